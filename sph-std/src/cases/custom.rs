//! `custom`: a scene described from parts in a scene file.
//!
//! A scene file with `case = "custom"` takes every key a built-in case
//! takes (resolution, physics, output times, monitor) plus a `[scene]`
//! table that describes the flow:
//!
//! ```toml
//! case = "custom"
//! resolution = 20          # particles across length_scale: dx = length_scale / resolution
//! re = 100.0               # velocity_scale * length_scale / nu: sets nu
//!
//! [scene]
//! origin = [0.0, 0.0]      # lower corner of the box, one entry per dimension
//! extent = [1.0, 1.0]      # box size; each a whole number of dx
//! periodic = ["x"]         # periodic axes ("x", "y", "z")
//! rho0 = 1.0               # reference density
//! velocity_scale = 1.0     # U: sound speed = sound_speed_factor * U, errors relative to U
//! length_scale = 1.0       # L
//! body_force = [0.0, 0.0]  # acceleration (optional)
//! steady_tolerance = 1e-4  # stop when |dE/E| per L/U falls below this (optional)
//! velocity = { profile = "rest" }  # or "uniform" (value), "shear" (rate), "taylor-green" (amplitude, wavelength)
//!
//! [[scene.walls]]          # one table per wall; an axis that is neither periodic nor walled is open
//! axis = "y"
//! side = "upper"           # "lower" or "upper"
//! velocity = [1.0, 0.0]    # tangential wall velocity (optional)
//! free_slip = false        # (optional)
//! reflection = "mirror"    # "mirror" or "point" (point needs periodic tangential axes)
//! body_force_curvature = false  # continue the profile with curvature -g_t / nu (channels)
//!
//! [[scene.regions]]        # fluid boxes (optional: the whole box)
//! lo = [0.0, 0.0]
//! hi = [1.0, 0.5]
//!
//! [[scene.shapes]]         # walls of any shape (optional, at most 8)
//! kind = "polygon"         # "circle", "polygon", "plane" (2D); "sphere", "cylinder", "polygon", "plane" (3D)
//! vertices = [[0.4, 0.1], [0.6, 0.1], [0.5, 0.3]]
//! fluid_inside = false     # an obstacle (true: a container)
//! free_slip = false        # (optional)
//! # circle, sphere, cylinder: center, radius, fluid_inside, omega (spin; not spheres)
//! # plane: point, normal (into the fluid), velocity (along the plane)
//! # any kind: moves = { velocity = [0.1, 0.0], omega = 1.0, pivot = [0.5, 0.5] }
//! #   (a rigid body: it turns about the pivot, which travels at velocity)
//! ```
//!
//! Fluid fills the regions' lattice points at least half a spacing in
//! front of every shape. With `wall_boundary = "particles"` the shapes get
//! wall particles (the box lattice's points behind them), which fill
//! concave corners; with mirrors (the default) each shape images the fluid
//! through its closest point. A shape that `moves` is where its motion puts
//! it at each step, and its wall particles travel with it; it must stay
//! inside the box (a shape is not periodic). A solid with fluid on both
//! sides must be at least one kernel support thick (a run refuses a
//! thinner one, naming the shape: the fluid would see through it).
//!
//! Initial velocity profiles: `rest`; `uniform` with `value` (a vector);
//! `shear` with `rate`, `u_x = rate (y - origin_y)`; `taylor-green` with
//! `amplitude` and `wavelength`, the Taylor-Green velocity and its pressure
//! (`docs/physics.md` 6.c). A custom scene has no exact solution; its
//! outputs report the diagnostics, and `examples/custom-channel.toml`
//! shows a channel whose steady state the tests check against theory.

use std::f64::consts::PI;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::{Case, Settings};
use crate::config::check;
use crate::error::{Error, Result};
use sph_core::prelude::{Reflection, Shape, ShapedWall};

use crate::scene::{AxisSpec, Region, RunRecord, ScalarField, Scene, VectorField, WallSpec};

