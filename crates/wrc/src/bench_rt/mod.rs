//! `wrc bench rt`: run the paper's Table 1 task set with synthetic work sized like its Table 4,
//! probe IPC latency (Table 5) and run cyclictest in the same run for reference. The binary
//! prints and writes JSON; this module measures.

pub mod cyclictest;
pub mod ipc_latency;
pub mod load;
pub mod work;

use std::time::{Duration, Instant};

use wrc_rt::histogram::Histogram;
use wrc_rt::ipc;
use wrc_rt::notice::NoticeSink;
use wrc_rt::runtime::{Runtime, RuntimeError, RuntimeOptions, TaskSnapshot};
use wrc_rt::sched_policy::{fifo_priority, isolated_cpus, PinPolicy, RealtimeMode, SchedReport};
use wrc_rt::stats::Summary;
use wrc_rt::table::{TaskTable, TaskTableError};

pub use cyclictest::CyclictestResult;
pub use ipc_latency::IpcKind;

/// Name of the task compared with cyclictest.
pub const PULSE_GENERATOR: &str = "pulse_generator";

/// What to run.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// The task set (the paper's Table 1 by default, or the config's).
    pub table: TaskTable,
    /// How long to measure [s] (> 0).
    pub seconds: u64,
    /// Run a CPU and memory load meanwhile.
    pub load: bool,
    /// Override the Pulse Generator's period (and cyclictest's interval) [µs].
    pub pulse_period_us: Option<u64>,
    /// Ask for SCHED_FIFO.
    pub realtime: RealtimeMode,
    /// Run cyclictest when it is installed.
    pub cyclictest: bool,
}

/// A benchmark that could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BenchError {
    /// `seconds` was 0.
    #[error("the measurement must last at least 1 s")]
    ZeroSeconds,
    /// The Pulse Generator period override is not a valid period.
    #[error("--period-us: {0}")]
    Period(TaskTableError),
    /// The runtime could not start.
    #[error(transparent)]
    Runtime(#[from] RuntimeError),
    /// The loopback socket for the UDP probe could not be opened.
    #[error("cannot open the UDP probe's loopback socket: {0}")]
    Udp(std::io::Error),
}

/// Everything one run measured.
#[derive(Debug, Clone)]
pub struct BenchReport {
    /// Planned length [s].
    pub seconds: u64,
    /// What scheduling the tasks got.
    pub sched: SchedReport,
    /// Tasks that did not stop or panicked, if any.
    pub stop_problem: Option<String>,
    /// The load that ran, if any.
    pub load: Option<String>,
    /// Per-task statistics (Tables 3 and 4, and wake-up latency).
    pub tasks: Vec<TaskSnapshot>,
    /// IPC latencies [ns] (Table 5).
    pub ipc: Vec<(IpcKind, Histogram)>,
    /// cyclictest's figures, or why there are none.
    pub cyclictest: Result<CyclictestResult, String>,
}

/// Pulse Generator wake-up latency over cyclictest's: (p99 ratio, max ratio).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ratio {
    /// Pulse Generator p99 / cyclictest p99.
    pub p99_ratio: f64,
    /// Pulse Generator max / cyclictest max.
    pub max_ratio: f64,
}

impl BenchReport {
    /// The Pulse Generator's wake-up latency summary [µs].
    pub fn pulse_latency(&self) -> Option<Summary> {
        self.tasks
            .iter()
            .find(|t| t.spec.name == PULSE_GENERATOR)
            .map(|t| Summary::of(&t.stats.latency))
    }

    /// The Pulse Generator's wake-up latency relative to cyclictest's, when both exist.
    pub fn pulse_vs_cyclictest(&self) -> Option<Ratio> {
        let pg = self.pulse_latency()?;
        let ct = self.cyclictest.as_ref().ok()?;
        // cyclictest has 1 µs resolution: compare against at least 1 µs.
        Some(Ratio {
            p99_ratio: pg.p99_us / ct.p99_us.max(1.0),
            max_ratio: pg.max_us / ct.max_us.max(1.0),
        })
    }
}

