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

use std::sync::Arc;

use sph_core::analytic::Couette;
use sph_core::prelude::Limits;

use crate::checkpoint::Checkpoint;
use crate::config::{CouetteConfig, KernelName, ViscosityForm};
use crate::error::{Error, Result};
use crate::scene::{
    AxisSpec, EosForm, Monitor, Physics, PressureForm, Region, Regularise, Scene, Stop,
    WallBoundary, WallPressure, WallSpec,
};

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
    /// The user asked to stop (checked between steps): the run ends early
    /// and publishes what it computed, marked incomplete.
    fn cancelled(&self) -> bool {
        false
    }
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
        let nx = strip_particles(cfg.kernel, h, dx, cfg.strip_supports);
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

/// Particles along a periodic strip strictly wider than `supports` support
/// radii with skin, `(1 + SKIN) kappa h`, for spacing `dx`: the neighbour
/// lists then meet at most one image of each particle.
pub fn strip_particles(kernel: KernelName, h: f64, dx: f64, supports: f64) -> usize {
    let radius = kernel.support() * h * (1.0 + SKIN);
    (supports * radius / dx).floor() as usize + 1
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
    /// Positions (absolute; unused components zero).
    pub x: Vec<[f64; 3]>,
    /// Velocities.
    pub v: Vec<[f64; 3]>,
    /// Densities.
    pub rho: Vec<f64>,
    /// Pressures.
    pub p: Vec<f64>,
    /// The exact velocity at each particle, where there is one.
    pub v_exact: Option<Vec<[f64; 3]>>,
    /// The velocity errors are written relative to this.
    pub error_scale: f64,
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
    /// Why the run ended before `t_end` (interrupted, diverged); `None`
    /// for a complete run.
    pub stop: Option<Stop>,
    /// The state to continue from, when the run was interrupted.
    pub checkpoint: Option<Box<Checkpoint>>,
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

    /// Whether any output time has `t* >= HEADLINE_T_STAR` (otherwise
    /// [`Self::headline`] has nothing to report and returns zeros).
    pub fn has_headline(&self) -> bool {
        self.errors().iter().any(|e| e.t_star >= HEADLINE_T_STAR)
    }

    /// Largest `(linf, l2)` over output times with `t* >= HEADLINE_T_STAR`.
    pub fn headline(&self) -> (f64, f64) {
        self.errors()
            .iter()
            .filter(|e| e.t_star >= HEADLINE_T_STAR)
            .fold((0.0f64, 0.0f64), |(a, b), e| (a.max(e.linf), b.max(e.l2)))
    }
}

/// The scene of a configuration: the plates as point-reflecting walls of a
/// periodic strip (see [`crate::scene`]).
pub fn scene(cfg: &CouetteConfig) -> Scene {
    let geo = Geometry::of(cfg);
    let exact = Couette {
        y_lower: geo.y_lower,
        y_upper: geo.y_upper,
        u: cfg.u_wall,
        nu: cfg.nu,
        tolerance: 1e-14,
    };
    let strip = geo.nx as f64 * geo.dx;
    Scene {
        case: CASE.into(),
        dim: 2,
        origin: [cfg.shift, geo.y_lower, 0.0],
        extent: [strip, cfg.gap, 0.0],
        axes: [
            AxisSpec::Periodic,
            AxisSpec::Walls(
                Some(WallSpec::at_rest().point_reflected()),
                Some(WallSpec::moving([cfg.u_wall, 0.0, 0.0]).point_reflected()),
            ),
            AxisSpec::Periodic,
        ],
        dx: geo.dx,
        shaped_walls: Vec::new(),
        initial: None,
        summary: Vec::new(),
        regions: vec![Region {
            lo: [cfg.shift, geo.y_lower, 0.0],
            hi: [cfg.shift + strip, geo.y_upper, 0.0],
        }],
        velocity: None,
        pressure: None,
        body_force: [0.0; 3],
        rho0: cfg.rho0,
        nu: cfg.nu,
        physics: Physics {
            kernel: cfg.kernel,
            beta: cfg.beta,
            eta2: cfg.eta2,
            density: cfg.density,
            viscosity: cfg.viscosity,
            precision: cfg.precision,
            math: cfg.math,
            regularise: Regularise::None,
            shift_coefficient: 0.0,
            density_diffusion: 0.0,
            alpha: geo.alpha,
            eos: EosForm::Linear,
            tension_cutoff: false,
            energy_budget: false,
            adaptive_dt: false,
            gravity_ramp: 0.0,
            sound_speed: geo.c0,
            background_pressure: cfg.background_pressure * cfg.rho0 * geo.c0 * geo.c0,
            dt_factor: cfg.dt_factor,
            // No body force: both rules give the same ghosts.
            wall_pressure: WallPressure::Mirror,
            wall_boundary: WallBoundary::Mirror,
            pressure_gradient: PressureForm::Symmetric,
        },
        output_times: cfg.schedule(),
        velocity_scale: cfg.u_wall,
        length_scale: cfg.gap,
        exact: Some(Arc::new(move |x, t| [exact.velocity(x[1], t), 0.0, 0.0])),
        error_decay: 0.0,
        // The Couette case predates the monitor: it reports, never stops on it.
        monitor: Monitor {
            min_spacing: 0.0,
            max_density_deviation: f64::INFINITY,
            max_mach: f64::INFINITY,
            every: u64::MAX,
        },
        steady_tolerance: None,
        threads: cfg.threads,
        keep_particles: true,
        allow_long_run: cfg.allow_long_run,
    }
}

