//! [`FdWake`]: a waiter for a task whose events are readable file descriptors (sockets, a
//! tty) and notifications, on one epoll set.
//!
//! The set holds three kinds of member:
//! - the task's descriptors, level-triggered readable, each under a [`Token`] the task
//!   chose; a wait that sees one ready marks its token in a readiness set the task reads
//!   through its [`FdRegistry`] (so a cycle reads the clients that have input, not all);
//!   level-triggered, so input a cycle leaves unread releases the next wait at once;
//! - an eventfd for notifications: [`Notify::notify`] writes it only when no notification
//!   is pending since the last wait consumed one (an atomic flag), so a burst of
//!   notifications costs one `write`;
//! - a timerfd armed at the deadline with `TFD_TIMER_ABSTIME` on `CLOCK_MONOTONIC`: the
//!   wait ends exactly at the grid point, with no millisecond rounding of `epoll_wait`'s
//!   timeout and no blind spot before the grid point. It is re-armed only when the deadline
//!   changes, so event releases between two grid points cost one `epoll_wait` each.
//!
//! Hand-written on `libc` rather than `mio`: `mio` registers every source edge-triggered
//! (a cycle that reads a bounded amount per client would have to remember who has input
//! left and wake itself), has no absolute timers (a relative timeout rounded to
//! milliseconds), and its `Waker` writes its eventfd on every wake. The runtime is
//! Linux-only (futex, SCHED_FIFO) anyway, so epoll's portability layer buys nothing here.

use std::io;
use std::os::fd::{AsFd, AsRawFd, FromRawFd, OwnedFd};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

use super::{timespec_of, Notify, Waiter};
use crate::clock::{Clock, MonotonicClock};

/// The number a task gives a descriptor when it registers it, `0 .. FdWake::tokens()`.
pub type Token = usize;

/// epoll keys of the waiter's own descriptors (tokens are far below them).
const NOTIFY_KEY: u64 = u64::MAX;
const TIMER_KEY: u64 = u64::MAX - 1;

/// The eventfd with its "a notification is pending" flag.
#[derive(Debug)]
struct EventNotify {
    fd: OwnedFd,
    pending: AtomicBool,
}

impl Notify for EventNotify {
    fn notify(&self) {
        // AcqRel: the waiter's consuming swap reads this one (or a later one), so what the
        // producer wrote before notifying is visible to the cycle it releases.
        if !self.pending.swap(true, Ordering::AcqRel) {
            let one: u64 = 1;
            // SAFETY: `fd` is an open, non-blocking eventfd owned by `self`; the buffer is 8
            // readable bytes that live across the call. With at most one write pending the
            // counter cannot overflow, so the write never fails with EAGAIN.
            unsafe {
                libc::write(
                    self.fd.as_raw_fd(),
                    (&one as *const u64).cast::<libc::c_void>(),
                    8,
                );
            }
        }
    }
}

impl EventNotify {
    /// Reset the eventfd, then clear the flag (in this order: a notification after the read
    /// either finds the flag still set and is folded into this release, or writes again).
    fn consume(&self) {
        let mut count: u64 = 0;
        // SAFETY: `fd` is an open, non-blocking eventfd owned by `self`; `count` is 8
        // writable bytes. EAGAIN (nothing to read) is harmless.
        unsafe {
            libc::read(
                self.fd.as_raw_fd(),
                (&mut count as *mut u64).cast::<libc::c_void>(),
                8,
            );
        }
        self.pending.swap(false, Ordering::AcqRel);
    }
}

/// One bit per token: set by the wait, taken by the task's cycle (both on the task's thread).
#[derive(Debug)]
struct Readiness {
    bits: Box<[AtomicU64]>,
    tokens: usize,
}

impl Readiness {
    fn set(&self, token: u64) {
        if token < self.tokens as u64 {
            self.bits[(token / 64) as usize].fetch_or(1 << (token % 64), Ordering::AcqRel);
        }
    }

    fn take(&self, token: Token) -> bool {
        let Some(word) = self.bits.get(token / 64) else {
            return false;
        };
        let bit = 1u64 << (token % 64);
        word.load(Ordering::Acquire) & bit != 0 && word.fetch_and(!bit, Ordering::AcqRel) & bit != 0
    }
}

