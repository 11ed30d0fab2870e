//! wrc-trace integration tests: one binary, a module per topic. The binary's global
//! allocator counts heap calls per thread (`wrc_alloc_count`; see `alloc`).

mod alloc;
mod file;
mod robustness;

use wrc_alloc_count::CountingAllocator;
use wrc_trace::{
    ClockKind, Direction, Message, Meta, Sample, TraceFile, SOURCE_EVENT, SOURCE_HOST,
};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// The states of `wrc_protocol::State`, by number.
pub const STATES: [&str; 6] = ["IDLE", "MOVING", "STOPPING", "ERROR", "ESTOP", "HELD"];

/// A small trace with every meta field set: 4 axes, `n` samples at 10 ms moving J1 and Z,
/// a request and its reply every 10 samples, and an event.
pub fn sample_trace(n: u64) -> TraceFile {
    let mut meta = Meta::new("TRACE SAVE", 10_000_000, &["J1", "J2", "J3", "Z"], &STATES);
    meta.wrc_version = "0.1.0".into();
    meta.clock = ClockKind::Virtual;
    meta.config_toml = "[robot]\naxes = 4\n".into();
    meta.stations_toml = Some("[[station]]\nname = \"LP1\"\n".into());
    meta.wafers_toml = None;
    meta.world_toml = Some("seed = 7\n".into());
    meta.programs = vec![("demo".into(), "MOVE J1 10\nEND\n".into())];
    meta.start_pulses = vec![0, -5, 7, 1_000];
    meta.from_start = true;
    meta.saved_at_ns = n * 10_000_000 + 1;
    let samples = (0..n)
        .map(|k| {
            let mut s = Sample {
                t_ns: k * 10_000_000,
                inputs: (k as u32 / 7) & 0b101,
                outputs: u32::from(k > n / 2),
                state: u8::from(k > 3 && k < n - 3),
                error_code: if k == n - 1 { 206 } else { 0 },
                fifo_level: (k % 4) as u16,
                latency_ns: 1_000 + k as u32,
                exec_ns: 20_000,
                ..Sample::default()
            };
            s.commanded[0] = k as i64 * 50;
            s.actual[0] = k as i64 * 50 - 3;
            s.commanded[3] = -(k as i64) * 20;
            s.actual[3] = -(k as i64) * 20 + 1;
            s
        })
        .collect();
    // A host connects before its first request and leaves after the last line.
    let mut messages = vec![Message::new(4, Direction::Opened, SOURCE_HOST, 1, b"")];
    for k in (0..n).step_by(10) {
        let t = k * 10_000_000 + 5;
        messages.push(Message::new(
            t,
            Direction::Request,
            SOURCE_HOST,
            1,
            b"MOVE J1 10\n",
        ));
        messages.push(Message::new(
            t + 1,
            Direction::Reply,
            SOURCE_HOST,
            1,
            b"ACK 1\n",
        ));
    }
    messages.push(Message::new(
        7,
        Direction::Reply,
        SOURCE_EVENT,
        0,
        b"EVT STATE MOVING",
    ));
    messages.push(Message::new(8, Direction::Request, 2, 3, &[b'x'; 300]));
    messages.push(Message::new(
        n * 10_000_000,
        Direction::Closed,
        SOURCE_HOST,
        1,
        b"",
    ));
    TraceFile {
        meta,
        samples,
        messages,
    }
}

/// `trace` in the file format.
pub fn bytes_of(trace: &TraceFile) -> Vec<u8> {
    let mut out = Vec::new();
    trace.write_to(&mut out).expect("a valid trace writes");
    out
}
