//! The C ABI of `sph`: a scene's run, created from a built-in case or a
//! scene file's text, stepped, read and written from C, C++ or Fortran.
//!
//! The header is `include/sph.h`, generated from this file by cbindgen (the
//! test `header_is_current` fails when it is stale; `SPH_UPDATE_HEADER=1
//! cargo test -p sph-ffi --test header` rewrites it). `examples/c/couette.c`
//! runs the Couette case through it.
//!
//! # Contract
//! - Every function that can fail returns an [`SphStatus`]; the message of
//!   the last failure on a simulation is [`sph_simulation_error`] (creation
//!   writes its message into a caller buffer, since there is no simulation
//!   yet).
//! - A panic never crosses the boundary: it is caught and returned as
//!   [`SphStatus::Panic`] with its message.
//! - No global state: simulations are independent; one simulation may be
//!   used from one thread at a time.
//! - Buffers belong to the caller; lengths are counts of `double`s.
//! - A null pointer where an object is needed gives [`SphStatus::NullPointer`].
//!
//! `unsafe` is allowed in this crate only, for the raw pointers the C ABI
//! passes; `sph-core` forbids it.

#![allow(unsafe_code)]

use std::ffi::{c_char, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

use sph_std::cases::{self, Settings};
use sph_std::config::CouetteConfig;
use sph_std::error::Error;
use sph_std::simulation::{Field, Simulation};

/// What a call returned: `SPH_STATUS_OK` (0) or the kind of failure.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SphStatus {
    /// Success.
    Ok = 0,
    /// A configuration value or an argument broke a rule.
    Config = 1,
    /// The core refused the scene.
    Core = 2,
    /// The run diverged or tripped its monitor.
    Diverged = 3,
    /// A file could not be read or written.
    Io = 4,
    /// A null pointer where an object or a buffer was needed.
    NullPointer = 5,
    /// Text that is not UTF-8.
    Utf8 = 6,
    /// A panic inside the library, caught at the boundary (a bug: please
    /// report it with the message).
    Panic = 7,
}

/// A particle field (see [`sph_simulation_read`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SphField {
    /// Positions in m, `dim` values per particle.
    Position = 0,
    /// Velocities in m/s, `dim` values per particle.
    Velocity = 1,
    /// Densities in kg/m^3, one value per particle.
    Density = 2,
    /// Pressures in Pa, one value per particle (read only).
    Pressure = 3,
}

impl From<SphField> for Field {
    fn from(f: SphField) -> Self {
        match f {
            SphField::Position => Field::Position,
            SphField::Velocity => Field::Velocity,
            SphField::Density => Field::Density,
            SphField::Pressure => Field::Pressure,
        }
    }
}

/// Diagnostics at one output time. Errors against an exact solution are
/// NaN where the case has none.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphDiagnostics {
    /// Time in s.
    pub t: f64,
    /// `sum 1/2 m |v|^2` over the fluid, in J (per unit depth in 2D).
    pub kinetic_energy: f64,
    /// Closest fluid pair in units of the particle spacing.
    pub min_spacing: f64,
    /// `max |rho / rho0 - 1|`.
    pub max_density_deviation: f64,
    /// `max |v| / c0`.
    pub max_mach: f64,
    /// `max |v - v_exact|` over the error scale (NaN without an exact solution).
    pub linf: f64,
    /// `sqrt(mean |v - v_exact|^2)` over the error scale (NaN without one).
    pub l2: f64,
}

/// A scene's run between calls; opaque to C.
pub struct SphSimulation {
    sim: Simulation,
    /// The last failure's message, NUL-terminated ("" after a success).
    error: CString,
}

fn status_of(e: &Error) -> SphStatus {
    match e {
        Error::Config { .. } => SphStatus::Config,
        Error::Io { .. } => SphStatus::Io,
        Error::Core(sph_std::sph_core::error::Error::Unstable { .. }) => SphStatus::Diverged,
        Error::Core(_) => SphStatus::Core,
        Error::Diverged(_) | Error::Stopped(_) => SphStatus::Diverged,
    }
}

/// A C string without interior NULs (they are replaced).
fn c_string(text: &str) -> CString {
    CString::new(text.replace('\0', " ")).unwrap_or_default()
}

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    let what = payload
        .downcast_ref::<&str>()
        .map(|s| (*s).to_owned())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".into());
    format!("internal error (panic): {what}")
}

