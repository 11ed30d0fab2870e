//! Request parsing: one line (from [`LineReader`](crate::LineReader)) into a typed
//! [`Request`], or a [`Rejected`] that says which code to `NAK` with and why. Pure and
//! allocation-free; any bytes are accepted without panicking.

use core::fmt;
use core::str::FromStr;

use wrc_cell::Blade;
use wrc_robot::{AxisName, Pose, Posture, Robot, MAX_AXES};

use crate::code::Code;
use crate::reply::{ReplyBuf, ReplyTo};
use crate::verb::Verb;

/// Most digits in a request id.
pub const MAX_ID_DIGITS: usize = 8;

/// Number of digital outputs `OUT` can address (0 to 31, the bits of the output word).
pub const OUTPUT_COUNT: u8 = 32;

/// Most arguments any verb takes (`POINT <program> <name> JOINTS` and a value per axis on a
/// 16-axis robot).
const MAX_ARGS: usize = MAX_AXES + 3;

/// Most names one `VARS` request asks for.
pub const MAX_VAR_NAMES: usize = 4;

/// One parsed request line.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Request {
    /// The client's id (0 to 99999999), echoed in every reply to this request.
    pub id: Option<u32>,
    /// What to do.
    pub command: Command,
    /// The request carried a valid `*HH` checksum, so its replies must carry one.
    pub checksum: bool,
}

impl Request {
    /// Where replies to this request go: its id and whether they carry a checksum. Keep it
    /// to send the `INF` / `ABS` of a motion later.
    pub fn reply_to(&self) -> ReplyTo {
        ReplyTo {
            id: self.id,
            checksum: self.checksum,
        }
    }
}

/// A command with its checked arguments. Positions are in axis units ([deg] for rotary,
/// [mm] for linear axes); poses in [mm] and [deg].
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Command {
    /// `STATUS`.
    Status,
    /// `WHERE`.
    Where,
    /// `HOME`.
    Home,
    /// `MOVJ <j1> … <jn>`: joint PTP move.
    MovJ {
        /// Target of every axis in axis units; entries from `count` on are zero.
        joints: [f64; MAX_AXES],
        /// Number of values given, always the robot's axis count.
        count: usize,
    },
    /// `MOVP <x> <y> <z> <yaw> [L|R]`: PTP move to a Cartesian pose.
    MovP {
        /// Target pose of the tool centre point [mm, deg].
        pose: Pose,
        /// Arm configuration; `None` keeps the current one.
        posture: Option<Posture>,
    },
    /// `MOVL <x> <y> <z> <yaw>`: straight-line move.
    MovL {
        /// Target pose of the tool centre point [mm, deg].
        pose: Pose,
    },
    /// `JOG <axis> <pulses>`: relative move of one axis.
    Jog {
        /// Which axis.
        axis: AxisArg,
        /// Distance [pulse], signed.
        pulses: i64,
    },
    /// `SPEED <1-100>`: speed override [%], checked to be within 1 to 100.
    Speed(f64),
    /// `STOP`.
    Stop,
    /// `ESTOP`.
    Estop,
    /// `HOLD`: brake on the path, keep the motion.
    Hold,
    /// `RESUME`: continue the held motion.
    Resume,
    /// `RESET`.
    Reset,
    /// `IO`.
    Io,
    /// `OUT <n> 0|1 [FORCE]`.
    Out {
        /// Output number, 0 to 31 (bit `n` of the output word).
        n: u8,
        /// Switch it on (`1`) or off (`0`).
        on: bool,
        /// `FORCE`: switch a guarded output even while a blade holds a wafer (the
        /// controller refuses it with 141 otherwise), and say so to everyone.
        force: bool,
    },
    /// `WAIT`.
    Wait,
    /// `CONTROL`.
    Control,
    /// `RELEASE`.
    Release,
    /// `HELP`.
    Help,
    /// `SUBSCRIBE`.
    Subscribe,
    /// `UNSUBSCRIBE`.
    Unsubscribe,
    /// `UPLOAD <name>`: the program's lines follow, up to a line `.`.
    Upload(ProgramName),
    /// `PROGRAMS`.
    Programs,
    /// `ROBOT`.
    Robot,
    /// `TASKS`.
    Tasks,
    /// `STN`.
    Stn,
    /// `TEACH <station>`.
    Teach(StationName),
    /// `WAFERS`.
    Wafers,
    /// `GET <station> <slot> [A|B]`: take the wafer in the slot onto the hand (blade A when
    /// none is named).
    Get {
        /// The station.
        station: StationName,
        /// The slot, from 1.
        slot: u16,
        /// The blade.
        blade: Blade,
    },
    /// `PUT <station> <slot> [A|B]`: put the blade's wafer into the slot.
    Put {
        /// The station.
        station: StationName,
        /// The slot, from 1.
        slot: u16,
        /// The blade.
        blade: Blade,
    },
    /// `SWAP <station> <slot>`: a dual-blade robot takes the slot's wafer with its empty
    /// blade and puts the other blade's wafer into the slot, without leaving the station.
    Swap {
        /// The station.
        station: StationName,
        /// The slot, from 1.
        slot: u16,
    },
    /// `MAP <station>`: scan the station's slots with the mapping sensor.
    Map(StationName),
    /// `RUN <name> [STEP]`.
    Run {
        /// The program.
        name: ProgramName,
        /// `STEP`: start paused before the first statement.
        step: bool,
    },
    /// `PAUSE`.
    Pause,
    /// `CONTINUE [<answer>]`: the answer to a `WAIT OPERATOR` (a word of 1-32 letters,
    /// digits, `_` or `-`).
    Continue(Option<ProgramName>),
    /// `ABORT`.
    Abort,
    /// `DELETE <name>`.
    Delete(ProgramName),
    /// `TRACE SAVE [<name>]`: the trace file's name (a program-like name), or a name made
    /// from the time.
    TraceSave(Option<ProgramName>),
    /// `AUTH <token>`: the control token, answered by the connection itself.
    Auth(AuthToken),
    /// `BREAK …`: the running program's breakpoints.
    Break(BreakArg),
    /// `STEP [INTO|OVER|OUT]`.
    Step(StepKind),
    /// `VARS [<name> …]`: all the variables in scope (none named), or these.
    Vars(VarNames),
    /// `POINTS <program>`.
    Points(ProgramName),
    /// `POINT <program> <name> …`.
    Point {
        /// The stored program whose points file it is.
        program: ProgramName,
        /// The point (a name of the language: letters, digits, `_`).
        point: ProgramName,
        /// What to do with it.
        action: PointAction,
    },
    /// `RECOVERY`.
    Recovery,
    /// `RETRACT`.
    Retract,
    /// `SENSE [A|B]`: blade A when none is named.
    Sense(Blade),
    /// `CONFIRM …`: an operator's word on an uncertain place.
    Confirm(ConfirmArg),
}

/// A place `CONFIRM` names: a blade or a station slot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Place {
    /// `HAND [A|B]`.
    Hand(Blade),
    /// `<station> <slot>`.
    Slot {
        /// The station.
        station: StationName,
        /// The slot, from 1.
        slot: u16,
    },
}

/// What `CONFIRM` says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConfirmArg {
    /// `<wafer> <place>`: the wafer (its number, `W3` → 3) is there.
    At {
        /// The wafer's number.
        wafer: u32,
        /// Where it is.
        place: Place,
    },
    /// `<wafer> GONE`: the wafer is no longer in the cell.
    Gone {
        /// The wafer's number.
        wafer: u32,
    },
    /// `<place> EMPTY`: the place holds no wafer.
    Empty(Place),
}

/// A line of the running program's source: of the program itself (`file` `None`), or of
/// one of its libraries or called programs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SourceLine {
    /// The library or called program, by name; `None`: the program itself.
    pub file: Option<ProgramName>,
    /// Line [1-based].
    pub line: u32,
}

/// What `BREAK` does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BreakArg {
    /// `BREAK`: list the breakpoints.
    List,
    /// `BREAK [<file>:]<line>`: stop before the statement on that line (or the next line
    /// with one).
    Set(SourceLine),
    /// `BREAK CLEAR`: every breakpoint; `BREAK CLEAR [<file>:]<line>`: that one.
    Clear(Option<SourceLine>),
}

/// How far `STEP` goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepKind {
    /// `STEP` or `STEP INTO`: the next statement, into a called SUB too.
    Into,
    /// `STEP OVER`: the next statement of this SUB (a CALL runs whole).
    Over,
    /// `STEP OUT`: until the running SUB or FUNCTION has returned.
    Out,
}

