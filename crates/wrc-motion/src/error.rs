//! Errors of the velocity generator: bad settings and moves that cannot be planned.

use wrc_robot::{AxisName, KinematicsError, Pose, Unit};

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
    /// A straight line that leaves the workspace somewhere between its ends: its wrist
    /// point comes within the singularity margin of the stretched or folded arm, or a joint
    /// would leave its limits (joints are followed continuously along the line, never
    /// wrapped a turn).
    #[error(
        "the straight line leaves the workspace from {fraction_pct:.1} % of its length on \
         (x={x:.3} y={y:.3} z={z:.3} yaw={yaw:.3}): {problem}",
        x = pose.x, y = pose.y, z = pose.z, yaw = pose.yaw
    )]
    PathLeavesWorkspace {
        /// Where along the line the problem starts, 0-100 [%] of the path parameter (the
        /// TCP's distance, or the hand's turn for a pure rotation).
        fraction_pct: f64,
        /// The TCP pose there [mm, mm, mm, deg].
        pose: Pose,
        /// What happens there.
        problem: PathProblem,
    },
    /// A straight line that the timing law cannot take to its end within the limits (a
    /// geometry so close to a singular spot that no motion keeps every limit there).
    #[error(
        "the straight line cannot be timed within the joint limits beyond {fraction_pct:.1} % \
         of its length; move in two steps or use MOVP"
    )]
    Untimed {
        /// How far the law got [%].
        fraction_pct: f64,
    },
    /// A straight line would need the elbow to flip between the two postures.
    #[error("the straight line needs the elbow to change posture on the way; move in two steps or use MOVP")]
    PostureChange,

    /// No blended approach to the line's start keeps every joint in range (and, entering
    /// moving, the hand behind the start): the transfer cannot be made from here.
    #[error("no approach to the station's line keeps the hand behind its approach pose; teach the approach pose further back")]
    ApproachCrossesEntry,
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
    /// An acceleration override outside 1-100 %.
    #[error("acceleration override must be from 1 to 100 %, got {0}")]
    AccelOverride(f64),
    /// A move so long that its pulse count or duration cannot be represented.
    #[error("the move is too long to plan ({0})")]
    TooLong(&'static str),
    /// A paper-profile move whose input stream would exceed the preallocated delay line.
    #[error("another move is still running; stop it or wait until it has finished")]
    Busy,
}

/// Why a straight path is refused at some point.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PathProblem {
    /// The wrist point comes within the singularity margin of the stretched arm.
    #[error(
        "the arm would come too close to the stretched arm (the wrist point {r_mm:.3} mm \
         from the shoulder, at most {limit_mm:.3} mm allowed)"
    )]
    Stretched {
        /// Distance of the wrist point from the shoulder there [mm].
        r_mm: f64,
        /// Largest allowed distance: L1 + L2 minus the singularity margin [mm].
        limit_mm: f64,
    },
    /// The wrist point comes within the singularity margin of the folded arm.
    #[error(
        "the arm would come too close to the folded arm (the wrist point {r_mm:.3} mm from \
         the shoulder, at least {limit_mm:.3} mm needed)"
    )]
    Folded {
        /// Distance of the wrist point from the shoulder there [mm].
        r_mm: f64,
        /// Smallest allowed distance: |L1 − L2| plus the singularity margin [mm].
        limit_mm: f64,
    },
    /// A joint would leave its limits.
    #[error(
        "axis {axis} would go beyond its limits [{min}, {max}] (to {extreme:.3} {unit})",
        unit = unit.as_str()
    )]
    JointLimit {
        /// The axis.
        axis: AxisName,
        /// Its unit.
        unit: Unit,
        /// The farthest value the line would take it to (beyond `min` or `max`) [unit].
        extreme: f64,
        /// Lower soft limit [unit].
        min: f64,
        /// Upper soft limit [unit].
        max: f64,
    },
}
