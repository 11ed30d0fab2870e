//! The recorder's memory: the last samples and messages in two fixed-size rings, allocated
//! once by [`Ring::new`]; a push copies into a slot and never allocates, never blocks and
//! never fails (when full it overwrites the oldest), so real-time tasks may push.
//!
//! The rings are hand-written rather than taken from a queue crate: the recorder needs
//! overwrite-oldest and in-place iteration by its single owner, not a producer/consumer
//! hand-off.

use std::mem::size_of;

use crate::{Message, Meta, Sample, TraceFile};

/// A count of samples and one of messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Counts {
    /// Samples.
    pub samples: usize,
    /// Messages.
    pub messages: usize,
}

/// The last samples and messages, oldest overwritten first.
#[derive(Clone, Debug)]
pub struct Ring {
    samples: Slots<Sample>,
    messages: Slots<Message>,
}

impl Ring {
    /// A ring keeping the last `sample_capacity` samples and `message_capacity` messages.
    /// This is its only allocation. A capacity of 0 keeps nothing of that kind.
    pub fn new(sample_capacity: usize, message_capacity: usize) -> Ring {
        let empty = Message::new(0, crate::Direction::Request, 0, 0, b"");
        Ring {
            samples: Slots::new(sample_capacity, Sample::default()),
            messages: Slots::new(message_capacity, empty),
        }
    }

    /// A ring keeping `seconds` [s] of samples taken every `period_ns` [ns], rounded up, and
    /// the last `messages` messages. Seconds that are negative or not finite count as 0,
    /// a period of 0 as 1 ns.
    pub fn for_seconds(seconds: f64, period_ns: u64, messages: usize) -> Ring {
        Ring::new(samples_for(seconds, period_ns), messages)
    }

    /// Keep `sample` (copied), overwriting the oldest when full. Never allocates.
    pub fn push_sample(&mut self, sample: &Sample) {
        self.samples.push(sample);
    }

    /// Keep `message` (copied), overwriting the oldest when full. Never allocates.
    pub fn push_message(&mut self, message: &Message) {
        self.messages.push(message);
    }

    /// The samples kept, oldest first.
    pub fn samples(&self) -> impl Iterator<Item = &Sample> + '_ {
        self.samples.iter()
    }

    /// The messages kept, oldest first.
    pub fn messages(&self) -> impl Iterator<Item = &Message> + '_ {
        self.messages.iter()
    }

    /// How many samples and messages are kept now.
    pub fn len(&self) -> Counts {
        Counts {
            samples: self.samples.len,
            messages: self.messages.len,
        }
    }

    /// Nothing is kept.
    pub fn is_empty(&self) -> bool {
        self.len() == Counts::default()
    }

    /// How many samples and messages the ring keeps at most.
    pub fn capacity(&self) -> Counts {
        Counts {
            samples: self.samples.slots.len(),
            messages: self.messages.slots.len(),
        }
    }

    /// How many samples and messages were overwritten (lost) since the ring was made.
    pub fn overwritten(&self) -> Counts {
        Counts {
            samples: self.samples.overwritten,
            messages: self.messages.overwritten,
        }
    }

    /// Memory the ring holds [byte]: its slots and itself.
    pub fn bytes(&self) -> usize {
        size_of::<Ring>()
            + self.samples.slots.len() * size_of::<Sample>()
            + self.messages.slots.len() * size_of::<Message>()
    }

    /// Forget everything kept (the overwritten counts too); the memory stays.
    pub fn clear(&mut self) {
        self.samples.clear();
        self.messages.clear();
    }

    /// A trace of what the ring keeps with `t_ns >= since_ns` (everything for `None`), with
    /// `meta`. Allocates: call it from a non-real-time thread.
    ///
    /// `meta.from_start` is kept only if no message was overwritten and `since_ns` leaves
    /// out none of the messages kept: otherwise the trace does not hold the whole session.
    pub fn snapshot(&self, meta: Meta, since_ns: Option<u64>) -> TraceFile {
        let mut trace = TraceFile {
            meta: meta.clone(),
            samples: Vec::new(),
            messages: Vec::new(),
        };
        self.snapshot_into(meta, since_ns, &mut trace);
        trace
    }

    /// [`Ring::snapshot`] into `into`, reusing its vectors (no allocation when they hold
    /// [`Ring::capacity`]).
    pub fn snapshot_into(&self, mut meta: Meta, since_ns: Option<u64>, into: &mut TraceFile) {
        let since = since_ns.unwrap_or(0);
        into.samples.clear();
        into.samples
            .extend(self.samples().filter(|s| s.t_ns >= since).copied());
        into.messages.clear();
        into.messages
            .extend(self.messages().filter(|m| m.t_ns >= since).copied());
        meta.from_start &=
            self.messages.overwritten == 0 && into.messages.len() == self.messages.len;
        into.meta = meta;
    }
}

