//! The blended approach (`plan_approach`, docs/motion.md "Blended approach"): every axis
//! flows into a station's straight line in at speed instead of stopping at its start. On the
//! demo cell's geometry (approach poses 100-120 mm from the base, lines 200-220 mm long): it
//! is faster than the same PTP and line at rest between them, keeps every joint limit (finite
//! differences of the exact positions), stays behind the line's start until it enters and on
//! the line from there, lands exactly on the line's end, and a stop at full limits from any
//! period up to the commit point ends behind the line's start.

use wrc_motion::{BrakeLimits, MoveEnd, Period, Profile, Status, VelocityGenerator};
use wrc_robot::{Joints, Pose, Posture};

use crate::common::*;

/// A transfer's approach: from a station's approach pose (where the last transfer left the
/// hand) to another's approach pose `a`, then straight in to its seat `s`.
#[derive(Clone)]
struct Case {
    name: &'static str,
    from: Pose,
    a: Pose,
    s: Pose,
    line_pct: f64,
}

fn station(yaw_deg: f64, seat_r: f64, back: f64, z: f64) -> (Pose, Pose) {
    let (sin, cos) = yaw_deg.to_radians().sin_cos();
    let s = Pose {
        x: seat_r * cos,
        y: seat_r * sin,
        z,
        yaw: yaw_deg,
    };
    let a = Pose {
        x: s.x - back * cos,
        y: s.y - back * sin,
        ..s
    };
    (a, s)
}

fn cases() -> Vec<Case> {
    let (lp1a, _) = station(-30.0, 340.0, 220.0, 23.0);
    let (ala, als) = station(90.0, 300.0, 200.0, 83.0);
    let (lp2a, lp2s) = station(30.0, 340.0, 220.0, 20.0);
    let (pm2a, pm2s) = station(-90.0, 340.0, 220.0, 105.0);
    vec![
        Case {
            name: "LP1 -> AL",
            from: lp1a,
            a: ala,
            s: als,
            line_pct: 80.0,
        },
        Case {
            name: "AL -> LP2",
            from: Pose { z: 77.0, ..ala },
            a: lp2a,
            s: lp2s,
            line_pct: 60.0,
        },
        Case {
            name: "LP2 -> PM2",
            from: lp2a,
            a: pm2a,
            s: pm2s,
            line_pct: 100.0,
        },
    ]
}

fn at(vg: &mut VelocityGenerator, pose: &Pose) {
    let q = vg.robot().inverse(pose, Posture::Right, None).unwrap();
    let p = vg.robot().joints_to_pulses(&q);
    vg.set_position_pulses(&p).unwrap();
}

fn via(vg: &VelocityGenerator, a: &Pose) -> Joints {
    vg.robot().inverse(a, Posture::Right, None).unwrap()
}

/// How far into the station along its line a pose is [mm].
fn along(c: &Case, p: &Pose) -> f64 {
    let (dx, dy) = (c.s.x - c.a.x, c.s.y - c.a.y);
    let n = dx.hypot(dy);
    ((p.x - c.a.x) * dx + (p.y - c.a.y) * dy) / n
}

/// Distance of a pose from the station's line (in the plane, and in z) [mm].
fn off_line(c: &Case, p: &Pose) -> f64 {
    let (dx, dy) = (c.s.x - c.a.x, c.s.y - c.a.y);
    let n = dx.hypot(dy);
    let cross = ((p.x - c.a.x) * dy - (p.y - c.a.y) * dx) / n;
    cross.abs().max((p.z - c.a.z).abs())
}

