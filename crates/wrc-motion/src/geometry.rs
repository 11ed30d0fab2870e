//! The path the TCP follows in a Cartesian move, as the timing law and the check see it: a
//! straight line ([`LinePath`]) or a composite path of lines, arcs and blends ([`Curve`]),
//! parametrised by v in [0, 1]. A composite path is seen through a window of its own
//! parameter: the rest of it from where a held move stands (v = 0 there), or beyond its end
//! (a path that flows into a PTP continues its last segment a little, for the brakes of its
//! last moments: docs/motion.md, "PTP blends").
//!
//! A composite path's derivative rows carry two more channels besides the joints', for the
//! TCP's Cartesian limits: its speed along the path s′ (with s″ and s‴, so that the speed,
//! the tangential acceleration and the tangential jerk are bounded like a joint's), and
//! √(κ)·s′, whose product with v̇ squared is the centripetal acceleration κ·ṡ² (bounded by the
//! line acceleration limit, a bound on the speed alone). A straight line has neither: its
//! Cartesian limits are constant bounds of u.
//!
//! Real-time promise: `Copy`, fixed-size; evaluating allocates nothing.

use wrc_robot::{
    wrap180, IkCheck, JointJets, Joints, KinematicsError, Pose, PoseJet, Posture, Robot, MAX_AXES,
};

use crate::curve::{Curve, MAX_PIECES, P4};
use crate::error::{PathProblem, PlanError};
use crate::path::{end_reachable, no_posture, scan, Derivs, LineAxes, LinePath, PathCheck};
use crate::path_spec::PathSpec;

/// A composite path seen over u in [`from`, `to`] of its parameter: v = 0 at `from`, v = 1
/// where the window reaches the path's end (or at `to` before it), and past 1 along the
/// continuation beyond the end, up to [`Window::v_end`], in the same units — so that a
/// window with a continuation is, up to the path's end, the window without it, to the bit.
///
/// The robot stands at the window's start within [`START_TOL_MM`] or [`ON_PATH_TOL_MM`]
/// (pulses round the joints, so a pose of the path is never quite where the robot is): that
/// difference, `offset`, is added at v = 0 and faded out over the first [`FADE_MM`] of the
/// window (a septic smoothstep, so the pose's first three derivatives stay continuous), and
/// the motion starts exactly where the robot stands instead of jumping a few pulses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Window {
    pub curve: Curve,
    /// The path's u at v = 0.
    pub from: f64,
    /// The path's u where the window ends (past 1: beyond the path's end, along its last
    /// segment).
    pub to: f64,
    /// The path's u per unit of v: from `from` to the path's end, or to `to` before it.
    span: f64,
    /// Elbow posture kept along it.
    pub posture: Posture,
    /// Where the robot stands less the path's pose at v = 0 [mm, mm, mm, deg].
    offset: P4,
    /// Over how much of v the offset fades out.
    fade: f64,
}

/// Length over which a window's start offset fades out [mm] (at most half the window): the
/// offset is hundredths of a millimetre, so its derivatives along the path stay far below
/// the path's own.
pub const FADE_MM: f64 = 10.0;

/// The septic smoothstep 1 − S(x) on [0, 1] and its first three derivatives: 1 at 0, 0 at 1,
/// its first three derivatives 0 at both ends.
fn fade_out(x: f64) -> [f64; 4] {
    if x >= 1.0 {
        return [0.0; 4];
    }
    let x = x.max(0.0);
    let (x2, x3) = (x * x, x * x * x);
    let s = x2 * x2 * (35.0 - 84.0 * x + 70.0 * x2 - 20.0 * x3);
    let d1 = x3 * (140.0 - 420.0 * x + 420.0 * x2 - 140.0 * x3);
    let d2 = x2 * (420.0 - 1680.0 * x + 2100.0 * x2 - 840.0 * x3);
    let d3 = x * (840.0 - 5040.0 * x + 8400.0 * x2 - 4200.0 * x3);
    [1.0 - s, -d1, -d2, -d3]
}

