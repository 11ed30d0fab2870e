//! A 1 kHz servo on a host that stalls, on virtual time: the Pulse Generator keeps
//! `[motion] lookahead_ms` (100 periods) queued, so a stall of half of it costs no underrun;
//! a stall longer than the host watchdog stops the axes with the board's own jerk-limited
//! brake; and a stop asked during a stall is braked by the board on time, from the moment
//! it sees the stop word, not when the Pulse Generator runs again.

use wrc_board::layout::{axis, axis_base, control};
use wrc_config::Config;
use wrc_controller::pulse_generator::IN_POSITION_PERIODS;
use wrc_controller::simulation::SimCellFrom;
use wrc_motion::Brake1d;

use crate::vhost::VHost;

/// The board's and the Pulse Generator's period [ns].
const PERIOD_NS: u64 = 1_000_000;

/// The embedded default at 1 kHz: the motion period and the Pulse Generator's (and the
/// Simulator Manager's, which streams it) at 1 ms; the look-ahead (100 ms), the watchdog
/// (150 ms) and the FIFO (256) as shipped.
fn khz() -> Config {
    let text = wrc_config::DEFAULT_TOML.replacen("period_ms = 10.0 ", "period_ms = 1.0 ", 1);
    let mut out = String::new();
    let mut fast = false;
    for line in text.lines() {
        if line.starts_with("name = ") {
            fast = line.contains("pulse_generator") || line.contains("simulator_manager");
        }
        if fast && line.starts_with("period_ms = 10") {
            out.push_str("period_ms = 1\n");
            continue;
        }
        out.push_str(line);
        out.push('\n');
    }
    let config = Config::parse(&out, "khz").unwrap();
    assert_eq!(config.motion.period_s, 0.001);
    assert_eq!(config.lookahead_periods, 100);
    assert_eq!(config.boards[0].watchdog_periods, 150);
    config
}

/// Homed at 1 kHz, a long J1 move under way and cruising.
fn cruising() -> VHost {
    let mut host = VHost::start_config(&khz(), SimCellFrom::default());
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert_eq!(host.ask("3 MOVJ 100 150 -75 0"), "ACK 3");
    // J1 from −75° at 180 deg/s: cruising from about 0.35 s on.
    host.wait_moving("J1 cruising", |j, _, _| j[0] > 0.0);
    host
}

/// Wait until the controller has the robot at rest (the brake over, the board released).
fn at_rest(host: &mut VHost) {
    host.poll("at rest", |h| {
        if h.sim
            .shared()
            .in_flight
            .load(std::sync::atomic::Ordering::Acquire)
            != 0
        {
            Err(h.status())
        } else {
            Ok(())
        }
    });
}

fn underruns(host: &VHost) -> u32 {
    let board = host.sim.board(0).unwrap();
    (0..4)
        .map(|c| board.dpram().load(axis_base(c) + axis::UNDERRUNS))
        .sum()
}

fn board_word(host: &VHost, offset: usize) -> u32 {
    host.sim.board(0).unwrap().dpram().load(offset)
}

#[test]
fn a_stall_of_half_the_look_ahead_costs_no_underrun_and_a_longer_one_is_braked() {
    let mut host = cruising();
    host.sim.stall_pulse_generator(50 * PERIOD_NS);
    assert_eq!(host.reply(), "INF 3");
    assert_eq!(underruns(&host), 0);
    // The stall drained the FIFO by about its length, and no further.
    let fifo = host.sim.shared().fifo.read();
    let deepest = fifo.lookahead - fifo.min_level.unwrap();
    assert!((49..=51).contains(&deepest), "{fifo:?}");
    assert_eq!(board_word(&host, control::BOARD_STOPS), 0);

    // A stall longer than the look-ahead (but shorter than the watchdog) runs the FIFO
    // dry: the board brakes on its own rather than hold, and the motion ends with 209.
    assert_eq!(host.ask("4 MOVJ -75 150 -75 0"), "ACK 4");
    host.wait_moving("J1 cruising back", |j, _, _| j[0] < 0.0);
    host.sim.stall_pulse_generator(120 * PERIOD_NS);
    let end = host.reply();
    assert!(end.starts_with("ABS 4 209 "), "{end}");
    assert!(underruns(&host) >= 1);
    assert_eq!(board_word(&host, control::BOARD_STOPS), 1);
    assert_eq!(board_word(&host, control::WATCHDOG_TRIPS), 0);
}

