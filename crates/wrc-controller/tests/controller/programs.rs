//! Programs on the whole controller under virtual time: a program that recovers from each
//! fault the simulated board can play (a vacuum miss, an empty slot, a closed interlock, a
//! WAIT that times out, an E-stop, a servo alarm, a following error), with its handler
//! running only once the robot stands still; the cell's answers (SLOT, WAFER$, HAND$, the
//! stations); named points, POINT/POINTS and TEACH; INCLUDE and CALL PROGRAM through the
//! store; the debugger's verbs; blended motions that never stop, and arcs.

use wrc_controller::simulation::SimCellFrom;

use crate::vhost::{repo, VHost};

/// `CONTROL` and `HOME`, then upload `text` as `name`: a host ready to run it.
fn ready(text: &str) -> VHost {
    let mut host = VHost::start();
    ready_with(&mut host, text);
    host
}

fn ready_with(host: &mut VHost, text: &str) {
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    let r = host.upload(3, "p", text);
    assert!(r.starts_with("ACK 3 name=p "), "{r}: {:?}", host.seen);
    host.seen.clear();
}

/// What the program printed so far (`EVT PRINT` texts), in order.
fn printed(host: &VHost) -> Vec<String> {
    host.seen
        .iter()
        .filter_map(|l| l.strip_prefix("EVT PRINT "))
        .map(str::to_string)
        .collect()
}

/// Run program `p` with id 9 and return its final reply (`INF 9` or `ABS 9 …`).
fn run(host: &mut VHost) -> String {
    assert_eq!(host.ask("9 RUN p"), "ACK 9");
    host.reply()
}

/// Replace the simulated cell's ground truth by `edit` of its world file's text (the
/// wafers an operator took away or put back by hand).
fn edit_world(host: &VHost, edit: impl FnOnce(&str) -> String) {
    host.edit_world(edit);
}

/// The state field of `STATUS`.
fn state(host: &mut VHost) -> String {
    let s = host.status();
    wrc_protocol::reply_field(&s, "state").unwrap().to_string()
}

