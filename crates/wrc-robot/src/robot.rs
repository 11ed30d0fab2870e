//! The robot: its axes and the planar arm's geometry, validated once when built.

use crate::axis::{Axis, AxisName, AxisRole, Limits, Unit};
use crate::error::{KinematicsError, ModelError};
use crate::shape::{blade_capsule, ArmBodies, ArmShape, BladeLoad, BodyKind};
use crate::solid::{Capsule, Span};

/// Most axes one controller drives: four motion boards of four axes each.
pub const MAX_AXES: usize = 16;

/// Joint positions of every axis in axis units ([deg] or [mm]); entries past the robot's
/// axis count are unused and kept at zero.
pub type Joints = [f64; MAX_AXES];

/// Geometry of the planar arm and which axes play which role.
#[derive(Debug, Clone, PartialEq)]
pub struct Arm {
    /// Shoulder-to-elbow length L1 [mm].
    pub link1_mm: f64,
    /// Elbow-to-wrist length L2 [mm].
    pub link2_mm: f64,
    /// Distance from the wrist (J3) axis to the tool centre point along the hand [mm].
    pub hand_mm: f64,
    /// Distance kept from the stretched and folded singularities [mm]: targets and straight
    /// paths whose wrist point comes closer than this to them are rejected.
    pub singularity_margin_mm: f64,
    /// Index of the shoulder axis (J1).
    pub shoulder: usize,
    /// Index of the elbow axis (J2).
    pub elbow: usize,
    /// Index of the hand axis (J3), if the arm has one.
    pub wrist: Option<usize>,
    /// Index of the Z lift, if the arm has one.
    pub z: Option<usize>,
}

/// A validated robot: axes plus arm geometry.
#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    /// Human-readable model name.
    pub name: String,
    axes: Vec<Axis>,
    arm: Arm,
    shape: ArmShape,
}

fn positive(key: String, value: f64) -> Result<(), ModelError> {
    if !value.is_finite() {
        return Err(ModelError::new(
            key,
            format!("must be a finite number, got {value}"),
        ));
    }
    if value <= 0.0 {
        return Err(ModelError::new(
            key,
            format!("must be greater than 0, got {value}"),
        ));
    }
    Ok(())
}

fn finite(key: String, value: f64) -> Result<(), ModelError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(ModelError::new(
            key,
            format!("must be a finite number, got {value}"),
        ))
    }
}

impl Robot {
    /// Build a robot from its axes and arm geometry, checking every number.
    ///
    /// The arm's `shoulder`, `elbow`, `wrist` and `z` indices are derived from the axes'
    /// roles: exactly one shoulder and one elbow, at most one wrist and one Z.
    pub fn new(
        name: impl Into<String>,
        axes: Vec<Axis>,
        link1_mm: f64,
        link2_mm: f64,
        hand_mm: f64,
        singularity_margin_mm: f64,
    ) -> Result<Robot, ModelError> {
        positive("robot.link1_mm".into(), link1_mm)?;
        positive("robot.link2_mm".into(), link2_mm)?;
        finite("robot.hand_mm".into(), hand_mm)?;
        if hand_mm < 0.0 {
            return Err(ModelError::new(
                "robot.hand_mm",
                format!("must be 0 or more, got {hand_mm}"),
            ));
        }
        finite("robot.singularity_margin_mm".into(), singularity_margin_mm)?;
        if singularity_margin_mm < 0.0 {
            return Err(ModelError::new(
                "robot.singularity_margin_mm",
                format!("must be 0 or more, got {singularity_margin_mm}"),
            ));
        }
        let reach = link1_mm + link2_mm - (link1_mm - link2_mm).abs();
        if 2.0 * singularity_margin_mm >= reach {
            return Err(ModelError::new(
                "robot.singularity_margin_mm",
                format!("{singularity_margin_mm} mm leaves no workspace between the folded and stretched arm"),
            ));
        }
        if axes.is_empty() || axes.len() > MAX_AXES {
            return Err(ModelError::new(
                "axis",
                format!("a robot has 2 to {MAX_AXES} axes, got {}", axes.len()),
            ));
        }
        let mut shoulder = None;
        let mut elbow = None;
        let mut wrist = None;
        let mut z = None;
        for (i, axis) in axes.iter().enumerate() {
            let key = |field: &str| format!("axis.{}.{field}", axis.name);
            if axes[..i].iter().any(|a| a.name == axis.name) {
                return Err(ModelError::new(
                    format!("axis.{}", axis.name),
                    "this axis name is used twice; every axis needs its own name",
                ));
            }
            positive(key("pulses_per_unit"), axis.pulses_per_unit)?;
            positive(key("max_velocity"), axis.limits.max_velocity)?;
            positive(key("max_acceleration"), axis.limits.max_acceleration)?;
            positive(key("max_jerk"), axis.limits.max_jerk)?;
            finite(key("min"), axis.min)?;
            finite(key("max"), axis.max)?;
            finite(key("home"), axis.home)?;
            if axis.min >= axis.max {
                return Err(ModelError::new(
                    key("min"),
                    format!("must be below max ({} >= {})", axis.min, axis.max),
                ));
            }
            if !(axis.min..=axis.max).contains(&axis.home) {
                return Err(ModelError::new(
                    key("home"),
                    format!(
                        "{} is outside the axis limits [{}, {}]",
                        axis.home, axis.min, axis.max
                    ),
                ));
            }
            // Pulse counts are i64 and positions must survive the round trip through f64.
            let span_pulses = axis.min.abs().max(axis.max.abs()) * axis.pulses_per_unit;
            if span_pulses > 1e15 {
                return Err(ModelError::new(
                    key("pulses_per_unit"),
                    "gives pulse counts too large to represent exactly; lower it or the limits",
                ));
            }
            let slot = match axis.role {
                AxisRole::Shoulder => Some(&mut shoulder),
                AxisRole::Elbow => Some(&mut elbow),
                AxisRole::Wrist => Some(&mut wrist),
                AxisRole::Z => Some(&mut z),
                AxisRole::Auxiliary => None,
            };
            if let Some(slot) = slot {
                if slot.is_some() {
                    return Err(ModelError::new(
                        key("role"),
                        format!(
                            "a second axis with role {:?}; the arm has one of each",
                            axis.role.as_str()
                        ),
                    ));
                }
                *slot = Some(i);
            }
            let want_unit = match axis.role {
                AxisRole::Z => Some(Unit::Mm),
                AxisRole::Auxiliary => None,
                _ => Some(Unit::Deg),
            };
            if let Some(unit) = want_unit {
                if axis.unit != unit {
                    return Err(ModelError::new(
                        key("unit"),
                        format!(
                            "a {} axis is measured in {}",
                            axis.role.as_str(),
                            unit.as_str()
                        ),
                    ));
                }
            }
        }
        let (Some(shoulder), Some(elbow)) = (shoulder, elbow) else {
            return Err(ModelError::new(
                "axis",
                "the arm needs one axis with role \"shoulder\" and one with role \"elbow\"",
            ));
        };
        if wrist.is_none() && hand_mm > 0.0 {
            return Err(ModelError::new(
                "robot.hand_mm",
                "a hand offset needs an axis with role \"wrist\" to hold the hand's yaw; set it to 0 or add a wrist axis",
            ));
        }
        Ok(Robot {
            name: name.into(),
            axes,
            arm: Arm {
                link1_mm,
                link2_mm,
                hand_mm,
                singularity_margin_mm,
                shoulder,
                elbow,
                wrist,
                z,
            },
            shape: ArmShape::default(),
        })
    }

