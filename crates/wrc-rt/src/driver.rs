//! The loop body of one task thread, apart from the thread: sleep to the grid point (or, with
//! a [`Waiter`], until the grid point or an event), run the cycle, measure it, move the grid,
//! record statistics, queue an overrun event.
//!
//! Event release ([`TaskDriver::with_waiter`]): a wait that an event ends before the grid
//! point runs an **event cycle** ([`Release::Event`]). It does not move the grid: the next
//! periodic release stays on `origin + k × period`, and that grid point still releases its
//! own periodic cycle, even right after an event cycle — an event never takes a period's
//! place. A release at or after the grid point is the **periodic** cycle
//! ([`Release::Period`]) whatever ended the wait (the cycle does the event's work too; tasks
//! drain what is waiting each cycle). An event cycle that runs past the grid point makes the
//! periodic cycle that follows late: that shows as its wake-up latency and, past the next
//! point, as an overrun with skipped periods, exactly as a late wake-up would.
//!
//! Statistics: the periodic figures (cycles, period, execution time, wake-up latency,
//! overruns, missed periods) are recorded for periodic releases only, as for a task without
//! events; event cycles are counted and their execution times kept apart
//! ([`StatsCell::record_event`]).
//!
//! Generic over the [`Clock`] and the [`Waiter`], so the same code that runs on a SCHED_FIFO
//! thread runs against a [`crate::MockClock`] and a [`crate::wake::MockWaiter`] in tests.
//! [`TaskDriver::step`] does not allocate, lock or print.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use crate::clock::Clock;
use crate::notice::RtEvent;
use crate::schedule::Schedule;
use crate::stats::{CycleSample, StatsCell};
use crate::task::{CycleContext, Release, Task};
use crate::wake::{NoWaiter, Waiter};

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

/// One task's periodic loop on a given clock, released by its period only (`W` =
/// [`NoWaiter`]) or by its period or an event ([`TaskDriver::with_waiter`]).
pub struct TaskDriver<C: Clock, T: Task, W: Waiter = NoWaiter> {
    clock: C,
    task: T,
    waiter: Option<W>,
    schedule: Schedule,
    stats: Arc<StatsCell>,
    events: rtrb::Producer<RtEvent>,
    stop: Arc<AtomicBool>,
    previous_wake_ns: Option<u64>,
    /// The last periodic cycle's execution time [ns] ([`CycleContext::previous_exec_ns`]).
    previous_exec_ns: u64,
}

impl<C: Clock, T: Task> TaskDriver<C, T> {
    /// A driver whose first wake-up is at `first_wake_ns` [ns], every `period_ns` [ns],
    /// released by its period only.
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
            waiter: None,
            schedule: Schedule::new(first_wake_ns, period_ns),
            stats,
            events,
            stop,
            previous_wake_ns: None,
            previous_exec_ns: 0,
        }
    }
}

impl<C: Clock, T: Task, W: Waiter> TaskDriver<C, T, W> {
    /// The same driver (same grid, statistics and stop flag) released by its period or by an
    /// event from `waiter`, whichever comes first; any waiter it had is dropped. `waiter` must wait on the driver's clock (`CLOCK_MONOTONIC` for the real
    /// waiters).
    pub fn with_waiter<V: Waiter>(self, waiter: V) -> TaskDriver<C, T, V> {
        self.with_optional_waiter(Some(waiter))
    }

    /// [`TaskDriver::with_waiter`], or period-only for `None`.
    pub(crate) fn with_optional_waiter<V: Waiter>(self, waiter: Option<V>) -> TaskDriver<C, T, V> {
        TaskDriver {
            clock: self.clock,
            task: self.task,
            waiter,
            schedule: self.schedule,
            stats: self.stats,
            events: self.events,
            stop: self.stop,
            previous_wake_ns: self.previous_wake_ns,
            previous_exec_ns: self.previous_exec_ns,
        }
    }

