//! Math backends: the only place the core calls `libm` or `micromath`.
//!
//! A scene picks its backend with a type parameter, so one binary can run and
//! compare both. Functions are always called by explicit path
//! (`libm::sqrt(x)`, `micromath::F32Ext::sqrt(x)`): with std linked, method
//! syntax (`x.sqrt()`) would silently resolve to std's inherent methods.
//!
//! | backend | precisions | accuracy |
//! |---|---|---|
//! | [`Libm`] | `f32`, `f64` | correctly rounded or within an ulp or two; same bits on every target |
//! | [`Micromath`] | `f32` only | fast approximations: `sqrt` is a few percent off (see the crate docs) |
//!
//! On x86-64, `libm` computes the square root with inline assembly in the
//! legacy SSE encoding. In a build for a CPU with AVX (`-C
//! target-cpu=native`) the surrounding code is VEX-encoded and each call
//! pays an encoding transition: the 2D box's `f64` step measured 20 times
//! slower on an AVX-512 Xeon (`cargo bench -p sph-core --bench core --
//! steps::summation_f64`, where `summation_f64_host` is the same step on
//! the compiler's square root). A std program can implement [`Math`] with
//! `f64::sqrt` and libm for the rest: IEEE square roots are correctly
//! rounded, so the bits are the same (`sph_std::math::Host` does this).

use core::fmt::Debug;

use crate::real::Real;

/// A set of elementary functions for the float type `F`.
pub trait Math<F: Real>: Copy + Default + Debug + Send + Sync + 'static {
    /// Short name, for reports: `"libm"` or `"micromath"`.
    const NAME: &'static str;
    /// Square root.
    fn sqrt(x: F) -> F;
    /// Exponential.
    fn exp(x: F) -> F;
    /// `x` raised to the real power `y`.
    fn powf(x: F, y: F) -> F;
    /// Largest integer not greater than `x`.
    fn floor(x: F) -> F;
}

/// `f64` functions for set-up constants and exact solutions (libm), so that
/// this module stays the only caller of `libm` and `micromath`.
pub(crate) mod f64s {
    /// Square root.
    #[inline]
    pub fn sqrt(x: f64) -> f64 {
        libm::sqrt(x)
    }
    /// Exponential.
    #[inline]
    pub fn exp(x: f64) -> f64 {
        libm::exp(x)
    }
    /// Sine.
    #[inline]
    pub fn sin(x: f64) -> f64 {
        libm::sin(x)
    }
    /// Cosine.
    #[inline]
    pub fn cos(x: f64) -> f64 {
        libm::cos(x)
    }
    /// Largest integer not greater than `x`.
    #[inline]
    pub fn floor(x: f64) -> f64 {
        libm::floor(x)
    }
    /// Error function.
    #[inline]
    pub fn erf(x: f64) -> f64 {
        libm::erf(x)
    }
    /// `ln(1 + x)`, accurate for small `x`.
    #[inline]
    pub fn ln_1p(x: f64) -> f64 {
        libm::log1p(x)
    }
    /// `e^x - 1`, accurate for small `x`.
    #[inline]
    pub fn exp_m1(x: f64) -> f64 {
        libm::expm1(x)
    }
}

/// The portable backend: `libm`, for both precisions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Libm;

impl Math<f64> for Libm {
    const NAME: &'static str = "libm";
    #[inline(always)]
    fn sqrt(x: f64) -> f64 {
        libm::sqrt(x)
    }
    #[inline(always)]
    fn exp(x: f64) -> f64 {
        libm::exp(x)
    }
    #[inline(always)]
    fn powf(x: f64, y: f64) -> f64 {
        libm::pow(x, y)
    }
    #[inline(always)]
    fn floor(x: f64) -> f64 {
        libm::floor(x)
    }
}

impl Math<f32> for Libm {
    const NAME: &'static str = "libm";
    #[inline(always)]
    fn sqrt(x: f32) -> f32 {
        libm::sqrtf(x)
    }
    #[inline(always)]
    fn exp(x: f32) -> f32 {
        libm::expf(x)
    }
    #[inline(always)]
    fn powf(x: f32, y: f32) -> f32 {
        libm::powf(x, y)
    }
    #[inline(always)]
    fn floor(x: f32) -> f32 {
        libm::floorf(x)
    }
}

/// The fast backend: `micromath`'s approximations, `f32` only.
///
/// Its square root is a bit trick a few percent off; what that costs in
/// accuracy is measured by the studies in `sph-std`, not assumed.
#[cfg(feature = "micromath")]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Micromath;

#[cfg(feature = "micromath")]
impl Math<f32> for Micromath {
    const NAME: &'static str = "micromath";
    #[inline(always)]
    fn sqrt(x: f32) -> f32 {
        micromath::F32Ext::sqrt(x)
    }
    #[inline(always)]
    fn exp(x: f32) -> f32 {
        micromath::F32Ext::exp(x)
    }
    #[inline(always)]
    fn powf(x: f32, y: f32) -> f32 {
        micromath::F32Ext::powf(x, y)
    }
    #[inline(always)]
    fn floor(x: f32) -> f32 {
        micromath::F32Ext::floor(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn libm_backends_are_accurate() {
        assert_eq!(<Libm as Math<f64>>::sqrt(2.25), 1.5);
        assert_eq!(<Libm as Math<f32>>::floor(-0.5), -1.0);
        assert!((<Libm as Math<f64>>::exp(1.0) - core::f64::consts::E).abs() < 1e-15);
        assert!((<Libm as Math<f64>>::powf(2.0, 10.0) - 1024.0).abs() < 1e-12);
    }

    #[cfg(feature = "micromath")]
    #[test]
    fn micromath_is_an_approximation_within_a_few_percent() {
        // The documented trade: a cheap square root, off by a few percent.
        let mut worst = 0.0f64;
        for k in 1..1000 {
            let x = k as f32 * 0.37;
            let approx = <Micromath as Math<f32>>::sqrt(x) as f64;
            let exact = libm::sqrt(x as f64);
            worst = worst.max(((approx - exact) / exact).abs());
        }
        assert!(worst < 0.07, "micromath sqrt relative error {worst}");
        assert!(
            worst > 1e-6,
            "micromath sqrt is not the approximation we document"
        );
    }
}
