//! A motion board that stops answering, on virtual time: the Pulse Generator sees its
//! heartbeat stand and raises fatal error 300 within the configured periods (`ABS` for the
//! motion, `EVT ERROR`, state `ERROR`); RESET is refused until the board runs again, then
//! re-attaches it where the arm stands; the wafer map keeps a wafer on the hand, uncertain,
//! and a transfer under way pending, until the board's sensors answer again.

use crate::vhost::VHost;

/// The Pulse Generator's period and the default `heartbeat_periods` [ns, periods].
const PERIOD_NS: u64 = 10_000_000;
const HEARTBEAT_PERIODS: u64 = 3;

fn homed() -> VHost {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    host
}

/// The board is dead: read until the line starting with `prefix`, and return it with the
/// virtual time it came at.
fn until_timed(host: &mut VHost, prefix: &str) -> (String, u64) {
    let line = host.until(prefix);
    (line, host.sim.now_ns())
}

/// RESET until the board has answered for long enough to be re-attached: every answer is
/// either the refusal 300 or the ACK.
fn reset_until_attached(host: &mut VHost, id: u32) {
    host.poll("RESET to re-attach the restarted board", |h| {
        let r = h.ask(&format!("{id} RESET"));
        if r == format!("ACK {id}") {
            Ok(())
        } else {
            assert!(r.starts_with(&format!("NAK {id} 300 ")), "{r}");
            Err(r)
        }
    });
}

#[test]
fn a_board_that_dies_mid_move_ends_it_with_300_and_a_reset_reattaches_it() {
    let mut host = homed();
    assert_eq!(host.ask("3 MOVJ 90 60 -45 0"), "ACK 3");
    host.wait_moving("J1 on its way", |j, _, _| j[0] > -40.0);
    let died_ns = host.sim.now_ns();
    assert!(host.sim.kill_board(0));

    // Fatal error 300: the motion ends, every connection hears it, state ERROR.
    let (evt, evt_ns) = until_timed(&mut host, "EVT ERROR");
    assert!(evt.starts_with("EVT ERROR 300 "), "{evt}");
    assert!(
        host.seen.iter().any(|l| l.starts_with("ABS 3 300 ")),
        "{:?}",
        host.seen
    );
    // Seen within the heartbeat's allowance, plus the period that reads it and the one
    // that replies.
    let waited = evt_ns - died_ns;
    assert!(
        waited <= (HEARTBEAT_PERIODS + 2) * PERIOD_NS,
        "error 300 came {waited} ns after the board died"
    );
    assert!(host.status().contains("state=ERROR"), "{}", host.status());
    let (stood, _, _) = host.where_();

    // Nothing re-attaches a board that does not answer; the arm stands where it was.
    let refused = host.ask("4 RESET");
    assert!(refused.starts_with("NAK 4 300 "), "{refused}");
    host.sim.run_for_ns(500_000_000);
    assert_eq!(host.where_().0, stood);
    assert!(host.status().contains("state=ERROR"));

    // The board runs again (restarted on its DPRAM): RESET re-attaches it at the position
    // its encoders kept, and motion works again.
    host.sim.restart_board(0).unwrap();
    reset_until_attached(&mut host, 5);
    assert!(host.status().contains("state=IDLE"), "{}", host.status());
    let (joints, _, _) = host.where_();
    for (a, b) in joints.iter().zip(&stood) {
        assert!(
            (a - b).abs() < 0.01,
            "re-attached at {joints:?}, stood at {stood:?}"
        );
    }
    assert_eq!(host.motion(6, "MOVJ 0 90 0 5"), "INF 6");
    let (joints, _, _) = host.where_();
    assert!(
        (joints[0] - 0.0).abs() < 0.01 && (joints[1] - 90.0).abs() < 0.01,
        "{joints:?}"
    );
}

