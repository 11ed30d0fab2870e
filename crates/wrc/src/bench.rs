//! `wrc bench …`: measurements. `wrc bench rt` runs the paper's task set on the real-time
//! runtime and prints its Tables 3, 4 and 5 with a cyclictest reference (wrc-rt measures;
//! this module parses, shows progress, prints and writes JSON).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use crate::bench_rt::{self as bench, BenchOptions, BenchReport};
use anyhow::Context;
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::{json, Value};
use wrc_rt::{fifo_priority, Notice, RealtimeMode, Summary};

/// Benchmarks.
#[derive(Debug, Args)]
pub struct BenchArgs {
    #[command(subcommand)]
    what: BenchWhat,
}

#[derive(Debug, Subcommand)]
enum BenchWhat {
    /// Run the real-time task set (paper Table 1) and print periods, execution times and IPC
    /// latencies (paper Tables 3-5), with cyclictest as the reference.
    Rt(RtArgs),
    /// Run the controller with a simulated board and measure, idle and while 200 TCP clients
    /// poll STATUS: request → reply, motion request → first pulse, ESTOP → first braking
    /// period (read and sent) and → the simulator stream, and the Pulse Generator's jitter.
    Controller(crate::bench_controller::ControllerArgs),
    /// Straight lines against the time-optimal lower bound: random reachable lines planned
    /// and run; durations, limits used, accuracy and planning time.
    Motion(crate::bench_motion::MotionArgs),
    /// Stopping times and distances (ISO 10218-1 Annex B): every axis and a straight line, at
    /// 33, 66 and 100 % speed, stopped at peak acceleration and in cruise, ESTOP and STOP,
    /// from the output pulses, against the time-optimal brake.
    Stop(crate::bench_stop::StopArgs),
    /// Wafer throughput on the demo cell: standard GET/PUT sequences, wafers per hour,
    /// seconds per GET and PUT, moving vs waiting, and each transfer against the
    /// time-optimal time of its path (virtual time; `--real-time` on `wrc up`).
    Cell(crate::bench_cell::CellArgs),
    /// A sustained run of `wrc up` under random valid and invalid requests from several
    /// clients while the robot moves: no crash, every request answered, no descriptor or
    /// memory left behind, the Pulse Generator's jitter at the end as at the start; and the
    /// servo loop at its period (`--period-ms 1`: 1 kHz), idle or under `--load`: underruns,
    /// watchdog and following-error trips, lost pulses, overruns, the deepest FIFO drain and
    /// the Pulse Generator's wake-up latency beside cyclictest's.
    Soak(crate::bench_soak::SoakArgs),
    /// Measure the Pulse Generator's jitter with no GUI, with `wrc ui` serving browsers, and
    /// after `kill -9` of `wrc ui`: the GUI must not disturb control.
    Ui(crate::bench_ui::UiBenchArgs),
    /// Fault-injection campaign on loopback: kill -9 of the board, the controller and the
    /// GUI, E-stop, vacuum loss, following error, serial garbage and unplugging, a client
    /// dropping mid-command, a full or read-only state directory, corrupt state files; each
    /// injected at random (seeded) moments and judged: detected, stopped safely, wafer map
    /// consistent with the simulated cell, recovered.
    Faults(crate::bench_faults::FaultsArgs),
}

#[derive(Debug, Args)]
struct RtArgs {
    /// How long to measure [s].
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u64).range(1..=86_400))]
    seconds: u64,
    /// Run a CPU and memory stressor meanwhile (stress-ng when installed, else a built-in one).
    #[arg(long)]
    load: bool,
    /// Pulse Generator period (and cyclictest interval) [µs]; default from the task table.
    #[arg(long, value_name = "P", value_parser = clap::value_parser!(u64).range(100..=10_000_000))]
    period_us: Option<u64>,
    /// Write every figure as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Take the task table from this config file instead of the embedded default.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Do not ask for SCHED_FIFO or locked memory (normal scheduling).
    #[arg(long)]
    no_rt: bool,
    /// Do not run cyclictest even when it is installed.
    #[arg(long)]
    no_cyclictest: bool,
}

/// Run a benchmark subcommand.
pub fn run(args: BenchArgs) -> anyhow::Result<ExitCode> {
    match args.what {
        BenchWhat::Rt(args) => run_rt(args),
        BenchWhat::Controller(args) => crate::bench_controller::run(args),
        BenchWhat::Ui(args) => crate::bench_ui::run(args),
        BenchWhat::Motion(args) => crate::bench_motion::run(args),
        BenchWhat::Stop(args) => crate::bench_stop::run(args),
        BenchWhat::Cell(args) => crate::bench_cell::run(args),
        BenchWhat::Soak(args) => crate::bench_soak::run(args),
        BenchWhat::Faults(args) => crate::bench_faults::run(args),
    }
}

