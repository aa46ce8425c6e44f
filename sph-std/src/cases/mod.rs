//! The built-in cases: each a file here and one line in [`CASES`].
//!
//! A case turns resolved [`Settings`] into a [`Scene`]. Settings start from
//! the case's own defaults; a scene file (`case = "NAME"` plus keys) and then
//! command-line flags override them key by key, and the resolved settings
//! are written back as `config.toml`, so a run can be repeated exactly.
//!
//! # The state monitor's defaults
//! Closest fluid pair 0.5 dx, density deviation 5 %, Mach 0.5, checked every
//! 50 steps (density and Mach) and at every output time (all three). On the
//! Taylor-Green vortex without regularisation the closest pair falls to
//! 0.03-0.3 dx while every other measure looks healthy, so the spacing bound
//! is the one that catches clumping; 0.5 dx is far below what any built-in
//! case reaches with its own defaults (a test runs each at CI size) and far
//! above a collapsed state. With `c0 = 10 U` the density varies by about 1 %
//! (Mach 0.1): 5 % and Mach 0.5 flag a run that has left the weakly
//! compressible regime.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::config::{check, DensityMode, KernelName, MathBackend, Precision, ViscosityForm};
use crate::error::{Error, Result};
use crate::plot::{line_plot, Axes, Series};
use crate::scene::{
    EosForm, Monitor, Physics, PressureForm, Regularise, RunRecord, Scene, WallBoundary,
    WallPressure,
};

mod cavity;
mod closed_tank;
mod couette;
pub mod custom;
mod cylinder_array;
mod dam_break;
mod hydrostatic;
mod poiseuille;
mod rotating_tank;
mod taylor_couette;
mod taylor_green;
mod tilted_channel;

pub use cavity::{compare_ghia, ghia, shepard_velocity, Comparison, GhiaRow};
pub use closed_tank::{pressure_probes as closed_tank_pressure_probes, Container};
pub use cylinder_array::{
    drag as cylinder_array_drag, measured_drag as cylinder_array_measured_drag,
};
pub use dam_break::{
    front as dam_break_front, history as dam_break_history, interpolate as dam_break_interpolate,
    KOSHIZUKA_OKA, MARTIN_MOYCE_1125, MARTIN_MOYCE_225,
};
pub use hydrostatic::{
    exact_pressure as hydrostatic_exact_pressure, pressure_probes as hydrostatic_pressure_probes,
};
pub use rotating_tank::pressure_probes as rotating_tank_pressure_probes;
pub use taylor_couette::{spin_up as taylor_couette_spin_up, steady as taylor_couette_steady};
pub use taylor_green::velocity as taylor_green_velocity;

/// A built-in case.
#[derive(Clone, Copy, Debug)]
pub struct Case {
    /// Name used by `sph run NAME` and `case = "NAME"`.
    pub name: &'static str,
    /// One line for `sph cases`.
    pub about: &'static str,
    /// The case's default settings.
    pub defaults: fn() -> Settings,
    /// Builds the scene.
    pub build: fn(&Settings) -> Result<Scene>,
    /// The case's own figure (`case.png`): profiles or fields against the
    /// reference, from the scene and its run.
    pub figure: fn(&Scene, &RunRecord) -> Result<Vec<u8>>,
    /// The run's last output against published reference data, where the
    /// case has some and no exact solution (`reference` in summary.json).
    pub reference: fn(&RunRecord) -> Option<Reference>,
}

/// A run against published reference data (see [`Case::reference`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Reference {
    /// Where the data come from.
    pub source: String,
    /// Time of the output compared.
    pub t: f64,
    /// Largest `|sph - reference|` over the points, relative to the
    /// velocity scale for velocities, to the reference value for a drag and
    /// to `rho0 g D` for a pressure (each case's docs say which).
    pub max_deviation: f64,
    /// Every point compared.
    pub points: Vec<ReferencePoint>,
}

/// One point of a [`Reference`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReferencePoint {
    /// The quantity and line, e.g. `u(x = 1/2)`.
    pub quantity: &'static str,
    /// Position along the line.
    pub at: f64,
    /// The published value.
    pub reference: f64,
    /// The run's value there.
    pub sph: f64,
}