#[test]
fn a_wafer_on_the_hand_of_a_dead_board_is_uncertain_until_its_sensor_answers() {
    let mut host = homed();
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3"));
    assert_eq!(host.motion(4, "GET LP1 1"), "INF 4 W1");

    // At rest with W1 on the hand: the board dies all the same.
    host.sim.kill_board(0);
    let evt = host.until("EVT ERROR");
    assert!(evt.starts_with("EVT ERROR 300 "), "{evt}");
    let wafers = host.poll("the map to mark W1 uncertain", |h| {
        let w = h.ask("WAFERS");
        if w.contains(" hand=W1? ") {
            Ok(w)
        } else {
            Err(w)
        }
    });
    assert!(!wafers.contains("pending="), "{wafers}");
    // No transfer is planned on a map the sensors cannot confirm (state ERROR refuses it
    // first; the map would too).
    let get = host.ask("7 GET LP1 2");
    assert!(get.starts_with("NAK 7 "), "{get}");

    host.sim.restart_board(0).unwrap();
    reset_until_attached(&mut host, 8);
    // The vacuum held (the restarted board keeps its latched outputs), the sensor senses
    // W1: certain again, and the cell agrees.
    host.poll("the map to settle W1 from the sensor", |h| {
        let w = h.ask("WAFERS");
        if w.contains(" hand=W1 ") {
            Ok(())
        } else {
            Err(w)
        }
    });
    assert!(!host.hand_empty(), "the wafer is on the cell's hand");
    assert_eq!(host.motion(9, "PUT LP1 1"), "INF 9 W1");
    assert!(host.hand_empty());
}

#[test]
fn a_transfer_cut_by_a_dead_board_stays_pending_until_the_sensor_settles_it() {
    let mut host = homed();
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3"));
    assert_eq!(host.ask("4 GET LP1 2"), "ACK 4");
    // On the way to LP1, long before the hand reaches the wafer.
    host.sim.run_for_ns(300_000_000);
    host.sim.kill_board(0);
    let abs = host.until("ABS 4");
    assert!(abs.starts_with("ABS 4 300 "), "{abs}");
    let wafers = host.poll("the transfer to stay pending", |h| {
        let w = h.ask("WAFERS");
        if w.contains(" pending=get:LP1.2:W2") {
            Ok(w)
        } else {
            Err(w)
        }
    });
    assert!(wafers.contains(" hand=- "), "{wafers}");

    host.sim.restart_board(0).unwrap();
    reset_until_attached(&mut host, 5);
    // The sensor senses no wafer: the GET had not happened, W2 is still in LP1 slot 2,
    // as in the cell.
    host.poll("the pending GET to be settled", |h| {
        let w = h.ask("WAFERS");
        if !w.contains("pending=") {
            Ok(())
        } else {
            Err(w)
        }
    });
    let wafers = host.ask("WAFERS");
    assert!(wafers.contains(" hand=- "), "{wafers}");
    assert_eq!(
        crate::vhost::map_codes(&wafers, "LP1"),
        host.truth("LP1"),
        "{wafers}"
    );
    assert!(host.hand_empty());
    assert_eq!(host.motion(6, "GET LP1 2"), "INF 6 W2");
}

#[test]
fn a_live_board_whose_encoder_sticks_still_trips_the_following_error() {
    // The other side of the heartbeat: a board that runs, but whose axis does not follow
    // its command, is caught by the following error (203), not by the heartbeat.
    let mut host = homed();
    assert_eq!(host.ask("3 MOVJ 90 60 -45 0"), "ACK 3");
    host.wait_moving("J1 on its way", |j, _, _| j[0] > -60.0);
    host.inject("encoder-stuck 0 on");
    let end = host.until("ABS 3");
    assert!(end.starts_with("ABS 3 203 "), "{end}");
    assert!(host.status().contains("state=ERROR"));
    assert!(!host
        .sim
        .shared()
        .board_dead
        .load(std::sync::atomic::Ordering::Acquire));
    let refused = host.ask("4 RESET");
    // The board answers: RESET is not refused for a dead board (the alarm may still be
    // latched while the encoder is stuck, which is a different refusal).
    assert!(!refused.starts_with("NAK 4 300"), "{refused}");
}
