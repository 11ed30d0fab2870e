//! State shared by the controller's tasks: atomics only, so any task reads or writes it
//! without a lock (the messages between the tasks are in [`crate::messages`]).

use std::sync::atomic::{AtomicBool, AtomicI64, AtomicU32, AtomicU64, AtomicU8, Ordering};
use std::sync::{Arc, OnceLock};

use wrc_rt::Notify;

pub use wrc_protocol::State as RobotState;
use wrc_robot::MAX_AXES;

/// In [`Shared::blade_wafers`]: the map's wafer on the blade is uncertain.
pub const BLADE_UNCERTAIN: u64 = 1 << 32;

/// In [`Shared::blade_wafers`]: a transfer under way takes or gives the wafer with the blade.
pub const BLADE_PENDING: u64 = 1 << 33;

/// Everything the tasks share, as atomics.
pub struct Shared {
    state: AtomicU8,
    /// Where the running program is: its source file (high 32 bits; 0 the program's own)
    /// and line (low 32 bits); 0 when no program runs. The Command Interpreter publishes
    /// it each cycle for the status stream.
    pub program_line: AtomicU64,
    /// The robot has been homed since start-up.
    pub homed: AtomicBool,
    /// The source holding control ([`crate::messages::SourceId`] bits; 0 = nobody).
    pub owner: AtomicU32,
    /// Speed override for the next moves [%].
    pub speed_pct: AtomicU32,
    /// Code of the last error (0: none).
    pub error_code: AtomicU32,
    /// Bumped to request a controlled stop; the Pulse Generator stops from the period it
    /// has reached and the Velocity Generator drops its plan.
    pub stop_epoch: AtomicU32,
    /// The last stop epoch the Pulse Generator has brought to rest.
    pub stopped_epoch: AtomicU32,
    /// Stop requests begun: counted first, before the stop word is posted and the epoch
    /// moves, so while it differs from the epoch the Pulse Generator has taken a stop is on
    /// its way (a board may already brake for its word).
    pub stop_requests: AtomicU32,
    /// The strongest [`StopKind`] requested since the Pulse Generator last took it (0: none,
    /// a plain stop).
    pub stop_kind: AtomicU8,
    /// Commanded position: every pulse pushed to the board so far [pulse].
    pub commanded: [AtomicI64; MAX_AXES],
    /// Digital outputs the I/O Monitor applies, one word per board.
    pub outputs: [AtomicU32; 4],
    /// Digital inputs as last read by the I/O Monitor, one word per board.
    pub inputs: [AtomicU32; 4],
    /// Pulse batches in flight (ring + board FIFO) — 0 when the robot is at rest.
    pub in_flight: AtomicU32,
    /// The Velocity Generator is filling the ring (set before its first batch of a cycle,
    /// cleared after its last): a move's start that finds fewer periods than the look-ahead
    /// waits for the rest instead of queuing a few that a stall would run dry.
    pub vg_filling: AtomicBool,
    /// Set with a stop request after RESET: the Pulse Generator takes the board's own
    /// position (the board may have stopped by itself or dropped entries of an alarmed axis).
    pub resync_from_board: AtomicBool,
    /// Observability [ns, CLOCK_MONOTONIC]: when the Pulse Generator pushed the first batch
    /// of the latest move.
    pub first_pulse_ns: AtomicU64,
    /// When the Ethernet or RS232C task read the latest STOP or ESTOP line.
    pub urgent_read_ns: AtomicU64,
    /// When the Pulse Generator pushed the first decelerating batch of the latest stop.
    pub decel_ns: AtomicU64,
    /// How the Pulse Generator's stops braked: with a FIFO flush or behind the queue.
    pub stops: StopCounts,
    /// The board FIFO as the Pulse Generator sees it: its look-ahead, the deepest drain, the
    /// boards' underrun, watchdog and late-period counters.
    pub fifo: FifoStats,
    /// The I/O Monitor has read the inputs at least once (`inputs` are real). Cleared by the
    /// Pulse Generator when a board stops answering (its inputs are stale), set again by the
    /// I/O Monitor's first read once every board answers.
    pub io_ready: AtomicBool,
    /// How many times the I/O Monitor has read the inputs (counted after `inputs` is
    /// stored): who needs inputs read after some moment waits for the count to pass the one
    /// it saw then (`inputs` may be an I/O Monitor period old).
    pub io_samples: AtomicU64,
    /// A board's heartbeat has stood for its `heartbeat_periods` (the Pulse Generator
    /// watches it every period): the board is not answering. Cleared when every heartbeat
    /// advances again; the controller stays in ERROR until a RESET re-attaches.
    pub board_dead: AtomicBool,
    /// The E-stop input's opening is on the urgent path (202), from the Pulse Generator,
    /// which watches it every period, or Error Check: the other does not report it again.
    /// Cleared once the input is seen closed.
    pub estop_reported: AtomicBool,
    /// The blades the wafer map has a wafer on for certain and that no transfer under way
    /// uses (bit 0: A, the hand; bit 1: B), set by the cell service once it has settled the
    /// start-up: outside a job the Command Interpreter watches their vacuum sensors, moving
    /// or not (a wafer lost is alarm 213).
    pub hand_wafers: AtomicU8,
    /// What the wafer map has on each blade (index: [`wrc_cell::Blade::index`]), set by the
    /// cell service for the Command Interpreter, which may not look into the map (it guards
    /// the vacuum valves and the guarded outputs with it): 0 nothing; otherwise the wafer's
    /// number in the low 32 bits, with [`BLADE_UNCERTAIN`] when the map is not sure of it
    /// and [`BLADE_PENDING`] when a transfer under way takes or gives it with that blade.
    pub blade_wafers: [AtomicU64; wrc_cell::MAX_BLADES],
    /// How many wafer jobs the Command Interpreter has ended and told the cell service of
    /// ([`crate::messages::cell_job::CellEvent::Ended`]).
    pub jobs_ended: AtomicU32,
    /// How many of those the cell service has settled: while it is behind
    /// [`Shared::jobs_ended`], the map (and `hand_wafers`) may not yet show what the last job
    /// left ([`Shared::map_settled`]).
    pub jobs_settled: AtomicU32,
    /// The speed [%] a motion may have while a blade perhaps holds a wafer its vacuum does
    /// not clamp (after a power loss), set by the cell service; 0: no limit.
    pub careful_pct: AtomicU32,
    /// What the transfer journal cost the Command Interpreter: steps that waited for their
    /// beginning to be on disk, the total and the longest wait [ns].
    pub journal_waits: AtomicU64,
    /// See [`Shared::journal_waits`].
    pub journal_wait_ns: AtomicU64,
    /// See [`Shared::journal_waits`].
    pub journal_wait_max_ns: AtomicU64,
    /// The ticket of the last move whose pulses the Pulse Generator sent from a state
    /// committed to enter a station (a blended approach past its commit point, or a line):
    /// until it names a blended approach, a stop still ends behind its approach pose
    /// (docs/motion.md, "Blended approach").
    pub entry_committed: AtomicU32,
    /// Released by every stop request: the Pulse Generator's wake (set once at start-up).
    stop_notify: OnceLock<Arc<dyn Notify>>,
    /// Every stop request is posted here too, straight to the board(s)' stop word (set once
    /// at start-up): a board whose stop the Pulse Generator does not answer within a board
    /// period brakes on its own.
    stop_line: OnceLock<wrc_board::StopLine>,
    /// Released by every change of `outputs`: the I/O Monitor's wake (set once at start-up).
    output_notify: OnceLock<Arc<dyn Notify>>,
}

