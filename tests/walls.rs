//! Walls of any shape (sph_core::shape) against exact solutions: the
//! Taylor-Couette flow between a spinning inner and a fixed outer cylinder,
//! its spin-up against a reference this test computes itself, the tilted
//! channel against the aligned one, the drag of a periodic array of
//! cylinders against Sangani & Acrivos (1982), a closed tank under gravity
//! (square and circular) against hydrostatics, and no particle behind a
//! wall.

use sph_std::cases::{self, taylor_couette_steady, Settings};
use sph_std::couette::Silent;
use sph_std::scene::{self, RunRecord, WallBoundary};

const R1: f64 = 1.0;
const R2: f64 = 2.0;

fn taylor_couette(resolution: usize, t_end: f64, interval: f64) -> RunRecord {
    let mut s: Settings = (cases::find("taylor-couette").unwrap().defaults)();
    s.resolution = resolution;
    s.t_end = t_end;
    s.output_interval = interval;
    s.threads = 2;
    let r = scene::run(&cases::scene(&s).unwrap(), &Silent).unwrap();
    assert!(r.complete(), "{:?}", r.stop);
    r
}

/// The azimuthal spin-up by explicit finite differences (forward Euler on
/// `du/dt = nu (u'' + u'/r - u/r^2)`, 400 intervals): a different method
/// from the case's Crank-Nicolson reference, with its own error well below
/// the SPH error it checks.
fn explicit_spin_up(nu: f64, t: f64) -> Vec<f64> {
    let m = 400;
    let dr = (R2 - R1) / m as f64;
    let dt = 0.2 * dr * dr / nu;
    let steps = (t / dt).ceil() as usize;
    let dt = t / steps as f64;
    let mut u = vec![0.0; m + 1];
    u[0] = R1; // Omega R1 with Omega = 1
    let mut next = u.clone();
    for _ in 0..steps {
        for i in 1..m {
            let r = R1 + dr * i as f64;
            let d2 = (u[i + 1] - 2.0 * u[i] + u[i - 1]) / (dr * dr);
            let d1 = (u[i + 1] - u[i - 1]) / (2.0 * dr);
            next[i] = u[i] + dt * nu * (d2 + d1 / r - u[i] / (r * r));
        }
        next[0] = u[0];
        next[m] = 0.0;
        std::mem::swap(&mut u, &mut next);
    }
    u
}

/// Largest `|v - v_ref|` over the particles of a frame, relative to
/// `Omega R1 = 1`, for an azimuthal reference `u_theta(r)`.
fn worst(frame: &scene::Frame, reference: impl Fn(f64) -> f64) -> f64 {
    frame
        .x
        .iter()
        .zip(&frame.v)
        .map(|(x, v)| {
            let r = (x[0] * x[0] + x[1] * x[1]).sqrt();
            let u = reference(r);
            let (ex, ey) = (-u * x[1] / r, u * x[0] / r);
            ((v[0] - ex).powi(2) + (v[1] - ey).powi(2)).sqrt()
        })
        .fold(0.0, f64::max)
}

#[test]
fn taylor_couette_converges_to_the_steady_profile_and_follows_the_spin_up() {
    // Re 1: nu = 1; the steady state is reached by t = 2 (R2 - R1)^2 / nu.
    let mut errors = Vec::new();
    for n in [20, 40] {
        let r = taylor_couette(n, 2.0, 0.25);
        let last = r.frames.last().unwrap();
        let e = worst(last, taylor_couette_steady);
        // Every particle stays in the annulus.
        for x in &last.x {
            let radius = (x[0] * x[0] + x[1] * x[1]).sqrt();
            assert!(radius > R1 && radius < R2, "particle at r = {radius}");
        }
        // The spin-up at t = 0.25 against the explicit reference.
        let early = &r.frames[0];
        assert!((early.t - 0.25).abs() < 1e-12);
        let u = explicit_spin_up(1.0, 0.25);
        let spin = worst(early, |radius| {
            let f = (radius - R1) / (R2 - R1) * 400.0;
            let i = (f.floor() as usize).min(399);
            let w = f - i as f64;
            u[i] * (1.0 - w) + u[i + 1] * w
        });
        eprintln!("{n} across: steady Linf {e:.3e}, spin-up Linf {spin:.3e} (of Omega R1)");
        errors.push((n, e, spin));
    }
    let (_, e40, spin40) = errors[1];
    assert!(e40 <= 0.01, "40 across: {e40:.3e} of Omega R1");
    assert!(spin40 <= 0.02, "spin-up at 40 across: {spin40:.3e}");
    let order = (errors[0].1 / e40).log2();
    eprintln!("order 20 -> 40: {order:.2}");
    assert!(
        order > 0.5,
        "the error does not fall with resolution: {errors:?}"
    );
}

