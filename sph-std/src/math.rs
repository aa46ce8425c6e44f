//! The frontend's math backend: [`Host`].
//!
//! sph-core's [`Libm`] takes every function from the `libm` crate, which on
//! x86-64 computes a square root with inline assembly in the legacy SSE
//! encoding (`sqrtsd`). Built for a CPU with AVX (`RUSTFLAGS="-C
//! target-cpu=native"` on most machines of the last decade), the code
//! around it is VEX-encoded, and each such `sqrtsd` pays a transition
//! between the two encodings: the 2D box's f64 step measured 20 times
//! slower on an AVX-512 Xeon (`cargo bench -p sph-core --bench core --
//! steps::summation_f64`, `summation_f64` against `summation_f64_host`,
//! with and without that flag). Inline assembly also hides the operation
//! from the optimiser.
//!
//! [`Host`] takes the square root from the compiler's intrinsic instead
//! (`f64::sqrt`, `f32::sqrt`), which the standard library provides and the
//! no_std core cannot call on stable Rust. IEEE 754 requires the square root
//! to be correctly rounded, and libm's is too, so both give the same bits
//! for every input; the other functions are libm's. Every scene, study and
//! benchmark of this crate runs on [`Host`] where a configuration says
//! `math = "libm"`; results are those of [`Libm`], bit for bit.

use sph_core::math::{Libm, Math};

/// libm's functions with the compiler's square root (see the module docs):
/// the same bits as [`Libm`], without its inline assembly.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Host;

/// One backend for both precisions: the square root from std, the rest
/// from [`Libm`].
macro_rules! host_math {
    ($t:ty) => {
        impl Math<$t> for Host {
            const NAME: &'static str = "libm";
            #[inline(always)]
            fn sqrt(x: $t) -> $t {
                x.sqrt()
            }
            #[inline(always)]
            fn exp(x: $t) -> $t {
                <Libm as Math<$t>>::exp(x)
            }
            #[inline(always)]
            fn powf(x: $t, y: $t) -> $t {
                <Libm as Math<$t>>::powf(x, y)
            }
            #[inline(always)]
            fn floor(x: $t) -> $t {
                <Libm as Math<$t>>::floor(x)
            }
        }
    };
}

host_math!(f64);
host_math!(f32);

#[cfg(test)]
mod tests {
    use super::*;

    /// Values across the whole range, both signs, subnormals, zeros,
    /// infinities and NaN, from a fixed sequence of random bit patterns.
    fn patterns(count: usize) -> Vec<u64> {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut out: Vec<u64> = (0..count)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                state
            })
            .collect();
        out.extend([0, 1, 2, 0x000f_ffff_ffff_ffff, 0x0010_0000_0000_0000]);
        for special in [
            0.0f64,
            -0.0,
            1.0,
            2.0,
            0.25,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ] {
            out.push(special.to_bits());
        }
        out
    }

    /// The same bits, or both NaN. A NaN's sign and payload are not
    /// specified (the optimiser may replace one NaN by another), so only
    /// NaN-ness is compared there, each value tested on its own.
    fn same64(a: f64, b: f64) -> bool {
        (a.is_nan() && b.is_nan()) || a.to_bits() == b.to_bits()
    }

    fn same32(a: f32, b: f32) -> bool {
        (a.is_nan() && b.is_nan()) || a.to_bits() == b.to_bits()
    }

    #[test]
    fn the_square_root_has_libms_bits_in_both_precisions() {
        for bits in patterns(200_000) {
            let x = f64::from_bits(bits);
            let (host, libm) = (<Host as Math<f64>>::sqrt(x), <Libm as Math<f64>>::sqrt(x));
            assert!(
                same64(host, libm),
                "sqrt({x:e}) in f64: {host:e} against {libm:e}"
            );
            // The low and high halves as f32 patterns.
            for half in [bits as u32, (bits >> 32) as u32] {
                let y = f32::from_bits(half);
                let (host, libm) = (<Host as Math<f32>>::sqrt(y), <Libm as Math<f32>>::sqrt(y));
                assert!(
                    same32(host, libm),
                    "sqrt({y:e}) in f32: {host:e} against {libm:e}"
                );
            }
        }
    }

    #[test]
    fn squares_of_representable_roots_come_back_exactly() {
        // r * r is exact for r with at most 26 significant bits, so its
        // correctly rounded root is r itself: a check that needs no reference.
        for k in 1..=4096u32 {
            let r = f64::from(k) * 0.125;
            assert_eq!(<Host as Math<f64>>::sqrt(r * r), r);
            let r32 = k as f32 * 0.125;
            assert_eq!(<Host as Math<f32>>::sqrt(r32 * r32), r32);
        }
        assert!(<Host as Math<f64>>::sqrt(-1.0).is_nan());
        assert_eq!(
            <Host as Math<f64>>::sqrt(-0.0).to_bits(),
            (-0.0f64).to_bits()
        );
    }

    #[test]
    fn the_other_functions_are_libms() {
        for x in [-3.5f64, -0.1, 0.0, 0.7, 1.0, 2.5, 40.0] {
            assert_eq!(
                <Host as Math<f64>>::exp(x).to_bits(),
                <Libm as Math<f64>>::exp(x).to_bits()
            );
            assert_eq!(
                <Host as Math<f64>>::floor(x).to_bits(),
                <Libm as Math<f64>>::floor(x).to_bits()
            );
            let b = x.abs() + 0.5;
            assert_eq!(
                <Host as Math<f64>>::powf(b, 7.0).to_bits(),
                <Libm as Math<f64>>::powf(b, 7.0).to_bits()
            );
        }
    }
}
