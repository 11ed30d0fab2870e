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

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use wrc_board::layout::board_status;
use wrc_board::MotionBoard;
use wrc_lang::{Motion, Program, Resume, RuntimeErrorKind, Step, Vm, VmIo, VmLimits};
use wrc_protocol::{
    AxisArg, Code, Command, Event, HelpBody, IoBody, ProgramName, ReplyBuf, ReplyTo, Request,
    StatusBody, Verb, WhereBody,
};
use wrc_robot::{Joints, Pose, Posture, Robot, MAX_AXES};
use wrc_rt::ipc::{MessageQueue, Semaphore};
use wrc_rt::{CycleContext, Task};

mod cell;

use crate::clients::{source_name, Incoming};
use crate::program_store::{ProgramStart, StoreLinks};
use crate::shared::{
    MoveDone, MoveKind, MoveOrder, MoveOutcome, OutLine, RobotState, Shared, SourceId, Urgent,
};
use crate::velocity_generator::refusal_code;

/// Motions accepted but not finished, at most.
pub const MAX_TICKETS: usize = 32;
/// Clients waiting on WAIT, at most.
pub const MAX_WAITERS: usize = 64;
/// Robot-language instructions a running program may execute per cycle between two of its
/// requests.
pub const PROGRAM_BUDGET: u32 = 2_000;
/// Requests carried out at once (PRINT, OUT, SPEED) a program may make per cycle.
pub const PROGRAM_REQUESTS: u32 = 16;
/// Cycles a RESET may wait for the board to clear its faults before it is refused (1 s at
/// the default 50 ms period).
pub const RESET_CYCLES: u32 = 20;

#[derive(Debug, Clone, Copy)]
struct Ticket {
    ticket: u32,
    from: SourceId,
    to: ReplyTo,
    home: bool,
}

/// The blocking half of the urgent path: a thread that waits on the semaphore and requests
/// the stop at once.
pub struct UrgentPath {
    /// The semaphore the receiving tasks post.
    pub wake: Arc<Semaphore>,
    /// The shared state whose stop epoch it bumps.
    pub shared: Arc<Shared>,
    /// Ends the thread.
    pub quit: Arc<AtomicBool>,
}

impl UrgentPath {
    /// Run until `quit`: every post requests one stop.
    pub fn run(self) {
        while !self.quit.load(Ordering::Acquire) {
            if self.wake.wait_timeout(Duration::from_millis(100)) {
                self.shared.request_stop();
            }
        }
    }
}

/// The refusal of the running program's last request (its requests go through the same
/// checks as a connection's; a refusal is kept here instead of sent as a NAK).
#[derive(Clone, Copy)]
struct Refusal {
    code: Option<Code>,
    text: [u8; 400],
    len: usize,
}

impl Refusal {
    fn record(&mut self, code: Code, text: &str) {
        let n = floor_char_boundary(text, self.text.len());
        self.text[..n].copy_from_slice(&text.as_bytes()[..n]);
        self.len = n;
        self.code = Some(code);
    }

    /// The recorded text.
    fn text(&self) -> &str {
        std::str::from_utf8(&self.text[..self.len]).unwrap_or("refused")
    }
}

/// The largest index ≤ `max` that is a character boundary of `text`.
pub(crate) fn floor_char_boundary(text: &str, max: usize) -> usize {
    let mut n = text.len().min(max);
    while !text.is_char_boundary(n) {
        n -= 1;
    }
    n
}

/// How a motion's end ends the program or job that waited for it: `None` when it completed.
fn motion_failure(outcome: MoveOutcome) -> Option<(Code, &'static str)> {
    match outcome {
        MoveOutcome::Completed => None,
        MoveOutcome::Stopped => Some((Code::Stopped, "stopped")),
        MoveOutcome::Refused(number) => {
            let code = Code::from_number(number).unwrap_or(Code::MotionFault);
            Some((code, code.text()))
        }
    }
}

/// Send `line` to `to`; replies to the running program need not be sent (its refusals are
/// recorded by [`CommandInterpreter::nak`]).
fn deliver(out: &Outputs, to: SourceId, line: &[u8]) {
    // A program's and a job's own motions are answered to themselves, not on the wire.
    if to != SourceId::PROGRAM && to != SourceId::CELL {
        out.send(to, line);
    }
}

/// What a running program waits for.
#[derive(Debug, Clone, Copy, PartialEq)]
enum ProgramWait {
    /// Nothing: run it.
    Nothing,
    /// Its motion with this ticket to finish.
    Motion(u32),
    /// `DELAY`: until this time [ns].
    Until(u64),
    /// `WAIT IN(n) = value`, until the deadline [ns] if there is one.
    Input {
        n: u8,
        value: bool,
        deadline: Option<u64>,
    },
    /// `GET`, `PUT` or `MAP`: the cell service's answer, then the job.
    Job,
}

/// The program the Command Interpreter is running.
struct RunningProgram {
    from: SourceId,
    to: ReplyTo,
    name: ProgramName,
    program: Box<Program>,
    wait: ProgramWait,
    paused: bool,
}

/// What a program reads synchronously: inputs and the pose where its last motion ended.
struct ProgramIo {
    inputs: u32,
    here: Pose,
}

impl VmIo for ProgramIo {
    fn input(&self, n: u8) -> bool {
        n < 32 && self.inputs & (1u32 << n) != 0
    }
    fn here(&self) -> Pose {
        self.here
    }
}

/// Where replies go: the Ethernet task's queue and the RS232C task's.
#[derive(Clone)]
pub struct Outputs {
    /// Hosts and GUIs.
    pub network: Arc<MessageQueue<OutLine>>,
    /// The pendant.
    pub serial: Arc<MessageQueue<OutLine>>,
}

