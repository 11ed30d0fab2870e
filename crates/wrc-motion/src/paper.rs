//! The paper's profile (eq. 1-2): a triangular mask K(t) convolved with the per-period input
//! pulses, in exact integer arithmetic so that not one pulse is lost.
//!
//! Eq. (1): K(t) = A·t for t <= n/2 and A·(n−t) for t > n/2. With n = 2m the mask is the
//! convolution of two boxes of m periods, and unit gain (ΣK = 1) gives A = 1/m² = 4/n².
//! Eq. (2): O(i) = Σ K(t)·P(i−t). The input P is the move's pulses spread evenly over N0
//! periods (P(j) = ⌊D(j+1)/N0⌋ − ⌊Dj/N0⌋, summing to D exactly). Running sums evaluate
//! eq. (2) in O(1) per period with no delay line, and the fractional output is carried:
//! the pulses emitted up to period i are round(Σ O), so their total equals D exactly.
//! No allocation, no floating point in the pulse path.

/// One channel (an axis, or the path parameter of a straight line) of the paper profile.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PaperChannel {
    /// Total input pulses D [pulse] (negative for a move in the negative direction).
    distance: i64,
    /// Input periods N0 over which D is spread.
    input_periods: u64,
    /// Input periods actually fed: N0, or fewer after a stop.
    cut: u64,
    /// Half the mask length, m = n/2 [periods].
    half: u64,
    /// Next period index i.
    index: u64,
    /// Σ K·P for the current period, times m² (the second running sum).
    sum2: i128,
    /// Σ over all periods so far of O(i), times m².
    cumulative: i128,
    /// Pulses emitted so far.
    emitted: i64,
}

impl PaperChannel {
    /// A channel that moves `distance` pulses with its input spread over `input_periods`
    /// (>= 1) periods and a mask of `2 * half` periods (`half` >= 1).
    pub fn new(distance: i64, input_periods: u64, half: u64) -> PaperChannel {
        let input_periods = input_periods.max(1);
        PaperChannel {
            distance,
            input_periods,
            cut: input_periods,
            half: half.max(1),
            index: 0,
            sum2: 0,
            cumulative: 0,
            emitted: 0,
        }
    }

    /// Periods from the start until the channel is at rest: N0 + n − 2 (N0 = input length).
    pub fn total_periods(&self) -> u64 {
        self.cut + 2 * self.half - 2
    }

    /// Whether every output period has been produced.
    pub fn done(&self) -> bool {
        self.index >= self.total_periods()
    }

    /// Pulses this channel will have emitted when it comes to rest.
    pub fn final_pulses(&self) -> i64 {
        self.cumulative_input(self.cut as i128 - 1)
    }

    /// Pulses of the whole move as planned, D [pulse].
    pub fn distance(&self) -> i64 {
        self.distance
    }

    /// Output so far before rounding, Σ O(i) [pulse] (what eq. 2 gives in real numbers).
    pub fn exact_output(&self) -> f64 {
        self.cumulative as f64 / (self.half * self.half) as f64
    }

    /// Pulses emitted so far.
    pub fn emitted(&self) -> i64 {
        self.emitted
    }

    /// Cumulative input C(j) = Σ_{x<=j} P(x) [pulse].
    #[inline]
    fn cumulative_input(&self, j: i128) -> i64 {
        if j < 0 {
            return 0;
        }
        let fed = (j + 1).min(self.cut as i128);
        (self.distance as i128 * fed).div_euclid(self.input_periods as i128) as i64
    }

    /// First running sum s1(i) = Σ_{x=i−m+1}^{i} P(x).
    #[inline]
    fn sum1(&self, i: i128) -> i128 {
        (self.cumulative_input(i) - self.cumulative_input(i - self.half as i128)) as i128
    }

