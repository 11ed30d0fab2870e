//! Paths, PTP blends and the acceleration override through the motion path (Velocity
//! Generator → pulse ring → Pulse Generator → simulated board), stepped by hand: each new
//! `MoveKind` ends on its target's pulses on the board; a HOLD on a path ends the move
//! `Held` and the same order again (what RESUME sends) continues it to the same end; a path
//! from elsewhere is refused with code 113 and nothing moves; an order at ACCEL 25 % takes
//! longer than at 100 %.

use std::sync::Arc;

use crate::motion::{sim_board, Motion};
use wrc_board::{DpramBoard, Expect, Feedback, MotionBoard};
use wrc_board_sim::SimBoard;
use wrc_config::Config;
use wrc_controller::messages::{MoveDone, MoveKind, MoveOrder, MoveOutcome};
use wrc_controller::pulse_generator::PulseGenerator;
use wrc_controller::shared::{Shared, StopKind};
use wrc_controller::velocity_generator::VelocityGenerator;
use wrc_motion::{check_path, PathSegment, PathSpec};
use wrc_robot::{Joints, Pose, Posture, Robot};
use wrc_rt::ipc::MessageQueue;

struct Rig {
    sim: SimBoard,
    host: DpramBoard,
    pg: PulseGenerator<DpramBoard>,
    vg: VelocityGenerator,
    orders: Arc<MessageQueue<MoveOrder>>,
    done: Arc<MessageQueue<MoveDone>>,
    shared: Arc<Shared>,
    robot: Robot,
    k: u64,
}

impl Rig {
    fn new() -> Rig {
        let config = Config::embedded_default();
        let (sim, mapping) = sim_board(&config, &config.boards[0]);
        let pg_board = DpramBoard::attach(mapping.share(), Expect::default()).unwrap();
        let host = DpramBoard::attach(mapping, Expect::default()).unwrap();
        let Motion {
            pg,
            vg,
            shared,
            orders,
            done,
        } = Motion::at_rest(&config, pg_board);
        Rig {
            sim,
            host,
            pg,
            vg,
            orders,
            done,
            shared,
            robot: config.robot.clone(),
            k: 0,
        }
    }

    /// One 10 ms period: the Velocity Generator every 5th, the Pulse Generator, the board.
    fn period(&mut self) {
        if self.k % 5 == 0 {
            self.vg.step();
        }
        self.pg.step();
        self.sim.step();
        self.k += 1;
    }

    /// Where the board has commanded every axis [pulse].
    fn commanded(&self) -> [i64; 16] {
        let mut fb = Feedback::default();
        self.host.read_feedback(&mut fb).unwrap();
        std::array::from_fn(|i| fb.axes[i].commanded)
    }

    fn order(&self, ticket: u32, kind: MoveKind, accel_pct: f64) {
        let epoch = self
            .shared
            .stop_epoch
            .load(std::sync::atomic::Ordering::Acquire);
        self.orders
            .try_send(MoveOrder {
                ticket,
                epoch,
                speed_pct: 100.0,
                accel_pct,
                kind,
            })
            .unwrap();
    }

    /// Run until a move ends; how many periods it took.
    fn run_until_done(&mut self, limit: u64) -> (MoveDone, u64) {
        for k in 0..limit {
            self.period();
            if let Ok(d) = self.done.try_recv() {
                return (d, k + 1);
            }
        }
        panic!("no move ended within {limit} periods");
    }

    /// A PTP to `pose` (right elbow) to start from; its joints.
    fn go_to(&mut self, pose: &Pose) -> Joints {
        let q = self.robot.inverse(pose, Posture::Right, None).unwrap();
        self.order(100, MoveKind::Joints(q), 100.0);
        let (done, _) = self.run_until_done(2000);
        assert_eq!(done.outcome, MoveOutcome::Completed);
        // Let the board's FIFO drain.
        for _ in 0..20 {
            self.period();
        }
        q
    }

    fn pulses(&self, q: &Joints) -> [i64; 16] {
        self.robot.joints_to_pulses(q)
    }
}

fn p(x: f64, y: f64, z: f64, yaw: f64) -> Pose {
    Pose { x, y, z, yaw }
}

fn rounded_corners() -> PathSpec {
    let mut spec = PathSpec::new(p(200.0, -150.0, 20.0, 0.0));
    for seg in [
        PathSegment::Line {
            to: p(300.0, -150.0, 20.0, 0.0),
            blend_mm: 20.0,
        },
        PathSegment::Arc {
            via: p(350.0, -50.0, 0.0, 0.0),
            to: p(300.0, 50.0, 40.0, 45.0),
            blend_mm: 10.0,
        },
        PathSegment::Line {
            to: p(150.0, 50.0, 40.0, 90.0),
            blend_mm: 0.0,
        },
    ] {
        spec.push(seg).unwrap();
    }
    spec
}

