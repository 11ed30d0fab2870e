//! The simulated board's digital I/O: outputs are applied as the host writes them; inputs
//! come from simulated sensors (a vacuum sensor per hand that follows its valve after a
//! delay when a wafer is on the hand, interlocks held asserted, the E-stop button) and from
//! injected faults (E-stop, inverted inputs). No allocation per period.

/// A vacuum hand: valve output and the vacuum-sensed input that follows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Vacuum {
    /// Output bit of the valve.
    pub valve_output: u8,
    /// Input bit of the vacuum sensor.
    pub sensor_input: u8,
    /// Periods from valve on to vacuum sensed (and from valve off to released) [periods].
    pub delay_periods: u32,
    /// Whether a wafer lies on the hand (without one, vacuum is never sensed).
    pub wafer: bool,
}

/// Maximum vacuum hands simulated per board.
pub const MAX_VACUUM: usize = 4;

/// I/O map of the simulated board.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct IoSettings {
    /// Input bit of the E-stop button (asserted = pressed), if any.
    pub estop_input: Option<u8>,
    /// Inputs held asserted (interlocks such as "door closed").
    pub interlock_inputs: u32,
    /// Vacuum hands (at most [`MAX_VACUUM`]).
    pub vacuum: Vec<Vacuum>,
}

/// State of the simulated I/O.
#[derive(Debug, Clone)]
pub struct SimIo {
    estop_input: Option<u8>,
    interlocks: u32,
    vacuum: [Option<Vacuum>; MAX_VACUUM],
    /// Periods each vacuum valve has been in its current state.
    valve_periods: [u32; MAX_VACUUM],
    valve_state: [bool; MAX_VACUUM],
    sensed: [bool; MAX_VACUUM],
    /// Injected: E-stop pressed.
    pub estop_pressed: bool,
    /// Injected: inputs inverted (XOR mask).
    pub flipped: u32,
}

impl SimIo {
    /// I/O per `settings`, vacuum off.
    pub fn new(settings: &IoSettings) -> SimIo {
        let mut vacuum = [None; MAX_VACUUM];
        for (slot, v) in vacuum.iter_mut().zip(&settings.vacuum) {
            *slot = Some(*v);
        }
        SimIo {
            estop_input: settings.estop_input,
            interlocks: settings.interlock_inputs,
            vacuum,
            valve_periods: [0; MAX_VACUUM],
            valve_state: [false; MAX_VACUUM],
            sensed: [false; MAX_VACUUM],
            estop_pressed: false,
            flipped: 0,
        }
    }

    /// Advance one period with the host's `outputs`; returns the inputs.
    pub fn step(&mut self, outputs: u32) -> u32 {
        let mut inputs = self.interlocks;
        for (i, v) in self.vacuum.iter().enumerate() {
            let Some(v) = v else { continue };
            let on = outputs & (1 << (v.valve_output & 31)) != 0;
            if on != self.valve_state[i] {
                self.valve_state[i] = on;
                self.valve_periods[i] = 0;
            }
            self.valve_periods[i] = self.valve_periods[i].saturating_add(1);
            if self.valve_periods[i] >= v.delay_periods {
                self.sensed[i] = on && v.wafer;
            }
            if self.sensed[i] {
                inputs |= 1 << (v.sensor_input & 31);
            }
        }
        if let (Some(bit), true) = (self.estop_input, self.estop_pressed) {
            inputs |= 1 << (bit & 31);
        }
        inputs ^ self.flipped
    }

    /// Whether `inputs` show the E-stop asserted.
    pub fn estop(&self, inputs: u32) -> bool {
        self.estop_input
            .is_some_and(|bit| inputs & (1 << (bit & 31)) != 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vacuum_follows_the_valve_after_the_delay() {
        let mut io = SimIo::new(&IoSettings {
            estop_input: Some(15),
            interlock_inputs: 1 << 14,
            vacuum: vec![Vacuum {
                valve_output: 0,
                sensor_input: 0,
                delay_periods: 3,
                wafer: true,
            }],
        });
        assert_eq!(io.step(0), 1 << 14);
        assert_eq!(io.step(1) & 1, 0);
        assert_eq!(io.step(1) & 1, 0);
        assert_eq!(io.step(1) & 1, 1);
        io.estop_pressed = true;
        let inputs = io.step(1);
        assert!(io.estop(inputs));
        io.flipped = 1 << 14;
        assert_eq!(io.step(1) & (1 << 14), 0);
    }
}
