//! `wrc bench controller`: the controller's latencies, measured on this machine with a
//! simulated board, first with one client and then while many TCP clients poll STATUS —
//! request to reply, motion request to first pulse, ESTOP to first decelerating pulse (as
//! the controller pushes it, and as the simulator stream shows it) — and the Pulse
//! Generator's wake-up jitter in both conditions.

use std::io::{BufRead, BufReader, Write};
use std::net::{SocketAddr, TcpStream, UdpSocket};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use clap::Args;
use wrc_config::Config;
use wrc_controller::controller::{self, CellFiles, Options, Running};
use wrc_controller::shared::{Shared, StopTally};
use wrc_protocol::sim_stream;
use wrc_robot::MAX_AXES;
use wrc_rt::RealtimeMode;

/// Arguments of `wrc bench controller`.
#[derive(Debug, Args)]
pub struct ControllerArgs {
    /// Requests of each kind timed in each condition (SPEED, STATUS, a refused MOVJ, a
    /// refused GET: four times this many requests).
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    runs: u32,
    /// Motion + ESTOP runs in each condition (a long MOVJ, an ESTOP in its cruise, a RESET:
    /// about 1 s each; 100 runs keep the whole bench near 4 minutes).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=1000))]
    stop_runs: u32,
    /// Length of each jitter window [s].
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..=3600))]
    seconds: u64,
    /// TCP clients polling STATUS in the loaded condition.
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(1..=250))]
    clients: u32,
    /// Write the figures as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Do not ask for SCHED_FIFO.
    #[arg(long)]
    no_rt: bool,
}

/// Goal: request received → reply written, p99 [ms].
const REPLY_GOAL_MS: f64 = 2.0;
/// Goal: motion request → first moving pulse, p99 [Pulse Generator periods].
const FIRST_PULSE_GOAL_PERIODS: f64 = 2.0;
/// Goal: ESTOP read → first decelerating pulse, p99 [Pulse Generator periods].
const ESTOP_READ_GOAL_PERIODS: f64 = 1.0;
/// Goal: ESTOP sent → first decelerating datagram of the simulator stream, p99 [periods].
const ESTOP_STREAM_GOAL_PERIODS: f64 = 2.0;

/// The two ends of the ESTOP runs' joint moves; each run heads for the one farther from
/// J1's position, at least 170° away, so J1 cruises at its full 180 °/s from ~0.35 s after
/// the start to at least ~0.95 s. The arm is folded (J2 150°), short of every station of
/// the demo cell at any height: the move goes straight, as asked (a route round the cell
/// through the travel height would move other axes first), and so does its brake.
const FAR_MOVES: [&str; 2] = ["MOVJ 170 150 -60 150", "MOVJ -170 150 60 20"];
/// ESTOP is sent this long after the move's first pulse, plus up to [`ESTOP_SPREAD_MS`]
/// (spread over the Pulse Generator's grid): in the cruise of J1 [ms].
const ESTOP_AFTER_FIRST_PULSE_MS: u64 = 450;
/// See [`ESTOP_AFTER_FIRST_PULSE_MS`] [ms].
const ESTOP_SPREAD_MS: u64 = 150;
/// A deceleration in the simulator stream counts when the increment also shrinks in this
/// many following datagrams (a one-datagram dip is rounding, not braking).
const DECEL_CONFIRM: usize = 2;

/// A host connection of the bench.
pub(crate) struct Host {
    reader: BufReader<TcpStream>,
    writer: TcpStream,
}

impl Host {
    pub(crate) fn connect(addr: SocketAddr) -> anyhow::Result<Host> {
        let s = TcpStream::connect(addr)?;
        s.set_read_timeout(Some(Duration::from_secs(30)))?;
        s.set_nodelay(true)?;
        Ok(Host {
            reader: BufReader::new(s.try_clone()?),
            writer: s,
        })
    }
    pub(crate) fn send(&mut self, line: &str) -> anyhow::Result<()> {
        self.writer.write_all(format!("{line}\n").as_bytes())?;
        Ok(())
    }
    fn read_line(&mut self) -> anyhow::Result<String> {
        let mut l = String::new();
        if self.reader.read_line(&mut l)? == 0 {
            bail!("the controller closed the connection");
        }
        Ok(l.trim_end().to_string())
    }
    /// Read until a non-event line starting with one of `kinds`.
    pub(crate) fn expect(&mut self, kinds: &[&str]) -> anyhow::Result<String> {
        loop {
            let l = self.read_line()?;
            if kinds.iter().any(|k| l.starts_with(k)) {
                return Ok(l);
            }
            if l.starts_with("NAK") {
                bail!("unexpected reply: {l}");
            }
        }
    }
    /// Read until the reply to request `id` whose first word is one of `words` (`ACK`,
    /// `NAK`, `INF`, `ABS`); other lines (events, other requests' replies) are skipped.
    fn reply_to(&mut self, id: u32, words: &[&str]) -> anyhow::Result<String> {
        loop {
            let l = self.read_line()?;
            let mut w = l.split_whitespace();
            if let (Some(word), Some(n)) = (w.next(), w.next()) {
                if words.contains(&word) && n.parse::<u32>().ok() == Some(id) {
                    return Ok(l);
                }
            }
        }
    }
    /// Send `line` as request `id` and wait for its first reply (`ACK` or `NAK`); returns
    /// the reply and the time from the write to the reply line read.
    fn request(&mut self, id: u32, line: &str) -> anyhow::Result<(String, Duration)> {
        let t0 = Instant::now();
        self.send(&format!("{id} {line}"))?;
        let reply = self.reply_to(id, &["ACK", "NAK"])?;
        Ok((reply, t0.elapsed()))
    }
    /// Send `line` as request `id`; its ACK, or an error if it was refused.
    fn accepted(&mut self, id: u32, line: &str) -> anyhow::Result<String> {
        let (reply, _) = self.request(id, line)?;
        if !reply.starts_with("ACK") {
            bail!("`{line}` was refused: {reply}");
        }
        Ok(reply)
    }
}

