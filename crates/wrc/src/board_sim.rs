//! `wrc board-sim`: run a simulated motion board on a DPRAM file (the DSP side of
//! `docs/dpram.md`), optionally with the simulated wafer cell as its ground truth, inject
//! faults into a running one, or print its state or a world file.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use clap::{Args, Subcommand};
use wrc_board::layout::{alarm, axis_status, board_status};
use wrc_board::wrc_cell::{SlotCode, Stations};
use wrc_board::{DpramBoard, Expect, Fault, Feedback, MappingScan, MotionBoard};
use wrc_board_sim::cell::SimCell;
use wrc_board_sim::runner::{self, MonotonicClock};
use wrc_board_sim::world_file::{self, Change, Origin, WorldSaver};
use wrc_board_sim::{PowerUp, SimBoard, SimSettings};
use wrc_config::{BoardConfig, Config};

/// Arguments of `wrc board-sim`.
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct BoardSimArgs {
    #[command(subcommand)]
    action: Option<Action>,
    #[command(flatten)]
    run: RunArgs,
}

#[derive(Debug, Subcommand)]
enum Action {
    /// Inject a fault into a running simulated board:
    /// alarm AXIS | encoder-stuck AXIS on|off | sensor-flip INPUT on|off | estop on|off | clear
    Inject(InjectArgs),
    /// Print a board's header, status, axes, I/O and mapping latch once.
    Status(TargetArgs),
    /// Print a simulated cell's world file: each station's slot codes, the hand, lost
    /// wafers and the fault count.
    World(WorldArgs),
}

#[derive(Debug, Args)]
struct WorldArgs {
    /// The world file (`--world` of a running board).
    #[arg(long, value_name = "FILE")]
    world: PathBuf,
    /// The stations file the world was made with [default: the embedded demo cell].
    #[arg(long, value_name = "FILE")]
    stations: Option<PathBuf>,
}

#[derive(Debug, Args)]
struct TargetArgs {
    /// The board's DPRAM [default: the configured board's `dpram`].
    #[arg(long, value_name = "PATH")]
    dpram: Option<PathBuf>,
    /// Configuration file [default: the embedded default].
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Which `[[board]]` of the configuration.
    #[arg(long, value_name = "ID", default_value_t = 0)]
    board_id: u32,
}

#[derive(Debug, Args)]
struct InjectArgs {
    #[command(flatten)]
    target: TargetArgs,
    /// The fault, e.g. `alarm 1` or `estop on`.
    #[arg(required = true, num_args = 1..)]
    fault: Vec<String>,
}

#[derive(Debug, Args)]
struct RunArgs {
    #[command(flatten)]
    target: TargetArgs,
    /// Command FIFO depth [periods] (1-64) [default: from the configuration].
    #[arg(long, value_name = "PERIODS")]
    fifo_depth: Option<u32>,
    /// Stop all axes when the host watchdog is stale this long [periods] [default: from
    /// the configuration].
    #[arg(long, value_name = "PERIODS")]
    watchdog_periods: Option<u32>,
    /// Fault present from the start (repeatable), e.g. `--fault "encoder-stuck 0 on"`.
    #[arg(long, value_name = "FAULT")]
    fault: Vec<String>,
    /// Exit after this many board periods [default: run until killed].
    #[arg(long, value_name = "N")]
    periods: Option<u64>,
    /// Simulate the wafer cell of this stations file: the hand's pose from the encoders
    /// moves wafers, the vacuum and mapping sensors follow the cell (every robot axis must
    /// be on this board).
    #[arg(long, value_name = "FILE")]
    stations: Option<PathBuf>,
    /// Step the board at SCHED_FIFO priority 90 with locked memory where allowed (above
    /// every controller task): like the DSP card it stands for, it must not be delayed by
    /// host load, or the controller it checks, which watches its heartbeat, would starve it
    /// first. Where
    /// SCHED_FIFO is not allowed it says so once and runs on normal scheduling.
    #[arg(long)]
    realtime: bool,
    /// The cell's ground truth: read at start (created from the stations' [station.sim]
    /// wafers when missing, refused when unusable), rewritten atomically after every change
    /// and at SIGINT/SIGTERM. Needs --stations.
    #[arg(long, value_name = "FILE")]
    world: Option<PathBuf>,
    /// Power up after a power loss: on the DPRAM of a board that ran before, the axes start
    /// where its encoders stood (absolute encoders) and every output is off (the vacuum has
    /// let go: the simulated cell drops the hand's wafer where the arm is). A DPRAM file
    /// that cannot be used (another layout version, axis count or board, garbage) is
    /// replaced by a first start at home, said in the log. Without it an existing wrc
    /// DPRAM is taken over as a restart (encoders and latched outputs kept) and anything
    /// else is refused.
    #[arg(long)]
    power_up: bool,
}

