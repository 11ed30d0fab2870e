//! The trace recorder (docs/trace.md): what the controller did in the last seconds, kept in
//! memory and written to a file on demand (`TRACE SAVE`) or when an alarm, an E-stop or a
//! fault is raised.
//!
//! - The Pulse Generator pushes one [`Sample`] per period (commanded and actual pulses of
//!   every axis, inputs, outputs, state, error code, FIFO level, its wake-up latency) into a
//!   [`SampleTap`]; each client set of the Ethernet and RS232C tasks pushes every request
//!   line it reads and every line it delivers into a [`MessageTap`]. The taps are lock-free
//!   single-producer queues made before the tasks start: pushing copies a fixed-size record,
//!   never allocates, never blocks (a full queue counts the loss).
//! - The [`Recorder`] lives on the service thread (not real-time): it drains the taps into a
//!   bounded [`Ring`] (allocated once, at start-up, for `[trace] seconds` and `messages`),
//!   watches the samples for a state that turns to ERROR or ESTOP, and writes trace files
//!   atomically into the trace directory.
//!
//! A trace carries what a replay needs to run the session again under virtual time: the
//! configuration text, the stations, the wafer map, the simulated cell's ground truth and
//! the stored programs as they were when the controller started, and the commanded
//! position then.

use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::Arc;

use wrc_protocol::{Code, State};
use wrc_trace::{Direction, EncodeBuffers, Message, Meta, Ring, Sample, TraceError, TraceFile};

use crate::messages::SourceId;
use crate::shared::Shared;

/// Samples the Pulse Generator may push between two drains by the service thread (10 s at
/// 10 ms, 1 s at 1 ms).
pub const SAMPLE_QUEUE: usize = 1024;
/// Messages a client set may push between two drains.
pub const MESSAGE_QUEUE: usize = 1024;

/// The Pulse Generator's end of the recorder.
pub struct SampleTap {
    tx: rtrb::Producer<Sample>,
    /// Samples lost because the service thread had not drained the queue.
    pub dropped: u64,
}

impl SampleTap {
    /// Record one period (a copy; never allocates or blocks).
    pub fn push(&mut self, sample: &Sample) {
        if self.tx.push(*sample).is_err() {
            self.dropped += 1;
        }
    }
}

/// A client set's end of the recorder.
pub struct MessageTap {
    tx: rtrb::Producer<Message>,
    /// Messages lost because the service thread had not drained the queue.
    pub dropped: u64,
}

impl MessageTap {
    /// Record `line` (a request read from `who`, or a line delivered to `who`) at `t_ns`
    /// [ns] (a copy of at most 256 bytes; never allocates or blocks).
    pub fn push(&mut self, t_ns: u64, direction: Direction, who: SourceId, line: &[u8]) {
        let (source, client) = trace_source(who);
        let message = Message::new(t_ns, direction, source, client, line);
        if self.tx.push(message).is_err() {
            self.dropped += 1;
        }
    }
}

/// The trace's source code and connection slot of `who`.
pub fn trace_source(who: SourceId) -> (u8, u16) {
    let slot = who.slot() as u16;
    match who.kind() {
        SourceId::TCP => (wrc_trace::SOURCE_HOST, slot),
        SourceId::GUI => (wrc_trace::SOURCE_GUI, slot),
        SourceId::PENDANT => (wrc_trace::SOURCE_PENDANT, slot),
        _ if who == SourceId::PROGRAM => (wrc_trace::SOURCE_PROGRAM, 0),
        _ => (wrc_trace::SOURCE_EVENT, 0),
    }
}

/// The part of every trace's [`Meta`] that does not change during a session, for a
/// controller of `config` starting with the programs in `programs` and the cell files
/// `stations` and `wafers` (missing files are `None`, unreadable programs skipped). The
/// caller adds what only it knows: the clock, the commanded position at the start, the
/// simulated cell's ground truth.
pub fn session_meta(
    config: &wrc_config::Config,
    programs: &Path,
    stations: Option<&Path>,
    wafers: Option<&Path>,
) -> Meta {
    let read = |p: Option<&Path>| p.and_then(|p| std::fs::read_to_string(p).ok());
    let mut stored: Vec<(String, String)> = std::fs::read_dir(programs)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let path = e.path();
            let name = path.file_stem()?.to_str()?.to_string();
            (path.extension()? == "wrl")
                .then(|| std::fs::read_to_string(&path).ok().map(|t| (name, t)))?
        })
        .collect();
    stored.sort();
    let period_ns = (config.motion.period_s * 1e9).round().max(1.0) as u64;
    let axis_names: Vec<&str> = config
        .robot
        .axes()
        .iter()
        .map(|a| a.name.as_str())
        .collect();
    let state_names: Vec<&str> = State::ALL.iter().map(|s| s.as_str()).collect();
    let mut meta = Meta::new("", period_ns, &axis_names, &state_names);
    meta.wrc_version = env!("CARGO_PKG_VERSION").to_string();
    meta.config_toml = config.text.clone();
    meta.stations_toml = read(stations);
    meta.wafers_toml = read(wafers);
    meta.programs = stored;
    meta
}

