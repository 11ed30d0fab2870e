//! Answers to `ROBOT` and `TASKS`: the robot's geometry and every real-time task's measured
//! timing, formatted as protocol lines by the program store's non-real-time thread (they
//! allocate; no real-time task ever runs this code).

use std::fmt::Write as _;
use std::sync::{Arc, OnceLock};

use wrc_protocol::Num;
use wrc_robot::Robot;
use wrc_rt::histogram::bucket_range;
use wrc_rt::{StatsCell, Summary, TaskSpec, TaskStats};

use crate::shared::{FifoTally, Shared, StopTally};

/// Every task as configured with its figures, set once the runtime has started.
pub type TaskCells = Arc<OnceLock<Vec<(TaskSpec, TaskCell)>>>;

/// Where one task's `TASKS` figures are read: the runtime's timing statistics and, for the
/// Pulse Generator, how its stops braked ([`crate::shared::StopCounts`]).
#[derive(Clone)]
pub struct TaskCell {
    timing: Arc<StatsCell>,
    stops: Option<Arc<Shared>>,
}

impl TaskCell {
    /// A task's cell: its `timing` and, if it is the Pulse Generator, the shared state whose
    /// stop counts it keeps.
    pub fn new(timing: Arc<StatsCell>, stops: Option<Arc<Shared>>) -> TaskCell {
        TaskCell { timing, stops }
    }

    /// The task's figures now (never blocks the task).
    pub fn snapshot(&self) -> TaskFigures {
        TaskFigures {
            timing: self.timing.snapshot(),
            stops: self.stops.as_ref().map(|s| s.stops.read()),
            fifo: self.stops.as_ref().map(|s| s.fifo.read()),
        }
    }
}

/// One task's figures for its `EVT TASK` line.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TaskFigures {
    /// Its timing (the paper's Tables 3 and 4).
    pub timing: TaskStats,
    /// How its stops braked (the Pulse Generator only).
    pub stops: Option<StopTally>,
    /// The board FIFO and the boards' counters (the Pulse Generator only).
    pub fifo: Option<FifoTally>,
}

/// Digital inputs and outputs of the controller (the input and output words).
pub const SIGNALS: usize = 32;

/// The `EVT AXIS` bodies (one per axis) and the `ACK` body of `ROBOT`; `blade_b`: the height
/// of a dual-blade robot's blade B above the hand [mm] (`blade_b=<mm>` at the end).
pub fn robot_reply(robot: &Robot, period_ms: f64, blade_b: Option<f64>) -> (Vec<String>, String) {
    let axes = robot
        .axes()
        .iter()
        .enumerate()
        .map(|(i, a)| {
            format!(
                "{} name={} role={} unit={} ppu={} min={} max={} home={}",
                i + 1,
                a.name.as_str(),
                a.role.as_str(),
                a.unit.as_str(),
                Num(a.pulses_per_unit),
                Num(a.min),
                Num(a.max),
                Num(a.home),
            )
        })
        .collect();
    let arm = robot.arm();
    let name: String = robot
        .name
        .chars()
        .map(|c| if c.is_ascii_graphic() { c } else { '_' })
        .collect();
    let mut ack = format!(
        "name={name} link1={} link2={} hand={} axes={} period_ms={} inputs={SIGNALS} outputs={SIGNALS}",
        Num(arm.link1_mm),
        Num(arm.link2_mm),
        Num(arm.hand_mm),
        robot.axis_count(),
        Num(period_ms),
    );
    if let Some(dz) = blade_b {
        ack.push_str(&format!(" blade_b={}", Num(dz)));
    }
    (axes, ack)
}

/// Each station interlock input of `stations` and its name for `ROBOT`: `interlock` and
/// the stations that use it (`interlock LP1 LP2`), by input number.
pub fn interlocks(stations: &wrc_cell::Stations) -> Vec<(u8, String)> {
    let mut out: Vec<(u8, String)> = Vec::new();
    for s in stations {
        let Some(n) = s.interlock_input else { continue };
        match out.iter_mut().find(|(m, _)| *m == n) {
            Some((_, name)) => {
                name.push(' ');
                name.push_str(s.name.as_str());
            }
            None => out.push((n, format!("interlock {}", s.name))),
        }
    }
    out.sort_by_key(|(n, _)| *n);
    out
}