/// Ring memory per second of recording, samples only [byte/s], for samples every
/// `period_ns` [ns]: the ring keeps whole [`Sample`]s (all [`MAX_AXES`](crate::MAX_AXES)
/// axes, so that a push is one copy), whatever the axis count. A period of 0 counts as
/// 1 ns.
pub fn ring_bytes_per_second(period_ns: u64) -> f64 {
    size_of::<Sample>() as f64 * 1e9 / period_ns.max(1) as f64
}

/// Trace file size per second of recording, samples only [byte/s], for `axis_count` axes
/// sampled every `period_ns` [ns]: a file keeps only the trace's axes
/// ([`sample_file_bytes`](crate::sample_file_bytes)). A period of 0 counts as 1 ns.
pub fn file_bytes_per_second(axis_count: usize, period_ns: u64) -> f64 {
    crate::sample_file_bytes(axis_count) as f64 * 1e9 / period_ns.max(1) as f64
}

/// Samples in `seconds` [s] at `period_ns` [ns], rounded up.
fn samples_for(seconds: f64, period_ns: u64) -> usize {
    if !seconds.is_finite() || seconds <= 0.0 {
        return 0;
    }
    // `as` saturates: an absurd duration asks for usize::MAX slots, which the allocator
    // refuses as any oversized Vec would.
    (seconds * 1e9 / period_ns.max(1) as f64).ceil() as usize
}

/// A fixed number of slots, `len` of them in use from `head` on, wrapping.
#[derive(Clone, Debug)]
struct Slots<T> {
    slots: Box<[T]>,
    head: usize,
    len: usize,
    overwritten: usize,
}

impl<T: Copy> Slots<T> {
    fn new(capacity: usize, fill: T) -> Slots<T> {
        Slots {
            slots: vec![fill; capacity].into_boxed_slice(),
            head: 0,
            len: 0,
            overwritten: 0,
        }
    }

    fn push(&mut self, value: &T) {
        let capacity = self.slots.len();
        if capacity == 0 {
            self.overwritten += 1;
            return;
        }
        if self.len < capacity {
            let mut i = self.head + self.len;
            if i >= capacity {
                i -= capacity;
            }
            self.slots[i] = *value;
            self.len += 1;
        } else {
            self.slots[self.head] = *value;
            self.head += 1;
            if self.head == capacity {
                self.head = 0;
            }
            self.overwritten += 1;
        }
    }

