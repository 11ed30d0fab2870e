//! The task trait: a setup step that may allocate, and a cycle step that must not.

/// Why a task's setup failed (any error; setup runs before real-time starts).
pub type SetupError = Box<dyn std::error::Error + Send + Sync>;

/// Why a cycle runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Release {
    /// Its grid point came (the periodic cycle; also when an event came with it or while the
    /// thread was late).
    Period,
    /// An event (a message, readable input) came before the grid point; the grid does not
    /// move, and the grid point still releases its own periodic cycle.
    Event,
}

/// What a cycle knows about its timing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CycleContext {
    /// Periodic cycles run before this one (event-released cycles are not counted).
    pub cycle: u64,
    /// The grid point this cycle was scheduled for [ns, on the runtime's clock]; for an
    /// event release, the grid point still ahead.
    pub scheduled_ns: u64,
    /// When the thread actually woke [ns].
    pub woke_ns: u64,
    /// The task's period [ns].
    pub period_ns: u64,
    /// Why it runs: its period or an event.
    pub release: Release,
    /// How long the task's previous periodic cycle ran [ns, measured by the runtime from
    /// its wake-up to its return]; 0 before the first one ended. A cycle cannot time itself
    /// to its end; this is how a task records its own execution time (the trace does).
    pub previous_exec_ns: u64,
}

/// One periodic real-time task. The runtime owns timing: it wakes the task on its grid (and,
/// for a task added with [`crate::Runtime::add_released`], at events in between), calls
/// [`Task::cycle`], measures it and puts the thread back to sleep.
///
/// `cycle` runs on a SCHED_FIFO thread: it must not allocate, print, lock a contended mutex,
/// block or make an avoidable system call, and it should return well within its period.
pub trait Task: Send + 'static {
    /// Prepare (allocate buffers, open devices). Runs on the task's own thread, after its
    /// scheduling is set and before the first cycle.
    fn setup(&mut self) -> Result<(), SetupError> {
        Ok(())
    }

    /// Do one period's work (`ctx.release` says whether the period or an event released it).
    fn cycle(&mut self, ctx: &CycleContext);
}

impl<F: FnMut(&CycleContext) + Send + 'static> Task for F {
    fn cycle(&mut self, ctx: &CycleContext) {
        self(ctx)
    }
}
