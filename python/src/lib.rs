//! The Python module `sph`: a scene's run created from a built-in case or a
//! scene file's text, stepped, and read and written as numpy arrays.
//!
//! ```python
//! import sph
//! sim = sph.Simulation("case = 'couette'\nresolution = 20\nt_end = 0.1")
//! sim.run_to_end()
//! print(sim.time, sim.diagnostics()[-1]["linf"], sim.velocities.shape)
//! ```
//!
//! Errors are exceptions carrying the messages of the `sph` command line:
//! `sph.ConfigError` (a value breaks a rule), `sph.CoreError` (the core
//! refused the scene), `sph.DivergedError` (the run diverged or tripped its
//! monitor), all subclasses of `sph.SphError`, and `OSError` for files.

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyOSError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sph_std::cases::{self, Settings};
use sph_std::config::CouetteConfig;
use sph_std::error::Error;
use sph_std::simulation::{Field, Simulation as Run};

create_exception!(sph, SphError, PyException, "Every error of sph.");
create_exception!(
    sph,
    ConfigError,
    SphError,
    "A configuration value or an argument breaks a rule."
);
create_exception!(sph, CoreError, SphError, "The core refused the scene.");
create_exception!(
    sph,
    DivergedError,
    SphError,
    "The run diverged or tripped its monitor."
);

fn to_py(e: Error) -> PyErr {
    let message = e.to_string();
    match e {
        Error::Config { .. } => ConfigError::new_err(message),
        Error::Io { .. } => PyOSError::new_err(message),
        Error::Core(sph_std::sph_core::error::Error::Unstable { .. })
        | Error::Diverged(_)
        | Error::Stopped(_) => DivergedError::new_err(message),
        Error::Core(_) => CoreError::new_err(message),
    }
}

/// A scene's run, paused between calls.
///
/// `Simulation(scene)` takes a built-in case's name ("couette", with its
/// defaults; `sph.cases()` lists them) or the text of a scene file (TOML
/// naming its case, as in the repository's examples/*.toml).
/// `Simulation.couette(config)` runs `sph couette` from the text of its
/// configuration file ("" for the defaults). The run starts paused before
/// its first step; `advance(n)` steps it, and stepping in pieces gives bit
/// for bit the run made in one piece. Each call also copies the run's
/// storage in and out (under one step's cost at 10^3 to 10^4 particles):
/// advance by several steps at a time where speed matters.
#[pyclass(module = "sph")]
struct Simulation {
    run: Run,
}

impl Simulation {
    fn field<'py>(&self, py: Python<'py>, field: Field) -> PyResult<Bound<'py, PyAny>> {
        let n = self.run.particles();
        let d = field.components(self.run.dim());
        let mut values = vec![0.0; n * d];
        self.run.read(field, &mut values).map_err(to_py)?;
        // The vector moves into numpy without a copy.
        let flat = PyArray1::from_vec(py, values);
        if d == 1 {
            Ok(flat.into_any())
        } else {
            Ok(flat.reshape([n, d])?.into_any())
        }
    }

    fn set(&mut self, field: Field, values: PyReadonlyArrayDyn<'_, f64>) -> PyResult<()> {
        let n = self.run.particles();
        let d = field.components(self.run.dim());
        let shape = values.shape();
        let expected: &[usize] = if d == 1 { &[n] } else { &[n, d] };
        if shape != expected {
            return Err(to_py(Error::config(
                field.name(),
                format!("an array of shape {shape:?}"),
                format!("needs shape {expected:?} ({n} particles x {d} components)"),
            )));
        }
        let owned;
        let slice = match values.as_slice() {
            Ok(s) => s,
            Err(_) => {
                // A strided view: one copy, in C order.
                owned = values.as_array().iter().copied().collect::<Vec<f64>>();
                &owned
            }
        };
        self.run.write(field, slice).map_err(to_py)
    }
}

#[pymethods]
impl Simulation {
    #[new]
    fn new(py: Python<'_>, scene: &str) -> PyResult<Self> {
        let name = scene.trim();
        let settings = if cases::CASES.iter().any(|c| c.name == name) {
            cases::find(name).map(|c| (c.defaults)())
        } else {
            Settings::from_toml(scene)
        }
        .map_err(to_py)?;
        let run = py.detach(|| Run::from_settings(&settings)).map_err(to_py)?;
        Ok(Self { run })
    }

    /// The run of `sph couette` (plates at y = -L and y = L) from the text
    /// of its configuration file ("" for the defaults).
    #[staticmethod]
    #[pyo3(signature = (config = ""))]
    fn couette(py: Python<'_>, config: &str) -> PyResult<Self> {
        let config = CouetteConfig::from_toml(config).map_err(to_py)?;
        let run = py.detach(|| Run::couette(&config)).map_err(to_py)?;
        Ok(Self { run })
    }

