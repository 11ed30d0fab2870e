//! The simulated cell's world file (`wrc board-sim --world FILE`): read at start (created
//! from the stations' `[station.sim]` wafers when missing, never replaced when unreadable),
//! and kept up to date by [`WorldSaver`], a thread of its own that writes each new state
//! atomically (temporary file in the same directory, fsync, rename, directory fsync) and
//! prints what happened to the wafers. The board's stepping loop only hands it text; it never
//! touches the file.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::thread::JoinHandle;

use wrc_cell::{slot_codes_string, Stations, World, WorldError, WorldEvent};

/// A world file that cannot be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WorldFileError {
    /// The file exists but cannot be read.
    #[error("cannot read the world file {path}: {error}", path = path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why (in the message, so not also a `source`).
        error: io::Error,
    },
    /// The file does not hold a world of these stations.
    #[error(
        "world file {path}: {problem}; the simulated board does not replace it: fix it, or \
         remove it to start again from the stations' [station.sim] wafers",
        path = path.display()
    )]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What is wrong (in the message, so not also a `source`).
        problem: WorldError,
    },
    /// The file cannot be written.
    #[error("cannot write the world file {path}: {error}", path = path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why (in the message, so not also a `source`).
        error: io::Error,
    },
}

/// How [`load_or_create`] found the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// Read from the existing file.
    Loaded,
    /// The file did not exist: a new world from the stations, written to it.
    Created,
}

/// Read the world at `path` made with `stations`; when the file does not exist, start from
/// [`World::new`] and write it. An unreadable or unfitting file is an error, never replaced.
pub fn load_or_create(path: &Path, stations: &Stations) -> Result<(World, Origin), WorldFileError> {
    match fs::read_to_string(path) {
        Ok(text) => World::from_text(&text, stations)
            .map(|w| (w, Origin::Loaded))
            .map_err(|problem| WorldFileError::Corrupt {
                path: path.to_path_buf(),
                problem,
            }),
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            let world = World::new(stations);
            save_atomic(path, &world.to_text())?;
            Ok((world, Origin::Created))
        }
        Err(error) => Err(WorldFileError::Read {
            path: path.to_path_buf(),
            error,
        }),
    }
}

/// Read the world at `path` made with `stations` (no file is created).
pub fn load(path: &Path, stations: &Stations) -> Result<World, WorldFileError> {
    let text = fs::read_to_string(path).map_err(|error| WorldFileError::Read {
        path: path.to_path_buf(),
        error,
    })?;
    World::from_text(&text, stations).map_err(|problem| WorldFileError::Corrupt {
        path: path.to_path_buf(),
        problem,
    })
}

/// Replace `path` with `text` atomically: `FILE.tmp` in the same directory, fsync, rename
/// over `path`, fsync the directory (`wrc_cell::write_atomic`, the same write as the wafer
/// map's). A crash leaves the old file or the new one.
pub fn save_atomic(path: &Path, text: &str) -> Result<(), WorldFileError> {
    wrc_cell::write_atomic(path, text.as_bytes()).map_err(|error| WorldFileError::Write {
        path: path.to_path_buf(),
        error,
    })
}

/// One line on what happened to a wafer; faults start with `FAULT`.
pub fn describe_event(event: &WorldEvent) -> String {
    match *event {
        WorldEvent::Picked { station, slot, tag } => {
            format!("picked wafer T{tag} from {station} slot {slot}")
        }
        WorldEvent::Placed { station, slot, tag } => {
            format!("placed wafer T{tag} in {station} slot {slot}")
        }
        WorldEvent::Stacked { station, slot, tag } => format!(
            "FAULT: wafer T{tag} was set down onto the wafer in {station} slot {slot}, which \
             is now double"
        ),
        WorldEvent::Lost { tag } => {
            format!("FAULT: wafer T{tag} is lost: the vacuum went off away from any slot")
        }
        WorldEvent::Collision { station, slot } => format!(
            "FAULT: collision at {station} slot {slot}: the hand rose into a double or \
             cross-slotted slot, or into a wafer while carrying one"
        ),
        WorldEvent::UnclampedLift { station, slot } => format!(
            "FAULT: the hand rose through the wafer in {station} slot {slot} with the vacuum \
             off; the wafer stays"
        ),
        WorldEvent::SideCollision { station, body } => format!(
            "FAULT: side collision at {station}: {} touched it (a station is entered only \
             along its line, an obstacle never)",
            body.describe()
        ),
    }
}

