//! `sph-tool`: smoothed particle hydrodynamics, the facade crate and the
//! `sph` command-line tool.
//!
//! This facade re-exports the two crates of the workspace under their own
//! names (so that `use sph_tool::*` never shadows the language's `core`
//! and `std`):
//! - [`sph_core`]: the `no_std`, allocation-free numerics;
//! - [`sph_std`]: the workstation frontend (rayon, config, I/O, validation
//!   cases, checkpoints, plots).
//!
//! The `sph` binary is a thin command-line shell over [`sph_std`].
//!
//! ```
//! use sph_tool::sph_core::analytic::Couette;
//!
//! // The start-up Couette flow at mid-gap: linear long after the start.
//! let exact = Couette::new(0.0, 1e-3, 1.25e-5, 1e-6)?;
//! let u = exact.velocity(0.5e-3, 100.0);
//! assert!((u - 0.5 * 1.25e-5).abs() < 1e-15);
//! # Ok::<(), sph_tool::sph_core::error::Error>(())
//! ```

pub use sph_core;
pub use sph_std;