    /// Takes up to `steps` time steps (fewer where the run reaches its end
    /// time or a steady state) and returns how many it took. The GIL is
    /// released while it runs.
    fn advance(&mut self, py: Python<'_>, steps: u64) -> PyResult<u64> {
        let run = &mut self.run;
        py.detach(|| run.advance(steps)).map_err(to_py)
    }

    /// Runs to the end time (or a steady state); returns the steps taken.
    fn run_to_end(&mut self, py: Python<'_>) -> PyResult<u64> {
        self.advance(py, u64::MAX)
    }

    /// Simulated time in s.
    #[getter]
    fn time(&self) -> f64 {
        self.run.time()
    }

    /// The end time in s.
    #[getter]
    fn end_time(&self) -> f64 {
        self.run.end_time()
    }

    /// Steps taken since the start.
    #[getter]
    fn steps(&self) -> u64 {
        self.run.steps()
    }

    /// True once the run reached its end time or a steady state.
    #[getter]
    fn ended(&self) -> bool {
        self.run.ended()
    }

    /// Spatial dimension, 2 or 3.
    #[getter]
    fn dim(&self) -> usize {
        self.run.dim()
    }

    /// Fluid particles.
    #[getter]
    fn particles(&self) -> usize {
        self.run.particles()
    }

    /// The time step in s (with an adaptive step, the starting estimate).
    #[getter]
    fn dt(&self) -> f64 {
        self.run.dt()
    }

    /// Time-step limits at the start (acoustic, viscous, body force) in s.
    #[getter]
    fn limits(&self) -> (f64, f64, f64) {
        let [a, b, c] = self.run.limits();
        (a, b, c)
    }

    /// The case's name.
    #[getter]
    fn case(&self) -> String {
        self.run.scene().case.clone()
    }

    /// The velocity scale the errors are relative to, in m/s.
    #[getter]
    fn velocity_scale(&self) -> f64 {
        self.run.record().velocity_scale
    }

    /// Kinematic viscosity in m^2/s.
    #[getter]
    fn nu(&self) -> f64 {
        self.run.record().nu
    }

    /// Positions in m, shape (particles, dim), in particle id order.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.field(py, Field::Position)
    }

    #[setter]
    fn set_positions(&mut self, values: PyReadonlyArrayDyn<'_, f64>) -> PyResult<()> {
        self.set(Field::Position, values)
    }

    /// Velocities in m/s, shape (particles, dim).
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.field(py, Field::Velocity)
    }

    #[setter]
    fn set_velocities(&mut self, values: PyReadonlyArrayDyn<'_, f64>) -> PyResult<()> {
        self.set(Field::Velocity, values)
    }

    /// Densities in kg/m^3, shape (particles,).
    #[getter]
    fn density<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.field(py, Field::Density)
    }

    #[setter]
    fn set_density(&mut self, values: PyReadonlyArrayDyn<'_, f64>) -> PyResult<()> {
        self.set(Field::Density, values)
    }

    /// Pressures in Pa, shape (particles,) (read only: the equation of
    /// state gives them from the density).
    #[getter]
    fn pressure<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.field(py, Field::Pressure)
    }

    /// Diagnostics at every output time reached: a list of dicts with `t`,
    /// `kinetic_energy`, `min_spacing`, `max_density_deviation`,
    /// `max_mach`, and `linf` and `l2` (errors against the exact solution
    /// over the velocity scale, None without one).
    fn diagnostics<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.run
            .diagnostics()
            .iter()
            .map(|d| {
                let dict = PyDict::new(py);
                dict.set_item("t", d.t)?;
                dict.set_item("kinetic_energy", d.kinetic_energy)?;
                dict.set_item("min_spacing", d.min_spacing)?;
                dict.set_item("max_density_deviation", d.max_density_deviation)?;
                dict.set_item("max_mach", d.max_mach)?;
                dict.set_item("linf", d.linf)?;
                dict.set_item("l2", d.l2)?;
                Ok(dict)
            })
            .collect()
    }

    fn __repr__(&self) -> String {
        format!(
            "sph.Simulation({}, {}D, {} particles, t = {:.6e} s of {:.6e} s, {} steps)",
            self.run.scene().case,
            self.run.dim(),
            self.run.particles(),
            self.run.time(),
            self.run.end_time(),
            self.run.steps()
        )
    }
}

/// The built-in cases' names.
#[pyfunction(name = "cases")]
fn case_names() -> Vec<&'static str> {
    cases::CASES.iter().map(|c| c.name).collect()
}

/// Smoothed particle hydrodynamics: sph's scenes from Python.
#[pymodule]
fn sph(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<Simulation>()?;
    m.add_function(wrap_pyfunction!(case_names, m)?)?;
    m.add("SphError", m.py().get_type::<SphError>())?;
    m.add("ConfigError", m.py().get_type::<ConfigError>())?;
    m.add("CoreError", m.py().get_type::<CoreError>())?;
    m.add("DivergedError", m.py().get_type::<DivergedError>())?;
    Ok(())
}
