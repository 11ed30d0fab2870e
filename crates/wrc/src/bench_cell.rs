//! `wrc bench cell`: wafer throughput on the demo cell. Standard sequences of `GET`/`PUT`
//! (LP → LP, LP → AL → LP, LP → PM1 → LP, a swap at PM1 through the buffer, and a `SWAP` at
//! PM1 by the dual-blade robot of `config/dual-blade.toml`) run on a fresh
//! controller each, in virtual time by default (fast, deterministic) or on the real-time
//! controller (`--real-time`: `wrc up` on free loopback ports). Every figure comes from the
//! controller's own trace of the sequence (`TRACE SAVE`), so both modes are measured the
//! same way, on the controller's clock:
//!
//! - wafers per hour: wafers delivered / (last transfer's `INF` − first transfer's request);
//! - seconds per GET and per PUT: request read → its `INF`;
//! - moving vs waiting: the periods of a transfer in which a commanded position changed;
//! - the ratio of a transfer's time to its **reference**: the sum, over the transfer's
//!   motions, of the time-optimal rest-to-rest time of the same path with the same limits
//!   (a PTP: the slowest joint's jerk-limited time over its travel, which a synchronised PTP
//!   cannot beat; a straight line or Z move: the lower bound of `wrc_motion::reference`,
//!   TOPP-RA with joint and Cartesian velocity and acceleration and the 1-D jerk-limited
//!   times), each divided by the speed override in force (the station's `speed_pct` inside a
//!   station), plus the vacuum sensor's delay from the board's configuration after each
//!   vacuum change. A blended transfer may come under 1. A `SWAP`'s reference is its GET's
//!   and its PUT's, each with its blade's height offset.

use std::io::{BufRead, BufReader, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{bail, Context};
use clap::{Args, ValueEnum};
use serde_json::json;
use wrc_board::wrc_cell::{plan, Blade, Stations, Step, TransferKind, MAX_BLADES};
use wrc_config::Config;
use wrc_controller::messages::cell_job::JobKind;
use wrc_controller::simulation::{SimCellFrom, SimClient, Simulation};
use wrc_motion::reference::line_bound;
use wrc_motion::DoubleS;
use wrc_robot::{Joints, Posture, MAX_AXES};
use wrc_trace::{Direction, TraceFile};

use crate::up_process::{Up, UpOptions};

/// Arguments of `wrc bench cell`.
#[derive(Debug, Args)]
pub struct CellArgs {
    /// Wafers each sequence delivers (the swap needs one more in LP1).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u16).range(1..=24))]
    wafers: u16,
    /// Run on the real-time controller (`wrc up` on free loopback ports, SCHED_FIFO where
    /// the machine allows) instead of virtual time.
    #[arg(long, conflicts_with = "compare")]
    real_time: bool,
    /// Run every sequence both ways and print how far the real-time transfer times are
    /// from the virtual ones [Pulse Generator periods].
    #[arg(long)]
    compare: bool,
    /// Plan every transfer's motions from rest to rest (`[motion] blend = false`), to see
    /// what blending gains.
    #[arg(long)]
    rest_to_rest: bool,
    /// Only these sequences (comma-separated).
    #[arg(long, value_delimiter = ',', value_name = "SEQUENCE")]
    only: Vec<Sequence>,
    /// Also write the figures as JSON here.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

/// A standard sequence of the demo cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Sequence {
    /// LP1 slot n → LP2 slot n.
    LpLp,
    /// LP1 slot n → the aligner → LP2 slot n.
    LpAlLp,
    /// LP1 slot n → process module PM1 → LP2 slot n.
    LpPm1Lp,
    /// A swap at PM1 with one hand: the next wafer waits in the buffer BF1 while the
    /// processed one leaves PM1 for LP2, then goes into PM1.
    SwapPm1,
    /// A swap at PM1 by the dual-blade robot (`config/dual-blade.toml`): the next wafer
    /// rides on blade B, `SWAP PM1 1` takes the processed one with blade A and puts the next
    /// one, and blade A takes it to LP2.
    SwapPm1Dual,
}

impl Sequence {
    const ALL: [Sequence; 5] = [
        Sequence::LpLp,
        Sequence::LpAlLp,
        Sequence::LpPm1Lp,
        Sequence::SwapPm1,
        Sequence::SwapPm1Dual,
    ];

    /// The configuration it runs on: the embedded default, or the dual-blade example.
    fn config(self) -> Config {
        match self {
            Sequence::SwapPm1Dual => Config::embedded_dual_blade(),
            _ => Config::embedded_default(),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Sequence::LpLp => "LP1 → LP2",
            Sequence::LpAlLp => "LP1 → AL → LP2",
            Sequence::LpPm1Lp => "LP1 → PM1 → LP2",
            Sequence::SwapPm1 => "swap at PM1 (via BF1)",
            Sequence::SwapPm1Dual => "SWAP at PM1 (dual blade)",
        }
    }

    fn key(self) -> &'static str {
        match self {
            Sequence::LpLp => "lp-lp",
            Sequence::LpAlLp => "lp-al-lp",
            Sequence::LpPm1Lp => "lp-pm1-lp",
            Sequence::SwapPm1 => "swap-pm1",
            Sequence::SwapPm1Dual => "swap-pm1-dual",
        }
    }

    /// The untimed set-up (mapping, a first wafer into PM1 for the swap) and the timed
    /// transfers delivering `wafers` wafers.
    fn requests(self, wafers: u16) -> (Vec<String>, Vec<String>) {
        let mut setup = vec!["HOME".to_string()];
        let mut timed = Vec::new();
        let stations: &[&str] = match self {
            Sequence::LpLp => &["LP1", "LP2"],
            Sequence::LpAlLp => &["LP1", "LP2", "AL"],
            Sequence::LpPm1Lp => &["LP1", "LP2", "PM1"],
            Sequence::SwapPm1 => &["LP1", "LP2", "PM1", "BF1"],
            Sequence::SwapPm1Dual => &["LP1", "LP2", "PM1"],
        };
        setup.extend(stations.iter().map(|s| format!("MAP {s}")));
        for n in 1..=wafers {
            let through = match self {
                Sequence::LpLp => None,
                Sequence::LpAlLp => Some("AL"),
                Sequence::LpPm1Lp => Some("PM1"),
                Sequence::SwapPm1 => {
                    timed.extend([
                        format!("GET LP1 {}", n + 1),
                        "PUT BF1 1".to_string(),
                        "GET PM1 1".to_string(),
                        format!("PUT LP2 {n}"),
                        "GET BF1 1".to_string(),
                        "PUT PM1 1".to_string(),
                    ]);
                    continue;
                }
                Sequence::SwapPm1Dual => {
                    timed.extend([
                        format!("GET LP1 {} B", n + 1),
                        "SWAP PM1 1".to_string(),
                        format!("PUT LP2 {n}"),
                    ]);
                    continue;
                }
            };
            timed.push(format!("GET LP1 {n}"));
            if let Some(s) = through {
                timed.extend([format!("PUT {s} 1"), format!("GET {s} 1")]);
            }
            timed.push(format!("PUT LP2 {n}"));
        }
        if matches!(self, Sequence::SwapPm1 | Sequence::SwapPm1Dual) {
            setup.extend(["GET LP1 1".to_string(), "PUT PM1 1".to_string()]);
        }
        (setup, timed)
    }
}

