//! The `[[board]]` sections: which motion boards drive which axes (paper §2.2: 4 axes a
//! board, up to 4 boards), where each board's DPRAM is, its FIFO depth and host watchdog,
//! and how the simulated board models it. Without any `[[board]]` section the robot's axes
//! go in order onto simulated boards of 4 axes each.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::Deserialize;
use wrc_robot::Robot;

use crate::ConfigError;

/// Axes one board drives at most.
pub const AXES_PER_BOARD: usize = 4;
/// Boards at most.
pub const MAX_BOARDS: usize = 4;

/// One motion board.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardConfig {
    /// Board id (0..4), the board's number in the DPRAM header.
    pub id: u32,
    /// The board's DPRAM: a shared-memory file (simulated board), a PCI resource file or
    /// a UIO device.
    pub dpram: PathBuf,
    /// Robot axis indices in channel order (1 to 4).
    pub axes: Vec<usize>,
    /// Command FIFO depth [periods].
    pub fifo_depth: u32,
    /// The board stops all axes when the host watchdog is stale this long: `watchdog_ms`
    /// over the motion period, rounded up [periods].
    pub watchdog_periods: u32,
    /// The controller declares the board dead (fatal error 300) when its heartbeat has not
    /// advanced for this long: `heartbeat_ms` over the motion period, rounded up [board
    /// periods].
    pub heartbeat_periods: u32,
    /// Whether the controller starts `wrc board-sim` for it (false: real hardware).
    pub simulate: bool,
    /// Simulated-board model.
    pub sim: BoardSimConfig,
}

/// How the simulated board models its axes and I/O.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardSimConfig {
    /// Motor velocity limit = axis `max_velocity × pulses_per_unit ×` this, unless
    /// [`BoardSimConfig::motor_limit_pps`] gives it.
    pub overspeed_margin: f64,
    /// Per channel: explicit motor velocity limit [pulse/s].
    pub motor_limit_pps: Vec<Option<f64>>,
    /// Servo lag time constant [ms].
    pub servo_lag_ms: f64,
    /// Following-error alarm limit [pulse]; derived from the motor limit when `None`.
    pub following_error_limit: Option<i64>,
    /// Interpolation sub-steps per period.
    pub substeps: u32,
    /// E-stop input bit, if any.
    pub estop_input: Option<u8>,
    /// Inputs held asserted (interlocks such as "door closed").
    pub interlock_inputs: Vec<u8>,
    /// Vacuum hands.
    pub vacuum: Vec<VacuumConfig>,
}

/// A simulated vacuum hand.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VacuumConfig {
    /// Valve output bit.
    pub valve_output: u8,
    /// Vacuum-sensed input bit.
    pub sensor_input: u8,
    /// Valve to sensor delay [ms].
    pub delay_ms: f64,
    /// A wafer lies on the hand (vacuum can be sensed).
    pub wafer: bool,
}

