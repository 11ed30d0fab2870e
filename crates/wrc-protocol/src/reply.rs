//! Reply formatting: `ACK`, `NAK`, `INF`, `ABS` and `EVT` lines written into a fixed
//! [`ReplyBuf`], with the request id echoed and the `*HH` checksum when the request carried
//! one. No allocation; the output is always one line of printable ASCII ending in LF.

use core::fmt::{self, Display, Write};

use wrc_robot::Pose;

use crate::code::Code;
use crate::line::checksum;
use crate::line::LineError;
use crate::state::State;
use crate::verb::Verb;

/// The value of the field `key=value` in a reply line (`ACK 7 state=IDLE homed=1 …`,
/// `WHERE`'s `j=…`, `WAFERS`' `LP1=…`), for host software reading replies back; `None`
/// when the line has no such field. Fields are separated by spaces; the first one named
/// `key` counts.
pub fn reply_field<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    line.split_whitespace()
        .find_map(|w| w.strip_prefix(key)?.strip_prefix('='))
}

/// Size of a [`ReplyBuf`] [bytes], including the checksum suffix and the LF: room for the
/// longest line the controller writes (the Pulse Generator's `EVT TASK` line after a long
/// run, every latency bin filled: about 900 bytes).
pub const REPLY_CAPACITY: usize = 1024;

/// Room kept at the end of the buffer for `*HH` and LF.
const SUFFIX_LEN: usize = 4;

/// Where a reply goes: the id to echo and whether to append a checksum. Taken from the
/// request ([`Request::reply_to`](crate::Request::reply_to)) and kept for the `INF` / `ABS`
/// of a motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct ReplyTo {
    /// The request's id, echoed right after the reply word.
    pub id: Option<u32>,
    /// Append `*HH` (the request carried a checksum).
    pub checksum: bool,
}

/// The first word of a reply line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ReplyKind {
    /// `ACK`: accepted (a motion: started or queued).
    Ack,
    /// `NAK`: refused; nothing moved.
    Nak,
    /// `INF`: the action finished normally.
    Inf,
    /// `ABS`: the action ended abnormally.
    Abs,
    /// `EVT`: unsolicited event.
    Evt,
}

impl ReplyKind {
    /// The word on the wire.
    pub fn as_str(self) -> &'static str {
        match self {
            ReplyKind::Ack => "ACK",
            ReplyKind::Nak => "NAK",
            ReplyKind::Inf => "INF",
            ReplyKind::Abs => "ABS",
            ReplyKind::Evt => "EVT",
        }
    }
}

/// A fixed 512-byte buffer holding one reply line.
///
/// Each of [`ack`](ReplyBuf::ack), [`nak`](ReplyBuf::nak), [`inf`](ReplyBuf::inf),
/// [`abs`](ReplyBuf::abs), [`evt`](ReplyBuf::evt) and [`event`](ReplyBuf::event) clears the
/// buffer, writes one complete line and returns it, ready for the socket. Bodies are any
/// [`Display`] (a `&str`, `format_args!`, or the body types of this module); an empty body
/// adds nothing. Text is kept to printable ASCII: tabs become spaces, other control
/// characters, non-ASCII and `*` (reserved for the checksum) become `?`. A line that does
/// not fit is cut (see [`is_truncated`](ReplyBuf::is_truncated)) but still ends properly.
///
/// For a line the helpers do not cover, [`begin`](ReplyBuf::begin), write with
/// [`core::fmt::Write`], and [`finish`](ReplyBuf::finish).
///
/// ```
/// use wrc_protocol::{Code, ReplyBuf, ReplyTo};
///
/// let mut out = ReplyBuf::new();
/// let to = ReplyTo { id: Some(12), checksum: false };
/// assert_eq!(out.ack(to, format_args!("speed={}", 50)), b"ACK 12 speed=50\n");
/// assert_eq!(out.inf(to, ""), b"INF 12\n");
/// assert_eq!(out.abs(to, Code::Stopped, Code::Stopped.text()), b"ABS 12 200 stopped by STOP\n");
/// let serial = ReplyTo { id: Some(1), checksum: true };
/// assert_eq!(out.ack(serial, ""), b"ACK 1*58\n");
/// ```
#[derive(Clone)]
pub struct ReplyBuf {
    buf: [u8; REPLY_CAPACITY],
    len: usize,
    truncated: bool,
}