/// The case's table entry.
pub const CASE: Case = Case {
    name: "custom",
    about: "a scene described from parts in a scene file: box, periodic axes, walls, fluid regions, initial velocity, body force (see examples/custom-channel.toml)",
    defaults,
    build,
    figure,
    reference: super::no_reference,
};

/// The most particles a custom scene may ask for (about 300 bytes each in
/// 2D: 6 GB).
const MAX_PARTICLES: f64 = 2e7;

fn defaults() -> Settings {
    Settings::base("custom", 20, 1.0, 0.1, 100.0).consistent()
}

/// A coordinate axis by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// The first axis.
    X,
    /// The second axis.
    Y,
    /// The third axis (3D only).
    Z,
}

impl Axis {
    fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
}

/// Which side of the box along an axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Side {
    /// At the box's origin.
    Lower,
    /// At origin + extent.
    Upper,
}

/// Ghost placement of a wall.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ReflectionName {
    /// Mirror image across the wall plane.
    #[default]
    Mirror,
    /// Point image through an anchor moving with the wall.
    Point,
}

/// One planar wall of the box.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallPart {
    /// The axis the wall is normal to.
    pub axis: Axis,
    /// Lower or upper side.
    pub side: Side,
    /// Tangential wall velocity (empty: at rest).
    #[serde(default)]
    pub velocity: Vec<f64>,
    /// Free slip instead of no-slip.
    #[serde(default)]
    pub free_slip: bool,
    /// Ghost placement.
    #[serde(default)]
    pub reflection: ReflectionName,
    /// Continue the tangential profile with the curvature `-g_t / nu`.
    #[serde(default)]
    pub body_force_curvature: bool,
}

/// A wall of any shape in a custom scene (`[[scene.shapes]]`, global
/// coordinates; see the module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum ShapePart {
    /// A circle (2D).
    Circle {
        /// Centre.
        center: Vec<f64>,
        /// Radius.
        radius: f64,
        /// The fluid is inside (a container) rather than outside.
        #[serde(default)]
        fluid_inside: bool,
        /// Spin about the centre, radians per second (anticlockwise).
        #[serde(default)]
        omega: f64,
        /// Free slip instead of no-slip.
        #[serde(default)]
        free_slip: bool,
        /// The shape moves as a rigid body (optional).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        moves: Option<MotionPart>,
    },
    /// A sphere (3D).
    Sphere {
        /// Centre.
        center: Vec<f64>,
        /// Radius.
        radius: f64,
        /// The fluid is inside rather than outside.
        #[serde(default)]
        fluid_inside: bool,
        /// Free slip instead of no-slip.
        #[serde(default)]
        free_slip: bool,
        /// The shape moves as a rigid body (optional).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        moves: Option<MotionPart>,
    },
    /// A cylinder along z (3D).
    Cylinder {
        /// A point of the axis.
        center: Vec<f64>,
        /// Radius.
        radius: f64,
        /// The fluid is inside rather than outside.
        #[serde(default)]
        fluid_inside: bool,
        /// Spin about the axis, radians per second.
        #[serde(default)]
        omega: f64,
        /// Free slip instead of no-slip.
        #[serde(default)]
        free_slip: bool,
        /// The shape moves as a rigid body (optional).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        moves: Option<MotionPart>,
    },
    /// A polygon, convex or concave (2D; a prism along z in 3D).
    Polygon {
        /// Vertices `[x, y]` in order, 3 to 12.
        vertices: Vec<[f64; 2]>,
        /// The fluid is inside rather than outside.
        #[serde(default)]
        fluid_inside: bool,
        /// Free slip instead of no-slip.
        #[serde(default)]
        free_slip: bool,
        /// The shape moves as a rigid body (optional).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        moves: Option<MotionPart>,
    },
    /// A plane at any angle: the fluid on the side its normal points to.
    Plane {
        /// A point of the plane.
        point: Vec<f64>,
        /// The normal into the fluid (any length but zero).
        normal: Vec<f64>,
        /// Velocity of the surface along itself (optional).
        #[serde(default)]
        velocity: Vec<f64>,
        /// Free slip instead of no-slip.
        #[serde(default)]
        free_slip: bool,
        /// The shape moves as a rigid body (optional).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        moves: Option<MotionPart>,
    },
}

