//! The trace file format, version [`FORMAT_VERSION`] (docs/trace.md): the magic, the
//! version, then the meta, samples, messages and end sections in that order, each as a
//! 4-byte tag, a `u64` body length [byte], the body and a CRC-32 of tag, length and body.
//! All numbers are little-endian.
//!
//! The reader never trusts a length: a section body is read only as far as the data goes
//! (a length past the end of the file is a truncation, not an allocation), and every count
//! inside a body is checked against the bytes left in it before anything is reserved.

use std::io::{self, Read, Write};

use crate::{
    ClockKind, Direction, Message, Meta, Sample, TraceError, TraceFile, MAX_AXES, MAX_MESSAGE,
};

/// The first 8 bytes of every trace file.
pub const MAGIC: [u8; 8] = *b"WRCTRACE";

/// The trace format this build writes and reads; a reader refuses any other version.
pub const FORMAT_VERSION: u32 = 2;

/// The longest section body a reader accepts [byte] (4 GiB): an hour of 16-axis samples
/// at 1 ms is about 1 GiB.
pub const MAX_SECTION_BYTES: u64 = 1 << 32;

/// The name `write_to` and `read_from` give the data in their errors.
pub(crate) const STREAM: &str = "<stream>";

/// One section: its tag in the file and its name in messages.
#[derive(Clone, Copy)]
struct Section {
    tag: [u8; 4],
    name: &'static str,
    /// Where a reader that runs out of data is, for [`TraceError::Truncated`].
    inside: &'static str,
}

const META: Section = Section {
    tag: *b"META",
    name: "meta",
    inside: "the meta section",
};
const SAMPLES: Section = Section {
    tag: *b"SMPL",
    name: "samples",
    inside: "the samples section",
};
const MESSAGES: Section = Section {
    tag: *b"MESG",
    name: "messages",
    inside: "the messages section",
};
const END: Section = Section {
    tag: *b"END\0",
    name: "end",
    inside: "the end section",
};

/// Bytes of a message record before its line: t_ns, direction, source, client, flags, len.
const MESSAGE_HEAD_BYTES: usize = 8 + 1 + 1 + 2 + 1 + 2;

fn invalid(reason: impl Into<String>) -> TraceError {
    TraceError::Invalid {
        file: STREAM.to_string(),
        reason: reason.into(),
    }
}

fn io_error(action: &'static str, source: io::Error) -> TraceError {
    TraceError::Io {
        file: STREAM.to_string(),
        action,
        source,
    }
}

// ---------------------------------------------------------------------------------------
// Writing

/// The buffers a trace is encoded in, kept from one save to the next: a recorder that
/// made them as large as its ring at start-up saves without growing (at 1 kHz a 30 s
/// window is tens of MB, which a first save on an alarm would otherwise add then).
#[derive(Debug, Default)]
pub struct EncodeBuffers {
    meta: Vec<u8>,
    samples: Vec<u8>,
    messages: Vec<u8>,
    out: Vec<u8>,
}

impl EncodeBuffers {
    /// The encoded file of the last [`TraceFile::encode_into`].
    pub fn bytes(&self) -> &[u8] {
        &self.out
    }

    /// Memory they hold [byte].
    pub fn capacity(&self) -> usize {
        self.meta.capacity()
            + self.samples.capacity()
            + self.messages.capacity()
            + self.out.capacity()
    }
}

/// Encode `trace` in the file format into `b.out`. Nothing is encoded when the trace
/// cannot be.
pub(crate) fn encode(trace: &TraceFile, b: &mut EncodeBuffers) -> Result<(), TraceError> {
    let axes = trace.meta.axis_names.len();
    if axes > MAX_AXES {
        return Err(invalid(format!(
            "it has {axes} axis names; a trace has at most {MAX_AXES} axes"
        )));
    }
    // The meta is the only part that can break a rule: encode it before anything else.
    b.meta.clear();
    encode_meta(&trace.meta, &mut b.meta)?;
    b.samples.clear();
    encode_samples(&trace.samples, axes, &mut b.samples);
    b.messages.clear();
    encode_messages(&trace.messages, &mut b.messages);
    b.out.clear();
    let w = &mut b.out;
    w.extend_from_slice(&MAGIC);
    w.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    for (section, body) in [
        (META, &b.meta),
        (SAMPLES, &b.samples),
        (MESSAGES, &b.messages),
    ] {
        put_section(w, section, body).map_err(|e| io_error("write", e))?;
    }
    put_section(w, END, &[]).map_err(|e| io_error("write", e))
}

