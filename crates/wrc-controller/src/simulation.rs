//! The whole controller under virtual time: the eight tasks of Table 1, the urgent path, the
//! service thread's work and the simulated boards (servo, I/O, vacuum, mapping sensor,
//! watchdog, the wafer cell) stepped in this process by one deterministic scheduler
//! ([`wrc_rt::virtual_time`]), as fast as the CPU allows or at a multiple of real time.
//!
//! The task code is the code `wrc up` runs on real-time threads ([`crate::controller`]
//! assembles both on a [`crate::host::Host`]); what changes is the clock and who releases
//! the tasks:
//!
//! | part | real time | virtual time |
//! |---|---|---|
//! | tasks of Table 1 | SCHED_FIFO threads | the scheduler, priority order, same periods |
//! | event release (queues, stop requests) | futex / epoll | a flag the scheduler reads |
//! | sockets, tty | epoll wakes Ethernet and RS232C | read at their period, or at once after [`Simulation::notify_network`] |
//! | urgent path | a thread on the semaphore | a task released when the semaphore holds a count |
//! | service thread | a thread, woken or every 50 ms | a task at the lowest priority, same release |
//! | simulated board | `wrc board-sim` process at its own clock | a task above all others at the board period |
//!
//! A cycle takes no virtual time. With the same configuration, files and requests at the
//! same virtual times, two runs make the same calls in the same order: the same pulses reach
//! the board and the same replies the clients. Benchmark timestamps (`Shared::now_ns`) stay
//! on the host's clock: they measure this process, not the robot.
//!
//! # A power cut
//!
//! [`Simulation::power_cycle`] plays a power loss at the current virtual instant and the
//! power coming back: the controller and the boards die without a word (nothing is saved
//! that a power cut would not have saved: the state directory keeps what is on disk at that
//! instant), then a new controller starts in the same state directory with the same
//! configuration, its boards powering up where their absolute encoders stood with every
//! output off (`SimBoard::power_up`, as `wrc up` starts them), the simulated cell going on
//! from its world as it was: at its first step the hand's wafer, which the vacuum no longer
//! holds, drops where the arm is. The clients' connections are gone with the controller.

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::net::SocketAddr;
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;
use std::time::Instant;

use wrc_board::driver::Mapping;
use wrc_board::wrc_cell::{Stations, World};
use wrc_board::{DpramBoard, Expect, MultiBoard};
use wrc_board_sim::cell::SimCell;
use wrc_board_sim::{PowerUp, SimBoard, SimSettings};
use wrc_config::Config;
use wrc_rt::virtual_time::{Pace, VirtualRuntime};
use wrc_rt::{CycleContext, Notify, RealtimeMode, TaskSpec};

use crate::controller::{assemble, query_cells, CellFiles, Options, StartError};
use crate::host::VirtualHost;
use crate::shared::Shared;

/// Where virtual time starts [ns] (one second, so that no time a task computes is 0).
pub const START_NS: u64 = 1_000_000_000;

/// How long the power stays off in [`Simulation::power_cycle`] [ns, virtual]: the new
/// controller's clock starts this much after the instant of the cut.
pub const POWER_OFF_NS: u64 = 1_000_000_000;

/// The paper priority of the simulated boards: above every task (hardware does not wait).
const BOARD_PRIORITY: u8 = 1;
/// The paper priority of the service thread's work: below every task of Table 1.
const SERVICE_PRIORITY: u8 = 90;
/// The service thread's longest wait between two looks at its queues [µs].
const SERVICE_PERIOD_US: u64 = 50_000;

/// Where [`Simulation::in_state_dir`] takes the simulated cell from.
#[derive(Debug, Clone, Copy, Default)]
pub struct SimCellFrom<'a> {
    /// The stations file (default: `dir/stations.toml`).
    pub stations: Option<&'a Path>,
    /// The ground truth, as a world file's text (default: the stations' sim wafers).
    pub world: Option<&'a str>,
}

