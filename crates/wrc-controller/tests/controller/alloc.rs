//! Counting allocator: a Command Interpreter cycle allocates and frees nothing, also while
//! it runs a robot-language program (motions, PRINT, OUT, WAIT IN, DELAY, SUB calls) and
//! while it checks motions against the cell (through, round, refused, stopped short, out of
//! a station).

use std::sync::atomic::Ordering;
use std::sync::Arc;

use wrc_alloc_count::{heap_calls, CountingAllocator};

use wrc_board::{DpramBoard, Expect, Mapping, MotionBoard};
use wrc_board_sim::{SimBoard, SimSettings};
use wrc_cell::TransferKind;
use wrc_config::Config;
use wrc_controller::cell_service::transfer_steps;
use wrc_controller::command_interpreter::{CommandInterpreter, CommandLinks};
use wrc_controller::messages::cell_job::{
    CellEvent, CellJob, CellView, JobKind, JobOffer, JournalAck,
};
use wrc_controller::messages::{
    Incoming, MoveDone, MoveOrder, MoveOutcome, OutLine, ProgramStart, SourceId, StoreLinks,
};
use wrc_controller::shared::Shared;
use wrc_controller::velocity_generator::plan_order;
use wrc_protocol::{Parser, ProgramName, ReplyTo};
use wrc_robot::Robot;
use wrc_rt::ipc::{mailbox, MessageQueue};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

const PROGRAM: &str = "\
HOME
FOR I = 1 TO 3
  MOVEP POSE(300, 20 * I, 0, 0)
  CALL REPORT
  OUT 0, 1
  WAIT IN(0) = 0 TIMEOUT 1
  DELAY 0.1
NEXT I
MOVEL HERE() + POSE(0, 0, 10, 0)
END
SUB REPORT
  PRINT \"at\", HERE().Y, I
ENDSUB
";

/// A Command Interpreter on a simulated board, with the queues through which a test plays
/// the other tasks' parts. No Pulse Generator: the commanded position stays at home, where
/// every motion is checked from, and every motion order completes at once.
struct Rig {
    robot: Robot,
    ci: CommandInterpreter<DpramBoard>,
    /// The board's own period, stepped by the test when `board_periods` is set.
    sim: SimBoard,
    /// The I/O Monitor's view of the board: it applies the commanded outputs.
    io: DpramBoard,
    board_periods: bool,
    shared: Arc<Shared>,
    orders: Arc<MessageQueue<MoveOrder>>,
    done: Arc<MessageQueue<MoveDone>>,
    network: Arc<MessageQueue<OutLine>>,
    /// Requests as the Ethernet task hands them over.
    incoming: Arc<MessageQueue<Incoming>>,
    links: StoreLinks,
    /// Every line sent to the network, in order.
    lines: Vec<String>,
    /// Motion orders the Command Interpreter sent.
    motions: usize,
    /// Heap calls (allocations and frees) inside the Command Interpreter's cycles.
    heap_calls: u64,
    /// The wafer-job events the Command Interpreter sent, but for the journal's steps
    /// (which the rig answers as the cell service does).
    cell_events: Vec<CellEvent>,
    /// Steps the journal was told about.
    journaled: usize,
    /// Plays each order to its end and takes that as the commanded position (as the Velocity
    /// and Pulse Generators would), when set; otherwise the position stays.
    player: Option<wrc_motion::VelocityGenerator>,
}

