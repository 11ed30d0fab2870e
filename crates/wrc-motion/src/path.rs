//! Straight-line paths (the paper's Table 2): the TCP moves on the segment from a start pose
//! to a target pose, parametrised by u in [0, 1]; the hand's yaw and the Z height change
//! linearly with u. This module holds the geometry: the pose and the joints at any u, the
//! check of every point of a line against the workspace and the joint limits, and the
//! joints' derivatives along it, which the timing law needs.
//!
//! Joints are followed *continuously* along a line (the inverse kinematics on
//! [`wrc_robot::Jet`]s continues each angle from the previous point, never wrapping a turn),
//! so a line on which the shoulder would pass ±180° either stays in a joint range wider
//! than 360° or is refused, with the axis, where along the line and the pose there.
//!
//! The check samples the line densely and finds, between samples, every crossing of a
//! limit and every extremum of a joint or of the wrist radius exactly (by bisection and
//! Newton steps on the exact derivatives), so a limit passed between two samples is found
//! too. Planning and the check do not allocate; the derivative table is preallocated.

use std::sync::atomic::{AtomicU64, Ordering};

use wrc_robot::{
    wrap180, IkCheck, Jet, JointJets, Joints, KinematicsError, Pose, PoseJet, Posture, Robot,
    MAX_AXES,
};

use crate::error::{PathProblem, PlanError};
use crate::geometry::Geometry;
use crate::geometry::MAX_TABLE_PIECES;
use crate::settings::LineLimits;

/// Spacing of the samples that check a line and tabulate its derivatives: along the TCP
/// path [mm] (and the Z travel).
pub const SAMPLE_MM: f64 = 0.5;
/// Spacing of the samples of the hand's turn [deg].
pub const SAMPLE_DEG: f64 = 0.25;
/// Fewest sample intervals along a line.
pub const MIN_INTERVALS: usize = 64;
/// Most sample intervals along a line (a longer line is sampled more coarsely).
pub const MAX_INTERVALS: usize = 2048;

/// Safety factor on sampled derivative maxima (the true maximum may fall between samples),
/// for the constant limits of the paper profile.
const DERIVATIVE_MARGIN: f64 = 1.05;

/// Most moving axes of a line: shoulder, elbow, wrist, Z.
pub(crate) const LINE_AXES: usize = 4;

/// Channels of a derivative row: the moving axes, then (on a composite path) the TCP's
/// speed along the path ([`Derivs::set_tcp`]).
pub(crate) const CHANNELS: usize = LINE_AXES + 1;

/// Most points of a derivative table: a composite path's samples, both ends of each piece.
const TABLE_POINTS: usize =
    crate::curve::MAX_CURVE_INTERVALS + crate::geometry::CONTINUATION_INTERVALS + MAX_TABLE_PIECES;

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

/// Limits of the path parameter u derived from the joints and the Cartesian limits, constant
/// along a line [1/s, 1/s², 1/s³] (the paper profile's: see [`PathCheck::constant_limits`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathLimits {
    /// Velocity of u [1/s].
    pub v: f64,
    /// Acceleration of u [1/s²].
    pub a: f64,
    /// Jerk of u [1/s³].
    pub j: f64,
}

/// What the check of a whole line found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathCheck {
    /// Joints at u = 1, continued along the line from the start.
    pub end_joints: Joints,
    /// Largest |q'|, |q''|, |q'''| of every axis over the samples [unit per u, u², u³].
    pub max_derivatives: [[f64; 3]; MAX_AXES],
}

/// The axes a line moves (shoulder, elbow, then wrist and Z if the robot has them): their
/// indices among the robot's axes, and how many there are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct LineAxes {
    pub idx: [usize; LINE_AXES],
    pub n: usize,
}

