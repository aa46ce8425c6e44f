//! Physics terms, composed at compile time.
//!
//! A [`Term`] contributes to one particle's accumulator through three hooks
//! with no-op defaults: `init` (once per destination), `pair` (once per
//! neighbour) and `viscous` (the linear viscous part alone, used to find the
//! viscous time-step limit). A tuple of terms is a term, so a scene states the
//! physics it needs as a type, e.g. `(PressureGradient, MorrisViscosity<f64>)`,
//! and a term it does not name costs nothing. A tuple is a group: one
//! neighbour pass evaluates all of its members, sharing the pair quantities
//! (`r_ij`, `W`, `grad W`, `v_ij`) computed once per pair.
//!
//! Gather only: a term writes only to its destination's accumulator. Ghosts
//! are sources, never destinations. This is what makes chunked and parallel
//! evaluation exact without atomics.
//!
//! Conventions (`docs/physics.md`): `r_ij = x_i - x_j`, `v_ij = v_i - v_j`,
//! `grad W = F r_ij` with `F = (1/r) dW/dr <= 0`, and `eta2` is the absolute
//! regulariser `eta^2` (a fraction of `h^2`, 0.01 by default).

use crate::error::{Error, Result};
use crate::real::Real;
use crate::space::{Space, VectorOps};

/// Per-particle fields read during a pass (fluid first, then ghosts).
#[derive(Clone, Copy, Debug)]
pub struct Fields<'a, S: Space> {
    /// Positions.
    pub x: &'a [S::Vector],
    /// Velocities the pass sees (the predicted velocity during a step).
    pub v: &'a [S::Vector],
    /// Masses.
    pub m: &'a [S::Real],
    /// Densities.
    pub rho: &'a [S::Real],
    /// Pressures.
    pub p: &'a [S::Real],
    /// Index of the first wall particle: `x[walls..]` are fixed wall
    /// particles (`docs/physics.md` 5.3), the rest fluid and mirrored
    /// ghosts; the length of the fields when there are none.
    pub walls: usize,
}

impl<'a, S: Space> Fields<'a, S> {
    /// The same fields, each cut to the length of the shortest, so that one
    /// index check covers all of them.
    #[inline(always)]
    pub fn uniform(&self) -> Self {
        let n = self
            .x
            .len()
            .min(self.v.len())
            .min(self.m.len())
            .min(self.rho.len())
            .min(self.p.len());
        Self {
            x: &self.x[..n],
            v: &self.v[..n],
            m: &self.m[..n],
            rho: &self.rho[..n],
            p: &self.p[..n],
            walls: self.walls.min(n),
        }
    }
}

/// The destination particle's own values, read once per pass.
#[derive(Clone, Copy, Debug)]
pub struct Dest<S: Space> {
    /// Index.
    pub i: usize,
    /// Velocity.
    pub v: S::Vector,
    /// Mass.
    pub m: S::Real,
    /// Density.
    pub rho: S::Real,
    /// Pressure.
    pub p: S::Real,
}

/// Quantities of one pair, computed once and shared by every term of a group.
#[derive(Clone, Copy, Debug)]
pub struct Pair<S: Space> {
    /// Index of the neighbour (may equal the destination: the self pair).
    pub j: usize,
    /// Separation `x_i - x_j` (to the nearest periodic image).
    pub r_ij: S::Vector,
    /// `|r_ij|^2`.
    pub r2: S::Real,
    /// Kernel value `W_ij` (zero unless the group declares `NEEDS_W`).
    pub w: S::Real,
    /// `F_ij = (1/r) dW/dr` (zero unless the group declares `NEEDS_F`).
    pub f: S::Real,
    /// `grad_i W_ij = F_ij r_ij`.
    pub grad: S::Vector,
    /// `v_i - v_j`.
    pub v_ij: S::Vector,
}

/// What a pass accumulates for one destination.
#[derive(Clone, Copy, Debug, Default)]
pub struct Acc<S: Space> {
    /// Summed density.
    pub rho: S::Real,
    /// Rate of change of density.
    pub drho: S::Real,
    /// Acceleration.
    pub dv: S::Vector,
    /// Shifting velocity (only groups with [`Term::SHIFTS`] write it).
    pub shift: S::Vector,
}

/// The scratch of [`Shifting`]: first-order gradients for its Taylor
/// correction, and what its free-surface limit reads.
#[derive(Clone, Copy, Debug)]
pub struct Gradients<S: Space> {
    /// Velocity gradient, `v[b] = d v / d x_b`.
    pub v: [S::Vector; 3],
    /// Density gradient.
    pub rho: S::Vector,
    /// Divergence of position `-sum_j V_j r_ij . grad_i W_ij`: about the
    /// dimension inside the fluid, less where the support is cut (summed
    /// only with a free-surface limit).
    pub div_r: S::Real,
    /// `sum_j V_j grad_i W_ij`, pointing into the fluid at a free surface
    /// (summed only with a free-surface limit).
    pub inward: S::Vector,
}

impl<S: Space> Default for Gradients<S> {
    fn default() -> Self {
        Self {
            v: [S::Vector::zero(); 3],
            rho: S::Vector::zero(),
            div_r: S::Real::ZERO,
            inward: S::Vector::zero(),
        }
    }
}

/// The accumulators of a local least-squares fit ([`CorrectedMorrisViscosity`]),
/// kept apart from [`Acc`] so that groups without a fit carry none of them.
#[derive(Clone, Copy, Debug)]
pub struct Fit<S: Space> {
    /// Right-hand sides of the fit, one per basis function.
    pub s: [S::Vector; 9],
    /// The fit's normal matrix (upper triangle used).
    pub t: [[S::Real; 9]; 9],
    /// The plain Morris sum, the fallback.
    pub plain: S::Vector,
}

impl<S: Space> Default for Fit<S> {
    fn default() -> Self {
        Self {
            s: [S::Vector::zero(); 9],
            t: [[S::Real::ZERO; 9]; 9],
            plain: S::Vector::zero(),
        }
    }
}

/// Scene constants every term may read.
#[derive(Clone, Copy, Debug)]
pub struct Consts<S: Space> {
    /// Smoothing length.
    pub h: S::Real,
    /// Absolute regulariser `eta^2` (already multiplied by `h^2`).
    pub eta2: S::Real,
    /// Reference sound speed (zero without an equation of state).
    pub c0: S::Real,
}

/// One physics contribution (see the module docs).
pub trait Term<S: Space>: Copy + Send + Sync {
    /// The pair loop must compute `W`.
    const NEEDS_W: bool = false;
    /// The pair loop must compute `F` and `grad W`.
    const NEEDS_F: bool = false;
    /// The term has a viscous (`viscous` hook) part.
    const VISCOUS: bool = false;
    /// The term does nothing at all (only `()`): its pass is skipped.
    const EMPTY: bool = false;
    /// The term writes a shifting velocity (`Acc::shift`), which the solver
    /// adds to the drift (see [`Shifting`]).
    const SHIFTS: bool = false;
    /// Per-destination scratch a term accumulates besides [`Acc`] (`()` for
    /// all but [`CorrectedMorrisViscosity`], whose local fit needs a
    /// [`Fit`]); a group's scratch is the tuple of its members', so a group
    /// without a fit carries nothing.
    type Scratch: Copy + Default;

    /// Checks the term's coefficients (finite, in range); the solver calls
    /// it when it is built and before every step, so a NaN or negative
    /// viscosity is reported as [`Error::InvalidParameter`] naming it
    /// instead of surfacing later as a non-finite position.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming the coefficient.
    fn validate(&self) -> Result<()> {
        Ok(())
    }

    /// Called once per destination before its neighbours.
    #[inline(always)]
    fn init(&self, _k: &Consts<S>, _d: &Dest<S>, _acc: &mut Acc<S>) {}

    /// Called once per neighbour.
    #[inline(always)]
    fn pair(
        &self,
        _k: &Consts<S>,
        _d: &Dest<S>,
        _f: &Fields<'_, S>,
        _p: &Pair<S>,
        _acc: &mut Acc<S>,
    ) {
    }

    /// Called once per neighbour after `pair`, with the term's scratch
    /// (not in the viscous-only pass).
    #[inline(always)]
    fn pair_scratch(
        &self,
        _k: &Consts<S>,
        _d: &Dest<S>,
        _f: &Fields<'_, S>,
        _p: &Pair<S>,
        _scratch: &mut Self::Scratch,
    ) {
    }

    /// Called once per destination after its neighbours, with the term's
    /// scratch (not in the viscous-only pass).
    #[inline(always)]
    fn finish(&self, _k: &Consts<S>, _d: &Dest<S>, _scratch: &Self::Scratch, _acc: &mut Acc<S>) {}

