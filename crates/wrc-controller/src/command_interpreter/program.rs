//! The program runner of the Command Interpreter: runs the robot-language VM a fixed budget
//! per cycle; each motion statement becomes the request a connection would send, checked
//! the same way; DELAY and WAIT IN are deadlines on the cycle's clock; questions about the
//! cell and TEACH go to the service thread and wait for its answer; the operator answers
//! WAIT OPERATOR with CONTINUE.
//!
//! Errors: what the controller cannot carry out (a refused motion, a failed transfer, a
//! stop by a fault) is handed to the program as an error its TRY may catch — once the robot
//! stands still, so a handler never runs while the arm still brakes. The operator's STOP and
//! ABORT end the program.

use std::fmt::Write as _;

use std::sync::atomic::Ordering;
use wrc_rt::FixedText;

use wrc_board::MotionBoard;
use wrc_lang::{
    Answer, Motion, MoveOptions, PointValue, Program, Request as VmRequest, Resume,
    RuntimeErrorKind, SourcePos, Step, StepMode, Text, VmIo,
};
use wrc_protocol::{AxisArg, Code, Command, Event, ProgramName, ReplyTo};
use wrc_robot::Pose;

use super::blend::{Deferred, Pending};
use super::motion::motion_failure;
use super::{deliver, CommandInterpreter, PROGRAM_BUDGET, PROGRAM_REQUESTS};
use crate::messages::{MoveOutcome, ProgramAnswer, ProgramStart, SourceId, StoreRequest};
use crate::shared::RobotState;

/// The speed override of the motions a single STEP runs [%] (a reduced speed while an
/// engineer steps through a program, as a teach mode's).
pub const STEP_SPEED_PCT: f64 = 25.0;

/// How long a program's GET, PUT or MAP that the cell refuses as busy (the map still being
/// settled after a failed transfer) is asked again before it fails [ns].
const JOB_BUSY_RETRY_NS: u64 = 10_000_000_000;

/// How often it is asked again [ns].
const JOB_BUSY_PERIOD_NS: u64 = 100_000_000;

/// What a running program waits for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum ProgramWait {
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
    /// The same, refused as busy: asked again at `at` [ns] until `deadline` [ns].
    JobAgain { at: u64, deadline: u64 },
    /// A question about the cell or a TEACH: the service's answer.
    Answer,
    /// `WAIT OPERATOR`: the operator's CONTINUE.
    Operator,
    /// `RESET`: the board clearing the alarm.
    Reset,
    /// An error for the program (its TRY may catch it), handed over once the robot stands
    /// still.
    Failed(Code),
}

/// The program the Command Interpreter is running.
pub(super) struct RunningProgram {
    pub(super) from: SourceId,
    pub(super) to: ReplyTo,
    pub(super) name: ProgramName,
    pub(super) program: Box<Program>,
    pub(super) wait: ProgramWait,
    pub(super) paused: bool,
    /// The acceleration override of its motions (ACCEL) [%].
    pub(super) accel_pct: f64,
    /// A STEP is under way: its motions run at [`STEP_SPEED_PCT`] at most.
    pub(super) stepping: bool,
    /// The last GET, PUT or MAP asked for (asked again while the cell is busy).
    pub(super) job_request: Option<StoreRequest>,
    /// The text of the error being handed over ([`ProgramWait::Failed`]).
    pub(super) failure: FixedText<200>,
    /// A motion held back because it blends into the next.
    pub(super) pending: Option<Pending>,
    /// What runs once the awaited motion (a held one, ordered) has ended.
    pub(super) deferred: Option<Deferred>,
}

/// What a program reads synchronously: inputs, the pose where its last motion ended and
/// its run time.
pub(super) struct ProgramIo {
    pub(super) inputs: u32,
    pub(super) here: Pose,
    pub(super) seconds: f64,
}

