//! Counting allocator: a Command Interpreter cycle allocates and frees nothing, also while
//! it runs a robot-language program (motions, PRINT, OUT, WAIT IN, DELAY, SUB calls).

use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use wrc_alloc_count::{heap_calls, CountingAllocator};

use wrc_board::sim::{SimBoard, SimSettings};
use wrc_board::{DpramBoard, Expect, Mapping, MotionBoard};
use wrc_config::Config;
use wrc_controller::command_interpreter::{CommandInterpreter, Outputs};
use wrc_controller::program_store::{ProgramStart, StoreLinks};
use wrc_controller::shared::{MoveDone, MoveOutcome, Shared, SourceId};
use wrc_motion::VelocityGenerator as Generator;
use wrc_protocol::{ProgramName, ReplyTo};
use wrc_rt::ipc::{MessageQueue, Semaphore};

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

#[test]
fn a_command_interpreter_cycle_running_a_program_allocates_and_frees_nothing() {
    wrc_alloc_count::assert_installed();
    let config = Config::embedded_default();
    let robot = config.robot.clone();
    let settings = SimSettings::from_config(&config, &config.boards[0]);
    let mapping = Mapping::anonymous().unwrap();
    let mut sim = SimBoard::new(mapping.share(), &settings, 1).unwrap();
    sim.step();
    let board = DpramBoard::attach(mapping, Expect::default()).unwrap();
    let generator = Generator::new(robot.clone(), config.motion).unwrap();
    let shared = Arc::new(Shared::default());
    // No Pulse Generator here: the commanded position stays at home, where every motion
    // is checked from.
    let home = robot.joints_to_pulses(&robot.home());
    for (c, p) in shared.commanded.iter().zip(home) {
        c.store(p, std::sync::atomic::Ordering::Release);
    }
    let orders = Arc::new(MessageQueue::new(32));
    let done = Arc::new(MessageQueue::new(64));
    let network = Arc::new(MessageQueue::new(4096));
    let links = StoreLinks::new();
    let mut ci = CommandInterpreter::new(
        robot.clone(),
        board,
        generator,
        shared.clone(),
        Arc::new(MessageQueue::new(16)),
        Arc::new(MessageQueue::new(16)),
        Arc::new(Semaphore::new(0)),
        orders.clone(),
        done.clone(),
        Outputs {
            network: network.clone(),
            serial: Arc::new(MessageQueue::new(16)),
        },
        Arc::new(AtomicBool::new(false)),
        links.clone(),
    );
    let compiled = wrc_lang::compile(PROGRAM, "alloc.wrl", &robot);
    let program = compiled.program.expect("the test program compiles");
    let from = SourceId::new(SourceId::TCP, 0, 1);
    let to = ReplyTo {
        id: Some(9),
        checksum: false,
    };
    let mut now = 1_000_000_000u64;
    ci.step(now); // warm-up: first touches happen outside the measured cycles
    links
        .starts
        .try_send(ProgramStart {
            from,
            to,
            name: ProgramName::new("alloc").unwrap(),
            program: Box::new(program),
        })
        .ok()
        .expect("room for the start");

    let mut lines = Vec::with_capacity(256);
    let mut motions = 0;
    let mut allocations = 0;
    for _ in 0..400 {
        let before = heap_calls().total();
        ci.step(now);
        allocations += heap_calls().total() - before;
        // The Velocity and Pulse Generators' part: every order completes at once.
        while let Ok(order) = orders.try_recv() {
            motions += 1;
            let _ = done.try_send(MoveDone {
                ticket: order.ticket,
                outcome: MoveOutcome::Completed,
            });
        }
        while let Ok(line) = network.try_recv() {
            lines.push(String::from_utf8_lossy(line.bytes()).trim_end().to_string());
        }
        if lines
            .iter()
            .any(|l| l.starts_with("INF 9") || l.starts_with("ABS 9"))
        {
            break;
        }
        now += 50_000_000;
    }
    assert!(lines.iter().any(|l| l == "INF 9"), "{lines:?}");
    assert_eq!(motions, 5, "HOME, three MOVEP and one MOVEL: {lines:?}");
    assert_eq!(
        lines
            .iter()
            .filter(|l| l.starts_with("EVT PRINT at"))
            .count(),
        3,
        "{lines:?}"
    );
    assert_eq!(
        allocations, 0,
        "allocations or frees in Command Interpreter cycles"
    );
    // The program went back to the store to be freed there.
    assert!(links.retired.try_recv().is_ok());
}

