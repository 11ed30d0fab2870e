//! The timing law of a straight line under the default (`fir`) profile: how the path
//! parameter u goes from 0 to 1, as fast as every joint's velocity, acceleration and jerk
//! limits and the Cartesian line limits allow *at each point of the line*.
//!
//! # How
//!
//! Along a line the joints move as q(u), so q̇ = q′u̇, q̈ = q′ü + q″u̇², q⃛ = q′u⃛ + 3q″u̇ü +
//! q‴u̇³, with q′, q″, q‴ the exact derivatives of the inverse kinematics ([`crate::path`]).
//! At a state (u, u̇, ü) every limit is linear in the jerk u⃛, so the admissible jerks are an
//! interval, and the admissible decelerations too.
//!
//! The law is built forward in time, in steps of [`STEP_S`] with a constant jerk per step.
//! Each step takes the **largest jerk whose next state is safe**: a state is *safe* when a
//! brake from it (`brake_step`: decelerate at a fraction κ of what the limits allow there,
//! then release so that ü and u̇ reach 0 together) keeps every limit at every step and stops
//! before u = 1. The brake is simulated to the stop to decide; κ is tried from strong to
//! gentle ([`BRAKES`]). Because the brake is a feedback law of the state alone, the state it
//! reaches after one step is safe again; so from every state of a plan a controlled stop
//! along the line is known to keep every limit, and following the brake from the last safe
//! state is always possible. The largest safe jerk is looked for with short brake probes
//! (bisection, from the last step's jerk), then verified with one brake to the stop; where
//! a limit further ahead binds while the line already decelerates, the line follows its
//! verified brake. Near the end, the jerk whose brake stops on u = 1 is found by regula falsi
//! on where the brake stops (to [`LAND_TOL`]); that last brake is the line's deceleration,
//! stretched to end exactly on u = 1.
//!
//! This is a greedy (bang-bang where it can, riding the boundary of the safe set where it
//! must) approximation of the time-optimal jerk-limited path parameterisation; docs/motion.md
//! gives its measured distance from the time-optimal lower bound.
//!
//! # Time and speed override
//!
//! The law is planned at 100 % in *plan time*. A speed override p scales velocity by p,
//! acceleration by p² and jerk by p³ — exactly what playing the same law at plan time p·t
//! does — so one plan serves every override and stays within the scaled limits.
//!
//! # Stop
//!
//! A stop brakes from the present state ([`LineProfile::brake_now`]) with the time-optimal
//! brake of u along the path: the most negative jerk the limits admit *where the line is at
//! each moment* (every joint's, through the coupling terms, and the Cartesian ones) down to
//! the largest deceleration they admit, which it then tracks, and a release that brings ü
//! and u̇ to 0 together ([`STOP_BRAKES`], in steps of [`STOP_STEP_S`]). It is simulated to its
//! stop before it is taken, besides the closed-form brake of u with the limits at rest and in
//! the present state ([`Brake1d`]) and the plan's feedback brakes; the one that stops first
//! of those that keep every limit is followed — each checked from this very state, as every
//! state of a plan is. Measured against the time-optimal path brake of
//! `bench::stop::line_brake_reference` (0.1 ms simulation, the limits without the planner's
//! margin): within 2.5 % of its time and distance, plus one period, from every phase.
//! STOP brakes in plan time (played at the override); ESTOP below 100 % first rescales the law
//! to real time — its state in real time is (u, p·u̇, p²·ü) — and brakes with the limits at
//! 100 %. If nothing passes, the line brakes from the plan's next knot with the brake verified
//! there ([`LineProfile::stop`]): never later than 4 ms of plan time.
//!
//! Real-time promise: every function here is arithmetic on `Copy` values; no allocation, no
//! I/O. The state ([`LineProfile`]) is small and `Copy`: a stop needs only the state and the
//! line's derivatives, which can be computed on the spot.

use crate::brake::Brake1d;
use crate::path::{Derivs, LineAxes, CHANNELS};
use crate::settings::LineLimits;
use wrc_robot::Robot;

/// Step of the timing law in plan time [s]: u⃛ is constant over each step.
pub const STEP_S: f64 = 0.004;

/// Fewest points checked per step of the law and of its brakes where a step touches a blend
/// of a composite path or passes from one of its pieces into another ([`Derivs::fine`],
/// [`Derivs::piece`]): every millisecond of plan time, and at most [`CHECK_MM`] apart. A
/// blend may be shorter than a step (a 4 ms step at 500 mm/s is 2 mm; a corner blended
/// within 0.5 mm is shorter than that): checked at the steps' ends alone, the law passed a
/// hairpin of 0.3 mm at 440 mm/s, and a blend of a few millimetres that turns z or the hand
/// back varies its joints' third derivatives within a millimetre (checked every 2 ms the
/// jerk of a joint passed its limit by 4 % there; every millisecond, not at all on the
/// seeded random paths of `tests/motion/path.rs`). Lines and arcs vary slowly, as a line
/// does: steps within them are checked at their ends.
pub(crate) const BLEND_CHECKS: usize = 4;

/// Longest stretch of a step between two checks where [`BLEND_CHECKS`] applies [mm].
pub(crate) const CHECK_MM: f64 = 0.1;

/// Most points checked in one step.
const MAX_CHECKS: usize = 64;

/// Fraction of every limit the planner uses; the rest absorbs the interpolation of the
/// derivative table and the variation of the bounds within a step.
pub const LIMIT_MARGIN: f64 = 0.995;

/// The brakes tried, strongest first: each decelerates at this fraction κ of the
/// deceleration the limits allow where it is, and releases with κ of the jerk they allow.
pub const BRAKES: [f64; 4] = [0.97, 0.8, 0.6, 0.4];

/// A brake policy ([`brake_step`]): track the deceleration −κ·decel(u, u̇) the limits allow
/// where it is with a jerk within κ of the admissible range, then release with a constant
/// jerk that brings ü and u̇ to 0 together, from where that jerk reaches `release` times the
/// largest admissible one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Policy {
    /// κ [-].
    kappa: f64,
    /// Fraction of the largest admissible jerk the release may take [-].
    release: f64,
    /// Whether that largest jerk is also the one admissible at rest where it is (the plan's
    /// brakes, whose release must be admissible to its end); otherwise only the one where
    /// the release starts (a stop's, whose release is verified to its end).
    at_rest: bool,
    /// Step [s].
    step: f64,
}

impl Policy {
    /// A brake of the plan ([`BRAKES`]).
    const fn plan(kappa: f64) -> Policy {
        Policy {
            kappa,
            release: kappa,
            at_rest: true,
            step: STEP_S,
        }
    }

    /// A stop's brake ([`STOP_BRAKES`]).
    const fn stop(kappa: f64, release: f64, at_rest: bool) -> Policy {
        Policy {
            kappa,
            release,
            at_rest,
            step: STOP_STEP_S,
        }
    }
}

/// How many of [`STOP_BRAKES`] brake with the whole deceleration and jerk (tried first).
const STOP_FULL: usize = 2;

/// The brakes a stop tries first, strongest first ([`LineProfile::brake_now`]): the whole
/// deceleration and braking jerk the limits allow where the line is at each moment, in steps
/// of [`STOP_STEP_S`], released with all, or a little less, of the jerk allowed where the
/// release starts: the time-optimal brake of u along the path, up to the discretisation.
/// Each is simulated to its stop and kept within the bounds relaxed by [`STOP_RELAX`].
const STOP_BRAKES: [Policy; 4] = [
    Policy::stop(1.0, 1.0, false),
    Policy::stop(1.0, 1.0, true),
    Policy::stop(1.0, 0.95, true),
    Policy::stop(0.97, 0.9, true),
];

/// A stop tries the closed-form time-optimal brake of u ([`Brake1d`]) with these fractions of
/// the deceleration and jerk u may have where it is (the smaller of their values at rest and
/// in its present state), besides the feedback brakes of [`BRAKES`].
pub const CLOSED_BRAKES: [f64; 5] = [1.0, 0.95, 0.9, 0.8, 0.7];

/// Step of a stop's brake ([`STOP_BRAKES`]) [s]: the jerk is constant over each.
const STOP_STEP_S: f64 = 0.002;

/// How far a stop's brake may stray beyond the planner's bounds at a knot: half the margin
/// ([`LIMIT_MARGIN`]) between them and the limits, the rest for the variation within a step
/// and the interpolation of the derivative table.
const STOP_RELAX: f64 = 0.5 * (1.0 / LIMIT_MARGIN - 1.0);

/// Part of the velocity margin ([`LIMIT_MARGIN`]) a closed-form brake may use [-]: the plan
/// rides the velocity bound with the variation within a step above it, and a brake that
/// starts there still accelerating rises by ü²/2J more (some 1e-5 relative).
const VELOCITY_SLACK: f64 = 1e-3;

