//! The cell service's half of the recovery after a power loss: it keeps the transfer
//! journal (`wrc_cell::journal`) of every GET, PUT and SWAP — the steps the Command
//! Interpreter reports, each made durable before a step that moves the hand or switches the
//! vacuum starts — and, at start-up (or when a board answers again), judges an interrupted
//! transfer from the journal and the vacuum sensors: committed, aborted, or its wafer
//! uncertain at each place it may be in. It finds whether the hand is inside a station
//! (from the encoders' pose) and tells the Command Interpreter to retract it before any
//! other motion; it answers `RECOVERY`, carries out `SENSE` and records an operator's
//! `CONFIRM`, each logged. No wafer leaves the map without a sensor reading or an
//! operator's word.

use std::fmt::Write as _;
use std::sync::atomic::Ordering;

use wrc_cell::journal::{
    judge, read_journal, Act, Closed, Evidence, JournalFile, Judgement, Maybe, Record,
};
use wrc_cell::{Blade, Location, Sensed, Transfer, TransferKind, WaferId};
use wrc_protocol::{Code, ConfirmArg, Event, Place, ReplyTo, StationName};
use wrc_robot::Pose;

use super::CellService;
use crate::messages::cell_job::{
    CellJob, JobKind, JobOffer, JobStep, JournalAck, RetractPlan, StationLine, ON_LINE_DEG,
    ON_LINE_MM,
};
use crate::messages::SourceId;

/// The speed of a retract out of a station [%]: slow, whatever the station allows.
pub const RETRACT_SPEED_PCT: f64 = 20.0;

/// The journal of the job under way: what each step does and where it goes.
#[derive(Debug, Clone)]
pub(super) struct JobJournal {
    acts: Vec<Act>,
    targets: Vec<Option<Pose>>,
    /// A SWAP's PUT half, recorded when its GET half commits.
    swap_put: Option<Transfer>,
}

/// What each step of a transfer job does, for the journal, and where a motion goes.
fn journal_plan(
    steps: &[JobStep],
    first: TransferKind,
    robot: &wrc_robot::Robot,
) -> (Vec<Act>, Vec<Option<Pose>>) {
    use wrc_cell::Step;
    let mut kind = first;
    let mut committed = false;
    // A line before the first move to an approach pose takes a hand that stood inside a
    // station out of it ([`CellService::leave_station`]).
    let mut approached = false;
    let mut blades = 0;
    let mut acts = Vec::with_capacity(steps.len());
    let mut targets = Vec::with_capacity(steps.len());
    for step in steps {
        let (act, to) = match step {
            JobStep::UseBlade(b) => {
                blades += 1;
                if blades > 1 {
                    // A SWAP's second half.
                    kind = TransferKind::Put;
                    committed = false;
                }
                (Act::Blade(*b), None)
            }
            JobStep::Transfer(t) => match t {
                Step::RequireInput(_) => (Act::Interlock, None),
                Step::Speed(_) | Step::RestoreSpeed => (Act::Speed, None),
                Step::Ptp(p, _) => {
                    approached = true;
                    (Act::Approach, Some(*p))
                }
                Step::Line(p) if !approached => (Act::Leave, Some(*p)),
                Step::Line(p) if committed => (Act::Out, Some(*p)),
                Step::Line(p) => (Act::In, Some(*p)),
                Step::Vacuum(true) => (Act::VacuumOn, None),
                Step::Vacuum(false) => (Act::VacuumOff, None),
                Step::Z(p) if kind == TransferKind::Get => (Act::Lift, Some(*p)),
                Step::Z(p) => (Act::Lower, Some(*p)),
                Step::CheckVacuum { expect: true } => (Act::CheckWafer, None),
                Step::CheckVacuum { expect: false } => (Act::CheckNoWafer, None),
                Step::CommitMap => {
                    committed = true;
                    (Act::Commit, None)
                }
            },
            JobStep::Joints(j) => {
                approached = true;
                (Act::Approach, Some(robot.forward(j)))
            }
            JobStep::Approach { to, .. } => {
                approached = true;
                (Act::Enter, Some(*to))
            }
            JobStep::MapClear | JobStep::MapSensor(_) | JobStep::MapRead | JobStep::Sense => {
                (Act::Scan, None)
            }
        };
        acts.push(act);
        targets.push(to);
    }
    (acts, targets)
}

impl CellService {
    /// The journal file next to the wafer map.
    pub(super) fn open_journal(&mut self) {
        match JournalFile::open(&self.journal_path) {
            Ok(f) => self.journal = Some(f),
            Err(e) => {
                tracing::error!(
                    "wrc: cannot open the transfer journal {}: {e}; GET, PUT and SWAP are refused until it can be written",
                    self.journal_path.display()
                );
            }
        }
    }

