//! RESET: answered once the board has carried it out and reports no fault. A board that
//! does not answer (its heartbeat stands) refuses it at once with 300; once it runs again
//! (restarted, on the same DPRAM), RESET re-attaches it: the Pulse Generator takes its
//! position and pushes again. A RESET sent while a stop (an ESTOP, a fault, STOP, HOLD)
//! still brakes waits for the arm to stand still, then is carried out or refused as at
//! rest; one sent while the arm moves with no stop under way is refused (121).
//!
//! Real-time promise: as the rest of the task — the wait is a state with a deadline, never
//! a blocking call.

use std::sync::atomic::Ordering;

use wrc_board::layout::board_status;
use wrc_board::MotionBoard;
use wrc_protocol::{Code, ReplyTo};

use super::{deliver, CommandInterpreter, RESET_REST_TIMEOUT_NS, RESET_TIMEOUT_NS};
use crate::messages::SourceId;
use crate::shared::{RobotState, StopKind};

/// What a RESET not answered yet waits for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum ResetPhase {
    /// A stop's brake to end (the arm to stand still).
    Rest,
    /// The board to carry the RESET out.
    Board,
}

/// A RESET not answered yet: who asked, what it waits for, and when it is refused [ns].
#[derive(Debug, Clone, Copy)]
pub(super) struct PendingReset {
    from: SourceId,
    to: ReplyTo,
    phase: ResetPhase,
    deadline: u64,
}

impl<B: MotionBoard> CommandInterpreter<B> {
    /// `RESET`: carried out now, or once a stop's brake has ended; refused otherwise.
    pub(super) fn reset_request(&mut self, from: SourceId, to: ReplyTo) {
        if self.reset_pending.is_some() {
            return self.nak(from, to, Code::Busy, "a RESET is already in progress");
        }
        if !self.stands_still() && self.stop_under_way() {
            // Answered once the arm stands still (`finish_reset`), as at rest then.
            self.reset_pending = Some(PendingReset {
                from,
                to,
                phase: ResetPhase::Rest,
                deadline: self.now_ns.saturating_add(RESET_REST_TIMEOUT_NS),
            });
            return;
        }
        if let Err((code, text)) = self.begin_reset(from, to) {
            self.nak(from, to, code, text);
        }
    }

    /// Whether a stop requested is still braking (the Pulse Generator has not brought its
    /// epoch to rest).
    fn stop_under_way(&self) -> bool {
        self.shared.stopped_epoch.load(Ordering::Acquire)
            != self.shared.stop_epoch.load(Ordering::Acquire)
    }

    /// Ask the board to clear its faults, after the checks a RESET needs; answered by
    /// `finish_reset` once the board has.
    fn begin_reset(&mut self, from: SourceId, to: ReplyTo) -> Result<(), (Code, &'static str)> {
        if self.shared.board_dead.load(Ordering::Acquire) {
            return Err((
                Code::BoardLost,
                "the motion board does not answer (its heartbeat stands); RESET once it runs again",
            ));
        }
        if let Some(input) = self.estop_input {
            if self.shared.inputs[0].load(Ordering::Acquire) & (1u32 << input) != 0 {
                return Err((
                    Code::InEstop,
                    "the E-stop input is still open; close it, then RESET",
                ));
            }
        }
        // The board re-reads its position at a RESET: only once it has executed every
        // period pushed and stands still.
        if !self.stands_still() {
            return Err((Code::Busy, "the robot is still moving; STOP and WAIT first"));
        }
        if self.board.reset().is_err() {
            return Err((
                Code::Busy,
                "the board is busy with a previous command; repeat RESET",
            ));
        }
        // Answered once the board has carried it out and reports no fault (see
        // `finish_reset`), so Error Check never sees the fault of before the RESET.
        self.reset_pending = Some(PendingReset {
            from,
            to,
            phase: ResetPhase::Board,
            deadline: self.now_ns.saturating_add(RESET_TIMEOUT_NS),
        });
        Ok(())
    }

    /// A RESET that waited for a stop's brake: carry it out once the arm stands still, or
    /// refuse it when the stop has not ended by its deadline.
    fn reset_after_rest(&mut self, p: PendingReset) {
        let refused = if self.stands_still() {
            self.reset_pending = None;
            self.begin_reset(p.from, p.to).err()
        } else if self.now_ns >= p.deadline {
            self.reset_pending = None;
            Some((
                Code::Busy,
                "the stop under way did not end within 5 s (the robot still moves); WAIT for it, then RESET",
            ))
        } else {
            None
        };
        if let Some((code, text)) = refused {
            self.nak(p.from, p.to, code, text);
            if p.from == SourceId::PROGRAM {
                self.program_reset_done(Some((code, text)));
            }
        }
    }

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
        let Some(p) = self.reset_pending else {
            return;
        };
        if p.phase == ResetPhase::Rest {
            self.reset_after_rest(p);
            // Carried out now: answered once the board has (a later cycle).
            return;
        }
        let (from, to, deadline) = (p.from, p.to, p.deadline);
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
