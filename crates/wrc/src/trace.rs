//! `wrc trace`: inspect a recorded trace (docs/trace.md) — `info` prints what it holds,
//! `plot` draws it as an SVG of stacked panels on one time axis.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use wrc_trace::{Direction, Sample, TraceFile};

use crate::plot::COLOURS;

/// Arguments of `wrc trace`.
#[derive(Debug, clap::Args)]
pub struct TraceArgs {
    #[command(subcommand)]
    action: TraceAction,
}

#[derive(Debug, clap::Subcommand)]
enum TraceAction {
    /// Draw a trace as SVG: positions, velocities, the robot state and the I/O bits over
    /// time, with a mark at every request received.
    Plot(PlotArgs),
    /// Print what a trace holds: why it was saved, its period and axes, its time span, its
    /// samples and messages, the states and errors seen.
    Info(InfoArgs),
    /// Ask a running controller to save its trace (TRACE SAVE) and print where it went.
    Save(crate::trace_replay::SaveArgs),
    /// Run a recorded session again under virtual time and report the first period where
    /// what the controller does differs from the recording (none, for a trace of this build).
    Replay(crate::trace_replay::ReplayArgs),
}

/// Arguments of `wrc trace plot`.
#[derive(Debug, clap::Args)]
struct PlotArgs {
    /// The trace file.
    file: PathBuf,
    /// The SVG to write (default: FILE with the extension .svg).
    #[arg(long, value_name = "OUT.svg")]
    out: Option<PathBuf>,
    /// Start of the window on the controller clock [s], as `wrc trace info` shows it
    /// (default: the first sample).
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    from: Option<f64>,
    /// End of the window on the controller clock [s] (default: the last sample).
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    to: Option<f64>,
}

/// Arguments of `wrc trace info`.
#[derive(Debug, clap::Args)]
struct InfoArgs {
    /// The trace file.
    file: PathBuf,
}

/// Run `wrc trace`.
pub fn run(args: TraceArgs) -> anyhow::Result<ExitCode> {
    match args.action {
        TraceAction::Plot(args) => plot(args),
        TraceAction::Info(args) => info(args),
        TraceAction::Save(args) => crate::trace_replay::save(args),
        TraceAction::Replay(args) => crate::trace_replay::replay(args),
    }
}

fn info(args: InfoArgs) -> anyhow::Result<ExitCode> {
    let trace = TraceFile::load(&args.file)?;
    print!("{}", trace.summary());
    Ok(ExitCode::SUCCESS)
}

fn plot(args: PlotArgs) -> anyhow::Result<ExitCode> {
    let trace = TraceFile::load(&args.file)?;
    let window = Window::of(&trace, args.from, args.to)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| args.file.with_extension("svg"));
    let title = format!("{} — {}", args.file.display(), trace.meta.reason);
    draw(&out, &title, &trace, &window)
        .with_context(|| format!("cannot write the plot {}", out.display()))?;
    eprintln!(
        "wrc: plot of {} samples (t = {:.3} s to {:.3} s) written to {}",
        window.samples.len(),
        window.seconds.start,
        window.seconds.end,
        out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// The part of a trace a plot shows.
struct Window<'a> {
    /// The time axis [s on the controller clock].
    seconds: Range<f64>,
    /// The samples within it.
    samples: &'a [Sample],
    /// Times of the requests received within it [s].
    requests: Vec<f64>,
}

