//! The command line: one subcommand per job, each in its own module.

use std::process::ExitCode;

use std::sync::OnceLock;

use clap::{Parser, Subcommand, ValueEnum};

use crate::bench;
use crate::board_sim;
use crate::compile;
use crate::plan;
use crate::run as run_program;
use crate::send;
use crate::sim;
use crate::ui;
use crate::up;

/// wrc — real-time controller for wafer-handling robots.
#[derive(Debug, Parser)]
#[command(name = "wrc", version, about, long_about = None)]
struct Cli {
    /// What the controller's log shows on standard error (the process's own messages, the
    /// real-time tasks' notices, the cell service's and the GUI server's): `error`, `warn`,
    /// `info` (default), `debug` or `trace`. `wrc up` passes it on to its board and GUI
    /// processes.
    #[arg(long, global = true, value_enum, default_value_t = LogLevel::Info)]
    log_level: LogLevel,
    #[command(subcommand)]
    command: Command,
}

/// `--log-level`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LogLevel {
    /// Errors only.
    Error,
    /// Errors and warnings.
    Warn,
    /// And what happened (the default).
    Info,
    /// And details for finding a problem.
    Debug,
    /// Everything.
    Trace,
}

impl LogLevel {
    fn filter(self) -> tracing::Level {
        match self {
            LogLevel::Error => tracing::Level::ERROR,
            LogLevel::Warn => tracing::Level::WARN,
            LogLevel::Info => tracing::Level::INFO,
            LogLevel::Debug => tracing::Level::DEBUG,
            LogLevel::Trace => tracing::Level::TRACE,
        }
    }

    /// The word on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            LogLevel::Error => "error",
            LogLevel::Warn => "warn",
            LogLevel::Info => "info",
            LogLevel::Debug => "debug",
            LogLevel::Trace => "trace",
        }
    }
}

static LOG_LEVEL: OnceLock<LogLevel> = OnceLock::new();

/// The `--log-level` this process runs with (for the processes it starts).
pub fn log_level() -> LogLevel {
    LOG_LEVEL.get().copied().unwrap_or(LogLevel::Info)
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Start the controller: the eight real-time tasks, simulated boards, host protocol on
    /// TCP, the local GUI socket and the simulator stream.
    Up(up::UpArgs),
    /// Serve the web GUI (started by `wrc up`; alone with `--controller HOST:PORT` on
    /// another PC).
    Ui(ui::UiArgs),
    /// Send one command line to a running controller and print the replies.
    Send(send::SendArgs),
    /// Compile a robot-language program, upload it to a running controller, run it and
    /// print what it prints until it ends.
    Run(run_program::RunArgs),
    /// Run the controller and its simulated boards under virtual time: a program as fast
    /// as the CPU allows (`wrc sim PROGRAM.wrl`), or a host session at a multiple of real
    /// time (`wrc sim --listen ADDR --rate X`).
    Sim(sim::SimArgs),
    /// Plan a move offline and print its per-period pulses as CSV (no controller needed).
    Plan(plan::PlanArgs),
    /// Compile a robot program (.wrl): diagnostics, or its bytecode listing or JSON.
    Compile(compile::CompileArgs),
    /// Run a simulated motion board on a DPRAM file (the DSP side), inject faults into it
    /// or print its state.
    BoardSim(board_sim::BoardSimArgs),
    /// Measure: `wrc bench rt` runs the real-time task set and prints the paper's Tables 3-5.
    Bench(bench::BenchArgs),
    /// Inspect a recorded trace: `wrc trace info FILE` prints what it holds, `wrc trace plot
    /// FILE` draws its positions, velocities, state and I/O over time as SVG.
    Trace(crate::trace::TraceArgs),
}

/// Parse the command line and run the subcommand; the exit code is the subcommand's.
pub fn run() -> anyhow::Result<ExitCode> {
    let cli = Cli::parse();
    let _ = LOG_LEVEL.set(cli.log_level);
    // One line per message on standard error, as the messages are written (`wrc: …`): no
    // time stamp (the journal or the terminal has one), no target, no level word.
    let _ = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_max_level(cli.log_level.filter())
        .without_time()
        .with_target(false)
        .with_level(false)
        .try_init();
    match cli.command {
        Command::Up(args) => up::run(args),
        Command::Ui(args) => ui::run(args),
        Command::Send(args) => send::run(args),
        Command::Run(args) => run_program::run(args),
        Command::Sim(args) => sim::run(args),
        Command::Plan(args) => plan::run(args),
        Command::Compile(args) => compile::run(args),
        Command::BoardSim(args) => board_sim::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Trace(args) => crate::trace::run(args),
    }
}
