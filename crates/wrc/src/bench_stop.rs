//! `wrc bench stop`: stopping times and distances in the form of ISO 10218-1 Annex B — every
//! axis of the configured robot and a straight line of the TCP, at 33, 66 and 100 % speed,
//! the stop requested at peak acceleration and in cruise, ESTOP (stop category 1, full
//! limits) and STOP (the move's limits), measured from the velocity generator's output
//! pulses, next to the one-dimensional time-optimal brake from the same state (wrc-motion
//! measures; this module parses, prints and writes JSON).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use serde_json::json;
use wrc_motion::bench::stop::{default_line, table, RefBy, StopRow, Subject};
use wrc_motion::bench::LineCase;
use wrc_motion::BrakeLimits;
use wrc_robot::{Pose, Posture, Robot};

/// Arguments of `wrc bench stop`.
#[derive(Debug, Args)]
pub struct StopArgs {
    /// Speed overrides to measure at [%], comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "33,66,100")]
    speed: Vec<f64>,
    /// Pulse period [ms]; default from the configuration.
    #[arg(long, value_name = "MS")]
    period_ms: Option<f64>,
    /// Start of the straight line [mm, mm, mm, deg] (with --line-to; default: a 500 mm chord
    /// at 62.5 % of the reach, x = 250 mm for the default robot).
    #[arg(
        long,
        value_name = "X,Y,Z,YAW",
        value_delimiter = ',',
        num_args = 4,
        requires = "line_to"
    )]
    line_from: Option<Vec<f64>>,
    /// End of the straight line [mm, mm, mm, deg] (with --line-from).
    #[arg(
        long,
        value_name = "X,Y,Z,YAW",
        value_delimiter = ',',
        num_args = 4,
        requires = "line_from"
    )]
    line_to: Option<Vec<f64>>,
    /// Robot and limits from this config file instead of the embedded default.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Write every row as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

/// Run `wrc bench stop`.
pub fn run(args: StopArgs) -> anyhow::Result<ExitCode> {
    let (robot, settings) =
        crate::bench_motion::fir_settings(args.config.as_deref(), args.period_ms, &args.speed)?;
    let line = match (&args.line_from, &args.line_to) {
        (Some(a), Some(b)) => LineCase {
            start: pose(a),
            posture: Posture::Right,
            target: pose(b),
        },
        _ => default_line(&robot),
    };
    let generator = wrc_motion::VelocityGenerator::new(robot.clone(), settings)
        .map_err(|e| anyhow::anyhow!("{}: {}", e.key, e.reason))?;
    let rows = table(&generator, &args.speed, Some(line)).with_context(|| {
        format!(
            "the straight line {} -> {} (choose another with --line-from/--line-to)",
            show(&line.start),
            show(&line.target)
        )
    })?;
    let period_ms = settings.period_s * 1000.0;
    println!(
        "wrc bench stop: {}, period {period_ms} ms, speed override {:?} %",
        robot.name, args.speed
    );
    println!(
        "  stop requested at peak acceleration (mid-acceleration) or in cruise (half-way); \
         time = request to the last period with a pulse, distance = the pulses after the request \
         (a line: mm of TCP path)"
    );
    println!(
        "  reference = the time-optimal jerk-limited brake from the same state (scaled by the \
         override for STOP): an axis's 1-D brake; a line's, the longer of its TCP's 1-D brake \
         with the Cartesian limits (by tcp) and its path brake with every joint's limits too \
         (by path)"
    );
    println!(
        "  ESTOP = stop category 1 (IEC 60204-1) with every axis's full limits; STOP = the \
         move's override-scaled limits"
    );
    print_table(&robot, &rows, &line);
    if let Some(path) = &args.json {
        let doc = json!({
            "robot": robot.name,
            "period_ms": period_ms,
            "speeds_pct": args.speed,
            "line": { "from": pose_json(&line.start), "to": pose_json(&line.target) },
            "rows": rows.iter().map(|r| row_json(&robot, r)).collect::<Vec<_>>(),
        });
        std::fs::write(path, serde_json::to_string_pretty(&doc)? + "\n")
            .with_context(|| format!("cannot write {}", path.display()))?;
        println!("\n  JSON written to {}", path.display());
    }
    Ok(ExitCode::SUCCESS)
}