impl LineAxes {
    pub(crate) fn of(robot: &Robot) -> LineAxes {
        let arm = robot.arm();
        let mut idx = [arm.shoulder, arm.elbow, 0, 0];
        let mut n = 2;
        for i in [arm.wrist, arm.z].into_iter().flatten() {
            idx[n] = i;
            n += 1;
        }
        LineAxes { idx, n }
    }
}

/// The derivatives of the moving axes ([`LineAxes`] order) at one point of a path:
/// q', q'', q''' [unit per u, u², u³]; on a composite path also the TCP's channels after
/// them ([`Derivs::set_tcp`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Derivs {
    pub d1: [f64; CHANNELS],
    pub d2: [f64; CHANNELS],
    pub d3: [f64; CHANNELS],
    /// √(κ)·s′ [√mm per u]: κ·s′²·u̇² is the TCP's centripetal acceleration (0 on a line).
    pub dn: f64,
    /// In a blend of a composite path, whose derivatives vary fast: the timing law checks
    /// its steps more densely there.
    pub fine: bool,
    /// Which piece of a composite path (segment, blend, the continuation past its end): a
    /// step whose ends are in different pieces is checked densely, lest it pass over one.
    pub piece: u8,
}

impl Derivs {
    pub(crate) fn of(jets: &JointJets, axes: &LineAxes) -> Derivs {
        let mut d = Derivs::default();
        for k in 0..axes.n {
            let j = jets.joints[axes.idx[k]].d;
            d.d1[k] = j[1];
            d.d2[k] = j[2];
            d.d3[k] = j[3];
        }
        d
    }

    /// Set channel `k` to the TCP's path length s along the path of `pose` (s′ = |p′|, its
    /// speed per unit of the parameter; s″ and s‴), and [`Derivs::dn`] to √(κ)·s′, with κ
    /// the curvature of the TCP's path in x, y, z.
    pub(crate) fn set_tcp(&mut self, k: usize, pose: &PoseJet) {
        let p = |m: usize| [pose.x.d[m], pose.y.d[m], pose.z.d[m]];
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let (p1, p2, p3) = (p(1), p(2), p(3));
        let m = dot(p1, p1).sqrt();
        if m < 1e-12 {
            (self.d1[k], self.d2[k], self.d3[k], self.dn) = (0.0, 0.0, 0.0, 0.0);
            return;
        }
        let q = dot(p1, p2);
        let cross = [
            p1[1] * p2[2] - p1[2] * p2[1],
            p1[2] * p2[0] - p1[0] * p2[2],
            p1[0] * p2[1] - p1[1] * p2[0],
        ];
        self.d1[k] = m;
        self.d2[k] = q / m;
        self.d3[k] = (dot(p2, p2) + dot(p1, p3)) / m - q * q / (m * m * m);
        self.dn = (dot(cross, cross).sqrt() / m).sqrt();
    }
}

/// Identity of the next derivative table filled (0 means none), unique in the process.
static NEXT_TABLE_ID: AtomicU64 = AtomicU64::new(1);

/// One piece of a derivative table: evenly spaced samples of v from `v0` to `v1`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct TablePiece {
    v0: f64,
    v1: f64,
    /// Index of its first point.
    offset: usize,
    intervals: usize,
    /// A blend ([`Derivs::fine`]).
    fine: bool,
}

/// The derivatives of a path's channels tabulated at evenly spaced v within each piece (one
/// piece for a line; a composite path's segments and blends each have their own spacing, and
/// both ends, since q‴ may jump where they meet), interpolated between (cubic Hermite for q'
/// and q'', whose derivatives are tabulated too; linear for q''' and the centripetal
/// channel). Preallocated once ([`TABLE_POINTS`] rows, 1.2 MB); filling it for a new path
/// does not allocate.
#[derive(Clone)]
pub(crate) struct DerivTable {
    /// Which plan the table holds (0: none).
    pub id: u64,
    /// Channels interpolated (the line's axes, plus the TCP's on a composite path).
    channels: usize,
    pieces: [TablePiece; MAX_TABLE_PIECES],
    count: usize,
    points: Box<[Derivs]>,
}

