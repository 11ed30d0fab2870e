//! Scheduling policy: the paper's priorities mapped to SCHED_FIFO, memory locking, CPU pinning,
//! and a plain statement of what the process actually got.
//!
//! Mapping: `SCHED_FIFO priority = 90 − paper priority`, so the paper's 10 (Error Check) runs
//! at 80, 20 (Pulse Generator) at 70, 25 at 65, 30 at 60, 40 at 50 and 45 at 45. Lower paper
//! numbers are more urgent and get higher FIFO priorities (monotonic); everything stays below
//! 90, leaving 90–99 to the kernel's own watchdog/migration threads, and the Pulse Generator
//! above the default PREEMPT_RT interrupt threads (50).

use std::fmt;
use std::io;

/// Most urgent paper priority accepted.
pub const PAPER_PRIORITY_MIN: u8 = 1;
/// Least urgent paper priority accepted.
pub const PAPER_PRIORITY_MAX: u8 = 89;

/// The SCHED_FIFO priority (1 … 89) for a paper priority (1 … 89, lower = more urgent).
pub fn fifo_priority(paper_priority: u8) -> i32 {
    90 - i32::from(paper_priority.clamp(PAPER_PRIORITY_MIN, PAPER_PRIORITY_MAX))
}

/// Whether the runtime asks for real-time scheduling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RealtimeMode {
    /// SCHED_FIFO and locked memory when the process may have them; otherwise normal
    /// scheduling, said once at start-up.
    #[default]
    Auto,
    /// Normal scheduling (SCHED_OTHER) without trying (tests, development).
    Off,
}

/// Where task threads run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PinPolicy {
    /// Pin every task without its own `cpu` to the first CPU named in
    /// `/sys/devices/system/cpu/isolated`; leave them unpinned when none is isolated.
    #[default]
    IsolatedIfAny,
    /// Pin every task without its own `cpu` to this CPU.
    Cpu(usize),
    /// No pinning (tasks with their own `cpu` are still pinned).
    None,
}

/// The scheduling one thread got.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ThreadSched {
    /// SCHED_FIFO at this priority.
    Fifo(i32),
    /// Normal scheduling; the reason real-time was not used.
    Normal(String),
}

/// Put the calling thread on SCHED_FIFO at `fifo_priority` (1 … 99).
pub fn set_current_thread_fifo(fifo_priority: i32) -> io::Result<()> {
    let param = libc::sched_param {
        sched_priority: fifo_priority,
    };
    // SAFETY: pthread_self() is the calling thread, alive for the call; `param` is a valid
    // sched_param on the stack.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    if rc == 0 {
        Ok(())
    } else {
        Err(io::Error::from_raw_os_error(rc))
    }
}

/// Pin the calling thread to `cpu`.
pub fn pin_current_thread(cpu: usize) -> io::Result<()> {
    if cpu >= libc::CPU_SETSIZE as usize {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("CPU {cpu} does not exist"),
        ));
    }
    // SAFETY: cpu_set_t is plain data; all-zero is the empty set, which CPU_ZERO also makes.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    // SAFETY: `cpu` < CPU_SETSIZE was checked above, so CPU_SET stays inside `set`.
    unsafe { libc::CPU_SET(cpu, &mut set) };
    // SAFETY: pid 0 is the calling thread; `set` is a valid cpu_set_t of the size passed.
    let rc = unsafe { libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set) };
    if rc == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

/// The CPUs named in `/sys/devices/system/cpu/isolated` (kernel `isolcpus=`), maybe none.
pub fn isolated_cpus() -> Vec<usize> {
    std::fs::read_to_string("/sys/devices/system/cpu/isolated")
        .map(|s| parse_cpu_list(&s))
        .unwrap_or_default()
}

/// Parse a kernel CPU list such as `2-3,5`; malformed parts are ignored.
pub fn parse_cpu_list(text: &str) -> Vec<usize> {
    let mut cpus = Vec::new();
    for part in text.trim().split(',').filter(|p| !p.is_empty()) {
        match part.split_once('-') {
            Some((a, b)) => {
                if let (Ok(a), Ok(b)) = (a.trim().parse::<usize>(), b.trim().parse::<usize>()) {
                    cpus.extend(a..=b);
                }
            }
            None => cpus.extend(part.trim().parse::<usize>().ok()),
        }
    }
    cpus
}

