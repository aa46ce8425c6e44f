//! Standard benchmark scenes for `sph bench`.
//!
//! - `box2d`: a 2D periodic box of weakly compressible fluid in f64: a square
//!   lattice perturbed by up to 0.05 dx with a small random velocity field
//!   (fixed seed); summation density, linear EOS, pressure gradient and
//!   Morris viscosity; cubic spline with `h = 1.3 dx` (support 2.6 dx, about
//!   21 neighbours per particle including itself).
//! - `box3d`: the same in 3D (cubic, `h = 1.2 dx`, about 57 neighbours).
//! - `couette`: the Couette validation scene (walls by ghosts).
//!
//! - any built-in case or scene file ([`run_case`]): the scene as `sph run`
//!   steps it, through the scene layer (its terms, walls, adaptive step,
//!   monitor and energy budget), so a term's cost is the difference between
//!   two runs that differ in it.
//!
//! The box is timed after an untimed warm-up that disorders the lattice: on a
//! fresh lattice the branch predictor learns the neighbour pattern and
//! flatters branchy code.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use crate::math::Host;
use serde::Serialize;
use sph_core::exec::{Executor, Serial};
use sph_core::kernel::CubicSpline;
use sph_core::prelude::{
    Continuity, Domain, Eos, MorrisViscosity, Params, PressureGradient, Side, Solver, Space,
    SummationDensity, Term, Vector, VectorOps, Wall, D2, D3,
};

use crate::cases::Settings;
use crate::config::DensityMode;
use crate::couette::Progress;
use crate::driver::{Buffers, Rayon};
use crate::error::{Error, Result};

/// Which scene to time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Scene {
    /// 2D periodic box.
    Box2d,
    /// 3D periodic box.
    Box3d,
    /// Couette channel with mirrored walls.
    Couette,
}

impl Scene {
    /// Parses a scene name.
    ///
    /// # Errors
    /// A message listing the accepted names.
    pub fn parse(s: &str) -> std::result::Result<Self, String> {
        match s {
            "box2d" => Ok(Scene::Box2d),
            "box3d" => Ok(Scene::Box3d),
            "couette" => Ok(Scene::Couette),
            _ => Err("expected one of box2d, box3d, couette".into()),
        }
    }

    /// The scene's name.
    pub fn name(self) -> &'static str {
        match self {
            Scene::Box2d => "box2d",
            Scene::Box3d => "box3d",
            Scene::Couette => "couette",
        }
    }
}

/// The physics configuration a box scene is timed in.
///
/// Both presets keep the kernel (cubic spline), its support and `beta`, so
/// the neighbour count is the same: a preset changes how much work each
/// pair costs, not how many pairs there are.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Preset {
    /// f64, summation density (a density pass, then a force pass), cubic
    /// spline, symmetric pressure gradient, Morris viscosity: the
    /// configuration of the validation cases.
    #[default]
    Default,
    /// f64, continuity density (the density rate joins the force pass: one
    /// neighbour pass per step), cubic spline, symmetric pressure gradient,
    /// Morris viscosity, no density diffusion: the configuration a user
    /// would pick for speed. Measured (ARCHITECTURE.md), it runs 10-30 %
    /// faster than the default in most sittings, not twice as fast: most of
    /// the density pass it saves is spent again in the force pass, which
    /// must test every list entry against the support (summation density's
    /// pass sorts each row's entries inside the support to the front, so
    /// its force pass skips that test).
    Fast,
}

impl Preset {
    /// Parses a preset name.
    ///
    /// # Errors
    /// A message listing the accepted names.
    pub fn parse(s: &str) -> std::result::Result<Self, String> {
        match s {
            "default" => Ok(Preset::Default),
            "fast" => Ok(Preset::Fast),
            _ => Err("expected one of default, fast".into()),
        }
    }

    /// The preset's name.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Default => "default",
            Preset::Fast => "fast",
        }
    }
}

/// What to run.
#[derive(Clone, Copy, Debug)]
pub struct BenchConfig {
    /// Scene.
    pub scene: Scene,
    /// Physics configuration of the box scenes (the Couette scene always
    /// runs the default).
    pub preset: Preset,
    /// Approximate number of fluid particles (rounded to a lattice).
    pub n: usize,
    /// Threads (1 = serial executor, no rayon).
    pub threads: usize,
    /// Timed steps.
    pub steps: usize,
    /// Untimed warm-up steps.
    pub warmup: usize,
    /// Reorder particles by cell every this many cell-list builds (0: never).
    pub reorder_every: u32,
    /// Use Verlet neighbour lists (else scan cells in every pass).
    pub lists: bool,
    /// Verlet skin as a fraction of the support radius.
    pub skin: f64,
    /// Start from a random particle order instead of the lattice's row order
    /// (the case cell reordering is for).
    pub shuffle: bool,
}

