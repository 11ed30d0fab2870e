//! The board's E-stop input overtakes a busy Command Interpreter: the simulated board, the
//! Pulse Generator (watching the boards and their stops as in the controller), the Velocity
//! Generator, Error Check, the urgent path and the Command Interpreter, stepped by hand on
//! one thread (10 ms board periods; the Velocity Generator and the Command Interpreter every
//! 5th, Error Check every 10th) except the urgent path, which runs on its own thread as in
//! the controller and is waited on, never slept for.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};

use crate::motion::{sim_board, Motion};
use wrc_board::{DpramBoard, Expect, Fault, Feedback, MotionBoard};
use wrc_board_sim::{SimBoard, SimSettings};
use wrc_config::Config;
use wrc_controller::command_interpreter::{CommandInterpreter, CommandLinks, UrgentPath};
use wrc_controller::error_check::{ErrorCheck, Limits};
use wrc_controller::messages::{Incoming, MoveOrder, OutLine, SourceId, Urgent};
use wrc_controller::pulse_generator::{Liveness, PulseGenerator};
use wrc_controller::shared::{RobotState, Shared};
use wrc_controller::velocity_generator::VelocityGenerator;
use wrc_protocol::{Code, Parser};
use wrc_rt::ipc::{MessageQueue, Semaphore};
use wrc_rt::{Clock, MonotonicClock};

/// Requests the Command Interpreter's queue holds in this rig.
const QUEUE: usize = 16;

/// The host the requests come from.
const HOST: SourceId = SourceId(0x1000_0001);

struct Rig {
    sim: SimBoard,
    host: DpramBoard,
    pg: PulseGenerator<DpramBoard>,
    vg: VelocityGenerator,
    ec: ErrorCheck<DpramBoard>,
    ci: CommandInterpreter<DpramBoard>,
    shared: Arc<Shared>,
    incoming: Arc<MessageQueue<Incoming>>,
    urgent: Arc<MessageQueue<Urgent>>,
    urgent_wake: Arc<Semaphore>,
    forwarded: Arc<MessageQueue<Urgent>>,
    orders: Arc<MessageQueue<MoveOrder>>,
    network: Arc<MessageQueue<OutLine>>,
    parser: Parser,
    /// Board periods run.
    k: u64,
    /// J1's increment in each board period [pulse].
    increments: Vec<i64>,
    /// Every line sent to the hosts, in order.
    lines: Vec<String>,
}

impl Rig {
    /// The controller's tasks on one simulated board with an E-stop input, the robot homed
    /// and at rest at the board's position.
    fn new() -> Rig {
        let config = Config::embedded_default();
        let robot = config.robot.clone();
        let settings = SimSettings::from_config(&config, &config.boards[0]);
        assert!(settings.io.estop_input.is_some(), "the board has an E-stop");
        let (sim, mapping) = sim_board(&config, &config.boards[0]);
        let attach = || DpramBoard::attach(mapping.share(), Expect::default()).unwrap();
        let host = attach();
        let Motion {
            pg,
            vg,
            shared,
            orders,
            done,
        } = Motion::at_rest(&config, attach());
        let incoming = Arc::new(MessageQueue::new(QUEUE));
        let urgent = Arc::new(MessageQueue::new(8));
        let urgent_wake = Arc::new(Semaphore::new(0));
        shared.set_stop_line(host.stop_line().unwrap());
        let pg = pg.with_board_stops().with_liveness(Liveness::new(
            3,
            10_000,
            10_000,
            urgent.clone(),
            urgent_wake.clone(),
        ));
        let forwarded = Arc::new(MessageQueue::new(8));
        let network = Arc::new(MessageQueue::new(256));
        let owner_lost = Arc::new(AtomicBool::new(false));
        let ec = ErrorCheck::new(
            attach(),
            robot.axis_count(),
            shared.clone(),
            urgent.clone(),
            urgent_wake.clone(),
            Limits::for_robot(&robot),
            owner_lost.clone(),
            Arc::new(OnceLock::new()),
        );
        let mut ci = CommandInterpreter::new(
            robot.clone(),
            attach(),
            shared.clone(),
            CommandLinks {
                urgent: urgent.clone(),
                forwarded: forwarded.clone(),
                owner_lost,
                ..CommandLinks::new(incoming.clone(), orders.clone(), done, network.clone())
            },
        );
        ci.estop_input = settings.io.estop_input;
        Rig {
            sim,
            host,
            pg,
            vg,
            ec,
            ci,
            shared,
            incoming,
            urgent,
            urgent_wake,
            forwarded,
            orders,
            network,
            parser: Parser::new(robot.axis_count()),
            k: 0,
            increments: Vec::new(),
            lines: Vec::new(),
        }
    }