/// A name `VARS` asks for: a variable, or an element (`A[3]`): letters, digits, `_`, `$`,
/// `[`, `]` and `,`, at most [`VarName::MAX_LEN`] characters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VarName {
    bytes: [u8; VarName::MAX_LEN],
    len: u8,
}

impl VarName {
    /// Most characters.
    pub const MAX_LEN: usize = 40;

    /// `text` as a name `VARS` takes.
    pub fn new(text: &str) -> Option<VarName> {
        let ok = !text.is_empty()
            && text.len() <= Self::MAX_LEN
            && text
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b"_$[],".contains(&b));
        if !ok {
            return None;
        }
        let mut bytes = [0u8; Self::MAX_LEN];
        bytes[..text.len()].copy_from_slice(text.as_bytes());
        Some(VarName {
            bytes,
            len: text.len() as u8,
        })
    }

    /// The name as written.
    pub fn as_str(&self) -> &str {
        core::str::from_utf8(&self.bytes[..usize::from(self.len)]).unwrap_or("")
    }
}

/// The names of a `VARS` request (none: every variable in scope).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VarNames {
    names: [Option<VarName>; MAX_VAR_NAMES],
}

impl VarNames {
    /// The names asked for, in order.
    pub fn iter(&self) -> impl Iterator<Item = &VarName> {
        self.names.iter().flatten()
    }

    /// No names: every variable.
    pub fn is_empty(&self) -> bool {
        self.names[0].is_none()
    }
}

/// What `POINT` does with a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PointAction {
    /// `<x> <y> <z> <yaw>`: store this pose [mm, deg].
    Pose(Pose),
    /// `JOINTS <j1> … <jn>`: store these joint positions, one per axis.
    Joints([f64; MAX_AXES]),
    /// `HERE`: store where the robot is (as a pose, or as joints for a point of joints).
    Here,
    /// `DELETE`: remove it.
    Delete,
}

impl Command {
    /// The command's verb.
    pub fn verb(&self) -> Verb {
        match self {
            Command::Status => Verb::Status,
            Command::Where => Verb::Where,
            Command::Home => Verb::Home,
            Command::MovJ { .. } => Verb::MovJ,
            Command::MovP { .. } => Verb::MovP,
            Command::MovL { .. } => Verb::MovL,
            Command::Jog { .. } => Verb::Jog,
            Command::Speed(_) => Verb::Speed,
            Command::Stop => Verb::Stop,
            Command::Estop => Verb::Estop,
            Command::Hold => Verb::Hold,
            Command::Resume => Verb::Resume,
            Command::Reset => Verb::Reset,
            Command::Io => Verb::Io,
            Command::Out { .. } => Verb::Out,
            Command::Wait => Verb::Wait,
            Command::Control => Verb::Control,
            Command::Release => Verb::Release,
            Command::Help => Verb::Help,
            Command::Subscribe => Verb::Subscribe,
            Command::Unsubscribe => Verb::Unsubscribe,
            Command::Upload(_) => Verb::Upload,
            Command::Programs => Verb::Programs,
            Command::Robot => Verb::Robot,
            Command::Tasks => Verb::Tasks,
            Command::TraceSave(_) => Verb::Trace,
            Command::Stn => Verb::Stn,
            Command::Teach(_) => Verb::Teach,
            Command::Wafers => Verb::Wafers,
            Command::Get { .. } => Verb::Get,
            Command::Put { .. } => Verb::Put,
            Command::Swap { .. } => Verb::Swap,
            Command::Map(_) => Verb::Map,
            Command::Run { .. } => Verb::Run,
            Command::Pause => Verb::Pause,
            Command::Continue(_) => Verb::Continue,
            Command::Abort => Verb::Abort,
            Command::Delete(_) => Verb::Delete,
            Command::Auth(_) => Verb::Auth,
            Command::Break(_) => Verb::Break,
            Command::Step(_) => Verb::Step,
            Command::Vars(_) => Verb::Vars,
            Command::Points(_) => Verb::Points,
            Command::Point { .. } => Verb::Point,
            Command::Recovery => Verb::Recovery,
            Command::Retract => Verb::Retract,
            Command::Sense(_) => Verb::Sense,
            Command::Confirm(_) => Verb::Confirm,
        }
    }
}

/// A stored program's name: 1 to 32 ASCII letters, digits, `_` or `-` (so also a safe file
/// name), kept inline so requests never allocate.
pub type ProgramName = wrc_robot::InlineName<32>;

/// The control token of `AUTH`: 16 to 64 ASCII letters, digits, `_` or `-`, kept inline so
/// requests never allocate. Its `Debug` form does not show it.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct AuthToken(wrc_robot::InlineName<64>);

impl AuthToken {
    /// Fewest characters in a token.
    pub const MIN_LEN: usize = 16;

    /// `text` as a token, if it is 16 to 64 letters, digits, `_` or `-`.
    pub fn new(text: &str) -> Option<AuthToken> {
        if text.len() < Self::MIN_LEN {
            return None;
        }
        wrc_robot::InlineName::new(text).map(AuthToken)
    }

    /// The token's text.
    pub fn as_str(&self) -> &str {
        self.0.as_str()
    }

    /// Whether it equals `other`, in a time that depends on the lengths only (a wrong
    /// guess does not say how many leading characters were right).
    pub fn matches(&self, other: &AuthToken) -> bool {
        let (a, b) = (self.as_str().as_bytes(), other.as_str().as_bytes());
        let mut diff = u8::from(a.len() != b.len());
        for (x, y) in a.iter().zip(b) {
            diff |= x ^ y;
        }
        diff == 0
    }
}

impl fmt::Debug for AuthToken {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("AuthToken(..)")
    }
}

/// A station's name: 1-16 letters, digits, `_` or `-`, stored inline (no allocation).
pub type StationName = wrc_robot::InlineName<16>;

/// The axis argument of `JOG`: a 1-based axis number or an axis name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisArg {
    /// Axis number as written, 1 = first axis; checked against the axis count.
    Number(u8),
    /// Axis name (1-15 ASCII letters, digits, `_`, `-`), not yet checked against the robot.
    Name(AxisName),
}

impl AxisArg {
    /// The 0-based index of the axis in `robot` (names compared ignoring case), or `None`
    /// when there is no such axis (reply [`Code::AxisUnknown`]).
    pub fn resolve(&self, robot: &Robot) -> Option<usize> {
        match self {
            AxisArg::Number(n) => {
                let i = usize::from(*n).checked_sub(1)?;
                (i < robot.axis_count()).then_some(i)
            }
            AxisArg::Name(name) => robot.axis_index(name.as_str()),
        }
    }
}

impl fmt::Display for AxisArg {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AxisArg::Number(n) => write!(f, "{n}"),
            AxisArg::Name(name) => f.write_str(name.as_str()),
        }
    }
}

/// A word from a request, kept inline (at most 24 bytes, longer ones cut with `...`) so
/// that errors quoting it never allocate. Only printable ASCII is stored.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Token {
    bytes: [u8; Token::MAX_LEN],
    len: u8,
    truncated: bool,
}

impl Token {
    /// Most bytes kept.
    pub const MAX_LEN: usize = 24;

    /// Keep up to [`Token::MAX_LEN`] bytes of `word`; bytes that are not printable ASCII
    /// become `?`.
    pub fn new(word: &[u8]) -> Token {
        let mut bytes = [0u8; Token::MAX_LEN];
        let len = word.len().min(Token::MAX_LEN);
        for (dst, &src) in bytes.iter_mut().zip(&word[..len]) {
            *dst = if src.is_ascii_graphic() || src == b' ' {
                src
            } else {
                b'?'
            };
        }
        Token {
            bytes,
            len: len as u8,
            truncated: word.len() > Token::MAX_LEN,
        }
    }

    /// The kept bytes (without the `...` of a cut word).
    pub fn as_str(&self) -> &str {
        // Only printable ASCII is stored, so this never fails.
        core::str::from_utf8(&self.bytes[..usize::from(self.len)]).unwrap_or("?")
    }
}

impl fmt::Display for Token {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())?;
        if self.truncated {
            f.write_str("...")?;
        }
        Ok(())
    }
}

impl fmt::Debug for Token {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "\"{self}\"")
    }
}