/// A host session with a controller: requests with an id, answered by their final line.
trait Session {
    /// Send `id line` and return its first `ACK`/`NAK` with that id.
    fn ask(&mut self, id: u32, line: &str) -> anyhow::Result<String>;
    /// The next line with `id` that ends a motion (`INF`/`ABS`).
    fn end_of(&mut self, id: u32) -> anyhow::Result<String>;
}

/// Longest a single request may take before the bench gives up [s].
const PATIENCE_S: f64 = 120.0;

struct Virtual {
    sim: Simulation,
    client: SimClient,
}

impl Session for Virtual {
    fn ask(&mut self, id: u32, line: &str) -> anyhow::Result<String> {
        Ok(self.sim.ask(
            &mut self.client,
            &format!("{id} {line}"),
            (PATIENCE_S * 1e9) as u64,
        )?)
    }

    fn end_of(&mut self, id: u32) -> anyhow::Result<String> {
        let until = self.sim.now_ns() + (PATIENCE_S * 1e9) as u64;
        loop {
            let left = until.saturating_sub(self.sim.now_ns());
            let l = self.sim.next_line(&mut self.client, left)?;
            if ends(&l, id) {
                return Ok(l);
            }
        }
    }
}

/// `line` is the `INF` or `ABS` of request `id`.
fn ends(line: &str, id: u32) -> bool {
    let mut w = line.split(' ');
    matches!(w.next(), Some("INF" | "ABS")) && w.next() == Some(&id.to_string())
}

/// The real-time controller: `wrc up` in its own state directory, over TCP.
struct RealTime {
    reader: BufReader<TcpStream>,
    writer: TcpStream,
    _up: Up,
}

