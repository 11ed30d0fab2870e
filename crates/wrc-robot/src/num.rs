//! Lengths and angles as the controller writes them (protocol lines, station and wafer-map
//! files): at most 3 decimals — 1 µm, 0.001° — and no trailing zeros.

use std::fmt;

/// A number with at most 3 decimals and no trailing zeros (`90`, `12.5`, `-0.001`); enough
/// for 1 µm / 0.001° and short on the wire. Never writes `-0`. Formats without allocating.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if !self.0.is_finite() {
            return write!(f, "{}", self.0);
        }
        // Saturating cast: positions are far below the ±9.2e15 where this would clip.
        let milli = (self.0 * 1000.0).round() as i64;
        let sign = if milli < 0 { "-" } else { "" };
        let abs = milli.unsigned_abs();
        let (int, mut frac) = (abs / 1000, abs % 1000);
        write!(f, "{sign}{int}")?;
        if frac != 0 {
            let mut digits = 3;
            while frac % 10 == 0 {
                frac /= 10;
                digits -= 1;
            }
            write!(f, ".{frac:0digits$}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_short_and_never_negative_zero() {
        let cases = [
            (0.0, "0"),
            (-0.0, "0"),
            (-0.0004, "0"),
            (-0.0005, "-0.001"),
            (1.5, "1.5"),
            (1.05, "1.05"),
            (-123.456789, "-123.457"),
            (1e6, "1000000"),
        ];
        for (v, s) in cases {
            assert_eq!(Num(v).to_string(), s, "{v}");
        }
    }
}
