#![no_std]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::todo)
)]
#![doc = include_str!("../README.md")]
// `!(x > 0.0)` is how this crate rejects NaN together with out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

#[cfg(test)]
extern crate std;

pub mod analytic;
pub mod boundary;
pub mod domain;
pub mod eos;
pub mod error;
pub mod exec;
pub mod kernel;
pub mod math;
pub mod neighbour;
pub mod real;
pub mod shape;
pub mod solver;
pub mod space;
pub mod store;
pub mod terms;

/// The names most scenes need.
pub mod prelude {
    pub use crate::domain::{Domain, Reflection, Side, Wall, WallKind};
    pub use crate::eos::Eos;
    pub use crate::error::{Error, Fault, Result};
    pub use crate::exec::{Executor, Serial};
    pub use crate::kernel::{CubicSpline, Gaussian, Kernel, QuinticSpline, WendlandC2, WendlandC4};
    #[cfg(feature = "micromath")]
    pub use crate::math::Micromath;
    pub use crate::math::{Libm, Math};
    pub use crate::real::Real;
    pub use crate::shape::{Shape, ShapedWall};
    pub use crate::solver::{Limits, Params, Solver, Storage};
    pub use crate::space::{Space, Vector, VectorOps, D1, D2, D3};
    pub use crate::store::Store;
    pub use crate::terms::{
        AnyContinuity, AnyPressure, AnyViscosity, ArtificialViscosity, BodyForce, Continuity,
        CorrectedMorrisViscosity, DensityDiffusion, MorrisViscosity, PiViscosity, PressureGradient,
        Shifting, SummationDensity, Term,
    };
}
