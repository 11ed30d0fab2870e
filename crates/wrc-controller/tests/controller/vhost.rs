//! A host session with the whole controller on virtual time: the embedded default
//! configuration and the demo cell, a client on the local socket, and the ground truth of
//! the simulated cell read directly. The methods speak as the process-level tests' client
//! does (`ask`, `motion`, `WHERE`, …); every wait is bounded in virtual time, so a test
//! that fails ends at once and the wall clock never decides anything.

use std::path::{Path, PathBuf};

use wrc_board::wrc_cell::{parse_slot_list, slot_codes_string, SlotCode, World};
use wrc_board::Fault;
use wrc_config::Config;
use wrc_controller::simulation::{SimCellFrom, SimClient, Simulation};
use wrc_protocol::reply_field;

/// Virtual time any single line may take to come [ns]: longer than any motion of the demo
/// cell, far shorter than a program that hangs.
pub const LINE_NS: u64 = 60_000_000_000;

/// Virtual time a polled condition may take ([`VHost::poll`]) [ns].
const PATIENCE_NS: u64 = 60_000_000_000;

/// Virtual time between two probes of a polled condition [ns]: one Pulse Generator period.
const POLL_NS: u64 = 10_000_000;

pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The controller of the embedded default configuration with the demo cell (or the cell
/// of `cell`), its state in `dir`.
pub fn demo(dir: &Path, cell: SimCellFrom<'_>) -> Simulation {
    demo_with(&Config::embedded_default(), dir, cell)
}

/// The controller of `config` with the demo cell (or the cell of `cell`), its state in `dir`.
pub fn demo_with(config: &Config, dir: &Path, cell: SimCellFrom<'_>) -> Simulation {
    // Nobody listens on the simulator port; datagrams to a closed port are dropped.
    let sim_addr = "127.0.0.1:9".parse().unwrap();
    Simulation::in_state_dir(config, dir, cell, None, sim_addr).unwrap()
}

/// The shipped dual-blade example configuration (config/dual-blade.toml).
pub fn dual_blade() -> Config {
    let path = repo().join("config/dual-blade.toml");
    Config::load(Some(&path)).unwrap()
}

/// The simulated cell's occupancy of `station`: `1` a wafer, `0` empty, `2` a double, `X`
/// cross-slotted (as `MAP` reports it).
pub fn truth_codes(sim: &Simulation, station: &str) -> String {
    let board = sim.board(0).unwrap();
    let world = board.cell().unwrap().world();
    slot_codes_string(&world.map_station(station).unwrap())
}

/// The map's occupancy of `station` in a `WAFERS` reply, as `MAP` codes (`1` a wafer, `0`
/// empty, `2`/`X` faults, `?` unknown): comparable with [`truth_codes`].
pub fn map_codes(wafers: &str, station: &str) -> String {
    let list = reply_field(wafers, station).unwrap_or_else(|| panic!("no {station} in {wafers}"));
    parse_slot_list(list)
        .unwrap_or_else(|| panic!("{station}'s list does not read: {wafers}"))
        .iter()
        .map(|s| s.code().map_or('?', SlotCode::as_char))
        .collect()
}

/// One host on a simulated controller.
pub struct VHost {
    pub sim: Simulation,
    client: SimClient,
    /// Every line received, events included.
    pub seen: Vec<String>,
    _dir: tempfile::TempDir,
}

impl VHost {
    /// The embedded default with the demo cell, in a fresh state directory.
    pub fn start() -> VHost {
        VHost::start_with(SimCellFrom::default())
    }

    /// The embedded default with the cell of `cell`, in a fresh state directory.
    pub fn start_with(cell: SimCellFrom<'_>) -> VHost {
        VHost::start_config(&Config::embedded_default(), cell)
    }

    /// `config` with the cell of `cell`, in a fresh state directory.
    pub fn start_config(config: &Config, cell: SimCellFrom<'_>) -> VHost {
        let dir = tempfile::tempdir().unwrap();
        let mut sim = demo_with(config, dir.path(), cell);
        let client = sim.connect().unwrap();
        VHost {
            sim,
            client,
            seen: Vec::new(),
            _dir: dir,
        }
    }

    /// The controller's state directory (wafer map, journal, programs).
    pub fn dir(&self) -> &Path {
        self._dir.path()
    }

    /// The next line, events included.
    pub fn line(&mut self) -> String {
        let l = self
            .sim
            .next_line(&mut self.client, LINE_NS)
            .unwrap_or_else(|e| panic!("{e}; seen so far: {:?}", self.seen));
        self.seen.push(l.clone());
        l
    }

    /// Send `text` (whole lines) now.
    pub fn send_raw(&mut self, text: &str) {
        self.sim.send(&mut self.client, text).unwrap();
    }

    /// `UPLOAD` of `text` as program `name` with request id `id`: the reply.
    pub fn upload(&mut self, id: u32, name: &str, text: &str) -> String {
        let mut lines = format!("{id} UPLOAD {name}\n");
        for l in text.lines() {
            lines.push_str(l);
            lines.push('\n');
        }
        lines.push_str(".\n");
        self.send_raw(&lines);
        self.reply()
    }

    /// Send `line` and return the first reply that is not an event.
    pub fn ask(&mut self, line: &str) -> String {
        self.send_raw(&format!("{line}\n"));
        self.reply()
    }

    /// The next line that is not an event.
    pub fn reply(&mut self) -> String {
        loop {
            let l = self.line();
            if !l.starts_with("EVT") {
                return l;
            }
        }
    }

    /// Send a motion with `id`: expect ACK (with or without a note: `route=travel`, a
    /// motion that goes round the cell), then return the final INF/ABS.
    pub fn motion(&mut self, id: u32, line: &str) -> String {
        let ack = self.ask(&format!("{id} {line}"));
        let plain = format!("ACK {id}");
        assert!(
            ack == plain || ack.starts_with(&format!("{plain} route=")),
            "{line}: {ack}"
        );
        self.reply()
    }

    /// Read until a line that starts with `prefix`, and return it.
    pub fn until(&mut self, prefix: &str) -> String {
        loop {
            let l = self.line();
            if l.starts_with(prefix) {
                return l;
            }
        }
    }

    /// `WHERE`: the joints [deg, deg, deg, mm] and the hand's x and y [mm].
    pub fn where_(&mut self) -> (Vec<f64>, f64, f64) {
        let r = self.ask("WHERE");
        let field = |k: &str| reply_field(&r, k).unwrap_or_else(|| panic!("no {k} in {r}"));
        let joints = field("j").split(',').map(|v| v.parse().unwrap()).collect();
        (
            joints,
            field("x").parse().unwrap(),
            field("y").parse().unwrap(),
        )
    }

    pub fn status(&mut self) -> String {
        self.ask("STATUS")
    }

    /// Probe until it gives `Ok` and return its value, letting [`POLL_NS`] of virtual time
    /// pass between two probes (a reply takes no virtual time: probing without it would
    /// never see the robot move); fail, naming `what` and what the last probe saw, after
    /// [`PATIENCE_NS`] of virtual time.
    pub fn poll<T>(
        &mut self,
        what: &str,
        mut probe: impl FnMut(&mut VHost) -> Result<T, String>,
    ) -> T {
        let until = self.sim.now_ns() + PATIENCE_NS;
        loop {
            match probe(self) {
                Ok(value) => return value,
                Err(last) if self.sim.now_ns() >= until => {
                    panic!("waited {PATIENCE_NS} ns of virtual time in vain for {what}; last seen: {last}")
                }
                Err(_) => self.sim.run_for_ns(POLL_NS),
            }
        }
    }

    /// Poll STATUS and WHERE until the arm is MOVING and `moved(joints, x, y)` says it has
    /// got far enough (`what`, for the failure message).
    pub fn wait_moving(&mut self, what: &str, moved: impl Fn(&[f64], f64, f64) -> bool) {
        self.poll(what, |host| {
            let status = host.status();
            if !status.contains("state=MOVING") {
                return Err(status);
            }
            let (j, x, y) = host.where_();
            if moved(&j, x, y) {
                Ok(())
            } else {
                Err(format!("j={j:?} x={x} y={y}"))
            }
        })
    }

    /// `WAFERS` once the map has settled every wafer job that ended and no transfer is
    /// pending any more: one that ended abnormally is judged by its journal and the vacuum
    /// sensors when the arm stands still and the sensor has answered.
    pub fn settled_wafers(&mut self) -> String {
        self.poll("the wafer map settled, no transfer pending", |host| {
            let settled = host.sim.shared().map_settled();
            let map = host.ask("WAFERS");
            if map.contains("pending=") || !settled {
                Err(map)
            } else {
                Ok(map)
            }
        })
    }

    /// Inject a board fault (`wrc board-sim inject`'s words: `sensor-flip 14 on`, …) into
    /// board 0 now.
    pub fn inject(&mut self, fault: &str) {
        let fault: Fault = fault.parse().unwrap();
        self.sim.board(0).unwrap().apply_fault(fault);
    }

    /// The simulated cell's occupancy of `station` ([`truth_codes`]).
    pub fn truth(&self, station: &str) -> String {
        truth_codes(&self.sim, station)
    }

    /// Whether the simulated cell's hand holds no wafer.
    pub fn blade_empty(&self, blade: wrc_cell::Blade) -> bool {
        let board = self.sim.board(0).unwrap();
        board.cell().unwrap().world().hand_of(blade).is_none()
    }

    pub fn hand_empty(&self) -> bool {
        let board = self.sim.board(0).unwrap();
        board.cell().unwrap().world().hand().is_none()
    }

    /// Replace the simulated cell's ground truth by `edit` of its world file's text (what an
    /// operator did by hand, or a wafer that slipped off a blade).
    pub fn edit_world(&self, edit: impl FnOnce(&str) -> String) {
        let mut board = self.sim.board(0).unwrap();
        let cell = board.take_cell().unwrap();
        let text = edit(&cell.world().to_text());
        let world = World::from_text(&text, cell.stations()).unwrap();
        board.attach_cell(cell.with_world(world)).unwrap();
    }

    /// The wafer on `blade` slips off it in the simulated cell now (it is lost, as a wafer
    /// dropped away from any slot is), whatever the vacuum does.
    pub fn drop_from_blade(&self, blade: wrc_cell::Blade) {
        let key = if blade == wrc_cell::Blade::A {
            "hand = "
        } else {
            "hand_b = "
        };
        self.edit_world(|text| {
            let line = text
                .lines()
                .find(|l| l.starts_with(key))
                .unwrap_or_else(|| panic!("no wafer on blade {blade} in the cell:\n{text}"));
            let tag = line[key.len()..].trim().to_string();
            let lost = text
                .lines()
                .find(|l| l.starts_with("lost = "))
                .unwrap_or_else(|| panic!("no lost list:\n{text}"));
            let list = lost["lost = ".len()..].trim();
            let more = if list == "[]" {
                format!("lost = [{tag}]")
            } else {
                format!("lost = {}, {tag}]", list.trim_end_matches(']'))
            };
            text.replacen(&format!("{line}\n"), "", 1)
                .replacen(lost, &more, 1)
        });
        assert!(self.blade_empty(blade));
    }

    /// A copy of the simulated cell's ground truth as it is now.
    pub fn world(&self) -> World {
        let board = self.sim.board(0).unwrap();
        board.cell().unwrap().world().clone()
    }

    /// Board 0's encoders now, channel order [pulse].
    pub fn encoders(&self) -> Vec<i64> {
        let board = self.sim.board(0).unwrap();
        (0..4)
            .filter_map(|c| board.axis(c))
            .map(|a| a.encoder())
            .collect()
    }

    /// A power cut now and the power back ([`Simulation::power_cycle`]): a new controller
    /// in the same state directory, on boards powered up where the arm stood; this host
    /// connects to it again (the lines seen so far are kept).
    pub fn power_cycle(self) -> VHost {
        let VHost {
            sim,
            client,
            seen,
            _dir,
        } = self;
        let mut sim = sim.power_cycle().unwrap();
        drop(client);
        let client = sim.connect().unwrap();
        VHost {
            sim,
            client,
            seen,
            _dir,
        }
    }
}
