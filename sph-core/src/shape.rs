//! Walls of any shape: planes at any angle, periodic channels, circles and
//! spheres, cylinders, and any shape given by a signed distance function
//! (`docs/physics.md` 5.5).
//!
//! A [`ShapedWall`] bounds the fluid where its signed distance is positive.
//! Every fluid particle closer to it than the neighbour radius gets a ghost
//! mirrored through the closest wall point, `x_g = x - 2 d n` (`d` the
//! distance, `n` the unit normal into the fluid), with the source's density
//! and pressure. Its velocity follows the wall's rule at that point: no-slip
//! `2 v_w - v`, free-slip reflects the normal part relative to the wall.
//! Its mass is the source's times the Jacobian of the mirror map (the
//! ratio of the ghost's volume element to the source's), so the ghosts of a
//! curved wall carry the mass per volume of the fluid they mirror: for a
//! circle of radius `R` a particle at radius `r` maps to `2R - r` and its
//! ghost weighs `(2R - r)/r` as much (squared for a sphere). Planar mirrors
//! keep the mass and are exact as before.
//!
//! Geometry is evaluated in `f64` (with `libm`, whatever the working
//! precision and math backend), so the ghosts of every build are the same
//! bits. A wall's shape does not move: its surface may slide along itself
//! (a rotating cylinder, a plane sliding in its own plane), which is what the
//! velocity and angular velocity describe.
//!
//! A ghost of a shaped wall is recorded with [`BODY_FLAG`] and the wall's
//! index in [`crate::boundary::Ghost::mirrors`]. Known limits: a particle
//! near two walls gets one image per wall but no image through their corner
//! (the planar box walls still get theirs), so a concave corner of two
//! shaped walls leaves a small gap in the support; two walls closer together
//! than a support radius (a thin plate with fluid on both sides) mirror
//! each side's fluid into the other side's reach.

use crate::error::{Error, Result};
use crate::math::f64s;
use crate::real::Real;
use crate::space::{Space, VectorOps};

/// The most shaped walls a domain holds.
pub const MAX_SHAPED_WALLS: usize = 8;

/// Set in [`crate::boundary::Ghost::mirrors`] for a ghost of a shaped wall;
/// the low bits are the wall's index.
pub const BODY_FLAG: u8 = 0x80;

/// Parameters of a signed distance function.
pub const SDF_PARAMS: usize = 8;

/// A signed distance function: `f(params, x)` is the distance from `x`
/// (local coordinates) to the wall, positive in the fluid.
pub type SdfFn = fn(&[f64; SDF_PARAMS], [f64; 3]) -> f64;

/// The geometry of a shaped wall, in the domain's local coordinates
/// (relative to its lower corner). Normals are unit vectors pointing into
/// the fluid.
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    /// The half-space on the side of `normal` of the plane through `point`.
    Plane {
        /// A point of the plane.
        point: [f64; 3],
        /// Unit normal, pointing into the fluid.
        normal: [f64; 3],
    },
    /// Fluid between two parallel planes `width` apart, the first through
    /// `point` with unit `normal` into the fluid; with a finite `period` the
    /// channel repeats every `period` along the normal (solid strips of
    /// `period - width` between the channels), which is how a channel at
    /// an angle closes on itself across a periodic box.
    Channel {
        /// A point of the first wall.
        point: [f64; 3],
        /// Unit normal of the first wall, into the fluid.
        normal: [f64; 3],
        /// Distance between the walls.
        width: f64,
        /// Repeat distance along the normal (`f64::INFINITY`: one channel).
        period: f64,
    },
    /// A circle (2D) or sphere (3D).
    Ball {
        /// Centre.
        center: [f64; 3],
        /// Radius.
        radius: f64,
        /// The fluid is inside (a container) rather than outside (an obstacle).
        fluid_inside: bool,
    },
    /// A cylinder along the z axis (3D); in 2D the same as [`Shape::Ball`].
    Cylinder {
        /// A point of the axis.
        center: [f64; 3],
        /// Radius.
        radius: f64,
        /// The fluid is inside rather than outside.
        fluid_inside: bool,
    },
    /// Any shape given by its signed distance function, evaluated at
    /// `x + offset`. Normals and curvature come from central differences
    /// with `step` (a small fraction of the particle spacing); the ghost
    /// mass uses the first-order Jacobian `1 - 2 d lap(f)`, exact for
    /// circles in 2D and cylinders.
    Sdf {
        /// The function.
        f: SdfFn,
        /// Its parameters.
        params: [f64; SDF_PARAMS],
        /// Added to positions before evaluation (a shift of the shape).
        offset: [f64; 3],
        /// Finite-difference step.
        step: f64,
    },
}

