//! Host sessions on virtual time ([`crate::vhost`]): the wafer handling, straight-line and
//! HOLD scenarios that test the controller's logic, not real-time behaviour. They were
//! process-level tests against `wrc up` (seconds of robot motion each, minutes of the suite);
//! the same requests now run on the same task code under a virtual clock. What only real
//! time shows (the processes, sockets, signals, the serial line, a board process killed)
//! stays in the `wrc` crate's process-level tests.

use wrc_controller::simulation::SimCellFrom;
use wrc_protocol::reply_field;

use crate::vhost::{map_codes, repo, VHost};

fn expect_nak(host: &mut VHost, id: u32, line: &str, code: u32) -> String {
    let reply = host.ask(&format!("{id} {line}"));
    assert!(
        reply.starts_with(&format!("NAK {id} {code} ")),
        "{line}: expected NAK {code}, got {reply}"
    );
    reply
}

/// Ask `IO` until the controller's I/O Monitor reports input `n` as `on`: an injected
/// sensor change reaches the controller at the I/O Monitor's next period.
fn wait_input(host: &mut VHost, n: u32, on: bool) {
    host.poll(&format!("input {n} {on} at the controller"), |host| {
        let r = host.ask("IO");
        let word = reply_field(&r, "in").and_then(|h| u32::from_str_radix(h, 16).ok());
        if word.is_some_and(|w| (w >> n) & 1 == u32::from(on)) {
            Ok(())
        } else {
            Err(r)
        }
    })
}