/// The controller and its simulated boards on virtual time.
pub struct Simulation {
    runtime: VirtualRuntime,
    shared: Arc<Shared>,
    ethernet: Arc<dyn Notify>,
    boards: Vec<Arc<Mutex<SimBoard>>>,
    /// Per board: its DPRAM, its settings and whether it runs ([`Simulation::kill_board`]).
    board_lives: Vec<BoardLife>,
    pulse_log: PulseLog,
    service: Arc<Mutex<crate::service::Service>>,
    wall_start: Instant,
    /// The Pulse Generator does nothing before this virtual time [ns].
    stall: Arc<std::sync::atomic::AtomicU64>,
    /// What it was started with, to start again after a power cut.
    config: Config,
    options: Options,
    pace: Pace,
    /// The TCP address actually bound (with the real port when 0 was asked).
    pub tcp: Option<SocketAddr>,
    /// The local GUI socket.
    pub socket: Option<PathBuf>,
}

impl std::fmt::Debug for Simulation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Simulation")
            .field("runtime", &self.runtime)
            .field("tcp", &self.tcp)
            .field("socket", &self.socket)
            .finish_non_exhaustive()
    }
}

/// What board 0 executed, when asked for ([`Simulation::record_pulses`]): the virtual time
/// [ns] and each axis's commanded position [pulse] after every board period.
#[derive(Debug, Default)]
struct PulseRecorder {
    on: std::sync::atomic::AtomicBool,
    rows: Mutex<Vec<(u64, Vec<i64>)>>,
}

type PulseLog = Arc<PulseRecorder>;

/// A simulated board's DPRAM and settings, to restart it on, and whether it runs.
struct BoardLife {
    map: Mapping,
    settings: SimSettings,
    alive: Arc<std::sync::atomic::AtomicBool>,
}

/// A simulated board about to run: its DPRAM, its settings and the board on it.
struct PoweredBoard {
    map: Mapping,
    settings: SimSettings,
    sim: SimBoard,
}

/// What a [`Simulation`] starts from: the virtual time, the pace and the pulse log (those of
/// the simulation that ran before a power cut).
struct Continued {
    start_ns: u64,
    pace: Pace,
    pulse_log: PulseLog,
}

/// A task that steps one simulated board (while it is alive).
struct BoardTask {
    board: Arc<Mutex<SimBoard>>,
    alive: Arc<std::sync::atomic::AtomicBool>,
    log: Option<PulseLog>,
}

impl wrc_rt::Task for BoardTask {
    fn cycle(&mut self, ctx: &CycleContext) {
        if !self.alive.load(Ordering::Acquire) {
            return; // a dead board does nothing at all: its heartbeat stands
        }
        let mut board = lock(&self.board);
        board.step();
        // The cell's event was for `wrc board-sim`'s log and world file; here the world is
        // read directly ([`Simulation::board`]).
        let _ = board.take_cell_event();
        if let Some(log) = self.log.as_ref().filter(|l| l.on.load(Ordering::Relaxed)) {
            let pulses = (0..4)
                .filter_map(|ch| board.axis(ch).map(|a| a.commanded()))
                .collect();
            log.rows
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push((ctx.woke_ns, pulses));
        }
    }
}

fn lock(board: &Mutex<SimBoard>) -> MutexGuard<'_, SimBoard> {
    // One thread: never contended; a poisoned lock still holds a usable board.
    board.lock().unwrap_or_else(|e| e.into_inner())
}

impl Simulation {
    /// Build the controller of `config` with `options` (its `boards`, `board_wait`,
    /// `realtime` and `serial` are not used: the boards are simulated here) on virtual time
    /// starting at [`START_NS`]. `cell`: the simulated wafer cell on board 0 (the stations
    /// must be those of `options.cell`).
    pub fn start(
        config: &Config,
        options: &Options,
        cell: Option<SimCell>,
    ) -> Result<Simulation, StartError> {
        let mut boards = Vec::with_capacity(config.boards.len());
        let mut cell = cell;
        for board in &config.boards {
            let map = Mapping::anonymous()?;
            let settings = SimSettings::from_config(config, board);
            let mut sim = SimBoard::new(map.share(), &settings, 1)?;
            if let Some(c) = cell.take() {
                sim.attach_cell(c)?;
            }
            boards.push(PoweredBoard { map, settings, sim });
        }
        let from = Continued {
            start_ns: START_NS,
            pace: Pace::Unpaced,
            pulse_log: PulseLog::default(),
        };
        Simulation::run_on(config, options, boards, from)
    }