/// How a shape moves as a rigid body (`moves = { ... }` in
/// `[[scene.shapes]]`): at time `t` a point `x0` of the shape is at
/// `pivot + velocity t + R(omega t) (x0 - pivot)`, `R` the turn about the
/// z axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionPart {
    /// Translation velocity (zero if left out).
    #[serde(default)]
    pub velocity: Vec<f64>,
    /// Turn rate about the z axis through the pivot, radians per second,
    /// anticlockwise (zero if left out).
    #[serde(default)]
    pub omega: f64,
    /// The centre of the turn at time zero (the origin if left out).
    #[serde(default)]
    pub pivot: Vec<f64>,
}

impl ShapePart {
    /// The part's rigid motion, if it has one.
    fn moves(&self) -> Option<&MotionPart> {
        match self {
            ShapePart::Circle { moves, .. }
            | ShapePart::Sphere { moves, .. }
            | ShapePart::Cylinder { moves, .. }
            | ShapePart::Polygon { moves, .. }
            | ShapePart::Plane { moves, .. } => moves.as_ref(),
        }
    }

    /// The core's wall for this part, checked, in global coordinates;
    /// `k` numbers it in error messages.
    fn wall(&self, k: usize, d: usize) -> Result<ShapedWall> {
        let key = |field: &str| format!("scene.shapes[{k}].{field}");
        let radius_ok = |r: f64| {
            check(
                r.is_finite() && r > 0.0,
                &key("radius"),
                r,
                "must be positive and finite",
            )
        };
        let dims = |want: usize, kind: &str| {
            check(
                d == want,
                &key("kind"),
                kind,
                &format!("needs a {want}D scene (circle and polygon 2D; sphere and cylinder 3D; polygon and plane either)"),
            )
        };
        let (shape, omega, center, velocity, free_slip) = match self {
            ShapePart::Circle {
                center,
                radius,
                fluid_inside,
                omega,
                free_slip,
                ..
            } => {
                dims(2, "circle")?;
                radius_ok(*radius)?;
                let c = vector(&key("center"), center, d)?;
                let shape = Shape::Ball {
                    center: c,
                    radius: *radius,
                    fluid_inside: *fluid_inside,
                };
                (shape, *omega, c, [0.0; 3], *free_slip)
            }
            ShapePart::Sphere {
                center,
                radius,
                fluid_inside,
                free_slip,
                ..
            } => {
                dims(3, "sphere")?;
                radius_ok(*radius)?;
                let c = vector(&key("center"), center, d)?;
                let shape = Shape::Ball {
                    center: c,
                    radius: *radius,
                    fluid_inside: *fluid_inside,
                };
                (shape, 0.0, c, [0.0; 3], *free_slip)
            }
            ShapePart::Cylinder {
                center,
                radius,
                fluid_inside,
                omega,
                free_slip,
                ..
            } => {
                dims(3, "cylinder")?;
                radius_ok(*radius)?;
                let c = vector(&key("center"), center, d)?;
                let shape = Shape::Cylinder {
                    center: c,
                    radius: *radius,
                    fluid_inside: *fluid_inside,
                };
                (shape, *omega, c, [0.0; 3], *free_slip)
            }
            ShapePart::Polygon {
                vertices,
                fluid_inside,
                free_slip,
                ..
            } => {
                let shape = Shape::polygon(vertices, *fluid_inside).map_err(|e| {
                    Error::config(key("vertices"), format!("{vertices:?}"), core_rule(&e))
                })?;
                (shape, 0.0, [0.0; 3], [0.0; 3], *free_slip)
            }
            ShapePart::Plane {
                point,
                normal,
                velocity,
                free_slip,
                ..
            } => {
                let p = vector(&key("point"), point, d)?;
                let n = vector(&key("normal"), normal, d)?;
                let len = libm::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
                check(
                    len > 0.0,
                    &key("normal"),
                    format!("{normal:?}"),
                    "must not be zero",
                )?;
                let n = [n[0] / len, n[1] / len, n[2] / len];
                let v = optional_vector(&key("velocity"), velocity, d)?;
                let shape = Shape::Plane {
                    point: p,
                    normal: n,
                };
                (shape, 0.0, [0.0; 3], v, *free_slip)
            }
        };
        check(omega.is_finite(), &key("omega"), omega, "must be finite")?;
        let mut wall = ShapedWall::new(shape).sliding(velocity);
        if omega != 0.0 {
            wall = wall.spinning(omega, center);
        }
        if free_slip {
            wall = wall.free_slip();
        }
        if let Some(m) = self.moves() {
            check(
                omega == 0.0 && velocity == [0.0; 3],
                &key("moves"),
                format!("{m:?}"),
                "a moving shape's surface moves with it: give its motion in moves, not omega or velocity",
            )?;
            check(
                m.omega.is_finite(),
                &key("moves.omega"),
                m.omega,
                "must be finite",
            )?;
            let v = optional_vector(&key("moves.velocity"), &m.velocity, d)?;
            let pivot = optional_vector(&key("moves.pivot"), &m.pivot, d)?;
            wall = wall.moving(v, m.omega, pivot);
        }
        wall.validate(d)
            .map_err(|e| Error::config(key("kind"), format!("{self:?}"), core_rule(&e)))?;
        Ok(wall)
    }
}

