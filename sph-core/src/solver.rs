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
//! 2. evaluate at the new positions: ghosts, cell list, density pass,
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
//! Passes 1-3 run through an [`Executor`]; each writes only the range it is
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
use crate::exec::{Executor, Max2, Serial};
use crate::kernel::{Kernel, SmoothingKernel};
use crate::math::Math;
use crate::neighbour::{CellList, CellView, Grid};
use crate::real::Real;
use crate::space::{Space, VectorOps};
use crate::terms::{Acc, Consts, Dest, Fields, Pair, SummationDensity, Term};

/// Caller-provided per-particle slices (structure of arrays).
///
/// All slices but the three cell-list buffers have the same length, the
/// capacity: indices `0..n_fluid` hold fluid particles, the rest is reserved
/// for ghosts. The caller fills `x`, `v`, `m` (and `rho` for continuity
/// density) of the fluid; the rest is scratch. `cell_start` needs
/// [`Solver::cells_needed`] entries.
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
}

/// Bytes of [`Storage`] per particle slot for space `S` (cell starts excluded).
pub const fn bytes_per_particle<S: Space>() -> usize {
    let v = core::mem::size_of::<S::Vector>();
    let f = core::mem::size_of::<S::Real>();
    4 * v + 5 * f + core::mem::size_of::<Ghost>() + 2 * core::mem::size_of::<u32>()
}

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
}

impl<F: Real> Params<F> {
    /// Parameters with smoothing length `h`, equation of state `eos`, and
    /// the defaults `eta2 = 0.01`, speed limit = sound speed, 60 power iterations.
    pub fn new(h: F, eos: Eos<F>) -> Self {
        Self {
            h,
            eta2: F::from_f64(0.01),
            eos,
            max_speed: F::ZERO,
            viscous_iterations: 60,
        }
    }

    /// Sets the regulariser (fraction of `h^2`).
    pub fn with_eta2(mut self, eta2: F) -> Self {
        self.eta2 = eta2;
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

/// The fluid slices the last kick writes: `v`, `rho`, `p`.
type KickParts<'s, S> = (
    &'s mut [<S as Space>::Vector],
    &'s mut [<S as Space>::Real],
    &'s mut [<S as Space>::Real],
);

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
}

/// What one pass reads, shared by every range.
struct Pass<'s, S: Space, K: Kernel, M: Math<S::Real>> {
    kernel: &'s SmoothingKernel<S, K, M>,
    grid: &'s Grid<S>,
    cells: CellView<'s>,
    consts: &'s Consts<S>,
    fields: Fields<'s, S>,
}

impl<S: Space, K: Kernel, M: Math<S::Real>> Pass<'_, S, K, M> {
    /// Accumulates the terms `T` for destination `i` (only their viscous
    /// parts when `VISCOUS_ONLY`).
    #[inline(always)]
    fn accumulate<T: Term<S>, const VISCOUS_ONLY: bool>(&self, terms: &T, i: usize) -> Acc<S> {
        let f = &self.fields;
        let d = Dest {
            i,
            v: f.v[i],
            m: f.m[i],
            rho: f.rho[i],
            p: f.p[i],
        };
        let mut acc = Acc {
            rho: S::Real::ZERO,
            drho: S::Real::ZERO,
            dv: S::Vector::zero(),
        };
        if !VISCOUS_ONLY {
            terms.init(self.consts, &d, &mut acc);
        }
        self.cells
            .for_each_neighbour(self.grid, f.x, i, |j, r_ij, r2| {
                let (w, fk) = if T::NEEDS_W && T::NEEDS_F {
                    self.kernel.w_and_f(r2)
                } else if T::NEEDS_W {
                    (self.kernel.w(r2), S::Real::ZERO)
                } else if T::NEEDS_F {
                    (S::Real::ZERO, self.kernel.f(r2))
                } else {
                    (S::Real::ZERO, S::Real::ZERO)
                };
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
                    terms.viscous(self.consts, &d, f, &pair, &mut acc);
                } else {
                    terms.pair(self.consts, &d, f, &pair, &mut acc);
                }
            });
        acc
    }
}