/// How many arguments a verb takes, for [`ArgumentCount`] messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arity {
    /// Exactly this many.
    Exactly(usize),
    /// From `.0` to `.1`.
    Between(usize, usize),
    /// One joint value per axis (`MOVJ`); the robot's axis count.
    PerAxis(usize),
}

/// Wrong number of arguments: which verb, what it takes and what it got.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArgumentCount {
    /// The verb.
    pub verb: Verb,
    /// What it takes.
    pub expected: Arity,
    /// How many arguments the request had.
    pub got: usize,
}

impl fmt::Display for ArgumentCount {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (verb, got, args) = (self.verb, self.got, self.verb.spec().args);
        match self.expected {
            Arity::Exactly(0) => write!(f, "{verb} takes no arguments, got {got}"),
            Arity::Exactly(1) => write!(f, "{verb} needs 1 argument ({args}), got {got}"),
            Arity::Exactly(n) => write!(f, "{verb} needs {n} arguments ({args}), got {got}"),
            Arity::Between(a, b) => {
                write!(f, "{verb} needs {a} or {b} arguments ({args}), got {got}")
            }
            Arity::PerAxis(n) => {
                write!(f, "{verb} needs {n} joint values (one per axis), got {got}")
            }
        }
    }
}

/// Why a request line was refused. Each maps to a [`Code`] ([`ParseError::code`]); the
/// message is the `NAK` text.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ParseError {
    /// The line has an id but no verb.
    #[error("no verb after the id; HELP lists the verbs")]
    NoVerb,
    /// A byte that is not printable ASCII (or a tab).
    #[error("byte 0x{byte:02X} at column {column} is not printable ASCII")]
    NotAscii {
        /// The byte.
        byte: u8,
        /// Its position in the line, 1-based.
        column: usize,
    },
    /// A leading number that is not a valid id.
    #[error("id {0} has more than 8 digits")]
    BadId(Token),
    /// The verb is not known.
    #[error("unknown verb {0}; HELP lists the verbs")]
    UnknownVerb(Token),
    /// Too many or too few arguments.
    #[error("{0}")]
    ArgumentCount(ArgumentCount),
    /// An argument that should be a number is not one.
    #[error("\"{0}\" is not a number")]
    NotANumber(Token),
    /// A number that is infinite or NaN (`1e999`, `inf`, `nan`).
    #[error("\"{0}\" is not a finite number")]
    NotFinite(Token),
    /// A number that must be whole (pulses, output number) is not written as one.
    #[error("\"{0}\" is not a whole number; write digits only, e.g. 1000")]
    NotWhole(Token),
    /// A whole number too large for its field.
    #[error("\"{0}\" is out of range")]
    TooLarge(Token),
    /// `SPEED` outside 1 to 100 [%].
    #[error("speed {0} is out of range; SPEED takes 1 to 100 [%]")]
    SpeedOutOfRange(f64),
    /// An axis number outside 1 to the axis count.
    #[error("axis {number} does not exist; this robot has axes 1 to {axis_count}")]
    AxisUnknown {
        /// The number given.
        number: i64,
        /// The robot's axis count.
        axis_count: usize,
    },
    /// An axis argument that is neither a number nor a valid name.
    #[error("axis \"{0}\" is neither an axis number nor a name (1-15 letters, digits, _ or -)")]
    BadAxisName(Token),
    /// A program name with characters other than letters, digits, `_` and `-`, or too long.
    #[error("program name \"{0}\" must be 1-32 letters, digits, _ or -")]
    BadProgramName(Token),
    /// `TRACE` with an action other than `SAVE`.
    #[error("TRACE knows one action, SAVE (TRACE SAVE [<name>]), not \"{0}\"")]
    TraceAction(Token),
    /// A trace name with characters other than letters, digits, `_` and `-`, or too long.
    #[error(
        "trace name \"{0}\" must be 1-32 letters, digits, _ or - (it is saved as <name>.wrctrace)"
    )]
    BadTraceName(Token),
    /// A station name with characters other than letters, digits, `_` and `-`, or too long.
    #[error("station name \"{0}\" must be 1-16 letters, digits, _ or -")]
    BadStationName(Token),
    /// A slot number below 1 or beyond any station.
    #[error("slot {0} does not exist; slots are numbered from 1")]
    SlotNumber(i64),
    /// A blade word other than `A` or `B`.
    #[error("blade \"{0}\" must be A or B")]
    BadBlade(Token),
    /// A posture word other than `L` or `R`.
    #[error("posture \"{0}\" must be L or R")]
    BadPosture(Token),
    /// An output state other than `0` or `1`.
    #[error("output state \"{0}\" must be 0 or 1")]
    BadSwitch(Token),
    /// An `OUT` option other than `FORCE`.
    #[error("OUT takes FORCE after the state (OUT <n> 0|1 FORCE), not \"{0}\"")]
    BadOutOption(Token),
    /// An output number outside 0 to 31.
    #[error("output {0} does not exist; outputs are 0 to 31")]
    OutputUnknown(i64),
    /// The text after `*` is not two hex digits.
    #[error("checksum \"{0}\" must be two hex digits")]
    ChecksumFormat(Token),
    /// The checksum does not match the bytes before `*`.
    #[error("checksum {got:02X} does not match the request (expected {expected:02X})")]
    ChecksumMismatch {
        /// The checksum the request carried.
        got: u8,
        /// XOR of the bytes before `*`.
        expected: u8,
    },
    /// A checksum on a connection that does not take them.
    #[error("checksums are accepted on the serial port only")]
    ChecksumNotAccepted,
    /// An `AUTH` token that is not 16-64 letters, digits, `_` or `-` (not echoed).
    #[error("a token is 16-64 letters, digits, _ or -")]
    BadToken,
    /// A BREAK line that is not `<line>` or `<file>:<line>`.
    #[error("\"{0}\" is not a source line: write <line> or <file>:<line> (a line from 1)")]
    BadLine(Token),
    /// A STEP that is not INTO, OVER or OUT.
    #[error("STEP goes INTO, OVER or OUT, not \"{0}\"")]
    BadStep(Token),
    /// A VARS or POINT name that cannot be a variable's.
    #[error("\"{0}\" is not a variable name (letters, digits, _, $, or an element like A[3])")]
    BadVarName(Token),
    /// A RUN option other than STEP.
    #[error("RUN takes STEP after the name (RUN <name> STEP), not \"{0}\"")]
    BadRunOption(Token),
    /// A CONTINUE answer that is not a word.
    #[error("the answer \"{0}\" must be 1-32 letters, digits, _ or -")]
    BadAnswer(Token),
    /// A POINT whose action is none of the four.
    #[error("POINT {0}: give <x> <y> <z> <yaw>, JOINTS and one value per axis, HERE or DELETE")]
    BadPointAction(Token),
    /// A CONFIRM that is none of its five forms.
    #[error("CONFIRM {0}: give <wafer> <station> <slot>, <wafer> HAND [A|B], <wafer> GONE, HAND [A|B] EMPTY or <station> <slot> EMPTY")]
    BadConfirm(Token),
}

impl ParseError {
    /// The code to `NAK` with.
    pub fn code(&self) -> Code {
        match self {
            ParseError::NoVerb | ParseError::NotAscii { .. } | ParseError::BadId(_) => {
                Code::Malformed
            }
            ParseError::UnknownVerb(_) => Code::UnknownVerb,
            ParseError::ArgumentCount(_) => Code::ArgumentCount,
            ParseError::NotANumber(_)
            | ParseError::NotFinite(_)
            | ParseError::NotWhole(_)
            | ParseError::TooLarge(_) => Code::BadNumber,
            ParseError::SpeedOutOfRange(_) => Code::SpeedOutOfRange,
            ParseError::AxisUnknown { .. } => Code::AxisUnknown,
            ParseError::BadAxisName(_)
            | ParseError::BadPosture(_)
            | ParseError::BadBlade(_)
            | ParseError::BadSwitch(_)
            | ParseError::BadOutOption(_)
            | ParseError::BadProgramName(_)
            | ParseError::BadTraceName(_)
            | ParseError::TraceAction(_)
            | ParseError::BadStationName(_)
            | ParseError::BadToken
            | ParseError::BadLine(_)
            | ParseError::BadStep(_)
            | ParseError::BadVarName(_)
            | ParseError::BadRunOption(_)
            | ParseError::BadAnswer(_)
            | ParseError::BadPointAction(_)
            | ParseError::BadConfirm(_) => Code::BadArgument,
            ParseError::OutputUnknown(_) => Code::OutputUnknown,
            ParseError::SlotNumber(_) => Code::SlotUnknown,
            ParseError::ChecksumFormat(_) | ParseError::ChecksumMismatch { .. } => {
                Code::BadChecksum
            }
            ParseError::ChecksumNotAccepted => Code::NotAvailable,
        }
    }
}

