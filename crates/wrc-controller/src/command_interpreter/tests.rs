//! The Command Interpreter stepped by hand on made-up times (a mock clock: `step_released`
//! takes the time), with the test playing the Velocity and Pulse Generators through the
//! order and done queues: the motion runner (tickets, HOLD/RESUME, WAIT), the program
//! runner (DELAY on the cycle's clock), RESET's deadline, and message-released cycles.

use std::sync::atomic::Ordering;
use std::sync::Arc;

use wrc_board::{DpramBoard, Expect, Mapping};
use wrc_board_sim::{SimBoard, SimSettings};
use wrc_config::Config;
use wrc_protocol::{Command, ReplyTo, Request};
use wrc_rt::ipc::MessageQueue;

use super::{CommandInterpreter, CommandLinks, RESET_TIMEOUT_NS};
use crate::messages::{Incoming, MoveDone, MoveKind, MoveOrder, MoveOutcome, OutLine, SourceId};
use crate::shared::{RobotState, Shared, StopKind};

const MS: u64 = 1_000_000;
const HOST: SourceId = SourceId(0x1000_0001);

struct Rig {
    ci: CommandInterpreter<DpramBoard>,
    _sim: SimBoard,
    shared: Arc<Shared>,
    incoming: Arc<MessageQueue<Incoming>>,
    orders: Arc<MessageQueue<MoveOrder>>,
    done: Arc<MessageQueue<MoveDone>>,
    network: Arc<MessageQueue<OutLine>>,
    now_ns: u64,
}

impl Rig {
    fn new() -> Rig {
        let config = Config::embedded_default();
        let settings = SimSettings::from_config(&config, &config.boards[0]);
        let mapping = Mapping::anonymous().unwrap();
        let mut sim = SimBoard::new(mapping.share(), &settings, 1).unwrap();
        sim.step();
        let board = DpramBoard::attach(mapping, Expect::default()).unwrap();
        let shared = Arc::new(Shared::default());
        shared.homed.store(true, Ordering::Release);
        let robot = config.robot.clone();
        for (c, p) in shared
            .commanded
            .iter()
            .zip(robot.joints_to_pulses(&robot.home()))
        {
            c.store(p, Ordering::Release);
        }
        let incoming = Arc::new(MessageQueue::new(16));
        let orders = Arc::new(MessageQueue::new(super::MAX_TICKETS));
        let done = Arc::new(MessageQueue::new(64));
        let network = Arc::new(MessageQueue::new(256));
        let ci = CommandInterpreter::new(
            robot,
            board,
            shared.clone(),
            CommandLinks::new(
                incoming.clone(),
                orders.clone(),
                done.clone(),
                network.clone(),
            ),
        );
        Rig {
            ci,
            _sim: sim,
            shared,
            incoming,
            orders,
            done,
            network,
            now_ns: 1_000 * MS,
        }
    }

    /// Send `command` (with id `id`) and run one message-released cycle 1 ms later; return
    /// the lines it wrote.
    fn send(&mut self, id: u32, command: Command) -> Vec<String> {
        let request = Request {
            id: Some(id),
            command,
            checksum: false,
        };
        self.incoming
            .try_send(Incoming::Request(HOST, request))
            .unwrap();
        self.now_ns += MS;
        self.ci.step_released(self.now_ns, false);
        self.lines()
    }

    /// Periodic cycles every 50 ms for `n` cycles.
    fn periods(&mut self, n: u32) -> Vec<String> {
        for _ in 0..n {
            self.now_ns += 50 * MS;
            self.ci.step_released(self.now_ns, true);
        }
        self.lines()
    }

    fn lines(&mut self) -> Vec<String> {
        let mut v = Vec::new();
        while let Ok(l) = self.network.try_recv() {
            v.push(String::from_utf8_lossy(l.bytes()).trim_end().to_string());
        }
        v
    }

    /// The Pulse Generator's part of a stop: bring the stop epoch to rest.
    fn at_rest(&self) {
        let epoch = self.shared.stop_epoch.load(Ordering::Acquire);
        self.shared.stopped_epoch.store(epoch, Ordering::Release);
        self.shared.in_flight.store(0, Ordering::Release);
    }

    fn movj(&mut self, id: u32, j1: f64) -> Vec<String> {
        self.send(
            id,
            Command::MovJ {
                joints: [
                    j1, 90.0, 0.0, 10.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                ],
                count: 4,
            },
        )
    }
}

#[test]
fn a_reply_comes_in_the_message_released_cycle_not_a_period_later() {
    let mut r = Rig::new();
    assert_eq!(r.send(7, Command::Speed(40.0)), ["ACK 7 speed=40"]);
    assert_eq!(r.shared.speed_pct.load(Ordering::Acquire), 40);
    let status = r.send(8, Command::Status);
    assert!(status[0].starts_with("ACK 8 state=IDLE"), "{status:?}");
}