#[test]
fn map_get_put_with_every_refusal_and_the_map_matches_the_cell() {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    // Nothing moves before HOME.
    expect_nak(&mut host, 2, "MAP LP1", 110);
    assert_eq!(host.motion(3, "HOME"), "INF 3");

    // Unmapped slots are refused; a mapping reports the cell's wafers.
    expect_nak(&mut host, 4, "GET LP1 1", 136);
    assert_eq!(
        host.motion(5, "MAP LP1"),
        format!("INF 5 LP1 {}", host.truth("LP1"))
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
    assert_eq!(host.truth("LP1"), "1101111111111111111111111", "the cell");
    assert!(!host.hand_empty());
    expect_nak(&mut host, 21, "GET LP1 4", 133);
    expect_nak(&mut host, 22, "PUT LP1 4", 132);
    // The interlock (input 14, held by the board) closed: refused before anything moves.
    host.inject("sensor-flip 14 on");
    wait_input(&mut host, 14, false);
    let r = expect_nak(&mut host, 23, "PUT LP2 1", 135);
    assert!(r.contains("interlock"), "{r}");
    host.inject("sensor-flip 14 off");
    wait_input(&mut host, 14, true);

    // PUT: into LP2 slot 1.
    assert_eq!(host.motion(24, "PUT LP2 1"), "INF 24 W3");
    assert_eq!(host.truth("LP2"), "1000000000000000000000000");
    let map = host.ask("25 WAFERS");
    assert!(
        map.starts_with("ACK 25 hand=- LP1=W1,W2,-,W4..W25 LP2=W3,-x24 AL=- "),
        "{map}"
    );
    for station in ["LP1", "LP2", "AL"] {
        assert_eq!(map_codes(&map, station), host.truth(station), "{station}");
    }
    // A second mapping confirms the map: ids are kept.
    assert_eq!(
        host.motion(26, "MAP LP2"),
        "INF 26 LP2 1000000000000000000000000"
    );
    assert!(host.ask("27 WAFERS").contains(" LP2=W3,-x24 "));
    assert!(host.hand_empty());
}

#[test]
fn a_program_maps_and_moves_wafers_with_get_and_put() {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    host.send_raw(
        "3 UPLOAD two\nMAP \"LP1\"\nMAP \"LP2\"\nFOR I = 1 TO 2\n  GET \"LP1\", I\n  \
         PUT \"LP2\", I\n  PRINT \"moved\", I\nNEXT\nGET \"LP1\", 1\n.\n",
    );
    assert!(host.reply().starts_with("ACK 3 name=two "));
    host.seen.clear();
    // The last GET finds slot 1 empty: the program ends with the transfer's code.
    let end = host.motion(4, "RUN two");
    assert!(end.starts_with("ABS 4 131 two line 8: "), "{end}");
    assert!(
        host.seen.iter().any(|l| l == "EVT PRINT moved 2"),
        "{:?}",
        host.seen
    );
    assert_eq!(host.truth("LP1"), "0011111111111111111111111");
    assert_eq!(host.truth("LP2"), "1100000000000000000000000");
    let map = host.ask("5 WAFERS");
    assert!(
        map.starts_with("ACK 5 hand=- LP1=-x2,W3..W25 LP2=W1,W2,-x23 "),
        "{map}"
    );
}

/// Regression: the connection's line reader skipped an upload's blank lines as it skips
/// blank lines between requests, so the stored program lost them and every diagnostic (and
/// a running program's `ABS … line n`) after a blank line named the wrong line (found by
/// the `upload` fuzz target on examples/fig7_ptp.wrl).
#[test]
fn an_upload_keeps_its_blank_lines_and_diagnostics_name_the_line_sent() {
    let mut host = VHost::start();
    host.send_raw("1 UPLOAD blanks\nHOME\n\n  \r\nBOGUS 1\n.\n");
    let diag = host.line();
    assert!(
        diag.starts_with("EVT DIAG blanks.wrl:4:1: error: "),
        "{diag}"
    );
    let nak = host.reply();
    assert!(
        nak.starts_with("NAK 1 126 blanks: 1 error; first: 4:1 "),
        "{nak}"
    );
    // Blank lines between requests are still skipped, with no reply.
    host.send_raw("\n \n");
    host.send_raw("2 UPLOAD blanks\nHOME\n\n.\n");
    assert_eq!(host.reply(), "ACK 2 name=blanks lines=2 warnings=0");
}

#[test]
fn mapping_reports_absent_double_and_cross_slotted_wafers_and_get_refuses_them() {
    let scratch = tempfile::tempdir().unwrap();
    let demo = std::fs::read_to_string(repo().join("config/stations.toml")).unwrap();
    // LP2 holds a wafer, a double, a cross-slotted one, then nothing.
    let cell = demo.replacen(
        "wafers = \"00000 00000 00000 00000 00000\"",
        "wafers = \"12X00 00000 00000 00000 00000\"",
        1,
    );
    assert_ne!(cell, demo);
    let stations = scratch.path().join("cell.toml");
    std::fs::write(&stations, cell).unwrap();
    let mut host = VHost::start_with(SimCellFrom {
        stations: Some(&stations),
        world: None,
    });
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
    assert_eq!(host.truth("LP2"), "02X0000000000000000000000");
}

#[test]
fn abort_during_a_programs_get_stops_it_and_the_map_settles_from_the_sensor() {
    let mut host = VHost::start();
    // Nobody holds control: the program (and its GET) act for whoever started it.
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    host.send_raw("3 UPLOAD one\nMAP \"LP1\"\nGET \"LP1\", 1\nPRINT \"never\"\n.\n");
    assert!(host.reply().starts_with("ACK 3 name=one "));
    host.seen.clear();
    assert_eq!(host.ask("4 RUN one"), "ACK 4");
    // The GET has started once its pending transfer is announced.
    host.until("EVT WAFER pending=get:LP1.1:");
    assert_eq!(host.ask("5 ABORT"), "ACK 5");
    let end = host.reply();
    assert!(end.starts_with("ABS 4 200 one line 2: "), "{end}");
    assert!(!host.seen.iter().any(|l| l.contains("never")));
    // The robot comes to rest, and the map agrees with the cell.
    assert!(host.motion(6, "WAIT").starts_with("INF 6"));
    let map = host.poll("the map settled, no transfer pending", |host| {
        let map = host.ask("7 WAFERS");
        if map.contains("pending=") {
            Err(map)
        } else {
            Ok(map)
        }
    });
    // The ABORT came seconds before the hand could reach the wafer: the GET stopped with the
    // program, so the wafer is still in its slot, in the cell and in the map.
    assert!(host.hand_empty());
    assert_eq!(host.truth("LP1"), "1".repeat(25));
    assert!(map.starts_with("ACK 7 hand=- LP1=W1..W25 "), "{map}");
}

/// The joints from `WHERE` [deg, deg, deg, mm].
fn joints(host: &mut VHost) -> Vec<f64> {
    host.where_().0
}

fn assert_same_place(a: &[f64], b: &[f64]) {
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() < 0.002, "the robot moved: {a:?} → {b:?}");
    }
}

