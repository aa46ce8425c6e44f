//! How a pass is run over particle ranges: the [`Executor`] trait.
//!
//! Every per-particle pass of a step writes only the outputs of the particles
//! it is given and reads shared state, so any split of `0..N` into ranges, run
//! in any order on any thread, gives bitwise the same result. The core never
//! names a thread: it hands an executor the mutable output slices (as a
//! [`Chunk`]) and a closure; [`Serial`] runs it in one call, and a frontend
//! can split the slices and run the pieces in parallel (`sph-std` does so
//! with rayon) in safe Rust alone.

use crate::error::Result;
use crate::real::Real;

/// Mutable per-particle slices that can be split at an index, together.
pub trait Chunk: Send + Sized {
    /// Number of particles covered.
    fn len(&self) -> usize;
    /// True if no particles are covered.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Splits into `[0, mid)` and `[mid, len)`.
    fn split_at(self, mid: usize) -> (Self, Self);
}

impl<T: Send> Chunk for &mut [T] {
    fn len(&self) -> usize {
        <[T]>::len(self)
    }
    fn split_at(self, mid: usize) -> (Self, Self) {
        self.split_at_mut(mid)
    }
}

/// A buffer of fixed-width rows (one row per particle) split at row boundaries.
#[derive(Debug)]
pub struct Rows<'a, T> {
    /// The entries, `width` per row.
    pub data: &'a mut [T],
    /// Entries per row (at least one).
    pub width: usize,
}

impl<T: Send> Chunk for Rows<'_, T> {
    fn len(&self) -> usize {
        self.data.len() / self.width.max(1)
    }
    fn split_at(self, mid: usize) -> (Self, Self) {
        let width = self.width.max(1);
        let (a, b) = self.data.split_at_mut((mid * width).min(self.data.len()));
        (Rows { data: a, width }, Rows { data: b, width })
    }
}

macro_rules! chunk_tuple {
    ($($T:ident $v:ident $i:tt),+) => {
        impl<$($T: Chunk),+> Chunk for ($($T,)+) {
            fn len(&self) -> usize {
                self.0.len()
            }
            fn split_at(self, mid: usize) -> (Self, Self) {
                $(let $v = self.$i.split_at(mid);)+
                (($($v.0,)+), ($($v.1,)+))
            }
        }
    };
}

chunk_tuple!(A a 0, B b 1);
chunk_tuple!(A a 0, B b 1, C c 2);
chunk_tuple!(A a 0, B b 1, C c 2, D d 3);
chunk_tuple!(A a 0, B b 1, C c 2, D d 3, E e 4);

/// A value combined across ranges (associative; `identity` is neutral).
pub trait Reduce: Send + Sized {
    /// The neutral element.
    fn identity() -> Self;
    /// Combines the results of two adjacent ranges, left first.
    fn combine(self, right: Self) -> Self;
}

impl Reduce for () {
    fn identity() -> Self {}
    fn combine(self, _right: Self) -> Self {}
}

/// Component-wise maximum of two non-negative quantities.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Max2<F>(pub F, pub F);

impl<F: Real> Reduce for Max2<F> {
    fn identity() -> Self {
        Max2(F::ZERO, F::ZERO)
    }
    fn combine(self, right: Self) -> Self {
        Max2(self.0.max(right.0), self.1.max(right.1))
    }
}

/// Runs a per-range closure over a split of `0..parts.len()`.
///
/// Contract: `f(start, piece)` is called on pieces that together cover the
/// whole range exactly once; results are combined left to right with
/// [`Reduce::combine`], and if any piece fails, the error of the leftmost
/// failing piece is returned (so the reported error does not depend on the
/// split).
pub trait Executor: Sync {
    /// Runs `f` over `parts`.
    ///
    /// # Errors
    /// The leftmost error returned by `f`.
    fn run<P: Chunk, R: Reduce>(
        &self,
        parts: P,
        f: &(dyn Fn(usize, P) -> Result<R> + Sync),
    ) -> Result<R>;
}

/// Runs the whole range in one call on the current thread.
#[derive(Clone, Copy, Debug, Default)]
pub struct Serial;

impl Executor for Serial {
    fn run<P: Chunk, R: Reduce>(
        &self,
        parts: P,
        f: &(dyn Fn(usize, P) -> Result<R> + Sync),
    ) -> Result<R> {
        f(0, parts)
    }
}

/// Runs fixed-size pieces one after the other on the current thread; a
/// reference for split independence, and a way to bound per-call latency.
#[derive(Clone, Copy, Debug)]
pub struct Chunked {
    /// Particles per piece (at least one).
    pub size: usize,
}

impl Executor for Chunked {
    fn run<P: Chunk, R: Reduce>(
        &self,
        parts: P,
        f: &(dyn Fn(usize, P) -> Result<R> + Sync),
    ) -> Result<R> {
        let size = self.size.max(1);
        let mut acc = R::identity();
        let mut rest = parts;
        let mut start = 0;
        loop {
            let len = rest.len();
            if len <= size {
                return Ok(acc.combine(f(start, rest)?));
            }
            let (head, tail) = rest.split_at(size);
            acc = acc.combine(f(start, head)?);
            start += size;
            rest = tail;
        }
    }
}

/// Runs `f` through `exec`, refusing any piece that the executor hands out
/// beyond the range it was given (a wrong start offset): the passes index
/// shared arrays with `start + k`, so a bad offset is an error here rather
/// than an out-of-bounds access.
pub(crate) fn run_checked<E: Executor, P: Chunk, R: Reduce>(
    exec: &E,
    parts: P,
    f: &(dyn Fn(usize, P) -> Result<R> + Sync),
) -> Result<R> {
    let total = parts.len();
    exec.run(
        parts,
        &|start, piece: P| match start.checked_add(piece.len()) {
            Some(end) if end <= total => f(start, piece),
            _ => Err(crate::error::Error::InvalidParameter {
                name: "start",
                value: start as f64,
                rule: "an executor handed a pass a piece beyond the range it was given",
            }),
        },
    )
}
