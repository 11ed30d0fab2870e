//! State shared by the controller's tasks: atomics only, so any task reads or writes it
//! without a lock, and the messages that flow between the tasks.

use std::sync::atomic::{AtomicBool, AtomicI64, AtomicU32, AtomicU64, AtomicU8, Ordering};

use wrc_motion::MotionState;
pub use wrc_protocol::State as RobotState;
use wrc_robot::{Joints, Pose, Posture, MAX_AXES};

/// Everything the tasks share, as atomics.
#[derive(Debug)]
pub struct Shared {
    state: AtomicU8,
    /// The robot has been homed since start-up.
    pub homed: AtomicBool,
    /// The source holding control ([`SourceId`] bits; 0 = nobody).
    pub owner: AtomicU32,
    /// Speed override for the next moves [%].
    pub speed_pct: AtomicU32,
    /// Code of the last error (0: none).
    pub error_code: AtomicU32,
    /// Bumped to request a controlled stop; the Pulse Generator stops from the period it
    /// has reached and the Velocity Generator drops its plan.
    pub stop_epoch: AtomicU32,
    /// The last stop epoch the Pulse Generator has brought to rest.
    pub stopped_epoch: AtomicU32,
    /// Commanded position: every pulse pushed to the board so far [pulse].
    pub commanded: [AtomicI64; MAX_AXES],
    /// Digital outputs the I/O Monitor applies, one word per board.
    pub outputs: [AtomicU32; 4],
    /// Digital inputs as last read by the I/O Monitor, one word per board.
    pub inputs: [AtomicU32; 4],
    /// Pulse batches in flight (ring + board FIFO) — 0 when the robot is at rest.
    pub in_flight: AtomicU32,
    /// Set with a stop request after RESET: the Pulse Generator takes the board's own
    /// position (the board may have stopped by itself or dropped entries of an alarmed axis).
    pub resync_from_board: AtomicBool,
    /// Observability [ns, CLOCK_MONOTONIC]: when the Pulse Generator pushed the first batch
    /// of the latest move.
    pub first_pulse_ns: AtomicU64,
    /// When the Ethernet or RS232C task read the latest STOP or ESTOP line.
    pub urgent_read_ns: AtomicU64,
    /// When the Pulse Generator pushed the first decelerating batch of the latest stop.
    pub decel_ns: AtomicU64,
    /// The I/O Monitor has read the inputs at least once (`inputs` are real).
    pub io_ready: AtomicBool,
    /// The wafer map has a wafer on the hand (set by the cell service).
    pub hand_wafer: AtomicBool,
}

impl Default for Shared {
    fn default() -> Self {
        Shared {
            state: AtomicU8::new(RobotState::Idle.to_u8()),
            owner: AtomicU32::new(0),
            speed_pct: AtomicU32::new(100),
            homed: AtomicBool::new(false),
            error_code: AtomicU32::new(0),
            stop_epoch: AtomicU32::new(0),
            stopped_epoch: AtomicU32::new(0),
            commanded: std::array::from_fn(|_| AtomicI64::new(0)),
            outputs: std::array::from_fn(|_| AtomicU32::new(0)),
            inputs: std::array::from_fn(|_| AtomicU32::new(0)),
            in_flight: AtomicU32::new(0),
            resync_from_board: AtomicBool::new(false),
            first_pulse_ns: AtomicU64::new(0),
            urgent_read_ns: AtomicU64::new(0),
            decel_ns: AtomicU64::new(0),
            io_ready: AtomicBool::new(false),
            hand_wafer: AtomicBool::new(false),
        }
    }
}

impl Shared {
    /// The current state.
    pub fn state(&self) -> RobotState {
        RobotState::from_u8(self.state.load(Ordering::Acquire)).unwrap_or(RobotState::Error)
    }

    /// Set the state.
    pub fn set_state(&self, state: RobotState) {
        self.state.store(state.to_u8(), Ordering::Release);
    }

    /// Request a controlled stop; returns the new stop epoch.
    pub fn request_stop(&self) -> u32 {
        self.stop_epoch
            .fetch_add(1, Ordering::AcqRel)
            .wrapping_add(1)
    }

    /// Now on the clock of the timestamps above [ns] (a vDSO read, no system call).
    pub fn now_ns() -> u64 {
        use wrc_rt::Clock;
        wrc_rt::MonotonicClock.now_ns()
    }

    /// The commanded position [pulse].
    pub fn commanded_pulses(&self) -> [i64; MAX_AXES] {
        std::array::from_fn(|i| self.commanded[i].load(Ordering::Acquire))
    }
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

/// Longest reply line [bytes], newline included.
pub const LINE_MAX: usize = 512;

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
