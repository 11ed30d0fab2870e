//! HOLD and RESUME through the host protocol of a real `wrc up`: a held PTP brakes on its
//! joint line and stays open (no INF/ABS), the state is HELD, RESUME continues it to the
//! same target. A held straight line, STOP of a held motion and a held GET run on virtual
//! time in `wrc-controller`'s `sessions` tests.
//!
//! The hold is sent once the arm is seen moving (polled with STATUS and WHERE, bounded by a
//! deadline that only a failure reaches), never after a sleep.

use crate::up::{Client, Controller};

/// Read until `EVT STATE <state>`; fail on a final reply of `id` on the way.
fn until_state(host: &mut Client, state: &str, id: u32) {
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

fn hold(host: &mut Client, id: u32) {
    assert_eq!(host.ask("HOLD"), "ACK");
    until_state(host, "HELD", id);
    assert!(host.status().starts_with("ACK state=HELD"));
}

#[test]
fn a_held_ptp_stays_on_its_joint_line_and_resumes_to_its_target() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert_eq!(host.ask("RESUME"), "NAK 129 no motion is held");
    assert_eq!(host.ask("HOLD"), "ACK", "HOLD at rest is harmless");
    assert!(host.status().starts_with("ACK state=IDLE"));
    let (start, _, _) = host.where_();
    assert!(host.ask("SPEED 30").starts_with("ACK"));
    let target = [60.0, 30.0, 120.0, 0.0];
    assert_eq!(host.ask("3 MOVJ 60 30 120 0"), "ACK 3");
    host.wait_moving("j1 20 deg on its way", |j, _, _| {
        (j[0] - start[0]).abs() > 20.0
    });
    hold(&mut host, 3);
    let (held, _, _) = host.where_();
    // Phase-synchronised: every axis has covered the same fraction of its distance.
    let f = (held[0] - start[0]) / (target[0] - start[0]);
    assert!(f > 0.1 && f < 0.95, "held at fraction {f}");
    for i in 0..3 {
        let fi = (held[i] - start[i]) / (target[i] - start[i]);
        assert!((fi - f).abs() < 1e-3, "axis {i} at {fi}, j1 at {f}");
    }
    // While held: no new motion, and the hold survives queries.
    assert!(host.ask("4 MOVJ 0 90 0 0").starts_with("NAK 4 121 "));
    assert!(host.status().starts_with("ACK state=HELD"));
    assert_eq!(host.ask("RESUME"), "ACK");
    assert_eq!(host.reply(), "INF 3");
    let (end, _, _) = host.where_();
    for (e, t) in end.iter().zip(target) {
        assert!((e - t).abs() < 0.002, "{end:?}");
    }
    assert!(host.status().starts_with("ACK state=IDLE"));
    c.stop_clear_of_the_cell();
}
