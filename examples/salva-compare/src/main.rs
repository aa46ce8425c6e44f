//! Same-run comparison of `sph bench` (2D box, one thread) with salva2d's
//! DFSPH solver on a block of the same size, in rounds that alternate the
//! engines, so that a shared, noisy machine slows both alike.
//!
//! Both sides time whole steps of a resting block of `side x side`
//! particles with a cubic-spline kernel of radius 2.6 dx (sph's `h = 1.3
//! dx`, about 21 neighbours):
//! - sph: `sph_std::bench::run`, the periodic box of `sph bench` (f64,
//!   serial, Verlet lists), after its untimed warm-up that disorders the
//!   lattice; the default preset (summation density, two passes) and
//!   `fast` (continuity density, one pass).
//! - salva2d 0.9: `LiquidWorld` with `DFSPHSolver` (its density and
//!   divergence solves; f32; serial), no gravity, steps of 1 ms after 10
//!   untimed ones. The particle radius is `dx / 2`, and `smoothing_factor`
//!   2.6 gives its kernel radius `2 x 2.6 x radius = 2.6 dx`. The block has
//!   free edges (salva has no periodic box); DFSPH may take several
//!   substeps a step, which the output counts.
//!
//! The two engines differ in method (DFSPH solves for incompressibility,
//! WCSPH steps an equation of state) and in precision, so the ratio is of
//! cost per step at the same particle count and kernel, not of cost per
//! unit of simulated time.

use std::time::Instant;

use clap::Parser;
use nalgebra::{Point2, Vector2};
use salva2d::kernel::CubicSplineKernel;
use salva2d::object::Fluid;
use salva2d::solver::DFSPHSolver;
use salva2d::LiquidWorld;
use sph_std::bench::{self, BenchConfig, Preset};

/// Times sph's 2D box and salva2d's DFSPH on the same block, alternating.
#[derive(Parser, Debug)]
struct Args {
    /// Particles per side of the block (side^2 in all).
    #[arg(long, default_value_t = 200)]
    side: usize,
    /// Rounds; each times salva, then sph default, then sph fast.
    #[arg(long, default_value_t = 3)]
    rounds: usize,
    /// Timed salva steps per round.
    #[arg(long, default_value_t = 60)]
    salva_steps: usize,
    /// Timed sph steps per round.
    #[arg(long, default_value_t = 300)]
    sph_steps: usize,
}

/// Particle-steps per second of salva2d's DFSPH and the substeps it took.
fn salva(side: usize, steps: usize) -> (f64, usize) {
    let radius = 0.01_f32;
    let dx = 2.0 * radius;
    let points: Vec<Point2<f32>> = (0..side * side)
        .map(|k| Point2::new((k % side) as f32 * dx, (k / side) as f32 * dx))
        .collect();
    let n = points.len();
    let mut world = LiquidWorld::new(
        DFSPHSolver::<CubicSplineKernel, CubicSplineKernel>::new(),
        radius,
        2.6,
    );
    world.add_fluid(Fluid::new(points, radius, 1000.0));
    let gravity = Vector2::zeros();
    let dt = 1.0e-3;
    for _ in 0..10 {
        world.step(dt, &gravity);
    }
    let mut substeps = 0;
    let start = Instant::now();
    for _ in 0..steps {
        world.step(dt, &gravity);
        substeps += world.counters.nsubsteps;
    }
    ((n * steps) as f64 / start.elapsed().as_secs_f64(), substeps)
}

/// `sph bench --n side^2 --steps steps --preset preset` (its other settings
/// at their defaults: the 2D box, one thread, Verlet lists).
fn sph(side: usize, steps: usize, preset: Preset) -> Result<bench::BenchReport, String> {
    bench::run(&BenchConfig {
        preset,
        n: side * side,
        steps,
        ..BenchConfig::default()
    })
    .map_err(|e| e.to_string())
}

fn main() {
    let args = Args::parse();
    for (name, value, least) in [
        ("--side", args.side, 10),
        ("--rounds", args.rounds, 1),
        ("--salva-steps", args.salva_steps, 1),
        ("--sph-steps", args.sph_steps, 1),
    ] {
        if value < least {
            eprintln!("error: {name} = {value}: must be at least {least}");
            std::process::exit(2);
        }
    }
    println!(
        "{:>5}  {:>22}  {:>18}  {:>18}  {:>13}  {:>10}",
        "round",
        "salva2d DFSPH (substeps)",
        "sph default",
        "sph fast",
        "default/salva",
        "fast/salva"
    );
    let mut n = 0;
    for round in 1..=args.rounds {
        let (s, substeps) = salva(args.side, args.salva_steps);
        let reports = [Preset::Default, Preset::Fast].map(|p| sph(args.side, args.sph_steps, p));
        let [Ok(d), Ok(f)] = reports else {
            for r in reports {
                if let Err(e) = r {
                    eprintln!("error: {e}");
                }
            }
            std::process::exit(1);
        };
        n = d.n;
        println!(
            "{round:>5}  {:>14.3e} ({substeps:>5})  {:>18.3e}  {:>18.3e}  {:>12.1}x  {:>9.1}x",
            s,
            d.particle_steps_per_s,
            f.particle_steps_per_s,
            d.particle_steps_per_s / s,
            f.particle_steps_per_s / s
        );
    }
    println!(
        "particle-steps per second, one thread; salva's block holds {} particles, \
         sph's box {n} (rounded to its lattice)",
        args.side * args.side
    );
}