impl RealTime {
    fn start(dir: &Path, config: &Path) -> anyhow::Result<RealTime> {
        let options = UpOptions {
            state: dir.to_path_buf(),
            config: Some(config.to_path_buf()),
            ..UpOptions::default()
        };
        let up = match Up::start(&options)? {
            Ok(up) => up,
            Err(refused) => bail!(
                "wrc up refused to start ({}): {}",
                refused.status,
                refused.stderr
            ),
        };
        let writer = TcpStream::connect(("127.0.0.1", up.port))?;
        writer.set_read_timeout(Some(Duration::from_secs_f64(PATIENCE_S)))?;
        writer.set_nodelay(true)?;
        Ok(RealTime {
            reader: BufReader::new(writer.try_clone()?),
            writer,
            _up: up,
        })
    }

    fn line(&mut self) -> anyhow::Result<String> {
        let mut l = String::new();
        if self.reader.read_line(&mut l)? == 0 {
            bail!("the controller closed the connection");
        }
        Ok(l.trim_end().to_string())
    }
}

impl Session for RealTime {
    fn ask(&mut self, id: u32, line: &str) -> anyhow::Result<String> {
        self.writer.write_all(format!("{id} {line}\n").as_bytes())?;
        loop {
            let l = self.line()?;
            let mut w = l.split(' ');
            if matches!(w.next(), Some("ACK" | "NAK")) && w.next() == Some(&id.to_string()) {
                return Ok(l);
            }
        }
    }

    fn end_of(&mut self, id: u32) -> anyhow::Result<String> {
        loop {
            let l = self.line()?;
            if ends(&l, id) {
                return Ok(l);
            }
        }
    }
}

/// What a run of transfers leaves: its trace, the timed requests (id, line), and what the
/// transfer journal cost.
type Driven = (TraceFile, Vec<(u32, String)>, JournalCost);

/// Run the set-up and the timed transfers of `sequence`; the trace of the run.
fn drive(
    session: &mut dyn Session,
    sequence: Sequence,
    wafers: u16,
    trace_dir: &Path,
) -> anyhow::Result<Driven> {
    let (setup, timed) = sequence.requests(wafers);
    let mut id = 0;
    let motion = |session: &mut dyn Session, line: &str, id: u32| -> anyhow::Result<()> {
        let ack = session.ask(id, line)?;
        if !ack.starts_with("ACK") {
            bail!("`{line}` was refused: {ack}");
        }
        let end = session.end_of(id)?;
        if !end.starts_with("INF") {
            bail!("`{line}` ended with {end}");
        }
        Ok(())
    };
    for line in &setup {
        id += 1;
        motion(session, line, id)?;
    }
    let mut sent = Vec::new();
    for line in &timed {
        id += 1;
        motion(session, line, id)?;
        sent.push((id, line.clone()));
    }
    id += 1;
    let journal = JournalCost::parse(&session.ask(id, "RECOVERY")?);
    id += 1;
    let name = format!("bench-{}", sequence.key());
    let reply = session.ask(id, &format!("TRACE SAVE {name}"))?;
    if !reply.starts_with("ACK") {
        bail!("TRACE SAVE was refused: {reply}");
    }
    let trace = TraceFile::load(&trace_dir.join(format!("{name}.wrctrace")))?;
    Ok((trace, sent, journal))
}

/// One transfer as measured.
#[derive(Debug, Clone)]
struct Measured {
    line: String,
    kind: JobKind,
    seconds: f64,
    moving_s: f64,
    /// Request read → the first period that moved the arm [s].
    first_motion_s: f64,
    reference_s: f64,
}

/// The figures of one sequence.
#[derive(Debug, Clone)]
struct Figures {
    sequence: Sequence,
    wafers: u16,
    total_s: f64,
    transfers: Vec<Measured>,
    /// What the transfer journal cost (the controller's `RECOVERY` reply after the run).
    journal: JournalCost,
}

/// The Command Interpreter's waits for a step's beginning to be on disk, over a run.
#[derive(Debug, Clone, Copy, Default)]
struct JournalCost {
    waits: u64,
    total_s: f64,
    max_s: f64,
    /// The journal's syncs (fdatasync, each making the records written before it durable),
    /// their total and longest time.
    writes: u64,
    write_s: f64,
    write_max_s: f64,
}

impl JournalCost {
    /// Read from a `RECOVERY` reply (`… journal_waits=N journal_wait_ms=X journal_wait_max_ms=Y`).
    fn parse(reply: &str) -> JournalCost {
        let field = |k: &str| {
            wrc_protocol::reply_field(reply, k)
                .and_then(|v| v.parse::<f64>().ok())
                .unwrap_or(0.0)
        };
        JournalCost {
            waits: field("journal_waits") as u64,
            total_s: field("journal_wait_ms") * 1e-3,
            max_s: field("journal_wait_max_ms") * 1e-3,
            writes: field("journal_syncs") as u64,
            write_s: field("journal_sync_ms") * 1e-3,
            write_max_s: field("journal_sync_max_ms") * 1e-3,
        }
    }
}

