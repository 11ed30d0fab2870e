//! A counting semaphore on a Linux futex: `post` from any thread (lock-free, one system call
//! only when a waiter sleeps), `wait` with a timeout.

use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

/// A counting semaphore, like RTAI's `rt_sem_signal` / `rt_sem_wait_timed`.
///
/// ```
/// use std::time::Duration;
/// let sem = wrc_rt::ipc::Semaphore::new(0);
/// sem.post();
/// assert!(sem.wait_timeout(Duration::from_millis(10)));
/// assert!(!sem.wait_timeout(Duration::from_millis(1)));
/// ```
#[derive(Debug, Default)]
pub struct Semaphore {
    count: AtomicU32,
    waiters: AtomicU32,
}

impl Semaphore {
    /// A semaphore holding `initial` counts.
    pub fn new(initial: u32) -> Semaphore {
        Semaphore {
            count: AtomicU32::new(initial),
            waiters: AtomicU32::new(0),
        }
    }

    /// Add one count and wake one waiter. Never blocks or allocates; saturates at `u32::MAX`.
    pub fn post(&self) {
        let _ = self
            .count
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |c| c.checked_add(1));
        if self.waiters.load(Ordering::SeqCst) > 0 {
            futex_wake_one(&self.count);
        }
    }

    /// Take one count if there is one, without waiting.
    pub fn try_wait(&self) -> bool {
        self.count
            .fetch_update(Ordering::Acquire, Ordering::Relaxed, |c| c.checked_sub(1))
            .is_ok()
    }

    /// Take one count, waiting at most `timeout`; `false` when the time ran out.
    pub fn wait_timeout(&self, timeout: Duration) -> bool {
        let deadline = Instant::now() + timeout;
        loop {
            if self.try_wait() {
                return true;
            }
            let now = Instant::now();
            if now >= deadline {
                return false;
            }
            self.waiters.fetch_add(1, Ordering::SeqCst);
            // Sleeps only while the count is still 0; a post in between makes it return at once.
            futex_wait(&self.count, 0, deadline - now);
            self.waiters.fetch_sub(1, Ordering::SeqCst);
        }
    }

    /// Counts available now.
    pub fn count(&self) -> u32 {
        self.count.load(Ordering::Relaxed)
    }
}

fn futex_wait(word: &AtomicU32, expected: u32, timeout: Duration) {
    let ts = libc::timespec {
        tv_sec: timeout.as_secs().min(i32::MAX as u64) as libc::time_t,
        tv_nsec: timeout.subsec_nanos() as libc::c_long,
    };
    // SAFETY: `word` is a live, aligned 32-bit atomic for the whole call; `ts` is a valid
    // relative timeout. The kernel only reads both. Spurious returns (EINTR, EAGAIN, timeout)
    // are handled by the caller's loop.
    unsafe {
        libc::syscall(
            libc::SYS_futex,
            word.as_ptr(),
            libc::FUTEX_WAIT | libc::FUTEX_PRIVATE_FLAG,
            expected,
            &ts as *const libc::timespec,
        );
    }
}

fn futex_wake_one(word: &AtomicU32) {
    // SAFETY: `word` is a live, aligned 32-bit atomic; FUTEX_WAKE only uses its address.
    unsafe {
        libc::syscall(
            libc::SYS_futex,
            word.as_ptr(),
            libc::FUTEX_WAKE | libc::FUTEX_PRIVATE_FLAG,
            1,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    #[test]
    fn counts_and_times_out() {
        let sem = Semaphore::new(2);
        assert!(sem.try_wait() && sem.try_wait() && !sem.try_wait());
        let t0 = Instant::now();
        assert!(!sem.wait_timeout(Duration::from_millis(20)));
        assert!(t0.elapsed() >= Duration::from_millis(20));
    }

    #[test]
    fn a_post_wakes_a_sleeping_waiter() {
        let sem = Arc::new(Semaphore::new(0));
        let waiter = {
            let sem = sem.clone();
            std::thread::spawn(move || sem.wait_timeout(Duration::from_secs(10)))
        };
        std::thread::sleep(Duration::from_millis(20));
        sem.post();
        assert!(waiter.join().unwrap());
    }

    #[test]
    fn many_posters_many_waiters_lose_no_count() {
        let sem = Arc::new(Semaphore::new(0));
        let per = 20_000;
        let waiters: Vec<_> = (0..3)
            .map(|_| {
                let sem = sem.clone();
                std::thread::spawn(move || {
                    let mut got = 0;
                    while got < per && sem.wait_timeout(Duration::from_secs(10)) {
                        got += 1;
                    }
                    got
                })
            })
            .collect();
        let posters: Vec<_> = (0..3)
            .map(|_| {
                let sem = sem.clone();
                std::thread::spawn(move || (0..per).for_each(|_| sem.post()))
            })
            .collect();
        posters.into_iter().for_each(|p| p.join().unwrap());
        let got: u32 = waiters.into_iter().map(|w| w.join().unwrap()).sum();
        assert_eq!(got, 3 * per);
        assert_eq!(sem.count(), 0);
    }
}
