//! Starting and stopping the controller: open the motion boards, bind the endpoints, build
//! the eight tasks of Table 1 with their queues, and run them on the real-time runtime.
//! Everything that may fail (a busy port, a missing board) fails here, before the first
//! cycle, with a message that names the endpoint or the file.

use std::net::{SocketAddr, TcpListener, UdpSocket};
use std::os::unix::net::UnixListener;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use wrc_board::{DpramBoard, Expect, MotionBoard, MultiBoard};
use wrc_config::Config;
use wrc_motion::VelocityGenerator as Generator;
use wrc_rt::ipc::{mailbox, spsc, MessageQueue, Semaphore};
use wrc_rt::{RealtimeMode, RunningRuntime, Runtime, RuntimeOptions, SchedReport, StopReport};

use crate::clients::{ClientSet, Routes};
pub use crate::start_error::StartError;

use crate::host::{Host, HostWake, RealHost};

use crate::command_interpreter::{CommandInterpreter, CommandLinks, UrgentPath};
use crate::error_check::{ErrorCheck, Limits, Watched};
use crate::ethernet::Ethernet;
use crate::io_monitor::IoMonitor;
use crate::messages::{Outputs, SourceId, StoreLinks};
use crate::pulse_generator::PulseGenerator;
use crate::queries::TaskCell;
use crate::rs232c::{open_serial, Parity, Rs232c};
use crate::service::Service;
use crate::shared::{Shared, StopKind};
use crate::simulator_manager::SimulatorManager;
use crate::velocity_generator::VelocityGenerator;

/// Local GUI clients served at once (Unix socket).
pub const MAX_GUIS: usize = 16;

/// The tasks whose overruns during a motion are a fault (code 207) under real-time scheduling.
/// Batches in the pulse ring: what the Velocity Generator plans between two of its cycles
/// and the Pulse Generator's look-ahead, twice over (at 1 kHz a 16-period ring ran dry
/// between two 50 ms cycles and the motion stuttered: zero periods streamed mid-move).
fn ring_capacity(config: &Config) -> usize {
    let vg_period_us = config
        .tasks
        .get("velocity_generator")
        .map_or(50_000, |t| t.period_us);
    let motion_us = (config.motion.period_s * 1e6).max(1.0);
    let ring =
        (2.0 * (vg_period_us as f64 / motion_us).ceil()) as usize + 2 * config.lookahead_periods;
    ring.clamp(16, 4096)
}

/// How long a stall of task `name` of the motion path a motion rides out [ns] (`None`: not
/// of the motion path; its stalls are no fault): what the buffer after it covers. The
/// Pulse Generator's: the look-ahead queued in the board's FIFO. The Velocity Generator's:
/// the full ring and the look-ahead, less the period it waits anyway. Error Check's: one of
/// its periods (a check late by more than that is a fault found that much later).
fn stall_tolerance_ns(config: &Config, name: &str) -> Option<u64> {
    let motion_ns = config.motion.period_s * 1e9;
    let period_ns = |task: &str| {
        config
            .tasks
            .get(task)
            .map_or(0.0, |t| t.period_us as f64 * 1e3)
    };
    let lookahead = config.lookahead_periods as f64 * motion_ns;
    let ns = match name {
        "pulse_generator" => lookahead,
        "velocity_generator" => {
            ring_capacity(config) as f64 * motion_ns + lookahead - period_ns(name)
        }
        "error_check" => period_ns(name),
        _ => return None,
    };
    Some(ns.max(0.0) as u64)
}