/// Longest interval between two checks of a closed-form brake [s] (half a plan step; every
/// phase boundary is checked too).
const CHECK_S: f64 = STEP_S / 2.0;

/// How close to u = 1 the search for the last brake of a line brings its stop; the law then
/// stretches that brake onto u = 1 (by at most this fraction).
const LAND_TOL: f64 = 1e-6;

/// How far past u = 1 a brake may stop and still count as stopping at the end (rounding).
const END_TOL: f64 = 1e-12;

/// Bisection steps on the jerk when the largest admissible jerk is not safe.
const BISECTIONS: usize = 6;

/// Most steps of the search for the jerk whose brake stops on u = 1.
const LANDING_STEPS: usize = 30;

/// Most steps a brake may take before it counts as failed [steps] (60 s of plan time).
const MAX_BRAKE_STEPS: usize = 15_000;

/// How close above the release curve a brake starts its release (relative) [-].
const RELEASE_BAND: f64 = 1e-3;

/// A speed this small counts as standing still [1/s].
const REST_V: f64 = 1e-12;

/// The limits of a path's axes and of its TCP, as bounds on u's derivatives, at 100 % and
/// times [`LIMIT_MARGIN`]: per channel of the derivative rows (each moving axis, and on a
/// composite path the TCP's speed along it), the Cartesian limits of a straight line as
/// constant bounds of u, and the centripetal acceleration of a composite path's TCP.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Bounds {
    n: usize,
    v: [f64; CHANNELS],
    a: [f64; CHANNELS],
    j: [f64; CHANNELS],
    /// A straight line's Cartesian limits in u units (∞ for a line of no length, and for a
    /// composite path, whose TCP is a channel) [1/s, 1/s², 1/s³].
    cv: f64,
    ca: f64,
    cj: f64,
    /// Bound of [`Derivs::dn`]·u̇: the square root of the largest centripetal acceleration
    /// of the TCP [√(mm/s²)] (∞ on a straight line).
    cn: f64,
    /// The acceleration override the acceleration and jerk bounds are scaled by (0, 1].
    accel: f64,
    /// A composite path's length per unit of u [mm] (0 on a straight line): a step that
    /// touches a blend or crosses from one piece into another ([`Derivs::fine`],
    /// [`Derivs::piece`]) is checked every [`CHECK_MM`] of it, and closed-form brakes
    /// [`BLEND_CHECKS`] times as often as on a line.
    path_mm: f64,
    /// Where the motion must end [u]: every brake stops by it, and the law lands on it. 1,
    /// or less on a path continued past its end whose law must stop at the path's end
    /// ([`Bounds::ending_at`]).
    end: f64,
}

impl Bounds {
    pub(crate) fn new(robot: &Robot, axes: &LineAxes, line: &LineLimits, length_mm: f64) -> Self {
        let mut b = Bounds {
            n: axes.n,
            v: [0.0; CHANNELS],
            a: [0.0; CHANNELS],
            j: [0.0; CHANNELS],
            cv: f64::INFINITY,
            ca: f64::INFINITY,
            cj: f64::INFINITY,
            cn: f64::INFINITY,
            accel: 1.0,
            path_mm: 0.0,
            end: 1.0,
        };
        for k in 0..axes.n {
            let l = &robot.axes()[axes.idx[k]].limits;
            b.v[k] = l.max_velocity * LIMIT_MARGIN;
            b.a[k] = l.max_acceleration * LIMIT_MARGIN;
            b.j[k] = l.max_jerk * LIMIT_MARGIN;
        }
        if length_mm > 0.0 {
            b.cv = line.max_speed_mm_s * LIMIT_MARGIN / length_mm;
            b.ca = line.max_accel_mm_s2 * LIMIT_MARGIN / length_mm;
            b.cj = line.max_jerk_mm_s3 * LIMIT_MARGIN / length_mm;
        }
        b
    }

    /// The bounds of a composite path ([`crate::geometry::Geometry::Curve`]): every moving
    /// axis, then the TCP's speed, tangential acceleration and jerk along the path within
    /// the line limits, and its centripetal acceleration within the line acceleration limit.
    pub(crate) fn for_path(
        robot: &Robot,
        axes: &LineAxes,
        line: &LineLimits,
        length_mm: f64,
    ) -> Self {
        let mut b = Bounds::new(robot, axes, line, 0.0);
        let k = axes.n;
        b.n = k + 1;
        b.v[k] = line.max_speed_mm_s * LIMIT_MARGIN;
        b.a[k] = line.max_accel_mm_s2 * LIMIT_MARGIN;
        b.j[k] = line.max_jerk_mm_s3 * LIMIT_MARGIN;
        b.cn = (line.max_accel_mm_s2 * LIMIT_MARGIN).sqrt();
        b.path_mm = length_mm.max(1e-9);
        b
    }

    /// These bounds with every acceleration and jerk bound (each axis's and the TCP's)
    /// times `accel` in (0, 1]: the acceleration override a move is planned with.
    pub(crate) fn with_accel(&self, accel: f64) -> Bounds {
        let f = accel / self.accel;
        Bounds {
            a: self.a.map(|x| x * f),
            j: self.j.map(|x| x * f),
            ca: self.ca * f,
            cj: self.cj * f,
            cn: self.cn * f.sqrt(),
            accel,
            ..*self
        }
    }

    /// These bounds with the motion ending at `end` [u] in (0, 1] instead of 1: a path
    /// continued past its end (room for the brakes of a path that flows into a PTP) whose
    /// law must stop at the path's end, or within part of the continuation.
    pub(crate) fn ending_at(&self, end: f64) -> Bounds {
        Bounds { end, ..*self }
    }

    /// These bounds without the acceleration override: what a stop brakes with.
    pub(crate) fn full_accel(&self) -> Bounds {
        if self.accel == 1.0 {
            *self
        } else {
            self.with_accel(1.0)
        }
    }

    /// These bounds loosened by the factor 1 + `by`.
    fn relaxed(&self, by: f64) -> Bounds {
        let f = 1.0 + by;
        Bounds {
            n: self.n,
            v: self.v.map(|x| x * f),
            a: self.a.map(|x| x * f),
            j: self.j.map(|x| x * f),
            cv: self.cv * f,
            ca: self.ca * f,
            cj: self.cj * f,
            cn: self.cn * f.sqrt(),
            accel: self.accel,
            path_mm: self.path_mm,
            end: self.end,
        }
    }

    /// Whether the states strictly inside a step of `dt` at jerk `j` from (u, v, a), whose
    /// derivatives at its ends are `ends`, keep every limit. On a composite path, a step that
    /// touches a blend or passes from one piece into another is checked every [`CHECK_MM`]
    /// of its length (at least [`BLEND_CHECKS`] − 1 points, at most [`MAX_CHECKS`]); a piece
    /// shorter than a step would otherwise pass unseen between its ends. Elsewhere, and on a
    /// straight line, only the end of each step is checked, by the law itself.
    #[inline]
    fn ok_within(
        &self,
        derivs: &impl Fn(f64) -> Derivs,
        (u, v, a): (f64, f64, f64),
        j: f64,
        dt: f64,
        ends: (&Derivs, &Derivs),
    ) -> bool {
        if self.path_mm == 0.0 || !(ends.0.fine || ends.1.fine || ends.0.piece != ends.1.piece) {
            return true;
        }
        let (un, ..) = advance(u, v, a, j, dt);
        let mm = (un - u).abs() * self.path_mm;
        let sub = ((mm / CHECK_MM).ceil() as usize).clamp(BLEND_CHECKS, MAX_CHECKS);
        (1..sub).all(|i| {
            let (ui, vi, ai) = advance(u, v, a, j, dt * i as f64 / sub as f64);
            self.ok(&derivs(ui), vi.max(0.0), ai, j)
        })
    }

    /// Whether the state (v = u̇ ≥ 0, a = ü) with jerk j = u⃛ keeps every limit.
    #[inline]
    fn ok(&self, d: &Derivs, v: f64, a: f64, j: f64) -> bool {
        if v > self.cv || a.abs() > self.ca || j.abs() > self.cj || d.dn * v > self.cn {
            return false;
        }
        let v2 = v * v;
        for k in 0..self.n {
            let (d1, d2, d3) = (d.d1[k], d.d2[k], d.d3[k]);
            if d1.abs() * v > self.v[k]
                || (d1 * a + d2 * v2).abs() > self.a[k]
                || (d1 * j + 3.0 * d2 * v * a + d3 * v2 * v).abs() > self.j[k]
            {
                return false;
            }
        }
        true
    }

