//! Smoothing kernels `W(r, h) = sigma_d / h^d * f(q)`, `q = r / h`.
//!
//! Each kernel is a zero-sized type implementing [`Kernel`]: the shape `f(q)`,
//! its derivative through `F(q) = f'(q) / q` (finite at `q = 0`, so no division
//! by `r` is ever needed), the support `kappa` (W vanishes for `q >= kappa`)
//! and the normalisation `sigma_d` for `d = 1, 2, 3`. Constants follow
//! `docs/physics.md` section 2, where each was re-derived symbolically; the
//! tests below check every one by quadrature.
//!
//! The smoothing length `h` is explicit; the overlap factor of the seed is
//! `beta = h / dx`, chosen by the scene. [`SmoothingKernel`] binds a kernel to
//! an `h` and precomputes the factors used in the pair loop.

use core::fmt::Debug;
use core::marker::PhantomData;

use crate::error::{Error, Result};
use crate::math::Math;
use crate::real::Real;
use crate::space::{Space, VectorOps};

/// A radial smoothing kernel (zero-sized; see the module docs).
pub trait Kernel: Copy + Default + Debug + Send + Sync + 'static {
    /// Short name, for reports and file names.
    const NAME: &'static str;
    /// Support in units of `h`: `W(r, h) = 0` for `r >= SUPPORT * h`.
    const SUPPORT: f64;
    /// Normalisation `sigma_d` in dimension `dim` (1, 2 or 3), such that the
    /// integral of `W` over space is one.
    fn sigma(dim: usize) -> f64;
    /// Shape function `f(q)`, zero for `q >= SUPPORT`.
    fn f<S: Space, M: Math<S::Real>>(q: S::Real) -> S::Real;
    /// `f'(q) / q`, finite at `q = 0`, zero for `q >= SUPPORT`.
    fn df_q<S: Space, M: Math<S::Real>>(q: S::Real) -> S::Real;
}

#[inline(always)]
fn c<F: Real>(x: f64) -> F {
    F::from_f64(x)
}

#[inline(always)]
fn pow2<F: Real>(x: F) -> F {
    x * x
}

#[inline(always)]
fn pow3<F: Real>(x: F) -> F {
    x * x * x
}

#[inline(always)]
fn pow4<F: Real>(x: F) -> F {
    pow2(pow2(x))
}

#[inline(always)]
fn pow5<F: Real>(x: F) -> F {
    pow4(x) * x
}

#[inline(always)]
fn pow6<F: Real>(x: F) -> F {
    pow3(pow2(x))
}

const PI: f64 = core::f64::consts::PI;

/// `max(x, 0)`, compiled to a branch-free instruction.
#[inline(always)]
fn pos<F: Real>(x: F) -> F {
    x.max(F::ZERO)
}

/// `if c { a } else { b }` for finite `a`, `b`, as arithmetic:
/// `[c] a + [!c] b` with exact 0/1 weights. A plain `if` on floats can be
/// compiled into a branch (LLVM does so when an operand holds a division),
/// and branches on `q` mispredict in the pair loop. The weight is a
/// conversion of the bool, not `if c { 1 } else { 0 }`: LLVM compiled that
/// into a branch too, and the step ran 25-38 % slower (ARCHITECTURE.md).
#[inline(always)]
fn select<F: Real>(c: bool, a: F, b: F) -> F {
    let w = F::from_usize(usize::from(c));
    w * a + (F::ONE - w) * b
}

// Kernels are written branch-free: every piece is a truncated power
// `(k - q)_+^n`, and where `f'(q)/q` would divide by `q` near the origin the
// polynomial valid on `q < 1` is selected instead, so `F` is exact and finite
// at `q = 0`. Branches on `q` mispredict in the pair loop because `q` is
// spread evenly over the support.

/// Cubic B-spline M4 (Monaghan & Lattanzio 1985), support `2h`:
/// `f(q) = (2 - q)_+^3 / 4 - (1 - q)_+^3`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CubicSpline;

impl Kernel for CubicSpline {
    const NAME: &'static str = "cubic";
    const SUPPORT: f64 = 2.0;
    fn sigma(dim: usize) -> f64 {
        match dim {
            1 => 2.0 / 3.0,
            2 => 10.0 / (7.0 * PI),
            _ => 1.0 / PI,
        }
    }
    #[inline(always)]
    fn f<S: Space, M: Math<S::Real>>(q: S::Real) -> S::Real {
        let t1 = pos(S::Real::ONE - q);
        let t2 = pos(S::Real::TWO - q);
        c::<S::Real>(0.25) * pow3(t2) - pow3(t1)
    }
    #[inline(always)]
    fn df_q<S: Space, M: Math<S::Real>>(q: S::Real) -> S::Real {
        let q = q.min(S::Real::TWO);
        let inner = c::<S::Real>(-3.0) + c::<S::Real>(2.25) * q;
        let t2 = pos(S::Real::TWO - q);
        let outer = c::<S::Real>(-0.75) * pow2(t2) / q.max(S::Real::ONE);
        select(q < S::Real::ONE, inner, outer)
    }
}

