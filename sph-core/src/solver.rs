//! The time stepper: storage views, the evaluation passes and kick-drift-kick.
//!
//! A [`Solver`] borrows caller-provided [`Storage`] (every per-particle slice
//! has the same length, the capacity: fluid particles first, then room for
//! ghosts), a [`Domain`], a kernel, a math backend and two term groups: `D`
//! for the density pass (`SummationDensity`, or `()` for continuity density)
//! and `T` for the force pass. One step is
//!
//! 1. kick and drift: `v += dt/2 a`, `x += dt v`, predicted `v* = v + dt/2 a`
//!    (continuity: `rho` likewise), all per fluid particle;
//! 2. evaluate at the new positions: ghosts, neighbours, density pass,
//!    equation of state, ghost copies, force pass (rates `a`, `d rho/dt`);
//! 3. kick: `v += dt/2 a`, with checks for divergence.
//!
//! Evaluating the velocity-dependent forces at the predicted velocity makes
//! the scheme stable for the linear viscous system `dv/dt = -lambda v` exactly
//! while `lambda dt < 1` (the amplification matrix has trace `1 - 3z/2` and
//! determinant `-z/2`, `z = lambda dt`; Jury's conditions give `z < 1`). The
//! viscous limit [`Limits::viscous`] is therefore `1 / lambda_max`, with
//! `lambda_max` estimated by power iteration on the scene's own viscous
//! operator at set-up: no constant per viscous form is assumed, the form's
//! discrete operator decides.
//!
//! # Neighbours
//! Without neighbour-list buffers, every pass scans the cells around each
//! particle (least memory). With them (see [`Storage::neighbours`]), each
//! particle's Verlet list holds every particle closer than `(1 + skin) R`
//! and is reused until the fastest particle could have closed half the skin
//! (`2 sum_steps max|v| dt >= skin R`), which keeps the lists exact. Ghosts
//! then keep their sources between rebuilds and only move with them, and
//! positions along periodic axes are wrapped at rebuilds only (between
//! rebuilds they may lie up to half a skin outside the box).
//!
//! Passes run through an [`Executor`]; each writes only the range it is
//! given, so the result is bitwise the same for any split (see
//! [`Solver::rates_range`]).
//!
//! # No-panic contract
//! Once [`Solver::new`] has returned `Ok`, no method panics: bad arguments
//! and diverging runs are reported as [`Error`]s.

use crate::boundary::{self, Ghost};
use crate::domain::{Domain, Side};
use crate::eos::Eos;
use crate::error::{Error, Fault, Result};
use crate::exec::{run_checked, Executor, Max2, Rows, Serial};
use crate::kernel::{Kernel, SmoothingKernel};
use crate::math::Math;
use crate::neighbour::{CellList, CellView, Grid};
use crate::real::Real;
use crate::space::{Space, VectorOps};
use crate::terms::{Acc, Consts, Dest, Fields, Pair, SummationDensity, Term};

/// Caller-provided per-particle slices (structure of arrays).
///
/// All per-particle slices have the same length, the capacity: indices
/// `0..n_fluid` hold fluid particles, the rest is reserved for ghosts. The
/// caller fills `x`, `v`, `m` (and `rho` for continuity density) of the
/// fluid; the rest is scratch. `cell_start` needs [`Solver::cells_needed`]
/// entries.
#[derive(Debug)]
pub struct Storage<'a, S: Space> {
    /// Positions, relative to the domain's lower corner.
    pub x: &'a mut [S::Vector],
    /// Velocities.
    pub v: &'a mut [S::Vector],
    /// Masses.
    pub m: &'a mut [S::Real],
    /// Densities.
    pub rho: &'a mut [S::Real],
    /// Pressures (computed).
    pub p: &'a mut [S::Real],
    /// Velocities seen by the passes (predicted; scratch).
    pub ve: &'a mut [S::Vector],
    /// Accelerations (computed).
    pub dv: &'a mut [S::Vector],
    /// Density rates (computed).
    pub drho: &'a mut [S::Real],
    /// Scratch density.
    pub rho_aux: &'a mut [S::Real],
    /// Ghost records.
    pub ghosts: &'a mut [Ghost],
    /// Cell list: first particle of each cell (`cells_needed` entries).
    pub cell_start: &'a mut [u32],
    /// Cell list: particle indices sorted by cell (capacity entries).
    pub cell_sorted: &'a mut [u32],
    /// Cell list: cell of each particle (capacity entries).
    pub cell_index: &'a mut [u32],
    /// Neighbour lists: one row of `width` entries per fluid particle
    /// (`n_fluid * width` entries: ghosts and wall particles gather from
    /// none, so they need no row), or empty to scan the cells in every pass
    /// (least memory). A particle with more than `width` neighbours within
    /// `(1 + skin) R` is reported as [`Error::CapacityExceeded`].
    pub neighbours: &'a mut [u32],
    /// Entries used in each row of `neighbours` (`n_fluid` entries, or
    /// empty together with `neighbours`).
    pub neighbour_counts: &'a mut [u32],
    /// Shifting velocities (capacity entries) when the force group shifts
    /// particles (see [`crate::terms::Shifting`]); otherwise may be empty.
    pub shift: &'a mut [S::Vector],
}

/// Every buffer of a solver's [`Storage`], whole and read-only
/// ([`Solver::storage`]): what a checkpoint copies, field by field, to
/// resume with [`Solver::resume_with`].
#[derive(Clone, Copy, Debug)]
pub struct StorageRef<'s, S: Space> {
    /// See [`Storage::x`].
    pub x: &'s [S::Vector],
    /// See [`Storage::v`].
    pub v: &'s [S::Vector],
    /// See [`Storage::m`].
    pub m: &'s [S::Real],
    /// See [`Storage::rho`].
    pub rho: &'s [S::Real],
    /// See [`Storage::p`].
    pub p: &'s [S::Real],
    /// See [`Storage::ve`].
    pub ve: &'s [S::Vector],
    /// See [`Storage::dv`].
    pub dv: &'s [S::Vector],
    /// See [`Storage::drho`].
    pub drho: &'s [S::Real],
    /// See [`Storage::rho_aux`].
    pub rho_aux: &'s [S::Real],
    /// See [`Storage::ghosts`].
    pub ghosts: &'s [Ghost],
    /// See [`Storage::cell_start`].
    pub cell_start: &'s [u32],
    /// See [`Storage::cell_sorted`].
    pub cell_sorted: &'s [u32],
    /// See [`Storage::cell_index`].
    pub cell_index: &'s [u32],
    /// See [`Storage::neighbours`].
    pub neighbours: &'s [u32],
    /// See [`Storage::neighbour_counts`].
    pub neighbour_counts: &'s [u32],
    /// See [`Storage::shift`].
    pub shift: &'s [S::Vector],
}

/// Bytes of [`Storage`] per particle slot for space `S`, without neighbour
/// lists (they add `4 * (width + 1)`) and cell starts.
pub const fn bytes_per_particle<S: Space>() -> usize {
    let v = core::mem::size_of::<S::Vector>();
    let f = core::mem::size_of::<S::Real>();
    4 * v + 5 * f + core::mem::size_of::<Ghost>() + 2 * core::mem::size_of::<u32>()
}

/// A solver's scalar state between two steps ([`Solver::resume_state`]);
/// with a copy of the storage, what [`Solver::resume_with`] needs to
/// continue the run bit for bit. Reals are kept as `f64` (exact for `f32`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Resume {
    /// Simulated time in seconds.
    pub time: f64,
    /// Steps taken.
    pub steps: u64,
    /// Ghosts at the last evaluation.
    pub n_ghost: usize,
    /// Particles in the cell list's last build (0 if none is current).
    pub cell_len: usize,
    /// Cell-list builds so far (the reordering cadence counts them).
    pub builds: u32,
    /// Largest squared speed after the last step.
    pub vmax2: f64,
    /// Largest squared acceleration after the last step.
    pub amax2: f64,
    /// Estimated largest viscous decay rate (1/s).
    pub viscous_rate: f64,
    /// Distance travelled since the neighbour lists were built.
    pub travel: f64,
    /// The neighbour lists are current.
    pub lists_fresh: bool,
    /// The density pass has partitioned the neighbour rows.
    pub partitioned: bool,
}

/// The most power iterations [`Params::viscous_iterations`] may ask for:
/// each costs a viscous pass, and the estimate converges long before.
pub const MAX_VISCOUS_ITERATIONS: u32 = 1000;

/// Scene parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params<F> {
    /// Smoothing length `h`.
    pub h: F,
    /// Regulariser `eta^2` as a fraction of `h^2` (0.01 is the seed's choice).
    pub eta2: F,
    /// Equation of state.
    pub eos: Eos<F>,
    /// Speed beyond which a run counts as diverging; zero means the sound
    /// speed of `eos` (no limit when that is zero too).
    pub max_speed: F,
    /// Power iterations used to estimate the viscous operator's largest decay
    /// rate (see the module docs).
    pub viscous_iterations: u32,
    /// Reorder the fluid particles by cell every this many cell-list builds
    /// (0: never). Neighbours then sit close in memory, which pays off once
    /// the arrays outgrow the cache; but particle indices change, so a caller
    /// who follows particles by index must leave it off.
    pub reorder_every: u32,
    /// Verlet skin as a fraction of the support radius (neighbour lists
    /// only; see the module docs).
    pub skin: F,
    /// The smallest density continuity density may reach (negative
    /// infinity: none). At a free surface the weakly compressible fluid
    /// stretches where a liquid would not (a thinning front, a falling
    /// sheet): its density falls below `rho0` and the equation of state
    /// answers with tension, which pulls the surface particles into pairs
    /// (the tensile instability). A floor at `rho0` cuts that off: a
    /// liquid without air separates rather than expands, so the pressure
    /// stays at or above the background pressure, and a particle that
    /// meets a wall or another after flying apart is repelled at once,
    /// not after making up the expansion first. Masses are unchanged;
    /// with summation density the floor does nothing.
    pub density_floor: F,
}

impl<F: Real> Params<F> {
    /// Parameters with smoothing length `h`, equation of state `eos`, and
    /// the defaults `eta2 = 0.01`, speed limit = sound speed, 60 power
    /// iterations, no reordering, skin 0.1.
    ///
    /// ```
    /// use sph_core::prelude::*;
    ///
    /// let dx = 1e-3 / 40.0;
    /// let params = Params::new(1.3 * dx, Eos::Linear { rho0: 1e3, c0: 1.25e-4, p0: 0.0 })
    ///     .with_eta2(0.01)
    ///     .with_skin(0.1);
    /// assert_eq!(params.viscous_iterations, 60);
    /// ```
    pub fn new(h: F, eos: Eos<F>) -> Self {
        Self {
            h,
            eta2: F::from_f64(0.01),
            eos,
            max_speed: F::ZERO,
            viscous_iterations: 60,
            reorder_every: 0,
            skin: F::from_f64(0.1),
            density_floor: F::NEG_INFINITY,
        }
    }

    /// Bounds continuity density below (see the field).
    pub fn with_density_floor(mut self, floor: F) -> Self {
        self.density_floor = floor;
        self
    }

    /// `rho` bounded below by the density floor; a NaN stays NaN for the
    /// divergence checks to see.
    #[inline(always)]
    pub fn floored(&self, rho: F) -> F {
        if rho < self.density_floor {
            self.density_floor
        } else {
            rho
        }
    }

    /// Sets the regulariser (fraction of `h^2`).
    pub fn with_eta2(mut self, eta2: F) -> Self {
        self.eta2 = eta2;
        self
    }

    /// Reorders particles by cell every `every` cell-list builds (see the field).
    pub fn with_reorder_every(mut self, every: u32) -> Self {
        self.reorder_every = every;
        self
    }

    /// Sets the Verlet skin (fraction of the support radius).
    pub fn with_skin(mut self, skin: F) -> Self {
        self.skin = skin;
        self
    }

    /// Sets the divergence speed limit.
    pub fn with_max_speed(mut self, max_speed: F) -> Self {
        self.max_speed = max_speed;
        self
    }