/// The `EVT SIGNAL` bodies of `ROBOT`, one per named signal
/// ([`wrc_config::IoConfig::signals`], in its order): `<in|out> <n> <guarded|-> <name>`,
/// the name the rest of the line.
pub fn signal_lines(signals: &[wrc_config::Signal]) -> Vec<String> {
    signals
        .iter()
        .map(|s| {
            // A line stays well inside the protocol's reply limit, however many stations
            // share an interlock.
            let mut name = s.name.clone();
            if name.len() > 200 {
                let mut end = 197;
                while !name.is_char_boundary(end) {
                    end -= 1;
                }
                name.truncate(end);
                name.push_str("...");
            }
            format!(
                "{} {} {} {name}",
                s.dir.as_str(),
                s.n,
                if s.guarded { "guarded" } else { "-" }
            )
        })
        .collect()
}

/// The `EVT TASK` body of one task (the paper's Tables 3 and 4 plus a latency histogram, for
/// its periodic cycles; then the count and execution times of its event-released cycles; for
/// the Pulse Generator, its stops braked with a FIFO flush and behind the queue).
pub fn task_line(spec: &TaskSpec, figures: &TaskFigures) -> String {
    let stats = &figures.timing;
    let period = Summary::of(&stats.period);
    let exec = Summary::of(&stats.exec);
    let latency = Summary::of(&stats.latency);
    let event_exec = Summary::of(&stats.event_exec);
    let mut line = format!(
        "{} prio={} period_ms={} cycles={} overruns={} missed={} per_avg_us={} per_min_us={} \
         per_max_us={} exec_avg_us={} exec_max_us={} lat_avg_us={} lat_p99_us={} lat_max_us={} \
         ev_cycles={} ev_exec_avg_us={} ev_exec_max_us={} ",
        spec.name,
        spec.priority,
        Num(spec.period_us as f64 / 1000.0),
        stats.cycles,
        stats.overruns,
        stats.missed_periods,
        Num(period.avg_us),
        Num(period.min_us),
        Num(period.max_us),
        Num(exec.avg_us),
        Num(exec.max_us),
        Num(latency.avg_us),
        Num(latency.p99_us),
        Num(latency.max_us),
        stats.event_cycles,
        Num(event_exec.avg_us),
        Num(event_exec.max_us),
    );
    if let Some(stops) = figures.stops {
        let _ = write!(
            line,
            "stops_flushed={} stops_behind_queue={} ",
            stops.flushed, stops.behind_queue
        );
    }
    if let Some(f) = figures.fifo {
        let _ = write!(
            line,
            "board_stops={} lookahead={} fifo_min={} fifo_min_late_us={} fifo_min_ring={} \
             fifo_min_after_start={} fifo_min_moving={} dry_after_start={} dry_after_flush={} \
             underruns={} watchdog_trips={} board_late={} ",
            f.board_stops,
            f.lookahead,
            f.min_level.map_or("-".to_string(), |m| m.to_string()),
            f.min_late_us,
            f.min_ring,
            f.min_after_start,
            u8::from(f.min_moving),
            f.dry_after_start.map_or("-".to_string(), |m| m.to_string()),
            f.dry_after_flush.map_or("-".to_string(), |m| m.to_string()),
            f.underruns,
            f.watchdog_trips,
            f.board_late
        );
    }
    line.push_str("lat_hist=");
    let mut first = true;
    for (upper_us, count) in power_of_two_bins(&stats.latency) {
        let _ = write!(line, "{}{upper_us}:{count}", if first { "" } else { "," });
        first = false;
    }
    line
}

