//! The time-optimal jerk-limited brake of one coordinate: from any state (position p0,
//! velocity v0, acceleration a0) to rest (v = 0, a = 0) as fast as an acceleration limit A and
//! a jerk limit J allow, in closed form ([`Brake1d`]).
//!
//! # The profile
//!
//! Velocity and acceleration form a double integrator driven by the jerk, so the time-optimal
//! control is bang-bang around the switching curve v = −a·|a|/(2J) — the states from which a
//! single jerk phase (+J or −J) brings v and a to zero together:
//!
//! 1. an acceleration beyond ±A is first brought back to the limit with the jerk that points
//!    inside (as Ruckig's brake pre-trajectory does);
//! 2. above the curve (v + a·|a|/(2J) > 0) the jerk is −J until the deceleration reaches its
//!    peak −√(J·v + a²/2), or the limit −A and then a phase of constant deceleration −A until
//!    v = A²/(2J); below the curve everything is mirrored (+J, peak +√(…));
//! 3. the opposite jerk brings the acceleration back to zero just as the velocity reaches zero.
//!
//! At most four constant-jerk phases. A state already braking harder than it needs
//! (v0 > 0, a0 < 0 and v0 < a0²/(2J)) is below the curve: zero acceleration cannot be reached
//! before the velocity passes zero, so the time-optimal brake reverses — by exactly as much as
//! that requires (it is the bang-bang optimum, and a test compares it with Ruckig's). A
//! velocity limit plays no part: from a state within a plan's velocity envelope
//! (v + a²/(2J) ≤ V while accelerating, as every jerk-limited plan has) the brake never
//! exceeds it.
//!
//! Real-time promise: `Copy`, no allocation, no panic, O(1) to build and to evaluate; every
//! output is finite for finite input.

/// Which limits a controlled stop ([`crate::VelocityGenerator::stop`]) brakes with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BrakeLimits {
    /// STOP or HOLD: every axis's (and a line's or path's Cartesian) limits scaled by the
    /// move's speed override (velocity p, acceleration p², jerk p³) — the limits the move was
    /// planned with, without its acceleration override, which a stop never takes.
    Override,
    /// ESTOP, IEC 60204-1 stop category 1: every axis's full limits whatever the speed
    /// override (a straight line: its full joint and Cartesian limits).
    Full,
}

/// Most constant-jerk phases of a brake: back inside ±A, towards the peak deceleration, at
/// the peak, back to zero acceleration.
const MAX_PHASES: usize = 4;

/// Velocities and accelerations are clamped to ±this before a brake is built, and limits to
/// [`LIMIT_MIN`, `LIMIT_MAX`]: far beyond any machine, and small enough that every
/// intermediate quantity (at worst v²/A ~ 1e210) stays finite.
const STATE_MAX: f64 = 1e30;
/// Smallest limit a brake uses (a limit that is zero, negative or NaN becomes this).
const LIMIT_MIN: f64 = 1e-30;
/// Largest limit a brake uses (an infinite limit becomes this).
const LIMIT_MAX: f64 = 1e30;

/// A time-optimal jerk-limited brake of one coordinate from a state to rest, evaluated exactly
/// at any time. Units are consistent ones, e.g. [deg], [deg/s], [deg/s²], [deg/s³], or a
/// fraction of a move and its derivatives [1], [1/s], [1/s²], [1/s³].
///
/// ```
/// use wrc_motion::Brake1d;
///
/// // 180 deg/s, no acceleration, A = 720 deg/s², J = 7200 deg/s³: jerk down for 0.1 s,
/// // hold −720 deg/s² for 0.15 s, jerk back up for 0.1 s.
/// let b = Brake1d::new(0.0, 180.0, 0.0, 720.0, 7200.0);
/// assert!((b.duration() - 0.35).abs() < 1e-12);
/// assert!((b.stop_position() - 31.5).abs() < 1e-9); // v0·T/2 for this symmetric brake
/// let (p, v, a) = b.at(0.1);
/// assert!((v - 144.0).abs() < 1e-9 && (a + 720.0).abs() < 1e-9 && p > 0.0);
/// assert_eq!(b.at(1.0), (b.stop_position(), 0.0, 0.0));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Brake1d {
    p0: f64,
    v0: f64,
    a0: f64,
    /// Length of each phase [s], in order; unused phases are 0.
    len: [f64; MAX_PHASES],
    /// Jerk of each phase.
    jerk: [f64; MAX_PHASES],
    /// Sum of the phases [s].
    duration: f64,
    /// Position at rest.
    stop: f64,
}

