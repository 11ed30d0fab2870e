//! The Command Interpreter's wafer jobs (`GET`, `PUT`, `MAP`): it carries out the steps the
//! cell service planned ([`crate::cell_job`]), one at a time — motions through the same
//! checks as every other motion, the vacuum valve and the mapping sensor through the
//! outputs, waits on the vacuum sensor and the board's mapping latch — and watches the
//! vacuum while the hand holds a wafer. A wafer fault (212, 213, 214) stops the robot like
//! any alarm: `ABS` to the job, `EVT ERROR` to everyone, state `ERROR` until `RESET`.
//!
//! Real-time promise: as the rest of the task — no allocation, no blocking, no printing.

use std::fmt::Write as _;

use std::sync::atomic::Ordering;
use wrc_rt::FixedText;

use wrc_board::MotionBoard;
use wrc_cell::{Blade, Step, MAX_BLADES};
use wrc_protocol::ReplyTo;
use wrc_protocol::{Code, Command};
use wrc_robot::{Joints, Pose};

use super::program::ProgramWait;
use super::{deliver, CommandInterpreter};
use crate::messages::cell_job::{CellEvent, CellJob, JobKind, JobOffer, JobStep, MAX_MAP_SLOTS};
use crate::messages::{MoveKind, SourceId, Urgent};
use crate::shared::{RobotState, StopKind};

/// How long the board may take to clear its mapping latch or to apply an output [ns].
const BOARD_ACK_NS: u64 = 1_000_000_000;

/// How long the transfer journal may take to make a step's beginning durable [ns]: far
/// longer than a disk's sync, short enough that a broken disk stops a transfer quickly.
const JOURNAL_ACK_NS: u64 = 2_000_000_000;

/// Cycles the vacuum sensor may read "no wafer" during a motion before the wafer counts as
/// lost (2 × the Command Interpreter's period: a single glitch is no loss).
const LOST_CYCLES: u32 = 2;

/// What a running job waits for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum JobWait {
    /// Nothing: do the next step.
    Nothing,
    /// Its motion with this ticket to finish.
    Motion(u32),
    /// The board to show `outputs & mask == value` (the I/O Monitor applies outputs).
    Output {
        mask: u32,
        value: u32,
        deadline: u64,
    },
    /// The vacuum sensor to read `expect`, until the deadline.
    Vacuum { expect: bool, deadline: u64 },
    /// The board to clear its mapping latch.
    MapClear { deadline: u64 },
    /// The transfer journal to make step `step`'s beginning durable (asked at `since`).
    Journal { step: u8, since: u64, deadline: u64 },
    /// A `SENSE`: the sensor to settle, until the deadline.
    Sense { deadline: u64 },
}

/// The job the Command Interpreter is carrying out.
#[derive(Debug, Clone, Copy)]
pub(super) struct RunningJob {
    job: CellJob,
    /// The next step.
    next: usize,
    wait: JobWait,
    /// The blades a wafer is on (confirmed, or not yet released; bit 0: A, bit 1: B): their
    /// vacuum sensors are watched.
    holding: u8,
    /// The blade the vacuum steps switch and read.
    blade: Blade,
    /// The speed override before the job's `Speed` step.
    saved_speed: Option<u32>,
    /// Successive cycles a holding blade's vacuum sensor read "no wafer".
    dropped: u32,
    /// During a blended approach: the station's interlock input and the approach's ticket.
    /// Until the Pulse Generator reports the approach committed to enter, an interlock
    /// that opens stops the robot, and the stop ends behind the approach pose.
    guard: Option<(u8, u32)>,
    /// The step whose beginning the transfer journal has made durable (it may start).
    journaled: Option<u8>,
    /// A `SENSE`: its blade's sensor saw a wafer.
    sensed: bool,
}

