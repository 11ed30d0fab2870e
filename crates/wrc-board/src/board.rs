//! The [`MotionBoard`] trait: what the controller's real-time tasks need from a motion board,
//! whichever board it is (a mapped DPRAM, several of them, a test double). Every method is
//! non-blocking and allocation-free, so the Pulse Generator, Error Check and I/O Monitor may
//! call it from their cycles.

use crate::dpram::FifoPosition;
use wrc_robot::MAX_AXES;

use crate::layout::MAX_BOARDS;

pub use crate::dpram::Torn;

/// The command FIFO of at least one axis has no room for another period. Nothing was
/// pushed (all axes take a period together or none does); try again next cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the board's command FIFO is full; nothing was pushed")]
pub struct Full;

/// The board has not yet acknowledged the previous command; try again next cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the board has not acknowledged the previous command yet")]
pub struct Busy;

/// A board's sign of life ([`MotionBoard::heartbeat`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Heartbeat {
    /// The board's epoch: changes when the board restarts (a restarted board has lost its
    /// FIFO and state, so the host must treat it as the board it knew dying).
    pub epoch: u32,
    /// The board's watchdog counter: advances every board period.
    pub beat: u32,
}

/// One axis as the board last reported it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct AxisFeedback {
    /// Axis status bits, [`crate::layout::axis_status`].
    pub status: u32,
    /// Alarm cause bits, [`crate::layout::alarm`]; 0 when not alarmed.
    pub alarm: u32,
    /// Commanded position [pulse].
    pub commanded: i64,
    /// Encoder position [pulse].
    pub encoder: i64,
    /// Following error, commanded − encoder [pulse].
    pub following_error: i64,
    /// Increment executed in the last board period [pulse/period].
    pub increment: i64,
    /// Entries waiting in the FIFO [periods].
    pub fifo_level: u32,
    /// FIFO underruns since the board started.
    pub underruns: u32,
    /// Alarms raised since the board started.
    pub alarms: u32,
    /// Entries consumed without being executed (axis alarmed or stopping).
    pub discarded: u32,
}

/// One board's own state.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BoardFeedback {
    /// Board status bits, [`crate::layout::board_status`].
    pub status: u32,
    /// The board's watchdog counter (advances every board period while the board runs).
    pub board_watchdog: u32,
    /// Board periods since the board started.
    pub period_count: u64,
    /// Host-watchdog trips since the board started.
    pub watchdog_trips: u32,
    /// Periods the simulated board started late and caught up.
    pub late_periods: u32,
    /// Digital inputs, bit n = input n.
    pub inputs: u32,
    /// Digital outputs as the board drives them.
    pub outputs: u32,
    /// Board epoch; changes when the board restarts.
    pub epoch: u32,
}

/// A snapshot of every axis and board, filled by [`MotionBoard::read_feedback`]; make it
/// once and reuse it every cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Feedback {
    /// Axes in use (`axes[..axis_count]`).
    pub axis_count: usize,
    /// Per axis, in controller axis order.
    pub axes: [AxisFeedback; MAX_AXES],
    /// Boards in use (`boards[..board_count]`).
    pub board_count: usize,
    /// Per board, in board order.
    pub boards: [BoardFeedback; MAX_BOARDS],
}

impl Default for Feedback {
    fn default() -> Self {
        Feedback {
            axis_count: 0,
            axes: [AxisFeedback::default(); MAX_AXES],
            board_count: 0,
            boards: [BoardFeedback::default(); MAX_BOARDS],
        }
    }
}

impl Feedback {
    /// True when any board is stopped or stopping (watchdog, E-stop) or any axis is alarmed.
    pub fn any_fault(&self) -> bool {
        use crate::layout::board_status as b;
        self.boards[..self.board_count].iter().any(|board| {
            board.status & (b::WATCHDOG_TRIPPED | b::ESTOP | b::STOPPING | b::ALARM) != 0
        })
    }