impl Figures {
    fn wafers_per_hour(&self) -> f64 {
        f64::from(self.wafers) * 3600.0 / self.total_s
    }

    fn mean(&self, kind: JobKind, f: impl Fn(&Measured) -> f64) -> f64 {
        let v: Vec<f64> = self
            .transfers
            .iter()
            .filter(|m| m.kind == kind)
            .map(f)
            .collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    }

    /// The mean seconds of its `SWAP`s, if it has any.
    fn swap_s(&self) -> Option<f64> {
        self.transfers
            .iter()
            .any(|m| m.kind == JobKind::Swap)
            .then(|| self.mean(JobKind::Swap, |m| m.seconds))
    }

    fn sum(&self, f: impl Fn(&Measured) -> f64) -> f64 {
        self.transfers.iter().map(f).sum()
    }
}

/// The time-optimal reference of a transfer (see the module docs) from `start`, and the
/// joints it ends at; `hands` (which blades hold a wafer) is brought up to date.
fn reference(
    config: &Config,
    stations: &Stations,
    line: &str,
    start: Joints,
    hands: &mut [bool; MAX_BLADES],
) -> anyhow::Result<(JobKind, f64, Joints)> {
    let robot = &config.robot;
    let words: Vec<&str> = line.split_whitespace().collect();
    let blade = |w: &str| Blade::parse(w).with_context(|| format!("no blade {w}"));
    let (kind, name, slot, blade) = match words[..] {
        ["GET", s, n] => (JobKind::Get, s, n.parse::<u16>()?, Blade::A),
        ["GET", s, n, b] => (JobKind::Get, s, n.parse::<u16>()?, blade(b)?),
        ["PUT", s, n] => (JobKind::Put, s, n.parse::<u16>()?, Blade::A),
        ["PUT", s, n, b] => (JobKind::Put, s, n.parse::<u16>()?, blade(b)?),
        // The empty blade takes, the other puts.
        ["SWAP", s, n] => {
            let taker = if hands[0] { Blade::B } else { Blade::A };
            (JobKind::Swap, s, n.parse::<u16>()?, taker)
        }
        _ => bail!("not a transfer: {line}"),
    };
    let station = stations
        .get(name)
        .with_context(|| format!("no station {name}"))?;
    let at = |b: Blade| station.for_blade(config.hand.z_offset_mm(b.index()));
    let steps = match kind {
        JobKind::Get => plan(TransferKind::Get, &at(blade), slot)?,
        JobKind::Put => plan(TransferKind::Put, &at(blade), slot)?,
        JobKind::Swap => {
            let mut steps = plan(TransferKind::Get, &at(blade), slot)?;
            steps.extend(plan(TransferKind::Put, &at(blade.other()), slot)?);
            steps
        }
        JobKind::Map | JobKind::Sense => bail!("not a transfer: {line}"),
    };
    match kind {
        JobKind::Get => hands[blade.index()] = true,
        JobKind::Put => hands[blade.index()] = false,
        JobKind::Swap => {
            hands[blade.index()] = true;
            hands[blade.other().index()] = false;
        }
        JobKind::Map | JobKind::Sense => {}
    }
    let global = config.motion.speed_pct;
    let mut speed = global;
    let vacuum_s = config
        .boards
        .first()
        .and_then(|b| b.sim.vacuum.first())
        .map_or(0.0, |v| v.delay_ms / 1e3);
    let mut joints = start;
    let mut total = 0.0;
    let mut vacuum_changed = false;
    for step in steps {
        match step {
            Step::Ptp(pose, posture) => {
                let posture = posture
                    .or_else(|| Posture::of(robot, &joints))
                    .unwrap_or(Posture::Right);
                let target = robot.inverse(&pose, posture, Some(&joints))?;
                let mut slowest = 0.0f64;
                for (i, axis) in robot.axes().iter().enumerate() {
                    let d = (target[i] - joints[i]).abs();
                    if d > 0.0 {
                        let l = &axis.limits;
                        let t = DoubleS::time_optimal(
                            d,
                            l.max_velocity,
                            l.max_acceleration,
                            l.max_jerk,
                        )
                        .duration();
                        slowest = slowest.max(t);
                    }
                }
                total += slowest * 100.0 / speed;
                joints = target;
            }
            Step::Line(pose) | Step::Z(pose) => {
                let bound = line_bound(robot, &config.motion.line, &joints, &pose)?;
                total += bound.with_joints_s() * 100.0 / speed;
                let posture = Posture::of(robot, &joints).unwrap_or(Posture::Right);
                joints = robot.inverse(&pose, posture, Some(&joints))?;
            }
            Step::Speed(pct) => speed = pct.min(global),
            Step::RestoreSpeed => speed = global,
            Step::Vacuum(_) => vacuum_changed = true,
            Step::CheckVacuum { .. } => {
                if vacuum_changed {
                    total += vacuum_s;
                    vacuum_changed = false;
                }
            }
            Step::RequireInput(_) | Step::CommitMap => {}
        }
    }
    Ok((kind, total, joints))
}