/// The watch of one blade's vacuum sensor outside a job ([`CommandInterpreter::watch_hand`]).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct BladeWatch {
    /// Since when its valve is on [ns] (`None`: off).
    valve_since: Option<u64>,
    /// The valve has been on for the sensor's settling time while the map had a certain
    /// wafer on the blade: from then on the sensor must see it, valve on or off.
    armed: bool,
    /// Successive periods its sensor read "no wafer".
    dropped: u32,
    /// The loss was raised (213): not again while the map still claims the wafer.
    reported: bool,
}

/// The bit of `blade` in a blade mask.
fn bit(blade: Blade) -> u8 {
    1 << blade.index()
}

impl RunningJob {
    /// Who asked for the job.
    pub(super) fn from(&self) -> SourceId {
        self.job.from
    }

    /// `source` went away: the job goes on, its replies go nowhere.
    pub(super) fn forget_requester(&mut self, source: SourceId) {
        if self.job.from == source {
            self.job.from = SourceId::NONE;
        }
    }
}

impl<B: MotionBoard> CommandInterpreter<B> {
    /// The vacuum-sensed input of `blade`, fresh from the board (false for a blade the robot
    /// does not have).
    fn vacuum_sensed_of(&self, blade: Blade) -> bool {
        self.hand
            .blade(blade.index())
            .is_some_and(|s| self.board.read_inputs(0) & (1u32 << (s.vacuum_input & 31)) != 0)
    }

    /// The valve and sensor of `blade`: a job names blade B only on a robot that has one (the
    /// cell service refuses it otherwise), so the hand's stand in for a missing blade.
    fn blade_signals(&self, blade: Blade) -> wrc_config::BladeB {
        self.hand
            .blade(blade.index())
            .unwrap_or(self.hand.hand_signals())
    }

    /// Every blade's vacuum-sensed input.
    pub(super) fn vacuum_sensed_all(&self) -> [bool; MAX_BLADES] {
        Blade::ALL.map(|b| self.vacuum_sensed_of(b))
    }

    /// Whether every blade in `mask` senses its wafer.
    fn all_sensed(&self, mask: u8) -> bool {
        Blade::ALL
            .into_iter()
            .all(|b| mask & bit(b) == 0 || self.vacuum_sensed_of(b))
    }

    /// Set or clear output `n`; returns the wait for the board to apply it.
    fn job_output(&mut self, n: u8, on: bool) -> JobWait {
        let bit = 1u32 << (n & 31);
        self.shared.set_output(n, on);
        JobWait::Output {
            mask: bit,
            value: if on { bit } else { 0 },
            deadline: self.now_ns.saturating_add(BOARD_ACK_NS),
        }
    }

    /// A job offer from the cell service.
    pub(super) fn offer_job(&mut self, offer: JobOffer) {
        match offer {
            JobOffer::Start(job) => self.start_job(job),
            JobOffer::Refused(r) => self.program_job_refused(r.code, r.text()),
            JobOffer::Recovery { retract, alarm } => {
                self.retract = retract;
                if alarm && self.shared.state() != RobotState::Estop {
                    let code = Code::TransferInterrupted;
                    self.shared
                        .error_code
                        .store(u32::from(code.number()), Ordering::Release);
                    self.set_state(RobotState::Error);
                    self.event(&wrc_protocol::Event::Error {
                        code,
                        text: code.text(),
                    });
                }
            }
        }
    }

    /// Whether the job may start now; the refusal otherwise.
    fn job_refusal(&self, job: &CellJob) -> Option<(Code, &'static str)> {
        let for_program = job.from == SourceId::PROGRAM;
        let acting = match (&self.program, for_program) {
            (Some(p), true) => p.from,
            _ => job.from,
        };
        let owner = self.owner();
        if self.job.is_some() {
            Some((Code::TransferBusy, "a transfer or mapping is in progress"))
        } else if for_program
            && !self
                .program
                .as_ref()
                .is_some_and(|p| p.wait == ProgramWait::Job)
        {
            Some((
                Code::NoProgram,
                "the program that asked is no longer running",
            ))
        } else if !for_program && self.program.is_some() {
            Some((Code::ProgramRunning, "a program is running; ABORT it first"))
        } else if owner != SourceId::NONE && owner != acting {
            Some((Code::ControlHeld, "control is held by another source"))
        } else if self.shared.state() == RobotState::Error {
            Some((Code::InError, "the robot is in ERROR; RESET first"))
        } else if self.shared.state() == RobotState::Estop {
            Some((Code::InEstop, "the robot is in ESTOP; RESET first"))
        } else if !self.shared.homed.load(Ordering::Acquire) {
            Some((Code::NotHomed, "the robot is not homed; send HOME first"))
        } else if self.outstanding() || self.shared.state() == RobotState::Stopping {
            Some((Code::Busy, "the robot is moving; WAIT first"))
        } else {
            None
        }
    }

