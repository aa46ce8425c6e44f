//! `closed-tank`: a closed container full of fluid at rest under gravity,
//! against the hydrostatic state it must keep.
//!
//! The container is the unit square (the box's four planar walls, corner
//! images included) or, with `container = "circle"`, a circle of diameter
//! 1 (one [`Shape::Ball`] wall with the fluid inside; the box's lattice
//! clipped to the points at least `dx/2` inside, so that the interior stays
//! a regular lattice), or a polygon with the fluid inside:
//! `container = "step"`, the square with a block `D/4` square cut from its
//! lower right (a floor with a step: concave corners and a convex one, on
//! the lattice's lines when `resolution` is a multiple of 4), or
//! `"hopper"`, the square with its lower corners cut at 45 degrees `D/4`
//! along each side (a floor at an angle to the lattice). Gravity `g = 1` along `-y`, `rho0 = 1`, `nu` from
//! `Re = sqrt(g D) D / nu` (10 by default), `c0 = 10 sqrt(g D)`, the
//! consistent operators, no density diffusion (without a hydrostatic
//! correction it would diffuse the very density gradient the state
//! needs).
//! The fluid starts at rest with the hydrostatic pressure
//! `p = rho0 g (D - y)` (zero at the container's top, positive below it:
//! negative pressures would invite the tensile instability), and
//! continuity density from it; `resolution` counts particles across
//! `D = 1`.
//!
//! The exact solution is that nothing happens: `v = 0` (the velocity error
//! is the largest speed) and `p` linear in depth with slope `rho0 g`. A
//! closed full container fixes its mass, not its pressure level (the
//! weakly compressible fluid settles to the level its mass gives), so the
//! pressure is compared after removing its mean offset from the
//! hydrostatic field: `reference` in summary.json lists probes on the
//! vertical centre line at depths `D/4`, `D/2` and `3D/4` (mean pressure of
//! the particles within `1.5 dx`), relative to `rho0 g D`.
//!
//! The case shows what the walls' pressure rule does: with
//! `wall_pressure = "hydrostatic"` (the default) the ghosts carry the
//! weight of the fluid between source and ghost; with `"mirror"` they copy
//! their source's pressure and the wall has no normal pressure gradient
//! (docs/validation.md gives both). The square stays at rest. The curved
//! and polygonal containers stay at rest to the square's bounds with
//! `wall_boundary = "particles"`: the box lattice is split at the wall
//! into fluid and wall particles, so the fluid next to the wall sees the
//! same regular lattice as inside. With mirrored ghosts the circle keeps
//! its particles but not its rest (the clipped lattice is irregular next
//! to the wall and the symmetric pressure gradient turns that into a
//! force proportional to the absolute pressure, docs/physics.md 5.1), and
//! the step and the hopper are refused: at their concave corners a
//! particle's ghost is mirrored through one side only, and particles go
//! through the other (docs/validation.md measures both).

use std::sync::Arc;

use serde::{Deserialize, Serialize};
use sph_core::prelude::{Shape, ShapedWall};

use super::{Case, Reference, Settings};
use crate::error::Result;
use crate::scene::{AxisSpec, Region, RunRecord, Scene, WallSpec};

/// The case's table entry.
pub const CASE: Case = Case {
    name: "closed-tank",
    about: "a closed container (square; container = \"circle\", \"step\" or \"hopper\" for a curved or polygonal one) full of fluid at rest under gravity: the hydrostatic state kept",
    defaults,
    build,
    figure,
    reference,
};

/// The container of `closed-tank`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Container {
    /// The unit square: the box's planar walls.
    #[serde(rename = "square")]
    Square,
    /// A circle of diameter 1: one curved wall.
    #[serde(rename = "circle")]
    Circle,
    /// The unit square with a step in its floor (a block `D/4` square in
    /// the lower right): one polygon wall with five concave corners and a
    /// convex one, all on the lattice's lines.
    #[serde(rename = "step")]
    Step,
    /// The unit square with its lower corners cut at 45 degrees, `D/4` along
    /// each side: one polygon wall, a floor with two 135-degree corners.
    #[serde(rename = "hopper")]
    Hopper,
}

/// Gravity.
const G: f64 = 1.0;

/// The wall of a curved or polygonal container of size [`D`] with its lower
/// left corner at the origin, the fluid inside (the square as a polygon).
pub(crate) fn container_shape(container: Container) -> Result<Shape> {
    let q = 0.25 * D;
    let center = [0.5 * D, 0.5 * D, 0.0];
    Ok(match container {
        Container::Square => Shape::polygon(&[[0.0, 0.0], [D, 0.0], [D, D], [0.0, D]], true)?,
        Container::Step => Shape::polygon(
            &[
                [0.0, 0.0],
                [D - q, 0.0],
                [D - q, q],
                [D, q],
                [D, D],
                [0.0, D],
            ],
            true,
        )?,
        Container::Hopper => Shape::polygon(
            &[[0.0, q], [q, 0.0], [D - q, 0.0], [D, q], [D, D], [0.0, D]],
            true,
        )?,
        Container::Circle => Shape::Ball {
            center,
            radius: 0.5 * D,
            fluid_inside: true,
        },
    })
}
/// The container's size (side or diameter).
const D: f64 = 1.0;

