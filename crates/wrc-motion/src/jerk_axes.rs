//! A time-synchronised jerk-limited move of every axis between two states (from rest to a
//! moving state, from a moving state to rest): the joint-space parts of the blended moves
//! (docs/motion.md, "Blended approach", "PTP blends"), computed by Ruckig
//! (`rsruckig`, the time-optimal jerk-limited online trajectory generator) and kept as plain
//! data: up to seven constant-jerk phases per axis.
//!
//! Real-time promise: [`JerkAxes`] is `Copy` and heap-free, so a real-time task keeps one per
//! queued period; evaluating it is arithmetic. [`Planner`] owns Ruckig's calculator and
//! trajectory, allocated once when it is created: a calculation that succeeds allocates
//! nothing (the allocation test runs one), and one that fails is reported without a message.

use rsruckig::prelude::*;

use crate::line_profile::advance;
use wrc_robot::{Joints, Robot, MAX_AXES};

/// Axes Ruckig plans at once; an arm has at most this many moving axes in an approach.
pub const RUCKIG_DOF: usize = 4;

/// Constant-jerk phases of one axis: the state where it starts, and each phase's end time and
/// jerk (the state at each phase's start is integrated when evaluated: small, as a queued
/// period's copy should be).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Phases {
    /// End time of each phase [s].
    t_end: [f64; 7],
    /// Jerk of each phase.
    j: [f64; 7],
    /// Position, velocity and acceleration at the start.
    p0: f64,
    v0: f64,
    a0: f64,
}

impl Phases {
    fn at(&self, t: f64) -> (f64, f64, f64) {
        let (mut p, mut v, mut a) = (self.p0, self.v0, self.a0);
        let mut start = 0.0;
        for i in 0..7 {
            let end = self.t_end[i].max(start);
            (p, v, a) = advance(p, v, a, self.j[i], (t.min(end) - start).max(0.0));
            if t <= end {
                return (p, v, a);
            }
            start = end;
        }
        // After the end: on with the final velocity and acceleration (the next part takes
        // over at the end, so this is only reached within rounding).
        advance(p, v, a, 0.0, (t - start).max(0.0))
    }
}

/// The move of every axis (entries past the moving ones stand still).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JerkAxes {
    axes: [Phases; RUCKIG_DOF],
    idx: [usize; RUCKIG_DOF],
    n: usize,
    start: Joints,
    duration: f64,
}

impl JerkAxes {
    /// Duration [s].
    pub fn duration(&self) -> f64 {
        self.duration
    }

    /// Joints, joint velocities and accelerations at time `t` [s] (clamped to the move).
    pub fn state(&self, t: f64) -> (Joints, Joints, Joints) {
        let t = t.clamp(0.0, self.duration);
        let (mut q, mut v, mut a) = (self.start, [0.0; MAX_AXES], [0.0; MAX_AXES]);
        for k in 0..self.n {
            let (p, vk, ak) = self.axes[k].at(t);
            let i = self.idx[k];
            q[i] = p;
            v[i] = vk;
            a[i] = ak;
        }
        (q, v, a)
    }
}

/// Ruckig's calculator, preallocated.
pub struct Planner {
    otg: Ruckig<RUCKIG_DOF, IgnoreErrorHandler>,
    input: InputParameter<RUCKIG_DOF>,
    trajectory: Trajectory<RUCKIG_DOF>,
}

impl Clone for Planner {
    fn clone(&self) -> Self {
        Planner::new()
    }
}

impl std::fmt::Debug for Planner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Planner(ruckig)")
    }
}

impl Default for Planner {
    fn default() -> Self {
        Planner::new()
    }
}

impl Planner {
    /// A calculator (allocates its buffers once).
    pub fn new() -> Planner {
        Planner {
            otg: Ruckig::new(None, 0.001),
            input: InputParameter::new(None),
            trajectory: Trajectory::new(None),
        }
    }

