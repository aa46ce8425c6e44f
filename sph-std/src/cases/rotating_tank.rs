//! `rotating-tank`: a closed container full of fluid, turning (and, with
//! `drift`, travelling) as a rigid body, the fluid turning with it.
//!
//! The container is one of `closed-tank`'s (size `D = 1`, the fluid
//! inside): the square (default, as a polygon: four concave corners), the
//! circle, the step or the hopper, as one wall that moves as a rigid body
//! (`sph_core::shape::ShapedWall::moving`). It turns anticlockwise at
//! `Omega = 1` about its centre `c`, which travels at `drift * U` (zero by
//! default), `U = Omega D / 2` the rim speed of the circle. There is no
//! gravity. `nu` from `Re = U D / nu` (10 by default), `c0 = 10 U`, the
//! consistent operators, no density diffusion, and wall particles by
//! default (the square, step and hopper have concave corners, where
//! mirrored ghosts let particles through: `wall_boundary = "mirror"` is
//! refused for them). `resolution` counts particles across `D`; the end
//! time is one turn, `2 pi / Omega`.
//!
//! The fluid starts in the state it must keep: rigid-body motion with the
//! container, `v = V + Omega z x (x - c(t))`, and the pressure that holds
//! it on its circles, `p = rho0 Omega^2 |x - c|^2 / 2` (zero at the centre),
//! with continuity density from it. Viscosity does no work on a rigid
//! motion, so the exact solution is that state at every time, whatever
//! `Re`: the velocity error is against it, relative to `U`. The wall
//! particles travel with the container and their pressure carries the
//! centripetal acceleration of the wall (`p_w` with `g - a_w`,
//! docs/physics.md 5.5). `reference` in summary.json lists the pressure at
//! three probes fixed in the container (its centre, and `D/4` and `0.4 D`
//! out along its turning x axis; the mean of the particles within `1.5 dx`),
//! relative to `rho0 Omega^2 (D/2)^2`, after removing the mean offset from
//! the exact field (a closed container fixes its mass, not its pressure
//! level).

use std::sync::Arc;

use sph_core::prelude::ShapedWall;

use super::closed_tank::{container_shape, Container};
use super::{Case, Reference, Settings};
use crate::config::check;
use crate::error::{Error, Result};
use crate::scene::{AxisSpec, Region, RunRecord, Scene, WallBoundary};

/// The case's table entry.
pub const CASE: Case = Case {
    name: "rotating-tank",
    about: "a closed container (square; circle, step or hopper) full of fluid turning with it as a rigid body (drift = [ux, uy] also moves it): the rigid motion kept",
    defaults,
    build,
    figure,
    reference,
};

/// The container's size.
const D: f64 = 1.0;
/// Its turn rate.
const OMEGA: f64 = 1.0;

fn defaults() -> Settings {
    let turn = 2.0 * std::f64::consts::PI / OMEGA;
    let mut s = Settings::base("rotating-tank", 40, turn, 0.25 * turn, 10.0).consistent();
    s.density_diffusion = 0.0;
    s.wall_boundary = WallBoundary::Particles;
    s.container = Some(Container::Square);
    s.drift = Some(vec![0.0, 0.0]);
    s
}

/// The motion of a run: the container's centre at time zero and its
/// velocity (global coordinates).
fn motion(s: &Settings) -> Result<([f64; 3], [f64; 3])> {
    let u = 0.5 * OMEGA * D;
    let drift = match &s.drift {
        None => [0.0; 2],
        Some(v) => {
            check(
                v.len() == 2 && v.iter().all(|c| c.is_finite()),
                "drift",
                format!("{v:?}"),
                "must be two finite numbers [ux, uy] (the container's velocity over its rim speed)",
            )?;
            [v[0], v[1]]
        }
    };
    Ok(([0.5 * D, 0.5 * D, 0.0], [drift[0] * u, drift[1] * u, 0.0]))
}

