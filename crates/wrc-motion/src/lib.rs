//! Velocity generation for wrc: the paper's Velocity Generator mathematics.
//!
//! A [`VelocityGenerator`] plans a move — PTP in joint space, PTP to a Cartesian pose, a
//! straight line of the tool centre point (the paper's Table 2), or a jog of one axis — and
//! then yields each period's integer pulse increments per axis. Two profiles:
//! - [`Profile::Fir`] (default): the constant-velocity stream through two moving averages of
//!   lengths V/A and A/J, the time-optimal jerk-limited rest-to-rest motion ([`DoubleS`]);
//! - [`Profile::Paper`]: the paper's triangular mask (eq. 1) convolved with the input pulses
//!   (eq. 2), normalised so that no pulse is lost ([`PaperChannel`]).
//!
//! A straight line is checked at every point, each joint followed continuously
//! ([`check_line`]; a line that leaves the workspace or a joint's range is refused with the
//! axis, where and the pose), and under the default profile timed by a time-optimal
//! jerk-limited path parameterisation whose every state is known to stop along the line
//! within the limits (`line_profile.rs`). A composite path ([`PathSpec`]: lines and circular
//! arcs, each corner rounded within its blend zone by a curve that keeps the curvature
//! continuous) is checked ([`check_path`]) and timed the same way
//! ([`VelocityGenerator::start_path`]). A PTP move to a pose goes to the joint solution it
//! reaches soonest ([`ptp_target`]). PTP and Cartesian moves blend without stopping
//! between them (docs/motion.md, "PTP blends"): a PTP into a path
//! ([`VelocityGenerator::plan_ptp_into`]; a wafer transfer's approach,
//! [`VelocityGenerator::plan_approach`], with a station's rule), a path into a PTP
//! ([`VelocityGenerator::plan_depart`]) and a PTP through a via point
//! ([`VelocityGenerator::plan_ptp_via`]), by Ruckig's synchronised moves to and from the
//! path's moving states; their searches for the fastest candidate are bounded in work, not
//! time ([`BlendSearch`], observed in [`SearchStats`]). An acceleration override
//! ([`VelocityGenerator::set_accel_pct`]) lowers a move's accelerations and jerks, never its
//! stop. Not for the controller:
//! [`reference`] (lower bounds of a line's or path's duration, TOPP-RA) and [`bench`]
//! (`wrc bench motion`), which allocate.
//!
//! A controlled stop ([`VelocityGenerator::stop`]) brakes from the present state in the next
//! period with the time-optimal jerk-limited brake ([`Brake1d`]): with the move's limits for
//! STOP and HOLD, every axis's full limits for ESTOP ([`BrakeLimits`]); a PTP move on its
//! joint-space line, a straight line on its line. [`MotionState::goal`] keeps where a held
//! move was going.
//!
//! Guarantees: the pulses emitted for a completed move sum exactly to the target; velocity,
//! acceleration and jerk stay within every axis's limits (scaled by the speed override);
//! straight lines and paths keep the TCP on them; planning and every period run without heap
//! allocation, without I/O and without blocking, so they can run in a real-time task.
//!
//! ```
//! use wrc_motion::{MotionSettings, Period, Status, VelocityGenerator};
//! use wrc_robot::Robot;
//!
//! let robot = Robot::paper_default();
//! let mut vg = VelocityGenerator::new(robot, MotionSettings::default()).unwrap();
//! let start = vg.position_pulses()[0];
//! let info = vg.plan_jog(0, 10_000).unwrap(); // 10 deg on J1
//! let mut period = Period::default();
//! let mut total = 0;
//! while let Status::Working | Status::Finished(_) = vg.next_period(&mut period) {
//!     total += period.pulses[0];
//!     if !vg.is_moving() { break; }
//! }
//! assert_eq!(total, 10_000);
//! assert_eq!(vg.position_pulses()[0], start + 10_000);
//! assert!(info.periods > 0);
//! ```
#![deny(missing_docs)]

pub mod bench;
mod brake;
mod curve;
mod double_s;
mod error;
mod fir_axes;
mod generator;
mod geometry;
mod jerk_axes;
mod line_profile;
mod paper;
mod path;
mod path_spec;
pub mod reference;
mod search;
mod settings;
mod solutions;

pub use brake::Brake1d;
pub use curve::{MAX_ARC_RADIUS_MM, MIN_BLEND_SPEED, MIN_SEGMENT_MM, TANGENT_DEG, TANGENT_ZONE_MM};
pub use double_s::DoubleS;
pub use error::{ArcProblem, PathPlace, PathProblem, PlanError, SettingsError};
pub use generator::{
    BrakeLimits, EntryRule, Goal, MotionState, MoveEnd, MoveInfo, Period, Status, Sync,
    VelocityGenerator, DEPART_ROOM_MM, ENTRY_HORIZON_MM, VIA_SPEEDS,
};
pub use geometry::{check_path, ON_PATH_TOL_MM, START_TOL_MM, YAW_TOL_DEG};
pub use paper::PaperChannel;
pub use path::{check_line, LinePath, PathCheck, PathLimits};
pub use path_spec::{PathSegment, PathSpec, MAX_PATH_SEGMENTS};
pub use search::{BlendSearch, SearchStats};
pub use settings::{check_speed_pct, LineLimits, MotionSettings, Profile, MAX_PAPER_MASK};
pub use solutions::{ptp_cost, ptp_target, solutions, sooner, Solutions, MAX_SOLUTIONS};
