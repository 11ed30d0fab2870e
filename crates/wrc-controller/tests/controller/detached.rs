//! The Pulse Generator detached from a board that stopped answering, stepped by hand: the
//! pulse ring's producer (the Velocity Generator, on its own thread) may still push a period
//! of the move the fault cut, and that must not keep the arm "moving" for ever.

use std::sync::atomic::Ordering;
use std::sync::Arc;

use crate::motion::sim_board;
use wrc_board::{DpramBoard, Expect, Feedback, MotionBoard};
use wrc_config::Config;
use wrc_controller::messages::Batch;
use wrc_controller::pulse_generator::{Liveness, PulseGenerator};
use wrc_controller::shared::{Shared, StopKind};
use wrc_motion::VelocityGenerator as Generator;
use wrc_robot::MAX_AXES;
use wrc_rt::ipc::{mailbox, spsc, MessageQueue, Semaphore};
use wrc_rt::Release;

/// Regression (found by `wrc bench faults`, board-kill during a transfer's approach): the
/// Velocity Generator reads the stop epoch when its cycle begins; when the board died and
/// the urgent path's stop was taken by the Pulse Generator (which drained the ring) while
/// that cycle was still producing the cut move's periods, they landed in the ring after the
/// drain. A detached Pulse Generator read nothing from the ring, so they stayed there, the
/// arm counted as moving, and every RESET was refused (121) for ever: the controller could
/// not be recovered. A detached Pulse Generator now drops whatever reaches the ring.
#[test]
fn a_period_pushed_after_the_board_died_does_not_keep_the_arm_moving() {
    let config = Config::embedded_default();
    let (mut sim, mapping) = sim_board(&config, &config.boards[0]);
    let board = DpramBoard::attach(mapping.share(), Expect::default()).unwrap();
    let mut fb = Feedback::default();
    board.read_feedback(&mut fb).unwrap();
    let mut start = [0i64; MAX_AXES];
    for (i, s) in start.iter_mut().enumerate().take(config.robot.axis_count()) {
        *s = fb.axes[i].commanded;
    }
    let mut generator = Generator::new(config.robot.clone(), config.motion).unwrap();
    generator.set_position_pulses(&start).unwrap();
    let shared = Arc::new(Shared::default());
    for (c, s) in shared.commanded.iter().zip(start) {
        c.store(s, Ordering::Release);
    }
    let (mut ring, ring_rx) = spsc::channel::<Batch>(12);
    let (resume, _resume_rx) = mailbox(generator.state());
    let urgent = Arc::new(MessageQueue::new(8));
    let heartbeat_periods = config.boards[0].heartbeat_periods;
    let mut pg = PulseGenerator::new(
        board,
        ring_rx,
        shared.clone(),
        Arc::new(MessageQueue::new(8)),
        resume,
        generator.clone(),
    )
    .with_liveness(Liveness::new(
        heartbeat_periods,
        10_000,
        10_000,
        urgent.clone(),
        Arc::new(Semaphore::new(0)),
    ));

    // The board runs, then stops (its heartbeat stands): the Pulse Generator detaches.
    for _ in 0..5 {
        pg.step();
        sim.step();
    }
    assert!(!shared.board_dead.load(Ordering::Acquire));
    for _ in 0..10 {
        pg.step();
    }
    assert!(shared.board_dead.load(Ordering::Acquire));
    assert!(urgent.try_recv().is_ok(), "error 300 reported");

    // The urgent path requests the fault's stop; the Pulse Generator takes it at once.
    let cut = shared.stop_epoch.load(Ordering::Acquire);
    shared.request_stop(StopKind::Estop);
    pg.step_released(Release::Event);
    let stand_still = |s: &Shared| {
        s.in_flight.load(Ordering::Acquire) == 0
            && s.stopped_epoch.load(Ordering::Acquire) == s.stop_epoch.load(Ordering::Acquire)
    };
    assert!(stand_still(&shared));

    // The Velocity Generator's cycle that began before the stop pushes one more period of
    // the move the fault cut.
    let mut pulses = [0i64; MAX_AXES];
    pulses[0] = 1_800;
    ring.try_send(Batch {
        pulses,
        epoch: cut,
        ticket: 7,
        last: false,
        after: generator.state(),
    })
    .unwrap();
    for _ in 0..3 {
        pg.step();
    }
    assert!(
        stand_still(&shared),
        "in flight {} with the board dead: RESET would be refused for ever",
        shared.in_flight.load(Ordering::Acquire)
    );
}
