//! The `sph` command-line tool: a thin shell over `sph-std`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use clap::{Args, Parser, Subcommand};
use sph_std::cases::{self, Settings};
use sph_std::config::{
    CouetteConfig, DensityMode, KernelName, MathBackend, Precision, ViscosityForm,
};
use sph_std::distributed::Comm;
use sph_std::error::Result;
use sph_std::output::VtkEncoding;
use sph_std::scene::{
    EosForm, PressureForm, Regularise, RunControl, RunRecord, Stop, WallBoundary, WallPressure,
};
use sph_std::{bench, checkpoint, couette, output, progress, report, studies};

/// `println!` for results: a closed pipe on stdout ends the program quietly
/// with status 0 (as Unix tools do), any other write error with one line on
/// stderr and status 1; never a panic.
macro_rules! outln {
    () => {
        stdout_write(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        stdout_write(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `print!` with the rules of [`outln!`].
macro_rules! out {
    ($($arg:tt)*) => {
        stdout_write(format_args!($($arg)*))
    };
}

/// With `--json`, stdout carries one JSON object and nothing else: the
/// human-readable text of [`outln!`] goes to stderr instead.
static HUMAN_TO_STDERR: AtomicBool = AtomicBool::new(false);

/// Sends the human-readable text to stderr from now on (`--json`).
fn json_mode() {
    HUMAN_TO_STDERR.store(true, Ordering::Relaxed);
}

/// Prints the one JSON object of a `--json` command on stdout.
fn json_out(value: &serde_json::Value) {
    raw_stdout_write(format_args!("{value}\n"));
}

/// Writes human-readable text: stdout, or stderr in `--json` mode.
fn stdout_write(args: std::fmt::Arguments<'_>) {
    if HUMAN_TO_STDERR.load(Ordering::Relaxed) {
        use std::io::Write;
        let _ = std::io::stderr().lock().write_fmt(args);
        return;
    }
    raw_stdout_write(args);
}

/// Writes to stdout under the rules of [`outln!`].
fn raw_stdout_write(args: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("sph: error: cannot write to standard output: {e}");
        std::process::exit(1);
    }
}

#[derive(Parser, Debug)]
#[command(
    name = "sph",
    version,
    about = "Smoothed particle hydrodynamics: validation cases and studies"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Impulsively started Couette flow against the exact series solution.
    ///
    /// Writes summary.json, profile.csv, profiles.png and config.toml (and
    /// VTK snapshots with --vtk) to the output directory and prints the
    /// errors at each output time. Every flag has a config-file key with the
    /// same words (underscores for dashes); flags override the file.
    Couette(Box<CouetteArgs>),
    /// Times a standard scene or a case: particle-steps and pair interactions per second.
    ///
    /// The periodic boxes are timed after an untimed warm-up that disorders
    /// the initial lattice. A case (`--scene dam-break --dim 3`) is stepped
    /// as `sph run` steps it, from its initial state, with the same flags to
    /// change its settings (`--density-diffusion 0` times it without delta-SPH).
    /// With --json stdout is one JSON object (the text goes to stderr).
    Bench(Box<BenchArgs>),
    /// Convergence of the Couette error in N and beta (the poster's "second order").
    ///
    /// Fixed-beta sweeps per kernel (local, fitted and Richardson orders, and
    /// the extrapolated floor), beta sweeps at fixed N with two regularisers,
    /// and a joint sweep where beta grows as sqrt(N). Writes convergence.csv,
    /// orders.txt, convergence.png, richardson.png and beta.png.
    Convergence(StudyArgs),
    /// The speed/accuracy trade: Couette runs across kernel, precision, math
    /// backend, beta, time-step factor and resolution (one-factor variations
    /// around the default), each timed on one thread. Writes pareto.csv,
    /// pareto.png and cheapest.txt (the cheapest run for 10 %, 1 % and 0.1 % of U).
    Pareto(StudyArgs),
    /// Runs a built-in case by name, or a scene file (`case = "NAME"` plus keys).
    ///
    /// Writes summary.json (every resolved parameter, diagnostics and errors
    /// per output time), particles.csv, config.toml (the resolved settings,
    /// to repeat the run with `sph run out/CASE/config.toml`), diagnostics.png
    /// and, with --vtk, particle snapshots. Flags override the file. A run
    /// whose state degenerates or diverges writes what it computed with
    /// `complete: false` and exits with status 1.
    Run(Box<RunArgs>),
    /// Continues an interrupted or checkpointed `sph run` or `sph couette`
    /// in its output directory, bit for bit as if it had never stopped.
    ///
    /// DIR must hold checkpoint.bin (written at SIGINT or SIGTERM, and with
    /// --checkpoint-every while the run is going) and config.toml. The
    /// results replace the directory's set when the run ends or stops again.
    Resume(ResumeArgs),
    /// Lists the built-in cases.
    Cases,
}

#[derive(Args, Debug)]
struct RunArgs {
    /// A built-in case (see `sph cases`) or a scene file ending in .toml.
    #[arg(value_name = "CASE|FILE")]
    scene: String,
    /// Output directory [default: out/CASE].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Replace a non-empty output directory that sph did not write.
    #[arg(long)]
    overwrite: bool,
    /// Run even when the run needs more than 10^9 time steps.
    #[arg(long)]
    allow_long_run: bool,
    /// End time in seconds.
    #[arg(long, value_name = "S")]
    t_end: Option<f64>,
    /// Time between outputs in seconds.
    #[arg(long, value_name = "S")]
    output_interval: Option<f64>,
    /// Worker threads; 0 = all cores.
    #[arg(long, value_name = "T")]
    threads: Option<usize>,
    /// The scene's settings.
    #[command(flatten)]
    scene_settings: SceneOverrides,
    /// Write VTK particle snapshots (.vtu and a .pvd index).
    #[arg(long)]
    vtk: bool,
    /// Write the VTK snapshots as ASCII text instead of binary.
    #[arg(long)]
    vtk_ascii: bool,
    /// Publish the results so far with a checkpoint every S simulated
    /// seconds (resume with `sph resume DIR` if the process is lost).
    #[arg(long, value_name = "S")]
    checkpoint_every: Option<f64>,
    /// Print summary.json as one JSON object on stdout (the table goes to stderr).
    #[arg(long)]
    json: bool,
    /// No progress bar and no table.
    #[arg(long)]
    quiet: bool,
    /// Run on the MPI ranks this process was started among (`mpirun -np N
    /// sph run CASE --mpi`): the same particles and figures as one process,
    /// written by rank 0. Needs a build with `--features mpi`.
    #[arg(long)]
    mpi: bool,
}

/// A scene file's settings (a name ending in .toml) or a built-in case's defaults.
fn scene_settings(scene: &str) -> Result<Settings> {
    if scene.ends_with(".toml") {
        Settings::from_file(std::path::Path::new(scene))
    } else {
        Ok((cases::find(scene)?.defaults)())
    }
}

/// Settings a command line may change in a built-in case or a scene file
/// (`sph run`, and `sph bench` for case scenes).
#[derive(Args, Debug, Default, PartialEq)]
struct SceneOverrides {
    /// Particles across the case's reference length.
    #[arg(long, value_name = "N")]
    resolution: Option<usize>,
    /// Dimension.
    #[arg(long, value_name = "2|3")]
    dim: Option<usize>,
    /// Reynolds number.
    #[arg(long, value_name = "RE")]
    re: Option<f64>,
    /// Smoothing kernel.
    #[arg(long, value_name = "NAME", value_parser = parse_name::<KernelName>)]
    kernel: Option<KernelName>,
    /// Overlap factor beta = h / dx.
    #[arg(long, value_name = "B")]
    beta: Option<f64>,
    /// Density: summation, continuity, corrected (continuity with a
    /// corrected divergence).
    #[arg(long, value_name = "MODE", value_parser = parse_name::<DensityMode>)]
    density: Option<DensityMode>,
    /// Viscous form: morris, pi, artificial, corrected (consistent Laplacian).
    #[arg(long, value_name = "FORM", value_parser = parse_name::<ViscosityForm>)]
    viscosity: Option<ViscosityForm>,
    /// Floating-point precision.
    #[arg(long, value_name = "P", value_parser = parse_name::<Precision>)]
    precision: Option<Precision>,
    /// Math backend.
    #[arg(long, value_name = "M", value_parser = parse_name::<MathBackend>)]
    math: Option<MathBackend>,
    /// Particle regularisation: none or shifting.
    #[arg(long, value_name = "METHOD", value_parser = parse_name::<Regularise>)]
    regularise: Option<Regularise>,
    /// Shifting coefficient C.
    #[arg(long, value_name = "C")]
    shift_coefficient: Option<f64>,
    /// Density diffusion delta (continuity and corrected density).
    #[arg(long, value_name = "D")]
    density_diffusion: Option<f64>,
    /// Time step as a fraction of the smallest stability limit.
    #[arg(long, value_name = "F")]
    dt_factor: Option<f64>,
    /// Wall ghost pressure: hydrostatic (balances the body force) or mirror.
    #[arg(long, value_name = "RULE", value_parser = parse_name::<WallPressure>)]
    wall_pressure: Option<WallPressure>,
    /// Planar walls: mirror (mirrored ghosts) or particles (fixed wall
    /// particles with values from the fluid, Adami et al. 2012).
    #[arg(long, value_name = "METHOD", value_parser = parse_name::<WallBoundary>)]
    wall_boundary: Option<WallBoundary>,
    /// Pressure gradient: symmetric, or corrected (exact for linear pressure
    /// on any arrangement; continuity density only).
    #[arg(long, value_name = "FORM", value_parser = parse_name::<PressureForm>)]
    pressure_gradient: Option<PressureForm>,
    /// Equation of state: linear, or tait (gamma 7).
    #[arg(long, value_name = "EOS", value_parser = parse_name::<EosForm>)]
    eos: Option<EosForm>,
    /// Artificial viscosity alpha: the coefficient of viscosity = artificial
    /// (0: matched to re), or added to viscosity = morris.
    #[arg(long, value_name = "A")]
    alpha: Option<f64>,
    /// No tension: continuity density bounded below by rho0, so the
    /// pressure by the background pressure (free surfaces).
    #[arg(long, value_name = "BOOL")]
    tension_cutoff: Option<bool>,
    /// Integrate the energy budget (kinetic, potential, internal,
    /// dissipated) into summary.json: one more pass per step.
    #[arg(long, value_name = "BOOL")]
    energy_budget: Option<bool>,
    /// Choose the time step every step from the current state (acoustic
    /// limit on c0 + max speed, force and viscous limits) times dt_factor.
    #[arg(long, value_name = "BOOL")]
    adaptive_dt: Option<bool>,
    /// Time over which gravity rises from zero (free-surface cases).
    #[arg(long, value_name = "S")]
    gravity_ramp: Option<f64>,
}

impl SceneOverrides {
    /// Applies the overrides given to `s`.
    fn apply(&self, s: &mut Settings) {
        macro_rules! set {
            ($($field:ident),+) => {
                $(if let Some(v) = self.$field.clone() { s.$field = v; })+
            };
        }
        set!(
            resolution,
            dim,
            re,
            kernel,
            beta,
            density,
            viscosity,
            precision,
            math,
            regularise,
            shift_coefficient,
            density_diffusion,
            dt_factor,
            wall_pressure,
            wall_boundary,
            pressure_gradient,
            eos,
            alpha,
            tension_cutoff,
            energy_budget,
            adaptive_dt
        );
        if let Some(ramp) = self.gravity_ramp {
            s.gravity_ramp = Some(ramp);
        }
    }
}

#[derive(Args, Debug)]
struct ResumeArgs {
    /// The output directory of the run to continue.
    #[arg(value_name = "DIR")]
    dir: PathBuf,
    /// Worker threads; 0 = all cores [default: the run's own].
    #[arg(long, value_name = "T")]
    threads: Option<usize>,
    /// Print summary.json as one JSON object on stdout (the table goes to stderr).
    #[arg(long)]
    json: bool,
    /// No progress bar and no table.
    #[arg(long)]
    quiet: bool,
}

impl RunArgs {
    /// The settings: the case's defaults, then the file, then the flags.
    fn settings(&self) -> Result<Settings> {
        let mut s = scene_settings(&self.scene)?;
        macro_rules! set {
            ($($field:ident),+) => {
                $(if let Some(v) = self.$field { s.$field = v; })+
            };
        }
        set!(t_end, output_interval, threads);
        self.scene_settings.apply(&mut s);
        s.validate()?;
        Ok(s)
    }
}

/// Caps a requested thread count at four per core, with a warning: more
/// only costs time spawning workers (100,000 took 51 s before failing).
fn sane_threads(requested: usize) -> usize {
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let cap = 4 * cores;
    if requested > cap {
        eprintln!("sph: warning: {requested} threads asked for on {cores} cores; using {cap}");
        cap
    } else {
        requested
    }
}

fn run_scene(args: &RunArgs) -> Result<()> {
    if args.json {
        json_mode();
    }
    let mut settings = args.settings()?;
    settings.threads = sane_threads(settings.threads);
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out").join(&settings.case));
    let options = checkpoint::Options {
        vtk: args.vtk,
        vtk_ascii: args.vtk_ascii,
        checkpoint_every: args.checkpoint_every.unwrap_or(0.0),
        allow_long_run: args.allow_long_run,
    };
    let run = |ranks: Option<&(dyn Comm + Sync)>| {
        execute(
            &settings,
            &dir,
            args.overwrite,
            options,
            None,
            args.quiet,
            ranks,
        )
    };
    if args.mpi {
        return sph_std::distributed::with_mpi(|comm| run(Some(comm)))?;
    }
    run(None)
}

fn resume_scene(args: &ResumeArgs) -> Result<()> {
    if args.json {
        json_mode();
    }
    let dir = &args.dir;
    let ck = checkpoint::Checkpoint::read(dir)?;
    if ck.case == couette::CASE {
        // A `sph couette` set: its config.toml is a Couette configuration.
        let mut config = CouetteConfig::from_file(&dir.join("config.toml"))?;
        config.out = dir.clone();
        config.quiet = args.quiet;
        if let Some(t) = args.threads {
            config.threads = t;
        }
        config.threads = sane_threads(config.threads);
        return couette_in(&config, false, Some(&ck));
    }
    let mut settings = Settings::from_file(&dir.join("config.toml"))?;
    if let Some(t) = args.threads {
        settings.threads = t;
    }
    settings.threads = sane_threads(settings.threads);
    let options = ck.options;
    execute(&settings, dir, false, options, Some(&ck), args.quiet, None)
}

/// Runs a scene (from its start or from a checkpoint), publishing its
/// output set at every checkpoint and at the end, then prints its table.
fn execute(
    settings: &Settings,
    dir: &std::path::Path,
    overwrite: bool,
    options: checkpoint::Options,
    resume: Option<&checkpoint::Checkpoint>,
    quiet: bool,
    ranks: Option<&(dyn Comm + Sync)>,
) -> Result<()> {
    // On several ranks, rank 0 writes and reports.
    let writer = ranks.is_none_or(|c| c.rank() == 0);
    let mut scene = cases::scene(settings)?;
    scene.allow_long_run = options.allow_long_run;
    // Refuse a directory before the work, not after it.
    if writer {
        output::check_out_dir(dir, overwrite)?;
    }
    let case = cases::find(&settings.case)?;
    let bar = progress::Bar::new(&settings.case, quiet || !writer);
    // Writes the set for a record (and its checkpoint, if any) into `dir`.
    let publish = |record: &RunRecord, ck: Option<&checkpoint::Checkpoint>| {
        output::in_dir(dir, overwrite, |stage| {
            let figure = (case.figure)(&scene, record)?;
            let reference = (case.reference)(record);
            let mut written = report::write_record(
                record,
                Some(settings),
                Some(figure),
                reference.as_ref(),
                stage,
                options.vtk.then_some(report::Vtk {
                    encoding: if options.vtk_ascii {
                        VtkEncoding::Ascii
                    } else {
                        VtkEncoding::Binary
                    },
                    exact: scene.exact.as_ref(),
                    error_decay: scene.error_decay,
                }),
            )?;
            if let Some(ck) = ck {
                let mut ck = ck.clone();
                ck.options = options;
                let path = stage.join(checkpoint::FILE);
                output::write_atomic(&path, &ck.to_bytes())?;
                written.push(path);
            }
            Ok((reference, written))
        })
    };
    let mut on_checkpoint = |record: &RunRecord, ck: &checkpoint::Checkpoint| {
        let mut partial = record.clone();
        partial.stop = Some(Stop {
            t: ck.state.time,
            particle: None,
            reason: format!(
                "running: checkpoint at t = {:.6e} s (if this process is gone, `sph resume {}` continues the run)",
                ck.state.time,
                dir.display()
            ),
        });
        publish(&partial, Some(ck)).map(|_| ())
    };
    let every = (options.checkpoint_every > 0.0).then_some(options.checkpoint_every);
    let record = sph_std::scene::run_with(
        &scene,
        &mut RunControl {
            progress: &bar,
            resume,
            checkpoint_every: every,
            on_checkpoint: &mut on_checkpoint,
            pause_after: None,
            refresh: false,
            ranks,
        },
    )?;
    if !writer {
        return Ok(());
    }
    let (reference, written) = publish(&record, record.checkpoint.as_deref())?;
    if HUMAN_TO_STDERR.load(Ordering::Relaxed) {
        json_out(&read_summary(dir)?);
    }
    if !quiet {
        let p = &record.physics;
        outln!(
            "{}: {} particles ({} across), {} kernel, beta {}, {} viscosity, {} density, regularise {}, {}/{}",
            record.case, record.n_fluid, settings.resolution, p.kernel, p.beta, p.viscosity, p.density, p.regularise, p.precision, p.math
        );
        outln!(
            "dt = {:.4e} s, {} steps, {} thread(s), {:.2} s",
            record.dt,
            record.steps,
            record.threads,
            record.wall_seconds
        );
        if !record.rank_stats.is_empty() {
            let r = &record.rank_stats;
            let sum =
                |f: &dyn Fn(&sph_std::distributed::RankStats) -> f64| r.iter().map(f).sum::<f64>();
            let busy = sum(&|x| x.step_seconds);
            let comm = sum(&|x| x.halo_seconds + x.reduce_seconds + x.migrate_seconds);
            outln!(
                "{} ranks: {:.0} owned and {:.0} halo particles per rank, {:.1} kB sent per rank and step, {:.0} % of the ranks' time outside their steps",
                record.ranks,
                sum(&|x| x.owned as f64) / r.len() as f64,
                sum(&|x| x.halo as f64) / r.len() as f64,
                sum(&|x| x.bytes_sent) / (r.len() as f64 * record.steps.max(1) as f64) / 1e3,
                100.0 * comm / (busy + comm).max(f64::MIN_POSITIVE)
            );
        }
        outln!();
        outln!(
            "{:>10} {:>12} {:>11} {:>11} {:>9} {:>10} {:>10}",
            "t [s]",
            "kinetic",
            "Linf",
            "L2",
            "min dx",
            "max drho",
            "max Mach"
        );
        for d in &record.outputs {
            let opt = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.3e}"));
            outln!(
                "{:>10.4} {:>12.5e} {:>11} {:>11} {:>9.3} {:>10.2e} {:>10.3}",
                d.t,
                d.kinetic_energy,
                opt(d.linf),
                opt(d.l2),
                d.min_spacing,
                d.max_density_deviation,
                d.max_mach
            );
        }
        if record.steady {
            outln!("Steady state reached (kinetic energy change below the case's tolerance).");
        }
        let last_energy = record.outputs.last().and_then(|d| d.energy);
        let drift = sph_std::scene::energy_drift(&record.outputs, record.physics.gravity_ramp);
        if let (Some(e), Some(d)) = (last_energy, drift) {
            outln!(
                "Energy at the end: kinetic {:.4e}, potential {:.4e}, internal {:.4e}, dissipated {:.4e}; the sum drifted {:.2e} of {:.4e} from t = {:.4}",
                e.kinetic_energy,
                e.potential_energy,
                e.internal_energy,
                e.dissipated_energy,
                d.max_relative,
                d.energy_scale,
                d.from
            );
        }
        if let Some(r) = &reference {
            let worst = r.points.iter().max_by(|a, b| {
                (a.sph - a.reference)
                    .abs()
                    .total_cmp(&(b.sph - b.reference).abs())
            });
            if let Some(w) = worst {
                outln!(
                    "Against {}: largest relative deviation {:.3e} at t = {:.4}, {} at {} ({} points)",
                    r.source,
                    r.max_deviation,
                    r.t,
                    w.quantity,
                    w.at,
                    r.points.len()
                );
            }
        }
        let names: Vec<String> = written
            .iter()
            .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
            .collect();
        outln!("Wrote {} to {}", names.join(", "), dir.display());
    }
    stopped(record.stop.as_ref(), record.checkpoint.is_some(), dir)
}

/// The summary.json just published in `dir`, for `--json`.
fn read_summary(dir: &std::path::Path) -> Result<serde_json::Value> {
    let path = dir.join("summary.json");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| sph_std::error::Error::io("read summary", &path, e))?;
    serde_json::from_str(&text)
        .map_err(|e| sph_std::error::Error::config("summary", path.display(), e.to_string()))
}

