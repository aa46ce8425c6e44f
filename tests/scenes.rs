//! The scene layer: every built-in case under the default monitor, the
//! monitor against the Taylor-Green collapse, one engine for Couette, and
//! the cases against their exact solutions (CI-sized resolutions).

use sph_std::cases::{self, Settings};
use sph_std::config::CouetteConfig;
use sph_std::couette::{self, Silent};
use sph_std::scene::{self, RunRecord};

fn settings(case: &str) -> Settings {
    let mut s = (cases::find(case).unwrap().defaults)();
    s.threads = 1;
    s
}

fn run(s: &Settings) -> RunRecord {
    scene::run(&cases::scene(s).unwrap(), &Silent).unwrap()
}

#[test]
fn every_case_runs_at_ci_size_under_its_default_monitor() {
    for case in cases::CASES {
        if case.name == "custom" {
            // Described by its file: tested below.
            continue;
        }
        let mut s = settings(case.name);
        let (resolution, t_end) = match case.name {
            "taylor-green" => (32, 0.5),
            "lid-driven-cavity" => (20, 2.0),
            _ => (20, 0.2),
        };
        s.resolution = resolution;
        s.t_end = t_end;
        s.output_interval = t_end / 4.0;
        let r = run(&s);
        assert!(r.complete(), "{}: {:?}", case.name, r.stop);
        // The dam break also writes its initial state (t = 0, at rest).
        let outputs = 4 + usize::from(case.name == "dam-break");
        assert_eq!(r.outputs.len(), outputs, "{}", case.name);
        for d in &r.outputs {
            assert!(
                d.min_spacing >= s.monitor_min_spacing,
                "{}: {d:?}",
                case.name
            );
            assert!(d.kinetic_energy.is_finite() && (d.t == 0.0 || d.kinetic_energy > 0.0));
        }
        // particles.csv has every fluid particle at every output time.
        assert_eq!(r.frames.len(), outputs);
        assert!(r.frames.iter().all(|f| f.x.len() == r.n_fluid));
    }
}

#[test]
fn the_monitor_stops_taylor_green_without_regularisation() {
    // Plain WCSPH clumps along the stagnation lines (closest pair 0.03-0.3 dx
    // by t = 0.5, issue 10): the run must stop, naming time and particle.
    let mut s = settings("taylor-green");
    s.resolution = 32;
    s.t_end = 1.0;
    s.regularise = scene::Regularise::None;
    let r = run(&s);
    let stop = r.stop.expect("the collapsed run was not stopped");
    assert!(stop.particle.is_some(), "{}", stop.reason);
    assert!(stop.t < 1.0, "{}", stop.reason);
    assert!(stop.reason.contains("t = "), "{}", stop.reason);
    // What it computed up to then is kept.
    assert!(!r.outputs.is_empty());
}

#[test]
fn sph_run_couette_and_the_couette_command_share_one_engine() {
    // The same plates, strip and physics: the scene file's plates sit at
    // 0 and H, the command's at -L and +L; positions are stored relative to
    // the box, so the dynamics agree to the round-off of placing the lattice.
    let mut s = settings("couette");
    s.resolution = 16;
    s.t_end = 0.05;
    s.output_interval = 0.025;
    s.viscosity = sph_std::config::ViscosityForm::Morris;
    s.density = sph_std::config::DensityMode::Summation;
    let a = run(&s);
    let b = couette::run(
        &CouetteConfig {
            particles_across: 16,
            t_end: 0.05,
            output_times: vec![0.025],
            threads: 1,
            quiet: true,
            ..CouetteConfig::default()
        },
        &Silent,
    )
    .unwrap();
    assert_eq!(a.steps, b.steps);
    let last = a.frames.last().unwrap();
    let profile = b.profiles.last().unwrap();
    for (k, v) in last.v.iter().enumerate() {
        assert!(
            (v[0] - profile.vx[k]).abs() <= 1e-9 * 1.25e-5,
            "particle {k}: {} vs {}",
            v[0],
            profile.vx[k]
        );
    }
}

