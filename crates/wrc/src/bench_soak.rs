//! `wrc bench soak`: a sustained run of `wrc up` under random valid and invalid requests from
//! several clients while the robot moves, watching for what only a long run reveals: a
//! crash, a request left unanswered, descriptors or memory that grow, real-time jitter that
//! drifts.
//!
//! One client holds control and keeps the robot moving (random joint moves within 90 % of
//! each axis's range, straight lines to random poses, every target clear of the cell — see
//! [`cell`]; a joint move may go round it through the travel height, and some lines are
//! refused, as they must be, where they would cross a station or leave the workspace —
//! speed changes; it resumes a motion another client held and resets after an E-stop). The
//! others send, every 5 to 45 ms at random, queries (65.5 %), invalid lines (25 %: unknown
//! verbs, bad numbers and arguments, non-ASCII bytes, over-long lines, checksums on TCP),
//! `CONTROL` (4 %, refused: the mover holds it), `HOLD` and `STOP` (0.2 % each), `ESTOP`
//! (0.02 %), and reconnect (5 %). Every request carries an id and must be answered within
//! [`REPLY_S`]; an invalid line must get exactly one `NAK` before the reply to the request
//! sent after it.
//!
//! Figures: requests and replies, motions ended (`INF`, `ABS` by code, refusals by code —
//! 117 where a motion would touch the cell — and the joint moves routed round it), the side
//! collisions the simulated cell counted, the controller's resident memory after the warm-up
//! (the first tenth of the run), at half time, every 30 s and at the end, its open
//! descriptors before the clients connect and after they have gone, and the Pulse
//! Generator's wake-up latency p99 in the first and the last tenth of the run (from the
//! `TASKS` latency histograms). It passes when the controller runs to the end, every request
//! was answered as the protocol says, no body of the arm touched the cell (a station off its
//! line, an obstacle: the simulated cell's ground truth, read when the board stops), no
//! descriptor is left over, and its memory grew in the second half of the run by at most
//! [`RSS_SLACK_KIB`] KiB or [`RSS_SLACK_PCT`] %. The first half may take a step that stays
//! (buffers the allocator keeps once used; the runs measured took one step of about 10 MB in
//! their first two minutes, then stayed flat); a leak keeps climbing.
//!
//! The servo loop, at the configuration's period or at `--period-ms` (1 for 1 kHz), idle or
//! under `--load` (stress-ng): underruns, host-watchdog trips and following-error trips
//! (none allowed), every task's overruns, the Pulse Generator's wake-up latency beside
//! cyclictest's at the same SCHED_FIFO priority and interval in the same run, the deepest
//! board FIFO drain against the look-ahead, and, at rest at the end, the pulse count of every
//! axis on the board against the controller's (equal, or pulses were lost). See [`servo`].

mod cell;
mod period;
mod pulses;
mod servo;
mod tasks;

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use clap::Args;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::json;
use wrc_config::Config;

use crate::bench_rt::cyclictest::{self, Cyclictest};
use crate::bench_rt::load::Load;
use crate::up_process::{reply_of, Conn, Up, UpOptions};
use cell::Targets;
use servo::Servo;
use tasks::{Bins, TaskLine, PULSE_GENERATOR};
use wrc_rt::fifo_priority;
use wrc_rt::sched_policy::isolated_cpus;

/// How long a request may wait for its reply, and a motion for its end [s].
const REPLY_S: u64 = 10;
/// How long a motion may take from its `ACK` to its `INF`/`ABS` [s].
const MOTION_S: u64 = 120;
/// The probe connection's pace of `STATUS` while it waits [s] (under the idle timeout).
const KEEP_ALIVE_S: u64 = 30;
/// `--load`: stress-ng's CPU stressors and its memory stressor's size (`stress-ng --cpu 2
/// --vm 1 --vm-bytes 256M`).
const LOAD_CPUS: usize = 2;
const LOAD_VM_BYTES: &str = "256M";
/// stress-ng's own timeout beyond the clients' time [s]; the bench stops it sooner.
const LOAD_SPARE_S: u64 = 300;
/// Resident-memory growth allowed from half time to the end [KiB] …
const RSS_SLACK_KIB: u64 = 4096;
/// … or [%] of the half-time figure, whichever is larger.
const RSS_SLACK_PCT: u64 = 10;

