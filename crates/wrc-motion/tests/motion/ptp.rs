//! PTP and jog moves: pulse conservation, synchronised start and finish, limits, bad input.

use proptest::prelude::*;
use wrc_motion::{MotionSettings, MoveEnd, PlanError, Profile, Sync, VelocityGenerator};
use wrc_robot::{KinematicsError, Pose, Posture, Robot};

use crate::common::*;

fn profile(paper: bool, n: usize) -> Profile {
    if paper {
        Profile::Paper { mask_len: n }
    } else {
        Profile::Fir
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    // Conservation: the pulses of every axis sum exactly to target − start, for both
    // profiles, at 10 ms and 1 ms, any override. Limits: exact positions within 1e-6
    // (fir) or one pulse of quantisation per period (paper's integer input stream).
    #[test]
    fn ptp_conserves_pulses_and_keeps_limits(
        from in (-170.0f64..170.0, -160.0f64..160.0, -260.0f64..260.0, 0.0f64..300.0),
        to in (-170.0f64..170.0, -160.0f64..160.0, -260.0f64..260.0, 0.0f64..300.0),
        paper in any::<bool>(), half in 1usize..30, fast in any::<bool>(), pct in 1.0f64..100.0,
    ) {
        let ts = if fast { 0.001 } else { 0.010 };
        // A paper mask of m periods limits jerk to V/(m·Ts)²: keep m·Ts at 50 ms or more
        // so that moves finish in reasonable time.
        let half = if fast { 50 + 5 * half } else { 5 + half };
        let mut vg = generator(profile(paper, 2 * half), ts, pct);
        let start = vg.robot().joints_from_slice(&[from.0, from.1, from.2, from.3]).unwrap();
        vg.set_position_pulses(&vg.robot().joints_to_pulses(&start)).unwrap();
        let target = vg.robot().joints_from_slice(&[to.0, to.1, to.2, to.3]).unwrap();
        let before = *vg.position_pulses();
        let info = vg.plan_ptp(&target).unwrap();
        prop_assume!(info.periods < 200_000);
        let run = run(&mut vg);
        prop_assert_eq!(run.end, MoveEnd::Completed);
        prop_assert_eq!(run.periods.len() as u64, info.periods);
        let goal = vg.robot().joints_to_pulses(&target);
        let sums = pulse_sums(&run);
        for ax in 0..4 {
            prop_assert_eq!(sums[ax], goal[ax] - before[ax], "axis {}", ax);
            prop_assert_eq!(vg.position_pulses()[ax], goal[ax]);
        }
        // Phase synchronisation: all axes start together and finish together. An axis of n
        // pulses cannot show its first pulse before about 1/n of the way (quantisation), so
        // the bound is where the longest axis has covered 2/n of its distance (and, at the
        // end, has 2/n left), with 2 periods and 1 % of the move of slack. A regression found a 4-pulse J3 beside a
        // 17,000-pulse Z move: its first pulse came at 26 % of the time, correctly.
        let reference = (0..4).max_by_key(|&a| sums[a].abs()).unwrap();
        let total = sums[reference].abs() as f64;
        let mut covered = Vec::with_capacity(run.periods.len());
        let mut acc = 0i64;
        for p in &run.periods {
            acc += p.pulses[reference];
            covered.push(acc.abs() as f64);
        }
        let moving: Vec<usize> = (0..4).filter(|&a| sums[a] != 0).collect();
        let last = run.periods.len() - 1;
        for &ax in &moving {
            let share = 2.0 * total / sums[ax].abs() as f64;
            let slack = 2 + last / 100;
            let first = run.periods.iter().position(|p| p.pulses[ax] != 0).unwrap();
            let end = run.periods.iter().rposition(|p| p.pulses[ax] != 0).unwrap();
            let may_start = covered.iter().position(|&c| c >= share).unwrap_or(0);
            let may_end = covered.iter().rposition(|&c| total - c >= share).unwrap_or(0);
            prop_assert!(first <= may_start + slack, "axis {} starts late: period {} (bound {})", ax, first, may_start + slack);
            prop_assert!(end + slack >= may_end, "axis {} ends early: period {} (bound {})", ax, end, may_end);
        }
        if paper {
            assert_within_limits(&vg, &run, 1e-9, 1.0);
        } else {
            assert_within_limits(&vg, &run, 1e-6, 0.0);
        }
    }

    #[test]
    fn jog_moves_one_axis_only(axis in 0usize..4, pulses in -50_000i64..50_000, paper in any::<bool>()) {
        let mut vg = generator(profile(paper, 20), 0.01, 100.0);
        let start = *vg.position_pulses();
        match vg.plan_jog(axis, pulses) {
            Ok(info) => {
                if pulses == 0 {
                    prop_assert_eq!(info.periods, 0);
                    prop_assert!(!vg.is_moving());
                } else {
                    let run = run(&mut vg);
                    let sums = pulse_sums(&run);
                    for ax in 0..4 {
                        prop_assert_eq!(sums[ax], if ax == axis { pulses } else { 0 });
                        prop_assert_eq!(vg.position_pulses()[ax], start[ax] + sums[ax]);
                    }
                    assert_within_limits(&vg, &run, 1e-6, if paper { 1.0 } else { 0.0 });
                }
            }
            Err(PlanError::JogBeyondLimit { axis: name, .. }) => {
                let a = &vg.robot().axes()[axis];
                prop_assert_eq!(name, a.name);
                let end = a.pulses_to_units(start[axis] + pulses);
                prop_assert!(end < a.min || end > a.max);
            }
            Err(other) => prop_assert!(false, "unexpected {}", other),
        }
    }
}

#[test]
fn time_sync_when_one_shape_would_be_slower() {
    // J1 travels 150 deg and is velocity-limited; J3, with a low acceleration limit, turns
    // 30 deg. One common shape would have to respect J1's velocity ratio and J3's
    // acceleration ratio at once and be slower than J1 alone, so each axis gets its own
    // shape, stretched to the slowest axis's optimum (as Ruckig's time synchronisation).
    let paper = Robot::paper_default();
    let mut axes = paper.axes().to_vec();
    axes[2].limits.max_acceleration = 100.0;
    let robot = Robot::new("hetero", axes, 200.0, 200.0, 0.0, 2.0).unwrap();
    let settings = MotionSettings {
        period_s: 0.01,
        ..MotionSettings::default()
    };
    let mut vg = VelocityGenerator::new(robot, settings).unwrap();
    let mut target = vg.joints();
    target[0] += 150.0;
    target[2] += 30.0;
    let info = vg.plan_ptp(&target).unwrap();
    assert_eq!(info.sync, Sync::Time);
    // J1's own optimum: 150/180 + 180/720 + 720/7200 s.
    let own = 150.0 / 180.0 + 0.25 + 0.1;
    assert!((info.duration_s - own).abs() < 1e-9, "{}", info.duration_s);
    let run = run(&mut vg);
    assert_within_limits(&vg, &run, 1e-6, 0.0);
    assert_eq!(pulse_sums(&run)[2], 30_000);
    // Proportional moves keep one shape.
    let mut vg = generator(Profile::Fir, 0.01, 100.0);
    let mut target = vg.joints();
    target[0] += 10.0;
    target[1] -= 10.0;
    assert_eq!(vg.plan_ptp(&target).unwrap().sync, Sync::Phase);
}

#[test]
fn speed_override_stretches_time() {
    let mut full = generator(Profile::Fir, 0.001, 100.0);
    let mut half = generator(Profile::Fir, 0.001, 50.0);
    let mut target = full.joints();
    target[0] = 60.0;
    let a = full.plan_ptp(&target).unwrap();
    let b = half.plan_ptp(&target).unwrap();
    assert!(
        (b.duration_s - 2.0 * a.duration_s).abs() < 1e-9,
        "{} vs {}",
        a.duration_s,
        b.duration_s
    );
    assert!(full.set_speed_pct(0.5).is_err());
    assert!(full.set_speed_pct(f64::NAN).is_err());
    assert!(full.set_speed_pct(101.0).is_err());
}

#[test]
fn bad_targets_are_refused_before_any_pulse() {
    let mut vg = generator(Profile::Fir, 0.01, 100.0);
    let home = *vg.position_pulses();
    let mut t = vg.joints();
    t[1] = 170.0;
    assert!(matches!(
        vg.plan_ptp(&t),
        Err(PlanError::Kinematics(KinematicsError::JointLimit { .. }))
    ));
    t[1] = f64::NAN;
    assert!(matches!(
        vg.plan_ptp(&t),
        Err(PlanError::Kinematics(KinematicsError::NotFinite { .. }))
    ));
    let far = Pose {
        x: 450.0,
        y: 0.0,
        z: 0.0,
        yaw: 0.0,
    };
    let err = vg.plan_ptp_pose(&far, None).unwrap_err();
    assert!(err.to_string().contains("out of reach"), "{err}");
    assert!(matches!(
        vg.plan_jog(7, 10),
        Err(PlanError::NoSuchAxis { index: 7, count: 4 })
    ));
    assert!(!vg.is_moving());
    assert_eq!(*vg.position_pulses(), home);
    // A second move while one runs is refused, the first one is untouched.
    vg.plan_jog(0, 1000).unwrap();
    assert_eq!(vg.plan_jog(1, 1000), Err(PlanError::Busy));
    let run = run(&mut vg);
    assert_eq!(pulse_sums(&run)[0], 1000);
}

#[test]
fn ptp_to_a_pose_reaches_it() {
    let mut vg = generator(Profile::Fir, 0.01, 100.0);
    let target = Pose {
        x: 250.0,
        y: 150.0,
        z: 42.0,
        yaw: 90.0,
    };
    vg.plan_ptp_pose(&target, Some(Posture::Left)).unwrap();
    run(&mut vg);
    let p = vg.pose();
    assert!(
        (p.x - target.x).abs() < 0.01 && (p.y - target.y).abs() < 0.01,
        "{p:?}"
    );
    assert!((p.z - target.z).abs() < 0.001 && (p.yaw - target.yaw).abs() < 0.002);
    assert_eq!(Posture::of(vg.robot(), &vg.joints()), Some(Posture::Left));
}
