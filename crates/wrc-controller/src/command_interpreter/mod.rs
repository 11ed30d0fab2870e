//! Command Interpreter task (Table 1: priority 40, 50 ms): merges the commands of every
//! source (Ethernet hosts, the local GUI, the RS232C pendant), enforces the control lock,
//! validates every motion before accepting it (NAK and nothing moves), hands moves to the
//! Velocity Generator, and answers in three phases (ACK, then INF or ABS).
//!
//! Emergencies first: STOP, ESTOP and Error Check's faults arrive on an urgent queue with a
//! semaphore. A dedicated thread ([`UrgentPath`]) blocks on that semaphore and requests the
//! stop the moment it is posted, so deceleration starts at the Pulse Generator's next
//! period instead of after this task's 50 ms period; the bookkeeping (replies, state) follows
//! in the next cycle.
//!
//! Real-time promise: the cycle does not allocate (fixed tables, fixed reply buffers), does
//! not block and does not print.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use wrc_board::MotionBoard;
use wrc_lang::{Program, Vm, VmLimits};
use wrc_protocol::{Code, Event, ReplyBuf, ReplyTo};
use wrc_robot::{Joints, Robot};
use wrc_rt::ipc::MessageQueue;
use wrc_rt::{CycleContext, Release, Task};

mod admission;
mod blend;
pub mod clearance;
mod debug;
mod guard;
mod job;
mod motion;
mod program;
mod requests;
mod reset;
mod urgent;

pub use urgent::UrgentPath;

use crate::messages::{
    Incoming, MoveDone, MoveOrder, OutLine, Outputs, SourceId, StoreLinks, Urgent,
};
use crate::shared::{RobotState, Shared};
use motion::Ticket;
use program::RunningProgram;
use requests::Refusal;

/// Motions accepted but not finished, at most.
pub const MAX_TICKETS: usize = 32;
/// Clients waiting on WAIT, at most.
pub const MAX_WAITERS: usize = 64;
/// Robot-language instructions a running program may execute per cycle between two of its
/// requests.
pub const PROGRAM_BUDGET: u32 = 2_000;
/// Requests carried out at once (PRINT, OUT, SPEED) a program may make per cycle.
pub const PROGRAM_REQUESTS: u32 = 16;
/// How long a RESET may wait for the board to clear its faults before it is refused [ns].
pub const RESET_TIMEOUT_NS: u64 = 1_000_000_000;
/// How long a RESET sent while a stop still brakes waits for the arm to stand still before
/// it is refused [ns]: far longer than any brake (an ESTOP's at full limits takes well under
/// a second), short enough that an operator is not left without an answer.
pub const RESET_REST_TIMEOUT_NS: u64 = 5_000_000_000;

/// Send `line` to `to`; replies to the running program need not be sent (its refusals are
/// recorded by [`CommandInterpreter::nak`]).
fn deliver(out: &Outputs, to: SourceId, line: &[u8]) {
    // A program's and a job's own motions are answered to themselves, not on the wire.
    if to != SourceId::PROGRAM && to != SourceId::CELL {
        out.send(to, line);
    }
}

/// The queues a Command Interpreter talks through.
pub struct CommandLinks {
    /// Requests and disconnections from the Ethernet and RS232C tasks.
    pub incoming: Arc<MessageQueue<Incoming>>,
    /// Emergencies as the receiving tasks sent them: one this task takes off first (before
    /// the [`UrgentPath`] thread) has its stop requested here.
    pub urgent: Arc<MessageQueue<Urgent>>,
    /// Emergencies the [`UrgentPath`] thread has already stopped for.
    pub forwarded: Arc<MessageQueue<Urgent>>,
    /// Move orders for the Velocity Generator.
    pub orders: Arc<MessageQueue<MoveOrder>>,
    /// Ends of moves, from the Velocity and Pulse Generators.
    pub done: Arc<MessageQueue<MoveDone>>,
    /// Where replies and events go.
    pub out: Outputs,
    /// Set when the controlling client went away during a motion (Error Check stops).
    pub owner_lost: Arc<AtomicBool>,
    /// The queues to and from the service thread (programs, wafer jobs).
    pub store: StoreLinks,
}