/// Runs `body` on a simulation, recording its failure's message there.
fn with_sim(
    sim: *mut SphSimulation,
    body: impl FnOnce(&mut Simulation) -> Result<(), (SphStatus, String)>,
) -> SphStatus {
    // SAFETY: the caller passes a pointer from `sph_simulation_new` that it
    // has not freed, used from one thread at a time (the header's contract).
    let Some(handle) = (unsafe { sim.as_mut() }) else {
        return SphStatus::NullPointer;
    };
    let outcome = catch_unwind(AssertUnwindSafe(|| body(&mut handle.sim)));
    let (status, message) = match outcome {
        Ok(Ok(())) => (SphStatus::Ok, String::new()),
        Ok(Err((status, message))) => (status, message),
        Err(payload) => (SphStatus::Panic, panic_message(&*payload)),
    };
    handle.error = c_string(&message);
    status
}

fn fail(e: Error) -> (SphStatus, String) {
    (status_of(&e), e.to_string())
}

/// The settings of a scene given as a built-in case name or a scene file's
/// text.
fn settings_of(scene: &str) -> Result<Settings, Error> {
    let name = scene.trim();
    if cases::CASES.iter().any(|c| c.name == name) {
        return Ok((cases::find(name)?.defaults)());
    }
    Settings::from_toml(scene)
}

/// Creates a simulation and pauses it before its first step.
///
/// `scene` is a built-in case's name (`"couette"`, with its defaults) or
/// the text of a scene file (TOML naming its case, as in `examples/*.toml`;
/// `threads = 1` keeps the run on the calling thread, 0 uses every core).
/// On success `*out` receives the simulation, to be freed with
/// [`sph_simulation_free`]. On failure `*out` is set to null and, where
/// `message` is not null, the message is written into it (cut to
/// `message_len - 1` bytes, NUL-terminated).
///
/// # Safety
/// `scene` is null or a NUL-terminated string; `out` is null or writable;
/// `message` is null or points to `message_len` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_new(
    scene: *const c_char,
    out: *mut *mut SphSimulation,
    message: *mut c_char,
    message_len: usize,
) -> SphStatus {
    // SAFETY: the same contract.
    unsafe {
        create(scene, out, message, message_len, |text| {
            settings_of(text).and_then(|s| Simulation::from_settings(&s))
        })
    }
}

/// Creates the run of `sph couette` (plates at `y = -L` and `y = L`, the
/// table's and summary.json's errors) from the text of its configuration
/// file (`examples/couette.toml`; "" for the defaults), paused before its
/// first step. Otherwise as [`sph_simulation_new`].
///
/// # Safety
/// As [`sph_simulation_new`].
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_new_couette(
    config: *const c_char,
    out: *mut *mut SphSimulation,
    message: *mut c_char,
    message_len: usize,
) -> SphStatus {
    // SAFETY: the same contract.
    unsafe {
        create(config, out, message, message_len, |text| {
            CouetteConfig::from_toml(text).and_then(|c| Simulation::couette(&c))
        })
    }
}

/// The body of the constructors: checks the pointers, builds the
/// simulation from the text with `build`, reports into `message`.
///
/// # Safety
/// As [`sph_simulation_new`].
unsafe fn create(
    text: *const c_char,
    out: *mut *mut SphSimulation,
    message: *mut c_char,
    message_len: usize,
    build: impl FnOnce(&str) -> Result<Simulation, Error> + std::panic::UnwindSafe,
) -> SphStatus {
    let report = |status: SphStatus, what: &str| {
        if !message.is_null() && message_len > 0 {
            let bytes = what.as_bytes();
            let n = bytes.len().min(message_len - 1);
            // SAFETY: `message` holds `message_len` bytes (the contract).
            unsafe {
                std::ptr::copy_nonoverlapping(bytes.as_ptr(), message.cast::<u8>(), n);
                *message.add(n) = 0;
            }
        }
        status
    };
    if out.is_null() {
        return report(SphStatus::NullPointer, "out is null");
    }
    // SAFETY: `out` is writable (the contract).
    unsafe { *out = std::ptr::null_mut() };
    if text.is_null() {
        return report(SphStatus::NullPointer, "the scene text is null");
    }
    // SAFETY: `text` is NUL-terminated (the contract).
    let Ok(text) = (unsafe { CStr::from_ptr(text) }).to_str() else {
        return report(SphStatus::Utf8, "the scene text is not UTF-8");
    };
    match catch_unwind(|| build(text)) {
        Ok(Ok(sim)) => {
            let handle = Box::new(SphSimulation {
                sim,
                error: CString::default(),
            });
            // SAFETY: as above.
            unsafe { *out = Box::into_raw(handle) };
            report(SphStatus::Ok, "")
        }
        Ok(Err(e)) => report(status_of(&e), &e.to_string()),
        Err(payload) => report(SphStatus::Panic, &panic_message(&*payload)),
    }
}

