//! Pulse Generator task (Table 1: priority 20, 10 ms): every period, moves the Velocity
//! Generator's pulse batches from the SPSC ring into the board FIFO, keeping it a fixed
//! number of periods ahead, and streams zero batches at rest (a motion card expects one
//! entry per period; a missing one is an underrun). A stop request takes effect here, from
//! the period the board has actually reached: the queued plan is discarded, the generator
//! state after the last period the board executed brakes time-optimally on its path from
//! its velocity and acceleration (STOP and HOLD at the move's override limits, ESTOP and
//! faults at the axes' full limits), and the board is asked to flush the periods it has
//! queued but not executed (docs/dpram.md, "FIFO flush"), so the brake's first period is
//! the board's next one. A board that cannot flush (several boards) gets the brake behind
//! its queued periods. A HOLD's move is reported held, not stopped, so the Command
//! Interpreter can resume it.
//!
//! Every period it also watches each board's heartbeat (the board's watchdog counter, which
//! the board advances every one of its periods): a heartbeat that stands for the board's
//! `heartbeat_periods` means a board that does not answer (a hung DSP, a dead board
//! process), and a new epoch means a board that restarted (so the one it replaces died,
//! with its FIFO and its state, however short the gap). The task then raises fatal error
//! 300 on the urgent path (`ABS` for the motion, `EVT ERROR`, state `ERROR`; retried each
//! period while the urgent queue is full), pushes nothing more, and ends any motion where
//! it stands: a dead board can neither brake nor report where the arm is. It stays so, whatever the
//! heartbeat does, until a RESET re-attaches: it takes the board's position again
//! ([`Shared::resync_from_board`]) and starts a new history of the board's FIFO (a
//! restarted board starts an empty one).
//!
//! Real-time promise: the cycle does not allocate, block or print; the board calls are
//! atomic memory operations on the mapped DPRAM.

use std::sync::atomic::Ordering;
use std::sync::Arc;

use wrc_board::layout::MAX_BOARDS;
use wrc_board::{Feedback, FifoPosition, Heartbeat, MotionBoard};
use wrc_motion::{BrakeLimits, MotionState, MoveEnd, Period, Status, VelocityGenerator};
use wrc_protocol::Code;
use wrc_robot::MAX_AXES;
use wrc_rt::ipc::mailbox::MailboxWriter;
use wrc_rt::ipc::queue::MessageQueue;
use wrc_rt::ipc::spsc::SpscReceiver;
use wrc_rt::ipc::Semaphore;
use wrc_rt::{CycleContext, Release, Task};

use crate::messages::{Batch, MoveDone, MoveOutcome, Urgent};
use crate::recorder::SampleTap;
use crate::shared::{Shared, StopKind};
use wrc_trace::Sample;

/// Periods kept queued in the board FIFO ahead of the board unless the configuration says
/// otherwise ([`PulseGenerator::with_lookahead`], `[motion] lookahead_ms`): a late wake-up of
/// up to this many periods does not starve an axis. A stop does not wait for them: the
/// board skips them (docs/dpram.md, "FIFO flush").
pub const FIFO_LEAD: usize = 2;

/// Zero periods pushed after the last moving period of a motion, in the same cycle, and
/// then nothing while at rest: the board's last increment is zero before its FIFO can run
/// dry, so an empty FIFO at rest is a hold, never an underrun of a moving axis; and a move
/// starts in the board's next period, not behind a queue (it fills the FIFO to the
/// look-ahead from its first period on: the Velocity Generator plans a ring's worth ahead).
/// A stall at rest costs nothing: the board holds, and the next move starts later.
pub const REST_ZEROS: usize = 1;

/// Periods a finished move may wait, once the board has executed its last period, for every
/// encoder to reach its commanded count before its end is reported anyway (the servo's lag;
/// Error Check watches the following error).
pub const IN_POSITION_PERIODS: usize = 10;

/// Periods pushed to the board that the Pulse Generator remembers (the state after each and
/// its pulses), to brake from the one the board has reached: more than the FIFO ever holds
/// (its whole capacity, and the one before them).
const HISTORY: usize = wrc_board::layout::FIFO_CAPACITY + 2;

/// Tries at a flush before a stop brakes behind the queued periods: a try fails only when a
/// board period begins while the brake's first periods are computed.
const FLUSH_TRIES: usize = 3;

/// Polls of the board's FIFO position while the board is inside a period (its period takes
/// microseconds) before a flush is given up.
const POSITION_POLLS: usize = 10_000;

/// One period pushed to the board.
#[derive(Clone, Copy)]
struct Pushed {
    pulses: [i64; MAX_AXES],
    after: MotionState,
}

/// The last [`HISTORY`] periods pushed, oldest first.
struct History {
    /// On the heap: a period's state is large, and the ring holds a whole FIFO of them.
    ring: Box<[Pushed]>,
    /// Periods pushed since the start (the newest is at `(count - 1) % HISTORY`).
    count: usize,
}

impl History {
    fn new(at: MotionState) -> History {
        History {
            ring: vec![
                Pushed {
                    pulses: [0; MAX_AXES],
                    after: at,
                };
                HISTORY
            ]
            .into_boxed_slice(),
            count: 0,
        }
    }

    /// Forget every period: a new history from the state `at` (in place, no allocation).
    fn restart(&mut self, at: MotionState) {
        for p in self.ring.iter_mut() {
            p.pulses = [0; MAX_AXES];
            p.after = at;
        }
        self.count = 0;
    }