impl CommandLinks {
    /// Links on these queues, with fresh ones for the rest (the urgent and forwarded
    /// emergencies, the serial line's output, the owner-lost flag, the service's links):
    /// one Command Interpreter wired on its own, as a test or a tool does. Override a field
    /// with `CommandLinks { urgent, ..CommandLinks::new(…) }`.
    pub fn new(
        incoming: Arc<MessageQueue<Incoming>>,
        orders: Arc<MessageQueue<MoveOrder>>,
        done: Arc<MessageQueue<MoveDone>>,
        network: Arc<MessageQueue<OutLine>>,
    ) -> CommandLinks {
        CommandLinks {
            incoming,
            urgent: Arc::new(MessageQueue::new(16)),
            forwarded: Arc::new(MessageQueue::new(16)),
            orders,
            done,
            out: Outputs {
                network,
                serial: Arc::new(MessageQueue::new(256)),
            },
            owner_lost: Arc::new(AtomicBool::new(false)),
            store: StoreLinks::new(),
        }
    }
}

/// The Command Interpreter.
pub struct CommandInterpreter<B: MotionBoard> {
    robot: Robot,
    board: B,
    shared: Arc<Shared>,
    /// The queues it talks through.
    io: CommandLinks,
    /// Whether a HOLD is braking, or holds the motions of the open tickets.
    hold: motion::Hold,
    tickets: [Option<Ticket>; MAX_TICKETS],
    waiters: [Option<motion::Waiter>; MAX_WAITERS],
    next_ticket: u32,
    /// Joints where the last accepted move ends (validation reference).
    planned_end: Joints,
    buf: ReplyBuf,
    feedback: wrc_board::Feedback,
    /// A RESET not answered yet: waiting for a stop's brake to end, or for the board to
    /// carry it out.
    reset_pending: Option<reset::PendingReset>,
    /// Input bit of the E-stop circuit (board 0), if the cell has one.
    pub estop_input: Option<u8>,
    vm: Vm,
    program: Option<RunningProgram>,
    /// When the running program started [ns] (its `TIMER()`).
    program_started_ns: u64,
    /// The options of the motion the program orders next.
    next_move: program::NextMove,
    /// The breakpoints, kept across runs.
    breaks: debug::Breakpoints,
    /// A finished program the store's queue had no room for yet (freed there, not here).
    retire: Option<Box<Program>>,
    refusal: Refusal,
    now_ns: u64,
    /// This cycle was released by the period (not by a message): counters of successive
    /// periods (the vacuum watch) advance only on these.
    periodic: bool,
    /// The hand's signals (vacuum valve and sensor, mapping sensor).
    pub hand: wrc_config::HandConfig,
    job: Option<job::RunningJob>,
    scan: wrc_board::MappingScan,
    /// Outside a job: the watch of each blade's vacuum sensor while the map has a certain
    /// wafer on it (index: [`wrc_cell::Blade::index`]).
    blade_watch: [job::BladeWatch; wrc_cell::MAX_BLADES],
    /// The outputs the configuration guards and the outputs' names (`OUT`'s 141).
    output_guard: guard::OutputGuard,
    /// The hand may be inside a station (found at start-up by the cell service): HOME and
    /// RETRACT take it straight out first.
    retract: Option<crate::messages::cell_job::RetractPlan>,
    /// The ticket of the retract under way.
    retract_ticket: Option<u32>,
    /// Every motion checked against the cell before it is accepted (none without a cell).
    cell: Option<clearance::CellCheck>,
}