fn list_cases() -> Result<()> {
    for c in cases::CASES {
        outln!("{:<20} {}", c.name, c.about);
    }
    Ok(())
}

#[derive(Args, Debug)]
struct StudyArgs {
    /// Fewer resolutions (under two minutes on 2 cores).
    #[arg(long)]
    quick: bool,
    /// Output directory [default: out/COMMAND].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Replace a non-empty output directory that sph did not write.
    #[arg(long)]
    overwrite: bool,
    /// Worker threads per run; 0 = all cores [default: 0].
    #[arg(long, value_name = "T", default_value_t = 0, hide_default_value = true)]
    threads: usize,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

impl StudyArgs {
    fn out_dir(&self, command: &str) -> PathBuf {
        self.out
            .clone()
            .unwrap_or_else(|| PathBuf::from("out").join(command))
    }
}

fn run_pareto(args: &StudyArgs) -> Result<()> {
    let dir = args.out_dir("pareto");
    let resolutions: &[usize] = if args.quick {
        &[10, 20, 40]
    } else {
        &[10, 20, 40, 80, 160]
    };
    let configs = studies::pareto_configs(resolutions);
    if args.threads > 1 {
        eprintln!("sph: warning: pareto times every run on one thread; --threads is ignored");
    }
    let bar = progress::Bar::new("pareto runs", args.quiet);
    let (rows, written) = output::in_dir(&dir, args.overwrite, |stage| {
        let rows = studies::pareto(&configs, &bar)?;
        let written = studies::write_pareto(&rows, stage)?;
        Ok((rows, written))
    })?;
    outln!(
        "{:<12} {:>5} {:>4} {:>10} {:>4} {:>5} {:>11} {:>9} {:>12}  frontier",
        "kernel",
        "beta",
        "prec",
        "math",
        "dt",
        "N",
        "Linf/U",
        "seconds",
        "p-steps/s"
    );
    for r in &rows {
        outln!(
            "{:<12} {:>5} {:>4} {:>10} {:>4} {:>5} {:>11.3e} {:>9.3} {:>12.3e}  {}",
            r.kernel.name(),
            r.beta,
            r.precision.name(),
            r.math.name(),
            r.dt_factor,
            r.particles_across,
            r.linf_error,
            r.wall_seconds,
            r.particle_steps_per_s,
            if r.pareto { "*" } else { "" }
        );
    }
    out!("{}", studies::cheapest_for(&rows, &[0.1, 0.01, 0.001]));
    let names: Vec<String> = written
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    outln!("Wrote {} to {}", names.join(", "), dir.display());
    Ok(())
}

fn run_convergence(args: &StudyArgs) -> Result<()> {
    let dir = args.out_dir("convergence");
    let mut plan = if args.quick {
        studies::ConvergencePlan::quick()
    } else {
        studies::ConvergencePlan::full()
    };
    plan.threads = sane_threads(args.threads);
    let bar = progress::Bar::new("convergence runs", args.quiet);
    let (report, written) = output::in_dir(&dir, args.overwrite, |stage| {
        let report = studies::convergence(&plan, &bar)?;
        let written = studies::write_convergence(&report, stage)?;
        Ok((report, written))
    })?;
    out!("{}", studies::orders_table(&report));
    let names: Vec<String> = written
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    outln!("Wrote {} to {}", names.join(", "), dir.display());
    Ok(())
}

#[derive(Args, Debug)]
struct BenchArgs {
    /// Scene: box2d, box3d, couette, or a built-in case (see `sph cases`)
    /// or scene file (.toml) stepped as `sph run` steps it [default: box2d].
    #[arg(
        long,
        value_name = "NAME|FILE",
        default_value = "box2d",
        hide_default_value = true
    )]
    scene: String,
    /// Approximate number of fluid particles [default: 40000 for the box
    /// scenes; a case's own resolution].
    #[arg(long, value_name = "N")]
    n: Option<usize>,
    /// Threads; 0 = all cores, 1 = serial without rayon [default: 1].
    #[arg(
        long,
        value_name = "T",
        default_value_t = bench::BenchConfig::default().threads,
        hide_default_value = true
    )]
    threads: usize,
    /// Timed steps [default: 100].
    #[arg(
        long,
        value_name = "S",
        default_value_t = bench::BenchConfig::default().steps,
        hide_default_value = true
    )]
    steps: usize,
    /// Untimed warm-up steps that disorder the lattice [default: 300].
    #[arg(
        long,
        value_name = "S",
        default_value_t = bench::BenchConfig::default().warmup,
        hide_default_value = true
    )]
    warmup: usize,
    /// Reorder particles by cell every this many neighbour builds; 0 = never [default: 1].
    #[arg(
        long,
        value_name = "K",
        default_value_t = bench::BenchConfig::default().reorder_every,
        hide_default_value = true
    )]
    reorder_every: u32,
    /// Scan cells in every pass instead of using Verlet neighbour lists.
    #[arg(long)]
    no_lists: bool,
    /// Verlet skin as a fraction of the support radius [default: 0.1].
    #[arg(
        long,
        value_name = "F",
        default_value_t = bench::BenchConfig::default().skin,
        hide_default_value = true
    )]
    skin: f64,
    /// Start from a random particle order (what cell reordering is for).
    #[arg(long)]
    shuffle: bool,
    /// Physics of the box scenes: default (f64, summation density, cubic,
    /// Morris: a density pass and a force pass) or fast (continuity density
    /// in the force pass: one neighbour pass per step; same kernel, support
    /// and neighbours) [default: default].
    #[arg(
        long,
        value_name = "NAME",
        default_value = "default",
        hide_default_value = true,
        value_parser = bench::Preset::parse
    )]
    preset: bench::Preset,
    /// Time N = 1e3, 1e4, 1e5, 1e6 (or the sizes of --sizes) and fit the slope of time per step.
    #[arg(long)]
    sweep: bool,
    /// Sizes for --sweep, comma separated.
    #[arg(
        long,
        value_name = "N,..",
        value_delimiter = ',',
        default_value = "1000,10000,100000,1000000",
        hide_default_value = true
    )]
    sizes: Vec<usize>,
    /// Print the report as one JSON object on stdout (the text goes to stderr).
    #[arg(long)]
    json: bool,
    /// Settings of a case scene.
    #[command(flatten, next_help_heading = "Case scenes (not box2d, box3d, couette)")]
    scene_settings: SceneOverrides,
}