    /// The controller of `config` with `options` on `powered` (board 0 carrying the
    /// simulated cell, if any), its clock starting at `from.start_ns`.
    fn run_on(
        config: &Config,
        options: &Options,
        powered: Vec<PoweredBoard>,
        from: Continued,
    ) -> Result<Simulation, StartError> {
        let mut boards = Vec::with_capacity(powered.len());
        let mut maps = Vec::with_capacity(powered.len());
        let mut board_lives = Vec::with_capacity(powered.len());
        for (board, p) in config.boards.iter().zip(powered) {
            maps.push((board.id, board.axes.len(), p.map.share()));
            board_lives.push(BoardLife {
                map: p.map,
                settings: p.settings,
                alive: Arc::new(std::sync::atomic::AtomicBool::new(true)),
            });
            boards.push(Arc::new(Mutex::new(p.sim)));
        }
        let open = || -> Result<MultiBoard<DpramBoard>, StartError> {
            let mut opened = Vec::with_capacity(maps.len());
            let mut map = vec![(0usize, 0usize); config.robot.axis_count()];
            for (b, ((id, axes, mapping), board)) in maps.iter().zip(&config.boards).enumerate() {
                let expect = Expect {
                    board_id: Some(*id),
                    axis_count: Some(*axes as u32),
                    period_us: None,
                };
                opened.push(DpramBoard::attach(mapping.share(), expect)?);
                for (channel, &axis) in board.axes.iter().enumerate() {
                    if let Some(m) = map.get_mut(axis) {
                        *m = (b, channel);
                    }
                }
            }
            Ok(MultiBoard::new(opened, &map)?)
        };
        let stall = Arc::new(std::sync::atomic::AtomicU64::new(0));
        let mut runtime = VirtualRuntime::new(from.start_ns);
        runtime.set_pace(from.pace);
        let mut host = VirtualHost(runtime, stall.clone());
        let pulse_log = from.pulse_log;
        for ((board, sim), life) in config.boards.iter().zip(&boards).zip(&board_lives) {
            let period_us = u64::from(lock(sim).period_us());
            host.0.add(
                TaskSpec::new(format!("board{}", board.id), BOARD_PRIORITY, period_us),
                BoardTask {
                    board: sim.clone(),
                    alive: life.alive.clone(),
                    log: (board.id == config.boards[0].id).then(|| pulse_log.clone()),
                },
            )?;
        }
        let world_toml = boards
            .first()
            .and_then(|b| lock(b).cell().map(|c| c.world().to_text()));
        let parts = assemble(
            &mut host,
            config,
            options,
            &open,
            wrc_trace::ClockKind::Virtual,
            world_toml,
        )?;
        let mut runtime = host.0;
        let urgent = parts.urgent;
        let posted = urgent.wake.clone();
        runtime.add_polled(
            TaskSpec::new("urgent_path", parts.ci_priority, SERVICE_PERIOD_US),
            move |_: &CycleContext| urgent.drain(),
            move || posted.count() > 0,
        )?;
        let service = Arc::new(Mutex::new(parts.service));
        let stepped = service.clone();
        runtime.add_released(
            TaskSpec::new("service", SERVICE_PRIORITY, SERVICE_PERIOD_US),
            move |_: &CycleContext| stepped.lock().unwrap_or_else(|e| e.into_inner()).step(),
            &parts.service_wake,
        )?;
        let tasks: Vec<_> = runtime
            .task_cells()
            .into_iter()
            .filter(|(spec, _)| {
                wrc_rt::TaskTable::paper_table1().get(&spec.name).is_some()
                    || config.tasks.get(&spec.name).is_some()
            })
            .collect();
        let _ = parts.task_cells.set(query_cells(tasks, &parts.shared));
        // Power-on: every task has run its first cycle (the I/O Monitor has read the inputs,
        // Error Check has looked at the boards) before a client is served, as under
        // `wrc up`, where the boards start before the controller and clients come later.
        let longest_ns = runtime
            .task_cells()
            .iter()
            .map(|(spec, _)| spec.period_ns())
            .max()
            .unwrap_or(0);
        runtime.run_for_ns(longest_ns);
        Ok(Simulation {
            runtime,
            shared: parts.shared,
            ethernet: parts.ethernet,
            boards,
            board_lives,
            pulse_log,
            service,
            wall_start: Instant::now(),
            stall,
            config: config.clone(),
            options: options.clone(),
            pace: from.pace,
            tcp: parts.tcp,
            socket: options.socket.clone(),
        })
    }