impl Default for Shared {
    fn default() -> Self {
        Shared {
            state: AtomicU8::new(RobotState::Idle.to_u8()),
            program_line: AtomicU64::new(0),
            owner: AtomicU32::new(0),
            speed_pct: AtomicU32::new(100),
            homed: AtomicBool::new(false),
            error_code: AtomicU32::new(0),
            stop_epoch: AtomicU32::new(0),
            stopped_epoch: AtomicU32::new(0),
            stop_kind: AtomicU8::new(0),
            stop_requests: AtomicU32::new(0),
            commanded: std::array::from_fn(|_| AtomicI64::new(0)),
            outputs: std::array::from_fn(|_| AtomicU32::new(0)),
            inputs: std::array::from_fn(|_| AtomicU32::new(0)),
            in_flight: AtomicU32::new(0),
            resync_from_board: AtomicBool::new(false),
            first_pulse_ns: AtomicU64::new(0),
            vg_filling: AtomicBool::new(false),
            urgent_read_ns: AtomicU64::new(0),
            decel_ns: AtomicU64::new(0),
            stops: StopCounts::default(),
            fifo: FifoStats::default(),
            io_ready: AtomicBool::new(false),
            io_samples: AtomicU64::new(0),
            board_dead: AtomicBool::new(false),
            estop_reported: AtomicBool::new(false),
            hand_wafers: AtomicU8::new(0),
            blade_wafers: std::array::from_fn(|_| AtomicU64::new(0)),
            jobs_ended: AtomicU32::new(0),
            jobs_settled: AtomicU32::new(0),
            careful_pct: AtomicU32::new(0),
            journal_waits: AtomicU64::new(0),
            journal_wait_ns: AtomicU64::new(0),
            journal_wait_max_ns: AtomicU64::new(0),
            entry_committed: AtomicU32::new(0),
            stop_notify: OnceLock::new(),
            stop_line: OnceLock::new(),
            output_notify: OnceLock::new(),
        }
    }
}

