//! A program's blended motions: a motion statement with `BLEND` is held back until the
//! next statement's request, and the two become one move that does not stop in between —
//! a run of straight lines and arcs one path with rounded corners (`MoveKind::Path`), a PTP
//! into such a path (`PtpToPath`), a path into a PTP (`Depart`), a PTP through another's
//! target (`Via`). Any other request (PRINT, OUT, WAIT, GET, …) first lets the held motion
//! run to its target and stop, as without BLEND, so nothing the program does happens while
//! the robot is still on its way.
//!
//! Real-time: the held motion is a fixed-size value; checking a path (the same check as a
//! connection's MOVL) runs in the cycle that orders it.

use std::fmt::Write as _;
use std::sync::atomic::Ordering;

use wrc_board::MotionBoard;
use wrc_lang::{Blend, Motion, MoveOptions, Request as VmRequest, Resume};
use wrc_motion::{PathSegment, PathSpec, PlanError, MAX_PATH_SEGMENTS};
use wrc_protocol::{Code, Command, ReplyTo};
use wrc_robot::{Joints, Pose, Posture};
use wrc_rt::FixedText;

use super::admission::{admit, Refused, Situation};
use super::program::ProgramWait;
use super::CommandInterpreter;
use crate::messages::{MoveKind, SourceId};
use crate::velocity_generator::refusal_code;

/// What a program runs when its held motion has ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Deferred {
    /// The request that made it run to its target.
    Request(VmRequest),
    /// The program's end.
    End,
}

/// A program's motion held back because it blends into the next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Pending {
    /// The PTP the run starts with: its target joints.
    ptp: Option<Joints>,
    /// The lines and arcs (after the PTP, if any).
    path: Option<PathSpec>,
    /// The zone [mm] of the corner after the last segment (its BLEND).
    zone: f64,
    /// The order's speed and acceleration (the first motion's) [%].
    speed_pct: Option<f64>,
    accel_pct: f64,
    /// The path's speed (its first motion's) [%].
    path_pct: Option<f64>,
}

impl Pending {
    /// Where the held motion ends.
    pub(super) fn end_pose(&self, robot: &wrc_robot::Robot) -> Pose {
        match (self.path.as_ref().and_then(PathSpec::end), self.ptp) {
            (Some(p), _) => p,
            (None, Some(j)) => robot.forward(&j),
            (None, None) => Pose::default(),
        }
    }
}

/// What a program's motion is, for blending.
enum Kind {
    /// A PTP to these joints.
    Ptp(Joints),
    /// A line or an arc.
    Cartesian(PathSegment),
    /// One that does not blend (a jog).
    Other,
}

impl<B: MotionBoard> CommandInterpreter<B> {
    /// Where the program's motions end so far: the held one's end, else the last ordered.
    fn program_end_joints(&self) -> Joints {
        self.planned_end
    }

    /// The joints a PTP motion of the program goes to, from where its motions end.
    fn ptp_joints(&self, motion: &Motion, from: &Joints) -> Result<Option<Joints>, PlanError> {
        Ok(Some(match motion {
            Motion::Home => self.robot.home(),
            Motion::Joints(j) => {
                self.robot.check_joints(j)?;
                *j
            }
            Motion::Pose(pose, posture) => {
                let posture = posture
                    .or_else(|| Posture::of(&self.robot, from))
                    .unwrap_or(Posture::Right);
                wrc_motion::ptp_target(&self.robot, from, pose, posture)?
            }
            _ => return Ok(None),
        }))
    }

    /// The program may go on: resume it (its blended motion is held).
    fn program_goes_on(&mut self) -> bool {
        self.vm.resume(Resume::Ok);
        true
    }