    /// Before a GET, PUT or SWAP moves (its pending transfer saved): start the journal
    /// with the job. `Err` with the reason when it cannot be written (the caller aborts).
    pub(super) fn journal_open(
        &mut self,
        job: &CellJob,
        transfer: Transfer,
        swap_put: Option<Transfer>,
    ) -> Result<(), String> {
        let (acts, targets) = journal_plan(job.steps(), transfer.kind, &self.robot);
        let record = Record::Open {
            transfer: Some(transfer),
            station: transfer.station,
            plan: acts.clone(),
        };
        let Some(file) = self.journal.as_mut() else {
            return Err(format!(
                "the transfer journal {} cannot be opened",
                self.journal_path.display()
            ));
        };
        file.restart(&record).map_err(|e| {
            format!(
                "cannot write the transfer journal {}: {e}",
                self.journal_path.display()
            )
        })?;
        self.jjob = Some(JobJournal {
            acts,
            targets,
            swap_put,
        });
        Ok(())
    }

    fn journal_append(&mut self, record: &Record) -> bool {
        let Some(file) = self.journal.as_mut() else {
            return false;
        };
        // Measured only (for RECOVERY's figures): nothing depends on how long it took.
        let started = std::time::Instant::now();
        let written = file.append(record);
        let took = started.elapsed().as_secs_f64();
        self.journal_writes.0 += 1;
        self.journal_writes.1 += took;
        self.journal_writes.2 = self.journal_writes.2.max(took);
        match written {
            Ok(()) => true,
            Err(e) => {
                tracing::error!(
                    "wrc: cannot write the transfer journal {}: {e}",
                    self.journal_path.display()
                );
                false
            }
        }
    }

    /// A step of the running job began or ended: journal it; answer a beginning that must
    /// be durable before the step starts.
    pub(super) fn journal_step(&mut self, index: u8, done: bool, at: Pose) {
        let Some(jj) = self.jjob.as_ref() else {
            return;
        };
        let i = usize::from(index);
        let Some(&act) = jj.acts.get(i) else {
            return;
        };
        let to = jj.targets.get(i).copied().flatten();
        let record = if done {
            Record::Done {
                step: index,
                act,
                at,
            }
        } else {
            Record::Begin {
                step: index,
                act,
                to,
                at,
            }
        };
        // Written now, made durable with the others queued behind it by one sync
        // ([`CellService::sync_journal`]) before the step is answered.
        let written = match self.journal.as_mut() {
            Some(file) => file.write(&record).is_ok(),
            None => false,
        };
        self.journal_unsynced = true;
        self.journal_failed |= !written;
        let physical = act.moves() || matches!(act, Act::VacuumOn | Act::VacuumOff);
        if !done && physical {
            self.journal_acks.push(index);
        }
    }

    /// Make the records written since the last sync durable (one fdatasync for all the
    /// steps the Command Interpreter reported since), then answer the beginnings that wait.
    pub fn sync_journal(&mut self) {
        if !self.journal_unsynced {
            return;
        }
        self.journal_unsynced = false;
        let started = std::time::Instant::now();
        let synced = self.journal.as_mut().is_some_and(|f| f.sync().is_ok());
        let took = started.elapsed().as_secs_f64();
        self.journal_writes.0 += 1;
        self.journal_writes.1 += took;
        self.journal_writes.2 = self.journal_writes.2.max(took);
        let ok = synced && !std::mem::take(&mut self.journal_failed);
        if !ok {
            tracing::error!(
                "wrc: cannot write the transfer journal {}: the transfer stops",
                self.journal_path.display()
            );
        }
        for step in std::mem::take(&mut self.journal_acks) {
            if let Some(links) = &self.links {
                let _ = links.journaled.try_send(JournalAck { step, ok });
            }
        }
    }

    /// A SWAP's GET half committed and its PUT half begins.
    pub(super) fn journal_swap_half(&mut self) {
        if let Some(put) = self.jjob.as_mut().and_then(|j| j.swap_put.take()) {
            self.journal_append(&Record::Transfer(put));
        }
    }

    /// The job is settled: close the journal.
    pub(super) fn journal_close(&mut self, how: Closed) {
        if self.jjob.take().is_some() {
            self.journal_append(&Record::Close(how));
        }
    }

    /// What the vacuum valve and sensor of `blade` say now.
    fn evidence(&self, blade: Blade) -> Evidence {
        let signals = self.hand.blade(blade.index());
        let outputs = self.shared.outputs[0].load(Ordering::Acquire);
        let inputs = self.shared.inputs[0].load(Ordering::Acquire);
        Evidence {
            valve_on: signals.is_some_and(|s| outputs & (1u32 << (s.vacuum_output & 31)) != 0),
            sensed: signals.is_some_and(|s| inputs & (1u32 << (s.vacuum_input & 31)) != 0),
        }
    }

    /// Where the hand is (the board's commanded position).
    pub(super) fn hand_pose(&self) -> Pose {
        let joints = self.robot.pulses_to_joints(&self.shared.commanded_pulses());
        self.robot.forward(&joints)
    }