impl DerivTable {
    pub(crate) fn new() -> DerivTable {
        DerivTable {
            id: 0,
            channels: CHANNELS,
            pieces: [TablePiece::default(); MAX_TABLE_PIECES],
            count: 0,
            points: vec![Derivs::default(); TABLE_POINTS].into_boxed_slice(),
        }
    }

    /// The derivatives at `v` in [0, 1] (or to the end of a continuation past the path's
    /// end), clamped to the table's ends. Where two pieces meet, the one before: at the
    /// path's end, the path's last sample, whether a continuation follows or not.
    #[inline]
    pub(crate) fn at(&self, v: f64) -> Derivs {
        let last = self.count.saturating_sub(1);
        let v = v.clamp(0.0, self.pieces[last].v1.max(1.0));
        let mut k = last;
        while k > 0 && self.pieces[k].v0 >= v {
            k -= 1;
        }
        let piece = &self.pieces[k];
        let n = piece.intervals;
        let span = piece.v1 - piece.v0;
        let x = ((v - piece.v0) / span).clamp(0.0, 1.0) * n as f64;
        let i = (x as usize).min(n.saturating_sub(1));
        let f = x - i as f64;
        let (p, q) = (
            &self.points[piece.offset + i],
            &self.points[piece.offset + i + 1],
        );
        let du = span / n as f64;
        // Cubic Hermite basis on [0, 1].
        let (f2, f3) = (f * f, f * f * f);
        let h00 = 2.0 * f3 - 3.0 * f2 + 1.0;
        let h10 = f3 - 2.0 * f2 + f;
        let h01 = -2.0 * f3 + 3.0 * f2;
        let h11 = f3 - f2;
        let mut d = Derivs::default();
        for k in 0..self.channels {
            d.d1[k] = h00 * p.d1[k] + h10 * du * p.d2[k] + h01 * q.d1[k] + h11 * du * q.d2[k];
            d.d2[k] = h00 * p.d2[k] + h10 * du * p.d3[k] + h01 * q.d2[k] + h11 * du * q.d3[k];
            d.d3[k] = p.d3[k] + f * (q.d3[k] - p.d3[k]);
        }
        d.dn = p.dn + f * (q.dn - p.dn);
        d.fine = piece.fine;
        d.piece = k as u8;
        d
    }
}

impl std::fmt::Debug for DerivTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DerivTable")
            .field("id", &self.id)
            .field("pieces", &self.count)
            .finish_non_exhaustive()
    }
}

/// The straight line of the TCP from the pose of the joints `start` to `target`, keeping
/// the elbow posture of `start`, checked at every point ([`LinePath::check`]): what
/// [`crate::VelocityGenerator::plan_line`] checks before planning, for callers that need
/// the verdict (or the end joints) without planning the motion.
pub fn check_line(
    robot: &Robot,
    start: &Joints,
    target: &Pose,
) -> Result<(LinePath, PathCheck), PlanError> {
    line_path(robot, start, target, None)
}

/// [`check_line`], tabulating the derivatives into `table`.
pub(crate) fn line_path(
    robot: &Robot,
    start: &Joints,
    target: &Pose,
    table: Option<&mut DerivTable>,
) -> Result<(LinePath, PathCheck), PlanError> {
    let from = robot.forward(start);
    let Some(posture) = Posture::of(robot, start) else {
        let (pose, problem) = no_posture(robot, start);
        return Err(PlanError::PathLeavesWorkspace {
            fraction_pct: 0.0,
            pose,
            problem,
        });
    };
    end_reachable(robot, start, target, posture)?;
    let path = LinePath::new(robot, from, *target, posture);
    let check = scan(&Geometry::Line(path), robot, start, table)?;
    Ok((path, check))
}