/// Write `trace` in the file format. Nothing is written when the trace cannot be.
pub(crate) fn write(trace: &TraceFile, w: &mut impl Write) -> Result<(), TraceError> {
    let mut b = EncodeBuffers::default();
    encode(trace, &mut b)?;
    w.write_all(&b.out)
        .and_then(|()| w.flush())
        .map_err(|e| io_error("write", e))
}

fn put_section(w: &mut impl Write, section: Section, body: &[u8]) -> io::Result<()> {
    let len = (body.len() as u64).to_le_bytes();
    w.write_all(&section.tag)?;
    w.write_all(&len)?;
    w.write_all(body)?;
    w.write_all(&section_crc(section.tag, len, body).to_le_bytes())
}

fn section_crc(tag: [u8; 4], len: [u8; 8], body: &[u8]) -> u32 {
    let mut crc = crc32fast::Hasher::new();
    crc.update(&tag);
    crc.update(&len);
    crc.update(body);
    crc.finalize()
}

fn put_str(out: &mut Vec<u8>, field: &str, s: &str) -> Result<(), TraceError> {
    let len = u32::try_from(s.len())
        .map_err(|_| invalid(format!("{field} is {} bytes, more than 4 GiB", s.len())))?;
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(s.as_bytes());
    Ok(())
}

fn put_count(out: &mut Vec<u8>, field: &str, n: usize) -> Result<(), TraceError> {
    let n = u32::try_from(n).map_err(|_| invalid(format!("{field} has {n} entries")))?;
    out.extend_from_slice(&n.to_le_bytes());
    Ok(())
}

fn put_opt_str(out: &mut Vec<u8>, field: &str, s: &Option<String>) -> Result<(), TraceError> {
    match s {
        None => {
            out.push(0);
            Ok(())
        }
        Some(s) => {
            out.push(1);
            put_str(out, field, s)
        }
    }
}

fn clock_code(clock: ClockKind) -> u8 {
    match clock {
        ClockKind::Monotonic => 0,
        ClockKind::Virtual => 1,
    }
}

fn direction_code(direction: Direction) -> u8 {
    match direction {
        Direction::Request => 0,
        Direction::Reply => 1,
        Direction::Opened => 2,
        Direction::Closed => 3,
    }
}

fn encode_meta(meta: &Meta, out: &mut Vec<u8>) -> Result<(), TraceError> {
    put_str(out, "wrc_version", &meta.wrc_version)?;
    put_str(out, "reason", &meta.reason)?;
    out.push(clock_code(meta.clock));
    out.extend_from_slice(&meta.period_ns.to_le_bytes());
    put_count(out, "axis_names", meta.axis_names.len())?;
    for name in &meta.axis_names {
        put_str(out, "an axis name", name)?;
    }
    put_count(out, "state_names", meta.state_names.len())?;
    for name in &meta.state_names {
        put_str(out, "a state name", name)?;
    }
    put_str(out, "config_toml", &meta.config_toml)?;
    put_opt_str(out, "stations_toml", &meta.stations_toml)?;
    put_opt_str(out, "wafers_toml", &meta.wafers_toml)?;
    put_opt_str(out, "world_toml", &meta.world_toml)?;
    put_count(out, "programs", meta.programs.len())?;
    for (name, text) in &meta.programs {
        put_str(out, "a program name", name)?;
        put_str(out, "a program text", text)?;
    }
    put_count(out, "start_pulses", meta.start_pulses.len())?;
    for p in &meta.start_pulses {
        out.extend_from_slice(&p.to_le_bytes());
    }
    out.push(u8::from(meta.from_start));
    out.extend_from_slice(&meta.saved_at_ns.to_le_bytes());
    Ok(())
}