/// Arguments of `wrc bench soak`.
#[derive(Debug, Args)]
pub struct SoakArgs {
    /// How long the clients run [s].
    #[arg(long, default_value_t = 60, value_parser = clap::value_parser!(u64).range(5..=86_400))]
    seconds: u64,
    /// Clients at once: one moves the robot, the others send random requests.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(2..=32))]
    clients: u32,
    /// Seed of the random requests (the same seed sends the same requests).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Run the controller without SCHED_FIFO.
    #[arg(long)]
    no_rt: bool,
    /// Servo period [ms]: the Pulse Generator's, the Simulator Manager's and the board's
    /// (1 for 1 kHz); default: the configuration's own (10).
    #[arg(long, value_name = "P")]
    period_ms: Option<f64>,
    /// Run `stress-ng --cpu 2 --vm 1 --vm-bytes 256M` for the whole run (the run fails when
    /// stress-ng cannot run).
    #[arg(long)]
    load: bool,
    /// Do not run cyclictest beside the Pulse Generator.
    #[arg(long)]
    no_cyclictest: bool,
    /// Write every figure as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

/// Send `line` with the connection's next id and wait [`REPLY_S`] for its `ACK`/`NAK`; with
/// the `NAK`s of other lines and the other lines that came first.
fn ask(c: &mut Conn, line: &str) -> anyhow::Result<Asked> {
    let mark = c.lines.mark();
    let id = c.send(line)?;
    Ok(asked_since(c, mark, id))
}

/// The reply to request `id`, and what came before it from `mark` on.
fn asked_since(c: &Conn, mark: usize, id: u32) -> Asked {
    let found = c.lines.find(mark, Duration::from_secs(REPLY_S), |l| {
        reply_of(l, id, &["ACK", "NAK"])
    });
    let before = found
        .as_ref()
        .map_or_else(|| c.lines.mark(), |(i, _, _)| *i);
    let mut asked = Asked {
        id,
        ..Asked::default()
    };
    for l in c
        .lines
        .since(mark)
        .into_iter()
        .take(before.saturating_sub(mark))
    {
        if l.starts_with("NAK") {
            asked.other_naks += 1;
        } else {
            asked.lines.push(l);
        }
    }
    asked.reply = found.map(|(_, _, l)| l);
    asked
}

/// The `INF`/`ABS` of request `id` (sent after line `mark`), resuming it when another client
/// held it; `None` when it did not end within [`MOTION_S`].
fn motion_end(c: &mut Conn, mark: usize, id: u32) -> anyhow::Result<Option<String>> {
    let deadline = Instant::now() + Duration::from_secs(MOTION_S);
    while Instant::now() < deadline {
        let end = c.lines.find(mark, Duration::from_secs(1), |l| {
            reply_of(l, id, &["INF", "ABS"])
        });
        if let Some((_, _, l)) = end {
            return Ok(Some(l));
        }
        // Quiet for a second: held by another client's HOLD?
        if ask(c, "STATUS")?
            .reply
            .is_some_and(|r| r.contains("state=HELD"))
        {
            ask(c, "RESUME")?;
        }
    }
    Ok(None)
}

/// What [`ask`] saw.
#[derive(Default)]
struct Asked {
    /// The request's id.
    id: u32,
    /// The request's `ACK`/`NAK`; `None` when it did not come in time.
    reply: Option<String>,
    /// `NAK`s for other lines that came first.
    other_naks: u32,
    /// Other lines (events, `EVT TASK`, ends of motions) that came first.
    lines: Vec<String>,
}

/// What the clients did.
#[derive(Default, Debug, Clone)]
struct Tally {
    requests: u64,
    replies: u64,
    invalid_lines: u64,
    /// Requests (or invalid lines) not answered as the protocol says.
    unanswered: u64,
    wrong: Vec<String>,
    motions: u64,
    /// Motions that went round the cell through the travel height (`ACK <id> route=travel`).
    routed: u64,
    inf: u64,
    abs: BTreeMap<String, u64>,
    refused: BTreeMap<String, u64>,
    reconnects: u64,
    estops: u64,
}

impl Tally {
    fn merge(&mut self, o: Tally) {
        self.requests += o.requests;
        self.replies += o.replies;
        self.invalid_lines += o.invalid_lines;
        self.unanswered += o.unanswered;
        self.wrong.extend(o.wrong);
        self.motions += o.motions;
        self.routed += o.routed;
        self.inf += o.inf;
        for (k, v) in o.abs {
            *self.abs.entry(k).or_default() += v;
        }
        for (k, v) in o.refused {
            *self.refused.entry(k).or_default() += v;
        }
        self.reconnects += o.reconnects;
        self.estops += o.estops;
    }