impl Window {
    /// The window over [`from`, `to`] of `curve`, starting where the robot stands at
    /// `here` (near the path's pose at `from`).
    pub(crate) fn new(curve: Curve, from: f64, to: f64, posture: Posture, here: &Pose) -> Window {
        let at = curve.pose_at(from);
        let offset = [
            here.x - at.x,
            here.y - at.y,
            here.z - at.z,
            wrap180(here.yaw - at.yaw),
        ];
        let span = to.min(1.0) - from;
        let length = curve.total() * span;
        let fade = if length > 0.0 {
            (FADE_MM / length).min(0.5)
        } else {
            0.5
        };
        Window {
            curve,
            from,
            to,
            span,
            posture,
            offset,
            fade,
        }
    }

    /// The v where the window ends: 1, or past 1 on a window that continues beyond the
    /// path's end.
    #[inline]
    pub(crate) fn v_end(&self) -> f64 {
        if self.to > 1.0 {
            self.v(self.to)
        } else {
            1.0
        }
    }

    /// The pose at v and its derivatives with respect to v.
    fn pose_jet(&self, v: f64) -> PoseJet {
        let mut p = self.curve.pose_jet(self.u(v), self.span);
        if v < self.fade && self.offset != [0.0; 4] {
            let f = fade_out(v / self.fade);
            for (jet, o) in [&mut p.x, &mut p.y, &mut p.z, &mut p.yaw]
                .into_iter()
                .zip(self.offset)
            {
                let mut k = 1.0;
                for (m, d) in jet.d.iter_mut().enumerate() {
                    *d += o * f[m] * k;
                    k /= self.fade;
                }
            }
        }
        p
    }

    /// The path's u at v.
    #[inline]
    pub(crate) fn u(&self, v: f64) -> f64 {
        self.from + v * self.span
    }

    /// The v of the path's u.
    #[inline]
    pub(crate) fn v(&self, u: f64) -> f64 {
        (u - self.from) / self.span
    }
}

/// A Cartesian move's path over v in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(clippy::large_enum_variant)]
pub(crate) enum Geometry {
    /// A straight line (v is its u).
    Line(LinePath),
    /// A composite path through a window.
    Curve(Window),
}

/// Most sample pieces of a path: a composite path's, and the continuation beyond its end.
pub(crate) const MAX_TABLE_PIECES: usize = MAX_PIECES + 1;

/// Most sample intervals of the continuation beyond a path's end (besides the path's own).
pub(crate) const CONTINUATION_INTERVALS: usize = 1024;

/// The sample pieces of a path: (v where it starts, where it ends, sample intervals).
pub(crate) type Pieces = ([(f64, f64, usize); MAX_TABLE_PIECES], usize);

impl Geometry {
    /// Elbow posture kept along the path.
    pub(crate) fn posture(&self) -> Posture {
        match self {
            Geometry::Line(l) => l.posture,
            Geometry::Curve(w) => w.posture,
        }
    }

    /// The pose at v.
    #[inline]
    pub(crate) fn pose_at(&self, v: f64) -> Pose {
        match self {
            Geometry::Line(l) => l.pose_at(v),
            Geometry::Curve(w) => w.pose_jet(v).value(),
        }
    }

    /// The pose at v with its derivatives with respect to v.
    #[inline]
    pub(crate) fn pose_jet(&self, v: f64) -> PoseJet {
        match self {
            Geometry::Line(l) => l.pose_jet(v),
            Geometry::Curve(w) => w.pose_jet(v),
        }
    }

    /// Whether the derivative rows carry the TCP's channels (a composite path).
    pub(crate) fn cartesian_channels(&self) -> bool {
        matches!(self, Geometry::Curve(_))
    }

    /// Length of the TCP's path over v in [0, 1] [mm] (along σ for a composite path; a
    /// window's continuation past the path's end lies beyond v = 1).
    pub(crate) fn length_mm(&self) -> f64 {
        match self {
            Geometry::Line(l) => l.length_mm(),
            Geometry::Curve(w) => w.curve.total() * w.span,
        }
    }

    /// The joints at v and their derivatives along the path, continued from `reference`.
    #[inline]
    pub(crate) fn jets_at(
        &self,
        robot: &Robot,
        v: f64,
        reference: &Joints,
    ) -> Result<JointJets, KinematicsError> {
        robot.inverse_jet(&self.pose_jet(v), self.posture(), reference)
    }