impl<B: MotionBoard> CommandInterpreter<B> {
    /// A Command Interpreter for `robot` on `board`, talking through `links`.
    pub fn new(robot: Robot, board: B, shared: Arc<Shared>, links: CommandLinks) -> Self {
        let planned_end = robot.pulses_to_joints(&shared.commanded_pulses());
        CommandInterpreter {
            robot,
            board,
            shared,
            io: links,
            hold: motion::Hold::None,
            tickets: [None; MAX_TICKETS],
            waiters: [None; MAX_WAITERS],
            next_ticket: 1,
            planned_end,
            buf: ReplyBuf::new(),
            feedback: wrc_board::Feedback::default(),
            reset_pending: None,
            estop_input: None,
            vm: Vm::new(VmLimits::default()),
            program: None,
            program_started_ns: 0,
            next_move: program::NextMove::default(),
            breaks: debug::Breakpoints::default(),
            retire: None,
            refusal: Refusal {
                code: None,
                text: [0; 400],
                len: 0,
            },
            now_ns: 0,
            periodic: true,
            hand: wrc_config::HandConfig::default(),
            job: None,
            scan: wrc_board::MappingScan::default(),
            blade_watch: Default::default(),
            output_guard: guard::OutputGuard::default(),
            retract: None,
            retract_ticket: None,
            cell: None,
        }
    }

    /// Check every motion against the cell that `view` publishes (the cell service writes
    /// it), playing it on `generator`, a copy of the Velocity Generator's; `offsets` are the
    /// blades' heights above the hand's [mm], the hand's (0) first.
    pub fn with_cell_check(
        mut self,
        generator: wrc_motion::VelocityGenerator,
        view: wrc_rt::ipc::mailbox::MailboxReader<crate::messages::cell_job::CellView>,
        offsets: &[f64],
    ) -> Self {
        self.cell = Some(clearance::CellCheck::new(generator, view, offsets));
        self
    }

    /// What the cell checks have cost so far (zeros without a cell).
    pub fn check_figures(&self) -> clearance::CheckFigures {
        self.cell.as_ref().map_or_else(
            clearance::CheckFigures::default,
            clearance::CellCheck::figures,
        )
    }

    /// MOVING, STOPPING and HELD end when nothing is open, queued, in flight or stopping
    /// and the arm stands still ([`Self::stands_still`]): then the state becomes IDLE (now,
    /// before a reply that tells a client the motion ended goes out, so the client's next
    /// request sees it). Whether the robot is at rest.
    pub(super) fn settle_state(&mut self) -> bool {
        let at_rest = !self.outstanding()
            && self.job.is_none()
            && self.io.orders.is_empty()
            && self.stands_still();
        if at_rest
            && matches!(
                self.shared.state(),
                RobotState::Moving | RobotState::Stopping | RobotState::Held
            )
        {
            self.set_state(RobotState::Idle);
        }
        at_rest
    }

    /// Whether the arm stands still: the Pulse Generator has nothing in flight and is at
    /// rest in the current stop epoch. It publishes both only once the board has executed
    /// every period pushed and its encoders are on their commanded counts (or the settling
    /// time is over), after a stop's brake as after a completed move.
    pub(super) fn stands_still(&self) -> bool {
        self.shared.in_flight.load(Ordering::Acquire) == 0
            && self.shared.stopped_epoch.load(Ordering::Acquire)
                == self.shared.stop_epoch.load(Ordering::Acquire)
    }

    /// Whether the cell service has settled every job this task ended
    /// ([`Shared::map_settled`]).
    pub(super) fn map_settled(&self) -> bool {
        self.shared.map_settled()
    }

    /// The alarm's code in ERROR or ESTOP.
    fn alarm(&self) -> Option<Code> {
        match self.shared.state() {
            RobotState::Error | RobotState::Estop => Some(
                Code::from_number(self.shared.error_code.load(Ordering::Acquire) as u16)
                    .unwrap_or(Code::MotionFault),
            ),
            _ => None,
        }
    }

    pub(super) fn owner(&self) -> SourceId {
        SourceId(self.shared.owner.load(Ordering::Acquire))
    }

    pub(super) fn event(&mut self, event: &Event<'_>) {
        let line = self.buf.event(false, event);
        self.io.out.send(SourceId::BROADCAST, line);
    }