    /// Produce the next period's pulses.
    #[inline]
    pub fn next_pulses(&mut self) -> i64 {
        if self.done() {
            return 0;
        }
        let i = self.index as i128;
        let m = self.half as i128;
        self.sum2 += self.sum1(i) - self.sum1(i - m);
        self.cumulative += self.sum2;
        self.index += 1;
        let scale = m * m;
        // round(cumulative / m²), half away from -inf, exact in integers.
        let total = (2 * self.cumulative + scale).div_euclid(2 * scale) as i64;
        let pulses = total - self.emitted;
        self.emitted = total;
        pulses
    }

    /// Controlled stop before input period `self.index`: stop feeding input as early as the
    /// jerk limit allows. The mask is two boxes of m periods: a cut makes a deceleration jerk
    /// pulse of 2m periods, which must not overlap the acceleration's (the jerk would
    /// double), so a cut inside the first n = 2m input periods waits until period n. This is
    /// the paper profile's own stop; the default profile brakes with [`crate::Brake1d`].
    pub fn stop(&mut self) {
        let now = self.index;
        if now >= self.cut {
            return;
        }
        let n = 2 * self.half;
        let cut = if now > 0 && now < n { n } else { now };
        self.cut = cut.min(self.cut);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Eq. (1) and (2) literally, in floating point, with unit gain: the mask with A = 4/n².
    fn literal(distance: i64, n0: u64, n: u64) -> Vec<f64> {
        let a = 4.0 / (n * n) as f64;
        let k = |t: u64| {
            if t <= n / 2 {
                a * t as f64
            } else {
                a * (n - t) as f64
            }
        };
        let p = |j: i64| -> f64 {
            if j < 0 || j as u64 >= n0 {
                0.0
            } else {
                let j = j as i128;
                let d = distance as i128;
                ((d * (j + 1)).div_euclid(n0 as i128) - (d * j).div_euclid(n0 as i128)) as f64
            }
        };
        (0..(n0 + n - 2) as i64)
            .map(|i| (1..n).map(|t| k(t) * p(i + 1 - t as i64)).sum())
            .collect()
    }

    #[test]
    fn matches_the_papers_equations() {
        for (d, n0, n) in [(1000, 30, 10), (-777, 25, 20), (5, 40, 4), (123_457, 7, 2)] {
            let want = literal(d, n0, n);
            let mut ch = PaperChannel::new(d, n0, n / 2);
            assert_eq!(ch.total_periods() as usize, want.len());
            let mut carried = 0.0;
            let mut emitted = 0i64;
            for (i, w) in want.iter().enumerate() {
                carried += w;
                emitted += ch.next_pulses();
                assert!(
                    (emitted as f64 - carried).abs() <= 0.5 + 1e-9,
                    "{d} {n0} {n} period {i}"
                );
            }
            assert_eq!(emitted, d);
            assert!(ch.done());
            assert_eq!(ch.next_pulses(), 0);
        }
    }

    #[test]
    fn mask_sums_to_one_with_a_of_four_over_n_squared() {
        for n in (2..200).step_by(2) {
            let a = 4.0 / (n * n) as f64;
            let sum: f64 = (1..n)
                .map(|t| {
                    if t <= n / 2 {
                        a * t as f64
                    } else {
                        a * (n - t) as f64
                    }
                })
                .sum();
            assert!((sum - 1.0).abs() < 1e-12);
        }
    }

    proptest! {
        // Pulse conservation: the output sums to the input exactly, stopped or not, and a
        // stop never moves back.
        #[test]
        fn conserves_pulses(d in -10_000_000i64..10_000_000, n0 in 1u64..500, half in 1u64..60,
                            stop_at in proptest::option::of(0u64..600)) {
            let mut ch = PaperChannel::new(d, n0, half);
            let mut total = 0i64;
            let mut k = 0u64;
            while !ch.done() {
                if Some(k) == stop_at { ch.stop(); }
                let p = ch.next_pulses();
                prop_assert!(p == 0 || p.signum() == d.signum());
                total += p;
                k += 1;
            }
            prop_assert_eq!(total, ch.final_pulses());
            if stop_at.is_none_or(|s| s >= n0) {
                prop_assert_eq!(total, d);
            }
        }
    }
}
