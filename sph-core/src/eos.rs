//! Equations of state `P(rho)` for weakly compressible flow (`docs/physics.md` 3.3).

use crate::error::{Error, Result};
use crate::math::Math;
use crate::real::Real;

/// An equation of state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Eos<F> {
    /// No pressure at all (`P = 0`, no sound speed): for scenes without a
    /// pressure term.
    None,
    /// `P = c0^2 (rho - rho0) + p0`: symmetric in compression and expansion;
    /// the choice for low-Reynolds channel flows.
    Linear {
        /// Reference density.
        rho0: F,
        /// Sound speed.
        c0: F,
        /// Background pressure.
        p0: F,
    },
    /// Tait/Cole `P = B ((rho/rho0)^gamma - 1) + p0`, `B = rho0 c0^2 / gamma`:
    /// the usual choice for free-surface water (`gamma = 7`).
    Tait {
        /// Reference density.
        rho0: F,
        /// Sound speed at `rho0`.
        c0: F,
        /// Exponent.
        gamma: F,
        /// Background pressure.
        p0: F,
    },
}

impl<F: Real> Eos<F> {
    /// Checks the parameters.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming the parameter and its rule.
    pub fn validate(&self) -> Result<()> {
        let positive = |name, x: F| {
            if x.is_finite() && x > F::ZERO {
                Ok(())
            } else {
                Err(Error::InvalidParameter {
                    name,
                    value: x.to_f64(),
                    rule: "must be positive and finite",
                })
            }
        };
        let finite = |name, x: F| {
            if x.is_finite() {
                Ok(())
            } else {
                Err(Error::InvalidParameter {
                    name,
                    value: x.to_f64(),
                    rule: "must be finite",
                })
            }
        };
        match *self {
            Eos::None => Ok(()),
            Eos::Linear { rho0, c0, p0 } => {
                positive("rho0", rho0)?;
                positive("c0", c0)?;
                finite("p0", p0)
            }
            Eos::Tait {
                rho0,
                c0,
                gamma,
                p0,
            } => {
                positive("rho0", rho0)?;
                positive("c0", c0)?;
                positive("gamma", gamma)?;
                finite("p0", p0)
            }
        }
    }

    /// Pressure at density `rho`.
    #[inline(always)]
    pub fn pressure<M: Math<F>>(&self, rho: F) -> F {
        match *self {
            Eos::None => F::ZERO,
            Eos::Linear { rho0, c0, p0 } => c0 * c0 * (rho - rho0) + p0,
            Eos::Tait {
                rho0,
                c0,
                gamma,
                p0,
            } => {
                let b = rho0 * c0 * c0 / gamma;
                b * (M::powf(rho / rho0, gamma) - F::ONE) + p0
            }
        }
    }

    /// Density at pressure `p`: the inverse of [`Self::pressure`]. For
    /// [`Eos::None`], which has none, and for a Tait pressure at or below
    /// `p0 - B` (a tension the equation reaches only at zero density) it is
    /// `fallback`, so that a density never comes out zero or negative.
    #[inline]
    pub fn density<M: Math<F>>(&self, p: F, fallback: F) -> F {
        match *self {
            Eos::None => fallback,
            Eos::Linear { rho0, c0, p0 } => rho0 + (p - p0) / (c0 * c0),
            Eos::Tait {
                rho0,
                c0,
                gamma,
                p0,
            } => {
                let b = rho0 * c0 * c0 / gamma;
                let base = (p - p0) / b + F::ONE;
                if base > F::ZERO {
                    rho0 * M::powf(base, F::ONE / gamma)
                } else {
                    fallback
                }
            }
        }
    }

    /// Specific internal energy `e(rho) = int_rho0^rho P(r) / r^2 dr` (J/kg,
    /// zero at `rho0`): the energy a unit mass stores when compressed from
    /// `rho0` to `rho` (`de/dt = P / rho^2 drho/dt`, the first law for a
    /// barotropic fluid), so that kinetic plus potential plus `sum m e` is
    /// what the continuity and momentum equations conserve without
    /// dissipation. Evaluated in `f64` from the closed forms
    /// (`docs/physics.md` 3.3), written in `ln_1p`/`exp_m1` of
    /// `x = rho/rho0 - 1` so that the `O(x^2)` value near `rho0` does not
    /// cancel away. Zero for [`Eos::None`]; NaN for a non-positive `rho`.
    pub fn internal_energy(&self, rho: f64) -> f64 {
        use crate::math::f64s::{exp_m1, ln_1p};
        // The background pressure's part: p0 (1/rho0 - 1/rho).
        let background = |rho0: f64, p0: f64| p0 * (rho - rho0) / (rho0 * rho);
        match *self {
            Eos::None => 0.0,
            Eos::Linear { rho0, c0, p0 } => {
                let (rho0, c2, p0) = (rho0.to_f64(), (c0 * c0).to_f64(), p0.to_f64());
                let x = rho / rho0 - 1.0;
                // c0^2 (ln(1 + x) - x / (1 + x)).
                c2 * (ln_1p(x) - x / (1.0 + x)) + background(rho0, p0)
            }
            Eos::Tait {
                rho0,
                c0,
                gamma,
                p0,
            } => {
                let (rho0, g, p0) = (rho0.to_f64(), gamma.to_f64(), p0.to_f64());
                let b = rho0 * (c0 * c0).to_f64() / g;
                let x = rho / rho0 - 1.0;
                // B / rho0 (((1 + x)^(g - 1) - 1) / (g - 1) - x / (1 + x)).
                let power = exp_m1((g - 1.0) * ln_1p(x));
                b / rho0 * (power / (g - 1.0) - x / (1.0 + x)) + background(rho0, p0)
            }
        }
    }

