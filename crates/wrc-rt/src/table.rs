//! The task table: each task's name, paper priority and period; defaults are the paper's
//! Table 1.

use std::fmt;

use crate::sched_policy::{PAPER_PRIORITY_MAX, PAPER_PRIORITY_MIN};

/// Shortest period a task may have [µs].
pub const MIN_PERIOD_US: u64 = 100;
/// Longest period a task may have [µs].
pub const MAX_PERIOD_US: u64 = 10_000_000;

/// One periodic task: who it is, how urgent, how often.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TaskSpec {
    /// Identifier in snake case (`pulse_generator`); also names its thread and config keys.
    pub name: String,
    /// The paper's priority: lower is more urgent (10 … 45 in Table 1). Mapped to SCHED_FIFO by
    /// [`crate::sched_policy::fifo_priority`].
    pub priority: u8,
    /// Period [µs].
    pub period_us: u64,
    /// CPU to pin the task to; `None` follows the runtime's pinning policy.
    pub cpu: Option<usize>,
}

impl TaskSpec {
    /// A task that follows the runtime's pinning policy.
    pub fn new(name: impl Into<String>, priority: u8, period_us: u64) -> TaskSpec {
        TaskSpec {
            name: name.into(),
            priority,
            period_us,
            cpu: None,
        }
    }

    /// Period [ns].
    pub fn period_ns(&self) -> u64 {
        self.period_us * 1000
    }

    /// The paper's name for the task when it is one of Table 1's, else the identifier.
    pub fn label(&self) -> String {
        paper_label(&self.name)
            .map(str::to_string)
            .unwrap_or_else(|| self.name.clone())
    }

    fn validate(&self) -> Result<(), TaskTableError> {
        let err = |field: &'static str, reason: String| TaskTableError {
            task: self.name.clone(),
            field,
            reason,
        };
        let name_ok = !self.name.is_empty()
            && self.name.len() <= 32
            && self
                .name
                .bytes()
                .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_');
        if !name_ok {
            return Err(err(
                "name",
                format!(
                    "{:?} is not a task name: use 1 to 32 of a-z, 0-9 and '_'",
                    self.name
                ),
            ));
        }
        if !(PAPER_PRIORITY_MIN..=PAPER_PRIORITY_MAX).contains(&self.priority) {
            return Err(err(
                "priority",
                format!(
                    "{} is out of range: use {PAPER_PRIORITY_MIN} (most urgent) to {PAPER_PRIORITY_MAX}",
                    self.priority
                ),
            ));
        }
        if !(MIN_PERIOD_US..=MAX_PERIOD_US).contains(&self.period_us) {
            return Err(err(
                "period_us",
                format!(
                    "{} µs is out of range: use {MIN_PERIOD_US} µs to {MAX_PERIOD_US} µs",
                    self.period_us
                ),
            ));
        }
        Ok(())
    }
}

/// The name the paper uses for one of its Table 1 tasks.
pub fn paper_label(name: &str) -> Option<&'static str> {
    Some(match name {
        "error_check" => "Error Check",
        "pulse_generator" => "Pulse Generator",
        "simulator_manager" => "Simulator Manager",
        "velocity_generator" => "Velocity Generator",
        "command_interpreter" => "Command Interpreter",
        "io_monitor" => "I/O Monitor",
        "ethernet" => "Ethernet",
        "rs232c" => "RS232C",
        _ => return None,
    })
}

/// A task table entry that cannot be used.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("task {task}: {field}: {reason}")]
#[non_exhaustive]
pub struct TaskTableError {
    /// The task's name as given.
    pub task: String,
    /// The offending field (`name`, `priority`, `period_us`).
    pub field: &'static str,
    /// What is wrong and what is expected.
    pub reason: String,
}

/// A validated set of tasks with unique names.
///
/// ```
/// let table = wrc_rt::TaskTable::paper_table1();
/// let pulse = table.get("pulse_generator").unwrap();
/// assert_eq!((pulse.priority, pulse.period_us), (20, 10_000));
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TaskTable {
    tasks: Vec<TaskSpec>,
}

