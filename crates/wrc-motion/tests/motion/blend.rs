//! PTP blends (docs/motion.md "PTP blends"): a PTP flowing into a path
//! (`plan_ptp_into`), a path flowing into a PTP (`plan_depart`) and a PTP through a via
//! point (`plan_ptp_via`). Each is faster than the same moves at rest between them (or, where
//! no moving candidate passes, exactly as long), keeps every joint limit, lands exactly on
//! its target, keeps the TCP on the path where it follows one, and a HOLD in any part is
//! RESUMEd by the same order to the same end.

use wrc_motion::bench::PathProbe;
use wrc_motion::{BrakeLimits, EntryRule, Goal, MoveEnd, Period, Profile, VelocityGenerator};
use wrc_robot::{Joints, Pose, Posture};

use crate::common::*;
use crate::path::{at, cases, line, p, path};

fn joints(vg: &VelocityGenerator, pose: &Pose) -> Joints {
    vg.robot().inverse(pose, Posture::Right, None).unwrap()
}

/// The TCP of every period from the pulses.
fn tcp(vg: &VelocityGenerator, run: &Run) -> Vec<Pose> {
    let robot = vg.robot();
    let mut pulses = robot.joints_to_pulses(&run.start);
    run.periods
        .iter()
        .map(|period| {
            for (a, d) in pulses.iter_mut().zip(&period.pulses) {
                *a += d;
            }
            robot.forward(&robot.pulses_to_joints(&pulses))
        })
        .collect()
}

/// Stop after `k` periods (with `limits`) and run the brake; the generator at rest.
fn stop_after(vg: &mut VelocityGenerator, k: usize, limits: BrakeLimits) -> Run {
    let mut out = Period::default();
    for _ in 0..k {
        vg.next_period(&mut out);
    }
    vg.stop(limits);
    run(vg)
}

#[test]
fn a_ptp_flows_into_a_path_faster_and_follows_it_from_its_start() {
    let ts = 0.01;
    let mut entered_moving = 0;
    for (name, spec) in cases() {
        let from = p(150.0, 250.0, 100.0, 90.0);
        // The PTP to the path's start, then the path: two moves.
        let mut vg = at(Profile::Fir, ts, 100.0, &from);
        let via = joints(&vg, &spec.start);
        let ptp = vg.plan_ptp(&via).unwrap().periods;
        run(&mut vg);
        let along = vg.plan_path(&spec).unwrap().periods;
        run(&mut vg);
        let end = *vg.position_pulses();
        // One move.
        let mut vg = at(Profile::Fir, ts, 100.0, &from);
        assert!(vg
            .plan_ptp_into(&via, &spec, 100.0, EntryRule::Free)
            .unwrap());
        assert!(matches!(vg.goal(), Some(Goal::Path { pulses, .. }) if pulses == end));
        let blended = run(&mut vg);
        assert_eq!(blended.end, MoveEnd::Completed);
        assert_eq!(*vg.position_pulses(), end, "{name}");
        assert!(
            blended.periods.len() as u64 <= ptp + along,
            "{name}: {} periods, {} at rest between",
            blended.periods.len(),
            ptp + along
        );
        assert_within_limits(&vg, &blended, 1e-3, 1.0);
        // On the path from its start: every period after the last one off the path is on
        // it, and the first of them within a period's travel of its start.
        let probe = PathProbe::new(vg.robot(), &spec).unwrap();
        let poses = tcp(&vg, &blended);
        let off: Vec<_> = poses.iter().map(|q| probe.distance(q)).collect();
        let first = off
            .iter()
            .rposition(|d| d.off_mm >= 0.01)
            .map_or(0, |k| k + 1);
        assert!(
            off[first].u * probe.length_mm() < 5.0,
            "{name}: joins the path {} mm after its start",
            off[first].u * probe.length_mm()
        );
        // Entering moving: the TCP moved in the period it joined the path.
        let moving = first > 0 && {
            let (a, b) = (&poses[first - 1], &poses[first]);
            (a.x - b.x).hypot(a.y - b.y).hypot(a.z - b.z) > 0.01
        };
        entered_moving += usize::from(moving);
        println!(
            "{name}: blended {} periods, at rest between {}",
            blended.periods.len(),
            ptp + along
        );
    }
    assert!(entered_moving >= 3, "{entered_moving} entered moving");
}

