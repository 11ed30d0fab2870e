//! A stopped or held motion ends when the arm stands still on the board: Command Interpreter
//! → Velocity Generator → pulse ring → Pulse Generator → board FIFO → simulated board,
//! stepped by hand on one thread (10 ms Pulse Generator periods; the Velocity Generator and
//! the Command Interpreter every 5th, and the Command Interpreter also in the cycle a
//! request or a move's end releases, as its thread runs it).

use std::sync::atomic::Ordering;
use std::sync::Arc;

use crate::motion::{sim_board, Motion};
use wrc_board::{DpramBoard, Expect, Fault, Feedback, MotionBoard};
use wrc_board_sim::SimBoard;
use wrc_config::Config;
use wrc_controller::command_interpreter::{CommandInterpreter, CommandLinks};
use wrc_controller::messages::{Incoming, MoveDone, OutLine, SourceId, Urgent};
use wrc_controller::pulse_generator::{Liveness, PulseGenerator};
use wrc_controller::shared::{Shared, StopKind};
use wrc_controller::velocity_generator::VelocityGenerator;
use wrc_protocol::{Code, Command, Request};
use wrc_rt::ipc::{MessageQueue, Semaphore};
use wrc_rt::Release;

const PERIOD_NS: u64 = 10_000_000;
const HOST: SourceId = SourceId(0x1000_0001);

struct Rig {
    sim: SimBoard,
    host: DpramBoard,
    ci: CommandInterpreter<DpramBoard>,
    pg: PulseGenerator<DpramBoard>,
    vg: VelocityGenerator,
    incoming: Arc<MessageQueue<Incoming>>,
    done: Arc<MessageQueue<MoveDone>>,
    network: Arc<MessageQueue<OutLine>>,
    shared: Arc<Shared>,
    /// Board periods run.
    k: u64,
    /// Every line the host received, in order.
    lines: Vec<String>,
    /// The board as it stood when the last period's lines were written (before its own
    /// period ran).
    told_at: Feedback,
}

impl Rig {
    /// The tasks on one simulated board, the robot homed where the board stands.
    fn new() -> Rig {
        let config = Config::embedded_default();
        let (sim, mapping) = sim_board(&config, &config.boards[0]);
        let attach = || DpramBoard::attach(mapping.share(), Expect::default()).unwrap();
        let (ci_board, host) = (attach(), attach());
        let mut fb = Feedback::default();
        host.read_feedback(&mut fb).unwrap();
        let Motion {
            pg,
            vg,
            shared,
            orders,
            done,
        } = Motion::at_rest(&config, attach());
        let incoming = Arc::new(MessageQueue::new(16));
        let network = Arc::new(MessageQueue::new(256));
        let ci = CommandInterpreter::new(
            config.robot.clone(),
            ci_board,
            shared.clone(),
            CommandLinks::new(incoming.clone(), orders, done.clone(), network.clone()),
        );
        Rig {
            sim,
            host,
            ci,
            pg,
            vg,
            incoming,
            done,
            network,
            shared,
            k: 0,
            lines: Vec::new(),
            told_at: fb,
        }
    }

    fn now_ns(&self) -> u64 {
        1_000_000_000 + self.k * PERIOD_NS
    }

    /// The lines the host received since the last call.
    fn take_lines(&mut self) -> Vec<String> {
        let new: Vec<String> = std::iter::from_fn(|| self.network.try_recv().ok())
            .map(|l| String::from_utf8_lossy(l.bytes()).trim_end().to_string())
            .collect();
        self.lines.extend(new.iter().cloned());
        new
    }

    /// A request from the host, handled in the Command Interpreter cycle it releases; a
    /// stop request releases the Pulse Generator at once, an order the Velocity Generator.
    fn send(&mut self, id: u32, command: Command) -> Vec<String> {
        let request = Request {
            id: Some(id),
            command,
            checksum: false,
        };
        self.incoming
            .try_send(Incoming::Request(HOST, request))
            .unwrap();
        let epoch = self.shared.stop_epoch.load(Ordering::Acquire);
        self.ci.step_released(self.now_ns(), false);
        if self.shared.stop_epoch.load(Ordering::Acquire) != epoch {
            self.pg.step_released(Release::Event);
        }
        self.vg.step();
        self.take_lines()
    }