    fn push(&mut self, pulses: &[i64; MAX_AXES], after: &MotionState) {
        let slot = &mut self.ring[self.count % HISTORY];
        slot.pulses = *pulses;
        slot.after = *after;
        self.count += 1;
    }

    /// The `back`-th newest period (0 = the newest), if remembered.
    fn get(&self, back: usize) -> Option<&Pushed> {
        (back < self.count.min(HISTORY)).then(|| &self.ring[(self.count - 1 - back) % HISTORY])
    }

    /// The state before the oldest of the `queued` newest periods (after the period before
    /// them), if remembered.
    fn before(&self, queued: usize) -> Option<&MotionState> {
        self.get(queued).map(|p| &p.after)
    }

    /// Forget the `n` newest periods (the board skipped them).
    fn drop_newest(&mut self, n: usize) {
        self.count -= n.min(self.count);
    }

    /// Sum of the pulses of the `n` newest periods.
    fn newest_pulses(&self, n: usize) -> [i64; MAX_AXES] {
        let mut sum = [0i64; MAX_AXES];
        for back in 0..n {
            if let Some(p) = self.get(back) {
                for (s, x) in sum.iter_mut().zip(&p.pulses) {
                    *s += x;
                }
            }
        }
        sum
    }
}

/// The boards' heartbeats as the Pulse Generator watches them, and where it reports a board
/// that stopped answering.
pub struct Liveness {
    /// Periods of this task in which a heartbeat may stand before its board is dead.
    limit: u32,
    last: [Option<Heartbeat>; MAX_BOARDS],
    still: [u32; MAX_BOARDS],
    urgent: Arc<MessageQueue<Urgent>>,
    wake: Arc<Semaphore>,
    /// A dead board's fault is not on the urgent queue yet (it was full).
    unreported: bool,
}

impl Liveness {
    /// A board is dead when its heartbeat stands for `board_periods` of its own periods
    /// (`board_period_us` long), counted in this task's periods (`period_us`): at least one
    /// of them, and never less time than the board's. The fault goes on `urgent`, with
    /// `wake` posted.
    pub fn new(
        board_periods: u32,
        board_period_us: u32,
        period_us: u32,
        urgent: Arc<MessageQueue<Urgent>>,
        wake: Arc<Semaphore>,
    ) -> Liveness {
        let board_time = u64::from(board_periods.max(1)) * u64::from(board_period_us);
        let limit = board_time.div_ceil(u64::from(period_us.max(1))).max(1);
        Liveness {
            limit: u32::try_from(limit).unwrap_or(u32::MAX),
            last: [None; MAX_BOARDS],
            still: [0; MAX_BOARDS],
            urgent,
            wake,
            unreported: false,
        }
    }

    /// Raise fault `code` on the urgent path now (false if the queue is full).
    fn raise(&self, code: Code) -> bool {
        let sent = self.urgent.try_send(Urgent::Fault(code.number())).is_ok();
        if sent {
            self.wake.post();
        }
        sent
    }

    /// Put the dead board's fault on the urgent queue if it is not there yet.
    fn report(&mut self) {
        if self.unreported
            && self
                .urgent
                .try_send(Urgent::Fault(Code::BoardLost.number()))
                .is_ok()
        {
            self.unreported = false;
            self.wake.post();
        }
    }

    /// One period's look at every heartbeat: true when some board's has stood too long, or
    /// when a board has restarted (a new epoch: the board it replaces died, with its FIFO
    /// and its state).
    fn dead<B: MotionBoard>(&mut self, board: &B) -> bool {
        let mut dead = false;
        for b in 0..board.board_count().min(MAX_BOARDS) {
            let Some(now) = board.heartbeat(b) else {
                continue;
            };
            match self.last[b] {
                Some(last) if last == now => {
                    self.still[b] = self.still[b].saturating_add(1);
                }
                Some(last) if last.epoch != now.epoch => {
                    self.still[b] = 0;
                    dead = true;
                }
                _ => self.still[b] = 0,
            }
            self.last[b] = Some(now);
            dead |= self.still[b] >= self.limit;
        }
        dead
    }
}