    /// Whether jerk `j` keeps every jerk limit at (v, a) (the velocity and acceleration
    /// there already checked).
    #[inline]
    fn jerk_ok(&self, d: &Derivs, v: f64, a: f64, j: f64) -> bool {
        if j.abs() > self.cj {
            return false;
        }
        let v2 = v * v;
        (0..self.n)
            .all(|k| (d.d1[k] * j + 3.0 * d.d2[k] * v * a + d.d3[k] * v2 * v).abs() <= self.j[k])
    }

    /// The largest admissible acceleration at rest (u̇ = 0) where the derivatives are `d`.
    #[inline]
    fn accel_at_rest(&self, d: &Derivs) -> f64 {
        let mut hi = self.ca;
        for k in 0..self.n {
            let d1 = d.d1[k].abs();
            if d1 >= 1e-9 {
                hi = hi.min(self.a[k] / d1);
            }
        }
        hi
    }

    /// The largest admissible jerk at rest (u̇ = ü = 0) where the derivatives are `d`.
    #[inline]
    fn jerk_hi_at_rest(&self, d: &Derivs) -> f64 {
        let mut hi = self.cj;
        for k in 0..self.n {
            let d1 = d.d1[k].abs();
            if d1 >= 1e-9 {
                hi = hi.min(self.j[k] / d1);
            }
        }
        hi
    }

    /// The admissible jerks u⃛ at (v, a): an interval, empty when lo > hi.
    #[inline]
    fn jerk_range(&self, d: &Derivs, v: f64, a: f64) -> (f64, f64) {
        let (mut lo, mut hi) = (-self.cj, self.cj);
        let v2 = v * v;
        for k in 0..self.n {
            let c = 3.0 * d.d2[k] * v * a + d.d3[k] * v2 * v;
            let d1 = d.d1[k];
            if d1.abs() < 1e-9 {
                if c.abs() > self.j[k] {
                    return (1.0, -1.0);
                }
                continue;
            }
            let (l, h) = ((-self.j[k] - c) / d1, (self.j[k] - c) / d1);
            let (l, h) = if l <= h { (l, h) } else { (h, l) };
            lo = lo.max(l);
            hi = hi.min(h);
        }
        (lo, hi)
    }

    /// The accelerations ü the limits admit at speed v, lowest and highest: every joint's
    /// acceleration limit against its centripetal term q″·v², and the Cartesian one. The
    /// highest is negative where the state must decelerate, the lowest positive where it
    /// must accelerate.
    #[inline]
    fn accel_range(&self, d: &Derivs, v: f64) -> (f64, f64) {
        let (mut lo, mut hi) = (-self.ca, self.ca);
        let v2 = v * v;
        for k in 0..self.n {
            let d1 = d.d1[k];
            if d1.abs() < 1e-9 {
                continue;
            }
            let c = d.d2[k] * v2;
            let (l, h) = ((-self.a[k] - c) / d1, (self.a[k] - c) / d1);
            lo = lo.max(l.min(h));
            hi = hi.min(l.max(h));
        }
        (lo, hi)
    }

    /// The largest acceleration ü the limits admit at speed v (negative: the state must
    /// decelerate).
    #[inline]
    fn accel(&self, d: &Derivs, v: f64) -> f64 {
        self.accel_range(d, v).1
    }

    /// The fastest speed u̇ [1/s] admissible with no acceleration of u where the derivatives
    /// are `d`: every joint's and the TCP's velocity limit, the centripetal acceleration, and
    /// every joint's acceleration limit against its centripetal term q″·u̇²; ∞ where nothing
    /// bounds it.
    #[inline]
    fn speed(&self, d: &Derivs) -> f64 {
        let mut v = self.cv;
        if d.dn > 1e-12 {
            v = v.min(self.cn / d.dn);
        }
        for k in 0..self.n {
            if d.d1[k].abs() >= 1e-9 {
                v = v.min(self.v[k] / d.d1[k].abs());
            }
            if d.d2[k].abs() >= 1e-12 {
                v = v.min((self.a[k] / d.d2[k].abs()).sqrt());
            }
        }
        v
    }

    /// The largest deceleration −ü the limits admit at speed v (negative: the state must
    /// accelerate).
    #[inline]
    fn decel(&self, d: &Derivs, v: f64) -> f64 {
        -self.accel_range(d, v).0
    }
}

/// Most steps of [`estimate_time`] (60 s of plan time).
const ESTIMATE_STEPS: usize = 15_000;

/// An estimate of the plan time [s] the law takes from u = 0, entered at speed `v0` [1/s]
/// with no acceleration, to u = `to`, without running it: a forward integration in steps of
/// [`STEP_S`] that accelerates as hard as every acceleration limit allows at the present
/// speed (the coupling term q″u̇² included), changing the acceleration with the jerk
/// admissible at rest, up to the speed admissible with no acceleration where it is
/// ([`Bounds::speed`]: velocity limits, centripetal terms), and held to it where that speed
/// drops; near the end, under the speed from which a jerk-limited brake with the limits
/// there stops on it. Nothing is verified: it compares entries into a path
/// ([`crate::VelocityGenerator::plan_ptp_into`]), whose laws differ, once they have met,
/// by about what their estimates differ (docs/motion.md: how often it picks another entry
/// than the laws themselves would). About 2 derivative rows per step, no allocation;
/// ∞ if it does not get there within 60 s.
pub(crate) fn estimate_time(b: &Bounds, derivs: &impl Fn(f64) -> Derivs, v0: f64, to: f64) -> f64 {
    let h = STEP_S;
    // The speed from which the time-optimal brake with deceleration `a` and jerk `j`,
    // decelerating at `a` already, stops within `rem`: at `a` down to a²/2j, then the jerk
    // brings the deceleration and the speed to 0 together (a³/6j² of the way).
    let brake_speed = |rem: f64, a: f64, j: f64| {
        let rem = rem.max(0.0);
        let tail = a * a * a / (6.0 * j * j);
        if !(a > 0.0 && j > 0.0) {
            f64::INFINITY
        } else if rem >= tail {
            let v1 = a * a / (2.0 * j);
            (2.0 * a * (rem - tail) + v1 * v1).sqrt()
        } else {
            (3.0 * rem * j.sqrt() / std::f64::consts::SQRT_2).powf(2.0 / 3.0)
        }
    };
    let cap = |d: &Derivs, u: f64| {
        let v = b.speed(d);
        if to >= b.end {
            v.min(brake_speed(
                to - u,
                b.accel_at_rest(d),
                b.jerk_hi_at_rest(d),
            ))
        } else {
            v
        }
    };
    let (mut u, mut v, mut a, mut t) = (0.0f64, v0.max(0.0), 0.0f64, 0.0f64);
    let mut d = derivs(u);
    for _ in 0..ESTIMATE_STEPS {
        if u >= to {
            return t;
        }
        let j = b.jerk_hi_at_rest(&d);
        // Accelerate as hard as allowed, easing off so as to reach the admissible speed
        // with no acceleration left.
        let room = (cap(&d, u) - v).max(0.0);
        let target = b.accel(&d, v).max(0.0).min((2.0 * j * room).sqrt());
        let an = target.clamp(a - j * h, a + j * h);
        let vn = v + 0.5 * (a + an) * h;
        let un = u + 0.5 * (v + vn) * h;
        if un >= to {
            return t + h * (to - u) / (un - u);
        }
        d = derivs(un);
        let held = vn.min(cap(&d, un)).max(0.0);
        if un <= u {
            break;
        }
        (u, v, a, t) = (un, held, if held < vn { an.min(0.0) } else { an }, t + h);
    }
    f64::INFINITY
}

/// Position, velocity and acceleration after `dt` [s] at constant jerk `j` (of u here, of
/// an axis in a blended approach's first part).
#[inline]
pub(crate) fn advance(u: f64, v: f64, a: f64, j: f64, dt: f64) -> (f64, f64, f64) {
    (
        u + dt * (v + dt * (0.5 * a + dt * j / 6.0)),
        v + dt * (a + 0.5 * dt * j),
        a + dt * j,
    )
}

/// One step of the brake policy.
#[derive(Debug, Clone, Copy, PartialEq)]
enum BrakeStep {
    /// Standing still.
    Rest,
    /// Apply this jerk for `dt` (≤ one step; shorter when the release starts within it).
    Jerk { jerk: f64, dt: f64 },
    /// Apply this jerk for `dt` (≤ one step): ü and u̇ reach 0 together.
    Land { jerk: f64, dt: f64 },
    /// The brake cannot keep the limits from this state.
    Fail,
}