fn check(rc: libc::c_int) -> io::Result<libc::c_int> {
    if rc < 0 {
        Err(io::Error::last_os_error())
    } else {
        Ok(rc)
    }
}

/// Take ownership of a descriptor a system call just returned.
fn owned(rc: libc::c_int) -> io::Result<OwnedFd> {
    let fd = check(rc)?;
    // SAFETY: `fd` is a new descriptor returned to us by the kernel and owned by nobody else.
    Ok(unsafe { OwnedFd::from_raw_fd(fd) })
}

fn epoll_add(epoll: &OwnedFd, fd: libc::c_int, key: u64) -> io::Result<()> {
    let mut event = libc::epoll_event {
        events: libc::EPOLLIN as u32,
        u64: key,
    };
    // SAFETY: `epoll` is an open epoll descriptor; `event` is a valid epoll_event that lives
    // across the call (the kernel copies it). A bad `fd` is reported as an error.
    check(unsafe { libc::epoll_ctl(epoll.as_raw_fd(), libc::EPOLL_CTL_ADD, fd, &mut event) })
        .map(|_| ())
}

/// The waiting half of an epoll waiter: moved into the task's thread (with
/// [`crate::Runtime::add_released`]); the task keeps the [`FdRegistry`] half.
///
/// ```
/// use std::io::Write;
/// use std::os::unix::net::UnixStream;
/// use wrc_rt::wake::{FdWake, Waiter};
/// use wrc_rt::{Clock, MonotonicClock};
///
/// let mut wake = FdWake::new(4).unwrap();
/// let registry = wake.registry();
/// let (mut client, server) = UnixStream::pair().unwrap();
/// registry.register(&server, 3).unwrap();
/// client.write_all(b"STATUS\n").unwrap();
/// // The line released the wait long before its deadline, and token 3 is marked ready.
/// assert!(wake.wait_until_ns(MonotonicClock.now_ns() + 10_000_000_000));
/// assert!(registry.take_ready(3));
/// assert!(!registry.take_ready(3));
/// ```
#[derive(Debug)]
pub struct FdWake {
    epoll: Arc<OwnedFd>,
    timer: OwnedFd,
    /// The deadline the timer is armed for [ns].
    armed_ns: Option<u64>,
    notify: Arc<EventNotify>,
    ready: Arc<Readiness>,
    /// Room for every token plus the eventfd and the timer: one wait sees everything ready.
    events: Box<[libc::epoll_event]>,
}

impl FdWake {
    /// A waiter for descriptors with tokens `0 .. tokens`, plus notifications. Allocates its
    /// event buffer and readiness set here, once.
    pub fn new(tokens: usize) -> io::Result<FdWake> {
        // SAFETY: plain system calls with flag arguments; the results are checked and owned.
        let epoll = owned(unsafe { libc::epoll_create1(libc::EPOLL_CLOEXEC) })?;
        // SAFETY: as above.
        let eventfd = owned(unsafe { libc::eventfd(0, libc::EFD_NONBLOCK | libc::EFD_CLOEXEC) })?;
        // SAFETY: as above.
        let timer = owned(unsafe {
            libc::timerfd_create(
                libc::CLOCK_MONOTONIC,
                libc::TFD_NONBLOCK | libc::TFD_CLOEXEC,
            )
        })?;
        epoll_add(&epoll, eventfd.as_raw_fd(), NOTIFY_KEY)?;
        epoll_add(&epoll, timer.as_raw_fd(), TIMER_KEY)?;
        Ok(FdWake {
            epoll: Arc::new(epoll),
            timer,
            armed_ns: None,
            notify: Arc::new(EventNotify {
                fd: eventfd,
                pending: AtomicBool::new(false),
            }),
            ready: Arc::new(Readiness {
                bits: (0..tokens.div_ceil(64))
                    .map(|_| AtomicU64::new(0))
                    .collect(),
                tokens,
            }),
            events: vec![libc::epoll_event { events: 0, u64: 0 }; tokens + 2].into_boxed_slice(),
        })
    }