    /// The same robot with the bodies `shape` ([`ArmShape::validate`]d).
    pub fn with_shape(mut self, shape: ArmShape) -> Result<Robot, ModelError> {
        shape.validate()?;
        self.shape = shape;
        Ok(self)
    }

    /// The sizes of the arm's bodies.
    pub fn shape(&self) -> &ArmShape {
        &self.shape
    }

    /// The arm's bodies at `joints` [deg, mm] with `blades` (the hand first; at most
    /// [`crate::shape::MAX_BLADES`]): links 1 and 2, a bar from the wrist to the blades'
    /// palm when the hand reaches further than the blades do behind the TCP, and each
    /// blade with its wafer if it carries one. Allocation-free.
    pub fn bodies(&self, joints: &Joints, blades: &[BladeLoad]) -> ArmBodies {
        let arm = &self.arm;
        let shape = &self.shape;
        let j1 = joints[arm.shoulder].to_radians();
        let j12 = j1 + joints[arm.elbow].to_radians();
        let yaw = j12 + arm.wrist.map_or(0.0, |w| joints[w].to_radians());
        let z = arm.z.map_or(0.0, |i| joints[i]);
        let elbow = [arm.link1_mm * j1.cos(), arm.link1_mm * j1.sin()];
        let wrist = [
            elbow[0] + arm.link2_mm * j12.cos(),
            elbow[1] + arm.link2_mm * j12.sin(),
        ];
        let (s, c) = yaw.sin_cos();
        let tcp = [wrist[0] + arm.hand_mm * c, wrist[1] + arm.hand_mm * s];
        let mut out = ArmBodies {
            tcp,
            yaw: yaw.to_degrees(),
            z,
            ..ArmBodies::default()
        };
        let span = |[lo, hi]: [f64; 2]| Span::new(z + lo, z + hi);
        out.push(
            Capsule::new(
                [0.0, 0.0],
                elbow,
                shape.link1_radius_mm,
                span(shape.link1_z_mm),
            ),
            BodyKind::Link1,
        );
        out.push(
            Capsule::new(elbow, wrist, shape.link2_radius_mm, span(shape.link2_z_mm)),
            BodyKind::Link2,
        );
        let lowest = blades.iter().map(|b| b.z_offset_mm).fold(0.0f64, f64::min);
        if arm.hand_mm > shape.blade_back_mm {
            let palm = arm.hand_mm - shape.blade_back_mm;
            out.push(
                Capsule::new(
                    wrist,
                    [wrist[0] + palm * c, wrist[1] + palm * s],
                    shape.blade_half_width_mm.min(shape.link2_radius_mm),
                    Span::new(z + lowest - shape.blade_thickness_mm, z),
                ),
                BodyKind::HandBar,
            );
        }
        for (i, blade) in blades.iter().take(crate::shape::MAX_BLADES).enumerate() {
            let plane = z + blade.z_offset_mm;
            out.push(
                blade_capsule(
                    shape,
                    tcp,
                    (c, s),
                    Span::new(plane - shape.blade_thickness_mm, plane),
                ),
                BodyKind::Blade(i as u8),
            );
            if blade.wafer {
                out.push(
                    Capsule::disc(
                        tcp,
                        shape.wafer_radius_mm,
                        Span::new(plane, plane + shape.wafer_thickness_mm),
                    ),
                    BodyKind::Wafer(i as u8),
                );
            }
        }
        out
    }