/// The brake policy with strength `kappa` at (v, a), the derivatives `d` where it is: track
/// the deceleration −κ·decel(u, v) with a jerk within κ of the admissible range, and release
/// — a constant jerk a²/2v that brings ü and u̇ to 0 together — from the instant u̇ reaches
/// ü²/(2·κ·j_max) (the release curve). The release may start within a step, which then ends
/// there, so where the brake stops depends continuously on where it starts.
#[inline]
fn brake_step(b: &Bounds, d: &Derivs, v: f64, a: f64, policy: &Policy) -> BrakeStep {
    let Policy {
        kappa,
        release,
        at_rest,
        step: h,
    } = *policy;
    if v <= REST_V && a.abs() <= 1e-9 {
        return BrakeStep::Rest;
    }
    let (lo, hi) = b.jerk_range(d, v, a);
    if lo > hi || hi <= 0.0 {
        return BrakeStep::Fail;
    }
    // The release's jerk is constant while the admissible range moves from its value here
    // to its value at rest: keep within both.
    let cap = release
        * if at_rest {
            hi.min(b.jerk_hi_at_rest(d))
        } else {
            hi
        };
    // On (or below) the release curve: release now. The curve moves a little with the
    // state (cap does), so "on" means within 0.1 %: the release jerk is then at most cap
    // plus 0.1 %, still inside the admissible range.
    if a < 0.0 && v <= a * a / (2.0 * cap) * (1.0 + RELEASE_BAND) {
        if v <= 0.0 {
            return BrakeStep::Fail;
        }
        let jr = a * a / (2.0 * v);
        if jr > hi {
            return BrakeStep::Fail;
        }
        let t = -a / jr;
        return if t <= h {
            BrakeStep::Land { jerk: jr, dt: t }
        } else {
            BrakeStep::Jerk { jerk: jr, dt: h }
        };
    }
    let decel = b.decel(d, v);
    if decel <= 0.0 {
        return BrakeStep::Fail;
    }
    let jt = ((-kappa * decel - a) / h).clamp(kappa * lo.min(0.0), cap);
    // Does the tracking step reach the release curve, g(τ) = u̇(τ) − ü(τ)²/2cap = 0 with
    // ü(τ) < 0, within the step? g is a quadratic in τ.
    let (qa, qb, qc) = (
        0.5 * jt - jt * jt / (2.0 * cap),
        a - a * jt / cap,
        v - a * a / (2.0 * cap),
    );
    let mut hit = f64::INFINITY;
    let mut consider = |tau: f64| {
        if tau > 0.0 && tau <= h && a + jt * tau < 0.0 {
            hit = hit.min(tau);
        }
    };
    // Both roots without cancellation (q = −(b + sign(b)·√disc)/2; roots q/a and c/q), so a
    // nearly constant deceleration (a ≈ 0) still finds the linear root.
    let disc = qb * qb - 4.0 * qa * qc;
    if disc >= 0.0 {
        let q = -0.5 * (qb + qb.signum() * disc.sqrt());
        if q != 0.0 {
            consider(qc / q);
        }
        if qa != 0.0 {
            consider(q / qa);
        }
    }
    BrakeStep::Jerk {
        jerk: jt,
        dt: if hit.is_finite() { hit } else { h },
    }
}

/// Why a state is not safe.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Unsafe {
    /// The brake would stop beyond u = 1, at this u (the path continued straight on).
    Overshoot(f64),
    /// A limit would be exceeded.
    Limit,
}

/// How far a brake is simulated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Horizon {
    /// To its stop: the verdict on the state.
    Full,
    /// Until its speed has been falling for a few steps: catches what the next moments
    /// decide (an acceleration or speed limit, a jerk too large to come back from), cheaply.
    Short,
}

/// Steps a short probe goes on after the brake's speed has started to fall.
const SHORT_AFTER_PEAK: usize = 3;

/// Simulate the brake `policy` within the bounds `b` from (u, v, a), checking every limit of
/// `check` at every step: to its stop (`Some(where)`), or for a short horizon (`None` when
/// nothing failed in it).
fn brake_stop(
    (b, check): (&Bounds, &Bounds),
    derivs: &impl Fn(f64) -> Derivs,
    (mut u, mut v, mut a): (f64, f64, f64),
    policy: &Policy,
    horizon: Horizon,
) -> Result<Option<f64>, Unsafe> {
    let mut d = derivs(u);
    let mut falling = 0;
    let end = b.end + END_TOL;
    let mut beyond = u > end;
    for _ in 0..MAX_BRAKE_STEPS {
        let (j, dt, last) = match brake_step(b, &d, v, a, policy) {
            BrakeStep::Rest => break,
            BrakeStep::Fail => return Err(Unsafe::Limit),
            BrakeStep::Jerk { jerk, dt } => (jerk, dt, false),
            BrakeStep::Land { jerk, dt } => (jerk, dt, true),
        };
        // The jerk changes at the knot: it must be admissible there too.
        if !check.jerk_ok(&d, v, a, j) {
            return Err(Unsafe::Limit);
        }
        let (un, vn, an) = step_to(u, v, a, j, dt);
        // Past the end the brake is followed on (the derivatives of the end) only to learn
        // where it would stop.
        beyond |= un > end;
        if vn < -1e-9 {
            return Err(Unsafe::Limit);
        }
        let start = d;
        d = derivs(un);
        if !check.ok(&d, vn, an, j) || !check.ok_within(derivs, (u, v, a), j, dt, (&start, &d)) {
            return Err(Unsafe::Limit);
        }
        (u, v, a) = (un, vn.max(0.0), an);
        if last {
            break;
        }
        if horizon == Horizon::Short && a < 0.0 && !beyond {
            falling += 1;
            if falling > SHORT_AFTER_PEAK {
                return Ok(None);
            }
        }
    }
    if beyond {
        Err(Unsafe::Overshoot(u))
    } else if v <= REST_V {
        Ok(Some(u))
    } else {
        Err(Unsafe::Limit)
    }
}

/// The state after a step of `dt` [s] at jerk `j`, as both the plan and its brakes compute
/// it (so that a brake followed reproduces the one verified, bit for bit).
#[inline]
fn step_to(u: f64, v: f64, a: f64, j: f64, dt: f64) -> (f64, f64, f64) {
    advance(u, v, a, j, dt)
}

/// Whether (u, v, a) is safe: a brake of [`BRAKES`] (those from index `brakes.0` to
/// `brakes.1`, strongest first) that keeps every limit to its stop (or over a short
/// horizon), and where it stops. A brake that overshoots u = 1 ends the search, since a
/// weaker one stops later still.
fn safe(
    b: &Bounds,
    derivs: &impl Fn(f64) -> Derivs,
    state: (f64, f64, f64),
    brakes: (usize, usize),
    horizon: Horizon,
) -> Result<(u8, Option<f64>), Unsafe> {
    for (i, &kappa) in BRAKES.iter().enumerate().take(brakes.1 + 1).skip(brakes.0) {
        match brake_stop((b, b), derivs, state, &Policy::plan(kappa), horizon) {
            Ok(stop) => return Ok((i as u8, stop)),
            Err(Unsafe::Overshoot(at)) => return Err(Unsafe::Overshoot(at)),
            Err(Unsafe::Limit) => {}
        }
    }
    Err(Unsafe::Limit)
}

/// The bisection for the largest jerk that passes a probe: passes at `lo`, not at `hi`.
struct JerkSearch {
    lo: f64,
    hi: f64,
    /// The largest jerk that passed, its brake and where that brake stops (if simulated to
    /// the stop).
    best: Option<(f64, u8, Option<f64>)>,
}

impl JerkSearch {
    fn new(lo: f64, hi: f64) -> JerkSearch {
        JerkSearch { lo, hi, best: None }
    }

    fn probe(&mut self, j: f64, probe: &impl Fn(f64) -> Result<(u8, Option<f64>), Unsafe>) {
        match probe(j) {
            Ok((k, stop)) => {
                self.lo = j;
                self.best = Some((j, k, stop));
            }
            Err(_) => self.hi = j,
        }
    }

    fn bisect(&mut self, probe: &impl Fn(f64) -> Result<(u8, Option<f64>), Unsafe>) {
        self.probe(0.5 * (self.lo + self.hi), probe);
    }
}

/// What the timing law is doing.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    /// Following the plan.
    Forward,
    /// A stop was requested: from the next knot on, the brake.
    Stopping,
    /// A stop was requested: the brake [`STOP_BRAKES`]`[brake]`, from the last knot on.
    Braking { brake: u8 },
    /// A stop was requested: the closed-form brake `brake`, started at time `from` [s] and
    /// checked along its whole length.
    Closed { from: f64, brake: Brake1d },
    /// At rest for good at `u`.
    Done,
    /// Stopped before choosing the step from the last knot, the first whose search looked
    /// past the end ([`LineProfile::start_watched`]); `last` is the jerk of the step
    /// before. The step from the knot is its verified brake until
    /// [`LineProfile::resume`] chooses again.
    Junction { last: f64 },
}

