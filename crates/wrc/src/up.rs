//! `wrc up`: the controller with its simulated boards, endpoints printed, stopped cleanly by
//! SIGINT or SIGTERM (controlled stop of any motion, state saved, tasks stopped, exit 0).
//!
//! # Supervision, kept small
//!
//! `wrc up` is one process with the controller's tasks in it, and starts two kinds of child
//! process from the same binary:
//!
//! - **`wrc board-sim`**, one per simulated board, before the controller (the controller maps
//!   its DPRAM). It powers up (`--power-up`) on the DPRAM file `STATE_DIR/boardN.dpram` the
//!   previous run left, as a board comes back after a power loss: the arm where its absolute
//!   encoders stood, every output off (the simulated cell drops a wafer the vacuum held where
//!   the arm is); an unusable file (another layout version or axis count, garbage) is
//!   replaced by a first start at home, and `wrc up` says which before it starts the board.
//!   Started, then waited for until its DPRAM is up with its new epoch (10 s at most, its
//!   log quoted if it exits). It dies with `wrc up` even on `kill -9` (`PR_SET_PDEATHSIG`), as a
//!   board loses power with its host. A board process that dies is reaped at once (SIGCHLD)
//!   and logged; the controller notices on its own (the board's heartbeat stands: error 300,
//!   docs/protocol.md). It is **restarted only with `--restart-boards`**, and then at most
//!   when it ran for at least 1 s (a board that dies as it starts, on a bad configuration, is left dead): a board that
//!   stops is a fault the controller must report, not hide, and the restarted board runs
//!   only once an operator's `RESET` re-attaches it.
//! - **`wrc ui`**, after the controller, at a lower CPU priority (nice 5): waited for until it
//!   serves (10 s), its output copied to `STATE_DIR/ui.log`. Dies with `wrc up`; reaped and
//!   logged if it dies, **not restarted**: the GUI is a client like any other, and a
//!   browser reconnects.
//!
//! At SIGINT/SIGTERM: the controller stops any motion and its tasks, the state is saved,
//! then every child gets SIGTERM and 2 s to exit before SIGKILL, and is reaped.

use std::net::SocketAddr;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitCode, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use clap::{Args, ValueEnum};
use wrc_config::Config;
use wrc_controller::controller::{self, CellFiles, Options};
use wrc_controller::rs232c::Parity;
use wrc_rt::RealtimeMode;

