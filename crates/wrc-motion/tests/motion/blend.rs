//! PTP blends (docs/motion.md "PTP blends"): a PTP flowing into a path
//! (`plan_ptp_into`), a path flowing into a PTP (`plan_depart`) and a PTP through a via
//! point (`plan_ptp_via`). Each is faster than the same moves at rest between them (or, where
//! no moving candidate passes, exactly as long), keeps every joint limit, lands exactly on
//! its target, keeps the TCP on the path where it follows one, and a HOLD in any part is
//! RESUMEd by the same order to the same end.

use wrc_motion::bench::PathProbe;
use wrc_motion::{
    BlendSearch, BrakeLimits, EntryRule, Goal, MoveEnd, Period, Profile, VelocityGenerator,
};
use wrc_robot::{Joints, Pose, Posture, MAX_AXES};

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

/// The pulses of every period of a run.
fn pulses(periods: &[Period]) -> Vec<[i64; MAX_AXES]> {
    periods.iter().map(|p| p.pulses).collect()
}

/// Whether the TCP stands at `pose` in some period of `run` (from rest a period moves it by
/// micrometres there; entering a path moving, by millimetres).
fn stands_at(vg: &VelocityGenerator, run: &Run, pose: &Pose) -> bool {
    let poses = tcp(vg, run);
    let d = |q: &Pose, r: &Pose| (q.x - r.x).hypot(q.y - r.y).hypot(q.z - r.z);
    let k = (0..poses.len())
        .min_by(|&i, &j| d(&poses[i], pose).total_cmp(&d(&poses[j], pose)))
        .unwrap();
    let (a, b) = (
        &poses[k.saturating_sub(1)],
        &poses[(k + 1).min(poses.len() - 1)],
    );
    d(a, b) < 0.1
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

#[test]
fn a_path_into_a_ptp_is_the_path_alone_until_its_junction_near_its_end() {
    // Up to its junction (the first knot whose search looks past the path's end) the law of
    // a path that flows into a PTP is the path's own, to the bit: its pulses are the path's
    // alone. It decides how it leaves there, within a brake of the end, never earlier.
    let ts = 0.01;
    let to_pose = p(100.0, 250.0, 150.0, 90.0);
    for (name, spec) in cases() {
        let mut alone = at(Profile::Fir, ts, 100.0, &spec.start);
        let to = joints(&alone, &to_pose);
        assert!(alone.start_path(&spec).unwrap());
        let path = run(&mut alone);
        let mut vg = at(Profile::Fir, ts, 100.0, &spec.start);
        assert!(vg.plan_depart(&spec, &to, 100.0).unwrap());
        let blended = run(&mut vg);
        let same = path
            .periods
            .iter()
            .zip(&blended.periods)
            .take_while(|(a, b)| a.pulses == b.pulses)
            .count();
        let probe = PathProbe::new(vg.robot(), &spec).unwrap();
        let poses = tcp(&vg, &blended);
        let left = (1.0 - probe.distance(&poses[same.min(poses.len() - 1)]).u) * probe.length_mm();
        assert!(
            left < 150.0,
            "{name}: {same} periods as the path alone, then {left:.1} mm from its end"
        );
        assert_eq!(vg.search_stats().searches, 1, "{name}");
        println!("{name}: the path alone for {same} periods, to {left:.1} mm from its end");
    }
}

#[test]
fn a_search_out_of_budget_stops_at_the_junction_and_says_so() {
    let ts = 0.01;
    let to_pose = p(100.0, 250.0, 150.0, 90.0);
    let from = p(150.0, 250.0, 100.0, 90.0);
    for (name, spec) in cases() {
        // A path into a PTP with no work to spend: the path to rest, then the PTP — the two
        // moves, to the pulse.
        let mut vg = at(Profile::Fir, ts, 100.0, &spec.start);
        let to = joints(&vg, &to_pose);
        assert!(vg.start_path(&spec).unwrap());
        let mut apart = run(&mut vg).periods;
        vg.plan_ptp(&to).unwrap();
        apart.extend(run(&mut vg).periods);
        let mut vg = at(Profile::Fir, ts, 100.0, &spec.start);
        vg.set_blend_search(BlendSearch::Bounded { work: 0 });
        assert!(vg.plan_depart(&spec, &to, 100.0).unwrap());
        let blended = run(&mut vg);
        assert_eq!(blended.end, MoveEnd::Completed);
        assert_eq!(pulses(&blended.periods), pulses(&apart), "{name}");
        assert_eq!(*vg.position_pulses(), vg.robot().joints_to_pulses(&to));
        assert_within_limits(&vg, &blended, 1e-3, 1.0);
        let stats = vg.search_stats();
        assert_eq!((stats.searches, stats.fallbacks), (1, 1), "{name}");
        // Its one step: the law resumed from the junction to rest at the path's end.
        assert_eq!(stats.last_work, stats.max_step, "{name}");

        // A PTP into a path with no work to spend: it enters the path at rest, and the
        // moving entries are not even started (the one step is the entry at rest's).
        let mut vg = at(Profile::Fir, ts, 100.0, &from);
        vg.set_blend_search(BlendSearch::Bounded { work: 0 });
        let via = joints(&vg, &spec.start);
        assert!(vg
            .plan_ptp_into(&via, &spec, 100.0, EntryRule::Free)
            .unwrap());
        let blended = run(&mut vg);
        assert_eq!(blended.end, MoveEnd::Completed);
        assert_within_limits(&vg, &blended, 1e-3, 1.0);
        let stats = vg.search_stats();
        assert_eq!((stats.searches, stats.fallbacks), (1, 1), "{name}");
        assert_eq!(stats.last_work, stats.max_step, "{name}");
        assert!(
            stands_at(&vg, &blended, &spec.start),
            "{name}: entered moving"
        );
    }
}

#[test]
fn a_bounded_search_ends_within_a_step_of_its_budget_with_the_same_move_or_the_fallback() {
    // Budgets below what the search without one spends. A search checks its budget before
    // each step (a knot of the path's law; an entry's brake check or its estimate) and ends
    // at the first check that finds it spent: its work is at most its budget and its
    // largest step. Whatever the budget, the move ends on its target within every limit and
    // is never slower than the two moves at rest between them. A path into a PTP is either
    // the move the search without a budget finds or, when it ran out, the path to rest and
    // the PTP from there, both to the pulse; a PTP into a path that ran out enters at rest.
    let ts = 0.01;
    let from = p(150.0, 250.0, 100.0, 90.0);
    let to_pose = p(100.0, 250.0, 150.0, 90.0);
    let (mut fell_back, mut found, mut largest_step) = (0, 0, 0);
    let mut check = |name: &str, budget: u64, vg: &VelocityGenerator, run: &Run, apart: usize| {
        let stats = vg.search_stats();
        assert_eq!(run.end, MoveEnd::Completed, "{name}");
        assert_within_limits(vg, run, 1e-3, 1.0);
        assert!(
            run.periods.len() <= apart,
            "{name}, budget {budget}: {} periods, {apart} at rest between",
            run.periods.len()
        );
        assert_eq!(stats.searches, 1, "{name}");
        assert!(
            stats.last_work <= budget + stats.max_step,
            "{name}: {} units for a budget of {budget}, steps of up to {}",
            stats.last_work,
            stats.max_step
        );
        largest_step = largest_step.max(stats.max_step);
        stats.fallbacks == 1
    };
    for (name, spec) in cases() {
        // A path into a PTP.
        let mut vg = at(Profile::Fir, ts, 100.0, &spec.start);
        let to = joints(&vg, &to_pose);
        let target = vg.robot().joints_to_pulses(&to);
        assert!(vg.start_path(&spec).unwrap());
        let mut apart = run(&mut vg).periods;
        vg.plan_ptp(&to).unwrap();
        apart.extend(run(&mut vg).periods);
        let depart = |search: BlendSearch| {
            let mut vg = at(Profile::Fir, ts, 100.0, &spec.start);
            vg.set_blend_search(search);
            assert!(vg.plan_depart(&spec, &to, 100.0).unwrap());
            let blended = run(&mut vg);
            assert_eq!(*vg.position_pulses(), target, "{name}");
            (vg, blended)
        };
        let (vg, free) = depart(BlendSearch::Bounded { work: u64::MAX });
        assert_eq!(vg.search_stats().fallbacks, 0, "{name}");
        let all = vg.search_stats().last_work;
        for budget in [all / 4, all / 2, all - 1] {
            let (vg, blended) = depart(BlendSearch::Bounded { work: budget });
            let name = format!("{name}, out of the path");
            if check(&name, budget, &vg, &blended, apart.len()) {
                assert_eq!(pulses(&blended.periods), pulses(&apart), "{name}");
                fell_back += 1;
            } else {
                assert_eq!(pulses(&blended.periods), pulses(&free.periods), "{name}");
                found += 1;
            }
        }

        // A PTP into the path.
        let mut vg = at(Profile::Fir, ts, 100.0, &from);
        let via = joints(&vg, &spec.start);
        let mut apart = vg.plan_ptp(&via).unwrap().periods as usize;
        run(&mut vg);
        apart += vg.plan_path(&spec).unwrap().periods as usize;
        run(&mut vg);
        let end = *vg.position_pulses();
        let into = |search: BlendSearch| {
            let mut vg = at(Profile::Fir, ts, 100.0, &from);
            vg.set_blend_search(search);
            assert!(vg
                .plan_ptp_into(&via, &spec, 100.0, EntryRule::Free)
                .unwrap());
            let blended = run(&mut vg);
            assert_eq!(*vg.position_pulses(), end, "{name}");
            (vg, blended)
        };
        let (vg, _) = into(BlendSearch::Bounded { work: u64::MAX });
        let all = vg.search_stats().last_work;
        for budget in [all / 4, all / 2, all - 1] {
            let (vg, blended) = into(BlendSearch::Bounded { work: budget });
            let name = format!("{name}, into the path");
            if check(&name, budget, &vg, &blended, apart) {
                assert!(
                    stands_at(&vg, &blended, &spec.start),
                    "{name}: entered moving"
                );
                fell_back += 1;
            } else {
                found += 1;
            }
        }
    }
    assert!(
        fell_back > 0 && found > 0,
        "{fell_back} fell back, {found} found"
    );
    // The budget's grain: a step is small against the default budget.
    assert!(
        largest_step * 4 <= BlendSearch::DEFAULT.limit(),
        "a step of {largest_step} units"
    );
    println!("{fell_back} fell back, {found} found a move; steps of up to {largest_step} units");
}

#[test]
fn the_bounded_search_plans_as_the_exhaustive_one_and_the_same_every_time() {
    // The bounded search compares entries by an estimate of the path's law and decides a
    // path's exit at its junction: on the test paths it takes the same moves as timing
    // every candidate by its law (within a period), is never slower than its fallback (at
    // rest at the junction), and plans the same periods and counts the same work every time
    // (no clock in the plan).
    let ts = 0.01;
    let from = p(150.0, 250.0, 100.0, 90.0);
    let to_pose = p(100.0, 250.0, 150.0, 90.0);
    for (name, spec) in cases() {
        let plan = |search: BlendSearch, depart: bool| {
            let mut vg = at(
                Profile::Fir,
                ts,
                100.0,
                if depart { &spec.start } else { &from },
            );
            vg.set_blend_search(search);
            if depart {
                let to = joints(&vg, &to_pose);
                assert!(vg.plan_depart(&spec, &to, 100.0).unwrap());
            } else {
                let via = joints(&vg, &spec.start);
                assert!(vg
                    .plan_ptp_into(&via, &spec, 100.0, EntryRule::Free)
                    .unwrap());
            }
            let out = run(&mut vg);
            (out, vg.search_stats())
        };
        for depart in [false, true] {
            let (bounded, stats) = plan(BlendSearch::DEFAULT, depart);
            let (again, stats_again) = plan(BlendSearch::DEFAULT, depart);
            let (exhaustive, _) = plan(BlendSearch::Exhaustive, depart);
            let (fallback, _) = plan(BlendSearch::Bounded { work: 0 }, depart);
            assert_eq!(stats, stats_again, "{name}");
            assert_eq!(stats.fallbacks, 0, "{name}");
            assert_eq!(pulses(&bounded.periods), pulses(&again.periods), "{name}");
            let (n, m) = (bounded.periods.len(), exhaustive.periods.len());
            assert!(
                n <= m + 1,
                "{name} (depart {depart}): {n} periods, exhaustive {m}"
            );
            // Never slower than its fallback, the motion at rest at the junction.
            assert!(
                n <= fallback.periods.len(),
                "{name} (depart {depart}): {n} periods, the fallback {}",
                fallback.periods.len()
            );
        }
    }
}
