//! The planar Couette validation case (the poster's central result).
//!
//! Plates at `y = -L` (at rest) and `y = +L` (moving at `U` along x from
//! `t = 0`), fluid at rest, periodic in x over a strip a few kernel supports
//! wide. Walls are mirrored ghosts, no-slip relative to each plate (the moving
//! plate's ghosts carry `2U - u`). Steps land exactly on the output times,
//! where fluid velocity profiles are sampled and compared with the exact
//! series ([`sph_core::analytic::Couette`]).
//!
//! Defaults (see [`CouetteConfig`]) and why: cubic spline at `beta = 1.3`,
//! summation density, linear EOS with `c0 = 10 U`, `eta^2 = 0.01 h^2`, Morris
//! viscosity, 40 particles across. physics.md section 9 measured that this
//! kernel and overlap have the lowest transient-error floor of the common
//! choices (about 2.5e-5 U, where the regulariser cancels the lattice error),
//! and that at 40 particles across the transient error at t* >= 0.02 is
//! resolution-limited at a few 1e-3 U, inside the 0.5 % target with margin;
//! 20 across would not be. Summation density keeps walls impermeable and
//! does not drift; continuity is the poster's choice and a setting.

use std::time::Instant;

use sph_core::analytic::Couette;
use sph_core::exec::{Executor, Serial};
use sph_core::kernel::{CubicSpline, Gaussian, Kernel, QuinticSpline, WendlandC2, WendlandC4};
use sph_core::math::{Libm, Math, Micromath};
use sph_core::prelude::{
    AnyViscosity, ArtificialViscosity, Continuity, Domain, Eos, Limits, MorrisViscosity, Params,
    PiViscosity, PressureGradient, Side, Solver, SummationDensity, Term, Vector, Wall, D2,
};
use sph_core::real::Real;

use crate::config::{
    CouetteConfig, DensityMode, KernelName, MathBackend, Precision, ViscosityForm,
};
use crate::driver::{Buffers, Rayon};
use crate::error::{Error, Result};

/// Verlet skin of the neighbour lists (fraction of the support radius).
pub const SKIN: f64 = 0.1;

/// Reports progress of a long run (implemented by a progress bar in the CLI).
pub trait Progress: Sync {
    /// The run will take `total` steps.
    fn start(&self, total: u64);
    /// `steps` more steps are done.
    fn advance(&self, steps: u64);
    /// The run is over.
    fn finish(&self);
}

/// Reports nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Progress for Silent {
    fn start(&self, _total: u64) {}
    fn advance(&self, _steps: u64) {}
    fn finish(&self) {}
}

/// Derived sizes of the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Geometry {
    /// Lower plate position `-L`.
    pub y_lower: f64,
    /// Upper plate position `+L`.
    pub y_upper: f64,
    /// Particle spacing.
    pub dx: f64,
    /// Smoothing length.
    pub h: f64,
    /// Particles along the periodic strip.
    pub nx: usize,
    /// Fluid particles.
    pub n_fluid: usize,
    /// Sound speed.
    pub c0: f64,
    /// Artificial-viscosity coefficient in use (0 unless `viscosity = artificial`).
    pub alpha: f64,
}

impl Geometry {
    /// Sizes for a configuration.
    pub fn of(cfg: &CouetteConfig) -> Self {
        let n = cfg.particles_across;
        let dx = cfg.gap / n as f64;
        let h = cfg.beta * dx;
        // The neighbour lists reach (1 + skin) R; the strip is strictly wider
        // than `strip_supports` such radii, so the periodic-image rule holds.
        let radius = cfg.kernel.support() * h * (1.0 + SKIN);
        let nx = (cfg.strip_supports * radius / dx).floor() as usize + 1;
        let c0 = cfg.sound_speed_factor * cfg.u_wall;
        let alpha = match cfg.viscosity {
            ViscosityForm::Artificial if cfg.alpha > 0.0 => cfg.alpha,
            // nu = alpha h c0 / (2 (d + 2)) in 2D (physics.md 1.4).
            ViscosityForm::Artificial => 8.0 * cfg.nu / (h * c0),
            _ => 0.0,
        };
        Self {
            y_lower: cfg.shift - 0.5 * cfg.gap,
            y_upper: cfg.shift + 0.5 * cfg.gap,
            dx,
            h,
            nx,
            n_fluid: nx * n,
            c0,
            alpha,
        }
    }
}

