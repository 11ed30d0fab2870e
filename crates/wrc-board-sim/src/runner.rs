//! Runs a [`SimBoard`] at its board clock: one [`SimBoard::step`] per period on absolute
//! deadlines. The clock is injected (the runtime's [`Clock`]: `CLOCK_MONOTONIC` and absolute
//! `clock_nanosleep` in the process, a scripted one in tests) so the loop can be tested
//! without sleeping.
//! When the process is scheduled late the board catches up by stepping the missed periods
//! (a DSP's clock does not wait for the host) and counts them; after more than
//! [`MAX_CATCH_UP`] missed periods it starts a new schedule from now instead.

use std::sync::atomic::{AtomicBool, Ordering};

pub use wrc_rt::{Clock, MonotonicClock};

use super::SimBoard;

/// Most periods caught up at once [periods].
pub const MAX_CATCH_UP: u32 = 100;

/// Step `board` every board period until `stop` is set or `max_periods` periods ran;
/// returns the periods stepped.
pub fn run(
    board: &mut SimBoard,
    clock: &impl Clock,
    stop: &AtomicBool,
    max_periods: Option<u64>,
) -> u64 {
    run_with(board, clock, stop, max_periods, |_| {})
}

/// [`run`], calling `after_step` after every [`SimBoard::step`] (caught-up periods too),
/// outside the step: the place to take the simulated cell's event
/// ([`SimBoard::take_cell_event`]) and hand it to a non-real-time thread. It must not
/// block.
pub fn run_with(
    board: &mut SimBoard,
    clock: &impl Clock,
    stop: &AtomicBool,
    max_periods: Option<u64>,
    mut after_step: impl FnMut(&mut SimBoard),
) -> u64 {
    let period = u64::from(board.period_us()) * 1000;
    let mut deadline = clock.now_ns();
    let mut stepped = 0u64;
    while !stop.load(Ordering::Relaxed) && max_periods.is_none_or(|m| stepped < m) {
        board.step();
        after_step(board);
        stepped += 1;
        deadline += period;
        let now = clock.now_ns();
        if now >= deadline + period {
            let behind = u32::try_from((now - deadline) / period).unwrap_or(u32::MAX);
            if behind > MAX_CATCH_UP {
                board.note_late();
                deadline = now;
            } else {
                for _ in 0..behind {
                    board.note_late();
                    board.step();
                    after_step(board);
                    stepped += 1;
                    deadline += period;
                }
            }
        }
        clock.sleep_until_ns(deadline);
    }
    stepped
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::AtomicU64;

    use super::*;
    use crate::tests::settings;
    use wrc_board::driver::Mapping;
    use wrc_board::layout::control;

    /// A clock that advances only when slept on, plus a scripted stall [ns].
    struct StallClock {
        now: AtomicU64,
        stall_at: u64,
        stall: u64,
    }

    impl StallClock {
        /// From 0; sleeping past `stall_at_ms` oversleeps by `stall_ms`.
        fn new(stall_at_ms: u64, stall_ms: u64) -> StallClock {
            StallClock {
                now: AtomicU64::new(0),
                stall_at: stall_at_ms * 1_000_000,
                stall: stall_ms * 1_000_000,
            }
        }
    }

    impl Clock for StallClock {
        fn now_ns(&self) -> u64 {
            self.now.load(Ordering::Relaxed)
        }
        fn sleep_until_ns(&self, deadline: u64) {
            let now = self.now_ns();
            let mut t = deadline.max(now);
            if t >= self.stall_at && now < self.stall_at {
                t += self.stall;
            }
            self.now.store(t, Ordering::Relaxed);
        }
    }

    #[test]
    fn steps_one_period_per_period_and_catches_up_after_a_stall() {
        let mut board = SimBoard::new(Mapping::anonymous().unwrap(), &settings(), 1).unwrap();
        let clock = StallClock::new(100, 55);
        let stop = AtomicBool::new(false);
        let stepped = run(&mut board, &clock, &stop, Some(30));
        assert!(stepped >= 30);
        // A 55 ms stall at 10 ms periods from t = 100 ms: the periods due at 110 to 140 ms
        // are stepped at once and counted; the one due at 150 ms starts within its period.
        assert_eq!(board.dpram().load(control::LATE_PERIODS), 4);
        assert_eq!(board.dpram().load64(control::PERIOD_COUNT), stepped);
    }

    #[test]
    fn the_hook_sees_every_period_caught_up_ones_too() {
        let mut board = SimBoard::new(Mapping::anonymous().unwrap(), &settings(), 1).unwrap();
        let clock = StallClock::new(100, 55);
        let mut seen = Vec::new();
        let stepped = run_with(&mut board, &clock, &AtomicBool::new(false), Some(30), |b| {
            seen.push(b.dpram().load64(control::PERIOD_COUNT))
        });
        assert_eq!(seen, (1..=stepped).collect::<Vec<_>>());
    }
}