/// Frees a simulation (null is ignored).
///
/// # Safety
/// `sim` is null or a pointer from [`sph_simulation_new`] not yet freed.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_free(sim: *mut SphSimulation) {
    if !sim.is_null() {
        // SAFETY: from `Box::into_raw` in `sph_simulation_new` (the contract).
        drop(unsafe { Box::from_raw(sim) });
    }
}

/// The message of the last failed call on `sim` ("" after a success); valid
/// until the next call on `sim`. Null for a null `sim`.
///
/// # Safety
/// `sim` is null or a live simulation.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_error(sim: *const SphSimulation) -> *const c_char {
    // SAFETY: the contract.
    match unsafe { sim.as_ref() } {
        Some(h) => h.error.as_ptr(),
        None => std::ptr::null(),
    }
}

/// Takes up to `steps` time steps (fewer where the run reaches its end time
/// or a steady state) and pauses; `*taken` (if not null) receives the count.
/// Pieces give bit for bit the run made in one piece. Each call also copies
/// the run's storage in and out (under one step's cost at 10^3 to 10^4
/// particles): advance by several steps at a time where speed matters.
///
/// # Safety
/// `sim` is null or a live simulation; `taken` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_advance(
    sim: *mut SphSimulation,
    steps: u64,
    taken: *mut u64,
) -> SphStatus {
    with_sim(sim, |s| {
        let n = s.advance(steps).map_err(fail)?;
        // SAFETY: the contract.
        if let Some(t) = unsafe { taken.as_mut() } {
            *t = n;
        }
        Ok(())
    })
}

/// Runs to the end time (or a steady state); `*taken` as in
/// [`sph_simulation_advance`].
///
/// # Safety
/// As [`sph_simulation_advance`].
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_run_to_end(
    sim: *mut SphSimulation,
    taken: *mut u64,
) -> SphStatus {
    // SAFETY: the same contract.
    unsafe { sph_simulation_advance(sim, u64::MAX, taken) }
}

/// Reads a scalar property of a live simulation; `fallback` for null.
fn property<T>(sim: *const SphSimulation, fallback: T, get: impl FnOnce(&Simulation) -> T) -> T {
    // SAFETY: the callers' contract: null or a live simulation.
    match unsafe { sim.as_ref() } {
        Some(h) => get(&h.sim),
        None => fallback,
    }
}

/// 1 once the run reached its end time or a steady state, else 0 (also for
/// null).
///
/// # Safety
/// `sim` is null or a live simulation.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_ended(sim: *const SphSimulation) -> i32 {
    property(sim, 0, |s| i32::from(s.ended()))
}

/// Simulated time in s (NaN for null).
///
/// # Safety
/// `sim` is null or a live simulation.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_time(sim: *const SphSimulation) -> f64 {
    property(sim, f64::NAN, Simulation::time)
}

/// The end time in s (NaN for null).
///
/// # Safety
/// `sim` is null or a live simulation.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_end_time(sim: *const SphSimulation) -> f64 {
    property(sim, f64::NAN, Simulation::end_time)
}

/// Steps taken since the start (0 for null).
///
/// # Safety
/// `sim` is null or a live simulation.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_steps(sim: *const SphSimulation) -> u64 {
    property(sim, 0, Simulation::steps)
}

/// The time step in s (with an adaptive step, the starting estimate; NaN
/// for null).
///
/// # Safety
/// `sim` is null or a live simulation.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_dt(sim: *const SphSimulation) -> f64 {
    property(sim, f64::NAN, Simulation::dt)
}

/// Dimension, 2 or 3 (0 for null).
///
/// # Safety
/// `sim` is null or a live simulation.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_dim(sim: *const SphSimulation) -> usize {
    property(sim, 0, Simulation::dim)
}

/// Fluid particles (0 for null).
///
/// # Safety
/// `sim` is null or a live simulation.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_particles(sim: *const SphSimulation) -> usize {
    property(sim, 0, Simulation::particles)
}

/// The `double`s a buffer for `field` holds: particles times components (0
/// for null).
///
/// # Safety
/// `sim` is null or a live simulation.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_field_len(
    sim: *const SphSimulation,
    field: SphField,
) -> usize {
    property(sim, 0, |s| s.len(field.into()))
}

