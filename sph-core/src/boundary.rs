//! Planar walls by mirrored ghost particles.
//!
//! For every fluid particle closer than one support radius to a wall, a ghost
//! is written into the reserved tail of the particle arrays: its position is
//! the mirror image, and it copies the source's mass, density and pressure
//! (zero normal pressure gradient). Its velocity follows the wall's rule
//! ([`WallKind`]): no-slip `2 V_w - v`, so that the velocity interpolated at
//! the wall is the wall's own (a moving Couette plate gets `2U - u`, not
//! `-u`); free-slip reflects only the normal component.
//!
//! Near a corner of two (or three) walls the particle also gets the images
//! across both walls together, so that its support is filled on every side.
//! Ghosts are sources in the sums, never destinations: they are rebuilt from
//! their fluid images before every evaluation and never integrated.
//!
//! Wall particles ([`Domain::with_wall_particles`]; Adami, Hu & Adams
//! 2012) replace the mirrors of the planar walls: a fixed lattice behind
//! the walls, written into the same tail after the mirrored ghosts and
//! marked [`WALL_PARTICLE`]. They take their values from the fluid near
//! them before each pass (see [`crate::solver`]): velocity `2 V_w - v~`
//! (no-slip; free slip reverses only the normal part) from the Shepard
//! average `v~` of the fluid velocity, pressure
//! `(sum_f p_f W_wf + g . sum_f rho_f r_wf W_wf) / sum_f W_wf`, density
//! from the equation of state, mass `rho0` times their lattice volume.
//! Unlike a mirror image they stay put as a fluid particle nears the
//! wall, so their repulsion does not vanish at the wall.
//!
//! Running out of reserved capacity is [`Error::CapacityExceeded`] with the
//! number of ghosts needed, not a panic.

use crate::domain::{Domain, Reflection, Side, WallKind};
use crate::error::{Error, Result};
use crate::real::Real;
use crate::shape::{narrow, widen, BODY_FLAG};
use crate::space::{Space, VectorOps};

/// Marks a ghost record as a wall particle; the low bits then name the one
/// wall (bit `2a` or `2a + 1`) whose velocity rule it follows: the wall it
/// lies deepest behind.
pub const WALL_PARTICLE: u8 = 0x40;

/// One ghost: its fluid source and which mirrors produced it.
///
/// Bit `2a` of `mirrors` is the wall on the lower side of axis `a`, bit
/// `2a + 1` the one on the upper side; [`crate::shape::BODY_FLAG`] marks a
/// shaped wall's image and [`WALL_PARTICLE`] a wall particle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Ghost {
    /// Index of the fluid particle this ghost mirrors; for a wall particle
    /// (which has none), its index in the box's lattice if its wall moves
    /// as a body ([`body_wall_particle`]), else 0.
    pub source: u32,
    /// Mirrors applied (see the type docs).
    pub mirrors: u8,
}

/// Reflects position `x` across the walls named in `mirrors`: the normal
/// coordinate always; for a [`Reflection::Point`] wall the coordinates along
/// the wall too, through the wall's anchor (the result may then lie up to
/// one period outside the box along those axes).
#[inline]
pub fn mirror_position<S: Space>(domain: &Domain<S>, mut x: S::Vector, mirrors: u8) -> S::Vector {
    if mirrors & BODY_FLAG != 0 {
        return match domain.shaped_wall(usize::from(mirrors & !BODY_FLAG)) {
            Some(w) => narrow::<S>(w.shape.image(widen::<S>(x), S::DIM).position),
            None => x,
        };
    }
    let extent = domain.extent();
    for a in 0..S::DIM {
        for (bit, side) in [(2 * a, Side::Lower), (2 * a + 1, Side::Upper)] {
            if mirrors & (1 << bit) == 0 {
                continue;
            }
            x[a] = match side {
                Side::Lower => -x[a],
                Side::Upper => S::Real::TWO * extent[a] - x[a],
            };
            if domain.wall(a, side).map(|w| w.reflection) == Some(Reflection::Point) {
                let anchor = domain.anchor(a, side);
                for b in 0..S::DIM {
                    if b != a {
                        x[b] = S::Real::TWO * anchor[b] - x[b];
                    }
                }
            }
        }
    }
    x
}

/// Moves `x` by whole periods along the periodic axes so that it lies within
/// half a period of `near` (a few steps at most; positions are finite).
#[inline]
pub fn nearest_image<S: Space>(domain: &Domain<S>, mut x: S::Vector, near: S::Vector) -> S::Vector {
    let extent = domain.extent();
    for a in 0..S::DIM {
        if !domain.is_periodic(a) {
            continue;
        }
        let l = extent[a];
        let half = S::Real::HALF * l;
        // An anchor that wrapped moves a point image by two periods.
        for _ in 0..4 {
            if x[a] - near[a] > half {
                x[a] -= l;
            } else if near[a] - x[a] > half {
                x[a] += l;
            } else {
                break;
            }
        }
    }
    x
}

/// The image of `x` inside `[0, extent)` along the periodic axes, for a
/// point that lies less than two periods outside (mirror images of wrapped
/// fluid positions do).
#[inline]
fn into_box<S: Space>(domain: &Domain<S>, mut x: S::Vector) -> S::Vector {
    let extent = domain.extent();
    for a in 0..S::DIM {
        if !domain.is_periodic(a) {
            continue;
        }
        let l = extent[a];
        for _ in 0..2 {
            if x[a] < S::Real::ZERO {
                x[a] += l;
            } else if x[a] >= l {
                x[a] -= l;
            }
        }
        // Rounding can land on `l` (the same point as 0).
        if !(x[a] >= S::Real::ZERO && x[a] < l) {
            x[a] = S::Real::ZERO;
        }
    }
    x
}

