//! Errors of the velocity generator: bad settings and moves that cannot be planned.

use wrc_robot::{AxisName, KinematicsError, Pose, Unit};

use crate::path_spec::MAX_PATH_SEGMENTS;

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
    /// A straight line or path that the timing law cannot take to its end within the limits
    /// (a geometry so close to a singular spot that no motion keeps every limit there).
    #[error(
        "the motion along the path cannot be timed within the joint limits beyond \
         {fraction_pct:.1} % of it; move in two steps or use MOVP"
    )]
    Untimed {
        /// How far the law got [%].
        fraction_pct: f64,
    },
    /// A straight line or path would need the elbow to flip between the two postures.
    #[error(
        "the path needs the elbow to change posture on the way; move in two steps or use MOVP"
    )]
    PostureChange,

    /// A path that leaves the workspace somewhere along it: as
    /// [`PlanError::PathLeavesWorkspace`], naming the segment (or the blend after it).
    #[error(
        "the path leaves the workspace in {place} from {fraction_pct:.1} % of the path on \
         (x={x:.3} y={y:.3} z={z:.3} yaw={yaw:.3}): {problem}",
        x = pose.x, y = pose.y, z = pose.z, yaw = pose.yaw
    )]
    SegmentLeavesWorkspace {
        /// The segment, or the blend after it, where the problem starts.
        place: PathPlace,
        /// Where along the whole path it starts, 0-100 [%] of its parameter (close to the
        /// fraction of its length).
        fraction_pct: f64,
        /// The TCP pose there [mm, mm, mm, deg].
        pose: Pose,
        /// What happens there.
        problem: PathProblem,
    },
    /// A path without segments, or with more than [`MAX_PATH_SEGMENTS`].
    #[error("a path has 1 to {max} segments, got {len}", max = MAX_PATH_SEGMENTS)]
    PathSegments {
        /// How many it has.
        len: usize,
    },
    /// An arc that defines no circle.
    #[error("segment {segment} of the path: {problem}")]
    Arc {
        /// The segment, from 1.
        segment: usize,
        /// What is wrong with it.
        problem: ArcProblem,
    },
    /// A segment along which the TCP does not move.
    #[error(
        "segment {segment} of the path does not move the TCP (less than 0.01 mm): turn the \
         hand with a straight line of its own"
    )]
    SegmentTooShort {
        /// The segment, from 1.
        segment: usize,
    },
    /// A blend zone that is negative or not a number.
    #[error("the blend zone of segment {segment} must be 0 mm or more, got {blend_mm}")]
    BlendZone {
        /// The segment, from 1.
        segment: usize,
        /// The zone given [mm].
        blend_mm: f64,
    },
    /// A corner without a blend zone where the segments are not tangent: the TCP would have
    /// to stop there.
    #[error(
        "the corner after segment {segment} turns by {angle_deg:.1} deg with no blend zone: \
         the robot would have to stop there; give it a blend zone or end the path at it"
    )]
    SharpCorner {
        /// The segment before the corner, from 1.
        segment: usize,
        /// How much the direction of the TCP turns there [deg].
        angle_deg: f64,
    },
    /// A corner that turns back so sharply that no blend within its zone keeps the TCP
    /// moving.
    #[error(
        "the corner after segment {segment} turns back by {angle_deg:.1} deg: no blend within \
         {blend_mm} mm of it keeps the TCP moving; end the path at it"
    )]
    CornerTurnsBack {
        /// The segment before the corner, from 1.
        segment: usize,
        /// How much the direction of the TCP turns there [deg].
        angle_deg: f64,
        /// The blend zone [mm].
        blend_mm: f64,
    },
    /// A path ordered from a pose that is neither its start nor a point of it.
    #[error(
        "the robot (x={x:.3} y={y:.3} z={z:.3} yaw={yaw:.3}) is neither at the path's start \
         (x={sx:.3} y={sy:.3} z={sz:.3} yaw={syaw:.3}) nor on the path: move it to the start first",
        x = here.x, y = here.y, z = here.z, yaw = here.yaw,
        sx = start.x, sy = start.y, sz = start.z, syaw = start.yaw
    )]
    NotOnPath {
        /// Where the robot is.
        here: Pose,
        /// Where the path starts.
        start: Pose,
    },
    /// A path or a blended move under the paper profile, whose moves start and end at rest.
    #[error(
        "paths, arcs and blended moves need the default profile (motion.profile = \"fir\"); \
         under the paper profile use separate moves"
    )]
    ProfileUnsupported,
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

/// Where along a path: a segment, or the blend at the corner after it. (Small on purpose:
/// [`PlanError`] carries it and is sent in messages.)
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PathPlace {
    /// The segment, from 1 (at most [`MAX_PATH_SEGMENTS`]).
    pub segment: u8,
    /// In the blend at the corner after the segment, not on the segment itself.
    pub blend: bool,
}

impl std::fmt::Display for PathPlace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.blend {
            write!(f, "the blend after segment {}", self.segment)
        } else {
            write!(f, "segment {}", self.segment)
        }
    }
}

/// Why an arc defines no circle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ArcProblem {
    /// Its start, via point and end are on a line (or nearly: a radius over 100 m).
    #[error("the arc's start, via point and end are on a line: use a straight line (MOVL)")]
    Collinear,
    /// Its via point coincides with its start or its end (within 0.01 mm).
    #[error(
        "the arc's via point is at its start or its end: give a point between them on the arc"
    )]
    ViaAtEnd,
    /// It ends where it starts (within 0.01 mm in x-y): a full circle is not one arc.
    #[error("the arc ends where it starts: a full circle takes two arcs")]
    Closed,
}