/// The figures of `sequence` from its trace.
fn analyse(
    config: &Config,
    stations: &Stations,
    sequence: Sequence,
    wafers: u16,
    trace: &TraceFile,
    sent: &[(u32, String)],
) -> anyhow::Result<Figures> {
    let robot = &config.robot;
    let axes = trace.meta.axis_count().min(MAX_AXES);
    let period_s = trace.meta.period_ns as f64 / 1e9;
    // When each request was read and its INF delivered [ns].
    let find = |dir: Direction, pred: &dyn Fn(&str) -> bool| -> Option<u64> {
        trace
            .messages
            .iter()
            .find(|m| m.direction == dir && pred(&m.text()))
            .map(|m| m.t_ns)
    };
    let mut transfers = Vec::new();
    let (mut first, mut last) = (u64::MAX, 0u64);
    // Every sequence's set-up leaves both blades empty.
    let mut hands = [false; MAX_BLADES];
    for (id, line) in sent {
        let asked = format!("{id} {line}");
        let t0 = find(Direction::Request, &|t| t == asked)
            .with_context(|| format!("`{asked}` is not in the trace"))?;
        let t1 = find(Direction::Reply, &|t| ends(t, *id))
            .with_context(|| format!("the end of `{asked}` is not in the trace"))?;
        first = first.min(t0);
        last = last.max(t1);
        // The samples of the transfer, and the one before it (where the arm started).
        let before = trace
            .samples
            .iter()
            .rev()
            .find(|s| s.t_ns <= t0)
            .context("no sample before the transfer")?;
        let mut pulses = [0i64; MAX_AXES];
        pulses[..axes].copy_from_slice(&before.commanded[..axes]);
        let start = robot.pulses_to_joints(&pulses);
        let window: Vec<_> = trace
            .samples
            .iter()
            .filter(|s| s.t_ns >= before.t_ns && s.t_ns <= t1)
            .collect();
        let moving = window
            .windows(2)
            .filter(|w| w[0].commanded[..axes] != w[1].commanded[..axes])
            .count();
        let first_motion_s = window
            .windows(2)
            .find(|w| w[0].commanded[..axes] != w[1].commanded[..axes])
            .map_or(f64::NAN, |w| w[1].t_ns.saturating_sub(t0) as f64 / 1e9);
        let (kind, reference_s, _) = reference(config, stations, line, start, &mut hands)?;
        transfers.push(Measured {
            line: line.clone(),
            kind,
            seconds: (t1 - t0) as f64 / 1e9,
            moving_s: moving as f64 * period_s,
            first_motion_s,
            reference_s,
        });
    }
    Ok(Figures {
        sequence,
        wafers,
        total_s: last.saturating_sub(first) as f64 / 1e9,
        transfers,
        journal: JournalCost::default(),
    })
}

/// The configuration text with the trace recorder keeping an hour and every line: a bench
/// sequence is longer than the default 30 s.
/// `config` with `[motion] blend = false`: its text with that key set in its `[motion]`
/// section (added if it has none), parsed again (the real-time run reads the text).
fn unblended(config: &Config) -> anyhow::Result<Config> {
    let mut out = String::new();
    let mut section = "";
    let mut done = false;
    for line in config.text.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            section = if t == "[motion]" { "motion" } else { "other" };
        }
        if section == "motion" && t.split('=').next().is_some_and(|k| k.trim() == "blend") {
            continue;
        }
        out.push_str(line);
        out.push('\n');
        if t == "[motion]" {
            out.push_str("blend = false\n");
            done = true;
        }
    }
    if !done {
        out.push_str("\n[motion]\nblend = false\n");
    }
    let parsed = Config::parse(&out, &config.source)?;
    if parsed.blend {
        bail!("the bench could not turn blending off");
    }
    Ok(parsed)
}