/// No reference data (cases with an exact solution).
pub(crate) fn no_reference(_record: &RunRecord) -> Option<Reference> {
    None
}

/// Every built-in case.
pub const CASES: &[Case] = &[
    couette::CASE,
    poiseuille::CASE,
    taylor_green::CASE,
    taylor_couette::CASE,
    tilted_channel::CASE,
    cylinder_array::CASE,
    closed_tank::CASE,
    rotating_tank::CASE,
    hydrostatic::CASE,
    dam_break::CASE,
    cavity::CASE,
    custom::CASE,
];

fn mirror() -> WallBoundary {
    WallBoundary::Mirror
}

fn hydrostatic() -> WallPressure {
    WallPressure::Hydrostatic
}

fn symmetric() -> PressureForm {
    PressureForm::Symmetric
}

fn linear() -> EosForm {
    EosForm::Linear
}

/// The case called `name`.
///
/// # Errors
/// [`Error::Config`] naming the key `case` and listing the cases.
pub fn find(name: &str) -> Result<&'static Case> {
    CASES.iter().find(|c| c.name == name).ok_or_else(|| {
        Error::config(
            "case",
            name,
            format!(
                "unknown case; the built-in cases are {}",
                CASES.iter().map(|c| c.name).collect::<Vec<_>>().join(", ")
            ),
        )
    })
}

/// Resolved settings of a run: every key has a value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    /// The built-in case.
    pub case: String,
    /// Particles across the case's reference length.
    pub resolution: usize,
    /// Dimension: 2, or 3 for the channel cases (periodic along z).
    pub dim: usize,
    /// End time in seconds.
    pub t_end: f64,
    /// Time between outputs in seconds.
    pub output_interval: f64,
    /// Reynolds number `U L / nu` (sets the viscosity).
    pub re: f64,
    /// Smoothing kernel.
    pub kernel: KernelName,
    /// `h / dx`.
    pub beta: f64,
    /// Viscous regulariser as a fraction of `h^2`.
    pub eta2: f64,
    /// Density by summation or continuity.
    pub density: DensityMode,
    /// Viscous form.
    pub viscosity: ViscosityForm,
    /// Floating-point precision.
    pub precision: Precision,
    /// Math backend.
    pub math: MathBackend,
    /// Particle regularisation.
    pub regularise: Regularise,
    /// Shifting coefficient `C`.
    pub shift_coefficient: f64,
    /// Density diffusion `delta` (continuity and corrected density; 0: off).
    pub density_diffusion: f64,
    /// Time step as a fraction of the smallest stability limit.
    pub dt_factor: f64,
    /// `c0` as a multiple of the velocity scale.
    pub sound_speed_factor: f64,
    /// Background pressure as a fraction of `rho0 c0^2`.
    pub background_pressure: f64,
    /// What the wall ghosts' pressure balances: `hydrostatic` (the body
    /// force across the wall) or `mirror` (a copy of the source's).
    #[serde(default = "hydrostatic")]
    pub wall_pressure: WallPressure,
    /// The box's planar walls: `mirror` (mirrored ghosts, exact for the
    /// channels) or `particles` (fixed wall particles, Adami et al. 2012:
    /// free surfaces driven at a wall).
    #[serde(default = "mirror")]
    pub wall_boundary: WallBoundary,
    /// The pressure gradient: `symmetric` (conserves momentum) or
    /// `corrected` (exact for linear pressure on any arrangement;
    /// continuity density only).
    #[serde(default = "symmetric")]
    pub pressure_gradient: PressureForm,
    /// The equation of state: `linear` or `tait` (`gamma = 7`).
    #[serde(default = "linear")]
    pub eos: EosForm,
    /// Artificial viscosity `alpha`: with `viscosity = "artificial"` its
    /// coefficient (0: matched to `re`); with `"morris"` added to the
    /// laminar term (0: none).
    #[serde(default)]
    pub alpha: f64,
    /// No tension: continuity density bounded below by `rho0`, so the
    /// pressure by the background pressure (free surfaces, where tension
    /// pulls particles into pairs).
    #[serde(default)]
    pub tension_cutoff: bool,
    /// The energy budget (kinetic, potential, internal, dissipated) at
    /// every output time, at the cost of one more pass per step over the
    /// viscous and diffusive terms.
    #[serde(default)]
    pub energy_budget: bool,
    /// A time step chosen every step from the current state (the acoustic
    /// limit on `c0` plus the largest speed, the force limit on the largest
    /// acceleration, the viscous limit), times `dt_factor`, instead of one
    /// fixed step from the scene's velocity scale.
    #[serde(default)]
    pub adaptive_dt: bool,
    /// Worker threads (0: all cores).
    pub threads: usize,
    /// Monitor: smallest closest-pair distance, in `dx`.
    pub monitor_min_spacing: f64,
    /// Monitor: largest `|rho/rho0 - 1|`.
    pub monitor_max_density_deviation: f64,
    /// Monitor: largest Mach number.
    pub monitor_max_mach: f64,
    /// Area fraction of the solid: `case = "cylinder-array"` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub solid_fraction: Option<f64>,
    /// Time over which gravity rises from zero, in the case's time unit:
    /// the free-surface cases only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity_ramp: Option<f64>,
    /// The container: `case = "closed-tank"` or `"rotating-tank"` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub container: Option<Container>,
    /// The container's velocity `[ux, uy]` in units of its rim speed
    /// (`[0, 0]` by default): `case = "rotating-tank"` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drift: Option<Vec<f64>>,
    /// The scene's parts: `case = "custom"` only (see [`custom`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene: Option<custom::Parts>,
}

