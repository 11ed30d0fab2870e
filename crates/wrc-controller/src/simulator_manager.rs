//! Simulator Manager task (Table 1: priority 25, 10 ms): every period, one versioned binary
//! UDP datagram with the robot's state (docs/simulator-stream.md) to the 3D simulator
//! (default `127.0.0.1:7200`). The socket is non-blocking: a full socket buffer or an absent
//! receiver drops the datagram, never delays the task.
//!
//! Real-time promise: one non-blocking `sendto` per cycle; no allocation, no printing.

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::Ordering;
use std::sync::Arc;

use wrc_board::{Feedback, MotionBoard};
use wrc_protocol::sim_stream::{encode, SimFrame, MAX_DATAGRAM_LEN};
use wrc_robot::{Robot, MAX_AXES};
use wrc_rt::{CycleContext, Task};

use crate::shared::Shared;

/// The Simulator Manager.
pub struct SimulatorManager<B: MotionBoard> {
    board: B,
    robot: Robot,
    shared: Arc<Shared>,
    socket: UdpSocket,
    to: SocketAddr,
    sequence: u64,
    feedback: Feedback,
    datagram: [u8; MAX_DATAGRAM_LEN],
    /// Datagrams the socket refused (no receiver, buffer full).
    pub dropped: u64,
}

impl<B: MotionBoard> SimulatorManager<B> {
    /// Send to `to` from a non-blocking `socket`.
    pub fn new(
        board: B,
        robot: Robot,
        shared: Arc<Shared>,
        socket: UdpSocket,
        to: SocketAddr,
    ) -> Self {
        SimulatorManager {
            board,
            robot,
            shared,
            socket,
            to,
            sequence: 0,
            feedback: Feedback::default(),
            datagram: [0; MAX_DATAGRAM_LEN],
            dropped: 0,
        }
    }

    /// One period at time `now_ns` (public for tests that step the task by hand).
    pub fn step(&mut self, now_ns: u64) {
        let pulses: [i64; MAX_AXES] = if self.board.read_feedback(&mut self.feedback).is_ok() {
            std::array::from_fn(|i| self.feedback.axes[i].encoder)
        } else {
            self.shared.commanded_pulses()
        };
        let mut positions = [0.0; MAX_AXES];
        for (i, a) in self.robot.axes().iter().enumerate() {
            positions[i] = a.pulses_to_units(pulses[i]);
        }
        let frame = SimFrame {
            sequence: self.sequence,
            timestamp_ns: now_ns,
            state: self.shared.state(),
            homed: self.shared.homed.load(Ordering::Acquire),
            inputs: self.shared.inputs[0].load(Ordering::Acquire),
            outputs: self.shared.outputs[0].load(Ordering::Acquire),
            tcp: self.robot.forward(&positions),
            axis_count: self.robot.axis_count(),
            positions,
            pulses,
        };
        self.sequence += 1;
        if let Ok(len) = encode(&frame, &mut self.datagram) {
            if self.socket.send_to(&self.datagram[..len], self.to).is_err() {
                self.dropped += 1;
            }
        }
    }
}

impl<B: MotionBoard + 'static> Task for SimulatorManager<B> {
    fn cycle(&mut self, ctx: &CycleContext) {
        self.step(ctx.woke_ns);
    }
}