impl Default for BenchConfig {
    /// What `sph bench` runs without flags: the 2D box of 40,000 particles,
    /// default preset, one thread, 100 timed steps after 300, reordered at
    /// every list build, Verlet lists with a skin of 0.1, lattice order.
    fn default() -> Self {
        BenchConfig {
            scene: Scene::Box2d,
            preset: Preset::Default,
            n: 40_000,
            threads: 1,
            steps: 100,
            warmup: 300,
            reorder_every: 1,
            lists: true,
            skin: 0.1,
            shuffle: false,
        }
    }
}

/// What a benchmark measured.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// Scene name.
    pub scene: &'static str,
    /// Preset name (`default` for case scenes, which run their own settings).
    pub preset: &'static str,
    /// Floating-point precision of the state and the pair arithmetic.
    pub precision: &'static str,
    /// Density mode.
    pub density: &'static str,
    /// Smoothing kernel.
    pub kernel: &'static str,
    /// Fluid particles.
    pub n: usize,
    /// Threads.
    pub threads: usize,
    /// Timed steps.
    pub steps: usize,
    /// Mean neighbours per fluid particle (itself included), counted after the warm-up.
    pub neighbours_mean: f64,
    /// Wall seconds of the timed steps.
    pub seconds: f64,
    /// Particle-steps per second.
    pub particle_steps_per_s: f64,
    /// Pair interactions per second (each pass counts its pairs).
    pub pairs_per_s: f64,
    /// Nanoseconds per pair interaction.
    pub ns_per_pair: f64,
    /// Bytes of solver storage per particle slot.
    pub bytes_per_particle: f64,
    /// Neighbour passes per step (density and forces).
    pub passes_per_step: usize,
}

/// Deterministic xorshift generator, uniform in `[-1, 1)`.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// Runs a benchmark.
///
/// # Errors
/// [`Error::Config`] for a bad size or thread count; core errors if the scene diverges.
pub fn run(cfg: &BenchConfig) -> Result<BenchReport> {
    validate(cfg)?;
    if cfg.threads == 1 {
        return dispatch(cfg, &Serial);
    }
    let threads = crate::driver::resolve_threads(cfg.threads);
    let pool = crate::driver::thread_pool(threads)?;
    let min_chunk = (cfg.n / (8 * threads)).max(256);
    let mut report = pool.install(|| dispatch(cfg, &Rayon { min_chunk }))?;
    report.threads = threads;
    Ok(report)
}

/// The largest particle count with neighbour lists: their entries keep a
/// particle index in 26 bits (ghosts need slots too).
const MAX_LISTED: usize = 60_000_000;

/// Checks a configuration before anything is allocated: the skin, the
/// particle count against what the scene needs (a periodic box at least
/// two list radii across) and against the list index, the step count, and
/// the estimated memory against what is available.
fn validate(cfg: &BenchConfig) -> Result<()> {
    if !(cfg.skin.is_finite() && (0.0..=1.0).contains(&cfg.skin)) {
        return Err(Error::config(
            "skin",
            cfg.skin,
            "must be between 0 and 1 (a fraction of the support radius)",
        ));
    }
    if cfg.steps == 0 {
        return Err(Error::config("steps", cfg.steps, "must be at least 1"));
    }
    let skin = if cfg.lists { cfg.skin } else { 0.0 };
    let (dim, beta) = match cfg.scene {
        Scene::Box2d | Scene::Couette => (2, 1.3),
        Scene::Box3d => (3, 1.2),
    };
    // A periodic side of `side` particles holds two list radii (2 h each).
    let min_side = (4.0 * beta * (1.0 + skin)).ceil() as usize;
    let (min_n, side) = match cfg.scene {
        Scene::Couette => (16, usize::MAX),
        _ => (
            min_side.pow(dim as u32),
            (cfg.n as f64).powf(1.0 / dim as f64).round() as usize,
        ),
    };
    let max_n = if cfg.lists { MAX_LISTED } else { 100_000_000 };
    if cfg.n < min_n || side < min_side || cfg.n > max_n {
        return Err(Error::config(
            "n",
            cfg.n,
            format!(
                "must be between {min_n} and {max_n} particles for the {} scene{}",
                cfg.scene.name(),
                if cfg.lists {
                    format!(" with neighbour lists of skin {}", cfg.skin)
                } else {
                    String::new()
                }
            ),
        ));
    }
    let width = if cfg.lists {
        crate::driver::list_width(dim, 2.0, beta, skin) + 1
    } else {
        0
    };
    let per = if dim == 2 {
        sph_core::solver::bytes_per_particle::<D2<f64>>()
    } else {
        sph_core::solver::bytes_per_particle::<D3<f64>>()
    } + 4 * width;
    // Ghosts, cells and the positions copied for the neighbour count: 1.5x.
    crate::resources::check_memory("n", cfg.n, 1.5 * (cfg.n * per) as f64)
}