impl<'a> Window<'a> {
    /// The samples between `from` and `to` [s] (default: all), at least one.
    fn of(trace: &'a TraceFile, from: Option<f64>, to: Option<f64>) -> anyhow::Result<Window<'a>> {
        for (option, value) in [("--from", from), ("--to", to)] {
            if value.is_some_and(|v| !v.is_finite()) {
                bail!("{option} must be a number of seconds");
            }
        }
        let (Some(first), Some(last)) = (trace.samples.first(), trace.samples.last()) else {
            bail!("the trace holds no samples: there is nothing to plot");
        };
        let from = from.unwrap_or(seconds(first.t_ns));
        let to = to.unwrap_or(seconds(last.t_ns));
        if from > to {
            bail!("--from ({from} s) is after --to ({to} s): give a window that starts before it ends");
        }
        let inside = |t_ns: u64| (from..=to).contains(&seconds(t_ns));
        let start = trace.samples.partition_point(|s| seconds(s.t_ns) < from);
        let end = start + trace.samples[start..].partition_point(|s| inside(s.t_ns));
        if start == end {
            bail!(
                "no samples between {from} s and {to} s: the trace covers {:.3} s to {:.3} s",
                seconds(first.t_ns),
                seconds(last.t_ns)
            );
        }
        // A window of one instant still gets a visible width: one period.
        let period = (trace.meta.period_ns.max(1) as f64 / 1e9).max(1e-6);
        let end_s = if to > from { to } else { from + period };
        let requests = trace
            .messages
            .iter()
            .filter(|m| m.direction == Direction::Request && inside(m.t_ns))
            .map(|m| seconds(m.t_ns))
            .collect();
        Ok(Window {
            seconds: from..end_s,
            samples: &trace.samples[start..end],
            requests,
        })
    }
}

fn seconds(t_ns: u64) -> f64 {
    t_ns as f64 / 1e9
}

/// Commanded velocity per sample [pulse/s]: the change of commanded position since the
/// previous sample over the time between them; none for the first sample or equal times.
fn velocities(samples: &[Sample], axis: usize) -> Vec<(f64, f64)> {
    samples
        .windows(2)
        .filter(|w| w[1].t_ns > w[0].t_ns)
        .map(|w| {
            let dt = seconds(w[1].t_ns - w[0].t_ns);
            let dp = w[1].commanded[axis].wrapping_sub(w[0].commanded[axis]) as f64;
            (seconds(w[1].t_ns), dp / dt)
        })
        .collect()
}

/// A step line of `value` per sample: it holds each value until the next sample.
fn steps(samples: &[Sample], value: impl Fn(&Sample) -> f64) -> Vec<(f64, f64)> {
    let mut points: Vec<(f64, f64)> = Vec::with_capacity(samples.len() * 2);
    for (i, s) in samples.iter().enumerate() {
        let (t, v) = (seconds(s.t_ns), value(s));
        if i > 0 {
            points.push((t, points[points.len() - 1].1));
        }
        points.push((t, v));
    }
    points
}

/// The I/O bits a plot shows: those set in at least one sample, inputs first.
fn io_lanes(samples: &[Sample]) -> Vec<(String, bool, u32)> {
    let (mut inputs, mut outputs) = (0u32, 0u32);
    for s in samples {
        inputs |= s.inputs;
        outputs |= s.outputs;
    }
    let ins = (0..32)
        .filter(|b| inputs >> b & 1 == 1)
        .map(|b| (format!("in {b}"), true, b));
    let outs = (0..32)
        .filter(|b| outputs >> b & 1 == 1)
        .map(|b| (format!("out {b}"), false, b));
    ins.chain(outs).collect()
}

/// A range around `lo..=hi` with 5 % room, never empty.
fn padded(lo: f64, hi: f64) -> Range<f64> {
    let pad = ((hi - lo) * 0.05).max(1.0);
    (lo - pad)..(hi + pad)
}

const LABEL_AREA: u32 = 90;
/// Colour of the request marks: apart from the axis colours.
const MARK: RGBColor = RGBColor(140, 86, 75);

/// Draw `window` of `trace` into the SVG `out`: positions, velocities, state and I/O, each
/// a panel on the same time axis, with the requests marked on each.
fn draw(out: &Path, title: &str, trace: &TraceFile, window: &Window<'_>) -> anyhow::Result<()> {
    let root = SVGBackend::new(out, (1200, 1250)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 20))?;
    let heights = root.dim_in_pixel().1;
    let cuts = [heights * 36 / 100, heights * 62 / 100, heights * 77 / 100];
    let panels = root.split_by_breakpoints([] as [u32; 0], cuts);
    positions_panel(&panels[0], trace, window)?;
    velocities_panel(&panels[1], trace, window)?;
    state_panel(&panels[2], trace, window)?;
    io_panel(&panels[3], window)?;
    root.present()?;
    Ok(())
}

type Panel<'b> = DrawingArea<SVGBackend<'b>, Shift>;
type Chart<'p, 'b> = ChartContext<'p, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A chart on `area` over the window's time axis and `y`; the time is labelled only on the
/// bottom panel.
fn chart<'p, 'b>(
    area: &'p Panel<'b>,
    window: &Window<'_>,
    y: Range<f64>,
    bottom: bool,
) -> anyhow::Result<Chart<'p, 'b>> {
    Ok(ChartBuilder::on(area)
        .margin(8)
        .x_label_area_size(if bottom { 40 } else { 22 })
        .y_label_area_size(LABEL_AREA)
        .build_cartesian_2d(window.seconds.clone(), y)?)
}

