//! Time sources for the runtime: the real `CLOCK_MONOTONIC` and a mock clock for tests.
//!
//! Real-time promise: [`Clock::now_ns`] and [`Clock::sleep_until_ns`] do not allocate; on
//! Linux `now_ns` is a vDSO read (no system call) and `sleep_until_ns` is one
//! `clock_nanosleep(TIMER_ABSTIME)` call.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// A monotonic time source that can put the calling thread to sleep until an absolute time.
///
/// Times are nanoseconds on the clock's own axis [ns]; only differences are meaningful.
pub trait Clock: Send + Sync + 'static {
    /// The current time [ns].
    fn now_ns(&self) -> u64;
    /// Sleep until the absolute time `deadline_ns` [ns]; returns at once when it has passed.
    fn sleep_until_ns(&self, deadline_ns: u64);
}

/// `CLOCK_MONOTONIC`: never steps, unaffected by NTP jumps; sleeps with
/// `clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME)` so that wake-ups stay on an absolute grid.
#[derive(Debug, Clone, Copy, Default)]
pub struct MonotonicClock;

impl Clock for MonotonicClock {
    fn now_ns(&self) -> u64 {
        monotonic_now_ns()
    }

    fn sleep_until_ns(&self, deadline_ns: u64) {
        let ts = libc::timespec {
            tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
            tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
        };
        loop {
            // SAFETY: `ts` is a valid timespec that lives across the call; the remaining-time
            // pointer may be null with TIMER_ABSTIME.
            let rc = unsafe {
                libc::clock_nanosleep(
                    libc::CLOCK_MONOTONIC,
                    libc::TIMER_ABSTIME,
                    &ts,
                    std::ptr::null_mut(),
                )
            };
            // An absolute sleep interrupted by a signal is simply restarted with the same deadline.
            if rc != libc::EINTR {
                break;
            }
        }
    }
}

/// The current `CLOCK_MONOTONIC` time [ns].
pub fn monotonic_now_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC always exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// A clock that only moves when told to: `sleep_until_ns` jumps to the deadline, and
/// [`MockClock::advance_ns`] simulates work. Clones share the same time.
#[derive(Debug, Clone, Default)]
pub struct MockClock {
    now_ns: Arc<AtomicU64>,
}

impl MockClock {
    /// A mock clock reading `start_ns` [ns].
    pub fn new(start_ns: u64) -> MockClock {
        MockClock {
            now_ns: Arc::new(AtomicU64::new(start_ns)),
        }
    }

    /// Move time forward by `delta_ns` [ns] (for example, to simulate a cycle's work).
    pub fn advance_ns(&self, delta_ns: u64) {
        self.now_ns.fetch_add(delta_ns, Ordering::SeqCst);
    }

    /// Set the time to `now_ns` [ns] (never backwards).
    pub fn set_ns(&self, now_ns: u64) {
        self.now_ns.fetch_max(now_ns, Ordering::SeqCst);
    }
}

impl Clock for MockClock {
    fn now_ns(&self) -> u64 {
        self.now_ns.load(Ordering::SeqCst)
    }

    fn sleep_until_ns(&self, deadline_ns: u64) {
        self.set_ns(deadline_ns);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monotonic_clock_moves_forward_and_sleeps_to_an_absolute_time() {
        let clock = MonotonicClock;
        let t0 = clock.now_ns();
        clock.sleep_until_ns(t0 + 2_000_000);
        let t1 = clock.now_ns();
        assert!(t1 >= t0 + 2_000_000, "woke {} ns after start", t1 - t0);
        // A deadline in the past returns at once (loose bound: this is a noisy VM).
        clock.sleep_until_ns(t0);
        assert!(clock.now_ns() - t1 < 1_000_000_000);
    }

    #[test]
    fn mock_clock_jumps_to_deadlines_and_never_goes_back() {
        let clock = MockClock::new(100);
        clock.sleep_until_ns(250);
        assert_eq!(clock.now_ns(), 250);
        clock.sleep_until_ns(200);
        assert_eq!(clock.now_ns(), 250);
        clock.clone().advance_ns(50);
        assert_eq!(clock.now_ns(), 300);
    }
}