fn dispatch<E: Executor>(cfg: &BenchConfig, exec: &E) -> Result<BenchReport> {
    match cfg.scene {
        Scene::Box2d => periodic_box::<D2<f64>, E>(cfg, exec, 1.3),
        Scene::Box3d => periodic_box::<D3<f64>, E>(cfg, exec, 1.2),
        Scene::Couette => couette(cfg, exec),
    }
}

/// Mean neighbours (itself included, fluid, ghosts and wall particles
/// counted) of a fluid particle at the solver's state, within the support
/// radius, counted once over a fresh cell list.
pub(crate) fn mean_neighbours<S, K, M, D, T>(solver: &Solver<'_, S, K, M, D, T>) -> Result<f64>
where
    S: Space,
    K: sph_core::kernel::Kernel,
    M: sph_core::math::Math<S::Real>,
    D: Term<S>,
    T: Term<S>,
{
    let domain = solver.domain();
    // Between list rebuilds positions may lie just outside a periodic side: wrap them.
    let mut all: Vec<S::Vector> = solver
        .positions()
        .iter()
        .map(|x| domain.wrap::<M>(*x))
        .collect();
    let n = all.len();
    all.extend_from_slice(solver.ghost_positions());
    let radius = solver.kernel().radius();
    let reach = radius * (<S::Real as sph_core::real::Real>::ONE + solver.params().skin);
    // The grid spans the ghosts, which reach as far as the Verlet lists do
    // (`reach`, at least `radius`); only pairs within `radius` count.
    let reach = if reach > radius { reach } else { radius };
    let grid = sph_core::neighbour::Grid::new(domain, reach)?;
    let r2 = radius * radius;
    let mut start = vec![0u32; grid.cell_count() + 1];
    let mut sorted = vec![0u32; all.len()];
    let mut cell = vec![0u32; all.len()];
    let mut list = sph_core::neighbour::CellList::new(&mut start, &mut sorted, &mut cell);
    list.build(&grid, &all)?;
    let view = list.view();
    let mut pairs = 0usize;
    for i in 0..n {
        view.for_each_neighbour(&grid, &all, i, |_, _, d2| {
            if d2 < r2 {
                pairs += 1;
            }
        })?;
    }
    Ok(pairs as f64 / n.max(1) as f64)
}

fn timed<S, E, D, T>(
    cfg: &BenchConfig,
    exec: &E,
    solver: &mut Solver<'_, S, CubicSpline, Host, D, T>,
    bytes_per_particle: f64,
) -> Result<BenchReport>
where
    S: Space<Real = f64>,
    E: Executor,
    D: Term<S>,
    T: Term<S>,
    Host: sph_core::math::Math<S::Real>,
{
    let dt = 0.5 * solver.limits().min();
    for _ in 0..cfg.warmup {
        solver.step_with(exec, dt)?;
    }
    let n = solver.n_fluid();
    let neighbours_mean = mean_neighbours(solver)?;
    let start = Instant::now();
    for _ in 0..cfg.steps {
        solver.step_with(exec, dt)?;
    }
    let seconds = start.elapsed().as_secs_f64();
    let passes = usize::from(!D::EMPTY) + usize::from(!T::EMPTY);
    let particle_steps = (n * cfg.steps) as f64;
    let pairs = particle_steps * neighbours_mean * passes as f64;
    Ok(BenchReport {
        scene: cfg.scene.name(),
        preset: cfg.preset.name(),
        precision: "f64",
        density: if D::EMPTY { "continuity" } else { "summation" },
        kernel: "cubic",
        n,
        threads: 1,
        steps: cfg.steps,
        neighbours_mean,
        seconds,
        particle_steps_per_s: particle_steps / seconds,
        pairs_per_s: pairs / seconds,
        ns_per_pair: seconds * 1e9 / pairs,
        bytes_per_particle,
        passes_per_step: passes,
    })
}

/// A box of weakly compressible fluid ready to hand to a solver: the
/// standard benchmark scene (see the module docs), periodic along every axis,
/// or with no-slip walls across the second axis (the upper one sliding) when
/// `walls` is set.
#[derive(Debug)]
pub struct BoxScene<S: Space> {
    /// The domain.
    pub domain: Domain<S>,
    /// Buffers holding the fluid particles (and room for ghosts with walls).
    pub buffers: Buffers<S>,
    /// Fluid particles.
    pub n: usize,
    /// Smoothing length.
    pub h: f64,
    /// Parameters (linear EOS with c0 = 10, background pressure with walls,
    /// skin and reordering as asked).
    pub params: Params<f64>,
}

/// Options of [`box_scene`].
#[derive(Clone, Copy, Debug)]
pub struct BoxOptions {
    /// `h / dx`.
    pub beta: f64,
    /// Verlet lists with this skin, or `None` to scan cells.
    pub skin: Option<f64>,
    /// Reorder particles by cell every this many builds.
    pub reorder_every: u32,
    /// Walls across the second axis instead of periodicity.
    pub walls: bool,
    /// Random initial particle order.
    pub shuffle: bool,
}

/// The forces of the benchmark scenes: pressure and Morris viscosity.
pub type BoxForces = (PressureGradient, MorrisViscosity<f64>);

/// Builds the benchmark box with about `n` particles (rounded to a lattice).
///
/// # Errors
/// Core errors for an impossible size.
pub fn box_scene<S>(n: usize, options: BoxOptions) -> Result<BoxScene<S>>
where
    S: Space<Real = f64>,
    Host: sph_core::math::Math<S::Real>,
{
    let d = S::DIM;
    let side = (n as f64).powf(1.0 / d as f64).round().max(4.0) as usize;
    let n = side.pow(d as u32);
    let dx = 1.0 / side as f64;
    let h = options.beta * dx;
    let mut domain = Domain::<S>::new(S::Global::zero(), S::Vector::splat(1.0))?;
    for a in 0..d {
        if options.walls && a == 1 {
            let mut u = S::Vector::zero();
            u[0] = 0.1;
            domain = domain
                .with_wall(a, Side::Lower, Wall::no_slip())?
                .with_wall(a, Side::Upper, Wall::moving(u))?;
        } else {
            domain = domain.with_periodic(a)?;
        }
    }
    let cells =
        Solver::<S, CubicSpline, Host, SummationDensity, BoxForces>::cells_needed(&domain, h)?;
    let skin = options.skin.unwrap_or(0.0);
    let spare = if options.walls {
        2 * n / side * ((2.0 * options.beta * (1.0 + skin)).ceil() as usize + 1)
    } else {
        0
    };
    let mut b = Buffers::<S>::new(n + spare, cells);
    if let Some(skin) = options.skin {
        b = b.with_lists(n, crate::driver::list_width(d, 2.0, options.beta, skin));
    }
    let mut rng = Rng(0x5eed_1234_abcd_0001);
    let (c0, rho0) = (10.0, 1.0);
    // Mirrored walls hold particles back by pressure alone: where a random
    // velocity field rarefies the fluid (P < 0) a particle's own ghost pulls it
    // through the wall (physics.md 3.5, 8.6). With walls the field is gentler
    // and a background pressure keeps P positive.
    let (amplitude, p0) = if options.walls {
        (0.02 * c0, 0.1 * rho0 * c0 * c0)
    } else {
        (0.05 * c0, 0.0)
    };
    for k in 0..n {
        let mut rest = k;
        let mut x = S::Vector::zero();
        let mut v = S::Vector::zero();
        for a in 0..d {
            let i = rest % side;
            rest /= side;
            x[a] = ((i as f64 + 0.5) + 0.05 * rng.next()) * dx;
            v[a] = amplitude * rng.next();
        }
        b.x[k] = x;
        b.v[k] = v;
        b.m[k] = rho0 * dx.powi(d as i32);
        b.rho[k] = rho0;
    }
    if options.shuffle {
        // Fisher-Yates with the same generator: a fixed random order.
        for k in (1..n).rev() {
            let r = ((rng.next() + 1.0) * 0.5 * (k + 1) as f64) as usize % (k + 1);
            b.x.swap(k, r);
            b.v.swap(k, r);
        }
    }
    let params = Params::new(h, Eos::Linear { rho0, c0, p0 })
        .with_reorder_every(options.reorder_every)
        .with_skin(skin);
    Ok(BoxScene {
        domain,
        buffers: b,
        n,
        h,
        params,
    })
}

/// The forces of [`box_scene`].
pub fn box_forces() -> BoxForces {
    (PressureGradient, MorrisViscosity { mu: 1e-3 })
}

/// The solver type of a [`BoxScene`].
pub type BoxSolver<'a, S> = Solver<'a, S, CubicSpline, Host, SummationDensity, BoxForces>;

impl<S> BoxScene<S>
where
    S: Space<Real = f64>,
    Host: sph_core::math::Math<S::Real>,
{
    /// A solver over the scene's buffers, set up through `exec`.
    ///
    /// # Errors
    /// Core errors from the set-up.
    pub fn solver<E: Executor>(&mut self, exec: &E) -> Result<BoxSolver<'_, S>> {
        self.solver_with(exec, SummationDensity, box_forces())
    }

    /// A solver over the scene's buffers with other density and force
    /// groups (continuity density puts `Continuity` in the force group and
    /// `()` as the density group).
    ///
    /// # Errors
    /// Core errors from the set-up.
    pub fn solver_with<E: Executor, D: Term<S>, T: Term<S>>(
        &mut self,
        exec: &E,
        density: D,
        forces: T,
    ) -> Result<Solver<'_, S, CubicSpline, Host, D, T>> {
        Ok(Solver::new_with(
            exec,
            self.params,
            self.domain,
            self.buffers.storage(),
            self.n,
            density,
            forces,
        )?)
    }
}