#[test]
fn a_path_flows_into_a_ptp_faster_and_leaves_it_at_its_end() {
    let ts = 0.01;
    let to_pose = p(100.0, 250.0, 150.0, 90.0);
    let mut flowed = 0;
    for (name, spec) in cases() {
        let mut vg = at(Profile::Fir, ts, 100.0, &spec.start);
        let to = joints(&vg, &to_pose);
        let along = vg.plan_path(&spec).unwrap().periods;
        run(&mut vg);
        let ptp = vg.plan_ptp(&to).unwrap().periods;
        run(&mut vg);
        let mut vg = at(Profile::Fir, ts, 100.0, &spec.start);
        assert!(vg.plan_depart(&spec, &to, 100.0).unwrap());
        let target = vg.robot().joints_to_pulses(&to);
        assert_eq!(vg.goal(), Some(Goal::Joints(target)));
        let blended = run(&mut vg);
        assert_eq!(blended.end, MoveEnd::Completed);
        assert_eq!(*vg.position_pulses(), target, "{name}");
        let n = blended.periods.len() as u64;
        assert!(
            n <= ptp + along,
            "{name}: {n} periods, {} at rest",
            ptp + along
        );
        flowed += usize::from(n < ptp + along);
        assert_within_limits(&vg, &blended, 1e-3, 1.0);
        // On the path until it has reached its end (within a period's travel of it).
        let probe = PathProbe::new(vg.robot(), &spec).unwrap();
        let mut furthest = 0.0f64;
        for q in tcp(&vg, &blended) {
            let d = probe.distance(&q);
            if d.off_mm > 0.01 {
                let left = (1.0 - furthest) * probe.length_mm();
                assert!(left < 5.0, "{name}: left the path {left} mm before its end");
                break;
            }
            furthest = furthest.max(d.u);
        }
        println!(
            "{name}: blended {n} periods, at rest between {}",
            ptp + along
        );
    }
    assert!(flowed >= 3, "{flowed} flowed");
}

#[test]
fn a_path_with_no_room_past_its_end_stops_there_and_then_moves_on() {
    // The path ends near the stretched arm, moving outward: no room to brake past its end,
    // so the path stops there and the PTP starts from rest: exactly the two moves.
    let ts = 0.01;
    let spec = path(
        p(200.0, 0.0, 0.0, 0.0),
        &[line(p(396.5, 0.0, 0.0, 0.0), 0.0)],
    );
    let mut vg = at(Profile::Fir, ts, 100.0, &spec.start);
    let to = joints(&vg, &p(0.0, 300.0, 0.0, 90.0));
    let along = vg.plan_path(&spec).unwrap().periods;
    run(&mut vg);
    let ptp = vg.plan_ptp(&to).unwrap().periods;
    run(&mut vg);
    let mut vg = at(Profile::Fir, ts, 100.0, &spec.start);
    assert!(vg.plan_depart(&spec, &to, 100.0).unwrap());
    let blended = run(&mut vg);
    assert_eq!(blended.end, MoveEnd::Completed);
    assert_eq!(blended.periods.len() as u64, along + ptp);
    assert_eq!(*vg.position_pulses(), vg.robot().joints_to_pulses(&to));
    assert_within_limits(&vg, &blended, 1e-3, 1.0);
}

#[test]
fn a_ptp_passes_its_via_point_moving() {
    let ts = 0.01;
    let poses = [
        (
            p(250.0, -150.0, 0.0, 0.0),
            p(300.0, 50.0, 50.0, 30.0),
            p(50.0, 300.0, 100.0, 120.0),
        ),
        (
            p(-100.0, -250.0, 200.0, -90.0),
            p(200.0, -200.0, 100.0, 0.0),
            p(300.0, 100.0, 0.0, 45.0),
        ),
        (
            p(100.0, 200.0, 0.0, 90.0),
            p(250.0, 0.0, 0.0, 0.0),
            p(100.0, -200.0, 0.0, -90.0),
        ),
    ];
    let mut faster = 0;
    for (a, b, c) in poses {
        let mut vg = at(Profile::Fir, ts, 100.0, &a);
        let start = vg.joints();
        let (via, to) = (joints(&vg, &b), joints(&vg, &c));
        let two = vg.plan_ptp(&via).unwrap().periods;
        run(&mut vg);
        let two = two + vg.plan_ptp(&to).unwrap().periods;
        let mut vg = at(Profile::Fir, ts, 100.0, &a);
        assert!(vg.plan_ptp_via(&start, &via, &to).unwrap());
        let target = vg.robot().joints_to_pulses(&to);
        assert_eq!(vg.goal(), Some(Goal::Joints(target)));
        let blended = run(&mut vg);
        assert_eq!(blended.end, MoveEnd::Completed);
        assert_eq!(*vg.position_pulses(), target);
        let n = blended.periods.len() as u64;
        assert!(n <= two, "{n} periods, two PTPs {two}");
        faster += usize::from(n < two);
        assert_within_limits(&vg, &blended, 1e-3, 1.0);
        // It passes the via point: within one period's travel of every axis.
        let nearest = blended
            .periods
            .iter()
            .map(|q| {
                (0..4)
                    .map(|i| (q.exact[i] - via[i]).abs() / vg.robot().axes()[i].limits.max_velocity)
                    .fold(0.0, f64::max)
            })
            .fold(f64::INFINITY, f64::min);
        assert!(nearest <= ts, "{nearest} s from the via");
        println!("via: {n} periods, two PTPs {two}");
    }
    assert!(faster >= 2, "{faster} faster");
}

