//! The motion runner of the Command Interpreter: tickets of accepted motions, orders to the
//! Velocity Generator, their ends (INF/ABS), WAIT, and aborting everything on a stop. The
//! Pulse Generator reports a move's end once the arm stands still on the board, a stopped or
//! held one too; WAIT is answered then.

use std::fmt::Write as _;
use std::sync::atomic::Ordering;

use wrc_board::MotionBoard;
use wrc_cell::obstacle::TravelRoute;
use wrc_protocol::Num;
use wrc_protocol::{Code, Event, ReplyTo};
use wrc_robot::Joints;
use wrc_rt::FixedText;

use super::{deliver, CommandInterpreter, MAX_TICKETS};
use crate::messages::{MoveDone, MoveKind, MoveOrder, MoveOutcome, SourceId};
use crate::shared::{RobotState, StopKind};

/// An accepted motion, open until its INF or ABS.
#[derive(Debug, Clone, Copy)]
pub(super) struct Ticket {
    pub(super) ticket: u32,
    pub(super) from: SourceId,
    pub(super) to: ReplyTo,
    pub(super) home: bool,
    /// The order that carries it out from wherever the motions before it ended, as
    /// admitted: a PTP or jog to its checked joint target, a line to its pose. `RESUME`
    /// sends it again after a HOLD: a PTP then continues on its joint-space line, a line on
    /// its line, to the same target.
    pub(super) resume: MoveKind,
    /// The motion's own speed (a program's `SPEED` option) [%]; `None`: the operator's.
    /// RESUME keeps it, below the override then in force.
    pub(super) speed_pct: Option<f64>,
    /// The motion's acceleration override [%]; RESUME keeps it.
    pub(super) accel_pct: f64,
    /// The joints where it ends (where the motions queued after it start).
    pub(super) end: Joints,
    /// The Pulse Generator reported it held (it was braking when HOLD came).
    pub(super) held: bool,
}

/// A client's `WAIT`, answered once the arm stands still and nothing is open or queued.
#[derive(Debug, Clone, Copy)]
pub(super) struct Waiter {
    pub(super) from: SourceId,
    pub(super) to: ReplyTo,
    /// The stop or alarm that ended the motions it waited for abnormally: its `ABS` code.
    pub(super) ended: Option<Code>,
}

/// How a motion may go, checked against the cell. (The route is held by value on purpose:
/// boxing it would allocate in the real-time cycle.)
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
enum Cleared {
    /// As asked.
    Go,
    /// A jog stopped short: these pulses, ending at these joints.
    Shortened { pulses: i64, end: Joints },
    /// A PTP through these via points.
    Route(TravelRoute),
    /// Not at all (the text says why).
    Refused,
}

/// Where a HOLD stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Hold {
    /// No HOLD.
    None,
    /// Braking on the path after HOLD.
    Braking,
    /// At rest; the open tickets wait for RESUME.
    Held,
}

/// How a motion's end ends the program or job that waited for it: `None` when it completed.
pub(super) fn motion_failure(outcome: MoveOutcome) -> Option<(Code, &'static str)> {
    match outcome {
        MoveOutcome::Completed | MoveOutcome::Held => None,
        MoveOutcome::Stopped => Some((Code::Stopped, "stopped")),
        MoveOutcome::Refused(number) => {
            let code = Code::from_number(number).unwrap_or(Code::MotionFault);
            Some((code, code.text()))
        }
    }
}

impl<B: MotionBoard> CommandInterpreter<B> {
    pub(super) fn outstanding(&self) -> bool {
        self.tickets.iter().any(Option::is_some)
    }

    /// Abort every accepted motion with ABS `code` now; every WAIT gets ABS `code` once the
    /// arm stands still.
    pub(super) fn abort_all(&mut self, code: Code, text: &str) {
        self.hold = Hold::None;
        if self.job.is_some() {
            self.end_job(Some((code, text)));
        }
        for i in 0..MAX_TICKETS {
            if let Some(t) = self.tickets[i].take() {
                if t.from == SourceId::CELL {
                    continue;
                }
                let line = self.buf.abs(t.to, code, text);
                deliver(&self.io.out, t.from, line);
            }
        }
        for w in self.waiters.iter_mut().flatten() {
            w.ended.get_or_insert(code);
        }
        self.program_stopped(code, text);
    }

