//! Virtual time: the same tasks, on one thread, under a virtual clock.
//!
//! A [`VirtualRuntime`] holds tasks as the real [`crate::Runtime`] does (a [`TaskSpec`] each,
//! released by their period, by an event, or by a condition) and runs them with a
//! deterministic scheduler instead of threads:
//!
//! - the clock is a [`MockClock`] that only the scheduler moves; a cycle takes no virtual
//!   time, so no task is ever late and none overruns;
//! - at each instant the most urgent task that is due runs first: lowest paper priority,
//!   then the order the tasks were added in. A task is due when its grid point
//!   `origin + k × period` has come, when its [`VirtualWake`] was notified (a message in a
//!   queue made with [`crate::ipc::MessageQueue::with_notify`]), or when its release
//!   condition holds ([`VirtualRuntime::add_polled`]); events run at the instant they happen,
//!   before time moves on, exactly as a higher-priority thread would preempt;
//! - when nothing is due the clock jumps to the next grid point, as fast as the CPU allows
//!   ([`Pace::Unpaced`]) or no faster than a given multiple of real time
//!   ([`Pace::Rate`]);
//! - each task runs through the same [`TaskDriver`] as on a real-time thread, so its cycle
//!   sees the same [`crate::CycleContext`] and its statistics are kept the same way (on
//!   virtual time: periods exact, latency and execution time 0).
//!
//! Two runs with the same tasks and the same inputs at the same virtual times make the same
//! calls in the same order. A task that keeps releasing itself at one instant is cut off
//! after [`MAX_EVENTS_PER_INSTANT`] event cycles (counted in [`VirtualRuntime::cut_bursts`])
//! so that time still moves on.
//!
//! ```
//! use std::sync::{Arc, Mutex};
//! use wrc_rt::virtual_time::{VirtualRuntime, VirtualWake};
//! use wrc_rt::{CycleContext, TaskSpec};
//!
//! let mut rt = VirtualRuntime::new(0);
//! let log = Arc::new(Mutex::new(Vec::new()));
//! let (a, b) = (log.clone(), log.clone());
//! let wake = VirtualWake::new();
//! let notify = wake.notifier();
//! rt.add(TaskSpec::new("fast", 10, 1_000), move |c: &CycleContext| {
//!     a.lock().unwrap().push(("fast", c.woke_ns));
//!     if c.woke_ns == 2_000_000 {
//!         notify.notify(); // a message for "slow"
//!     }
//! })
//! .unwrap();
//! rt.add_released(TaskSpec::new("slow", 20, 5_000), move |c: &CycleContext| {
//!     b.lock().unwrap().push(("slow", c.woke_ns));
//! }, &wake)
//! .unwrap();
//! rt.run_until_ns(5_000_000);
//! assert_eq!(
//!     *log.lock().unwrap(),
//!     [("fast", 1_000_000), ("fast", 2_000_000), ("slow", 2_000_000), ("fast", 3_000_000),
//!      ("fast", 4_000_000), ("fast", 5_000_000), ("slow", 5_000_000)]
//! );
//! ```

use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::clock::{Clock, MockClock};
use crate::driver::{TaskDriver, EVENT_QUEUE_CAPACITY};
use crate::notice::RtEvent;
use crate::runtime::{RuntimeError, TaskSnapshot};
use crate::stats::StatsCell;
use crate::table::TaskSpec;
use crate::task::{Release, Task};
use crate::wake::{Notify, Waiter};

/// Event cycles at one instant after which further events wait for the next grid point.
pub const MAX_EVENTS_PER_INSTANT: u32 = 10_000;

/// How fast virtual time runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pace {
    /// As fast as the CPU allows.
    Unpaced,
    /// No faster than this many virtual seconds per real second (> 0); 1.0 is real time.
    Rate(f64),
}

#[derive(Debug, Default)]
struct Flag(AtomicBool);

impl Notify for Flag {
    fn notify(&self) {
        self.0.store(true, Ordering::Release);
    }
}