    /// The time-optimal synchronised move from rest at `start` to `end` reached with joint
    /// velocities `v_end` and accelerations `a_end`, each axis within its limits scaled by
    /// `(s, α)`, the speed and acceleration overrides as fractions (velocity ×s,
    /// acceleration ×s²·α, jerk ×s³·α); `None` if Ruckig finds none or the robot has more
    /// than [`RUCKIG_DOF`] axes.
    pub fn rest_to_moving(
        &mut self,
        robot: &Robot,
        start: &Joints,
        end: &Joints,
        v_end: &Joints,
        a_end: &Joints,
        scale: (f64, f64),
    ) -> Option<JerkAxes> {
        let rest = [0.0; MAX_AXES];
        self.between(robot, (start, &rest, &rest), (end, v_end, a_end), scale)
    }

    /// The time-optimal synchronised move from joints, velocities and accelerations `from`
    /// to `to`, each axis within its limits scaled by `(s, α)` as in
    /// [`Planner::rest_to_moving`]. `None` if Ruckig finds none, if it would need a brake
    /// or acceleration pre-trajectory first (a start beyond the limits), or if the robot has
    /// more than [`RUCKIG_DOF`] axes.
    pub fn between(
        &mut self,
        robot: &Robot,
        from: (&Joints, &Joints, &Joints),
        to: (&Joints, &Joints, &Joints),
        (scale, accel): (f64, f64),
    ) -> Option<JerkAxes> {
        let n = robot.axis_count();
        if n > RUCKIG_DOF {
            return None;
        }
        let (start, v0, a0) = from;
        let (end, v_end, a_end) = to;
        let mut idx = [0usize; RUCKIG_DOF];
        for (k, i) in idx.iter_mut().enumerate() {
            *i = k.min(n.saturating_sub(1));
        }
        let inp = &mut self.input;
        for k in 0..RUCKIG_DOF {
            let (p0, pv0, pa0, p1, v1, a1, (v, a, j)) = if k < n {
                let l = &robot.axes()[k].limits;
                (
                    start[k],
                    v0[k],
                    a0[k],
                    end[k],
                    v_end[k],
                    a_end[k],
                    (
                        l.max_velocity * scale,
                        l.max_acceleration * scale * scale * accel,
                        l.max_jerk * scale * scale * scale * accel,
                    ),
                )
            } else {
                (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, (1.0, 1.0, 1.0))
            };
            inp.current_position[k] = p0;
            inp.current_velocity[k] = pv0;
            inp.current_acceleration[k] = pa0;
            inp.target_position[k] = p1;
            inp.target_velocity[k] = v1;
            inp.target_acceleration[k] = a1;
            inp.max_velocity[k] = v;
            inp.max_acceleration[k] = a;
            inp.max_jerk[k] = j;
        }
        self.otg.calculate(&self.input, &mut self.trajectory).ok()?;
        let duration = self.trajectory.get_duration();
        let profiles = self.trajectory.get_profiles().first()?;
        let mut axes = [Phases::default(); RUCKIG_DOF];
        for (k, out) in axes.iter_mut().enumerate().take(n) {
            let pr = &profiles[k];
            // A brake or acceleration pre-trajectory (from a start beyond the limits) would
            // not be part of the phases kept here.
            if pr.brake.duration > 0.0 || pr.accel.duration > 0.0 {
                return None;
            }
            out.t_end = pr.t_sum;
            out.j = pr.j;
            (out.p0, out.v0, out.a0) = (pr.p[0], pr.v[0], pr.a[0]);
        }
        if !(duration.is_finite() && duration >= 0.0) {
            return None;
        }
        let m = JerkAxes {
            axes,
            idx,
            n,
            start: *start,
            duration,
        };
        // What is kept must start where it was asked to.
        let (q, v, a) = m.state(0.0);
        let near = |x: f64, y: f64| (x - y).abs() <= 1e-9 * y.abs().max(1.0);
        if !(0..n).all(|i| near(q[i], start[i]) && near(v[i], v0[i]) && near(a[i], a0[i])) {
            return None;
        }
        // What is kept must end where it was asked to: position, velocity and acceleration.
        let (q, v, a) = m.state(duration);
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-6 * y.abs().max(1.0);
        (0..n)
            .all(|i| close(q[i], end[i]) && close(v[i], v_end[i]) && close(a[i], a_end[i]))
            .then_some(m)
    }
}