    fn problem(&mut self, what: String) {
        self.unanswered += 1;
        if self.wrong.len() < 10 {
            self.wrong.push(what);
        }
    }

    /// Count the reply of a request; `false` when none came.
    fn answered(&mut self, line: &str, asked: &Asked) -> bool {
        self.requests += 1;
        match &asked.reply {
            Some(_) => {
                self.replies += 1;
                true
            }
            None => {
                self.problem(format!("no reply to {line:?} within {REPLY_S} s"));
                false
            }
        }
    }
}

/// The code of a `NAK <id> <code> …` or `ABS <id> <code> …` line.
fn code_of(line: &str) -> String {
    line.split(' ').nth(2).unwrap_or("?").to_string()
}

/// The client that holds control and keeps the robot moving.
fn mover(up: &Up, config: &Config, seed: u64, quit: &AtomicBool) -> anyhow::Result<Tally> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut t = Tally::default();
    let robot = &config.robot;
    let targets = Targets::new(robot, &up.state.join("stations.toml"))?;
    let mut c = up.conn()?;
    ask_counted(&mut c, &mut t, "CONTROL")?;
    while !quit.load(Ordering::Acquire) {
        let line = match rng.random_range(0..20) {
            0 => format!("SPEED {}", rng.random_range(20..=100)),
            1..=4 => {
                let p = robot.forward(&targets.joints(&mut rng));
                format!("MOVL {:.3} {:.3} {:.3} {:.3}", p.x, p.y, p.z, p.yaw)
            }
            _ => {
                let j = targets.joints(&mut rng);
                let joints: Vec<String> = j[..robot.axes().len()]
                    .iter()
                    .map(|v| format!("{v:.3}"))
                    .collect();
                format!("MOVJ {}", joints.join(" "))
            }
        };
        let mark = c.lines.mark();
        let asked = ask_counted(&mut c, &mut t, &line)?;
        let Some(reply) = asked.reply else { continue };
        if line.starts_with("SPEED") {
            continue;
        }
        if reply.starts_with("NAK") {
            let code = code_of(&reply);
            *t.refused.entry(code.clone()).or_default() += 1;
            match code.as_str() {
                "110" | "122" | "123" => recover(&mut c, &mut t, quit)?,
                // Still braking from another client's STOP: wait for standstill.
                "121" => run_to_end(&mut c, &mut t, "WAIT")?,
                _ => {}
            }
            continue;
        }
        t.motions += 1;
        t.routed += u64::from(reply.contains(" route=travel"));
        match motion_end(&mut c, mark, asked.id)? {
            Some(end) if end.starts_with("INF") => t.inf += 1,
            Some(end) => {
                let code = code_of(&end);
                *t.abs.entry(code.clone()).or_default() += 1;
                if code != "200" {
                    recover(&mut c, &mut t, quit)?;
                }
            }
            None => t.problem(format!("{line:?} did not end within {MOTION_S} s")),
        }
    }
    Ok(t)
}