    pub(super) fn set_state(&mut self, state: RobotState) {
        if self.shared.state() != state {
            self.shared.set_state(state);
            self.event(&Event::State(state));
        }
    }

    pub(super) fn nak(&mut self, from: SourceId, to: ReplyTo, code: Code, text: &str) {
        if from == SourceId::PROGRAM || from == SourceId::CELL {
            self.refusal.record(code, text);
        } else {
            let line = self.buf.nak(to, code, text);
            self.io.out.send(from, line);
        }
    }

    /// One periodic cycle at `now_ns` (the cycle's wake-up time; public for tests that step
    /// the task by hand with their own clock).
    pub fn step(&mut self, now_ns: u64) {
        self.step_released(now_ns, true);
    }

    /// One cycle at `now_ns`, released by the period (`periodic`) or by a message: the same
    /// work, except that counts of successive periods advance only on periodic cycles.
    pub fn step_released(&mut self, now_ns: u64, periodic: bool) {
        self.now_ns = now_ns;
        self.periodic = periodic;
        // An emergency taken here before the urgent thread got to it: request its stop now
        // (exactly one stop per message, whoever takes it).
        while let Ok(u) = self.io.urgent.try_recv() {
            if let Some(kind) = u.stop_kind() {
                self.shared.request_stop(kind);
            }
            self.handle_urgent(u);
        }
        while let Ok(u) = self.io.forwarded.try_recv() {
            self.handle_urgent(u);
        }
        while let Ok(d) = self.io.done.try_recv() {
            self.handle_done(d);
        }
        while let Ok(incoming) = self.io.incoming.try_recv() {
            match incoming {
                Incoming::Request(from, request) => self.handle_request(from, request),
                Incoming::Disconnected(source) => self.disconnected(source),
            }
        }
        self.finish_reset();
        while let Ok(start) = self.io.store.starts.try_recv() {
            self.start_program(start);
        }
        while let Ok(offer) = self.io.store.jobs.try_recv() {
            self.offer_job(offer);
        }
        self.run_program();
        self.run_job();
        self.watch_hand();
        if let Some(program) = self.retire.take() {
            if let Err(e) = self.io.store.retired.try_send(program) {
                self.retire = Some(e.into_inner());
            }
        }
        let stopped = self.stands_still();
        // A HOLD is HELD once its brake has come to rest on the board, until RESUME, a stop
        // or the end of whatever waited on its motions (ABORT of a program) leaves nothing
        // open; a brake that ended on the last motion's target held nothing.
        if self.hold == motion::Hold::Braking && stopped {
            if self.outstanding() {
                self.hold = motion::Hold::Held;
                self.planned_end = self.robot.pulses_to_joints(&self.shared.commanded_pulses());
                self.set_state(RobotState::Held);
            } else {
                self.hold = motion::Hold::None;
            }
        }
        if self.hold == motion::Hold::Held && !self.outstanding() {
            self.hold = motion::Hold::None;
        }
        if self.settle_state() {
            // At rest the robot is where the board was commanded; a move that ended on its
            // target keeps the target exactly (a program's HERE() does not turn into the
            // pulses' rounding once the state settles).
            let commanded = self.shared.commanded_pulses();
            if self.robot.joints_to_pulses(&self.planned_end) != commanded {
                self.planned_end = self.robot.pulses_to_joints(&commanded);
            }
            for i in 0..MAX_WAITERS {
                if let Some(w) = self.waiters[i].take() {
                    // The stop that ended the motions it waited for, or the alarm now.
                    let line = match w.ended.or_else(|| self.alarm()) {
                        Some(code) => self.buf.abs(w.to, code, code.text()),
                        None => self.buf.inf(w.to, ""),
                    };
                    deliver(&self.io.out, w.from, line);
                }
            }
        }
    }
}

impl<B: MotionBoard + 'static> Task for CommandInterpreter<B> {
    fn cycle(&mut self, ctx: &CycleContext) {
        self.step_released(ctx.woke_ns, ctx.release == Release::Period);
    }
}

#[cfg(test)]
mod tests;