    fn start_job(&mut self, job: CellJob) {
        let refusal = self.job_refusal(&job);
        // The station's interlock is checked before anything moves: a closed one refuses.
        let inputs = self.board.read_inputs(0);
        let closed = job.steps().iter().find_map(|s| match s {
            JobStep::Transfer(Step::RequireInput(n)) if inputs & (1u32 << (n & 31)) == 0 => {
                Some(*n)
            }
            _ => None,
        });
        let mut text = FixedText::<120>::new();
        let refusal = match (refusal, closed) {
            (Some((code, t)), _) => Some((code, t)),
            (None, Some(n)) => {
                let _ = write!(
                    text,
                    "the interlock of {} (input {n}) is closed; nothing moved",
                    job.station
                );
                Some((Code::InterlockClosed, text.as_str()))
            }
            (None, None) => None,
        };
        if let Some((code, text)) = refusal {
            if job.from == SourceId::PROGRAM {
                self.program_job_refused(code, text);
            } else {
                self.nak(job.from, job.to, code, text);
            }
            let sensed = self.vacuum_sensed_all();
            self.send_ended(CellEvent::Ended {
                kind: job.kind,
                started: false,
                code: Some(code),
                sensed,
            });
            return;
        }
        if job.from != SourceId::PROGRAM {
            let line = self.buf.ack(job.to, "");
            deliver(&self.io.out, job.from, line);
        }
        self.job = Some(RunningJob {
            job,
            next: 0,
            wait: JobWait::Nothing,
            holding: job.holding,
            blade: Blade::A,
            saved_speed: None,
            dropped: 0,
            guard: None,
            journaled: None,
            sensed: false,
        });
    }

    /// A motion of the running job finished.
    pub(super) fn job_motion_done(&mut self, ticket: u32, outcome: crate::messages::MoveOutcome) {
        if !self.job.is_some_and(|j| j.wait == JobWait::Motion(ticket)) {
            return;
        }
        match super::motion::motion_failure(outcome) {
            None => self.job_advance(),
            failure => self.end_job(failure),
        }
    }

    /// Issue one motion of the job through the checks every motion goes through.
    fn job_motion(&mut self, command: Command) -> Result<Option<u32>, Code> {
        self.internal_request(SourceId::CELL, command)
    }