    fn validate(&self) -> Result<()> {
        if !(self.eta2.is_finite() && self.eta2 >= F::ZERO) {
            return Err(Error::InvalidParameter {
                name: "eta2",
                value: self.eta2.to_f64(),
                rule: "the regulariser must be finite and not negative",
            });
        }
        if !(self.skin.is_finite() && self.skin >= F::ZERO && self.skin <= F::ONE) {
            return Err(Error::InvalidParameter {
                name: "skin",
                value: self.skin.to_f64(),
                rule: "the Verlet skin must be between 0 and 1 (fraction of the support radius)",
            });
        }
        if self.viscous_iterations == 0 || self.viscous_iterations > MAX_VISCOUS_ITERATIONS {
            return Err(Error::InvalidParameter {
                name: "viscous_iterations",
                value: self.viscous_iterations as f64,
                rule: "between 1 and 1000 power iterations (60 are plenty: the estimate converges geometrically)",
            });
        }
        if !(self.density_floor.is_finite() || self.density_floor == F::NEG_INFINITY) {
            return Err(Error::InvalidParameter {
                name: "density_floor",
                value: self.density_floor.to_f64(),
                rule: "the density floor must be finite or negative infinity (none)",
            });
        }
        if !(self.max_speed.is_finite() && self.max_speed >= F::ZERO) {
            return Err(Error::InvalidParameter {
                name: "max_speed",
                value: self.max_speed.to_f64(),
                rule: "the speed limit must be finite and not negative",
            });
        }
        self.eos.validate()
    }
}

/// Time-step limits in seconds; take the smallest, times a safety factor below one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Acoustic CFL `0.25 h / (c0 + max |v|)`.
    pub cfl: f64,
    /// Viscous: `1 / lambda_max`, the exact linear stability bound of the
    /// integrator for the scene's viscous operator (infinite without viscosity).
    pub viscous: f64,
    /// Body force `0.25 sqrt(h / max |a|)`.
    pub force: f64,
}

impl Limits {
    /// The smallest limit.
    pub fn min(&self) -> f64 {
        self.cfl.min(self.viscous).min(self.force)
    }
}

/// The fluid slices the first kick and drift write: `x`, `v`, `ve`, `rho`, `rho_aux`.
type DriftParts<'s, S> = (
    &'s mut [<S as Space>::Vector],
    &'s mut [<S as Space>::Vector],
    &'s mut [<S as Space>::Vector],
    &'s mut [<S as Space>::Real],
    &'s mut [<S as Space>::Real],
);

/// The fluid slices the force pass writes with shifting: `dv`, `drho`, `shift`.
type RatesParts<'s, S> = (
    &'s mut [<S as Space>::Vector],
    &'s mut [<S as Space>::Real],
    &'s mut [<S as Space>::Vector],
);

/// The fluid slices the last kick writes: `v`, `rho`, `p`.
type KickParts<'s, S> = (
    &'s mut [<S as Space>::Vector],
    &'s mut [<S as Space>::Real],
    &'s mut [<S as Space>::Real],
);

/// The fluid's state between steps, writable ([`Solver::fluid_mut`]): every
/// slice holds the `n_fluid` fluid particles.
#[derive(Debug)]
pub struct FluidMut<'s, S: Space> {
    /// Positions (local coordinates).
    pub x: &'s mut [S::Vector],
    /// Velocities.
    pub v: &'s mut [S::Vector],
    /// Densities.
    pub rho: &'s mut [S::Real],
    /// Pressures.
    pub p: &'s mut [S::Real],
    /// Pass velocities `v*` of the last evaluation.
    pub ve: &'s mut [S::Vector],
    /// Accelerations of the last evaluation.
    pub dv: &'s mut [S::Vector],
    /// Density rates of the last evaluation.
    pub drho: &'s mut [S::Real],
    /// Summed density (summation) or half-step density (continuity).
    pub rho_aux: &'s mut [S::Real],
    /// Shifting velocities (empty unless the force group shifts).
    pub shift: &'s mut [S::Vector],
}

/// The transport velocity of the drift: the half-kicked velocity `v + a
/// dt/2`, plus the shifting velocity where the force group shifts. One
/// function for the drift and for [`Solver::drift_speed2`], so the bound a
/// caller computes is bitwise the drift's own.
#[inline(always)]
fn transport<V: VectorOps<R>, R: Real>(v: V, a: V, half: R, shift: Option<V>) -> (V, V) {
    let vh = v + a * half;
    (vh, shift.map_or(vh, |u| vh + u))
}

/// Per-particle arrays of the storage (everything but the cell list).
#[derive(Debug)]
struct Arrays<'a, S: Space> {
    x: &'a mut [S::Vector],
    v: &'a mut [S::Vector],
    m: &'a mut [S::Real],
    rho: &'a mut [S::Real],
    p: &'a mut [S::Real],
    ve: &'a mut [S::Vector],
    dv: &'a mut [S::Vector],
    drho: &'a mut [S::Real],
    rho_aux: &'a mut [S::Real],
    ghosts: &'a mut [Ghost],
    nbr: &'a mut [u32],
    nbr_count: &'a mut [u32],
    shift: &'a mut [S::Vector],
}

/// The fluid particles within the kernel's support of a point, for the
/// wall particles' gather (in cell order: the same sums for any split of
/// the wall particles over threads).
struct FluidNear<'s, S: Space, K: Kernel, M: Math<S::Real>> {
    kernel: &'s SmoothingKernel<S, K, M>,
    grid: &'s Grid<S>,
    cells: CellView<'s>,
    x: &'s [S::Vector],
    n: usize,
}

impl<S: Space, K: Kernel, M: Math<S::Real>> FluidNear<'_, S, K, M> {
    /// Calls `f(j, W, r_ij)` for each fluid particle `j` with `W > 0`
    /// around particle `i` of the cell list.
    fn visit(&self, i: usize, mut f: impl FnMut(usize, S::Real, S::Vector)) {
        let n = self.n;
        self.cells.visit_coded(self.grid, self.x, i, |j, _, d, r2| {
            if j < n {
                let w = self.kernel.w(r2);
                if w > S::Real::ZERO {
                    f(j, w, d);
                }
            }
        });
    }
}

/// Bits of a neighbour-list entry that hold the particle index; the six bits
/// above hold the periodic image (two per axis, as in
/// [`CellView::for_each_neighbour_coded`]).
const INDEX_BITS: u32 = 26;
const INDEX_MASK: u32 = (1 << INDEX_BITS) - 1;

/// A row's count word: entries used in the low 16 bits; in the high 16 bits,
/// how many of them (at the front of the row) lay inside the support at the
/// last density pass.
const COUNT_MASK: u32 = 0xFFFF;

/// How many entries of an unsorted Verlet row the force pass gathers at a
/// time (a power of two).
const GATHER: usize = 64;

/// Pairs whose kernel values are computed together, in vector lanes.
const BATCH: usize = 8;

/// Where a pass finds the neighbours of a particle.
#[derive(Clone, Copy, Debug)]
enum Neighbours<'s> {
    /// Scan the cells around it.
    Cells(CellView<'s>),
    /// Its row of a Verlet list; with `partitioned`, the density pass has
    /// moved the entries inside the support to the front of each row at the
    /// current positions, so the force pass visits just those.
    Lists {
        rows: &'s [u32],
        counts: &'s [u32],
        width: usize,
        partitioned: bool,
    },
}

/// The destination's own values and an empty accumulator.
#[inline(always)]
fn start<S: Space>(f: &Fields<'_, S>, i: usize) -> (Dest<S>, Acc<S>) {
    let d = Dest {
        i,
        v: f.v[i],
        m: f.m[i],
        rho: f.rho[i],
        p: f.p[i],
    };
    (
        d,
        Acc {
            rho: S::Real::ZERO,
            drho: S::Real::ZERO,
            dv: S::Vector::zero(),
            shift: S::Vector::zero(),
        },
    )
}

/// What one pass reads, shared by every range.
struct Pass<'s, S: Space, K: Kernel, M: Math<S::Real>> {
    kernel: &'s SmoothingKernel<S, K, M>,
    grid: &'s Grid<S>,
    neighbours: Neighbours<'s>,
    consts: &'s Consts<S>,
    fields: Fields<'s, S>,
}