fn long_trace(config: &Config) -> anyhow::Result<String> {
    let mut out = String::new();
    let mut section = "";
    for line in config.text.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            section = if t == "[trace]" { "trace" } else { "other" };
        }
        if section == "trace" && (t.starts_with("seconds") || t.starts_with("messages")) {
            continue;
        }
        out.push_str(line);
        out.push('\n');
        if t == "[trace]" {
            out.push_str("seconds = 3600\nmessages = 100000\n");
        }
    }
    if !config.text.lines().any(|l| l.trim() == "[trace]") {
        out.push_str("\n[trace]\nseconds = 3600\nmessages = 100000\n");
    }
    let parsed = Config::parse(&out, "the bench's configuration")?;
    if parsed.trace.seconds < 3600.0 {
        bail!("the bench could not lengthen the trace");
    }
    Ok(out)
}

/// Run one sequence on a fresh controller; its figures.
fn run_sequence(
    config: &Config,
    sequence: Sequence,
    wafers: u16,
    real_time: bool,
) -> anyhow::Result<Figures> {
    let dir = crate::sim::state_dir(None)?;
    let stations = Stations::embedded_demo();
    let text = long_trace(config)?;
    let (trace, sent, journal) = if real_time {
        let path = dir.path.join("bench.toml");
        std::fs::write(&path, &text)?;
        let mut session = RealTime::start(&dir.path, &path)?;
        drive(&mut session, sequence, wafers, &dir.path.join("traces"))?
    } else {
        let config = Config::parse(&text, "the bench's configuration")?;
        let mut sim = Simulation::in_state_dir(
            &config,
            &dir.path,
            SimCellFrom::default(),
            None,
            "127.0.0.1:9".parse().expect("an address"),
        )?;
        let client = sim.connect()?;
        let mut session = Virtual { sim, client };
        drive(&mut session, sequence, wafers, &dir.path.join("traces"))?
    };
    let mut figures = analyse(config, &stations, sequence, wafers, &trace, &sent)?;
    figures.journal = journal;
    Ok(figures)
}

