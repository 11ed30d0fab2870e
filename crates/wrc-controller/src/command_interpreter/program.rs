//! The program runner of the Command Interpreter: runs the robot-language VM a fixed budget
//! per cycle; each motion statement becomes the request a connection would send, checked
//! the same way; DELAY and WAIT IN are deadlines on the cycle's clock.

use std::fmt::Write as _;

use std::sync::atomic::Ordering;
use wrc_rt::FixedText;

use wrc_board::MotionBoard;
use wrc_lang::{Motion, Program, Resume, RuntimeErrorKind, Step, VmIo};
use wrc_protocol::{AxisArg, Code, Command, Event, ProgramName, ReplyTo};
use wrc_robot::Pose;

use super::motion::motion_failure;
use super::{deliver, CommandInterpreter, PROGRAM_BUDGET, PROGRAM_REQUESTS};
use crate::messages::{MoveOutcome, ProgramStart, SourceId};
use crate::shared::RobotState;

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
}

/// The program the Command Interpreter is running.
pub(super) struct RunningProgram {
    pub(super) from: SourceId,
    pub(super) to: ReplyTo,
    pub(super) name: ProgramName,
    pub(super) program: Box<Program>,
    pub(super) wait: ProgramWait,
    pub(super) paused: bool,
}

/// What a program reads synchronously: inputs and the pose where its last motion ended.
pub(super) struct ProgramIo {
    pub(super) inputs: u32,
    pub(super) here: Pose,
}

impl VmIo for ProgramIo {
    fn input(&self, n: u8) -> bool {
        n < 32 && self.inputs & (1u32 << n) != 0
    }
    fn here(&self) -> Pose {
        self.here
    }
}

impl<B: MotionBoard> CommandInterpreter<B> {
    pub(super) fn program_event(&mut self, name: ProgramName, state: &str) {
        let line = self.buf.event(
            false,
            &Event::Program {
                name: name.as_str(),
                state,
            },
        );
        self.io.out.send(SourceId::BROADCAST, line);
    }

    /// `RUN`: the store compiled the program; start it unless something forbids it.
    pub(super) fn start_program(&mut self, start: ProgramStart) {
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
            let mut text = FixedText::<160>::new();
            let _ = write!(text, "{name}: {e}");
            self.nak(from, to, Code::ProgramInvalid, text.as_str());
            self.retire_program(program);
            return;
        }
        let line = self.buf.ack(to, "");
        deliver(&self.io.out, from, line);
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

    /// [`Self::end_program`] naming source line `line` (default: where the program is).
    pub(super) fn end_program_at(&mut self, failure: Option<(Code, &str)>, line: Option<u32>) {
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
                deliver(&self.io.out, p.from, line);
            }
            Some((code, text)) => {
                let waiting = match p.wait {
                    ProgramWait::Motion(ticket) => Some(ticket),
                    _ => None,
                };
                self.abandon_motion(waiting, SourceId::PROGRAM);
                let mut body = FixedText::<400>::new();
                let _ = write!(body, "{} line {line_no}: {text}", p.name);
                let line = self.buf.abs(p.to, code, body.as_str());
                deliver(&self.io.out, p.from, line);
            }
        }
        self.program_event(p.name, "ENDED");
        self.retire_program(p.program);
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
                let line = self.buf.ack(to, "");
                deliver(&self.io.out, from, line);
                if changed {
                    self.program_event(name, "PAUSED");
                }
            }
            Command::Continue => {
                let changed = p.paused;
                p.paused = false;
                let line = self.buf.ack(to, "");
                deliver(&self.io.out, from, line);
                if changed {
                    self.program_event(name, "RUNNING");
                }
            }
            _ => {
                let line = self.buf.ack(to, "");
                deliver(&self.io.out, from, line);
                self.end_program(Some((Code::Stopped, "aborted by ABORT")));
            }
        }
    }

    /// A motion of the running program finished.
    pub(super) fn program_motion_done(&mut self, ticket: u32, outcome: MoveOutcome) {
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
    pub(super) fn program_request(&mut self, command: Command) -> Result<Option<u32>, Code> {
        self.internal_request(SourceId::PROGRAM, command)
    }

    /// Run the program for this cycle's budget, or check what it waits for.
    pub(super) fn run_program(&mut self) {
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
                    let mut text = FixedText::<200>::new();
                    let _ = write!(text, "{}", e.kind);
                    return self.end_program_at(Some((code, text.as_str())), Some(e.line));
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
    pub(super) fn program_yield(&mut self, request: wrc_lang::Request) -> bool {
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
                self.io.out.send(SourceId::BROADCAST, line);
                self.vm.resume(Resume::Ok);
                return true;
            }
            R::Out { n, on } => Command::Out { n, on },
            R::Speed { pct } => Command::Speed(pct),
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
                let asked = self
                    .io
                    .store
                    .requests
                    .try_send(crate::messages::StoreRequest::Job {
                        from: SourceId::PROGRAM,
                        to: ReplyTo::default(),
                        kind,
                        station,
                        slot,
                        blade,
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
}
