//! The cell service: the wafer cell's non-real-time half, run on the service thread beside
//! the program store. It owns the stations (`STN`, `TEACH`) and the wafer map (`WAFERS`),
//! and for `GET`, `PUT` and `MAP` it checks the request against the map and the controller's
//! state (a refusal is a `NAK` and nothing moves), plans the steps (`wrc_cell::plan`), saves
//! the pending transfer *before* anything moves, and hands the job to the Command
//! Interpreter ([`crate::cell_job`]). It commits and saves the map when the Command
//! Interpreter reports the vacuum sensor's confirmation, settles a transfer that ended
//! abnormally or was refused as the transfer journal and the vacuum sensors judge it (the
//! same judgement as after a power loss, once the arm stands still and the sensor has
//! answered: `recovery.rs`), makes a wafer a vacuum sensor lost uncertain, applies
//! mappings, and tells every connection what changed (`EVT WAFER`, `EVT RECOVERY`). It
//! publishes what the map has on each blade for the Command Interpreter
//! ([`Shared::blade_wafers`], [`Shared::hand_wafers`]), which guards the vacuum valves and
//! watches the vacuum sensors with it.
//!
//! At start-up it settles a transfer left pending by a crash or a power loss the same way,
//! once the I/O Monitor has read the inputs; until then `GET` and `PUT` are refused (138).

use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::Arc;

use wrc_cell::{
    Blade, SlotCode, SlotState, Station, StationError, Stations, Step, Transfer, TransferKind,
    WaferMap, WaferMapError, MAX_BLADES,
};
use wrc_config::HandConfig;
use wrc_protocol::{Code, Event, ReplyBuf, ReplyTo, StationName, MAX_LINE};
use wrc_robot::{Joints, Robot};

use crate::messages::cell_job::{
    CellEvent, CellJob, CellView, JobKind, JobOffer, JobRefusal, JobStep,
};
use crate::messages::{Outputs, SourceId, StoreLinks};
use crate::shared::{RobotState, Shared, BLADE_PENDING, BLADE_UNCERTAIN};
use wrc_rt::ipc::mailbox::MailboxWriter;

mod recovery;

pub use recovery::RETRACT_SPEED_PCT;

/// The job steps of a transfer ([`wrc_cell::plan`]'s), with its move to the approach pose
/// made a joint move to the solution from which the straight line into the station keeps
/// every limit, reached soonest from `from` ([`Station::approach_joints`]): the transfer's
/// motions are checked here, before anything moves. With `blend`, that move, the station's
/// speed, its interlock and the line in are one [`JobStep::Approach`].
pub fn transfer_steps(
    kind: TransferKind,
    station: &Station,
    slot: u16,
    robot: &Robot,
    from: &Joints,
    blend: bool,
) -> Result<(Vec<JobStep>, Joints), StationError> {
    // GET enters lowered (under the wafer), PUT lifted (holding it).
    let approach = station.approach_joints(robot, slot, kind == TransferKind::Put, from)?;
    let plan = wrc_cell::plan(kind, station, slot)?;
    let mut steps = Vec::with_capacity(plan.len());
    let mut rest = plan.as_slice();
    while let Some((step, after)) = rest.split_first() {
        rest = after;
        steps.push(match (step, after) {
            (Step::Ptp(..), [Step::Speed(pct), Step::RequireInput(n), Step::Line(to), ..])
                if blend =>
            {
                rest = &after[3..];
                approach_step(approach, *to, *pct, Some(*n))
            }
            (Step::Ptp(..), [Step::Speed(pct), Step::Line(to), ..]) if blend => {
                rest = &after[2..];
                approach_step(approach, *to, *pct, None)
            }
            (Step::Ptp(..), _) => JobStep::Joints(approach),
            (other, _) => JobStep::Transfer(*other),
        });
    }
    Ok((steps, approach))
}

fn approach_step(
    via: Joints,
    to: wrc_robot::Pose,
    speed_pct: f64,
    interlock: Option<u8>,
) -> JobStep {
    JobStep::Approach {
        via,
        to,
        speed_pct,
        interlock,
    }
}

