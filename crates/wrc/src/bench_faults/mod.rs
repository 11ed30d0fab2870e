//! `wrc bench faults`: a fault-injection campaign against real processes on loopback. Each
//! fault kind is injected `--rounds` times at a random moment (seeded) into a wafer transfer
//! or a move of the demo cell, and each round judges, from outside the controller as an
//! operator would: was the fault **detected** (and how long after it was injected), did the
//! motion **stop safely** (the arm at rest on the board within a stated bound, or the motion
//! carried on where that is the right answer; and, where the kind says so, no side collision
//! in the simulated cell: no station touched off its line), is the **wafer map consistent**
//! with the simulated cell afterwards (in memory and on disk, wafer by wafer), and is the
//! controller **recovered** and usable again (`RESET`, or a restart, then a transfer to its
//! `INF`).
//!
//! Everything runs in temporary directories on free loopback ports; the default state
//! directory, ports and GUI of `wrc up` are never touched. The campaign is bounded in time
//! (`--max-minutes`) and every wait in it has a deadline.

mod disk;
mod harness;
mod kinds;
mod lines;
mod power;
mod processes;
mod session;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use clap::Args;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub(crate) use kinds::Kind;

/// Arguments of `wrc bench faults`.
#[derive(Debug, Args)]
pub struct FaultsArgs {
    /// Seed of the random moments, fault details and corruptions.
    #[arg(long, default_value_t = 2026)]
    seed: u64,
    /// Injections per fault kind.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    rounds: u32,
    /// Only these fault kinds (comma-separated; `--list` names them).
    #[arg(long, value_name = "KIND,...", value_delimiter = ',')]
    only: Vec<String>,
    /// List the fault kinds and what each round judges, and exit.
    #[arg(long)]
    list: bool,
    /// Write every round and the table as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Stop injecting once the campaign has run this long; rounds not run are reported.
    #[arg(long, default_value_t = 10.0)]
    max_minutes: f64,
    /// Keep the campaign's temporary directory (state directories, logs, traces of every
    /// alarm) and say where it is.
    #[arg(long)]
    keep: bool,
    /// Run the controllers and boards without SCHED_FIFO (and with the lenient watchdog and
    /// heartbeat `wrc up` then uses).
    #[arg(long)]
    no_rt: bool,
}

/// What a round found for one of the judged properties.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Verdict {
    /// It holds; how it was seen.
    Pass(String),
    /// It does not; what was seen.
    Fail(String),
    /// The round ended before it could be judged.
    NotReached,
}

impl Verdict {
    /// `Pass` when `ok`, else `Fail`, with the same text.
    pub(crate) fn from(ok: bool, text: String) -> Verdict {
        if ok {
            Verdict::Pass(text)
        } else {
            Verdict::Fail(text)
        }
    }

    fn is_pass(&self) -> bool {
        matches!(self, Verdict::Pass(_))
    }

    fn json(&self) -> serde_json::Value {
        match self {
            Verdict::Pass(t) => serde_json::json!({"pass": true, "seen": t}),
            Verdict::Fail(t) => serde_json::json!({"pass": false, "seen": t}),
            Verdict::NotReached => serde_json::json!({"pass": false, "seen": "not reached"}),
        }
    }
}

/// One injection and what came of it.
#[derive(Debug, Clone)]
pub(crate) struct Round {
    /// What the robot was doing when the fault came (`GET LP1 7, 1.234 s in`).
    pub(crate) moment: String,
    /// Injection → the signal [ms], when it came.
    pub(crate) latency_ms: Option<f64>,
    /// The signal (an `EVT ERROR` line, a log line, a refusal).
    pub(crate) signal: String,
    pub(crate) stopped: Verdict,
    pub(crate) consistent: Verdict,
    pub(crate) recovered: Verdict,
    /// The harness failed mid-round (a process that would not start, a reply that never
    /// came): what, for the report.
    pub(crate) error: Option<String>,
    /// What the host connection heard during the round (for the JSON report).
    pub(crate) transcript: Vec<String>,
    /// Another fault the controller raised during the round (an `EVT ERROR` with another
    /// code than the injected fault's): the round was disturbed, not necessarily wrong.
    pub(crate) disturbed: Vec<String>,
}

