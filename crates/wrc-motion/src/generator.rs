//! The incremental velocity generator: plans a move (PTP, straight line, composite path,
//! jog, and the blends between PTP and Cartesian moves: a PTP into a path — a transfer's
//! approach into a station's line among them — a path into a PTP, a PTP through a via point)
//! from the current commanded position and then yields, period by period, the integer pulse
//! increment of every axis, with speed and acceleration overrides and a controlled stop
//! (STOP/HOLD with the speed override's limits, ESTOP with every axis's full limits:
//! [`BrakeLimits`]).
//!
//! Planning takes from microseconds (a PTP) to milliseconds (a line or path is checked point
//! by point; a blend into or out of a path searches its candidates within a budget of work,
//! [`BlendSearch`]: docs/motion.md gives the costs) but, like every period, it does not
//! allocate: the generator owns fixed-size arrays and a derivative table allocated with it,
//! so all of it can run in the real-time Velocity Generator task. The commanded position is
//! by definition the sum of the pulses emitted; no pulse is ever lost or invented.

use wrc_robot::{Joints, Pose, Posture, Robot, MAX_AXES};

use crate::brake::Brake1d;
pub use crate::brake::BrakeLimits;
use crate::curve::Curve;
use crate::double_s::DoubleS;
use crate::error::{PlanError, SettingsError};
use crate::fir_axes::FirAxes;
use crate::geometry::{path_window, place_on};
use crate::geometry::{Geometry, Window};
use crate::jerk_axes::{JerkAxes, Planner, RUCKIG_DOF};
use crate::line_profile::{estimate_time, Bounds, LineProfile};
use crate::paper::PaperChannel;
use crate::path::{line_path, scan, scan_recording, DerivTable, Derivs, LineAxes, PathCheck};
use crate::path_spec::PathSpec;
use crate::search::{BlendSearch, SearchStats, Work};
use crate::settings::{check_speed_pct, MotionSettings, Profile};
use crate::solutions::ptp_target;

/// Path-parameter resolution of a straight line under the paper profile [counts per line].
const LINE_COUNTS: i64 = 1 << 40;

/// The room past a path's end, along its last segment continued, within which the law of a
/// path that flows into a PTP may brake ([`VelocityGenerator::plan_depart`]), largest first
/// [mm]: each gives the path a faster exit.
pub const DEPART_ROOM_MM: [f64; 3] = [100.0, 30.0, 10.0];

/// How far along a path its entries are compared ([`VelocityGenerator::plan_ptp_into`]; a
/// line's to its end): beyond the entry's acceleration from the slowest entry to the path's
/// speed [mm].
pub const ENTRY_HORIZON_MM: f64 = 150.0;

/// The fractions of the nominal velocity at a via point tried by
/// [`VelocityGenerator::plan_ptp_via`], fastest first.
pub const VIA_SPEEDS: [f64; 3] = [1.0, 0.6, 0.3];

/// What [`VelocityGenerator::next_period`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// No move: the period's pulses are all zero.
    Idle,
    /// A move is under way and continues after this period.
    Working,
    /// This period was the last of a move; the generator is idle afterwards.
    Finished(MoveEnd),
}

/// How a move ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MoveEnd {
    /// It reached its target.
    Completed,
    /// A controlled stop ended it before the target.
    Stopped,
}

/// Where a move is going ([`MotionState::goal`]): what HOLD keeps to RESUME to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Goal {
    /// A PTP move or a jog: every axis's target [pulse] (start plus distance; entries past
    /// the axis count are 0). [`VelocityGenerator::plan_ptp_pulses`] goes there exactly.
    Joints([i64; MAX_AXES]),
    /// A straight line: its end pose [mm, mm, mm, deg] (the yaw as the line reaches it, not
    /// wrapped), and its end joints followed along the line [pulse].
    Line {
        /// The line's end pose.
        pose: Pose,
        /// The joints at the end of the line [pulse].
        pulses: [i64; MAX_AXES],
    },
    /// A composite path ([`PathSpec`]): its end pose (the yaw as the path reaches it, not
    /// wrapped) and its end joints followed along it [pulse]. RESUME sends the same path
    /// again: from a point of it, the generator continues along the rest.
    Path {
        /// The path's end pose.
        pose: Pose,
        /// The joints at the end of the path [pulse].
        pulses: [i64; MAX_AXES],
    },
}

impl Goal {
    /// Where a Cartesian path ends, with its end joints [pulse].
    fn of_path(path: &Geometry, pulses: [i64; MAX_AXES]) -> Goal {
        match path {
            Geometry::Line(l) => Goal::Line {
                pose: l.pose_at(1.0),
                pulses,
            },
            Geometry::Curve(w) => Goal::Path {
                pose: w.curve.pose_at(1.0),
                pulses,
            },
        }
    }
}

/// How the elbow and the hand must enter a path flowed into from a PTP
/// ([`VelocityGenerator::plan_ptp_into`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EntryRule {
    /// A station's rule (a wafer transfer): entering moving, the TCP stays behind the
    /// path's start (the half-plane behind it, across the direction in which the path
    /// leaves it) until it is on the path, and the move has a commit point
    /// ([`MotionState::entry_committed`]) before which a stop at full limits ends behind it.
    Station,
    /// No rule besides every joint in range (a program's blended PTP): the joint-space part
    /// is checked as a PTP is.
    Free,
}

/// How the axes of a PTP move are synchronised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sync {
    /// All axes follow one shape: a straight line in joint space.
    Phase,
    /// Each axis has its own shape with the same duration (used when one shape would be
    /// slower than the slowest axis's own optimum, as Ruckig does).
    Time,
    /// One channel only (a straight line or a jog).
    Single,
}

/// A planned move, as seen before its first period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveInfo {
    /// Duration of the motion [s] (the continuous profile's; 0 for a move of no length).
    pub duration_s: f64,
    /// Number of periods that carry its pulses.
    pub periods: u64,
    /// Synchronisation of the axes.
    pub sync: Sync,
}

/// The output of one period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Period {
    /// Pulses to emit on each axis in this period [pulse]; entries past the axis count are 0.
    pub pulses: [i64; MAX_AXES],
    /// Commanded joints at the end of the period before rounding to pulses [deg or mm]
    /// (for plots and tests; the pulses are what moves).
    pub exact: Joints,
}

impl Default for Period {
    fn default() -> Self {
        Period {
            pulses: [0; MAX_AXES],
            exact: [0.0; MAX_AXES],
        }
    }
}

/// Timing law of every channel. Both variants are fixed-size arrays on purpose: boxing the
/// larger one would allocate when a move is planned in the real-time task.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
enum Law {
    /// The default profile: each axis's double-S, or after a stop its brake.
    Fir(FirAxes),
    /// The paper's profile, one channel per axis.
    Paper([PaperChannel; MAX_AXES]),
}

/// Timing law of a straight line (fixed-size on purpose, as [`Law`]).
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
enum LineLaw {
    /// The default profile: the path parameter's time-optimal jerk-limited law, planned at
    /// 100 % and played at `scale` × real time.
    Timed {
        profile: LineProfile,
        bounds: Bounds,
        /// Speed override as a fraction: plan time = scale × time.
        scale: f64,
        /// The derivative table this law was planned with ([`DerivTable::id`]); another
        /// generator computes the derivatives on the spot instead.
        table: u64,
    },
    /// The paper profile on u, with limits constant along the line.
    Paper(PaperChannel),
}

/// The move under way (fixed-size on purpose, as [`Law`]).
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
enum Active {
    Idle,
    Joint {
        start: [i64; MAX_AXES],
        distance: [i64; MAX_AXES],
        law: Law,
        sync: Sync,
        /// Speed override of the move as a fraction.
        scale: f64,
        /// A second PTP from rest at the end to this target [pulse] (a PTP through a via
        /// that could not be passed moving: two moves in one).
        then: Option<[i64; MAX_AXES]>,
    },
    /// A Cartesian move: a straight line or a composite path.
    Line {
        path: Geometry,
        law: LineLaw,
        target: [i64; MAX_AXES],
        last: Joints,
        /// When the line starts, after the move's first period's start [s] (0, or the end
        /// of a blended approach's first part).
        t0: f64,
        /// What follows the path.
        then: Then,
    },
    /// A blended approach (docs/motion.md): every axis's jerk-limited move to the line's
    /// start, reached at the line's entry velocity, then the line, which takes over at
    /// `ptp.duration()` (the variant becomes [`Active::Line`] there).
    Approach {
        ptp: JerkAxes,
        /// The last period from which a stop at every axis's full limits, asked for up to
        /// two periods later, still comes to rest behind the line's start.
        commit_k: u64,
        path: Geometry,
        law: LineLaw,
        target: [i64; MAX_AXES],
        last: Joints,
        /// A stop asked for after the commit point: the first part runs on to the line,
        /// which brakes with these limits from its start (on the line, not sideways into
        /// the station).
        stop: Option<BrakeLimits>,
    },
    /// Ruckig's synchronised moves in joint space, one after the other (`count` of
    /// `parts`, from time `t0` of the move), ending at rest on `target` [pulse]: a PTP
    /// through a via point, or the PTP a path flows into.
    Jerk {
        parts: [JerkAxes; 2],
        count: usize,
        t0: f64,
        target: [i64; MAX_AXES],
    },
    /// Every axis's own time-optimal brake ([`Brake1d`]), from a state off any single law
    /// (a stop during a blended approach's first part); `goal` is the move's.
    Brake {
        brakes: [Brake1d; RUCKIG_DOF],
        n: usize,
        t0: f64,
        goal: Goal,
    },
}

/// What follows a Cartesian move ([`Active::Line`]); fixed-size on purpose, as [`Law`].
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
enum Then {
    /// Nothing: the move ends with the path.
    End,
    /// A PTP from rest at the path's end to `target` [pulse] (a path that could not flow
    /// into it moving: two moves in one).
    Ptp { target: [i64; MAX_AXES] },
    /// The path's law is cut at `cut` (the law's parameter, where the path ends; beyond it
    /// the law's window continues the last segment, room for its brakes), reached `t_cut`
    /// [s] after the path's start; from there `ptp` takes every axis to rest on `target`.
    Flow {
        t_cut: f64,
        ptp: JerkAxes,
        target: [i64; MAX_AXES],
    },
    /// The path's law is planned to rest at the path's end and waits at its junction (the
    /// first knot whose search looks past that end) to decide how it leaves: flowing into
    /// the PTP, or not ([`VelocityGenerator::plan_depart`]).
    Depart(Junction),
    /// A stop came during the path: it ends there; the move was going to `target`.
    Cancelled { target: [i64; MAX_AXES] },
}

/// What a path that flows into a PTP needs to decide how it leaves at its junction
/// ([`Then::Depart`]); fixed-size.
#[derive(Debug, Clone, Copy)]
struct Junction {
    /// The law's parameter where the path ends (its law is planned with its bounds ending
    /// there until it decides).
    cut: f64,
    /// The ends of the rooms past the path's end that were checked, largest first [law's
    /// parameter]: a flowing exit's law may brake up to one of them.
    rooms: [f64; DEPART_ROOM_MM.len()],
    /// How many of `rooms` there are.
    count: usize,
    /// The joints where the path ends.
    at_cut: Joints,
    /// The PTP's target [deg or mm], and in pulses.
    to: Joints,
    target: [i64; MAX_AXES],
    /// The speed and acceleration overrides of the PTP, as fractions.
    scales: (f64, f64),
}

impl Then {
    /// The joint target the move goes on to, if any.
    fn target(&self) -> Option<[i64; MAX_AXES]> {
        match self {
            Then::End => None,
            Then::Ptp { target } | Then::Flow { target, .. } | Then::Cancelled { target } => {
                Some(*target)
            }
            Then::Depart(j) => Some(j.target),
        }
    }
}

/// The dynamic state of a [`VelocityGenerator`]: position, the move under way and its
/// progress. `Copy` and heap-free, so a real-time task can keep one per queued period and
/// restart from any of them (e.g. to stop from the period the Pulse Generator has reached).
#[derive(Debug, Clone, Copy)]
pub struct MotionState {
    position: [i64; MAX_AXES],
    active: Active,
    k: u64,
    stopped: bool,
    speed_pct: f64,
    accel_pct: f64,
}

impl MotionState {
    /// Commanded position [pulse] in this state.
    pub fn position_pulses(&self) -> &[i64; MAX_AXES] {
        &self.position
    }

    /// Whether a move is under way in this state.
    pub fn is_moving(&self) -> bool {
        !matches!(self.active, Active::Idle)
    }