fn encode_samples(samples: &[Sample], axes: usize, out: &mut Vec<u8>) {
    out.reserve(8 + samples.len() * crate::sample_file_bytes(axes));
    out.extend_from_slice(&(samples.len() as u64).to_le_bytes());
    for s in samples {
        out.extend_from_slice(&s.t_ns.to_le_bytes());
        for p in &s.commanded[..axes] {
            out.extend_from_slice(&p.to_le_bytes());
        }
        for p in &s.actual[..axes] {
            out.extend_from_slice(&p.to_le_bytes());
        }
        out.extend_from_slice(&s.inputs.to_le_bytes());
        out.extend_from_slice(&s.outputs.to_le_bytes());
        out.push(s.state);
        out.extend_from_slice(&s.error_code.to_le_bytes());
        out.extend_from_slice(&s.fifo_level.to_le_bytes());
        out.extend_from_slice(&s.latency_ns.to_le_bytes());
        out.extend_from_slice(&s.exec_ns.to_le_bytes());
    }
}

fn encode_messages(messages: &[Message], out: &mut Vec<u8>) {
    out.extend_from_slice(&(messages.len() as u64).to_le_bytes());
    for m in messages {
        out.extend_from_slice(&m.t_ns.to_le_bytes());
        out.push(direction_code(m.direction));
        out.push(m.source);
        out.extend_from_slice(&m.client.to_le_bytes());
        out.push(u8::from(m.truncated()));
        // A line is at most MAX_MESSAGE = 256 bytes: it fits a u16.
        out.extend_from_slice(&(m.line().len() as u16).to_le_bytes());
        out.extend_from_slice(m.line());
    }
}

// ---------------------------------------------------------------------------------------
// Reading

/// Read a trace in the file format; never panics, whatever the bytes.
pub(crate) fn read(r: &mut impl Read) -> Result<TraceFile, TraceError> {
    let mut magic = [0u8; 8];
    let got = read_up_to(r, &mut magic)?;
    if magic[..got] != MAGIC[..got] {
        return Err(TraceError::NotATrace {
            file: STREAM.to_string(),
        });
    }
    if got < magic.len() {
        return Err(truncated("the header"));
    }
    let mut version = [0u8; 4];
    read_exact(r, &mut version, "the header")?;
    let found = u32::from_le_bytes(version);
    if found != FORMAT_VERSION {
        return Err(TraceError::Version {
            file: STREAM.to_string(),
            found,
            supported: FORMAT_VERSION,
        });
    }
    let body = read_section(r, META)?;
    let meta = decode_meta(&mut Body::new(&body, META))?;
    let body = read_section(r, SAMPLES)?;
    let samples = decode_samples(&mut Body::new(&body, SAMPLES), meta.axis_names.len())?;
    let body = read_section(r, MESSAGES)?;
    let messages = decode_messages(&mut Body::new(&body, MESSAGES))?;
    let body = read_section(r, END)?;
    if !body.is_empty() {
        return Err(invalid(format!(
            "its end section has {} bytes; it has none",
            body.len()
        )));
    }
    Ok(TraceFile {
        meta,
        samples,
        messages,
    })
}

fn truncated(what: &'static str) -> TraceError {
    TraceError::Truncated {
        file: STREAM.to_string(),
        what,
    }
}

/// Read into `buf` until it is full or the data ends; the number of bytes read.
fn read_up_to(r: &mut impl Read, buf: &mut [u8]) -> Result<usize, TraceError> {
    let mut got = 0;
    while got < buf.len() {
        match r.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(io_error("read", e)),
        }
    }
    Ok(got)
}

fn read_exact(r: &mut impl Read, buf: &mut [u8], what: &'static str) -> Result<(), TraceError> {
    if read_up_to(r, buf)? < buf.len() {
        return Err(truncated(what));
    }
    Ok(())
}

/// Read one section, check its CRC and then its tag; its body.
fn read_section(r: &mut impl Read, section: Section) -> Result<Vec<u8>, TraceError> {
    let mut tag = [0u8; 4];
    read_exact(r, &mut tag, section.inside)?;
    let mut len = [0u8; 8];
    read_exact(r, &mut len, section.inside)?;
    let n = u64::from_le_bytes(len);
    if n > MAX_SECTION_BYTES {
        // A damaged length is the likely cause when the tag is the expected one.
        return Err(if tag == section.tag {
            TraceError::Corrupt {
                file: STREAM.to_string(),
                section: section.name,
            }
        } else {
            unexpected_tag(tag, section)
        });
    }
    // Reserve no more than 1 MiB up front: the body then grows only as data arrives, so a
    // damaged length never allocates more than the file holds.
    let mut body = Vec::with_capacity(n.min(1 << 20) as usize);
    let got = r
        .by_ref()
        .take(n)
        .read_to_end(&mut body)
        .map_err(|e| io_error("read", e))?;
    if (got as u64) < n {
        return Err(truncated(section.inside));
    }
    let mut crc = [0u8; 4];
    read_exact(r, &mut crc, section.inside)?;
    if u32::from_le_bytes(crc) != section_crc(tag, len, &body) {
        return Err(TraceError::Corrupt {
            file: STREAM.to_string(),
            section: section.name,
        });
    }
    if tag != section.tag {
        return Err(unexpected_tag(tag, section));
    }
    Ok(body)
}

