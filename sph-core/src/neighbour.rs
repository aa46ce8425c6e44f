//! Neighbour search: an allocation-free cell list, and the brute-force reference.
//!
//! [`Grid`] covers the domain with cells at least one support radius wide
//! (along bounded axes it is padded by one radius on each side, where ghost
//! particles live). [`CellList`] sorts particle indices by cell with a counting
//! sort into three caller-provided `u32` buffers; the buffer sizes are asked of
//! the grid first ([`Grid::cell_count`]), so nothing is allocated.
//!
//! A neighbour of particle `i` is any `j` (including `i` itself) whose nearest
//! periodic image lies strictly closer than the support radius. The
//! separation is always computed as `(x_i - x_j) - shift`, with `shift` a
//! multiple of the period, in both the cell list and [`brute_force`], so the
//! two return exactly the same pairs, bit for bit.
//!
//! Within a cell, particles keep increasing index order and cells are visited
//! in a fixed order: the neighbour sequence of a particle depends only on the
//! positions, never on how work is split across threads.

use crate::domain::Domain;
use crate::error::{Error, Result};
use crate::real::Real;
use crate::space::{Space, VectorOps};

/// Relative widening of cells over the support radius, so that rounding in
/// the cell index can never hide a neighbour two cells away.
const CELL_MARGIN: f64 = 1e-3;

/// A uniform grid of cells over a domain (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid<S: Space> {
    lo: S::Vector,
    inv_cell: S::Vector,
    dims: [usize; 3],
    periodic: [bool; 3],
    period: S::Vector,
    radius2: S::Real,
}

