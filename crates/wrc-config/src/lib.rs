//! wrc's configuration: a TOML file describing the robot (arm geometry and axes) and the
//! velocity generator. A default file, the paper's robot, is embedded in the binary
//! ([`DEFAULT_TOML`]); `--config FILE` replaces it. Every error names the file, the key and
//! the reason.
//!
//! ```
//! let config = wrc_config::Config::embedded_default();
//! assert_eq!(config.robot.axis_count(), 4);
//! assert_eq!(config.motion.period_s, 0.010);
//! ```
#![deny(missing_docs)]

mod board;
mod hand;
mod host;
mod io;
mod raw;
mod tasks;

use std::path::Path;

use wrc_motion::MotionSettings;
use wrc_robot::Robot;

pub use board::{
    default_dpram, BoardConfig, BoardSimConfig, VacuumConfig, DEFAULT_HEARTBEAT_MS,
    DEFAULT_WATCHDOG_MS, MAX_FIFO_DEPTH,
};
pub use hand::{BladeB, HandConfig};
pub use host::{canonical, listed, parse_net, HostConfig, MAX_CONNECTIONS};
pub use io::{IoConfig, Signal, SignalDir, MAX_SIGNAL_NAME, SIGNALS};
pub use ipnet::IpNet;

/// The embedded default configuration (`config/default.toml`).
pub const DEFAULT_TOML: &str = include_str!("../../../config/default.toml");

/// The dual-blade example (`config/dual-blade.toml`): the default robot with a second blade.
pub const DUAL_BLADE_TOML: &str = include_str!("../../../config/dual-blade.toml");

/// Name used for the embedded file in messages.
pub const EMBEDDED_NAME: &str = "<embedded default config>";

/// A configuration that cannot be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read config file {file}: {reason}")]
    Read {
        /// The file.
        file: String,
        /// Why.
        reason: std::io::Error,
    },
    /// The file is not valid TOML, has an unknown key or a value of the wrong type.
    #[error("config file {file}: {message}")]
    Parse {
        /// The file.
        file: String,
        /// The TOML parser's message, with line, column and key.
        message: String,
    },
    /// A value is of the right type but not usable.
    #[error("config file {file}: key {key}: {reason}")]
    Invalid {
        /// The file.
        file: String,
        /// The key, as written in the file (`axis.j1.max_velocity`).
        key: String,
        /// What is wrong and what is expected.
        reason: String,
    },
}

/// A loaded, validated configuration.
#[derive(Debug, Clone)]
pub struct Config {
    /// Where it came from: a path, or [`EMBEDDED_NAME`].
    pub source: String,
    /// The text it was parsed from (a trace carries it, so a replay runs the same robot).
    pub text: String,
    /// The robot.
    pub robot: Robot,
    /// Velocity generator settings.
    pub motion: MotionSettings,
    /// Whether a transfer's move to a station's approach pose flows into its straight line
    /// in (`[motion] blend`, default true; docs/motion.md "Blended approach"). Only under the
    /// default profile: the paper profile's moves start and end at rest.
    pub blend: bool,
    /// Periods the Pulse Generator keeps queued in the board FIFO ahead of the board
    /// (`[motion] lookahead_ms` over the period, rounded up, at least 1): a host stall
    /// shorter than this costs no underrun. Always less than every board's `fifo_depth`.
    pub lookahead_periods: usize,
    /// Motion boards (`[[board]]`), in board order; at least one.
    pub boards: Vec<BoardConfig>,
    /// Real-time tasks (`[[task]]`): priority and period of each; the paper's Table 1 when the
    /// file has no `[[task]]` section.
    pub tasks: wrc_rt::TaskTable,
    /// The hand's signals (`[hand]`; defaults when absent).
    pub hand: HandConfig,
    /// The trace recorder (`[trace]`; defaults when absent).
    pub trace: TraceConfig,
    /// The host port's admission (`[host]`; defaults when absent).
    pub host: HostConfig,
    /// Guarded outputs and signal names (`[io]`; none when absent).
    pub io: IoConfig,
}

/// Default `[motion] lookahead_ms`: the Pulse Generator's look-ahead in the board FIFO [ms]
/// (10 periods at the default 10 ms, 100 at 1 ms): longer than the stalls a stock kernel
/// gives a SCHED_FIFO task on a loaded, shared machine (up to 74 ms measured on a 2-core VM,
/// by cyclictest too). Moves do not start later for it (docs/realtime.md) and stops do not
/// wait for it (docs/dpram.md); docs/realtime.md gives a tighter value for PREEMPT_RT.
pub const DEFAULT_LOOKAHEAD_MS: f64 = 100.0;

