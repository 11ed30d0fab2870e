//! The messages that flow between the controller's tasks and its service thread: move
//! orders and their ends, requests and their replies, emergencies, program and store
//! requests. A leaf module: every type is fixed-size (sent from real-time tasks without
//! allocating, except the boxed program, whose box is only moved) and depends on no other
//! module of the controller.

use std::sync::Arc;

use wrc_lang::Program;
use wrc_motion::{MotionState, PathSpec};
use wrc_protocol::{ProgramName, ReplyTo, Request, StationName, MAX_LINE};
use wrc_robot::{Joints, Pose, Posture, MAX_AXES};
use wrc_rt::ipc::MessageQueue;
use wrc_rt::Notify;

use crate::shared::StopKind;

pub mod cell_job;

/// A request or a disconnection, for the Command Interpreter.
// Fixed-size on purpose (a request is sent from real-time tasks without allocating); the
// largest request, POINT with a joint value per axis, is some 200 bytes.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
pub enum Incoming {
    /// A parsed request from a source.
    Request(SourceId, Request),
    /// A source went away.
    Disconnected(SourceId),
}

/// A move the Command Interpreter hands to the Velocity Generator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MoveKind {
    /// PTP in joint space [deg or mm per axis].
    Joints(Joints),
    /// PTP to a Cartesian pose, with the elbow posture or the current one.
    Pose(Pose, Option<Posture>),
    /// Straight line of the TCP to a pose.
    Line(Pose),
    /// A blended approach to a station (docs/motion.md): every axis to `via` (the line's
    /// start, checked joints), reached at the speed of the straight line from there to `to`,
    /// which it flows into at `line_pct` (the station's speed; never above the order's).
    Approach {
        /// Joints of the line's start (the station's approach pose).
        via: Joints,
        /// The line's end (the seat).
        to: Pose,
        /// Speed override of the line [%].
        line_pct: f64,
    },
    /// A composite path (docs/motion.md, "Arcs", "Blended paths"): lines and arcs from
    /// `start`, each corner blended within its zone. `start` must be where the motion before
    /// it ends (the move is refused, code 113, from anywhere else); from a point of the path
    /// it is the rest of it (RESUME sends the same order again).
    Path(PathSpec),
    /// A PTP flowing into a path without stopping at its start (docs/motion.md, "PTP
    /// blends"): every axis to `via` (the joints at `path.start`, checked), reached moving,
    /// then `path` at `path_pct` (never above the order's speed). No station rule: a
    /// program's blended PTP. From the path's start or a point of it, the path alone.
    PtpToPath {
        /// The joints at the path's start.
        via: Joints,
        /// The path.
        path: PathSpec,
        /// Speed override of the path [%].
        path_pct: f64,
    },
    /// A path flowing into a PTP without stopping at its end (docs/motion.md, "PTP
    /// blends"): `path` at `path_pct` (never above the order's speed) from `path.start`,
    /// then every axis to the joints `to` (checked), at rest there. From a point of the path,
    /// the rest of it and the PTP; from anywhere else, the PTP alone (a RESUME after a HOLD
    /// in the PTP part).
    Depart {
        /// The path.
        path: PathSpec,
        /// The joints the PTP goes to.
        to: Joints,
        /// Speed override of the path [%].
        path_pct: f64,
    },
    /// A PTP through the joints `via` to the joints `to` without stopping at `via`
    /// (docs/motion.md, "PTP blends"). `start` is where the motion before it ends: from
    /// elsewhere (RESUME) it goes through `via` unless it was held past it.
    Via {
        /// The joints where the move starts.
        start: Joints,
        /// The joints it passes moving.
        via: Joints,
        /// The joints it ends at.
        to: Joints,
    },
    /// A pulse count on one axis.
    Jog {
        /// Axis index.
        axis: usize,
        /// Pulses (negative: backwards).
        pulses: i64,
    },
}