impl Rig {
    fn new(homed: bool, board_periods: bool) -> Rig {
        let config = Config::embedded_default();
        let robot = config.robot.clone();
        let settings = SimSettings::from_config(&config, &config.boards[0]);
        let mapping = Mapping::anonymous().unwrap();
        let mut sim = SimBoard::new(mapping.share(), &settings, 1).unwrap();
        sim.step();
        let board = DpramBoard::attach(mapping.share(), Expect::default()).unwrap();
        let io = DpramBoard::attach(mapping, Expect::default()).unwrap();
        let shared = Arc::new(Shared::default());
        let home = robot.joints_to_pulses(&robot.home());
        for (c, p) in shared.commanded.iter().zip(home) {
            c.store(p, Ordering::Release);
        }
        shared.homed.store(homed, Ordering::Release);
        let orders = Arc::new(MessageQueue::new(32));
        let done = Arc::new(MessageQueue::new(64));
        let network = Arc::new(MessageQueue::new(4096));
        let links = StoreLinks::new();
        let incoming = Arc::new(MessageQueue::new(16));
        let ci = CommandInterpreter::new(
            robot.clone(),
            board,
            shared.clone(),
            CommandLinks {
                store: links.clone(),
                ..CommandLinks::new(
                    incoming.clone(),
                    orders.clone(),
                    done.clone(),
                    network.clone(),
                )
            },
        );
        Rig {
            robot,
            ci,
            sim,
            io,
            board_periods,
            shared,
            orders,
            done,
            network,
            incoming,
            links,
            lines: Vec::with_capacity(256),
            motions: 0,
            heap_calls: 0,
            cell_events: Vec::new(),
            journaled: 0,
            player: None,
        }
    }

    /// Command Interpreter periods 50 ms apart, each counted, then the other tasks' part,
    /// until a line starts with one of `ends` (or 400 periods). The first period, at
    /// `now_ns`, is a warm-up outside the count: first touches happen there.
    fn run_until(&mut self, mut now_ns: u64, start: impl FnOnce(&StoreLinks), ends: &[&str]) {
        self.ci.step(now_ns);
        start(&self.links);
        for _ in 0..400 {
            let before = heap_calls().total();
            self.ci.step(now_ns);
            self.heap_calls += heap_calls().total() - before;
            // The Velocity and Pulse Generators' part: every order completes at once.
            while let Ok(order) = self.orders.try_recv() {
                self.motions += 1;
                if let Some(g) = self.player.as_mut() {
                    let at = self.shared.commanded_pulses();
                    g.abandon_at(&at);
                    if plan_order(g, &order).unwrap_or(false) {
                        let mut period = wrc_motion::Period::default();
                        while g.is_moving() {
                            g.next_period(&mut period);
                        }
                    }
                    for (c, p) in self.shared.commanded.iter().zip(g.position_pulses()) {
                        c.store(*p, Ordering::Release);
                    }
                }
                let _ = self.done.try_send(MoveDone {
                    ticket: order.ticket,
                    outcome: MoveOutcome::Completed,
                });
            }
            // The cell service's part: the journal's steps answered, the rest kept.
            while let Ok(event) = self.links.cell_events.try_recv() {
                match event {
                    CellEvent::Step { index, done, .. } => {
                        self.journaled += 1;
                        if !done {
                            let ack = JournalAck {
                                step: index,
                                ok: true,
                            };
                            let _ = self.links.journaled.try_send(ack);
                        }
                    }
                    other => self.cell_events.push(other),
                }
            }
            if self.board_periods {
                // The I/O Monitor's part: apply the outputs; then the board's period.
                let outputs = self.shared.outputs[0].load(Ordering::Acquire);
                self.io.write_outputs(0, outputs);
                self.sim.step();
            }
            while let Ok(line) = self.network.try_recv() {
                self.lines
                    .push(String::from_utf8_lossy(line.bytes()).trim_end().to_string());
            }
            if self
                .lines
                .iter()
                .any(|l| ends.iter().any(|e| l.starts_with(e)))
            {
                return;
            }
            now_ns += 50_000_000;
        }
    }
}

#[test]
fn a_command_interpreter_cycle_running_a_program_allocates_and_frees_nothing() {
    wrc_alloc_count::assert_installed();
    let mut rig = Rig::new(false, false);
    let compiled = wrc_lang::compile(PROGRAM, "alloc.wrl", &rig.robot);
    let program = compiled.program.expect("the test program compiles");
    let start = ProgramStart {
        from: SourceId::new(SourceId::TCP, 0, 1),
        to: ReplyTo {
            id: Some(9),
            checksum: false,
        },
        name: ProgramName::new("alloc").unwrap(),
        program: Box::new(program),
        step: false,
    };
    rig.run_until(
        1_000_000_000,
        |links| {
            links
                .starts
                .try_send(start)
                .ok()
                .expect("room for the start")
        },
        &["INF 9", "ABS 9"],
    );
    let lines = &rig.lines;
    assert!(lines.iter().any(|l| l == "INF 9"), "{lines:?}");
    assert_eq!(rig.motions, 5, "HOME, three MOVEP and one MOVEL: {lines:?}");
    assert_eq!(
        lines
            .iter()
            .filter(|l| l.starts_with("EVT PRINT at"))
            .count(),
        3,
        "{lines:?}"
    );
    assert_eq!(
        rig.heap_calls, 0,
        "allocations or frees in Command Interpreter cycles"
    );
    // The program went back to the store to be freed there.
    assert!(rig.links.retired.try_recv().is_ok());
}