/// Ask the kernel to keep CPU idle-exit latency at 0 µs (PM QoS, `/dev/cpu_dma_latency`)
/// for as long as the returned file stays open — what cyclictest does by default. Deep idle
/// states (and, in a VM, halting the virtual CPU) otherwise add tens of microseconds to
/// every wake-up of a task that slept on an idle CPU.
pub fn hold_cpu_latency_zero() -> io::Result<std::fs::File> {
    use std::io::Write;
    let mut file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open("/dev/cpu_dma_latency")?;
    file.write_all(&0i32.to_ne_bytes())?;
    Ok(file)
}

/// Lock all current and future memory (mlockall) and keep the heap from returning memory
/// to the kernel, then prefault `heap_bytes` of heap, so page faults do not hit cycles.
pub fn lock_memory(heap_bytes: usize) -> io::Result<()> {
    // SAFETY: mlockall takes flags only and affects this process's mappings.
    if unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) } != 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: mallopt only sets glibc allocator tunables: no trimming of the heap top and no
    // mmap for large blocks, so freed memory stays mapped (and locked) for reuse.
    unsafe {
        libc::mallopt(libc::M_TRIM_THRESHOLD, -1);
        libc::mallopt(libc::M_MMAP_MAX, 0);
    }
    let mut block = vec![0u8; heap_bytes];
    for i in (0..block.len()).step_by(4096) {
        block[i] = 1;
    }
    std::hint::black_box(&mut block);
    Ok(())
}

/// Touch `bytes` of the calling thread's stack so its pages are mapped before the first
/// cycle.
#[inline(never)]
pub fn prefault_stack() {
    const BYTES: usize = 128 * 1024;
    let mut buf = [0u8; BYTES];
    for i in (0..BYTES).step_by(4096) {
        buf[i] = 1;
    }
    std::hint::black_box(&mut buf);
}

/// RLIMIT_RTPRIO of the process (`None` = unlimited).
pub fn rtprio_limit() -> Option<u64> {
    let mut lim = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: `lim` is a valid, writable rlimit.
    unsafe { libc::getrlimit(libc::RLIMIT_RTPRIO, &mut lim) };
    (lim.rlim_cur != libc::RLIM_INFINITY).then_some(lim.rlim_cur)
}

/// What the runtime got for all its tasks, said once at start-up.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SchedReport {
    /// Tasks on SCHED_FIFO, with their FIFO priority.
    pub fifo: Vec<(String, i32)>,
    /// Tasks on normal scheduling, with the reason.
    pub normal: Vec<(String, String)>,
    /// Memory: `Ok(())` locked, or why not.
    pub memory_locked: Result<(), String>,
    /// CPUs tasks were pinned to, by task; empty when unpinned.
    pub pinned: Vec<(String, usize)>,
    /// Pinning failures, by task.
    pub pin_errors: Vec<(String, String)>,
    /// The kernel's RT throttling (`sched_rt_runtime_us` of each second), when it limits.
    pub rt_throttle_us: Option<i64>,
    /// CPU idle-exit latency held at 0 µs through `/dev/cpu_dma_latency`: `Ok(())`, or why not.
    pub cpu_latency_zero: Result<(), String>,
}

impl SchedReport {
    /// Every task got SCHED_FIFO.
    pub fn is_realtime(&self) -> bool {
        self.normal.is_empty() && !self.fifo.is_empty()
    }
}

fn rt_runtime_us() -> Option<i64> {
    let v: i64 = std::fs::read_to_string("/proc/sys/kernel/sched_rt_runtime_us")
        .ok()?
        .trim()
        .parse()
        .ok()?;
    (v >= 0).then_some(v)
}

pub(crate) fn rt_throttle_us() -> Option<i64> {
    rt_runtime_us()
}