impl<S: Space, K: Kernel, M: Math<S::Real>> Pass<'_, S, K, M> {
    /// Neighbour index and separation `(x_i - x_j) - shift` for a list entry.
    #[inline(always)]
    fn separation(&self, f: &Fields<'_, S>, xi: S::Vector, entry: u32) -> (usize, S::Vector) {
        let j = (entry & INDEX_MASK) as usize;
        let code = entry >> INDEX_BITS;
        // The one bounds check of the pair: the fields share this length.
        let mut r_ij = xi - f.x[j];
        if code != 0 {
            // A periodic image (rare): (x_i - x_j) - shift, as in the cell scan.
            let signs = [S::Real::ZERO, S::Real::ONE, -S::Real::ONE, S::Real::ZERO];
            let period = self.grid.period();
            let mut shift = S::Vector::zero();
            for a in 0..S::DIM {
                shift[a] = period[a] * signs[((code >> (2 * a)) & 3) as usize];
            }
            r_ij -= shift;
        }
        (j, r_ij)
    }

    /// The density pass over a Verlet row it owns: accumulates the terms and
    /// moves the entries inside the support to the front of the row (their
    /// order kept); returns the accumulator and how many are inside.
    #[inline(always)]
    fn accumulate_partition<T: Term<S>>(
        &self,
        terms: &T,
        i: usize,
        row: &mut [u32],
    ) -> (Acc<S>, usize) {
        // Every field re-sliced to one length: with `j` checked against it once,
        // the compiler drops the per-field bounds checks in the pair loop.
        let f = self.fields.uniform();
        let (d, mut acc) = start::<S>(&f, i);
        let mut scratch = T::Scratch::default();
        terms.init(self.consts, &d, &mut acc);
        let xi = f.x[i];
        let radius2 = self.kernel.radius2();
        // Partition first, without a branch: an entry inside the support
        // swaps with the first entry outside it (selects, not jumps; a test
        // taken about half the time would mispredict). The inside entries
        // end at the front in row order, and are then visited in that order.
        let mut inside = 0;
        for e in 0..row.len() {
            let (_, r_ij) = self.separation(&f, xi, row[e]);
            let take = r_ij.norm2() < radius2;
            // `inside` <= `e` < `row.len()`.
            let (a, b) = (row[e], row[inside]);
            row[inside] = if take { a } else { b };
            row[e] = if take { b } else { a };
            inside += usize::from(take);
        }
        self.visit_entries::<T, false, true>(
            &f,
            terms,
            &d,
            (&mut acc, &mut scratch),
            xi,
            &row[..inside],
        );
        terms.finish(self.consts, &d, &scratch, &mut acc);
        (acc, inside)
    }

    /// Visits the list entries `entries` of destination `d` (every one
    /// inside the support), in order; their kernel values a batch at a
    /// time when `BATCHED`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn visit_entries<T: Term<S>, const VISCOUS_ONLY: bool, const BATCHED: bool>(
        &self,
        f: &Fields<'_, S>,
        terms: &T,
        d: &Dest<S>,
        (acc, scratch): (&mut Acc<S>, &mut T::Scratch),
        xi: S::Vector,
        entries: &[u32],
    ) {
        if !BATCHED {
            for &entry in entries {
                let (j, r_ij) = self.separation(f, xi, entry);
                self.visit::<T, VISCOUS_ONLY>(f, terms, d, (acc, scratch), j, r_ij, r_ij.norm2());
            }
            return;
        }
        // A batch at a time: the separations in row order, then the kernel
        // of the whole batch in one branch-free loop of fixed length (which
        // the compiler runs in vector lanes, square roots and divisions
        // packed), then the terms pair by pair in row order. Each pair's
        // kernel value is computed by the same operations as one at a time,
        // and the sums are taken in the same order: the same bits.
        for chunk in entries.chunks(BATCH) {
            let mut js = [0usize; BATCH];
            let mut rs = [S::Vector::zero(); BATCH];
            for ((&entry, j), r) in chunk.iter().zip(js.iter_mut()).zip(rs.iter_mut()) {
                (*j, *r) = self.separation(f, xi, entry);
            }
            // Squared distances here, not in the loop above: read back as
            // lanes, scalars stored one by one would miss store forwarding.
            let mut r2s = [S::Real::ZERO; BATCH];
            let mut ws = [S::Real::ZERO; BATCH];
            let mut fs = [S::Real::ZERO; BATCH];
            // Lanes past a short last chunk hold zero separations: their
            // values are computed (the loop keeps its fixed length) and
            // never read.
            for k in 0..BATCH {
                r2s[k] = rs[k].norm2();
                (ws[k], fs[k]) = self.kernel_values::<T>(r2s[k]);
            }
            for k in 0..chunk.len().min(BATCH) {
                self.visit_with::<T, VISCOUS_ONLY>(
                    f,
                    terms,
                    d,
                    (acc, scratch),
                    (js[k], rs[k], r2s[k]),
                    (ws[k], fs[k]),
                );
            }
        }
    }

    /// `(W, F)` at squared distance `r2`, each only if the group `T` needs it.
    #[inline(always)]
    fn kernel_values<T: Term<S>>(&self, r2: S::Real) -> (S::Real, S::Real) {
        if T::NEEDS_W && T::NEEDS_F {
            self.kernel.w_and_f(r2)
        } else if T::NEEDS_W {
            (self.kernel.w(r2), S::Real::ZERO)
        } else if T::NEEDS_F {
            (S::Real::ZERO, self.kernel.f(r2))
        } else {
            (S::Real::ZERO, S::Real::ZERO)
        }
    }

    /// One pair: the shared pair quantities, then every term of the group.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn visit<T: Term<S>, const VISCOUS_ONLY: bool>(
        &self,
        f: &Fields<'_, S>,
        terms: &T,
        d: &Dest<S>,
        (acc, scratch): (&mut Acc<S>, &mut T::Scratch),
        j: usize,
        r_ij: S::Vector,
        r2: S::Real,
    ) {
        let kernel = self.kernel_values::<T>(r2);
        self.visit_with::<T, VISCOUS_ONLY>(f, terms, d, (acc, scratch), (j, r_ij, r2), kernel);
    }

    /// One pair whose kernel values `(W, F)` are known.
    #[inline(always)]
    fn visit_with<T: Term<S>, const VISCOUS_ONLY: bool>(
        &self,
        f: &Fields<'_, S>,
        terms: &T,
        d: &Dest<S>,
        (acc, scratch): (&mut Acc<S>, &mut T::Scratch),
        (j, r_ij, r2): (usize, S::Vector, S::Real),
        (w, fk): (S::Real, S::Real),
    ) {
        let pair = Pair {
            j,
            r_ij,
            r2,
            w,
            f: fk,
            grad: r_ij * fk,
            v_ij: d.v - f.v[j],
        };
        if VISCOUS_ONLY {
            terms.viscous(self.consts, d, f, &pair, acc);
        } else {
            terms.pair(self.consts, d, f, &pair, acc);
            terms.pair_scratch(self.consts, d, f, &pair, scratch);
        }
    }

    /// Calls `f(j, r2)` for every neighbour `j` of `i` inside the support
    /// (the self pair included), in the order the passes visit them.
    fn for_each_neighbour(&self, i: usize, mut f: impl FnMut(usize, S::Real)) {
        let fields = self.fields.uniform();
        match self.neighbours {
            Neighbours::Cells(cells) => {
                cells.visit_coded(self.grid, fields.x, i, |j, _, _, r2| f(j, r2))
            }
            Neighbours::Lists {
                rows,
                counts,
                width,
                ..
            } => {
                let Some(&xi) = fields.x.get(i) else { return };
                let used = ((counts.get(i).copied().unwrap_or(0) & COUNT_MASK) as usize).min(width);
                let row = rows.get(i * width..i * width + used).unwrap_or(&[]);
                let radius2 = self.kernel.radius2();
                for &entry in row {
                    let (j, r_ij) = self.separation(&fields, xi, entry);
                    let r2 = r_ij.norm2();
                    if r2 < radius2 {
                        f(j, r2);
                    }
                }
            }
        }
    }

    /// Accumulates the terms `T` for destination `i` (only their viscous
    /// parts when `VISCOUS_ONLY`).
    #[inline(always)]
    fn accumulate<T: Term<S>, const VISCOUS_ONLY: bool>(&self, terms: &T, i: usize) -> Acc<S> {
        // Every field re-sliced to one length: with `j` checked against it once,
        // the compiler drops the per-field bounds checks in the pair loop.
        let f = self.fields.uniform();
        let (d, mut acc) = start::<S>(&f, i);
        let mut scratch = T::Scratch::default();
        if !VISCOUS_ONLY {
            terms.init(self.consts, &d, &mut acc);
        }
        match self.neighbours {
            Neighbours::Cells(cells) => cells.visit_coded(self.grid, f.x, i, |j, _, r_ij, r2| {
                self.visit::<T, VISCOUS_ONLY>(&f, terms, &d, (&mut acc, &mut scratch), j, r_ij, r2);
            }),
            Neighbours::Lists {
                rows,
                counts,
                width,
                partitioned,
            } => {
                let xi = f.x[i];
                let word = counts.get(i).copied().unwrap_or(0);
                let start = i * width;
                let used = ((word & COUNT_MASK) as usize).min(width);
                let row = rows.get(start..start + used).unwrap_or(&[]);
                if partitioned {
                    // Positions have not moved since the density pass sorted these in.
                    let inside = ((word >> 16) as usize).min(used);
                    self.visit_entries::<T, VISCOUS_ONLY, false>(
                        &f,
                        terms,
                        &d,
                        (&mut acc, &mut scratch),
                        xi,
                        &row[..inside],
                    );
                } else {
                    // No pass has sorted the row (continuity density): the
                    // entries inside the support are gathered a chunk at a
                    // time without a branch, then visited in row order. A
                    // test per entry, taken about half the time, would
                    // mispredict; this gather does not, and the pairs and
                    // their order are the same.
                    let radius2 = self.kernel.radius2();
                    let mut inside = [0u32; GATHER];
                    for chunk in row.chunks(GATHER) {
                        let mut k = 0;
                        for &entry in chunk {
                            let (_, r_ij) = self.separation(&f, xi, entry);
                            // `k` < GATHER always; the mask drops the bounds check.
                            inside[k & (GATHER - 1)] = entry;
                            k += usize::from(r_ij.norm2() < radius2);
                        }
                        self.visit_entries::<T, VISCOUS_ONLY, true>(
                            &f,
                            terms,
                            &d,
                            (&mut acc, &mut scratch),
                            xi,
                            &inside[..k],
                        );
                    }
                }
            }
        }
        if !VISCOUS_ONLY {
            terms.finish(self.consts, &d, &scratch, &mut acc);
        }
        acc
    }
}

/// The time stepper (see the module docs).
///
/// Type parameters: `S` space, `K` kernel, `M` math backend, `D` density
/// group (`SummationDensity` or `()`), `T` force group.
///
/// A shear wave in a periodic box decays, as viscosity says it must:
///
/// ```
/// use sph_core::prelude::*;
///
/// # fn main() -> Result<()> {
/// let (n, l) = (12usize, 1.0f64);
/// let dx = l / n as f64;
/// let mut store: Store<D2<f64>, 144, 64> = Store::new();
/// for j in 0..n {
///     for i in 0..n {
///         let y = (j as f64 + 0.5) * dx;
///         let x = Vector::new([(i as f64 + 0.5) * dx, y]);
///         let u = 1e-3 * (2.0 * core::f64::consts::PI * y).sin();
///         store.push(x, Vector::new([u, 0.0]), 1.0, 1.0)?;
///     }
/// }
/// let domain = Domain::new(Vector::new([0.0, 0.0]), Vector::new([l, l]))?
///     .with_periodic(0)?
///     .with_periodic(1)?;
/// let (storage, n_fluid) = store.storage()?;
/// let params = Params::new(1.3 * dx, Eos::Linear { rho0: 1.0, c0: 0.1, p0: 0.0 });
/// let forces = (PressureGradient, MorrisViscosity { mu: 1e-2 });
/// let mut solver = Solver::<D2<f64>, CubicSpline, Libm, _, _>::new(
///     params, domain, storage, n_fluid, SummationDensity, forces,
/// )?;
/// solver.calibrate_mass(1.0)?;
/// let speed = |s: &Solver<'_, D2<f64>, _, _, _, _>| s.max_speed();
/// let before = speed(&solver);
/// let dt = 0.5 * solver.limits().min();
/// for _ in 0..50 {
///     solver.step(dt)?;
/// }
/// assert!(speed(&solver) < before);
/// # Ok(())
/// # }
/// ```
#[derive(Debug)]
pub struct Solver<'a, S: Space, K: Kernel, M: Math<S::Real>, D: Term<S>, T: Term<S>> {
    params: Params<S::Real>,
    consts: Consts<S>,
    kernel: SmoothingKernel<S, K, M>,
    grid: Grid<S>,
    domain: Domain<S>,
    density: D,
    forces: T,
    a: Arrays<'a, S>,
    cells: CellList<'a>,
    n: usize,
    n_ghost: usize,
    time: f64,
    step: u64,
    vmax2: S::Real,
    amax2: S::Real,
    speed_limit2: S::Real,
    viscous_rate: f64,
    builds: u32,
    list_width: usize,
    list_radius: S::Real,
    travel: f64,
    anchor_speed: f64,
    curved_walls: bool,
    lists_fresh: bool,
    partitioned: bool,
    failed: Option<Error>,
}

fn unstable(step: u64, particle: usize, fault: Fault) -> Error {
    Error::Unstable {
        step,
        particle,
        fault,
    }
}

