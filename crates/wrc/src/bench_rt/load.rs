//! The load for `wrc bench rt --load` and `wrc bench soak --load`: stress-ng, or for `wrc
//! bench rt` when stress-ng is not installed a built-in stressor (one arithmetic spinner per
//! CPU and one thread that keeps allocating, touching and freeing 64 MiB). Both run on normal
//! scheduling, as other work on the controller would.

use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

/// A running load; dropped or [`Load::stop`]ped, it ends.
#[derive(Debug)]
pub enum Load {
    /// stress-ng as a child process.
    StressNg {
        /// The process.
        child: Child,
        /// Its command line.
        command: String,
    },
    /// The built-in stressor's threads.
    BuiltIn {
        /// Set to end the threads.
        stop: Arc<AtomicBool>,
        /// The threads.
        threads: Vec<JoinHandle<()>>,
    },
}

impl Load {
    /// Start stress-ng (CPU and memory stressors on every CPU for `seconds` + 5 s) if it is
    /// installed, else the built-in stressor.
    pub fn start(seconds: u64) -> Load {
        let cpus = std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1);
        Load::stress_ng(cpus, "128M", seconds + 5).unwrap_or_else(|_| Load::built_in(cpus))
    }

    /// Start `stress-ng --cpu <cpus> --vm 1 --vm-bytes <vm_bytes> --timeout <seconds>s`; an
    /// error when it cannot be started (not installed).
    pub fn stress_ng(cpus: usize, vm_bytes: &str, seconds: u64) -> std::io::Result<Load> {
        let args = [
            "--cpu".to_string(),
            cpus.to_string(),
            "--vm".into(),
            "1".into(),
            "--vm-bytes".into(),
            vm_bytes.into(),
            "--timeout".into(),
            format!("{seconds}s"),
            "--quiet".into(),
        ];
        let command = format!("stress-ng {}", args.join(" "));
        let child = Command::new("stress-ng")
            .args(&args)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()?;
        Ok(Load::StressNg { child, command })
    }

    /// `Ok` while the load runs; how it ended when stress-ng has exited.
    pub fn check_running(&mut self) -> Result<(), String> {
        match self {
            Load::StressNg { child, command } => match child.try_wait() {
                Ok(None) => Ok(()),
                Ok(Some(status)) => Err(format!("`{command}` ended ({status})")),
                Err(e) => Err(format!("`{command}`: {e}")),
            },
            Load::BuiltIn { .. } => Ok(()),
        }
    }

    /// The built-in stressor on `cpus` spinners plus one memory thread.
    pub fn built_in(cpus: usize) -> Load {
        let stop = Arc::new(AtomicBool::new(false));
        let mut threads = Vec::new();
        for _ in 0..cpus {
            let stop = stop.clone();
            threads.push(std::thread::spawn(move || {
                let mut x = 1.0f64;
                while !stop.load(Ordering::Relaxed) {
                    for _ in 0..10_000 {
                        x = (x * 1.000_001 + 0.25).sqrt();
                    }
                    std::hint::black_box(x);
                }
            }));
        }
        let stop_mem = stop.clone();
        threads.push(std::thread::spawn(move || {
            while !stop_mem.load(Ordering::Relaxed) {
                let mut block = vec![0u8; 64 << 20];
                for i in (0..block.len()).step_by(4096) {
                    block[i] = i as u8;
                }
                std::hint::black_box(&block);
            }
        }));
        Load::BuiltIn { stop, threads }
    }

    /// What is running, for the report.
    pub fn describe(&self) -> String {
        match self {
            Load::StressNg { command, .. } => command.clone(),
            Load::BuiltIn { threads, .. } => {
                format!("built-in stressor ({} CPU spinners, 1 thread allocating 64 MiB; stress-ng not installed)", threads.len().saturating_sub(1))
            }
        }
    }

    /// End the load.
    pub fn stop(mut self) {
        self.end();
    }

    /// End the load and wait for it; nothing left to do the second time.
    fn end(&mut self) {
        match self {
            Load::StressNg { child, .. } => {
                if matches!(child.try_wait(), Ok(None)) {
                    // SIGTERM lets stress-ng end its own workers.
                    // SAFETY: kill() with the pid of a child we spawned and have not reaped
                    // (try_wait just found it running), so the pid is still ours.
                    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) };
                }
                let _ = child.wait();
            }
            Load::BuiltIn { stop, threads } => {
                stop.store(true, Ordering::Relaxed);
                threads.drain(..).for_each(|t| {
                    let _ = t.join();
                });
            }
        }
    }
}

impl Drop for Load {
    /// A load dropped (a benchmark that ended early) ends too.
    fn drop(&mut self) {
        self.end();
    }
}