impl Default for Brake1d {
    /// At rest at 0: a brake of no duration.
    fn default() -> Self {
        Brake1d::new(0.0, 0.0, 0.0, 1.0, 1.0)
    }
}

impl Brake1d {
    /// The time-optimal brake from position `p0`, velocity `v0` and acceleration `a0` to rest,
    /// with acceleration limit `a_max` and jerk limit `j_max` (both > 0; one that is not a
    /// positive number is taken as 1e-30, an infinite one as 1e30). `v0` and `a0` are clamped
    /// to ±1e30 (a NaN is taken as 0), so that nothing overflows.
    pub fn new(p0: f64, v0: f64, a0: f64, a_max: f64, j_max: f64) -> Brake1d {
        let state = |x: f64| {
            if x.is_nan() {
                0.0
            } else {
                x.clamp(-STATE_MAX, STATE_MAX)
            }
        };
        let limit = |x: f64| {
            if x > 0.0 {
                x.clamp(LIMIT_MIN, LIMIT_MAX)
            } else {
                LIMIT_MIN
            }
        };
        let (v0, a0) = (state(v0), state(a0));
        let (a_lim, j) = (limit(a_max), limit(j_max));
        let mut b = Brake1d {
            p0,
            v0,
            a0,
            len: [0.0; MAX_PHASES],
            jerk: [0.0; MAX_PHASES],
            duration: 0.0,
            stop: p0,
        };
        let mut phases = Phases {
            brake: &mut b,
            count: 0,
            state: (p0, v0, a0),
        };
        // 1. An acceleration beyond the limit comes back inside first.
        let a = phases.state.2;
        if a > a_lim {
            phases.push((a - a_lim) / j, -j);
        } else if a < -a_lim {
            phases.push((-a_lim - a) / j, j);
        }
        // 2. The side of the switching curve v = −a|a|/(2J) gives the direction; in that
        // direction's frame (v and a times `dir`) the jerk is −J to the peak deceleration.
        let (_, v, a) = phases.state;
        let dir = if v + a * a.abs() / (2.0 * j) >= 0.0 {
            1.0
        } else {
            -1.0
        };
        let (v, a) = (dir * v, dir * a);
        let peak = -(j * v + 0.5 * a * a).max(0.0).sqrt();
        if peak >= -a_lim {
            phases.push((a - peak.min(a)) / j, -dir * j);
        } else {
            // The limit is reached: hold −A until the last phase can land on v = 0.
            phases.push(((a + a_lim) / j).max(0.0), -dir * j);
            let (_, v, a) = phases.state;
            let (v, a) = (dir * v, dir * a);
            if a < 0.0 {
                phases.push(((v - a * a / (2.0 * j)) / -a).max(0.0), 0.0);
            }
        }
        // 3. Back to zero acceleration, and so to rest.
        let a = dir * phases.state.2;
        phases.push((-a / j).max(0.0), dir * j);
        b.stop = phases_end(&b);
        b
    }

    /// Duration of the brake [s]; 0 when it starts at rest.
    pub fn duration(&self) -> f64 {
        self.duration
    }

    /// Position where the brake comes to rest.
    pub fn stop_position(&self) -> f64 {
        self.stop
    }

