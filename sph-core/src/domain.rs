//! The simulation box: origin, extent, periodic axes and planar walls.
//!
//! Positions are stored relative to the box's lower corner, the scene origin,
//! held in `f64`. An `f32` scene placed far from the coordinate origin keeps
//! its full resolution because its particles never see the large offset.
//!
//! Each axis is either periodic, or bounded by two planar sides at local
//! coordinates `0` and `extent`. A bounded side is a [`Wall`] (mirrored ghost
//! particles, see [`crate::boundary`]) or open (no ghosts; a particle that
//! crosses it is an error).

use crate::error::{Error, Result};
use crate::math::Math;
use crate::real::Real;
use crate::shape::{widen, ShapedWall, MAX_SHAPED_WALLS};
use crate::space::{Space, VectorOps};

/// How many periods from the box a coordinate along a periodic axis may
/// lie: wrapping a coordinate `k` periods out loses `log2 k` bits of it,
/// so one much further out (1e300 on a box of 1) is a caller's error, not
/// a position to wrap silently.
pub const MAX_PERIODS: f64 = 1024.0;

/// Which side of an axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// The side at local coordinate 0.
    Lower,
    /// The side at local coordinate `extent`.
    Upper,
}

impl Side {
    fn index(self) -> usize {
        match self {
            Side::Lower => 0,
            Side::Upper => 1,
        }
    }
}

/// Boundary condition a wall imposes on the velocity of its ghosts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WallKind {
    /// Ghost velocity `2 V_w - v`: no penetration and no slip relative to the wall.
    NoSlip,
    /// Normal component reflected about the wall's, tangential component copied.
    FreeSlip,
}

/// How a wall places its ghosts (see [`crate::boundary`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Reflection {
    /// Mirror image across the wall plane: the ghost keeps its source's
    /// tangential coordinates. Works for every wall.
    #[default]
    Mirror,
    /// Point reflection through an anchor point on the wall plane that moves
    /// with the wall: the tangential coordinates are reflected too. For
    /// no-slip walls whose tangential axes are all periodic (channels). The
    /// ghosts then move with the velocity the no-slip rule gives them, so a
    /// sheared lattice continues through the wall unchanged; with mirrored
    /// ghosts the rows near the wall lose their point symmetry as they slide
    /// (`docs/physics.md` 10) and a steady linear profile is no longer an
    /// exact discrete solution.
    Point,
}

/// A planar wall: its kind and its velocity (tangential motion drives the flow;
/// the normal component must be zero since the wall does not move in the model).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wall<S: Space> {
    /// Velocity boundary condition.
    pub kind: WallKind,
    /// Wall velocity.
    pub velocity: S::Vector,
    /// Ghost placement.
    pub reflection: Reflection,
    /// Curvature of the tangential velocity at the wall, `d^2 v_t / d n^2`
    /// (zero: the ghost rule continues the profile linearly). The ghost of a
    /// particle at distance `d` gets `2 V_w - v + curvature d^2`, the odd
    /// continuation of `v_t = a n + (curvature / 2) n^2` through the wall:
    /// exact for quadratic profiles, where the plain rule leaves a slip of
    /// order `curvature d^2`. At a wall at rest without a tangential pressure
    /// gradient the momentum equation gives `curvature = -g_t / nu` (body
    /// force `g`), at every time.
    pub curvature: S::Vector,
}

impl<S: Space> Wall<S> {
    /// A wall at rest with no-slip.
    pub fn no_slip() -> Self {
        Self {
            kind: WallKind::NoSlip,
            velocity: S::Vector::zero(),
            reflection: Reflection::Mirror,
            curvature: S::Vector::zero(),
        }
    }

    /// A no-slip wall sliding with `velocity`.
    pub fn moving(velocity: S::Vector) -> Self {
        Self {
            kind: WallKind::NoSlip,
            velocity,
            reflection: Reflection::Mirror,
            curvature: S::Vector::zero(),
        }
    }

    /// A wall at rest with free slip.
    pub fn free_slip() -> Self {
        Self {
            kind: WallKind::FreeSlip,
            velocity: S::Vector::zero(),
            reflection: Reflection::Mirror,
            curvature: S::Vector::zero(),
        }
    }

    /// The same wall with a velocity curvature for its ghost rule (see the field).
    pub fn with_curvature(mut self, curvature: S::Vector) -> Self {
        self.curvature = curvature;
        self
    }

    /// The same wall with point-reflected ghosts ([`Reflection::Point`]).
    pub fn point_reflected(mut self) -> Self {
        self.reflection = Reflection::Point;
        self
    }
}