    pub(super) fn new_ticket(
        &mut self,
        from: SourceId,
        to: ReplyTo,
        home: bool,
        resume: MoveKind,
        end: Joints,
    ) -> Option<u32> {
        let speed_pct = self.next_move.speed_pct;
        let accel_pct = self.next_move.accel_pct.unwrap_or(100.0);
        let slot = self.tickets.iter().position(Option::is_none)?;
        let ticket = self.next_ticket;
        self.next_ticket = self.next_ticket.wrapping_add(1).max(1);
        self.tickets[slot] = Some(Ticket {
            ticket,
            from,
            to,
            home,
            resume,
            speed_pct,
            accel_pct,
            end,
            held: false,
        });
        Some(ticket)
    }

    /// Validate and queue a motion; ACK or NAK. Returns its ticket when it was queued.
    ///
    /// Every motion is first checked against the cell ([`super::clearance`]): a PTP that
    /// would touch it goes round through the travel height (its legs queued ahead of it,
    /// `ACK <id> route=travel`), a jog stops short of it (`ACK <id> limited=<name>
    /// jog=<pulses>`), anything else is refused with `NAK 117` naming what it would touch
    /// and where.
    pub(super) fn motion(
        &mut self,
        from: SourceId,
        to: ReplyTo,
        kind: MoveKind,
        end: Joints,
        home: bool,
    ) -> Option<u32> {
        let mut note = FixedText::<400>::new();
        match self.clear_of_cell(kind, end, &mut note) {
            Cleared::Go => self.queue_motion(from, to, kind, end, home, note.as_str()),
            Cleared::Shortened { pulses, end } => {
                let MoveKind::Jog { axis, .. } = kind else {
                    return None;
                };
                let kind = MoveKind::Jog { axis, pulses };
                self.queue_motion(from, to, kind, end, home, note.as_str())
            }
            Cleared::Route(route) => {
                if self.tickets.iter().filter(|t| t.is_none()).count() <= route.len {
                    self.nak(from, to, Code::Busy, "too many motions queued; WAIT first");
                    return None;
                }
                for via in route.via() {
                    let here = self.robot.joints_to_pulses(&self.planned_end);
                    if self.robot.joints_to_pulses(via) == here {
                        continue;
                    }
                    let leg = self.queue_motion(
                        SourceId::NONE,
                        ReplyTo::default(),
                        MoveKind::Joints(*via),
                        *via,
                        false,
                        "",
                    );
                    if leg.is_none() {
                        // The legs queued so far take the arm to a checked via point.
                        self.nak(from, to, Code::Busy, "too many motions queued; WAIT first");
                        return None;
                    }
                }
                // From the route's last via point the target's joints, as checked (a pose
                // from there could pick another solution).
                let kind = match kind {
                    MoveKind::Pose(..) => MoveKind::Joints(end),
                    other => other,
                };
                self.queue_motion(from, to, kind, end, home, note.as_str())
            }
            Cleared::Refused => {
                self.nak(from, to, Code::Collision, note.as_str());
                None
            }
        }
    }

    /// Queue a motion checked against the cell; ACK with `note` (empty: a plain ACK) or NAK
    /// when the queues are full. Returns its ticket when it was queued.
    fn queue_motion(
        &mut self,
        from: SourceId,
        to: ReplyTo,
        kind: MoveKind,
        end: Joints,
        home: bool,
        note: &str,
    ) -> Option<u32> {
        // A line, a path or a blend is resumed as itself (the Velocity Generator finds where
        // on it the arm stands); every other motion as a PTP to the joint target admission
        // checked (the one the Velocity Generator goes to).
        let resume = match kind {
            MoveKind::Line(_)
            | MoveKind::Approach { .. }
            | MoveKind::Path(_)
            | MoveKind::PtpToPath { .. }
            | MoveKind::Depart { .. }
            | MoveKind::Via { .. } => kind,
            MoveKind::Joints(_) | MoveKind::Pose(..) | MoveKind::Jog { .. } => {
                MoveKind::Joints(end)
            }
        };
        let Some(ticket) = self.new_ticket(from, to, home, resume, end) else {
            self.nak(from, to, Code::Busy, "too many motions queued; WAIT first");
            return None;
        };
        let order = MoveOrder {
            ticket,
            epoch: self.shared.stop_epoch.load(Ordering::Acquire),
            ..self.order_for(kind)
        };
        if self.io.orders.try_send(order).is_err() {
            if let Some(t) = self
                .tickets
                .iter_mut()
                .find(|t| t.is_some_and(|t| t.ticket == ticket))
            {
                *t = None;
            }
            self.nak(from, to, Code::Busy, "too many motions queued; WAIT first");
            return None;
        }
        self.planned_end = end;
        let line = self.buf.ack(to, note);
        deliver(&self.io.out, from, line);
        self.set_state(RobotState::Moving);
        Some(ticket)
    }