/// A thin vertical line at every request, across `y`; in the legend as `request` when
/// `legend`.
fn mark_requests(
    chart: &mut Chart<'_, '_>,
    window: &Window<'_>,
    y: &Range<f64>,
    legend: bool,
) -> anyhow::Result<()> {
    let style = MARK.mix(0.8).stroke_width(1);
    let marks = chart.draw_series(
        window
            .requests
            .iter()
            .map(|&t| PathElement::new(vec![(t, y.start), (t, y.end)], style)),
    )?;
    if legend {
        marks
            .label("request")
            .legend(move |(x, y)| PathElement::new(vec![(x + 10, y - 6), (x + 10, y + 6)], style));
    }
    Ok(())
}

fn positions_panel(area: &Panel<'_>, trace: &TraceFile, window: &Window<'_>) -> anyhow::Result<()> {
    let axes = trace.axis_count();
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for s in window.samples {
        for p in s.commanded[..axes].iter().chain(&s.actual[..axes]) {
            lo = lo.min(*p as f64);
            hi = hi.max(*p as f64);
        }
    }
    if lo > hi {
        (lo, hi) = (0.0, 0.0);
    }
    let y = padded(lo, hi);
    let mut chart = chart(area, window, y.clone(), false)?;
    chart
        .configure_mesh()
        .y_desc("position [pulse]")
        .y_label_formatter(&|v| format!("{v:.0}"))
        .draw()?;
    mark_requests(&mut chart, window, &y, !window.requests.is_empty())?;
    for (i, name) in trace.meta.axis_names.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let commanded: Vec<(f64, f64)> = window
            .samples
            .iter()
            .map(|s| (seconds(s.t_ns), s.commanded[i] as f64))
            .collect();
        let actual: Vec<(f64, f64)> = window
            .samples
            .iter()
            .map(|s| (seconds(s.t_ns), s.actual[i] as f64))
            .collect();
        chart
            .draw_series(LineSeries::new(commanded, colour.stroke_width(2)))?
            .label(format!("{name} commanded"))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        let light = colour.mix(0.55).stroke_width(1);
        chart
            .draw_series(DashedLineSeries::new(actual, 6, 4, light))?
            .label(format!("{name} actual"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], light));
    }
    crate::plot::legend(&mut chart)?;
    Ok(())
}

fn velocities_panel(
    area: &Panel<'_>,
    trace: &TraceFile,
    window: &Window<'_>,
) -> anyhow::Result<()> {
    let series: Vec<Vec<(f64, f64)>> = (0..trace.axis_count())
        .map(|i| velocities(window.samples, i))
        .collect();
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    for &(_, v) in series.iter().flatten() {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    let y = padded(lo, hi);
    let mut chart = chart(area, window, y.clone(), false)?;
    chart
        .configure_mesh()
        .y_desc("commanded velocity [pulse/s]")
        .y_label_formatter(&|v| format!("{v:.0}"))
        .draw()?;
    mark_requests(&mut chart, window, &y, false)?;
    for (i, points) in series.into_iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        chart.draw_series(LineSeries::new(points, colour.stroke_width(2)))?;
    }
    Ok(())
}

fn state_panel(area: &Panel<'_>, trace: &TraceFile, window: &Window<'_>) -> anyhow::Result<()> {
    let highest = window.samples.iter().map(|s| s.state).max().unwrap_or(0);
    // State codes are u8: at most 256 rows, whatever the table says.
    let count = (trace.meta.state_names.len().max(usize::from(highest) + 1)).min(256);
    let y = -0.5..(count as f64 - 0.5);
    let mut chart = chart(area, window, y.clone(), false)?;
    chart.configure_mesh().y_labels(0).y_desc("state").draw()?;
    let names: Vec<(f64, String)> = (0..count)
        .map(|s| (s as f64, trace.meta.state_name(s as u8)))
        .collect();
    name_rows(area, &chart, window, &names)?;
    mark_requests(&mut chart, window, &y, false)?;
    let points = steps(window.samples, |s| f64::from(s.state));
    chart.draw_series(LineSeries::new(points, BLACK.stroke_width(2)))?;
    Ok(())
}

