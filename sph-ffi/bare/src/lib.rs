//! sph-core for bare-metal C firmware: plane Couette flow in caller
//! storage, set up from a parameter struct, with no allocator and no
//! panics.
//!
//! The C side declares one [`SphBare`] (a `static`, about 24 KB: its size is
//! fixed, so the linker places it and no heap is involved), fills an
//! [`SphBareCouette`] and calls [`sph_bare_init`], then [`sph_bare_step`]
//! as often as it likes. Header: `include/sph_bare.h` (cbindgen; the test
//! `header` fails when it is stale). The physics is the firmware's
//! (`examples/firmware`): f32, cubic spline, summation density, Morris
//! viscosity, mirrored no-slip plates, a periodic strip six particles wide;
//! with the firmware's parameters the velocities are the firmware's bit for
//! bit (tests/couette.rs).
//!
//! No panics by construction: the core returns `Result` for every
//! failure, this layer maps each to a status code, and its only indexing
//! is bounds-checked against lengths it checked first; `panic = "abort"`
//! in the firmware's profile is the last guard. `unsafe` is allowed here
//! only to turn the caller's pointers into references.

// no_std on bare metal; a host build (this crate's tests) links std, whose
// panic handler a static library needs there.
#![cfg_attr(target_os = "none", no_std)]
#![allow(unsafe_code)]

use core::mem::{align_of, size_of, MaybeUninit};

use sph_core::analytic::Couette;
use sph_core::prelude::*;
use sph_core::solver::Resume;
use sph_core::store::Store;

/// Most particles across the gap.
pub const SPH_BARE_MAX_ACROSS: u32 = 32;
/// Particles along the periodic strip (just over two supports of 2.6 dx).
const ALONG: usize = 6;
/// Particle slots: fluid plus four ghost rows at each plate.
const SLOTS: usize = SPH_BARE_MAX_ACROSS as usize * ALONG + 2 * 4 * ALONG;
/// Cell-list starts (35 at 32 across).
const CELLS: usize = 40;

type Forces = (PressureGradient, MorrisViscosity<f32>);
type Couetter<'a> = Solver<'a, D2<f32>, CubicSpline, Libm, SummationDensity, Forces>;

/// The run's state inside the caller's [`SphBare`].
struct Inner {
    /// [`MAGIC`] once initialised.
    magic: u32,
    store: Store<D2<f32>, SLOTS, CELLS>,
    domain: Domain<D2<f32>>,
    params: Params<f32>,
    forces: Forces,
    n: usize,
    state: Resume,
    dt: f64,
    /// The time the last [`sph_bare_advance_to`] aimed at.
    mark: f64,
    exact: Couette,
    u: f64,
}

const MAGIC: u32 = 0x5350_4842;

/// 8-byte words of [`SphBare`]: at least the run's state (checked at
/// compile time).
pub const SPH_BARE_WORDS: usize = 3072;

const _: () = assert!(size_of::<Inner>() <= 8 * SPH_BARE_WORDS);
const _: () = assert!(align_of::<Inner>() <= align_of::<u64>());

/// The caller's storage for one run: declare it (a `static` in firmware)
/// and pass its address; its contents are private. Words of `u64` give it
/// the alignment of the state inside.
#[repr(C)]
pub struct SphBare {
    /// Opaque.
    pub words: [u64; SPH_BARE_WORDS],
}

/// Plane Couette flow: plates at `y = -gap/2` (at rest) and `y = gap/2`
/// (moving at `wall_speed` along x), fluid at rest at the start.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphBareCouette {
    /// Particles across the gap, 4 to [`SPH_BARE_MAX_ACROSS`].
    pub particles_across: u32,
    /// Plate separation in m (f64: the plates' positions are kept in f64,
    /// the particles' in f32 relative to the lower plate).
    pub gap: f64,
    /// Speed of the upper plate in m/s.
    pub wall_speed: f32,
    /// Kinematic viscosity in m^2/s.
    pub nu: f32,
    /// Reference density in kg/m^3.
    pub rho0: f32,
    /// Sound speed in m/s (10 x `wall_speed` keeps density within 1 %).
    pub sound_speed: f32,
    /// Overlap factor h / dx, 1 to 2 (the strip is six particles wide).
    pub beta: f32,
    /// Time step as a fraction of the smallest stability limit, in (0, 0.9].
    pub dt_factor: f64,
}