    /// The joints at v continued from `reference`, unchecked (for points a check accepted).
    #[inline]
    pub(crate) fn joints_at(&self, robot: &Robot, v: f64, reference: &Joints) -> Option<Joints> {
        robot
            .inverse_checked(
                &self.pose_at(v),
                self.posture(),
                Some(reference),
                IkCheck::CONTINUE,
            )
            .ok()
    }

    /// The derivative row at v (the joints', and the TCP's channels of a composite path),
    /// and the joint jets it came from.
    #[inline]
    pub(crate) fn row(
        &self,
        robot: &Robot,
        axes: &LineAxes,
        v: f64,
        reference: &Joints,
    ) -> Result<(Derivs, JointJets), KinematicsError> {
        let pose = self.pose_jet(v);
        let jets = robot.inverse_jet(&pose, self.posture(), reference)?;
        let mut d = Derivs::of(&jets, axes);
        if let Geometry::Curve(w) = self {
            d.set_tcp(axes.n, &pose);
            let u = w.u(v);
            let k = w.curve.piece_at(u.min(1.0));
            d.fine = k % 2 == 1;
            // The continuation past the path's end is a piece of its own.
            d.piece = if u > 1.0 { MAX_PIECES as u8 } else { k as u8 };
        }
        Ok((d, jets))
    }

    /// The derivative row at v, exactly (zero where the path cannot be evaluated).
    #[inline]
    pub(crate) fn derivs(
        &self,
        robot: &Robot,
        axes: &LineAxes,
        v: f64,
        reference: &Joints,
    ) -> Derivs {
        self.row(robot, axes, v, reference)
            .map_or_else(|_| Derivs::default(), |(d, _)| d)
    }

    /// The pieces the check samples and the derivative table holds, in v: a composite
    /// path's pieces within the window, and the continuation beyond the path's end as a
    /// piece of its own (so that v where the path ends is a sample, and the path's pieces
    /// are sampled as in the window without it).
    pub(crate) fn pieces(&self) -> Pieces {
        let mut out = [(0.0, 0.0, 0usize); MAX_TABLE_PIECES];
        match self {
            Geometry::Line(l) => {
                out[0] = (0.0, 1.0, l.intervals());
                (out, 1)
            }
            Geometry::Curve(w) => {
                let c = &w.curve;
                let last = c.pieces() - 1;
                let mut count = 0;
                let v_end = w.v_end();
                let mut push = |a: f64, b: f64, n: usize| {
                    if b > a && n > 0 {
                        out[count] = (w.v(a).max(0.0), w.v(b).min(v_end), n);
                        count += 1;
                    }
                };
                for k in 0..=last {
                    let (u0, u1, n) = c.piece(k);
                    let (a, b) = (u0.max(w.from), u1.min(w.to));
                    let part = (n as f64 * (b - a) / (u1 - u0).max(1e-300)).ceil() as usize;
                    push(a, b, part.min(n).max(1));
                }
                // The path's pieces stay within the table's share of them.
                let sum: usize = out[..count].iter().map(|p| p.2).sum();
                let cap = crate::curve::MAX_CURVE_INTERVALS;
                if sum > cap {
                    for p in out[..count].iter_mut() {
                        p.2 = (p.2 * cap / sum).max(1);
                    }
                }
                if count > 0 {
                    out[0].0 = 0.0;
                    out[count - 1].1 = v_end.min(1.0);
                }
                if w.to > 1.0 {
                    // Beyond the end, sampled as the line's 0.5 mm (at least 4 intervals).
                    let mm = (w.to - 1.0) * c.total();
                    let n = ((mm / crate::path::SAMPLE_MM).ceil() as usize)
                        .clamp(4, CONTINUATION_INTERVALS);
                    out[count] = (1.0, v_end, n);
                    count += 1;
                }
                (out, count)
            }
        }
    }

    /// The v where the path itself ends in this window: 1 (a window continued past the
    /// path's end has the continuation beyond 1; one that ends before the path's end ends
    /// at 1).
    pub(crate) fn path_end(&self) -> f64 {
        match self {
            Geometry::Line(_) => 1.0,
            Geometry::Curve(w) => w.v(1.0).min(1.0),
        }
    }

