//! sph-core in a browser: plane Couette flow as a wasm32 module with plain
//! exported functions (no wasm-bindgen), driven by `web/index.html`.
//!
//! The same code runs natively (`cargo run -p sph-web --example reference`),
//! which is what the page's figures are checked against: the module's f64
//! arithmetic is IEEE and its math is libm's pure Rust, so the error after
//! N steps is the native one bit for bit.
//!
//! The flow is `sph couette`'s defaults (gap 1 mm, U = 1.25e-5 m/s,
//! rho0 = 1000, c0 = 10 U), with the viscosity and the particles across
//! chosen by the caller: cubic spline at beta 1.3, summation density, Morris
//! viscosity, mirrored no-slip plates, f64. Particles live in `Vec`s (std's
//! allocator exists on wasm32); between calls the run is kept as its
//! storage plus [`Resume`], and each call resumes it (bit for bit).

use std::cell::RefCell;

use sph_core::analytic::Couette;
use sph_core::prelude::*;
use sph_core::solver::Resume;

#[path = "../../sph-core/tests/common/mod.rs"]
#[allow(missing_docs)]
mod common;

use common::Buffers;

/// Plate separation in m.
pub const GAP: f64 = 1e-3;
/// Speed of the upper plate in m/s.
pub const U: f64 = 1.25e-5;
const RHO0: f64 = 1000.0;
const BETA: f64 = 1.3;
/// Particles along the periodic strip: just over two supports (2 x 2.6 dx).
const ALONG: usize = 6;

/// A run between calls.
pub struct Run {
    buffers: Buffers<D2<f64>>,
    domain: Domain<D2<f64>>,
    params: Params<f64>,
    forces: (PressureGradient, MorrisViscosity<f64>),
    n: usize,
    state: Resume,
    dt: f64,
    nu: f64,
    exact: Couette,
}

type Couetter<'a> = Solver<
    'a,
    D2<f64>,
    CubicSpline,
    Libm,
    SummationDensity,
    (PressureGradient, MorrisViscosity<f64>),
>;

impl Run {
    /// `across` particles across the gap (4 to 200), kinematic viscosity
    /// `nu` in m^2/s (positive).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] for values outside those ranges; any
    /// error of the core's set-up.
    pub fn new(across: usize, nu: f64) -> Result<Self> {
        if !(4..=200).contains(&across) {
            return Err(Error::InvalidParameter {
                name: "across",
                value: across as f64,
                rule: "particles across the gap: 4 to 200",
            });
        }
        if !(nu > 0.0 && nu.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "nu",
                value: nu,
                rule: "the viscosity must be positive and finite",
            });
        }
        let dx = GAP / across as f64;
        let x: Vec<_> = (0..across)
            .flat_map(|j| {
                (0..ALONG).map(move |i| Vector::new([(i as f64 + 0.5) * dx, (j as f64 + 0.5) * dx]))
            })
            .collect();
        let v = vec![Vector::zero(); x.len()];
        let domain = Domain::new(
            Vector::new([0.0, -0.5 * GAP]),
            Vector::new([ALONG as f64 * dx, GAP]),
        )?
        .with_periodic(0)?
        .with_wall(1, Side::Lower, Wall::no_slip())?
        .with_wall(1, Side::Upper, Wall::moving(Vector::new([U, 0.0])))?;
        let h = BETA * dx;
        let cells = Couetter::cells_needed(&domain, h)?;
        // Ghosts: four rows at each plate (the support is 2.6 dx).
        let mut buffers = Buffers::new(&x, &v, 1.0, RHO0, 2 * 4 * ALONG, cells);
        let params = Params::new(
            h,
            Eos::Linear {
                rho0: RHO0,
                c0: 10.0 * U,
                p0: 0.0,
            },
        );
        let forces = (PressureGradient, MorrisViscosity { mu: nu * RHO0 });
        let n = x.len();
        let (state, dt) = {
            let mut solver = Couetter::new(
                params,
                domain,
                buffers.storage(),
                n,
                SummationDensity,
                forces,
            )?;
            solver.calibrate_mass(RHO0)?;
            (solver.resume_state(), 0.7 * solver.limits().min())
        };
        let exact = Couette::new(-0.5 * GAP, 0.5 * GAP, U, nu)?;
        Ok(Self {
            buffers,
            domain,
            params,
            forces,
            n,
            state,
            dt,
            nu,
            exact,
        })
    }

    /// Takes `steps` steps of the fixed step [`Self::dt`].
    ///
    /// # Errors
    /// A core error (a diverged step).
    pub fn step(&mut self, steps: u32) -> Result<()> {
        let mut solver = Couetter::resume_with(
            self.params,
            self.domain,
            self.buffers.storage(),
            self.n,
            SummationDensity,
            self.forces,
            self.state,
        )?;
        for _ in 0..steps {
            solver.step(self.dt)?;
        }
        self.state = solver.resume_state();
        Ok(())
    }

    /// Simulated time in s.
    pub fn time(&self) -> f64 {
        self.state.time
    }

    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.state.steps
    }

    /// The time step in s.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Fluid particles.
    pub fn particles(&self) -> usize {
        self.n
    }

    /// The viscosity in m^2/s.
    pub fn nu(&self) -> f64 {
        self.nu
    }

    /// Writes the fluid's positions (global, m) and velocities (m/s) as
    /// `x, y, u, v` per particle into `out` (cleared first).
    pub fn particles_into(&self, out: &mut Vec<f64>) {
        out.clear();
        for i in 0..self.n {
            let x = self
                .domain
                .to_global(self.domain.wrap::<Libm>(self.buffers.x[i]));
            let v = self.buffers.v[i];
            out.extend_from_slice(&[x[0], x[1], v[0], v[1]]);
        }
    }

    /// `max |v - v_exact| / U` over the fluid at the current time.
    pub fn linf(&self) -> f64 {
        let t = self.time();
        (0..self.n)
            .map(|i| {
                let y = self.domain.to_global(self.buffers.x[i])[1];
                let v = self.buffers.v[i];
                let du = v[0] - self.exact.velocity(y, t);
                (du * du + v[1] * v[1]).sqrt() / U
            })
            .fold(0.0, f64::max)
    }
}