#[test]
fn a_stall_longer_than_the_watchdog_stops_the_axes_within_their_limits() {
    let mut host = cruising();
    host.sim.record_pulses(true);
    host.sim.stall_pulse_generator(200 * PERIOD_NS);
    let end = host.reply();
    assert!(end.starts_with("ABS 3 2"), "{end}");
    host.until("EVT STATE ERROR");
    at_rest(&mut host);
    host.sim.run_for_ns(50 * PERIOD_NS);
    assert_eq!(board_word(&host, control::WATCHDOG_TRIPS), 1);
    // J1's velocity over 10 ms windows never changes faster than its 720 deg/s² (720 000
    // pulse/s², 7.2 pulses per ms per 10 ms), and it comes to rest.
    let rows = host.sim.take_pulses();
    let j1: Vec<i64> = rows.iter().map(|(_, p)| p[0]).collect();
    let v: Vec<i64> = j1.windows(2).map(|w| w[1] - w[0]).collect();
    for w in v.windows(11) {
        let a = (w[10] - w[0]) as f64 / 10e-6;
        assert!(a.abs() <= 720_000.0 * 1.05 + 1e5, "{a} pulse/s²: {v:?}");
    }
    assert_eq!(v[v.len() - 20..], [0; 20], "{v:?}");
    // RESET takes the board's position; the robot moves again, exactly.
    assert_eq!(host.ask("5 RESET"), "ACK 5");
    assert_eq!(host.motion(6, "MOVJ 0 90 0 5"), "INF 6");
    let (j, _, _) = host.where_();
    assert_eq!(j, vec![0.0, 90.0, 0.0, 5.0]);
    let board = host.sim.board(0).unwrap();
    assert_eq!(board.axis(0).unwrap().commanded(), 0);
    assert_eq!(board.axis(3).unwrap().commanded(), 5_000);
}

#[test]
fn an_estop_during_a_stall_is_braked_by_the_board_on_time() {
    let mut host = cruising();
    host.sim.record_pulses(true);
    host.sim.run_for_ns(20 * PERIOD_NS);
    // The Pulse Generator stalls for 75 ms (less than the look-ahead); 1 ms into it the
    // ESTOP comes (the Ethernet task, on the other CPU, still runs).
    host.sim.stall_pulse_generator(75 * PERIOD_NS);
    host.sim.run_for_ns(PERIOD_NS);
    let asked_ns = host.sim.now_ns();
    host.send_raw("7 ESTOP\n");
    let end = host.until("ABS 3 ");
    assert!(end.starts_with("ABS 3 201 "), "{end}");
    at_rest(&mut host);
    assert_eq!(board_word(&host, control::BOARD_STOPS), 1);
    assert!(host.sim.shared().fifo.read().board_stops >= 1);
    let rows = host.sim.take_pulses();
    // The board period that first sees the stop word, and the state it was in then.
    let seen = rows.iter().position(|(t, _)| *t > asked_ns).unwrap();
    let j1: Vec<f64> = rows.iter().map(|(_, p)| p[0] as f64).collect();
    let v0 = (j1[seen - 1] - j1[seen - 11]) / 10e-3;
    let a0 = ((j1[seen - 1] - j1[seen - 6]) - (j1[seen - 6] - j1[seen - 11])) / 25e-6;
    let reference = Brake1d::new(0.0, v0, a0, 720_000.0, 7_200_000.0);
    let last = j1.iter().rposition(|p| *p != j1[j1.len() - 1]).unwrap() + 1;
    let time_s = (last - (seen - 1)) as f64 * 1e-3;
    let distance = j1[j1.len() - 1] - j1[seen - 1];
    assert!(v0 > 170_000.0, "J1 was not cruising: {v0} pulse/s");
    // From the moment the board sees the stop word: within 1.05 times the time-optimal
    // brake of that state, plus the period the board waits for the host's brake.
    assert!(
        time_s <= 1.05 * reference.duration() + 1e-3 + 1e-9,
        "{time_s} s against {} s",
        reference.duration()
    );
    assert!(
        distance <= 1.05 * reference.stop_position() + v0 * 1e-3,
        "{distance} pulses against {}",
        reference.stop_position()
    );
    // The robot goes on after the RESET: the board was released.
    assert_eq!(host.ask("8 RESET"), "ACK 8");
    assert_eq!(host.motion(9, "MOVJ 0 90 0 5"), "INF 9");
}

