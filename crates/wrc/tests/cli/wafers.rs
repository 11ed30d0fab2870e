//! Wafer handling as an equipment engineer meets it (issue 8): `MAP`, `GET`, `PUT` against
//! the simulated board's cell (its ground truth is the world file `wrc board-sim` keeps),
//! every refusal with its own code, the wafer-sense fault, and the wafer map checked against
//! the ground truth.

use std::path::Path;

use crate::up::{Client, Controller};
use crate::{text, wait_until, wrc};

/// The ground truth: `wrc board-sim world` of the world file, one line per station
/// (`LP1 11111…`) and the hand.
pub(crate) fn truth(world: &Path) -> String {
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

fn expect_nak(host: &mut Client, id: u32, line: &str, code: u32) -> String {
    let reply = host.ask(&format!("{id} {line}"));
    assert!(
        reply.starts_with(&format!("NAK {id} {code} ")),
        "{line}: expected NAK {code}, got {reply}"
    );
    reply
}

fn inject(c: &Controller, fault: &str) {
    let dpram = c.dpram();
    let mut args = vec!["board-sim", "inject", "--dpram", dpram.to_str().unwrap()];
    args.extend(fault.split_whitespace());
    let out = wrc(&args);
    assert!(out.status.success(), "{:?}", text(&out));
}

/// Wait until the controller's I/O Monitor reports input `n` as `on` (`IO`): an injected
/// sensor change reaches the controller only at the I/O Monitor's next period, later under
/// load. Regression: a PUT sent right after `sensor-flip 14 off` was refused with 135 in a
/// loaded CI run, because the controller still saw the interlock closed.
fn wait_input(host: &mut Client, n: u32, on: bool) {
    wait_until(&format!("input {n} {on} at the controller"), || {
        let r = host.ask("IO");
        let word = r
            .split_whitespace()
            .find_map(|f| f.strip_prefix("in="))
            .and_then(|h| u32::from_str_radix(h, 16).ok());
        if word.is_some_and(|w| (w >> n) & 1 == u32::from(on)) {
            Ok(())
        } else {
            Err(r)
        }
    });
}

#[test]
fn map_get_put_with_every_refusal_and_the_map_matches_the_cell() {
    let c = Controller::start(&[]);
    let world = c.dir_path().join("world.toml");
    let mut host = c.client();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    // Nothing moves before HOME.
    expect_nak(&mut host, 2, "MAP LP1", 110);
    assert_eq!(host.motion(3, "HOME"), "INF 3");

    // Unmapped slots are refused; a mapping reports the cell's wafers.
    expect_nak(&mut host, 4, "GET LP1 1", 136);
    assert_eq!(
        host.motion(5, "MAP LP1"),
        format!("INF 5 LP1 {}", truth_codes(&world, "LP1"))
    );
    assert_eq!(
        host.motion(6, "MAP LP2"),
        "INF 6 LP2 0000000000000000000000000"
    );
    assert_eq!(host.motion(7, "MAP AL"), "INF 7 AL 0");
    let map = host.ask("8 WAFERS");
    assert!(
        map.starts_with("ACK 8 hand=- LP1=W1..W25 LP2=-x25 AL=- "),
        "{map}"
    );

    // The refusals, each with its code; nothing moves.
    expect_nak(&mut host, 10, "GET LP9 1", 130);
    expect_nak(&mut host, 11, "GET LP1 26", 137);
    expect_nak(&mut host, 12, "GET LP1 0", 137);
    expect_nak(&mut host, 13, "GET LP2 1", 131);
    expect_nak(&mut host, 14, "PUT LP2 1", 134);
    expect_nak(&mut host, 15, "PUT LP1 1", 134);
    expect_nak(&mut host, 16, "GET PM1 1", 136);

    // GET: the wafer leaves LP1 slot 3 for the hand, in the map and in the cell.
    assert_eq!(host.motion(20, "GET LP1 3"), "INF 20 W3");
    assert_eq!(
        truth_codes(&world, "LP1"),
        "1101111111111111111111111",
        "the cell"
    );
    expect_nak(&mut host, 21, "GET LP1 4", 133);
    expect_nak(&mut host, 22, "PUT LP1 4", 132);
    // The interlock (input 14, held by the board) closed: refused before anything moves.
    inject(&c, "sensor-flip 14 on");
    wait_input(&mut host, 14, false);
    let r = expect_nak(&mut host, 23, "PUT LP2 1", 135);
    assert!(r.contains("interlock"), "{r}");
    inject(&c, "sensor-flip 14 off");
    wait_input(&mut host, 14, true);

    // PUT: into LP2 slot 1.
    assert_eq!(host.motion(24, "PUT LP2 1"), "INF 24 W3");
    assert_eq!(truth_codes(&world, "LP2"), "1000000000000000000000000");
    let map = host.ask("25 WAFERS");
    assert!(
        map.starts_with("ACK 25 hand=- LP1=W1,W2,-,W4..W25 LP2=W3,-x24 AL=- "),
        "{map}"
    );
    // A second mapping confirms the map: ids are kept.
    assert_eq!(
        host.motion(26, "MAP LP2"),
        "INF 26 LP2 1000000000000000000000000"
    );
    assert!(host.ask("27 WAFERS").contains(" LP2=W3,-x24 "));
    let t = truth(&world);
    assert!(t.contains("hand -"), "{t}");
}

#[test]
fn a_vacuum_sensor_that_sees_no_wafer_stops_the_get_with_212() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3 LP1 1"));
    // The vacuum sensor reads inverted: after the lift it says "no wafer".
    inject(&c, "sensor-flip 0 on");
    host.seen.clear();
    let end = host.motion(4, "GET LP1 1");
    assert!(end.starts_with("ABS 4 212 "), "{end}");
    assert!(end.contains("vacuum sensor"), "{end}");
    // Everyone is told, and the robot waits for RESET.
    while !host.seen.iter().any(|l| l.starts_with("EVT ERROR 212 ")) {
        host.line();
    }
    assert!(host.status().contains("state=ERROR"));
    expect_nak(&mut host, 5, "GET LP1 2", 122);
    inject(&c, "sensor-flip 0 off");
    assert!(host.ask("6 RESET").starts_with("ACK 6"));
    assert!(host.status().contains("state=IDLE"));
}