/// A path cannot start from joints whose elbow is exactly straight or folded (no posture
/// to keep): where the TCP is, and which singularity it is at.
pub(crate) fn no_posture(robot: &Robot, start: &Joints) -> (Pose, PathProblem) {
    let from = robot.forward(start);
    let r = robot.wrist_radius(&from);
    let arm = robot.arm();
    let stretched = robot.axes()[arm.elbow].min <= 0.0 && start[arm.elbow].abs() < 90.0;
    let problem = if stretched {
        PathProblem::Stretched {
            r_mm: r,
            limit_mm: arm.link1_mm + arm.link2_mm - arm.singularity_margin_mm,
        }
    } else {
        PathProblem::Folded {
            r_mm: r,
            limit_mm: (arm.link1_mm - arm.link2_mm).abs() + arm.singularity_margin_mm,
        }
    };
    (from, problem)
}

/// A path's end `target` with the posture kept along it, with a clear message if only the
/// other posture reaches it.
pub(crate) fn end_reachable(
    robot: &Robot,
    start: &Joints,
    target: &Pose,
    posture: Posture,
) -> Result<(), PlanError> {
    if let Err(err) = robot.inverse(target, posture, Some(start)) {
        let other = match posture {
            Posture::Right => Posture::Left,
            Posture::Left => Posture::Right,
        };
        return Err(match robot.inverse(target, other, Some(start)) {
            Ok(_) => PlanError::PostureChange,
            Err(_) => PlanError::Kinematics(err),
        });
    }
    Ok(())
}

/// What the scan of a line tracks between two samples of one quantity (a joint or the wrist
/// radius): its value and slope at the previous sample.
#[derive(Clone, Copy)]
struct Sample {
    u: f64,
    value: f64,
    slope: f64,
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

    /// The pose at `u` with its derivatives with respect to u.
    #[inline]
    pub fn pose_jet(&self, u: f64) -> PoseJet {
        let p = self.pose_at(u);
        PoseJet {
            x: Jet::variable(p.x, self.delta.x),
            y: Jet::variable(p.y, self.delta.y),
            z: Jet::variable(p.z, self.delta.z),
            yaw: Jet::variable(p.yaw, self.delta.yaw),
        }
    }

    /// The joints at `u` and their derivatives along the line, continued from `reference`
    /// (the joints at a nearby point of the line).
    #[inline]
    pub fn jets_at(
        &self,
        robot: &Robot,
        u: f64,
        reference: &Joints,
    ) -> Result<JointJets, KinematicsError> {
        robot.inverse_jet(&self.pose_jet(u), self.posture, reference)
    }

    /// The joints at `u` continued from `reference` (each angle the turn nearest it), with no
    /// check of limits or margin (for points of a line that [`LinePath::check`] accepted).
    #[inline]
    pub fn joints_at(&self, robot: &Robot, u: f64, reference: &Joints) -> Option<Joints> {
        robot
            .inverse_checked(
                &self.pose_at(u),
                self.posture,
                Some(reference),
                IkCheck::CONTINUE,
            )
            .ok()
    }

    /// Number of sample intervals used to check and tabulate this line.
    pub fn intervals(&self) -> usize {
        let n = (self.length_mm() / SAMPLE_MM)
            .max(self.delta.yaw.abs() / SAMPLE_DEG)
            .ceil();
        if n.is_finite() {
            (n as usize).clamp(MIN_INTERVALS, MAX_INTERVALS)
        } else {
            MAX_INTERVALS
        }
    }

    /// Check every point of the line, following the joints continuously from
    /// `start_joints` (the joints at u = 0): the wrist point stays more than the singularity
    /// margin away from the stretched and folded arm, and every joint within its limits.
    /// Limits crossed and extrema reached between samples are found exactly. On success
    /// returns the joints at u = 1 and the derivative maxima.
    pub fn check(&self, robot: &Robot, start_joints: &Joints) -> Result<PathCheck, PlanError> {
        scan(&Geometry::Line(*self), robot, start_joints, None)
    }

