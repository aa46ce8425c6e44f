//! Precision, dimension and storage: f32 against f64, scenes far from the
//! coordinate origin, 1D and 3D, and the heapless store.

mod common;

use common::*;
use sph_core::analytic::Couette;
use sph_core::prelude::*;

/// A small Couette start-up in precision `F`, with the domain's lower corner at `origin_x`;
/// returns the fluid velocities (as f64) and heights (absolute, f64) at t* = 0.1.
fn couette<F: Real>(n: usize, origin_x: f64) -> (Vec<f64>, Vec<f64>)
where
    Libm: Math<F>,
{
    couette_quantized::<F>(n, origin_x, None)
}

/// As [`couette`]; with `Some(offset)` the initial positions are first rounded to
/// the `f32` grid at `offset` metres, emulating a code that stores absolute
/// `f32` coordinates there (only that storage rounding is emulated).
fn couette_quantized<F: Real>(
    n: usize,
    origin_x: f64,
    quantize_at: Option<f64>,
) -> (Vec<f64>, Vec<f64>)
where
    Libm: Math<F>,
{
    let nx = 6;
    let (gap, u, nu) = (1e-3, 1.25e-5, 1e-6);
    let dx = gap / n as f64;
    let h = 1.3 * dx;
    let origin = Vector::new([origin_x, -0.5e-3]);
    let domain = Domain::<D2<F>>::new(
        origin,
        Vector::new([F::from_f64(nx as f64 * dx), F::from_f64(gap)]),
    )
    .unwrap()
    .with_periodic(0)
    .unwrap()
    .with_wall(1, Side::Lower, Wall::no_slip())
    .unwrap()
    .with_wall(
        1,
        Side::Upper,
        Wall::moving(Vector::new([F::from_f64(u), F::ZERO])),
    )
    .unwrap();
    let round = |c: f64| match quantize_at {
        Some(offset) => ((offset + c) as f32) as f64 - offset,
        None => c,
    };
    let x: Vec<Vector<F, 2>> = lattice_2d(nx, n, dx)
        .iter()
        .map(|p| Vector::new([F::from_f64(round(p[0])), F::from_f64(round(p[1]))]))
        .collect();
    let v = vec![Vector::<F, 2>::zero(); x.len()];
    let cells =
        Solver::<D2<F>, CubicSpline, Libm, (), ()>::cells_needed(&domain, F::from_f64(h)).unwrap();
    let mut b = Buffers::<D2<F>>::new(&x, &v, F::ONE, F::ONE, 4 * x.len(), cells);
    let params = Params::new(
        F::from_f64(h),
        Eos::Linear {
            rho0: F::from_f64(1e3),
            c0: F::from_f64(10.0 * u),
            p0: F::ZERO,
        },
    );
    let forces = (
        PressureGradient,
        MorrisViscosity {
            mu: F::from_f64(nu * 1e3),
        },
    );
    let mut s = Solver::<D2<F>, CubicSpline, Libm, _, _>::new(
        params,
        domain,
        b.storage(),
        x.len(),
        SummationDensity,
        forces,
    )
    .unwrap();
    s.calibrate_mass(F::from_f64(1e3)).unwrap();
    let t_end: f64 = 0.1;
    let steps = (t_end / (0.7 * s.limits().min())).ceil() as usize;
    let t_end: f64 = t_end;
    for _ in 0..steps {
        s.step(t_end / steps as f64).unwrap();
    }
    let y = s
        .positions()
        .iter()
        .map(|p| s.domain().to_global(*p)[1])
        .collect();
    (s.velocities().iter().map(|v| v[0].to_f64()).collect(), y)
}

fn linf(u: &[f64], y: &[f64], t: f64) -> f64 {
    let exact = Couette::new(-0.5e-3, 0.5e-3, 1.25e-5, 1e-6).unwrap();
    u.iter()
        .zip(y)
        .map(|(u, y)| (u - exact.velocity(*y, t)).abs() / 1.25e-5)
        .fold(0.0, f64::max)
}

