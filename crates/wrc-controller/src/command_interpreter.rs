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
use wrc_motion::{MotionState, VelocityGenerator as Generator};
use wrc_protocol::{
    Code, Command, Event, HelpBody, IoBody, ReplyBuf, ReplyTo, Request, StatusBody, Verb, WhereBody,
};
use wrc_robot::{Joints, Posture, Robot, MAX_AXES};
use wrc_rt::ipc::{MessageQueue, Semaphore};
use wrc_rt::{CycleContext, Task};

use crate::clients::{source_name, Incoming};
use crate::shared::{
    MoveDone, MoveKind, MoveOrder, MoveOutcome, OutLine, RobotState, Shared, SourceId, Urgent,
};
use crate::velocity_generator::refusal_code;

/// Motions accepted but not finished, at most.
pub const MAX_TICKETS: usize = 32;
/// Clients waiting on WAIT, at most.
pub const MAX_WAITERS: usize = 64;
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
    fn send(&self, to: SourceId, bytes: &[u8]) {
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
    scratch: Generator,
    scratch_idle: MotionState,
    buf: ReplyBuf,
    feedback: wrc_board::Feedback,
    /// A RESET the board has not yet carried out: who asked, and cycles left before it is
    /// refused.
    reset_pending: Option<(SourceId, ReplyTo, u32)>,
    /// Input bit of the E-stop circuit (board 0), if the cell has one.
    pub estop_input: Option<u8>,
}

impl<B: MotionBoard> CommandInterpreter<B> {
    /// A Command Interpreter; `generator` is a generator for the same robot and settings
    /// (used only to check straight lines before accepting them).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        robot: Robot,
        board: B,
        generator: Generator,
        shared: Arc<Shared>,
        incoming: Arc<MessageQueue<Incoming>>,
        urgent: Arc<MessageQueue<Urgent>>,
        wake: Arc<Semaphore>,
        orders: Arc<MessageQueue<MoveOrder>>,
        done: Arc<MessageQueue<MoveDone>>,
        out: Outputs,
        owner_lost: Arc<AtomicBool>,
    ) -> Self {
        let planned_end = robot.pulses_to_joints(&shared.commanded_pulses());
        let scratch_idle = generator.state();
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
            scratch: generator,
            scratch_idle,
            buf: ReplyBuf::new(),
            feedback: wrc_board::Feedback::default(),
            reset_pending: None,
            estop_input: None,
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
        let line = self.buf.nak(to, code, text);
        self.out.send(from, line);
    }

    fn outstanding(&self) -> bool {
        self.tickets.iter().any(Option::is_some)
    }

    /// Abort every accepted motion and WAIT with ABS `code`.
    fn abort_all(&mut self, code: Code, text: &str) {
        for i in 0..MAX_TICKETS {
            if let Some(t) = self.tickets[i].take() {
                let line = self.buf.abs(t.to, code, text);
                self.out.send(t.from, line);
            }
        }
        for i in 0..MAX_WAITERS {
            if let Some((from, to)) = self.waiters[i].take() {
                let line = self.buf.abs(to, code, text);
                self.out.send(from, line);
            }
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
                self.out.send(from, line);
                if self.shared.state() == RobotState::Moving {
                    self.set_state(RobotState::Stopping);
                }
                self.abort_all(Code::Stopped, "stopped by STOP");
            }
            Urgent::Estop(from, to) => {
                let line = self.buf.ack(to, "");
                self.out.send(from, line);
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
        self.out.send(from, line);
        self.set_state(RobotState::Moving);
    }

    fn handle_request(&mut self, from: SourceId, request: Request) {
        let to = request.reply_to();
        let verb = request.command.verb();
        let owner = self.owner();
        if verb.spec().needs_control && owner != SourceId::NONE && owner != from {
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
                self.out.send(from, line);
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
                self.out.send(from, line);
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
                match self.robot.inverse(&pose, posture, Some(&self.planned_end)) {
                    Ok(end) => {
                        self.motion(from, to, MoveKind::Pose(pose, Some(posture)), end, false)
                    }
                    Err(e) => self.refuse(from, to, &wrc_motion::PlanError::Kinematics(e)),
                }
            }
            Command::MovL { pose } => {
                // Check the whole line from where the previous motion ends.
                self.scratch.restore(&self.scratch_idle);
                let start = self.robot.joints_to_pulses(&self.planned_end);
                let checked = self
                    .scratch
                    .set_position_pulses(&start)
                    .and_then(|()| self.scratch.plan_line(&pose));
                match checked {
                    Ok(_) => {
                        let end = match Posture::of(&self.robot, &self.planned_end) {
                            Some(p) => self
                                .robot
                                .inverse(&pose, p, Some(&self.planned_end))
                                .unwrap_or(self.planned_end),
                            None => self.planned_end,
                        };
                        self.motion(from, to, MoveKind::Line(pose), end, false)
                    }
                    Err(e) => self.refuse(from, to, &e),
                }
                self.scratch.restore(&self.scratch_idle);
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
                self.out.send(from, line);
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
                self.out.send(from, line);
            }
            Command::Out { n, on } => {
                let bit = 1u32 << n;
                if on {
                    self.shared.outputs[0].fetch_or(bit, Ordering::AcqRel);
                } else {
                    self.shared.outputs[0].fetch_and(!bit, Ordering::AcqRel);
                }
                let line = self.buf.ack(to, "");
                self.out.send(from, line);
            }
            Command::Wait => {
                let line = self.buf.ack(to, "");
                self.out.send(from, line);
                match self.waiters.iter().position(Option::is_none) {
                    Some(i) => self.waiters[i] = Some((from, to)),
                    None => {
                        let line = self.buf.abs(to, Code::Busy, "too many clients waiting");
                        self.out.send(from, line);
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
            Command::Help => {
                let line = self.buf.ack(to, HelpBody);
                self.out.send(from, line);
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
        self.out.send(from, line);
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
        // `text` borrows a local buffer; format into the reply buffer.
        let line = self.buf.nak(to, code, text);
        self.out.send(from, line);
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
        match done.outcome {
            MoveOutcome::Completed => {
                if t.home {
                    self.shared.homed.store(true, Ordering::Release);
                }
                let line = self.buf.inf(t.to, "");
                self.out.send(t.from, line);
            }
            MoveOutcome::Stopped => {
                let line = self.buf.abs(t.to, Code::Stopped, "stopped");
                self.out.send(t.from, line);
            }
            MoveOutcome::Refused(number) => {
                let code = Code::from_number(number).unwrap_or(Code::MotionFault);
                let line = self.buf.abs(t.to, code, code.text());
                self.out.send(t.from, line);
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
                self.out.send(from, line);
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

    /// One cycle (public for tests that step the task by hand).
    pub fn step(&mut self) {
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
        // State: MOVING and STOPPING end when nothing is queued, in flight or stopping.
        let at_rest = !self.outstanding()
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
                    self.out.send(from, line);
                }
            }
        }
    }
}

impl<B: MotionBoard + 'static> Task for CommandInterpreter<B> {
    fn cycle(&mut self, _ctx: &CycleContext) {
        self.step();
    }
}
