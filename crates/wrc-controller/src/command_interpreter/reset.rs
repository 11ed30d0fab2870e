//! RESET: answered once the board has carried it out and reports no fault. A board that
//! does not answer (its heartbeat stands) refuses it at once with 300; once it runs again
//! (restarted, on the same DPRAM), RESET re-attaches it: the Pulse Generator takes its
//! position and pushes again.

use std::sync::atomic::Ordering;

use wrc_board::layout::board_status;
use wrc_board::MotionBoard;
use wrc_protocol::Code;

use super::{deliver, CommandInterpreter};
use crate::shared::{RobotState, StopKind};

impl<B: MotionBoard> CommandInterpreter<B> {
    /// The fault the board still reports, if any (a torn read counts as not yet clear).
    pub(super) fn board_fault(&mut self) -> Option<&'static str> {
        if self.shared.board_dead.load(Ordering::Acquire) {
            return Some(
                "the motion board does not answer (its heartbeat stands); RESET once it runs again",
            );
        }
        if self.board.read_feedback(&mut self.feedback).is_err() {
            return Some("the board's feedback could not be read");
        }
        let fb = &self.feedback;
        for b in &fb.boards[..fb.board_count] {
            if b.status & board_status::ESTOP != 0 {
                return Some("the board still latches its E-stop");
            }
            if b.status & board_status::WATCHDOG_TRIPPED != 0 {
                return Some("the board's watchdog is still tripped");
            }
        }
        let n = self.robot.axis_count();
        if fb.axes[..n].iter().any(|a| a.alarm != 0) {
            return Some("an axis still reports an alarm");
        }
        None
    }

    /// Complete a pending RESET once the board has acted on it: ACK and IDLE when it reports
    /// no fault, NAK when it still does after [`super::RESET_TIMEOUT_NS`].
    pub(super) fn finish_reset(&mut self) {
        let Some((from, to, deadline)) = self.reset_pending else {
            return;
        };
        // A board that died meanwhile never carries it out: refused at once (board_fault).
        let dead = self.shared.board_dead.load(Ordering::Acquire);
        let fault = if !dead && self.board.command_pending() {
            Some("the board did not carry out the RESET")
        } else {
            self.board_fault()
        };
        match fault {
            None => {
                self.reset_pending = None;
                self.shared.resync_from_board.store(true, Ordering::Release);
                // Re-read the board's position (it may have stopped by itself) through a
                // stop request, which resynchronises the Pulse and Velocity Generators.
                self.shared.request_stop(StopKind::Stop);
                self.shared.error_code.store(0, Ordering::Release);
                let line = self.buf.ack(to, "");
                deliver(&self.io.out, from, line);
                self.set_state(RobotState::Idle);
                if from == crate::messages::SourceId::PROGRAM {
                    self.program_reset_done(None);
                }
            }
            Some(reason) if dead || self.now_ns >= deadline => {
                self.reset_pending = None;
                let code = if dead {
                    Code::BoardLost
                } else if self.shared.state() == RobotState::Estop {
                    Code::InEstop
                } else {
                    Code::InError
                };
                self.nak(from, to, code, reason);
                if from == crate::messages::SourceId::PROGRAM {
                    self.program_reset_done(Some((code, reason)));
                }
            }
            Some(_) => {}
        }
    }
}