/// Where the controller listens and sends.
#[derive(Debug, Clone)]
pub struct Options {
    /// Host protocol on TCP (default 127.0.0.1:7100); `None`: no TCP.
    pub tcp: Option<SocketAddr>,
    /// Local GUI socket path; `None`: no Unix socket.
    pub socket: Option<PathBuf>,
    /// Simulator datagrams go here (default 127.0.0.1:7200).
    pub sim_addr: SocketAddr,
    /// Teaching pendant: device, baud rate and parity.
    pub serial: Option<(PathBuf, u32, Parity)>,
    /// Real-time scheduling (SCHED_FIFO when allowed).
    pub realtime: RealtimeMode,
    /// The DPRAM file of each board, in configuration order.
    pub boards: Vec<PathBuf>,
    /// How long to wait for a board to appear (a simulated board starting up).
    pub board_wait: Duration,
    /// Where robot-language programs are stored (created if missing).
    pub programs: PathBuf,
    /// Where the trace recorder saves (created if missing); `None`: no recorder.
    pub traces: Option<PathBuf>,
    /// The wafer cell's files: the stations file (written from the embedded demo cell when
    /// missing) and the wafer map; `None`: no stations (`STN`, `TEACH`, `WAFERS` are refused).
    pub cell: Option<CellFiles>,
}

/// Where the wafer cell is kept.
#[derive(Debug, Clone)]
pub struct CellFiles {
    /// The stations file (TOML).
    pub stations: PathBuf,
    /// The wafer map file (TOML).
    pub wafers: PathBuf,
}

/// A running controller.
pub struct Running {
    runtime: Option<RunningRuntime>,
    urgent: Option<JoinHandle<()>>,
    store: Option<JoinHandle<()>>,
    quit: Arc<AtomicBool>,
    shared: Arc<Shared>,
    /// Where it listens: TCP address actually bound (with the real port when 0 was asked).
    pub tcp: Option<SocketAddr>,
    /// The Unix socket path.
    pub socket: Option<PathBuf>,
    /// Where the simulator datagrams go.
    pub sim_addr: SocketAddr,
}

fn open_boards(
    config: &Config,
    paths: &[PathBuf],
    wait: Duration,
) -> Result<MultiBoard<DpramBoard>, StartError> {
    let mut boards = Vec::with_capacity(paths.len());
    let mut map = vec![(0usize, 0usize); config.robot.axis_count()];
    for (b, (board, path)) in config.boards.iter().zip(paths).enumerate() {
        let expect = Expect {
            board_id: Some(board.id),
            axis_count: Some(board.axes.len() as u32),
            period_us: None,
        };
        boards.push(DpramBoard::open_waiting(path, expect, wait)?);
        for (channel, &axis) in board.axes.iter().enumerate() {
            if let Some(m) = map.get_mut(axis) {
                *m = (b, channel);
            }
        }
    }
    Ok(MultiBoard::new(boards, &map)?)
}

impl Running {
    /// The shared state (for tests and the binary's status line).
    pub fn shared(&self) -> &Arc<Shared> {
        &self.shared
    }

    /// Every task's statistics so far (allocates; for reports and benchmarks).
    pub fn task_stats(&self) -> Vec<wrc_rt::TaskSnapshot> {
        self.runtime
            .as_ref()
            .map(|r| r.snapshot())
            .unwrap_or_default()
    }

    /// What scheduling the tasks got.
    pub fn scheduling(&self) -> Option<&SchedReport> {
        self.runtime.as_ref().map(|r| r.scheduling())
    }

