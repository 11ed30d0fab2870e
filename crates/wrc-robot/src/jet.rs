//! Jets: truncated Taylor series of order 3 — a value and its first three derivatives with
//! respect to one parameter — with the arithmetic and the functions the inverse kinematics
//! needs. Running the closed-form inverse kinematics on jets gives the exact derivatives of
//! every joint along a path (q', q'', q'''), without finite differences. Plain `f64`
//! arithmetic, no allocation: safe in a real-time cycle.
//!
//! ```
//! use wrc_robot::Jet;
//!
//! // x(u) = 2 + 3u at u = 0: sin(x) has derivatives 3cos 2, -9 sin 2, -27 cos 2.
//! let s = Jet::variable(2.0, 3.0).sin();
//! assert!((s.d[1] - 3.0 * 2f64.cos()).abs() < 1e-12);
//! assert!((s.d[3] + 27.0 * 2f64.cos()).abs() < 1e-12);
//! ```

use std::ops::{Add, Div, Mul, Neg, Sub};

/// A value and its first three derivatives with respect to a path parameter:
/// `d = [f, f', f'', f''']`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Jet {
    /// The value and its derivatives, lowest order first.
    pub d: [f64; 4],
}

impl Jet {
    /// A constant: every derivative is zero.
    #[inline]
    pub const fn constant(value: f64) -> Jet {
        Jet {
            d: [value, 0.0, 0.0, 0.0],
        }
    }

    /// A quantity linear in the parameter: `value + slope · (u − u0)` at u = u0.
    #[inline]
    pub const fn variable(value: f64, slope: f64) -> Jet {
        Jet {
            d: [value, slope, 0.0, 0.0],
        }
    }

    /// The value.
    #[inline]
    pub fn value(&self) -> f64 {
        self.d[0]
    }

    /// Multiply by a constant.
    #[inline]
    pub fn scale(self, k: f64) -> Jet {
        Jet {
            d: [k * self.d[0], k * self.d[1], k * self.d[2], k * self.d[3]],
        }
    }

    /// Add a constant to the value.
    #[inline]
    pub fn offset(self, k: f64) -> Jet {
        Jet {
            d: [self.d[0] + k, self.d[1], self.d[2], self.d[3]],
        }
    }

    /// `f(self)` for an outer function whose value and first three derivatives at
    /// `self.value()` are `f` (Faà di Bruno's formula to order 3).
    #[inline]
    pub fn compose(self, f: [f64; 4]) -> Jet {
        let [_, x1, x2, x3] = self.d;
        Jet {
            d: [
                f[0],
                f[1] * x1,
                f[2] * x1 * x1 + f[1] * x2,
                f[3] * x1 * x1 * x1 + 3.0 * f[2] * x1 * x2 + f[1] * x3,
            ],
        }
    }

    /// `1 / self` (the value must not be zero).
    #[inline]
    pub fn recip(self) -> Jet {
        let x = self.d[0];
        let r = 1.0 / x;
        let r2 = r * r;
        self.compose([r, -r2, 2.0 * r2 * r, -6.0 * r2 * r2])
    }

    /// Square root (the value must be positive).
    #[inline]
    pub fn sqrt(self) -> Jet {
        let x = self.d[0];
        let s = x.sqrt();
        let f1 = 0.5 / s;
        let f2 = -0.5 * f1 / x;
        let f3 = -1.5 * f2 / x;
        self.compose([s, f1, f2, f3])
    }

    /// Sine [rad].
    #[inline]
    pub fn sin(self) -> Jet {
        let (s, c) = self.d[0].sin_cos();
        self.compose([s, c, -s, -c])
    }

    /// Cosine [rad].
    #[inline]
    pub fn cos(self) -> Jet {
        let (s, c) = self.d[0].sin_cos();
        self.compose([c, -s, -c, s])
    }

    /// Arc cosine [rad] (the value must lie strictly inside (-1, 1)).
    #[inline]
    pub fn acos(self) -> Jet {
        let c = self.d[0];
        let w = 1.0 - c * c;
        let sw = w.sqrt();
        let f1 = -1.0 / sw;
        let f2 = f1 * c / w;
        let f3 = -(1.0 + 2.0 * c * c) / (w * w * sw);
        self.compose([c.acos(), f1, f2, f3])
    }

    /// `atan2(self, x)` [rad], the angle of the point (x, self); the point must not be the
    /// origin. The value is in (-π, π]; its derivatives are those of the continuous angle.
    pub fn atan2(self, x: Jet) -> Jet {
        let [y0, y1, y2, y3] = self.d;
        let [x0, x1, x2, x3] = x.d;
        // φ' = n/ρ with n = x y' − y x', ρ = x² + y².
        let n = x0 * y1 - y0 * x1;
        let n1 = x0 * y2 - y0 * x2;
        let n2 = x1 * y2 + x0 * y3 - y1 * x2 - y0 * x3;
        let rho = x0 * x0 + y0 * y0;
        let rho1 = 2.0 * (x0 * x1 + y0 * y1);
        let rho2 = 2.0 * (x1 * x1 + x0 * x2 + y1 * y1 + y0 * y2);
        let q = n1 * rho - n * rho1;
        Jet {
            d: [
                y0.atan2(x0),
                n / rho,
                q / (rho * rho),
                (n2 * rho - n * rho2) / (rho * rho) - 2.0 * rho1 * q / (rho * rho * rho),
            ],
        }
    }
}

