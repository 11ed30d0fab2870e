//! Line framing: [`LineReader`] turns byte chunks, as they come from a socket or a serial
//! port, into request lines; fixed buffer, no allocation, and no input can make it panic or
//! lose its place.

use crate::code::Code;

/// XOR of `bytes`: the `*HH` checksum of the text before `*` (requests and replies).
pub fn checksum(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |acc, b| acc ^ b)
}

/// Longest request line, in bytes, not counting the terminating LF or CR LF.
pub const MAX_LINE: usize = 256;

/// The reader's buffer: a full line plus the CR of a CR LF pair.
const BUF_LEN: usize = MAX_LINE + 1;

/// What went wrong with one line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum LineError {
    /// The line was longer than [`MAX_LINE`]; it was discarded up to and including its LF.
    #[error("line of {len} bytes is longer than the limit of 256 bytes; nothing was done")]
    TooLong {
        /// Length of the discarded line [bytes], without its terminator; saturates at
        /// `u32::MAX`.
        len: u32,
    },
}

impl LineError {
    /// The reply code for this error ([`Code::LineTooLong`]).
    pub fn code(&self) -> Code {
        match self {
            LineError::TooLong { .. } => Code::LineTooLong,
        }
    }
}

/// Splits a byte stream into lines of at most [`MAX_LINE`] bytes.
///
/// A line ends at LF; a CR right before the LF is dropped. Lines that are empty or only
/// spaces, tabs and CRs are skipped (clients send them to wake a connection up), except
/// while [`keep_blank_lines`](LineReader::keep_blank_lines) is on: the text of an `UPLOAD`,
/// where a blank line is a line of the program. Any other bytes, including NUL and
/// non-UTF-8, are handed on unchanged for the parser to judge. A line over the limit yields
/// exactly one [`LineError::TooLong`], when its LF arrives, and the reader carries on with
/// the next line.
///
/// Feed it with [`LineReader::read`] (pull style) or [`LineReader::feed`] (callback style).
/// The reader holds a 257-byte buffer and never allocates.
///
/// ```
/// use wrc_protocol::{LineError, LineReader};
///
/// let mut reader = LineReader::new();
/// let mut lines = Vec::new();
/// for chunk in [&b"1 STA"[..], b"TUS\r\n\nWH", b"ERE\n"] {
///     let mut rest = chunk;
///     while let Some(line) = reader.read(&mut rest) {
///         lines.push(line.map(|l| l.to_vec()));
///     }
/// }
/// assert_eq!(lines, vec![Ok(b"1 STATUS".to_vec()), Ok(b"WHERE".to_vec())]);
/// ```
#[derive(Debug, Clone)]
pub struct LineReader {
    buf: [u8; BUF_LEN],
    len: usize,
    /// Bytes of the current line seen so far when it is over the limit; `None` otherwise.
    discarding: Option<u32>,
    /// The last byte discarded was a CR (not counted when the LF ends the line).
    discarded_cr: bool,
    /// Hand on blank lines instead of skipping them.
    keep_blank: bool,
}

impl Default for LineReader {
    fn default() -> Self {
        Self::new()
    }
}

impl LineReader {
    /// An empty reader.
    pub const fn new() -> Self {
        LineReader {
            buf: [0; BUF_LEN],
            len: 0,
            discarding: None,
            discarded_cr: false,
            keep_blank: false,
        }
    }

    /// Hand on blank lines (`keep: true`, for the lines of an `UPLOAD`, which are program
    /// text taken verbatim) or skip them (`false`, the default, between requests). Takes
    /// effect from the next line completed.
    pub fn keep_blank_lines(&mut self, keep: bool) {
        self.keep_blank = keep;
    }

