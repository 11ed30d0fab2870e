//! The messages of a wafer job (`GET`, `PUT`, `MAP`) between the cell service (non-real-time:
//! it checks the request against the wafer map, saves the map and plans the steps) and the
//! Command Interpreter (real-time: it carries the steps out, watches the vacuum, and
//! answers). Every type is fixed-size and `Copy`, so the real-time side sends and receives
//! them without allocating.
//!
//! The order that makes the map crash-safe: the service saves the pending transfer
//! (`WaferMap::begin`) *before* it hands the job over; the Command Interpreter reports
//! [`CellEvent::Commit`] the moment the vacuum sensor has confirmed the wafer's new place,
//! and [`CellEvent::Ended`] at the end; the service commits (or settles a failed transfer
//! by its journal and the vacuum sensors, as at start-up) and saves. Outside a job the
//! Command Interpreter reports a wafer its sensor lost ([`CellEvent::WaferLost`]) and a
//! forced switch of a guarded output ([`CellEvent::Forced`]).
//!
//! The transfer journal (`wrc_cell::journal`) goes the same way: the Command Interpreter
//! reports every step of a GET, PUT or SWAP as it begins and ends ([`CellEvent::Step`]), the
//! service appends it to the journal and makes it durable, and a step that moves the hand or
//! switches the vacuum starts only once the service has answered [`JournalAck`] for its
//! beginning: after a power loss the journal bounds what the robot did.

use wrc_cell::obstacle::MAX_SOLIDS;
use wrc_cell::{Blade, CellModel, Step, MAX_BLADES};
use wrc_protocol::{Code, ReplyTo, StationName};

use super::{floor_char_boundary, SourceId};

/// The cell as the Command Interpreter checks every motion against it: the stations and
/// obstacles as solids, and which blades may hold a wafer (the map's, certain or not).
/// Published by the cell service through a mailbox whenever the stations or the map change.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellView {
    /// The cell's solids.
    pub model: CellModel,
    /// Per blade (the hand first): the map has a wafer on it.
    pub wafers: [bool; MAX_BLADES],
    /// The stations' lines, to take a hand found inside one straight out.
    pub lines: [Option<StationLine>; MAX_SOLIDS],
}

impl CellView {
    /// No cell: every motion is clear.
    pub fn empty(robot: &wrc_robot::Robot) -> CellView {
        CellView {
            model: CellModel::empty(robot),
            wafers: [false; MAX_BLADES],
            lines: [None; MAX_SOLIDS],
        }
    }

    /// The cell of `stations` (as `model`) with `wafers` on the blades.
    pub fn of<'a>(
        model: CellModel,
        wafers: [bool; MAX_BLADES],
        stations: impl IntoIterator<Item = &'a wrc_cell::Station>,
    ) -> CellView {
        let mut lines = [None; MAX_SOLIDS];
        for (l, s) in lines.iter_mut().zip(stations) {
            *l = Some(StationLine::of(s));
        }
        CellView {
            model,
            wafers,
            lines,
        }
    }

    /// The way straight out of the station the hand at `pose` is inside, if it is inside
    /// one (`careful`: a blade may hold a wafer, or the map has one on a blade).
    pub fn retract_from(&self, pose: &wrc_robot::Pose, careful: bool) -> Option<RetractPlan> {
        let careful = careful || self.wafers.iter().any(|w| *w);
        self.lines
            .iter()
            .flatten()
            .find_map(|l| l.retract_from(pose, careful))
    }
}

/// A station's line as the Command Interpreter needs it to take a hand it finds inside the
/// station straight out (`HOME`, `RETRACT`) when no recovery planned it: an operator who
/// moved in to teach, a program stopped inside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StationLine {
    /// The station.
    pub name: StationName,
    /// Slot 1's taught pose: the line's seat and its yaw.
    pub seat: wrc_robot::Pose,
    /// How far the approach pose lies back from the seat along the line [mm].
    pub approach_mm: f64,
    /// The station's speed [%].
    pub speed_pct: f64,
}

impl StationLine {
    /// The line of `station`.
    pub fn of(station: &wrc_cell::Station) -> StationLine {
        StationLine {
            name: station.name,
            seat: station.pose,
            approach_mm: station.approach_mm,
            speed_pct: station.speed_pct,
        }
    }

