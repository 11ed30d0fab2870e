//! The soak's servo figures: what the board FIFO, the host watchdog, the following error and
//! the Pulse Generator's wake-ups did over the run, cyclictest's wake-ups beside it at the same
//! priority and interval, the pulse counts at rest, and the judgement against the goal: no
//! underrun, no watchdog trip, no following-error trip, no lost pulse.

use std::collections::BTreeMap;

use serde_json::{json, Value};

use super::pulses::AxisPulses;
use super::tasks::{percentile, Bins, FifoFigures, TaskLine, PULSE_GENERATOR};
use crate::bench_rt::cyclictest::CyclictestResult;

/// Alarm code of a following error (docs/protocol.md).
pub(crate) const FOLLOWING_ERROR: &str = "203";
/// Alarm code of a board's host watchdog that expired.
pub(crate) const BOARD_WATCHDOG: &str = "206";

/// Everything the soak measured about the servo loop.
#[derive(Debug)]
pub(crate) struct Servo {
    /// The servo period [ms].
    pub(crate) period_ms: f64,
    /// What scheduling the controller's tasks got, as it said at start-up.
    pub(crate) scheduling: String,
    /// The load that ran (its command line), or why it could not run the whole time; `None`
    /// without `--load`.
    pub(crate) load: Option<Result<String, String>>,
    /// The `TASKS` lines at the end.
    pub(crate) tasks: Vec<TaskLine>,
    /// The Pulse Generator's wake-up latency histogram over the run.
    pub(crate) pg_run: Bins,
    /// `EVT ERROR` codes raised over the run, and how often.
    pub(crate) alarms: BTreeMap<String, u64>,
    /// cyclictest's wake-up latency over the run, or why there is none.
    pub(crate) cyclictest: Result<CyclictestResult, String>,
    /// Every axis's pulse counts at rest at the end, or why they could not be compared.
    pub(crate) pulses: Result<Vec<AxisPulses>, String>,
}

/// One row of the table: what, the measured value, the goal.
pub(crate) struct Row {
    pub(crate) what: String,
    pub(crate) value: String,
    pub(crate) goal: &'static str,
}

fn row(what: impl Into<String>, value: impl Into<String>, goal: &'static str) -> Row {
    Row {
        what: what.into(),
        value: value.into(),
        goal,
    }
}

/// Count the `EVT ERROR <code> …` lines among `lines` by code.
pub(crate) fn alarms_of<'a>(lines: impl IntoIterator<Item = &'a String>) -> BTreeMap<String, u64> {
    let mut alarms = BTreeMap::new();
    for l in lines {
        if let Some(code) = l
            .strip_prefix("EVT ERROR ")
            .and_then(|r| r.split_whitespace().next())
        {
            *alarms.entry(code.to_string()).or_default() += 1;
        }
    }
    alarms
}

impl Servo {
    fn pg(&self) -> Option<&TaskLine> {
        self.tasks.iter().find(|t| t.name == PULSE_GENERATOR)
    }

    /// The Pulse Generator's FIFO figures (all zero when `TASKS` gave none).
    pub(crate) fn fifo(&self) -> FifoFigures {
        self.pg().and_then(TaskLine::fifo).unwrap_or_default()
    }

    fn alarm(&self, code: &str) -> u64 {
        self.alarms.get(code).copied().unwrap_or(0)
    }

    /// The pulses lost over every axis (their absolute values summed); `None` when they could
    /// not be compared.
    pub(crate) fn lost_pulses(&self) -> Option<u64> {
        self.pulses
            .as_ref()
            .ok()
            .map(|axes| axes.iter().map(|a| a.lost().unsigned_abs()).sum())
    }

