//! Line-protocol clients, shared by the Ethernet and RS232C tasks: non-blocking streams,
//! framing, parsing, routing requests to the Command Interpreter (STOP and ESTOP through its
//! urgent path: queue + semaphore), fixed output buffers, and the status stream.
//!
//! With an [`FdRegistry`] ([`ClientSet::set_registry`]) every connected stream is watched by
//! its task's [`wrc_rt::wake::FdWake`] under its own token, so input releases the task at
//! once; [`ClientSet::read_ready`] then reads only the clients that have input.
//!
//! Fairness: one cycle reads at most [`READ_BUDGET`] bytes from each client (one `read`);
//! what is left stays in the socket, and the level-triggered waiter releases the task again
//! at once, so many clients flooding requests are served round-robin, a bounded amount each
//! per cycle, and none waits behind another's backlog.
//!
//! Admission (TCP hosts, with a [`HostAccess`]; docs/protocol.md "Connections"): a peer the
//! rules do not know is told `EVT CLOSING DENIED` and closed; one whose address holds its
//! limit of connections, or that finds every slot taken, gets the slot of the least recently
//! active connection without control (of its own address, or of any), which is told
//! `EVT CLOSING ADDRESS|FULL` first — so a flood of idle connections can never lock out a new
//! client, and the controlling connection is never the one closed. A connection without
//! control or subscription that sends nothing for the idle timeout is told
//! `EVT CLOSING IDLE` and closed. A monitoring connection may send read-only verbs only
//! (`NAK 107`); `AUTH <token>` lifts a token-guarded one to command.
//!
//! Real-time promise: every buffer is allocated when the set is made; a cycle makes only
//! non-blocking socket calls (the I/O the task exists for) and, when a client comes or goes,
//! one `epoll_ctl`; it never allocates or prints.

use std::fmt::Write as _;
use std::io::{self, Read, Write};

use std::net::{IpAddr, TcpStream};
use std::os::fd::{AsFd, BorrowedFd};
use std::os::unix::net::UnixStream;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use wrc_rt::FixedText;

use wrc_protocol::{
    Access, CloseReason, Code, Command, Event, LineReader, Parser, ReplyBuf, Request, StatusBody,
    WhereBody,
};
use wrc_robot::{Robot, MAX_AXES};
use wrc_rt::ipc::{MessageQueue, Semaphore};
use wrc_rt::wake::{FdRegistry, Token};

use crate::host_access::{HostAccess, Rights, MAX_AUTH_FAILURES};
use crate::messages::cell_job::JobKind;
use crate::messages::{Incoming, OutLine, SourceId, StoreRequest, Urgent};
use crate::recorder::MessageTap;
use crate::shared::Shared;
use wrc_trace::Direction;

/// Bytes of output kept per client before it counts as not reading.
pub const OUT_CAP: usize = 64 * 1024;

/// The most bytes read from one client in one cycle of a task with a waiter [bytes]: one
/// line of the longest length ([`wrc_protocol::MAX_LINE`]), or about 36 `STATUS` lines.
pub const READ_BUDGET: usize = wrc_protocol::MAX_LINE;

/// A byte stream a client talks over.
#[derive(Debug)]
pub enum Stream {
    /// A host on TCP.
    Tcp(TcpStream),
    /// A local GUI on the Unix socket.
    Unix(UnixStream),
    /// The teaching pendant's serial line (a tty opened non-blocking).
    Serial(std::fs::File),
}

impl Read for Stream {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self {
            Stream::Tcp(s) => s.read(buf),
            Stream::Unix(s) => s.read(buf),
            Stream::Serial(s) => s.read(buf),
        }
    }
}

impl AsFd for Stream {
    fn as_fd(&self) -> BorrowedFd<'_> {
        match self {
            Stream::Tcp(s) => s.as_fd(),
            Stream::Unix(s) => s.as_fd(),
            Stream::Serial(s) => s.as_fd(),
        }
    }
}

