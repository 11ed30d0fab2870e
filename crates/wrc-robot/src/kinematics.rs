//! Closed-form forward and inverse kinematics of the planar arm.
//!
//! Conventions: angles in degrees, lengths in millimetres; J1 is measured from the base x
//! axis, J2 from the first link, J3 from the second link, all counter-clockwise seen from
//! above. The hand's yaw is J1 + J2 + J3. The tool centre point (TCP) lies `hand_mm` along
//! the hand from the J3 axis. No allocation, no I/O: safe in a real-time cycle.

use crate::error::KinematicsError;
use crate::robot::{Joints, Robot, MAX_AXES};

/// A Cartesian pose of the tool centre point.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose {
    /// x [mm], in the base frame.
    pub x: f64,
    /// y [mm], in the base frame.
    pub y: f64,
    /// Height of the Z lift [mm].
    pub z: f64,
    /// Hand direction, counter-clockwise from the base x axis [deg].
    pub yaw: f64,
}

/// How strictly [`Robot::inverse_checked`] checks a target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IkCheck {
    /// Keep the singularity margin from the stretched and folded arm.
    pub margin: bool,
    /// Keep every joint within its soft limits.
    pub joint_limits: bool,
}

impl IkCheck {
    /// Margin and joint limits: for targets.
    pub const STRICT: IkCheck = IkCheck {
        margin: true,
        joint_limits: true,
    };
    /// Neither: for points between checked samples of a planned path.
    pub const CONTINUE: IkCheck = IkCheck {
        margin: false,
        joint_limits: false,
    };
}

/// Which of the two arm configurations reaches a point: the elbow on the right or on the
/// left of the line from the shoulder to the wrist, looking along it from the shoulder.
/// `Right` has J2 > 0, `Left` has J2 < 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Posture {
    /// Elbow right of the shoulder→wrist line (J2 > 0).
    Right,
    /// Elbow left of the shoulder→wrist line (J2 < 0).
    Left,
}

impl Posture {
    /// The posture of a joint vector, or `None` when the elbow is exactly straight or folded.
    pub fn of(robot: &Robot, joints: &Joints) -> Option<Posture> {
        let j2 = joints[robot.arm().elbow];
        let s = j2.to_radians().sin();
        if s > 0.0 {
            Some(Posture::Right)
        } else if s < 0.0 {
            Some(Posture::Left)
        } else {
            None
        }
    }

    /// `R` or `L`, as in the host protocol.
    pub fn letter(self) -> char {
        match self {
            Posture::Right => 'R',
            Posture::Left => 'L',
        }
    }
}

/// Wrap an angle into (-180, 180] [deg].
pub(crate) fn wrap180(deg: f64) -> f64 {
    let w = deg.rem_euclid(360.0);
    if w > 180.0 {
        w - 360.0
    } else {
        w
    }
}

impl Robot {
    /// Forward kinematics: the TCP pose of a joint vector.
    pub fn forward(&self, joints: &Joints) -> Pose {
        let arm = self.arm();
        let t1 = joints[arm.shoulder];
        let t2 = joints[arm.elbow];
        let t3 = arm.wrist.map_or(0.0, |w| joints[w]);
        let a1 = t1.to_radians();
        let a12 = (t1 + t2).to_radians();
        let yaw = t1 + t2 + t3;
        let ay = yaw.to_radians();
        Pose {
            x: arm.link1_mm * a1.cos() + arm.link2_mm * a12.cos() + arm.hand_mm * ay.cos(),
            y: arm.link1_mm * a1.sin() + arm.link2_mm * a12.sin() + arm.hand_mm * ay.sin(),
            z: arm.z.map_or(0.0, |z| joints[z]),
            yaw: wrap180(yaw),
        }
    }

    /// Distance of a pose's wrist (J3) point from the shoulder axis [mm].
    pub fn wrist_radius(&self, pose: &Pose) -> f64 {
        let (wx, wy) = self.wrist_point(pose);
        wx.hypot(wy)
    }

    fn wrist_point(&self, pose: &Pose) -> (f64, f64) {
        let arm = self.arm();
        let ay = pose.yaw.to_radians();
        (
            pose.x - arm.hand_mm * ay.cos(),
            pose.y - arm.hand_mm * ay.sin(),
        )
    }

    /// Inverse kinematics in closed form.
    ///
    /// `posture` picks the elbow side. `reference` (usually the current joints) chooses,
    /// among angles 360° apart, the one nearest to it within the limits, and gives the
    /// values of auxiliary axes; without it auxiliary axes stay at home. On an arm without
    /// a hand joint the pose's yaw cannot be chosen and is ignored.
    ///
    /// Errors: a non-finite coordinate, a wrist point outside
    /// `|L1-L2| + margin < r < L1 + L2 - margin`, or a joint outside its limits.
    pub fn inverse(
        &self,
        pose: &Pose,
        posture: Posture,
        reference: Option<&Joints>,
    ) -> Result<Joints, KinematicsError> {
        self.inverse_checked(pose, posture, reference, IkCheck::STRICT)
    }

