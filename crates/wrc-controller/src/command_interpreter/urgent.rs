//! The urgent path: STOP, ESTOP and Error Check's faults overtake everything. A thread
//! ([`UrgentPath`]) requests the stop the moment the semaphore is posted; the Command
//! Interpreter's cycle then answers and sets the state.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use wrc_board::MotionBoard;
use wrc_protocol::{Code, Event};
use wrc_rt::ipc::{MessageQueue, Semaphore};

use super::{deliver, CommandInterpreter};
use crate::messages::Urgent;
use crate::shared::{RobotState, Shared};

/// The blocking half of the urgent path: a thread that waits on the semaphore, takes each
/// emergency off the urgent queue, requests its stop at once (the kind decides the brake:
/// [`Urgent::stop_kind`]; the E-stop input's the Pulse Generator has asked for) and forwards it to the Command Interpreter for the replies.
pub struct UrgentPath {
    /// The semaphore the receiving tasks post.
    pub wake: Arc<Semaphore>,
    /// The emergencies, as the receiving tasks sent them.
    pub urgent: Arc<MessageQueue<Urgent>>,
    /// The same, once their stop is requested, for the Command Interpreter's bookkeeping.
    pub forwarded: Arc<MessageQueue<Urgent>>,
    /// The shared state whose stop epoch it bumps.
    pub shared: Arc<Shared>,
    /// Ends the thread.
    pub quit: Arc<AtomicBool>,
}

impl UrgentPath {
    /// Run until `quit`: every emergency requests one stop.
    pub fn run(self) {
        while !self.quit.load(Ordering::Acquire) {
            if self.wake.wait_timeout(Duration::from_millis(100)) {
                self.forward();
            }
        }
    }

    /// Take every count the semaphore holds and request the stop of every emergency queued
    /// (under virtual time, where this is a task released by the semaphore's count).
    pub fn drain(&self) {
        while self.wake.try_wait() {}
        self.forward();
    }

    fn forward(&self) {
        while let Ok(urgent) = self.urgent.try_recv() {
            if let Some(kind) = urgent.stop_kind() {
                self.shared.request_stop(kind);
            }
            // Sized like the urgent queue: a message taken from it always fits.
            let _ = self.forwarded.try_send(urgent);
        }
    }
}

impl<B: MotionBoard> CommandInterpreter<B> {
    /// The bookkeeping of an emergency whose stop is already requested: replies, aborts,
    /// state.
    pub(super) fn handle_urgent(&mut self, urgent: Urgent) {
        match urgent {
            Urgent::Stop(from, to) => {
                let line = self.buf.ack(to, "");
                deliver(&self.io.out, from, line);
                if self.shared.state() == RobotState::Moving {
                    self.set_state(RobotState::Stopping);
                }
                self.abort_all(Code::Stopped, "stopped by STOP");
            }
            Urgent::Estop(from, to) => {
                let line = self.buf.ack(to, "");
                deliver(&self.io.out, from, line);
                self.abort_all(Code::EmergencyStop, "emergency stop");
                self.shared
                    .error_code
                    .store(u32::from(Code::EmergencyStop.number()), Ordering::Release);
                self.set_state(RobotState::Estop);
                self.event(&Event::Error {
                    code: Code::EmergencyStop,
                    text: "emergency stop; RESET to continue",
                });
            }
            Urgent::Fault(number) => {
                let code = Code::from_number(number).unwrap_or(Code::MotionFault);
                let text = code.text();
                self.abort_all(code, text);
                self.shared
                    .error_code
                    .store(u32::from(number), Ordering::Release);
                let state = if code == Code::EstopInput {
                    RobotState::Estop
                } else {
                    RobotState::Error
                };
                self.set_state(state);
                self.event(&Event::Error { code, text });
            }
        }
        self.planned_end = self.robot.pulses_to_joints(&self.shared.commanded_pulses());
    }

    /// An alarm of this task's own (its stop already requested) with a text that says more
    /// than the code's: every open motion ends with `ABS <code> <text>`, the state becomes
    /// ERROR (an ESTOP stays ESTOP: RESET must still see the E-stop released), and everyone
    /// is told (`EVT ERROR`).
    pub(super) fn fault(&mut self, code: Code, text: &str) {
        self.abort_all(code, text);
        self.shared
            .error_code
            .store(u32::from(code.number()), Ordering::Release);
        if self.shared.state() != RobotState::Estop {
            self.set_state(RobotState::Error);
        }
        self.event(&Event::Error { code, text });
        self.planned_end = self.robot.pulses_to_joints(&self.shared.commanded_pulses());
    }
}
