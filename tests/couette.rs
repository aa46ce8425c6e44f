//! Couette validation against the exact series (issue: the poster's central result).

use sph_std::config::CouetteConfig;
use sph_std::couette::{self, Silent, HEADLINE_T_STAR};
use sph_std::output;

#[test]
fn default_case_meets_the_validation_bounds() {
    // The README's main job, in f64, serial.
    let config = CouetteConfig {
        threads: 1,
        ..CouetteConfig::default()
    };
    let run = couette::run(&config, &Silent).unwrap();
    let errors = run.errors();
    assert_eq!(errors.len(), 5);
    for e in &errors {
        if e.t_star >= HEADLINE_T_STAR {
            assert!(
                e.linf <= 5e-3,
                "t = {}: Linf {:.3e} U above 0.5 %",
                e.t,
                e.linf
            );
        }
    }
    // Mirrored ghosts make the linear profile an exact discrete steady state:
    // what is left at t* = 1 is the exact series' own distance from the line
    // plus boundary bookkeeping and pressure noise.
    let steady = errors.last().unwrap();
    assert!((steady.t_star - 1.0).abs() < 1e-12);
    assert!(
        steady.linf <= 1e-4,
        "steady state Linf {:.3e} U",
        steady.linf
    );
}

#[test]
fn rayon_and_serial_runs_write_bitwise_identical_profiles() {
    let base = CouetteConfig {
        t_end: 0.05,
        output_times: vec![0.0225],
        ..CouetteConfig::default()
    };
    let serial = couette::run(
        &CouetteConfig {
            threads: 1,
            ..base.clone()
        },
        &Silent,
    )
    .unwrap();
    let parallel = couette::run(
        &CouetteConfig {
            threads: 2,
            ..base.clone()
        },
        &Silent,
    )
    .unwrap();
    assert_eq!(parallel.threads, 2);
    assert!(
        serial.geometry.n_fluid > 2 * 64,
        "the rayon run must really split the particles"
    );
    assert_eq!(output::profile_csv(&serial), output::profile_csv(&parallel));
}

#[test]
fn single_precision_and_continuity_density_agree_with_the_reference_run() {
    let base = CouetteConfig {
        t_end: 0.1125,
        output_times: vec![0.045],
        threads: 1,
        ..CouetteConfig::default()
    };
    let reference = couette::run(&base, &Silent).unwrap().errors();
    for variant in [
        CouetteConfig {
            precision: sph_std::config::Precision::F32,
            ..base.clone()
        },
        CouetteConfig {
            density: sph_std::config::DensityMode::Continuity,
            ..base.clone()
        },
    ] {
        let errors = couette::run(&variant, &Silent).unwrap().errors();
        for (a, b) in errors.iter().zip(&reference) {
            // Both are discretisations of the same operator on the same
            // lattice; in the transient they differ far below the error itself.
            assert!(
                (a.linf - b.linf).abs() < 0.05 * b.linf,
                "{:?} vs {:?}",
                a,
                b
            );
        }
    }
}