/// Send `line` and count its reply.
fn ask_counted(c: &mut Conn, t: &mut Tally, line: &str) -> anyhow::Result<Asked> {
    let asked = ask(c, line)?;
    t.answered(line, &asked);
    Ok(asked)
}

/// Send a request that completes later (`WAIT`, `HOME`) and, once accepted, wait for its end.
fn run_to_end(c: &mut Conn, t: &mut Tally, line: &str) -> anyhow::Result<()> {
    let mark = c.lines.mark();
    let asked = ask_counted(c, t, line)?;
    if asked.reply.is_some_and(|r| r.starts_with("ACK")) {
        motion_end(c, mark, asked.id)?;
    }
    Ok(())
}

/// After an E-stop or a fault: wait for standstill, `RESET` (once the E-stop request is
/// gone), `HOME` when needed.
fn recover(c: &mut Conn, t: &mut Tally, quit: &AtomicBool) -> anyhow::Result<()> {
    let deadline = Instant::now() + Duration::from_secs(MOTION_S);
    while Instant::now() < deadline && !quit.load(Ordering::Acquire) {
        let reset = ask_counted(c, t, "RESET")?;
        let Some(reply) = reset.reply else {
            return Ok(());
        };
        if reply.starts_with("ACK") {
            let status = ask_counted(c, t, "STATUS")?;
            if status.reply.is_some_and(|r| r.contains("homed=0")) {
                run_to_end(c, t, "HOME")?;
            }
            return Ok(());
        }
        // Still moving, or the E-stop is being handled: wait for standstill.
        run_to_end(c, t, "WAIT")?;
    }
    Ok(())
}

/// An invalid line: exactly one `NAK` answers it.
fn invalid_line(rng: &mut ChaCha8Rng) -> Vec<u8> {
    let id = rng.random_range(1..100_000u32);
    let mut line = match rng.random_range(0..8) {
        0 => format!("{id} FROB{}", rng.random::<u32>()).into_bytes(),
        1 => format!("{id} MOVJ 1 x 3 4").into_bytes(),
        2 => format!("{id} MOVJ 1 2").into_bytes(),
        3 => {
            let mut l = format!("{id} STATUS ").into_bytes();
            l.extend([0xFF, 0xFE, rng.random_range(0x80..=0xFFu8)]);
            l
        }
        4 => {
            let mut l = format!("{id} STATUS ").into_bytes();
            l.extend(std::iter::repeat_n(b'A', 300 + rng.random_range(0..2000)));
            l
        }
        5 => format!("{id} OUT {} 7", rng.random_range(0..32)).into_bytes(),
        6 => format!("{id} SPEED {}", rng.random_range(101..1101)).into_bytes(),
        _ => format!("{id} STATUS*{:02X}", rng.random::<u8>()).into_bytes(),
    };
    line.push(b'\n');
    line
}

/// A client that sends random requests, valid and not.
fn chatter(up: &Up, seed: u64, quit: &AtomicBool) -> anyhow::Result<Tally> {
    const QUERIES: [&str; 9] = [
        "STATUS", "WHERE", "IO", "TASKS", "WAFERS", "STN", "HELP", "ROBOT", "PROGRAMS",
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut t = Tally::default();
    let mut c = up.conn()?;
    while !quit.load(Ordering::Acquire) {
        // A host's pace: a request every 5 to 45 ms.
        std::thread::sleep(Duration::from_millis(rng.random_range(5..45)));
        let roll = rng.random_range(0..10_000);
        if roll < 2_500 {
            // An invalid line, then a query: one NAK must come before the query's reply.
            t.invalid_lines += 1;
            let mark = c.lines.mark();
            c.send_raw(&invalid_line(&mut rng))?;
            let id = c.send("STATUS")?;
            let asked = asked_since(&c, mark, id);
            if t.answered("STATUS", &asked) && asked.other_naks != 1 {
                t.problem(format!("{} NAKs for one invalid line", asked.other_naks));
            }
            continue;
        }
        if roll < 3_000 {
            t.reconnects += 1;
            c = up.conn()?;
            continue;
        }
        let line = match roll {
            3_000..=9_549 => QUERIES[rng.random_range(0..QUERIES.len())],
            9_550..=9_957 => "CONTROL",
            9_958..=9_977 => "HOLD",
            9_978..=9_997 => "STOP",
            _ => {
                t.estops += 1;
                "ESTOP"
            }
        };
        ask_counted(&mut c, &mut t, line)?;
    }
    Ok(t)
}

/// The controller's resident memory [KiB] and open descriptors.
fn usage(pid: u32) -> anyhow::Result<(u64, u64)> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status"))?;
    let rss = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
        .context("no VmRSS in /proc/PID/status")?;
    let fds = std::fs::read_dir(format!("/proc/{pid}/fd"))?.count() as u64;
    Ok((rss, fds))
}

