//! How much a blend between a PTP and a path may search for its fastest way through the
//! junction, counted in work units (derivative rows the path's timing law, its brakes and
//! its estimate evaluate), never in time: the plan is the same on every machine and under
//! virtual time, and its worst case in the real-time Velocity Generator is bounded. A search
//! checks its budget before each step — one knot of the law, or one entry's brake check or
//! time estimate — and ends at the first check that finds it spent, so it ends within one
//! step of its budget ([`SearchStats::max_step`]). Past the budget it takes its safe
//! fallback — the motion at rest at the junction, as the two moves one after the other are —
//! and says so in [`SearchStats`] (docs/motion.md, "PTP blends").
//!
//! Real-time promise: counters and `Copy` values; nothing allocates.

use std::cell::Cell;

use crate::path::Derivs;

/// How a blend between a PTP and a path chooses among its candidates (docs/motion.md, "PTP
/// blends").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlendSearch {
    /// For the real-time task. A PTP into a path compares its entries by an estimate of the
    /// path's timing law ([`crate::VelocityGenerator::plan_ptp_into`]); past the budget it
    /// enters the path at rest. A path into a PTP decides how it leaves at the knot where
    /// its law first looks past the path's end, timing its exits by running the law over
    /// the last stretch ([`crate::VelocityGenerator::plan_depart`]); past the budget it
    /// stops at the path's end and the PTP starts from there. Each search spends at most
    /// `work` units and one step (Ruckig's moves and the samples of their joints, at most
    /// four, are not counted): about 0.15 µs a unit at the median on a 2-core VM.
    Bounded {
        /// Most work units one search may spend.
        work: u64,
    },
    /// No budget, and a PTP's entries into a path timed by the path's law run over the first
    /// [`crate::ENTRY_HORIZON_MM`] of it (a line's to its end) instead of estimated: tens of
    /// milliseconds before the first pulse on a long path, so not for the real-time task.
    /// What the bounded search is measured against (`wrc bench motion`).
    Exhaustive,
}

impl BlendSearch {
    /// The default: bounded at 40,000 units, about 6 ms on a 2-core VM; 280 of the 284
    /// searches of a path's exit on `wrc bench motion`'s 300 random paths need less, and a
    /// PTP's entries at most 2,238.
    pub const DEFAULT: BlendSearch = BlendSearch::Bounded { work: 40_000 };

    /// The most work units a search may spend (`u64::MAX` without a budget).
    pub fn limit(&self) -> u64 {
        match self {
            BlendSearch::Bounded { work } => *work,
            BlendSearch::Exhaustive => u64::MAX,
        }
    }
}

impl Default for BlendSearch {
    fn default() -> Self {
        BlendSearch::DEFAULT
    }
}

/// What the blends' searches of a generator did, since it was created: an observable figure
/// of the real-time path, as a task's execution time is.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SearchStats {
    /// Searches done (a PTP into a path's entries, a path into a PTP's exits).
    pub searches: u64,
    /// Searches that ran out of work units and took their fallback: at rest at the junction.
    pub fallbacks: u64,
    /// Work units of the last search.
    pub last_work: u64,
    /// The most work units a search spent.
    pub max_work: u64,
    /// The most work units one step of a search spent (between two checks of its budget):
    /// how far past its budget a search may end.
    pub max_step: u64,
}

impl SearchStats {
    /// Count the search that spent `work` and ended in its fallback or not.
    pub(crate) fn record(&mut self, work: &Work, fell_back: bool) {
        self.searches += 1;
        self.fallbacks += u64::from(fell_back);
        self.last_work = work.used();
        self.max_work = self.max_work.max(work.used());
        self.max_step = self.max_step.max(work.max_step());
    }
}

/// The work a search has spent against its budget, and its largest step.
#[derive(Debug)]
pub(crate) struct Work {
    used: Cell<u64>,
    limit: u64,
    /// Units spent when the budget was last checked.
    checked: Cell<u64>,
    /// The most units spent between two checks (or after the last one).
    max_step: Cell<u64>,
}

impl Work {
    pub(crate) fn new(search: BlendSearch) -> Work {
        Work {
            used: Cell::new(0),
            limit: search.limit(),
            checked: Cell::new(0),
            max_step: Cell::new(0),
        }
    }

    /// `derivs`, each row it gives counted as one unit.
    pub(crate) fn counting<'a>(
        &'a self,
        derivs: &'a impl Fn(f64) -> Derivs,
    ) -> impl Fn(f64) -> Derivs + 'a {
        move |u| {
            self.used.set(self.used.get() + 1);
            derivs(u)
        }
    }

    /// Whether the budget still has units left: asked before each step of a search, which
    /// stops at the first answer no.
    pub(crate) fn left(&self) -> bool {
        self.end_step();
        self.used.get() < self.limit
    }

    /// Units spent.
    pub(crate) fn used(&self) -> u64 {
        self.used.get()
    }

    /// The most units one step spent (between two checks of the budget, or after the last
    /// one up to now).
    pub(crate) fn max_step(&self) -> u64 {
        self.end_step();
        self.max_step.get()
    }

    fn end_step(&self) {
        let used = self.used.get();
        let step = used - self.checked.get();
        self.max_step.set(self.max_step.get().max(step));
        self.checked.set(used);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_is_counted_in_rows_and_runs_out_at_its_limit() {
        let work = Work::new(BlendSearch::Bounded { work: 3 });
        let rows = |_: f64| Derivs::default();
        let counted = work.counting(&rows);
        counted(0.0);
        counted(0.5);
        assert!(work.left());
        counted(1.0);
        assert!(!work.left());
        assert_eq!(work.used(), 3);
        assert!(Work::new(BlendSearch::Exhaustive).left());
        let mut stats = SearchStats::default();
        stats.record(&work, true);
        assert_eq!(
            stats,
            SearchStats {
                searches: 1,
                fallbacks: 1,
                last_work: 3,
                max_work: 3,
                max_step: 2,
            }
        );
    }

    #[test]
    fn a_step_is_the_work_between_two_checks_or_after_the_last() {
        // Checks after 2 units, after 3 more, then 4 more without a check: the largest step
        // is the last one, counted when the search is recorded.
        let work = Work::new(BlendSearch::Bounded { work: 100 });
        let rows = |_: f64| Derivs::default();
        let counted = work.counting(&rows);
        let spend = |n: usize| {
            for _ in 0..n {
                let _ = counted(0.0);
            }
        };
        spend(2);
        assert!(work.left());
        spend(3);
        assert!(work.left());
        spend(4);
        let mut stats = SearchStats::default();
        stats.record(&work, false);
        assert_eq!((stats.last_work, stats.max_step), (9, 4));
        stats.record(&Work::new(BlendSearch::DEFAULT), false);
        assert_eq!(
            (
                stats.searches,
                stats.last_work,
                stats.max_work,
                stats.max_step
            ),
            (2, 0, 9, 4)
        );
    }
}