/// One order for the Velocity Generator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveOrder {
    /// Identifies the move in the replies (never 0).
    pub ticket: u32,
    /// The stop epoch when it was ordered: a stop cancels every older order.
    pub epoch: u32,
    /// Speed override for this move [%].
    pub speed_pct: f64,
    /// Acceleration override for this move [%] (100: the axes' full acceleration and
    /// jerk).
    pub accel_pct: f64,
    /// What to do.
    pub kind: MoveKind,
}

/// One period's pulses on their way from the Velocity Generator to the Pulse Generator.
#[derive(Debug, Clone, Copy)]
pub struct Batch {
    /// Pulses per axis for the period [pulse].
    pub pulses: [i64; MAX_AXES],
    /// Stop epoch of the plan it belongs to; a newer stop discards it.
    pub epoch: u32,
    /// The move it belongs to.
    pub ticket: u32,
    /// The last period of that move.
    pub last: bool,
    /// The generator's state after this period, to stop from if the stop comes now.
    pub after: MotionState,
}

/// How a move ended, reported to the Command Interpreter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MoveOutcome {
    /// Its last period was pushed to the board.
    Completed,
    /// A stop brought it to rest early.
    Stopped,
    /// A HOLD brought it to rest on its path; it stays open until RESUME continues it or a
    /// stop abandons it.
    Held,
    /// It could not be planned (the reason is a protocol code number).
    Refused(u16),
}

/// A move's end, from the Velocity or Pulse Generator to the Command Interpreter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MoveDone {
    /// The move's ticket.
    pub ticket: u32,
    /// How it ended.
    pub outcome: MoveOutcome,
}

/// Who sent a command: the kind of source and its connection slot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct SourceId(pub u32);

impl SourceId {
    /// Nobody (no owner, or a message for every client).
    pub const NONE: SourceId = SourceId(0);
    /// The controller itself (Error Check, I/O Monitor).
    pub const CONTROLLER: SourceId = SourceId(1);
    /// Every client (events), as an address for the Command Interpreter's replies.
    pub const BROADCAST: SourceId = SourceId(2);
    /// The robot-language program the Command Interpreter runs.
    pub const PROGRAM: SourceId = SourceId(3);
    /// The steps of a wafer job (`GET`, `PUT`, `MAP`) the Command Interpreter carries out.
    pub const CELL: SourceId = SourceId(4);
    /// Kind tag of a TCP host connection.
    pub const TCP: u32 = 1;
    /// Kind tag of a local GUI connection (Unix socket).
    pub const GUI: u32 = 2;
    /// Kind tag of the teaching pendant (serial line).
    pub const PENDANT: u32 = 3;

    /// A source of `kind` at connection `slot` (generation keeps reused slots apart).
    pub fn new(kind: u32, slot: u32, generation: u32) -> SourceId {
        SourceId((kind << 28) | ((generation & 0xfff) << 16) | (slot & 0xffff))
    }

    /// The kind tag.
    pub fn kind(self) -> u32 {
        self.0 >> 28
    }

    /// The connection slot.
    pub fn slot(self) -> usize {
        (self.0 & 0xffff) as usize
    }
}

impl std::fmt::Display for SourceId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.kind() {
            _ if *self == SourceId::NONE => f.write_str("none"),
            _ if *self == SourceId::CONTROLLER => f.write_str("controller"),
            _ if *self == SourceId::PROGRAM => f.write_str("program"),
            _ if *self == SourceId::CELL => f.write_str("cell"),
            SourceId::TCP => write!(f, "tcp{}", self.slot()),
            SourceId::GUI => write!(f, "gui{}", self.slot()),
            SourceId::PENDANT => f.write_str("pendant"),
            _ => write!(f, "src{:x}", self.0),
        }
    }
}

/// Longest reply line [bytes], newline included: a reply buffer's (a line cut here would
/// lose its newline and run into the next one).
pub const LINE_MAX: usize = wrc_protocol::REPLY_CAPACITY;

/// One reply or event line on its way to a client, fixed-size (no allocation).
#[derive(Clone, Copy)]
pub struct OutLine {
    /// The client, or [`SourceId::NONE`] for every client (events).
    pub to: SourceId,
    len: u16,
    text: [u8; LINE_MAX],
}