impl<S: Space> Grid<S> {
    /// A grid for `domain` and support radius `radius`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if the radius is not positive and finite, a
    /// periodic extent is shorter than twice the radius (a particle would meet
    /// two images of one neighbour), or the cell count overflows.
    pub fn new(domain: &Domain<S>, radius: S::Real) -> Result<Self> {
        let r = radius.to_f64();
        if !(r > 0.0 && r.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "radius",
                value: r,
                rule: "the support radius must be positive and finite",
            });
        }
        let extent = domain.extent();
        let mut lo = S::Vector::zero();
        let mut inv_cell = S::Vector::zero();
        let mut dims = [1usize; 3];
        let mut periodic = [false; 3];
        let mut period = S::Vector::zero();
        let mut total: usize = 1;
        let wide = r * (1.0 + CELL_MARGIN);
        for a in 0..S::DIM {
            let l = extent[a].to_f64();
            let (n, cell, low) = if domain.is_periodic(a) {
                if l < 2.0 * r {
                    return Err(Error::InvalidParameter {
                        name: "extent",
                        value: l,
                        rule: "a periodic extent must be at least twice the kernel support radius",
                    });
                }
                periodic[a] = true;
                period[a] = extent[a];
                // Truncation is floor for these positive values.
                let n = ((l / wide) as u64).max(1) as f64;
                (n, l / n, 0.0)
            } else {
                let span = (l + 2.0 * wide) / wide;
                let n = if span.is_finite() && span < u32::MAX as f64 {
                    let t = span as u64;
                    if (t as f64) < span {
                        t + 1
                    } else {
                        t
                    }
                } else {
                    u64::MAX
                } as f64;
                (n, wide, -wide)
            };
            if !(n < u32::MAX as f64) {
                return Err(Error::InvalidParameter {
                    name: "radius",
                    value: r,
                    rule: "too many cells along an axis for this support radius",
                });
            }
            let n = n as usize;
            total = total
                .checked_mul(n)
                .filter(|&t| t < u32::MAX as usize)
                .ok_or(Error::InvalidParameter {
                    name: "radius",
                    value: r,
                    rule:
                        "the cell count overflows: the support radius is too small for this domain",
                })?;
            dims[a] = n;
            lo[a] = S::Real::from_f64(low);
            inv_cell[a] = S::Real::from_f64(1.0 / cell);
        }
        Ok(Self {
            lo,
            inv_cell,
            dims,
            periodic,
            period,
            radius2: radius * radius,
        })
    }

    /// Number of cells; a [`CellList`] needs `cell_count() + 1` entries in its
    /// `start` buffer.
    pub fn cell_count(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// Cells along each axis (1 for axes beyond the dimension).
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Squared support radius.
    pub fn radius2(&self) -> S::Real {
        self.radius2
    }

    /// Linear index of the cell holding `x`, or `None` outside the grid.
    #[inline]
    pub fn cell_of(&self, x: S::Vector) -> Option<usize> {
        let mut index = 0;
        let mut stride = 1;
        for a in 0..S::DIM {
            let t = (x[a] - self.lo[a]) * self.inv_cell[a];
            if !(t >= S::Real::ZERO) {
                return None;
            }
            let mut k = t.trunc_i64() as usize;
            if k >= self.dims[a] {
                // On a periodic axis only rounding can get here (x < period).
                if self.periodic[a] && k == self.dims[a] {
                    k = self.dims[a] - 1;
                } else {
                    return None;
                }
            }
            index += k * stride;
            stride *= self.dims[a];
        }
        Some(index)
    }

    /// The period along each axis (zero along bounded axes).
    pub fn period(&self) -> S::Vector {
        self.period
    }

    /// Up to three `(cell coordinate, shift, shift code)` candidates along
    /// axis `a` around coordinate `k`; returns how many were written. The
    /// code is 0 (no shift), 1 (`+period`) or 2 (`-period`).
    #[inline(always)]
    fn axis_candidates(&self, a: usize, k: usize, out: &mut [(usize, S::Real, u32); 3]) -> usize {
        if a >= S::DIM {
            out[0] = (0, S::Real::ZERO, 0);
            return 1;
        }
        let n = self.dims[a];
        let mut m = 0;
        for o in [-1i64, 0, 1] {
            let c = k as i64 + o;
            if c < 0 {
                if self.periodic[a] {
                    out[m] = ((c + n as i64) as usize, -self.period[a], 2);
                    m += 1;
                }
            } else if c as usize >= n {
                if self.periodic[a] {
                    out[m] = (c as usize - n, self.period[a], 1);
                    m += 1;
                }
            } else {
                out[m] = (c as usize, S::Real::ZERO, 0);
                m += 1;
            }
        }
        m
    }
}

/// A cell list over three caller-provided buffers (see the module docs).
#[derive(Debug)]
pub struct CellList<'a> {
    start: &'a mut [u32],
    sorted: &'a mut [u32],
    cell: &'a mut [u32],
    len: usize,
}

impl<'a> CellList<'a> {
    /// Wraps the buffers: `start` needs `grid.cell_count() + 1` entries,
    /// `sorted` and `cell` one per particle. Sizes are checked by [`Self::build`].
    pub fn new(start: &'a mut [u32], sorted: &'a mut [u32], cell: &'a mut [u32]) -> Self {
        Self {
            start,
            sorted,
            cell,
            len: 0,
        }
    }