    /// Carry the running job on: check what it waits for, then do steps until one waits.
    pub(super) fn run_job(&mut self) {
        let Some(j) = self.job else {
            return;
        };
        // The wafers on the blades are watched during every motion of the job.
        if j.holding != 0 && matches!(j.wait, JobWait::Motion(_)) {
            let dropped = if self.all_sensed(j.holding) {
                0
            } else if self.periodic {
                j.dropped + 1
            } else {
                j.dropped
            };
            if let Some(r) = self.job.as_mut() {
                r.dropped = dropped;
            }
            if dropped >= LOST_CYCLES {
                return self.job_fault(
                    Code::WaferLost,
                    "the vacuum sensor lost the wafer while the hand carried it",
                );
            }
        }
        // A blended approach is watched for the interlock until it is committed to enter.
        if let (Some((input, ticket)), JobWait::Motion(waiting)) = (j.guard, j.wait) {
            let committed = self.shared.entry_committed.load(Ordering::Acquire) == ticket;
            if waiting == ticket
                && !committed
                && self.board.read_inputs(0) & (1u32 << (input & 31)) == 0
            {
                return self.job_fault(
                    Code::InterlockOpened,
                    "the station's interlock opened while the hand was approaching; it stopped outside the station",
                );
            }
        }
        for _ in 0..crate::messages::cell_job::MAX_JOB_STEPS + 1 {
            let Some(j) = self.job else {
                return;
            };
            match j.wait {
                JobWait::Nothing => {}
                JobWait::Motion(_) => return,
                JobWait::Output {
                    mask,
                    value,
                    deadline,
                } => {
                    let applied = self.board.read_feedback(&mut self.feedback).is_ok()
                        && self.feedback.boards[0].outputs & mask == value;
                    if applied {
                        self.job_advance();
                    } else if self.now_ns >= deadline {
                        return self.end_job(Some((
                            Code::MotionFault,
                            "the board did not apply an output within 1 s",
                        )));
                    } else {
                        return;
                    }
                }
                JobWait::Vacuum { expect, deadline } => {
                    if self.vacuum_sensed_of(j.blade) == expect {
                        if let Some(r) = self.job.as_mut() {
                            r.holding = if expect {
                                r.holding | bit(r.blade)
                            } else {
                                r.holding & !bit(r.blade)
                            };
                        }
                        self.job_advance();
                    } else if self.now_ns >= deadline {
                        let (verb, station, slot) = (j.job.kind.verb(), j.job.station, j.job.slot);
                        let mut text = FixedText::<160>::new();
                        let input = self.blade_signals(j.blade).vacuum_input;
                        let on = if j.blade == Blade::A {
                            "the hand"
                        } else {
                            "blade B"
                        };
                        let _ = if expect {
                            write!(
                                text,
                                "{verb} {station} {slot}: the vacuum sensor (input {input}) sees no wafer on {on}"
                            )
                        } else {
                            write!(
                                text,
                                "{verb} {station} {slot}: the vacuum sensor (input {input}) still sees a wafer after the release"
                            )
                        };
                        return self.job_fault(Code::WaferNotSensed, text.as_str());
                    } else {
                        return;
                    }
                }
                JobWait::Journal {
                    step,
                    since,
                    deadline,
                } => {
                    match self.journal_ack(step) {
                        Some(true) => {
                            let waited = self.now_ns.saturating_sub(since);
                            let s = &self.shared;
                            s.journal_waits.fetch_add(1, Ordering::Relaxed);
                            s.journal_wait_ns.fetch_add(waited, Ordering::Relaxed);
                            s.journal_wait_max_ns.fetch_max(waited, Ordering::Relaxed);
                            if let Some(r) = self.job.as_mut() {
                                r.journaled = Some(step);
                                r.wait = JobWait::Nothing;
                            }
                        }
                        Some(false) => {
                            return self.job_fault(
                                Code::Internal,
                                "the transfer journal could not be written; the transfer stopped",
                            )
                        }
                        None if self.now_ns >= deadline => return self.job_fault(
                            Code::Internal,
                            "the transfer journal was not written within 2 s; the transfer stopped",
                        ),
                        None => return,
                    }
                }
                JobWait::Sense { deadline } => {
                    if self.now_ns < deadline {
                        return;
                    }
                    let sensed = self.vacuum_sensed_of(j.blade);
                    let _ = self.io.store.cell_events.try_send(CellEvent::Sensed {
                        blade: j.blade,
                        sensed,
                    });
                    if let Some(r) = self.job.as_mut() {
                        r.sensed = sensed;
                        r.wait = JobWait::Nothing;
                    }
                    if sensed {
                        self.job_advance();
                    } else {
                        // Nothing to hold: the valve goes off again.
                        let output = self.blade_signals(j.blade).vacuum_output;
                        let wait = self.job_output(output, false);
                        self.job_wait(wait);
                    }
                    continue;
                }
                JobWait::MapClear { deadline } => {
                    let cleared =
                        self.board.read_mapping(&mut self.scan).is_ok() && self.scan.cleared;
                    if cleared {
                        self.job_advance();
                    } else if self.now_ns >= deadline {
                        return self.end_job(Some((
                            Code::MotionFault,
                            "the board did not clear its mapping sensor within 1 s",
                        )));
                    } else {
                        return;
                    }
                }
            }
            let Some(j) = self.job else {
                return;
            };
            if j.next >= j.job.len {
                return self.end_job(None);
            }
            let step = j.job.steps[j.next];
            // A journaled job: every step's beginning goes to the journal, and one that
            // moves the hand or switches the vacuum starts only once it is on disk.
            if j.job.kind.journaled() {
                let index = j.next as u8;
                if j.journaled != Some(index) {
                    if !self.journal_record(index, false) {
                        return self.job_fault(
                            Code::Internal,
                            "the transfer journal's queue is full; the transfer stopped",
                        );
                    }
                    if step.physical() {
                        let deadline = self.now_ns.saturating_add(JOURNAL_ACK_NS);
                        return self.job_wait(JobWait::Journal {
                            step: index,
                            since: self.now_ns,
                            deadline,
                        });
                    }
                    if let Some(r) = self.job.as_mut() {
                        r.journaled = Some(index);
                    }
                }
            }
            self.job_step(step);
        }
    }