/// A wafer job (GET) through the Command Interpreter: its motions, the speed near the
/// station, the vacuum valve (applied by a stand-in for the I/O Monitor), the vacuum check
/// (this board has no cell: its sensor follows the valve), the commit and the end — no
/// allocation.
#[test]
fn a_command_interpreter_cycle_running_a_wafer_job_allocates_and_frees_nothing() {
    wrc_alloc_count::assert_installed();
    use wrc_controller::cell_job::{CellEvent, CellJob, JobKind, JobOffer, JobStep};
    let config = Config::embedded_default();
    let robot = config.robot.clone();
    let settings = SimSettings::from_config(&config, &config.boards[0]);
    let mapping = Mapping::anonymous().unwrap();
    let mut sim = SimBoard::new(mapping.share(), &settings, 1).unwrap();
    sim.step();
    let board = DpramBoard::attach(mapping.share(), Expect::default()).unwrap();
    let mut io = DpramBoard::attach(mapping, Expect::default()).unwrap();
    let generator = Generator::new(robot.clone(), config.motion).unwrap();
    let shared = Arc::new(Shared::default());
    let home = robot.joints_to_pulses(&robot.home());
    for (c, p) in shared.commanded.iter().zip(home) {
        c.store(p, std::sync::atomic::Ordering::Release);
    }
    shared
        .homed
        .store(true, std::sync::atomic::Ordering::Release);
    let orders = Arc::new(MessageQueue::new(32));
    let done = Arc::new(MessageQueue::new(64));
    let network = Arc::new(MessageQueue::new(4096));
    let links = StoreLinks::new();
    let mut ci = CommandInterpreter::new(
        robot.clone(),
        board,
        generator,
        shared.clone(),
        Arc::new(MessageQueue::new(16)),
        Arc::new(MessageQueue::new(16)),
        Arc::new(Semaphore::new(0)),
        orders.clone(),
        done.clone(),
        Outputs {
            network: network.clone(),
            serial: Arc::new(MessageQueue::new(16)),
        },
        Arc::new(AtomicBool::new(false)),
        links.clone(),
    );
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
    for step in wrc_cell::plan_get(lp1, 1).unwrap() {
        assert!(job.push(JobStep::Transfer(step)));
    }
    let mut now = 1_000_000_000u64;
    ci.step(now); // warm-up
    links.jobs.try_send(JobOffer::Start(job)).ok().unwrap();

    let mut lines = Vec::with_capacity(256);
    let mut motions = 0;
    let mut allocations = 0;
    for _ in 0..400 {
        let before = heap_calls().total();
        ci.step(now);
        allocations += heap_calls().total() - before;
        while let Ok(order) = orders.try_recv() {
            motions += 1;
            let _ = done.try_send(MoveDone {
                ticket: order.ticket,
                outcome: MoveOutcome::Completed,
            });
        }
        // The I/O Monitor's part: apply the outputs; the board's period.
        io.write_outputs(
            0,
            shared.outputs[0].load(std::sync::atomic::Ordering::Acquire),
        );
        sim.step();
        while let Ok(line) = network.try_recv() {
            lines.push(String::from_utf8_lossy(line.bytes()).trim_end().to_string());
        }
        if lines
            .iter()
            .any(|l| l.starts_with("ABS 7") || l.starts_with("INF 7"))
        {
            break;
        }
        now += 50_000_000;
    }
    // The job's own motions are not answered on the wire: only its ACK and INF are.
    let replies: Vec<&String> = lines.iter().filter(|l| !l.starts_with("EVT")).collect();
    assert_eq!(replies, ["ACK 7", "INF 7 W1"], "{lines:?}");
    assert_eq!(motions, 4, "PTP, line in, Z up, line out: {lines:?}");
    assert_eq!(links.cell_events.try_recv().ok(), Some(CellEvent::Commit));
    assert_eq!(
        links.cell_events.try_recv().ok(),
        Some(CellEvent::Ended {
            kind: JobKind::Get,
            started: true,
            code: None,
            sensed: true,
        })
    );
    assert_eq!(
        shared.speed_pct.load(std::sync::atomic::Ordering::Acquire),
        100,
        "the speed near the station was restored"
    );
    assert_eq!(
        allocations, 0,
        "allocations or frees in Command Interpreter cycles running a job"
    );
}