    /// How many tokens it has room for.
    pub fn tokens(&self) -> usize {
        self.ready.tokens
    }

    /// The handle through which the task registers its descriptors and reads which are
    /// ready.
    pub fn registry(&self) -> FdRegistry {
        FdRegistry {
            epoll: self.epoll.clone(),
            ready: self.ready.clone(),
        }
    }

    /// A handle that wakes the waiter from any thread (writes the eventfd, at most once per
    /// wait).
    pub fn notifier(&self) -> Arc<dyn Notify> {
        self.notify.clone()
    }

    fn arm(&mut self, deadline_ns: u64) -> io::Result<()> {
        if self.armed_ns == Some(deadline_ns) {
            return Ok(());
        }
        let spec = libc::itimerspec {
            it_interval: timespec_of(0),
            // An all-zero value would disarm the timer: 1 ns is as much in the past.
            it_value: timespec_of(deadline_ns.max(1)),
        };
        // SAFETY: `timer` is an open timerfd; `spec` is a valid itimerspec that lives across
        // the call; the old value may be null. Setting it also clears a past expiry.
        check(unsafe {
            libc::timerfd_settime(
                self.timer.as_raw_fd(),
                libc::TFD_TIMER_ABSTIME,
                &spec,
                std::ptr::null_mut(),
            )
        })?;
        self.armed_ns = Some(deadline_ns);
        Ok(())
    }
}

impl Waiter for FdWake {
    fn wait_until_ns(&mut self, deadline_ns: u64) -> bool {
        if self.arm(deadline_ns).is_err() {
            // Cannot happen with a valid timerfd; keep the grid with a plain sleep.
            MonotonicClock.sleep_until_ns(deadline_ns);
            return false;
        }
        loop {
            // SAFETY: `epoll` is an open epoll descriptor; `events` is a writable buffer of
            // `events.len()` entries owned by `self` for the whole call; -1: no timeout (the
            // timerfd ends the wait at the deadline).
            let n = unsafe {
                libc::epoll_wait(
                    self.epoll.as_raw_fd(),
                    self.events.as_mut_ptr(),
                    self.events.len() as libc::c_int,
                    -1,
                )
            };
            if n < 0 {
                if io::Error::last_os_error().raw_os_error() == Some(libc::EINTR) {
                    continue;
                }
                MonotonicClock.sleep_until_ns(deadline_ns);
                return false;
            }
            let (mut event, mut notified, mut timer) = (false, false, false);
            for e in &self.events[..n as usize] {
                // Copied out by value: epoll_event is packed on x86-64.
                let key = e.u64;
                match key {
                    NOTIFY_KEY => notified = true,
                    TIMER_KEY => timer = true,
                    token => {
                        self.ready.set(token);
                        event = true;
                    }
                }
            }
            if notified {
                self.notify.consume();
                return true;
            }
            if event || timer {
                // The timerfd stays readable until re-armed: a wait for the same, passed
                // deadline returns at once.
                return event;
            }
        }
    }

    fn notifier(&self) -> Option<Arc<dyn Notify>> {
        Some(FdWake::notifier(self))
    }
}

/// The task's half of an [`FdWake`]: register and deregister descriptors, and take the
/// readiness the last waits saw. Clones share the same epoll set.
#[derive(Debug, Clone)]
pub struct FdRegistry {
    epoll: Arc<OwnedFd>,
    ready: Arc<Readiness>,
}

impl FdRegistry {
    /// Release the waiter whenever `fd` is readable (level-triggered: as long as input is
    /// left), marking `token` ready. A stale mark of `token` is cleared. `InvalidInput` when
    /// `token` is not below [`FdWake::tokens`]. One `epoll_ctl` call; no allocation.
    pub fn register(&self, fd: &impl AsFd, token: Token) -> io::Result<()> {
        if token >= self.ready.tokens {
            return Err(io::ErrorKind::InvalidInput.into());
        }
        self.ready.take(token);
        epoll_add(&self.epoll, fd.as_fd().as_raw_fd(), token as u64)
    }

