//! The simulated board's digital I/O: outputs are applied as the host writes them; inputs
//! come from simulated sensors (a vacuum sensor per hand that follows "valve on and a wafer
//! on the hand" after a delay, interlocks held asserted, the E-stop button) and from
//! injected faults (E-stop, inverted inputs). No allocation per period.

/// A vacuum hand: valve output and the vacuum-sensed input that follows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Vacuum {
    /// Output bit of the valve.
    pub valve_output: u8,
    /// Input bit of the vacuum sensor.
    pub sensor_input: u8,
    /// Periods from valve on (with a wafer) to vacuum sensed, and from valve off (or the
    /// wafer gone) to released \[periods\].
    pub delay_periods: u32,
    /// Whether a wafer lies on the hand (without one, vacuum is never sensed). Fixed by the
    /// configuration, or driven every period by the simulated cell ([`SimIo::set_wafer`]).
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
    /// Periods each hand's vacuum (valve on and a wafer there) has been in its current state.
    held_periods: [u32; MAX_VACUUM],
    held: [bool; MAX_VACUUM],
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
            held_periods: [0; MAX_VACUUM],
            held: [false; MAX_VACUUM],
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
            // The sensor follows "vacuum holds a wafer" after the delay; with a fixed wafer
            // flag that is the valve itself.
            let on = outputs & (1 << (v.valve_output & 31)) != 0 && v.wafer;
            if on != self.held[i] {
                self.held[i] = on;
                self.held_periods[i] = 0;
            }
            self.held_periods[i] = self.held_periods[i].saturating_add(1);
            if self.held_periods[i] >= v.delay_periods {
                self.sensed[i] = on;
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

    /// Every vacuum sensor reads what it senses now, without its delay (a board that
    /// restarts under a vacuum that has held all along): "valve on in `outputs` and a wafer
    /// there".
    pub fn settle(&mut self, outputs: u32) {
        for (i, v) in self.vacuum.iter().enumerate() {
            let Some(v) = v else { continue };
            let on = outputs & (1 << (v.valve_output & 31)) != 0 && v.wafer;
            self.held[i] = on;
            self.held_periods[i] = v.delay_periods;
            self.sensed[i] = on;
        }
    }

    /// The vacuum hand whose valve is output `valve_output` and whose sensor is input
    /// `sensor_input`; added with `delay_periods` and no wafer when there is none. `None`
    /// when it is missing and all [`MAX_VACUUM`] hands are taken.
    pub fn ensure_vacuum(
        &mut self,
        valve_output: u8,
        sensor_input: u8,
        delay_periods: u32,
    ) -> Option<usize> {
        let same = |v: &Option<Vacuum>| {
            v.is_some_and(|v| v.valve_output == valve_output && v.sensor_input == sensor_input)
        };
        if let Some(i) = self.vacuum.iter().position(same) {
            return Some(i);
        }
        let i = self.vacuum.iter().position(Option::is_none)?;
        self.vacuum[i] = Some(Vacuum {
            valve_output,
            sensor_input,
            delay_periods,
            wafer: false,
        });
        Some(i)
    }

    /// Put a wafer on vacuum hand `index` or take it away (ignored for a hand that does not
    /// exist); the sensor follows after the hand's delay.
    pub fn set_wafer(&mut self, index: usize, wafer: bool) {
        if let Some(Some(v)) = self.vacuum.get_mut(index) {
            v.wafer = wafer;
        }
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

    #[test]
    fn a_wafer_arriving_under_an_open_valve_is_sensed_after_the_delay() {
        let mut io = SimIo::new(&IoSettings::default());
        assert_eq!(io.ensure_vacuum(0, 2, 3), Some(0));
        assert_eq!(io.ensure_vacuum(0, 2, 9), Some(0), "found, not added twice");
        for _ in 0..10 {
            assert_eq!(io.step(1) & 0b100, 0, "valve on, no wafer: no vacuum");
        }
        io.set_wafer(0, true);
        assert_eq!(io.step(1) & 0b100, 0);
        assert_eq!(io.step(1) & 0b100, 0);
        assert_eq!(io.step(1) & 0b100, 0b100);
        io.set_wafer(0, false);
        io.step(1);
        io.step(1);
        assert_eq!(io.step(1) & 0b100, 0);
        io.set_wafer(7, true); // no such hand: ignored
        for k in 1..MAX_VACUUM {
            assert_eq!(io.ensure_vacuum(k as u8, 0, 1), Some(k));
        }
        assert_eq!(io.ensure_vacuum(9, 9, 1), None, "all hands taken");
    }
}