impl Default for BoardSimConfig {
    fn default() -> Self {
        BoardSimConfig {
            overspeed_margin: 1.2,
            motor_limit_pps: Vec::new(),
            servo_lag_ms: 4.0,
            following_error_limit: None,
            substeps: 10,
            estop_input: Some(15),
            interlock_inputs: vec![14],
            vacuum: vec![VacuumConfig {
                valve_output: 0,
                sensor_input: 0,
                delay_ms: 50.0,
                wafer: true,
            }],
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawBoard {
    id: u32,
    #[serde(default)]
    dpram: Option<PathBuf>,
    axes: Vec<String>,
    #[serde(default = "default_fifo_depth")]
    fifo_depth: u32,
    #[serde(default)]
    watchdog_ms: Option<f64>,
    #[serde(default)]
    heartbeat_ms: Option<f64>,
    /// Replaced by `watchdog_ms` and `heartbeat_ms` (a count of periods meant 10 ms at
    /// 1 kHz): still read, so that older files keep working, and refused next to them.
    #[serde(default)]
    watchdog_periods: Option<u32>,
    #[serde(default)]
    heartbeat_periods: Option<u32>,
    #[serde(default = "default_true")]
    simulate: bool,
    #[serde(default)]
    sim: RawSim,
}

fn default_fifo_depth() -> u32 {
    MAX_FIFO_DEPTH
}

/// The deepest command FIFO a board has [periods]: its DPRAM's slots per axis
/// (`wrc_board::layout::FIFO_CAPACITY`), 256 ms at 1 kHz.
pub const MAX_FIFO_DEPTH: u32 = 256;

/// Default host watchdog timeout [ms]: longer than the stalls a stock kernel gives a
/// SCHED_FIFO task under load (up to 74 ms measured on a shared VM, by cyclictest too), and
/// longer than the default look-ahead, so that only a host that has really stopped trips it.
/// docs/realtime.md gives a tighter value for PREEMPT_RT.
pub const DEFAULT_WATCHDOG_MS: f64 = 150.0;
/// Default time a board's heartbeat may stand before the controller declares it dead [ms].
pub const DEFAULT_HEARTBEAT_MS: f64 = 30.0;

/// `ms` in periods of `period_s`, rounded up, at least 1.
fn periods_of(ms: f64, period_s: f64) -> u32 {
    let periods = (ms / 1000.0 / period_s - 1e-9).ceil();
    if periods.is_finite() {
        periods.clamp(1.0, f64::from(u32::MAX)) as u32
    } else {
        1
    }
}
fn default_true() -> bool {
    true
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct RawSim {
    overspeed_margin: f64,
    motor_limit_pps: BTreeMap<String, f64>,
    servo_lag_ms: f64,
    following_error_limit: Option<i64>,
    substeps: u32,
    estop_input: Option<u8>,
    interlock_inputs: Vec<u8>,
    vacuum: Vec<RawVacuum>,
}

impl Default for RawSim {
    fn default() -> Self {
        let d = BoardSimConfig::default();
        RawSim {
            overspeed_margin: d.overspeed_margin,
            motor_limit_pps: BTreeMap::new(),
            servo_lag_ms: d.servo_lag_ms,
            following_error_limit: None,
            substeps: d.substeps,
            estop_input: d.estop_input,
            interlock_inputs: d.interlock_inputs,
            vacuum: d
                .vacuum
                .iter()
                .map(|v| RawVacuum {
                    valve_output: v.valve_output,
                    sensor_input: v.sensor_input,
                    delay_ms: v.delay_ms,
                    wafer: v.wafer,
                })
                .collect(),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawVacuum {
    valve_output: u8,
    sensor_input: u8,
    #[serde(default = "default_delay_ms")]
    delay_ms: f64,
    #[serde(default = "default_true")]
    wafer: bool,
}

fn default_delay_ms() -> f64 {
    50.0
}

/// Default DPRAM path of board `id`: a shared-memory file.
pub fn default_dpram(id: u32) -> PathBuf {
    PathBuf::from(format!("/dev/shm/wrc-board{id}.dpram"))
}

/// Validate the raw boards against `robot`; none given = the robot's axes in order on
/// boards of four.
pub(crate) fn boards(
    raw: Vec<RawBoard>,
    robot: &Robot,
    period_s: f64,
    file: &str,
) -> Result<Vec<BoardConfig>, ConfigError> {
    let invalid = |key: String, reason: String| ConfigError::Invalid {
        file: file.to_string(),
        key,
        reason,
    };
    if raw.is_empty() {
        let indices: Vec<usize> = (0..robot.axis_count()).collect();
        return Ok(indices
            .chunks(AXES_PER_BOARD)
            .enumerate()
            .map(|(id, axes)| BoardConfig {
                id: id as u32,
                dpram: default_dpram(id as u32),
                axes: axes.to_vec(),
                fifo_depth: default_fifo_depth(),
                watchdog_periods: periods_of(DEFAULT_WATCHDOG_MS, period_s),
                heartbeat_periods: periods_of(DEFAULT_HEARTBEAT_MS, period_s),
                simulate: true,
                sim: BoardSimConfig::default(),
            })
            .collect());
    }
    if raw.len() > MAX_BOARDS {
        return Err(invalid(
            "board".into(),
            format!("{} boards; at most {MAX_BOARDS}", raw.len()),
        ));
    }
    let mut placed: Vec<Option<usize>> = vec![None; robot.axis_count()];
    let mut out: Vec<BoardConfig> = Vec::with_capacity(raw.len());
    for (i, b) in raw.into_iter().enumerate() {
        let key = |field: &str| format!("board[{}].{field}", i + 1);
        if b.id as usize >= MAX_BOARDS {
            return Err(invalid(
                key("id"),
                format!("{} is not a board id; expected 0 to 3", b.id),
            ));
        }
        if let Some(other) = out.iter().position(|o| o.id == b.id) {
            return Err(invalid(
                key("id"),
                format!("board id {} is also used by board[{}]", b.id, other + 1),
            ));
        }
        if b.axes.is_empty() || b.axes.len() > AXES_PER_BOARD {
            return Err(invalid(
                key("axes"),
                format!(
                    "{} axes; a board drives 1 to {AXES_PER_BOARD}",
                    b.axes.len()
                ),
            ));
        }
        let mut axes = Vec::with_capacity(b.axes.len());
        for name in &b.axes {
            let index = robot.axis_index(name).ok_or_else(|| {
                invalid(key("axes"), format!("{name:?} is not an axis of the robot"))
            })?;
            if let Some(board) = placed[index] {
                return Err(invalid(
                    key("axes"),
                    format!("axis {name} is already on board[{}]", board + 1),
                ));
            }
            placed[index] = Some(i);
            axes.push(index);
        }
        if !(1..=MAX_FIFO_DEPTH).contains(&b.fifo_depth) {
            return Err(invalid(
                key("fifo_depth"),
                format!("{}; expected 1 to {MAX_FIFO_DEPTH} periods", b.fifo_depth),
            ));
        }
        let in_periods = |ms_key: &str,
                          ms: Option<f64>,
                          periods_key: &str,
                          periods: Option<u32>,
                          default_ms: f64| {
            match (ms, periods) {
                (Some(_), Some(_)) => Err(invalid(
                    key(periods_key),
                    format!("give {ms_key} only ({periods_key} is its older form, in periods)"),
                )),
                (None, Some(0)) => Err(invalid(
                    key(periods_key),
                    format!("must be at least 1 period (or give {ms_key} in milliseconds)"),
                )),
                (None, Some(p)) => Ok(p),
                (Some(ms), None) if !(ms.is_finite() && ms > 0.0 && ms <= 60_000.0) => {
                    Err(invalid(
                        key(ms_key),
                        format!("{ms}; expected more than 0 and at most 60000 ms"),
                    ))
                }
                (ms, None) => Ok(periods_of(ms.unwrap_or(default_ms), period_s)),
            }
        };
        let watchdog_periods = in_periods(
            "watchdog_ms",
            b.watchdog_ms,
            "watchdog_periods",
            b.watchdog_periods,
            DEFAULT_WATCHDOG_MS,
        )?;
        let heartbeat_periods = in_periods(
            "heartbeat_ms",
            b.heartbeat_ms,
            "heartbeat_periods",
            b.heartbeat_periods,
            DEFAULT_HEARTBEAT_MS,
        )?;
        let s = b.sim;
        if !(s.overspeed_margin.is_finite() && s.overspeed_margin >= 1.0) {
            return Err(invalid(
                key("sim.overspeed_margin"),
                format!("{}; expected a finite number ≥ 1.0", s.overspeed_margin),
            ));
        }
        if !(s.servo_lag_ms.is_finite() && s.servo_lag_ms >= 0.0) {
            return Err(invalid(
                key("sim.servo_lag_ms"),
                format!("{}; expected a finite number ≥ 0", s.servo_lag_ms),
            ));
        }
        if !(1..=1000).contains(&s.substeps) {
            return Err(invalid(
                key("sim.substeps"),
                format!("{}; expected 1 to 1000", s.substeps),
            ));
        }
        if let Some(limit) = s.following_error_limit.filter(|l| *l <= 0) {
            return Err(invalid(
                key("sim.following_error_limit"),
                format!("{limit}; expected a positive number of pulses"),
            ));
        }
        let mut motor_limit_pps = vec![None; axes.len()];
        for (name, pps) in &s.motor_limit_pps {
            let channel = b.axes.iter().position(|a| a == name).ok_or_else(|| {
                invalid(
                    key("sim.motor_limit_pps"),
                    format!("{name:?} is not an axis of this board"),
                )
            })?;
            if !(pps.is_finite() && *pps > 0.0) {
                return Err(invalid(
                    key(&format!("sim.motor_limit_pps.{name}")),
                    format!("{pps}; expected pulses per second greater than 0"),
                ));
            }
            motor_limit_pps[channel] = Some(*pps);
        }
        let bit = |field: String, bit: u8| {
            if bit < 32 {
                Ok(bit)
            } else {
                Err(invalid(
                    field,
                    format!("{bit} is not an I/O bit; expected 0 to 31"),
                ))
            }
        };
        let estop_input = s
            .estop_input
            .map(|b| bit(key("sim.estop_input"), b))
            .transpose()?;
        for b in &s.interlock_inputs {
            bit(key("sim.interlock_inputs"), *b)?;
        }
        let mut vacuum = Vec::with_capacity(s.vacuum.len());
        if s.vacuum.len() > 4 {
            return Err(invalid(
                key("sim.vacuum"),
                format!("{} hands; at most 4", s.vacuum.len()),
            ));
        }
        for (j, v) in s.vacuum.iter().enumerate() {
            let vkey = |f: &str| key(&format!("sim.vacuum[{}].{f}", j + 1));
            if !(v.delay_ms.is_finite() && v.delay_ms >= 0.0) {
                return Err(invalid(
                    vkey("delay_ms"),
                    format!("{}; expected a finite number ≥ 0", v.delay_ms),
                ));
            }
            vacuum.push(VacuumConfig {
                valve_output: bit(vkey("valve_output"), v.valve_output)?,
                sensor_input: bit(vkey("sensor_input"), v.sensor_input)?,
                delay_ms: v.delay_ms,
                wafer: v.wafer,
            });
        }
        out.push(BoardConfig {
            id: b.id,
            dpram: b.dpram.unwrap_or_else(|| default_dpram(b.id)),
            axes,
            fifo_depth: b.fifo_depth,
            watchdog_periods,
            heartbeat_periods,
            simulate: b.simulate,
            sim: BoardSimConfig {
                overspeed_margin: s.overspeed_margin,
                motor_limit_pps,
                servo_lag_ms: s.servo_lag_ms,
                following_error_limit: s.following_error_limit,
                substeps: s.substeps,
                estop_input,
                interlock_inputs: s.interlock_inputs,
                vacuum,
            },
        });
    }
    if let Some(missing) = placed.iter().position(Option::is_none) {
        return Err(invalid(
            "board".into(),
            format!(
                "axis {} is on no board; list every robot axis in some board's axes",
                robot.axes()[missing].name
            ),
        ));
    }
    Ok(out)
}