impl BenchArgs {
    /// The settings of a case scene: the case's defaults or the file, then
    /// the flags; refuses the box scenes' own options.
    fn case_settings(&self) -> Result<Settings> {
        let box_only = [
            ("no_lists", self.no_lists, "true".to_string()),
            ("shuffle", self.shuffle, "true".to_string()),
            ("sweep", self.sweep, "true".to_string()),
            ("skin", self.skin != 0.1, self.skin.to_string()),
            (
                "reorder_every",
                self.reorder_every != 1,
                self.reorder_every.to_string(),
            ),
        ];
        if let Some((key, _, value)) = box_only.into_iter().find(|b| b.1) {
            return Err(sph_std::error::Error::config(
                key,
                value,
                "applies to the box2d, box3d and couette scenes only (a case scene runs \
                 with the scene layer's own neighbour lists)",
            ));
        }
        if let (Some(n), Some(_)) = (self.n, self.scene_settings.resolution) {
            return Err(sph_std::error::Error::config(
                "n",
                n,
                "give either --n or --resolution for a case scene, not both",
            ));
        }
        let mut s = scene_settings(&self.scene)?;
        self.scene_settings.apply(&mut s);
        s.threads = sane_threads(self.threads);
        s.validate()?;
        Ok(s)
    }
}