    /// The speed a hand that may hold an unclamped wafer moves at [%]: the slowest
    /// station's, at most [`RETRACT_SPEED_PCT`].
    pub(super) fn careful_speed_pct(&self) -> f64 {
        self.stations
            .iter()
            .map(|s| s.speed_pct)
            .fold(RETRACT_SPEED_PCT, f64::min)
            .max(1.0)
    }

    /// The way straight out of the station the hand is inside at `pose`, if any
    /// ([`StationLine::retract_from`]: past its approach pose and within
    /// [`IN_STATION_MM`](crate::messages::cell_job::IN_STATION_MM) and its degrees of its line, the rule the Command Interpreter applies too;
    /// farther off the line the hand stands in the open space before the station).
    fn inside_plan(&self, pose: &Pose, careful: bool) -> Option<RetractPlan> {
        self.stations
            .iter()
            .find_map(|s| StationLine::of(s).retract_from(pose, careful))
    }

    /// The retract out of the station the hand stands inside at `pose` (`None`: outside
    /// every station), and why the hand cannot be taken straight out if it cannot: it
    /// stands off the station's line by more than [`ON_LINE_MM`] or [`ON_LINE_DEG`] (the
    /// Command Interpreter refuses HOME and RETRACT then, with the same reason).
    fn retract_from(&self, pose: &Pose) -> Option<(RetractPlan, Option<String>)> {
        let careful = Blade::ALL
            .into_iter()
            .any(|b| self.wafers.hand_of(b).is_some());
        let plan = self.inside_plan(pose, careful)?;
        let (_, lateral, turned) = plan.offset(pose);
        let off = (!(lateral <= ON_LINE_MM && turned <= ON_LINE_DEG)).then(|| {
            format!(
                "the hand stands in {} {lateral:.1} mm and {turned:.1} deg off its line: a straight move out would scrape it; move it out by hand (JOG) first",
                plan.station
            )
        });
        Some((plan, off))
    }

    /// A job's way out of the station the hand stands inside at `from` (a transfer or a MAP
    /// that failed there, a program or an operator that moved it in): straight out along
    /// the station's line to its approach pose at the hand's height, slowly, before the
    /// job's first joint move, which would otherwise swing the hand sideways through the
    /// station's side. The steps and the joints where they end; none when the hand stands
    /// outside every station; a refusal (140) when it stands off the line.
    pub(super) fn leave_station(
        &self,
        from: &wrc_robot::Joints,
    ) -> Result<(Vec<JobStep>, wrc_robot::Joints), (Code, String)> {
        let pose = self.robot.forward(from);
        let plan = match self.retract_from(&pose) {
            None => return Ok((Vec::new(), *from)),
            Some((plan, None)) => plan,
            Some((_, Some(text))) => {
                return Err((Code::HandInside, format!("{text}; nothing moved")))
            }
        };
        let end = wrc_motion::check_line(&self.robot, from, &plan.to)
            .map(|(_, check)| check.end_joints)
            .map_err(|e| {
                (
                    Code::HandInside,
                    format!(
                        "the hand stands in {} and the straight line out of it is refused: {e}; nothing moved",
                        plan.station
                    ),
                )
            })?;
        let steps = vec![
            JobStep::Transfer(wrc_cell::Step::Speed(plan.speed_pct)),
            JobStep::Transfer(wrc_cell::Step::Line(plan.to)),
            JobStep::Transfer(wrc_cell::Step::RestoreSpeed),
        ];
        Ok((steps, end))
    }

    /// While the arm stands still and no job runs: whether the hand stands inside a
    /// station, so that HOME takes it straight out first (the Command Interpreter keeps
    /// the plan; it checks it against where the hand is when HOME comes). A plan left by a
    /// power loss is dropped once the hand stands outside every station (moved out with
    /// `MOVL` or `JOG`).
    pub(super) fn watch_rest(&mut self) {
        let s = &self.shared;
        if !self.reconciled
            || self.busy.is_some()
            || !self.stands_still()
            || !s.io_ready.load(Ordering::Acquire)
            || s.board_dead.load(Ordering::Acquire)
        {
            return;
        }
        let pose = self.hand_pose();
        let same = self.rest_pose.is_some_and(|p| {
            (p.x - pose.x).abs() < 1e-6
                && (p.y - pose.y).abs() < 1e-6
                && (p.z - pose.z).abs() < 1e-6
                && (p.yaw - pose.yaw).abs() < 1e-6
        });
        if same {
            return;
        }
        let Some(links) = self.links.as_ref() else {
            return;
        };
        let offer = match (self.inside, self.retract_from(&pose)) {
            // Out of the station a power loss left it in: nothing left to retract.
            (Some(plan), None) => {
                tracing::info!("wrc: the hand is out of {}", plan.station);
                Some((None, Some(plan.station)))
            }
            (Some(_), Some(_)) => None,
            (None, Some((plan, _))) => Some((Some(plan), None)),
            (None, _) if self.rest_plan => Some((None, None)),
            (None, _) => None,
        };
        if let Some((retract, out_of)) = offer {
            if links
                .jobs
                .try_send(JobOffer::Recovery {
                    retract,
                    alarm: false,
                })
                .is_err()
            {
                return; // the queue is full: again at the next poll
            }
            self.rest_plan = retract.is_some();
            if let Some(station) = out_of {
                self.inside = None;
                let text = format!("the hand is out of {station}");
                self.event(SourceId::BROADCAST, false, &Event::Recovery(&text));
            }
        }
        self.rest_pose = Some(pose);
    }