#[test]
fn single_precision_tracks_double_on_a_transient() {
    let (u64s, y64) = couette::<f64>(16, 0.0);
    let (u32s, y32) = couette::<f32>(16, 0.0);
    let (e64, e32) = (linf(&u64s, &y64, 0.1), linf(&u32s, &y32, 0.1));
    assert!(e64 < 0.02, "f64 error {e64}");
    assert!((e32 - e64).abs() < 1e-3, "f32 error {e32} vs f64 {e64}");
}

#[test]
fn absolute_f32_coordinates_far_away_would_lose_the_accuracy() {
    // Storing absolute f32 coordinates at distance X rounds every position to
    // an ulp of X: a lattice distortion of eps = ulp(X)/dx, to which the
    // viscous operator responds at first order (an error of order 0.02 eps on
    // top of the baseline here). At 40 across: eps = 0.048 at 10 m (1e4 gap
    // widths), 0.48 at 100 m. The error must grow with eps, and at eps ~ 1/2
    // dwarf the baseline. Local coordinates (the core's design, next test)
    // avoid it entirely.
    let t = 0.1;
    let (u, y) = couette::<f32>(40, 0.0);
    let base = linf(&u, &y, t);
    let (u10, y10) = couette_quantized::<f32>(40, 0.0, Some(10.0));
    let (u100, y100) = couette_quantized::<f32>(40, 0.0, Some(100.0));
    let (e10, e100) = (linf(&u10, &y10, t), linf(&u100, &y100, t));
    assert!(
        base < e10 && e10 < e100,
        "error must grow with the rounding: {base:e}, {e10:e}, {e100:e}"
    );
    assert!(e100 > 10.0 * base, "half-dx rounding: {e100:e} vs {base:e}");
}

#[test]
fn a_scene_far_from_the_origin_keeps_full_resolution() {
    // Positions are relative to the domain's corner: moving the corner 1e4 gap
    // widths away changes nothing inside, bit for bit, even in f32.
    let (u_near, _) = couette::<f32>(12, 0.0);
    let (u_far, _) = couette::<f32>(12, 10.0);
    assert_eq!(u_near, u_far);
}

#[test]
fn one_and_three_dimensional_scenes_stay_at_rest() {
    // 1D: a periodic line; 3D: a periodic x-z slab between no-slip walls in y.
    let n = 12;
    let dx = 1.0 / n as f64;
    let x1: Vec<Vector<f64, 1>> = (0..n)
        .map(|i| Vector::new([(i as f64 + 0.5) * dx]))
        .collect();
    let domain1 = Domain::<D1<f64>>::new(Vector::new([0.0]), Vector::new([1.0]))
        .unwrap()
        .with_periodic(0)
        .unwrap();
    let cells =
        Solver::<D1<f64>, WendlandC2, Libm, (), ()>::cells_needed(&domain1, 1.5 * dx).unwrap();
    let mut b = Buffers::<D1<f64>>::new(&x1, &vec![Vector::zero(); n], dx, 1.0, 0, cells);
    let params = Params::new(
        1.5 * dx,
        Eos::Linear {
            rho0: 1.0,
            c0: 1.0,
            p0: 0.0,
        },
    );
    let mut s = Solver::<D1<f64>, WendlandC2, Libm, _, _>::new(
        params,
        domain1,
        b.storage(),
        n,
        SummationDensity,
        (PressureGradient, MorrisViscosity { mu: 0.01 }),
    )
    .unwrap();
    s.calibrate_mass(1.0).unwrap();
    for _ in 0..20 {
        s.step(1e-3).unwrap();
    }
    assert!(s.velocities().iter().all(|v| v[0].abs() < 1e-13));

    let m = 8;
    let dx = 1.0 / m as f64;
    let mut x3 = Vec::new();
    for k in 0..m {
        for j in 0..m {
            for i in 0..m {
                x3.push(Vector::new([
                    (i as f64 + 0.5) * dx,
                    (j as f64 + 0.5) * dx,
                    (k as f64 + 0.5) * dx,
                ]));
            }
        }
    }
    let domain3 = Domain::<D3<f64>>::new(Vector::new([0.0; 3]), Vector::new([1.0; 3]))
        .unwrap()
        .with_periodic(0)
        .unwrap()
        .with_periodic(2)
        .unwrap()
        .with_wall(1, Side::Lower, Wall::no_slip())
        .unwrap()
        .with_wall(1, Side::Upper, Wall::no_slip())
        .unwrap();
    let h = dx;
    let cells = Solver::<D3<f64>, QuinticSpline, Libm, (), ()>::cells_needed(&domain3, h).unwrap();
    let mut b = Buffers::<D3<f64>>::new(
        &x3,
        &vec![Vector::zero(); x3.len()],
        dx * dx * dx,
        1.0,
        2 * x3.len(),
        cells,
    );
    let params = Params::new(
        h,
        Eos::Linear {
            rho0: 1.0,
            c0: 1.0,
            p0: 0.0,
        },
    );
    let mut s = Solver::<D3<f64>, QuinticSpline, Libm, _, _>::new(
        params,
        domain3,
        b.storage(),
        x3.len(),
        SummationDensity,
        (PressureGradient, PiViscosity { mu: 0.01 }),
    )
    .unwrap();
    s.calibrate_mass(1.0).unwrap();
    let rho_spread = s
        .densities()
        .iter()
        .fold(0.0f64, |a, r| a.max((r - 1.0).abs()));
    assert!(
        rho_spread < 1e-12,
        "mirrored ghosts complete every support: {rho_spread:e}"
    );
    for _ in 0..20 {
        s.step(1e-3).unwrap();
    }
    assert!(s.velocities().iter().all(|v| v.norm2().sqrt() < 1e-12));
}

