//! What the hand-stepped rigs of these tests share: the motion path — Velocity Generator →
//! pulse ring → Pulse Generator → board — at rest where the board stands, and simulated
//! boards to run it on.

use std::sync::atomic::Ordering;
use std::sync::Arc;

use wrc_board::{Feedback, Mapping, MotionBoard};
use wrc_board_sim::{SimBoard, SimSettings};
use wrc_config::{BoardConfig, Config};
use wrc_controller::messages::{MoveDone, MoveOrder};
use wrc_controller::pulse_generator::PulseGenerator;
use wrc_controller::shared::Shared;
use wrc_controller::velocity_generator::VelocityGenerator;
use wrc_motion::VelocityGenerator as Generator;
use wrc_rt::ipc::{mailbox, spsc, MessageQueue};

/// The simulated board `board` of `config`, one period run (its DPRAM initialised), and its
/// DPRAM to attach the tasks' views to.
pub fn sim_board(config: &Config, board: &BoardConfig) -> (SimBoard, Mapping) {
    let settings = SimSettings::from_config(config, board);
    let mapping = Mapping::anonymous().unwrap();
    let mut sim = SimBoard::new(mapping.share(), &settings, 1).unwrap();
    sim.step();
    (sim, mapping)
}

/// The motion path's tasks and the queues the rest of the controller reaches them by.
pub struct Motion<B: MotionBoard> {
    pub pg: PulseGenerator<B>,
    pub vg: VelocityGenerator,
    pub shared: Arc<Shared>,
    pub orders: Arc<MessageQueue<MoveOrder>>,
    pub done: Arc<MessageQueue<MoveDone>>,
}

impl<B: MotionBoard> Motion<B> {
    /// The robot of `config` homed and at rest where `board` stands (its commanded counts),
    /// the Pulse Generator on `board`.
    pub fn at_rest(config: &Config, board: B) -> Motion<B> {
        let mut fb = Feedback::default();
        board.read_feedback(&mut fb).unwrap();
        let mut start = [0i64; 16];
        for (i, s) in start.iter_mut().enumerate().take(config.robot.axis_count()) {
            *s = fb.axes[i].commanded;
        }
        let mut generator = Generator::new(config.robot.clone(), config.motion).unwrap();
        generator.set_position_pulses(&start).unwrap();
        let shared = Arc::new(Shared::default());
        for (c, s) in shared.commanded.iter().zip(start) {
            c.store(s, Ordering::Release);
        }
        shared.homed.store(true, Ordering::Release);
        let (ring_tx, ring_rx) = spsc::channel(12);
        let (resume_tx, resume_rx) = mailbox(generator.state());
        let orders = Arc::new(MessageQueue::new(32));
        let done = Arc::new(MessageQueue::new(64));
        let pg = PulseGenerator::new(
            board,
            ring_rx,
            shared.clone(),
            done.clone(),
            resume_tx,
            generator.clone(),
        );
        let vg = VelocityGenerator::new(
            generator,
            orders.clone(),
            ring_tx,
            shared.clone(),
            done.clone(),
            resume_rx,
        );
        Motion {
            pg,
            vg,
            shared,
            orders,
            done,
        }
    }
}
