//! [`MockWaiter`]: events at scripted times on a [`MockClock`], for tests of event release
//! without threads or real time.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use super::{Notify, Waiter};
use crate::clock::MockClock;

#[derive(Debug, Default)]
struct Flag(AtomicBool);

impl Notify for Flag {
    fn notify(&self) {
        self.0.store(true, Ordering::Release);
    }
}

/// A waiter on a [`MockClock`]: a wait moves the clock to the next scripted event, or to the
/// deadline when that comes first; a pending notification releases it without moving the
/// clock.
///
/// ```
/// use wrc_rt::wake::{MockWaiter, Waiter};
/// use wrc_rt::{Clock, MockClock};
///
/// let clock = MockClock::new(0);
/// let mut waiter = MockWaiter::with_events(clock.clone(), [300, 1_000]);
/// assert!(waiter.wait_until_ns(1_000)); // the event at 300
/// assert_eq!(clock.now_ns(), 300);
/// assert!(waiter.wait_until_ns(1_000)); // the event at 1 000 comes with the deadline
/// assert!(!waiter.wait_until_ns(2_000)); // no event left: the deadline
/// assert_eq!(clock.now_ns(), 2_000);
/// ```
#[derive(Debug)]
pub struct MockWaiter {
    clock: MockClock,
    script: VecDeque<u64>,
    notified: Arc<Flag>,
}

impl MockWaiter {
    /// A waiter with no scripted event.
    pub fn new(clock: MockClock) -> MockWaiter {
        MockWaiter::with_events(clock, [])
    }

    /// A waiter with events at the times `events_ns` [ns, on `clock`], in the order given;
    /// an event already in the past when a wait starts releases it at once.
    pub fn with_events(clock: MockClock, events_ns: impl IntoIterator<Item = u64>) -> MockWaiter {
        MockWaiter {
            clock,
            script: events_ns.into_iter().collect(),
            notified: Arc::default(),
        }
    }

    /// A handle whose notification releases the next wait at the clock's current time.
    pub fn notifier(&self) -> Arc<dyn Notify> {
        self.notified.clone()
    }

    /// Scripted events not yet delivered.
    pub fn events_left(&self) -> usize {
        self.script.len()
    }
}

impl Waiter for MockWaiter {
    fn wait_until_ns(&mut self, deadline_ns: u64) -> bool {
        if self.notified.0.swap(false, Ordering::AcqRel) {
            return true;
        }
        match self.script.front() {
            Some(&at_ns) if at_ns <= deadline_ns => {
                self.script.pop_front();
                self.clock.set_ns(at_ns);
                true
            }
            _ => {
                self.clock.set_ns(deadline_ns);
                false
            }
        }
    }

    fn notifier(&self) -> Option<Arc<dyn Notify>> {
        Some(MockWaiter::notifier(self))
    }
}
