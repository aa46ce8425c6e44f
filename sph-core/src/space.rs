//! Dimension and precision in one sealed type parameter: [`Space`].
//!
//! `D1<F>`, `D2<F>` and `D3<F>` carry the float type `F` and the dimension;
//! their vectors are the small `Copy` type [`Vector`]. Every algorithm in the
//! core is generic over one `S: Space`.

use core::fmt::Debug;
use core::marker::PhantomData;
use core::ops::{Add, AddAssign, Index, IndexMut, Mul, MulAssign, Neg, Sub, SubAssign};

use crate::real::Real;

/// A fixed-size vector of `D` components.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vector<F, const D: usize>(pub [F; D]);

impl<F: Real, const D: usize> Default for Vector<F, D> {
    fn default() -> Self {
        Self([F::ZERO; D])
    }
}

impl<F: Real, const D: usize> Vector<F, D> {
    /// Builds a vector from its components.
    pub const fn new(components: [F; D]) -> Self {
        Self(components)
    }
}

impl<F: Real, const D: usize> Add for Vector<F, D> {
    type Output = Self;
    #[inline(always)]
    fn add(mut self, rhs: Self) -> Self {
        for a in 0..D {
            self.0[a] += rhs.0[a];
        }
        self
    }
}

impl<F: Real, const D: usize> Sub for Vector<F, D> {
    type Output = Self;
    #[inline(always)]
    fn sub(mut self, rhs: Self) -> Self {
        for a in 0..D {
            self.0[a] -= rhs.0[a];
        }
        self
    }
}

impl<F: Real, const D: usize> Neg for Vector<F, D> {
    type Output = Self;
    #[inline(always)]
    fn neg(mut self) -> Self {
        for a in 0..D {
            self.0[a] = -self.0[a];
        }
        self
    }
}

impl<F: Real, const D: usize> Mul<F> for Vector<F, D> {
    type Output = Self;
    #[inline(always)]
    fn mul(mut self, s: F) -> Self {
        for a in 0..D {
            self.0[a] *= s;
        }
        self
    }
}

impl<F: Real, const D: usize> AddAssign for Vector<F, D> {
    #[inline(always)]
    fn add_assign(&mut self, rhs: Self) {
        for a in 0..D {
            self.0[a] += rhs.0[a];
        }
    }
}

impl<F: Real, const D: usize> SubAssign for Vector<F, D> {
    #[inline(always)]
    fn sub_assign(&mut self, rhs: Self) {
        for a in 0..D {
            self.0[a] -= rhs.0[a];
        }
    }
}

impl<F: Real, const D: usize> MulAssign<F> for Vector<F, D> {
    #[inline(always)]
    fn mul_assign(&mut self, s: F) {
        for a in 0..D {
            self.0[a] *= s;
        }
    }
}

impl<F, const D: usize> Index<usize> for Vector<F, D> {
    type Output = F;
    #[inline(always)]
    fn index(&self, a: usize) -> &F {
        &self.0[a]
    }
}

impl<F, const D: usize> IndexMut<usize> for Vector<F, D> {
    #[inline(always)]
    fn index_mut(&mut self, a: usize) -> &mut F {
        &mut self.0[a]
    }
}

/// What the core needs of a vector type; implemented by [`Vector`].
pub trait VectorOps<F: Real>:
    Copy
    + Debug
    + Default
    + PartialEq
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Neg<Output = Self>
    + Mul<F, Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign<F>
    + Index<usize, Output = F>
    + IndexMut<usize>
{
    /// Number of components.
    const DIM: usize;
    /// The zero vector.
    fn zero() -> Self;
    /// A vector with every component `s`.
    fn splat(s: F) -> Self;
    /// Builds a vector component by component.
    fn from_fn(f: impl FnMut(usize) -> F) -> Self;
    /// Dot product.
    fn dot(self, other: Self) -> F;
    /// Squared Euclidean norm.
    #[inline(always)]
    fn norm2(self) -> F {
        self.dot(self)
    }
    /// True if every component is finite.
    fn is_finite(self) -> bool;
}

impl<F: Real, const D: usize> VectorOps<F> for Vector<F, D> {
    const DIM: usize = D;
    #[inline(always)]
    fn zero() -> Self {
        Self([F::ZERO; D])
    }
    #[inline(always)]
    fn splat(s: F) -> Self {
        Self([s; D])
    }
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> F) -> Self {
        let mut v = [F::ZERO; D];
        for (a, c) in v.iter_mut().enumerate() {
            *c = f(a);
        }
        Self(v)
    }
    #[inline(always)]
    fn dot(self, other: Self) -> F {
        let mut s = F::ZERO;
        for a in 0..D {
            s += self.0[a] * other.0[a];
        }
        s
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        self.0.iter().all(|c| c.is_finite())
    }
}

mod sealed {
    pub trait Sealed {}
    impl<F> Sealed for super::D1<F> {}
    impl<F> Sealed for super::D2<F> {}
    impl<F> Sealed for super::D3<F> {}
}

/// Dimension plus precision (sealed): [`D1`], [`D2`] or [`D3`] of `f32` or `f64`.
pub trait Space: sealed::Sealed + Copy + Debug + Default + Send + Sync + 'static {
    /// The float type.
    type Real: Real;
    /// Spatial dimension: 1, 2 or 3.
    const DIM: usize;
    /// Vectors in the working precision (positions relative to the scene origin, velocities).
    type Vector: VectorOps<Self::Real>;
    /// Vectors in `f64`, for absolute coordinates such as the scene origin.
    type Global: VectorOps<f64>;

    /// Converts a working-precision vector to `f64`.
    #[inline(always)]
    fn widen(v: Self::Vector) -> Self::Global {
        Self::Global::from_fn(|a| v[a].to_f64())
    }

    /// Converts an `f64` vector to the working precision (rounding).
    #[inline(always)]
    fn narrow(v: Self::Global) -> Self::Vector {
        Self::Vector::from_fn(|a| Self::Real::from_f64(v[a]))
    }
}

macro_rules! space {
    ($name:ident, $dim:literal, $doc:literal) => {
        #[doc = $doc]
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
        pub struct $name<F>(PhantomData<F>);

        impl<F: Real> Space for $name<F> {
            type Real = F;
            const DIM: usize = $dim;
            type Vector = Vector<F, $dim>;
            type Global = Vector<f64, $dim>;
        }
    };
}

space!(D1, 1, "One dimension with float type `F`.");
space!(D2, 2, "Two dimensions with float type `F`.");
space!(D3, 3, "Three dimensions with float type `F`.");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vector_arithmetic() {
        let a = Vector::new([1.0f64, 2.0]);
        let b = Vector::new([0.5f64, -1.0]);
        assert_eq!(a + b, Vector::new([1.5, 1.0]));
        assert_eq!(a - b, Vector::new([0.5, 3.0]));
        assert_eq!(-a, Vector::new([-1.0, -2.0]));
        assert_eq!(a * 2.0, Vector::new([2.0, 4.0]));
        assert_eq!(a.dot(b), -1.5);
        assert_eq!(a.norm2(), 5.0);
        assert!(!Vector::new([1.0f32, f32::NAN]).is_finite());
        assert_eq!(<D3<f32> as Space>::DIM, 3);
        let g = D2::<f32>::widen(Vector::new([0.5f32, 0.25]));
        assert_eq!(g, Vector::new([0.5f64, 0.25]));
    }
}
