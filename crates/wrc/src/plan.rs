//! `wrc plan`: plan a PTP, straight-line or joint move offline and print its per-period
//! pulses as CSV (and optionally an SVG plot like the paper's Fig. 7 and 8).

use std::io::{self, BufWriter, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::{Args, Subcommand, ValueEnum};
use wrc_config::Config;
use wrc_motion::{MoveEnd, MoveInfo, Period, Profile, Status, Sync, VelocityGenerator};
use wrc_robot::{Pose, Posture, Robot};

use crate::plot::{self, Row};

const EXAMPLES: &str = "\
Examples:
  wrc plan ptp --from=-75,150,-75,0 --to=30,60,-90,100      PTP in joint space (deg, deg, deg, mm)
  wrc plan line --from=300,-100,0,0 --to=300,150,50,0       straight line (x, y, z [mm], yaw [deg])
  wrc plan joint --axis j1 --pulses 20000                    20000 pulses on J1 from home
  wrc plan ptp --to=30,60,-90,100 --profile paper --paper-n 20 --plot ptp.svg > ptp.csv
  wrc plan line --from=300,-100,0,0 --to=300,150,0,0 --period-ms 1 --speed 50

CSV columns: k, t_s, <axis>_pulses (pulses emitted in period k), <axis>_pos (commanded
position after period k, deg or mm), x_mm, y_mm (TCP from forward kinematics).
Negative values: write --from=-75,... (with '=') or quote the list.";

/// Arguments of `wrc plan`.
#[derive(Debug, Args)]
#[command(after_help = EXAMPLES)]
pub struct PlanArgs {
    #[command(subcommand)]
    kind: PlanKind,
}

#[derive(Debug, Subcommand)]
enum PlanKind {
    /// PTP move in joint space: all axes start and finish together.
    #[command(after_help = EXAMPLES)]
    Ptp {
        /// Start joints, one value per axis [deg or mm] (default: home).
        #[arg(long, value_name = "J1,J2,J3,Z", allow_hyphen_values = true)]
        from: Option<String>,
        /// Target joints, one value per axis [deg or mm].
        #[arg(long, value_name = "J1,J2,J3,Z", allow_hyphen_values = true)]
        to: String,
        #[command(flatten)]
        common: Common,
    },
    /// Straight line of the tool centre point (Table 2: points → IK → pulses).
    #[command(after_help = EXAMPLES)]
    Line {
        /// Start pose x,y,z [mm], yaw [deg] (default: the home pose).
        #[arg(long, value_name = "X,Y,Z,YAW", allow_hyphen_values = true)]
        from: Option<String>,
        /// Target pose x,y,z [mm], yaw [deg].
        #[arg(long, value_name = "X,Y,Z,YAW", allow_hyphen_values = true)]
        to: String,
        /// Elbow posture at the start (kept along the line).
        #[arg(long, value_enum, default_value = "right")]
        posture: PostureArg,
        #[command(flatten)]
        common: Common,
    },
    /// Joint mode: a pulse count on one axis, with the same acceleration and deceleration.
    #[command(after_help = EXAMPLES)]
    Joint {
        /// Axis name (j1, j2, j3, z with the default robot).
        #[arg(long)]
        axis: String,
        /// Pulses to move (negative: backwards).
        #[arg(long, allow_hyphen_values = true)]
        pulses: i64,
        /// Start joints (default: home).
        #[arg(long, value_name = "J1,J2,J3,Z", allow_hyphen_values = true)]
        from: Option<String>,
        #[command(flatten)]
        common: Common,
    },
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum PostureArg {
    Right,
    Left,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum ProfileArg {
    /// Time-optimal jerk-limited (two cascaded moving averages).
    Fir,
    /// The paper's triangular convolution mask (eq. 1-2).
    Paper,
}

#[derive(Debug, Args)]
struct Common {
    /// Robot configuration file (TOML); default: the embedded paper robot.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Pulse period [ms] (default: from the configuration, 10 ms).
    #[arg(long, value_name = "MS", allow_hyphen_values = true)]
    period_ms: Option<f64>,
    /// Velocity profile (default: from the configuration, fir).
    #[arg(long, value_enum)]
    profile: Option<ProfileArg>,
    /// Mask length n of the paper profile [periods], even (default: from the configuration).
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    paper_n: Option<f64>,
    /// Speed override [%], 1-100 (default: from the configuration, 100).
    #[arg(long, value_name = "PCT", allow_hyphen_values = true)]
    speed: Option<f64>,
    /// Also draw the output pulses per axis over time into this SVG file.
    #[arg(long, value_name = "FILE.svg")]
    plot: Option<PathBuf>,
}

/// Parse `a,b,c` into numbers, with messages that name the option and the bad value.
fn numbers(option: &str, text: &str, expected: usize, names: &str) -> anyhow::Result<Vec<f64>> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != expected {
        bail!(
            "{option} needs {expected} comma-separated values ({names}), got {} in {text:?}",
            parts.len()
        );
    }
    parts
        .iter()
        .map(|p| match p.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => bail!("{option}: {p:?} is not a finite number"),
            Err(_) => bail!("{option}: {p:?} is not a number"),
        })
        .collect()
}

fn axis_names(robot: &Robot) -> String {
    robot
        .axes()
        .iter()
        .map(|a| a.name.as_str())
        .collect::<Vec<_>>()
        .join(",")
}

fn joints_arg(robot: &Robot, option: &str, text: &str) -> anyhow::Result<wrc_robot::Joints> {
    let values = numbers(option, text, robot.axis_count(), &axis_names(robot))?;
    let joints = robot.joints_from_slice(&values)?;
    robot
        .check_joints(&joints)
        .with_context(|| format!("{option} {text}"))?;
    Ok(joints)
}

fn pose_arg(option: &str, text: &str) -> anyhow::Result<Pose> {
    let v = numbers(option, text, 4, "x,y,z [mm], yaw [deg]")?;
    Ok(Pose {
        x: v[0],
        y: v[1],
        z: v[2],
        yaw: v[3],
    })
}

fn paper_n(n: f64) -> anyhow::Result<Profile> {
    Profile::paper(Some(n), None).map_err(|e| anyhow::anyhow!("--paper-n: {}", e.reason))
}

fn generator(common: &Common) -> anyhow::Result<VelocityGenerator> {
    let config = Config::load(common.config.as_deref())?;
    let mut settings = config.motion;
    if let Some(ms) = common.period_ms {
        settings.period_s = ms / 1000.0;
    }
    match common.profile {
        Some(ProfileArg::Fir) => settings.profile = Profile::Fir,
        Some(ProfileArg::Paper) => {
            settings.profile = match (common.paper_n, settings.profile) {
                (Some(n), _) => paper_n(n)?,
                (None, p @ Profile::Paper { .. }) => p,
                (None, Profile::Fir) => Profile::paper(None, None)?,
            }
        }
        None => {
            if let Some(n) = common.paper_n {
                if settings.profile == Profile::Fir {
                    bail!("--paper-n only applies with --profile paper");
                }
                settings.profile = paper_n(n)?;
            }
        }
    }
    if let Some(pct) = common.speed {
        settings.speed_pct = pct;
    }
    // Name the command-line option rather than the configuration key.
    settings.validate().map_err(|e| {
        let option = match e.key.as_str() {
            "motion.period_ms" => "--period-ms",
            "motion.speed_pct" => "--speed",
            "motion.paper_n" => "--paper-n",
            other => other,
        };
        anyhow::anyhow!("{option}: {}", e.reason)
    })?;
    Ok(VelocityGenerator::new(config.robot, settings)?)
}

/// Run `wrc plan`.
pub fn run(args: PlanArgs) -> anyhow::Result<ExitCode> {
    let (mut vg, kind, plot_path, info) = match args.kind {
        PlanKind::Ptp { from, to, common } => {
            let mut vg = generator(&common)?;
            let robot = vg.robot().clone();
            if let Some(from) = from {
                let start = joints_arg(&robot, "--from", &from)?;
                vg.set_position_pulses(&robot.joints_to_pulses(&start))?;
            }
            let target = joints_arg(&robot, "--to", &to)?;
            let info = vg.plan_ptp(&target).context("cannot plan the PTP move")?;
            (vg, "ptp", common.plot, info)
        }
        PlanKind::Line {
            from,
            to,
            posture,
            common,
        } => {
            let mut vg = generator(&common)?;
            let robot = vg.robot().clone();
            if let Some(from) = from {
                let start = pose_arg("--from", &from)?;
                let posture = match posture {
                    PostureArg::Right => Posture::Right,
                    PostureArg::Left => Posture::Left,
                };
                let joints = robot
                    .inverse(&start, posture, None)
                    .with_context(|| format!("--from {from} cannot be the start of a line"))?;
                vg.set_position_pulses(&robot.joints_to_pulses(&joints))?;
            }
            let target = pose_arg("--to", &to)?;
            let info = vg
                .plan_line(&target)
                .context("cannot plan the straight line")?;
            (vg, "line", common.plot, info)
        }
        PlanKind::Joint {
            axis,
            pulses,
            from,
            common,
        } => {
            let mut vg = generator(&common)?;
            let robot = vg.robot().clone();
            let Some(index) = robot.axis_index(&axis) else {
                bail!(
                    "--axis {axis:?} is not an axis of this robot; axes: {}",
                    axis_names(&robot)
                );
            };
            if let Some(from) = from {
                let start = joints_arg(&robot, "--from", &from)?;
                vg.set_position_pulses(&robot.joints_to_pulses(&start))?;
            }
            let info = vg
                .plan_jog(index, pulses)
                .context("cannot plan the joint move")?;
            (vg, "joint", common.plot, info)
        }
    };
    let rows = produce(&mut vg)?;
    describe(&vg, kind, &info, &rows);
    if let Some(path) = plot_path {
        let title = format!(
            "wrc plan {kind}: output pulses per {} ms period ({} profile)",
            vg.settings().period_s * 1000.0,
            vg.settings().profile.name()
        );
        plot::pulses_svg(&path, &title, vg.robot(), vg.settings().period_s, &rows)
            .with_context(|| format!("cannot write the plot {}", path.display()))?;
        eprintln!("wrc: plot written to {}", path.display());
    }
    match write_csv(&vg, &rows) {
        Ok(()) => Ok(ExitCode::SUCCESS),
        // `wrc plan … | head` closes the pipe early: that is not an error.
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => Ok(ExitCode::SUCCESS),
        Err(e) => Err(e).context("cannot write the CSV to standard output"),
    }
}

fn produce(vg: &mut VelocityGenerator) -> anyhow::Result<Vec<Row>> {
    let n = vg.robot().axis_count();
    let mut rows = vec![Row {
        k: 0,
        pulses: vec![0; n],
        position: vg.position_pulses()[..n].to_vec(),
    }];
    let mut period = Period::default();
    // Ten million periods is over a day at 10 ms: far past any sensible move.
    for k in 1..=10_000_000u64 {
        let status = vg.next_period(&mut period);
        if status == Status::Idle {
            break;
        }
        rows.push(Row {
            k,
            pulses: period.pulses[..n].to_vec(),
            position: vg.position_pulses()[..n].to_vec(),
        });
        if let Status::Finished(MoveEnd::Stopped) = status {
            bail!("the move stopped before its target");
        }
        if matches!(status, Status::Finished(_)) {
            return Ok(rows);
        }
    }
    if vg.is_moving() {
        bail!("the move takes more than ten million periods; raise --speed or the axis limits");
    }
    Ok(rows)
}

fn describe(vg: &VelocityGenerator, kind: &str, info: &MoveInfo, rows: &[Row]) {
    let s = vg.settings();
    let sync = match info.sync {
        Sync::Phase => ", axes phase-synchronised",
        Sync::Time => ", axes time-synchronised",
        Sync::Single => "",
    };
    eprintln!(
        "wrc: {kind}: {} periods of {} ms = {:.3} s (profile {}, speed {} %{sync})",
        rows.len() - 1,
        s.period_s * 1000.0,
        info.duration_s,
        s.profile.name(),
        s.speed_pct,
    );
}

fn write_csv(vg: &VelocityGenerator, rows: &[Row]) -> io::Result<()> {
    let robot = vg.robot();
    let ts = vg.settings().period_s;
    let stdout = io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    write!(out, "k,t_s")?;
    for a in robot.axes() {
        write!(out, ",{}_pulses", a.name)?;
    }
    for a in robot.axes() {
        write!(out, ",{}_pos", a.name)?;
    }
    writeln!(out, ",x_mm,y_mm")?;
    let mut pulses = [0i64; wrc_robot::MAX_AXES];
    for row in rows {
        write!(out, "{},{:.6}", row.k, row.k as f64 * ts)?;
        for p in &row.pulses {
            write!(out, ",{p}")?;
        }
        for (i, (p, a)) in row.position.iter().zip(robot.axes()).enumerate() {
            pulses[i] = *p;
            write!(out, ",{:.6}", a.pulses_to_units(*p))?;
        }
        let tcp = robot.forward(&robot.pulses_to_joints(&pulses));
        writeln!(out, ",{:.4},{:.4}", tcp.x, tcp.y)?;
    }
    out.flush()
}