    /// Sum of all axes' underruns.
    pub fn underruns(&self) -> u64 {
        self.axes[..self.axis_count]
            .iter()
            .map(|a| u64::from(a.underruns))
            .sum()
    }
}

/// The mapping sensor's latch, filled by [`MotionBoard::read_mapping`]: which station's
/// slots the sensor has passed since the last [`MotionBoard::clear_mapping`] and what it saw
/// in each (`docs/dpram.md`, Mapping sensor). Make it once and reuse it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MappingScan {
    /// The board has acted on the last clear (`CLEAR_ACK == CLEAR_SEQ`): the latch shows
    /// only what was scanned since. Stays false on a board without a mapping sensor.
    pub cleared: bool,
    /// 1 + the index (stations-file order) of the station scanned; 0: none yet.
    pub station: u32,
    /// Bit `s - 1` set when slot `s` has been scanned.
    pub seen: u64,
    /// `codes[s - 1]` is slot `s`'s code, [`crate::layout::slot_code`] (0 absent, 1 present,
    /// 2 double, 3 cross); meaningful where `seen` has the slot's bit.
    pub codes: [u8; crate::layout::mapping::MAX_SLOTS],
}

impl Default for MappingScan {
    fn default() -> Self {
        MappingScan {
            cleared: false,
            station: 0,
            seen: 0,
            codes: [0; crate::layout::mapping::MAX_SLOTS],
        }
    }
}

impl MappingScan {
    /// Decode the board's words.
    pub fn from_record(cleared: bool, record: &crate::dpram::MappingRecord) -> MappingScan {
        let mut scan = MappingScan {
            cleared,
            station: record.station,
            seen: record.seen,
            ..MappingScan::default()
        };
        for (i, code) in scan.codes.iter_mut().enumerate() {
            *code = ((record.codes[i / 16] >> (2 * (i % 16))) & 0b11) as u8;
        }
        scan
    }

    /// Whether slot `slot` (1-based) has been scanned.
    pub fn is_seen(&self, slot: u16) -> bool {
        (1..=crate::layout::mapping::MAX_SLOTS as u16).contains(&slot)
            && self.seen & (1u64 << (slot - 1)) != 0
    }

    /// Slot `slot`'s code (1-based), or `None` when it has not been scanned.
    pub fn slot_code(&self, slot: u16) -> Option<wrc_cell::SlotCode> {
        use crate::layout::slot_code as c;
        if !self.is_seen(slot) {
            return None;
        }
        Some(match u32::from(self.codes[usize::from(slot - 1)]) {
            c::ABSENT => wrc_cell::SlotCode::Absent,
            c::PRESENT => wrc_cell::SlotCode::Present,
            c::DOUBLE => wrc_cell::SlotCode::Double,
            _ => wrc_cell::SlotCode::Cross,
        })
    }
}

/// A handle on the stop words of the board(s) that any thread may use
/// ([`MotionBoard::stop_line`]): a stop request reaches the board at once, not when the
/// Pulse Generator next runs, so the board brakes on its own if the host's brake does not
/// come within a board period (docs/dpram.md, "Stops"). Posting is a compare-and-swap per
/// board: no lock, no allocation, no system call.
pub struct StopLine {
    pub(crate) boards: Vec<crate::dpram::Dpram>,
}

impl StopLine {
    /// A line to every board of `boards`.
    pub fn new(boards: Vec<crate::dpram::Dpram>) -> StopLine {
        StopLine { boards }
    }

    /// Post a stop whose brake, if a board brakes on its own, uses `level` % of the axes'
    /// brake limits (100 for ESTOP; the speed override for STOP and HOLD).
    pub fn post(&self, level: u8) {
        for b in &self.boards {
            b.post_stop(level);
        }
    }
}

impl std::fmt::Debug for StopLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "StopLine({} boards)", self.boards.len())
    }
}