fn run_rt(args: RtArgs) -> anyhow::Result<ExitCode> {
    let config = wrc_config::Config::load(args.config.as_deref())?;
    let options = BenchOptions {
        table: config.tasks.clone(),
        seconds: args.seconds,
        load: args.load,
        pulse_period_us: args.period_us,
        realtime: if args.no_rt {
            RealtimeMode::Off
        } else {
            RealtimeMode::Auto
        },
        cyclictest: !args.no_cyclictest,
    };
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template("{spinner} measuring [{bar:40}] {elapsed}/{msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(format!("{}s", args.seconds));
    bar.enable_steady_tick(Duration::from_millis(200));
    let notice_bar = bar.clone();
    let notices: wrc_rt::NoticeSink = Arc::new(move |n: &Notice| notice_bar.println(n.to_string()));
    let mut progress = |f: f64| bar.set_position((f * 1000.0) as u64);
    let report = bench::run(&options, notices, &mut progress);
    bar.finish_and_clear();
    let report = report.context("wrc bench rt")?;

    print_report(&report);
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&to_json(&report))?;
        std::fs::write(path, text + "\n")
            .with_context(|| format!("cannot write {}", path.display()))?;
        println!("\nJSON written to {}", path.display());
    }
    if let Some(problem) = &report.stop_problem {
        eprintln!("wrc: {problem}");
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}

fn print_report(r: &BenchReport) {
    println!("wrc bench rt: {} s, {}", r.seconds, r.sched);
    if let Some(load) = &r.load {
        println!("load: {load}");
    }

    println!("\nTable 3 — task periods [µs] (wake-up to wake-up of the periodic releases)");
    println!(
        "{:<20} {:>4} {:>4} {:>9} {:>9} {:>9} {:>9} {:>9} {:>7} {:>8} {:>7}",
        "task",
        "prio",
        "fifo",
        "period",
        "min",
        "max",
        "avg",
        "p99",
        "cycles",
        "overruns",
        "events"
    );
    for t in &r.tasks {
        let s = Summary::of(&t.stats.period);
        println!(
            "{:<20} {:>4} {:>4} {:>9} {:>9.0} {:>9.0} {:>9.0} {:>9.0} {:>7} {:>8} {:>7}",
            t.spec.label(),
            t.spec.priority,
            fifo_priority(t.spec.priority),
            t.spec.period_us,
            s.min_us,
            s.max_us,
            s.avg_us,
            s.p99_us,
            t.stats.cycles,
            t.stats.overruns,
            t.stats.event_cycles
        );
    }

    println!("\nTable 4 — execution time [µs] (wake-up to end of work; synthetic work after the paper's Table 4)");
    println!(
        "{:<20} {:>9} {:>9} {:>9} {:>9}",
        "task", "min", "max", "avg", "p99"
    );
    for t in &r.tasks {
        let s = Summary::of(&t.stats.exec);
        println!(
            "{:<20} {:>9.1} {:>9.1} {:>9.1} {:>9.1}",
            t.spec.label(),
            s.min_us,
            s.max_us,
            s.avg_us,
            s.p99_us
        );
    }

    if r.tasks.iter().any(|t| t.stats.event_cycles > 0) {
        println!("\nEvent-released cycles — execution time [µs] (apart from the periodic ones)");
        println!(
            "{:<20} {:>9} {:>9} {:>9} {:>9} {:>7}",
            "task", "min", "max", "avg", "p99", "cycles"
        );
        for t in r.tasks.iter().filter(|t| t.stats.event_cycles > 0) {
            let s = Summary::of(&t.stats.event_exec);
            println!(
                "{:<20} {:>9.1} {:>9.1} {:>9.1} {:>9.1} {:>7}",
                t.spec.label(),
                s.min_us,
                s.max_us,
                s.avg_us,
                s.p99_us,
                t.stats.event_cycles
            );
        }
    }

    println!("\nWake-up latency [µs] (actual minus scheduled wake-up; what cyclictest measures)");
    println!(
        "{:<20} {:>9} {:>9} {:>9} {:>9} {:>9}",
        "task", "min", "avg", "p50", "p99", "max"
    );
    for t in &r.tasks {
        let s = Summary::of(&t.stats.latency);
        println!(
            "{:<20} {:>9.1} {:>9.1} {:>9.1} {:>9.1} {:>9.1}",
            t.spec.label(),
            s.min_us,
            s.avg_us,
            s.p50_us,
            s.p99_us,
            s.max_us
        );
    }

    println!("\nTable 5 — IPC latency [µs] (send → receiver running)");
    println!(
        "{:<20} {:>9} {:>9} {:>9} {:>9} {:>9} {:>7}",
        "kind", "min", "max", "avg", "p50", "p99", "samples"
    );
    for (kind, h) in &r.ipc {
        let s = Summary::of(h);
        println!(
            "{:<20} {:>9.1} {:>9.1} {:>9.1} {:>9.1} {:>9.1} {:>7}",
            kind.label(),
            s.min_us,
            s.max_us,
            s.avg_us,
            s.p50_us,
            s.p99_us,
            s.count
        );
    }

    println!();
    match &r.cyclictest {
        Ok(ct) => {
            println!(
                "cyclictest (same run: {}): min {:.0} avg {:.0} p99 {:.0} max {:.0} µs, {} samples",
                ct.command, ct.min_us, ct.avg_us, ct.p99_us, ct.max_us, ct.samples
            );
            if let (Some(pg), Some(ratio)) = (r.pulse_latency(), r.pulse_vs_cyclictest()) {
                let mark = |ok: bool| if ok { "meets" } else { "MISSES" };
                println!(
                    "Pulse Generator vs cyclictest: p99 {:.1} / {:.0} µs = {:.2} ({} target ≤ 1.2), \
                     max {:.1} / {:.0} µs = {:.2} ({} target ≤ 1.5)",
                    pg.p99_us,
                    ct.p99_us,
                    ratio.p99_ratio,
                    mark(ratio.p99_ratio <= 1.2),
                    pg.max_us,
                    ct.max_us,
                    ratio.max_ratio,
                    mark(ratio.max_ratio <= 1.5)
                );
            }
        }
        Err(why) => println!("cyclictest: none ({why})"),
    }
}