/// Quintic B-spline M6 (Morris 1996), support `3h`:
/// `f(q) = (3 - q)_+^5 - 6 (2 - q)_+^5 + 15 (1 - q)_+^5`.
///
/// The 3D constant is `1 / (120 pi)`; the often quoted `3 / (359 pi)` is 0.3 % off.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct QuinticSpline;

impl Kernel for QuinticSpline {
    const NAME: &'static str = "quintic";
    const SUPPORT: f64 = 3.0;
    fn sigma(dim: usize) -> f64 {
        match dim {
            1 => 1.0 / 120.0,
            2 => 7.0 / (478.0 * PI),
            _ => 1.0 / (120.0 * PI),
        }
    }
    #[inline(always)]
    fn f<S: Space, M: Math<S::Real>>(q: S::Real) -> S::Real {
        let t1 = pos(S::Real::ONE - q);
        let t2 = pos(S::Real::TWO - q);
        let t3 = pos(c::<S::Real>(3.0) - q);
        pow5(t3) - c::<S::Real>(6.0) * pow5(t2) + c::<S::Real>(15.0) * pow5(t1)
    }
    #[inline(always)]
    fn df_q<S: Space, M: Math<S::Real>>(q: S::Real) -> S::Real {
        let q = q.min(c::<S::Real>(3.0));
        let inner =
            c::<S::Real>(-120.0) + c::<S::Real>(120.0) * q * q - c::<S::Real>(50.0) * q * q * q;
        let t2 = pos(S::Real::TWO - q);
        let t3 = pos(c::<S::Real>(3.0) - q);
        let outer =
            (c::<S::Real>(-5.0) * pow4(t3) + c::<S::Real>(30.0) * pow4(t2)) / q.max(S::Real::ONE);
        select(q < S::Real::ONE, inner, outer)
    }
}

/// Wendland C2 (Wendland 1995; Dehnen & Aly 2012), support `2h`.
///
/// 2D and 3D use psi_{3,1}; 1D uses its own polynomial psi_{1,1}. Free of the
/// pairing instability at any neighbour number.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WendlandC2;

impl Kernel for WendlandC2 {
    const NAME: &'static str = "wendland-c2";
    const SUPPORT: f64 = 2.0;
    fn sigma(dim: usize) -> f64 {
        match dim {
            1 => 5.0 / 8.0,
            2 => 7.0 / (4.0 * PI),
            _ => 21.0 / (16.0 * PI),
        }
    }
    #[inline(always)]
    fn f<S: Space, M: Math<S::Real>>(q: S::Real) -> S::Real {
        let t = pos(S::Real::ONE - S::Real::HALF * q);
        // Clamped so that `t = 0` times the factor stays 0 even for an infinite `q`.
        let q = q.min(S::Real::TWO);
        if S::DIM == 1 {
            pow3(t) * (S::Real::ONE + c::<S::Real>(1.5) * q)
        } else {
            pow4(t) * (S::Real::ONE + S::Real::TWO * q)
        }
    }
    #[inline(always)]
    fn df_q<S: Space, M: Math<S::Real>>(q: S::Real) -> S::Real {
        let t = pos(S::Real::ONE - S::Real::HALF * q);
        if S::DIM == 1 {
            c::<S::Real>(-3.0) * pow2(t)
        } else {
            c::<S::Real>(-5.0) * pow3(t)
        }
    }
}

/// Wendland C4, support `2h`.
///
/// 2D and 3D use psi_{3,2}; 1D uses psi_{1,2}.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WendlandC4;

