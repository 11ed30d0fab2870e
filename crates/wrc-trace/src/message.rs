//! One protocol line as the Ethernet or RS232C task received or sent it: a fixed-size
//! `Copy` value (the line is copied into it), so recording it never allocates.

use std::borrow::Cow;

/// Bytes of a line a message keeps: a protocol line is at most 256 bytes.
pub const MAX_MESSAGE: usize = 256;

/// [`Message::source`] of the host on TCP.
pub const SOURCE_HOST: u8 = 0;
/// [`Message::source`] of the GUI.
pub const SOURCE_GUI: u8 = 1;
/// [`Message::source`] of the teach pendant (RS232C).
pub const SOURCE_PENDANT: u8 = 2;
/// [`Message::source`] of a running robot program.
pub const SOURCE_PROGRAM: u8 = 3;
/// [`Message::source`] of a broadcast or an event line (`EVT …`).
pub const SOURCE_EVENT: u8 = 255;

/// The name of a [`Message::source`] code (`host`, `GUI`, `pendant`, `program`, `event`),
/// `other` for a code with no name.
pub fn source_name(source: u8) -> &'static str {
    match source {
        SOURCE_HOST => "host",
        SOURCE_GUI => "GUI",
        SOURCE_PENDANT => "pendant",
        SOURCE_PROGRAM => "program",
        SOURCE_EVENT => "event",
        _ => "other",
    }
}

/// Which way a line went, or what happened to a connection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// A request line the controller received.
    Request,
    /// A reply (or event) line the controller sent.
    Reply,
    /// A client connected (the message's line is empty): a replay opens its connection
    /// here.
    Opened,
    /// The client's connection closed, by the client or by the controller (line empty): a
    /// replay closes it here, so that what a lost client causes (a stop, control released)
    /// happens again.
    Closed,
}

/// A protocol line, received or sent, with when and from whom.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Message {
    /// Controller clock when the line was received or sent [ns since the controller
    /// started].
    pub t_ns: u64,
    /// Received (request) or sent (reply).
    pub direction: Direction,
    /// Who: [`SOURCE_HOST`], [`SOURCE_GUI`], [`SOURCE_PENDANT`], [`SOURCE_PROGRAM`],
    /// [`SOURCE_EVENT`].
    pub source: u8,
    /// The connection slot of the client.
    pub client: u16,
    len: u16,
    truncated: bool,
    bytes: [u8; MAX_MESSAGE],
}

impl Message {
    /// A message holding a copy of `line` without one trailing `\n`; a line longer than
    /// [`MAX_MESSAGE`] bytes keeps its first [`MAX_MESSAGE`] bytes and is marked
    /// [`truncated`](Message::truncated). Never allocates.
    pub fn new(t_ns: u64, direction: Direction, source: u8, client: u16, line: &[u8]) -> Message {
        let line = line.strip_suffix(b"\n").unwrap_or(line);
        let kept = line.len().min(MAX_MESSAGE);
        let mut bytes = [0u8; MAX_MESSAGE];
        bytes[..kept].copy_from_slice(&line[..kept]);
        Message {
            t_ns,
            direction,
            source,
            client,
            // `kept` <= MAX_MESSAGE = 256 fits a u16.
            len: kept as u16,
            truncated: kept < line.len(),
            bytes,
        }
    }

    /// The line's bytes as kept (without the trailing `\n`).
    pub fn line(&self) -> &[u8] {
        &self.bytes[..usize::from(self.len)]
    }

    /// The line as text; bytes that are not UTF-8 show as `U+FFFD`.
    pub fn text(&self) -> Cow<'_, str> {
        String::from_utf8_lossy(self.line())
    }

    /// The line was longer than [`MAX_MESSAGE`] bytes and only its start is kept.
    pub fn truncated(&self) -> bool {
        self.truncated
    }

    /// A message read from a file: `line` is at most [`MAX_MESSAGE`] bytes (the reader
    /// checks it) and is kept as is, with its truncation flag.
    pub(crate) fn from_parts(
        t_ns: u64,
        direction: Direction,
        source: u8,
        client: u16,
        line: &[u8],
        truncated: bool,
    ) -> Message {
        let mut m = Message::new(t_ns, direction, source, client, b"");
        let kept = line.len().min(MAX_MESSAGE);
        m.bytes[..kept].copy_from_slice(&line[..kept]);
        m.len = kept as u16;
        m.truncated = truncated;
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_trailing_newline_is_stripped() {
        let m = Message::new(5, Direction::Request, SOURCE_HOST, 1, b"MOVE J1 10\n");
        assert_eq!(m.line(), b"MOVE J1 10");
        assert_eq!(m.text(), "MOVE J1 10");
        assert!(!m.truncated());
        let m = Message::new(5, Direction::Reply, SOURCE_HOST, 1, b"ACK\n\n");
        assert_eq!(m.line(), b"ACK\n");
    }

    #[test]
    fn a_long_line_keeps_its_start_and_says_so() {
        let long = vec![b'x'; MAX_MESSAGE + 10];
        let m = Message::new(0, Direction::Request, SOURCE_GUI, 0, &long);
        assert_eq!(m.line().len(), MAX_MESSAGE);
        assert!(m.truncated());
        let exact = vec![b'y'; MAX_MESSAGE];
        let m = Message::new(0, Direction::Request, SOURCE_GUI, 0, &exact);
        assert!(!m.truncated());
        // The newline does not count toward the limit.
        let mut with_nl = exact.clone();
        with_nl.push(b'\n');
        assert!(!Message::new(0, Direction::Request, 0, 0, &with_nl).truncated());
    }

    #[test]
    fn invalid_utf8_is_shown_lossily() {
        let m = Message::new(0, Direction::Reply, SOURCE_EVENT, 0, b"EVT \xff");
        assert_eq!(m.text(), "EVT \u{fffd}");
    }
}