fn periodic_box<S, E>(cfg: &BenchConfig, exec: &E, beta: f64) -> Result<BenchReport>
where
    S: Space<Real = f64>,
    E: Executor,
    Host: sph_core::math::Math<S::Real>,
{
    let options = BoxOptions {
        beta,
        skin: cfg.lists.then_some(cfg.skin),
        reorder_every: cfg.reorder_every,
        walls: false,
        shuffle: cfg.shuffle,
    };
    let mut scene = box_scene::<S>(cfg.n, options)?;
    let bytes = scene.buffers.bytes() as f64 / scene.n as f64;
    match cfg.preset {
        Preset::Default => {
            let mut solver = scene.solver(exec)?;
            timed(cfg, exec, &mut solver, bytes)
        }
        Preset::Fast => {
            let (pressure, viscosity) = box_forces();
            let mut solver = scene.solver_with(exec, (), (Continuity, pressure, viscosity))?;
            timed(cfg, exec, &mut solver, bytes)
        }
    }
}

fn couette<E: Executor>(cfg: &BenchConfig, exec: &E) -> Result<BenchReport> {
    // Keep the Couette aspect ratio of the validation case: a strip 6 dx wide per 40 across.
    let across = ((cfg.n as f64 / 0.15).sqrt().round() as usize).max(8);
    // The periodic strip holds two list radii (2 h (1 + skin) each).
    let min_nx = (5.2 * (1.0 + cfg.skin)).ceil() as usize + 1;
    let nx = (across * 6).div_ceil(40).max(min_nx);
    let n = across * nx;
    let (gap, u, nu, rho0) = (1e-3, 1.25e-5, 1e-6, 1e3);
    let dx = gap / across as f64;
    let h = 1.3 * dx;
    let domain = Domain::<D2<f64>>::new(
        Vector::new([0.0, -0.5 * gap]),
        Vector::new([nx as f64 * dx, gap]),
    )?
    .with_periodic(0)?
    .with_wall(1, Side::Lower, Wall::no_slip())?
    .with_wall(1, Side::Upper, Wall::moving(Vector::new([u, 0.0])))?;
    let cells = Solver::<D2<f64>, CubicSpline, Host, SummationDensity, BoxForces>::cells_needed(
        &domain, h,
    )?;
    // Ghost rows within the list radius of each wall, plus one.
    let rows = (2.6 * (1.0 + cfg.skin)).ceil() as usize + 1;
    let cap = n + 2 * rows * nx;
    let mut b = Buffers::<D2<f64>>::new(cap, cells);
    if cfg.lists {
        b = b.with_lists(n, crate::driver::list_width(2, 2.0, 1.3, cfg.skin));
    }
    for j in 0..across {
        for i in 0..nx {
            b.x[j * nx + i] = Vector::new([(i as f64 + 0.5) * dx, (j as f64 + 0.5) * dx]);
            b.m[j * nx + i] = 1.0;
        }
    }
    let bytes = b.bytes() as f64 / cap as f64;
    let params = Params::new(
        h,
        Eos::Linear {
            rho0,
            c0: 10.0 * u,
            p0: 0.0,
        },
    )
    .with_reorder_every(cfg.reorder_every)
    .with_skin(cfg.skin);
    let forces = (PressureGradient, MorrisViscosity { mu: nu * rho0 });
    let mut solver = Solver::<D2<f64>, CubicSpline, Host, _, _>::new_with(
        exec,
        params,
        domain,
        b.storage(),
        n,
        SummationDensity,
        forces,
    )?;
    solver.calibrate_mass_with(exec, rho0)?;
    timed(cfg, exec, &mut solver, bytes)
}