impl Round {
    pub(crate) fn new(moment: String) -> Round {
        Round {
            moment,
            latency_ms: None,
            signal: String::new(),
            stopped: Verdict::NotReached,
            consistent: Verdict::NotReached,
            recovered: Verdict::NotReached,
            error: None,
            transcript: Vec::new(),
            disturbed: Vec::new(),
        }
    }

    /// Detected at `at`, injected at `t0`, by `signal`.
    pub(crate) fn detected(&mut self, t0: Instant, at: Instant, signal: &str) {
        self.latency_ms = Some(at.saturating_duration_since(t0).as_secs_f64() * 1e3);
        self.signal = signal.to_string();
    }

    /// Every judged property holds.
    fn clean(&self) -> bool {
        self.error.is_none()
            && self.latency_ms.is_some()
            && [&self.stopped, &self.consistent, &self.recovered]
                .iter()
                .all(|v| v.is_pass())
    }
}

/// What every round needs: the random source, where to put things, how to run processes,
/// the campaign's deadline.
pub(crate) struct Ctx {
    pub(crate) rng: ChaCha8Rng,
    /// A directory of this run (removed at the end).
    pub(crate) root: PathBuf,
    /// Controllers and boards run with SCHED_FIFO where allowed.
    pub(crate) rt: bool,
    /// Stop injecting after this.
    pub(crate) deadline: Instant,
    /// A configuration with the watchdog and heartbeat `wrc up` uses for its own boards
    /// when not real-time, for the controllers the campaign starts on a board of its own.
    pub(crate) lenient_config: PathBuf,
}

impl Ctx {
    /// A random delay between `lo` and `hi` [ms].
    pub(crate) fn delay(&mut self, lo_ms: u64, hi_ms: u64) -> Duration {
        Duration::from_millis(self.rng.random_range(lo_ms..=hi_ms))
    }

    /// A fresh directory under the run's root.
    pub(crate) fn dir(&self, name: &str) -> anyhow::Result<PathBuf> {
        let d = self.root.join(name);
        std::fs::create_dir_all(&d).with_context(|| format!("cannot create {}", d.display()))?;
        Ok(d)
    }

    /// Whether the campaign's time is up.
    pub(crate) fn out_of_time(&self) -> bool {
        Instant::now() >= self.deadline
    }

    #[cfg(test)]
    pub(crate) fn for_tests(seed: u64) -> Ctx {
        Ctx {
            rng: ChaCha8Rng::seed_from_u64(seed),
            root: std::env::temp_dir(),
            rt: false,
            deadline: Instant::now() + Duration::from_secs(60),
            lenient_config: PathBuf::new(),
        }
    }
}

/// A kind's rows: what ran and what it found.
struct KindReport {
    kind: Kind,
    rounds: Vec<Round>,
    /// Rounds not run (the campaign's time ran out) or a set-up that failed.
    skipped: Option<String>,
}

/// p50 and max of `v` (nearest rank).
fn p50_max(v: &[f64]) -> Option<(f64, f64)> {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    (n > 0).then(|| (s[(n - 1) / 2], s[n - 1]))
}

fn count(rounds: &[Round], f: impl Fn(&Round) -> &Verdict) -> String {
    let pass = rounds.iter().filter(|r| f(r).is_pass()).count();
    format!("{pass}/{}", rounds.len())
}

impl KindReport {
    fn row(&self) -> [String; 7] {
        let injected = self.rounds.len();
        let latencies: Vec<f64> = self.rounds.iter().filter_map(|r| r.latency_ms).collect();
        let latency = p50_max(&latencies).map_or("—".into(), |(p50, max)| {
            format!("{} / {}", fmt_ms(p50), fmt_ms(max))
        });
        [
            self.kind.name().to_string(),
            injected.to_string(),
            format!("{}/{injected}", latencies.len()),
            latency,
            count(&self.rounds, |r| &r.stopped),
            count(&self.rounds, |r| &r.consistent),
            count(&self.rounds, |r| &r.recovered),
        ]
    }
}

fn fmt_ms(ms: f64) -> String {
    if ms >= 100.0 {
        format!("{ms:.0}")
    } else {
        format!("{ms:.1}")
    }
}

