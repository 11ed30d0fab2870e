//! The default profile: a constant-velocity stream through two cascaded moving-average
//! (rectangular) filters — the time-optimal rest-to-rest jerk-limited ("double-S") motion.
//!
//! A move of distance D at velocity V is a box of height V and length T0 = D/V. Filtering it
//! with normalised boxes of lengths T1 = V/A and T2 = A/J gives a velocity with acceleration
//! limit A and jerk limit J. Because the input is piecewise constant, the filters' output is
//! evaluated in closed form (a sum of shifted cubic step responses), which equals the FIR
//! evaluated at an infinitely fine tick: durations are the continuous optimum, not rounded
//! to whole periods, and one evaluation is O(1) with no delay line. Velocity and acceleration
//! have closed forms too ([`DoubleS::state`]): a controlled stop brakes from them
//! (`brake.rs`). All `f64`, no allocation.

/// Lengths of the three boxes whose convolution is the motion, for a distance normalised to
/// 1.
///
/// Invariants: `t1 >= t2 >= 0`, `t0 >= t1 + t2`. With `t0 >= t1 + t2` the jerk pulses of
/// acceleration and deceleration never overlap, so the peak jerk is the planned one (overlap
/// would double it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoubleS {
    /// Length of the constant-velocity input box, distance / velocity [s].
    pub t0: f64,
    /// First filter, velocity / acceleration [s].
    pub t1: f64,
    /// Second filter, acceleration / jerk [s].
    pub t2: f64,
}

impl DoubleS {
    /// A profile that does not move (zero distance).
    pub const REST: DoubleS = DoubleS {
        t0: 0.0,
        t1: 0.0,
        t2: 0.0,
    };

    /// The time-optimal rest-to-rest profile for a distance `d` and limits `v`, `a`, `j`,
    /// all positive, in consistent units (e.g. [deg], [deg/s], [deg/s²], [deg/s³]). The
    /// result is normalised: [`DoubleS::fraction`] goes from 0 to 1.
    ///
    /// Cases: when V·J < A² the acceleration limit cannot be reached before V, so
    /// A := sqrt(V·J). When D/V < T1 + T2 (a short move) V is lowered until T0 = T1 + T2;
    /// if that lowers V below A²/J, A is not reached either and T1 = T2 = (D/2J)^⅓.
    pub fn time_optimal(d: f64, v: f64, a: f64, j: f64) -> DoubleS {
        debug_assert!(d > 0.0 && v > 0.0 && a > 0.0 && j > 0.0);
        let a_eff = if v * j < a * a { (v * j).sqrt() } else { a };
        let (t0, t1, t2);
        if d / v >= v / a_eff + a_eff / j {
            // Full profile: cruise at V.
            t1 = v / a_eff;
            t2 = a_eff / j;
            t0 = d / v;
        } else {
            // V is not reached. Peak velocity vp with acceleration limit reached:
            // vp (vp/A + A/J) = D.
            let q = a / j;
            let vp = 0.5 * a * (-q + (q * q + 4.0 * d / a).sqrt());
            if vp * j >= a * a {
                t1 = vp / a;
                t2 = a / j;
            } else {
                // Neither V nor A reached: triangular acceleration.
                let tj = (d / (2.0 * j)).cbrt();
                t1 = tj;
                t2 = tj;
            }
            t0 = t1 + t2;
        }
        DoubleS { t0, t1, t2 }
    }

    /// Duration [s] of the profile: it is at rest from then on (0 for [`DoubleS::REST`]).
    pub fn duration(&self) -> f64 {
        if self.t0 <= 0.0 {
            0.0
        } else {
            self.t0 + self.t1 + self.t2
        }
    }

    /// The same shape slowed down so that it lasts `duration` [s] (>= its own): velocity
    /// scales by 1/s, acceleration by 1/s², jerk by 1/s³, so every limit still holds.
    pub fn stretched_to(&self, duration: f64) -> DoubleS {
        let own = self.duration();
        if own <= 0.0 || duration <= own {
            return *self;
        }
        let s = duration / own;
        DoubleS {
            t0: self.t0 * s,
            t1: self.t1 * s,
            t2: self.t2 * s,
        }
    }