    /// The order a motion of `kind` would get now (speed and acceleration as `queue_motion`
    /// gives them).
    fn order_for(&self, kind: MoveKind) -> MoveOrder {
        let operator = self.speed_limit();
        MoveOrder {
            ticket: 0,
            epoch: 0,
            speed_pct: self
                .next_move
                .speed_pct
                .map_or(operator, |s| s.min(operator)),
            accel_pct: self.next_move.accel_pct.unwrap_or(100.0),
            kind,
        }
    }

    /// Whether a motion of `kind` from where the queued motions end keeps clear of the cell,
    /// and if not, how it may go anyway (see [`Self::motion`]); `note` gets the ACK's note
    /// or the refusal's text.
    fn clear_of_cell(&mut self, kind: MoveKind, end: Joints, note: &mut FixedText<400>) -> Cleared {
        let Some(mut cell) = self.cell.take() else {
            return Cleared::Go;
        };

        let verdict = self.check_with(&mut cell, kind, end, note);
        self.cell = Some(cell);
        verdict
    }

    fn check_with(
        &mut self,
        cell: &mut super::clearance::CellCheck,
        kind: MoveKind,
        end: Joints,
        note: &mut FixedText<400>,
    ) -> Cleared {
        if !cell.active() {
            return Cleared::Go;
        }
        let sensed = self.vacuum_sensed_all();
        let start = self.robot.joints_to_pulses(&self.planned_end);
        let touch = match cell.check(&self.robot, &self.order_for(kind), &start, sensed) {
            Ok(_) => return Cleared::Go,
            Err(t) => t,
        };
        // A target that touches the cell is refused: no way to it helps.
        if !matches!(kind, MoveKind::Jog { .. }) {
            if let Some(c) = cell.target_touch(&self.robot, &self.planned_end, &end, sensed) {
                let _ = write!(
                    note,
                    "the target would put {} into {} {} ({}): a station is entered only along its line, an obstacle never",
                    c.body.describe(),
                    c.kind,
                    c.name,
                    PoseText(self.robot.forward(&end))
                );
                return Cleared::Refused;
            }
        }
        // A PTP goes round through the travel height; a jog stops short.
        let target = match kind {
            MoveKind::Joints(j) => Some(j),
            MoveKind::Pose(..) => Some(end),
            MoveKind::Approach { via, .. } | MoveKind::PtpToPath { via, .. } => Some(via),
            _ => None,
        };
        let travel = cell.travel_z(&self.robot, sensed);
        if let (Some(target), Some(z)) = (target, travel) {
            let last = match kind {
                MoveKind::Pose(..) => MoveKind::Joints(end),
                other => other,
            };
            for route in
                wrc_cell::obstacle::travel_routes(&self.robot, &self.planned_end, &target, z)
                    .into_iter()
                    .flatten()
            {
                let mut at = start;
                let legs = route
                    .via()
                    .iter()
                    .map(|q| MoveKind::Joints(*q))
                    .chain([last]);
                let mut clear = true;
                for leg in legs {
                    match cell.check(&self.robot, &self.order_for(leg), &at, sensed) {
                        Ok(q) => at = self.robot.joints_to_pulses(&q),
                        Err(_) => {
                            clear = false;
                            break;
                        }
                    }
                }
                if clear {
                    let _ = write!(note, "route=travel");
                    return Cleared::Route(route);
                }
            }
        }
        if let MoveKind::Jog { axis, pulses } = kind {
            if let Some((pulses, end)) = self.longest_clear_jog(cell, axis, pulses, sensed) {
                let _ = write!(note, "limited={} jog={pulses}", touch.contact.name);
                return Cleared::Shortened { pulses, end };
            }
        }
        let verdict = self.describe_touch(&touch, travel, target.is_some(), note);
        // From inside a station the way out is its line.
        let here = self.robot.forward(&self.planned_end);
        if let Some(plan) = cell.retract_from(&here, false) {
            let _ = write!(
                note,
                "; the hand is inside {}: RETRACT or HOME takes it straight out first",
                plan.station
            );
        }
        verdict
    }