/// The Pulse Generator.
pub struct PulseGenerator<B: MotionBoard> {
    board: B,
    ring: SpscReceiver<Batch>,
    shared: Arc<Shared>,
    done: Arc<MessageQueue<MoveDone>>,
    resume: MailboxWriter<MotionState>,
    stopper: VelocityGenerator,
    last: MotionState,
    ticket: u32,
    epoch_seen: u32,
    stopping: bool,
    /// What the stop under way was asked for (decides the report: held or stopped).
    stop_kind: StopKind,
    /// The first braking period of the stop under way is not pushed yet (its push time is
    /// the benchmark's "first decelerating pulse").
    decel_pending: bool,
    pending: Option<Batch>,
    fifo_depth: usize,
    /// Periods kept queued ahead of the board while moving (the look-ahead); at rest none
    /// after [`REST_ZEROS`].
    lead: usize,
    /// Zero periods pushed since the last period that moved an axis.
    zeros_pushed: usize,
    /// The brake's first periods, computed before a flush is asked (capacity
    /// [`HISTORY`], reserved at start-up: the cycle does not allocate).
    first_pulses: Vec<[i64; MAX_AXES]>,
    /// The generator's state after each of them (same capacity).
    first_after: Vec<MotionState>,
    /// The FIFO had been filled to its lead since the last stop or start: the levels seen
    /// count for the deepest drain.
    streaming: bool,
    /// A move (completed, or stopped or held by a brake) reported once the board has
    /// executed its last period and its motors have settled: (ticket, outcome, periods to
    /// wait).
    completing: Option<(u32, MoveOutcome, usize)>,
    /// The stop epoch is at rest once the move `completing` ends (a stop's brake, or a
    /// move whose end the board was still executing when the stop came): `stopped_epoch`
    /// is published then, not before.
    epoch_pending: bool,
    feedback: Feedback,
    history: History,
    /// The brake pushed before a flush ended the stop (reported by the next cycle's loop).
    brake_end: Option<Status>,
    /// The trace recorder's tap: one sample per period.
    trace: Option<(SampleTap, Sample)>,
    /// The boards' heartbeats, when watched.
    liveness: Option<Liveness>,
    /// A board stopped answering: nothing is pushed until a RESET re-attaches.
    detached: bool,
    /// The E-stop input is open and its stop asked for ([`PulseGenerator::watch_estop`]).
    estop_seen: bool,
    /// The board(s) take a stop word directly from whoever asks for a stop
    /// ([`Shared::set_stop_line`]): a stop this task cannot answer with its brake in time
    /// is braked by the board.
    board_stops: bool,
    /// The board braked on its own: nothing is pushed until it is at rest, its position
    /// taken and it is released.
    board_braked: bool,
    /// Some axis decelerates in a brake of its board's own
    /// ([`wrc_board::BoardStop::braking`]), read once a cycle (and again where the cycle
    /// reads the board's stop words anyway) for [`PulseGenerator::publish_in_flight`].
    board_braking: bool,
    /// Periodic cycles run (wrapping), for the run-dry diagnosis.
    periods: u32,
    /// `periods` when the current move's first period was pushed.
    move_started: u32,
    /// `periods` at the last flush.
    flushed_at: Option<u32>,
    /// This cycle's wake-up lateness [µs] (0 when stepped by hand).
    late_us: u32,
}

impl<B: MotionBoard> PulseGenerator<B> {
    /// A Pulse Generator on `board`, whose state starts as `generator`'s (idle at the
    /// board's position).
    pub fn new(
        board: B,
        ring: SpscReceiver<Batch>,
        shared: Arc<Shared>,
        done: Arc<MessageQueue<MoveDone>>,
        resume: MailboxWriter<MotionState>,
        generator: VelocityGenerator,
    ) -> Self {
        let fifo_depth = board.fifo_free();
        let last = generator.state();
        let epoch_seen = shared.stop_epoch.load(Ordering::Acquire);
        PulseGenerator {
            board,
            ring,
            shared,
            done,
            resume,
            stopper: generator,
            last,
            ticket: 0,
            epoch_seen,
            stopping: false,
            stop_kind: StopKind::Stop,
            decel_pending: false,
            pending: None,
            fifo_depth,
            lead: FIFO_LEAD.min(fifo_depth.saturating_sub(1)).max(1),
            // At rest from the start: no motion to end with a zero period.
            zeros_pushed: REST_ZEROS,
            first_pulses: Vec::with_capacity(HISTORY),
            first_after: Vec::with_capacity(HISTORY),
            streaming: false,
            completing: None,
            epoch_pending: false,
            feedback: Feedback::default(),
            history: History::new(last),
            brake_end: None,
            trace: None,
            liveness: None,
            detached: false,
            estop_seen: false,
            board_stops: false,
            board_braked: false,
            board_braking: false,
            periods: 0,
            move_started: 0,
            flushed_at: None,
            late_us: 0,
        }
    }

    /// Keep `periods` queued in the board FIFO ahead of the board (at least 1, and less than
    /// the FIFO's depth): `[motion] lookahead_ms` over the period.
    pub fn with_lookahead(mut self, periods: usize) -> Self {
        self.lead = periods.min(self.fifo_depth.saturating_sub(1)).max(1);
        self.shared
            .fifo
            .lookahead
            .store(self.lead as u32, Ordering::Relaxed);
        self
    }

    /// The board(s) take stops directly (their stop line is set on the shared state): when
    /// this task cannot flush its brake to the board, the board brakes on its own and this
    /// task waits for it instead of braking behind the queued periods.
    pub fn with_board_stops(mut self) -> Self {
        self.board_stops = true;
        self
    }

    /// Watch every board's heartbeat each period ([`Liveness`]).
    pub fn with_liveness(mut self, liveness: Liveness) -> Self {
        self.liveness = Some(liveness);
        self
    }

    /// This period's heartbeat check: publishes whether a board is dead, and on the first
    /// period it is, detaches (fatal error 300 on the urgent path, the motion ended where
    /// it stands).
    fn watch_boards(&mut self) {
        let Some(liveness) = self.liveness.as_mut() else {
            return;
        };
        let dead = liveness.dead(&self.board);
        let newly_dead = dead && !self.detached && !self.shared.board_dead.load(Ordering::Acquire);
        self.shared.board_dead.store(dead, Ordering::Release);
        if newly_dead {
            // Its inputs are stale from now on.
            self.shared.io_ready.store(false, Ordering::Release);
            liveness.unreported = true;
        }
        liveness.report();
        if newly_dead {
            self.detach();
        }
    }

