//! Per-task statistics: period, execution time and wake-up latency histograms, cycles,
//! overruns and missed periods of the periodic releases; the count and execution times of
//! event releases, apart.
//!
//! The task's thread records into a [`StatsCell`] in every cycle without allocating or
//! locking; any other thread takes a consistent [`TaskStats`] snapshot without ever blocking
//! the task (a sequence lock: the reader retries when the writer was mid-update).

use std::sync::atomic::{fence, AtomicU64, Ordering};

use crate::histogram::{AtomicHistogram, Histogram};

/// What one cycle measured, in [ns].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CycleSample {
    /// Time since the previous cycle's wake-up [ns]; `None` for the first cycle.
    pub period_ns: Option<u64>,
    /// Time from wake-up to the end of the cycle's work [ns].
    pub exec_ns: u64,
    /// How late the thread woke after its grid point [ns].
    pub latency_ns: u64,
    /// The cycle overran its period.
    pub overrun: bool,
    /// Grid points skipped after this cycle.
    pub missed_periods: u64,
}

/// The shared statistics of one task: one writer (the task), any number of readers.
#[derive(Debug, Default)]
pub struct StatsCell {
    seq: AtomicU64,
    cycles: AtomicU64,
    overruns: AtomicU64,
    missed_periods: AtomicU64,
    /// The most periods one late cycle skipped since [`StatsCell::take_worst_missed`].
    worst_missed: AtomicU64,
    period: AtomicHistogram,
    exec: AtomicHistogram,
    latency: AtomicHistogram,
    event_cycles: AtomicU64,
    event_exec: AtomicHistogram,
}

impl StatsCell {
    /// Empty statistics (allocates the histograms once, here).
    pub fn new() -> StatsCell {
        StatsCell::default()
    }

    /// Record one cycle. Only the task's own thread calls this; wait-free, no allocation.
    pub fn record(&self, sample: &CycleSample) {
        let seq = self.seq.load(Ordering::Relaxed);
        self.seq.store(seq.wrapping_add(1), Ordering::Relaxed);
        fence(Ordering::Release);
        let bump =
            |a: &AtomicU64, by: u64| a.store(a.load(Ordering::Relaxed) + by, Ordering::Relaxed);
        bump(&self.cycles, 1);
        bump(&self.overruns, sample.overrun as u64);
        bump(&self.missed_periods, sample.missed_periods);
        if sample.missed_periods > 0 {
            self.worst_missed
                .fetch_max(sample.missed_periods, Ordering::Relaxed);
        }
        if let Some(period_ns) = sample.period_ns {
            self.period.record(period_ns);
        }
        self.exec.record(sample.exec_ns);
        self.latency.record(sample.latency_ns);
        self.seq.store(seq.wrapping_add(2), Ordering::Release);
    }

    /// Record one event-released cycle that took `exec_ns` [ns] from wake-up to the end of
    /// its work. Only the task's own thread calls this; wait-free, no allocation. The
    /// periodic figures are not touched.
    pub fn record_event(&self, exec_ns: u64) {
        let seq = self.seq.load(Ordering::Relaxed);
        self.seq.store(seq.wrapping_add(1), Ordering::Relaxed);
        fence(Ordering::Release);
        let n = self.event_cycles.load(Ordering::Relaxed);
        self.event_cycles.store(n + 1, Ordering::Relaxed);
        self.event_exec.record(exec_ns);
        self.seq.store(seq.wrapping_add(2), Ordering::Release);
    }

    /// The most periods one late cycle skipped since the last call (0: none), and start
    /// over: how long the task's longest stall in that time was, in its periods. For one
    /// reader (Error Check); wait-free.
    pub fn take_worst_missed(&self) -> u64 {
        self.worst_missed.swap(0, Ordering::AcqRel)
    }

    /// A consistent copy of everything recorded so far (allocates; for non-real-time code).
    pub fn snapshot(&self) -> TaskStats {
        let mut stats = TaskStats::default();
        self.snapshot_into(&mut stats);
        stats
    }

    /// Copy into `into` without allocating; retries (never blocks the writer) until the copy
    /// was not torn by a concurrent [`StatsCell::record`].
    pub fn snapshot_into(&self, into: &mut TaskStats) {
        let mut tries = 0u32;
        loop {
            let before = self.seq.load(Ordering::Acquire);
            if before % 2 == 0 {
                into.cycles = self.cycles.load(Ordering::Relaxed);
                into.overruns = self.overruns.load(Ordering::Relaxed);
                into.missed_periods = self.missed_periods.load(Ordering::Relaxed);
                self.period.copy_into(&mut into.period);
                self.exec.copy_into(&mut into.exec);
                self.latency.copy_into(&mut into.latency);
                into.event_cycles = self.event_cycles.load(Ordering::Relaxed);
                self.event_exec.copy_into(&mut into.event_exec);
                fence(Ordering::Acquire);
                if self.seq.load(Ordering::Relaxed) == before {
                    return;
                }
            }
            tries += 1;
            if tries % 64 == 0 {
                // The writer was preempted mid-update; let it finish.
                std::thread::yield_now();
            } else {
                std::hint::spin_loop();
            }
        }
    }
}

