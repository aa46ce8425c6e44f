//! The scene layer: a scene is data, and one generic engine runs every scene.
//!
//! A [`Scene`] states the box (periodic axes and planar walls, each wall with
//! its velocity, slip rule and ghost placement), the fluid regions filled on
//! a lattice, the initial velocity and pressure fields, the body force, the
//! equation of state, the physics choices ([`Physics`]), the output times,
//! the velocity and length scales, an exact solution when there is one, and
//! the state monitor's bounds ([`Monitor`]). [`run`] turns the run-time
//! choices (dimension, precision and math backend, kernel, density mode,
//! regularisation) into one monomorphised solver type, steps it to each
//! output time, and returns a [`RunRecord`] that every output and plot reads.
//!
//! Adding a case is one file in `cases/` plus one line in its table; the
//! dispatch here never changes.

use std::cell::Cell;
use std::sync::Arc;

use serde::Serialize;
use sph_core::exec::{Executor, Serial};
use sph_core::kernel::{CubicSpline, Kernel, QuinticSpline, SmoothingKernel};
#[cfg(feature = "full")]
use sph_core::kernel::{Gaussian, WendlandC2, WendlandC4};
use sph_core::math::Math;
#[cfg(feature = "full")]
use sph_core::math::Micromath;
#[cfg(feature = "full")]
use sph_core::prelude::D3;
use sph_core::prelude::{
    AnyContinuity, AnyPressure, AnyViscosity, ArtificialViscosity, BodyForce,
    CorrectedMorrisViscosity, DensityDiffusion, Domain, Eos, MorrisViscosity, Params, PiViscosity,
    PressureGradient, Reflection, ShapedWall, Shifting, Side, Solver, SummationDensity, Term, Wall,
    D2,
};
use sph_core::real::Real;
use sph_core::space::{Space, VectorOps};

use crate::checkpoint::Checkpoint;
use crate::config::{DensityMode, KernelName, MathBackend, Precision, ViscosityForm};
pub use crate::config::{EosForm, PressureForm, WallBoundary, WallPressure};
use crate::couette::{Progress, SKIN};
use crate::distributed::{self, Comm, Particles, Setup, StepDone, Stepping};
use crate::driver::Buffers;
#[cfg(feature = "full")]
use crate::driver::Rayon;
use crate::error::{Error, Result};
use crate::exact::ExactSum;
use crate::math::Host;
use sph_core::solver::Limits;

/// A velocity field `v(x, t)` in global coordinates (unused components zero).
pub type VectorField = Arc<dyn Fn([f64; 3], f64) -> [f64; 3] + Send + Sync>;
/// A scalar field `p(x)` in global coordinates.
pub type ScalarField = Arc<dyn Fn([f64; 3]) -> f64 + Send + Sync>;

/// One planar wall of the box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallSpec {
    /// Wall velocity (tangential only).
    pub velocity: [f64; 3],
    /// Free slip instead of no-slip.
    pub free_slip: bool,
    /// Ghost placement ([`Reflection::Point`] needs periodic tangential axes).
    pub reflection: Reflection,
    /// Continue the tangential velocity through the wall with the curvature
    /// the momentum equation gives at a no-slip wall without a tangential
    /// pressure gradient, `-g_t / nu` (channels driven by a body force; see
    /// `sph_core::domain::Wall::curvature`).
    pub body_force_curvature: bool,
}

impl WallSpec {
    /// A no-slip wall at rest with mirrored ghosts.
    pub fn at_rest() -> Self {
        Self::moving([0.0; 3])
    }

    /// A no-slip wall sliding with `velocity`, mirrored ghosts.
    pub fn moving(velocity: [f64; 3]) -> Self {
        Self {
            velocity,
            free_slip: false,
            reflection: Reflection::Mirror,
            body_force_curvature: false,
        }
    }

    /// The same wall with the body-force curvature (see the field).
    pub fn with_body_force_curvature(mut self) -> Self {
        self.body_force_curvature = true;
        self
    }

    /// The same wall with point-reflected ghosts.
    pub fn point_reflected(mut self) -> Self {
        self.reflection = Reflection::Point;
        self
    }
}

/// What bounds one axis of the box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AxisSpec {
    /// Periodic.
    Periodic,
    /// Walls on the lower and upper side (`None`: open, a particle that
    /// crosses it is an error).
    Walls(Option<WallSpec>, Option<WallSpec>),
}

/// A box of fluid, filled on the scene's lattice (cell centres of spacing
/// `dx` counted from the box origin).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Region {
    /// Lower corner (global).
    pub lo: [f64; 3],
    /// Upper corner (global).
    pub hi: [f64; 3],
}

/// Regularisation of the particle arrangement.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, serde::Deserialize)]
pub enum Regularise {
    /// None: particles move with the fluid velocity.
    #[serde(rename = "none")]
    None,
    /// Particle shifting (`sph_core::terms::Shifting`).
    #[serde(rename = "shifting")]
    Shifting,
}

impl Regularise {
    /// Every value.
    pub const ALL: &'static [Regularise] = &[Regularise::None, Regularise::Shifting];

    /// The name in configs and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Regularise::None => "none",
            Regularise::Shifting => "shifting",
        }
    }
}

impl std::fmt::Display for Regularise {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Regularise {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        Self::ALL
            .iter()
            .copied()
            .find(|v| v.name() == s)
            .ok_or_else(|| "expected one of none, shifting".to_string())
    }
}

/// Numerical choices of a scene.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Physics {
    /// Smoothing kernel.
    pub kernel: KernelName,
    /// `h / dx`.
    pub beta: f64,
    /// Viscous regulariser as a fraction of `h^2`.
    pub eta2: f64,
    /// Density mode.
    pub density: DensityMode,
    /// Viscous form.
    pub viscosity: ViscosityForm,
    /// Floating-point precision.
    pub precision: Precision,
    /// Math backend.
    pub math: MathBackend,
    /// Regularisation.
    pub regularise: Regularise,
    /// Shifting coefficient `C` (see `sph_core::terms::Shifting`).
    pub shift_coefficient: f64,
    /// Density diffusion `delta` (continuity and corrected density; 0: off).
    pub density_diffusion: f64,
    /// Artificial-viscosity coefficient: with `viscosity = artificial` the
    /// coefficient of that form (0: matched to `nu`); with `morris`, an
    /// artificial viscosity added to the laminar term (0: none).
    pub alpha: f64,
    /// The equation of state.
    pub eos: EosForm,
    /// No tension: continuity density bounded below by `rho0`, so the
    /// pressure by the background pressure (`sph_core::solver::Params::density_floor`).
    pub tension_cutoff: bool,
    /// Whether the run integrates an energy budget ([`Energy`]).
    pub energy_budget: bool,
    /// Whether the time step follows the state (`dt_factor` times the
    /// smallest of the current limits) instead of staying fixed.
    pub adaptive_dt: bool,
    /// Time over which the body force rises from zero,
    /// `g(t) = g (1 - cos(pi t / T)) / 2` for `t < T` (0: on from the start).
    pub gravity_ramp: f64,
    /// Reference sound speed `c0` in m/s.
    pub sound_speed: f64,
    /// Background pressure in Pa.
    pub background_pressure: f64,
    /// Time step as a fraction of the smallest stability limit.
    pub dt_factor: f64,
    /// What the wall ghosts' pressure balances.
    pub wall_pressure: WallPressure,
    /// Mirrored ghosts or fixed wall particles at the box's planar walls.
    pub wall_boundary: WallBoundary,
    /// The pressure-gradient form (continuity density only).
    pub pressure_gradient: PressureForm,
}

/// Bounds of the state monitor: a run whose state crosses one stops.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Monitor {
    /// Smallest allowed distance between two fluid particles, in `dx`.
    pub min_spacing: f64,
    /// Largest allowed `|rho / rho0 - 1|`.
    pub max_density_deviation: f64,
    /// Largest allowed `|v| / c0`.
    pub max_mach: f64,
    /// Check every this many steps (and at every output time).
    pub every: u64,
}

impl Default for Monitor {
    /// Defaults chosen from the collapse they must catch (see the module
    /// docs of `cases`): closest pair 0.5 dx, density 5 %, Mach 0.5.
    fn default() -> Self {
        Self {
            min_spacing: 0.5,
            max_density_deviation: 0.05,
            max_mach: 0.5,
            every: 50,
        }
    }
}

/// Everything a run needs.
#[derive(Clone)]
pub struct Scene {
    /// Case name.
    pub case: String,
    /// Dimension, 2 or 3.
    pub dim: usize,
    /// Lower corner of the box (global).
    pub origin: [f64; 3],
    /// Size of the box.
    pub extent: [f64; 3],
    /// What bounds each axis.
    pub axes: [AxisSpec; 3],
    /// Particle spacing.
    pub dx: f64,
    /// Fluid regions.
    pub regions: Vec<Region>,
    /// Walls of any shape, in global coordinates (`sph_core::shape`). The
    /// lattice keeps only points at least `dx / 2` inside the fluid of
    /// every one of them.
    pub shaped_walls: Vec<ShapedWall>,
    /// Initial positions (global) instead of the lattice of `regions`: an
    /// arrangement that conforms to curved walls (rings in an annulus),
    /// since mirrored ghosts continue the arrangement they are given.
    pub initial: Option<Vec<[f64; 3]>>,
    /// Initial velocity `v(x, 0)` (rest if `None`).
    pub velocity: Option<VectorField>,
    /// Initial pressure (reference state if `None`; with summation density
    /// the density follows the positions, so only continuity density starts
    /// from it).
    pub pressure: Option<ScalarField>,
    /// Body force per unit mass.
    pub body_force: [f64; 3],
    /// Reference density.
    pub rho0: f64,
    /// Kinematic viscosity.
    pub nu: f64,
    /// Numerical choices.
    pub physics: Physics,
    /// Output times in seconds, increasing.
    pub output_times: Vec<f64>,
    /// Velocity scale (errors are relative to it).
    pub velocity_scale: f64,
    /// Length scale (gap, channel, box side, cavity side).
    pub length_scale: f64,
    /// Exact velocity `v(x, t)`, where one exists.
    pub exact: Option<VectorField>,
    /// Errors are relative to `velocity_scale * exp(error_decay * t)`
    /// (a decaying flow's current amplitude; 0 for a fixed scale).
    pub error_decay: f64,
    /// State monitor.
    pub monitor: Monitor,
    /// Stop once the relative change of kinetic energy per `L/U` falls
    /// below this (see [`steady`]).
    pub steady_tolerance: Option<f64>,
    /// Worker threads (0: all cores).
    pub threads: usize,
    /// Keep particle states at every output time.
    pub keep_particles: bool,
    /// Run even when the run needs more than [`MAX_STEPS`] steps.
    pub allow_long_run: bool,
    /// Keys the case adds to `summary.json` (its geometry, say).
    pub summary: Vec<(String, serde_json::Value)>,
}

