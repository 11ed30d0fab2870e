//! A saved trace: its meta, samples and messages, written and read in the file format of
//! docs/trace.md (see [`crate::format`]), and the summary `wrc trace info` prints.

use std::fmt::Write as _;
use std::io::{Read, Write};
use std::path::Path;

use crate::format::{self, EncodeBuffers};
use crate::{Direction, Message, Meta, Sample, TraceError};

/// A trace: what the ring held when it was saved, and its meta.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TraceFile {
    /// What the trace is and what a replay needs.
    pub meta: Meta,
    /// One sample per period, oldest first.
    pub samples: Vec<Sample>,
    /// Request and reply lines, oldest first.
    pub messages: Vec<Message>,
}

impl TraceFile {
    /// Write the trace to `w` in the file format. Fails with [`TraceError::Invalid`] when
    /// the meta has more than [`MAX_AXES`](crate::MAX_AXES) axis names or a text longer than
    /// 4 GiB, and with [`TraceError::Io`] when `w` fails.
    pub fn write_to(&self, w: &mut impl Write) -> Result<(), TraceError> {
        format::write(self, w)
    }

    /// Save the trace to `path` atomically: the parent directory is created if missing, the
    /// file is written next to `path` under a temporary name, synced and renamed over
    /// `path`, so a reader sees the old file or the new one, never half of one.
    pub fn save(&self, path: &Path) -> Result<(), TraceError> {
        self.save_with(path, &mut EncodeBuffers::default())
    }

    /// Encode the trace into `buffers` ([`EncodeBuffers::bytes`]), reusing their memory.
    pub fn encode_into(&self, buffers: &mut EncodeBuffers) -> Result<(), TraceError> {
        crate::format::encode(self, buffers)
    }

    /// [`TraceFile::save`], encoding into `buffers` (kept for the next save).
    pub fn save_with(&self, path: &Path, buffers: &mut EncodeBuffers) -> Result<(), TraceError> {
        let name = path.display().to_string();
        self.encode_into(buffers).map_err(|e| e.in_file(&name))?;
        let bytes = buffers.bytes();
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| TraceError::Io {
                file: name.clone(),
                action: "create the directory of",
                source,
            })?;
        }
        wrc_cell::write_atomic(path, bytes).map_err(|source| TraceError::Io {
            file: name,
            action: "write",
            source,
        })
    }

    /// Read a trace from `r`. Any input gives a trace or an error, never a panic, and no
    /// length read from the data allocates more than the data holds.
    pub fn read_from(r: &mut impl Read) -> Result<TraceFile, TraceError> {
        format::read(r)
    }

    /// Load the trace file `path`; errors name the file.
    pub fn load(path: &Path) -> Result<TraceFile, TraceError> {
        let name = path.display().to_string();
        let file = std::fs::File::open(path).map_err(|source| TraceError::Io {
            file: name.clone(),
            action: "read",
            source,
        })?;
        format::read(&mut std::io::BufReader::new(file)).map_err(|e| e.in_file(&name))
    }

    /// The number of axes of the trace.
    pub fn axis_count(&self) -> usize {
        self.meta.axis_count()
    }

    /// Time from the first to the last sample [ns], 0 with fewer than two samples.
    pub fn duration_ns(&self) -> u64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => b.t_ns.saturating_sub(a.t_ns),
            _ => 0,
        }
    }

    /// The state codes of the samples, each once, in order of first appearance.
    pub fn states_seen(&self) -> Vec<u8> {
        let mut seen = [false; 256];
        let mut order = Vec::new();
        for s in &self.samples {
            if !seen[usize::from(s.state)] {
                seen[usize::from(s.state)] = true;
                order.push(s.state);
            }
        }
        order
    }

    /// A few lines saying what the trace holds: why it was saved, its clock, period and
    /// axes, its time span, the samples and messages, and the states seen.
    pub fn summary(&self) -> String {
        let m = &self.meta;
        let mut out = String::new();
        let version = if m.wrc_version.is_empty() {
            "an unknown wrc version"
        } else {
            &m.wrc_version
        };
        let _ = writeln!(out, "reason:   {}", m.reason);
        let _ = writeln!(
            out,
            "written:  by wrc {version}, trace format {}, saved at t = {} on the {} clock",
            format::FORMAT_VERSION,
            seconds(m.saved_at_ns),
            m.clock.as_str()
        );
        let _ = writeln!(
            out,
            "period:   {} ms, {} axes ({})",
            m.period_ns as f64 / 1e6,
            m.axis_count(),
            m.axis_names.join(", ")
        );
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => {
                let _ = writeln!(
                    out,
                    "duration: {} (t = {} to {})",
                    seconds(self.duration_ns()),
                    seconds(a.t_ns),
                    seconds(b.t_ns)
                );
            }
            _ => {
                let _ = writeln!(out, "duration: no samples");
            }
        }
        let count = |d: Direction| self.messages.iter().filter(|x| x.direction == d).count();
        let (requests, replies) = (count(Direction::Request), count(Direction::Reply));
        let (opened, closed) = (count(Direction::Opened), count(Direction::Closed));
        let _ = writeln!(out, "samples:  {}", self.samples.len());
        let connections = if opened + closed > 0 {
            format!("; connections: {opened} opened, {closed} closed")
        } else {
            String::new()
        };
        let _ = writeln!(
            out,
            "messages: {} ({requests} requests, {replies} replies{connections}){}",
            self.messages.len(),
            if m.from_start {
                ", from the session's start"
            } else {
                ", not from the session's start (no replay)"
            }
        );
        let states: Vec<String> = self
            .states_seen()
            .into_iter()
            .map(|s| m.state_name(s))
            .collect();
        let _ = writeln!(
            out,
            "states:   {}",
            if states.is_empty() {
                "none".to_string()
            } else {
                states.join(", ")
            }
        );
        let errors = self.error_codes_seen();
        if !errors.is_empty() {
            let codes: Vec<String> = errors.iter().map(u16::to_string).collect();
            let _ = writeln!(out, "errors:   {}", codes.join(", "));
        }
        out
    }

    /// The nonzero error codes of the samples, each once, in order of first appearance.
    fn error_codes_seen(&self) -> Vec<u16> {
        let mut codes: Vec<u16> = Vec::new();
        for s in &self.samples {
            if s.error_code != 0 && !codes.contains(&s.error_code) {
                codes.push(s.error_code);
            }
        }
        codes
    }
}

/// `ns` as seconds with millisecond resolution: `12.340 s`.
fn seconds(ns: u64) -> String {
    format!("{:.3} s", ns as f64 / 1e9)
}
