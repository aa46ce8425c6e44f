//! Configuration of the Couette validation case: serde types read from TOML,
//! with defaults and validation that names the key, the value and the rule.
//!
//! Every CLI flag of `sph couette` has a key here with the same words
//! (`--particles-across` is `particles_across`). `examples/couette.toml`
//! documents them all.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

macro_rules! named_enum {
    ($(#[$doc:meta])* $name:ident { $($(#[$vdoc:meta])* $variant:ident => $text:literal),+ $(,)? }) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
        pub enum $name {
            $($(#[$vdoc])* #[serde(rename = $text)] $variant),+
        }

        impl $name {
            /// Every value, in documentation order.
            pub const ALL: &'static [$name] = &[$($name::$variant),+];

            /// The name used in configs and on the command line.
            pub fn name(self) -> &'static str {
                match self {
                    $($name::$variant => $text),+
                }
            }

            /// The accepted names, comma separated.
            pub fn names() -> String {
                Self::ALL.iter().map(|v| v.name()).collect::<Vec<_>>().join(", ")
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.name())
            }
        }

        impl FromStr for $name {
            type Err = String;
            fn from_str(s: &str) -> std::result::Result<Self, String> {
                Self::ALL
                    .iter()
                    .copied()
                    .find(|v| v.name() == s)
                    .ok_or_else(|| format!("expected one of {}", Self::names()))
            }
        }
    };
}

named_enum!(
    /// Smoothing kernel.
    KernelName {
        /// Cubic B-spline, support 2h.
        Cubic => "cubic",
        /// Quintic B-spline, support 3h.
        Quintic => "quintic",
        /// Wendland C2, support 2h.
        WendlandC2 => "wendland-c2",
        /// Wendland C4, support 2h.
        WendlandC4 => "wendland-c4",
        /// Gaussian truncated at 3h.
        Gaussian => "gaussian",
    }
);

impl KernelName {
    /// Support radius in units of `h`.
    pub fn support(self) -> f64 {
        match self {
            KernelName::Quintic | KernelName::Gaussian => 3.0,
            _ => 2.0,
        }
    }
}

named_enum!(
    /// Viscous term.
    ViscosityForm {
        /// Morris, Fox & Zhu (1997) laminar viscosity.
        Morris => "morris",
        /// The poster's slot corrected (Monaghan-Cleary, factor d+2).
        Pi => "pi",
        /// Monaghan's artificial viscosity, alpha matched to nu.
        Artificial => "artificial",
        /// A consistent Laplacian: exact for quadratic fields on any
        /// arrangement (`sph_core::terms::CorrectedMorrisViscosity`).
        Corrected => "corrected",
    }
);

named_enum!(
    /// How density is obtained.
    DensityMode {
        /// `rho_i = sum_j m_j W_ij`, ghosts included.
        Summation => "summation",
        /// The continuity equation (the poster's choice).
        Continuity => "continuity",
        /// The continuity equation with a kernel-gradient-corrected
        /// divergence, exact for linear velocity fields on any arrangement
        /// (`sph_core::terms::AnyContinuity::Corrected`).
        Corrected => "corrected",
    }
);

named_enum!(
    /// The pressure-gradient form.
    PressureForm {
        /// `-sum_j m_j (p_i / rho_i^2 + p_j / rho_j^2) grad W_ij`:
        /// conserves momentum exactly (`sph_core::terms::PressureGradient`).
        Symmetric => "symmetric",
        /// The kernel-gradient-corrected difference form, exact for linear
        /// pressure fields on any arrangement; continuity density only
        /// (`sph_core::terms::AnyPressure::Corrected`).
        Corrected => "corrected",
    }
);

named_enum!(
    /// What the wall ghosts' pressure balances.
    WallPressure {
        /// Each ghost copies its source's pressure (zero normal gradient):
        /// exact where nothing pushes on the wall, as in the channel cases.
        Mirror => "mirror",
        /// The ghost's pressure adds the scene's body force over the depth
        /// between source and ghost, `p_g = p_f + rho_f g . (r_g - r_f)_n`
        /// (`sph_core::domain::Domain::with_wall_gravity`), so that a tank
        /// under gravity stays at rest. The same as `mirror` without a body
        /// force or with one along the walls.
        Hydrostatic => "hydrostatic",
    }
);

named_enum!(
    /// How the walls (the box's planar walls and the shaped ones) act on
    /// the fluid.
    WallBoundary {
        /// Mirrored ghosts: each fluid particle near a wall has an image
        /// behind it (`docs/physics.md` 5.1, 5.5); exact for planar walls on
        /// an aligned lattice, the channel cases' choice. A shaped wall
        /// images each particle once, through its closest point.
        Mirror => "mirror",
        /// Fixed wall particles behind the walls with values from the
        /// fluid near them (Adami, Hu & Adams 2012; `docs/physics.md`
        /// 5.3): their repulsion does not vanish as a particle reaches the
        /// wall, which a free-surface flow driven at a wall needs, and
        /// they fill the concave corners of shaped walls.
        Particles => "particles",
    }
);

named_enum!(
    /// The equation of state of the scenes (`sph_core::eos::Eos`).
    EosForm {
        /// `p = c0^2 (rho - rho0) + p_b`: the channel and vortex flows.
        Linear => "linear",
        /// Tait, `p = B ((rho / rho0)^7 - 1) + p_b`, `B = rho0 c0^2 / 7`:
        /// stiff in compression, soft in tension, the usual choice for
        /// free-surface water.
        Tait => "tait",
    }
);

named_enum!(
    /// Floating-point precision of the whole computation.
    Precision {
        /// Single precision.
        F32 => "f32",
        /// Double precision.
        F64 => "f64",
    }
);

named_enum!(
    /// Math backend for square roots and exponentials.
    MathBackend {
        /// libm's functions, both precisions, with the square root from the
        /// compiler (`sph_std::math::Host`: the same bits, without libm's
        /// inline assembly).
        Libm => "libm",
        /// micromath's fast approximations (f32 only).
        Micromath => "micromath",
    }
);

/// Largest allowed `dt_factor`. The viscous limit is `1 / lambda_max`, the
/// exact stability bound of the integrator, with `lambda_max` estimated by
/// power iteration, which converges from below (0.5 % low at 16 and 40
/// across; a run at 160 across and factor 1.0 diverged): 0.9 keeps a margin
/// the tests verify.
pub const MAX_DT_FACTOR: f64 = 0.9;

fn default_output_times() -> Vec<f64> {
    vec![0.0225, 0.045, 0.1125, 0.225, 1.0]
}

/// The Couette case. Defaults follow Morris, Fox & Zhu (1997): gap 1 mm,
/// `nu = 1e-6 m^2/s`, `rho0 = 1000 kg/m^3`, `U = 1.25e-5 m/s` (Re = 0.0125).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CouetteConfig {
    /// Fluid particles across the gap (dx = gap / particles_across).
    pub particles_across: usize,
    /// Overlap factor `beta = h / dx`.
    pub beta: f64,
    /// Smoothing kernel.
    pub kernel: KernelName,
    /// Viscous term.
    pub viscosity: ViscosityForm,
    /// Density by summation or continuity.
    pub density: DensityMode,
    /// Floating-point precision.
    pub precision: Precision,
    /// Math backend (`micromath` needs `f32`).
    pub math: MathBackend,
    /// Worker threads; 0 means all cores, 1 runs serially without rayon.
    pub threads: usize,
    /// End time in seconds.
    pub t_end: f64,
    /// Time step as a fraction of the smallest stability limit, in (0, 0.9].
    pub dt_factor: f64,
    /// Viscous regulariser `eta^2` as a fraction of `h^2`.
    pub eta2: f64,
    /// Gap between the plates `2L` in metres (plates at `y = -L` and `+L`).
    pub gap: f64,
    /// Kinematic viscosity in m^2/s.
    pub nu: f64,
    /// Reference density in kg/m^3.
    pub rho0: f64,
    /// Speed of the upper plate in m/s.
    pub u_wall: f64,
    /// Sound speed as a multiple of `u_wall` (`c0 = sound_speed_factor * U`).
    pub sound_speed_factor: f64,
    /// Background pressure as a fraction of `rho0 c0^2` (0 to 1). Mirrored
    /// walls hold particles back by pressure alone; where the pressure turns
    /// negative a particle's own ghost attracts it through the wall. A small
    /// background pressure keeps P positive (physics.md 3.5); it is needed
    /// at high Reynolds numbers.
    pub background_pressure: f64,
    /// Artificial-viscosity coefficient; 0 means "match nu":
    /// `alpha = 2 (d + 2) nu / (h c0)`.
    pub alpha: f64,
    /// Width of the periodic strip in kernel support radii (at least 2).
    pub strip_supports: f64,
    /// Moves the whole scene by this many metres along x and y (the plates
    /// sit at `y = shift -+ L`), to check that results do not depend on
    /// where the scene is: positions are stored relative to the domain.
    pub shift: f64,
    /// Output times in seconds (the end time is always added).
    pub output_times: Vec<f64>,
    /// Output directory.
    pub out: PathBuf,
    /// Write VTK particle snapshots (`.vtu`, with a `.pvd` index) for ParaView.
    pub vtk: bool,
    /// Write the VTK snapshots as ASCII text instead of binary.
    pub vtk_ascii: bool,
    /// No progress bar and no table.
    pub quiet: bool,
    /// Run even when it needs more than `sph_std::scene::MAX_STEPS` steps.
    pub allow_long_run: bool,
}