/// What a call returned.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SphBareStatus {
    /// Success.
    Ok = 0,
    /// A parameter broke its rule.
    InvalidParameter = 1,
    /// The run needs more particles or cells than [`SphBare`] holds.
    Capacity = 2,
    /// A step diverged (a non-finite value).
    Unstable = 3,
    /// Another error of the core.
    Core = 4,
    /// A null pointer.
    NullPointer = 5,
    /// The state was not initialised by [`sph_bare_init`].
    NotInitialised = 6,
    /// A buffer of the wrong length.
    BufferLength = 7,
}

fn status(e: Error) -> SphBareStatus {
    match e {
        Error::InvalidParameter { .. } => SphBareStatus::InvalidParameter,
        Error::CapacityExceeded { .. } => SphBareStatus::Capacity,
        Error::Unstable { .. } => SphBareStatus::Unstable,
        _ => SphBareStatus::Core,
    }
}

fn invalid(name: &'static str, value: f64, rule: &'static str) -> Error {
    Error::InvalidParameter { name, value, rule }
}

fn check(p: &SphBareCouette) -> Result<()> {
    let positive = |name, v: f32| {
        if v > 0.0 && v.is_finite() {
            Ok(())
        } else {
            Err(invalid(name, f64::from(v), "must be positive and finite"))
        }
    };
    if !(4..=SPH_BARE_MAX_ACROSS).contains(&p.particles_across) {
        return Err(invalid(
            "particles_across",
            f64::from(p.particles_across),
            "4 to SPH_BARE_MAX_ACROSS",
        ));
    }
    if !(p.gap > 0.0 && p.gap.is_finite()) {
        return Err(invalid("gap", p.gap, "must be positive and finite"));
    }
    positive("wall_speed", p.wall_speed)?;
    positive("nu", p.nu)?;
    positive("rho0", p.rho0)?;
    positive("sound_speed", p.sound_speed)?;
    if !(1.0..=2.0).contains(&p.beta) {
        return Err(invalid("beta", f64::from(p.beta), "1 to 2"));
    }
    if !(p.dt_factor > 0.0 && p.dt_factor <= 0.9) {
        return Err(invalid("dt_factor", p.dt_factor, "in (0, 0.9]"));
    }
    Ok(())
}

/// The state behind a caller's pointer, initialised or not.
fn slot<'a>(bare: *mut SphBare) -> core::result::Result<&'a mut MaybeUninit<Inner>, SphBareStatus> {
    // SAFETY: `SphBare` is at least as large and as aligned as `Inner`
    // (the assertions above); the caller passes storage it owns and uses
    // from one thread at a time (the header's contract).
    unsafe { bare.cast::<MaybeUninit<Inner>>().as_mut() }.ok_or(SphBareStatus::NullPointer)
}

fn inner<'a>(bare: *mut SphBare) -> core::result::Result<&'a mut Inner, SphBareStatus> {
    let slot = slot(bare)?;
    // The magic word is read as plain bytes: valid for any contents.
    let ptr = slot.as_mut_ptr();
    // SAFETY: `magic` is a `u32` at an aligned offset inside the storage;
    // every bit pattern is a valid `u32`.
    let magic = unsafe { core::ptr::addr_of!((*ptr).magic).read() };
    if magic != MAGIC {
        return Err(SphBareStatus::NotInitialised);
    }
    // SAFETY: `sph_bare_init` wrote every field before setting the magic.
    Ok(unsafe { slot.assume_init_mut() })
}

/// Sets up a run in `bare` from `params` (the fluid at rest on a lattice,
/// masses calibrated) and pauses it before the first step. A failure
/// leaves `bare` uninitialised.
///
/// # Safety
/// `bare` is null or points to an `SphBare` the caller owns; `params` is
/// null or valid.
#[no_mangle]
pub unsafe extern "C" fn sph_bare_init(
    bare: *mut SphBare,
    params: *const SphBareCouette,
) -> SphBareStatus {
    let Ok(slot) = slot(bare) else {
        return SphBareStatus::NullPointer;
    };
    // SAFETY: the contract.
    let Some(p) = (unsafe { params.as_ref() }) else {
        return SphBareStatus::NullPointer;
    };
    let ptr = slot.as_mut_ptr();
    // SAFETY: writing a `u32` into the storage; cleared first so that a
    // failure below leaves it uninitialised.
    unsafe { core::ptr::addr_of_mut!((*ptr).magic).write(0) };
    match init(ptr, p) {
        Ok(()) => {
            // SAFETY: as above; every other field is written.
            unsafe { core::ptr::addr_of_mut!((*ptr).magic).write(MAGIC) };
            SphBareStatus::Ok
        }
        Err(e) => status(e),
    }
}

