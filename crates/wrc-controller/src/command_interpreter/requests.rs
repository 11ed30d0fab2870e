//! Requests from every source (connections, the running program, a wafer job), after
//! admission: queries answered at once, settings, motions handed to the motion runner.

use std::fmt::Write as _;

use std::sync::atomic::Ordering;
use wrc_rt::FixedText;

use wrc_board::MotionBoard;
use wrc_protocol::{
    Code, Command, Event, HelpBody, IoBody, ReplyTo, Request, StatusBody, Verb, WhereBody,
};
use wrc_robot::{Posture, MAX_AXES};

use super::admission::{admit, Refused, Situation};
use super::{deliver, CommandInterpreter};
use crate::clients::source_name;
use crate::messages::{floor_char_boundary, MoveKind, SourceId, Urgent};
use crate::shared::StopKind;
use crate::velocity_generator::refusal_code;

/// The refusal of the running program's last request (its requests go through the same
/// checks as a connection's; a refusal is kept here instead of sent as a NAK).
#[derive(Clone, Copy)]
pub(super) struct Refusal {
    pub(super) code: Option<Code>,
    pub(super) text: [u8; 400],
    pub(super) len: usize,
}

impl Refusal {
    pub(super) fn record(&mut self, code: Code, text: &str) {
        let n = floor_char_boundary(text, self.text.len());
        self.text[..n].copy_from_slice(&text.as_bytes()[..n]);
        self.len = n;
        self.code = Some(code);
    }

    /// The recorded text.
    pub(super) fn text(&self) -> &str {
        std::str::from_utf8(&self.text[..self.len]).unwrap_or("refused")
    }
}

impl<B: MotionBoard> CommandInterpreter<B> {
    pub(super) fn handle_request(&mut self, from: SourceId, request: Request) {
        let to = request.reply_to();
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
        let state = self.shared.state();
        let situation = Situation {
            from,
            acting,
            owner,
            state,
            homed: self.shared.homed.load(Ordering::Acquire),
            job: self.job.is_some(),
            program: self.program.is_some(),
        };
        match admit(&request.command, &situation) {
            Ok(()) => {}
            Err(Refused::ControlHeld(owner)) => {
                let name = source_name(owner);
                let mut text = FixedText::<96>::new();
                let _ = write!(
                    text,
                    "control is held by {}; it must RELEASE first",
                    name.as_ref().map_or("another source", FixedText::as_str)
                );
                return self.nak(from, to, Code::ControlHeld, text.as_str());
            }
            Err(Refused::Interlock(code, text)) => return self.nak(from, to, code, text),
        }
        match request.command {
            Command::Status => {
                let name = source_name(owner);
                let body = StatusBody {
                    state,
                    homed: self.shared.homed.load(Ordering::Acquire),
                    speed_pct: f64::from(self.shared.speed_pct.load(Ordering::Acquire)),
                    owner: name.as_ref().map(FixedText::as_str),
                    err: Code::from_number(self.shared.error_code.load(Ordering::Acquire) as u16),
                };
                let line = self.buf.ack(to, body);
                deliver(&self.io.out, from, line);
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
                deliver(&self.io.out, from, line);
            }
            Command::Home => self.home(from, to),
            Command::Retract => self.retract_request(from, to),
            Command::MovJ { joints, .. } => match self.robot.check_joints(&joints) {
                Ok(()) => {
                    self.motion(from, to, MoveKind::Joints(joints), joints, false);
                }
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
                        self.motion(from, to, MoveKind::Pose(pose, Some(posture)), end, false);
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
                        self.motion(from, to, MoveKind::Line(pose), check.end_joints, false);
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
                let mut body = FixedText::<24>::new();
                let _ = write!(body, "speed={}", pct.round().clamp(1.0, 100.0) as u32);
                let line = self.buf.ack(to, body.as_str());
                deliver(&self.io.out, from, line);
            }
            // STOP and ESTOP from a connection take the urgent path; these are a program's
            // or a test's, which request the stop here.
            Command::Stop | Command::Estop => {
                let (urgent, kind) = if matches!(request.command, Command::Stop) {
                    (Urgent::Stop(from, to), StopKind::Stop)
                } else {
                    (Urgent::Estop(from, to), StopKind::Estop)
                };
                self.shared.request_stop(kind);
                self.handle_urgent(urgent);
            }
            Command::Hold => self.hold(from, to),
            Command::Resume => self.resume(from, to),
            Command::Reset => self.reset_request(from, to),
            Command::Io => {
                let body = IoBody {
                    inputs: self.shared.inputs[0].load(Ordering::Acquire),
                    outputs: self.shared.outputs[0].load(Ordering::Acquire),
                };
                let line = self.buf.ack(to, body);
                deliver(&self.io.out, from, line);
            }
            Command::Out { n, on, force } => self.out_request(from, to, n, on, force),
            Command::Wait => {
                let line = self.buf.ack(to, "");
                deliver(&self.io.out, from, line);
                match self.waiters.iter().position(Option::is_none) {
                    Some(i) => {
                        self.waiters[i] = Some(super::motion::Waiter {
                            from,
                            to,
                            ended: None,
                        })
                    }
                    None => {
                        let line = self.buf.abs(to, Code::Busy, "too many clients waiting");
                        deliver(&self.io.out, from, line);
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
            Command::Pause | Command::Continue(_) | Command::Abort => {
                self.program_control(from, to, request.command)
            }
            Command::Break(arg) => self.break_command(from, to, arg),
            Command::Step(kind) => self.step_command(from, to, kind),
            Command::Vars(names) => self.vars_command(from, to, &names),
            Command::Help => {
                let line = self.buf.ack(to, HelpBody);
                deliver(&self.io.out, from, line);
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

    pub(super) fn control_changed(&mut self, owner: Option<SourceId>, from: SourceId, to: ReplyTo) {
        let name = owner.and_then(source_name);
        let owner_name = name.as_ref().map(FixedText::as_str);
        let mut body = FixedText::<40>::new();
        let _ = write!(body, "owner={}", owner_name.unwrap_or("none"));
        let line = self.buf.ack(to, body.as_str());
        deliver(&self.io.out, from, line);
        let line = self.buf.event(false, &Event::Control { owner: owner_name });
        self.io.out.send(SourceId::BROADCAST, line);
    }

    pub(super) fn refuse(&mut self, from: SourceId, to: ReplyTo, err: &wrc_motion::PlanError) {
        let code = Code::from_number(refusal_code(err)).unwrap_or(Code::OutOfReach);
        let mut text = FixedText::<400>::new();
        let _ = write!(text, "{err}");
        self.nak(from, to, code, text.as_str());
    }

    /// A request of the controller's own (`source`: the program or a wafer job) through the
    /// checks every connection's request goes through (see [`Self::program_request`]).
    pub(super) fn internal_request(
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
}