/// The event release of a task in a [`VirtualRuntime`]: its notifier marks the task due at
/// the current virtual instant. Made before the task (its notifier goes to whoever produces
/// the events, such as a queue), then given to [`VirtualRuntime::add_released`].
#[derive(Debug, Clone, Default)]
pub struct VirtualWake {
    flag: Arc<Flag>,
}

impl VirtualWake {
    /// A wake with no event pending.
    pub fn new() -> VirtualWake {
        VirtualWake::default()
    }

    /// The handle that releases the task (from any thread; never blocks or allocates).
    pub fn notifier(&self) -> Arc<dyn Notify> {
        self.flag.clone()
    }

    /// Whether an event is pending.
    pub fn is_pending(&self) -> bool {
        self.flag.0.load(Ordering::Acquire)
    }
}

/// What releases a task besides its period.
enum Source {
    Period,
    Flag(Arc<Flag>),
    Poll(Box<dyn Fn() -> bool + Send>),
}

impl Source {
    fn pending(&self) -> bool {
        match self {
            Source::Period => false,
            Source::Flag(flag) => flag.0.load(Ordering::Acquire),
            Source::Poll(ready) => ready(),
        }
    }
}

/// The waiter of a task under virtual time: it never waits. The scheduler steps a task only
/// at its grid point (the clock is already there) or when its event is pending.
struct VirtualWaiter {
    clock: MockClock,
    source: Source,
}

impl Waiter for VirtualWaiter {
    fn wait_until_ns(&mut self, deadline_ns: u64) -> bool {
        let event = match &self.source {
            Source::Period => false,
            Source::Flag(flag) => flag.0.swap(false, Ordering::AcqRel),
            Source::Poll(ready) => ready(),
        };
        if !event {
            self.clock.set_ns(deadline_ns);
        }
        event
    }
}

/// One task as the scheduler sees it.
trait Stepper: Send {
    fn next_wake_ns(&self) -> u64;
    fn event_pending(&self) -> bool;
    fn step(&mut self);
}

struct Driven<T: Task> {
    driver: TaskDriver<MockClock, T, VirtualWaiter>,
    /// Overrun events (never produced on virtual time: cycles take no time); drained so a
    /// full queue cannot hide one.
    events: rtrb::Consumer<RtEvent>,
}

impl<T: Task> Stepper for Driven<T> {
    fn next_wake_ns(&self) -> u64 {
        self.driver.schedule().next_wake_ns()
    }

    fn event_pending(&self) -> bool {
        self.driver_waiter_pending()
    }

    fn step(&mut self) {
        let _ = self.driver.step();
        while self.events.pop().is_ok() {}
    }
}

impl<T: Task> Driven<T> {
    fn driver_waiter_pending(&self) -> bool {
        self.driver
            .waiter()
            .is_some_and(|w: &VirtualWaiter| w.source.pending())
    }
}

struct Entry {
    spec: TaskSpec,
    stats: Arc<StatsCell>,
    stepper: Box<dyn Stepper>,
}

/// Tasks run by a deterministic scheduler on a virtual clock (see the module docs).
pub struct VirtualRuntime {
    clock: MockClock,
    start_ns: u64,
    entries: Vec<Entry>,
    pace: Pace,
    /// Wall time and virtual time when pacing (re)started.
    paced_from: Option<(Instant, u64)>,
    instant_ns: u64,
    events_at_instant: u32,
    cut_bursts: u64,
    cycles: u64,
    stop: Arc<AtomicBool>,
}

impl fmt::Debug for VirtualRuntime {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("VirtualRuntime")
            .field("now_ns", &self.clock.now_ns())
            .field(
                "tasks",
                &self
                    .entries
                    .iter()
                    .map(|e| &e.spec.name)
                    .collect::<Vec<_>>(),
            )
            .field("pace", &self.pace)
            .finish_non_exhaustive()
    }
}

impl VirtualRuntime {
    /// An empty runtime whose clock reads `start_ns` [ns]; every task's first grid point is
    /// one period later.
    pub fn new(start_ns: u64) -> VirtualRuntime {
        VirtualRuntime {
            clock: MockClock::new(start_ns),
            start_ns,
            entries: Vec::new(),
            pace: Pace::Unpaced,
            paced_from: None,
            instant_ns: start_ns,
            events_at_instant: 0,
            cut_bursts: 0,
            cycles: 0,
            stop: Arc::new(AtomicBool::new(false)),
        }
    }