    /// Inverse kinematics with a chosen strictness: [`IkCheck::STRICT`] is [`Robot::inverse`];
    /// [`IkCheck::CONTINUE`] is for following a path that planning has already checked: no
    /// singularity margin and no joint limits, angles chosen nearest to `reference` only.
    pub fn inverse_checked(
        &self,
        pose: &Pose,
        posture: Posture,
        reference: Option<&Joints>,
        check: IkCheck,
    ) -> Result<Joints, KinematicsError> {
        for (what, v) in [
            ("x", pose.x),
            ("y", pose.y),
            ("z", pose.z),
            ("yaw", pose.yaw),
        ] {
            if !v.is_finite() {
                return Err(KinematicsError::NotFinite { what });
            }
        }
        let arm = self.arm();
        let (l1, l2) = (arm.link1_mm, arm.link2_mm);
        let (wx, wy) = self.wrist_point(pose);
        let r = wx.hypot(wy);
        let margin = if check.margin {
            arm.singularity_margin_mm
        } else {
            0.0
        };
        let r_max = l1 + l2;
        let r_min = (l1 - l2).abs();
        if r >= r_max - margin {
            return Err(KinematicsError::TooFar {
                x: pose.x,
                y: pose.y,
                r,
                max: r_max,
                margin,
            });
        }
        // The folded arm is singular too, and at r = 0 the shoulder angle is undefined.
        if r <= r_min + margin || r <= 0.0 {
            return Err(KinematicsError::TooClose {
                x: pose.x,
                y: pose.y,
                r,
                min: r_min,
                margin,
            });
        }
        let c2 = ((r * r - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)).clamp(-1.0, 1.0);
        let s2_abs = (1.0 - c2 * c2).sqrt();
        let s2 = match posture {
            Posture::Right => s2_abs,
            Posture::Left => -s2_abs,
        };
        let t2 = s2.atan2(c2);
        let t1 = wy.atan2(wx) - (l2 * s2).atan2(l1 + l2 * c2);
        let t1 = t1.to_degrees();
        let t2 = t2.to_degrees();

        let mut joints = match reference {
            Some(reference) => *reference,
            None => self.home(),
        };
        let axes = self.axes();
        let near = |i: usize| reference.map_or(0.0, |r| r[i]);
        let limits = check.joint_limits;
        joints[arm.shoulder] = self.nearest_turn(arm.shoulder, t1, near(arm.shoulder), limits)?;
        joints[arm.elbow] = self.nearest_turn(arm.elbow, t2, near(arm.elbow), limits)?;
        if let Some(w) = arm.wrist {
            let t3 = pose.yaw - joints[arm.shoulder] - joints[arm.elbow];
            joints[w] = self.nearest_turn(w, t3, near(w), limits)?;
        }
        match arm.z {
            Some(z) => {
                let axis = &axes[z];
                if limits && !axis.within_limits(pose.z) {
                    return Err(KinematicsError::JointLimit {
                        axis: axis.name,
                        value: pose.z,
                        min: axis.min,
                        max: axis.max,
                    });
                }
                joints[z] = pose.z;
            }
            None if pose.z != 0.0 => return Err(KinematicsError::NoZAxis { z: pose.z }),
            None => {}
        }
        for j in joints.iter_mut().skip(axes.len()).take(MAX_AXES) {
            *j = 0.0;
        }
        Ok(joints)
    }