impl<'a, S, K, M, D, T> Solver<'a, S, K, M, D, T>
where
    S: Space,
    K: Kernel,
    M: Math<S::Real>,
    D: Term<S>,
    T: Term<S>,
{
    /// Entries the `cell_start` buffer needs for this domain and smoothing
    /// length (enough with or without neighbour lists).
    ///
    /// # Errors
    /// As [`SmoothingKernel::new`] and [`Grid::new`].
    pub fn cells_needed(domain: &Domain<S>, h: S::Real) -> Result<usize> {
        let kernel = SmoothingKernel::<S, K, M>::new(h)?;
        Ok(Grid::new(domain, kernel.radius())?.cell_count() + 1)
    }

    /// Validates the scene and evaluates the initial rates on the current thread.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for bad parameters or a domain too small for
    /// the kernel; [`Error::LengthMismatch`] / [`Error::CapacityExceeded`] for
    /// storage of the wrong size; [`Error::NonFinite`] or
    /// [`Error::OutsideDomain`] for bad particle data.
    pub fn new(
        params: Params<S::Real>,
        domain: Domain<S>,
        storage: Storage<'a, S>,
        n_fluid: usize,
        density: D,
        forces: T,
    ) -> Result<Self> {
        Self::new_with(&Serial, params, domain, storage, n_fluid, density, forces)
    }

    /// As [`Self::new`], running the set-up passes through `exec`.
    ///
    /// # Errors
    /// As [`Self::new`].
    pub fn new_with<E: Executor>(
        exec: &E,
        params: Params<S::Real>,
        domain: Domain<S>,
        storage: Storage<'a, S>,
        n_fluid: usize,
        density: D,
        forces: T,
    ) -> Result<Self> {
        let mut solver = Self::assemble(params, domain, storage, n_fluid, density, forces, true)?;
        solver.prepare(exec)?;
        Ok(solver)
    }

    /// Continues a run from a checkpoint: `storage` holds every buffer as
    /// it was after step [`Resume::steps`] of the run (all of it, scratch
    /// included: the neighbour lists, cell list and ghost records decide
    /// the order of the sums), and `state` is [`Self::resume_state`] at
    /// that point. Nothing is re-evaluated, so the run continues bit for
    /// bit as if it had never stopped (with the same parameters, domain,
    /// terms and executor split independence as ever).
    ///
    /// # Errors
    /// As [`Self::new`]; [`Error::InvalidParameter`] or
    /// [`Error::CapacityExceeded`] naming the field of `state` or the buffer
    /// that is inconsistent (a ghost whose source is not a fluid particle,
    /// a neighbour entry beyond the particles, a cell list that does not
    /// fit the grid, a non-finite rate).
    pub fn resume_with(
        params: Params<S::Real>,
        mut domain: Domain<S>,
        storage: Storage<'a, S>,
        n_fluid: usize,
        density: D,
        forces: T,
        state: Resume,
    ) -> Result<Self> {
        domain.set_wall_time(state.time);
        let mut solver = Self::assemble(params, domain, storage, n_fluid, density, forces, false)?;
        solver.restore(state)?;
        Ok(solver)
    }

    /// Every storage buffer, whole (for a checkpoint; see [`Self::resume_with`]).
    pub fn storage(&self) -> StorageRef<'_, S> {
        let (cell_start, cell_sorted, cell_index) = self.cells.buffers();
        StorageRef {
            x: self.a.x,
            v: self.a.v,
            m: self.a.m,
            rho: self.a.rho,
            p: self.a.p,
            ve: self.a.ve,
            dv: self.a.dv,
            drho: self.a.drho,
            rho_aux: self.a.rho_aux,
            ghosts: self.a.ghosts,
            cell_start,
            cell_sorted,
            cell_index,
            neighbours: self.a.nbr,
            neighbour_counts: self.a.nbr_count,
            shift: self.a.shift,
        }
    }

    /// The solver's own state between steps, besides the storage: with a
    /// copy of every storage buffer, what [`Self::resume_with`] needs.
    pub fn resume_state(&self) -> Resume {
        Resume {
            time: self.time,
            steps: self.step,
            n_ghost: self.n_ghost,
            cell_len: self.cells.len(),
            builds: self.builds,
            vmax2: self.vmax2.to_f64(),
            amax2: self.amax2.to_f64(),
            viscous_rate: self.viscous_rate,
            travel: self.travel,
            lists_fresh: self.lists_fresh,
            partitioned: self.partitioned,
        }
    }

    fn restore(&mut self, state: Resume) -> Result<()> {
        let bad = |name: &'static str, value: f64| Error::InvalidParameter {
            name,
            value,
            rule: "the resumed state must be finite, not negative and consistent with the storage",
        };
        for (name, value) in [
            ("time", state.time),
            ("vmax2", state.vmax2),
            ("amax2", state.amax2),
            ("viscous_rate", state.viscous_rate),
            ("travel", state.travel),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(bad(name, value));
            }
        }
        let n = self.n;
        let cap = self.a.x.len();
        let total = match n.checked_add(state.n_ghost) {
            Some(t) if t <= cap => t,
            _ => {
                return Err(Error::CapacityExceeded {
                    buffer: "ghosts",
                    needed: n.saturating_add(state.n_ghost),
                    available: cap,
                })
            }
        };
        let mirror_bits = (1u16 << (2 * S::DIM)) - 1;
        for g in &self.a.ghosts[..state.n_ghost] {
            let shaped = g.mirrors & crate::shape::BODY_FLAG != 0;
            let wall = g.mirrors & boundary::WALL_PARTICLE != 0;
            let known = if wall && shaped {
                self.domain.wall_particles().is_some()
                    && usize::from(g.mirrors & !(boundary::WALL_PARTICLE | crate::shape::BODY_FLAG))
                        < self.domain.shaped_count()
            } else if wall {
                self.domain.wall_particles().is_some()
                    && (u16::from(g.mirrors & !boundary::WALL_PARTICLE) & !mirror_bits) == 0
            } else if shaped {
                usize::from(g.mirrors & !crate::shape::BODY_FLAG) < self.domain.shaped_count()
            } else {
                u16::from(g.mirrors) & !mirror_bits == 0
            };
            // A wall particle's source is a lattice index, not a particle.
            if (!wall && g.source as usize >= n) || !known {
                return Err(bad("ghosts", f64::from(g.source)));
            }
        }
        self.cells.restore(self.grid.cell_count(), state.cell_len)?;
        if state.cell_len != 0 && state.cell_len != total {
            return Err(bad("cell_len", state.cell_len as f64));
        }
        let width = self.list_width;
        if width > 0 {
            for i in 0..n {
                let word = self.a.nbr_count[i];
                let used = (word & COUNT_MASK) as usize;
                let inside = (word >> 16) as usize;
                if used > width || inside > used {
                    return Err(bad("neighbour_counts", f64::from(word)));
                }
                let row = &self.a.nbr[i * width..i * width + used];
                if row.iter().any(|&e| (e & INDEX_MASK) as usize >= total) {
                    return Err(bad("neighbours", i as f64));
                }
            }
        }
        for i in 0..n {
            let finite = self.a.ve[i].is_finite()
                && self.a.dv[i].is_finite()
                && self.a.drho[i].is_finite()
                && self.a.rho[i].is_finite()
                && self.a.rho_aux[i].is_finite()
                && self.a.p[i].is_finite()
                && (!T::SHIFTS || self.a.shift[i].is_finite());
            if !finite {
                return Err(Error::NonFinite {
                    particle: i,
                    field: "rates",
                });
            }
        }
        self.time = state.time;
        self.step = state.steps;
        self.n_ghost = state.n_ghost;
        self.builds = state.builds;
        self.vmax2 = S::Real::from_f64(state.vmax2);
        self.amax2 = S::Real::from_f64(state.amax2);
        self.viscous_rate = state.viscous_rate;
        self.travel = state.travel;
        self.lists_fresh = state.lists_fresh && width > 0;
        self.partitioned = state.partitioned;
        Ok(())
    }

    /// Checks the parameters, the terms and the storage and takes them;
    /// with `wrap`, fluid positions along periodic axes are wrapped into
    /// the box (a fresh start), otherwise left where a resumed run had them.
    fn assemble(
        params: Params<S::Real>,
        domain: Domain<S>,
        storage: Storage<'a, S>,
        n_fluid: usize,
        density: D,
        forces: T,
        wrap: bool,
    ) -> Result<Self> {
        params.validate()?;
        density.validate()?;
        forces.validate()?;
        domain.validate()?;
        let kernel = SmoothingKernel::<S, K, M>::new(params.h)?;
        let cap = storage.x.len();
        let list_width = Self::check_lists(&storage, cap, n_fluid)?;
        let list_radius = if list_width > 0 {
            kernel.radius() * (S::Real::ONE + params.skin)
        } else {
            kernel.radius()
        };
        let grid = Grid::new(&domain, list_radius)?;
        for a in 0..S::DIM {
            let walled =
                domain.wall(a, Side::Lower).is_some() || domain.wall(a, Side::Upper).is_some();
            if walled && domain.extent()[a] < list_radius {
                return Err(Error::InvalidParameter {
                    name: "extent",
                    value: domain.extent()[a].to_f64(),
                    rule: "along an axis with walls the extent must be at least the kernel support radius (plus skin)",
                });
            }
        }
        for (buffer, len) in [
            ("v", storage.v.len()),
            ("m", storage.m.len()),
            ("rho", storage.rho.len()),
            ("p", storage.p.len()),
            ("ve", storage.ve.len()),
            ("dv", storage.dv.len()),
            ("drho", storage.drho.len()),
            ("rho_aux", storage.rho_aux.len()),
            ("ghosts", storage.ghosts.len()),
            ("cell_sorted", storage.cell_sorted.len()),
            ("cell_index", storage.cell_index.len()),
        ] {
            if len != cap {
                return Err(Error::LengthMismatch {
                    buffer,
                    expected: cap,
                    got: len,
                });
            }
        }
        if T::SHIFTS && storage.shift.len() != cap {
            return Err(Error::LengthMismatch {
                buffer: "shift",
                expected: cap,
                got: storage.shift.len(),
            });
        }
        if n_fluid > cap {
            return Err(Error::CapacityExceeded {
                buffer: "particles",
                needed: n_fluid,
                available: cap,
            });
        }
        let needed_cells = grid.cell_count() + 1;
        if storage.cell_start.len() < needed_cells {
            return Err(Error::CapacityExceeded {
                buffer: "cell_start",
                needed: needed_cells,
                available: storage.cell_start.len(),
            });
        }
        for i in 0..n_fluid {
            let checks = [
                ("position", storage.x[i].is_finite()),
                ("velocity", storage.v[i].is_finite()),
                ("mass", storage.m[i].is_finite()),
                ("density", !D::EMPTY || storage.rho[i].is_finite()),
            ];
            for (field, ok) in checks {
                if !ok {
                    return Err(Error::NonFinite { particle: i, field });
                }
            }
            if storage.m[i] <= S::Real::ZERO {
                return Err(Error::InvalidParameter {
                    name: "mass",
                    value: storage.m[i].to_f64(),
                    rule: "particle masses must be positive",
                });
            }
            if D::EMPTY && storage.rho[i] <= S::Real::ZERO {
                return Err(Error::InvalidParameter {
                    name: "rho",
                    value: storage.rho[i].to_f64(),
                    rule: "initial densities must be positive with continuity density",
                });
            }
            if let Some((axis, c)) = domain.outside(storage.x[i]) {
                return Err(Error::OutsideDomain {
                    particle: i,
                    axis,
                    coordinate: c.to_f64(),
                });
            }
            if let Some((wall, distance)) = domain.behind_wall(storage.x[i]) {
                return Err(Error::BehindWall {
                    particle: i,
                    wall,
                    distance,
                });
            }
            if wrap {
                storage.x[i] = domain.wrap::<M>(storage.x[i]);
            }
        }
        let c0 = params.eos.sound_speed();
        let limit = if params.max_speed > S::Real::ZERO {
            params.max_speed
        } else {
            c0
        };
        let speed_limit2 = if limit > S::Real::ZERO {
            limit * limit
        } else {
            S::Real::MAX
        };
        let consts = Consts {
            h: params.h,
            eta2: params.eta2 * params.h * params.h,
            c0,
        };
        let Storage {
            x,
            v,
            m,
            rho,
            p,
            ve,
            dv,
            drho,
            rho_aux,
            ghosts,
            cell_start,
            cell_sorted,
            cell_index,
            neighbours,
            neighbour_counts,
            shift,
        } = storage;
        let solver = Self {
            params,
            consts,
            kernel,
            grid,
            domain,
            density,
            forces,
            a: Arrays {
                x,
                v,
                m,
                rho,
                p,
                ve,
                dv,
                drho,
                rho_aux,
                ghosts,
                nbr: neighbours,
                nbr_count: neighbour_counts,
                shift,
            },
            cells: CellList::new(cell_start, cell_sorted, cell_index),
            n: n_fluid,
            n_ghost: 0,
            time: 0.0,
            step: 0,
            vmax2: S::Real::ZERO,
            amax2: S::Real::ZERO,
            speed_limit2,
            viscous_rate: 0.0,
            builds: 0,
            list_width,
            list_radius,
            travel: 0.0,
            anchor_speed: point_wall_speed(&domain),
            curved_walls: has_curved_walls(&domain),
            lists_fresh: false,
            partitioned: false,
            failed: None,
        };
        Ok(solver)
    }

    /// The width of the neighbour-list rows (0 without lists).
    fn check_lists(storage: &Storage<'_, S>, cap: usize, n_fluid: usize) -> Result<usize> {
        if storage.neighbours.is_empty() && storage.neighbour_counts.is_empty() {
            return Ok(0);
        }
        if !cfg!(feature = "neighbour-lists") {
            return Err(Error::InvalidParameter {
                name: "neighbours",
                value: storage.neighbours.len() as f64,
                rule: "neighbour lists need sph-core's `neighbour-lists` feature",
            });
        }
        let rows = n_fluid.max(1);
        let width = storage.neighbours.len() / rows;
        if width == 0 || width * rows != storage.neighbours.len() {
            return Err(Error::LengthMismatch {
                buffer: "neighbours",
                expected: rows * width.max(1),
                got: storage.neighbours.len(),
            });
        }
        if storage.neighbour_counts.len() != rows {
            return Err(Error::LengthMismatch {
                buffer: "neighbour_counts",
                expected: rows,
                got: storage.neighbour_counts.len(),
            });
        }
        if cap > INDEX_MASK as usize {
            return Err(Error::CapacityExceeded {
                buffer: "particles",
                needed: cap,
                available: INDEX_MASK as usize,
            });
        }
        if width > COUNT_MASK as usize {
            return Err(Error::InvalidParameter {
                name: "neighbours",
                value: width as f64,
                rule: "neighbour-list rows may hold at most 65535 entries",
            });
        }
        Ok(width)
    }

    /// Evaluates the rates at the current state with `ve = v`, then estimates
    /// the viscous decay rate.
    fn prepare<E: Executor>(&mut self, exec: &E) -> Result<()> {
        let n = self.n;
        self.lists_fresh = false;
        self.a.ve[..n].copy_from_slice(&self.a.v[..n]);
        self.evaluate(exec)?;
        self.viscous_rate = self.estimate_viscous_rate(exec)?;
        // The estimate used `ve` and `dv` as scratch: evaluate again.
        self.a.ve[..n].copy_from_slice(&self.a.v[..n]);
        self.evaluate(exec)?;
        let mut vmax2 = S::Real::ZERO;
        let mut amax2 = S::Real::ZERO;
        for i in 0..n {
            vmax2 = vmax2.max(self.a.v[i].norm2());
            amax2 = amax2.max(self.a.dv[i].norm2());
        }
        self.vmax2 = vmax2;
        self.amax2 = amax2;
        Ok(())
    }

    /// Re-evaluates everything the particle state determines (ghosts,
    /// neighbour lists, summation density, rates and the step limits' maxima)
    /// after the caller changed positions, velocities or densities between
    /// steps, for instance in the storage of a checkpoint before
    /// [`Self::resume_with`]. A run resumed without changes needs none of
    /// this and continues bit for bit without it.
    ///
    /// # Errors
    /// Those of a step's evaluation, such as [`Error::CapacityExceeded`]
    /// where the new arrangement needs more ghosts or neighbours than the
    /// storage holds. The caller checks that the values it wrote are finite.
    pub fn refresh_with<E: Executor>(&mut self, exec: &E) -> Result<()> {
        self.prepare(exec)
    }

    /// Sets every fluid mass so that summation density gives exactly `rho0`
    /// at each particle in the current arrangement (`m_i = rho0 / sum_j W_ij`,
    /// ghosts included), and with continuity density sets `rho = rho0`.
    ///
    /// On a lattice whose supports are complete (periodic or mirrored) all
    /// masses come out equal.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if `rho0` is not positive and finite; errors
    /// of the re-evaluation.
    pub fn calibrate_mass_with<E: Executor>(&mut self, exec: &E, rho0: S::Real) -> Result<()> {
        if !(rho0.is_finite() && rho0 > S::Real::ZERO) {
            return Err(Error::InvalidParameter {
                name: "rho0",
                value: rho0.to_f64(),
                rule: "reference density must be positive and finite",
            });
        }
        let n = self.n;
        self.a.m[..n].fill(S::Real::ONE);
        self.sync_ghost_kinematics(exec, false)?;
        if let Some(spacing) = self.domain.wall_particles() {
            // In units of the fluid's volume, as the fluid's unit masses.
            let unit = (0..S::DIM).fold(1.0, |u, _| u * spacing.to_f64());
            for (k, g) in self.a.ghosts[..self.n_ghost].iter().enumerate() {
                if g.mirrors & boundary::WALL_PARTICLE != 0 {
                    let volume = boundary::wall_particle_volume(&self.domain, self.a.x[n + k]);
                    self.a.m[n + k] = S::Real::from_f64(volume / unit);
                }
            }
        }
        self.run_density(exec, &SummationDensity)?;
        for i in 0..n {
            self.a.m[i] = rho0 / self.a.rho_aux[i];
            if D::EMPTY {
                self.a.rho[i] = rho0;
            }
        }
        self.prepare(exec)
    }

    /// As [`Self::calibrate_mass_with`] on the current thread.
    ///
    /// # Errors
    /// As [`Self::calibrate_mass_with`].
    pub fn calibrate_mass(&mut self, rho0: S::Real) -> Result<()> {
        self.calibrate_mass_with(&Serial, rho0)
    }

    /// Ghost velocities and masses, through the executor: each ghost writes
    /// only its own slots, and a wall particle's gather runs in cell order,
    /// so any split gives the same bits.
    fn sync_ghost_kinematics<E: Executor>(&mut self, exec: &E, homogeneous: bool) -> Result<()> {
        let n = self.n;
        let total = n + self.n_ghost;
        let curved = !homogeneous && self.curved_walls;
        let rho0 = self.params.eos.density::<M>(S::Real::ZERO, S::Real::ONE);
        let domain = &self.domain;
        let Arrays {
            x, ve, m, ghosts, ..
        } = &mut self.a;
        let ghosts = &ghosts[..self.n_ghost];
        let (fluid_v, ghost_v) = ve[..total].split_at_mut(n);
        let (fluid_m, ghost_m) = m[..total].split_at_mut(n);
        let (fluid_v, fluid_m) = (&*fluid_v, &*fluid_m);
        let near = FluidNear {
            kernel: &self.kernel,
            grid: &self.grid,
            cells: self.cells.view(),
            x: &x[..total],
            n,
        };
        run_checked(exec, (ghost_v, ghost_m), &|start,
                                                (ghost_v, ghost_m): (
            &mut [S::Vector],
            &mut [S::Real],
        )| {
            for (k, (vk, mk)) in ghost_v.iter_mut().zip(ghost_m.iter_mut()).enumerate() {
                let g = ghosts[start + k];
                let i = n + start + k;
                if g.mirrors & boundary::WALL_PARTICLE != 0 {
                    // The Shepard average of the fluid velocity, through the
                    // rule of the wall the particle lies behind.
                    let (mut sum_w, mut sum_v, mut sum_r) =
                        (S::Real::ZERO, S::Vector::zero(), S::Vector::zero());
                    near.visit(i, |j, w, r_wf| {
                        sum_w += w;
                        sum_v += fluid_v[j] * w;
                        sum_r += r_wf * w;
                    });
                    let (average, centroid) = if sum_w > S::Real::ZERO {
                        let inv = S::Real::ONE / sum_w;
                        (sum_v * inv, near.x[i] - sum_r * inv)
                    } else {
                        (S::Vector::zero(), near.x[i])
                    };
                    *vk = boundary::wall_particle_velocity(
                        domain,
                        near.x[i],
                        average,
                        centroid,
                        g.mirrors,
                        homogeneous,
                    );
                    let volume = boundary::wall_particle_volume(domain, near.x[i]);
                    *mk = rho0 * S::Real::from_f64(volume);
                    continue;
                }
                let s = g.source as usize;
                if let Some((vg, jacobian)) =
                    boundary::shaped_ghost(domain, near.x[s], fluid_v[s], g.mirrors, homogeneous)
                {
                    *vk = vg;
                    *mk = fluid_m[s] * jacobian;
                    continue;
                }
                *vk = boundary::mirror_velocity(domain, fluid_v[s], g.mirrors, homogeneous);
                if curved {
                    *vk += boundary::curvature_correction(domain, near.x[s], g.mirrors);
                }
                *mk = fluid_m[s];
            }
            Ok(())
        })
    }

    fn sync_ghost_positions(&mut self) {
        let n = self.n;
        let (fluid, ghosts) = self.a.x.split_at_mut(n);
        for (k, g) in self.a.ghosts[..self.n_ghost].iter().enumerate() {
            if g.mirrors & boundary::WALL_PARTICLE != 0 {
                // A moving body's wall particles travel with it.
                if let Some(xw) = boundary::body_wall_particle(&self.domain, g.mirrors, g.source) {
                    ghosts[k] = boundary::nearest_image(&self.domain, xw, ghosts[k]);
                }
                continue;
            }
            let image =
                boundary::mirror_position(&self.domain, fluid[g.source as usize], g.mirrors);
            // Keep the periodic image the neighbour lists were built with.
            ghosts[k] = boundary::nearest_image(&self.domain, image, ghosts[k]);
        }
    }

    /// Ghost densities and pressures, through the executor (as
    /// [`Self::sync_ghost_kinematics`]: the same bits for any split).
    fn sync_ghost_thermo<E: Executor>(&mut self, exec: &E) -> Result<()> {
        let n = self.n;
        let total = n + self.n_ghost;
        let gravity = self.domain.wall_gravity();
        let eos = self.params.eos;
        // The fallback density for a wall pressure the equation cannot invert.
        let rho0 = eos.density::<M>(S::Real::ZERO, S::Real::ONE);
        let domain = &self.domain;
        let Arrays {
            x, rho, p, ghosts, ..
        } = &mut self.a;
        let ghosts = &ghosts[..self.n_ghost];
        let (fluid_rho, ghost_rho) = rho[..total].split_at_mut(n);
        let (fluid_p, ghost_p) = p[..total].split_at_mut(n);
        let (fluid_rho, fluid_p) = (&*fluid_rho, &*fluid_p);
        let near = FluidNear {
            kernel: &self.kernel,
            grid: &self.grid,
            cells: self.cells.view(),
            x: &x[..total],
            n,
        };
        run_checked(exec, (ghost_rho, ghost_p), &|start,
                                                  (ghost_rho, ghost_p): (
            &mut [S::Real],
            &mut [S::Real],
        )| {
            for (k, (rk, pk)) in ghost_rho.iter_mut().zip(ghost_p.iter_mut()).enumerate() {
                let g = ghosts[start + k];
                let i = n + start + k;
                let s = g.source as usize;
                if g.mirrors & boundary::WALL_PARTICLE != 0 {
                    // p_w = (sum_f p_f W + g . sum_f rho_f r_wf W) / sum_f W.
                    let (mut sum_w, mut sum_p, mut sum_r) =
                        (S::Real::ZERO, S::Real::ZERO, S::Vector::zero());
                    near.visit(i, |j, w, r_wf| {
                        sum_w += w;
                        sum_p += fluid_p[j] * w;
                        sum_r += r_wf * (fluid_rho[j] * w);
                    });
                    let mut pw = S::Real::ZERO;
                    if sum_w > S::Real::ZERO {
                        pw = sum_p;
                        if let Some(g) = gravity {
                            pw += g.dot(sum_r);
                        }
                        // A turning body's wall accelerates: `(g - a_w)`.
                        if let Some(a) = boundary::body_acceleration(domain, near.x[i], g.mirrors) {
                            pw -= a.dot(sum_r);
                        }
                        pw *= S::Real::ONE / sum_w;
                    }
                    *pk = pw;
                    *rk = eos.density::<M>(pw, rho0);
                    continue;
                }
                let Some(gravity) = gravity else {
                    *rk = fluid_rho[s];
                    *pk = fluid_p[s];
                    continue;
                };
                // The wall's normal momentum balance (`Domain::with_wall_gravity`).
                let offset = boundary::image_offset(domain, near.x[s], g.mirrors);
                let pg = fluid_p[s] + fluid_rho[s] * gravity.dot(offset);
                *pk = pg;
                *rk = eos.density::<M>(pg, fluid_rho[s]);
            }
            Ok(())
        })
    }

    /// Runs a density group into `rho_aux[..n]`; with neighbour lists it also
    /// partitions each row (see [`Neighbours::Lists`]).
    fn run_density<E: Executor, G: Term<S>>(&mut self, exec: &E, group: &G) -> Result<()> {
        let n = self.n;
        let total = n + self.n_ghost;
        let walls = self.walls_from();
        let width = if cfg!(feature = "neighbour-lists") {
            self.list_width
        } else {
            0
        };
        let Arrays {
            x,
            ve,
            m,
            rho,
            p,
            rho_aux,
            nbr,
            nbr_count,
            ..
        } = &mut self.a;
        let fields = Fields {
            x: &x[..total],
            v: &ve[..total],
            m: &m[..total],
            rho: &rho[..total],
            p: &p[..total],
            walls,
        };
        if width == 0 {
            let pass = Pass {
                kernel: &self.kernel,
                grid: &self.grid,
                neighbours: Neighbours::Cells(self.cells.view()),
                consts: &self.consts,
                fields,
            };
            return run_checked(exec, &mut rho_aux[..n], &|start, out: &mut [S::Real]| {
                for (k, o) in out.iter_mut().enumerate() {
                    *o = pass.accumulate::<G, false>(group, start + k).rho;
                }
                Ok(())
            });
        }
        let pass = Pass {
            kernel: &self.kernel,
            grid: &self.grid,
            neighbours: Neighbours::Lists {
                rows: &[],
                counts: &[],
                width,
                partitioned: false,
            },
            consts: &self.consts,
            fields,
        };
        run_checked(
            exec,
            (
                &mut rho_aux[..n],
                Rows {
                    data: &mut nbr[..n * width],
                    width,
                },
                &mut nbr_count[..n],
            ),
            &|start, (out, rows, counts): (&mut [S::Real], Rows<'_, u32>, &mut [u32])| {
                for (k, (o, word)) in out.iter_mut().zip(counts.iter_mut()).enumerate() {
                    let used = ((*word & COUNT_MASK) as usize).min(width);
                    let row = &mut rows.data[k * width..k * width + used];
                    let (acc, inside) = pass.accumulate_partition::<G>(group, start + k, row);
                    *o = acc.rho;
                    *word = used as u32 | ((inside as u32) << 16);
                }
                Ok(())
            },
        )?;
        self.partitioned = true;
        Ok(())
    }

    /// Ghosts and neighbours at the current positions: with lists, rebuilt
    /// only when the skin may have been used up; without, every time.
    fn update_neighbours<E: Executor>(&mut self, exec: &E) -> Result<()> {
        self.partitioned = false;
        if !cfg!(feature = "neighbour-lists") || self.list_width == 0 {
            self.build_cells(self.kernel.radius())?;
            return Ok(());
        }
        let margin = (self.list_radius - self.kernel.radius()).to_f64();
        if self.lists_fresh && 2.0 * self.travel < margin {
            self.sync_ghost_positions();
            return Ok(());
        }
        let n = self.n;
        for i in 0..n {
            self.a.x[i] = self.domain.wrap::<M>(self.a.x[i]);
        }
        self.build_cells(self.list_radius)?;
        let total = n + self.n_ghost;
        let width = self.list_width;
        let view = self.cells.view();
        let grid = &self.grid;
        let x = &self.a.x[..total];
        run_checked(
            exec,
            (
                Rows {
                    data: &mut self.a.nbr[..n * width],
                    width,
                },
                &mut self.a.nbr_count[..n],
            ),
            &|start, (rows, counts): (Rows<'_, u32>, &mut [u32])| {
                for (k, count) in counts.iter_mut().enumerate() {
                    let row = &mut rows.data[k * width..(k + 1) * width];
                    let mut used = 0usize;
                    view.visit_coded(grid, x, start + k, |j, code, _, _| {
                        if used < width {
                            row[used] = j as u32 | (code << INDEX_BITS);
                        }
                        used += 1;
                    });
                    if used > width {
                        return Err(Error::CapacityExceeded {
                            buffer: "neighbours",
                            needed: used,
                            available: width,
                        });
                    }
                    *count = used as u32;
                }
                Ok(())
            },
        )?;
        self.travel = 0.0;
        self.lists_fresh = true;
        Ok(())
    }

    /// Index of the first wall particle ([`Fields::walls`]): the wall
    /// particles come last in the ghost tail.
    fn walls_from(&self) -> usize {
        let ghosts = &self.a.ghosts[..self.n_ghost];
        let first = if self.domain.wall_particles().is_some() {
            ghosts
                .iter()
                .position(|g| g.mirrors & boundary::WALL_PARTICLE != 0)
                .unwrap_or(ghosts.len())
        } else {
            ghosts.len()
        };
        self.n + first
    }

    /// Reorders (when due), generates ghosts within `radius` of the walls and
    /// sorts all particles into cells.
    fn build_cells(&mut self, radius: S::Real) -> Result<()> {
        let every = self.params.reorder_every;
        if every > 0 && self.builds > 0 && self.builds.is_multiple_of(every) {
            self.reorder_by_cell();
        }
        self.builds = self.builds.wrapping_add(1);
        let n = self.n;
        self.n_ghost = boundary::generate(&self.domain, radius, self.a.x, n, self.a.ghosts)?;
        self.cells.build(&self.grid, &self.a.x[..n + self.n_ghost])
    }

    /// Ghosts, neighbours, density, equation of state and forces at the
    /// current positions and pass velocities `ve`.
    fn evaluate<E: Executor>(&mut self, exec: &E) -> Result<()> {
        let n = self.n;
        self.update_neighbours(exec)?;
        self.sync_ghost_kinematics(exec, false)?;
        if !D::EMPTY {
            let density = self.density;
            self.run_density(exec, &density)?;
        }
        let eos = self.params.eos;
        let summation = !D::EMPTY;
        {
            let Arrays {
                rho, p, rho_aux, ..
            } = &mut self.a;
            let rho_aux = &rho_aux[..n];
            run_checked(exec, (&mut rho[..n], &mut p[..n]), &|start,
                                                              (rho, p): (
                &mut [S::Real],
                &mut [S::Real],
            )| {
                for k in 0..rho.len() {
                    if summation {
                        rho[k] = rho_aux[start + k];
                    }
                    p[k] = eos.pressure::<M>(rho[k]);
                }
                Ok(())
            })?;
        }
        self.sync_ghost_thermo(exec)?;
        self.run_forces::<E, false>(exec)
    }

    /// Permutes the fluid particles into the cell order of the last cell list.
    ///
    /// Called before a cell-list build, where `dv`, `drho` and the cell index
    /// are about to be recomputed: they serve as scratch. The state that lives
    /// across the evaluation (`x`, `v`, `ve`, `m`, `rho`, `rho_aux`) is permuted.
    fn reorder_by_cell(&mut self) {
        let n = self.n;
        let Some(perm) = self.cells.order_of_first(n) else {
            return;
        };
        if perm.len() != n {
            return;
        }
        fn apply<T: Copy>(data: &mut [T], scratch: &mut [T], perm: &[u32]) {
            scratch.copy_from_slice(data);
            for (d, &p) in data.iter_mut().zip(perm) {
                *d = scratch[p as usize];
            }
        }
        let Arrays {
            x,
            v,
            ve,
            m,
            rho,
            rho_aux,
            dv,
            drho,
            ..
        } = &mut self.a;
        let (dv, drho) = (&mut dv[..n], &mut drho[..n]);
        apply(&mut x[..n], dv, perm);
        apply(&mut v[..n], dv, perm);
        apply(&mut ve[..n], dv, perm);
        apply(&mut m[..n], drho, perm);
        apply(&mut rho[..n], drho, perm);
        apply(&mut rho_aux[..n], drho, perm);
    }

    /// The force pass (or its viscous part) into `dv[..n]`, `drho[..n]`.
    fn run_forces<E: Executor, const VISCOUS_ONLY: bool>(&mut self, exec: &E) -> Result<()> {
        let n = self.n;
        let total = n + self.n_ghost;
        let walls = self.walls_from();
        let Arrays {
            x,
            ve,
            m,
            rho,
            p,
            dv,
            drho,
            nbr,
            nbr_count,
            shift,
            ..
        } = &mut self.a;
        let pass = Pass {
            kernel: &self.kernel,
            grid: &self.grid,
            neighbours: neighbour_source(
                &self.cells,
                nbr,
                nbr_count,
                self.list_width,
                self.partitioned,
            ),
            consts: &self.consts,
            fields: Fields {
                x: &x[..total],
                v: &ve[..total],
                m: &m[..total],
                rho: &rho[..total],
                p: &p[..total],
                walls,
            },
        };
        let forces = &self.forces;
        if T::SHIFTS && !VISCOUS_ONLY {
            let shift = &mut shift[..n];
            return run_checked(
                exec,
                (&mut dv[..n], &mut drho[..n], shift),
                &|start, (dv, drho, shift): RatesParts<'_, S>| {
                    for k in 0..dv.len() {
                        let acc = pass.accumulate::<T, false>(forces, start + k);
                        dv[k] = acc.dv;
                        drho[k] = acc.drho;
                        shift[k] = acc.shift;
                    }
                    Ok(())
                },
            );
        }
        run_checked(exec, (&mut dv[..n], &mut drho[..n]), &|start,
                                                            (dv, drho): (
            &mut [S::Vector],
            &mut [S::Real],
        )| {
            for k in 0..dv.len() {
                let acc = pass.accumulate::<T, VISCOUS_ONLY>(forces, start + k);
                dv[k] = acc.dv;
                drho[k] = acc.drho;
            }
            Ok(())
        })
    }

    /// Largest decay rate of the viscous operator by power iteration, with
    /// the wall rule's homogeneous part on the ghosts.
    fn estimate_viscous_rate<E: Executor>(&mut self, exec: &E) -> Result<f64> {
        let n = self.n;
        if !T::VISCOUS || n == 0 {
            return Ok(0.0);
        }
        // A fixed pseudo-random start (xorshift), so runs are reproducible.
        let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut norm2 = 0.0f64;
        for i in 0..n {
            self.a.ve[i] = S::Vector::from_fn(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let u = (state >> 11) as f64 / (1u64 << 53) as f64;
                S::Real::from_f64(2.0 * u - 1.0)
            });
            norm2 += self.a.ve[i].norm2().to_f64();
        }
        let mut scale = S::Real::ONE / M::sqrt(S::Real::from_f64(norm2));
        let mut rate = 0.0;
        for _ in 0..self.params.viscous_iterations {
            for i in 0..n {
                self.a.ve[i] *= scale;
            }
            self.sync_ghost_kinematics(exec, true)?;
            self.run_forces::<E, true>(exec)?;
            let norm = M::sqrt(S::Real::from_f64(
                self.a.dv[..n]
                    .iter()
                    .map(|a| a.norm2().to_f64())
                    .sum::<f64>(),
            ))
            .to_f64();
            if !(norm > 0.0 && norm.is_finite()) {
                break;
            }
            rate = norm;
            self.a.ve[..n].copy_from_slice(&self.a.dv[..n]);
            scale = S::Real::from_f64(1.0 / norm);
        }
        Ok(rate)
    }

    /// Advances one step of `dt` seconds on the current thread.
    ///
    /// # Errors
    /// As [`Self::step_with`].
    pub fn step(&mut self, dt: f64) -> Result<()> {
        self.step_with(&Serial, dt)
    }

    /// Advances one step of `dt` seconds, running the passes through `exec`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for a non-positive or non-finite `dt`;
    /// [`Error::Unstable`] naming the step and the first particle at fault if
    /// a velocity, position or density becomes non-finite, a speed exceeds
    /// the limit, a density turns non-positive or a particle leaves the
    /// domain; [`Error::CapacityExceeded`] if the ghosts or the neighbour
    /// lists outgrow their buffers. After an error the state is unspecified
    /// and every later call returns the same error.
    pub fn step_with<E: Executor>(&mut self, exec: &E, dt: f64) -> Result<()> {
        // Bounded by its own drift only.
        self.step_bounded_with(exec, dt, S::Real::ZERO)
    }

    /// Advances one step like [`Self::step_with`], with the Verlet travel
    /// counted from the larger of this solver's fastest transport speed
    /// (squared) and `drift2`: a caller that runs one scene as several
    /// solvers, each holding part of the particles, passes the largest
    /// [`Self::drift_speed2`] of them all, so that every part rebuilds its
    /// lists at the steps a single solver would.
    ///
    /// # Errors
    /// As [`Self::step_with`]; [`Error::InvalidParameter`] for a negative or
    /// non-finite `drift2`.
    pub fn step_bounded_with<E: Executor>(
        &mut self,
        exec: &E,
        dt: f64,
        drift2: S::Real,
    ) -> Result<()> {
        if !(drift2.is_finite() && drift2 >= S::Real::ZERO) {
            return Err(Error::InvalidParameter {
                name: "drift2",
                value: drift2.to_f64(),
                rule: "the squared drift speed bound must be finite and not negative",
            });
        }
        if let Some(e) = self.failed {
            return Err(e);
        }
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "dt",
                value: dt,
                rule: "time step must be positive and finite",
            });
        }
        self.density.validate()?;
        self.forces.validate()?;
        let result = self.advance(exec, dt, drift2);
        if let Err(e) = result {
            self.failed = Some(e);
        }
        result
    }

    /// The largest squared transport speed the next step of `dt` seconds
    /// will drift a fluid particle with (bitwise the drift's own figure).
    pub fn drift_speed2(&self, dt: f64) -> S::Real {
        let half = S::Real::from_f64(0.5 * dt);
        let n = self.n;
        let shifting = T::SHIFTS;
        let mut fastest = S::Real::ZERO;
        for i in 0..n {
            let shift = if shifting {
                Some(self.a.shift[i])
            } else {
                None
            };
            let (_, vt) = transport(self.a.v[i], self.a.dv[i], half, shift);
            fastest = fastest.max(vt.norm2());
        }
        fastest
    }

    /// The travel since the last list build after a step of `dt` seconds
    /// at squared transport speed `drift2`.
    fn travel_after(&self, dt: f64, drift2: S::Real) -> f64 {
        // A point-reflected ghost also moves with twice its wall's
        // speed, and so may the image through a moving body.
        let walls = self.anchor_speed + self.domain.body_speed();
        self.travel + (M::sqrt(drift2).to_f64() + 2.0 * walls) * dt
    }

    /// Whether the next step of `dt` seconds, at squared transport speed
    /// `drift2` (at least [`Self::drift_speed2`]), rebuilds the neighbour
    /// lists (always without lists: the cell list is rebuilt every step).
    pub fn rebuilds_next(&self, dt: f64, drift2: S::Real) -> bool {
        if !cfg!(feature = "neighbour-lists") || self.list_width == 0 {
            return true;
        }
        let margin = (self.list_radius - self.kernel.radius()).to_f64();
        !(self.lists_fresh && 2.0 * self.travel_after(dt, drift2) < margin)
    }

    /// The fluid's state, writable between steps.
    ///
    /// For a caller that keeps some particles equal to those of another
    /// run of the same scene (the copies a distributed run holds of its
    /// neighbours' particles): the lists, ghosts and cells are not rebuilt,
    /// so what is written must be the state that run has at this step.
    /// Anything else leaves the lists unspecified: build a new solver
    /// instead ([`Self::resume_with`] with `lists_fresh` false).
    pub fn fluid_mut(&mut self) -> FluidMut<'_, S> {
        let n = self.n;
        let shifts = if T::SHIFTS { n } else { 0 };
        FluidMut {
            x: &mut self.a.x[..n],
            v: &mut self.a.v[..n],
            rho: &mut self.a.rho[..n],
            p: &mut self.a.p[..n],
            ve: &mut self.a.ve[..n],
            dv: &mut self.a.dv[..n],
            drho: &mut self.a.drho[..n],
            rho_aux: &mut self.a.rho_aux[..n],
            shift: &mut self.a.shift[..shifts],
        }
    }

    fn advance<E: Executor>(&mut self, exec: &E, dt: f64, bound: S::Real) -> Result<()> {
        let n = self.n;
        let step = self.step + 1;
        let dtf = S::Real::from_f64(dt);
        let half = S::Real::from_f64(0.5 * dt);
        let summation = !D::EMPTY;
        let domain = self.domain;
        // With Verlet lists, positions are wrapped at rebuilds only.
        let wrap = !cfg!(feature = "neighbour-lists") || self.list_width == 0;
        let params = self.params;
        let Max2(drift2, _) = {
            let Arrays {
                x,
                v,
                ve,
                rho,
                rho_aux,
                dv,
                drho,
                shift,
                ..
            } = &mut self.a;
            let (dv, drho) = (&dv[..n], &drho[..n]);
            let shifting = T::SHIFTS;
            let shift: &[S::Vector] = if shifting { &shift[..n] } else { &[] };
            run_checked(
                exec,
                (
                    &mut x[..n],
                    &mut v[..n],
                    &mut ve[..n],
                    &mut rho[..n],
                    &mut rho_aux[..n],
                ),
                &|start, (x, v, ve, rho, rho_aux): DriftParts<'_, S>| {
                    let mut fastest = S::Real::ZERO;
                    for k in 0..x.len() {
                        let i = start + k;
                        let a = dv[i];
                        // The transport velocity: with shifting, v + u_s.
                        let u = if shifting { Some(shift[i]) } else { None };
                        let (vh, vt) = transport(v[k], a, half, u);
                        v[k] = vh;
                        ve[k] = vh + a * half;
                        fastest = fastest.max(vt.norm2());
                        let xn = x[k] + vt * dtf;
                        if !xn.is_finite() {
                            return Err(unstable(step, i, Fault::NonFinite { field: "position" }));
                        }
                        let xn = if wrap { domain.wrap::<M>(xn) } else { xn };
                        if let Some((axis, c)) = domain.outside(xn) {
                            return Err(unstable(
                                step,
                                i,
                                Fault::LeftDomain {
                                    axis,
                                    coordinate: c.to_f64(),
                                },
                            ));
                        }
                        if let Some((wall, distance)) = domain.behind_wall(xn) {
                            return Err(unstable(step, i, Fault::BehindWall { wall, distance }));
                        }
                        x[k] = xn;
                        if !summation {
                            let rh = params.floored(rho[k] + drho[i] * half);
                            rho_aux[k] = rh;
                            rho[k] = params.floored(rh + drho[i] * half);
                            if !(rho[k] > S::Real::ZERO) {
                                return Err(unstable(
                                    step,
                                    i,
                                    Fault::NonPositiveDensity {
                                        value: rho[k].to_f64(),
                                    },
                                ));
                            }
                        }
                    }
                    Ok(Max2(fastest, S::Real::ZERO))
                },
            )?
        };
        if cfg!(feature = "neighbour-lists") && self.list_width > 0 {
            self.travel = self.travel_after(dt, drift2.max(bound));
        }
        self.domain.set_wall_time(self.time + dt);
        self.evaluate(exec)?;
        let eos = params.eos;
        let limit2 = self.speed_limit2;
        let Max2(vmax2, amax2) = {
            let Arrays {
                v,
                rho,
                p,
                rho_aux,
                dv,
                drho,
                ..
            } = &mut self.a;
            let (dv, drho, rho_aux) = (&dv[..n], &drho[..n], &rho_aux[..n]);
            run_checked(
                exec,
                (&mut v[..n], &mut rho[..n], &mut p[..n]),
                &|start, (v, rho, p): KickParts<'_, S>| {
                    let mut max = Max2(S::Real::ZERO, S::Real::ZERO);
                    for k in 0..v.len() {
                        let i = start + k;
                        let a = dv[i];
                        let vn = v[k] + a * half;
                        v[k] = vn;
                        let speed2 = vn.norm2();
                        if !speed2.is_finite() {
                            return Err(unstable(step, i, Fault::NonFinite { field: "velocity" }));
                        }
                        if speed2 > limit2 {
                            return Err(unstable(
                                step,
                                i,
                                Fault::TooFast {
                                    speed: M::sqrt(speed2).to_f64(),
                                    limit: M::sqrt(limit2).to_f64(),
                                },
                            ));
                        }
                        if !summation {
                            rho[k] = params.floored(rho_aux[i] + drho[i] * half);
                            p[k] = eos.pressure::<M>(rho[k]);
                        }
                        if !(rho[k] > S::Real::ZERO && rho[k].is_finite()) {
                            return Err(unstable(
                                step,
                                i,
                                Fault::NonPositiveDensity {
                                    value: rho[k].to_f64(),
                                },
                            ));
                        }
                        max.0 = max.0.max(speed2);
                        max.1 = max.1.max(a.norm2());
                    }
                    Ok(max)
                },
            )?
        };
        self.vmax2 = vmax2;
        self.amax2 = amax2;
        self.time += dt;
        self.step = step;
        Ok(())
    }

    /// Time-step limits at the current state.
    pub fn limits(&self) -> Limits {
        self.limits_at(self.vmax2, self.amax2)
    }

    /// The time-step limits this solver would give with `vmax2` its
    /// largest squared fluid speed and `amax2` its largest squared
    /// acceleration (for a caller that runs one scene as several solvers
    /// and takes the maxima over all of them; [`Self::limits`] is this at
    /// the solver's own maxima).
    pub fn limits_at(&self, vmax2: S::Real, amax2: S::Real) -> Limits {
        let h = self.params.h.to_f64();
        let c = (self.consts.c0 + M::sqrt(vmax2)).to_f64();
        let amax_r = M::sqrt(amax2);
        let amax = amax_r.to_f64();
        Limits {
            cfl: if c > 0.0 { 0.25 * h / c } else { f64::INFINITY },
            viscous: if self.viscous_rate > 0.0 {
                1.0 / self.viscous_rate
            } else {
                f64::INFINITY
            },
            force: if amax > 0.0 {
                0.25 * M::sqrt(self.params.h / amax_r).to_f64()
            } else {
                f64::INFINITY
            },
        }
    }

    /// The viscous operator's largest decay rate `lambda_max` (1/s) estimated at set-up.
    pub fn viscous_rate(&self) -> f64 {
        self.viscous_rate
    }

    /// Cell-list builds so far (with neighbour lists: list rebuilds; wraps at 2^32).
    pub fn neighbour_builds(&self) -> u32 {
        self.builds
    }

    fn check_range(&self, start: usize, len: usize) -> Result<()> {
        match start.checked_add(len) {
            Some(end) if end <= self.n => Ok(()),
            _ => Err(Error::InvalidParameter {
                name: "range",
                value: start as f64 + len as f64,
                rule: "the range must lie within the fluid particles",
            }),
        }
    }

    /// Summation density for fluid particles `start..start + out.len()`,
    /// reading only shared state. The density group `D` decides what is summed.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if the range leaves the fluid.
    pub fn density_range(&self, start: usize, out: &mut [S::Real]) -> Result<()> {
        self.check_range(start, out.len())?;
        let pass = self.pass();
        for (k, o) in out.iter_mut().enumerate() {
            *o = pass.accumulate::<D, false>(&self.density, start + k).rho;
        }
        Ok(())
    }

    /// Accelerations and density rates for fluid particles
    /// `start..start + dv.len()`, reading only shared state: any split of the
    /// fluid into ranges, in any order, reproduces [`Self::accelerations`]
    /// bit for bit (as long as no step was taken since the last evaluation).
    ///
    /// # Errors
    /// [`Error::LengthMismatch`] if `drho` and `dv` differ in length;
    /// [`Error::InvalidParameter`] if the range leaves the fluid.
    pub fn rates_range(
        &self,
        start: usize,
        dv: &mut [S::Vector],
        drho: &mut [S::Real],
    ) -> Result<()> {
        self.rates_range_of(&self.forces, start, dv, drho)
    }

    /// The rates of any term group `U` (not necessarily the solver's own) for
    /// fluid particles `start..start + dv.len()`, on the fields as they are
    /// now and the ghosts and neighbours of the last evaluation: the
    /// contribution of one part of the physics, for example the viscous and
    /// diffusive terms alone, whose work an energy budget integrates. With
    /// `U` the solver's force group this is [`Self::rates_range`].
    ///
    /// # Errors
    /// As [`Self::rates_range`].
    pub fn rates_range_of<U: Term<S>>(
        &self,
        terms: &U,
        start: usize,
        dv: &mut [S::Vector],
        drho: &mut [S::Real],
    ) -> Result<()> {
        if drho.len() != dv.len() {
            return Err(Error::LengthMismatch {
                buffer: "drho",
                expected: dv.len(),
                got: drho.len(),
            });
        }
        self.check_range(start, dv.len())?;
        let pass = self.pass();
        for k in 0..dv.len() {
            let acc = pass.accumulate::<U, false>(terms, start + k);
            dv[k] = acc.dv;
            drho[k] = acc.drho;
        }
        Ok(())
    }

    fn pass(&self) -> Pass<'_, S, K, M> {
        let total = self.n + self.n_ghost;
        Pass {
            kernel: &self.kernel,
            grid: &self.grid,
            neighbours: neighbour_source(
                &self.cells,
                self.a.nbr,
                self.a.nbr_count,
                self.list_width,
                self.partitioned,
            ),
            consts: &self.consts,
            fields: Fields {
                x: &self.a.x[..total],
                v: &self.a.ve[..total],
                m: &self.a.m[..total],
                rho: &self.a.rho[..total],
                p: &self.a.p[..total],
                walls: self.walls_from(),
            },
        }
    }

    /// The closest pair of distinct fluid particles within the support at the
    /// last evaluation, as `(i, j, distance)` with `i < j`; `None` if no two
    /// fluid particles are that close. Serial; one neighbour scan, without
    /// kernel evaluations (a state check for output times).
    pub fn closest_fluid_pair(&self) -> Option<(usize, usize, f64)> {
        let pass = self.pass();
        let n = self.n;
        let mut best: Option<(usize, usize, S::Real)> = None;
        for i in 0..n {
            pass.for_each_neighbour(i, |j, r2| {
                if j < n && j != i && best.is_none_or(|b| r2 < b.2) {
                    best = Some((i.min(j), i.max(j), r2));
                }
            });
        }
        best.map(|(i, j, r2)| (i, j, M::sqrt(r2).to_f64()))
    }

    /// Number of fluid particles.
    pub fn n_fluid(&self) -> usize {
        self.n
    }

    /// Number of ghosts at the last evaluation.
    pub fn n_ghost(&self) -> usize {
        self.n_ghost
    }

    /// Simulated time in seconds.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.step
    }

    /// Fluid positions, relative to the domain's lower corner (with
    /// neighbour lists, up to half a skin outside a periodic side between
    /// rebuilds).
    pub fn positions(&self) -> &[S::Vector] {
        &self.a.x[..self.n]
    }

    /// Ghost positions at the last evaluation.
    pub fn ghost_positions(&self) -> &[S::Vector] {
        &self.a.x[self.n..self.n + self.n_ghost]
    }

    /// Fluid velocities.
    pub fn velocities(&self) -> &[S::Vector] {
        &self.a.v[..self.n]
    }

    /// Fluid densities.
    pub fn densities(&self) -> &[S::Real] {
        &self.a.rho[..self.n]
    }

    /// Fluid pressures.
    pub fn pressures(&self) -> &[S::Real] {
        &self.a.p[..self.n]
    }

    /// Fluid masses.
    pub fn masses(&self) -> &[S::Real] {
        &self.a.m[..self.n]
    }

    /// Accelerations from the last evaluation.
    pub fn accelerations(&self) -> &[S::Vector] {
        &self.a.dv[..self.n]
    }

    /// Density rates from the last evaluation (zero without a continuity term).
    pub fn density_rates(&self) -> &[S::Real] {
        &self.a.drho[..self.n]
    }

    /// The domain.
    pub fn domain(&self) -> &Domain<S> {
        &self.domain
    }

    /// Changes the gravity the wall ghosts' pressure balances
    /// ([`Domain::with_wall_gravity`]) between steps: for a body force that
    /// changes in time (a ramp), kept equal to the force term's.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if a component is not finite; the
    /// solver is then unchanged.
    pub fn set_wall_gravity(&mut self, g: S::Vector) -> Result<()> {
        self.domain = self.domain.with_wall_gravity(g)?;
        Ok(())
    }

    /// The kernel bound to `h`.
    pub fn kernel(&self) -> &SmoothingKernel<S, K, M> {
        &self.kernel
    }

    /// The force group (with the coefficients of the last step).
    pub fn forces(&self) -> &T {
        &self.forces
    }

    /// The force group, to change its coefficients between steps (for
    /// example a shifting velocity scale that follows the flow). The group's
    /// type, and so which terms run, cannot change.
    pub fn forces_mut(&mut self) -> &mut T {
        &mut self.forces
    }

    /// Largest fluid speed at the end of the last step.
    pub fn max_speed(&self) -> f64 {
        M::sqrt(self.vmax2).to_f64()
    }

    /// The parameters.
    pub fn params(&self) -> &Params<S::Real> {
        &self.params
    }
}