    /// The linear viscous part of `pair` alone (no pressure, no body force).
    #[inline(always)]
    fn viscous(
        &self,
        _k: &Consts<S>,
        _d: &Dest<S>,
        _f: &Fields<'_, S>,
        _p: &Pair<S>,
        _acc: &mut Acc<S>,
    ) {
    }
}

impl<S: Space> Term<S> for () {
    type Scratch = ();
    const EMPTY: bool = true;
}

macro_rules! term_tuple {
    ($($T:ident $i:tt),+) => {
        impl<S: Space, $($T: Term<S>),+> Term<S> for ($($T,)+) {
            const NEEDS_W: bool = $($T::NEEDS_W)||+;
            const NEEDS_F: bool = $($T::NEEDS_F)||+;
            const VISCOUS: bool = $($T::VISCOUS)||+;
            const SHIFTS: bool = $($T::SHIFTS)||+;
            type Scratch = ($($T::Scratch,)+);
            fn validate(&self) -> Result<()> {
                $(self.$i.validate()?;)+
                Ok(())
            }
            #[inline(always)]
            fn init(&self, k: &Consts<S>, d: &Dest<S>, acc: &mut Acc<S>) {
                $(self.$i.init(k, d, acc);)+
            }
            #[inline(always)]
            fn pair(&self, k: &Consts<S>, d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, acc: &mut Acc<S>) {
                $(self.$i.pair(k, d, f, p, acc);)+
            }
            #[inline(always)]
            fn viscous(&self, k: &Consts<S>, d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, acc: &mut Acc<S>) {
                $(self.$i.viscous(k, d, f, p, acc);)+
            }
            #[inline(always)]
            fn pair_scratch(&self, k: &Consts<S>, d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, scratch: &mut Self::Scratch) {
                $(self.$i.pair_scratch(k, d, f, p, &mut scratch.$i);)+
            }
            #[inline(always)]
            fn finish(&self, k: &Consts<S>, d: &Dest<S>, scratch: &Self::Scratch, acc: &mut Acc<S>) {
                $(self.$i.finish(k, d, &scratch.$i, acc);)+
            }
        }
    };
}

term_tuple!(A 0);
term_tuple!(A 0, B 1);
term_tuple!(A 0, B 1, C 2);
term_tuple!(A 0, B 1, C 2, D 3);
term_tuple!(A 0, B 1, C 2, D 3, E 4);
term_tuple!(A 0, B 1, C 2, D 3, E 4, G 5);

fn finite<F: Real>(name: &'static str, value: F) -> Result<()> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            name,
            value: value.to_f64(),
            rule: "a term coefficient must be finite",
        })
    }
}

fn non_negative<F: Real>(name: &'static str, value: F) -> Result<()> {
    if value.is_finite() && value >= F::ZERO {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            name,
            value: value.to_f64(),
            rule: "a term coefficient must be finite and not negative",
        })
    }
}

fn positive<F: Real>(name: &'static str, value: F) -> Result<()> {
    if value.is_finite() && value > F::ZERO {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            name,
            value: value.to_f64(),
            rule: "a term coefficient must be finite and positive",
        })
    }
}

/// Summation density `rho_i = sum_j m_j W_ij` (the sum includes `j = i`).
///
/// ```
/// # use sph_core::prelude::*;
/// # use sph_core::terms::{Acc, Consts, Dest, Fields, Pair};
/// # // Two particles 0.1 apart along x; particle 0 moves towards 1.
/// # let x = [Vector::new([0.0, 0.0]), Vector::new([0.1, 0.0])];
/// # let v = [Vector::new([1.0, 0.0]), Vector::new([0.0, 0.0])];
/// # let (m, rho, p) = ([0.01, 0.01], [1.0, 1.02], [2.0, 1.0]);
/// # let f = Fields::<D2<f64>> { x: &x, v: &v, m: &m, rho: &rho, p: &p, walls: x.len() };
/// # let k = Consts { h: 0.13, eta2: 1e-6, c0: 10.0 };
/// # let dest = |i: usize| Dest { i, v: v[i], m: m[i], rho: rho[i], p: p[i] };
/// # // Kernel value and F = (1/r) dW/dr (negative) of the pair, by hand.
/// # let (w, fr) = (5.0, -300.0);
/// # let pair = |i: usize, j: usize| {
/// #     let r_ij = x[i] - x[j];
/// #     Pair { j, r_ij, r2: r_ij.norm2(), w, f: fr, grad: r_ij * fr, v_ij: v[i] - v[j] }
/// # };
/// # let one = |t: &dyn Fn(&Dest<D2<f64>>, &Pair<D2<f64>>, &mut Acc<D2<f64>>), i: usize, j: usize| {
/// #     let mut acc = Acc::default();
/// #     t(&dest(i), &pair(i, j), &mut acc);
/// #     acc
/// # };
/// let t = SummationDensity;
/// let acc = one(&|d, q, a| Term::<D2<f64>>::pair(&t, &k, d, &f, q, a), 0, 1);
/// assert_eq!(acc.rho, m[1] * w); // m_j W_ij
/// ```
#[derive(Clone, Copy, Debug, Default)]
pub struct SummationDensity;

impl<S: Space> Term<S> for SummationDensity {
    type Scratch = ();
    const NEEDS_W: bool = true;
    #[inline(always)]
    fn pair(&self, _k: &Consts<S>, _d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, acc: &mut Acc<S>) {
        acc.rho += f.m[p.j] * p.w;
    }
}

/// Continuity `d rho_i / dt = sum_j m_j v_ij . grad_i W_ij` (Monaghan 1992, the seed's S1).
///
/// Two particles approaching each other compress: the rate is positive for
/// both, and equal for equal masses.
///
/// ```
/// # use sph_core::prelude::*;
/// # use sph_core::terms::{Acc, Consts, Dest, Fields, Pair};
/// # // Two particles 0.1 apart along x; particle 0 moves towards 1.
/// # let x = [Vector::new([0.0, 0.0]), Vector::new([0.1, 0.0])];
/// # let v = [Vector::new([1.0, 0.0]), Vector::new([0.0, 0.0])];
/// # let (m, rho, p) = ([0.01, 0.01], [1.0, 1.02], [2.0, 1.0]);
/// # let f = Fields::<D2<f64>> { x: &x, v: &v, m: &m, rho: &rho, p: &p, walls: x.len() };
/// # let k = Consts { h: 0.13, eta2: 1e-6, c0: 10.0 };
/// # let dest = |i: usize| Dest { i, v: v[i], m: m[i], rho: rho[i], p: p[i] };
/// # // Kernel value and F = (1/r) dW/dr (negative) of the pair, by hand.
/// # let (w, fr) = (5.0, -300.0);
/// # let pair = |i: usize, j: usize| {
/// #     let r_ij = x[i] - x[j];
/// #     Pair { j, r_ij, r2: r_ij.norm2(), w, f: fr, grad: r_ij * fr, v_ij: v[i] - v[j] }
/// # };
/// # let one = |t: &dyn Fn(&Dest<D2<f64>>, &Pair<D2<f64>>, &mut Acc<D2<f64>>), i: usize, j: usize| {
/// #     let mut acc = Acc::default();
/// #     t(&dest(i), &pair(i, j), &mut acc);
/// #     acc
/// # };
/// let t = Continuity;
/// let a0 = one(&|d, q, a| Term::<D2<f64>>::pair(&t, &k, d, &f, q, a), 0, 1);
/// let a1 = one(&|d, q, a| Term::<D2<f64>>::pair(&t, &k, d, &f, q, a), 1, 0);
/// assert!(a0.drho > 0.0);
/// assert_eq!(a0.drho, a1.drho);
/// ```
#[derive(Clone, Copy, Debug, Default)]
pub struct Continuity;

impl<S: Space> Term<S> for Continuity {
    type Scratch = ();
    const NEEDS_F: bool = true;
    #[inline(always)]
    fn pair(&self, _k: &Consts<S>, _d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, acc: &mut Acc<S>) {
        acc.drho += f.m[p.j] * p.v_ij.dot(p.grad);
    }
}

/// The scratch of [`AnyContinuity::Corrected`]: the moment matrix
/// `M_ab = sum_j V_j (x_j - x_i)_a (grad_i W_ij)_b` and the velocity sums
/// `G_cb = sum_j V_j (v_j - v_i)_c (grad_i W_ij)_b` (rows `a`, `c`).
#[derive(Clone, Copy, Debug)]
pub struct Renormal<S: Space> {
    /// Rows of `M`.
    pub m: [S::Vector; 3],
    /// Rows of `G`.
    pub g: [S::Vector; 3],
    /// The plain continuity sum, the fallback.
    pub plain: S::Real,
}

impl<S: Space> Default for Renormal<S> {
    fn default() -> Self {
        Self {
            m: [S::Vector::zero(); 3],
            g: [S::Vector::zero(); 3],
            plain: S::Real::ZERO,
        }
    }
}

