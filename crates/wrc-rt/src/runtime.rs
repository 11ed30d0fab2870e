//! The runtime: one thread per task with its scheduling, memory and pinning set up, a common
//! start time, a non-real-time reporter, and a clean stop with a join timeout. A task is
//! released by its period ([`Runtime::add`]) or by its period or an event, whichever comes
//! first ([`Runtime::add_released`]).

use std::fmt;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::clock::{Clock, MonotonicClock};
use crate::driver::{Step, TaskDriver, EVENT_QUEUE_CAPACITY};
use crate::notice::{stderr_sink, Notice, NoticeSink, RtEvent};
use crate::sched_policy::{self, PinPolicy, RealtimeMode, SchedReport, ThreadSched};
use crate::stats::{StatsCell, TaskStats};
use crate::table::TaskSpec;
use crate::task::Task;
use crate::wake::{NoWaiter, Notify, Waiter};

/// Stack of each task thread [bytes]: locked with the rest of the process (mlockall), so
/// never faulted in during a cycle. Room for the Command Interpreter's unoptimised (debug)
/// frames, which hold whole move orders (a composite path is under 1 KiB) by value.
pub const TASK_STACK_BYTES: usize = 2 * 1024 * 1024;

/// How the runtime runs its tasks.
#[derive(Clone)]
pub struct RuntimeOptions {
    /// Ask for SCHED_FIFO (default) or not.
    pub realtime: RealtimeMode,
    /// Lock memory with mlockall and prefault this much heap [bytes] (0 = do not lock).
    pub lock_memory_bytes: usize,
    /// Where tasks run.
    pub pin: PinPolicy,
    /// Time from start-up to the first grid point, shared by all tasks [ms].
    pub start_delay_ms: u64,
    /// Interval between overrun reports per task [ms].
    pub report_interval_ms: u64,
    /// Where the start-up statement and overrun reports go.
    pub notices: NoticeSink,
}

impl Default for RuntimeOptions {
    fn default() -> Self {
        RuntimeOptions {
            realtime: RealtimeMode::Auto,
            lock_memory_bytes: 8 << 20,
            pin: PinPolicy::IsolatedIfAny,
            start_delay_ms: 20,
            report_interval_ms: 1000,
            notices: stderr_sink(),
        }
    }
}

impl fmt::Debug for RuntimeOptions {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RuntimeOptions")
            .field("realtime", &self.realtime)
            .field("lock_memory_bytes", &self.lock_memory_bytes)
            .field("pin", &self.pin)
            .field("start_delay_ms", &self.start_delay_ms)
            .field("report_interval_ms", &self.report_interval_ms)
            .finish_non_exhaustive()
    }
}

/// The runtime could not start.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RuntimeError {
    /// A task's setup step failed; no task was started.
    #[error("task {task}: setup failed: {reason}")]
    Setup {
        /// Task name.
        task: String,
        /// The task's error.
        reason: String,
    },
    /// The operating system would not create a thread.
    #[error("task {task}: cannot create its thread: {source}")]
    Spawn {
        /// Task name.
        task: String,
        /// Why.
        source: std::io::Error,
    },
    /// Two tasks share a name.
    #[error("task {task}: added twice; every task needs its own name")]
    Duplicate {
        /// Task name.
        task: String,
    },
}

type BoxedStart = Box<dyn FnOnce(ThreadCtx) + Send>;

/// The start line: threads wait here until the runtime opens it (start or abort).
#[derive(Default)]
struct Gate {
    open: Mutex<bool>,
    cond: Condvar,
}

impl Gate {
    fn open(&self) {
        *self.open.lock().unwrap_or_else(|e| e.into_inner()) = true;
        self.cond.notify_all();
    }

    fn wait(&self) {
        let mut open = self.open.lock().unwrap_or_else(|e| e.into_inner());
        while !*open {
            open = self.cond.wait(open).unwrap_or_else(|e| e.into_inner());
        }
    }
}

struct ThreadCtx {
    index: usize,
    spec: TaskSpec,
    options_realtime: RealtimeMode,
    cpu: Option<usize>,
    stats: Arc<StatsCell>,
    events: rtrb::Producer<RtEvent>,
    stop: Arc<AtomicBool>,
    ready: mpsc::Sender<Ready>,
    go: Arc<Gate>,
    start_ns: Arc<AtomicU64>,
    abort: Arc<AtomicBool>,
    finished: Arc<AtomicBool>,
}

