//! The soak's configuration at another servo period: the embedded default with `[motion]
//! period_ms` and the Pulse Generator's and Simulator Manager's `[[task]] period_ms` set to
//! the period asked for, every other line as it is (the look-ahead, the watchdog and the
//! heartbeat are in milliseconds, so they keep their time and change their periods).

use anyhow::{bail, Context};
use wrc_config::Config;

/// The tasks that run at the servo period: they move with `[motion] period_ms`.
const SERVO_TASKS: [&str; 2] = ["pulse_generator", "simulator_manager"];

/// The default configuration's text at a servo period of `period_ms` [ms], and what it parses
/// to; an error when the period does not make a valid configuration.
pub(crate) fn config_for_period(period_ms: f64) -> anyhow::Result<(String, Config)> {
    let text = rewrite(wrc_config::DEFAULT_TOML, period_ms);
    let config = Config::parse(&text, "the soak's configuration")
        .with_context(|| format!("--period-ms {period_ms} does not make a valid configuration"))?;
    // The rewrite works on the text: check that it reached every line it had to.
    let period_us = (period_ms * 1000.0).round() as u64;
    if (config.motion.period_s * 1e6).round() as u64 != period_us {
        bail!("the soak's configuration kept [motion] period_ms: the default's layout changed");
    }
    for name in SERVO_TASKS {
        if config.tasks.get(name).map(|t| t.period_us) != Some(period_us) {
            bail!(
                "the soak's configuration kept task {name}'s period: the default's layout changed"
            );
        }
    }
    Ok((text, config))
}

/// `text` with `period_ms = …` replaced by `period_ms` in `[motion]` and in the servo tasks'
/// `[[task]]` tables; comments after the value are kept.
fn rewrite(text: &str, period_ms: f64) -> String {
    let mut out = String::with_capacity(text.len() + 64);
    // Whether the table being read is one whose period follows the servo period.
    let mut servo_table = false;
    let mut task_table = false;
    for line in text.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with('[') {
            task_table = trimmed.starts_with("[[task]]");
            servo_table = trimmed.starts_with("[motion]");
        } else if task_table && trimmed.starts_with("name") {
            servo_table = SERVO_TASKS
                .iter()
                .any(|t| value_of(trimmed) == Some(&format!("\"{t}\"")[..]));
        }
        match trimmed.strip_prefix("period_ms") {
            Some(rest) if servo_table && rest.trim_start().starts_with('=') => {
                let comment = rest.find('#').map_or("", |i| &rest[i..]);
                let value = format!("period_ms = {period_ms:?}");
                // The comment stays in its column (one blank after a longer value).
                let column = (line.len() - comment.len()).max(value.len() + 1);
                if comment.is_empty() {
                    out.push_str(&value);
                } else {
                    out.push_str(&format!("{value:<column$}{comment}"));
                }
            }
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

/// The value of a `key = value` line, without a comment after it.
fn value_of(line: &str) -> Option<&str> {
    let (_, value) = line.split_once('=')?;
    Some(value.split('#').next().unwrap_or("").trim())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_millisecond_moves_the_servo_tasks_and_keeps_the_look_ahead_time() {
        let (text, c) = config_for_period(1.0).unwrap();
        assert_eq!(c.motion.period_s, 0.001);
        assert_eq!(c.tasks.get("pulse_generator").unwrap().period_us, 1_000);
        assert_eq!(c.tasks.get("simulator_manager").unwrap().period_us, 1_000);
        // The other tasks keep their periods.
        assert_eq!(c.tasks.get("velocity_generator").unwrap().period_us, 50_000);
        assert_eq!(c.tasks.get("error_check").unwrap().period_us, 100_000);
        // lookahead_ms = 100 is 100 periods at 1 ms (10 at the default's 10 ms).
        assert_eq!(c.lookahead_periods, 100);
        assert_eq!(c.boards[0].watchdog_periods, 150);
        let line = text.lines().find(|l| l.starts_with("period_ms = 1.0 "));
        assert_eq!(
            line.map(|l| l.find('#')),
            Some(Some(30)),
            "the comment is kept in its column: {text}"
        );
        let default = Config::embedded_default();
        assert_eq!(default.lookahead_periods, 10);
        assert_eq!(c.robot.axis_count(), default.robot.axis_count());
    }

    #[test]
    fn the_default_period_gives_the_default_configuration() {
        let (_, c) = config_for_period(10.0).unwrap();
        let default = Config::embedded_default();
        assert_eq!(c.tasks, default.tasks);
        assert_eq!(c.motion.period_s, default.motion.period_s);
        assert_eq!(c.lookahead_periods, default.lookahead_periods);
    }

    #[test]
    fn a_period_the_configuration_refuses_is_an_error() {
        let e = config_for_period(0.0).unwrap_err();
        assert!(format!("{e:#}").contains("--period-ms 0"), "{e:#}");
    }
}