/// Continuity density chosen at run time: the plain sum ([`Continuity`]) or
/// its kernel-gradient-corrected form, one solver type for both.
///
/// `Corrected` takes `d rho_i / dt = -rho_i tr(G M^-1)` (see [`Renormal`];
/// `V_j = m_j / rho_j`): the velocity gradient renormalised so that it is
/// exact for linear velocity fields on any arrangement (the correction of
/// Bonet & Lok 1999 applied to the divergence). The plain sum is not: on a
/// lattice whose rows slide past each other in a shear flow it reports a
/// compression that depends on the rows' slip phase (it is the time
/// derivative of the summation density, which varies with that phase at
/// unchanged volume per particle), and the pressure it builds drives the
/// transverse motion that long channel-flow runs show
/// (docs/validation.md). Mass is then no longer exactly `sum_j m_j W_ij`
/// of the arrangement; a particle whose moment matrix is singular (too few
/// neighbours) falls back to the plain sum.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AnyContinuity {
    /// [`Continuity`].
    #[default]
    Plain,
    /// The kernel-gradient-corrected divergence.
    Corrected,
}

impl<S: Space> Term<S> for AnyContinuity {
    type Scratch = Renormal<S>;
    const NEEDS_F: bool = true;
    #[inline(always)]
    fn pair(&self, k: &Consts<S>, d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, acc: &mut Acc<S>) {
        if *self == Self::Plain {
            <Continuity as Term<S>>::pair(&Continuity, k, d, f, p, acc);
        }
    }

    #[inline(always)]
    fn pair_scratch(
        &self,
        _k: &Consts<S>,
        _d: &Dest<S>,
        f: &Fields<'_, S>,
        p: &Pair<S>,
        acc: &mut Renormal<S>,
    ) {
        if *self == Self::Plain || p.r2 <= S::Real::ZERO {
            return;
        }
        let j = p.j;
        acc.plain += f.m[j] * p.v_ij.dot(p.grad);
        // (x_j - x_i) = -r_ij and (v_j - v_i) = -v_ij.
        let vol = f.m[j] / f.rho[j];
        add_moment::<S>(&mut acc.m, p, vol);
        for a in 0..S::DIM {
            acc.g[a] -= p.grad * (vol * p.v_ij[a]);
        }
    }

    #[inline(always)]
    fn finish(&self, _k: &Consts<S>, d: &Dest<S>, r: &Renormal<S>, acc: &mut Acc<S>) {
        if *self == Self::Plain {
            return;
        }
        // M is symmetric, so tr(G M^-1) = sum_cb G_cb (M^-1)_cb.
        acc.drho += match inverse_symmetric::<S>(&r.m) {
            Some(inv) => {
                let mut div = S::Real::ZERO;
                for (g, row) in r.g.iter().zip(&inv).take(S::DIM) {
                    div += g.dot(*row);
                }
                -d.rho * div
            }
            None => r.plain,
        };
    }
}

/// Adds neighbour `p`'s part of the moment matrix
/// `M_ab = sum_j V_j (x_j - x_i)_a (grad_i W_ij)_b` (rows `a`; `x_j - x_i =
/// -r_ij`), the matrix the corrected divergence and gradient invert.
#[inline(always)]
fn add_moment<S: Space>(m: &mut [S::Vector; 3], p: &Pair<S>, vol: S::Real) {
    for (a, row) in m.iter_mut().enumerate().take(S::DIM) {
        *row -= p.grad * (vol * p.r_ij[a]);
    }
}

/// The inverse of a symmetric `DIM x DIM` matrix given by rows, or `None`
/// when its determinant is below `1e-6` of its diagonal's product (too few
/// or too one-sided neighbours for a renormalised gradient).
fn inverse_symmetric<S: Space>(m: &[S::Vector; 3]) -> Option<[S::Vector; 3]> {
    let e = |a: usize, b: usize| m[a][b];
    let mut inv = [S::Vector::zero(); 3];
    let (det, diag) = match S::DIM {
        1 => (e(0, 0), e(0, 0)),
        2 => (e(0, 0) * e(1, 1) - e(0, 1) * e(1, 0), e(0, 0) * e(1, 1)),
        _ => {
            let c00 = e(1, 1) * e(2, 2) - e(1, 2) * e(2, 1);
            let c01 = e(1, 2) * e(2, 0) - e(1, 0) * e(2, 2);
            let c02 = e(1, 0) * e(2, 1) - e(1, 1) * e(2, 0);
            (
                e(0, 0) * c00 + e(0, 1) * c01 + e(0, 2) * c02,
                e(0, 0) * e(1, 1) * e(2, 2),
            )
        }
    };
    let tiny = S::Real::from_f64(1e-6);
    if !(det.abs() > tiny * diag.abs()) || !det.is_finite() {
        return None;
    }
    let r = S::Real::ONE / det;
    match S::DIM {
        1 => inv[0][0] = r,
        2 => {
            inv[0][0] = e(1, 1) * r;
            inv[1][1] = e(0, 0) * r;
            inv[0][1] = -e(0, 1) * r;
            inv[1][0] = -e(1, 0) * r;
        }
        _ => {
            for (a, row) in inv.iter_mut().enumerate() {
                let (a1, a2) = ((a + 1) % 3, (a + 2) % 3);
                for b in 0..3 {
                    // Cofactor of (b, a), cyclic indices.
                    let (b1, b2) = ((b + 1) % 3, (b + 2) % 3);
                    row[b] = (e(b1, a1) * e(b2, a2) - e(b1, a2) * e(b2, a1)) * r;
                }
            }
        }
    }
    Some(inv)
}

/// Symmetric pressure gradient
/// `dv_i/dt = -sum_j m_j (P_i/rho_i^2 + P_j/rho_j^2) grad_i W_ij`;
/// pairwise antisymmetric, so it conserves linear and angular momentum.
///
/// ```
/// # use sph_core::prelude::*;
/// # use sph_core::terms::{Acc, Consts, Dest, Fields, Pair};
/// # // Two particles 0.1 apart along x; particle 0 moves towards 1.
/// # let x = [Vector::new([0.0, 0.0]), Vector::new([0.1, 0.0])];
/// # let v = [Vector::new([1.0, 0.0]), Vector::new([0.0, 0.0])];
/// # let (m, rho, p) = ([0.01, 0.01], [1.0, 1.02], [2.0, 1.0]);
/// # let f = Fields::<D2<f64>> { x: &x, v: &v, m: &m, rho: &rho, p: &p, walls: x.len() };
/// # let k = Consts { h: 0.13, eta2: 1e-6, c0: 10.0 };
/// # let dest = |i: usize| Dest { i, v: v[i], m: m[i], rho: rho[i], p: p[i] };
/// # // Kernel value and F = (1/r) dW/dr (negative) of the pair, by hand.
/// # let (w, fr) = (5.0, -300.0);
/// # let pair = |i: usize, j: usize| {
/// #     let r_ij = x[i] - x[j];
/// #     Pair { j, r_ij, r2: r_ij.norm2(), w, f: fr, grad: r_ij * fr, v_ij: v[i] - v[j] }
/// # };
/// # let one = |t: &dyn Fn(&Dest<D2<f64>>, &Pair<D2<f64>>, &mut Acc<D2<f64>>), i: usize, j: usize| {
/// #     let mut acc = Acc::default();
/// #     t(&dest(i), &pair(i, j), &mut acc);
/// #     acc
/// # };
/// // The pair's forces m_i a_i and m_j a_j cancel (Newton's third law).
/// let t = PressureGradient;
/// let a0 = one(&|d, q, a| Term::<D2<f64>>::pair(&t, &k, d, &f, q, a), 0, 1);
/// let a1 = one(&|d, q, a| Term::<D2<f64>>::pair(&t, &k, d, &f, q, a), 1, 0);
/// let net = a0.dv * m[0] + a1.dv * m[1];
/// assert!(net.norm2() < 1e-30);
/// // Pressure pushes the pair apart: particle 0 (on the left) goes left.
/// assert!(a0.dv[0] < 0.0);
/// ```
#[derive(Clone, Copy, Debug, Default)]
pub struct PressureGradient;

impl<S: Space> Term<S> for PressureGradient {
    type Scratch = ();
    const NEEDS_F: bool = true;
    #[inline(always)]
    fn pair(&self, _k: &Consts<S>, d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, acc: &mut Acc<S>) {
        let j = p.j;
        let rho_j = f.rho[j];
        let coeff = f.m[j] * (d.p / (d.rho * d.rho) + f.p[j] / (rho_j * rho_j));
        acc.dv -= p.grad * coeff;
    }
}