impl Shared {
    /// The current state.
    pub fn state(&self) -> RobotState {
        RobotState::from_u8(self.state.load(Ordering::Acquire)).unwrap_or(RobotState::Error)
    }

    /// Set the state.
    pub fn set_state(&self, state: RobotState) {
        self.state.store(state.to_u8(), Ordering::Release);
    }

    /// Whether the cell service has settled every wafer job that ended: the wafer map shows
    /// what the last one left (a transfer that ended abnormally is settled once the arm
    /// stands still and the vacuum sensor has answered). The watch of the blades outside a
    /// job and a program's error handler wait for it.
    pub fn map_settled(&self) -> bool {
        // The count settled first: what the service published before it is then visible.
        let settled = self.jobs_settled.load(Ordering::Acquire);
        settled == self.jobs_ended.load(Ordering::Acquire)
    }

    /// Request a stop of `kind`; returns the new stop epoch. The kind is raised before the
    /// epoch moves, so the Pulse Generator that sees the epoch also sees the kind (or a
    /// stronger one requested meanwhile: an ESTOP is never weakened by a later STOP or HOLD).
    pub fn request_stop(&self, kind: StopKind) -> u32 {
        self.stop_requests.fetch_add(1, Ordering::AcqRel);
        self.stop_kind.fetch_max(kind as u8, Ordering::AcqRel);
        // The board's stop word before the epoch: a Pulse Generator that sees the epoch then
        // answers this stop (its flush carries the word's sequence), never an older one.
        if let Some(line) = self.stop_line.get() {
            // A board that brakes on its own uses the limits this stop would: full for an
            // ESTOP, the speed override's for a STOP or a HOLD.
            let level = match kind {
                StopKind::Estop => 100,
                StopKind::Hold | StopKind::Stop => {
                    self.speed_pct.load(Ordering::Relaxed).clamp(1, 100) as u8
                }
            };
            line.post(level);
        }
        let epoch = self
            .stop_epoch
            .fetch_add(1, Ordering::AcqRel)
            .wrapping_add(1);
        if let Some(notify) = self.stop_notify.get() {
            notify.notify();
        }
        epoch
    }

    /// Post every stop request to `line` as well (the board(s)' stop word). Set once; later
    /// calls change nothing.
    pub fn set_stop_line(&self, line: wrc_board::StopLine) {
        let _ = self.stop_line.set(line);
    }

    /// Wake `notify` (the Pulse Generator) on every stop request, so the brake starts at
    /// once instead of at its next period. Set once; later calls change nothing.
    pub fn notify_stops(&self, notify: Arc<dyn Notify>) {
        let _ = self.stop_notify.set(notify);
    }