/// A snapshot of one task's statistics. `cycles`, `overruns`, `missed_periods`, `period`,
/// `exec` and `latency` are about periodic releases only; `event_cycles` and `event_exec`
/// about event releases (a task added with [`crate::Runtime::add_released`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TaskStats {
    /// Periodic cycles run.
    pub cycles: u64,
    /// Periodic cycles that ended after their next grid point.
    pub overruns: u64,
    /// Grid points skipped because of overruns.
    pub missed_periods: u64,
    /// Wake-to-wake intervals [ns] (the paper's Table 3).
    pub period: Histogram,
    /// Execution times, wake-up to end of work [ns] (the paper's Table 4).
    pub exec: Histogram,
    /// Wake-up latencies, actual minus scheduled wake-up [ns] (what cyclictest measures).
    pub latency: Histogram,
    /// Cycles released by an event before their grid point.
    pub event_cycles: u64,
    /// Execution times of the event-released cycles, wake-up to end of work [ns].
    pub event_exec: Histogram,
}

/// min / max / avg / p99 of a histogram in [µs], for tables and JSON.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Summary {
    /// Samples.
    pub count: u64,
    /// Minimum [µs].
    pub min_us: f64,
    /// Maximum [µs].
    pub max_us: f64,
    /// Mean [µs].
    pub avg_us: f64,
    /// 50th percentile [µs].
    pub p50_us: f64,
    /// 99th percentile [µs].
    pub p99_us: f64,
}

impl Summary {
    /// Summarise `h` (all zero when it is empty).
    pub fn of(h: &Histogram) -> Summary {
        let us = |ns: Option<u64>| ns.unwrap_or(0) as f64 / 1000.0;
        Summary {
            count: h.count(),
            min_us: us(h.min_ns()),
            max_us: us(h.max_ns()),
            avg_us: h.mean_ns().unwrap_or(0.0) / 1000.0,
            p50_us: us(h.quantile_ns(0.5)),
            p99_us: us(h.quantile_ns(0.99)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn records_and_summarises() {
        let cell = StatsCell::new();
        cell.record(&CycleSample {
            period_ns: None,
            exec_ns: 2_000,
            latency_ns: 10_000,
            ..Default::default()
        });
        cell.record(&CycleSample {
            period_ns: Some(10_000_000),
            exec_ns: 4_000,
            latency_ns: 30_000,
            overrun: true,
            missed_periods: 2,
        });
        cell.record_event(7_000);
        let s = cell.snapshot();
        assert_eq!((s.cycles, s.overruns, s.missed_periods), (2, 1, 2));
        assert_eq!(s.period.count(), 1);
        assert_eq!(s.exec.count(), 2, "an event cycle is not a periodic one");
        assert_eq!((s.event_cycles, s.event_exec.max_ns()), (1, Some(7_000)));
        let exec = Summary::of(&s.exec);
        assert_eq!((exec.min_us, exec.max_us, exec.avg_us), (2.0, 4.0, 3.0));
        assert_eq!(Summary::of(&s.latency).max_us, 30.0);
    }

    #[test]
    fn snapshots_taken_while_recording_are_never_torn() {
        // Every sample has exec = latency = 1000 ns: a torn copy would show counts that differ.
        let cell = Arc::new(StatsCell::new());
        let writer = {
            let cell = cell.clone();
            std::thread::spawn(move || {
                for _ in 0..200_000 {
                    cell.record(&CycleSample {
                        period_ns: Some(1),
                        exec_ns: 1000,
                        latency_ns: 1000,
                        ..Default::default()
                    });
                }
            })
        };
        let mut snap = TaskStats::default();
        let mut last = 0;
        while !writer.is_finished() {
            cell.snapshot_into(&mut snap);
            assert_eq!(snap.exec.count(), snap.cycles);
            assert_eq!(snap.latency.count(), snap.cycles);
            assert_eq!(snap.period.count(), snap.cycles);
            assert!(snap.cycles >= last);
            last = snap.cycles;
        }
        writer.join().unwrap();
        assert_eq!(cell.snapshot().cycles, 200_000);
    }
}
