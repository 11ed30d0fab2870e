//! Waiting for a condition in the process-level tests: probe it until it holds, with a
//! deadline that only a test whose condition never comes reaches. The deadline is not a
//! timing assertion (a loaded machine only makes the wait longer), and no test sleeps in
//! the hope that a process got somewhere.

use std::time::{Duration, Instant};

/// How long a condition may take before the test gives up on it: generous, for a loaded
/// machine.
pub const PATIENCE: Duration = Duration::from_secs(30);

/// Pause between two probes of a condition: short next to a controller period (10 ms).
const POLL_INTERVAL: Duration = Duration::from_millis(5);

/// Probe until it gives `Ok`, for at most `patience`; the `Err` of the last probe (what it
/// saw) when the condition did not come.
pub fn poll_until<T>(
    patience: Duration,
    mut probe: impl FnMut() -> Result<T, String>,
) -> Result<T, String> {
    let deadline = Instant::now() + patience;
    loop {
        match probe() {
            Ok(value) => return Ok(value),
            Err(last) if Instant::now() >= deadline => return Err(last),
            Err(_) => std::thread::sleep(POLL_INTERVAL),
        }
    }
}

/// Probe until it gives `Ok` and return its value; fail the test, naming `what` it waited
/// for and what the last probe saw, when the condition has not come within [`PATIENCE`].
#[track_caller]
pub fn wait_until<T>(what: &str, probe: impl FnMut() -> Result<T, String>) -> T {
    match poll_until(PATIENCE, probe) {
        Ok(value) => value,
        Err(last) => panic!("waited {PATIENCE:?} in vain for {what}; last seen: {last}"),
    }
}