impl Default for ReplyBuf {
    fn default() -> Self {
        Self::new()
    }
}

impl fmt::Debug for ReplyBuf {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ReplyBuf")
            .field("line", &self.as_str())
            .field("truncated", &self.truncated)
            .finish()
    }
}

impl ReplyBuf {
    /// An empty buffer.
    pub const fn new() -> Self {
        ReplyBuf {
            buf: [0; REPLY_CAPACITY],
            len: 0,
            truncated: false,
        }
    }

    /// `ACK [<id>][ <body>]`: accepted.
    pub fn ack(&mut self, to: ReplyTo, body: impl Display) -> &[u8] {
        self.line(ReplyKind::Ack, to.id, None, body);
        self.finish(to.checksum)
    }

    /// `NAK [<id>] <code> <text>`: refused, nothing moved. `text` must not start with a
    /// digit (clients tell the id from the code by counting numbers).
    pub fn nak(&mut self, to: ReplyTo, code: Code, text: impl Display) -> &[u8] {
        self.line(ReplyKind::Nak, to.id, Some(code), text);
        self.finish(to.checksum)
    }

    /// `INF [<id>][ <body>]`: the action finished normally.
    pub fn inf(&mut self, to: ReplyTo, body: impl Display) -> &[u8] {
        self.line(ReplyKind::Inf, to.id, None, body);
        self.finish(to.checksum)
    }

    /// `ABS [<id>] <code> <text>`: the action ended abnormally.
    pub fn abs(&mut self, to: ReplyTo, code: Code, text: impl Display) -> &[u8] {
        self.line(ReplyKind::Abs, to.id, Some(code), text);
        self.finish(to.checksum)
    }

    /// `EVT <name>[ <body>]`: an unsolicited event; `checksum` for serial clients that use
    /// checksums.
    pub fn evt(&mut self, checksum: bool, name: &str, body: impl Display) -> &[u8] {
        self.begin(ReplyKind::Evt, None);
        self.push_str(" ");
        self.push_str(name);
        self.body(body);
        self.finish(checksum)
    }

    /// One of the documented events, `EVT <name> <body>`.
    pub fn event(&mut self, checksum: bool, event: &Event<'_>) -> &[u8] {
        self.evt(checksum, event.name(), event)
    }

    /// The `NAK` for a line the [`LineReader`](crate::LineReader) refused (code 103, no id:
    /// the line was never read).
    pub fn line_error(&mut self, error: &LineError) -> &[u8] {
        self.nak(ReplyTo::default(), error.code(), error)
    }

    /// Clear the buffer and write the reply word and the id, if any; continue with
    /// [`core::fmt::Write`] (start each field with a space) and end with
    /// [`finish`](ReplyBuf::finish).
    pub fn begin(&mut self, kind: ReplyKind, id: Option<u32>) {
        self.len = 0;
        self.truncated = false;
        self.push_str(kind.as_str());
        if let Some(id) = id {
            let _ = write!(self, " {id}");
        }
    }

    /// Append `*HH` when `checksum` (XOR of every byte before the `*`) and LF, and return
    /// the finished line.
    pub fn finish(&mut self, checksum_suffix: bool) -> &[u8] {
        // `push` keeps SUFFIX_LEN bytes free, so the suffix always fits.
        if checksum_suffix {
            let sum = checksum(&self.buf[..self.len]);
            let hex = |n: u8| b"0123456789ABCDEF"[usize::from(n & 0xF)];
            self.buf[self.len..self.len + 3].copy_from_slice(&[b'*', hex(sum >> 4), hex(sum)]);
            self.len += 3;
        }
        self.buf[self.len] = b'\n';
        self.len += 1;
        &self.buf[..self.len]
    }

    /// The line written so far (after [`finish`](ReplyBuf::finish): the whole line).
    pub fn as_bytes(&self) -> &[u8] {
        &self.buf[..self.len]
    }