/// A trace written to a file.
#[derive(Debug, Clone, PartialEq)]
pub struct Saved {
    /// Where.
    pub path: PathBuf,
    /// Per-period samples in it.
    pub samples: usize,
    /// Requests and replies in it.
    pub messages: usize,
    /// The time it covers [s].
    pub seconds: f64,
}

/// The non-real-time end: the ring, the alarm watch, the files.
pub struct Recorder {
    ring: Ring,
    samples: rtrb::Consumer<Sample>,
    messages: Vec<rtrb::Consumer<Message>>,
    meta: Meta,
    dir: PathBuf,
    seconds: f64,
    save_on_alarm: bool,
    last_state: u8,
    last_t_ns: u64,
    saves: u32,
    /// What a save copies the ring into and encodes it in, as large as the ring from
    /// start-up (so memory does not step up at the first save, an alarm's).
    scratch: TraceFile,
    buffers: EncodeBuffers,
}

/// The recorder of a session described by `meta` ([`session_meta`]) for `config`, saving
/// into `dir`, and the taps for the tasks: one sample tap, `message_taps` message taps.
pub fn recorder(
    config: &wrc_config::Config,
    meta: Meta,
    dir: PathBuf,
    message_taps: usize,
) -> (Recorder, SampleTap, Vec<MessageTap>) {
    let (stx, srx) = rtrb::RingBuffer::new(SAMPLE_QUEUE);
    let mut taps = Vec::with_capacity(message_taps);
    let mut consumers = Vec::with_capacity(message_taps);
    for _ in 0..message_taps {
        let (tx, rx) = rtrb::RingBuffer::new(MESSAGE_QUEUE);
        taps.push(MessageTap { tx, dropped: 0 });
        consumers.push(rx);
    }
    let ring = Ring::for_seconds(config.trace.seconds, meta.period_ns, config.trace.messages);
    let (scratch, buffers) = save_buffers(&ring, &meta);
    let recorder = Recorder {
        ring,
        samples: srx,
        messages: consumers,
        meta,
        dir,
        seconds: config.trace.seconds,
        save_on_alarm: config.trace.save_on_alarm,
        last_state: State::Idle.to_u8(),
        last_t_ns: 0,
        saves: 0,
        scratch,
        buffers,
    };
    (
        recorder,
        SampleTap {
            tx: stx,
            dropped: 0,
        },
        taps,
    )
}

impl Recorder {
    /// Where traces are written.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Memory the ring holds [byte].
    pub fn bytes(&self) -> usize {
        self.ring.bytes()
    }

    /// Move what the tasks recorded into the ring. When a sample shows the state turning
    /// to ERROR or ESTOP (an alarm, a fault, an E-stop) and `[trace] save_on_alarm` is on,
    /// the last seconds are saved: the result says where, or why not.
    pub fn drain(&mut self) -> Option<Result<Saved, TraceError>> {
        let mut raised: Option<(u8, u16)> = None;
        while let Ok(sample) = self.samples.pop() {
            let alarm = |s: u8| s == State::Error.to_u8() || s == State::Estop.to_u8();
            if alarm(sample.state) && !alarm(self.last_state) && raised.is_none() {
                raised = Some((sample.state, sample.error_code));
            }
            self.last_state = sample.state;
            self.last_t_ns = self.last_t_ns.max(sample.t_ns);
            self.ring.push_sample(&sample);
        }
        for consumer in &mut self.messages {
            while let Ok(message) = consumer.pop() {
                self.last_t_ns = self.last_t_ns.max(message.t_ns);
                self.ring.push_message(&message);
            }
        }
        let (state, code) = raised.filter(|_| self.save_on_alarm)?;
        let what = if state == State::Estop.to_u8() {
            "estop"
        } else {
            "alarm"
        };
        let text = Code::from_number(code)
            .map(|c| c.text().to_string())
            .unwrap_or_default();
        let reason = format!("{what} {code} {text}");
        let name = format!("{what}-{code}-{}", self.stamp());
        Some(self.save(&name, reason.trim_end()))
    }

    /// A name part from the controller clock [ms] and a counter (unique in a session).
    fn stamp(&mut self) -> String {
        self.saves += 1;
        format!("{}ms-{}", self.last_t_ns / 1_000_000, self.saves)
    }

