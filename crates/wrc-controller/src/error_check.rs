//! Error Check task (Table 1: priority 10, 100 ms — the most urgent): watches the board and
//! the controller for faults — servo alarm (over-speed), following error, soft limits, the
//! board's host watchdog, the E-stop input, task overruns beyond a threshold and loss of the
//! controlling client — and hands the first one to the Command Interpreter's urgent path,
//! which stops the robot in a controlled way and enters ERROR (or ESTOP) until RESET.
//!
//! Real-time promise: the cycle reads the mapped DPRAM and atomics only; it does not
//! allocate, block or print.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

use wrc_board::layout::{alarm, board_status};
use wrc_board::{Feedback, MotionBoard};
use wrc_protocol::Code;
use wrc_robot::{Robot, MAX_AXES};
use wrc_rt::ipc::{MessageQueue, Semaphore};
use wrc_rt::{CycleContext, StatsCell, Task};

use crate::messages::Urgent;
use crate::shared::{RobotState, Shared};

/// Limits Error Check enforces.
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    /// Largest |commanded − encoder| per axis [pulse].
    pub following_error: [i64; MAX_AXES],
    /// Soft limits per axis [pulse] (min, max).
    pub soft: [(i64, i64); MAX_AXES],
}

/// A task whose stalls stop a motion (the motion path: Error Check, Pulse Generator,
/// Velocity Generator), and how long a stall of it the motion rides out.
#[derive(Debug, Clone)]
pub struct Watched {
    /// Its statistics.
    pub cell: Arc<StatsCell>,
    /// Its period [ns].
    pub period_ns: u64,
    /// The longest stall (periods skipped in one late cycle, in time) that costs nothing
    /// [ns]: what the buffer after the task covers (docs/realtime.md).
    pub tolerance_ns: u64,
}

impl Watched {
    /// Whether a stall of `skipped` periods is longer than the tolerance.
    pub fn too_long(&self, skipped: u64) -> bool {
        skipped.saturating_mul(self.period_ns) > self.tolerance_ns
    }
}

impl Limits {
    /// Limits for `robot`: following error up to 50 ms of full speed, soft limits from the
    /// axis configuration.
    pub fn for_robot(robot: &Robot) -> Limits {
        let mut l = Limits {
            following_error: [i64::MAX; MAX_AXES],
            soft: [(i64::MIN, i64::MAX); MAX_AXES],
        };
        for (i, a) in robot.axes().iter().enumerate() {
            l.following_error[i] =
                (a.limits.max_velocity * a.pulses_per_unit * 0.05).ceil() as i64 + 10;
            l.soft[i] = (a.units_to_pulses(a.min) - 1, a.units_to_pulses(a.max) + 1);
        }
        l
    }
}

/// Error Check.
pub struct ErrorCheck<B: MotionBoard> {
    board: B,
    shared: Arc<Shared>,
    urgent: Arc<MessageQueue<Urgent>>,
    wake: Arc<Semaphore>,
    limits: Limits,
    axis_count: usize,
    /// Set by the Ethernet/RS232C task when the controlling client disconnects mid-motion.
    pub owner_lost: Arc<AtomicBool>,
    /// The tasks whose stalls stop a motion (the motion path: Error Check, Pulse Generator,
    /// Velocity Generator). Set once the runtime runs on real-time scheduling; left unset
    /// without it, where overruns are counted and reported but are no fault (an ordinary
    /// process on a busy machine overruns, and says so once).
    stats: Arc<OnceLock<Vec<Watched>>>,
    feedback: Feedback,
    reported: bool,
}

impl<B: MotionBoard> ErrorCheck<B> {
    /// Error Check on `board` for `axis_count` axes.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        board: B,
        axis_count: usize,
        shared: Arc<Shared>,
        urgent: Arc<MessageQueue<Urgent>>,
        wake: Arc<Semaphore>,
        limits: Limits,
        owner_lost: Arc<AtomicBool>,
        stats: Arc<OnceLock<Vec<Watched>>>,
    ) -> Self {
        ErrorCheck {
            board,
            shared,
            urgent,
            wake,
            limits,
            axis_count,
            owner_lost,
            stats,
            feedback: Feedback::default(),
            reported: false,
        }
    }

    /// The first fault found this period, if any.
    fn find_fault(&mut self) -> Option<Code> {
        if self.board.read_feedback(&mut self.feedback).is_err() {
            return None; // torn read: try again next period
        }
        let fb = &self.feedback;
        for b in &fb.boards[..fb.board_count] {
            if b.status & board_status::ESTOP != 0 {
                return Some(Code::EstopInput);
            }
            if b.status & board_status::WATCHDOG_TRIPPED != 0 {
                return Some(Code::BoardWatchdog);
            }
        }
        for (i, a) in fb.axes[..self.axis_count].iter().enumerate() {
            if a.alarm & alarm::FOLLOWING_ERROR != 0
                || a.following_error.abs() > self.limits.following_error[i]
            {
                return Some(Code::FollowingError);
            }
            if a.alarm & (alarm::LIMIT_POS | alarm::LIMIT_NEG) != 0 {
                return Some(Code::SoftLimit);
            }
            if a.alarm != 0 {
                return Some(Code::ServoAlarm);
            }
            let (lo, hi) = self.limits.soft[i];
            if a.commanded < lo || a.commanded > hi || a.encoder < lo || a.encoder > hi {
                return Some(Code::SoftLimit);
            }
        }
        if self.owner_lost.swap(false, Ordering::AcqRel) {
            return Some(Code::ClientLost);
        }
        if let Some(watched) = self.stats.get() {
            // A stall matters while pulses flow, and only when it outlasts the buffer after
            // the task (the FIFO's look-ahead after the Pulse Generator, the ring after the
            // Velocity Generator): then the motors starve. Shorter ones, at any rate, cost
            // nothing. At rest they are counted (TASKS, the log) but stop nothing.
            let moving = matches!(
                self.shared.state(),
                RobotState::Moving | RobotState::Stopping
            );
            let mut fault = None;
            for w in watched {
                if w.too_long(w.cell.take_worst_missed()) && moving {
                    fault = Some(Code::TaskOverrun);
                }
            }
            if fault.is_some() {
                return fault;
            }
        }
        None
    }

    /// One period (public for tests that step the task by hand).
    pub fn step(&mut self) {
        let fault = self.find_fault();
        let state = self.shared.state();
        if matches!(state, RobotState::Idle | RobotState::Moving) {
            self.reported = false;
        }
        // Cleared by the Pulse Generator when it sees the input closed.
        let estop = &self.shared.estop_reported;
        if let Some(code) = fault {
            // The Pulse Generator watches the E-stop input every period and reports it.
            let reported_elsewhere = code == Code::EstopInput && estop.load(Ordering::Acquire);
            if !self.reported
                && !reported_elsewhere
                && !matches!(state, RobotState::Error | RobotState::Estop)
            {
                // Reported once it is on the urgent queue; a queue full of emergencies (a
                // burst of STOP and ESTOP lines) leaves it for the next period.
                if self.urgent.try_send(Urgent::Fault(code.number())).is_ok() {
                    self.reported = true;
                    if code == Code::EstopInput {
                        estop.store(true, Ordering::Release);
                    }
                    self.wake.post();
                } else if code == Code::ClientLost {
                    // The loss was taken from its flag: keep it for the next period.
                    self.owner_lost.store(true, Ordering::Release);
                }
            }
        }
    }
}

impl<B: MotionBoard + 'static> Task for ErrorCheck<B> {
    fn cycle(&mut self, _ctx: &CycleContext) {
        self.step();
    }
}