/// The ghost velocity for fluid velocity `v` across the walls in `mirrors`.
///
/// With `homogeneous`, wall velocities are taken as zero: the linear part of
/// the rule, used to analyse the viscous operator's stability.
#[inline]
pub fn mirror_velocity<S: Space>(
    domain: &Domain<S>,
    mut v: S::Vector,
    mirrors: u8,
    homogeneous: bool,
) -> S::Vector {
    if mirrors & BODY_FLAG != 0 {
        // Shaped walls need the source's position: see [`shaped_ghost`].
        return v;
    }
    for a in 0..S::DIM {
        for (bit, side) in [(2 * a, Side::Lower), (2 * a + 1, Side::Upper)] {
            if mirrors & (1 << bit) == 0 {
                continue;
            }
            let Some(wall) = domain.wall(a, side) else {
                continue;
            };
            let vw = if homogeneous {
                S::Vector::zero()
            } else {
                wall.velocity
            };
            match wall.kind {
                WallKind::NoSlip => v = vw * S::Real::TWO - v,
                WallKind::FreeSlip => v[a] = S::Real::TWO * vw[a] - v[a],
            }
        }
    }
    v
}

/// The velocity of a wall particle at `x` (code `mirrors`, see
/// [`for_each_wall_particle`]) from the Shepard average `v` of the fluid
/// velocity near it, taken at the fluid's Shepard centroid `centroid`:
/// no-slip `2 v_w - v`, free slip `v` with the normal part of `v - v_w`
/// reversed, `v_w` the wall's velocity at `x` (zero with `homogeneous`).
///
/// A wall whose surface turns (a spinning cylinder, a turning body) moves
/// at different speeds at `x` and at the centroid, and no-slip then
/// reflects the fluid's velocity relative to the wall: `v_w(x) + v_w(c) -
/// v`, `c` the centroid. Fluid turning with the wall then gives its wall
/// particles exactly the wall's own velocity, where `2 v_w(x) - v` would
/// add `omega z x (x - c)`, about two spacings' worth of rim speed, and
/// spin the fluid ahead of its container (measured: 4 % at 20 across).
/// For walls at rest or sliding uniformly the two rules are the same.
#[inline]
pub fn wall_particle_velocity<S: Space>(
    domain: &Domain<S>,
    x: S::Vector,
    v: S::Vector,
    centroid: S::Vector,
    mirrors: u8,
    homogeneous: bool,
) -> S::Vector {
    let bits = mirrors & !WALL_PARTICLE;
    if bits & BODY_FLAG == 0 {
        return mirror_velocity(domain, v, bits, homogeneous);
    }
    let Some(w) = domain.shaped_wall(usize::from(bits & !BODY_FLAG)) else {
        return v;
    };
    let p = widen::<S>(x);
    let vw = if homogeneous {
        [0.0; 3]
    } else {
        w.surface_velocity(p)
    };
    let va = widen::<S>(v);
    let out = if w.no_slip && w.omega != 0.0 && !homogeneous {
        let vc = w.surface_velocity(widen::<S>(centroid));
        [
            vw[0] + vc[0] - va[0],
            vw[1] + vc[1] - va[1],
            vw[2] + vc[2] - va[2],
        ]
    } else if w.no_slip {
        [
            2.0 * vw[0] - va[0],
            2.0 * vw[1] - va[1],
            2.0 * vw[2] - va[2],
        ]
    } else {
        let (_, n) = w.shape.distance(p, S::DIM);
        let rel = (va[0] - vw[0]) * n[0] + (va[1] - vw[1]) * n[1] + (va[2] - vw[2]) * n[2];
        [
            va[0] - 2.0 * rel * n[0],
            va[1] - 2.0 * rel * n[1],
            va[2] - 2.0 * rel * n[2],
        ]
    };
    narrow::<S>(out)
}

/// Velocity and mass factor of a shaped wall's ghost (`mirrors` with
/// [`BODY_FLAG`]) for a source at `x` with velocity `v`; `None` for other
/// ghosts.
#[inline]
pub fn shaped_ghost<S: Space>(
    domain: &Domain<S>,
    x: S::Vector,
    v: S::Vector,
    mirrors: u8,
    homogeneous: bool,
) -> Option<(S::Vector, S::Real)> {
    if mirrors & BODY_FLAG == 0 {
        return None;
    }
    let w = domain.shaped_wall(usize::from(mirrors & !BODY_FLAG))?;
    let img = w.shape.image(widen::<S>(x), S::DIM);
    let vg = w.ghost_velocity(widen::<S>(v), &img, homogeneous);
    Some((narrow::<S>(vg), S::Real::from_f64(img.jacobian)))
}

/// The part along the wall normals of the offset from a source at `x` to
/// its ghost across the walls in `mirrors`: `-2 x_a` or `2 (L_a - x_a)` on
/// each mirrored axis of the box, `-2 d n` through a shaped wall (whose
/// image lies on the normal already). A point-reflected ghost's offset
/// along its wall is left out: it is a kinematic device, not a depth.
#[inline]
pub fn image_offset<S: Space>(domain: &Domain<S>, x: S::Vector, mirrors: u8) -> S::Vector {
    let mut dx = S::Vector::zero();
    if mirrors & BODY_FLAG != 0 {
        if let Some(w) = domain.shaped_wall(usize::from(mirrors & !BODY_FLAG)) {
            let img = w.shape.image(widen::<S>(x), S::DIM);
            for a in 0..S::DIM {
                dx[a] = S::Real::from_f64(-2.0 * img.distance * img.normal[a]);
            }
        }
        return dx;
    }
    let extent = domain.extent();
    for a in 0..S::DIM {
        if mirrors & (1 << (2 * a)) != 0 {
            dx[a] = -S::Real::TWO * x[a];
        }
        if mirrors & (1 << (2 * a + 1)) != 0 {
            dx[a] = S::Real::TWO * (extent[a] - x[a]);
        }
    }
    dx
}