/// A wafer job (GET) through the Command Interpreter: its motions, the speed near the
/// station, the vacuum valve (applied by a stand-in for the I/O Monitor), the vacuum check
/// (this board has no cell: its sensor follows the valve), the commit and the end — no
/// allocation.
#[test]
fn a_command_interpreter_cycle_running_a_wafer_job_allocates_and_frees_nothing() {
    wrc_alloc_count::assert_installed();
    // Rest to rest (PTP, line in, Z up, line out), then with the approach blended into the
    // line in (approach, Z up, line out).
    for (blend, motions) in [(false, 4), (true, 3)] {
        let mut rig = Rig::new(true, true);
        let stations = wrc_cell::Stations::embedded_demo();
        let lp1 = stations.get("LP1").unwrap();
        let from = SourceId::new(SourceId::TCP, 0, 1);
        let to = ReplyTo {
            id: Some(7),
            checksum: false,
        };
        let mut job = CellJob::new(from, to, JobKind::Get, lp1.name);
        job.slot = 1;
        job.wafer = 1;
        let robot = Robot::paper_default();
        for step in transfer_steps(TransferKind::Get, lp1, 1, &robot, &robot.home(), blend)
            .unwrap()
            .0
        {
            assert!(job.push(step));
        }
        rig.run_until(
            1_000_000_000,
            |links| links.jobs.try_send(JobOffer::Start(job)).ok().unwrap(),
            &["ABS 7", "INF 7"],
        );
        let lines = &rig.lines;
        // The job's own motions are not answered on the wire: only its ACK and INF are.
        let replies: Vec<&String> = lines.iter().filter(|l| !l.starts_with("EVT")).collect();
        assert_eq!(replies, ["ACK 7", "INF 7 W1"], "{lines:?}");
        assert_eq!(rig.motions, motions, "blend {blend}: {lines:?}");
        assert_eq!(
            rig.cell_events,
            [
                CellEvent::Commit,
                CellEvent::Ended {
                    kind: JobKind::Get,
                    started: true,
                    code: None,
                    sensed: [true, false],
                }
            ]
        );
        // Every step began and ended in the journal.
        assert_eq!(rig.journaled, 2 * job.len, "blend {blend}");
        assert_eq!(
            rig.shared.speed_pct.load(Ordering::Acquire),
            100,
            "the speed near the station was restored"
        );
        assert_eq!(
            rig.heap_calls, 0,
            "allocations or frees in Command Interpreter cycles running a job (blend {blend})"
        );
    }
}

