//! The hand's signals (`[hand]`): which digital output switches the vacuum valve, which input
//! senses a held wafer and how long it takes to settle, and which output switches the
//! mapping sensor. The controller uses them for GET, PUT and MAP; the simulated board drives
//! its simulated cell from the same outputs.

use serde::Deserialize;

use crate::ConfigError;

/// Highest digital input or output number.
const MAX_IO: u8 = 31;

/// The hand's signals.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandConfig {
    /// Output that opens the vacuum valve (0..=31).
    pub vacuum_output: u8,
    /// Input asserted while the vacuum holds a wafer (0..=31).
    pub vacuum_input: u8,
    /// Time the vacuum sensor needs to follow the valve [s] (> 0): a check waits this long
    /// for the expected level before it fails.
    pub vacuum_settle_s: f64,
    /// Output that switches the mapping sensor on (0..=31).
    pub mapping_output: u8,
}

impl Default for HandConfig {
    fn default() -> Self {
        HandConfig {
            vacuum_output: 0,
            vacuum_input: 0,
            vacuum_settle_s: 0.5,
            mapping_output: 1,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct RawHand {
    vacuum_output: u8,
    vacuum_input: u8,
    vacuum_settle_ms: f64,
    mapping_output: u8,
}

impl Default for RawHand {
    fn default() -> Self {
        let d = HandConfig::default();
        RawHand {
            vacuum_output: d.vacuum_output,
            vacuum_input: d.vacuum_input,
            vacuum_settle_ms: d.vacuum_settle_s * 1000.0,
            mapping_output: d.mapping_output,
        }
    }
}

impl RawHand {
    pub(crate) fn into_hand(self, file: &str) -> Result<HandConfig, ConfigError> {
        let invalid = |key: &str, reason: String| ConfigError::Invalid {
            file: file.to_string(),
            key: format!("hand.{key}"),
            reason,
        };
        for (key, n) in [
            ("vacuum_output", self.vacuum_output),
            ("vacuum_input", self.vacuum_input),
            ("mapping_output", self.mapping_output),
        ] {
            if n > MAX_IO {
                return Err(invalid(
                    key,
                    format!("{n} does not exist; use 0 to {MAX_IO}"),
                ));
            }
        }
        if self.mapping_output == self.vacuum_output {
            return Err(invalid(
                "mapping_output",
                format!(
                    "{} is the vacuum valve's output too; give the mapping sensor its own",
                    self.mapping_output
                ),
            ));
        }
        if !(self.vacuum_settle_ms.is_finite()
            && self.vacuum_settle_ms > 0.0
            && self.vacuum_settle_ms <= 10_000.0)
        {
            return Err(invalid(
                "vacuum_settle_ms",
                format!(
                    "{} is out of range; use more than 0 and at most 10000 [ms]",
                    self.vacuum_settle_ms
                ),
            ));
        }
        Ok(HandConfig {
            vacuum_output: self.vacuum_output,
            vacuum_input: self.vacuum_input,
            vacuum_settle_s: self.vacuum_settle_ms / 1000.0,
            mapping_output: self.mapping_output,
        })
    }
}
