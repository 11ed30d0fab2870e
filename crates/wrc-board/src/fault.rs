//! Fault injection for tests and demos: the faults a simulated board can be told to play,
//! their text form (`alarm 2`, `encoder-stuck 0 on`, `sensor-flip 5 on`, `estop on`,
//! `clear`) and their encoding in the DPRAM's fault mailbox (ignored by real hardware).

use std::fmt;
use std::str::FromStr;

use crate::dpram::Dpram;
use crate::layout::{fault, AXES_PER_BOARD};

/// A fault the simulated board plays.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// Servo amplifier alarm on an axis channel (cleared by clearing the axis's alarm).
    Alarm {
        /// Channel on the board (0..4).
        axis: u8,
    },
    /// Encoder stops counting (on) or counts again (off).
    EncoderStuck {
        /// Channel on the board (0..4).
        axis: u8,
        /// On or off.
        on: bool,
    },
    /// A digital input reads inverted (on) or normally (off).
    SensorFlip {
        /// Input bit (0..32).
        input: u8,
        /// On or off.
        on: bool,
    },
    /// The E-stop button is pressed (on) or released (off).
    Estop {
        /// On or off.
        on: bool,
    },
    /// Remove every injected fault (alarms stay until cleared by the host).
    Clear,
}

/// Fault text that does not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("bad fault {text:?}: {reason}; expected one of: alarm AXIS | encoder-stuck AXIS on|off | sensor-flip INPUT on|off | estop on|off | clear")]
pub struct FaultParseError {
    /// The text.
    pub text: String,
    /// What is wrong.
    pub reason: String,
}

impl Fault {
    /// Mailbox encoding: (code, arg0, arg1).
    pub fn encode(self) -> (u32, u32, u32) {
        match self {
            Fault::Alarm { axis } => (1, axis.into(), 1),
            Fault::EncoderStuck { axis, on } => (2, axis.into(), on.into()),
            Fault::SensorFlip { input, on } => (3, input.into(), on.into()),
            Fault::Estop { on } => (4, 0, on.into()),
            Fault::Clear => (5, 0, 0),
        }
    }

    /// Mailbox decoding; `None` for an unknown code or an argument out of range.
    pub fn decode(code: u32, arg0: u32, arg1: u32) -> Option<Fault> {
        let on = arg1 != 0;
        let axis = u8::try_from(arg0)
            .ok()
            .filter(|a| usize::from(*a) < AXES_PER_BOARD);
        Some(match code {
            1 => Fault::Alarm { axis: axis? },
            2 => Fault::EncoderStuck { axis: axis?, on },
            3 => Fault::SensorFlip {
                input: u8::try_from(arg0).ok().filter(|i| *i < 32)?,
                on,
            },
            4 => Fault::Estop { on },
            5 => Fault::Clear,
            _ => return None,
        })
    }

    /// Post the fault to a running board's mailbox; false when the board has not yet
    /// taken the previous one.
    pub fn inject(self, dpram: &Dpram) -> bool {
        let (code, a0, a1) = self.encode();
        dpram.post(fault::SEQ, fault::ACK, code, &[a0, a1])
    }
}

impl FromStr for Fault {
    type Err = FaultParseError;

    fn from_str(text: &str) -> Result<Fault, FaultParseError> {
        let err = |reason: &str| FaultParseError {
            text: text.to_string(),
            reason: reason.to_string(),
        };
        let words: Vec<&str> = text
            .split(|c: char| c.is_whitespace() || c == ':' || c == '=')
            .filter(|w| !w.is_empty())
            .collect();
        let number = |i: usize, max: u32, what: &str| -> Result<u8, FaultParseError> {
            let w = words
                .get(i)
                .ok_or_else(|| err(&format!("missing {what}")))?;
            match w.parse::<u32>() {
                Ok(n) if n < max => Ok(n as u8),
                _ => Err(err(&format!(
                    "{what} {w:?} is not a number from 0 to {}",
                    max - 1
                ))),
            }
        };
        let switch = |i: usize| -> Result<bool, FaultParseError> {
            match words.get(i).copied() {
                None | Some("on") => Ok(true),
                Some("off") => Ok(false),
                Some(w) => Err(err(&format!("{w:?} is neither on nor off"))),
            }
        };
        let fault = match words.first().copied() {
            Some("alarm") => Fault::Alarm {
                axis: number(1, AXES_PER_BOARD as u32, "axis")?,
            },
            Some("encoder-stuck") => Fault::EncoderStuck {
                axis: number(1, AXES_PER_BOARD as u32, "axis")?,
                on: switch(2)?,
            },
            Some("sensor-flip") => Fault::SensorFlip {
                input: number(1, 32, "input")?,
                on: switch(2)?,
            },
            Some("estop") => Fault::Estop { on: switch(1)? },
            Some("clear") => Fault::Clear,
            Some(other) => return Err(err(&format!("unknown fault {other:?}"))),
            None => return Err(err("empty")),
        };
        let used = match fault {
            Fault::Alarm { .. } | Fault::Estop { .. } => 2,
            Fault::Clear => 1,
            _ => 3,
        };
        if words.len() > used {
            return Err(err("too many words"));
        }
        Ok(fault)
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let on = |b: bool| if b { "on" } else { "off" };
        match *self {
            Fault::Alarm { axis } => write!(f, "alarm {axis}"),
            Fault::EncoderStuck { axis, on: o } => write!(f, "encoder-stuck {axis} {}", on(o)),
            Fault::SensorFlip { input, on: o } => write!(f, "sensor-flip {input} {}", on(o)),
            Fault::Estop { on: o } => write!(f, "estop {}", on(o)),
            Fault::Clear => write!(f, "clear"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_and_mailbox_round_trip() {
        for text in [
            "alarm 2",
            "encoder-stuck 0 on",
            "sensor-flip 31 off",
            "estop on",
            "clear",
        ] {
            let fault: Fault = text.parse().unwrap();
            assert_eq!(fault.to_string(), text);
            let (c, a, b) = fault.encode();
            assert_eq!(Fault::decode(c, a, b), Some(fault));
        }
        assert_eq!(
            "alarm:1".parse::<Fault>().unwrap(),
            Fault::Alarm { axis: 1 }
        );
        assert_eq!("estop".parse::<Fault>().unwrap(), Fault::Estop { on: true });
    }

    #[test]
    fn bad_faults_say_why() {
        for (text, why) in [
            ("alarm 4", "0 to 3"),
            ("smoke", "unknown"),
            ("estop maybe", "on nor off"),
            ("alarm", "missing"),
        ] {
            let e = text.parse::<Fault>().unwrap_err().to_string();
            assert!(e.contains(why), "{e}");
        }
        assert_eq!(Fault::decode(9, 0, 0), None);
        assert_eq!(Fault::decode(1, 7, 0), None);
    }
}