    /// Where the move under way in this state is going (also while it is being stopped);
    /// `None` when idle.
    pub fn goal(&self) -> Option<Goal> {
        match &self.active {
            Active::Idle => None,
            Active::Joint {
                start,
                distance,
                then,
                ..
            } => {
                let mut target = [0i64; MAX_AXES];
                for ((t, s), d) in target.iter_mut().zip(start).zip(distance) {
                    *t = s + d;
                }
                Some(Goal::Joints(then.unwrap_or(target)))
            }
            Active::Line {
                path, target, then, ..
            } => Some(match then.target() {
                Some(t) => Goal::Joints(t),
                None => Goal::of_path(path, *target),
            }),
            Active::Approach { path, target, .. } => Some(Goal::of_path(path, *target)),
            Active::Jerk { target, .. } => Some(Goal::Joints(*target)),
            Active::Brake { goal, .. } => Some(*goal),
        }
    }

    /// Whether a stop from this state brakes along the motion's own path, so that the brake
    /// ends on the path before its end: a PTP or jog in phase or single-axis sync (default
    /// profile), a straight line or path, a blended approach past its commit point. False
    /// where every axis brakes on its own and leaves the path: a time-synchronised PTP, the
    /// paper profile's channels, Ruckig's parts (a PTP blend, an approach's first part before
    /// its commit point), a brake already under way. True at rest.
    pub fn brakes_on_path(&self) -> bool {
        match &self.active {
            Active::Idle | Active::Line { .. } => true,
            Active::Joint { law, sync, .. } => matches!(law, Law::Fir(_)) && *sync != Sync::Time,
            Active::Approach { commit_k, .. } => self.k > *commit_k,
            Active::Jerk { .. } | Active::Brake { .. } => false,
        }
    }

    /// Whether a blended approach under way in this state has passed the last moment from
    /// which a stop at full limits (asked for up to two periods later) still ends behind
    /// the line's start: the hand is committed to enter. True for any other line, false
    /// for every other move and at rest.
    pub fn entry_committed(&self) -> bool {
        match &self.active {
            Active::Approach { commit_k, .. } => self.k > *commit_k,
            Active::Line { .. } => true,
            _ => false,
        }
    }
}

/// The velocity generator of one robot.
#[derive(Debug, Clone)]
pub struct VelocityGenerator {
    robot: Robot,
    settings: MotionSettings,
    position: [i64; MAX_AXES],
    active: Active,
    /// Periods done in the active move.
    k: u64,
    stopped: bool,
    /// Acceleration override for the next moves [%] (1-100): scales every acceleration and
    /// jerk limit a move is planned with, not the limits it stops with.
    accel_pct: f64,
    /// The axes a straight line moves.
    line_axes: LineAxes,
    /// Derivatives of the last line planned (preallocated: planning does not allocate).
    table: DerivTable,
    /// Ruckig, for a blended approach's first part (preallocated; boxed: its calculator is
    /// some 24 kB, too much to move around on a real-time thread's stack).
    planner: Box<Planner>,
    /// How the blends between a PTP and a path search their candidates.
    search: BlendSearch,
    /// What those searches did.
    stats: SearchStats,
}

impl VelocityGenerator {
    /// A generator for `robot`, idle at the home position.
    pub fn new(robot: Robot, settings: MotionSettings) -> Result<VelocityGenerator, SettingsError> {
        settings.validate()?;
        let position = robot.joints_to_pulses(&robot.home());
        let line_axes = LineAxes::of(&robot);
        Ok(VelocityGenerator {
            robot,
            settings,
            position,
            active: Active::Idle,
            k: 0,
            stopped: false,
            accel_pct: 100.0,
            line_axes,
            table: DerivTable::new(),
            planner: Box::new(Planner::new()),
            search: BlendSearch::DEFAULT,
            stats: SearchStats::default(),
        })
    }

    /// How the blends between a PTP and a path ([`VelocityGenerator::plan_ptp_into`],
    /// [`VelocityGenerator::plan_depart`], [`VelocityGenerator::plan_approach`]) search their
    /// candidates: [`BlendSearch::DEFAULT`], bounded for the real-time task, unless set.
    pub fn set_blend_search(&mut self, search: BlendSearch) {
        self.search = search;
    }

    /// The blends' search in force.
    pub fn blend_search(&self) -> BlendSearch {
        self.search
    }

    /// What the blends' searches of this generator did: how many, how many ran out of
    /// their budget and stopped at the junction, their work.
    pub fn search_stats(&self) -> SearchStats {
        self.stats
    }

    /// The robot.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// The settings in force.
    pub fn settings(&self) -> &MotionSettings {
        &self.settings
    }

    /// Commanded position: the sum of every pulse emitted [pulse].
    pub fn position_pulses(&self) -> &[i64; MAX_AXES] {
        &self.position
    }

    /// Commanded position in axis units.
    pub fn joints(&self) -> Joints {
        self.robot.pulses_to_joints(&self.position)
    }

    /// Commanded TCP pose.
    pub fn pose(&self) -> Pose {
        self.robot.forward(&self.joints())
    }

    /// The dynamic state, to restore later with [`VelocityGenerator::restore`].
    pub fn state(&self) -> MotionState {
        MotionState {
            position: self.position,
            active: self.active,
            k: self.k,
            stopped: self.stopped,
            speed_pct: self.settings.speed_pct,
            accel_pct: self.accel_pct,
        }
    }

    /// Continue from a state taken from this generator (or one with the same robot and
    /// settings) by [`VelocityGenerator::state`]. Never allocates.
    pub fn restore(&mut self, state: &MotionState) {
        self.position = state.position;
        self.active = state.active;
        self.k = state.k;
        self.stopped = state.stopped;
        self.settings.speed_pct = state.speed_pct;
        self.accel_pct = state.accel_pct;
    }

    /// Whether a move is under way.
    pub fn is_moving(&self) -> bool {
        !matches!(self.active, Active::Idle)
    }

    /// Where the move under way is going; `None` when idle (see [`MotionState::goal`]).
    pub fn goal(&self) -> Option<Goal> {
        self.state().goal()
    }

    /// Set the commanded position (after homing, or to start from a known place). Refused
    /// while moving.
    pub fn set_position_pulses(&mut self, pulses: &[i64; MAX_AXES]) -> Result<(), PlanError> {
        if self.is_moving() {
            return Err(PlanError::Busy);
        }
        let mut p = *pulses;
        for v in p.iter_mut().skip(self.robot.axis_count()) {
            *v = 0;
        }
        self.position = p;
        Ok(())
    }

    /// Drop the move under way without braking and rest at `pulses`: for a board that no
    /// longer answers, where no brake can be carried out and the arm is where the board
    /// last said. Never allocates.
    pub fn abandon_at(&mut self, pulses: &[i64; MAX_AXES]) {
        self.active = Active::Idle;
        self.k = 0;
        self.stopped = false;
        let mut p = *pulses;
        for v in p.iter_mut().skip(self.robot.axis_count()) {
            *v = 0;
        }
        self.position = p;
    }

    /// Speed override in force for the next move [%].
    pub fn speed_pct(&self) -> f64 {
        self.settings.speed_pct
    }

    /// Set the speed override for the next moves, 1 to 100 %.
    pub fn set_speed_pct(&mut self, pct: f64) -> Result<(), PlanError> {
        check_speed_pct(pct).map_err(|_| PlanError::SpeedOverride(pct))?;
        self.settings.speed_pct = pct;
        Ok(())
    }

    /// Acceleration override in force for the next move [%].
    pub fn accel_pct(&self) -> f64 {
        self.accel_pct
    }

    /// Set the acceleration override for the next moves, 1 to 100 %: every move planned
    /// after it (PTP, jog, straight line, path, blends) is planned with each acceleration
    /// limit and each jerk limit (every axis's and the TCP's) times `pct`/100, on top of the
    /// speed override (velocity ×p, acceleration ×p²·α, jerk ×p³·α). A stop is never weaker
    /// for it: STOP and HOLD brake with the speed override's limits, ESTOP with the full
    /// ones, whatever the acceleration override.
    pub fn set_accel_pct(&mut self, pct: f64) -> Result<(), PlanError> {
        check_speed_pct(pct).map_err(|_| PlanError::AccelOverride(pct))?;
        self.accel_pct = pct;
        Ok(())
    }

    /// The acceleration override as a fraction (0, 1].
    fn accel(&self) -> f64 {
        self.accel_pct / 100.0
    }

    fn ensure_idle(&self) -> Result<(), PlanError> {
        if self.is_moving() {
            Err(PlanError::Busy)
        } else {
            Ok(())
        }
    }

    fn scale(&self) -> f64 {
        self.settings.speed_pct / 100.0
    }

    /// Plan a PTP move in joint space to `target` [deg or mm per axis]: all axes start and
    /// finish together, each within its own limits.
    pub fn plan_ptp(&mut self, target: &Joints) -> Result<MoveInfo, PlanError> {
        self.ensure_idle()?;
        self.robot.check_joints(target)?;
        self.ptp_to_pulses(&self.robot.joints_to_pulses(target))
    }

    /// Plan a PTP move in joint space to `target` [pulse per axis; entries past the axis
    /// count are ignored], exactly: e.g. to resume a held move to its [`Goal::Joints`]
    /// without rounding through units. Refused if a target is beyond its axis's limits.
    pub fn plan_ptp_pulses(&mut self, target: &[i64; MAX_AXES]) -> Result<MoveInfo, PlanError> {
        self.ensure_idle()?;
        self.robot
            .check_joints(&self.robot.pulses_to_joints(target))?;
        self.ptp_to_pulses(target)
    }

    fn ptp_to_pulses(&mut self, goal: &[i64; MAX_AXES]) -> Result<MoveInfo, PlanError> {
        let mut distance = [0i64; MAX_AXES];
        for (i, d) in distance
            .iter_mut()
            .enumerate()
            .take(self.robot.axis_count())
        {
            *d = goal[i]
                .checked_sub(self.position[i])
                .ok_or(PlanError::TooLong("pulse count overflows"))?;
        }
        Ok(self.start_joint_move(distance))
    }

    /// Plan a PTP move to a Cartesian pose with the given elbow posture, or the current one
    /// when `None` (right-handed if the arm is exactly straight). Where the joint ranges
    /// allow several solutions (the shoulder or the hand a turn apart), the move goes to the
    /// one it reaches soonest ([`crate::ptp_target`]).
    pub fn plan_ptp_pose(
        &mut self,
        target: &Pose,
        posture: Option<Posture>,
    ) -> Result<MoveInfo, PlanError> {
        self.ensure_idle()?;
        let current = self.joints();
        let posture = posture
            .or_else(|| Posture::of(&self.robot, &current))
            .unwrap_or(Posture::Right);
        let joints = ptp_target(&self.robot, &current, target, posture)?;
        self.plan_ptp(&joints)
    }

    /// Plan a jog: `pulses` on axis `axis`, with the same acceleration and deceleration.
    pub fn plan_jog(&mut self, axis: usize, pulses: i64) -> Result<MoveInfo, PlanError> {
        self.ensure_idle()?;
        let count = self.robot.axis_count();
        if axis >= count {
            return Err(PlanError::NoSuchAxis { index: axis, count });
        }
        let a = &self.robot.axes()[axis];
        let end = self.position[axis]
            .checked_add(pulses)
            .ok_or(PlanError::TooLong("pulse count overflows"))?;
        let target = a.pulses_to_units(end);
        if !a.within_limits(target) {
            return Err(PlanError::JogBeyondLimit {
                axis: a.name,
                target,
                min: a.min,
                max: a.max,
            });
        }
        let mut distance = [0i64; MAX_AXES];
        distance[axis] = pulses;
        Ok(self.start_joint_move(distance))
    }

    /// Plan a straight line of the TCP from the current pose to `target`, keeping the current
    /// elbow posture and following every joint continuously. Refused before any pulse when
    /// any point of the line is out of reach, too close to a singularity, or needs a joint
    /// beyond its limits (the error names the axis, where along the line and the pose).
    ///
    /// Under the default profile the line is timed by the time-optimal jerk-limited law
    /// (docs/motion.md); this runs the law once to its end, for the duration in the
    /// [`MoveInfo`] — some milliseconds, without allocating. A real-time task that does not
    /// need the duration beforehand calls [`VelocityGenerator::start_line`] instead.
    pub fn plan_line(&mut self, target: &Pose) -> Result<MoveInfo, PlanError> {
        if !self.start_line(target)? {
            return Ok(self.nothing_to_do());
        }
        self.run_ahead()
    }