/// The guard on a blade's vacuum valve (a refusal with its text, a forced switch told to the
/// cell service) and the watch of the blades outside a job (the wafer lost at rest: 213 with
/// its text) allocate nothing.
#[test]
fn a_command_interpreter_cycle_guarding_and_watching_a_held_wafer_allocates_nothing() {
    wrc_alloc_count::assert_installed();
    let mut rig = Rig::new(true, true);
    let config = Config::embedded_default();
    rig.ci.hand = config.hand;
    rig.ci.name_outputs(&config.signals(&[]), 1 << 7);
    // The map has W4 on blade A, certain; its valve on (this board's sensor follows it).
    rig.shared.set_output(0, true);
    rig.shared.blade_wafers[0].store(4, Ordering::Release);
    rig.shared.hand_wafers.store(1, Ordering::Release);
    rig.shared.io_ready.store(true, Ordering::Release);
    // The valve on for long enough that its sensor is watched.
    rig.run_until(1_000_000_000, |_| {}, &["never"]);
    assert!(rig.lines.is_empty(), "{:?}", rig.lines);
    let host = SourceId::new(SourceId::TCP, 0, 1);
    let parser = Parser::new(4);
    let requests = [
        parser.parse(b"1 OUT 0 0").unwrap(),
        parser.parse(b"2 OUT 0 0 FORCE").unwrap(),
    ];
    let incoming = rig.incoming.clone();
    rig.run_until(
        30_000_000_000,
        |_| {
            for r in requests {
                incoming.try_send(Incoming::Request(host, r)).ok().unwrap();
            }
        },
        &["EVT ERROR 213"],
    );
    let lines = &rig.lines;
    assert!(
        lines[0].starts_with("NAK 1 141 output 0 (vacuum valve) "),
        "{lines:?}"
    );
    assert_eq!(lines[1], "ACK 2", "{lines:?}");
    let alarm = lines
        .iter()
        .find(|l| l.starts_with("EVT ERROR 213 "))
        .unwrap();
    assert!(alarm.contains("blade A lost W4"), "{alarm}");
    assert!(rig.cell_events.iter().any(|e| matches!(
        e,
        CellEvent::Forced {
            n: 0,
            on: false,
            wafer: 4,
            ..
        }
    )));
    assert!(rig
        .cell_events
        .contains(&CellEvent::WaferLost { blades: 1 }));
    assert_eq!(
        rig.heap_calls, 0,
        "allocations or frees in Command Interpreter cycles guarding and watching"
    );
}

#[test]
fn a_pulse_generator_cycle_recording_its_trace_sample_allocates_nothing() {
    use wrc_rt::{CycleContext, Release, Task};
    let config = Config::embedded_default();
    let (mut sim, mapping) = crate::motion::sim_board(&config, &config.boards[0]);
    let board = DpramBoard::attach(mapping.share(), Expect::default()).unwrap();
    let motion = crate::motion::Motion::at_rest(&config, board);
    let dir = tempfile::tempdir().unwrap();
    let (mut recorder, tap, _) = wrc_controller::recorder::recorder(
        &config,
        wrc_controller::recorder::session_meta(&config, dir.path(), None, None),
        dir.path().to_path_buf(),
        0,
    );
    let mut pg = motion.pg.with_trace(tap);
    let ctx = |k: u64| CycleContext {
        cycle: k,
        scheduled_ns: 10_000_000 * k,
        woke_ns: 10_000_000 * k + 1_000,
        period_ns: 10_000_000,
        release: Release::Period,
        previous_exec_ns: 20_000,
    };
    pg.cycle(&ctx(1));
    sim.step();
    let mut calls = 0;
    for k in 2..200 {
        calls += wrc_alloc_count::allocations_in(|| pg.cycle(&ctx(k)))
            .0
            .total();
        sim.step();
    }
    assert_eq!(calls, 0, "the cycles allocated or freed");
    // And what was recorded reaches the ring: 199 periods, 1 µs late each, each with the
    // previous cycle's execution time the runtime measured.
    let trace = recorder.snapshot("test");
    assert_eq!(trace.samples.len(), 199);
    assert!(trace
        .samples
        .iter()
        .all(|s| s.latency_ns == 1_000 && s.exec_ns == 20_000));
}

/// The soak at 1 kHz found the controller's memory 20-25 MB higher after the first alarm
/// than before: the trace saved on it copied and encoded the ring into new buffers. A
/// recorder now makes them as large as its full ring at start-up, and saves into them: a
/// save of a full ring, twice, leaves them as large as they were.
#[test]
fn a_trace_save_of_a_full_ring_grows_no_buffer() {
    let config = Config::embedded_default();
    let dir = tempfile::tempdir().unwrap();
    let (mut recorder, mut tap, mut messages) = wrc_controller::recorder::recorder(
        &config,
        wrc_controller::recorder::session_meta(&config, dir.path(), None, None),
        dir.path().to_path_buf(),
        1,
    );
    let before = recorder.save_bytes();
    let samples = (config.trace.seconds / config.motion.period_s).ceil() as usize;
    assert!(
        before >= samples * std::mem::size_of::<wrc_trace::Sample>(),
        "{before} bytes for {samples} samples"
    );
    let long = [b'x'; 300];
    for round in 0..2u64 {
        // More periods than the ring keeps, with messages, in batches the queue holds.
        for k in 0..(samples as u64 + 500) {
            let t_ns = (round * 100_000 + k) * 10_000_000;
            tap.push(&wrc_trace::Sample {
                t_ns,
                ..Default::default()
            });
            messages[0].push(
                t_ns,
                wrc_trace::Direction::Request,
                wrc_controller::messages::SourceId::NONE,
                &long,
            );
            if k % 256 == 0 {
                let _ = recorder.drain();
            }
        }
        let _ = recorder.drain();
        let saved = recorder.save_named(None, "test").unwrap();
        assert!(saved.samples >= samples - 1, "{saved:?}");
        assert_eq!(
            recorder.save_bytes(),
            before,
            "round {round}: a buffer grew"
        );
    }
}