/// The curvature part of the ghost velocity for a source at `x` across the
/// walls in `mirrors`: `curvature d^2` per wall, `d` the source's distance
/// from it (see [`crate::domain::Wall::curvature`]).
#[inline]
pub fn curvature_correction<S: Space>(domain: &Domain<S>, x: S::Vector, mirrors: u8) -> S::Vector {
    let mut dv = S::Vector::zero();
    if mirrors & BODY_FLAG != 0 {
        return dv;
    }
    let extent = domain.extent();
    for a in 0..S::DIM {
        for (bit, side) in [(2 * a, Side::Lower), (2 * a + 1, Side::Upper)] {
            if mirrors & (1 << bit) == 0 {
                continue;
            }
            if let Some(w) = domain.wall(a, side) {
                let d = match side {
                    Side::Lower => x[a],
                    Side::Upper => extent[a] - x[a],
                };
                dv += w.curvature * (d * d);
            }
        }
    }
    dv
}

/// The wall-particle lattice along one axis: `lower` layers behind the
/// lower wall, `inside` points across the box, `upper` layers behind the
/// upper wall.
#[derive(Clone, Copy, Debug)]
struct AxisLattice {
    lower: usize,
    inside: usize,
    upper: usize,
    /// Spacing across the box (the extent over `inside`).
    step: f64,
    /// Spacing of the layers behind the walls.
    spacing: f64,
    extent: f64,
}

impl AxisLattice {
    fn new<S: Space>(domain: &Domain<S>, a: usize, spacing: f64, radius: f64) -> Self {
        let extent = domain.extent()[a].to_f64();
        let layers = |side| {
            if domain.wall(a, side).is_none() {
                return 0;
            }
            let mut k = 0usize;
            while (k as f64 + 0.5) * spacing < radius {
                k += 1;
            }
            k
        };
        let inside = crate::math::f64s::floor(extent / spacing + 0.5).max(1.0) as usize;
        Self {
            lower: layers(Side::Lower),
            inside,
            upper: layers(Side::Upper),
            step: extent / inside as f64,
            spacing,
            extent,
        }
    }

    /// The single point of an axis the space does not have.
    fn flat() -> Self {
        Self {
            lower: 0,
            inside: 1,
            upper: 0,
            step: 1.0,
            spacing: 1.0,
            extent: 1.0,
        }
    }

    fn len(&self) -> usize {
        self.lower + self.inside + self.upper
    }

    /// Coordinate, cell width and depth behind a wall (with the wall's
    /// bit offset: 0 lower, 1 upper) of lattice index `k`.
    fn point(&self, k: usize) -> (f64, f64, Option<(f64, u8)>) {
        if k < self.lower {
            let d = ((self.lower - 1 - k) as f64 + 0.5) * self.spacing;
            (-d, self.spacing, Some((d, 0)))
        } else if k < self.lower + self.inside {
            (
                (((k - self.lower) as f64) + 0.5) * self.step,
                self.step,
                None,
            )
        } else {
            let d = ((k - self.lower - self.inside) as f64 + 0.5) * self.spacing;
            (self.extent + d, self.spacing, Some((d, 1)))
        }
    }
}

/// Calls `f(position, code, volume)` for every wall particle
/// ([`Domain::with_wall_particles`]) within `radius` of the fluid's side
/// of the walls, in a fixed order; does nothing without wall particles.
/// `code` is the record's [`Ghost::mirrors`]: [`WALL_PARTICLE`] with the
/// bit of the planar wall whose rule the particle follows, or with
/// [`BODY_FLAG`] and the index of a shaped wall.
///
/// The planar walls' particles come first: a lattice behind each wall,
/// corners filled. A particle in a corner follows a moving no-slip wall (a
/// lid claims its corners), else the wall it lies deepest behind. Then the
/// shaped walls' particles: the points of the box's own lattice (the
/// step along each axis the box's extent over the nearest whole number of
/// spacings) behind a shaped wall (or less than
/// [`Domain::shaped_wall_front`] spacings in front of it, none by
/// default), by less than `radius` (the largest depth over the walls they
/// lie behind); each follows the wall whose surface is nearest. A fluid
/// seeded on the same lattice at the points in front of every wall (as
/// sph-std's scenes do) and these wall particles then share one lattice
/// with no gap and no point twice (the wall side's threshold is smaller by
/// a millionth of a spacing, so rounding cannot give a point to both).
/// Concave corners and walls closer together than a support fill as any
/// other solid. A solid thinner than the spacing may hold no lattice point
/// and then gets no wall particle at all: the fluid does not see it.
///
/// A wall that moves as a body ([`crate::shape::ShapedWall::moving`]) gets its own
/// particles, whatever other walls it overlaps: the lattice points behind
/// its starting shape, placed where the body is now (and wrapped into the
/// box along periodic axes), so they travel with it.
pub fn for_each_wall_particle<S: Space>(
    domain: &Domain<S>,
    radius: S::Real,
    mut f: impl FnMut(S::Vector, u8, f64),
) {
    each_wall_particle(domain, radius, |x, code, volume, _| f(x, code, volume));
}

/// [`for_each_wall_particle`], with each particle's lattice index (the
/// [`Ghost::source`] of a body's wall particle, which
/// [`body_wall_particle`] places again as the body moves; 0 for the
/// others).
fn each_wall_particle<S: Space>(
    domain: &Domain<S>,
    radius: S::Real,
    mut f: impl FnMut(S::Vector, u8, f64, u32),
) {
    let Some(spacing) = domain.wall_particles() else {
        return;
    };
    let (spacing, radius) = (spacing.to_f64(), radius.to_f64());
    if domain.has_walls() {
        planar_wall_particles(domain, spacing, radius, |x, bit, volume| {
            f(x, WALL_PARTICLE | (1 << bit), volume, 0)
        });
    }
    if domain.shaped_count() > 0 {
        shaped_wall_particles(domain, spacing, radius, f);
    }
}