    /// The E-stop input, looked at every cycle: when it opens, the stop is asked for here, an
    /// ESTOP, so that this cycle flushes the brake along the path within the board's grace
    /// (docs/dpram.md, "Stops" 6; Error Check, at its slower period, would come
    /// after the board has braked each axis on its own, off the path), and reported (202)
    /// on the urgent path unless Error Check has already.
    fn watch_estop(&mut self, open: bool) {
        let reported = &self.shared.estop_reported;
        if !open {
            self.estop_seen = false;
            if reported.load(Ordering::Acquire) {
                reported.store(false, Ordering::Release);
            }
            return;
        }
        if self.estop_seen || self.detached {
            return;
        }
        self.estop_seen = true;
        self.shared.request_stop(StopKind::Estop);
        if let Some(l) = self.liveness.as_ref() {
            // A full urgent queue leaves the report to Error Check's next period.
            if !reported.swap(true, Ordering::AcqRel) && !l.raise(Code::EstopInput) {
                reported.store(false, Ordering::Release);
            }
        }
    }

    /// Stop pushing to a board that does not answer, and end the motion where it stands:
    /// the queued plan and any brake are dropped, the generator rests at the last position
    /// the board reported (or the last one pushed), and a waiting stop is at rest at once.
    /// The moves in flight end with the fault (the Command Interpreter aborts them).
    fn detach(&mut self) {
        self.detached = true;
        self.board_braked = false;
        self.streaming = false;
        self.pending = None;
        while self.ring.try_recv().is_some() {}
        self.stopping = false;
        self.decel_pending = false;
        self.completing = None;
        self.brake_end = None;
        self.ticket = 0;
        let mut position = self.shared.commanded_pulses();
        if self.board.read_feedback(&mut self.feedback).is_ok() {
            let n = self.feedback.axis_count.min(MAX_AXES);
            for (p, a) in position.iter_mut().zip(&self.feedback.axes[..n]) {
                *p = a.encoder;
            }
        }
        self.rest_at(&position);
        self.resume.write(self.last);
        self.settle_pending_epoch();
        self.publish_in_flight();
    }

    /// Abandon the plan and rest at `position` [pulse], the board's (what it executed is
    /// the truth): the generator's state and the commanded position the tasks share.
    fn rest_at(&mut self, position: &[i64; MAX_AXES]) {
        self.stopper.restore(&self.last);
        self.stopper.abandon_at(position);
        self.last = self.stopper.state();
        // The board stands still there: no motion of this task's to end.
        self.zeros_pushed = REST_ZEROS;
        for (c, p) in self.shared.commanded.iter().zip(position) {
            c.store(*p, Ordering::Release);
        }
    }

    /// The stop epoch waiting for the move `completing` to end is at rest now.
    fn settle_pending_epoch(&mut self) {
        if std::mem::take(&mut self.epoch_pending) {
            self.shared
                .stopped_epoch
                .store(self.epoch_seen, Ordering::Release);
        }
    }

    /// Record one sample per period into `tap` (commanded and encoder pulses, I/O, state,
    /// FIFO level, wake-up latency, the previous cycle's execution time).
    pub fn with_trace(mut self, tap: SampleTap) -> Self {
        self.trace = Some((tap, Sample::default()));
        self
    }

    /// This period's sample, at the grid point `ctx.scheduled_ns`: how late the cycle woke,
    /// and how long the previous one ran.
    fn record(&mut self, ctx: &CycleContext) {
        let Some((tap, sample)) = self.trace.as_mut() else {
            return;
        };
        let clamp = |ns: u64| ns.min(u64::from(u32::MAX)) as u32;
        sample.t_ns = ctx.scheduled_ns;
        sample.latency_ns = clamp(ctx.woke_ns.saturating_sub(ctx.scheduled_ns));
        sample.exec_ns = clamp(ctx.previous_exec_ns);
        // The commanded position is the board's (what it has executed), not the one pushed
        // a look-ahead ahead of it: the trace shows the motor's command at that moment. A
        // torn read keeps the previous period's positions.
        if self.board.read_feedback(&mut self.feedback).is_ok() {
            let n = self.feedback.axis_count.min(MAX_AXES);
            for ((c, a), f) in sample
                .commanded
                .iter_mut()
                .zip(sample.actual.iter_mut())
                .zip(&self.feedback.axes[..n])
            {
                *c = f.commanded;
                *a = f.encoder;
            }
            sample.fifo_level = self.feedback.axes[0].fifo_level.min(u32::from(u16::MAX)) as u16;
        }
        crate::recorder::shared_part(sample, &self.shared);
        tap.push(sample);
    }

    fn queued(&self) -> usize {
        self.fifo_depth.saturating_sub(self.board.fifo_free())
    }

    /// Push one period whose generator state after it is `after`.
    fn emit(&mut self, pulses: &[i64; MAX_AXES], after: &MotionState) -> bool {
        if self.board.push(pulses).is_err() {
            return false;
        }
        self.pushed(pulses, after);
        true
    }

    /// A period is queued (pushed, or queued by a flush): its record and commanded pulses.
    fn pushed(&mut self, pulses: &[i64; MAX_AXES], after: &MotionState) {
        self.zeros_pushed = if pulses.iter().all(|p| *p == 0) {
            self.zeros_pushed.saturating_add(1)
        } else {
            0
        };
        self.history.push(pulses, after);
        for (c, p) in self.shared.commanded.iter().zip(pulses) {
            if *p != 0 {
                c.fetch_add(*p, Ordering::AcqRel);
            }
        }
    }