impl Settings {
    /// Settings shared by the cases, for `case` at `resolution` with the
    /// given end time and output interval (cubic, beta 1.3, Morris,
    /// summation, f64, no regularisation, `c0 = 10 U`).
    pub fn base(case: &str, resolution: usize, t_end: f64, output_interval: f64, re: f64) -> Self {
        let m = Monitor::default();
        Self {
            case: case.to_string(),
            resolution,
            dim: 2,
            t_end,
            output_interval,
            re,
            kernel: KernelName::Cubic,
            beta: 1.3,
            eta2: 0.01,
            density: DensityMode::Summation,
            viscosity: ViscosityForm::Morris,
            precision: Precision::F64,
            math: MathBackend::Libm,
            regularise: Regularise::None,
            shift_coefficient: 4.0,
            density_diffusion: 0.1,
            dt_factor: 0.7,
            sound_speed_factor: 10.0,
            background_pressure: 0.0,
            wall_pressure: WallPressure::Hydrostatic,
            wall_boundary: WallBoundary::Mirror,
            pressure_gradient: PressureForm::Symmetric,
            eos: EosForm::Linear,
            alpha: 0.0,
            tension_cutoff: false,
            energy_budget: false,
            adaptive_dt: false,
            threads: 0,
            monitor_min_spacing: m.min_spacing,
            monitor_max_density_deviation: m.max_density_deviation,
            monitor_max_mach: m.max_mach,
            solid_fraction: None,
            gravity_ramp: None,
            container: None,
            drift: None,
            scene: None,
        }
    }