/// The check of every motion against the cell (the demo stations), in the Command
/// Interpreter's cycle: a PTP that passes under the stations, one that goes round through
/// the travel height, a target inside a station refused with its text, a jog stopped short,
/// and a hand moved into LP1 along its line taken out by HOME from the stations' lines —
/// no allocation.
#[test]
fn a_command_interpreter_cycle_checking_motions_against_the_cell_allocates_nothing() {
    wrc_alloc_count::assert_installed();
    let config = Config::embedded_default();
    let mut rig = Rig::new(true, false);
    let stations = wrc_cell::Stations::embedded_demo();
    let model = stations.model(&rig.robot).unwrap();
    let (mut writer, reader) = mailbox(CellView::empty(&rig.robot));
    writer.write(CellView::of(model, [false; 2], stations.iter()));
    let generator = wrc_motion::VelocityGenerator::new(rig.robot.clone(), config.motion).unwrap();
    rig.ci = rig.ci.with_cell_check(generator.clone(), reader, &[0.0]);
    rig.player = Some(generator);
    let parser = Parser::new(rig.robot.axis_count());
    let from = SourceId::new(SourceId::TCP, 0, 1);
    let mut now_ns = 1_000_000_000;
    let mut said = Vec::new();
    let steps: [(u32, &str, &str); 8] = [
        (1, "HOME", "INF 1"),
        (2, "MOVP 250 -150 100 0", "NAK 2"),
        (3, "MOVP 250 -150 0 0", "INF 3"),
        (4, "MOVJ 60 60 -90 50", "INF 4"),
        (5, "JOG z 50000", "INF 5"),
        (6, "MOVP 103.923 -60 37 -30 R", "INF 6"),
        (7, "MOVL 294.449 -170 37 -30", "INF 7"),
        (8, "HOME", "INF 8"),
    ];
    let mut orders = Vec::new();
    for (id, line, end) in steps {
        let before = rig.motions;
        let request = parser.parse(format!("{id} {line}").as_bytes()).unwrap();
        rig.lines.clear();
        let incoming = rig.incoming.clone();
        rig.run_until(
            now_ns,
            |_| {
                assert!(
                    incoming.try_send(Incoming::Request(from, request)).is_ok(),
                    "room for the request"
                )
            },
            &[end],
        );
        now_ns += 30_000_000_000;
        orders.push(rig.motions - before);
        said.push(
            rig.lines
                .iter()
                .filter(|l| !l.starts_with("EVT"))
                .cloned()
                .collect::<Vec<_>>(),
        );
    }
    assert_eq!(said[0], ["ACK 1", "INF 1"], "{said:?}");
    assert!(
        said[1][0].starts_with("NAK 2 117 the target would put the hand into station LP1"),
        "{said:?}"
    );
    assert_eq!(said[2], ["ACK 3", "INF 3"], "{said:?}");
    assert_eq!(said[3], ["ACK 4 route=travel", "INF 4"], "{said:?}");
    assert!(said[4][0].starts_with("ACK 5 limited="), "{said:?}");
    assert_eq!(said[6], ["ACK 7", "INF 7"], "{said:?}");
    assert_eq!(said[7], ["ACK 8", "INF 8"], "{said:?}");
    // HOME went straight out of LP1 first (a line), then home.
    assert_eq!(orders[7], 2, "{orders:?}");
    assert!(
        rig.ci.check_figures().checks >= 8,
        "{:?}",
        rig.ci.check_figures()
    );
    assert_eq!(
        rig.heap_calls, 0,
        "allocations or frees in Command Interpreter cycles checking motions"
    );
}