    /// The parts of the goal the run missed, each as a sentence; empty when it met it.
    pub(crate) fn failures(&self) -> Vec<String> {
        let mut fails = Vec::new();
        let fifo = self.fifo();
        if self.pg().and_then(TaskLine::fifo).is_none() {
            fails.push("TASKS gave no board FIFO figures for the Pulse Generator".into());
        }
        if fifo.underruns > 0 {
            fails.push(format!("{} underrun(s) (goal 0)", fifo.underruns));
        }
        let watchdog = fifo.watchdog_trips.max(self.alarm(BOARD_WATCHDOG));
        if watchdog > 0 {
            fails.push(format!("{watchdog} watchdog trip(s) (goal 0)"));
        }
        let following = self.alarm(FOLLOWING_ERROR);
        if following > 0 {
            fails.push(format!("{following} following-error trip(s) (goal 0)"));
        }
        match &self.pulses {
            Ok(axes) => {
                for a in axes.iter().filter(|a| a.lost() != 0) {
                    fails.push(format!(
                        "axis {}: {} pulse(s) lost (controller {}, board {})",
                        a.name,
                        a.lost(),
                        a.host,
                        a.board
                    ));
                }
            }
            Err(why) => fails.push(format!("the pulse counts were not compared: {why}")),
        }
        if let Some(Err(why)) = &self.load {
            fails.push(format!("the load did not run the whole time: {why}"));
        }
        fails
    }