/// The look-ahead (100 ms) is kept while moving only: at rest the Pulse Generator queues
/// nothing after the zero period that ends a motion, so a move starts on the board a period
/// or two after it is asked and is reported a few periods after the board executed its last
/// one, as with a short look-ahead; and a stall at rest costs no underrun.
#[test]
fn a_long_look_ahead_delays_neither_the_start_nor_the_end_of_a_move() {
    let mut host = VHost::start_config(&khz(), SimCellFrom::default());
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    host.sim.run_for_ns(50 * PERIOD_NS);
    let level = |host: &VHost| {
        let board = host.sim.board(0).unwrap();
        let d = board.dpram();
        d.load(axis_base(0) + axis::FIFO_WRITE)
            .wrapping_sub(d.load(axis_base(0) + axis::FIFO_READ)) as usize
    };
    assert_eq!(level(&host), 0, "queued at rest");
    // A stall at rest: the board holds, nothing is lost.
    host.sim.stall_pulse_generator(6 * PERIOD_NS);
    host.sim.run_for_ns(20 * PERIOD_NS);
    assert_eq!(underruns(&host), 0);
    assert_eq!(board_word(&host, control::BOARD_STOPS), 0);

    host.sim.record_pulses(true);
    host.send_raw("3 MOVJ -60 150 -75 0\n");
    assert_eq!(host.reply(), "ACK 3");
    let asked_ns = host.sim.now_ns();
    assert_eq!(host.reply(), "INF 3");
    let reported_ns = host.sim.now_ns();
    let rows = host.sim.take_pulses();
    let rest = rows[0].1[0];
    let first = rows.iter().find(|(_, p)| p[0] != rest).unwrap().0;
    let end = rows[rows
        .iter()
        .rposition(|(_, p)| p[0] != rows[rows.len() - 1].1[0])
        .unwrap()
        + 1]
    .0;
    // J1's first whole pulse comes about 9.4 ms into its jerk-limited start (7.2e6
    // pulse/s³: 1 pulse after (6 / 7.2e6)^(1/3) s); a queue kept at rest would add to it
    // (the look-ahead: 100 ms).
    assert!(
        first - asked_ns <= 20 * PERIOD_NS,
        "the move started {} ms after it was asked",
        (first - asked_ns) as f64 / 1e6
    );
    assert!(
        reported_ns - end <= (IN_POSITION_PERIODS as u64 + 5) * PERIOD_NS,
        "the move was reported {} ms after the board executed it",
        (reported_ns - end) as f64 / 1e6
    );
    // While it moved the FIFO held the look-ahead; it drained to empty at rest.
    let fifo = host.sim.shared().fifo.read();
    assert_eq!(fifo.lookahead, 100);
    assert!(fifo.min_level.unwrap() >= 95, "{fifo:?}");
    assert_eq!(level(&host), 0);
    assert_eq!(underruns(&host), 0);
}