    /// One 10 ms board period: the Velocity Generator and the Command Interpreter every
    /// 5th, the Pulse Generator, the Command Interpreter again if a move's end released
    /// it, then the board. The lines the host received meanwhile.
    fn period(&mut self) -> Vec<String> {
        if self.k % 5 == 0 {
            self.vg.step();
            self.ci.step_released(self.now_ns(), true);
        }
        self.pg.step();
        if !self.done.is_empty() {
            self.ci.step_released(self.now_ns(), false);
        }
        let lines = self.take_lines();
        self.told_at = self.feedback();
        self.sim.step();
        self.k += 1;
        lines
    }

    fn feedback(&self) -> Feedback {
        let mut fb = Feedback::default();
        self.host.read_feedback(&mut fb).unwrap();
        fb
    }

    /// Where the board's axes have been commanded to [pulse].
    fn board_commanded(&self) -> [i64; 4] {
        let fb = self.feedback();
        std::array::from_fn(|i| fb.axes[i].commanded)
    }
}

/// When the last period's lines were written, the board had executed every period the Pulse
/// Generator pushed, and every encoder was on its commanded count.
fn assert_at_rest(r: &Rig, what: &str) {
    let fb = r.told_at;
    let pushed = r.shared.commanded_pulses();
    for (i, a) in fb.axes[..4].iter().enumerate() {
        assert_eq!(
            a.commanded, pushed[i],
            "{what}: the end came with periods still queued on axis {i}"
        );
        assert_eq!(
            a.encoder, a.commanded,
            "{what}: the end came before axis {i} was in position"
        );
    }
}

fn movj(j1: f64) -> Command {
    let mut joints = [0.0; 16];
    joints[..4].copy_from_slice(&[j1, 30.0, 0.0, 250.0]);
    Command::MovJ { joints, count: 4 }
}

/// One way to stop a motion, and how a host sees its end.
struct Case {
    stop: Command,
    /// The aborted motion's ABS, at once.
    aborted: Option<&'static str>,
    /// The lines that tell the end (each the start of a line): the replies of a WAIT sent
    /// before the stop (2) and of one sent during the brake (4), and the state the end
    /// leaves (ESTOP's is set at once).
    ends: &'static [&'static str],
}