impl Default for TaskTable {
    fn default() -> Self {
        TaskTable::paper_table1()
    }
}

impl TaskTable {
    /// The paper's Table 1: priority (lower = more urgent) and period of each real-time task.
    pub fn paper_table1() -> TaskTable {
        let t =
            |name: &str, priority, period_ms: u64| TaskSpec::new(name, priority, period_ms * 1000);
        TaskTable {
            tasks: vec![
                t("error_check", 10, 100),
                t("pulse_generator", 20, 10),
                t("simulator_manager", 25, 10),
                t("velocity_generator", 30, 50),
                t("command_interpreter", 40, 50),
                t("io_monitor", 45, 100),
                t("ethernet", 45, 100),
                t("rs232c", 45, 100),
            ],
        }
    }

    /// Validate `tasks`: names, priorities, periods, no name twice.
    pub fn new(tasks: Vec<TaskSpec>) -> Result<TaskTable, TaskTableError> {
        for (i, task) in tasks.iter().enumerate() {
            task.validate()?;
            if tasks[..i].iter().any(|t| t.name == task.name) {
                return Err(TaskTableError {
                    task: task.name.clone(),
                    field: "name",
                    reason: "the name is used twice; every task needs its own".into(),
                });
            }
        }
        Ok(TaskTable { tasks })
    }

    /// The tasks in table order.
    pub fn tasks(&self) -> &[TaskSpec] {
        &self.tasks
    }

    /// The task called `name`.
    pub fn get(&self, name: &str) -> Option<&TaskSpec> {
        self.tasks.iter().find(|t| t.name == name)
    }

    /// Replace the period of task `name` [µs], validated.
    pub fn set_period_us(&mut self, name: &str, period_us: u64) -> Result<(), TaskTableError> {
        let mut tasks = self.tasks.clone();
        if let Some(task) = tasks.iter_mut().find(|t| t.name == name) {
            task.period_us = period_us;
        }
        *self = TaskTable::new(tasks)?;
        Ok(())
    }
}

impl fmt::Display for TaskTable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for t in &self.tasks {
            writeln!(
                f,
                "{:<20} priority {:>2}  period {:>8} µs",
                t.label(),
                t.priority,
                t.period_us
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table1_is_valid_and_ordered_by_urgency() {
        let t = TaskTable::paper_table1();
        assert_eq!(TaskTable::new(t.tasks().to_vec()).unwrap(), t);
        assert_eq!(t.tasks().len(), 8);
        assert!(t.tasks().windows(2).all(|w| w[0].priority <= w[1].priority));
        assert_eq!(t.get("io_monitor").unwrap().label(), "I/O Monitor");
    }

    #[test]
    fn bad_entries_name_task_and_field() {
        let e = TaskTable::new(vec![TaskSpec::new("a", 0, 1000)]).unwrap_err();
        assert_eq!((e.task.as_str(), e.field), ("a", "priority"));
        let e = TaskTable::new(vec![TaskSpec::new("a", 10, 5)]).unwrap_err();
        assert_eq!(e.field, "period_us");
        assert!(e.to_string().contains("100 µs"), "{e}");
        let e = TaskTable::new(vec![TaskSpec::new("Bad Name", 10, 1000)]).unwrap_err();
        assert_eq!(e.field, "name");
        let e = TaskTable::new(vec![
            TaskSpec::new("a", 10, 1000),
            TaskSpec::new("a", 11, 1000),
        ])
        .unwrap_err();
        assert!(e.to_string().contains("twice"), "{e}");
        let mut t = TaskTable::paper_table1();
        assert!(t.set_period_us("pulse_generator", 1).is_err());
        t.set_period_us("pulse_generator", 1000).unwrap();
        assert_eq!(t.get("pulse_generator").unwrap().period_us, 1000);
    }
}