/// The scratch of [`AnyPressure::Corrected`]: the moment matrix
/// `M_ab = sum_j V_j (x_j - x_i)_a (grad_i W_ij)_b` (rows `a`), the
/// pressure sum `g_b = sum_j V_j (p_j - p_i) (grad_i W_ij)_b`, and the
/// symmetric form's acceleration, the fallback.
#[derive(Clone, Copy, Debug)]
pub struct PressureMoments<S: Space> {
    /// Rows of `M`.
    pub m: [S::Vector; 3],
    /// The pressure sum.
    pub g: S::Vector,
    /// [`PressureGradient`]'s acceleration.
    pub plain: S::Vector,
}

impl<S: Space> Default for PressureMoments<S> {
    fn default() -> Self {
        Self {
            m: [S::Vector::zero(); 3],
            g: S::Vector::zero(),
            plain: S::Vector::zero(),
        }
    }
}

/// The pressure gradient chosen at run time: the symmetric form
/// ([`PressureGradient`], conserving momentum exactly) or its
/// kernel-gradient-corrected difference form, one solver type for both.
///
/// `Corrected` takes `a_i = -M^-1 g / rho_i` (see [`PressureMoments`];
/// `V_j = m_j / rho_j`): exact for linear pressure fields on any
/// arrangement, so a fluid at rest under gravity feels no force from the
/// arrangement of its particles, only from the pressure's departure from
/// the hydrostatic field. The symmetric form is exact only for a constant
/// pressure on a regular lattice: elsewhere it pushes particles with a
/// force proportional to the absolute pressure, which a tank of any depth
/// turns into motion wherever the lattice does not conform to the wall
/// (docs/validation.md, closed-tank). The price: pair forces are no
/// longer antisymmetric, so momentum is conserved only to the truncation
/// error. A particle whose moment matrix is singular falls back to the
/// symmetric form.
///
/// ```
/// use sph_core::prelude::*;
/// use sph_core::terms::{Acc, Consts, Dest, Fields, Pair, PressureMoments};
///
/// // A particle at the origin with eight neighbours on a ring, at random
/// // angles (no symmetry), in the pressure field p = 3 + 2 x - 5 y.
/// let angles = [0.3, 1.1, 1.7, 2.9, 3.4, 4.4, 5.1, 5.9];
/// let mut x = vec![Vector::new([0.0, 0.0])];
/// x.extend(angles.iter().map(|a: &f64| Vector::new([0.1 * a.cos(), 0.1 * a.sin()])));
/// let v = vec![Vector::new([0.0, 0.0]); 9];
/// let p: Vec<f64> = x.iter().map(|x| 3.0 + 2.0 * x[0] - 5.0 * x[1]).collect();
/// let (m, rho) = (vec![0.01; 9], vec![1.0; 9]);
/// let f = Fields::<D2<f64>> { x: &x, v: &v, m: &m, rho: &rho, p: &p, walls: x.len() };
/// let k = Consts { h: 0.08, eta2: 0.0, c0: 10.0 };
/// let d = Dest { i: 0, v: v[0], m: m[0], rho: rho[0], p: p[0] };
/// let (mut acc, mut scratch) = (Acc::default(), PressureMoments::default());
/// let t = AnyPressure::Corrected;
/// for j in 1..9 {
///     let r_ij = x[0] - x[j];
///     // Any radial kernel works: F = (1/r) dW/dr = -1 here.
///     let pair = Pair { j, r_ij, r2: r_ij.norm2(), w: 1.0, f: -1.0, grad: -r_ij, v_ij: v[0] - v[j] };
///     Term::<D2<f64>>::pair(&t, &k, &d, &f, &pair, &mut acc);
///     Term::<D2<f64>>::pair_scratch(&t, &k, &d, &f, &pair, &mut scratch);
/// }
/// Term::<D2<f64>>::finish(&t, &k, &d, &scratch, &mut acc);
/// // -grad p / rho, exactly (to rounding).
/// assert!((acc.dv[0] + 2.0).abs() < 1e-12 && (acc.dv[1] - 5.0).abs() < 1e-12);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AnyPressure {
    /// [`PressureGradient`].
    #[default]
    Symmetric,
    /// The kernel-gradient-corrected difference form.
    Corrected,
}

impl<S: Space> Term<S> for AnyPressure {
    type Scratch = PressureMoments<S>;
    const NEEDS_F: bool = true;
    #[inline(always)]
    fn pair(&self, k: &Consts<S>, d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, acc: &mut Acc<S>) {
        if *self == Self::Symmetric {
            <PressureGradient as Term<S>>::pair(&PressureGradient, k, d, f, p, acc);
        }
    }

    #[inline(always)]
    fn pair_scratch(
        &self,
        _k: &Consts<S>,
        d: &Dest<S>,
        f: &Fields<'_, S>,
        p: &Pair<S>,
        acc: &mut PressureMoments<S>,
    ) {
        if *self == Self::Symmetric || p.r2 <= S::Real::ZERO {
            return;
        }
        let j = p.j;
        let rho_j = f.rho[j];
        let coeff = f.m[j] * (d.p / (d.rho * d.rho) + f.p[j] / (rho_j * rho_j));
        acc.plain -= p.grad * coeff;
        let vol = f.m[j] / rho_j;
        add_moment::<S>(&mut acc.m, p, vol);
        acc.g += p.grad * (vol * (f.p[j] - d.p));
    }

    #[inline(always)]
    fn finish(&self, _k: &Consts<S>, d: &Dest<S>, r: &PressureMoments<S>, acc: &mut Acc<S>) {
        if *self == Self::Symmetric {
            return;
        }
        // M is symmetric, so g = M^T grad p gives grad p = M^-1 g.
        acc.dv += match inverse_symmetric::<S>(&r.m) {
            Some(inv) => {
                let mut grad = S::Vector::zero();
                for a in 0..S::DIM {
                    grad[a] = inv[a].dot(r.g);
                }
                grad * (-S::Real::ONE / d.rho)
            }
            None => r.plain,
        };
    }
}

/// A uniform body force per unit mass (gravity, or a driving pressure gradient).
///
/// ```
/// use sph_core::prelude::*;
/// use sph_core::terms::{Acc, Consts, Dest};
///
/// let g = BodyForce::<D2<f64>> { g: Vector::new([0.0, -9.81]) };
/// let k = Consts { h: 0.1, eta2: 0.0, c0: 30.0 };
/// let d = Dest { i: 0, v: Vector::new([0.0, 0.0]), m: 1.0, rho: 1000.0, p: 0.0 };
/// let mut acc = Acc::default();
/// g.init(&k, &d, &mut acc);
/// assert_eq!(acc.dv, g.g);
/// let bad = BodyForce::<D2<f64>> { g: Vector::new([f64::NAN, 0.0]) };
/// assert!(matches!(bad.validate(), Err(Error::InvalidParameter { name: "g", .. })));
/// ```
#[derive(Clone, Copy, Debug)]
pub struct BodyForce<S: Space> {
    /// Acceleration.
    pub g: S::Vector,
}

impl<S: Space> Term<S> for BodyForce<S> {
    type Scratch = ();
    fn validate(&self) -> Result<()> {
        for a in 0..S::DIM {
            finite("g", self.g[a])?;
        }
        Ok(())
    }
    #[inline(always)]
    fn init(&self, _k: &Consts<S>, _d: &Dest<S>, acc: &mut Acc<S>) {
        acc.dv += self.g;
    }
}

#[inline(always)]
fn regularised<F: Real>(r2: F, eta2: F) -> F {
    // `max` keeps 0/0 out for coincident particles when eta2 is zero.
    (r2 + eta2).max(F::MIN_POSITIVE)
}

/// Laminar viscosity of Morris, Fox & Zhu (1997), `docs/physics.md` 1.6:
/// `dv_i/dt = sum_j m_j 2 mu / (rho_i rho_j) (r_ij . grad W) / (r^2 + eta^2) v_ij`.
///
/// Its continuum limit is exactly `nu lap v`. Conserves linear momentum; not
/// angular momentum (the force is along `v_ij`).
///
/// Terms compose as tuples (a scene pays only for the terms it names), and
/// each checks its own coefficients:
///
/// ```
/// use sph_core::prelude::*;
///
/// let g = BodyForce::<D2<f64>> { g: Vector::new([1e-4, 0.0]) };
/// let forces = (PressureGradient, MorrisViscosity { mu: 1e-3 }, g);
/// assert!(Term::<D2<f64>>::validate(&forces).is_ok());
/// let bad = MorrisViscosity { mu: f64::NAN };
/// assert!(matches!(
///     Term::<D2<f64>>::validate(&bad),
///     Err(Error::InvalidParameter { name: "mu", .. })
/// ));
/// ```
#[derive(Clone, Copy, Debug)]
pub struct MorrisViscosity<F> {
    /// Dynamic viscosity `mu`.
    pub mu: F,
}

