//! `wrc sim`: the controller and its simulated boards under virtual time
//! ([`wrc_controller::simulation`]).
//!
//! - `wrc sim PROGRAM.wrl` runs a robot-language program as `wrc run` does against
//!   `wrc up` (same checks, same output on stdout, same exit codes), as fast as the CPU
//!   allows, and says on stderr how much virtual time it took in how much wall time.
//! - `wrc sim --listen ADDR --rate X` serves the host protocol on `ADDR` with virtual time
//!   running at X times real time, until SIGINT or SIGTERM: host software tested faster (or
//!   slower) than real time.
//!
//! The state (programs, stations, wafer map) lives in `--state-dir`, by default a new
//! temporary directory removed at the end. The simulated cell (its ground truth) starts from
//! `STATE_DIR/world.toml` when that exists, else from the stations' `[station.sim]` wafers,
//! and is saved there at the end: runs in one state directory go on from where the last one
//! left the wafers, in the map and in the cell alike (as `wrc up` keeps them).

use std::io::Write;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::Ordering;

use anyhow::{bail, Context};
use clap::Args;
use wrc_config::Config;
use wrc_controller::simulation::{ClientError, SimCellFrom, Simulation};
use wrc_rt::virtual_time::Pace;

use crate::run::{self as run_program, Conversation, Heard};

/// Arguments of `wrc sim`.
#[derive(Debug, Args)]
pub struct SimArgs {
    /// The robot-language program (`.wrl`) to run from start to end.
    #[arg(required_unless_present = "listen", conflicts_with = "listen")]
    program: Option<PathBuf>,
    /// Serve the host protocol on this TCP address instead, until SIGINT/SIGTERM.
    #[arg(long, value_name = "ADDR")]
    listen: Option<SocketAddr>,
    /// With --listen: virtual seconds per real second (1 = real time, 10 = ten times faster).
    #[arg(long, value_name = "X", default_value_t = 1.0, requires = "listen")]
    rate: f64,
    /// Robot configuration (TOML); default: the embedded paper robot.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Stations file (TOML) [default: STATE_DIR/stations.toml, written from the built-in
    /// demo cell when missing].
    #[arg(long, value_name = "FILE")]
    stations: Option<PathBuf>,
    /// Programs, stations, the wafer map and the simulated cell (world.toml) live here
    /// [default: a new temporary directory, removed at the end].
    #[arg(long, value_name = "DIR")]
    state_dir: Option<PathBuf>,
    /// Store the program under this name instead of the file's name.
    #[arg(long)]
    name: Option<String>,
    /// Give up after this much virtual time [s].
    #[arg(long, value_name = "S", default_value_t = 3600.0)]
    timeout: f64,
    /// Simulator datagrams go to this UDP address.
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:7200")]
    sim_addr: SocketAddr,
    /// Write every line exchanged with the controller, with its virtual time [s], here.
    #[arg(long, value_name = "FILE")]
    transcript: Option<PathBuf>,
    /// Save the session's trace (every period and every line, from the start) here at the
    /// end, for `wrc trace replay`, `plot` and the GUI.
    #[arg(long, value_name = "FILE")]
    trace: Option<PathBuf>,
    /// Write the position every axis of board 0 was commanded [pulse] at each board period
    /// here (CSV).
    #[arg(long, value_name = "FILE")]
    pulses: Option<PathBuf>,
}

/// A state directory that is removed at the end when it was made here (a new temporary
/// one).
pub(crate) struct StateDir {
    pub path: PathBuf,
    temporary: bool,
}

impl Drop for StateDir {
    fn drop(&mut self) {
        if self.temporary {
            let _ = std::fs::remove_dir_all(&self.path);
        }
    }
}

pub(crate) fn state_dir(given: Option<&Path>) -> anyhow::Result<StateDir> {
    let (path, temporary) = match given {
        Some(p) => (p.to_path_buf(), false),
        None => {
            let nanos = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.subsec_nanos())
                .unwrap_or(0);
            let p = std::env::temp_dir().join(format!("wrc-sim-{}-{nanos}", std::process::id()));
            (p, true)
        }
    };
    std::fs::create_dir_all(&path)
        .with_context(|| format!("cannot create the state directory {}", path.display()))?;
    Ok(StateDir { path, temporary })
}