impl Write for Stream {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match self {
            Stream::Tcp(s) => s.write(buf),
            Stream::Unix(s) => s.write(buf),
            Stream::Serial(s) => s.write(buf),
        }
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// Where requests go.
#[derive(Clone)]
pub struct Routes {
    /// Requests for the Command Interpreter's periodic cycle.
    pub incoming: Arc<MessageQueue<Incoming>>,
    /// STOP, ESTOP (and Error Check's faults) for its urgent path.
    pub urgent: Arc<MessageQueue<Urgent>>,
    /// Wakes the urgent path at once.
    pub wake: Arc<Semaphore>,
    /// Program upload, listing, deletion and RUN, for the program store (non-real-time).
    pub store: Arc<MessageQueue<StoreRequest>>,
}

struct Slot {
    stream: Option<Stream>,
    source: SourceId,
    reader: LineReader,
    out: Box<[u8]>,
    out_len: usize,
    subscribed: bool,
    checksum: bool,
    /// Inside `UPLOAD`: lines are program text until a line `.`.
    uploading: bool,
    /// The last write left output behind (the client does not read): retried on the
    /// period only.
    backed_up: bool,
    generation: u32,
    /// The peer's address (TCP); `None` for local clients.
    peer: Option<IpAddr>,
    /// What it may send.
    rights: Rights,
    /// When it last sent anything (or connected) [ns, the task's clock].
    last_active_ns: u64,
    /// Wrong `AUTH` tokens so far.
    auth_failures: u8,
}

/// What [`ClientSet::add`] did with a new connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Added {
    /// It has a slot.
    Yes,
    /// It has a slot; another connection was closed to make room.
    Evicted,
    /// It was told why and closed (its address may not connect, or no connection could make
    /// room, or the kernel would not watch it).
    Refused,
}

/// A fixed-capacity set of clients of one kind.
pub struct ClientSet {
    kind: u32,
    slots: Vec<Slot>,
    parser: Parser,
    routes: Routes,
    shared: Arc<Shared>,
    robot: Robot,
    buf: ReplyBuf,
    read_buf: Box<[u8; 4096]>,
    /// The waiter's registry and the token of slot 0 (slot `i` has `first + i`).
    poll: Option<(FdRegistry, Token)>,
    /// Clients dropped because they stopped reading their replies.
    pub dropped_slow: u64,
    /// The trace recorder's tap: every line read and delivered.
    tap: Option<MessageTap>,
    /// The owning task's cycle time, for the recorder and the idle timeout [ns].
    now_ns: u64,
    /// Admission rules (TCP hosts); `None`: local clients, every slot may command.
    access: Option<HostAccess>,
    /// Connections closed by the idle timeout.
    pub closed_idle: u64,
    /// Connections closed to make room for a new one.
    pub evicted: u64,
}

impl ClientSet {
    /// Room for `capacity` clients of `kind` ([`SourceId::TCP`], …); `checksum` accepts the
    /// serial `*HH` suffix. Allocates every buffer now.
    pub fn new(
        kind: u32,
        capacity: usize,
        checksum: bool,
        robot: Robot,
        shared: Arc<Shared>,
        routes: Routes,
    ) -> ClientSet {
        let slots = (0..capacity)
            .map(|_| Slot {
                stream: None,
                source: SourceId::NONE,
                reader: LineReader::new(),
                out: vec![0u8; OUT_CAP].into_boxed_slice(),
                out_len: 0,
                subscribed: false,
                checksum: false,
                uploading: false,
                backed_up: false,
                generation: 0,
                peer: None,
                rights: Rights::Command,
                last_active_ns: 0,
                auth_failures: 0,
            })
            .collect();
        ClientSet {
            kind,
            slots,
            parser: Parser::new(robot.axis_count()).with_checksum(checksum),
            routes,
            shared,
            robot,
            buf: ReplyBuf::new(),
            read_buf: Box::new([0; 4096]),
            poll: None,
            dropped_slow: 0,
            tap: None,
            now_ns: 0,
            access: None,
            closed_idle: 0,
            evicted: 0,
        }
    }

    /// Admit TCP hosts by `access`; the set's capacity is the most connections it serves.
    pub fn with_access(mut self, access: HostAccess) -> ClientSet {
        self.access = Some(access);
        self
    }

    /// Record every request line read and every line delivered into `tap`.
    pub fn set_trace(&mut self, tap: MessageTap) {
        self.tap = Some(tap);
    }