impl Default for CouetteConfig {
    fn default() -> Self {
        Self {
            particles_across: 40,
            beta: 1.3,
            kernel: KernelName::Cubic,
            viscosity: ViscosityForm::Morris,
            density: DensityMode::Summation,
            precision: Precision::F64,
            math: MathBackend::Libm,
            threads: 0,
            t_end: 1.0,
            dt_factor: 0.7,
            eta2: 0.01,
            gap: 1e-3,
            nu: 1e-6,
            rho0: 1000.0,
            u_wall: 1.25e-5,
            sound_speed_factor: 10.0,
            background_pressure: 0.0,
            alpha: 0.0,
            strip_supports: 2.0,
            shift: 0.0,
            output_times: default_output_times(),
            out: PathBuf::from("out/couette"),
            vtk: false,
            vtk_ascii: false,
            quiet: false,
            allow_long_run: false,
        }
    }
}

pub(crate) fn check(ok: bool, key: &str, value: impl fmt::Display, rule: &str) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::config(key, value, rule))
    }
}

impl CouetteConfig {
    /// How the VTK snapshots are encoded.
    pub fn vtk_encoding(&self) -> crate::output::VtkEncoding {
        if self.vtk_ascii {
            crate::output::VtkEncoding::Ascii
        } else {
            crate::output::VtkEncoding::Binary
        }
    }

