//! Messages from the runtime to people: the start-up scheduling statement and rate-limited
//! overrun reports. Real-time threads never format or print; they push a small
//! [`RtEvent`] into a lock-free queue that a non-real-time reporter thread turns into
//! [`Notice`]s.

use std::fmt;
use std::sync::Arc;

use crate::sched_policy::SchedReport;

/// A fixed-size record pushed by a task's thread (no allocation, no formatting).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RtEvent {
    /// A cycle ended after its next grid point.
    Overrun {
        /// Cycle index.
        cycle: u64,
        /// How late the wake-up was [ns].
        latency_ns: u64,
        /// Execution time [ns].
        exec_ns: u64,
        /// Grid points skipped.
        missed_periods: u64,
    },
}

/// A message for people, delivered to the runtime's [`NoticeSink`] from a non-RT thread.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Notice {
    /// What scheduling the runtime got (once, at start-up).
    Scheduling(SchedReport),
    /// Overruns of one task since the last report (at most one per task per interval).
    Overruns {
        /// Task name.
        task: String,
        /// Overrunning cycles in this interval.
        count: u64,
        /// Grid points skipped in this interval.
        missed_periods: u64,
        /// Longest execution time among them [ns].
        worst_exec_ns: u64,
        /// Longest wake-up latency among them [ns].
        worst_latency_ns: u64,
        /// Events lost because the task's event queue was full.
        dropped: u64,
    },
}

impl fmt::Display for Notice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Notice::Scheduling(report) => write!(f, "wrc-rt: {report}"),
            Notice::Overruns {
                task,
                count,
                missed_periods,
                worst_exec_ns,
                worst_latency_ns,
                dropped,
            } => {
                write!(
                    f,
                    "wrc-rt: task {task}: {count} overrun(s), {missed_periods} period(s) skipped \
                     (worst execution {:.0} µs, worst wake-up latency {:.0} µs)",
                    *worst_exec_ns as f64 / 1000.0,
                    *worst_latency_ns as f64 / 1000.0
                )?;
                if *dropped > 0 {
                    write!(f, "; {dropped} more not itemised (event queue full)")?;
                }
                Ok(())
            }
        }
    }
}

/// Where notices go; called from non-real-time threads only.
pub type NoticeSink = Arc<dyn Fn(&Notice) + Send + Sync>;

/// The default sink: the process's log (`tracing`, at warning level; the binary's
/// subscriber writes it to standard error). Real-time threads never call it: they queue
/// notices, and the non-real-time reporter drains the queue into this sink.
pub fn stderr_sink() -> NoticeSink {
    Arc::new(|notice: &Notice| tracing::warn!("{notice}"))
}