/// The state of a line's timing law: the last knot (plan time t, u, u̇, ü), the jerk and
/// length of the step from it, the brake that the next knot was verified with and where
/// that brake stops, the final landing, and the mode. `Copy` and small, so a real-time task
/// can keep one per period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LineProfile {
    t: f64,
    u: f64,
    v: f64,
    a: f64,
    jerk: f64,
    dt: f64,
    /// Index into [`BRAKES`] of the brake verified from the knot at t + dt.
    brake: u8,
    /// Where that brake stops.
    brake_stop: f64,
    /// The step from this knot ends the motion (a brake lands).
    ends: bool,
    /// The final landing, once the line follows its last brake: from u = `land.0` on, u is
    /// played stretched so that this brake's stop `land.1` (within [`LAND_TOL`] of 1) falls
    /// exactly on 1.
    land: Option<(f64, f64)>,
    mode: Mode,
    /// A brake from [`LineProfile::brake_now`] is under way: it was verified with the
    /// derivatives it was given there, so it must be followed with the same ones.
    braked_now: bool,
    /// Watched: the law stops at the first knot whose search looks past the end
    /// ([`LineProfile::start_watched`]).
    junction: bool,
}

impl LineProfile {
    /// A law at rest at u = 0, planned from there.
    pub(crate) fn start(b: &Bounds, derivs: &impl Fn(f64) -> Derivs) -> LineProfile {
        LineProfile::begin(b, derivs, false)
    }

    /// A law at rest at u = 0, watched for its junction or not.
    fn begin(b: &Bounds, derivs: &impl Fn(f64) -> Derivs, junction: bool) -> LineProfile {
        let mut p = LineProfile {
            t: 0.0,
            u: 0.0,
            v: 0.0,
            a: 0.0,
            jerk: 0.0,
            dt: STEP_S,
            brake: 0,
            brake_stop: 0.0,
            ends: false,
            land: None,
            mode: Mode::Forward,
            braked_now: false,
            junction,
        };
        p.choose(b, derivs);
        p
    }

    /// [`LineProfile::start`], watched: the law stops at the first knot from which the
    /// search for its next step looks past the end — where a brake of a candidate step would
    /// reach it — and waits there ([`LineProfile::at_junction`]) until
    /// [`LineProfile::resume`]. Up to that knot the law is the same whatever lies past the
    /// end and wherever the end is beyond it, to the bit: no step of it depended on either.
    /// So a path that may flow into a PTP is planned to rest at its end, and decides how it
    /// leaves only there: with the end moved further along its continuation, or not.
    pub(crate) fn start_watched(b: &Bounds, derivs: &impl Fn(f64) -> Derivs) -> LineProfile {
        LineProfile::begin(b, derivs, true)
    }

    /// Whether the law waits at its junction ([`LineProfile::start_watched`]).
    pub(crate) fn at_junction(&self) -> bool {
        matches!(self.mode, Mode::Junction { .. })
    }

    /// Go on from the junction with the bounds `b` (whose end may differ from the one it
    /// was watched with), no longer watched: the step from the junction's knot is chosen
    /// as it would have been had the law been planned with `b` from its start.
    pub(crate) fn resume(&mut self, b: &Bounds, derivs: &impl Fn(f64) -> Derivs) {
        if let Mode::Junction { last } = self.mode {
            self.mode = Mode::Forward;
            self.junction = false;
            self.jerk = last;
            self.choose(b, derivs);
        }
    }

    /// A law that starts at u = 0 already moving, at speed `v0` [1/s] with no acceleration
    /// (a blended transfer's straight line in, entered at speed: docs/motion.md), planned from
    /// there; `None` unless that state keeps every limit and a brake from it stops before
    /// u = 1 within them.
    pub(crate) fn start_moving(
        b: &Bounds,
        derivs: &impl Fn(f64) -> Derivs,
        v0: f64,
    ) -> Option<LineProfile> {
        if !(v0 > 0.0 && v0.is_finite() && b.ok(&derivs(0.0), v0, 0.0, 0.0)) {
            return None;
        }
        let (brake, stop) = safe(
            b,
            derivs,
            (0.0, v0, 0.0),
            (0, BRAKES.len() - 1),
            Horizon::Full,
        )
        .ok()?;
        let stop = stop.filter(|s| *s <= b.end)?;
        let mut p = LineProfile {
            t: 0.0,
            u: 0.0,
            v: v0,
            a: 0.0,
            jerk: 0.0,
            dt: STEP_S,
            brake,
            brake_stop: stop,
            ends: false,
            land: None,
            mode: Mode::Forward,
            braked_now: false,
            junction: false,
        };
        p.choose(b, derivs);
        Some(p)
    }

    /// The fastest speed u̇ [1/s] at which the line may be entered at u = 0 with no
    /// acceleration of u: every joint's and the TCP's velocity limit, and every joint's
    /// acceleration limit against the centripetal term q″·u̇².
    pub(crate) fn entry_speed(b: &Bounds, derivs: &impl Fn(f64) -> Derivs) -> f64 {
        let v = b.speed(&derivs(0.0));
        if v.is_finite() {
            v
        } else {
            0.0
        }
    }

    /// Whether a brake taken by [`LineProfile::brake_now`] is under way (or has ended the
    /// motion): the law must then be played with the derivatives given to `brake_now` (those
    /// it was verified with), not the plan's.
    pub(crate) fn braked_now(&self) -> bool {
        self.braked_now
    }

    /// Whether the motion has come to rest for good.
    pub(crate) fn done(&self) -> bool {
        self.mode == Mode::Done
    }

    /// Whether it came to rest at u = 1 (not stopped short).
    pub(crate) fn completed(&self) -> bool {
        self.mode == Mode::Done && self.land.is_some_and(|(_, stop)| self.u >= stop)
    }

    /// u at plan time `t` [s] (≥ the last knot's), moving the knots forward as needed.
    pub(crate) fn at(&mut self, b: &Bounds, derivs: &impl Fn(f64) -> Derivs, t: f64) -> f64 {
        self.advance_to(b, derivs, t);
        let u = self.state(t).0;
        match self.land {
            // u + (1 − stop)·x⁴ with x the fraction of the last brake done: the brake ends on
            // u = 1, and u, u̇ and ü stay continuous where the stretch begins (the added
            // derivatives are of the order of 1 − stop ≤ LAND_TOL relative).
            Some((from, stop)) if u > from && stop > from => {
                let x = ((u - from) / (stop - from)).min(1.0);
                (u + (b.end - stop) * x * x * x * x).min(b.end)
            }
            _ => u,
        }
    }

    /// Advance the law to where u first reaches `target` (a path's end, where a blended move
    /// leaves it for a PTP): the plan time [s] and (u, u̇, ü) there; `None` if the law comes
    /// to rest before. Searches in quarter steps, then by bisection within one (the law
    /// between two knots is a cubic, evaluated without new knots).
    pub(crate) fn time_at(
        &mut self,
        b: &Bounds,
        derivs: &impl Fn(f64) -> Derivs,
        target: f64,
    ) -> Option<(f64, (f64, f64, f64))> {
        self.time_at_while(b, derivs, target, &|| true)
    }