impl Outputs {
    /// Send a reply to `to`; [`SourceId::BROADCAST`] reaches every client, and a reply for
    /// a client that has gone ([`SourceId::NONE`]) is dropped.
    pub fn send(&self, to: SourceId, bytes: &[u8]) {
        if to == SourceId::NONE {
            return;
        }
        let to = if to == SourceId::BROADCAST {
            SourceId::NONE
        } else {
            to
        };
        let line = OutLine::new(to, bytes);
        if to == SourceId::NONE {
            let _ = self.network.try_send(line);
            let _ = self.serial.try_send(line);
        } else if to.kind() == SourceId::PENDANT {
            let _ = self.serial.try_send(line);
        } else {
            let _ = self.network.try_send(line);
        }
    }
}

/// The Command Interpreter.
pub struct CommandInterpreter<B: MotionBoard> {
    robot: Robot,
    board: B,
    shared: Arc<Shared>,
    incoming: Arc<MessageQueue<Incoming>>,
    urgent: Arc<MessageQueue<Urgent>>,
    wake: Arc<Semaphore>,
    orders: Arc<MessageQueue<MoveOrder>>,
    done: Arc<MessageQueue<MoveDone>>,
    out: Outputs,
    owner_lost: Arc<AtomicBool>,
    tickets: [Option<Ticket>; MAX_TICKETS],
    waiters: [Option<(SourceId, ReplyTo)>; MAX_WAITERS],
    next_ticket: u32,
    /// Joints where the last accepted move ends (validation reference).
    planned_end: Joints,
    buf: ReplyBuf,
    feedback: wrc_board::Feedback,
    /// A RESET the board has not yet carried out: who asked, and cycles left before it is
    /// refused.
    reset_pending: Option<(SourceId, ReplyTo, u32)>,
    /// Input bit of the E-stop circuit (board 0), if the cell has one.
    pub estop_input: Option<u8>,
    links: StoreLinks,
    vm: Vm,
    program: Option<RunningProgram>,
    /// A finished program the store's queue had no room for yet (freed there, not here).
    retire: Option<Box<Program>>,
    refusal: Refusal,
    now_ns: u64,
    /// The hand's signals (vacuum valve and sensor, mapping sensor).
    pub hand: wrc_config::HandConfig,
    job: Option<cell::RunningJob>,
    scan: wrc_board::MappingScan,
    /// Successive cycles the vacuum sensor read "no wafer" while the map's wafer on the
    /// hand moved outside a job.
    hand_dropped: u32,
}

