//! The energy budget (`energy_budget = true`): kinetic, potential, internal
//! and dissipated energy at every output time, each checked against theory
//! on three flows it was not built on: the compressible column at rest (its
//! potential and internal energy in closed form), the steady channel (the
//! viscous dissipation of the parabola) and the decaying vortex array
//! (whatever kinetic energy it loses, the dissipated energy gains, up to
//! the work of particle shifting, which falls with resolution).

use sph_core::eos::Eos;
use sph_core::math::Libm;
use sph_std::cases::{self, Settings};
use sph_std::couette::Silent;
use sph_std::report;
use sph_std::scene::{self, energy_drift, Energy, RunRecord};

fn settings(case: &str, extra: &str) -> Settings {
    let mut s =
        Settings::from_toml(&format!("case = \"{case}\"\nenergy_budget = true\n{extra}")).unwrap();
    s.threads = 2;
    s
}

fn run(s: &Settings) -> RunRecord {
    let r = scene::run(&cases::scene(s).unwrap(), &Silent).unwrap();
    assert!(r.complete(), "{:?}", r.stop);
    r
}

fn energy(r: &RunRecord, k: usize) -> Energy {
    r.outputs[k].energy.expect("a budget at every output")
}

/// Midpoint rule on `n` panels.
fn integrate(a: f64, b: f64, n: usize, f: impl Fn(f64) -> f64) -> f64 {
    let h = (b - a) / n as f64;
    (0..n).map(|k| f(a + (k as f64 + 0.5) * h)).sum::<f64>() * h
}

#[test]
fn a_tank_at_rest_holds_the_energy_of_the_compressible_column_and_conserves_it() {
    let s = settings("hydrostatic", "resolution = 20\n");
    let r = run(&s);
    let (g, h, width) = (1.0, 1.0, 2.0);
    let (rho0, c0) = (r.rho0, r.physics.sound_speed);
    let tait = Eos::Tait {
        rho0,
        c0,
        gamma: 7.0,
        p0: 0.0,
    };
    // In the mass coordinate s (mass per unit width above a point, 0 at the
    // surface, rho0 H at the floor) the column at rest has p = g s, so
    // rho(s) = rho(p = g s) from the equation of state, internal energy
    // W int e(rho(s)) ds, and potential energy W g int y(s) ds with
    // y(s) = int_s^(rho0 H) ds' / rho(s'), which by parts is
    // W g int s / rho(s) ds.
    let sigma = rho0 * h;
    let rho = |s: f64| tait.density::<Libm>(g * s, rho0);
    let internal = width * integrate(0.0, sigma, 20_000, |s| tait.internal_energy(rho(s)));
    let potential = width * g * integrate(0.0, sigma, 20_000, |s| s / rho(s));
    let last = energy(&r, r.outputs.len() - 1);
    eprintln!(
        "potential {:.6} against {potential:.6}, internal {:.4e} against {internal:.4e}",
        last.potential_energy, last.internal_energy
    );
    assert!(
        (last.potential_energy - potential).abs() < 1e-3 * potential,
        "potential energy {} against the column's {potential}",
        last.potential_energy
    );
    assert!(
        (last.internal_energy - internal).abs() < 1e-2 * internal,
        "internal energy {} against the column's {internal}",
        last.internal_energy
    );
    assert!(last.kinetic_energy < 1e-6 * potential);
    // After the ramp the sum stays within 1 % of the potential energy.
    let from = r
        .outputs
        .iter()
        .position(|o| o.t >= s.gravity_ramp.unwrap() - 1e-12)
        .unwrap();
    let reference = energy(&r, from);
    for k in from..r.outputs.len() {
        let e = energy(&r, k);
        let drift = (e.total_energy - reference.total_energy).abs() / reference.potential_energy;
        assert!(drift < 1e-2, "t = {}: drift {drift:.3e}", r.outputs[k].t);
    }
    let drift = energy_drift(&r.outputs, s.gravity_ramp.unwrap()).unwrap();
    eprintln!("drift after the ramp: {drift:?}");
    assert_eq!(drift.from, r.outputs[from].t);
    assert!(drift.max_relative < 1e-2);
    let png = report::energy_png(&r)
        .unwrap()
        .expect("a budget has a plot");
    assert_eq!(&png[1..4], b"PNG");
}