/// Whether any wall has a velocity curvature for its ghost rule.
fn has_curved_walls<S: Space>(domain: &Domain<S>) -> bool {
    (0..S::DIM).any(|a| {
        [Side::Lower, Side::Upper]
            .into_iter()
            .filter_map(|side| domain.wall(a, side))
            .any(|w| w.curvature != S::Vector::zero())
    })
}

/// The fastest point-reflecting wall (its anchor's speed), or zero.
fn point_wall_speed<S: Space>(domain: &Domain<S>) -> f64 {
    let mut fastest = 0.0f64;
    for a in 0..S::DIM {
        for side in [Side::Lower, Side::Upper] {
            if let Some(w) = domain.wall(a, side) {
                if w.reflection == crate::domain::Reflection::Point {
                    fastest = fastest.max(crate::math::f64s::sqrt(w.velocity.norm2().to_f64()));
                }
            }
        }
    }
    fastest
}

/// The neighbour source of a pass: lists when the solver has them, else cells.
fn neighbour_source<'s>(
    cells: &'s CellList<'_>,
    rows: &'s [u32],
    counts: &'s [u32],
    width: usize,
    partitioned: bool,
) -> Neighbours<'s> {
    if cfg!(feature = "neighbour-lists") && width > 0 {
        Neighbours::Lists {
            rows,
            counts,
            width,
            partitioned,
        }
    } else {
        Neighbours::Cells(cells.view())
    }
}

