//! The cell as an obstacle for every motion, against the simulated cell's ground truth:
//! free moves (MOVJ, MOVP, MOVL, JOG) all over the workspace at every height, with the hand
//! empty and carrying a wafer, each either refused before anything moves or run (straight,
//! round through the travel height, or a jog stopped short) without one collision in the
//! simulated cell — also when an ESTOP stops it anywhere.

use proptest::prelude::Rng;
use proptest::test_runner::{RngAlgorithm, TestRng};
use wrc_protocol::reply_field;

use crate::vhost::VHost;

/// A number in [lo, hi) from `rng`.
fn uniform(rng: &mut TestRng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

/// A random free move over the demo robot's whole workspace: joints within their limits,
/// poses within its reach, every height of its Z axis.
fn free_move(rng: &mut TestRng) -> String {
    let z = uniform(rng, 0.0, 300.0);
    let r = uniform(rng, 60.0, 390.0);
    let phi = uniform(rng, -180.0, 180.0_f64).to_radians();
    let (x, y) = (r * phi.cos(), r * phi.sin());
    let yaw = uniform(rng, -180.0, 180.0);
    match rng.next_u64() % 5 {
        0 | 1 => format!(
            "MOVJ {:.1} {:.1} {:.1} {z:.1}",
            uniform(rng, -175.0, 175.0),
            uniform(rng, -160.0, 160.0),
            uniform(rng, -260.0, 260.0)
        ),
        2 => format!(
            "MOVP {x:.1} {y:.1} {z:.1} {yaw:.1} {}",
            if rng.next_u64() % 2 == 0 { "R" } else { "L" }
        ),
        3 => format!("MOVL {x:.1} {y:.1} {z:.1} {yaw:.1}"),
        _ => {
            let axis = 1 + rng.next_u64() % 4;
            let span = if axis == 4 { 150_000.0 } else { 120_000.0 };
            format!("JOG {axis} {:.0}", uniform(rng, -span, span))
        }
    }
}

/// What became of the free moves.
#[derive(Debug, Default)]
struct Tally {
    refused: u32,
    ran: u32,
    routed: u32,
    shortened: u32,
    stopped: u32,
}

/// `count` seeded free moves from where `host` stands, every third one that runs stopped
/// by an ESTOP somewhere along it; the simulated cell must count no collision.
fn fuzz(host: &mut VHost, seed: u8, count: u32, tally: &mut Tally) {
    let mut rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[seed; 32]);
    let sides = host.world().side_collisions();
    for i in 0..count {
        let id = 1000 + i;
        let request = free_move(&mut rng);
        let before = host.encoders();
        let ack = host.ask(&format!("{id} {request}"));
        if ack.starts_with(&format!("NAK {id}")) {
            // Refused before anything moved.
            tally.refused += 1;
            host.sim.run_for_ns(20_000_000);
            assert_eq!(host.encoders(), before, "{request}: {ack}");
            continue;
        }
        assert!(ack.starts_with(&format!("ACK {id}")), "{request}: {ack}");
        tally.routed += u32::from(ack.contains("route=travel"));
        tally.shortened += u32::from(ack.contains("limited="));
        tally.ran += 1;
        let stop = tally.ran % 3 == 0;
        if stop {
            host.sim
                .run_for_ns(rng.next_u64() % 2_000_000_000 + 10_000_000);
        }
        // (A move that has ended already is not stopped: its INF is waiting.)
        if stop && !host.sim.at_rest() {
            assert_eq!(host.ask("ESTOP"), "ACK");
            let end = host.reply();
            assert!(
                end.starts_with(&format!("ABS {id} 201")) || end == format!("INF {id}"),
                "{request}: {end}"
            );
            // Once the brake has ended, RESET clears the E-stop.
            host.poll("RESET after the ESTOP", |h| {
                let r = h.ask("RESET");
                if r.starts_with("ACK") {
                    Ok(())
                } else {
                    Err(r)
                }
            });
            tally.stopped += 1;
        } else {
            let end = host.reply();
            assert_eq!(end, format!("INF {id}"), "{request}");
        }
        let world = host.world();
        assert_eq!(
            world.side_collisions(),
            sides,
            "{request} ({ack}) touched {:?}; the arm is at {:?}",
            world.last_side_collision(),
            host.where_()
        );
    }
}

#[test]
fn free_moves_anywhere_are_refused_or_run_without_touching_the_cell() {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    let mut tally = Tally::default();
    // The hand empty.
    fuzz(&mut host, 7, 60, &mut tally);
    // With a wafer on the hand: a bigger body, and the map says so.
    assert_eq!(host.motion(3, "HOME"), "INF 3");
    assert!(host.motion(4, "MAP LP1").starts_with("INF 4"));
    assert_eq!(host.motion(5, "GET LP1 1"), "INF 5 W1");
    fuzz(&mut host, 11, 60, &mut tally);
    let map = host.ask("WAFERS");
    assert_eq!(reply_field(&map, "hand"), Some("W1"), "{map}");
    assert!(!host.hand_empty());
    // Not vacuous: the check refused some, let others run, routed and shortened some.
    assert!(
        tally.refused >= 10 && tally.ran >= 20 && tally.routed >= 2 && tally.shortened >= 1,
        "{tally:?}"
    );
    assert!(tally.stopped >= 6, "{tally:?}");
}

