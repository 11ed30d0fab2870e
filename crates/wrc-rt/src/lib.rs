//! wrc-rt: wrc's real-time task runtime, in user space on stock Linux or PREEMPT_RT, the way
//! the paper runs its controller as RTAI/LXRT tasks.
//!
//! What it guarantees:
//! - every task is its own thread on SCHED_FIFO, priority mapped monotonically from the
//!   paper's numbers ([`sched_policy::fifo_priority`]: 10 → 80 … 45 → 45), woken at absolute
//!   times on `CLOCK_MONOTONIC`, with memory locked and its stack prefaulted; where the
//!   process may not have SCHED_FIFO it runs anyway on normal scheduling and says so once;
//! - wake-ups stay on the grid `origin + k × period` (no drift); an overrun is counted, its
//!   missed periods are skipped rather than replayed, and it is reported from a non-real-time
//!   thread;
//! - a task may also be released by an event ([`Runtime::add_released`] with a
//!   [`wake::Waiter`]: a message in a queue made with
//!   [`ipc::MessageQueue::with_notify`], a readable socket): it runs at its grid point or at
//!   the event, whichever comes first; events never move the grid, and their cycles are
//!   counted and timed apart from the periodic ones;
//! - after start-up, the runtime's per-cycle path (sleep or wait, cycle, statistics, overrun
//!   event) allocates nothing, takes no lock and prints nothing; statistics are read without
//!   blocking the task;
//! - IPC ([`ipc`]) allocates only when created.
//!
//! ```
//! use std::time::Duration;
//! use wrc_rt::{RealtimeMode, Runtime, RuntimeOptions, TaskSpec};
//!
//! let mut rt = Runtime::new(RuntimeOptions { realtime: RealtimeMode::Off, ..Default::default() });
//! let mut pulses = 0u64;
//! rt.add(TaskSpec::new("pulse_generator", 20, 1_000), move |_: &wrc_rt::CycleContext| pulses += 1);
//! let running = rt.start().unwrap();
//! std::thread::sleep(Duration::from_millis(30));
//! let report = running.stop(Duration::from_secs(1));
//! assert!(report.is_clean());
//! assert!(report.tasks[0].stats.cycles > 0);
//! ```
#![deny(missing_docs)]

pub mod clock;
pub mod driver;
pub mod histogram;
pub mod ipc;
pub mod notice;
pub mod runtime;
pub mod sched_policy;
pub mod schedule;
pub mod stats;
pub mod table;
pub mod task;
pub mod text;
pub mod virtual_time;
pub mod wake;

pub use clock::{Clock, MockClock, MonotonicClock};
pub use driver::{Step, TaskDriver};
pub use histogram::Histogram;
pub use notice::{Notice, NoticeSink};
pub use runtime::{
    RunningRuntime, Runtime, RuntimeError, RuntimeOptions, StopReport, TaskSnapshot,
};
pub use sched_policy::{fifo_priority, PinPolicy, RealtimeMode, SchedReport};
pub use schedule::{CycleOutcome, Schedule};
pub use stats::{StatsCell, Summary, TaskStats};
pub use table::{TaskSpec, TaskTable, TaskTableError};
pub use task::{CycleContext, Release, SetupError, Task};
pub use text::FixedText;
pub use wake::{Notify, Waiter};