/// Most samples the trace recorder may keep, `[trace] seconds` over the motion period: an
/// hour at 1 ms, about 1 GB of memory (288 bytes a sample, docs/trace.md). A configuration
/// asking for more is refused.
pub const MAX_TRACE_SAMPLES: usize = 3_600_000;

/// The trace recorder's settings (`[trace]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceConfig {
    /// Seconds of per-period samples kept and saved (1 to 3600, and at most
    /// [`MAX_TRACE_SAMPLES`] motion periods) [s].
    pub seconds: f64,
    /// Requests and replies kept (100 to 1 000 000) [messages].
    pub messages: usize,
    /// Save the last `seconds` when an alarm, an E-stop or a fault is raised.
    pub save_on_alarm: bool,
}

impl Default for TraceConfig {
    fn default() -> Self {
        TraceConfig {
            seconds: 30.0,
            messages: 10_000,
            save_on_alarm: true,
        }
    }
}

impl Config {
    /// The embedded default configuration.
    pub fn embedded_default() -> Config {
        // The embedded file is checked by a unit test, so this cannot fail in a release.
        Config::parse(DEFAULT_TOML, EMBEDDED_NAME).expect("the embedded default config is valid")
    }

    /// The dual-blade example ([`DUAL_BLADE_TOML`]), as embedded.
    pub fn embedded_dual_blade() -> Config {
        // Checked by a unit test, as the default is.
        Config::parse(DUAL_BLADE_TOML, "config/dual-blade.toml (embedded)")
            .expect("the embedded dual-blade config is valid")
    }

    /// The E-stop button's input (`[board.sim] estop_input` of the first board): RESET is
    /// refused while it is asserted.
    pub fn estop_input(&self) -> Option<u8> {
        self.boards.first().and_then(|b| b.sim.estop_input)
    }

    /// Every signal the configuration names, with the stations' interlock inputs
    /// (`interlocks`: each input and its name; [`IoConfig::signals`]).
    pub fn signals(&self, interlocks: &[(u8, String)]) -> Vec<Signal> {
        self.io.signals(&self.hand, self.estop_input(), interlocks)
    }

    /// Load `path`, or the embedded default when `path` is `None`.
    pub fn load(path: Option<&Path>) -> Result<Config, ConfigError> {
        match path {
            None => Config::parse(DEFAULT_TOML, EMBEDDED_NAME),
            Some(path) => {
                let file = path.display().to_string();
                let text = std::fs::read_to_string(path).map_err(|reason| ConfigError::Read {
                    file: file.clone(),
                    reason,
                })?;
                Config::parse(&text, &file)
            }
        }
    }

