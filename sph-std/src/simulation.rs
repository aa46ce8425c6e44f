//! A scene stepped by its caller, for code that embeds `sph` (the C ABI and
//! the Python package build on this).
//!
//! [`crate::scene::run`] runs a scene from start to end in one call. A
//! [`Simulation`] holds the same run between calls: [`Simulation::advance`]
//! takes a number of steps and pauses, and between calls the caller reads
//! the fluid's fields and may overwrite them. Stepping in pieces gives bit
//! for bit the run made in one call (the pause is a checkpoint, and a
//! checkpoint's continuation is bitwise the run that never stopped); a
//! write re-evaluates the state (ghosts, lists, density, rates) before the
//! next step.
//!
//! ```no_run
//! use sph_std::cases::Settings;
//! use sph_std::simulation::{Field, Simulation};
//!
//! let settings = Settings::from_toml("case = \"couette\"\nresolution = 20\nt_end = 0.1")?;
//! let mut sim = Simulation::from_settings(&settings)?;
//! while !sim.ended() {
//!     sim.advance(100)?;
//! }
//! let mut v = vec![0.0; sim.len(Field::Velocity)];
//! sim.read(Field::Velocity, &mut v)?;
//! println!("t = {}: error {:?}", sim.time(), sim.diagnostics().last().and_then(|d| d.linf));
//! # Ok::<(), sph_std::error::Error>(())
//! ```
//!
//! Each call to [`Simulation::advance`] rebuilds the run's storage from the
//! paused state and copies it out again. Measured from Python on the
//! Taylor-Green case at 1,024 and 4,096 particles, one thread, with other
//! work on the machine: 0.1 to 2.6 ms a call against 1.8 to 10.6 ms a step
//! (0.01 to 0.7 of a step). Advance by several steps at a time where speed
//! matters.

use crate::cases::{self, Settings};
use crate::checkpoint::Checkpoint;
use crate::config::{CouetteConfig, DensityMode, Precision};
use crate::couette::Silent;
use crate::error::{Error, Result};
use crate::scene::{self, AxisSpec, Diagnostics, Frame, RunControl, RunRecord, Scene};

/// A particle field that a [`Simulation`] reads or writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// Positions in m (global coordinates), `dim` values per particle.
    Position,
    /// Velocities in m/s, `dim` values per particle.
    Velocity,
    /// Densities in kg/m^3, one value per particle.
    Density,
    /// Pressures in Pa, one value per particle (read only: the equation of
    /// state gives them from the density).
    Pressure,
}

impl Field {
    /// The field's name, as errors and the other languages' bindings spell it.
    pub fn name(self) -> &'static str {
        match self {
            Field::Position => "position",
            Field::Velocity => "velocity",
            Field::Density => "density",
            Field::Pressure => "pressure",
        }
    }

    /// Values per particle in `dim` dimensions.
    pub fn components(self, dim: usize) -> usize {
        match self {
            Field::Position | Field::Velocity => dim,
            Field::Density | Field::Pressure => 1,
        }
    }
}

/// A scene's run, paused between calls (see the module docs).
pub struct Simulation {
    scene: Scene,
    /// The resumable state where the run paused.
    checkpoint: Box<Checkpoint>,
    /// The fluid's fields where the run paused.
    state: Frame,
    /// The run's record so far (outputs, limits, steps; its checkpoint and
    /// state moved out to the fields above).
    record: RunRecord,
    /// Fields were written since the last pause.
    changed: bool,
    /// The run reached its end time or a steady state.
    ended: bool,
    /// The run reached a steady state.
    steady: bool,
}

impl Simulation {
    /// Builds a scene's run and pauses it before the first step.
    ///
    /// # Errors
    /// As [`scene::run`]: [`Error::Config`] for a scene that cannot be
    /// built, [`Error::Core`] if the core refuses it.
    pub fn new(scene: Scene) -> Result<Self> {
        let record = pause(&scene, None, false, 0)?;
        Self::paused(scene, record, false)
    }

    /// The run of a built-in case's settings ([`Settings::from_toml`] reads
    /// them from a scene file's text).
    ///
    /// # Errors
    /// As [`cases::scene`] and [`Self::new`].
    pub fn from_settings(settings: &Settings) -> Result<Self> {
        Self::new(cases::scene(settings)?)
    }

    /// The run of `sph couette` with its configuration (the defaults'
    /// output times clipped to its end time, as the command does).
    ///
    /// # Errors
    /// As [`CouetteConfig::validate`] and [`Self::new`].
    pub fn couette(config: &CouetteConfig) -> Result<Self> {
        let mut config = config.clone();
        config.clip_default_output_times();
        config.validate()?;
        Self::new(crate::couette::scene(&config))
    }