#[test]
fn hold_keeps_every_open_motion_and_resume_sends_them_again_in_order() {
    let mut r = Rig::new();
    assert_eq!(r.movj(1, 10.0), ["ACK 1", "EVT STATE MOVING"]);
    assert_eq!(r.movj(2, 20.0), ["ACK 2"]);
    let first: Vec<MoveOrder> = std::iter::from_fn(|| r.orders.try_recv().ok()).collect();
    assert_eq!(first.len(), 2);
    let epoch = r.shared.stop_epoch.load(Ordering::Acquire);

    // HOLD: a stop of kind Hold, the tickets stay open, STOPPING until at rest.
    assert_eq!(r.send(3, Command::Hold), ["ACK 3", "EVT STATE STOPPING"]);
    assert_eq!(r.shared.stop_epoch.load(Ordering::Acquire), epoch + 1);
    assert_eq!(r.shared.take_stop_kind(), StopKind::Hold);
    // Not at rest yet: RESUME is refused, and so is a new motion.
    r.shared.in_flight.store(1, Ordering::Release);
    assert!(r.send(4, Command::Resume)[0].starts_with("NAK 4 129 the robot is still braking"));
    assert!(r.movj(5, 30.0)[0].starts_with("NAK 5 121 "));
    // The Pulse Generator reports motion 1 held and comes to rest.
    r.done
        .try_send(MoveDone {
            ticket: first[0].ticket,
            outcome: MoveOutcome::Held,
        })
        .unwrap();
    r.at_rest();
    assert_eq!(r.periods(1), ["EVT STATE HELD"]);
    // Held: nothing ended, nothing is ordered.
    assert!(r.orders.is_empty());
    assert!(r.periods(10).is_empty());

    assert_eq!(r.send(6, Command::Resume), ["ACK 6", "EVT STATE MOVING"]);
    let again: Vec<MoveOrder> = std::iter::from_fn(|| r.orders.try_recv().ok()).collect();
    assert_eq!(
        again.iter().map(|o| o.ticket).collect::<Vec<_>>(),
        first.iter().map(|o| o.ticket).collect::<Vec<_>>(),
        "the same motions, in the order they were accepted"
    );
    for o in &again {
        assert_eq!(o.epoch, epoch + 1, "ordered after the hold");
        assert!(matches!(o.kind, MoveKind::Joints(_)));
    }
    // Their ends are answered as usual.
    for o in &again {
        r.done
            .try_send(MoveDone {
                ticket: o.ticket,
                outcome: MoveOutcome::Completed,
            })
            .unwrap();
    }
    // The state is IDLE before the INF that ends the last motion goes out, so the client's
    // next request already sees it.
    assert_eq!(r.periods(1), ["INF 1", "EVT STATE IDLE", "INF 2"]);
    assert!(r.send(9, Command::Resume)[0].starts_with("NAK 9 129 no motion is held"));
}

/// A HOLD's brake that ends on the target: the Pulse Generator reports the move completed
/// (once the board stands still), so the motion answers `INF` and nothing is HELD; while the
/// brake is in flight nothing is answered.
#[test]
fn a_hold_that_brakes_onto_the_target_answers_inf_and_holds_nothing() {
    let mut r = Rig::new();
    r.movj(1, 10.0);
    let order = r.orders.try_recv().unwrap();
    assert_eq!(r.send(2, Command::Hold), ["ACK 2", "EVT STATE STOPPING"]);
    r.shared.in_flight.store(1, Ordering::Release);
    assert!(r.periods(1).is_empty(), "the brake is still in flight");
    r.at_rest();
    r.done
        .try_send(MoveDone {
            ticket: order.ticket,
            outcome: MoveOutcome::Completed,
        })
        .unwrap();
    // The state is IDLE before the INF goes out.
    assert_eq!(r.periods(1), ["EVT STATE IDLE", "INF 1"]);
    assert!(r.periods(1).is_empty());
}

#[test]
fn stop_while_held_abandons_the_held_motions() {
    let mut r = Rig::new();
    r.movj(1, 10.0);
    // The Velocity Generator takes the order.
    assert!(r.orders.try_recv().is_ok());
    r.send(2, Command::Hold);
    r.at_rest();
    assert_eq!(r.periods(1), ["EVT STATE HELD"]);
    let stop = r.send(3, Command::Stop);
    assert_eq!(stop[0], "ACK 3", "{stop:?}");
    assert!(stop.iter().any(|l| l.starts_with("ABS 1 200")), "{stop:?}");
    assert_eq!(r.shared.take_stop_kind(), StopKind::Stop);
    r.at_rest();
    assert_eq!(r.periods(1), ["EVT STATE IDLE"]);
}

#[test]
fn a_reset_the_board_does_not_carry_out_is_refused_after_one_second_of_clock() {
    let mut r = Rig::new();
    r.shared.set_state(RobotState::Error);
    // The board never runs (no simulated board period): the command stays pending.
    assert!(r.send(1, Command::Reset).is_empty());
    // Many message-released cycles within the second do not refuse it…
    for i in 0..50 {
        assert!(r.send(100 + i, Command::Io)[0].starts_with("ACK"));
    }
    let before = r.now_ns;
    let mut t = r.periods(1);
    while t.is_empty() {
        t = r.periods(1);
    }
    // …the clock does: refused at the first cycle at or after the deadline.
    assert!(t[0].starts_with("NAK 1 122 "), "{t:?}");
    assert!(r.now_ns - before + 50 * MS >= RESET_TIMEOUT_NS - 50 * MS);
    assert!(r.now_ns - before <= RESET_TIMEOUT_NS + 50 * MS);
}

#[test]
fn hold_at_rest_is_acknowledged_and_changes_nothing() {
    let mut r = Rig::new();
    let epoch = r.shared.stop_epoch.load(Ordering::Acquire);
    assert_eq!(r.send(1, Command::Hold), ["ACK 1"]);
    assert_eq!(r.shared.stop_epoch.load(Ordering::Acquire), epoch);
    assert_eq!(r.shared.state(), RobotState::Idle);
    let _ = ReplyTo::default();
}