/// The most time steps a run may take unless the scene allows a long run
/// (`--allow-long-run`): about a day at 10^4 particles on one core. A
/// larger count is almost always a unit slip (a viscosity or an end time
/// off by orders of magnitude) and is refused before any work.
pub const MAX_STEPS: f64 = 1e9;

/// Diagnostics at one output time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Diagnostics {
    /// Time in seconds.
    pub t: f64,
    /// `sum 1/2 m |v|^2` over fluid particles.
    pub kinetic_energy: f64,
    /// The same sum with the exact velocity at the particles (where there is one).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kinetic_energy_exact: Option<f64>,
    /// Closest fluid pair in units of `dx` (1 on the initial lattice).
    pub min_spacing: f64,
    /// `max |rho / rho0 - 1|`.
    pub max_density_deviation: f64,
    /// `max |v| / c0`.
    pub max_mach: f64,
    /// `max |v - v_exact|` relative to the error scale.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub linf: Option<f64>,
    /// `sqrt(mean |v - v_exact|^2)` relative to the error scale.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub l2: Option<f64>,
    /// The energy budget (runs with `energy_budget` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub energy: Option<Energy>,
}

/// The energy budget at an output time, in J (per unit depth in 2D): what
/// the weakly compressible equations conserve without viscosity and
/// diffusion, plus what those terms took out.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Energy {
    /// `sum 1/2 m |v|^2`.
    pub kinetic_energy: f64,
    /// `-sum m g(t) . (x - origin)` for the body force's part along bounded
    /// axes (at its ramped strength, measured from the box's origin), plus,
    /// along periodic axes, where wrapped positions have no potential,
    /// minus that part's work integrated every step (`-int sum m g . v dt`,
    /// the potential of the unwrapped displacement): so a channel's driving
    /// force balances its dissipation in the total.
    pub potential_energy: f64,
    /// `sum m e(rho)`, `e` the energy the equation of state stores in
    /// compression (`sph_core::eos::Eos::internal_energy`).
    pub internal_energy: f64,
    /// `-int sum m (v . a_visc + P / rho^2 Drho_diff) dt`: the work of the
    /// viscous terms (wall ghosts included, so a moving wall's input counts
    /// negative) and the change of internal energy by density diffusion,
    /// integrated every step by the trapezoidal rule; not a residual.
    pub dissipated_energy: f64,
    /// The sum of the four: constant for a closed system once a ramp is
    /// over, up to time-integration error, shifting's transport and the
    /// work of the wall ghosts' pressure.
    pub total_energy: f64,
}

/// How far the budget's total moved after the body force's ramp.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct EnergyDrift {
    /// The reference output: the first at or after the ramp's end.
    pub from: f64,
    /// The largest `|potential| + kinetic + |internal|` over the outputs
    /// from the reference on: the scale of the drift.
    pub energy_scale: f64,
    /// Largest `|total - total_ref|` over the later outputs, over the scale.
    pub max_relative: f64,
    /// `(total - total_ref)` at the last output, over the scale.
    pub final_relative: f64,
}

/// The drift of the energy budget's total over outputs after a ramp of
/// `ramp` seconds (0: none); `None` without a budget or without an output
/// after the ramp.
pub fn energy_drift(outputs: &[Diagnostics], ramp: f64) -> Option<EnergyDrift> {
    let start = outputs.iter().position(|d| d.t >= ramp * (1.0 - 1e-12))?;
    let first = outputs[start].energy?;
    let mut scale: f64 = 0.0;
    let mut max: f64 = 0.0;
    let mut last = 0.0;
    for d in &outputs[start..] {
        let e = d.energy?;
        scale = scale.max(e.potential_energy.abs() + e.kinetic_energy + e.internal_energy.abs());
        last = e.total_energy - first.total_energy;
        max = max.max(last.abs());
    }
    let (max, last) = (max / scale, last / scale);
    Some(EnergyDrift {
        from: outputs[start].t,
        energy_scale: scale,
        max_relative: max,
        final_relative: last,
    })
}

/// The stop of a run whose step failed with `e` at simulated time `t`.
fn diverged(t: f64, e: sph_core::error::Error) -> Stop {
    let particle = match e {
        sph_core::error::Error::Unstable { particle, .. } => Some(particle),
        _ => None,
    };
    Stop {
        t,
        particle,
        reason: format!("the run diverged: {e}"),
    }
}

/// Particle state at one output time (fluid only, in creation order).
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Time in seconds.
    pub t: f64,
    /// Positions (global).
    pub x: Vec<[f64; 3]>,
    /// Velocities.
    pub v: Vec<[f64; 3]>,
    /// Densities.
    pub rho: Vec<f64>,
    /// Pressures.
    pub p: Vec<f64>,
}

/// Why a run stopped before its end time.
#[derive(Clone, Debug, PartialEq)]
pub struct Stop {
    /// Simulated time of the stop.
    pub t: f64,
    /// The particle at fault, where there is one.
    pub particle: Option<usize>,
    /// One line saying what happened.
    pub reason: String,
}

/// What every scene's run produces; outputs and plots read only this.
#[derive(Clone, Debug)]
pub struct RunRecord {
    /// Case name.
    pub case: String,
    /// Dimension.
    pub dim: usize,
    /// Numerical choices.
    pub physics: Physics,
    /// Monitor bounds.
    pub monitor: Monitor,
    /// Particle spacing.
    pub dx: f64,
    /// Smoothing length.
    pub h: f64,
    /// Fluid particles.
    pub n_fluid: usize,
    /// Velocity scale.
    pub velocity_scale: f64,
    /// Length scale.
    pub length_scale: f64,
    /// Reference density.
    pub rho0: f64,
    /// Kinematic viscosity.
    pub nu: f64,
    /// Body force.
    pub body_force: [f64; 3],
    /// Time-step limits at the start: `[cfl, viscous, force]` seconds.
    pub limits: [f64; 3],
    /// The step used (with `adaptive_dt`, the estimate made at the start
    /// from the scene's velocity scale).
    pub dt: f64,
    /// With `adaptive_dt`: the smallest and the largest step taken (the
    /// last step of an output interval is shortened to land on it, and is
    /// left out).
    pub dt_range: Option<[f64; 2]>,
    /// Steps taken.
    pub steps: u64,
    /// Threads used (on each rank).
    pub threads: usize,
    /// Ranks the run was spread over ([`RunControl::ranks`]; 1 in one
    /// process).
    pub ranks: usize,
    /// On several ranks: what each held, sent and spent (empty in one
    /// process).
    pub rank_stats: Vec<distributed::RankStats>,
    /// On several ranks: the rank that owned each particle at each frame
    /// (for the VTK pieces; empty in one process).
    pub frame_owners: Vec<Vec<u32>>,
    /// Wall-clock seconds.
    pub wall_seconds: f64,
    /// Bytes of particle storage.
    pub storage_bytes: usize,
    /// Mean neighbours of a fluid particle within the support radius
    /// (itself, fluid, ghosts and wall particles included) at the state
    /// where the run ended; `None` where they could not be counted (a
    /// diverged state).
    pub neighbours_mean: Option<f64>,
    /// Diagnostics at each output time reached.
    pub outputs: Vec<Diagnostics>,
    /// Particle states at each output time reached (with `keep_particles`).
    pub frames: Vec<Frame>,
    /// Why the run stopped early, if it did.
    pub stop: Option<Stop>,
    /// The run reached a steady state before its end time.
    pub steady: bool,
    /// The state where a stop request (SIGINT) halted the run, or where a
    /// run with [`RunControl::pause_after`] paused or ended, to resume it.
    pub checkpoint: Option<Box<Checkpoint>>,
    /// With [`RunControl::pause_after`]: the fluid's state where the run
    /// paused or ended (global positions, as the frames).
    pub state: Option<Frame>,
    /// The scene's own `summary.json` keys ([`Scene::summary`]).
    pub summary: Vec<(String, serde_json::Value)>,
}

impl RunRecord {
    /// The run ended as planned (at its end time or at a steady state).
    pub fn complete(&self) -> bool {
        self.stop.is_none()
    }
}

/// What a run takes from its caller besides the scene, and where its
/// checkpoints go.
pub struct RunControl<'a> {
    /// Progress reports and the stop request (SIGINT).
    pub progress: &'a dyn Progress,
    /// Continue from this checkpoint instead of the initial state (the
    /// scene must be the one it was taken from).
    pub resume: Option<&'a Checkpoint>,
    /// Take a checkpoint every this many simulated seconds and hand it to
    /// `on_checkpoint`, with the run's record so far.
    pub checkpoint_every: Option<f64>,
    /// Receives each periodic checkpoint; an error stops the run with it.
    pub on_checkpoint: &'a mut (dyn FnMut(&RunRecord, &Checkpoint) -> Result<()> + Send),
    /// Pause after this many steps: the run returns with its resumable state
    /// in [`RunRecord::checkpoint`] and the fluid's in [`RunRecord::state`]
    /// (also where it ends sooner, at its end time or a steady state). This
    /// is how [`crate::simulation::Simulation`] steps a scene.
    pub pause_after: Option<u64>,
    /// Re-evaluate the resumed state before the first step
    /// ([`sph_core::solver::Solver::refresh_with`]): for a checkpoint whose
    /// particle fields the caller changed. Without changes, leave it off (the
    /// continuation is then bitwise the uninterrupted run).
    pub refresh: bool,
    /// Run on these ranks ([`crate::distributed`]; `sph run --mpi`): the
    /// same particles and figures as one process, bit for bit, with the
    /// record complete on rank 0 only. A run with checkpoints, a pause or a
    /// resume is refused.
    pub ranks: Option<&'a (dyn Comm + Sync)>,
}

impl<'a> RunControl<'a> {
    /// A plain run: no resume, no checkpoints, no pause.
    pub fn new(
        progress: &'a dyn Progress,
        on_checkpoint: &'a mut (dyn FnMut(&RunRecord, &Checkpoint) -> Result<()> + Send),
    ) -> Self {
        Self {
            progress,
            resume: None,
            checkpoint_every: None,
            on_checkpoint,
            pause_after: None,
            refresh: false,
            ranks: None,
        }
    }
}

