//! Closed-form forward and inverse kinematics of the planar arm.
//!
//! Conventions: angles in degrees, lengths in millimetres; J1 is measured from the base x
//! axis, J2 from the first link, J3 from the second link, all counter-clockwise seen from
//! above. The hand's yaw is J1 + J2 + J3. The tool centre point (TCP) lies `hand_mm` along
//! the hand from the J3 axis. No allocation, no I/O: safe in a real-time cycle.

use crate::error::KinematicsError;
use crate::jet::Jet;
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

/// A pose whose coordinates are [`Jet`]s along a path parameter u: x, y, z [mm] and yaw
/// [deg], each with its derivatives with respect to u.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PoseJet {
    /// x [mm] and its derivatives.
    pub x: Jet,
    /// y [mm] and its derivatives.
    pub y: Jet,
    /// z [mm] and its derivatives.
    pub z: Jet,
    /// yaw [deg] and its derivatives.
    pub yaw: Jet,
}

impl PoseJet {
    /// The pose at the jet's point.
    pub fn value(&self) -> Pose {
        Pose {
            x: self.x.value(),
            y: self.y.value(),
            z: self.z.value(),
            yaw: self.yaw.value(),
        }
    }
}

/// The inverse kinematics along a path at one point: every joint as a [`Jet`] (value and
/// derivatives along the path), and the wrist point's distance from the shoulder axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointJets {
    /// Joint values [deg or mm] and their derivatives; axes that the arm does not move
    /// (auxiliary axes) are constants.
    pub joints: [Jet; MAX_AXES],
    /// Distance of the wrist (J3) point from the shoulder axis [mm], with its derivatives.
    pub wrist_radius: Jet,
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
///
/// ```
/// assert_eq!(wrc_robot::wrap180(190.0), -170.0);
/// assert_eq!(wrc_robot::wrap180(-180.0), 180.0);
/// ```
pub fn wrap180(deg: f64) -> f64 {
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

    /// Inverse kinematics on jets: the joints at a point of a path and their exact
    /// derivatives along it. Angles are continued from `reference` (the nearest 360° turn,
    /// *without* the soft limits: a path that needs a joint beyond its limits shows it,
    /// instead of jumping a turn), so consecutive points of a path give continuous joints.
    /// Neither the singularity margin nor the joint limits are checked; the wrist point must
    /// lie strictly between the folded and stretched arm, where the derivatives are finite.
    pub fn inverse_jet(
        &self,
        pose: &PoseJet,
        posture: Posture,
        reference: &Joints,
    ) -> Result<JointJets, KinematicsError> {
        let p = pose.value();
        for (what, v) in [("x", p.x), ("y", p.y), ("z", p.z), ("yaw", p.yaw)] {
            if !v.is_finite() {
                return Err(KinematicsError::NotFinite { what });
            }
        }
        let arm = self.arm();
        let (l1, l2) = (arm.link1_mm, arm.link2_mm);
        let (wx, wy) = if arm.hand_mm > 0.0 {
            let yaw = pose.yaw.scale(std::f64::consts::PI / 180.0);
            (
                pose.x - yaw.cos().scale(arm.hand_mm),
                pose.y - yaw.sin().scale(arm.hand_mm),
            )
        } else {
            (pose.x, pose.y)
        };
        let r2 = wx * wx + wy * wy;
        let r = r2.value().sqrt();
        if r >= l1 + l2 {
            return Err(KinematicsError::TooFar {
                x: p.x,
                y: p.y,
                r,
                max: l1 + l2,
                margin: 0.0,
            });
        }
        if r <= (l1 - l2).abs() || r <= 0.0 {
            return Err(KinematicsError::TooClose {
                x: p.x,
                y: p.y,
                r,
                min: (l1 - l2).abs(),
                margin: 0.0,
            });
        }
        let c2 = r2.offset(-(l1 * l1 + l2 * l2)).scale(1.0 / (2.0 * l1 * l2));
        let t2 = match posture {
            Posture::Right => c2.acos(),
            Posture::Left => -c2.acos(),
        };
        let beta = t2.sin().scale(l2).atan2(t2.cos().scale(l2).offset(l1));
        let deg = 180.0 / std::f64::consts::PI;
        let t1 = (wy.atan2(wx) - beta).scale(deg);
        let t2 = t2.scale(deg);
        let mut joints = [Jet::default(); MAX_AXES];
        for (j, &r) in joints.iter_mut().zip(reference).take(self.axis_count()) {
            *j = Jet::constant(r);
        }
        let turn = |j: Jet, near: f64| j.offset(360.0 * ((near - j.value()) / 360.0).round());
        joints[arm.shoulder] = turn(t1, reference[arm.shoulder]);
        joints[arm.elbow] = turn(t2, reference[arm.elbow]);
        if let Some(w) = arm.wrist {
            let t3 = pose.yaw - joints[arm.shoulder] - joints[arm.elbow];
            joints[w] = turn(t3, reference[w]);
        }
        match arm.z {
            Some(z) => joints[z] = pose.z,
            None if p.z != 0.0 => return Err(KinematicsError::NoZAxis { z: p.z }),
            None => {}
        }
        Ok(JointJets {
            joints,
            wrist_radius: r2.sqrt(),
        })
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

    /// The pose jet of the straight segment a→b at parameter u (yaw linear too).
    fn segment(a: Pose, b: Pose, u: f64) -> PoseJet {
        let lin = |p: f64, q: f64| Jet::variable(p + u * (q - p), q - p);
        PoseJet {
            x: lin(a.x, b.x),
            y: lin(a.y, b.y),
            z: lin(a.z, b.z),
            yaw: lin(a.yaw, b.yaw),
        }
    }

    #[test]
    fn joint_jets_are_the_derivatives_of_the_inverse_kinematics() {
        let paper = Robot::paper_default();
        let hand = Robot::new("hand", paper.axes().to_vec(), 200.0, 200.0, 120.0, 2.0).unwrap();
        let a = Pose {
            x: 150.0,
            y: -120.0,
            z: 10.0,
            yaw: -40.0,
        };
        let b = Pose {
            x: 60.0,
            y: 230.0,
            z: 90.0,
            yaw: 70.0,
        };
        for robot in [paper, hand] {
            for posture in [Posture::Right, Posture::Left] {
                let q = |u: f64| {
                    let p = segment(a, b, u).value();
                    robot
                        .inverse_checked(&p, posture, None, IkCheck::CONTINUE)
                        .unwrap()
                };
                let q0 = q(0.0);
                for u in [0.1, 0.45, 0.8] {
                    let jets = robot
                        .inverse_jet(&segment(a, b, u), posture, &q(u))
                        .unwrap();
                    for ax in 0..4 {
                        // Steps for each order: finite differences lose digits as 1/h^k.
                        let h = 2e-4;
                        let f = |k: f64| {
                            let mut v = q(u + k * h)[ax];
                            // Continue across ±180°.
                            v += 360.0 * ((q(u)[ax] - v) / 360.0).round();
                            v
                        };
                        let d1 = (f(1.0) - f(-1.0)) / (2.0 * h);
                        let d2 = (f(1.0) - 2.0 * f(0.0) + f(-1.0)) / (h * h);
                        let d3 =
                            (f(2.0) - 2.0 * f(1.0) + 2.0 * f(-1.0) - f(-2.0)) / (2.0 * h * h * h);
                        let j = jets.joints[ax].d;
                        assert!(close(j[0], f(0.0), 1e-9), "axis {ax} value");
                        assert!(
                            close(j[1], d1, 1e-4 * d1.abs().max(1.0)),
                            "axis {ax} d1 {} {d1}",
                            j[1]
                        );
                        assert!(
                            close(j[2], d2, 1e-3 * d2.abs().max(1.0)),
                            "axis {ax} d2 {} {d2}",
                            j[2]
                        );
                        assert!(
                            close(j[3], d3, 1e-2 * d3.abs().max(10.0)),
                            "axis {ax} d3 {} {d3}",
                            j[3]
                        );
                    }
                    let r = robot.wrist_radius(&segment(a, b, u).value());
                    assert!(close(jets.wrist_radius.value(), r, 1e-9));
                }
                let _ = q0;
            }
        }
    }

    #[test]
    fn joint_jets_continue_past_the_soft_limits() {
        // J1 near +180°: the reference decides the turn, the limits do not.
        let robot = Robot::paper_default();
        let pose = Pose {
            x: -300.0,
            y: 10.0,
            z: 0.0,
            yaw: 180.0,
        };
        let strict = robot.inverse(&pose, Posture::Left, None).unwrap();
        let mut reference = strict;
        reference[0] += 360.0;
        let jets = robot
            .inverse_jet(&segment(pose, pose, 0.0), Posture::Left, &reference)
            .unwrap();
        assert!(close(jets.joints[0].value(), strict[0] + 360.0, 1e-9));
        assert!(jets.joints[0].value() > 180.0);
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