/// Fluid velocities at one output time.
#[derive(Clone, Debug, PartialEq)]
pub struct Profile {
    /// Time in seconds.
    pub t: f64,
    /// Heights (same frame as the plates).
    pub y: Vec<f64>,
    /// Velocity along x.
    pub vx: Vec<f64>,
}

/// Particle state at one output time, for VTK.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    /// Time in seconds.
    pub t: f64,
    /// Positions (absolute).
    pub x: Vec<[f64; 2]>,
    /// Velocities.
    pub v: Vec<[f64; 2]>,
    /// Densities.
    pub rho: Vec<f64>,
    /// Pressures.
    pub p: Vec<f64>,
}

/// Errors against the exact series at one output time, relative to `U`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorRow {
    /// Time in seconds.
    pub t: f64,
    /// Non-dimensional time `nu t / (2L)^2`.
    pub t_star: f64,
    /// `max |u - u_exact| / U` over fluid particles.
    pub linf: f64,
    /// `sqrt(mean (u - u_exact)^2) / U`.
    pub l2: f64,
    /// `mean (u - u_exact) / U`: a signed measure that exists at every resolution.
    pub mean_signed: f64,
}

/// Everything a run produced.
#[derive(Clone, Debug)]
pub struct CouetteRun {
    /// The configuration that ran.
    pub config: CouetteConfig,
    /// Derived sizes.
    pub geometry: Geometry,
    /// Stability limits at the start.
    pub limits: Limits,
    /// The largest step used (`dt_factor * limits.min()`).
    pub dt_max: f64,
    /// Steps taken.
    pub steps: u64,
    /// Threads used.
    pub threads: usize,
    /// Wall-clock seconds of the whole run (set-up and stepping).
    pub wall_seconds: f64,
    /// Bytes of particle storage.
    pub storage_bytes: usize,
    /// Profiles at the output times.
    pub profiles: Vec<Profile>,
    /// Snapshots at the output times (only with `vtk`).
    pub snapshots: Vec<Snapshot>,
}

/// Only output times with `nu t / (2L)^2` at or above this enter the headline errors
/// (earlier profiles are dominated by the impulsive start, resolved by no lattice).
pub const HEADLINE_T_STAR: f64 = 0.02;

impl CouetteRun {
    /// The exact solution for this run.
    pub fn exact(&self) -> Couette {
        Couette {
            y_lower: self.geometry.y_lower,
            y_upper: self.geometry.y_upper,
            u: self.config.u_wall,
            nu: self.config.nu,
            tolerance: 1e-14,
        }
    }

    /// Errors at every output time.
    pub fn errors(&self) -> Vec<ErrorRow> {
        let exact = self.exact();
        let u = self.config.u_wall;
        self.profiles
            .iter()
            .map(|p| {
                let n = p.y.len().max(1) as f64;
                let (mut linf, mut sq, mut sum) = (0.0f64, 0.0, 0.0);
                for (y, vx) in p.y.iter().zip(&p.vx) {
                    let e = (vx - exact.velocity(*y, p.t)) / u;
                    linf = linf.max(e.abs());
                    sq += e * e;
                    sum += e;
                }
                ErrorRow {
                    t: p.t,
                    t_star: p.t / exact.diffusion_time(),
                    linf,
                    l2: (sq / n).sqrt(),
                    mean_signed: sum / n,
                }
            })
            .collect()
    }

    /// Largest `(linf, l2)` over output times with `t* >= HEADLINE_T_STAR`.
    pub fn headline(&self) -> (f64, f64) {
        self.errors()
            .iter()
            .filter(|e| e.t_star >= HEADLINE_T_STAR)
            .fold((0.0f64, 0.0f64), |(a, b), e| (a.max(e.linf), b.max(e.l2)))
    }
}

