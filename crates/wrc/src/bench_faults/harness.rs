//! What a fault round drives and looks at besides `wrc up` and its connections (those are
//! [`crate::up_process`]'s): a `wrc board-sim` that outlives the controller, the processes of
//! a state directory, the board seen through its DPRAM, and the simulated cell's world file
//! against the wafer map. Every wait has a deadline; nothing here sleeps in the hope that a
//! process got somewhere.

use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

pub(super) use crate::up_process::{
    exe, free_port, free_udp, poll, Conn, Lines, Tmpfs, Up, UpOptions, PATIENCE, PROBE,
};
use anyhow::{bail, Context};
use wrc_board::{DpramBoard, Expect, Fault, Feedback, MotionBoard};
use wrc_cell::{Blade, Stations, Tracking, WaferMap, World};

/// Whether user namespaces with a tmpfs of their own work here: the reason when not.
pub(super) fn tmpfs_namespaces_work(dir: &Path) -> Result<(), String> {
    let probe = dir.join("probe");
    std::fs::create_dir_all(&probe).map_err(|e| e.to_string())?;
    let out = Command::new("unshare")
        .args(["--user", "--map-root-user", "--mount", "sh", "-c"])
        .arg("mount -t tmpfs -o size=65536 tmpfs \"$0\" && mount -o remount,bind,ro \"$0\"")
        .arg(&probe)
        .output();
    let _ = std::fs::remove_dir(&probe);
    match out {
        Err(e) => Err(format!("cannot run unshare (util-linux): {e}")),
        Ok(o) if !o.status.success() => Err(format!(
            "unshare --user --map-root-user --mount with a tmpfs failed: {}",
            String::from_utf8_lossy(&o.stderr).trim()
        )),
        Ok(_) => Ok(()),
    }
}

/// The processes whose command line names `dir` and runs `what` (`board-sim`, `ui`): their
/// ids.
pub(super) fn processes(dir: &Path, what: &str) -> Vec<u32> {
    let needle = dir.to_string_lossy().to_string();
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    entries
        .flatten()
        .filter_map(|e| {
            let pid: u32 = e.file_name().to_str()?.parse().ok()?;
            let cmd = std::fs::read(e.path().join("cmdline")).ok()?;
            let words: Vec<String> = cmd
                .split(|&b| b == 0)
                .map(|w| String::from_utf8_lossy(w).into_owned())
                .collect();
            let names_dir = words.iter().any(|w| w.contains(&needle));
            let runs = words.iter().any(|w| w == what);
            (names_dir && runs && !zombie(pid)).then_some(pid)
        })
        .collect()
}

/// Whether process `pid` has exited (gone, or a zombie not yet reaped).
pub(super) fn zombie(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => true,
        Ok(stat) => stat
            .rsplit_once(')')
            .is_some_and(|(_, rest)| rest.trim_start().starts_with('Z')),
    }
}

/// `kill -9 pid`; the instant the signal was sent.
pub(super) fn kill9(pid: u32) -> anyhow::Result<Instant> {
    let t = Instant::now();
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(pid as i32),
        nix::sys::signal::Signal::SIGKILL,
    )
    .with_context(|| format!("kill -9 {pid}"))?;
    Ok(t)
}

/// A simulated board seen through its DPRAM, read only: its own period count is the clock
/// the arm moves on.
pub(super) struct BoardView {
    board: DpramBoard,
}

impl BoardView {
    /// The board on `dpram` (waits until it is set up).
    pub(super) fn open(dpram: &Path) -> anyhow::Result<BoardView> {
        let board = poll(PATIENCE, || DpramBoard::open(dpram, Expect::default()).ok())
            .with_context(|| format!("no board on {}", dpram.display()))?;
        Ok(BoardView { board })
    }

    /// Its feedback (a read torn by the board's own update is read again).
    pub(super) fn feedback(&self) -> Feedback {
        let mut f = Feedback::default();
        let _ = poll(PATIENCE, || self.board.read_feedback(&mut f).ok());
        f
    }

    /// Post a fault to its mailbox and wait until the board has taken it; the instant it
    /// was posted.
    pub(super) fn inject(&self, fault: Fault) -> anyhow::Result<Instant> {
        let d = self.board.dpram();
        let taken =
            || d.load(wrc_board::layout::fault::ACK) == d.load(wrc_board::layout::fault::SEQ);
        poll(PATIENCE, || taken().then_some(())).context("the board does not take faults")?;
        let t = Instant::now();
        if !fault.inject(d) {
            bail!("the board's fault mailbox is busy");
        }
        poll(PATIENCE, || taken().then_some(()))
            .with_context(|| format!("the board did not take \"{fault}\""))?;
        Ok(t)
    }

