//! What every summary says about itself: the units of its numbers, the sph
//! version and git commit that wrote it, and when.

use std::sync::OnceLock;

use serde::Serialize;

static COMMIT: OnceLock<String> = OnceLock::new();

/// Records the git commit the running program was built from (the `sph`
/// binary does this at start-up from its build script); summaries written
/// afterwards carry it. Without it, `git_commit` is `null`.
pub fn set_git_commit(commit: &str) {
    let _ = COMMIT.set(commit.to_string());
}

/// The units of the quantities in a summary (SI; the built-in cases are
/// posed in SI units, nondimensional ones with unit scales).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Units {
    /// Times, time steps and limits.
    pub time: &'static str,
    /// Positions, lengths, `dx` and `h`.
    pub length: &'static str,
    /// Velocities and velocity scales.
    pub velocity: &'static str,
    /// Densities.
    pub density: &'static str,
    /// Pressures.
    pub pressure: &'static str,
    /// Kinematic viscosity `nu`.
    pub nu: &'static str,
    /// Body force per unit mass.
    pub body_force: &'static str,
    /// Energies (per unit depth in 2D).
    pub energy: &'static str,
    /// Error norms.
    pub errors: &'static str,
    /// Wall-clock times.
    pub wall_seconds: &'static str,
    /// Memory.
    pub storage_bytes: &'static str,
}

/// The units every summary uses.
pub const UNITS: Units = Units {
    time: "s",
    length: "m",
    velocity: "m/s",
    density: "kg/m^3",
    pressure: "Pa",
    nu: "m^2/s",
    body_force: "m/s^2",
    energy: "J (J/m in 2D)",
    errors:
        "fraction of velocity_scale (relative to the decaying amplitude where error_decay is set)",
    wall_seconds: "s",
    storage_bytes: "bytes",
};

/// Version, commit, time of writing and units, flattened into a summary.
#[derive(Clone, Debug, Serialize)]
pub struct Provenance {
    /// The sph version (of `sph-std`).
    pub sph_version: &'static str,
    /// The git commit of the build, where known.
    pub git_commit: Option<String>,
    /// When the summary was written (RFC 3339, UTC, seconds).
    pub timestamp: String,
    /// Units of the summary's numbers.
    pub units: Units,
}

/// The provenance of a summary written now.
pub fn now() -> Provenance {
    Provenance {
        sph_version: env!("CARGO_PKG_VERSION"),
        git_commit: COMMIT.get().cloned(),
        timestamp: humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string(),
        units: UNITS,
    }
}