/// Arguments of `wrc up`.
#[derive(Debug, Args)]
pub struct UpArgs {
    /// Robot configuration (TOML); default: the embedded paper robot.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Use this DPRAM (a real board's PCI BAR or UIO device, or a board-sim file) instead of
    /// starting simulated boards; once per board, in configuration order.
    #[arg(long, value_name = "PATH")]
    board: Vec<PathBuf>,
    /// Host protocol TCP address. Off loopback (e.g. 0.0.0.0:7100) the configuration or
    /// --allow/--monitor/--token-file must say who may use it (docs/protocol.md
    /// "Connections").
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:7100")]
    port: SocketAddr,
    /// An address or network that may connect and command (adds to [host] allow;
    /// repeatable), e.g. 192.168.1.20 or 192.168.1.0/24.
    #[arg(long, value_name = "ADDR[/LEN]", value_parser = net)]
    allow: Vec<wrc_config::IpNet>,
    /// An address or network that may connect to monitor only (adds to [host] monitor;
    /// repeatable).
    #[arg(long, value_name = "ADDR[/LEN]", value_parser = net)]
    monitor: Vec<wrc_config::IpNet>,
    /// The file holding the control token ([host] token_file): connections from off the
    /// machine command only after AUTH <token>.
    #[arg(long, value_name = "FILE")]
    token_file: Option<PathBuf>,
    /// Simulator datagrams go to this UDP address.
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:7200")]
    sim_addr: SocketAddr,
    /// Local GUI socket [default: STATE_DIR/wrc.sock].
    #[arg(long, value_name = "PATH")]
    socket: Option<PathBuf>,
    /// Saved state, simulated boards' DPRAM files and the socket live here.
    #[arg(long, value_name = "DIR", default_value = "/tmp/wrc")]
    state_dir: PathBuf,
    /// Stations file (TOML) [default: STATE_DIR/stations.toml, written from the built-in
    /// demo cell when missing]; TEACH saves into it.
    #[arg(long, value_name = "FILE")]
    stations: Option<PathBuf>,
    /// Teaching pendant serial device (e.g. /dev/ttyUSB0).
    #[arg(long, value_name = "DEV")]
    serial: Option<PathBuf>,
    /// Serial speed [baud].
    #[arg(long, value_name = "BAUD", default_value_t = 9600)]
    baud: u32,
    /// Serial parity.
    #[arg(long, value_name = "PARITY", value_enum, ignore_case = true, default_value_t = SerialParity::None)]
    parity: SerialParity,
    /// Do not start the web GUI (`wrc ui`).
    #[arg(long)]
    no_ui: bool,
    /// Port of the web GUI (http://127.0.0.1:PORT).
    #[arg(long, value_name = "PORT", default_value_t = 8080)]
    ui_port: u16,
    /// Run without SCHED_FIFO even where it is allowed.
    #[arg(long)]
    no_rt: bool,
    /// Start a simulated board again when its process dies (it takes over its DPRAM with a
    /// new epoch; the controller stays in ERROR 300 until a RESET re-attaches it). Without
    /// it a dead board stays dead: reaped and logged.
    #[arg(long)]
    restart_boards: bool,
}

/// The signals that end `wrc up`, `wrc sim --listen` and `wrc board-sim`.
const TERMINATION: [libc::c_int; 2] = [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM];

/// SIGINT and SIGTERM, from now on delivered to the returned iterator (signal-hook's
/// self-pipe) instead of ending the process; the caller waits on it.
pub(crate) fn termination_signals() -> anyhow::Result<signal_hook::iterator::Signals> {
    signal_hook::iterator::Signals::new(TERMINATION)
        .context("cannot install the SIGINT/SIGTERM handler")
}

/// A flag set when SIGINT or SIGTERM arrives (signal-hook's handler: it only stores to the
/// flag, so whichever thread the kernel picks, a real-time one included, spends
/// nanoseconds on it).
pub(crate) fn stop_on_signals() -> anyhow::Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    for sig in TERMINATION {
        signal_hook::flag::register(sig, stop.clone())
            .context("cannot install the SIGINT/SIGTERM handler")?;
    }
    Ok(stop)
}

/// Whether this process may run threads under SCHED_FIFO (a probe thread tries it).
pub(crate) fn fifo_allowed() -> bool {
    std::thread::spawn(|| wrc_rt::sched_policy::set_current_thread_fifo(1).is_ok())
        .join()
        .unwrap_or(false)
}

/// Start `wrc board-sim` for board `id` on `dpram`; `watchdog_periods` overrides the
/// configured host-watchdog limit; `realtime` steps it at SCHED_FIFO (`--realtime`);
/// `cell` = (stations file, world file) makes it simulate the wafer cell, and then waits
/// until the board is up so a refusal (an unusable world file, stations out of reach) is
/// reported here with the board's own words. The board takes `dpram` over as it finds it
/// (a new file: a first start; a wrc DPRAM: a restart, encoders and outputs kept).
pub(crate) fn spawn_board(
    config: Option<&Path>,
    id: u32,
    dpram: &Path,
    log: &Path,
    watchdog_periods: Option<u32>,
    realtime: bool,
    cell: Option<(&Path, &Path)>,
) -> anyhow::Result<Child> {
    BoardCommand {
        config,
        id,
        dpram,
        log,
        watchdog_periods,
        realtime,
        cell,
        power_up: None,
    }
    .spawn()
}