    /// The duration of the Cartesian move just started: its law run to its end once, on a
    /// copy. Refused (and the move dropped) if the law does not get there.
    fn run_ahead(&mut self) -> Result<MoveInfo, PlanError> {
        let ts = self.settings.period_s;
        let info = match &self.active {
            Active::Line {
                law:
                    LineLaw::Timed {
                        profile,
                        bounds,
                        scale,
                        ..
                    },
                ..
            } => {
                // Run the law to its end once: the duration, and proof that it gets there.
                let table = &self.table;
                let derivs = |u: f64| table.at(u);
                let mut dry = *profile;
                let end_t = dry.run_to_end(bounds, &derivs);
                if !dry.completed() {
                    let fraction_pct = 100.0 * dry.at(bounds, &derivs, end_t);
                    self.nothing_to_do();
                    return Err(PlanError::Untimed { fraction_pct });
                }
                let duration_s = end_t / scale;
                MoveInfo {
                    duration_s,
                    periods: periods_for(duration_s, ts),
                    sync: Sync::Single,
                }
            }
            Active::Line {
                law: LineLaw::Paper(ch),
                ..
            } => MoveInfo {
                duration_s: ch.total_periods() as f64 * ts,
                periods: ch.total_periods(),
                sync: Sync::Single,
            },
            Active::Idle
            | Active::Joint { .. }
            | Active::Approach { .. }
            | Active::Jerk { .. }
            | Active::Brake { .. } => return Ok(self.nothing_to_do()),
        };
        Ok(info)
    }

    /// Start a straight line as [`VelocityGenerator::plan_line`] does, without running its
    /// timing law ahead: before the first pulse only the line's check (and its derivative
    /// table) is computed; the law advances as periods are produced (docs/motion.md gives
    /// both costs). Returns whether anything moves. The law cannot stall short of the target:
    /// from any state of it, either speeding up is safe or its verified brake moves on.
    pub fn start_line(&mut self, target: &Pose) -> Result<bool, PlanError> {
        self.start_line_at(target, self.scale())
    }

    /// [`VelocityGenerator::start_line`] at speed override `scale` (a fraction).
    fn start_line_at(&mut self, target: &Pose, scale: f64) -> Result<bool, PlanError> {
        self.ensure_idle()?;
        let current = self.joints();
        let (line, check) = line_path(&self.robot, &current, target, Some(&mut self.table))?;
        self.start_cartesian(Geometry::Line(line), &check, &current, scale, Then::End)
    }

    /// The bounds a Cartesian move along `path` is planned with (at the acceleration
    /// override in force).
    fn bounds_of(&self, path: &Geometry) -> Bounds {
        let (robot, axes, line) = (&self.robot, &self.line_axes, &self.settings.line);
        match path {
            Geometry::Line(l) => Bounds::new(robot, axes, line, l.length_mm()),
            Geometry::Curve(_) => Bounds::for_path(robot, axes, line, path.length_mm()),
        }
        .with_accel(self.accel())
    }

    /// Start the Cartesian move along `path` — checked from `current` by `check`, its
    /// derivative table filled — at speed override `scale` (a fraction), followed by `then`.
    fn start_cartesian(
        &mut self,
        path: Geometry,
        check: &PathCheck,
        current: &Joints,
        scale: f64,
        then: Then,
    ) -> Result<bool, PlanError> {
        let target_pulses = self.robot.joints_to_pulses(&check.end_joints);
        let n = self.robot.axis_count();
        if target_pulses[..n] == self.position[..n] {
            self.nothing_to_do();
            return Ok(false);
        }
        let ts = self.settings.period_s;
        let length = path.length_mm();
        let law = match self.settings.profile {
            Profile::Fir => {
                let bounds = self.bounds_of(&path);
                let table = &self.table;
                LineLaw::Timed {
                    profile: LineProfile::start(&bounds, &|u: f64| table.at(u)),
                    bounds,
                    scale,
                    table: table.id,
                }
            }
            Profile::Paper { mask_len } => {
                let limits = check.constant_limits_with(
                    &self.robot,
                    length,
                    &self.settings.line,
                    scale,
                    self.accel(),
                );
                if limits.v <= 0.0 {
                    self.nothing_to_do();
                    return Ok(false);
                }
                let half = (mask_len / 2) as u64;
                let rate = paper_rate(limits.v, limits.a, limits.j, half, ts) * ts; // u per period
                let periods = ((1.0 / rate).ceil() as u64).max(2 * half);
                LineLaw::Paper(PaperChannel::new(LINE_COUNTS, periods, half))
            }
        };
        self.active = Active::Line {
            path,
            law,
            target: target_pulses,
            last: *current,
            t0: 0.0,
            then,
        };
        self.k = 0;
        self.stopped = false;
        Ok(true)
    }

    /// Refused under the paper profile, whose moves start and end at rest.
    fn fir_only(&self) -> Result<(), PlanError> {
        match self.settings.profile {
            Profile::Fir => Ok(()),
            Profile::Paper { .. } => Err(PlanError::ProfileUnsupported),
        }
    }

    /// Plan a composite path ([`PathSpec`]: lines and arcs, corners blended) as
    /// [`VelocityGenerator::plan_line`] plans a line: checked at every point, timed by the
    /// same time-optimal jerk-limited law within every joint's limits and the TCP's (its
    /// speed, tangential acceleration and jerk along the path within the line limits, its
    /// centripetal acceleration within the line acceleration limit), the law run once to its
    /// end for the duration.
    pub fn plan_path(&mut self, path: &PathSpec) -> Result<MoveInfo, PlanError> {
        if !self.start_path(path)? {
            return Ok(self.nothing_to_do());
        }
        self.run_ahead()
    }

    /// Start a composite path as [`VelocityGenerator::start_line`] starts a line: before the
    /// first pulse the path is built and checked at every point (as [`crate::check_path`]
    /// does) and its derivative table filled; the law advances as periods are produced.
    /// From the path's start (within [`crate::START_TOL_MM`]) the whole path; from a point of
    /// it (a RESUME after a HOLD on it) the rest of it, to the same end; from anywhere else
    /// refused ([`PlanError::NotOnPath`]). Returns whether anything moves. Only under the
    /// default profile.
    pub fn start_path(&mut self, path: &PathSpec) -> Result<bool, PlanError> {
        self.start_path_at(path, self.scale())
    }

    /// [`VelocityGenerator::start_path`] at speed override `scale` (a fraction).
    fn start_path_at(&mut self, spec: &PathSpec, scale: f64) -> Result<bool, PlanError> {
        self.ensure_idle()?;
        self.fir_only()?;
        let current = self.joints();
        let Some(window) = path_window(&self.robot, &current, spec)? else {
            self.nothing_to_do();
            return Ok(false);
        };
        let path = Geometry::Curve(window);
        let check = scan(&path, &self.robot, &current, Some(&mut self.table))?;
        self.start_cartesian(path, &check, &current, scale, Then::End)
    }

    /// Plan a blended approach (docs/motion.md, "Blended approach"): every axis from here to
    /// `via` (the joints of the line's start, checked by the caller), reached moving at the
    /// line's entry velocity instead of at rest, flowing into the straight line from there
    /// to `target` at `line_pct` (never faster than this move's override). The first part
    /// is Ruckig's time-optimal synchronised move to that moving state, within every axis's
    /// limits at the override. The line is entered at 90 % of the fastest speed its limits
    /// allow without acceleration, at ½ or ¼ of it, or at rest (a rest-to-rest approach in
    /// one move): of those whose first part keeps every joint in range and, entering
    /// moving, the TCP behind the line's start, the one that gets to `target` soonest (from
    /// the approach pose itself, entering at rest) by the estimate of the line's law
    /// ([`BlendSearch`]; by the law itself under [`BlendSearch::Exhaustive`]). The entry at
    /// rest, the fallback, is planned first; the moving ones only while the budget of work
    /// lasts (a fallback taken for want of it is counted in [`SearchStats`]). Entering at
    /// rest is the
    /// unblended transfer's move to the approach pose, committed only there. Refused
    /// ([`PlanError::ApproachCrossesEntry`]) if none passes. This is
    /// [`VelocityGenerator::plan_ptp_into`] with [`EntryRule::Station`] on a straight line.
    ///
    /// From the hand already on the line between its start and `target` (a `RESUME` after
    /// a HOLD inside) it is the line alone. Returns whether anything moves. Only under the
    /// default profile: the paper profile is refused (its moves start and end at rest).
    pub fn plan_approach(
        &mut self,
        via: &Joints,
        target: &Pose,
        line_pct: f64,
    ) -> Result<bool, PlanError> {
        self.ensure_idle()?;
        check_speed_pct(line_pct).map_err(|_| PlanError::SpeedOverride(line_pct))?;
        if self.settings.profile != Profile::Fir {
            return Err(PlanError::ApproachCrossesEntry);
        }
        self.robot.check_joints(via)?;
        let line_scale = (line_pct / 100.0).min(self.scale());
        let current = self.joints();
        let here = self.robot.forward(&current);
        let entry = self.robot.forward(via);
        // At the approach pose already (within a pulse: a GET right after a PUT there), or
        // on the line between it and the target: the line alone, from here.
        let via_pulses = self.robot.joints_to_pulses(via);
        let there =
            (0..self.robot.axis_count()).all(|i| (via_pulses[i] - self.position[i]).abs() <= 1);
        if there || on_segment(&here, &entry, target) {
            return self.start_line_at(target, line_scale);
        }
        let (line, check) = line_path(&self.robot, via, target, Some(&mut self.table))?;
        self.plan_entry(
            via,
            Geometry::Line(line),
            &check,
            line_scale,
            EntryRule::Station,
        )
    }

    /// Plan a PTP into a composite path without stopping at its start (docs/motion.md, "PTP
    /// blends"): every axis from here to `via` (the joints at the path's start,
    /// `path.start`, checked by the caller), reached moving at the path's entry velocity,
    /// flowing into `path` at `path_pct` (never faster than this move's override). The same
    /// planning as [`VelocityGenerator::plan_approach`] — four entry speeds, down to rest (a
    /// PTP and the path in one move), of those that keep every joint in range the one that
    /// gets [`ENTRY_HORIZON_MM`] along the path soonest by the estimate of its law (no law
    /// is run ahead: a few milliseconds before the first pulse, whatever the path; past the
    /// budget of work of [`BlendSearch`], the entry at rest) — with
    /// `rule`: [`EntryRule::Free`] for a program's blended PTP
    /// (no station rule, so it never refuses what the PTP and the path as two moves would
    /// do), [`EntryRule::Station`] for a transfer. From the path's start or a point of it (a
    /// RESUME after a HOLD on it) it is the path alone, from there. Returns whether anything
    /// moves. Only under the default profile.
    pub fn plan_ptp_into(
        &mut self,
        via: &Joints,
        path: &PathSpec,
        path_pct: f64,
        rule: EntryRule,
    ) -> Result<bool, PlanError> {
        self.ensure_idle()?;
        check_speed_pct(path_pct).map_err(|_| PlanError::SpeedOverride(path_pct))?;
        self.fir_only()?;
        self.robot.check_joints(via)?;
        let scale = (path_pct / 100.0).min(self.scale());
        let current = self.joints();
        let curve = Curve::build(path, self.robot.arm().wrist.is_some())?;
        if place_on(&self.robot, &curve, path, &current, 1.0).is_ok() {
            return self.start_path_at(path, scale);
        }
        let Some(window) = path_window(&self.robot, via, path)? else {
            // `via` is where the path ends (it has no length from there): the PTP alone.
            return self.plan_ptp(via).map(|info| info.periods > 0);
        };
        if window.from > 0.0 {
            // `via` is on the path but not its start.
            return Err(PlanError::NotOnPath {
                here: self.robot.forward(via),
                start: path.start,
            });
        }
        let geometry = Geometry::Curve(window);
        let check = scan(&geometry, &self.robot, via, Some(&mut self.table))?;
        self.plan_entry(via, geometry, &check, scale, rule)
    }

