//! Which joint solution a PTP move to a Cartesian pose goes to. With a given elbow posture a
//! pose has one solution per turn of the shoulder and of the hand joint (angles 360° apart);
//! where an axis range is wider than 360° several lie within the limits. The rule: the
//! solution the move reaches **soonest** (each axis's time-optimal duration with its own
//! limits, the slowest axis decides, as for every PTP move); on a tie, the one with the
//! least total joint travel. With ranges of 360° or less there is one solution and the rule
//! changes nothing.

use wrc_robot::{Joints, Pose, Posture, Robot};

use crate::double_s::DoubleS;
use crate::error::PlanError;

/// Most turns either way an axis is tried at [turns].
const TURNS: i32 = 2;

/// Most joint solutions of one pose with one posture (the shoulder and the hand at up to
/// [`TURNS`] turns either way).
pub const MAX_SOLUTIONS: usize = ((2 * TURNS + 1) * (2 * TURNS + 1)) as usize;

/// The joint solutions of a pose with one elbow posture that lie within every axis's
/// limits, the one [`Robot::inverse`] picks (nearest the reference) first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solutions {
    list: [Joints; MAX_SOLUTIONS],
    len: usize,
}

impl Solutions {
    /// The solutions.
    pub fn as_slice(&self) -> &[Joints] {
        &self.list[..self.len]
    }
}

/// The solutions of `pose` with `posture` within the limits; auxiliary axes as in
/// `reference`. Errors as [`Robot::inverse`] when there is none.
pub fn solutions(
    robot: &Robot,
    pose: &Pose,
    posture: Posture,
    reference: &Joints,
) -> Result<Solutions, PlanError> {
    let base = robot.inverse(pose, posture, Some(reference))?;
    let arm = robot.arm();
    let axes = robot.axes();
    let mut out = Solutions {
        list: [base; MAX_SOLUTIONS],
        len: 1,
    };
    for k1 in -TURNS..=TURNS {
        let mut q = base;
        q[arm.shoulder] = base[arm.shoulder] + 360.0 * f64::from(k1);
        if !axes[arm.shoulder].within_limits(q[arm.shoulder]) {
            continue;
        }
        // The hand keeps the pose's yaw: J3 = yaw − J1 − J2, a turn at a time.
        let wrist_turns = if arm.wrist.is_some() { TURNS } else { 0 };
        for k3 in -wrist_turns..=wrist_turns {
            let mut q = q;
            if let Some(w) = arm.wrist {
                q[w] = base[w] - 360.0 * f64::from(k1) + 360.0 * f64::from(k3);
                if !axes[w].within_limits(q[w]) {
                    continue;
                }
            }
            if (k1, k3) != (0, 0) && out.len < MAX_SOLUTIONS {
                out.list[out.len] = q;
                out.len += 1;
            }
        }
    }
    Ok(out)
}

/// How soon a PTP move from `from` reaches `to`: the slowest axis's time-optimal
/// jerk-limited duration at 100 % [s], then the total joint travel (for ties).
pub fn ptp_cost(robot: &Robot, from: &Joints, to: &Joints) -> (f64, f64) {
    let mut worst = 0.0f64;
    let mut travel = 0.0;
    for (i, axis) in robot.axes().iter().enumerate() {
        let d = (to[i] - from[i]).abs();
        travel += d;
        if d > 0.0 {
            let l = &axis.limits;
            let t =
                DoubleS::time_optimal(d, l.max_velocity, l.max_acceleration, l.max_jerk).duration();
            worst = worst.max(t);
        }
    }
    (worst, travel)
}

/// Whether cost `a` ([`ptp_cost`]) is better than `b`: sooner, or as soon with less travel.
pub fn sooner(a: (f64, f64), b: (f64, f64)) -> bool {
    a.0 < b.0 - 1e-9 || (a.0 <= b.0 + 1e-9 && a.1 < b.1 - 1e-9)
}

/// The joints a PTP move from `from` to `pose` (with `posture`) goes to: among the solutions
/// within every axis's limits, the one reached soonest (see the module docs). Errors as
/// [`Robot::inverse`] when no solution lies within the limits.
pub fn ptp_target(
    robot: &Robot,
    from: &Joints,
    pose: &Pose,
    posture: Posture,
) -> Result<Joints, PlanError> {
    let all = solutions(robot, pose, posture, from)?;
    let mut best = all.as_slice()[0];
    let mut best_cost = ptp_cost(robot, from, &best);
    for q in &all.as_slice()[1..] {
        let cost = ptp_cost(robot, from, q);
        if sooner(cost, best_cost) {
            best = *q;
            best_cost = cost;
        }
    }
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use wrc_robot::{AxisRole, Robot};

    fn wide_shoulder() -> Robot {
        let paper = Robot::paper_default();
        let mut axes = paper.axes().to_vec();
        for a in axes.iter_mut().filter(|a| a.role == AxisRole::Shoulder) {
            a.min = -270.0;
            a.max = 270.0;
        }
        Robot::new("wide", axes, 200.0, 200.0, 0.0, 2.0).unwrap()
    }

    #[test]
    fn the_solution_reached_soonest_is_chosen() {
        let robot = wide_shoulder();
        // From J1 = 200°, a pose whose J1 is -150° (or 210°): 210° is 10° away.
        let mut from = robot.home();
        from[0] = 200.0;
        from[1] = 60.0;
        from[2] = -260.0;
        let mut want = from;
        want[0] = -150.0;
        let pose = robot.forward(&want);
        let q = ptp_target(&robot, &from, &pose, Posture::Right).unwrap();
        assert!((q[0] - 210.0).abs() < 1e-6, "{q:?}");
        let back = robot.forward(&q);
        assert!((back.x - pose.x).abs() < 1e-9 && (back.y - pose.y).abs() < 1e-9);
        assert!((back.yaw - pose.yaw).abs() < 1e-9);
        robot.check_joints(&q).unwrap();
    }

    #[test]
    fn with_ranges_of_one_turn_there_is_one_solution() {
        let robot = Robot::paper_default();
        let pose = Pose {
            x: -250.0,
            y: 30.0,
            z: 5.0,
            yaw: 170.0,
        };
        let from = robot.home();
        let q = ptp_target(&robot, &from, &pose, Posture::Right).unwrap();
        assert_eq!(
            q,
            robot.inverse(&pose, Posture::Right, Some(&from)).unwrap()
        );
    }
}