/// A refused request: where the `NAK` goes and why.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("{error}")]
pub struct Rejected {
    /// The request's id when it could be read (also when the checksum was wrong).
    pub id: Option<u32>,
    /// The request carried a checksum suffix, so the `NAK` must carry one.
    pub checksum: bool,
    /// What was wrong.
    pub error: ParseError,
}

impl Rejected {
    /// The code to `NAK` with.
    pub fn code(&self) -> Code {
        self.error.code()
    }

    /// Where the `NAK` goes.
    pub fn reply_to(&self) -> ReplyTo {
        ReplyTo {
            id: self.id,
            checksum: self.checksum,
        }
    }
}

pub use crate::line::checksum;

impl ReplyBuf {
    /// The `NAK` for a request the parser refused: its id, code and message.
    pub fn rejected(&mut self, rejected: &Rejected) -> &[u8] {
        self.nak(rejected.reply_to(), rejected.code(), rejected)
    }
}

/// Parses request lines for one robot and one kind of connection.
///
/// ```
/// use wrc_protocol::{Command, Parser};
///
/// let parser = Parser::new(4);
/// let request = parser.parse(b"7 movj 10 20 0 5").unwrap();
/// assert_eq!(request.id, Some(7));
/// assert!(matches!(request.command, Command::MovJ { count: 4, .. }));
///
/// let refused = parser.parse(b"8 MOVJ 10 20 0").unwrap_err();
/// assert_eq!(refused.id, Some(8));
/// assert_eq!(refused.code().number(), 101);
/// assert_eq!(refused.to_string(), "MOVJ needs 4 joint values (one per axis), got 3");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Parser {
    axis_count: usize,
    accept_checksum: bool,
}

impl Parser {
    /// A parser for a robot with `axis_count` axes (clamped to 1 to
    /// [`MAX_AXES`]) that refuses `*HH` checksums (TCP, Unix socket).
    pub fn new(axis_count: usize) -> Parser {
        Parser {
            axis_count: axis_count.clamp(1, MAX_AXES),
            accept_checksum: false,
        }
    }

    /// The same parser, accepting the optional `*HH` checksum (serial port) or not.
    pub fn with_checksum(self, accept: bool) -> Parser {
        Parser {
            accept_checksum: accept,
            ..self
        }
    }

    /// The axis count `MOVJ` values are checked against.
    pub fn axis_count(&self) -> usize {
        self.axis_count
    }

    /// Parse one line (without its LF or CR LF). Never panics, never allocates.
    pub fn parse(&self, line: &[u8]) -> Result<Request, Rejected> {
        let (payload, suffix) = match line.iter().position(|&b| b == b'*') {
            Some(star) => (&line[..star], Some(&line[star + 1..])),
            None => (line, None),
        };
        let checksum_present = suffix.is_some();
        let mut words = words(payload);
        let first = words.next();

        // The id is read before anything else so that every NAK can echo it.
        let mut id = None;
        let mut id_error = None;
        let mut verb_word = first;
        if let Some(word) = first.filter(|w| w.iter().all(u8::is_ascii_digit)) {
            verb_word = words.next();
            if word.len() <= MAX_ID_DIGITS {
                id = Some(word.iter().fold(0u32, |n, d| n * 10 + u32::from(d - b'0')));
            } else {
                id_error = Some(ParseError::BadId(Token::new(word)));
            }
        }
        let reject = |error| Rejected {
            id,
            checksum: checksum_present,
            error,
        };

        if let Some(suffix) = suffix {
            if !self.accept_checksum {
                // This connection does not do checksums, so neither does the NAK.
                return Err(Rejected {
                    checksum: false,
                    ..reject(ParseError::ChecksumNotAccepted)
                });
            }
            let digits = trim_end(suffix);
            let got = match digits {
                [h, l] => hex(*h).zip(hex(*l)).map(|(h, l)| h << 4 | l),
                _ => None,
            };
            let Some(got) = got else {
                return Err(reject(ParseError::ChecksumFormat(Token::new(digits))));
            };
            let expected = checksum(payload);
            if got != expected {
                return Err(reject(ParseError::ChecksumMismatch { got, expected }));
            }
        }
        if let Some((i, &byte)) = payload
            .iter()
            .enumerate()
            .find(|(_, &b)| !(b.is_ascii_graphic() || b == b' ' || b == b'\t'))
        {
            return Err(reject(ParseError::NotAscii {
                byte,
                column: i + 1,
            }));
        }
        if let Some(error) = id_error {
            return Err(reject(error));
        }
        let Some(verb_word) = verb_word else {
            return Err(reject(ParseError::NoVerb));
        };
        let Some(verb) = Verb::from_name(verb_word) else {
            return Err(reject(ParseError::UnknownVerb(Token::new(verb_word))));
        };

        let mut args: [&[u8]; MAX_ARGS] = [&[]; MAX_ARGS];
        let mut argc = 0;
        for word in words {
            if let Some(slot) = args.get_mut(argc) {
                *slot = word;
            }
            argc += 1;
        }
        let args = Args {
            verb,
            words: &args[..argc.min(MAX_ARGS)],
            count: argc,
        };
        match self.command(verb, &args) {
            Ok(command) => Ok(Request {
                id,
                command,
                checksum: checksum_present,
            }),
            Err(error) => Err(reject(error)),
        }
    }