#[test]
fn the_heapless_store_drives_a_solver_without_an_allocator() {
    const N: usize = 256;
    const C: usize = 64;
    let mut store: Store<D2<f32>, N, C> = Store::new();
    let n = 10;
    let dx = 0.1f32;
    for j in 0..n {
        for i in 0..6 {
            store
                .push(
                    Vector::new([(i as f32 + 0.5) * dx, (j as f32 + 0.5) * dx]),
                    Vector::zero(),
                    0.01,
                    1.0,
                )
                .unwrap();
        }
    }
    let domain = Domain::<D2<f32>>::new(Vector::new([0.0, 0.0]), Vector::new([0.6, 1.0]))
        .unwrap()
        .with_periodic(0)
        .unwrap()
        .with_wall(1, Side::Lower, Wall::no_slip())
        .unwrap()
        .with_wall(1, Side::Upper, Wall::moving(Vector::new([0.01, 0.0])))
        .unwrap();
    assert!(
        Solver::<D2<f32>, CubicSpline, Libm, (), ()>::cells_needed(&domain, 0.13).unwrap() <= C
    );
    let (storage, n_fluid) = store.storage().unwrap();
    let params = Params::new(
        0.13f32,
        Eos::Linear {
            rho0: 1.0,
            c0: 0.1,
            p0: 0.0,
        },
    );
    let mut s = Solver::<D2<f32>, CubicSpline, Libm, _, _>::new(
        params,
        domain,
        storage,
        n_fluid,
        SummationDensity,
        (PressureGradient, MorrisViscosity { mu: 0.01f32 }),
    )
    .unwrap();
    s.calibrate_mass(1.0).unwrap();
    let dt = 0.5 * s.limits().min();
    for _ in 0..50 {
        s.step(dt).unwrap();
    }
    // Momentum flows in from the moving wall: the top row moves, and no speed exceeds the wall's.
    let top = s.velocities()[n_fluid - 1][0];
    assert!(top > 0.0 && s.velocities().iter().all(|v| v[0] <= 0.01 && v[0] >= -1e-6));
    assert!(
        core::mem::size_of::<Store<D2<f32>, N, C>>()
            >= N * sph_core::solver::bytes_per_particle::<D2<f32>>()
    );
}