impl Kernel for WendlandC4 {
    const NAME: &'static str = "wendland-c4";
    const SUPPORT: f64 = 2.0;
    fn sigma(dim: usize) -> f64 {
        match dim {
            1 => 3.0 / 4.0,
            2 => 9.0 / (4.0 * PI),
            _ => 495.0 / (256.0 * PI),
        }
    }
    #[inline(always)]
    fn f<S: Space, M: Math<S::Real>>(q: S::Real) -> S::Real {
        let t = pos(S::Real::ONE - S::Real::HALF * q);
        let q = q.min(S::Real::TWO);
        if S::DIM == 1 {
            pow5(t) * (S::Real::ONE + c::<S::Real>(2.5) * q + S::Real::TWO * q * q)
        } else {
            pow6(t) * (S::Real::ONE + c::<S::Real>(3.0) * q + c::<S::Real>(35.0 / 12.0) * q * q)
        }
    }
    #[inline(always)]
    fn df_q<S: Space, M: Math<S::Real>>(q: S::Real) -> S::Real {
        let t = pos(S::Real::ONE - S::Real::HALF * q);
        let q = q.min(S::Real::TWO);
        if S::DIM == 1 {
            c::<S::Real>(-3.5) * pow4(t) * (S::Real::ONE + S::Real::TWO * q)
        } else {
            c::<S::Real>(-14.0 / 3.0) * pow5(t) * (S::Real::ONE + c::<S::Real>(2.5) * q)
        }
    }
}

/// Gaussian truncated at `q = 3`, renormalised exactly after truncation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Gaussian;

impl Kernel for Gaussian {
    const NAME: &'static str = "gaussian";
    const SUPPORT: f64 = 3.0;
    fn sigma(dim: usize) -> f64 {
        let e9 = crate::math::f64s::exp(-9.0);
        let erf3 = crate::math::f64s::erf(3.0);
        match dim {
            1 => 1.0 / (crate::math::f64s::sqrt(PI) * erf3),
            2 => 1.0 / (PI * (1.0 - e9)),
            _ => 1.0 / (PI * crate::math::f64s::sqrt(PI) * erf3 - 6.0 * PI * e9),
        }
    }
    #[inline(always)]
    fn f<S: Space, M: Math<S::Real>>(q: S::Real) -> S::Real {
        let inside = q < c::<S::Real>(3.0);
        let q = q.min(c::<S::Real>(3.0));
        select(inside, M::exp(-q * q), S::Real::ZERO)
    }
    #[inline(always)]
    fn df_q<S: Space, M: Math<S::Real>>(q: S::Real) -> S::Real {
        let inside = q < c::<S::Real>(3.0);
        let q = q.min(c::<S::Real>(3.0));
        select(inside, c::<S::Real>(-2.0) * M::exp(-q * q), S::Real::ZERO)
    }
}

/// A kernel bound to a smoothing length `h`, with its factors precomputed.
///
/// `w(r2)` is `W` and `f(r2)` is `F = (1/r) dW/dr` (never positive), both
/// taking the squared distance so the pair loop computes one square root.
/// The gradient with respect to particle `i` is `F * r_ij`.
#[derive(Clone, Copy, Debug)]
pub struct SmoothingKernel<S: Space, K: Kernel, M: Math<S::Real>> {
    h: S::Real,
    inv_h: S::Real,
    cw: S::Real,
    cf: S::Real,
    radius: S::Real,
    radius2: S::Real,
    _marker: PhantomData<(K, M)>,
}