    /// The line written so far as text (always ASCII).
    pub fn as_str(&self) -> &str {
        // Only printable ASCII, LF and the checksum are ever stored, so this never fails.
        core::str::from_utf8(self.as_bytes()).unwrap_or("")
    }

    /// The last line was cut because it did not fit in [`REPLY_CAPACITY`] bytes.
    pub fn is_truncated(&self) -> bool {
        self.truncated
    }

    fn line(&mut self, kind: ReplyKind, id: Option<u32>, code: Option<Code>, body: impl Display) {
        self.begin(kind, id);
        if let Some(code) = code {
            let _ = write!(self, " {code}");
        }
        self.body(body);
    }

    /// ` <body>`, or nothing when the body is empty.
    fn body(&mut self, body: impl Display) {
        let before = self.len;
        self.push_str(" ");
        let _ = write!(self, "{body}");
        if self.len == before + 1 {
            self.len = before;
        }
    }

    fn push_str(&mut self, s: &str) {
        for c in s.chars() {
            let byte = match c {
                '*' => b'?',
                '\t' => b' ',
                c if c.is_ascii_graphic() || c == ' ' => c as u8,
                _ => b'?',
            };
            if self.len >= REPLY_CAPACITY - SUFFIX_LEN {
                self.truncated = true;
                return;
            }
            self.buf[self.len] = byte;
            self.len += 1;
        }
    }
}

/// Appends text to the line being built, sanitised as described on [`ReplyBuf`]; text
/// past the capacity is dropped (never an error).
impl Write for ReplyBuf {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.push_str(s);
        Ok(())
    }
}

pub use wrc_robot::Num;

/// The body of the `STATUS` ACK:
/// `state=<STATE> homed=0|1 speed=<pct> owner=<source|none> err=<code|0>`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StatusBody<'a> {
    /// Controller state.
    pub state: State,
    /// Every axis has been homed since start-up.
    pub homed: bool,
    /// Speed override [%], 1 to 100.
    pub speed_pct: f64,
    /// Name of the command source holding control (`tcp`, `serial`, `unix`, …), or `None`.
    pub owner: Option<&'a str>,
    /// The last alarm or fatal code, until `RESET` clears it; `None` is written as `0`.
    pub err: Option<Code>,
}

impl Display for StatusBody<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "state={} homed={} speed={} owner={} err={}",
            self.state,
            u8::from(self.homed),
            Num(self.speed_pct),
            self.owner.unwrap_or("none"),
            self.err.map_or(0, Code::number)
        )
    }
}

/// The body of the `WHERE` ACK: `j=<j1>,<j2>,… x=<mm> y=<mm> z=<mm> yaw=<deg>`, joints in
/// axis units ([deg] or [mm]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WhereBody<'a> {
    /// Position of each axis (exactly the robot's axis count) in axis units.
    pub joints: &'a [f64],
    /// Tool centre point [mm, deg].
    pub tcp: Pose,
}

impl Display for WhereBody<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("j=")?;
        for (i, j) in self.joints.iter().enumerate() {
            if i > 0 {
                f.write_str(",")?;
            }
            write!(f, "{}", Num(*j))?;
        }
        let t = &self.tcp;
        write!(
            f,
            " x={} y={} z={} yaw={}",
            Num(t.x),
            Num(t.y),
            Num(t.z),
            Num(t.yaw)
        )
    }
}

/// The body of the `IO` ACK: `in=<hex> out=<hex>`, each word as 8 upper-case hex digits,
/// bit n = input / output n.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IoBody {
    /// Input word.
    pub inputs: u32,
    /// Output word.
    pub outputs: u32,
}

impl Display for IoBody {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "in={:08X} out={:08X}", self.inputs, self.outputs)
    }
}

/// The body of the `HELP` ACK: `verbs=STATUS,WHERE,…`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HelpBody;

impl Display for HelpBody {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("verbs=")?;
        for (i, verb) in Verb::ALL.iter().enumerate() {
            if i > 0 {
                f.write_str(",")?;
            }
            f.write_str(verb.name())?;
        }
        Ok(())
    }
}

