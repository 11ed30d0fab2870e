//! Wafer-sense faults against a real `wrc up` and its `wrc board-sim` process, injected
//! with `wrc board-sim inject` while the arm moves: a vacuum sensor that sees no wafer after
//! the lift (212) and a wafer lost in motion (213). The wafer handling logic (MAP, GET, PUT,
//! every refusal, the map against the cell, programs, ABORT) runs on virtual time in
//! `wrc-controller`'s `sessions` tests.

use crate::up::{files_in, up_once, Client, Controller};
use crate::{text, wait_until, wrc};

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
fn a_wafer_lost_in_motion_stops_the_robot_with_213_and_sense_settles_the_map() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3 LP1 1"));
    assert_eq!(host.motion(4, "GET LP1 1"), "INF 4 W1");
    host.seen.clear();
    // Carrying the wafer round to the far side, the vacuum sensor drops. (Folded, J2 150°,
    // the wafer stays inside every station's box at any height: the move goes straight.)
    assert_eq!(host.ask("5 MOVJ 120 150 0 250"), "ACK 5");
    inject(&c, "sensor-flip 0 on");
    let end = host.reply();
    assert!(end.starts_with("ABS 5 213 "), "{end}");
    while !host.seen.iter().any(|l| l.starts_with("EVT ERROR 213 ")) {
        host.line();
    }
    assert!(host.status().contains("state=ERROR"));
    // The sensor cannot tell a wafer that fell from one it no longer sees: the wafer stays
    // in the map, uncertain, until SENSE (or MAP, or an operator's CONFIRM) settles it.
    wait_until("W1 uncertain on the hand", || {
        let map = host.ask("6 WAFERS");
        if map.starts_with("ACK 6 hand=W1? LP1=-,W2..W25 ") {
            Ok(())
        } else {
            Err(map)
        }
    });
    // RESET clears the alarm, not the uncertainty.
    assert_eq!(host.ask("7 RESET"), "ACK 7");
    let map = host.ask("8 WAFERS");
    assert!(map.starts_with("ACK 8 hand=W1? "), "{map}");
    // SENSE: still not sensed, so taken as gone, it leaves the map; the map does not invent
    // where it is.
    assert_eq!(host.motion(9, "SENSE"), "INF 9 none");
    wait_until("W1 off the hand and out of the map", || {
        let map = host.ask("10 WAFERS");
        if map.starts_with("ACK 10 hand=- LP1=-,W2..W25 ") {
            Ok(())
        } else {
            Err(map)
        }
    });
    c.stop_clear_of_the_cell();
}

/// Regression (found by `wrc bench faults`): a corrupt wafer map was refused by the
/// controller only after `wrc up` had started the simulated board, which wrote the cell's
/// world file (and its DPRAM) on its way down. Now the state files are checked before
/// anything starts: the refusal names the file, and nothing in the state directory is
/// written.
#[test]
fn a_corrupt_wafer_map_is_refused_before_anything_starts_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let corrupt = b"version = 1\nnext_id = 26\nhand = \"W\x00\"\n".to_vec();
    std::fs::write(dir.path().join("wafers.toml"), &corrupt).unwrap();
    let out = up_once(dir.path(), "127.0.0.1", &[]);
    let (_, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("wafers.toml"), "{stderr}");
    assert_eq!(
        std::fs::read(dir.path().join("wafers.toml")).unwrap(),
        corrupt
    );
    let written = files_in(dir.path());
    assert_eq!(written, ["wafers.toml"], "nothing else written");
}

/// Regression (found by `wrc bench faults`): a stations file cut at the end of a station is
/// still a valid, shorter cell. `wrc up` started the simulated board on it, which refused
/// the world file ("6 stations saved, 2 configured") and advised removing the world file,
/// the cell's ground truth. Now `wrc up` checks the world against the stations before
/// anything starts, names the stations file and says to restore it; nothing is written.
#[test]
fn a_stations_file_cut_short_is_refused_by_name_before_the_board_starts() {
    use wrc_board::wrc_cell::{Stations, World, DEMO_TOML};
    let dir = tempfile::tempdir().unwrap();
    let third = DEMO_TOML
        .match_indices("[[station]]")
        .nth(2)
        .expect("a third station")
        .0;
    let cut = &DEMO_TOML[..third];
    assert!(Stations::parse(cut, "cut").is_ok(), "still a valid cell");
    let world = World::new(&Stations::embedded_demo()).to_text();
    std::fs::write(dir.path().join("stations.toml"), cut).unwrap();
    std::fs::write(dir.path().join("world.toml"), &world).unwrap();
    let out = up_once(dir.path(), "127.0.0.1", &[]);
    let (_, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("stations.toml") && stderr.contains("restore it"),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("stations.toml")).unwrap(),
        cut
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("world.toml")).unwrap(),
        world
    );
    let written = files_in(dir.path());
    assert_eq!(
        written,
        ["stations.toml", "world.toml"],
        "nothing else written"
    );
}