impl PartialEq for Shape {
    fn eq(&self, other: &Self) -> bool {
        use Shape::*;
        match (self, other) {
            (
                Plane {
                    point: a,
                    normal: b,
                },
                Plane {
                    point: c,
                    normal: d,
                },
            ) => a == c && b == d,
            (
                Channel {
                    point: a,
                    normal: b,
                    width: w,
                    period: p,
                },
                Channel {
                    point: c,
                    normal: d,
                    width: v,
                    period: q,
                },
            ) => a == c && b == d && w == v && p == q,
            (
                Ball {
                    center: a,
                    radius: r,
                    fluid_inside: i,
                },
                Ball {
                    center: b,
                    radius: s,
                    fluid_inside: j,
                },
            )
            | (
                Cylinder {
                    center: a,
                    radius: r,
                    fluid_inside: i,
                },
                Cylinder {
                    center: b,
                    radius: s,
                    fluid_inside: j,
                },
            ) => a == b && r == s && i == j,
            (
                Sdf {
                    f,
                    params,
                    offset,
                    step,
                },
                Sdf {
                    f: g,
                    params: p,
                    offset: o,
                    step: s,
                },
            ) => core::ptr::fn_addr_eq(*f, *g) && params == p && offset == o && step == s,
            _ => false,
        }
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn axpy(a: f64, x: [f64; 3], y: [f64; 3]) -> [f64; 3] {
    [a * x[0] + y[0], a * x[1] + y[1], a * x[2] + y[2]]
}

/// The closest wall point of a position and what the mirror needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Image {
    /// Signed distance from the wall (positive in the fluid).
    pub distance: f64,
    /// Unit normal at the closest wall point, into the fluid.
    pub normal: [f64; 3],
    /// The closest wall point, `x - d n`.
    pub wall_point: [f64; 3],
    /// The mirror image, `x - 2 d n`.
    pub position: [f64; 3],
    /// Ratio of the image's volume element to the source's.
    pub jacobian: f64,
}

impl Shape {
    /// Signed distance of `x` (positive in the fluid) and the unit normal
    /// into the fluid at its closest wall point, in `dim` dimensions.
    pub fn distance(&self, x: [f64; 3], dim: usize) -> (f64, [f64; 3]) {
        match *self {
            Shape::Plane { point, normal } => (dot(sub(x, point), normal), normal),
            Shape::Channel {
                point,
                normal,
                width,
                period,
            } => {
                let mut s = dot(sub(x, point), normal);
                if period.is_finite() {
                    s -= period * f64s::floor(s / period);
                }
                let minus = [-normal[0], -normal[1], -normal[2]];
                if s < width {
                    if s <= 0.5 * width {
                        (s, normal)
                    } else {
                        (width - s, minus)
                    }
                } else if s - width <= period - s {
                    (width - s, minus)
                } else {
                    (s - period, normal)
                }
            }
            Shape::Ball {
                center,
                radius,
                fluid_inside,
            } => radial(x, center, radius, fluid_inside, dim),
            Shape::Cylinder {
                center,
                radius,
                fluid_inside,
            } => radial(x, center, radius, fluid_inside, dim.min(2)),
            Shape::Sdf {
                f,
                params,
                offset,
                step,
            } => {
                let (d, g, _) = stencil(f, &params, offset, step, x, dim);
                let len = f64s::sqrt(dot(g, g));
                if len > 0.0 && len.is_finite() {
                    (d, [g[0] / len, g[1] / len, g[2] / len])
                } else {
                    (d, [0.0; 3])
                }
            }
        }
    }

