//! The wafer map under crashes: `wrc up` killed with SIGKILL again and again during
//! transfers (in each of the windows a crash can hit, found by the events the host hears)
//! never loses or duplicates a wafer in the map, checked against the simulated board's
//! ground truth after every restart. This one stays in real time: it tests what survives a
//! killed process (the files, the board outliving the controller). The 25-wafer cycle of
//! the demo program runs under virtual time (`wrc-controller`'s `virtual_time` tests).
//!
//! It runs the demo cell with the stations' speed limits lifted to 100 % and the Command
//! Interpreter, Velocity Generator and I/O Monitor at 10 ms instead of Table 1's 50/50/100 ms,
//! so that its transfers fit in a test run; the steps, checks and files are the same.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use wrc_board::wrc_cell::{parse_slot_list, SlotCode};
use wrc_protocol::reply_field;

use crate::up::{free_port, Client};
use crate::{text, wait_until, wrc, BoardView};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The fast test configuration and stations (see the module docs), written into `dir`.
fn fast_cell(dir: &Path) -> (PathBuf, PathBuf) {
    let config = std::fs::read_to_string(repo().join("config/default.toml")).unwrap();
    let mut fast = String::new();
    let mut task = "";
    for line in config.lines() {
        if let Some(name) = line.strip_prefix("name = \"") {
            task = name.trim_end_matches('"');
        }
        let faster = ["velocity_generator", "command_interpreter", "io_monitor"].contains(&task);
        if faster && line.starts_with("period_ms") {
            fast.push_str("period_ms = 10\n");
        } else {
            fast.push_str(line);
            fast.push('\n');
        }
    }
    assert_eq!(fast.matches("period_ms = 10\n").count(), 5, "{fast}");
    let stations = std::fs::read_to_string(repo().join("config/stations.toml")).unwrap();
    let stations: String = stations
        .lines()
        .map(|l| {
            if l.starts_with("speed_pct") {
                "speed_pct = 100.0\n".to_string()
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    let (c, s) = (dir.join("fast.toml"), dir.join("fast-stations.toml"));
    std::fs::write(&c, fast).unwrap();
    std::fs::write(&s, stations).unwrap();
    (c, s)
}

/// The map's occupancy of `station` from a `WAFERS` reply: `1` a wafer, `0` empty, `?`
/// unknown, `2`/`X` faults.
fn map_codes(wafers: &str, station: &str) -> String {
    let list = reply_field(wafers, station).unwrap_or_else(|| panic!("no {station} in {wafers}"));
    parse_slot_list(list)
        .unwrap_or_else(|| panic!("{station}'s list does not read: {wafers}"))
        .iter()
        .map(|s| s.code().map_or('?', SlotCode::as_char))
        .collect()
}

/// The ground truth: `wrc board-sim world` of the world file, one line per station
/// (`LP1 11111…`) and the hand.
fn truth(world: &Path) -> String {
    let out = wrc(&["board-sim", "world", "--world", world.to_str().unwrap()]);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}{stderr}");
    stdout
}

/// The ground truth's codes of `station` (spaces removed).
pub(crate) fn truth_codes(world: &Path, station: &str) -> String {
    truth(world)
        .lines()
        .find_map(|l| l.strip_prefix(&format!("{station} ")))
        .unwrap_or_else(|| panic!("no {station} in the world: {}", truth(world)))
        .replace(' ', "")
}

fn hand(wafers: &str) -> &str {
    reply_field(wafers, "hand").unwrap()
}

/// The map (after any start-up reconciliation) agrees with the cell: every station's
/// occupancy, the hand, and 25 wafers in all, none lost.
fn check_against_truth(host: &mut Client, world: &Path, when: &str) {
    let wafers = wait_until(&format!("{when}: no transfer pending"), || {
        let w = host.ask("WAFERS");
        if w.contains("pending=") {
            Err(w)
        } else {
            Ok(w)
        }
    });
    let t = truth(world);
    let mut total = 0;
    for station in ["LP1", "LP2", "AL"] {
        let map = map_codes(&wafers, station);
        let real = truth_codes(world, station);
        assert_eq!(
            map, real,
            "{when}: {station} in the map vs the cell\n{wafers}\n{t}"
        );
        total += map.matches('1').count();
    }
    let on_hand = hand(&wafers) != "-";
    assert_eq!(
        on_hand,
        !t.contains("hand -"),
        "{when}: the hand in the map vs the cell\n{wafers}\n{t}"
    );
    total += usize::from(on_hand);
    assert_eq!(total, 25, "{when}: wafers in the map\n{wafers}\n{t}");
    assert!(t.contains("lost -"), "{when}: the cell lost a wafer\n{t}");
}

/// A process killed when the test ends, passed or failed (the board, every `wrc up`).
pub(crate) struct KillOnDrop(pub(crate) Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn start_up(dir: &Path, dpram: &Path, config: &Path, stations: &Path, port: u16) -> KillOnDrop {
    let up = Command::new(env!("CARGO_BIN_EXE_wrc"))
        .args(["up", "--no-rt", "--no-ui"])
        .args(["--port", &format!("127.0.0.1:{port}")])
        .args(["--sim-addr", &format!("127.0.0.1:{}", free_port())])
        .arg("--state-dir")
        .arg(dir)
        .arg("--board")
        .arg(dpram)
        .arg("--config")
        .arg(config)
        .arg("--stations")
        .arg(stations)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let up = KillOnDrop(up);
    wait_until("wrc up to open its port", || {
        std::net::TcpStream::connect(("127.0.0.1", port)).map_err(|e| e.to_string())
    });
    up
}

/// Where each round kills the controller: right after the host hears the `n`-th line that
/// starts with the text, counted from the program's start (input 0 is the hand's vacuum
/// sensor). Between them the rounds hit every window a crash can fall in.
const KILLS: [(&str, usize, &str); 4] = [
    (
        "EVT WAFER pending=get:",
        2,
        "a GET announced, the hand on its way to the wafer",
    ),
    (
        "EVT INPUT 0 1",
        2,
        "a wafer sensed on the hand, its GET not yet in the map",
    ),
    (
        "EVT INPUT 0 0",
        2,
        "a wafer released by a PUT, not yet in the map",
    ),
    (
        "EVT WAFER pending=-",
        3,
        "a transfer in the map, the next one not yet begun",
    ),
];

#[test]
fn kill_9_during_transfers_never_loses_or_duplicates_a_wafer() {
    let scratch = tempfile::tempdir().unwrap();
    let (config, stations) = fast_cell(scratch.path());
    let state = scratch.path().join("state");
    std::fs::create_dir_all(&state).unwrap();
    let dpram = scratch.path().join("board0.dpram");
    let world = scratch.path().join("world.toml");
    // The board runs on its own, like hardware, and outlives every controller.
    let mut board = Command::new(env!("CARGO_BIN_EXE_wrc"))
        .args(["board-sim", "--watchdog-periods", "100", "--dpram"])
        .arg(&dpram)
        .arg("--config")
        .arg(&config)
        .arg("--stations")
        .arg(&stations)
        .arg("--world")
        .arg(&world)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stderr = board.stderr.take().unwrap();
    let board = KillOnDrop(board);
    let mut lines = BufReader::new(stderr).lines();
    // Wait for the board to be up.
    loop {
        let l = lines.next().expect("board-sim ended").unwrap();
        if l.contains("board 0 with") {
            break;
        }
    }
    std::thread::spawn(move || for _ in lines {});

    let view = BoardView::open(&dpram);
    for (round, (event, nth, window)) in (1..).zip(KILLS) {
        let port = free_port();
        let mut up = start_up(&state, &dpram, &config, &stations, port);
        let mut host = Client::connect_to(port);
        if round > 1 {
            check_against_truth(&mut host, &world, &format!("restart {round}"));
        }
        assert!(host.ask("CONTROL").starts_with("ACK"));
        // The board stopped the arm when the controller died (its watchdog): RESET, HOME.
        let _ = host.ask("RESET");
        assert_eq!(host.motion(1, "HOME"), "INF 1", "round {round}");
        if round == 1 {
            for (id, station) in [(2, "LP1"), (3, "LP2"), (4, "AL")] {
                let r = host.motion(id, &format!("MAP {station}"));
                let want = format!("INF {id} {station} ");
                assert!(r.starts_with(&want), "{r}: {:?}", host.seen);
            }
            check_against_truth(&mut host, &world, "after mapping");
        }
        // Carry on: the hand's wafer to LP2, then LP1's wafers slot for slot through AL.
        let wafers = host.ask("WAFERS");
        let mut program = String::new();
        if let Some(id) = hand(&wafers).strip_prefix('W') {
            let lp2 = map_codes(&wafers, "LP2");
            let free = lp2.find('0').unwrap() + 1;
            program.push_str(&format!("PUT \"LP2\", {free}\n' W{id}\n"));
        }
        if map_codes(&wafers, "AL") == "1" {
            program.push_str("GET \"AL\", 1\n");
            let lp2 = map_codes(&wafers, "LP2");
            let free = lp2.find('0').unwrap() + 1;
            program.push_str(&format!("PUT \"LP2\", {free}\n"));
        }
        let lp1 = map_codes(&wafers, "LP1");
        for (i, c) in lp1.chars().enumerate() {
            if c == '1' {
                let s = i + 1;
                program.push_str(&format!(
                    "GET \"LP1\", {s}\nPUT \"AL\", 1\nGET \"AL\", 1\nPUT \"LP2\", {s}\n"
                ));
            }
        }
        host.send_raw(b"UPLOAD carry\n");
        for line in program.lines() {
            host.send_raw(format!("{line}\n").as_bytes());
        }
        assert!(host.ask(".").starts_with("ACK name=carry"), "{program}");
        assert_eq!(host.ask("5 RUN carry"), "ACK 5");
        let mut heard = 0;
        while heard < nth {
            let l = host.line();
            assert!(
                !l.starts_with("INF 5") && !l.starts_with("ABS 5"),
                "round {round}: the program ended before {window}: {:?}",
                host.seen
            );
            heard += usize::from(l.starts_with(event));
        }
        let trips = view.feedback().boards[0].watchdog_trips;
        up.0.kill().unwrap();
        up.0.wait().unwrap();
        drop(host);
        // The board stops the arm by itself once the dead controller's watchdog refreshes
        // stop coming; its saver thread writes the cell to the world file right after each
        // change, and the last change came before the arm stood still.
        wait_until(&format!("round {round}: the board's watchdog trip"), || {
            let now = view.feedback().boards[0].watchdog_trips;
            if now > trips {
                Ok(())
            } else {
                Err(format!("{now} trips"))
            }
        });
        view.wait_at_rest();
    }
    // A last restart: the map still matches the cell.
    let port = free_port();
    let up = start_up(&state, &dpram, &config, &stations, port);
    let mut host = Client::connect_to(port);
    check_against_truth(&mut host, &world, "the last restart");
    drop(up);
    drop(board);
}