    /// [`LinePath::check`], tabulating the derivatives into `table` for the timing law.
    #[cfg(test)]
    pub(crate) fn scan(
        &self,
        robot: &Robot,
        start_joints: &Joints,
        table: Option<&mut DerivTable>,
    ) -> Result<PathCheck, PlanError> {
        scan(&Geometry::Line(*self), robot, start_joints, table)
    }
}

/// Check every point of a path (a line or a composite path), following the joints
/// continuously from `start_joints` (the joints at v = 0): the wrist point stays more than
/// the singularity margin away from the stretched and folded arm, and every joint within its
/// limits. Each piece is sampled evenly; limits crossed and extrema reached between samples
/// are found exactly. Tabulates the derivative rows into `table` if given. On success
/// returns the joints at v = 1 and the joint derivative maxima.
pub(crate) fn scan(
    path: &Geometry,
    robot: &Robot,
    start_joints: &Joints,
    table: Option<&mut DerivTable>,
) -> Result<PathCheck, PlanError> {
    scan_recording(path, robot, start_joints, table, f64::NAN).map(|(check, _)| check)
}

/// [`scan`], also returning the joints at `record`, a v where one of the pieces ends (the
/// start joints if it is none).
pub(crate) fn scan_recording(
    path: &Geometry,
    robot: &Robot,
    start_joints: &Joints,
    mut table: Option<&mut DerivTable>,
    record: f64,
) -> Result<(PathCheck, Joints), PlanError> {
    let mut recorded = *start_joints;
    let axes = LineAxes::of(robot);
    let arm = robot.arm();
    let margin = arm.singularity_margin_mm;
    let r_lo = (arm.link1_mm - arm.link2_mm).abs() + margin;
    let r_hi = arm.link1_mm + arm.link2_mm - margin;
    let mut max_derivatives = [[0.0; 3]; MAX_AXES];
    let mut reference = *start_joints;
    let mut prev_r: Option<Sample> = None;
    let mut prev_q = [None::<Sample>; LINE_AXES];
    let (pieces, count) = path.pieces();
    let mut offset = 0;
    for (k, &(v0, v1, n)) in pieces[..count].iter().enumerate() {
        let mut fine = false;
        for i in 0..=n {
            let u = if i == n {
                v1
            } else {
                v0 + (v1 - v0) * (i as f64 / n as f64)
            };
            let (row, jets) = match path.row(robot, &axes, u, &reference) {
                Ok(r) => r,
                Err(KinematicsError::NotFinite { what }) => {
                    return Err(PlanError::NotFinite { what });
                }
                Err(_) => {
                    // Beyond the stretched or folded arm: the margin was crossed since the
                    // last sample (or the path starts there).
                    let from = prev_r.map_or(0.0, |s| s.u);
                    return Err(radius_refusal(path, robot, from, u, r_lo, r_hi));
                }
            };
            // The wrist radius and every moving joint, between the last sample and here.
            let sample = |jet: Jet| Sample {
                u,
                value: jet.d[0],
                slope: jet.d[1],
            };
            let r = sample(jets.wrist_radius);
            let band = |v: f64| v > r_lo && v < r_hi;
            let radius = |j: &JointJets| j.wrist_radius;
            if let Some(at) = outside_at(path, robot, prev_r, r, &reference, radius, band) {
                let from = prev_r.map_or(0.0, |s| s.u);
                return Err(radius_refusal(path, robot, from, at, r_lo, r_hi));
            }
            prev_r = Some(r);
            for (&ax, prev) in axes.idx[..axes.n].iter().zip(prev_q.iter_mut()) {
                let jet = jets.joints[ax].d;
                let s = sample(jets.joints[ax]);
                let axis = &robot.axes()[ax];
                let joint = |j: &JointJets| j.joints[ax];
                let within = |v: f64| axis.within_limits(v);
                if let Some(at) = outside_at(path, robot, *prev, s, &reference, joint, within) {
                    let from = prev.map_or(0.0, |p| p.u);
                    return Err(joint_refusal(path, robot, ax, from, at, &reference));
                }
                *prev = Some(s);
                let m: &mut [f64; 3] = &mut max_derivatives[ax];
                for (o, d) in m.iter_mut().zip(&jet[1..]) {
                    *o = o.max(d.abs());
                }
            }
            for (q, j) in reference
                .iter_mut()
                .zip(&jets.joints)
                .take(robot.axis_count())
            {
                *q = j.value();
            }
            if u == record {
                recorded = reference;
            }
            // Inside the piece (its ends may belong to the neighbours).
            fine |= i > 0 && i < n && row.fine;
            if let Some(t) = table.as_deref_mut() {
                t.points[offset + i] = row;
            }
        }
        if let Some(t) = table.as_deref_mut() {
            t.pieces[k] = TablePiece {
                v0,
                v1,
                offset,
                intervals: n,
                fine,
            };
        }
        offset += n + 1;
    }
    if let Some(t) = table {
        t.count = count;
        t.channels = if path.cartesian_channels() {
            axes.n + 1
        } else {
            axes.n
        };
        t.id = NEXT_TABLE_ID.fetch_add(1, Ordering::Relaxed);
    }
    Ok((
        PathCheck {
            end_joints: reference,
            max_derivatives,
        },
        recorded,
    ))
}