/// Largest L-infinity error (relative to u_max) of Poiseuille at each output
/// time up to `t_end`, at `n` across.
fn poiseuille_errors(n: usize, t_end: f64, interval: f64) -> Vec<f64> {
    let mut s = settings("poiseuille");
    s.resolution = n;
    s.t_end = t_end;
    s.output_interval = interval;
    let r = run(&s);
    assert!(r.complete(), "{:?}", r.stop);
    r.outputs.iter().map(|d| d.linf.unwrap()).collect()
}

#[test]
fn poiseuille_transient_converges_at_second_order() {
    // The consistent operators are second order in dx on any arrangement;
    // the start-up of Poiseuille flow up to t* = 0.225 must show it in raw
    // errors, with 1e-3 u_max at 40 (issue 10).
    let times = 0.225;
    let e20 = poiseuille_errors(20, times, 0.0225);
    let e40 = poiseuille_errors(40, times, 0.0225);
    let e80 = poiseuille_errors(80, times, 0.0225);
    for k in 0..e40.len() {
        assert!(
            e40[k] <= 1e-3,
            "output {k}: {:e} u_max at 40 across",
            e40[k]
        );
        let (p1, p2) = ((e20[k] / e40[k]).log2(), (e40[k] / e80[k]).log2());
        assert!(
            p1 >= 1.8 && p2 >= 1.8,
            "output {k}: orders {p1:.2}, {p2:.2}"
        );
    }
}

#[test]
fn poiseuille_steady_state_holds_and_converges() {
    // Issue 10: from t = 1 s to t = 10 s (outputs every second) the largest
    // error is at most 1e-3 u_max at 40 across and falls from 10 to 20 to
    // 40 across. With summation density it grew as t^2 to 1e-3 at every
    // resolution (the rows' slip phase changes the summed density).
    let worst = |n: usize| {
        let e = poiseuille_errors(n, 10.0, 1.0);
        e[..].iter().cloned().fold(0.0f64, f64::max)
    };
    let (e10, e20, e40) = (worst(10), worst(20), worst(40));
    assert!(e40 <= 1e-3, "{e40:e} u_max at 40 across");
    assert!(e10 > e20 && e20 > e40, "{e10:e}, {e20:e}, {e40:e}");
}

#[test]
fn the_cavity_matches_ghia_at_re_100() {
    // Centre-line profiles against Ghia, Ghia & Shin (1982), Re 100: every
    // interior reference point within 0.05 U at 50 x 50 (issue 10), once
    // steady (the run ends there) or at t = 30 L/U.
    let mut s = settings("lid-driven-cavity");
    s.resolution = 50;
    s.t_end = 30.0;
    let r = run(&s);
    assert!(r.complete(), "{:?}", r.stop);
    let (u, v) = cases::compare_ghia(r.frames.last().unwrap(), r.h, 100.0).unwrap();
    assert_eq!(u.len() + v.len(), 30);
    for (line, rows) in [("u(x = 1/2)", &u), ("v(y = 1/2)", &v)] {
        for &(s, reference, sph) in rows.iter() {
            assert!(
                (sph - reference).abs() <= 0.05,
                "{line} at {s}: {sph:.4} vs Ghia {reference:.4}"
            );
        }
    }
}

#[test]
fn the_cavity_runs_with_wall_particles() {
    // Wall particles in the corners of the moving lid follow the lid's rule
    // (a lid claims its corners). Split by depth, the corner held particles
    // at -v beside the lid's 2U - v along the lid's row, a jump the
    // continuity equation read as a compression: the corner particle left
    // through the lid at t = 0.06 (30 across). Every particle stays inside
    // the cavity and the run completes under the case's monitor.
    let mut s = Settings::from_toml(
        "case = \"lid-driven-cavity\"\nwall_boundary = \"particles\"\nresolution = 30",
    )
    .unwrap();
    s.threads = 1;
    s.t_end = 2.0;
    s.output_interval = 0.25;
    let r = run(&s);
    assert!(r.complete(), "{:?}", r.stop);
    for frame in &r.frames {
        for (i, x) in frame.x.iter().enumerate() {
            assert!(
                (0.0..=1.0).contains(&x[0]) && (0.0..=1.0).contains(&x[1]),
                "t = {}: particle {i} at {x:?}",
                frame.t
            );
        }
    }
}