/// One row of a size sweep.
#[derive(Clone, Debug, Serialize)]
pub struct SweepRow {
    /// The benchmark at this size.
    pub report: BenchReport,
    /// Wall seconds per step.
    pub seconds_per_step: f64,
}

/// Times `base` at each size in `sizes` (timed steps chosen so each size takes
/// a few seconds) and fits the log-log slope of time per step against N.
///
/// # Errors
/// As [`run`].
pub fn sweep(base: &BenchConfig, sizes: &[usize]) -> Result<(Vec<SweepRow>, f64)> {
    let mut distinct = sizes.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    if distinct.len() < 2 {
        return Err(Error::config(
            "sizes",
            format!("{sizes:?}"),
            "a sweep fits a slope: give at least two different sizes",
        ));
    }
    for &n in sizes {
        validate(&BenchConfig { n, ..*base })?;
    }
    let mut rows = Vec::with_capacity(sizes.len());
    for &n in sizes {
        let steps = (4.0e6 / n as f64).clamp(5.0, 2000.0) as usize;
        let report = run(&BenchConfig { n, steps, ..*base })?;
        let seconds_per_step = report.seconds / report.steps as f64;
        rows.push(SweepRow {
            report,
            seconds_per_step,
        });
    }
    Ok((
        rows.clone(),
        loglog_slope(
            &rows
                .iter()
                .map(|r| (r.report.n as f64, r.seconds_per_step))
                .collect::<Vec<_>>(),
        ),
    ))
}

