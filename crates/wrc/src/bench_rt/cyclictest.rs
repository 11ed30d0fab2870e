//! Running `cyclictest` (rt-tests) alongside the task set, at the Pulse Generator's priority
//! and interval, and reading its histogram: the reference for what this machine's wake-up
//! latency can be.

use std::io::Read;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Largest latency cyclictest's histogram keeps [µs]; beyond it counts as overflow.
pub const HISTOGRAM_MAX_US: u64 = 20_000;

/// cyclictest's wake-up latency figures [µs] (1 µs resolution).
#[derive(Debug, Clone, PartialEq)]
pub struct CyclictestResult {
    /// Samples.
    pub samples: u64,
    /// Minimum [µs].
    pub min_us: f64,
    /// Mean [µs].
    pub avg_us: f64,
    /// Median [µs].
    pub p50_us: f64,
    /// 99th percentile [µs].
    pub p99_us: f64,
    /// Maximum [µs].
    pub max_us: f64,
    /// The command line that was run.
    pub command: String,
}

/// Where cyclictest is, when it is installed.
pub fn find() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|dir| dir.join("cyclictest"))
        .find(|p| p.is_file())
}

/// A cyclictest process running for a fixed time.
#[derive(Debug)]
pub struct Cyclictest {
    child: Child,
    command: String,
    duration: Duration,
    started: Instant,
    // The histogram is ~20 000 lines, more than a pipe holds: read it while cyclictest runs.
    stdout: Option<std::thread::JoinHandle<String>>,
}

impl Cyclictest {
    /// Start `binary` with one measuring thread at SCHED_FIFO `fifo_priority`, waking every
    /// `interval_us` [µs] for `seconds` [s], memory locked, optionally pinned to `cpu`.
    pub fn start(
        binary: &std::path::Path,
        fifo_priority: i32,
        interval_us: u64,
        seconds: u64,
        cpu: Option<usize>,
    ) -> std::io::Result<Cyclictest> {
        let mut args = vec![
            "-m".to_string(),
            "-q".into(),
            format!("-p{fifo_priority}"),
            format!("-i{interval_us}"),
            "-t1".into(),
            format!("-D{seconds}"),
            format!("-h{HISTOGRAM_MAX_US}"),
        ];
        if let Some(cpu) = cpu {
            args.push(format!("-a{cpu}"));
        }
        let command = format!("{} {}", binary.display(), args.join(" "));
        let mut child = Command::new(binary)
            .args(&args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()?;
        let stdout = child.stdout.take().map(|mut pipe| {
            std::thread::spawn(move || {
                let mut out = String::new();
                let _ = pipe.read_to_string(&mut out);
                out
            })
        });
        Ok(Cyclictest {
            child,
            command,
            duration: Duration::from_secs(seconds),
            started: Instant::now(),
            stdout,
        })
    }

    /// Wait for it to end (killing it 10 s after its planned end) and read its figures.
    pub fn finish(mut self) -> Result<CyclictestResult, String> {
        let deadline = self.started + self.duration + Duration::from_secs(10);
        let status = loop {
            match self.child.try_wait() {
                Ok(Some(status)) => break status,
                Ok(None) if Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(20))
                }
                Ok(None) => {
                    let _ = self.child.kill();
                    let _ = self.child.wait();
                    return Err(format!("`{}` did not end; killed", self.command));
                }
                Err(e) => return Err(format!("`{}`: {e}", self.command)),
            }
        };
        let out = self
            .stdout
            .take()
            .and_then(|t| t.join().ok())
            .unwrap_or_default();
        let mut err = String::new();
        if let Some(mut s) = self.child.stderr.take() {
            let _ = s.read_to_string(&mut err);
        }
        if !status.success() {
            return Err(format!(
                "`{}` failed ({status}): {}",
                self.command,
                err.trim()
            ));
        }
        let mut result = parse(&out)
            .ok_or_else(|| format!("`{}` printed no histogram: {}", self.command, err.trim()))?;
        result.command = self.command;
        Ok(result)
    }
}

/// Read cyclictest's `-h` output (`bucket count` lines, then `# Max Latencies: …`).
pub fn parse(text: &str) -> Option<CyclictestResult> {
    let mut buckets = Vec::new();
    let (mut max_us, mut min_us, mut avg_us, mut overflows) = (None, None, None, 0u64);
    for line in text.lines() {
        let field = |prefix: &str| {
            line.strip_prefix(prefix)
                .and_then(|v| v.split_whitespace().next()?.parse::<f64>().ok())
        };
        if let Some(v) = field("# Max Latencies:") {
            max_us = Some(v);
        } else if let Some(v) = field("# Min Latencies:") {
            min_us = Some(v);
        } else if let Some(v) = field("# Avg Latencies:") {
            avg_us = Some(v);
        } else if let Some(v) = field("# Histogram Overflows:") {
            overflows = v as u64;
        } else if !line.starts_with('#') {
            let mut parts = line.split_whitespace();
            if let (Some(Ok(us)), Some(Ok(n))) = (
                parts.next().map(str::parse::<u64>),
                parts.next().map(str::parse::<u64>),
            ) {
                buckets.push((us, n));
            }
        }
    }
    let max_us = max_us?;
    let samples = buckets.iter().map(|b| b.1).sum::<u64>() + overflows;
    if samples == 0 {
        return None;
    }
    // The bucket the `q` quantile falls in; beyond the last bucket, the maximum.
    let quantile = |q: f64| {
        let rank = ((q * samples as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (us, n) in &buckets {
            seen += n;
            if seen >= rank {
                return *us as f64;
            }
        }
        max_us
    };
    let (p50_us, p99_us) = (quantile(0.5), quantile(0.99));
    Some(CyclictestResult {
        samples,
        min_us: min_us.unwrap_or(0.0),
        avg_us: avg_us.unwrap_or(0.0),
        p50_us,
        p99_us,
        max_us,
        command: String::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_histogram_and_summary() {
        let mut text = String::from("# /dev/cpu_dma_latency set to 0us\n");
        for us in 0..100u64 {
            text.push_str(&format!(
                "{us:06} {:06}\n",
                if us == 10 {
                    98
                } else if us == 40 {
                    1
                } else {
                    0
                }
            ));
        }
        text.push_str("# Total: 000000100\n# Min Latencies: 00010\n# Avg Latencies: 00011\n");
        text.push_str("# Max Latencies: 00372\n# Histogram Overflows: 00001\n# Thread 0:\n");
        let r = parse(&text).unwrap();
        assert_eq!(
            (r.samples, r.min_us, r.avg_us, r.max_us),
            (100, 10.0, 11.0, 372.0)
        );
        assert_eq!((r.p50_us, r.p99_us), (10.0, 40.0));
        assert!(parse("nothing here").is_none());
    }
}