fn init(ptr: *mut Inner, p: &SphBareCouette) -> Result<()> {
    check(p)?;
    let across = p.particles_across as usize;
    let gap = p.gap as f32;
    let dx = gap / across as f32;
    let half = 0.5 * p.gap;
    let domain = Domain::new(
        Vector::new([0.0, -half]),
        Vector::new([ALONG as f32 * dx, gap]),
    )?
    .with_periodic(0)?
    .with_wall(1, Side::Lower, Wall::no_slip())?
    .with_wall(
        1,
        Side::Upper,
        Wall::moving(Vector::new([p.wall_speed, 0.0])),
    )?;
    let h = p.beta * dx;
    let needed = Couetter::cells_needed(&domain, h)?;
    if needed > CELLS {
        return Err(Error::CapacityExceeded {
            buffer: "cell_start",
            needed,
            available: CELLS,
        });
    }
    // The store is written in place (it is most of the storage: no copy of
    // it passes through the stack).
    // SAFETY: `ptr` points into the caller's storage, aligned for `Inner`.
    let store = unsafe {
        let field = core::ptr::addr_of_mut!((*ptr).store);
        field.write(Store::new());
        &mut *field
    };
    for j in 0..across {
        for i in 0..ALONG {
            let x = Vector::new([(i as f32 + 0.5) * dx, (j as f32 + 0.5) * dx]);
            store.push(x, Vector::zero(), 1.0, p.rho0)?;
        }
    }
    let params = Params::new(
        h,
        Eos::Linear {
            rho0: p.rho0,
            c0: p.sound_speed,
            p0: 0.0,
        },
    );
    let forces = (PressureGradient, MorrisViscosity { mu: p.nu * p.rho0 });
    let (storage, n) = store.storage()?;
    let mut solver = Couetter::new(params, domain, storage, n, SummationDensity, forces)?;
    solver.calibrate_mass(p.rho0)?;
    let state = solver.resume_state();
    let dt = p.dt_factor * solver.limits().min();
    let exact = Couette::new(-half, half, f64::from(p.wall_speed), f64::from(p.nu))?;
    // SAFETY: each field of the caller's storage written once, in place.
    unsafe {
        core::ptr::addr_of_mut!((*ptr).domain).write(domain);
        core::ptr::addr_of_mut!((*ptr).params).write(params);
        core::ptr::addr_of_mut!((*ptr).forces).write(forces);
        core::ptr::addr_of_mut!((*ptr).n).write(n);
        core::ptr::addr_of_mut!((*ptr).state).write(state);
        core::ptr::addr_of_mut!((*ptr).dt).write(dt);
        core::ptr::addr_of_mut!((*ptr).mark).write(0.0);
        core::ptr::addr_of_mut!((*ptr).exact).write(exact);
        core::ptr::addr_of_mut!((*ptr).u).write(f64::from(p.wall_speed));
    }
    Ok(())
}

/// Takes `steps` steps of the fixed step (the run continues bit for bit
/// across calls). After a failure the run stays at its last good state.
///
/// # Safety
/// `bare` is null or points to an `SphBare` the caller owns.
#[no_mangle]
pub unsafe extern "C" fn sph_bare_step(bare: *mut SphBare, steps: u32) -> SphBareStatus {
    let run = match inner(bare) {
        Ok(r) => r,
        Err(s) => return s,
    };
    let dt = run.dt;
    let status = advance(run, steps, dt);
    run.mark = run.state.time;
    status
}

/// Advances to time `t` (after the last time aimed at) in the fewest equal
/// steps no longer than the fixed step: the firmware's way of landing on
/// output times.
///
/// # Safety
/// As [`sph_bare_step`].
#[no_mangle]
pub unsafe extern "C" fn sph_bare_advance_to(bare: *mut SphBare, t: f64) -> SphBareStatus {
    let run = match inner(bare) {
        Ok(r) => r,
        Err(s) => return s,
    };
    let span = t - run.mark;
    if !(span > 0.0 && span.is_finite()) {
        return SphBareStatus::InvalidParameter;
    }
    let steps = -<Libm as Math<f64>>::floor(-span / run.dt);
    if steps > f64::from(u32::MAX) {
        return SphBareStatus::InvalidParameter;
    }
    let steps = steps as u32;
    let status = advance(run, steps, span / f64::from(steps));
    if status == SphBareStatus::Ok {
        run.mark = t;
    }
    status
}

