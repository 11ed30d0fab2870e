//! Event release: a task released by its period or by an event, whichever comes first.
//!
//! A [`Waiter`] is what a task's thread blocks on between cycles when the task is added with
//! [`crate::Runtime::add_released`]: it returns at the task's next grid point (an absolute
//! `CLOCK_MONOTONIC` time) or as soon as an event arrives. A [`Notify`] is the other end,
//! held by whoever produces the event (for example a [`crate::ipc::MessageQueue`] made with
//! [`crate::ipc::MessageQueue::with_notify`]).
//!
//! | waiter | events | wait |
//! |---|---|---|
//! | [`Wake`] | notifications only | one futex word, `FUTEX_WAIT_BITSET` with an absolute `CLOCK_MONOTONIC` timeout |
//! | [`FdWake`] | readable file descriptors (sockets, a tty) and notifications | epoll, an eventfd for notifications, a timerfd armed at the absolute deadline |
//! | [`MockWaiter`] | scripted times on a [`crate::MockClock`] and notifications | none: moves the mock clock |
//!
//! Real-time promise: [`Notify::notify`] never blocks, never allocates, takes no lock and
//! makes at most one system call, only when the waiter has to be woken (several
//! notifications before one wait cost one). [`Waiter::wait_until_ns`] does not allocate
//! (the event buffer exists before the first wait); a notification sent before the wait
//! is never lost, and several release one cycle.
//!
//! ```
//! use wrc_rt::wake::{Notify, Wake, Waiter};
//! use wrc_rt::{Clock, MonotonicClock};
//!
//! let mut wake = Wake::new();
//! let notifier = wake.notifier();
//! notifier.notify();
//! notifier.notify();
//! let far = MonotonicClock.now_ns() + 10_000_000_000;
//! // Both notifications came before the wait: it returns at once, released by an event …
//! assert!(wake.wait_until_ns(far));
//! // … once: with no further notification it sleeps until the deadline.
//! assert!(!wake.wait_until_ns(MonotonicClock.now_ns() + 1_000_000));
//! ```

mod epoll;
mod futex;
mod mock;

pub use epoll::{FdRegistry, FdWake, Token};
pub use futex::Wake;
pub use mock::MockWaiter;

use std::sync::Arc;

/// Wakes a task: called by the producer of an event, from any thread.
///
/// An implementation never blocks, never allocates, takes no lock and makes at most one
/// system call, only when the task's thread sleeps and has not been woken yet.
pub trait Notify: Send + Sync {
    /// Release the task's next wait (or end the one it is in).
    fn notify(&self);
}

/// What a task's thread waits on between cycles when the task may be released by events.
///
/// Times are [ns] on `CLOCK_MONOTONIC` (the runtime's [`crate::MonotonicClock`]); a
/// [`MockWaiter`] uses a [`crate::MockClock`] instead.
pub trait Waiter: Send + 'static {
    /// Block until the absolute time `deadline_ns` [ns] or an event, whichever comes first.
    /// Returns `true` when an event released the wait (also when it came together with the
    /// deadline), `false` when the deadline passed without one. Never returns `false` before
    /// the deadline. Does not allocate.
    fn wait_until_ns(&mut self, deadline_ns: u64) -> bool;

    /// A handle that releases this waiter from another thread; the runtime uses it to end a
    /// wait at once when the tasks are stopped. `None`: the wait ends at its deadline.
    fn notifier(&self) -> Option<Arc<dyn Notify>> {
        None
    }
}

impl<W: Waiter + ?Sized> Waiter for Box<W> {
    fn wait_until_ns(&mut self, deadline_ns: u64) -> bool {
        (**self).wait_until_ns(deadline_ns)
    }

    fn notifier(&self) -> Option<Arc<dyn Notify>> {
        (**self).notifier()
    }
}

/// The waiter of a task without events: the type [`crate::TaskDriver`] has when it only
/// sleeps to its grid points. It has no value, so it never waits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoWaiter {}

impl Waiter for NoWaiter {
    fn wait_until_ns(&mut self, _deadline_ns: u64) -> bool {
        match *self {}
    }
}

/// A timespec for an absolute time [ns] on `CLOCK_MONOTONIC`.
pub(crate) fn timespec_of(ns: u64) -> libc::timespec {
    libc::timespec {
        tv_sec: (ns / 1_000_000_000).min(libc::time_t::MAX as u64) as libc::time_t,
        tv_nsec: (ns % 1_000_000_000) as libc::c_long,
    }
}

/// What the waiters' tests share.
#[cfg(test)]
pub(crate) mod testing {
    use super::{Notify, Waiter};
    use crate::{Clock, MonotonicClock};

    /// A deadline no test reaches unless it fails [ns].
    pub(crate) fn far() -> u64 {
        MonotonicClock.now_ns() + 20_000_000_000
    }

    /// Two waiters notify each other `rounds` times from two threads; every notification
    /// must release the other's wait before the far deadline (none is lost).
    pub(crate) fn ping_pong<W: Waiter>(
        mut a: W,
        mut b: W,
        to_a: std::sync::Arc<dyn Notify>,
        to_b: std::sync::Arc<dyn Notify>,
        rounds: usize,
    ) {
        let partner = std::thread::spawn(move || {
            for _ in 0..rounds {
                assert!(b.wait_until_ns(far()), "lost a ping");
                to_a.notify();
            }
        });
        for _ in 0..rounds {
            to_b.notify();
            assert!(a.wait_until_ns(far()), "lost a pong");
        }
        partner.join().unwrap();
    }
}
