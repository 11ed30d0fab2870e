//! Settings of the velocity generator: pulse period, profile, speed override and the
//! Cartesian limits of straight-line motion.

use crate::error::SettingsError;

/// Longest accepted mask of the paper profile, in periods (also the size of its
/// preallocated delay line).
pub const MAX_PAPER_MASK: usize = 1000;

/// How a move's pulses are smoothed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Profile {
    /// Default: the constant-velocity stream through two cascaded moving-average filters of
    /// lengths V/A and A/J — the time-optimal rest-to-rest jerk-limited (double-S) profile.
    Fir,
    /// The paper's method: a triangular mask K(t) (eq. 1) of `mask_len` periods convolved
    /// with the per-period input pulses (eq. 2), normalised to lose no pulse.
    Paper {
        /// n, the number of acceleration/deceleration sections [periods]; even, 2 or more.
        mask_len: usize,
    },
}

impl Profile {
    /// The profile's name as written in configuration and on the command line.
    pub fn name(&self) -> &'static str {
        match self {
            Profile::Fir => "fir",
            Profile::Paper { .. } => "paper",
        }
    }

    /// The paper profile from either of its parameters: the mask length `n` [periods] or the
    /// acceleration constant `a` of eq. (1). A mask normalised to unit gain (so no pulse is
    /// lost) has A = 4/n², so A and n are one degree of freedom: give one, or both consistent.
    pub fn paper(n: Option<f64>, a: Option<f64>) -> Result<Profile, SettingsError> {
        let from_a = |a: f64| -> Result<usize, SettingsError> {
            if !a.is_finite() || a <= 0.0 || a > 1.0 {
                return Err(SettingsError::new(
                    "motion.paper_a",
                    format!("must be a number in (0, 1], got {a}"),
                ));
            }
            // n = 2/sqrt(A), rounded to the nearest even number.
            Ok(((1.0 / a.sqrt()).round() as usize * 2).max(2))
        };
        let mask_len = match (n, a) {
            (None, None) => 20,
            (None, Some(a)) => from_a(a)?,
            (Some(n), a) => {
                if !n.is_finite()
                    || n.fract() != 0.0
                    || n < 2.0
                    || n > MAX_PAPER_MASK as f64
                    || n % 2.0 != 0.0
                {
                    return Err(SettingsError::new(
                        "motion.paper_n",
                        format!("must be an even whole number of periods from 2 to {MAX_PAPER_MASK}, got {n}"),
                    ));
                }
                let n = n as usize;
                if let Some(a) = a {
                    let want = 4.0 / (n * n) as f64;
                    if (a - want).abs() > 1e-9 * want.max(1.0) {
                        return Err(SettingsError::new(
                            "motion.paper_a",
                            format!(
                                "{a} does not match paper_n = {n}: a unit-gain mask of n sections has A = 4/n² = {want}; give only one of them"
                            ),
                        ));
                    }
                }
                n
            }
        };
        Ok(Profile::Paper { mask_len })
    }
}

/// Limits of the tool centre point along a straight line (on top of every joint's limits).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineLimits {
    /// Path speed [mm/s].
    pub max_speed_mm_s: f64,
    /// Path acceleration [mm/s²].
    pub max_accel_mm_s2: f64,
    /// Path jerk [mm/s³].
    pub max_jerk_mm_s3: f64,
}

/// Everything the velocity generator needs besides the robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionSettings {
    /// Pulse period, the time between two pulse batches [s] (10 ms in the paper).
    pub period_s: f64,
    /// Smoothing profile.
    pub profile: Profile,
    /// Speed override [%], 1 to 100: scales velocity by p, acceleration by p² and jerk by p³,
    /// which stretches a move in time without changing its shape.
    pub speed_pct: f64,
    /// Straight-line TCP limits.
    pub line: LineLimits,
}

impl Default for MotionSettings {
    fn default() -> Self {
        MotionSettings {
            period_s: 0.010,
            profile: Profile::Fir,
            speed_pct: 100.0,
            line: LineLimits {
                max_speed_mm_s: 500.0,
                max_accel_mm_s2: 2000.0,
                max_jerk_mm_s3: 20000.0,
            },
        }
    }
}

impl MotionSettings {
    /// Check every number; `key` in the error names the configuration setting.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let p = self.period_s;
        if !p.is_finite() || !(0.0001..=1.0).contains(&p) {
            return Err(SettingsError::new(
                "motion.period_ms",
                format!("must be from 0.1 to 1000 ms, got {} ms", p * 1000.0),
            ));
        }
        check_speed_pct(self.speed_pct)?;
        for (key, v) in [
            ("motion.line_max_speed_mm_s", self.line.max_speed_mm_s),
            ("motion.line_max_accel_mm_s2", self.line.max_accel_mm_s2),
            ("motion.line_max_jerk_mm_s3", self.line.max_jerk_mm_s3),
        ] {
            if !v.is_finite() || v <= 0.0 {
                return Err(SettingsError::new(
                    key,
                    format!("must be a number greater than 0, got {v}"),
                ));
            }
        }
        if let Profile::Paper { mask_len } = self.profile {
            if !(2..=MAX_PAPER_MASK).contains(&mask_len) || mask_len % 2 != 0 {
                return Err(SettingsError::new(
                    "motion.paper_n",
                    format!("must be an even whole number of periods from 2 to {MAX_PAPER_MASK}, got {mask_len}"),
                ));
            }
        }
        Ok(())
    }
}

/// Check a speed override [%]: a number from 1 to 100.
pub fn check_speed_pct(pct: f64) -> Result<(), SettingsError> {
    if !pct.is_finite() || !(1.0..=100.0).contains(&pct) {
        return Err(SettingsError::new(
            "motion.speed_pct",
            format!("must be from 1 to 100 %, got {pct}"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_parameters_are_one_degree_of_freedom() {
        assert_eq!(
            Profile::paper(None, None).unwrap(),
            Profile::Paper { mask_len: 20 }
        );
        assert_eq!(
            Profile::paper(Some(10.0), None).unwrap(),
            Profile::Paper { mask_len: 10 }
        );
        assert_eq!(
            Profile::paper(None, Some(0.04)).unwrap(),
            Profile::Paper { mask_len: 10 }
        );
        assert_eq!(
            Profile::paper(Some(10.0), Some(0.04)).unwrap(),
            Profile::Paper { mask_len: 10 }
        );
        let err = Profile::paper(Some(10.0), Some(0.5)).unwrap_err();
        assert_eq!(err.key, "motion.paper_a");
        assert!(Profile::paper(Some(7.0), None).is_err());
        assert!(Profile::paper(Some(f64::NAN), None).is_err());
        assert!(Profile::paper(None, Some(-1.0)).is_err());
    }

    #[test]
    fn bad_settings_name_their_key() {
        let mut s = MotionSettings::default();
        assert!(s.validate().is_ok());
        s.period_s = 0.0;
        assert_eq!(s.validate().unwrap_err().key, "motion.period_ms");
        s = MotionSettings {
            speed_pct: 0.0,
            ..Default::default()
        };
        assert_eq!(s.validate().unwrap_err().key, "motion.speed_pct");
        s = MotionSettings::default();
        s.line.max_jerk_mm_s3 = f64::INFINITY;
        assert_eq!(s.validate().unwrap_err().key, "motion.line_max_jerk_mm_s3");
    }
}