    /// Controlled shutdown: stop any motion (waiting up to `timeout` for the robot to come
    /// to rest), then end every task after its current cycle.
    pub fn shutdown(mut self, timeout: Duration) -> Option<StopReport> {
        self.shared.request_stop(StopKind::Stop);
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            let stopped = self.shared.stopped_epoch.load(Ordering::Acquire)
                == self.shared.stop_epoch.load(Ordering::Acquire)
                && self.shared.in_flight.load(Ordering::Acquire) == 0;
            if stopped {
                break;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        self.finish(timeout)
    }

    fn finish(&mut self, timeout: Duration) -> Option<StopReport> {
        self.quit.store(true, Ordering::Release);
        let report = self.runtime.take().map(|r| r.stop(timeout));
        if let Some(h) = self.urgent.take() {
            let _ = h.join();
        }
        if let Some(h) = self.store.take() {
            let _ = h.join();
        }
        if let Some(path) = &self.socket {
            let _ = std::fs::remove_file(path);
        }
        report
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        self.finish(Duration::from_secs(1));
    }
}

/// The controller assembled on a [`Host`], before it runs: what the runtime's caller still
/// has to start or hand on.
pub(crate) struct Assembled<W> {
    pub shared: Arc<Shared>,
    pub tcp: Option<SocketAddr>,
    /// Overrun statistics Error Check watches (set once the runtime says it is real-time).
    pub watched: Arc<OnceLock<Vec<Watched>>>,
    /// The `TASKS` query's cells (set once the runtime has its tasks).
    pub task_cells: crate::queries::TaskCells,
    /// The urgent path's blocking half.
    pub urgent: UrgentPath,
    /// The service thread's state and its waiter.
    pub service: Service,
    pub service_wake: W,
    /// Releases the Ethernet task (a client wrote to it; virtual time's clients).
    #[cfg_attr(not(feature = "sim"), allow(dead_code))]
    pub ethernet: Arc<dyn wrc_rt::Notify>,
    /// The Command Interpreter's task: the urgent path runs at its priority.
    pub ci_priority: u8,
    pub quit: Arc<AtomicBool>,
}

/// Build the eight tasks of Table 1 with their queues on `host`, with the boards `open`
/// makes (called once per task that drives them).
pub(crate) fn assemble<H: Host>(
    host: &mut H,
    config: &Config,
    options: &Options,
    open: &dyn Fn() -> Result<MultiBoard<DpramBoard>, StartError>,
    clock: wrc_trace::ClockKind,
    world_toml: Option<String>,
) -> Result<Assembled<H::Wake>, StartError> {
    let robot = config.robot.clone();
    let axis_count = robot.axis_count();
    let pg_board = open()?;
    let ec_board = open()?;
    let io_board = open()?;
    let ci_board = open()?;
    let sm_board = open()?;

    // Endpoints, before anything runs. The serial line first: once the TCP port accepts, a
    // client may take the controller as up, and the pendant's tty must be raw by then (a
    // line written to it earlier would be echoed back by the tty, not answered).
    let serial = match &options.serial {
        Some((path, baud, parity)) => Some(open_serial(path, *baud, *parity)?),
        None => None,
    };
    let token = match (&options.tcp, &config.host.token_file) {
        (Some(_), Some(path)) => Some(crate::host_access::read_token(path)?),
        _ => None,
    };
    let host_access = crate::host_access::HostAccess::new(&config.host, token);
    let tcp = match options.tcp {
        Some(addr) => {
            crate::host_access::check_exposure(addr, &config.host)?;
            let l = TcpListener::bind(addr).map_err(|reason| StartError::Bind {
                what: "TCP port",
                at: addr.to_string(),
                reason,
            })?;
            l.set_nonblocking(true).map_err(|reason| StartError::Bind {
                what: "TCP port",
                at: addr.to_string(),
                reason,
            })?;
            Some(l)
        }
        None => None,
    };
    let tcp_addr = tcp.as_ref().and_then(|l| l.local_addr().ok());
    let unix = match &options.socket {
        Some(path) => Some(bind_unix(path)?),
        None => None,
    };
    let udp = UdpSocket::bind("0.0.0.0:0")
        .and_then(|s| s.set_nonblocking(true).map(|()| s))
        .map_err(|reason| StartError::Bind {
            what: "UDP sender",
            at: options.sim_addr.to_string(),
            reason,
        })?;

    // Shared state, starting from the board's position.
    let shared = Arc::new(Shared::default());
    let mut feedback = wrc_board::Feedback::default();
    let board_period_us = pg_board.period_us();
    let _ = pg_board.read_feedback(&mut feedback);
    let mut start = [0i64; wrc_robot::MAX_AXES];
    for (i, s) in start.iter_mut().enumerate().take(axis_count) {
        *s = feedback.axes[i].commanded;
        shared.commanded[i].store(*s, Ordering::Release);
    }
    for b in 0..pg_board.board_count().min(4) {
        shared.outputs[b].store(pg_board.outputs(b), Ordering::Release);
    }
    let mut generator = Generator::new(robot.clone(), config.motion)?;
    let _ = generator.set_position_pulses(&start);
    shared
        .speed_pct
        .store(config.motion.speed_pct.round() as u32, Ordering::Release);

    // Queues (the paper's Table 5 kinds) between the tasks.
    let (ring_tx, ring_rx) = spsc::channel(ring_capacity(config));
    let (resume_tx, resume_rx) = mailbox(generator.state());
    // The Command Interpreter, the Velocity Generator and the service thread are released
    // by their messages as well as by their periods (the queues notify their consumer); the
    // Pulse Generator by every stop request.
    let ci_wake = host.wake("command_interpreter", None)?;
    let vg_wake = host.wake("velocity_generator", None)?;
    let pg_wake = host.wake("pulse_generator", None)?;
    let service_wake = host.wake("service", None)?;
    let io_wake = host.wake("io_monitor", None)?;
    shared.notify_stops(pg_wake.notifier());
    shared.notify_outputs(io_wake.notifier());
    let orders = Arc::new(MessageQueue::with_notify(
        crate::command_interpreter::MAX_TICKETS,
        vg_wake.notifier(),
    ));
    let done = Arc::new(MessageQueue::with_notify(
        4 * crate::command_interpreter::MAX_TICKETS,
        ci_wake.notifier(),
    ));
    let incoming = Arc::new(MessageQueue::with_notify(1024, ci_wake.notifier()));
    let urgent = Arc::new(MessageQueue::new(64));
    let wake = Arc::new(Semaphore::new(0));
    // The Ethernet and RS232C tasks are released by their sockets or tty and by every line
    // pushed into their reply queues, as well as by their periods.
    let ethernet_wake = host.wake(
        "ethernet",
        Some(Ethernet::tokens(config.host.max_connections, MAX_GUIS)),
    )?;
    let rs232c_wake = host.wake("rs232c", Some(Rs232c::TOKENS))?;
    let network_out = Arc::new(MessageQueue::with_notify(4096, ethernet_wake.notifier()));
    let serial_out = Arc::new(MessageQueue::with_notify(256, rs232c_wake.notifier()));
    let owner_lost = Arc::new(AtomicBool::new(false));
    let watched = Arc::new(OnceLock::new());
    let task_cells: crate::queries::TaskCells = Arc::new(OnceLock::new());
    let links = StoreLinks::notifying(service_wake.notifier(), ci_wake.notifier());
    let outputs = Outputs {
        network: network_out.clone(),
        serial: serial_out.clone(),
    };
    let store = Service::new(
        &options.programs,
        robot.clone(),
        links.clone(),
        outputs.clone(),
    )
    .map_err(|reason| StartError::Programs {
        path: options.programs.display().to_string(),
        reason,
    })?
    .with_queries(config.motion.period_s * 1000.0, task_cells.clone())
    .with_signals(config)
    .with_shared(shared.clone());
    // The cell, for the Command Interpreter's check of every motion: published by the cell
    // service whenever the stations or the wafers on the blades change.
    let (cell_view_tx, cell_view_rx) = mailbox(crate::messages::cell_job::CellView::empty(&robot));
    let checks_cell = options.cell.is_some();
    let store = match &options.cell {
        Some(files) => store.with_cell(
            crate::cell_service::CellService::open(
                &robot,
                &files.stations,
                &files.wafers,
                shared.clone(),
                config.hand,
            )?
            .with_view(cell_view_tx)
            .with_blend(config.blend)
            .with_io_period(
                config
                    .tasks
                    .get("io_monitor")
                    .map_or(0.1, |t| t.period_us as f64 * 1e-6),
            ),
        ),
        None => store,
    };
    // The trace recorder: samples from the Pulse Generator, lines from the Ethernet task's
    // two client sets and the pendant's.
    let (store, taps) = match &options.traces {
        Some(dir) => {
            std::fs::create_dir_all(dir).map_err(|reason| StartError::Traces {
                path: dir.display().to_string(),
                reason,
            })?;
            let mut meta = crate::recorder::session_meta(
                config,
                &options.programs,
                options.cell.as_ref().map(|c| c.stations.as_path()),
                options.cell.as_ref().map(|c| c.wafers.as_path()),
            );
            meta.start_pulses = start[..axis_count].to_vec();
            meta.clock = clock;
            meta.world_toml = world_toml;
            let (recorder, samples, messages) =
                crate::recorder::recorder(config, meta, dir.clone(), 3);
            (store.with_recorder(recorder), Some((samples, messages)))
        }
        None => (store, None),
    };
    let (sample_tap, mut message_taps) = match taps {
        Some((s, m)) => (Some(s), m),
        None => (None, Vec::new()),
    };
    let routes = Routes {
        incoming: incoming.clone(),
        urgent: urgent.clone(),
        wake: wake.clone(),
        store: links.requests.clone(),
    };

    let tasks = &config.tasks;
    let spec = |name: &str| {
        tasks.get(name).cloned().unwrap_or_else(|| {
            wrc_rt::TaskTable::paper_table1()
                .get(name)
                .cloned()
                .expect("Table 1 task")
        })
    };
    host.add(
        spec("error_check"),
        ErrorCheck::new(
            ec_board,
            axis_count,
            shared.clone(),
            urgent.clone(),
            wake.clone(),
            Limits::for_robot(&robot),
            owner_lost.clone(),
            watched.clone(),
        ),
    )?;
    // The board brakes on its own, with every axis's full limits (scaled for a STOP by the
    // stop word's level), when a stop is not answered by the Pulse Generator's brake in
    // time; every stop request reaches it directly (docs/dpram.md, "Stops").
    let mut pg_board = pg_board;
    for (i, a) in robot.axes().iter().enumerate() {
        let ppu = a.pulses_per_unit.abs();
        pg_board.set_brake_limits(i, a.limits.max_acceleration * ppu, a.limits.max_jerk * ppu);
    }
    let stop_line = pg_board.stop_line();
    let board_stops = stop_line.is_some();
    if let Some(line) = stop_line {
        shared.set_stop_line(line);
    }
    let mut pulse_generator = PulseGenerator::new(
        pg_board,
        ring_rx,
        shared.clone(),
        done.clone(),
        resume_tx,
        generator.clone(),
    )
    .with_lookahead(config.lookahead_periods);
    if board_stops {
        pulse_generator = pulse_generator.with_board_stops();
    }
    if let Some(tap) = sample_tap {
        pulse_generator = pulse_generator.with_trace(tap);
    }
    // Every board's heartbeat, each period: the longest of the boards' allowances.
    let heartbeat_periods = config
        .boards
        .iter()
        .map(|b| b.heartbeat_periods)
        .max()
        .unwrap_or(3);
    let liveness = crate::pulse_generator::Liveness::new(
        heartbeat_periods,
        board_period_us,
        (config.motion.period_s * 1e6).round() as u32,
        urgent.clone(),
        wake.clone(),
    );
    pulse_generator = pulse_generator.with_liveness(liveness);
    host.add_released(spec("pulse_generator"), pulse_generator, pg_wake)?;
    host.add(
        spec("simulator_manager"),
        SimulatorManager::new(
            sm_board,
            robot.clone(),
            shared.clone(),
            udp,
            options.sim_addr,
        ),
    )?;
    host.add_released(
        spec("velocity_generator"),
        VelocityGenerator::new(
            generator.clone(),
            orders.clone(),
            ring_tx,
            shared.clone(),
            done.clone(),
            resume_rx,
        ),
        vg_wake,
    )?;
    let forwarded = Arc::new(MessageQueue::with_notify(
        urgent.capacity(),
        ci_wake.notifier(),
    ));
    let mut interpreter = CommandInterpreter::new(
        robot.clone(),
        ci_board,
        shared.clone(),
        CommandLinks {
            incoming,
            urgent: urgent.clone(),
            forwarded: forwarded.clone(),
            orders,
            done,
            out: outputs,
            owner_lost,
            store: links,
        },
    );
    if checks_cell {
        let offsets: Vec<f64> = std::iter::once(0.0)
            .chain(config.hand.blade_b.map(|b| b.z_offset_mm))
            .collect();
        interpreter = interpreter.with_cell_check(generator.clone(), cell_view_rx, &offsets);
    }
    interpreter.estop_input = config.estop_input();
    interpreter.hand = config.hand;
    interpreter.name_outputs(&config.signals(&[]), config.io.guarded_outputs);
    let ci_applied = ci_wake.notifier();
    host.add_released(spec("command_interpreter"), interpreter, ci_wake)?;
    // Released by every output request, so a vacuum valve opens at once; it releases the
    // Command Interpreter, which waits for the valve in a transfer.
    host.add_released(
        spec("io_monitor"),
        IoMonitor::new(
            io_board,
            shared.clone(),
            vec![network_out.clone(), serial_out.clone()],
        )
        .with_applied(ci_applied)
        .primed(),
        io_wake,
    )?;
    let hosts = ClientSet::new(
        SourceId::TCP,
        config.host.max_connections,
        false,
        robot.clone(),
        shared.clone(),
        routes.clone(),
    )
    .with_access(host_access);
    let guis = ClientSet::new(
        SourceId::GUI,
        MAX_GUIS,
        false,
        robot.clone(),
        shared.clone(),
        routes.clone(),
    );
    let mut ethernet = Ethernet::new(tcp, unix, hosts, guis, network_out);
    let pendant_tap = message_taps.pop();
    if let (Some(guis), Some(hosts)) = (message_taps.pop(), message_taps.pop()) {
        ethernet.set_trace(hosts, guis);
    }
    if let Some(registry) = ethernet_wake.registry() {
        ethernet = ethernet
            .released_by(registry)
            .map_err(|reason| StartError::Waiter {
                task: "ethernet",
                reason,
            })?;
    }
    let ethernet_notify = ethernet_wake.notifier();
    host.add_released(spec("ethernet"), ethernet, ethernet_wake)?;
    let pendant = ClientSet::new(
        SourceId::PENDANT,
        1,
        true,
        robot.clone(),
        shared.clone(),
        routes,
    );
    let mut rs232c = Rs232c::new(serial, pendant, serial_out);
    if let Some(tap) = pendant_tap {
        rs232c.set_trace(tap);
    }
    if let Some(registry) = rs232c_wake.registry() {
        rs232c = rs232c
            .released_by(registry)
            .map_err(|reason| StartError::Waiter {
                task: "rs232c",
                reason,
            })?;
    }
    host.add_released(spec("rs232c"), rs232c, rs232c_wake)?;

    let quit = Arc::new(AtomicBool::new(false));
    let urgent = UrgentPath {
        wake,
        urgent,
        forwarded,
        shared: shared.clone(),
        quit: quit.clone(),
    };
    Ok(Assembled {
        shared,
        tcp: tcp_addr,
        watched,
        task_cells,
        urgent,
        service: store,
        service_wake,
        ethernet: ethernet_notify,
        ci_priority: spec("command_interpreter").priority,
        quit,
    })
}

/// The `TASKS` query's cells for `tasks` (the Pulse Generator's line also says how its stops
/// braked).
pub(crate) fn query_cells(
    tasks: Vec<(wrc_rt::TaskSpec, Arc<wrc_rt::StatsCell>)>,
    shared: &Arc<Shared>,
) -> Vec<(wrc_rt::TaskSpec, TaskCell)> {
    tasks
        .into_iter()
        .map(|(spec, timing)| {
            let stops = (spec.name == "pulse_generator").then(|| shared.clone());
            (spec, TaskCell::new(timing, stops))
        })
        .collect()
}

/// Start the controller for `config` with `options`.
pub fn start(config: &Config, options: &Options) -> Result<Running, StartError> {
    if options.tcp.is_some() {
        // Every connection, the boards, files and the waiters' own descriptors.
        crate::host_access::reserve_descriptors(config.host.max_connections + MAX_GUIS + 128)?;
    }
    let mut host = RealHost(Runtime::new(RuntimeOptions {
        realtime: options.realtime,
        ..Default::default()
    }));
    let open = || open_boards(config, &options.boards, options.board_wait);
    let parts = assemble(
        &mut host,
        config,
        options,
        &open,
        wrc_trace::ClockKind::Monotonic,
        None,
    )?;
    let running = host.0.start()?;
    if running.scheduling().is_realtime() {
        // Error Check stops a motion on overruns of the motion path only, and only when the
        // tasks really run real-time: an ordinary process on a busy machine overruns, which
        // the runtime already reports (once, and per overrun in the log and TASKS).
        let watched = running
            .task_cells()
            .into_iter()
            .filter_map(|(spec, cell)| {
                Some(Watched {
                    cell,
                    period_ns: spec.period_us * 1_000,
                    tolerance_ns: stall_tolerance_ns(config, &spec.name)?,
                })
            })
            .collect();
        let _ = parts.watched.set(watched);
    } else {
        tracing::warn!(
            "wrc: not real-time, so task overruns are counted (TASKS, the log) but do not stop the robot"
        );
    }
    let _ = parts
        .task_cells
        .set(query_cells(running.task_cells(), &parts.shared));
    let ci_priority = parts.ci_priority;
    let realtime = options.realtime;
    let path = parts.urgent;
    let urgent_thread = std::thread::Builder::new()
        .name("wrc-urgent".into())
        .spawn(move || {
            if realtime != RealtimeMode::Off {
                // Same priority as the Command Interpreter: it is that task's urgent half.
                let _ = wrc_rt::sched_policy::set_current_thread_fifo(wrc_rt::fifo_priority(
                    ci_priority,
                ));
            }
            path.run()
        })
        .ok();
    let store_quit = parts.quit.clone();
    let store = parts.service;
    let service_wake = parts.service_wake;
    let store_thread = std::thread::Builder::new()
        .name("wrc-service".into())
        .spawn(move || {
            if realtime != RealtimeMode::Off {
                // The lowest SCHED_FIFO priority, below every task of Table 1: its answers
                // (GET/PUT refusals, STN, WAFERS) do not queue behind ordinary processes,
                // such as hundreds of clients polling on the same CPUs. Its long work
                // (compiling) still yields to every real-time task.
                let _ = wrc_rt::sched_policy::set_current_thread_fifo(1);
            }
            store.run(store_quit, service_wake)
        })
        .ok();
    Ok(Running {
        runtime: Some(running),
        urgent: urgent_thread,
        store: store_thread,
        quit: parts.quit,
        shared: parts.shared,
        tcp: parts.tcp,
        socket: options.socket.clone(),
        sim_addr: options.sim_addr,
    })
}

fn bind_unix(path: &Path) -> Result<UnixListener, StartError> {
    let err = |reason| StartError::Bind {
        what: "Unix socket",
        at: path.display().to_string(),
        reason,
    };
    // A socket file left by a controller that was killed: remove it if nobody answers.
    if path.exists() && std::os::unix::net::UnixStream::connect(path).is_err() {
        let _ = std::fs::remove_file(path);
    }
    let l = UnixListener::bind(path).map_err(err)?;
    l.set_nonblocking(true).map_err(err)?;
    Ok(l)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stalls the motion rides out follow the buffers, at 10 ms and at 1 kHz: the
    /// look-ahead (100 ms either way) after the Pulse Generator; the ring (30 batches at
    /// 10 ms, 300 at 1 ms) and the look-ahead, less its 50 ms period, after the Velocity
    /// Generator; one 100 ms period for Error Check; no other task's stalls are a fault.
    #[test]
    fn stall_tolerances_are_what_the_buffers_cover() {
        let ms =
            |name: &str, config: &Config| stall_tolerance_ns(config, name).map(|ns| ns / 1_000_000);
        let ten = Config::embedded_default();
        assert_eq!(ten.lookahead_periods, 10);
        assert_eq!(ring_capacity(&ten), 2 * 5 + 2 * 10);
        assert_eq!(ms("pulse_generator", &ten), Some(100));
        assert_eq!(ms("velocity_generator", &ten), Some(300 + 100 - 50));
        assert_eq!(ms("error_check", &ten), Some(100));
        assert_eq!(ms("ethernet", &ten), None);
        let text = wrc_config::DEFAULT_TOML.replacen("period_ms = 10.0 ", "period_ms = 1.0 ", 1);
        let khz = Config::parse(&text, "khz").unwrap();
        assert_eq!(khz.lookahead_periods, 100);
        assert_eq!(ring_capacity(&khz), 2 * 50 + 2 * 100);
        assert_eq!(ms("pulse_generator", &khz), Some(100));
        assert_eq!(ms("velocity_generator", &khz), Some(300 + 100 - 50));
    }
}