    /// Sorts the particles at `x` into cells (stable counting sort, O(N + cells)).
    ///
    /// # Errors
    /// [`Error::CapacityExceeded`] if a buffer is too small;
    /// [`Error::OutsideDomain`] for a particle outside the grid.
    pub fn build<S: Space>(&mut self, grid: &Grid<S>, x: &[S::Vector]) -> Result<()> {
        let cells = grid.cell_count();
        let n = x.len();
        for (buffer, have, need) in [
            ("cell_start", self.start.len(), cells + 1),
            ("cell_sorted", self.sorted.len(), n),
            ("cell_index", self.cell.len(), n),
        ] {
            if have < need {
                return Err(Error::CapacityExceeded {
                    buffer,
                    needed: need,
                    available: have,
                });
            }
        }
        if n >= u32::MAX as usize {
            return Err(Error::CapacityExceeded {
                buffer: "particles",
                needed: n,
                available: u32::MAX as usize - 1,
            });
        }
        let start = &mut self.start[..cells + 1];
        start.fill(0);
        for (i, xi) in x.iter().enumerate() {
            let c = match grid.cell_of(*xi) {
                Some(c) => c,
                None => {
                    let axis = (0..S::DIM)
                        .find(|&a| {
                            let t = (xi[a] - grid.lo[a]) * grid.inv_cell[a];
                            !(t >= S::Real::ZERO && (t.trunc_i64() as usize) <= grid.dims[a])
                        })
                        .unwrap_or(0);
                    return Err(Error::OutsideDomain {
                        particle: i,
                        axis,
                        coordinate: xi[axis].to_f64(),
                    });
                }
            };
            self.cell[i] = c as u32;
            start[c + 1] += 1;
        }
        for c in 0..cells {
            start[c + 1] += start[c];
        }
        // Place particles; `start[c]` is used as a cursor and restored below.
        for i in 0..n {
            let c = self.cell[i] as usize;
            self.sorted[start[c] as usize] = i as u32;
            start[c] += 1;
        }
        for c in (1..=cells).rev() {
            start[c] = start[c - 1];
        }
        start[0] = 0;
        self.len = n;
        Ok(())
    }

    /// Number of particles sorted by the last build (0 before the first
    /// build and after [`Self::order_of_first`]).
    pub fn len(&self) -> usize {
        self.len
    }

    /// True if no particles are sorted.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The three buffers, whole: `(cell_start, cell_sorted, cell_index)`.
    pub fn buffers(&self) -> (&[u32], &[u32], &[u32]) {
        (self.start, self.sorted, self.cell)
    }

    /// Takes the buffers as they are, as left by a build of `len` particles
    /// on a grid of `cells` cells (a restored checkpoint), after checking
    /// that they are consistent: starts non-decreasing up to `len`, every
    /// sorted index below `len`, every cell index below `cells`.
    ///
    /// # Errors
    /// [`Error::CapacityExceeded`] or [`Error::InvalidParameter`] naming the
    /// buffer that does not hold a cell list.
    pub fn restore(&mut self, cells: usize, len: usize) -> Result<()> {
        for (buffer, have, need) in [
            ("cell_start", self.start.len(), cells + 1),
            ("cell_sorted", self.sorted.len(), len),
            ("cell_index", self.cell.len(), len),
        ] {
            if have < need {
                return Err(Error::CapacityExceeded {
                    buffer,
                    needed: need,
                    available: have,
                });
            }
        }
        let bad = |name| Error::InvalidParameter {
            name,
            value: len as f64,
            rule: "the restored cell list is not consistent",
        };
        if len > 0 {
            let start = &self.start[..cells + 1];
            if start[0] != 0 || start[cells] as usize != len {
                return Err(bad("cell_start"));
            }
            if start.windows(2).any(|w| w[0] > w[1]) {
                return Err(bad("cell_start"));
            }
            if self.sorted[..len].iter().any(|&j| j as usize >= len) {
                return Err(bad("cell_sorted"));
            }
            if self.cell[..len].iter().any(|&c| c as usize >= cells) {
                return Err(bad("cell_index"));
            }
        }
        self.len = len;
        Ok(())
    }

    /// Writes the indices below `n` in cell order (the order of the last
    /// build) into the per-particle cell-index buffer and returns them; that
    /// buffer is rebuilt by the next [`Self::build`]. `None` unless the last
    /// build covered at least `n` particles.
    pub fn order_of_first(&mut self, n: usize) -> Option<&[u32]> {
        if self.len < n {
            return None;
        }
        let mut k = 0;
        for &j in &self.sorted[..self.len] {
            if (j as usize) < n {
                self.cell[k] = j;
                k += 1;
            }
        }
        self.len = 0; // the cell indices are gone: the list must be rebuilt
        Some(&self.cell[..k])
    }

