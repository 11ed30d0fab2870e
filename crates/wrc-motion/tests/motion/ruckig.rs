//! Ruckig as an oracle: a PTP move's duration must equal Ruckig's time-optimal duration
//! (with time synchronisation, rest to rest) within one period, and the 1-D brake
//! ([`Brake1d`]) must equal Ruckig's time-optimal brake (velocity interface to rest).

use proptest::prelude::*;
use rsruckig::prelude::*;
use wrc_motion::{Brake1d, Profile};

use crate::common::*;

fn ruckig_duration(start: &[f64; 4], target: &[f64; 4], limits: &[(f64, f64, f64); 4]) -> f64 {
    let mut otg = Ruckig::<4, ThrowErrorHandler>::new(None, 0.01);
    let mut input = InputParameter::new(None);
    for i in 0..4 {
        input.current_position[i] = start[i];
        input.target_position[i] = target[i];
        input.max_velocity[i] = limits[i].0;
        input.max_acceleration[i] = limits[i].1;
        input.max_jerk[i] = limits[i].2;
    }
    let mut trajectory = Trajectory::new(None);
    otg.calculate(&input, &mut trajectory)
        .expect("ruckig accepts the input");
    trajectory.get_duration()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    // Tolerance: the continuous durations agree within 1e-6 relative (Ruckig's own numeric
    // precision), and the number of periods times the period is within one period.
    #[test]
    fn ptp_duration_equals_ruckig(
        from in (-170.0f64..170.0, -160.0f64..160.0, -260.0f64..260.0, 0.0f64..300.0),
        to in (-170.0f64..170.0, -160.0f64..160.0, -260.0f64..260.0, 0.0f64..300.0),
        pct in 1.0f64..100.0, fast in any::<bool>(),
    ) {
        let ts = if fast { 0.001 } else { 0.010 };
        let mut vg = generator(Profile::Fir, ts, pct);
        let robot = vg.robot().clone();
        let start = robot.joints_from_slice(&[from.0, from.1, from.2, from.3]).unwrap();
        let target = robot.joints_from_slice(&[to.0, to.1, to.2, to.3]).unwrap();
        vg.set_position_pulses(&robot.joints_to_pulses(&start)).unwrap();
        let info = vg.plan_ptp(&target).unwrap();
        // Ruckig sees exactly the pulse-quantised start and target.
        let s = pct / 100.0;
        let (p0, p1) = (robot.joints_to_pulses(&start), robot.joints_to_pulses(&target));
        let mut a = [0.0; 4];
        let mut b = [0.0; 4];
        let mut limits = [(0.0, 0.0, 0.0); 4];
        for i in 0..4 {
            let ax = &robot.axes()[i];
            a[i] = ax.pulses_to_units(p0[i]);
            b[i] = ax.pulses_to_units(p1[i]);
            let l = &ax.limits;
            limits[i] = (l.max_velocity * s, l.max_acceleration * s * s, l.max_jerk * s * s * s);
        }
        let t_ruckig = ruckig_duration(&a, &b, &limits);
        prop_assert!((info.duration_s - t_ruckig).abs() <= 1e-6 * t_ruckig.max(1.0),
            "wrc {} s vs ruckig {} s ({:?})", info.duration_s, t_ruckig, info.sync);
        let t_periods = info.periods as f64 * ts;
        prop_assert!((t_periods - t_ruckig).abs() <= ts + 1e-9, "{} periods vs ruckig {} s", info.periods, t_ruckig);
        let run = run(&mut vg);
        prop_assert_eq!(run.periods.len() as u64, info.periods);
    }
}

/// Ruckig's time-optimal brake of one coordinate (velocity interface, target velocity and
/// acceleration 0, acceleration limit `a_max`, jerk limit `j_max`) from (v0, a0): its
/// duration [s] and the distance it travels.
pub fn ruckig_brake(v0: f64, a0: f64, a_max: f64, j_max: f64) -> (f64, f64) {
    let mut otg = Ruckig::<1, ThrowErrorHandler>::new(None, 0.001);
    let mut input = InputParameter::new(None);
    input.control_interface = ControlInterface::Velocity;
    input.current_position[0] = 0.0;
    input.current_velocity[0] = v0;
    input.current_acceleration[0] = a0;
    input.target_velocity[0] = 0.0;
    input.target_acceleration[0] = 0.0;
    input.max_velocity[0] = f64::INFINITY;
    input.max_acceleration[0] = a_max;
    input.max_jerk[0] = j_max;
    let mut trajectory = Trajectory::new(None);
    otg.calculate(&input, &mut trajectory)
        .expect("ruckig accepts the input");
    let duration = trajectory.get_duration();
    let mut position = DataArrayOrVec::<f64, 1>::new(Some(1), 0.0);
    trajectory.at_time(
        duration,
        &mut Some(&mut position),
        &mut None,
        &mut None,
        &mut None,
        &mut None,
    );
    (duration, position[0])
}

/// The 1-D brake equals Ruckig's time-optimal brake on seeded random states: inside and
/// beyond the acceleration limit, accelerating, cruising, braking gently or too hard, in
/// both directions, and the special states (rest, on the switching curve).
///
/// Tolerance: durations within 1e-6 s + 1e-6 relative (Ruckig's root finding; its brake
/// pre-trajectory adds f64::EPSILON), distances within 1e-6 of the distance scale
/// |v0|·T + |a0|·T² + 1e-9.
#[test]
fn brake_equals_ruckig() {
    let mut rng = SplitMix64(2026);
    let mut cases = Vec::new();
    for _ in 0..4000 {
        let a_max = rng.uniform(10.0, 2000.0);
        let j_max = rng.uniform(100.0, 50_000.0);
        let v0 = rng.uniform(-500.0, 500.0);
        let a0 = rng.uniform(-1.3 * a_max, 1.3 * a_max);
        cases.push((v0, a0, a_max, j_max));
    }
    // Rest, pure acceleration, on the switching curve from either side, at the limit.
    for (v0, a0) in [
        (0.0, 0.0),
        (0.0, 300.0),
        (0.0, -300.0),
        (300.0 * 300.0 / (2.0 * 7200.0), -300.0),
        (-300.0 * 300.0 / (2.0 * 7200.0), 300.0),
        (180.0, 720.0),
        (180.0, -720.0),
        (1e-9, 0.0),
    ] {
        cases.push((v0, a0, 720.0, 7200.0));
    }
    let mut worst = (0.0f64, 0.0f64);
    for (v0, a0, a_max, j_max) in cases {
        let b = Brake1d::new(0.0, v0, a0, a_max, j_max);
        let (t_ruckig, d_ruckig) = ruckig_brake(v0, a0, a_max, j_max);
        let t = b.duration();
        let t_err = (t - t_ruckig).abs();
        let scale = v0.abs() * t + a0.abs() * t * t + 1e-9;
        let d_err = (b.stop_position() - d_ruckig).abs() / scale;
        worst = (worst.0.max(t_err), worst.1.max(d_err));
        assert!(
            t_err <= 1e-6 + 1e-6 * t_ruckig,
            "v0 {v0} a0 {a0} A {a_max} J {j_max}: {t} s vs ruckig {t_ruckig} s"
        );
        assert!(
            d_err <= 1e-6,
            "v0 {v0} a0 {a0} A {a_max} J {j_max}: stops at {} vs ruckig {d_ruckig}",
            b.stop_position()
        );
    }
    eprintln!(
        "brake vs ruckig: worst |Δt| {:.2e} s, worst |Δd|/scale {:.2e}",
        worst.0, worst.1
    );
}
