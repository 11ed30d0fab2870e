//! A bounded multi-producer multi-consumer message queue, like RTAI's mailboxes/message
//! queues: `try_send` never blocks and hands the message back when the queue is full;
//! receive without waiting or with a timeout.
//!
//! The slots are a `crossbeam_queue::ArrayQueue` (lock-free, allocated once); a
//! [`Semaphore`] counts the messages so a receiver can sleep until one arrives.
//!
//! A queue made with [`MessageQueue::with_notify`] also releases its consumer task (one
//! added with [`crate::Runtime::add_released`]) at once. The rule: **every** successful send
//! notifies, after the message is in the queue. Notifying costs an atomic swap; the
//! notifier makes a system call only when the consumer sleeps and nobody woke it yet, so a
//! burst of sends costs one. Every message is therefore pushed before a notification the
//! consumer has not consumed yet, or before the consumer's wait that consumes it: the cycle
//! that follows sees it. Nothing is left unnoticed as long as the consumer drains the queue
//! each cycle; a consumer that leaves messages behind gets them at its next release (its
//! period, or the next send).

use std::fmt;
use std::sync::Arc;
use std::time::Duration;

use crossbeam_queue::ArrayQueue;

use crate::ipc::semaphore::Semaphore;
use crate::wake::Notify;

/// Why a send did not happen; the message is handed back.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TrySendError<T> {
    /// The queue holds `capacity` messages.
    #[error("the message queue is full")]
    Full(T),
}

impl<T> TrySendError<T> {
    /// The message that was not sent.
    pub fn into_inner(self) -> T {
        match self {
            TrySendError::Full(t) => t,
        }
    }
}

/// Why nothing was received.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RecvError {
    /// No message was waiting.
    #[error("the message queue is empty")]
    Empty,
    /// No message arrived within the timeout.
    #[error("no message arrived within the timeout")]
    Timeout,
}

/// A bounded message queue; share it with `Arc`.
///
/// ```
/// use wrc_rt::ipc::{MessageQueue, TrySendError};
/// let q = MessageQueue::new(1);
/// q.try_send(1).unwrap();
/// assert_eq!(q.try_send(2), Err(TrySendError::Full(2)));
/// assert_eq!(q.try_recv(), Ok(1));
/// ```
pub struct MessageQueue<T> {
    slots: ArrayQueue<T>,
    ready: Semaphore,
    consumer: Option<Arc<dyn Notify>>,
}

impl<T> fmt::Debug for MessageQueue<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MessageQueue")
            .field("len", &self.slots.len())
            .field("capacity", &self.slots.capacity())
            .field("notifies", &self.consumer.is_some())
            .finish()
    }
}

impl<T> MessageQueue<T> {
    /// A queue for up to `capacity` (> 0) messages; allocates here only.
    pub fn new(capacity: usize) -> MessageQueue<T> {
        MessageQueue {
            slots: ArrayQueue::new(capacity),
            ready: Semaphore::new(0),
            consumer: None,
        }
    }

    /// A queue for up to `capacity` (> 0) messages whose every successful send notifies
    /// `consumer` (the [`crate::wake::Waiter`] of the task that drains it), so that task runs
    /// at once instead of at its next period. Allocates here only.
    ///
    /// ```
    /// use wrc_rt::ipc::MessageQueue;
    /// use wrc_rt::wake::{Wake, Waiter};
    /// use wrc_rt::{Clock, MonotonicClock};
    ///
    /// let mut wake = Wake::new();
    /// let q = MessageQueue::with_notify(8, wake.notifier());
    /// q.try_send("1 SPEED 100").unwrap();
    /// // The consumer's wait ends at once, long before its deadline.
    /// assert!(wake.wait_until_ns(MonotonicClock.now_ns() + 10_000_000_000));
    /// assert_eq!(q.try_recv(), Ok("1 SPEED 100"));
    /// ```
    pub fn with_notify(capacity: usize, consumer: Arc<dyn Notify>) -> MessageQueue<T> {
        MessageQueue {
            consumer: Some(consumer),
            ..MessageQueue::new(capacity)
        }
    }

    /// Send without blocking; a full queue hands the message back (and notifies nobody).
    pub fn try_send(&self, message: T) -> Result<(), TrySendError<T>> {
        self.slots.push(message).map_err(TrySendError::Full)?;
        self.ready.post();
        if let Some(consumer) = &self.consumer {
            consumer.notify();
        }
        Ok(())
    }

    /// Take the oldest message, without waiting.
    pub fn try_recv(&self) -> Result<T, RecvError> {
        if self.ready.try_wait() {
            Ok(self.take())
        } else {
            Err(RecvError::Empty)
        }
    }

    /// Take the oldest message, waiting at most `timeout` for one.
    pub fn recv_timeout(&self, timeout: Duration) -> Result<T, RecvError> {
        if self.ready.wait_timeout(timeout) {
            Ok(self.take())
        } else {
            Err(RecvError::Timeout)
        }
    }

    fn take(&self) -> T {
        // Every count in `ready` was posted after its message was pushed, and each count is
        // taken once, so a message is there; the loop only covers another receiver's pop that
        // has taken its count but not yet finished.
        loop {
            if let Some(message) = self.slots.pop() {
                return message;
            }
            std::hint::spin_loop();
        }
    }

