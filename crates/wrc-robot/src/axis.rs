//! One axis of the robot: its name, role in the arm, unit, pulse scaling, travel and limits.

use std::fmt;

/// Physical unit of an axis position.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// Rotary axis, positions in degrees [deg].
    Deg,
    /// Linear axis, positions in millimetres [mm].
    Mm,
}

impl Unit {
    /// The unit's short name as written in configuration and output (`deg`, `mm`).
    pub fn as_str(self) -> &'static str {
        match self {
            Unit::Deg => "deg",
            Unit::Mm => "mm",
        }
    }
}

/// What an axis does in the planar arm's kinematics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisRole {
    /// J1: rotates the first link about the base [deg].
    Shoulder,
    /// J2: rotates the second link relative to the first [deg].
    Elbow,
    /// J3: rotates the hand relative to the second link, so it holds the hand's yaw [deg].
    Wrist,
    /// Vertical lift of the whole arm [mm].
    Z,
    /// An axis outside the arm's kinematics (a track, a second hand, …); moved in joint space only.
    Auxiliary,
}

impl AxisRole {
    /// The role's name as written in configuration.
    pub fn as_str(self) -> &'static str {
        match self {
            AxisRole::Shoulder => "shoulder",
            AxisRole::Elbow => "elbow",
            AxisRole::Wrist => "wrist",
            AxisRole::Z => "z",
            AxisRole::Auxiliary => "auxiliary",
        }
    }
}

/// A name of 1 to `N` ASCII letters, digits, `_` or `-` (so also a safe file name), stored
/// inline so that errors, requests and reports that carry it never allocate.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct InlineName<const N: usize> {
    bytes: [u8; N],
    len: u8,
}

/// An axis name of at most [`AxisName::MAX_LEN`] (15) characters.
pub type AxisName = InlineName<15>;

impl<const N: usize> InlineName<N> {
    /// Longest accepted name, in bytes.
    pub const MAX_LEN: usize = N;

    /// Make a name from `text`: 1 to `N` characters of ASCII letters, digits, `_` or `-`.
    /// Returns `None` for anything else.
    pub fn new(text: &str) -> Option<Self> {
        let ok = !text.is_empty()
            && text.len() <= N
            && text.len() <= usize::from(u8::MAX)
            && text
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
        if !ok {
            return None;
        }
        let mut bytes = [0u8; N];
        bytes[..text.len()].copy_from_slice(text.as_bytes());
        Some(InlineName {
            bytes,
            len: text.len() as u8,
        })
    }

    /// The name as a string slice.
    pub fn as_str(&self) -> &str {
        // The constructor only accepts ASCII, so this never fails.
        std::str::from_utf8(&self.bytes[..self.len as usize]).unwrap_or("?")
    }
}

impl<const N: usize> fmt::Display for InlineName<N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl<const N: usize> fmt::Debug for InlineName<N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.as_str())
    }
}

/// Kinematic limits of one axis, in the axis unit ([deg] or [mm]) per second powers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Maximum speed [unit/s].
    pub max_velocity: f64,
    /// Maximum acceleration [unit/s²].
    pub max_acceleration: f64,
    /// Maximum jerk [unit/s³].
    pub max_jerk: f64,
}

/// One axis of the robot.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// Name used in commands and output (`j1`, `z`, …).
    pub name: AxisName,
    /// Role in the arm's kinematics.
    pub role: AxisRole,
    /// Unit of positions.
    pub unit: Unit,
    /// Motor pulses per unit: encoder counts per motor turn × gear ratio / unit per output turn
    /// [pulse/deg] or [pulse/mm].
    pub pulses_per_unit: f64,
    /// Lower soft limit [unit].
    pub min: f64,
    /// Upper soft limit [unit].
    pub max: f64,
    /// Velocity, acceleration and jerk limits.
    pub limits: Limits,
    /// Home position [unit].
    pub home: f64,
}

impl Axis {
    /// Position in units of a pulse count.
    #[inline]
    pub fn pulses_to_units(&self, pulses: i64) -> f64 {
        pulses as f64 / self.pulses_per_unit
    }

    /// Pulse count nearest to a position in units.
    #[inline]
    pub fn units_to_pulses(&self, units: f64) -> i64 {
        (units * self.pulses_per_unit).round() as i64
    }

    /// Whether `units` lies within the soft limits (inclusive, with a tolerance of half a pulse).
    #[inline]
    pub fn within_limits(&self, units: f64) -> bool {
        let tol = 0.5 / self.pulses_per_unit;
        units >= self.min - tol && units <= self.max + tol
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_names_are_checked() {
        assert_eq!(AxisName::new("j1").unwrap().as_str(), "j1");
        assert!(AxisName::new("").is_none());
        assert!(AxisName::new("a name").is_none());
        assert!(AxisName::new("sixteen_chars_xx").is_none());
        assert!(AxisName::new("ünïcode").is_none());
    }

    #[test]
    fn pulse_conversion_rounds_to_nearest() {
        let axis = Axis {
            name: AxisName::new("j1").unwrap(),
            role: AxisRole::Shoulder,
            unit: Unit::Deg,
            pulses_per_unit: 1000.0,
            min: -10.0,
            max: 10.0,
            limits: Limits {
                max_velocity: 1.0,
                max_acceleration: 1.0,
                max_jerk: 1.0,
            },
            home: 0.0,
        };
        assert_eq!(axis.units_to_pulses(1.2344), 1234);
        assert_eq!(axis.units_to_pulses(-1.2346), -1235);
        assert!((axis.pulses_to_units(1500) - 1.5).abs() < 1e-12);
        assert!(axis.within_limits(10.0004));
        assert!(!axis.within_limits(10.001));
    }
}