/// Every task's `EVT TASK` line now (`TASKS`).
fn tasks_now(c: &mut Conn) -> anyhow::Result<Vec<TaskLine>> {
    let asked = ask(c, "TASKS")?;
    if asked.reply.is_none() {
        bail!("the controller did not answer TASKS within {REPLY_S} s");
    }
    let tasks = tasks::task_lines(&asked.lines);
    if !tasks.iter().any(|t| t.name == PULSE_GENERATOR) {
        bail!("TASKS did not list the Pulse Generator");
    }
    Ok(tasks)
}

/// The Pulse Generator's latency histogram now (`TASKS`).
fn pg_histogram(c: &mut Conn) -> anyhow::Result<Bins> {
    let tasks = tasks_now(c)?;
    Ok(tasks
        .iter()
        .find(|t| t.name == PULSE_GENERATOR)
        .map(TaskLine::histogram)
        .unwrap_or_default())
}

/// The p99 [µs] (a bin's upper bound) of the samples added from `a` to `b`.
fn window_p99(a: &[(u64, u64)], b: &[(u64, u64)]) -> Option<u64> {
    tasks::percentile(&tasks::difference(a, b), 99)
}

/// What the controller said of its scheduling at start-up (`wrc-rt: real-time scheduling: …`
/// or `wrc-rt: NOT real-time: …`).
fn scheduling_of(up: &Up) -> String {
    up.log
        .find(0, Duration::from_secs(2), |l| {
            l.starts_with("wrc-rt: real-time scheduling") || l.starts_with("wrc-rt: NOT real-time")
        })
        .map_or_else(
            || "not reported by the controller".to_string(),
            |(_, _, l)| l.trim_start_matches("wrc-rt: ").to_string(),
        )
}

/// cyclictest at the Pulse Generator's SCHED_FIFO priority, interval and CPU for `seconds`,
/// or why it does not run.
fn start_cyclictest(
    pg: &wrc_rt::TaskSpec,
    seconds: u64,
    wanted: bool,
) -> Result<Cyclictest, String> {
    if !wanted {
        return Err("not requested (--no-cyclictest)".into());
    }
    let bin = cyclictest::find().ok_or("not installed (Debian package rt-tests)")?;
    let cpu = pg.cpu.or(isolated_cpus().first().copied());
    Cyclictest::start(&bin, fifo_priority(pg.priority), pg.period_us, seconds, cpu)
        .map_err(|e| format!("cannot start cyclictest: {e}"))
}