/// Why the wafer cell could not be opened.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CellError {
    /// The stations file is unusable.
    #[error(transparent)]
    Stations(#[from] wrc_cell::StationsError),
    /// The wafer map file is unusable.
    #[error(transparent)]
    WaferMap(#[from] wrc_cell::WaferMapError),
}

/// The wafer cell: stations and the wafer map, each with its file, and the job in progress.
pub struct CellService {
    /// The stations.
    pub stations: Stations,
    stations_path: PathBuf,
    /// Where every wafer is.
    pub wafers: WaferMap,
    wafers_path: PathBuf,
    shared: Arc<Shared>,
    robot: Robot,
    hand: HandConfig,
    out: Option<Outputs>,
    links: Option<StoreLinks>,
    buf: ReplyBuf,
    /// A job handed to the Command Interpreter and not ended yet.
    busy: Option<JobKind>,
    /// A pending transfer left by a crash has been settled (or there was none).
    reconciled: bool,
    /// The PUT half of a running SWAP: begun (and saved) when its GET half commits.
    swap_put: Option<Transfer>,
    /// Transfers blend their approach into the line in (`[motion] blend`).
    blend: bool,
    /// A transfer that ended abnormally stays pending until the arm stands still and the
    /// vacuum sensor has had its time to answer ([`CellService::poll`]).
    settle_ended: SettleEnded,
    /// I/O Monitor readings that cover `[hand] vacuum_settle_ms` (see
    /// [`CellService::with_io_period`]).
    settle_samples: u64,
    /// The transfer journal (`journal.wrcj` next to the wafer map), open for appending.
    journal: Option<wrc_cell::journal::JournalFile>,
    journal_path: PathBuf,
    /// The journal of the job under way.
    jjob: Option<recovery::JobJournal>,
    /// The hand may be inside a station (found at start-up): the retract that takes it out.
    inside: Option<crate::messages::cell_job::RetractPlan>,
    /// Journal syncs (each makes the records written before it durable), their total and
    /// longest time [s].
    journal_writes: (u64, f64, f64),
    /// Records written and not yet synced.
    journal_unsynced: bool,
    /// A write failed since the last sync.
    journal_failed: bool,
    /// Steps whose beginnings wait for the next sync to be answered.
    journal_acks: Vec<u8>,
    /// Where the hand stood still when [`CellService::watch_rest`] last looked.
    rest_pose: Option<wrc_robot::Pose>,
    /// The Command Interpreter holds a retract plan `watch_rest` sent (not a power loss's).
    rest_plan: bool,
    /// Where the cell goes to the Command Interpreter's check of every motion, and the
    /// blades' wafers it was last told.
    view: Option<(MailboxWriter<CellView>, [bool; MAX_BLADES])>,
}

/// Where the settling of a transfer that ended abnormally stands.
#[derive(Debug, Clone, Copy, PartialEq)]
enum SettleEnded {
    /// Nothing to settle.
    No,
    /// Waiting for the arm to stand still (a stop's brake may still carry the hand through
    /// a slot's support height, picking or leaving the wafer).
    UntilRest,
    /// Standing still, the hand where the stop left it: settle from the I/O Monitor's
    /// reading after this count (the sensor answers a pick or a release after its delay, at
    /// most `vacuum_settle_ms`).
    UntilSample(u64, wrc_robot::Pose),
}

impl CellService {
    /// Open the stations file (written from the embedded demo cell when it does not exist)
    /// and the wafer map (every slot unknown when it does not exist); both are checked
    /// against `robot`.
    pub fn open(
        robot: &Robot,
        stations_path: &Path,
        wafers_path: &Path,
        shared: Arc<Shared>,
        hand: HandConfig,
    ) -> Result<CellService, CellError> {
        let stations = if stations_path.exists() {
            Stations::load(stations_path)?
        } else {
            let demo = Stations::embedded_demo();
            demo.save_atomic(stations_path)?;
            demo
        };
        stations.validate(robot)?;
        let mut wafers = WaferMap::load(wafers_path)?;
        wafers.set_dual(hand.blade_b.is_some());
        wafers.adopt_stations(&stations)?;
        wafers.save_atomic(wafers_path)?;
        let mut cell = CellService {
            stations,
            stations_path: stations_path.to_path_buf(),
            wafers,
            wafers_path: wafers_path.to_path_buf(),
            shared,
            robot: robot.clone(),
            hand,
            out: None,
            links: None,
            buf: ReplyBuf::new(),
            busy: None,
            // Settled at the first poll with the inputs read ([`CellService::recover`]).
            reconciled: false,
            swap_put: None,
            blend: false,
            settle_ended: SettleEnded::No,
            settle_samples: settle_samples(&hand, DEFAULT_IO_PERIOD_S),
            journal: None,
            journal_path: wafers_path.with_file_name("journal.wrcj"),
            jjob: None,
            inside: None,
            journal_writes: (0, 0.0, 0.0),
            journal_unsynced: false,
            journal_failed: false,
            journal_acks: Vec::new(),
            rest_pose: None,
            rest_plan: false,
            view: None,
        };
        cell.open_journal();
        Ok(cell)
    }

    /// Publish the cell (the stations' and obstacles' solids and the blades' wafers) to the
    /// Command Interpreter's check of every motion through `view`, now and whenever the
    /// stations or the map change.
    pub fn with_view(mut self, view: MailboxWriter<CellView>) -> CellService {
        self.view = Some((view, [false; MAX_BLADES]));
        self.publish_view(true);
        self
    }

    /// Publish the cell to the Command Interpreter if the blades' wafers changed since the
    /// last time, or always with `stations` (they changed).
    fn publish_view(&mut self, stations: bool) {
        let wafers = Blade::ALL.map(|b| self.wafers.hand_of(b).is_some());
        let Some((_, told)) = self.view.as_ref() else {
            return;
        };
        if !stations && *told == wafers {
            return;
        }
        let model = self.stations.model(&self.robot).unwrap_or_else(|e| {
            eprintln!("wrc: the cell cannot be checked against motions: {e}");
            wrc_cell::CellModel::empty(&self.robot)
        });
        if let Some((writer, told)) = self.view.as_mut() {
            *told = wafers;
            writer.write(CellView::of(model, wafers, self.stations.iter()));
        }
    }

    /// The I/O Monitor's period [s] (Table 1: 0.1 s unless the configuration says
    /// otherwise): how many of its readings cover `[hand] vacuum_settle_ms`, the time the
    /// vacuum sensor has to answer before a transfer that ended abnormally is settled.
    pub fn with_io_period(mut self, period_s: f64) -> CellService {
        self.settle_samples = settle_samples(&self.hand, period_s);
        self
    }

    /// Plan transfers with a blended approach ([`JobStep::Approach`]) or not.
    pub fn with_blend(mut self, blend: bool) -> CellService {
        self.blend = blend;
        self
    }

    /// The height of a dual-blade robot's blade B above the hand [mm]; `None` for one hand.
    pub fn blade_b_offset(&self) -> Option<f64> {
        self.hand.blade_b.map(|b| b.z_offset_mm)
    }

    /// Connect the service to the connections and the Command Interpreter.
    pub fn connect(&mut self, out: Outputs, links: StoreLinks) {
        self.out = Some(out);
        self.links = Some(links);
    }

    fn send(&self, to: SourceId, line: &[u8]) {
        if let Some(out) = &self.out {
            out.send(to, line);
        }
    }

    fn nak(&mut self, from: SourceId, to: ReplyTo, code: Code, text: &str) {
        if from == SourceId::PROGRAM {
            if let Some(links) = &self.links {
                let _ = links
                    .jobs
                    .try_send(JobOffer::Refused(JobRefusal::new(code, text)));
            }
            return;
        }
        let line = self.buf.nak(to, code, text).to_vec();
        self.send(from, &line);
    }

    fn ack(&mut self, from: SourceId, to: ReplyTo, body: &str) {
        let line = self.buf.ack(to, body).to_vec();
        self.send(from, &line);
    }

    fn event(&mut self, to: SourceId, checksum: bool, event: &Event<'_>) {
        let line = self.buf.event(checksum, event).to_vec();
        self.send(to, &line);
    }

    /// Tell every connection the map's places (`EVT WAFER` per place, `pending=-` when no
    /// transfer is pending any more).
    fn broadcast_map(&mut self) {
        self.publish_view(false);
        let mut parts = self.wafers.wafers_lines();
        if self.wafers.pending().is_none() {
            parts.push("pending=-".to_string());
        }
        for part in &parts {
            self.event(SourceId::BROADCAST, false, &Event::Wafer(part));
        }
    }

    /// Save the map; on failure say so on stderr (the service thread may print) and return
    /// the error's text.
    fn save(&mut self) -> Result<(), String> {
        self.wafers
            .save_atomic(&self.wafers_path)
            .map_err(|e| e.to_string())
    }

    /// `STN`.
    pub fn stn(&mut self, from: SourceId, to: ReplyTo) {
        let lines: Vec<String> = self
            .stations
            .iter()
            .map(|s| wrc_cell::stn_line(s, self.robot.shape().wafer_radius_mm))
            .collect();
        for text in &lines {
            self.event(from, to.checksum, &Event::Station(text));
        }
        let obstacles: Vec<String> = self
            .stations
            .obstacles()
            .iter()
            .map(wrc_cell::obstacle_line)
            .collect();
        for text in &obstacles {
            self.event(from, to.checksum, &Event::Obstacle(text));
        }
        let ack = if obstacles.is_empty() {
            format!("stations={}", lines.len())
        } else {
            format!("stations={} obstacles={}", lines.len(), obstacles.len())
        };
        self.ack(from, to, &ack);
    }

    /// `WAFERS`.
    pub fn wafers(&mut self, from: SourceId, to: ReplyTo) {
        let one = self.wafers.wafers_line();
        if one.len() <= MAX_LINE - 16 {
            return self.ack(from, to, &one);
        }
        let parts = self.wafers.wafers_lines();
        for part in &parts {
            self.event(from, to.checksum, &Event::Wafer(part));
        }
        self.ack(from, to, &format!("parts={}", parts.len()));
    }

    /// The refusal common to TEACH, GET, PUT and MAP, from the controller's state.
    fn state_refusal(&self, from: SourceId, motion: bool) -> Option<(Code, String)> {
        let shared = &self.shared;
        let owner = shared.owner.load(Ordering::Acquire);
        if from != SourceId::PROGRAM && owner != SourceId::NONE.0 && owner != from.0 {
            return Some((
                Code::ControlHeld,
                "control is held by another source".to_string(),
            ));
        }
        if !shared.homed.load(Ordering::Acquire) {
            return Some((Code::NotHomed, "not homed; send HOME first".to_string()));
        }
        match shared.state() {
            RobotState::Error => {
                return Some((Code::InError, "the robot is in ERROR; RESET first".into()))
            }
            RobotState::Estop => {
                return Some((Code::InEstop, "the robot is in ESTOP; RESET first".into()))
            }
            _ => {}
        }
        if !motion
            && (shared.state() != RobotState::Idle || shared.in_flight.load(Ordering::Acquire) != 0)
        {
            return Some((
                Code::Busy,
                "the robot is moving; teach when it stands still".to_string(),
            ));
        }
        None
    }

    /// Answer a running program's question about the wafer map or a station (`SLOT(…)`,
    /// `WAFER$(…)`, `HAND$(…)`, `SLOTS(…)`, `PITCH(…)`, `STATION(…)`, `APPROACH(…)`), or the
    /// code and text of why it cannot be answered.
    pub fn answer(&self, query: &wrc_lang::CellQuery) -> Result<wrc_lang::Answer, (Code, String)> {
        use wrc_lang::{Answer, CellInfo, Text};
        let text = |t: &str| Answer::Text(Text::cut(t));
        if query.info == CellInfo::HandWafer {
            let blade = if query.blade_b { Blade::B } else { Blade::A };
            if blade == Blade::B && !self.wafers.is_dual() {
                return Err((
                    Code::NotAvailable,
                    "this robot has one blade: HAND$(B) names a dual-blade robot's second".into(),
                ));
            }
            return Ok(text(
                &self
                    .wafers
                    .hand_of(blade)
                    .map_or_else(String::new, |w| w.to_string()),
            ));
        }
        let name = query.station.as_str();
        let Some(station) = self.stations.get(name) else {
            return Err((
                Code::StationUnknown,
                format!("no station named {name}; STN lists them"),
            ));
        };
        let slot_state = || {
            if query.slot == 0 || query.slot > station.slots {
                return Err((
                    Code::SlotUnknown,
                    format!(
                        "{name} has slots 1 to {}, not {}",
                        station.slots, query.slot
                    ),
                ));
            }
            self.wafers
                .slot(name, query.slot)
                .map_err(|e| (map_error_code(&e), e.to_string()))
        };
        Ok(match query.info {
            CellInfo::SlotState => Answer::Number(match slot_state()? {
                SlotState::Unknown => -1.0,
                SlotState::Empty => 0.0,
                SlotState::Wafer(_) => 1.0,
                SlotState::Fault(f) => match f.code() {
                    SlotCode::Double => 2.0,
                    _ => 3.0,
                },
                SlotState::Uncertain(_) => -2.0,
            }),
            CellInfo::SlotWafer => match slot_state()? {
                SlotState::Wafer(w) => text(&w.to_string()),
                _ => text(""),
            },
            CellInfo::Slots => Answer::Number(f64::from(station.slots)),
            CellInfo::Pitch => Answer::Number(station.pitch_mm),
            CellInfo::Pose => Answer::Pose(station.pose),
            CellInfo::Approach => Answer::Number(station.approach_mm),
            _ => {
                return Err((
                    Code::NotAvailable,
                    "this controller cannot answer that question".into(),
                ))
            }
        })
    }

    /// `TEACH <station>`.
    pub fn teach(&mut self, from: SourceId, to: ReplyTo, name: &StationName) {
        let mut refusal = self.state_refusal(from, false);
        if refusal.is_none() && self.stations.get(name.as_str()).is_none() {
            refusal = Some((
                Code::StationUnknown,
                format!("no station named {name}; STN lists them"),
            ));
        }
        if let Some((code, text)) = refusal {
            return self.nak(from, to, code, &text);
        }
        let joints = self.robot.pulses_to_joints(&self.shared.commanded_pulses());
        let pose = self.robot.forward(&joints);
        let mut taught = self.stations.clone();
        let wafer_radius = self.robot.shape().wafer_radius_mm;
        let body = match taught
            .teach(name.as_str(), pose, &self.robot)
            .map(|s| wrc_cell::stn_line(s, wafer_radius))
        {
            Ok(body) => body,
            Err(e) => {
                let text = format!("cannot teach {name} here: {e}");
                return self.nak(from, to, Code::OutOfReach, &text);
            }
        };
        if let Err(e) = taught.save_atomic(&self.stations_path) {
            let text = format!("cannot save the stations: {e}; nothing changed");
            return self.nak(from, to, Code::Internal, &text);
        }
        // Teaching moves a station; its slots, and so the wafer map, stay as they are.
        self.stations = taught;
        self.publish_view(true);
        self.ack(from, to, &body);
        self.event(SourceId::BROADCAST, false, &Event::Station(&body));
    }

    /// `GET`/`PUT <station> <slot> [blade]` and `SWAP <station> <slot>` (`kind`), or
    /// `MAP <station>` (`kind` = `Map`, `slot` and `blade` ignored), from a connection or
    /// from the running program.
    pub fn job(
        &mut self,
        from: SourceId,
        to: ReplyTo,
        kind: JobKind,
        station: &StationName,
        slot: u16,
        blade: Blade,
    ) {
        match self.plan_job(from, to, kind, station, slot, blade) {
            Ok(job) => {
                let sent = self
                    .links
                    .as_ref()
                    .is_some_and(|l| l.jobs.try_send(JobOffer::Start(job)).is_ok());
                if sent {
                    self.busy = Some(kind);
                    // The transfer's blade is guarded from now on.
                    self.publish();
                } else {
                    self.swap_put = None;
                    if self.wafers.pending().is_some() {
                        let _ = self.wafers.abort();
                        let _ = self.save();
                        self.broadcast_map();
                    }
                    self.nak(
                        from,
                        to,
                        Code::Busy,
                        "the controller is busy; repeat the request",
                    );
                }
            }
            Err((code, text)) => self.nak(from, to, code, &text),
        }
    }

    /// Check a job and build it; for GET, PUT and SWAP, save the (first) pending transfer.
    fn plan_job(
        &mut self,
        from: SourceId,
        to: ReplyTo,
        kind: JobKind,
        name: &StationName,
        slot: u16,
        blade: Blade,
    ) -> Result<CellJob, (Code, String)> {
        if let Some((code, text)) = self.state_refusal(from, true) {
            return Err((code, text));
        }
        if self.busy.is_some() || (self.reconciled && self.wafers.pending().is_some()) {
            return Err((
                Code::TransferBusy,
                "a transfer or mapping is in progress".to_string(),
            ));
        }
        if let Some(refusal) = self.inside_refusal() {
            return Err(refusal);
        }
        if !self.reconciled {
            return Err((
                Code::TransferBusy,
                "the wafer map is being settled with the vacuum sensors; repeat in a moment"
                    .to_string(),
            ));
        }
        let Some(index) = self
            .stations
            .iter()
            .position(|s| s.name.as_str().eq_ignore_ascii_case(name.as_str()))
        else {
            return Err((
                Code::StationUnknown,
                format!("no station named {name}; STN lists them"),
            ));
        };
        let station = self
            .stations
            .iter()
            .nth(index)
            .cloned()
            .ok_or((Code::Internal, "the station list changed".to_string()))?;
        let mut job = CellJob::new(from, to, kind, station.name);
        job.station_index = index as u32;
        // The job watches the vacuum of every blade that holds a certain wafer, a MAP's too:
        // a wafer lost on the way is 213, and the map learns it at the job's end.
        job.holding = Blade::ALL
            .into_iter()
            .filter(|b| self.wafers.hand_of(*b).is_some() && !self.wafers.is_uncertain(*b))
            .fold(0, |m, b| m | 1 << b.index());
        if kind == JobKind::Map {
            job.slot = station.slots;
            let here = self.robot.pulses_to_joints(&self.shared.commanded_pulses());
            let (out, from) = self.leave_station(&here)?;
            for step in out
                .into_iter()
                .chain(map_steps(&station, &self.robot, &from)?)
            {
                if !job.push(step) {
                    return Err((Code::Internal, "the mapping has too many steps".into()));
                }
            }
            return Ok(job);
        }
        if slot == 0 || slot > station.slots {
            return Err((
                Code::SlotUnknown,
                format!(
                    "{} has no slot {slot}; its slots are 1 to {}",
                    station.name, station.slots
                ),
            ));
        }
        let dual = self.hand.blade_b.is_some();
        if !dual && (blade != Blade::A || kind == JobKind::Swap) {
            return Err((
                Code::NotAvailable,
                "this robot has one hand; blade B and SWAP need a dual-blade robot ([hand.blade_b] in the configuration)"
                    .to_string(),
            ));
        }
        // SWAP: the empty blade takes the slot's wafer, then the other puts its own there.
        let (tkind, blade, put) = match kind {
            JobKind::Swap => {
                let (a, b) = (self.wafers.hand(), self.wafers.hand_of(Blade::B));
                let (taker, given) =
                    match (a, b) {
                        (None, Some(w)) => (Blade::A, w),
                        (Some(w), None) => (Blade::B, w),
                        (None, None) => return Err((
                            Code::HandEmpty,
                            "SWAP needs a wafer on one blade to put into the slot; both are empty"
                                .to_string(),
                        )),
                        (Some(_), Some(_)) => return Err((
                            Code::HandFull,
                            "SWAP needs one empty blade to take the slot's wafer; both hold one"
                                .to_string(),
                        )),
                    };
                let put = Transfer {
                    kind: TransferKind::Put,
                    station: station.name,
                    slot,
                    wafer: given,
                    blade: taker.other(),
                };
                (TransferKind::Get, taker, Some(put))
            }
            JobKind::Get => (TransferKind::Get, blade, None),
            _ => (TransferKind::Put, blade, None),
        };
        if !self.shared.io_ready.load(Ordering::Acquire) {
            // Right after start-up (or while a board does not answer) the inputs are not
            // read yet: the interlock and the vacuum sensor, judged below from them, would
            // be judged on 0. (A MAP's interlock is checked by the Command Interpreter on the
            // board's own inputs.)
            return Err((
                Code::TransferBusy,
                "the controller has not read its inputs yet; repeat in a moment".to_string(),
            ));
        }
        let transfer = self
            .wafers
            .prepare_blade(tkind, station.name.as_str(), slot, blade)
            .map_err(|e| (map_error_code(&e), e.to_string()))?;
        // A wafer the map does not know on the taking blade would be driven into the slot's.
        if tkind == TransferKind::Get && self.sensed()[blade.index()] {
            return Err((
                Code::HandFull,
                format!(
                    "the vacuum sensor senses a wafer on the {} that the wafer map does not have; take it off or identify it first; nothing moved",
                    wrc_cell::Location::Hand(blade)
                ),
            ));
        }
        if let Some(n) = station.interlock_input {
            if self.shared.inputs[0].load(Ordering::Acquire) & (1u32 << (n & 31)) == 0 {
                return Err((
                    Code::InterlockClosed,
                    format!(
                        "the interlock of {} (input {n}) is closed; nothing moved",
                        station.name
                    ),
                ));
            }
        }
        let here = self.robot.pulses_to_joints(&self.shared.commanded_pulses());
        // Out of a station the hand stands in first, straight along its line.
        let (out, from) = self.leave_station(&here)?;
        let refused = |e: wrc_cell::StationError| (station_code(&e), format!("{e}; nothing moved"));
        let offset = |b: Blade| self.hand.z_offset_mm(b.index());
        let mut steps = vec![JobStep::UseBlade(blade)];
        steps.extend(out);
        let (first, approach) = transfer_steps(
            tkind,
            &station.for_blade(offset(blade)),
            slot,
            &self.robot,
            &from,
            self.blend,
        )
        .map_err(refused)?;
        steps.extend(first);
        if let Some(put) = put {
            // From the GET's approach pose: the PUT's move there only changes the height.
            let (second, _) = transfer_steps(
                TransferKind::Put,
                &station.for_blade(offset(put.blade)),
                slot,
                &self.robot,
                &approach,
                self.blend,
            )
            .map_err(refused)?;
            steps.push(JobStep::UseBlade(put.blade));
            steps.extend(second);
            job.wafer_put = put.wafer.0;
        }
        for step in steps {
            if !job.push(step) {
                return Err((Code::Internal, "the transfer has too many steps".into()));
            }
        }
        job.slot = slot;
        job.wafer = transfer.wafer.0;
        // The pending transfer is on disk before anything moves.
        self.wafers
            .begin(transfer)
            .map_err(|e| (map_error_code(&e), e.to_string()))?;
        self.swap_put = put;
        if let Err(e) = self.save() {
            let _ = self.wafers.abort();
            return Err((
                Code::Internal,
                format!("cannot save the wafer map: {e}; nothing moved"),
            ));
        }
        // The journal is on disk before anything moves too.
        if let Err(e) = self.journal_open(&job, transfer, put) {
            let _ = self.wafers.abort();
            self.swap_put = None;
            let _ = self.save();
            return Err((Code::Internal, format!("{e}; nothing moved")));
        }
        self.broadcast_map();
        Ok(job)
    }

    /// What the Command Interpreter reports.
    pub fn on_event(&mut self, event: CellEvent) {
        match event {
            CellEvent::Step { index, done, at } => self.journal_step(index, done, at),
            CellEvent::Sensed { blade, sensed } => self.sensed_blade(blade, sensed),
            CellEvent::Retracted(out) => self.retracted(out),
            CellEvent::Commit => {
                if self.wafers.commit().is_ok() {
                    // A SWAP's PUT half is pending, on disk, before it moves.
                    if let Some(put) = self.swap_put.take() {
                        if let Err(e) = self.wafers.begin(put) {
                            tracing::warn!("wrc: SWAP: the wafer map refused its PUT half: {e}");
                        }
                        self.journal_swap_half();
                    }
                    self.persist();
                }
            }
            CellEvent::Ended {
                kind,
                started,
                code,
                sensed,
            } => {
                self.busy = None;
                self.swap_put = None;
                if code == Some(Code::BoardLost) {
                    // The board's sensors are stale: nothing is settled from them now
                    // (`poll` may have seen the board dead first).
                    if self.reconciled {
                        self.board_lost(Some(kind));
                    }
                    return self.job_settled();
                }
                if code == Some(Code::WaferLost) {
                    // The job's own watch raised 213: a certain wafer on a blade its
                    // sensor no longer sees becomes uncertain now (a transfer's own wafer is
                    // judged with the journal below).
                    let lost = Blade::ALL
                        .into_iter()
                        .filter(|b| !sensed[b.index()])
                        .fold(0u8, |m, b| m | 1 << b.index());
                    self.lost_from_blades(lost, Some(kind));
                }
                if matches!(kind, JobKind::Map | JobKind::Sense) {
                    return self.job_settled();
                }
                // Finished, or committed and nothing went wrong after: nothing to judge.
                if self.wafers.pending().is_none() && (code.is_none() || self.jjob.is_none()) {
                    self.journal_close(wrc_cell::journal::Closed::Committed);
                    return self.job_settled();
                }
                if !started {
                    // Refused before anything moved: judged now, by the same rules.
                    let here = self.hand_pose();
                    self.settle_ended_transfer(&here);
                    self.job_settled();
                } else {
                    // Judged by the journal and the vacuum sensors, exactly as after a
                    // power loss, once the arm stands still and the sensor has answered:
                    // the sensor read now may predate a pick or a release the brake still
                    // makes.
                    self.settle_ended = SettleEnded::UntilRest;
                }
            }
            CellEvent::Mapped {
                station_index,
                count,
                codes,
            } => {
                let Some(station) = self.stations.iter().nth(station_index as usize) else {
                    return;
                };
                let name = station.name;
                let scan: Vec<SlotCode> = codes[..usize::from(count)]
                    .iter()
                    .map(|&c| match c {
                        0 => SlotCode::Absent,
                        1 => SlotCode::Present,
                        2 => SlotCode::Double,
                        _ => SlotCode::Cross,
                    })
                    .collect();
                match self.wafers.apply_mapping(name.as_str(), &scan) {
                    Ok(changes) => {
                        for (slot, id) in &changes.removed {
                            tracing::warn!("wrc: MAP {name}: wafer {id} of slot {slot} is gone");
                        }
                        self.persist();
                    }
                    Err(e) => {
                        tracing::warn!("wrc: MAP {name}: the wafer map refused the result: {e}")
                    }
                }
            }
            CellEvent::WaferLost { blades } => self.lost_from_blades(blades, None),
            CellEvent::Forced {
                n,
                on,
                from,
                blade,
                wafer,
                valve,
            } => self.forced(n, on, from, blade, wafer, valve),
        }
    }

    /// The cell service has settled a job that ended: publish the map's blades, then count
    /// it (the Command Interpreter's watch of the blades outside a job waits for this).
    fn job_settled(&mut self) {
        self.publish();
        self.shared.jobs_settled.fetch_add(1, Ordering::AcqRel);
    }

    /// The motion board stopped answering (during a job of `during`): nothing moves in the
    /// map. A pending transfer stays pending, a wafer on a blade becomes uncertain, and
    /// both are settled by the journal and the vacuum sensors once the board answers again
    /// (`poll`, as at start-up); until then GET and PUT are refused.
    fn board_lost(&mut self, during: Option<JobKind>) {
        let n = self.wafers.mark_uncertain();
        self.reconciled = false;
        // A pending transfer is settled when the board answers again, as at start-up; the
        // job that left it is done with here.
        if self.settle_ended != SettleEnded::No {
            self.settle_ended = SettleEnded::No;
            self.job_settled();
        }
        let what = if self.wafers.pending().is_some() {
            "keeps the transfer pending"
        } else if n > 0 {
            "marks the wafer on the hand uncertain"
        } else {
            "keeps every wafer where it was"
        };
        let during = during.map_or(String::new(), |k| format!(" during {}", k.verb()));
        tracing::warn!("wrc: the motion board stopped answering{during}: the wafer map {what} until the board's sensors answer again");
        self.persist();
    }

    /// Whether the arm stands still: nothing in flight, at rest in the current stop epoch
    /// (what RESET waits for too).
    fn stands_still(&self) -> bool {
        let s = &self.shared;
        s.in_flight.load(Ordering::Acquire) == 0
            && s.stopped_epoch.load(Ordering::Acquire) == s.stop_epoch.load(Ordering::Acquire)
    }

    /// What each blade's vacuum sensor senses now.
    fn sensed(&self) -> [bool; MAX_BLADES] {
        let inputs = self.shared.inputs[0].load(Ordering::Acquire);
        Blade::ALL.map(|b| {
            self.hand
                .blade(b.index())
                .is_some_and(|s| inputs & (1u32 << (s.vacuum_input & 31)) != 0)
        })
    }

    fn persist(&mut self) {
        if let Err(e) = self.save() {
            tracing::error!("wrc: cannot save the wafer map: {e}");
        }
        self.publish();
        self.broadcast_map();
    }

    /// Tell the Command Interpreter what the map has on each blade ([`Shared::blade_wafers`]:
    /// for the guard on the vacuum valves and the guarded outputs), which blades hold a
    /// certain wafer no transfer uses ([`Shared::hand_wafers`]: their sensors are watched
    /// outside a job; none until the start-up is settled), and the careful speed while a
    /// blade may hold a wafer its vacuum does not clamp.
    fn publish(&self) {
        let pending = self.wafers.pending().copied();
        let mut holding = 0u8;
        for b in Blade::ALL {
            let word = match (pending.filter(|t| t.blade == b), self.wafers.hand_of(b)) {
                (Some(t), _) => u64::from(t.wafer.0) | BLADE_PENDING,
                (None, Some(w)) if self.wafers.is_uncertain(b) => u64::from(w.0) | BLADE_UNCERTAIN,
                (None, Some(w)) => u64::from(w.0),
                (None, None) => 0,
            };
            self.shared.blade_wafers[b.index()].store(word, Ordering::Release);
            if self.reconciled && word != 0 && word & (BLADE_PENDING | BLADE_UNCERTAIN) == 0 {
                holding |= 1 << b.index();
            }
        }
        self.shared.hand_wafers.store(holding, Ordering::Release);
        // Everything moves at the careful speed while a blade may hold a wafer.
        let careful = Blade::ALL
            .into_iter()
            .any(|b| self.wafers.hand_of(b).is_some() && self.wafers.is_uncertain(b));
        let pct = if careful {
            self.careful_speed_pct().round() as u32
        } else {
            0
        };
        self.shared.careful_pct.store(pct, Ordering::Release);
    }

    /// Periodic work: settle a transfer left pending by a crash once the inputs are known,
    /// and one that ended abnormally once the arm stands still and the sensor has answered;
    /// publish what the map has on each blade.
    pub fn poll(&mut self) {
        self.publish_view(false);
        if self.reconciled && self.shared.board_dead.load(Ordering::Acquire) {
            self.board_lost(None);
        }
        let samples = self.shared.io_samples.load(Ordering::Acquire);
        match self.settle_ended {
            SettleEnded::UntilRest if self.stands_still() => {
                // Where the stop left the hand: the settling judges from it, whatever moves
                // the arm meanwhile.
                let rest = self.hand_pose();
                self.settle_ended = SettleEnded::UntilSample(samples + self.settle_samples, rest);
            }
            SettleEnded::UntilSample(after, rest)
                if samples > after
                    && self.reconciled
                    && !self.shared.board_dead.load(Ordering::Acquire) =>
            {
                self.settle_ended = SettleEnded::No;
                self.settle_ended_transfer(&rest);
                self.job_settled();
            }
            _ => {}
        }
        if !self.reconciled
            && self.shared.io_ready.load(Ordering::Acquire)
            && !self.shared.board_dead.load(Ordering::Acquire)
        {
            self.recover();
        }
        self.watch_rest();
        self.publish();
    }
}

/// The I/O Monitor's period when the configuration does not give one (Table 1) [s].
const DEFAULT_IO_PERIOD_S: f64 = 0.1;

/// I/O Monitor readings (of `io_period_s` each) that cover the vacuum sensor's settling
/// time, and one more: the reading after them answers for the sensor.
fn settle_samples(hand: &HandConfig, io_period_s: f64) -> u64 {
    let periods = (hand.vacuum_settle_s / io_period_s.max(1e-3)).ceil();
    periods.clamp(1.0, 1000.0) as u64
}

/// The code of a wafer-map refusal.
fn map_error_code(e: &WaferMapError) -> Code {
    match e {
        WaferMapError::NoSuchStation { .. } => Code::StationUnknown,
        WaferMapError::NoSuchSlot { .. } => Code::SlotUnknown,
        WaferMapError::SlotEmpty { .. } => Code::SlotEmpty,
        WaferMapError::SlotOccupied { .. } => Code::SlotOccupied,
        WaferMapError::SlotFault { .. } | WaferMapError::SlotUnknown { .. } => Code::SlotNotUsable,
        WaferMapError::HandOccupied { .. } => Code::HandFull,
        WaferMapError::HandEmpty => Code::HandEmpty,
        WaferMapError::TransferPending { .. } => Code::TransferBusy,
        WaferMapError::Uncertain { .. } => Code::PlaceUncertain,
        _ => Code::Internal,
    }
}

/// The protocol code of a station that cannot be used for a transfer.
fn station_code(e: &wrc_cell::StationError) -> Code {
    match e {
        wrc_cell::StationError::PathLeavesWorkspace { .. } => Code::PathLeavesWorkspace,
        _ => Code::OutOfReach,
    }
}

/// The steps of `MAP`: the mapping sensor on at the approach pose below slot 1 (the solution
/// a transfer there would use), a straight Z sweep up past the last slot, the sensor off,
/// the latch read.
fn map_steps(
    station: &wrc_cell::Station,
    robot: &Robot,
    from: &wrc_robot::Joints,
) -> Result<Vec<JobStep>, (Code, String)> {
    use wrc_cell::Step;
    let refused = |e: wrc_cell::StationError| (station_code(&e), format!("{e}; nothing moved"));
    let first = station
        .approach_joints(robot, 1, false, from)
        .map_err(refused)?;
    let last = station
        .approach_pose(station.slots, true)
        .map_err(refused)?;
    let mut steps = Vec::with_capacity(9);
    steps.extend(
        station
            .interlock_input
            .map(|n| JobStep::Transfer(Step::RequireInput(n))),
    );
    steps.push(JobStep::Joints(first));
    steps.push(JobStep::Transfer(Step::Speed(station.speed_pct)));
    steps.push(JobStep::MapClear);
    steps.push(JobStep::MapSensor(true));
    steps.push(JobStep::Transfer(Step::Z(last)));
    steps.push(JobStep::MapSensor(false));
    steps.push(JobStep::MapRead);
    steps.push(JobStep::Transfer(Step::RestoreSpeed));
    Ok(steps)
}