impl<S: Space, K: Kernel, M: Math<S::Real>> SmoothingKernel<S, K, M> {
    /// Binds the kernel to smoothing length `h`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if `h` is not positive and finite, or if its
    /// factors `sigma/h^d` or `sigma/h^(d+2)` overflow or vanish in `S::Real`.
    pub fn new(h: S::Real) -> Result<Self> {
        let hf = h.to_f64();
        if !(hf > 0.0 && hf.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "h",
                value: hf,
                rule: "smoothing length must be positive and finite",
            });
        }
        let sigma = K::sigma(S::DIM);
        // Integer powers by multiplication: exact enough, and no `pow` in the
        // image of a small firmware.
        let hd = (0..S::DIM).fold(1.0, |p, _| p * hf);
        let cw = S::Real::from_f64(sigma / hd);
        let cf = S::Real::from_f64(sigma / (hd * hf * hf));
        let radius = S::Real::from_f64(K::SUPPORT * hf);
        let ok = |x: S::Real| x.is_finite() && x > S::Real::ZERO;
        if !(ok(cw) && ok(cf) && ok(radius * radius)) {
            return Err(Error::InvalidParameter {
                name: "h",
                value: hf,
                rule: "kernel factors sigma/h^d and sigma/h^(d+2) must be finite and non-zero in this precision",
            });
        }
        Ok(Self {
            h,
            inv_h: S::Real::ONE / h,
            cw,
            cf,
            radius,
            radius2: radius * radius,
            _marker: PhantomData,
        })
    }

    /// The smoothing length.
    #[inline(always)]
    pub fn h(&self) -> S::Real {
        self.h
    }

    /// Support radius `kappa * h`.
    #[inline(always)]
    pub fn radius(&self) -> S::Real {
        self.radius
    }

    /// Squared support radius.
    #[inline(always)]
    pub fn radius2(&self) -> S::Real {
        self.radius2
    }

    #[inline(always)]
    fn q(&self, r2: S::Real) -> S::Real {
        M::sqrt(r2) * self.inv_h
    }

    /// `W` at squared distance `r2`.
    #[inline(always)]
    pub fn w(&self, r2: S::Real) -> S::Real {
        self.cw * K::f::<S, M>(self.q(r2))
    }

    /// `F = (1/r) dW/dr` at squared distance `r2` (finite at `r = 0`).
    #[inline(always)]
    pub fn f(&self, r2: S::Real) -> S::Real {
        self.cf * K::df_q::<S, M>(self.q(r2))
    }

    /// Both `W` and `F`, sharing one square root.
    #[inline(always)]
    pub fn w_and_f(&self, r2: S::Real) -> (S::Real, S::Real) {
        let q = self.q(r2);
        (self.cw * K::f::<S, M>(q), self.cf * K::df_q::<S, M>(q))
    }

    /// Gradient of `W` with respect to `x_i` for separation `r_ij = x_i - x_j`.
    #[inline(always)]
    pub fn gradient(&self, r_ij: S::Vector) -> S::Vector {
        r_ij * self.f(r_ij.norm2())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Libm;
    use crate::space::{Vector, D1, D2, D3};

    /// Radial integral of `sigma f(q)` times the surface of the unit sphere,
    /// by composite Simpson on each polynomial piece `[k, k+1]`.
    fn radial_integral<S: Space<Real = f64>, K: Kernel>() -> f64 {
        let surface = match S::DIM {
            1 => 2.0,
            2 => 2.0 * PI,
            _ => 4.0 * PI,
        };
        let mut total = 0.0;
        let pieces = K::SUPPORT as usize;
        let n = 2000;
        for k in 0..pieces {
            let (a, b) = (k as f64, k as f64 + 1.0);
            let step = (b - a) / n as f64;
            let g = |q: f64| K::f::<S, Libm>(q) * q.powi(S::DIM as i32 - 1);
            // Evaluate the open end just inside the piece so each piece sees its own polynomial.
            let edge = |q: f64| if q >= b { g(b - 1e-12) } else { g(q) };
            let mut s = g(a) + edge(b);
            for m in 1..n {
                let q = a + m as f64 * step;
                s += if m % 2 == 1 { 4.0 } else { 2.0 } * g(q);
            }
            total += s * step / 3.0;
        }
        total * surface * K::sigma(S::DIM)
    }

    fn check_normalised<K: Kernel>() {
        for (dim, integral) in [
            (1, radial_integral::<D1<f64>, K>()),
            (2, radial_integral::<D2<f64>, K>()),
            (3, radial_integral::<D3<f64>, K>()),
        ] {
            assert!(
                (integral - 1.0).abs() < 1e-6,
                "{} in {dim}D integrates to {integral}",
                K::NAME
            );
        }
    }

    #[test]
    fn cubic_is_normalised() {
        check_normalised::<CubicSpline>();
    }
    #[test]
    fn quintic_is_normalised() {
        check_normalised::<QuinticSpline>();
    }
    #[test]
    fn wendland_c2_is_normalised() {
        check_normalised::<WendlandC2>();
    }
    #[test]
    fn wendland_c4_is_normalised() {
        check_normalised::<WendlandC4>();
    }
    #[test]
    fn gaussian_is_normalised() {
        check_normalised::<Gaussian>();
    }

    /// An independent check of the 2D constants: the Cartesian lattice sum
    /// `dx^2 sum W` tends to one as `dx / h -> 0`.
    fn lattice_sum_2d<K: Kernel>(h: f64, dx: f64) -> f64 {
        let k = SmoothingKernel::<D2<f64>, K, Libm>::new(h).unwrap();
        let n = (K::SUPPORT * h / dx) as i64 + 2;
        let mut s = 0.0;
        for a in -n..=n {
            for b in -n..=n {
                let (x, y) = (a as f64 * dx, b as f64 * dx);
                s += k.w(x * x + y * y);
            }
        }
        s * dx * dx
    }

    #[test]
    fn lattice_sums_tend_to_one() {
        for (name, s) in [
            ("cubic", lattice_sum_2d::<CubicSpline>(1.0, 0.05)),
            ("quintic", lattice_sum_2d::<QuinticSpline>(1.0, 0.05)),
            ("wendland-c2", lattice_sum_2d::<WendlandC2>(1.0, 0.05)),
            ("wendland-c4", lattice_sum_2d::<WendlandC4>(1.0, 0.05)),
            ("gaussian", lattice_sum_2d::<Gaussian>(1.0, 0.05)),
        ] {
            assert!((s - 1.0).abs() < 1e-4, "{name}: lattice sum {s}");
        }
    }

    fn check_derivative<S: Space<Real = f64>, K: Kernel>() {
        let h = 0.7;
        let k = SmoothingKernel::<S, K, Libm>::new(h).unwrap();
        let radius = K::SUPPORT * h;
        let delta = 1e-6 * h;
        for m in 1..300 {
            let r = radius * m as f64 / 300.0;
            let fd =
                (k.w((r + delta) * (r + delta)) - k.w((r - delta) * (r - delta))) / (2.0 * delta);
            let analytic = k.f(r * r) * r;
            let scale = k.f(0.0).abs() * h;
            assert!(
                (fd - analytic).abs() <= 1e-6 * scale,
                "{} {}D at r/h = {}: finite difference {fd}, analytic {analytic}",
                K::NAME,
                S::DIM,
                r / h
            );
        }
    }

    fn check_all_dims<K: Kernel>() {
        check_derivative::<D1<f64>, K>();
        check_derivative::<D2<f64>, K>();
        check_derivative::<D3<f64>, K>();
    }

    #[test]
    fn gradients_match_finite_differences() {
        check_all_dims::<CubicSpline>();
        check_all_dims::<QuinticSpline>();
        check_all_dims::<WendlandC2>();
        check_all_dims::<WendlandC4>();
        check_all_dims::<Gaussian>();
    }

    fn check_support_sign_and_origin<K: Kernel>() {
        let h = 1.3;
        let k = SmoothingKernel::<D2<f64>, K, Libm>::new(h).unwrap();
        let radius = K::SUPPORT * h;
        // Vanishes at and beyond the support.
        for r in [radius, radius * 1.000001, radius * 2.0, 1e300] {
            assert_eq!(k.w(r * r), 0.0, "{}", K::NAME);
            assert_eq!(k.f(r * r), 0.0, "{}", K::NAME);
        }
        // Non-negative, non-increasing, and F never positive inside.
        let mut last = f64::INFINITY;
        for m in 0..=400 {
            let r = radius * m as f64 / 400.0;
            let (w, f) = k.w_and_f(r * r);
            assert!(
                w >= 0.0 && w <= last + 1e-15,
                "{} not monotone at {r}",
                K::NAME
            );
            assert!(f <= 0.0, "{}: F = {f} > 0 at r = {r}", K::NAME);
            last = w;
        }
        // The gradient is exactly zero at r = 0 (no NaN) and odd in r_ij.
        let g0 = k.gradient(Vector::new([0.0, 0.0]));
        assert_eq!(g0, Vector::new([0.0, 0.0]));
        assert!(k.f(0.0).is_finite());
        let r = Vector::new([0.4, -0.9]);
        assert_eq!(k.gradient(-r), -k.gradient(r));
    }

    #[test]
    fn kernels_have_compact_support_and_odd_gradients() {
        check_support_sign_and_origin::<CubicSpline>();
        check_support_sign_and_origin::<QuinticSpline>();
        check_support_sign_and_origin::<WendlandC2>();
        check_support_sign_and_origin::<WendlandC4>();
        check_support_sign_and_origin::<Gaussian>();
    }

    #[test]
    fn single_precision_agrees_with_double() {
        let k32 = SmoothingKernel::<D3<f32>, QuinticSpline, Libm>::new(2e-5).unwrap();
        let k64 = SmoothingKernel::<D3<f64>, QuinticSpline, Libm>::new(2e-5).unwrap();
        for m in 0..60 {
            let r = 6e-5 * m as f64 / 60.0;
            let w32 = k32.w((r * r) as f32) as f64;
            let w64 = k64.w(r * r);
            assert!((w32 - w64).abs() <= 1e-5 * k64.w(0.0), "r = {r}");
        }
    }

    #[test]
    fn bad_smoothing_lengths_are_errors() {
        for h in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                SmoothingKernel::<D2<f64>, CubicSpline, Libm>::new(h),
                Err(Error::InvalidParameter { name: "h", .. })
            ));
        }
        // sigma / h^5 underflows f32 for a tiny h: reported, not silently zero.
        assert!(SmoothingKernel::<D3<f32>, CubicSpline, Libm>::new(1e-12).is_err());
    }
}