fn unexpected_tag(tag: [u8; 4], section: Section) -> TraceError {
    invalid(format!(
        "the {} section (tag {}) was expected, found tag {}",
        section.name,
        tag_text(section.tag),
        tag_text(tag)
    ))
}

fn tag_text(tag: [u8; 4]) -> String {
    format!("{:?}", String::from_utf8_lossy(&tag))
}

/// A section body being decoded; running out of it breaks the format.
struct Body<'a> {
    bytes: &'a [u8],
    section: Section,
}

impl<'a> Body<'a> {
    fn new(bytes: &'a [u8], section: Section) -> Body<'a> {
        Body { bytes, section }
    }

    fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8], TraceError> {
        if n > self.bytes.len() {
            return Err(invalid(format!(
                "its {} section ends inside {field} ({n} bytes wanted, {} left)",
                self.section.name,
                self.bytes.len()
            )));
        }
        let (head, rest) = self.bytes.split_at(n);
        self.bytes = rest;
        Ok(head)
    }

    fn array<const N: usize>(&mut self, field: &str) -> Result<[u8; N], TraceError> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N, field)?);
        Ok(a)
    }

    fn u8(&mut self, field: &str) -> Result<u8, TraceError> {
        Ok(self.array::<1>(field)?[0])
    }
    fn u16(&mut self, field: &str) -> Result<u16, TraceError> {
        Ok(u16::from_le_bytes(self.array(field)?))
    }
    fn u32(&mut self, field: &str) -> Result<u32, TraceError> {
        Ok(u32::from_le_bytes(self.array(field)?))
    }
    fn u64(&mut self, field: &str) -> Result<u64, TraceError> {
        Ok(u64::from_le_bytes(self.array(field)?))
    }
    fn i64(&mut self, field: &str) -> Result<i64, TraceError> {
        Ok(i64::from_le_bytes(self.array(field)?))
    }

    fn bool(&mut self, field: &str) -> Result<bool, TraceError> {
        match self.u8(field)? {
            0 => Ok(false),
            1 => Ok(true),
            n => Err(invalid(format!("{field} is {n}; it is 0 or 1"))),
        }
    }

    fn string(&mut self, field: &str) -> Result<String, TraceError> {
        let n = self.u32(field)? as usize;
        let bytes = self.take(n, field)?;
        String::from_utf8(bytes.to_vec()).map_err(|_| invalid(format!("{field} is not UTF-8")))
    }

    fn opt_string(&mut self, field: &str) -> Result<Option<String>, TraceError> {
        Ok(if self.bool(field)? {
            Some(self.string(field)?)
        } else {
            None
        })
    }

    /// A count of entries of at least `min_bytes` each, checked against the bytes left.
    fn count(&mut self, field: &str, n: u64, min_bytes: usize) -> Result<usize, TraceError> {
        let left = (self.bytes.len() / min_bytes.max(1)) as u64;
        if n > left {
            return Err(invalid(format!(
                "its {} section says {n} {field}, but holds room for at most {left}",
                self.section.name
            )));
        }
        // n <= left, which came from a usize.
        Ok(n as usize)
    }

    fn finish(&self) -> Result<(), TraceError> {
        if self.bytes.is_empty() {
            Ok(())
        } else {
            Err(invalid(format!(
                "its {} section has {} bytes after its last field",
                self.section.name,
                self.bytes.len()
            )))
        }
    }
}

