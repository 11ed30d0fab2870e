//! What checking a motion against the cell costs the Command Interpreter before its ACK
//! (docs/motion.md, "The cell as an obstacle"): the motion planned on its copy of the
//! Velocity Generator, played period by period, the arm's bodies swept between periods and
//! the brakes that would leave the path played where the arm is near the cell; on the demo
//! cell. Per motion: seeded random PTPs and lines over the whole workspace at every height
//! (some clear, some touching: a check that finds a touch ends there), a transfer's blended
//! approach, a PTP with a wafer from LP1 to LP2, and one pose's clearances.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use wrc_cell::obstacle::LineTolerance;
use wrc_cell::{CellModel, Stations};
use wrc_controller::command_interpreter::clearance::CellCheck;
use wrc_controller::messages::cell_job::CellView;
use wrc_controller::messages::{MoveKind, MoveOrder};
use wrc_motion::{MotionSettings, VelocityGenerator};
use wrc_robot::{BladeLoad, Joints, Pose, Posture, Robot};

/// A seeded sequence in [0, 1) (SplitMix64).
struct Seq(u64);

impl Seq {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

/// The demo cell's check, the blades carrying `wafer`.
fn check(robot: &Robot, wafer: bool) -> CellCheck {
    let stations = Stations::embedded_demo();
    let model: CellModel = stations.model(robot).unwrap();
    let (mut w, r) = wrc_rt::ipc::mailbox(CellView::empty(robot));
    w.write(CellView::of(model, [wafer, false], stations.iter()));
    let g = VelocityGenerator::new(robot.clone(), MotionSettings::default()).unwrap();
    CellCheck::new(g, r, &[0.0])
}

fn order(kind: MoveKind) -> MoveOrder {
    MoveOrder {
        ticket: 1,
        epoch: 0,
        speed_pct: 100.0,
        accel_pct: 100.0,
        kind,
    }
}

fn random_joints(robot: &Robot, seq: &mut Seq) -> Joints {
    let mut q = robot.home();
    q[0] = seq.range(-175.0, 175.0);
    q[1] = seq.range(-160.0, 160.0);
    q[2] = seq.range(-260.0, 260.0);
    q[3] = seq.range(0.0, 300.0);
    q
}

fn random_pose(seq: &mut Seq) -> Pose {
    let r = seq.range(80.0, 380.0);
    let phi = seq.range(-180.0, 180.0_f64).to_radians();
    Pose {
        x: r * phi.cos(),
        y: r * phi.sin(),
        z: seq.range(0.0, 300.0),
        yaw: seq.range(-180.0, 180.0),
    }
}

fn benches(c: &mut Criterion) {
    let robot = Robot::paper_default();
    let home = robot.joints_to_pulses(&robot.home());
    let sensed = [false; 2];

    // 100 random PTPs from home, the hand empty.
    let mut seq = Seq(2026);
    let ptps: Vec<MoveOrder> = (0..100)
        .map(|_| order(MoveKind::Joints(random_joints(&robot, &mut seq))))
        .collect();
    let mut empty = check(&robot, false);
    c.bench_function("cell_check/ptp_random_100", |b| {
        b.iter(|| {
            for o in &ptps {
                let _ = black_box(empty.check(&robot, o, &home, sensed));
            }
        })
    });

    // 100 random lines from a pose in front of the robot, under the stations.
    let start_pose = Pose {
        x: 200.0,
        y: 0.0,
        z: 0.0,
        yaw: 0.0,
    };
    let start = robot.joints_to_pulses(&robot.inverse(&start_pose, Posture::Right, None).unwrap());
    let lines: Vec<MoveOrder> = (0..100)
        .map(|_| order(MoveKind::Line(random_pose(&mut seq))))
        .collect();
    c.bench_function("cell_check/line_random_100", |b| {
        b.iter(|| {
            for o in &lines {
                let _ = black_box(empty.check(&robot, o, &start, sensed));
            }
        })
    });

    // A GET's blended approach into LP1 slot 13, and a PTP with a wafer from LP1's approach
    // pose to LP2's (a transfer's move).
    let stations = Stations::embedded_demo();
    let lp1 = stations.get("LP1").unwrap();
    let lp2 = stations.get("LP2").unwrap();
    let via = lp1
        .approach_joints(&robot, 13, false, &robot.home())
        .unwrap();
    let approach = order(MoveKind::Approach {
        via,
        to: lp1.seated_pose(13, false).unwrap(),
        line_pct: 60.0,
    });
    c.bench_function("cell_check/approach_lp1", |b| {
        b.iter(|| black_box(empty.check(&robot, &approach, &home, sensed).is_ok()))
    });
    // The Velocity Generator's own work for the same motion: planning it and producing its
    // periods (what the check adds is the rest).
    let mut g = VelocityGenerator::new(robot.clone(), MotionSettings::default()).unwrap();
    c.bench_function("cell_check/vg_alone_approach_lp1", |b| {
        b.iter(|| {
            g.abandon_at(&home);
            let _ = wrc_controller::velocity_generator::plan_order(&mut g, &approach);
            let mut p = wrc_motion::Period::default();
            while g.is_moving() {
                g.next_period(&mut p);
            }
        })
    });
    let mut loaded = check(&robot, true);
    let from = robot.joints_to_pulses(
        &lp1.approach_joints(&robot, 13, true, &robot.home())
            .unwrap(),
    );
    let to = lp2
        .approach_joints(&robot, 13, true, &robot.home())
        .unwrap();
    let carry = order(MoveKind::Joints(to));
    c.bench_function("cell_check/ptp_wafer_lp1_to_lp2", |b| {
        b.iter(|| black_box(loaded.check(&robot, &carry, &from, sensed).is_ok()))
    });

    // One pose's clearances: the bodies placed and measured against the six stations.
    let model = stations.model(&robot).unwrap();
    let blades = [BladeLoad {
        z_offset_mm: 0.0,
        wafer: true,
    }];
    let q = robot
        .inverse(
            &Pose {
                x: 150.0,
                y: 150.0,
                z: 100.0,
                yaw: 45.0,
            },
            Posture::Right,
            None,
        )
        .unwrap();
    let mut clear = [0.0; wrc_cell::obstacle::MAX_SOLIDS];
    c.bench_function("cell_check/pose_clearances", |b| {
        b.iter(|| {
            let bodies = robot.bodies(black_box(&q), &blades);
            model.clearances(&bodies, &blades, &LineTolerance::CONTROLLER, &mut clear);
            black_box(clear[0])
        })
    });
}

criterion_group!(cell_check, benches);
criterion_main!(cell_check);