/// The arguments of one `wrc board-sim` that [`BoardCommand::spawn`] starts (see
/// [`spawn_board`]).
struct BoardCommand<'a> {
    config: Option<&'a Path>,
    id: u32,
    dpram: &'a Path,
    log: &'a Path,
    watchdog_periods: Option<u32>,
    realtime: bool,
    cell: Option<(&'a Path, &'a Path)>,
    /// `Some(epoch)`: `--power-up`, the board powers up after a power loss (encoders kept,
    /// outputs off) with this epoch in its header ([`wrc_board_sim::power_up_outlook`]).
    power_up: Option<u32>,
}

impl BoardCommand<'_> {
    /// Start it. With a cell, or powering up, wait until the board is up: a refusal is then
    /// reported here with the board's words, and the controller, which starts next, never
    /// attaches to the DPRAM a power-up is about to initialise again (the file the previous
    /// run left is valid until the new board has read its encoders).
    fn spawn(&self) -> anyhow::Result<Child> {
        let exe =
            std::env::current_exe().context("cannot find the wrc executable to start board-sim")?;
        let mut cmd = Command::new(exe);
        cmd.args(["--log-level", crate::cli::log_level().as_str(), "board-sim"])
            .arg("--dpram")
            .arg(self.dpram)
            .arg("--board-id")
            .arg(self.id.to_string());
        if let Some(c) = self.config {
            cmd.arg("--config").arg(c);
        }
        if let Some(p) = self.watchdog_periods {
            cmd.arg("--watchdog-periods").arg(p.to_string());
        }
        if self.realtime {
            cmd.arg("--realtime");
        }
        if self.power_up.is_some() {
            cmd.arg("--power-up");
        }
        if let Some((stations, world)) = self.cell {
            cmd.arg("--stations")
                .arg(stations)
                .arg("--world")
                .arg(world);
        }
        let log = std::fs::File::create(self.log)
            .with_context(|| format!("cannot create {}", self.log.display()))?;
        cmd.stdin(Stdio::null())
            .stdout(log.try_clone()?)
            .stderr(log);
        // SAFETY: runs in the child between fork and exec and only calls an
        // async-signal-safe function (prctl).
        unsafe {
            cmd.pre_exec(|| {
                // The simulated board dies with the controller, even on kill -9.
                libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
                Ok(())
            });
        }
        let mut child = cmd
            .spawn()
            .context("cannot start the simulated board (wrc board-sim)")?;
        if self.cell.is_some() || self.power_up.is_some() {
            let up = || match wrc_board::DpramBoard::open(self.dpram, wrc_board::Expect::default())
            {
                Ok(board) => self.power_up.is_none_or(|e| {
                    board.header().epoch == e && board.header().board_id == self.id
                }),
                Err(_) => false,
            };
            let deadline = Instant::now() + Duration::from_secs(10);
            while Instant::now() < deadline {
                if let Ok(Some(status)) = child.try_wait() {
                    let said = std::fs::read_to_string(self.log).unwrap_or_default();
                    bail!(
                        "the simulated board {} did not start ({status}): {}",
                        self.id,
                        said.trim()
                    );
                }
                if up() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(10));
            }
        }
        Ok(child)
    }
}

/// A simulated board's process under `wrc up`, and what starts it again.
struct BoardProcess {
    id: u32,
    child: Option<Child>,
    started: Instant,
    dpram: PathBuf,
    log: PathBuf,
    /// `None`: normal scheduling, the host watchdog at 1 s (see [`run`]); otherwise the
    /// board steps at SCHED_FIFO with its configured watchdog.
    watchdog: Option<u32>,
    cell: Option<(PathBuf, PathBuf)>,
    /// `Some(epoch)`: the next start is the power-up of `wrc up` (`--power-up`), to this
    /// epoch; restarts by supervision take the DPRAM over as it is.
    power_up: Option<u32>,
}