    /// The owning task's cycle began at `now_ns` [ns] (the time its records carry).
    pub fn set_time(&mut self, now_ns: u64) {
        self.now_ns = now_ns;
    }

    /// Watch every client of this set with the task's waiter: slot `i` under token
    /// `first_token + i` (tokens `first_token .. first_token + capacity` must be below
    /// [`FdRegistry::tokens`]). Clients already connected are registered now; later ones when
    /// they are added, and each is deregistered when it is closed. Fails when a token is out
    /// of range or the kernel refuses a registration.
    pub fn set_registry(&mut self, registry: FdRegistry, first_token: Token) -> io::Result<()> {
        if first_token + self.slots.len() > registry.tokens() {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "{} clients from token {first_token} do not fit a waiter with {} tokens",
                    self.slots.len(),
                    registry.tokens()
                ),
            ));
        }
        for (i, slot) in self.slots.iter().enumerate() {
            if let Some(stream) = &slot.stream {
                registry.register(stream, first_token + i)?;
            }
        }
        self.poll = Some((registry, first_token));
        Ok(())
    }

    /// Take a new client from `peer` (`None`: a local one), by the set's admission rules:
    /// see [`Added`]. Without rules, a client finds a free slot or is refused.
    pub fn add(&mut self, mut stream: Stream, peer: Option<IpAddr>) -> Added {
        let mut added = Added::Yes;
        let rights = match (&self.access, peer) {
            (Some(access), Some(peer)) => match access.rights(peer) {
                Some(rights) => rights,
                None => {
                    let mut text = FixedText::<96>::new();
                    let _ = write!(text, "{peer} may not connect to this controller");
                    self.refuse(&mut stream, CloseReason::Denied, text.as_str());
                    return Added::Refused;
                }
            },
            _ => Rights::Command,
        };
        if let (Some(access), Some(peer)) = (&self.access, peer) {
            let (limit, from_peer) = (access.max_per_address, self.connected_from(peer));
            if from_peer >= limit {
                let mut text = FixedText::<128>::new();
                let _ = write!(
                    text,
                    "{peer} holds {from_peer} connections, the most one address may; \
                     closing its least recently active one"
                );
                if !self.evict(Some(peer), CloseReason::Address, text.as_str()) {
                    self.refuse(&mut stream, CloseReason::Address, text.as_str());
                    return Added::Refused;
                }
                added = Added::Evicted;
            }
        }
        if self.slots.iter().all(|s| s.stream.is_some()) {
            let mut text = FixedText::<128>::new();
            let _ = write!(
                text,
                "all {} connections are taken; closing the least recently active one",
                self.slots.len()
            );
            if self.access.is_none() || !self.evict(None, CloseReason::Full, text.as_str()) {
                self.refuse(&mut stream, CloseReason::Full, text.as_str());
                return Added::Refused;
            }
            added = Added::Evicted;
        }
        let kind = self.kind;
        let Some((i, slot)) = self
            .slots
            .iter_mut()
            .enumerate()
            .find(|(_, s)| s.stream.is_none())
        else {
            return Added::Refused;
        };
        if let Some((registry, first)) = &self.poll {
            if registry.register(&stream, first + i).is_err() {
                // The kernel would not watch it (out of memory or watches): refuse it rather
                // than keep a client whose input would wait for the period.
                return Added::Refused;
            }
        }
        slot.generation = slot.generation.wrapping_add(1);
        slot.source = SourceId::new(kind, i as u32, slot.generation);
        slot.stream = Some(stream);
        slot.reader.clear();
        slot.out_len = 0;
        slot.subscribed = false;
        slot.checksum = false;
        slot.uploading = false;
        slot.backed_up = false;
        slot.peer = peer;
        slot.rights = rights;
        slot.last_active_ns = self.now_ns;
        slot.auth_failures = 0;
        if let Some(tap) = &mut self.tap {
            tap.push(self.now_ns, Direction::Opened, slot.source, b"");
        }
        added
    }

    /// Connections from `peer` now.
    fn connected_from(&self, peer: IpAddr) -> usize {
        self.slots
            .iter()
            .filter(|s| s.stream.is_some() && s.peer == Some(peer))
            .count()
    }

    /// Close the least recently active connection (from `peer` only, if given) that holds
    /// no control, after telling it `EVT CLOSING <reason> <text>`; `false` when there is
    /// none.
    fn evict(&mut self, peer: Option<IpAddr>, reason: CloseReason, text: &str) -> bool {
        let owner = self.shared.owner.load(Ordering::Acquire);
        let victim = self
            .slots
            .iter()
            .enumerate()
            .filter(|(_, s)| {
                s.stream.is_some() && s.source.0 != owner && peer.is_none_or(|p| s.peer == Some(p))
            })
            .min_by_key(|(_, s)| s.last_active_ns)
            .map(|(i, _)| i);
        match victim {
            Some(i) => {
                self.evicted += 1;
                self.close_saying(i, reason, text);
                true
            }
            None => false,
        }
    }

    /// Tell a connection that gets no slot why (one non-blocking write), and close it.
    fn refuse(&mut self, stream: &mut Stream, reason: CloseReason, text: &str) {
        let _ = stream.write(self.buf.event(false, &Event::Closing { reason, text }));
    }

    /// Tell slot `i` `EVT CLOSING <reason> <text>` (after what it still has to receive, as
    /// far as its socket takes it now), and close it.
    fn close_saying(&mut self, i: usize, reason: CloseReason, text: &str) {
        let line = self
            .buf
            .event(self.slots[i].checksum, &Event::Closing { reason, text });
        if let Some(tap) = self.tap.as_mut() {
            tap.push(self.now_ns, Direction::Reply, self.slots[i].source, line);
        }
        let slot = &mut self.slots[i];
        let _ = Self::push_out(slot, line);
        let _ = Self::send_queued(slot);
        self.close(i);
    }

    /// Close every connection the idle timeout has run out for: no control, no
    /// subscription, no upload under way, and nothing sent for the whole timeout.
    pub fn close_idle(&mut self) {
        let Some(limit_ns) = self.access.as_ref().and_then(|a| a.idle_timeout_ns) else {
            return;
        };
        let owner = self.shared.owner.load(Ordering::Acquire);
        for i in 0..self.slots.len() {
            let s = &self.slots[i];
            let idle = s.stream.is_some()
                && s.source.0 != owner
                && !s.subscribed
                && !s.uploading
                && self.now_ns.saturating_sub(s.last_active_ns) >= limit_ns;
            if idle {
                let mut text = FixedText::<160>::new();
                let _ = write!(
                    text,
                    "no request for {} s and no control or subscription; reconnect when needed",
                    wrc_protocol::Num(limit_ns as f64 / 1e9)
                );
                self.closed_idle += 1;
                self.close_saying(i, CloseReason::Idle, text.as_str());
            }
        }
    }

    /// Clients connected now.
    pub fn connected(&self) -> usize {
        self.slots.iter().filter(|s| s.stream.is_some()).count()
    }

    /// Clients it has room for.
    pub fn capacity(&self) -> usize {
        self.slots.len()
    }

    fn push_out(slot: &mut Slot, bytes: &[u8]) -> bool {
        if slot.out_len + bytes.len() > slot.out.len() {
            return false;
        }
        slot.out[slot.out_len..slot.out_len + bytes.len()].copy_from_slice(bytes);
        slot.out_len += bytes.len();
        true
    }

    fn close(&mut self, i: usize) {
        let slot = &mut self.slots[i];
        if let Some(stream) = slot.stream.take() {
            if let Some((registry, _)) = &self.poll {
                let _ = registry.deregister(&stream);
            }
            drop(stream);
            let _ = self
                .routes
                .incoming
                .try_send(Incoming::Disconnected(slot.source));
            if let Some(tap) = &mut self.tap {
                tap.push(self.now_ns, Direction::Closed, slot.source, b"");
            }
        }
        if slot.uploading {
            let _ = self
                .routes
                .store
                .try_send(StoreRequest::Cancel { from: slot.source });
        }
        slot.out_len = 0;
        slot.subscribed = false;
        slot.uploading = false;
        slot.backed_up = false;
    }

    /// Read every client, parse complete lines and route them: with a registry at most
    /// [`READ_BUDGET`] bytes each (the waiter releases the task again for the rest), without
    /// one everything each has sent.
    pub fn poll_reads(&mut self) {
        for i in 0..self.slots.len() {
            if let Some((registry, first)) = &self.poll {
                // Read now: the mark would only cost the next event cycle an empty read.
                registry.take_ready(first + i);
            }
            self.read_client(i);
        }
    }

    /// Read the clients the waiter saw readable since the last cycle, at most
    /// [`READ_BUDGET`] bytes each; without a registry, every client ([`ClientSet::poll_reads`]).
    pub fn read_ready(&mut self) {
        let Some((registry, first)) = &self.poll else {
            return self.poll_reads();
        };
        let (registry, first) = (registry.clone(), *first);
        for i in 0..self.slots.len() {
            if registry.take_ready(first + i) {
                self.read_client(i);
            }
        }
    }

    fn read_client(&mut self, i: usize) {
        let budget = if self.poll.is_some() {
            READ_BUDGET
        } else {
            self.read_buf.len()
        };
        while let Some(stream) = self.slots[i].stream.as_mut() {
            match stream.read(&mut self.read_buf[..budget]) {
                Ok(0) => {
                    self.close(i);
                    break;
                }
                Ok(n) => {
                    self.handle_bytes(i, n);
                    if self.slots[i].auth_failures >= MAX_AUTH_FAILURES {
                        self.close_saying(
                            i,
                            CloseReason::Auth,
                            "too many wrong tokens; connect again to retry",
                        );
                        break;
                    }
                    if self.poll.is_some() {
                        break;
                    }
                }
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(_) => {
                    self.close(i);
                    break;
                }
            }
        }
    }

    fn handle_bytes(&mut self, i: usize, n: usize) {
        let mut input: &[u8] = &self.read_buf[..n];
        // Split borrows: the reader lives in the slot, the parser and buffers in self.
        let ClientSet {
            slots,
            parser,
            routes,
            buf,
            shared,
            tap,
            now_ns,
            access,
            ..
        } = self;
        let slot = &mut slots[i];
        slot.last_active_ns = *now_ns;
        loop {
            // An upload's blank lines are program text (its line numbers count them); between
            // requests they are skipped.
            slot.reader.keep_blank_lines(slot.uploading);
            let Some(line) = slot.reader.read(&mut input) else {
                break;
            };
            if let (Some(tap), Ok(text)) = (tap.as_mut(), &line) {
                tap.push(*now_ns, Direction::Request, slot.source, redacted(text));
            }
            if slot.uploading {
                let source = slot.source;
                if let Some(bytes) = upload_line(source, &mut slot.uploading, line, routes, buf) {
                    if let Some(tap) = tap.as_mut() {
                        tap.push(*now_ns, Direction::Reply, source, bytes);
                    }
                    let _ = Self::push_out(slot, bytes);
                }
                continue;
            }
            let reply: Option<&[u8]> = match line {
                Err(e) => Some(buf.line_error(&e)),
                Ok(line) => match parser.parse(line) {
                    Err(rejected) => Some(buf.rejected(&rejected)),
                    Ok(request) => {
                        slot.checksum |= request.checksum;
                        let to = request.reply_to();
                        if let Command::Auth(token) = request.command {
                            Some(authenticate(slot, &token, access.as_ref(), to, buf))
                        } else if slot.rights != Rights::Command
                            && request.command.verb().spec().access != Access::Read
                        {
                            Some(buf.nak(
                                to,
                                Code::MonitorOnly,
                                match slot.rights {
                                    Rights::Token => {
                                        "this connection may only monitor until AUTH <token>"
                                    }
                                    Rights::Monitor | Rights::Command => {
                                        "this connection's address may only monitor"
                                    }
                                },
                            ))
                        } else {
                            if matches!(request.command, Command::Stop | Command::Estop) {
                                shared
                                    .urgent_read_ns
                                    .store(Shared::now_ns(), Ordering::Release);
                            }
                            route(slot, request, routes, buf)
                        }
                    }
                },
            };
            if let Some(bytes) = reply {
                if let Some(tap) = tap.as_mut() {
                    tap.push(*now_ns, Direction::Reply, slot.source, bytes);
                }
                let _ = Self::push_out(slot, bytes);
            }
        }
    }

    /// Queue one of the Command Interpreter's or monitors' lines for its client (every
    /// client for [`SourceId::NONE`]); lines for other kinds of client are ignored, so the
    /// task that drains a shared queue hands each line to every set once.
    pub fn deliver(&mut self, line: &OutLine) {
        if let Some(tap) = self.tap.as_mut() {
            // Lines for this set's clients; a line for every client once, by the host set
            // (every set gets its copy).
            let mine = match line.to {
                SourceId::NONE => self.kind == SourceId::TCP,
                to => to.kind() == self.kind,
            };
            if mine {
                tap.push(self.now_ns, Direction::Reply, line.to, line.bytes());
            }
        }
        if line.to == SourceId::NONE {
            for slot in self.slots.iter_mut().filter(|s| s.stream.is_some()) {
                let _ = Self::push_out(slot, line.bytes());
            }
        } else if line.to.kind() == self.kind {
            let i = line.to.slot();
            if let Some(slot) = self.slots.get_mut(i) {
                if slot.stream.is_some()
                    && slot.source == line.to
                    && !Self::push_out(slot, line.bytes())
                {
                    self.dropped_slow += 1;
                    self.close(i);
                }
            }
        }
    }

    /// Send one status-stream sample to every subscriber (dropped for a client whose
    /// output is backed up).
    pub fn status_stream(&mut self) {
        if !self
            .slots
            .iter()
            .any(|s| s.subscribed && s.stream.is_some())
        {
            return;
        }
        let shared = &self.shared;
        let commanded = shared.commanded_pulses();
        let mut joints = [0.0; MAX_AXES];
        for (i, a) in self.robot.axes().iter().enumerate() {
            joints[i] = a.pulses_to_units(commanded[i]);
        }
        let tcp = self.robot.forward(&joints);
        let owner = SourceId(shared.owner.load(Ordering::Acquire));
        let name = source_name(owner);
        let owner_name = name.as_ref().map(FixedText::as_str);
        let status = StatusBody {
            state: shared.state(),
            homed: shared.homed.load(Ordering::Acquire),
            speed_pct: f64::from(shared.speed_pct.load(Ordering::Acquire)),
            owner: owner_name,
            err: Code::from_number(shared.error_code.load(Ordering::Acquire) as u16),
        };
        let position = WhereBody {
            joints: &joints[..self.robot.axis_count()],
            tcp,
        };
        let at = shared.program_line.load(Ordering::Acquire);
        let program_line = (at != 0).then_some(((at >> 32) as u16, at as u32));
        for slot in self
            .slots
            .iter_mut()
            .filter(|s| s.subscribed && s.stream.is_some())
        {
            let line = self.buf.event(
                slot.checksum,
                &Event::Status {
                    status,
                    position,
                    program_line,
                },
            );
            if slot.out_len + line.len() <= slot.out.len() / 2 {
                let _ = Self::push_out(slot, line);
            }
        }
    }

    /// Write what is queued for each client, without blocking.
    pub fn flush(&mut self) {
        self.write_out(true);
    }

    /// Write what is queued for the clients whose last write took everything; a client
    /// that is backed up (it does not read) waits for [`ClientSet::flush`] on the period, so
    /// event cycles make no write calls that are bound to fail.
    pub fn flush_new(&mut self) {
        self.write_out(false);
    }

    fn write_out(&mut self, backed_up_too: bool) {
        for i in 0..self.slots.len() {
            let slot = &mut self.slots[i];
            if slot.out_len == 0 || (slot.backed_up && !backed_up_too) {
                continue;
            }
            if !Self::send_queued(slot) {
                self.close(i);
            }
        }
    }

    /// Write as much of `slot`'s queued output as its socket takes now (no blocking), keep
    /// the rest; `false` when the connection failed.
    fn send_queued(slot: &mut Slot) -> bool {
        let Some(stream) = slot.stream.as_mut() else {
            return true;
        };
        let mut sent = 0;
        while sent < slot.out_len {
            match stream.write(&slot.out[sent..slot.out_len]) {
                Ok(0) => break,
                Ok(n) => sent += n,
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(_) => return false,
            }
        }
        slot.out.copy_within(sent..slot.out_len, 0);
        slot.out_len -= sent;
        slot.backed_up = slot.out_len > 0;
        true
    }
}