/// Run `wrc board-sim`.
pub fn run(args: BoardSimArgs) -> anyhow::Result<ExitCode> {
    match args.action {
        None => run_board(args.run),
        Some(Action::Inject(a)) => inject(a),
        Some(Action::Status(t)) => status(t),
        Some(Action::World(w)) => world(w),
    }
}

/// The configuration and the selected board (with the `--dpram` override applied).
fn target(t: &TargetArgs) -> anyhow::Result<(Config, BoardConfig)> {
    let config = Config::load(t.config.as_deref())?;
    let Some(mut board) = config.boards.iter().find(|b| b.id == t.board_id).cloned() else {
        let ids: Vec<String> = config.boards.iter().map(|b| b.id.to_string()).collect();
        bail!(
            "config {} has no [[board]] with id {} (it has: {})",
            config.source,
            t.board_id,
            ids.join(", ")
        );
    };
    if let Some(path) = &t.dpram {
        board.dpram = path.clone();
    }
    Ok((config, board))
}

fn run_board(args: RunArgs) -> anyhow::Result<ExitCode> {
    let (config, mut board) = target(&args.target)?;
    if let Some(depth) = args.fifo_depth {
        if !(1..=wrc_config::MAX_FIFO_DEPTH).contains(&depth) {
            bail!(
                "--fifo-depth {depth}: expected 1 to {} periods",
                wrc_config::MAX_FIFO_DEPTH
            );
        }
        board.fifo_depth = depth;
    }
    if let Some(periods) = args.watchdog_periods {
        if periods == 0 {
            bail!("--watchdog-periods 0: expected at least 1 period");
        }
        board.watchdog_periods = periods;
    }
    let faults = args
        .fault
        .iter()
        .map(|f| f.parse::<Fault>().with_context(|| "--fault"))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let cell = match (&args.stations, &args.world) {
        (None, None) => None,
        (None, Some(world)) => bail!(
            "--world {}: the simulated cell needs --stations FILE too (the world's stations and \
             slots are the stations file's)",
            world.display()
        ),
        (Some(stations), world) => Some(load_cell(&config, &board, stations, world.as_deref())?),
    };
    let settings = SimSettings::from_config(&config, &board);
    let mut sim = if args.power_up {
        let (sim, how) = SimBoard::power_up_file(&board.dpram, &settings)?;
        let line = format!(
            "wrc board-sim: power-up on {}: {how}",
            board.dpram.display()
        );
        if matches!(how, PowerUp::Replaced(_)) {
            tracing::warn!("{line}");
        } else {
            tracing::info!("{line}");
        }
        sim
    } else {
        SimBoard::create(&board.dpram, &settings)?
    };
    for fault in faults {
        sim.apply_fault(fault);
    }
    let Some(cell) = cell else {
        print_started(&sim, &board);
        step_in_real_time(args.realtime);
        let stop = AtomicBool::new(false);
        runner::run(&mut sim, &MonotonicClock, &stop, args.periods);
        return Ok(ExitCode::SUCCESS);
    };
    run_cell_board(sim, cell, &board, args.world, args.periods, args.realtime)
}

/// SCHED_FIFO priority of a simulated board's stepping thread under `--realtime`: one above
/// the controller's most urgent task (its priorities map to 1..89, docs/realtime.md), so
/// the "hardware" is never starved by the software it checks, as a board's DSP is not; still
/// below the kernel's own watchdog and migration threads (99).
pub const BOARD_FIFO_PRIORITY: i32 = 90;

/// With `realtime`, put the calling (stepping) thread on SCHED_FIFO at
/// [`BOARD_FIFO_PRIORITY`] with its memory locked (threads started before it, the world
/// saver, stay on normal scheduling); said once when the machine does not allow it.
fn step_in_real_time(realtime: bool) {
    if !realtime {
        return;
    }
    if let Err(e) = wrc_rt::sched_policy::lock_memory(1 << 20) {
        tracing::warn!(
            "wrc board-sim: --realtime: memory cannot be locked here ({e}); page faults may delay a board period"
        );
    }
    wrc_rt::sched_policy::prefault_stack();
    if let Err(e) = wrc_rt::sched_policy::set_current_thread_fifo(BOARD_FIFO_PRIORITY) {
        tracing::warn!(
            "wrc board-sim: --realtime: SCHED_FIFO is not allowed here ({e}); the board steps on normal scheduling"
        );
    }
}