/// The rule of a core error, for a message that names the scene's key.
fn core_rule(e: &sph_core::error::Error) -> String {
    match e {
        sph_core::error::Error::InvalidParameter { rule, .. } => (*rule).to_string(),
        other => other.to_string(),
    }
}

/// A box of fluid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionPart {
    /// Lower corner.
    pub lo: Vec<f64>,
    /// Upper corner.
    pub hi: Vec<f64>,
}

/// A named initial velocity profile (see the module docs).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "profile", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Profile {
    /// At rest.
    #[default]
    Rest,
    /// A uniform velocity.
    Uniform {
        /// The velocity.
        value: Vec<f64>,
    },
    /// `u_x = rate (y - origin_y)`.
    Shear {
        /// Shear rate in 1/s.
        rate: f64,
    },
    /// The Taylor-Green vortex and its pressure.
    TaylorGreen {
        /// Peak speed.
        amplitude: f64,
        /// Period of the pattern along x and y.
        wavelength: f64,
    },
}

/// The `[scene]` table of a custom scene file (see the module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Parts {
    /// Lower corner of the box.
    pub origin: Vec<f64>,
    /// Size of the box.
    pub extent: Vec<f64>,
    /// Periodic axes.
    #[serde(default)]
    pub periodic: Vec<Axis>,
    /// Reference density.
    pub rho0: f64,
    /// Velocity scale `U`.
    pub velocity_scale: f64,
    /// Length scale `L` (the resolution counts particles across it).
    pub length_scale: f64,
    /// Body force per unit mass (empty: none).
    #[serde(default)]
    pub body_force: Vec<f64>,
    /// Stop once the relative change of kinetic energy per `L/U` falls
    /// below this.
    #[serde(default)]
    pub steady_tolerance: Option<f64>,
    /// Initial velocity.
    #[serde(default)]
    pub velocity: Profile,
    /// Walls.
    #[serde(default)]
    pub walls: Vec<WallPart>,
    /// Walls of any shape, at most eight.
    #[serde(default)]
    pub shapes: Vec<ShapePart>,
    /// Fluid regions (empty: the whole box).
    #[serde(default)]
    pub regions: Vec<RegionPart>,
}

/// A vector key of `dim` finite entries, padded to three.
fn vector(key: &str, v: &[f64], dim: usize) -> Result<[f64; 3]> {
    check(
        v.len() == dim && v.iter().all(|x| x.is_finite()),
        key,
        format!("{v:?}"),
        &format!("must have {dim} finite entries (one per dimension)"),
    )?;
    let mut out = [0.0; 3];
    out[..dim].copy_from_slice(v);
    Ok(out)
}