    /// Tell the cell service that step `index` of the running job begins or has ended, with
    /// the hand where the board was commanded; `false` when its queue is full.
    fn journal_record(&mut self, index: u8, done: bool) -> bool {
        let joints = self.robot.pulses_to_joints(&self.shared.commanded_pulses());
        let at = self.robot.forward(&joints);
        self.io
            .store
            .cell_events
            .try_send(CellEvent::Step { index, done, at })
            .is_ok()
    }

    /// The journal's answer for step `step`, if it has come (older answers are dropped).
    fn journal_ack(&mut self, step: u8) -> Option<bool> {
        while let Ok(ack) = self.io.store.journaled.try_recv() {
            if ack.step == step {
                return Some(ack.ok);
            }
        }
        None
    }

    /// Outside a job, moving or not: while the wafer map has a certain wafer on a blade,
    /// that blade's vacuum sensor must keep seeing it once its valve has been on for
    /// `[hand] vacuum_settle_ms` (and after the valve is switched off: a forced `OUT`). A
    /// sensor that reads "no wafer" for [`LOST_CYCLES`] periods in a row raises 213 at once
    /// (an ESTOP-class stop if the arm moves) and tells the cell service, which makes the
    /// wafer uncertain on that blade; each loss is raised once. Not while a job runs (its
    /// own watch does it) nor until the cell service has settled every job that ended.
    pub(super) fn watch_hand(&mut self) {
        let outputs = self.shared.outputs[0].load(Ordering::Acquire);
        let holding = self.shared.hand_wafers.load(Ordering::Acquire);
        let settle_ns = (self.hand.vacuum_settle_s * 1e9) as u64;
        for b in Blade::ALL {
            let w = &mut self.blade_watch[b.index()];
            let valve_on = self
                .hand
                .blade(b.index())
                .is_some_and(|s| outputs & (1u32 << (s.vacuum_output & 31)) != 0);
            w.valve_since = match (valve_on, w.valve_since) {
                (false, _) => None,
                (true, None) => Some(self.now_ns),
                (true, since) => since,
            };
            if holding & bit(b) == 0 {
                // Not (or no longer) a certain wafer there: watched afresh next time.
                *w = BladeWatch {
                    valve_since: w.valve_since,
                    ..BladeWatch::default()
                };
                continue;
            }
            if w.valve_since
                .is_some_and(|t| self.now_ns.saturating_sub(t) >= settle_ns)
            {
                w.armed = true;
            }
        }
        let settled = self.map_settled();
        let watching = self.job.is_none()
            && settled
            && self.shared.io_ready.load(Ordering::Acquire)
            && !self.shared.board_dead.load(Ordering::Acquire);
        let mut lost = 0u8;
        for b in Blade::ALL {
            let sensed = self.vacuum_sensed_of(b);
            let periodic = self.periodic;
            let w = &mut self.blade_watch[b.index()];
            if !watching || !w.armed || w.reported || sensed {
                w.dropped = 0;
                continue;
            }
            if periodic {
                w.dropped += 1;
            }
            if w.dropped >= LOST_CYCLES {
                w.reported = true;
                lost |= bit(b);
            }
        }
        if lost == 0 {
            return;
        }
        let _ = self
            .io
            .store
            .cell_events
            .try_send(CellEvent::WaferLost { blades: lost });
        let mut text = FixedText::<200>::new();
        let mut first = true;
        for b in Blade::ALL.into_iter().filter(|b| lost & bit(*b) != 0) {
            let wafer = self.shared.blade_wafers[b.index()].load(Ordering::Acquire) as u32;
            let input = self.blade_signals(b).vacuum_input;
            let _ = if first {
                write!(
                    text,
                    "the vacuum sensor (input {input}) of blade {b} lost W{wafer}"
                )
            } else {
                write!(text, ", and that of blade {b} (input {input}) W{wafer}")
            };
            first = false;
        }
        let _ = text.write_str(
            " outside a transfer; it is uncertain in the wafer map: SENSE, MAP or CONFIRM",
        );
        self.shared.request_stop(StopKind::Estop);
        self.fault(Code::WaferLost, text.as_str());
    }