    /// Settle the pending transfer as the journal's `records` and the vacuum sensors of its
    /// blade judge it ([`judge`]): committed, aborted, or its wafer uncertain at each place
    /// it may be in; the journal is closed with the verdict. One path for every end: a
    /// transfer found pending at start-up (a crash, a power loss) and one that ended
    /// abnormally or was refused while the controller ran. Returns what left places
    /// uncertain, for the operator (empty when nothing did).
    ///
    /// `rest` is where the hand stood still when the transfer ended (at start-up: where it
    /// stands now). A `PUT` moves its wafer only inward until it releases it at the seat, so
    /// a wafer never released whose hand came to rest outside the station cannot have gone
    /// into the slot, whatever the journal's line in had begun.
    pub(super) fn settle_pending(&mut self, records: &[Record], rest: &Pose) -> Vec<String> {
        let Some(t) = self.wafers.pending().copied() else {
            return Vec::new();
        };
        let ev = self.evidence(t.blade);
        let j = judge(records, ev);
        let (on_blade, in_slot, text) = if j.open() && j.transfer == Some(t) {
            let short = t.kind == TransferKind::Put
                && j.in_slot == Maybe::Perhaps
                && j.on_blade != Maybe::No
                && self
                    .stations
                    .get(t.station.as_str())
                    .is_some_and(|s| !s.hand_inside(rest));
            if short {
                (
                    j.on_blade,
                    Maybe::No,
                    format!(
                        "{}; the hand stopped short of {}, outside it: the wafer cannot be in the slot",
                        j.text, t.station
                    ),
                )
            } else {
                (j.on_blade, j.in_slot, j.text.clone())
            }
        } else if !j.open() {
            // The journal never opened it: no step had begun, nothing moved. The sensor
            // confirms a PUT's wafer still held; one it does not see stays uncertain on
            // the blade, never out of the map on its word.
            let on_blade = match (t.kind, ev.valve_on, ev.sensed) {
                (TransferKind::Get, ..) => Maybe::No,
                (TransferKind::Put, true, true) => Maybe::Yes,
                (TransferKind::Put, ..) => Maybe::Perhaps,
            };
            let in_slot = if t.kind == TransferKind::Get {
                Maybe::Yes
            } else {
                Maybe::No
            };
            (
                on_blade,
                in_slot,
                format!("{t} was pending but had not begun: nothing moved"),
            )
        } else {
            (
                Maybe::Perhaps,
                Maybe::Perhaps,
                format!(
                    "{t} was pending but the journal holds another job ({}); its wafer is uncertain",
                    j.text
                ),
            )
        };
        let mut notes = Vec::new();
        let how = match self.wafers.settle_interrupted(on_blade, in_slot) {
            Ok(wrc_cell::Interrupted::Committed(t)) => {
                tracing::warn!("wrc: {text}: committed ({t})");
                Closed::Committed
            }
            Ok(wrc_cell::Interrupted::Aborted(t)) => {
                tracing::warn!("wrc: {text}: the wafer stays at its source ({t})");
                Closed::Aborted
            }
            Ok(wrc_cell::Interrupted::Uncertain(t)) => {
                tracing::warn!("wrc: {text}: wafer {} is uncertain", t.wafer);
                notes.push(text);
                Closed::Uncertain
            }
            Ok(wrc_cell::Interrupted::Gone(t)) => {
                tracing::warn!("wrc: {text}: wafer {} is on neither its blade nor in its slot; it left the wafer map", t.wafer);
                notes.push(format!("{text}; {} left the wafer map", t.wafer));
                Closed::Uncertain
            }
            Err(e) => {
                tracing::error!("wrc: cannot settle the pending transfer: {e}");
                return notes;
            }
        };
        self.jjob = None;
        self.journal_append(&Record::Close(how));
        notes
    }

    /// A transfer that ended abnormally (once the arm stands still and the sensor has
    /// answered) or was refused before it moved: settle it from its journal and the sensors
    /// ([`CellService::settle_pending`]), save, and tell what it left uncertain.
    pub(super) fn settle_ended_transfer(&mut self, rest: &Pose) {
        let records = match read_journal(&self.journal_path) {
            Ok(j) => j.records,
            Err(e) => {
                tracing::error!(
                    "wrc: cannot read the transfer journal {}: {e}; the transfer is judged without it",
                    self.journal_path.display()
                );
                Vec::new()
            }
        };
        let notes = if self.wafers.pending().is_some() {
            self.settle_pending(&records, rest)
        } else {
            self.settle_committed(&records)
        };
        self.tell_uncertain(notes);
    }