/// Run `wrc bench faults`.
pub fn run(args: FaultsArgs) -> anyhow::Result<ExitCode> {
    if args.list {
        for k in Kind::ALL {
            println!("{:<18} {}", k.name(), k.about());
        }
        return Ok(ExitCode::SUCCESS);
    }
    let kinds: Vec<Kind> = if args.only.is_empty() {
        Kind::ALL.to_vec()
    } else {
        args.only
            .iter()
            .map(|name| {
                Kind::ALL
                    .iter()
                    .copied()
                    .find(|k| k.name() == name.trim())
                    .with_context(|| {
                        format!("--only {name}: no such fault kind; `wrc bench faults --list` names them")
                    })
            })
            .collect::<anyhow::Result<_>>()?
    };
    if !args.max_minutes.is_finite() || args.max_minutes <= 0.0 || args.max_minutes > 1440.0 {
        bail!(
            "--max-minutes {}: expected more than 0 and at most 1440",
            args.max_minutes
        );
    }
    let started = Instant::now();
    let root = tempfile::Builder::new()
        .prefix("wrc-faults-")
        .tempdir()
        .context("cannot create a temporary directory")?;
    let rt = !args.no_rt && crate::up::fifo_allowed();
    let lenient_config = root.path().join("lenient.toml");
    std::fs::write(&lenient_config, lenient_config_text())?;
    let mut ctx = Ctx {
        rng: ChaCha8Rng::seed_from_u64(args.seed),
        root: root.path().to_path_buf(),
        rt,
        deadline: started + Duration::from_secs_f64(args.max_minutes * 60.0),
        lenient_config,
    };
    println!(
        "wrc bench faults: seed {}, {} round(s) per kind, {} kind(s), {}, at most {} min",
        args.seed,
        args.rounds,
        kinds.len(),
        if rt {
            "SCHED_FIFO"
        } else {
            "normal scheduling"
        },
        args.max_minutes
    );
    let mut reports = Vec::new();
    let mut shared = None;
    for kind in kinds {
        if ctx.out_of_time() {
            reports.push(KindReport {
                kind,
                rounds: Vec::new(),
                skipped: Some("the campaign's time ran out before it".into()),
            });
            continue;
        }
        eprintln!("{}: {} round(s) …", kind.name(), args.rounds);
        let (rounds, skipped) = kinds::run(kind, &mut ctx, args.rounds, &mut shared);
        for (i, r) in rounds.iter().enumerate() {
            let mark = if r.clean() { "ok" } else { "FAULT" };
            eprintln!(
                "  {} round {}: {mark}: {} → {} in {}",
                kind.name(),
                i + 1,
                r.moment,
                if r.signal.is_empty() {
                    "no signal"
                } else {
                    &r.signal
                },
                r.latency_ms.map_or("—".into(), |l| format!("{l:.1} ms"))
            );
        }
        if let Some(why) = &skipped {
            eprintln!("  {}: {why}", kind.name());
        }
        reports.push(KindReport {
            kind,
            rounds,
            skipped,
        });
    }
    drop(shared);
    let elapsed = started.elapsed();
    if args.keep {
        let kept = root.keep();
        eprintln!("the campaign's files are kept in {}", kept.display());
    }
    print_table(&reports, &args, rt, elapsed);
    if let Some(path) = &args.json {
        write_json(path, &reports, &args, rt, elapsed)?;
        println!("\nJSON written to {}", path.display());
    }
    let all_clean = reports
        .iter()
        .all(|r| r.skipped.is_none() && r.rounds.iter().all(Round::clean));
    Ok(if all_clean {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// The embedded configuration with the host watchdog and the heartbeat at 1 s, as `wrc up`
/// sets them for its own boards when it runs without SCHED_FIFO.
fn lenient_config_text() -> String {
    wrc_config::DEFAULT_TOML
        .lines()
        .map(|l| {
            if l.starts_with("watchdog_ms") {
                "watchdog_ms = 1000.0".to_string()
            } else if l.starts_with("heartbeat_ms") {
                "heartbeat_ms = 1000.0".to_string()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

const HEADER: [&str; 7] = [
    "fault",
    "injected",
    "detected",
    "latency p50 / max [ms]",
    "stopped safely",
    "map consistent",
    "recovered",
];

fn print_table(reports: &[KindReport], args: &FaultsArgs, rt: bool, elapsed: Duration) {
    println!(
        "\nFault campaign: `wrc bench faults --seed {} --rounds {}{}`, {}, {:.0} s",
        args.seed,
        args.rounds,
        if args.only.is_empty() {
            String::new()
        } else {
            format!(" --only {}", args.only.join(","))
        },
        if rt {
            "SCHED_FIFO"
        } else {
            "normal scheduling"
        },
        elapsed.as_secs_f64()
    );
    println!("\n| {} |", HEADER.join(" | "));
    println!("|{}", "---|".repeat(HEADER.len()));
    for r in reports {
        println!("| {} |", r.row().join(" | "));
    }
    println!("\nHow each fault is injected, and what counts (see `--list`):");
    for r in reports {
        println!("- {}: {}", r.kind.name(), r.kind.about());
    }
    let mut problems = Vec::new();
    for r in reports {
        if let Some(why) = &r.skipped {
            problems.push(format!("{}: {why}", r.kind.name()));
        }
        for (i, round) in r.rounds.iter().enumerate() {
            if round.clean() && round.disturbed.is_empty() {
                continue;
            }
            let mut what = Vec::new();
            if !round.disturbed.is_empty() {
                what.push(format!("disturbed by {}", round.disturbed.join(", ")));
            }
            if let Some(e) = &round.error {
                what.push(format!("error: {e}"));
            }
            if round.latency_ms.is_none() {
                what.push("not detected".into());
            }
            for (name, v) in [
                ("stopped", &round.stopped),
                ("map", &round.consistent),
                ("recovered", &round.recovered),
            ] {
                match v {
                    Verdict::Fail(t) => what.push(format!("{name}: {t}")),
                    Verdict::NotReached => what.push(format!("{name}: not reached")),
                    Verdict::Pass(_) => {}
                }
            }
            problems.push(format!(
                "{} round {} ({}): {}",
                r.kind.name(),
                i + 1,
                round.moment,
                what.join("; ")
            ));
        }
    }
    if problems.is_empty() {
        println!("\nEvery round: detected, stopped safely, map consistent, recovered.");
    } else {
        println!("\nRounds with a finding (or disturbed by another fault):");
        for p in problems {
            println!("- {p}");
        }
    }
}

fn write_json(
    path: &Path,
    reports: &[KindReport],
    args: &FaultsArgs,
    rt: bool,
    elapsed: Duration,
) -> anyhow::Result<()> {
    let kinds: Vec<serde_json::Value> = reports
        .iter()
        .map(|r| {
            let row = r.row();
            let rounds: Vec<serde_json::Value> = r
                .rounds
                .iter()
                .map(|x| {
                    serde_json::json!({
                        "moment": x.moment,
                        "latency_ms": x.latency_ms,
                        "signal": x.signal,
                        "stopped": x.stopped.json(),
                        "consistent": x.consistent.json(),
                        "recovered": x.recovered.json(),
                        "error": x.error,
                        "clean": x.clean(),
                        "transcript": x.transcript,
                        "disturbed": x.disturbed,
                    })
                })
                .collect();
            serde_json::json!({
                "kind": r.kind.name(),
                "about": r.kind.about(),
                "injected": r.rounds.len(),
                "detected": row[2],
                "latency_p50_max_ms": row[3],
                "stopped": row[4],
                "consistent": row[5],
                "recovered": row[6],
                "skipped": r.skipped,
                "rounds": rounds,
            })
        })
        .collect();
    let json = serde_json::json!({
        "seed": args.seed,
        "rounds": args.rounds,
        "realtime": rt,
        "seconds": elapsed.as_secs_f64(),
        "kinds": kinds,
    });
    std::fs::write(path, serde_json::to_string_pretty(&json)? + "\n")
        .with_context(|| format!("cannot write {}", path.display()))
}

#[cfg(test)]
mod tests {
    /// The lenient configuration keeps the embedded one but gives the host watchdog and the
    /// heartbeat 1 s (a rewritten key that no longer exists would leave them at 50 and 30 ms).
    #[test]
    fn the_lenient_configuration_gives_the_watchdog_and_the_heartbeat_a_second() {
        let c = wrc_config::Config::parse(&super::lenient_config_text(), "lenient").unwrap();
        let d = wrc_config::Config::embedded_default();
        let periods = (1.0 / d.motion.period_s).round() as u32;
        assert_eq!(c.boards[0].watchdog_periods, periods);
        assert_eq!(c.boards[0].heartbeat_periods, periods);
        assert_eq!(c.robot, d.robot);
    }
}