// The batched visit walks neighbour-list rows; without the
// `neighbour-lists` feature the solver refuses lists and walks cells.
#[cfg(all(test, feature = "neighbour-lists"))]
mod tests {
    use super::*;
    use crate::eos::Eos;
    use crate::kernel::{CubicSpline, WendlandC2};
    use crate::math::Libm;
    use crate::space::{D2, D3};
    use crate::store::Store;
    use crate::terms::{Continuity, MorrisViscosity, PressureGradient, SummationDensity};
    use std::vec;
    use std::vec::Vec;

    /// The compiler's square root (taken in `f64`, which rounds an `f32`
    /// root exactly as `f32::sqrt`), libm for the rest: the bits of
    /// `sph_std::math::Host` and of the core bench's `Host`, written again
    /// here because the core cannot depend on the frontend.
    #[derive(Clone, Copy, Debug, Default)]
    struct HostSqrt;
    impl<F: Real> Math<F> for HostSqrt
    where
        Libm: Math<F>,
    {
        const NAME: &'static str = "host-sqrt";
        fn sqrt(x: F) -> F {
            F::from_f64(x.to_f64().sqrt())
        }
        fn exp(x: F) -> F {
            <Libm as Math<F>>::exp(x)
        }
        fn powf(x: F, y: F) -> F {
            <Libm as Math<F>>::powf(x, y)
        }
        fn floor(x: F) -> F {
            <Libm as Math<F>>::floor(x)
        }
    }