/// A transfer keeps its own way into the station, along its line; its move there is checked
/// like any PTP: BF1, entered with the left elbow, from where the right elbow stands (the
/// elbow's turn swings the stretched arm through the stations at their height) goes round
/// through the travel height, and nothing touches the cell.
#[test]
fn a_transfer_whose_move_would_sweep_through_the_cell_goes_round() {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    assert!(host.motion(3, "MAP LP1").starts_with("INF 3"));
    assert!(host.motion(4, "MAP BF1").starts_with("INF 4"));
    assert_eq!(host.motion(5, "GET LP1 1"), "INF 5 W1");
    // Home with the wafer: the right elbow.
    assert_eq!(host.motion(9, "HOME"), "INF 9");
    let sides = host.world().side_collisions();
    let (start, _, _) = host.where_();
    assert!(start[1] > 0.0, "the right elbow: {start:?}");
    host.sim.record_pulses(true);
    assert_eq!(host.ask("6 PUT BF1 3"), "ACK 6");
    assert_eq!(host.reply(), "INF 6 W1");
    // The elbow turned over (through the stretched arm) at the travel height, under every
    // station: j2 [pulse] within ±30 deg only with z [pulse] at most the travel height.
    let pulses = host.sim.take_pulses();
    let swing: Vec<(i64, i64)> = pulses
        .iter()
        .map(|(_, p)| (p[1], p[3]))
        .filter(|(j2, _)| j2.abs() < 30_000)
        .collect();
    assert!(!swing.is_empty(), "the elbow turned over");
    assert!(swing.iter().all(|&(_, z)| z <= 7_300), "{swing:?}");
    assert_eq!(host.motion(7, "GET BF1 3"), "INF 7 W1");
    assert_eq!(host.motion(8, "PUT LP1 1"), "INF 8 W1");
    let world = host.world();
    assert_eq!(
        world.side_collisions(),
        sides,
        "{:?}",
        world.last_side_collision()
    );
    assert!(host.hand_empty());
    assert_eq!(&host.truth("LP1")[..1], "1");
}

/// Teaching: an operator moves the hand into LP1 along its line (MOVL from the approach
/// pose), then wants it out. A move elsewhere is refused and says how; HOME and RETRACT
/// take it straight out along the line first (no recovery planned that: the hand went in by
/// hand), and nothing touches the cell.
#[test]
fn a_hand_moved_into_a_station_to_teach_leaves_along_its_line_with_home_or_retract() {
    let mut host = VHost::start();
    assert!(host.ask("1 CONTROL").starts_with("ACK 1"));
    assert_eq!(host.motion(2, "HOME"), "INF 2");
    let sides = host.world().side_collisions();
    // LP1: seat (294.449, -170), yaw -30, approach 220 mm; slot 3 lowered is z 37.
    let approach = "103.923 -60 37 -30";
    let seat = "294.449 -170 37 -30";
    for (id, out) in [(10, "HOME"), (20, "RETRACT")] {
        assert_eq!(
            host.motion(id, &format!("MOVP {approach} R")),
            format!("INF {id}")
        );
        assert_eq!(
            host.motion(id + 1, &format!("MOVL {seat}")),
            format!("INF {}", id + 1)
        );
        let (_, x, y) = host.where_();
        assert!(
            (x - 294.449).abs() < 0.5 && (y + 170.0).abs() < 0.5,
            "{x} {y}"
        );
        // Anywhere else first: refused, and told the way out.
        let nak = host.ask(&format!("{} MOVJ 0 150 0 0", id + 2));
        assert!(nak.starts_with(&format!("NAK {} 117 ", id + 2)), "{nak}");
        assert!(
            nak.contains("the hand is inside LP1: RETRACT or HOME takes it straight out first"),
            "{nak}"
        );
        assert_eq!(host.motion(id + 3, out), format!("INF {}", id + 3));
        let (joints, x, y) = host.where_();
        if out == "HOME" {
            let home = wrc_config::Config::embedded_default().robot.home();
            for (j, h) in joints.iter().zip(home.iter()) {
                assert!((j - h).abs() < 0.01, "{joints:?} against {home:?}");
            }
        } else {
            assert!(
                (x - 103.923).abs() < 0.5 && (y + 60.0).abs() < 0.5,
                "{x} {y}"
            );
        }
        let world = host.world();
        assert_eq!(
            world.side_collisions(),
            sides,
            "{out}: {:?}",
            world.last_side_collision()
        );
    }
}
