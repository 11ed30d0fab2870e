//! The loop body of one task thread, apart from the thread: sleep to the grid point, run the
//! cycle, measure it, move the grid, record statistics, queue an overrun event.
//!
//! Generic over the [`Clock`], so the same code that runs on a SCHED_FIFO thread runs against
//! a [`crate::MockClock`] in tests. [`TaskDriver::step`] does not allocate, lock or print.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use crate::clock::Clock;
use crate::notice::RtEvent;
use crate::schedule::Schedule;
use crate::stats::{CycleSample, StatsCell};
use crate::task::{CycleContext, Task};

/// Capacity of each task's event queue to the reporter.
pub const EVENT_QUEUE_CAPACITY: usize = 64;

/// Whether the loop goes on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    /// A cycle ran; call `step` again.
    Ran,
    /// A stop was requested; the task is done.
    Stopped,
}

/// One task's periodic loop on a given clock.
pub struct TaskDriver<C: Clock, T: Task> {
    clock: C,
    task: T,
    schedule: Schedule,
    stats: Arc<StatsCell>,
    events: rtrb::Producer<RtEvent>,
    stop: Arc<AtomicBool>,
    previous_wake_ns: Option<u64>,
}

impl<C: Clock, T: Task> TaskDriver<C, T> {
    /// A driver whose first wake-up is at `first_wake_ns` [ns], every `period_ns` [ns].
    pub fn new(
        clock: C,
        task: T,
        first_wake_ns: u64,
        period_ns: u64,
        stats: Arc<StatsCell>,
        events: rtrb::Producer<RtEvent>,
        stop: Arc<AtomicBool>,
    ) -> Self {
        TaskDriver {
            clock,
            task,
            schedule: Schedule::new(first_wake_ns, period_ns),
            stats,
            events,
            stop,
            previous_wake_ns: None,
        }
    }

    /// Sleep until the next grid point and run one cycle, unless a stop was requested.
    pub fn step(&mut self) -> Step {
        if self.stop.load(Ordering::Acquire) {
            return Step::Stopped;
        }
        let scheduled_ns = self.schedule.next_wake_ns();
        self.clock.sleep_until_ns(scheduled_ns);
        // A stop requested while asleep ends the task before another cycle starts.
        if self.stop.load(Ordering::Acquire) {
            return Step::Stopped;
        }
        let woke_ns = self.clock.now_ns();
        let ctx = CycleContext {
            cycle: self.schedule.cycles(),
            scheduled_ns,
            woke_ns,
            period_ns: self.schedule.period_ns(),
        };
        self.task.cycle(&ctx);
        let end_ns = self.clock.now_ns();
        let outcome = self.schedule.end_cycle(end_ns);
        let sample = CycleSample {
            period_ns: self.previous_wake_ns.map(|p| woke_ns.saturating_sub(p)),
            exec_ns: end_ns.saturating_sub(woke_ns),
            latency_ns: woke_ns.saturating_sub(scheduled_ns),
            overrun: outcome.overrun,
            missed_periods: outcome.missed_periods,
        };
        self.previous_wake_ns = Some(woke_ns);
        self.stats.record(&sample);
        if outcome.overrun {
            // A full queue only loses the itemised event; the count is in the statistics.
            let _ = self.events.push(RtEvent::Overrun {
                cycle: ctx.cycle,
                latency_ns: sample.latency_ns,
                exec_ns: sample.exec_ns,
                missed_periods: outcome.missed_periods,
            });
        }
        Step::Ran
    }

    /// The grid (cycles, overruns, next wake-up).
    pub fn schedule(&self) -> &Schedule {
        &self.schedule
    }