impl fmt::Display for SchedReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_realtime() {
            let hi = self.fifo.iter().map(|t| t.1).max().unwrap_or(0);
            let lo = self.fifo.iter().map(|t| t.1).min().unwrap_or(0);
            write!(
                f,
                "real-time scheduling: SCHED_FIFO for all {} tasks (priorities {hi}..{lo})",
                self.fifo.len()
            )?;
        } else if self.fifo.is_empty() {
            let reason = self
                .normal
                .first()
                .map(|t| t.1.as_str())
                .unwrap_or("no tasks");
            write!(
                f,
                "NOT real-time: running with normal scheduling (SCHED_OTHER) because {reason}; \
                 timing figures are those of an ordinary process. To grant SCHED_FIFO: run as root, \
                 `setcap cap_sys_nice,cap_ipc_lock+ep <binary>`, or an rtprio limit in \
                 /etc/security/limits.d (see docs/realtime.md)"
            )?;
        } else {
            write!(
                f,
                "PARTLY real-time: SCHED_FIFO for {} tasks, normal scheduling for",
                self.fifo.len()
            )?;
            for (name, why) in &self.normal {
                write!(f, " {name} ({why})")?;
            }
        }
        match &self.memory_locked {
            Ok(()) => write!(f, "; memory locked (mlockall)")?,
            Err(why) => write!(f, "; memory NOT locked ({why})")?,
        }
        if self.pinned.is_empty() {
            write!(f, "; no CPU pinning (no isolated CPU)")?;
        } else {
            let mut cpus: Vec<usize> = self.pinned.iter().map(|p| p.1).collect();
            cpus.sort_unstable();
            cpus.dedup();
            write!(f, "; {} tasks pinned to CPU {cpus:?}", self.pinned.len())?;
        }
        for (name, why) in &self.pin_errors {
            write!(f, "; pinning {name} failed ({why})")?;
        }
        if !self.fifo.is_empty() {
            match &self.cpu_latency_zero {
                Ok(()) => write!(f, "; CPU idle latency held at 0 us")?,
                Err(why) => write!(f, "; CPU idle latency NOT held ({why})")?,
            }
        }
        if let (true, Some(us)) = (!self.fifo.is_empty(), self.rt_throttle_us) {
            if us < 1_000_000 {
                write!(f, "; kernel RT throttling allows {us} µs of each second")?;
            }
        }
        Ok(())
    }
}

/// Why SCHED_FIFO was refused, in words a user can act on.
pub fn explain_fifo_error(err: &io::Error) -> String {
    let limit = match rtprio_limit() {
        None => "unlimited".to_string(),
        Some(n) => n.to_string(),
    };
    match err.raw_os_error() {
        Some(libc::EPERM) => {
            format!("SCHED_FIFO was refused (no CAP_SYS_NICE, RLIMIT_RTPRIO = {limit})")
        }
        _ => format!("SCHED_FIFO failed: {err}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mapping_is_monotonic_and_matches_the_documented_values() {
        let table: Vec<i32> = [10u8, 20, 25, 30, 40, 45]
            .iter()
            .map(|&p| fifo_priority(p))
            .collect();
        assert_eq!(table, [80, 70, 65, 60, 50, 45]);
        for p in PAPER_PRIORITY_MIN..PAPER_PRIORITY_MAX {
            assert!(fifo_priority(p) > fifo_priority(p + 1));
            assert!((1..=89).contains(&fifo_priority(p)));
        }
    }

    #[test]
    fn cpu_lists_parse() {
        assert_eq!(parse_cpu_list("\n"), Vec::<usize>::new());
        assert_eq!(parse_cpu_list("2-3,5\n"), vec![2, 3, 5]);
        assert_eq!(parse_cpu_list("x,1"), vec![1]);
    }

    #[test]
    fn report_says_what_was_got() {
        let normal = SchedReport {
            fifo: vec![],
            normal: vec![("a".into(), "SCHED_FIFO was refused".into())],
            memory_locked: Err("not permitted".into()),
            pinned: vec![],
            pin_errors: vec![],
            rt_throttle_us: Some(950_000),
            cpu_latency_zero: Ok(()),
        };
        let text = normal.to_string();
        assert!(
            text.contains("NOT real-time")
                && text.contains("setcap")
                && text.contains("NOT locked"),
            "{text}"
        );
        let rt = SchedReport {
            fifo: vec![("a".into(), 70)],
            normal: vec![],
            memory_locked: Ok(()),
            ..normal
        };
        let text = rt.to_string();
        assert!(
            text.contains("SCHED_FIFO for all 1") && text.contains("950000 µs"),
            "{text}"
        );
    }
}