/// Where the wall particle with `code` and lattice index `index` (its
/// [`Ghost::source`]) is now, if it belongs to a wall that moves as a
/// body; `None` for every other record.
pub fn body_wall_particle<S: Space>(domain: &Domain<S>, code: u8, index: u32) -> Option<S::Vector> {
    if code & WALL_PARTICLE == 0 || code & BODY_FLAG == 0 {
        return None;
    }
    let w = domain.shaped_wall(usize::from(code & !(WALL_PARTICLE | BODY_FLAG)))?;
    let body = w.body.as_ref()?;
    let spacing = domain.wall_particles()?.to_f64();
    let axes = lattice_axes(domain, spacing, spacing);
    let p = lattice_point::<S>(&axes, index as usize);
    Some(into_box(domain, narrow::<S>(body.place(p))))
}

/// The acceleration of the wall particle at `x` with `code` if its wall
/// turns as a body (`-omega^2 (x - c)`, which the wall pressure's
/// momentum balance takes with gravity); `None` for every other record.
pub fn body_acceleration<S: Space>(
    domain: &Domain<S>,
    x: S::Vector,
    code: u8,
) -> Option<S::Vector> {
    if code & WALL_PARTICLE == 0 || code & BODY_FLAG == 0 {
        return None;
    }
    let w = domain.shaped_wall(usize::from(code & !(WALL_PARTICLE | BODY_FLAG)))?;
    if w.body.is_none() || w.omega == 0.0 {
        return None;
    }
    Some(narrow::<S>(w.body_acceleration(widen::<S>(x))))
}

/// The point of the box's lattice with linear index `index` (the first
/// axis fastest).
fn lattice_point<S: Space>(axes: &[AxisLattice; 3], index: usize) -> [f64; 3] {
    let mut p = [0.0; 3];
    let mut rest = index;
    for (a, ax) in axes.iter().enumerate().take(S::DIM) {
        p[a] = ((rest % ax.inside) as f64 + 0.5) * ax.step;
        rest /= ax.inside;
    }
    p
}

/// The wall-particle lattice along each axis of the box, a single point
/// along the axes the space does not have.
fn lattice_axes<S: Space>(domain: &Domain<S>, spacing: f64, radius: f64) -> [AxisLattice; 3] {
    core::array::from_fn(|a| {
        if a < S::DIM {
            AxisLattice::new(domain, a, spacing, radius)
        } else {
            AxisLattice::flat()
        }
    })
}

/// The shaped walls' part of [`for_each_wall_particle`]: first the walls
/// at rest, together; then each body's own particles.
fn shaped_wall_particles<S: Space>(
    domain: &Domain<S>,
    spacing: f64,
    radius: f64,
    mut f: impl FnMut(S::Vector, u8, f64, u32),
) {
    let axes = lattice_axes(domain, spacing, radius);
    let mut volume = 1.0;
    let mut points = 1usize;
    for ax in axes.iter().take(S::DIM) {
        volume *= ax.step;
        points *= ax.inside;
    }
    let front = domain.shaped_wall_front() * spacing - 1e-6 * spacing;
    let code = |b: usize| WALL_PARTICLE | BODY_FLAG | b as u8;
    let walls = domain.shaped_count();
    let at_rest = |b: &usize| domain.shaped_wall(*b).is_some_and(|w| w.body.is_none());
    if (0..walls).any(|b| at_rest(&b)) {
        for index in 0..points {
            let p = lattice_point::<S>(&axes, index);
            // The largest depth behind any wall, and the nearest surface
            // among the walls the point lies behind.
            let mut depth = 0.0f64;
            let mut nearest: Option<(f64, usize)> = None;
            for b in (0..walls).filter(at_rest) {
                let Some(w) = domain.shaped_wall(b) else {
                    continue;
                };
                let (d, _) = w.shape.distance(p, S::DIM);
                if d < front {
                    depth = depth.max(-d);
                    if nearest.is_none_or(|(best, _)| d.abs() < best) {
                        nearest = Some((d.abs(), b));
                    }
                }
            }
            if let Some((_, b)) = nearest {
                if depth < radius {
                    f(narrow::<S>(p), code(b), volume, 0);
                }
            }
        }
    }
    for b in 0..walls {
        let Some(body) = domain.shaped_wall(b).and_then(|w| w.body.as_ref()) else {
            continue;
        };
        for index in 0..points {
            let p = lattice_point::<S>(&axes, index);
            let (d, _) = body.shape.distance(p, S::DIM);
            if d < front && -d < radius {
                let x = into_box(domain, narrow::<S>(body.place(p)));
                f(x, code(b), volume, index as u32);
            }
        }
    }
}