/// Least-squares slope of `ln y` against `ln x`.
pub fn loglog_slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0);
    for &(x, y) in points {
        let (lx, ly) = (x.ln(), y.ln());
        sx += lx;
        sy += ly;
        sxx += lx * lx;
        sxy += lx * ly;
    }
    (n * sxy - sx * sy) / (n * sxx - sx * sx)
}

/// What [`run_case`] times.
#[derive(Clone, Debug)]
pub struct CaseBench {
    /// The scene's settings (a built-in case's defaults, a scene file, and
    /// any overrides; `threads` is the thread count timed).
    pub settings: Settings,
    /// Approximate fluid particles: the resolution is scaled from the
    /// settings' to reach it (`None`: the settings' resolution).
    pub n: Option<usize>,
    /// Timed steps.
    pub steps: usize,
    /// Untimed steps before them, from the scene's initial state.
    pub warmup: usize,
}

/// Counts the steps of a scene run (the scene layer asks
/// [`Progress::cancelled`] once before each step), starts the clock before
/// step `warmup + 1` and stops the run before step `warmup + steps + 1`.
struct Stopwatch {
    calls: AtomicU64,
    warmup: u64,
    steps: u64,
    start: Mutex<Option<Instant>>,
    end: Mutex<Option<Instant>>,
}

impl Stopwatch {
    fn mark(slot: &Mutex<Option<Instant>>) {
        if let Ok(mut t) = slot.lock() {
            *t = Some(Instant::now());
        }
    }

    fn read(slot: &Mutex<Option<Instant>>) -> Option<Instant> {
        slot.lock().ok().and_then(|t| *t)
    }
}

