//! A fixed-bucket log-linear histogram of durations [ns], recorded without allocation.
//!
//! Buckets are exact below 16 ns, then 16 buckets per power of two: any recorded value is
//! known to within 1/16 (6.25 %) up to about 68 s. Hand-written rather than `hdrhistogram`
//! because the real-time side records into atomics that a non-real-time reader copies while
//! the task runs (see [`crate::stats`]); recording is one relaxed load and store.

use std::sync::atomic::{AtomicU64, Ordering};

const SUB_BITS: u32 = 4;
const SUB: u64 = 1 << SUB_BITS;
const MAX_EXP: u32 = 36;

/// Number of buckets.
pub const BUCKETS: usize = ((MAX_EXP - SUB_BITS + 1) as usize + 1) * SUB as usize;

/// The bucket that holds `value_ns` (values beyond the range go into the last bucket).
pub fn bucket_of(value_ns: u64) -> usize {
    if value_ns < SUB {
        return value_ns as usize;
    }
    let exp = 63 - value_ns.leading_zeros();
    if exp > MAX_EXP {
        return BUCKETS - 1;
    }
    let mantissa = (value_ns >> (exp - SUB_BITS)) & (SUB - 1);
    ((exp - SUB_BITS + 1) as u64 * SUB + mantissa) as usize
}

/// The half-open range `[low, high)` of values in `bucket` [ns].
pub fn bucket_range(bucket: usize) -> (u64, u64) {
    let bucket = bucket as u64;
    if bucket < SUB {
        return (bucket, bucket + 1);
    }
    let exp = (bucket / SUB) as u32 + SUB_BITS - 1;
    let mantissa = bucket % SUB;
    let width = 1u64 << (exp - SUB_BITS);
    let low = (SUB + mantissa) * width;
    (low, low + width)
}

/// Counts of durations per bucket plus exact count, min, max and sum [ns].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Histogram {
    counts: Vec<u64>,
    count: u64,
    min_ns: u64,
    max_ns: u64,
    sum_ns: u128,
}

impl Default for Histogram {
    fn default() -> Self {
        Histogram::new()
    }
}

impl Histogram {
    /// An empty histogram (allocates its buckets once, here).
    pub fn new() -> Histogram {
        Histogram {
            counts: vec![0; BUCKETS],
            count: 0,
            min_ns: u64::MAX,
            max_ns: 0,
            sum_ns: 0,
        }
    }

    /// Record one duration [ns]; never allocates.
    pub fn record(&mut self, value_ns: u64) {
        self.counts[bucket_of(value_ns)] += 1;
        self.count += 1;
        self.min_ns = self.min_ns.min(value_ns);
        self.max_ns = self.max_ns.max(value_ns);
        self.sum_ns += value_ns as u128;
    }

    /// Number of recorded values.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Smallest recorded value [ns], `None` when empty.
    pub fn min_ns(&self) -> Option<u64> {
        (self.count > 0).then_some(self.min_ns)
    }

    /// Largest recorded value [ns], `None` when empty.
    pub fn max_ns(&self) -> Option<u64> {
        (self.count > 0).then_some(self.max_ns)
    }

    /// Mean of the recorded values [ns], `None` when empty.
    pub fn mean_ns(&self) -> Option<f64> {
        (self.count > 0).then(|| self.sum_ns as f64 / self.count as f64)
    }

    /// The value at quantile `q` (0 ≤ q ≤ 1) [ns]: the upper edge of the bucket holding it,
    /// clamped to the recorded min and max, so it errs high by at most one bucket (6.25 %).
    pub fn quantile_ns(&self, q: f64) -> Option<u64> {
        if self.count == 0 {
            return None;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.count as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (bucket, &n) in self.counts.iter().enumerate() {
            seen += n;
            if seen >= rank {
                let high = bucket_range(bucket).1 - 1;
                return Some(high.clamp(self.min_ns, self.max_ns));
            }
        }
        Some(self.max_ns)
    }

    /// Count per bucket (index with [`bucket_range`]).
    pub fn bucket_counts(&self) -> &[u64] {
        &self.counts
    }

    /// Add every value recorded in `other`.
    pub fn merge(&mut self, other: &Histogram) {
        for (a, b) in self.counts.iter_mut().zip(&other.counts) {
            *a += b;
        }
        self.count += other.count;
        self.min_ns = self.min_ns.min(other.min_ns);
        self.max_ns = self.max_ns.max(other.max_ns);
        self.sum_ns += other.sum_ns;
    }

    /// What was recorded after `earlier`, a snapshot of this same histogram taken before:
    /// the bucket counts and the sum are exact; min and max are the edges of the lowest and
    /// highest non-empty bucket (so they are known to one bucket, 6.25 %), clamped to this
    /// histogram's own min and max.
    pub fn since(&self, earlier: &Histogram) -> Histogram {
        let counts: Vec<u64> = self
            .counts
            .iter()
            .zip(&earlier.counts)
            .map(|(now, then)| now.saturating_sub(*then))
            .collect();
        let first = counts.iter().position(|&n| n > 0);
        let last = counts.iter().rposition(|&n| n > 0);
        let (min_ns, max_ns) = match (first, last) {
            (Some(f), Some(l)) => (
                bucket_range(f).0.max(self.min_ns),
                (bucket_range(l).1 - 1).min(self.max_ns),
            ),
            _ => (u64::MAX, 0),
        };
        Histogram {
            count: counts.iter().sum(),
            counts,
            min_ns,
            max_ns,
            sum_ns: self.sum_ns.saturating_sub(earlier.sum_ns),
        }
    }
}

/// The same histogram in atomics, written by one thread and copied by others.
///
/// Only one thread may call [`AtomicHistogram::record`]; a consistent copy needs the
/// sequence lock of [`crate::stats`] around it.
#[derive(Debug)]
pub struct AtomicHistogram {
    counts: Box<[AtomicU64]>,
    count: AtomicU64,
    min_ns: AtomicU64,
    max_ns: AtomicU64,
    sum_ns: AtomicU64,
}

impl Default for AtomicHistogram {
    fn default() -> Self {
        AtomicHistogram::new()
    }
}

impl AtomicHistogram {
    /// An empty histogram (allocates once, here).
    pub fn new() -> AtomicHistogram {
        AtomicHistogram {
            counts: (0..BUCKETS).map(|_| AtomicU64::new(0)).collect(),
            count: AtomicU64::new(0),
            min_ns: AtomicU64::new(u64::MAX),
            max_ns: AtomicU64::new(0),
            sum_ns: AtomicU64::new(0),
        }
    }