fn case(name: &str, resolution: usize, t_end: f64) -> RunRecord {
    let mut s: Settings = (cases::find(name).unwrap().defaults)();
    s.resolution = resolution;
    s.t_end = t_end;
    s.output_interval = 0.1;
    s.threads = 2;
    let r = scene::run(&cases::scene(&s).unwrap(), &Silent).unwrap();
    assert!(r.complete(), "{name}: {:?}", r.stop);
    r
}

#[test]
fn a_tilted_channel_on_the_box_lattice_matches_the_aligned_channel() {
    // The same Poiseuille start-up between walls at atan(4/7) to the axes,
    // particles on the box's lattice (not the channel's): the transient
    // error stays within 1.5x of the aligned case's at the same resolution.
    let aligned = case("poiseuille", 20, 0.5);
    let tilted = case("tilted-channel", 20, 1.0);
    for (a, t) in aligned.outputs.iter().zip(&tilted.outputs) {
        assert!((a.t - t.t).abs() < 1e-12);
        let (ea, et) = (a.linf.unwrap(), t.linf.unwrap());
        eprintln!(
            "t = {:.1}: aligned {ea:.3e}, tilted {et:.3e} (of u_max)",
            a.t
        );
        assert!(
            et <= 1.5 * ea,
            "t = {}: tilted {et:.3e} vs aligned {ea:.3e}",
            a.t
        );
    }
    // Near the steady state (t = 1 is e^-pi^2 of the slowest mode away) the
    // aligned channel sits on an exact discrete steady state, the tilted one
    // has the ordinary discretisation error, which must fall with dx.
    let fine = case("tilted-channel", 40, 1.0);
    let (coarse, fine) = (
        tilted.outputs.last().unwrap().linf.unwrap(),
        fine.outputs.last().unwrap().linf.unwrap(),
    );
    let order = (coarse / fine).log2();
    eprintln!(
        "tilted at t = 1: {coarse:.3e} (20 across), {fine:.3e} (40 across), order {order:.2}"
    );
    assert!(order > 1.0, "{coarse:.3e} -> {fine:.3e}");
}

/// The drag `F / (mu U)` at output `k` of a cylinder-array run.
fn drag_at(r: &RunRecord, k: usize) -> f64 {
    let mut upto = r.clone();
    upto.frames.truncate(k + 1);
    cases::cylinder_array_measured_drag(&upto).unwrap()
}

#[test]
fn a_square_array_of_cylinders_has_the_drag_of_sangani_and_acrivos() {
    // Stokes flow (Re 0.1) through one cylinder per periodic cell, driven
    // by a body force; the drag F / (mu U) at steady state against Sangani
    // & Acrivos (1982), Table 1, an independent (multipole) solution.
    let run = |phi: f64, resolution: usize| {
        let mut s: Settings = (cases::find("cylinder-array").unwrap().defaults)();
        s.solid_fraction = Some(phi);
        s.resolution = resolution;
        s.threads = 2;
        let r = scene::run(&cases::scene(&s).unwrap(), &Silent).unwrap();
        // A particle behind the wall stops the run: complete means none was.
        assert!(r.complete(), "phi {phi}: {:?}", r.stop);
        let k = cases::cylinder_array_drag(phi).unwrap();
        let n = r.frames.len();
        let (before, last) = (drag_at(&r, n - 2), drag_at(&r, n - 1));
        eprintln!(
            "phi {phi}, {resolution} across: K = {last:.3} against {k} ({:+.2} %)",
            100.0 * (last / k - 1.0)
        );
        // Steady: the drag of the last two outputs (0.1 apart, several
        // viscous times of the pores) agrees to 0.2 %.
        assert!(
            (before / last - 1.0).abs() < 2e-3,
            "not steady: {before} -> {last}"
        );
        (last / k - 1.0).abs()
    };
    for phi in [0.05, 0.1, 0.2] {
        let error = run(phi, 40);
        assert!(error <= 0.05, "phi {phi}: {:.2} %", 100.0 * error);
    }
    // And the deviation falls with resolution.
    let (coarse, fine) = (run(0.1, 20), run(0.1, 40));
    assert!(fine < 0.6 * coarse, "{coarse:.3e} -> {fine:.3e}");
}