#[test]
fn a_vacuum_miss_is_mapped_then_alarmed_and_the_operator_lets_it_go_on() {
    // After a miss the slot is uncertain (the wafer may have been taken away, or lie
    // askew): a GET of it is refused (139) until the station is mapped again, so the handler
    // maps it and retries only a slot the mapping found full.
    let mut host = ready(
        "\
MAP \"LP1\"
MAP \"LP2\"
PRINT \"mapped\"
tries = 0
TRY
  GET \"LP1\", 2
CATCH 212
  tries = tries + 1
  PRINT \"miss\", tries, ERR, ERRLINE, HAND$(), SLOT(\"LP1\", 2)
  RESET
  MAP \"LP1\"
  IF tries < 2 AND SLOT(\"LP1\", 2) = 1 THEN
    RETRY
  ENDIF
  ALARM 1001, \"no wafer on the hand from LP1 slot 2\"
  WAIT OPERATOR \"put the wafer back\"
  MAP \"LP1\"
  tries = 0
  RETRY
ENDTRY
PRINT \"got\", HAND$()
PUT \"LP2\", 2
PRINT \"LP2 slot 2:\", WAFER$(\"LP2\", 2), SLOT(\"LP2\", 2)
",
    );
    let sides = host.world().side_collisions();
    assert_eq!(host.ask("9 RUN p"), "ACK 9");
    host.until("EVT PRINT mapped");
    // Someone takes the wafer of LP1 slot 2 away after the mapping.
    let original = {
        let board = host.sim.board(0).unwrap();
        board.cell().unwrap().world().to_text()
    };
    edit_world(&host, |t| {
        let edited = t.replacen("\"T2\"", "\"-\"", 1);
        assert_ne!(edited, t);
        edited
    });
    let alarm = host.until("EVT ALARM");
    assert!(
        alarm.starts_with("EVT ALARM 1001 p p:15: no wafer on the hand from LP1 slot 2"),
        "{alarm}"
    );
    let waiting = host.until("EVT PROGRAM p WAITING");
    assert_eq!(waiting, "EVT PROGRAM p WAITING p:16 put the wafer back");
    // One miss, handled with the robot still and its fault cleared by the program; the slot
    // was uncertain (-2) until the mapping found it empty, so nothing was retried blind.
    assert_eq!(printed(&host)[1..], ["miss 1 212 6  -2"]);
    assert_eq!(state(&mut host), "IDLE");
    assert!(host.hand_empty());
    // The operator puts the wafer back and lets the program go on.
    edit_world(&host, |_| original.clone());
    assert_eq!(host.ask("10 CONTINUE"), "ACK 10");
    assert_eq!(host.reply(), "INF 9");
    // The mapping took the wafer back as a new one (W2 left the map when its slot was found
    // empty): W26.
    assert_eq!(
        printed(&host)[2..],
        ["got W26", "LP2 slot 2: W26 1"],
        "{:?}",
        host.seen
    );
    // Each retry left LP1 along its line before its approach: nothing hit a side.
    let world = host.world();
    assert_eq!(
        world.side_collisions(),
        sides,
        "{:?}",
        world.last_side_collision()
    );
    assert_eq!(&host.truth("LP2")[..3], "010");
    assert_eq!(&host.truth("LP1")[..3], "101");
}

#[test]
fn a_program_skips_the_slots_the_map_says_are_empty_and_catches_a_get_of_one() {
    let scratch = tempfile::tempdir().unwrap();
    let demo = std::fs::read_to_string(repo().join("config/stations.toml")).unwrap();
    // LP2 holds wafers in slots 1, 3 and 4.
    let cell = demo.replacen(
        "wafers = \"00000 00000 00000 00000 00000\"",
        "wafers = \"10110 00000 00000 00000 00000\"",
        1,
    );
    assert_ne!(cell, demo);
    let stations = scratch.path().join("cell.toml");
    std::fs::write(&stations, cell).unwrap();
    let mut host = VHost::start_with(SimCellFrom {
        stations: Some(&stations),
        world: None,
    });
    ready_with(
        &mut host,
        "\
PRINT SLOT(\"LP2\", 1), SLOTS(\"LP2\"), PITCH(\"LP2\") > 0, APPROACH(\"LP2\") > 0
MAP \"LP2\"
MAP \"AL\"
moved = 0
FOR i = 1 TO 5
  IF SLOT(\"LP2\", i) = 1 THEN
    GET \"LP2\", i
    PUT \"AL\", 1
    GET \"AL\", 1
    PUT \"LP2\", i
    moved = moved + 1
  ELSE
    PRINT \"skip\", i, SLOT(\"LP2\", i), WAFER$(\"LP2\", i)
  ENDIF
NEXT
TRY
  GET \"LP2\", 2
CATCH 131
  PRINT \"caught\", ERR, ERRMSG$
ENDTRY
PRINT \"moved\", moved, WAFER$(\"LP2\", 4)
",
    );
    assert_eq!(run(&mut host), "INF 9", "{:?}", host.seen);
    assert_eq!(
        printed(&host),
        [
            "-1 25 TRUE TRUE",
            "skip 2 0",
            "skip 5 0",
            "caught 131 no GET from LP2 slot 2: the wafer map says it is empty",
            "moved 3 W3",
        ]
    );
    assert_eq!(&host.truth("LP2")[..5], "10110");
}

#[test]
fn a_closed_interlock_and_a_wait_that_times_out_are_handled_and_the_put_retried() {
    let mut host = ready(
        "\
MAP \"LP1\"
MAP \"LP2\"
GET \"LP1\", 1
PRINT \"got\", HAND$()
DELAY 1
TRY
  PUT \"LP2\", 1
CATCH 135
  PRINT \"closed:\", ERRMSG$
  TRY
    WAIT IN(14) = 1 TIMEOUT 2
  CATCH 211
    PRINT \"still closed\", ERR
    WAIT IN(14) = 1
  ENDTRY
  RETRY
ENDTRY
PRINT \"put\", WAFER$(\"LP2\", 1)
",
    );
    assert_eq!(host.ask("9 RUN p"), "ACK 9");
    // Someone opens LP2's door while the robot holds the wafer.
    host.until("EVT PRINT got W1");
    host.inject("sensor-flip 14 on");
    host.until("EVT PRINT still closed 211");
    let t0 = host.sim.now_ns();
    // The operator closes the door some time later: the program goes on.
    host.sim.run_for_ns(3_000_000_000);
    host.inject("sensor-flip 14 off");
    assert_eq!(host.reply(), "INF 9");
    assert!(host.sim.now_ns() - t0 > 3_000_000_000);
    let out = printed(&host);
    assert!(out[1].starts_with("closed: "), "{out:?}");
    assert!(out[1].contains("interlock"), "{out:?}");
    assert_eq!(out[2..], ["still closed 211", "put W1"]);
    assert_eq!(&host.truth("LP2")[..2], "10");
}

/// A program whose MOVEJ a fault stops: its handler waits for the operator, who clears the
/// fault and lets it RETRY the move. Returns the printed lines.
fn fault_during_a_move(fault: &str, clear: &str, code: u16) -> Vec<String> {
    let mut host = ready(
        "\
TRY
  MOVEJ JOINTS(60, 90, -60, 50)
CATCH 201, 202, 203, 205
  PRINT \"fault\", ERR, ERRLINE
  TRY
    RESET
  CATCH 122, 123
    PRINT \"reset refused\", ERR
  ENDTRY
  WAIT OPERATOR \"clear the fault\"
  PRINT \"operator\", OPERATOR$
  RETRY
ENDTRY
PRINT \"there\"
",
    );
    assert_eq!(host.ask("9 RUN p"), "ACK 9");
    host.wait_moving("the move under way", |j, _, _| j[0] > 10.0);
    host.inject(fault);
    let waiting = host.until("EVT PROGRAM p WAITING");
    assert_eq!(waiting, "EVT PROGRAM p WAITING p:10 clear the fault");
    // The handler ran with the robot standing still, in its fault.
    let status = host.status();
    assert!(status.contains(&format!("err={code}")), "{status}");
    let before = host.where_().0;
    host.sim.run_for_ns(500_000_000);
    assert_eq!(
        host.where_().0,
        before,
        "the robot moved while the handler ran"
    );
    host.inject(clear);
    host.poll("the operator's RESET", |h| {
        let r = h.ask("10 RESET");
        if r == "ACK 10" {
            Ok(())
        } else {
            Err(r)
        }
    });
    assert_eq!(state(&mut host), "IDLE");
    assert_eq!(host.ask("11 CONTINUE done"), "ACK 11");
    assert_eq!(host.reply(), "INF 9", "{:?}", host.seen);
    let (j, _, _) = host.where_();
    assert!(
        (j[0] - 60.0).abs() < 0.01 && (j[3] - 50.0).abs() < 0.01,
        "{j:?}"
    );
    printed(&host)
}

#[test]
fn an_estop_during_a_move_is_handled_after_the_stop_and_the_move_retried() {
    let out = fault_during_a_move("estop on", "estop off", 202);
    assert_eq!(
        out,
        ["fault 202 2", "reset refused 123", "operator done", "there"]
    );
}

#[test]
fn a_servo_alarm_during_a_move_is_handled_and_the_move_retried() {
    let out = fault_during_a_move("alarm 1", "clear", 205);
    assert_eq!(
        out,
        ["fault 205 2", "reset refused 122", "operator done", "there"]
    );
}

#[test]
fn a_following_error_during_a_move_is_handled_and_the_move_retried() {
    let out = fault_during_a_move("encoder-stuck 0 on", "encoder-stuck 0 off", 203);
    assert_eq!(
        out,
        ["fault 203 2", "reset refused 122", "operator done", "there"]
    );
}

#[test]
fn an_alarm_no_catch_takes_ends_the_program_with_215_and_its_text() {
    let mut host = ready("PRINT \"a\"\nRAISE 1200, \"lot \" + STR$(7) + \" rejected\"\n");
    let end = run(&mut host);
    assert_eq!(end, "ABS 9 215 p line 2: alarm 1200: lot 7 rejected");
    // No RESET is needed: the next program runs.
    assert_eq!(state(&mut host), "IDLE");
    assert_eq!(run(&mut host), end);
}

/// The debugger's program: a SUB called twice, an array, a motion.
const DEBUGGED: &str = "\
X = 1
DIM A[3]
CALL work(2)
X = X + 10
MOVEJ JOINTS(40, 90, -60, 0)
PRINT X, A[1]
END
SUB work(n)
  LOCAL k = n * 3
  A[1] = k
  X = X + k
  PRINT \"work\", k
ENDSUB
";

#[test]
fn breakpoints_steps_and_variables_over_the_protocol() {
    let mut host = ready(DEBUGGED);
    assert!(host.ask("3 SUBSCRIBE").starts_with("ACK 3"));
    // Breakpoints set before the run: line 9 (in the SUB), and line 6.
    assert_eq!(host.ask("4 BREAK 9"), "ACK 4 breaks=9");
    assert_eq!(host.ask("5 BREAK 6"), "ACK 5 breaks=9,6");
    assert_eq!(host.ask("9 RUN p"), "ACK 9");
    assert_eq!(
        host.until("EVT PROGRAM p PAUSED"),
        "EVT PROGRAM p PAUSED p:9"
    );
    // The status stream names the line: in file 0 (`files=p`), line 9.
    let status = host.until("EVT STATUS");
    assert!(status.ends_with(" line=0:9"), "{status}");
    host.seen.clear();
    let vars = host.ask("10 VARS");
    assert!(vars.starts_with("ACK 10 vars="), "{vars}");
    let listed: Vec<&String> = host
        .seen
        .iter()
        .filter(|l| l.starts_with("EVT VAR "))
        .collect();
    assert!(
        listed.iter().any(|l| l.starts_with("EVT VAR n number 2")),
        "{listed:?}"
    );
    assert!(
        listed.iter().any(|l| l.starts_with("EVT VAR X number 1")),
        "{listed:?}"
    );
    // A step goes to the next statement, in the SUB.
    assert_eq!(host.ask("11 STEP"), "ACK 11");
    assert_eq!(
        host.until("EVT PROGRAM p PAUSED"),
        "EVT PROGRAM p PAUSED p:10"
    );
    host.seen.clear();
    assert!(host.ask("12 VARS k A[1]").starts_with("ACK 12 vars=2"));
    assert_eq!(
        host.seen
            .iter()
            .filter(|l| l.starts_with("EVT VAR "))
            .collect::<Vec<_>>(),
        ["EVT VAR k number 6", "EVT VAR A[1] number 0"]
    );
    // STEP OUT: until the SUB has returned, its PRINT on the way.
    host.seen.clear();
    assert_eq!(host.ask("13 STEP OUT"), "ACK 13");
    assert_eq!(
        host.until("EVT PROGRAM p PAUSED"),
        "EVT PROGRAM p PAUSED p:4"
    );
    assert_eq!(printed(&host), ["work 6"]);
    // STEP OVER the addition, then over the motion: it runs, at the stepping speed.
    assert_eq!(host.ask("14 STEP OVER"), "ACK 14");
    assert_eq!(
        host.until("EVT PROGRAM p PAUSED"),
        "EVT PROGRAM p PAUSED p:5"
    );
    let t0 = host.sim.now_ns();
    assert_eq!(host.ask("15 STEP OVER"), "ACK 15");
    assert_eq!(
        host.until("EVT PROGRAM p PAUSED"),
        "EVT PROGRAM p PAUSED p:6"
    );
    let stepped = host.sim.now_ns() - t0;
    let (j, _, _) = host.where_();
    assert!((j[0] - 40.0).abs() < 0.01, "{j:?}");
    // Clear the breakpoints and go on to the end.
    assert_eq!(host.ask("16 BREAK CLEAR"), "ACK 16 breaks=none");
    assert_eq!(host.ask("17 CONTINUE"), "ACK 17");
    assert_eq!(host.reply(), "INF 9");
    assert_eq!(printed(&host).last().unwrap(), "17 6");

    // The same motion at full speed takes far less time than stepped.
    assert_eq!(host.motion(18, "HOME"), "INF 18");
    let t0 = host.sim.now_ns();
    assert_eq!(host.motion(19, "MOVJ 40 90 -60 0"), "INF 19");
    let full = host.sim.now_ns() - t0;
    assert!(
        stepped as f64 > 1.5 * full as f64,
        "stepped {stepped} ns, full speed {full} ns"
    );
}

#[test]
fn run_step_starts_paused_and_the_debugger_verbs_refuse_what_they_cannot_do() {
    let mut host = ready(DEBUGGED);
    // Without a program.
    assert!(host.ask("4 STEP").starts_with("NAK 4 128 "));
    assert!(host.ask("5 VARS").starts_with("NAK 5 128 "));
    assert_eq!(host.ask("9 RUN p STEP"), "ACK 9");
    assert_eq!(
        host.until("EVT PROGRAM p PAUSED"),
        "EVT PROGRAM p PAUSED p:1"
    );
    // A line with no statement after it; a variable that does not exist.
    let r = host.ask("10 BREAK 99");
    assert!(r.starts_with("NAK 10 106 "), "{r}");
    host.seen.clear();
    assert!(host.ask("11 VARS nothing").starts_with("ACK 11"));
    assert!(
        host.seen
            .iter()
            .any(|l| l.starts_with("EVT VAR nothing unknown")),
        "{:?}",
        host.seen
    );
    // A DIM is no statement to stop at; STEP INTO the CALL: the first statement of the SUB.
    assert_eq!(host.ask("12 STEP"), "ACK 12");
    assert_eq!(
        host.until("EVT PROGRAM p PAUSED"),
        "EVT PROGRAM p PAUSED p:3"
    );
    assert_eq!(host.ask("14 STEP INTO"), "ACK 14");
    host.until("EVT PROGRAM p PAUSED p:9");
    // Running, STEP is refused; PAUSE stops it again.
    assert_eq!(host.ask("15 CONTINUE"), "ACK 15");
    let r = host.ask("16 STEP");
    assert!(r.starts_with("NAK 16 127 ") || r == "INF 9", "{r}");
    assert_eq!(host.until("INF 9"), "INF 9");
}

#[test]
fn named_points_are_stored_next_to_the_program_taught_by_it_and_listed() {
    let text = "MOVEL P1\nPRINT DIST(HERE(), P1) < 0.01\nTEACH P2\nEND\n";
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    // A program that needs P1 does not compile without it; the error says how to get it.
    let r = host.upload(3, "p", text);
    assert!(r.starts_with("NAK 3 126 "), "{r}");
    assert!(r.contains("P1") && r.contains("named point"), "{r}");
    // Teaching P1 (before the program is stored: the points belong to its name).
    let (_, x, y) = host.where_();
    let p1 = format!("{:.3} {:.3} 0 0", x + 50.0, y - 30.0);
    host.seen.clear();
    let r = host.ask(&format!("20 POINT p P1 {p1}"));
    assert!(r.starts_with("ACK 20 p P1 pose "), "{r}");
    assert!(
        host.seen
            .iter()
            .any(|l| l.starts_with("EVT POINT p P1 pose ")),
        "{:?}",
        host.seen
    );
    assert!(host.upload(4, "p", text).starts_with("ACK 4 name=p "));
    host.seen.clear();
    assert_eq!(run(&mut host), "INF 9", "{:?}", host.seen);
    assert_eq!(printed(&host), ["TRUE"]);
    // TEACH stored P2 where the robot stood: at P1.
    host.seen.clear();
    assert_eq!(host.ask("21 POINTS p"), "ACK 21 points=2");
    let listed: Vec<&String> = host
        .seen
        .iter()
        .filter(|l| l.starts_with("EVT POINT p "))
        .collect();
    assert_eq!(listed.len(), 2, "{listed:?}");
    let p2 = listed
        .iter()
        .find(|l| l.starts_with("EVT POINT p P2 pose "))
        .unwrap_or_else(|| panic!("{listed:?}"));
    let xy: Vec<f64> = p2["EVT POINT p P2 pose ".len()..]
        .split(' ')
        .map(|v| v.parse().unwrap())
        .collect();
    assert!(
        (xy[0] - (x + 50.0)).abs() < 0.01 && (xy[1] - (y - 30.0)).abs() < 0.01,
        "{p2}"
    );
    // POINT … HERE stores where the robot is; DELETE removes a point.
    assert_eq!(host.motion(22, "HOME"), "INF 22");
    let r = host.ask("23 POINT p P2 HERE");
    assert!(r.starts_with("ACK 23 p P2 pose "), "{r}");
    assert_eq!(host.ask("24 POINT p P2 DELETE"), "ACK 24 p P2 deleted");
    assert_eq!(host.ask("25 POINTS p"), "ACK 25 points=1");
    // Bad points are refused with a clear error and nothing changes.
    assert!(host.ask("26 POINT p 9x 1 2 3 4").starts_with("NAK 26 "));
    assert!(host.ask("27 POINT p P3 1 2").starts_with("NAK 27 "));
    assert!(host.ask("28 POINT p P9 DELETE").starts_with("NAK 28 106 "));
    assert_eq!(host.ask("29 POINTS p"), "ACK 29 points=1");
}

#[test]
fn a_program_includes_a_stored_library_and_calls_another_stored_program() {
    let mut host = VHost::start();
    let lib = "SUB greet(who$)\n  PRINT \"hello\", who$\nENDSUB\nFUNCTION twice(v)\n  RETURN v * 2\nENDFUNCTION\n";
    assert!(host.upload(4, "lib", lib).starts_with("ACK 4 name=lib "));
    let other = "PRINT \"other runs\"\n";
    assert!(host
        .upload(5, "other", other)
        .starts_with("ACK 5 name=other "));
    ready_with(
        &mut host,
        "INCLUDE \"lib\"\nCALL greet(\"cell\")\nPRINT twice(21)\nCALL PROGRAM \"other\"\nPRINT \"back\"\n",
    );
    assert_eq!(run(&mut host), "INF 9", "{:?}", host.seen);
    assert_eq!(printed(&host), ["hello cell", "42", "other runs", "back"]);
    // A library that no longer compiles with it is named in the refusal.
    assert!(host
        .upload(6, "lib", "SUB greet(who$)\n  PRINT who$\nENDSUB\n")
        .starts_with("ACK 6 "));
    host.seen.clear();
    let r = host.ask("9 RUN p");
    assert!(r.starts_with("NAK 9 126 "), "{r}: {:?}", host.seen);
    assert!(
        host.seen
            .iter()
            .any(|l| l.starts_with("EVT DIAG") && l.contains("twice")),
        "{:?}",
        host.seen
    );
}

/// The virtual times at which board 0's commanded position of some axis did not change
/// between two periods, from `first` to `last` [ns] (the robot paused on its way).
fn standstills(pulses: &[(u64, Vec<i64>)], first: u64, last: u64) -> Vec<u64> {
    pulses
        .windows(2)
        .filter(|w| w[1].0 > first && w[1].0 < last && w[0].1 == w[1].1)
        .map(|w| w[1].0)
        .collect()
}

#[test]
fn blended_lines_and_an_arc_run_as_one_motion_that_does_not_stop_at_the_corners() {
    let text = "\
MOVEP POSE(250, 0, 0, 0), R
PRINT \"start\"
MOVEL POSE(250, 100, 0, 0) BLEND 20
MOVEL POSE(150, 100, 0, 0) BLEND 20
ARC POSE(100, 150, 0, 0), POSE(150, 200, 0, 0) BLEND 10
MOVEL POSE(250, 200, 0, 0) SPEED 50
PRINT \"end\", HERE()
";
    let mut host = ready(text);
    host.sim.record_pulses(true);
    assert_eq!(host.ask("9 RUN p"), "ACK 9");
    host.until("EVT PRINT start");
    let first = host.sim.now_ns();
    assert_eq!(host.reply(), "INF 9", "{:?}", host.seen);
    let end = printed(&host).pop().unwrap();
    assert_eq!(end, "end POSE(250, 200, 0, 0)");
    let pulses = host.sim.take_pulses();
    // From the first period in which it moved to the last: never a period standing.
    let moving: Vec<u64> = pulses
        .windows(2)
        .filter(|w| w[1].0 > first && w[0].1 != w[1].1)
        .map(|w| w[1].0)
        .collect();
    let (start, stop) = (moving[0], *moving.last().unwrap());
    assert_eq!(standstills(&pulses, start, stop), Vec::<u64>::new());
    // Without BLEND, the same moves stop at every corner.
    let unblended = text.replace(" BLEND 20", "").replace(" BLEND 10", "");
    let mut host = ready(&unblended);
    host.sim.record_pulses(true);
    assert_eq!(host.ask("9 RUN p"), "ACK 9");
    host.until("EVT PRINT start");
    let first = host.sim.now_ns();
    assert_eq!(host.reply(), "INF 9", "{:?}", host.seen);
    let pulses = host.sim.take_pulses();
    let moving: Vec<u64> = pulses
        .windows(2)
        .filter(|w| w[1].0 > first && w[0].1 != w[1].1)
        .map(|w| w[1].0)
        .collect();
    let (start, stop) = (moving[0], *moving.last().unwrap());
    assert!(!standstills(&pulses, start, stop).is_empty());
}

#[test]
fn the_example_wafer_cycle_skips_empty_slots_and_gives_up_a_wafer_the_operator_skips() {
    let scratch = tempfile::tempdir().unwrap();
    let demo = std::fs::read_to_string(repo().join("config/stations.toml")).unwrap();
    // LP1 lacks the wafers of slots 3 and 7; LP2 slot 10 is taken already.
    let cell = demo
        .replacen(
            "wafers = \"11111 11111 11111 11111 11111\"",
            "wafers = \"11011 10111 11111 11111 11111\"",
            1,
        )
        .replacen(
            "wafers = \"00000 00000 00000 00000 00000\"",
            "wafers = \"00000 00001 00000 00000 00000\"",
            1,
        );
    let stations = scratch.path().join("cell.toml");
    std::fs::write(&stations, &cell).unwrap();
    let mut host = VHost::start_with(SimCellFrom {
        stations: Some(&stations),
        world: None,
    });
    let library = std::fs::read_to_string(repo().join("examples/cell_lib.wrl")).unwrap();
    assert!(host.upload(5, "cell_lib", &library).starts_with("ACK 5 "));
    let program = std::fs::read_to_string(repo().join("examples/wafer_cycle.wrl")).unwrap();
    ready_with(&mut host, &program);
    assert_eq!(host.ask("9 RUN p"), "ACK 9");
    // After the second wafer, someone takes the wafer of LP1 slot 5 away.
    host.until("EVT PRINT wafer 2 of 22:");
    let slot5 = {
        let board = host.sim.board(0).unwrap();
        let world = board.cell().unwrap().world();
        match world.slot("LP1", 5).unwrap() {
            wrc_board::wrc_cell::SlotContent::Wafer(tag) => tag,
            other => panic!("{other:?}"),
        }
    };
    edit_world(&host, |t| t.replacen(&format!("\"T{slot5}\""), "\"-\"", 1));
    let alarm = host.until("EVT ALARM");
    assert!(
        alarm.starts_with("EVT ALARM 1001 p cell_lib:")
            && alarm.ends_with(": no wafer on the hand from LP1 slot 5"),
        "{alarm}"
    );
    host.until("EVT PROGRAM p WAITING");
    assert_eq!(host.ask("10 CONTINUE skip"), "ACK 10");
    assert_eq!(host.reply(), "INF 9", "{:?}", host.seen);
    let out = printed(&host);
    assert_eq!(out.last().unwrap(), "all 21 wafers are in LP2");
    for line in [
        "LP1 slot 3 holds no wafer: skipped",
        "LP1 slot 7 holds no wafer: skipped",
        "LP2 slot 10 is taken: LP1 slot 10 stays",
        "wafer 21 of 22: LP1 slot 25 -> AL -> LP2 slot 25",
    ] {
        assert!(out.iter().any(|l| l == line), "{line}: {out:?}");
    }
    // The cell and the map agree: slot 5's wafer was skipped (the station was mapped
    // again), slot 10's stayed.
    assert_eq!(host.truth("LP1"), "0000000001000000000000000");
    assert_eq!(host.truth("LP2"), "1101010111111111111111111");
    let wafers = host.ask("11 WAFERS");
    for station in ["LP1", "LP2", "AL"] {
        assert_eq!(
            crate::vhost::map_codes(&wafers, station),
            host.truth(station),
            "{station}: {wafers}"
        );
    }
}

#[test]
fn here_stays_the_exact_target_once_the_robot_has_settled() {
    let mut host = ready(
        "MOVEL POSE(300, 0, 5, 0)\nPRINT HERE()\nDELAY 1\nPRINT HERE()\nMOVEP POSE(250, 100, 0, 30)\nDELAY 1\nPRINT HERE()\n",
    );
    assert_eq!(run(&mut host), "INF 9");
    assert_eq!(
        printed(&host),
        [
            "POSE(300, 0, 5, 0)",
            "POSE(300, 0, 5, 0)",
            "POSE(250, 100, 0, 30)"
        ]
    );
}

#[test]
fn a_called_programs_teach_goes_to_its_own_points_file() {
    let mut host = VHost::start();
    assert!(host
        .ask("4 POINT callee REST JOINTS 0 90 0 5")
        .starts_with("ACK 4 "));
    let callee = "MOVEJ JOINTS(10, 90, 0, 5)\nTEACH REST\nPRINT REST\n";
    assert!(host.upload(5, "callee", callee).starts_with("ACK 5 "));
    ready_with(&mut host, "CALL PROGRAM \"callee\"\nTEACH HOME_HERE\n");
    assert_eq!(run(&mut host), "INF 9", "{:?}", host.seen);
    assert!(
        host.seen
            .iter()
            .any(|l| l == "EVT POINT callee REST joints 10 90 0 5"),
        "{:?}",
        host.seen
    );
    assert_eq!(printed(&host), ["JOINTS(10, 90, 0, 5)"]);
    // The caller's own TEACH goes to its file.
    assert!(host.ask("6 POINTS p").starts_with("ACK 6 points=1"));
    host.seen.clear();
    assert_eq!(host.ask("7 POINTS callee"), "ACK 7 points=1");
    assert_eq!(host.seen[0], "EVT POINT callee REST joints 10 90 0 5");
}

#[test]
fn a_held_program_move_resumes_at_its_own_speed_and_acceleration() {
    let config = wrc_config::Config::embedded_default();
    let j1 = &config.robot.axes()[0];
    let mut host = ready("MOVEJ JOINTS(150, 90, 0, 5) SPEED 20 ACCEL 25\nPRINT \"there\"\n");
    assert_eq!(host.ask("9 RUN p"), "ACK 9");
    host.wait_moving("the move under way", |j, _, _| j[0] > 20.0);
    assert_eq!(host.ask("10 HOLD"), "ACK 10");
    host.poll("HELD", |h| {
        let s = h.status();
        if s.contains("state=HELD") {
            Ok(())
        } else {
            Err(s)
        }
    });
    host.sim.record_pulses(true);
    assert_eq!(host.ask("11 RESUME"), "ACK 11");
    assert_eq!(host.reply(), "INF 9");
    let pulses = host.sim.take_pulses();
    // The fastest J1 went after RESUME, from period to period of the board.
    let fastest = pulses
        .windows(2)
        .map(|w| {
            let dt = (w[1].0 - w[0].0) as f64 * 1e-9;
            (w[1].1[0] - w[0].1[0]).abs() as f64 / j1.pulses_per_unit / dt
        })
        .fold(0.0, f64::max);
    let limit = j1.limits.max_velocity;
    assert!(
        fastest <= 0.2 * limit * 1.01 && fastest > 0.1 * limit,
        "J1 at {fastest} deg/s after RESUME; SPEED 20 of {limit}"
    );
    let (j, _, _) = host.where_();
    assert!((j[0] - 150.0).abs() < 0.01, "{j:?}");
}

/// A program's `OUT` goes through the same guard as a host's: the vacuum valve of a blade
/// that holds a wafer cannot be switched off (141, an error its TRY may catch), and a
/// program has no FORCE. The wafer stays held, in the map and the cell.
#[test]
fn a_programs_out_of_the_valve_of_a_held_wafer_is_refused_with_141() {
    let mut host = ready(
        "\
MAP \"LP1\"
GET \"LP1\", 1
TRY
  OUT 0, 0
  PRINT \"not reached\"
CATCH 141
  PRINT \"guarded\", ERR, HAND$()
ENDTRY
PUT \"LP1\", 1
PRINT \"back\", WAFER$(\"LP1\", 1)
",
    );
    assert_eq!(run(&mut host), "INF 9", "{:?}", host.seen);
    assert_eq!(printed(&host), ["guarded 141 W1", "back W1"]);
    assert!(!host
        .seen
        .iter()
        .any(|l| l.starts_with("EVT ERROR") || l.starts_with("EVT RECOVERY forced")));
    assert_eq!(host.truth("LP1"), "1".repeat(25));
}