    /// The defaults of `case`, overridden by the keys of a scene file's text
    /// (which must name the case).
    ///
    /// # Errors
    /// [`Error::Config`] for a missing or unknown case, an unknown key or a
    /// value of the wrong type.
    pub fn from_toml(text: &str) -> Result<Self> {
        let table: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| Error::config("scene", "file", one_line(&e)))?;
        let name = match table.get("case") {
            Some(toml::Value::String(s)) => s.clone(),
            Some(other) => return Err(Error::config("case", other, "must be a string")),
            None => {
                return Err(Error::config(
                    "case",
                    "(missing)",
                    "a scene file names its built-in case, or custom for a scene from parts: case = \"NAME\"",
                ))
            }
        };
        let case = find(&name)?;
        let defaults = (case.defaults)();
        let mut merged = toml::Table::try_from(&defaults)
            .map_err(|e| Error::config("scene", "defaults", e.to_string()))?;
        for (key, value) in table {
            let parts = key == "scene" && name == custom::CASE.name;
            if !merged.contains_key(&key) && !parts {
                return Err(Error::config(
                    key,
                    value,
                    "unknown key (see the case's example file for the keys)",
                ));
            }
            merged.insert(key, value);
        }
        toml::Value::Table(merged)
            .try_into()
            .map_err(|e: toml::de::Error| Error::config("scene", "file", one_line(&e)))
    }

    /// Reads a scene file.
    ///
    /// # Errors
    /// [`Error::Io`] if it cannot be read; as [`Self::from_toml`].
    pub fn from_file(path: &Path) -> Result<Self> {
        let text =
            std::fs::read_to_string(path).map_err(|e| Error::io("read scene file", path, e))?;
        Self::from_toml(&text).map_err(|e| match e {
            Error::Config { key, value, rule } => Error::Config {
                key,
                value,
                rule: format!("{rule} (in {})", path.display()),
            },
            other => other,
        })
    }

    /// The settings as TOML (the `config.toml` of a run).
    ///
    /// # Errors
    /// Never for finite values; reported rather than assumed.
    pub fn to_toml(&self) -> Result<String> {
        toml::to_string(self).map_err(|e| Error::config("config", "toml", e.to_string()))
    }

    /// Checks the keys every case shares.
    ///
    /// # Errors
    /// The first [`Error::Config`] found, naming key, value and rule.
    pub fn validate(&self) -> Result<()> {
        find(&self.case)?;
        check(
            (4..=2000).contains(&self.resolution),
            "resolution",
            self.resolution,
            "must be between 4 and 2000",
        )?;
        check(
            self.dim == 2 || self.dim == 3,
            "dim",
            self.dim,
            "must be 2 or 3",
        )?;
        check(
            self.t_end > 0.0 && self.t_end <= 1e6,
            "t_end",
            self.t_end,
            "must be positive and at most 1e6",
        )?;
        check(
            self.output_interval > 0.0 && self.t_end / self.output_interval <= 10000.0,
            "output_interval",
            self.output_interval,
            "must be positive, with at most 10000 outputs up to t_end",
        )?;
        check(
            self.re > 0.0 && self.re <= 1e5,
            "re",
            self.re,
            "must be positive and at most 1e5",
        )?;
        check(
            (1.0..=3.0).contains(&self.beta),
            "beta",
            self.beta,
            "must be between 1 and 3",
        )?;
        check(
            (0.0..=1.0).contains(&self.eta2),
            "eta2",
            self.eta2,
            "must be between 0 and 1",
        )?;
        check(
            (0.0..=100.0).contains(&self.shift_coefficient),
            "shift_coefficient",
            self.shift_coefficient,
            "must be between 0 and 100",
        )?;
        check(
            (0.0..=1.0).contains(&self.density_diffusion),
            "density_diffusion",
            self.density_diffusion,
            "must be between 0 and 1",
        )?;
        check(
            self.dt_factor > 0.0 && self.dt_factor <= crate::config::MAX_DT_FACTOR,
            "dt_factor",
            self.dt_factor,
            "must be in (0, 0.9]",
        )?;
        check(
            (1.0..=1000.0).contains(&self.sound_speed_factor),
            "sound_speed_factor",
            self.sound_speed_factor,
            "must be between 1 and 1000",
        )?;
        check(
            (0.0..=1.0).contains(&self.background_pressure),
            "background_pressure",
            self.background_pressure,
            "must be between 0 and 1 (fraction of rho0 c0^2)",
        )?;
        check(
            self.threads <= 1024,
            "threads",
            self.threads,
            "must be at most 1024",
        )?;
        check(
            self.monitor_min_spacing >= 0.0 && self.monitor_min_spacing < 1.0,
            "monitor_min_spacing",
            self.monitor_min_spacing,
            "must be in [0, 1) (a fraction of dx)",
        )?;
        check(
            self.monitor_max_density_deviation > 0.0,
            "monitor_max_density_deviation",
            self.monitor_max_density_deviation,
            "must be positive",
        )?;
        check(
            self.monitor_max_mach > 0.0,
            "monitor_max_mach",
            self.monitor_max_mach,
            "must be positive",
        )?;
        if self.math == MathBackend::Micromath && self.precision == Precision::F64 {
            return Err(Error::config(
                "math",
                self.math,
                "micromath implements f32 only: use precision = \"f32\"",
            ));
        }
        check(
            self.alpha.is_finite() && (0.0..=10.0).contains(&self.alpha),
            "alpha",
            self.alpha,
            "must be between 0 and 10",
        )?;
        crate::scene::check_forms(
            self.viscosity,
            self.alpha,
            self.density,
            self.pressure_gradient,
        )?;
        if let Some(ramp) = self.gravity_ramp {
            check(
                ramp.is_finite() && ramp >= 0.0,
                "gravity_ramp",
                ramp,
                "must be finite and at least 0 (0: no ramp)",
            )?;
        }
        for (key, set, cases) in [
            (
                "solid_fraction",
                self.solid_fraction.is_some(),
                &["cylinder-array"][..],
            ),
            (
                "container",
                self.container.is_some(),
                &["closed-tank", "rotating-tank"][..],
            ),
            ("drift", self.drift.is_some(), &["rotating-tank"][..]),
            (
                "gravity_ramp",
                self.gravity_ramp.is_some(),
                &["hydrostatic"][..],
            ),
        ] {
            if set && !cases.contains(&self.case.as_str()) {
                return Err(Error::config(
                    key,
                    &self.case,
                    format!("belongs to case = \"{}\" only", cases.join("\" or \"")),
                ));
            }
        }
        Ok(())
    }

    /// Output times: every `output_interval` up to `t_end` (which is always included).
    pub fn output_times(&self) -> Vec<f64> {
        let k = (self.t_end / self.output_interval - 1e-9).floor() as usize;
        let mut times: Vec<f64> = (1..=k).map(|i| i as f64 * self.output_interval).collect();
        times.push(self.t_end);
        times
    }

    /// The physics of these settings for a velocity scale `u` and density `rho0`.
    pub fn physics(&self, u: f64, rho0: f64) -> Physics {
        let c0 = self.sound_speed_factor * u;
        Physics {
            kernel: self.kernel,
            beta: self.beta,
            eta2: self.eta2,
            density: self.density,
            viscosity: self.viscosity,
            precision: self.precision,
            math: self.math,
            regularise: self.regularise,
            shift_coefficient: self.shift_coefficient,
            density_diffusion: self.density_diffusion,
            alpha: self.alpha,
            eos: self.eos,
            tension_cutoff: self.tension_cutoff,
            energy_budget: self.energy_budget,
            adaptive_dt: self.adaptive_dt,
            gravity_ramp: self.gravity_ramp.unwrap_or(0.0),
            sound_speed: c0,
            background_pressure: self.background_pressure * rho0 * c0 * c0,
            dt_factor: self.dt_factor,
            wall_pressure: self.wall_pressure,
            wall_boundary: self.wall_boundary,
            pressure_gradient: self.pressure_gradient,
        }
    }

    /// The consistent operators: kernel-gradient-corrected continuity
    /// density and the consistent Laplacian (the defaults of every built-in
    /// case; docs/validation.md measures them against summation density
    /// and the Morris operator case by case).
    pub fn consistent(mut self) -> Self {
        self.density = DensityMode::Corrected;
        self.viscosity = ViscosityForm::Corrected;
        self
    }

    /// The monitor of these settings.
    pub fn monitor(&self) -> Monitor {
        Monitor {
            min_spacing: self.monitor_min_spacing,
            max_density_deviation: self.monitor_max_density_deviation,
            max_mach: self.monitor_max_mach,
            ..Monitor::default()
        }
    }
}