/// Run the benchmark. `notices` receives the scheduling statement and overrun reports;
/// `progress` is called about ten times a second with the fraction done (0 … 1).
pub fn run(
    options: &BenchOptions,
    notices: NoticeSink,
    progress: &mut dyn FnMut(f64),
) -> Result<BenchReport, BenchError> {
    if options.seconds == 0 {
        return Err(BenchError::ZeroSeconds);
    }
    let mut table = options.table.clone();
    if let Some(p) = options.pulse_period_us {
        table
            .set_period_us(PULSE_GENERATOR, p)
            .map_err(BenchError::Period)?;
    }

    let load = options.load.then(|| load::Load::start(options.seconds));
    let load_text = load.as_ref().map(load::Load::describe);
    if load.is_some() {
        // Let the stressors get going before measuring.
        std::thread::sleep(Duration::from_millis(500));
    }

    let cpu = isolated_cpus().first().copied();
    let mut rt = Runtime::new(RuntimeOptions {
        realtime: options.realtime,
        pin: cpu.map_or(PinPolicy::None, PinPolicy::Cpu),
        notices,
        ..RuntimeOptions::default()
    });
    let pulse_batches = table
        .get(PULSE_GENERATOR)
        .map(|pg| pg.period_us)
        .unwrap_or(10_000);
    let (vg_tx, pg_rx) = ipc::spsc::channel::<work::PulseBatch>(64);
    let (pg_out, sm_in) = ipc::mailbox([0i64; 4]);
    let (mut vg_tx, mut pg_rx, mut pg_out, mut sm_in) =
        (Some(vg_tx), Some(pg_rx), Some(pg_out), Some(sm_in));
    for (i, spec) in table.tasks().iter().enumerate() {
        let (min_us, max_us) = work::paper_work_range_us(&spec.name);
        let role = match spec.name.as_str() {
            "velocity_generator" => {
                let per = (spec.period_us / pulse_batches.max(1)).clamp(1, 32) as u32;
                vg_tx
                    .take()
                    .map(|tx| work::Role::VelocityGenerator(tx, per))
            }
            "pulse_generator" => pg_rx
                .take()
                .zip(pg_out.take())
                .map(|(rx, out)| work::Role::PulseGenerator(rx, out)),
            "simulator_manager" => sm_in.take().map(work::Role::SimulatorManager),
            _ => None,
        };
        rt.add(
            spec.clone(),
            work::SyntheticTask::new(
                min_us,
                max_us,
                i as u64 + 1,
                role.unwrap_or(work::Role::Plain),
            ),
        );
    }

    // cyclictest at the Pulse Generator's priority and interval, started with the tasks.
    let pg = table.get(PULSE_GENERATOR);
    let cyclic = match (options.cyclictest, cyclictest::find(), pg) {
        (false, _, _) => Err("not requested".to_string()),
        (true, None, _) => Err("cyclictest is not installed (Debian package rt-tests)".to_string()),
        (true, Some(_), None) => {
            Err("the task table has no pulse_generator to compare with".to_string())
        }
        (true, Some(bin), Some(pg)) => cyclictest::Cyclictest::start(
            &bin,
            fifo_priority(pg.priority),
            pg.period_us,
            options.seconds,
            pg.cpu.or(cpu),
        )
        .map_err(|e| format!("cannot start cyclictest: {e}")),
    };

    let running = match rt.start() {
        Ok(r) => r,
        Err(e) => {
            if let Ok(c) = cyclic {
                let _ = c.finish();
            }
            if let Some(l) = load {
                l.stop();
            }
            return Err(e.into());
        }
    };
    let probes = ipc_latency::IpcProbes::start(options.realtime).map_err(BenchError::Udp);

    let total = Duration::from_secs(options.seconds);
    let started = Instant::now();
    while started.elapsed() < total {
        progress(started.elapsed().as_secs_f64() / total.as_secs_f64());
        std::thread::sleep(Duration::from_millis(100));
    }
    progress(1.0);

    let longest_period = table.tasks().iter().map(|t| t.period_us).max().unwrap_or(0);
    let sched = running.scheduling().clone();
    let stop = running.stop(Duration::from_micros(longest_period) + Duration::from_secs(2));
    let ipc = match probes {
        Ok(p) => p.finish(),
        Err(e) => {
            if let Some(l) = load {
                l.stop();
            }
            return Err(e);
        }
    };
    let cyclictest = cyclic.and_then(cyclictest::Cyclictest::finish);
    if let Some(l) = load {
        l.stop();
    }
    Ok(BenchReport {
        seconds: options.seconds,
        sched,
        stop_problem: (!stop.is_clean()).then(|| stop.to_string()),
        load: load_text,
        tasks: stop.tasks,
        ipc,
        cyclictest,
    })
}