    /// A request line from the host, queued for the Command Interpreter; false when the
    /// queue is full.
    fn request(&self, line: &str) -> bool {
        let request = self.parser.parse(line.as_bytes()).unwrap();
        self.incoming
            .try_send(Incoming::Request(HOST, request))
            .is_ok()
    }

    /// The Command Interpreter's cycle at this period's time; its lines collected.
    fn interpreter_cycle(&mut self) {
        self.ci.step(1_000_000_000 + self.k * 10_000_000);
        while let Ok(line) = self.network.try_recv() {
            let text = String::from_utf8_lossy(line.bytes());
            self.lines.push(text.trim_end().to_string());
        }
    }

    /// One 10 ms period: every 5th the Command Interpreter and the Velocity Generator, every
    /// 10th Error Check; then the Pulse Generator and the board.
    fn period(&mut self) {
        if self.k % 5 == 0 {
            self.interpreter_cycle();
            self.vg.step();
        }
        if self.k % 10 == 0 {
            self.ec.step();
        }
        self.board_period();
    }

    /// The Pulse Generator's period, then the board's.
    fn board_period(&mut self) {
        self.pg.step();
        let before = self.j1_commanded();
        self.sim.step();
        self.increments.push(self.j1_commanded() - before);
        self.k += 1;
    }

    fn j1_commanded(&self) -> i64 {
        let mut fb = Feedback::default();
        self.host.read_feedback(&mut fb).unwrap();
        fb.axes[0].commanded
    }

    /// Run the urgent path's thread, as the controller does, until it has forwarded the
    /// emergency posted to the Command Interpreter (a far deadline bounds only a failure).
    fn urgent_path(&self) {
        let quit = Arc::new(AtomicBool::new(false));
        let path = UrgentPath {
            wake: self.urgent_wake.clone(),
            urgent: self.urgent.clone(),
            forwarded: self.forwarded.clone(),
            shared: self.shared.clone(),
            quit: quit.clone(),
        };
        let thread = std::thread::spawn(move || path.run());
        let deadline = MonotonicClock.now_ns() + 20_000_000_000;
        while self.forwarded.is_empty() {
            assert!(
                MonotonicClock.now_ns() < deadline,
                "the urgent path forwarded nothing"
            );
            std::thread::yield_now();
        }
        quit.store(true, Ordering::Release);
        thread.join().unwrap();
    }
}