/// Pins the bug where a stopped or held motion's end came while the board still had the
/// brake's last periods queued (the Pulse Generator reports a brake once it has pushed it):
/// after STOP, ESTOP or HOLD in the middle of a long move, the end a host sees — WAIT's reply,
/// the state IDLE or HELD — comes only when the board has executed every period pushed and
/// stands still, and no pulse follows it. The aborted motion's own `ABS` comes at once.
#[test]
fn a_stopped_or_held_motion_ends_when_the_board_stands_still() {
    let cases = [
        Case {
            stop: Command::Stop,
            aborted: Some("ABS 1 200"),
            ends: &["ABS 2 200", "INF 4", "EVT STATE IDLE"],
        },
        Case {
            stop: Command::Estop,
            aborted: Some("ABS 1 201"),
            ends: &["ABS 2 201", "ABS 4 201"],
        },
        Case {
            stop: Command::Hold,
            aborted: None,
            ends: &["EVT STATE HELD"],
        },
    ];
    for case in cases {
        let stop = case.stop;
        let mut r = Rig::new();
        let start = r.board_commanded();
        assert_eq!(r.send(1, movj(170.0)), ["ACK 1", "EVT STATE MOVING"]);
        // Cruising on J1 (from -75 to 170 deg).
        for _ in 0..60 {
            r.period();
        }
        let cruise = r.board_commanded()[0] - start[0];
        assert!(cruise > 10_000, "{stop:?}: j1 moved {cruise} pulses");
        assert_eq!(r.send(2, Command::Wait), ["ACK 2"]);
        let lines = r.send(3, stop);
        assert_eq!(lines[0], "ACK 3", "{stop:?}: {lines:?}");
        // STOP and ESTOP abort the motion at once (its ABS); its brake goes on.
        if let Some(abs) = case.aborted {
            assert!(
                lines.iter().any(|l| l.starts_with(abs)),
                "{stop:?}: {lines:?}"
            );
        }
        let is_end = |l: &String| case.ends.iter().any(|e| l.starts_with(e));
        assert!(
            !lines.iter().any(is_end),
            "{stop:?}: the end came with the stop request: {lines:?}"
        );
        r.period();
        assert_eq!(r.send(4, Command::Wait), ["ACK 4"]);
        // Every period that tells an end finds the board at rest.
        let mut periods = 0;
        while !case
            .ends
            .iter()
            .all(|e| r.lines.iter().any(|l| l.starts_with(e)))
        {
            let lines = r.period();
            if lines.iter().any(is_end) {
                assert_at_rest(&r, &format!("{stop:?}: {lines:?}"));
            }
            periods += 1;
            assert!(periods < 500, "{stop:?}: no end within 500 periods");
        }
        let end = r.board_commanded();
        for _ in 0..10 {
            let lines = r.period();
            assert!(
                !lines.iter().any(|l| l.starts_with("EVT STATE")),
                "{stop:?}: {lines:?}"
            );
        }
        assert_eq!(r.board_commanded(), end, "{stop:?}: pulses after the end");
        assert!(
            end[0] - start[0] < 245_000,
            "{stop:?}: stopped short of the target"
        );
        if case.aborted.is_none() {
            // Held: the motion and both WAITs are still open.
            assert!(
                !r.lines
                    .iter()
                    .any(|l| l.starts_with("INF") || l.starts_with("ABS")),
                "{stop:?}: {:?}",
                r.lines
            );
        }
    }
}

/// Pins the bug where a fault campaign under load left the robot "still moving" for ever
/// after the E-stop input opened during a transfer, every RESET refused (121). A flush the
/// Pulse Generator had armed for an earlier stop was still pending when it took the E-stop,
/// so it could not flush for it and waited for the board to brake on its own, as a board does
/// with a stop word nobody answers. But a flush answers the stop word posted when it is
/// armed: the pending one answered the E-stop's, so the board never braked on its own (its
/// E-stop input had already stopped the axes, so no run-dry brake came either), and the wait
/// never ended. The Pulse Generator now sees the stop answered and brakes behind the queue.
/// It runs twice in every board period here, as a late one catching up does: a brake the
/// board still shows after the host released it is not waited for again.
#[test]
fn a_stop_answered_by_a_flush_armed_earlier_is_not_waited_for_on_the_board() {
    let mut r = Rig::new();
    r.pg = r.pg.with_board_stops();
    r.shared.set_stop_line(r.host.stop_line().unwrap());
    assert_eq!(r.send(1, movj(170.0)), ["ACK 1", "EVT STATE MOVING"]);
    for _ in 0..60 {
        r.period();
    }
    // The E-stop input opens: the board stops the axes itself at its next period.
    r.sim.apply_fault(Fault::Estop { on: true });
    // The E-stop request posts its stop word; a flush armed after that (here by hand, as
    // the Pulse Generator armed one for an earlier stop) carries it and is still pending
    // when the Pulse Generator takes the stop.
    r.incoming
        .try_send(Incoming::Request(
            HOST,
            Request {
                id: Some(2),
                command: Command::Estop,
                checksum: false,
            },
        ))
        .unwrap();
    r.ci.step_released(r.now_ns(), false);
    let at = r.host.fifo_position().unwrap();
    assert!(r.host.flush_queued(&at, at.write, &[]));
    r.pg.step_released(Release::Event);
    let mut periods = 0;
    while !(r.shared.in_flight.load(Ordering::Acquire) == 0
        && r.shared.stopped_epoch.load(Ordering::Acquire)
            == r.shared.stop_epoch.load(Ordering::Acquire))
    {
        r.pg.step();
        r.period();
        periods += 1;
        assert!(
            periods < 300,
            "still moving {periods} periods after the E-stop: board {:?}",
            r.host.board_stop()
        );
    }
    let fb = r.feedback();
    assert!(fb.axes[..4].iter().all(|a| a.increment == 0), "{fb:?}");
    assert!(!r.host.board_stop().braking_own);
    // The input closes; RESET is taken and the robot moves again from where it stopped.
    r.sim.apply_fault(Fault::Estop { on: false });
    r.send(3, Command::Reset);
    for _ in 0..10 {
        r.period();
    }
    assert!(r.lines.iter().any(|l| l == "ACK 3"), "{:?}", r.lines);
    let at = r.board_commanded();
    assert_eq!(r.send(4, movj(100.0)), ["ACK 4", "EVT STATE MOVING"]);
    for _ in 0..20 {
        r.period();
    }
    assert_ne!(r.board_commanded(), at, "no motion after RESET");
}