    /// A program's motion statement, blended with the held one or held itself when it
    /// blends: `Some(going_on)` when it is taken care of here, `None` when it is an
    /// ordinary motion (no blend involved) for the usual path.
    pub(super) fn blend_motion(&mut self, motion: Motion, options: MoveOptions) -> Option<bool> {
        let pending = self.program.as_ref()?.pending;
        let joining = !matches!(options.blend, Blend::Stop);
        if pending.is_none() && !joining && !matches!(motion, Motion::Arc { .. }) {
            return None;
        }
        let operator = self.speed_limit();
        let accel = options
            .accel_pct
            .or_else(|| self.program.as_ref().map(|p| p.accel_pct))
            .unwrap_or(100.0);
        let speed = options.speed_pct.map(|s| s.min(operator));
        let zone = match options.blend {
            Blend::Zone(mm) => mm,
            _ => 0.0,
        };
        let from = match &pending {
            Some(p) => match (p.path.as_ref().and_then(PathSpec::end), p.ptp) {
                (None, Some(j)) => j,
                _ => self.program_end_joints(),
            },
            None => self.program_end_joints(),
        };
        let kind = match motion {
            Motion::Line(to) => Kind::Cartesian(PathSegment::Line { to, blend_mm: 0.0 }),
            Motion::Arc { via, to } => Kind::Cartesian(PathSegment::Arc {
                via,
                to,
                blend_mm: 0.0,
            }),
            Motion::Home | Motion::Joints(_) | Motion::Pose(..) => {
                match self.ptp_joints(&motion, &from) {
                    Ok(Some(j)) => Kind::Ptp(j),
                    Ok(None) => Kind::Other,
                    Err(e) => {
                        let code = Code::from_number(refusal_code(&e)).unwrap_or(Code::OutOfReach);
                        let mut text = FixedText::<400>::new();
                        let _ = write!(text, "{e}");
                        self.drop_pending();
                        self.vm.fail(code.number(), text.as_str());
                        return Some(true);
                    }
                }
            }
            Motion::Jog { .. } => Kind::Other,
        };
        let Some(mut p) = pending else {
            // Nothing held: this motion starts a held run (it blends), or it is an ARC.
            let start_pose = self.robot.forward(&self.planned_end);
            let mut held = Pending {
                ptp: None,
                path: None,
                zone,
                speed_pct: speed,
                accel_pct: accel,
                path_pct: speed,
            };
            match kind {
                Kind::Ptp(j) => held.ptp = Some(j),
                Kind::Cartesian(seg) => {
                    let mut spec = PathSpec::new(start_pose);
                    let _ = spec.push(seg);
                    held.path = Some(spec);
                }
                Kind::Other => return None,
            }
            if joining {
                self.set_pending(Some(held));
                return Some(self.program_goes_on());
            }
            // An ARC that does not blend: a path of one arc.
            return Some(self.order_pending(held, None));
        };
        match kind {
            Kind::Cartesian(seg) => match p.path.as_mut() {
                Some(spec) if spec.len < MAX_PATH_SEGMENTS => {
                    // The corner before this segment takes the previous motion's zone.
                    if let Some(last) = spec.segments.get_mut(spec.len - 1) {
                        set_blend(last, p.zone);
                    }
                    let _ = spec.push(seg);
                    p.zone = zone;
                    if joining {
                        self.set_pending(Some(p));
                        return Some(self.program_goes_on());
                    }
                    Some(self.order_pending(p, None))
                }
                Some(_) => {
                    // Full: the held path runs to its end, this one starts anew.
                    self.order_pending_queued(p)?;
                    self.blend_motion(motion, options)
                }
                None => {
                    // A PTP into a path.
                    let start = p.ptp.map_or(Pose::default(), |j| self.robot.forward(&j));
                    let mut spec = PathSpec::new(start);
                    let _ = spec.push(seg);
                    p.path = Some(spec);
                    p.path_pct = speed;
                    p.zone = zone;
                    if joining {
                        self.set_pending(Some(p));
                        return Some(self.program_goes_on());
                    }
                    Some(self.order_pending(p, None))
                }
            },
            Kind::Ptp(j) => {
                if p.path.is_some() && p.ptp.is_some() {
                    // A PTP into a path is one move; the path stops before this PTP.
                    self.order_pending_queued(p)?;
                    self.set_pending(None);
                    return self.blend_motion(motion, options);
                }
                Some(self.order_pending(p, Some(j)))
            }
            Kind::Other => {
                self.order_pending_queued(p)?;
                self.set_pending(None);
                None
            }
        }
    }

    fn set_pending(&mut self, pending: Option<Pending>) {
        if let Some(prog) = self.program.as_mut() {
            prog.pending = pending;
        }
    }

    /// Forget the held motion (the program ends or failed before it was ordered).
    pub(super) fn drop_pending(&mut self) {
        self.set_pending(None);
    }

    /// A request that is not a blendable motion while one is held: let the held motion run
    /// to its target first, then carry `then` out. `true` when nothing was held.
    pub(super) fn flush_before(&mut self, then: Deferred) -> bool {
        let Some(p) = self.program.as_ref().and_then(|p| p.pending) else {
            return true;
        };
        self.set_pending(None);
        match self.order_kind(p, None) {
            Ok(ticket) => {
                if let Some(prog) = self.program.as_mut() {
                    prog.wait = ProgramWait::Motion(ticket);
                    prog.deferred = Some(then);
                }
            }
            Err(code) => {
                let text = self.refusal;
                if then == Deferred::End {
                    // The program has ended: it ends with the refusal.
                    self.end_program(Some((code, text.text())));
                } else {
                    self.program_failed(code, text.text());
                }
            }
        }
        false
    }

