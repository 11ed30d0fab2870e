//! The periodic grid of one task: when to wake next, and what counts as an overrun.
//!
//! A plain struct with no clock and no threads, so the timing rules are tested against
//! made-up times. Wake-ups stay on the absolute grid `start + k × period` (no drift); when a
//! cycle ends after one or more grid points have passed, those periods are counted as missed
//! and skipped, never replayed in a burst.

/// What happened to one cycle, decided when it ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CycleOutcome {
    /// The cycle ended after the next grid point: it overran its period.
    pub overrun: bool,
    /// Grid points skipped because the cycle ended after them (0 without an overrun).
    pub missed_periods: u64,
    /// The absolute time the task sleeps until next [ns].
    pub next_wake_ns: u64,
}

/// The absolute wake-up grid of one periodic task.
///
/// ```
/// use wrc_rt::Schedule;
/// let mut grid = Schedule::new(1_000, 100);
/// assert_eq!(grid.next_wake_ns(), 1_000);
/// // A cycle that woke at 1 000 and ended at 1 030 is on time: the next wake is 1 100.
/// assert_eq!(grid.end_cycle(1_030).next_wake_ns, 1_100);
/// // A cycle that ends at 1 350 missed the points 1 200 and 1 300; it resumes at 1 400.
/// let late = grid.end_cycle(1_350);
/// assert!(late.overrun);
/// assert_eq!((late.missed_periods, late.next_wake_ns), (2, 1_400));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Schedule {
    period_ns: u64,
    next_wake_ns: u64,
    cycles: u64,
    overruns: u64,
    missed_periods: u64,
}

impl Schedule {
    /// A grid whose first wake-up is at `first_wake_ns` [ns], every `period_ns` [ns] (> 0).
    pub fn new(first_wake_ns: u64, period_ns: u64) -> Schedule {
        assert!(period_ns > 0, "a period must be longer than 0 ns");
        Schedule {
            period_ns,
            next_wake_ns: first_wake_ns,
            cycles: 0,
            overruns: 0,
            missed_periods: 0,
        }
    }

    /// The period [ns].
    pub fn period_ns(&self) -> u64 {
        self.period_ns
    }

    /// The grid point the task sleeps until next [ns].
    pub fn next_wake_ns(&self) -> u64 {
        self.next_wake_ns
    }

    /// The cycle that was woken at [`Schedule::next_wake_ns`] ended at `end_ns` [ns]: move to
    /// the next grid point that lies after `end_ns`.
    pub fn end_cycle(&mut self, end_ns: u64) -> CycleOutcome {
        self.cycles += 1;
        let mut next = self.next_wake_ns + self.period_ns;
        let mut missed = 0;
        if end_ns >= next {
            // The grid points next, next + period, … up to end_ns have passed: skip them all.
            missed = (end_ns - next) / self.period_ns + 1;
            next += missed * self.period_ns;
            self.overruns += 1;
            self.missed_periods += missed;
        }
        self.next_wake_ns = next;
        CycleOutcome {
            overrun: missed > 0,
            missed_periods: missed,
            next_wake_ns: next,
        }
    }

    /// Cycles ended so far.
    pub fn cycles(&self) -> u64 {
        self.cycles
    }

    /// Cycles that overran their period so far.
    pub fn overruns(&self) -> u64 {
        self.overruns
    }

    /// Grid points skipped so far.
    pub fn missed_periods(&self) -> u64 {
        self.missed_periods
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn on_time_cycles_stay_on_the_grid_without_drift() {
        let period = 10_000_000;
        let mut grid = Schedule::new(5, period);
        for k in 1..=100_000u64 {
            // Each cycle ends somewhere inside its period: the grid must not drift with it.
            let woke = grid.next_wake_ns();
            let out = grid.end_cycle(woke + (k * 7919) % (period - 1));
            assert!(!out.overrun);
            assert_eq!(out.next_wake_ns, 5 + k * period);
        }
        assert_eq!(
            (grid.cycles(), grid.overruns(), grid.missed_periods()),
            (100_000, 0, 0)
        );
    }

    #[test]
    fn ending_exactly_on_the_next_point_is_an_overrun() {
        let mut grid = Schedule::new(0, 100);
        let out = grid.end_cycle(100);
        assert_eq!(
            out,
            CycleOutcome {
                overrun: true,
                missed_periods: 1,
                next_wake_ns: 200
            }
        );
    }

    #[test]
    fn overruns_skip_missed_points_and_do_not_replay_them() {
        let mut grid = Schedule::new(0, 100);
        let out = grid.end_cycle(450);
        assert_eq!(
            out,
            CycleOutcome {
                overrun: true,
                missed_periods: 4,
                next_wake_ns: 500
            }
        );
        // After the catch-up the task is back on the same grid, one cycle per period.
        assert_eq!(grid.end_cycle(510).next_wake_ns, 600);
        assert_eq!(grid.end_cycle(620).next_wake_ns, 700);
        assert_eq!(
            (grid.cycles(), grid.overruns(), grid.missed_periods()),
            (3, 1, 4)
        );
    }

    #[test]
    fn a_late_wake_up_with_a_short_cycle_is_not_an_overrun() {
        // Woken 90 ns late but finished before the next point: late, not overrun.
        let mut grid = Schedule::new(0, 100);
        assert!(!grid.end_cycle(95).overrun);
        assert_eq!(grid.next_wake_ns(), 100);
    }
}