    /// The retract out of this station for a hand at `pose`, if the hand is inside it
    /// ([`RetractPlan::inside`]): to the approach pose at the hand's height, at the
    /// station's speed and at most [`crate::cell_service::RETRACT_SPEED_PCT`], as after a
    /// power loss.
    pub fn retract_from(&self, pose: &wrc_robot::Pose, careful: bool) -> Option<RetractPlan> {
        let (s, c) = self.seat.yaw.to_radians().sin_cos();
        let plan = RetractPlan {
            station: self.name,
            to: wrc_robot::Pose {
                x: self.seat.x - self.approach_mm * c,
                y: self.seat.y - self.approach_mm * s,
                z: pose.z,
                yaw: self.seat.yaw,
            },
            depth_mm: self.approach_mm,
            speed_pct: self.speed_pct.min(crate::cell_service::RETRACT_SPEED_PCT),
            careful,
        };
        plan.inside(pose).then_some(plan)
    }
}

/// Most steps in one job.
pub const MAX_JOB_STEPS: usize = 32;

/// Most slots a mapping reports.
pub const MAX_MAP_SLOTS: usize = 64;

/// How far off a station's line (sideways [mm], turned [deg]) a hand inside it may stand and
/// still be taken straight out ([`RetractPlan`], a job's way out of the station it stands
/// in): a stop's brake in a blended approach or on a line may leave it by a few millimetres
/// (up to 3.8 mm and 3.7° measured), and the straight line to the approach pose only brings
/// it nearer the line. Farther off, it is moved out by hand (`JOG`).
pub const ON_LINE_MM: f64 = 5.0;
/// See [`ON_LINE_MM`] [deg].
pub const ON_LINE_DEG: f64 = 5.0;

/// How far off a station's line a hand in front of it (`wrc_cell::Station::hand_inside`)
/// may stand and be in the station at all [mm]: a cassette's slot leaves a wafer a few
/// millimetres, so a hand farther off stands in the open space before the station (where a
/// joint move passes), not in it.
pub const IN_STATION_MM: f64 = 20.0;
/// See [`IN_STATION_MM`] [deg].
pub const IN_STATION_DEG: f64 = 15.0;

/// What a job does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JobKind {
    /// `GET <station> <slot>`.
    Get,
    /// `PUT <station> <slot>`.
    Put,
    /// `MAP <station>`.
    Map,
    /// `SWAP <station> <slot>`: a GET with the empty blade, then a PUT with the other.
    Swap,
    /// `SENSE [A|B]`: the blade's vacuum on, its sensor read (the valve stays on for a wafer
    /// sensed, goes off otherwise).
    Sense,
}

impl JobKind {
    /// The verb, as on the wire.
    pub fn verb(self) -> &'static str {
        match self {
            JobKind::Get => "GET",
            JobKind::Put => "PUT",
            JobKind::Map => "MAP",
            JobKind::Swap => "SWAP",
            JobKind::Sense => "SENSE",
        }
    }

    /// Whether its steps are journaled (it moves a wafer).
    pub fn journaled(self) -> bool {
        matches!(self, JobKind::Get | JobKind::Put | JobKind::Swap)
    }
}

/// One step of a job.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JobStep {
    /// A step of a transfer ([`wrc_cell::plan`]).
    Transfer(Step),
    /// A PTP move to these joints [deg or mm per axis]: the transfer's move to the approach
    /// pose, with the solution the cell service chose ([`wrc_cell::Station::approach_joints`]).
    Joints(wrc_robot::Joints),
    /// Clear the board's mapping latch and wait until it has.
    MapClear,
    /// Switch the mapping sensor on or off.
    MapSensor(bool),
    /// Read the mapping latch: every slot must have been seen at the job's station.
    MapRead,
    /// The following vacuum steps switch and read this blade's valve and sensor.
    UseBlade(Blade),
    /// Wait the vacuum sensor's settling time, read the job's blade's sensor and report it
    /// ([`CellEvent::Sensed`]); switch the valve off again when it senses nothing.
    Sense,
    /// A blended approach (docs/motion.md): the move to the approach pose `via` flowing
    /// into the straight line in to `to` at the station's `speed_pct`, with the station's
    /// interlock checked when it starts and watched until it is committed to enter. Made by
    /// [`crate::cell_service::transfer_steps`] from the plan's move to the approach pose,
    /// speed, interlock and line in, when blending is on.
    Approach {
        /// The approach pose's joints (the solution the cell service chose).
        via: wrc_robot::Joints,
        /// The end of the line in (under or above the slot).
        to: wrc_robot::Pose,
        /// The station's speed override [%].
        speed_pct: f64,
        /// The station's interlock input, if it has one.
        interlock: Option<u8>,
    },
}