    /// A power cut now, and the power back [`POWER_OFF_NS`] later (see the module docs):
    /// the controller and its boards are dropped without any shutdown (a motion in flight
    /// stops where it is: the arm stays where its encoders stand); a new controller starts
    /// in the same state directory with the same configuration, on boards that power up at
    /// those encoder counts with every output off and a new epoch, the simulated cell going
    /// on from its world as it is now (its wafers where they are; a wafer on the hand is
    /// released where the arm is at the first board period: placed if the hand is seated
    /// within a stroke above a support, otherwise lost). The new clock starts at the cut's
    /// virtual instant plus [`POWER_OFF_NS`] (nothing moves while the power is off), the
    /// pace and the pulse recording go on; [`Simulation::virtual_s`] counts from the new
    /// start. Clients connect again.
    pub fn power_cycle(self) -> Result<Simulation, StartError> {
        let Simulation {
            runtime,
            shared,
            ethernet,
            boards,
            board_lives,
            pulse_log,
            service,
            stall,
            config,
            options,
            pace,
            ..
        } = self;
        let start_ns = runtime.now_ns().saturating_add(POWER_OFF_NS);
        // The cell's ground truth as it is at the cut; its sensor state (the mapping latch)
        // was in the board's memory and goes with the power.
        let cell = boards.first().and_then(|b| lock(b).take_cell());
        // Everything dies at once: the tasks with their queues and sockets (the clients see
        // their connections end), the boards. Nothing here writes a file on its way out.
        drop((runtime, shared, ethernet, boards, service, stall));
        let mut powered = Vec::with_capacity(board_lives.len());
        for life in board_lives {
            let (sim, how) = SimBoard::power_up(life.map.share(), &life.settings)?;
            if !matches!(how, PowerUp::Resumed { .. }) {
                // Cannot happen on the DPRAM the same board ran on; never start at home
                // silently.
                return Err(StartError::SimCell(format!(
                    "board {} lost its encoders in the power cut: {how}",
                    life.settings.board_id
                )));
            }
            powered.push(PoweredBoard {
                map: life.map,
                settings: life.settings,
                sim,
            });
        }
        if let (Some(old), Some(first), Some(board)) =
            (cell, powered.first_mut(), config.boards.first())
        {
            let fresh = SimCell::new(&config, board, old.stations().clone())
                .map_err(|e| StartError::SimCell(e.to_string()))?;
            first
                .sim
                .attach_cell(fresh.with_world(old.world().clone()))?;
        }
        let from = Continued {
            start_ns,
            pace,
            pulse_log,
        };
        Simulation::run_on(&config, &options, powered, from)
    }