/// Writes the time-step limits at the start, `[acoustic, viscous, body
/// force]` in s, into `out` (3 doubles).
///
/// # Safety
/// `sim` is null or a live simulation; `out` is null or holds 3 doubles.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_limits(
    sim: *mut SphSimulation,
    out: *mut f64,
) -> SphStatus {
    with_sim(sim, |s| {
        let out = buffer_mut(out, 3)?;
        out.copy_from_slice(&s.limits());
        Ok(())
    })
}

/// Output times reached so far: the diagnostics available (0 for null).
///
/// # Safety
/// `sim` is null or a live simulation.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_outputs(sim: *const SphSimulation) -> usize {
    property(sim, 0, |s| s.diagnostics().len())
}

/// Diagnostics at output `index` (0 the first; `sph_simulation_outputs - 1`
/// the latest).
///
/// # Safety
/// `sim` is null or a live simulation; `out` is null or writable.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_diagnostics(
    sim: *mut SphSimulation,
    index: usize,
    out: *mut SphDiagnostics,
) -> SphStatus {
    with_sim(sim, |s| {
        // SAFETY: the contract.
        let out = unsafe { out.as_mut() }.ok_or((SphStatus::NullPointer, "out is null".into()))?;
        let all = s.diagnostics();
        let d = all.get(index).ok_or_else(|| {
            fail(Error::config(
                "index",
                index,
                format!("{} output times reached so far", all.len()),
            ))
        })?;
        *out = SphDiagnostics {
            t: d.t,
            kinetic_energy: d.kinetic_energy,
            min_spacing: d.min_spacing,
            max_density_deviation: d.max_density_deviation,
            max_mach: d.max_mach,
            linf: d.linf.unwrap_or(f64::NAN),
            l2: d.l2.unwrap_or(f64::NAN),
        };
        Ok(())
    })
}

fn buffer_mut<'a>(ptr: *mut f64, len: usize) -> Result<&'a mut [f64], (SphStatus, String)> {
    if ptr.is_null() {
        return Err((SphStatus::NullPointer, "buffer is null".into()));
    }
    // SAFETY: the callers' contract: `ptr` holds `len` writable doubles.
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, len) })
}

/// Copies `field` into `out` (`len` doubles, which must equal
/// [`sph_simulation_field_len`]): particle by particle in id order, vectors
/// as `dim` consecutive components.
///
/// # Safety
/// `sim` is null or a live simulation; `out` is null or holds `len`
/// writable doubles.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_read(
    sim: *mut SphSimulation,
    field: SphField,
    out: *mut f64,
    len: usize,
) -> SphStatus {
    with_sim(sim, |s| {
        s.read(field.into(), buffer_mut(out, len)?).map_err(fail)
    })
}

/// Overwrites `field` from `values` (the layout of [`sph_simulation_read`]);
/// the next advance re-evaluates the state from it. A refused write
/// (wrong length, a value that is not finite, a position outside the walls,
/// the pressure, a density under summation density) changes nothing.
///
/// # Safety
/// `sim` is null or a live simulation; `values` is null or holds `len`
/// doubles.
#[no_mangle]
pub unsafe extern "C" fn sph_simulation_write(
    sim: *mut SphSimulation,
    field: SphField,
    values: *const f64,
    len: usize,
) -> SphStatus {
    with_sim(sim, |s| {
        if values.is_null() {
            return Err((SphStatus::NullPointer, "values is null".into()));
        }
        // SAFETY: the contract: `values` holds `len` doubles.
        let values = unsafe { std::slice::from_raw_parts(values, len) };
        s.write(field.into(), values).map_err(fail)
    })
}

/// The library's version, e.g. "0.1.0" (static, NUL-terminated).
#[no_mangle]
pub extern "C" fn sph_version() -> *const c_char {
    concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr().cast()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A panic inside a call comes back as a status and a message, and the
    /// simulation stays usable.
    #[test]
    fn a_panic_stops_at_the_boundary() {
        let settings = settings_of("case = \"couette\"\nresolution = 8\nthreads = 1\n").unwrap();
        let mut handle = SphSimulation {
            sim: Simulation::from_settings(&settings).unwrap(),
            error: CString::default(),
        };
        let status = with_sim(&mut handle, |_| panic!("boom"));
        assert_eq!(status, SphStatus::Panic);
        let message = handle.error.to_str().unwrap();
        assert!(message.contains("boom"), "{message}");
        assert_eq!(
            with_sim(&mut handle, |s| s.advance(3).map(|_| ()).map_err(fail)),
            SphStatus::Ok
        );
        assert_eq!(handle.sim.steps(), 3);
    }
}