    /// The refusal for `problem` at v.
    pub(crate) fn refusal(&self, v: f64, problem: PathProblem) -> PlanError {
        let pose = self.pose_at(v);
        match self {
            Geometry::Line(_) => PlanError::PathLeavesWorkspace {
                fraction_pct: 100.0 * v,
                pose,
                problem,
            },
            Geometry::Curve(w) => {
                let u = w.u(v);
                PlanError::SegmentLeavesWorkspace {
                    place: w.curve.place(u.min(1.0)),
                    fraction_pct: 100.0 * u,
                    pose,
                    problem,
                }
            }
        }
    }
}

/// Within this distance of a path's start [mm] (and [`YAW_TOL_DEG`] of its yaw) the robot is
/// at the start: a few pulses of every joint.
pub const START_TOL_MM: f64 = 0.02;
/// Within this distance of a path [mm] (and [`YAW_TOL_DEG`] of its yaw there) the robot is
/// on it: where a stop on it leaves it, within the rounding to pulses.
pub const ON_PATH_TOL_MM: f64 = 0.02;
/// Yaw tolerance of [`START_TOL_MM`] and [`ON_PATH_TOL_MM`] [deg].
pub const YAW_TOL_DEG: f64 = 0.01;

/// Where the robot at the joints `current` is on `curve` (built from `spec`): 0 at the
/// path's start, the path's u at a point of it (up to `upto`, past 1 beyond its end), or
/// [`PlanError::NotOnPath`].
pub(crate) fn place_on(
    robot: &Robot,
    curve: &Curve,
    spec: &PathSpec,
    current: &Joints,
    upto: f64,
) -> Result<f64, PlanError> {
    let here = robot.forward(current);
    let wrist = robot.arm().wrist.is_some();
    let s = &spec.start;
    let yaw_ok = !wrist || wrap180(here.yaw - s.yaw).abs() <= YAW_TOL_DEG;
    if (here.x - s.x).hypot(here.y - s.y).hypot(here.z - s.z) <= START_TOL_MM && yaw_ok {
        return Ok(0.0);
    }
    curve
        .locate(&here, upto, (ON_PATH_TOL_MM, YAW_TOL_DEG, wrist))
        .ok_or(PlanError::NotOnPath { here, start: *s })
}

/// The window of `spec`'s path that the robot at `current` still has to follow: all of it
/// from its start, the rest of it from a point of it, `None` at its end; refused when the
/// path is malformed, the robot elsewhere, or it cannot keep its posture to the end.
pub(crate) fn path_window(
    robot: &Robot,
    current: &Joints,
    spec: &PathSpec,
) -> Result<Option<Window>, PlanError> {
    let curve = Curve::build(spec, robot.arm().wrist.is_some())?;
    let Some(posture) = Posture::of(robot, current) else {
        let (pose, problem) = no_posture(robot, current);
        return Err(PlanError::SegmentLeavesWorkspace {
            place: curve.place(0.0),
            fraction_pct: 0.0,
            pose,
            problem,
        });
    };
    let from = place_on(robot, &curve, spec, current, 1.0)?;
    if from >= 1.0 - 1e-12 {
        return Ok(None);
    }
    end_reachable(robot, current, &curve.pose_at(1.0), posture)?;
    let here = robot.forward(current);
    Ok(Some(Window::new(curve, from, 1.0, posture, &here)))
}

/// Check a composite path ([`PathSpec`]) from the joints `start` as the velocity generator
/// does before it moves ([`crate::VelocityGenerator::start_path`]): the robot at the path's
/// start (or on the path: the rest of it from there), every segment and corner well formed,
/// every point within the workspace and every joint in range (followed continuously, the
/// elbow's posture kept), found exactly between samples as along a straight line. On success
/// the joints at the path's end and the derivative maxima (the start joints when the robot
/// is at the end already). For a Command Interpreter's admission check: it allocates
/// nothing and costs about what [`crate::check_line`] does for the same length.
pub fn check_path(robot: &Robot, start: &Joints, path: &PathSpec) -> Result<PathCheck, PlanError> {
    match path_window(robot, start, path)? {
        Some(w) => scan(&Geometry::Curve(w), robot, start, None),
        None => Ok(PathCheck {
            end_joints: *start,
            max_derivatives: [[0.0; 3]; MAX_AXES],
        }),
    }
}
