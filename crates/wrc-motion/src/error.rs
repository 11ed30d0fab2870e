//! Errors of the velocity generator: bad settings and moves that cannot be planned.

use wrc_robot::{AxisName, KinematicsError};

/// A setting of the velocity generator that cannot be used; `key` names it as the
/// configuration file does.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{key}: {reason}")]
#[non_exhaustive]
pub struct SettingsError {
    /// The configuration key (`motion.period_ms`, …).
    pub key: String,
    /// What is wrong and what is expected.
    pub reason: String,
}

impl SettingsError {
    pub(crate) fn new(key: impl Into<String>, reason: impl Into<String>) -> Self {
        SettingsError {
            key: key.into(),
            reason: reason.into(),
        }
    }
}

/// A move that is refused before any pulse is produced.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PlanError {
    /// The start or target pose cannot be reached, or a point along the path cannot.
    #[error(transparent)]
    Kinematics(#[from] KinematicsError),
    /// A straight line whose wrist path comes too close to a singularity or leaves the
    /// workspace somewhere between its ends.
    #[error(
        "the straight line leaves the workspace at {fraction_pct:.1} % of its length \
         (x={x:.3} y={y:.3} mm): {reason}"
    )]
    PathLeavesWorkspace {
        /// Where along the line, 0-100 [%].
        fraction_pct: f64,
        /// TCP x there [mm].
        x: f64,
        /// TCP y there [mm].
        y: f64,
        /// What happens there.
        reason: PathProblem,
    },
    /// A straight line would need the elbow to flip between the two postures.
    #[error("the straight line needs the elbow to change posture on the way; move in two steps or use MOVP")]
    PostureChange,
    /// A number is NaN or infinite.
    #[error("{what} is not a finite number")]
    NotFinite {
        /// Which input.
        what: &'static str,
    },
    /// A jog on an axis that does not exist.
    #[error("axis index {index} does not exist; the robot has {count} axes")]
    NoSuchAxis {
        /// The index asked for.
        index: usize,
        /// The robot's axis count.
        count: usize,
    },
    /// A jog that would leave the axis limits.
    #[error("axis {axis} would end at {target:.4}, outside its limits [{min}, {max}]")]
    JogBeyondLimit {
        /// The axis.
        axis: AxisName,
        /// Where it would end [unit].
        target: f64,
        /// Lower soft limit.
        min: f64,
        /// Upper soft limit.
        max: f64,
    },
    /// A speed override outside 1-100 %.
    #[error("speed override must be from 1 to 100 %, got {0}")]
    SpeedOverride(f64),
    /// A move so long that its pulse count or duration cannot be represented.
    #[error("the move is too long to plan ({0})")]
    TooLong(&'static str),
    /// A paper-profile move whose input stream would exceed the preallocated delay line.
    #[error("another move is still running; stop it or wait until it has finished")]
    Busy,
}

/// Why a straight path is refused at some point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum PathProblem {
    /// The wrist point comes within the singularity margin of the stretched arm.
    #[error("the arm would be (nearly) stretched")]
    Stretched,
    /// The wrist point comes within the singularity margin of the folded arm.
    #[error("the arm would be (nearly) folded")]
    Folded,
    /// A joint would leave its limits.
    #[error("a joint would leave its limits")]
    JointLimit,
}
