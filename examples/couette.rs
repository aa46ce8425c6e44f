//! The Couette case through the library API, without the CLI: build the
//! scene from `sph-core` pieces, step it with the rayon executor, and compare
//! with the exact series. Run with `cargo run --release --example couette`.

use sph_core::analytic::Couette;
use sph_core::prelude::*;
use sph_std::driver::{Buffers, Rayon};

fn main() -> Result<()> {
    // Morris, Fox & Zhu (1997): gap 1 mm, nu = 1e-6 m^2/s, U = 1.25e-5 m/s.
    let (gap, nu, rho0, u) = (1e-3, 1e-6, 1e3, 1.25e-5);
    let (n, beta) = (40, 1.3);
    let dx = gap / n as f64;
    let h = beta * dx;
    let nx = 6; // a periodic strip just over two kernel supports (2 x 2.6 dx) wide
    let exact = Couette::new(-0.5 * gap, 0.5 * gap, u, nu)?;

    // Plates at y = -L (at rest) and y = +L (moving), periodic in x.
    let domain = Domain::<D2<f64>>::new(
        Vector::new([0.0, -0.5 * gap]),
        Vector::new([nx as f64 * dx, gap]),
    )?
    .with_periodic(0)?
    .with_wall(1, Side::Lower, Wall::no_slip())?
    .with_wall(1, Side::Upper, Wall::moving(Vector::new([u, 0.0])))?;

    // Fluid on a square lattice, first row dx/2 from each wall; room for ghosts.
    type Forces = (PressureGradient, MorrisViscosity<f64>);
    let cells =
        Solver::<D2<f64>, CubicSpline, Libm, SummationDensity, Forces>::cells_needed(&domain, h)?;
    let n_fluid = n * nx;
    let mut buffers = Buffers::<D2<f64>>::new(n_fluid + 8 * nx, cells);
    for j in 0..n {
        for i in 0..nx {
            buffers.x[j * nx + i] = Vector::new([(i as f64 + 0.5) * dx, (j as f64 + 0.5) * dx]);
            buffers.m[j * nx + i] = 1.0;
        }
    }

    // Summation density, linear EOS with c0 = 10 U, Morris viscosity.
    let params = Params::new(
        h,
        Eos::Linear {
            rho0,
            c0: 10.0 * u,
            p0: 0.0,
        },
    );
    let forces = (PressureGradient, MorrisViscosity { mu: nu * rho0 });
    let exec = Rayon::default();
    let mut solver = Solver::<D2<f64>, CubicSpline, Libm, _, _>::new_with(
        &exec,
        params,
        domain,
        buffers.storage(),
        n_fluid,
        SummationDensity,
        forces,
    )?;
    solver.calibrate_mass_with(&exec, rho0)?; // rho = rho0 exactly on the lattice
    let limits = solver.limits();
    println!(
        "limits: CFL {:.3e} s, viscous {:.3e} s, force {:.3e} s",
        limits.cfl, limits.viscous, limits.force
    );

    // Step to each output time exactly, then compare with the series.
    let mut t = 0.0;
    for t_out in [0.0225, 0.045, 0.1125, 0.225, 1.0] {
        let steps = ((t_out - t) / (0.7 * limits.min())).ceil() as usize;
        let dt = (t_out - t) / steps as f64;
        for _ in 0..steps {
            solver.step_with(&exec, dt)?;
        }
        t = t_out;
        let linf = solver
            .positions()
            .iter()
            .zip(solver.velocities())
            .map(|(x, v)| (v[0] - exact.velocity(solver.domain().to_global(*x)[1], t)).abs() / u)
            .fold(0.0, f64::max);
        println!(
            "t = {t:<7} s  Linf error = {linf:.3e} U  ({} steps so far)",
            solver.steps()
        );
    }
    Ok(())
}