    /// The command for `verb` with its arguments checked.
    fn command(&self, verb: Verb, args: &Args<'_>) -> Result<Command, ParseError> {
        let simple = |command| args.exactly(0).map(|_| command);
        match verb {
            Verb::Status => simple(Command::Status),
            Verb::Where => simple(Command::Where),
            Verb::Home => simple(Command::Home),
            Verb::MovJ => {
                if args.count != self.axis_count {
                    return Err(args.wrong(Arity::PerAxis(self.axis_count)));
                }
                let mut joints = [0.0; MAX_AXES];
                for (j, word) in joints.iter_mut().zip(args.words) {
                    *j = number(word)?;
                }
                Ok(Command::MovJ {
                    joints,
                    count: self.axis_count,
                })
            }
            Verb::MovP => {
                args.between(4, 5)?;
                let posture = match args.words.get(4) {
                    None => None,
                    Some(word) => Some(posture(word)?),
                };
                Ok(Command::MovP {
                    pose: pose(args.words)?,
                    posture,
                })
            }
            Verb::MovL => {
                args.exactly(4)?;
                Ok(Command::MovL {
                    pose: pose(args.words)?,
                })
            }
            Verb::Jog => {
                args.exactly(2)?;
                Ok(Command::Jog {
                    axis: self.axis(args.words[0])?,
                    pulses: whole(args.words[1])?,
                })
            }
            Verb::Speed => {
                args.exactly(1)?;
                let pct = number(args.words[0])?;
                if !(1.0..=100.0).contains(&pct) {
                    return Err(ParseError::SpeedOutOfRange(pct));
                }
                Ok(Command::Speed(pct))
            }
            Verb::Stop => simple(Command::Stop),
            Verb::Estop => simple(Command::Estop),
            Verb::Hold => simple(Command::Hold),
            Verb::Resume => simple(Command::Resume),
            Verb::Reset => simple(Command::Reset),
            Verb::Io => simple(Command::Io),
            Verb::Out => {
                args.between(2, 3)?;
                let n = whole(args.words[0])?;
                if !(0..i64::from(OUTPUT_COUNT)).contains(&n) {
                    return Err(ParseError::OutputUnknown(n));
                }
                let on = match args.words[1] {
                    b"0" => false,
                    b"1" => true,
                    other => return Err(ParseError::BadSwitch(Token::new(other))),
                };
                let force = match args.words[..args.count] {
                    [_, _, word] if word.eq_ignore_ascii_case(b"FORCE") => true,
                    [_, _, word] => return Err(ParseError::BadOutOption(Token::new(word))),
                    _ => false,
                };
                Ok(Command::Out {
                    n: n as u8,
                    on,
                    force,
                })
            }
            Verb::Wait => simple(Command::Wait),
            Verb::Control => simple(Command::Control),
            Verb::Release => simple(Command::Release),
            Verb::Help => simple(Command::Help),
            Verb::Subscribe => simple(Command::Subscribe),
            Verb::Unsubscribe => simple(Command::Unsubscribe),
            Verb::Upload => program_name(args).map(Command::Upload),
            Verb::Programs => simple(Command::Programs),
            Verb::Robot => simple(Command::Robot),
            Verb::Tasks => simple(Command::Tasks),
            Verb::Trace => {
                args.between(1, 2)?;
                if !args.words[0].eq_ignore_ascii_case(b"SAVE") {
                    return Err(ParseError::TraceAction(Token::new(args.words[0])));
                }
                match args.words.get(1) {
                    None => Ok(Command::TraceSave(None)),
                    Some(word) => ProgramName::new(as_str(word))
                        .map(|n| Command::TraceSave(Some(n)))
                        .ok_or_else(|| ParseError::BadTraceName(Token::new(word))),
                }
            }
            Verb::Auth => {
                args.exactly(1)?;
                AuthToken::new(as_str(args.words[0]))
                    .map(Command::Auth)
                    .ok_or(ParseError::BadToken)
            }
            Verb::Stn => simple(Command::Stn),
            Verb::Teach => station_name(args).map(Command::Teach),
            Verb::Wafers => simple(Command::Wafers),
            Verb::Get => {
                let (station, slot, blade) = station_slot_blade(args)?;
                Ok(Command::Get {
                    station,
                    slot,
                    blade,
                })
            }
            Verb::Put => {
                let (station, slot, blade) = station_slot_blade(args)?;
                Ok(Command::Put {
                    station,
                    slot,
                    blade,
                })
            }
            Verb::Swap => {
                let (station, slot) = station_slot(args)?;
                Ok(Command::Swap { station, slot })
            }
            Verb::Map => station_name(args).map(Command::Map),
            Verb::Run => {
                args.between(1, 2)?;
                let name = ProgramName::new(as_str(args.words[0]))
                    .ok_or_else(|| ParseError::BadProgramName(Token::new(args.words[0])))?;
                let step = match args.words.get(1) {
                    None => false,
                    Some(w) if w.eq_ignore_ascii_case(b"STEP") => true,
                    Some(w) => return Err(ParseError::BadRunOption(Token::new(w))),
                };
                Ok(Command::Run { name, step })
            }
            Verb::Pause => simple(Command::Pause),
            Verb::Continue => {
                args.between(0, 1)?;
                match args.words.first() {
                    None => Ok(Command::Continue(None)),
                    Some(w) => ProgramName::new(as_str(w))
                        .map(|a| Command::Continue(Some(a)))
                        .ok_or_else(|| ParseError::BadAnswer(Token::new(w))),
                }
            }
            Verb::Abort => simple(Command::Abort),
            Verb::Delete => program_name(args).map(Command::Delete),
            Verb::Break => {
                args.between(0, 2)?;
                match args.words {
                    [] => Ok(Command::Break(BreakArg::List)),
                    [w] if w.eq_ignore_ascii_case(b"CLEAR") => {
                        Ok(Command::Break(BreakArg::Clear(None)))
                    }
                    [w, line] if w.eq_ignore_ascii_case(b"CLEAR") => {
                        Ok(Command::Break(BreakArg::Clear(Some(source_line(line)?))))
                    }
                    [line] => Ok(Command::Break(BreakArg::Set(source_line(line)?))),
                    [_, extra] => Err(ParseError::BadLine(Token::new(extra))),
                    _ => Err(args.wrong(Arity::Between(0, 2))),
                }
            }
            Verb::Step => {
                args.between(0, 1)?;
                let kind = match args.words.first() {
                    None => StepKind::Into,
                    Some(w) if w.eq_ignore_ascii_case(b"INTO") => StepKind::Into,
                    Some(w) if w.eq_ignore_ascii_case(b"OVER") => StepKind::Over,
                    Some(w) if w.eq_ignore_ascii_case(b"OUT") => StepKind::Out,
                    Some(w) => return Err(ParseError::BadStep(Token::new(w))),
                };
                Ok(Command::Step(kind))
            }
            Verb::Vars => {
                args.between(0, MAX_VAR_NAMES)?;
                let mut names = [None; MAX_VAR_NAMES];
                for (slot, w) in names.iter_mut().zip(args.words) {
                    *slot = Some(
                        VarName::new(as_str(w))
                            .ok_or_else(|| ParseError::BadVarName(Token::new(w)))?,
                    );
                }
                Ok(Command::Vars(VarNames { names }))
            }
            Verb::Points => program_name(args).map(Command::Points),
            Verb::Point => self.point(args),
            Verb::Recovery => simple(Command::Recovery),
            Verb::Retract => simple(Command::Retract),
            Verb::Sense => {
                args.between(0, 1)?;
                match args.words.first() {
                    None => Ok(Command::Sense(Blade::A)),
                    Some(w) => Blade::parse(as_str(w))
                        .map(Command::Sense)
                        .ok_or_else(|| ParseError::BadBlade(Token::new(w))),
                }
            }
            Verb::Confirm => confirm(args).map(Command::Confirm),
        }
    }

    /// `POINT <program> <name> <x> <y> <z> <yaw> | JOINTS <j1> … | HERE | DELETE`.
    fn point(&self, args: &Args<'_>) -> Result<Command, ParseError> {
        if args.count < 3 {
            return Err(args.wrong(Arity::Between(3, 6)));
        }
        let program = ProgramName::new(as_str(args.words[0]))
            .ok_or_else(|| ParseError::BadProgramName(Token::new(args.words[0])))?;
        let point = ProgramName::new(as_str(args.words[1]))
            .ok_or_else(|| ParseError::BadVarName(Token::new(args.words[1])))?;
        let rest = &args.words[2..];
        let bad = || ParseError::BadPointAction(Token::new(args.words[1]));
        let action = match rest {
            [w] if w.eq_ignore_ascii_case(b"HERE") => PointAction::Here,
            [w] if w.eq_ignore_ascii_case(b"DELETE") => PointAction::Delete,
            [w, values @ ..] if w.eq_ignore_ascii_case(b"JOINTS") => {
                if args.count - 3 != self.axis_count {
                    return Err(args.wrong(Arity::PerAxis(self.axis_count)));
                }
                let mut joints = [0.0; MAX_AXES];
                for (j, word) in joints.iter_mut().zip(values) {
                    *j = number(word)?;
                }
                PointAction::Joints(joints)
            }
            [_, _, _, _] => PointAction::Pose(pose(rest)?),
            _ => return Err(bad()),
        };
        Ok(Command::Point {
            program,
            point,
            action,
        })
    }

    /// An axis number (checked against the axis count) or an axis name.
    fn axis(&self, word: &[u8]) -> Result<AxisArg, ParseError> {
        if let Ok(number) = as_str(word).parse::<i64>() {
            return match u8::try_from(number) {
                Ok(n) if n >= 1 && usize::from(n) <= self.axis_count => Ok(AxisArg::Number(n)),
                _ => Err(ParseError::AxisUnknown {
                    number,
                    axis_count: self.axis_count,
                }),
            };
        }
        AxisName::new(as_str(word))
            .map(AxisArg::Name)
            .ok_or_else(|| ParseError::BadAxisName(Token::new(word)))
    }
}

/// The one argument of `UPLOAD`, `RUN` and `DELETE`.
fn station_name(args: &Args<'_>) -> Result<StationName, ParseError> {
    args.exactly(1)?;
    StationName::new(as_str(args.words[0]))
        .ok_or_else(|| ParseError::BadStationName(Token::new(args.words[0])))
}

/// The two arguments of `GET` and `PUT`: a station and a slot number from 1.
fn station_slot(args: &Args<'_>) -> Result<(StationName, u16), ParseError> {
    args.exactly(2)?;
    station_and_slot(args)
}

/// `<station> <slot> [A|B]`: blade A when none is named.
fn station_slot_blade(args: &Args<'_>) -> Result<(StationName, u16, Blade), ParseError> {
    args.between(2, 3)?;
    let (station, slot) = station_and_slot(args)?;
    let blade = match args.words.get(2) {
        None => Blade::A,
        Some(word) => {
            Blade::parse(as_str(word)).ok_or_else(|| ParseError::BadBlade(Token::new(word)))?
        }
    };
    Ok((station, slot, blade))
}

fn station_and_slot(args: &Args<'_>) -> Result<(StationName, u16), ParseError> {
    let station = StationName::new(as_str(args.words[0]))
        .ok_or_else(|| ParseError::BadStationName(Token::new(args.words[0])))?;
    let slot = whole(args.words[1])?;
    match u16::try_from(slot) {
        Ok(n) if n >= 1 => Ok((station, n)),
        _ => Err(ParseError::SlotNumber(slot)),
    }
}

