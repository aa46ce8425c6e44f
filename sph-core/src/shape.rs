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
//! bits. A wall's shape stays in place unless it moves as a rigid body
//! ([`ShapedWall::moving`]: a translation and a turn about a travelling
//! pivot, put in place each step by
//! [`crate::domain::Domain::set_wall_time`]); otherwise its surface may only
//! slide along itself (a rotating cylinder, a plane sliding in its own
//! plane), which is what the velocity and angular velocity describe.
//!
//! A ghost of a shaped wall is recorded with [`BODY_FLAG`] and the wall's
//! index in [`crate::boundary::Ghost::mirrors`]. Known limits: a particle
//! near two walls gets one image per wall but no image through their corner
//! (the planar box walls still get theirs), so a concave corner of two
//! shaped walls leaves a small gap in the support; two walls closer together
//! than a support radius (a thin plate with fluid on both sides) mirror
//! each side's fluid into the other side's reach, and the fluid on each
//! side sees the other's through the plate (sph-std refuses such scenes).

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

/// The most vertices a [`Shape::Polygon`] holds.
pub const MAX_POLYGON_VERTICES: usize = 12;

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
    /// A simple polygon (2D; a prism along z in 3D), convex or concave,
    /// with its first `count` vertices in order (either orientation). The
    /// closest wall point is on an edge or at a vertex, so the mirror is a
    /// reflection across an edge or a point reflection through a vertex:
    /// either keeps area (the Jacobian is 1). A particle near a concave
    /// corner (the fluid's angle below 180 degrees) gets one image, through
    /// its closest edge; wall particles fill such corners completely
    /// (`crate::domain::Domain::with_wall_particles`).
    Polygon {
        /// Vertices `[x, y]`; entries from `count` on are ignored.
        vertices: [[f64; 2]; MAX_POLYGON_VERTICES],
        /// Number of vertices (3 to [`MAX_POLYGON_VERTICES`]).
        count: usize,
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
                Polygon {
                    vertices: a,
                    count: n,
                    fluid_inside: i,
                },
                Polygon {
                    vertices: b,
                    count: m,
                    fluid_inside: j,
                },
            ) => n == m && i == j && a.get(..*n) == b.get(..*m),
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
    /// A [`Shape::Polygon`] from its vertices in order (either
    /// orientation), checked.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] (`wall.vertices`) for fewer than 3 or
    /// more than [`MAX_POLYGON_VERTICES`] vertices, a non-finite one, a
    /// repeated one, crossing edges or no area.
    pub fn polygon(points: &[[f64; 2]], fluid_inside: bool) -> Result<Self> {
        let mut vertices = [[0.0; 2]; MAX_POLYGON_VERTICES];
        let count = points.len();
        if count > MAX_POLYGON_VERTICES {
            return Err(Error::InvalidParameter {
                name: "wall.vertices",
                value: count as f64,
                rule: "a polygon needs 3 to 12 vertices",
            });
        }
        vertices[..count].copy_from_slice(points);
        check_polygon(&vertices, count)?;
        Ok(Shape::Polygon {
            vertices,
            count,
            fluid_inside,
        })
    }

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
            Shape::Polygon {
                vertices,
                count,
                fluid_inside,
            } => polygon_distance(
                &vertices[..count.min(MAX_POLYGON_VERTICES)],
                fluid_inside,
                x,
            ),
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
            Shape::Plane { .. } | Shape::Channel { .. } | Shape::Polygon { .. } => 1.0,
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
        self.moved(by, [1.0, 0.0], [0.0; 3])
    }

    /// The same shape turned about the z axis through `pivot` by the angle
    /// whose cosine and sine are `turn`, then shifted by `by`: where a rigid
    /// body's shape is once it has moved. With `turn = [1, 0]` only the
    /// shift is applied (bit for bit). A [`Shape::Sdf`] only shifts (its
    /// function cannot be turned: [`ShapedWall::validate`] refuses a
    /// turning one), and so does a circle or sphere about its own centre.
    pub fn moved(self, by: [f64; 3], turn: [f64; 2], pivot: [f64; 3]) -> Self {
        let still = turn == [1.0, 0.0];
        let spin = |v: [f64; 3]| {
            if still {
                v
            } else {
                [
                    turn[0] * v[0] - turn[1] * v[1],
                    turn[1] * v[0] + turn[0] * v[1],
                    v[2],
                ]
            }
        };
        let place = |p: [f64; 3]| {
            let q = if still {
                p
            } else {
                let r = spin(sub(p, pivot));
                [pivot[0] + r[0], pivot[1] + r[1], p[2]]
            };
            [q[0] + by[0], q[1] + by[1], q[2] + by[2]]
        };
        match self {
            Shape::Plane { point, normal } => Shape::Plane {
                point: place(point),
                normal: spin(normal),
            },
            Shape::Channel {
                point,
                normal,
                width,
                period,
            } => Shape::Channel {
                point: place(point),
                normal: spin(normal),
                width,
                period,
            },
            Shape::Ball {
                center,
                radius,
                fluid_inside,
            } => Shape::Ball {
                center: place(center),
                radius,
                fluid_inside,
            },
            Shape::Cylinder {
                center,
                radius,
                fluid_inside,
            } => Shape::Cylinder {
                center: place(center),
                radius,
                fluid_inside,
            },
            Shape::Polygon {
                mut vertices,
                count,
                fluid_inside,
            } => {
                for v in &mut vertices {
                    let q = place([v[0], v[1], 0.0]);
                    *v = [q[0], q[1]];
                }
                Shape::Polygon {
                    vertices,
                    count,
                    fluid_inside,
                }
            }
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

/// Signed distance (positive in the fluid) and unit normal into the fluid
/// of `x` from the polygon with `vertices` (its `x`, `y` only): the
/// closest point over the edges, the sign from the even-odd rule. On the
/// boundary itself the normal is the first closest edge's.
fn polygon_distance(vertices: &[[f64; 2]], fluid_inside: bool, x: [f64; 3]) -> (f64, [f64; 3]) {
    let p = [x[0], x[1]];
    let n = vertices.len();
    let mut best = f64::INFINITY;
    let mut closest = p;
    let mut edge = [0.0, 0.0];
    // The closest point lies inside the edge (not at a vertex), and the
    // side of the edge's line `p` is on (the cross product's sign).
    let mut interior = false;
    let mut side = 0.0;
    let mut inside = false;
    for k in 0..n {
        let a = vertices[k];
        let b = vertices[(k + 1) % n];
        let e = [b[0] - a[0], b[1] - a[1]];
        let ap = [p[0] - a[0], p[1] - a[1]];
        let len2 = e[0] * e[0] + e[1] * e[1];
        let t = if len2 > 0.0 {
            ((ap[0] * e[0] + ap[1] * e[1]) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let q = [a[0] + t * e[0], a[1] + t * e[1]];
        let d2 = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]);
        if d2 < best {
            best = d2;
            closest = q;
            edge = e;
            interior = t > 0.0 && t < 1.0;
            side = e[0] * ap[1] - e[1] * ap[0];
        }
        // Even-odd: does the edge cross the horizontal ray to +x?
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let xc = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * e[0];
            if p[0] < xc {
                inside = !inside;
            }
        }
    }
    let in_fluid = inside == fluid_inside;
    let dist = f64s::sqrt(best);
    let len = f64s::sqrt(edge[0] * edge[0] + edge[1] * edge[1]);
    let left = [-edge[1] / len, edge[0] / len];
    let towards = if interior && side != 0.0 {
        // Along an edge: its normal (exact), on `x`'s side, turned into
        // the fluid.
        let s = if (side > 0.0) == in_fluid { 1.0 } else { -1.0 };
        [s * left[0], s * left[1]]
    } else if dist > 0.0 {
        // Nearest a vertex: from it to `x`, turned into the fluid.
        let s = if in_fluid { 1.0 } else { -1.0 } / dist;
        [s * (p[0] - closest[0]), s * (p[1] - closest[1])]
    } else {
        // On the boundary: the edge's normal on the fluid's side.
        let s = if (polygon_area(vertices) > 0.0) == fluid_inside {
            1.0
        } else {
            -1.0
        };
        [s * left[0], s * left[1]]
    };
    (
        if in_fluid { dist } else { -dist },
        [towards[0], towards[1], 0.0],
    )
}

/// Signed area of a polygon (positive counter-clockwise).
fn polygon_area(vertices: &[[f64; 2]]) -> f64 {
    let n = vertices.len();
    let mut twice = 0.0;
    for k in 0..n {
        let (a, b) = (vertices[k], vertices[(k + 1) % n]);
        twice += a[0] * b[1] - b[0] * a[1];
    }
    0.5 * twice
}

/// Whether segments `ab` and `cd` meet (touching counts).
fn segments_meet(a: [f64; 2], b: [f64; 2], c: [f64; 2], d: [f64; 2]) -> bool {
    let orient = |p: [f64; 2], q: [f64; 2], r: [f64; 2]| {
        let v = (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]);
        if v > 0.0 {
            1
        } else if v < 0.0 {
            -1
        } else {
            0
        }
    };
    let on = |p: [f64; 2], q: [f64; 2], r: [f64; 2]| {
        r[0] >= p[0].min(q[0])
            && r[0] <= p[0].max(q[0])
            && r[1] >= p[1].min(q[1])
            && r[1] <= p[1].max(q[1])
    };
    let (o1, o2, o3, o4) = (
        orient(a, b, c),
        orient(a, b, d),
        orient(c, d, a),
        orient(c, d, b),
    );
    if o1 != o2 && o3 != o4 {
        return true;
    }
    (o1 == 0 && on(a, b, c))
        || (o2 == 0 && on(a, b, d))
        || (o3 == 0 && on(c, d, a))
        || (o4 == 0 && on(c, d, b))
}