/// The world as a few lines of text: one per station with its slot codes in groups of five
/// (`LP1 11111 11111 …`), then the hand, the lost wafers and the fault count, and the side
/// collisions among them if there were any.
pub fn summary(world: &World, stations: &Stations) -> String {
    let mut out = String::new();
    for s in stations.iter() {
        let codes = world
            .map_station(s.name.as_str())
            .map(|c| slot_codes_string(&c))
            .unwrap_or_default();
        let grouped: Vec<&str> = codes
            .as_bytes()
            .chunks(5)
            .map(|c| std::str::from_utf8(c).unwrap_or(""))
            .collect();
        out.push_str(&format!("{} {}\n", s.name, grouped.join(" ")));
    }
    let vacuum = if world.vacuum() { "on" } else { "off" };
    match world.hand() {
        Some(tag) => out.push_str(&format!("hand T{tag} (vacuum {vacuum})\n")),
        None => out.push_str(&format!("hand - (vacuum {vacuum})\n")),
    }
    if world.lost().is_empty() {
        out.push_str("lost -\n");
    } else {
        let lost: Vec<String> = world.lost().iter().map(|t| format!("T{t}")).collect();
        out.push_str(&format!("lost {}\n", lost.join(" ")));
    }
    out.push_str(&format!("faults {}\n", world.faults()));
    if let Some(station) = world.last_side_collision() {
        out.push_str(&format!(
            "side collisions {} (the latest at {station})\n",
            world.side_collisions()
        ));
    }
    out
}

/// What the board hands the saver after a change.
#[derive(Debug, Clone, PartialEq)]
pub struct Change {
    /// The world's text ([`World::to_text`]) to write, if there is a file.
    pub text: Option<String>,
    /// What happened, to report.
    pub event: Option<WorldEvent>,
    /// The world's fault count after it.
    pub faults: u32,
}

/// A thread that reports world events and writes the world file (see the module docs).
#[derive(Debug)]
pub struct WorldSaver {
    tx: Option<mpsc::Sender<Change>>,
    thread: Option<JoinHandle<()>>,
}

impl WorldSaver {
    /// Start the thread: it writes every change's text to `path` (when given) and passes
    /// every report line to `log`, and ends after [`WorldSaver::finish`].
    pub fn spawn(
        path: Option<PathBuf>,
        mut log: impl FnMut(&str) + Send + 'static,
    ) -> io::Result<WorldSaver> {
        let (tx, rx) = mpsc::channel::<Change>();
        let thread = std::thread::Builder::new()
            .name("world-saver".into())
            .spawn(move || {
                while let Ok(first) = rx.recv() {
                    // Report every event; write only the newest text of a burst.
                    let mut text = None;
                    for change in std::iter::once(first).chain(rx.try_iter()) {
                        if let Some(event) = &change.event {
                            let line = describe_event(event);
                            if event.is_fault() {
                                log(&format!("cell: {line} ({} faults so far)", change.faults));
                            } else {
                                log(&format!("cell: {line}"));
                            }
                        }
                        if change.text.is_some() {
                            text = change.text;
                        }
                    }
                    if let (Some(path), Some(text)) = (&path, text) {
                        if let Err(e) = save_atomic(path, &text) {
                            log(&e.to_string());
                        }
                    }
                }
            })?;
        Ok(WorldSaver {
            tx: Some(tx),
            thread: Some(thread),
        })
    }

    /// Hand over a change; never blocks.
    pub fn send(&self, change: Change) {
        if let Some(tx) = &self.tx {
            let _ = tx.send(change);
        }
    }