/// Route one parsed request; returns a reply to send at once, if any.
fn route<'b>(
    slot: &mut Slot,
    request: Request,
    routes: &Routes,
    buf: &'b mut ReplyBuf,
) -> Option<&'b [u8]> {
    let to = request.reply_to();
    match request.command {
        Command::Stop | Command::Estop => {
            let urgent = if matches!(request.command, Command::Stop) {
                Urgent::Stop(slot.source, to)
            } else {
                Urgent::Estop(slot.source, to)
            };
            // Emergency first: wake the Command Interpreter's urgent path now.
            if routes.urgent.try_send(urgent).is_ok() {
                routes.wake.post();
                None
            } else {
                Some(buf.nak(
                    to,
                    Code::Busy,
                    "too many emergency requests at once; repeat it",
                ))
            }
        }
        Command::Subscribe => {
            slot.subscribed = true;
            Some(buf.ack(to, ""))
        }
        Command::Unsubscribe => {
            slot.subscribed = false;
            Some(buf.ack(to, ""))
        }
        Command::Upload(name) => {
            let from = slot.source;
            if routes
                .store
                .try_send(StoreRequest::Begin { from, to, name })
                .is_ok()
            {
                // No reply now: the program's lines follow, the reply comes after `.`.
                slot.uploading = true;
                None
            } else {
                Some(buf.nak(to, Code::Busy, "the program store is busy; repeat UPLOAD"))
            }
        }
        Command::Programs
        | Command::Run { .. }
        | Command::Points(_)
        | Command::Point { .. }
        | Command::Delete(_)
        | Command::Robot
        | Command::Tasks
        | Command::TraceSave(_)
        | Command::Stn
        | Command::Teach(_)
        | Command::Wafers
        | Command::Get { .. }
        | Command::Put { .. }
        | Command::Swap { .. }
        | Command::Map(_)
        | Command::Recovery
        | Command::Sense(_)
        | Command::Confirm(_) => {
            let from = slot.source;
            let request = match request.command {
                Command::Run { name, step } => StoreRequest::Run {
                    from,
                    to,
                    name,
                    step,
                },
                Command::Points(program) => StoreRequest::Points { from, to, program },
                Command::Point {
                    program,
                    point,
                    action,
                } => StoreRequest::Point {
                    from,
                    to,
                    program,
                    point,
                    action,
                },
                Command::Delete(name) => StoreRequest::Delete { from, to, name },
                Command::Robot => StoreRequest::Robot { from, to },
                Command::Tasks => StoreRequest::Tasks { from, to },
                Command::TraceSave(name) => StoreRequest::TraceSave { from, to, name },
                Command::Stn => StoreRequest::Stn { from, to },
                Command::Teach(name) => StoreRequest::Teach { from, to, name },
                Command::Wafers => StoreRequest::Wafers { from, to },
                Command::Recovery => StoreRequest::Recovery { from, to },
                Command::Sense(blade) => StoreRequest::Sense { from, to, blade },
                Command::Confirm(arg) => StoreRequest::Confirm { from, to, arg },
                Command::Get {
                    station,
                    slot,
                    blade,
                } => StoreRequest::Job {
                    from,
                    to,
                    kind: JobKind::Get,
                    station,
                    slot,
                    blade,
                },
                Command::Put {
                    station,
                    slot,
                    blade,
                } => StoreRequest::Job {
                    from,
                    to,
                    kind: JobKind::Put,
                    station,
                    slot,
                    blade,
                },
                Command::Swap { station, slot } => StoreRequest::Job {
                    from,
                    to,
                    kind: JobKind::Swap,
                    station,
                    slot,
                    blade: wrc_cell::Blade::A,
                },
                Command::Map(station) => StoreRequest::Job {
                    from,
                    to,
                    kind: JobKind::Map,
                    station,
                    slot: 0,
                    blade: wrc_cell::Blade::A,
                },
                _ => StoreRequest::List { from, to },
            };
            match routes.store.try_send(request) {
                Ok(()) => None,
                Err(_) => Some(buf.nak(to, Code::Busy, "the program store is busy; repeat it")),
            }
        }
        _ => match routes
            .incoming
            .try_send(Incoming::Request(slot.source, request))
        {
            Ok(()) => None,
            Err(_) => Some(buf.nak(to, Code::Busy, "the controller is busy; repeat the request")),
        },
    }
}