impl OutLine {
    /// A line for `to` with `text` (cut at [`LINE_MAX`] bytes).
    pub fn new(to: SourceId, text: &[u8]) -> OutLine {
        let mut line = OutLine {
            to,
            len: 0,
            text: [0; LINE_MAX],
        };
        let n = text.len().min(LINE_MAX);
        line.text[..n].copy_from_slice(&text[..n]);
        line.len = n as u16;
        line
    }

    /// The bytes of the line.
    pub fn bytes(&self) -> &[u8] {
        &self.text[..self.len as usize]
    }
}

impl std::fmt::Debug for OutLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "OutLine({}, {:?})",
            self.to,
            String::from_utf8_lossy(self.bytes())
        )
    }
}

/// An emergency for the Command Interpreter's urgent path (posted with its semaphore).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Urgent {
    /// STOP from a source (with where its reply goes).
    Stop(SourceId, wrc_protocol::ReplyTo),
    /// ESTOP from a source (with where its reply goes).
    Estop(SourceId, wrc_protocol::ReplyTo),
    /// A fault found by Error Check: the protocol code number.
    Fault(u16),
}

impl Urgent {
    /// The stop it requests: ESTOP and faults brake with the axes' full limits. None for
    /// the E-stop input (202): the Pulse Generator asked for its stop the period it saw the
    /// input open, within the board's grace (docs/dpram.md, "Stops" 6); a second
    /// stop would only brake again from where the first brake is.
    pub fn stop_kind(&self) -> Option<StopKind> {
        match self {
            Urgent::Stop(..) => Some(StopKind::Stop),
            Urgent::Fault(n) if *n == wrc_protocol::Code::EstopInput.number() => None,
            Urgent::Estop(..) | Urgent::Fault(_) => Some(StopKind::Estop),
        }
    }
}

