//! The controller's `TASKS` answer read back: one [`TaskLine`] per `EVT TASK` line (its
//! counters, wake-up latency and power-of-two latency histogram) and the Pulse Generator's
//! board FIFO figures ([`FifoFigures`]); percentiles of a histogram or of the samples two
//! readings of it differ by.

use std::collections::BTreeMap;

/// The task whose wake-up latency the soak compares with cyclictest.
pub(crate) const PULSE_GENERATOR: &str = "pulse_generator";

/// Latency histogram in power-of-two bins: `(u, n)`, `n` wake-ups between `u/2` and `u` [µs].
pub(crate) type Bins = Vec<(u64, u64)>;

/// One `EVT TASK <name> key=value …` line.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TaskLine {
    /// The task's name (`pulse_generator`).
    pub(crate) name: String,
    fields: BTreeMap<String, String>,
}

impl TaskLine {
    /// Read an `EVT TASK` line; `None` for any other line.
    pub(crate) fn parse(line: &str) -> Option<TaskLine> {
        let mut words = line.strip_prefix("EVT TASK ")?.split_whitespace();
        let name = words.next()?.to_string();
        let fields = words
            .filter_map(|w| w.split_once('='))
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        Some(TaskLine { name, fields })
    }

    /// A whole-number field (`cycles`, `overruns`, `missed`, `underruns`, …).
    pub(crate) fn count(&self, key: &str) -> Option<u64> {
        self.fields.get(key)?.parse().ok()
    }

    /// A decimal field (`lat_p99_us`, `lat_max_us` [µs], `period_ms` [ms]).
    pub(crate) fn number(&self, key: &str) -> Option<f64> {
        self.fields.get(key)?.parse().ok()
    }

    /// The wake-up latency histogram (`lat_hist=u:n,…`).
    pub(crate) fn histogram(&self) -> Bins {
        self.fields
            .get("lat_hist")
            .map(String::as_str)
            .unwrap_or("")
            .split(',')
            .filter_map(|bin| {
                let (u, n) = bin.split_once(':')?;
                Some((u.parse().ok()?, n.parse().ok()?))
            })
            .collect()
    }

    /// The Pulse Generator's board FIFO figures; `None` on another task's line.
    pub(crate) fn fifo(&self) -> Option<FifoFigures> {
        Some(FifoFigures {
            lookahead: self.count("lookahead")?,
            // `-` until the Pulse Generator has streamed a period.
            fifo_min: self.count("fifo_min"),
            // Absent from an older controller's line: unknown.
            min_late_us: self.count("fifo_min_late_us"),
            min_ring: self.count("fifo_min_ring"),
            min_after_start: self.count("fifo_min_after_start"),
            min_moving: self.count("fifo_min_moving").map(|m| m != 0),
            dry_after_start: self.count("dry_after_start"),
            dry_after_flush: self.count("dry_after_flush"),
            underruns: self.count("underruns")?,
            watchdog_trips: self.count("watchdog_trips")?,
            board_late: self.count("board_late")?,
            board_stops: self.count("board_stops")?,
        })
    }
}

/// The Pulse Generator's view of the board FIFO since the controller started.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct FifoFigures {
    /// Periods kept queued ahead of the board [periods].
    pub(crate) lookahead: u64,
    /// The lowest FIFO level found at the start of a period while streaming [periods];
    /// `None` before the first streamed period.
    pub(crate) fifo_min: Option<u64>,
    /// The Pulse Generator's wake-up lateness in the period of the lowest level [µs].
    pub(crate) min_late_us: Option<u64>,
    /// Periods the Velocity Generator's ring held then.
    pub(crate) min_ring: Option<u64>,
    /// Periods since the move's start then.
    pub(crate) min_after_start: Option<u64>,
    /// Whether the last period pushed then was moving (else the move's last was pushed).
    pub(crate) min_moving: Option<bool>,
    /// At the last move that ran its FIFO dry: periods since its start; `None`: none did.
    pub(crate) dry_after_start: Option<u64>,
    /// Then: periods since the last flush (`None`: none yet).
    pub(crate) dry_after_flush: Option<u64>,
    /// Periods an axis found its FIFO empty, all axes of all boards.
    pub(crate) underruns: u64,
    /// Host-watchdog trips, all boards.
    pub(crate) watchdog_trips: u64,
    /// Board periods started late and caught up, all boards.
    pub(crate) board_late: u64,
    /// Stops the boards braked on their own.
    pub(crate) board_stops: u64,
}

impl FifoFigures {
    /// The deepest the FIFO drained below the look-ahead [periods]: look-ahead − lowest level
    /// (0 when it never went below, `None` before any streaming).
    pub(crate) fn deepest_drain(&self) -> Option<u64> {
        self.fifo_min.map(|m| self.lookahead.saturating_sub(m))
    }
}

/// Every `EVT TASK` line among `lines`, in their order.
pub(crate) fn task_lines<'a>(lines: impl IntoIterator<Item = &'a String>) -> Vec<TaskLine> {
    lines
        .into_iter()
        .filter_map(|l| TaskLine::parse(l))
        .collect()
}