/// The functions the page calls by name. `no_mangle` is all the `unsafe`
/// lint sees here: there is no unsafe block in this crate.
#[allow(unsafe_code)]
mod exports {
    use super::*;

    thread_local! {
        /// The page's run (a wasm module has one thread).
        static RUN: RefCell<Option<Run>> = const { RefCell::new(None) };
        /// `x, y, u, v` per particle, for the page to read through a pointer.
        static VIEW: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
    }

    /// Starts a run with `across` particles across the gap and viscosity `nu`
    /// (m^2/s); 0 on success, 1 for a refused value.
    #[no_mangle]
    pub extern "C" fn sph_start(across: u32, nu: f64) -> i32 {
        match Run::new(across as usize, nu) {
            Ok(run) => {
                RUN.with(|r| *r.borrow_mut() = Some(run));
                0
            }
            Err(_) => 1,
        }
    }

    /// Takes `steps` steps; 0 on success, 1 without a run, 2 if it diverged.
    #[no_mangle]
    pub extern "C" fn sph_step(steps: u32) -> i32 {
        RUN.with(|r| match r.borrow_mut().as_mut() {
            None => 1,
            Some(run) => i32::from(run.step(steps).is_err()) * 2,
        })
    }

    fn with_run(f: impl FnOnce(&Run) -> f64) -> f64 {
        RUN.with(|r| r.borrow().as_ref().map_or(f64::NAN, f))
    }

    /// Simulated time in s (NaN without a run).
    #[no_mangle]
    pub extern "C" fn sph_time() -> f64 {
        with_run(Run::time)
    }

    /// Steps taken (NaN without a run).
    #[no_mangle]
    pub extern "C" fn sph_steps() -> f64 {
        with_run(|r| r.steps() as f64)
    }

    /// The time step in s.
    #[no_mangle]
    pub extern "C" fn sph_dt() -> f64 {
        with_run(Run::dt)
    }

    /// `max |v - v_exact| / U` now.
    #[no_mangle]
    pub extern "C" fn sph_linf() -> f64 {
        with_run(Run::linf)
    }

    /// The diffusion time `gap^2 / nu` in s.
    #[no_mangle]
    pub extern "C" fn sph_diffusion_time() -> f64 {
        with_run(|r| GAP * GAP / r.nu())
    }

    /// Fills the view with `x, y, u, v` per particle and returns the particle
    /// count; [`sph_view`] points at it until the next call.
    #[no_mangle]
    pub extern "C" fn sph_fill_view() -> u32 {
        RUN.with(|r| match r.borrow().as_ref() {
            None => 0,
            Some(run) => VIEW.with(|v| {
                run.particles_into(&mut v.borrow_mut());
                run.particles() as u32
            }),
        })
    }

    /// Where the view's values start in the module's memory.
    #[no_mangle]
    pub extern "C" fn sph_view() -> *const f64 {
        VIEW.with(|v| v.borrow().as_ptr())
    }
}
