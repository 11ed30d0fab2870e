//! The description of a Cartesian path that a caller hands to the velocity generator: where
//! it starts and up to [`MAX_PATH_SEGMENTS`] segments, each a straight line or a circular arc,
//! every corner between two of them rounded by a blend zone. Fixed-size and `Copy`, so a
//! real-time task can send it in a message and keep it to resume a held move.

use wrc_robot::Pose;

use crate::error::PlanError;

/// Most segments of one path.
pub const MAX_PATH_SEGMENTS: usize = 8;

/// One segment of a path, from where the previous one ends (the path's start for the
/// first). `blend_mm` is the blend zone of the corner at its end [mm]: the TCP leaves the
/// segment at most that far before the corner and joins the next at most that far after it,
/// on a curve of continuous curvature that stays within that distance of the corner point
/// (clamped to half of each segment's length). 0 goes through the corner point, which only a
/// corner where the two segments are tangent allows without stopping. Ignored on the last
/// segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PathSegment {
    /// A straight line to `to`; z and yaw change linearly along it (the yaw the short way
    /// round).
    Line {
        /// Where it ends [mm, mm, mm, deg].
        to: Pose,
        /// Blend zone of the corner at its end [mm].
        blend_mm: f64,
    },
    /// The circular arc in x-y from where it starts through `via` to `to`: the arc of the
    /// circle through the three points that contains `via`. z and yaw change linearly with
    /// the arc length from the start to `to` (the yaw the short way round); `via` sets only
    /// the circle (its z and yaw are not used).
    Arc {
        /// A point of the arc between its ends [mm, mm, -, -].
        via: Pose,
        /// Where it ends [mm, mm, mm, deg].
        to: Pose,
        /// Blend zone of the corner at its end [mm].
        blend_mm: f64,
    },
}

impl PathSegment {
    /// Where the segment ends.
    pub fn to(&self) -> Pose {
        match self {
            PathSegment::Line { to, .. } | PathSegment::Arc { to, .. } => *to,
        }
    }

    /// The blend zone of the corner at its end [mm].
    pub fn blend_mm(&self) -> f64 {
        match self {
            PathSegment::Line { blend_mm, .. } | PathSegment::Arc { blend_mm, .. } => *blend_mm,
        }
    }
}

impl Default for PathSegment {
    fn default() -> Self {
        PathSegment::Line {
            to: Pose::default(),
            blend_mm: 0.0,
        }
    }
}

/// A path: its start and its segments. `start` is where the path begins: the end of the
/// previous motion (the velocity generator refuses a path from anywhere else, except a
/// point of the path itself, where it continues along the rest: a RESUME after a HOLD).
/// The elbow keeps its posture along the whole path and every joint is followed
/// continuously, as along a straight line.
///
/// ```
/// use wrc_motion::{PathSegment, PathSpec};
/// use wrc_robot::Pose;
///
/// let p = |x: f64, y: f64| Pose { x, y, z: 0.0, yaw: 0.0 };
/// let mut path = PathSpec::new(p(250.0, -100.0));
/// path.push(PathSegment::Line { to: p(250.0, 0.0), blend_mm: 20.0 }).unwrap();
/// path.push(PathSegment::Arc { via: p(300.0, 50.0), to: p(350.0, 0.0), blend_mm: 0.0 }).unwrap();
/// assert_eq!(path.segments().len(), 2);
/// assert_eq!(path.end(), Some(p(350.0, 0.0)));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathSpec {
    /// Where the path starts [mm, mm, mm, deg].
    pub start: Pose,
    /// The segments; those from `len` on are not used.
    pub segments: [PathSegment; MAX_PATH_SEGMENTS],
    /// How many segments there are, 1 to [`MAX_PATH_SEGMENTS`].
    pub len: usize,
}

impl PathSpec {
    /// A path from `start` with no segment yet.
    pub fn new(start: Pose) -> PathSpec {
        PathSpec {
            start,
            segments: [PathSegment::default(); MAX_PATH_SEGMENTS],
            len: 0,
        }
    }

    /// A path of one straight line from `start` to `to`.
    pub fn line(start: Pose, to: Pose) -> PathSpec {
        let mut p = PathSpec::new(start);
        p.segments[0] = PathSegment::Line { to, blend_mm: 0.0 };
        p.len = 1;
        p
    }

    /// Add a segment at the end; refused ([`PlanError::PathSegments`]) when the path already
    /// has [`MAX_PATH_SEGMENTS`].
    pub fn push(&mut self, segment: PathSegment) -> Result<(), PlanError> {
        if self.len >= MAX_PATH_SEGMENTS {
            return Err(PlanError::PathSegments {
                len: self.len.saturating_add(1),
            });
        }
        self.segments[self.len] = segment;
        self.len += 1;
        Ok(())
    }

    /// The segments in use (at most [`MAX_PATH_SEGMENTS`], whatever `len` says).
    pub fn segments(&self) -> &[PathSegment] {
        &self.segments[..self.len.min(MAX_PATH_SEGMENTS)]
    }

    /// Where the path ends; `None` without segments.
    pub fn end(&self) -> Option<Pose> {
        self.segments().last().map(PathSegment::to)
    }
}