    /// The controller of `config` with its state in `dir` (programs, wafer map, traces,
    /// the local socket `dir/wrc.sock`): stations from `cell.stations` (default
    /// `dir/stations.toml`, written from the built-in demo cell when missing), the simulated
    /// cell on board 0 (when it drives every robot axis) from `cell.world` (a world file's
    /// text; default: the stations' `[station.sim]` wafers), the host protocol on `tcp`.
    pub fn in_state_dir(
        config: &Config,
        dir: &Path,
        cell: SimCellFrom<'_>,
        tcp: Option<SocketAddr>,
        sim_addr: SocketAddr,
    ) -> Result<Simulation, StartError> {
        let stations_path = cell
            .stations
            .map(Path::to_path_buf)
            .unwrap_or_else(|| dir.join("stations.toml"));
        if !stations_path.exists() {
            Stations::embedded_demo()
                .save_atomic(&stations_path)
                .map_err(crate::cell_service::CellError::from)?;
        }
        let sim_cell = match config.boards.first() {
            Some(board)
                if (0..config.robot.axis_count()).all(|axis| board.axes.contains(&axis)) =>
            {
                let stations =
                    Stations::load(&stations_path).map_err(crate::cell_service::CellError::from)?;
                let bad = |e: &dyn std::fmt::Display| {
                    StartError::SimCell(format!("stations {}: {e}", stations_path.display()))
                };
                let sim_cell = SimCell::new(config, board, stations).map_err(|e| bad(&e))?;
                Some(match cell.world {
                    Some(text) => {
                        let world = World::from_text(text, sim_cell.stations()).map_err(|e| {
                            StartError::SimCell(format!("the cell's ground truth: {e}"))
                        })?;
                        sim_cell.with_world(world)
                    }
                    None => sim_cell,
                })
            }
            _ => None,
        };
        let options = Options {
            tcp,
            socket: Some(dir.join("wrc.sock")),
            sim_addr,
            serial: None,
            realtime: RealtimeMode::Off,
            boards: Vec::new(),
            board_wait: Duration::ZERO,
            programs: dir.join("programs"),
            traces: Some(dir.join("traces")),
            cell: Some(CellFiles {
                stations: stations_path,
                wafers: dir.join("wafers.toml"),
            }),
        };
        Simulation::start(config, &options, sim_cell)
    }

    /// Run as fast as the CPU allows, or no faster than a multiple of real time.
    pub fn set_pace(&mut self, pace: Pace) {
        self.pace = pace;
        self.runtime.set_pace(pace);
    }

    /// Run one cycle (the most urgent task due); returns the task's name.
    pub fn step(&mut self) -> &str {
        self.runtime.step().0
    }

    /// Run every cycle due up to `t_ns` [ns, virtual].
    pub fn run_until_ns(&mut self, t_ns: u64) {
        self.runtime.run_until_ns(t_ns);
    }

    /// Run every cycle due before `t_ns` [ns] and leave the clock at `t_ns`, with what is
    /// due at it still to run ([`VirtualRuntime::run_before_ns`]).
    pub fn run_before_ns(&mut self, t_ns: u64) {
        self.runtime.run_before_ns(t_ns);
    }

    /// Run for `ns` [ns] of virtual time.
    pub fn run_for_ns(&mut self, ns: u64) {
        self.runtime.run_for_ns(ns);
    }

    /// Now [ns, virtual; starts at [`START_NS`]].
    pub fn now_ns(&self) -> u64 {
        self.runtime.now_ns()
    }

    /// Virtual time since the start, power-on included [s].
    pub fn virtual_s(&self) -> f64 {
        self.runtime.elapsed_ns() as f64 / 1e9
    }

    /// Wall time since the start [s].
    pub fn wall_s(&self) -> f64 {
        self.wall_start.elapsed().as_secs_f64()
    }

    /// A client wrote to the controller: the Ethernet task runs at this instant (as epoll
    /// would release it) instead of at its next period.
    pub fn notify_network(&self) {
        self.ethernet.notify();
    }

    /// The shared state.
    pub fn shared(&self) -> &Arc<Shared> {
        &self.shared
    }

