//! Runs a [`SimBoard`] at its board clock: one [`SimBoard::step`] per period on absolute
//! deadlines. The clock is injected ([`Clock`]) so the loop can be tested without sleeping.
//! When the process is scheduled late the board catches up by stepping the missed periods
//! (a DSP's clock does not wait for the host) and counts them; after more than
//! [`MAX_CATCH_UP`] missed periods it starts a new schedule from now instead.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use super::SimBoard;

/// Most periods caught up at once [periods].
pub const MAX_CATCH_UP: u32 = 100;

/// A monotonic clock the runner sleeps on.
pub trait Clock {
    /// Time since an arbitrary fixed start.
    fn now(&self) -> Duration;
    /// Sleep until `now() >= deadline`.
    fn sleep_until(&self, deadline: Duration);
}

/// The operating system's monotonic clock.
#[derive(Debug, Clone, Copy)]
pub struct SystemClock(Instant);

impl Default for SystemClock {
    fn default() -> Self {
        SystemClock(Instant::now())
    }
}

impl Clock for SystemClock {
    fn now(&self) -> Duration {
        self.0.elapsed()
    }
    fn sleep_until(&self, deadline: Duration) {
        let now = self.now();
        if deadline > now {
            std::thread::sleep(deadline - now);
        }
    }
}

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
    let period = Duration::from_micros(u64::from(board.period_us()));
    let mut deadline = clock.now();
    let mut stepped = 0u64;
    while !stop.load(Ordering::Relaxed) && max_periods.is_none_or(|m| stepped < m) {
        board.step();
        after_step(board);
        stepped += 1;
        deadline += period;
        let now = clock.now();
        if now >= deadline + period {
            let behind = ((now - deadline).as_nanos() / period.as_nanos()) as u32;
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
        clock.sleep_until(deadline);
    }
    stepped
}

#[cfg(test)]
mod tests {
    use std::cell::Cell;

    use super::*;
    use crate::driver::Mapping;
    use crate::layout::control;
    use crate::sim::tests::settings;

    /// A clock that advances only when slept on, plus a scripted stall.
    struct MockClock {
        now: Cell<Duration>,
        stall_at: Duration,
        stall: Duration,
    }

    impl Clock for MockClock {
        fn now(&self) -> Duration {
            self.now.get()
        }
        fn sleep_until(&self, deadline: Duration) {
            let mut t = deadline.max(self.now.get());
            if t >= self.stall_at && self.now.get() < self.stall_at {
                t += self.stall;
            }
            self.now.set(t);
        }
    }

    #[test]
    fn steps_one_period_per_period_and_catches_up_after_a_stall() {
        let mut board = SimBoard::new(Mapping::anonymous().unwrap(), &settings(), 1).unwrap();
        let clock = MockClock {
            now: Cell::new(Duration::ZERO),
            stall_at: Duration::from_millis(100),
            stall: Duration::from_millis(55),
        };
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
        let clock = MockClock {
            now: Cell::new(Duration::ZERO),
            stall_at: Duration::from_millis(100),
            stall: Duration::from_millis(55),
        };
        let mut seen = Vec::new();
        let stepped = run_with(&mut board, &clock, &AtomicBool::new(false), Some(30), |b| {
            seen.push(b.dpram().load64(control::PERIOD_COUNT))
        });
        assert_eq!(seen, (1..=stepped).collect::<Vec<_>>());
    }
}