impl Progress for Stopwatch {
    fn start(&self, _total: u64) {}
    fn advance(&self, _steps: u64) {}
    fn finish(&self) {}
    fn cancelled(&self) -> bool {
        if crate::progress::stop_flag().load(Ordering::Relaxed) {
            return true;
        }
        let k = self.calls.fetch_add(1, Ordering::SeqCst);
        if k == self.warmup {
            Self::mark(&self.start);
        }
        if k == self.warmup + self.steps {
            Self::mark(&self.end);
        }
        k >= self.warmup + self.steps
    }
}

/// The resolution that gives about `n` fluid particles, scaled from the
/// settings' own (fluid particles grow as resolution^dim).
fn resolution_for(settings: &Settings, n: usize) -> Result<usize> {
    let scene = crate::cases::scene(settings)?;
    let n0 = crate::scene::lattice(&scene).len();
    if n0 == 0 || n == 0 {
        return Err(Error::config(
            "n",
            n,
            "must be a positive particle count (the scene must hold fluid)",
        ));
    }
    let scale = (n as f64 / n0 as f64).powf(1.0 / settings.dim as f64);
    Ok(((settings.resolution as f64 * scale).round() as usize).max(1))
}

/// Times a scene as `sph run` steps it: `warmup` untimed steps from its
/// initial state, then `steps` timed ones, everything the scene layer does
/// per step included (wall particles, the adaptive step, the monitor, the
/// energy budget, diagnostics at output times that fall inside). Pairs
/// count the fluid passes over neighbours (density by summation, forces,
/// the energy budget's rates) with the mean neighbour count at the end;
/// the wall particles' gathers are timed but not counted as pairs.
///
/// # Errors
/// [`Error::Config`] for a bad setting, a step count of zero, or a scene
/// that ends (or stops) before the timed steps are done; core errors.
pub fn run_case(bench: &CaseBench) -> Result<BenchReport> {
    if bench.steps == 0 {
        return Err(Error::config("steps", bench.steps, "must be at least 1"));
    }
    let mut settings = bench.settings.clone();
    if let Some(n) = bench.n {
        settings.resolution = resolution_for(&settings, n)?;
    }
    let mut scene = crate::cases::scene(&settings)?;
    // Nothing is written; frames would only cost memory.
    scene.keep_particles = false;
    let watch = Stopwatch {
        calls: AtomicU64::new(0),
        warmup: bench.warmup as u64,
        steps: bench.steps as u64,
        start: Mutex::new(None),
        end: Mutex::new(None),
    };
    let record = crate::scene::run(&scene, &watch)?;
    // The clock stops only where the stopwatch ended the run itself.
    let (Some(start), Some(end)) = (Stopwatch::read(&watch.start), Stopwatch::read(&watch.end))
    else {
        return Err(Error::config(
            "steps",
            bench.warmup + bench.steps,
            match &record.stop {
                Some(stop) => format!(
                    "the scene stopped after {} steps, before {} warm-up and {} timed steps: {}",
                    record.steps, bench.warmup, bench.steps, stop.reason
                ),
                None => format!(
                    "the scene ended after {} steps, before {} warm-up and {} timed steps; \
                     lower --warmup or --steps",
                    record.steps, bench.warmup, bench.steps
                ),
            },
        ));
    };
    let seconds = end.duration_since(start).as_secs_f64();
    let neighbours_mean = record.neighbours_mean.unwrap_or(f64::NAN);
    let passes = 1
        + usize::from(settings.density == DensityMode::Summation)
        + usize::from(settings.energy_budget);
    let particle_steps = (record.n_fluid * bench.steps) as f64;
    let pairs = particle_steps * neighbours_mean * passes as f64;
    Ok(BenchReport {
        scene: crate::cases::find(&settings.case)?.name,
        preset: Preset::Default.name(),
        precision: settings.precision.name(),
        density: settings.density.name(),
        kernel: settings.kernel.name(),
        n: record.n_fluid,
        threads: record.threads,
        steps: bench.steps,
        neighbours_mean,
        seconds,
        particle_steps_per_s: particle_steps / seconds,
        pairs_per_s: pairs / seconds,
        ns_per_pair: seconds * 1e9 / pairs,
        bytes_per_particle: record.storage_bytes as f64 / record.n_fluid.max(1) as f64,
        passes_per_step: passes,
    })
}
