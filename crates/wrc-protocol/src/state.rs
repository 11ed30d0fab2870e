//! The controller state as clients see it, in `STATUS`, `EVT STATE` and the simulator
//! datagram.

use core::fmt;

/// The controller's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[non_exhaustive]
pub enum State {
    /// Standing still and ready for a command.
    #[default]
    Idle,
    /// A motion is running.
    Moving,
    /// A motion is decelerating to a stop (after `STOP` or an alarm).
    Stopping,
    /// Stopped by an alarm; `RESET` clears it once its cause is gone.
    Error,
    /// Emergency stop (`ESTOP` or the E-stop input); `RESET` clears it once released.
    Estop,
    /// A motion was held (`HOLD`): at rest on its path, `RESUME` continues it, `STOP`
    /// abandons it.
    Held,
}

impl State {
    /// Every state, in wire-number order.
    pub const ALL: &'static [State] = &[
        State::Idle,
        State::Moving,
        State::Stopping,
        State::Error,
        State::Estop,
        State::Held,
    ];

    /// The state's name on the wire (`IDLE`, `MOVING`, `STOPPING`, `ERROR`, `ESTOP`, `HELD`).
    pub fn as_str(self) -> &'static str {
        match self {
            State::Idle => "IDLE",
            State::Moving => "MOVING",
            State::Stopping => "STOPPING",
            State::Error => "ERROR",
            State::Estop => "ESTOP",
            State::Held => "HELD",
        }
    }

    /// The state's number in the simulator datagram (0 `IDLE` … 4 `ESTOP`, 5 `HELD`).
    pub fn to_u8(self) -> u8 {
        match self {
            State::Idle => 0,
            State::Moving => 1,
            State::Stopping => 2,
            State::Error => 3,
            State::Estop => 4,
            State::Held => 5,
        }
    }

    /// The state with datagram number `n`, if any.
    pub fn from_u8(n: u8) -> Option<State> {
        State::ALL.get(usize::from(n)).copied()
    }
}

impl fmt::Display for State {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_round_trip() {
        for &s in State::ALL {
            assert_eq!(State::from_u8(s.to_u8()), Some(s));
        }
        assert_eq!(State::from_u8(6), None);
        assert_eq!(State::Estop.to_string(), "ESTOP");
    }
}