/// Runs a scene.
///
/// # Errors
/// [`Error::Config`] for a scene that cannot be built; [`Error::Core`] if the
/// core refuses it. A run that diverges or trips the monitor is not an
/// error here: it returns a record with [`RunRecord::stop`] set.
pub fn run(scene: &Scene, progress: &dyn Progress) -> Result<RunRecord> {
    let mut none = |_: &RunRecord, _: &Checkpoint| Ok(());
    run_with(scene, &mut RunControl::new(progress, &mut none))
}

/// Runs a scene with checkpoints, or continues one from a checkpoint: the
/// continuation is bitwise the run that was never stopped (any thread
/// count). A run stopped by the progress's stop request (SIGINT) returns
/// its state in [`RunRecord::checkpoint`].
///
/// # Errors
/// As [`run`]; [`Error::Config`] (key `checkpoint`) for a checkpoint that
/// does not belong to this scene; errors of `on_checkpoint`.
pub fn run_with(scene: &Scene, ctl: &mut RunControl<'_>) -> Result<RunRecord> {
    check_scene(scene)?;
    if ctl.ranks.is_some() {
        let refused = [
            (ctl.resume.is_some(), "a resumed run"),
            (ctl.checkpoint_every.is_some(), "checkpoints"),
            (ctl.pause_after.is_some(), "a paused run"),
        ];
        if let Some((_, what)) = refused.iter().find(|r| r.0) {
            return Err(Error::config(
                "mpi",
                "on",
                format!(
                    "a run on several ranks does not support {what} yet; run it in one process"
                ),
            ));
        }
    }
    if let Some(every) = ctl.checkpoint_every {
        if !(every > 0.0 && every.is_finite()) {
            return Err(Error::config(
                "checkpoint_every",
                every,
                "must be a positive, finite number of simulated seconds",
            ));
        }
    }
    let threads = crate::driver::resolve_threads(scene.threads);
    let start = Stopwatch::start();
    let mut hook = |record: &RunRecord, ck: &Checkpoint| {
        let mut record = record.clone();
        record.threads = threads;
        record.wall_seconds = start.seconds();
        (ctl.on_checkpoint)(&record, ck)
    };
    let mut inner = RunControl {
        progress: ctl.progress,
        resume: ctl.resume,
        checkpoint_every: ctl.checkpoint_every,
        on_checkpoint: &mut hook,
        pause_after: ctl.pause_after,
        refresh: ctl.refresh,
        ranks: ctl.ranks,
    };
    #[cfg(feature = "full")]
    let mut record = if threads == 1 {
        by_dim(scene, &Serial, &mut inner)?
    } else {
        let pool = crate::driver::thread_pool(threads)?;
        let min_chunk = min_chunk(scene, threads);
        pool.install(|| by_dim(scene, &Rayon { min_chunk }, &mut inner))?
    };
    // Without `full` every run is serial (the same bits as any thread
    // count), and says so in its record.
    #[cfg(not(feature = "full"))]
    let (threads, mut record) = (1, by_dim(scene, &Serial, &mut inner)?);
    ctl.progress.finish();
    record.threads = threads;
    record.ranks = ctl.ranks.map_or(1, |c| c.size());
    record.wall_seconds = start.seconds();
    Ok(record)
}

/// Wall-clock seconds since a start. wasm32-unknown-unknown has no clock
/// (`Instant::now` panics there), so a run in a browser reports 0 s; its
/// page times the calls itself.
pub(crate) struct Stopwatch {
    #[cfg(not(all(target_arch = "wasm32", target_os = "unknown")))]
    start: std::time::Instant,
}

impl Stopwatch {
    pub(crate) fn start() -> Self {
        Self {
            #[cfg(not(all(target_arch = "wasm32", target_os = "unknown")))]
            start: std::time::Instant::now(),
        }
    }

    pub(crate) fn seconds(&self) -> f64 {
        #[cfg(not(all(target_arch = "wasm32", target_os = "unknown")))]
        return self.start.elapsed().as_secs_f64();
        #[cfg(all(target_arch = "wasm32", target_os = "unknown"))]
        0.0
    }
}

fn check_scene(scene: &Scene) -> Result<()> {
    if scene.dim != 2 && scene.dim != 3 {
        return Err(Error::config("dim", scene.dim, "must be 2 or 3"));
    }
    if !(scene.dx > 0.0 && scene.dx.is_finite()) {
        return Err(Error::config("dx", scene.dx, "must be positive and finite"));
    }
    if scene.output_times.is_empty() {
        return Err(Error::config(
            "output_times",
            "[]",
            "at least one output time is needed",
        ));
    }
    let mut last = 0.0;
    for (k, &t) in scene.output_times.iter().enumerate() {
        // The first may be 0: the initial state, written before any step.
        if !((t > last || (k == 0 && t == 0.0)) && t.is_finite()) {
            return Err(Error::config(
                "output_times",
                t,
                "output times must be finite and increasing, the first at or after 0, the others after it",
            ));
        }
        last = t;
    }
    if scene.physics.math == MathBackend::Micromath && scene.physics.precision == Precision::F64 {
        return Err(Error::config(
            "math",
            scene.physics.math,
            "micromath implements f32 only: use precision = \"f32\"",
        ));
    }
    if scene.dim == 3 && scene.physics.math == MathBackend::Micromath {
        return Err(Error::config(
            "math",
            scene.physics.math,
            "3D scenes run with libm only",
        ));
    }
    // What the settings check for the built-in cases, again for a scene
    // built in code, so that no choice is silently ignored.
    let p = &scene.physics;
    if !(p.alpha >= 0.0 && p.alpha.is_finite()) {
        return Err(Error::config(
            "alpha",
            p.alpha,
            "must be finite and at least 0",
        ));
    }
    check_forms(p.viscosity, p.alpha, p.density, p.pressure_gradient)?;
    if !(p.gravity_ramp >= 0.0 && p.gravity_ramp.is_finite()) {
        return Err(Error::config(
            "gravity_ramp",
            p.gravity_ramp,
            "must be finite and at least 0 (0: no ramp)",
        ));
    }
    Ok(())
}

/// The combinations of forms the engine has no meaning for: an artificial
/// viscosity on top of a form other than Morris (or artificial itself), and
/// the corrected pressure gradient with summation density. Shared by the
/// settings' validation and [`run`] (for scenes built in code).
///
/// # Errors
/// [`Error::Config`] naming the key, its value and the rule.
pub(crate) fn check_forms(
    viscosity: ViscosityForm,
    alpha: f64,
    density: DensityMode,
    pressure_gradient: PressureForm,
) -> Result<()> {
    if alpha > 0.0 && !matches!(viscosity, ViscosityForm::Morris | ViscosityForm::Artificial) {
        return Err(Error::config(
            "alpha",
            alpha,
            format!(
                "an artificial viscosity is added to viscosity = \"morris\" only, not to \"{viscosity}\""
            ),
        ));
    }
    if pressure_gradient == PressureForm::Corrected && density == DensityMode::Summation {
        return Err(Error::config(
            "pressure_gradient",
            pressure_gradient,
            "corrected needs continuity density: use density = \"corrected\" or \"continuity\"",
        ));
    }
    Ok(())
}

/// Lattice points of the scene's regions (global positions).
pub fn lattice(scene: &Scene) -> Vec<[f64; 3]> {
    if let Some(points) = &scene.initial {
        return points.clone();
    }
    // Mirrored ghosts: the fluid keeps half a spacing in front of a shaped
    // wall, so no particle meets its own image closer than a spacing. Wall
    // particles: the box lattice is split at the wall itself, the fluid
    // taking the points in front of it and the wall particles those behind
    // (`sph_core::boundary::for_each_wall_particle`, its default front),
    // so the wall lies where the geometry puts it at any angle. Either way
    // the fluid's threshold is half a millionth of a spacing below the
    // wall particles', so rounding cannot give a point to both.
    let front = match scene.physics.wall_boundary {
        WallBoundary::Particles => 0.0,
        WallBoundary::Mirror => 0.5,
    } - 0.5e-6;
    let d = scene.dim;
    let dx = scene.dx;
    let mut counts = [1usize; 3];
    for (a, c) in counts.iter_mut().enumerate().take(d) {
        *c = (scene.extent[a] / dx).round().max(1.0) as usize;
    }
    let mut points = Vec::new();
    for k in 0..counts[2] {
        for j in 0..counts[1] {
            for i in 0..counts[0] {
                let idx = [i, j, k];
                let mut p = [0.0; 3];
                for a in 0..d {
                    p[a] = scene.origin[a] + (idx[a] as f64 + 0.5) * dx;
                }
                let inside = scene
                    .regions
                    .iter()
                    .any(|r| (0..d).all(|a| p[a] >= r.lo[a] && p[a] < r.hi[a]))
                    && scene
                        .shaped_walls
                        .iter()
                        .all(|w| w.shape.distance(p, d).0 >= front * dx);
                if inside {
                    points.push(p);
                }
            }
        }
    }
    points
}

