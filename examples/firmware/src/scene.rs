//! The firmware's Couette case, shared word for word with the host example
//! `sph-core/examples/firmware_host.rs`, so that the emulated Cortex-M and the host
//! run the same code on the same data and can be compared bit for bit.
//!
//! 16 particles across a 1 mm gap, 6 along a periodic strip, cubic spline at
//! beta 1.3, summation density, linear EOS with c0 = 10 U, Morris viscosity,
//! f32, held in a fixed-capacity `heapless` store: no allocator anywhere.
//! Lines are printed with integers only (errors in parts per million of U, a
//! hash of the velocity bits), so no float formatting is linked.

use core::fmt;

use sph_core::analytic::Couette;
use sph_core::prelude::*;

/// Particles across the gap.
pub const ACROSS: usize = 16;
/// Particles along the periodic strip (just over two supports of 2.6 dx).
pub const ALONG: usize = 6;
/// Particle slots: fluid plus ghosts (4 rows at each wall).
pub const SLOTS: usize = ACROSS * ALONG + 2 * 4 * ALONG;
/// Cell-list starts (the grid needs 19).
pub const CELLS: usize = 24;
/// Output times in milliseconds (t* = t / 1 s).
pub const OUTPUT_MS: [u32; 4] = [20, 50, 100, 200];
/// Errors are checked from this t* on (in ms).
pub const CHECK_FROM_MS: u32 = 50;

/// The store the scene runs in (about 12 KiB for f32 in 2D).
pub type SceneStore = Store<D2<f32>, SLOTS, CELLS>;

/// One output line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Line {
    /// Time in milliseconds.
    pub t_ms: u32,
    /// Steps so far.
    pub steps: u32,
    /// Linf error against the exact series, in ppm of U (0 without reporting).
    pub linf_ppm: u32,
    /// FNV-1a hash of the bits of every fluid velocity.
    pub hash: u32,
}

impl fmt::Display for Line {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "t_ms={} steps={} linf_ppm={} hash={:08x}",
            self.t_ms, self.steps, self.linf_ppm, self.hash
        )
    }
}

fn fnv(hash: &mut u32, word: u32) {
    for byte in word.to_le_bytes() {
        *hash ^= u32::from(byte);
        *hash = hash.wrapping_mul(0x0100_0193);
    }
}

/// Runs the scene with math backend `M`, calling `out` at each output time;
/// with `report`, compares with the exact series. Returns the largest error
/// (ppm of U) over output times from [`CHECK_FROM_MS`] on.
///
/// # Errors
/// Any core error (none is expected).
pub fn run<M: Math<f32>>(
    store: &mut SceneStore,
    report: bool,
    mut out: impl FnMut(Line),
) -> Result<u32> {
    let (gap, u, nu, rho0) = (1e-3f32, 1.25e-5f32, 1e-6f32, 1000.0f32);
    let dx = gap / ACROSS as f32;
    for j in 0..ACROSS {
        for i in 0..ALONG {
            let x = Vector::new([(i as f32 + 0.5) * dx, (j as f32 + 0.5) * dx]);
            store.push(x, Vector::zero(), 1.0, rho0)?;
        }
    }
    let domain = Domain::new(
        Vector::new([0.0, -0.5e-3]),
        Vector::new([ALONG as f32 * dx, gap]),
    )?
    .with_periodic(0)?
    .with_wall(1, Side::Lower, Wall::no_slip())?
    .with_wall(1, Side::Upper, Wall::moving(Vector::new([u, 0.0])))?;
    let h = 1.3 * dx;
    let needed = Solver::<D2<f32>, CubicSpline, M, (), ()>::cells_needed(&domain, h)?;
    if needed > CELLS {
        return Err(Error::CapacityExceeded {
            buffer: "cell_start",
            needed,
            available: CELLS,
        });
    }
    let (storage, n) = store.storage()?;
    let params = Params::new(
        h,
        Eos::Linear {
            rho0,
            c0: 10.0 * u,
            p0: 0.0,
        },
    );
    let forces = (PressureGradient, MorrisViscosity { mu: nu * rho0 });
    let mut solver = Solver::<D2<f32>, CubicSpline, M, _, _>::new(
        params,
        domain,
        storage,
        n,
        SummationDensity,
        forces,
    )?;
    solver.calibrate_mass(rho0)?;
    let exact = Couette::new(-0.5e-3, 0.5e-3, f64::from(u), f64::from(nu))?;
    let dt_max = 0.7 * solver.limits().min();
    let mut t_prev = 0.0f64;
    let mut worst = 0u32;
    for &t_ms in &OUTPUT_MS {
        let t = f64::from(t_ms) * 1e-3;
        let steps = -<Libm as Math<f64>>::floor(-(t - t_prev) / dt_max) as u32;
        let dt = (t - t_prev) / f64::from(steps);
        for _ in 0..steps {
            solver.step(dt)?;
        }
        t_prev = t;
        let mut hash = 0x811c_9dc5u32;
        let mut linf = 0.0f64;
        for (x, v) in solver.positions().iter().zip(solver.velocities()) {
            fnv(&mut hash, v[0].to_bits());
            fnv(&mut hash, v[1].to_bits());
            if report {
                let y = solver.domain().to_global(*x)[1];
                let e = (f64::from(v[0]) - exact.velocity(y, t)) / f64::from(u);
                linf = if e < 0.0 { linf.max(-e) } else { linf.max(e) };
            }
        }
        let linf_ppm = <Libm as Math<f64>>::floor(linf * 1e6 + 0.5) as u32;
        if t_ms >= CHECK_FROM_MS {
            worst = worst.max(linf_ppm);
        }
        out(Line {
            t_ms,
            steps: solver.steps() as u32,
            linf_ppm,
            hash,
        });
    }
    Ok(worst)
}