impl JobStep {
    /// Whether it moves the hand or switches the vacuum: in a journaled job it starts only
    /// once its beginning is on disk ([`JournalAck`]).
    pub fn physical(&self) -> bool {
        matches!(
            self,
            JobStep::Transfer(Step::Line(_) | Step::Z(_) | Step::Vacuum(_) | Step::Ptp(..))
                | JobStep::Joints(_)
                | JobStep::Approach { .. }
        )
    }
}

/// A job the cell service hands to the Command Interpreter.
#[derive(Debug, Clone, Copy)]
pub struct CellJob {
    /// Who asked ([`SourceId::PROGRAM`] for a program's statement): gets the replies.
    pub from: SourceId,
    /// Where the replies go.
    pub to: ReplyTo,
    /// What it does.
    pub kind: JobKind,
    /// The station.
    pub station: StationName,
    /// The station's index in the stations file (the board's mapping latch names it + 1).
    pub station_index: u32,
    /// GET/PUT: the slot; MAP: the station's slot count.
    pub slot: u16,
    /// GET/PUT: the wafer's id number (`W<n>`); SWAP: the wafer it takes.
    pub wafer: u32,
    /// SWAP: the wafer it puts (0 otherwise).
    pub wafer_put: u32,
    /// The blades that hold a wafer when the job starts (bit 0: A, bit 1: B): their vacuum
    /// sensors are watched during every motion until a step releases them.
    pub holding: u8,
    /// The steps, `steps[..len]`.
    pub steps: [JobStep; MAX_JOB_STEPS],
    /// Steps used.
    pub len: usize,
}

impl CellJob {
    /// A job without steps.
    pub fn new(from: SourceId, to: ReplyTo, kind: JobKind, station: StationName) -> CellJob {
        CellJob {
            from,
            to,
            kind,
            station,
            station_index: 0,
            slot: 0,
            wafer: 0,
            wafer_put: 0,
            holding: 0,
            steps: [JobStep::MapRead; MAX_JOB_STEPS],
            len: 0,
        }
    }

    /// Append a step; `false` when the job is full.
    pub fn push(&mut self, step: JobStep) -> bool {
        if self.len == MAX_JOB_STEPS {
            return false;
        }
        self.steps[self.len] = step;
        self.len += 1;
        true
    }

    /// The steps.
    pub fn steps(&self) -> &[JobStep] {
        &self.steps[..self.len]
    }
}

/// A refusal for a program's statement: the program ends with it.
#[derive(Debug, Clone, Copy)]
pub struct JobRefusal {
    /// The code.
    pub code: Code,
    /// Bytes used in `text`.
    pub len: usize,
    /// The reason.
    pub text: [u8; 200],
}

impl JobRefusal {
    /// A refusal with `text` (cut at 200 bytes, on a character boundary).
    pub fn new(code: Code, text: &str) -> JobRefusal {
        let len = floor_char_boundary(text, 200);
        let mut buf = [0u8; 200];
        buf[..len].copy_from_slice(&text.as_bytes()[..len]);
        JobRefusal {
            code,
            len,
            text: buf,
        }
    }

    /// The reason.
    pub fn text(&self) -> &str {
        std::str::from_utf8(&self.text[..self.len]).unwrap_or("refused")
    }
}

/// From the cell service to the Command Interpreter.
// The job is large on purpose: boxing it would allocate in the real-time receiver's
// counterpart, and the queue holds four.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
pub enum JobOffer {
    /// Carry this job out.
    Start(CellJob),
    /// The running program's statement was refused: end the program with this.
    Refused(JobRefusal),
    /// What the start-up (or a board that answers again) found: where the hand must be
    /// taken out of a station before anything else moves it (`None`: nowhere), and whether
    /// to raise alarm 216 (a transfer a power loss interrupted).
    Recovery {
        /// The retract HOME and RETRACT make first.
        retract: Option<RetractPlan>,
        /// Raise alarm 216.
        alarm: bool,
    },
}