fn run_bench(args: &BenchArgs) -> Result<()> {
    let scene = bench::Scene::parse(&args.scene).ok();
    if args.preset != bench::Preset::Default
        && !matches!(scene, Some(bench::Scene::Box2d | bench::Scene::Box3d))
    {
        return Err(sph_std::error::Error::config(
            "preset",
            args.preset.name(),
            "applies to the box scenes (box2d, box3d); the couette scene and case scenes \
             take their physics from their own settings (--density, --precision, --kernel, ...)",
        ));
    }
    let Some(scene) = scene else {
        return run_case_bench(args);
    };
    if args.scene_settings != SceneOverrides::default() {
        return Err(sph_std::error::Error::config(
            "scene",
            &args.scene,
            "takes no case settings (--resolution, --dim, --density, ...): they apply to \
             case scenes; the box scenes take --n and --preset",
        ));
    }
    let config = bench::BenchConfig {
        scene,
        preset: args.preset,
        n: args.n.unwrap_or(bench::BenchConfig::default().n),
        threads: sane_threads(args.threads),
        steps: args.steps,
        warmup: args.warmup,
        reorder_every: args.reorder_every,
        lists: !args.no_lists,
        skin: args.skin,
        shuffle: args.shuffle,
    };
    if args.json {
        json_mode();
    }
    if args.sweep {
        let (rows, slope) = bench::sweep(&config, &args.sizes)?;
        outln!(
            "{} scene, {} thread(s): time per step against N",
            scene.name(),
            rows[0].report.threads
        );
        outln!(
            "{:>10}  {:>8}  {:>14}  {:>14}  {:>8}",
            "N",
            "steps",
            "s / step",
            "p-steps / s",
            "B / p"
        );
        for r in &rows {
            outln!(
                "{:>10}  {:>8}  {:>14.4e}  {:>14.4e}  {:>8.0}",
                r.report.n,
                r.report.steps,
                r.seconds_per_step,
                r.report.particle_steps_per_s,
                r.report.bytes_per_particle
            );
        }
        outln!("log-log slope of time per step against N: {slope:.3}");
        if args.json {
            json_out(&serde_json::json!({ "rows": rows, "slope": slope }));
        }
        return Ok(());
    }
    let report = bench::run(&config)?;
    print_bench(&report, args.json)
}