impl<S: Space> Term<S> for MorrisViscosity<S::Real> {
    type Scratch = ();
    fn validate(&self) -> Result<()> {
        non_negative("mu", self.mu)
    }
    const NEEDS_F: bool = true;
    const VISCOUS: bool = true;
    #[inline(always)]
    fn pair(&self, k: &Consts<S>, d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, acc: &mut Acc<S>) {
        <Self as Term<S>>::viscous(self, k, d, f, p, acc);
    }
    #[inline(always)]
    fn viscous(
        &self,
        k: &Consts<S>,
        d: &Dest<S>,
        f: &Fields<'_, S>,
        p: &Pair<S>,
        acc: &mut Acc<S>,
    ) {
        let j = p.j;
        // One division per pair.
        let num = f.m[j] * S::Real::TWO * self.mu * p.f * p.r2;
        let coeff = num / (d.rho * f.rho[j] * regularised(p.r2, k.eta2));
        acc.dv += p.v_ij * coeff;
    }
}

/// The seed's viscous slot, corrected (Monaghan-Cleary, `docs/physics.md` 1.4):
/// `Pi_ij = -2 (d + 2) mu / (rho_i rho_j) (v_ij . r_ij) / (r^2 + eta^2)`,
/// `dv_i/dt = -sum_j m_j Pi_ij grad_i W_ij`.
///
/// A central force: conserves linear and angular momentum. On a square
/// lattice it sees a viscosity 5-35 % too small at `h/dx <= 1.3`, and its
/// stability limit is about half of Morris's.
///
/// ```
/// # use sph_core::prelude::*;
/// # use sph_core::terms::{Acc, Consts, Dest, Fields, Pair};
/// # // Two particles 0.1 apart along x; particle 0 moves towards 1.
/// # let x = [Vector::new([0.0, 0.0]), Vector::new([0.1, 0.0])];
/// # let v = [Vector::new([1.0, 0.0]), Vector::new([0.0, 0.0])];
/// # let (m, rho, p) = ([0.01, 0.01], [1.0, 1.02], [2.0, 1.0]);
/// # let f = Fields::<D2<f64>> { x: &x, v: &v, m: &m, rho: &rho, p: &p, walls: x.len() };
/// # let k = Consts { h: 0.13, eta2: 1e-6, c0: 10.0 };
/// # let dest = |i: usize| Dest { i, v: v[i], m: m[i], rho: rho[i], p: p[i] };
/// # // Kernel value and F = (1/r) dW/dr (negative) of the pair, by hand.
/// # let (w, fr) = (5.0, -300.0);
/// # let pair = |i: usize, j: usize| {
/// #     let r_ij = x[i] - x[j];
/// #     Pair { j, r_ij, r2: r_ij.norm2(), w, f: fr, grad: r_ij * fr, v_ij: v[i] - v[j] }
/// # };
/// # let one = |t: &dyn Fn(&Dest<D2<f64>>, &Pair<D2<f64>>, &mut Acc<D2<f64>>), i: usize, j: usize| {
/// #     let mut acc = Acc::default();
/// #     t(&dest(i), &pair(i, j), &mut acc);
/// #     acc
/// # };
/// // A central force: along r_ij, and equal and opposite for the pair.
/// let t = PiViscosity { mu: 1e-3 };
/// let a0 = one(&|d, q, a| Term::<D2<f64>>::pair(&t, &k, d, &f, q, a), 0, 1);
/// let a1 = one(&|d, q, a| Term::<D2<f64>>::pair(&t, &k, d, &f, q, a), 1, 0);
/// assert_eq!(a0.dv[1], 0.0);
/// assert!((a0.dv * m[0] + a1.dv * m[1]).norm2() < 1e-30);
/// // It slows the approach.
/// assert!(a0.dv[0] < 0.0);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct PiViscosity<F> {
    /// Dynamic viscosity `mu`.
    pub mu: F,
}

impl<S: Space> Term<S> for PiViscosity<S::Real> {
    type Scratch = ();
    fn validate(&self) -> Result<()> {
        non_negative("mu", self.mu)
    }
    const NEEDS_F: bool = true;
    const VISCOUS: bool = true;
    #[inline(always)]
    fn pair(&self, k: &Consts<S>, d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, acc: &mut Acc<S>) {
        <Self as Term<S>>::viscous(self, k, d, f, p, acc);
    }
    #[inline(always)]
    fn viscous(
        &self,
        k: &Consts<S>,
        d: &Dest<S>,
        f: &Fields<'_, S>,
        p: &Pair<S>,
        acc: &mut Acc<S>,
    ) {
        let j = p.j;
        let factor = S::Real::TWO * S::Real::from_usize(S::DIM + 2);
        let num = f.m[j] * factor * self.mu * p.v_ij.dot(p.r_ij) * p.f;
        let coeff = num / (d.rho * f.rho[j] * regularised(p.r2, k.eta2));
        acc.dv += p.r_ij * coeff;
    }
}

/// Monaghan's artificial viscosity, for high Reynolds numbers:
/// for approaching pairs (`v_ij . r_ij < 0`),
/// `Pi_ij = (-alpha c0 mu_ij + beta mu_ij^2) / rho_bar`, `mu_ij = h v_ij.r_ij / (r^2 + eta^2)`.
///
/// Equivalent shear viscosity `nu = alpha h c0 / (2 (d + 2))`.
///
/// ```
/// # use sph_core::prelude::*;
/// # use sph_core::terms::{Acc, Consts, Dest, Fields, Pair};
/// # // Two particles 0.1 apart along x; particle 0 moves towards 1.
/// # let x = [Vector::new([0.0, 0.0]), Vector::new([0.1, 0.0])];
/// # let v = [Vector::new([1.0, 0.0]), Vector::new([0.0, 0.0])];
/// # let (m, rho, p) = ([0.01, 0.01], [1.0, 1.02], [2.0, 1.0]);
/// # let f = Fields::<D2<f64>> { x: &x, v: &v, m: &m, rho: &rho, p: &p, walls: x.len() };
/// # let k = Consts { h: 0.13, eta2: 1e-6, c0: 10.0 };
/// # let dest = |i: usize| Dest { i, v: v[i], m: m[i], rho: rho[i], p: p[i] };
/// # // Kernel value and F = (1/r) dW/dr (negative) of the pair, by hand.
/// # let (w, fr) = (5.0, -300.0);
/// # let pair = |i: usize, j: usize| {
/// #     let r_ij = x[i] - x[j];
/// #     Pair { j, r_ij, r2: r_ij.norm2(), w, f: fr, grad: r_ij * fr, v_ij: v[i] - v[j] }
/// # };
/// # let one = |t: &dyn Fn(&Dest<D2<f64>>, &Pair<D2<f64>>, &mut Acc<D2<f64>>), i: usize, j: usize| {
/// #     let mut acc = Acc::default();
/// #     t(&dest(i), &pair(i, j), &mut acc);
/// #     acc
/// # };
/// let t = ArtificialViscosity { alpha: 0.1, beta: 0.0 };
/// // Approaching pair: braked.
/// let a0 = one(&|d, q, a| Term::<D2<f64>>::pair(&t, &k, d, &f, q, a), 0, 1);
/// assert!(a0.dv[0] < 0.0);
/// // The same pair receding feels nothing.
/// let mut q = pair(0, 1);
/// q.v_ij = q.v_ij * -1.0;
/// let mut acc = Acc::default();
/// Term::<D2<f64>>::pair(&t, &k, &dest(0), &f, &q, &mut acc);
/// assert_eq!(acc.dv, Vector::new([0.0, 0.0]));
/// ```
#[derive(Clone, Copy, Debug)]
pub struct ArtificialViscosity<F> {
    /// Linear coefficient (0.01-0.1 for validation runs, up to 1 for shocks).
    pub alpha: F,
    /// Quadratic coefficient (0 for subsonic flows).
    pub beta: F,
}

impl<S: Space> Term<S> for ArtificialViscosity<S::Real> {
    type Scratch = ();
    fn validate(&self) -> Result<()> {
        non_negative("alpha", self.alpha)?;
        non_negative("beta", self.beta)
    }
    const NEEDS_F: bool = true;
    const VISCOUS: bool = true;
    #[inline(always)]
    fn pair(&self, k: &Consts<S>, d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, acc: &mut Acc<S>) {
        let vr = p.v_ij.dot(p.r_ij);
        if vr < S::Real::ZERO {
            let j = p.j;
            let mu_ij = k.h * vr / regularised(p.r2, k.eta2);
            let rho_bar = S::Real::HALF * (d.rho + f.rho[j]);
            let pi = (-self.alpha * k.c0 * mu_ij + self.beta * mu_ij * mu_ij) / rho_bar;
            acc.dv -= p.grad * (f.m[j] * pi);
        }
    }
    /// The linear part without the approach switch: an upper bound of the operator.
    #[inline(always)]
    fn viscous(
        &self,
        k: &Consts<S>,
        d: &Dest<S>,
        f: &Fields<'_, S>,
        p: &Pair<S>,
        acc: &mut Acc<S>,
    ) {
        let j = p.j;
        let mu_ij = k.h * p.v_ij.dot(p.r_ij) / regularised(p.r2, k.eta2);
        let rho_bar = S::Real::HALF * (d.rho + f.rho[j]);
        let pi = -self.alpha * k.c0 * mu_ij / rho_bar;
        acc.dv -= p.grad * (f.m[j] * pi);
    }
}