/// Build the simulation: the controller on virtual time with its boards, and the simulated
/// cell on board 0 when it drives every robot axis.
fn simulation(args: &SimArgs, config: &Config, dir: &Path) -> anyhow::Result<Simulation> {
    let world_path = dir.join(WORLD_FILE);
    let world = match std::fs::read_to_string(&world_path) {
        Ok(text) => Some(text),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", world_path.display())),
    };
    build(
        config,
        dir,
        args.stations.clone(),
        world.as_deref(),
        args.listen,
        args.sim_addr,
    )
    .with_context(|| match &world {
        Some(_) => format!(
            "the simulated cell kept in {} (remove it to start from the stations' wafers)",
            world_path.display()
        ),
        None => "the stations' simulated cell".to_string(),
    })
}

/// The simulated cell's ground truth in a state directory (the name `wrc up` uses).
const WORLD_FILE: &str = "world.toml";

/// Keep the simulated cell's ground truth in `dir` for the next run (atomically), unless
/// `dir` is a temporary one about to be removed.
fn save_world(sim: &Simulation, dir: &StateDir) -> anyhow::Result<()> {
    if dir.temporary {
        return Ok(());
    }
    let Some(text) = sim
        .board(0)
        .and_then(|b| b.cell().map(|c| c.world().to_text()))
    else {
        return Ok(());
    };
    let path = dir.path.join(WORLD_FILE);
    wrc_board::wrc_cell::write_atomic(&path, text.as_bytes())
        .with_context(|| format!("cannot save the simulated cell in {}", path.display()))
}

/// The controller of `config` on virtual time, its state in `dir`: stations from
/// `stations` (default `dir/stations.toml`, written from the demo cell when missing), the
/// simulated cell from `world` (a world file's text; default: the stations' `[station.sim]`
/// wafers), the host protocol on `tcp` if given.
pub(crate) fn build(
    config: &Config,
    dir: &Path,
    stations: Option<PathBuf>,
    world: Option<&str>,
    tcp: Option<SocketAddr>,
    sim_addr: SocketAddr,
) -> anyhow::Result<Simulation> {
    let cell = SimCellFrom {
        stations: stations.as_deref(),
        world,
    };
    Simulation::in_state_dir(config, dir, cell, tcp, sim_addr)
        .context("the simulated controller could not start")
}

/// Run `wrc sim`.
pub fn run(args: SimArgs) -> anyhow::Result<ExitCode> {
    if !(args.timeout > 0.0 && args.timeout.is_finite()) {
        bail!("--timeout must be a positive number of seconds");
    }
    if !(args.rate > 0.0 && args.rate.is_finite()) {
        bail!("--rate must be a positive number (virtual seconds per real second)");
    }
    let mut config = Config::load(args.config.as_deref())?;
    if args.trace.is_some() {
        // The whole session, not the last seconds: as long as it may run (memory grows with
        // it: about 29 kB per second at 10 ms, docs/trace.md).
        config.trace.seconds = config.trace.seconds.max(args.timeout.min(3600.0));
        config.trace.messages = config.trace.messages.max(50_000);
        config.trace.save_on_alarm = false;
    }
    match &args.program {
        Some(program) => run_file(&args, &config, program),
        None => listen(&args, &config),
    }
}

/// What was exchanged and executed, for `--transcript` and `--pulses`.
struct Records {
    transcript: Option<std::io::BufWriter<std::fs::File>>,
    pulses: Option<std::io::BufWriter<std::fs::File>>,
}

impl Records {
    fn open(args: &SimArgs, sim: &Simulation) -> anyhow::Result<Records> {
        let create = |p: &Option<PathBuf>| -> anyhow::Result<_> {
            p.as_ref()
                .map(|p| {
                    std::fs::File::create(p)
                        .map(std::io::BufWriter::new)
                        .with_context(|| format!("cannot create {}", p.display()))
                })
                .transpose()
        };
        let records = Records {
            transcript: create(&args.transcript)?,
            pulses: create(&args.pulses)?,
        };
        sim.record_pulses(records.pulses.is_some());
        Ok(records)
    }

    /// `text`'s lines, sent (`>`) or received (`<`) now.
    fn line(&mut self, sim: &Simulation, arrow: &str, text: &str) -> anyhow::Result<()> {
        if let Some(w) = &mut self.transcript {
            for l in text.lines() {
                writeln!(w, "{:.3} {arrow} {l}", sim.virtual_s())?;
            }
        }
        Ok(())
    }