#[test]
fn the_steady_channel_dissipates_what_the_parabola_does() {
    // Plane Poiseuille at steady state: the viscous dissipation per unit
    // time is mu int (du/dy)^2 dV = rho0 g^2 L^3 Lx / (12 nu) for
    // u = g y (L - y) / (2 nu); the budget's dissipated energy, integrated
    // from the viscous term's work step by step, must grow at that rate.
    let s = settings(
        "poiseuille",
        "resolution = 20\nt_end = 1.5\noutput_interval = 0.25\n",
    );
    let r = run(&s);
    let g = r.body_force[0];
    let l = r.length_scale;
    let n_rows = (l / r.dx).round() as usize;
    let lx = (r.n_fluid / n_rows) as f64 * r.dx;
    let exact = r.rho0 * g * g * l.powi(3) * lx / (12.0 * r.nu);
    let k = r.outputs.len();
    let (a, b) = (&r.outputs[k - 2], &r.outputs[k - 1]);
    let (ea, eb) = (a.energy.unwrap(), b.energy.unwrap());
    let rate = (eb.dissipated_energy - ea.dissipated_energy) / (b.t - a.t);
    eprintln!("dissipation rate {rate:.6e} against {exact:.6e}");
    assert!(
        (rate - exact).abs() < 1e-2 * exact,
        "dissipation rate {rate:e} against {exact:e}"
    );
    // The driving force's work (the periodic axis's potential) balances it.
    let drift = energy_drift(&r.outputs, 0.0).unwrap();
    assert!(drift.max_relative < 1e-3, "{drift:?}");
}

#[test]
fn the_vortex_array_dissipates_the_kinetic_energy_it_loses() {
    // Taylor-Green in a periodic box, no body force: only the viscous term
    // should change the energy, so the dissipated energy makes up the loss
    // of kinetic (and internal) energy, except for what particle shifting
    // (which the case needs: without it the lattice pairs up) does to it, a
    // work that falls as the resolution rises.
    let drift = |resolution: usize| {
        let s = settings(
            "taylor-green",
            &format!("resolution = {resolution}\nt_end = 1.0\n"),
        );
        let r = run(&s);
        let first = energy(&r, 0);
        let last = energy(&r, r.outputs.len() - 1);
        assert!(
            last.kinetic_energy < 0.5 * first.kinetic_energy,
            "the flow must decay: {} from {}",
            last.kinetic_energy,
            first.kinetic_energy
        );
        let mut worst: f64 = 0.0;
        for k in 0..r.outputs.len() {
            let e = energy(&r, k);
            assert_eq!(e.potential_energy, 0.0);
            worst = worst.max((e.total_energy - first.total_energy).abs() / first.kinetic_energy);
        }
        eprintln!("{resolution}: drift {worst:.3e} of the kinetic energy");
        worst
    };
    let (coarse, fine) = (drift(24), drift(48));
    assert!(fine < 5e-3, "drift {fine:.3e} at 48");
    assert!(
        fine < 0.5 * coarse,
        "drift {coarse:.3e} at 24, {fine:.3e} at 48"
    );
}

#[test]
fn without_the_key_there_is_no_budget() {
    let mut s = settings("poiseuille", "resolution = 8\nt_end = 0.1\n");
    s.energy_budget = false;
    let r = run(&s);
    assert!(r.outputs.iter().all(|o| o.energy.is_none()));
    assert!(energy_drift(&r.outputs, 0.0).is_none());
    assert!(report::energy_png(&r).unwrap().is_none());
}
