//! Fuzz the trace file reader (`TraceFile::read_from`, which `TraceFile::load` and
//! `wrc trace` use): any bytes give a trace or a `TraceError`, never a panic, and never an
//! allocation larger than the data (libFuzzer's malloc limit would catch one).
//!
//! Each input is read twice: as it is (magic, version, section framing, CRCs), and with its
//! section lengths clamped to the data and its section tags and CRC-32s made right, so that
//! mutations reach the meta, sample and message decoders behind the CRCs. Asserts: reading
//! the data in small chunks with interruptions gives the same result as reading it at once;
//! an accepted trace writes back to exactly the bytes it was read from and reads back equal;
//! its summary (`wrc trace info`) and state names render.
#![no_main]

use std::io::{self, Read};

use libfuzzer_sys::fuzz_target;
use wrc_trace::{TraceFile, MAGIC};

fuzz_target!(|data: &[u8]| {
    check(data);
    check(&with_sections_fixed(data));
});

fn check(data: &[u8]) {
    let at_once = TraceFile::read_from(&mut &data[..]);
    let trickled = TraceFile::read_from(&mut Trickle {
        data,
        step: data.len() % 61 + 1,
        interrupt: true,
    });
    match (&at_once, &trickled) {
        (Ok(a), Ok(b)) => assert_eq!(a, b, "chunked reads changed the trace"),
        (Err(a), Err(b)) => assert_eq!(
            a.to_string(),
            b.to_string(),
            "chunked reads changed the error"
        ),
        _ => panic!("chunked reads changed the outcome: {at_once:?} / {trickled:?}"),
    }
    let Ok(trace) = at_once else {
        return;
    };
    let mut written = Vec::new();
    trace
        .write_to(&mut written)
        .expect("a trace that was read writes");
    assert!(
        data.starts_with(&written),
        "the trace does not write back to the bytes it was read from"
    );
    let back = TraceFile::read_from(&mut &written[..]).expect("a written trace reads");
    assert_eq!(back, trace);
    let _ = trace.summary();
    let _ = trace.duration_ns();
    for state in trace.states_seen() {
        let _ = trace.meta.state_name(state);
    }
}

/// The section tags in file order.
const TAGS: [&[u8; 4]; 4] = [b"META", b"SMPL", b"MESG", b"END\0"];

/// `data` with the magic and version of a trace, each section's length clamped to the data
/// left, its tag the expected one and its CRC-32 right.
fn with_sections_fixed(data: &[u8]) -> Vec<u8> {
    let mut out = data.to_vec();
    if out.len() < 12 {
        return out;
    }
    out[..8].copy_from_slice(&MAGIC);
    out[8..12].copy_from_slice(&wrc_trace::FORMAT_VERSION.to_le_bytes());
    let mut at = 12;
    for tag in TAGS {
        let body = at + 12;
        let Some(room) = out.len().checked_sub(body + 4) else {
            break;
        };
        let mut len = [0u8; 8];
        len.copy_from_slice(&out[at + 4..body]);
        let n = u64::from_le_bytes(len).min(room as u64);
        out[at..at + 4].copy_from_slice(tag);
        out[at + 4..body].copy_from_slice(&n.to_le_bytes());
        let end = body + n as usize;
        let mut crc = crc32fast::Hasher::new();
        crc.update(&out[at..end]);
        out[end..end + 4].copy_from_slice(&crc.finalize().to_le_bytes());
        at = end + 4;
    }
    out
}

/// A reader that hands out `step` bytes at a time, each read after an `Interrupted`.
struct Trickle<'a> {
    data: &'a [u8],
    step: usize,
    interrupt: bool,
}

impl Read for Trickle<'_> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.interrupt = !self.interrupt;
        if !self.interrupt {
            return Err(io::ErrorKind::Interrupted.into());
        }
        let n = self.step.min(buf.len()).min(self.data.len());
        buf[..n].copy_from_slice(&self.data[..n]);
        self.data = &self.data[n..];
        Ok(n)
    }
}
