//! One simulated servo axis: executes one period's increment, interpolated over the board's
//! sub-steps, through a first-order servo lag to the motor and its encoder; checks the
//! motor's velocity limit, the following error and the limit switches; decelerates under
//! control to a stop. Plain arithmetic, no allocation.

use wrc_board::layout::{alarm, axis_status};
use wrc_motion::Brake1d;

/// Increments an axis remembers to brake from.
const RECENT: usize = 9;
/// The time over which a stop reads the acceleration from the increments [s].
const ACCEL_WINDOW_S: f64 = 0.008;

/// Per-axis model parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoSettings {
    /// Motor velocity limit; a period's increment above it raises [`alarm::OVERSPEED`]
    /// [pulse/s].
    pub max_velocity_pps: f64,
    /// Acceleration limit of a controlled stop (watchdog, E-stop, a stop the board brakes
    /// on its own) when the host has written none [pulse/s²].
    pub stop_deceleration_pps2: f64,
    /// Jerk limit of a controlled stop when the host has written none [pulse/s³].
    pub stop_jerk_pps3: f64,
    /// Servo lag time constant: the motor follows the command as a first-order lag [s].
    pub lag_s: f64,
    /// Following error above which the axis alarms [pulse].
    pub following_error_limit: i64,
    /// Positive limit switch: active at encoder ≥ this [pulse].
    pub limit_pos: i64,
    /// Negative limit switch: active at encoder ≤ this [pulse].
    pub limit_neg: i64,
    /// Position at power-on [pulse].
    pub initial: i64,
}

/// What the axis is asked to do in one period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Drive {
    /// Execute this increment from the FIFO [pulse/period].
    Increment(i64),
    /// The FIFO was empty: hold the commanded position.
    Hold,
    /// Controlled stop: the time-optimal jerk-limited brake from the current velocity and
    /// acceleration to standstill within these limits, then hold.
    Stop {
        /// Acceleration limit [pulse/s²].
        accel_pps2: f64,
        /// Jerk limit [pulse/s³].
        jerk_pps3: f64,
    },
}

/// The state of one simulated axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoAxis {
    settings: ServoSettings,
    commanded: i64,
    motor: f64,
    encoder: i64,
    /// Alarm cause bits; 0 = servo on.
    alarm: u32,
    /// Increment executed in the last period [pulse/period].
    increment: i64,
    /// The last [`RECENT`] increments executed, newest at `(recent_n - 1) % RECENT`
    /// [pulse/period]: the velocity and acceleration a stop brakes from.
    recent: [i64; RECENT],
    recent_n: usize,
    /// A controlled stop: the brake from where it began (position 0), its time so far [s],
    /// the pulses it has emitted, and whether it is still decelerating.
    brake: Brake1d,
    brake_t: f64,
    brake_emitted: i64,
    braking: bool,
    /// In a controlled stop (decelerating, then holding until it ends).
    stopping: bool,
    /// Encoder frozen (injected fault).
    pub encoder_stuck: bool,
}

impl ServoAxis {
    /// An axis at rest at its initial position, servo on.
    pub fn new(settings: ServoSettings) -> ServoAxis {
        ServoAxis {
            settings,
            commanded: settings.initial,
            motor: settings.initial as f64,
            encoder: settings.initial,
            alarm: 0,
            increment: 0,
            recent: [0; RECENT],
            recent_n: 0,
            brake: Brake1d::default(),
            brake_t: 0.0,
            brake_emitted: 0,
            braking: false,
            stopping: false,
            encoder_stuck: false,
        }
    }

    /// The parameters.
    pub fn settings(&self) -> &ServoSettings {
        &self.settings
    }

    /// Commanded position [pulse].
    pub fn commanded(&self) -> i64 {
        self.commanded
    }

    /// Encoder position [pulse].
    pub fn encoder(&self) -> i64 {
        self.encoder
    }

    /// Alarm cause bits (0 = none).
    pub fn alarm(&self) -> u32 {
        self.alarm
    }

    /// Increment executed in the last period [pulse/period].
    pub fn increment(&self) -> i64 {
        self.increment
    }

    /// Whether a controlled stop is in progress (decelerating, or holding after it).
    pub fn is_stopping(&self) -> bool {
        self.stopping
    }

    /// Whether a controlled stop is still decelerating.
    pub fn is_braking(&self) -> bool {
        self.stopping && self.braking
    }