struct Ready {
    index: usize,
    sched: ThreadSched,
    pin: Option<Result<usize, String>>,
    setup: Result<(), String>,
}

/// A runtime being assembled: add tasks, then [`Runtime::start`].
pub struct Runtime {
    options: RuntimeOptions,
    tasks: Vec<(TaskSpec, BoxedStart)>,
    /// The waiters' notifiers, to end their waits at once on a stop.
    wakers: Vec<Arc<dyn Notify>>,
}

impl fmt::Debug for Runtime {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Runtime")
            .field("options", &self.options)
            .field(
                "tasks",
                &self.tasks.iter().map(|t| &t.0.name).collect::<Vec<_>>(),
            )
            .finish()
    }
}

impl Runtime {
    /// An empty runtime.
    pub fn new(options: RuntimeOptions) -> Runtime {
        Runtime {
            options,
            tasks: Vec::new(),
            wakers: Vec::new(),
        }
    }

    /// Add `task` to run as `spec` says, released by its period.
    pub fn add(&mut self, spec: TaskSpec, task: impl Task) -> &mut Self {
        self.push(spec, task, None::<NoWaiter>)
    }

    /// Add `task` to run as `spec` says, released by its period or by an event from
    /// `waiter`, whichever comes first (see [`crate::driver`] for how the two interplay and
    /// are counted). `waiter` moves into the task's thread and waits on `CLOCK_MONOTONIC`;
    /// its notifier, if it has one, also ends the wait when the runtime stops.
    pub fn add_released(
        &mut self,
        spec: TaskSpec,
        task: impl Task,
        waiter: impl Waiter,
    ) -> &mut Self {
        if let Some(notifier) = waiter.notifier() {
            self.wakers.push(notifier);
        }
        self.push(spec, task, Some(waiter))
    }

    fn push<T: Task, W: Waiter>(
        &mut self,
        spec: TaskSpec,
        task: T,
        waiter: Option<W>,
    ) -> &mut Self {
        let mut parts = Some((task, waiter));
        let start: BoxedStart = Box::new(move |ctx: ThreadCtx| {
            if let Some((task, waiter)) = parts.take() {
                run_thread(ctx, task, waiter)
            }
        });
        self.tasks.push((spec, start));
        self
    }