/// `AUTH <token>` on `slot`: the control token lifts a token-guarded connection to command;
/// a wrong one is refused on any connection (and counts towards [`MAX_AUTH_FAILURES`]); a
/// connection that commands where no token is configured is told it needs none.
fn authenticate<'b>(
    slot: &mut Slot,
    token: &wrc_protocol::AuthToken,
    access: Option<&HostAccess>,
    to: wrc_protocol::ReplyTo,
    buf: &'b mut ReplyBuf,
) -> &'b [u8] {
    let configured = access.is_some_and(HostAccess::has_token);
    if slot.rights == Rights::Monitor {
        buf.nak(
            to,
            Code::AuthFailed,
            "this connection's address may only monitor; no token changes that",
        )
    } else if !configured {
        buf.ack(to, "rights=command")
    } else if access.is_some_and(|a| a.token_matches(token)) {
        slot.rights = Rights::Command;
        slot.auth_failures = 0;
        buf.ack(to, "rights=command")
    } else {
        slot.auth_failures = slot.auth_failures.saturating_add(1);
        buf.nak(to, Code::AuthFailed, "wrong token")
    }
}

/// A request line as the trace recorder keeps it: an `AUTH` line without its token.
fn redacted(line: &[u8]) -> &[u8] {
    let mut words = line.split(|b| *b == b' ').filter(|w| !w.is_empty());
    let first = words.next().unwrap_or_default();
    let verb = if !first.is_empty() && first.iter().all(u8::is_ascii_digit) {
        words.next().unwrap_or_default()
    } else {
        first
    };
    if verb.eq_ignore_ascii_case(b"AUTH") {
        b"AUTH <token not recorded>"
    } else {
        line
    }
}

