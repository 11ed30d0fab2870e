//! Straight-line paths (the paper's Table 2): the TCP moves on the segment from a start pose
//! to a target pose, parametrised by u in [0, 1]; the hand's yaw and the Z height change
//! linearly with u. Planning checks the whole segment against the workspace and the joint
//! limits and derives velocity, acceleration and jerk limits for u such that no joint exceeds
//! its own limits anywhere on the segment.
//!
//! Joint speeds along a line are q̇ = q'(u)·u̇, and near the stretched or folded arm |q'(u)|
//! grows like 1/sin θ2. With m1, m2, m3 the maxima of |q'|, |q''|, |q'''| over the segment:
//!   q̇ <= m1·V_u,  q̈ <= m1·A_u + m2·V_u²,  q⃛ <= m1·J_u + 3·m2·V_u·A_u + m3·V_u³,
//! so V_u, A_u, J_u are chosen to keep each sum within the joint's limit. The limits are
//! constant along the segment (conservative near singular spots, exact elsewhere). Planning
//! samples the segment (no allocation: a rolling window of five IK solutions).

use wrc_robot::{Joints, KinematicsError, Pose, Posture, Robot};

use crate::error::{PathProblem, PlanError};
use crate::settings::LineLimits;

/// Safety factor on sampled derivative maxima (the true maximum may fall between samples).
const DERIVATIVE_MARGIN: f64 = 1.05;

/// A straight segment in Cartesian space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinePath {
    /// Pose at u = 0.
    pub start: Pose,
    /// Target minus start (yaw the short way round) [mm, mm, mm, deg].
    pub delta: Pose,
    /// Elbow posture kept along the whole segment.
    pub posture: Posture,
}

/// Limits of the path parameter u derived from the joints and the Cartesian limits
/// [1/s, 1/s², 1/s³].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathLimits {
    /// Velocity of u [1/s].
    pub v: f64,
    /// Acceleration of u [1/s²].
    pub a: f64,
    /// Jerk of u [1/s³].
    pub j: f64,
}

fn wrap180(deg: f64) -> f64 {
    let w = deg.rem_euclid(360.0);
    if w > 180.0 {
        w - 360.0
    } else {
        w
    }
}

impl LinePath {
    /// The segment from `start` to `target`, keeping `posture`.
    pub fn new(robot: &Robot, start: Pose, target: Pose, posture: Posture) -> LinePath {
        // On an arm without a hand joint the yaw follows J1 + J2 and is not interpolated.
        let dyaw = if robot.arm().wrist.is_some() {
            wrap180(target.yaw - start.yaw)
        } else {
            0.0
        };
        LinePath {
            start,
            delta: Pose {
                x: target.x - start.x,
                y: target.y - start.y,
                z: target.z - start.z,
                yaw: dyaw,
            },
            posture,
        }
    }

    /// Cartesian length of the segment [mm].
    pub fn length_mm(&self) -> f64 {
        (self.delta.x * self.delta.x + self.delta.y * self.delta.y + self.delta.z * self.delta.z)
            .sqrt()
    }

    /// The pose at parameter `u` in [0, 1].
    #[inline]
    pub fn pose_at(&self, u: f64) -> Pose {
        Pose {
            x: self.start.x + u * self.delta.x,
            y: self.start.y + u * self.delta.y,
            z: self.start.z + u * self.delta.z,
            yaw: self.start.yaw + u * self.delta.yaw,
        }
    }

    /// Joints at parameter `u`, continuing from `reference` (the previous point's joints).
    #[inline]
    pub fn joints_at(
        &self,
        robot: &Robot,
        u: f64,
        reference: &Joints,
    ) -> Result<Joints, KinematicsError> {
        robot.inverse(&self.pose_at(u), self.posture, Some(reference))
    }