/// The histogram regrouped into power-of-two bins of microseconds: `(u, n)` says that `n`
/// samples lie in `[u/2, u)` µs (`u = 1`: under 1 µs). Empty bins are left out. A fine
/// bucket is counted in the bin of its middle (the fine buckets are 6.25 % wide).
pub fn power_of_two_bins(h: &wrc_rt::Histogram) -> Vec<(u64, u64)> {
    let mut bins: Vec<(u64, u64)> = Vec::new();
    for (bucket, &count) in h.bucket_counts().iter().enumerate() {
        if count == 0 {
            continue;
        }
        let (low_ns, high_ns) = bucket_range(bucket);
        let mid_us = (low_ns + (high_ns - low_ns) / 2) / 1000;
        let upper = if mid_us == 0 {
            1
        } else {
            (mid_us + 1).next_power_of_two()
        };
        match bins.last_mut() {
            Some((u, n)) if *u == upper => *n += count,
            _ => bins.push((upper, count)),
        }
    }
    bins
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::Ordering;

    #[test]
    fn bins_hold_their_samples() {
        let mut h = wrc_rt::Histogram::new();
        for ns in [200, 700, 1_300, 1_500, 2_500, 3_500, 40_000, 40_000, 70_000] {
            h.record(ns);
        }
        let bins = power_of_two_bins(&h);
        assert_eq!(bins, vec![(1, 2), (2, 2), (4, 2), (64, 2), (128, 1)]);
        assert_eq!(bins.iter().map(|b| b.1).sum::<u64>(), h.count());
    }

    #[test]
    fn the_demo_cells_signals_are_named_for_robot() {
        let config = wrc_config::Config::embedded_default();
        let stations = wrc_cell::Stations::embedded_demo();
        let interlocks = interlocks(&stations);
        assert_eq!(interlocks, [(14, "interlock LP1 LP2".to_string())]);
        let lines = signal_lines(&config.signals(&interlocks));
        assert_eq!(
            lines,
            [
                "out 0 guarded vacuum valve",
                "out 1 - mapping sensor",
                "in 0 - vacuum sensor",
                "in 14 - interlock LP1 LP2",
                "in 15 - E-stop button",
            ]
        );
        // Each line reads back as the contract says: direction, number, guard, name.
        for l in &lines {
            let mut w = l.splitn(4, ' ');
            assert!(matches!(w.next(), Some("in" | "out")), "{l}");
            assert!(w.next().unwrap().parse::<u8>().unwrap() < 32, "{l}");
            assert!(matches!(w.next(), Some("guarded" | "-")), "{l}");
            assert!(!w.next().unwrap().is_empty(), "{l}");
        }
        // A very long name is cut to keep the line short.
        let long = wrc_config::Signal {
            dir: wrc_config::SignalDir::In,
            n: 3,
            guarded: false,
            name: "x".repeat(300),
        };
        assert_eq!(signal_lines(&[long])[0].len(), "in 3 - ".len() + 200);
    }

    #[test]
    fn robot_reply_lists_every_axis() {
        let robot = Robot::paper_default();
        let (axes, ack) = robot_reply(&robot, 10.0, None);
        assert!(!ack.contains("blade_b"), "{ack}");
        assert!(robot_reply(&robot, 10.0, Some(-30.0))
            .1
            .ends_with(" blade_b=-30"));
        assert_eq!(axes.len(), robot.axis_count());
        assert_eq!(
            axes[0],
            "1 name=j1 role=shoulder unit=deg ppu=1000 min=-180 max=180 home=-75"
        );
        assert!(
            ack.contains("link1=200 link2=200 hand=0 axes=4 period_ms=10"),
            "{ack}"
        );
    }

    /// The longest `EVT TASK` line (the Pulse Generator's, after months at 1 kHz: every
    /// counter large, every latency bin from 1 µs to 2 s filled) fits a reply line whole;
    /// cut, it would lose its histogram.
    #[test]
    fn the_longest_task_line_fits_a_reply_line() {
        let stats = StatsCell::new();
        for bin in 0..22 {
            for _ in 0..3 {
                stats.record(&wrc_rt::stats::CycleSample {
                    period_ns: Some(1_000_000 + (1u64 << bin) * 1_000),
                    exec_ns: 123_456_789,
                    latency_ns: (1u64 << bin) * 1_000 + 777,
                    overrun: true,
                    missed_periods: 1_000_000,
                });
            }
            stats.record_event(987_654_321);
        }
        let shared = Arc::new(Shared::default());
        shared.stops.flushed.store(u64::MAX / 2, Ordering::Relaxed);
        shared
            .stops
            .behind_queue
            .store(u64::MAX / 2, Ordering::Relaxed);
        let f = &shared.fifo;
        f.lookahead.store(255, Ordering::Relaxed);
        f.min_level.store(0, Ordering::Relaxed);
        f.min_late_us.store(u32::MAX - 1, Ordering::Relaxed);
        f.min_ring.store(u32::MAX - 1, Ordering::Relaxed);
        f.min_after_start.store(u32::MAX - 1, Ordering::Relaxed);
        f.dry_after_start.store(u32::MAX - 1, Ordering::Relaxed);
        f.dry_after_flush.store(u32::MAX - 1, Ordering::Relaxed);
        for c in [
            &f.underruns,
            &f.watchdog_trips,
            &f.board_late,
            &f.board_stops,
        ] {
            c.store(u64::MAX / 2, Ordering::Relaxed);
        }
        let cell = TaskCell::new(Arc::new(stats), Some(shared));
        let text = task_line(
            &TaskSpec::new("pulse_generator", 80, 1_000),
            &cell.snapshot(),
        );
        let mut buf = wrc_protocol::ReplyBuf::new();
        let line = buf.event(true, &wrc_protocol::Event::Task(&text)).to_vec();
        assert!(!buf.is_truncated(), "{} bytes: {text}", text.len());
        // And it travels to the client whole, its newline included.
        let out = crate::messages::OutLine::new(crate::messages::SourceId::NONE, &line);
        assert_eq!(out.bytes(), &line[..]);
        let line = String::from_utf8(line).unwrap();
        assert!(line.contains(",2097152:3"), "{line}");
    }

    #[test]
    fn task_line_of_an_idle_task_is_all_zero() {
        let spec = TaskSpec::new("pulse_generator", 20, 10_000);
        let line = task_line(&spec, &TaskFigures::default());
        assert!(
            line.starts_with("pulse_generator prio=20 period_ms=10 cycles=0"),
            "{line}"
        );
        assert!(
            line.ends_with("ev_cycles=0 ev_exec_avg_us=0 ev_exec_max_us=0 lat_hist="),
            "{line}"
        );
    }

    #[test]
    fn task_line_shows_event_cycles_apart_from_periodic_ones() {
        let cell = StatsCell::new();
        cell.record_event(12_000);
        cell.record_event(4_000);
        let cell = TaskCell::new(Arc::new(cell), None);
        let line = task_line(&TaskSpec::new("ethernet", 45, 100_000), &cell.snapshot());
        assert!(line.contains(" cycles=0 "), "{line}");
        assert!(
            line.contains(" ev_cycles=2 ev_exec_avg_us=8 ev_exec_max_us=12 "),
            "{line}"
        );
    }

    #[test]
    fn the_pulse_generators_line_counts_its_stops_by_how_they_braked() {
        let shared = Arc::new(Shared::default());
        let cell = TaskCell::new(Arc::new(StatsCell::new()), Some(shared.clone()));
        let spec = TaskSpec::new("pulse_generator", 20, 10_000);
        let line = task_line(&spec, &cell.snapshot());
        assert!(
            line.ends_with(
                " stops_flushed=0 stops_behind_queue=0 board_stops=0 lookahead=2 fifo_min=- \
                 fifo_min_late_us=0 fifo_min_ring=0 fifo_min_after_start=0 fifo_min_moving=0 \
                 dry_after_start=- dry_after_flush=- \
                 underruns=0 watchdog_trips=0 board_late=0 lat_hist="
            ),
            "{line}"
        );
        shared.stops.flushed.fetch_add(3, Ordering::Relaxed);
        shared.stops.behind_queue.fetch_add(1, Ordering::Relaxed);
        shared.fifo.min_level.fetch_min(7, Ordering::Relaxed);
        shared.fifo.min_late_us.store(1_250, Ordering::Relaxed);
        shared.fifo.dry_after_start.store(3, Ordering::Relaxed);
        shared.fifo.underruns.store(4, Ordering::Relaxed);
        let line = task_line(&spec, &cell.snapshot());
        assert!(
            line.contains(
                " ev_exec_max_us=0 stops_flushed=3 stops_behind_queue=1 board_stops=0 \
                 lookahead=2 fifo_min=7 fifo_min_late_us=1250 fifo_min_ring=0 \
                 fifo_min_after_start=0 fifo_min_moving=0 dry_after_start=3 dry_after_flush=- underruns=4 "
            ),
            "{line}"
        );
    }
}