    /// Read-only view for the neighbour loops.
    pub fn view(&self) -> CellView<'_> {
        CellView {
            start: self.start,
            sorted: &self.sorted[..self.len],
            cell: &self.cell[..self.len],
        }
    }
}

/// A built cell list, shared by every thread during a pass.
#[derive(Clone, Copy, Debug)]
pub struct CellView<'a> {
    start: &'a [u32],
    sorted: &'a [u32],
    cell: &'a [u32],
}

impl CellView<'_> {
    /// Number of particles sorted.
    pub fn len(&self) -> usize {
        self.sorted.len()
    }

    /// True if no particles were sorted.
    pub fn is_empty(&self) -> bool {
        self.sorted.is_empty()
    }

    /// Particle indices in cell order.
    pub fn sorted(&self) -> &[u32] {
        self.sorted
    }

    /// Calls `f(j, r_ij, r2)` for every neighbour `j` of particle `i`
    /// (including `i`), where `r_ij` is the separation to `j`'s nearest image
    /// and `r2 = |r_ij|^2 < radius^2`. `x` and `grid` must be those the list
    /// was built from.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] (nothing is visited) if `i` is not a
    /// particle of the list, `x` is shorter than the list, or `grid` has
    /// fewer cells than the list was built for.
    #[inline(always)]
    pub fn for_each_neighbour<S: Space>(
        &self,
        grid: &Grid<S>,
        x: &[S::Vector],
        i: usize,
        mut f: impl FnMut(usize, S::Vector, S::Real),
    ) -> Result<()> {
        self.for_each_neighbour_coded(grid, x, i, |j, _, d, r2| f(j, d, r2))
    }

    /// As [`Self::for_each_neighbour`], also passing the image's shift code:
    /// two bits per axis `a` at bit `2a`, 0 for no shift, 1 for `+period`, 2
    /// for `-period`, so that `r_ij = (x_i - x_j) - shift`.
    ///
    /// # Errors
    /// As [`Self::for_each_neighbour`].
    #[inline(always)]
    pub fn for_each_neighbour_coded<S: Space>(
        &self,
        grid: &Grid<S>,
        x: &[S::Vector],
        i: usize,
        f: impl FnMut(usize, u32, S::Vector, S::Real),
    ) -> Result<()> {
        let bad = |name, value: usize, rule| {
            Err(Error::InvalidParameter {
                name,
                value: value as f64,
                rule,
            })
        };
        if i >= self.sorted.len() {
            return bad("i", i, "the particle must be one of the cell list's");
        }
        if x.len() < self.sorted.len() {
            return bad(
                "x",
                x.len(),
                "the positions must cover every particle of the cell list",
            );
        }
        let cells = grid.cell_count();
        if self.start.len() <= cells || self.cell[i] as usize >= cells {
            return bad(
                "grid",
                cells,
                "the grid must be the one the cell list was built on",
            );
        }
        self.visit_coded(grid, x, i, f);
        Ok(())
    }

    /// [`Self::for_each_neighbour_coded`] without the checks, for the
    /// solver, whose lists, positions and grid always belong together.
    #[inline(always)]
    pub(crate) fn visit_coded<S: Space>(
        &self,
        grid: &Grid<S>,
        x: &[S::Vector],
        i: usize,
        mut f: impl FnMut(usize, u32, S::Vector, S::Real),
    ) {
        let xi = x[i];
        let ci = self.cell[i] as usize;
        let k = [
            ci % grid.dims[0],
            (ci / grid.dims[0]) % grid.dims[1],
            ci / (grid.dims[0] * grid.dims[1]),
        ];
        let mut cand = [[(0usize, S::Real::ZERO, 0u32); 3]; 3];
        let mut count = [0usize; 3];
        for a in 0..3 {
            count[a] = grid.axis_candidates(a, k[a], &mut cand[a]);
        }
        let (d0, d01) = (grid.dims[0], grid.dims[0] * grid.dims[1]);
        for &(c2, s2, k2) in &cand[2][..count[2]] {
            for &(c1, s1, k1) in &cand[1][..count[1]] {
                for &(c0, s0, k0) in &cand[0][..count[0]] {
                    let code = k0 | (k1 << 2) | (k2 << 4);
                    let mut shift = S::Vector::zero();
                    shift[0] = s0;
                    if S::DIM > 1 {
                        shift[1] = s1;
                    }
                    if S::DIM > 2 {
                        shift[2] = s2;
                    }
                    let c = c0 + c1 * d0 + c2 * d01;
                    let (lo, hi) = (self.start[c] as usize, self.start[c + 1] as usize);
                    for &j in &self.sorted[lo..hi] {
                        let j = j as usize;
                        let d = (xi - x[j]) - shift;
                        let r2 = d.norm2();
                        if r2 < grid.radius2 {
                            f(j, code, d, r2);
                        }
                    }
                }
            }
        }
    }
}