/// `CONFIRM`'s five forms (see [`ConfirmArg`]).
fn confirm(args: &Args<'_>) -> Result<ConfirmArg, ParseError> {
    args.between(2, 3)?;
    let w = args.words;
    let bad = || ParseError::BadConfirm(Token::new(w[0]));
    let is = |word: &[u8], what: &[u8]| word.eq_ignore_ascii_case(what);
    let wafer = |word: &[u8]| -> Option<u32> {
        let text = as_str(word);
        let digits = text.strip_prefix(['W', 'w'])?;
        if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        digits.parse().ok()
    };
    let blade = |word: Option<&&[u8]>| -> Result<Blade, ParseError> {
        match word {
            None => Ok(Blade::A),
            Some(b) => Blade::parse(as_str(b)).ok_or_else(|| ParseError::BadBlade(Token::new(b))),
        }
    };
    let slot = |station: &[u8], slot: &[u8]| -> Result<Place, ParseError> {
        let station = StationName::new(as_str(station))
            .ok_or_else(|| ParseError::BadStationName(Token::new(station)))?;
        let n = whole(slot)?;
        match u16::try_from(n) {
            Ok(slot) if slot >= 1 => Ok(Place::Slot { station, slot }),
            _ => Err(ParseError::SlotNumber(n)),
        }
    };
    match (wafer(w[0]), w) {
        (Some(n), [_, g]) if is(g, b"GONE") => Ok(ConfirmArg::Gone { wafer: n }),
        (Some(n), [_, h, rest @ ..]) if is(h, b"HAND") && rest.len() <= 1 => Ok(ConfirmArg::At {
            wafer: n,
            place: Place::Hand(blade(rest.first())?),
        }),
        (Some(n), [_, station, s]) if !is(station, b"GONE") => Ok(ConfirmArg::At {
            wafer: n,
            place: slot(station, s)?,
        }),
        (None, [h, e]) if is(h, b"HAND") && is(e, b"EMPTY") => {
            Ok(ConfirmArg::Empty(Place::Hand(Blade::A)))
        }
        (None, [h, b, e]) if is(h, b"HAND") && is(e, b"EMPTY") => {
            Ok(ConfirmArg::Empty(Place::Hand(blade(Some(b))?)))
        }
        (None, [station, s, e]) if is(e, b"EMPTY") => Ok(ConfirmArg::Empty(slot(station, s)?)),
        _ => Err(bad()),
    }
}

/// `<line>` or `<file>:<line>`.
fn source_line(word: &[u8]) -> Result<SourceLine, ParseError> {
    let text = as_str(word);
    let (file, line) = match text.rsplit_once(':') {
        Some((f, l)) => (
            Some(ProgramName::new(f).ok_or(ParseError::BadLine(Token::new(word)))?),
            l,
        ),
        None => (None, text),
    };
    match line.parse::<u32>() {
        Ok(n) if n >= 1 && line.bytes().all(|b| b.is_ascii_digit()) => {
            Ok(SourceLine { file, line: n })
        }
        _ => Err(ParseError::BadLine(Token::new(word))),
    }
}

fn program_name(args: &Args<'_>) -> Result<ProgramName, ParseError> {
    args.exactly(1)?;
    ProgramName::new(as_str(args.words[0]))
        .ok_or_else(|| ParseError::BadProgramName(Token::new(args.words[0])))
}

/// The arguments after the verb.
struct Args<'a> {
    verb: Verb,
    /// The first [`MAX_ARGS`] arguments.
    words: &'a [&'a [u8]],
    /// How many arguments there were in all.
    count: usize,
}

impl Args<'_> {
    fn wrong(&self, expected: Arity) -> ParseError {
        ParseError::ArgumentCount(ArgumentCount {
            verb: self.verb,
            expected,
            got: self.count,
        })
    }

    fn exactly(&self, n: usize) -> Result<(), ParseError> {
        if self.count == n {
            Ok(())
        } else {
            Err(self.wrong(Arity::Exactly(n)))
        }
    }

    fn between(&self, min: usize, max: usize) -> Result<(), ParseError> {
        if (min..=max).contains(&self.count) {
            Ok(())
        } else {
            Err(self.wrong(Arity::Between(min, max)))
        }
    }
}

/// The whitespace-separated words of `line` (spaces and tabs; runs count as one).
fn words(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|&b| b == b' ' || b == b'\t')
        .filter(|w| !w.is_empty())
}

fn trim_end(mut bytes: &[u8]) -> &[u8] {
    while let [rest @ .., b' ' | b'\t'] = bytes {
        bytes = rest;
    }
    bytes
}

fn hex(digit: u8) -> Option<u8> {
    (digit as char).to_digit(16).map(|d| d as u8)
}

/// `word` as text; words reaching here are printable ASCII, anything else reads as "".
fn as_str(word: &[u8]) -> &str {
    core::str::from_utf8(word).unwrap_or("")
}

/// A finite decimal number.
fn number(word: &[u8]) -> Result<f64, ParseError> {
    match f64::from_str(as_str(word)) {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(ParseError::NotFinite(Token::new(word))),
        Err(_) => Err(ParseError::NotANumber(Token::new(word))),
    }
}

/// A whole number written as optional sign and digits.
fn whole(word: &[u8]) -> Result<i64, ParseError> {
    let digits = match word {
        [b'+' | b'-', rest @ ..] => rest,
        _ => word,
    };
    if digits.is_empty() || !digits.iter().all(u8::is_ascii_digit) {
        return Err(match number(word) {
            Ok(_) => ParseError::NotWhole(Token::new(word)),
            Err(e) => e,
        });
    }
    i64::from_str(as_str(word)).map_err(|_| ParseError::TooLarge(Token::new(word)))
}

fn pose(words: &[&[u8]]) -> Result<Pose, ParseError> {
    Ok(Pose {
        x: number(words[0])?,
        y: number(words[1])?,
        z: number(words[2])?,
        yaw: number(words[3])?,
    })
}