    /// A transfer the map had committed whose job did not end normally (a wafer lost on the
    /// line out, a power loss before the journal was closed): a GET whose hand had not left
    /// the slot when its wafer was lost (or its vacuum went off) may have set it back there:
    /// the slot and the blade become uncertain. The journal is closed. Returns what left
    /// places uncertain.
    fn settle_committed(&mut self, records: &[Record]) -> Vec<String> {
        let mut notes = Vec::new();
        let blade = self.jjob_transfer_blade(records);
        let j = judge(records, self.evidence(blade));
        if let Some(t) = j.transfer {
            let back = t.kind == TransferKind::Get
                && self.wafers.hand_of(t.blade) == Some(t.wafer)
                && j.in_slot == Maybe::Perhaps
                && self.wafers.doubt_back_in_slot(t.blade, t.slot_location());
            if back {
                tracing::warn!("wrc: {}", j.text);
                notes.push(j.text.clone());
            }
        }
        self.jjob = None;
        let how = if notes.is_empty() {
            Closed::Committed
        } else {
            Closed::Uncertain
        };
        self.journal_append(&Record::Close(how));
        notes
    }

    /// The blade of the journal's open transfer (a SWAP's current half), or blade A.
    fn jjob_transfer_blade(&self, records: &[Record]) -> Blade {
        judge(
            records,
            Evidence {
                valve_on: false,
                sensed: false,
            },
        )
        .transfer
        .map_or(Blade::A, |t| t.blade)
    }

    /// Save the map and tell every connection; when `notes` say what left places
    /// uncertain, keep them with the map's note and broadcast the `EVT RECOVERY` lines
    /// (what happened, what is uncertain, what to do next).
    pub(super) fn tell_uncertain(&mut self, notes: Vec<String>) {
        if !notes.is_empty() {
            let mut all: Vec<String> = self.wafers.note().map(str::to_string).into_iter().collect();
            all.extend(notes.iter().cloned());
            // The newest first: the note keeps its first 400 bytes.
            all.reverse();
            self.wafers.set_note(&all.join("; "));
        }
        self.persist();
        if !notes.is_empty() {
            for l in self.recovery_lines() {
                self.event(SourceId::BROADCAST, false, &Event::Recovery(&l));
            }
        }
    }

    /// The vacuum sensors of `blades` (bit 0: A, bit 1: B) lost their wafers — outside a
    /// job (`during` none: the Command Interpreter's watch, 213 raised) or in one: each
    /// certain wafer there becomes uncertain on its blade (it may have fallen, or the sensor
    /// failed; the sensor cannot tell), with a line on the log and `EVT RECOVERY` lines to
    /// everyone. A transfer's own wafer is left to its judgement. Nothing leaves the map:
    /// SENSE, MAP or an operator's CONFIRM settles it.
    pub(super) fn lost_from_blades(&mut self, blades: u8, during: Option<JobKind>) {
        let pending_blade = self.wafers.pending().map(|t| t.blade);
        let mut notes = Vec::new();
        for b in Blade::ALL {
            if blades & (1 << b.index()) == 0 || Some(b) == pending_blade {
                continue;
            }
            let Some(w) = self.wafers.hand_of(b) else {
                continue;
            };
            if self.wafers.is_uncertain(b) || !self.wafers.mark_blade_uncertain(b) {
                continue;
            }
            let ev = self.evidence(b);
            let input = self.hand.blade(b.index()).map_or(0, |s| s.vacuum_input);
            let when = match during {
                None => "while no transfer ran".to_string(),
                Some(k) => format!("during {}", k.verb()),
            };
            let valve = if ev.valve_on {
                "its valve is on"
            } else {
                "its valve is off"
            };
            let text = format!(
                "the vacuum sensor (input {input}) of blade {b} lost {w} {when} ({valve}): it may have fallen, or the sensor failed; {w} stays in the wafer map, uncertain, until SENSE, MAP or CONFIRM"
            );
            tracing::warn!("wrc: {text}");
            notes.push(text);
        }
        if !notes.is_empty() {
            self.tell_uncertain(notes);
        }
    }

    /// `OUT <n> <0|1> FORCE` switched a guarded output while `blade` held `wafer`: on the
    /// log, and to every connection.
    pub(super) fn forced(
        &mut self,
        n: u8,
        on: bool,
        from: SourceId,
        blade: Blade,
        wafer: u32,
        valve: bool,
    ) {
        let v = u8::from(on);
        let meaning = if valve && !on {
            format!("blade {blade} held W{wafer}: its vacuum is off, the wafer will drop")
        } else {
            format!("output {n} is guarded while a blade holds a wafer, and blade {blade} held W{wafer}")
        };
        let text = format!("forced OUT {n} {v} by {from}: {meaning}");
        tracing::warn!("wrc: {text}");
        self.event(SourceId::BROADCAST, false, &Event::Recovery(&text));
    }