impl VmIo for ProgramIo {
    fn input(&self, n: u8) -> bool {
        n < 32 && self.inputs & (1u32 << n) != 0
    }
    fn here(&self) -> Pose {
        self.here
    }
    fn seconds(&self) -> f64 {
        self.seconds
    }
}

/// The options of the next motion a program orders (consumed by the motion runner).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) struct NextMove {
    /// Its speed override [%] (the smaller of the statement's and the operator's).
    pub(super) speed_pct: Option<f64>,
    /// Its acceleration override [%].
    pub(super) accel_pct: Option<f64>,
}

/// A source file's name as events show it: the program's or library's name.
pub(super) fn file_label(program: &Program, file: u16) -> &str {
    let name = program
        .files()
        .get(usize::from(file))
        .map_or("?", String::as_str);
    name.strip_suffix(".wrl").unwrap_or(name)
}

impl<B: MotionBoard> CommandInterpreter<B> {
    /// `EVT PROGRAM <name> <state> [<detail>]` to everyone.
    pub(super) fn program_event(&mut self, name: ProgramName, state: &str, detail: &str) {
        let line = self.buf.event(
            false,
            &Event::Program {
                name: name.as_str(),
                state,
                detail,
            },
        );
        self.io.out.send(SourceId::BROADCAST, line);
    }

    /// `EVT PROGRAM <name> <state> <file>:<line>[ <text>]` at `pos`.
    fn program_event_at(&mut self, state: &str, pos: SourcePos, text: &str) {
        let Some(p) = self.program.as_ref() else {
            return;
        };
        let mut detail = FixedText::<400>::new();
        let _ = write!(detail, "{}:{}", file_label(&p.program, pos.file), pos.line);
        if !text.is_empty() {
            let _ = write!(detail, " {text}");
        }
        let name = p.name;
        self.program_event(name, state, detail.as_str());
    }

    /// `RUN`: the store compiled the program; start it unless something forbids it.
    pub(super) fn start_program(&mut self, start: ProgramStart) {
        let ProgramStart {
            from,
            to,
            name,
            program,
            step,
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
            let mut text = FixedText::<160>::new();
            let _ = write!(text, "{name}: {e}");
            self.nak(from, to, Code::ProgramInvalid, text.as_str());
            self.retire_program(program);
            return;
        }
        let line = self.buf.ack(to, "");
        deliver(&self.io.out, from, line);
        let mut files = FixedText::<400>::new();
        let _ = write!(files, "files=");
        for i in 0..program.files().len() {
            if i > 0 {
                let _ = files.write_str(",");
            }
            let _ = files.write_str(file_label(&program, i as u16));
        }
        self.program = Some(RunningProgram {
            from,
            to,
            name,
            program,
            wait: ProgramWait::Nothing,
            paused: false,
            accel_pct: 100.0,
            stepping: false,
            job_request: None,
            failure: FixedText::new(),
            pending: None,
            deferred: None,
        });
        self.program_started_ns = self.now_ns;
        self.apply_breakpoints();
        if step {
            self.vm.step(StepMode::Into);
        }
        self.program_event(name, "RUNNING", files.as_str());
    }

