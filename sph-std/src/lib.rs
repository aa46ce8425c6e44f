//! The std frontend of `sph`: a rayon driver over the core's chunked API,
//! configuration, validation cases, output files and plots.
//!
//! The `sph` command-line tool is a thin shell over this crate; everything it
//! does can be done from code:
//!
//! ```no_run
//! use sph_std::config::CouetteConfig;
//! use sph_std::couette::{self, Silent};
//!
//! let config = CouetteConfig { particles_across: 20, ..CouetteConfig::default() };
//! let run = couette::run(&config, &Silent)?;
//! let (linf, _l2) = run.headline();
//! println!("L-infinity error {linf:.2e} U in {} steps", run.steps);
//! # Ok::<(), sph_std::error::Error>(())
//! ```

pub mod bench;
pub mod cases;
pub mod checkpoint;
pub mod config;
pub mod couette;
pub mod distributed;
pub mod driver;
pub mod error;
pub mod exact;
pub mod math;
pub mod output;
pub mod plot;
pub mod progress;
pub mod provenance;
pub mod report;
pub mod resources;
pub mod scene;
pub mod simulation;
pub mod studies;

pub use sph_core;
