//! The real-time task table (`[[task]]`): each task's name, the paper's priority (lower =
//! more urgent) and period. Without a `[[task]]` section the paper's Table 1 applies.

use serde::Deserialize;
use wrc_rt::{TaskSpec, TaskTable};

use crate::ConfigError;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawTask {
    name: String,
    priority: i64,
    period_ms: f64,
    #[serde(default)]
    cpu: Option<usize>,
}

/// Validate the `[[task]]` entries into a task table; none at all gives the paper's Table 1.
pub(crate) fn tasks(raw: Vec<RawTask>, file: &str) -> Result<TaskTable, ConfigError> {
    if raw.is_empty() {
        return Ok(TaskTable::paper_table1());
    }
    let invalid = |key: String, reason: String| ConfigError::Invalid {
        file: file.to_string(),
        key,
        reason,
    };
    let mut specs = Vec::with_capacity(raw.len());
    for (i, t) in raw.into_iter().enumerate() {
        let key = |field: &str| {
            if t.name.is_empty() {
                format!("task[{}].{field}", i + 1)
            } else {
                format!("task.{}.{field}", t.name)
            }
        };
        let priority = u8::try_from(t.priority).map_err(|_| {
            invalid(
                key("priority"),
                format!("{} is out of range: use 1 (most urgent) to 89", t.priority),
            )
        })?;
        if !t.period_ms.is_finite() || t.period_ms <= 0.0 {
            return Err(invalid(
                key("period_ms"),
                format!(
                    "{} is not a period: use a finite number of ms greater than 0",
                    t.period_ms
                ),
            ));
        }
        let period_us = (t.period_ms * 1000.0).round() as u64;
        specs.push(TaskSpec {
            name: t.name,
            priority,
            period_us,
            cpu: t.cpu,
        });
    }
    TaskTable::new(specs).map_err(|e| {
        let field = match e.field {
            "period_us" => "period_ms",
            other => other,
        };
        let reason = if field == "period_ms" {
            format!(
                "{} ms is out of range: use {} ms to {} ms",
                e.reason
                    .split(' ')
                    .next()
                    .unwrap_or("")
                    .parse::<f64>()
                    .map(|us| us / 1000.0)
                    .unwrap_or(f64::NAN),
                wrc_rt::table::MIN_PERIOD_US as f64 / 1000.0,
                wrc_rt::table::MAX_PERIOD_US as f64 / 1000.0
            )
        } else {
            e.reason.clone()
        };
        invalid(format!("task.{}.{field}", e.task), reason)
    })
}

#[cfg(test)]
mod tests {
    use crate::{Config, DEFAULT_TOML};

    fn err(text: &str) -> String {
        Config::parse(text, "cell.toml").unwrap_err().to_string()
    }

    fn with(from: &str, to: &str) -> String {
        assert!(DEFAULT_TOML.contains(from), "{from}");
        DEFAULT_TOML.replacen(from, to, 1)
    }

    #[test]
    fn the_default_file_holds_the_paper_table1() {
        let config = Config::embedded_default();
        assert_eq!(config.tasks, wrc_rt::TaskTable::paper_table1());
    }

    #[test]
    fn no_task_section_means_table1() {
        let cut = DEFAULT_TOML
            .find("[[task]]")
            .expect("default.toml has a [[task]] section");
        let config = Config::parse(&DEFAULT_TOML[..cut], "cell.toml").unwrap();
        assert_eq!(config.tasks, wrc_rt::TaskTable::paper_table1());
    }

    #[test]
    fn task_errors_name_the_key() {
        let pg = "name = \"pulse_generator\"\npriority = 20\nperiod_ms = 10";
        let e = err(&with(
            pg,
            "name = \"pulse_generator\"\npriority = 20\nperiod_ms = 0.01",
        ));
        assert!(
            e.contains("cell.toml")
                && e.contains("task.pulse_generator.period_ms")
                && e.contains("0.1 ms"),
            "{e}"
        );
        let e = err(&with(
            pg,
            "name = \"pulse_generator\"\npriority = 20\nperiod_ms = -1",
        ));
        assert!(e.contains("task.pulse_generator.period_ms"), "{e}");
        let e = err(&with(
            pg,
            "name = \"pulse_generator\"\npriority = 0\nperiod_ms = 10",
        ));
        assert!(
            e.contains("task.pulse_generator.priority") && e.contains("1 (most urgent)"),
            "{e}"
        );
        let e = err(&with(
            pg,
            "name = \"pulse_generator\"\npriority = 300\nperiod_ms = 10",
        ));
        assert!(e.contains("task.pulse_generator.priority"), "{e}");
        let e = err(&with(
            pg,
            "name = \"error_check\"\npriority = 20\nperiod_ms = 10",
        ));
        assert!(
            e.contains("task.error_check.name") && e.contains("twice"),
            "{e}"
        );
        let e = err(&with(
            pg,
            "name = \"pulse_generator\"\npriority = 20\nperiod_ms = 10\nperiod = 3",
        ));
        assert!(e.contains("period"), "{e}");
    }

    #[test]
    fn a_custom_table_replaces_table1() {
        let cut = DEFAULT_TOML.find("[[task]]").unwrap();
        let text = format!(
            "{}[[task]]\nname = \"servo\"\npriority = 5\nperiod_ms = 1\ncpu = 1\n",
            &DEFAULT_TOML[..cut]
        );
        let config = Config::parse(&text, "cell.toml").unwrap();
        let servo = config.tasks.get("servo").unwrap();
        assert_eq!(
            (
                config.tasks.tasks().len(),
                servo.priority,
                servo.period_us,
                servo.cpu
            ),
            (1, 5, 1000, Some(1))
        );
    }
}