    /// Wait until the next grid point (or an event before it, with a waiter) and run one
    /// cycle, unless a stop was requested.
    pub fn step(&mut self) -> Step {
        if self.stop.load(Ordering::Acquire) {
            return Step::Stopped;
        }
        let scheduled_ns = self.schedule.next_wake_ns();
        let (release, woke_ns) = match self.waiter.as_mut() {
            None => {
                self.clock.sleep_until_ns(scheduled_ns);
                (Release::Period, self.clock.now_ns())
            }
            Some(waiter) => loop {
                let event = waiter.wait_until_ns(scheduled_ns);
                let now_ns = self.clock.now_ns();
                if now_ns >= scheduled_ns {
                    break (Release::Period, now_ns);
                }
                if event {
                    break (Release::Event, now_ns);
                }
                // A waiter that gave up before the deadline without an event: wait again.
            },
        };
        // A stop requested while asleep ends the task before another cycle starts.
        if self.stop.load(Ordering::Acquire) {
            return Step::Stopped;
        }
        let ctx = CycleContext {
            cycle: self.schedule.cycles(),
            scheduled_ns,
            woke_ns,
            period_ns: self.schedule.period_ns(),
            release,
            previous_exec_ns: self.previous_exec_ns,
        };
        self.task.cycle(&ctx);
        let end_ns = self.clock.now_ns();
        if release == Release::Event {
            // The grid and the periodic figures stay as they are.
            self.stats.record_event(end_ns.saturating_sub(woke_ns));
            return Step::Ran;
        }
        let outcome = self.schedule.end_cycle(end_ns);
        let sample = CycleSample {
            period_ns: self.previous_wake_ns.map(|p| woke_ns.saturating_sub(p)),
            exec_ns: end_ns.saturating_sub(woke_ns),
            latency_ns: woke_ns.saturating_sub(scheduled_ns),
            overrun: outcome.overrun,
            missed_periods: outcome.missed_periods,
        };
        self.previous_wake_ns = Some(woke_ns);
        self.previous_exec_ns = sample.exec_ns;
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

    /// The waiter, if the task is released by events.
    pub fn waiter(&self) -> Option<&W> {
        self.waiter.as_ref()
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
    use crate::wake::MockWaiter;

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
        let previous = Arc::new(std::sync::Mutex::new(Vec::new()));
        let p = previous.clone();
        let (mut d, stats, mut rx, _) = driver(
            &clock,
            move |ctx: &CycleContext| {
                p.lock().unwrap().push(ctx.previous_exec_ns);
                c.advance_ns(100 + ctx.cycle)
            },
            1_000,
        );
        for _ in 0..5 {
            wakes.push(d.schedule().next_wake_ns());
            assert_eq!(d.step(), Step::Ran);
        }
        assert_eq!(wakes, [2_000, 3_000, 4_000, 5_000, 6_000]);
        // Each cycle is told how long the one before it ran.
        assert_eq!(*previous.lock().unwrap(), [0, 100, 101, 102, 103]);
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

    /// A task that records every cycle's context and takes `exec_ns(ctx)` of mock time.
    fn recorder(
        clock: &MockClock,
        exec_ns: impl Fn(&CycleContext) -> u64 + Send + 'static,
    ) -> (impl Task, Arc<std::sync::Mutex<Vec<CycleContext>>>) {
        let seen = Arc::new(std::sync::Mutex::new(Vec::new()));
        let (c, s) = (clock.clone(), seen.clone());
        let task = move |ctx: &CycleContext| {
            s.lock().unwrap().push(*ctx);
            c.advance_ns(exec_ns(ctx));
        };
        (task, seen)
    }

    #[test]
    fn events_run_cycles_between_grid_points_without_moving_the_grid() {
        let clock = MockClock::new(0);
        let (task, seen) = recorder(&clock, |_| 5);
        let (d, stats, mut rx, _) = driver(&clock, task, 1_000);
        // 1 990 is just before a grid point, 2 000 on one.
        let events = [300, 700, 1_500, 1_990, 2_000, 2_500];
        let mut d = d.with_waiter(MockWaiter::with_events(clock.clone(), events));
        for _ in 0..8 {
            assert_eq!(d.step(), Step::Ran);
        }
        let runs: Vec<(Release, u64, u64)> = seen
            .lock()
            .unwrap()
            .iter()
            .map(|c| (c.release, c.woke_ns, c.scheduled_ns))
            .collect();
        use Release::{Event, Period};
        assert_eq!(
            runs,
            [
                (Event, 300, 1_000),
                (Event, 700, 1_000),
                (Period, 1_000, 1_000),
                (Event, 1_500, 2_000),
                // Just before the grid point: an event cycle, and the point keeps its own.
                (Event, 1_990, 2_000),
                // On the grid point: one periodic cycle does both.
                (Period, 2_000, 2_000),
                (Event, 2_500, 3_000),
                (Period, 3_000, 3_000),
            ]
        );
        assert_eq!(d.schedule().next_wake_ns(), 4_000);
        let s = stats.snapshot();
        assert_eq!((s.cycles, s.overruns, s.missed_periods), (3, 0, 0));
        assert_eq!(s.event_cycles, 5);
        assert_eq!((s.exec.count(), s.event_exec.count()), (3, 5));
        assert_eq!(
            (s.event_exec.min_ns(), s.event_exec.max_ns()),
            (Some(5), Some(5))
        );
        // The periodic figures are those of a task without events.
        assert_eq!(
            (s.period.count(), s.period.min_ns(), s.period.max_ns()),
            (2, Some(1_000), Some(1_000))
        );
        assert_eq!(s.latency.max_ns(), Some(0));
        assert!(rx.pop().is_err());
    }

    #[test]
    fn an_event_cycle_knows_it_was_released_by_an_event() {
        let clock = MockClock::new(0);
        let (task, seen) = recorder(&clock, |_| 1);
        let (d, _stats, _rx, _) = driver(&clock, task, 1_000);
        let mut d = d.with_waiter(MockWaiter::with_events(clock.clone(), [1_250]));
        d.step();
        d.step();
        let ctx = seen.lock().unwrap()[1];
        assert_eq!(
            ctx,
            CycleContext {
                cycle: 1,
                scheduled_ns: 2_000,
                woke_ns: 1_250,
                period_ns: 1_000,
                release: Release::Event,
                previous_exec_ns: 1,
            }
        );
        // A notification releases the wait at once, at the current time.
        let waiter = MockWaiter::new(clock.clone());
        let notify = waiter.notifier();
        let mut d = d.with_waiter(waiter);
        notify.notify();
        d.step();
        let ctx = seen.lock().unwrap()[2];
        assert_eq!((ctx.release, ctx.woke_ns), (Release::Event, 1_251));
    }

    #[test]
    fn an_event_cycle_past_the_grid_point_makes_the_periodic_one_late_not_lost() {
        let clock = MockClock::new(0);
        // The event at 900 takes 250 (past the point 1 000); the one at 1 950 takes 2 200.
        let (task, seen) = recorder(&clock, |ctx| match (ctx.release, ctx.woke_ns) {
            (Release::Event, 900) => 250,
            (Release::Event, _) => 2_200,
            (Release::Period, _) => 5,
        });
        let (d, stats, mut rx, _) = driver(&clock, task, 1_000);
        let mut d = d.with_waiter(MockWaiter::with_events(clock.clone(), [900, 1_950]));
        for _ in 0..4 {
            d.step();
        }
        let runs: Vec<(Release, u64)> = seen
            .lock()
            .unwrap()
            .iter()
            .map(|c| (c.release, c.woke_ns))
            .collect();
        assert_eq!(
            runs,
            [
                (Release::Event, 900),
                (Release::Period, 1_150),
                (Release::Event, 1_950),
                (Release::Period, 4_150),
            ]
        );
        let s = stats.snapshot();
        // Late by 150, then by 2 150: the second ends after 3 000 and skips it, and 4 000.
        assert_eq!(s.latency.max_ns(), Some(2_150));
        assert_eq!((s.cycles, s.overruns, s.missed_periods), (2, 1, 2));
        assert_eq!(d.schedule().next_wake_ns(), 5_000);
        assert!(matches!(
            rx.pop(),
            Ok(RtEvent::Overrun {
                cycle: 1,
                missed_periods: 2,
                ..
            })
        ));
    }

    #[test]
    fn a_stop_requested_while_waiting_ends_the_loop_with_a_waiter() {
        /// Requests the stop from inside the wait, then reports an event.
        struct StopWhileWaiting(Arc<AtomicBool>);
        impl Waiter for StopWhileWaiting {
            fn wait_until_ns(&mut self, _deadline_ns: u64) -> bool {
                self.0.store(true, Ordering::Release);
                true
            }
        }
        let clock = MockClock::new(0);
        let (task, seen) = recorder(&clock, |_| 1);
        let (d, stats, _rx, stop) = driver(&clock, task, 1_000);
        let mut d = d.with_waiter(StopWhileWaiting(stop.clone()));
        assert_eq!(d.step(), Step::Stopped);
        assert_eq!(d.step(), Step::Stopped);
        assert!(seen.lock().unwrap().is_empty());
        let s = stats.snapshot();
        assert_eq!((s.cycles, s.event_cycles), (0, 0));
    }

    #[test]
    fn a_task_without_a_waiter_is_released_by_its_period() {
        let clock = MockClock::new(0);
        let (task, seen) = recorder(&clock, |_| 1);
        let (mut d, _stats, _rx, _) = driver(&clock, task, 1_000);
        d.step();
        assert_eq!(seen.lock().unwrap()[0].release, Release::Period);
    }
}