    /// Take bytes from the front of `input` until one line is complete and return it
    /// (without its LF or CR LF), or the error for an over-long line. `input` is advanced past
    /// what was consumed. Returns `None` once `input` is used up without completing a line;
    /// the partial line is kept for the next call.
    pub fn read(&mut self, input: &mut &[u8]) -> Option<Result<&[u8], LineError>> {
        loop {
            let Some(pos) = input.iter().position(|&b| b == b'\n') else {
                self.take(input);
                *input = &[];
                return None;
            };
            let (head, tail) = input.split_at(pos);
            self.take(head);
            *input = &tail[1..];
            if let Some(seen) = self.discarding.take() {
                self.len = 0;
                let len = seen - u32::from(self.discarded_cr);
                return Some(Err(LineError::TooLong { len }));
            }
            let mut end = self.len;
            self.len = 0;
            if end > 0 && self.buf[end - 1] == b'\r' {
                end -= 1;
            }
            if end > MAX_LINE {
                return Some(Err(LineError::TooLong { len: end as u32 }));
            }
            if !self.keep_blank
                && self.buf[..end]
                    .iter()
                    .all(|&b| matches!(b, b' ' | b'\t' | b'\r'))
            {
                continue;
            }
            return Some(Ok(&self.buf[..end]));
        }
    }

    /// Feed one chunk and call `on_line` for each line (or error) it completes, in order.
    pub fn feed(&mut self, mut chunk: &[u8], mut on_line: impl FnMut(Result<&[u8], LineError>)) {
        while let Some(line) = self.read(&mut chunk) {
            on_line(line);
        }
    }

    /// Number of bytes of an unfinished line held in the buffer.
    pub fn pending(&self) -> usize {
        self.len
    }

    /// Forget any unfinished line (after a reconnect, for example).
    pub fn clear(&mut self) {
        self.len = 0;
        self.discarding = None;
    }