fn run_case_bench(args: &BenchArgs) -> Result<()> {
    let settings = args.case_settings()?;
    if args.json {
        json_mode();
    }
    let report = bench::run_case(&bench::CaseBench {
        settings,
        n: args.n,
        steps: args.steps,
        warmup: args.warmup,
    })?;
    print_bench(&report, args.json)
}

/// Prints a benchmark's report (and its JSON with `json`).
fn print_bench(report: &bench::BenchReport, json: bool) -> Result<()> {
    outln!(
        "{} scene, preset {} ({}, {} density, {} kernel): {} particles, {} thread(s), {} steps in {:.3} s",
        report.scene,
        report.preset,
        report.precision,
        report.density,
        report.kernel,
        report.n,
        report.threads,
        report.steps,
        report.seconds
    );
    outln!(
        "  neighbours per particle (itself included): {:.2}",
        report.neighbours_mean
    );
    outln!(
        "  particle-steps per second:                 {:.4e}",
        report.particle_steps_per_s
    );
    outln!(
        "  pair interactions per second:              {:.4e} ({} passes per step)",
        report.pairs_per_s,
        report.passes_per_step
    );
    outln!(
        "  nanoseconds per pair:                      {:.2}",
        report.ns_per_pair
    );
    outln!(
        "  bytes per particle:                        {:.0}",
        report.bytes_per_particle
    );
    if json {
        match serde_json::to_value(report) {
            Ok(value) => json_out(&value),
            Err(e) => {
                return Err(sph_std::error::Error::config(
                    "json",
                    "report",
                    e.to_string(),
                ))
            }
        }
    }
    Ok(())
}