/// Where a quantity of the path (`pick` of its joint jets) is outside its allowed range
/// (`inside` false) from the sample `prev` (if any) to the sample `s`: the extremum
/// between them when the slope changes sign there and it is outside, otherwise `s` when
/// it is outside; `None` when it stays inside. `reference`: the joints at `prev`.
fn outside_at(
    path: &Geometry,
    robot: &Robot,
    prev: Option<Sample>,
    s: Sample,
    reference: &Joints,
    pick: impl Fn(&JointJets) -> Jet,
    inside: impl Fn(f64) -> bool,
) -> Option<f64> {
    if let Some(p) = prev.filter(|p| p.slope * s.slope < 0.0) {
        let at = |u: f64| path.jets_at(robot, u, reference).ok().map(|j| pick(&j).d);
        let e = find_extremum(&p, &s, |u| at(u).map(|d| d[1]));
        if at(e).is_none_or(|d| !inside(d[0])) {
            return Some(e);
        }
    }
    (!inside(s.value)).then_some(s.u)
}

/// The refusal for a wrist radius that leaves (lo, hi) somewhere in (`from`, `to`]: the
/// first point where it does, found by bisection.
fn radius_refusal(
    path: &Geometry,
    robot: &Robot,
    from: f64,
    to: f64,
    lo: f64,
    hi: f64,
) -> PlanError {
    let r_at = |u: f64| robot.wrist_radius(&path.pose_at(u));
    let inside = |u: f64| {
        let r = r_at(u);
        r > lo && r < hi
    };
    let u = if inside(from) {
        first_failure(from, to, |u| !inside(u))
    } else {
        from
    };
    let r = r_at(u);
    let problem = if (r - hi).abs() < (r - lo).abs() {
        PathProblem::Stretched {
            r_mm: r,
            limit_mm: hi,
        }
    } else {
        PathProblem::Folded {
            r_mm: r,
            limit_mm: lo,
        }
    };
    path.refusal(u, problem)
}