/// Where the boards' own brakes stand ([`MotionBoard::board_stop`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BoardStop {
    /// Some board braked on its own (the host's brake did not come in time): it discards
    /// the FIFO until [`MotionBoard::release_stop`].
    pub braking_own: bool,
    /// Every board that braked on its own is at rest.
    pub settled: bool,
    /// Some axis still decelerates in a brake of its board's own: a stop it took on its own,
    /// its E-stop input, a host-watchdog trip. The arm is moving though the host pushes
    /// nothing.
    pub braking: bool,
    /// No board braked on its own, and none will for the stop last posted: every board has
    /// taken it otherwise (a flush of the host's brake answered it, or a RESET) and no flush
    /// is pending. A host that waits for a board's own brake then waits in vain.
    pub answered: bool,
    /// Some board's E-stop input has opened (latched until RESET): the board plays the
    /// host's brake only if the host flushes it at once (docs/dpram.md, "Stops" 6).
    pub estop: bool,
}

/// A motion board (or several) as the controller's real-time tasks use it.
///
/// Axes are numbered 0.. in the controller's (robot's) order; I/O words one per board.
/// Implementations do not allocate, block, print or make system calls in these methods.
pub trait MotionBoard: Send {
    /// Axes driven [count].
    fn axis_count(&self) -> usize;

    /// Boards behind this handle, i.e. digital I/O words [count].
    fn board_count(&self) -> usize;

    /// Board period: one pushed increment is executed per period [µs].
    fn period_us(&self) -> u32;

    /// Periods that can be pushed right now without [`Full`] [periods].
    fn fifo_free(&self) -> usize;

    /// Queue one period's increments, `increments[axis]` [pulse/period] for
    /// `axis < axis_count()` (the rest is ignored). All axes or none.
    fn push(&mut self, increments: &[i64; MAX_AXES]) -> Result<(), Full>;

    /// Fill `out` with the current state of every axis and board.
    fn read_feedback(&self, out: &mut Feedback) -> Result<(), Torn>;

    /// Digital inputs of board `board`, bit n = input n (0 for a board that does not exist).
    fn read_inputs(&self, board: usize) -> u32;

    /// Set the digital outputs of board `board` (ignored for a board that does not exist).
    fn write_outputs(&mut self, board: usize, outputs: u32);

    /// The outputs last written to board `board`.
    fn outputs(&self, board: usize) -> u32;

    /// Board `board`'s heartbeat: its epoch (which changes when the board restarts) and its
    /// watchdog counter (which advances every board period while the board runs); two
    /// atomic loads. `None` for a board that does not exist or has no heartbeat (a test
    /// double): it is never judged dead.
    fn heartbeat(&self, board: usize) -> Option<Heartbeat> {
        let _ = board;
        None
    }

    /// Tell the board(s) the host is alive; call once per cycle. The board stops all axes
    /// when this stops for its configured number of periods.
    fn refresh_watchdog(&mut self);

    /// Clear the alarms of the axes in `axes` (bit n = axis n). Idempotent.
    fn clear_alarms(&mut self, axes: u16) -> Result<(), Busy>;

    /// Clear watchdog trip, E-stop latch and all alarms, so the board accepts motion again.
    /// Idempotent.
    fn reset(&mut self) -> Result<(), Busy>;

    /// Whether a command posted with [`MotionBoard::clear_alarms`] or [`MotionBoard::reset`]
    /// has not yet been carried out (the board has not acknowledged it).
    fn command_pending(&self) -> bool;

    /// Clear the mapping sensor's latch and start a new scan (board 0's sensor): the board
    /// acts at its next period; [`MappingScan::cleared`] says when it has.
    fn clear_mapping(&mut self);

    /// Fill `out` with the mapping sensor's latch (board 0's sensor).
    fn read_mapping(&self, out: &mut MappingScan) -> Result<(), Torn>;

    /// Where the command FIFO stands, for [`MotionBoard::flush_queued`]: `None` if the
    /// board cannot flush (several boards, or none of the DPRAM kind), is inside a period,
    /// or has a flush pending.
    fn fifo_position(&self) -> Option<FifoPosition> {
        None
    }

