//! Errors of the robot model: an invalid model, and a pose or joint vector the arm cannot take.

use crate::axis::AxisName;

/// A robot model that cannot be used. `key` names the offending setting the way the
/// configuration file spells it (`axis.j1.max_velocity`, `robot.link1_mm`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key}: {reason}")]
#[non_exhaustive]
pub struct ModelError {
    /// The setting, as the configuration file names it.
    pub key: String,
    /// What is wrong with it and what is expected.
    pub reason: String,
}

impl ModelError {
    pub(crate) fn new(key: impl Into<String>, reason: impl Into<String>) -> Self {
        ModelError {
            key: key.into(),
            reason: reason.into(),
        }
    }
}

/// A target the arm cannot reach, or an input that is not a usable number.
///
/// Every variant is `Copy` and carries the numbers needed for a clear message, so building
/// one never allocates (kinematics run in real-time cycles).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum KinematicsError {
    /// A coordinate or joint value is NaN or infinite.
    #[error("{what} is not a finite number")]
    NotFinite {
        /// Which value (`x`, `y`, `z`, `yaw`, or a joint).
        what: &'static str,
    },
    /// The wrist point is farther from the shoulder than the stretched arm reaches.
    #[error(
        "target x={x:.3} y={y:.3} mm is out of reach: its wrist point is {r:.3} mm from the shoulder, \
         the arm reaches at most {max:.3} mm (minus a {margin:.3} mm singularity margin)"
    )]
    TooFar {
        /// Target x [mm].
        x: f64,
        /// Target y [mm].
        y: f64,
        /// Distance of the wrist point from the shoulder axis [mm].
        r: f64,
        /// Reach of the stretched arm, L1 + L2 [mm].
        max: f64,
        /// Margin kept from the stretched singularity [mm].
        margin: f64,
    },
    /// The wrist point is closer to the shoulder than the folded arm allows.
    #[error(
        "target x={x:.3} y={y:.3} mm is out of reach: its wrist point is {r:.3} mm from the shoulder, \
         the folded arm needs at least {min:.3} mm (|L1-L2| plus a {margin:.3} mm singularity margin)"
    )]
    TooClose {
        /// Target x [mm].
        x: f64,
        /// Target y [mm].
        y: f64,
        /// Distance of the wrist point from the shoulder axis [mm].
        r: f64,
        /// |L1 - L2| [mm].
        min: f64,
        /// Margin kept from the folded singularity [mm].
        margin: f64,
    },
    /// A joint would leave its soft limits.
    #[error("axis {axis} would be at {value:.4}, outside its limits [{min}, {max}]")]
    JointLimit {
        /// The axis.
        axis: AxisName,
        /// The joint value the target needs [deg or mm].
        value: f64,
        /// Lower soft limit.
        min: f64,
        /// Upper soft limit.
        max: f64,
    },
    /// The robot has no Z axis, so a target must have z = 0.
    #[error("this robot has no Z axis, so z must be 0 (got {z})")]
    NoZAxis {
        /// The requested z [mm].
        z: f64,
    },
    /// A joint vector with the wrong number of values.
    #[error("expected {expected} joint values, got {got}")]
    AxisCount {
        /// The robot's axis count.
        expected: usize,
        /// The number given.
        got: usize,
    },
}