/// `v`, or zero when empty, as a vector key.
fn optional_vector(key: &str, v: &[f64], dim: usize) -> Result<[f64; 3]> {
    if v.is_empty() {
        Ok([0.0; 3])
    } else {
        vector(key, v, dim)
    }
}

fn build(s: &Settings) -> Result<Scene> {
    let parts = s.scene.as_ref().ok_or_else(|| {
        Error::config(
            "scene",
            "(missing)",
            "a custom scene needs a [scene] table (see examples/custom-channel.toml)",
        )
    })?;
    let d = s.dim;
    let origin = vector("scene.origin", &parts.origin, d)?;
    let extent = vector("scene.extent", &parts.extent, d)?;
    for (name, x) in [
        ("scene.rho0", parts.rho0),
        ("scene.velocity_scale", parts.velocity_scale),
        ("scene.length_scale", parts.length_scale),
    ] {
        check(
            x.is_finite() && x > 0.0,
            name,
            x,
            "must be positive and finite",
        )?;
    }
    let dx = parts.length_scale / s.resolution as f64;
    let mut particles = 1.0;
    for &length in extent.iter().take(d) {
        let cells = length / dx;
        check(
            length > 0.0 && (cells - cells.round()).abs() <= 1e-6 * cells.max(1.0),
            "scene.extent",
            length,
            &format!(
                "must be positive and a whole number of dx = length_scale / resolution = {dx:e} (here {cells} dx)"
            ),
        )?;
        particles *= cells.round();
    }
    check(
        particles <= MAX_PARTICLES,
        "resolution",
        s.resolution,
        &format!("asks for {particles:e} particles; at most {MAX_PARTICLES:e}"),
    )?;
    // Axes are open unless named periodic or walled; a 2D scene's third
    // axis is periodic (unused).
    let mut axes = [AxisSpec::Periodic; 3];
    for axis in axes.iter_mut().take(d) {
        *axis = AxisSpec::Walls(None, None);
    }
    for p in &parts.periodic {
        check(
            p.index() < d,
            "scene.periodic",
            format!("{p:?}"),
            "names an axis the scene does not have",
        )?;
        axes[p.index()] = AxisSpec::Periodic;
    }
    for w in &parts.walls {
        let a = w.axis.index();
        check(
            a < d,
            "scene.walls.axis",
            format!("{:?}", w.axis),
            "names an axis the scene does not have",
        )?;
        let velocity = optional_vector("scene.walls.velocity", &w.velocity, d)?;
        check(
            velocity[a] == 0.0,
            "scene.walls.velocity",
            format!("{:?}", w.velocity),
            "must be tangential (zero along the wall's axis)",
        )?;
        let mut spec = WallSpec::moving(velocity);
        spec.free_slip = w.free_slip;
        spec.body_force_curvature = w.body_force_curvature;
        spec.reflection = match w.reflection {
            ReflectionName::Mirror => Reflection::Mirror,
            ReflectionName::Point => Reflection::Point,
        };
        match &mut axes[a] {
            AxisSpec::Periodic => {
                return Err(Error::config(
                    "scene.walls.axis",
                    format!("{:?}", w.axis),
                    "is periodic; a wall needs a non-periodic axis",
                ))
            }
            AxisSpec::Walls(lower, upper) => {
                let slot = if w.side == Side::Lower { lower } else { upper };
                check(
                    slot.is_none(),
                    "scene.walls",
                    format!("{:?} {:?}", w.axis, w.side),
                    "names the same wall twice",
                )?;
                *slot = Some(spec);
            }
        }
    }
    let mut regions = Vec::new();
    for r in &parts.regions {
        let lo = vector("scene.regions.lo", &r.lo, d)?;
        let hi = vector("scene.regions.hi", &r.hi, d)?;
        check(
            (0..d).all(|a| lo[a] < hi[a]),
            "scene.regions",
            format!("{:?} .. {:?}", r.lo, r.hi),
            "lo must lie below hi on every axis",
        )?;
        regions.push(Region { lo, hi });
    }
    if regions.is_empty() {
        let mut hi = origin;
        for a in 0..d {
            hi[a] += extent[a];
        }
        regions.push(Region { lo: origin, hi });
    }
    let body_force = optional_vector("scene.body_force", &parts.body_force, d)?;
    if let Some(tol) = parts.steady_tolerance {
        check(
            tol.is_finite() && tol > 0.0,
            "scene.steady_tolerance",
            tol,
            "must be positive",
        )?;
    }
    check(
        parts.shapes.len() <= sph_core::shape::MAX_SHAPED_WALLS,
        "scene.shapes",
        parts.shapes.len(),
        "at most 8 walls of any shape",
    )?;
    let shaped_walls = parts
        .shapes
        .iter()
        .enumerate()
        .map(|(k, p)| p.wall(k, d))
        .collect::<Result<Vec<_>>>()?;
    let (velocity, pressure) = profile(&parts.velocity, origin, d, parts.rho0)?;
    let nu = parts.velocity_scale * parts.length_scale / s.re;
    Ok(Scene {
        case: s.case.clone(),
        dim: d,
        origin,
        extent,
        axes,
        dx,
        shaped_walls,
        initial: None,
        summary: Vec::new(),
        regions,
        velocity,
        pressure,
        body_force,
        rho0: parts.rho0,
        nu,
        physics: s.physics(parts.velocity_scale, parts.rho0),
        output_times: s.output_times(),
        velocity_scale: parts.velocity_scale,
        length_scale: parts.length_scale,
        exact: None,
        error_decay: 0.0,
        monitor: s.monitor(),
        steady_tolerance: parts.steady_tolerance,
        threads: s.threads,
        keep_particles: true,
        allow_long_run: false,
    })
}