#[test]
fn a_program_maps_and_moves_wafers_with_get_and_put() {
    let c = Controller::start(&[]);
    let world = c.dir_path().join("world.toml");
    let mut host = c.client();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    let program = "\
MAP \"LP1\"
MAP \"LP2\"
FOR I = 1 TO 2
  GET \"LP1\", I
  PUT \"LP2\", I
  PRINT \"moved\", I
NEXT
GET \"LP1\", 1
";
    host.send_raw(b"3 UPLOAD two\n");
    for line in program.lines() {
        host.send_raw(format!("{line}\n").as_bytes());
    }
    assert!(host.ask(".").starts_with("ACK 3 name=two "));
    host.seen.clear();
    // The last GET finds slot 1 empty: the program ends with the transfer's code.
    let end = host.motion(4, "RUN two");
    assert!(end.starts_with("ABS 4 131 two line 8: "), "{end}");
    assert!(
        host.seen.iter().any(|l| l == "EVT PRINT moved 2"),
        "{:?}",
        host.seen
    );
    assert_eq!(truth_codes(&world, "LP1"), "0011111111111111111111111");
    assert_eq!(truth_codes(&world, "LP2"), "1100000000000000000000000");
    let map = host.ask("5 WAFERS");
    assert!(
        map.starts_with("ACK 5 hand=- LP1=-x2,W3..W25 LP2=W1,W2,-x23 "),
        "{map}"
    );
}