    /// Run as fast as the CPU allows, or no faster than a multiple of real time.
    pub fn set_pace(&mut self, pace: Pace) {
        self.pace = pace;
        self.paced_from = None;
    }

    /// The virtual clock (clones share its time; for code that reads the time).
    pub fn clock(&self) -> MockClock {
        self.clock.clone()
    }

    /// Now [ns, virtual].
    pub fn now_ns(&self) -> u64 {
        self.clock.now_ns()
    }

    /// Virtual time since the runtime was made [ns].
    pub fn elapsed_ns(&self) -> u64 {
        self.clock.now_ns() - self.start_ns
    }

    /// Cycles run so far, all tasks.
    pub fn cycles(&self) -> u64 {
        self.cycles
    }

    /// Instants at which events were cut off after [`MAX_EVENTS_PER_INSTANT`] cycles.
    pub fn cut_bursts(&self) -> u64 {
        self.cut_bursts
    }

    /// Add `task`, released by its period. Its setup runs now.
    pub fn add(&mut self, spec: TaskSpec, task: impl Task) -> Result<(), RuntimeError> {
        self.push(spec, task, Source::Period)
    }

    /// Add `task`, released by its period or by `wake`'s notifier. Its setup runs now.
    pub fn add_released(
        &mut self,
        spec: TaskSpec,
        task: impl Task,
        wake: &VirtualWake,
    ) -> Result<(), RuntimeError> {
        self.push(spec, task, Source::Flag(wake.flag.clone()))
    }

    /// Add `task`, released by its period or whenever `ready` holds (checked before every
    /// cycle of any task: keep it cheap). Its setup runs now.
    pub fn add_polled(
        &mut self,
        spec: TaskSpec,
        task: impl Task,
        ready: impl Fn() -> bool + Send + 'static,
    ) -> Result<(), RuntimeError> {
        self.push(spec, task, Source::Poll(Box::new(ready)))
    }

    fn push<T: Task>(
        &mut self,
        spec: TaskSpec,
        mut task: T,
        source: Source,
    ) -> Result<(), RuntimeError> {
        if self.entries.iter().any(|e| e.spec.name == spec.name) {
            return Err(RuntimeError::Duplicate { task: spec.name });
        }
        task.setup().map_err(|e| RuntimeError::Setup {
            task: spec.name.clone(),
            reason: e.to_string(),
        })?;
        let stats = Arc::new(StatsCell::new());
        let (producer, events) = rtrb::RingBuffer::new(EVENT_QUEUE_CAPACITY);
        let period_ns = spec.period_ns();
        let driver = TaskDriver::new(
            self.clock.clone(),
            task,
            self.clock.now_ns() + period_ns,
            period_ns,
            stats.clone(),
            producer,
            self.stop.clone(),
        )
        .with_waiter(VirtualWaiter {
            clock: self.clock.clone(),
            source,
        });
        // Most urgent first; equal priorities in the order added (a stable insert).
        let at = self
            .entries
            .iter()
            .position(|e| e.spec.priority > spec.priority)
            .unwrap_or(self.entries.len());
        self.entries.insert(
            at,
            Entry {
                spec,
                stats,
                stepper: Box::new(Driven { driver, events }),
            },
        );
        Ok(())
    }

    /// Every task as configured with its statistics cell, most urgent first.
    pub fn task_cells(&self) -> Vec<(TaskSpec, Arc<StatsCell>)> {
        self.entries
            .iter()
            .map(|e| (e.spec.clone(), e.stats.clone()))
            .collect()
    }

    /// A snapshot of every task's statistics, most urgent first.
    pub fn snapshot(&self) -> Vec<TaskSnapshot> {
        self.entries
            .iter()
            .map(|e| TaskSnapshot {
                spec: e.spec.clone(),
                stats: e.stats.snapshot(),
            })
            .collect()
    }