fn print_started(sim: &SimBoard, board: &BoardConfig) {
    let h = *sim.dpram().header();
    tracing::info!(
        "wrc board-sim: board {} with {} axes, period {} µs, FIFO depth {}, watchdog {} periods, DPRAM {} (epoch {})",
        h.board_id,
        h.axis_count,
        h.period_us,
        h.fifo_depth,
        board.watchdog_periods,
        board.dpram.display(),
        h.epoch
    );
}

/// The simulated cell of `stations_path`, from the world file when given (created when
/// missing, refused when unusable).
fn load_cell(
    config: &Config,
    board: &BoardConfig,
    stations_path: &Path,
    world_path: Option<&Path>,
) -> anyhow::Result<SimCell> {
    let stations = Stations::load(stations_path)?;
    let cell = SimCell::new(config, board, stations)
        .with_context(|| format!("--stations {}", stations_path.display()))?;
    let Some(path) = world_path else {
        tracing::info!(
            "wrc board-sim: simulated cell of {} (wafers from its [station.sim] tables, not saved)",
            stations_path.display()
        );
        return Ok(cell);
    };
    let (world, origin) = world_file::load_or_create(path, cell.stations())?;
    let how = match origin {
        Origin::Loaded => "read from",
        Origin::Created => "new, written to",
    };
    tracing::info!(
        "wrc board-sim: simulated cell of {}; ground truth {how} {}",
        stations_path.display(),
        path.display()
    );
    Ok(cell.with_world(world))
}