    /// The longest jog of `axis` towards `pulses` that keeps clear of the cell, if one of a
    /// pulse at least does: its pulses and its end.
    fn longest_clear_jog(
        &self,
        cell: &mut super::clearance::CellCheck,
        axis: usize,
        pulses: i64,
        sensed: [bool; wrc_cell::MAX_BLADES],
    ) -> Option<(i64, Joints)> {
        let start = self.robot.joints_to_pulses(&self.planned_end);
        let sign = pulses.signum();
        let (mut lo, mut hi) = (0i64, pulses.abs());
        let step = (hi / 1000).max(1);
        let mut best = None;
        while hi - lo > step {
            let mid = lo + (hi - lo) / 2;
            let order = self.order_for(MoveKind::Jog {
                axis,
                pulses: sign * mid,
            });
            match cell.check(&self.robot, &order, &start, sensed) {
                Ok(q) => {
                    lo = mid;
                    best = Some((sign * mid, q));
                }
                Err(_) => hi = mid,
            }
        }
        best
    }

    /// The refusal's text for `touch` (`route`: a route was looked for).
    fn describe_touch(
        &self,
        touch: &super::clearance::Touch,
        travel: Option<f64>,
        route: bool,
        note: &mut FixedText<400>,
    ) -> Cleared {
        let c = &touch.contact;
        let (body, what, name) = (c.body.describe(), c.kind, c.name);
        let at = PoseText(self.robot.forward(&touch.joints));
        let pct = (touch.fraction * 100.0).round();
        let _ = if touch.brake {
            write!(
                note,
                "a stop at {pct} % of the motion would brake {body} into {what} {name} ({at})"
            )
        } else {
            write!(
                note,
                "{body} would touch {what} {name} at {pct} % of the motion ({at})"
            )
        };
        let _ = note.write_str(": a station is entered only along its line, an obstacle never");
        if route {
            let _ = match travel {
                Some(z) => write!(
                    note,
                    "; no route through the travel height (z={}) is clear either",
                    Num(z)
                ),
                None => note.write_str("; the cell declares no travel height to go round it"),
            };
        }
        Cleared::Refused
    }

    /// The speed override a motion may use now [%]: the operator's, below the careful
    /// speed while a blade perhaps holds an unclamped wafer (after a power loss).
    pub(super) fn speed_limit(&self) -> f64 {
        let operator = f64::from(self.shared.speed_pct.load(Ordering::Acquire));
        match self.shared.careful_pct.load(Ordering::Acquire) {
            0 => operator,
            careful => operator.min(f64::from(careful)),
        }
    }

    /// `HOME`: a hand left inside a station (by a power loss, a fault, a program or an
    /// operator; the cell service says which) is first taken straight out to the station's
    /// approach pose, slowly; then every axis goes home by PTP (at the station's speed when
    /// a blade may hold a wafer).
    pub(super) fn home(&mut self, from: SourceId, to: ReplyTo) {
        let home = self.robot.home();
        let mut speed = None;
        if let Some(plan) = self.retract_plan() {
            if let Err(text) = self.start_retract(SourceId::NONE, ReplyTo::default(), &plan) {
                return self.nak(from, to, Code::HandInside, text.as_str());
            }
            speed = plan.careful.then_some(plan.speed_pct);
        }
        self.next_move.speed_pct = speed;
        self.motion(from, to, MoveKind::Joints(home), home, true);
        self.next_move = super::program::NextMove::default();
    }

    /// `RETRACT`: take a hand left inside a station straight out to its approach pose.
    pub(super) fn retract_request(&mut self, from: SourceId, to: ReplyTo) {
        let Some(plan) = self.retract_plan() else {
            return self.nak(
                from,
                to,
                Code::BadArgument,
                "the hand is not inside a station: nothing to retract",
            );
        };
        if let Err(text) = self.start_retract(from, to, &plan) {
            self.nak(from, to, Code::HandInside, text.as_str());
        }
    }

    /// The retract the cell service planned, if the hand (where the queued motions end) is
    /// still past the station's approach pose (a plan the hand has left, moved out since, is
    /// dropped); otherwise the way out of the station the hand is inside now, from the
    /// stations' lines (an operator who moved in to teach, a program stopped inside).
    fn retract_plan(&mut self) -> Option<crate::messages::cell_job::RetractPlan> {
        let here = self.robot.forward(&self.planned_end);
        if let Some(plan) = self.retract {
            if plan.inside(&here) {
                return Some(plan);
            }
            self.retract = None;
        }
        let sensed = self.vacuum_sensed_all().iter().any(|s| *s);
        self.cell.as_mut()?.retract_from(&here, sensed)
    }