    /// Parse configuration text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<Config, ConfigError> {
        let raw: raw::RawConfig = toml::from_str(text).map_err(|e| ConfigError::Parse {
            file: file.to_string(),
            message: e.to_string().trim_end().replace('\n', "\n  "),
        })?;
        let mut config = raw.into_config(file)?;
        config.text = text.to_string();
        Ok(config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_default_is_the_paper_robot() {
        let config = Config::embedded_default();
        assert_eq!(config.robot, Robot::paper_default());
        assert_eq!(config.motion, MotionSettings::default());
        assert_eq!(config.source, EMBEDDED_NAME);
    }

    fn err(text: &str) -> String {
        Config::parse(text, "cell.toml").unwrap_err().to_string()
    }

    fn with(from: &str, to: &str) -> String {
        assert!(DEFAULT_TOML.contains(from), "{from}");
        DEFAULT_TOML.replacen(from, to, 1)
    }

    #[test]
    fn the_arms_shape_is_read_and_checked() {
        let config = Config::parse(
            &with("blade_front_mm = 128.0", "blade_front_mm = 140.0"),
            "cell.toml",
        )
        .unwrap();
        assert_eq!(config.robot.shape().blade_front_mm, 140.0);
        assert_eq!(
            *Config::embedded_default().robot.shape(),
            wrc_robot::ArmShape::default()
        );
        let e = err(&with("link2_radius_mm = 38.0", "link2_radius_mm = -1.0"));
        assert!(
            e.contains("robot.shape.link2_radius_mm") && e.contains("greater than 0"),
            "{e}"
        );
        let e = err(&with(
            "link1_z_mm = [-91.0, -57.0]",
            "link1_z_mm = [-50.0, -57.0]",
        ));
        assert!(
            e.contains("robot.shape.link1_z_mm") && e.contains("bottom below top"),
            "{e}"
        );
        let e = err(&with(
            "wafer_radius_mm = 150.0",
            "wafer_radius_mm = 150.0
wafer_mm = 1",
        ));
        assert!(e.contains("wafer_mm"), "{e}");
    }

    #[test]
    fn host_admission_is_read_and_checked() {
        let config = Config::embedded_default();
        assert_eq!(config.host, HostConfig::default());
        let text = with(
            "idle_timeout_s = 600.0",
            "idle_timeout_s = 30.0\nallow = [\"192.168.1.20\", \"10.1.0.0/16\"]\nmonitor = [\"fd00::/8\"]\ntoken_file = \"/etc/wrc/host.token\"",
        );
        let host = Config::parse(&text, "cell.toml").unwrap().host;
        assert_eq!(host.idle_timeout_s, 30.0);
        assert!(listed(&host.allow, "10.1.9.9".parse().unwrap()));
        assert!(!listed(&host.allow, "192.168.1.21".parse().unwrap()));
        assert!(listed(&host.monitor, "fd00::5".parse().unwrap()));
        assert!(host.guards_the_network());
        for (from, to, key, reason) in [
            (
                "max_connections = 256",
                "max_connections = 0",
                "host.max_connections",
                "1 to 1024",
            ),
            (
                "max_connections = 256",
                "max_connections = 5000",
                "host.max_connections",
                "1 to 1024",
            ),
            (
                "max_per_address = 64",
                "max_per_address = 300",
                "host.max_per_address",
                "max_connections (256)",
            ),
            (
                "idle_timeout_s = 600.0",
                "idle_timeout_s = -1.0",
                "host.idle_timeout_s",
                "0 (never)",
            ),
            (
                "idle_timeout_s = 600.0",
                "idle_timeout_s = 600.0\nallow = [\"robot-1\"]",
                "host.allow",
                "\"robot-1\" is not an address",
            ),
            (
                "idle_timeout_s = 600.0",
                "idle_timeout_s = 600.0\ntoken_file = \"\"",
                "host.token_file",
                "is empty",
            ),
        ] {
            let e = err(&with(from, to));
            assert!(
                e.contains("cell.toml") && e.contains(key) && e.contains(reason),
                "{e}"
            );
        }
    }

    #[test]
    fn errors_name_file_key_and_reason() {
        let e = err(&with("max_velocity = 180.0", "max_velocity = -1.0"));
        assert!(
            e.contains("cell.toml")
                && e.contains("axis.j1.max_velocity")
                && e.contains("greater than 0"),
            "{e}"
        );

        let e = err(&with("link1_mm = 200.0", "link1_mm = nan"));
        assert!(e.contains("robot.link1_mm") && e.contains("finite"), "{e}");

        let e = err(&with("profile = \"fir\"", "profile = \"scurve\""));
        assert!(
            e.contains("motion.profile") && e.contains("scurve") && e.contains("fir"),
            "{e}"
        );

        let e = err(&with("period_ms = 10.0", "period_ms = 0.0"));
        assert!(e.contains("motion.period_ms"), "{e}");

        let e = err(&with("hand_mm = 0.0", "hand_mm = 0.0\nhandd_mm = 3"));
        assert!(e.contains("cell.toml") && e.contains("handd_mm"), "{e}");

        let e = err(&with("max_velocity = 180.0", "max_velocity = \"fast\""));
        assert!(e.contains("cell.toml") && e.contains("max_velocity"), "{e}");

        let e = err(&with("role = \"elbow\"", "role = \"knee\""));
        assert!(e.contains("axis.j2.role") && e.contains("knee"), "{e}");

        let e = err(&with("unit = \"mm\"", "unit = \"inch\""));
        assert!(e.contains("axis.z.unit"), "{e}");

        let e = err(&with("name = \"j2\"", "name = \"j1\""));
        assert!(e.contains("axis.j1") && e.contains("twice"), "{e}");

        let e = err("this is = = not toml");
        assert!(e.contains("cell.toml"), "{e}");
    }

    #[test]
    fn hand_signals_default_and_are_checked() {
        assert_eq!(Config::embedded_default().hand, HandConfig::default());
        let e = err(&with("mapping_output = 1 ", "mapping_output = 0 "));
        assert!(
            e.contains("hand.mapping_output") && e.contains("vacuum"),
            "{e}"
        );
        let e = err(&with("vacuum_input = 0 ", "vacuum_input = 32 "));
        assert!(
            e.contains("hand.vacuum_input") && e.contains("0 to 31"),
            "{e}"
        );
        let e = err(&with("vacuum_settle_ms = 500.0", "vacuum_settle_ms = 0.0"));
        assert!(e.contains("hand.vacuum_settle_ms"), "{e}");
        let c = Config::parse(&with("vacuum_output = 0 ", "vacuum_output = 5 "), "x").unwrap();
        assert_eq!(c.hand.vacuum_output, 5);
    }

    #[test]
    fn the_dual_blade_example_has_blade_b_and_blade_b_is_checked() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/dual-blade.toml");
        let dual = Config::load(Some(&path)).unwrap();
        assert_eq!(Config::embedded_dual_blade().hand, dual.hand);
        assert_eq!(dual.hand.blades(), 2);
        assert_eq!(
            dual.hand.blade(1),
            Some(BladeB {
                z_offset_mm: -30.0,
                vacuum_output: 2,
                vacuum_input: 2
            })
        );
        assert_eq!(dual.hand.z_offset_mm(1), -30.0);
        assert_eq!(Config::embedded_default().hand.blades(), 1);
        assert_eq!(Config::embedded_default().hand.blade(1), None);
        let text = std::fs::read_to_string(&path).unwrap();
        let bad = |from: &str, to: &str| {
            assert!(text.contains(from), "{from}");
            err(&text.replace(from, to))
        };
        let e = bad("z_offset_mm = -30.0", "z_offset_mm = 1.0");
        assert!(
            e.contains("hand.blade_b.z_offset_mm") && e.contains("5 to 200"),
            "{e}"
        );
        let e = bad("vacuum_output = 2\n", "vacuum_output = 1\n");
        assert!(
            e.contains("hand.blade_b.vacuum_output") && e.contains("its own"),
            "{e}"
        );
        let e = bad("vacuum_input = 2\n", "vacuum_input = 0\n");
        assert!(e.contains("hand.blade_b.vacuum_input"), "{e}");
        let e = bad("vacuum_input = 2\n", "vacuum_input = 40\n");
        assert!(e.contains("0 to 31"), "{e}");
    }