    /// Start every task: each thread sets its scheduling and pinning, prefaults its stack and
    /// runs its setup; then all start on a common grid origin. The scheduling the process got
    /// is said once, through the notice sink. Fails (with every thread ended) when a setup
    /// fails.
    pub fn start(self) -> Result<RunningRuntime, RuntimeError> {
        let Runtime {
            options,
            tasks,
            wakers,
        } = self;
        for (i, (spec, _)) in tasks.iter().enumerate() {
            if tasks[..i].iter().any(|t| t.0.name == spec.name) {
                return Err(RuntimeError::Duplicate {
                    task: spec.name.clone(),
                });
            }
        }
        // Held open for the runtime's life: closing the file drops the request.
        let cpu_latency = if options.realtime == RealtimeMode::Off {
            Err("not requested".to_string())
        } else {
            sched_policy::hold_cpu_latency_zero().map_err(|e| e.to_string())
        };
        let memory_locked =
            if options.lock_memory_bytes == 0 || options.realtime == RealtimeMode::Off {
                Err("not requested".to_string())
            } else {
                sched_policy::lock_memory(options.lock_memory_bytes).map_err(|e| e.to_string())
            };
        let default_cpu = match options.pin {
            PinPolicy::IsolatedIfAny => sched_policy::isolated_cpus().first().copied(),
            PinPolicy::Cpu(cpu) => Some(cpu),
            PinPolicy::None => None,
        };

        let n = tasks.len();
        let stop = Arc::new(AtomicBool::new(false));
        let abort = Arc::new(AtomicBool::new(false));
        let go = Arc::new(Gate::default());
        let start_ns = Arc::new(AtomicU64::new(0));
        let (ready_tx, ready_rx) = mpsc::channel();
        let mut threads = Vec::with_capacity(n);
        let mut consumers = Vec::with_capacity(n);
        let mut specs = Vec::with_capacity(n);
        for (index, (spec, start)) in tasks.into_iter().enumerate() {
            let stats = Arc::new(StatsCell::new());
            let (events, consumer) = rtrb::RingBuffer::new(EVENT_QUEUE_CAPACITY);
            let finished = Arc::new(AtomicBool::new(false));
            let ctx = ThreadCtx {
                index,
                cpu: spec.cpu.or(default_cpu),
                spec: spec.clone(),
                options_realtime: options.realtime,
                stats: stats.clone(),
                events,
                stop: stop.clone(),
                ready: ready_tx.clone(),
                go: go.clone(),
                start_ns: start_ns.clone(),
                abort: abort.clone(),
                finished: finished.clone(),
            };
            let spawned = std::thread::Builder::new()
                .name(thread_name(&spec.name))
                .stack_size(TASK_STACK_BYTES)
                .spawn(move || start(ctx));
            match spawned {
                Ok(handle) => threads.push(TaskThread {
                    name: spec.name.clone(),
                    handle: Some(handle),
                    finished,
                }),
                Err(source) => {
                    // Release the threads already at the start line, then report.
                    abort.store(true, Ordering::Release);
                    go.open();
                    join_all(&mut threads);
                    return Err(RuntimeError::Spawn {
                        task: spec.name,
                        source,
                    });
                }
            }
            consumers.push(consumer);
            specs.push((spec, stats));
        }
        drop(ready_tx);

        let mut readies: Vec<Option<Ready>> = (0..n).map(|_| None).collect();
        for _ in 0..n {
            match ready_rx.recv() {
                Ok(r) => {
                    let i = r.index;
                    readies[i] = Some(r);
                }
                Err(_) => break,
            }
        }
        let failed = readies.iter().enumerate().find_map(|(i, r)| match r {
            Some(Ready { setup: Err(e), .. }) => Some((specs[i].0.name.clone(), e.clone())),
            None => Some((
                specs[i].0.name.clone(),
                "the thread ended before it was ready".to_string(),
            )),
            _ => None,
        });
        if let Some((task, reason)) = failed {
            abort.store(true, Ordering::Release);
            go.open();
            join_all(&mut threads);
            return Err(RuntimeError::Setup { task, reason });
        }

        let mut report = SchedReport {
            fifo: vec![],
            normal: vec![],
            memory_locked,
            pinned: vec![],
            pin_errors: vec![],
            rt_throttle_us: sched_policy::rt_throttle_us(),
            cpu_latency_zero: cpu_latency.as_ref().map(|_| ()).map_err(Clone::clone),
        };
        for (i, r) in readies.into_iter().enumerate() {
            let r = r.expect("every thread reported ready");
            let name = specs[i].0.name.clone();
            match r.sched {
                ThreadSched::Fifo(p) => report.fifo.push((name.clone(), p)),
                ThreadSched::Normal(why) => report.normal.push((name.clone(), why)),
            }
            match r.pin {
                Some(Ok(cpu)) => report.pinned.push((name, cpu)),
                Some(Err(why)) => report.pin_errors.push((name, why)),
                None => {}
            }
        }
        (options.notices)(&Notice::Scheduling(report.clone()));

        let origin_ns = MonotonicClock.now_ns() + options.start_delay_ms * 1_000_000;
        start_ns.store(origin_ns, Ordering::Release);
        go.open();

        let reporter = Reporter {
            consumers,
            stats: specs
                .iter()
                .map(|s| (s.0.name.clone(), s.1.clone()))
                .collect(),
            last_overruns: vec![0; specs.len()],
            sink: options.notices.clone(),
        };
        let reporter_stop = Arc::new(AtomicBool::new(false));
        let reporter_handle = {
            let stop = reporter_stop.clone();
            let interval = Duration::from_millis(options.report_interval_ms.max(10));
            std::thread::Builder::new()
                .name("wrc-rt:report".into())
                .spawn(move || reporter.run(&stop, interval))
                .ok()
        };

        Ok(RunningRuntime {
            _cpu_latency: cpu_latency.ok(),
            tasks: specs,
            threads,
            stop,
            wakers,
            sched: report,
            origin_ns,
            reporter_stop,
            reporter: reporter_handle,
        })
    }
}

fn join_all(threads: &mut [TaskThread]) {
    for t in threads {
        if let Some(h) = t.handle.take() {
            let _ = h.join();
        }
    }
}