fn closed_tank(container: &str, wall_boundary: &str, t_end: f64) -> RunRecord {
    let mut s = Settings::from_toml(&format!(
        "case = \"closed-tank\"\ncontainer = \"{container}\"\nwall_boundary = \"{wall_boundary}\"\n"
    ))
    .unwrap();
    s.threads = 2;
    s.t_end = t_end;
    let r = scene::run(&cases::scene(&s).unwrap(), &Silent).unwrap();
    // A particle behind a wall stops the run: complete means none crossed.
    assert!(r.complete(), "{container}: {:?}", r.stop);
    r
}

/// The hydrostatic bounds of the closed tank: over 20 acoustic crossing
/// times (c0 = 10 sqrt(g D), t = 2) the largest speed stays below 1e-3
/// sqrt(g D) at every output, and the pressure on the centre line at
/// depths D/4, D/2, 3D/4 is within 1 % of rho0 g D of the hydrostatic
/// field.
fn assert_at_rest(container: &str, r: &RunRecord) {
    for o in &r.outputs {
        let speed = o.linf.unwrap();
        assert!(
            speed < 1e-3,
            "{container}: speed {speed:.3e} at t = {}",
            o.t
        );
    }
    let probes = cases::closed_tank_pressure_probes(r).unwrap();
    assert_eq!(probes.len(), 3, "{container}");
    for (depth, sph, exact) in probes {
        eprintln!("{container}: depth {depth}: p = {sph:.4} against {exact:.4} rho0 g D");
        assert!(
            (sph - exact).abs() < 1e-2,
            "{container} depth {depth}: {sph} vs {exact}"
        );
    }
}

#[test]
fn a_closed_tank_under_gravity_stays_at_rest() {
    // A full container at rest under gravity, from the hydrostatic state:
    // the exact solution is v = 0 and p linear in depth. The ghosts carry
    // the weight of the fluid between them and their sources across the
    // box's planar walls and through their corners.
    assert_at_rest("square", &closed_tank("square", "mirror", 2.0));
}

#[test]
fn curved_and_polygonal_tanks_stay_at_rest_with_wall_particles() {
    // The same exact solution in a circle, a floor with a step (concave
    // corners, a convex one) and a hopper (sides at 45 degrees to the
    // lattice): shaped walls filled with wall particles.
    for container in ["circle", "hopper"] {
        assert_at_rest(container, &closed_tank(container, "particles", 2.0));
    }
    // The step over more than 1e4 steps (dt = 5.17e-4 at 40 across): no
    // particle crosses a wall (the run would stop) and the bounds still
    // hold at the end.
    assert_at_rest("step", &closed_tank("step", "particles", 5.5));
}

#[test]
fn mirrored_ghosts_are_refused_at_concave_corners() {
    let s = Settings::from_toml("case = \"closed-tank\"\ncontainer = \"step\"\n").unwrap();
    let e = cases::scene(&s).err().unwrap().to_string();
    assert!(e.contains("wall_boundary"), "{e}");
}

#[test]
fn a_circular_tank_with_mirrored_ghosts_keeps_its_particles() {
    // With mirrored ghosts the circle does not stay at rest to the
    // square's bounds (see the case docs); what it must do: no particle
    // crosses the curved wall and the walls hold the fluid's weight, the
    // pressure rising with depth at about rho0 g (between the probes at
    // D/4 and 3D/4, within 10 %).
    let r = closed_tank("circle", "mirror", 2.0);
    let probes = cases::closed_tank_pressure_probes(&r).unwrap();
    let slope = (probes[2].1 - probes[0].1) / (probes[2].0 - probes[0].0);
    assert!((slope - 1.0).abs() < 0.1, "dp/d(depth) = {slope} rho0 g");
}