    #[test]
    fn watchdog_heartbeat_and_look_ahead_are_in_milliseconds() {
        let d = Config::embedded_default();
        assert_eq!(d.boards[0].watchdog_periods, 15); // 150 ms at 10 ms
        assert_eq!(d.boards[0].heartbeat_periods, 3); // 30 ms
        assert_eq!(d.lookahead_periods, 10); // 100 ms
        assert_eq!(d.boards[0].fifo_depth, MAX_FIFO_DEPTH);
        // At 1 kHz the same milliseconds are ten times the periods, and the FIFO holds them.
        let fast = Config::parse(&with("period_ms = 10.0", "period_ms = 1.0"), "c").unwrap();
        assert_eq!(fast.boards[0].watchdog_periods, 150);
        assert_eq!(fast.boards[0].heartbeat_periods, 30);
        assert_eq!(fast.lookahead_periods, 100);
        // A part of a period is a whole one.
        let c = Config::parse(&with("watchdog_ms = 150.0", "watchdog_ms = 141.0"), "c").unwrap();
        assert_eq!(c.boards[0].watchdog_periods, 15);
        // The older keys in periods still read, but not next to the new ones.
        let old = with("watchdog_ms = 150.0", "watchdog_periods = 17");
        let old = old.replacen("heartbeat_ms = 30.0", "heartbeat_periods = 4", 1);
        let c = Config::parse(&old, "c").unwrap();
        assert_eq!(
            (c.boards[0].watchdog_periods, c.boards[0].heartbeat_periods),
            (17, 4)
        );
        let e = err(&with(
            "watchdog_ms = 150.0",
            "watchdog_ms = 150.0\nwatchdog_periods = 17",
        ));
        assert!(
            e.contains("watchdog_periods") && e.contains("watchdog_ms only"),
            "{e}"
        );
        let e = err(&with("heartbeat_ms = 30.0", "heartbeat_periods = 0"));
        assert!(
            e.contains("heartbeat_periods") && e.contains("at least 1"),
            "{e}"
        );
        for bad in ["0.0", "-5.0", "nan", "inf"] {
            let e = err(&with(
                "watchdog_ms = 150.0",
                &format!("watchdog_ms = {bad}"),
            ));
            assert!(e.contains("cell.toml") && e.contains("watchdog_ms"), "{e}");
            let e = err(&with(
                "lookahead_ms = 100.0",
                &format!("lookahead_ms = {bad}"),
            ));
            assert!(e.contains("motion.lookahead_ms"), "{e}");
        }
        // The FIFO must hold the look-ahead and one period more.
        let e = err(&with("fifo_depth = 256", "fifo_depth = 10"));
        assert!(
            e.contains("lookahead_ms") && e.contains("10 periods") && e.contains("fifo_depth"),
            "{e}"
        );
        assert!(Config::parse(&with("fifo_depth = 256", "fifo_depth = 11"), "c").is_ok());
        let e = err(&with("fifo_depth = 256", "fifo_depth = 257"));
        assert!(e.contains("fifo_depth") && e.contains("1 to 256"), "{e}");
        // The watchdog must outlast the look-ahead: a stall the FIFO rides out must not
        // trip it (in the older key, in periods, too).
        let e = err(&with("watchdog_ms = 150.0", "watchdog_ms = 100.0"));
        assert!(
            e.contains("board[1].watchdog_ms")
                && e.contains("100 ms is not longer than [motion] lookahead_ms (100 ms)"),
            "{e}"
        );
        let e = err(&with("watchdog_ms = 150.0", "watchdog_periods = 10"));
        assert!(e.contains("board[1].watchdog_ms"), "{e}");
        assert!(Config::parse(&with("watchdog_ms = 150.0", "watchdog_ms = 101.0"), "c").is_ok());
        let tight = with("watchdog_ms = 150.0", "watchdog_ms = 30.0");
        let tight = tight.replacen("lookahead_ms = 100.0", "lookahead_ms = 20.0", 1);
        assert!(Config::parse(&tight, "c").is_ok(), "the PREEMPT_RT values");
    }