/// Runs the case.
///
/// # Errors
/// [`Error::Config`] for an invalid configuration; [`Error::Core`] if the
/// core rejects the scene or the run diverges (naming step and particle).
pub fn run(cfg: &CouetteConfig, progress: &dyn Progress) -> Result<CouetteRun> {
    cfg.validate()?;
    let threads = cfg.resolved_threads();
    let start = Instant::now();
    let mut out = if threads == 1 {
        dispatch(cfg, &Serial, progress)?
    } else {
        let pool = crate::driver::thread_pool(threads)?;
        // About four pieces per thread, but no piece under 64 particles.
        let min_chunk = (Geometry::of(cfg).n_fluid / (4 * threads)).max(64);
        pool.install(|| dispatch(cfg, &Rayon { min_chunk }, progress))?
    };
    out.threads = threads;
    out.wall_seconds = start.elapsed().as_secs_f64();
    progress.finish();
    Ok(out)
}

fn dispatch<E: Executor>(
    cfg: &CouetteConfig,
    exec: &E,
    progress: &dyn Progress,
) -> Result<CouetteRun> {
    match (cfg.precision, cfg.math) {
        (Precision::F64, MathBackend::Libm) => by_kernel::<f64, Libm, E>(cfg, exec, progress),
        (Precision::F32, MathBackend::Libm) => by_kernel::<f32, Libm, E>(cfg, exec, progress),
        (Precision::F32, MathBackend::Micromath) => {
            by_kernel::<f32, Micromath, E>(cfg, exec, progress)
        }
        (Precision::F64, MathBackend::Micromath) => Err(Error::config(
            "math",
            cfg.math,
            "micromath implements f32 only: use precision = \"f32\"",
        )),
    }
}

fn by_kernel<F: Real, M: Math<F>, E: Executor>(
    cfg: &CouetteConfig,
    exec: &E,
    progress: &dyn Progress,
) -> Result<CouetteRun> {
    match cfg.kernel {
        KernelName::Cubic => by_density::<F, M, CubicSpline, E>(cfg, exec, progress),
        KernelName::Quintic => by_density::<F, M, QuinticSpline, E>(cfg, exec, progress),
        KernelName::WendlandC2 => by_density::<F, M, WendlandC2, E>(cfg, exec, progress),
        KernelName::WendlandC4 => by_density::<F, M, WendlandC4, E>(cfg, exec, progress),
        KernelName::Gaussian => by_density::<F, M, Gaussian, E>(cfg, exec, progress),
    }
}

fn by_density<F: Real, M: Math<F>, K: Kernel, E: Executor>(
    cfg: &CouetteConfig,
    exec: &E,
    progress: &dyn Progress,
) -> Result<CouetteRun> {
    let geo = Geometry::of(cfg);
    let mu = F::from_f64(cfg.nu * cfg.rho0);
    let visc = match cfg.viscosity {
        ViscosityForm::Morris => AnyViscosity::Morris(MorrisViscosity { mu }),
        ViscosityForm::Pi => AnyViscosity::Pi(PiViscosity { mu }),
        ViscosityForm::Artificial => AnyViscosity::Artificial(ArtificialViscosity {
            alpha: F::from_f64(geo.alpha),
            beta: F::ZERO,
        }),
    };
    match cfg.density {
        DensityMode::Summation => simulate::<F, M, K, E, _, _>(
            cfg,
            &geo,
            exec,
            progress,
            SummationDensity,
            (PressureGradient, visc),
        ),
        DensityMode::Continuity => simulate::<F, M, K, E, _, _>(
            cfg,
            &geo,
            exec,
            progress,
            (),
            (Continuity, PressureGradient, visc),
        ),
    }
}