#[test]
fn a_hold_in_any_part_of_a_blend_is_resumed_by_the_same_order() {
    let ts = 0.01;
    let (_, spec) = cases().remove(1);
    let from = p(150.0, 250.0, 100.0, 90.0);
    // PTP into the path: held in the PTP part and on the path.
    let mut whole = at(Profile::Fir, ts, 100.0, &from);
    let via = joints(&whole, &spec.start);
    whole
        .plan_ptp_into(&via, &spec, 100.0, EntryRule::Free)
        .unwrap();
    let total = run(&mut whole.clone()).periods.len();
    let end = {
        let mut w = whole.clone();
        run(&mut w);
        *w.position_pulses()
    };
    for k in [total / 10, total / 2] {
        let mut vg = whole.clone();
        let brake = stop_after(&mut vg, k, BrakeLimits::Override);
        assert_eq!(brake.end, MoveEnd::Stopped);
        assert!(vg
            .plan_ptp_into(&via, &spec, 100.0, EntryRule::Free)
            .unwrap());
        let rest = run(&mut vg);
        assert_eq!(*vg.position_pulses(), end, "resumed after {k} periods");
        assert_within_limits(&vg, &rest, 1e-3, 1.0);
    }
    // Path into a PTP: held on the path, and in the PTP part.
    let mut whole = at(Profile::Fir, ts, 100.0, &spec.start);
    let to = joints(&whole, &from);
    whole.plan_depart(&spec, &to, 100.0).unwrap();
    let total = run(&mut whole.clone()).periods.len();
    let target = whole.robot().joints_to_pulses(&to);
    let probe = PathProbe::new(whole.robot(), &spec).unwrap();
    for k in [total / 3, total * 9 / 10] {
        let mut vg = whole.clone();
        stop_after(&mut vg, k, BrakeLimits::Override);
        let stood = probe.distance(&vg.pose());
        assert!(vg.plan_depart(&spec, &to, 100.0).unwrap());
        let rest = run(&mut vg);
        assert_eq!(*vg.position_pulses(), target, "resumed after {k} periods");
        assert_within_limits(&vg, &rest, 1e-3, 1.0);
        if stood.off_mm < 0.01 && stood.u < 0.99 {
            // Held on the path: the rest of it first.
            let first = tcp(&vg, &rest)[0];
            assert!(probe.distance(&first).off_mm < 0.01);
        }
    }
    // A PTP through a via: held before the via it passes it; held after it, it does not
    // go back (the rest is the PTP to the target from there).
    let (a, b, c) = (
        p(250.0, -150.0, 0.0, 0.0),
        p(300.0, 50.0, 50.0, 30.0),
        p(50.0, 300.0, 100.0, 120.0),
    );
    let mut whole = at(Profile::Fir, ts, 100.0, &a);
    let start = whole.joints();
    let (via, to) = (joints(&whole, &b), joints(&whole, &c));
    whole.plan_ptp_via(&start, &via, &to).unwrap();
    let total = run(&mut whole.clone()).periods.len();
    let target = whole.robot().joints_to_pulses(&to);
    // (Held early, while it is still slow: from speed the brake itself would carry it past
    // the via.)
    for k in [5, total * 4 / 5] {
        let mut vg = whole.clone();
        stop_after(&mut vg, k, BrakeLimits::Override);
        let mut direct = vg.clone();
        let direct = direct.plan_ptp(&to).unwrap().periods as usize;
        assert!(vg.plan_ptp_via(&start, &via, &to).unwrap());
        let rest = run(&mut vg);
        assert_eq!(*vg.position_pulses(), target);
        assert_within_limits(&vg, &rest, 1e-3, 1.0);
        if k > total / 2 {
            assert_eq!(
                rest.periods.len(),
                direct,
                "past the via: the PTP to the target"
            );
        } else {
            // Before the via: through it, within one period's travel of every axis.
            let nearest = rest
                .periods
                .iter()
                .map(|q| {
                    (0..4)
                        .map(|i| {
                            (q.exact[i] - via[i]).abs() / vg.robot().axes()[i].limits.max_velocity
                        })
                        .fold(0.0, f64::max)
                })
                .fold(f64::INFINITY, f64::min);
            assert!(nearest <= ts, "before the via: {nearest} s from it");
        }
    }
}