    /// Tell the cell service a job ended, and count it (the watch outside a job waits until
    /// the service has settled as many).
    fn send_ended(&mut self, ended: CellEvent) {
        if self.io.store.cell_events.try_send(ended).is_ok() {
            self.shared.jobs_ended.fetch_add(1, Ordering::AcqRel);
        }
    }

    /// The current step is done: on to the next (journaled as done first).
    fn job_advance(&mut self) {
        if let Some(j) = self.job {
            if j.job.kind.journaled() {
                // A full queue loses this record only: the journal then shows the step
                // begun, not done, which is judged the more cautious way.
                let _ = self.journal_record(j.next as u8, true);
            }
        }
        if let Some(r) = self.job.as_mut() {
            r.wait = JobWait::Nothing;
            r.next += 1;
        }
    }

    fn job_wait(&mut self, wait: JobWait) {
        if let Some(r) = self.job.as_mut() {
            r.wait = wait;
        }
    }

    /// Start one step.
    fn job_step(&mut self, step: JobStep) {
        match step {
            JobStep::Transfer(step) => match step {
                Step::RequireInput(n) => {
                    if self.board.read_inputs(0) & (1u32 << (n & 31)) == 0 {
                        return self.job_fault(
                            Code::InterlockOpened,
                            "the station's interlock opened while the hand was entering",
                        );
                    }
                    self.job_advance();
                }
                // A job's move to the approach pose comes as joints (`transfer_steps`), so
                // that the straight line in is known to stay in range; a bare pose is a
                // job built without that check.
                Step::Ptp(..) => self.end_job(Some((
                    Code::Internal,
                    "a transfer's approach came without its checked joint solution; nothing moved",
                ))),
                Step::Line(pose) | Step::Z(pose) => self.job_move(Command::MovL { pose }),
                Step::Speed(pct) => {
                    let now = self.shared.speed_pct.load(Ordering::Acquire);
                    let near = (pct.round().clamp(1.0, 100.0) as u32).min(now);
                    if let Some(r) = self.job.as_mut() {
                        r.saved_speed.get_or_insert(now);
                    }
                    self.shared.speed_pct.store(near, Ordering::Release);
                    self.job_advance();
                }
                Step::RestoreSpeed => {
                    self.restore_job_speed();
                    self.job_advance();
                }
                Step::Vacuum(on) => {
                    let blade = self.job.map_or(Blade::A, |r| r.blade);
                    if !on {
                        if let Some(r) = self.job.as_mut() {
                            r.holding &= !bit(blade);
                        }
                    }
                    let output = self.blade_signals(blade).vacuum_output;
                    let wait = self.job_output(output, on);
                    self.job_wait(wait);
                }
                Step::CheckVacuum { expect } => {
                    let deadline = self
                        .now_ns
                        .saturating_add((self.hand.vacuum_settle_s * 1e9) as u64);
                    self.job_wait(JobWait::Vacuum { expect, deadline });
                }
                Step::CommitMap => {
                    let _ = self.io.store.cell_events.try_send(CellEvent::Commit);
                    self.job_advance();
                }
            },
            JobStep::Joints(joints) => self.job_move(Command::MovJ {
                joints,
                count: self.robot.axis_count(),
            }),
            JobStep::Approach {
                via,
                to,
                speed_pct,
                interlock,
            } => self.job_approach(via, to, speed_pct, interlock),
            JobStep::MapClear => {
                self.board.clear_mapping();
                let deadline = self.now_ns.saturating_add(BOARD_ACK_NS);
                self.job_wait(JobWait::MapClear { deadline });
            }
            JobStep::MapSensor(on) => {
                let wait = self.job_output(self.hand.mapping_output, on);
                self.job_wait(wait);
            }
            JobStep::MapRead => self.job_map_read(),
            JobStep::Sense => {
                let deadline = self
                    .now_ns
                    .saturating_add((self.hand.vacuum_settle_s * 1e9) as u64);
                self.job_wait(JobWait::Sense { deadline });
            }
            JobStep::UseBlade(blade) => {
                if let Some(r) = self.job.as_mut() {
                    r.blade = blade;
                }
                self.job_advance();
            }
        }
    }

