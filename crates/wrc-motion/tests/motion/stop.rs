//! Controlled stop from any state: decelerates within the limits, keeps a straight line on
//! its line, and loses no pulse of bookkeeping.

use proptest::prelude::*;
use wrc_motion::{MoveEnd, Profile};
use wrc_robot::{Pose, Posture};

use crate::common::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn stop_keeps_limits_and_bookkeeping(stop_at in 0usize..300, paper in any::<bool>(), line in any::<bool>()) {
        let profile = if paper { Profile::Paper { mask_len: 20 } } else { Profile::Fir };
        let mut vg = generator(profile, 0.01, 100.0);
        let before = *vg.position_pulses();
        if line {
            let start = vg.robot().inverse(&Pose { x: 300.0, y: -150.0, z: 0.0, yaw: 0.0 }, Posture::Right, None).unwrap();
            vg.set_position_pulses(&vg.robot().joints_to_pulses(&start)).unwrap();
            vg.plan_line(&Pose { x: 300.0, y: 150.0, z: 100.0, yaw: 45.0 }).unwrap();
        } else {
            let mut t = vg.joints();
            t[0] = 120.0;
            t[1] = 30.0;
            t[3] = 250.0;
            vg.plan_ptp(&t).unwrap();
        }
        let start = *vg.position_pulses();
        let a = vg.pose();
        let full = {
            let mut probe = vg.clone();
            run(&mut probe).periods.len()
        };
        let run = run_with(&mut vg, 100_000, |vg, k| if k == stop_at { vg.stop() });
        // Bookkeeping: the position is the start plus every pulse emitted.
        let sums = pulse_sums(&run);
        for ax in 0..4 {
            prop_assert_eq!(vg.position_pulses()[ax], start[ax] + sums[ax]);
        }
        if stop_at < full.saturating_sub(60) {
            prop_assert_eq!(run.end, MoveEnd::Stopped);
            prop_assert!(run.periods.len() < full);
        }
        assert_within_limits(&vg, &run, 1e-6, if paper { 1.0 } else { 0.0 });
        if line {
            // Still on the line.
            let target = Pose { x: 300.0, y: 150.0, z: 100.0, yaw: 45.0 };
            let p = vg.pose();
            let (dx, dy) = (target.x - a.x, target.y - a.y);
            let cross = ((p.x - a.x) * dy - (p.y - a.y) * dx).abs() / dx.hypot(dy);
            prop_assert!(cross < 0.01, "{} mm off the line", cross);
        }
        let _ = before;
    }
}

#[test]
fn stop_when_idle_does_nothing() {
    let mut vg = generator(Profile::Fir, 0.01, 100.0);
    let p = *vg.position_pulses();
    vg.stop();
    assert!(!vg.is_moving());
    assert_eq!(*vg.position_pulses(), p);
}

#[test]
fn stop_during_cruise_decelerates_at_once() {
    let mut vg = generator(Profile::Fir, 0.01, 100.0);
    let mut t = vg.joints();
    t[0] = 175.0; // 250 deg at 180 deg/s: a long cruise
    vg.plan_ptp(&t).unwrap();
    let mut speeds = Vec::new();
    let run = run_with(&mut vg, 10_000, |vg, k| {
        if k == 100 {
            vg.stop()
        }
    });
    for p in &run.periods {
        speeds.push(p.pulses[0]);
    }
    // Cruising before the stop; strictly slower two periods after it.
    assert_eq!(speeds[98], speeds[99]);
    assert!(speeds[101] < speeds[99], "{:?}", &speeds[95..105]);
    assert_eq!(run.end, MoveEnd::Stopped);
}

#[test]
fn a_stop_can_restart_from_an_earlier_state() {
    // The controller keeps a state per queued period and stops from the one the Pulse
    // Generator reached: the result equals stopping a generator that ran only that far.
    let mut ahead = generator(Profile::Fir, 0.01, 100.0);
    let mut t = ahead.joints();
    t[0] = 150.0;
    ahead.plan_ptp(&t).unwrap();
    let mut states = Vec::new();
    let mut p = wrc_motion::Period::default();
    for _ in 0..60 {
        states.push(ahead.state());
        ahead.next_period(&mut p);
    }
    let mut reference = generator(Profile::Fir, 0.01, 100.0);
    reference.plan_ptp(&t).unwrap();
    for _ in 0..40 {
        reference.next_period(&mut p);
    }
    ahead.restore(&states[40]);
    assert_eq!(ahead.position_pulses(), reference.position_pulses());
    ahead.stop();
    reference.stop();
    let a = run(&mut ahead);
    let b = run(&mut reference);
    assert_eq!(a.end, MoveEnd::Stopped);
    assert_eq!(pulse_sums(&a), pulse_sums(&b));
    assert_eq!(ahead.position_pulses(), reference.position_pulses());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    // The controller's Pulse Generator stops a line from the state of the period it has
    // reached, in a generator of its own (which computes the line's derivatives itself):
    // the stop keeps every limit, stays on the line, ends short of the target, and lands
    // within a pulse of where the planning generator's own stop lands.
    #[test]
    fn a_line_stopped_by_another_generator_keeps_its_limits(
        stop_at in 1usize..120, pct in 10.0f64..100.0, fast in any::<bool>(),
    ) {
        let ts = if fast { 0.001 } else { 0.01 };
        let stop_at = if fast { stop_at * 10 } else { stop_at };
        let mut planner = generator(Profile::Fir, ts, pct);
        let start = planner.robot().inverse(&Pose { x: 320.0, y: -180.0, z: 20.0, yaw: -30.0 }, Posture::Right, None).unwrap();
        planner.set_position_pulses(&planner.robot().joints_to_pulses(&start)).unwrap();
        let a = planner.pose();
        let target = Pose { x: 80.0, y: 250.0, z: 120.0, yaw: 60.0 };
        let info = planner.plan_line(&target).unwrap();
        prop_assume!((stop_at as u64) < info.periods.saturating_sub(2));
        let first = planner.joints();
        let mut before = Vec::new();
        for _ in 0..stop_at {
            let mut p = wrc_motion::Period::default();
            planner.next_period(&mut p);
            before.push(p);
        }
        let state = planner.state();
        let mut stopper = generator(Profile::Fir, ts, pct);
        stopper.restore(&state);
        stopper.stop();
        planner.stop();
        let own = run(&mut planner);
        let other = run(&mut stopper);
        // Stopped short of the target, unless the stop came during the line's last brake,
        // which ends on the target anyway.
        prop_assert_eq!(other.end, own.end);
        if (stop_at as u64) < info.periods / 2 {
            prop_assert_eq!(other.end, MoveEnd::Stopped);
        }
        // The whole motion, from rest to rest: the periods before the stop, then the stop's.
        let whole = Run {
            periods: before.iter().chain(&other.periods).copied().collect(),
            end: other.end,
            start: first,
        };
        assert_within_limits(&stopper, &whole, 1e-6, 0.0);
        for (x, y) in stopper.position_pulses().iter().zip(planner.position_pulses()).take(4) {
            prop_assert!((x - y).abs() <= 1, "{:?} vs {:?}", stopper.position_pulses(), planner.position_pulses());
        }
        let end = stopper.pose();
        let (dx, dy) = (target.x - a.x, target.y - a.y);
        let cross = ((end.x - a.x) * dy - (end.y - a.y) * dx).abs() / dx.hypot(dy);
        prop_assert!(cross < 0.01, "{} mm off the line", cross);
        prop_assert!(other.periods.len() < (info.periods as usize - stop_at) + 2);
    }
}