fn thread_name(task: &str) -> String {
    // Linux keeps 15 bytes of a thread name.
    let mut name = format!("rt:{task}");
    name.truncate(15);
    name
}

fn run_thread<T: Task, W: Waiter>(ctx: ThreadCtx, mut task: T, waiter: Option<W>) {
    struct Finished(Arc<AtomicBool>);
    impl Drop for Finished {
        fn drop(&mut self) {
            self.0.store(true, Ordering::Release);
        }
    }
    let _finished = Finished(ctx.finished.clone());

    let sched = match ctx.options_realtime {
        RealtimeMode::Off => ThreadSched::Normal("real-time scheduling was not requested".into()),
        RealtimeMode::Auto => {
            let prio = sched_policy::fifo_priority(ctx.spec.priority);
            match sched_policy::set_current_thread_fifo(prio) {
                Ok(()) => ThreadSched::Fifo(prio),
                Err(e) => ThreadSched::Normal(sched_policy::explain_fifo_error(&e)),
            }
        }
    };
    let pin = ctx.cpu.map(|cpu| {
        sched_policy::pin_current_thread(cpu)
            .map(|()| cpu)
            .map_err(|e| e.to_string())
    });
    sched_policy::prefault_stack();
    let setup = task.setup().map_err(|e| e.to_string());
    let ok = setup.is_ok();
    let _ = ctx.ready.send(Ready {
        index: ctx.index,
        sched,
        pin,
        setup,
    });
    drop(ctx.ready);
    ctx.go.wait();
    if !ok || ctx.abort.load(Ordering::Acquire) {
        return;
    }
    let first_wake_ns = ctx.start_ns.load(Ordering::Acquire);
    let mut driver = TaskDriver::new(
        MonotonicClock,
        task,
        first_wake_ns,
        ctx.spec.period_ns(),
        ctx.stats,
        ctx.events,
        ctx.stop,
    )
    .with_optional_waiter(waiter);
    while driver.step() == Step::Ran {}
}

struct TaskThread {
    name: String,
    handle: Option<JoinHandle<()>>,
    finished: Arc<AtomicBool>,
}

/// Statistics of one task, by name.
#[derive(Debug, Clone, PartialEq)]
pub struct TaskSnapshot {
    /// The task as configured.
    pub spec: TaskSpec,
    /// Its statistics so far.
    pub stats: TaskStats,
}

/// Running tasks: read their statistics, then [`RunningRuntime::stop`].
pub struct RunningRuntime {
    tasks: Vec<(TaskSpec, Arc<StatsCell>)>,
    /// `/dev/cpu_dma_latency`, kept open while the tasks run.
    _cpu_latency: Option<std::fs::File>,
    threads: Vec<TaskThread>,
    stop: Arc<AtomicBool>,
    wakers: Vec<Arc<dyn Notify>>,
    sched: SchedReport,
    origin_ns: u64,
    reporter_stop: Arc<AtomicBool>,
    reporter: Option<JoinHandle<()>>,
}

impl fmt::Debug for RunningRuntime {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RunningRuntime")
            .field(
                "tasks",
                &self.tasks.iter().map(|t| &t.0.name).collect::<Vec<_>>(),
            )
            .field("sched", &self.sched)
            .finish_non_exhaustive()
    }
}

impl RunningRuntime {
    /// What scheduling the tasks got.
    pub fn scheduling(&self) -> &SchedReport {
        &self.sched
    }

    /// The common grid origin: every task's first wake-up [ns, CLOCK_MONOTONIC].
    pub fn origin_ns(&self) -> u64 {
        self.origin_ns
    }

    /// Every task's statistics cell, in task order, for a real-time task (such as the
    /// controller's Error Check) that reads them each cycle with
    /// [`StatsCell::snapshot_into`] without allocating.
    pub fn stats_cells(&self) -> Vec<Arc<StatsCell>> {
        self.tasks.iter().map(|(_, cell)| cell.clone()).collect()
    }

    /// Every task as configured with its statistics cell, in task order.
    pub fn task_cells(&self) -> Vec<(TaskSpec, Arc<StatsCell>)> {
        self.tasks.clone()
    }

    /// A consistent snapshot of every task's statistics (never blocks the tasks).
    pub fn snapshot(&self) -> Vec<TaskSnapshot> {
        self.tasks
            .iter()
            .map(|(spec, cell)| TaskSnapshot {
                spec: spec.clone(),
                stats: cell.snapshot(),
            })
            .collect()
    }