/// Pins the bug where an E-stop from the GUI on a loaded host (no real-time scheduling)
/// ended the motion with `ABS 209 motion fault` instead of 201: the request posts the
/// board's stop word before it moves the stop epoch, and the thread asking was preempted
/// between the two for more than a board period. The board, finding the word unanswered,
/// braked on its own; the Pulse Generator's next period, seeing no new epoch, took the brake
/// for a FIFO run dry. A stop on its way (counted, its epoch not yet taken) is no fault.
#[test]
fn a_board_brake_for_a_stop_whose_epoch_has_not_moved_yet_is_no_motion_fault() {
    let mut r = Rig::new();
    let urgent = Arc::new(MessageQueue::new(8));
    r.pg = r.pg.with_board_stops().with_liveness(Liveness::new(
        3,
        10_000,
        10_000,
        urgent.clone(),
        Arc::new(Semaphore::new(0)),
    ));
    r.shared.set_stop_line(r.host.stop_line().unwrap());
    assert_eq!(r.send(1, movj(170.0)), ["ACK 1", "EVT STATE MOVING"]);
    for _ in 0..60 {
        r.period();
    }
    // The first half of `Shared::request_stop` (ESTOP): counted, its word posted; the
    // asking thread is preempted there.
    r.shared.stop_requests.fetch_add(1, Ordering::AcqRel);
    r.shared
        .stop_kind
        .fetch_max(StopKind::Estop as u8, Ordering::AcqRel);
    r.host.stop_line().unwrap().post(100);
    // Two board periods and the Pulse Generator's own: the board brakes on its own.
    for _ in 0..3 {
        r.period();
    }
    assert!(r.host.board_stop().braking_own, "{:?}", r.host.board_stop());
    // The second half: the epoch moves.
    r.shared.stop_epoch.fetch_add(1, Ordering::AcqRel);
    r.pg.step_released(Release::Event);
    let mut periods = 0;
    while !(r.shared.in_flight.load(Ordering::Acquire) == 0
        && r.shared.stopped_epoch.load(Ordering::Acquire)
            == r.shared.stop_epoch.load(Ordering::Acquire))
    {
        r.period();
        periods += 1;
        assert!(periods < 300, "no rest {periods} periods after the stop");
    }
    let raised: Vec<Urgent> = std::iter::from_fn(|| urgent.try_recv().ok()).collect();
    assert!(
        raised.is_empty(),
        "a stop that was asked for raised {raised:?}"
    );
    // And a FIFO that runs dry while moving still is a motion fault (209).
    assert_eq!(r.send(3, movj(100.0))[0], "ACK 3");
    for _ in 0..30 {
        r.period();
    }
    for _ in 0..5 {
        r.sim.step();
        r.k += 1;
    }
    r.period();
    let raised: Vec<Urgent> = std::iter::from_fn(|| urgent.try_recv().ok()).collect();
    assert!(
        raised
            .iter()
            .any(|u| matches!(u, Urgent::Fault(c) if *c == Code::MotionFault.number())),
        "{raised:?}"
    );
}