/// The largest index ≤ `max` that is a character boundary of `text`.
pub(crate) fn floor_char_boundary(text: &str, max: usize) -> usize {
    let mut n = text.len().min(max);
    while !text.is_char_boundary(n) {
        n -= 1;
    }
    n
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
    pub fn send(&self, to: SourceId, bytes: &[u8]) {
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

/// A request for the program store, fixed-size so real-time tasks send it without
/// allocating.
// The line variant is large on purpose: boxing it would allocate in the real-time sender.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy)]
pub enum StoreRequest {
    /// `UPLOAD <name>`: the lines that follow from `from` are program text.
    Begin {
        /// The uploading connection.
        from: SourceId,
        /// Where the final reply goes.
        to: ReplyTo,
        /// The program's name.
        name: ProgramName,
    },
    /// One line of program text (without its line end).
    Line {
        /// The uploading connection.
        from: SourceId,
        /// Bytes used in `text`.
        len: u16,
        /// The line.
        text: [u8; MAX_LINE],
    },
    /// The line `.`: compile and store.
    End {
        /// The uploading connection.
        from: SourceId,
    },
    /// The upload from `from` ended without `.` (the connection went away, or a line was
    /// refused): forget it.
    Cancel {
        /// The uploading connection.
        from: SourceId,
    },
    /// `PROGRAMS`.
    List {
        /// The requesting connection.
        from: SourceId,
        /// Where the reply goes.
        to: ReplyTo,
    },
    /// `DELETE <name>`.
    Delete {
        /// The requesting connection.
        from: SourceId,
        /// Where the reply goes.
        to: ReplyTo,
        /// The program.
        name: ProgramName,
    },
    /// `ROBOT`: the robot's geometry and axes.
    Robot {
        /// The requesting connection.
        from: SourceId,
        /// Where the replies go.
        to: ReplyTo,
    },
    /// `TASKS`: every real-time task's measured timing.
    Tasks {
        /// The requesting connection.
        from: SourceId,
        /// Where the replies go.
        to: ReplyTo,
    },
    /// `TRACE SAVE [<name>]`: write the trace recorder's last seconds to a file.
    TraceSave {
        /// The requesting connection.
        from: SourceId,
        /// Where the reply goes.
        to: ReplyTo,
        /// The file's name (`<name>.wrctrace` in the trace directory); `None`: from the time.
        name: Option<ProgramName>,
    },
    /// `STN`: list the stations.
    Stn {
        /// The requesting connection.
        from: SourceId,
        /// Where the replies go.
        to: ReplyTo,
    },
    /// `TEACH <station>`: the current pose becomes the station's taught pose.
    Teach {
        /// The requesting connection.
        from: SourceId,
        /// Where the reply goes.
        to: ReplyTo,
        /// The station.
        name: StationName,
    },
    /// `WAFERS`: where every wafer is.
    Wafers {
        /// The requesting connection.
        from: SourceId,
        /// Where the replies go.
        to: ReplyTo,
    },
    /// `GET`, `PUT`, `SWAP` or `MAP` (from a connection, or from the running program with
    /// [`SourceId::PROGRAM`]).
    Job {
        /// The requesting connection.
        from: SourceId,
        /// Where the replies go.
        to: ReplyTo,
        /// Which.
        kind: crate::messages::cell_job::JobKind,
        /// The station.
        station: StationName,
        /// GET/PUT/SWAP: the slot.
        slot: u16,
        /// GET/PUT: the blade (A for MAP and SWAP).
        blade: wrc_cell::Blade,
    },
    /// `RECOVERY`: what an interrupted transfer left uncertain.
    Recovery {
        /// The requesting connection.
        from: SourceId,
        /// Where the replies go.
        to: ReplyTo,
    },
    /// `SENSE [A|B]`: read a blade's vacuum sensor with its valve on.
    Sense {
        /// The requesting connection.
        from: SourceId,
        /// Where the reply goes.
        to: ReplyTo,
        /// The blade.
        blade: wrc_cell::Blade,
    },
    /// `CONFIRM …`: an operator's word on an uncertain place.
    Confirm {
        /// The requesting connection.
        from: SourceId,
        /// Where the reply goes.
        to: ReplyTo,
        /// What is confirmed.
        arg: wrc_protocol::ConfirmArg,
    },
    /// `RUN <name> [STEP]`: compile the stored text and hand it to the Command Interpreter.
    Run {
        /// The requesting connection.
        from: SourceId,
        /// Where the replies go.
        to: ReplyTo,
        /// The program.
        name: ProgramName,
        /// Start paused before the first statement.
        step: bool,
    },
    /// `POINTS <program>`: list a stored program's named points.
    Points {
        /// The requesting connection.
        from: SourceId,
        /// Where the replies go.
        to: ReplyTo,
        /// The program.
        program: ProgramName,
    },
    /// `POINT <program> <name> …`: set, teach or delete a named point.
    Point {
        /// The requesting connection.
        from: SourceId,
        /// Where the reply goes.
        to: ReplyTo,
        /// The program.
        program: ProgramName,
        /// The point.
        point: ProgramName,
        /// What to do.
        action: wrc_protocol::PointAction,
    },
    /// The running program asks about the wafer map or a station (`SLOT(…)`, …); the
    /// answer comes back on [`StoreLinks::answers`].
    Cell {
        /// The question.
        query: wrc_lang::CellQuery,
    },
    /// The running program's `TEACH point`: store `value` in `program`'s points file; the
    /// answer (the value stored, or why not) comes back on [`StoreLinks::answers`].
    TeachPoint {
        /// The program.
        program: ProgramName,
        /// The point.
        point: ProgramName,
        /// Where the robot is: a pose, or joints for a point of joints.
        value: wrc_lang::PointValue,
    },
}

/// The service's answer to the running program's question ([`StoreRequest::Cell`],
/// [`StoreRequest::TeachPoint`]).
#[derive(Debug, Clone, Copy)]
pub enum ProgramAnswer {
    /// The answer.
    Value(wrc_lang::Answer),
    /// It could not be answered: the program's statement fails with this code and text.
    Failed(cell_job::JobRefusal),
}

impl StoreRequest {
    /// A [`StoreRequest::Line`] with `text` (cut at [`MAX_LINE`] bytes).
    pub fn line(from: SourceId, text: &[u8]) -> StoreRequest {
        let mut line = [0u8; MAX_LINE];
        let n = text.len().min(MAX_LINE);
        line[..n].copy_from_slice(&text[..n]);
        StoreRequest::Line {
            from,
            len: n as u16,
            text: line,
        }
    }
}

/// A compiled program on its way to the Command Interpreter.
pub struct ProgramStart {
    /// The requesting connection (gets the ACK and the final INF/ABS).
    pub from: SourceId,
    /// Where the replies go.
    pub to: ReplyTo,
    /// The program's name.
    pub name: ProgramName,
    /// The compiled program.
    pub program: Box<Program>,
    /// Start paused before the first statement (`RUN <name> STEP`).
    pub step: bool,
}

/// The queues between the store and the real-time tasks.
#[derive(Clone)]
pub struct StoreLinks {
    /// Requests from the Ethernet and RS232C tasks.
    pub requests: Arc<MessageQueue<StoreRequest>>,
    /// Compiled programs for the Command Interpreter.
    pub starts: Arc<MessageQueue<ProgramStart>>,
    /// Programs the Command Interpreter is done with (freed by the store).
    pub retired: Arc<MessageQueue<Box<Program>>>,
    /// Wafer jobs (and refusals of a program's) for the Command Interpreter.
    pub jobs: Arc<MessageQueue<crate::messages::cell_job::JobOffer>>,
    /// What the Command Interpreter reports of the wafer jobs.
    pub cell_events: Arc<MessageQueue<crate::messages::cell_job::CellEvent>>,
    /// Answers to the running program's questions, for the Command Interpreter.
    pub answers: Arc<MessageQueue<ProgramAnswer>>,
    /// The transfer journal's answers to the steps' beginnings, for the Command Interpreter.
    pub journaled: Arc<MessageQueue<crate::messages::cell_job::JournalAck>>,
}

/// Room in the queue of wafer-job events: a job's every step begins and ends, twice its
/// [`cell_job::MAX_JOB_STEPS`], with room to spare for a slow disk.
const CELL_EVENTS: usize = 256;

/// Room in the queue of the journal's answers: one per step.
const JOURNAL_ACKS: usize = 64;

impl StoreLinks {
    /// Queues of sensible sizes.
    pub fn new() -> StoreLinks {
        StoreLinks {
            requests: Arc::new(MessageQueue::new(4096)),
            starts: Arc::new(MessageQueue::new(4)),
            retired: Arc::new(MessageQueue::new(16)),
            jobs: Arc::new(MessageQueue::new(4)),
            cell_events: Arc::new(MessageQueue::new(CELL_EVENTS)),
            answers: Arc::new(MessageQueue::new(4)),
            journaled: Arc::new(MessageQueue::new(JOURNAL_ACKS)),
        }
    }
}

impl StoreLinks {
    /// Queues of the same sizes whose messages wake their consumer: requests and wafer-job
    /// events wake the service thread (`service`), compiled programs and wafer jobs the
    /// Command Interpreter (`interpreter`).
    pub fn notifying(service: Arc<dyn Notify>, interpreter: Arc<dyn Notify>) -> StoreLinks {
        StoreLinks {
            requests: Arc::new(MessageQueue::with_notify(4096, service.clone())),
            starts: Arc::new(MessageQueue::with_notify(4, interpreter.clone())),
            retired: Arc::new(MessageQueue::new(16)),
            jobs: Arc::new(MessageQueue::with_notify(4, interpreter.clone())),
            cell_events: Arc::new(MessageQueue::with_notify(CELL_EVENTS, service)),
            answers: Arc::new(MessageQueue::with_notify(4, interpreter.clone())),
            journaled: Arc::new(MessageQueue::with_notify(JOURNAL_ACKS, interpreter)),
        }
    }
}

impl Default for StoreLinks {
    fn default() -> Self {
        StoreLinks::new()
    }
}