    /// A blended approach ([`JobStep::Approach`], docs/motion.md): the interlock checked now
    /// and watched until the approach is committed to enter; the first part at the override
    /// in force, the line at the station's speed.
    fn job_approach(&mut self, via: Joints, to: Pose, pct: f64, interlock: Option<u8>) {
        if let Some(n) = interlock {
            if self.board.read_inputs(0) & (1u32 << (n & 31)) == 0 {
                return self.job_fault(
                    Code::InterlockOpened,
                    "the station's interlock opened before the hand approached; nothing entered",
                );
            }
        }
        let now = self.shared.speed_pct.load(Ordering::Acquire);
        let near = (pct.round().clamp(1.0, 100.0) as u32).min(now);
        // The line in, checked from the approach pose as the Velocity Generator follows it.
        let start = self
            .robot
            .pulses_to_joints(&self.robot.joints_to_pulses(&via));
        let end = match wrc_motion::check_line(&self.robot, &start, &to) {
            Ok((_, check)) => check.end_joints,
            Err(e) => {
                let code = Code::from_number(crate::velocity_generator::refusal_code(&e))
                    .unwrap_or(Code::MotionFault);
                return self.end_job(Some((code, code.text())));
            }
        };
        let kind = MoveKind::Approach {
            via,
            to,
            line_pct: f64::from(near),
        };
        let Some(ticket) = self.motion(SourceId::CELL, ReplyTo::default(), kind, end, false) else {
            return self.end_job(Some((Code::Busy, "too many motions queued; WAIT first")));
        };
        self.shared.speed_pct.store(near, Ordering::Release);
        if let Some(r) = self.job.as_mut() {
            r.saved_speed.get_or_insert(now);
            r.wait = JobWait::Motion(ticket);
            r.guard = interlock.map(|n| (n, ticket));
        }
    }

    fn job_move(&mut self, command: Command) {
        match self.job_motion(command) {
            Ok(Some(ticket)) => self.job_wait(JobWait::Motion(ticket)),
            Ok(None) => self.job_advance(),
            Err(code) => {
                let refusal = self.refusal;
                self.end_job(Some((code, refusal.text())));
            }
        }
    }