/// The initial velocity (and pressure) fields of a profile.
fn profile(
    p: &Profile,
    origin: [f64; 3],
    d: usize,
    rho0: f64,
) -> Result<(Option<VectorField>, Option<ScalarField>)> {
    Ok(match p {
        Profile::Rest => (None, None),
        Profile::Uniform { value } => {
            let v = vector("scene.velocity.value", value, d)?;
            (Some(Arc::new(move |_, _| v)), None)
        }
        Profile::Shear { rate } => {
            let rate = *rate;
            check(
                rate.is_finite(),
                "scene.velocity.rate",
                rate,
                "must be finite",
            )?;
            let y0 = origin[1];
            (
                Some(Arc::new(move |x, _| [rate * (x[1] - y0), 0.0, 0.0])),
                None,
            )
        }
        Profile::TaylorGreen {
            amplitude,
            wavelength,
        } => {
            let (u, l) = (*amplitude, *wavelength);
            check(
                u.is_finite(),
                "scene.velocity.amplitude",
                u,
                "must be finite",
            )?;
            check(
                l.is_finite() && l > 0.0,
                "scene.velocity.wavelength",
                l,
                "must be positive",
            )?;
            let k = 2.0 * PI / l;
            let velocity: VectorField = Arc::new(move |x, _| {
                let (sx, cx) = libm::sincos(k * (x[0] - origin[0]));
                let (sy, cy) = libm::sincos(k * (x[1] - origin[1]));
                [-u * cx * sy, u * sx * cy, 0.0]
            });
            let pressure: ScalarField = Arc::new(move |x| {
                -0.25
                    * rho0
                    * u
                    * u
                    * (libm::cos(2.0 * k * (x[0] - origin[0]))
                        + libm::cos(2.0 * k * (x[1] - origin[1])))
            });
            (Some(velocity), Some(pressure))
        }
    })
}

/// The particles at the last output, coloured by speed (2D).
fn figure(scene: &Scene, record: &RunRecord) -> Result<Vec<u8>> {
    speed_figure(scene, record, "custom scene")
}