/// The time stepper (see the module docs).
///
/// Type parameters: `S` space, `K` kernel, `M` math backend, `D` density
/// group (`SummationDensity` or `()`), `T` force group.
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
    /// Entries the `cell_start` buffer needs for this domain and smoothing length.
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
        params.validate()?;
        let kernel = SmoothingKernel::<S, K, M>::new(params.h)?;
        let grid = Grid::new(&domain, kernel.radius())?;
        for a in 0..S::DIM {
            let walled =
                domain.wall(a, Side::Lower).is_some() || domain.wall(a, Side::Upper).is_some();
            if walled && domain.extent()[a] < kernel.radius() {
                return Err(Error::InvalidParameter {
                    name: "extent",
                    value: domain.extent()[a].to_f64(),
                    rule: "along an axis with walls the extent must be at least the kernel support radius",
                });
            }
        }
        let cap = storage.x.len();
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
            let x = domain.wrap::<M>(storage.x[i]);
            if let Some((axis, c)) = domain.outside(x) {
                return Err(Error::OutsideDomain {
                    particle: i,
                    axis,
                    coordinate: c.to_f64(),
                });
            }
            storage.x[i] = x;
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
        } = storage;
        let mut solver = Self {
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
            failed: None,
        };
        solver.prepare(exec)?;
        Ok(solver)
    }

    /// Evaluates the rates at the current state with `ve = v`, then estimates
    /// the viscous decay rate.
    fn prepare<E: Executor>(&mut self, exec: &E) -> Result<()> {
        let n = self.n;
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
        self.sync_ghost_kinematics(false);
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

    fn sync_ghost_kinematics(&mut self, homogeneous: bool) {
        let n = self.n;
        let (fluid_v, ghost_v) = self.a.ve.split_at_mut(n);
        let (fluid_m, ghost_m) = self.a.m.split_at_mut(n);
        for (k, g) in self.a.ghosts[..self.n_ghost].iter().enumerate() {
            let s = g.source as usize;
            ghost_v[k] =
                boundary::mirror_velocity(&self.domain, fluid_v[s], g.mirrors, homogeneous);
            ghost_m[k] = fluid_m[s];
        }
    }

    fn sync_ghost_thermo(&mut self) {
        let n = self.n;
        let (fluid_rho, ghost_rho) = self.a.rho.split_at_mut(n);
        let (fluid_p, ghost_p) = self.a.p.split_at_mut(n);
        for (k, g) in self.a.ghosts[..self.n_ghost].iter().enumerate() {
            let s = g.source as usize;
            ghost_rho[k] = fluid_rho[s];
            ghost_p[k] = fluid_p[s];
        }
    }

    /// Runs a density group into `rho_aux[..n]`.
    fn run_density<E: Executor, G: Term<S>>(&mut self, exec: &E, group: &G) -> Result<()> {
        let n = self.n;
        let total = n + self.n_ghost;
        let Arrays {
            x,
            ve,
            m,
            rho,
            p,
            rho_aux,
            ..
        } = &mut self.a;
        let pass = Pass {
            kernel: &self.kernel,
            grid: &self.grid,
            cells: self.cells.view(),
            consts: &self.consts,
            fields: Fields {
                x: &x[..total],
                v: &ve[..total],
                m: &m[..total],
                rho: &rho[..total],
                p: &p[..total],
            },
        };
        exec.run(&mut rho_aux[..n], &|start, out: &mut [S::Real]| {
            for (k, o) in out.iter_mut().enumerate() {
                *o = pass.accumulate::<G, false>(group, start + k).rho;
            }
            Ok(())
        })
    }

    /// Ghosts, cell list, density, equation of state and forces at the
    /// current positions and pass velocities `ve`.
    fn evaluate<E: Executor>(&mut self, exec: &E) -> Result<()> {
        let n = self.n;
        self.n_ghost = boundary::generate(
            &self.domain,
            self.kernel.radius(),
            self.a.x,
            n,
            self.a.ghosts,
        )?;
        let total = n + self.n_ghost;
        self.cells.build(&self.grid, &self.a.x[..total])?;
        self.sync_ghost_kinematics(false);
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
            exec.run((&mut rho[..n], &mut p[..n]), &|start,
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
        self.sync_ghost_thermo();
        self.run_forces::<E, false>(exec)
    }

    /// The force pass (or its viscous part) into `dv[..n]`, `drho[..n]`.
    fn run_forces<E: Executor, const VISCOUS_ONLY: bool>(&mut self, exec: &E) -> Result<()> {
        let n = self.n;
        let total = n + self.n_ghost;
        let Arrays {
            x,
            ve,
            m,
            rho,
            p,
            dv,
            drho,
            ..
        } = &mut self.a;
        let pass = Pass {
            kernel: &self.kernel,
            grid: &self.grid,
            cells: self.cells.view(),
            consts: &self.consts,
            fields: Fields {
                x: &x[..total],
                v: &ve[..total],
                m: &m[..total],
                rho: &rho[..total],
                p: &p[..total],
            },
        };
        let forces = &self.forces;
        exec.run((&mut dv[..n], &mut drho[..n]), &|start,
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
        let mut scale = S::Real::from_f64(1.0 / libm::sqrt(norm2));
        let mut rate = 0.0;
        for _ in 0..self.params.viscous_iterations {
            for i in 0..n {
                self.a.ve[i] *= scale;
            }
            self.sync_ghost_kinematics(true);
            self.run_forces::<E, true>(exec)?;
            let norm = libm::sqrt(
                self.a.dv[..n]
                    .iter()
                    .map(|a| a.norm2().to_f64())
                    .sum::<f64>(),
            );
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
    /// domain; [`Error::CapacityExceeded`] if the ghosts outgrow the reserved
    /// capacity. After an error the state is unspecified and every later call
    /// returns the same error.
    pub fn step_with<E: Executor>(&mut self, exec: &E, dt: f64) -> Result<()> {
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
        let result = self.advance(exec, dt);
        if let Err(e) = result {
            self.failed = Some(e);
        }
        result
    }

    fn advance<E: Executor>(&mut self, exec: &E, dt: f64) -> Result<()> {
        let n = self.n;
        let step = self.step + 1;
        let dtf = S::Real::from_f64(dt);
        let half = S::Real::from_f64(0.5 * dt);
        let summation = !D::EMPTY;
        let domain = self.domain;
        {
            let Arrays {
                x,
                v,
                ve,
                rho,
                rho_aux,
                dv,
                drho,
                ..
            } = &mut self.a;
            let (dv, drho) = (&dv[..n], &drho[..n]);
            exec.run(
                (
                    &mut x[..n],
                    &mut v[..n],
                    &mut ve[..n],
                    &mut rho[..n],
                    &mut rho_aux[..n],
                ),
                &|start, (x, v, ve, rho, rho_aux): DriftParts<'_, S>| {
                    for k in 0..x.len() {
                        let i = start + k;
                        let a = dv[i];
                        let vh = v[k] + a * half;
                        v[k] = vh;
                        ve[k] = vh + a * half;
                        let xn = x[k] + vh * dtf;
                        if !xn.is_finite() {
                            return Err(unstable(step, i, Fault::NonFinite { field: "position" }));
                        }
                        let xn = domain.wrap::<M>(xn);
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
                        x[k] = xn;
                        if !summation {
                            let rh = rho[k] + drho[i] * half;
                            rho_aux[k] = rh;
                            rho[k] = rh + drho[i] * half;
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
                    Ok(())
                },
            )?;
        }
        self.evaluate(exec)?;
        let eos = self.params.eos;
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
            exec.run(
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
                                    speed: libm::sqrt(speed2.to_f64()),
                                    limit: libm::sqrt(limit2.to_f64()),
                                },
                            ));
                        }
                        if !summation {
                            rho[k] = rho_aux[i] + drho[i] * half;
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
        let h = self.params.h.to_f64();
        let c = self.consts.c0.to_f64() + libm::sqrt(self.vmax2.to_f64());
        let amax = libm::sqrt(self.amax2.to_f64());
        Limits {
            cfl: if c > 0.0 { 0.25 * h / c } else { f64::INFINITY },
            viscous: if self.viscous_rate > 0.0 {
                1.0 / self.viscous_rate
            } else {
                f64::INFINITY
            },
            force: if amax > 0.0 {
                0.25 * libm::sqrt(h / amax)
            } else {
                f64::INFINITY
            },
        }
    }

    /// The viscous operator's largest decay rate `lambda_max` (1/s) estimated at set-up.
    pub fn viscous_rate(&self) -> f64 {
        self.viscous_rate
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
            let acc = pass.accumulate::<T, false>(&self.forces, start + k);
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
            cells: self.cells.view(),
            consts: &self.consts,
            fields: Fields {
                x: &self.a.x[..total],
                v: &self.a.ve[..total],
                m: &self.a.m[..total],
                rho: &self.a.rho[..total],
                p: &self.a.p[..total],
            },
        }
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

    /// Fluid positions, relative to the domain's lower corner.
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

    /// The kernel bound to `h`.
    pub fn kernel(&self) -> &SmoothingKernel<S, K, M> {
        &self.kernel
    }

    /// The parameters.
    pub fn params(&self) -> &Params<S::Real> {
        &self.params
    }
}