fn build(s: &Settings) -> Result<Scene> {
    super::only_2d(s)?;
    let container = s.container.unwrap_or(Container::Square);
    if container != Container::Circle && s.wall_boundary == WallBoundary::Mirror {
        return Err(Error::config(
            "wall_boundary",
            "mirror",
            "the square, step and hopper containers have concave corners, where mirrored ghosts let particles through: use wall_boundary = \"particles\"",
        ));
    }
    let dx = D / s.resolution as f64;
    let rho0 = 1.0;
    let u = 0.5 * OMEGA * D;
    let nu = u * D / s.re;
    let (c0, velocity) = motion(s)?;
    // The box holds the turning container with its wall layer (the support
    // and rows to spare) in every orientation: the corners of the square's
    // layer sweep a circle of radius (D/2 + layer) sqrt 2. Its margin is a
    // whole number of spacings, so the box's lattice meets the container's
    // sides; the travel widens it along the drift.
    let layer = (2.0 * s.beta * 1.5).ceil() * dx + 2.0 * dx;
    let sweep = (0.5 * D + layer) * std::f64::consts::SQRT_2 - 0.5 * D;
    let margin = (sweep / dx).ceil() * dx + 2.0 * dx;
    let t_end = s.t_end;
    let mut origin = [-margin, -margin, 0.0];
    let mut extent = [D + 2.0 * margin, D + 2.0 * margin, 0.0];
    for a in 0..2 {
        let travel = (velocity[a] * t_end / dx).abs().ceil() * dx;
        if velocity[a] < 0.0 {
            origin[a] -= travel;
        }
        extent[a] += travel;
    }
    let wall = ShapedWall::new(container_shape(container)?).moving(velocity, OMEGA, c0);
    let centre = move |t: f64| [c0[0] + velocity[0] * t, c0[1] + velocity[1] * t];
    let exact: crate::scene::VectorField = Arc::new(move |x, t| {
        let c = centre(t);
        [
            velocity[0] - OMEGA * (x[1] - c[1]),
            velocity[1] + OMEGA * (x[0] - c[0]),
            0.0,
        ]
    });
    let start = exact.clone();
    let pressure: crate::scene::ScalarField = Arc::new(move |x| {
        let r2 = (x[0] - c0[0]).powi(2) + (x[1] - c0[1]).powi(2);
        0.5 * rho0 * OMEGA * OMEGA * r2
    });
    Ok(Scene {
        case: s.case.clone(),
        dim: 2,
        origin,
        extent,
        axes: [
            AxisSpec::Walls(None, None),
            AxisSpec::Walls(None, None),
            AxisSpec::Periodic,
        ],
        dx,
        regions: vec![Region {
            lo: [0.0; 3],
            hi: [D, D, 0.0],
        }],
        shaped_walls: vec![wall],
        initial: None,
        summary: vec![
            (
                "container".into(),
                serde_json::to_value(container).unwrap_or_default(),
            ),
            ("size".into(), D.into()),
            ("omega".into(), OMEGA.into()),
            ("center".into(), serde_json::json!([c0[0], c0[1]])),
            (
                "drift_velocity".into(),
                serde_json::json!([velocity[0], velocity[1]]),
            ),
            (
                "exact".into(),
                "rigid motion: v = V + Omega z x (x - c(t)), p = rho0 Omega^2 |x - c|^2 / 2 plus a constant".into(),
            ),
        ],
        velocity: Some(start),
        pressure: Some(pressure),
        body_force: [0.0; 3],
        rho0,
        nu,
        physics: s.physics(u, rho0),
        output_times: s.output_times(),
        velocity_scale: u,
        length_scale: D,
        exact: Some(exact),
        error_decay: 0.0,
        monitor: s.monitor(),
        steady_tolerance: None,
        threads: s.threads,
        keep_particles: true,
        allow_long_run: false,
    })
}

/// The pressure of a run's last output against the exact field at probes
/// fixed in the container: `(distance from the centre / D, sph, exact)`,
/// both relative to `rho0 Omega^2 (D/2)^2`, the run's pressure shifted by
/// its mean offset from the exact field over every particle.
pub fn pressure_probes(record: &RunRecord) -> Option<Vec<(f64, f64, f64)>> {
    let frame = record.frames.last()?;
    let key = |name: &str| {
        record
            .summary
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.clone())
    };
    let pair = |name: &str| -> Option<[f64; 2]> {
        let v = key(name)?;
        Some([v.get(0)?.as_f64()?, v.get(1)?.as_f64()?])
    };
    let omega = key("omega")?.as_f64()?;
    let c0 = pair("center")?;
    let v = pair("drift_velocity")?;
    let t = frame.t;
    let c = [c0[0] + v[0] * t, c0[1] + v[1] * t];
    let unit = record.rho0 * (omega * 0.5 * D).powi(2);
    if unit.is_nan() || unit <= 0.0 {
        return None;
    }
    let exact = |x: &[f64; 3]| {
        0.5 * record.rho0 * omega * omega * ((x[0] - c[0]).powi(2) + (x[1] - c[1]).powi(2))
    };
    let offset = frame
        .x
        .iter()
        .zip(&frame.p)
        .map(|(x, p)| p - exact(x))
        .sum::<f64>()
        / frame.p.len() as f64;
    let radius = 1.5 * record.dx;
    let (cos, sin) = ((omega * t).cos(), (omega * t).sin());
    [0.0, 0.25, 0.4]
        .iter()
        .map(|&r| {
            let probe = [c[0] + r * D * cos, c[1] + r * D * sin, 0.0];
            let near: Vec<f64> = frame
                .x
                .iter()
                .zip(&frame.p)
                .filter(|(x, _)| libm::hypot(x[0] - probe[0], x[1] - probe[1]) <= radius)
                .map(|(_, p)| p - offset)
                .collect();
            (!near.is_empty()).then(|| {
                let mean = near.iter().sum::<f64>() / near.len() as f64;
                (r, mean / unit, exact(&probe) / unit)
            })
        })
        .collect()
}

fn reference(record: &RunRecord) -> Option<Reference> {
    Some(super::probes_reference(
        "rigid rotation: p = rho0 Omega^2 r^2 / 2 + const",
        "p/(rho0 Omega^2 D^2/4) at r/D",
        record.frames.last()?.t,
        pressure_probes(record)?,
    ))
}

/// The particles at the last output, coloured by speed, the container
/// where it is then.
fn figure(scene: &Scene, record: &RunRecord) -> Result<Vec<u8>> {
    super::custom::speed_figure(scene, record, "Rotating tank")
}