    /// The task.
    pub fn task_mut(&mut self) -> &mut T {
        &mut self.task
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::MockClock;

    fn driver<T: Task>(
        clock: &MockClock,
        task: T,
        period_ns: u64,
    ) -> (
        TaskDriver<MockClock, T>,
        Arc<StatsCell>,
        rtrb::Consumer<RtEvent>,
        Arc<AtomicBool>,
    ) {
        let stats = Arc::new(StatsCell::new());
        let (tx, rx) = rtrb::RingBuffer::new(EVENT_QUEUE_CAPACITY);
        let stop = Arc::new(AtomicBool::new(false));
        let d = TaskDriver::new(
            clock.clone(),
            task,
            clock.now_ns() + period_ns,
            period_ns,
            stats.clone(),
            tx,
            stop.clone(),
        );
        (d, stats, rx, stop)
    }

    #[test]
    fn wakes_on_the_grid_and_measures_exec_and_period() {
        let clock = MockClock::new(1_000);
        let c = clock.clone();
        let mut wakes = Vec::new();
        let (mut d, stats, mut rx, _) = driver(
            &clock,
            move |ctx: &CycleContext| c.advance_ns(100 + ctx.cycle),
            1_000,
        );
        for _ in 0..5 {
            wakes.push(d.schedule().next_wake_ns());
            assert_eq!(d.step(), Step::Ran);
        }
        assert_eq!(wakes, [2_000, 3_000, 4_000, 5_000, 6_000]);
        let s = stats.snapshot();
        assert_eq!((s.cycles, s.overruns), (5, 0));
        assert_eq!((s.exec.min_ns(), s.exec.max_ns()), (Some(100), Some(104)));
        assert_eq!(
            (s.period.min_ns(), s.period.max_ns()),
            (Some(1_000), Some(1_000))
        );
        assert_eq!(s.latency.max_ns(), Some(0));
        assert!(rx.pop().is_err());
    }

    #[test]
    fn an_overlong_cycle_is_counted_reported_and_not_replayed() {
        let clock = MockClock::new(0);
        let c = clock.clone();
        // Cycle 2 takes 3.5 periods.
        let task = move |ctx: &CycleContext| c.advance_ns(if ctx.cycle == 2 { 3_500 } else { 10 });
        let (mut d, stats, mut rx, _) = driver(&clock, task, 1_000);
        let mut wakes = Vec::new();
        for _ in 0..6 {
            wakes.push(d.schedule().next_wake_ns());
            d.step();
        }
        // Woke at 3000, ended 6500: points 4000, 5000, 6000 are skipped, not run back to back.
        assert_eq!(wakes, [1_000, 2_000, 3_000, 7_000, 8_000, 9_000]);
        let s = stats.snapshot();
        assert_eq!((s.cycles, s.overruns, s.missed_periods), (6, 1, 3));
        assert_eq!(
            rx.pop(),
            Ok(RtEvent::Overrun {
                cycle: 2,
                latency_ns: 0,
                exec_ns: 3_500,
                missed_periods: 3
            })
        );
    }

    #[test]
    fn a_late_wake_up_past_the_next_point_is_an_overrun() {
        let clock = MockClock::new(0);
        let c = clock.clone();
        let (mut d, stats, _rx, _) = driver(&clock, move |_: &CycleContext| c.advance_ns(5), 1_000);
        d.step();
        // The thread was held off for 2.2 periods before its next wake-up.
        clock.set_ns(4_200);
        d.step();
        let s = stats.snapshot();
        assert_eq!((s.overruns, s.missed_periods), (1, 2));
        assert_eq!(s.latency.max_ns(), Some(2_200));
        assert_eq!(d.schedule().next_wake_ns(), 5_000);
    }

    #[test]
    fn stop_ends_the_loop_before_the_next_cycle() {
        let clock = MockClock::new(0);
        let (mut d, stats, _rx, stop) = driver(&clock, |_: &CycleContext| {}, 1_000);
        assert_eq!(d.step(), Step::Ran);
        stop.store(true, Ordering::Release);
        assert_eq!(d.step(), Step::Stopped);
        assert_eq!(stats.snapshot().cycles, 1);
    }
}