/// The particles at the last output over the scene's box, coloured by
/// speed, titled `name at t = ...` (2D; the first two axes in 3D).
pub(crate) fn speed_figure(scene: &Scene, record: &RunRecord, name: &str) -> Result<Vec<u8>> {
    let bounds = [
        scene.origin[0],
        scene.origin[0] + scene.extent[0],
        scene.origin[1],
        scene.origin[1] + scene.extent[1],
    ];
    let empty = crate::scene::Frame {
        t: 0.0,
        x: Vec::new(),
        v: Vec::new(),
        rho: Vec::new(),
        p: Vec::new(),
    };
    let f = record.frames.last().unwrap_or(&empty);
    crate::plot::speed_scatter_png(
        f,
        bounds,
        &format!("{name} at t = {:.2}", f.t),
        &wall_outlines(scene, bounds, f.t),
    )
}

/// The walls of a scene as polylines in the plane of its first two axes,
/// within `bounds` (`[x0, x1, y0, y1]`): the box's planar walls, then each
/// shaped wall's trace where it is at time `t` (circles and cylinders as
/// 180-gons; a signed distance function is not drawn).
pub(crate) fn wall_outlines(scene: &Scene, bounds: [f64; 4], t: f64) -> Vec<Vec<(f64, f64)>> {
    let mut lines = Vec::new();
    let (lo, hi) = (
        scene.origin,
        [
            scene.origin[0] + scene.extent[0],
            scene.origin[1] + scene.extent[1],
        ],
    );
    for a in 0..2 {
        if let AxisSpec::Walls(lower, upper) = &scene.axes[a] {
            for (wall, at) in [(lower, lo[a]), (upper, hi[a])] {
                if wall.is_some() {
                    lines.push(if a == 0 {
                        vec![(at, lo[1]), (at, hi[1])]
                    } else {
                        vec![(lo[0], at), (hi[0], at)]
                    });
                }
            }
        }
    }
    // The part of the line through `p` along `t` inside the bounds.
    let clipped = |p: [f64; 3], t: [f64; 2]| -> Option<Vec<(f64, f64)>> {
        let (mut s0, mut s1) = (f64::NEG_INFINITY, f64::INFINITY);
        for (a, (b0, b1)) in [(bounds[0], bounds[1]), (bounds[2], bounds[3])]
            .into_iter()
            .enumerate()
        {
            if t[a] == 0.0 {
                if p[a] < b0 || p[a] > b1 {
                    return None;
                }
            } else {
                let (u, v) = ((b0 - p[a]) / t[a], (b1 - p[a]) / t[a]);
                s0 = s0.max(u.min(v));
                s1 = s1.min(u.max(v));
            }
        }
        (s0 < s1).then(|| {
            vec![
                (p[0] + s0 * t[0], p[1] + s0 * t[1]),
                (p[0] + s1 * t[0], p[1] + s1 * t[1]),
            ]
        })
    };
    for w in &scene.shaped_walls {
        let mut w = *w;
        w.set_time(t);
        match w.shape {
            Shape::Plane { point, normal } => {
                lines.extend(clipped(point, [-normal[1], normal[0]]));
            }
            Shape::Channel {
                point,
                normal,
                width,
                period,
            } => {
                let t = [-normal[1], normal[0]];
                // Every repeat whose lines can cross the bounds.
                let reach = (bounds[1] - bounds[0]).hypot(bounds[3] - bounds[2])
                    + (point[0] - bounds[0]).hypot(point[1] - bounds[2]);
                let repeats = if period.is_finite() {
                    (reach / period).ceil() as i64
                } else {
                    0
                };
                for k in -repeats..=repeats {
                    for offset in [0.0, width] {
                        let s = k as f64 * if period.is_finite() { period } else { 0.0 } + offset;
                        let p = [point[0] + s * normal[0], point[1] + s * normal[1], 0.0];
                        lines.extend(clipped(p, t));
                    }
                }
            }
            Shape::Ball { center, radius, .. } | Shape::Cylinder { center, radius, .. } => {
                lines.push(
                    (0..=180)
                        .map(|k| {
                            let (s, c) = libm::sincos(2.0 * PI * k as f64 / 180.0);
                            (center[0] + radius * c, center[1] + radius * s)
                        })
                        .collect(),
                );
            }
            Shape::Polygon {
                vertices, count, ..
            } => {
                let n = count.min(vertices.len());
                lines.push(
                    (0..=n)
                        .map(|k| (vertices[k % n][0], vertices[k % n][1]))
                        .collect(),
                );
            }
            Shape::Sdf { .. } => {
                let z = scene.origin[2] + 0.5 * scene.extent[2];
                lines.extend(zero_contour(
                    |x, y| w.shape.distance([x, y, z], scene.dim).0,
                    bounds,
                ));
            }
        }
    }
    lines
}