#[test]
fn get_and_put_reach_the_buffer_behind_the_robot_with_the_elbow_that_keeps_the_line_in_range() {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(joints(&mut host)[1] > 0.0, "HOME has the right elbow");
    // From the right elbow, the mapping at BF1 goes to the left one: with the right, the
    // shoulder would pass -180 deg on the straight line in.
    assert_eq!(host.motion(3, "MAP BF1"), "INF 3 BF1 00000");
    assert!(joints(&mut host)[1] < 0.0, "BF1 with the left elbow");
    assert!(host.motion(4, "MAP LP1").starts_with("INF 4 LP1 1"));

    // A GET refused (the slot is not mapped) moves nothing.
    let before = joints(&mut host);
    let r = host.ask("5 GET LP2 1");
    assert!(r.starts_with("NAK 5 136 "), "{r}");
    assert_same_place(&before, &joints(&mut host));

    // LP1 slot 1 → BF1 slot 2, the approach at BF1 with the left elbow (J2 < 0).
    assert_eq!(host.motion(6, "GET LP1 1"), "INF 6 W1");
    assert_eq!(host.motion(7, "PUT BF1 2"), "INF 7 W1");
    let at_bf1 = joints(&mut host);
    assert!(at_bf1[1] < 0.0, "BF1 with the left elbow: {at_bf1:?}");
    assert!(at_bf1[0] > -180.0 && at_bf1[0] < 180.0);
    assert_eq!(host.truth("BF1"), "01000");
    let map = host.ask("8 WAFERS");
    assert!(map.contains(" BF1=-,W1,-x3"), "{map}");

    // And back: BF1 slot 2 → LP1 slot 1.
    assert_eq!(host.motion(9, "GET BF1 2"), "INF 9 W1");
    assert_eq!(host.motion(10, "PUT LP1 1"), "INF 10 W1");
    assert_eq!(host.truth("BF1"), "00000");
    assert_eq!(host.truth("LP1"), "1".repeat(25));
}

/// Read until `EVT STATE <state>`; fail on a final reply of `id` on the way.
fn until_state(host: &mut VHost, state: &str, id: u32) {
    let want = format!("EVT STATE {state}");
    loop {
        let l = host.line();
        if l == want {
            return;
        }
        assert!(
            !l.starts_with(&format!("INF {id}")) && !l.starts_with(&format!("ABS {id}")),
            "motion {id} ended while it should be held: {l}"
        );
    }
}

fn hold(host: &mut VHost, id: u32) {
    assert_eq!(host.ask("HOLD"), "ACK");
    until_state(host, "HELD", id);
    assert!(host.status().starts_with("ACK state=HELD"));
}

#[test]
fn a_held_line_stays_on_its_line_and_stop_abandons_a_held_motion() {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert_eq!(host.motion(3, "MOVP 300 -150 0 0"), "INF 3");
    assert!(host.ask("SPEED 20").starts_with("ACK"));
    let (a, b) = ((300.0, -150.0), (300.0, 150.0));
    assert_eq!(host.ask("4 MOVL 300 150 0 0"), "ACK 4");
    host.wait_moving("y past -100 mm", |_, _, y| y > -100.0);
    hold(&mut host, 4);
    let (_, x, y) = host.where_();
    assert!(
        (x - a.0).abs() < 0.01 && y > a.1 && y < b.1,
        "held at {x} {y}"
    );
    // Held means held: a second of virtual time later it has not moved.
    host.sim.run_for_ns(1_000_000_000);
    let (_, x2, y2) = host.where_();
    assert!((x2 - x).abs() < 1e-3 && (y2 - y).abs() < 1e-3, "{x2} {y2}");
    assert_eq!(host.ask("RESUME"), "ACK");
    assert_eq!(host.reply(), "INF 4");
    let (_, x, y) = host.where_();
    assert!((x - b.0).abs() < 0.01 && (y - b.1).abs() < 0.01, "{x} {y}");

    // STOP while held ends the held motion.
    assert_eq!(host.ask("5 MOVL 300 -150 0 0"), "ACK 5");
    host.wait_moving("y back below 100 mm", |_, _, y| y < 100.0);
    hold(&mut host, 5);
    assert_eq!(host.ask("STOP"), "ACK");
    assert!(host.reply().starts_with("ABS 5 200"));
    until_state(&mut host, "IDLE", 5);
    assert_eq!(host.ask("RESUME"), "NAK 129 no motion is held");
}