    /// The next instant a task is due [ns, virtual]: now when an event is pending.
    pub fn next_release_ns(&self) -> u64 {
        let now = self.clock.now_ns();
        let events_open = self.events_at_instant < MAX_EVENTS_PER_INSTANT;
        self.entries
            .iter()
            .map(|e| {
                if events_open && e.stepper.event_pending() {
                    now
                } else {
                    e.stepper.next_wake_ns().max(now)
                }
            })
            .min()
            .unwrap_or(u64::MAX)
    }

    /// The most urgent task due now, if any.
    fn due(&mut self) -> Option<usize> {
        let now = self.clock.now_ns();
        if now != self.instant_ns {
            self.instant_ns = now;
            self.events_at_instant = 0;
        }
        let events_open = self.events_at_instant < MAX_EVENTS_PER_INSTANT;
        let mut event_only = false;
        let found = self.entries.iter().position(|e| {
            if e.stepper.next_wake_ns() <= now {
                event_only = false;
                true
            } else if events_open && e.stepper.event_pending() {
                event_only = true;
                true
            } else {
                false
            }
        });
        if found.is_some() && event_only {
            self.events_at_instant += 1;
            if self.events_at_instant == MAX_EVENTS_PER_INSTANT {
                self.cut_bursts += 1;
            }
        }
        found
    }

    /// Run one cycle: the most urgent task due now, or, when none is, the first due after
    /// moving the clock to the next grid point. Returns the task's name and why it ran.
    pub fn step(&mut self) -> (&str, Release) {
        loop {
            if let Some(i) = self.due() {
                let now = self.clock.now_ns();
                let release = if self.entries[i].stepper.next_wake_ns() <= now {
                    Release::Period
                } else {
                    Release::Event
                };
                self.entries[i].stepper.step();
                self.cycles += 1;
                return (&self.entries[i].spec.name, release);
            }
            let next = self
                .entries
                .iter()
                .map(|e| e.stepper.next_wake_ns())
                .min()
                .unwrap_or(u64::MAX);
            if next == u64::MAX {
                // No task at all: nothing ever becomes due.
                return ("", Release::Period);
            }
            self.advance_to(next);
        }
    }

    /// Run every cycle due up to and including `t_ns` [ns, virtual], then leave the clock at
    /// `t_ns` (never moves it backwards).
    pub fn run_until_ns(&mut self, t_ns: u64) {
        while !self.entries.is_empty() && self.next_release_ns() <= t_ns {
            self.step();
        }
        if t_ns > self.clock.now_ns() {
            self.advance_to(t_ns);
        }
    }

    /// Run every cycle due before `t_ns` [ns, virtual], then move the clock to `t_ns`
    /// without running what is due at it (never moves it backwards): an input given now
    /// is seen by the cycles of `t_ns` in their priority order, as if it had come just
    /// before them (a replay delivers a recorded request this way).
    pub fn run_before_ns(&mut self, t_ns: u64) {
        while !self.entries.is_empty() && self.next_release_ns() < t_ns {
            self.step();
        }
        if t_ns > self.clock.now_ns() {
            self.advance_to(t_ns);
        }
    }

    /// Run for `ns` [ns] of virtual time from now.
    pub fn run_for_ns(&mut self, ns: u64) {
        let until = self.clock.now_ns().saturating_add(ns);
        self.run_until_ns(until);
    }

    /// Move the clock to `t_ns`, waiting in real time first when paced.
    fn advance_to(&mut self, t_ns: u64) {
        if let Pace::Rate(rate) = self.pace {
            if rate.is_finite() && rate > 0.0 {
                let (wall0, virt0) = *self
                    .paced_from
                    .get_or_insert((Instant::now(), self.clock.now_ns()));
                let wall = Duration::from_secs_f64(t_ns.saturating_sub(virt0) as f64 / 1e9 / rate);
                let target = wall0 + wall;
                let now = Instant::now();
                if target > now {
                    std::thread::sleep(target - now);
                }
            }
        }
        self.clock.set_ns(t_ns);
    }