    /// The paper's robot (Fig. 2): two 200 mm links, a hand joint and a Z lift; the same as
    /// the embedded default configuration. Handy for tests and examples.
    pub fn paper_default() -> Robot {
        let axis = |name: &str, role, unit, ppu, min, max, v, a, j, home| Axis {
            name: AxisName::new(name).expect("valid built-in axis name"),
            role,
            unit,
            pulses_per_unit: ppu,
            min,
            max,
            limits: Limits {
                max_velocity: v,
                max_acceleration: a,
                max_jerk: j,
            },
            home,
        };
        let axes = vec![
            axis(
                "j1",
                AxisRole::Shoulder,
                Unit::Deg,
                1000.0,
                -180.0,
                180.0,
                180.0,
                720.0,
                7200.0,
                -75.0,
            ),
            axis(
                "j2",
                AxisRole::Elbow,
                Unit::Deg,
                1000.0,
                -165.0,
                165.0,
                180.0,
                720.0,
                7200.0,
                150.0,
            ),
            axis(
                "j3",
                AxisRole::Wrist,
                Unit::Deg,
                1000.0,
                -270.0,
                270.0,
                360.0,
                1440.0,
                14400.0,
                -75.0,
            ),
            axis(
                "z",
                AxisRole::Z,
                Unit::Mm,
                1000.0,
                0.0,
                300.0,
                200.0,
                1000.0,
                10000.0,
                0.0,
            ),
        ];
        Robot::new("paper-300mm", axes, 200.0, 200.0, 0.0, 2.0).expect("valid built-in robot")
    }

    /// The axes, in board order.
    pub fn axes(&self) -> &[Axis] {
        &self.axes
    }

    /// Number of axes.
    pub fn axis_count(&self) -> usize {
        self.axes.len()
    }

    /// The arm's geometry and axis roles.
    pub fn arm(&self) -> &Arm {
        &self.arm
    }

    /// Index of the axis called `name` (case-insensitive).
    pub fn axis_index(&self, name: &str) -> Option<usize> {
        self.axes
            .iter()
            .position(|a| a.name.as_str().eq_ignore_ascii_case(name))
    }

    /// The home position of every axis.
    pub fn home(&self) -> Joints {
        let mut joints = [0.0; MAX_AXES];
        for (j, axis) in joints.iter_mut().zip(&self.axes) {
            *j = axis.home;
        }
        joints
    }

    /// Build a joint vector from a slice with exactly one value per axis.
    pub fn joints_from_slice(&self, values: &[f64]) -> Result<Joints, KinematicsError> {
        if values.len() != self.axes.len() {
            return Err(KinematicsError::AxisCount {
                expected: self.axes.len(),
                got: values.len(),
            });
        }
        let mut joints = [0.0; MAX_AXES];
        joints[..values.len()].copy_from_slice(values);
        Ok(joints)
    }

    /// Check that every joint is a finite number within its soft limits.
    pub fn check_joints(&self, joints: &Joints) -> Result<(), KinematicsError> {
        for (axis, &value) in self.axes.iter().zip(joints) {
            if !value.is_finite() {
                return Err(KinematicsError::NotFinite {
                    what: "a joint value",
                });
            }
            if !axis.within_limits(value) {
                return Err(KinematicsError::JointLimit {
                    axis: axis.name,
                    value,
                    min: axis.min,
                    max: axis.max,
                });
            }
        }
        Ok(())
    }

    /// Joint positions in units of a pulse vector.
    pub fn pulses_to_joints(&self, pulses: &[i64; MAX_AXES]) -> Joints {
        let mut joints = [0.0; MAX_AXES];
        for ((j, axis), &p) in joints.iter_mut().zip(&self.axes).zip(pulses) {
            *j = axis.pulses_to_units(p);
        }
        joints
    }

    /// Nearest pulse vector of a joint vector.
    pub fn joints_to_pulses(&self, joints: &Joints) -> [i64; MAX_AXES] {
        let mut pulses = [0i64; MAX_AXES];
        for ((p, axis), &j) in pulses.iter_mut().zip(&self.axes).zip(joints) {
            *p = axis.units_to_pulses(j);
        }
        pulses
    }
}
