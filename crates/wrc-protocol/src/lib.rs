//! wrc-protocol: the controller's host protocol (line-based ASCII, docs/protocol.md) and
//! the simulator's UDP datagram (docs/simulator-stream.md), as pure functions over bytes.
//!
//! What it guarantees:
//! - no threads, no sockets, no I/O, no logging: callers bring the bytes and send the
//!   results;
//! - no heap allocation anywhere on the path a real-time task uses: [`LineReader`] frames
//!   into a fixed 257-byte buffer, [`Parser::parse`] reads from `&[u8]`, [`ReplyBuf`] formats
//!   into a fixed 512-byte buffer, [`sim_stream::encode`] writes into the caller's slice (a
//!   counting-allocator test proves it);
//! - no input panics: arbitrary bytes give a line, a typed error with a [`Code`] and a
//!   sentence for the `NAK`, or nothing; an over-long line yields one error and the reader
//!   carries on at the next LF;
//! - the reply codes ([`Code`]) are a stable contract: numbers are never changed or reused.
//!
//! ```
//! use wrc_protocol::{Command, LineReader, Parser, ReplyBuf, StatusBody, State};
//!
//! let parser = Parser::new(4);
//! let mut reader = LineReader::new();
//! let mut out = ReplyBuf::new();
//! let mut sent = Vec::new();
//!
//! // Bytes as they come from a socket, split anywhere.
//! for chunk in [&b"1 stat"[..], b"us\r\n2 MOVJ 1 2\n3 FOO\n"] {
//!     let mut rest = chunk;
//!     while let Some(line) = reader.read(&mut rest) {
//!         let reply = match line {
//!             Err(too_long) => out.line_error(&too_long),
//!             Ok(line) => match parser.parse(line) {
//!                 Err(refused) => out.rejected(&refused),
//!                 Ok(request) => match request.command {
//!                     Command::Status => out.ack(
//!                         request.reply_to(),
//!                         StatusBody {
//!                             state: State::Idle,
//!                             homed: false,
//!                             speed_pct: 100.0,
//!                             owner: None,
//!                             err: None,
//!                         },
//!                     ),
//!                     _ => out.ack(request.reply_to(), ""),
//!                 },
//!             },
//!         };
//!         sent.push(String::from_utf8(reply.to_vec()).unwrap());
//!     }
//! }
//! assert_eq!(sent, [
//!     "ACK 1 state=IDLE homed=0 speed=100 owner=none err=0\n",
//!     "NAK 2 101 MOVJ needs 4 joint values (one per axis), got 2\n",
//!     "NAK 3 100 unknown verb FOO; HELP lists the verbs\n",
//! ]);
//! ```
#![deny(missing_docs)]

pub mod code;
pub mod line;
pub mod reply;
pub mod request;
pub mod sim_stream;
pub mod state;
pub mod verb;

pub use code::{Code, Severity};
pub use line::{LineError, LineReader, MAX_LINE};
pub use reply::{
    reply_field, CloseReason, Event, HelpBody, IoBody, Num, ReplyBuf, ReplyKind, ReplyTo,
    StatusBody, WhereBody, REPLY_CAPACITY,
};
pub use request::{
    checksum, ArgumentCount, Arity, AuthToken, AxisArg, BreakArg, Command, ConfirmArg, ParseError,
    Parser, Place, PointAction, ProgramName, Rejected, Request, SourceLine, StationName, StepKind,
    Token, VarName, VarNames, MAX_ID_DIGITS, MAX_VAR_NAMES, OUTPUT_COUNT,
};
pub use sim_stream::{DecodeError, EncodeError, SimFrame};
pub use state::State;
pub use verb::{Access, Verb, VerbSpec};
/// Re-exported from `wrc-cell` because `GET` and `PUT` carry one.
pub use wrc_cell::Blade;
/// Re-exported from `wrc-robot` because requests carry them.
pub use wrc_robot::{AxisName, Pose, Posture, MAX_AXES};
