//! One simulated servo axis: executes one period's increment, interpolated over the board's
//! sub-steps, through a first-order servo lag to the motor and its encoder; checks the
//! motor's velocity limit, the following error and the limit switches; decelerates under
//! control to a stop. Plain arithmetic, no allocation.

use wrc_board::layout::{alarm, axis_status};

/// Per-axis model parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoSettings {
    /// Motor velocity limit; a period's increment above it raises [`alarm::OVERSPEED`]
    /// [pulse/s].
    pub max_velocity_pps: f64,
    /// Deceleration of a controlled stop (watchdog, E-stop) [pulse/s²].
    pub stop_deceleration_pps2: f64,
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
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Drive {
    /// Execute this increment from the FIFO [pulse/period].
    Increment(i64),
    /// The FIFO was empty: hold the commanded position.
    Hold,
    /// Controlled stop: decelerate from the current velocity to standstill.
    Stop,
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
    /// Velocity during a controlled stop [pulse/period] and the fractional position.
    stop_velocity: f64,
    stop_position: f64,
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
            stop_velocity: 0.0,
            stop_position: 0.0,
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

    /// Whether a controlled stop is in progress.
    pub fn is_stopping(&self) -> bool {
        self.stopping
    }

    /// Raise alarm `cause`: the servo turns off and the motor stops where it is (the
    /// paper's overcurrent stop). Returns true if the axis was not alarmed before.
    pub fn raise(&mut self, cause: u32) -> bool {
        let new = self.alarm == 0;
        self.alarm |= cause;
        self.increment = 0;
        self.stopping = false;
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

    /// Start a controlled stop from the current velocity (no effect when alarmed).
    pub fn begin_stop(&mut self) {
        if self.alarm == 0 && !self.stopping {
            self.stopping = true;
            self.stop_velocity = self.increment as f64;
            self.stop_position = 0.0;
        }
    }

    /// End a finished controlled stop so the axis accepts the FIFO again.
    pub fn end_stop(&mut self) {
        if self.stopping && self.stop_velocity == 0.0 {
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
            Drive::Stop => {
                self.begin_stop();
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

    fn stop_increment(&mut self, period_s: f64) -> i64 {
        let decel = self.settings.stop_deceleration_pps2 * period_s * period_s;
        let v = self.stop_velocity;
        let next = (v.abs() - decel).max(0.0) * v.signum();
        self.stop_velocity = next;
        let before = self.stop_position.round();
        self.stop_position += next;
        (self.stop_position.round() - before) as i64
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
