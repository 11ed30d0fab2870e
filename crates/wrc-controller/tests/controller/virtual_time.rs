//! The whole controller under virtual time ([`wrc_controller::simulation`]): the bundled
//! 25-wafer program on the demo cell with the map checked against the simulated cell's
//! ground truth, and two runs with the same inputs that must be byte-identical.
//!
//! These run the embedded default configuration unchanged (Table 1's periods, the demo
//! cell's speeds): virtual time makes the 6-minute cycle cost seconds.

use std::path::Path;

use wrc_controller::simulation::{SimCellFrom, SimClient, Simulation, START_NS};

use crate::vhost::{demo, map_codes, repo, truth_codes};

/// Virtual time any single reply may take [ns].
const REPLY_NS: u64 = 5_000_000_000;

/// Upload `text` as program `name`, run it, and return every line heard until it ended
/// (its `INF` or `ABS` last), each with the virtual time it came at [ns].
fn run_program(
    sim: &mut Simulation,
    host: &mut SimClient,
    name: &str,
    text: &str,
) -> Vec<(u64, String)> {
    let mut upload = format!("1 UPLOAD {name}\n");
    for line in text.lines() {
        upload.push_str(line);
        upload.push('\n');
    }
    upload.push_str(".\n");
    sim.send(host, &upload).unwrap();
    let mut heard = Vec::new();
    loop {
        let l = sim.next_line(host, REPLY_NS).unwrap();
        heard.push((sim.now_ns() - START_NS, l.clone()));
        if l.starts_with("ACK 1") {
            break;
        }
        assert!(!l.starts_with("NAK"), "{heard:?}");
    }
    sim.send(host, &format!("2 RUN {name}\n")).unwrap();
    loop {
        // A transfer's motions take seconds; none takes a minute.
        let l = sim.next_line(host, 60_000_000_000).unwrap();
        heard.push((sim.now_ns() - START_NS, l.clone()));
        if l.starts_with("INF 2") || l.starts_with("ABS") || l.starts_with("NAK") {
            return heard;
        }
    }
}

#[test]
fn the_demo_program_moves_25_wafers_lp1_al_lp2_and_the_map_matches_the_cell() {
    let dir = tempfile::tempdir().unwrap();
    let mut sim = demo(dir.path(), SimCellFrom::default());
    let mut host = sim.connect().unwrap();
    // Its library first: the program compiles against it when it is stored.
    let library = std::fs::read_to_string(repo().join("examples/cell_lib.wrl")).unwrap();
    let mut upload = String::from("7 UPLOAD cell_lib\n");
    for line in library.lines() {
        upload.push_str(line);
        upload.push('\n');
    }
    upload.push_str(".\n");
    sim.send(&mut host, &upload).unwrap();
    let ack = sim.next_line(&mut host, REPLY_NS).unwrap();
    assert!(ack.starts_with("ACK 7 name=cell_lib "), "{ack}");
    let program = std::fs::read_to_string(repo().join("examples/wafer_cycle.wrl")).unwrap();
    let heard: Vec<String> = run_program(&mut sim, &mut host, "wafer_cycle", &program)
        .into_iter()
        .map(|(_, l)| l)
        .collect();
    let last = heard.last().unwrap();
    assert_eq!(last, "INF 2", "{heard:#?}");
    let prints: Vec<&String> = heard
        .iter()
        .filter(|l| l.starts_with("EVT PRINT"))
        .collect();
    for n in 1..=25 {
        let line = format!("EVT PRINT wafer {n} of 25: LP1 slot {n} -> AL -> LP2 slot {n}");
        assert_eq!(prints[n - 1], &line);
    }
    assert_eq!(prints[25], "EVT PRINT all 25 wafers are in LP2");
    // The map and the cell agree, wafer for wafer.
    let wafers = sim.ask(&mut host, "WAFERS", REPLY_NS).unwrap();
    assert!(
        wafers.starts_with("ACK hand=- LP1=-x25 LP2=W1..W25 AL=- "),
        "{wafers}"
    );
    for station in ["LP1", "LP2", "AL"] {
        assert_eq!(
            map_codes(&wafers, station),
            truth_codes(&sim, station),
            "{station}: {wafers}"
        );
    }
    assert_eq!(truth_codes(&sim, "LP2"), "1".repeat(25));
    let board = sim.board(0).unwrap();
    let world = board.cell().unwrap().world();
    assert_eq!(world.hand(), None);
    assert!(world.lost().is_empty(), "{}", world.to_text());
    // No move of the 100 transfers went sideways through a station's side.
    assert_eq!(
        (world.side_collisions(), world.faults()),
        (0, 0),
        "{:?}: {}",
        world.last_side_collision(),
        world.to_text()
    );
    drop(board);
    // The cycle took minutes of robot time: virtual time, not a shortened cell.
    assert!(sim.virtual_s() > 120.0, "{} s", sim.virtual_s());
}