    /// Set (`on`) or clear output `n` of board 0 for the I/O Monitor to apply, and release
    /// the I/O Monitor so it applies it now rather than at its next period (a vacuum valve
    /// in a transfer waits for it).
    pub fn set_output(&self, n: u8, on: bool) {
        let bit = 1u32 << (n & 31);
        if on {
            self.outputs[0].fetch_or(bit, Ordering::AcqRel);
        } else {
            self.outputs[0].fetch_and(!bit, Ordering::AcqRel);
        }
        if let Some(notify) = self.output_notify.get() {
            notify.notify();
        }
    }

    /// Wake `notify` (the I/O Monitor) on every [`Shared::set_output`]. Set once; later calls
    /// change nothing.
    pub fn notify_outputs(&self, notify: Arc<dyn Notify>) {
        let _ = self.output_notify.set(notify);
    }

    /// Take the strongest stop kind requested (the Pulse Generator, when it sees a new stop
    /// epoch); a stop without a recorded kind is a plain [`StopKind::Stop`].
    pub fn take_stop_kind(&self) -> StopKind {
        StopKind::from_u8(self.stop_kind.swap(0, Ordering::AcqRel))
    }

    /// Now on the clock of the timestamps above [ns] (a vDSO read, no system call).
    pub fn now_ns() -> u64 {
        use wrc_rt::Clock;
        wrc_rt::MonotonicClock.now_ns()
    }

    /// The commanded position [pulse].
    pub fn commanded_pulses(&self) -> [i64; MAX_AXES] {
        std::array::from_fn(|i| self.commanded[i].load(Ordering::Acquire))
    }
}

/// Stops the Pulse Generator has braked, by how the brake reached the board (counted from
/// start-up; `TASKS` reports them on the Pulse Generator's line).
#[derive(Debug, Default)]
pub struct StopCounts {
    /// Stops braked with a FIFO flush: the board skipped the periods queued ahead and
    /// executed the first braking period next [stops].
    pub flushed: AtomicU64,
    /// Stops braked behind the queued periods, the flush not usable (a robot on several
    /// boards, a flush still pending, a board period beginning at every try, no room in the
    /// FIFO): the board executed the queued periods (the look-ahead)
    /// first [stops].
    pub behind_queue: AtomicU64,
}

impl StopCounts {
    /// The counts now.
    pub fn read(&self) -> StopTally {
        StopTally {
            flushed: self.flushed.load(Ordering::Relaxed),
            behind_queue: self.behind_queue.load(Ordering::Relaxed),
        }
    }
}

/// The board FIFO and the boards' counters, as the Pulse Generator last read them (`TASKS`
/// reports them on its line; `wrc bench soak` judges a run by them).
#[derive(Debug)]
pub struct FifoStats {
    /// Periods the Pulse Generator keeps queued ahead of the board.
    pub lookahead: AtomicU32,
    /// The lowest FIFO level the Pulse Generator found at the start of a period while it
    /// streamed (the FIFO filled to its look-ahead since the last stop), `u32::MAX` before
    /// any: the look-ahead less this is the deepest drain a late wake-up caused [periods].
    pub min_level: AtomicU32,
    /// The Pulse Generator's wake-up lateness in the period that found [`FifoStats::min_level`]
    /// [µs]: a drain deeper than it was not this task's stall.
    pub min_late_us: AtomicU32,
    /// Periods the Velocity Generator's ring held then (none: the plan was late, or all of
    /// it was queued).
    pub min_ring: AtomicU32,
    /// The Pulse Generator's periods since the move's first period was pushed, then.
    pub min_after_start: AtomicU32,
    /// Whether the last period pushed then was moving (1) or the move's last (0).
    pub min_moving: AtomicU32,
    /// When the last move ran its FIFO dry (the board braked on its own with no stop asked):
    /// the Pulse Generator's periods since that move's first period was pushed, `u32::MAX`
    /// before any.
    pub dry_after_start: AtomicU32,
    /// Then, its periods since its last flush (`u32::MAX`: none yet).
    pub dry_after_flush: AtomicU32,
    /// Underruns, summed over every axis of every board, since the boards started.
    pub underruns: AtomicU64,
    /// Host-watchdog trips, summed over the boards.
    pub watchdog_trips: AtomicU64,
    /// Board periods started late and caught up (simulated boards), summed over the boards.
    pub board_late: AtomicU64,
    /// Stops the boards braked on their own (the host's brake had not come in time).
    pub board_stops: AtomicU64,
}