    /// Fraction of the distance covered at time `t` [s] after the start, in [0, 1].
    #[inline]
    pub fn fraction(&self, t: f64) -> f64 {
        self.state(t).0
    }

    /// Fraction of the distance covered at time `t` [s] after the start, and its first and
    /// second time derivatives [1, 1/s, 1/s²], in closed form: (0, 0, 0) before the start,
    /// (1, 0, 0) from [`DoubleS::duration`] on.
    #[inline]
    pub fn state(&self, t: f64) -> (f64, f64, f64) {
        if self.t0 <= 0.0 || t >= self.duration() {
            return (1.0, 0.0, 0.0);
        }
        let (p, v, a) = ramp_response(t, self.t1, self.t2);
        let (pc, vc, ac) = ramp_response(t - self.t0, self.t1, self.t2);
        ((p - pc) / self.t0, (v - vc) / self.t0, (a - ac) / self.t0)
    }
}

/// Position response at time `t` [s] of a unit-velocity step through normalised boxes of
/// lengths `t1 >= t2 >= 0` [s], with its first and second derivatives: 0 before the step,
/// `t − (t1 + t2)/2` once both filters are full, and a piecewise cubic in between.
#[inline]
fn ramp_response(t: f64, t1: f64, t2: f64) -> (f64, f64, f64) {
    if t <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let full = t1 + t2;
    if t >= full {
        return (t - 0.5 * full, 1.0, 0.0);
    }
    // Degenerate filters (a box of length ~0 is the identity).
    let tiny = 1e-12_f64.max(full * 1e-9);
    if t1 <= tiny {
        return (t, 1.0, 0.0);
    }
    let pos = |x: f64| x.max(0.0);
    let sq = |x: f64| pos(x) * pos(x);
    let (d1, d2) = (t - t1, t - t2);
    if t2 <= tiny {
        // One box: the double integral of (H(t) − H(t−t1)) / t1.
        let step = if d1 > 0.0 { 0.0 } else { 1.0 };
        return ((sq(t) - sq(d1)) / (2.0 * t1), (t - pos(d1)) / t1, step / t1);
    }
    let cube = |x: f64| pos(x) * pos(x) * pos(x);
    let (c, q) = (6.0 * t1 * t2, 2.0 * t1 * t2);
    (
        (cube(t) - cube(d1) - cube(d2)) / c,
        (sq(t) - sq(d1) - sq(d2)) / q,
        (t - pos(d1) - pos(d2)) / (t1 * t2),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sample a profile scaled to distance `d` every `dt` seconds; return the maximum
    /// velocity, acceleration and jerk from finite differences.
    fn peaks(p: &DoubleS, d: f64, dt: f64) -> (f64, f64, f64) {
        let n = (p.duration() / dt).ceil() as usize + 4;
        let x: Vec<f64> = (0..n).map(|k| d * p.fraction(k as f64 * dt)).collect();
        let v: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
        let a: Vec<f64> = v.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
        let j: Vec<f64> = a.windows(2).map(|w| (w[1] - w[0]) / dt).collect();
        let max = |s: &[f64]| s.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        (max(&v), max(&a), max(&j))
    }

    #[test]
    fn full_profile_reaches_every_limit() {
        let p = DoubleS::time_optimal(100.0, 50.0, 200.0, 2000.0);
        assert!(
            (p.t1 - 0.25).abs() < 1e-12 && (p.t2 - 0.1).abs() < 1e-12 && (p.t0 - 2.0).abs() < 1e-12
        );
        let (v, a, j) = peaks(&p, 100.0, 1e-4);
        assert!((v - 50.0).abs() < 0.01, "v {v}");
        assert!((a - 200.0).abs() < 1.0, "a {a}");
        assert!(j <= 2000.0 * 1.001 && j > 1990.0, "j {j}");
        assert_eq!(p.fraction(10.0), 1.0);
        assert_eq!(p.fraction(-1.0), 0.0);
    }

    #[test]
    fn short_moves_lower_v_and_never_double_jerk() {
        // Acceleration reached, velocity not.
        let p = DoubleS::time_optimal(5.0, 50.0, 200.0, 2000.0);
        assert!((p.t0 - (p.t1 + p.t2)).abs() < 1e-12 && p.t1 >= p.t2);
        let (v, a, j) = peaks(&p, 5.0, 1e-4);
        assert!(
            v < 50.0 && a <= 200.0 * 1.001 && j <= 2000.0 * 1.001,
            "{v} {a} {j}"
        );
        // Neither reached.
        let p = DoubleS::time_optimal(0.01, 50.0, 200.0, 2000.0);
        assert!((p.t1 - p.t2).abs() < 1e-12 && (p.t0 - 2.0 * p.t1).abs() < 1e-12);
        let (_, a, j) = peaks(&p, 0.01, 1e-5);
        assert!(a < 200.0 && j <= 2000.0 * 1.001, "{a} {j}");
    }

    #[test]
    fn velocity_limited_before_acceleration() {
        // V·J < A²: A := sqrt(V·J) = 10.
        let p = DoubleS::time_optimal(100.0, 1.0, 1000.0, 100.0);
        assert!((p.t1 - 0.1).abs() < 1e-12 && (p.t2 - 0.1).abs() < 1e-12);
        let (v, a, j) = peaks(&p, 100.0, 1e-4);
        assert!(
            v <= 1.0 + 1e-9 && a <= 10.0 * 1.001 && j <= 100.0 * 1.001,
            "{v} {a} {j}"
        );
    }

    #[test]
    fn state_is_the_exact_derivative_of_the_fraction() {
        for p in [
            DoubleS::time_optimal(100.0, 50.0, 200.0, 2000.0),
            DoubleS::time_optimal(5.0, 50.0, 200.0, 2000.0),
            DoubleS::time_optimal(0.01, 50.0, 200.0, 2000.0),
            DoubleS::time_optimal(100.0, 1.0, 1000.0, 100.0),
        ] {
            let h = 1e-6;
            for k in 0..=400 {
                let t = p.duration() * k as f64 / 400.0;
                let (f, v, a) = p.state(t);
                assert_eq!(f, p.fraction(t));
                // Central differences. Tolerance: their truncation error where the
                // acceleration has a kink (the jerk, 1/(t0·t1·t2), times h² for v and h for
                // a) plus rounding (a few ulps of the response, (t + 1) s, over h).
                let (fm, vm, _) = p.state(t - h);
                let (fp, vp, _) = p.state(t + h);
                let jerk = 1.0 / (p.t0 * p.t1 * p.t2);
                let round = 1e-15 * (t + 1.0) / (h * p.t0);
                let (dv, da) = ((fp - fm) / (2.0 * h), (vp - vm) / (2.0 * h));
                assert!((v - dv).abs() < jerk * h * h + round, "{p:?} v at {t}");
                assert!((a - da).abs() < jerk * h + round, "{p:?} a at {t}");
            }
            assert_eq!(p.state(p.duration()), (1.0, 0.0, 0.0));
            assert_eq!(p.state(-1.0), (0.0, 0.0, 0.0));
        }
    }

    #[test]
    fn stretching_keeps_the_shape_and_the_limits() {
        let p = DoubleS::time_optimal(10.0, 50.0, 200.0, 2000.0);
        let q = p.stretched_to(2.0 * p.duration());
        assert!((q.duration() - 2.0 * p.duration()).abs() < 1e-12);
        let (v, a, j) = peaks(&q, 10.0, 1e-4);
        let (v0, a0, j0) = peaks(&p, 10.0, 1e-4);
        assert!((v - v0 / 2.0).abs() < 1e-3 * v0 && a < a0 / 3.9 && j < j0 / 7.8);
    }
}