impl<B: MotionBoard> CommandInterpreter<B> {
    /// A Command Interpreter for `robot` on `board`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        robot: Robot,
        board: B,
        shared: Arc<Shared>,
        incoming: Arc<MessageQueue<Incoming>>,
        urgent: Arc<MessageQueue<Urgent>>,
        wake: Arc<Semaphore>,
        orders: Arc<MessageQueue<MoveOrder>>,
        done: Arc<MessageQueue<MoveDone>>,
        out: Outputs,
        owner_lost: Arc<AtomicBool>,
        links: StoreLinks,
    ) -> Self {
        let planned_end = robot.pulses_to_joints(&shared.commanded_pulses());
        CommandInterpreter {
            robot,
            board,
            shared,
            incoming,
            urgent,
            wake,
            orders,
            done,
            out,
            owner_lost,
            tickets: [None; MAX_TICKETS],
            waiters: [None; MAX_WAITERS],
            next_ticket: 1,
            planned_end,
            buf: ReplyBuf::new(),
            feedback: wrc_board::Feedback::default(),
            reset_pending: None,
            estop_input: None,
            links,
            vm: Vm::new(VmLimits::default()),
            program: None,
            retire: None,
            refusal: Refusal {
                code: None,
                text: [0; 400],
                len: 0,
            },
            now_ns: 0,
            hand: wrc_config::HandConfig::default(),
            job: None,
            scan: wrc_board::MappingScan::default(),
            hand_dropped: 0,
        }
    }

    fn owner(&self) -> SourceId {
        SourceId(self.shared.owner.load(Ordering::Acquire))
    }

    fn event(&mut self, event: &Event<'_>) {
        let line = self.buf.event(false, event);
        self.out.send(SourceId::BROADCAST, line);
    }

    fn set_state(&mut self, state: RobotState) {
        if self.shared.state() != state {
            self.shared.set_state(state);
            self.event(&Event::State(state));
        }
    }

    fn nak(&mut self, from: SourceId, to: ReplyTo, code: Code, text: &str) {
        if from == SourceId::PROGRAM || from == SourceId::CELL {
            self.refusal.record(code, text);
        } else {
            let line = self.buf.nak(to, code, text);
            self.out.send(from, line);
        }
    }

    fn outstanding(&self) -> bool {
        self.tickets.iter().any(Option::is_some)
    }

    /// Abort every accepted motion and WAIT with ABS `code`.
    fn abort_all(&mut self, code: Code, text: &str) {
        if self.job.is_some() {
            self.end_job(Some((code, text)));
        }
        for i in 0..MAX_TICKETS {
            if let Some(t) = self.tickets[i].take() {
                if t.from == SourceId::CELL {
                    continue;
                }
                let line = self.buf.abs(t.to, code, text);
                deliver(&self.out, t.from, line);
            }
        }
        for i in 0..MAX_WAITERS {
            if let Some((from, to)) = self.waiters[i].take() {
                let line = self.buf.abs(to, code, text);
                deliver(&self.out, from, line);
            }
        }
        if self.program.is_some() {
            self.end_program(Some((code, text)));
        }
    }

    fn handle_urgent(&mut self, urgent: Urgent) {
        // The urgent thread normally took the semaphore token and requested the stop
        // already; if this cycle got here first, request it now (exactly one per message).
        if self.wake.try_wait() {
            self.shared.request_stop();
        }
        match urgent {
            Urgent::Stop(from, to) => {
                let line = self.buf.ack(to, "");
                deliver(&self.out, from, line);
                if self.shared.state() == RobotState::Moving {
                    self.set_state(RobotState::Stopping);
                }
                self.abort_all(Code::Stopped, "stopped by STOP");
            }
            Urgent::Estop(from, to) => {
                let line = self.buf.ack(to, "");
                deliver(&self.out, from, line);
                self.abort_all(Code::EmergencyStop, "emergency stop");
                self.shared
                    .error_code
                    .store(u32::from(Code::EmergencyStop.number()), Ordering::Release);
                self.set_state(RobotState::Estop);
                self.event(&Event::Error {
                    code: Code::EmergencyStop,
                    text: "emergency stop; RESET to continue",
                });
            }
            Urgent::Fault(number) => {
                let code = Code::from_number(number).unwrap_or(Code::MotionFault);
                let text = code.text();
                self.abort_all(code, text);
                self.shared
                    .error_code
                    .store(u32::from(number), Ordering::Release);
                let state = if code == Code::EstopInput {
                    RobotState::Estop
                } else {
                    RobotState::Error
                };
                self.set_state(state);
                self.event(&Event::Error { code, text });
            }
        }
        self.planned_end = self.robot.pulses_to_joints(&self.shared.commanded_pulses());
    }

    fn new_ticket(&mut self, from: SourceId, to: ReplyTo, home: bool) -> Option<u32> {
        let slot = self.tickets.iter().position(Option::is_none)?;
        let ticket = self.next_ticket;
        self.next_ticket = self.next_ticket.wrapping_add(1).max(1);
        self.tickets[slot] = Some(Ticket {
            ticket,
            from,
            to,
            home,
        });
        Some(ticket)
    }

    /// Validate and queue a motion; ACK or NAK.
    fn motion(&mut self, from: SourceId, to: ReplyTo, kind: MoveKind, end: Joints, home: bool) {
        let Some(ticket) = self.new_ticket(from, to, home) else {
            self.nak(from, to, Code::Busy, "too many motions queued; WAIT first");
            return;
        };
        let order = MoveOrder {
            ticket,
            epoch: self.shared.stop_epoch.load(Ordering::Acquire),
            speed_pct: f64::from(self.shared.speed_pct.load(Ordering::Acquire)),
            kind,
        };
        if self.orders.try_send(order).is_err() {
            if let Some(t) = self
                .tickets
                .iter_mut()
                .find(|t| t.is_some_and(|t| t.ticket == ticket))
            {
                *t = None;
            }
            self.nak(from, to, Code::Busy, "too many motions queued; WAIT first");
            return;
        }
        self.planned_end = end;
        let line = self.buf.ack(to, "");
        deliver(&self.out, from, line);
        self.set_state(RobotState::Moving);
    }

    fn handle_request(&mut self, from: SourceId, request: Request) {
        let to = request.reply_to();
        let verb = request.command.verb();
        let owner = self.owner();
        // A program's requests act for the source that started it; a job's for the source
        // that asked for it (or that program's starter).
        let acting = match (&self.program, from) {
            (Some(p), SourceId::PROGRAM) => p.from,
            (_, SourceId::CELL) => match (&self.job, &self.program) {
                (Some(j), Some(p)) if j.from() == SourceId::PROGRAM => p.from,
                (Some(j), _) => j.from(),
                (None, _) => from,
            },
            _ => from,
        };
        if verb.spec().needs_control && owner != SourceId::NONE && owner != acting {
            let mut name = [0u8; 24];
            let mut text = [0u8; 96];
            let mut w: &mut [u8] = &mut text[..];
            let _ = write!(
                w,
                "control is held by {}; it must RELEASE first",
                source_name(owner, &mut name).unwrap_or("another source")
            );
            let len = 96 - w.len();
            let text =
                std::str::from_utf8(&text[..len]).unwrap_or("control is held by another source");
            self.nak(from, to, Code::ControlHeld, text);
            return;
        }
        let state = self.shared.state();
        let is_motion = matches!(
            request.command,
            Command::Home
                | Command::MovJ { .. }
                | Command::MovP { .. }
                | Command::MovL { .. }
                | Command::Jog { .. }
        );
        if is_motion {
            if self.job.is_some() && from != SourceId::CELL {
                return self.nak(
                    from,
                    to,
                    Code::TransferBusy,
                    "a transfer or mapping is in progress; wait for its end or STOP",
                );
            }
            if self.program.is_some() && from != SourceId::PROGRAM && from != SourceId::CELL {
                return self.nak(
                    from,
                    to,
                    Code::ProgramRunning,
                    "a program is running; ABORT it first",
                );
            }
            if state == RobotState::Error {
                return self.nak(
                    from,
                    to,
                    Code::InError,
                    "the robot is in ERROR; RESET first",
                );
            }
            if state == RobotState::Estop {
                return self.nak(
                    from,
                    to,
                    Code::InEstop,
                    "the robot is in ESTOP; RESET first",
                );
            }
            if state == RobotState::Stopping {
                return self.nak(
                    from,
                    to,
                    Code::Busy,
                    "the robot is stopping; repeat when it is IDLE",
                );
            }
            if !matches!(request.command, Command::Home)
                && !self.shared.homed.load(Ordering::Acquire)
            {
                return self.nak(
                    from,
                    to,
                    Code::NotHomed,
                    "the robot is not homed; send HOME first",
                );
            }
        }
        match request.command {
            Command::Status => {
                let mut name = [0u8; 24];
                let body = StatusBody {
                    state,
                    homed: self.shared.homed.load(Ordering::Acquire),
                    speed_pct: f64::from(self.shared.speed_pct.load(Ordering::Acquire)),
                    owner: source_name(owner, &mut name),
                    err: Code::from_number(self.shared.error_code.load(Ordering::Acquire) as u16),
                };
                let line = self.buf.ack(to, body);
                deliver(&self.out, from, line);
            }
            Command::Where => {
                let mut joints = [0.0; MAX_AXES];
                let ok = self.board.read_feedback(&mut self.feedback).is_ok();
                let commanded = self.shared.commanded_pulses();
                for (i, a) in self.robot.axes().iter().enumerate() {
                    let p = if ok {
                        self.feedback.axes[i].encoder
                    } else {
                        commanded[i]
                    };
                    joints[i] = a.pulses_to_units(p);
                }
                let tcp = self.robot.forward(&joints);
                let body = WhereBody {
                    joints: &joints[..self.robot.axis_count()],
                    tcp,
                };
                let line = self.buf.ack(to, body);
                deliver(&self.out, from, line);
            }
            Command::Home => {
                let home = self.robot.home();
                self.motion(from, to, MoveKind::Joints(home), home, true);
            }
            Command::MovJ { joints, .. } => match self.robot.check_joints(&joints) {
                Ok(()) => self.motion(from, to, MoveKind::Joints(joints), joints, false),
                Err(e) => self.refuse(from, to, &wrc_motion::PlanError::Kinematics(e)),
            },
            Command::MovP { pose, posture } => {
                let posture = posture
                    .or_else(|| Posture::of(&self.robot, &self.planned_end))
                    .unwrap_or(Posture::Right);
                // The joint solution the Velocity Generator will go to (the one it reaches
                // soonest where the ranges allow several).
                match wrc_motion::ptp_target(&self.robot, &self.planned_end, &pose, posture) {
                    Ok(end) => {
                        self.motion(from, to, MoveKind::Pose(pose, Some(posture)), end, false)
                    }
                    Err(e) => self.refuse(from, to, &e),
                }
            }
            Command::MovL { pose } => {
                // Check every point of the line from where the previous motion ends, as the
                // Velocity Generator will follow it (joints continuous).
                let start = self
                    .robot
                    .pulses_to_joints(&self.robot.joints_to_pulses(&self.planned_end));
                match wrc_motion::check_line(&self.robot, &start, &pose) {
                    Ok((_, check)) => {
                        self.motion(from, to, MoveKind::Line(pose), check.end_joints, false)
                    }
                    Err(e) => self.refuse(from, to, &e),
                }
            }
            Command::Jog { axis, pulses } => {
                let Some(index) = axis.resolve(&self.robot) else {
                    return self.nak(
                        from,
                        to,
                        Code::AxisUnknown,
                        "no such axis; WHERE lists the axes in order",
                    );
                };
                let a = &self.robot.axes()[index];
                let mut end = self.planned_end;
                end[index] = a.pulses_to_units(a.units_to_pulses(end[index]) + pulses);
                if !a.within_limits(end[index]) {
                    return self.nak(
                        from,
                        to,
                        Code::JointLimit,
                        "the jog would leave the axis limits",
                    );
                }
                self.motion(
                    from,
                    to,
                    MoveKind::Jog {
                        axis: index,
                        pulses,
                    },
                    end,
                    false,
                );
            }
            Command::Speed(pct) => {
                self.shared
                    .speed_pct
                    .store(pct.round().clamp(1.0, 100.0) as u32, Ordering::Release);
                let mut body = [0u8; 24];
                let mut w: &mut [u8] = &mut body[..];
                let _ = write!(w, "speed={}", pct.round().clamp(1.0, 100.0) as u32);
                let len = 24 - w.len();
                let line = self
                    .buf
                    .ack(to, std::str::from_utf8(&body[..len]).unwrap_or(""));
                deliver(&self.out, from, line);
            }
            Command::Stop => self.handle_urgent(Urgent::Stop(from, to)),
            Command::Estop => self.handle_urgent(Urgent::Estop(from, to)),
            Command::Reset => {
                if let Some(input) = self.estop_input {
                    if self.shared.inputs[0].load(Ordering::Acquire) & (1u32 << input) != 0 {
                        return self.nak(
                            from,
                            to,
                            Code::InEstop,
                            "the E-stop input is still open; close it, then RESET",
                        );
                    }
                }
                if self.shared.in_flight.load(Ordering::Acquire) != 0 {
                    return self.nak(
                        from,
                        to,
                        Code::Busy,
                        "the robot is still moving; STOP and WAIT first",
                    );
                }
                if self.reset_pending.is_some() {
                    return self.nak(from, to, Code::Busy, "a RESET is already in progress");
                }
                if self.board.reset().is_err() {
                    return self.nak(
                        from,
                        to,
                        Code::Busy,
                        "the board is busy with a previous command; repeat RESET",
                    );
                }
                // Answered once the board has carried it out and reports no fault (see
                // `finish_reset`), so Error Check never sees the fault of before the RESET.
                self.reset_pending = Some((from, to, RESET_CYCLES));
            }
            Command::Io => {
                let body = IoBody {
                    inputs: self.shared.inputs[0].load(Ordering::Acquire),
                    outputs: self.shared.outputs[0].load(Ordering::Acquire),
                };
                let line = self.buf.ack(to, body);
                deliver(&self.out, from, line);
            }
            Command::Out { n, on } => {
                let bit = 1u32 << n;
                if on {
                    self.shared.outputs[0].fetch_or(bit, Ordering::AcqRel);
                } else {
                    self.shared.outputs[0].fetch_and(!bit, Ordering::AcqRel);
                }
                let line = self.buf.ack(to, "");
                deliver(&self.out, from, line);
            }
            Command::Wait => {
                let line = self.buf.ack(to, "");
                deliver(&self.out, from, line);
                match self.waiters.iter().position(Option::is_none) {
                    Some(i) => self.waiters[i] = Some((from, to)),
                    None => {
                        let line = self.buf.abs(to, Code::Busy, "too many clients waiting");
                        deliver(&self.out, from, line);
                    }
                }
            }
            Command::Control => {
                if owner == SourceId::NONE || owner == from {
                    self.shared.owner.store(from.0, Ordering::Release);
                    self.control_changed(Some(from), from, to);
                } else {
                    self.nak(
                        from,
                        to,
                        Code::ControlHeld,
                        "control is held by another source",
                    );
                }
            }
            Command::Release => {
                if owner == from || owner == SourceId::NONE {
                    self.shared.owner.store(0, Ordering::Release);
                    self.control_changed(None, from, to);
                } else {
                    self.nak(
                        from,
                        to,
                        Code::ControlHeld,
                        "control is held by another source",
                    );
                }
            }
            Command::Pause | Command::Continue | Command::Abort => {
                self.program_control(from, to, request.command)
            }
            Command::Help => {
                let line = self.buf.ack(to, HelpBody);
                deliver(&self.out, from, line);
            }
            _ => {
                let _ = Verb::ALL;
                self.nak(
                    from,
                    to,
                    Code::NotAvailable,
                    "not available on this controller",
                );
            }
        }
    }

    fn control_changed(&mut self, owner: Option<SourceId>, from: SourceId, to: ReplyTo) {
        let mut name = [0u8; 24];
        let owner_name = owner.and_then(|o| source_name(o, &mut name));
        let mut body = [0u8; 40];
        let mut w: &mut [u8] = &mut body[..];
        let _ = write!(w, "owner={}", owner_name.unwrap_or("none"));
        let len = 40 - w.len();
        let body = std::str::from_utf8(&body[..len]).unwrap_or("");
        let line = self.buf.ack(to, body);
        deliver(&self.out, from, line);
        let line = self.buf.event(false, &Event::Control { owner: owner_name });
        self.out.send(SourceId::BROADCAST, line);
    }

    fn refuse(&mut self, from: SourceId, to: ReplyTo, err: &wrc_motion::PlanError) {
        let code = Code::from_number(refusal_code(err)).unwrap_or(Code::OutOfReach);
        let mut text = [0u8; 400];
        let mut w: &mut [u8] = &mut text[..];
        let _ = write!(w, "{err}");
        let len = 400 - w.len();
        let text = std::str::from_utf8(&text[..len]).unwrap_or("the target cannot be reached");
        self.nak(from, to, code, text);
    }

    fn handle_done(&mut self, done: MoveDone) {
        let Some(i) = self
            .tickets
            .iter()
            .position(|t| t.is_some_and(|t| t.ticket == done.ticket))
        else {
            return; // already answered (a stop aborted it)
        };
        let Some(t) = self.tickets[i].take() else {
            return;
        };
        if t.from == SourceId::PROGRAM {
            if t.home && done.outcome == MoveOutcome::Completed {
                self.shared.homed.store(true, Ordering::Release);
            }
            return self.program_motion_done(t.ticket, done.outcome);
        }
        if t.from == SourceId::CELL {
            return self.job_motion_done(t.ticket, done.outcome);
        }
        match done.outcome {
            MoveOutcome::Completed => {
                if t.home {
                    self.shared.homed.store(true, Ordering::Release);
                }
                let line = self.buf.inf(t.to, "");
                deliver(&self.out, t.from, line);
            }
            MoveOutcome::Stopped => {
                let line = self.buf.abs(t.to, Code::Stopped, "stopped");
                deliver(&self.out, t.from, line);
            }
            MoveOutcome::Refused(number) => {
                let code = Code::from_number(number).unwrap_or(Code::MotionFault);
                let line = self.buf.abs(t.to, code, code.text());
                deliver(&self.out, t.from, line);
            }
        }
    }

    fn disconnected(&mut self, source: SourceId) {
        for t in self.tickets.iter_mut() {
            if t.is_some_and(|t| t.from == source) {
                // Nobody to answer; the motion itself continues unless it is the owner's.
                if let Some(t) = t.as_mut() {
                    t.from = SourceId::NONE;
                    t.to = ReplyTo::default();
                }
            }
        }
        for w in self.waiters.iter_mut() {
            if w.is_some_and(|w| w.0 == source) {
                *w = None;
            }
        }
        if let Some(j) = self.job.as_mut() {
            j.forget_requester(source);
        }
        if self.owner() == source {
            self.shared.owner.store(0, Ordering::Release);
            let line = self.buf.event(false, &Event::Control { owner: None });
            self.out.send(SourceId::BROADCAST, line);
            if matches!(self.shared.state(), RobotState::Moving) {
                // Error Check turns this into a controlled stop and ERROR.
                self.owner_lost.store(true, Ordering::Release);
            }
        }
    }

    fn program_event(&mut self, name: ProgramName, state: &str) {
        let line = self.buf.event(
            false,
            &Event::Program {
                name: name.as_str(),
                state,
            },
        );
        self.out.send(SourceId::BROADCAST, line);
    }

    /// `RUN`: the store compiled the program; start it unless something forbids it.
    fn start_program(&mut self, start: ProgramStart) {
        let ProgramStart {
            from,
            to,
            name,
            program,
        } = start;
        let owner = self.owner();
        let refusal = if self.program.is_some() {
            Some((Code::ProgramRunning, "a program is running; ABORT it first"))
        } else if owner != SourceId::NONE && owner != from {
            Some((Code::ControlHeld, "control is held by another source"))
        } else if self.shared.state() == RobotState::Error {
            Some((Code::InError, "the robot is in ERROR; RESET first"))
        } else if self.shared.state() == RobotState::Estop {
            Some((Code::InEstop, "the robot is in ESTOP; RESET first"))
        } else if self.outstanding() || self.shared.state() == RobotState::Stopping {
            Some((Code::Busy, "the robot is moving; WAIT first"))
        } else {
            None
        };
        if let Some((code, text)) = refusal {
            self.nak(from, to, code, text);
            self.retire_program(program);
            return;
        }
        if let Err(e) = self.vm.load(&program) {
            let mut text = [0u8; 160];
            let mut w: &mut [u8] = &mut text[..];
            let _ = write!(w, "{name}: {e}");
            let len = 160 - w.len();
            let text = std::str::from_utf8(&text[..len]).unwrap_or("the program is too large");
            self.nak(from, to, Code::ProgramInvalid, text);
            self.retire_program(program);
            return;
        }
        let line = self.buf.ack(to, "");
        deliver(&self.out, from, line);
        self.program = Some(RunningProgram {
            from,
            to,
            name,
            program,
            wait: ProgramWait::Nothing,
            paused: false,
        });
        self.program_event(name, "RUNNING");
    }

    fn retire_program(&mut self, program: Box<Program>) {
        if let Err(e) = self.links.retired.try_send(program) {
            // Sent again next cycle and freed by the store, never here. Should even the retry
            // slot be taken (the store drains its queue every 50 ms, so it is not expected),
            // the program is leaked rather than freed in this real-time task.
            if self.retire.is_none() {
                self.retire = Some(e.into_inner());
            } else {
                std::mem::forget(e.into_inner());
            }
        }
    }

    /// End the running program: `INF` to its starter, or `ABS` with `code`, the program's
    /// name, its source line and `text`; stop its motion if one is under way.
    /// A program or wafer job (`owner`) ends abnormally: if the motion it waits for
    /// (`waiting`) is still in flight, stop the robot in a controlled way, and forget every
    /// ticket of `owner`, whose replies nobody awaits any more.
    fn abandon_motion(&mut self, waiting: Option<u32>, owner: SourceId) {
        let in_flight = waiting.is_some_and(|ticket| {
            self.tickets
                .iter()
                .any(|t| t.is_some_and(|t| t.ticket == ticket))
        });
        if in_flight {
            self.shared.request_stop();
            if self.shared.state() == RobotState::Moving {
                self.set_state(RobotState::Stopping);
            }
        }
        for t in self.tickets.iter_mut() {
            if t.is_some_and(|t| t.from == owner) {
                *t = None;
            }
        }
    }

    fn end_program(&mut self, failure: Option<(Code, &str)>) {
        self.end_program_at(failure, None);
    }

    /// [`Self::end_program`] naming source line `line` (default: where the program is).
    fn end_program_at(&mut self, failure: Option<(Code, &str)>, line: Option<u32>) {
        let Some(p) = self.program.take() else {
            return;
        };
        // A GET, PUT or MAP of the program's (ABORT, a refusal) ends with it and stops.
        if self.job.is_some_and(|j| j.from() == SourceId::PROGRAM) {
            self.end_job(Some(
                failure.unwrap_or((Code::Stopped, "the program that asked for it ended")),
            ));
        }
        let line_no = line
            .or_else(|| self.vm.position(&p.program).map(|pos| pos.line))
            .unwrap_or(0);
        self.vm.abort();
        match failure {
            None => {
                let line = self.buf.inf(p.to, "");
                deliver(&self.out, p.from, line);
            }
            Some((code, text)) => {
                let waiting = match p.wait {
                    ProgramWait::Motion(ticket) => Some(ticket),
                    _ => None,
                };
                self.abandon_motion(waiting, SourceId::PROGRAM);
                let mut body = [0u8; 400];
                let mut w: &mut [u8] = &mut body[..];
                let _ = write!(w, "{} line {line_no}: {text}", p.name);
                let len = 400 - w.len();
                let body = std::str::from_utf8(&body[..len]).unwrap_or(text);
                let line = self.buf.abs(p.to, code, body);
                deliver(&self.out, p.from, line);
            }
        }
        self.program_event(p.name, "ENDED");
        self.retire_program(p.program);
    }

    /// `PAUSE`, `CONTINUE`, `ABORT`.
    fn program_control(&mut self, from: SourceId, to: ReplyTo, command: Command) {
        let Some(p) = self.program.as_mut() else {
            return self.nak(from, to, Code::NoProgram, "no program is running");
        };
        let name = p.name;
        match command {
            Command::Pause => {
                let changed = !p.paused;
                p.paused = true;
                let line = self.buf.ack(to, "");
                deliver(&self.out, from, line);
                if changed {
                    self.program_event(name, "PAUSED");
                }
            }
            Command::Continue => {
                let changed = p.paused;
                p.paused = false;
                let line = self.buf.ack(to, "");
                deliver(&self.out, from, line);
                if changed {
                    self.program_event(name, "RUNNING");
                }
            }
            _ => {
                let line = self.buf.ack(to, "");
                deliver(&self.out, from, line);
                self.end_program(Some((Code::Stopped, "aborted by ABORT")));
            }
        }
    }

    /// A motion of the running program finished.
    fn program_motion_done(&mut self, ticket: u32, outcome: MoveOutcome) {
        let Some(p) = self.program.as_mut() else {
            return;
        };
        if p.wait != ProgramWait::Motion(ticket) {
            return;
        }
        match motion_failure(outcome) {
            None => {
                p.wait = ProgramWait::Nothing;
                self.vm.resume(Resume::Ok);
            }
            failure => self.end_program(failure),
        }
    }

    /// Hand one of the program's requests to the checks every connection's request goes
    /// through: `Ok` with the ticket of a queued motion, `Err` with the refusal's code (its
    /// text is in `self.refusal`).
    fn program_request(&mut self, command: Command) -> Result<Option<u32>, Code> {
        self.internal_request(SourceId::PROGRAM, command)
    }

    /// A request of the controller's own (`source`: the program or a wafer job) through the
    /// checks every connection's request goes through (see [`Self::program_request`]).
    fn internal_request(
        &mut self,
        source: SourceId,
        command: Command,
    ) -> Result<Option<u32>, Code> {
        self.refusal.code = None;
        let next = self.next_ticket;
        self.handle_request(
            source,
            Request {
                id: None,
                command,
                checksum: false,
            },
        );
        if let Some(code) = self.refusal.code {
            return Err(code);
        }
        Ok(self
            .tickets
            .iter()
            .flatten()
            .find(|t| t.from == source && t.ticket >= next)
            .map(|t| t.ticket))
    }

    /// Run the program for this cycle's budget, or check what it waits for.
    fn run_program(&mut self) {
        let Some(p) = self.program.as_mut() else {
            return;
        };
        match p.wait {
            ProgramWait::Nothing => {}
            ProgramWait::Motion(_) | ProgramWait::Job => return,
            ProgramWait::Until(t) => {
                if self.now_ns < t {
                    return;
                }
                p.wait = ProgramWait::Nothing;
                self.vm.resume(Resume::Ok);
            }
            ProgramWait::Input { n, value, deadline } => {
                let on = self.shared.inputs[0].load(Ordering::Acquire) & (1u32 << n) != 0;
                if on == value {
                    p.wait = ProgramWait::Nothing;
                    self.vm.resume(Resume::Ok);
                } else if deadline.is_some_and(|d| self.now_ns >= d) {
                    p.wait = ProgramWait::Nothing;
                    self.vm
                        .resume(Resume::Failed(RuntimeErrorKind::WaitTimeout));
                } else {
                    return;
                }
            }
        }
        if p.paused {
            return;
        }
        // At most PROGRAM_BUDGET instructions between two requests, and at most
        // PROGRAM_REQUESTS requests carried out at once (PRINT, OUT, SPEED) per cycle.
        for _ in 0..PROGRAM_REQUESTS {
            let Some(p) = self.program.as_ref() else {
                return;
            };
            let mut io = ProgramIo {
                inputs: self.shared.inputs[0].load(Ordering::Acquire),
                here: self.robot.forward(&self.planned_end),
            };
            match self.vm.run(&p.program, PROGRAM_BUDGET, &mut io) {
                Step::Budget => return,
                Step::Done => return self.end_program(None),
                Step::Fault(e) => {
                    let code = match e.kind {
                        RuntimeErrorKind::WaitTimeout => Code::WaitTimeout,
                        _ => Code::ProgramError,
                    };
                    let mut text = [0u8; 200];
                    let mut w: &mut [u8] = &mut text[..];
                    let _ = write!(w, "{}", e.kind);
                    let len = 200 - w.len();
                    let text = std::str::from_utf8(&text[..len]).unwrap_or("program error");
                    return self.end_program_at(Some((code, text)), Some(e.line));
                }
                Step::Yield(request) => {
                    if !self.program_yield(request) {
                        return;
                    }
                }
            }
        }
    }

    /// Carry out one request of the program; `true` when it may go on at once.
    fn program_yield(&mut self, request: wrc_lang::Request) -> bool {
        use wrc_lang::Request as R;
        let command = match request {
            R::Move(motion) => match motion {
                Motion::Home => Command::Home,
                Motion::Joints(joints) => Command::MovJ {
                    joints,
                    count: self.robot.axis_count(),
                },
                Motion::Pose(pose, posture) => Command::MovP { pose, posture },
                Motion::Line(pose) => Command::MovL { pose },
                Motion::Jog { axis, pulses } => Command::Jog {
                    axis: AxisArg::Number(u8::try_from(axis + 1).unwrap_or(u8::MAX)),
                    pulses,
                },
            },
            R::Delay { seconds } => {
                let ns = (seconds.max(0.0) * 1e9) as u64;
                if let Some(p) = self.program.as_mut() {
                    p.wait = ProgramWait::Until(self.now_ns.saturating_add(ns));
                }
                return false;
            }
            R::WaitInput {
                n,
                value,
                timeout_s,
            } => {
                if let Some(p) = self.program.as_mut() {
                    p.wait = ProgramWait::Input {
                        n: n.min(31),
                        value,
                        deadline: timeout_s
                            .map(|s| self.now_ns.saturating_add((s.max(0.0) * 1e9) as u64)),
                    };
                }
                return false;
            }
            R::Print => {
                let line = self.buf.event(false, &Event::Print(self.vm.print_text()));
                self.out.send(SourceId::BROADCAST, line);
                self.vm.resume(Resume::Ok);
                return true;
            }
            R::Out { n, on } => Command::Out { n, on },
            R::Speed { pct } => Command::Speed(pct),
            R::Transfer { .. } | R::Map { .. } => {
                let (kind, station, slot) = match request {
                    R::Transfer {
                        kind: wrc_lang::TransferKind::Get,
                        station,
                        slot,
                    } => (crate::cell_job::JobKind::Get, station, slot),
                    R::Transfer { station, slot, .. } => {
                        (crate::cell_job::JobKind::Put, station, slot)
                    }
                    R::Map { station } => (crate::cell_job::JobKind::Map, station, 0),
                    _ => return true,
                };
                let asked = self
                    .links
                    .requests
                    .try_send(crate::program_store::StoreRequest::Job {
                        from: SourceId::PROGRAM,
                        to: ReplyTo::default(),
                        kind,
                        station,
                        slot,
                    });
                if asked.is_err() {
                    self.end_program(Some((
                        Code::Busy,
                        "the controller is busy; the transfer could not be asked for",
                    )));
                } else if let Some(p) = self.program.as_mut() {
                    p.wait = ProgramWait::Job;
                }
                return false;
            }
            _ => {
                self.vm.resume(Resume::Failed(RuntimeErrorKind::BadArgument(
                    "this controller cannot carry out that request",
                )));
                return true;
            }
        };
        let is_motion = matches!(request, R::Move(_));
        match self.program_request(command) {
            Ok(Some(ticket)) if is_motion => {
                if let Some(p) = self.program.as_mut() {
                    p.wait = ProgramWait::Motion(ticket);
                }
                false
            }
            Ok(_) => {
                self.vm.resume(Resume::Ok);
                true
            }
            Err(code) => {
                // The text is copied out: ending the program writes replies.
                let refusal = self.refusal;
                self.end_program(Some((code, refusal.text())));
                false
            }
        }
    }

    /// The fault the board still reports, if any (a torn read counts as not yet clear).
    fn board_fault(&mut self) -> Option<&'static str> {
        if self.board.read_feedback(&mut self.feedback).is_err() {
            return Some("the board's feedback could not be read");
        }
        let fb = &self.feedback;
        for b in &fb.boards[..fb.board_count] {
            if b.status & board_status::ESTOP != 0 {
                return Some("the board still latches its E-stop");
            }
            if b.status & board_status::WATCHDOG_TRIPPED != 0 {
                return Some("the board's watchdog is still tripped");
            }
        }
        let n = self.robot.axis_count();
        if fb.axes[..n].iter().any(|a| a.alarm != 0) {
            return Some("an axis still reports an alarm");
        }
        None
    }

    /// Complete a pending RESET once the board has acted on it: ACK and IDLE when it reports
    /// no fault, NAK when it still does after [`RESET_CYCLES`] cycles.
    fn finish_reset(&mut self) {
        let Some((from, to, left)) = self.reset_pending else {
            return;
        };
        let fault = if self.board.command_pending() {
            Some("the board did not carry out the RESET")
        } else {
            self.board_fault()
        };
        match fault {
            None => {
                self.reset_pending = None;
                self.shared.resync_from_board.store(true, Ordering::Release);
                // Re-read the board's position (it may have stopped by itself) through a
                // stop request, which resynchronises the Pulse and Velocity Generators.
                self.shared.request_stop();
                self.shared.error_code.store(0, Ordering::Release);
                let line = self.buf.ack(to, "");
                deliver(&self.out, from, line);
                self.set_state(RobotState::Idle);
            }
            Some(reason) if left == 0 => {
                self.reset_pending = None;
                let code = if self.shared.state() == RobotState::Estop {
                    Code::InEstop
                } else {
                    Code::InError
                };
                self.nak(from, to, code, reason);
            }
            Some(_) => self.reset_pending = Some((from, to, left - 1)),
        }
    }

    /// One cycle at `now_ns` (the cycle's wake-up time; public for tests that step the task
    /// by hand with their own clock).
    pub fn step(&mut self, now_ns: u64) {
        self.now_ns = now_ns;
        while let Ok(u) = self.urgent.try_recv() {
            self.handle_urgent(u);
        }
        while let Ok(d) = self.done.try_recv() {
            self.handle_done(d);
        }
        while let Ok(incoming) = self.incoming.try_recv() {
            match incoming {
                Incoming::Request(from, request) => self.handle_request(from, request),
                Incoming::Disconnected(source) => self.disconnected(source),
            }
        }
        self.finish_reset();
        while let Ok(start) = self.links.starts.try_recv() {
            self.start_program(start);
        }
        while let Ok(offer) = self.links.jobs.try_recv() {
            self.offer_job(offer);
        }
        self.run_program();
        self.run_job();
        self.watch_hand();
        if let Some(program) = self.retire.take() {
            if let Err(e) = self.links.retired.try_send(program) {
                self.retire = Some(e.into_inner());
            }
        }
        // State: MOVING and STOPPING end when nothing is queued, in flight or stopping.
        let at_rest = !self.outstanding()
            && self.job.is_none()
            && self.orders.is_empty()
            && self.shared.in_flight.load(Ordering::Acquire) == 0
            && self.shared.stopped_epoch.load(Ordering::Acquire)
                == self.shared.stop_epoch.load(Ordering::Acquire);
        if at_rest {
            if matches!(
                self.shared.state(),
                RobotState::Moving | RobotState::Stopping
            ) {
                self.set_state(RobotState::Idle);
            }
            self.planned_end = self.robot.pulses_to_joints(&self.shared.commanded_pulses());
            for i in 0..MAX_WAITERS {
                if let Some((from, to)) = self.waiters[i].take() {
                    let line = match self.shared.state() {
                        RobotState::Error | RobotState::Estop => {
                            let code = Code::from_number(
                                self.shared.error_code.load(Ordering::Acquire) as u16,
                            )
                            .unwrap_or(Code::MotionFault);
                            self.buf.abs(to, code, code.text())
                        }
                        _ => self.buf.inf(to, ""),
                    };
                    deliver(&self.out, from, line);
                }
            }
        }
    }
}

impl<B: MotionBoard + 'static> Task for CommandInterpreter<B> {
    fn cycle(&mut self, ctx: &CycleContext) {
        self.step(ctx.woke_ns);
    }
}