fn simulate<F, M, K, E, D, T>(
    cfg: &CouetteConfig,
    geo: &Geometry,
    exec: &E,
    progress: &dyn Progress,
    density: D,
    forces: T,
) -> Result<CouetteRun>
where
    F: Real,
    M: Math<F>,
    K: Kernel,
    E: Executor,
    D: Term<D2<F>>,
    T: Term<D2<F>>,
{
    let n = cfg.particles_across;
    let (dx, nx) = (geo.dx, geo.nx);
    let f = F::from_f64;
    let domain = Domain::<D2<F>>::new(
        Vector::new([cfg.shift, geo.y_lower]),
        Vector::new([f(nx as f64 * dx), f(cfg.gap)]),
    )?
    .with_periodic(0)?
    .with_wall(1, Side::Lower, Wall::no_slip())?
    .with_wall(
        1,
        Side::Upper,
        Wall::moving(Vector::new([f(cfg.u_wall), F::ZERO])),
    )?;
    let h = f(geo.h);
    let radius_rows = (K::SUPPORT * cfg.beta * (1.0 + SKIN)).ceil() as usize + 1;
    let capacity = geo.n_fluid + 2 * nx * radius_rows;
    let cells = Solver::<D2<F>, K, M, D, T>::cells_needed(&domain, h)?;
    let width = crate::driver::list_width(2, K::SUPPORT, cfg.beta, SKIN);
    let mut buffers = Buffers::<D2<F>>::new(capacity, cells).with_lists(width);
    for j in 0..n {
        for i in 0..nx {
            let k = j * nx + i;
            buffers.x[k] = Vector::new([f((i as f64 + 0.5) * dx), f((j as f64 + 0.5) * dx)]);
            buffers.m[k] = F::ONE;
            buffers.rho[k] = f(cfg.rho0);
        }
    }
    let storage_bytes = buffers.bytes();
    let p0 = cfg.background_pressure * cfg.rho0 * geo.c0 * geo.c0;
    let eos = Eos::Linear {
        rho0: f(cfg.rho0),
        c0: f(geo.c0),
        p0: f(p0),
    };
    let params = Params::new(h, eos)
        .with_eta2(f(cfg.eta2))
        .with_skin(f(SKIN));
    let mut solver = Solver::<D2<F>, K, M, D, T>::new_with(
        exec,
        params,
        domain,
        buffers.storage(),
        geo.n_fluid,
        density,
        forces,
    )?;
    solver.calibrate_mass_with(exec, f(cfg.rho0))?;
    let limits = solver.limits();
    let dt_max = cfg.dt_factor * limits.min();
    let schedule = cfg.schedule();
    let mut plan = Vec::with_capacity(schedule.len());
    let mut last = 0.0;
    for &t in &schedule {
        let steps = ((t - last) / dt_max).ceil().max(1.0) as u64;
        plan.push((t, steps, (t - last) / steps as f64));
        last = t;
    }
    progress.start(plan.iter().map(|p| p.1).sum());
    let mut profiles = Vec::with_capacity(plan.len());
    let mut snapshots = Vec::new();
    for (t, steps, dt) in plan {
        for k in 0..steps {
            solver.step_with(exec, dt)?;
            if k % 64 == 63 {
                progress.advance(64);
            }
        }
        progress.advance(steps % 64);
        let global: Vec<[f64; 2]> = solver
            .positions()
            .iter()
            .map(|x| {
                let g = solver.domain().to_global(*x);
                [g[0], g[1]]
            })
            .collect();
        let v: Vec<[f64; 2]> = solver
            .velocities()
            .iter()
            .map(|v| [v[0].to_f64(), v[1].to_f64()])
            .collect();
        profiles.push(Profile {
            t,
            y: global.iter().map(|g| g[1]).collect(),
            vx: v.iter().map(|v| v[0]).collect(),
        });
        if cfg.vtk {
            snapshots.push(Snapshot {
                t,
                x: global,
                v,
                rho: solver.densities().iter().map(|r| r.to_f64()).collect(),
                p: solver.pressures().iter().map(|p| p.to_f64()).collect(),
            });
        }
    }
    Ok(CouetteRun {
        config: cfg.clone(),
        geometry: *geo,
        limits,
        dt_max,
        steps: solver.steps(),
        threads: 1,
        wall_seconds: 0.0,
        storage_bytes,
        profiles,
        snapshots,
    })
}