/// The Voigt pair of component `a` in `dim` dimensions: the diagonal
/// first, then the off-diagonal pairs (2D: xx, yy, xy).
#[inline(always)]
fn voigt(dim: usize, a: usize) -> (usize, usize) {
    const D2: [(usize, usize); 3] = [(0, 0), (1, 1), (0, 1)];
    const D3: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];
    match dim {
        1 => (0, 0),
        2 => D2[a],
        _ => D3[a],
    }
}

/// Unknowns of the local quadratic fit in `dim` dimensions: the gradient
/// and the Hessian's Voigt components.
const fn fit_len(dim: usize) -> usize {
    dim + dim * (dim + 1) / 2
}

/// The Morris viscous operator replaced by a consistent Laplacian: exact for
/// quadratic velocity fields on any particle arrangement (a weighted
/// least-squares Taylor fit, in the spirit of the second-order consistent
/// operators of Fatehi & Manzari 2011), where the Morris operator is exact
/// only on arrangements with symmetric, isotropic moments.
///
/// For destination `i` it fits `v_i - v_j = r_ij . grad v - 1/2 r_ij r_ij : H`
/// over the neighbours in the least-squares sense, with weights
/// `V_j (-F_ij)` (`V_j = m_j / rho_j`), and takes `(mu / rho0) tr H` as the
/// viscous acceleration: one neighbour pass, a `5 x 5` (3D: `9 x 9`) solve
/// per particle. On a lattice it agrees with the Morris operator to its
/// lattice bias; on a sheared lattice, where the Morris operator's bias
/// depends on how far the rows have slid (what makes long channel-flow runs
/// drift, `docs/physics.md` 10), it has none.
///
/// The kinematic viscosity is `mu / rho0`, not `mu / rho_i`: the weakly
/// compressible model stands in for an incompressible liquid, whose
/// kinematic viscosity is one number, and its density varies through
/// artefacts (the lowered sound speed; a sheared lattice, whose summation
/// density changes with the rows' slip phase at unchanged volume per
/// particle). With `mu / rho_i` those artefacts become a viscosity that
/// varies in space: in plane Poiseuille flow the summation density near
/// the walls rises 0.3 % by t = 10 s and the centre-line speed 1e-3 u_max
/// with it (3x the error of `mu / rho0`, docs/validation.md).
///
/// Not conservative: momentum is not exchanged pairwise. The viscous
/// time-step estimate uses the Morris operator (the same on a lattice). A
/// particle with too few neighbours for the fit falls back to Morris.
///
/// It needs a neighbourhood for its fit and its own scratch, so it is used
/// through a solver; alone it validates its coefficients:
///
/// ```
/// use sph_core::prelude::*;
///
/// let t = CorrectedMorrisViscosity { mu: 1e-3, rho0: 1000.0 };
/// assert!(Term::<D2<f64>>::validate(&t).is_ok());
/// let bad = CorrectedMorrisViscosity { mu: 1e-3, rho0: 0.0 };
/// assert!(Term::<D2<f64>>::validate(&bad).is_err());
/// ```
#[derive(Clone, Copy, Debug)]
pub struct CorrectedMorrisViscosity<F> {
    /// Dynamic viscosity `mu`.
    pub mu: F,
    /// Reference density `rho0`: the acceleration is `(mu / rho0) lap v`.
    pub rho0: F,
}

impl<S: Space> Term<S> for CorrectedMorrisViscosity<S::Real> {
    type Scratch = Fit<S>;
    fn validate(&self) -> Result<()> {
        non_negative("mu", self.mu)?;
        positive("rho0", self.rho0)
    }
    const NEEDS_F: bool = true;
    const VISCOUS: bool = true;
    #[inline(always)]
    fn pair_scratch(
        &self,
        k: &Consts<S>,
        _d: &Dest<S>,
        f: &Fields<'_, S>,
        p: &Pair<S>,
        acc: &mut Fit<S>,
    ) {
        if p.r2 <= S::Real::ZERO {
            return;
        }
        let j = p.j;
        let vol = f.m[j] / f.rho[j];
        // The Morris sum, the fallback.
        let w = S::Real::TWO * vol * p.f * p.r2 / regularised(p.r2, k.eta2);
        acc.plain += p.v_ij * w;
        // Basis of the fit in units of h: r/h, then -1/2 c r_k r_l / h^2.
        let inv_h = S::Real::ONE / k.h;
        let dim = S::DIM;
        let n = fit_len(dim);
        let mut phi = [S::Real::ZERO; 9];
        for (a, slot) in phi.iter_mut().enumerate().take(dim) {
            *slot = p.r_ij[a] * inv_h;
        }
        for a in 0..n - dim {
            let (kk, ll) = voigt(dim, a);
            let c = if kk == ll {
                -S::Real::HALF
            } else {
                -S::Real::ONE
            };
            phi[dim + a] = c * phi[kk] * phi[ll];
        }
        let omega = -vol * p.f;
        for a in 0..n {
            let wa = omega * phi[a];
            acc.s[a] += p.v_ij * wa;
            for (t, &pb) in acc.t[a][a..n].iter_mut().zip(&phi[a..n]) {
                *t += wa * pb;
            }
        }
    }

    #[inline(always)]
    // Matrix index arithmetic reads clearer than iterator chains here.
    #[allow(clippy::needless_range_loop)]
    fn finish(&self, k: &Consts<S>, _d: &Dest<S>, fit: &Self::Scratch, acc: &mut Acc<S>) {
        let dim = S::DIM;
        let n = fit_len(dim);
        let mut t = fit.t;
        // Mirror the upper triangle the pairs filled.
        for a in 0..n {
            for b in 0..a {
                t[a][b] = t[b][a];
            }
        }
        // The Laplacian is sum over the diagonal Hessian unknowns: solve for
        // the row of the inverse that picks them (t is symmetric).
        let mut pick = [S::Real::ZERO; 9];
        for slot in pick.iter_mut().skip(dim).take(dim) {
            *slot = S::Real::ONE;
        }
        let lap = if solve(&mut t, &mut pick, n) {
            let mut sum = S::Vector::zero();
            for (a, &c) in pick.iter().enumerate().take(n) {
                sum += fit.s[a] * c;
            }
            sum * (S::Real::ONE / (k.h * k.h))
        } else {
            fit.plain
        };
        acc.dv += lap * (self.mu / self.rho0);
    }

    /// The Morris operator (see the type docs).
    #[inline(always)]
    fn viscous(
        &self,
        k: &Consts<S>,
        d: &Dest<S>,
        f: &Fields<'_, S>,
        p: &Pair<S>,
        acc: &mut Acc<S>,
    ) {
        let morris = MorrisViscosity { mu: self.mu };
        <MorrisViscosity<S::Real> as Term<S>>::viscous(&morris, k, d, f, p, acc);
    }
}

/// Solves `t x = rhs` in place (`rhs` becomes `x`) for the leading `n x n`
/// block by Gaussian elimination with partial pivoting; false if the matrix
/// is singular relative to its largest entry.
#[allow(clippy::needless_range_loop)]
fn solve<F: Real>(t: &mut [[F; 9]; 9], rhs: &mut [F; 9], n: usize) -> bool {
    let mut scale = F::ZERO;
    for row in t.iter().take(n) {
        for &x in row.iter().take(n) {
            scale = scale.max(x.abs());
        }
    }
    if !(scale > F::ZERO) {
        return false;
    }
    let tiny = scale * F::from_f64(1e-10);
    for c in 0..n {
        let mut piv = c;
        for r in c + 1..n {
            if t[r][c].abs() > t[piv][c].abs() {
                piv = r;
            }
        }
        if !(t[piv][c].abs() > tiny) {
            return false;
        }
        t.swap(c, piv);
        rhs.swap(c, piv);
        for r in c + 1..n {
            let factor = t[r][c] / t[c][c];
            for k in c..n {
                let v = t[c][k];
                t[r][k] -= factor * v;
            }
            let v = rhs[c];
            rhs[r] -= factor * v;
        }
    }
    for c in (0..n).rev() {
        let mut x = rhs[c];
        for k in c + 1..n {
            x -= t[c][k] * rhs[k];
        }
        rhs[c] = x / t[c][c];
    }
    true
}