/// Run to the end and 20 periods more (the board's FIFO drained): the outcome and periods.
fn finish(rig: &mut Rig) -> (MoveOutcome, u64) {
    let (done, n) = rig.run_until_done(5000);
    for _ in 0..20 {
        rig.period();
    }
    (done.outcome, n)
}

#[test]
fn a_path_runs_on_the_board_and_a_hold_on_it_resumes_to_its_end() {
    let spec = rounded_corners();
    let mut rig = Rig::new();
    let start = rig.go_to(&spec.start);
    let end = rig.pulses(&check_path(&rig.robot, &start, &spec).unwrap().end_joints);
    rig.order(1, MoveKind::Path(spec), 100.0);
    let (outcome, _) = finish(&mut rig);
    assert_eq!(outcome, MoveOutcome::Completed);
    assert_eq!(rig.commanded()[..4], end[..4]);

    // Again, held half-way: Held, off the end; the same order again runs to the same end.
    let mut rig = Rig::new();
    rig.go_to(&spec.start);
    rig.order(2, MoveKind::Path(spec), 100.0);
    for _ in 0..80 {
        rig.period();
    }
    rig.shared.request_stop(StopKind::Hold);
    let (outcome, _) = finish(&mut rig);
    assert_eq!(outcome, MoveOutcome::Held);
    assert_ne!(rig.commanded()[..4], end[..4]);
    rig.order(2, MoveKind::Path(spec), 100.0);
    let (outcome, _) = finish(&mut rig);
    assert_eq!(outcome, MoveOutcome::Completed);
    assert_eq!(rig.commanded()[..4], end[..4]);
}

#[test]
fn a_path_from_elsewhere_is_refused_and_nothing_moves() {
    let spec = rounded_corners();
    let mut rig = Rig::new();
    rig.go_to(&p(250.0, 100.0, 0.0, 0.0));
    let before = rig.commanded();
    rig.order(3, MoveKind::Path(spec), 100.0);
    let (outcome, _) = finish(&mut rig);
    assert_eq!(outcome, MoveOutcome::Refused(113));
    assert_eq!(rig.commanded(), before);
}

#[test]
fn ptp_blends_end_on_their_targets_and_accel_lowers_a_move() {
    let spec = rounded_corners();
    let elsewhere = p(50.0, 300.0, 100.0, 90.0);
    let mut rig = Rig::new();
    let away = rig.go_to(&elsewhere);
    let start = rig
        .robot
        .inverse(&spec.start, Posture::Right, None)
        .unwrap();
    let end = rig.pulses(&check_path(&rig.robot, &start, &spec).unwrap().end_joints);
    // PTP into the path, then the path out into a PTP back, then a PTP through a via.
    rig.order(
        4,
        MoveKind::PtpToPath {
            via: start,
            path: spec,
            path_pct: 80.0,
        },
        100.0,
    );
    let (outcome, _) = finish(&mut rig);
    assert_eq!(outcome, MoveOutcome::Completed);
    assert_eq!(rig.commanded()[..4], end[..4]);
    let back = rig
        .robot
        .inverse(&spec.start, Posture::Right, None)
        .unwrap();
    rig.order(5, MoveKind::Joints(back), 100.0);
    finish(&mut rig);
    rig.order(
        6,
        MoveKind::Depart {
            path: spec,
            to: away,
            path_pct: 100.0,
        },
        100.0,
    );
    let (outcome, _) = finish(&mut rig);
    assert_eq!(outcome, MoveOutcome::Completed);
    assert_eq!(rig.commanded()[..4], rig.pulses(&away)[..4]);
    let via = rig
        .robot
        .inverse(&p(300.0, 0.0, 50.0, 0.0), Posture::Right, None)
        .unwrap();
    let mut periods = Vec::new();
    for (ticket, accel) in [(7, 100.0), (8, 25.0)] {
        let from = rig.robot.pulses_to_joints(&rig.commanded());
        let to = if ticket == 7 { start } else { away };
        rig.order(
            ticket,
            MoveKind::Via {
                start: from,
                via,
                to,
            },
            accel,
        );
        let (outcome, n) = finish(&mut rig);
        assert_eq!(outcome, MoveOutcome::Completed);
        assert_eq!(rig.commanded()[..4], rig.pulses(&to)[..4]);
        periods.push(n);
    }
    // The same distances back and forth: at ACCEL 25 % it takes longer.
    assert!(periods[1] > periods[0], "{periods:?}");
}