    /// At start-up, or when a board answers again, once the inputs are read: settle a
    /// transfer left pending by the journal and the sensors, doubt every wafer on a blade
    /// whose vacuum is off, find a hand left inside a station, and tell the Command
    /// Interpreter and every connection.
    pub(super) fn recover(&mut self) {
        let journal = match read_journal(&self.journal_path) {
            Ok(j) => j,
            Err(e) => {
                tracing::error!(
                    "wrc: cannot read the transfer journal {}: {e}; an interrupted transfer is judged without it",
                    self.journal_path.display()
                );
                Default::default()
            }
        };
        if let Some(line) = journal.torn_at {
            tracing::warn!("wrc: the transfer journal ends in a record a power cut left half written (line {line}); it is judged up to the record before");
        }
        let mut notes: Vec<String> = Vec::new();
        // Saved and told only when something changes: a clean start says nothing.
        let before = self.wafers.wafers_line();
        let pending = self.wafers.pending().is_some();
        let blade = self.wafers.pending().map_or(Blade::A, |t| t.blade);
        let j = judge(&journal.records, self.evidence(blade));
        if pending {
            let now = self.hand_pose();
            notes.extend(self.settle_pending(&journal.records, &now));
        } else if j.open() {
            // The map had committed it but the journal was not closed yet: a GET whose hand
            // had not left the slot when the vacuum went off may have set its wafer back.
            tracing::info!(
                "wrc: the transfer journal's last job had not closed: {}",
                j.text
            );
            notes.extend(self.settle_committed(&journal.records));
        }
        // A wafer on a blade whose vacuum is off (a power loss switched it off), or that
        // its sensor does not see: perhaps still there, perhaps fallen.
        for b in Blade::ALL {
            let Some(w) = self.wafers.hand_of(b) else {
                continue;
            };
            let ev = self.evidence(b);
            if self.wafers.is_uncertain(b) {
                // Uncertain since the board stopped answering (or the last start-up): its
                // sensor, read with the valve on, settles it now.
                if ev.valve_on && ev.sensed {
                    if let Ok(Sensed::Held(w)) = self.wafers.sense_blade(b, true) {
                        tracing::info!(
                            "wrc: wafer {w} on the {} is sensed again: certain",
                            Location::Hand(b)
                        );
                    }
                }
                continue;
            }
            let why = if !ev.valve_on {
                "its vacuum was off at start-up (a power loss switches it off): the wafer may have stayed on the blade or fallen"
            } else if !ev.sensed {
                "its vacuum sensor senses none"
            } else {
                continue;
            };
            self.wafers.mark_blade_uncertain(b);
            let at = Location::Hand(b);
            tracing::warn!("wrc: wafer {w} on the {at} is uncertain: {why}");
            notes.push(format!("{w} on the {at}: {why}"));
        }
        self.reconciled = true;
        self.find_inside(j.open().then_some(&j));
        if !notes.is_empty() {
            self.wafers.set_note(&notes.join("; "));
        }
        let alarm = self.wafers.has_uncertain() || self.inside.is_some();
        // Nothing to tell when nothing is uncertain and the hand is outside.
        let links = self.links.as_ref().filter(|_| alarm);
        if let Some(links) = links {
            let _ = links.jobs.try_send(JobOffer::Recovery {
                retract: self.inside,
                alarm,
            });
        }
        if !notes.is_empty() || self.wafers.wafers_line() != before {
            self.persist();
        }
        if alarm {
            let lines = self.recovery_lines();
            for l in &lines {
                self.event(SourceId::BROADCAST, false, &Event::Recovery(l));
            }
        }
    }

    /// Whether the hand is inside a station now (the encoders' pose); the retract that
    /// takes it out, slowly, and carefully when a blade may hold a wafer.
    fn find_inside(&mut self, journal: Option<&Judgement>) {
        let pose = self.hand_pose();
        let careful = Blade::ALL.into_iter().any(|b| self.wafers.is_uncertain(b))
            || Blade::ALL
                .into_iter()
                .any(|b| self.wafers.hand_of(b).is_some());
        self.inside = self.inside_plan(&pose, careful);
        match (&self.inside, journal) {
            (Some(plan), _) => tracing::warn!(
                "wrc: the hand is inside {} (x={:.3} y={:.3} z={:.3}): HOME (or RETRACT) takes it straight out to the approach pose first, at {} %",
                plan.station,
                pose.x,
                pose.y,
                pose.z,
                plan.speed_pct
            ),
            (None, Some(j)) if j.inside => tracing::info!(
                "wrc: the journal had the hand inside {}, but it stands outside every station now",
                j.station.map(|s| s.to_string()).unwrap_or_default()
            ),
            _ => {}
        }
    }

    /// The station the hand is inside: the one a power loss left it in, or the one it stands
    /// in now.
    fn inside_now(&self) -> Option<StationName> {
        self.inside.map(|p| p.station).or_else(|| {
            self.inside_plan(&self.hand_pose(), false)
                .map(|p| p.station)
        })
    }