#[test]
fn a_held_get_waits_and_resumes_to_take_its_wafer() {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3 LP1 1"));
    let (start, _, _) = host.where_();
    assert!(host.ask("SPEED 30").starts_with("ACK"));
    assert_eq!(host.ask("4 GET LP1 2"), "ACK 4");
    host.wait_moving("an axis 5 deg on its way", |j, _, _| {
        j.iter().zip(&start).any(|(a, b)| (a - b).abs() > 5.0)
    });
    hold(&mut host, 4);
    // The held GET neither ends nor takes the wafer while held (an INF 4 meanwhile would
    // come before RESUME's ACK).
    host.sim.run_for_ns(2_000_000_000);
    assert!(host.hand_empty());
    assert_eq!(host.ask("RESUME"), "ACK");
    assert_eq!(host.reply(), "INF 4 W2");
    assert!(host.ask("WAFERS").contains("hand=W2"));
    assert!(!host.hand_empty());
    assert_eq!(host.truth("LP1"), "1011111111111111111111111");
}

/// An output request releases the I/O Monitor (period 100 ms): the board applies it within
/// a few Pulse Generator periods, not at the I/O Monitor's next period (a transfer waits
/// for its vacuum valve this way).
#[test]
fn an_output_reaches_the_board_at_once_not_at_the_io_monitors_next_period() {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    let applied = |host: &VHost| {
        host.sim
            .board(0)
            .unwrap()
            .dpram()
            .load(wrc_board::layout::io::OUTPUTS_APPLIED)
    };
    // Just after an I/O Monitor grid point: its next one is 100 ms away.
    let io_period_ns = 100_000_000;
    let now = host.sim.now_ns();
    host.sim
        .run_before_ns((now / io_period_ns + 1) * io_period_ns + 1_000_000);
    assert_eq!(applied(&host) & (1 << 5), 0);
    let asked = host.sim.now_ns();
    assert_eq!(host.ask("OUT 5 1"), "ACK");
    host.sim.run_until_ns(asked + 30_000_000);
    assert_ne!(
        applied(&host) & (1 << 5),
        0,
        "output 5 not applied 30 ms after OUT"
    );
}

/// The hand's x, y and z [mm] from a `WHERE` reply.
fn xyz(reply: &str) -> (f64, f64, f64) {
    let f = |k: &str| -> f64 { reply_field(reply, k).unwrap().parse().unwrap() };
    (f("x"), f("y"), f("z"))
}

