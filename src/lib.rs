//! `sph`: smoothed particle hydrodynamics.
//!
//! This facade re-exports the two crates of the workspace:
//! - [`core`] (`sph-core`): the `no_std`, allocation-free numerics;
//! - [`std`] (`sph-std`): the workstation frontend (rayon, config, I/O,
//!   validation cases, plots).
//!
//! The `sph` binary is a thin command-line shell over [`std`].

pub use sph_core as core;
pub use sph_std as std;