    /// The mirror image of `x` through its closest wall point.
    pub fn image(&self, x: [f64; 3], dim: usize) -> Image {
        let (d, n) = self.distance(x, dim);
        let wall_point = axpy(-d, n, x);
        let position = axpy(-2.0 * d, n, x);
        let jacobian = match *self {
            Shape::Plane { .. } | Shape::Channel { .. } => 1.0,
            Shape::Ball { center, .. } | Shape::Cylinder { center, .. } => {
                let dims = if matches!(self, Shape::Cylinder { .. }) {
                    dim.min(2)
                } else {
                    dim
                };
                let r = radius_of(sub(x, center), dims);
                let rg = radius_of(sub(position, center), dims);
                let ratio = if r > 0.0 { rg / r } else { 1.0 };
                if dims == 3 {
                    ratio * ratio
                } else {
                    ratio
                }
            }
            Shape::Sdf {
                f,
                params,
                offset,
                step,
            } => {
                let (_, _, lap) = stencil(f, &params, offset, step, x, dim);
                1.0 - 2.0 * d * lap
            }
        };
        Image {
            distance: d,
            normal: n,
            wall_point,
            position,
            // A mirror map never creates or destroys volume outright.
            jacobian: jacobian.clamp(0.1, 10.0),
        }
    }

    /// The same shape shifted by `by` (a global description made local:
    /// `by` is minus the domain origin).
    pub fn translated(self, by: [f64; 3]) -> Self {
        let add = |p: [f64; 3]| [p[0] + by[0], p[1] + by[1], p[2] + by[2]];
        match self {
            Shape::Plane { point, normal } => Shape::Plane {
                point: add(point),
                normal,
            },
            Shape::Channel {
                point,
                normal,
                width,
                period,
            } => Shape::Channel {
                point: add(point),
                normal,
                width,
                period,
            },
            Shape::Ball {
                center,
                radius,
                fluid_inside,
            } => Shape::Ball {
                center: add(center),
                radius,
                fluid_inside,
            },
            Shape::Cylinder {
                center,
                radius,
                fluid_inside,
            } => Shape::Cylinder {
                center: add(center),
                radius,
                fluid_inside,
            },
            Shape::Sdf {
                f,
                params,
                offset,
                step,
            } => Shape::Sdf {
                f,
                params,
                offset: sub(offset, by),
                step,
            },
        }
    }
}

/// A signed distance function at `x + offset` with its central-difference
/// gradient and Laplacian (step `step`, `dim` axes).
fn stencil(
    f: SdfFn,
    params: &[f64; SDF_PARAMS],
    offset: [f64; 3],
    step: f64,
    x: [f64; 3],
    dim: usize,
) -> (f64, [f64; 3], f64) {
    let at = |p: [f64; 3]| {
        f(
            params,
            [p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]],
        )
    };
    let d = at(x);
    let mut g = [0.0; 3];
    let mut lap = 0.0;
    for (a, ga) in g.iter_mut().enumerate().take(dim) {
        let mut hi = x;
        let mut lo = x;
        hi[a] += step;
        lo[a] -= step;
        let (fh, fl) = (at(hi), at(lo));
        *ga = (fh - fl) / (2.0 * step);
        lap += (fh - 2.0 * d + fl) / (step * step);
    }
    (d, g, lap)
}

fn radius_of(r: [f64; 3], dims: usize) -> f64 {
    let mut s = 0.0;
    for c in r.iter().take(dims) {
        s += c * c;
    }
    f64s::sqrt(s)
}

fn radial(
    x: [f64; 3],
    center: [f64; 3],
    radius: f64,
    inside: bool,
    dims: usize,
) -> (f64, [f64; 3]) {
    let mut e = [0.0; 3];
    let rel = sub(x, center);
    let r = radius_of(rel, dims);
    if r > 0.0 {
        for a in 0..dims {
            e[a] = rel[a] / r;
        }
    } else {
        e[0] = 1.0;
    }
    if inside {
        (radius - r, [-e[0], -e[1], -e[2]])
    } else {
        (r - radius, e)
    }
}