    /// Start the brake from the state after the last period the board executed, and ask
    /// the board to skip the periods queued after it: the brake's first periods are
    /// computed first, then queued by the flush itself, right behind the skipped ones (the
    /// board publishes them as it takes the flush: however late this task runs on, the
    /// board's next period finds them), or the flush is refused if a board period began
    /// meanwhile (then try again from the period reached by then). True when the board will
    /// skip them (the brake is under way: `stopper`, `last`); false when it cannot flush
    /// (several boards, a flush pending, the state before the queued periods forgotten, no
    /// room): the caller brakes from the last pushed period, behind the queue.
    fn flush_brake(&mut self, limits: BrakeLimits) -> bool {
        for _ in 0..FLUSH_TRIES {
            let Some(at) = self.fifo_position() else {
                break;
            };
            // Read after the flush word: a board that has not braked on its own by now
            // cannot before it takes the flush (the swap below fails if a period began).
            if self.board.board_stop().braking_own {
                break;
            }
            let queued = at.write.wrapping_sub(at.read) as usize;
            let room = self.board.fifo_free().min(self.lead);
            let Some(before) = self.history.before(queued).copied() else {
                break;
            };
            if room == 0 {
                break;
            }
            self.stopper.restore(&before);
            self.stopper.stop(limits);
            // The brake's first periods, as many as the lead keeps queued.
            self.first_pulses.clear();
            self.first_after.clear();
            let mut end = None;
            let mut period = Period::default();
            while self.first_pulses.len() < room && end.is_none() {
                let status = self.stopper.next_period(&mut period);
                self.first_pulses.push(period.pulses);
                self.first_after.push(self.stopper.state());
                if !matches!(status, Status::Working) {
                    end = Some(status);
                }
            }
            if !self.board.flush_queued(&at, at.write, &self.first_pulses) {
                continue; // a board period began: it executed another queued period
            }
            // The board skips the `queued` periods from its next one on.
            let skipped = self.history.newest_pulses(queued);
            for (c, p) in self.shared.commanded.iter().zip(skipped) {
                if p != 0 {
                    c.fetch_sub(p, Ordering::AcqRel);
                }
            }
            self.history.drop_newest(queued);
            for i in 0..self.first_pulses.len() {
                let (pulses, after) = (self.first_pulses[i], self.first_after[i]);
                self.pushed(&pulses, &after);
            }
            self.last = self.first_after[self.first_after.len() - 1];
            self.brake_end = end;
            self.flushed_at = Some(self.periods);
            return true;
        }
        false
    }

    /// The board's FIFO position, waiting out a board period under way (microseconds).
    fn fifo_position(&self) -> Option<FifoPosition> {
        for _ in 0..POSITION_POLLS {
            if let Some(at) = self.board.fifo_position() {
                return Some(at);
            }
            std::hint::spin_loop();
        }
        None
    }

    fn report(&self, ticket: u32, outcome: MoveOutcome) {
        if ticket != 0 {
            // The queue is sized for every ticket in flight; a full queue only loses a reply.
            let _ = self.done.try_send(MoveDone { ticket, outcome });
        }
    }

    /// One period (public for tests that step the task by hand).
    pub fn step(&mut self) {
        self.step_released(Release::Period);
    }