#[test]
fn the_estop_input_brakes_along_the_path_within_the_boards_grace_past_a_full_request_queue() {
    let mut rig = Rig::new();
    let mut target = Config::embedded_default().robot.home();
    target[0] = 170.0; // a long cruise of J1, from -75 deg
    let axes = Config::embedded_default().robot.axis_count();
    let movj = |t: &[f64]| {
        let j: Vec<String> = t[..axes].iter().map(f64::to_string).collect();
        j.join(" ")
    };
    assert!(rig.request(&format!("1 MOVJ {}", movj(&target))));
    for _ in 0..60 {
        rig.period();
    }
    assert_eq!(rig.lines[..2], ["ACK 1", "EVT STATE MOVING"]);
    let cruise = *rig.increments.last().unwrap();
    assert!(cruise > 1000, "cruising at {cruise} pulse/period");

    // The Command Interpreter is busy: its queue is full of motions that, carried out, would
    // be accepted and queued behind the running one.
    let mut back = target;
    back[0] = -170.0;
    let mut queued = 0;
    while rig.request(&format!("{} MOVJ {}", 100 + queued, movj(&back))) {
        queued += 1;
    }
    assert_eq!(queued, QUEUE);

    // The E-stop button is pressed between two board periods. The board's next period
    // still plays its queued entry: the host has that period and the next to take the stop
    // with its own brake, along the path (docs/dpram.md, "Stops" 6).
    rig.sim.apply_fault(Fault::Estop { on: true });
    let pressed_at = rig.increments.len();
    let epoch = rig.shared.stop_epoch.load(Ordering::Acquire);
    rig.board_period();
    assert_eq!(rig.increments[pressed_at], cruise, "{:?}", rig.increments);

    // The Pulse Generator's next period sees the input: it asks for the stop (an ESTOP),
    // flushes the first periods of its brake before the board's next period, and reports
    // the fault on the urgent path, past the full request queue, with one post of its
    // semaphore.
    let decel_before = rig.shared.decel_ns.load(Ordering::Acquire);
    rig.pg.step();
    assert_eq!(
        rig.shared.stop_epoch.load(Ordering::Acquire),
        epoch + 1,
        "one stop"
    );
    assert!(rig.shared.decel_ns.load(Ordering::Acquire) > decel_before);
    assert_eq!(rig.urgent_wake.count(), 1);
    assert_eq!(rig.incoming.len(), QUEUE, "the request queue was bypassed");
    let before = rig.j1_commanded();
    rig.sim.step();
    rig.increments.push(rig.j1_commanded() - before);
    rig.k += 1;
    let inc = &rig.increments;
    assert!(
        inc[pressed_at + 1] < cruise,
        "no deceleration in the board's next period: {:?}",
        &inc[pressed_at - 2..]
    );

    // Error Check's next cycle finds it reported: no second report. The urgent path hands
    // the fault on without a second stop.
    rig.ec.step();
    assert_eq!(rig.urgent_wake.count(), 1);
    rig.urgent_path();
    assert_eq!(rig.shared.stop_epoch.load(Ordering::Acquire), epoch + 1);

    // The forwarded fault releases the Command Interpreter: it is handled before any queued
    // request, so every queued motion is refused in ESTOP and none reaches the Velocity
    // Generator.
    rig.lines.clear();
    rig.interpreter_cycle();
    assert_eq!(rig.shared.state(), RobotState::Estop);
    let lines = &rig.lines;
    let abs = lines.iter().position(|l| l.starts_with("ABS 1 202 "));
    let first_nak = lines.iter().position(|l| l.starts_with("NAK 100 "));
    assert!(
        matches!((abs, first_nak), (Some(a), Some(n)) if a < n),
        "{lines:?}"
    );
    let estop = format!(" {} ", Code::InEstop.number());
    for id in 100..100 + QUEUE {
        let nak = format!("NAK {id}{estop}");
        assert!(lines.iter().any(|l| l.starts_with(&nak)), "{lines:?}");
    }
    assert!(
        !lines.iter().any(|l| l.starts_with("ACK")),
        "a queued motion was accepted: {lines:?}"
    );
    assert!(rig.orders.is_empty(), "a queued motion was ordered");

    // The arm comes to rest and stays there: it never sped up after the press.
    for _ in 0..100 {
        rig.period();
    }
    let inc = &rig.increments;
    assert!(
        inc[pressed_at - 1..].windows(2).all(|w| w[1] <= w[0]),
        "{:?}",
        &inc[pressed_at - 1..]
    );
    assert!(inc[inc.len() - 50..].iter().all(|&i| i == 0), "{inc:?}");
    assert_eq!(rig.shared.state(), RobotState::Estop);
    // The host's brake stopped it: the board never braked on its own.
    assert_eq!(rig.shared.fifo.board_stops.load(Ordering::Acquire), 0);
    assert!(rig.host.board_stop().estop);
}