    /// The table's rows, in order.
    pub(crate) fn rows(&self) -> Vec<Row> {
        let fifo = self.fifo();
        let mut rows = vec![
            row("servo period [ms]", num(self.period_ms), ""),
            // Its first clause (`real-time scheduling: SCHED_FIFO for all 8 tasks …`); the JSON
            // has the whole statement.
            row(
                "scheduling",
                self.scheduling.split(';').next().unwrap_or(""),
                "",
            ),
            row(
                "load",
                match &self.load {
                    None => "none (idle)".to_string(),
                    Some(Ok(c)) => c.clone(),
                    Some(Err(why)) => format!("FAILED: {why}"),
                },
                "",
            ),
            row(
                "underruns: controller (TASKS) / boards",
                format!(
                    "{} / {}",
                    fifo.underruns,
                    self.pulses.as_ref().map_or("-".to_string(), |axes| axes
                        .iter()
                        .map(|a| u64::from(a.board_underruns))
                        .sum::<u64>()
                        .to_string())
                ),
                "0",
            ),
            row(
                "watchdog trips: TASKS / alarms 206",
                format!("{} / {}", fifo.watchdog_trips, self.alarm(BOARD_WATCHDOG)),
                "0",
            ),
            row(
                "following-error trips (alarms 203)",
                self.alarm(FOLLOWING_ERROR).to_string(),
                "0",
            ),
            row(
                "alarms raised (code ×n)",
                if self.alarms.is_empty() {
                    "none".to_string()
                } else {
                    self.alarms
                        .iter()
                        .map(|(c, n)| format!("{c} ×{n}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                },
                "",
            ),
        ];
        for t in &self.tasks {
            rows.push(row(
                format!("overruns (missed periods): {}", t.name),
                format!("{} ({})", opt(t.count("overruns")), opt(t.count("missed"))),
                "",
            ));
        }
        let pg = self.pg();
        let lat = |key: &str| pg.and_then(|t| t.number(key));
        rows.push(row(
            "PG wake-up latency p50 / p99 / max [µs]",
            format!(
                "≤{} / {} / {}",
                opt(percentile(&self.pg_run, 50)),
                lat("lat_p99_us").map_or("-".into(), num),
                lat("lat_max_us").map_or("-".into(), num)
            ),
            "",
        ));
        match &self.cyclictest {
            Ok(ct) => {
                rows.push(row(
                    "cyclictest p50 / p99 / max [µs]",
                    format!(
                        "{} / {} / {}",
                        num(ct.p50_us),
                        num(ct.p99_us),
                        num(ct.max_us)
                    ),
                    "",
                ));
                let ratio = |pg: Option<f64>, ct: f64| {
                    pg.map_or("-".to_string(), |pg| format!("{:.2}", pg / ct.max(1.0)))
                };
                rows.push(row(
                    "PG / cyclictest: p99 / max",
                    format!(
                        "{} / {}",
                        ratio(lat("lat_p99_us"), ct.p99_us),
                        ratio(lat("lat_max_us"), ct.max_us)
                    ),
                    "",
                ));
            }
            Err(why) => rows.push(row("cyclictest", format!("none ({why})"), "")),
        }
        rows.push(row(
            "deepest FIFO drain: periods (ms) of the look-ahead",
            match fifo.deepest_drain() {
                Some(d) => format!(
                    "{d} ({} ms) of {} ({} ms); lowest level {} (PG {} µs late, ring {}, {} \
                     periods into a move, {})",
                    num(d as f64 * self.period_ms),
                    fifo.lookahead,
                    num(fifo.lookahead as f64 * self.period_ms),
                    opt(fifo.fifo_min),
                    opt(fifo.min_late_us),
                    opt(fifo.min_ring),
                    opt(fifo.min_after_start),
                    match fifo.min_moving {
                        Some(true) => "moving",
                        Some(false) => "its end queued",
                        None => "-",
                    },
                ),
                None => format!("- (never streamed) of {}", fifo.lookahead),
            },
            // A FIFO found empty at the start of a period has not underrun yet: the goal is on
            // the underruns.
            "",
        ));
        rows.push(row(
            "board periods late / board stops",
            format!("{} / {}", fifo.board_late, fifo.board_stops),
            "",
        ));
        if let Some(start) = fifo.dry_after_start {
            // Where a move ran dry: at its start (a plan still coming), right after a flush
            // (its brake not yet pushed), or mid-move (a stall longer than the look-ahead).
            rows.push(row(
                "last run-dry: PG periods after its move's start / the last flush",
                format!("{start} / {}", opt(fifo.dry_after_flush)),
                "",
            ));
        }
        match &self.pulses {
            Ok(axes) => {
                for a in axes {
                    rows.push(row(
                        format!("lost pulses: {}", a.name),
                        format!(
                            "{} (controller {}, board {}, encoder {})",
                            a.lost(),
                            a.host,
                            a.board,
                            a.encoder
                        ),
                        "0",
                    ));
                }
            }
            Err(why) => rows.push(row("lost pulses", format!("not compared: {why}"), "0")),
        }
        rows
    }

    /// Every figure as JSON.
    pub(crate) fn to_json(&self) -> Value {
        let fifo = self.fifo();
        let pg = self.pg();
        let lat = |key: &str| pg.and_then(|t| t.number(key));
        json!({
            "period_ms": self.period_ms,
            "scheduling": self.scheduling,
            "load": match &self.load {
                None => Value::Null,
                Some(Ok(c)) => json!({ "command": c, "ran": true }),
                Some(Err(why)) => json!({ "error": why, "ran": false }),
            },
            "underruns": fifo.underruns,
            "board_underruns": self.pulses.as_ref().ok().map(|axes| axes
                .iter()
                .map(|a| u64::from(a.board_underruns))
                .sum::<u64>()),
            "watchdog_trips": fifo.watchdog_trips,
            "watchdog_alarms": self.alarm(BOARD_WATCHDOG),
            "following_error_trips": self.alarm(FOLLOWING_ERROR),
            "alarms": self.alarms,
            "tasks": self.tasks.iter().map(|t| json!({
                "name": t.name,
                "overruns": t.count("overruns"),
                "missed_periods": t.count("missed"),
                "lat_p99_us": t.number("lat_p99_us"),
                "lat_max_us": t.number("lat_max_us"),
            })).collect::<Vec<_>>(),
            "pg_latency_us": {
                "p50_bin_upper": percentile(&self.pg_run, 50),
                "p99_bin_upper": percentile(&self.pg_run, 99),
                "p99": lat("lat_p99_us"),
                "max": lat("lat_max_us"),
                "run_histogram": self.pg_run,
            },
            "cyclictest": match &self.cyclictest {
                Ok(ct) => json!({
                    "p50_us": ct.p50_us, "p99_us": ct.p99_us, "max_us": ct.max_us,
                    "avg_us": ct.avg_us, "min_us": ct.min_us, "samples": ct.samples,
                    "command": ct.command,
                }),
                Err(why) => json!({ "error": why }),
            },
            "pg_over_cyclictest": self.cyclictest.as_ref().ok().map(|ct| json!({
                "p99": lat("lat_p99_us").map(|v| v / ct.p99_us.max(1.0)),
                "max": lat("lat_max_us").map(|v| v / ct.max_us.max(1.0)),
            })),
            "fifo": {
                "lookahead_periods": fifo.lookahead,
                "fifo_min_periods": fifo.fifo_min,
                "deepest_drain_periods": fifo.deepest_drain(),
                "deepest_drain_ms": fifo.deepest_drain().map(|d| d as f64 * self.period_ms),
                "deepest_drain_pg_late_us": fifo.min_late_us,
                "deepest_drain_ring_periods": fifo.min_ring,
                "deepest_drain_after_start_periods": fifo.min_after_start,
                "deepest_drain_moving": fifo.min_moving,
                "run_dry_after_start_periods": fifo.dry_after_start,
                "run_dry_after_flush_periods": fifo.dry_after_flush,
                "board_late": fifo.board_late,
                "board_stops": fifo.board_stops,
            },
            "pulses": match &self.pulses {
                Ok(axes) => json!(axes.iter().map(AxisPulses::to_json).collect::<Vec<_>>()),
                Err(why) => json!({ "error": why }),
            },
            "lost_pulses": self.lost_pulses(),
            "servo_failures": self.failures(),
        })
    }
}

/// A number for the table: at most one decimal, none when whole.
fn num(v: f64) -> String {
    if v.fract() == 0.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.1}")
    }
}

fn opt(v: Option<u64>) -> String {
    v.map_or("-".to_string(), |v| v.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn servo(pg_line: &str) -> Servo {
        Servo {
            period_ms: 1.0,
            scheduling: "SCHED_FIFO".into(),
            load: None,
            tasks: vec![TaskLine::parse(pg_line).unwrap()],
            pg_run: vec![(16, 990), (64, 10)],
            alarms: BTreeMap::new(),
            cyclictest: Err("not installed".into()),
            pulses: Ok(vec![AxisPulses {
                name: "j1".into(),
                host: 5,
                board: 5,
                encoder: 5,
                board_underruns: 0,
                discarded: 0,
            }]),
        }
    }

    const CLEAN: &str = "EVT TASK pulse_generator overruns=0 missed=0 lat_p99_us=40 lat_max_us=90 \
        board_stops=0 lookahead=20 fifo_min=18 underruns=0 watchdog_trips=0 board_late=0 lat_hist=16:990,64:10";

    #[test]
    fn a_clean_run_meets_the_goal_and_its_table_has_every_row() {
        let s = servo(CLEAN);
        assert_eq!(s.failures(), Vec::<String>::new());
        let rows = s.rows();
        let find = |what: &str| {
            rows.iter()
                .find(|r| r.what.starts_with(what))
                .map(|r| r.value.clone())
        };
        assert_eq!(find("underruns").unwrap(), "0 / 0");
        assert_eq!(
            find("deepest FIFO drain").unwrap(),
            "2 (2 ms) of 20 (20 ms); lowest level 18 (PG - µs late, ring -, - periods into a \
             move, -)"
        );
        assert_eq!(find("PG wake-up latency").unwrap(), "≤16 / 40 / 90");
        assert_eq!(
            find("lost pulses: j1").unwrap(),
            "0 (controller 5, board 5, encoder 5)"
        );
        assert!(find("cyclictest").unwrap().contains("not installed"));
        assert_eq!(s.to_json()["lost_pulses"], 0);
    }

    #[test]
    fn each_part_of_the_goal_fails_on_its_own() {
        let mut s = servo(&CLEAN.replace("underruns=0", "underruns=3"));
        s.alarms = alarms_of(&[
            "EVT ERROR 203 following error on axis j2".to_string(),
            "EVT ERROR 201 emergency stop".to_string(),
            "EVT STATE ERROR".to_string(),
        ]);
        s.pulses = Ok(vec![AxisPulses {
            name: "z".into(),
            host: 10,
            board: 7,
            encoder: 7,
            board_underruns: 3,
            discarded: 0,
        }]);
        s.load = Some(Err("`stress-ng …` ended (exit status: 1)".into()));
        let f = s.failures().join("\n");
        for part in [
            "3 underrun",
            "1 following-error",
            "axis z: 3 pulse(s) lost",
            "the load",
        ] {
            assert!(f.contains(part), "{part}: {f}");
        }
        assert!(!f.contains("watchdog"), "{f}");
        let rows = s.rows();
        assert!(rows.iter().any(|r| r.value == "201 ×1, 203 ×1"));
        assert_eq!(s.to_json()["lost_pulses"], 3);
    }
}