    /// What board 0 executed since the last call.
    fn pulses(&mut self, sim: &Simulation) -> anyhow::Result<()> {
        if let Some(w) = &mut self.pulses {
            for (t_ns, pulses) in sim.take_pulses() {
                let t = t_ns.saturating_sub(wrc_controller::simulation::START_NS) as f64 / 1e9;
                write!(w, "{t:.3}")?;
                for p in pulses {
                    write!(w, ",{p}")?;
                }
                writeln!(w)?;
            }
        }
        Ok(())
    }

    fn finish(mut self, sim: &Simulation) -> anyhow::Result<()> {
        self.pulses(sim)?;
        for w in [self.transcript, self.pulses].into_iter().flatten() {
            w.into_inner().map_err(|e| e.into_error())?;
        }
        Ok(())
    }
}

fn run_file(args: &SimArgs, config: &Config, program: &Path) -> anyhow::Result<ExitCode> {
    let checked = match run_program::check(program, args.name.as_deref(), config)? {
        Ok(checked) => checked,
        Err(code) => return Ok(code),
    };
    let dir = state_dir(args.state_dir.as_deref())?;
    let mut sim = simulation(args, config, &dir.path)?;
    let mut records = Records::open(args, &sim)?;
    let mut client = sim.connect()?;
    let (mut talk, first) = Conversation::start(checked);
    sim.send(&mut client, &first)?;
    records.line(&sim, ">", &first)?;
    let limit_ns = sim.now_ns() + (args.timeout * 1e9) as u64;
    let code = loop {
        let line = match sim.next_line(&mut client, limit_ns.saturating_sub(sim.now_ns())) {
            Ok(line) => line,
            Err(ClientError::Timeout(_)) => {
                eprintln!(
                    "wrc sim: the program did not end within {} s of virtual time (--timeout)",
                    args.timeout
                );
                break ExitCode::from(1);
            }
            Err(e) => return Err(e.into()),
        };
        records.line(&sim, "<", &line)?;
        records.pulses(&sim)?;
        match talk.hear(&line) {
            Heard::Nothing => {}
            Heard::Send(request) => {
                sim.send(&mut client, &request)?;
                records.line(&sim, ">", &request)?;
            }
            Heard::Ended(code) => break code,
        }
    };
    records.finish(&sim)?;
    save_trace(args, &sim)?;
    save_world(&sim, &dir)?;
    report(&sim);
    Ok(code)
}

/// `--trace`: the session's trace, saved.
fn save_trace(args: &SimArgs, sim: &Simulation) -> anyhow::Result<()> {
    let Some(path) = &args.trace else {
        return Ok(());
    };
    let trace = sim
        .trace("wrc sim --trace")
        .context("the simulated controller keeps no trace")?;
    let began = std::time::Instant::now();
    trace.save(path)?;
    eprintln!(
        "wrc sim: trace of {} periods and {} lines saved in {} ({:.1} ms)",
        trace.samples.len(),
        trace.messages.len(),
        path.display(),
        began.elapsed().as_secs_f64() * 1e3
    );
    Ok(())
}

/// The virtual and wall durations, on stderr.
fn report(sim: &Simulation) {
    let (virt, wall) = (sim.virtual_s(), sim.wall_s());
    eprintln!(
        "wrc sim: {virt:.3} s of virtual time in {wall:.3} s of wall time ({:.1}x real time)",
        virt / wall.max(1e-9)
    );
}

fn listen(args: &SimArgs, config: &Config) -> anyhow::Result<ExitCode> {
    let stop = crate::up::stop_on_signals()?;
    let dir = state_dir(args.state_dir.as_deref())?;
    let mut sim = simulation(args, config, &dir.path)?;
    let mut records = Records::open(args, &sim)?;
    sim.set_pace(Pace::Rate(args.rate));
    if let Some(tcp) = sim.tcp {
        println!("wrc sim: host protocol on tcp {tcp}");
    }
    if let Some(socket) = &sim.socket {
        println!("wrc sim: local GUI socket {}", socket.display());
    }
    println!(
        "wrc sim: virtual time at {}x real time; state in {}; Ctrl-C or SIGTERM ends it",
        args.rate,
        dir.path.display()
    );
    let _ = std::io::stdout().flush();
    while !stop.load(Ordering::Relaxed) {
        sim.run_for_ns(100_000_000);
        records.pulses(&sim)?;
    }
    records.finish(&sim)?;
    save_trace(args, &sim)?;
    save_world(&sim, &dir)?;
    println!("wrc sim: stopped");
    report(&sim);
    Ok(ExitCode::SUCCESS)
}