    /// Queue the retract of `plan` (its reply to `from`); the reason when the hand is not on
    /// the station's line any more (it was jogged) or the line is refused.
    // The reason is a fixed buffer on purpose: the real-time task does not allocate.
    #[allow(clippy::result_large_err)]
    fn start_retract(
        &mut self,
        from: SourceId,
        to: ReplyTo,
        plan: &crate::messages::cell_job::RetractPlan,
    ) -> Result<(), FixedText<240>> {
        let mut text = FixedText::<240>::new();
        let start = self
            .robot
            .pulses_to_joints(&self.robot.joints_to_pulses(&self.planned_end));
        let here = self.robot.forward(&start);
        // Along the line out: the hand must be on it (a stop's brake may leave it by a few
        // millimetres).
        let (_, lateral, turned) = plan.offset(&here);
        use crate::messages::cell_job::{ON_LINE_DEG, ON_LINE_MM};
        if !(lateral <= ON_LINE_MM && turned <= ON_LINE_DEG) {
            let _ = write!(
                text,
                "the hand is in {} but {lateral:.1} mm and {turned:.1} deg off its line: move it out by hand (JOG), then HOME",
                plan.station
            );
            return Err(text);
        }
        let target = wrc_robot::Pose {
            z: here.z,
            ..plan.to
        };
        let end = match wrc_motion::check_line(&self.robot, &start, &target) {
            Ok((_, check)) => check.end_joints,
            Err(e) => {
                let _ = write!(
                    text,
                    "the straight line out of {} is refused: {e}",
                    plan.station
                );
                return Err(text);
            }
        };
        self.next_move.speed_pct = Some(plan.speed_pct);
        let ticket = self.motion(from, to, MoveKind::Line(target), end, false);
        self.next_move = super::program::NextMove::default();
        match ticket {
            Some(t) => {
                self.retract_ticket = Some(t);
                Ok(())
            }
            None => {
                let _ = text.write_str("the retract could not be queued");
                Err(text)
            }
        }
    }