impl BoardProcess {
    /// Start board `id`'s `wrc board-sim` as a power-up to `epoch` (see [`run`]).
    fn spawn(
        config: Option<&Path>,
        id: u32,
        dpram: PathBuf,
        log: PathBuf,
        watchdog: Option<u32>,
        cell: Option<(PathBuf, PathBuf)>,
        epoch: u32,
    ) -> anyhow::Result<BoardProcess> {
        let mut board = BoardProcess {
            id,
            child: None,
            started: Instant::now(),
            dpram,
            log,
            watchdog,
            cell,
            power_up: Some(epoch),
        };
        board.start(config)?;
        Ok(board)
    }

    /// Start (or start again) its `wrc board-sim`: the first time as a power-up on the
    /// DPRAM file a previous run left (see [`run`]), then as restarts by supervision.
    fn start(&mut self, config: Option<&Path>) -> anyhow::Result<()> {
        let cell = self.cell.as_ref().map(|(s, w)| (s.as_path(), w.as_path()));
        // Without a lenient watchdog the controller runs real-time, and watches the board's
        // heartbeat as closely: the board steps at SCHED_FIFO like the DSP it stands for.
        let realtime = self.watchdog.is_none();
        let child = BoardCommand {
            config,
            id: self.id,
            dpram: &self.dpram,
            log: &self.log,
            watchdog_periods: self.watchdog,
            realtime,
            cell,
            power_up: self.power_up,
        }
        .spawn()?;
        self.power_up = None;
        self.child = Some(child);
        self.started = Instant::now();
        Ok(())
    }
}

/// A board must have run this long before `--restart-boards` starts it again.
const RESTART_AFTER: Duration = Duration::from_secs(1);

/// On SIGCHLD: reap every child that exited, say so, and start a dead board again when
/// `restart` (see the module docs).
fn reap(boards: &mut [BoardProcess], ui: &mut Option<Child>, config: Option<&Path>, restart: bool) {
    for b in boards.iter_mut() {
        let Some(child) = b.child.as_mut() else {
            continue;
        };
        let Ok(Some(status)) = child.try_wait() else {
            continue;
        };
        let pid = child.id();
        b.child = None;
        tracing::error!(
            "wrc: simulated board {} (wrc board-sim, pid {pid}) exited: {status}; its log is {}",
            b.id,
            b.log.display()
        );
        if !restart {
            tracing::error!("wrc: board {} is not restarted (wrc up --restart-boards would); the controller reports error 300 until it runs again", b.id);
            continue;
        }
        if b.started.elapsed() < RESTART_AFTER {
            tracing::error!(
                "wrc: board {} is not restarted: it died within {} s of its start",
                b.id,
                RESTART_AFTER.as_secs()
            );
            continue;
        }
        match b.start(config) {
            Ok(()) => tracing::warn!(
                "wrc: simulated board {} restarted (pid {}) on {}; RESET re-attaches it",
                b.id,
                b.child.as_ref().map_or(0, Child::id),
                b.dpram.display()
            ),
            Err(e) => tracing::error!("wrc: board {} could not be restarted: {e:#}", b.id),
        }
    }
    if let Some(child) = ui.as_mut() {
        if let Ok(Some(status)) = child.try_wait() {
            tracing::error!(
                "wrc: the GUI (wrc ui, pid {}) exited: {status}; not restarted (the controller runs on without it)",
                child.id()
            );
            *ui = None;
        }
    }
}

