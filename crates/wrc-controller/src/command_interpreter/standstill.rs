//! When a stop has ended: the arm stands still on the board. The Pulse Generator reports a
//! stop's brake (the move `Stopped` or `Held`, the stop epoch at rest, nothing in flight) as
//! soon as it has pushed the brake's last period; the board then still executes the periods
//! queued ahead of it ([`FIFO_LEAD`]) and its servos catch up. A stop ends — the state `IDLE`
//! or `HELD`, `WAIT`'s reply, a move end reported during the brake, `RESET` accepted — by the
//! rule a completed move ends by: the board has executed every period pushed (its commanded
//! count is the Pulse Generator's on every axis) and every encoder is on its commanded count;
//! or the settling time a completed move is given is over (an alarmed axis that discards its
//! periods, a stuck encoder: Error Check reports those, the end is not held up for ever).
//!
//! A plain struct: the caller passes the Pulse Generator's state, the time and the board's
//! feedback in, so tests drive it with made-up values. No allocation, no blocking.

use wrc_board::Feedback;

use crate::pulse_generator::{FIFO_LEAD, IN_POSITION_PERIODS};

/// Which stop has ended on the board, and since when the newer one has been waited for.
#[derive(Debug, Clone, Copy)]
pub(super) struct Standstill {
    /// The newest stop epoch whose end the board has shown.
    settled: u32,
    /// The stop epoch the Pulse Generator was first seen at rest in, and when [ns], while
    /// the board has not shown its end yet.
    waiting: Option<(u32, u64)>,
    /// How long the board may take after that to stand still before the stop counts as
    /// ended anyway [ns]: as long as a completed move may take from its last period pushed
    /// to its end ([`FIFO_LEAD`] + 1 + [`IN_POSITION_PERIODS`] board periods).
    settle_ns: u64,
}

impl Standstill {
    /// At rest in stop epoch `epoch`, on a board whose period is `period_us` [µs].
    pub(super) fn new(epoch: u32, period_us: u32) -> Standstill {
        let periods = (FIFO_LEAD + 1 + IN_POSITION_PERIODS) as u64;
        Standstill {
            settled: epoch,
            waiting: None,
            settle_ns: periods * u64::from(period_us) * 1_000,
        }
    }

    /// Whether a stop of epoch `epoch` (the current one) has not ended on the board yet.
    pub(super) fn stopping(&self, epoch: u32) -> bool {
        self.settled != epoch
    }

    /// Whether the arm stands still at `now_ns` [ns] in stop epoch `epoch`: the Pulse
    /// Generator is at rest in that epoch with nothing in flight (`generator_at_rest`) and,
    /// if that epoch's stop has not ended on the board yet, `board_at_rest()` says it has
    /// now (or the settling time since the Pulse Generator came to rest is over).
    pub(super) fn update(
        &mut self,
        epoch: u32,
        generator_at_rest: bool,
        now_ns: u64,
        board_at_rest: impl FnOnce() -> bool,
    ) -> bool {
        if !generator_at_rest {
            self.waiting = None;
            return false;
        }
        if self.settled == epoch {
            return true;
        }
        let since = match self.waiting {
            Some((e, since)) if e == epoch => since,
            _ => {
                self.waiting = Some((epoch, now_ns));
                now_ns
            }
        };
        if board_at_rest() || now_ns.saturating_sub(since) >= self.settle_ns {
            self.settled = epoch;
            self.waiting = None;
            return true;
        }
        false
    }
}

/// Whether the board stands where the pulses pushed to it lead: on every axis it reports, its
/// commanded count is `pushed` (every period pushed has been executed) and its encoder is on
/// it (the servo has caught up) [pulse].
pub(super) fn board_at_rest(feedback: &Feedback, pushed: &[i64]) -> bool {
    feedback.axes[..feedback.axis_count]
        .iter()
        .zip(pushed)
        .all(|(a, &p)| a.commanded == p && a.encoder == p)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: u64 = 1_000_000;

    #[test]
    fn a_stop_ends_when_the_board_stands_still_not_when_the_brake_is_pushed() {
        let mut s = Standstill::new(0, 10_000);
        assert!(s.update(0, true, 0, || unreachable!(
            "no stop: the board is not asked"
        )));
        // A stop (epoch 1): braking, then the brake pushed while the board executes it.
        assert!(s.stopping(1));
        assert!(!s.update(1, false, 10 * MS, || true));
        assert!(!s.update(1, true, 20 * MS, || false));
        assert!(!s.update(1, true, 30 * MS, || false));
        assert!(s.update(1, true, 40 * MS, || true));
        assert!(!s.stopping(1));
        // Ended: the board is not asked again, and a new motion is not at rest.
        assert!(s.update(1, true, 50 * MS, || unreachable!()));
        assert!(!s.update(1, false, 60 * MS, || unreachable!()));
    }

    #[test]
    fn a_board_that_never_settles_ends_the_stop_after_a_completed_moves_settling_time() {
        let mut s = Standstill::new(4, 10_000);
        let settle = (FIFO_LEAD + 1 + IN_POSITION_PERIODS) as u64 * 10 * MS;
        assert!(!s.update(5, true, 1_000 * MS, || false));
        assert!(!s.update(5, true, 1_000 * MS + settle - 1, || false));
        assert!(s.update(5, true, 1_000 * MS + settle, || false));
        // A newer stop waits from when the Pulse Generator came to rest in it.
        assert!(!s.update(6, true, 3_000 * MS, || false));
        assert!(!s.update(6, false, 3_000 * MS + settle, || false));
        assert!(!s.update(6, true, 3_000 * MS + settle + 1, || false));
        assert!(s.update(6, true, 3_000 * MS + 2 * settle + 1, || false));
    }

    #[test]
    fn the_board_is_at_rest_once_it_executed_every_pulse_and_the_encoders_caught_up() {
        let mut fb = Feedback {
            axis_count: 2,
            ..Feedback::default()
        };
        fb.axes[0].commanded = 100;
        fb.axes[0].encoder = 100;
        fb.axes[1].commanded = -7;
        fb.axes[1].encoder = -6;
        assert!(!board_at_rest(&fb, &[100, -7]), "the servo lags");
        fb.axes[1].encoder = -7;
        assert!(board_at_rest(&fb, &[100, -7]));
        assert!(!board_at_rest(&fb, &[103, -7]), "periods still queued");
    }
}
