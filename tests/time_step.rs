//! The adaptive time step (`adaptive_dt = true`): the same physics as the
//! fixed step on flows it was not tuned on, output times hit exactly, and
//! steps within the stability limits. Thread-count and resume determinism
//! are in tests/restart.rs.

use sph_std::cases::{self, Settings};
use sph_std::couette::Silent;
use sph_std::scene::{self, RunRecord};

fn settings(case: &str, extra: &str, adaptive: bool) -> Settings {
    let mut s = Settings::from_toml(&format!("case = \"{case}\"\n{extra}")).unwrap();
    s.threads = 2;
    s.adaptive_dt = adaptive;
    s
}

fn run(s: &Settings) -> RunRecord {
    let r = scene::run(&cases::scene(s).unwrap(), &Silent).unwrap();
    assert!(r.complete(), "{:?}", r.stop);
    r
}

/// Runs `case` with the fixed and the adaptive step; returns both.
fn both(case: &str, extra: &str) -> (RunRecord, RunRecord) {
    let fixed = run(&settings(case, extra, false));
    let adaptive = run(&settings(case, extra, true));
    assert!(fixed.dt_range.is_none());
    let [lo, hi] = adaptive.dt_range.unwrap();
    // Never beyond the acoustic limit at rest, 0.25 h / c0, times the factor.
    let cfl_at_rest = 0.25 * adaptive.h / adaptive.physics.sound_speed;
    eprintln!(
        "{case}: fixed dt {:.4e} ({} steps), adaptive {lo:.4e} .. {hi:.4e} ({} steps)",
        fixed.dt, fixed.steps, adaptive.steps
    );
    assert!(hi <= adaptive.physics.dt_factor * cfl_at_rest * (1.0 + 1e-12));
    assert!(lo > 0.0);
    // The same output times.
    let times = |r: &RunRecord| r.outputs.iter().map(|o| o.t).collect::<Vec<_>>();
    assert_eq!(times(&fixed), times(&adaptive));
    (fixed, adaptive)
}

fn worst_linf(r: &RunRecord) -> f64 {
    r.outputs
        .iter()
        .map(|o| o.linf.unwrap())
        .fold(0.0, f64::max)
}

#[test]
fn where_the_viscous_limit_governs_the_adaptive_step_is_the_fixed_one() {
    // Plane Poiseuille against its exact series: here the viscous limit
    // governs, a constant, so the adaptive step is the fixed one (up to how
    // each lands on the output times) and so is the error.
    let (fixed, adaptive) = both("poiseuille", "resolution = 20\nt_end = 0.5\n");
    let (ef, ea) = (worst_linf(&fixed), worst_linf(&adaptive));
    eprintln!("poiseuille: Linf {ef:.4e} fixed, {ea:.4e} adaptive");
    assert!(ea < 1e-2, "{ea}");
    assert!((ea - ef).abs() < 0.05 * ef, "{ef} against {ea}");
}

#[test]
fn a_tank_at_rest_takes_fewer_steps_and_stays_at_rest_with_an_adaptive_step() {
    // The fixed step budgets for c0 + sqrt(g H); at rest the adaptive one
    // sees c0 + max |v|, so it takes longer steps, and the tank settles the
    // same: probes within 1 % of rho0 g H, speed below 1e-3 sqrt(g H).
    let (fixed, adaptive) = both("hydrostatic", "resolution = 20\n");
    assert!(adaptive.steps < fixed.steps);
    for r in [&fixed, &adaptive] {
        let last = r.outputs.last().unwrap();
        assert!(last.linf.unwrap() < 1e-3, "speed {:?}", last.linf);
        for (depth, sph, exact) in cases::hydrostatic_pressure_probes(r).unwrap() {
            assert!(
                (sph - exact).abs() < 1e-2,
                "depth {depth}: {sph} against {exact}"
            );
        }
    }
}

#[test]
fn a_decaying_vortex_array_keeps_its_accuracy_with_longer_steps() {
    // Taylor-Green: the acoustic limit governs; as the vortices decay the
    // largest speed falls below the velocity scale the fixed step budgets
    // for, so the adaptive steps grow, and the error against the exact decay
    // stays the spatial one.
    let (fixed, adaptive) = both("taylor-green", "resolution = 24\nt_end = 0.5\n");
    let [lo, hi] = adaptive.dt_range.unwrap();
    assert!(
        lo > fixed.dt && hi > lo,
        "{lo} .. {hi} against {}",
        fixed.dt
    );
    assert!(adaptive.steps < fixed.steps);
    let (ef, ea) = (worst_linf(&fixed), worst_linf(&adaptive));
    eprintln!("taylor-green: Linf {ef:.4e} fixed, {ea:.4e} adaptive");
    assert!((ea - ef).abs() < 0.05 * ef, "{ef} against {ea}");
}