/// The dual-blade example: GET and PUT with either blade, and SWAP at a process module takes
/// the processed wafer with the empty blade and puts the other blade's there, with the hand
/// on the station's line throughout (it never leaves the station's approach line); the
/// wafer map follows the cell.
#[test]
fn a_dual_blade_robot_swaps_at_a_process_module_without_leaving_it() {
    use wrc_cell::Blade;
    let mut host = VHost::start_config(&crate::vhost::dual_blade(), SimCellFrom::default());
    assert!(host.ask("1 ROBOT").ends_with(" blade_b=-30"));
    assert!(host.ask("2 CONTROL").starts_with("ACK 2"));
    assert_eq!(host.motion(3, "HOME"), "INF 3");
    for (id, station) in [(4, "LP1"), (5, "PM1"), (6, "LP2")] {
        assert!(host
            .motion(id, &format!("MAP {station}"))
            .starts_with("INF"));
    }
    // W1 into PM1 with blade A; W2 onto blade B.
    assert_eq!(host.motion(7, "GET LP1 1"), "INF 7 W1");
    assert_eq!(host.motion(8, "PUT PM1 1"), "INF 8 W1");
    assert_eq!(host.motion(9, "GET LP1 2 B"), "INF 9 W2");
    let wafers = host.ask("WAFERS");
    assert!(wafers.contains("hand=- hand.B=W2 "), "{wafers}");
    assert!(host.hand_empty() && !host.blade_empty(Blade::B));
    // Blade B is full: a second GET with it is refused; SWAP needs one full blade.
    expect_nak(&mut host, 10, "GET LP1 3 B", 133);
    expect_nak(&mut host, 11, "SWAP LP2 1", 131);

    // SWAP PM1 1: blade A takes W1, blade B puts W2. Sample the hand while it runs.
    let pm1 = wrc_cell::Stations::embedded_demo()
        .get("PM1")
        .unwrap()
        .clone();
    let yaw = pm1.pose.yaw.to_radians();
    let (ux, uy) = (yaw.cos(), yaw.sin());
    assert_eq!(host.ask("12 SWAP PM1 1"), "ACK 12");
    // From the moment the hand reaches the station's line at its approach pose (the move
    // there comes first).
    let (mut samples, mut off_line, mut lowest, mut highest) = (0, 0.0f64, f64::MAX, f64::MIN);
    let mut arrived = false;
    let end = loop {
        host.sim.run_for_ns(20_000_000);
        host.send_raw("WHERE\n");
        let mut end = None;
        let at = loop {
            let l = host.reply();
            if l.starts_with("INF 12") || l.starts_with("ABS 12") {
                end = Some(l);
            } else if l.starts_with("ACK") {
                break l;
            }
        };
        let (x, y, z) = xyz(&at);
        // Distance from the station's line (through the wafer centre, along its yaw).
        let (dx, dy) = (x - pm1.pose.x, y - pm1.pose.y);
        let off = (dx * uy - dy * ux).abs();
        // On the line and past the approach pose (a blended approach meets the line's
        // extension there, flowing into it).
        let along = dx * ux + dy * uy;
        arrived |= off < 0.01 && along >= -pm1.approach_mm - 0.01;
        // Off the line only behind the approach pose: a blended approach to blade B's
        // height flows into the line from there.
        if arrived && along > -pm1.approach_mm + 0.01 {
            off_line = off_line.max(off);
            lowest = lowest.min(z);
            highest = highest.max(z);
            samples += 1;
        }
        if let Some(end) = end {
            break end;
        }
    };
    assert_eq!(end, "INF 12 W1 W2");
    assert!(samples > 50, "{samples} samples");
    assert!(
        off_line < 0.01,
        "the hand left the station's line by {off_line} mm"
    );
    // The wrist went from blade A under W1 (95 mm) up to blade B's release height
    // (105 + 30 mm) and back down to blade B's lowered pose (95 + 30 mm).
    assert!(lowest > 94.9 && lowest < 95.1, "{lowest}");
    assert!(highest > 134.9 && highest < 135.1, "{highest}");
    let wafers = host.ask("WAFERS");
    assert!(wafers.contains("hand=W1 hand.B=- "), "{wafers}");
    assert!(wafers.contains(" PM1=W2 "), "{wafers}");
    assert_eq!(host.truth("PM1"), "1");
    assert!(!host.hand_empty() && host.blade_empty(Blade::B));
    // W1 goes to LP2 with blade A; blade B is empty, so PUT with it is refused.
    expect_nak(&mut host, 13, "PUT LP2 1 B", 134);
    assert_eq!(host.motion(14, "PUT LP2 1"), "INF 14 W1");
    // The map and the cell agree everywhere.
    let wafers = host.ask("WAFERS");
    for station in ["LP1", "LP2", "PM1"] {
        assert_eq!(
            map_codes(&wafers, station),
            host.truth(station),
            "{station}"
        );
    }
}

/// A single-hand robot refuses blade B and SWAP with their own code; a blade other than A or
/// B is a bad argument. Nothing moves.
#[test]
fn a_single_hand_robot_refuses_blade_b_and_swap() {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3"));
    assert!(!host.ask("ROBOT").contains("blade_b"));
    let text = expect_nak(&mut host, 4, "GET LP1 1 B", 124);
    assert!(text.contains("one hand"), "{text}");
    expect_nak(&mut host, 5, "SWAP LP1 1", 124);
    let text = expect_nak(&mut host, 6, "GET LP1 1 C", 106);
    assert!(text.contains("blade \"C\" must be A or B"), "{text}");
    assert!(!host.ask("WAFERS").contains("hand.B"));
    // Blade A by name is the hand.
    assert_eq!(host.motion(7, "GET LP1 1 A"), "INF 7 W1");
}

/// ESTOP in the middle of a SWAP, after its GET half committed: the PUT half is settled from
/// blade B's vacuum sensor (the wafer never left it), so the map has a wafer on each blade
/// and the slot empty, as the cell has.
#[test]
fn an_estop_between_the_halves_of_a_swap_leaves_the_map_as_the_cell_is() {
    use wrc_cell::Blade;
    let mut host = VHost::start_config(&crate::vhost::dual_blade(), SimCellFrom::default());
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3"));
    assert!(host.motion(4, "MAP PM1").starts_with("INF 4"));
    assert_eq!(host.motion(5, "GET LP1 1"), "INF 5 W1");
    assert_eq!(host.motion(6, "PUT PM1 1"), "INF 6 W1");
    assert_eq!(host.motion(7, "GET LP1 2 B"), "INF 7 W2");
    assert_eq!(host.ask("8 SWAP PM1 1"), "ACK 8");
    // The GET half has committed when the PUT half is pending.
    host.until("EVT WAFER pending=put:PM1.1:W2:B");
    assert_eq!(host.ask("ESTOP"), "ACK");
    assert!(host.until("ABS 8").starts_with("ABS 8 201"));
    assert!(host.ask("RESET").starts_with("ACK"));
    let wafers = host.settled_wafers();
    assert!(wafers.contains("hand=W1 hand.B=W2 "), "{wafers}");
    assert!(wafers.contains(" PM1=- "), "{wafers}");
    assert!(!wafers.contains("pending="), "{wafers}");
    assert_eq!(host.truth("PM1"), "0");
    assert!(!host.hand_empty() && !host.blade_empty(Blade::B));
}