/// The box a scene lives in.
///
/// ```
/// use sph_core::prelude::*;
///
/// // A channel: periodic along x, a wall at rest below, a lid sliding at
/// // 1 m/s above; positions are stored relative to the lower corner.
/// let domain = Domain::<D2<f64>>::new(Vector::new([10.0, 0.0]), Vector::new([2.0, 1.0]))?
///     .with_periodic(0)?
///     .with_wall(1, Side::Lower, Wall::no_slip())?
///     .with_wall(1, Side::Upper, Wall::moving(Vector::new([1.0, 0.0])))?;
/// let local = domain.to_local(Vector::new([10.5, 0.25]));
/// assert_eq!(local, Vector::new([0.5, 0.25]));
/// // Along x a position wraps; across y it must stay inside.
/// assert_eq!(domain.wrap::<Libm>(Vector::new([2.5, 0.25])), Vector::new([0.5, 0.25]));
/// assert!(domain.outside(Vector::new([0.5, 1.5])).is_some());
/// # Ok::<(), Error>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Domain<S: Space> {
    origin: S::Global,
    extent: S::Vector,
    periodic: [bool; 3],
    walls: [[Option<Wall<S>>; 2]; 3],
    /// Anchor of each point-reflecting wall: `V_w t` wrapped into the box.
    anchors: [[S::Vector; 2]; 3],
    /// Walls of any shape ([`crate::shape`]), the first `n_shaped` used.
    shaped: [Option<ShapedWall>; MAX_SHAPED_WALLS],
    n_shaped: usize,
    /// Body force per unit mass the ghosts' pressure balances, if any.
    gravity: Option<S::Vector>,
    /// Spacing of the fixed wall particles that replace mirrored ghosts at
    /// the planar walls, if chosen ([`Self::with_wall_particles`]).
    wall_spacing: Option<S::Real>,
    /// How far in front of a shaped wall, in spacings, its wall particles
    /// reach ([`Self::with_shaped_wall_front`]).
    wall_front: f64,
}

fn axis_error(axis: usize) -> Error {
    Error::InvalidParameter {
        name: "axis",
        value: axis as f64,
        rule: "axis must be below the dimension of the space",
    }
}

impl<S: Space> Domain<S> {
    /// A box with lower corner `origin` (absolute, `f64`) and size `extent`;
    /// every side starts open.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if an extent is not positive and finite or
    /// the origin is not finite.
    pub fn new(origin: S::Global, extent: S::Vector) -> Result<Self> {
        for a in 0..S::DIM {
            if !origin[a].is_finite() {
                return Err(Error::InvalidParameter {
                    name: "origin",
                    value: origin[a],
                    rule: "the domain origin must be finite",
                });
            }
            let e = extent[a];
            if !(e.is_finite() && e > S::Real::ZERO) {
                return Err(Error::InvalidParameter {
                    name: "extent",
                    value: e.to_f64(),
                    rule: "every domain extent must be positive and finite",
                });
            }
        }
        Ok(Self {
            origin,
            extent,
            periodic: [false; 3],
            walls: [[None; 2]; 3],
            anchors: [[S::Vector::zero(); 2]; 3],
            shaped: [None; MAX_SHAPED_WALLS],
            n_shaped: 0,
            gravity: None,
            wall_spacing: None,
            wall_front: 0.0,
        })
    }

    /// Makes `axis` periodic.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if the axis is out of range or already has a wall.
    pub fn with_periodic(mut self, axis: usize) -> Result<Self> {
        if axis >= S::DIM {
            return Err(axis_error(axis));
        }
        if self.walls[axis].iter().any(Option::is_some) {
            return Err(Error::InvalidParameter {
                name: "axis",
                value: axis as f64,
                rule: "an axis with a wall cannot also be periodic",
            });
        }
        self.periodic[axis] = true;
        Ok(self)
    }