/// The planar walls' part of [`for_each_wall_particle`]: `f(position,
/// wall bit, volume)`.
fn planar_wall_particles<S: Space>(
    domain: &Domain<S>,
    spacing: f64,
    radius: f64,
    mut f: impl FnMut(S::Vector, u8, f64),
) {
    let axes = lattice_axes(domain, spacing, radius);
    // A moving no-slip wall claims the corners it meets, as a lid extends
    // over them: its wall particles' velocity `2 V_w - v~` then continues
    // along the wall into the corner. Split by depth, the corner would hold
    // particles at `-v~` beside the lid's `2 V_w - v~` along the lid, a jump
    // the continuity equation reads as a compression (a lid-driven cavity
    // with continuity density lost its corner particle through the lid).
    let moves = |a: usize, side: u8| {
        let side = if side == 0 { Side::Lower } else { Side::Upper };
        domain.wall(a, side).is_some_and(|w| {
            w.kind == crate::domain::WallKind::NoSlip && w.velocity.norm2() > S::Real::ZERO
        })
    };
    let radius2 = radius * radius;
    for k2 in 0..axes[2].len() {
        let p2 = axes[2].point(k2);
        for k1 in 0..axes[1].len() {
            let p1 = axes[1].point(k1);
            let outer_behind = p1.2.is_some() || p2.2.is_some();
            let x0 = &axes[0];
            let skip = if outer_behind {
                0..0
            } else {
                x0.lower..x0.lower + x0.inside
            };
            for k0 in (0..x0.len()).filter(|k| !skip.contains(k)) {
                let p0 = x0.point(k0);
                let points = [p0, p1, p2];
                let mut depth2 = 0.0;
                let mut deepest: Option<(f64, u8)> = None;
                let mut moving: Option<(f64, u8)> = None;
                let mut volume = 1.0;
                let mut x = S::Vector::zero();
                for (a, &(c, width, behind)) in points.iter().enumerate().take(S::DIM) {
                    x[a] = S::Real::from_f64(c);
                    volume *= width;
                    if let Some((d, side)) = behind {
                        depth2 += d * d;
                        let bit = 2 * a as u8 + side;
                        if deepest.is_none_or(|(best, _)| d > best) {
                            deepest = Some((d, bit));
                        }
                        if moves(a, side) && moving.is_none_or(|(best, _)| d > best) {
                            moving = Some((d, bit));
                        }
                    }
                }
                if let Some((_, bit)) = moving.or(deepest) {
                    if depth2 < radius2 {
                        f(x, bit, volume);
                    }
                }
            }
        }
    }
}

/// Number of wall particles [`generate`] writes for `domain` at `radius`.
pub fn wall_particle_count<S: Space>(domain: &Domain<S>, radius: S::Real) -> usize {
    let mut count = 0;
    for_each_wall_particle(domain, radius, |_, _, _| count += 1);
    count
}

/// The lattice volume of the wall particle at `x` (see
/// [`for_each_wall_particle`]): the layer spacing across each wall it lies
/// behind, the box's own lattice step along the others.
pub fn wall_particle_volume<S: Space>(domain: &Domain<S>, x: S::Vector) -> f64 {
    let Some(spacing) = domain.wall_particles() else {
        return 0.0;
    };
    let spacing = spacing.to_f64();
    let extent = domain.extent();
    let mut volume = 1.0;
    for a in 0..S::DIM {
        let l = extent[a].to_f64();
        let c = x[a].to_f64();
        volume *= if c < 0.0 || c > l {
            spacing
        } else {
            l / crate::math::f64s::floor(l / spacing + 0.5).max(1.0)
        };
    }
    volume
}

