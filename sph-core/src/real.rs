//! The floating-point scalar: [`Real`], implemented for `f32` and `f64` only.
//!
//! Everything that is not plain arithmetic (square roots, exponentials, floors)
//! goes through a [`Math`] backend, never through method syntax: in host builds
//! std's inherent float methods would silently win over a no_std backend.

use core::fmt::{Debug, Display};
use core::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

use crate::math::Math;

mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// A floating-point scalar the core computes in: `f32` or `f64` (sealed).
pub trait Real:
    sealed::Sealed
    + Copy
    + Default
    + Debug
    + Display
    + PartialEq
    + PartialOrd
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
{
    /// Zero.
    const ZERO: Self;
    /// One.
    const ONE: Self;
    /// One half.
    const HALF: Self;
    /// Two.
    const TWO: Self;
    /// Machine epsilon.
    const EPSILON: Self;
    /// Largest finite value.
    const MAX: Self;
    /// Smallest positive normal value.
    const MIN_POSITIVE: Self;
    /// Negative infinity.
    const NEG_INFINITY: Self;
    /// `"f32"` or `"f64"`.
    const NAME: &'static str;
    /// The math backend a scene gets when it names none: [`crate::math::Libm`],
    /// or [`crate::math::Micromath`] for `f32` with the `fast-math` feature.
    type DefaultMath: Math<Self>;

    /// Converts from `f64`, rounding to nearest.
    fn from_f64(x: f64) -> Self;
    /// Converts to `f64` (exact for both precisions).
    fn to_f64(self) -> f64;
    /// Converts a count.
    fn from_usize(n: usize) -> Self;
    /// True unless NaN or infinite.
    fn is_finite(self) -> bool;
    /// Absolute value (exact).
    fn abs(self) -> Self;
    /// Truncates toward zero into an `i64` (saturating; NaN gives 0).
    fn trunc_i64(self) -> i64;

    /// The larger of two values (`self` if they compare equal or unordered).
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        if other > self {
            other
        } else {
            self
        }
    }

    /// The smaller of two values (`self` if they compare equal or unordered).
    #[inline(always)]
    fn min(self, other: Self) -> Self {
        if other < self {
            other
        } else {
            self
        }
    }
}

macro_rules! impl_real {
    ($t:ty, $name:literal, $sign:expr, $default_math:ty) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const HALF: Self = 0.5;
            const TWO: Self = 2.0;
            const EPSILON: Self = <$t>::EPSILON;
            const MAX: Self = <$t>::MAX;
            const MIN_POSITIVE: Self = <$t>::MIN_POSITIVE;
            const NEG_INFINITY: Self = <$t>::NEG_INFINITY;
            const NAME: &'static str = $name;
            type DefaultMath = $default_math;

            #[inline(always)]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn from_usize(n: usize) -> Self {
                n as $t
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                // Clear the sign bit: exact, and no library call.
                <$t>::from_bits(self.to_bits() & !$sign)
            }
            #[inline(always)]
            fn trunc_i64(self) -> i64 {
                self as i64
            }
        }
    };
}

#[cfg(not(feature = "fast-math"))]
impl_real!(f32, "f32", 1u32 << 31, crate::math::Libm);
#[cfg(feature = "fast-math")]
impl_real!(f32, "f32", 1u32 << 31, crate::math::Micromath);
impl_real!(f64, "f64", 1u64 << 63, crate::math::Libm);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_round_trip_and_classify() {
        assert_eq!(f32::from_f64(0.5).to_f64(), 0.5);
        assert_eq!(f64::from_usize(7), 7.0);
        assert!(!Real::is_finite(f64::NAN));
        assert!(!Real::is_finite(f32::INFINITY));
        assert_eq!(Real::abs(-2.0f64), 2.0);
        assert_eq!(Real::abs(-0.0f32).to_bits(), 0);
        assert_eq!(Real::abs(f64::NEG_INFINITY), f64::INFINITY);
        assert_eq!(Real::trunc_i64(-1.5f64), -1);
        assert_eq!(Real::max(1.0f32, 2.0), 2.0);
        assert_eq!(Real::min(1.0f32, 2.0), 1.0);
    }
}