/// One of the three viscous forms, chosen at run time (one predictable branch
/// per pair; a scene that knows its form at compile time names the form's own
/// type instead).
#[derive(Clone, Copy, Debug)]
pub enum AnyViscosity<F> {
    /// [`MorrisViscosity`].
    Morris(MorrisViscosity<F>),
    /// [`PiViscosity`].
    Pi(PiViscosity<F>),
    /// [`ArtificialViscosity`].
    Artificial(ArtificialViscosity<F>),
    /// [`MorrisViscosity`] and [`ArtificialViscosity`] together: the
    /// laminar term for the fluid's viscosity, the artificial one for the
    /// shocks and splashes of free-surface flows (it acts on approaching
    /// pairs only).
    MorrisArtificial(MorrisViscosity<F>, ArtificialViscosity<F>),
}

impl<S: Space> Term<S> for AnyViscosity<S::Real> {
    type Scratch = ();
    fn validate(&self) -> Result<()> {
        match self {
            AnyViscosity::Morris(t) => <MorrisViscosity<S::Real> as Term<S>>::validate(t),
            AnyViscosity::Pi(t) => <PiViscosity<S::Real> as Term<S>>::validate(t),
            AnyViscosity::Artificial(t) => <ArtificialViscosity<S::Real> as Term<S>>::validate(t),
            AnyViscosity::MorrisArtificial(m, a) => {
                <MorrisViscosity<S::Real> as Term<S>>::validate(m)?;
                <ArtificialViscosity<S::Real> as Term<S>>::validate(a)
            }
        }
    }
    const NEEDS_F: bool = true;
    const VISCOUS: bool = true;
    #[inline(always)]
    fn pair(&self, k: &Consts<S>, d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, acc: &mut Acc<S>) {
        match self {
            AnyViscosity::Morris(t) => {
                <MorrisViscosity<S::Real> as Term<S>>::pair(t, k, d, f, p, acc)
            }
            AnyViscosity::Pi(t) => <PiViscosity<S::Real> as Term<S>>::pair(t, k, d, f, p, acc),
            AnyViscosity::Artificial(t) => {
                <ArtificialViscosity<S::Real> as Term<S>>::pair(t, k, d, f, p, acc)
            }
            AnyViscosity::MorrisArtificial(m, a) => {
                <MorrisViscosity<S::Real> as Term<S>>::pair(m, k, d, f, p, acc);
                <ArtificialViscosity<S::Real> as Term<S>>::pair(a, k, d, f, p, acc);
            }
        }
    }
    #[inline(always)]
    fn viscous(
        &self,
        k: &Consts<S>,
        d: &Dest<S>,
        f: &Fields<'_, S>,
        p: &Pair<S>,
        acc: &mut Acc<S>,
    ) {
        match self {
            AnyViscosity::Morris(t) => {
                <MorrisViscosity<S::Real> as Term<S>>::viscous(t, k, d, f, p, acc)
            }
            AnyViscosity::Pi(t) => <PiViscosity<S::Real> as Term<S>>::viscous(t, k, d, f, p, acc),
            AnyViscosity::Artificial(t) => {
                <ArtificialViscosity<S::Real> as Term<S>>::viscous(t, k, d, f, p, acc)
            }
            AnyViscosity::MorrisArtificial(m, a) => {
                <MorrisViscosity<S::Real> as Term<S>>::viscous(m, k, d, f, p, acc);
                <ArtificialViscosity<S::Real> as Term<S>>::viscous(a, k, d, f, p, acc);
            }
        }
    }
}

/// Particle shifting (Lind et al. 2012, in the form of the delta-plus-SPH
/// scheme of Sun et al. 2017): each particle drifts with `v + u_s`, where
///
/// `u_s,i = -C U h sum_j V_j [1 + R (W_ij / W(dx))^4] grad_i W_ij`,
///
/// `V_j = m_j / rho_j`, `U` the scene's velocity scale, `C` a dimensionless
/// coefficient and `R = 0.2`. The sum is the gradient of the particle
/// concentration (zero on a uniform arrangement), so particles move from
/// crowded to sparse regions; the `R` term repels close pairs, which breaks
/// up the strings and clumps that form along stagnation lines in weakly
/// compressible SPH (Taylor-Green vortex, cavities). Per unit time the shift
/// is a diffusion of the particle positions with coefficient of order
/// `C U h^2`; it does not change velocities or densities, so with summation
/// density the density follows the shifted positions by itself.
///
/// Shifting is part of the force group; the solver needs a `shift` buffer
/// (see [`crate::solver::Storage::shift`]).
///
/// ```
/// # use sph_core::prelude::*;
/// # use sph_core::terms::{Acc, Consts, Dest, Fields, Pair};
/// # // Two particles 0.1 apart along x; particle 0 moves towards 1.
/// # let x = [Vector::new([0.0, 0.0]), Vector::new([0.1, 0.0])];
/// # let v = [Vector::new([1.0, 0.0]), Vector::new([0.0, 0.0])];
/// # let (m, rho, p) = ([0.01, 0.01], [1.0, 1.02], [2.0, 1.0]);
/// # let f = Fields::<D2<f64>> { x: &x, v: &v, m: &m, rho: &rho, p: &p, walls: x.len() };
/// # let k = Consts { h: 0.13, eta2: 1e-6, c0: 10.0 };
/// # let dest = |i: usize| Dest { i, v: v[i], m: m[i], rho: rho[i], p: p[i] };
/// # // Kernel value and F = (1/r) dW/dr (negative) of the pair, by hand.
/// # let (w, fr) = (5.0, -300.0);
/// # let pair = |i: usize, j: usize| {
/// #     let r_ij = x[i] - x[j];
/// #     Pair { j, r_ij, r2: r_ij.norm2(), w, f: fr, grad: r_ij * fr, v_ij: v[i] - v[j] }
/// # };
/// # let one = |t: &dyn Fn(&Dest<D2<f64>>, &Pair<D2<f64>>, &mut Acc<D2<f64>>), i: usize, j: usize| {
/// #     let mut acc = Acc::default();
/// #     t(&dest(i), &pair(i, j), &mut acc);
/// #     acc
/// # };
/// // A crowded neighbour to the right pushes particle 0 to the left.
/// let t = Shifting::new(0.5, 1.0, k.h, 4.0);
/// let a0 = one(&|d, q, a| Term::<D2<f64>>::pair(&t, &k, d, &f, q, a), 0, 1);
/// assert!(a0.shift[0] < 0.0 && a0.shift[1] == 0.0);
/// assert!(Term::<D2<f64>>::validate(&Shifting::new(-1.0, 1.0, k.h, 4.0)).is_err());
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Shifting<F> {
    /// `C U h`: the coefficient times the velocity scale and `h`.
    pub scale: F,
    /// `1 / W(dx)`: the kernel value at the initial spacing, inverted.
    pub inv_w_dx: F,
    /// Weight `R` of the anti-clumping part (0.2 in Sun et al. 2017).
    pub repulsion: F,
    /// Free-surface limit: where the divergence of position is below this
    /// threshold (the support is cut: a free surface), the shift keeps only
    /// its part along the surface, so it cannot push particles out of the
    /// fluid (Lind et al. 2012). 0: no limit, the default (bitwise the
    /// unlimited term); [`Self::with_free_surface`] sets it.
    pub surface: F,
}

impl<F: Real> Shifting<F> {
    /// Shifting with coefficient `c`, velocity scale `u`, smoothing length
    /// `h`, and `w_dx` the kernel value at the initial particle spacing.
    pub fn new(c: F, u: F, h: F, w_dx: F) -> Self {
        let inv_w_dx = if w_dx > F::ZERO {
            F::ONE / w_dx
        } else {
            F::ZERO
        };
        Self {
            scale: c * u * h,
            inv_w_dx,
            repulsion: F::from_f64(0.2),
            surface: F::ZERO,
        }
    }

    /// The same shifting, limited to the surface's tangent where the
    /// divergence of position falls below `threshold` (Lind et al. 2012 use
    /// 1.5 in 2D; the dimension itself inside a full support).
    pub fn with_free_surface(mut self, threshold: F) -> Self {
        self.surface = threshold;
        self
    }
}

impl<S: Space> Term<S> for Shifting<S::Real> {
    type Scratch = Gradients<S>;
    fn validate(&self) -> Result<()> {
        non_negative("shift scale", self.scale)?;
        non_negative("inv_w_dx", self.inv_w_dx)?;
        non_negative("repulsion", self.repulsion)?;
        non_negative("free-surface threshold", self.surface)
    }
    const NEEDS_W: bool = true;
    const NEEDS_F: bool = true;
    const SHIFTS: bool = true;
    #[inline(always)]
    fn pair(&self, _k: &Consts<S>, _d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, acc: &mut Acc<S>) {
        let j = p.j;
        let vol = f.m[j] / f.rho[j];
        let ratio = p.w * self.inv_w_dx;
        let r2 = ratio * ratio;
        let weight = S::Real::ONE + self.repulsion * r2 * r2;
        acc.shift -= p.grad * (self.scale * weight * vol);
    }