/// The zero contour of `f` within `bounds` (`[x0, x1, y0, y1]`) as
/// segments, by marching squares on a grid of 240 cells along the longer
/// side (a signed distance function's wall, to a fraction of a cell).
fn zero_contour(f: impl Fn(f64, f64) -> f64, bounds: [f64; 4]) -> Vec<Vec<(f64, f64)>> {
    let (w, h) = (bounds[1] - bounds[0], bounds[3] - bounds[2]);
    if !(w > 0.0 && h > 0.0) {
        return Vec::new();
    }
    let cell = w.max(h) / 240.0;
    let (nx, ny) = ((w / cell).ceil() as usize, (h / cell).ceil() as usize);
    let at = |i: usize, j: usize| {
        (
            bounds[0] + w * i as f64 / nx as f64,
            bounds[2] + h * j as f64 / ny as f64,
        )
    };
    let values: Vec<f64> = (0..=ny)
        .flat_map(|j| (0..=nx).map(move |i| (i, j)))
        .map(|(i, j)| {
            let (x, y) = at(i, j);
            f(x, y)
        })
        .collect();
    let value = |i: usize, j: usize| values[j * (nx + 1) + i];
    let mut segments = Vec::new();
    for j in 0..ny {
        for i in 0..nx {
            // Corners anticlockwise from the lower left, and the crossing
            // on each edge between consecutive corners.
            let corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
            let mut crossings = Vec::with_capacity(4);
            for k in 0..4 {
                let (a, b) = (corners[k], corners[(k + 1) % 4]);
                let (fa, fb) = (value(a.0, a.1), value(b.0, b.1));
                if (fa < 0.0) != (fb < 0.0) && fa.is_finite() && fb.is_finite() {
                    let s = fa / (fa - fb);
                    let (pa, pb) = (at(a.0, a.1), at(b.0, b.1));
                    crossings.push((pa.0 + s * (pb.0 - pa.0), pa.1 + s * (pb.1 - pa.1)));
                }
            }
            for pair in crossings.chunks_exact(2) {
                segments.push(vec![pair[0], pair[1]]);
            }
        }
    }
    segments
}

#[cfg(test)]
mod tests {
    use super::zero_contour;

    #[test]
    fn the_zero_contour_of_a_circles_distance_is_the_circle() {
        let (cx, cy, r) = (0.5, 0.4, 0.3);
        let segments = zero_contour(|x, y| (x - cx).hypot(y - cy) - r, [0.0, 1.0, 0.0, 0.8]);
        let mut length = 0.0;
        for s in &segments {
            for &(x, y) in s {
                // A crossing interpolated along a cell edge of h = 1/240
                // lies within h^2 / (8 r) of the circle.
                assert!(((x - cx).hypot(y - cy) - r).abs() < 1e-5, "{x} {y}");
            }
            length += (s[1].0 - s[0].0).hypot(s[1].1 - s[0].1);
        }
        // Chords of 1/240 or less fall short of the perimeter by under
        // (1/240)^2 / (24 r^2) of it.
        let perimeter = 2.0 * std::f64::consts::PI * r;
        assert!(
            (length / perimeter - 1.0).abs() < 1e-4,
            "{length} {perimeter}"
        );
        // A shape outside the bounds draws nothing.
        assert!(zero_contour(|x, _| x + 2.0, [0.0, 1.0, 0.0, 1.0]).is_empty());
    }
}