    /// A blended entry: from here to `via` (the joints at the start of `path`, which is
    /// checked from them by `check` and tabulated), reached moving, flowing into `path` at
    /// speed override `line_scale`, with `rule` (docs/motion.md, "Blended approach").
    fn plan_entry(
        &mut self,
        via: &Joints,
        path: Geometry,
        check: &PathCheck,
        line_scale: f64,
        rule: EntryRule,
    ) -> Result<bool, PlanError> {
        let current = self.joints();
        let here = self.robot.forward(&current);
        let entry = self.robot.forward(via);
        let target_pulses = self.robot.joints_to_pulses(&check.end_joints);
        let bounds = self.bounds_of(&path);
        // The station's half-plane: across the direction in which the path leaves its start.
        let d = path.pose_jet(0.0);
        let (dx, dy) = (d.x.d[1], d.y.d[1]);
        let norm = dx.hypot(dy);
        let dir = if norm > 1e-9 && rule == EntryRule::Station {
            (dx / norm, dy / norm)
        } else {
            (0.0, 0.0)
        };
        // How far into the station (along the path, from its start) a pose is [mm].
        let along = |p: &Pose| (p.x - entry.x) * dir.0 + (p.y - entry.y) * dir.1;
        let inner = along(&here).max(0.0) + 1e-6;
        let v_max = 0.9 * LineProfile::entry_speed(&bounds, &|u: f64| self.table.at(u));
        let scale = (self.scale(), self.accel());
        let ts = self.settings.period_s;
        // Where the entries are compared: a line's end, or ENTRY_HORIZON_MM along a path,
        // where the entries no longer differ.
        let horizon = match path {
            Geometry::Line(_) => 1.0,
            Geometry::Curve(_) => (ENTRY_HORIZON_MM / path.length_mm()).min(1.0),
        };
        let work = Work::new(self.search);
        let mut skipped = false;
        // The fastest moving candidate and the entry at rest: (duration, first part, its
        // commit period, the line's law). The entry at rest, the fallback, is planned first
        // whatever the budget; each moving one checks the budget before its brake is
        // verified and before its time is estimated, and none is started once it is spent.
        let mut best: Option<(f64, JerkAxes, u64, LineProfile)> = None;
        let mut at_rest: Option<(f64, JerkAxes, u64, LineProfile)> = None;
        for fraction in [0.0, 1.0, 0.5, 0.25] {
            let table = &self.table;
            let rows = |u: f64| table.at(u);
            let derivs = work.counting(&rows);
            let v0 = v_max * fraction;
            if v0 > 0.0 && !work.left() {
                skipped = true;
                break;
            }
            let profile = if v0 > 0.0 {
                match LineProfile::start_moving(&bounds, &derivs, v0) {
                    Some(p) => p,
                    None => continue,
                }
            } else {
                LineProfile::start(&bounds, &derivs)
            };
            // The path's joint velocity and acceleration where it starts, in real time.
            let d0 = derivs(0.0);
            let (mut vel, mut acc) = ([0.0; MAX_AXES], [0.0; MAX_AXES]);
            for k in 0..self.line_axes.n {
                let i = self.line_axes.idx[k];
                vel[i] = line_scale * d0.d1[k] * v0;
                acc[i] = line_scale * line_scale * d0.d2[k] * v0 * v0;
            }
            let Some(ptp) =
                self.planner
                    .rest_to_moving(&self.robot, &current, via, &vel, &acc, scale)
            else {
                continue;
            };
            // Every point of the first part: each joint in range, and for a station the TCP
            // never further in than the path's start (or than where it starts, if a stop
            // left it inside). The entry at rest is the move to the approach pose a transfer
            // makes without blending: only its joints are checked, so blending never refuses
            // a transfer that the unblended one makes (the half-plane behind the line's start
            // also holds poses far to the side of the station, which a move from the other
            // side of the robot passes through).
            let step = ts.min(0.002);
            let samples = (ptp.duration() / step).ceil() as u64;
            let keeps = (0..=samples).all(|k| {
                let q = ptp.state(k as f64 * step).0;
                self.robot.check_joints(&q).is_ok()
                    && (v0 == 0.0 || along(&self.robot.forward(&q)) <= inner)
            });
            if !keeps {
                continue;
            }
            // The last period from which every axis's full-limit brake ends behind the start;
            // entering at rest, the end of the first part (at the approach pose, where a
            // transfer without blending checks the station's interlock). Without a station
            // there is nothing to commit to.
            let periods = (ptp.duration() / ts).ceil() as u64;
            let mut last_ok = if v0 == 0.0 { periods + 2 } else { 0u64 };
            for k in (0..=periods).filter(|_| v0 > 0.0 && rule == EntryRule::Station) {
                let (q, v, a) = ptp.state(k as f64 * ts);
                let mut stop = q;
                for (i, s) in stop.iter_mut().enumerate().take(self.robot.axis_count()) {
                    let l = &self.robot.axes()[i].limits;
                    *s = Brake1d::new(q[i], v[i], a[i], l.max_acceleration, l.max_jerk)
                        .stop_position();
                }
                if along(&self.robot.forward(&stop)) > inner {
                    break;
                }
                last_ok = k;
            }
            if rule == EntryRule::Free {
                last_ok = 0;
            }
            if v0 > 0.0 && !work.left() {
                skipped = true;
                break;
            }
            // The path's time from this entry to the horizon: estimated (bounded search), or
            // its law run there on a copy (exhaustive: a path's law costs tens of
            // milliseconds for the four entries).
            let end_t = match self.search {
                BlendSearch::Bounded { .. } => estimate_time(&bounds, &derivs, v0, horizon),
                BlendSearch::Exhaustive => {
                    let mut dry = profile;
                    match path {
                        Geometry::Line(_) => {
                            let end_t = dry.run_to_end(&bounds, &derivs);
                            if !dry.completed() {
                                continue;
                            }
                            end_t
                        }
                        Geometry::Curve(_) => match dry.time_at(&bounds, &derivs, horizon) {
                            Some((t, _)) => t,
                            None => continue,
                        },
                    }
                }
            };
            if !end_t.is_finite() {
                continue;
            }
            let candidate = (
                ptp.duration() + end_t / line_scale,
                ptp,
                last_ok.saturating_sub(2),
                profile,
            );
            if v0 == 0.0 {
                at_rest = Some(candidate);
            } else if best.as_ref().is_none_or(|b| candidate.0 < b.0) {
                best = Some(candidate);
            }
        }
        // The entry at rest only if it is sooner than every moving one: a fallback when the
        // budget left it the only one.
        let rest_sooner = match (&at_rest, &best) {
            (Some(r), Some(b)) => r.0 < b.0,
            (Some(_), None) => true,
            (None, _) => false,
        };
        if rest_sooner {
            best = at_rest;
        }
        self.stats.record(&work, skipped && rest_sooner);
        let Some((_, ptp, commit_k, profile)) = best else {
            self.nothing_to_do();
            return Err(PlanError::ApproachCrossesEntry);
        };
        self.active = Active::Approach {
            ptp,
            commit_k,
            path,
            law: LineLaw::Timed {
                profile,
                bounds,
                scale: line_scale,
                table: self.table.id,
            },
            target: target_pulses,
            last: *via,
            stop: None,
        };
        self.k = 0;
        self.stopped = false;
        Ok(true)
    }

    /// Plan a composite path that flows into a PTP without stopping at its end (docs/
    /// motion.md, "PTP blends"): `path` at `path_pct` (never faster than this move's
    /// override), then every axis to the joints `to` and rest there, jerk-limited and
    /// time-optimal (Ruckig from the path's state where it ends), the TCP leaving the path at
    /// its end moving.
    ///
    /// How fast it leaves: a flowing exit's law is planned with room past the path's end to
    /// brake along its continuation (its last segment continued) — 100, 30 or 10 mm
    /// ([`DEPART_ROOM_MM`]), checked like the path — so the path may end moving; every state
    /// of it keeps a verified brake along the path, as a line's does. Before the first pulse
    /// only the path and the largest room that keeps in the workspace are checked and
    /// tabulated: the law is planned to rest at the path's end and run as the periods are
    /// produced, up to its *junction*, the first knot from which the search for its next step
    /// looks past the path's end. Up to there the law is the same with any room, so the exit
    /// is decided there, in the period that reaches it, with the law run ahead over the last
    /// stretch only: the rooms largest first, the first whose PTP part keeps every joint in
    /// range (checked every 2 ms) taken, unless the path to rest at its end and the PTP from
    /// there (two moves in one) arrive sooner. When none passes, or the search runs out of
    /// its budget of work ([`BlendSearch`]: counted in [`SearchStats`]), it is those two
    /// moves: it never refuses what they would do.
    ///
    /// From the path's start the whole move; from a point of the path (a RESUME after a HOLD
    /// on it) the rest of the path and the PTP; from anywhere else — at or past the path's end,
    /// or off it (a RESUME after a HOLD in the PTP part) — the PTP to `to` alone. Returns
    /// whether anything moves. Only under the default profile.
    pub fn plan_depart(
        &mut self,
        path: &PathSpec,
        to: &Joints,
        path_pct: f64,
    ) -> Result<bool, PlanError> {
        self.ensure_idle()?;
        check_speed_pct(path_pct).map_err(|_| PlanError::SpeedOverride(path_pct))?;
        self.fir_only()?;
        self.robot.check_joints(to)?;
        let line_scale = (path_pct / 100.0).min(self.scale());
        let current = self.joints();
        let curve = Curve::build(path, self.robot.arm().wrist.is_some())?;
        let total = curve.total();
        let upto = 1.0 + DEPART_ROOM_MM[0] / total;
        let from = match place_on(&self.robot, &curve, path, &current, upto) {
            Ok(u) if u < 1.0 - 1e-9 => u,
            // At or past the path's end, or off it: the PTP alone.
            Ok(_) | Err(_) => return self.plan_ptp(to).map(|info| info.periods > 0),
        };
        let Some(posture) = Posture::of(&self.robot, &current) else {
            // No posture to keep: let the path's own check say why.
            return self.start_path_at(path, line_scale);
        };
        let target = self.robot.joints_to_pulses(to);
        let here = self.robot.forward(&current);
        let window = |to: f64| Window::new(curve, from, to, posture, &here);
        let rest = Geometry::Curve(window(1.0));
        // The path with the largest room past its end that keeps in the workspace, checked
        // and tabulated; if the largest fails, the path alone is checked first (its refusal
        // is the move's).
        let mut room = None;
        for (i, mm) in DEPART_ROOM_MM.iter().enumerate() {
            let w = window(1.0 + mm / total);
            let geometry = Geometry::Curve(w);
            let cut = geometry.path_end();
            match scan_recording(&geometry, &self.robot, &current, Some(&mut self.table), cut) {
                Ok((_, at_cut)) => {
                    room = Some((i, w, at_cut));
                    break;
                }
                Err(_) if i == 0 => {
                    scan(&rest, &self.robot, &current, None)?;
                }
                Err(_) => {}
            }
        }
        let Some((first, w, at_cut)) = room else {
            // No room past the end: the path to rest at its end, then the PTP from there.
            let check = scan(&rest, &self.robot, &current, Some(&mut self.table))?;
            return if self.start_cartesian(
                rest,
                &check,
                &current,
                line_scale,
                Then::Ptp { target },
            )? {
                Ok(true)
            } else {
                self.plan_ptp_pulses(&target).map(|info| info.periods > 0)
            };
        };
        let geometry = Geometry::Curve(w);
        let cut = geometry.path_end();
        let mut rooms = [1.0; DEPART_ROOM_MM.len()];
        let mut count = 0;
        for mm in &DEPART_ROOM_MM[first..] {
            rooms[count] = w.v(1.0 + mm / total);
            count += 1;
        }
        // Planned to rest at the path's end, watched for its junction.
        let bounds = self.bounds_of(&geometry).ending_at(cut);
        let table = &self.table;
        let profile = LineProfile::start_watched(&bounds, &|u: f64| table.at(u));
        let end_pulses = self.robot.joints_to_pulses(&at_cut);
        self.active = Active::Line {
            path: geometry,
            law: LineLaw::Timed {
                profile,
                bounds,
                scale: line_scale,
                table: self.table.id,
            },
            target: end_pulses,
            last: current,
            t0: 0.0,
            then: Then::Depart(Junction {
                cut,
                rooms,
                count,
                at_cut,
                to: *to,
                target,
                scales: (self.scale(), self.accel()),
            }),
        };
        self.k = 0;
        self.stopped = false;
        // A path within a brake of its end is at its junction from the start.
        self.settle_junction();
        Ok(true)
    }