fn advance(run: &mut Inner, steps: u32, dt: f64) -> SphBareStatus {
    let advanced = (|| -> Result<Resume> {
        let (storage, n) = run.store.storage()?;
        let mut solver = Couetter::resume_with(
            run.params,
            run.domain,
            storage,
            n,
            SummationDensity,
            run.forces,
            run.state,
        )?;
        for _ in 0..steps {
            solver.step(dt)?;
        }
        Ok(solver.resume_state())
    })();
    match advanced {
        Ok(state) => {
            run.state = state;
            SphBareStatus::Ok
        }
        Err(e) => status(e),
    }
}

fn get<T>(bare: *const SphBare, fallback: T, f: impl FnOnce(&Inner) -> T) -> T {
    inner(bare.cast_mut()).map_or(fallback, |r| f(r))
}

/// Simulated time in s (NaN before initialisation).
///
/// # Safety
/// As [`sph_bare_step`].
#[no_mangle]
pub unsafe extern "C" fn sph_bare_time(bare: *const SphBare) -> f64 {
    get(bare, f64::NAN, |r| r.state.time)
}

/// Steps taken (0 before initialisation).
///
/// # Safety
/// As [`sph_bare_step`].
#[no_mangle]
pub unsafe extern "C" fn sph_bare_steps(bare: *const SphBare) -> u64 {
    get(bare, 0, |r| r.state.steps)
}

/// The time step in s (NaN before initialisation).
///
/// # Safety
/// As [`sph_bare_step`].
#[no_mangle]
pub unsafe extern "C" fn sph_bare_dt(bare: *const SphBare) -> f64 {
    get(bare, f64::NAN, |r| r.dt)
}

/// Fluid particles (0 before initialisation).
///
/// # Safety
/// As [`sph_bare_step`].
#[no_mangle]
pub unsafe extern "C" fn sph_bare_particles(bare: *const SphBare) -> u32 {
    get(bare, 0, |r| r.n as u32)
}

/// Copies the fluid's velocities (`u, v` per particle, m/s) into `out`,
/// which holds `len` floats: exactly twice [`sph_bare_particles`].
///
/// # Safety
/// As [`sph_bare_step`]; `out` is null or holds `len` writable floats.
#[no_mangle]
pub unsafe extern "C" fn sph_bare_velocities(
    bare: *mut SphBare,
    out: *mut f32,
    len: u32,
) -> SphBareStatus {
    let run = match inner(bare) {
        Ok(r) => r,
        Err(s) => return s,
    };
    if out.is_null() {
        return SphBareStatus::NullPointer;
    }
    if len as usize != 2 * run.n {
        return SphBareStatus::BufferLength;
    }
    // SAFETY: the contract: `out` holds `len` floats.
    let out = unsafe { core::slice::from_raw_parts_mut(out, len as usize) };
    let Ok((storage, _)) = run.store.storage() else {
        return SphBareStatus::Core;
    };
    for (pair, v) in out.chunks_exact_mut(2).zip(storage.v.iter()) {
        pair[0] = v[0];
        pair[1] = v[1];
    }
    SphBareStatus::Ok
}

/// The largest `|u - u_exact| / wall_speed` over the fluid now, against the
/// exact series (NaN before initialisation).
///
/// # Safety
/// As [`sph_bare_step`].
#[no_mangle]
pub unsafe extern "C" fn sph_bare_linf(bare: *mut SphBare) -> f64 {
    let Ok(run) = inner(bare) else {
        return f64::NAN;
    };
    let (t, n, u, exact, domain) = (run.state.time, run.n, run.u, run.exact, run.domain);
    let Ok((storage, _)) = run.store.storage() else {
        return f64::NAN;
    };
    let mut worst = 0.0f64;
    for (x, v) in storage.x.iter().zip(storage.v.iter()).take(n) {
        let y = domain.to_global(*x)[1];
        let e = (f64::from(v[0]) - exact.velocity(y, t)) / u;
        worst = worst.max(if e < 0.0 { -e } else { e });
    }
    worst
}

/// The bare-metal library's panic handler (none is reached: see the crate
/// docs); on a host build std provides its own.
#[cfg(target_os = "none")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    loop {
        core::hint::spin_loop();
    }
}
