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

/// The joints a PTP move from `from` to `pose` (with `posture`) goes to: among the solutions
/// within every axis's limits, the one reached soonest (see the module docs). Errors as
/// [`Robot::inverse`] when no solution lies within the limits.
pub fn ptp_target(
    robot: &Robot,
    from: &Joints,
    pose: &Pose,
    posture: Posture,
) -> Result<Joints, PlanError> {
    let base = robot.inverse(pose, posture, Some(from))?;
    let arm = robot.arm();
    let axes = robot.axes();
    let duration = |q: &Joints| {
        let mut worst = 0.0f64;
        let mut travel = 0.0;
        for (i, axis) in axes.iter().enumerate() {
            let d = (q[i] - from[i]).abs();
            travel += d;
            if d > 0.0 {
                let l = &axis.limits;
                let t = DoubleS::time_optimal(d, l.max_velocity, l.max_acceleration, l.max_jerk)
                    .duration();
                worst = worst.max(t);
            }
        }
        (worst, travel)
    };
    let mut best = base;
    let mut best_cost = duration(&base);
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
            let cost = duration(&q);
            let better = cost.0 < best_cost.0 - 1e-9
                || (cost.0 <= best_cost.0 + 1e-9 && cost.1 < best_cost.1 - 1e-9);
            if better {
                best = q;
                best_cost = cost;
            }
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