fn parse_name<T: std::str::FromStr<Err = String>>(s: &str) -> std::result::Result<T, String> {
    s.parse()
}

#[derive(Args, Debug, Default)]
struct CouetteArgs {
    /// TOML configuration file (see examples/couette.toml); flags override it.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Output directory [default: out/couette].
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Replace a non-empty output directory that sph did not write.
    #[arg(long)]
    overwrite: bool,
    /// Run even when the run needs more than 10^9 time steps.
    #[arg(long)]
    allow_long_run: bool,
    /// Fluid particles across the gap, 4 to 4000 [default: 40].
    #[arg(long, value_name = "N")]
    particles_across: Option<usize>,
    /// Overlap factor beta = h/dx, 1.0 to 3.0 [default: 1.3].
    #[arg(long, value_name = "B", allow_hyphen_values = true)]
    beta: Option<f64>,
    /// Kernel: cubic, quintic, wendland-c2, wendland-c4, gaussian [default: cubic].
    #[arg(long, value_name = "NAME", value_parser = parse_name::<KernelName>)]
    kernel: Option<KernelName>,
    /// Viscous term: morris, pi, artificial, corrected [default: morris].
    #[arg(long, value_name = "FORM", value_parser = parse_name::<ViscosityForm>)]
    viscosity: Option<ViscosityForm>,
    /// Density: summation, continuity, corrected [default: summation].
    #[arg(long, value_name = "MODE", value_parser = parse_name::<DensityMode>)]
    density: Option<DensityMode>,
    /// Precision: f32, f64 [default: f64].
    #[arg(long, value_name = "P", value_parser = parse_name::<Precision>)]
    precision: Option<Precision>,
    /// Math backend: libm, micromath (f32 only) [default: libm].
    #[arg(long, value_name = "M", value_parser = parse_name::<MathBackend>)]
    math: Option<MathBackend>,
    /// Worker threads; 0 = all cores, 1 = serial without rayon [default: 0].
    #[arg(long, value_name = "T")]
    threads: Option<usize>,
    /// End time in seconds [default: 1].
    #[arg(long, value_name = "S", allow_hyphen_values = true)]
    t_end: Option<f64>,
    /// Time step as a fraction of the smallest stability limit, in (0, 0.9] [default: 0.7].
    #[arg(long, value_name = "F", allow_hyphen_values = true)]
    dt_factor: Option<f64>,
    /// Viscous regulariser eta^2 as a fraction of h^2, 0 to 1 [default: 0.01].
    #[arg(long, value_name = "F", allow_hyphen_values = true)]
    eta2: Option<f64>,
    /// Gap between the plates 2L in metres [default: 0.001].
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    gap: Option<f64>,
    /// Kinematic viscosity in m^2/s [default: 0.000001].
    #[arg(long, value_name = "NU", allow_hyphen_values = true)]
    nu: Option<f64>,
    /// Reference density in kg/m^3 [default: 1000].
    #[arg(long, value_name = "RHO", allow_hyphen_values = true)]
    rho0: Option<f64>,
    /// Speed of the moving plate in m/s [default: 0.0000125].
    #[arg(long, value_name = "U", allow_hyphen_values = true)]
    u_wall: Option<f64>,
    /// Sound speed as a multiple of the plate speed, at least 1 [default: 10].
    #[arg(long, value_name = "F", allow_hyphen_values = true)]
    sound_speed_factor: Option<f64>,
    /// Background pressure as a fraction of rho0 c0^2, 0 to 1 [default: 0].
    #[arg(long, value_name = "F", allow_hyphen_values = true)]
    background_pressure: Option<f64>,
    /// Artificial-viscosity alpha; 0 matches nu [default: 0].
    #[arg(long, value_name = "A", allow_hyphen_values = true)]
    alpha: Option<f64>,
    /// Width of the periodic strip in kernel support radii, at least 2 [default: 2].
    #[arg(long, value_name = "W", allow_hyphen_values = true)]
    strip_supports: Option<f64>,
    /// Move the whole scene by this many metres along x and y [default: 0].
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    shift: Option<f64>,
    /// Output times in seconds, comma separated [default: 0.0225,0.045,0.1125,0.225,1].
    #[arg(
        long,
        value_name = "T,..",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    output_times: Option<Vec<f64>>,
    /// Write VTK particle snapshots (.vtu and a .pvd index) for ParaView.
    #[arg(long)]
    vtk: bool,
    /// Write the VTK snapshots as ASCII text instead of binary.
    #[arg(long)]
    vtk_ascii: bool,
    /// Print summary.json as one JSON object on stdout (the table goes to stderr).
    #[arg(long)]
    json: bool,
    /// No progress bar and no table.
    #[arg(long)]
    quiet: bool,
}