    /// Position, velocity and acceleration at time `t` [s] after the brake starts, exactly
    /// (closed form, no integration): the start state for t ≤ 0, rest at
    /// [`Brake1d::stop_position`] from [`Brake1d::duration`] on.
    pub fn at(&self, t: f64) -> (f64, f64, f64) {
        if t.is_nan() || t >= self.duration {
            return (self.stop, 0.0, 0.0);
        }
        let mut t = t.max(0.0);
        let mut s = (self.p0, self.v0, self.a0);
        for (&len, &jerk) in self.len.iter().zip(&self.jerk) {
            if t <= len {
                return advance(s, jerk, t);
            }
            s = advance(s, jerk, len);
            t -= len;
        }
        (self.stop, 0.0, 0.0)
    }
}

impl Brake1d {
    /// The brake's constant-jerk phases in order: (start [s], length [s], jerk), for checks
    /// along it (a straight line's brake is verified against every joint limit).
    pub(crate) fn phases(&self) -> impl Iterator<Item = (f64, f64, f64)> + '_ {
        let mut start = 0.0;
        self.len
            .iter()
            .zip(&self.jerk)
            .filter(|(&len, _)| len > 0.0)
            .map(move |(&len, &jerk)| {
                let phase = (start, len, jerk);
                start += len;
                phase
            })
    }
}

/// The phases of a brake being built, and the state at the end of the last one.
struct Phases<'a> {
    brake: &'a mut Brake1d,
    count: usize,
    state: (f64, f64, f64),
}

impl Phases<'_> {
    /// Append a phase of `len` [s] at `jerk` (nothing if it has no length).
    fn push(&mut self, len: f64, jerk: f64) {
        if len > 0.0 && self.count < MAX_PHASES {
            self.brake.len[self.count] = len;
            self.brake.jerk[self.count] = jerk;
            self.brake.duration += len;
            self.state = advance(self.state, jerk, len);
            self.count += 1;
        }
    }
}

/// Where the phases of `b` end, evaluated as [`Brake1d::at`] evaluates them.
fn phases_end(b: &Brake1d) -> f64 {
    let mut s = (b.p0, b.v0, b.a0);
    for (&len, &jerk) in b.len.iter().zip(&b.jerk) {
        s = advance(s, jerk, len);
    }
    s.0
}

