//! SVG plot of output pulses per axis over time, like the paper's Fig. 7 (PTP) and Fig. 8
//! (straight line).

use std::path::Path;

use plotters::prelude::*;
use wrc_robot::Robot;

/// One CSV row: the pulses of period k and the commanded pulse position after it.
pub struct Row {
    /// Period index (0 = the state before the move).
    pub k: u64,
    /// Pulses emitted in the period, per axis.
    pub pulses: Vec<i64>,
    /// Commanded position after the period [pulse].
    pub position: Vec<i64>,
}

/// Line colours, one per axis in axis order (wrapping after six).
pub(crate) const COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
];

/// The series' legend, as every wrc plot draws it: upper right, on a white box.
pub(crate) fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

/// Draw `rows` (pulses per period, per axis) against time into an SVG file.
pub fn pulses_svg(
    path: &Path,
    title: &str,
    robot: &Robot,
    period_s: f64,
    rows: &[Row],
) -> anyhow::Result<()> {
    let t_max = (rows.len().max(2) - 1) as f64 * period_s;
    let (mut lo, mut hi) = (0i64, 1i64);
    for row in rows {
        for &p in &row.pulses {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    let pad = ((hi - lo) as f64 * 0.05).max(1.0);
    let root = SVGBackend::new(path, (1000, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..t_max, (lo as f64 - pad)..(hi as f64 + pad))?;
    chart
        .configure_mesh()
        .x_desc("time [s]")
        .y_desc("output pulses per period")
        .draw()?;
    for (i, axis) in robot.axes().iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let points = rows
            .iter()
            .map(|r| (r.k as f64 * period_s, r.pulses[i] as f64));
        chart
            .draw_series(LineSeries::new(points, colour.stroke_width(2)))?
            .label(axis.name.as_str())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
    }
    legend(&mut chart)?;
    root.present()?;
    Ok(())
}