/// A wall of any shape with its boundary condition and its surface motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapedWall {
    /// Geometry.
    pub shape: Shape,
    /// No-slip (`true`) or free slip.
    pub no_slip: bool,
    /// Velocity of the surface (a translation along itself).
    pub velocity: [f64; 3],
    /// Angular velocity of the surface about the z axis through `center`.
    pub omega: f64,
    /// Centre of the rotation.
    pub center: [f64; 3],
    /// Velocity curvature `d^2 v / d n^2` at the wall; its tangential part
    /// continues a no-slip ghost's velocity as a parabola, `2 v_w - v +
    /// c_t d^2` (see `crate::domain::Wall::curvature`: `-g / nu` for a
    /// channel driven by a body force `g`).
    pub curvature: [f64; 3],
}

impl ShapedWall {
    /// A no-slip wall at rest.
    pub fn new(shape: Shape) -> Self {
        Self {
            shape,
            no_slip: true,
            velocity: [0.0; 3],
            omega: 0.0,
            center: [0.0; 3],
            curvature: [0.0; 3],
        }
    }

    /// The same wall with a velocity curvature (see the field).
    pub fn with_curvature(mut self, curvature: [f64; 3]) -> Self {
        self.curvature = curvature;
        self
    }

    /// The same wall with free slip.
    pub fn free_slip(mut self) -> Self {
        self.no_slip = false;
        self
    }

    /// The same wall sliding with `velocity`.
    pub fn sliding(mut self, velocity: [f64; 3]) -> Self {
        self.velocity = velocity;
        self
    }

    /// The same wall spinning at `omega` (radians per second, about the z
    /// axis through `center`).
    pub fn spinning(mut self, omega: f64, center: [f64; 3]) -> Self {
        self.omega = omega;
        self.center = center;
        self
    }

    /// The same wall shifted by `by` (see [`Shape::translated`]).
    pub fn translated(mut self, by: [f64; 3]) -> Self {
        self.shape = self.shape.translated(by);
        self.center = [
            self.center[0] + by[0],
            self.center[1] + by[1],
            self.center[2] + by[2],
        ];
        self
    }

    /// Checks the description: finite numbers, unit normals, positive
    /// radii and widths, and a motion that keeps the shape in place.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming the field.
    pub fn validate(&self, dim: usize) -> Result<()> {
        let bad = |name: &'static str, value: f64, rule: &'static str| {
            Err(Error::InvalidParameter { name, value, rule })
        };
        if dim < 2 {
            return bad(
                "dim",
                dim as f64,
                "shaped walls need two or three dimensions",
            );
        }
        let finite3 = |v: [f64; 3]| v.iter().all(|c| c.is_finite());
        if !finite3(self.velocity)
            || !finite3(self.center)
            || !finite3(self.curvature)
            || !self.omega.is_finite()
        {
            return bad(
                "wall.velocity",
                f64::NAN,
                "wall velocity, angular velocity and centre must be finite",
            );
        }
        let unit = |n: [f64; 3]| finite3(n) && (dot(n, n) - 1.0).abs() < 1e-9;
        let spins_in_place = |center: [f64; 3]| {
            self.omega == 0.0 || (0..dim.min(2)).all(|a| self.center[a] == center[a])
        };
        let no_drift = |normal: Option<[f64; 3]>| match normal {
            Some(n) => dot(self.velocity, n) == 0.0,
            None => self.velocity.iter().all(|&c| c == 0.0),
        };
        match self.shape {
            Shape::Plane { point, normal } => {
                if !finite3(point) || !unit(normal) {
                    return bad(
                        "wall.normal",
                        dot(normal, normal),
                        "a plane needs a finite point and a unit normal",
                    );
                }
                if !no_drift(Some(normal)) || self.omega != 0.0 {
                    return bad(
                        "wall.velocity",
                        dot(self.velocity, normal),
                        "a plane may only slide along itself",
                    );
                }
            }
            Shape::Channel {
                point,
                normal,
                width,
                period,
            } => {
                if !finite3(point) || !unit(normal) {
                    return bad(
                        "wall.normal",
                        dot(normal, normal),
                        "a channel needs a finite point and a unit normal",
                    );
                }
                if !(width > 0.0 && width.is_finite()) {
                    return bad(
                        "wall.width",
                        width,
                        "a channel width must be positive and finite",
                    );
                }
                if !(period > width) {
                    return bad(
                        "wall.period",
                        period,
                        "a channel's period must exceed its width (or be infinite)",
                    );
                }
                if !no_drift(Some(normal)) || self.omega != 0.0 {
                    return bad(
                        "wall.velocity",
                        dot(self.velocity, normal),
                        "a channel's walls may only slide along themselves",
                    );
                }
            }
            Shape::Ball { center, radius, .. } | Shape::Cylinder { center, radius, .. } => {
                if !(finite3(center) && radius > 0.0 && radius.is_finite()) {
                    return bad(
                        "wall.radius",
                        radius,
                        "a circle, sphere or cylinder needs a finite centre and a positive radius",
                    );
                }
                if !no_drift(None) || !spins_in_place(center) {
                    return bad(
                        "wall.omega",
                        self.omega,
                        "a round wall may only spin about its own axis",
                    );
                }
                if dim == 3 && matches!(self.shape, Shape::Ball { .. }) && self.omega != 0.0 {
                    return bad(
                        "wall.omega",
                        self.omega,
                        "a spinning sphere is not supported (spin a cylinder)",
                    );
                }
            }
            Shape::Sdf {
                offset,
                step,
                params,
                ..
            } => {
                if !finite3(offset) || !params.iter().all(|p| p.is_finite()) {
                    return bad(
                        "wall.params",
                        f64::NAN,
                        "signed-distance parameters and offset must be finite",
                    );
                }
                if !(step > 0.0 && step.is_finite()) {
                    return bad(
                        "wall.step",
                        step,
                        "the finite-difference step must be positive and finite",
                    );
                }
            }
        }
        Ok(())
    }

