//! Number formatting for protocol lines: at most 3 decimals, no trailing zeros.

/// `v` with at most 3 decimals and no trailing zeros (`10`, `294.449`, `-0.5`); `-0` is `0`.
pub(crate) fn fmt_num(v: f64) -> String {
    let mut s = format!("{v:.3}");
    if s.contains('.') {
        while s.ends_with('0') {
            s.pop();
        }
        if s.ends_with('.') {
            s.pop();
        }
    }
    if s == "-0" {
        s = "0".into();
    }
    s
}

pub(crate) use wrc_robot::wrap180;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_have_at_most_three_decimals_and_no_trailing_zeros() {
        assert_eq!(fmt_num(10.0), "10");
        assert_eq!(fmt_num(294.4486), "294.449");
        assert_eq!(fmt_num(-0.5), "-0.5");
        assert_eq!(fmt_num(-0.0001), "0");
        assert_eq!(fmt_num(0.1 + 0.2), "0.3");
        assert_eq!(fmt_num(1e6), "1000000");
    }

    #[test]
    fn angles_wrap_into_the_half_open_interval() {
        assert_eq!(wrap180(180.0), 180.0);
        assert_eq!(wrap180(-180.0), 180.0);
        assert_eq!(wrap180(190.0), -170.0);
        assert_eq!(wrap180(-30.0), -30.0);
    }
}