    /// Among `angle + k·360°` within the axis limits (or anywhere, without `limits`), the
    /// one nearest `near`.
    fn nearest_turn(
        &self,
        index: usize,
        angle: f64,
        near: f64,
        limits: bool,
    ) -> Result<f64, KinematicsError> {
        let axis = &self.axes()[index];
        let base = wrap180(angle);
        let mut best: Option<f64> = None;
        for k in -2..=2 {
            let candidate = base + 360.0 * k as f64;
            if !limits || axis.within_limits(candidate) {
                let better = match best {
                    Some(b) => (candidate - near).abs() < (b - near).abs(),
                    None => true,
                };
                if better {
                    best = Some(candidate);
                }
            }
        }
        best.ok_or(KinematicsError::JointLimit {
            axis: axis.name,
            value: base,
            min: axis.min,
            max: axis.max,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::Robot;
    use proptest::prelude::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn home_pose_of_the_paper_robot() {
        let robot = Robot::paper_default();
        let pose = robot.forward(&robot.home());
        // J1 = -75, J2 = 150: the wrist sits 2·200·cos 75° in front of the shoulder.
        assert!(
            close(pose.x, 400.0 * 75f64.to_radians().cos(), 1e-9),
            "{pose:?}"
        );
        assert!(close(pose.y, 0.0, 1e-9));
        assert!(close(pose.yaw, 0.0, 1e-9));
        assert_eq!(Posture::of(&robot, &robot.home()), Some(Posture::Right));
    }

    #[test]
    fn unreachable_targets_are_named() {
        let robot = Robot::paper_default();
        let far = Pose {
            x: 500.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0,
        };
        let err = robot.inverse(&far, Posture::Right, None).unwrap_err();
        assert!(matches!(err, KinematicsError::TooFar { .. }));
        let msg = err.to_string();
        assert!(
            msg.contains("x=500.000") && msg.contains("out of reach"),
            "{msg}"
        );

        let origin = Pose {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0,
        };
        assert!(matches!(
            robot.inverse(&origin, Posture::Right, None),
            Err(KinematicsError::TooClose { .. })
        ));
        let nan = Pose {
            x: f64::NAN,
            ..origin
        };
        assert_eq!(
            robot.inverse(&nan, Posture::Right, None),
            Err(KinematicsError::NotFinite { what: "x" })
        );
        let high = Pose {
            x: 200.0,
            y: 0.0,
            z: 301.0,
            yaw: 0.0,
        };
        assert!(matches!(
            robot.inverse(&high, Posture::Right, None),
            Err(KinematicsError::JointLimit { .. })
        ));
    }

    #[test]
    fn both_postures_reach_the_same_point() {
        let robot = Robot::paper_default();
        let pose = Pose {
            x: 150.0,
            y: 220.0,
            z: 10.0,
            yaw: 45.0,
        };
        let right = robot.inverse(&pose, Posture::Right, None).unwrap();
        let left = robot.inverse(&pose, Posture::Left, None).unwrap();
        assert!(right[1] > 0.0 && left[1] < 0.0);
        for j in [right, left] {
            let p = robot.forward(&j);
            assert!(close(p.x, pose.x, 1e-9) && close(p.y, pose.y, 1e-9));
            assert!(close(p.yaw, pose.yaw, 1e-9) && close(p.z, pose.z, 1e-12));
        }
    }

    proptest! {
        // FK∘IK: any reachable target within limits comes back within 1e-9 mm / 1e-9 deg.
        #[test]
        fn forward_of_inverse_is_identity(
            r in 5.0f64..395.0, phi in -180.0f64..180.0, yaw in -180.0f64..180.0,
            z in 0.0f64..300.0, right in any::<bool>(),
        ) {
            let robot = Robot::paper_default();
            let pose = Pose { x: r * phi.to_radians().cos(), y: r * phi.to_radians().sin(), z, yaw };
            let posture = if right { Posture::Right } else { Posture::Left };
            match robot.inverse(&pose, posture, None) {
                Ok(joints) => {
                    robot.check_joints(&joints).unwrap();
                    let back = robot.forward(&joints);
                    prop_assert!(close(back.x, pose.x, 1e-9) && close(back.y, pose.y, 1e-9));
                    prop_assert!(close(wrap180(back.yaw - pose.yaw), 0.0, 1e-9));
                    prop_assert!(close(back.z, pose.z, 1e-12));
                    prop_assert_eq!(Posture::of(&robot, &joints), Some(posture));
                }
                // Only the elbow limit (|J2| <= 165°, i.e. the nearly folded arm) may refuse.
                Err(KinematicsError::JointLimit { axis, .. }) => prop_assert_eq!(axis.as_str(), "j2"),
                Err(other) => prop_assert!(false, "unexpected {other}"),
            }
        }

        // IK∘FK: joints within limits and 2 mm from the singularities (|J2| >= ~11.5°) come back.
        #[test]
        fn inverse_of_forward_is_identity(
            j1 in -179.0f64..179.0, j2 in 15.0f64..160.0, j3 in -90.0f64..90.0, z in 0.0f64..300.0,
            left in any::<bool>(),
        ) {
            let robot = Robot::paper_default();
            let j2 = if left { -j2 } else { j2 };
            let joints = robot.joints_from_slice(&[j1, j2, j3, z]).unwrap();
            let pose = robot.forward(&joints);
            let posture = Posture::of(&robot, &joints).unwrap();
            let back = robot.inverse(&pose, posture, Some(&joints)).unwrap();
            for i in 0..4 {
                prop_assert!(close(back[i], joints[i], 1e-7), "axis {i}: {} vs {}", back[i], joints[i]);
            }
        }
    }
}