    /// The surface velocity at wall point `p`.
    pub fn surface_velocity(&self, p: [f64; 3]) -> [f64; 3] {
        let r = sub(p, self.center);
        [
            self.velocity[0] - self.omega * r[1],
            self.velocity[1] + self.omega * r[0],
            self.velocity[2],
        ]
    }

    /// The ghost velocity for fluid velocity `v` with image `img`; with
    /// `homogeneous` the wall is taken at rest (the rule's linear part).
    pub fn ghost_velocity(&self, v: [f64; 3], img: &Image, homogeneous: bool) -> [f64; 3] {
        let vw = if homogeneous {
            [0.0; 3]
        } else {
            self.surface_velocity(img.wall_point)
        };
        if self.no_slip {
            let mut g = [2.0 * vw[0] - v[0], 2.0 * vw[1] - v[1], 2.0 * vw[2] - v[2]];
            if !homogeneous && self.curvature != [0.0; 3] {
                let c = self.curvature;
                let ct = axpy(-dot(c, img.normal), img.normal, c);
                g = axpy(img.distance * img.distance, ct, g);
            }
            g
        } else {
            let rel = dot(sub(v, vw), img.normal);
            axpy(-2.0 * rel, img.normal, v)
        }
    }
}

/// A working-precision vector as three `f64` components.
#[inline]
pub fn widen<S: Space>(v: S::Vector) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (a, o) in out.iter_mut().enumerate().take(S::DIM) {
        *o = v[a].to_f64();
    }
    out
}