    /// Bring the law of a path into a PTP that has not decided how it leaves up to time
    /// `now` [s] of the move, and decide there if it reaches its junction.
    fn reach_junction(&mut self, now: f64) {
        let Active::Line {
            path,
            law:
                LineLaw::Timed {
                    profile,
                    bounds,
                    scale,
                    table,
                },
            then: Then::Depart(_),
            last,
            t0,
            ..
        } = &mut self.active
        else {
            return;
        };
        let t = (now - *t0) * *scale;
        if *table == self.table.id && !profile.braked_now() {
            let tab = &self.table;
            profile.at(bounds, &|u: f64| tab.at(u), t);
        } else {
            let (robot, axes, reference) = (&self.robot, &self.line_axes, *last);
            profile.at(bounds, &|u: f64| path.derivs(robot, axes, u, &reference), t);
        }
        self.settle_junction();
    }

    /// If the path under way (a path into a PTP) waits at its junction, decide how it leaves
    /// ([`VelocityGenerator::plan_depart`]) and go on. Never allocates.
    fn settle_junction(&mut self) {
        let Active::Line {
            path,
            law:
                LineLaw::Timed {
                    profile,
                    bounds,
                    scale,
                    table,
                },
            then: Then::Depart(junction),
            last,
            ..
        } = self.active
        else {
            return;
        };
        if !profile.at_junction() {
            return;
        }
        let work = Work::new(self.search);
        let step = self.settings.period_s.min(0.002);
        let exit = if table == self.table.id && !profile.braked_now() {
            let tab = &self.table;
            let rows = |u: f64| tab.at(u);
            let derivs = work.counting(&rows);
            exit_at_junction(
                (&self.robot, &mut self.planner, &work, step),
                (&path, &profile, &bounds, scale),
                &junction,
                &derivs,
            )
        } else {
            // Another generator's plan: the derivatives from the kinematics, exactly.
            let (robot, axes) = (&self.robot, &self.line_axes);
            let rows = |u: f64| path.derivs(robot, axes, u, &last);
            let derivs = work.counting(&rows);
            exit_at_junction(
                (robot, &mut self.planner, &work, step),
                (&path, &profile, &bounds, scale),
                &junction,
                &derivs,
            )
        };
        self.stats.record(&work, exit.fell_back);
        if let Active::Line {
            law: LineLaw::Timed {
                profile, bounds, ..
            },
            target,
            then,
            ..
        } = &mut self.active
        {
            (*profile, *bounds, *then) = (exit.profile, exit.bounds, exit.then);
            if matches!(exit.then, Then::Flow { .. }) {
                // The path's own end is not where this move ends.
                *target = junction.target;
            }
        }
    }

    /// Plan a PTP through the joints `via` to the joints `to` without stopping at `via`
    /// (docs/motion.md, "PTP blends"): Ruckig's time-optimal synchronised move from rest to
    /// `via`, reached moving, then from there to rest at `to`, every axis within its limits
    /// at the overrides. The velocity at `via`: each axis that moves on in the same direction
    /// passes it at the smaller of its limit and 1.5 times its mean speed over either part
    /// (the parts' rest-to-rest times), times 1, 0.6 or 0.3; an axis that turns back there
    /// passes it at rest. Both parts are checked every 2 ms (every joint in range), and of the
    /// candidates that pass and the two PTPs at rest (the fallback, two moves in one: it never
    /// refuses what they would do) the one that arrives soonest is taken.
    ///
    /// `start` is where the move began (the end of the previous motion). From elsewhere (a
    /// RESUME after a HOLD) the move is planned again from `start`, as it was, and the point
    /// of it nearest the robot (each axis measured in time at its velocity limit) says where
    /// it was held: before `via` it goes through `via` from here, after it (or at `via`)
    /// straight to `to`. Returns whether anything moves. Only under the default profile.
    pub fn plan_ptp_via(
        &mut self,
        start: &Joints,
        via: &Joints,
        to: &Joints,
    ) -> Result<bool, PlanError> {
        self.ensure_idle()?;
        self.fir_only()?;
        self.robot.check_joints(via)?;
        self.robot.check_joints(to)?;
        let n = self.robot.axis_count();
        let (via_pulses, to_pulses) = (
            self.robot.joints_to_pulses(via),
            self.robot.joints_to_pulses(to),
        );
        let here = self.position;
        let near = |p: &[i64; MAX_AXES]| (0..n).all(|i| (p[i] - here[i]).abs() <= 1);
        let current = self.joints();
        let from_start = near(&self.robot.joints_to_pulses(start));
        if near(&via_pulses) || (!from_start && self.passed_via(start, via, to, &current)) {
            return self
                .plan_ptp_pulses(&to_pulses)
                .map(|info| info.periods > 0);
        }
        match self.via_parts(&current, via, to) {
            Some((first, second)) => {
                self.active = Active::Jerk {
                    parts: [first, second],
                    count: 2,
                    t0: 0.0,
                    target: to_pulses,
                };
                self.k = 0;
                self.stopped = false;
                Ok(true)
            }
            None => {
                // Two PTPs at rest, in one move.
                let info = self.plan_ptp_pulses(&via_pulses)?;
                if info.periods == 0 {
                    return self
                        .plan_ptp_pulses(&to_pulses)
                        .map(|info| info.periods > 0);
                }
                if let Active::Joint { then, .. } = &mut self.active {
                    *then = Some(to_pulses);
                }
                Ok(true)
            }
        }
    }

    /// The two parts of a PTP from `from` through `via` to `to` passing `via` moving
    /// ([`VelocityGenerator::plan_ptp_via`]), or `None` when the two PTPs at rest are as
    /// fast (or no moving candidate passes).
    fn via_parts(
        &mut self,
        from: &Joints,
        via: &Joints,
        to: &Joints,
    ) -> Option<(JerkAxes, JerkAxes)> {
        let n = self.robot.axis_count();
        let (from_pulses, via_pulses, to_pulses) = (
            self.robot.joints_to_pulses(from),
            self.robot.joints_to_pulses(via),
            self.robot.joints_to_pulses(to),
        );
        let t1 = self.ptp_duration(&from_pulses, &via_pulses);
        let t2 = self.ptp_duration(&via_pulses, &to_pulses);
        let fallback = t1 + t2;
        let (s, alpha) = (self.scale(), self.accel());
        let mut nominal = [0.0; MAX_AXES];
        for (i, v) in nominal.iter_mut().enumerate().take(n) {
            let (d1, d2) = (via[i] - from[i], to[i] - via[i]);
            if d1 * d2 > 0.0 && t1 > 0.0 && t2 > 0.0 {
                let limit = self.robot.axes()[i].limits.max_velocity * s;
                *v = d1.signum() * limit.min(1.5 * d1.abs() / t1).min(1.5 * d2.abs() / t2);
            }
        }
        if nominal.iter().all(|&v| v == 0.0) {
            return None;
        }
        let step = self.settings.period_s.min(0.002);
        let rest = [0.0; MAX_AXES];
        let mut best: Option<(f64, JerkAxes, JerkAxes)> = None;
        for fraction in VIA_SPEEDS {
            let vel = nominal.map(|v| v * fraction);
            let Some(first) =
                self.planner
                    .rest_to_moving(&self.robot, from, via, &vel, &rest, (s, alpha))
            else {
                continue;
            };
            let Some(second) = self.planner.between(
                &self.robot,
                (via, &vel, &rest),
                (to, &rest, &rest),
                (s, alpha),
            ) else {
                continue;
            };
            let keeps = [first, second].iter().all(|part| {
                let samples = (part.duration() / step).ceil() as u64;
                (0..=samples).all(|k| {
                    self.robot
                        .check_joints(&part.state(k as f64 * step).0)
                        .is_ok()
                })
            });
            let time = first.duration() + second.duration();
            if keeps && best.as_ref().is_none_or(|b| time < b.0) {
                best = Some((time, first, second));
            }
        }
        best.filter(|b| b.0 < fallback).map(|(_, a, b)| (a, b))
    }

