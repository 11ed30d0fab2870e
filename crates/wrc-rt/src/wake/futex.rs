//! [`Wake`]: a wake event on one futex word, for a task whose events are notifications only.
//!
//! The word is `IDLE`, `NOTIFIED` or `WAITING`. `notify` swaps in `NOTIFIED` and makes the
//! one `FUTEX_WAKE` call only when it replaced `WAITING` (the task's thread is asleep and
//! nobody woke it yet). The waiter consumes a `NOTIFIED` without sleeping; otherwise it
//! moves `IDLE → WAITING` and sleeps with `FUTEX_WAIT_BITSET`, whose timeout is an absolute
//! `CLOCK_MONOTONIC` time, so the deadline is the grid point itself with no conversion to a
//! relative time. A notification that lands between the two steps changes the word, so the
//! kernel refuses to sleep (`EAGAIN`): none is lost.

use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;

use super::{timespec_of, Notify, Waiter};

const IDLE: u32 = 0;
const NOTIFIED: u32 = 1;
const WAITING: u32 = 2;

/// The futex word shared by the waiter and its notifiers.
#[derive(Debug, Default)]
struct Word(AtomicU32);

impl Notify for Word {
    fn notify(&self) {
        // AcqRel: what the producer wrote before notifying is visible to the cycle that the
        // waiter's consuming swap releases.
        if self.0.swap(NOTIFIED, Ordering::AcqRel) == WAITING {
            // SAFETY: the word is a live, aligned 32-bit atomic (the notifier holds an `Arc`
            // to it); FUTEX_WAKE only uses its address. One waiter at most sleeps on it.
            unsafe {
                libc::syscall(
                    libc::SYS_futex,
                    self.0.as_ptr(),
                    libc::FUTEX_WAKE | libc::FUTEX_PRIVATE_FLAG,
                    1,
                );
            }
        }
    }
}

/// A futex wake event: [`Wake::notifier`] handles wake it from any thread; the one thread
/// that owns it waits until an absolute `CLOCK_MONOTONIC` deadline or a notification.
///
/// Notifications before a wait are kept (the wait returns at once), and several of them
/// release one wait.
#[derive(Debug, Default)]
pub struct Wake {
    word: Arc<Word>,
}

impl Wake {
    /// A wake event with no notification pending (allocates its word once, here).
    pub fn new() -> Wake {
        Wake::default()
    }

    /// A handle that notifies this wake event from any thread (no allocation: it shares the
    /// word).
    pub fn notifier(&self) -> Arc<dyn Notify> {
        self.word.clone()
    }

    #[cfg(test)]
    fn is_sleeping(&self) -> bool {
        self.word.0.load(Ordering::Acquire) == WAITING
    }
}

impl Waiter for Wake {
    fn wait_until_ns(&mut self, deadline_ns: u64) -> bool {
        let word = &self.word.0;
        let ts = timespec_of(deadline_ns);
        loop {
            if word
                .compare_exchange(IDLE, WAITING, Ordering::AcqRel, Ordering::Acquire)
                .is_err()
            {
                // Only this thread writes IDLE and WAITING, so the word is NOTIFIED: consume
                // it (a notification arriving now is folded into this release).
                word.swap(IDLE, Ordering::AcqRel);
                return true;
            }
            // SAFETY: the word is a live, aligned 32-bit atomic owned through `self.word`;
            // `ts` is a valid timespec that lives across the call; the kernel only reads
            // both. FUTEX_WAIT_BITSET takes `ts` as an absolute CLOCK_MONOTONIC time (no
            // FUTEX_CLOCK_REALTIME); the fifth argument is unused; the bitset matches any
            // FUTEX_WAKE. It sleeps only while the word is still WAITING.
            let rc = unsafe {
                libc::syscall(
                    libc::SYS_futex,
                    word.as_ptr(),
                    libc::FUTEX_WAIT_BITSET | libc::FUTEX_PRIVATE_FLAG,
                    WAITING,
                    &ts as *const libc::timespec,
                    std::ptr::null::<u32>(),
                    libc::FUTEX_BITSET_MATCH_ANY,
                )
            };
            let timed_out =
                rc != 0 && std::io::Error::last_os_error().raw_os_error() == Some(libc::ETIMEDOUT);
            if word.swap(IDLE, Ordering::AcqRel) == NOTIFIED {
                return true;
            }
            if timed_out {
                return false;
            }
            // Interrupted by a signal or woken spuriously: the deadline is absolute, so
            // waiting again keeps it.
        }
    }

    fn notifier(&self) -> Option<Arc<dyn Notify>> {
        Some(Wake::notifier(self))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::{Clock, MonotonicClock};
    use std::time::{Duration, Instant};

    use crate::wake::testing::{far, ping_pong};

    #[test]
    fn notifications_before_the_wait_release_it_once() {
        let mut wake = Wake::new();
        let n = wake.notifier();
        for _ in 0..3 {
            n.notify();
        }
        assert!(wake.wait_until_ns(far()));
        // Nothing pending any more: the next wait runs to its deadline.
        let deadline = MonotonicClock.now_ns() + 2_000_000;
        assert!(!wake.wait_until_ns(deadline));
        assert!(MonotonicClock.now_ns() >= deadline);
    }

    #[test]
    fn a_past_deadline_returns_at_once_without_an_event() {
        let mut wake = Wake::new();
        let t0 = Instant::now();
        assert!(!wake.wait_until_ns(MonotonicClock.now_ns().saturating_sub(1_000)));
        // Loose bound: it must not have slept until some far time.
        assert!(t0.elapsed() < Duration::from_secs(5));
    }

    #[test]
    fn a_notification_wakes_a_sleeping_waiter() {
        let mut wake = Wake::new();
        let n = wake.notifier();
        let word = wake.word.clone();
        let notifier = std::thread::spawn(move || {
            // Notify only once the waiter is asleep, so the futex path is the one tested.
            let t0 = Instant::now();
            while word.0.load(Ordering::Acquire) != WAITING {
                assert!(t0.elapsed() < Duration::from_secs(20), "never slept");
                std::thread::yield_now();
            }
            n.notify();
        });
        let deadline = far();
        assert!(wake.wait_until_ns(deadline));
        assert!(MonotonicClock.now_ns() < deadline);
        assert!(!wake.is_sleeping());
        notifier.join().unwrap();
    }

    #[test]
    fn ping_pong_never_loses_a_notification() {
        let (a, b) = (Wake::new(), Wake::new());
        let (to_a, to_b) = (a.notifier(), b.notifier());
        ping_pong(a, b, to_a, to_b, 20_000);
    }
}