    /// The lines of `RECOVERY` (and of the broadcast after a recovery).
    fn recovery_lines(&self) -> Vec<String> {
        let mut lines = Vec::new();
        if let Some(note) = self.wafers.note() {
            lines.push(format!("note {note}"));
        }
        let pose = self.hand_pose();
        let mut hand = String::new();
        let _ = write!(
            hand,
            "hand x={:.3} y={:.3} z={:.3} yaw={:.3}",
            pose.x, pose.y, pose.z, pose.yaw
        );
        let inside = self.inside_now();
        match inside {
            Some(station) => {
                let _ = write!(hand, " inside={station}");
            }
            None => hand.push_str(" inside=-"),
        }
        lines.push(hand);
        for (at, w) in self.wafers.uncertain_places() {
            lines.push(format!("uncertain {at} {w}"));
        }
        let mut next = Vec::new();
        if let Some(station) = inside {
            next.push(format!("RETRACT (or HOME) out of {station}"));
        }
        let mut stations: Vec<StationName> = Vec::new();
        let mut blades: Vec<Blade> = Vec::new();
        for (at, _) in self.wafers.uncertain_places() {
            match at {
                Location::Slot { station, .. } if !stations.contains(&station) => {
                    stations.push(station)
                }
                Location::Hand(b) if !blades.contains(&b) => blades.push(b),
                _ => {}
            }
        }
        for b in blades {
            next.push(if b == Blade::A {
                "SENSE".to_string()
            } else {
                "SENSE B".to_string()
            });
        }
        for s in stations {
            next.push(format!("MAP {s}"));
        }
        if self.wafers.has_uncertain() {
            next.push("or CONFIRM what an operator sees".into());
        }
        if !next.is_empty() {
            lines.push(format!("next {}", next.join(", ")));
        }
        lines
    }

    /// `RECOVERY`.
    pub fn recovery(&mut self, from: SourceId, to: ReplyTo) {
        let lines = self.recovery_lines();
        for l in &lines {
            self.event(from, to.checksum, &Event::Recovery(l));
        }
        let inside = self.inside_now().map_or("-".to_string(), |s| s.to_string());
        // What the journal has cost the transfers so far (the Command Interpreter's waits
        // for a step's beginning to be on disk).
        let s = &self.shared;
        let waits = s.journal_waits.load(Ordering::Relaxed);
        let total = s.journal_wait_ns.load(Ordering::Relaxed) as f64 * 1e-6;
        let max = s.journal_wait_max_ns.load(Ordering::Relaxed) as f64 * 1e-6;
        let (writes, write_s, write_max_s) = self.journal_writes;
        let body = format!(
            "uncertain={} inside={inside} journal_waits={waits} journal_wait_ms={total:.3} journal_wait_max_ms={max:.3} journal_syncs={writes} journal_sync_ms={:.3} journal_sync_max_ms={:.3}",
            self.wafers.uncertain_places().len(),
            write_s * 1e3,
            write_max_s * 1e3
        );
        self.ack(from, to, &body);
    }

    /// Whether the hand may be inside a station: anything else that moves it is refused.
    pub(super) fn inside_refusal(&self) -> Option<(Code, String)> {
        self.inside.map(|p| {
            (
                Code::HandInside,
                format!(
                    "the hand may be inside {} after an interrupted transfer: RETRACT or HOME first",
                    p.station
                ),
            )
        })
    }

    /// The Command Interpreter took the hand out of the station (or was stopped).
    pub(super) fn retracted(&mut self, out: bool) {
        if !out {
            return;
        }
        if let Some(plan) = self.inside.take() {
            tracing::info!("wrc: the hand is out of {} (RETRACT)", plan.station);
            let text = format!("retracted out of {}", plan.station);
            self.event(SourceId::BROADCAST, false, &Event::Recovery(&text));
        }
    }

    /// `SENSE [A|B]`: the blade's vacuum on and its sensor read, by the Command
    /// Interpreter; the map learns the result ([`CellService::sensed_blade`]).
    pub fn sense(&mut self, from: SourceId, to: ReplyTo, blade: Blade) {
        if let Some((code, text)) = self
            .state_refusal(from, true)
            .or_else(|| self.inside_refusal())
        {
            return self.nak(from, to, code, &text);
        }
        if blade == Blade::B && self.hand.blade_b.is_none() {
            let text = "this robot has one hand; SENSE B needs a dual-blade robot";
            return self.nak(from, to, Code::NotAvailable, text);
        }
        if self.busy.is_some() || self.wafers.pending().is_some() || !self.reconciled {
            let text = "a transfer or mapping is in progress";
            return self.nak(from, to, Code::TransferBusy, text);
        }
        let Some(station) = self.stations.iter().next().map(|s| s.name) else {
            return self.nak(from, to, Code::NotAvailable, "the cell has no stations");
        };
        let mut job = CellJob::new(from, to, JobKind::Sense, station);
        job.push(JobStep::UseBlade(blade));
        job.push(JobStep::Transfer(wrc_cell::Step::Vacuum(true)));
        job.push(JobStep::Sense);
        let sent = self
            .links
            .as_ref()
            .is_some_and(|l| l.jobs.try_send(JobOffer::Start(job)).is_ok());
        if sent {
            self.busy = Some(JobKind::Sense);
        } else {
            self.nak(
                from,
                to,
                Code::Busy,
                "the controller is busy; repeat the request",
            );
        }
    }