    /// Stop watching `fd` (call before closing it). One `epoll_ctl` call; no allocation.
    pub fn deregister(&self, fd: &impl AsFd) -> io::Result<()> {
        // SAFETY: `epoll` is an open epoll descriptor; EPOLL_CTL_DEL ignores the event
        // pointer, which may be null. A descriptor that is not registered is an error.
        check(unsafe {
            libc::epoll_ctl(
                self.epoll.as_raw_fd(),
                libc::EPOLL_CTL_DEL,
                fd.as_fd().as_raw_fd(),
                std::ptr::null_mut(),
            )
        })
        .map(|_| ())
    }

    /// Whether a wait saw `token`'s descriptor readable since the last time this was asked
    /// (and clear the mark). Wait-free; no system call.
    pub fn take_ready(&self, token: Token) -> bool {
        self.ready.take(token)
    }

    /// How many tokens the waiter has room for.
    pub fn tokens(&self) -> usize {
        self.ready.tokens
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};
    use std::os::unix::net::UnixStream;

    use crate::wake::testing::{far, ping_pong};

    #[test]
    fn notifications_release_one_wait_and_the_timer_ends_the_next_at_its_deadline() {
        let mut wake = FdWake::new(2).unwrap();
        let n = wake.notifier();
        n.notify();
        n.notify();
        assert!(wake.wait_until_ns(far()));
        let deadline = MonotonicClock.now_ns() + 3_000_000;
        assert!(!wake.wait_until_ns(deadline));
        assert!(MonotonicClock.now_ns() >= deadline);
        // The same, passed deadline again: at once, no event.
        assert!(!wake.wait_until_ns(deadline));
        // A deadline in the past.
        assert!(!wake.wait_until_ns(1));
    }

    #[test]
    fn input_releases_the_wait_until_it_is_read() {
        let mut wake = FdWake::new(8).unwrap();
        let registry = wake.registry();
        let (mut client, mut server) = UnixStream::pair().unwrap();
        server.set_nonblocking(true).unwrap();
        let (_quiet, other) = UnixStream::pair().unwrap();
        registry.register(&server, 5).unwrap();
        registry.register(&other, 6).unwrap();
        client.write_all(b"1 SPEED 100\n").unwrap();
        assert!(wake.wait_until_ns(far()));
        assert!(registry.take_ready(5));
        assert!(!registry.take_ready(6));
        // Level-triggered: still unread, so the next wait returns at once as well.
        assert!(wake.wait_until_ns(far()));
        assert!(registry.take_ready(5));
        let mut buf = [0u8; 64];
        assert_eq!(server.read(&mut buf).unwrap(), 12);
        let deadline = MonotonicClock.now_ns() + 2_000_000;
        assert!(!wake.wait_until_ns(deadline));
        assert!(!registry.take_ready(5));
        // Deregistered: input no longer releases the wait.
        registry.deregister(&server).unwrap();
        client.write_all(b"2 STATUS\n").unwrap();
        assert!(!wake.wait_until_ns(MonotonicClock.now_ns() + 2_000_000));
        assert!(registry.deregister(&server).is_err());
    }

    #[test]
    fn a_token_out_of_range_is_refused() {
        let wake = FdWake::new(3).unwrap();
        let (a, _b) = UnixStream::pair().unwrap();
        let e = wake.registry().register(&a, 3).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
        assert!(!wake.registry().take_ready(3));
    }

    #[test]
    fn a_notification_from_another_thread_ends_a_sleeping_wait() {
        let mut wake = FdWake::new(1).unwrap();
        let n = wake.notifier();
        let notify = wake.notify.clone();
        // However the two threads interleave (before or during the wait), it must end with
        // an event and leave no notification pending.
        let notifier = std::thread::spawn(move || {
            n.notify();
            notify
        });
        let deadline = far();
        assert!(wake.wait_until_ns(deadline));
        assert!(MonotonicClock.now_ns() < deadline);
        let notify = notifier.join().unwrap();
        assert!(!notify.pending.load(Ordering::Acquire));
    }

    #[test]
    fn ping_pong_never_loses_a_notification() {
        let (a, b) = (FdWake::new(0).unwrap(), FdWake::new(0).unwrap());
        let (to_a, to_b) = (a.notifier(), b.notifier());
        ping_pong(a, b, to_a, to_b, 10_000);
    }
}
