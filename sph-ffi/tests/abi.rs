//! The C ABI called as C calls it: status codes and messages, null
//! pointers, and two simulations side by side with no shared state.

#![allow(unsafe_code)]

use std::ffi::{c_char, CStr, CString};
use std::ptr::null_mut;

use sph_ffi::*;

const SCENE: &str = "case = \"couette\"\nresolution = 8\nt_end = 0.05\nthreads = 1\n";

fn create(scene: &str) -> (SphStatus, *mut SphSimulation, String) {
    let text = CString::new(scene).unwrap();
    let mut out = null_mut();
    let mut message = [0 as c_char; 256];
    // SAFETY: valid pointers and lengths.
    let status =
        unsafe { sph_simulation_new(text.as_ptr(), &mut out, message.as_mut_ptr(), message.len()) };
    // SAFETY: NUL-terminated by the callee.
    let message = unsafe { CStr::from_ptr(message.as_ptr()) }
        .to_string_lossy()
        .into_owned();
    (status, out, message)
}

fn error(sim: *const SphSimulation) -> String {
    // SAFETY: a live simulation; the message lives until the next call.
    unsafe { CStr::from_ptr(sph_simulation_error(sim)) }
        .to_string_lossy()
        .into_owned()
}

fn velocities(sim: *mut SphSimulation) -> Vec<f64> {
    // SAFETY: a live simulation and a buffer of the length it asks for.
    unsafe {
        let mut v = vec![0.0; sph_simulation_field_len(sim, SphField::Velocity)];
        assert_eq!(
            sph_simulation_read(sim, SphField::Velocity, v.as_mut_ptr(), v.len()),
            SphStatus::Ok
        );
        v
    }
}

#[test]
fn failures_come_back_as_codes_and_messages() {
    let (status, sim, message) = create("case = \"couette\"\nbeta = 7.5\n");
    assert_eq!(status, SphStatus::Config);
    assert!(sim.is_null());
    assert!(message.contains("beta"), "{message}");
    let (status, _, message) = create("not a case");
    assert_eq!(status, SphStatus::Config, "{message}");
    // Null pointers.
    let mut out = null_mut();
    // SAFETY: null pointers are part of the contract.
    unsafe {
        assert_eq!(
            sph_simulation_new(std::ptr::null(), &mut out, null_mut(), 0),
            SphStatus::NullPointer
        );
        assert_eq!(
            sph_simulation_advance(null_mut(), 1, null_mut()),
            SphStatus::NullPointer
        );
        assert!(sph_simulation_error(std::ptr::null()).is_null());
        assert!(sph_simulation_time(std::ptr::null()).is_nan());
        sph_simulation_free(null_mut());
    }
    // A message cut to the caller's buffer, still terminated.
    let text = CString::new("case = \"couette\"\nresolution = 2\n").unwrap();
    let mut small = [1 as c_char; 8];
    // SAFETY: valid pointers and lengths.
    let status =
        unsafe { sph_simulation_new(text.as_ptr(), &mut out, small.as_mut_ptr(), small.len()) };
    assert_eq!(status, SphStatus::Config);
    assert_eq!(small[7], 0);
}

#[test]
fn two_simulations_share_nothing() {
    let (status, a, _) = create(SCENE);
    assert_eq!(status, SphStatus::Ok);
    let (_, b, _) = create(SCENE);
    let mut taken = 0;
    // SAFETY: live simulations and valid buffers throughout.
    unsafe {
        assert_eq!(sph_simulation_advance(a, 5, &mut taken), SphStatus::Ok);
        assert_eq!(taken, 5);
        assert_eq!(sph_simulation_advance(b, 10, &mut taken), SphStatus::Ok);
        assert_ne!(velocities(a), velocities(b));
        // A failure on one is that one's message only.
        let one = 1.0;
        assert_eq!(
            sph_simulation_write(a, SphField::Pressure, &one, 1),
            SphStatus::Config
        );
        assert!(error(a).contains("buffer"), "{}", error(a));
        assert_eq!(error(b), "");
        let mut d = std::mem::zeroed::<SphDiagnostics>();
        assert_eq!(sph_simulation_diagnostics(a, 99, &mut d), SphStatus::Config);
        assert!(error(a).contains("index"), "{}", error(a));
        // Five more steps bring `a` to `b`, bit for bit.
        assert_eq!(sph_simulation_advance(a, 5, &mut taken), SphStatus::Ok);
        assert_eq!(error(a), "", "a success clears the message");
        assert_eq!(velocities(a), velocities(b));
        assert_eq!(sph_simulation_steps(a), 10);
        assert_eq!(sph_simulation_run_to_end(a, &mut taken), SphStatus::Ok);
        assert_eq!(sph_simulation_ended(a), 1);
        assert!((sph_simulation_time(a) - 0.05).abs() < 1e-12);
        assert!(sph_simulation_outputs(a) >= 1);
        let last = sph_simulation_outputs(a) - 1;
        assert_eq!(sph_simulation_diagnostics(a, last, &mut d), SphStatus::Ok);
        assert!(
            d.linf.is_finite() && d.linf < 0.05,
            "Couette error {}",
            d.linf
        );
        let mut limits = [0.0; 3];
        assert_eq!(sph_simulation_limits(a, limits.as_mut_ptr()), SphStatus::Ok);
        assert!(limits.iter().all(|l| *l > 0.0));
        assert!(sph_simulation_dt(a) <= limits.iter().copied().fold(f64::INFINITY, f64::min));
        sph_simulation_free(a);
        sph_simulation_free(b);
    }
}

#[test]
fn the_version_is_the_crate_version() {
    // SAFETY: a static NUL-terminated string.
    let v = unsafe { CStr::from_ptr(sph_version()) };
    assert_eq!(v.to_str().unwrap(), env!("CARGO_PKG_VERSION"));
}
