//! The board's view of the host watchdog: armed once the host first refreshes its counter,
//! tripped when the counter has not changed for the configured number of periods, latched
//! until the host resets the board.

/// Host-watchdog monitor; call [`HostWatchdog::step`] once per board period.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HostWatchdog {
    limit_periods: u32,
    last: u32,
    stale_periods: u32,
    armed: bool,
    tripped: bool,
}

impl HostWatchdog {
    /// A monitor that trips after `limit_periods` periods without a refresh (≥ 1).
    pub fn new(limit_periods: u32, initial: u32) -> HostWatchdog {
        HostWatchdog {
            limit_periods: limit_periods.max(1),
            last: initial,
            stale_periods: 0,
            armed: false,
            tripped: false,
        }
    }

    /// Look at the host's counter; returns true in the period the watchdog trips.
    pub fn step(&mut self, counter: u32) -> bool {
        if counter != self.last {
            self.last = counter;
            self.stale_periods = 0;
            self.armed = true;
            return false;
        }
        if !self.armed || self.tripped {
            return false;
        }
        self.stale_periods += 1;
        if self.stale_periods >= self.limit_periods {
            self.tripped = true;
            return true;
        }
        false
    }

    /// Whether the host has refreshed at least once.
    pub fn is_armed(&self) -> bool {
        self.armed
    }

    /// Whether it has tripped (until [`HostWatchdog::reset`]).
    pub fn is_tripped(&self) -> bool {
        self.tripped
    }

    /// Clear the trip; the count of stale periods starts again.
    pub fn reset(&mut self) {
        self.tripped = false;
        self.stale_periods = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trips_after_the_limit_only_once_armed() {
        let mut w = HostWatchdog::new(3, 0);
        for _ in 0..10 {
            assert!(!w.step(0)); // never refreshed: not armed
        }
        assert!(!w.step(1));
        assert!(!w.step(1));
        assert!(!w.step(1));
        assert!(w.step(1));
        assert!(w.is_tripped());
        assert!(!w.step(2)); // latched
        assert!(w.is_tripped());
        w.reset();
        assert!(!w.is_tripped());
    }
}
