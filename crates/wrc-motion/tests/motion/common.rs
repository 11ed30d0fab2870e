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

/// Largest |first|, |second| and |third| finite difference per time unit of `x`, sampled
/// every `ts` [s] and at rest before and after (padded with its first and last value).
pub fn derivative_peaks(x: &[f64], ts: f64) -> (f64, f64, f64) {
    let mut padded = vec![x[0]; 3];
    padded.extend_from_slice(x);
    let last = *x.last().unwrap();
    padded.extend([last; 3]);
    let d = |s: &[f64]| s.windows(2).map(|w| (w[1] - w[0]) / ts).collect::<Vec<_>>();
    let v = d(&padded);
    let a = d(&v);
    let j = d(&a);
    let m = |s: &[f64]| s.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    (m(&v), m(&a), m(&j))
}

/// Largest |velocity|, |acceleration| and |jerk| per axis from finite differences of the
/// exact positions (starting and ending at rest).
pub fn peaks(run: &Run, ts: f64) -> [(f64, f64, f64); MAX_AXES] {
    let mut out = [(0.0, 0.0, 0.0); MAX_AXES];
    for (ax, o) in out.iter_mut().enumerate() {
        let mut x = vec![run.start[ax]];
        x.extend(run.periods.iter().map(|p| p.exact[ax]));
        *o = derivative_peaks(&x, ts);
    }
    out
}

/// Assert that no axis exceeded its limits scaled by the override, within `rel` relative
/// tolerance plus `abs_pulses` pulses of quantisation per period.
pub fn assert_within_limits(vg: &VelocityGenerator, run: &Run, rel: f64, abs_pulses: f64) {
    let s = vg.settings().speed_pct / 100.0;
    assert_within_scaled(vg, run, (s, s), rel, abs_pulses);
}

/// Assert that no axis exceeded its velocity limit times `scale.0`, nor its acceleration and
/// jerk limits times `scale.1`² and `scale.1`³, within `rel` relative tolerance plus
/// `abs_pulses` pulses of quantisation per period. Finite differences of positions sampled
/// every period are averages of the derivative over 1, 2 and 3 periods, so they never
/// exceed its largest value: no allowance for the sampling is needed.
pub fn assert_within_scaled(
    vg: &VelocityGenerator,
    run: &Run,
    scale: (f64, f64),
    rel: f64,
    abs_pulses: f64,
) {
    let ts = vg.settings().period_s;
    let (sv, s) = scale;
    let peaks = peaks(run, ts);
    for (ax, axis) in vg.robot().axes().iter().enumerate() {
        // Quantisation, plus floating-point noise of ~1e-11 units in positions of hundreds
        // of units, which finite differences amplify by 1/Ts³.
        let q = abs_pulses / axis.pulses_per_unit + 1e-11;
        let (v, a, j) = peaks[ax];
        let l = &axis.limits;
        let (vl, al, jl) = (
            l.max_velocity * sv,
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

/// A fixed-seed pseudo-random generator (SplitMix64) for reproducible random states.
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
}