/// Position, velocity and acceleration after `t` [s] at constant `jerk` from `(p, v, a)`.
#[inline]
fn advance((p, v, a): (f64, f64, f64), jerk: f64, t: f64) -> (f64, f64, f64) {
    (
        p + t * (v + t * (0.5 * a + t * jerk / 6.0)),
        v + t * (a + 0.5 * t * jerk),
        a + t * jerk,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Sample the brake every `dt` and return the largest |a| and |jerk| (finite differences
    /// of the exact acceleration), and whether v and a are continuous.
    fn sampled(b: &Brake1d, dt: f64) -> (f64, f64) {
        let n = (b.duration() / dt).ceil() as usize + 2;
        let mut amax = 0.0f64;
        let mut jmax = 0.0f64;
        let mut last = b.at(0.0);
        for k in 1..=n {
            let s = b.at(k as f64 * dt);
            amax = amax.max(s.2.abs());
            jmax = jmax.max(((s.2 - last.2) / dt).abs());
            last = s;
        }
        (amax, jmax)
    }

    #[test]
    fn cruise_brake_holds_the_acceleration_limit() {
        let b = Brake1d::new(10.0, 180.0, 0.0, 720.0, 7200.0);
        assert!((b.duration() - 0.35).abs() < 1e-12);
        assert!((b.stop_position() - 41.5).abs() < 1e-9);
        let (a, j) = sampled(&b, 1e-4);
        assert!(a <= 720.0 * (1.0 + 1e-12) && a > 719.0, "{a}");
        assert!(j <= 7200.0 * (1.0 + 1e-9), "{j}");
    }

    #[test]
    fn slow_brake_does_not_reach_the_limit() {
        // v0 = 6, a0 = 0: peak √(J v0) = 207.8 < A, duration 2·peak/J.
        let b = Brake1d::new(0.0, 6.0, 0.0, 720.0, 7200.0);
        let peak = (7200.0f64 * 6.0).sqrt();
        assert!((b.duration() - 2.0 * peak / 7200.0).abs() < 1e-12);
        let (a, _) = sampled(&b, 1e-5);
        assert!((a - peak).abs() < 1.0, "{a}");
    }

    #[test]
    fn accelerating_state_first_stops_accelerating() {
        // a0 = A: the velocity still rises by A²/2J before it falls.
        let b = Brake1d::new(0.0, 36.0, 720.0, 720.0, 7200.0);
        assert!((b.duration() - 0.3).abs() < 1e-12);
        assert!((b.stop_position() - 13.2).abs() < 1e-9);
        let (_, v, a) = b.at(0.1);
        assert!((v - 72.0).abs() < 1e-9 && a.abs() < 1e-9);
    }

    #[test]
    fn a_state_braking_too_hard_reverses_as_little_as_the_optimum() {
        // v0 < a0²/2J: the velocity passes zero before the acceleration can; +J, then −J.
        let (v0, a0, jm) = (1.0, -400.0, 7200.0);
        let b = Brake1d::new(0.0, v0, a0, 720.0, jm);
        // Below the curve: the peak (positive) acceleration is √(J·(−v0) + a0²/2).
        let peak = (jm * -v0 + 0.5 * a0 * a0).sqrt();
        let want = (peak - a0) / jm + peak / jm;
        assert!(
            (b.duration() - want).abs() < 1e-12,
            "{} vs {want}",
            b.duration()
        );
        // The most negative velocity is where a = 0 on the way up: v0 − a0²/2J.
        let n = 10_000;
        let vmin = (0..=n)
            .map(|k| b.at(b.duration() * k as f64 / n as f64).1)
            .fold(f64::INFINITY, f64::min);
        assert!((vmin - (v0 - a0 * a0 / (2.0 * jm))).abs() < 1e-6, "{vmin}");
        assert_eq!(b.at(b.duration()), (b.stop_position(), 0.0, 0.0));
    }

    #[test]
    fn acceleration_beyond_the_limit_comes_back_first() {
        for (v0, a0) in [
            (50.0, 1000.0),
            (50.0, -1000.0),
            (-50.0, 1000.0),
            (400.0, -900.0),
        ] {
            let b = Brake1d::new(0.0, v0, a0, 720.0, 7200.0);
            // The first phase moves the acceleration towards the limit at full jerk.
            let (_, _, a) = b.at(1e-6);
            assert!(
                (a.abs() - (a0.abs() - 7200.0 * 1e-6)).abs() < 1e-6,
                "{v0} {a0}: {a}"
            );
            let (amax, jmax) = sampled(&b, 1e-5);
            assert!(amax <= a0.abs() + 1e-9 && jmax <= 7200.0 * (1.0 + 1e-9));
            // Within the limit once it is back.
            let back = (a0.abs() - 720.0) / 7200.0;
            let n = 1000;
            for k in 0..=n {
                let t = back + (b.duration() - back) * k as f64 / n as f64;
                assert!(b.at(t).2.abs() <= 720.0 * (1.0 + 1e-9), "{v0} {a0} at {t}");
            }
        }
    }

    #[test]
    fn negative_velocity_mirrors() {
        let a = Brake1d::new(5.0, 100.0, 300.0, 720.0, 7200.0);
        let b = Brake1d::new(-5.0, -100.0, -300.0, 720.0, 7200.0);
        assert_eq!(a.duration(), b.duration());
        assert!((a.stop_position() + b.stop_position()).abs() < 1e-12);
        for k in 0..50 {
            let t = k as f64 * 0.01;
            let (pa, va, aa) = a.at(t);
            let (pb, vb, ab) = b.at(t);
            assert!((pa + pb).abs() < 1e-12 && (va + vb).abs() < 1e-12 && (aa + ab).abs() < 1e-12);
        }
    }

    #[test]
    fn rest_is_nothing() {
        let b = Brake1d::new(3.0, 0.0, 0.0, 720.0, 7200.0);
        assert_eq!(b.duration(), 0.0);
        assert_eq!(b.at(0.0), (3.0, 0.0, 0.0));
        assert_eq!(b.stop_position(), 3.0);
        assert_eq!(Brake1d::default().duration(), 0.0);
    }

    #[test]
    fn degenerate_limits_and_huge_states_stay_finite() {
        let odd = [
            0.0,
            -1.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1e-300,
            1e300,
            f64::MAX,
            f64::MIN_POSITIVE,
        ];
        for &a_max in &odd {
            for &j_max in &odd {
                for (v0, a0) in [
                    (1.0, 0.0),
                    (-1e300, 1e300),
                    (f64::MAX, f64::MIN),
                    (0.0, -5.0),
                ] {
                    let b = Brake1d::new(1.0, v0, a0, a_max, j_max);
                    assert!(b.duration().is_finite() && b.duration() >= 0.0);
                    assert!(b.stop_position().is_finite(), "{a_max} {j_max} {v0} {a0}");
                    for t in [-1.0, 0.0, 0.5 * b.duration(), b.duration(), f64::NAN, 1e300] {
                        let (p, v, a) = b.at(t);
                        assert!(p.is_finite() && v.is_finite() && a.is_finite());
                    }
                }
            }
        }
    }

    proptest! {
        // Every brake: within the limits (once inside them), continuous, and at rest at its
        // end.
        #[test]
        fn every_brake_keeps_the_limits_and_ends_at_rest(
            v0 in -500.0f64..500.0, a0 in -1500.0f64..1500.0,
            a_max in 10.0f64..2000.0, j_max in 100.0f64..50_000.0,
        ) {
            let b = Brake1d::new(0.0, v0, a0, a_max, j_max);
            let d = b.duration();
            prop_assert!(d.is_finite() && d >= 0.0);
            let back = ((a0.abs() - a_max) / j_max).max(0.0);
            let n = 2000;
            let mut last = b.at(0.0);
            prop_assert_eq!(last, (0.0, v0, a0));
            for k in 1..=n {
                let t = d * k as f64 / n as f64;
                let s = b.at(t);
                let dt = d / n as f64;
                // Continuous velocity and acceleration.
                let a_between = last.2.abs().max(s.2.abs()) + j_max * dt;
                prop_assert!((s.1 - last.1).abs() <= a_between * dt * (1.0 + 1e-9) + 1e-9 * (1.0 + v0.abs()));
                prop_assert!((s.2 - last.2).abs() <= j_max * dt * (1.0 + 1e-9) + 1e-9);
                if t > back + 1e-9 {
                    prop_assert!(s.2.abs() <= a_max * (1.0 + 1e-9) + 1e-9, "a {} at {}", s.2, t);
                }
                last = s;
            }
            // At rest at the end (the closed form's rounding is all that remains).
            // (1e-12 of the duration before its end, the acceleration is still J·d·1e-12.)
            let early = d * 1e-12;
            let (p, v, a) = b.at(d - early);
            prop_assert!(v.abs() < 1e-9 * (1.0 + v0.abs() + a0.abs()) + a_max * early, "v {v}");
            prop_assert!(a.abs() < 1e-9 * (1.0 + a0.abs()) + 2.0 * j_max * early, "a {a}");
            prop_assert!((p - b.stop_position()).abs() < 1e-9 * (1.0 + b.stop_position().abs()));
        }
    }
}
