//! `wrc bench motion`: straight lines, arcs and blended paths against the time-optimal lower
//! bound, and the PTP blends against the same moves at rest between them. Random reachable
//! lines, arcs and paths of the configured robot (fixed seed, printed) are planned and run as
//! the controller runs them; the bench prints their durations over the lower bound, the
//! limits they used (from the output pulses), their accuracy (the TCP's distance from the
//! path, a blend's from its corner) and the planning time (wrc-motion measures; this module
//! parses, prints and writes JSON). Each PTP blend is planned twice, with the bounded
//! search the controller uses and with the exhaustive one (no budget, and a PTP's entries
//! into a path timed by the path's law, as before the search was bounded), in the same run.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use serde_json::json;
use wrc_motion::bench::paths::{
    random_joints, run_blend, run_path, Blend, BlendRun, Cycles, PathCase, PathRun,
};
use wrc_motion::bench::{median_max, run_line, LineRun, Lines};
use wrc_motion::{DoubleS, Profile};

/// Arguments of `wrc bench motion`.
#[derive(Debug, Args)]
pub struct MotionArgs {
    /// Random lines to run.
    #[arg(long, default_value_t = 200, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    lines: u32,
    /// Random long lines (700 mm and more) to run besides, for the planning costs of the
    /// longest lines.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    long_lines: u32,
    /// Random arcs to run (through a via point, up to 300° of sweep).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    arcs: u32,
    /// Random paths of 2 to 5 lines and arcs, every corner blended, to run.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    paths: u32,
    /// PTP blends to run of each kind (into a path, out of one, through a via point), on the
    /// first of the random paths.
    #[arg(long, default_value_t = 50, value_parser = clap::value_parser!(u32).range(0..=100_000))]
    blends: u32,
    /// Seed of the random lines (the same seed gives the same lines on every machine).
    #[arg(long, default_value_t = 2026)]
    seed: u64,
    /// Speed overrides to run every line at [%], comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "100,30")]
    speed: Vec<f64>,
    /// Pulse period [ms]; default from the configuration.
    #[arg(long, value_name = "MS")]
    period_ms: Option<f64>,
    /// Robot and limits from this config file instead of the embedded default.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Write every figure as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

/// The robot and the motion settings a motion benchmark runs with: the configuration (or the
/// embedded default), the default profile, `--period-ms` if given; every setting and every
/// `--speed` checked, an error naming the option that set a bad value.
pub(crate) fn fir_settings(
    config: Option<&std::path::Path>,
    period_ms: Option<f64>,
    speeds: &[f64],
) -> anyhow::Result<(wrc_robot::Robot, wrc_motion::MotionSettings)> {
    let config = wrc_config::Config::load(config)?;
    let mut settings = config.motion;
    settings.profile = Profile::Fir;
    if let Some(ms) = period_ms {
        settings.period_s = ms / 1000.0;
    }
    settings.validate().map_err(|e| {
        // Name the option that set it, when an option did.
        let key = match e.key.as_str() {
            "motion.period_ms" if period_ms.is_some() => "--period-ms",
            other => other,
        };
        anyhow::anyhow!("{key}: {}", e.reason)
    })?;
    for &pct in speeds {
        wrc_motion::check_speed_pct(pct).map_err(|e| anyhow::anyhow!("--speed: {}", e.reason))?;
    }
    Ok((config.robot, settings))
}

/// Run `wrc bench motion`.
pub fn run(args: MotionArgs) -> anyhow::Result<ExitCode> {
    let (robot, settings) = fir_settings(args.config.as_deref(), args.period_ms, &args.speed)?;
    let cycles = vg_cycles(args.config.as_deref(), settings.period_s)?;
    println!(
        "wrc bench motion: {} random reachable lines and {} long ones of {} (seed {}), period {} ms, speeds {:?} %",
        args.lines,
        args.long_lines,
        robot.name,
        args.seed,
        settings.period_s * 1000.0,
        args.speed
    );
    // The lines: uniform ends over the reachable disc, Z range and every yaw; candidates the
    // planner refuses are counted by reason.
    let mut lines = Lines::new(args.seed);
    let mut refused = std::collections::BTreeMap::<String, u32>::new();
    let mut count = |e: &wrc_motion::PlanError| {
        *refused.entry(refusal_kind(e)).or_default() += 1;
    };
    let cases: Vec<_> = (0..args.lines)
        .map(|_| lines.next_line(&robot, &mut count))
        .collect();
    let long: Vec<_> = (0..args.long_lines)
        .map(|_| lines.next_long_line(&robot, &mut count))
        .collect();
    // Arcs and paths (their refusals counted apart), and the other ends of the blends.
    let mut path_refused = std::collections::BTreeMap::<String, u32>::new();
    let mut count_path = |e: &wrc_motion::PlanError| {
        *path_refused.entry(refusal_kind(e)).or_default() += 1;
    };
    let arcs: Vec<_> = (0..args.arcs)
        .map(|_| lines.next_arc(&robot, &mut count_path))
        .collect();
    let paths: Vec<_> = (0..args.paths)
        .map(|_| lines.next_path(&robot, &mut count_path))
        .collect();
    let blends: Vec<_> = paths
        .iter()
        .take(args.blends as usize)
        .map(|case| {
            let mut other = || random_joints(&mut lines, &robot, case.posture);
            (*case, other(), other(), other())
        })
        .collect();
    println!(
        "  candidates refused by the planner (an end out of reach, or a point of the line): {}",
        refused
            .iter()
            .map(|(k, v)| format!("{k} {v}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    println!(
        "  arc and path candidates refused by the planner: {}",
        path_refused
            .iter()
            .map(|(k, v)| format!("{k} {v}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut report = Vec::new();
    for &pct in &args.speed {
        let mut s = settings;
        s.speed_pct = pct;
        let generator = wrc_motion::VelocityGenerator::new(robot.clone(), s)
            .map_err(|e| anyhow::anyhow!("{}: {}", e.key, e.reason))?;
        let run_all = |cases: &[wrc_motion::bench::LineCase]| -> anyhow::Result<Vec<LineRun>> {
            cases
                .iter()
                .map(|case| {
                    run_line(&generator, case).with_context(|| format!("planning {case:?}"))
                })
                .collect()
        };
        let runs = run_all(&cases)?;
        let figures = summarise(&runs, &robot, &s);
        print_figures(pct, "random lines", &figures);
        let long_runs = run_all(&long)?;
        let long_figures = (!long_runs.is_empty()).then(|| summarise(&long_runs, &robot, &s));
        if let Some(f) = &long_figures {
            print_figures(pct, "long lines", f);
        }
        if let Some(worst) = runs.iter().max_by(|a, b| a.ratio().total_cmp(&b.ratio())) {
            let p = |p: &wrc_robot::Pose| format!("{},{},{},{}", p.x, p.y, p.z, p.yaw);
            println!(
                "  slowest line: wrc plan line --from={} --to={} --posture {} --speed {pct}  ({:.3} s, {:.3}x)",
                p(&worst.case.start),
                p(&worst.case.target),
                match worst.case.posture {
                    wrc_robot::Posture::Right => "right",
                    wrc_robot::Posture::Left => "left",
                },
                worst.duration_s,
                worst.ratio()
            );
        }
        let run_paths = |cases: &[PathCase]| -> anyhow::Result<Vec<PathRun>> {
            cases
                .iter()
                .map(|case| {
                    run_path(&generator, case).with_context(|| format!("planning {case:?}"))
                })
                .collect()
        };
        let arc_figures = (!arcs.is_empty())
            .then(|| run_paths(&arcs).map(|r| summarise_paths(&r)))
            .transpose()?;
        if let Some(f) = &arc_figures {
            print_path_figures(pct, "arcs", f);
        }
        let path_figures = (!paths.is_empty())
            .then(|| run_paths(&paths).map(|r| summarise_paths(&r)))
            .transpose()?;
        if let Some(f) = &path_figures {
            print_path_figures(pct, "blended paths", f);
        }
        let blend_figures = (!blends.is_empty())
            .then(|| run_blends(&generator, &blends, cycles))
            .transpose()?;
        if let Some(f) = &blend_figures {
            print_blend_figures(pct, f);
        }
        report.push(json!({
            "speed_pct": pct,
            "figures": figures,
            "long_lines": long_figures,
            "arcs": arc_figures,
            "blended_paths": path_figures,
            "ptp_blends": blend_figures,
        }));
    }
    if let Some(path) = &args.json {
        let doc = json!({
            "robot": robot.name,
            "seed": args.seed,
            "lines": args.lines,
            "period_ms": settings.period_s * 1000.0,
            "refused_candidates": refused,
            "arcs": args.arcs,
            "paths": args.paths,
            "refused_path_candidates": path_refused,
            "runs": report,
        });
        std::fs::write(path, serde_json::to_string_pretty(&doc)?)
            .with_context(|| format!("cannot write {}", path.display()))?;
        println!("  JSON written to {}", path.display());
    }
    Ok(ExitCode::SUCCESS)
}

/// How the controller's Velocity Generator produces a move's periods with this
/// configuration: in the cycle that plans it, as many as its pulse ring holds (two of its
/// periods' worth and twice the Pulse Generator's look-ahead, as the controller sizes it),
/// then one of its periods' worth a cycle.
fn vg_cycles(config: Option<&std::path::Path>, period_s: f64) -> anyhow::Result<Cycles> {
    let config = wrc_config::Config::load(config)?;
    let vg_s = config
        .tasks
        .get("velocity_generator")
        .map_or(0.05, |t| t.period_us as f64 * 1e-6);
    let then = (vg_s / period_s).ceil().max(1.0) as usize;
    let lookahead_s = config.lookahead_periods as f64 * config.motion.period_s;
    let lookahead = ((lookahead_s / period_s) - 1e-9).ceil().max(1.0) as usize;
    Ok(Cycles {
        first: (2 * then + 2 * lookahead).clamp(16, 4096),
        then,
    })
}

fn refusal_kind(e: &wrc_motion::PlanError) -> String {
    use wrc_motion::{PathProblem, PlanError};
    match e {
        PlanError::PathLeavesWorkspace { problem, .. }
        | PlanError::SegmentLeavesWorkspace { problem, .. } => match problem {
            PathProblem::JointLimit { axis, .. } => format!("{axis} beyond its limits on the line"),
            PathProblem::Stretched { .. } | PathProblem::Folded { .. } => {
                "singularity on the line".into()
            }
            _ => "other path problem".into(),
        },
        PlanError::PostureChange => "posture change".into(),
        PlanError::Arc { .. } => "arc on a line".into(),
        PlanError::CornerTurnsBack { .. } => "corner turning back".into(),
        PlanError::SharpCorner { .. } => "sharp corner".into(),
        PlanError::Untimed { .. } => "untimed".into(),
        PlanError::Kinematics(_) => "end out of reach".into(),
        _ => "other".into(),
    }
}

/// Every figure of one speed, as JSON.
fn summarise(
    runs: &[LineRun],
    robot: &wrc_robot::Robot,
    s: &wrc_motion::MotionSettings,
) -> serde_json::Value {
    let ratios: Vec<f64> = runs.iter().map(LineRun::ratio).collect();
    let ratios_joints: Vec<f64> = runs
        .iter()
        .map(|r| r.duration_s / r.bound.with_joints_s())
        .collect();
    // The planner this replaces: the same line at limits constant along it (the worst
    // point's), one double-S in u.
    let before: Vec<f64> = runs
        .iter()
        .filter_map(|r| {
            let start = robot.inverse(&r.case.start, r.case.posture, None).ok()?;
            let from = robot.pulses_to_joints(&robot.joints_to_pulses(&start));
            let (path, check) = wrc_motion::check_line(robot, &from, &r.case.target).ok()?;
            let l = check.constant_limits(robot, path.length_mm(), &s.line, s.speed_pct / 100.0);
            (l.v > 0.0).then(|| {
                DoubleS::time_optimal(1.0, l.v, l.a, l.j).duration() / r.bound.lower_bound_s()
            })
        })
        .collect();
    let ms = |f: fn(&LineRun) -> f64| runs.iter().map(|r| f(r) * 1e3).collect::<Vec<f64>>();
    let plan_ms = ms(|r| r.plan_s);
    let start_ms = ms(|r| r.start_s);
    let period_max_ms = ms(|r| r.period_max_s);
    // The law's cost per 10 ms of motion, averaged over each line.
    let per_10ms: Vec<f64> = runs
        .iter()
        .map(|r| r.periods_total_s * 1e3 / (r.duration_s / 0.010))
        .collect();
    let over_limit = runs.iter().filter(|r| !r.limits.within(1e-6)).count();
    let max_use = |k: usize, pulses: bool| {
        runs.iter()
            .map(|r| {
                if pulses {
                    r.limits.pulses[k]
                } else {
                    r.limits.exact[k]
                }
            })
            .fold(0.0f64, f64::max)
    };
    let (rm, rx) = median_max(&ratios);
    let (jm, jx) = median_max(&ratios_joints);
    let (bm, bx) = median_max(&before);
    let (pm, px) = median_max(&plan_ms);
    let (sm, sx) = median_max(&start_ms);
    let (qm, qx) = median_max(&period_max_ms);
    let (tm, tx) = median_max(&per_10ms);
    let lengths: Vec<f64> = runs.iter().map(|r| r.length_mm).collect();
    let (len_m, len_x) = median_max(&lengths);
    json!({
        "lines": runs.len(),
        "length_mm": { "median": len_m, "max": len_x },
        "ratio_to_lower_bound": { "median": rm, "max": rx },
        "ratio_to_lower_bound_with_joint_jerk": { "median": jm, "max": jx },
        "ratio_before_constant_limits": { "median": bm, "max": bx },
        "lines_over_a_limit": over_limit,
        "limit_use_exact": { "v": max_use(0, false), "a": max_use(1, false), "j": max_use(2, false) },
        "limit_use_pulses": { "v": max_use(0, true), "a": max_use(1, true), "j": max_use(2, true) },
        "max_deviation_mm": runs.iter().map(|r| r.deviation_mm).fold(0.0f64, f64::max),
        "exact_end": runs.iter().filter(|r| r.exact_end).count(),
        "plan_ahead_ms": { "median": pm, "max": px },
        "start_ms": { "median": sm, "max": sx },
        "period_max_ms": { "median": qm, "max": qx },
        "law_ms_per_10ms_of_motion": { "median": tm, "max": tx },
    })
}

/// The number at `path` in the figures `f` (NaN where there is none).
fn figure(f: &serde_json::Value, path: &[&str]) -> f64 {
    path.iter()
        .fold(f, |v, p| &v[*p])
        .as_f64()
        .unwrap_or(f64::NAN)
}

/// The limits used, from the exact positions and from the output pulses.
fn print_limit_use(f: &serde_json::Value) {
    for (label, key) in [
        ("exact positions", "limit_use_exact"),
        ("output pulses less rounding", "limit_use_pulses"),
    ] {
        println!(
            "  limit use (v a j), {label}: {:.4} {:.4} {:.4}",
            figure(f, &[key, "v"]),
            figure(f, &[key, "a"]),
            figure(f, &[key, "j"])
        );
    }
}

fn print_figures(pct: f64, what: &str, f: &serde_json::Value) {
    let g = |path: &[&str]| figure(f, path);
    println!(
        "\nspeed {pct} %, {what}: {} lines, length median {:.0} mm, max {:.0} mm",
        f["lines"],
        g(&["length_mm", "median"]),
        g(&["length_mm", "max"])
    );
    let median_max_rows = [
        (
            "duration / lower bound (TOPP-RA v/a; TCP 1-D jerk)",
            "ratio_to_lower_bound",
        ),
        (
            "… with each joint's 1-D jerk-limited time too",
            "ratio_to_lower_bound_with_joint_jerk",
        ),
        (
            "the previous planner (limits constant along a line)",
            "ratio_before_constant_limits",
        ),
        (
            "start of a line (check of every point, derivative table) [ms]",
            "start_ms",
        ),
        (
            "timing law as it runs, per 10 ms of motion [ms]",
            "law_ms_per_10ms_of_motion",
        ),
        ("the longest single period [ms]", "period_max_ms"),
        (
            "the whole law run ahead (wrc plan; for the duration) [ms]",
            "plan_ahead_ms",
        ),
    ];
    for (label, key) in median_max_rows {
        println!(
            "  {label}: median {:.3}  max {:.3}",
            g(&[key, "median"]),
            g(&[key, "max"])
        );
    }
    print_limit_use(f);
    println!(
        "  lines over a limit: {}; TCP off the line (from the pulses): max {:.4} mm; ends exactly on the target pulses: {} of {}",
        f["lines_over_a_limit"],
        g(&["max_deviation_mm"]),
        f["exact_end"],
        f["lines"]
    );
}

/// Every figure of the arcs or the paths at one speed, as JSON.
fn summarise_paths(runs: &[PathRun]) -> serde_json::Value {
    let ratios: Vec<f64> = runs.iter().map(PathRun::ratio).collect();
    let ratios_joints: Vec<f64> = runs
        .iter()
        .map(|r| r.duration_s / r.bound.with_joints_s())
        .collect();
    let ms = |f: fn(&PathRun) -> f64| runs.iter().map(|r| f(r) * 1e3).collect::<Vec<f64>>();
    let per_10ms: Vec<f64> = runs
        .iter()
        .map(|r| r.periods_total_s * 1e3 / (r.duration_s / 0.010))
        .collect();
    let max_use = |k: usize, pulses: bool| {
        runs.iter()
            .map(|r| {
                if pulses {
                    r.limits.pulses[k]
                } else {
                    r.limits.exact[k]
                }
            })
            .fold(0.0f64, f64::max)
    };
    let mm = |v: Vec<f64>| {
        let (m, x) = median_max(&v);
        json!({ "median": m, "max": x })
    };
    json!({
        "runs": runs.len(),
        "length_mm": mm(runs.iter().map(|r| r.length_mm).collect()),
        "ratio_to_lower_bound": mm(ratios),
        "ratio_to_lower_bound_with_joint_jerk": mm(ratios_joints),
        "over_a_limit": runs.iter().filter(|r| !r.limits.within(1e-6)).count(),
        "limit_use_exact": { "v": max_use(0, false), "a": max_use(1, false), "j": max_use(2, false) },
        "limit_use_pulses": { "v": max_use(0, true), "a": max_use(1, true), "j": max_use(2, true) },
        "max_deviation_mm": runs.iter().map(|r| r.deviation_mm).fold(0.0f64, f64::max),
        "max_zone_use": runs.iter().map(|r| r.zone_use).fold(0.0f64, f64::max),
        "exact_end": runs.iter().filter(|r| r.exact_end).count(),
        "plan_ahead_ms": mm(ms(|r| r.plan_s)),
        "start_ms": mm(ms(|r| r.start_s)),
        "period_max_ms": mm(ms(|r| r.period_max_s)),
        "law_ms_per_10ms_of_motion": mm(per_10ms),
    })
}

fn print_path_figures(pct: f64, what: &str, f: &serde_json::Value) {
    let g = |path: &[&str]| figure(f, path);
    println!(
        "\nspeed {pct} %, {what}: {} runs, length median {:.0} mm, max {:.0} mm",
        f["runs"],
        g(&["length_mm", "median"]),
        g(&["length_mm", "max"])
    );
    for (label, key) in [
        (
            "duration / lower bound (TOPP-RA v/a; TCP 1-D jerk)",
            "ratio_to_lower_bound",
        ),
        (
            "… with each joint's 1-D jerk-limited time too",
            "ratio_to_lower_bound_with_joint_jerk",
        ),
        (
            "start of a path (built, every point checked, derivative table) [ms]",
            "start_ms",
        ),
        (
            "timing law as it runs, per 10 ms of motion [ms]",
            "law_ms_per_10ms_of_motion",
        ),
        ("the longest single period [ms]", "period_max_ms"),
        ("the whole law run ahead (plan_path) [ms]", "plan_ahead_ms"),
    ] {
        println!(
            "  {label}: median {:.3}  max {:.3}",
            g(&[key, "median"]),
            g(&[key, "max"])
        );
    }
    print_limit_use(f);
    println!(
        "  over a limit: {}; TCP off the path (from the pulses): max {:.4} mm; in a blend, from its corner: max {:.3} of the zone; ends exactly on the end's pulses: {} of {}",
        f["over_a_limit"],
        g(&["max_deviation_mm"]),
        g(&["max_zone_use"]),
        f["exact_end"],
        f["runs"]
    );
}

/// The three PTP blends on each case, with the bounded search and with the exhaustive one,
/// as JSON.
fn run_blends(
    generator: &wrc_motion::VelocityGenerator,
    cases: &[(
        PathCase,
        wrc_robot::Joints,
        wrc_robot::Joints,
        wrc_robot::Joints,
    )],
    cycles: Cycles,
) -> anyhow::Result<serde_json::Value> {
    let mut exhaustive = generator.clone();
    exhaustive.set_blend_search(wrc_motion::BlendSearch::Exhaustive);
    // The search's fallback on its own: no work to spend (a PTP into a path enters it at
    // rest; a path into a PTP is the two moves, the reference already).
    let mut fallback = generator.clone();
    fallback.set_blend_search(wrc_motion::BlendSearch::Bounded { work: 0 });
    let mut out = serde_json::Map::new();
    for kind in ["into_path", "out_of_path", "through_via"] {
        let run = |g: &wrc_motion::VelocityGenerator| -> anyhow::Result<Vec<BlendRun>> {
            cases
                .iter()
                .map(|(case, a, b, c)| {
                    let blend = match kind {
                        "into_path" => Blend::Into { from: *a },
                        "out_of_path" => Blend::Depart { to: *b },
                        _ => Blend::Via { via: *b, to: *c },
                    };
                    run_blend(g, case, blend, cycles).with_context(|| format!("{kind} on {case:?}"))
                })
                .collect()
        };
        let runs = run(generator)?;
        let before = run(&exhaustive)?;
        let fell = if kind == "into_path" {
            run(&fallback)?
        } else {
            Vec::new()
        };
        let vs_fallback: Vec<f64> = runs
            .iter()
            .zip(&fell)
            .map(|(r, f)| r.blended_s / f.blended_s)
            .collect();
        let ratios: Vec<f64> = runs.iter().map(BlendRun::ratio).collect();
        let before_ratios: Vec<f64> = before.iter().map(BlendRun::ratio).collect();
        let vs_before: Vec<f64> = runs
            .iter()
            .zip(&before)
            .map(|(r, b)| r.blended_s / b.blended_s)
            .collect();
        let ms = |runs: &[BlendRun], f: fn(&BlendRun) -> f64| -> serde_json::Value {
            let v: Vec<f64> = runs.iter().map(|r| f(r) * 1e3).collect();
            let (m, x) = median_max(&v);
            json!({ "median": m, "max": x })
        };
        let spread = |v: &[f64]| {
            let (m, x) = median_max(v);
            let min = v.iter().copied().fold(f64::INFINITY, f64::min);
            json!({ "median": m, "max": x, "min": min })
        };
        // The work of each search (the runs without one, a path with no room past its end
        // or a via, left out).
        let work: Vec<f64> = runs
            .iter()
            .filter(|r| r.search.searches > 0)
            .map(|r| r.search.max_work as f64)
            .collect();
        let steps: Vec<f64> = runs.iter().map(|r| r.search.max_step as f64).collect();
        let (_, step_max) = median_max(&steps);
        // A search in a period of its own (a path deciding at its junction): its period's
        // time, and that time per work unit where the search dominates it.
        let searched: Vec<&BlendRun> = runs
            .iter()
            .filter(|r| r.search_period_s.is_some())
            .collect();
        let search_ms: Vec<f64> = searched
            .iter()
            .filter_map(|r| r.search_period_s.map(|s| s * 1e3))
            .collect();
        let us_per_unit: Vec<f64> = searched
            .iter()
            .filter(|r| r.search.last_work >= 5_000)
            .filter_map(|r| {
                r.search_period_s
                    .map(|s| s * 1e6 / r.search.last_work as f64)
            })
            .collect();
        let stat = |v: &[f64]| {
            if v.is_empty() {
                serde_json::Value::Null
            } else {
                let (m, x) = median_max(v);
                json!({ "median": m, "max": x, "runs": v.len() })
            }
        };
        // From the pulses: where a path stops and a PTP starts from rest (the fallback) the
        // exact positions step by the pulses' rounding, which the exact figures would count.
        let over = runs
            .iter()
            .filter(|r| r.limits.pulses.iter().any(|&x| x > 1.0 + 1e-6))
            .count();
        let max_use = |pulses: bool| {
            runs.iter()
                .flat_map(|r| {
                    if pulses {
                        r.limits.pulses
                    } else {
                        r.limits.exact
                    }
                })
                .fold(0.0f64, f64::max)
        };
        out.insert(
            kind.into(),
            json!({
                "runs": runs.len(),
                "ratio_to_apart": spread(&ratios),
                "faster": ratios.iter().filter(|&&r| r < 1.0).count(),
                "exhaustive_ratio_to_apart": spread(&before_ratios),
                "exhaustive_faster": before_ratios.iter().filter(|&&r| r < 1.0).count(),
                "ratio_to_exhaustive": spread(&vs_before),
                "ratio_to_fallback": (!vs_fallback.is_empty()).then(|| spread(&vs_fallback)),
                "slower_than_fallback": vs_fallback.iter().filter(|&&r| r > 1.0).count(),
                "plan_ms": ms(&runs, |r| r.plan_s),
                "cycle_max_ms": ms(&runs, |r| r.cycle_max_s),
                "period_max_ms": ms(&runs, |r| r.period_max_s),
                "exhaustive_plan_ms": ms(&before, |r| r.plan_s),
                "exhaustive_cycle_max_ms": ms(&before, |r| r.cycle_max_s),
                "searches": runs.iter().map(|r| r.search.searches).sum::<u64>(),
                "fallbacks": runs.iter().map(|r| r.search.fallbacks).sum::<u64>(),
                "work_units": stat(&work),
                "largest_step_units": step_max,
                "search_period_ms": stat(&search_ms),
                "us_per_unit": stat(&us_per_unit),
                "per_run": runs
                    .iter()
                    .zip(&before)
                    .enumerate()
                    .map(|(i, (r, b))| json!({
                        "ratio_to_apart": r.ratio(),
                        "exhaustive_ratio_to_apart": b.ratio(),
                        "ratio_to_fallback": vs_fallback.get(i),
                        "work_units": r.search.last_work,
                        "fell_back": r.search.fallbacks > 0,
                        "plan_ms": r.plan_s * 1e3,
                        "exhaustive_plan_ms": b.plan_s * 1e3,
                        "search_period_ms": r.search_period_s.map(|s| s * 1e3),
                    }))
                    .collect::<Vec<_>>(),
                "over_a_limit": over,
                "limit_use_pulses": max_use(true),
                "limit_use_exact": max_use(false),
                "exact_end": runs.iter().filter(|r| r.exact_end).count(),
            }),
        );
    }
    out.insert(
        "cycles".into(),
        json!({ "first": cycles.first, "then": cycles.then }),
    );
    Ok(serde_json::Value::Object(out))
}

fn print_blend_figures(pct: f64, f: &serde_json::Value) {
    println!(
        "\nspeed {pct} %, PTP blends against the same moves at rest between them (bounded search; the exhaustive one in brackets; a Velocity Generator cycle plans and produces {} periods, then {} a cycle):",
        f["cycles"]["first"], f["cycles"]["then"]
    );
    for (label, key) in [
        ("PTP into a path", "into_path"),
        ("path into a PTP", "out_of_path"),
        ("PTP through a via point", "through_via"),
    ] {
        let b = &f[key];
        let g = |a: &str, c: &str| b[a][c].as_f64().unwrap_or(f64::NAN);
        println!(
            "  {label}: {} runs, duration / apart median {:.4} min {:.4} max {:.4} ({} faster) [{:.4} min {:.4} max {:.4}, {} faster]; duration / exhaustive's median {:.4} min {:.4} max {:.4}",
            b["runs"],
            g("ratio_to_apart", "median"),
            g("ratio_to_apart", "min"),
            g("ratio_to_apart", "max"),
            b["faster"],
            g("exhaustive_ratio_to_apart", "median"),
            g("exhaustive_ratio_to_apart", "min"),
            g("exhaustive_ratio_to_apart", "max"),
            b["exhaustive_faster"],
            g("ratio_to_exhaustive", "median"),
            g("ratio_to_exhaustive", "min"),
            g("ratio_to_exhaustive", "max"),
        );
        println!(
            "    planning median {:.3} max {:.3} ms [{:.3} / {:.3}]; busiest cycle median {:.3} max {:.3} ms [{:.3} / {:.3}]; longest period median {:.3} max {:.3} ms; searches {}, fallbacks (budget ran out) {}{}",
            g("plan_ms", "median"),
            g("plan_ms", "max"),
            g("exhaustive_plan_ms", "median"),
            g("exhaustive_plan_ms", "max"),
            g("cycle_max_ms", "median"),
            g("cycle_max_ms", "max"),
            g("exhaustive_cycle_max_ms", "median"),
            g("exhaustive_cycle_max_ms", "max"),
            g("period_max_ms", "median"),
            g("period_max_ms", "max"),
            b["searches"],
            b["fallbacks"],
            if b["work_units"].is_object() {
                format!(
                    ", work units of a search median {:.0} max {:.0}",
                    g("work_units", "median"),
                    g("work_units", "max")
                )
            } else {
                String::new()
            },
        );
        if b["ratio_to_fallback"].is_object() {
            println!(
                "    duration / the search's fallback (no budget: entering at rest) median {:.4} min {:.4} max {:.4}, slower than it {}",
                g("ratio_to_fallback", "median"),
                g("ratio_to_fallback", "min"),
                g("ratio_to_fallback", "max"),
                b["slower_than_fallback"],
            );
        }
        if b["search_period_ms"].is_object() {
            println!(
                "    the period that searches (a path deciding at its junction): {} runs, median {:.3} max {:.3} ms; largest step {} units; {} a unit (median, max; runs of 5,000 units and more: {})",
                b["search_period_ms"]["runs"],
                g("search_period_ms", "median"),
                g("search_period_ms", "max"),
                b["largest_step_units"],
                if b["us_per_unit"].is_object() {
                    format!(
                        "{:.3} / {:.3} µs",
                        g("us_per_unit", "median"),
                        g("us_per_unit", "max")
                    )
                } else {
                    "—".to_string()
                },
                b["us_per_unit"]["runs"],
            );
        }
        println!(
            "    over a limit {} (most of a limit used, pulses {:.4}, exact {:.4}), exact ends {}",
            b["over_a_limit"],
            b["limit_use_pulses"].as_f64().unwrap_or(f64::NAN),
            b["limit_use_exact"].as_f64().unwrap_or(f64::NAN),
            b["exact_end"]
        );
    }
}