    pub(super) fn handle_done(&mut self, done: MoveDone) {
        let Some(i) = self
            .tickets
            .iter()
            .position(|t| t.is_some_and(|t| t.ticket == done.ticket))
        else {
            return; // already answered (a stop aborted it)
        };
        if done.outcome == MoveOutcome::Held {
            // Open until RESUME; whoever waits for it (a client, a program, a job) waits on.
            if let Some(t) = self.tickets[i].as_mut() {
                t.held = true;
            }
            return;
        }
        let Some(t) = self.tickets[i].take() else {
            return;
        };
        if self.retract_ticket == Some(t.ticket) {
            self.retract_ticket = None;
            let out = done.outcome == MoveOutcome::Completed;
            if out {
                self.retract = None;
            }
            let _ = self
                .io
                .store
                .cell_events
                .try_send(crate::messages::cell_job::CellEvent::Retracted(out));
        }
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
                self.settle_state();
                let line = self.buf.inf(t.to, "");
                deliver(&self.io.out, t.from, line);
            }
            MoveOutcome::Stopped | MoveOutcome::Held => {
                let line = self.buf.abs(t.to, Code::Stopped, "stopped");
                deliver(&self.io.out, t.from, line);
            }
            MoveOutcome::Refused(number) => {
                let code = Code::from_number(number).unwrap_or(Code::MotionFault);
                let line = self.buf.abs(t.to, code, code.text());
                deliver(&self.io.out, t.from, line);
            }
        }
    }

    pub(super) fn disconnected(&mut self, source: SourceId) {
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
            if w.is_some_and(|w| w.from == source) {
                *w = None;
            }
        }
        if let Some(j) = self.job.as_mut() {
            j.forget_requester(source);
        }
        if self.owner() == source {
            self.shared.owner.store(0, Ordering::Release);
            let line = self.buf.event(false, &Event::Control { owner: None });
            self.io.out.send(SourceId::BROADCAST, line);
            if matches!(self.shared.state(), RobotState::Moving) {
                // Error Check turns this into a controlled stop and ERROR.
                self.io.owner_lost.store(true, Ordering::Release);
            }
        }
    }

    /// End the running program: `INF` to its starter, or `ABS` with `code`, the program's
    /// name, its source line and `text`; stop its motion if one is under way.
    /// A program or wafer job (`owner`) ends abnormally: if the motion it waits for
    /// (`waiting`) is still in flight, stop the robot in a controlled way, and forget every
    /// ticket of `owner`, whose replies nobody awaits any more.
    pub(super) fn abandon_motion(&mut self, waiting: Option<u32>, owner: SourceId) {
        let in_flight = waiting.is_some_and(|ticket| {
            self.tickets
                .iter()
                .any(|t| t.is_some_and(|t| t.ticket == ticket))
        });
        if in_flight {
            self.shared.request_stop(StopKind::Stop);
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

    /// `HOLD`: brake on the path at the override's limits and keep every open motion.
    pub(super) fn hold(&mut self, from: SourceId, to: ReplyTo) {
        let line = self.buf.ack(to, "");
        deliver(&self.io.out, from, line);
        if self.hold != Hold::None || !self.outstanding() {
            return; // nothing moves, or already held
        }
        self.shared.request_stop(StopKind::Hold);
        self.hold = Hold::Braking;
        self.set_state(RobotState::Stopping);
    }

    /// `RESUME`: send every open motion again, in the order they were accepted, from where
    /// the arm stands (the held one continues on its path to its target).
    pub(super) fn resume(&mut self, from: SourceId, to: ReplyTo) {
        if self.hold != Hold::Held {
            let text = if self.hold == Hold::Braking {
                "the robot is still braking for HOLD; repeat RESUME when it is HELD"
            } else {
                "no motion is held"
            };
            return self.nak(from, to, Code::NotHeld, text);
        }
        let epoch = self.shared.stop_epoch.load(Ordering::Acquire);
        let speed_pct = self.speed_limit();
        // Ticket numbers grow (wrapping) in the order motions were accepted.
        let first = self.next_ticket;
        let mut order: [Option<Ticket>; MAX_TICKETS] = [None; MAX_TICKETS];
        order.copy_from_slice(&self.tickets);
        order.sort_unstable_by_key(|o| o.map_or(u32::MAX, |t| t.ticket.wrapping_sub(first)));
        // From where it is held the motion is planned anew: it must keep clear of the cell
        // (a PTP held off its path by its axes' own brakes takes another way back to it).
        let resumed = |t: &Ticket| MoveOrder {
            ticket: t.ticket,
            epoch,
            // The motion's own speed and acceleration, below today's override.
            speed_pct: t.speed_pct.map_or(speed_pct, |s| s.min(speed_pct)),
            accel_pct: t.accel_pct,
            kind: t.resume,
        };
        if let Some(mut cell) = self.cell.take() {
            let sensed = self.vacuum_sensed_all();
            let mut at = self.shared.commanded_pulses();
            let mut refused = None;
            for t in order.iter().flatten() {
                match cell.check(&self.robot, &resumed(t), &at, sensed) {
                    Ok(q) => at = self.robot.joints_to_pulses(&q),
                    Err(touch) => {
                        refused = Some(touch);
                        break;
                    }
                }
            }
            self.cell = Some(cell);
            if let Some(touch) = refused {
                let mut note = FixedText::<400>::new();
                let _ = note.write_str("RESUME from here: ");
                self.describe_touch(&touch, None, false, &mut note);
                let _ = note.write_str("; STOP abandons the held motion, then move out of the way");
                return self.nak(from, to, Code::Collision, note.as_str());
            }
        }
        for t in order.into_iter().flatten() {
            let ticket = t.ticket;
            self.planned_end = t.end;
            let sent = self.io.orders.try_send(resumed(&t));
            // The order queue holds MAX_TICKETS orders and the Velocity Generator dropped
            // the held ones, so there is room; should there not be, the motion ends openly.
            if sent.is_err() {
                self.handle_done(MoveDone {
                    ticket,
                    outcome: MoveOutcome::Refused(Code::Busy.number()),
                });
            }
        }
        for t in self.tickets.iter_mut().flatten() {
            t.held = false;
        }
        self.hold = Hold::None;
        let line = self.buf.ack(to, "");
        deliver(&self.io.out, from, line);
        self.set_state(RobotState::Moving);
    }
}

/// A pose in a refusal's text: `x=… y=… z=… yaw=…`.
struct PoseText(wrc_robot::Pose);

impl std::fmt::Display for PoseText {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let p = &self.0;
        write!(
            f,
            "x={} y={} z={} yaw={}",
            Num(p.x),
            Num(p.y),
            Num(p.z),
            Num(p.yaw)
        )
    }
}