    /// Read the mapping latch: the station's every slot must have been seen.
    fn job_map_read(&mut self) {
        let Some(j) = self.job else {
            return;
        };
        let count = usize::from(j.job.slot).min(MAX_MAP_SLOTS);
        if self.board.read_mapping(&mut self.scan).is_err() {
            return; // torn: read again next cycle
        }
        let all = if count == 64 {
            u64::MAX
        } else {
            (1u64 << count) - 1
        };
        if self.scan.station != j.job.station_index + 1 || self.scan.seen & all != all {
            let mut text = FixedText::<160>::new();
            let _ = write!(
                text,
                "MAP {}: the mapping sensor saw {} of {} slots; is the station where it was taught?",
                j.job.station,
                if self.scan.station == j.job.station_index + 1 {
                    (self.scan.seen & all).count_ones()
                } else {
                    0
                },
                count
            );
            return self.end_job(Some((Code::MotionFault, text.as_str())));
        }
        let mut codes = [0u8; MAX_MAP_SLOTS];
        codes[..count].copy_from_slice(&self.scan.codes[..count]);
        let _ = self.io.store.cell_events.try_send(CellEvent::Mapped {
            station_index: j.job.station_index,
            count: count as u16,
            codes,
        });
        self.job_advance();
    }

    fn restore_job_speed(&mut self) {
        if let Some(r) = self.job.as_mut() {
            if let Some(s) = r.saved_speed.take() {
                self.shared.speed_pct.store(s, Ordering::Release);
            }
        }
    }

    /// A wafer fault: end the job with `code` and stop the robot like an alarm.
    fn job_fault(&mut self, code: Code, text: &str) {
        self.end_job(Some((code, text)));
        self.shared.request_stop(StopKind::Estop);
        self.handle_urgent(Urgent::Fault(code.number()));
    }

    /// End the running job: `INF` (with the wafer, or the mapping) or `ABS`; stop its motion
    /// if one is under way; tell the cell service.
    pub(super) fn end_job(&mut self, failure: Option<(Code, &str)>) {
        let Some(j) = self.job else {
            return;
        };
        self.restore_job_speed();
        self.job = None;
        if failure.is_some() {
            let waiting = match j.wait {
                JobWait::Motion(ticket) => Some(ticket),
                _ => None,
            };
            self.abandon_motion(waiting, SourceId::CELL);
        }
        // The mapping sensor is only on during a scan.
        if j.job.kind == JobKind::Map {
            self.shared.set_output(self.hand.mapping_output, false);
        }
        let sensed = self.vacuum_sensed_all();
        self.send_ended(CellEvent::Ended {
            kind: j.job.kind,
            started: true,
            code: failure.map(|f| f.0),
            sensed,
        });
        if j.job.from == SourceId::PROGRAM {
            let waiting = self
                .program
                .as_ref()
                .is_some_and(|p| p.wait == ProgramWait::Job);
            if waiting {
                match failure {
                    None => {
                        if let Some(p) = self.program.as_mut() {
                            p.wait = ProgramWait::Nothing;
                        }
                        self.vm.resume(wrc_lang::Resume::Ok);
                    }
                    // The operator's STOP ends the program; anything else is its error.
                    Some((Code::Stopped, text)) => self.end_program(Some((Code::Stopped, text))),
                    Some((code, text)) => self.program_failed(code, text),
                }
            }
            return;
        }
        let line = match failure {
            None => {
                let mut body = FixedText::<120>::new();
                let _ = match j.job.kind {
                    JobKind::Map => {
                        let _ = write!(body, "{} ", j.job.station);
                        for &c in &self.scan.codes[..usize::from(j.job.slot).min(MAX_MAP_SLOTS)] {
                            let _ = body.write_str(match c {
                                0 => "0",
                                1 => "1",
                                2 => "2",
                                _ => "X",
                            });
                        }
                        Ok(())
                    }
                    JobKind::Swap => write!(body, "W{} W{}", j.job.wafer, j.job.wafer_put),
                    JobKind::Sense => body.write_str(if j.sensed { "wafer" } else { "none" }),
                    _ => write!(body, "W{}", j.job.wafer),
                };
                self.buf.inf(j.job.to, body.as_str())
            }
            Some((code, text)) => self.buf.abs(j.job.to, code, text),
        };
        deliver(&self.io.out, j.job.from, line);
    }
}