    /// Puts `wall` on one side of `axis`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if the axis is out of range or periodic, or
    /// the wall velocity has a normal component or is not finite.
    pub fn with_wall(mut self, axis: usize, side: Side, wall: Wall<S>) -> Result<Self> {
        if axis >= S::DIM {
            return Err(axis_error(axis));
        }
        if self.periodic[axis] {
            return Err(Error::InvalidParameter {
                name: "axis",
                value: axis as f64,
                rule: "a periodic axis cannot have walls",
            });
        }
        if !wall.curvature.is_finite() || wall.curvature[axis] != S::Real::ZERO {
            return Err(Error::InvalidParameter {
                name: "wall.curvature",
                value: wall.curvature[axis].to_f64(),
                rule: "the velocity curvature must be finite and tangential",
            });
        }
        if !wall.velocity.is_finite() {
            return Err(Error::InvalidParameter {
                name: "wall.velocity",
                value: f64::NAN,
                rule: "wall velocity must be finite",
            });
        }
        if wall.velocity[axis] != S::Real::ZERO {
            return Err(Error::InvalidParameter {
                name: "wall.velocity",
                value: wall.velocity[axis].to_f64(),
                rule: "a wall may only move tangentially: its normal velocity must be zero",
            });
        }
        if wall.reflection == Reflection::Point && wall.kind != WallKind::NoSlip {
            return Err(Error::InvalidParameter {
                name: "wall.reflection",
                value: axis as f64,
                rule: "point-reflected ghosts need a no-slip wall",
            });
        }
        self.walls[axis][side.index()] = Some(wall);
        Ok(self)
    }

    /// Adds a wall of any shape (in local coordinates: relative to the
    /// box's lower corner; see [`crate::shape`]).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for an invalid description
    /// ([`ShapedWall::validate`]); [`Error::CapacityExceeded`] beyond
    /// [`MAX_SHAPED_WALLS`].
    pub fn with_shaped_wall(mut self, wall: ShapedWall) -> Result<Self> {
        if !cfg!(feature = "shaped-walls") {
            return Err(Error::InvalidParameter {
                name: "shaped_wall",
                value: f64::NAN,
                rule: "walls of any shape need sph-core's `shaped-walls` feature",
            });
        }
        wall.validate(S::DIM)?;
        if self.n_shaped >= MAX_SHAPED_WALLS {
            return Err(Error::CapacityExceeded {
                buffer: "shaped walls",
                needed: self.n_shaped + 1,
                available: MAX_SHAPED_WALLS,
            });
        }
        self.shaped[self.n_shaped] = Some(wall);
        self.n_shaped += 1;
        Ok(self)
    }

    /// Makes the ghosts' pressure balance a body force `g` per unit mass
    /// across every wall: a ghost at `r_g` imaging the fluid particle at
    /// `r_f` takes `p_g = p_f + rho_f g . (r_g - r_f)_n` (the offset's part
    /// along the wall normal, so that a force along a wall, such as a
    /// channel's driving force, adds nothing) and the density the equation
    /// of state gives for `p_g` (`docs/physics.md` 5.1). A tank at rest then
    /// stays at rest; without it the mirrored pressure has zero normal
    /// gradient and the wall supports no weight. Scenes without a body force
    /// leave it unset and the ghosts copy their source's pressure.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if a component is not finite.
    pub fn with_wall_gravity(mut self, g: S::Vector) -> Result<Self> {
        if !g.is_finite() {
            return Err(Error::InvalidParameter {
                name: "wall_gravity",
                value: f64::NAN,
                rule: "every component of the gravity the walls balance must be finite",
            });
        }
        self.gravity = Some(g);
        Ok(self)
    }

    /// The body force the ghosts' pressure balances
    /// ([`Self::with_wall_gravity`]).
    #[inline]
    pub fn wall_gravity(&self) -> Option<S::Vector> {
        self.gravity
    }

    /// Replaces the mirrored ghosts of every planar wall by fixed wall
    /// particles on a lattice of the given spacing behind the walls (the
    /// generalised wall boundary of Adami, Hu & Adams 2012;
    /// [`crate::boundary`]): layers `spacing / 2, 3 spacing / 2, ...` deep
    /// out to the support radius, corners filled. Along a wall the lattice
    /// spacing is the box's extent divided by the nearest whole number of
    /// spacings, so it closes on itself. Give the fluid's particle spacing.
    /// Shaped walls get wall particles too, in place of their mirror
    /// images: the box lattice's points behind them, as deep as the
    /// support ([`crate::boundary::for_each_wall_particle`]).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if the spacing is not positive and finite.
    pub fn with_wall_particles(mut self, spacing: S::Real) -> Result<Self> {
        if !cfg!(feature = "wall-particles") {
            return Err(Error::InvalidParameter {
                name: "wall_spacing",
                value: spacing.to_f64(),
                rule: "wall particles need sph-core's `wall-particles` feature",
            });
        }
        if !(spacing.is_finite() && spacing > S::Real::ZERO) {
            return Err(Error::InvalidParameter {
                name: "wall_spacing",
                value: spacing.to_f64(),
                rule: "the wall particles' spacing must be positive and finite",
            });
        }
        self.wall_spacing = Some(spacing);
        Ok(self)
    }