#[test]
fn a_blended_approach_is_faster_within_every_limit_and_enters_on_the_line() {
    for ts in [0.01, 0.001] {
        for c in cases() {
            // Rest to rest: the PTP, then the line at the station's speed.
            let mut vg = generator(Profile::Fir, ts, 100.0);
            at(&mut vg, &c.from);
            let q = via(&vg, &c.a);
            vg.plan_ptp(&q).unwrap();
            let ptp = run(&mut vg);
            vg.set_speed_pct(c.line_pct).unwrap();
            vg.plan_line(&c.s).unwrap();
            let line = run(&mut vg);
            let rest = (ptp.periods.len() + line.periods.len()) as f64 * ts;
            let end = *vg.position_pulses();

            let mut vg = generator(Profile::Fir, ts, 100.0);
            at(&mut vg, &c.from);
            assert!(vg.plan_approach(&q, &c.s, c.line_pct).unwrap());
            let blended = run(&mut vg);
            assert_eq!(blended.end, MoveEnd::Completed);
            let t = blended.periods.len() as f64 * ts;
            assert!(
                t <= rest,
                "{}: blended {t:.3} s, rest to rest {rest:.3} s",
                c.name
            );
            // Lands on the line's end exactly as the line alone does.
            assert_eq!(*vg.position_pulses(), end, "{}", c.name);
            // Every joint limit at 100 % (the line part's at its own, lower, override).
            assert_within_limits(&vg, &blended, 1e-3, 1.0);
            // Behind the start until the TCP reaches it; on the line from there.
            let mut inside = false;
            for p in &blended.periods {
                let pose = vg.robot().forward(&p.exact);
                let x = along(&c, &pose);
                if x > 1e-3 {
                    inside = true;
                }
                if inside {
                    assert!(
                        off_line(&c, &pose) < 0.01,
                        "{}: {:.4} mm off the line {x:.2} mm in",
                        c.name,
                        off_line(&c, &pose)
                    );
                    assert!(
                        (pose.yaw - c.a.yaw).abs() < 1e-3,
                        "{}: yaw {}",
                        c.name,
                        pose.yaw
                    );
                }
            }
            assert!(inside);
            println!(
                "{} at {ts} s: blended {t:.3} s, rest to rest {rest:.3} s",
                c.name
            );
        }
    }
}

#[test]
fn an_estop_up_to_the_commit_point_ends_behind_the_approach_pose_and_after_it_on_the_line() {
    let ts = 0.01;
    for (c, limits) in cases()
        .into_iter()
        .flat_map(|c| [BrakeLimits::Full, BrakeLimits::Override].map(|l| (c.clone(), l)))
    {
        let mut vg = generator(Profile::Fir, ts, 100.0);
        at(&mut vg, &c.from);
        let q = via(&vg, &c.a);
        vg.plan_approach(&q, &c.s, c.line_pct).unwrap();
        let total = run(&mut vg.clone()).periods.len();
        let mut committed_at = None;
        for k in 0..total {
            // Stop after k periods, as the Pulse Generator does: from the state reached, in a
            // generator restored to it.
            let mut stopper = vg.clone();
            let mut out = Period::default();
            for _ in 0..k {
                stopper.next_period(&mut out);
            }
            let committed = stopper.state().entry_committed();
            if committed && committed_at.is_none() {
                committed_at = Some(k);
            }
            stopper.stop(limits);
            let mut periods = Vec::new();
            let end = loop {
                match stopper.next_period(&mut out) {
                    Status::Finished(end) => {
                        periods.push(out);
                        break end;
                    }
                    Status::Working => periods.push(out),
                    Status::Idle => break MoveEnd::Stopped,
                }
            };
            let pose = stopper.pose();
            if !committed && k > 0 {
                assert_eq!(end, MoveEnd::Stopped, "{} k={k}", c.name);
            }
            assert!(!stopper.is_moving());
            let _ = periods;
            // Watched until committed (the stop may come two periods after the flag was
            // read): behind the approach pose.
            if !committed {
                assert!(
                    along(&c, &pose) <= 1e-3,
                    "{}: a stop after {k} periods ended {:.2} mm in",
                    c.name,
                    along(&c, &pose)
                );
            } else {
                // Committed: on to the line, and braked on it (every axis braking on its
                // own ended up to 13 mm and 11 degrees off it, inside the station).
                assert!(
                    off_line(&c, &pose) <= 0.01 && (pose.yaw - c.a.yaw).abs() <= 0.01,
                    "{} {limits:?}: a stop after {k} periods ended {:.3} mm and {:.3} deg off the line",
                    c.name,
                    off_line(&c, &pose),
                    pose.yaw - c.a.yaw
                );
                assert!(along(&c, &pose) >= -1e-3, "{} k={k}", c.name);
            }
        }
        let k = committed_at.expect("the approach commits before it enters");
        println!("{}: committed after {k} of {total} periods", c.name);
    }
}
