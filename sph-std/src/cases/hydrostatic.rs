//! `hydrostatic`: a tank with a free surface at rest under gravity
//! (`docs/physics.md` 6.e; Adami, Hu & Adams 2012, section 6).
//!
//! Water of depth `H = 1` in a tank `2H` wide (2D; in 3D also `H` deep
//! along z, walls on every side), the box's planar no-slip walls below and
//! at the sides with the hydrostatic ghost pressure, the top open: the
//! surface is free. Gravity `g = 1` along `-y`, ramped from zero over
//! `gravity_ramp` (1 by default, `g(t) = g (1 - cos(pi t / T)) / 2`), so
//! the fluid starts at rest at `rho0` and settles without a pressure wave;
//! with `gravity_ramp = 0` it starts from the incompressible hydrostatic
//! pressure instead. `rho0 = 1`, `c0 = 10 sqrt(g H)` (`sound_speed_factor`
//! times the velocity scale `sqrt(g H)`), the Tait equation, continuity
//! density with delta-SPH diffusion (`delta = 0.1`, hydrostatic part left
//! alone), the Morris viscosity at `Re = sqrt(g H) H / nu = 100`, the
//! quintic kernel at `beta = 1.0` (its lattice gradient bias is the
//! smallest; with the cubic at 1.3 the equilibrium pressure slope is
//! 0.8 % shallow, a bias that does not shrink with resolution). The run
//! ends 20 acoustic crossing times `H / c0` after the ramp (`t = 3`).
//! `resolution` counts particles across the depth.
//!
//! The exact state is rest, `v = 0` (the velocity error is the largest
//! speed), with the pressure of a weakly compressible column: from the
//! floor, where it carries the column's weight `p = rho0 g H` (mass is
//! conserved, so this holds however the fluid compresses), `dp/dy = -g
//! rho(p)` with `rho(p)` the equation of state's inverse, in closed form
//! for both equations ([`exact_pressure`]). The compression lowers the
//! surface by about `g H^2 / (2 c0^2)`, half a per cent of `H`, which the
//! incompressible `rho0 g (H - y)` would count as an error of that size.
//! `reference` in summary.json gives pressure probes on the vertical
//! centre line at depths `H/4`, `H/2` and `3H/4` below the initial
//! surface (a least-squares plane through the pressures of the particles
//! within `2 dx`, so that a lattice settled by a fraction of `dx` does not
//! bias it), relative to `rho0 g H`.
//!
//! Summation density is refused: at a free surface the kernel support is
//! cut and summation gives the surface particles a density deficit of up
//! to half, a pressure far below the surface's zero. A background pressure
//! is refused too: a free surface holds `p = 0`.

use std::sync::Arc;

use super::{Case, Reference, Settings};
use crate::config::{check, DensityMode, KernelName};
use crate::error::Result;
use crate::plot::{line_plot, Axes, Series, REFERENCE};
use crate::scene::{ramp_factor, AxisSpec, EosForm, Region, RunRecord, Scene, WallSpec};

/// The case's table entry.
pub const CASE: Case = Case {
    name: "hydrostatic",
    about: "a tank with a free surface at rest under gravity (2D or 3D): pressure against the compressible hydrostatic column, spurious speeds",
    defaults,
    build,
    figure,
    reference,
};

/// Gravity.
const G: f64 = 1.0;
/// The depth.
const H: f64 = 1.0;
/// The tank's width along x (and, in 3D, `H` along z).
const WIDTH: f64 = 2.0 * H;
/// The box's height: room above the surface for the open top.
const TOP: f64 = 1.25 * H;

fn defaults() -> Settings {
    let mut s = Settings::base("hydrostatic", 40, 3.0, 0.25, 100.0);
    // The quintic kernel at beta 1.0: the smallest gradient bias on a
    // lattice (the cubic at 1.3 leaves the pressure slope 0.8 % shallow:
    // docs/validation.md).
    s.kernel = KernelName::Quintic;
    s.beta = 1.0;
    s.density = DensityMode::Continuity;
    s.eos = EosForm::Tait;
    s.gravity_ramp = Some(1.0);
    s.energy_budget = true;
    s
}

/// The checks every free-surface case makes of its settings.
pub(crate) fn free_surface_settings(s: &Settings) -> Result<()> {
    check(
        s.density != DensityMode::Summation,
        "density",
        s.density,
        "summation density is wrong at a free surface (the kernel support is cut there): use \"continuity\" or \"corrected\"",
    )?;
    check(
        s.background_pressure == 0.0,
        "background_pressure",
        s.background_pressure,
        "must be 0 with a free surface (its pressure is zero)",
    )
}