fn summary_json(s: &Summary) -> Value {
    json!({
        "min_us": s.min_us, "max_us": s.max_us, "avg_us": s.avg_us,
        "p50_us": s.p50_us, "p99_us": s.p99_us, "samples": s.count,
    })
}

fn to_json(r: &BenchReport) -> Value {
    let tasks: Vec<Value> = r
        .tasks
        .iter()
        .map(|t| {
            json!({
                "name": t.spec.name,
                "label": t.spec.label(),
                "priority": t.spec.priority,
                "fifo_priority": fifo_priority(t.spec.priority),
                "period_us": t.spec.period_us,
                "period": summary_json(&Summary::of(&t.stats.period)),
                "exec": summary_json(&Summary::of(&t.stats.exec)),
                "latency": summary_json(&Summary::of(&t.stats.latency)),
                "cycles": t.stats.cycles,
                "overruns": t.stats.overruns,
                "missed_periods": t.stats.missed_periods,
                "event_cycles": t.stats.event_cycles,
                "event_exec": summary_json(&Summary::of(&t.stats.event_exec)),
            })
        })
        .collect();
    let ipc: Vec<Value> = r
        .ipc
        .iter()
        .map(|(kind, h)| {
            let mut v = summary_json(&Summary::of(h));
            v["kind"] = json!(kind.key());
            v
        })
        .collect();
    let cyclictest = match &r.cyclictest {
        Ok(ct) => json!({
            "min_us": ct.min_us, "avg_us": ct.avg_us, "p50_us": ct.p50_us, "p99_us": ct.p99_us, "max_us": ct.max_us,
            "samples": ct.samples, "command": ct.command,
        }),
        Err(_) => Value::Null,
    };
    let ratio = match r.pulse_vs_cyclictest() {
        Some(q) => json!({ "p99_ratio": q.p99_ratio, "max_ratio": q.max_ratio }),
        None => Value::Null,
    };
    json!({
        "seconds": r.seconds,
        "realtime": r.sched.is_realtime(),
        "scheduling": r.sched.to_string(),
        "load": r.load,
        "tasks": tasks,
        "ipc": ipc,
        "cyclictest": cyclictest,
        "cyclictest_unavailable": r.cyclictest.as_ref().err(),
        "pulse_vs_cyclictest": ratio,
        "stop_problem": r.stop_problem,
    })
}
