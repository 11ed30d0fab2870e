//! The configuration file as written (serde types) and its conversion into validated models.

use serde::Deserialize;
use wrc_motion::{LineLimits, MotionSettings, Profile};
use wrc_robot::{Axis, AxisName, AxisRole, Limits, ModelError, Robot, Unit};

use crate::{Config, ConfigError};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawConfig {
    robot: RawRobot,
    #[serde(default)]
    motion: RawMotion,
    #[serde(default)]
    axis: Vec<RawAxis>,
    #[serde(default)]
    board: Vec<crate::board::RawBoard>,
    #[serde(default)]
    task: Vec<crate::tasks::RawTask>,
    #[serde(default)]
    hand: crate::hand::RawHand,
    #[serde(default)]
    trace: RawTrace,
    #[serde(default)]
    host: crate::host::RawHost,
    #[serde(default)]
    io: crate::io::RawIo,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct RawTrace {
    seconds: f64,
    messages: i64,
    save_on_alarm: bool,
}

impl Default for RawTrace {
    fn default() -> Self {
        let d = crate::TraceConfig::default();
        RawTrace {
            seconds: d.seconds,
            messages: d.messages as i64,
            save_on_alarm: d.save_on_alarm,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRobot {
    #[serde(default = "default_name")]
    name: String,
    link1_mm: f64,
    link2_mm: f64,
    #[serde(default)]
    hand_mm: f64,
    #[serde(default = "default_margin")]
    singularity_margin_mm: f64,
    #[serde(default)]
    shape: RawShape,
}

/// `[robot.shape]`: the arm's bodies for the cell's collision checks (wrc_robot::ArmShape).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct RawShape {
    link1_radius_mm: f64,
    link1_z_mm: [f64; 2],
    link2_radius_mm: f64,
    link2_z_mm: [f64; 2],
    blade_back_mm: f64,
    blade_front_mm: f64,
    blade_half_width_mm: f64,
    blade_thickness_mm: f64,
    wafer_radius_mm: f64,
    wafer_thickness_mm: f64,
}

impl Default for RawShape {
    fn default() -> Self {
        let d = wrc_robot::ArmShape::default();
        RawShape {
            link1_radius_mm: d.link1_radius_mm,
            link1_z_mm: d.link1_z_mm,
            link2_radius_mm: d.link2_radius_mm,
            link2_z_mm: d.link2_z_mm,
            blade_back_mm: d.blade_back_mm,
            blade_front_mm: d.blade_front_mm,
            blade_half_width_mm: d.blade_half_width_mm,
            blade_thickness_mm: d.blade_thickness_mm,
            wafer_radius_mm: d.wafer_radius_mm,
            wafer_thickness_mm: d.wafer_thickness_mm,
        }
    }
}

impl RawShape {
    fn shape(&self) -> wrc_robot::ArmShape {
        wrc_robot::ArmShape {
            link1_radius_mm: self.link1_radius_mm,
            link1_z_mm: self.link1_z_mm,
            link2_radius_mm: self.link2_radius_mm,
            link2_z_mm: self.link2_z_mm,
            blade_back_mm: self.blade_back_mm,
            blade_front_mm: self.blade_front_mm,
            blade_half_width_mm: self.blade_half_width_mm,
            blade_thickness_mm: self.blade_thickness_mm,
            wafer_radius_mm: self.wafer_radius_mm,
            wafer_thickness_mm: self.wafer_thickness_mm,
        }
    }
}

fn default_name() -> String {
    "robot".into()
}

fn default_margin() -> f64 {
    2.0
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct RawMotion {
    period_ms: f64,
    profile: String,
    paper_n: Option<f64>,
    paper_a: Option<f64>,
    speed_pct: f64,
    line_max_speed_mm_s: f64,
    line_max_accel_mm_s2: f64,
    line_max_jerk_mm_s3: f64,
    blend: bool,
    lookahead_ms: f64,
}

impl Default for RawMotion {
    fn default() -> Self {
        let d = MotionSettings::default();
        RawMotion {
            period_ms: d.period_s * 1000.0,
            profile: "fir".into(),
            paper_n: None,
            paper_a: None,
            speed_pct: d.speed_pct,
            line_max_speed_mm_s: d.line.max_speed_mm_s,
            line_max_accel_mm_s2: d.line.max_accel_mm_s2,
            line_max_jerk_mm_s3: d.line.max_jerk_mm_s3,
            blend: true,
            lookahead_ms: crate::DEFAULT_LOOKAHEAD_MS,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAxis {
    name: String,
    role: String,
    unit: String,
    pulses_per_unit: f64,
    min: f64,
    max: f64,
    max_velocity: f64,
    max_acceleration: f64,
    max_jerk: f64,
    home: f64,
}

impl RawConfig {
    pub(crate) fn into_config(self, file: &str) -> Result<Config, ConfigError> {
        let invalid = |key: String, reason: String| ConfigError::Invalid {
            file: file.to_string(),
            key,
            reason,
        };
        let mut axes = Vec::with_capacity(self.axis.len());
        for (i, raw) in self.axis.into_iter().enumerate() {
            let name = AxisName::new(&raw.name).ok_or_else(|| {
                invalid(
                    format!("axis[{}].name", i + 1),
                    format!(
                        "{:?} is not a usable axis name: use 1 to {} letters, digits, '_' or '-'",
                        raw.name,
                        AxisName::MAX_LEN
                    ),
                )
            })?;
            let role = match raw.role.as_str() {
                "shoulder" => AxisRole::Shoulder,
                "elbow" => AxisRole::Elbow,
                "wrist" => AxisRole::Wrist,
                "z" => AxisRole::Z,
                "auxiliary" => AxisRole::Auxiliary,
                other => {
                    return Err(invalid(
                        format!("axis.{name}.role"),
                        format!(
                        "unknown role {other:?}; expected shoulder, elbow, wrist, z or auxiliary"
                    ),
                    ))
                }
            };
            let unit = match raw.unit.as_str() {
                "deg" => Unit::Deg,
                "mm" => Unit::Mm,
                other => {
                    return Err(invalid(
                        format!("axis.{name}.unit"),
                        format!("unknown unit {other:?}; expected deg or mm"),
                    ))
                }
            };
            axes.push(Axis {
                name,
                role,
                unit,
                pulses_per_unit: raw.pulses_per_unit,
                min: raw.min,
                max: raw.max,
                limits: Limits {
                    max_velocity: raw.max_velocity,
                    max_acceleration: raw.max_acceleration,
                    max_jerk: raw.max_jerk,
                },
                home: raw.home,
            });
        }
        let r = self.robot;
        let robot = Robot::new(
            r.name,
            axes,
            r.link1_mm,
            r.link2_mm,
            r.hand_mm,
            r.singularity_margin_mm,
        )
        .and_then(|robot| robot.with_shape(r.shape.shape()))
        .map_err(|ModelError { key, reason, .. }| invalid(key, reason))?;

        let m = self.motion;
        let blend = m.blend;
        let profile = match m.profile.as_str() {
            "fir" => Profile::Fir,
            "paper" => {
                Profile::paper(m.paper_n, m.paper_a).map_err(|e| invalid(e.key, e.reason))?
            }
            other => {
                return Err(invalid(
                    "motion.profile".into(),
                    format!("unknown profile {other:?}; expected \"fir\" or \"paper\""),
                ))
            }
        };
        let motion = MotionSettings {
            period_s: m.period_ms / 1000.0,
            profile,
            speed_pct: m.speed_pct,
            line: LineLimits {
                max_speed_mm_s: m.line_max_speed_mm_s,
                max_accel_mm_s2: m.line_max_accel_mm_s2,
                max_jerk_mm_s3: m.line_max_jerk_mm_s3,
            },
        };
        motion.validate().map_err(|e| invalid(e.key, e.reason))?;
        let boards = crate::board::boards(self.board, &robot, motion.period_s, file)?;
        let lookahead_ms = m.lookahead_ms;
        if !(lookahead_ms.is_finite() && lookahead_ms > 0.0 && lookahead_ms <= 10_000.0) {
            return Err(invalid(
                "motion.lookahead_ms".into(),
                format!("{lookahead_ms}; expected more than 0 and at most 10000 ms"),
            ));
        }
        // At least one period; a part of a period is a whole one.
        let lookahead_periods = ((lookahead_ms / 1000.0 / motion.period_s) - 1e-9)
            .ceil()
            .max(1.0) as usize;
        if let Some((i, b)) = boards
            .iter()
            .enumerate()
            .find(|(_, b)| b.fifo_depth as usize <= lookahead_periods)
        {
            return Err(invalid(
                "motion.lookahead_ms".into(),
                format!(
                    "{lookahead_ms} ms is {lookahead_periods} periods of {} ms, and board[{}] \
                     holds {} (fifo_depth): a look-ahead needs a FIFO at least one period \
                     deeper; shorten the look-ahead or deepen the FIFO (at most {})",
                    motion.period_s * 1000.0,
                    i + 1,
                    b.fifo_depth,
                    crate::MAX_FIFO_DEPTH
                ),
            ));
        }
        if let Some((i, b)) = boards
            .iter()
            .enumerate()
            .find(|(_, b)| b.watchdog_periods as usize <= lookahead_periods)
        {
            return Err(invalid(
                format!("board[{}].watchdog_ms", i + 1),
                format!(
                    "{} ms is not longer than [motion] lookahead_ms ({lookahead_ms} ms): a host \
                     stall the look-ahead rides out would trip the watchdog and stop the \
                     robot; give a longer watchdog or a shorter look-ahead",
                    (f64::from(b.watchdog_periods) * motion.period_s * 1000.0).round()
                ),
            ));
        }
        let t = self.trace;
        if !(t.seconds.is_finite() && (1.0..=3600.0).contains(&t.seconds)) {
            return Err(invalid(
                "trace.seconds".into(),
                format!(
                    "{} is out of range: use 1 to 3600 s of recording",
                    t.seconds
                ),
            ));
        }
        // The recorder keeps every sample of the last `seconds` in memory, one per motion
        // period; refuse what no machine could hold rather than fail at start-up.
        let samples = (t.seconds / motion.period_s).ceil();
        if samples > crate::MAX_TRACE_SAMPLES as f64 {
            return Err(invalid(
                "trace.seconds".into(),
                format!(
                    "{} s of samples at the {} ms motion period is {samples} samples, more \
                     than the {} the recorder keeps in memory (an hour at 1 ms, about 1 GB): \
                     record fewer seconds or lengthen motion.period_ms",
                    t.seconds,
                    motion.period_s * 1000.0,
                    crate::MAX_TRACE_SAMPLES
                ),
            ));
        }
        if !(100..=1_000_000).contains(&t.messages) {
            return Err(invalid(
                "trace.messages".into(),
                format!(
                    "{} is out of range: use 100 to 1000000 messages",
                    t.messages
                ),
            ));
        }
        let trace = crate::TraceConfig {
            seconds: t.seconds,
            messages: t.messages as usize,
            save_on_alarm: t.save_on_alarm,
        };
        Ok(Config {
            source: file.to_string(),
            text: String::new(),
            trace,
            robot,
            blend: blend && motion.profile == Profile::Fir,
            lookahead_periods,
            motion,
            boards,
            tasks: crate::tasks::tasks(self.task, file)?,
            hand: self.hand.into_hand(file)?,
            host: self.host.into_host(file)?,
            io: self.io.into_io(file)?,
        })
    }
}