    /// Ask the board to skip, at the start of its next period, the entries it has not
    /// executed at `at` up to the FIFO index `to` (`at.write`, or `at.read` to skip
    /// nothing), and to execute `next` from `to` on, `next` queued by the flush itself: the
    /// board publishes them as it takes the flush, so its next period never finds them
    /// missing, however late this thread runs after the request. False, and nothing asked
    /// nor queued, if the board began a period since `at` was read (read the position again
    /// and try again), or `next` does not fit in the free slots.
    fn flush_queued(&mut self, at: &FifoPosition, to: u32, next: &[[i64; MAX_AXES]]) -> bool {
        let _ = (at, to, next);
        false
    }

    /// A handle that posts stops to every board from any thread; `None` for a board
    /// without a stop word (a test double): stops then wait for the Pulse Generator.
    fn stop_line(&self) -> Option<StopLine> {
        None
    }

    /// Give axis `axis` the brake limits the board uses when it brakes on its own (a stop
    /// the host did not answer in time, a host-watchdog trip, the E-stop input) [pulse/s²,
    /// pulse/s³]; written once at start-up.
    fn set_brake_limits(&mut self, axis: usize, accel_pps2: f64, jerk_pps3: f64) {
        let _ = (axis, accel_pps2, jerk_pps3);
    }

    /// Whether a board braked on its own, and whether every such board is at rest.
    fn board_stop(&self) -> BoardStop {
        BoardStop::default()
    }

    /// Let every board that braked on its own take the FIFO again, from the next entry
    /// pushed (the ones pushed before are skipped). Call once they are settled and the host
    /// has taken their positions.
    fn release_stop(&mut self) {}
}

impl<B: MotionBoard + ?Sized> MotionBoard for Box<B> {
    fn axis_count(&self) -> usize {
        (**self).axis_count()
    }
    fn board_count(&self) -> usize {
        (**self).board_count()
    }
    fn period_us(&self) -> u32 {
        (**self).period_us()
    }
    fn fifo_free(&self) -> usize {
        (**self).fifo_free()
    }
    fn push(&mut self, increments: &[i64; MAX_AXES]) -> Result<(), Full> {
        (**self).push(increments)
    }
    fn read_feedback(&self, out: &mut Feedback) -> Result<(), Torn> {
        (**self).read_feedback(out)
    }
    fn read_inputs(&self, board: usize) -> u32 {
        (**self).read_inputs(board)
    }
    fn write_outputs(&mut self, board: usize, outputs: u32) {
        (**self).write_outputs(board, outputs)
    }
    fn outputs(&self, board: usize) -> u32 {
        (**self).outputs(board)
    }
    fn heartbeat(&self, board: usize) -> Option<Heartbeat> {
        (**self).heartbeat(board)
    }
    fn refresh_watchdog(&mut self) {
        (**self).refresh_watchdog()
    }
    fn clear_alarms(&mut self, axes: u16) -> Result<(), Busy> {
        (**self).clear_alarms(axes)
    }
    fn reset(&mut self) -> Result<(), Busy> {
        (**self).reset()
    }
    fn command_pending(&self) -> bool {
        (**self).command_pending()
    }
    fn clear_mapping(&mut self) {
        (**self).clear_mapping()
    }
    fn read_mapping(&self, out: &mut MappingScan) -> Result<(), Torn> {
        (**self).read_mapping(out)
    }
    fn fifo_position(&self) -> Option<FifoPosition> {
        (**self).fifo_position()
    }
    fn flush_queued(&mut self, at: &FifoPosition, to: u32, next: &[[i64; MAX_AXES]]) -> bool {
        (**self).flush_queued(at, to, next)
    }
    fn stop_line(&self) -> Option<StopLine> {
        (**self).stop_line()
    }
    fn set_brake_limits(&mut self, axis: usize, accel_pps2: f64, jerk_pps3: f64) {
        (**self).set_brake_limits(axis, accel_pps2, jerk_pps3)
    }
    fn board_stop(&self) -> BoardStop {
        (**self).board_stop()
    }
    fn release_stop(&mut self) {
        (**self).release_stop()
    }
}
