//! wrc-trace: the controller's trace recorder — what the Pulse Generator saw every period
//! and every protocol line received or sent, kept in memory for the last seconds and saved
//! as a trace file that `wrc trace` reads and a replay re-runs.
//!
//! What it guarantees:
//! - [`Ring`] allocates once, in [`Ring::new`]; after that [`Ring::push_sample`] and
//!   [`Ring::push_message`] copy into a slot, overwrite the oldest when full, and never
//!   allocate, block or fail, so the real-time tasks push directly (a counting-allocator test
//!   asserts zero heap calls);
//! - [`Ring::snapshot`] and everything about files allocate: they run on a non-real-time
//!   thread;
//! - the file format (docs/trace.md) is versioned ([`FORMAT_VERSION`]) and every section
//!   carries a CRC-32; [`TraceFile::read_from`] returns a trace or a typed [`TraceError`]
//!   for any input, never panics, and never allocates more than the input holds;
//! - [`TraceFile::save`] is atomic: a reader sees the old file or the new one.
//!
//! ```
//! use wrc_trace::{Direction, Message, Meta, Ring, Sample, TraceFile};
//!
//! let mut ring = Ring::for_seconds(2.0, 10_000_000, 64); // 2 s at 10 ms, 64 lines
//! for k in 0..300u64 {
//!     let mut s = Sample { t_ns: k * 10_000_000, ..Sample::default() };
//!     s.commanded[0] = k as i64 * 100;
//!     ring.push_sample(&s); // real-time task: a copy, no allocation
//! }
//! ring.push_message(&Message::new(2_990_000_000, Direction::Request, 0, 1, b"STATUS\n"));
//!
//! let meta = Meta::new("TRACE SAVE", 10_000_000, &["J1", "J2"], &["IDLE", "MOVING"]);
//! let trace = ring.snapshot(meta, None); // non-real-time thread
//! assert_eq!(trace.samples.len(), 200); // the last 2 s
//!
//! let mut file = Vec::new();
//! trace.write_to(&mut file).unwrap();
//! assert_eq!(TraceFile::read_from(&mut file.as_slice()).unwrap(), trace);
//! ```
#![deny(missing_docs)]

mod error;
pub mod format;
mod message;
mod meta;
mod ring;
mod sample;
mod trace_file;

pub use error::TraceError;
pub use format::{EncodeBuffers, FORMAT_VERSION, MAGIC};
pub use message::{
    source_name, Direction, Message, MAX_MESSAGE, SOURCE_EVENT, SOURCE_GUI, SOURCE_HOST,
    SOURCE_PENDANT, SOURCE_PROGRAM,
};
pub use meta::{ClockKind, Meta};
pub use ring::{file_bytes_per_second, ring_bytes_per_second, Counts, Ring};
pub use sample::{sample_file_bytes, Sample, MAX_AXES};
pub use trace_file::TraceFile;