    /// Order the held run `p`, ending in the PTP to `then` if given; the program waits for
    /// it. `false` (the program waits).
    fn order_pending(&mut self, p: Pending, then: Option<Joints>) -> bool {
        self.set_pending(None);
        match self.order_kind(p, then) {
            Ok(ticket) => {
                if let Some(prog) = self.program.as_mut() {
                    prog.wait = ProgramWait::Motion(ticket);
                }
                false
            }
            Err(code) => {
                let text = self.refusal;
                self.vm.fail(code.number(), text.text());
                true
            }
        }
    }

    /// Order the held run `p` without waiting for it (a motion follows it in the queue).
    /// `None` when it was refused (the program was told).
    fn order_pending_queued(&mut self, p: Pending) -> Option<()> {
        self.set_pending(None);
        match self.order_kind(p, None) {
            Ok(_) => Some(()),
            Err(code) => {
                let text = self.refusal;
                self.vm.fail(code.number(), text.text());
                None
            }
        }
    }

    /// The move of a held run (ending at rest, or in a PTP to `then`), checked and ordered
    /// as a connection's motion is: its ticket, or the refusal's code (its text recorded in
    /// `self.refusal`).
    fn order_kind(&mut self, p: Pending, then: Option<Joints>) -> Result<u32, Code> {
        let start = self
            .robot
            .pulses_to_joints(&self.robot.joints_to_pulses(&self.planned_end));
        let operator = self.speed_limit();
        let path_pct = p.path_pct.unwrap_or(operator).min(operator);
        let check = |robot: &wrc_robot::Robot, from: &Joints, path: &PathSpec| {
            wrc_motion::check_path(robot, from, path).map_err(|e| {
                let code = Code::from_number(refusal_code(&e)).unwrap_or(Code::PathLeavesWorkspace);
                (code, e)
            })
        };
        let planned = match (p.ptp, p.path, then) {
            (Some(via), None, Some(to)) => Ok((
                MoveKind::Via {
                    start: self.planned_end,
                    via,
                    to,
                },
                to,
            )),
            (Some(j), None, None) => Ok((MoveKind::Joints(j), j)),
            (None, Some(mut path), None) => {
                path.start = self.robot.forward(&start);
                check(&self.robot, &start, &path).map(|c| (MoveKind::Path(path), c.end_joints))
            }
            (None, Some(mut path), Some(to)) => {
                path.start = self.robot.forward(&start);
                check(&self.robot, &start, &path)
                    .map(|_| (MoveKind::Depart { path, to, path_pct }, to))
            }
            (Some(via), Some(path), _) => check(&self.robot, &via, &path).map(|c| {
                (
                    MoveKind::PtpToPath {
                        via,
                        path,
                        path_pct,
                    },
                    c.end_joints,
                )
            }),
            (None, None, _) => return Err(self.record_refusal(Code::Internal, &"an empty blend")),
        };
        let (kind, end) = match planned {
            Ok(planned) => planned,
            Err((code, e)) => return Err(self.record_refusal(code, &e)),
        };
        if let Err((code, text)) = self.admit_program_motion() {
            return Err(self.record_refusal(code, &text));
        }
        self.next_move = super::program::NextMove {
            speed_pct: p.speed_pct,
            accel_pct: Some(p.accel_pct),
        };
        self.refusal.code = None;
        let ticket = self.motion(SourceId::PROGRAM, ReplyTo::default(), kind, end, false);
        self.next_move = super::program::NextMove::default();
        // A refused motion recorded its own refusal.
        ticket.ok_or_else(|| *self.refusal.code.get_or_insert(Code::Busy))
    }

    /// Record refusal `code` with `text` in `self.refusal`; the code.
    fn record_refusal(&mut self, code: Code, text: &dyn std::fmt::Display) -> Code {
        let mut t = FixedText::<400>::new();
        let _ = write!(t, "{text}");
        self.refusal.record(code, t.as_str());
        code
    }

    /// The admission a connection's motion goes through, for a program's move.
    fn admit_program_motion(&self) -> Result<(), (Code, &'static str)> {
        let acting = self.program.as_ref().map_or(SourceId::PROGRAM, |p| p.from);
        let situation = Situation {
            from: SourceId::PROGRAM,
            acting,
            owner: self.owner(),
            state: self.shared.state(),
            homed: self.shared.homed.load(Ordering::Acquire),
            job: self.job.is_some(),
            program: true,
        };
        let stand_in = Command::MovL {
            pose: Pose::default(),
        };
        match admit(&stand_in, &situation) {
            Ok(()) => Ok(()),
            Err(Refused::ControlHeld(_)) => {
                Err((Code::ControlHeld, "control is held by another source"))
            }
            Err(Refused::Interlock(code, text)) => Err((code, text)),
        }
    }
}

fn set_blend(seg: &mut PathSegment, zone: f64) {
    match seg {
        PathSegment::Line { blend_mm, .. } | PathSegment::Arc { blend_mm, .. } => *blend_mm = zone,
    }
}