    /// One cycle, released by the period or by a stop request (`Release::Event`): a stop
    /// starts its brake at once and pushes its first braking period even when the FIFO
    /// already holds its lead, so it follows the periods already queued without waiting
    /// for the next period of this task.
    pub fn step_released(&mut self, release: Release) {
        self.board.refresh_watchdog();
        let board_stop = self.board.board_stop();
        self.board_braking = board_stop.braking;
        if release == Release::Period {
            self.periods = self.periods.wrapping_add(1);
            self.watch_boards();
            self.watch_fifo();
        }
        self.watch_estop(board_stop.estop);
        let mut braking_now = false;
        let epoch = self.shared.stop_epoch.load(Ordering::Acquire);
        if epoch != self.epoch_seen {
            self.epoch_seen = epoch;
            self.streaming = false;
            let kind = self.shared.take_stop_kind();
            self.pending = None;
            while self.ring.try_recv().is_some() {}
            if self.detached {
                // Nothing moves through a board that does not answer: at rest at once. A
                // RESET (which asks for the board's position) re-attaches a board that
                // answers again.
                let reattach = !self.shared.board_dead.load(Ordering::Acquire)
                    && self.shared.resync_from_board.load(Ordering::Acquire);
                if reattach {
                    self.detached = false;
                    self.history.restart(self.last);
                }
            }
            if self.detached {
                self.resume.write(self.last);
                self.shared.stopped_epoch.store(epoch, Ordering::Release);
            } else if self.board_braked {
                // The board brakes on its own (or is about to, for an earlier stop it found
                // unanswered): it takes this stop word too, a stronger one by braking again.
                // No flush now: one would answer this word and leave the board's brake to
                // be waited for in vain.
                if kind as u8 > self.stop_kind as u8 {
                    self.stop_kind = kind;
                }
            } else if self.last.is_moving() || self.tail_moving() {
                if !self.last.is_moving() {
                    // The move's last period is pushed but the board still executes its
                    // motion (up to the look-ahead): the stop ends that move, from the
                    // period the board has reached, like any other.
                    if let Some((ticket, _, _)) = self.completing.take() {
                        self.ticket = ticket;
                    }
                }
                // From the state of the period the board has reached (mid-brake too, when a
                // stronger stop overtakes a HOLD or a STOP): ESTOP brakes with the full
                // limits.
                let limits = match kind {
                    StopKind::Estop => BrakeLimits::Full,
                    StopKind::Hold | StopKind::Stop => BrakeLimits::Override,
                };
                self.stop_kind = kind;
                self.stopping = true;
                self.decel_pending = true;
                braking_now = true;
                if self.flush_brake(limits) {
                    self.shared.stops.flushed.fetch_add(1, Ordering::Relaxed);
                    self.decel_pushed();
                    if let Some(status) = self.brake_end.take() {
                        self.brake_finished(status);
                    }
                } else if self.board_stops {
                    // The board brakes on its own, a board period after it saw the stop
                    // word: wait for it instead of braking behind the queued periods.
                    self.enter_board_braked();
                } else {
                    self.brake_behind_queue();
                }
            } else {
                if self.board_stops {
                    self.answer_stop_at_rest();
                }
                // At rest: take the board's own position (after a RESET the board may have
                // stopped by itself, e.g. on a watchdog trip or E-stop).
                let resync = self.shared.resync_from_board.swap(false, Ordering::AcqRel);
                if resync && self.board.read_feedback(&mut self.feedback).is_ok() {
                    let mut position = [0i64; MAX_AXES];
                    for (i, p) in position
                        .iter_mut()
                        .enumerate()
                        .take(self.feedback.axis_count)
                    {
                        *p = self.feedback.axes[i].commanded;
                    }
                    self.stopper.restore(&self.last);
                    if self.stopper.set_position_pulses(&position).is_ok() {
                        self.last = self.stopper.state();
                        for (c, p) in self.shared.commanded.iter().zip(position) {
                            c.store(p, Ordering::Release);
                        }
                    }
                }
                self.resume.write(self.last);
                if self.completing.is_some() {
                    self.epoch_pending = true;
                } else {
                    self.shared.stopped_epoch.store(epoch, Ordering::Release);
                }
            }
        }
        if self.board_stops
            && !self.detached
            && !self.board_braked
            && self.board.board_stop().braking_own
        {
            // A stop on its way (its word posted, its epoch not yet moved or taken: the
            // thread that asked may be preempted between the two for longer than a board
            // period) is a stop that was asked for. Otherwise the board ran out of periods
            // while moving (a stall longer than the look-ahead) and braked: a motion fault.
            let asked = self.shared.stop_requests.load(Ordering::Acquire) != self.epoch_seen;
            if !asked && (self.last.is_moving() || self.completing.is_some()) {
                let fifo = &self.shared.fifo;
                let since = |at: u32| self.periods.wrapping_sub(at);
                fifo.dry_after_start
                    .store(since(self.move_started), Ordering::Relaxed);
                fifo.dry_after_flush
                    .store(self.flushed_at.map_or(u32::MAX, since), Ordering::Relaxed);
                if let Some(l) = self.liveness.as_ref() {
                    l.raise(Code::MotionFault);
                }
            }
            // Its kind is the epoch's, taken when the epoch comes.
            self.stop_kind = StopKind::Hold;
            self.enter_board_braked();
        }
        if self.board_braked && self.await_board_brake() {
            return;
        }
        let lead = if braking_now && release == Release::Event {
            self.lead + 1
        } else {
            self.lead
        };
        if release == Release::Event && !braking_now {
            return; // nothing to do between periods but a new stop
        }
        if self.detached {
            // Nothing goes to a board that does not answer, and nothing waits for it: a
            // period the Velocity Generator pushed after the stop was taken (its cycle began
            // before it) is dropped here, or it would count as motion in flight for ever
            // and no RESET could re-attach the board.
            self.pending = None;
            while self.ring.try_recv().is_some() {}
            self.publish_in_flight();
            return;
        }
        let mut period = Period::default();
        while self.queued() < lead {
            if self.stopping {
                let status = self.stopper.next_period(&mut period);
                let after = self.stopper.state();
                if !self.emit(&period.pulses, &after) {
                    break;
                }
                self.decel_pushed();
                self.last = after;
                if !matches!(status, Status::Working) {
                    self.brake_finished(status);
                }
                continue;
            }
            if self.start_waits() {
                // The motion before ends with its zero period first (its last increment
                // may not be zero: a board that ran out of periods after it would count
                // a moving axis run dry).
                if self.zeros_pushed < REST_ZEROS {
                    if self.push_rest_zero() {
                        continue;
                    }
                } else {
                    // That motion has ended: the FIFO drains its tail while the plan comes,
                    // which is no drain of a look-ahead.
                    self.streaming = false;
                }
                break;
            }
            let batch = match self.pending.take().or_else(|| self.ring.try_recv()) {
                Some(b) if b.epoch == self.epoch_seen => b,
                Some(_) => continue,
                None if self.last.is_moving() => {
                    // The plan is not in the ring yet: the Velocity Generator is still
                    // filling it (a move's start: it may run beside this task) or is late.
                    // What is queued runs on, and the FIFO is topped up when the plan
                    // comes; a zero period inside a motion would stop the axes in one
                    // period. (A plan later than the look-ahead runs the FIFO dry: the
                    // board brakes, 209.)
                    break;
                }
                None if self.zeros_pushed >= REST_ZEROS => {
                    // At rest, the motion's end followed by a zero period: nothing more
                    // is queued, so that the next move starts at once; and no longer a
                    // look-ahead whose levels count for the deepest drain.
                    self.streaming = false;
                    break;
                }
                None => {
                    if !self.push_rest_zero() {
                        break;
                    }
                    continue;
                }
            };
            if !self.emit(&batch.pulses, &batch.after) {
                self.pending = Some(batch);
                break;
            }
            self.last = batch.after;
            if batch.after.entry_committed() {
                self.shared
                    .entry_committed
                    .store(batch.ticket, Ordering::Release);
            }
            if batch.ticket != self.ticket {
                self.move_started = self.periods;
                self.shared
                    .first_pulse_ns
                    .store(Shared::now_ns(), Ordering::Release);
            }
            self.ticket = batch.ticket;
            if batch.last {
                self.complete(batch.ticket, MoveOutcome::Completed);
                self.ticket = 0;
            }
        }
        if release == Release::Period && !self.stopping {
            self.streaming |= self.queued() >= self.lead;
        }
        if let Some((ticket, outcome, left)) = self.completing {
            // Executed by the board; then in position (every encoder on its commanded
            // count) unless another move follows at once, or the settling time is over.
            let executed = left <= IN_POSITION_PERIODS + 1;
            let next_move = self.last.is_moving() || !self.ring.is_empty();
            if executed && (left <= 1 || next_move || self.in_position()) {
                self.completing = None;
                // At rest before the end is reported: whoever hears of it sees no motion.
                self.settle_pending_epoch();
                self.publish_in_flight();
                self.report(ticket, outcome);
            } else {
                self.completing = Some((ticket, outcome, left - 1));
            }
        }
        self.publish_in_flight();
    }