fn decode_meta(b: &mut Body<'_>) -> Result<Meta, TraceError> {
    let wrc_version = b.string("wrc_version")?;
    let reason = b.string("reason")?;
    let clock = match b.u8("clock")? {
        0 => ClockKind::Monotonic,
        1 => ClockKind::Virtual,
        n => return Err(invalid(format!("its clock code is {n}; it is 0 or 1"))),
    };
    let period_ns = b.u64("period_ns")?;
    let n = u64::from(b.u32("axis_names")?);
    if n > MAX_AXES as u64 {
        return Err(invalid(format!(
            "it has {n} axes; a trace has at most {MAX_AXES}"
        )));
    }
    let mut axis_names = Vec::new();
    for _ in 0..n {
        axis_names.push(b.string("an axis name")?);
    }
    let n = u64::from(b.u32("state_names")?);
    let n = b.count("state names", n, 4)?;
    let mut state_names = Vec::with_capacity(n);
    for _ in 0..n {
        state_names.push(b.string("a state name")?);
    }
    let config_toml = b.string("config_toml")?;
    let stations_toml = b.opt_string("stations_toml")?;
    let wafers_toml = b.opt_string("wafers_toml")?;
    let world_toml = b.opt_string("world_toml")?;
    let n = u64::from(b.u32("programs")?);
    let n = b.count("programs", n, 8)?;
    let mut programs = Vec::with_capacity(n);
    for _ in 0..n {
        programs.push((b.string("a program name")?, b.string("a program text")?));
    }
    let n = u64::from(b.u32("start_pulses")?);
    let n = b.count("start pulses", n, 8)?;
    let mut start_pulses = Vec::with_capacity(n);
    for _ in 0..n {
        start_pulses.push(b.i64("a start pulse")?);
    }
    let from_start = b.bool("from_start")?;
    let saved_at_ns = b.u64("saved_at_ns")?;
    b.finish()?;
    Ok(Meta {
        wrc_version,
        reason,
        clock,
        period_ns,
        axis_names,
        state_names,
        config_toml,
        stations_toml,
        wafers_toml,
        world_toml,
        programs,
        start_pulses,
        from_start,
        saved_at_ns,
    })
}

fn decode_samples(b: &mut Body<'_>, axes: usize) -> Result<Vec<Sample>, TraceError> {
    let size = crate::sample_file_bytes(axes);
    let n = b.u64("the sample count")?;
    if b.bytes.len() as u64 != n.saturating_mul(size as u64) {
        return Err(invalid(format!(
            "its samples section says {n} samples of {size} bytes but holds {} bytes",
            b.bytes.len()
        )));
    }
    let n = b.count("samples", n, size)?;
    let mut samples = Vec::with_capacity(n);
    for _ in 0..n {
        let mut s = Sample {
            t_ns: b.u64("a sample")?,
            ..Sample::default()
        };
        for p in &mut s.commanded[..axes] {
            *p = b.i64("a sample")?;
        }
        for p in &mut s.actual[..axes] {
            *p = b.i64("a sample")?;
        }
        s.inputs = b.u32("a sample")?;
        s.outputs = b.u32("a sample")?;
        s.state = b.u8("a sample")?;
        s.error_code = b.u16("a sample")?;
        s.fifo_level = b.u16("a sample")?;
        s.latency_ns = b.u32("a sample")?;
        s.exec_ns = b.u32("a sample")?;
        samples.push(s);
    }
    b.finish()?;
    Ok(samples)
}

fn decode_messages(b: &mut Body<'_>) -> Result<Vec<Message>, TraceError> {
    let n = b.u64("the message count")?;
    let n = b.count("messages", n, MESSAGE_HEAD_BYTES)?;
    let mut messages = Vec::with_capacity(n);
    for _ in 0..n {
        let t_ns = b.u64("a message")?;
        let direction = match b.u8("a message")? {
            0 => Direction::Request,
            1 => Direction::Reply,
            2 => Direction::Opened,
            3 => Direction::Closed,
            d => {
                return Err(invalid(format!(
                    "a message has direction code {d}; it is 0 to 3"
                )))
            }
        };
        let source = b.u8("a message")?;
        let client = b.u16("a message")?;
        let truncated = b.bool("a message's truncated flag")?;
        let len = usize::from(b.u16("a message")?);
        if len > MAX_MESSAGE {
            return Err(invalid(format!(
                "a message is {len} bytes long; a message keeps at most {MAX_MESSAGE}"
            )));
        }
        let line = b.take(len, "a message")?;
        messages.push(Message::from_parts(
            t_ns, direction, source, client, line, truncated,
        ));
    }
    b.finish()?;
    Ok(messages)
}
