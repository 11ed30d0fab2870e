//! Helpers shared by the tests: running a move to its end and checking limits.

use wrc_motion::{MotionSettings, MoveEnd, Period, Profile, Status, VelocityGenerator};
use wrc_robot::{Joints, Robot, MAX_AXES};

/// Every period of a move: pulses and the exact (unrounded) joints after it.
pub struct Run {
    pub periods: Vec<Period>,
    pub end: MoveEnd,
    pub start: Joints,
}

pub fn generator(profile: Profile, period_s: f64, speed_pct: f64) -> VelocityGenerator {
    let settings = MotionSettings {
        period_s,
        profile,
        speed_pct,
        ..MotionSettings::default()
    };
    VelocityGenerator::new(Robot::paper_default(), settings).unwrap()
}

/// Run the planned move to its end (at most `limit` periods), calling `each` before every
/// period with its index.
pub fn run_with(
    vg: &mut VelocityGenerator,
    limit: usize,
    mut each: impl FnMut(&mut VelocityGenerator, usize),
) -> Run {
    let start = vg.joints();
    let mut periods = Vec::new();
    for k in 0..limit {
        each(vg, k);
        let mut p = Period::default();
        match vg.next_period(&mut p) {
            Status::Working => periods.push(p),
            Status::Finished(end) => {
                periods.push(p);
                return Run {
                    periods,
                    end,
                    start,
                };
            }
            Status::Idle => panic!("idle before the move ended"),
        }
    }
    panic!("move did not end within {limit} periods");
}

pub fn run(vg: &mut VelocityGenerator) -> Run {
    run_with(vg, 1_000_000, |_, _| {})
}

/// Largest |velocity|, |acceleration| and |jerk| per axis from finite differences of the
/// exact positions (starting and ending at rest).
pub fn peaks(run: &Run, ts: f64) -> [(f64, f64, f64); MAX_AXES] {
    let mut out = [(0.0, 0.0, 0.0); MAX_AXES];
    for (ax, o) in out.iter_mut().enumerate() {
        // Rest before and after: pad with the start and the end position.
        let mut x = vec![run.start[ax]; 3];
        x.extend(run.periods.iter().map(|p| p.exact[ax]));
        let last = *x.last().unwrap();
        x.extend([last; 3]);
        let d = |s: &[f64]| s.windows(2).map(|w| (w[1] - w[0]) / ts).collect::<Vec<_>>();
        let v = d(&x);
        let a = d(&v);
        let j = d(&a);
        let m = |s: &[f64]| s.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        *o = (m(&v), m(&a), m(&j));
    }
    out
}

/// Assert that no axis exceeded its limits scaled by the override, within `rel` relative
/// tolerance plus `abs_pulses` pulses of quantisation per period.
pub fn assert_within_limits(vg: &VelocityGenerator, run: &Run, rel: f64, abs_pulses: f64) {
    let ts = vg.settings().period_s;
    let s = vg.settings().speed_pct / 100.0;
    let peaks = peaks(run, ts);
    for (ax, axis) in vg.robot().axes().iter().enumerate() {
        // Quantisation, plus floating-point noise of ~1e-11 units in positions of hundreds
        // of units, which finite differences amplify by 1/Ts³.
        let q = abs_pulses / axis.pulses_per_unit + 1e-11;
        let (v, a, j) = peaks[ax];
        let l = &axis.limits;
        let (vl, al, jl) = (
            l.max_velocity * s,
            l.max_acceleration * s * s,
            l.max_jerk * s * s * s,
        );
        assert!(
            v <= vl * (1.0 + rel) + q / ts,
            "{}: velocity {v} > {vl}",
            axis.name
        );
        assert!(
            a <= al * (1.0 + rel) + 2.0 * q / (ts * ts),
            "{}: acceleration {a} > {al}",
            axis.name
        );
        assert!(
            j <= jl * (1.0 + rel) + 4.0 * q / (ts * ts * ts),
            "{}: jerk {j} > {jl}",
            axis.name
        );
    }
}

/// Sum of the pulses per axis.
pub fn pulse_sums(run: &Run) -> [i64; MAX_AXES] {
    let mut s = [0i64; MAX_AXES];
    for p in &run.periods {
        for (a, b) in s.iter_mut().zip(p.pulses.iter()) {
            *a += b;
        }
    }
    s
}