    /// Sets how far in front of a shaped wall, as a fraction of the
    /// spacing, its wall particles reach: the box lattice's points less
    /// than `fraction` spacings in front of the surface (or behind it)
    /// become wall particles. The default, 0, fills the solid and
    /// completes a fluid seeded on the box lattice at every point in front
    /// of the walls (as sph-std's scenes do), or one seeded otherwise (on
    /// rings, say); one half completes a box-lattice fluid kept at least
    /// half a spacing off the walls.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] unless `0 <= fraction <= 1`.
    pub fn with_shaped_wall_front(mut self, fraction: f64) -> Result<Self> {
        if !(0.0..=1.0).contains(&fraction) {
            return Err(Error::InvalidParameter {
                name: "wall_front",
                value: fraction,
                rule: "the wall particles' reach in front of a shaped wall is 0 to 1 spacings",
            });
        }
        self.wall_front = fraction;
        Ok(self)
    }

    /// How far in front of a shaped wall its wall particles reach, in
    /// spacings ([`Self::with_shaped_wall_front`]).
    #[inline]
    pub fn shaped_wall_front(&self) -> f64 {
        self.wall_front
    }

    /// The spacing of the wall particles, if the planar walls use them
    /// ([`Self::with_wall_particles`]).
    #[inline]
    pub fn wall_particles(&self) -> Option<S::Real> {
        // A constant without the feature, so that the optimiser drops
        // every wall-particle branch from a firmware that cannot use them.
        if cfg!(feature = "wall-particles") {
            self.wall_spacing
        } else {
            None
        }
    }

    /// Number of shaped walls (always 0 without the `shaped-walls`
    /// feature).
    #[inline]
    pub fn shaped_count(&self) -> usize {
        if cfg!(feature = "shaped-walls") {
            self.n_shaped
        } else {
            0
        }
    }

    /// The shaped walls in use, in order.
    #[inline]
    fn shaped_in_use(&self) -> &[Option<ShapedWall>] {
        &self.shaped[..self.shaped_count()]
    }

    /// The shaped wall with index `i`, if there is one.
    #[inline]
    pub fn shaped_wall(&self, i: usize) -> Option<&ShapedWall> {
        self.shaped_in_use().get(i).and_then(Option::as_ref)
    }

    /// How far a fluid particle may lie behind a shaped wall's surface
    /// before it counts as crossed: none with mirrored ghosts (a particle
    /// behind the surface has no image); half a spacing with wall particles
    /// (the fluid and the wall particles share the lattice split at the
    /// surface, so a particle placed on the surface may step a hair behind
    /// it; beyond half a spacing it has passed into the wall particles'
    /// cells).
    #[inline]
    pub fn wall_tolerance(&self) -> f64 {
        self.wall_particles().map_or(0.0, |s| 0.5 * s.to_f64())
    }

    /// The first shaped wall that `x` lies behind by more than
    /// [`Self::wall_tolerance`], with its signed distance.
    pub fn behind_wall(&self, x: S::Vector) -> Option<(usize, f64)> {
        if self.shaped_count() == 0 {
            return None;
        }
        let p = widen::<S>(x);
        let tolerance = self.wall_tolerance();
        for (i, w) in self.shaped_in_use().iter().enumerate() {
            if let Some(w) = w {
                let (d, _) = w.shape.distance(p, S::DIM);
                if !(d >= -tolerance) {
                    return Some((i, d));
                }
            }
        }
        None
    }

    /// Checks what can only be checked once the box is complete: a wall with
    /// [`Reflection::Point`] needs every other axis periodic.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming the wall's axis.
    pub fn validate(&self) -> Result<()> {
        let curved = self
            .shaped_in_use()
            .iter()
            .flatten()
            .any(|w| w.curvature != [0.0; 3]);
        if self.wall_particles().is_some() && curved {
            return Err(Error::InvalidParameter {
                name: "wall.curvature",
                value: f64::NAN,
                rule: "wall particles take their velocity from the fluid near them: \
                       a velocity curvature is a mirror-ghost rule",
            });
        }
        for a in 0..S::DIM {
            for w in self.walls[a].iter().flatten() {
                if self.wall_particles().is_some()
                    && (w.reflection == Reflection::Point || w.curvature != S::Vector::zero())
                {
                    return Err(Error::InvalidParameter {
                        name: "wall.reflection",
                        value: a as f64,
                        rule: "wall particles take their velocity from the fluid near them: \
                               point reflection and a velocity curvature are mirror-ghost rules",
                    });
                }
                if w.reflection == Reflection::Point
                    && (0..S::DIM).any(|b| b != a && !self.periodic[b])
                {
                    return Err(Error::InvalidParameter {
                        name: "wall.reflection",
                        value: a as f64,
                        rule:
                            "point-reflected ghosts need every axis along the wall to be periodic",
                    });
                }
            }
        }
        Ok(())
    }