    /// Simulated board `index` (its DPRAM, servo axes and cell).
    pub fn board(&self, index: usize) -> Option<MutexGuard<'_, SimBoard>> {
        self.boards.get(index).map(|b| lock(b))
    }

    /// Board `index` stops dead (a hung DSP, a killed `wrc board-sim`): from its next period
    /// on it does nothing, its heartbeat stands and its DPRAM keeps its last contents. False
    /// for a board that does not exist.
    pub fn kill_board(&mut self, index: usize) -> bool {
        self.board_lives
            .get(index)
            .map(|l| l.alive.store(false, Ordering::Release))
            .is_some()
    }

    /// Board `index` starts again on its DPRAM, as `wrc board-sim` does when restarted: a
    /// new epoch, the axes where their encoders were, the outputs as latched, the simulated
    /// cell (its wafers) taken over from the dead board.
    pub fn restart_board(&mut self, index: usize) -> Result<(), StartError> {
        let (Some(life), Some(board)) = (self.board_lives.get(index), self.boards.get(index))
        else {
            return Ok(());
        };
        let mut old = lock(board);
        let mut fresh = SimBoard::take_over(life.map.share(), &life.settings)?;
        if let Some(cell) = old.take_cell() {
            fresh.attach_cell(cell)?;
        }
        *old = fresh;
        life.alive.store(true, Ordering::Release);
        Ok(())
    }

    /// A host stall: the Pulse Generator does nothing for `ns` [ns] of virtual time from now
    /// (neither pushes nor refreshes the board's watchdog nor answers a stop), as a
    /// real-time thread the kernel does not run; every other task, and the boards, go on.
    pub fn stall_pulse_generator(&self, ns: u64) {
        self.stall
            .store(self.now_ns().saturating_add(ns), Ordering::Relaxed);
    }

    /// Record (or stop recording) what board 0 executes: every board period's virtual
    /// time and commanded positions, kept until [`Simulation::take_pulses`].
    pub fn record_pulses(&self, on: bool) {
        self.pulse_log.on.store(on, Ordering::Relaxed);
    }

    /// Take what board 0 executed since the last call while recording: (virtual time [ns],
    /// commanded position of each axis [pulse]) per board period (the pulse stream, for
    /// comparing runs).
    pub fn take_pulses(&self) -> Vec<(u64, Vec<i64>)> {
        std::mem::take(
            &mut *self
                .pulse_log
                .rows
                .lock()
                .unwrap_or_else(|e| e.into_inner()),
        )
    }

    /// Everything the trace recorder holds now, with `reason` (`None`: the controller was
    /// started without a trace directory).
    pub fn trace(&self, reason: &str) -> Option<wrc_trace::TraceFile> {
        let mut service = self.service.lock().unwrap_or_else(|e| e.into_inner());
        service.recorder_mut().map(|r| r.snapshot(reason))
    }

    /// Every task's statistics (virtual: exact periods, no latency).
    pub fn task_stats(&self) -> Vec<wrc_rt::TaskSnapshot> {
        self.runtime.snapshot()
    }

    /// The robot has nothing moving or pending (every stop executed, no move in flight).
    pub fn at_rest(&self) -> bool {
        self.shared.stopped_epoch.load(Ordering::Acquire)
            == self.shared.stop_epoch.load(Ordering::Acquire)
            && self.shared.in_flight.load(Ordering::Acquire) == 0
    }
}

/// A client of a [`Simulation`] on its local socket (or its TCP port,
/// [`Simulation::connect_tcp`]): what it sends reaches the Ethernet task at the virtual
/// instant it is sent; what the controller writes is read between cycles.
#[derive(Debug)]
pub struct SimClient {
    stream: ClientStream,
    pending: Vec<u8>,
    lines: VecDeque<String>,
}

/// The connection of a [`SimClient`].
#[derive(Debug)]
enum ClientStream {
    Unix(UnixStream),
    Tcp(std::net::TcpStream),
}

impl ClientStream {
    fn set_nonblocking(&self, on: bool) -> std::io::Result<()> {
        match self {
            ClientStream::Unix(s) => s.set_nonblocking(on),
            ClientStream::Tcp(s) => s.set_nonblocking(on),
        }
    }

    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match self {
            ClientStream::Unix(s) => s.read(buf),
            ClientStream::Tcp(s) => s.read(buf),
        }
    }

    fn write_all(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        match self {
            ClientStream::Unix(s) => s.write_all(bytes),
            ClientStream::Tcp(s) => s.write_all(bytes),
        }
    }
}

/// Why a [`SimClient`] got no line.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// The socket failed.
    #[error("the simulated controller's socket: {0}")]
    Io(#[from] std::io::Error),
    /// The controller closed the connection.
    #[error("the simulated controller closed the connection")]
    Closed,
    /// Nothing came within the virtual time allowed.
    #[error("no line from the simulated controller within {0:.3} s of virtual time")]
    Timeout(f64),
    /// The simulation has no local socket (or no TCP port, for a TCP client).
    #[error("the simulation has no socket of that kind to connect to")]
    NoSocket,
}