    /// Append bytes of the current line (no LF among them), switching to discarding when
    /// they do not fit.
    fn take(&mut self, bytes: &[u8]) {
        if let Some(seen) = self.discarding.as_mut() {
            *seen = seen.saturating_add(bytes.len().min(u32::MAX as usize) as u32);
            if let Some(&last) = bytes.last() {
                self.discarded_cr = last == b'\r';
            }
            return;
        }
        if self.len + bytes.len() <= BUF_LEN {
            self.buf[self.len..self.len + bytes.len()].copy_from_slice(bytes);
            self.len += bytes.len();
        } else {
            let seen = (self.len + bytes.len()).min(u32::MAX as usize) as u32;
            self.discarding = Some(seen);
            self.discarded_cr = bytes.last() == Some(&b'\r');
            self.len = 0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn collect(reader: &mut LineReader, chunks: &[&[u8]]) -> Vec<Result<Vec<u8>, LineError>> {
        let mut out = Vec::new();
        for chunk in chunks {
            reader.feed(chunk, |line| out.push(line.map(<[u8]>::to_vec)));
        }
        out
    }

    #[test]
    fn lf_and_crlf_end_lines_and_blank_lines_are_skipped() {
        let mut r = LineReader::new();
        let out = collect(&mut r, &[b"A\nB\r\n\r\n  \t\nC\r", b"\n"]);
        assert_eq!(
            out,
            vec![Ok(b"A".to_vec()), Ok(b"B".to_vec()), Ok(b"C".to_vec())]
        );
        assert_eq!(r.pending(), 0);
    }

    #[test]
    fn partial_lines_wait_for_their_lf() {
        let mut r = LineReader::new();
        assert!(collect(&mut r, &[b"STA", b"TUS"]).is_empty());
        assert_eq!(r.pending(), 6);
        assert_eq!(collect(&mut r, &[b"\n"]), vec![Ok(b"STATUS".to_vec())]);
    }

    #[test]
    fn exactly_256_bytes_pass_and_257_do_not() {
        let mut r = LineReader::new();
        let ok = [b'A'; MAX_LINE];
        let out = collect(&mut r, &[&ok, b"\r\n"]);
        assert_eq!(out, vec![Ok(ok.to_vec())]);
        let out = collect(&mut r, &[&ok, b"\n"]);
        assert_eq!(out, vec![Ok(ok.to_vec())]);
        let long = [b'A'; MAX_LINE + 1];
        let out = collect(&mut r, &[&long, b"\nSTOP\n"]);
        assert_eq!(
            out,
            vec![Err(LineError::TooLong { len: 257 }), Ok(b"STOP".to_vec())]
        );
        let out = collect(&mut r, &[&long, b"\r\nSTOP\n"]);
        assert_eq!(
            out,
            vec![Err(LineError::TooLong { len: 257 }), Ok(b"STOP".to_vec())]
        );
    }

    #[test]
    fn an_over_long_line_yields_one_error_and_resynchronises() {
        let mut r = LineReader::new();
        let junk = [0xFFu8; 1000];
        let out = collect(&mut r, &[b"1 MOVJ ", &junk, &junk, b"\n2 STATUS\n"]);
        assert_eq!(
            out,
            vec![
                Err(LineError::TooLong { len: 2007 }),
                Ok(b"2 STATUS".to_vec())
            ]
        );
        assert_eq!(out[0].as_ref().unwrap_err().code(), Code::LineTooLong);
        // A CR LF split across chunks is not counted in the length.
        let out = collect(&mut r, &[&[b'A'; 300], b"\r", b"\nSTOP\n"]);
        assert_eq!(
            out,
            vec![Err(LineError::TooLong { len: 300 }), Ok(b"STOP".to_vec())]
        );
    }

    #[test]
    fn garbage_is_passed_on_not_swallowed() {
        let mut r = LineReader::new();
        let out = collect(&mut r, &[b"\0\xC3\x28\x7F\n"]);
        assert_eq!(out, vec![Ok(b"\0\xC3\x28\x7F".to_vec())]);
    }

    /// Regression: an uploaded program lost its blank lines (the reader skipped them as it
    /// does between requests), so the stored program was not the text sent and every
    /// diagnostic after a blank line named the wrong line (found by the `upload` fuzz
    /// target on examples/fig7_ptp.wrl).
    #[test]
    fn blank_lines_are_handed_on_while_kept() {
        let mut r = LineReader::new();
        r.keep_blank_lines(true);
        let out = collect(&mut r, &[b"A\n\n  \r\n\t\nB\n"]);
        let lines: Vec<&[u8]> = vec![b"A", b"", b"  ", b"\t", b"B"];
        assert_eq!(
            out,
            lines.iter().map(|l| Ok(l.to_vec())).collect::<Vec<_>>()
        );
        r.keep_blank_lines(false);
        assert_eq!(collect(&mut r, &[b"\n \nC\n"]), vec![Ok(b"C".to_vec())]);
    }

    #[test]
    fn clear_drops_a_partial_line() {
        let mut r = LineReader::new();
        collect(&mut r, &[&[b'x'; 300]]);
        r.clear();
        assert_eq!(collect(&mut r, &[b"OK\n"]), vec![Ok(b"OK".to_vec())]);
    }

    proptest! {
        #[test]
        fn arbitrary_streams_never_panic(chunks in proptest::collection::vec(
            proptest::collection::vec(any::<u8>(), 0..400), 0..8)) {
            let mut r = LineReader::new();
            for chunk in &chunks {
                r.feed(chunk, |line| {
                    if let Ok(line) = line {
                        assert!(line.len() <= MAX_LINE);
                        assert!(!line.contains(&b'\n'));
                    }
                });
            }
            // Whatever came before, a fresh line after an LF comes out intact.
            let out = collect(&mut r, &[b"\n9 STATUS\n"]);
            prop_assert_eq!(out.last().cloned(), Some(Ok(b"9 STATUS".to_vec())));
        }

        #[test]
        fn short_lines_split_anywhere_come_out_intact(
            lines in proptest::collection::vec("[ -~]{0,256}", 0..6),
            crlf in any::<bool>(),
            cuts in proptest::collection::vec(any::<prop::sample::Index>(), 0..10),
        ) {
            let mut stream = Vec::new();
            for line in &lines {
                stream.extend_from_slice(line.as_bytes());
                stream.extend_from_slice(if crlf { b"\r\n" } else { b"\n" });
            }
            let mut points: Vec<usize> = cuts.iter().map(|i| i.index(stream.len() + 1)).collect();
            points.sort_unstable();
            let mut chunks: Vec<&[u8]> = Vec::new();
            let mut last = 0;
            for p in points {
                chunks.push(&stream[last..p]);
                last = p;
            }
            chunks.push(&stream[last..]);
            let mut r = LineReader::new();
            let out = collect(&mut r, &chunks);
            let expected: Vec<Result<Vec<u8>, LineError>> = lines
                .iter()
                .filter(|l| !l.bytes().all(|b| b == b' '))
                .map(|l| Ok(l.as_bytes().to_vec()))
                .collect();
            prop_assert_eq!(out, expected);
            prop_assert_eq!(r.pending(), 0);
        }
    }
}
