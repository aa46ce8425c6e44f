//! A fixed-capacity owned store for embedded users, on `heapless`.
//!
//! [`Store<S, N, C>`] holds every buffer a [`crate::solver::Solver`] needs
//! for up to `N` particle slots (fluid plus ghosts) and `C` cell-list
//! entries, with no allocator: put it in a `static` or on the stack, `push`
//! the fluid particles, then hand [`Store::storage`] to the solver. Its size
//! is known at compile time: `core::mem::size_of::<Store<S, N, C>>()`.
//! It scans cells in every pass (no neighbour lists), the smallest memory bill.

use heapless::Vec;

use crate::boundary::Ghost;
use crate::error::{Error, Result};
use crate::real::Real;
use crate::solver::Storage;
use crate::space::{Space, VectorOps};

/// Fixed-capacity storage (see the module docs).
///
/// ```
/// use sph_core::prelude::*;
///
/// // 64 particle slots and 32 cell starts, no allocator.
/// let mut store: Store<D2<f32>, 64, 32> = Store::new();
/// store.push(Vector::new([0.1, 0.1]), Vector::zero(), 1.0, 1000.0)?;
/// assert_eq!(store.len(), 1);
/// let (storage, n_fluid) = store.storage()?;
/// assert_eq!((storage.x.len(), n_fluid), (64, 1));
/// # Ok::<(), Error>(())
/// ```
#[derive(Debug)]
pub struct Store<S: Space, const N: usize, const C: usize> {
    x: Vec<S::Vector, N>,
    v: Vec<S::Vector, N>,
    m: Vec<S::Real, N>,
    rho: Vec<S::Real, N>,
    p: Vec<S::Real, N>,
    ve: Vec<S::Vector, N>,
    dv: Vec<S::Vector, N>,
    drho: Vec<S::Real, N>,
    rho_aux: Vec<S::Real, N>,
    ghosts: Vec<Ghost, N>,
    cell_start: Vec<u32, C>,
    cell_sorted: Vec<u32, N>,
    cell_index: Vec<u32, N>,
    fluid: usize,
}

impl<S: Space, const N: usize, const C: usize> Default for Store<S, N, C> {
    fn default() -> Self {
        Self::new()
    }
}

impl<S: Space, const N: usize, const C: usize> Store<S, N, C> {
    /// An empty store.
    pub const fn new() -> Self {
        Self {
            x: Vec::new(),
            v: Vec::new(),
            m: Vec::new(),
            rho: Vec::new(),
            p: Vec::new(),
            ve: Vec::new(),
            dv: Vec::new(),
            drho: Vec::new(),
            rho_aux: Vec::new(),
            ghosts: Vec::new(),
            cell_start: Vec::new(),
            cell_sorted: Vec::new(),
            cell_index: Vec::new(),
            fluid: 0,
        }
    }

    /// Fluid particles pushed so far.
    pub fn len(&self) -> usize {
        self.fluid
    }

    /// True if no particle was pushed.
    pub fn is_empty(&self) -> bool {
        self.fluid == 0
    }

    /// Adds a fluid particle (position relative to the domain origin).
    ///
    /// # Errors
    /// [`Error::CapacityExceeded`] when all `N` slots are used.
    pub fn push(&mut self, x: S::Vector, v: S::Vector, m: S::Real, rho: S::Real) -> Result<()> {
        let full = Error::CapacityExceeded {
            buffer: "store",
            needed: self.fluid + 1,
            available: N,
        };
        self.x.truncate(self.fluid);
        self.v.truncate(self.fluid);
        self.m.truncate(self.fluid);
        self.rho.truncate(self.fluid);
        self.x.push(x).map_err(|_| full)?;
        self.v.push(v).map_err(|_| full)?;
        self.m.push(m).map_err(|_| full)?;
        self.rho.push(rho).map_err(|_| full)?;
        self.fluid += 1;
        Ok(())
    }

    /// Views every buffer at full capacity for a solver; returns the views
    /// and the number of fluid particles.
    ///
    /// # Errors
    /// Never in practice (every buffer is resized within its own capacity);
    /// reported as [`Error::CapacityExceeded`] rather than assumed.
    pub fn storage(&mut self) -> Result<(Storage<'_, S>, usize)> {
        let zero_v = S::Vector::zero();
        let zero = S::Real::ZERO;
        let err = |buffer| Error::CapacityExceeded {
            buffer,
            needed: N,
            available: N,
        };
        self.x.resize(N, zero_v).map_err(|_| err("x"))?;
        self.v.resize(N, zero_v).map_err(|_| err("v"))?;
        self.m.resize(N, zero).map_err(|_| err("m"))?;
        self.rho.resize(N, zero).map_err(|_| err("rho"))?;
        self.p.resize(N, zero).map_err(|_| err("p"))?;
        self.ve.resize(N, zero_v).map_err(|_| err("ve"))?;
        self.dv.resize(N, zero_v).map_err(|_| err("dv"))?;
        self.drho.resize(N, zero).map_err(|_| err("drho"))?;
        self.rho_aux.resize(N, zero).map_err(|_| err("rho_aux"))?;
        self.ghosts
            .resize(N, Ghost::default())
            .map_err(|_| err("ghosts"))?;
        self.cell_start
            .resize(C, 0)
            .map_err(|_| err("cell_start"))?;
        self.cell_sorted
            .resize(N, 0)
            .map_err(|_| err("cell_sorted"))?;
        self.cell_index
            .resize(N, 0)
            .map_err(|_| err("cell_index"))?;
        Ok((
            Storage {
                x: &mut self.x,
                v: &mut self.v,
                m: &mut self.m,
                rho: &mut self.rho,
                p: &mut self.p,
                ve: &mut self.ve,
                dv: &mut self.dv,
                drho: &mut self.drho,
                rho_aux: &mut self.rho_aux,
                ghosts: &mut self.ghosts,
                cell_start: &mut self.cell_start,
                cell_sorted: &mut self.cell_sorted,
                cell_index: &mut self.cell_index,
                neighbours: Default::default(),
                neighbour_counts: Default::default(),
                shift: Default::default(),
            },
            self.fluid,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::space::{Vector, D2};

    #[test]
    fn push_reports_capacity() {
        let mut store: Store<D2<f32>, 2, 16> = Store::new();
        let z = Vector::new([0.0f32, 0.0]);
        store.push(z, z, 1.0, 1.0).unwrap();
        store.push(z, z, 1.0, 1.0).unwrap();
        assert_eq!(
            store.push(z, z, 1.0, 1.0),
            Err(Error::CapacityExceeded {
                buffer: "store",
                needed: 3,
                available: 2
            })
        );
        let (s, n) = store.storage().unwrap();
        assert_eq!((s.x.len(), s.cell_start.len(), n), (2, 16, 2));
    }
}