/// Run `wrc bench soak`.
pub fn run(args: SoakArgs) -> anyhow::Result<ExitCode> {
    let dir = crate::sim::state_dir(None)?;
    let (config, config_file) = match args.period_ms {
        None => (Config::embedded_default(), None),
        Some(p) => {
            let (text, config) = period::config_for_period(p)?;
            let path = dir.path.join("soak-config.toml");
            std::fs::write(&path, text)
                .with_context(|| format!("cannot write {}", path.display()))?;
            (config, Some(path))
        }
    };
    let period_ms = config.motion.period_s * 1000.0;
    let pg_task = config
        .tasks
        .get(PULSE_GENERATOR)
        .cloned()
        .context("the configuration has no pulse_generator task")?;
    // A soak that says it ran loaded must have: stress-ng or no run. It starts first, so a
    // missing stress-ng is said at once, and loads the controller's start-up and homing too.
    let mut load_process = if args.load {
        Some(
            Load::stress_ng(LOAD_CPUS, LOAD_VM_BYTES, args.seconds + LOAD_SPARE_S).map_err(
                |e| {
                    anyhow::anyhow!(
                        "--load needs stress-ng, which cannot be run ({e}): install it (Debian \
                         package stress-ng; make soak does) or leave --load out"
                    )
                },
            )?,
        )
    } else {
        None
    };
    let options = UpOptions {
        state: dir.path.clone(),
        config: config_file,
        no_rt: args.no_rt,
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
    let pid = up.pid();
    let scheduling = scheduling_of(&up);
    let mut probe = up.conn()?;
    // The robot must be homed before it moves.
    probe.run_ok("HOME")?;
    let (_, fds_before) = usage(pid)?;
    eprintln!(
        "soak: {} clients for {} s (seed {}), servo period {period_ms} ms, {}, controller pid {pid} …",
        args.clients,
        args.seconds,
        args.seed,
        load_process.as_ref().map_or("idle".to_string(), Load::describe)
    );
    let quit = Arc::new(AtomicBool::new(false));
    let up = Arc::new(up);
    let h0 = pg_histogram(&mut probe)?;
    let cyclic = start_cyclictest(&pg_task, args.seconds, !args.no_cyclictest);
    let workers: Vec<_> = (0..args.clients)
        .map(|i| {
            let (up, quit, config) = (up.clone(), quit.clone(), config.clone());
            let seed = args.seed.wrapping_mul(1000).wrapping_add(u64::from(i));
            std::thread::spawn(move || {
                if i == 0 {
                    mover(&up, &config, seed, &quit)
                } else {
                    chatter(&up, seed, &quit)
                }
            })
        })
        .collect();
    let began = Instant::now();
    let at = |fraction: f64| began + Duration::from_secs_f64(args.seconds as f64 * fraction);
    // Resident memory every keep-alive [s since the start, KiB]: a leak climbs, a cache
    // filling up levels off.
    let mut rss_series: Vec<(u64, u64)> = Vec::new();
    let watched = (|| -> anyhow::Result<_> {
        let mut watch = |probe: &mut Conn, t: Instant| {
            keep_alive_until(probe, t, &mut |at| {
                if let Ok((rss, _)) = usage(pid) {
                    rss_series.push((at.duration_since(began).as_secs(), rss));
                }
            })
        };
        watch(&mut probe, at(0.1))?;
        let h1 = pg_histogram(&mut probe)?;
        let (rss_warm, _) = usage(pid)?;
        watch(&mut probe, at(0.5))?;
        let (rss_half, _) = usage(pid)?;
        watch(&mut probe, at(0.9))?;
        let h2 = pg_histogram(&mut probe)?;
        watch(&mut probe, at(1.0))?;
        let h3 = pg_histogram(&mut probe)?;
        Ok((h1, h2, h3, rss_warm, rss_half))
    })();
    // Whatever happened, the clients stop (and with the last of them the controller).
    quit.store(true, Ordering::Release);
    let mut tally = Tally::default();
    let mut failures = Vec::new();
    for (i, w) in workers.into_iter().enumerate() {
        match w.join() {
            Ok(Ok(t)) => tally.merge(t),
            Ok(Err(e)) => failures.push(format!("client {i}: {e:#}")),
            Err(_) => failures.push(format!("client {i} panicked")),
        }
    }
    let secs = began.elapsed().as_secs_f64();
    let load = load_process
        .as_mut()
        .map(|l| l.check_running().map(|()| l.describe()));
    // The clients are gone: the controller closes their connections within its period.
    let mut up = Arc::try_unwrap(up).map_err(|_| anyhow::anyhow!("a client still runs"))?;
    let (h1, h2, h3, rss_warm, rss_half) = watched?;
    let settle = Instant::now() + Duration::from_secs(5);
    let (mut rss_end, mut fds_end) = usage(pid)?;
    while fds_end > fds_before && Instant::now() < settle {
        std::thread::sleep(Duration::from_millis(50));
        (rss_end, fds_end) = usage(pid)?;
    }
    let alive = up.alive() && ask(&mut probe, "STATUS")?.reply.is_some();
    // The servo figures: pulses at rest, the tasks' counters, cyclictest's run, the alarms.
    let pulses = pulses::at_rest(&mut probe, &config, &up.state).map_err(|e| format!("{e:#}"));
    let tasks_end = tasks_now(&mut probe).unwrap_or_default();
    let servo = Servo {
        period_ms,
        scheduling,
        load,
        pg_run: tasks::difference(&h0, &h3),
        tasks: tasks_end,
        alarms: servo::alarms_of(&probe.lines.since(0)),
        cyclictest: cyclic.and_then(Cyclictest::finish),
        pulses,
    };
    // The load ends here (and on any early return above, when it is dropped).
    drop(load_process);
    // The simulated cell's ground truth, saved by the board as it stops with the controller.
    up.stop();
    let touched = cell::side_collisions(&up.state).map_err(|e| format!("{e:#}"));
    let (p99_first, p99_last) = (window_p99(&h0, &h1), window_p99(&h2, &h3));
    let rss_allowed = rss_half + (rss_half * RSS_SLACK_PCT / 100).max(RSS_SLACK_KIB);
    let mut fails: Vec<String> = Vec::new();
    if !alive {
        fails.push("the controller died".into());
    }
    fails.extend(failures.iter().map(|f| format!("client failed: {f}")));
    if tally.unanswered > 0 {
        fails.push(format!(
            "{} request(s) not answered as the protocol says",
            tally.unanswered
        ));
    }
    match &touched {
        Ok((0, _)) => {}
        Ok((n, latest)) => fails.push(format!(
            "{n} side collision(s) in the simulated cell, the latest at {}",
            latest.as_deref().unwrap_or("?")
        )),
        Err(e) => fails.push(format!("the simulated cell could not be read: {e}")),
    }
    if fds_end > fds_before {
        fails.push(format!(
            "descriptors left behind ({fds_before} before, {fds_end} after)"
        ));
    }
    if rss_end > rss_allowed {
        fails.push(format!(
            "resident memory grew in the second half ({rss_half} → {rss_end} KiB, allowed {rss_allowed})"
        ));
    }
    fails.extend(servo.failures());
    let pass = fails.is_empty();

    println!(
        "wrc bench soak: {} clients, {:.0} s, seed {}",
        args.clients, secs, args.seed
    );
    println!(
        "  requests           {} ({:.0}/s), answered {}",
        tally.requests,
        tally.requests as f64 / secs,
        tally.replies
    );
    println!(
        "  invalid lines      {} (one NAK each expected)",
        tally.invalid_lines
    );
    println!(
        "  not as expected    {}{}",
        tally.unanswered,
        if tally.wrong.is_empty() {
            String::new()
        } else {
            format!(": {}", tally.wrong.join("; "))
        }
    );
    println!(
        "  motions            {} ({} round the cell through the travel height) ended INF {}, ABS {:?}; refused {:?} (117: would touch the cell)",
        tally.motions, tally.routed, tally.inf, tally.abs, tally.refused
    );
    println!(
        "  cell               {}",
        match &touched {
            Ok((n, latest)) => format!(
                "{n} side collision(s){}",
                latest
                    .as_deref()
                    .map_or(String::new(), |at| format!(", the latest at {at}"))
            ),
            Err(e) => e.clone(),
        }
    );
    println!(
        "  reconnects         {}, ESTOPs {}",
        tally.reconnects, tally.estops
    );
    println!(
        "  controller         {}",
        if alive { "running" } else { "DEAD" }
    );
    println!("  descriptors        {fds_before} before the clients, {fds_end} after");
    println!("  resident memory    {rss_warm} KiB after the warm-up, {rss_half} KiB at half time, {rss_end} KiB at the end (allowed {rss_allowed})");
    let step = rss_series.len().div_ceil(8).max(1);
    let series: Vec<String> = rss_series
        .iter()
        .step_by(step)
        .map(|(t, kib)| format!("{t} s {kib}"))
        .collect();
    println!("  memory over time   {} KiB", series.join(", "));
    println!(
        "  PG latency p99     {} µs in the first tenth, {} µs in the last (bin bounds)",
        p99_first.map_or("-".into(), |v| v.to_string()),
        p99_last.map_or("-".into(), |v| v.to_string())
    );
    let condition = format!(
        "{} ms, {}, {secs:.0} s",
        servo_num(period_ms),
        if args.load { "stress-ng" } else { "idle" }
    );
    print_table(&condition, &servo.rows());
    println!(
        "  (PG p50 is the upper bound of its power-of-two bin over the run; PG p99 and max are"
    );
    println!(
        "  the controller's own since it started; cyclictest ran the same seconds beside it.)"
    );
    for f in &fails {
        println!("  fails              {f}");
    }
    println!(
        "  verdict            {}",
        if pass { "pass" } else { "FAIL" }
    );
    if let Some(path) = &args.json {
        let report = json!({
            "seconds": secs,
            "clients": args.clients,
            "seed": args.seed,
            "requests": tally.requests,
            "replies": tally.replies,
            "invalid_lines": tally.invalid_lines,
            "unanswered": tally.unanswered,
            "problems": tally.wrong,
            "motions": tally.motions,
            "routed": tally.routed,
            "inf": tally.inf,
            "abs": tally.abs,
            "refused": tally.refused,
            "reconnects": tally.reconnects,
            "estops": tally.estops,
            "side_collisions": touched.as_ref().ok().map(|(n, _)| n),
            "last_side_collision": touched.as_ref().ok().and_then(|(_, at)| at.clone()),
            "alive": alive,
            "client_failures": failures,
            "fds_before": fds_before,
            "fds_after": fds_end,
            "rss_warm_kib": rss_warm,
            "rss_half_kib": rss_half,
            "rss_series_s_kib": rss_series,
            "rss_end_kib": rss_end,
            "rss_allowed_kib": rss_allowed,
            "pg_latency_p99_us_first": p99_first,
            "pg_latency_p99_us_last": p99_last,
            "condition": condition,
            "servo": servo.to_json(),
            "failures": fails,
            "pass": pass,
        });
        std::fs::write(path, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(if pass {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// The servo table: one row per figure, the run's column and the goal's.
fn print_table(condition: &str, rows: &[servo::Row]) {
    let width = rows
        .iter()
        .map(|r| r.what.chars().count())
        .max()
        .unwrap_or(0);
    let value_width = rows
        .iter()
        .map(|r| r.value.chars().count())
        .chain([condition.chars().count()])
        .max()
        .unwrap_or(0);
    println!("  servo loop:");
    println!("  | {:width$} | {condition:value_width$} | goal", "figure");
    for r in rows {
        println!(
            "  | {:width$} | {:value_width$} | {}",
            r.what, r.value, r.goal
        );
    }
}

/// A period for the condition's name: `1`, `10`, `0.5`.
fn servo_num(ms: f64) -> String {
    format!("{}", (ms * 1000.0).round() / 1000.0)
}

/// Wait until `t`, with a `STATUS` on the probe connection every [`KEEP_ALIVE_S`]: it holds
/// no control, so the controller would close it after its idle timeout.
fn keep_alive_until(
    probe: &mut Conn,
    t: Instant,
    each: &mut dyn FnMut(Instant),
) -> anyhow::Result<()> {
    loop {
        let left = t.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Ok(());
        }
        std::thread::sleep(left.min(Duration::from_secs(KEEP_ALIVE_S)));
        if ask(probe, "STATUS")?.reply.is_none() {
            bail!("the controller did not answer STATUS within {REPLY_S} s");
        }
        each(Instant::now());
    }
}