impl SimClient {
    /// Read what the controller has written so far (non-blocking).
    fn fill(&mut self) -> Result<(), ClientError> {
        let mut buf = [0u8; 4096];
        // The lines before the end are still delivered; the end is reported once they are
        // read (the controller's last words, e.g. `EVT CLOSING`, come just before it).
        let mut closed = false;
        loop {
            match self.stream.read(&mut buf) {
                Ok(0) => {
                    closed = true;
                    break;
                }
                Ok(n) => self.pending.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e.into()),
            }
        }
        while let Some(end) = self.pending.iter().position(|&b| b == b'\n') {
            let line: Vec<u8> = self.pending.drain(..=end).collect();
            self.lines
                .push_back(String::from_utf8_lossy(&line).trim_end().to_string());
        }
        if closed && self.lines.is_empty() {
            return Err(ClientError::Closed);
        }
        Ok(())
    }
}

impl Simulation {
    /// Connect a client to the local socket (accepted at this instant), as the GUI does.
    pub fn connect(&mut self) -> Result<SimClient, ClientError> {
        let path = self.socket.as_ref().ok_or(ClientError::NoSocket)?;
        let stream = ClientStream::Unix(UnixStream::connect(path)?);
        Ok(self.client(stream)?)
    }

    /// Connect a client to the host protocol's TCP port (accepted at this instant), as a
    /// host does: the controller names it as a host (`tcp1`, …), not as the GUI.
    pub fn connect_tcp(&mut self) -> Result<SimClient, ClientError> {
        let addr = self.tcp.ok_or(ClientError::NoSocket)?;
        let stream = std::net::TcpStream::connect(addr)?;
        // Each line leaves at once (no Nagle wait for the previous one's ACK): on loopback
        // it is readable when the write returns.
        stream.set_nodelay(true)?;
        Ok(self.client(ClientStream::Tcp(stream))?)
    }

    fn client(&mut self, stream: ClientStream) -> std::io::Result<SimClient> {
        stream.set_nonblocking(true)?;
        self.notify_network();
        Ok(SimClient {
            stream,
            pending: Vec::new(),
            lines: VecDeque::new(),
        })
    }

    /// Send `text` (one or more lines, each ending with `\n`) from `client` now.
    pub fn send(&mut self, client: &mut SimClient, text: &str) -> Result<(), ClientError> {
        // Whole lines at once, as a host writes them; the socket's buffer is far larger than
        // a request or an upload of the protocol's lines.
        client.stream.set_nonblocking(false)?;
        let sent = client.stream.write_all(text.as_bytes());
        client.stream.set_nonblocking(true)?;
        sent?;
        self.notify_network();
        Ok(())
    }

    /// The next line the controller writes to `client`, running the simulation for at most
    /// `within_ns` [ns] of virtual time.
    pub fn next_line(
        &mut self,
        client: &mut SimClient,
        within_ns: u64,
    ) -> Result<String, ClientError> {
        let until = self.now_ns().saturating_add(within_ns);
        loop {
            if let Some(line) = client.lines.pop_front() {
                return Ok(line);
            }
            if self.now_ns() > until {
                return Err(ClientError::Timeout(within_ns as f64 / 1e9));
            }
            // Only the Ethernet task writes to clients.
            if self.step() == "ethernet" {
                client.fill()?;
            }
        }
    }

    /// Send the request `line` (no `\n`) and return its `ACK` or `NAK` (the first one with
    /// the request's id, or the first one at all for a request without an id), within
    /// `within_ns` [ns] of virtual time; other lines are skipped.
    pub fn ask(
        &mut self,
        client: &mut SimClient,
        line: &str,
        within_ns: u64,
    ) -> Result<String, ClientError> {
        self.send(client, &format!("{line}\n"))?;
        let id = line
            .split(' ')
            .next()
            .filter(|w| !w.is_empty() && w.bytes().all(|b| b.is_ascii_digit()));
        let until = self.now_ns().saturating_add(within_ns);
        loop {
            let left = until.saturating_sub(self.now_ns());
            let reply = self.next_line(client, left)?;
            let mut words = reply.split(' ');
            let kind = words.next().unwrap_or("");
            if (kind == "ACK" || kind == "NAK") && id.is_none_or(|id| words.next() == Some(id)) {
                return Ok(reply);
            }
        }
    }
}
