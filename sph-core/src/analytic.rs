//! Exact solutions, in `f64`, for validation on any target.
//!
//! Shared by the firmware and the std frontend, so both check against the
//! same code.

use crate::error::{Error, Result};

const PI: f64 = core::f64::consts::PI;

/// Impulsively started planar Couette flow (`docs/physics.md` 6.a).
///
/// Plates at `y_lower` (at rest) and `y_upper` (moving at `u` along x from
/// `t = 0`), fluid at rest at `t = 0`, kinematic viscosity `nu`. With gap
/// `H = y_upper - y_lower` and `eta = (y - y_lower) / H`,
///
/// `u(y, t) = U eta + sum_{n >= 1} 2U/(n pi) (-1)^n sin(n pi eta) exp(-n^2 pi^2 nu t / H^2)`.
///
/// The series is summed until a bound on the remaining tail falls below
/// `tolerance * U` (default `1e-14`), so its own error is stated, not guessed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Couette {
    /// Position of the plate at rest.
    pub y_lower: f64,
    /// Position of the moving plate.
    pub y_upper: f64,
    /// Speed of the moving plate.
    pub u: f64,
    /// Kinematic viscosity.
    pub nu: f64,
    /// Truncation tolerance relative to `u`.
    pub tolerance: f64,
}

/// Most terms the series may sum (reached only for `nu t / H^2` below about 1e-7).
pub const MAX_TERMS: usize = 1_000_000;

impl Couette {
    /// A Couette flow with the default tolerance `1e-14`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] unless `y_upper > y_lower`, `nu > 0` and all are finite.
    pub fn new(y_lower: f64, y_upper: f64, u: f64, nu: f64) -> Result<Self> {
        if !(y_lower.is_finite() && y_upper.is_finite() && y_upper > y_lower) {
            return Err(Error::InvalidParameter {
                name: "y_upper",
                value: y_upper,
                rule: "the moving plate must lie above the plate at rest",
            });
        }
        if !(nu.is_finite() && nu > 0.0) {
            return Err(Error::InvalidParameter {
                name: "nu",
                value: nu,
                rule: "viscosity must be positive and finite",
            });
        }
        if !u.is_finite() {
            return Err(Error::InvalidParameter {
                name: "U",
                value: u,
                rule: "plate speed must be finite",
            });
        }
        Ok(Self {
            y_lower,
            y_upper,
            u,
            nu,
            tolerance: 1e-14,
        })
    }

    /// Gap width `H`.
    pub fn gap(&self) -> f64 {
        self.y_upper - self.y_lower
    }

    /// Diffusion time `H^2 / nu`.
    pub fn diffusion_time(&self) -> f64 {
        self.gap() * self.gap() / self.nu
    }

    /// Velocity along x at height `y` and time `t`.
    ///
    /// At `t <= 0` the fluid is at rest (and the moving plate, `y >= y_upper`,
    /// moves at `U`); outside the gap the plate velocities are returned.
    pub fn velocity(&self, y: f64, t: f64) -> f64 {
        if y >= self.y_upper {
            return self.u;
        }
        if y <= self.y_lower || t <= 0.0 {
            return 0.0;
        }
        let eta = (y - self.y_lower) / self.gap();
        let a = PI * PI * self.nu * t / (self.gap() * self.gap());
        let mut sum = eta;
        for n in 1..=MAX_TERMS {
            let nf = n as f64;
            let decay = crate::math::f64s::exp(-a * nf * nf);
            let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
            sum += 2.0 / (nf * PI) * sign * crate::math::f64s::sin(nf * PI * eta) * decay;
            // Tail bound: |sum_{m > n}| <= 2/((n+1) pi) e^{-a (n+1)^2} / (1 - e^{-a (2n+3)}).
            let next = nf + 1.0;
            let tail = 2.0 / (next * PI) * crate::math::f64s::exp(-a * next * next)
                / (1.0 - crate::math::f64s::exp(-a * (2.0 * nf + 3.0)));
            if tail < self.tolerance {
                break;
            }
        }
        self.u * sum
    }
}

/// Plane Poiseuille flow started from rest (`docs/physics.md` 6.b).
///
/// Walls at `y_lower` and `y_upper` (gap `H`, both at rest), a body force `f`
/// per unit mass along x switched on at `t = 0`, kinematic viscosity `nu`.
/// With `s = y - y_lower`,
///
/// `u(y, t) = f/(2 nu) s (H - s) - sum_{n >= 0} 4 f H^2/(nu pi^3 (2n+1)^3) sin((2n+1) pi s/H) exp(-(2n+1)^2 pi^2 nu t/H^2)`;
///
/// steady centre-line speed `u_max = f H^2 / (8 nu)`. The series stops when
/// a bound on its tail falls below `tolerance * u_max` (default `1e-14`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Poiseuille {
    /// Lower wall.
    pub y_lower: f64,
    /// Upper wall.
    pub y_upper: f64,
    /// Body force per unit mass along x.
    pub f: f64,
    /// Kinematic viscosity.
    pub nu: f64,
    /// Truncation tolerance relative to `u_max`.
    pub tolerance: f64,
}