    /// The fastest a wall moves as a rigid body ([`ShapedWall::moving`])
    /// anywhere near the box: its translation speed plus its turn rate
    /// times the distance from its pivot to the far side of the box. Zero
    /// when no wall moves as a body.
    pub fn body_speed(&self) -> f64 {
        let mut mid = [0.0; 3];
        let mut diagonal = 0.0;
        for (a, m) in mid.iter_mut().enumerate().take(S::DIM) {
            let l = self.extent[a].to_f64();
            *m = 0.5 * l;
            diagonal += l * l;
        }
        let diagonal = crate::math::f64s::sqrt(diagonal);
        let mut fastest = 0.0f64;
        for w in self.shaped_in_use().iter().flatten() {
            let mut r = 0.0;
            for (a, m) in mid.iter().enumerate() {
                r += (w.center[a] - m) * (w.center[a] - m);
            }
            fastest = fastest.max(w.body_speed(crate::math::f64s::sqrt(r) + diagonal));
        }
        fastest
    }

    /// Moves the anchors of point-reflecting walls to where the walls are at
    /// time `t` (seconds since the start): `V_w t`, wrapped into the box;
    /// and puts the shaped walls that move as bodies where they are
    /// ([`ShapedWall::set_time`]: not wrapped; a body's shape is not
    /// periodic, so it must stay inside the box).
    pub fn set_wall_time(&mut self, t: f64) {
        let n = self.shaped_count();
        for w in self.shaped[..n].iter_mut().flatten() {
            w.set_time(t);
        }
        for a in 0..S::DIM {
            for s in 0..2 {
                let Some(w) = self.walls[a][s] else { continue };
                if w.reflection != Reflection::Point {
                    continue;
                }
                let mut anchor = S::Vector::zero();
                for b in 0..S::DIM {
                    if b != a && self.periodic[b] {
                        let l = self.extent[b].to_f64();
                        let c = w.velocity[b].to_f64() * t;
                        let c = c - l * crate::math::f64s::floor(c / l);
                        let c = S::Real::from_f64(c);
                        anchor[b] = if c >= self.extent[b] || c < S::Real::ZERO {
                            S::Real::ZERO
                        } else {
                            c
                        };
                    }
                }
                self.anchors[a][s] = anchor;
            }
        }
    }

    /// The anchor of the wall on `side` of `axis` (local coordinates along
    /// the wall; zero for mirroring walls).
    pub fn anchor(&self, axis: usize, side: Side) -> S::Vector {
        if axis < S::DIM {
            self.anchors[axis][side.index()]
        } else {
            S::Vector::zero()
        }
    }

    /// Absolute coordinates of the lower corner.
    pub fn origin(&self) -> S::Global {
        self.origin
    }

    /// Size of the box.
    pub fn extent(&self) -> S::Vector {
        self.extent
    }

    /// Whether `axis` is periodic.
    pub fn is_periodic(&self, axis: usize) -> bool {
        axis < S::DIM && self.periodic[axis]
    }

    /// The wall on one side of an axis, if any.
    pub fn wall(&self, axis: usize, side: Side) -> Option<&Wall<S>> {
        if axis < S::DIM {
            self.walls[axis][side.index()].as_ref()
        } else {
            None
        }
    }

    /// True if any side has a wall.
    pub fn has_walls(&self) -> bool {
        self.walls[..S::DIM].iter().flatten().any(Option::is_some)
    }

    /// Converts absolute coordinates to local ones (relative to the origin).
    pub fn to_local(&self, p: S::Global) -> S::Vector {
        S::narrow(p - self.origin)
    }

    /// Converts local coordinates to absolute ones.
    pub fn to_global(&self, x: S::Vector) -> S::Global {
        S::widen(x) + self.origin
    }

