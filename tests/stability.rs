//! Stability at the extremes, each against an expectation from theory.
//!
//! Planar Couette flow obeys a maximum principle: the velocity stays between
//! the plate velocities (0 and U), v_y stays 0, and with c0 = 10 U the density
//! stays within the weakly compressible band |rho/rho0 - 1| ~ (U/c0)^2.

use sph_std::config::{CouetteConfig, KernelName, Precision, ViscosityForm};
use sph_std::couette::{self, CouetteRun, Silent};

fn run(cfg: CouetteConfig) -> CouetteRun {
    couette::run(
        &CouetteConfig {
            threads: 1,
            quiet: true,
            vtk: true,
            ..cfg
        },
        &Silent,
    )
    .unwrap_or_else(|e| panic!("run failed: {e}"))
}

/// Checks the maximum principle (u within [0, U] up to `slack` U), |v_y| <=
/// `vy_slack` U, the density band and that no particle left the gap, at
/// every output time.
fn assert_bounded_vy(r: &CouetteRun, slack: f64, vy_slack: f64, what: &str) {
    let u = r.config.u_wall;
    for s in &r.snapshots {
        for ((x, v), rho) in s.x.iter().zip(&s.v).zip(&s.rho) {
            assert!(
                v[0].is_finite() && v[1].is_finite(),
                "{what}: NaN at t = {}",
                s.t
            );
            assert!(
                v[0] >= -slack * u && v[0] <= (1.0 + slack) * u,
                "{what}: u = {:e} U at t = {}",
                v[0] / u,
                s.t
            );
            assert!(
                v[1].abs() <= vy_slack * u,
                "{what}: v_y = {:e} U at t = {}",
                v[1] / u,
                s.t
            );
            assert!(
                (rho / r.config.rho0 - 1.0).abs() <= 2.0 / r.config.sound_speed_factor.powi(2),
                "{what}: rho/rho0 = {}",
                rho / r.config.rho0
            );
            assert!(
                x[1] >= r.geometry.y_lower && x[1] <= r.geometry.y_upper,
                "{what}: particle left the gap (y = {})",
                x[1]
            );
        }
    }
}

/// As [`assert_bounded_vy`] with a true shear viscosity: v_y stays 0 up to `slack`.
fn assert_bounded(r: &CouetteRun, slack: f64, what: &str) {
    assert_bounded_vy(r, slack, slack, what);
}

fn short(n: usize, t_end: f64) -> CouetteConfig {
    CouetteConfig {
        particles_across: n,
        t_end,
        output_times: vec![t_end],
        ..CouetteConfig::default()
    }
}

#[test]
fn each_viscous_form_is_bounded_at_nine_tenths_of_its_limit() {
    for form in [ViscosityForm::Morris, ViscosityForm::Pi] {
        let r = run(CouetteConfig {
            viscosity: form,
            dt_factor: 0.9,
            ..short(20, 0.1)
        });
        assert_bounded(&r, 0.02, form.name());
    }
    // The artificial form's approach switch is active for about half of the
    // ghost pairs at the moving plate, whose normal components all point one
    // way: the model pushes fluid normal to the wall (v_y is not 0 for it).
    // Stable means bounded and not growing: v_y below U, and no larger at
    // t = 0.1 than at t = 0.02.
    let r = run(CouetteConfig {
        viscosity: ViscosityForm::Artificial,
        dt_factor: 0.9,
        output_times: vec![0.02, 0.1],
        ..short(20, 0.1)
    });
    assert_bounded_vy(&r, 0.02, 1.0, "artificial");
    let vy = |k: usize| {
        r.snapshots[k]
            .v
            .iter()
            .map(|v| v[1].abs())
            .fold(0.0, f64::max)
    };
    assert!(
        vy(1) <= vy(0),
        "artificial: v_y grows from {:e} to {:e}",
        vy(0),
        vy(1)
    );
}

#[test]
fn very_low_reynolds_number_is_bounded_and_as_accurate() {
    // Re = U gap / nu = 1e-4 instead of 1.25e-2. With c0 = 10 U the pressure
    // term shrinks relative to viscosity as Re falls (ratio ~ U/nu), so in
    // units of U the run approaches the Stokes limit: the error may not grow.
    let base = run(short(20, 0.1));
    let low = run(CouetteConfig {
        u_wall: 1e-4 * 1e-6 / 1e-3,
        ..short(20, 0.1)
    });
    assert_bounded(&low, 0.02, "Re 1e-4");
    let (e_base, e_low) = (base.errors()[0].linf, low.errors()[0].linf);
    assert!(
        e_low <= 1.05 * e_base,
        "Re 1e-4 error {e_low:e} vs Re 1.25e-2 {e_base:e}"
    );
}

#[test]
fn high_reynolds_numbers_with_artificial_viscosity_are_bounded() {
    // Re = 100 and 1000 (U = 0.1 and 1 m/s, c0 = 10 U): h c0 / nu > 2, so
    // the acoustic limit governs (physics.md 4.1) and the run is cut to
    // t* = 0.02, when the shear layer has crossed a few particle rows.
    for re in [100.0, 300.0] {
        let u_wall = re * 1e-6 / 1e-3;
        for form in [ViscosityForm::Artificial, ViscosityForm::Morris] {
            let r = run(CouetteConfig {
                u_wall,
                viscosity: form,
                ..short(20, 0.02)
            });
            assert!(
                r.limits.cfl < r.limits.viscous,
                "Re {re}: the acoustic limit should govern: {:?}",
                r.limits
            );
            let vy = if form == ViscosityForm::Artificial {
                0.1
            } else {
                0.02
            };
            assert_bounded_vy(&r, 0.02, vy, &format!("Re {re} {form}"));
        }
    }
}