/// The triangular duct's exact steady velocity along z at `x`
/// (examples/triangular-duct.toml: side 1, g = 3.6, nu = 0.1): `g / (nu h)
/// L1 L2 L3`, the `L` the distances from the three sides (White, Viscous
/// Fluid Flow, 3-3).
fn triangular_duct_exact(x: [f64; 3]) -> f64 {
    let (g, nu) = (3.6, 0.1);
    let s3 = 3f64.sqrt();
    let h = 0.5 * s3;
    let l1 = x[1];
    let l2 = 0.5 * (s3 * x[0] - x[1]);
    let l3 = 0.5 * (s3 * (1.0 - x[0]) - x[1]);
    g / (nu * h) * l1 * l2 * l3
}

/// The worst velocity error over the particles of the duct's last frame,
/// relative to the peak speed (1), and the count of particles outside
/// the triangle.
fn triangular_duct(resolution: usize, wall_boundary: &str) -> (f64, usize) {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/triangular-duct.toml"
    ))
    .unwrap();
    let mut s = Settings::from_toml(&text).unwrap();
    s.resolution = resolution;
    s.threads = 2;
    s.wall_boundary = wall_boundary.parse().unwrap();
    s.output_interval = s.t_end;
    let r = scene::run(&cases::scene(&s).unwrap(), &Silent).unwrap();
    assert!(r.complete(), "{resolution} {wall_boundary}: {:?}", r.stop);
    let frame = r.frames.last().unwrap();
    let mut worst = 0.0f64;
    let mut outside = 0;
    for (x, v) in frame.x.iter().zip(&frame.v) {
        let exact = triangular_duct_exact(*x);
        if exact < 0.0 {
            outside += 1;
        }
        let e = (v[0] * v[0] + v[1] * v[1] + (v[2] - exact).powi(2)).sqrt();
        worst = worst.max(e);
    }
    (worst, outside)
}

#[test]
fn a_triangular_duct_has_the_exact_poiseuille_profile() {
    // A polygon wall with 60-degree corners at an angle to the lattice, in
    // a scene from parts nobody tuned this method on: the steady flow along
    // an equilateral triangular duct against its closed form. Mirrored
    // ghosts (the example's choice): within 5 % of the peak at 20 across
    // and falling with resolution (at least 0.7th order: 10 -> 20 divides
    // the error by more than 1.6).
    let (coarse, out_coarse) = triangular_duct(10, "mirror");
    let (fine, out_fine) = triangular_duct(20, "mirror");
    eprintln!("triangular duct, mirrored ghosts: Linf {coarse:.3e} (10) {fine:.3e} (20)");
    assert_eq!(out_coarse + out_fine, 0);
    assert!(fine < 0.05, "{fine:.3e}");
    assert!(fine < 0.6 * coarse, "{coarse:.3e} -> {fine:.3e}");
    // Wall particles keep every particle inside and converge, but slip:
    // docs/validation.md gives their error.
    let (coarse, out_coarse) = triangular_duct(10, "particles");
    let (fine, out_fine) = triangular_duct(20, "particles");
    eprintln!("triangular duct, wall particles: Linf {coarse:.3e} (10) {fine:.3e} (20)");
    assert_eq!(out_coarse + out_fine, 0);
    assert!(fine < 0.6 * coarse, "{coarse:.3e} -> {fine:.3e}");
}

#[test]
fn bad_shapes_in_a_scene_file_are_named_errors() {
    // The duct's scene with one part changed: each error names the key.
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/triangular-duct.toml"
    ))
    .unwrap();
    let bad = |from: &str, to: &str| {
        assert!(text.contains(from));
        let s = Settings::from_toml(&text.replace(from, to)).unwrap();
        cases::scene(&s).err().unwrap().to_string()
    };
    // A polygon whose edges cross (a bow tie).
    let e = bad(
        "vertices = [[0.0, 0.0], [1.0, 0.0], [0.5, 0.8660254037844386]]",
        "vertices = [[0.0, 0.0], [1.0, 0.8], [1.0, 0.0], [0.0, 0.8]]",
    );
    assert!(e.contains("scene.shapes[0].vertices"), "{e}");
    // Two vertices.
    let e = bad(
        "vertices = [[0.0, 0.0], [1.0, 0.0], [0.5, 0.8660254037844386]]",
        "vertices = [[0.0, 0.0], [1.0, 0.0]]",
    );
    assert!(e.contains("scene.shapes[0].vertices"), "{e}");
    // A circle in a 3D scene.
    let e = bad(
        "kind = \"polygon\"\nvertices = [[0.0, 0.0], [1.0, 0.0], [0.5, 0.8660254037844386]]",
        "kind = \"circle\"\ncenter = [0.5, 0.3]\nradius = 0.2",
    );
    assert!(e.contains("scene.shapes[0].kind"), "{e}");
}