impl CouetteArgs {
    /// The configuration: defaults, then the file, then the flags.
    fn config(&self) -> Result<CouetteConfig> {
        let mut c = match &self.config {
            Some(path) => CouetteConfig::from_file(path)?,
            None => CouetteConfig::default(),
        };
        macro_rules! set {
            ($($field:ident),+) => {
                $(if let Some(v) = self.$field.clone() { c.$field = v; })+
            };
        }
        set!(
            out,
            particles_across,
            beta,
            kernel,
            viscosity,
            density,
            precision,
            math,
            threads,
            t_end,
            dt_factor,
            eta2,
            gap,
            nu,
            rho0,
            u_wall,
            sound_speed_factor,
            background_pressure,
            alpha,
            strip_supports,
            shift,
            output_times
        );
        c.vtk |= self.vtk;
        c.vtk_ascii |= self.vtk_ascii;
        c.quiet |= self.quiet;
        c.allow_long_run |= self.allow_long_run;
        c.threads = sane_threads(c.threads);
        c.clip_default_output_times();
        c.validate()?;
        Ok(c)
    }
}

fn run_couette(args: &CouetteArgs) -> Result<()> {
    if args.json {
        json_mode();
    }
    let config = args.config()?;
    couette_in(&config, args.overwrite, None)
}

/// Runs `sph couette` (from its start or from a checkpoint) and publishes
/// its set in `config.out`: a run that stops early publishes what it
/// computed, marked incomplete, with a checkpoint when it was interrupted.
fn couette_in(
    config: &CouetteConfig,
    overwrite: bool,
    resume: Option<&checkpoint::Checkpoint>,
) -> Result<()> {
    output::check_out_dir(&config.out, overwrite)?;
    let bar = progress::Bar::new("couette", config.quiet);
    let run = couette::run_with(config, &bar, resume)?;
    let written = output::in_dir(&config.out, overwrite, |stage| {
        output::write_couette(&run, stage)
    })?;
    if !config.quiet {
        let g = &run.geometry;
        let c = &run.config;
        outln!(
            "Couette flow: {} kernel, beta {}, {} particles across ({} x {} = {} fluid), {} viscosity, {} density, {}/{}",
            c.kernel, c.beta, c.particles_across, g.nx, c.particles_across, g.n_fluid, c.viscosity, c.density, c.precision, c.math
        );
        outln!(
            "dt = {:.4e} s ({} x the {} limit), {} steps, {} thread(s), {:.2} s",
            run.dt_max,
            c.dt_factor,
            if run.limits.viscous <= run.limits.cfl.min(run.limits.force) {
                "viscous"
            } else {
                "acoustic/force"
            },
            run.steps,
            run.threads,
            run.wall_seconds
        );
        outln!();
        out!("{}", output::error_table(&run));
        let (linf, l2) = run.headline();
        outln!();
        if run.has_headline() {
            outln!(
                "Largest error over t* >= {}: Linf {:.3e} U, L2 {:.3e} U",
                couette::HEADLINE_T_STAR,
                linf,
                l2
            );
        } else {
            outln!(
                "No output time at t* >= {}: no headline error (the table above has every output)",
                couette::HEADLINE_T_STAR
            );
        }
        let names: Vec<String> = written
            .iter()
            .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
            .collect();
        outln!("Wrote {} to {}", names.join(", "), config.out.display());
    }
    if HUMAN_TO_STDERR.load(Ordering::Relaxed) {
        json_out(&read_summary(&config.out)?);
    }
    stopped(run.stop.as_ref(), run.checkpoint.is_some(), &config.out)
}