/// Checks a polygon: 3 to [`MAX_POLYGON_VERTICES`] finite vertices, no
/// zero-length edge, no two edges crossing or touching except neighbours
/// at their shared vertex.
fn check_polygon(vertices: &[[f64; 2]; MAX_POLYGON_VERTICES], count: usize) -> Result<()> {
    let bad = |name: &'static str, value: f64, rule: &'static str| {
        Err(Error::InvalidParameter { name, value, rule })
    };
    if !(3..=MAX_POLYGON_VERTICES).contains(&count) {
        return bad(
            "wall.vertices",
            count as f64,
            "a polygon needs 3 to 12 vertices",
        );
    }
    let v = &vertices[..count];
    if !v.iter().flatten().all(|c| c.is_finite()) {
        return bad(
            "wall.vertices",
            f64::NAN,
            "a polygon's vertices must be finite",
        );
    }
    for k in 0..count {
        let (a, b) = (v[k], v[(k + 1) % count]);
        if a == b {
            return bad(
                "wall.vertices",
                k as f64,
                "a polygon's consecutive vertices must differ (vertex index given)",
            );
        }
        for m in k + 1..count {
            let neighbours = m == k + 1 || (k == 0 && m == count - 1);
            if neighbours {
                continue;
            }
            if segments_meet(a, b, v[m], v[(m + 1) % count]) {
                return bad(
                    "wall.vertices",
                    k as f64,
                    "a polygon's edges must not cross or touch (first edge index given)",
                );
            }
        }
    }
    if polygon_area(v) == 0.0 {
        return bad("wall.vertices", 0.0, "a polygon must enclose an area");
    }
    Ok(())
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
    /// Set when the whole wall moves as a rigid body ([`Self::moving`]):
    /// where it started and how far it has gone.
    pub body: Option<Body>,
}