/// The hand may be inside a station: take it straight out along the station's line to the
/// approach pose at its height, slowly, before any other motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RetractPlan {
    /// The station.
    pub station: StationName,
    /// The approach pose at the hand's height (the line's end, outside).
    pub to: wrc_robot::Pose,
    /// How far the station's seat lies beyond `to`, along its line (its `approach_mm`).
    pub depth_mm: f64,
    /// The speed of the retract and, when a blade may hold a wafer, of the HOME after it
    /// [%].
    pub speed_pct: f64,
    /// A blade may hold a wafer: HOME moves at `speed_pct` too.
    pub careful: bool,
}

/// The service's answer to a step's beginning ([`CellEvent::Step`]): journaled, or not
/// (the transfer stops).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct JournalAck {
    /// The step.
    pub step: u8,
    /// Whether the record is on disk.
    pub ok: bool,
}

impl RetractPlan {
    /// Where `pose` is from the line out: how far past the approach pose along it [mm], how
    /// far off it sideways [mm], and how far turned from it [deg].
    pub fn offset(&self, pose: &wrc_robot::Pose) -> (f64, f64, f64) {
        let (s, c) = self.to.yaw.to_radians().sin_cos();
        let (dx, dy) = (pose.x - self.to.x, pose.y - self.to.y);
        (
            dx * c + dy * s,
            (dx * s - dy * c).abs(),
            wrc_robot::wrap180(pose.yaw - self.to.yaw).abs(),
        )
    }

    /// Whether the hand at `pose` is inside the plan's station: past its approach pose, not
    /// behind its seat, and within [`IN_STATION_MM`] and [`IN_STATION_DEG`] of its line.
    pub fn inside(&self, pose: &wrc_robot::Pose) -> bool {
        let (along, lateral, turned) = self.offset(pose);
        along > wrc_cell::INSIDE_ENTRY_MARGIN_MM
            && along <= self.depth_mm + wrc_cell::INSIDE_BEYOND_SEAT_MM
            && lateral <= IN_STATION_MM
            && turned <= IN_STATION_DEG
    }
}

/// From the Command Interpreter to the cell service.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CellEvent {
    /// Step `index` of the running job begins (`done` false) or has ended, with the hand at
    /// `at` (the commanded pose): for the transfer journal.
    Step {
        /// The step's index.
        index: u8,
        /// Ended (else begins).
        done: bool,
        /// Where the hand is.
        at: wrc_robot::Pose,
    },
    /// A `SENSE`: what the blade's vacuum sensor read with the valve on.
    Sensed {
        /// The blade.
        blade: Blade,
        /// A wafer sensed.
        sensed: bool,
    },
    /// The retract of a [`RetractPlan`] ended: the hand is outside (`true`), or it was
    /// stopped.
    Retracted(bool),
    /// The vacuum sensor confirmed the pending transfer's wafer at its destination.
    Commit,
    /// The job ended. `started`: it was accepted (ACK) and steps ran; `code`: `None` when
    /// it finished normally; `sensed`: the vacuum sensor's reading at the end.
    Ended {
        /// The job's kind.
        kind: JobKind,
        /// Whether it was accepted.
        started: bool,
        /// Why it failed, if it did.
        code: Option<Code>,
        /// The vacuum-sensed input of each blade at the end.
        sensed: [bool; MAX_BLADES],
    },
    /// A mapping's result: `codes[..count]`, one [`wrc_cell::SlotCode`] number per slot
    /// (0 absent, 1 present, 2 double, 3 cross).
    Mapped {
        /// The station's index in the stations file.
        station_index: u32,
        /// Slots.
        count: u16,
        /// The codes.
        codes: [u8; MAX_MAP_SLOTS],
    },
    /// The vacuum sensor lost a blade's wafer outside a job (code 213, raised already): the
    /// map must not keep claiming it.
    WaferLost {
        /// The blades whose sensor lost its wafer (bit 0: A, bit 1: B).
        blades: u8,
    },
    /// `OUT <n> <0|1> FORCE` switched a guarded output while a blade held a wafer (the
    /// Command Interpreter did it; the cell service logs it and tells everyone).
    Forced {
        /// The output.
        n: u8,
        /// Switched on (else off).
        on: bool,
        /// Who asked.
        from: SourceId,
        /// The blade whose wafer made it guarded.
        blade: Blade,
        /// That wafer's number.
        wafer: u32,
        /// The output is that blade's vacuum valve (else one the configuration guards).
        valve: bool,
    },
}