/// One run of a short session: a program with motion, I/O and a wafer transfer, then a
/// status request; everything heard, with its virtual time, and the pulse stream.
fn session(dir: &Path) -> (Vec<String>, Vec<(u64, Vec<i64>)>) {
    let mut sim = demo(dir, SimCellFrom::default());
    sim.record_pulses(true);
    let mut host = sim.connect().unwrap();
    let program = "SPEED 80\nHOME\nMAP \"LP1\"\nMAP \"LP2\"\nGET \"LP1\", 3\nPUT \"LP2\", 3\n\
                   MOVEJ JOINTS(30, 60, -90, 0)\nOUT 5, 1\nDELAY 0.25\nOUT 5, 0\n\
                   PRINT \"at\", HERE()\nEND\n";
    let mut heard: Vec<String> = run_program(&mut sim, &mut host, "session", program)
        .into_iter()
        .map(|(t, l)| format!("{t} {l}"))
        .collect();
    for ask in ["STATUS", "WAFERS", "IO"] {
        heard.push(sim.ask(&mut host, ask, REPLY_NS).unwrap());
    }
    assert!(
        heard.iter().any(|l| l.ends_with("INF 2")),
        "the session ended badly: {heard:#?}"
    );
    (heard, sim.take_pulses())
}

#[test]
fn two_runs_with_the_same_inputs_are_identical_pulse_for_pulse_and_byte_for_byte() {
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let (heard_a, pulses_a) = session(a.path());
    let (heard_b, pulses_b) = session(b.path());
    assert_eq!(heard_a, heard_b);
    // The arm moved (HOME, the transfer, the MOVEJ): a stream worth comparing.
    assert!(pulses_a.len() > 500, "{} periods", pulses_a.len());
    assert!(pulses_a.windows(2).any(|w| w[0].1 != w[1].1));
    assert_eq!(pulses_a, pulses_b);
}

/// Run until `client` hears a line that starts with `prefix`.
fn until_line(sim: &mut Simulation, client: &mut SimClient, prefix: &str) {
    let mut heard = Vec::new();
    loop {
        let l = sim
            .next_line(client, REPLY_NS)
            .unwrap_or_else(|e| panic!("{e}: {heard:?}"));
        if l.starts_with(prefix) {
            return;
        }
        heard.push(l);
    }
}

#[test]
fn trace_save_writes_the_last_seconds_and_an_estop_saves_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let mut sim = demo(dir.path(), SimCellFrom::default());
    let mut host = sim.connect().unwrap();
    assert_eq!(sim.ask(&mut host, "1 HOME", REPLY_NS).unwrap(), "ACK 1");
    until_line(&mut sim, &mut host, "INF 1");
    let reply = sim.ask(&mut host, "2 TRACE SAVE first", REPLY_NS).unwrap();
    let path = dir.path().join("traces/first.wrctrace");
    assert!(
        reply.starts_with(&format!("ACK 2 file={} samples=", path.display())),
        "{reply}"
    );
    let trace = wrc_trace::TraceFile::load(&path).unwrap();
    // One sample per 10 ms period since power-on (the save came within a service period of
    // the request), and the requests with their replies.
    let periods = ((sim.now_ns() - START_NS) / 10_000_000) as usize;
    assert!(
        (periods.saturating_sub(6)..=periods).contains(&trace.samples.len()),
        "{} samples in {periods} periods",
        trace.samples.len()
    );
    assert!(trace.meta.from_start);
    assert_eq!(trace.meta.clock, wrc_trace::ClockKind::Virtual);
    assert_eq!(trace.meta.axis_names, ["j1", "j2", "j3", "z"]);
    let lines: Vec<String> = trace
        .messages
        .iter()
        .map(|m| m.text().into_owned())
        .collect();
    assert!(lines.contains(&"1 HOME".to_string()), "{lines:?}");
    assert!(lines.contains(&"ACK 1".to_string()), "{lines:?}");
    assert!(lines.contains(&"INF 1".to_string()), "{lines:?}");
    // A bad name is refused and nothing is written.
    let reply = sim.ask(&mut host, "3 TRACE SAVE ../x", REPLY_NS).unwrap();
    assert!(reply.starts_with("NAK 3 106 trace name"), "{reply}");
    let reply = sim.ask(&mut host, "4 TRACE LOAD x", REPLY_NS).unwrap();
    assert!(
        reply.starts_with("NAK 4 106 TRACE knows one action"),
        "{reply}"
    );

    // An E-stop during a move: the recorder saves the seconds before it by itself.
    let traces = dir.path().join("traces");
    let estop_traces = || -> Vec<String> {
        std::fs::read_dir(&traces)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .filter(|n| n.starts_with("estop-"))
            .collect()
    };
    let ack = sim.ask(&mut host, "5 MOVJ 30 60 -90 0", REPLY_NS).unwrap();
    assert_eq!(ack, "ACK 5");
    until_line(&mut sim, &mut host, "EVT STATE MOVING");
    // A few periods into the move.
    sim.run_for_ns(100_000_000);
    assert_eq!(sim.ask(&mut host, "6 ESTOP", REPLY_NS).unwrap(), "ACK 6");
    until_line(&mut sim, &mut host, "EVT STATE ESTOP");
    // The service thread drains the recorder within its period (50 ms, virtual).
    let until = sim.now_ns() + REPLY_NS;
    while estop_traces().is_empty() && sim.now_ns() < until {
        sim.step();
    }
    let saved = estop_traces();
    assert_eq!(saved.len(), 1, "{saved:?}");
    let trace = wrc_trace::TraceFile::load(&dir.path().join("traces").join(&saved[0])).unwrap();
    assert!(
        trace.meta.reason.starts_with("estop "),
        "{}",
        trace.meta.reason
    );
    let last = trace.samples.last().unwrap();
    assert_eq!(trace.meta.state_name(last.state), "ESTOP");
    // It holds the move before the E-stop: the arm was moving.
    assert!(trace
        .samples
        .windows(2)
        .any(|w| w[0].commanded[0] != w[1].commanded[0]));
}
