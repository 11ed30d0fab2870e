//! A single-producer single-consumer ring for per-period batches (the Velocity Generator's
//! pulse batches to the Pulse Generator): wait-free, allocated once. A thin layer over
//! [`rtrb`] that names the operations after what a controller does with them.

/// The ring was full; the batch is handed back.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the ring is full")]
pub struct Full<T>(pub T);

/// A ring for up to `capacity` batches: the sending and the receiving end.
///
/// ```
/// let (mut tx, mut rx) = wrc_rt::ipc::spsc::channel::<[i32; 4]>(2);
/// tx.try_send([1, 2, 3, 4]).unwrap();
/// tx.try_send([5, 6, 7, 8]).unwrap();
/// assert!(tx.try_send([0; 4]).is_err());
/// assert_eq!(rx.try_recv(), Some([1, 2, 3, 4]));
/// ```
pub fn channel<T>(capacity: usize) -> (SpscSender<T>, SpscReceiver<T>) {
    let (tx, rx) = rtrb::RingBuffer::new(capacity);
    (SpscSender { inner: tx }, SpscReceiver { inner: rx })
}

/// The sending end (one thread).
#[derive(Debug)]
pub struct SpscSender<T> {
    inner: rtrb::Producer<T>,
}

impl<T> SpscSender<T> {
    /// Append a batch; a full ring hands it back.
    pub fn try_send(&mut self, batch: T) -> Result<(), Full<T>> {
        self.inner
            .push(batch)
            .map_err(|rtrb::PushError::Full(b)| Full(b))
    }

    /// Free slots now.
    pub fn free_slots(&self) -> usize {
        self.inner.slots()
    }

    /// The receiving end was dropped.
    pub fn is_abandoned(&self) -> bool {
        self.inner.is_abandoned()
    }
}

/// The receiving end (one thread).
#[derive(Debug)]
pub struct SpscReceiver<T> {
    inner: rtrb::Consumer<T>,
}

impl<T> SpscReceiver<T> {
    /// Take the oldest batch, if any.
    pub fn try_recv(&mut self) -> Option<T> {
        self.inner.pop().ok()
    }

    /// Batches waiting now.
    pub fn len(&self) -> usize {
        self.inner.slots()
    }

    /// No batch is waiting.
    pub fn is_empty(&self) -> bool {
        self.inner.is_empty()
    }

    /// The sending end was dropped.
    pub fn is_abandoned(&self) -> bool {
        self.inner.is_abandoned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batches_cross_threads_in_order() {
        let (mut tx, mut rx) = channel::<[u64; 8]>(4);
        let n = 50_000u64;
        let producer = std::thread::spawn(move || {
            let mut i = 0;
            while i < n {
                match tx.try_send([i; 8]) {
                    Ok(()) => i += 1,
                    Err(Full(_)) => std::thread::yield_now(),
                }
            }
        });
        let mut expected = 0;
        while expected < n {
            match rx.try_recv() {
                Some(batch) => {
                    assert_eq!(batch, [expected; 8]);
                    expected += 1;
                }
                None => std::thread::yield_now(),
            }
        }
        producer.join().unwrap();
        assert!(rx.is_empty() && rx.is_abandoned());
    }
}