/// A program on the dual-blade robot: the swap cycle at PM1 written in the language (blade B
/// carries the next wafer, SWAP exchanges it for the processed one, the hand takes that to
/// LP2), and the same program on the single-hand robot ends at its first blade-B statement
/// with code 124.
#[test]
fn a_program_swaps_at_a_process_module_with_two_blades() {
    const PROGRAM: &str = "3 UPLOAD swap\nMAP \"LP1\"\nMAP \"LP2\"\nMAP \"PM1\"\n\
        GET \"LP1\", 1\nPUT \"PM1\", 1\nFOR I = 1 TO 2\n  GET \"LP1\", I + 1, B\n  \
        SWAP \"PM1\", 1\n  PUT \"LP2\", I\nNEXT\n.\n";
    let mut host = VHost::start_config(&crate::vhost::dual_blade(), SimCellFrom::default());
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    host.send_raw(PROGRAM);
    assert!(host.reply().starts_with("ACK 3 name=swap "));
    assert_eq!(host.motion(4, "RUN swap"), "INF 4");
    // W1 and W2 went through PM1 to LP2; W3 is in PM1; both blades are empty.
    let map = host.ask("5 WAFERS");
    assert!(
        map.starts_with("ACK 5 hand=- hand.B=- LP1=-x3,W4..W25 LP2=W1,W2,-x23 "),
        "{map}"
    );
    assert!(map.contains(" PM1=W3 "), "{map}");
    for station in ["LP1", "LP2", "PM1"] {
        assert_eq!(map_codes(&map, station), host.truth(station), "{station}");
    }

    let mut one = VHost::start();
    assert!(one.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(one.motion(2, "HOME"), "INF 2");
    one.send_raw(PROGRAM);
    assert!(one.reply().starts_with("ACK 3 name=swap "));
    let end = one.motion(4, "RUN swap");
    assert!(end.starts_with("ABS 4 124 swap line 7: "), "{end}");
}

/// Every verb of the protocol reaches what carries it out: none is answered "not available"
/// (124) by a controller that has everything (the dual-blade robot, its cell). A new verb
/// without an example here fails this test, and one that no task routes fails it too.
#[test]
fn every_verb_is_carried_out_by_someone() {
    fn example(verb: &'static str) -> Option<&'static str> {
        Some(match verb {
            "MOVJ" => "MOVJ 0 90 0 50",
            "MOVP" => "MOVP 300 0 0 0",
            "MOVL" => "MOVL 300 0 5 0",
            "JOG" => "JOG 1 1",
            "SPEED" => "SPEED 50",
            "OUT" => "OUT 5 1",
            "UPLOAD" => "UPLOAD p\nHOME\n.",
            "RUN" => "RUN nothing",
            "DELETE" => "DELETE nothing",
            "TRACE" => "TRACE SAVE t",
            "TEACH" => "TEACH LP1",
            "GET" => "GET LP1 1 B",
            "PUT" => "PUT PM1 1 B",
            "MAP" => "MAP PM1",
            "SWAP" => "SWAP PM1 1",
            "AUTH" => "AUTH s3cret-token-0123456789",
            "BREAK" => "BREAK 3",
            "STEP" => "STEP OVER",
            "VARS" => "VARS N",
            "POINTS" => "POINTS p",
            "POINT" => "POINT p SAFE 300 0 50 0",
            "SENSE" => "SENSE B",
            "CONFIRM" => "CONFIRM HAND EMPTY",
            "STATUS" | "WHERE" | "HOME" | "STOP" | "ESTOP" | "HOLD" | "RESUME" | "RESET" | "IO"
            | "WAIT" | "CONTROL" | "RELEASE" | "HELP" | "SUBSCRIBE" | "UNSUBSCRIBE"
            | "PROGRAMS" | "PAUSE" | "CONTINUE" | "ABORT" | "ROBOT" | "TASKS" | "STN"
            | "WAFERS" | "RECOVERY" | "RETRACT" => verb,
            _ => return None,
        })
    }
    let config = crate::vhost::dual_blade();
    for (i, verb) in wrc_protocol::Verb::ALL.iter().enumerate() {
        let name = verb.spec().name;
        let line =
            example(name).unwrap_or_else(|| panic!("{name} has no example in this test; add one"));
        // A fresh controller, in control and homed, so that no state refusal (ESTOP, not
        // homed, control held) answers before the request reaches its task.
        let mut host = VHost::start_config(&config, SimCellFrom::default());
        assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
        assert_eq!(host.motion(2, "HOME"), "INF 2");
        let id = 100 + i;
        let reply = host.ask(&format!("{id} {line}"));
        assert!(
            !reply.starts_with(&format!("NAK {id} 124")),
            "{name}: {reply}"
        );
    }
}

/// Poll `WAFERS` until its hand token is `hand`; the reply then.
fn until_hand(host: &mut VHost, hand: &str) -> String {
    let want = format!(" hand={hand} ");
    host.poll(&format!("hand={hand} in the map"), |host| {
        let map = host.ask("WAFERS");
        if map.contains(&want) {
            Ok(map)
        } else {
            Err(map)
        }
    })
}

/// Regression (found by `wrc bench faults`): a vacuum sensor that dropped while the hand
/// carried a wafer (213) took the wafer out of the map at once, although the vacuum stayed
/// on and the wafer was still held; once the sensor answered again the map had an empty
/// hand with a wafer on it, and the next GET drove that wafer into the slot's (a collision
/// in the cell, and the map took the slot's wafer as taken). Now the wafer stays in the
/// map, uncertain, and GET is refused; RESET clears the alarm and leaves the uncertainty
/// (it once settled it from the sensor without a word); SENSE settles it: kept when the
/// sensor senses the wafer, out of the map when it does not.
#[test]
fn a_wafer_whose_vacuum_sensor_drops_in_motion_stays_uncertain_until_sense_settles_it() {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3"));
    assert_eq!(host.motion(4, "GET LP1 1"), "INF 4 W1");

    // The sensor drops on a move; the wafer stays on the hand in the cell.
    for (round, sensor_back) in [(0u32, true), (1, false)] {
        let id = 10 + 10 * round;
        let target = if round == 0 {
            "MOVP 0 -200 0 -90"
        } else {
            "MOVP 250 100 0 0"
        };
        // From where the first round's stop left it, round 1 goes round through the
        // travel height (`ACK 20 route=travel`).
        let ack = host.ask(&format!("{id} {target}"));
        assert!(ack.starts_with(&format!("ACK {id}")), "{ack}");
        host.inject("sensor-flip 0 on");
        let end = host.reply();
        assert!(end.starts_with(&format!("ABS {id} 213 ")), "{end}");
        host.until("EVT ERROR 213 ");
        assert!(!host.hand_empty(), "the cell still holds the wafer");
        until_hand(&mut host, "W1?");
        // No transfer while the robot is in the fault; none would take a slot's wafer.
        expect_nak(&mut host, id + 1, "GET LP1 2", 122);
        // The arm stands (WAIT ends with the fault's code once it does).
        let waited = host.motion(id + 5, "WAIT");
        assert!(
            waited.starts_with(&format!("ABS {} 213", id + 5)),
            "{waited}"
        );
        if sensor_back {
            host.inject("sensor-flip 0 off");
            wait_input(&mut host, 0, true);
        }
        let r = host.ask(&format!("{} RESET", id + 2));
        assert!(r.starts_with("ACK"), "{r}");
        // RESET clears the alarm, not the uncertainty, whatever the sensor says now.
        host.sim.run_for_ns(1_000_000_000);
        until_hand(&mut host, "W1?");
        expect_nak(&mut host, id + 3, "GET LP1 2", 139);
        let sense = host.motion(id + 4, "SENSE");
        if sensor_back {
            // Sensed again: the wafer is confirmed on the hand, and GET is refused (133).
            assert_eq!(sense, format!("INF {} wafer", id + 4));
            until_hand(&mut host, "W1");
            expect_nak(&mut host, id + 6, "GET LP1 2", 133);
        } else {
            // Still not sensed: SENSE takes it as gone (it switches the valve off, and the
            // cell drops what the blade held); the map and the cell agree again.
            assert_eq!(sense, format!("INF {} none", id + 4));
            until_hand(&mut host, "-");
            assert!(host.hand_empty());
        }
    }
    // The sensor answers again: it senses nothing, and the map has nothing on the hand.
    host.inject("sensor-flip 0 off");
    wait_input(&mut host, 0, false);
    until_hand(&mut host, "-");
    assert_eq!(host.truth("LP1"), "0111111111111111111111111");
}

/// Regression (found by `wrc bench faults`, whose recovery transfers start wherever a fault
/// left the arm): from the far side of the robot every candidate of a blended approach,
/// entering at rest too, passed through the half-plane in front of the station's approach
/// pose (far to the side of the station), so a GET was accepted and then ended `ABS 113`
/// with nothing moved, although the same transfer without blending runs. The entry at rest
/// is now the unblended move to the approach pose, checked as that one is.
#[test]
fn a_transfer_from_the_far_side_of_the_robot_runs_instead_of_ending_abs_113() {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3"));
    for (id, slot) in [(10, 1), (20, 19)] {
        assert_eq!(host.motion(id, "MOVJ 60 60 -90 0"), format!("INF {id}"));
        assert_eq!(
            host.motion(id + 1, &format!("GET LP1 {slot}")),
            format!("INF {} W{slot}", id + 1)
        );
        assert!(!host.hand_empty());
        assert_eq!(
            host.motion(id + 2, "MOVJ 60 60 -90 0"),
            format!("INF {}", id + 2)
        );
        assert_eq!(
            host.motion(id + 3, &format!("PUT LP1 {slot}")),
            format!("INF {} W{slot}", id + 3)
        );
        assert!(host.hand_empty());
    }
    let map = host.ask("30 WAFERS");
    assert_eq!(map_codes(&map, "LP1"), host.truth("LP1"));
    assert!(map.contains(" LP1=W1..W25 "), "{map}");
}

/// Regression (found by `wrc bench faults`, a pendant unplugged during a GET): a transfer
/// that ended abnormally was settled from the vacuum sensor at the moment it ended, but the
/// sensor answers a pick only after its delay (and a brake can still carry the hand through
/// the slot's support height). A GET stopped just after its pick was taken as not having
/// happened: the map kept the wafer in its slot while it was on the hand. It is settled now
/// once the arm stands still and the sensor has had `vacuum_settle_ms` to answer.
#[test]
fn a_get_stopped_right_after_its_pick_is_settled_once_the_sensor_has_answered() {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3"));
    assert_eq!(host.ask("4 GET LP1 1"), "ACK 4");
    // The wafer leaves its slot for the hand in the cell; its vacuum sensor answers 50 ms
    // later. The stop comes in between.
    for _ in 0..20_000 {
        if !host.hand_empty() {
            break;
        }
        host.sim.run_for_ns(1_000_000);
    }
    assert!(!host.hand_empty(), "the GET never picked its wafer");
    assert_eq!(host.ask("ESTOP"), "ACK");
    assert!(host.until("ABS 4").starts_with("ABS 4 201"));
    // Pending until the arm stands and the sensor has answered; then on the hand.
    let map = host.settled_wafers();
    assert!(map.contains(" hand=W1 "), "{map}");
    assert!(map.contains(" LP1=-,W2..W25 "), "{map}");
    assert!(!host.hand_empty());
    assert_eq!(host.truth("LP1"), "0111111111111111111111111");
}

/// `ROBOT` names the signals the configuration and the stations know, for the GUI: one
/// `EVT SIGNAL <in|out> <n> <guarded|-> <name>` line each, after the axes, before the ACK
/// (the format is a contract with the GUI; docs/protocol.md "Robot and task queries").
#[test]
fn robot_names_the_signals_after_the_axes_and_before_its_ack() {
    let mut host = VHost::start();
    host.seen.clear();
    let ack = host.ask("1 ROBOT");
    assert!(ack.starts_with("ACK 1 name=paper-300mm "), "{ack}");
    let signals: Vec<&str> = host
        .seen
        .iter()
        .filter(|l| l.starts_with("EVT SIGNAL "))
        .map(String::as_str)
        .collect();
    assert_eq!(
        signals,
        [
            "EVT SIGNAL out 0 guarded vacuum valve",
            "EVT SIGNAL out 1 - mapping sensor",
            "EVT SIGNAL in 0 - vacuum sensor",
            "EVT SIGNAL in 14 - interlock LP1 LP2",
            "EVT SIGNAL in 15 - E-stop button",
        ]
    );
    let last_axis = host.seen.iter().rposition(|l| l.starts_with("EVT AXIS "));
    let first_signal = host.seen.iter().position(|l| l.starts_with("EVT SIGNAL "));
    assert!(last_axis < first_signal, "{:?}", host.seen);
}