/// Three `f64` components as a working-precision vector.
#[inline]
pub fn narrow<S: Space>(v: [f64; 3]) -> S::Vector {
    S::Vector::from_fn(|a| S::Real::from_f64(v[a]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_circle_mirrors_radially_and_weighs_ghosts_by_the_jacobian() {
        let c = Shape::Ball {
            center: [1.0, 1.0, 0.0],
            radius: 0.5,
            fluid_inside: false,
        };
        let img = c.image([1.7, 1.0, 0.0], 2);
        assert!((img.distance - 0.2).abs() < 1e-15);
        assert_eq!(img.normal, [1.0, 0.0, 0.0]);
        assert!((img.position[0] - 1.3).abs() < 1e-15);
        // Radius 0.7 maps to 0.3: the ghost's ring is 3/7 as long.
        assert!((img.jacobian - 0.3 / 0.7).abs() < 1e-15);
        // Inside a container the ghosts spread out.
        let o = Shape::Ball {
            center: [0.0; 3],
            radius: 1.0,
            fluid_inside: true,
        };
        let img = o.image([0.0, 0.9, 0.0], 2);
        assert!((img.distance - 0.1).abs() < 1e-15);
        assert!((img.position[1] - 1.1).abs() < 1e-15);
        assert!((img.jacobian - 1.1 / 0.9).abs() < 1e-15);
        // A sphere squares it.
        let img = o.image([0.0, 0.9, 0.0], 3);
        assert!((img.jacobian - (1.1f64 / 0.9).powi(2)).abs() < 1e-14);
    }

    fn circle_sdf(p: &[f64; SDF_PARAMS], x: [f64; 3]) -> f64 {
        let (dx, dy) = (x[0] - p[0], x[1] - p[1]);
        libm::sqrt(dx * dx + dy * dy) - p[2]
    }

    #[test]
    fn a_signed_distance_function_gives_the_circles_image() {
        let exact = Shape::Ball {
            center: [0.2, -0.1, 0.0],
            radius: 0.5,
            fluid_inside: false,
        };
        let sdf = Shape::Sdf {
            f: circle_sdf,
            params: [0.2, -0.1, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0],
            offset: [0.0; 3],
            step: 1e-4,
        };
        for x in [[0.9, 0.3, 0.0], [0.2, 0.45, 0.0], [-0.4, -0.3, 0.0]] {
            let (a, b) = (exact.image(x, 2), sdf.image(x, 2));
            assert!((a.distance - b.distance).abs() < 1e-12);
            for k in 0..2 {
                assert!((a.position[k] - b.position[k]).abs() < 1e-7);
            }
            // The finite-difference Jacobian agrees to the stencil's error.
            assert!((a.jacobian - b.jacobian).abs() < 1e-5, "{a:?} {b:?}");
        }
    }

    #[test]
    fn a_periodic_channel_names_its_nearer_wall_and_its_solid_strip() {
        let ch = Shape::Channel {
            point: [0.0; 3],
            normal: [0.0, 1.0, 0.0],
            width: 1.0,
            period: 1.5,
        };
        assert_eq!(ch.distance([0.0, 0.25, 0.0], 2), (0.25, [0.0, 1.0, 0.0]));
        assert_eq!(ch.distance([0.0, 0.75, 0.0], 2), (0.25, [0.0, -1.0, 0.0]));
        // In the solid strip (1, 1.5): negative, towards the nearer wall.
        assert_eq!(
            ch.distance([0.0, 1.125, 0.0], 2),
            (-0.125, [0.0, -1.0, 0.0])
        );
        assert_eq!(ch.distance([0.0, 1.375, 0.0], 2), (-0.125, [0.0, 1.0, 0.0]));
        // One period on, the same.
        assert_eq!(ch.distance([0.0, 1.75, 0.0], 2), (0.25, [0.0, 1.0, 0.0]));
    }

    #[test]
    fn the_ghost_of_a_spinning_cylinder_carries_its_surface_speed() {
        let w = ShapedWall::new(Shape::Ball {
            center: [0.0; 3],
            radius: 1.0,
            fluid_inside: false,
        })
        .spinning(2.0, [0.0; 3]);
        assert!(w.validate(2).is_ok());
        let img = w.shape.image([1.1, 0.0, 0.0], 2);
        // Surface speed 2 along +y at (1, 0): ghost 2*2 - v.
        let v = [0.0, 1.5, 0.0];
        assert_eq!(w.ghost_velocity(v, &img, false), [0.0, 2.5, 0.0]);
        assert_eq!(w.ghost_velocity(v, &img, true), [0.0, -1.5, 0.0]);
        // A ball that moves off its place is refused.
        assert!(w.sliding([1.0, 0.0, 0.0]).validate(2).is_err());
        assert!(w.spinning(1.0, [0.5, 0.0, 0.0]).validate(2).is_err());
        // Free slip keeps the tangential part and reflects the normal one.
        let fs = ShapedWall::new(Shape::Plane {
            point: [0.0; 3],
            normal: [0.6, 0.8, 0.0],
        })
        .free_slip();
        let img = fs.shape.image([0.6, 0.8, 0.0], 2);
        let g = fs.ghost_velocity([0.6, 0.8, 0.0], &img, false);
        assert!((g[0] + 0.6).abs() < 1e-15 && (g[1] + 0.8).abs() < 1e-15);
    }
}