    fn paused(scene: Scene, record: RunRecord, steady: bool) -> Result<Self> {
        let (checkpoint, state, record, ended, steady) = Self::pause_parts(&scene, record, steady)?;
        Ok(Self {
            scene,
            checkpoint,
            state,
            record,
            changed: false,
            ended,
            steady,
        })
    }

    /// A record's pause: its checkpoint and state moved out, whether the
    /// run ended, whether it is steady.
    #[allow(clippy::type_complexity)]
    fn pause_parts(
        scene: &Scene,
        mut record: RunRecord,
        steady: bool,
    ) -> Result<(Box<Checkpoint>, Frame, RunRecord, bool, bool)> {
        if let Some(stop) = &record.stop {
            return Err(Error::Diverged(stop.reason.clone()));
        }
        let (Some(checkpoint), Some(state)) = (record.checkpoint.take(), record.state.take())
        else {
            return Err(Error::Diverged(
                "the run ended without a state to pause at".into(),
            ));
        };
        let ended = checkpoint.interval >= scene.output_times.len();
        let steady = steady || record.steady;
        Ok((checkpoint, state, record, ended, steady))
    }

    /// Takes up to `steps` time steps (fewer where the run reaches its end
    /// time or a steady state first) and pauses; returns the steps taken.
    /// Output times on the way append to [`Self::diagnostics`].
    ///
    /// # Errors
    /// [`Error::Diverged`] where the run diverged or tripped its monitor
    /// (the simulation then stays at its last pause); as [`Self::new`].
    pub fn advance(&mut self, steps: u64) -> Result<u64> {
        let before = self.steps();
        if self.ended || steps == 0 {
            return Ok(0);
        }
        let record = pause(&self.scene, Some(&self.checkpoint), self.changed, steps)?;
        let (checkpoint, state, record, ended, steady) =
            Self::pause_parts(&self.scene, record, self.steady)?;
        self.checkpoint = checkpoint;
        self.state = state;
        self.record = record;
        self.changed = false;
        self.ended = ended;
        self.steady = steady;
        Ok(self.steps() - before)
    }

    /// Runs to the end time (or a steady state); returns the steps taken.
    ///
    /// # Errors
    /// As [`Self::advance`].
    pub fn run_to_end(&mut self) -> Result<u64> {
        self.advance(u64::MAX)
    }

    /// The scene being run.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Simulated time in seconds.
    pub fn time(&self) -> f64 {
        self.checkpoint.state.time
    }

    /// Steps taken since the start.
    pub fn steps(&self) -> u64 {
        self.checkpoint.state.steps
    }

    /// The last output time: where the run ends.
    pub fn end_time(&self) -> f64 {
        self.scene.output_times.last().copied().unwrap_or(0.0)
    }

    /// The run reached its end time or a steady state: [`Self::advance`]
    /// takes no more steps.
    pub fn ended(&self) -> bool {
        self.ended
    }

    /// The run stopped early at a steady state.
    pub fn steady(&self) -> bool {
        self.steady
    }

    /// Spatial dimension (2 or 3).
    pub fn dim(&self) -> usize {
        self.scene.dim
    }

    /// Fluid particles.
    pub fn particles(&self) -> usize {
        self.record.n_fluid
    }

    /// Values a buffer for `field` holds: particles times components.
    pub fn len(&self, field: Field) -> usize {
        self.particles() * field.components(self.dim())
    }

    /// The fixed time step (with an adaptive step: the estimate made at the
    /// start) in seconds.
    pub fn dt(&self) -> f64 {
        self.record.dt
    }

    /// Time-step limits at the start, `[acoustic, viscous, body force]`, in
    /// seconds.
    pub fn limits(&self) -> [f64; 3] {
        self.record.limits
    }

    /// Diagnostics at every output time reached so far.
    pub fn diagnostics(&self) -> &[Diagnostics] {
        &self.record.outputs
    }

    /// The run's record so far, as [`scene::run`] returns it at the end.
    pub fn record(&self) -> &RunRecord {
        &self.record
    }

    /// The fluid's fields where the run paused.
    pub fn state(&self) -> &Frame {
        &self.state
    }