    /// Messages waiting now.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// No message is waiting.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// The most messages it holds.
    pub fn capacity(&self) -> usize {
        self.slots.capacity()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use std::time::Instant;

    #[test]
    fn a_full_queue_hands_the_message_back_and_order_is_kept() {
        let q = MessageQueue::new(3);
        for i in 0..3 {
            q.try_send(String::from(["a", "b", "c"][i])).unwrap();
        }
        let back = q.try_send("d".to_string()).unwrap_err().into_inner();
        assert_eq!(back, "d");
        assert_eq!((q.len(), q.capacity()), (3, 3));
        assert_eq!(q.try_recv().unwrap(), "a");
        q.try_send(back).unwrap();
        let all: Vec<_> = std::iter::from_fn(|| q.try_recv().ok()).collect();
        assert_eq!(all, ["b", "c", "d"]);
        assert_eq!(q.try_recv(), Err(RecvError::Empty));
    }

    #[test]
    fn receive_times_out_then_gets_a_late_message() {
        let q = Arc::new(MessageQueue::new(4));
        let t0 = Instant::now();
        assert_eq!(
            q.recv_timeout(Duration::from_millis(15)),
            Err(RecvError::Timeout)
        );
        assert!(t0.elapsed() >= Duration::from_millis(15));
        let sender = {
            let q = q.clone();
            std::thread::spawn(move || {
                std::thread::sleep(Duration::from_millis(10));
                q.try_send(7u32).unwrap();
            })
        };
        assert_eq!(q.recv_timeout(Duration::from_secs(10)), Ok(7));
        sender.join().unwrap();
    }

    #[test]
    fn every_send_to_a_notifying_queue_releases_its_consumer() {
        use crate::wake::{MockWaiter, Waiter};
        use crate::{Clock, MockClock};
        let clock = MockClock::new(0);
        let mut consumer = MockWaiter::new(clock.clone());
        let q = MessageQueue::with_notify(2, consumer.notifier());
        assert!(!consumer.wait_until_ns(1_000), "nothing sent yet");
        q.try_send(1u8).unwrap();
        assert!(consumer.wait_until_ns(2_000));
        assert_eq!(
            clock.now_ns(),
            1_000,
            "released without waiting for the deadline"
        );
        // Sent while the consumer is not waiting, even to a non-empty queue: released again.
        q.try_send(2).unwrap();
        assert!(consumer.wait_until_ns(2_000));
        assert_eq!((q.try_recv(), q.try_recv()), (Ok(1), Ok(2)));
        // A refused send notifies nobody.
        q.try_send(3).unwrap();
        q.try_send(4).unwrap();
        assert!(consumer.wait_until_ns(2_000));
        assert_eq!(q.try_send(5), Err(TrySendError::Full(5)));
        assert!(!consumer.wait_until_ns(2_000));
    }

    #[test]
    fn a_message_sent_while_the_consumer_drains_is_never_left_unnoticed() {
        use crate::wake::{Waiter, Wake};
        use crate::{Clock, MonotonicClock};
        // A consumer that drains the queue each time it is released must receive every
        // message, and never wait until its (far) deadline while one is queued.
        let mut wake = Wake::new();
        let q = Arc::new(MessageQueue::with_notify(64, wake.notifier()));
        let total = 50_000u64;
        let producer = {
            let q = q.clone();
            std::thread::spawn(move || {
                for i in 0..total {
                    let mut m = i;
                    while let Err(TrySendError::Full(back)) = q.try_send(m) {
                        m = back;
                        std::thread::yield_now();
                    }
                }
            })
        };
        let mut next = 0;
        while next < total {
            let deadline = MonotonicClock.now_ns() + 20_000_000_000;
            assert!(wake.wait_until_ns(deadline), "a message went unnoticed");
            while let Ok(m) = q.try_recv() {
                assert_eq!(m, next);
                next += 1;
            }
        }
        producer.join().unwrap();
    }

    #[test]
    fn many_threads_deliver_every_message_exactly_once() {
        let q = Arc::new(MessageQueue::new(16));
        let (senders, per) = (4u64, 10_000u64);
        let producers: Vec<_> = (0..senders)
            .map(|s| {
                let q = q.clone();
                std::thread::spawn(move || {
                    let mut full = 0u64;
                    for i in 0..per {
                        let mut m = s * per + i;
                        loop {
                            match q.try_send(m) {
                                Ok(()) => break,
                                Err(TrySendError::Full(back)) => {
                                    m = back;
                                    full += 1;
                                    std::thread::yield_now();
                                }
                            }
                        }
                    }
                    full
                })
            })
            .collect();
        let consumers: Vec<_> = (0..3)
            .map(|_| {
                let q = q.clone();
                std::thread::spawn(move || {
                    let mut got = Vec::new();
                    while let Ok(m) = q.recv_timeout(Duration::from_millis(500)) {
                        got.push(m);
                    }
                    got
                })
            })
            .collect();
        producers.into_iter().for_each(|p| {
            p.join().unwrap();
        });
        let mut all: Vec<u64> = consumers
            .into_iter()
            .flat_map(|c| c.join().unwrap())
            .collect();
        all.sort_unstable();
        assert_eq!(all, (0..senders * per).collect::<Vec<_>>());
    }
}