/// The scene name of `sph couette` runs, recorded in their checkpoints
/// (`sph resume` tells them from `sph run` sets by it).
pub const CASE: &str = "couette-validation";

/// Runs the case (on the scene layer, [`crate::scene::run`]) to its end.
///
/// # Errors
/// [`Error::Config`] for an invalid configuration; [`Error::Core`] if the
/// core rejects the scene; [`Error::Diverged`] if the run diverges (naming
/// step and particle) or is interrupted.
pub fn run(cfg: &CouetteConfig, progress: &dyn Progress) -> Result<CouetteRun> {
    let run = run_with(cfg, progress, None)?;
    match &run.stop {
        Some(stop) => Err(Error::Diverged(stop.reason.clone())),
        None => Ok(run),
    }
}

/// Runs the case, from its start or from a checkpoint of an earlier
/// `sph couette` run with the same configuration, and returns what it
/// computed even when it stopped early ([`CouetteRun::stop`] says why; an
/// interrupted run carries its [`CouetteRun::checkpoint`]).
///
/// # Errors
/// [`Error::Config`] for an invalid configuration or a checkpoint of another
/// run; [`Error::Core`] if the core rejects the scene.
pub fn run_with(
    cfg: &CouetteConfig,
    progress: &dyn Progress,
    resume: Option<&Checkpoint>,
) -> Result<CouetteRun> {
    cfg.validate()?;
    let record = crate::scene::run_with(
        &scene(cfg),
        &mut crate::scene::RunControl {
            progress,
            resume,
            checkpoint_every: None,
            on_checkpoint: &mut |_, _| Ok(()),
            pause_after: None,
            refresh: false,
            ranks: None,
        },
    )?;
    let profiles = record
        .frames
        .iter()
        .map(|f| Profile {
            t: f.t,
            y: f.x.iter().map(|x| x[1]).collect(),
            vx: f.v.iter().map(|v| v[0]).collect(),
        })
        .collect();
    let snapshots = if cfg.vtk {
        let g = Geometry::of(cfg);
        // The series as profile.csv evaluates it.
        let exact = Couette {
            y_lower: g.y_lower,
            y_upper: g.y_upper,
            u: cfg.u_wall,
            nu: cfg.nu,
            tolerance: 1e-14,
        };
        record
            .frames
            .iter()
            .map(|f| Snapshot {
                t: f.t,
                x: f.x.clone(),
                v: f.v.clone(),
                rho: f.rho.clone(),
                p: f.p.clone(),
                v_exact: Some(
                    f.x.iter()
                        .map(|x| [exact.velocity(x[1], f.t), 0.0, 0.0])
                        .collect(),
                ),
                error_scale: cfg.u_wall,
            })
            .collect()
    } else {
        Vec::new()
    };
    Ok(CouetteRun {
        config: cfg.clone(),
        geometry: Geometry::of(cfg),
        limits: Limits {
            cfl: record.limits[0],
            viscous: record.limits[1],
            force: record.limits[2],
        },
        dt_max: record.dt,
        steps: record.steps,
        threads: record.threads,
        wall_seconds: record.wall_seconds,
        storage_bytes: record.storage_bytes,
        profiles,
        snapshots,
        stop: record.stop,
        checkpoint: record.checkpoint,
    })
}