    /// Copies a field into `out`, particle by particle (vectors as `dim`
    /// consecutive components), in particle id order.
    ///
    /// # Errors
    /// [`Error::Config`] (key `buffer`) if `out` does not hold exactly
    /// [`Self::len`] values.
    pub fn read(&self, field: Field, out: &mut [f64]) -> Result<()> {
        self.check_len(field, out.len())?;
        let d = field.components(self.dim());
        for (i, chunk) in out.chunks_exact_mut(d).enumerate() {
            match field {
                Field::Position => chunk.copy_from_slice(&self.state.x[i][..d]),
                Field::Velocity => chunk.copy_from_slice(&self.state.v[i][..d]),
                Field::Density => chunk[0] = self.state.rho[i],
                Field::Pressure => chunk[0] = self.state.p[i],
            }
        }
        Ok(())
    }

    /// Overwrites a field from `values` (the layout of [`Self::read`]); the
    /// next [`Self::advance`] re-evaluates the state from it. Values are
    /// rounded to the run's precision.
    ///
    /// # Errors
    /// [`Error::Config`] naming the field and the rule, with nothing
    /// changed: a buffer of the wrong length, a value that is not finite, a
    /// position outside the box across a walled axis, a density that is not
    /// positive, a density with summation density (it follows from the
    /// positions), or the pressure (it follows from the density).
    pub fn write(&mut self, field: Field, values: &[f64]) -> Result<()> {
        self.check_len(field, values.len())?;
        let d = field.components(self.dim());
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            return Err(Error::config(
                field.name(),
                values[k],
                format!("particle {} holds a value that is not finite", k / d),
            ));
        }
        let round = |v: f64| match self.scene.physics.precision {
            Precision::F64 => v,
            Precision::F32 => f64::from(v as f32),
        };
        let origin = self.scene.origin;
        match field {
            Field::Pressure => {
                return Err(Error::config(
                    "pressure",
                    "(write)",
                    "is read only: the equation of state gives it from the density",
                ))
            }
            Field::Density if self.scene.physics.density == DensityMode::Summation => {
                return Err(Error::config(
                    "density",
                    "(write)",
                    "follows from the positions with density = \"summation\": write positions, or run with continuity density",
                ))
            }
            Field::Density => {
                if let Some(k) = values.iter().position(|&v| v <= 0.0) {
                    return Err(Error::config(
                        "density",
                        values[k],
                        format!("particle {k}: a density must be positive"),
                    ));
                }
            }
            Field::Position => {
                for (i, x) in values.chunks_exact(d).enumerate() {
                    for (a, &c) in x.iter().enumerate() {
                        let (lo, hi) = (origin[a], origin[a] + self.scene.extent[a]);
                        let walled = matches!(self.scene.axes[a], AxisSpec::Walls(..));
                        if walled && !(lo..=hi).contains(&c) {
                            return Err(Error::config(
                                "position",
                                c,
                                format!(
                                    "particle {i}: along axis {a} a position must lie between the walls at {lo} and {hi}"
                                ),
                            ));
                        }
                    }
                }
            }
            Field::Velocity => {}
        }
        // Storage slot order is particle id order; the fluid comes first.
        let slot = match field {
            Field::Position => 0,
            Field::Velocity => 1,
            Field::Density => 3,
            Field::Pressure => 4,
        };
        let stored = &mut self.checkpoint.arrays.reals[slot][..values.len()];
        for (k, (s, &v)) in stored.iter_mut().zip(values).enumerate() {
            let local = if field == Field::Position {
                v - origin[k % d]
            } else {
                v
            };
            *s = round(local);
        }
        for (i, chunk) in values.chunks_exact(d).enumerate() {
            for (a, &v) in chunk.iter().enumerate() {
                let v = if field == Field::Position {
                    round(v - origin[a]) + origin[a]
                } else {
                    round(v)
                };
                match field {
                    Field::Position => self.state.x[i][a] = v,
                    Field::Velocity => self.state.v[i][a] = v,
                    _ => self.state.rho[i] = v,
                }
            }
        }
        self.changed = true;
        Ok(())
    }

    fn check_len(&self, field: Field, len: usize) -> Result<()> {
        let want = self.len(field);
        if len != want {
            return Err(Error::config(
                "buffer",
                len,
                format!(
                    "a {} buffer holds {want} values ({} particles x {} components)",
                    field.name(),
                    self.particles(),
                    field.components(self.dim())
                ),
            ));
        }
        Ok(())
    }
}

/// Runs `scene` (from `resume` where given) for at most `steps` steps and
/// pauses.
fn pause(
    scene: &Scene,
    resume: Option<&Checkpoint>,
    refresh: bool,
    steps: u64,
) -> Result<RunRecord> {
    let mut none = |_: &RunRecord, _: &Checkpoint| Ok(());
    let mut ctl = RunControl::new(&Silent, &mut none);
    ctl.resume = resume;
    ctl.refresh = refresh;
    ctl.pause_after = Some(steps);
    scene::run_with(scene, &mut ctl)
}