/// Run `wrc bench cell`.
pub fn run(args: CellArgs) -> anyhow::Result<ExitCode> {
    let period_s = Config::embedded_default().motion.period_s;
    let sequences = if args.only.is_empty() {
        Sequence::ALL.to_vec()
    } else {
        args.only.clone()
    };
    let mode = match (args.real_time, args.compare) {
        (true, _) => "real time (wrc up)",
        (false, true) => "virtual time, then real time (wrc up)",
        (false, false) => "virtual time",
    };
    let mode = if args.rest_to_rest {
        format!("{mode}, every motion from rest to rest")
    } else {
        mode.to_string()
    };
    println!(
        "wrc bench cell: the demo cell, {} wafers per sequence, {mode}",
        args.wafers
    );
    println!(
        "{:<24} {:>9} {:>8} {:>8} {:>9} {:>8} {:>8} {:>11} {:>13}",
        "sequence",
        "wafers/h",
        "GET [s]",
        "PUT [s]",
        "SWAP [s]",
        "moving",
        "waiting",
        "vs optimal",
        "1st motion"
    );
    let mut all = Vec::new();
    for sequence in sequences {
        let config = if args.rest_to_rest {
            unblended(&sequence.config())?
        } else {
            sequence.config()
        };
        let f = run_sequence(&config, sequence, args.wafers, args.real_time)
            .with_context(|| format!("sequence {}", sequence.key()))?;
        let busy = f.sum(|m| m.seconds);
        let moving = f.sum(|m| m.moving_s);
        let ratio = busy / f.sum(|m| m.reference_s);
        // The slowest start of a transfer's motion, in Pulse Generator periods.
        let first = f
            .transfers
            .iter()
            .map(|m| m.first_motion_s)
            .fold(0.0f64, f64::max)
            / period_s;
        println!(
            "{:<24} {:>9.1} {:>8.2} {:>8.2} {:>9} {:>7.0}% {:>7.0}% {:>10.2}x {:>6.1} periods",
            sequence.name(),
            f.wafers_per_hour(),
            f.mean(JobKind::Get, |m| m.seconds),
            f.mean(JobKind::Put, |m| m.seconds),
            f.swap_s()
                .map_or_else(|| "-".to_string(), |s| format!("{s:.2}")),
            100.0 * moving / busy,
            100.0 * (busy - moving) / busy,
            ratio,
            first
        );
        if args.compare {
            let r = run_sequence(&config, sequence, args.wafers, true)
                .with_context(|| format!("sequence {} in real time", sequence.key()))?;
            let worst = f
                .transfers
                .iter()
                .zip(&r.transfers)
                .map(|(v, r)| ((r.seconds - v.seconds) / period_s).abs())
                .fold(0.0f64, f64::max);
            println!(
                "{:<24} {:>9.1} {:>8.2} {:>8.2}   real time: largest difference from virtual \
                 time {worst:.1} periods per transfer",
                "  the same, real time",
                r.wafers_per_hour(),
                r.mean(JobKind::Get, |m| m.seconds),
                r.mean(JobKind::Put, |m| m.seconds),
            );
        }
        all.push(f);
    }
    println!(
        "(per transfer: request read → INF on the controller's clock; moving: periods with a \
         commanded change; 1st motion: the slowest request → first moving period; optimal: \
         docs/throughput.md)"
    );
    for f in &all {
        let busy = f.sum(|m| m.seconds);
        let n = f.transfers.len().max(1) as f64;
        println!(
            "journal {:<16} {} steps waited for their record on disk: {:.1} ms in all, {:.2} ms per transfer ({:.3} % of its time), the longest {:.2} ms; {} syncs (fdatasync) of its records took {:.1} ms, {:.2} ms each, the longest {:.2} ms",
            f.sequence.key(),
            f.journal.waits,
            f.journal.total_s * 1e3,
            f.journal.total_s * 1e3 / n,
            100.0 * f.journal.total_s / busy,
            f.journal.max_s * 1e3,
            f.journal.writes,
            f.journal.write_s * 1e3,
            f.journal.write_s * 1e3 / (f.journal.writes.max(1) as f64),
            f.journal.write_max_s * 1e3
        );
    }
    if let Some(path) = &args.json {
        let v: Vec<_> = all
            .iter()
            .map(|f| {
                json!({
                    "sequence": f.sequence.key(),
                    "wafers": f.wafers,
                    "seconds": f.total_s,
                    "wafers_per_hour": f.wafers_per_hour(),
                    "get_s": f.mean(JobKind::Get, |m| m.seconds),
                    "put_s": f.mean(JobKind::Put, |m| m.seconds),
                    "swap_s": f.swap_s(),
                    "journal_waits": f.journal.waits,
                    "journal_wait_s": f.journal.total_s,
                    "journal_wait_max_s": f.journal.max_s,
                    "journal_share": f.journal.total_s / f.sum(|m| m.seconds),
                    "journal_syncs": f.journal.writes,
                    "journal_sync_s": f.journal.write_s,
                    "journal_sync_max_s": f.journal.write_max_s,
                    "transfers": f.transfers.iter().map(|m| json!({
                        "request": m.line,
                        "seconds": m.seconds,
                        "moving_s": m.moving_s,
                        "first_motion_s": m.first_motion_s,
                        "reference_s": m.reference_s,
                    })).collect::<Vec<_>>(),
                })
            })
            .collect();
        let doc = json!({
            "mode": if args.real_time { "real-time" } else { "virtual" },
            "sequences": v,
        });
        std::fs::write(path, serde_json::to_string_pretty(&doc)?)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sequences_deliver_their_wafers_with_the_transfers_they_name() {
        let (setup, timed) = Sequence::LpAlLp.requests(2);
        assert_eq!(setup, ["HOME", "MAP LP1", "MAP LP2", "MAP AL"]);
        assert_eq!(
            timed,
            [
                "GET LP1 1",
                "PUT AL 1",
                "GET AL 1",
                "PUT LP2 1",
                "GET LP1 2",
                "PUT AL 1",
                "GET AL 1",
                "PUT LP2 2"
            ]
        );
        let (setup, timed) = Sequence::SwapPm1.requests(1);
        assert_eq!(&setup[setup.len() - 2..], ["GET LP1 1", "PUT PM1 1"]);
        assert_eq!(
            timed,
            [
                "GET LP1 2",
                "PUT BF1 1",
                "GET PM1 1",
                "PUT LP2 1",
                "GET BF1 1",
                "PUT PM1 1"
            ]
        );
    }

    /// Every transfer of a short sequence, run in virtual time with blending off: its time
    /// is at least its reference (the reference sums lower bounds of rest-to-rest motions),
    /// it moved for at most its time, and the sequence's rate is its wafers over its span.
    /// With blending on (the default), every transfer is as fast or faster (within a
    /// period) and the sequence faster.
    #[test]
    fn a_short_sequence_is_measured_consistently_and_never_beats_its_reference() {
        assert!(Config::embedded_default().blend);
        let config = unblended(&Config::embedded_default()).unwrap();
        let f = run_sequence(&config, Sequence::LpAlLp, 1, false).unwrap();
        assert_eq!(f.transfers.len(), 4);
        let busy = f.sum(|m| m.seconds);
        assert!(f.total_s >= busy - 1e-9 && f.total_s < busy + 1.0, "{f:?}");
        assert!((f.wafers_per_hour() - 3600.0 / f.total_s).abs() < 1e-9);
        for m in &f.transfers {
            assert!(m.reference_s > 1.0, "{m:?}");
            assert!(m.seconds >= m.reference_s * 0.999, "{m:?}");
            // Within 25 %: the planner's segments are near time-optimal at rest-to-rest.
            assert!(m.seconds <= m.reference_s * 1.25, "{m:?}");
            assert!(
                m.moving_s > 0.5 * m.seconds && m.moving_s <= m.seconds + 0.011,
                "{m:?}"
            );
        }
        let blended =
            run_sequence(&Config::embedded_default(), Sequence::LpAlLp, 1, false).unwrap();
        for (b, r) in blended.transfers.iter().zip(&f.transfers) {
            assert_eq!(b.line, r.line);
            assert!(b.seconds <= r.seconds + 0.011, "{b:?} vs {r:?}");
        }
        assert!(
            blended.total_s < f.total_s - 0.5,
            "{} vs {}",
            blended.total_s,
            f.total_s
        );
    }

    /// The dual-blade swap: GET with blade B, SWAP (blade A takes, blade B puts), PUT with
    /// blade A; each against its reference, the SWAP's being its two halves'.
    #[test]
    fn the_dual_blade_swap_is_measured_against_both_halves() {
        // Rest to rest, so that every transfer is at least its reference.
        let config = unblended(&Sequence::SwapPm1Dual.config()).unwrap();
        assert_eq!(config.hand.blades(), 2);
        let f = run_sequence(&config, Sequence::SwapPm1Dual, 1, false).unwrap();
        let kinds: Vec<JobKind> = f.transfers.iter().map(|m| m.kind).collect();
        assert_eq!(kinds, [JobKind::Get, JobKind::Swap, JobKind::Put]);
        for m in &f.transfers {
            assert!(m.seconds >= m.reference_s * 0.999, "{m:?}");
            assert!(m.seconds <= m.reference_s * 1.25, "{m:?}");
        }
        let swap = &f.transfers[1];
        assert_eq!(f.swap_s(), Some(swap.seconds));
        // A SWAP takes longer than either half alone, and less than the two apart (no move
        // between them but the Z lift from one blade to the other).
        let (get, put) = (&f.transfers[0], &f.transfers[2]);
        assert!(
            swap.reference_s > get.reference_s.max(put.reference_s),
            "{f:?}"
        );
        // The SWAP's reference: blade A's GET at PM1, then blade B's PUT there from where
        // the GET ended (one start for both).
        let stations = Stations::embedded_demo();
        let start = config.robot.pulses_to_joints(&[0; MAX_AXES]);
        let mut hands = [false, true];
        let (kind, swap_ref, _) =
            reference(&config, &stations, "SWAP PM1 1", start, &mut hands).unwrap();
        assert_eq!((kind, hands), (JobKind::Swap, [true, false]));
        let mut one = [false; 2];
        let (_, get_a, end) = reference(&config, &stations, "GET PM1 1", start, &mut one).unwrap();
        let (_, put_b, _) =
            reference(&config, &stations, "PUT PM1 1 B", end, &mut [false, true]).unwrap();
        assert!(
            (swap_ref - (get_a + put_b)).abs() < 1e-9,
            "{swap_ref} {get_a} {put_b}"
        );
    }

    #[test]
    fn the_reference_adds_the_vacuum_delay_after_each_vacuum_change() {
        let mut config = Config::embedded_default();
        let stations = Stations::embedded_demo();
        let start = config.robot.pulses_to_joints(&[0; MAX_AXES]);
        let mut hands = [false; MAX_BLADES];
        let (kind, base, _) =
            reference(&config, &stations, "GET LP1 1", start, &mut hands).unwrap();
        assert_eq!(kind, JobKind::Get);
        assert_eq!(hands, [true, false]);
        config.boards[0].sim.vacuum[0].delay_ms += 200.0;
        let (_, slower, _) =
            reference(&config, &stations, "GET LP1 1", start, &mut [false; 2]).unwrap();
        // One vacuum change, checked once.
        assert!((slower - base - 0.2).abs() < 1e-9, "{base} {slower}");
        assert!(reference(&config, &stations, "MAP LP1", start, &mut hands).is_err());
        assert!(reference(&config, &stations, "GET XX 1", start, &mut hands).is_err());
    }
}
