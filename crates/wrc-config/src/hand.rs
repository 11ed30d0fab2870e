//! The hand's signals (`[hand]`): which digital output switches the vacuum valve, which input
//! senses a held wafer and how long it takes to settle, and which output switches the
//! mapping sensor. The controller uses them for GET, PUT and MAP; the simulated board drives
//! its simulated cell from the same outputs.
//!
//! A dual-blade robot adds `[hand.blade_b]`: a second blade on the same wrist, stacked at a
//! fixed height from the hand (`z_offset_mm`, negative: below it) and pointing the same way,
//! with its own vacuum valve and sensor.

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
    /// The second blade of a dual-blade robot; `None` for a single hand.
    pub blade_b: Option<BladeB>,
}

/// The second blade of a dual-blade robot (`[hand.blade_b]`); [`HandConfig::blade`] gives
/// the hand's signals in the same form (offset 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BladeB {
    /// Height of its wafer plane above the hand's (the TCP's) [mm]; negative: below.
    pub z_offset_mm: f64,
    /// Output that opens its vacuum valve (0..=31).
    pub vacuum_output: u8,
    /// Input asserted while its vacuum holds a wafer (0..=31).
    pub vacuum_input: u8,
}

impl Default for HandConfig {
    fn default() -> Self {
        HandConfig {
            vacuum_output: 0,
            vacuum_input: 0,
            vacuum_settle_s: 0.5,
            mapping_output: 1,
            blade_b: None,
        }
    }
}

impl HandConfig {
    /// Blades of the robot: 1, or 2 with blade B.
    pub fn blades(&self) -> usize {
        1 + usize::from(self.blade_b.is_some())
    }

    /// The signals and height of blade `index` (0: the hand, 1: blade B); `None` for a
    /// blade the robot does not have.
    pub fn blade(&self, index: usize) -> Option<BladeB> {
        match index {
            0 => Some(self.hand_signals()),
            1 => self.blade_b,
            _ => None,
        }
    }

    /// The hand's (blade A's) signals, as [`HandConfig::blade`] gives them.
    pub fn hand_signals(&self) -> BladeB {
        BladeB {
            z_offset_mm: 0.0,
            vacuum_output: self.vacuum_output,
            vacuum_input: self.vacuum_input,
        }
    }

    /// Height of blade `index`'s wafer plane above the hand's [mm] (0 for the hand, and for
    /// a blade the robot does not have).
    pub fn z_offset_mm(&self, index: usize) -> f64 {
        self.blade(index).map_or(0.0, |b| b.z_offset_mm)
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct RawHand {
    vacuum_output: u8,
    vacuum_input: u8,
    vacuum_settle_ms: f64,
    mapping_output: u8,
    blade_b: Option<RawBladeB>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBladeB {
    z_offset_mm: f64,
    vacuum_output: u8,
    vacuum_input: u8,
}

impl Default for RawHand {
    fn default() -> Self {
        let d = HandConfig::default();
        RawHand {
            vacuum_output: d.vacuum_output,
            vacuum_input: d.vacuum_input,
            vacuum_settle_ms: d.vacuum_settle_s * 1000.0,
            mapping_output: d.mapping_output,
            blade_b: None,
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
        let blade_io = self.blade_b.as_ref().map_or([None, None], |b| {
            [
                Some(("blade_b.vacuum_output", b.vacuum_output)),
                Some(("blade_b.vacuum_input", b.vacuum_input)),
            ]
        });
        let signals = [
            Some(("vacuum_output", self.vacuum_output)),
            Some(("vacuum_input", self.vacuum_input)),
            Some(("mapping_output", self.mapping_output)),
        ];
        for (key, n) in signals.into_iter().chain(blade_io).flatten() {
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
        let blade_b = match self.blade_b {
            None => None,
            Some(b) => {
                if b.vacuum_output == self.vacuum_output || b.vacuum_output == self.mapping_output {
                    return Err(invalid(
                        "blade_b.vacuum_output",
                        format!(
                            "{} is the hand's vacuum valve or mapping sensor output too; give blade B's valve its own",
                            b.vacuum_output
                        ),
                    ));
                }
                if b.vacuum_input == self.vacuum_input {
                    return Err(invalid(
                        "blade_b.vacuum_input",
                        format!(
                            "{} is the hand's vacuum sensor input too; give blade B's sensor its own",
                            b.vacuum_input
                        ),
                    ));
                }
                if !(b.z_offset_mm.is_finite()
                    && b.z_offset_mm.abs() >= 5.0
                    && b.z_offset_mm.abs() <= 200.0)
                {
                    return Err(invalid(
                        "blade_b.z_offset_mm",
                        format!(
                            "{} is out of range; the blades are 5 to 200 mm apart (negative: blade B below the hand)",
                            b.z_offset_mm
                        ),
                    ));
                }
                Some(BladeB {
                    z_offset_mm: b.z_offset_mm,
                    vacuum_output: b.vacuum_output,
                    vacuum_input: b.vacuum_input,
                })
            }
        };
        Ok(HandConfig {
            vacuum_output: self.vacuum_output,
            vacuum_input: self.vacuum_input,
            vacuum_settle_s: self.vacuum_settle_ms / 1000.0,
            mapping_output: self.mapping_output,
            blade_b,
        })
    }
}