/// The refusal for joint `ax` leaving its limits somewhere in (`from`, `to`]: the first
/// point where it does, and the farthest value the rest of the path takes it to.
fn joint_refusal(
    path: &Geometry,
    robot: &Robot,
    ax: usize,
    from: f64,
    to: f64,
    reference: &Joints,
) -> PlanError {
    let axis = &robot.axes()[ax];
    let value = |u: f64, r: &Joints| path.jets_at(robot, u, r).ok().map(|j| j.joints[ax].d[0]);
    let outside = |u: f64| value(u, reference).is_some_and(|v| !axis.within_limits(v));
    let u = if outside(from) {
        from
    } else {
        first_failure(from, to, outside)
    };
    // The farthest value: follow the rest of the path (continuously) while it is reachable
    // at all, at the line's sampling (every 0.5 mm, at most 2,048 steps).
    let above = value(u, reference).is_some_and(|v| v > axis.max);
    let mut extreme = value(u, reference).unwrap_or(if above { axis.max } else { axis.min });
    let n = ((path.length_mm() / SAMPLE_MM).ceil() as usize).clamp(MIN_INTERVALS, MAX_INTERVALS);
    let mut r = *reference;
    let start = (u * n as f64).floor() as usize;
    for i in start..=n {
        let ui = (i as f64 / n as f64).max(u);
        let Ok(jets) = path.jets_at(robot, ui, &r) else {
            break;
        };
        for (q, j) in r.iter_mut().zip(&jets.joints).take(robot.axis_count()) {
            *q = j.value();
        }
        let v = jets.joints[ax].d[0];
        extreme = if above {
            extreme.max(v)
        } else {
            extreme.min(v)
        };
    }
    path.refusal(
        u,
        PathProblem::JointLimit {
            axis: axis.name,
            unit: axis.unit,
            extreme,
            min: axis.min,
            max: axis.max,
        },
    )
}

/// The u in (a.u, b.u) where a slope that changes sign between two samples is zero:
/// Newton steps on the slope's secant, kept inside a shrinking bracket (bisection when a
/// step would leave it). `slope(u)` is `None` where the line cannot be evaluated.
fn find_extremum(a: &Sample, b: &Sample, slope: impl Fn(f64) -> Option<f64>) -> f64 {
    let (mut lo, mut hi) = (a.u, b.u);
    let (mut s_lo, mut s_hi) = (a.slope, b.slope);
    let mut u = 0.5 * (lo + hi);
    for _ in 0..60 {
        // Regula falsi with bisection as the fallback.
        let guess = lo - s_lo * (hi - lo) / (s_hi - s_lo);
        u = if guess.is_finite() && guess > lo && guess < hi {
            guess
        } else {
            0.5 * (lo + hi)
        };
        let Some(s) = slope(u) else {
            return u;
        };
        if s == 0.0 || hi - lo <= 1e-13 {
            break;
        }
        if s.signum() == s_lo.signum() {
            // Move the bracket; halve the stale end's weight (Illinois) to keep converging.
            lo = u;
            s_lo = s;
            s_hi *= 0.5;
        } else {
            hi = u;
            s_hi = s;
            s_lo *= 0.5;
        }
    }
    u
}