    fn iter(&self) -> impl Iterator<Item = &T> + '_ {
        let capacity = self.slots.len();
        let first = (capacity - self.head).min(self.len);
        let (tail, front) = (
            &self.slots[self.head..self.head + first],
            &self.slots[..self.len - first],
        );
        tail.iter().chain(front.iter())
    }

    fn clear(&mut self) {
        self.head = 0;
        self.len = 0;
        self.overwritten = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Direction;

    fn sample(t_ns: u64) -> Sample {
        Sample {
            t_ns,
            ..Sample::default()
        }
    }

    fn times(ring: &Ring) -> Vec<u64> {
        ring.samples().map(|s| s.t_ns).collect()
    }

    #[test]
    fn keeps_the_newest_oldest_first() {
        let mut ring = Ring::new(3, 2);
        assert!(ring.is_empty());
        ring.push_sample(&sample(1));
        ring.push_sample(&sample(2));
        assert_eq!(times(&ring), [1, 2]);
        for t in 3..=7 {
            ring.push_sample(&sample(t));
        }
        assert_eq!(times(&ring), [5, 6, 7]);
        assert_eq!(ring.len().samples, 3);
        assert_eq!(ring.overwritten().samples, 4);
        for t in 0..5 {
            ring.push_message(&Message::new(t, Direction::Request, 0, 0, b"STATUS"));
        }
        let kept: Vec<u64> = ring.messages().map(|m| m.t_ns).collect();
        assert_eq!(kept, [3, 4]);
        ring.clear();
        assert!(ring.is_empty());
        assert_eq!(
            ring.capacity(),
            Counts {
                samples: 3,
                messages: 2
            }
        );
    }

    #[test]
    fn a_ring_of_capacity_zero_keeps_nothing() {
        let mut ring = Ring::new(0, 0);
        ring.push_sample(&sample(1));
        ring.push_message(&Message::new(1, Direction::Reply, 0, 0, b"ACK"));
        assert!(ring.is_empty());
        assert_eq!(ring.samples().count(), 0);
        assert_eq!(
            ring.overwritten(),
            Counts {
                samples: 1,
                messages: 1
            }
        );
    }

    #[test]
    fn snapshot_keeps_the_window_and_says_whether_it_holds_the_session() {
        let mut ring = Ring::new(10, 10);
        for t in 0..6 {
            ring.push_sample(&sample(t * 10));
            ring.push_message(&Message::new(t * 10, Direction::Request, 0, 0, b"X"));
        }
        let mut meta = Meta::new("TRACE SAVE", 10, &["J1"], &[]);
        meta.from_start = true;
        let all = ring.snapshot(meta.clone(), None);
        assert_eq!(all.samples.len(), 6);
        assert!(all.meta.from_start);
        let recent = ring.snapshot(meta.clone(), Some(30));
        assert_eq!(
            recent.samples.iter().map(|s| s.t_ns).collect::<Vec<_>>(),
            [30, 40, 50]
        );
        assert_eq!(recent.messages.len(), 3);
        assert!(
            !recent.meta.from_start,
            "messages before 30 ns are left out"
        );
        let mut small = Ring::new(10, 2);
        for t in 0..3 {
            small.push_message(&Message::new(t, Direction::Request, 0, 0, b"X"));
        }
        assert!(
            !small.snapshot(meta, None).meta.from_start,
            "a message was lost"
        );
    }

    #[test]
    fn sizing_rounds_up_and_refuses_nonsense_without_panicking() {
        assert_eq!(
            Ring::for_seconds(1.0, 10_000_000, 4).capacity().samples,
            100
        );
        assert_eq!(
            Ring::for_seconds(0.015, 10_000_000, 0).capacity().samples,
            2
        );
        assert_eq!(Ring::for_seconds(-1.0, 10_000_000, 0).capacity().samples, 0);
        assert_eq!(Ring::for_seconds(f64::NAN, 0, 0).capacity().samples, 0);
        assert_eq!(samples_for(1e-9, 0), 1);
        let ring = Ring::new(100, 10);
        assert!(ring.bytes() >= 100 * size_of::<Sample>() + 10 * size_of::<Message>());
    }

    #[test]
    fn bytes_per_second_follows_the_period_and_the_axes() {
        let ring = ring_bytes_per_second(10_000_000);
        assert_eq!(ring, size_of::<Sample>() as f64 * 100.0);
        assert_eq!(file_bytes_per_second(4, 10_000_000), 9300.0);
        assert!(file_bytes_per_second(4, 1_000_000) > file_bytes_per_second(4, 10_000_000));
        assert!(file_bytes_per_second(16, 10_000_000) > file_bytes_per_second(4, 10_000_000));
    }
}