impl Default for FifoStats {
    fn default() -> Self {
        FifoStats {
            lookahead: AtomicU32::new(crate::pulse_generator::FIFO_LEAD as u32),
            min_level: AtomicU32::new(u32::MAX),
            min_late_us: AtomicU32::new(0),
            min_ring: AtomicU32::new(0),
            min_after_start: AtomicU32::new(0),
            min_moving: AtomicU32::new(0),
            dry_after_start: AtomicU32::new(u32::MAX),
            dry_after_flush: AtomicU32::new(u32::MAX),
            underruns: AtomicU64::new(0),
            watchdog_trips: AtomicU64::new(0),
            board_late: AtomicU64::new(0),
            board_stops: AtomicU64::new(0),
        }
    }
}

impl FifoStats {
    /// The figures now.
    pub fn read(&self) -> FifoTally {
        let min = self.min_level.load(Ordering::Relaxed);
        let known = |v: &AtomicU32| {
            let v = v.load(Ordering::Relaxed);
            (v != u32::MAX).then_some(v)
        };
        FifoTally {
            lookahead: self.lookahead.load(Ordering::Relaxed),
            min_level: (min != u32::MAX).then_some(min),
            min_late_us: self.min_late_us.load(Ordering::Relaxed),
            min_ring: self.min_ring.load(Ordering::Relaxed),
            min_after_start: self.min_after_start.load(Ordering::Relaxed),
            min_moving: self.min_moving.load(Ordering::Relaxed) != 0,
            dry_after_start: known(&self.dry_after_start),
            dry_after_flush: known(&self.dry_after_flush),
            underruns: self.underruns.load(Ordering::Relaxed),
            watchdog_trips: self.watchdog_trips.load(Ordering::Relaxed),
            board_late: self.board_late.load(Ordering::Relaxed),
            board_stops: self.board_stops.load(Ordering::Relaxed),
        }
    }
}

/// A reading of [`FifoStats`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FifoTally {
    /// Periods kept queued ahead of the board.
    pub lookahead: u32,
    /// The lowest level found while streaming; `None` before any [periods].
    pub min_level: Option<u32>,
    /// The Pulse Generator's wake-up lateness then [µs].
    pub min_late_us: u32,
    /// Periods in the Velocity Generator's ring then.
    pub min_ring: u32,
    /// Periods since the move's first was pushed, then.
    pub min_after_start: u32,
    /// The last period pushed then was moving.
    pub min_moving: bool,
    /// At the last run-dry of a move: periods since its first one was pushed.
    pub dry_after_start: Option<u32>,
    /// At the last run-dry of a move: periods since the last flush.
    pub dry_after_flush: Option<u32>,
    /// Underruns, all axes of all boards.
    pub underruns: u64,
    /// Host-watchdog trips, all boards.
    pub watchdog_trips: u64,
    /// Board periods started late and caught up, all boards.
    pub board_late: u64,
    /// Stops the boards braked on their own.
    pub board_stops: u64,
}

/// A reading of [`StopCounts`] [stops].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StopTally {
    /// Braked with a FIFO flush.
    pub flushed: u64,
    /// Braked behind the queued periods.
    pub behind_queue: u64,
}

/// What a stop request asks of the Pulse Generator, weakest first (a stronger request
/// overrides a weaker one made at about the same time).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
#[repr(u8)]
pub enum StopKind {
    /// `HOLD`: brake on the path at the move's own (override) limits and keep the move, to
    /// be resumed.
    Hold = 1,
    /// `STOP`, a program's `ABORT`, a RESET's resynchronisation: brake on the path at the
    /// move's own (override) limits and end the move.
    Stop = 2,
    /// `ESTOP`, a fault, a lost wafer: IEC 60204-1 stop category 1, brake on the path with
    /// every axis's full limits whatever the override, then hold position.
    Estop = 3,
}

impl StopKind {
    fn from_u8(n: u8) -> StopKind {
        match n {
            1 => StopKind::Hold,
            3 => StopKind::Estop,
            _ => StopKind::Stop,
        }
    }
}