fn rotating_tank(keys: &str, resolution: usize, t_end: f64) -> RunRecord {
    let mut s = Settings::from_toml(&format!("case = \"rotating-tank\"\n{keys}")).unwrap();
    s.threads = 2;
    s.resolution = resolution;
    s.t_end = t_end;
    s.output_interval = t_end / 2.0;
    let r = scene::run(&cases::scene(&s).unwrap(), &Silent).unwrap();
    // A particle behind the moving wall stops the run.
    assert!(r.complete(), "{keys}: {:?}", r.stop);
    r
}

/// The largest velocity error over the outputs (relative to the rim speed)
/// and the largest pressure probe deviation at the end (relative to
/// `rho0 Omega^2 D^2 / 4`).
fn rigid_errors(r: &RunRecord) -> (f64, f64) {
    let linf = r
        .outputs
        .iter()
        .map(|o| o.linf.unwrap())
        .fold(0.0, f64::max);
    let probes = cases::rotating_tank_pressure_probes(r).unwrap();
    assert_eq!(probes.len(), 3);
    let p = probes
        .iter()
        .map(|(_, sph, exact)| (sph - exact).abs())
        .fold(0.0, f64::max);
    (linf, p)
}

#[test]
fn fluid_in_a_turning_tank_turns_with_it() {
    // A square container (four concave corners) turning at Omega about its
    // centre, full of fluid in the same rigid rotation: the exact solution
    // keeps it, whatever the viscosity. The wall particles travel with the
    // container, carry its centripetal acceleration in their pressure and
    // reflect the fluid's velocity relative to the turning wall. A full
    // turn at 20 and 40 across: the rotation is kept to a small fraction of
    // the issue's 1e-3 of the rim speed, and the errors fall with the
    // spacing.
    let turn = 2.0 * std::f64::consts::PI;
    let (coarse, p_coarse) = rigid_errors(&rotating_tank("", 20, turn));
    let (fine, p_fine) = rigid_errors(&rotating_tank("", 40, turn));
    eprintln!("square: Linf {coarse:.3e} (20) {fine:.3e} (40); probes {p_coarse:.3e} {p_fine:.3e}");
    assert!(fine < 1e-4, "Linf {fine:.3e} at 40 across");
    assert!(p_fine < 5e-3, "probes {p_fine:.3e} at 40 across");
    assert!(fine < 0.6 * coarse, "{coarse:.3e} -> {fine:.3e}");
    assert!(p_fine < 0.6 * p_coarse, "{p_coarse:.3e} -> {p_fine:.3e}");
}

#[test]
fn travelling_turning_tanks_of_other_shapes_keep_their_rigid_motion() {
    // Cases nobody tuned: the hopper (sides at 45 degrees) and the step
    // (concave and convex corners) turning and travelling, and the circle
    // turning, for half a turn at 40 across: the same bounds as the square.
    let half = std::f64::consts::PI;
    for keys in [
        "container = \"hopper\"\ndrift = [0.4, 0.2]\n",
        "container = \"step\"\ndrift = [-0.3, 0.5]\n",
        "container = \"circle\"\n",
    ] {
        let (linf, p) = rigid_errors(&rotating_tank(keys, 40, half));
        eprintln!("{keys}: Linf {linf:.3e}, probes {p:.3e}");
        assert!(linf < 1e-4 && p < 5e-3, "{keys}: {linf:.3e} {p:.3e}");
    }
    // The square refuses mirrored ghosts (its corners are concave).
    let s = Settings::from_toml("case = \"rotating-tank\"\nwall_boundary = \"mirror\"\n").unwrap();
    let e = cases::scene(&s).err().unwrap().to_string();
    assert!(e.contains("wall_boundary"), "{e}");
}