    /// The blade's vacuum sensor, read with its valve on (`SENSE`): settle the blade.
    pub(super) fn sensed_blade(&mut self, blade: Blade, sensed: bool) {
        let at = Location::Hand(blade);
        let text = match self.wafers.sense_blade(blade, sensed) {
            Ok(Sensed::Held(w)) => format!("SENSE: {w} is on the {at} (vacuum sensor)"),
            Ok(Sensed::Unknown(w)) => format!(
                "SENSE: the {at} holds a wafer the map did not have; it is {w} now (vacuum sensor)"
            ),
            Ok(Sensed::NotHere(w)) => format!(
                "SENSE: {w} is not on the {at} (vacuum sensor); it may still be in its slot: MAP the station"
            ),
            Ok(Sensed::Gone(w)) => format!(
                "SENSE: {w} is not on the {at} (vacuum sensor) and was nowhere else: it left the wafer map"
            ),
            Ok(Sensed::Empty) => format!("SENSE: the {at} is empty (vacuum sensor)"),
            Err(e) => format!("SENSE: the wafer map refused the reading: {e}"),
        };
        tracing::warn!("wrc: {text}");
        self.event(SourceId::BROADCAST, false, &Event::Recovery(&text));
        self.persist();
    }

    /// `CONFIRM …`: an operator's word, logged.
    pub fn confirm(&mut self, from: SourceId, to: ReplyTo, arg: ConfirmArg) {
        let owner = self.shared.owner.load(Ordering::Acquire);
        if owner != SourceId::NONE.0 && owner != from.0 {
            return self.nak(
                from,
                to,
                Code::ControlHeld,
                "control is held by another source",
            );
        }
        if self.busy.is_some() || self.wafers.pending().is_some() {
            let text = "a transfer or mapping is in progress";
            return self.nak(from, to, Code::TransferBusy, text);
        }
        let place = |p: Place| match p {
            Place::Hand(b) => Location::Hand(b),
            Place::Slot { station, slot } => Location::Slot { station, slot },
        };
        let result = match arg {
            ConfirmArg::At { wafer, place: p } => {
                let w = WaferId(wafer);
                let at = place(p);
                self.check_place(&at)
                    .and_then(|()| self.wafers.confirm_at(w, at).map_err(|e| e.to_string()))
                    .map(|()| format!("{w} is at {at}"))
            }
            ConfirmArg::Gone { wafer } => {
                let w = WaferId(wafer);
                self.wafers
                    .confirm_gone(w)
                    .map_err(|e| e.to_string())
                    .map(|places| {
                        let list: Vec<String> = places.iter().map(|p| p.to_string()).collect();
                        format!(
                            "{w} is gone (it was at {}); it left the wafer map",
                            list.join(" or ")
                        )
                    })
            }
            ConfirmArg::Empty(p) => {
                let at = place(p);
                self.check_place(&at)
                    .and_then(|()| self.wafers.confirm_empty(at).map_err(|e| e.to_string()))
                    .map(|gone| match gone {
                        Some(w) => format!("{at} is empty; {w}, last there, left the wafer map"),
                        None => format!("{at} is empty"),
                    })
            }
        };
        match result {
            Ok(text) => {
                tracing::warn!("wrc: CONFIRM by {}: {text}", who(from));
                self.persist();
                let line = format!("confirmed {text}");
                self.event(SourceId::BROADCAST, false, &Event::Recovery(&line));
                self.ack(from, to, &text);
            }
            Err(text) => self.nak(from, to, Code::BadArgument, &text),
        }
    }

    /// A place a CONFIRM names must exist (a blade B on a dual-blade robot only).
    fn check_place(&self, at: &Location) -> Result<(), String> {
        match at {
            Location::Hand(Blade::B) if self.hand.blade_b.is_none() => {
                Err("this robot has one hand: there is no blade B".into())
            }
            Location::Slot { station, slot } => {
                let s = self
                    .stations
                    .get(station.as_str())
                    .ok_or_else(|| format!("no station named {station}; STN lists them"))?;
                if *slot == 0 || *slot > s.slots {
                    return Err(format!("{station} has slots 1 to {}", s.slots));
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }
}

/// Who confirmed, for the log.
fn who(from: SourceId) -> &'static str {
    match from.kind() {
        SourceId::TCP => "a host",
        SourceId::GUI => "the GUI",
        SourceId::PENDANT => "the pendant",
        _ => "the controller",
    }
}
