//! The Command Interpreter stepped by hand on made-up times (a mock clock: `step_released`
//! takes the time), with the test playing the Velocity and Pulse Generators through the
//! order and done queues: the motion runner (tickets, HOLD/RESUME, WAIT), the program
//! runner (DELAY on the cycle's clock), RESET's deadline and its wait for a stop's brake,
//! the guard on the vacuum valves and guarded outputs, and message-released cycles.

use std::sync::atomic::Ordering;
use std::sync::Arc;

use wrc_board::{DpramBoard, Expect, Mapping};
use wrc_board_sim::{SimBoard, SimSettings};
use wrc_config::Config;
use wrc_protocol::{Command, ReplyTo, Request};
use wrc_rt::ipc::MessageQueue;

use super::{CommandInterpreter, CommandLinks, RESET_REST_TIMEOUT_NS, RESET_TIMEOUT_NS};
use crate::messages::{Incoming, MoveDone, MoveKind, MoveOrder, MoveOutcome, OutLine, SourceId};
use crate::shared::{RobotState, Shared, StopKind};

const MS: u64 = 1_000_000;
const HOST: SourceId = SourceId(0x1000_0001);

struct Rig {
    ci: CommandInterpreter<DpramBoard>,
    sim: SimBoard,
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
            sim,
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

/// Regression: a RESET sent while an ESTOP's brake was still under way was refused with
/// "the robot is still moving; STOP and WAIT first" although a stop was already braking.
/// Now it waits for the arm to stand still, then is carried out as at rest.
#[test]
fn a_reset_during_an_estops_brake_is_answered_once_the_arm_stands_still() {
    let mut r = Rig::new();
    r.movj(1, 10.0);
    assert!(r.orders.try_recv().is_ok());
    r.shared.in_flight.store(4, Ordering::Release);
    let estop = r.send(2, Command::Estop);
    assert!(estop.contains(&"EVT STATE ESTOP".to_string()), "{estop:?}");
    // Braking: no answer yet, however many cycles.
    assert!(r.send(3, Command::Reset).is_empty());
    assert!(r.periods(10).is_empty());
    // A second RESET meanwhile is refused: one is in progress.
    assert!(r.send(4, Command::Reset)[0].starts_with("NAK 4 121 a RESET is already"));
    // The brake ends; the RESET is carried out (the board's part takes a board period).
    r.at_rest();
    assert!(r.periods(1).is_empty());
    r.sim.step();
    assert_eq!(r.periods(1), ["ACK 3", "EVT STATE IDLE"]);
    assert_eq!(r.shared.state(), RobotState::Idle);
}

#[test]
fn a_reset_during_a_brake_gets_its_usual_refusal_once_the_arm_stands_still() {
    let mut r = Rig::new();
    r.ci.estop_input = Some(15);
    r.shared.in_flight.store(4, Ordering::Release);
    r.send(1, Command::Estop);
    // The E-stop input is open: refused with 123, but only once the brake has ended.
    r.shared.inputs[0].store(1 << 15, Ordering::Release);
    assert!(r.send(2, Command::Reset).is_empty());
    r.at_rest();
    let t = r.periods(1);
    assert!(
        t[0].starts_with("NAK 2 123 the E-stop input is still open"),
        "{t:?}"
    );
}

#[test]
fn a_reset_whose_stop_never_ends_is_refused_after_its_deadline() {
    let mut r = Rig::new();
    r.shared.in_flight.store(4, Ordering::Release);
    r.send(1, Command::Estop);
    assert!(r.send(2, Command::Reset).is_empty());
    let before = r.now_ns;
    let mut t = r.periods(1);
    while t.is_empty() {
        t = r.periods(1);
    }
    assert!(
        t[0].starts_with("NAK 2 121 the stop under way did not end within 5 s"),
        "{t:?}"
    );
    assert!(r.now_ns - before >= RESET_REST_TIMEOUT_NS - 50 * MS);
    assert!(r.now_ns - before <= RESET_REST_TIMEOUT_NS + 50 * MS);
}

#[test]
fn a_reset_while_the_arm_moves_with_no_stop_under_way_is_refused_at_once() {
    let mut r = Rig::new();
    r.movj(1, 10.0);
    r.shared.in_flight.store(4, Ordering::Release);
    let t = r.send(2, Command::Reset);
    assert_eq!(
        t,
        ["NAK 2 121 the robot is still moving; STOP and WAIT first"]
    );
}

#[test]
fn out_of_a_vacuum_valve_holding_a_wafer_needs_force_and_is_told() {
    use crate::messages::cell_job::CellEvent;
    use crate::shared::BLADE_UNCERTAIN;
    let mut r = Rig::new();
    let config = Config::embedded_default();
    r.ci.hand = config.hand;
    r.ci.name_outputs(&config.signals(&[]), 1 << 7);
    let out = |n, on, force| Command::Out { n, on, force };
    // Nothing on the blade: free.
    assert_eq!(r.send(1, out(0, true, false)), ["ACK 1"]);
    assert_eq!(r.send(2, out(7, true, false)), ["ACK 2"]);
    // W4 on blade A: the valve may not go off, output 7 not switch, without FORCE.
    r.shared.blade_wafers[0].store(4, Ordering::Release);
    let t = r.send(3, out(0, false, false));
    assert_eq!(
        t,
        ["NAK 3 141 output 0 (vacuum valve) is blade A's vacuum valve and blade A holds W4: switched off, the wafer drops; send OUT 0 0 FORCE if you mean it"]
    );
    assert_ne!(
        r.shared.outputs[0].load(Ordering::Acquire) & 1,
        0,
        "still on"
    );
    let t = r.send(4, out(7, false, false));
    assert!(
        t[0].starts_with("NAK 4 141 output 7 is guarded while a blade holds a wafer, and blade A holds W4; send OUT 7 0 FORCE"),
        "{t:?}"
    );
    // Switching the valve on, or another output, is free.
    assert_eq!(r.send(5, out(0, true, false)), ["ACK 5"]);
    assert_eq!(r.send(6, out(5, true, false)), ["ACK 6"]);
    assert!(
        r.ci.io.store.cell_events.try_recv().is_err(),
        "nothing forced"
    );
    // FORCE: done, and the cell service is told who forced what.
    assert_eq!(r.send(7, out(0, false, true)), ["ACK 7"]);
    assert_eq!(r.shared.outputs[0].load(Ordering::Acquire) & 1, 0);
    match r.ci.io.store.cell_events.try_recv() {
        Ok(CellEvent::Forced {
            n: 0,
            on: false,
            from: HOST,
            blade: wrc_cell::Blade::A,
            wafer: 4,
            valve: true,
        }) => {}
        other => panic!("{other:?}"),
    }
    // An uncertain wafer is guarded too.
    r.shared.blade_wafers[0].store(4 | BLADE_UNCERTAIN, Ordering::Release);
    let t = r.send(8, out(0, false, false));
    assert!(t[0].contains("blade A may hold W4?"), "{t:?}");
}