    /// Ask every task to stop after its current cycle (returns at once); a task waiting for
    /// an event is woken now.
    pub fn request_stop(&self) {
        self.stop.store(true, Ordering::Release);
        for waker in &self.wakers {
            waker.notify();
        }
    }

    /// Stop every task after its current cycle and join them, waiting at most `timeout` in
    /// all. A task still sleeping finishes when its next grid point comes (a task waiting
    /// with a notifier at once), so `timeout` should exceed the longest period. Tasks that did not stop are named in the report (their
    /// threads are left running detached).
    pub fn stop(mut self, timeout: Duration) -> StopReport {
        self.request_stop();
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline
            && !self
                .threads
                .iter()
                .all(|t| t.finished.load(Ordering::Acquire))
        {
            std::thread::sleep(Duration::from_millis(1));
        }
        let mut report = StopReport {
            tasks: Vec::new(),
            not_stopped: Vec::new(),
            panicked: Vec::new(),
            timeout,
        };
        for t in &mut self.threads {
            if t.finished.load(Ordering::Acquire) {
                if let Some(h) = t.handle.take() {
                    if h.join().is_err() {
                        report.panicked.push(t.name.clone());
                    }
                }
            } else {
                report.not_stopped.push(t.name.clone());
            }
        }
        self.reporter_stop.store(true, Ordering::Release);
        if let Some(h) = self.reporter.take() {
            let _ = h.join();
        }
        report.tasks = self.snapshot();
        report
    }
}

/// How the stop went, and the final statistics.
#[derive(Debug, Clone)]
pub struct StopReport {
    /// Final statistics of every task.
    pub tasks: Vec<TaskSnapshot>,
    /// Tasks still running when the timeout passed.
    pub not_stopped: Vec<String>,
    /// Tasks whose thread panicked.
    pub panicked: Vec<String>,
    /// The join timeout that was used.
    pub timeout: Duration,
}

impl StopReport {
    /// Every task stopped and none panicked.
    pub fn is_clean(&self) -> bool {
        self.not_stopped.is_empty() && self.panicked.is_empty()
    }
}

impl fmt::Display for StopReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_clean() {
            return write!(f, "all {} tasks stopped", self.tasks.len());
        }
        if !self.not_stopped.is_empty() {
            write!(
                f,
                "task(s) {} did not stop within {} ms (a cycle that blocks or never returns?)",
                self.not_stopped.join(", "),
                self.timeout.as_millis()
            )?;
        }
        if !self.panicked.is_empty() {
            if !self.not_stopped.is_empty() {
                write!(f, "; ")?;
            }
            write!(f, "task(s) {} panicked", self.panicked.join(", "))?;
        }
        Ok(())
    }
}

struct Reporter {
    consumers: Vec<rtrb::Consumer<RtEvent>>,
    stats: Vec<(String, Arc<StatsCell>)>,
    last_overruns: Vec<u64>,
    sink: NoticeSink,
}

impl Reporter {
    fn run(mut self, stop: &AtomicBool, interval: Duration) {
        let mut next = Instant::now() + interval;
        loop {
            let stopping = stop.load(Ordering::Acquire);
            if stopping || Instant::now() >= next {
                self.report();
                next = Instant::now() + interval;
            }
            if stopping {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn report(&mut self) {
        for (i, consumer) in self.consumers.iter_mut().enumerate() {
            let (mut count, mut missed, mut worst_exec, mut worst_latency) =
                (0u64, 0u64, 0u64, 0u64);
            while let Ok(RtEvent::Overrun {
                exec_ns,
                latency_ns,
                missed_periods,
                ..
            }) = consumer.pop()
            {
                count += 1;
                missed += missed_periods;
                worst_exec = worst_exec.max(exec_ns);
                worst_latency = worst_latency.max(latency_ns);
            }
            let total = self.stats[i].1.snapshot().overruns;
            let new = total - self.last_overruns[i];
            self.last_overruns[i] = total;
            if new > 0 {
                (self.sink)(&Notice::Overruns {
                    task: self.stats[i].0.clone(),
                    count: new,
                    missed_periods: missed,
                    worst_exec_ns: worst_exec,
                    worst_latency_ns: worst_latency,
                    dropped: new.saturating_sub(count),
                });
            }
        }
    }
}