    /// Reference sound speed (zero for [`Eos::None`]).
    pub fn sound_speed(&self) -> F {
        match *self {
            Eos::None => F::ZERO,
            Eos::Linear { c0, .. } | Eos::Tait { c0, .. } => c0,
        }
    }

    /// Reference density, if the equation has one.
    pub fn reference_density(&self) -> Option<F> {
        match *self {
            Eos::None => None,
            Eos::Linear { rho0, .. } | Eos::Tait { rho0, .. } => Some(rho0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Libm;

    #[test]
    fn density_inverts_pressure() {
        let tait = Eos::Tait {
            rho0: 1000.0,
            c0: 20.0,
            gamma: 7.0,
            p0: 50.0,
        };
        let lin = Eos::Linear {
            rho0: 1.0,
            c0: 3.0,
            p0: -2.0,
        };
        for rho in [950.0, 999.0, 1000.0, 1003.5, 1040.0] {
            let back = tait.density::<Libm>(tait.pressure::<Libm>(rho), 0.0);
            assert!((back - rho).abs() < 1e-9 * rho, "{rho} -> {back}");
        }
        for rho in [0.9, 1.0, 1.1] {
            let back = lin.density::<Libm>(lin.pressure::<Libm>(rho), 0.0);
            assert!((back - rho).abs() < 1e-14, "{rho} -> {back}");
        }
        // Beyond the tension the Tait curve reaches: the fallback.
        assert_eq!(tait.density::<Libm>(-1e9, 998.0), 998.0);
        assert_eq!(Eos::<f64>::None.density::<Libm>(5.0, 0.7), 0.7);
    }

    #[test]
    fn pressures_vanish_at_reference_density_and_agree_to_first_order() {
        let lin = Eos::Linear {
            rho0: 1000.0,
            c0: 10.0,
            p0: 0.0,
        };
        let tait = Eos::Tait {
            rho0: 1000.0,
            c0: 10.0,
            gamma: 7.0,
            p0: 0.0,
        };
        assert_eq!(lin.pressure::<Libm>(1000.0), 0.0);
        assert!(tait.pressure::<Libm>(1000.0).abs() < 1e-9);
        // dP/drho = c0^2 at rho0 for both.
        let d = 1e-3;
        let slope =
            (tait.pressure::<Libm>(1000.0 + d) - tait.pressure::<Libm>(1000.0 - d)) / (2.0 * d);
        assert!((slope - 100.0).abs() < 1e-6, "{slope}");
        assert_eq!(lin.pressure::<Libm>(1001.0), 100.0);
        // Tait is stiffer in compression than in expansion.
        assert!(tait.pressure::<Libm>(1010.0) > -tait.pressure::<Libm>(990.0));
    }

    #[test]
    fn internal_energy_is_the_integral_of_p_over_rho_squared() {
        let forms = [
            Eos::Linear {
                rho0: 1000.0,
                c0: 20.0,
                p0: 0.0,
            },
            Eos::Linear {
                rho0: 1.0,
                c0: 3.0,
                p0: 0.5,
            },
            Eos::Tait {
                rho0: 1000.0,
                c0: 20.0,
                gamma: 7.0,
                p0: 0.0,
            },
            Eos::Tait {
                rho0: 1.0,
                c0: 10.0,
                gamma: 7.0,
                p0: 2.0,
            },
        ];
        for eos in forms {
            let rho0 = eos.reference_density().unwrap();
            assert_eq!(eos.internal_energy(rho0), 0.0);
            for x in [-0.05, -1e-3, 1e-4, 0.02, 0.1] {
                let rho = rho0 * (1.0 + x);
                // de/drho = P / rho^2, by a central difference ...
                let d = 1e-6 * rho0;
                let slope =
                    (eos.internal_energy(rho + d) - eos.internal_energy(rho - d)) / (2.0 * d);
                let p = eos.pressure::<Libm>(rho);
                let expect = p / (rho * rho);
                assert!(
                    (slope - expect).abs() <= 1e-6 * (expect.abs() + 1e-3),
                    "{eos:?} at {rho}: {slope} vs {expect}"
                );
                // ... and the integral itself by Simpson's rule on 2000 panels.
                let m = 2000;
                let h = (rho - rho0) / m as f64;
                let f = |r: f64| eos.pressure::<Libm>(r) / (r * r);
                let mut sum = f(rho0) + f(rho);
                for k in 1..m {
                    sum += f(rho0 + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
                }
                let simpson = sum * h / 3.0;
                let e = eos.internal_energy(rho);
                assert!(
                    (e - simpson).abs() <= 1e-9 * simpson.abs().max(1e-12),
                    "{eos:?} at {rho}: {e} vs {simpson}"
                );
            }
        }
        // Without a background pressure, compression and expansion both store energy.
        let tait = forms[2];
        assert!(tait.internal_energy(990.0) > 0.0 && tait.internal_energy(1010.0) > 0.0);
        assert_eq!(Eos::<f64>::None.internal_energy(3.0), 0.0);
    }

    #[test]
    fn invalid_parameters_are_named() {
        let e = Eos::Linear {
            rho0: 1000.0,
            c0: -1.0,
            p0: 0.0,
        }
        .validate();
        assert!(matches!(e, Err(Error::InvalidParameter { name: "c0", .. })));
        let e = Eos::Tait {
            rho0: 1000.0,
            c0: 1.0,
            gamma: 0.0,
            p0: 0.0,
        }
        .validate();
        assert!(matches!(
            e,
            Err(Error::InvalidParameter { name: "gamma", .. })
        ));
        assert!(Eos::<f64>::None.validate().is_ok());
    }
}