impl Poiseuille {
    /// A Poiseuille flow with the default tolerance `1e-14`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] unless `y_upper > y_lower`, `nu > 0` and all are finite.
    pub fn new(y_lower: f64, y_upper: f64, f: f64, nu: f64) -> Result<Self> {
        let c = Couette::new(y_lower, y_upper, f, nu)?;
        Ok(Self {
            y_lower: c.y_lower,
            y_upper: c.y_upper,
            f,
            nu,
            tolerance: 1e-14,
        })
    }

    /// Gap width `H`.
    pub fn gap(&self) -> f64 {
        self.y_upper - self.y_lower
    }

    /// Steady centre-line speed `f H^2 / (8 nu)`.
    pub fn u_max(&self) -> f64 {
        self.f * self.gap() * self.gap() / (8.0 * self.nu)
    }

    /// Velocity along x at height `y` and time `t` (zero outside the gap and at `t <= 0`).
    pub fn velocity(&self, y: f64, t: f64) -> f64 {
        let h = self.gap();
        let s = y - self.y_lower;
        if s <= 0.0 || s >= h || t <= 0.0 {
            return 0.0;
        }
        let a = PI * PI * self.nu * t / (h * h);
        let c = 4.0 * self.f * h * h / (self.nu * PI * PI * PI);
        let mut sum = self.f / (2.0 * self.nu) * s * (h - s);
        let limit = self.tolerance * self.u_max().abs();
        for n in 0..MAX_TERMS {
            let k = (2 * n + 1) as f64;
            sum -= c / (k * k * k)
                * crate::math::f64s::sin(k * PI * s / h)
                * crate::math::f64s::exp(-a * k * k);
            // Tail over odd m >= k + 2: each term is below c/m^3 e^{-a m^2};
            // bounded by the geometric series of ratio e^{-4a(k+3)}.
            let next = k + 2.0;
            let tail = c / (next * next * next) * crate::math::f64s::exp(-a * next * next)
                / (1.0 - crate::math::f64s::exp(-4.0 * a * (next + 1.0)));
            if tail.abs() < limit {
                break;
            }
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference values from `docs/physics.md` 6.a (convention A, u/U, computed there independently).
    #[test]
    fn matches_reference_table() {
        let c = Couette::new(0.0, 1.0, 1.0, 1.0).unwrap();
        let table = [
            (0.0225, [0.000407, 0.018422, 0.238593]),
            (0.045, [0.012388, 0.095580, 0.404657]),
            (0.1125, [0.105438, 0.290275, 0.597939]),
            (0.225, [0.201185, 0.430903, 0.701097]),
            (0.5, [0.246763, 0.495422, 0.746763]),
            (1.0, [0.249977, 0.499967, 0.749977]),
        ];
        for (t, row) in table {
            for (y, want) in [0.25, 0.5, 0.75].into_iter().zip(row) {
                let got = c.velocity(y, t);
                assert!((got - want).abs() < 1e-6, "t*={t} y={y}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn seed_convention_is_a_shift_and_limits_hold() {
        // Walls at -L and +L (the seed's convention) is convention A shifted.
        let a = Couette::new(0.0, 2e-3, 1.25e-5, 1e-6).unwrap();
        let b = Couette::new(-1e-3, 1e-3, 1.25e-5, 1e-6).unwrap();
        assert!((a.velocity(0.5e-3, 0.3) - b.velocity(-0.5e-3, 0.3)).abs() < 1e-20);
        // Steady state is the line; t = 0 is rest; boundary values are the plates'.
        let steady = b.velocity(0.0, 1e3);
        assert!((steady - 0.5 * 1.25e-5).abs() < 1e-18);
        assert_eq!(b.velocity(0.0, 0.0), 0.0);
        assert_eq!(b.velocity(1e-3, 0.1), 1.25e-5);
        assert_eq!(b.velocity(-1e-3, 0.1), 0.0);
        // Very early times need many terms but stay bounded and finite.
        let early = b.velocity(0.99e-3, 1e-6);
        assert!(early.is_finite() && early > 0.0 && early < 1.25e-5);
    }

    /// Reference values of `docs/physics.md` 6.b (u/u_max at the centre and at y = H/4).
    #[test]
    fn poiseuille_matches_reference_table() {
        let p = Poiseuille::new(0.0, 1.0, 8.0, 1.0).unwrap();
        assert_eq!(p.u_max(), 1.0);
        let table = [
            (0.0225, 0.178619, 0.161915),
            (0.045, 0.338766, 0.281444),
            (0.1125, 0.659993, 0.509576),
            (0.225, 0.887984, 0.670793),
            (0.5, 0.992578, 0.744752),
            (1.0, 0.999947, 0.749962),
        ];
        for (t, centre, quarter) in table {
            assert!((p.velocity(0.5, t) - centre).abs() < 1e-6, "t*={t}");
            assert!((p.velocity(0.25, t) - quarter).abs() < 1e-6, "t*={t}");
        }
        // Steady parabola, rest at t = 0, zero at the walls.
        assert!((p.velocity(0.25, 100.0) - 0.75).abs() < 1e-14);
        assert_eq!(p.velocity(0.5, 0.0), 0.0);
        assert_eq!(p.velocity(0.0, 1.0), 0.0);
    }

    #[test]
    fn rejects_bad_parameters() {
        assert!(Couette::new(1.0, 0.0, 1.0, 1.0).is_err());
        assert!(Couette::new(0.0, 1.0, 1.0, 0.0).is_err());
        assert!(Couette::new(0.0, 1.0, f64::NAN, 1.0).is_err());
    }
}