#[test]
fn a_wafer_lost_in_motion_stops_the_robot_with_213_and_leaves_the_map() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3 LP1 1"));
    assert_eq!(host.motion(4, "GET LP1 1"), "INF 4 W1");
    host.seen.clear();
    // Carrying the wafer somewhere, the vacuum sensor drops.
    assert_eq!(host.ask("5 MOVP 0 -300 100 -90"), "ACK 5");
    inject(&c, "sensor-flip 0 on");
    let end = host.reply();
    assert!(end.starts_with("ABS 5 213 "), "{end}");
    while !host.seen.iter().any(|l| l.starts_with("EVT ERROR 213 ")) {
        host.line();
    }
    assert!(host.status().contains("state=ERROR"));
    // The wafer left the map with the hand's vacuum: the map does not invent where it is.
    wait_until("W1 off the hand and out of the map", || {
        let map = host.ask("6 WAFERS");
        if map.starts_with("ACK 6 hand=- LP1=-,W2..W25 ") {
            Ok(())
        } else {
            Err(map)
        }
    });
}

#[test]
fn mapping_reports_absent_double_and_cross_slotted_wafers_and_get_refuses_them() {
    let scratch = tempfile::tempdir().unwrap();
    let demo = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/stations.toml"),
    )
    .unwrap();
    // LP2 holds a wafer, a double, a cross-slotted one, then nothing.
    let cell = demo.replacen(
        "wafers = \"00000 00000 00000 00000 00000\"",
        "wafers = \"12X00 00000 00000 00000 00000\"",
        1,
    );
    assert_ne!(cell, demo);
    let stations = scratch.path().join("cell.toml");
    std::fs::write(&stations, cell).unwrap();
    let c = Controller::start(&["--stations", stations.to_str().unwrap()]);
    let mut host = c.client();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert_eq!(
        host.motion(3, "MAP LP2"),
        "INF 3 LP2 12X0000000000000000000000"
    );
    let map = host.ask("4 WAFERS");
    assert!(map.contains(" LP2=W1,D,X,-x22 "), "{map}");
    expect_nak(&mut host, 5, "GET LP2 2", 136);
    expect_nak(&mut host, 6, "GET LP2 3", 136);
    expect_nak(&mut host, 7, "GET LP2 4", 131);
    assert_eq!(host.motion(8, "GET LP2 1"), "INF 8 W1");
}

#[test]
fn abort_during_a_programs_get_stops_it_and_the_map_settles_from_the_sensor() {
    let c = Controller::start(&[]);
    let world = c.dir_path().join("world.toml");
    let mut host = c.client();
    // Nobody holds control: the program (and its GET) act for whoever started it.
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    host.send_raw(b"3 UPLOAD one\nMAP \"LP1\"\nGET \"LP1\", 1\nPRINT \"never\"\n.\n");
    assert!(host.reply().starts_with("ACK 3 name=one "));
    host.seen.clear();
    assert_eq!(host.ask("4 RUN one"), "ACK 4");
    // The GET has started once its pending transfer is announced.
    while !host
        .seen
        .iter()
        .any(|l| l.starts_with("EVT WAFER pending=get:LP1.1:"))
    {
        host.line();
    }
    assert_eq!(host.ask("5 ABORT"), "ACK 5");
    let end = host.reply();
    assert!(end.starts_with("ABS 4 200 one line 2: "), "{end}");
    assert!(!host.seen.iter().any(|l| l.contains("never")));
    // The robot comes to rest, and the map agrees with the cell.
    assert!(host.motion(6, "WAIT").starts_with("INF 6"));
    let map = wait_until("the map settled, no transfer pending", || {
        let map = host.ask("7 WAFERS");
        if map.contains("pending=") {
            Err(map)
        } else {
            Ok(map)
        }
    });
    // The ABORT came seconds before the hand could reach the wafer: the GET stopped with the
    // program, so the wafer is still in its slot, in the cell and in the map.
    assert!(truth(&world).contains("hand -"), "{}", truth(&world));
    assert_eq!(truth_codes(&world, "LP1"), "1".repeat(25));
    assert!(map.starts_with("ACK 7 hand=- LP1=W1..W25 "), "{map}");
}