fn posture(word: &[u8]) -> Result<Posture, ParseError> {
    if word.eq_ignore_ascii_case(b"L") || word.eq_ignore_ascii_case(b"LEFT") {
        Ok(Posture::Left)
    } else if word.eq_ignore_ascii_case(b"R") || word.eq_ignore_ascii_case(b"RIGHT") {
        Ok(Posture::Right)
    } else {
        Err(ParseError::BadPosture(Token::new(word)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn p4() -> Parser {
        Parser::new(4)
    }

    fn ok(line: &str) -> Request {
        p4().with_checksum(true)
            .parse(line.as_bytes())
            .unwrap_or_else(|e| panic!("{line:?}: {e}"))
    }

    fn err(line: &str) -> Rejected {
        match p4().with_checksum(true).parse(line.as_bytes()) {
            Ok(r) => panic!("{line:?} parsed as {r:?}"),
            Err(e) => e,
        }
    }

    fn with_sum(line: &str) -> String {
        format!("{line}*{:02X}", checksum(line.as_bytes()))
    }

    #[test]
    fn get_and_put_take_an_optional_blade_and_swap_a_slot() {
        let lp1 = StationName::new("LP1").unwrap();
        let cases = [
            (
                "GET LP1 3",
                Command::Get {
                    station: lp1,
                    slot: 3,
                    blade: Blade::A,
                },
            ),
            (
                "get lp1 3 b",
                Command::Get {
                    station: StationName::new("lp1").unwrap(),
                    slot: 3,
                    blade: Blade::B,
                },
            ),
            (
                "PUT LP1 3 A",
                Command::Put {
                    station: lp1,
                    slot: 3,
                    blade: Blade::A,
                },
            ),
            (
                "PUT LP1 3 B",
                Command::Put {
                    station: lp1,
                    slot: 3,
                    blade: Blade::B,
                },
            ),
            (
                "SWAP LP1 3",
                Command::Swap {
                    station: lp1,
                    slot: 3,
                },
            ),
        ];
        for (line, command) in cases {
            assert_eq!(ok(line).command, command, "{line}");
        }
        let e = err("1 GET LP1 3 C");
        assert_eq!(e.error.code(), Code::BadArgument);
        assert!(
            e.error.to_string().contains("blade \"C\" must be A or B"),
            "{}",
            e.error
        );
        assert_eq!(err("GET LP1 3 B B").error.code(), Code::ArgumentCount);
        assert_eq!(err("SWAP LP1 3 B").error.code(), Code::ArgumentCount);
        assert_eq!(err("SWAP LP1 0").error.code(), Code::SlotUnknown);
        assert_eq!(ok("SWAP PM1 1").command.verb(), Verb::Swap);
    }

    #[test]
    fn recovery_retract_sense_and_the_five_forms_of_confirm() {
        let lp2 = StationName::new("LP2").unwrap();
        let slot = Place::Slot {
            station: lp2,
            slot: 1,
        };
        let cases = [
            ("RECOVERY", Command::Recovery),
            ("retract", Command::Retract),
            ("SENSE", Command::Sense(Blade::A)),
            ("SENSE b", Command::Sense(Blade::B)),
            (
                "CONFIRM W3 LP2 1",
                Command::Confirm(ConfirmArg::At {
                    wafer: 3,
                    place: slot,
                }),
            ),
            (
                "confirm w3 hand",
                Command::Confirm(ConfirmArg::At {
                    wafer: 3,
                    place: Place::Hand(Blade::A),
                }),
            ),
            (
                "CONFIRM W3 HAND B",
                Command::Confirm(ConfirmArg::At {
                    wafer: 3,
                    place: Place::Hand(Blade::B),
                }),
            ),
            (
                "CONFIRM W12 GONE",
                Command::Confirm(ConfirmArg::Gone { wafer: 12 }),
            ),
            (
                "CONFIRM HAND EMPTY",
                Command::Confirm(ConfirmArg::Empty(Place::Hand(Blade::A))),
            ),
            (
                "CONFIRM HAND B EMPTY",
                Command::Confirm(ConfirmArg::Empty(Place::Hand(Blade::B))),
            ),
            (
                "CONFIRM LP2 1 EMPTY",
                Command::Confirm(ConfirmArg::Empty(slot)),
            ),
        ];
        for (line, command) in cases {
            assert_eq!(ok(line).command, command, "{line}");
        }
        for bad in [
            "CONFIRM W3",
            "CONFIRM HAND",
            "CONFIRM W3 HAND C",
            "CONFIRM W3 LP2 0",
            "CONFIRM LP2 1",
            "CONFIRM W3 GONE NOW",
            "CONFIRM X3 LP2 1",
            "SENSE C",
            "SENSE A B",
        ] {
            let e = err(bad);
            assert!(
                matches!(
                    e.error.code(),
                    Code::BadArgument | Code::ArgumentCount | Code::SlotUnknown
                ),
                "{bad}: {:?}",
                e.error
            );
        }
        let e = err("CONFIRM LP2 1");
        assert!(e.error.to_string().contains("EMPTY"), "{}", e.error);
    }

    #[test]
    fn every_verb_without_arguments() {
        let cases = [
            ("STATUS", Command::Status),
            ("WHERE", Command::Where),
            ("HOME", Command::Home),
            ("STOP", Command::Stop),
            ("ESTOP", Command::Estop),
            ("HOLD", Command::Hold),
            ("RESUME", Command::Resume),
            ("RESET", Command::Reset),
            ("IO", Command::Io),
            ("WAIT", Command::Wait),
            ("CONTROL", Command::Control),
            ("RELEASE", Command::Release),
            ("HELP", Command::Help),
            ("SUBSCRIBE", Command::Subscribe),
            ("UNSUBSCRIBE", Command::Unsubscribe),
        ];
        for (line, command) in cases {
            let r = ok(line);
            assert_eq!(r.command, command);
            assert_eq!(r.command.verb().name(), line);
            assert_eq!((r.id, r.checksum), (None, false));
            let e = err(&format!("{line} 1"));
            assert_eq!(e.code(), Code::ArgumentCount);
            assert_eq!(e.to_string(), format!("{line} takes no arguments, got 1"));
        }
    }

    #[test]
    fn auth_takes_one_token_and_never_echoes_a_bad_one() {
        let r = ok("4 AUTH s3cret-token-0123456789");
        let Command::Auth(token) = r.command else {
            panic!("{r:?}");
        };
        assert_eq!(token.as_str(), "s3cret-token-0123456789");
        assert!(
            !format!("{r:?}").contains("s3cret"),
            "Debug shows the token"
        );
        for bad in [
            "AUTH short",
            "AUTH s3cret.token.0123456789",
            &format!("AUTH {}", "x".repeat(65)),
        ] {
            let e = err(bad);
            assert_eq!(e.code(), Code::BadArgument, "{bad}");
            assert!(
                !e.to_string().contains("short") && !e.to_string().contains("s3cret"),
                "{e}"
            );
        }
        assert_eq!(err("AUTH").code(), Code::ArgumentCount);
        assert_eq!(
            err("AUTH a-token-of-16-chars b").code(),
            Code::ArgumentCount
        );
    }

    #[test]
    fn verbs_are_case_insensitive_and_whitespace_is_tolerated() {
        assert_eq!(ok("status").command, Command::Status);
        assert_eq!(ok("StAtUs").command, Command::Status);
        let r = ok("  \t12   movl\t1  2 3   4  ");
        assert_eq!(r.id, Some(12));
        assert_eq!(
            r.command,
            Command::MovL {
                pose: Pose {
                    x: 1.0,
                    y: 2.0,
                    z: 3.0,
                    yaw: 4.0
                }
            }
        );
    }

    #[test]
    fn ids_are_one_to_eight_digits() {
        assert_eq!(ok("0 STATUS").id, Some(0));
        assert_eq!(ok("99999999 STATUS").id, Some(99_999_999));
        assert_eq!(ok("007 STATUS").id, Some(7));
        let e = err("123456789 STATUS");
        assert_eq!((e.id, e.code()), (None, Code::Malformed));
        assert_eq!(e.to_string(), "id 123456789 has more than 8 digits");
        let e = err("5");
        assert_eq!((e.id, e.code()), (Some(5), Code::Malformed));
        assert_eq!(e.to_string(), "no verb after the id; HELP lists the verbs");
        // A word that starts with digits but has letters is a verb, not an id.
        let e = err("12abc STATUS");
        assert_eq!((e.id, e.code()), (None, Code::UnknownVerb));
    }

    #[test]
    fn movj_takes_one_value_per_axis() {
        let r = ok("3 MOVJ 10 -20.5 +3 4e1");
        let Command::MovJ { joints, count } = r.command else {
            panic!("{r:?}")
        };
        assert_eq!(count, 4);
        assert_eq!(&joints[..5], &[10.0, -20.5, 3.0, 40.0, 0.0]);
        let e = err("4 MOVJ 1 2 3");
        assert_eq!((e.id, e.code()), (Some(4), Code::ArgumentCount));
        assert_eq!(
            e.to_string(),
            "MOVJ needs 4 joint values (one per axis), got 3"
        );
        let e = err("MOVJ 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18");
        assert_eq!(
            e.to_string(),
            "MOVJ needs 4 joint values (one per axis), got 18"
        );
        let p16 = Parser::new(16);
        let line = "MOVJ 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16";
        let Command::MovJ { joints, count } = p16.parse(line.as_bytes()).unwrap().command else {
            panic!()
        };
        assert_eq!((count, joints[15]), (16, 16.0));
    }

    #[test]
    fn movp_and_movl() {
        let r = ok("MOVP 250 100 20 30");
        assert_eq!(
            r.command,
            Command::MovP {
                pose: Pose {
                    x: 250.0,
                    y: 100.0,
                    z: 20.0,
                    yaw: 30.0
                },
                posture: None
            }
        );
        for (word, posture) in [
            ("L", Posture::Left),
            ("r", Posture::Right),
            ("left", Posture::Left),
        ] {
            let r = ok(&format!("MOVP 1 2 3 4 {word}"));
            assert!(matches!(r.command, Command::MovP { posture: Some(p), .. } if p == posture));
        }
        let e = err("MOVP 1 2 3 4 X");
        assert_eq!(
            (e.code(), e.to_string().as_str()),
            (Code::BadArgument, "posture \"X\" must be L or R")
        );
        let e = err("MOVP 1 2 3");
        assert_eq!(
            e.to_string(),
            "MOVP needs 4 or 5 arguments (<x> <y> <z> <yaw> [L|R]), got 3"
        );
        let e = err("MOVL 1 2 3 4 L");
        assert_eq!(
            e.to_string(),
            "MOVL needs 4 arguments (<x> <y> <z> <yaw>), got 5"
        );
    }

    #[test]
    fn numbers_must_be_finite() {
        for bad in ["1e999", "inf", "-inf", "NaN", "infinity"] {
            let e = err(&format!("MOVL {bad} 0 0 0"));
            assert_eq!(e.code(), Code::BadNumber);
            assert_eq!(e.to_string(), format!("\"{bad}\" is not a finite number"));
        }
        let e = err("MOVL 1 2 abc 4");
        assert_eq!(e.to_string(), "\"abc\" is not a number");
        let e = err("MOVL 1 2 3 0x10");
        assert_eq!(e.code(), Code::BadNumber);
        let long = "1".repeat(40) + "x";
        let e = err(&format!("MOVL 1 2 3 {long}"));
        assert_eq!(
            e.to_string(),
            format!("\"{}...\" is not a number", "1".repeat(24))
        );
    }

    #[test]
    fn jog_takes_an_axis_and_whole_pulses() {
        let r = ok("JOG 2 -1500");
        assert_eq!(
            r.command,
            Command::Jog {
                axis: AxisArg::Number(2),
                pulses: -1500
            }
        );
        let r = ok("jog Z +20");
        let Command::Jog { axis, pulses } = r.command else {
            panic!()
        };
        assert_eq!((axis.to_string().as_str(), pulses), ("Z", 20));
        let robot = Robot::paper_default();
        assert_eq!(axis.resolve(&robot), robot.axis_index("z"));
        assert_eq!(AxisArg::Number(1).resolve(&robot), Some(0));
        let e = err("JOG 5 10");
        assert_eq!(e.code(), Code::AxisUnknown);
        assert_eq!(
            e.to_string(),
            "axis 5 does not exist; this robot has axes 1 to 4"
        );
        assert_eq!(err("JOG 0 10").code(), Code::AxisUnknown);
        assert_eq!(err("JOG a.b 10").code(), Code::BadArgument);
        let e = err("JOG 1 1.5");
        assert_eq!(e.code(), Code::BadNumber);
        assert_eq!(
            e.to_string(),
            "\"1.5\" is not a whole number; write digits only, e.g. 1000"
        );
        assert_eq!(err("JOG 1 99999999999999999999").code(), Code::BadNumber);
        assert_eq!(err("JOG 1 ten").to_string(), "\"ten\" is not a number");
        assert_eq!(err("JOG 1").code(), Code::ArgumentCount);
    }

    #[test]
    fn speed_is_one_to_hundred_percent() {
        assert_eq!(ok("SPEED 1").command, Command::Speed(1.0));
        assert_eq!(ok("SPEED 100").command, Command::Speed(100.0));
        assert_eq!(ok("SPEED 12.5").command, Command::Speed(12.5));
        for bad in ["0", "0.5", "101", "-5"] {
            let e = err(&format!("SPEED {bad}"));
            assert_eq!(e.code(), Code::SpeedOutOfRange, "{bad}");
        }
        assert_eq!(
            err("SPEED 150").to_string(),
            "speed 150 is out of range; SPEED takes 1 to 100 [%]"
        );
        assert_eq!(
            err("SPEED").to_string(),
            "SPEED needs 1 argument (<1-100>), got 0"
        );
    }

    #[test]
    fn out_sets_one_of_32_outputs() {
        let out = |n, on, force| Command::Out { n, on, force };
        assert_eq!(ok("OUT 0 1").command, out(0, true, false));
        assert_eq!(ok("OUT 31 0").command, out(31, false, false));
        // FORCE, in any case, says the request means to switch a guarded output.
        assert_eq!(ok("OUT 0 0 FORCE").command, out(0, false, true));
        assert_eq!(ok("out 7 1 force").command, out(7, true, true));
        assert_eq!(ok("OUT 7 1 Force").command, out(7, true, true));
        let e = err("OUT 0 0 PLEASE");
        assert_eq!(e.code(), Code::BadArgument);
        assert_eq!(
            e.to_string(),
            "OUT takes FORCE after the state (OUT <n> 0|1 FORCE), not \"PLEASE\""
        );
        let e = err("OUT 0 0 FORCE FORCE");
        assert_eq!(e.code(), Code::ArgumentCount);
        assert_eq!(err("OUT 0").code(), Code::ArgumentCount);
        // The state is checked before the option.
        assert_eq!(err("OUT 0 2 FORCE").code(), Code::BadArgument);
        assert_eq!(err("OUT 40 0 FORCE").code(), Code::OutputUnknown);
        let e = err("OUT 32 1");
        assert_eq!(e.code(), Code::OutputUnknown);
        assert_eq!(
            e.to_string(),
            "output 32 does not exist; outputs are 0 to 31"
        );
        assert_eq!(err("OUT -1 1").code(), Code::OutputUnknown);
        let e = err("OUT 3 2");
        assert_eq!(e.code(), Code::BadArgument);
        assert_eq!(e.to_string(), "output state \"2\" must be 0 or 1");
    }

    #[test]
    fn unknown_verbs_and_garbage() {
        let e = err("9 FOO 1 2");
        assert_eq!((e.id, e.code()), (Some(9), Code::UnknownVerb));
        assert_eq!(e.to_string(), "unknown verb FOO; HELP lists the verbs");
        let e = err("1 STA\0TUS");
        assert_eq!((e.id, e.code()), (Some(1), Code::Malformed));
        assert_eq!(
            e.to_string(),
            "byte 0x00 at column 6 is not printable ASCII"
        );
        let e = p4().parse(b"\xC3\xA9").unwrap_err();
        assert_eq!(e.code(), Code::Malformed);
    }

    #[test]
    fn checksum_right_wrong_and_malformed() {
        // Worked example of docs/protocol.md: "1 STATUS" XORs to 0x05.
        assert_eq!(checksum(b"1 STATUS"), 0x05);
        let r = ok("1 STATUS*05");
        assert_eq!(
            (r.id, r.checksum, r.command),
            (Some(1), true, Command::Status)
        );
        assert!(ok("1 STATUS*05  ").checksum);
        assert_eq!(ok(&with_sum("2 movj 1 2 3 4")).id, Some(2));
        // Hex digits in either case.
        assert!(ok("WHERE*4d").checksum);
        assert!(ok("WHERE*4D").checksum);
        let e = err("1 STATUS*49");
        assert_eq!(
            (e.id, e.checksum, e.code()),
            (Some(1), true, Code::BadChecksum)
        );
        assert_eq!(
            e.to_string(),
            "checksum 49 does not match the request (expected 05)"
        );
        for bad in [
            "1 STATUS*0",
            "1 STATUS*",
            "1 STATUS*0G",
            "1 STATUS*050",
            "1 STATUS*05*05",
        ] {
            let e = err(bad);
            assert_eq!(
                (e.id, e.checksum, e.code()),
                (Some(1), true, Code::BadChecksum),
                "{bad}"
            );
        }
        // Argument errors on a checksummed request keep the flag so the NAK carries one.
        let e = err(&with_sum("3 SPEED 0"));
        assert_eq!(
            (e.id, e.checksum, e.code()),
            (Some(3), true, Code::SpeedOutOfRange)
        );
        // TCP and the Unix socket take no checksums.
        let e = p4().parse(b"1 STATUS*05").unwrap_err();
        assert_eq!(
            (e.id, e.checksum, e.code()),
            (Some(1), false, Code::NotAvailable)
        );
    }

    proptest! {
        #[test]
        fn any_bytes_parse_or_reject_without_panicking(
            line in proptest::collection::vec(any::<u8>(), 0..300),
            axes in 0usize..20,
            serial in any::<bool>(),
        ) {
            let parser = Parser::new(axes).with_checksum(serial);
            match parser.parse(&line) {
                Ok(r) => prop_assert!(r.id.is_none_or(|id| id <= 99_999_999)),
                Err(e) => {
                    // Every error has a code and a printable ASCII sentence.
                    let text = e.to_string();
                    prop_assert!(!text.is_empty());
                    prop_assert!(text.bytes().all(|b| b.is_ascii_graphic() || b == b' '));
                    prop_assert!(e.code().number() < 200);
                }
            }
        }

        #[test]
        fn words_made_of_protocol_characters_never_panic(
            line in "[0-9 ]{0,10}(movj|movp|movl|jog|speed|out|status)( [-+0-9.eEinfaLRz*]{1,6}){0,18}(\\*[0-9A-Fa-f]{0,3})?",
        ) {
            let _ = Parser::new(4).with_checksum(true).parse(line.as_bytes());
        }
    }
}