fn pose(v: &[f64]) -> Pose {
    Pose {
        x: v[0],
        y: v[1],
        z: v[2],
        yaw: v[3],
    }
}

fn show(p: &Pose) -> String {
    format!("({}, {}, {}, {})", p.x, p.y, p.z, p.yaw)
}

fn pose_json(p: &Pose) -> serde_json::Value {
    json!({ "x_mm": p.x, "y_mm": p.y, "z_mm": p.z, "yaw_deg": p.yaw })
}

/// The name and unit of what a row stopped.
fn subject(robot: &Robot, s: &Subject) -> (String, &'static str) {
    match s {
        Subject::Axis(i) => {
            let axis = &robot.axes()[*i];
            (axis.name.to_string(), axis.unit.as_str())
        }
        Subject::Line(_) => ("line".to_string(), "mm"),
    }
}

fn stop_name(limits: BrakeLimits) -> &'static str {
    match limits {
        BrakeLimits::Full => "ESTOP",
        BrakeLimits::Override => "STOP",
    }
}

fn print_table(robot: &Robot, rows: &[StopRow], line: &LineCase) {
    let mut current = None;
    for r in rows {
        let (name, unit) = subject(robot, &r.subject);
        if current.as_ref() != Some(&name) {
            match r.subject {
                Subject::Axis(_) => println!("\n{name} [{unit}], alone across its range"),
                Subject::Line(_) => println!(
                    "\nstraight line {} -> {} [mm of TCP path]",
                    show(&line.start),
                    show(&line.target)
                ),
            }
            println!(
                "  {:>5}  {:<6} {:<5} {:>12} {:>8} {:>8} {:>4} {:>6}  {:>9} {:>9} {:>4} {:>6}",
                "speed",
                "when",
                "stop",
                format!("v [{unit}/s]"),
                "time ms",
                "ref ms",
                "by",
                "ratio",
                format!("dist {unit}"),
                format!("ref {unit}"),
                "by",
                "ratio"
            );
            current = Some(name);
        }
        println!(
            "  {:>4}%  {:<6} {:<5} {:>12.1} {:>8.0} {:>8.1} {:>4} {:>6.3}  {:>9.3} {:>9.3} {:>4} {:>6.3}",
            r.speed_pct,
            r.phase.name(),
            stop_name(r.limits),
            r.speed,
            r.time_s * 1e3,
            r.ref_time_s * 1e3,
            binding(&r.subject, r.ref_time_by),
            r.time_ratio(),
            r.distance,
            r.ref_distance,
            binding(&r.subject, r.ref_distance_by),
            r.distance_ratio()
        );
    }
}

/// Which brake gives a reference: the axis's own, a line's TCP or its path brake.
fn binding(subject: &Subject, by: RefBy) -> &'static str {
    match (subject, by) {
        (Subject::Axis(_), _) => "",
        (Subject::Line(_), RefBy::OneD) => "tcp",
        (Subject::Line(_), RefBy::Path) => "path",
    }
}

fn row_json(robot: &Robot, r: &StopRow) -> serde_json::Value {
    let (name, unit) = subject(robot, &r.subject);
    json!({
        "subject": name,
        "unit": unit,
        "speed_pct": r.speed_pct,
        "when": r.phase.name(),
        "stop": stop_name(r.limits),
        "request_period": r.request_period,
        "speed_per_s": r.speed,
        "acceleration_per_s2": r.acceleration,
        "time_ms": r.time_s * 1e3,
        "distance": r.distance,
        "ref_time_ms": r.ref_time_s * 1e3,
        "ref_distance": r.ref_distance,
        "ref_time_by": binding(&r.subject, r.ref_time_by),
        "ref_distance_by": binding(&r.subject, r.ref_distance_by),
        "time_ratio": r.time_ratio(),
        "distance_ratio": r.distance_ratio(),
    })
}