/// Refuses a solid thinner than the kernel support `radius` with fluid on
/// both sides. Neither boundary method can hold such a solid: its far
/// side's fluid lies within the near side's support, seen straight
/// through it (no pair test looks for walls between particles); mirrored
/// ghosts of both sides crowd into one neighbourhood, and a solid thinner
/// than the spacing holds no wall particle at all (a plate 0.8 dx thick
/// let the fluid fall through at its free-fall speed). The probe: from
/// each fluid point within `radius` in front of a shaped wall (and off
/// its surface), the point
/// `radius` straight through it along the normal; if that point lies in
/// the fluid (in front of every wall, inside a region), the solid there is
/// thinner than `radius`.
fn thin_solid(scene: &Scene, points: &[[f64; 3]], radius: f64) -> Result<()> {
    let d = scene.dim;
    let walls = &scene.shaped_walls;
    if walls.is_empty() {
        return Ok(());
    }
    let in_box = |mut q: [f64; 3]| -> Option<[f64; 3]> {
        for (a, c) in q.iter_mut().enumerate().take(d) {
            let (lo, l) = (scene.origin[a], scene.extent[a]);
            if matches!(scene.axes[a], AxisSpec::Periodic) {
                *c = lo + (*c - lo).rem_euclid(l);
            } else if *c < lo || *c > lo + l {
                return None;
            }
        }
        Some(q)
    };
    let fluid = |q: [f64; 3]| {
        walls.iter().all(|w| w.shape.distance(q, d).0 > 0.0)
            && scene
                .regions
                .iter()
                .any(|r| (0..d).all(|a| q[a] >= r.lo[a] && q[a] < r.hi[a]))
    };
    for p in points {
        for (k, w) in walls.iter().enumerate() {
            let (dist, n) = w.shape.distance(*p, d);
            // A point on the surface itself (the lattice puts points on
            // 45-degree walls) has no reliable normal: its neighbours probe
            // the same solid.
            if dist.is_nan() || dist >= radius || dist < 1e-6 * scene.dx {
                continue;
            }
            let through = [
                p[0] - radius * n[0],
                p[1] - radius * n[1],
                p[2] - radius * n[2],
            ];
            if in_box(through).is_some_and(fluid) {
                let key = if scene.case == "custom" {
                    format!("scene.shapes[{k}]")
                } else {
                    format!("{} wall {k}", scene.case)
                };
                return Err(Error::config(
                    key,
                    format!("near ({:.4}, {:.4})", p[0], p[1]),
                    format!(
                        "a solid with fluid on both sides must be at least one kernel support ({radius:.4}) thick: the fluid there would see the fluid beyond it; thicken it or refine the spacing"
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Thickness, in particle rows, of the slab of ghosts a wall mirrors: the
/// list radius `(1 + skin) kappa beta dx`, rounded up, plus two rows.
fn ghost_slab(kappa: f64, beta: f64) -> f64 {
    (kappa * beta * (1.0 + SKIN)).ceil() + 2.0
}

/// The fraction of the body force on at time `t` with a ramp over `ramp`
/// (0: none): `(1 - cos(pi t / T)) / 2`, smooth at both ends.
pub fn ramp_factor(t: f64, ramp: f64) -> f64 {
    if t >= ramp {
        1.0
    } else {
        0.5 * (1.0 - libm::cos(std::f64::consts::PI * t / ramp))
    }
}

/// The smallest piece a pass is split into on `threads` threads: about
/// four pieces per thread of the fluid's own particles, not the box's (a
/// dam break fills an eighth of its tank: pieces sized from the box left
/// the whole fluid in one piece, on one thread).
#[cfg(feature = "full")]
fn min_chunk(scene: &Scene, threads: usize) -> usize {
    (estimate_fluid(scene) / (4 * threads.max(1))).max(64)
}

/// The fluid's particle count, estimated without building the lattice (a
/// scene too large for memory is refused after this, before anything is
/// allocated): the given initial points, or the regions' volume inside the
/// box over `dx^dim`, at most the box's count.
#[cfg(feature = "full")]
fn estimate_fluid(scene: &Scene) -> usize {
    if let Some(points) = &scene.initial {
        return points.len();
    }
    let mut volume = 0.0;
    for r in &scene.regions {
        let mut v = 1.0;
        for a in 0..scene.dim {
            let lo = r.lo[a].max(scene.origin[a]);
            let hi = r.hi[a].min(scene.origin[a] + scene.extent[a]);
            v *= ((hi - lo) / scene.dx).max(0.0);
        }
        volume += v;
    }
    (volume as usize).min(estimate_particles(scene))
}

/// The box's particle count at spacing `dx` (an upper bound on the fluid's).
fn estimate_particles(scene: &Scene) -> usize {
    let mut n = 1.0;
    for a in 0..scene.dim {
        n *= scene.extent[a] / scene.dx;
    }
    n as usize
}

fn by_dim<E: Executor>(scene: &Scene, exec: &E, ctl: &mut RunControl<'_>) -> Result<RunRecord> {
    let p = scene.physics;
    match (scene.dim, p.precision, p.math) {
        (2, Precision::F64, MathBackend::Libm) => by_kernel::<D2<f64>, Host, E>(scene, exec, ctl),
        #[cfg(feature = "full")]
        (2, Precision::F32, MathBackend::Libm) => by_kernel::<D2<f32>, Host, E>(scene, exec, ctl),
        #[cfg(feature = "full")]
        (2, Precision::F32, MathBackend::Micromath) => {
            by_kernel::<D2<f32>, Micromath, E>(scene, exec, ctl)
        }
        #[cfg(feature = "full")]
        (3, Precision::F64, MathBackend::Libm) => by_kernel::<D3<f64>, Host, E>(scene, exec, ctl),
        #[cfg(feature = "full")]
        (3, Precision::F32, MathBackend::Libm) => by_kernel::<D3<f32>, Host, E>(scene, exec, ctl),
        _ => Err(Error::config(
            "math",
            format!("{} in {}D with {}", p.math, scene.dim, p.precision),
            NOT_BUILT,
        )),
    }
}

/// Why a scene's configuration has no code in this build.
#[cfg(feature = "full")]
const NOT_BUILT: &str = "this combination of dimension, precision and math backend is not built";
/// Why a scene's configuration has no code in this build.
#[cfg(not(feature = "full"))]
const NOT_BUILT: &str = "not in this build: without sph-std's `full` feature only 2D, f64 and libm with the cubic and quintic kernels are compiled";

fn by_kernel<S, M, E>(scene: &Scene, exec: &E, ctl: &mut RunControl<'_>) -> Result<RunRecord>
where
    S: Space,
    M: Math<S::Real>,
    E: Executor,
{
    match scene.physics.kernel {
        KernelName::Cubic => by_terms::<S, CubicSpline, M, E>(scene, exec, ctl),
        KernelName::Quintic => by_terms::<S, QuinticSpline, M, E>(scene, exec, ctl),
        #[cfg(feature = "full")]
        KernelName::WendlandC2 => by_terms::<S, WendlandC2, M, E>(scene, exec, ctl),
        #[cfg(feature = "full")]
        KernelName::WendlandC4 => by_terms::<S, WendlandC4, M, E>(scene, exec, ctl),
        #[cfg(feature = "full")]
        KernelName::Gaussian => by_terms::<S, Gaussian, M, E>(scene, exec, ctl),
        #[cfg(not(feature = "full"))]
        other => Err(Error::config("kernel", other, NOT_BUILT)),
    }
}

/// The viscous term of a scene: the run-time enum (one predictable branch
/// per pair) or the consistent Laplacian.
fn by_terms<S, K, M, E>(scene: &Scene, exec: &E, ctl: &mut RunControl<'_>) -> Result<RunRecord>
where
    S: Space,
    K: Kernel,
    M: Math<S::Real>,
    E: Executor,
{
    let mu = S::Real::from_f64(scene.nu * scene.rho0);
    let mut run =
        |visc: AnyViscosity<S::Real>| by_regularisation::<S, K, M, E, _>(scene, exec, ctl, visc);
    match scene.physics.viscosity {
        ViscosityForm::Morris if scene.physics.alpha > 0.0 => run(AnyViscosity::MorrisArtificial(
            MorrisViscosity { mu },
            ArtificialViscosity {
                alpha: S::Real::from_f64(scene.physics.alpha),
                beta: S::Real::ZERO,
            },
        )),
        ViscosityForm::Morris => run(AnyViscosity::Morris(MorrisViscosity { mu })),
        ViscosityForm::Pi => run(AnyViscosity::Pi(PiViscosity { mu })),
        ViscosityForm::Artificial => {
            let alpha = if scene.physics.alpha > 0.0 {
                scene.physics.alpha
            } else {
                // nu = alpha h c0 / (2 (d + 2)) (physics.md 1.4).
                let h = scene.physics.beta * scene.dx;
                2.0 * (scene.dim as f64 + 2.0) * scene.nu / (h * scene.physics.sound_speed)
            };
            run(AnyViscosity::Artificial(ArtificialViscosity {
                alpha: S::Real::from_f64(alpha),
                beta: S::Real::ZERO,
            }))
        }
        // The consistent Laplacian is its own type: its scratch would give
        // every other viscous form a larger per-particle state if it were a
        // variant of the run-time enum.
        ViscosityForm::Corrected => by_regularisation::<S, K, M, E, _>(
            scene,
            exec,
            ctl,
            CorrectedMorrisViscosity {
                mu,
                rho0: S::Real::from_f64(scene.rho0),
            },
        ),
    }
}

fn by_regularisation<S, K, M, E, V>(
    scene: &Scene,
    exec: &E,
    ctl: &mut RunControl<'_>,
    visc: V,
) -> Result<RunRecord>
where
    S: Space,
    K: Kernel,
    M: Math<S::Real>,
    E: Executor,
    V: Term<S>,
{
    let f = S::Real::from_f64;
    let h = scene.physics.beta * scene.dx;
    // At the start of a ramp the body force is off (`ramp_factor`).
    let k0 = ramp_factor(0.0, scene.physics.gravity_ramp);
    let g0 = S::Vector::from_fn(|a| f(scene.body_force[a]));
    let g = BodyForce::<S> { g: g0 * f(k0) };
    let kernel = SmoothingKernel::<S, K, M>::new(f(h))?;
    let w_dx = kernel.w(f(scene.dx * scene.dx));
    let mut shift = Shifting::new(
        f(scene.physics.shift_coefficient),
        f(scene.velocity_scale),
        f(h),
        w_dx,
    );
    // A box with an open side has a free surface: there shifting keeps to
    // the surface's tangent (the threshold on the divergence of position is
    // Lind et al.'s 1.5 in 2D, the dimension minus a half in general).
    let open = scene
        .axes
        .iter()
        .take(scene.dim)
        .any(|a| matches!(a, AxisSpec::Walls(lo, hi) if lo.is_none() || hi.is_none()));
    if open {
        shift = shift.with_free_surface(f(scene.dim as f64 - 0.5));
    }
    // Continuity density always carries delta-SPH diffusion (zero by
    // default), leaving alone the hydrostatic density gradient of the body
    // force's part along bounded axes (along a periodic axis the pressure is
    // periodic and balances none of it: a channel's driving force).
    let c0 = scene.physics.sound_speed;
    let balanced = |a: usize| match scene.axes[a] {
        AxisSpec::Periodic => 0.0,
        AxisSpec::Walls(..) => scene.rho0 * scene.body_force[a] / (c0 * c0),
    };
    let gradient0 = S::Vector::from_fn(|a| f(balanced(a)));
    let diffusion = DensityDiffusion::<S>::new(f(scene.physics.density_diffusion))
        .hydrostatic(gradient0 * f(k0));
    // With continuity density the pressure gradient is chosen at run time
    // (summation density keeps the symmetric form, validated up front).
    let pressure = match scene.physics.pressure_gradient {
        PressureForm::Symmetric => AnyPressure::Symmetric,
        PressureForm::Corrected => AnyPressure::Corrected,
    };
    let mut ctx = Context { scene, exec, ctl };
    // The shifting velocity scale follows the flow: C h max(|v|, U/100).
    let c_h = scene.physics.shift_coefficient * h;
    let floor = 0.01 * scene.velocity_scale;
    let retune = move |shift: &mut Shifting<S::Real>, vmax: f64| {
        shift.scale = S::Real::from_f64(c_h * vmax.max(floor));
    };
    // A ramped body force: the force term and the diffusion's hydrostatic
    // gradient scaled together (the walls' gravity follows in `simulate`).
    let ramp = |body: &mut BodyForce<S>, k: S::Real| body.g = g0 * k;
    let ramp_both = move |body: &mut BodyForce<S>, d: &mut DensityDiffusion<S>, k: S::Real| {
        body.g = g0 * k;
        d.gradient = gradient0 * k;
    };
    match (scene.physics.density, scene.physics.regularise) {
        (DensityMode::Summation, Regularise::None) => ctx.simulate::<S, K, M, _, _, _>(
            SummationDensity,
            (PressureGradient, visc, g),
            |t, _, k| ramp(&mut t.2, k),
            |t| t.1,
        ),
        (DensityMode::Summation, Regularise::Shifting) => ctx.simulate::<S, K, M, _, _, _>(
            SummationDensity,
            (PressureGradient, visc, g, shift),
            |t, v, k| {
                ramp(&mut t.2, k);
                retune(&mut t.3, v);
            },
            |t| t.1,
        ),
        (continuity, Regularise::None) => ctx.simulate::<S, K, M, _, _, _>(
            (),
            ((by_form(continuity), diffusion), pressure, visc, g),
            |t, _, k| ramp_both(&mut t.3, &mut t.0 .1, k),
            |t| (t.2, t.0 .1),
        ),
        (continuity, Regularise::Shifting) => ctx.simulate::<S, K, M, _, _, _>(
            (),
            ((by_form(continuity), diffusion), pressure, visc, g, shift),
            |t, v, k| {
                ramp_both(&mut t.3, &mut t.0 .1, k);
                retune(&mut t.4, v);
            },
            |t| (t.2, t.0 .1),
        ),
    }
}

/// The continuity form of a density mode other than summation.
fn by_form(mode: DensityMode) -> AnyContinuity {
    if mode == DensityMode::Corrected {
        AnyContinuity::Corrected
    } else {
        AnyContinuity::Plain
    }
}

struct Context<'a, 'c, E> {
    scene: &'a Scene,
    exec: &'a E,
    ctl: &'a mut RunControl<'c>,
}

fn to3<S: Space>(v: S::Global) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (a, o) in out.iter_mut().enumerate().take(S::DIM) {
        *o = v[a];
    }
    out
}

fn vec3<S: Space>(v: S::Vector) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (a, o) in out.iter_mut().enumerate().take(S::DIM) {
        *o = v[a].to_f64();
    }
    out
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

impl<E: Executor> Context<'_, '_, E> {
    fn domain<S: Space>(&self) -> Result<Domain<S>> {
        let s = self.scene;
        let f = S::Real::from_f64;
        let mut domain = Domain::<S>::new(
            S::Global::from_fn(|a| s.origin[a]),
            S::Vector::from_fn(|a| f(s.extent[a])),
        )?;
        for a in 0..S::DIM {
            match s.axes[a] {
                AxisSpec::Periodic => domain = domain.with_periodic(a)?,
                AxisSpec::Walls(lower, upper) => {
                    for (side, spec) in [(Side::Lower, lower), (Side::Upper, upper)] {
                        let Some(w) = spec else { continue };
                        let velocity = S::Vector::from_fn(|b| f(w.velocity[b]));
                        let mut wall = if w.free_slip {
                            Wall::free_slip()
                        } else {
                            Wall::moving(velocity)
                        };
                        // Point reflection and the velocity curvature refine
                        // mirrored ghosts; wall particles take the fluid's.
                        let mirrored = s.physics.wall_boundary == WallBoundary::Mirror;
                        if mirrored {
                            wall.reflection = w.reflection;
                        }
                        if mirrored && w.body_force_curvature && !w.free_slip {
                            wall.curvature = S::Vector::from_fn(|b| {
                                if b == a {
                                    S::Real::ZERO
                                } else {
                                    f(-s.body_force[b] / s.nu)
                                }
                            });
                        }
                        domain = domain.with_wall(a, side, wall)?;
                    }
                }
            }
        }
        if s.physics.wall_boundary == WallBoundary::Particles {
            // The wall particles fill the solid behind a shaped wall and
            // nothing in front of it (the default front; see `lattice`).
            domain = domain.with_wall_particles(f(s.dx))?;
        }
        let to_local = [-s.origin[0], -s.origin[1], -s.origin[2]];
        for w in &s.shaped_walls {
            domain = domain.with_shaped_wall(w.translated(to_local))?;
        }
        if s.physics.wall_pressure == WallPressure::Hydrostatic && s.body_force != [0.0; 3] {
            // At the start of a ramp the body force is off.
            let k = ramp_factor(0.0, s.physics.gravity_ramp);
            domain = domain.with_wall_gravity(S::Vector::from_fn(|a| f(s.body_force[a] * k)))?;
        }
        Ok(domain)
    }

    /// Runs the scene with a density group, a force group, the closure
    /// that retunes the forces before each step (from the largest speed and
    /// the ramp factor) and the closure that picks the dissipative terms
    /// (viscous and diffusive) out of the force group for the energy budget.
    fn simulate<S, K, M, D, T, X>(
        &mut self,
        density: D,
        forces: T,
        retune: impl Fn(&mut T, f64, S::Real),
        dissipation: impl Fn(&T) -> X,
    ) -> Result<RunRecord>
    where
        S: Space,
        K: Kernel,
        M: Math<S::Real>,
        D: Term<S>,
        T: Term<S>,
        X: Term<S>,
    {
        let s = self.scene;
        let exec = self.exec;
        let f = S::Real::from_f64;
        let domain = self.domain::<S>()?;
        // A ramped body force: the walls' gravity follows it every step.
        let ramped_walls = s.physics.gravity_ramp > 0.0 && domain.wall_gravity().is_some();
        let body_force = S::Vector::from_fn(|a| f(s.body_force[a]));
        self.check_memory::<S, K>()?;
        let points = lattice(s);
        let n = points.len();
        if n == 0 {
            return Err(Error::config(
                "regions",
                "(empty)",
                "the fluid regions hold no lattice point",
            ));
        }
        let h = s.physics.beta * s.dx;
        let kappa = K::SUPPORT;
        thin_solid(s, &points, kappa * h)?;
        // Ghost capacity: every wall mirrors a slab (1 + skin) R thick, plus
        // corner images; generous, since a shortfall is a clear error.
        let slab = ghost_slab(kappa, s.physics.beta);
        let mut ghosts = 0usize;
        for a in 0..S::DIM {
            if let AxisSpec::Walls(lo, hi) = s.axes[a] {
                let walls = lo.is_some() as usize + hi.is_some() as usize;
                let mut face = 1.0;
                for b in 0..S::DIM {
                    if b != a {
                        face *= s.extent[b] / s.dx + 2.0 * slab;
                    }
                }
                ghosts += walls * (face * slab) as usize;
            }
        }
        // A shaped wall mirrors at most every fluid particle once. Wall
        // particles replace the mirrors of every wall and fill a shell as
        // deep as the neighbour-list radius (half a spacing added, against
        // rounding at the last layer).
        let (mirrored, wall_particles) = if domain.wall_particles().is_some() {
            let depth = (1.0 + SKIN) * h * kappa + 0.5 * s.dx;
            (
                0,
                sph_core::boundary::wall_particle_count(&domain, f(depth)),
            )
        } else {
            (2 * ghosts, 0)
        };
        let shaped_mirrors = if domain.wall_particles().is_some() {
            0
        } else {
            n * s.shaped_walls.len()
        };
        let capacity = n + mirrored + shaped_mirrors + wall_particles;
        let cells = Solver::<S, K, M, D, T>::cells_needed(&domain, f(h))?;
        let width = crate::driver::list_width(S::DIM, kappa, s.physics.beta, SKIN);
        let mut buffers = Buffers::<S>::new(capacity, cells).with_lists(n, width);
        if T::SHIFTS {
            buffers = buffers.with_shifting();
        }
        let continuity = D::EMPTY;
        let c0 = s.physics.sound_speed;
        let pb = s.physics.background_pressure;
        let eos = match s.physics.eos {
            EosForm::Linear => Eos::Linear {
                rho0: f(s.rho0),
                c0: f(c0),
                p0: f(pb),
            },
            EosForm::Tait => Eos::Tait {
                rho0: f(s.rho0),
                c0: f(c0),
                gamma: f(7.0),
                p0: f(pb),
            },
        };
        let cell_volume = s.dx.powi(S::DIM as i32);
        for (k, p) in points.iter().enumerate() {
            let local = domain.to_local(S::Global::from_fn(|a| p[a]));
            buffers.x[k] = local;
            let v = s.velocity.as_ref().map_or([0.0; 3], |field| field(*p, 0.0));
            buffers.v[k] = S::Vector::from_fn(|a| f(v[a]));
            buffers.m[k] = f(s.rho0 * cell_volume);
            // Continuity density starts from the initial pressure (inverse
            // of the equation of state); summation ignores it.
            let p0 = s.pressure.as_ref().map_or(0.0, |field| field(*p));
            buffers.rho[k] = match s.physics.eos {
                EosForm::Linear => f(s.rho0 + p0 / (c0 * c0)),
                EosForm::Tait => eos.density::<M>(f(pb + p0), f(s.rho0)),
            };
        }
        let storage_bytes = buffers.bytes();
        let mut params = Params::new(f(h), eos)
            .with_eta2(f(s.physics.eta2))
            .with_skin(f(SKIN));
        if s.physics.tension_cutoff {
            params = params.with_density_floor(f(s.rho0));
        }
        let resume = self.ctl.resume;
        let (mut solver, limits, dt_max) = if let Some(ck) = resume {
            if ck.case != s.case || ck.dim != S::DIM || ck.n_fluid != n {
                return Err(Error::config(
                    "checkpoint",
                    format!("{} {}D, {} particles", ck.case, ck.dim, ck.n_fluid),
                    format!(
                        "belongs to another run than this {} {}D scene of {n} particles",
                        s.case,
                        S::DIM
                    ),
                ));
            }
            buffers.load(&ck.arrays)?;
            let solver = Solver::<S, K, M, D, T>::resume_with(
                params,
                domain,
                buffers.storage(),
                n,
                density,
                forces,
                ck.state,
            )?;
            let mut solver = solver;
            if self.ctl.refresh {
                solver.refresh_with(exec)?;
            }
            (solver, ck.limits, ck.dt)
        } else {
            let mut solver = Solver::<S, K, M, D, T>::new_with(
                exec,
                params,
                domain,
                buffers.storage(),
                n,
                density,
                forces,
            )?;
            // Masses such that summation density gives rho0 on the initial
            // arrangement; continuity density started from a pressure field
            // keeps the lattice mass and its densities.
            if !continuity || s.pressure.is_none() {
                solver.calibrate_mass_with(exec, f(s.rho0))?;
            }
            let limits = solver.limits();
            // The acoustic limit with the scene's velocity scale (the state at
            // rest does not know how fast a lid or a vortex will go).
            let cfl = 0.25 * h / (c0 + s.velocity_scale);
            let dt_max = s.physics.dt_factor * cfl.min(limits.viscous).min(limits.force);
            (solver, [cfl, limits.viscous, limits.force], dt_max)
        };
        if !(dt_max > 0.0 && dt_max.is_finite()) {
            return Err(Error::config(
                "dt",
                dt_max,
                "the time step from the stability limits must be positive and finite",
            ));
        }
        // The energy budget: [dissipated energy, dissipative power, the
        // potential of the body force along periodic axes (minus its work),
        // that work's rate], the rates at the end of the last step and
        // integrated by the trapezoidal rule.
        let periodic_g: [f64; 3] = std::array::from_fn(|a| match s.axes[a] {
            AxisSpec::Periodic => s.body_force[a],
            AxisSpec::Walls(..) => 0.0,
        });
        // Each rate is an exact sum over the particles (`slots`: all, or a
        // rank's own), so that it has the same bits for any split.
        let local_rates =
            |solver: &Solver<'_, S, K, M, D, T>, slots: &[usize]| -> Result<[ExactSum; 2]> {
                let k = ramp_factor(solver.time(), s.physics.gravity_ramp);
                let (m, v) = (solver.masses(), solver.velocities());
                let mut body = ExactSum::new();
                for &i in slots {
                    let v = vec3::<S>(v[i]);
                    body.add(m[i].to_f64() * k * (0..3).map(|a| periodic_g[a] * v[a]).sum::<f64>());
                }
                let power = dissipation_power(solver, &dissipation(solver.forces()), exec, slots)?;
                Ok([power, body])
            };
        let every_slot: Vec<usize> = if s.physics.energy_budget {
            (0..n).collect()
        } else {
            Vec::new()
        };
        let rates = |solver: &Solver<'_, S, K, M, D, T>| -> Result<[f64; 2]> {
            let [mut power, mut body] = local_rates(solver, &every_slot)?;
            Ok([power.value(), body.value()])
        };
        let mut budget = match (s.physics.energy_budget, resume) {
            (false, _) => None,
            (true, Some(ck)) => Some(ck.budget),
            (true, None) => {
                let [power, body] = rates(&solver)?;
                Some([0.0, power, 0.0, body])
            }
        };
        let mut total = 0.0;
        let mut last = 0.0;
        for &t in &s.output_times {
            total += ((t - last) / dt_max).ceil().max(1.0);
            last = t;
        }
        // Beyond 2^53 steps the step counter and the times lose integers.
        if total > MAX_STEPS && (!s.allow_long_run || total > 9.0e15) {
            return Err(Error::config(
                "t_end",
                format!("{:e}", s.output_times.last().copied().unwrap_or(0.0)),
                format!(
                    "needs {total:.2e} time steps at dt = {dt_max:.3e} s, more than {MAX_STEPS:e}; shorten the run or pass --allow-long-run"
                ),
            ));
        }
        let mut plan = Vec::with_capacity(s.output_times.len());
        let mut last = 0.0;
        for &t in &s.output_times {
            // An output at t = 0 takes no step.
            let steps = if t > last {
                ((t - last) / dt_max).ceil().max(1.0) as u64
            } else {
                0
            };
            plan.push((t, steps, (t - last) / steps.max(1) as f64));
            last = t;
        }
        let (first_interval, first_done) = resume.map_or((0, 0), |ck| (ck.interval, ck.done));
        let adaptive = s.physics.adaptive_dt;
        // With an adaptive step the plan's step counts are estimates.
        if first_interval > plan.len()
            || (!adaptive && plan.get(first_interval).is_some_and(|p| first_done > p.1))
        {
            return Err(Error::config(
                "checkpoint",
                format!("output {first_interval}, step {first_done}"),
                "lies beyond the run's output times",
            ));
        }
        self.ctl.progress.start(plan.iter().map(|p| p.1).sum());
        let already: u64 = plan[..first_interval].iter().map(|p| p.1).sum::<u64>() + first_done;
        self.ctl.progress.advance(already);
        let mut record = RunRecord {
            case: s.case.clone(),
            dim: S::DIM,
            physics: s.physics,
            monitor: s.monitor,
            dx: s.dx,
            h,
            n_fluid: n,
            velocity_scale: s.velocity_scale,
            length_scale: s.length_scale,
            rho0: s.rho0,
            nu: s.nu,
            body_force: s.body_force,
            limits,
            dt: dt_max,
            dt_range: resume.and_then(|ck| ck.dt_range),
            steps: 0,
            threads: 1,
            ranks: 1,
            rank_stats: Vec::new(),
            frame_owners: Vec::new(),
            wall_seconds: 0.0,
            storage_bytes,
            neighbours_mean: None,
            outputs: resume.map_or_else(Vec::new, |ck| ck.outputs.clone()),
            frames: resume.map_or_else(Vec::new, |ck| ck.frames.clone()),
            stop: None,
            steady: false,
            checkpoint: None,
            state: None,
            summary: s.summary.clone(),
        };
        let every = s.monitor.every.max(1);
        let period = self.ctl.checkpoint_every;
        // The next checkpoint time: the first multiple of the period ahead.
        let next_after = |t: f64| period.map(|p| ((t / p).floor() + 1.0) * p);
        let mut next_checkpoint = next_after(solver.time());
        let pause = self.ctl.pause_after;
        let steps_before = solver.steps();
        let capture = |solver: &Solver<'_, S, K, M, D, T>,
                       record: &RunRecord,
                       budget: Option<[f64; 4]>,
                       interval: usize,
                       done: u64| Checkpoint {
            dt_range: record.dt_range,
            case: s.case.clone(),
            dim: S::DIM,
            n_fluid: n,
            interval,
            done,
            dt: dt_max,
            limits,
            storage_bytes,
            state: solver.resume_state(),
            arrays: crate::driver::save(&solver.storage()),
            outputs: record.outputs.clone(),
            frames: record.frames.clone(),
            budget: budget.unwrap_or([0.0; 4]),
            options: Default::default(),
        };
        // Before each step: the forces retuned to the largest speed, the
        // ramped body force's walls set.
        let before_step = |solver: &mut Solver<'_, S, K, M, D, T>, vmax: f64| -> Result<()> {
            let on = f(ramp_factor(solver.time(), s.physics.gravity_ramp));
            retune(solver.forces_mut(), vmax, on);
            if ramped_walls {
                solver.set_wall_gravity(body_force * on)?;
            }
            Ok(())
        };
        if let Some(comm) = self.ctl.ranks {
            // Shared by the hooks below: the budget (every rank integrates
            // it from the same exact sums), a stop between outputs, the
            // adaptive step's range.
            let budget = Cell::new(budget);
            let stopped: Cell<Option<(Stop, u64)>> = Cell::new(None);
            let dt_range = Cell::new(record.dt_range);
            // The full solver's viscous limit: a rank's own estimate sees
            // only its part.
            let viscous = solver.limits().viscous;
            let mut choose = |index: usize, time: f64, mut l: Limits| -> Option<f64> {
                l.viscous = viscous;
                let mut range = dt_range.get();
                let dt = adaptive_step(
                    s.physics.dt_factor * l.min(),
                    plan[index].0 - time,
                    &mut range,
                );
                dt_range.set(range);
                dt
            };
            let steps_plan: Vec<(u64, f64)> = plan.iter().map(|p| (p.1, p.2)).collect();
            let stepping = if adaptive {
                Stepping::Adaptive {
                    outputs: plan.len(),
                    choose: &mut choose,
                }
            } else {
                Stepping::Fixed(&steps_plan)
            };
            let mut after_step =
                |solver: &Solver<'_, S, K, M, D, T>, done: &StepDone<'_>| -> Result<bool> {
                    if let Some(before) = budget.get() {
                        let slots: Vec<usize> = done.owned.iter().map(|o| o.0).collect();
                        // Every rank joins the sum, a failed one with NaN.
                        let (sums, failed) = match local_rates(solver, &slots) {
                            Ok(r) => (r, None),
                            Err(e) => {
                                let nan = || {
                                    let mut x = ExactSum::new();
                                    x.add(f64::NAN);
                                    x
                                };
                                ([nan(), nan()], Some(e))
                            }
                        };
                        let totals = distributed::sum_exact(comm, sums.into());
                        if let Some(e) = failed {
                            return Err(e);
                        }
                        let rates = [totals[0], totals[1]];
                        budget.set(Some(integrate_budget(before, done.dt, rates)));
                    }
                    if (done.in_interval + 1).is_multiple_of(every) {
                        let worst = self.check_cheap_ranked(comm, solver, done.owned);
                        if let Some(stop) = self.judge(solver.time(), &worst) {
                            stopped.set(Some((stop, solver.steps())));
                            return Ok(true);
                        }
                    }
                    Ok(false)
                };
            let setup = Setup {
                params,
                domain,
                density,
                forces,
                cells,
                list_width: width,
                ghost_room: capacity - n,
            };
            let initial = Particles::of_solver(&solver);
            // Rank 0: this process's solver takes every gathered state
            // and judges it as a single run judges its own.
            let mut on_output = |out: distributed::Output| -> Result<bool> {
                let write = |solver: &mut Solver<'_, S, K, M, D, T>| {
                    let mut fluid = solver.fluid_mut();
                    for k in 0..n {
                        distributed::write_record::<S>(&mut fluid, k, out.particles.record(k));
                    }
                };
                write(&mut solver);
                // Lists and ghosts at the gathered positions for the closest
                // pair; then the state again, over the re-evaluation's.
                solver.refresh_with(exec)?;
                write(&mut solver);
                let t_out = plan[out.index].0;
                self.ctl.progress.advance(plan[out.index].1);
                record.steps = out.steps;
                record.rank_stats = out.ranks;
                if s.keep_particles {
                    record.frame_owners.push(out.owners);
                }
                let budget = budget.get().map(|b| [b[0], b[2]]);
                Ok(self.conclude_output(&mut record, &solver, t_out, out.time, budget))
            };
            let ran = distributed::run::<S, K, M, D, T, _, _>(
                comm,
                exec,
                &setup,
                &initial,
                stepping,
                &before_step,
                &mut after_step,
                &mut on_output,
            );
            record.dt_range = dt_range.get();
            if let Some((stop, steps)) = stopped.take() {
                record.stop = Some(stop);
                record.steps = steps;
            }
            if let Err(e) = ran {
                // A diverged part stops the run as a single run's step would
                // (the particle is an index on the rank that failed).
                let t = record.outputs.last().map_or(0.0, |d| d.t);
                record.stop = Some(match e {
                    Error::Core(c) => diverged(t, c),
                    Error::Diverged(why) => Stop {
                        t,
                        particle: None,
                        reason: format!("the run diverged: {why}"),
                    },
                    other => return Err(other),
                });
            }
            if comm.rank() == 0 {
                record.neighbours_mean = crate::bench::mean_neighbours(&solver).ok();
            }
            return Ok(record);
        }
        'outputs: for (interval, &(t_out, steps, fixed_dt)) in
            plan.iter().enumerate().skip(first_interval)
        {
            let first = if interval == first_interval {
                first_done
            } else {
                0
            };
            let mut k = first;
            loop {
                // The step: fixed, or `dt_factor` times the current state's
                // smallest limit, shortened to land on the output time (and
                // halved before that rather than leave a sliver).
                let dt = if adaptive {
                    let want = s.physics.dt_factor * solver.limits().min();
                    match adaptive_step(want, t_out - solver.time(), &mut record.dt_range) {
                        Some(dt) => dt,
                        None => break,
                    }
                } else if k < steps {
                    fixed_dt
                } else {
                    break;
                };
                if pause.is_some_and(|p| solver.steps() - steps_before >= p) {
                    record.steps = solver.steps();
                    record.checkpoint =
                        Some(Box::new(capture(&solver, &record, budget, interval, k)));
                    record.state = Some(frame(&solver, solver.time()));
                    return Ok(record);
                }
                if self.ctl.progress.cancelled() {
                    record.stop = Some(Stop {
                        t: solver.time(),
                        particle: None,
                        reason: format!("interrupted at t = {:.6e} s", solver.time()),
                    });
                    record.steps = solver.steps();
                    record.checkpoint =
                        Some(Box::new(capture(&solver, &record, budget, interval, k)));
                    break 'outputs;
                }
                let vmax = solver.max_speed();
                before_step(&mut solver, vmax)?;
                if let Err(e) = solver.step_with(exec, dt) {
                    record.stop = Some(diverged(solver.time(), e));
                    break 'outputs;
                }
                if let Some(b) = budget.as_mut() {
                    *b = integrate_budget(*b, dt, rates(&solver)?);
                }
                if k % 64 == 63 {
                    self.ctl.progress.advance(64);
                }
                if (k + 1) % every == 0 {
                    if let Some(stop) = self.check_cheap(&solver) {
                        record.stop = Some(stop);
                        break 'outputs;
                    }
                }
                if next_checkpoint.is_some_and(|tc| solver.time() >= tc) {
                    record.steps = solver.steps();
                    let ck = capture(&solver, &record, budget, interval, k + 1);
                    (self.ctl.on_checkpoint)(&record, &ck)?;
                    next_checkpoint = next_after(solver.time());
                }
                k += 1;
            }
            self.ctl.progress.advance((k - first) % 64);
            let budget = budget.map(|b| [b[0], b[2]]);
            if self.conclude_output(&mut record, &solver, t_out, solver.time(), budget) {
                break;
            }
        }
        record.steps = solver.steps();
        record.neighbours_mean = crate::bench::mean_neighbours(&solver).ok();
        if pause.is_some() && record.stop.is_none() {
            // Ended: a resumption from here takes no step.
            let ended = capture(&solver, &record, budget, plan.len(), 0);
            record.checkpoint = Some(Box::new(ended));
            record.state = Some(frame(&solver, solver.time()));
        }
        Ok(record)
    }

    /// Records the output at `t_out` of `solver`'s state (reached at
    /// simulated time `t`): its diagnostics, its frame if the scene keeps
    /// particles, and a stop or a steady state; returns whether the run
    /// ends here.
    fn conclude_output<S, K, M, D, T>(
        &self,
        record: &mut RunRecord,
        solver: &Solver<'_, S, K, M, D, T>,
        t_out: f64,
        t: f64,
        budget: Option<[f64; 2]>,
    ) -> bool
    where
        S: Space,
        K: Kernel,
        M: Math<S::Real>,
        D: Term<S>,
        T: Term<S>,
    {
        let s = self.scene;
        let (diag, worst) = self.diagnostics(solver, t_out, budget);
        record.outputs.push(diag);
        if s.keep_particles {
            record.frames.push(frame(solver, t_out));
        }
        if let Some(stop) = self.judge(t, &worst) {
            record.stop = Some(stop);
            return true;
        }
        if let Some(tol) = s.steady_tolerance {
            if steady(&record.outputs, tol, s.length_scale / s.velocity_scale) {
                record.steady = true;
                return true;
            }
        }
        false
    }

    /// Refuses a scene whose estimated memory (particle storage with its
    /// ghosts and lists, plus the particle frames kept at every output
    /// time and a checkpoint's copy) exceeds what is available, before any
    /// of it is allocated.
    fn check_memory<S: Space, K: Kernel>(&self) -> Result<()> {
        let s = self.scene;
        let n = estimate_particles(s) as f64;
        // Ghost slabs: at most two list radii of particles per wall.
        let mut ghosts = 0.0;
        for a in 0..S::DIM {
            if let AxisSpec::Walls(..) = s.axes[a] {
                let slab = ghost_slab(K::SUPPORT, s.physics.beta);
                ghosts += 2.0 * 2.0 * n * slab * s.dx / s.extent[a];
            }
        }
        ghosts += n * s.shaped_walls.len() as f64;
        let width = crate::driver::list_width(S::DIM, K::SUPPORT, s.physics.beta, SKIN) as f64;
        let per = sph_core::solver::bytes_per_particle::<S>() as f64
            + 4.0 * (width + 1.0)
            + std::mem::size_of::<S::Vector>() as f64;
        let storage = (n + ghosts) * per;
        // Frames: position, velocity (3 each), density, pressure as f64.
        let frames = if s.keep_particles {
            s.output_times.len() as f64 * n * 64.0
        } else {
            0.0
        };
        let checkpoint = if self.ctl.checkpoint_every.is_some() || self.ctl.resume.is_some() {
            2.0 * storage + frames
        } else {
            0.0
        };
        crate::resources::check_memory(
            "particles",
            format!("{n} (with {} output times)", s.output_times.len()),
            storage + frames + checkpoint,
        )
    }

    /// The O(N) checks (density and Mach) between output times.
    fn check_cheap<S, K, M, D, T>(&self, solver: &Solver<'_, S, K, M, D, T>) -> Option<Stop>
    where
        S: Space,
        K: Kernel,
        M: Math<S::Real>,
        D: Term<S>,
        T: Term<S>,
    {
        let worst = Worst {
            spacing: None,
            density: max_density_deviation(solver, self.scene.rho0),
            mach: max_mach(solver, self.scene.physics.sound_speed),
        };
        self.judge(solver.time(), &worst)
    }

    /// [`Self::check_cheap`]'s figures over every rank's own particles
    /// (`owned`: slot and id), on every rank: the same values and particle
    /// ids as one solver's.
    fn check_cheap_ranked<S, K, M, D, T>(
        &self,
        comm: &(dyn Comm + Sync),
        solver: &Solver<'_, S, K, M, D, T>,
        owned: &[(usize, usize)],
    ) -> Worst
    where
        S: Space,
        K: Kernel,
        M: Math<S::Real>,
        D: Term<S>,
        T: Term<S>,
    {
        let (rho0, c0) = (self.scene.rho0, self.scene.physics.sound_speed);
        let (rho, v) = (solver.densities(), solver.velocities());
        let density = worst_of(
            owned
                .iter()
                .map(|&(k, id)| (density_deviation(rho[k], rho0), id)),
        );
        let mach = worst_of(owned.iter().map(|&(k, id)| (mach::<S>(v[k], c0), id)));
        let all =
            distributed::all_gather(comm, &[density.0, density.1 as f64, mach.0, mach.1 as f64]);
        Worst {
            spacing: None,
            density: worst_of(all.iter().map(|w| (w[0], w[1] as usize))),
            mach: worst_of(all.iter().map(|w| (w[2], w[3] as usize))),
        }
    }

    fn judge(&self, t: f64, worst: &Worst) -> Option<Stop> {
        let m = self.scene.monitor;
        let (dev, mach) = (worst.density, worst.mach);
        if let Some((r, i)) = worst.spacing {
            if r < m.min_spacing {
                return Some(Stop {
                    t,
                    particle: Some(i),
                    reason: format!(
                        "the state degenerated at t = {t:.6e} s: particle {i} is {r:.3} dx from its closest neighbour (monitor.min_spacing = {})",
                        m.min_spacing
                    ),
                });
            }
        }
        if dev.0 > m.max_density_deviation {
            return Some(Stop {
                t,
                particle: Some(dev.1),
                reason: format!(
                    "the state degenerated at t = {t:.6e} s: particle {} has |rho/rho0 - 1| = {:.3e} (monitor.max_density_deviation = {})",
                    dev.1, dev.0, m.max_density_deviation
                ),
            });
        }
        if mach.0 > m.max_mach {
            return Some(Stop {
                t,
                particle: Some(mach.1),
                reason: format!(
                    "the state degenerated at t = {t:.6e} s: particle {} moves at Mach {:.3} (monitor.max_mach = {})",
                    mach.1, mach.0, m.max_mach
                ),
            });
        }
        None
    }

    /// The diagnostics at an output time, and the particles at which the
    /// monitor's quantities are worst.
    fn diagnostics<S, K, M, D, T>(
        &self,
        solver: &Solver<'_, S, K, M, D, T>,
        t: f64,
        budget: Option<[f64; 2]>,
    ) -> (Diagnostics, Worst)
    where
        S: Space,
        K: Kernel,
        M: Math<S::Real>,
        D: Term<S>,
        T: Term<S>,
    {
        let s = self.scene;
        let domain = solver.domain();
        let mut ke = 0.0;
        let mut ke_exact = 0.0;
        let mut linf = 0.0f64;
        let mut sq = 0.0;
        let scale = s.velocity_scale * libm::exp(s.error_decay * t);
        for (k, (x, v)) in solver
            .positions()
            .iter()
            .zip(solver.velocities())
            .enumerate()
        {
            let m = solver.masses()[k].to_f64();
            let v = vec3::<S>(*v);
            ke += 0.5 * m * norm(v).powi(2);
            if let Some(exact) = &s.exact {
                let p = to3::<S>(domain.to_global(domain.wrap::<M>(*x)));
                let ve = exact(p, t);
                ke_exact += 0.5 * m * norm(ve).powi(2);
                let e = norm([v[0] - ve[0], v[1] - ve[1], v[2] - ve[2]]) / scale;
                linf = linf.max(e);
                sq += e * e;
            }
        }
        let n = solver.n_fluid().max(1) as f64;
        let worst = Worst {
            spacing: solver.closest_fluid_pair().map(|(i, _, r)| (r / s.dx, i)),
            density: max_density_deviation(solver, s.rho0),
            mach: max_mach(solver, s.physics.sound_speed),
        };
        let energy = budget.map(|[dissipated, periodic]| {
            // The body force along bounded axes, at its ramped strength.
            let k = ramp_factor(t, s.physics.gravity_ramp);
            let g: [f64; 3] = std::array::from_fn(|a| match s.axes[a] {
                AxisSpec::Walls(..) => k * s.body_force[a],
                AxisSpec::Periodic => 0.0,
            });
            let eos = solver.params().eos;
            let (mut potential, mut internal) = (periodic, 0.0);
            for (k, x) in solver.positions().iter().enumerate() {
                let m = solver.masses()[k].to_f64();
                let p = to3::<S>(domain.to_global(domain.wrap::<M>(*x)));
                let height: f64 = (0..3).map(|a| g[a] * (p[a] - s.origin[a])).sum();
                potential -= m * height;
                internal += m * eos.internal_energy(solver.densities()[k].to_f64());
            }
            Energy {
                kinetic_energy: ke,
                potential_energy: potential,
                internal_energy: internal,
                dissipated_energy: dissipated,
                total_energy: ke + potential + internal + dissipated,
            }
        });
        let diag = Diagnostics {
            t,
            energy,
            kinetic_energy: ke,
            kinetic_energy_exact: s.exact.as_ref().map(|_| ke_exact),
            min_spacing: worst.spacing.map_or(f64::INFINITY, |(r, _)| r),
            max_density_deviation: worst.density.0,
            max_mach: worst.mach.0,
            linf: s.exact.as_ref().map(|_| linf),
            l2: s.exact.as_ref().map(|_| (sq / n).sqrt()),
        };
        (diag, worst)
    }
}

/// The rate `sum m (v . a + P / rho^2 Drho)` at which the terms `terms`
/// (the dissipative part of the force group) change the mechanical and
/// internal energy, over the fluid particles at `slots`, on the solver's
/// current state; each particle's share is computed in parallel, their sum
/// is exact (the same bits for any thread count or split over ranks).
fn dissipation_power<S, K, M, D, T, X, E>(
    solver: &Solver<'_, S, K, M, D, T>,
    terms: &X,
    exec: &E,
    slots: &[usize],
) -> Result<ExactSum>
where
    S: Space,
    K: Kernel,
    M: Math<S::Real>,
    D: Term<S>,
    T: Term<S>,
    X: Term<S>,
    E: Executor,
{
    let mut share = vec![0.0; slots.len()];
    exec.run(&mut share[..], &|start, out: &mut [f64]| {
        let (mut dv, mut drho) = ([S::Vector::zero()], [S::Real::ZERO]);
        for (k, o) in out.iter_mut().enumerate() {
            let i = slots[start + k];
            solver.rates_range_of(terms, i, &mut dv, &mut drho)?;
            let rho = solver.densities()[i].to_f64();
            let p = solver.pressures()[i].to_f64();
            let work = solver.velocities()[i].dot(dv[0]).to_f64();
            *o = solver.masses()[i].to_f64() * (work + p / (rho * rho) * drho[0].to_f64());
        }
        Ok(())
    })?;
    let mut sum = ExactSum::new();
    for x in share {
        sum.add(x);
    }
    Ok(sum)
}

/// The energy budget `[dissipated, power, potential, body]` after a step of
/// `dt` whose end has the rates `[power, body]`: both integrals advanced by
/// the trapezoidal rule, the rates kept for the next step.
fn integrate_budget(b: [f64; 4], dt: f64, [p, w]: [f64; 2]) -> [f64; 4] {
    let [dissipated, power, potential, body] = b;
    [
        dissipated - 0.5 * dt * (power + p),
        p,
        potential - 0.5 * dt * (body + w),
        w,
    ]
}

/// The adaptive step towards an output `remaining` seconds ahead when the
/// state allows `want`: `want`, shortened to land on the output (and halved
/// before that rather than leave a sliver), or `None` once the output is
/// reached; `range` keeps the smallest and largest `want` seen.
fn adaptive_step(want: f64, remaining: f64, range: &mut Option<[f64; 2]>) -> Option<f64> {
    if remaining <= 1e-6 * want {
        return None;
    }
    let [lo, hi] = range.unwrap_or([want, want]);
    *range = Some([lo.min(want), hi.max(want)]);
    Some(if remaining <= want {
        remaining
    } else if remaining < 2.0 * want {
        0.5 * remaining
    } else {
        want
    })
}

/// The largest of `(value, id)` pairs, in any order of ids: a NaN wins
/// (the one of largest id), else the largest value (the smallest id), else
/// `(0, 0)`. Over ids in increasing order this is a scan that keeps a value
/// only if it is larger or NaN.
fn worst_of(pairs: impl Iterator<Item = (f64, usize)>) -> (f64, usize) {
    let mut best = (0.0f64, 0usize);
    for (x, i) in pairs {
        let better = if x.is_nan() {
            !best.0.is_nan() || i > best.1
        } else {
            !best.0.is_nan() && (x > best.0 || (x == best.0 && x > 0.0 && i < best.1))
        };
        if better {
            best = (x, i);
        }
    }
    best
}

/// Outputs averaged in each window of the steady-state test.
pub const STEADY_WINDOW: usize = 5;

/// Whether the kinetic energy has settled: the means over the last two
/// windows of [`STEADY_WINDOW`] outputs differ by less than `tol` relative,
/// per `time_scale` of time between the windows' centres. Windows average
/// out the particle-scale fluctuation of the kinetic energy.
pub fn steady(outputs: &[Diagnostics], tol: f64, time_scale: f64) -> bool {
    let w = STEADY_WINDOW;
    if outputs.len() < 2 * w {
        return false;
    }
    let mean = |d: &[Diagnostics]| {
        (
            d.iter().map(|o| o.kinetic_energy).sum::<f64>() / w as f64,
            d.iter().map(|o| o.t).sum::<f64>() / w as f64,
        )
    };
    let k = outputs.len();
    let (e1, t1) = mean(&outputs[k - w..]);
    let (e0, t0) = mean(&outputs[k - 2 * w..k - w]);
    let rate = (e1 - e0).abs() / e1.max(f64::MIN_POSITIVE) / (t1 - t0) * time_scale;
    rate < tol
}

/// The monitor's quantities at their worst: `(value, particle)`; the
/// closest pair in units of dx (`None` between outputs, or with no pair
/// within the support).
struct Worst {
    spacing: Option<(f64, usize)>,
    density: (f64, usize),
    mach: (f64, usize),
}

/// The largest value and its index (a NaN counts as largest).
fn worst(values: impl Iterator<Item = f64>) -> (f64, usize) {
    worst_of(values.enumerate().map(|(i, x)| (x, i)))
}

fn max_density_deviation<S, K, M, D, T>(
    solver: &Solver<'_, S, K, M, D, T>,
    rho0: f64,
) -> (f64, usize)
where
    S: Space,
    K: Kernel,
    M: Math<S::Real>,
    D: Term<S>,
    T: Term<S>,
{
    worst(
        solver
            .densities()
            .iter()
            .map(|r| density_deviation(*r, rho0)),
    )
}

/// `|rho / rho0 - 1|`, the monitor's density figure of one particle.
fn density_deviation<R: Real>(rho: R, rho0: f64) -> f64 {
    (rho.to_f64() / rho0 - 1.0).abs()
}

/// `|v| / c0`, the monitor's Mach number of one particle.
fn mach<S: Space>(v: S::Vector, c0: f64) -> f64 {
    v.norm2().to_f64().sqrt() / c0
}

fn max_mach<S, K, M, D, T>(solver: &Solver<'_, S, K, M, D, T>, c0: f64) -> (f64, usize)
where
    S: Space,
    K: Kernel,
    M: Math<S::Real>,
    D: Term<S>,
    T: Term<S>,
{
    worst(solver.velocities().iter().map(|v| mach::<S>(*v, c0)))
}

fn frame<S, K, M, D, T>(solver: &Solver<'_, S, K, M, D, T>, t: f64) -> Frame
where
    S: Space,
    K: Kernel,
    M: Math<S::Real>,
    D: Term<S>,
    T: Term<S>,
{
    let domain = solver.domain();
    Frame {
        t,
        x: solver
            .positions()
            .iter()
            .map(|x| to3::<S>(domain.to_global(domain.wrap::<M>(*x))))
            .collect(),
        v: solver.velocities().iter().map(|v| vec3::<S>(*v)).collect(),
        rho: solver.densities().iter().map(|r| r.to_f64()).collect(),
        p: solver.pressures().iter().map(|p| p.to_f64()).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every case at its default resolution splits its fluid into at least
    /// one piece per thread, whatever part of its box the fluid fills.
    #[test]
    fn passes_split_the_fluid_not_the_box() {
        for case in crate::cases::CASES.iter().filter(|c| c.name != "custom") {
            let scene = crate::cases::scene(&(case.defaults)()).unwrap();
            let n = lattice(&scene).len();
            for threads in [2, 4] {
                let chunk = min_chunk(&scene, threads);
                assert!(
                    chunk == 64 || n / chunk >= threads,
                    "{}: {n} particles in pieces of {chunk} on {threads} threads",
                    case.name
                );
            }
        }
    }
}