    /// Push the zero period that ends a motion (false: the FIFO is full).
    fn push_rest_zero(&mut self) -> bool {
        let after = self.last;
        self.emit(&[0; MAX_AXES], &after)
    }

    /// A move's start (nothing moving queued after the periods in the FIFO) while the
    /// Velocity Generator is still producing it: with fewer periods than the look-ahead
    /// at hand, queuing them now would let a stall of this task right after run the board
    /// dry mid-start (the board brakes, 209); waiting one period for the rest costs nothing
    /// at rest. A short move whose whole plan is in the ring starts at once.
    fn start_waits(&self) -> bool {
        if self.last.is_moving() || self.pending.is_some() {
            return false;
        }
        // The ring first: a batch seen there shows the flag set before it (or cleared
        // after the last one).
        let at_hand = self.queued() + self.ring.len();
        at_hand < self.lead && self.shared.vg_filling.load(Ordering::Acquire)
    }

    /// The last period pushed is at rest, but the board still has periods of a motion to
    /// execute (the end of a move, queued up to the look-ahead ahead of it).
    fn tail_moving(&self) -> bool {
        self.completing.is_some()
            && self
                .history
                .before(self.queued())
                .is_some_and(|s| s.is_moving())
    }

    /// Answer a stop that found the robot at rest (no brake to push) so the board does not
    /// brake on its own: a flush that skips nothing. If it cannot be asked now (a flush
    /// pending), the board brakes on its own at rest and [`PulseGenerator::await_board_brake`]
    /// takes it from there.
    fn answer_stop_at_rest(&mut self) {
        if let Some(at) = self.fifo_position() {
            if !self.board.board_stop().braking_own {
                let _ = self.board.flush_queued(&at, at.read, &[]);
            }
        }
    }

    /// The board brakes on its own: push nothing until it is at rest.
    fn enter_board_braked(&mut self) {
        self.board_braked = true;
        self.stopping = false;
        self.decel_pending = false;
        self.brake_end = None;
        self.streaming = false;
        self.pending = None;
        while self.ring.try_recv().is_some() {}
        self.shared.fifo.board_stops.fetch_add(1, Ordering::Relaxed);
        self.publish_in_flight();
    }

    /// The brake of the stop under way (`stop_kind`), behind the queued periods, from the
    /// last one pushed.
    fn brake_behind_queue(&mut self) {
        self.shared
            .stops
            .behind_queue
            .fetch_add(1, Ordering::Relaxed);
        let limits = match self.stop_kind {
            StopKind::Estop => BrakeLimits::Full,
            StopKind::Hold | StopKind::Stop => BrakeLimits::Override,
        };
        self.stopper.restore(&self.last);
        self.stopper.stop(limits);
        self.stopping = true;
    }

    /// While the board brakes on its own: once every such board is at rest, take its
    /// position (what it executed is the truth; the periods it skipped never ran), release
    /// it, and end the move stopped (a HOLD too: off its planned path, it cannot resume) and
    /// the stop epoch at rest. True while this period has nothing more to do; false when
    /// no board will brake on its own after all (the stop was answered otherwise: a flush
    /// armed for an earlier stop carried it, or the board took it at a RESET): then the
    /// brake is this task's again, behind the queued periods.
    fn await_board_brake(&mut self) -> bool {
        self.pending = None;
        while self.ring.try_recv().is_some() {}
        let stop = self.board.board_stop();
        self.board_braking = stop.braking;
        if stop.answered {
            self.board_braked = false;
            self.brake_behind_queue();
            return false;
        }
        if !stop.settled || self.board.read_feedback(&mut self.feedback).is_err() {
            self.publish_in_flight();
            return true;
        }
        let mut position = self.shared.commanded_pulses();
        let n = self.feedback.axis_count.min(MAX_AXES);
        for (p, a) in position.iter_mut().zip(&self.feedback.axes[..n]) {
            *p = a.commanded;
        }
        self.rest_at(&position);
        self.history.restart(self.last);
        self.board.release_stop();
        self.board_braked = false;
        if let Some((ticket, _, _)) = self.completing.take() {
            self.report(ticket, MoveOutcome::Stopped);
        }
        let ticket = std::mem::take(&mut self.ticket);
        self.report(ticket, MoveOutcome::Stopped);
        self.resume.write(self.last);
        self.epoch_pending = false;
        self.shared
            .stopped_epoch
            .store(self.epoch_seen, Ordering::Release);
        self.publish_in_flight();
        true
    }