/// Writes the ghosts of the fluid particles `x[..n_fluid]` into
/// `x[n_fluid..]` and `ghosts[..]`, and returns how many there are.
///
/// # Errors
/// [`Error::LengthMismatch`] if `x` holds fewer than `n_fluid` positions;
/// [`Error::CapacityExceeded`] (buffer `"ghosts"`) with the number needed if
/// the reserved tail of `x` or the `ghosts` buffer is too short.
pub fn generate<S: Space>(
    domain: &Domain<S>,
    radius: S::Real,
    x: &mut [S::Vector],
    n_fluid: usize,
    ghosts: &mut [Ghost],
) -> Result<usize> {
    if n_fluid > x.len() {
        return Err(Error::LengthMismatch {
            buffer: "x",
            expected: n_fluid,
            got: x.len(),
        });
    }
    let (fluid, tail) = x.split_at_mut(n_fluid);
    let available = tail.len().min(ghosts.len());
    let extent = domain.extent();
    let mut count = 0usize;
    // The fluid's bounding box, for the wall particles below.
    let mut lo = S::Vector::from_fn(|_| S::Real::MAX);
    let mut hi = S::Vector::from_fn(|_| -S::Real::MAX);
    for (i, &xi) in fluid.iter().enumerate() {
        for a in 0..S::DIM {
            lo[a] = lo[a].min(xi[a]);
            hi[a] = hi[a].max(xi[a]);
        }
        // Per axis: "no mirror", plus each wall closer than the radius.
        let mut options = [[0u8; 3]; 3];
        let mut n_opt = [1usize; 3];
        for a in (0..S::DIM).filter(|_| domain.wall_particles().is_none()) {
            if domain.wall(a, Side::Lower).is_some() && xi[a] < radius {
                options[a][n_opt[a]] = 1 << (2 * a);
                n_opt[a] += 1;
            }
            if domain.wall(a, Side::Upper).is_some() && extent[a] - xi[a] < radius {
                options[a][n_opt[a]] = 1 << (2 * a + 1);
                n_opt[a] += 1;
            }
        }
        if domain.shaped_count() > 0 {
            let p = widen::<S>(xi);
            let r = radius.to_f64();
            let tolerance = domain.wall_tolerance();
            for b in 0..domain.shaped_count() {
                let Some(w) = domain.shaped_wall(b) else {
                    continue;
                };
                let img = w.shape.image(p, S::DIM);
                if !(img.distance >= -tolerance) {
                    return Err(Error::BehindWall {
                        particle: i,
                        wall: b,
                        distance: img.distance,
                    });
                }
                // Wall particles stand in for the mirror images.
                if img.distance < r && domain.wall_particles().is_none() {
                    if count < available {
                        tail[count] = into_box(domain, narrow::<S>(img.position));
                        ghosts[count] = Ghost {
                            source: i as u32,
                            mirrors: BODY_FLAG | b as u8,
                        };
                    }
                    count += 1;
                }
            }
        }
        if n_opt == [1, 1, 1] {
            continue;
        }
        for &m2 in &options[2][..n_opt[2]] {
            for &m1 in &options[1][..n_opt[1]] {
                for &m0 in &options[0][..n_opt[0]] {
                    let mirrors = m0 | m1 | m2;
                    if mirrors == 0 {
                        continue;
                    }
                    if count < available {
                        tail[count] = into_box(domain, mirror_position(domain, xi, mirrors));
                        ghosts[count] = Ghost {
                            source: i as u32,
                            mirrors,
                        };
                    }
                    count += 1;
                }
            }
        }
    }
    // Only the wall particles within `radius` of the fluid's bounding box
    // (along the walled axes): the others are in no fluid particle's
    // neighbourhood, so leaving them out changes no sum, and a tank the
    // fluid half fills does not pay for its empty half.
    let near = |xw: S::Vector| {
        (0..S::DIM)
            .all(|a| domain.is_periodic(a) || (xw[a] > lo[a] - radius && xw[a] < hi[a] + radius))
    };
    each_wall_particle(domain, radius, |xw, code, _, index| {
        if !near(xw) {
            return;
        }
        if count < available {
            tail[count] = xw;
            ghosts[count] = Ghost {
                source: index,
                mirrors: code,
            };
        }
        count += 1;
    });
    if count > available {
        return Err(Error::CapacityExceeded {
            buffer: "ghosts",
            needed: count,
            available,
        });
    }
    Ok(count)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Wall;
    use crate::space::{Vector, D2};

    type V2 = Vector<f64, 2>;

    fn box_domain() -> Domain<D2<f64>> {
        Domain::new(V2::new([0.0, 0.0]), V2::new([1.0, 1.0]))
            .unwrap()
            .with_wall(0, Side::Lower, Wall::free_slip())
            .unwrap()
            .with_wall(1, Side::Lower, Wall::no_slip())
            .unwrap()
            .with_wall(1, Side::Upper, Wall::moving(V2::new([2.0, 0.0])))
            .unwrap()
    }

    #[test]
    fn mirrors_positions_and_velocities_by_wall_rule() {
        let d = box_domain();
        let v = V2::new([0.3, -0.2]);
        // Lower y wall, no-slip at rest: both components reversed.
        assert_eq!(mirror_velocity(&d, v, 0b0100, false), V2::new([-0.3, 0.2]));
        // Upper y wall moving at U = 2: tangential 2U - u, normal reversed.
        assert_eq!(mirror_velocity(&d, v, 0b1000, false), V2::new([3.7, 0.2]));
        assert_eq!(mirror_velocity(&d, v, 0b1000, true), V2::new([-0.3, 0.2]));
        // Free-slip x wall: normal reversed, tangential copied.
        assert_eq!(mirror_velocity(&d, v, 0b0001, false), V2::new([-0.3, -0.2]));
        assert_eq!(
            mirror_position(&d, V2::new([0.1, 0.95]), 0b1000),
            V2::new([0.1, 1.05])
        );
        assert_eq!(
            mirror_position(&d, V2::new([0.1, 0.05]), 0b0101),
            V2::new([-0.1, -0.05])
        );
    }

    #[test]
    fn a_curved_wall_continues_a_quadratic_profile_exactly() {
        // u(n) = a n + (c/2) n^2 near a wall at rest: the ghost at -d must
        // carry u(-d) = -a d + (c/2) d^2, which is -u(d) + c d^2.
        let (a, c) = (0.7, -3.0);
        let d = Domain::<D2<f64>>::new(V2::new([0.0, 0.0]), V2::new([1.0, 1.0]))
            .unwrap()
            .with_periodic(0)
            .unwrap()
            .with_wall(
                1,
                Side::Lower,
                Wall::no_slip().with_curvature(V2::new([c, 0.0])),
            )
            .unwrap();
        let dist = 0.05;
        let u = |n: f64| a * n + 0.5 * c * n * n;
        let x = V2::new([0.3, dist]);
        let v = V2::new([u(dist), 0.0]);
        let ghost = mirror_velocity(&d, v, 0b0100, false) + curvature_correction(&d, x, 0b0100);
        assert!(
            (ghost[0] - u(-dist)).abs() < 1e-15,
            "{} vs {}",
            ghost[0],
            u(-dist)
        );
        // A normal curvature is refused.
        assert!(d
            .with_wall(
                1,
                Side::Upper,
                Wall::no_slip().with_curvature(V2::new([0.0, 1.0]))
            )
            .is_err());
    }

    #[test]
    fn corner_particles_get_three_images() {
        let d = box_domain();
        let mut x = [V2::default(); 8];
        x[0] = V2::new([0.05, 0.05]); // near the x- and y-lower walls
        x[1] = V2::new([0.5, 0.5]); // far from every wall
        let mut ghosts = [Ghost::default(); 8];
        let n = generate(&d, 0.1, &mut x, 2, &mut ghosts).unwrap();
        assert_eq!(n, 3);
        let images: std::vec::Vec<_> = x[2..5].to_vec();
        assert!(images.contains(&V2::new([-0.05, 0.05])));
        assert!(images.contains(&V2::new([0.05, -0.05])));
        assert!(images.contains(&V2::new([-0.05, -0.05])));
        assert!(ghosts[..3].iter().all(|g| g.source == 0));
    }

    #[test]
    #[cfg(feature = "wall-particles")]
    fn wall_particles_fill_a_shell_of_the_support_radius_around_the_box() {
        // A closed 1 x 1 box, spacing 0.1, radius 0.25: two layers (0.05
        // and 0.15 deep) along each of the four sides, 10 points along
        // each, and the 2 x 2 corner blocks (all within 0.25 of the corner).
        let walls = |d: Domain<D2<f64>>| {
            let mut d = d;
            for a in 0..2 {
                for side in [Side::Lower, Side::Upper] {
                    d = d.with_wall(a, side, Wall::no_slip()).unwrap();
                }
            }
            d.with_wall_particles(0.1).unwrap()
        };
        let d = walls(Domain::new(V2::new([0.0, 0.0]), V2::new([1.0, 1.0])).unwrap());
        assert_eq!(wall_particle_count(&d, 0.25), 4 * 10 * 2 + 4 * 4);
        let mut volume = 0.0;
        let mut corner_bits = std::vec::Vec::new();
        for_each_wall_particle(&d, 0.25, |x, bit, v| {
            volume += v;
            assert!(x[0] < 0.0 || x[0] > 1.0 || x[1] < 0.0 || x[1] > 1.0);
            assert!((wall_particle_volume(&d, x) - v).abs() < 1e-15);
            if (x[0] + 0.15).abs() < 1e-12 && (x[1] + 0.05).abs() < 1e-12 {
                corner_bits.push(bit);
            }
        });
        // The shell's area: (1.4^2 - 1) in the lattice's cells.
        assert!((volume - (1.4f64 * 1.4 - 1.0)).abs() < 1e-12, "{volume}");
        // Deeper behind the x wall (0.15) than the y wall: the x wall's rule.
        assert_eq!(corner_bits, [WALL_PARTICLE | 1]);
        // Unless the y wall moves: a lid claims its corners.
        let lid = walls(Domain::new(V2::new([0.0, 0.0]), V2::new([1.0, 1.0])).unwrap())
            .with_wall(1, Side::Lower, Wall::moving(V2::new([1.0, 0.0])))
            .unwrap();
        let mut claimed = std::vec::Vec::new();
        for_each_wall_particle(&lid, 0.25, |x, bit, _| {
            if x[1] < 0.0 && (x[0] < 0.0 || x[0] > 1.0) {
                claimed.push(bit);
            }
        });
        assert_eq!(claimed, [WALL_PARTICLE | 4; 8]);
        // A box 1.03 wide: 10 points along it, 0.103 apart, no gap.
        let d = walls(Domain::new(V2::new([0.0, 0.0]), V2::new([1.03, 1.0])).unwrap());
        let mut xs = std::vec::Vec::new();
        for_each_wall_particle(&d, 0.25, |x, _, _| {
            if (x[1] + 0.05).abs() < 1e-12 && x[0] > 0.0 && x[0] < 1.03 {
                xs.push(x[0]);
            }
        });
        assert_eq!(xs.len(), 10);
        assert!((xs[1] - xs[0] - 0.103).abs() < 1e-12);
        // With wall particles the planar walls mirror nothing; fluid in
        // opposite corners spans the box, so the whole shell is written.
        let mut x = [V2::default(); 200];
        x[0] = V2::new([0.05, 0.05]);
        x[1] = V2::new([0.98, 0.95]);
        let mut ghosts = [Ghost::default(); 200];
        let n = generate(&d, 0.25, &mut x, 2, &mut ghosts).unwrap();
        assert_eq!(n, wall_particle_count(&d, 0.25));
        assert!(ghosts[..n].iter().all(|g| g.mirrors & WALL_PARTICLE != 0));
        // One particle in a corner: the wall particles within the radius of
        // the fluid's bounding box, every one within the radius of the
        // particle among them, and no others.
        let n = generate(&d, 0.25, &mut x, 1, &mut ghosts).unwrap();
        let kept = x[1..1 + n].to_vec();
        let mut near = 0;
        for_each_wall_particle(&d, 0.25, |w, _, _| {
            let in_box = (0..2).all(|a| (w[a] - 0.05).abs() < 0.25);
            if in_box {
                near += 1;
                assert!(kept.contains(&w), "{w:?}");
            }
            assert!(in_box || (w - x[0]).norm2() >= 0.25 * 0.25);
        });
        assert_eq!(n, near);
        assert!(n < wall_particle_count(&d, 0.25) / 2);
    }

    #[test]
    #[cfg(all(feature = "shaped-walls", feature = "wall-particles"))]
    fn a_moving_bodys_wall_particles_travel_with_it() {
        use crate::shape::{Shape, ShapedWall};
        // A square container of side 0.5 in a unit box, turning about the
        // box's centre at 1 rad/s (a quarter turn in pi/2 s).
        let square = Shape::polygon(
            &[[0.25, 0.25], [0.75, 0.25], [0.75, 0.75], [0.25, 0.75]],
            true,
        )
        .unwrap();
        let wall = ShapedWall::new(square).moving([0.0; 3], 1.0, [0.5, 0.5, 0.0]);
        let mut d = Domain::<D2<f64>>::new(V2::new([0.0, 0.0]), V2::new([1.0, 1.0]))
            .unwrap()
            .with_periodic(0)
            .unwrap()
            .with_periodic(1)
            .unwrap()
            .with_shaped_wall(wall)
            .unwrap()
            .with_wall_particles(0.05)
            .unwrap();
        let start: std::vec::Vec<(V2, f64)> = {
            let mut v = std::vec::Vec::new();
            for_each_wall_particle(&d, 0.1, |x, code, _| {
                assert_eq!(code, WALL_PARTICLE | BODY_FLAG);
                let (dist, _) = square.distance([x[0], x[1], 0.0], 2);
                v.push((x, dist));
            });
            v
        };
        // Two layers around the square's 10 x 10 lattice points, at depths
        // 0.025 and 0.075, less the four outer corner points (0.075 sqrt 2
        // from the vertex: deeper than 0.1).
        assert_eq!(start.len(), 14 * 14 - 10 * 10 - 4);
        d.set_wall_time(0.3);
        let w = *d.shaped_wall(0).unwrap();
        let mut x = [V2::default(); 400];
        let mut ghosts = [Ghost::default(); 400];
        x[0] = V2::new([0.5, 0.5]);
        let n = generate(&d, 0.1, &mut x, 1, &mut ghosts).unwrap();
        assert_eq!(n, start.len());
        for (k, g) in ghosts[..n].iter().enumerate() {
            let xw = x[1 + k];
            // Each particle is where its starting point has turned to, so
            // it keeps its depth behind the turned wall.
            let (dist, _) = w.shape.distance([xw[0], xw[1], 0.0], 2);
            assert!(
                (dist - start[k].1).abs() < 1e-12,
                "{k}: {dist} {}",
                start[k].1
            );
            let r0 = (start[k].0 - V2::new([0.5, 0.5])).norm2();
            let r1 = (xw - V2::new([0.5, 0.5])).norm2();
            assert!((r0 - r1).abs() < 1e-12);
            // And the index it carries places it there again.
            assert_eq!(body_wall_particle(&d, g.mirrors, g.source), Some(xw));
            let a = body_acceleration(&d, xw, g.mirrors).unwrap();
            assert!((a[0] + (xw[0] - 0.5)).abs() < 1e-15);
        }
        // The planar walls' and the resting walls' particles have no body.
        assert_eq!(body_wall_particle(&d, WALL_PARTICLE | 1, 0), None);
        assert_eq!(body_acceleration(&d, V2::new([0.0, 0.0]), 0), None);
    }

    #[test]
    #[cfg(all(feature = "shaped-walls", feature = "wall-particles"))]
    fn wall_particles_fill_the_solid_of_a_shaped_wall_within_the_radius() {
        use crate::shape::{Shape, ShapedWall};
        // A unit box (periodic both ways) with an L-shaped solid in its
        // lower left: a polygon obstacle with a concave corner at (0.5, 0.5)
        // seen from the fluid, and a circle obstacle touching nothing.
        let l = Shape::polygon(
            &[
                [0.1, 0.1],
                [0.7, 0.1],
                [0.7, 0.3],
                [0.3, 0.3],
                [0.3, 0.7],
                [0.1, 0.7],
            ],
            false,
        )
        .unwrap();
        let d = Domain::<D2<f64>>::new(V2::new([0.0, 0.0]), V2::new([1.0, 1.0]))
            .unwrap()
            .with_periodic(0)
            .unwrap()
            .with_periodic(1)
            .unwrap()
            .with_shaped_wall(ShapedWall::new(l))
            .unwrap()
            .with_wall_particles(0.05)
            .unwrap()
            .with_shaped_wall_front(0.5)
            .unwrap();
        let mut count = 0;
        let mut volume = 0.0;
        for_each_wall_particle(&d, 0.125, |x, code, v| {
            // The lattice's points lie 0.025 off the edges: those in front
            // are the fluid's.
            let (dist, _) = l.distance([x[0], x[1], 0.0], 2);
            assert!(dist < 0.0 && dist > -0.125, "{x:?} {dist}");
            assert_eq!(code, WALL_PARTICLE | BODY_FLAG);
            assert!((v - 0.0025).abs() < 1e-15);
            volume += v;
            count += 1;
        });
        // The L is 0.2 thick: every lattice point inside it is within
        // 0.1 of its edges, so all of it: 0.6 x 0.2 + 0.2 x 0.4 = 0.2.
        assert_eq!(count, 80);
        assert!((volume - 0.2).abs() < 1e-12);
        // A deeper radius changes nothing; a shallow one keeps the rim.
        assert_eq!(wall_particle_count(&d, 0.3), 80);
        // Within 0.05: the L less its core of points 0.075 or more from
        // every edge, two arms of 10 x 2 points sharing 2 x 2 (36).
        assert_eq!(wall_particle_count(&d, 0.05), 80 - 36);
        // Fluid particles get no mirror images of the wall, only the wall
        // particles near them; the lattice's points in the fluid never.
        let mut x = [V2::default(); 100];
        x[0] = V2::new([0.5, 0.5]);
        x[1] = V2::new([0.35, 0.35]);
        let mut ghosts = [Ghost::default(); 100];
        let n = generate(&d, 0.125, &mut x, 2, &mut ghosts).unwrap();
        assert!(ghosts[..n]
            .iter()
            .all(|g| g.mirrors == WALL_PARTICLE | BODY_FLAG));
        // The concave corner at (0.3, 0.3) is filled on both sides.
        let has = |p: [f64; 2]| {
            x[2..2 + n]
                .iter()
                .any(|w| (w[0] - p[0]).abs() < 1e-12 && (w[1] - p[1]).abs() < 1e-12)
        };
        assert!(has([0.275, 0.275]) && has([0.325, 0.275]) && has([0.275, 0.325]));
    }

    #[test]
    fn too_little_reserved_capacity_is_an_error_with_the_count_needed() {
        let d = box_domain();
        let mut x = [V2::new([0.05, 0.05]), V2::new([0.5, 0.02]), V2::default()];
        let mut ghosts = [Ghost::default(); 3];
        assert_eq!(
            generate(&d, 0.1, &mut x, 2, &mut ghosts),
            Err(Error::CapacityExceeded {
                buffer: "ghosts",
                needed: 4,
                available: 1
            })
        );
    }

    #[test]
    #[cfg(feature = "shaped-walls")]
    fn image_offsets_are_the_depth_along_the_wall_normals() {
        let d = box_domain();
        let x = V2::new([0.1, 0.3]);
        // Lower y wall: the ghost lies 2 y below; upper: 2 (1 - y) above.
        assert_eq!(image_offset(&d, x, 0b0100), V2::new([0.0, -0.6]));
        assert_eq!(image_offset(&d, x, 0b1000)[1], 2.0 * (1.0 - 0.3));
        // A corner image: both normal offsets.
        assert_eq!(image_offset(&d, x, 0b0101), V2::new([-0.2, -0.6]));
        // A curved wall: a circle of radius 0.4 about the box's centre with
        // the fluid inside; a point 0.1 from it on the line through the
        // centre at 45 degrees has its image 0.2 further out on that line.
        let wall = crate::shape::ShapedWall::new(crate::shape::Shape::Ball {
            center: [0.5, 0.5, 0.0],
            radius: 0.4,
            fluid_inside: true,
        });
        let d = d.with_shaped_wall(wall).unwrap();
        let r = 0.3 / 2f64.sqrt();
        let off = image_offset(&d, V2::new([0.5 + r, 0.5 + r]), BODY_FLAG);
        let expect = 0.2 / 2f64.sqrt();
        assert!((off[0] - expect).abs() < 1e-12 && (off[1] - expect).abs() < 1e-12);
    }
}
