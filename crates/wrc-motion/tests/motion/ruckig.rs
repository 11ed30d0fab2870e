//! Ruckig as an oracle: a PTP move's duration must equal Ruckig's time-optimal duration
//! (with time synchronisation, rest to rest) within one period.

use proptest::prelude::*;
use rsruckig::prelude::*;
use wrc_motion::Profile;

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