/// A custom scene: a circular container of radius 0.4 moving at `(0.2,
/// 0.1)` through an open box, full of fluid moving with it.
const MOVING_CIRCLE: &str = r#"
case = "custom"
resolution = 20
re = 10.0
t_end = 1.0
output_interval = 0.5
wall_boundary = "particles"
density = "summation"

[scene]
origin = [-0.1, -0.1]
extent = [1.4, 1.3]
rho0 = 1.0
velocity_scale = 1.0
length_scale = 1.0
velocity = { profile = "uniform", value = [0.2, 0.1] }

[[scene.regions]]
lo = [0.1, 0.1]
hi = [0.9, 0.9]

[[scene.shapes]]
kind = "circle"
center = [0.5, 0.5]
radius = 0.4
fluid_inside = true
moves = { velocity = [0.2, 0.1] }
"#;

#[test]
fn a_shape_moving_in_a_custom_scene_carries_its_fluid() {
    // Galilean invariance through a moving wall: fluid at rest relative to
    // a translating container stays so. No exact solution is built into a
    // custom scene; this test's is every particle at (0.2, 0.1). With
    // summation density the fluid next to the wall counts the wall
    // particles as neighbours: they must travel with the container, or the
    // density at its trailing side falls and the fluid moves.
    let mut s = Settings::from_toml(MOVING_CIRCLE).unwrap();
    s.threads = 2;
    let sc = cases::scene(&s).unwrap();
    let r = scene::run(&sc, &Silent).unwrap();
    assert!(r.complete(), "{:?}", r.stop);
    let last = r.frames.last().unwrap();
    assert_eq!(last.x.len(), r.n_fluid);
    let worst = last
        .v
        .iter()
        .map(|v| (v[0] - 0.2).hypot(v[1] - 0.1))
        .fold(0.0, f64::max);
    // The container's centre has moved to (0.7, 0.6): every particle is
    // inside it.
    let outside = last
        .x
        .iter()
        .filter(|x| (x[0] - 0.7).hypot(x[1] - 0.6) > 0.4)
        .count();
    eprintln!("moving circle: worst |v - V| {worst:.3e}, {outside} outside");
    assert!(worst < 1e-3, "{worst:.3e}");
    assert_eq!(outside, 0);
    // A moving shape takes its motion from `moves` only.
    let e = Settings::from_toml(&MOVING_CIRCLE.replace(
        "fluid_inside = true\n",
        "fluid_inside = true\nomega = 1.0\n",
    ))
    .and_then(|s| cases::scene(&s))
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("scene.shapes[0].moves"), "{e}");
}

/// A custom scene at 20 across (dx = 0.05, cubic support 0.13) in a unit
/// box periodic both ways, the fluid at rest and driven along y by a body
/// force of 4: `settings` are the top-level keys above `[scene]`, `shapes`
/// the `[[scene.shapes]]` tables.
fn periodic_driven_scene(settings: &str, shapes: &str) -> String {
    format!(
        r#"
case = "custom"
resolution = 20
re = 1.0
{settings}

[scene]
origin = [0.0, 0.0]
extent = [1.0, 1.0]
periodic = ["x", "y"]
rho0 = 1.0
velocity_scale = 1.0
length_scale = 1.0
body_force = [0.0, 4.0]
velocity = {{ profile = "rest" }}

{shapes}
"#
    )
}

/// A plate `thickness` thick (0.2 to 0.8 along x, centred at y = 0.5),
/// fluid on both sides, falling past it.
fn plate(thickness: f64, wall_boundary: &str) -> String {
    let (lo, hi) = (0.5 - 0.5 * thickness, 0.5 + 0.5 * thickness);
    periodic_driven_scene(
        &format!(
            r#"t_end = 0.02
output_interval = 0.02
wall_boundary = "{wall_boundary}""#
        ),
        &format!(
            r#"[[scene.shapes]]
kind = "polygon"
vertices = [[0.2, {lo}], [0.8, {lo}], [0.8, {hi}], [0.2, {hi}]]
fluid_inside = false"#
        ),
    )
}