    /// This period's look at the FIFO before it is refilled (the deepest drain while
    /// streaming) and at the boards' counters, for `TASKS`.
    fn watch_fifo(&mut self) {
        let stats = &self.shared.fifo;
        if self.streaming && !self.detached {
            let level = self.queued() as u32;
            if stats.min_level.fetch_min(level, Ordering::Relaxed) > level {
                // The deepest drain's circumstances: this task late, or the plan.
                stats.min_late_us.store(self.late_us, Ordering::Relaxed);
                stats
                    .min_ring
                    .store(self.ring.len() as u32, Ordering::Relaxed);
                stats.min_after_start.store(
                    self.periods.wrapping_sub(self.move_started),
                    Ordering::Relaxed,
                );
                stats
                    .min_moving
                    .store(u32::from(self.last.is_moving()), Ordering::Relaxed);
            }
        }
        if self.board.read_feedback(&mut self.feedback).is_ok() {
            let boards = &self.feedback.boards[..self.feedback.board_count];
            stats
                .underruns
                .store(self.feedback.underruns(), Ordering::Relaxed);
            let sum = |f: fn(&wrc_board::BoardFeedback) -> u32| {
                boards.iter().map(|b| u64::from(f(b))).sum::<u64>()
            };
            stats
                .watchdog_trips
                .store(sum(|b| b.watchdog_trips), Ordering::Relaxed);
            stats
                .board_late
                .store(sum(|b| b.late_periods), Ordering::Relaxed);
        }
    }

    /// The first braking period of the stop under way was pushed (the benchmark's "first
    /// decelerating pulse").
    fn decel_pushed(&mut self) {
        if self.decel_pending {
            self.decel_pending = false;
            self.shared
                .decel_ns
                .store(Shared::now_ns(), Ordering::Release);
        }
    }

    /// The last period of move `ticket` was pushed: it ends with `outcome` once the board
    /// has executed it (the periods queued now, itself included) and its motors have
    /// settled ([`IN_POSITION_PERIODS`] at most). A move still completing ends now (the
    /// board executes in order).
    fn complete(&mut self, ticket: u32, outcome: MoveOutcome) {
        if let Some((ticket, outcome, _)) = self.completing.take() {
            self.report(ticket, outcome);
        }
        let queued = self.queued().max(1);
        self.completing = Some((ticket, outcome, queued + 1 + IN_POSITION_PERIODS));
    }

    /// The brake's last period was pushed: the move ends held, stopped or (a brake that
    /// ended on the target) completed by the rule a completed move ends by, and the stop
    /// epoch is at rest then ([`PulseGenerator::complete`]).
    fn brake_finished(&mut self, status: Status) {
        self.stopping = false;
        let outcome = match (status, self.stop_kind) {
            // The brake ended on the target (it was decelerating to it anyway).
            (Status::Finished(MoveEnd::Completed), _) => MoveOutcome::Completed,
            (_, StopKind::Hold) => MoveOutcome::Held,
            (_, StopKind::Stop | StopKind::Estop) => MoveOutcome::Stopped,
        };
        self.complete(self.ticket, outcome);
        self.epoch_pending = true;
        self.ticket = 0;
        self.resume.write(self.last);
    }

    /// Every axis's encoder on its commanded count (a torn read counts as not yet).
    fn in_position(&mut self) -> bool {
        if self.board.read_feedback(&mut self.feedback).is_err() {
            return false;
        }
        let n = self.feedback.axis_count;
        self.feedback.axes[..n]
            .iter()
            .all(|a| a.encoder == a.commanded)
    }

    /// Whether pulses are still in flight (a brake, a move, the ring, a move the board has
    /// not finished executing, a brake of the board's own), for the other tasks.
    fn publish_in_flight(&self) {
        let moving = self.stopping
            || self.board_braked
            || self.last.is_moving()
            || !self.ring.is_empty()
            || self.completing.is_some()
            || (!self.detached && self.board_braking);
        self.shared
            .in_flight
            .store(u32::from(moving), Ordering::Release);
    }
}

impl<B: MotionBoard + 'static> Task for PulseGenerator<B> {
    fn cycle(&mut self, ctx: &CycleContext) {
        let late_ns = ctx.woke_ns.saturating_sub(ctx.scheduled_ns);
        self.late_us = u32::try_from(late_ns / 1_000).unwrap_or(u32::MAX);
        self.step_released(ctx.release);
        if ctx.release == Release::Period {
            self.record(ctx);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dead board's fault is not lost when the urgent queue is full (a burst of STOP and
    /// ESTOP lines): it is retried every period until it is on the queue, then sent once.
    #[test]
    fn a_dead_boards_fault_waits_for_room_on_a_full_urgent_queue() {
        let urgent = Arc::new(MessageQueue::new(1));
        let wake = Arc::new(Semaphore::new(0));
        let mut liveness = Liveness::new(3, 10_000, 10_000, urgent.clone(), wake.clone());
        let stop = Urgent::Stop(
            crate::messages::SourceId::NONE,
            wrc_protocol::ReplyTo::default(),
        );
        assert!(urgent.try_send(stop).is_ok());
        liveness.unreported = true;
        for _ in 0..3 {
            liveness.report();
            assert!(liveness.unreported, "reported into a full queue");
        }
        assert!(matches!(urgent.try_recv(), Ok(Urgent::Stop(..))));
        liveness.report();
        assert!(!liveness.unreported);
        assert!(matches!(urgent.try_recv(), Ok(Urgent::Fault(300))));
        assert!(wake.try_wait(), "the urgent path was not woken");
        liveness.report();
        assert!(urgent.try_recv().is_err(), "the fault was sent twice");
    }
}