    /// Whether the robot at `q` has passed `via` on the PTP from `start` through `via` to
    /// `to`: the nearest point of that move, planned again from `start` (each axis measured
    /// in time at its velocity limit), is after `via`.
    fn passed_via(&mut self, start: &Joints, via: &Joints, to: &Joints, q: &Joints) -> bool {
        let n = self.robot.axis_count();
        let w: Joints = std::array::from_fn(|i| {
            self.robot
                .axes()
                .get(i)
                .map_or(0.0, |a| 1.0 / a.limits.max_velocity.max(1e-9))
        });
        let dist = |p: &Joints| (0..n).map(|i| ((p[i] - q[i]) * w[i]).powi(2)).sum::<f64>();
        match self.via_parts(start, via, to) {
            Some((first, second)) => {
                let nearest = |part: &JerkAxes| {
                    let samples = (part.duration() / 0.002).ceil().max(1.0) as u64;
                    (0..=samples)
                        .map(|k| dist(&part.state(part.duration() * k as f64 / samples as f64).0))
                        .fold(f64::INFINITY, f64::min)
                };
                nearest(&second) < nearest(&first)
            }
            None => {
                // Two straight lines in joint space.
                let segment = |a: &Joints, b: &Joints| {
                    let (mut ab, mut aq) = (0.0, 0.0);
                    for i in 0..n {
                        let d = (b[i] - a[i]) * w[i];
                        ab += d * d;
                        aq += d * (q[i] - a[i]) * w[i];
                    }
                    let t = if ab > 0.0 {
                        (aq / ab).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let p: Joints = std::array::from_fn(|i| a[i] + t * (b[i] - a[i]));
                    dist(&p)
                };
                segment(via, to) < segment(start, via)
            }
        }
    }

    /// The duration of a PTP from `from` to `to` [pulse] planned now [s]: the slowest axis's
    /// time-optimal profile at the overrides (what the move itself takes, synchronised).
    fn ptp_duration(&self, from: &[i64; MAX_AXES], to: &[i64; MAX_AXES]) -> f64 {
        ptp_time(&self.robot, from, to, (self.scale(), self.accel()))
    }

    fn nothing_to_do(&mut self) -> MoveInfo {
        self.active = Active::Idle;
        MoveInfo {
            duration_s: 0.0,
            periods: 0,
            sync: Sync::Single,
        }
    }

    fn fir_info(&self, profiles: &[DoubleS; MAX_AXES], sync: Sync) -> MoveInfo {
        let end = profiles.iter().map(DoubleS::duration).fold(0.0, f64::max);
        MoveInfo {
            duration_s: end,
            periods: periods_for(end, self.settings.period_s),
            sync,
        }
    }

    /// Start a joint-space move of `distance` pulses per axis.
    fn start_joint_move(&mut self, distance: [i64; MAX_AXES]) -> MoveInfo {
        let n = self.robot.axis_count();
        if distance[..n].iter().all(|&d| d == 0) {
            return self.nothing_to_do();
        }
        let s = self.scale();
        let alpha = self.accel();
        let axes = self.robot.axes();
        let moving = || (0..n).filter(|&i| distance[i] != 0);
        let units = |i: usize| distance[i].unsigned_abs() as f64 / axes[i].pulses_per_unit;
        // The speed override stretches the move in time; the acceleration override lowers
        // the acceleration and jerk on top of it.
        let limits = |i: usize| {
            let l = &axes[i].limits;
            (
                l.max_velocity * s,
                l.max_acceleration * s * s * alpha,
                l.max_jerk * s * s * s * alpha,
            )
        };
        let (law, info) = match self.settings.profile {
            Profile::Fir => {
                // Each axis's own optimum; the slowest sets the duration.
                let mut own = [DoubleS::REST; MAX_AXES];
                let mut t_sync = 0.0f64;
                let (mut vn, mut an, mut jn) = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
                for i in moving() {
                    let (v, a, j) = limits(i);
                    let d = units(i);
                    own[i] = DoubleS::time_optimal(d, v, a, j);
                    t_sync = t_sync.max(own[i].duration());
                    vn = vn.min(v / d);
                    an = an.min(a / d);
                    jn = jn.min(j / d);
                }
                // Phase synchronisation (one shape for all) when it is as fast as the slowest
                // axis; otherwise each axis stretched to the common duration.
                let common = DoubleS::time_optimal(1.0, vn, an, jn);
                let mut profiles = [DoubleS::REST; MAX_AXES];
                let sync = if moving().count() == 1 {
                    for i in moving() {
                        profiles[i] = own[i];
                    }
                    Sync::Single
                } else if common.duration() <= t_sync * (1.0 + 1e-9) {
                    for i in moving() {
                        profiles[i] = common;
                    }
                    Sync::Phase
                } else {
                    for i in moving() {
                        profiles[i] = own[i].stretched_to(t_sync);
                    }
                    Sync::Time
                };
                (
                    Law::Fir(FirAxes::new(&profiles)),
                    self.fir_info(&profiles, sync),
                )
            }
            Profile::Paper { mask_len } => {
                let half = (mask_len / 2) as u64;
                let ts = self.settings.period_s;
                let mut input_periods = 2 * half;
                for i in moving() {
                    let (v, a, j) = limits(i);
                    let rate = paper_rate(v, a, j, half, ts) * ts; // units per period
                    let need = (units(i) / rate).ceil();
                    input_periods = input_periods.max(if need.is_finite() {
                        need as u64
                    } else {
                        u64::MAX / 4
                    });
                }
                let mut ch = [PaperChannel::new(0, 1, half); MAX_AXES];
                for i in moving() {
                    ch[i] = PaperChannel::new(distance[i], input_periods, half);
                }
                let periods = ch[0].total_periods().max(input_periods + 2 * half - 2);
                let info = MoveInfo {
                    duration_s: periods as f64 * ts,
                    periods,
                    sync: if moving().count() == 1 {
                        Sync::Single
                    } else {
                        Sync::Phase
                    },
                };
                (Law::Paper(ch), info)
            }
        };
        self.active = Active::Joint {
            start: self.position,
            distance,
            law,
            sync: info.sync,
            scale: s,
            then: None,
        };
        self.k = 0;
        self.stopped = false;
        info
    }

    /// Controlled stop from any state: from the state after the last period produced, with
    /// no coasting and no deferral, brake to rest within `limits` as fast as they allow, a
    /// PTP move on its joint-space line and a straight line on its line. The move then ends
    /// with [`MoveEnd::Stopped`] unless it reached its target (a stop during its own planned
    /// deceleration with the same limits). A second stop is taken only if it brakes with
    /// stronger limits (ESTOP after STOP). Never allocates.
    ///
    /// - PTP and jog under the default profile: the time-optimal jerk-limited brake
    ///   ([`crate::Brake1d`]) from the exact state of the profile; phase-synchronised and
    ///   single-axis moves with one brake of the path parameter (the slowest axis's limits),
    ///   time-synchronised ones with each axis's own brake.
    /// - A straight line under the default profile: a brake of its path parameter checked,
    ///   from the present state, against every joint and Cartesian limit along the line and
    ///   to stop before its end — the closed-form time-optimal brake with the limits where
    ///   the line is, or the feedback brake of the law's plan, whichever stops first
    ///   (docs/motion.md). [`BrakeLimits::Override`] brakes in plan time, played at the
    ///   override; [`BrakeLimits::Full`] below 100 % rescales the law to real time at once
    ///   (u, p·u̇, p²·ü) and brakes with the full limits. If no brake from the present state
    ///   passes its check, the line brakes from its plan's next knot (at most 4 ms of plan
    ///   time later) with the brake verified there, as every state of its plan is; during its
    ///   final landing, it lands on the target unless a brake stops it sooner.
    /// - The paper profile keeps the paper's stop (its input stream cut as early as its mask
    ///   allows) with the move's limits, whatever `limits` says.
    pub fn stop(&mut self, limits: BrakeLimits) {
        let now = self.k as f64 * self.settings.period_s;
        let n = self.robot.axis_count();
        let mut cut_short = false;
        match &mut self.active {
            Active::Idle => return,
            Active::Joint {
                distance,
                law,
                sync,
                scale,
                ..
            } => match law {
                Law::Fir(fir) => {
                    let stronger = match (fir.braking(), limits) {
                        (None, _) | (Some(BrakeLimits::Override), BrakeLimits::Full) => true,
                        (Some(BrakeLimits::Override), BrakeLimits::Override)
                        | (Some(BrakeLimits::Full), _) => false,
                    };
                    if !stronger {
                        return;
                    }
                    let s = match limits {
                        BrakeLimits::Override => *scale,
                        BrakeLimits::Full => 1.0,
                    };
                    // The limits of each moving axis's fraction of its distance.
                    let mut fraction_limits = [None; MAX_AXES];
                    for (i, (l, &d)) in fraction_limits.iter_mut().zip(&*distance).enumerate() {
                        if i < n && d != 0 {
                            let axis = &self.robot.axes()[i];
                            let units = d.unsigned_abs() as f64 / axis.pulses_per_unit;
                            *l = Some((
                                axis.limits.max_acceleration * s * s / units,
                                axis.limits.max_jerk * s * s * s / units,
                            ));
                        }
                    }
                    fir.brake(now, limits, &fraction_limits, *sync != Sync::Time);
                }
                Law::Paper(channels) => {
                    for ch in channels.iter_mut() {
                        ch.stop();
                        cut_short |= ch.final_pulses() != ch.distance();
                    }
                }
            },
            Active::Approach {
                commit_k,
                stop: committed,
                ..
            } if self.k > *commit_k => {
                // Past the commit point every axis's own brake would end past the line's
                // start, off the line, inside the station: the planned first part (checked)
                // takes the hand to the line, whose brake keeps it on the line.
                if *committed != Some(BrakeLimits::Full) {
                    *committed = Some(limits);
                }
                cut_short = true;
            }
            Active::Approach {
                ptp, path, target, ..
            } => {
                let goal = Goal::of_path(path, *target);
                let (ptp, robot) = (*ptp, &self.robot);
                self.active = axis_brakes(
                    robot,
                    &ptp.state(now),
                    now,
                    limits,
                    self.settings.speed_pct,
                    goal,
                );
                cut_short = true;
            }
            Active::Jerk {
                parts,
                count,
                t0,
                target,
            } => {
                // Every axis's own brake from its state on the part under way.
                let t = now - *t0;
                let d0 = parts[0].duration();
                let state = if *count == 2 && t > d0 {
                    parts[1].state(t - d0)
                } else {
                    parts[0].state(t)
                };
                let goal = Goal::Joints(*target);
                self.active = axis_brakes(
                    &self.robot,
                    &state,
                    now,
                    limits,
                    self.settings.speed_pct,
                    goal,
                );
                cut_short = true;
            }
            Active::Brake {
                brakes,
                n,
                t0,
                goal,
                ..
            } => {
                // Only ESTOP after STOP or HOLD brakes harder: every axis's full limits from
                // where it is.
                if limits == BrakeLimits::Full {
                    let (mut q, mut v, mut a) = ([0.0; MAX_AXES], [0.0; MAX_AXES], [0.0; MAX_AXES]);
                    for i in 0..*n {
                        (q[i], v[i], a[i]) = brakes[i].at(now - *t0);
                    }
                    let goal = *goal;
                    self.active = axis_brakes(&self.robot, &(q, v, a), now, limits, 100.0, goal);
                }
                cut_short = true;
            }
            // Whether the brake ends short of the target is known when it has stopped.
            Active::Line {
                path,
                law,
                last,
                t0,
                then,
                ..
            } => match law {
                LineLaw::Timed {
                    profile,
                    bounds,
                    scale,
                    ..
                } => {
                    // The brakes are checked with the derivatives from the kinematics, exactly,
                    // whoever planned the line: the generator that planned it and another one
                    // restored to the same state (the Pulse Generator's) take the same brake.
                    let (robot, axes, reference) = (&self.robot, &self.line_axes, *last);
                    let derivs = |u: f64| path.derivs(robot, axes, u, &reference);
                    // From the line's start at the latest (a committed approach's stop,
                    // taken in the period in which the line takes over).
                    stop_line(
                        profile,
                        bounds,
                        scale,
                        limits,
                        (now - *t0).max(0.0),
                        &derivs,
                    );
                    // Nothing follows a stopped path; the move was going to its target.
                    if let Some(target) = then.target() {
                        *then = Then::Cancelled { target };
                    }
                }
                LineLaw::Paper(ch) => {
                    ch.stop();
                    cut_short |= ch.final_pulses() != ch.distance();
                }
            },
        }
        self.stopped |= cut_short;
    }

    /// What is left of the move under way, when that is a Cartesian path with nothing after
    /// it (a straight line, a path, the line of a blended approach past its first part),
    /// handed to `visit` as joints at points no more than `step_mm` [mm] of the TCP's path
    /// apart, from where it stands (not included) to its end, each continued from the one
    /// before: for a check of its geometry without its timing (its law keeps the TCP on the
    /// path, and a stop on it brakes along it). `visit` returning false ends the walk.
    /// `Some(false)` when it did, `Some(true)` when it reached the end, `None` for any other
    /// move (nothing visited). Allocation-free.
    pub fn walk_path_ahead(
        &self,
        step_mm: f64,
        visit: &mut dyn FnMut(&Joints) -> bool,
    ) -> Option<bool> {
        let Active::Line {
            path,
            law: LineLaw::Timed { profile, scale, .. },
            last,
            t0,
            then: Then::End,
            ..
        } = &self.active
        else {
            return None;
        };
        let now = self.k as f64 * self.settings.period_s;
        let (u, _, _) = profile.state((now - t0).max(0.0) * scale);
        let u = u.clamp(0.0, 1.0);
        let left = path.length_mm() * (1.0 - u);
        let n = (left / step_mm.max(0.1)).ceil().clamp(1.0, 1e6) as u32;
        let mut reference = *last;
        for i in 1..=n {
            let v = u + (1.0 - u) * f64::from(i) / f64::from(n);
            let q = path.joints_at(&self.robot, v, &reference)?;
            if !visit(&q) {
                return Some(false);
            }
            reference = q;
        }
        Some(true)
    }

    /// The path parameter of the move under way and its first two time derivatives after the
    /// last period, in real time [1, 1/s, 1/s²]: a joint move's fraction of its distance
    /// (phase-synchronised or single-axis, default profile), a straight line's u (default
    /// profile). `None` otherwise. For measurements (`wrc bench stop`).
    pub(crate) fn path_state(&self) -> Option<(f64, f64, f64)> {
        let now = self.k as f64 * self.settings.period_s;
        match &self.active {
            Active::Joint {
                law: Law::Fir(fir),
                sync: Sync::Phase | Sync::Single,
                distance,
                ..
            } => {
                let first = distance.iter().position(|&d| d != 0)?;
                Some(fir.state(first, now))
            }
            Active::Line {
                law: LineLaw::Timed { profile, scale, .. },
                t0,
                ..
            } => {
                let (u, v, a) = profile.state((now - t0) * scale);
                Some((u, v * scale, a * scale * scale))
            }
            Active::Idle
            | Active::Joint { .. }
            | Active::Approach { .. }
            | Active::Jerk { .. }
            | Active::Brake { .. }
            | Active::Line {
                law: LineLaw::Paper(_),
                ..
            } => None,
        }
    }

    /// Produce the next period: the pulses of every axis, added to the commanded position.
    /// Never allocates, never blocks.
    pub fn next_period(&mut self, out: &mut Period) -> Status {
        out.pulses = [0; MAX_AXES];
        let n = self.robot.axis_count();
        let before = self.position;
        let ts = self.settings.period_s;
        // A path into a PTP decides how it leaves in the period that reaches its junction.
        self.reach_junction((self.k + 1) as f64 * ts);
        if let Active::Approach {
            ptp,
            path,
            law,
            target,
            last,
            stop,
            ..
        } = self.active
        {
            // The line takes over where the first part ends.
            if (self.k + 1) as f64 * ts >= ptp.duration() {
                self.active = Active::Line {
                    path,
                    law,
                    target,
                    last,
                    t0: ptp.duration(),
                    then: Then::End,
                };
                // A stop asked for after the commit point brakes on the line from its start.
                if let Some(limits) = stop {
                    self.stop(limits);
                }
            }
        }
        if let Active::Line {
            t0,
            then: Then::Flow { t_cut, ptp, target },
            ..
        } = self.active
        {
            // The PTP takes over where the path ends.
            if (self.k + 1) as f64 * ts >= t0 + t_cut {
                self.active = Active::Jerk {
                    parts: [ptp; 2],
                    count: 1,
                    t0: t0 + t_cut,
                    target,
                };
            }
        }
        let finished = match &mut self.active {
            Active::Jerk {
                parts,
                count,
                t0,
                target,
            } => {
                self.k += 1;
                let t = self.k as f64 * ts - *t0;
                let d0 = parts[0].duration();
                let last = &parts[*count - 1];
                let end = if *count == 2 {
                    d0 + parts[1].duration()
                } else {
                    d0
                };
                if t >= end {
                    out.exact = last.state(last.duration()).0;
                    self.position[..n].copy_from_slice(&target[..n]);
                    true
                } else {
                    let q = if *count == 2 && t > d0 {
                        parts[1].state(t - d0).0
                    } else {
                        parts[0].state(t).0
                    };
                    let p = self.robot.joints_to_pulses(&q);
                    self.position[..n].copy_from_slice(&p[..n]);
                    out.exact = q;
                    false
                }
            }
            Active::Approach { ptp, .. } => {
                self.k += 1;
                let q = ptp.state(self.k as f64 * ts).0;
                let p = self.robot.joints_to_pulses(&q);
                self.position[..n].copy_from_slice(&p[..n]);
                out.exact = q;
                false
            }
            Active::Brake {
                brakes, n: m, t0, ..
            } => {
                self.k += 1;
                let t = self.k as f64 * ts - *t0;
                let mut q = self.robot.pulses_to_joints(&self.position);
                let mut done = true;
                for i in 0..*m {
                    let b = &brakes[i];
                    done &= t >= b.duration();
                    q[i] = b.at(t).0;
                }
                let p = self.robot.joints_to_pulses(&q);
                self.position[..n].copy_from_slice(&p[..n]);
                out.exact = q;
                if done {
                    self.stopped = true;
                }
                done
            }
            Active::Idle => {
                out.exact = self.robot.pulses_to_joints(&self.position);
                return Status::Idle;
            }
            Active::Joint {
                start,
                distance,
                law,
                ..
            } => {
                self.k += 1;
                let t = self.k as f64 * self.settings.period_s;
                let mut exact = self.robot.pulses_to_joints(start);
                let done = match law {
                    Law::Fir(fir) => {
                        let last = t >= fir.end_time(n);
                        for i in 0..n {
                            let f = if last {
                                fir.final_fraction(i)
                            } else {
                                fir.state(i, t).0
                            };
                            let ppu = self.robot.axes()[i].pulses_per_unit;
                            let travelled = distance[i] as f64 * f;
                            exact[i] += travelled / ppu;
                            let target = start[i]
                                + if f == 1.0 {
                                    distance[i]
                                } else {
                                    travelled.round() as i64
                                };
                            self.position[i] = target;
                        }
                        if last && fir.braking().is_some() {
                            self.stopped =
                                (0..n).any(|i| self.position[i] != start[i] + distance[i]);
                        }
                        last
                    }
                    Law::Paper(channels) => {
                        let mut done = true;
                        for i in 0..n {
                            let ch = &mut channels[i];
                            self.position[i] += ch.next_pulses();
                            exact[i] += ch.exact_output() / self.robot.axes()[i].pulses_per_unit;
                            done &= ch.done();
                        }
                        done
                    }
                };
                out.exact = exact;
                done
            }
            Active::Line {
                path,
                law,
                target,
                last,
                t0,
                ..
            } => {
                self.k += 1;
                let t = self.k as f64 * ts - *t0;
                let (u, done, complete) = match law {
                    LineLaw::Timed {
                        profile,
                        bounds,
                        scale,
                        table,
                    } => {
                        let u = if *table == self.table.id && !profile.braked_now() {
                            let tab = &self.table;
                            profile.at(bounds, &|u: f64| tab.at(u), t * *scale)
                        } else {
                            // Another generator's plan (e.g. restored to stop it), or a brake
                            // from the present state (verified with them): the derivatives
                            // from the kinematics, exactly.
                            let (robot, axes, reference) = (&self.robot, &self.line_axes, *last);
                            let derivs = |u: f64| path.derivs(robot, axes, u, &reference);
                            profile.at(bounds, &derivs, t * *scale)
                        };
                        (u, profile.done(), profile.completed())
                    }
                    LineLaw::Paper(ch) => {
                        ch.next_pulses();
                        let done = ch.done();
                        (
                            ch.emitted() as f64 / LINE_COUNTS as f64,
                            done,
                            done && ch.emitted() == LINE_COUNTS,
                        )
                    }
                };
                // Every point of the line was checked when it was planned: follow it,
                // continuing each joint from the last period's.
                if let Some(q) = path.joints_at(&self.robot, u, last) {
                    *last = q;
                }
                out.exact = *last;
                if complete {
                    self.position = *target;
                } else {
                    let p = self.robot.joints_to_pulses(last);
                    self.position[..n].copy_from_slice(&p[..n]);
                }
                if done {
                    // Stopped short unless the stop ended on the target's pulses anyway.
                    self.stopped = self.position[..n] != target[..n];
                }
                done
            }
        };
        for ((out, now), was) in out
            .pulses
            .iter_mut()
            .zip(&self.position)
            .zip(&before)
            .take(n)
        {
            *out = now - was;
        }
        if finished && !self.stopped {
            // A second PTP from rest where the first part ends (a via or a path's end that
            // could not be passed moving).
            let next = match &self.active {
                Active::Joint {
                    then: Some(target),
                    law: Law::Fir(fir),
                    ..
                } if fir.braking().is_none() => Some(*target),
                Active::Line {
                    then: Then::Ptp { target },
                    ..
                } => Some(*target),
                // A path into a PTP whose law came to rest at the path's end without reaching
                // its junction (it never looked past the end): the PTP from there.
                Active::Line {
                    then: Then::Depart(junction),
                    ..
                } => Some(junction.target),
                _ => None,
            };
            if let Some(target) = next {
                let mut distance = [0i64; MAX_AXES];
                for (i, d) in distance.iter_mut().enumerate().take(n) {
                    *d = target[i] - self.position[i];
                }
                if self.start_joint_move(distance).periods > 0 {
                    return Status::Working;
                }
            }
        }
        if finished {
            self.active = Active::Idle;
            let end = if self.stopped {
                MoveEnd::Stopped
            } else {
                MoveEnd::Completed
            };
            self.stopped = false;
            Status::Finished(end)
        } else {
            Status::Working
        }
    }
}

/// Every axis's own time-optimal brake from joints, velocities and accelerations `state`
/// at time `now`: with its full limits (ESTOP), or scaled by the override `speed_pct`.
fn axis_brakes(
    robot: &Robot,
    state: &(Joints, Joints, Joints),
    now: f64,
    limits: BrakeLimits,
    speed_pct: f64,
    goal: Goal,
) -> Active {
    let s = match limits {
        BrakeLimits::Override => speed_pct / 100.0,
        BrakeLimits::Full => 1.0,
    };
    let n = robot.axis_count().min(RUCKIG_DOF);
    let mut brakes = [Brake1d::default(); RUCKIG_DOF];
    for (i, b) in brakes.iter_mut().enumerate().take(n) {
        let l = &robot.axes()[i].limits;
        *b = Brake1d::new(
            state.0[i],
            state.1[i],
            state.2[i],
            l.max_acceleration * s * s,
            l.max_jerk * s * s * s,
        );
    }
    Active::Brake {
        brakes,
        n,
        t0: now,
        goal,
    }
}

/// Stop a straight line's timing law played at `scale` at real time `now` [s], with `limits`:
/// ESTOP below 100 % brakes in real time with the full limits (the law's scale becomes 1),
/// if a brake from there is verified; otherwise, and for STOP, it brakes at once in plan time
/// (played at the override), if verified; otherwise from the next knot with the brake
/// verified there (or, on its final landing, lands on the target). A line already braking
/// goes on, unless ESTOP finds a real-time brake from where it is.
///
/// The brake from the present state uses the bounds without the acceleration override (a
/// stop is never weaker for it), and the law goes on with them; the fallback from the next
/// knot follows the brake verified there, with the plan's bounds.
fn stop_line(
    profile: &mut LineProfile,
    bounds: &mut Bounds,
    scale: &mut f64,
    limits: BrakeLimits,
    now: f64,
    derivs: &impl Fn(f64) -> Derivs,
) {
    let t_plan = now * *scale;
    let forward = profile.is_forward();
    let rescale = limits == BrakeLimits::Full && *scale < 1.0;
    let full = bounds.full_accel();
    if rescale && profile.brake_now(&full, derivs, t_plan, *scale, now) {
        *scale = 1.0;
        *bounds = full;
    } else if forward && profile.brake_now(&full, derivs, t_plan, 1.0, t_plan) {
        *bounds = full;
    } else {
        profile.stop();
    }
}

/// How a path into a PTP leaves, decided at its junction ([`exit_at_junction`]).
struct Exit {
    /// The law from the junction's knot on, and its bounds.
    profile: LineProfile,
    bounds: Bounds,
    /// What follows the path: the PTP from where it ends moving, or from rest at its end.
    then: Then,
    /// Whether the search ran out of its budget and took the rest at the path's end.
    fell_back: bool,
}

/// How the path along `path`, whose law `profile` (played at speed override `scale`, with
/// `bounds` ending at the path's end) waits at its junction, leaves for the PTP of `j`
/// ([`VelocityGenerator::plan_depart`]): each room's law resumed from the junction and run
/// to the path's end, the first whose PTP part (from the state there, checked every
/// `step` [s]) keeps every joint in range, unless the path to rest and the PTP from there
/// arrive sooner; the rest when none passes, or when `work` runs out (a fallback).
fn exit_at_junction(
    (robot, planner, work, step): (&Robot, &mut Planner, &Work, f64),
    (path, profile, bounds, scale): (&Geometry, &LineProfile, &Bounds, f64),
    j: &Junction,
    derivs: &impl Fn(f64) -> Derivs,
) -> Exit {
    let more = || work.left();
    let end_pulses = robot.joints_to_pulses(&j.at_cut);
    let rest_ptp = ptp_time(robot, &end_pulses, &j.target, j.scales);
    // The path to rest at its end: the law as it was watched, resumed.
    let mut rest = *profile;
    rest.resume(bounds, derivs);
    let stop_there = |fell_back: bool| Exit {
        profile: rest,
        bounds: *bounds,
        then: Then::Ptp { target: j.target },
        fell_back,
    };
    // The exits, largest room first: the first whose PTP part passes.
    let zero = [0.0; MAX_AXES];
    let mut flow = None;
    for &end in &j.rooms[..j.count] {
        if !work.left() {
            return stop_there(true);
        }
        let b = bounds.ending_at(end);
        let mut law = *profile;
        law.resume(&b, derivs);
        let mut dry = law;
        let Some((t_cut, (_, v, a))) = dry.time_at_while(&b, derivs, j.cut, &more) else {
            if !work.left() {
                return stop_there(true);
            }
            continue;
        };
        // Every joint's state where the path ends, in real time.
        let Ok(jets) = path.jets_at(robot, j.cut, &j.at_cut) else {
            continue;
        };
        let (v, a) = (v * scale, a * scale * scale);
        let (mut qv, mut qa) = ([0.0; MAX_AXES], [0.0; MAX_AXES]);
        for i in 0..robot.axis_count() {
            let d = jets.joints[i].d;
            qv[i] = d[1] * v;
            qa[i] = d[1] * a + d[2] * v * v;
        }
        let Some(ptp) = planner.between(
            robot,
            (&j.at_cut, &qv, &qa),
            (&j.to, &zero, &zero),
            j.scales,
        ) else {
            continue;
        };
        let samples = (ptp.duration() / step).ceil() as u64;
        if (0..=samples).all(|k| robot.check_joints(&ptp.state(k as f64 * step).0).is_ok()) {
            flow = Some((law, b, t_cut / scale, ptp));
            break;
        }
    }
    let Some((law, b, t_cut, ptp)) = flow else {
        return stop_there(false);
    };
    let time = t_cut + ptp.duration();
    let flowing = Exit {
        profile: law,
        bounds: b,
        then: Then::Flow {
            t_cut,
            ptp,
            target: j.target,
        },
        fell_back: false,
    };
    // Never slower than the path to rest and the PTP from there: the path at rest reaches
    // its end no sooner than it leaves it moving, so only when this exit may be slower is
    // the law to rest run to its end to compare.
    if time <= t_cut + rest_ptp {
        return flowing;
    }
    let mut dry = rest;
    match dry.run_to_end_while(bounds, derivs, &more) {
        Some(end_t) if end_t / scale + rest_ptp <= time => stop_there(false),
        Some(_) => flowing,
        None => stop_there(true),
    }
}

/// The duration [s] of a PTP of `robot` from `from` to `to` [pulse] at the speed and
/// acceleration overrides `(s, α)` (fractions): the slowest axis's time-optimal profile
/// (what the move itself takes, synchronised).
fn ptp_time(
    robot: &Robot,
    from: &[i64; MAX_AXES],
    to: &[i64; MAX_AXES],
    (s, alpha): (f64, f64),
) -> f64 {
    let mut t = 0.0f64;
    for (i, axis) in robot.axes().iter().enumerate() {
        let d = (to[i] - from[i]).unsigned_abs() as f64 / axis.pulses_per_unit;
        if d > 0.0 {
            let l = &axis.limits;
            t = t.max(
                DoubleS::time_optimal(
                    d,
                    l.max_velocity * s,
                    l.max_acceleration * s * s * alpha,
                    l.max_jerk * s * s * s * alpha,
                )
                .duration(),
            );
        }
    }
    t
}

/// Whether `p` lies on the straight segment from `a` to `b` (within 1 µm, with the segment's
/// z and yaw where it is, to 0.001°).
fn on_segment(p: &Pose, a: &Pose, b: &Pose) -> bool {
    let d = [b.x - a.x, b.y - a.y, b.z - a.z];
    let len2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    if len2 < 1e-12 {
        return false;
    }
    let f = ((p.x - a.x) * d[0] + (p.y - a.y) * d[1] + (p.z - a.z) * d[2]) / len2;
    if !(-1e-9..=1.0 + 1e-9).contains(&f) {
        return false;
    }
    let yaw = a.yaw + f * wrc_robot::wrap180(b.yaw - a.yaw);
    let off = [
        a.x + f * d[0] - p.x,
        a.y + f * d[1] - p.y,
        a.z + f * d[2] - p.z,
    ];
    // Where a stop on the line leaves it: within the rounding to pulses (a HOLD after a
    // blended approach's commit point is held a few micrometres off it; a new entry from
    // there would go back out to the approach pose).
    (off[0] * off[0] + off[1] * off[1] + off[2] * off[2]).sqrt() <= crate::geometry::ON_PATH_TOL_MM
        && wrc_robot::wrap180(p.yaw - yaw).abs() <= crate::geometry::YAW_TOL_DEG
}

/// Input rate of the paper profile [unit/s] that keeps a mask of 2·`half` periods of `ts`
/// [s] within v, a and j: the mask's peak acceleration is rate/(m·Ts), its jerk rate/(m·Ts)².
fn paper_rate(v: f64, a: f64, j: f64, half: u64, ts: f64) -> f64 {
    let m_ts = half as f64 * ts;
    v.min(a * m_ts).min(j * m_ts * m_ts)
}

/// Periods needed to cover `duration` [s] at period `ts` [s].
fn periods_for(duration: f64, ts: f64) -> u64 {
    if duration <= 0.0 {
        0
    } else {
        ((duration / ts) - 1e-9).ceil().max(1.0) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn generator() -> VelocityGenerator {
        VelocityGenerator::new(Robot::paper_default(), MotionSettings::default()).unwrap()
    }

    fn run_to_end(vg: &mut VelocityGenerator) -> MoveEnd {
        let mut p = Period::default();
        loop {
            if let Status::Finished(end) = vg.next_period(&mut p) {
                return end;
            }
        }
    }

    #[test]
    fn the_goal_of_a_joint_move_is_its_target_in_pulses() {
        let mut vg = generator();
        assert_eq!(vg.goal(), None);
        let start = *vg.position_pulses();
        vg.plan_jog(2, -12_345).unwrap();
        let mut want = start;
        want[2] -= 12_345;
        assert_eq!(vg.goal(), Some(Goal::Joints(want)));
        // Still known while the move is being stopped, in every state taken of it.
        let mut p = Period::default();
        vg.next_period(&mut p);
        vg.stop(BrakeLimits::Override);
        assert_eq!(vg.state().goal(), Some(Goal::Joints(want)));
        assert_eq!(run_to_end(&mut vg), MoveEnd::Stopped);
        assert_eq!(vg.goal(), None);
    }

    #[test]
    fn a_ptp_in_pulses_lands_on_them_exactly() {
        let mut vg = generator();
        let mut target = *vg.position_pulses();
        target[0] += 33_333;
        target[1] -= 7;
        target[3] += 123_457;
        vg.plan_ptp_pulses(&target).unwrap();
        assert_eq!(vg.goal(), Some(Goal::Joints(target)));
        assert_eq!(
            vg.plan_ptp_pulses(&target).unwrap_err(),
            PlanError::Busy,
            "refused while moving"
        );
        assert_eq!(run_to_end(&mut vg), MoveEnd::Completed);
        assert_eq!(*vg.position_pulses(), target);
        // Beyond an axis's limits: refused before any pulse.
        let mut beyond = target;
        beyond[3] = -1_000;
        assert!(vg.plan_ptp_pulses(&beyond).is_err());
        assert!(!vg.is_moving());
    }

    #[test]
    fn the_goal_of_a_line_is_its_end_pose_and_pulses() {
        let mut vg = generator();
        let start = Pose {
            x: 300.0,
            y: -100.0,
            z: 0.0,
            yaw: 170.0,
        };
        let q = vg.robot().inverse(&start, Posture::Right, None).unwrap();
        vg.set_position_pulses(&vg.robot().joints_to_pulses(&q))
            .unwrap();
        // Yaw across ±180: the line turns 20°, the goal's yaw is where it ends (190°).
        let end = Pose {
            x: 300.0,
            y: 100.0,
            z: 50.0,
            yaw: -170.0,
        };
        vg.start_line(&end).unwrap();
        let Some(Goal::Line { pose, pulses }) = vg.goal() else {
            panic!("{:?}", vg.goal())
        };
        let from = vg.pose();
        assert!((pose.x - end.x).abs() < 1e-9 && (pose.y - end.y).abs() < 1e-9);
        assert!((pose.z - end.z).abs() < 1e-9);
        assert!((pose.yaw - (from.yaw + 20.0)).abs() < 1e-6, "{pose:?}");
        assert_eq!(run_to_end(&mut vg), MoveEnd::Completed);
        assert_eq!(*vg.position_pulses(), pulses);
    }

    /// Every period of a move to its end: (pulses after it, exact joints after it).
    fn trace(vg: &mut VelocityGenerator) -> Vec<([i64; MAX_AXES], Joints)> {
        let mut out = vec![(*vg.position_pulses(), vg.joints())];
        let mut p = Period::default();
        while vg.is_moving() {
            vg.next_period(&mut p);
            out.push((*vg.position_pulses(), p.exact));
        }
        out
    }

    /// Largest |second difference| per s² of `x` sampled every `ts` [s].
    fn peak_accel(x: &[f64], ts: f64) -> f64 {
        x.windows(3)
            .map(|w| ((w[2] - 2.0 * w[1] + w[0]) / (ts * ts)).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn the_acceleration_override_lowers_a_ptp_move_but_not_its_stop() {
        let ts = 0.01;
        let mut runs = Vec::new();
        for pct in [100.0, 25.0] {
            let mut vg = generator();
            let mut from = vg.joints();
            from[0] = -150.0;
            vg.set_position_pulses(&vg.robot().joints_to_pulses(&from))
                .unwrap();
            vg.set_accel_pct(pct).unwrap();
            assert_eq!(vg.accel_pct(), pct);
            let mut to = from;
            to[0] = 150.0;
            let info = vg.plan_ptp(&to).unwrap();
            // Every state taken of the move keeps the override (the Velocity Generator
            // restores the Pulse Generator's after a stop).
            let mut other = generator();
            other.restore(&vg.state());
            assert_eq!(other.accel_pct(), pct);
            let whole = trace(&mut vg.clone());
            // From the output pulses, allowing 2 pulses of rounding per second difference.
            let j1: Vec<f64> = whole.iter().map(|(p, _)| p[0] as f64 / 1000.0).collect();
            let a = (peak_accel(&j1, ts) - 2.0 / 1000.0 / (ts * ts)).max(0.0);
            let limit = vg.robot().axes()[0].limits.max_acceleration;
            assert!(
                a <= pct / 100.0 * limit * (1.0 + 1e-3),
                "ACCEL {pct}: {a} deg/s² against {limit}"
            );
            // STOP at the middle, in cruise at full speed (the move is long enough at 25 %).
            let half = info.periods as usize / 2;
            let mut p = Period::default();
            for _ in 0..half {
                vg.next_period(&mut p);
            }
            let at = vg.joints()[0];
            vg.stop(BrakeLimits::Override);
            let brake = trace(&mut vg);
            runs.push((info.duration_s, a, brake.len(), vg.joints()[0] - at));
        }
        let (full, slow) = (runs[0], runs[1]);
        println!(
            "PTP of 300°: ACCEL 100 % {full:?}, 25 % {slow:?} (s, deg/s², brake periods, deg)"
        );
        assert!(
            slow.0 > full.0 * 1.2,
            "ACCEL 25 %: {} s, 100 %: {} s",
            slow.0,
            full.0
        );
        assert!(slow.1 < 0.26 * full.1, "{} vs {}", slow.1, full.1);
        // The same brake from the same cruise: as many periods and the same distance.
        assert_eq!(slow.2, full.2, "brake periods");
        assert!(
            (slow.3 - full.3).abs() < 1e-6,
            "brake {} vs {} deg",
            slow.3,
            full.3
        );
        assert!(generator().set_accel_pct(0.5).is_err());
        assert_eq!(
            generator().set_accel_pct(f64::NAN).unwrap_err().to_string(),
            "acceleration override must be from 1 to 100 %, got NaN"
        );
    }

    #[test]
    fn the_acceleration_override_lowers_a_line_but_not_its_stop() {
        let ts = 0.01;
        let a = Pose {
            x: 250.0,
            y: -100.0,
            z: 0.0,
            yaw: 0.0,
        };
        let b = Pose { y: 100.0, ..a };
        let line = MotionSettings::default().line;
        let mut durations = Vec::new();
        for pct in [100.0, 25.0] {
            let mut vg = generator();
            let q = vg.robot().inverse(&a, Posture::Right, None).unwrap();
            vg.set_position_pulses(&vg.robot().joints_to_pulses(&q))
                .unwrap();
            vg.set_accel_pct(pct).unwrap();
            let info = vg.plan_line(&b).unwrap();
            durations.push(info.duration_s);
            let whole = trace(&mut vg.clone());
            // Every joint from the output pulses, the TCP along the line from the exact
            // positions (its pulses' rounding is too coarse for a second difference).
            for ax in 0..4 {
                let x: Vec<f64> = whole.iter().map(|(p, _)| p[ax] as f64 / 1000.0).collect();
                let acc = (peak_accel(&x, ts) - 2.0 / 1000.0 / (ts * ts)).max(0.0);
                let limit = vg.robot().axes()[ax].limits.max_acceleration;
                assert!(
                    acc <= pct / 100.0 * limit * (1.0 + 1e-3),
                    "axis {ax}: {acc}"
                );
            }
            let y: Vec<f64> = whole.iter().map(|(_, q)| vg.robot().forward(q).y).collect();
            let tcp = peak_accel(&y, ts);
            assert!(
                tcp <= pct / 100.0 * line.max_accel_mm_s2 * (1.0 + 1e-3),
                "ACCEL {pct}: the TCP at {tcp} mm/s²"
            );
            assert!(tcp > 0.8 * pct / 100.0 * line.max_accel_mm_s2, "{tcp}");
            // STOP at 40 % of the way, still accelerating: it brakes with the full limits,
            // as fast as the time-optimal brake of the TCP with them (within 5 %, plus a
            // period), never with the reduced ones.
            let mut p = Period::default();
            for _ in 0..(info.periods * 2 / 5) {
                vg.next_period(&mut p);
            }
            let (u, v, acc) = vg.path_state().unwrap();
            vg.stop(BrakeLimits::Override);
            let _ = trace(&mut vg);
            let travelled = (vg.pose().y - a.y) / 200.0 - u;
            let brake = |f: f64| {
                Brake1d::new(
                    0.0,
                    v,
                    acc,
                    f * line.max_accel_mm_s2 / 200.0,
                    f * line.max_jerk_mm_s3 / 200.0,
                )
                .stop_position()
            };
            assert!(
                travelled <= brake(1.0) * 1.05 + v * ts,
                "ACCEL {pct}: braked over {travelled} of the line, the full brake {}",
                brake(1.0)
            );
            println!(
                "ACCEL {pct} %: STOP at 40 % braked over {:.2} mm, the full limits' brake {:.2} mm, ACCEL's {:.2} mm",
                travelled * 200.0,
                brake(1.0) * 200.0,
                brake(pct / 100.0) * 200.0
            );
            if pct < 100.0 {
                assert!(travelled < 0.5 * brake(pct / 100.0), "{travelled}");
            }
        }
        println!("line of 200 mm: ACCEL 100 % and 25 %: {durations:?} s");
        assert!(durations[1] > durations[0] * 1.2, "{durations:?}");
    }
}