    pub(super) fn retire_program(&mut self, program: Box<Program>) {
        if let Err(e) = self.io.store.retired.try_send(program) {
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

    pub(super) fn end_program(&mut self, failure: Option<(Code, &str)>) {
        self.end_program_at(failure, None);
    }

    /// [`Self::end_program`] naming source position `at` (default: where the program is).
    pub(super) fn end_program_at(&mut self, failure: Option<(Code, &str)>, at: Option<SourcePos>) {
        let Some(p) = self.program.take() else {
            return;
        };
        self.shared.program_line.store(0, Ordering::Release);
        // A GET, PUT or MAP of the program's (ABORT, a refusal) ends with it and stops.
        if self.job.is_some_and(|j| j.from() == SourceId::PROGRAM) {
            self.end_job(Some(
                failure.unwrap_or((Code::Stopped, "the program that asked for it ended")),
            ));
        }
        let pos = at
            .or_else(|| self.vm.position(&p.program))
            .unwrap_or_default();
        self.vm.abort();
        match failure {
            None => {
                let line = self.buf.inf(p.to, "");
                deliver(&self.io.out, p.from, line);
            }
            Some((code, text)) => {
                let waiting = match p.wait {
                    ProgramWait::Motion(ticket) => Some(ticket),
                    _ => None,
                };
                self.abandon_motion(waiting, SourceId::PROGRAM);
                let mut body = FixedText::<400>::new();
                let _ = write!(body, "{} ", p.name);
                if pos.file != 0 {
                    let _ = write!(body, "{} ", file_label(&p.program, pos.file));
                }
                let _ = write!(body, "line {}: {text}", pos.line);
                let line = self.buf.abs(p.to, code, body.as_str());
                deliver(&self.io.out, p.from, line);
            }
        }
        self.program_event(p.name, "ENDED", "");
        self.retire_program(p.program);
    }

    /// The running program's statement could not be carried out: hand it `code` and `text`
    /// as an error (its TRY may catch it) once the robot stands still. A motion of the
    /// program's still under way is stopped, and its queued motions are dropped.
    pub(super) fn program_failed(&mut self, code: Code, text: &str) {
        let Some(p) = self.program.as_ref() else {
            return;
        };
        let waiting = match p.wait {
            ProgramWait::Motion(ticket) => Some(ticket),
            _ => None,
        };
        self.abandon_motion(waiting, SourceId::PROGRAM);
        if let Some(p) = self.program.as_mut() {
            p.wait = ProgramWait::Failed(code);
            p.failure = FixedText::new();
            let _ = p.failure.write_str(text);
            p.pending = None;
            p.deferred = None;
        }
    }

    /// Whether the robot is safe for an error handler: it stands still, nothing of the
    /// program's moves or brakes, no wafer job runs, and the cell service has settled every
    /// job that ended (a handler that asks `SLOT` after a failed `GET` reads the map as the
    /// journal and the sensors judged the failure, not as it was before).
    fn safe_for_handler(&self) -> bool {
        self.job.is_none()
            && self.map_settled()
            && self.stands_still()
            && !self
                .tickets
                .iter()
                .flatten()
                .any(|t| t.from == SourceId::PROGRAM)
            && self.shared.state() != RobotState::Stopping
    }

    /// `PAUSE`, `CONTINUE`, `ABORT`.
    pub(super) fn program_control(&mut self, from: SourceId, to: ReplyTo, command: Command) {
        let Some(p) = self.program.as_mut() else {
            return self.nak(from, to, Code::NoProgram, "no program is running");
        };
        let name = p.name;
        match command {
            Command::Pause => {
                let changed = !p.paused;
                p.paused = true;
                p.stepping = false;
                self.vm.cancel_step();
                let line = self.buf.ack(to, "");
                deliver(&self.io.out, from, line);
                if changed {
                    self.program_event(name, "PAUSED", "");
                }
            }
            Command::Continue(answer) => {
                let operator = p.wait == ProgramWait::Operator;
                let changed = p.paused || operator;
                p.paused = false;
                p.stepping = false;
                self.vm.cancel_step();
                if operator {
                    p.wait = ProgramWait::Nothing;
                    match answer.and_then(|a| Text::new(a.as_str())) {
                        Some(t) => self.vm.resume(Resume::Value(Answer::Text(t))),
                        None => self.vm.resume(Resume::Ok),
                    }
                }
                let line = self.buf.ack(to, "");
                deliver(&self.io.out, from, line);
                if changed {
                    self.program_event(name, "RUNNING", "");
                }
            }
            _ => {
                let line = self.buf.ack(to, "");
                deliver(&self.io.out, from, line);
                self.end_program(Some((Code::Stopped, "aborted by ABORT")));
            }
        }
    }

    /// A motion of the running program finished (the one it waits for, or one queued
    /// before it: a held run ordered ahead of the next motion).
    pub(super) fn program_motion_done(&mut self, ticket: u32, outcome: MoveOutcome) {
        let Some(p) = self.program.as_mut() else {
            return;
        };
        let awaited = p.wait == ProgramWait::Motion(ticket);
        match motion_failure(outcome) {
            None => {
                if !awaited {
                    return;
                }
                p.wait = ProgramWait::Nothing;
                match p.deferred.take() {
                    None => self.vm.resume(Resume::Ok),
                    Some(Deferred::End) => self.end_program(None),
                    Some(Deferred::Request(request)) => {
                        self.program_yield(request);
                    }
                }
            }
            // The operator's STOP ends the program.
            Some((Code::Stopped, text)) => self.end_program(Some((Code::Stopped, text))),
            Some((code, text)) => {
                if awaited || matches!(p.wait, ProgramWait::Motion(_)) {
                    self.program_failed(code, text);
                }
            }
        }
    }

    /// The operator's STOP, an E-stop or a fault ended every motion with `code`: STOP ends
    /// the program; anything else is an error for the program (handled once the robot
    /// stands still).
    pub(super) fn program_stopped(&mut self, code: Code, text: &str) {
        let Some(p) = self.program.as_ref() else {
            return;
        };
        if code == Code::Stopped {
            return self.end_program(Some((code, text)));
        }
        // A program between requests finds out at its next motion (refused in ERROR); one
        // that waits for something hears it now.
        if !matches!(p.wait, ProgramWait::Nothing | ProgramWait::Failed(_)) {
            self.program_failed(code, text);
        }
    }

    /// The service answered the program's question or TEACH.
    pub(super) fn program_answer(&mut self, answer: ProgramAnswer) {
        let Some(p) = self.program.as_mut() else {
            return;
        };
        if p.wait != ProgramWait::Answer {
            return;
        }
        match answer {
            ProgramAnswer::Value(a) => {
                p.wait = ProgramWait::Nothing;
                self.vm.resume(Resume::Value(a));
            }
            ProgramAnswer::Failed(r) => {
                p.wait = ProgramWait::Nothing;
                self.vm.fail(r.code.number(), r.text());
            }
        }
    }

    /// A RESET the program asked for was carried out (`refused`: it was not, and why).
    pub(super) fn program_reset_done(&mut self, refused: Option<(Code, &str)>) {
        let Some(p) = self.program.as_mut() else {
            return;
        };
        if p.wait != ProgramWait::Reset {
            return;
        }
        p.wait = ProgramWait::Nothing;
        match refused {
            None => self.vm.resume(Resume::Ok),
            Some((code, text)) => self.vm.fail(code.number(), text),
        }
    }

    /// A program's GET, PUT or MAP was refused: asked again while the cell is only busy
    /// settling the map, an error for the program otherwise.
    pub(super) fn program_job_refused(&mut self, code: Code, text: &str) {
        let now = self.now_ns;
        let Some(p) = self.program.as_mut() else {
            return;
        };
        let deadline = match p.wait {
            ProgramWait::Job => now.saturating_add(JOB_BUSY_RETRY_NS),
            ProgramWait::JobAgain { deadline, .. } => deadline,
            _ => return,
        };
        if code == Code::TransferBusy && now < deadline && p.job_request.is_some() {
            p.wait = ProgramWait::JobAgain {
                at: now.saturating_add(JOB_BUSY_PERIOD_NS),
                deadline,
            };
            return;
        }
        self.program_failed(code, text);
    }

    /// Hand one of the program's requests to the checks every connection's request goes
    /// through: `Ok` with the ticket of a queued motion, `Err` with the refusal's code (its
    /// text is in `self.refusal`).
    pub(super) fn program_request(&mut self, command: Command) -> Result<Option<u32>, Code> {
        self.internal_request(SourceId::PROGRAM, command)
    }

    /// Run the program for this cycle's budget, or check what it waits for.
    pub(super) fn run_program(&mut self) {
        while let Ok(answer) = self.io.store.answers.try_recv() {
            self.program_answer(answer);
        }
        let Some(p) = self.program.as_mut() else {
            return;
        };
        match p.wait {
            ProgramWait::Nothing => {}
            ProgramWait::Motion(_)
            | ProgramWait::Job
            | ProgramWait::Answer
            | ProgramWait::Operator
            | ProgramWait::Reset => return,
            ProgramWait::JobAgain { at, .. } => {
                if self.now_ns < at {
                    return;
                }
                let Some(request) = p.job_request else {
                    return;
                };
                p.wait = ProgramWait::Job;
                if self.io.store.requests.try_send(request).is_err() {
                    p.wait = ProgramWait::JobAgain {
                        at: self.now_ns.saturating_add(JOB_BUSY_PERIOD_NS),
                        deadline: self.now_ns,
                    };
                }
                return;
            }
            ProgramWait::Failed(code) => {
                if !self.safe_for_handler() {
                    return;
                }
                let Some(p) = self.program.as_mut() else {
                    return;
                };
                p.wait = ProgramWait::Nothing;
                let text = p.failure;
                self.vm.fail(code.number(), text.as_str());
            }
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
        if self.program.as_ref().is_some_and(|p| p.paused) {
            return;
        }
        // At most PROGRAM_BUDGET instructions between two requests, and at most
        // PROGRAM_REQUESTS requests carried out at once (PRINT, OUT, SPEED) per cycle.
        for _ in 0..PROGRAM_REQUESTS {
            let Some(p) = self.program.as_ref() else {
                return;
            };
            let here = match p.pending {
                Some(held) => held.end_pose(&self.robot),
                None => self.robot.forward(&self.planned_end),
            };
            let mut io = ProgramIo {
                inputs: self.shared.inputs[0].load(Ordering::Acquire),
                here,
                seconds: self.now_ns.saturating_sub(self.program_started_ns) as f64 * 1e-9,
            };
            let step = self.vm.run(&p.program, PROGRAM_BUDGET, &mut io);
            self.publish_line();
            match step {
                Step::Budget => return,
                Step::Done => {
                    // A held (blended) motion runs to its target first.
                    if self.flush_before(Deferred::End) {
                        self.end_program(None);
                    }
                    return;
                }
                Step::Break(pos) => {
                    if let Some(p) = self.program.as_mut() {
                        p.paused = true;
                        p.stepping = false;
                    }
                    self.program_event_at("PAUSED", pos, "");
                    return;
                }
                Step::Fault(e) => {
                    self.drop_pending();
                    let code = match e.kind {
                        RuntimeErrorKind::WaitTimeout => Code::WaitTimeout,
                        RuntimeErrorKind::Host { code } | RuntimeErrorKind::Raised { code } => {
                            Code::from_number(code).unwrap_or(Code::ProgramAlarm)
                        }
                        RuntimeErrorKind::NotLoaded | RuntimeErrorKind::InvalidProgram(_) => {
                            Code::Internal
                        }
                        _ => Code::ProgramError,
                    };
                    let mut text = FixedText::<300>::new();
                    if code == Code::ProgramAlarm {
                        let _ = write!(text, "alarm {}: ", e.kind.code());
                    }
                    let _ = write!(text, "{}", self.vm.error_text());
                    let pos = SourcePos {
                        line: e.line,
                        col: e.col,
                        file: e.file,
                    };
                    return self.end_program_at(Some((code, text.as_str())), Some(pos));
                }
                Step::Yield(request) => {
                    if !self.program_yield(request) {
                        return;
                    }
                }
            }
        }
    }

    /// Publish where the program is, for the status stream (file and line).
    fn publish_line(&self) {
        let Some(p) = self.program.as_ref() else {
            return;
        };
        let pos = self.vm.position(&p.program).unwrap_or_default();
        self.shared.program_line.store(
            (u64::from(pos.file) << 32) | u64::from(pos.line),
            Ordering::Release,
        );
    }

    /// The motion command a program's motion statement stands for; its options go to
    /// [`NextMove`].
    fn program_motion(&mut self, motion: Motion, options: MoveOptions) -> Option<Command> {
        let p = self.program.as_ref()?;
        let operator = self.speed_limit();
        let mut speed = options.speed_pct.map(|s| s.min(operator));
        if p.stepping {
            speed = Some(speed.unwrap_or(operator).min(STEP_SPEED_PCT));
        }
        self.next_move = super::program::NextMove {
            speed_pct: speed,
            accel_pct: Some(options.accel_pct.unwrap_or(p.accel_pct)),
        };
        Some(match motion {
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
            Motion::Arc { .. } => return None,
        })
    }

    /// Ask the service thread (a GET/PUT/MAP, a question, a TEACH); the program waits for
    /// `wait`. `false`: the queue is full (the program gets a busy error).
    fn ask_service(&mut self, request: StoreRequest, wait: ProgramWait) {
        if self.io.store.requests.try_send(request).is_err() {
            self.program_failed(
                Code::Busy,
                "the controller is busy; the request could not be made",
            );
        } else if let Some(p) = self.program.as_mut() {
            p.wait = wait;
        }
    }

    /// Carry out one request of the program; `true` when it may go on at once.
    pub(super) fn program_yield(&mut self, request: VmRequest) -> bool {
        use VmRequest as R;
        if let R::Move(motion, options) = request {
            if let Some(going_on) = self.blend_motion(motion, options) {
                return going_on;
            }
        } else if !self.flush_before(Deferred::Request(request)) {
            // A held (blended) motion runs to its target first; then this request.
            return false;
        }
        let command = match request {
            R::Move(motion, options) => match self.program_motion(motion, options) {
                Some(c) => c,
                None => {
                    self.vm.fail(
                        Code::NotAvailable.number(),
                        "ARC is not available on this controller yet",
                    );
                    return true;
                }
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
                self.io.out.send(SourceId::BROADCAST, line);
                self.vm.resume(Resume::Ok);
                return true;
            }
            // A program never forces a guarded output: that is an operator's decision.
            R::Out { n, on } => Command::Out {
                n,
                on,
                force: false,
            },
            R::Speed { pct } => Command::Speed(pct),
            R::Accel { pct } => {
                if let Some(p) = self.program.as_mut() {
                    p.accel_pct = pct;
                }
                self.vm.resume(Resume::Ok);
                return true;
            }
            R::Transfer { .. } | R::Swap { .. } | R::Map { .. } => {
                use crate::messages::cell_job::JobKind;
                use wrc_cell::Blade;
                let (kind, station, slot, blade) = match request {
                    R::Transfer {
                        kind,
                        station,
                        slot,
                        blade_b,
                    } => (
                        match kind {
                            wrc_lang::TransferKind::Get => JobKind::Get,
                            wrc_lang::TransferKind::Put => JobKind::Put,
                        },
                        station,
                        slot,
                        if blade_b { Blade::B } else { Blade::A },
                    ),
                    R::Swap { station, slot } => (JobKind::Swap, station, slot, Blade::A),
                    R::Map { station } => (JobKind::Map, station, 0, Blade::A),
                    _ => return true,
                };
                let request = StoreRequest::Job {
                    from: SourceId::PROGRAM,
                    to: ReplyTo::default(),
                    kind,
                    station,
                    slot,
                    blade,
                };
                if let Some(p) = self.program.as_mut() {
                    p.job_request = Some(request);
                }
                self.ask_service(request, ProgramWait::Job);
                return false;
            }
            R::Cell(query) => {
                self.ask_service(StoreRequest::Cell { query }, ProgramWait::Answer);
                return false;
            }
            R::Teach {
                point,
                joints,
                program,
            } => {
                let Some(p) = self.program.as_ref() else {
                    return false;
                };
                let value = if joints {
                    PointValue::Joints(self.planned_end)
                } else {
                    PointValue::Pose(self.robot.forward(&self.planned_end))
                };
                // A called program's TEACH goes to its own points file.
                let owner = program
                    .and_then(|n| ProgramName::new(n.as_str()))
                    .unwrap_or(p.name);
                let request = StoreRequest::TeachPoint {
                    program: owner,
                    point: ProgramName::new(point.as_str()).unwrap_or(p.name),
                    value,
                };
                self.ask_service(request, ProgramWait::Answer);
                return false;
            }
            R::Operator => {
                if let Some(p) = self.program.as_mut() {
                    p.wait = ProgramWait::Operator;
                }
                let pos = self
                    .program
                    .as_ref()
                    .and_then(|p| self.vm.position(&p.program))
                    .unwrap_or_default();
                let mut text = FixedText::<260>::new();
                let _ = text.write_str(self.vm.print_text());
                self.program_event_at("WAITING", pos, text.as_str());
                return false;
            }
            R::Alarm { code } => {
                let Some(p) = self.program.as_ref() else {
                    return false;
                };
                let pos = self.vm.position(&p.program).unwrap_or_default();
                let mut text = FixedText::<400>::new();
                let _ = write!(
                    text,
                    "{} {}:{}: {}",
                    p.name,
                    file_label(&p.program, pos.file),
                    pos.line,
                    self.vm.print_text()
                );
                let line = self.buf.event(
                    false,
                    &Event::Alarm {
                        code,
                        text: text.as_str(),
                    },
                );
                self.io.out.send(SourceId::BROADCAST, line);
                self.vm.resume(Resume::Ok);
                return true;
            }
            R::Reset => return self.program_reset(),
            _ => {
                self.vm.resume(Resume::Failed(RuntimeErrorKind::BadArgument(
                    "this controller cannot carry out that request",
                )));
                return true;
            }
        };
        let is_motion = matches!(request, R::Move(..));
        let result = self.program_request(command);
        self.next_move = NextMove::default();
        match result {
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
                // The text is copied out: the VM keeps its own copy.
                let refusal = self.refusal;
                self.vm.fail(code.number(), refusal.text());
                true
            }
        }
    }

    /// The program's `RESET`: clears a vacuum (212) or interlock (214) alarm as a host's
    /// RESET does; any other alarm needs the operator. `true`: go on at once.
    fn program_reset(&mut self) -> bool {
        let state = self.shared.state();
        let code = self.shared.error_code.load(Ordering::Acquire) as u16;
        match state {
            RobotState::Estop => {
                self.vm.fail(
                    Code::InEstop.number(),
                    "the robot is in ESTOP: only the operator's RESET clears an emergency stop",
                );
                return true;
            }
            RobotState::Error => {}
            // Nothing to clear.
            _ => {
                self.vm.resume(Resume::Ok);
                return true;
            }
        }
        if code != Code::WaferNotSensed.number() && code != Code::InterlockOpened.number() {
            let mut text = FixedText::<160>::new();
            let _ = write!(
                text,
                "a program's RESET clears a vacuum (212) or interlock (214) alarm; alarm {code} needs the operator's RESET"
            );
            self.vm.fail(Code::InError.number(), text.as_str());
            return true;
        }
        match self.program_request(Command::Reset) {
            Ok(_) => {
                if self.reset_pending.is_some() {
                    if let Some(p) = self.program.as_mut() {
                        p.wait = ProgramWait::Reset;
                    }
                    false
                } else {
                    self.vm.resume(Resume::Ok);
                    true
                }
            }
            Err(code) => {
                let refusal = self.refusal;
                self.vm.fail(code.number(), refusal.text());
                true
            }
        }
    }
}