    /// The sums of destination `i` over the entries of its list row inside
    /// the support, in row order, one pair at a time (the cell scan's
    /// `visit`): the reference for the batched passes.
    fn one_at_a_time<S, K, M, T, const VISCOUS_ONLY: bool>(
        pass: &Pass<'_, S, K, M>,
        terms: &T,
        i: usize,
    ) -> Acc<S>
    where
        S: Space,
        K: Kernel,
        M: Math<S::Real>,
        T: Term<S>,
    {
        let f = pass.fields.uniform();
        let (d, mut acc) = start::<S>(&f, i);
        let mut scratch = T::Scratch::default();
        if !VISCOUS_ONLY {
            terms.init(pass.consts, &d, &mut acc);
        }
        let Neighbours::Lists {
            rows,
            counts,
            width,
            ..
        } = pass.neighbours
        else {
            panic!("the scene has lists");
        };
        let used = (counts[i] & COUNT_MASK) as usize;
        for &entry in &rows[i * width..i * width + used] {
            let (j, r_ij) = pass.separation(&f, f.x[i], entry);
            let r2 = r_ij.norm2();
            if r2 < pass.kernel.radius2() {
                pass.visit::<T, VISCOUS_ONLY>(&f, terms, &d, (&mut acc, &mut scratch), j, r_ij, r2);
            }
        }
        if !VISCOUS_ONLY {
            terms.finish(pass.consts, &d, &scratch, &mut acc);
        }
        acc
    }