    /// Wait until the arm stands still on the board: `still` periods in a row in which no
    /// axis executed a pulse and no encoder moved. Returns the board period at which the
    /// still stretch began, or `None` when it has not come within `bound` periods of
    /// `from_period` (plus the stretch itself).
    pub(super) fn rest_after(&self, from_period: u64, bound: u64, still: u64) -> Option<u64> {
        let mut last = self.feedback();
        let mut since = last.boards[0].period_count;
        let deadline_period = from_period + bound + still;
        let wall = Instant::now() + PATIENCE;
        loop {
            std::thread::sleep(PROBE);
            let f = self.feedback();
            let now = f.boards[0].period_count;
            if now == last.boards[0].period_count {
                if Instant::now() > wall {
                    return None; // the board stopped counting
                }
                continue;
            }
            let moved = f.axes[..f.axis_count]
                .iter()
                .zip(&last.axes[..last.axis_count])
                .any(|(a, b)| a.increment != 0 || a.encoder != b.encoder);
            if moved {
                since = now;
            }
            last = f;
            if now >= since + still {
                return (since <= from_period + bound).then_some(since.max(from_period));
            }
            if now > deadline_period {
                return None;
            }
        }
    }
}

/// The simulated cell's ground truth, read from its world file.
pub(super) fn read_world(path: &Path) -> anyhow::Result<World> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read the world file {}", path.display()))?;
    Ok(World::from_text(&text, &Stations::embedded_demo())?)
}

/// How the controller's wafer map compared with the simulated cell.
pub(super) struct MapCheck {
    /// Empty when the map (in memory and on disk) agrees with the cell place by place and
    /// wafer by wafer.
    pub(super) problems: Vec<String>,
}

/// Compare the controller's map — `WAFERS` (memory) and `wafers.toml` (disk) — with the
/// world file, binding the controller's wafer ids to the cell's physical wafers in
/// `tracking` (kept over the campaign of one state directory). Waits (within [`PATIENCE`])
/// for a pending transfer to settle and for the board's saver to write the world, both
/// asynchronous.
pub(super) fn check_map(
    host: &mut Conn,
    wafers_file: &Path,
    world_file: &Path,
    tracking: &mut Tracking,
    wafers_total: usize,
) -> MapCheck {
    check_map_with(host, wafers_file, world_file, tracking, wafers_total, false)
}

/// [`check_map`], with `uncertain_ok`: an uncertain place (`W3?`, after a power loss) may
/// hold its wafer or nothing, and is not a problem by itself; the map still claims no
/// certain wafer the cell does not hold there and forgets none the cell holds.
pub(super) fn check_map_with(
    host: &mut Conn,
    wafers_file: &Path,
    world_file: &Path,
    tracking: &mut Tracking,
    wafers_total: usize,
    uncertain_ok: bool,
) -> MapCheck {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let mut problems = Vec::new();
        let body = match host.wafers() {
            Ok(b) => b,
            Err(e) => {
                problems.push(format!("WAFERS: {e:#}"));
                None
            }
        };
        let map = WaferMap::load(wafers_file);
        let world = read_world(world_file);
        let mut trial = tracking.clone();
        match (&map, &world) {
            (Ok(map), Ok(world)) => {
                // A wafer the controller is still settling from its sensor (`W3?`, for a
                // moment after RESET) is not a map to judge yet.
                if !uncertain_ok && Blade::ALL.iter().any(|b| map.is_uncertain(*b)) {
                    problems.push(format!(
                        "the hand's wafer is still uncertain: `{}`",
                        map.wafers_line()
                    ));
                }
                if let Some(body) = &body {
                    if *body != map.wafers_line() {
                        problems.push(format!(
                            "WAFERS says `{body}` but {} says `{}`",
                            wafers_file.display(),
                            map.wafers_line()
                        ));
                    }
                }
                problems.extend(trial.check(map, world).iter().map(ToString::to_string));
                let lost = world.lost().len();
                let in_cell = world.tags().len();
                if in_cell + lost != wafers_total {
                    problems.push(format!(
                        "the cell holds {in_cell} wafers and lost {lost}, of {wafers_total}"
                    ));
                }
            }
            (Err(e), _) => problems.push(format!("the wafer map file: {e}")),
            (_, Err(e)) => problems.push(format!("{e:#}")),
        }
        if problems.is_empty() {
            *tracking = trial;
            return MapCheck { problems };
        }
        if Instant::now() >= deadline {
            return MapCheck { problems };
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A `wrc board-sim` of the campaign's own, outliving the controllers that use it.
pub(super) struct Board {
    child: Option<Child>,
    /// Its DPRAM.
    pub(super) dpram: PathBuf,
}

impl Board {
    /// Start board 0 of `config` on `dir/board0.dpram` with the demo cell (`dir/stations.toml`,
    /// ground truth `dir/world.toml`), its host watchdog at `watchdog_periods`, stepping at
    /// SCHED_FIFO when `realtime` (as `wrc up` starts its own).
    pub(super) fn start(
        dir: &Path,
        config: Option<&Path>,
        watchdog_periods: u32,
        realtime: bool,
    ) -> anyhow::Result<Board> {
        std::fs::create_dir_all(dir)?;
        let stations = dir.join("stations.toml");
        if !stations.exists() {
            Stations::embedded_demo().save_atomic(&stations)?;
        }
        let dpram = dir.join("board0.dpram");
        let world = dir.join("world.toml");
        let child = crate::up::spawn_board(
            config,
            0,
            &dpram,
            &dir.join("board0.log"),
            Some(watchdog_periods),
            realtime,
            Some((&stations, &world)),
        )?;
        Ok(Board {
            child: Some(child),
            dpram,
        })
    }
}

impl Drop for Board {
    fn drop(&mut self) {
        if let Some(c) = self.child.as_mut() {
            crate::up::stop_children(std::slice::from_mut(c));
        }
    }
}