    /// Record one duration [ns] (single writer; wait-free, no allocation).
    pub fn record(&self, value_ns: u64) {
        let bump = |a: &AtomicU64, by: u64| {
            a.store(
                a.load(Ordering::Relaxed).wrapping_add(by),
                Ordering::Relaxed,
            )
        };
        bump(&self.counts[bucket_of(value_ns)], 1);
        bump(&self.count, 1);
        bump(&self.sum_ns, value_ns);
        if value_ns < self.min_ns.load(Ordering::Relaxed) {
            self.min_ns.store(value_ns, Ordering::Relaxed);
        }
        if value_ns > self.max_ns.load(Ordering::Relaxed) {
            self.max_ns.store(value_ns, Ordering::Relaxed);
        }
    }

    /// Copy into `into` (which must come from [`Histogram::new`]); no allocation.
    pub fn copy_into(&self, into: &mut Histogram) {
        for (dst, src) in into.counts.iter_mut().zip(self.counts.iter()) {
            *dst = src.load(Ordering::Relaxed);
        }
        into.count = self.count.load(Ordering::Relaxed);
        into.min_ns = self.min_ns.load(Ordering::Relaxed);
        into.max_ns = self.max_ns.load(Ordering::Relaxed);
        into.sum_ns = self.sum_ns.load(Ordering::Relaxed) as u128;
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn since_keeps_only_what_came_after_the_snapshot() {
        let mut h = Histogram::new();
        for v in [100, 2_000, 30_000] {
            h.record(v);
        }
        let before = h.clone();
        for v in [5_000, 5_000, 900_000] {
            h.record(v);
        }
        let window = h.since(&before);
        assert_eq!(window.count(), 3);
        assert_eq!(window.mean_ns(), Some(910_000.0 / 3.0));
        let (lo, hi) = (window.min_ns().unwrap(), window.max_ns().unwrap());
        assert!(lo <= 5_000 && lo as f64 >= 5_000.0 * 0.93, "{lo}");
        assert_eq!(hi, 900_000);
        assert!(window.quantile_ns(0.5).unwrap() >= 5_000);
        assert!(window.quantile_ns(0.5).unwrap() < 6_000);
        assert_eq!(h.since(&h).count(), 0);
    }

    use super::*;

    #[test]
    fn every_value_falls_inside_its_bucket_within_one_sixteenth() {
        let mut v = 0u64;
        while v < (1u64 << MAX_EXP) {
            let b = bucket_of(v);
            let (low, high) = bucket_range(b);
            assert!(
                low <= v && v < high,
                "{v} not in bucket {b} = [{low}, {high})"
            );
            assert!(high - low <= (low / 16).max(1), "bucket {b} too wide");
            v = v * 9 / 8 + 1;
        }
        assert_eq!(bucket_of(u64::MAX), BUCKETS - 1);
        // Buckets are ordered and contiguous.
        for b in 1..BUCKETS {
            assert_eq!(bucket_range(b - 1).1, bucket_range(b).0);
        }
    }

    #[test]
    fn quantiles_min_max_mean() {
        let mut h = Histogram::new();
        assert_eq!(h.quantile_ns(0.99), None);
        for v in 1..=1000u64 {
            h.record(v * 1000);
        }
        assert_eq!(
            (h.min_ns(), h.max_ns(), h.count()),
            (Some(1000), Some(1_000_000), 1000)
        );
        assert_eq!(h.mean_ns(), Some(500_500.0));
        let p50 = h.quantile_ns(0.5).unwrap() as f64;
        let p99 = h.quantile_ns(0.99).unwrap() as f64;
        assert!((500_000.0..=500_000.0 * 1.0625).contains(&p50), "p50 {p50}");
        assert!((990_000.0..=1_000_000.0).contains(&p99), "p99 {p99}");
        assert_eq!(h.quantile_ns(1.0), Some(1_000_000));
    }

    #[test]
    fn atomic_copy_equals_plain_recording_and_merge_adds() {
        let (a, mut plain, mut copy) = (AtomicHistogram::new(), Histogram::new(), Histogram::new());
        for v in [0, 3, 17, 999, 123_456, 7_000_000_000] {
            a.record(v);
            plain.record(v);
        }
        a.copy_into(&mut copy);
        assert_eq!(copy, plain);
        let mut twice = plain.clone();
        twice.merge(&plain);
        assert_eq!(twice.count(), 12);
        assert_eq!(twice.quantile_ns(0.5), plain.quantile_ns(0.5));
    }
}