/// The O(N^2) reference: calls `f(i, j, r_ij, r2)` for every ordered pair
/// (including `i == j`) closer than `radius`, using the nearest periodic image.
pub fn brute_force<S: Space>(
    domain: &Domain<S>,
    x: &[S::Vector],
    radius: S::Real,
    mut f: impl FnMut(usize, usize, S::Vector, S::Real),
) {
    let extent = domain.extent();
    let radius2 = radius * radius;
    for (i, &xi) in x.iter().enumerate() {
        for (j, &xj) in x.iter().enumerate() {
            let mut d = xi - xj;
            let mut shift = S::Vector::zero();
            for a in 0..S::DIM {
                if domain.is_periodic(a) {
                    let l = extent[a];
                    if d[a] > l * S::Real::HALF {
                        shift[a] = l;
                    } else if d[a] < -(l * S::Real::HALF) {
                        shift[a] = -l;
                    }
                }
            }
            d -= shift;
            let r2 = d.norm2();
            if r2 < radius2 {
                f(i, j, d, r2);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::{Side, Wall};
    use crate::space::{Vector, D2, D3};
    use proptest::prelude::*;
    use std::vec::Vec;

    type V2 = Vector<f64, 2>;

    fn pairs_by_cells<S: Space>(
        domain: &Domain<S>,
        x: &[S::Vector],
        radius: S::Real,
    ) -> Vec<(usize, usize, S::Vector)> {
        let grid = Grid::new(domain, radius).unwrap();
        let mut start = std::vec![0u32; grid.cell_count() + 1];
        let mut sorted = std::vec![0u32; x.len()];
        let mut cell = std::vec![0u32; x.len()];
        let mut list = CellList::new(&mut start, &mut sorted, &mut cell);
        list.build(&grid, x).unwrap();
        let view = list.view();
        let mut out = Vec::new();
        for i in 0..x.len() {
            view.for_each_neighbour(&grid, x, i, |j, d, _| out.push((i, j, d)))
                .unwrap();
        }
        out.sort_by_key(|a| (a.0, a.1));
        out
    }

    fn pairs_brute<S: Space>(
        domain: &Domain<S>,
        x: &[S::Vector],
        radius: S::Real,
    ) -> Vec<(usize, usize, S::Vector)> {
        let mut out = Vec::new();
        brute_force(domain, x, radius, |i, j, d, _| out.push((i, j, d)));
        out.sort_by_key(|a| (a.0, a.1));
        out
    }

    fn channel(l: f64, hgt: f64) -> Domain<D2<f64>> {
        Domain::new(V2::new([0.0, 0.0]), V2::new([l, hgt]))
            .unwrap()
            .with_periodic(0)
            .unwrap()
            .with_wall(1, Side::Lower, Wall::no_slip())
            .unwrap()
            .with_wall(1, Side::Upper, Wall::no_slip())
            .unwrap()
    }

    /// Coordinates biased toward cell edges, domain faces and wrap points.
    fn coordinate(l: f64, cell: f64) -> impl Strategy<Value = f64> {
        prop_oneof![
            0.0..l,
            (0usize..64).prop_map(move |k| (k as f64 * cell).min(l * 0.999_999)),
            Just(0.0),
            (0.0..1e-9f64).prop_map(move |e| l - e - 1e-12),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn cell_list_matches_brute_force_2d(
            radius in 0.05f64..0.4,
            pts in proptest::collection::vec((coordinate(1.0, 0.05), coordinate(0.8, 0.05)), 0..120),
        ) {
            let domain = channel(1.0, 0.8);
            prop_assume!(1.0 >= 2.0 * radius);
            let x: Vec<V2> = pts.iter().map(|&(a, b)| V2::new([a, b])).collect();
            prop_assert_eq!(pairs_by_cells(&domain, &x, radius), pairs_brute(&domain, &x, radius));
        }

        #[test]
        fn cell_list_matches_brute_force_3d_fully_periodic(
            radius in 0.1f64..0.5,
            pts in proptest::collection::vec((coordinate(1.0, 0.1), coordinate(1.0, 0.125), coordinate(1.2, 0.2)), 0..80),
        ) {
            let domain = Domain::<D3<f64>>::new(Vector::new([5.0, 5.0, 5.0]), Vector::new([1.0, 1.0, 1.2]))
                .unwrap().with_periodic(0).unwrap().with_periodic(1).unwrap().with_periodic(2).unwrap();
            let x: Vec<Vector<f64, 3>> = pts.iter().map(|&(a, b, c)| Vector::new([a, b, c])).collect();
            prop_assert_eq!(pairs_by_cells(&domain, &x, radius), pairs_brute(&domain, &x, radius));
        }
    }

    #[test]
    fn periodic_neighbours_across_the_wrap() {
        let domain = channel(1.0, 1.0);
        let x = [V2::new([0.01, 0.5]), V2::new([0.99, 0.5])];
        let pairs = pairs_by_cells(&domain, &x, 0.1);
        let across: Vec<_> = pairs.iter().filter(|p| p.0 != p.1).collect();
        assert_eq!(across.len(), 2);
        assert!(
            (across[0].2[0] - 0.02).abs() < 1e-12,
            "r_01 = {:?}",
            across[0].2
        );
    }

    #[test]
    fn buffer_sizes_and_domain_are_checked() {
        let domain = channel(1.0, 1.0);
        let grid = Grid::new(&domain, 0.1).unwrap();
        let x = [V2::new([0.5, 0.5]), V2::new([0.5, 3.0])];
        let mut start = std::vec![0u32; grid.cell_count()];
        let (mut sorted, mut cell) = ([0u32; 2], [0u32; 2]);
        let err = CellList::new(&mut start, &mut sorted, &mut cell).build(&grid, &x);
        assert!(matches!(
            err,
            Err(Error::CapacityExceeded {
                buffer: "cell_start",
                ..
            })
        ));
        let mut start = std::vec![0u32; grid.cell_count() + 1];
        let err = CellList::new(&mut start, &mut sorted, &mut cell).build(&grid, &x);
        assert!(matches!(
            err,
            Err(Error::OutsideDomain {
                particle: 1,
                axis: 1,
                ..
            })
        ));
        assert!(
            Grid::new(&domain, 0.6).is_err(),
            "period shorter than two radii"
        );
        assert!(Grid::new(&domain, -0.1).is_err());
    }

    #[test]
    fn empty_cloud_builds() {
        let domain = channel(1.0, 1.0);
        assert!(pairs_by_cells(&domain, &[], 0.1).is_empty());
    }
}