    /// Wait until everything handed over is reported and written, then end the thread.
    pub fn finish(mut self) {
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for WorldSaver {
    fn drop(&mut self) {
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};

    use wrc_cell::{SlotCode, StationName};

    use super::*;

    #[test]
    fn a_missing_file_is_created_and_a_bad_one_refused_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let stations = Stations::embedded_demo();
        let path = dir.path().join("world.toml");
        let (world, origin) = load_or_create(&path, &stations).unwrap();
        assert_eq!(origin, Origin::Created);
        assert_eq!(load(&path, &stations).unwrap(), world);
        let (again, origin) = load_or_create(&path, &stations).unwrap();
        assert_eq!((origin, again), (Origin::Loaded, world));
        assert!(!dir.path().join("world.toml.tmp").exists());

        fs::write(&path, "version = 1\nnonsense = true\n").unwrap();
        let e = load_or_create(&path, &stations).unwrap_err().to_string();
        assert!(
            e.contains("world.toml") && e.contains("does not replace it"),
            "{e}"
        );
        assert_eq!(
            fs::read_to_string(&path).unwrap(),
            "version = 1\nnonsense = true\n"
        );
        let e = save_atomic(Path::new("/nonexistent-wrc-dir/w.toml"), "x").unwrap_err();
        assert!(e.to_string().contains("/nonexistent-wrc-dir/w.toml"), "{e}");
    }

    #[test]
    fn the_summary_lists_every_station_the_hand_and_the_faults() {
        let stations = Stations::embedded_demo();
        let text = summary(&World::new(&stations), &stations);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], "LP1 11111 11111 11111 11111 11111");
        assert_eq!(lines[1], "LP2 00000 00000 00000 00000 00000");
        assert_eq!(lines[2], "AL 0");
        assert_eq!(lines[5], "BF1 00000");
        assert_eq!(&lines[6..], ["hand - (vacuum off)", "lost -", "faults 0"]);
        assert!(text.is_ascii());
        // A hand that turns inside PM2 hits its side.
        let robot = wrc_robot::Robot::paper_default();
        let mut world = World::new(&stations);
        world.set_arm(&robot, &stations, &[0.0]);
        let seat = stations.get("PM2").unwrap().seated_pose(1, false).unwrap();
        let q = robot
            .inverse(&seat, wrc_robot::Posture::Right, None)
            .unwrap();
        assert_eq!(world.touch(&q), None);
        let mut turned = q;
        turned[2] += 10.0;
        let event = world.touch(&turned).unwrap();
        assert_eq!(
            describe_event(&event),
            "FAULT: side collision at PM2: the hand touched it (a station is entered only \
             along its line, an obstacle never)"
        );
        let text = summary(&world, &stations);
        assert!(
            text.ends_with("faults 1\nside collisions 1 (the latest at PM2)\n"),
            "{text}"
        );
        assert_eq!(
            World::new(&stations).map_station("LP1").unwrap()[0],
            SlotCode::Present
        );
    }

    #[test]
    fn the_saver_reports_every_event_and_writes_the_newest_text() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("world.toml");
        let lines = Arc::new(Mutex::new(Vec::new()));
        let sink = lines.clone();
        let saver = WorldSaver::spawn(Some(path.clone()), move |l| {
            sink.lock().unwrap().push(l.to_string())
        })
        .unwrap();
        let station = StationName::new("LP1").unwrap();
        saver.send(Change {
            text: Some("first".into()),
            event: Some(WorldEvent::Picked {
                station,
                slot: 3,
                tag: 3,
            }),
            faults: 0,
        });
        saver.send(Change {
            text: Some("second".into()),
            event: Some(WorldEvent::Lost { tag: 3 }),
            faults: 1,
        });
        saver.finish();
        assert_eq!(fs::read_to_string(&path).unwrap(), "second");
        let lines = lines.lock().unwrap();
        assert_eq!(lines[0], "cell: picked wafer T3 from LP1 slot 3");
        assert!(
            lines[1].starts_with("cell: FAULT: wafer T3 is lost") && lines[1].contains("1 faults"),
            "{lines:?}"
        );
    }
}