/// Start `wrc ui` on the controller's Unix socket, compiling for the controller's robot
/// (`config`) with its program folder, and wait until it serves; returns the child and the
/// GUI's address. Its output after the start goes to `STATE_DIR/ui.log`.
fn spawn_ui(
    socket: &Path,
    sim_addr: SocketAddr,
    port: u16,
    state_dir: &Path,
    config: Option<&Path>,
) -> anyhow::Result<(Child, String)> {
    let exe = std::env::current_exe().context("cannot find the wrc executable to start wrc ui")?;
    let log_path = state_dir.join("ui.log");
    let mut cmd = Command::new(exe);
    cmd.args(["--log-level", crate::cli::log_level().as_str(), "ui"])
        .arg("--controller")
        .arg(socket)
        .arg("--sim-addr")
        .arg(sim_addr.to_string())
        .arg("--ui-port")
        .arg(port.to_string())
        // The editor compiles for this robot and reads the stored programs and points.
        .arg("--programs")
        .arg(state_dir.join("programs"));
    if let Some(config) = config {
        cmd.arg("--config").arg(config);
    }
    cmd.stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    // SAFETY: runs in the child between fork and exec and only calls async-signal-safe
    // functions (prctl, setpriority).
    unsafe {
        cmd.pre_exec(|| {
            libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
            // The GUI is the least urgent thing on the machine.
            libc::setpriority(libc::PRIO_PROCESS, 0, 5);
            Ok(())
        });
    }
    let mut child = cmd.spawn().context("cannot start wrc ui")?;
    let stdout = child.stdout.take().context("wrc ui has no stdout")?;
    let stderr = child.stderr.take().context("wrc ui has no stderr")?;
    let log = std::fs::File::create(&log_path)
        .with_context(|| format!("cannot create {}", log_path.display()))?;
    // Every line goes to the log; the first stdout line naming the GUI's address and
    // stderr's lines (why it failed) also come back here.
    let (tx, rx) = std::sync::mpsc::channel();
    forward_lines(stdout, log.try_clone()?, move |line| {
        if let Some(url) = line.strip_prefix("wrc ui: GUI on ") {
            let _ = tx.send(url.to_string());
        }
    });
    let (etx, erx) = std::sync::mpsc::channel();
    forward_lines(stderr, log, move |line| {
        let _ = etx.send(line.to_string());
    });
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        if let Ok(url) = rx.recv_timeout(Duration::from_millis(50)) {
            return Ok((child, url));
        }
        if let Ok(Some(status)) = child.try_wait() {
            std::thread::sleep(Duration::from_millis(50));
            let why: Vec<String> = erx.try_iter().collect();
            bail!("wrc ui exited ({status}): {}", why.join(" "));
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            bail!(
                "wrc ui did not start within 10 s (see {})",
                log_path.display()
            );
        }
    }
}

/// Copy `from`'s lines into `log` on a thread of their own, showing each to `seen`.
fn forward_lines(
    from: impl std::io::Read + Send + 'static,
    mut log: std::fs::File,
    seen: impl Fn(&str) + Send + 'static,
) {
    use std::io::{BufRead, Write};
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(from).lines().map_while(Result::ok) {
            let _ = writeln!(log, "{line}");
            seen(&line);
        }
    });
}

/// [`stop_children`] for the board processes that run.
fn stop_boards(boards: &mut [BoardProcess]) {
    let mut children: Vec<Child> = boards.iter_mut().filter_map(|b| b.child.take()).collect();
    stop_children(&mut children);
}