    /// Write the last `[trace] seconds` to `<dir>/<name>.wrctrace` (`name` made from the
    /// time when `None`), atomically, with `reason` in it.
    pub fn save_named(&mut self, name: Option<&str>, reason: &str) -> Result<Saved, TraceError> {
        let name = match name {
            Some(n) => n.to_string(),
            None => format!("trace-{}", self.stamp()),
        };
        self.save(&name, reason)
    }

    fn save(&mut self, name: &str, reason: &str) -> Result<Saved, TraceError> {
        let since = self.last_t_ns.saturating_sub((self.seconds * 1e9) as u64);
        let meta = self.meta_for(reason);
        self.ring
            .snapshot_into(meta, Some(since), &mut self.scratch);
        canonical_order(&mut self.scratch);
        let path = self.dir.join(format!("{name}.wrctrace"));
        self.scratch.save_with(&path, &mut self.buffers)?;
        Ok(Saved {
            path,
            samples: self.scratch.samples.len(),
            messages: self.scratch.messages.len(),
            seconds: self.scratch.duration_ns() as f64 / 1e9,
        })
    }

    /// Memory the save's copy and encoding hold [byte] (all of it from start-up).
    pub fn save_bytes(&self) -> usize {
        self.scratch.samples.capacity() * std::mem::size_of::<Sample>()
            + self.scratch.messages.capacity() * std::mem::size_of::<Message>()
            + self.buffers.capacity()
    }

    /// The session's meta for a trace saved now for `reason`.
    fn meta_for(&self, reason: &str) -> Meta {
        let mut meta = self.meta.clone();
        meta.reason = reason.to_string();
        meta.saved_at_ns = self.last_t_ns;
        meta.from_start = true;
        meta
    }

    /// The ring since `since_ns` as a trace saved for `reason`, its messages in
    /// [`canonical_order`].
    fn trace(&self, reason: &str, since_ns: Option<u64>) -> TraceFile {
        let mut trace = self.ring.snapshot(self.meta_for(reason), since_ns);
        canonical_order(&mut trace);
        trace
    }

    /// The last seconds as a trace, without writing it (for `wrc sim --trace` and tests).
    pub fn snapshot(&mut self, reason: &str) -> TraceFile {
        self.drain_quietly();
        self.trace(reason, None)
    }

    fn drain_quietly(&mut self) {
        let save = std::mem::replace(&mut self.save_on_alarm, false);
        let _ = self.drain();
        self.save_on_alarm = save;
    }
}

/// A save's copy of the ring and its encoding buffers, made as large as a full `ring`
/// needs and written once (every page touched), so that saves later neither allocate nor
/// raise the process's memory (at 1 kHz a 30 s window is about 25 MB; before, the first
/// alarm's save added it, and the soak's memory rule saw a step it could not tell from a
/// leak).
fn save_buffers(ring: &Ring, meta: &Meta) -> (TraceFile, EncodeBuffers) {
    let capacity = ring.capacity();
    let longest = [b'x'; wrc_trace::MAX_MESSAGE];
    let mut scratch = TraceFile {
        meta: meta.clone(),
        samples: vec![Sample::default(); capacity.samples],
        messages: vec![
            Message::new(0, wrc_trace::Direction::Request, 0, 0, &longest);
            capacity.messages
        ],
    };
    let mut buffers = EncodeBuffers::default();
    // A meta that cannot be encoded leaves the buffers to grow at the first save, which
    // then reports the same error.
    let _ = scratch.encode_into(&mut buffers);
    scratch.samples.clear();
    scratch.messages.clear();
    (scratch, buffers)
}

/// Put a trace's messages in time order, and at one instant the host set's lines (with
/// every broadcast) first, then the GUIs', then the pendant's, each set's in the order they
/// were read or delivered. The taps are drained one after another whenever the service
/// thread runs, so the ring interleaves them by drain; this order does not depend on when
/// the drains happened, so a replay that does the same thing records the same trace.
fn canonical_order(trace: &mut TraceFile) {
    let set = |source: u8| match source {
        wrc_trace::SOURCE_GUI => 1,
        wrc_trace::SOURCE_PENDANT => 2,
        _ => 0,
    };
    trace.messages.sort_by_key(|m| (m.t_ns, set(m.source)));
}

/// Fill `sample` from the shared state (what the Pulse Generator does not read itself).
pub fn shared_part(sample: &mut Sample, shared: &Arc<Shared>) {
    sample.inputs = shared.inputs[0].load(Ordering::Relaxed);
    sample.outputs = shared.outputs[0].load(Ordering::Relaxed);
    sample.state = shared.state().to_u8();
    sample.error_code = shared.error_code.load(Ordering::Relaxed) as u16;
}