fn io_panel(area: &Panel<'_>, window: &Window<'_>) -> anyhow::Result<()> {
    let lanes = io_lanes(window.samples);
    let y = -0.2..(lanes.len().max(1) as f64);
    let mut chart = chart(area, window, y.clone(), true)?;
    chart
        .configure_mesh()
        .y_labels(0)
        .x_desc("time [s]")
        .y_desc("I/O of board 0")
        .draw()?;
    let names: Vec<(f64, String)> = lanes
        .iter()
        .enumerate()
        .map(|(lane, (name, _, _))| (lane as f64 + 0.35, name.clone()))
        .collect();
    name_rows(area, &chart, window, &names)?;
    mark_requests(&mut chart, window, &y, false)?;
    if lanes.is_empty() {
        chart.draw_series(std::iter::once(Text::new(
            "no input or output bit is set in this window",
            (window.seconds.start, 0.5),
            ("sans-serif", 14),
        )))?;
    }
    for (lane, (_, input, bit)) in lanes.iter().enumerate() {
        let colour = if *input { COLOURS[0] } else { COLOURS[1] };
        let base = lane as f64;
        let points = steps(window.samples, |s| {
            let word = if *input { s.inputs } else { s.outputs };
            base + 0.7 * f64::from(word >> bit & 1)
        });
        chart.draw_series(LineSeries::new(points, colour.stroke_width(2)))?;
    }
    Ok(())
}

/// Write `rows` (height, name) left of the chart's y axis, where numbers would be: the
/// state and I/O panels name their rows instead of numbering them.
fn name_rows(
    area: &Panel<'_>,
    chart: &Chart<'_, '_>,
    window: &Window<'_>,
    rows: &[(f64, String)],
) -> anyhow::Result<()> {
    let (x0, y0) = area.get_base_pixel();
    let style = TextStyle::from(("sans-serif", 13)).pos(Pos::new(HPos::Right, VPos::Center));
    for (y, name) in rows {
        let (px, py) = chart.backend_coord(&(window.seconds.start, *y));
        area.draw(&Text::new(
            name.as_str(),
            (px - x0 - 6, py - y0),
            style.clone(),
        ))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use wrc_trace::{Message, Meta};

    fn trace() -> TraceFile {
        let samples = (0..5u64)
            .map(|k| {
                let mut s = Sample {
                    t_ns: 1_000_000_000 + k * 10_000_000,
                    state: u8::from(k >= 2),
                    inputs: if k == 3 { 0b100 } else { 0 },
                    ..Sample::default()
                };
                s.commanded[0] = (k * k) as i64;
                s
            })
            .collect();
        TraceFile {
            meta: Meta::new("test", 10_000_000, &["J1"], &["IDLE", "MOVING"]),
            samples,
            messages: vec![
                Message::new(1_015_000_000, Direction::Request, 0, 0, b"MOVE"),
                Message::new(1_016_000_000, Direction::Reply, 0, 0, b"ACK"),
                Message::new(5_000_000_000, Direction::Request, 0, 0, b"LATE"),
            ],
        }
    }

    #[test]
    fn the_window_keeps_its_samples_and_requests() {
        let t = trace();
        let w = Window::of(&t, None, None).unwrap();
        assert_eq!(w.samples.len(), 5);
        assert_eq!(w.requests, [1.015]);
        let w = Window::of(&t, Some(1.015), Some(1.03)).unwrap();
        assert_eq!(w.samples.len(), 2);
        assert_eq!(w.seconds, 1.015..1.03);
        // A window of one instant is widened to one period.
        let w = Window::of(&t, Some(1.02), Some(1.02)).unwrap();
        assert_eq!(w.samples.len(), 1);
        assert!(w.seconds.end > w.seconds.start);
    }

    #[test]
    fn an_empty_or_backwards_window_is_a_clear_error() {
        let t = trace();
        let err = Window::of(&t, Some(7.0), Some(8.0))
            .err()
            .unwrap()
            .to_string();
        assert_eq!(
            err,
            "no samples between 7 s and 8 s: the trace covers 1.000 s to 1.040 s"
        );
        let err = Window::of(&t, Some(2.0), Some(1.0))
            .err()
            .unwrap()
            .to_string();
        assert!(err.starts_with("--from (2 s) is after --to (1 s)"), "{err}");
        let err = Window::of(&t, Some(f64::NAN), None)
            .err()
            .unwrap()
            .to_string();
        assert_eq!(err, "--from must be a number of seconds");
    }

    #[test]
    fn velocity_is_the_change_over_the_time_between_samples() {
        let t = trace();
        let v = velocities(&t.samples, 0);
        // Commanded 0, 1, 4, 9, 16 pulses every 10 ms.
        let speeds: Vec<f64> = v.iter().map(|p| p.1).collect();
        assert_eq!(speeds, [100.0, 300.0, 500.0, 700.0]);
    }

    #[test]
    fn steps_hold_each_value_until_the_next_sample() {
        let t = trace();
        let s = steps(&t.samples[1..3], |s| f64::from(s.state));
        assert_eq!(s, [(1.01, 0.0), (1.02, 0.0), (1.02, 1.0)]);
        assert_eq!(io_lanes(&t.samples), [("in 2".to_string(), true, 2)]);
    }
}