impl Add for Jet {
    type Output = Jet;
    #[inline]
    fn add(self, o: Jet) -> Jet {
        Jet {
            d: [
                self.d[0] + o.d[0],
                self.d[1] + o.d[1],
                self.d[2] + o.d[2],
                self.d[3] + o.d[3],
            ],
        }
    }
}

impl Sub for Jet {
    type Output = Jet;
    #[inline]
    fn sub(self, o: Jet) -> Jet {
        Jet {
            d: [
                self.d[0] - o.d[0],
                self.d[1] - o.d[1],
                self.d[2] - o.d[2],
                self.d[3] - o.d[3],
            ],
        }
    }
}

impl Neg for Jet {
    type Output = Jet;
    #[inline]
    fn neg(self) -> Jet {
        self.scale(-1.0)
    }
}

impl Div for Jet {
    type Output = Jet;
    /// `self / other` (the other's value must not be zero).
    #[inline]
    #[allow(clippy::suspicious_arithmetic_impl)] // a / b = a · (1/b), by Leibniz's rule
    fn div(self, other: Jet) -> Jet {
        self * other.recip()
    }
}

impl Mul for Jet {
    type Output = Jet;
    /// Leibniz's rule to order 3.
    #[inline]
    fn mul(self, o: Jet) -> Jet {
        let [a0, a1, a2, a3] = self.d;
        let [b0, b1, b2, b3] = o.d;
        Jet {
            d: [
                a0 * b0,
                a1 * b0 + a0 * b1,
                a2 * b0 + 2.0 * a1 * b1 + a0 * b2,
                a3 * b0 + 3.0 * (a2 * b1 + a1 * b2) + a0 * b3,
            ],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Derivatives of `f` at `u0` by central differences of step `h`, to compare with jets.
    fn numeric(f: impl Fn(f64) -> f64, u0: f64, h: f64) -> [f64; 4] {
        let v = |k: f64| f(u0 + k * h);
        [
            v(0.0),
            (v(1.0) - v(-1.0)) / (2.0 * h),
            (v(1.0) - 2.0 * v(0.0) + v(-1.0)) / (h * h),
            (v(2.0) - 2.0 * v(1.0) + 2.0 * v(-1.0) - v(-2.0)) / (2.0 * h * h * h),
        ]
    }

    fn assert_close(jet: Jet, want: [f64; 4], tol: f64) {
        for (k, (got, want)) in jet.d.iter().zip(want).enumerate() {
            let scale = want.abs().max(1.0);
            assert!(
                (got - want).abs() <= tol * scale,
                "derivative {k}: jet {got} vs numeric {want}"
            );
        }
    }

    #[test]
    fn every_function_matches_finite_differences() {
        // A curved inner function so that second and third derivatives matter.
        let inner = |u: f64| 0.3 + 0.2 * u + 0.05 * u * u - 0.01 * u * u * u;
        let jet = |u: f64| Jet {
            d: [
                inner(u),
                0.2 + 0.1 * u - 0.03 * u * u,
                0.1 - 0.06 * u,
                -0.06,
            ],
        };
        let u0 = 0.7;
        let x = jet(u0);
        let h = 1e-3;
        assert_close(x.sin(), numeric(|u| inner(u).sin(), u0, h), 1e-5);
        assert_close(x.cos(), numeric(|u| inner(u).cos(), u0, h), 1e-5);
        assert_close(x.sqrt(), numeric(|u| inner(u).sqrt(), u0, h), 1e-5);
        assert_close(x.acos(), numeric(|u| inner(u).acos(), u0, h), 1e-5);
        assert_close(x.recip(), numeric(|u| 1.0 / inner(u), u0, h), 1e-5);
        assert_close(
            x * x.sin(),
            numeric(|u| inner(u) * inner(u).sin(), u0, h),
            1e-5,
        );
        let y = x.scale(-2.0).offset(0.1);
        let yf = |u: f64| -2.0 * inner(u) + 0.1;
        assert_close(y.atan2(x), numeric(|u| yf(u).atan2(inner(u)), u0, h), 1e-5);
        assert_close(x.atan2(y), numeric(|u| inner(u).atan2(yf(u)), u0, h), 1e-5);
        assert_close(x / y, numeric(|u| inner(u) / yf(u), u0, h), 1e-5);
    }

    #[test]
    fn atan2_is_the_continuous_angle_across_the_negative_x_axis() {
        // The point (-1, y) with y = 0.5 − u crosses the -x axis at u = 0.5: the value jumps
        // by 2π there, its derivative does not.
        let before = Jet::variable(0.01, -1.0).atan2(Jet::constant(-1.0));
        let after = Jet::variable(-0.01, -1.0).atan2(Jet::constant(-1.0));
        assert!(before.value() > 3.0 && after.value() < -3.0);
        assert!((before.d[1] - after.d[1]).abs() < 1e-3);
    }
}