/// The first u in (from, to] where `fails(u)` holds, given that it holds at `to` and not at
/// `from`, to 1e-12 in u.
fn first_failure(from: f64, to: f64, fails: impl Fn(f64) -> bool) -> f64 {
    let (mut lo, mut hi) = (from, to);
    while hi - lo > 1e-12 {
        let mid = 0.5 * (lo + hi);
        if fails(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

impl PathCheck {
    /// The paper profile's limits of u, constant along the line: with m1, m2, m3 the maxima
    /// of |q'|, |q''|, |q'''| over the line (plus 5 %), every joint keeps
    /// q̇ ≤ m1·V_u, q̈ ≤ m1·A_u + m2·V_u², q⃛ ≤ m1·J_u + 3·m2·V_u·A_u + m3·V_u³
    /// within its limits, and the TCP keeps the Cartesian ones. `scale` is the speed
    /// override as a fraction (0, 1]. All zero when nothing moves.
    pub fn constant_limits(
        &self,
        robot: &Robot,
        length_mm: f64,
        line: &LineLimits,
        scale: f64,
    ) -> PathLimits {
        self.constant_limits_with(robot, length_mm, line, scale, 1.0)
    }

    /// [`PathCheck::constant_limits`] with every acceleration and jerk limit also times
    /// `accel` (the acceleration override as a fraction).
    pub(crate) fn constant_limits_with(
        &self,
        robot: &Robot,
        length_mm: f64,
        line: &LineLimits,
        scale: f64,
        accel: f64,
    ) -> PathLimits {
        let (s2, s3) = (scale * scale * accel, scale * scale * scale * accel);
        let n = robot.axis_count();
        let axes = robot.axes();
        let m = |ax: usize, k: usize| self.max_derivatives[ax][k] * DERIVATIVE_MARGIN;
        let mut v = f64::INFINITY;
        if length_mm > 0.0 {
            v = v.min(line.max_speed_mm_s * scale / length_mm);
        }
        for (ax, axis) in axes.iter().enumerate().take(n) {
            let l = &axis.limits;
            let (d1, d2, d3) = (m(ax, 0), m(ax, 1), m(ax, 2));
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
        if length_mm > 0.0 {
            a = a.min(line.max_accel_mm_s2 * s2 / length_mm);
        }
        for (ax, axis) in axes.iter().enumerate().take(n) {
            let l = &axis.limits;
            let (d1, d2) = (m(ax, 0), m(ax, 1));
            if d1 > 0.0 {
                a = a.min((l.max_acceleration * s2 - d2 * v * v) / d1);
            }
            if d2 > 0.0 {
                a = a.min(l.max_jerk * s3 / (9.0 * d2 * v));
            }
        }
        let mut j = f64::INFINITY;
        if length_mm > 0.0 {
            j = j.min(line.max_jerk_mm_s3 * s3 / length_mm);
        }
        for (ax, axis) in axes.iter().enumerate().take(n) {
            let l = &axis.limits;
            let (d1, d2, d3) = (m(ax, 0), m(ax, 1), m(ax, 2));
            if d1 > 0.0 {
                j = j.min((l.max_jerk * s3 - 3.0 * d2 * v * a - d3 * v * v * v) / d1);
            }
        }
        if !(v.is_finite() && a.is_finite() && j.is_finite()) || v <= 0.0 || a <= 0.0 || j <= 0.0 {
            return PathLimits {
                v: 0.0,
                a: 0.0,
                j: 0.0,
            };
        }
        PathLimits { v, a, j }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_interpolates_the_exact_derivatives() {
        let robot = Robot::paper_default();
        let a = Pose {
            x: 120.0,
            y: -250.0,
            z: 10.0,
            yaw: -20.0,
        };
        let b = Pose {
            x: 200.0,
            y: 260.0,
            z: 60.0,
            yaw: 80.0,
        };
        let path = LinePath::new(&robot, a, b, Posture::Right);
        let start = robot.inverse(&a, Posture::Right, None).unwrap();
        let mut table = DerivTable::new();
        path.scan(&robot, &start, Some(&mut table)).unwrap();
        let axes = LineAxes::of(&robot);
        let mut reference = start;
        for i in 0..=997 {
            let u = i as f64 / 997.0;
            let jets = path.jets_at(&robot, u, &reference).unwrap();
            for (q, j) in reference.iter_mut().zip(&jets.joints).take(4) {
                *q = j.value();
            }
            let exact = Derivs::of(&jets, &axes);
            let t = table.at(u);
            for k in 0..axes.n {
                let rel = |x: f64, y: f64, s: f64| (x - y).abs() / s.max(1e-9);
                let s1 = exact.d1[k].abs().max(1.0);
                assert!(rel(t.d1[k], exact.d1[k], s1) < 1e-6, "u {u} axis {k} d1");
                let s2 = exact.d2[k].abs().max(10.0);
                assert!(rel(t.d2[k], exact.d2[k], s2) < 1e-4, "u {u} axis {k} d2");
                let s3 = exact.d3[k].abs().max(100.0);
                assert!(rel(t.d3[k], exact.d3[k], s3) < 1e-2, "u {u} axis {k} d3");
            }
        }
    }
}