/// Taylor-Green at `n` per side with the defaults: (largest relative
/// L-infinity error after t = 0.25, the one at t = 2, E(2) / E_exact(2),
/// fitted decay rate / exact rate over [0, 2]), after checking the closest
/// pair stayed above 0.5 dx throughout.
fn taylor_green(n: usize) -> (f64, f64, f64, f64) {
    let mut s = settings("taylor-green");
    s.resolution = n;
    let r = run(&s);
    assert!(r.complete(), "{:?}", r.stop);
    // Exact: kinetic energy (1/4) rho U^2 exp(-16 pi^2 nu t) over the box.
    let exact_rate = -16.0 * std::f64::consts::PI.powi(2) / s.re;
    let e0: f64 = 0.25;
    let (mut st, mut sl, mut stt, mut stl, mut m) = (0.0, e0.ln(), 0.0, 0.0, 1.0);
    let mut late = 0.0f64;
    for d in &r.outputs {
        assert!(
            d.min_spacing >= 0.5,
            "t = {}: closest pair {} dx",
            d.t,
            d.min_spacing
        );
        if d.t > 0.25 + 1e-9 {
            late = late.max(d.linf.unwrap());
        }
        let l = d.kinetic_energy.ln();
        st += d.t;
        sl += l;
        stt += d.t * d.t;
        stl += d.t * l;
        m += 1.0;
    }
    let rate = (stl - st * sl / m) / (stt - st * st / m);
    let last = r.outputs.last().unwrap();
    assert!((last.t - 2.0).abs() < 1e-9);
    let energy = last.kinetic_energy / (e0 * (exact_rate * last.t).exp());
    (late, last.linf.unwrap(), energy, rate / exact_rate)
}

#[test]
fn taylor_green_stays_regular_and_matches_the_exact_decay() {
    // Issue 10's bounds at 64 per side (relative to the current amplitude):
    // at most 1.5 % at t = 2 and 5 % after t = 0.25, the energy at t = 2
    // within 1 % and the decay rate over [0, 2] within 1 %; the error at
    // t = 2 falls from 32 to 64 (128 is in docs/validation.md).
    let (late, at_2, energy, rate) = taylor_green(64);
    assert!(at_2 <= 0.015, "{at_2:e} at t = 2");
    assert!(late <= 0.05, "{late:e} after t = 0.25");
    assert!((energy - 1.0).abs() <= 0.01, "E(2) / exact = {energy}");
    assert!((rate - 1.0).abs() <= 0.01, "rate / exact = {rate}");
    let (_, coarse, _, _) = taylor_green(32);
    assert!(coarse > at_2, "32: {coarse:e}, 64: {at_2:e}");
}