    /// Reads a TOML file; unknown keys and wrong types are errors naming the
    /// file, line, key and value.
    ///
    /// # Errors
    /// [`Error::Io`] if the file cannot be read, [`Error::Config`] if it does not parse.
    pub fn from_file(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io("read config", path, e))?;
        Self::from_toml(&text).map_err(|e| match e {
            Error::Config { key, value, rule } => Error::Config {
                key: format!("{}: {key}", path.display()),
                value,
                rule,
            },
            other => other,
        })
    }

    /// Parses TOML text (see [`Self::from_file`]).
    ///
    /// # Errors
    /// [`Error::Config`] naming the line and its text.
    pub fn from_toml(text: &str) -> Result<Self> {
        toml::from_str(text).map_err(|e| {
            let (line_no, line) = match e.span() {
                Some(span) => {
                    let start = span.start.min(text.len());
                    let line_no = text[..start].matches('\n').count() + 1;
                    let line = text
                        .lines()
                        .nth(line_no - 1)
                        .unwrap_or("")
                        .trim()
                        .to_string();
                    (line_no, line)
                }
                None => (0, String::new()),
            };
            Error::config(
                format!("line {line_no}"),
                format!("`{line}`"),
                e.message().to_string(),
            )
        })
    }

    /// Checks every value against its documented range.
    ///
    /// # Errors
    /// The first [`Error::Config`] found, naming key, value and rule.
    pub fn validate(&self) -> Result<()> {
        check(
            (4..=4000).contains(&self.particles_across),
            "particles_across",
            self.particles_across,
            "must be between 4 and 4000",
        )?;
        check(
            (1.0..=3.0).contains(&self.beta),
            "beta",
            self.beta,
            "must be between 1.0 and 3.0",
        )?;
        check(
            self.threads <= 1024,
            "threads",
            self.threads,
            "must be at most 1024 (0 means all cores)",
        )?;
        check(
            self.t_end.is_finite() && self.t_end > 0.0,
            "t_end",
            self.t_end,
            "must be positive (seconds)",
        )?;
        check(
            self.dt_factor > 0.0 && self.dt_factor <= MAX_DT_FACTOR,
            "dt_factor",
            self.dt_factor,
            "must be in (0, 0.9]: the viscous limit is the exact stability bound 1/lambda_max with lambda_max estimated from below (within about 1 %)",
        )?;
        check(
            (0.0..=1.0).contains(&self.eta2),
            "eta2",
            self.eta2,
            "must be between 0 and 1 (fraction of h^2)",
        )?;
        check(
            self.gap.is_finite() && self.gap > 0.0,
            "gap",
            self.gap,
            "must be positive (metres)",
        )?;
        check(
            self.shift.is_finite() && self.shift.abs() <= 1e9 * self.gap,
            "shift",
            self.shift,
            "must be finite and at most 1e9 gaps from the origin (further out the plates' positions in f64 keep fewer than 7 digits of the gap)",
        )?;
        check(
            self.nu.is_finite() && self.nu > 0.0,
            "nu",
            self.nu,
            "must be positive (m^2/s)",
        )?;
        check(
            self.rho0.is_finite() && self.rho0 > 0.0,
            "rho0",
            self.rho0,
            "must be positive (kg/m^3)",
        )?;
        check(
            self.u_wall.is_finite() && self.u_wall > 0.0,
            "u_wall",
            self.u_wall,
            "must be positive (m/s)",
        )?;
        check(
            self.sound_speed_factor.is_finite() && self.sound_speed_factor >= 1.0,
            "sound_speed_factor",
            self.sound_speed_factor,
            "must be at least 1 (c0 = factor * u_wall)",
        )?;
        check(
            self.alpha.is_finite() && self.alpha >= 0.0,
            "alpha",
            self.alpha,
            "must be >= 0 (0: match nu)",
        )?;
        check(
            (0.0..=1.0).contains(&self.background_pressure),
            "background_pressure",
            self.background_pressure,
            "must be between 0 and 1 (fraction of rho0 c0^2)",
        )?;
        check(
            self.strip_supports.is_finite() && self.strip_supports >= 2.0,
            "strip_supports",
            self.strip_supports,
            "the periodic strip must be at least two kernel supports wide",
        )?;
        check(
            !(self.math == MathBackend::Micromath && self.precision == Precision::F64),
            "math",
            self.math,
            "micromath implements f32 only: use precision = \"f32\"",
        )?;
        let support_rows = self.kernel.support() * self.beta;
        check(
            (self.particles_across as f64) >= support_rows,
            "particles_across",
            self.particles_across,
            "the gap must be at least one kernel support wide (particles_across >= support * beta)",
        )?;
        check(
            self.output_times.len() <= 10_000,
            "output_times",
            format!("{} times", self.output_times.len()),
            "at most 10000 output times (each keeps a profile of every particle)",
        )?;
        let mut last = 0.0;
        for &t in &self.output_times {
            check(
                t.is_finite() && t > last && t <= self.t_end,
                "output_times",
                t,
                "output times must increase, be positive and not exceed t_end",
            )?;
            last = t;
        }
        Ok(())
    }

    /// Drops the default output times beyond `t_end` when the output times
    /// are the defaults (a shorter run then needs no list of its own);
    /// output times a user chose are left for [`Self::validate`] to check.
    pub fn clip_default_output_times(&mut self) {
        if self.output_times == default_output_times() {
            let t_end = self.t_end;
            self.output_times.retain(|&t| t <= t_end);
        }
    }

    /// The output times with `t_end` appended when missing.
    pub fn schedule(&self) -> Vec<f64> {
        let mut times: Vec<f64> = self
            .output_times
            .iter()
            .copied()
            .filter(|&t| t <= self.t_end)
            .collect();
        if times.last().is_none_or(|&t| t < self.t_end) {
            times.push(self.t_end);
        }
        times
    }

    /// The configuration as TOML, for `config.toml` in the output directory.
    ///
    /// # Errors
    /// Never for a valid config; reported rather than assumed.
    pub fn to_toml(&self) -> Result<String> {
        toml::to_string(self).map_err(|e| Error::config("config", "(serialise)", e.to_string()))
    }

    /// Worker threads to use (resolves 0 to the number of cores).
    pub fn resolved_threads(&self) -> usize {
        crate::driver::resolve_threads(self.threads)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_round_trip() {
        let c = CouetteConfig::default();
        c.validate().unwrap();
        let back = CouetteConfig::from_toml(&c.to_toml().unwrap()).unwrap();
        assert_eq!(back, c);
        assert_eq!(c.schedule(), vec![0.0225, 0.045, 0.1125, 0.225, 1.0]);
    }

    #[test]
    fn errors_name_key_value_and_rule() {
        let e = CouetteConfig::from_toml("beta = 0.5\n")
            .unwrap()
            .validate()
            .unwrap_err()
            .to_string();
        assert_eq!(e, "invalid `beta` = 0.5: must be between 1.0 and 3.0");
        let e = CouetteConfig::from_toml("nu = -1e-6\n")
            .unwrap()
            .validate()
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("`nu`") && e.contains("-0.000001") && e.contains("positive"),
            "{e}"
        );
        let e = CouetteConfig::from_toml("kernel = \"spline\"\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("kernel = \"spline\"") && e.contains("expected one of"),
            "{e}"
        );
        let e = CouetteConfig::from_toml("\nbogus = 1\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 2") && e.contains("unknown field `bogus`"),
            "{e}"
        );
        let c = CouetteConfig {
            math: MathBackend::Micromath,
            ..CouetteConfig::default()
        };
        assert!(c.validate().unwrap_err().to_string().contains("f32"));
        let c = CouetteConfig {
            output_times: vec![0.5, 0.2],
            ..CouetteConfig::default()
        };
        assert!(c
            .validate()
            .unwrap_err()
            .to_string()
            .contains("output_times"));
    }

    #[test]
    fn names_parse_both_ways() {
        for k in KernelName::ALL {
            assert_eq!(k.name().parse::<KernelName>().unwrap(), *k);
        }
        assert!("cubic-spline"
            .parse::<KernelName>()
            .unwrap_err()
            .contains("wendland-c2"));
    }
}