/// The controller of `wrc up` on the simulated board in `dir`, with the demo cell (its
/// stations and wafer map in `dir`), the host protocol on a free loopback port and the
/// simulator stream sent to `sim_addr`.
fn start_controller(
    config: &Config,
    dir: &Path,
    sim_addr: SocketAddr,
    realtime: RealtimeMode,
) -> anyhow::Result<Running> {
    let options = Options {
        tcp: Some("127.0.0.1:0".parse().expect("address")),
        socket: None,
        sim_addr,
        serial: None,
        realtime,
        boards: vec![dir.join("board0.dpram")],
        board_wait: Duration::from_secs(10),
        programs: dir.join("programs"),
        traces: None,
        cell: Some(CellFiles {
            stations: dir.join("stations.toml"),
            wafers: dir.join("wafers.toml"),
        }),
    };
    controller::start(config, &options).context("the controller could not start")
}

/// p50, p99 and max of some samples (nearest rank: with fewer than 100 samples the p99 is
/// the max).
#[derive(Debug, Default, Clone, Copy)]
struct Summary {
    n: usize,
    p50: f64,
    p99: f64,
    max: f64,
}

impl Summary {
    fn of(samples: &[f64]) -> Summary {
        let mut v = samples.to_vec();
        if v.is_empty() {
            return Summary::default();
        }
        v.sort_by(f64::total_cmp);
        let rank = |q: f64| ((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
        Summary {
            n: v.len(),
            p50: v[rank(0.5)],
            p99: v[rank(0.99)],
            max: v[v.len() - 1],
        }
    }

    fn scaled(self, by: f64) -> Summary {
        Summary {
            p50: self.p50 * by,
            p99: self.p99 * by,
            max: self.max * by,
            ..self
        }
    }

    fn json(self) -> serde_json::Value {
        serde_json::json!({"n": self.n, "p50": self.p50, "p99": self.p99, "max": self.max})
    }
}

/// Wait until `atomic` holds a value above `after`; returns it.
fn wait_for(atomic: &AtomicU64, after: u64, timeout: Duration) -> Option<u64> {
    let deadline = Instant::now() + timeout;
    while Instant::now() < deadline {
        let v = atomic.load(Ordering::Acquire);
        if v > after {
            return Some(v);
        }
        std::thread::sleep(Duration::from_micros(200));
    }
    None
}

/// Sleep until [`Shared::now_ns`] reaches `t_ns`.
fn sleep_until_ns(t_ns: u64) {
    let now = Shared::now_ns();
    if t_ns > now {
        std::thread::sleep(Duration::from_nanos(t_ns - now));
    }
}

/// Pulse Generator wake-up latency p99 and max [µs] of a running controller.
fn pg_latency(running: &Running) -> (f64, f64) {
    let stats = running.task_stats();
    let pg = stats.iter().find(|t| t.spec.name == "pulse_generator");
    match pg {
        Some(t) => (
            t.stats.latency.quantile_ns(0.99).unwrap_or(0) as f64 / 1000.0,
            t.stats.latency.max_ns().unwrap_or(0) as f64 / 1000.0,
        ),
        None => (0.0, 0.0),
    }
}

/// Run `measure` with a simulated board (`wrc board-sim`) on `DIR/board0.dpram` in a fresh
/// temporary directory `wrc-bench-<name>-<pid>`; the board and the directory are removed
/// afterwards, whatever `measure` returns.
pub(crate) fn on_simulated_board<T>(
    name: &str,
    measure: impl FnOnce(&Path) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    on_simulated_board_process(name, |dir, _| measure(dir))
}

/// [`on_simulated_board`], also giving `measure` the board process's id.
fn on_simulated_board_process<T>(
    name: &str,
    measure: impl FnOnce(&Path, u32) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    let dir = std::env::temp_dir().join(format!("wrc-bench-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let board = crate::up::spawn_board(
        None,
        0,
        &dir.join("board0.dpram"),
        &dir.join("board0.log"),
        None,
        false,
        None,
    )?;
    let pid = board.id();
    let mut children = vec![board];
    let result = measure(&dir, pid);
    crate::up::stop_children(&mut children);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

/// SCHED_FIFO priority of the bench's own timing threads and of the simulated board: the
/// lowest real-time priority, below every controller task and above the flood's clients
/// (normal threads). The board stands for a DSP card, which host load does not delay, and
/// the timing client for a host on another machine; at normal priority the flood starves
/// both on a small machine (the board's host watchdog trips).
const HARNESS_FIFO_PRIORITY: i32 = 1;

/// Put every thread of process `pid` on SCHED_FIFO at [`HARNESS_FIFO_PRIORITY`]; returns
/// how many threads it changed.
fn raise_process(pid: u32) -> std::io::Result<usize> {
    let mut raised = 0;
    for entry in std::fs::read_dir(format!("/proc/{pid}/task"))? {
        let Some(tid) = entry?
            .file_name()
            .to_str()
            .and_then(|t| t.parse::<libc::pid_t>().ok())
        else {
            continue;
        };
        let param = libc::sched_param {
            sched_priority: HARNESS_FIFO_PRIORITY,
        };
        // SAFETY: `param` is a valid sched_param on the stack that the call only reads; a
        // thread id that has gone away makes the call fail with ESRCH, nothing else.
        if unsafe { libc::sched_setscheduler(tid, libc::SCHED_FIFO, &param) } != 0 {
            return Err(std::io::Error::last_os_error());
        }
        raised += 1;
    }
    Ok(raised)
}

/// Put the calling thread on SCHED_FIFO at [`HARNESS_FIFO_PRIORITY`] when `on`.
fn raise_this_thread(on: bool) {
    if on {
        let _ = wrc_rt::sched_policy::set_current_thread_fifo(HARNESS_FIFO_PRIORITY);
    }
}

/// One datagram of the simulator stream as the bench received it.
#[derive(Debug, Clone, Copy)]
struct StreamSample {
    /// When the bench received it [ns, the clock of [`Shared::now_ns`]].
    arrival_ns: u64,
    /// The controller's sample time [ns, same clock].
    sample_ns: u64,
    sequence: u64,
    /// Encoder position of every axis [pulse].
    pulses: [i64; MAX_AXES],
}

/// Receives the controller's simulator stream on a loopback UDP port and keeps the
/// datagrams that arrive while recording.
struct StreamListener {
    addr: SocketAddr,
    recording: Arc<AtomicBool>,
    samples: Arc<Mutex<Vec<StreamSample>>>,
    quit: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl StreamListener {
    /// Listen on a free loopback port; `fifo`: the receiving thread runs under SCHED_FIFO
    /// (see [`HARNESS_FIFO_PRIORITY`]).
    fn bind(fifo: bool) -> anyhow::Result<StreamListener> {
        let socket = UdpSocket::bind("127.0.0.1:0").context("cannot bind a UDP port")?;
        socket.set_read_timeout(Some(Duration::from_millis(50)))?;
        let addr = socket.local_addr()?;
        let recording = Arc::new(AtomicBool::new(false));
        let samples = Arc::new(Mutex::new(Vec::new()));
        let quit = Arc::new(AtomicBool::new(false));
        let thread = {
            let (recording, samples, quit) = (recording.clone(), samples.clone(), quit.clone());
            std::thread::spawn(move || {
                raise_this_thread(fifo);
                let mut buf = [0u8; sim_stream::MAX_DATAGRAM_LEN];
                while !quit.load(Ordering::Acquire) {
                    let Ok(len) = socket.recv(&mut buf) else {
                        continue;
                    };
                    let arrival_ns = Shared::now_ns();
                    if !recording.load(Ordering::Acquire) {
                        continue;
                    }
                    if let Ok(f) = sim_stream::decode(&buf[..len]) {
                        samples.lock().expect("stream samples").push(StreamSample {
                            arrival_ns,
                            sample_ns: f.timestamp_ns,
                            sequence: f.sequence,
                            pulses: f.pulses,
                        });
                    }
                }
            })
        };
        Ok(StreamListener {
            addr,
            recording,
            samples,
            quit,
            thread: Some(thread),
        })
    }

    fn start_recording(&self) {
        self.samples.lock().expect("stream samples").clear();
        self.recording.store(true, Ordering::Release);
    }

    fn stop_recording(&self) -> Vec<StreamSample> {
        self.recording.store(false, Ordering::Release);
        std::mem::take(&mut *self.samples.lock().expect("stream samples"))
    }
}

impl Drop for StreamListener {
    fn drop(&mut self) {
        self.quit.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Where an ESTOP shows in the simulator stream.
#[derive(Debug, Clone, Copy)]
struct StreamBrake {
    /// The first decelerating datagram.
    sample: StreamSample,
    /// The moving axis's increment was steady (cruise) over the datagrams before the send.
    in_cruise: bool,
}

/// The first datagram that arrived after `sent_ns` whose per-period increment of the moving
/// axis (the one with the largest increment before the send) is smaller in magnitude than
/// the previous datagram's, the increment shrinking again in the [`DECEL_CONFIRM`]
/// datagrams after it. Increments are divided by the sequence step (a lost datagram).
fn stream_brake(samples: &[StreamSample], sent_ns: u64) -> Option<StreamBrake> {
    let before = samples
        .iter()
        .take_while(|s| s.arrival_ns <= sent_ns)
        .count();
    if before < 4 {
        return None;
    }
    let increment = |k: usize, axis: usize| -> f64 {
        let (a, b) = (&samples[k - 1], &samples[k]);
        let steps = b.sequence.saturating_sub(a.sequence).max(1);
        (b.pulses[axis] - a.pulses[axis]) as f64 / steps as f64
    };
    let axis = (0..MAX_AXES)
        .max_by(|&i, &j| {
            increment(before - 1, i)
                .abs()
                .total_cmp(&increment(before - 1, j).abs())
        })
        .unwrap_or(0);
    let speed = |k: usize| increment(k, axis).abs();
    let cruise = speed(before - 1);
    let in_cruise = cruise > 0.0
        && (1..=3).all(|back| (speed(before - back) - cruise).abs() <= 2.0 + cruise * 0.002);
    (before..samples.len().saturating_sub(DECEL_CONFIRM))
        .find(|&k| (0..=DECEL_CONFIRM).all(|j| speed(k + j) < speed(k + j - 1)))
        .map(|k| StreamBrake {
            sample: samples[k],
            in_cruise,
        })
}

/// A request whose time to reply is measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum RequestKind {
    Speed,
    Status,
    RefusedMove,
    RefusedGet,
}

impl RequestKind {
    const ALL: [RequestKind; 4] = [
        RequestKind::Speed,
        RequestKind::Status,
        RequestKind::RefusedMove,
        RequestKind::RefusedGet,
    ];

    /// The request line, without its id.
    fn line(self) -> &'static str {
        match self {
            RequestKind::Speed => "SPEED 100",
            RequestKind::Status => "STATUS",
            // J1 reaches ±180°.
            RequestKind::RefusedMove => "MOVJ 200 90 0 0",
            // The demo cell starts unmapped: refused before anything moves.
            RequestKind::RefusedGet => "GET LP2 1",
        }
    }

    /// What the reply must be, for the table.
    fn expected(self) -> &'static str {
        match self {
            RequestKind::Speed | RequestKind::Status => "ACK",
            RequestKind::RefusedMove => "NAK 112",
            RequestKind::RefusedGet => "NAK 13x",
        }
    }

    /// The reply's code when it is the expected one (0 for an `ACK`).
    fn check(self, reply: &str) -> Option<u32> {
        let mut w = reply.split_whitespace();
        let word = w.next()?;
        let code = w.nth(1).and_then(|c| c.parse::<u32>().ok());
        match (self, word, code) {
            (RequestKind::Speed | RequestKind::Status, "ACK", _) => Some(0),
            (RequestKind::RefusedMove, "NAK", Some(112)) => Some(112),
            (RequestKind::RefusedGet, "NAK", Some(c @ 130..=139)) => Some(c),
            _ => None,
        }
    }
}

/// What one condition (idle or flooded) measured; times in [ms].
#[derive(Debug, Default)]
struct Condition {
    /// Request sent → reply line read, per [`RequestKind::ALL`].
    replies: [Vec<f64>; 4],
    /// The codes the refused GETs got.
    get_codes: Vec<u32>,
    /// MOVJ sent → first pulse pushed.
    first_pulse: Vec<f64>,
    /// ESTOP read by the controller → first decelerating pulse pushed.
    estop_read: Vec<f64>,
    /// ESTOP sent → first decelerating pulse pushed.
    estop_pushed: Vec<f64>,
    /// ESTOP sent → first decelerating datagram received.
    estop_stream: Vec<f64>,
    /// ESTOP sent → that datagram's sample time.
    estop_stream_sample: Vec<f64>,
    /// Runs in which the moving axis was not in cruise when ESTOP was sent.
    not_in_cruise: u32,
    /// Runs in which the stream showed no deceleration.
    no_stream_brake: u32,
    /// Runs in which the controller had not stamped the ESTOP's read time.
    read_unstamped: u32,
    /// How the controller's stops braked (its count from start-up: each condition has a
    /// controller of its own).
    stops: StopTally,
}

/// Counts request ids on one connection.
struct Ids(u32);

impl Ids {
    fn next(&mut self) -> u32 {
        self.0 += 1;
        self.0
    }
}

/// Clear any error and home the robot.
fn prepare(host: &mut Host, ids: &mut Ids) -> anyhow::Result<()> {
    host.accepted(ids.next(), "RESET")?;
    let id = ids.next();
    host.accepted(id, "HOME")?;
    let end = host.reply_to(id, &["INF", "ABS"])?;
    if !end.starts_with("INF") {
        bail!("HOME did not finish: {end}");
    }
    Ok(())
}

/// Sleep a part of `period` that changes with `n` (steps of 3.719 ms modulo the period), so
/// that successive requests fall at different phases of the tasks' common grid instead of
/// locking to it.
fn spread_over_grid(n: u64, period: Duration) {
    let period_us = period.as_micros().max(1) as u64;
    std::thread::sleep(Duration::from_micros(n * 3_719 % period_us));
}

/// `runs` requests of each kind, interleaved, each after a pause that spreads them over the
/// Pulse Generator's grid.
fn measure_replies(
    host: &mut Host,
    ids: &mut Ids,
    runs: u32,
    period: Duration,
    out: &mut Condition,
) -> anyhow::Result<()> {
    for run in 0..runs {
        for (k, kind) in RequestKind::ALL.into_iter().enumerate() {
            spread_over_grid(u64::from(run) * 4 + k as u64, period);
            let (reply, took) = host.request(ids.next(), kind.line())?;
            let Some(code) = kind.check(&reply) else {
                bail!(
                    "`{}` got `{reply}`; the bench expects {}",
                    kind.line(),
                    kind.expected()
                );
            };
            if kind == RequestKind::RefusedGet && !out.get_codes.contains(&code) {
                out.get_codes.push(code);
            }
            out.replies[k].push(took.as_secs_f64() * 1e3);
        }
    }
    Ok(())
}

/// One long MOVJ, an ESTOP in its cruise, a RESET.
fn stop_run(
    host: &mut Host,
    ids: &mut Ids,
    shared: &Shared,
    stream: &StreamListener,
    run: u32,
    period: Duration,
    out: &mut Condition,
) -> anyhow::Result<()> {
    // Towards the end farther from J1's position: at least 170° of travel.
    let target = FAR_MOVES[usize::from(shared.commanded[0].load(Ordering::Acquire) > 0)];
    stream.start_recording();
    // Not locked to the RESET's reply, which comes on the grid.
    spread_over_grid(u64::from(run), period);
    let id = ids.next();
    let t0 = Shared::now_ns();
    let ack = host.accepted(id, target)?;
    let first = wait_for(&shared.first_pulse_ns, t0, Duration::from_secs(5))
        .with_context(|| format!("no pulse within 5 s of `{target}` ({ack})"))?;
    out.first_pulse.push((first - t0) as f64 / 1e6);
    let delay_ms = ESTOP_AFTER_FIRST_PULSE_MS + u64::from(run) * 37 % ESTOP_SPREAD_MS;
    sleep_until_ns(first + delay_ms * 1_000_000);

    let t1 = Shared::now_ns();
    host.send(&format!("{} ESTOP", ids.next()))?;
    let Some(decel) = wait_for(&shared.decel_ns, t1, Duration::from_secs(5)) else {
        // What the controller said meanwhile: how the move ended, and why.
        let mut said = Vec::new();
        while let Ok(l) = host.read_line() {
            said.push(l);
            if said.len() >= 12 || said.last().is_some_and(|l| l.starts_with("ACK")) {
                break;
            }
        }
        bail!(
            "no deceleration within 5 s of an ESTOP {delay_ms} ms into `{target}` ({ack}, run {run}); the controller said: {said:?}"
        );
    };
    let read = shared.urgent_read_ns.load(Ordering::Acquire);
    if read < t1 {
        out.read_unstamped += 1;
    }
    let read = read.max(t1);
    out.estop_read.push(decel.saturating_sub(read) as f64 / 1e6);
    out.estop_pushed.push((decel - t1) as f64 / 1e6);
    let end = host.reply_to(id, &["INF", "ABS"])?;
    if end.starts_with("INF") {
        bail!("`{target}` finished before the ESTOP reached it: {end}");
    }
    // Until the robot stands, and a few more datagrams.
    let deadline = Instant::now() + Duration::from_secs(5);
    while shared.in_flight.load(Ordering::Acquire) != 0 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(50));
    let samples = stream.stop_recording();
    match stream_brake(&samples, t1) {
        Some(b) => {
            out.estop_stream
                .push(b.sample.arrival_ns.saturating_sub(t1) as f64 / 1e6);
            out.estop_stream_sample
                .push((b.sample.sample_ns as f64 - t1 as f64) / 1e6);
            out.not_in_cruise += u32::from(!b.in_cruise);
        }
        None => out.no_stream_brake += 1,
    }
    host.accepted(ids.next(), "RESET")?;
    Ok(())
}

/// What a condition's measurements need.
struct Bench<'a> {
    args: &'a ControllerArgs,
    stream: &'a StreamListener,
    period: Duration,
    /// The timing thread runs under SCHED_FIFO.
    fifo: bool,
}

/// Every latency of one condition on a started controller, timed from a thread of its own
/// (under SCHED_FIFO when `bench.fifo`).
fn measure_condition(bench: &Bench, running: &Running, what: &str) -> anyhow::Result<Condition> {
    let addr = running.tcp.context("no TCP port")?;
    let shared = running.shared().clone();
    let mut condition = std::thread::scope(|scope| {
        scope
            .spawn(|| {
                raise_this_thread(bench.fifo);
                measure_from_client(bench, addr, &shared, what)
            })
            .join()
            .unwrap_or_else(|_| Err(anyhow::anyhow!("the timing thread panicked")))
    })?;
    condition.stops = shared.stops.read();
    Ok(condition)
}

fn measure_from_client(
    bench: &Bench,
    addr: SocketAddr,
    shared: &Shared,
    what: &str,
) -> anyhow::Result<Condition> {
    let (args, stream, period) = (bench.args, bench.stream, bench.period);
    let mut out = Condition::default();
    let mut host = Host::connect(addr)?;
    let mut ids = Ids(0);
    prepare(&mut host, &mut ids)?;
    eprintln!("{what}: {} requests of each of 4 kinds …", args.runs);
    measure_replies(&mut host, &mut ids, args.runs, period, &mut out)?;
    eprintln!("{what}: {} MOVJ + ESTOP runs …", args.stop_runs);
    for run in 0..args.stop_runs {
        stop_run(&mut host, &mut ids, shared, stream, run, period, &mut out)?;
    }
    Ok(out)
}

/// TCP clients each looping STATUS → ACK.
struct Flood {
    quit: Arc<AtomicBool>,
    polls: Arc<AtomicU64>,
    threads: Vec<JoinHandle<anyhow::Result<()>>>,
}

/// What the flood's clients did.
struct FloodReport {
    polls: u64,
    failed: u32,
    first_error: Option<String>,
}

impl Flood {
    fn start(addr: SocketAddr, clients: u32) -> Flood {
        let quit = Arc::new(AtomicBool::new(false));
        let polls = Arc::new(AtomicU64::new(0));
        let threads = (0..clients)
            .map(|_| {
                let (quit, polls) = (quit.clone(), polls.clone());
                std::thread::spawn(move || -> anyhow::Result<()> {
                    let mut h = Host::connect(addr)?;
                    while !quit.load(Ordering::Acquire) {
                        h.send("STATUS")?;
                        h.expect(&["ACK"])?;
                        polls.fetch_add(1, Ordering::Relaxed);
                    }
                    Ok(())
                })
            })
            .collect();
        Flood {
            quit,
            polls,
            threads,
        }
    }

    fn stop(self) -> FloodReport {
        self.quit.store(true, Ordering::Release);
        let mut failed = 0;
        let mut first_error = None;
        for t in self.threads {
            match t.join() {
                Ok(Ok(())) => {}
                Ok(Err(e)) => {
                    failed += 1;
                    first_error.get_or_insert(e.to_string());
                }
                Err(_) => failed += 1,
            }
        }
        FloodReport {
            polls: self.polls.load(Ordering::Relaxed),
            failed,
            first_error,
        }
    }
}

/// Run `wrc bench controller`.
pub fn run(args: ControllerArgs) -> anyhow::Result<ExitCode> {
    let mut config = Config::embedded_default();
    // The flood's clients all come from 127.0.0.1: one address may hold every connection, or
    // each new client would close the least recently active one (docs/protocol.md
    // "Connections").
    config.host.max_per_address = config.host.max_connections;
    let realtime = if args.no_rt {
        RealtimeMode::Off
    } else {
        RealtimeMode::Auto
    };
    on_simulated_board_process("controller", |dir, board| {
        measure(&args, &config, dir, board, realtime)
    })
}

fn measure(
    args: &ControllerArgs,
    config: &Config,
    dir: &Path,
    board: u32,
    realtime: RealtimeMode,
) -> anyhow::Result<ExitCode> {
    let period = Duration::from_micros(
        config
            .tasks
            .get("pulse_generator")
            .map_or(10_000, |t| t.period_us),
    );

    // The bench's timing threads and the simulated board get SCHED_FIFO where allowed.
    let fifo = realtime == RealtimeMode::Auto
        && std::thread::spawn(|| {
            wrc_rt::sched_policy::set_current_thread_fifo(HARNESS_FIFO_PRIORITY).is_ok()
        })
        .join()
        .unwrap_or(false);
    let stream = StreamListener::bind(fifo)?;

    // 1. One client: the jitter window first, then the latencies, on one controller.
    let running = start_controller(config, dir, stream.addr, realtime)?;
    if let Some(s) = running.scheduling() {
        println!("wrc bench controller: {s}");
    }
    // The board is up (the controller waited for it), so all its threads exist.
    let harness = match (fifo, realtime) {
        (true, _) => raise_process(board).map(|_| ()).map_err(|e| e.to_string()),
        (false, RealtimeMode::Off) => Err("--no-rt".into()),
        (false, RealtimeMode::Auto) => Err("SCHED_FIFO not allowed".into()),
    };
    let harness = match harness {
        Ok(()) => format!(
            "the simulated board and the bench's timing threads at SCHED_FIFO \
             {HARNESS_FIFO_PRIORITY}, the flood's clients at normal priority"
        ),
        Err(why) => {
            format!("the simulated board and the bench's timing threads at normal priority ({why})")
        }
    };
    println!("harness: {harness}");
    eprintln!("jitter, no clients: {} s …", args.seconds);
    std::thread::sleep(Duration::from_secs(args.seconds));
    let idle_jitter = pg_latency(&running);
    let bench = Bench {
        args,
        stream: &stream,
        period,
        fifo,
    };
    let idle = measure_condition(&bench, &running, "one client");
    let _ = running.shutdown(Duration::from_secs(3));
    let idle = idle?;

    // 2. The same while many clients poll STATUS, on a fresh controller.
    let running = start_controller(config, dir, stream.addr, realtime)?;
    let flood = Flood::start(running.tcp.context("no TCP port")?, args.clients);
    eprintln!(
        "jitter, {} clients polling STATUS: {} s …",
        args.clients, args.seconds
    );
    std::thread::sleep(Duration::from_secs(args.seconds));
    let flood_jitter = pg_latency(&running);
    let flooded = measure_condition(
        &bench,
        &running,
        &format!("{} clients polling STATUS", args.clients),
    );
    let report = flood.stop();
    let _ = running.shutdown(Duration::from_secs(3));
    let flooded = flooded?;

    let table = Table::new(&idle, &flooded, period);
    table.print(args, &idle, &flooded, period);
    println!();
    println!("Pulse Generator wake-up latency [µs]     p99      max");
    println!(
        "no clients                          {:8.1} {:8.1}",
        idle_jitter.0, idle_jitter.1
    );
    println!(
        "{:3} clients polling STATUS         {:8.1} {:8.1}   ({} polls, {} clients failed)",
        args.clients, flood_jitter.0, flood_jitter.1, report.polls, report.failed
    );
    if let Some(path) = &args.json {
        let condition = |c: &Condition| {
            serde_json::json!({
                "not_in_cruise": c.not_in_cruise,
                "no_stream_deceleration": c.no_stream_brake,
                "estop_read_unstamped": c.read_unstamped,
                "stops_flushed": c.stops.flushed,
                "stops_behind_queue": c.stops.behind_queue,
                "refused_get_codes": c.get_codes,
            })
        };
        let json = serde_json::json!({
            "period_ms": period.as_secs_f64() * 1e3,
            "requests_per_kind": args.runs,
            "stop_runs": args.stop_runs,
            "clients": args.clients,
            "harness": harness,
            "rows": table.json(),
            "idle": condition(&idle),
            "flood": condition(&flooded),
            "pg_latency_idle_us": {"p99": idle_jitter.0, "max": idle_jitter.1},
            "pg_latency_clients_us": {
                "clients": args.clients, "polls": report.polls, "failed": report.failed,
                "p99": flood_jitter.0, "max": flood_jitter.1,
            },
        });
        std::fs::write(path, format!("{json:#}\n"))
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    if report.failed > 0 {
        bail!(
            "{} polling clients failed (first: {})",
            report.failed,
            report.first_error.unwrap_or_else(|| "a panic".into())
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// One row of the latency table.
struct Row {
    key: &'static str,
    label: String,
    unit: &'static str,
    idle: Summary,
    flood: Summary,
    /// The p99 goal in `unit`, if the row has one.
    goal: Option<f64>,
}

impl Row {
    fn verdict(&self) -> String {
        let Some(goal) = self.goal else {
            return String::new();
        };
        let unit = if self.unit == "ms" { " ms" } else { "" };
        let miss = |s: &Summary| s.n == 0 || s.p99 > goal;
        let v = match (miss(&self.idle), miss(&self.flood)) {
            (false, false) => "PASS",
            (true, false) => "FAIL (idle)",
            (false, true) => "FAIL (flood)",
            (true, true) => "FAIL",
        };
        format!("≤ {goal}{unit} {v}")
    }
}

/// The latency table: the four goals, idle and flooded.
struct Table {
    rows: Vec<Row>,
}

impl Table {
    fn new(idle: &Condition, flood: &Condition, period: Duration) -> Table {
        let per_period = 1.0 / (period.as_secs_f64() * 1e3);
        let mut rows = Vec::new();
        let mut all = (Vec::new(), Vec::new());
        for (k, kind) in RequestKind::ALL.into_iter().enumerate() {
            let mut codes: Vec<u32> = [&idle.get_codes, &flood.get_codes]
                .into_iter()
                .flatten()
                .copied()
                .collect();
            codes.sort_unstable();
            codes.dedup();
            let expected = match kind {
                RequestKind::RefusedGet if !codes.is_empty() => {
                    let codes: Vec<String> = codes.iter().map(u32::to_string).collect();
                    format!("NAK {}", codes.join("/"))
                }
                RequestKind::Speed
                | RequestKind::Status
                | RequestKind::RefusedMove
                | RequestKind::RefusedGet => kind.expected().to_string(),
            };
            rows.push(Row {
                key: ["speed", "status", "refused_movj", "refused_get"][k],
                label: format!("  {} → {expected}", kind.line()),
                unit: "ms",
                idle: Summary::of(&idle.replies[k]),
                flood: Summary::of(&flood.replies[k]),
                goal: Some(REPLY_GOAL_MS),
            });
            all.0.extend_from_slice(&idle.replies[k]);
            all.1.extend_from_slice(&flood.replies[k]);
        }
        rows.push(Row {
            key: "all_requests",
            label: "  all four kinds".into(),
            unit: "ms",
            idle: Summary::of(&all.0),
            flood: Summary::of(&all.1),
            goal: Some(REPLY_GOAL_MS),
        });
        let mut latency = |key: &'static str, label: &str, idle: &[f64], flood: &[f64]| {
            rows.push(Row {
                key,
                label: label.into(),
                unit: "ms",
                idle: Summary::of(idle),
                flood: Summary::of(flood),
                goal: None,
            });
        };
        latency(
            "movj_to_first_pulse",
            "2 MOVJ sent → first moving pulse pushed",
            &idle.first_pulse,
            &flood.first_pulse,
        );
        latency(
            "estop_read_to_decel",
            "3 ESTOP read (TCP) → first decelerating pulse",
            &idle.estop_read,
            &flood.estop_read,
        );
        latency(
            "estop_sent_to_stream_decel",
            "4 ESTOP sent → decelerating datagram received",
            &idle.estop_stream,
            &flood.estop_stream,
        );
        latency(
            "estop_sent_to_decel",
            "  (ESTOP sent → first decelerating pulse pushed)",
            &idle.estop_pushed,
            &flood.estop_pushed,
        );
        latency(
            "estop_sent_to_stream_sample",
            "  (ESTOP sent → that datagram's sample time)",
            &idle.estop_stream_sample,
            &flood.estop_stream_sample,
        );
        // Goals 2-4 in periods, each right under its row in milliseconds.
        for (key, goal) in [
            ("estop_sent_to_stream_decel", ESTOP_STREAM_GOAL_PERIODS),
            ("estop_read_to_decel", ESTOP_READ_GOAL_PERIODS),
            ("movj_to_first_pulse", FIRST_PULSE_GOAL_PERIODS),
        ] {
            let at = rows.iter().position(|r| r.key == key).expect("row");
            let ms = &rows[at];
            let row = Row {
                key,
                label: "  in periods".into(),
                unit: "periods",
                idle: ms.idle.scaled(per_period),
                flood: ms.flood.scaled(per_period),
                goal: Some(goal),
            };
            rows.insert(at + 1, row);
        }
        Table { rows }
    }

    fn print(&self, args: &ControllerArgs, idle: &Condition, flood: &Condition, period: Duration) {
        let period_ms = period.as_secs_f64() * 1e3;
        println!();
        println!(
            "{:50} {:^29}   {:^29}",
            format!("latency [ms] (periods of {period_ms} ms)"),
            "one client",
            format!("{} clients polling STATUS", args.clients)
        );
        println!(
            "{:50} {:>5} {:>7} {:>7} {:>7}   {:>5} {:>7} {:>7} {:>7}   goal (p99)",
            "", "n", "p50", "p99", "max", "n", "p50", "p99", "max"
        );
        println!("1 request sent → reply line received (client side)");
        for r in &self.rows {
            let cells = |s: Summary| {
                if s.n == 0 {
                    format!("{:>5} {:>7} {:>7} {:>7}", 0, "-", "-", "-")
                } else {
                    format!("{:>5} {:7.2} {:7.2} {:7.2}", s.n, s.p50, s.p99, s.max)
                }
            };
            println!(
                "{:50} {}   {}   {}",
                r.label,
                cells(r.idle),
                cells(r.flood),
                r.verdict()
            );
        }
        println!();
        println!(
            "1: {} requests of each kind per condition, interleaved, spread over the {period_ms} ms \
             grid; timed by the client on loopback from writing the request to reading its reply \
             line, an upper bound of the controller's request received → reply written.",
            args.runs
        );
        println!(
            "2-4: {} MOVJ + ESTOP runs per condition (each a move of J1 of at least 170°, an ESTOP \
             {}-{} ms after its first pulse, in cruise, and a RESET){}.",
            args.stop_runs,
            ESTOP_AFTER_FIRST_PULSE_MS,
            ESTOP_AFTER_FIRST_PULSE_MS + ESTOP_SPREAD_MS,
            if args.stop_runs < 100 {
                "; with fewer than 100 runs p99 is the max"
            } else {
                ""
            }
        );
        println!(
            "4: the first simulator datagram received after the ESTOP was sent whose per-period \
             encoder increment of the moving axis is smaller than the one before, and shrinks in \
             the {DECEL_CONFIRM} next datagrams too (runs not in cruise at the send: {} idle, {} \
             flood; no deceleration seen: {} idle, {} flood).",
            idle.not_in_cruise, flood.not_in_cruise, idle.no_stream_brake, flood.no_stream_brake
        );
        println!(
            "2-4: stops braked with a FIFO flush (the brake in the board's next period): {} idle, \
             {} flood; behind the queued periods (no flush): {} idle, {} flood.",
            idle.stops.flushed,
            flood.stops.flushed,
            idle.stops.behind_queue,
            flood.stops.behind_queue
        );
        if idle.read_unstamped + flood.read_unstamped > 0 {
            println!(
                "3: the controller did not stamp the ESTOP's read time in {} runs (counted from \
                 the send).",
                idle.read_unstamped + flood.read_unstamped
            );
        }
    }

    fn json(&self) -> serde_json::Value {
        let mut map = serde_json::Map::new();
        for r in &self.rows {
            let key = format!("{}_{}", r.key, r.unit);
            map.insert(
                key,
                serde_json::json!({
                    "idle": r.idle.json(),
                    "flood": r.flood.json(),
                    "goal_p99": r.goal,
                }),
            );
        }
        serde_json::Value::Object(map)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stream of J1 increments [pulse per period], one datagram every 10 ms from t = 0.
    fn stream(increments: &[i64]) -> Vec<StreamSample> {
        let mut position = 0;
        let mut out = vec![];
        for (k, inc) in std::iter::once(&0).chain(increments).enumerate() {
            position += inc;
            let mut pulses = [0; MAX_AXES];
            pulses[0] = position;
            pulses[1] = position / 3;
            let t = k as u64 * 10_000_000;
            out.push(StreamSample {
                arrival_ns: t + 50_000,
                sample_ns: t,
                sequence: k as u64,
                pulses,
            });
        }
        out
    }

    #[test]
    fn the_brake_is_the_first_decrease_that_continues() {
        // Cruise, a one-pulse rounding dip, cruise, then a jerk-limited brake.
        let s = stream(&[
            1800, 1800, 1800, 1800, 1800, 1799, 1800, 1800, 1799, 1794, 1782,
        ]);
        // Sent at 35 ms: the datagram of 60 ms (the dip) is not braking.
        let b = stream_brake(&s, 35_000_000).expect("a brake");
        assert_eq!(b.sample.sample_ns, 90_000_000);
        assert!(b.in_cruise);
    }

    #[test]
    fn a_brake_that_does_not_continue_is_not_found() {
        let s = stream(&[-1800, -1800, -1800, -1800, -1800, -1799, -1800, -1800]);
        assert!(stream_brake(&s, 35_000_000).is_none());
    }

    #[test]
    fn a_lost_datagram_counts_per_period() {
        let mut s = stream(&[1800, 1800, 1800, 1800, 1800, 1800, 1799, 1794, 1782]);
        // The datagram of 60 ms is lost: the next one's 3,599 pulses count over two periods.
        s.remove(6);
        let b = stream_brake(&s, 35_000_000).expect("a brake");
        assert_eq!(b.sample.sample_ns, 70_000_000);
    }

    #[test]
    fn accelerating_before_the_send_is_not_cruise() {
        let s = stream(&[600, 900, 1200, 1500, 1800, 1799, 1794, 1782]);
        let b = stream_brake(&s, 45_000_000).expect("a brake");
        assert!(!b.in_cruise);
        assert_eq!(b.sample.sample_ns, 60_000_000);
    }

    #[test]
    fn percentiles_are_nearest_rank() {
        let v: Vec<f64> = (1..=200).map(f64::from).collect();
        let s = Summary::of(&v);
        assert_eq!((s.n, s.p50, s.p99, s.max), (200, 100.0, 198.0, 200.0));
        let s = Summary::of(&v[..50]);
        assert_eq!((s.p50, s.p99, s.max), (25.0, 50.0, 50.0));
    }
}