    /// [`LineProfile::time_at`] while `more()` says so (checked every quarter step: a budget
    /// of work); `None` when it does not.
    pub(crate) fn time_at_while(
        &mut self,
        b: &Bounds,
        derivs: &impl Fn(f64) -> Derivs,
        target: f64,
        more: &impl Fn() -> bool,
    ) -> Option<(f64, (f64, f64, f64))> {
        let h = STEP_S / 4.0;
        let mut t = self.t;
        for _ in 0..4 * MAX_BRAKE_STEPS {
            if !more() {
                return None;
            }
            let before = *self;
            if self.at(b, derivs, t + h) >= target {
                let after = *self;
                let u_at = |x: f64| {
                    let mut p = if x >= after.t { after } else { before };
                    p.at(b, derivs, x)
                };
                let (mut lo, mut hi) = (t, t + h);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if u_at(mid) >= target {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                let mut p = if hi >= after.t { after } else { before };
                p.at(b, derivs, hi);
                let (_, v, a) = p.state(hi);
                return Some((hi, (u_at(hi), v, a)));
            }
            if self.done() || self.at_junction() {
                return None;
            }
            t += h;
        }
        None
    }

    /// Run the law to its end; returns the plan time at which it comes to rest [s].
    pub(crate) fn run_to_end(&mut self, b: &Bounds, derivs: &impl Fn(f64) -> Derivs) -> f64 {
        self.advance_to(b, derivs, f64::INFINITY);
        self.t
    }

    /// [`LineProfile::run_to_end`] knot by knot while `more()` says so (a budget of work):
    /// the plan time at which it comes to rest [s], or `None` when `more()` ends it first or
    /// the law waits at its junction.
    pub(crate) fn run_to_end_while(
        &mut self,
        b: &Bounds,
        derivs: &impl Fn(f64) -> Derivs,
        more: &impl Fn() -> bool,
    ) -> Option<f64> {
        for _ in 0..4 * MAX_BRAKE_STEPS {
            if self.done() {
                return Some(self.t);
            }
            if self.at_junction() || !more() {
                return None;
            }
            let next = match self.mode {
                Mode::Closed { .. } => f64::INFINITY,
                _ => self.t + self.dt,
            };
            self.advance_to(b, derivs, next);
        }
        None
    }

    /// Move the last knot up to time `t` [s] (the knot at or before it, or the rest).
    fn advance_to(&mut self, b: &Bounds, derivs: &impl Fn(f64) -> Derivs, t: f64) {
        loop {
            match self.mode {
                Mode::Done => return,
                Mode::Closed { from, brake } => {
                    if t >= from + brake.duration() {
                        (self.t, self.u, self.v, self.a) =
                            (from + brake.duration(), brake.stop_position(), 0.0, 0.0);
                        self.mode = Mode::Done;
                    }
                    return;
                }
                Mode::Forward | Mode::Stopping | Mode::Braking { .. } if t >= self.t + self.dt => {
                    self.next_knot(b, derivs)
                }
                Mode::Forward | Mode::Stopping | Mode::Braking { .. } | Mode::Junction { .. } => {
                    return
                }
            }
        }
    }

    /// Request a controlled stop: the current step ends at its knot, then the brake that was
    /// verified from that knot takes the line to rest (on the line, within every limit).
    pub(crate) fn stop(&mut self) {
        if matches!(self.mode, Mode::Forward | Mode::Junction { .. }) {
            self.mode = Mode::Stopping;
        }
    }

    /// Whether the law still follows its plan, up to its final landing on u = 1 (no stop
    /// requested, not at rest).
    pub(crate) fn is_forward(&self) -> bool {
        self.mode == Mode::Forward
    }

    /// u, u̇ and ü at plan time `t` [s] (from the last knot, which [`LineProfile::at`] has
    /// brought up to `t`) [1, 1/s, 1/s²]; u without the final landing's stretch (at most
    /// [`LAND_TOL`]).
    pub(crate) fn state(&self, t: f64) -> (f64, f64, f64) {
        match self.mode {
            Mode::Done => (self.u, 0.0, 0.0),
            Mode::Closed { from, brake } => brake.at(t - from),
            Mode::Forward | Mode::Stopping | Mode::Braking { .. } | Mode::Junction { .. } => {
                let (u, v, a) = step_to(self.u, self.v, self.a, self.jerk, t - self.t);
                (u, v.max(0.0), a)
            }
        }
    }

    /// Brake now, from the state at law time `t` [s] multiplied by `scale` (u, scale·u̇,
    /// scale²·ü), with the limits at 100 %; the brake's time starts at `t_new` [s].
    ///
    /// - A stop (STOP, at any override): `scale` = 1 and `t_new` = `t`, both in plan time.
    /// - A stop with the full limits below 100 % (ESTOP): the law played at `scale` is at plan
    ///   time `t` and real time `t_new`; the state in real time is the rescaled one. From
    ///   then on the law runs in real time, so [`LineProfile::at`] must be called with real
    ///   time (the caller's scale becomes 1).
    ///
    /// The candidates: the stop's brakes of [`STOP_BRAKES`] (the time-optimal brake of u along
    /// the path, with the deceleration and jerk the limits allow where the line is at each
    /// step), each simulated to its stop with every knot within the bounds relaxed by
    /// [`STOP_RELAX`]; the closed-form time-optimal brake of u ([`Brake1d`]) with the
    /// deceleration and jerk u may have where it is (at [`CLOSED_BRAKES`] of them), checked
    /// against every joint and Cartesian limit along its whole length (every [`CHECK_S`] and
    /// at every phase boundary); and the strongest feedback brake of [`BRAKES`] that keeps
    /// every limit, simulated to its stop as every state of a plan is verified. All stop by
    /// u = 1. The stop's full-strength brakes are simulated first, the rest only if neither
    /// passes (they would stop later). Of those that pass, the one that stops first along
    /// the line is taken, and this
    /// returns true — during the line's final landing only if it stops short of the landing.
    /// If none is taken (or at rest) nothing changes and it returns false: the caller stops
    /// as [`LineProfile::stop`] does, from the next knot with the brake verified there (or
    /// goes on landing on the target).
    ///
    /// Sound because whatever is taken was checked from this very state: the closed form is
    /// followed exactly, and a stop's or feedback brake (a law of the state alone, stepped as
    /// in its simulation) reproduces the simulation that verified it. The rescaled state is within the limits at 100 % (it was
    /// within them at the override, which only scales them down); the landing stretch near
    /// u = 1, if it has begun, stays in force and keeps u ≤ 1.
    pub(crate) fn brake_now(
        &mut self,
        b: &Bounds,
        derivs: &impl Fn(f64) -> Derivs,
        t: f64,
        scale: f64,
        t_new: f64,
    ) -> bool {
        self.advance_to(b, derivs, t);
        if self.mode == Mode::Done {
            return false;
        }
        let (u, v, a) = self.state(t);
        let (v, a) = ((scale * v).max(0.0), scale * scale * a);
        let d = derivs(u);
        // What u may do where it is: at rest there, and in its present state (the
        // acceleration's coupling terms q″u̇² and 3q″u̇ü narrow both).
        let (lo, _) = b.jerk_range(&d, v, a);
        let decel = b.accel_at_rest(&d).min(b.decel(&d, v).max(0.0));
        let jerk = b.jerk_hi_at_rest(&d).min((-lo).max(0.0));
        // During the final landing a brake must stop short of it to be worth taking.
        let landing = self.land.map_or(f64::INFINITY, |(_, stop)| stop - LAND_TOL);
        let check = b.relaxed(STOP_RELAX);
        // The stop's brakes from `from` to `to`: the one that stops first.
        let stopping = |(from, to): (usize, usize)| {
            STOP_BRAKES[from..to]
                .iter()
                .enumerate()
                .filter_map(|(k, policy)| {
                    match brake_stop((b, &check), derivs, (u, v, a), policy, Horizon::Full) {
                        Ok(Some(stop)) if stop < landing => Some(((from + k) as u8, stop)),
                        Ok(_) | Err(_) => None,
                    }
                })
                .min_by(|x, y| x.1.total_cmp(&y.1))
        };
        // The full-strength ones stop first when they pass; only if neither does are the
        // weaker ones and the others simulated (each costs a simulation to the stop).
        let (stopping, closed, feedback) = match stopping((0, STOP_FULL)) {
            found @ Some(_) => (found, None, None),
            None => {
                let closed = CLOSED_BRAKES
                    .iter()
                    .map(|&f| Brake1d::new(u, v, a, f * decel, f * jerk))
                    .filter(|brake| {
                        decel > 0.0
                            && jerk > 0.0
                            && brake.stop_position() < landing
                            && closed_brake_ok(b, derivs, brake)
                    })
                    .min_by(|x, y| x.stop_position().total_cmp(&y.stop_position()))
                    .map(|brake| (brake.stop_position(), brake));
                let feedback =
                    match safe(b, derivs, (u, v, a), (0, BRAKES.len() - 1), Horizon::Full) {
                        Ok((brake, Some(stop))) if stop < landing => Some((brake, stop)),
                        Ok(_) | Err(_) => None,
                    };
                (stopping((STOP_FULL, STOP_BRAKES.len())), closed, feedback)
            }
        };
        // The one that stops first.
        let first = [
            stopping.map(|(_, stop)| stop),
            closed.map(|(stop, _)| stop),
            feedback.map(|(_, stop)| stop),
        ]
        .into_iter()
        .flatten()
        .fold(f64::INFINITY, f64::min);
        match (stopping, closed, feedback) {
            (Some((brake, stop)), _, _) if stop <= first => {
                (self.t, self.u, self.v, self.a) = (t_new, u, v, a);
                self.mode = Mode::Braking { brake };
                self.choose(b, derivs);
            }
            (_, Some((stop, brake)), _) if stop <= first => {
                self.mode = Mode::Closed { from: t_new, brake };
            }
            (_, _, Some((brake, stop))) if stop <= first => {
                (self.t, self.u, self.v, self.a) = (t_new, u, v, a);
                self.brake = brake;
                self.brake_stop = stop;
                self.mode = Mode::Stopping;
                self.choose(b, derivs);
            }
            _ => return false,
        }
        self.braked_now = true;
        true
    }

    fn next_knot(&mut self, b: &Bounds, derivs: &impl Fn(f64) -> Derivs) {
        let (u, v, a) = step_to(self.u, self.v, self.a, self.jerk, self.dt);
        self.t += self.dt;
        self.u = u;
        self.v = v.max(0.0);
        self.a = a;
        if self.ends {
            self.v = 0.0;
            self.a = 0.0;
            self.mode = Mode::Done;
            return;
        }
        self.choose(b, derivs);
    }

    fn set_step(&mut self, jerk: f64, brake: u8, stop: f64) {
        self.jerk = jerk;
        self.dt = STEP_S;
        self.brake = brake;
        self.brake_stop = stop;
        self.ends = false;
    }

    /// Choose the step from the current knot, which is safe with the brake `self.brake`
    /// (stopping at `self.brake_stop`).
    fn choose(&mut self, b: &Bounds, derivs: &impl Fn(f64) -> Derivs) {
        let (u, v, a) = (self.u, self.v, self.a);
        if matches!(self.mode, Mode::Junction { .. }) {
            return;
        }
        if let Mode::Braking { brake } = self.mode {
            // The stop's brake, step by step as it was verified (a failure never comes from
            // a verified state: it would end the motion where it is).
            let policy = &STOP_BRAKES[brake as usize];
            (self.jerk, self.dt, self.ends) = match brake_step(b, &derivs(u), v, a, policy) {
                BrakeStep::Rest | BrakeStep::Fail => (0.0, 0.0, true),
                BrakeStep::Jerk { jerk, dt } => (jerk, dt, false),
                BrakeStep::Land { jerk, dt } => (jerk, dt, true),
            };
            return;
        }
        let last = self.jerk;
        let d = derivs(u);
        let brake = self.brake;
        let fallback = brake_step(b, &d, v, a, &Policy::plan(BRAKES[brake as usize]));
        // At rest (nothing safe to start with) or from a state the brake cannot hold (never
        // from a verified state), the motion ends where it is.
        let (jb, dtb, lands) = match fallback {
            BrakeStep::Rest | BrakeStep::Fail => (0.0, 0.0, true),
            BrakeStep::Jerk { jerk, dt } => (jerk, dt, false),
            BrakeStep::Land { jerk, dt } => (jerk, dt, true),
        };
        // Following the brake keeps its verdict: the next knot is on the verified brake.
        self.jerk = jb;
        self.dt = dtb;
        self.ends = lands;
        if self.mode == Mode::Stopping || self.land.is_some() {
            return;
        }
        if u > 0.0 && self.brake_stop >= b.end - LAND_TOL {
            // The last brake: it ends the line; stretch it onto u = 1.
            self.land = Some((u, self.brake_stop));
            return;
        }
        // Past its end the law sees the end's derivatives (a table's past its last row): its
        // brakes are followed there only to learn where they would stop.
        let end = b.end;
        if !self.junction {
            self.search(b, &|x: f64| derivs(x.min(end)), (&d, fallback), last);
            return;
        }
        // Watched: the first search that looks past the end (a brake of a probe reaching
        // it) is undone, and the law waits at this knot, on its verified brake.
        let before = *self;
        let looked = std::cell::Cell::new(false);
        let watch = |x: f64| {
            if x > end {
                looked.set(true);
            }
            derivs(x.min(end))
        };
        self.search(b, &watch, (&d, fallback), last);
        if looked.get() {
            *self = before;
            self.mode = Mode::Junction { last };
        }
    }

    /// The search for the step from the knot (u, u̇, ü) where the derivatives are `d`, the
    /// brake verified there giving `fallback`; `last` is the jerk of the step before.
    fn search(
        &mut self,
        b: &Bounds,
        derivs: &impl Fn(f64) -> Derivs,
        (d, fallback): (&Derivs, BrakeStep),
        last: f64,
    ) {
        let (u, v, a) = (self.u, self.v, self.a);
        let (d, jb, brake) = (*d, self.jerk, self.brake);
        let (_, hi) = b.jerk_range(&d, v, a);
        if hi <= jb {
            return;
        }
        // The brakes a probe tries: the current one's neighbours (every one near a stop).
        let every = (0, BRAKES.len() - 1);
        let near = if matches!(fallback, BrakeStep::Jerk { .. }) {
            (
                brake.saturating_sub(1) as usize,
                (brake as usize + 1).min(BRAKES.len() - 1),
            )
        } else {
            every
        };
        // A jerk's step must keep the limits (at the knot only the jerk changes), and its
        // end state must be safe with one of `brakes`.
        let probe = |j: f64, horizon: Horizon, brakes: (usize, usize)| {
            if !b.jerk_ok(&d, v, a, j) {
                return Err(Unsafe::Limit);
            }
            let (un, vn, an) = step_to(u, v, a, j, STEP_S);
            let next = derivs(un);
            if vn < -1e-9
                || !b.ok(&next, vn.max(0.0), an, j)
                || !b.ok_within(derivs, (u, v, a), j, STEP_S, (&d, &next))
            {
                return Err(Unsafe::Limit);
            }
            safe(b, derivs, (un, vn.max(0.0), an), brakes, horizon)
        };
        let short = |j: f64| probe(j, Horizon::Short, near);
        let full = |j: f64| probe(j, Horizon::Full, near);
        // The current brake only, to the stop: where it stops is continuous in the jerk.
        let k = brake as usize;
        let with_brake = |j: f64| probe(j, Horizon::Full, (k, k));
        // The largest jerk that passes a short probe (the largest admissible one, or found
        // by bisection from the last step's: it changes little from step to step), then
        // verified to the stop before it is taken.
        let candidate = if short(hi).is_ok() {
            hi
        } else {
            let mut search = JerkSearch::new(jb, hi);
            if last > jb && last < hi {
                search.probe(last, &short);
            }
            for _ in 0..BISECTIONS {
                search.bisect(&short);
            }
            match search.best {
                Some((j, _, _)) => j,
                None => return,
            }
        };
        let verdict = match full(candidate) {
            // A limit the nearby brakes cannot keep: every brake is tried.
            Err(Unsafe::Limit) if near != every => probe(candidate, Horizon::Full, every),
            verdict => verdict,
        };
        match verdict {
            Ok((k, Some(stop))) => self.set_step(candidate, k, stop),
            Ok((_, None)) => {}
            Err(Unsafe::Overshoot(_)) => {
                // Only the end limits this step: the jerk whose brake stops on it, by
                // regula falsi on where the brake stops (continuous in the jerk).
                let over = match with_brake(candidate) {
                    Err(Unsafe::Overshoot(at)) => Some(at),
                    _ => None,
                };
                let landed = over.and_then(|over| {
                    land(&with_brake, b.end, (jb, self.brake_stop), (candidate, over))
                });
                if let Some((j, k, stop)) = landed {
                    self.set_step(j, k, stop);
                }
            }
            // Limited further ahead: the largest jerk that a full brake verifies; while
            // already decelerating, the brake itself.
            Err(Unsafe::Limit) if a < 0.0 && matches!(fallback, BrakeStep::Jerk { .. }) => {}
            Err(Unsafe::Limit) => {
                let mut search = JerkSearch::new(jb, candidate);
                for _ in 0..BISECTIONS {
                    search.bisect(&full);
                }
                if let Some((j, k, Some(stop))) = search.best {
                    self.set_step(j, k, stop);
                }
            }
        }
    }
}

/// Whether the closed-form brake `brake` of u keeps every limit along its whole length
/// (checked every [`CHECK_S`] at most and at both ends of every phase, with that phase's
/// jerk), never moves backwards and stops by u = 1.
fn closed_brake_ok(b: &Bounds, derivs: &impl Fn(f64) -> Derivs, brake: &Brake1d) -> bool {
    if brake.stop_position() > b.end + END_TOL {
        return false;
    }
    brake.phases().all(|(start, len, jerk)| {
        let per = if b.path_mm > 0.0 {
            BLEND_CHECKS as f64
        } else {
            1.0
        };
        let steps = (len * per / CHECK_S)
            .ceil()
            .clamp(1.0, MAX_BRAKE_STEPS as f64) as usize;
        (0..=steps).all(|i| {
            let (u, v, a) = brake.at(start + len * (i as f64 / steps as f64));
            v >= -1e-9 && b.ok(&derivs(u), v.max(0.0) * (1.0 - VELOCITY_SLACK), a, jerk)
        })
    })
}

/// The jerk in (lo.0, hi.0) whose verified brake stops within [`LAND_TOL`] of u = `end`,
/// given where the brakes of `lo.0` and `hi.0` stop (before and beyond it): the Illinois
/// variant of regula falsi on the stop point. The best safe jerk found if it runs out of
/// steps or a probe fails on a limit.
fn land(
    full: &impl Fn(f64) -> Result<(u8, Option<f64>), Unsafe>,
    end: f64,
    lo: (f64, f64),
    hi: (f64, f64),
) -> Option<(f64, u8, f64)> {
    let ((mut jl, mut sl), (mut jh, mut sh)) = (lo, hi);
    let mut best = None;
    let mut side = 0i8;
    for _ in 0..LANDING_STEPS {
        let (gl, gh) = (sl - end, sh - end);
        let mut j = jl - gl * (jh - jl) / (gh - gl);
        if !(j > jl && j < jh) {
            j = 0.5 * (jl + jh);
        }
        match full(j) {
            Ok((k, Some(stop))) => {
                best = Some((j, k, stop));
                if stop >= end - LAND_TOL {
                    break;
                }
                (jl, sl) = (j, stop);
                if side == -1 {
                    sh = end + 0.5 * (sh - end);
                }
                side = -1;
            }
            Err(Unsafe::Overshoot(stop)) => {
                (jh, sh) = (j, stop);
                if side == 1 {
                    sl = end + 0.5 * (sl - end);
                }
                side = 1;
            }
            Ok((_, None)) | Err(Unsafe::Limit) => break,
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::double_s::DoubleS;
    use crate::path::{DerivTable, LinePath};
    use wrc_robot::{Pose, Posture};

    fn plan(a: Pose, b: Pose) -> (f64, Vec<(f64, f64)>) {
        let robot = Robot::paper_default();
        let path = LinePath::new(&robot, a, b, Posture::Right);
        let start = robot.inverse(&a, Posture::Right, None).unwrap();
        let mut table = DerivTable::new();
        path.scan(&robot, &start, Some(&mut table)).unwrap();
        let line = crate::settings::MotionSettings::default().line;
        let bounds = Bounds::new(&robot, &LineAxes::of(&robot), &line, path.length_mm());
        let derivs = |u: f64| table.at(u);
        let mut p = LineProfile::start(&bounds, &derivs);
        let mut out = Vec::new();
        let mut t = 0.0;
        while !p.done() {
            t += 0.001;
            out.push((t, p.at(&bounds, &derivs, t)));
            assert!(t < 100.0);
        }
        (t, out)
    }

    #[test]
    fn a_watched_law_is_any_ends_law_to_its_junction_and_resumes_as_that_ends_law() {
        // A line whose "path" ends at u = 0.6, continued to 0.75 or to 1 (the room a path
        // into a PTP brakes in). The law planned to rest at 0.6 and watched is, up to its
        // junction, the law planned with each end from its start, knot for knot to the bit;
        // resumed there with an end, it is that end's law to its rest.
        let robot = Robot::paper_default();
        let (a, b) = (
            Pose {
                x: 250.0,
                y: -150.0,
                z: 0.0,
                yaw: 0.0,
            },
            Pose {
                x: 250.0,
                y: 150.0,
                z: 0.0,
                yaw: 0.0,
            },
        );
        let path = LinePath::new(&robot, a, b, Posture::Right);
        let start = robot.inverse(&a, Posture::Right, None).unwrap();
        let mut table = DerivTable::new();
        path.scan(&robot, &start, Some(&mut table)).unwrap();
        let line = crate::settings::MotionSettings::default().line;
        let bounds = Bounds::new(&robot, &LineAxes::of(&robot), &line, path.length_mm());
        let derivs = |u: f64| table.at(u);
        let cut = 0.6;
        let to_cut = bounds.ending_at(cut);
        for end in [cut, 0.75, 1.0] {
            let with_end = bounds.ending_at(end);
            let mut plain = LineProfile::start(&with_end, &derivs);
            let mut watched = LineProfile::start_watched(&to_cut, &derivs);
            let mut junction = None;
            let mut t = 0.0;
            while !plain.done() {
                t += 0.001;
                let u = plain.at(&with_end, &derivs, t);
                if junction.is_none() {
                    watched.at(&to_cut, &derivs, t);
                    if watched.at_junction() {
                        junction = Some(watched.u);
                        watched.resume(&with_end, &derivs);
                    } else {
                        let unwatched = LineProfile {
                            junction: false,
                            ..watched
                        };
                        assert_eq!(unwatched, plain, "end {end}: at {t} s");
                        continue;
                    }
                }
                let w = watched.at(&with_end, &derivs, t);
                assert_eq!(w.to_bits(), u.to_bits(), "end {end}: at {t} s");
                assert_eq!(watched, plain, "end {end}: at {t} s");
            }
            let junction = junction.expect("the watched law reached its junction");
            assert!(
                junction > 0.1 && junction < cut,
                "end {end}: junction at u = {junction}"
            );
            assert!(watched.completed() && plain.completed());
        }
    }

    #[test]
    fn the_estimate_ranks_entries_as_the_law_does() {
        // Lines where the Cartesian limits bind, and one near the stretched arm where the
        // joints' do: the estimated time to 3/4 of the line and to its end (at rest) from
        // entries at rest and moving is within 15 % of the law's, and the differences
        // between entries — what a PTP into a path compares — within 10 ms.
        let robot = Robot::paper_default();
        let line = crate::settings::MotionSettings::default().line;
        for (a, b) in [
            ((250.0, -100.0), (250.0, 100.0)),
            ((150.0, 150.0), (-150.0, 150.0)),
            ((380.0, -40.0), (380.0, 60.0)),
        ] {
            let pose = |(x, y): (f64, f64)| Pose {
                x,
                y,
                z: 0.0,
                yaw: 0.0,
            };
            let (a, b) = (pose(a), pose(b));
            let path = LinePath::new(&robot, a, b, Posture::Right);
            let start = robot.inverse(&a, Posture::Right, None).unwrap();
            let mut table = DerivTable::new();
            path.scan(&robot, &start, Some(&mut table)).unwrap();
            let bounds = Bounds::new(&robot, &LineAxes::of(&robot), &line, path.length_mm());
            let derivs = |u: f64| table.at(u);
            let v_max = 0.9 * LineProfile::entry_speed(&bounds, &derivs);
            for to in [0.75, 1.0] {
                let mut times = Vec::new();
                for f in [1.0, 0.5, 0.25, 0.0] {
                    let v0 = v_max * f;
                    let mut law = if v0 > 0.0 {
                        LineProfile::start_moving(&bounds, &derivs, v0).unwrap()
                    } else {
                        LineProfile::start(&bounds, &derivs)
                    };
                    let t = if to < 1.0 {
                        law.time_at(&bounds, &derivs, to).unwrap().0
                    } else {
                        law.run_to_end(&bounds, &derivs)
                    };
                    let e = estimate_time(&bounds, &derivs, v0, to);
                    assert!(
                        (e / t - 1.0).abs() < 0.15,
                        "{a:?} to {to}: entry {f}: {e} s, law {t} s"
                    );
                    times.push((t, e));
                }
                for w in times.windows(2) {
                    let (law, est) = (w[1].0 - w[0].0, w[1].1 - w[0].1);
                    assert!(
                        (law - est).abs() < 0.010,
                        "{a:?} to {to}: {law} s apart, estimated {est} s"
                    );
                }
            }
        }
    }

    #[test]
    fn a_line_far_from_every_joint_limit_is_the_one_dimensional_optimum() {
        // A short radial line at mid reach: only the Cartesian limits bind (checked by the
        // joint speeds staying far below theirs), so the law must take the time of the
        // one-dimensional jerk-limited optimum with the Cartesian limits.
        let a = Pose {
            x: 250.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0,
        };
        let b = Pose {
            x: 250.0,
            y: 20.0,
            z: 0.0,
            yaw: 0.0,
        };
        let (t, out) = plan(a, b);
        let line = crate::settings::MotionSettings::default().line;
        let opt = DoubleS::time_optimal(
            20.0,
            line.max_speed_mm_s * LIMIT_MARGIN,
            line.max_accel_mm_s2 * LIMIT_MARGIN,
            line.max_jerk_mm_s3 * LIMIT_MARGIN,
        )
        .duration();
        assert!(
            t >= opt - 0.002 && t <= opt * 1.02 + 0.002,
            "{t} s vs optimum {opt} s"
        );
        assert!((out.last().unwrap().1 - 1.0).abs() < 1e-9);
        // Monotone: never backwards.
        assert!(out.windows(2).all(|w| w[1].1 >= w[0].1 - 1e-12));
    }
}