#[test]
fn scene_files_name_a_case_and_reject_unknown_keys() {
    let s = Settings::from_toml("case = \"taylor-green\"\nresolution = 48\n").unwrap();
    assert_eq!((s.case.as_str(), s.resolution), ("taylor-green", 48));
    assert_eq!(s.regularise, scene::Regularise::Shifting);
    let e = Settings::from_toml("resolution = 48\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("case"), "{e}");
    let e = Settings::from_toml("case = \"vortex\"\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("taylor-green"), "{e}");
    let e = Settings::from_toml("case = \"couette\"\nresolutoin = 4\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("resolutoin"), "{e}");
    // A case's own key on another case is an unknown key there.
    let e = Settings::from_toml("case = \"couette\"\ncontainer = \"circle\"\n")
        .and_then(|s| s.validate())
        .unwrap_err()
        .to_string();
    assert!(e.contains("container"), "{e}");
    // The corrected pressure gradient needs continuity density.
    let e = Settings::from_toml(
        "case = \"closed-tank\"\ndensity = \"summation\"\npressure_gradient = \"corrected\"\n",
    )
    .and_then(|s| s.validate())
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("pressure_gradient") && e.contains("continuity"),
        "{e}"
    );
    // Every example file parses and validates.
    for name in [
        "couette-scene",
        "poiseuille",
        "taylor-green",
        "taylor-couette",
        "tilted-channel",
        "cylinder-array",
        "closed-tank",
        "rotating-tank",
        "hydrostatic",
        "dam-break",
        "lid-driven-cavity",
    ] {
        let path = format!("{}/examples/{name}.toml", env!("CARGO_MANIFEST_DIR"));
        let s = Settings::from_file(std::path::Path::new(&path)).unwrap();
        s.validate().unwrap();
        assert_eq!(
            s,
            (cases::find(&s.case).unwrap().defaults)(),
            "{name}: not the defaults"
        );
    }
}

#[test]
fn couette_in_3d_converges_at_second_order() {
    // The 3D strip (periodic along x and z) has the same exact solution.
    // With summation density and the Morris operator the error approached
    // a floor of 3e-3 U (the cubic spline's 3D lattice bias); the
    // consistent operators have none, so raw errors fall at second order.
    let at = |n: usize| {
        let mut s = settings("couette");
        s.dim = 3;
        s.resolution = n;
        s.t_end = 0.1125;
        s.output_interval = 0.1125;
        let r = run(&s);
        assert!(r.complete(), "{:?}", r.stop);
        assert_eq!(r.frames[0].x.len(), r.n_fluid);
        r.outputs.last().unwrap().linf.unwrap()
    };
    let (e10, e20, e40) = (at(10), at(20), at(40));
    let (p1, p2) = ((e10 / e20).log2(), (e20 / e40).log2());
    assert!(
        p1 >= 1.8 && p2 >= 1.8,
        "orders {p1:.2}, {p2:.2} ({e10:e}, {e20:e}, {e40:e})"
    );
}

#[test]
fn couette_stays_exact_over_twenty_diffusion_times() {
    // Issue 10: at 40 across with the case's defaults, at most 1e-5 U at
    // every output from t* = 1 to t* = 20. The point-reflected plates keep
    // a sheared lattice symmetric, the consistent Laplacian is exact for
    // the linear profile on any arrangement and the corrected divergence
    // sees no compression in it, so the steady state is exact up to what
    // the start-up leaves and round-off.
    let mut s = settings("couette");
    s.t_end = 20.0;
    s.output_interval = 1.0;
    let r = run(&s);
    assert!(r.complete(), "{:?}", r.stop);
    for d in &r.outputs {
        let e = d.linf.unwrap();
        assert!(e <= 1e-5, "t* = {}: {e:e} U", d.t);
    }
}

/// The example custom scene's settings.
fn custom_channel() -> Settings {
    let path = format!(
        "{}/examples/custom-channel.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    let mut s = Settings::from_file(std::path::Path::new(&path)).unwrap();
    s.threads = 1;
    s
}

#[test]
fn a_scene_from_parts_reaches_the_couette_poiseuille_steady_state() {
    // examples/custom-channel.toml: a wall at rest and one sliding at U = 1,
    // a body force F along x, nu = 0.1; no built-in case has this flow. Its
    // steady state is u(y) = U y + F / (2 nu) y (1 - y), v = 0; the slowest
    // transient decays as exp(-pi^2 nu t), 3e-9 by t = 20.
    let mut s = custom_channel();
    s.t_end = 20.0;
    s.output_interval = 20.0;
    let r = run(&s);
    assert!(r.complete(), "{:?}", r.stop);
    let (f, nu) = (r.body_force[0], r.nu);
    assert!((f - 0.4).abs() < 1e-12 && (nu - 0.1).abs() < 1e-12);
    let last = r.frames.last().unwrap();
    assert_eq!(last.x.len(), 10 * 20);
    let mut worst = 0.0f64;
    for (x, v) in last.x.iter().zip(&last.v) {
        let y = x[1];
        let u = y + f / (2.0 * nu) * y * (1.0 - y);
        worst = worst.max(((v[0] - u).powi(2) + v[1].powi(2)).sqrt());
    }
    assert!(worst <= 1e-3, "{worst:e} U from the steady profile");
}

#[test]
fn couette_from_parts_is_the_built_in_couette() {
    // The built-in case's plates, strip and physics described as parts: the
    // same run to round-off (the box size is entered as a decimal).
    let text = r#"
case = "custom"
resolution = 16
re = 0.0125
t_end = 0.05
output_interval = 0.025
threads = 1
[scene]
origin = [0.0, 0.0]
extent = [3.75e-4, 1e-3]
periodic = ["x"]
rho0 = 1000.0
velocity_scale = 1.25e-5
length_scale = 1e-3
[[scene.walls]]
axis = "y"
side = "lower"
reflection = "point"
body_force_curvature = true
[[scene.walls]]
axis = "y"
side = "upper"
velocity = [1.25e-5, 0.0]
reflection = "point"
body_force_curvature = true
"#;
    let custom = run(&Settings::from_toml(text).unwrap());
    let mut s = settings("couette");
    s.resolution = 16;
    s.t_end = 0.05;
    s.output_interval = 0.025;
    let built_in = run(&s);
    assert_eq!(custom.n_fluid, built_in.n_fluid);
    assert_eq!(custom.steps, built_in.steps);
    for (a, b) in custom.frames.iter().zip(&built_in.frames) {
        for (va, vb) in a.v.iter().zip(&b.v) {
            assert!((va[0] - vb[0]).abs() <= 1e-9 * 1.25e-5, "{va:?} vs {vb:?}");
        }
    }
}

#[test]
fn scenes_from_parts_reject_what_they_cannot_build() {
    let base = std::fs::read_to_string(format!(
        "{}/examples/custom-channel.toml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let error = |text: &str| match Settings::from_toml(text) {
        Ok(s) => cases::scene(&s)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default(),
        Err(e) => e.to_string(),
    };
    // A wall on a periodic axis.
    let e = error(&base.replace(r#"periodic = ["x"]"#, r#"periodic = ["x", "y"]"#));
    assert!(
        e.contains("scene.walls.axis") && e.contains("periodic"),
        "{e}"
    );
    // A box that is not a whole number of dx.
    let e = error(&base.replace("extent = [0.5, 1.0]", "extent = [0.52, 1.0]"));
    assert!(e.contains("scene.extent") && e.contains("0.52"), "{e}");
    // A vector of the wrong dimension.
    let e = error(&base.replace("body_force = [0.4, 0.0]", "body_force = [0.4]"));
    assert!(e.contains("scene.body_force"), "{e}");
    // An unknown key inside [scene].
    let e = error(&base.replace(
        "rho0 = 1.0",
        "rho0 = 1.0
density0 = 1.0",
    ));
    assert!(e.contains("density0"), "{e}");
    // No [scene] table.
    let e = error("case = \"custom\"\n");
    assert!(e.contains("scene"), "{e}");
    // A [scene] table in a built-in case's file.
    let e = error("case = \"couette\"\n[scene]\nrho0 = 1.0\n");
    assert!(e.contains("unknown key"), "{e}");
}

#[test]
fn a_scene_built_in_code_gets_the_same_checks_as_the_settings() {
    // A library user can fill a Scene's physics directly, past the
    // settings' validation: the run refuses what the engine would ignore.
    let base = cases::scene(&settings("poiseuille")).unwrap();
    let refused = |edit: &dyn Fn(&mut scene::Scene), key: &str| {
        let mut s = base.clone();
        edit(&mut s);
        let e = scene::run(&s, &Silent).err().map(|e| e.to_string());
        let e = e.unwrap_or_else(|| panic!("{key}: accepted"));
        assert!(e.contains(key), "{key}: {e}");
    };
    use sph_std::config::{DensityMode, ViscosityForm};
    use sph_std::scene::PressureForm;
    refused(
        &|s| {
            s.physics.viscosity = ViscosityForm::Corrected;
            s.physics.alpha = 0.1;
        },
        "alpha",
    );
    refused(&|s| s.physics.alpha = f64::NAN, "alpha");
    refused(
        &|s| {
            s.physics.density = DensityMode::Summation;
            s.physics.pressure_gradient = PressureForm::Corrected;
        },
        "pressure_gradient",
    );
    refused(&|s| s.physics.gravity_ramp = -1.0, "gravity_ramp");
}