    /// Check every point of the segment and derive the limits of u. `start_joints` are the
    /// joints at u = 0; `scale` is the speed override as a fraction (0, 1]. Returns the
    /// limits and the joints at u = 1.
    pub fn plan(
        &self,
        robot: &Robot,
        start_joints: &Joints,
        line: &LineLimits,
        scale: f64,
    ) -> Result<(PathLimits, Joints), PlanError> {
        let length = self.length_mm();
        let margin = robot.arm().singularity_margin_mm;
        let step_mm = if margin > 0.0 { 0.5 * margin } else { 0.05 };
        let samples = ((length / step_mm).ceil() as usize).clamp(1000, 20000);
        let h = 1.0 / samples as f64;
        let n = robot.axis_count();

        let fail = |u: f64, err: KinematicsError, path: &LinePath| -> PlanError {
            let p = path.pose_at(u);
            let reason = match err {
                KinematicsError::TooFar { .. } => PathProblem::Stretched,
                KinematicsError::TooClose { .. } => PathProblem::Folded,
                KinematicsError::JointLimit { .. } => PathProblem::JointLimit,
                other => return PlanError::Kinematics(other),
            };
            PlanError::PathLeavesWorkspace {
                fraction_pct: 100.0 * u,
                x: p.x,
                y: p.y,
                reason,
            }
        };

        // Rolling window of joint vectors at u = (i-4..=i)·h; derivatives at its centre.
        let mut window: [Joints; 5] = [*start_joints; 5];
        let (mut m1, mut m2, mut m3) = (
            [0.0f64; wrc_robot::MAX_AXES],
            [0.0f64; wrc_robot::MAX_AXES],
            [0.0f64; wrc_robot::MAX_AXES],
        );
        let mut last = *start_joints;
        for i in 1..=samples {
            let u = i as f64 * h;
            let q = self
                .joints_at(robot, u, &last)
                .map_err(|e| fail(u, e, self))?;
            last = q;
            window.rotate_left(1);
            window[4] = q;
            if i >= 2 {
                // centre of the last three: first and second derivatives
                for ax in 0..n {
                    let (a, b, c) = (window[2][ax], window[3][ax], window[4][ax]);
                    m1[ax] = m1[ax].max(((c - a) / (2.0 * h)).abs());
                    m2[ax] = m2[ax].max(((c - 2.0 * b + a) / (h * h)).abs());
                }
            }
            if i >= 4 {
                for ax in 0..n {
                    let w = &window;
                    let d3 =
                        (w[4][ax] - 2.0 * w[3][ax] + 2.0 * w[1][ax] - w[0][ax]) / (2.0 * h * h * h);
                    m3[ax] = m3[ax].max(d3.abs());
                }
            }
        }
        if samples < 2 {
            // Never reached: samples >= 1000.
            return Err(PlanError::TooLong("no samples"));
        }

        // Limits of u, as in the module doc.
        let (s2, s3) = (scale * scale, scale * scale * scale);
        let mut v = f64::INFINITY;
        if length > 0.0 {
            v = v.min(line.max_speed_mm_s * scale / length);
        }
        let axes = robot.axes();
        for ax in 0..n {
            let (d1, d2, d3) = (
                m1[ax] * DERIVATIVE_MARGIN,
                m2[ax] * DERIVATIVE_MARGIN,
                m3[ax] * DERIVATIVE_MARGIN,
            );
            let l = &axes[ax].limits;
            if d1 > 0.0 {
                v = v.min(l.max_velocity * scale / d1);
            }
            if d2 > 0.0 {
                v = v.min((l.max_acceleration * s2 / (2.0 * d2)).sqrt());
            }
            if d3 > 0.0 {
                v = v.min((l.max_jerk * s3 / (3.0 * d3)).cbrt());
            }
        }
        let mut a = f64::INFINITY;
        if length > 0.0 {
            a = a.min(line.max_accel_mm_s2 * s2 / length);
        }
        for ax in 0..n {
            let (d1, d2) = (m1[ax] * DERIVATIVE_MARGIN, m2[ax] * DERIVATIVE_MARGIN);
            let l = &axes[ax].limits;
            if d1 > 0.0 {
                a = a.min((l.max_acceleration * s2 - d2 * v * v) / d1);
            }
            if d2 > 0.0 {
                a = a.min(l.max_jerk * s3 / (9.0 * d2 * v));
            }
        }
        let mut j = f64::INFINITY;
        if length > 0.0 {
            j = j.min(line.max_jerk_mm_s3 * s3 / length);
        }
        for ax in 0..n {
            let (d1, d2, d3) = (
                m1[ax] * DERIVATIVE_MARGIN,
                m2[ax] * DERIVATIVE_MARGIN,
                m3[ax] * DERIVATIVE_MARGIN,
            );
            let l = &axes[ax].limits;
            if d1 > 0.0 {
                j = j.min((l.max_jerk * s3 - 3.0 * d2 * v * a - d3 * v * v * v) / d1);
            }
        }
        if !(v.is_finite() && a.is_finite() && j.is_finite()) || v <= 0.0 || a <= 0.0 || j <= 0.0 {
            // Nothing moves (zero-length segment without rotation): no limits needed.
            return Ok((
                PathLimits {
                    v: 0.0,
                    a: 0.0,
                    j: 0.0,
                },
                last,
            ));
        }
        Ok((PathLimits { v, a, j }, last))
    }
}