fn defaults() -> Settings {
    let mut s = Settings::base("closed-tank", 40, 2.0, 0.5, 10.0).consistent();
    s.density_diffusion = 0.0;
    s.container = Some(Container::Square);
    s
}

fn build(s: &Settings) -> Result<Scene> {
    super::only_2d(s)?;
    let container = s.container.unwrap_or(Container::Square);
    if matches!(container, Container::Step | Container::Hopper)
        && s.wall_boundary == crate::config::WallBoundary::Mirror
    {
        return Err(crate::error::Error::config(
            "wall_boundary",
            "mirror",
            "the step and hopper containers have concave corners, where mirrored ghosts let particles through: use wall_boundary = \"particles\"",
        ));
    }
    let dx = D / s.resolution as f64;
    let rho0 = 1.0;
    let scale = (G * D).sqrt();
    let nu = scale * D / s.re;
    let center = [0.5 * D, 0.5 * D, 0.0];
    let hydrostatic: crate::scene::ScalarField = Arc::new(move |x| rho0 * G * (D - x[1]));
    let (origin, extent, axes, shaped_walls) = match container {
        Container::Square => (
            [0.0; 3],
            [D, D, 0.0],
            [
                AxisSpec::Walls(Some(WallSpec::at_rest()), Some(WallSpec::at_rest())),
                AxisSpec::Walls(Some(WallSpec::at_rest()), Some(WallSpec::at_rest())),
                AxisSpec::Periodic,
            ],
            Vec::new(),
        ),
        Container::Circle | Container::Step | Container::Hopper => {
            // The box holds the wall's ghosts: the support plus rows to spare.
            let margin = (2.0 * s.beta * 1.5).ceil() * dx + 2.0 * dx;
            let shape = container_shape(container)?;
            let wall = ShapedWall::new(shape);
            (
                [-margin, -margin, 0.0],
                [D + 2.0 * margin, D + 2.0 * margin, 0.0],
                [
                    AxisSpec::Walls(None, None),
                    AxisSpec::Walls(None, None),
                    AxisSpec::Periodic,
                ],
                vec![wall],
            )
        }
    };
    Ok(Scene {
        case: s.case.clone(),
        dim: 2,
        origin,
        extent,
        axes,
        dx,
        regions: vec![Region {
            lo: [0.0; 3],
            hi: [D, D, 0.0],
        }],
        shaped_walls,
        initial: None,
        summary: vec![
            (
                "container".into(),
                serde_json::to_value(container).unwrap_or_default(),
            ),
            ("size".into(), D.into()),
            ("gravity".into(), G.into()),
            ("center".into(), serde_json::json!([center[0], center[1]])),
            (
                "exact".into(),
                "at rest: v = 0, p = rho0 g (D - y) plus a constant".into(),
            ),
        ],
        velocity: None,
        pressure: Some(hydrostatic),
        body_force: [0.0, -G, 0.0],
        rho0,
        nu,
        physics: s.physics(scale, rho0),
        output_times: s.output_times(),
        velocity_scale: scale,
        length_scale: D,
        exact: Some(Arc::new(|_, _| [0.0; 3])),
        error_decay: 0.0,
        monitor: s.monitor(),
        steady_tolerance: None,
        threads: s.threads,
        keep_particles: true,
        allow_long_run: false,
    })
}

/// The pressure of a run's last output against the hydrostatic field:
/// `(depth / D, sph, exact)` at probes on the vertical centre line, both
/// in units of `rho0 g D`, the run's pressure shifted by its mean offset
/// from the hydrostatic field over every particle.
pub fn pressure_probes(record: &RunRecord) -> Option<Vec<(f64, f64, f64)>> {
    let frame = record.frames.last()?;
    let g = -record.body_force[1];
    let unit = record.rho0 * g * D;
    if unit.is_nan() || unit <= 0.0 {
        return None;
    }
    let hydro = |y: f64| record.rho0 * g * (D - y);
    let offset = frame
        .x
        .iter()
        .zip(&frame.p)
        .map(|(x, p)| p - hydro(x[1]))
        .sum::<f64>()
        / frame.p.len() as f64;
    let radius = 1.5 * record.dx;
    [0.25, 0.5, 0.75]
        .iter()
        .map(|&depth| {
            let y = D * (1.0 - depth);
            let near: Vec<f64> = frame
                .x
                .iter()
                .zip(&frame.p)
                .filter(|(x, _)| libm::hypot(x[0] - 0.5 * D, x[1] - y) <= radius)
                .map(|(_, p)| p - offset)
                .collect();
            (!near.is_empty()).then(|| {
                let mean = near.iter().sum::<f64>() / near.len() as f64;
                (depth, mean / unit, hydro(y) / unit)
            })
        })
        .collect()
}

fn reference(record: &RunRecord) -> Option<Reference> {
    Some(super::probes_reference(
        "hydrostatics: p = rho0 g (D - y) + const",
        "p/(rho0 g D) at depth/D",
        record.frames.last()?.t,
        pressure_probes(record)?,
    ))
}

/// The particles at the last output, coloured by speed.
fn figure(scene: &Scene, record: &RunRecord) -> Result<Vec<u8>> {
    super::custom::speed_figure(scene, record, "Closed tank")
}