/// The documented unsolicited events. Displays as the body after `EVT <name>`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Event<'a> {
    /// `EVT STATE <state>`: the controller state changed.
    State(State),
    /// `EVT ERROR <code> <text>`: an alarm or fatal condition was raised.
    Error {
        /// Its code (2xx or 3xx).
        code: Code,
        /// What happened, e.g. `following error on axis j2`; must not start with a digit.
        text: &'a str,
    },
    /// `EVT INPUT <n> 0|1`: input `n` changed.
    Input {
        /// Input number (bit of the input word), 0 to 31.
        n: u8,
        /// New level.
        on: bool,
    },
    /// `EVT CONTROL <owner|none>`: control was taken or released.
    Control {
        /// Source now holding control, `None` when free.
        owner: Option<&'a str>,
    },
    /// `EVT STATUS <status body> <where body>[ line=<file>:<line>]`: one status-stream
    /// sample (subscribers only); `line=` while a program runs: the source file (0 the
    /// program's own, then its libraries and called programs as `EVT PROGRAM … RUNNING
    /// files=…` lists them) and line of the statement it is at.
    Status {
        /// As in the `STATUS` ACK.
        status: StatusBody<'a>,
        /// As in the `WHERE` ACK.
        position: WhereBody<'a>,
        /// Where the running program is: file index and line.
        program_line: Option<(u16, u32)>,
    },
    /// `EVT PROGRAM <name> <state> [<detail>]`: a program started (`RUNNING files=…`),
    /// paused (`PAUSED <file>:<line>`), waits for the operator (`WAITING <file>:<line>
    /// <text>`) or ended (`ENDED`).
    Program {
        /// The program's name.
        name: &'a str,
        /// `RUNNING`, `PAUSED`, `WAITING` or `ENDED`.
        state: &'a str,
        /// What follows the state (may be empty).
        detail: &'a str,
    },
    /// `EVT ALARM <code> <text>`: a running program's `ALARM` (to every connection).
    Alarm {
        /// The alarm's code.
        code: u16,
        /// The program, where, and what.
        text: &'a str,
    },
    /// `EVT VAR <name> <type> <value>`: one variable in the reply to `VARS` (to the
    /// requester only); the body after `VAR`.
    Var(&'a str),
    /// `EVT POINT <program> <name> pose <x> <y> <z> <yaw>` or `… joints <j1> …`: a named
    /// point, in the reply to `POINTS` (requester) and when one changes (every
    /// connection); the body after `POINT`.
    Point(&'a str),
    /// `EVT RECOVERY <what> …`: one line of the recovery after an interrupted transfer, in
    /// the reply to `RECOVERY` (requester) and when the wafer map learns something during
    /// the recovery (every connection); the body after `RECOVERY`.
    Recovery(&'a str),
    /// `EVT PRINT <text>`: a running program's `PRINT` output (line breaks become spaces).
    Print(&'a str),
    /// `EVT DIAG <diagnostic>`: one compiler warning or error, as
    /// `<file>:<line>:<col>: <severity>: <message>` (to the requesting connection only).
    Diag(&'a str),
    /// `EVT AXIS <n> name=… role=… unit=… ppu=… min=… max=… home=…`: one axis in the reply
    /// to `ROBOT` (to the requesting connection only); the body after `AXIS`.
    Axis(&'a str),
    /// `EVT SIGNAL <in|out> <n> <guarded|-> <name>`: one named digital input or output in
    /// the reply to `ROBOT` (to the requesting connection only); the body after `SIGNAL`
    /// (the name is the rest of the line and may contain blanks).
    Signal(&'a str),
    /// `EVT TASK <name> prio=… …`: one real-time task's timing in the reply to `TASKS` (to
    /// the requesting connection only); the body after `TASK`.
    Task(&'a str),
    /// `EVT STATION <name> kind=… x=… …`: one station, in the reply to `STN` (to the
    /// requester only) and after `TEACH` (to every connection); the body after `STATION`.
    Station(&'a str),
    /// `EVT OBSTACLE <obstacle line>`: a fixed obstacle of the cell (in the reply to `STN`).
    Obstacle(&'a str),
    /// `EVT WAFER <place>=<tokens>`: one part of the wafer map, when `WAFERS` does not fit
    /// on one line (to the requester only).
    Wafer(&'a str),
    /// `EVT CLOSING <reason> <text>`: the controller is about to close this connection (to
    /// that connection only).
    Closing {
        /// Why.
        reason: CloseReason,
        /// What happened and what to do, e.g. `no request for 600 s; …`.
        text: &'a str,
    },
}

/// `text` with line breaks turned into spaces.
fn write_one_line(f: &mut fmt::Formatter<'_>, text: &str) -> fmt::Result {
    for c in text.chars() {
        let c = if c == '\n' || c == '\r' { ' ' } else { c };
        fmt::Write::write_char(f, c)?;
    }
    Ok(())
}

/// Why the controller closes a connection (`EVT CLOSING <reason> …`; docs/protocol.md
/// "Connections").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CloseReason {
    /// `IDLE`: no request within the idle timeout, and the connection holds no control.
    Idle,
    /// `FULL`: every connection slot is taken; the least recently active connection
    /// without control makes room for a new one.
    Full,
    /// `ADDRESS`: its address has the most connections one address may hold; its least
    /// recently active one without control makes room for a new one.
    Address,
    /// `DENIED`: its address may not connect.
    Denied,
    /// `AUTH`: too many wrong tokens.
    Auth,
}

impl CloseReason {
    /// The word written after `CLOSING`.
    pub fn as_str(self) -> &'static str {
        match self {
            CloseReason::Idle => "IDLE",
            CloseReason::Full => "FULL",
            CloseReason::Address => "ADDRESS",
            CloseReason::Denied => "DENIED",
            CloseReason::Auth => "AUTH",
        }
    }
}

impl Event<'_> {
    /// The event name written after `EVT`.
    pub fn name(&self) -> &'static str {
        match self {
            Event::State(_) => "STATE",
            Event::Error { .. } => "ERROR",
            Event::Input { .. } => "INPUT",
            Event::Control { .. } => "CONTROL",
            Event::Status { .. } => "STATUS",
            Event::Program { .. } => "PROGRAM",
            Event::Alarm { .. } => "ALARM",
            Event::Var(_) => "VAR",
            Event::Point(_) => "POINT",
            Event::Recovery(_) => "RECOVERY",
            Event::Print(_) => "PRINT",
            Event::Diag(_) => "DIAG",
            Event::Axis(_) => "AXIS",
            Event::Signal(_) => "SIGNAL",
            Event::Task(_) => "TASK",
            Event::Station(_) => "STATION",
            Event::Obstacle(_) => "OBSTACLE",
            Event::Wafer(_) => "WAFER",
            Event::Closing { .. } => "CLOSING",
        }
    }
}

impl Display for Event<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Event::State(state) => write!(f, "{state}"),
            Event::Error { code, text } => write!(f, "{code} {text}"),
            Event::Input { n, on } => write!(f, "{n} {}", u8::from(*on)),
            Event::Control { owner } => f.write_str(owner.unwrap_or("none")),
            Event::Status {
                status,
                position,
                program_line,
            } => {
                write!(f, "{status} {position}")?;
                if let Some((file, line)) = program_line {
                    write!(f, " line={file}:{line}")?;
                }
                Ok(())
            }
            Event::Program {
                name,
                state,
                detail,
            } => {
                write!(f, "{name} {state}")?;
                if !detail.is_empty() {
                    f.write_str(" ")?;
                    write_one_line(f, detail)?;
                }
                Ok(())
            }
            Event::Alarm { code, text } => {
                write!(f, "{code} ")?;
                write_one_line(f, text)
            }
            Event::Closing { reason, text } => write!(f, "{} {text}", reason.as_str()),
            Event::Print(text)
            | Event::Diag(text)
            | Event::Axis(text)
            | Event::Signal(text)
            | Event::Task(text)
            | Event::Station(text)
            | Event::Obstacle(text)
            | Event::Wafer(text)
            | Event::Var(text)
            | Event::Point(text)
            | Event::Recovery(text) => write_one_line(f, text),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::request::Parser;

    const NONE: ReplyTo = ReplyTo {
        id: None,
        checksum: false,
    };

    #[test]
    fn a_field_is_read_back_from_the_reply_that_wrote_it() {
        let mut out = ReplyBuf::new();
        let line = core::str::from_utf8(out.ack(
            ReplyTo {
                id: Some(7),
                checksum: false,
            },
            "state=IDLE homed=1 speed=100 owner=none err=0",
        ))
        .unwrap()
        .to_string();
        assert_eq!(reply_field(&line, "state"), Some("IDLE"));
        assert_eq!(reply_field(&line, "err"), Some("0"));
        // A key is a whole name: `homed` is not `home`, and a missing field is None.
        assert_eq!(reply_field(&line, "home"), None);
        assert_eq!(reply_field(&line, "x"), None);
        assert_eq!(reply_field("ACK hand=- LP1=-x25", "LP1"), Some("-x25"));
        assert_eq!(reply_field("ACK a= b=2", "a"), Some(""));
    }
    const ID7: ReplyTo = ReplyTo {
        id: Some(7),
        checksum: false,
    };

    fn text(line: &[u8]) -> &str {
        core::str::from_utf8(line).unwrap()
    }

    #[test]
    fn every_kind_with_and_without_id() {
        let mut out = ReplyBuf::new();
        assert_eq!(text(out.ack(NONE, "")), "ACK\n");
        assert_eq!(text(out.ack(ID7, "")), "ACK 7\n");
        assert_eq!(text(out.ack(ID7, "owner=tcp")), "ACK 7 owner=tcp\n");
        assert_eq!(
            text(out.nak(NONE, Code::UnknownVerb, "unknown verb FOO")),
            "NAK 100 unknown verb FOO\n"
        );
        assert_eq!(
            text(out.nak(ID7, Code::NotHomed, Code::NotHomed.text())),
            "NAK 7 110 not homed; send HOME first\n"
        );
        assert_eq!(text(out.inf(ID7, "")), "INF 7\n");
        assert_eq!(
            text(out.abs(ID7, Code::EmergencyStop, "emergency stop")),
            "ABS 7 201 emergency stop\n"
        );
        assert_eq!(
            text(out.evt(false, "STATE", State::Moving)),
            "EVT STATE MOVING\n"
        );
        assert_eq!(out.as_bytes(), b"EVT STATE MOVING\n");
    }

    #[test]
    fn checksum_suffix_covers_every_byte_before_the_star() {
        let mut out = ReplyBuf::new();
        let to = ReplyTo {
            id: Some(1),
            checksum: true,
        };
        let line = out.ack(to, "").to_vec();
        assert_eq!(line, b"ACK 1*58\n");
        let status = StatusBody {
            state: State::Idle,
            homed: true,
            speed_pct: 100.0,
            owner: None,
            err: None,
        };
        let line = out.ack(to, status).to_vec();
        assert_eq!(
            text(&line),
            "ACK 1 state=IDLE homed=1 speed=100 owner=none err=0*04\n"
        );
        let star = line.iter().position(|&b| b == b'*').unwrap();
        assert_eq!(
            format!("{:02X}", checksum(&line[..star])),
            text(&line[star + 1..star + 3])
        );
    }

    #[test]
    fn text_is_sanitised_to_one_ascii_line() {
        let mut out = ReplyBuf::new();
        let line = out.nak(ID7, Code::BadChecksum, "a*b\nc\td\u{e9}");
        assert_eq!(text(line), "NAK 7 104 a?b?c d?\n");
    }

    #[test]
    fn overlong_bodies_are_cut_but_the_line_is_whole() {
        let mut out = ReplyBuf::new();
        let long = "x".repeat(2 * REPLY_CAPACITY);
        let to = ReplyTo {
            id: Some(99_999_999),
            checksum: true,
        };
        let line = out.inf(to, &long).to_vec();
        assert!(out.is_truncated());
        assert_eq!(line.len(), REPLY_CAPACITY);
        assert!(line.ends_with(b"\n"));
        assert_eq!(line[REPLY_CAPACITY - 4], b'*');
        out.ack(to, "");
        assert!(!out.is_truncated());
    }

    #[test]
    fn body_helpers() {
        let mut out = ReplyBuf::new();
        let status = StatusBody {
            state: State::Error,
            homed: false,
            speed_pct: 12.5,
            owner: Some("serial"),
            err: Some(Code::FollowingError),
        };
        assert_eq!(
            text(out.ack(ID7, status)),
            "ACK 7 state=ERROR homed=0 speed=12.5 owner=serial err=203\n"
        );
        let position = WhereBody {
            joints: &[0.0, 90.0, -45.1234, 10.0005],
            tcp: Pose {
                x: 200.0,
                y: -0.0001,
                z: 10.0,
                yaw: 44.9999,
            },
        };
        assert_eq!(
            text(out.ack(ID7, position)),
            "ACK 7 j=0,90,-45.123,10.001 x=200 y=0 z=10 yaw=45\n"
        );
        let io = IoBody {
            inputs: 0x0F,
            outputs: 0x8000_0001,
        };
        assert_eq!(text(out.ack(ID7, io)), "ACK 7 in=0000000F out=80000001\n");
        let help = out.ack(ID7, HelpBody).to_vec();
        assert!(text(&help).starts_with("ACK 7 verbs=STATUS,WHERE,HOME,MOVJ,"));
        assert!(text(&help).ends_with(
            ",UPLOAD,PROGRAMS,RUN,PAUSE,CONTINUE,ABORT,DELETE,ROBOT,TASKS,TRACE,STN,TEACH,WAFERS,GET,PUT,MAP,SWAP,AUTH,BREAK,STEP,VARS,POINTS,POINT,RECOVERY,RETRACT,SENSE,CONFIRM\n"
        ));
    }

    #[test]
    fn events() {
        let mut out = ReplyBuf::new();
        let cases: [(Event<'_>, &str); 7] = [
            (Event::State(State::Estop), "EVT STATE ESTOP\n"),
            (
                Event::Closing {
                    reason: CloseReason::Idle,
                    text: "no request for 600 s",
                },
                "EVT CLOSING IDLE no request for 600 s\n",
            ),
            (
                Event::Error {
                    code: Code::FollowingError,
                    text: "following error on axis j2",
                },
                "EVT ERROR 203 following error on axis j2\n",
            ),
            (Event::Input { n: 3, on: true }, "EVT INPUT 3 1\n"),
            (Event::Control { owner: Some("tcp") }, "EVT CONTROL tcp\n"),
            (Event::Control { owner: None }, "EVT CONTROL none\n"),
            (
                Event::Status {
                    status: StatusBody {
                        state: State::Moving,
                        homed: true,
                        speed_pct: 50.0,
                        owner: Some("unix"),
                        err: None,
                    },
                    position: WhereBody {
                        joints: &[1.0, 2.0],
                        tcp: Pose::default(),
                    },
                    program_line: Some((0, 12)),
                },
                "EVT STATUS state=MOVING homed=1 speed=50 owner=unix err=0 j=1,2 x=0 y=0 z=0 yaw=0 line=0:12\n",
            ),
        ];
        for (event, line) in cases {
            assert_eq!(text(out.event(false, &event)), line);
        }
    }

    #[test]
    fn naks_for_parser_and_reader_errors() {
        let mut out = ReplyBuf::new();
        let parser = Parser::new(4).with_checksum(true);
        let rejected = parser.parse(b"5 MOVJ 1 2 3").unwrap_err();
        assert_eq!(
            text(out.rejected(&rejected)),
            "NAK 5 101 MOVJ needs 4 joint values (one per axis), got 3\n"
        );
        let rejected = parser.parse(b"5 STATUS*00").unwrap_err();
        let line = text(out.rejected(&rejected)).to_owned();
        assert!(
            line.starts_with("NAK 5 104 checksum 00 does not match"),
            "{line}"
        );
        assert_eq!(line.as_bytes()[line.len() - 4], b'*');
        let line = out.line_error(&LineError::TooLong { len: 300 });
        assert_eq!(
            text(line),
            "NAK 103 line of 300 bytes is longer than the limit of 256 bytes; nothing was done\n"
        );
    }
}