#[test]
fn a_solid_thinner_than_the_support_is_refused() {
    // A plate 0.8 dx thick holds no lattice point: with wall particles the
    // fluid fell through it at the free-fall speed; with mirrored ghosts
    // both sides' images crowded into one neighbourhood. Any solid thinner
    // than a kernel support lets the fluid on one side see the other's.
    // The run refuses it before any step, naming the shape.
    for thickness in [0.04, 0.1] {
        for boundary in ["particles", "mirror"] {
            let mut s = Settings::from_toml(&plate(thickness, boundary)).unwrap();
            s.threads = 2;
            let e = scene::run(&cases::scene(&s).unwrap(), &Silent)
                .err()
                .unwrap_or_else(|| panic!("a plate {thickness} thick ran ({boundary})"))
                .to_string();
            assert!(
                e.contains("scene.shapes[0]") && e.contains("support"),
                "{e}"
            );
        }
    }
    // Two supports thick, it runs, and no particle crosses it.
    for boundary in ["particles", "mirror"] {
        let mut s = Settings::from_toml(&plate(0.3, boundary)).unwrap();
        s.threads = 2;
        let r = scene::run(&cases::scene(&s).unwrap(), &Silent).unwrap();
        assert!(r.complete(), "{boundary}: {:?}", r.stop);
    }
}

/// Two cylinders of radius 0.2 at (0.25, 0.5) and (0.75, 0.5) in the
/// periodic box, so that the fluid between them passes through gaps 0.1
/// wide (2 dx), narrower than the cubic kernel's support (2.6 dx).
fn narrow_gaps() -> String {
    periodic_driven_scene(
        r#"t_end = 2.0
output_interval = 0.5
regularise = "shifting""#,
        r#"[[scene.shapes]]
kind = "circle"
center = [0.25, 0.5]
radius = 0.2

[[scene.shapes]]
kind = "circle"
center = [0.75, 0.5]
radius = 0.2"#,
    )
}

#[test]
fn walls_closer_than_a_support_keep_their_fluid() {
    // In a gap narrower than a support, a particle sees both walls' images
    // (or wall particles) at once. Neither boundary method may leak a
    // particle into a cylinder, and the two, built on different rules,
    // must carry the same flow through the gaps. By the scene's mirror
    // symmetry about x = 1/2 the mean x velocity is zero.
    let mut flow = Vec::new();
    for (boundary, method) in [
        ("mirror", WallBoundary::Mirror),
        ("particles", WallBoundary::Particles),
    ] {
        let mut s = Settings::from_toml(&narrow_gaps()).unwrap();
        s.wall_boundary = method;
        s.threads = 2;
        let dx = 1.0 / s.resolution as f64;
        assert!(0.1 < 2.6 * dx, "the gap must be narrower than a support");
        let r = scene::run(&cases::scene(&s).unwrap(), &Silent).unwrap();
        assert!(r.complete(), "{boundary}: {:?}", r.stop);
        for f in &r.frames {
            assert_eq!(f.x.len(), r.n_fluid, "{boundary} at t = {}", f.t);
            let inside =
                f.x.iter()
                    .filter(|x| {
                        [0.25, 0.75]
                            .iter()
                            .any(|c| (x[0] - c).hypot(x[1] - 0.5) < 0.2)
                    })
                    .count();
            assert_eq!(
                inside, 0,
                "{boundary}: particles in a cylinder at t = {}",
                f.t
            );
        }
        let last = r.frames.last().unwrap();
        let n = last.v.len() as f64;
        let (vx, vy) = last
            .v
            .iter()
            .fold((0.0, 0.0), |(a, b), v| (a + v[0] / n, b + v[1] / n));
        eprintln!("{boundary}: mean velocity ({vx:.2e}, {vy:.4e}) at t = 2");
        assert!(vy > 0.0 && vx.abs() < 1e-9 * vy, "{boundary}: ({vx}, {vy})");
        flow.push(vy);
    }
    let spread = (flow[0] - flow[1]).abs() / flow[0];
    assert!(
        spread < 0.1,
        "mirror {} against particles {}",
        flow[0],
        flow[1]
    );
}
