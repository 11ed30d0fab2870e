//! Straight lines through the host protocol of a real `wrc up`: a line past a joint's range
//! is refused before anything moves (NAK, or a program's runtime error) with the axis, where
//! along the line and the pose. GET/PUT at the buffer behind the robot (BF1, reached on a
//! straight line only with the left elbow) run on virtual time in `wrc-controller`'s
//! `sessions` tests.

use crate::up::{Client, Controller};

/// The joints from `WHERE` [deg, deg, deg, mm].
fn joints(host: &mut Client) -> Vec<f64> {
    host.where_().0
}

fn assert_same_place(a: &[f64], b: &[f64]) {
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() < 0.002, "the robot moved: {a:?} → {b:?}");
    }
}

#[test]
fn a_line_past_the_shoulders_range_is_refused_before_anything_moves() {
    let c = Controller::start(&[]);
    let mut host = c.client();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert_eq!(host.motion(3, "MOVP -97.4 -200.1 25.0 -87.2"), "INF 3");
    let before = joints(&mut host);
    // The shoulder would pass -180 deg on the way: such a line was once accepted and
    // crawled at about 1 mm/s for minutes.
    let r = host.ask("4 MOVL -171.7 -19.7 34.4 -84.2");
    assert!(r.starts_with("NAK 4 113 "), "{r}");
    assert!(
        r.contains("axis j1 would go beyond its limits [-180, 180]")
            && r.contains("% of its length")
            && r.contains("x=")
            && r.contains("yaw="),
        "{r}"
    );
    assert!(host.status().starts_with("ACK state=IDLE"));
    assert_same_place(&before, &joints(&mut host));
    // A line that stays in range is accepted and ends where it was sent.
    assert_eq!(host.motion(5, "MOVL -60 -250 40 -87.2"), "INF 5");
    let (_, x, y) = host.where_();
    assert!(
        (x + 60.0).abs() < 0.01 && (y + 250.0).abs() < 0.01,
        "{x} {y}"
    );

    // The same refusal ends a program at the statement, with the same words.
    assert_eq!(host.motion(6, "MOVP -97.4 -200.1 25.0 -87.2"), "INF 6");
    let before = joints(&mut host);
    host.send_raw(b"7 UPLOAD past\nMOVEL POSE(-171.7, -19.7, 34.4, -84.2)\nPRINT \"never\"\n.\n");
    assert!(host.reply().starts_with("ACK 7 name=past "));
    host.seen.clear();
    let end = host.motion(8, "RUN past");
    assert!(end.starts_with("ABS 8 113 past line 1: "), "{end}");
    assert!(end.contains("axis j1 would go beyond its limits"), "{end}");
    assert!(!host.seen.iter().any(|l| l.contains("never")));
    assert_same_place(&before, &joints(&mut host));
}