/// A wall that moves as a rigid body: at time `t` a point `x0` of its
/// starting shape is at `pivot + v t + R(omega t) (x0 - pivot)`, `R` the
/// turn about the z axis ([`ShapedWall::moving`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Body {
    /// The shape at time zero.
    pub shape: Shape,
    /// The centre of the turn at time zero.
    pub pivot: [f64; 3],
    /// The shift `v t` at the current time.
    pub shift: [f64; 3],
    /// Cosine and sine of the angle `omega t` at the current time.
    pub turn: [f64; 2],
}

impl Body {
    /// Where the body point that started at `x0` is now.
    pub fn place(&self, x0: [f64; 3]) -> [f64; 3] {
        let [c, s] = self.turn;
        let q = if self.turn == [1.0, 0.0] {
            x0
        } else {
            let r = sub(x0, self.pivot);
            [
                self.pivot[0] + c * r[0] - s * r[1],
                self.pivot[1] + s * r[0] + c * r[1],
                x0[2],
            ]
        };
        [
            q[0] + self.shift[0],
            q[1] + self.shift[1],
            q[2] + self.shift[2],
        ]
    }
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
            body: None,
        }
    }

    /// The same wall moving as a rigid body: translating at `velocity` and
    /// turning at `omega` (radians per second) about the z axis through
    /// `pivot`, which travels with it. Its surface moves with the body
    /// (`v + omega z x (x - pivot(t))`), so a no-slip wall drags the fluid
    /// along; [`crate::domain::Domain::set_wall_time`] puts it where it
    /// is at each step, and its wall particles (with
    /// [`crate::domain::Domain::with_wall_particles`]) travel with it.
    pub fn moving(mut self, velocity: [f64; 3], omega: f64, pivot: [f64; 3]) -> Self {
        self.velocity = velocity;
        self.omega = omega;
        self.center = pivot;
        self.body = Some(Body {
            shape: self.shape,
            pivot,
            shift: [0.0; 3],
            turn: [1.0, 0.0],
        });
        self
    }

    /// Puts a [`Self::moving`] wall where it is at time `t` (seconds since
    /// the start); does nothing to a wall that stays in place.
    pub fn set_time(&mut self, t: f64) {
        let Some(body) = self.body.as_mut() else {
            return;
        };
        let angle = self.omega * t;
        body.turn = if angle == 0.0 {
            [1.0, 0.0]
        } else {
            [f64s::cos(angle), f64s::sin(angle)]
        };
        body.shift = [
            self.velocity[0] * t,
            self.velocity[1] * t,
            self.velocity[2] * t,
        ];
        self.shape = body.shape.moved(body.shift, body.turn, body.pivot);
        self.center = axpy(1.0, body.shift, body.pivot);
    }

    /// The fastest any point within `reach` of the wall's turning centre
    /// moves (zero for a wall that stays in place).
    pub fn body_speed(&self, reach: f64) -> f64 {
        if self.body.is_none() {
            return 0.0;
        }
        f64s::sqrt(dot(self.velocity, self.velocity)) + self.omega.abs() * reach
    }

    /// The acceleration of the body point at `p`: `-omega^2 (p - c)` in the
    /// plane of the turn (zero for a wall that stays in place; a spinning
    /// surface of a shape at rest does not accelerate its wall particles).
    pub fn body_acceleration(&self, p: [f64; 3]) -> [f64; 3] {
        if self.body.is_none() || self.omega == 0.0 {
            return [0.0; 3];
        }
        let w2 = self.omega * self.omega;
        [
            -w2 * (p[0] - self.center[0]),
            -w2 * (p[1] - self.center[1]),
            0.0,
        ]
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
        if let Some(body) = self.body.as_mut() {
            body.shape = body.shape.translated(by);
            body.pivot = axpy(1.0, by, body.pivot);
        }
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
        // A rigid body may go anywhere; its motion is checked below.
        let body = self.body.is_some();
        let spins_in_place = |center: [f64; 3]| {
            body || self.omega == 0.0 || (0..dim.min(2)).all(|a| self.center[a] == center[a])
        };
        let no_drift = |normal: Option<[f64; 3]>| {
            body || match normal {
                Some(n) => dot(self.velocity, n) == 0.0,
                None => self.velocity.iter().all(|&c| c == 0.0),
            }
        };
        if let Some(b) = &self.body {
            if !finite3(b.pivot) || !finite3(b.shift) || !b.turn.iter().all(|c| c.is_finite()) {
                return bad(
                    "wall.pivot",
                    f64::NAN,
                    "a moving wall's pivot must be finite",
                );
            }
            if self.omega != 0.0 {
                let turns = match b.shape {
                    Shape::Sdf { .. } => Some("a signed-distance wall may translate but not turn"),
                    Shape::Channel { period, .. } if period.is_finite() => {
                        Some("a periodic channel may translate but not turn")
                    }
                    _ => None,
                };
                if let Some(rule) = turns {
                    return bad("wall.omega", self.omega, rule);
                }
            }
        }
        match self.shape {
            Shape::Plane { point, normal } => {
                if !finite3(point) || !unit(normal) {
                    return bad(
                        "wall.normal",
                        dot(normal, normal),
                        "a plane needs a finite point and a unit normal",
                    );
                }
                if !no_drift(Some(normal)) || (self.omega != 0.0 && !body) {
                    return bad(
                        "wall.velocity",
                        dot(self.velocity, normal),
                        "a plane may only slide along itself (or move as a body)",
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
                if !no_drift(Some(normal)) || (self.omega != 0.0 && !body) {
                    return bad(
                        "wall.velocity",
                        dot(self.velocity, normal),
                        "a channel's walls may only slide along themselves (or move as a body)",
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
            Shape::Polygon {
                vertices, count, ..
            } => {
                check_polygon(&vertices, count)?;
                if !body && (!no_drift(None) || self.omega != 0.0) {
                    return bad(
                        "wall.velocity",
                        self.omega,
                        "a polygon's surface cannot slide along itself: it stays at rest or moves as a body",
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
    fn a_polygon_is_the_nearest_of_its_edges_and_vertices() {
        // The unit square, fluid inside, against its four planes; either
        // orientation.
        let ccw = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let mut cw = ccw;
        cw.reverse();
        let planes = [
            ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
            ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
            ([1.0, 1.0, 0.0], [-1.0, 0.0, 0.0]),
            ([1.0, 1.0, 0.0], [0.0, -1.0, 0.0]),
        ];
        for vertices in [ccw, cw] {
            let sq = Shape::polygon(&vertices, true).unwrap();
            for x in [
                [0.3, 0.1, 0.0],
                [0.9, 0.45, 0.0],
                [0.5, 0.8, 0.0],
                [0.02, 0.6, 0.0],
            ] {
                let nearest = planes
                    .iter()
                    .map(|&(point, normal)| Shape::Plane { point, normal }.distance(x, 2))
                    .min_by(|a, b| a.0.total_cmp(&b.0))
                    .unwrap();
                let (d, n) = sq.distance(x, 2);
                assert!((d - nearest.0).abs() < 1e-15, "{x:?}");
                assert_eq!(n, nearest.1);
                assert_eq!(sq.image(x, 2).jacobian, 1.0);
            }
            // Outside, behind the corner (1, 1): negative, the normal
            // from the point towards the vertex.
            let (d, n) = sq.distance([1.3, 1.4, 0.0], 2);
            assert!((d + 0.5).abs() < 1e-15);
            assert!((n[0] + 0.6).abs() < 1e-15 && (n[1] + 0.8).abs() < 1e-15);
            // On an edge: the edge's inward normal.
            assert_eq!(sq.distance([0.5, 0.0, 0.0], 2), (0.0, [0.0, 1.0, 0.0]));
        }
        // An obstacle: the square's outside is the fluid. Beyond a convex
        // corner the image is the point reflection through it.
        let block = Shape::polygon(&ccw, false).unwrap();
        let img = block.image([1.3, 1.4, 0.0], 2);
        assert!((img.distance - 0.5).abs() < 1e-15);
        assert!((img.position[0] - 0.7).abs() < 1e-15 && (img.position[1] - 0.6).abs() < 1e-15);
        assert_eq!(img.jacobian, 1.0);
        assert_eq!(block.distance([0.5, 0.0, 0.0], 2), (0.0, [0.0, -1.0, 0.0]));
        // A concave polygon (an L, fluid inside): a point in the notch is
        // behind the wall, one in the corner's reach is nearest the
        // reflex vertex (1, 1).
        let l = Shape::polygon(
            &[
                [0.0, 0.0],
                [2.0, 0.0],
                [2.0, 1.0],
                [1.0, 1.0],
                [1.0, 2.0],
                [0.0, 2.0],
            ],
            true,
        )
        .unwrap();
        assert!(l.distance([1.5, 1.5, 0.0], 2).0 < 0.0);
        let (d, n) = l.distance([0.7, 0.6, 0.0], 2);
        assert!((d - 0.5).abs() < 1e-15);
        assert!((n[0] + 0.6).abs() < 1e-15 && (n[1] + 0.8).abs() < 1e-15);
        // Shifted with the domain's origin.
        let moved = l.translated([1.0, -1.0, 0.0]);
        assert_eq!(
            moved.distance([1.7, -0.4, 0.0], 2),
            l.distance([0.7, 0.6, 0.0], 2)
        );
        assert!(l == l && l != moved);
    }

    #[test]
    fn bad_polygons_are_named_errors() {
        let name = |r: Result<Shape>| match r {
            Err(Error::InvalidParameter { name, .. }) => name,
            other => panic!("{other:?}"),
        };
        // Too few, too many, repeated, not finite, crossing, flat.
        assert_eq!(
            name(Shape::polygon(&[[0.0, 0.0], [1.0, 0.0]], true)),
            "wall.vertices"
        );
        assert_eq!(
            name(Shape::polygon(&[[0.0, 0.0]; 13], true)),
            "wall.vertices"
        );
        let repeated = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        assert_eq!(name(Shape::polygon(&repeated, true)), "wall.vertices");
        let nan = [[0.0, 0.0], [f64::NAN, 0.0], [0.0, 1.0]];
        assert_eq!(name(Shape::polygon(&nan, true)), "wall.vertices");
        let bowtie = [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]];
        assert_eq!(name(Shape::polygon(&bowtie, true)), "wall.vertices");
        let flat = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]];
        assert_eq!(name(Shape::polygon(&flat, true)), "wall.vertices");
        // A polygon wall must be at rest.
        let tri = Shape::polygon(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], false).unwrap();
        assert!(ShapedWall::new(tri).validate(2).is_ok());
        assert!(ShapedWall::new(tri)
            .spinning(1.0, [0.0; 3])
            .validate(2)
            .is_err());
        assert!(ShapedWall::new(tri)
            .sliding([1.0, 0.0, 0.0])
            .validate(2)
            .is_err());
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

    #[test]
    fn a_moving_body_is_its_starting_shape_turned_and_shifted() {
        // A unit square centred at (2, 1), turning at omega = pi/2 about
        // its centre and drifting at (0.5, 0) (exact in binary).
        let square =
            Shape::polygon(&[[1.5, 0.5], [2.5, 0.5], [2.5, 1.5], [1.5, 1.5]], true).unwrap();
        let omega = core::f64::consts::FRAC_PI_2;
        let mut w = ShapedWall::new(square).moving([0.5, 0.0, 0.0], omega, [2.0, 1.0, 0.0]);
        assert!(w.validate(2).is_ok());
        // At time zero nothing moves, bit for bit.
        w.set_time(0.0);
        assert_eq!(w.shape, square);
        // After half a second it has turned 45 degrees anticlockwise and
        // gone 0.25: the corner (2.5, 0.5) is at (2.25, 1) + (sqrt(1/2), 0).
        w.set_time(0.5);
        let body = w.body.unwrap();
        let corner = body.place([2.5, 0.5, 0.0]);
        let h = core::f64::consts::FRAC_1_SQRT_2;
        assert!((corner[0] - (2.25 + h)).abs() < 1e-12 && (corner[1] - 1.0).abs() < 1e-12);
        let Shape::Polygon { vertices, .. } = w.shape else {
            panic!("a polygon stays a polygon");
        };
        assert!((vertices[1][0] - corner[0]).abs() < 1e-15);
        assert!((vertices[1][1] - corner[1]).abs() < 1e-15);
        // A body point keeps its distance to the moved wall.
        let inside = [1.8, 0.7, 0.0];
        let (d0, _) = square.distance(inside, 2);
        let (d1, _) = w.shape.distance(body.place(inside), 2);
        assert!((d0 - d1).abs() < 1e-12);
        // The surface moves with the body: v + omega z x (x - c(t)).
        assert_eq!(w.center, [2.25, 1.0, 0.0]);
        let u = w.surface_velocity(corner);
        assert!((u[0] - 0.5).abs() < 1e-12 && (u[1] - omega * h).abs() < 1e-12);
        let a = w.body_acceleration(corner);
        assert!((a[0] + omega * omega * h).abs() < 1e-12 && a[1].abs() < 1e-12);
        assert!((w.body_speed(1.0) - (0.5 + omega)).abs() < 1e-15);
        // A wall that stays in place neither moves nor accelerates.
        let mut still = ShapedWall::new(square);
        still.set_time(3.0);
        assert_eq!(still.shape, square);
        assert_eq!(still.body_speed(10.0), 0.0);
    }

    #[test]
    fn a_body_may_translate_any_shape_but_not_turn_every_one() {
        let sdf = Shape::Sdf {
            f: circle_sdf,
            params: [0.5, 0.5, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0],
            offset: [0.0; 3],
            step: 1e-4,
        };
        let slide = ShapedWall::new(sdf).moving([1.0, 0.0, 0.0], 0.0, [0.0; 3]);
        assert!(slide.validate(2).is_ok());
        let turn = ShapedWall::new(sdf).moving([0.0; 3], 1.0, [0.5, 0.5, 0.0]);
        assert!(matches!(
            turn.validate(2),
            Err(Error::InvalidParameter {
                name: "wall.omega",
                ..
            })
        ));
        let channel = Shape::Channel {
            point: [0.0; 3],
            normal: [0.0, 1.0, 0.0],
            width: 0.5,
            period: 1.0,
        };
        assert!(ShapedWall::new(channel)
            .moving([0.0, 0.1, 0.0], 0.0, [0.0; 3])
            .validate(2)
            .is_ok());
        assert!(ShapedWall::new(channel)
            .moving([0.0; 3], 0.1, [0.0; 3])
            .validate(2)
            .is_err());
        // A plane moving along its normal is a piston: allowed as a body,
        // refused as a sliding surface.
        let plane = Shape::Plane {
            point: [0.0; 3],
            normal: [1.0, 0.0, 0.0],
        };
        assert!(ShapedWall::new(plane)
            .moving([0.2, 0.0, 0.0], 0.0, [0.0; 3])
            .validate(2)
            .is_ok());
        assert!(ShapedWall::new(plane)
            .sliding([0.2, 0.0, 0.0])
            .validate(2)
            .is_err());
        let mut piston = ShapedWall::new(plane).moving([0.2, 0.0, 0.0], 0.0, [0.0; 3]);
        piston.set_time(2.0);
        let (d, _) = piston.shape.distance([1.0, 0.0, 0.0], 2);
        assert!((d - 0.6).abs() < 1e-15);
        let nan = ShapedWall::new(plane).moving([0.0; 3], 0.0, [f64::NAN, 0.0, 0.0]);
        assert!(nan.validate(2).is_err());
    }
}