    /// Raise alarm `cause`: the servo turns off and the motor stops where it is (the
    /// paper's overcurrent stop). Returns true if the axis was not alarmed before.
    pub fn raise(&mut self, cause: u32) -> bool {
        let new = self.alarm == 0;
        self.alarm |= cause;
        self.increment = 0;
        self.recent = [0; RECENT];
        self.stopping = false;
        self.braking = false;
        new
    }

    /// Clear the alarm: the command is set to the encoder so the axis does not jump.
    pub fn clear_alarm(&mut self) {
        if self.alarm != 0 {
            self.alarm = 0;
            self.commanded = self.encoder;
            self.motor = self.encoder as f64;
        }
    }

    /// Start a controlled stop: the time-optimal brake within `accel_pps2` and `jerk_pps3`
    /// from the velocity and acceleration the last two periods' increments show (from the
    /// brake's own state when a stop is already decelerating: a stronger stop brakes again
    /// from where the first one is). No effect when alarmed.
    pub fn begin_stop(&mut self, accel_pps2: f64, jerk_pps3: f64, period_s: f64) {
        if self.alarm != 0 {
            return;
        }
        let (v, a) = if self.is_braking() {
            let (_, v, a) = self.brake.at(self.brake_t);
            (v, a)
        } else {
            self.velocity_and_acceleration(period_s, accel_pps2)
        };
        self.brake = Brake1d::new(0.0, v, a, accel_pps2, jerk_pps3);
        self.brake_t = 0.0;
        self.brake_emitted = 0;
        self.braking = true;
        self.stopping = true;
    }

    /// The velocity at the end of the last period and the acceleration, from the recent
    /// increments [pulse/s, pulse/s²]. An increment is the velocity averaged over its
    /// period, rounded to a pulse (at 1 ms one pulse is 3 % of a slow axis's velocity, and a
    /// one-period difference of one pulse reads 10⁶ pulse/s²): so both come from the sums of
    /// the newest `h` increments and the `h` before them, over about [`ACCEL_WINDOW_S`]
    /// (the sums are exact positions, rounded once), and the acceleration is kept within
    /// the brake's own limit `accel_pps2`.
    fn velocity_and_acceleration(&self, period_s: f64, accel_pps2: f64) -> (f64, f64) {
        let back = |k: usize| {
            if k < self.recent_n.min(RECENT) {
                self.recent[(self.recent_n - 1 - k) % RECENT] as f64
            } else {
                0.0
            }
        };
        let h = ((ACCEL_WINDOW_S / period_s / 2.0).round() as usize).clamp(1, RECENT / 2);
        let span = h as f64 * period_s;
        let newer: f64 = (0..h).map(back).sum::<f64>() / span;
        let older: f64 = (h..2 * h).map(back).sum::<f64>() / span;
        let a = ((newer - older) / span).clamp(-accel_pps2.abs(), accel_pps2.abs());
        (newer + a * span / 2.0, a)
    }

    /// End a finished controlled stop so the axis accepts the FIFO again.
    pub fn end_stop(&mut self) {
        if self.stopping && !self.braking {
            self.stopping = false;
        }
    }

    /// Run one board period of `period_s` [s] in `substeps` interpolation steps; returns
    /// true when it raised a new alarm.
    pub fn step(&mut self, drive: Drive, period_s: f64, substeps: u32) -> bool {
        if self.alarm != 0 {
            self.increment = 0;
            return false;
        }
        let increment = match drive {
            _ if self.stopping => self.stop_increment(period_s),
            Drive::Stop {
                accel_pps2,
                jerk_pps3,
            } => {
                self.begin_stop(accel_pps2, jerk_pps3, period_s);
                self.stop_increment(period_s)
            }
            Drive::Hold => 0,
            Drive::Increment(inc) => {
                let velocity = inc.unsigned_abs() as f64 / period_s;
                if velocity > self.settings.max_velocity_pps {
                    return self.raise(alarm::OVERSPEED);
                }
                inc
            }
        };
        // Interpolate the increment over the sub-steps exactly (integer partial sums), and
        // move the motor towards the command through the lag.
        let n = i128::from(substeps.max(1));
        let dt = period_s / n as f64;
        let follow = if self.settings.lag_s > 0.0 {
            1.0 - (-dt / self.settings.lag_s).exp()
        } else {
            1.0
        };
        let start = self.commanded;
        for k in 1..=n {
            self.commanded = start + (i128::from(increment) * k / n) as i64;
            self.motor += (self.commanded as f64 - self.motor) * follow;
            if !self.encoder_stuck {
                self.encoder = self.motor.round() as i64;
            }
        }
        self.recent[self.recent_n % RECENT] = increment;
        self.recent_n += 1;
        self.increment = increment;
        if increment > 0 && self.encoder >= self.settings.limit_pos {
            return self.raise(alarm::LIMIT_POS);
        }
        if increment < 0 && self.encoder <= self.settings.limit_neg {
            return self.raise(alarm::LIMIT_NEG);
        }
        if (self.commanded - self.encoder).abs() > self.settings.following_error_limit {
            return self.raise(alarm::FOLLOWING_ERROR);
        }
        false
    }

