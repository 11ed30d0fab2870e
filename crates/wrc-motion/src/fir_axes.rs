//! The timing law of a joint move (PTP or jog) under the default profile: each axis's
//! fraction of its distance follows its planned double-S ([`DoubleS`]) and, after a
//! controlled stop, its time-optimal jerk-limited brake ([`Brake1d`]) from the exact state
//! the plan had reached.
//!
//! Phase-synchronised and single-axis moves brake *together*: one brake of the common
//! fraction s, with limits A_s = min A_i/|d_i| and J_s = min J_i/|d_i| over the moving axes
//! (d_i the axis's distance), so every axis stays on the joint-space line and the slowest
//! axis brakes time-optimally. Time-synchronised moves brake *axis by axis*: each axis its
//! own brake from its own state, as Ruckig's brake pre-trajectory does. A brake that would
//! carry an axis past its target (possible only during the planned deceleration, with the
//! planned limits, by rounding) is not taken: the plan is then the stop.
//!
//! Real-time promise: `Copy`, fixed-size, no allocation; every evaluation is closed form.

use wrc_robot::MAX_AXES;

use crate::brake::Brake1d;
use crate::brake::BrakeLimits;
use crate::double_s::DoubleS;

/// What one axis's fraction follows.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Channel {
    /// The planned profile, from time 0.
    Plan(DoubleS),
    /// A brake that started at time `from` [s].
    Brake { from: f64, brake: Brake1d },
}

impl Channel {
    /// Fraction, its velocity and acceleration at time `t` [s] [1, 1/s, 1/s²].
    #[inline]
    fn state(&self, t: f64) -> (f64, f64, f64) {
        match self {
            Channel::Plan(p) => p.state(t),
            Channel::Brake { from, brake } => brake.at(t - from),
        }
    }

    /// Time [s] from which the axis is at rest.
    fn end(&self) -> f64 {
        match self {
            Channel::Plan(p) => p.duration(),
            Channel::Brake { from, brake } => from + brake.duration(),
        }
    }

    /// Fraction of the distance where the axis comes to rest.
    fn final_fraction(&self) -> f64 {
        match self {
            Channel::Plan(_) => 1.0,
            Channel::Brake { brake, .. } => brake.stop_position(),
        }
    }
}

/// The axes of a joint move under the default profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FirAxes {
    axes: [Channel; MAX_AXES],
    /// The limits of the last stop, once one came.
    braking: Option<BrakeLimits>,
}

impl FirAxes {
    /// Every axis on its planned profile ([`DoubleS::REST`] for an axis that does not move).
    pub(crate) fn new(profiles: &[DoubleS; MAX_AXES]) -> FirAxes {
        FirAxes {
            axes: profiles.map(Channel::Plan),
            braking: None,
        }
    }

    /// The limits of the stop under way, if one came.
    pub(crate) fn braking(&self) -> Option<BrakeLimits> {
        self.braking
    }

    /// Time [s] from which the first `n` axes are all at rest.
    pub(crate) fn end_time(&self, n: usize) -> f64 {
        self.axes[..n].iter().map(Channel::end).fold(0.0, f64::max)
    }

    /// Fraction of axis `i`'s distance at time `t` [s], with its velocity and acceleration
    /// [1, 1/s, 1/s²].
    #[inline]
    pub(crate) fn state(&self, i: usize, t: f64) -> (f64, f64, f64) {
        self.axes[i].state(t)
    }

    /// Fraction of axis `i`'s distance where it comes to rest: 1, or less after a stop.
    pub(crate) fn final_fraction(&self, i: usize) -> f64 {
        self.axes[i].final_fraction()
    }

    /// Brake from time `now` [s]: `limits[i]` is the (acceleration [1/s²], jerk [1/s³])
    /// limit of axis `i`'s fraction, `None` for an axis that does not move. `together`: one
    /// brake of the common fraction for every moving axis (phase-synchronised or single-axis
    /// moves), with the smallest of their limits; otherwise one brake per axis. A brake that
    /// would stop at or past the target is not taken (the current law goes on). `kind` is
    /// remembered for [`FirAxes::braking`].
    pub(crate) fn brake(
        &mut self,
        now: f64,
        kind: BrakeLimits,
        limits: &[Option<(f64, f64)>; MAX_AXES],
        together: bool,
    ) {
        self.braking = Some(kind);
        let moving = || limits.iter().enumerate().filter(|(_, l)| l.is_some());
        let brake_from = |ch: &Channel, (a, j): (f64, f64)| {
            let (f, v, acc) = ch.state(now);
            let brake = Brake1d::new(f, v, acc, a, j);
            (brake.stop_position() < 1.0).then_some(Channel::Brake { from: now, brake })
        };
        if together {
            let (mut a, mut j) = (f64::INFINITY, f64::INFINITY);
            let mut first = None;
            for (i, l) in moving() {
                if let Some((ai, ji)) = *l {
                    a = a.min(ai);
                    j = j.min(ji);
                    first.get_or_insert(i);
                }
            }
            // Every moving axis follows the same law: the first one's state is everyone's.
            let Some(first) = first else { return };
            if let Some(ch) = brake_from(&self.axes[first], (a, j)) {
                for (i, _) in moving() {
                    self.axes[i] = ch;
                }
            }
        } else {
            for (i, l) in moving() {
                if let Some(ch) = l.and_then(|l| brake_from(&self.axes[i], l)) {
                    self.axes[i] = ch;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_brake_starts_from_the_exact_state_and_keeps_the_line() {
        let plan = DoubleS::time_optimal(1.0, 1.0, 4.0, 40.0);
        let mut profiles = [DoubleS::REST; MAX_AXES];
        profiles[0] = plan;
        profiles[1] = plan;
        let mut law = FirAxes::new(&profiles);
        let before = law.state(0, 0.2);
        let mut limits = [None; MAX_AXES];
        limits[0] = Some((4.0, 40.0));
        limits[1] = Some((8.0, 80.0));
        law.brake(0.2, BrakeLimits::Override, &limits, true);
        assert_eq!(law.braking(), Some(BrakeLimits::Override));
        // Continuous at the stop; both axes on one law (the smaller limits).
        assert_eq!(law.state(0, 0.2), before);
        for k in 0..100 {
            let t = 0.2 + k as f64 * 0.01;
            assert_eq!(law.state(0, t), law.state(1, t));
        }
        let want = Brake1d::new(before.0, before.1, before.2, 4.0, 40.0);
        assert_eq!(law.end_time(2), 0.2 + want.duration());
        assert_eq!(law.final_fraction(0), want.stop_position());
        assert!(law.final_fraction(0) < 1.0);
    }

    #[test]
    fn a_brake_that_would_pass_the_target_leaves_the_plan() {
        let plan = DoubleS::time_optimal(1.0, 1.0, 4.0, 40.0);
        let mut profiles = [DoubleS::REST; MAX_AXES];
        profiles[0] = plan;
        let mut law = FirAxes::new(&profiles);
        let mut limits = [None; MAX_AXES];
        // Gentler limits than the plan's as the deceleration begins: it would overshoot.
        limits[0] = Some((1.0, 10.0));
        let t = plan.t0;
        law.brake(t, BrakeLimits::Override, &limits, true);
        assert_eq!(law.final_fraction(0), 1.0);
        assert_eq!(law.end_time(1), plan.duration());
    }
}