/// One line inside `UPLOAD`: program text for the store, or `.` to end it. A refused line
/// (too long, or the store's queue full) cancels the upload with a NAK; nothing is stored.
fn upload_line<'b>(
    from: SourceId,
    uploading: &mut bool,
    line: Result<&[u8], wrc_protocol::LineError>,
    routes: &Routes,
    buf: &'b mut ReplyBuf,
) -> Option<&'b [u8]> {
    let request = match line {
        Ok(b".") => StoreRequest::End { from },
        Ok(text) => StoreRequest::line(from, text),
        Err(e) => {
            *uploading = false;
            let _ = routes.store.try_send(StoreRequest::Cancel { from });
            return Some(buf.nak(
                wrc_protocol::ReplyTo::default(),
                e.code(),
                format_args!("{e}; the upload is cancelled, nothing stored"),
            ));
        }
    };
    if matches!(request, StoreRequest::End { .. }) {
        *uploading = false;
    }
    if routes.store.try_send(request).is_err() {
        *uploading = false;
        let _ = routes.store.try_send(StoreRequest::Cancel { from });
        return Some(buf.nak(
            wrc_protocol::ReplyTo::default(),
            Code::Busy,
            "the program store is busy; the upload is cancelled, nothing stored",
        ));
    }
    None
}

/// A source's name (`tcp3`, `gui0`, `pendant`), formatted without allocating; `None` for
/// nobody.
pub fn source_name(source: SourceId) -> Option<FixedText<24>> {
    if source == SourceId::NONE {
        return None;
    }
    let mut name = FixedText::new();
    let _ = write!(name, "{source}");
    Some(name)
}

#[cfg(test)]
mod tests {
    use super::redacted;

    #[test]
    fn the_recorder_never_keeps_a_token() {
        for line in [
            &b"AUTH s3cret-token-0123456789"[..],
            b"12 auth s3cret-token-0123456789",
            b"  7   Auth  s3cret",
            b"AUTH",
        ] {
            assert_eq!(redacted(line), b"AUTH <token not recorded>");
        }
        for line in [&b"STATUS"[..], b"12 MOVJ 1 2 3 4", b"AUTHOR", b"", b"12"] {
            assert_eq!(redacted(line), line);
        }
    }
}