    /// Maps `x` into `[0, extent)` along every periodic axis.
    #[inline]
    pub fn wrap<M: Math<S::Real>>(&self, mut x: S::Vector) -> S::Vector {
        for a in 0..S::DIM {
            if self.periodic[a] {
                let l = self.extent[a];
                let mut c = x[a];
                if c < S::Real::ZERO || c >= l {
                    c -= l * M::floor(c / l);
                    // Rounding can land exactly on `l`, which is the same point as 0.
                    if c >= l || c < S::Real::ZERO {
                        c = S::Real::ZERO;
                    }
                    x[a] = c;
                }
            }
        }
        x
    }

    /// The first axis along which `x` lies outside `[0, extent]` on a
    /// non-periodic axis, more than [`MAX_PERIODS`] periods from the box on
    /// a periodic one, or is not finite, with its coordinate.
    #[inline]
    pub fn outside(&self, x: S::Vector) -> Option<(usize, S::Real)> {
        for a in 0..S::DIM {
            let c = x[a];
            let bad = if self.periodic[a] {
                !(c.is_finite() && c.abs() <= self.extent[a] * S::Real::from_f64(MAX_PERIODS))
            } else {
                !(c >= S::Real::ZERO && c <= self.extent[a])
            };
            if bad {
                return Some((a, c));
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Libm;
    use crate::space::{Vector, D2};

    fn strip() -> Domain<D2<f64>> {
        Domain::new(Vector::new([10.0, -1.0]), Vector::new([1.0, 2.0]))
            .unwrap()
            .with_periodic(0)
            .unwrap()
            .with_wall(1, Side::Lower, Wall::no_slip())
            .unwrap()
            .with_wall(1, Side::Upper, Wall::moving(Vector::new([0.5, 0.0])))
            .unwrap()
    }

    #[test]
    fn wraps_periodic_axes_only() {
        let d = strip();
        let x = d.wrap::<Libm>(Vector::new([-0.25, 0.5]));
        assert_eq!(x, Vector::new([0.75, 0.5]));
        let x = d.wrap::<Libm>(Vector::new([2.5, 0.5]));
        assert_eq!(x, Vector::new([0.5, 0.5]));
        // A tiny negative coordinate rounds onto the period and is mapped to 0.
        let x = d.wrap::<Libm>(Vector::new([-1e-20, 0.5]));
        assert_eq!(x[0], 0.0);
        assert_eq!(d.outside(Vector::new([0.5, 2.5])), Some((1, 2.5)));
        assert_eq!(d.outside(Vector::new([0.5, 2.0])), None);
    }

    #[test]
    fn local_and_global_coordinates() {
        let d = strip();
        let p = Vector::new([10.25, 0.0]);
        assert_eq!(d.to_local(p), Vector::new([0.25, 1.0]));
        assert_eq!(d.to_global(d.to_local(p)), p);
    }

    #[test]
    fn invalid_domains_are_errors() {
        assert!(Domain::<D2<f64>>::new(Vector::new([0.0, 0.0]), Vector::new([1.0, 0.0])).is_err());
        assert!(
            Domain::<D2<f64>>::new(Vector::new([f64::NAN, 0.0]), Vector::new([1.0, 1.0])).is_err()
        );
        let d = Domain::<D2<f64>>::new(Vector::new([0.0, 0.0]), Vector::new([1.0, 1.0])).unwrap();
        assert!(d.with_periodic(2).is_err());
        assert!(d
            .with_wall(0, Side::Lower, Wall::moving(Vector::new([1.0, 0.0])))
            .is_err());
        assert!(strip().with_wall(0, Side::Lower, Wall::no_slip()).is_err());
        assert!(strip().with_periodic(1).is_err());
    }

    #[test]
    fn walls_a_build_leaves_out_are_refused_by_name() {
        let ball = ShapedWall::new(crate::shape::Shape::Ball {
            center: [0.5, 1.0, 0.0],
            radius: 0.25,
            fluid_inside: false,
        });
        let shaped = strip().with_shaped_wall(ball);
        let particles = strip().with_wall_particles(0.05);
        if cfg!(feature = "shaped-walls") {
            assert_eq!(shaped.unwrap().shaped_count(), 1);
        } else {
            assert!(matches!(
                shaped,
                Err(Error::InvalidParameter {
                    name: "shaped_wall",
                    ..
                })
            ));
        }
        if cfg!(feature = "wall-particles") {
            assert_eq!(particles.unwrap().wall_particles(), Some(0.05));
        } else {
            assert!(matches!(
                particles,
                Err(Error::InvalidParameter {
                    name: "wall_spacing",
                    ..
                })
            ));
        }
    }
}