#[test]
fn reynolds_1000_is_reported_not_hidden() {
    // FIXME: at Re >= 500 (20 across) the top row, sliding against its mirror
    // images, compresses and breaks symmetry after t* ~ 0.006 and a particle
    // crosses the moving plate; a background pressure does not prevent it.
    // physics.md 8.4: plain WCSPH needs density diffusion (delta-SPH) or
    // particle shifting there. Until then the run must stop with a clear
    // error naming the step and the particle, never a panic or NaN.
    let cfg = CouetteConfig {
        u_wall: 1.0,
        threads: 1,
        quiet: true,
        ..short(20, 0.02)
    };
    match couette::run(&cfg, &Silent) {
        Err(sph_std::error::Error::Diverged(reason)) => {
            let step: u64 = reason
                .split("unstable at step ")
                .nth(1)
                .and_then(|r| r.split(':').next())
                .and_then(|n| n.parse().ok())
                .unwrap_or_else(|| panic!("the report names no step: {reason}"));
            assert!(reason.contains("particle"), "names no particle: {reason}");
            assert!(step > 1000, "fails late, after the start-up: {reason}");
        }
        Ok(r) => panic!(
            "Re 1000 now runs ({} steps): move it to the bounded test",
            r.steps
        ),
        Err(e) => panic!("unexpected error: {e}"),
    }
}

#[test]
fn beta_from_one_to_three_runs_without_nan() {
    for kernel in [
        KernelName::Cubic,
        KernelName::WendlandC2,
        KernelName::Quintic,
    ] {
        for beta in [1.0, 1.5, 2.0, 2.5, 3.0] {
            let r = run(CouetteConfig {
                kernel,
                beta,
                ..short(20, 0.05)
            });
            assert_bounded(&r, 0.02, &format!("{kernel} beta {beta}"));
            let e = r.errors()[0].linf;
            assert!(e.is_finite() && e < 0.1, "{kernel} beta {beta}: error {e}");
        }
    }
}

#[test]
fn single_precision_far_from_the_origin_keeps_its_accuracy() {
    // 1e4 gap widths from the coordinate origin: positions are stored relative
    // to the domain, so the f32 error must stay within 2x (it is the same).
    let near = run(CouetteConfig {
        precision: Precision::F32,
        ..short(20, 0.1)
    });
    let far = run(CouetteConfig {
        precision: Precision::F32,
        shift: 1e4 * 1e-3,
        ..short(20, 0.1)
    });
    let (a, b) = (near.errors()[0].linf, far.errors()[0].linf);
    assert!(b <= 2.0 * a, "shifted f32 error {b:e} vs {a:e}");
}

#[test]
fn a_hundred_diffusion_times_do_not_drift() {
    // 10 across to t = 100 s (t* = 100). Particles move with the flow, so rows
    // slide past each other: adjacent rows slip by U dx / H per unit time,
    // 0.0125 dx/s here. The plates place their ghosts by point reflection, so
    // a uniformly sheared lattice continues through the walls and the linear
    // profile stays an exact discrete steady state at every slip phase. What
    // is left comes from the start-up: the transient leaves the rows near the
    // moving plate slipped a little further than those near the plate at
    // rest (a strain difference of order Re), and the viscous operator's
    // lattice bias depends on the slip phase. That residue is periodic in the
    // phase (period 80 s), not a drift: back at (or below) its t* = 1 level
    // when the rows realign at t = 80 s, and equal at t = 20 and 100 s.
    // With mirrored ghosts the same run reached 1e-3 U at half slip.
    let r = run(CouetteConfig {
        particles_across: 10,
        t_end: 100.0,
        output_times: vec![1.0, 20.0, 80.0, 100.0],
        ..CouetteConfig::default()
    });
    let g = r.geometry;
    let vs_line = |k: usize| {
        let p = &r.profiles[k];
        p.y.iter()
            .zip(&p.vx)
            .map(|(y, u)| (u / r.config.u_wall - (y - g.y_lower) / (g.y_upper - g.y_lower)).abs())
            .fold(0.0, f64::max)
    };
    let (e1, e20, e80, e100) = (vs_line(0), vs_line(1), vs_line(2), vs_line(3));
    assert!(
        e80 <= e1,
        "realigned rows at t = 80 s: {e80:e} above the t* = 1 level {e1:e}"
    );
    assert!(
        (e100 - e20).abs() <= 0.1 * e20,
        "not periodic in the slip phase: t = 20 s {e20:e}, t = 100 s {e100:e}"
    );
    assert_bounded(&r, 2e-3, "long run");
    for k in 0..4 {
        let e = vs_line(k);
        assert!(
            e < 1e-4,
            "output {k}: {e:e} U, ten times below the mirrored walls' 1e-3"
        );
    }
}