/// Run the board with its cell until SIGINT/SIGTERM (or `periods`), handing every world
/// change to the saver thread, and save the final state.
fn run_cell_board(
    mut sim: SimBoard,
    cell: SimCell,
    board: &BoardConfig,
    world_path: Option<PathBuf>,
    periods: Option<u64>,
    realtime: bool,
) -> anyhow::Result<ExitCode> {
    // SIGINT/SIGTERM set the flag the board's loop watches.
    let stop = crate::up::stop_on_signals()?;
    let saver = WorldSaver::spawn(world_path.clone(), |line| {
        if line.starts_with("FAULT") {
            tracing::warn!("wrc board-sim: {line}")
        } else {
            tracing::info!("wrc board-sim: {line}")
        }
    })
    .context("cannot start the world-saver thread")?;

    sim.attach_cell(cell)?;
    print_started(&sim, board);
    step_in_real_time(realtime);
    let save = world_path.is_some();
    runner::run_with(&mut sim, &MonotonicClock, &stop, periods, |board| {
        // Outside the step: at most one text a change, written by the saver thread.
        if let Some(event) = board.take_cell_event() {
            if let Some(cell) = board.cell() {
                saver.send(Change {
                    text: save.then(|| cell.world().to_text()),
                    event: Some(event),
                    faults: cell.world().faults(),
                });
            }
        }
    });
    if let Some(cell) = sim.cell() {
        saver.send(Change {
            text: save.then(|| cell.world().to_text()),
            event: None,
            faults: cell.world().faults(),
        });
    }
    saver.finish();
    if let Some(path) = &world_path {
        tracing::info!(
            "wrc board-sim: stopped; ground truth saved in {}",
            path.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn open(t: &TargetArgs) -> anyhow::Result<DpramBoard> {
    let (_, board) = target(t)?;
    Ok(DpramBoard::open(&board.dpram, Expect::default())?)
}

fn inject(args: InjectArgs) -> anyhow::Result<ExitCode> {
    let fault: Fault = args.fault.join(" ").parse()?;
    let board = open(&args.target)?;
    let path = board.dpram().mapping().path().to_path_buf();
    wait(&path, "take the previous fault", || {
        board.dpram().load(wrc_board::layout::fault::ACK)
            == board.dpram().load(wrc_board::layout::fault::SEQ)
    })?;
    if !fault.inject(board.dpram()) {
        bail!(
            "DPRAM {}: another fault is being injected; try again",
            path.display()
        );
    }
    wait(&path, "take the fault", || {
        board.dpram().load(wrc_board::layout::fault::ACK)
            == board.dpram().load(wrc_board::layout::fault::SEQ)
    })?;
    eprintln!(
        "wrc board-sim: injected \"{fault}\" into {}",
        path.display()
    );
    Ok(ExitCode::SUCCESS)
}

fn wait(path: &Path, what: &str, done: impl Fn() -> bool) -> anyhow::Result<()> {
    let start = Instant::now();
    while !done() {
        if start.elapsed() > Duration::from_secs(2) {
            bail!(
                "DPRAM {}: the board did not {what} within 2 s; is `wrc board-sim` running on it?",
                path.display()
            );
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    Ok(())
}

fn bits(value: u32, names: &[(u32, &str)]) -> String {
    let list: Vec<&str> = names
        .iter()
        .filter(|(b, _)| value & b != 0)
        .map(|(_, n)| *n)
        .collect();
    if list.is_empty() {
        "-".into()
    } else {
        list.join(",")
    }
}

fn status(t: TargetArgs) -> anyhow::Result<ExitCode> {
    let board = open(&t)?;
    let mut f = Feedback::default();
    board.read_feedback(&mut f)?;
    let h = board.header();
    let b = &f.boards[0];
    println!(
        "board {} epoch {} period_us {} fifo_depth {} periods {} board_watchdog {} watchdog_trips {} late_periods {}",
        h.board_id, h.epoch, h.period_us, h.fifo_depth, b.period_count, b.board_watchdog, b.watchdog_trips, b.late_periods
    );
    println!(
        "status {} inputs {:#010x} outputs {:#010x}",
        bits(
            b.status,
            &[
                (board_status::RUNNING, "running"),
                (board_status::WATCHDOG_ARMED, "watchdog-armed"),
                (board_status::WATCHDOG_TRIPPED, "watchdog-tripped"),
                (board_status::ESTOP, "estop"),
                (board_status::STOPPING, "stopping"),
                (board_status::ALARM, "alarm"),
            ]
        ),
        b.inputs,
        b.outputs
    );
    println!("axis commanded_pulse encoder_pulse following_error_pulse fifo underruns alarms status alarm");
    for (i, a) in f.axes[..f.axis_count].iter().enumerate() {
        println!(
            "{i} {} {} {} {} {} {} {} {}",
            a.commanded,
            a.encoder,
            a.following_error,
            a.fifo_level,
            a.underruns,
            a.alarms,
            bits(
                a.status,
                &[
                    (axis_status::SERVO_ON, "servo-on"),
                    (axis_status::ALARM, "alarm"),
                    (axis_status::LIMIT_POS, "limit+"),
                    (axis_status::LIMIT_NEG, "limit-"),
                    (axis_status::MOVING, "moving"),
                    (axis_status::STOPPING, "stopping"),
                    (axis_status::UNDERRUN, "underrun"),
                    (axis_status::STREAMING, "streaming"),
                ]
            ),
            bits(
                a.alarm,
                &[
                    (alarm::OVERSPEED, "overspeed"),
                    (alarm::FOLLOWING_ERROR, "following-error"),
                    (alarm::LIMIT_POS, "limit+"),
                    (alarm::LIMIT_NEG, "limit-"),
                    (alarm::FIFO_SEQUENCE, "fifo-sequence"),
                    (alarm::AMPLIFIER, "amplifier"),
                ]
            )
        );
    }
    let mut scan = MappingScan::default();
    board.read_mapping(&mut scan)?;
    println!("{}", mapping_line(&scan));
    Ok(ExitCode::SUCCESS)
}

/// `mapping station N seen K codes ...`: the codes of slots 1 up to the highest seen one,
/// `.` for a slot not seen.
fn mapping_line(scan: &MappingScan) -> String {
    let highest = 64 - scan.seen.leading_zeros() as u16;
    let codes: String = (1..=highest)
        .map(|slot| scan.slot_code(slot).map_or('.', SlotCode::as_char))
        .collect();
    format!(
        "mapping station {} seen {} codes {} clear {}",
        scan.station,
        scan.seen.count_ones(),
        if codes.is_empty() { "-" } else { &codes },
        if scan.cleared {
            "acknowledged"
        } else {
            "pending (no simulated cell?)"
        }
    )
}

fn world(args: WorldArgs) -> anyhow::Result<ExitCode> {
    let stations = match &args.stations {
        Some(path) => Stations::load(path)?,
        None => Stations::embedded_demo(),
    };
    let world = world_file::load(&args.world, &stations)?;
    print!("{}", world_file::summary(&world, &stations));
    Ok(ExitCode::SUCCESS)
}