    /// The next period of the brake: the pulses to where it is at the period's end.
    fn stop_increment(&mut self, period_s: f64) -> i64 {
        if !self.braking {
            return 0;
        }
        self.brake_t += period_s;
        let target = if self.brake_t >= self.brake.duration() {
            self.braking = false;
            self.brake.stop_position()
        } else {
            self.brake.at(self.brake_t).0
        };
        let increment = target.round() as i64 - self.brake_emitted;
        self.brake_emitted += increment;
        increment
    }

    /// Status bits, [`axis_status`] (without the FIFO bits, which the board adds).
    pub fn status(&self) -> u32 {
        let mut s = 0;
        if self.alarm == 0 {
            s |= axis_status::SERVO_ON;
        } else {
            s |= axis_status::ALARM;
        }
        if self.encoder >= self.settings.limit_pos {
            s |= axis_status::LIMIT_POS;
        }
        if self.encoder <= self.settings.limit_neg {
            s |= axis_status::LIMIT_NEG;
        }
        if self.increment != 0 {
            s |= axis_status::MOVING;
        }
        if self.stopping {
            s |= axis_status::STOPPING;
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> ServoSettings {
        ServoSettings {
            max_velocity_pps: 100_000.0,
            stop_deceleration_pps2: 500_000.0,
            stop_jerk_pps3: 5_000_000.0,
            lag_s: 0.004,
            following_error_limit: 2_000,
            limit_pos: 50_000,
            limit_neg: -50_000,
            initial: 0,
        }
    }

    #[test]
    fn increments_are_executed_exactly_with_lag() {
        let mut axis = ServoAxis::new(settings());
        for _ in 0..50 {
            assert!(!axis.step(Drive::Increment(333), 0.01, 10));
        }
        assert_eq!(axis.commanded(), 50 * 333);
        // Steady velocity 33 300 pulse/s through a 4 ms lag: about 133 pulses behind.
        let lag = axis.commanded() - axis.encoder();
        assert!((100..170).contains(&lag), "{lag}");
        for _ in 0..50 {
            axis.step(Drive::Hold, 0.01, 10);
        }
        assert_eq!(axis.encoder(), axis.commanded());
    }

    #[test]
    fn overspeed_raises_the_alarm_and_stops() {
        let mut axis = ServoAxis::new(settings());
        assert!(axis.step(Drive::Increment(1_001), 0.01, 10)); // 100 100 pulse/s
        assert_eq!(axis.alarm(), alarm::OVERSPEED);
        assert_eq!(axis.commanded(), 0);
        assert!(!axis.step(Drive::Increment(10), 0.01, 10));
        assert_eq!(axis.commanded(), 0);
        axis.clear_alarm();
        assert!(!axis.step(Drive::Increment(1_000), 0.01, 10));
        assert_eq!(axis.commanded(), 1_000);
    }

    #[test]
    fn stuck_encoder_ends_in_a_following_error_alarm() {
        let mut axis = ServoAxis::new(settings());
        axis.encoder_stuck = true;
        let mut alarmed = false;
        for _ in 0..10 {
            alarmed |= axis.step(Drive::Increment(500), 0.01, 10);
        }
        assert!(alarmed);
        assert_eq!(axis.alarm(), alarm::FOLLOWING_ERROR);
    }

    #[test]
    fn limit_switch_stops_motion_into_it() {
        let mut axis = ServoAxis::new(ServoSettings {
            initial: 49_000,
            ..settings()
        });
        let mut periods = 0;
        while !axis.step(Drive::Increment(200), 0.01, 10) {
            periods += 1;
            assert!(periods < 20);
        }
        assert_eq!(axis.alarm(), alarm::LIMIT_POS);
        assert!(axis.status() & axis_status::LIMIT_POS != 0);
        axis.clear_alarm();
        // Moving away from the switch is allowed.
        assert!(!axis.step(Drive::Increment(-200), 0.01, 10));
    }
}