    /// How far virtual time is ahead of the pace (negative: behind) [s]; 0 when unpaced.
    pub fn pace_lead_s(&self) -> f64 {
        match (self.pace, self.paced_from) {
            (Pace::Rate(rate), Some((wall0, virt0))) => {
                let virt = (self.clock.now_ns() - virt0) as f64 / 1e9;
                virt / rate - wall0.elapsed().as_secs_f64()
            }
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Mutex;

    use super::*;
    use crate::task::CycleContext;

    type Log = Arc<Mutex<Vec<(&'static str, u64, Release)>>>;

    fn logger(log: &Log, name: &'static str) -> impl Task {
        let log = log.clone();
        move |c: &CycleContext| log.lock().unwrap().push((name, c.woke_ns, c.release))
    }

    #[test]
    fn equal_instants_run_most_urgent_first_then_in_the_order_added() {
        let log = Log::default();
        let mut rt = VirtualRuntime::new(0);
        rt.add(TaskSpec::new("c", 45, 2_000), logger(&log, "c"))
            .unwrap();
        rt.add(TaskSpec::new("a", 10, 1_000), logger(&log, "a"))
            .unwrap();
        rt.add(TaskSpec::new("d", 45, 2_000), logger(&log, "d"))
            .unwrap();
        rt.run_until_ns(4_000_000);
        let order: Vec<(&str, u64)> = log.lock().unwrap().iter().map(|e| (e.0, e.1)).collect();
        assert_eq!(
            order,
            [
                ("a", 1_000_000),
                ("a", 2_000_000),
                ("c", 2_000_000),
                ("d", 2_000_000),
                ("a", 3_000_000),
                ("a", 4_000_000),
                ("c", 4_000_000),
                ("d", 4_000_000),
            ]
        );
        assert_eq!(rt.now_ns(), 4_000_000);
        let cells = rt.task_cells();
        assert_eq!(cells[0].0.name, "a");
        let s = cells[0].1.snapshot();
        assert_eq!((s.cycles, s.overruns), (4, 0));
        assert_eq!(
            (s.period.min_ns(), s.period.max_ns()),
            (Some(1_000_000), Some(1_000_000))
        );
    }

    #[test]
    fn run_before_leaves_the_instant_to_run_and_an_input_given_then_meets_it_in_priority_order() {
        let log = Log::default();
        let wake = VirtualWake::new();
        let mut rt = VirtualRuntime::new(0);
        rt.add(TaskSpec::new("urgent", 10, 1_000), logger(&log, "urgent"))
            .unwrap();
        rt.add_released(
            TaskSpec::new("reader", 40, 2_000),
            logger(&log, "reader"),
            &wake,
        )
        .unwrap();
        rt.add(TaskSpec::new("late", 80, 2_000), logger(&log, "late"))
            .unwrap();
        rt.run_before_ns(2_000_000);
        assert_eq!(rt.now_ns(), 2_000_000);
        let ran: Vec<(&str, u64)> = log.lock().unwrap().iter().map(|e| (e.0, e.1)).collect();
        assert_eq!(ran, [("urgent", 1_000_000)], "nothing of 2 ms ran yet");
        // An input now: the reader takes it at 2 ms after the more urgent task, once.
        wake.notifier().notify();
        rt.run_until_ns(2_000_000);
        let ran: Vec<(&str, u64, Release)> = log.lock().unwrap().clone();
        assert_eq!(
            ran[1..],
            [
                ("urgent", 2_000_000, Release::Period),
                ("reader", 2_000_000, Release::Period),
                ("late", 2_000_000, Release::Period),
            ]
        );
        // Never backwards.
        rt.run_before_ns(1_500_000);
        assert_eq!(rt.now_ns(), 2_000_000);
    }

    #[test]
    fn an_event_runs_at_its_instant_and_the_grid_keeps_its_own_cycle() {
        let log = Log::default();
        let wake = VirtualWake::new();
        let notify = wake.notifier();
        let mut rt = VirtualRuntime::new(0);
        let l = log.clone();
        rt.add(
            TaskSpec::new("producer", 10, 1_000),
            move |c: &CycleContext| {
                l.lock().unwrap().push(("producer", c.woke_ns, c.release));
                if c.woke_ns == 3_000_000 {
                    notify.notify();
                }
            },
        )
        .unwrap();
        rt.add_released(
            TaskSpec::new("consumer", 40, 10_000),
            logger(&log, "consumer"),
            &wake,
        )
        .unwrap();
        rt.run_until_ns(10_000_000);
        let consumer: Vec<(u64, Release)> = log
            .lock()
            .unwrap()
            .iter()
            .filter(|e| e.0 == "consumer")
            .map(|e| (e.1, e.2))
            .collect();
        assert_eq!(
            consumer,
            [(3_000_000, Release::Event), (10_000_000, Release::Period)]
        );
        assert!(!wake.is_pending());
        let s = rt.task_cells()[1].1.snapshot();
        assert_eq!((s.cycles, s.event_cycles), (1, 1));
    }

    #[test]
    fn a_polled_task_runs_when_its_condition_holds() {
        let log = Log::default();
        let work = Arc::new(std::sync::atomic::AtomicU32::new(0));
        let mut rt = VirtualRuntime::new(0);
        let w = work.clone();
        rt.add(
            TaskSpec::new("poster", 10, 1_000),
            move |c: &CycleContext| {
                if c.woke_ns == 2_000_000 {
                    w.fetch_add(1, Ordering::SeqCst);
                }
            },
        )
        .unwrap();
        let (w, l) = (work.clone(), log.clone());
        let ready = work.clone();
        rt.add_polled(
            TaskSpec::new("urgent", 40, 100_000),
            move |c: &CycleContext| {
                w.store(0, Ordering::SeqCst);
                l.lock().unwrap().push(("urgent", c.woke_ns, c.release));
            },
            move || ready.load(Ordering::SeqCst) > 0,
        )
        .unwrap();
        rt.run_until_ns(5_000_000);
        assert_eq!(
            *log.lock().unwrap(),
            [("urgent", 2_000_000, Release::Event)]
        );
    }

    #[test]
    fn a_task_that_keeps_releasing_itself_cannot_stop_time() {
        let wake = VirtualWake::new();
        let notify = wake.notifier();
        notify.notify();
        let mut rt = VirtualRuntime::new(0);
        rt.add_released(
            TaskSpec::new("busy", 10, 1_000),
            move |_: &CycleContext| notify.notify(),
            &wake,
        )
        .unwrap();
        rt.run_until_ns(2_000_000);
        assert_eq!(rt.now_ns(), 2_000_000);
        assert!(rt.cut_bursts() >= 1);
    }

    #[test]
    fn same_inputs_same_calls() {
        let run = || {
            let log = Log::default();
            let wake = VirtualWake::new();
            let notify = wake.notifier();
            let mut rt = VirtualRuntime::new(5);
            let l = log.clone();
            rt.add(TaskSpec::new("a", 20, 3_000), move |c: &CycleContext| {
                l.lock().unwrap().push(("a", c.woke_ns, c.release));
                if c.cycle % 3 == 1 {
                    notify.notify();
                }
            })
            .unwrap();
            rt.add_released(TaskSpec::new("b", 30, 7_000), logger(&log, "b"), &wake)
                .unwrap();
            rt.run_until_ns(100_000_000);
            let v = log.lock().unwrap().clone();
            v
        };
        assert_eq!(run(), run());
    }

    #[test]
    fn a_duplicate_name_or_a_failing_setup_is_refused() {
        struct Fails;
        impl Task for Fails {
            fn setup(&mut self) -> Result<(), crate::SetupError> {
                Err("no device".into())
            }
            fn cycle(&mut self, _: &CycleContext) {}
        }
        let mut rt = VirtualRuntime::new(0);
        rt.add(TaskSpec::new("a", 10, 1_000), |_: &CycleContext| {})
            .unwrap();
        assert!(matches!(
            rt.add(TaskSpec::new("a", 10, 1_000), |_: &CycleContext| {}),
            Err(RuntimeError::Duplicate { .. })
        ));
        let e = rt.add(TaskSpec::new("b", 10, 1_000), Fails).unwrap_err();
        assert_eq!(e.to_string(), "task b: setup failed: no device");
    }
}