/// SIGTERM to every child, 2 s to exit, then SIGKILL; every one reaped.
pub(crate) fn stop_children(children: &mut [Child]) {
    for c in children.iter_mut() {
        // A pid we spawned and have not reaped (it may have exited: then this fails harmlessly).
        let _ = nix::sys::signal::kill(
            nix::unistd::Pid::from_raw(c.id() as i32),
            nix::sys::signal::Signal::SIGTERM,
        );
    }
    let deadline = Instant::now() + Duration::from_secs(2);
    for c in children.iter_mut() {
        while Instant::now() < deadline {
            if let Ok(Some(_)) = c.try_wait() {
                break;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        if let Ok(None) = c.try_wait() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// `--parity` (also `n`, `e`, `o`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SerialParity {
    /// No parity bit.
    #[value(alias = "n")]
    None,
    /// Even parity.
    #[value(alias = "e")]
    Even,
    /// Odd parity.
    #[value(alias = "o")]
    Odd,
}

/// An address or network of `--allow`/`--monitor`.
fn net(text: &str) -> Result<wrc_config::IpNet, String> {
    wrc_config::parse_net(text).ok_or_else(|| {
        format!("{text:?} is not an address or a network (e.g. 192.168.1.20, 10.1.0.0/16)")
    })
}

/// Run `wrc up`.
pub fn run(args: UpArgs) -> anyhow::Result<ExitCode> {
    let mut config = Config::load(args.config.as_deref())?;
    config.host.allow.extend(&args.allow);
    config.host.monitor.extend(&args.monitor);
    if let Some(file) = &args.token_file {
        config.host.token_file = Some(file.clone());
    }
    // Before any board starts: a port the network can reach needs someone to say who may
    // use it.
    wrc_controller::host_access::check_exposure(args.port, &config.host)?;
    let parity = match args.parity {
        SerialParity::None => Parity::None,
        SerialParity::Even => Parity::Even,
        SerialParity::Odd => Parity::Odd,
    };
    std::fs::create_dir_all(&args.state_dir).with_context(|| {
        format!(
            "cannot create the state directory {}",
            args.state_dir.display()
        )
    })?;
    // SIGINT/SIGTERM from now on are taken by signal-hook's self-pipe, read below.
    let mut signals = termination_signals()?;

    let mut boards_run: Vec<BoardProcess> = Vec::new();
    // The simulated cell (board 0, when it drives every robot axis) reads the same stations
    // file as the controller, so the controller's seeding from the demo cell happens here,
    // before the boards start.
    let stations_path = args
        .stations
        .clone()
        .unwrap_or_else(|| args.state_dir.join("stations.toml"));
    let world_path = args.state_dir.join("world.toml");
    let simulate_cell = args.board.is_empty()
        && config
            .boards
            .first()
            .is_some_and(|b| (0..config.robot.axis_count()).all(|axis| b.axes.contains(&axis)));
    check_state_files(
        &stations_path,
        &args.state_dir.join("wafers.toml"),
        simulate_cell.then_some(world_path.as_path()),
    )?;
    if simulate_cell {
        if !stations_path.exists() {
            wrc_board::wrc_cell::Stations::embedded_demo().save_atomic(&stations_path)?;
        }
        println!(
            "wrc: simulated cell: stations {}, ground truth {}",
            stations_path.display(),
            world_path.display()
        );
    } else if args.board.is_empty() {
        println!("wrc: no simulated cell: the robot's axes are not all on board 0");
    }
    let boards: Vec<PathBuf> = if args.board.is_empty() {
        // An ordinary process on a busy machine (or a VM) stalls for 100 ms now and then; the
        // simulated board then keeps its host watchdog to 1 s, so such a stall is not a fault
        // at rest. A real board keeps its own setting.
        let lenient =
            (args.no_rt || !fifo_allowed()).then(|| (1.0 / config.motion.period_s).ceil() as u32);
        // The same stalls would stop the board's heartbeat for as long: the controller then
        // waits as long before it declares a board dead.
        if let Some(p) = lenient {
            for b in config.boards.iter_mut().filter(|b| b.heartbeat_periods < p) {
                println!(
                    "wrc: not real-time: the controller waits {p} periods for board {}'s heartbeat instead of {}",
                    b.id, b.heartbeat_periods
                );
                b.heartbeat_periods = p;
            }
        }
        let mut paths = Vec::new();
        for b in &config.boards {
            let dpram = args.state_dir.join(format!("board{}.dpram", b.id));
            let log = args.state_dir.join(format!("board{}.log", b.id));
            // The board powers up on the DPRAM file the previous run left: the arm where its
            // absolute encoders stood when the power went (or `wrc up` stopped), every
            // output off; an unusable file is replaced by a first start at home.
            let settings = wrc_board_sim::SimSettings::from_config(&config, b);
            let epoch = match wrc_board_sim::power_up_outlook(&dpram, &settings) {
                Ok(how) => {
                    println!("wrc: board {}: {}: {how}", b.id, dpram.display());
                    match how {
                        wrc_board_sim::PowerUp::Resumed { epoch } => epoch,
                        _ => 1,
                    }
                }
                // The board says it again, in its words, when it refuses to start.
                Err(e) => {
                    println!("wrc: board {}: {e}", b.id);
                    1
                }
            };
            let watchdog = lenient.map(|p| p.max(b.watchdog_periods));
            if let Some(p) = watchdog.filter(|&p| p != b.watchdog_periods) {
                println!(
                    "wrc: not real-time: the simulated board {} watches the host with {p} periods instead of {}",
                    b.id, b.watchdog_periods
                );
            }
            let cell = (simulate_cell && paths.is_empty())
                .then(|| (stations_path.clone(), world_path.clone()));
            match BoardProcess::spawn(
                args.config.as_deref(),
                b.id,
                dpram.clone(),
                log,
                watchdog,
                cell,
                epoch,
            ) {
                Ok(board) => boards_run.push(board),
                Err(e) => {
                    stop_boards(&mut boards_run);
                    return Err(e);
                }
            }
            paths.push(dpram);
        }
        paths
    } else {
        if args.board.len() != config.boards.len() {
            bail!(
                "--board was given {} times but the configuration has {} boards",
                args.board.len(),
                config.boards.len()
            );
        }
        args.board.clone()
    };
    let options = Options {
        tcp: Some(args.port),
        socket: Some(
            args.socket
                .clone()
                .unwrap_or_else(|| args.state_dir.join("wrc.sock")),
        ),
        sim_addr: args.sim_addr,
        serial: args.serial.clone().map(|p| (p, args.baud, parity)),
        realtime: if args.no_rt {
            RealtimeMode::Off
        } else {
            RealtimeMode::Auto
        },
        boards: boards.clone(),
        board_wait: Duration::from_secs(10),
        programs: args.state_dir.join("programs"),
        traces: Some(args.state_dir.join("traces")),
        cell: Some(CellFiles {
            stations: args
                .stations
                .clone()
                .unwrap_or_else(|| args.state_dir.join("stations.toml")),
            wafers: args.state_dir.join("wafers.toml"),
        }),
    };
    let running = match controller::start(&config, &options) {
        Ok(r) => r,
        Err(e) => {
            stop_boards(&mut boards_run);
            return Err(e).context("the controller could not start");
        }
    };
    // The runtime has said once, on stderr, what scheduling the tasks got.
    if let Some(tcp) = running.tcp {
        println!("wrc: host protocol on tcp {tcp}");
    }
    if let Some(path) = &running.socket {
        println!("wrc: local GUI socket {}", path.display());
    }
    println!("wrc: simulator datagrams to udp {}", running.sim_addr);
    println!(
        "wrc: robot programs stored in {}",
        args.state_dir.join("programs").display()
    );
    if let Some(cell) = &options.cell {
        println!(
            "wrc: stations in {}, wafer map in {}",
            cell.stations.display(),
            cell.wafers.display()
        );
    }
    if let Some(serial) = &args.serial {
        println!(
            "wrc: teaching pendant on {} ({} baud, parity {})",
            serial.display(),
            args.baud,
            args.parity
                .to_possible_value()
                .map_or("?".into(), |v| v.get_name().to_string())
        );
    }
    for (b, path) in boards.iter().enumerate() {
        let how = if boards_run.is_empty() {
            "board"
        } else {
            "simulated board (wrc board-sim)"
        };
        println!("wrc: board {b}: {how} at {}", path.display());
    }
    let mut ui = None;
    if args.no_ui {
        println!("wrc: GUI not started (--no-ui)");
    } else if let Some(socket) = &running.socket {
        match spawn_ui(
            socket,
            running.sim_addr,
            args.ui_port,
            &args.state_dir,
            args.config.as_deref(),
        ) {
            Ok((child, url)) => {
                println!("wrc: GUI on {url}");
                ui = Some(child);
            }
            Err(e) => println!("wrc: GUI not started: {e:#}; the controller runs without it"),
        }
    }
    println!("wrc: ready; Ctrl-C or SIGTERM stops the robot and the controller");
    use std::io::Write;
    let _ = std::io::stdout().flush();

    // Children are reaped the moment they exit (SIGCHLD), so none is left a zombie.
    signals
        .add_signal(signal_hook::consts::SIGCHLD)
        .context("cannot watch the child processes (SIGCHLD)")?;
    let mut sig = signal_hook::consts::SIGTERM;
    for s in signals.forever() {
        if s == signal_hook::consts::SIGCHLD {
            reap(
                &mut boards_run,
                &mut ui,
                args.config.as_deref(),
                args.restart_boards,
            );
            continue;
        }
        sig = s;
        break;
    }
    println!("wrc: signal {sig}: stopping any motion, saving state, stopping tasks");
    let shared = running.shared().clone();
    let report = running.shutdown(Duration::from_secs(3));
    save_state(&args.state_dir, &shared);
    let mut children: Vec<Child> = boards_run
        .iter_mut()
        .filter_map(|b| b.child.take())
        .collect();
    children.extend(ui);
    stop_children(&mut children);
    match report {
        Some(r) if !r.is_clean() => {
            println!("wrc: {r}");
            Ok(ExitCode::from(1))
        }
        _ => {
            println!("wrc: stopped");
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// Refuse to start, before any board or task runs, when the stations file or the wafer map
/// exists but cannot be used, or (with the simulated cell) the cell's world file does not
/// fit the stations: the error names the file, and nothing is written (the controller and
/// the board would refuse them too, but only after the simulated board had started, and a
/// world file that no longer fits a stations file cut short was blamed on the world file).
/// Missing files are made later.
fn check_state_files(
    stations_path: &Path,
    wafers: &Path,
    world: Option<&Path>,
) -> anyhow::Result<()> {
    let stations = if stations_path.exists() {
        Some(wrc_cell::Stations::load(stations_path)?)
    } else {
        None
    };
    if wafers.exists() {
        wrc_cell::WaferMap::load(wafers)?;
    }
    if let (Some(stations), Some(world)) = (stations, world.filter(|w| w.exists())) {
        let text = std::fs::read_to_string(world).with_context(|| {
            format!(
                "cannot read the simulated cell's world file {}",
                world.display()
            )
        })?;
        if let Err(e) = wrc_cell::World::from_text(&text, &stations) {
            bail!(
                "the stations file {} does not fit the simulated cell saved in {} ({e}); if the stations file was cut short or edited by mistake, restore it: the world file holds where the simulated wafers are",
                stations_path.display(),
                world.display()
            );
        }
    }
    Ok(())
}

/// What `state.toml` records at shutdown, for the operator (nothing reads it back).
#[derive(serde::Serialize)]
struct SavedState {
    homed: bool,
    speed_pct: u32,
    outputs: u32,
    commanded_pulses: Vec<i64>,
}

/// Write the last commanded position and settings to `state.toml`, atomically (the wafer
/// map's write: temporary file, fsync, rename, fsync of the directory).
fn save_state(dir: &Path, shared: &wrc_controller::shared::Shared) {
    let state = SavedState {
        homed: shared.homed.load(Ordering::Acquire),
        speed_pct: shared.speed_pct.load(Ordering::Acquire),
        outputs: shared.outputs[0].load(Ordering::Acquire),
        commanded_pulses: shared.commanded_pulses().to_vec(),
    };
    let saved = toml::to_string(&state)
        .map_err(|e| e.to_string())
        .and_then(|body| {
            let text = format!("# wrc controller state at shutdown\n{body}");
            wrc_cell::write_atomic(&dir.join("state.toml"), text.as_bytes())
                .map_err(|e| e.to_string())
        });
    if let Err(e) = saved {
        tracing::error!("wrc: could not save the state in {}: {e}", dir.display());
    }
}