fn build(s: &Settings) -> Result<Scene> {
    free_surface_settings(s)?;
    let dim = s.dim;
    let dx = H / s.resolution as f64;
    let rho0 = 1.0;
    let scale = (G * H).sqrt();
    let nu = scale * H / s.re;
    let ramp = s.gravity_ramp.unwrap_or(0.0);
    // Without a ramp the fluid starts from the incompressible hydrostatic
    // pressure; with one it starts at rest at rho0, gravity off.
    let on = ramp_factor(0.0, ramp);
    let pressure: crate::scene::ScalarField = Arc::new(move |x| on * rho0 * G * (H - x[1]));
    let side = || AxisSpec::Walls(Some(WallSpec::at_rest()), Some(WallSpec::at_rest()));
    let (extent, z_axis, hi_z) = if dim == 3 {
        ([WIDTH, TOP, H], side(), H)
    } else {
        ([WIDTH, TOP, 0.0], AxisSpec::Periodic, 0.0)
    };
    Ok(Scene {
        case: s.case.clone(),
        dim,
        origin: [0.0; 3],
        extent,
        axes: [
            side(),
            AxisSpec::Walls(Some(WallSpec::at_rest()), None),
            z_axis,
        ],
        dx,
        regions: vec![Region {
            lo: [0.0; 3],
            hi: [WIDTH, H, hi_z],
        }],
        shaped_walls: Vec::new(),
        initial: None,
        summary: vec![
            ("depth".into(), H.into()),
            ("width".into(), WIDTH.into()),
            ("gravity".into(), G.into()),
            ("gravity_ramp".into(), ramp.into()),
            (
                "exact".into(),
                "at rest: v = 0, dp/dy = -g rho(p) from p = rho0 g H at the floor".into(),
            ),
        ],
        velocity: None,
        pressure: Some(pressure),
        body_force: [0.0, -G, 0.0],
        rho0,
        nu,
        physics: s.physics(scale, rho0),
        output_times: s.output_times(),
        velocity_scale: scale,
        length_scale: H,
        exact: Some(Arc::new(|_, _| [0.0; 3])),
        error_decay: 0.0,
        monitor: s.monitor(),
        steady_tolerance: None,
        threads: s.threads,
        keep_particles: true,
        allow_long_run: false,
    })
}

/// The gauge pressure at height `y` above the floor of a column at rest
/// whose weight per unit area is `p_floor`, under gravity `g`, for the
/// equation of state `eos` (reference density `rho0`, sound speed `c0`):
/// the solution of `dp/dy = -g rho(p)`, `p(0) = p_floor`.
///
/// Linear, `rho = rho0 + p / c0^2`: `p + rho0 c0^2` decays as
/// `exp(-g y / c0^2)`. Tait, `rho = rho0 (1 + p / B)^(1/gamma)`,
/// `B = rho0 c0^2 / gamma`: `(1 + p/B)^(1 - 1/gamma)` falls linearly,
/// by `(1 - 1/gamma) g rho0 y / B`.
pub fn exact_pressure(eos: EosForm, rho0: f64, c0: f64, g: f64, p_floor: f64, y: f64) -> f64 {
    let c2 = c0 * c0;
    match eos {
        EosForm::Linear => (p_floor + rho0 * c2) * libm::exp(-g * y / c2) - rho0 * c2,
        EosForm::Tait => {
            let gamma = 7.0;
            let b = rho0 * c2 / gamma;
            let e = 1.0 - 1.0 / gamma;
            let top = libm::pow(1.0 + p_floor / b, e) - e * g * rho0 * y / b;
            b * (libm::pow(top.max(0.0), 1.0 / e) - 1.0)
        }
    }
}

/// The pressure of a run's last output against the exact column:
/// `(depth / H, sph, exact)` at probes on the vertical centre line at
/// depths `H/4`, `H/2`, `3H/4` below the initial surface, both in units of
/// `rho0 g H` (the gauge pressure of the particles within `2 dx`, by a
/// least-squares plane: [`super::probe_linear`]).
pub fn pressure_probes(record: &RunRecord) -> Option<Vec<(f64, f64, f64)>> {
    let frame = record.frames.last()?;
    let g = -record.body_force[1];
    let unit = record.rho0 * g * H;
    if unit.is_nan() || unit <= 0.0 {
        return None;
    }
    let ph = record.physics;
    let centre_z = if record.dim == 3 { 0.5 * H } else { 0.0 };
    [0.25, 0.5, 0.75]
        .iter()
        .map(|&depth| {
            let y = H * (1.0 - depth);
            let point = [0.5 * WIDTH, y, centre_z];
            let p = super::probe_linear(frame, record.dim, point, 2.0 * record.dx, |k| {
                frame.p[k] - ph.background_pressure
            })?;
            let exact = exact_pressure(ph.eos, record.rho0, ph.sound_speed, g, unit, y);
            Some((depth, p / unit, exact / unit))
        })
        .collect()
}

fn reference(record: &RunRecord) -> Option<Reference> {
    Some(super::probes_reference(
        "hydrostatics of the compressible column: dp/dy = -g rho(p), p = rho0 g H at the floor",
        "p/(rho0 g H) at depth/H",
        record.frames.last()?.t,
        pressure_probes(record)?,
    ))
}

/// Every particle's pressure against its height at the last output, and
/// the exact column.
fn figure(_scene: &Scene, record: &RunRecord) -> Result<Vec<u8>> {
    let g = -record.body_force[1];
    let unit = record.rho0 * g * H;
    let ph = record.physics;
    let mut series = vec![Series {
        label: "exact (compressible column)".into(),
        points: (0..=100)
            .map(|i| {
                let y = H * i as f64 / 100.0;
                let p = exact_pressure(ph.eos, record.rho0, ph.sound_speed, g, unit, y);
                (y / H, p / unit)
            })
            .collect(),
        color: REFERENCE,
        line: true,
        markers: false,
    }];
    if let Some(f) = record.frames.last() {
        series.push(Series {
            label: format!("SPH, t = {:.2}", f.t),
            points: f
                .x
                .iter()
                .zip(&f.p)
                .map(|(x, p)| (x[1] / H, (p - ph.background_pressure) / unit))
                .collect(),
            color: 0,
            line: false,
            markers: true,
        });
    }
    line_plot(
        &Axes {
            title: "hydrostatic: pressure against height".into(),
            x: "y / H".into(),
            y: "p / (rho0 g H)".into(),
            log_x: false,
            log_y: false,
        },
        &series,
    )
}