/// The samples `b` holds beyond `a` (two readings of one histogram, `a` first).
pub(crate) fn difference(a: &[(u64, u64)], b: &[(u64, u64)]) -> Bins {
    let before = |u: u64| a.iter().find(|(x, _)| *x == u).map_or(0, |(_, n)| *n);
    b.iter()
        .map(|&(u, n)| (u, n.saturating_sub(before(u))))
        .filter(|&(_, n)| n > 0)
        .collect()
}

/// The `pct` percentile of `bins` as the upper bound of the bin it falls in [µs]; `None`
/// when they are empty.
pub(crate) fn percentile(bins: &[(u64, u64)], pct: u64) -> Option<u64> {
    let total: u64 = bins.iter().map(|(_, n)| n).sum();
    if total == 0 {
        return None;
    }
    let mut seen = 0;
    bins.iter().find_map(|&(u, n)| {
        seen += n;
        (seen * 100 >= total * pct).then_some(u)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Pulse Generator line as a 1 ms controller answered it.
    const PG: &str =
        "EVT TASK pulse_generator prio=20 period_ms=1 cycles=8773 overruns=2 missed=4 \
        per_avg_us=1000.455 per_min_us=298.302 per_max_us=3707.284 exec_avg_us=1.165 \
        exec_max_us=34.101 lat_avg_us=17.647 lat_p99_us=43.007 lat_max_us=2721.546 ev_cycles=0 \
        ev_exec_avg_us=0 ev_exec_max_us=0 stops_flushed=0 stops_behind_queue=0 board_stops=1 \
        lookahead=20 fifo_min=17 fifo_min_late_us=2721 fifo_min_ring=40 fifo_min_after_start=9 fifo_min_moving=1 \
        dry_after_start=2 \
        dry_after_flush=- underruns=0 watchdog_trips=3 board_late=5 \
        lat_hist=16:6412,32:2032,64:296,128:23,256:4,512:2,1024:2,4096:2";

    #[test]
    fn the_pulse_generator_line_gives_its_counters_fifo_and_histogram() {
        let t = TaskLine::parse(PG).unwrap();
        assert_eq!(t.name, PULSE_GENERATOR);
        assert_eq!((t.count("overruns"), t.count("missed")), (Some(2), Some(4)));
        assert_eq!(t.number("lat_p99_us"), Some(43.007));
        assert_eq!(t.number("lat_max_us"), Some(2721.546));
        assert_eq!(t.number("period_ms"), Some(1.0));
        let f = t.fifo().unwrap();
        assert_eq!(
            f,
            FifoFigures {
                lookahead: 20,
                fifo_min: Some(17),
                min_late_us: Some(2721),
                min_ring: Some(40),
                min_after_start: Some(9),
                min_moving: Some(true),
                dry_after_start: Some(2),
                dry_after_flush: None,
                underruns: 0,
                watchdog_trips: 3,
                board_late: 5,
                board_stops: 1,
            }
        );
        assert_eq!(f.deepest_drain(), Some(3));
        let h = t.histogram();
        assert_eq!(h.len(), 8);
        assert_eq!(h[0], (16, 6412));
        assert_eq!(h[7], (4096, 2));
        assert_eq!(percentile(&h, 50), Some(16));
        assert_eq!(percentile(&h, 99), Some(64));
        assert_eq!(percentile(&h, 100), Some(4096));
    }

    #[test]
    fn before_streaming_the_lowest_level_is_unknown() {
        let line = PG.replace("fifo_min=17", "fifo_min=-");
        let f = TaskLine::parse(&line).unwrap().fifo().unwrap();
        assert_eq!((f.fifo_min, f.deepest_drain()), (None, None));
    }

    #[test]
    fn other_tasks_have_no_fifo_and_other_lines_are_no_tasks() {
        let line =
            "EVT TASK ethernet prio=45 period_ms=100 cycles=5 overruns=0 missed=0 lat_hist=32:5";
        let t = TaskLine::parse(line).unwrap();
        assert_eq!((t.name.as_str(), t.fifo()), ("ethernet", None));
        assert_eq!(t.histogram(), vec![(32, 5)]);
        assert!(TaskLine::parse("ACK 3 tasks=8").is_none());
        let lines = vec![PG.to_string(), "ACK 3 tasks=8".into(), line.into()];
        let names: Vec<_> = task_lines(&lines).into_iter().map(|t| t.name).collect();
        assert_eq!(names, ["pulse_generator", "ethernet"]);
    }

    #[test]
    fn percentiles_of_what_two_readings_differ_by() {
        let a = [(16, 100), (32, 10)];
        let b = [(16, 100), (32, 60), (64, 30), (1024, 10)];
        let d = difference(&a, &b);
        assert_eq!(d, vec![(32, 50), (64, 30), (1024, 10)]);
        assert_eq!(percentile(&d, 50), Some(32));
        assert_eq!(percentile(&d, 99), Some(1024));
        assert_eq!(percentile(&difference(&b, &b), 99), None);
    }
}
