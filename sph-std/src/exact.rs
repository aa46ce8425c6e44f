//! Correctly rounded sums that split and merge without error, so that a sum
//! over particles has the same bits for any split of the particles over
//! threads or ranks (the accumulators are Neal's superaccumulators, from the
//! `xsum` crate).

use xsum::{Xsum, XsumAuto, XsumSmall};

/// The exact sum of the values added so far, rounded once on request.
pub struct ExactSum(XsumAuto);

impl core::fmt::Debug for ExactSum {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("ExactSum")
    }
}

impl Default for ExactSum {
    fn default() -> Self {
        Self(XsumAuto::new())
    }
}

impl ExactSum {
    /// An empty sum.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `x` exactly.
    pub fn add(&mut self, x: f64) {
        self.0.add(x);
    }

    /// The exact sum rounded to nearest (ties to even); `+0.0` when empty
    /// or zero. Non-finite values give what IEEE addition would (NaN, or an
    /// infinity of their sign).
    pub fn value(&mut self) -> f64 {
        let s = self.0.sum();
        if s == 0.0 {
            0.0
        } else {
            s
        }
    }

    /// Doubles whose exact sum is this sum's exact value, largest first
    /// (each the rounding of what the ones before it leave): the exact sum
    /// in a form that can be sent and merged. At most about 40 for any
    /// doubles, usually one to three.
    pub fn terms(self) -> Vec<f64> {
        let mut rest = self.0;
        let mut out = Vec::new();
        loop {
            let s = rest.sum();
            if s == 0.0 {
                return out;
            }
            out.push(s);
            if !s.is_finite() {
                return out;
            }
            // Exact: the accumulator holds `exact - s` with no rounding.
            rest.add(-s);
        }
    }
}

/// The correctly rounded sum of `values`: the same bits in any order.
pub fn sum(values: impl IntoIterator<Item = f64>) -> f64 {
    let mut s = ExactSum::new();
    for x in values {
        s.add(x);
    }
    s.value()
}

/// The correctly rounded sum of several [`ExactSum::terms`] lists.
pub fn merge<'a>(terms: impl IntoIterator<Item = &'a [f64]>) -> f64 {
    let mut s = XsumSmall::new();
    for t in terms {
        s.add_list(t);
    }
    let v = s.sum();
    if v == 0.0 {
        0.0
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pseudo-random sequence spanning many magnitudes and both signs.
    fn values(n: usize) -> Vec<f64> {
        let mut state: u64 = 0x2545_F491_4F6C_DD1D;
        (0..n)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let u = (state >> 11) as f64 / (1u64 << 53) as f64;
                let e = ((state & 0x3f) as i32) - 32;
                (2.0 * u - 1.0) * 2f64.powi(e)
            })
            .collect()
    }

    #[test]
    fn a_sum_is_the_same_in_any_order_and_any_split() {
        let v = values(5000);
        let whole = sum(v.iter().copied());
        let reversed = sum(v.iter().rev().copied());
        assert_eq!(whole.to_bits(), reversed.to_bits());
        for parts in [2, 3, 7] {
            let mut sums: Vec<ExactSum> = (0..parts).map(|_| ExactSum::new()).collect();
            for (k, x) in v.iter().enumerate() {
                sums[(k * 31) % parts].add(*x);
            }
            let terms: Vec<Vec<f64>> = sums.into_iter().map(ExactSum::terms).collect();
            let merged = merge(terms.iter().map(Vec::as_slice));
            assert_eq!(merged.to_bits(), whole.to_bits(), "{parts} parts");
        }
    }

    #[test]
    fn the_sum_is_exact_where_naive_addition_loses_everything() {
        // 1e16 + 1 - 1e16 in order: naive gives 0, the exact sum is 1.
        assert_eq!(sum([1e16, 1.0, -1e16]), 1.0);
        // Terms carry what a single double cannot: 1 + 2^-80 as two terms.
        let mut s = ExactSum::new();
        s.add(1.0);
        s.add(2f64.powi(-80));
        assert_eq!(s.terms(), vec![1.0, 2f64.powi(-80)]);
        assert_eq!(
            merge([&[1.0][..], &[2f64.powi(-80), -1.0][..]]),
            2f64.powi(-80)
        );
    }

    #[test]
    fn empty_and_cancelling_sums_are_positive_zero_and_non_finite_values_propagate() {
        assert_eq!(sum([]).to_bits(), 0.0f64.to_bits());
        assert_eq!(sum([1.5, -1.5]).to_bits(), 0.0f64.to_bits());
        assert!(ExactSum::new().terms().is_empty());
        assert!(sum([1.0, f64::NAN]).is_nan());
        assert_eq!(sum([1.0, f64::INFINITY]), f64::INFINITY);
    }
}