    /// Regression: `[trace] seconds = 3600` with `period_ms = 0.1` was accepted, and the
    /// controller then asked for a 10 GB trace ring at start-up and was killed (the `config`
    /// fuzz target's malloc limit caught the allocation).
    #[test]
    fn a_trace_ring_too_large_for_memory_is_refused_by_name() {
        let big = with("seconds = 30.0 ", "seconds = 3600.0");
        let big = big.replacen("lookahead_ms = 100.0", "lookahead_ms = 1.0", 1);
        let e = err(&big.replacen("period_ms = 10.0", "period_ms = 0.1", 1));
        assert!(
            e.contains("cell.toml")
                && e.contains("trace.seconds")
                && e.contains("36000000 samples")
                && e.contains("lengthen motion.period_ms"),
            "{e}"
        );
        // An hour at 1 ms is the most there is.
        let hour = Config::parse(&big.replacen("period_ms = 10.0", "period_ms = 1.0", 1), "c");
        assert_eq!(hour.unwrap().trace.seconds, 3600.0);
    }

    #[test]
    fn missing_file_is_named() {
        let e = Config::load(Some(Path::new("/nonexistent/wrc.toml")))
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/wrc.toml"), "{e}");
    }

    #[test]
    fn other_arms_need_no_code_changes() {
        // A SCARA-like arm with other link lengths, no wrist and no Z.
        let text = r#"
            [robot]
            link1_mm = 300.0
            link2_mm = 150.0
            [[axis]]
            name = "shoulder"
            role = "shoulder"
            unit = "deg"
            pulses_per_unit = 500.0
            min = -90.0
            max = 90.0
            max_velocity = 90.0
            max_acceleration = 300.0
            max_jerk = 3000.0
            home = 0.0
            [[axis]]
            name = "elbow"
            role = "elbow"
            unit = "deg"
            pulses_per_unit = 500.0
            min = -150.0
            max = 150.0
            max_velocity = 90.0
            max_acceleration = 300.0
            max_jerk = 3000.0
            home = 90.0
        "#;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("scara.toml");
        std::fs::write(&path, text).unwrap();
        let config = Config::load(Some(&path)).unwrap();
        assert_eq!(config.robot.axis_count(), 2);
        assert!(config.robot.arm().wrist.is_none() && config.robot.arm().z.is_none());
        assert_eq!(config.motion, MotionSettings::default());
        assert_eq!(config.source, path.display().to_string());
    }
}