/// The error for a run that stopped early (its set is published), naming
/// `sph resume` when it left a checkpoint.
fn stopped(stop: Option<&Stop>, checkpoint: bool, dir: &std::path::Path) -> Result<()> {
    match stop {
        None => Ok(()),
        Some(stop) if checkpoint => Err(sph_std::error::Error::Stopped(format!(
            "{}; `sph resume {}` continues the run",
            stop.reason,
            dir.display()
        ))),
        Some(stop) => Err(sph_std::error::Error::Stopped(stop.reason.clone())),
    }
}

fn main() -> ExitCode {
    if let Some(commit) = option_env!("SPH_GIT_COMMIT") {
        sph_std::provenance::set_git_commit(commit);
    }
    // SIGINT and SIGTERM: a scene run stops at the next step and still
    // publishes its results (marked incomplete), then exits 130 or 143.
    let interrupted = Arc::new(AtomicBool::new(false));
    let terminated = Arc::new(AtomicBool::new(false));
    for (signal, which) in [
        (signal_hook::consts::SIGINT, &interrupted),
        (signal_hook::consts::SIGTERM, &terminated),
    ] {
        // A second signal while the run is stopping ends the process at once.
        let _ = signal_hook::flag::register_conditional_shutdown(
            signal,
            128 + signal,
            Arc::clone(which),
        );
        let _ = signal_hook::flag::register(signal, progress::stop_flag());
        let _ = signal_hook::flag::register(signal, Arc::clone(which));
    }
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help and --version.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e)
            if matches!(
                e.kind(),
                clap::error::ErrorKind::MissingSubcommand
                    | clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) =>
        {
            let names: Vec<String> = <Cli as clap::CommandFactory>::command()
                .get_subcommands()
                .map(|c| c.get_name().to_string())
                .collect();
            eprintln!(
                "sph: error: no command given; the commands are {} (see sph --help)",
                names.join(", ")
            );
            return ExitCode::from(2);
        }
        Err(e) => {
            // One line: what was wrong, with the accepted values.
            let text = e.to_string();
            let first = text
                .lines()
                .next()
                .unwrap_or("invalid arguments")
                .trim_start_matches("error: ");
            // clap's suggestion ("a similar argument exists") is on a line
            // of its own: keep it on the one line.
            let tip = text
                .lines()
                .find_map(|l| l.trim().strip_prefix("tip: "))
                .map(|t| format!("; {t}"))
                .unwrap_or_default();
            eprintln!("sph: error: {first}{tip} (see sph --help)");
            return ExitCode::from(2);
        }
    };
    let result = match &cli.command {
        Command::Couette(args) => run_couette(args),
        Command::Bench(args) => run_bench(args),
        Command::Convergence(args) => run_convergence(args),
        Command::Pareto(args) => run_pareto(args),
        Command::Run(args) => run_scene(args),
        Command::Resume(args) => resume_scene(args),
        Command::Cases => list_cases(),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sph: error: {e}");
            // 128 + the signal number, as shells report a signal's end.
            if terminated.load(Ordering::SeqCst) {
                ExitCode::from(143)
            } else if interrupted.load(Ordering::SeqCst) {
                ExitCode::from(130)
            } else {
                ExitCode::from(e.exit_code() as u8)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn help_states_the_real_defaults() {
        let mut cmd = Cli::command();
        let help = cmd
            .find_subcommand_mut("couette")
            .unwrap()
            .render_long_help()
            .to_string();
        let d = CouetteConfig::default();
        for (flag, default) in [
            ("--particles-across", d.particles_across.to_string()),
            ("--beta", d.beta.to_string()),
            ("--kernel", d.kernel.to_string()),
            ("--viscosity", d.viscosity.to_string()),
            ("--density", d.density.to_string()),
            ("--precision", d.precision.to_string()),
            ("--math", d.math.to_string()),
            ("--threads", d.threads.to_string()),
            ("--t-end", d.t_end.to_string()),
            ("--dt-factor", d.dt_factor.to_string()),
            ("--eta2", d.eta2.to_string()),
            ("--gap", d.gap.to_string()),
            ("--nu", d.nu.to_string()),
            ("--rho0", d.rho0.to_string()),
            ("--u-wall", d.u_wall.to_string()),
            ("--sound-speed-factor", d.sound_speed_factor.to_string()),
            ("--alpha", d.alpha.to_string()),
            ("--background-pressure", d.background_pressure.to_string()),
            ("--strip-supports", d.strip_supports.to_string()),
            ("--shift", d.shift.to_string()),
            ("--out", d.out.display().to_string()),
        ] {
            let at = help
                .find(flag)
                .unwrap_or_else(|| panic!("{flag} missing from help"));
            let section = &help[at..];
            let end = section[2..]
                .find("\n  -")
                .map(|e| e + 2)
                .unwrap_or(section.len());
            assert!(
                section[..end].contains(&format!("[default: {default}]")),
                "{flag}: help does not state the default {default}:\n{}",
                &section[..end]
            );
        }
    }
}