    /// First-order gradients `<grad f>_i = sum_j V_j (f_j - f_i) grad_i W_ij`
    /// for the Taylor correction.
    #[inline(always)]
    fn pair_scratch(
        &self,
        _k: &Consts<S>,
        d: &Dest<S>,
        f: &Fields<'_, S>,
        p: &Pair<S>,
        g: &mut Self::Scratch,
    ) {
        let j = p.j;
        let vol = f.m[j] / f.rho[j];
        for b in 0..S::DIM {
            g.v[b] -= p.v_ij * (vol * p.grad[b]);
        }
        g.rho += p.grad * (vol * (f.rho[j] - d.rho));
        if self.surface > S::Real::ZERO {
            g.div_r -= p.r_ij.dot(p.grad) * vol;
            g.inward += p.grad * vol;
        }
    }

    /// A shifted particle samples the flow `u_s dt` away from where the fluid
    /// took it: its velocity and density change by `u_s . grad` per unit time
    /// (Lind et al. 2012, Taylor expansion to first order).
    #[inline(always)]
    fn finish(&self, _k: &Consts<S>, _d: &Dest<S>, g: &Self::Scratch, acc: &mut Acc<S>) {
        // At a free surface: the shift's part along the surface normal removed.
        if g.div_r < self.surface {
            let n2 = g.inward.norm2();
            if n2 > S::Real::ZERO {
                acc.shift -= g.inward * (acc.shift.dot(g.inward) / n2);
            }
        }
        for b in 0..S::DIM {
            acc.dv += g.v[b] * acc.shift[b];
        }
        acc.drho += g.rho.dot(acc.shift);
    }
}

/// Density diffusion of Molteni & Colagrossi (2009), the delta-SPH term
/// (`docs/physics.md` 3.2): with continuity density,
///
/// `d rho_i/dt += 2 delta h c0 sum_j V_j (rho_i - rho_j) (r_ij . grad_i W_ij) / (r^2 + eta^2)`,
///
/// `V_j = m_j / rho_j`. Since `r_ij . grad W < 0` it diffuses density
/// differences at the particle scale (the checkerboard noise continuity
/// density accumulates) and vanishes for uniform density; `delta = 0.1` is
/// the usual value.
///
/// Alone it also diffuses a hydrostatic density gradient: under gravity
/// `g` the density at rest grows with depth, and the term pulls it back
/// towards uniform. [`Self::hydrostatic`] removes that part (Fourtakas,
/// van Rijn, Rogers et al. 2019, to first order in the compression): the
/// difference diffused is `(rho_i - rho_j) - G . r_ij`, with
/// `G = rho0 g / c0^2` the density gradient of the fluid at rest, so the
/// hydrostatic state is left alone and only the deviation from it
/// diffuses. With `G = 0` (the default) the arithmetic is the plain term's.
/// For the Tait equation `G` uses the sound speed at `rho0`, which differs
/// from the local one by a fraction `(gamma - 1) (rho / rho0 - 1)` (a few
/// per cent of a small correction at 1 % compression).
///
/// Wall particles ([`Fields::walls`]) are left out of the sum, as in
/// DualSPHysics' `DDT2`: a wall particle's density is set from the wall's
/// extrapolated pressure every pass rather than integrated, so density
/// diffused into it would leave the fluid for good (the volume-weighted
/// rates of fluid pairs cancel; those of a fluid-wall pair do not), and
/// diffusing a particle approaching a wall towards the wall's smoother
/// density takes away the compression that holds it off the wall.
/// Mirrored ghosts carry their fluid particle's density and stay in.
///
/// ```
/// # use sph_core::prelude::*;
/// # use sph_core::terms::{Acc, Consts, Dest, Fields, Pair};
/// # // Two particles 0.1 apart along x; particle 0 moves towards 1.
/// # let x = [Vector::new([0.0, 0.0]), Vector::new([0.1, 0.0])];
/// # let v = [Vector::new([1.0, 0.0]), Vector::new([0.0, 0.0])];
/// # let (m, rho, p) = ([0.01, 0.01], [1.0, 1.02], [2.0, 1.0]);
/// # let f = Fields::<D2<f64>> { x: &x, v: &v, m: &m, rho: &rho, p: &p, walls: x.len() };
/// # let k = Consts { h: 0.13, eta2: 1e-6, c0: 10.0 };
/// # let dest = |i: usize| Dest { i, v: v[i], m: m[i], rho: rho[i], p: p[i] };
/// # // Kernel value and F = (1/r) dW/dr (negative) of the pair, by hand.
/// # let (w, fr) = (5.0, -300.0);
/// # let pair = |i: usize, j: usize| {
/// #     let r_ij = x[i] - x[j];
/// #     Pair { j, r_ij, r2: r_ij.norm2(), w, f: fr, grad: r_ij * fr, v_ij: v[i] - v[j] }
/// # };
/// # let one = |t: &dyn Fn(&Dest<D2<f64>>, &Pair<D2<f64>>, &mut Acc<D2<f64>>), i: usize, j: usize| {
/// #     let mut acc = Acc::default();
/// #     t(&dest(i), &pair(i, j), &mut acc);
/// #     acc
/// # };
/// // Density flows from the denser particle 1 to particle 0, and the
/// // volume-weighted rates cancel: mass density is only moved.
/// let t = DensityDiffusion::<D2<f64>>::new(0.1);
/// let a0 = one(&|d, q, a| t.pair(&k, d, &f, q, a), 0, 1);
/// let a1 = one(&|d, q, a| t.pair(&k, d, &f, q, a), 1, 0);
/// assert!(a0.drho > 0.0 && a1.drho < 0.0);
/// let moved = a0.drho * m[0] / rho[0] + a1.drho * m[1] / rho[1];
/// assert!(moved.abs() < 1e-12 * a0.drho.abs());
/// // With the hydrostatic correction a density difference that matches
/// // the gradient G along r_ij (here 0.02 over 0.1 along +x) is left alone.
/// let at_rest = t.hydrostatic(Vector::new([0.2, 0.0]));
/// let a0 = one(&|d, q, a| at_rest.pair(&k, d, &f, q, a), 0, 1);
/// assert!(a0.drho.abs() < 1e-12);
/// assert!(at_rest.hydrostatic(Vector::new([f64::NAN, 0.0])).validate().is_err());
/// // A wall particle (index `walls` and above) takes no part: its density
/// // comes from the wall's extrapolated pressure, not from a balance of
/// // mass, so what it gave or took would be lost.
/// let f = Fields { walls: 1, ..f };
/// let a0 = one(&|d, q, a| t.pair(&k, d, &f, q, a), 0, 1);
/// assert_eq!(a0.drho, 0.0);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct DensityDiffusion<S: Space> {
    /// The coefficient `delta`.
    pub delta: S::Real,
    /// The hydrostatic density gradient `G = rho0 g / c0^2` left alone
    /// (zero: none; see the type's docs).
    pub gradient: S::Vector,
}

impl<S: Space> DensityDiffusion<S> {
    /// The plain term with coefficient `delta`.
    pub fn new(delta: S::Real) -> Self {
        Self {
            delta,
            gradient: S::Vector::zero(),
        }
    }

    /// The same term leaving the hydrostatic density gradient `gradient`
    /// (`rho0 g / c0^2`) alone.
    pub fn hydrostatic(mut self, gradient: S::Vector) -> Self {
        self.gradient = gradient;
        self
    }
}

impl<S: Space> Term<S> for DensityDiffusion<S> {
    type Scratch = ();
    fn validate(&self) -> Result<()> {
        non_negative("delta", self.delta)?;
        for a in 0..S::DIM {
            finite("gradient", self.gradient[a])?;
        }
        Ok(())
    }
    const NEEDS_F: bool = true;
    #[inline(always)]
    fn pair(&self, k: &Consts<S>, d: &Dest<S>, f: &Fields<'_, S>, p: &Pair<S>, acc: &mut Acc<S>) {
        let j = p.j;
        if j >= f.walls {
            return;
        }
        let coeff = S::Real::TWO * self.delta * k.h * k.c0 * f.m[j] / f.rho[j];
        // `x - 0` is `x`: without a gradient the plain term's bits.
        let difference = (d.rho - f.rho[j]) - self.gradient.dot(p.r_ij);
        acc.drho += coeff * difference * p.r_ij.dot(p.grad) / regularised(p.r2, k.eta2);
    }
}