fn one_line(e: &toml::de::Error) -> String {
    e.to_string()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// Builds the scene of validated settings.
///
/// # Errors
/// As [`Settings::validate`] and the case's builder.
pub fn scene(settings: &Settings) -> Result<Scene> {
    settings.validate()?;
    (find(&settings.case)?.build)(settings)
}

/// The error for a 2D-only case asked for in 3D.
pub(crate) fn only_2d(s: &Settings) -> Result<()> {
    check(
        s.dim == 2,
        "dim",
        s.dim,
        &format!(
            "{} is a 2D case (couette and poiseuille also run in 3D)",
            s.case
        ),
    )
}

/// Velocity along x against height at (up to six) output times, SPH rows as
/// markers and the exact solution as lines: the channel cases' figure.
pub(crate) fn channel_figure(scene: &Scene, record: &RunRecord) -> Result<Vec<u8>> {
    let u = record.velocity_scale;
    let h = scene.extent[1];
    let y0 = scene.origin[1];
    // Up to six frames spread over the run, the first and the last included.
    let n = record.frames.len();
    let mut picks: Vec<usize> = (0..6).map(|k| k * n.saturating_sub(1) / 5).collect();
    picks.dedup();
    let mut series = Vec::new();
    for (k, f) in picks
        .iter()
        .filter_map(|&i| record.frames.get(i))
        .enumerate()
    {
        if let Some(exact) = &scene.exact {
            series.push(Series {
                label: format!("exact, t = {:.3} s", f.t),
                points: (0..=100)
                    .map(|i| {
                        let y = y0 + h * i as f64 / 100.0;
                        (y, exact([0.0, y, 0.0], f.t)[0] / u)
                    })
                    .collect(),
                color: k,
                line: true,
                markers: false,
            });
        }
        series.push(Series {
            label: format!("SPH, t = {:.3} s", f.t),
            points: f
                .x
                .iter()
                .zip(&f.v)
                .map(|(x, v)| (x[1], v[0] / u))
                .collect(),
            color: k,
            line: false,
            markers: true,
        });
    }
    line_plot(
        &Axes {
            title: format!("{}: u / U across the channel", record.case),
            x: "y [m]".into(),
            y: "u / U".into(),
            log_x: false,
            log_y: false,
        },
        &series,
    )
}

/// The reference of pressure probes `(depth, sph, exact)` (already in the
/// case's pressure unit): the largest absolute difference and every point.
pub(crate) fn probes_reference(
    source: &str,
    quantity: &'static str,
    t: f64,
    probes: Vec<(f64, f64, f64)>,
) -> Reference {
    Reference {
        source: source.into(),
        t,
        max_deviation: probes
            .iter()
            .map(|(_, sph, exact)| (sph - exact).abs())
            .fold(0.0, f64::max),
        points: probes
            .into_iter()
            .map(|(at, sph, reference)| ReferencePoint {
                quantity,
                at,
                reference,
                sph,
            })
            .collect(),
    }
}

/// A field's value at `point` from the particles of `frame` within
/// `radius` of it: the least-squares plane `a + b . (x - point)` through
/// their values (`value` picks the field), evaluated at the point. Exact
/// for a linear field whichever particles the radius happens to include,
/// where a plain mean is biased by an uneven inclusion (a lattice that has
/// settled by a fraction of `dx` gains or loses a row on one side). `None`
/// with fewer particles than the plane needs or a degenerate arrangement.
pub fn probe_linear(
    frame: &crate::scene::Frame,
    dim: usize,
    point: [f64; 3],
    radius: f64,
    value: impl Fn(usize) -> f64,
) -> Option<f64> {
    let n = dim + 1;
    // Normal equations of the fit, unknowns (a, b_0 .. b_dim).
    let mut m = [[0.0f64; 5]; 4];
    let mut count = 0;
    for (k, x) in frame.x.iter().enumerate() {
        // The basis (1, x - point), the offset in its tail.
        let mut basis = [1.0f64; 4];
        for a in 0..dim {
            basis[a + 1] = x[a] - point[a];
        }
        if basis[1..n].iter().map(|c| c * c).sum::<f64>().sqrt() > radius {
            continue;
        }
        count += 1;
        let v = value(k);
        for r in 0..n {
            for c in 0..n {
                m[r][c] += basis[r] * basis[c];
            }
            m[r][n] += basis[r] * v;
        }
    }
    if count < n + 1 {
        return None;
    }
    // Gaussian elimination with partial pivoting on the (n x n+1) system.
    for col in 0..n {
        let pivot = (col..n).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))?;
        m.swap(col, pivot);
        if m[col][col].abs() < 1e-12 * m[0][0] {
            return None;
        }
        let pivot_row = m[col];
        for row in m.iter_mut().take(n).skip(col + 1) {
            let factor = row[col] / pivot_row[col];
            for (x, p) in row.iter_mut().zip(pivot_row.iter()).take(n + 1).skip(col) {
                *x -= factor * p;
            }
        }
    }
    let mut x = [0.0f64; 4];
    for r in (0..n).rev() {
        let tail: f64 = (r + 1..n).map(|c| m[r][c] * x[c]).sum();
        x[r] = (m[r][n] - tail) / m[r][r];
    }
    x[0].is_finite().then_some(x[0])
}