    fn same_bits<S: Space>(a: &Acc<S>, b: &Acc<S>, what: &str, i: usize) {
        let bits = |x: S::Real| x.to_f64().to_bits();
        assert_eq!(bits(a.rho), bits(b.rho), "{what}: rho of {i}");
        assert_eq!(bits(a.drho), bits(b.drho), "{what}: drho of {i}");
        for k in 0..S::DIM {
            assert_eq!(bits(a.dv[k]), bits(b.dv[k]), "{what}: dv[{k}] of {i}");
        }
    }

    /// A periodic box of `side^DIM` jittered particles with random
    /// velocities and lists, stepped `steps` times; then every pass of the
    /// solver (density, forces, viscous part, and the force pass over rows
    /// no density pass has sorted) is compared with `one_at_a_time` for
    /// every particle, bit for bit.
    fn batched_passes_match<S, K, M, const N: usize>(side: usize, beta: f64, steps: usize)
    where
        S: Space,
        K: Kernel,
        M: Math<S::Real>,
    {
        let d = S::DIM;
        let n = side.pow(d as u32);
        assert!(n <= N);
        let dx = 1.0 / side as f64;
        let h = S::Real::from_f64(beta * dx);
        let mut domain =
            Domain::<S>::new(S::Global::zero(), S::Vector::splat(S::Real::ONE)).unwrap();
        for a in 0..d {
            domain = domain.with_periodic(a).unwrap();
        }
        type Forces<S> = (
            Continuity,
            PressureGradient,
            MorrisViscosity<<S as Space>::Real>,
        );
        let forces: Forces<S> = (
            Continuity,
            PressureGradient,
            MorrisViscosity {
                mu: S::Real::from_f64(0.05),
            },
        );
        let cells =
            Solver::<S, K, M, SummationDensity, Forces<S>>::cells_needed(&domain, h).unwrap();
        let mut store: Store<S, N, 1024> = Store::new();
        assert!(cells <= 1024);
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        };
        for k in 0..n {
            let (mut x, mut v, mut rest) = (S::Vector::zero(), S::Vector::zero(), k);
            for a in 0..d {
                let c = (rest % side) as f64;
                rest /= side;
                x[a] = S::Real::from_f64((c + 0.5 + 0.4 * rnd()) * dx);
                v[a] = S::Real::from_f64(0.3 * rnd());
            }
            store
                .push(x, v, S::Real::from_f64(dx.powi(d as i32)), S::Real::ONE)
                .unwrap();
        }
        let (mut storage, n_fluid) = store.storage().unwrap();
        let width = 64 * d;
        let mut rows = vec![0u32; n * width];
        let mut counts = vec![0u32; n];
        storage.neighbours = &mut rows;
        storage.neighbour_counts = &mut counts;
        let eos = Eos::Linear {
            rho0: S::Real::ONE,
            c0: S::Real::from_f64(10.0),
            p0: S::Real::ZERO,
        };
        let params = Params::new(h, eos).with_skin(S::Real::from_f64(0.1));
        let mut solver = Solver::<S, K, M, _, _>::new(
            params,
            domain,
            storage,
            n_fluid,
            SummationDensity,
            forces,
        )
        .unwrap();
        solver.calibrate_mass(S::Real::ONE).unwrap();
        let dt = 0.5 * solver.limits().min();
        for _ in 0..steps {
            solver.step(dt).unwrap();
        }
        let mut pass = solver.pass();
        assert!(matches!(
            pass.neighbours,
            Neighbours::Lists {
                partitioned: true,
                ..
            }
        ));
        let mut rows_of = Vec::new();
        for i in 0..n {
            // Rows of every length mod BATCH, over the particles: the
            // last batch of a row is full, or short by 1 to BATCH - 1.
            let Neighbours::Lists { counts, .. } = pass.neighbours else {
                unreachable!()
            };
            rows_of.push((counts[i] >> 16) as usize % BATCH);
            let density = pass.accumulate::<SummationDensity, false>(&SummationDensity, i);
            let reference = one_at_a_time::<S, K, M, _, false>(&pass, &SummationDensity, i);
            same_bits(&density, &reference, "density", i);
            assert!(density.rho > S::Real::ZERO);
            let acc = pass.accumulate::<Forces<S>, false>(&forces, i);
            let reference = one_at_a_time::<S, K, M, _, false>(&pass, &forces, i);
            same_bits(&acc, &reference, "forces", i);
            let acc = pass.accumulate::<Forces<S>, true>(&forces, i);
            let reference = one_at_a_time::<S, K, M, _, true>(&pass, &forces, i);
            same_bits(&acc, &reference, "viscous", i);
        }
        rows_of.sort_unstable();
        rows_of.dedup();
        assert_eq!(
            rows_of.len(),
            BATCH,
            "row lengths mod BATCH seen: {rows_of:?}"
        );
        // The force pass over unsorted rows (continuity density): entries
        // inside the support gathered, then batched.
        if let Neighbours::Lists { partitioned, .. } = &mut pass.neighbours {
            *partitioned = false;
        }
        for i in 0..n {
            let acc = pass.accumulate::<Forces<S>, false>(&forces, i);
            let reference = one_at_a_time::<S, K, M, _, false>(&pass, &forces, i);
            same_bits(&acc, &reference, "unsorted forces", i);
        }
    }

    #[test]
    fn batched_pairs_give_the_bits_of_one_pair_at_a_time() {
        batched_passes_match::<D2<f64>, CubicSpline, HostSqrt, 576>(24, 1.3, 20);
        batched_passes_match::<D2<f64>, CubicSpline, Libm, 576>(24, 1.3, 20);
        batched_passes_match::<D2<f32>, WendlandC2, HostSqrt, 576>(24, 1.7, 20);
        batched_passes_match::<D3<f64>, CubicSpline, HostSqrt, 1000>(10, 1.2, 5);
    }
}
