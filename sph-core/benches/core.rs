//! Micro-benchmarks of the core's building blocks (divan):
//! `cargo bench -p sph-core --bench core`.
//!
//! - kernel evaluation (`W` and `F` sharing one square root), per kernel;
//! - cell-list build (counting sort) against N;
//! - neighbour search: cell list (build + visit) against brute force, to find
//!   the crossover;
//! - one force pass (pressure + Morris) over a disordered 2D box;
//! - whole steps of `sph bench`'s 2D box, summation or continuity density,
//!   `f64` or `f32` (`-- steps`), and the `f64` summation step on libm's
//!   square root against the compiler's (`summation_f64_host`: the same
//!   bits; build with `RUSTFLAGS="-C target-cpu=native"` to see what libm's
//!   inline assembly costs in AVX code).

use divan::{black_box, Bencher};
use sph_core::kernel::SmoothingKernel;
use sph_core::neighbour::{brute_force, CellList, Grid};
use sph_core::prelude::*;

// The integration tests' Vec-owned storage.
#[path = "../tests/common/mod.rs"]
mod common;

fn main() {
    divan::main();
}

type V2 = Vector<f64, 2>;

fn cloud(n: usize) -> (Domain<D2<f64>>, Vec<V2>, f64) {
    let side = (n as f64).sqrt().ceil() as usize;
    let dx = 1.0 / side as f64;
    let mut state = 0x1234_5678_9abc_def1u64;
    let mut rnd = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let x = (0..n)
        .map(|k| {
            V2::new([
                ((k % side) as f64 + 0.5 + 0.1 * rnd()) * dx,
                ((k / side) as f64 + 0.5 + 0.1 * rnd()) * dx,
            ])
        })
        .collect();
    let domain = Domain::new(V2::new([0.0, 0.0]), V2::new([1.0, 1.0]))
        .unwrap()
        .with_periodic(0)
        .unwrap()
        .with_periodic(1)
        .unwrap();
    (domain, x, 2.6 * dx)
}

mod kernels {
    use super::*;

    fn eval<K: Kernel>(bencher: Bencher) {
        let k = SmoothingKernel::<D2<f64>, K, Libm>::new(1.0).unwrap();
        let r2: Vec<f64> = (0..1024)
            .map(|i| (K::SUPPORT * i as f64 / 1024.0).powi(2))
            .collect();
        bencher
            .counter(divan::counter::ItemsCount::new(r2.len()))
            .bench(|| {
                let mut s = 0.0;
                for &r in &r2 {
                    let (w, f) = k.w_and_f(black_box(r));
                    s += w + f;
                }
                s
            });
    }

    #[divan::bench]
    fn cubic(b: Bencher) {
        eval::<CubicSpline>(b)
    }
    #[divan::bench]
    fn quintic(b: Bencher) {
        eval::<QuinticSpline>(b)
    }
    #[divan::bench]
    fn wendland_c2(b: Bencher) {
        eval::<WendlandC2>(b)
    }
    #[divan::bench]
    fn wendland_c4(b: Bencher) {
        eval::<WendlandC4>(b)
    }
    #[divan::bench]
    fn gaussian(b: Bencher) {
        eval::<Gaussian>(b)
    }
}

mod neighbours {
    use super::*;

    #[divan::bench(args = [1_000, 10_000, 100_000])]
    fn cell_list_build(bencher: Bencher, n: usize) {
        let (domain, x, radius) = cloud(n);
        let grid = Grid::new(&domain, radius).unwrap();
        let mut start = vec![0u32; grid.cell_count() + 1];
        let (mut sorted, mut cell) = (vec![0u32; n], vec![0u32; n]);
        bencher
            .counter(divan::counter::ItemsCount::new(n))
            .bench_local(|| {
                CellList::new(&mut start, &mut sorted, &mut cell)
                    .build(&grid, black_box(&x))
                    .unwrap();
            });
    }

    /// An open box (no periodic axes), so that any N is allowed.
    fn closed(n: usize) -> (Domain<D2<f64>>, Vec<V2>, f64) {
        let (_, x, radius) = cloud(n);
        (
            Domain::new(V2::new([0.0, 0.0]), V2::new([1.0, 1.0])).unwrap(),
            x,
            radius,
        )
    }

    /// Build and visit every pair with the cell list (about 21 neighbours each).
    #[divan::bench(args = [16, 64, 256, 1024, 4096])]
    fn cells_all_pairs(bencher: Bencher, n: usize) {
        let (domain, x, radius) = closed(n);
        let grid = Grid::new(&domain, radius).unwrap();
        let mut start = vec![0u32; grid.cell_count() + 1];
        let (mut sorted, mut cell) = (vec![0u32; n], vec![0u32; n]);
        bencher.bench_local(|| {
            let mut list = CellList::new(&mut start, &mut sorted, &mut cell);
            list.build(&grid, &x).unwrap();
            let view = list.view();
            let mut count = 0usize;
            for i in 0..n {
                view.for_each_neighbour(&grid, &x, i, |_, _, _| count += 1)
                    .unwrap();
            }
            count
        });
    }

    /// Visit every pair by brute force (the reference).
    #[divan::bench(args = [16, 64, 256, 1024, 4096])]
    fn brute_all_pairs(bencher: Bencher, n: usize) {
        let (domain, x, radius) = closed(n);
        bencher.bench_local(|| {
            let mut count = 0usize;
            brute_force(&domain, &x, radius, |_, _, _, _| count += 1);
            count
        });
    }
}

mod rates {
    use super::*;

    /// A prepared disordered periodic box with the force group `T`; times one
    /// force pass over every particle.
    fn force_pass<T: Term<D2<f64>>>(bencher: Bencher, n: usize, forces: T) {
        let (domain, x, radius) = cloud(n);
        let h = radius / 2.0;
        let cells = Solver::<D2<f64>, CubicSpline, Libm, (), ()>::cells_needed(&domain, h).unwrap();
        let v = vec![V2::zero(); n];
        let mut b =
            common::Buffers::<D2<f64>>::new(&x, &v, h * h / 1.69, 1.0, 0, cells).with_lists(48);
        let params = Params::new(
            h,
            Eos::Linear {
                rho0: 1.0,
                c0: 10.0,
                p0: 0.0,
            },
        );
        let s = Solver::<D2<f64>, CubicSpline, Libm, _, _>::new(
            params,
            domain,
            b.storage(),
            n,
            SummationDensity,
            forces,
        )
        .unwrap();
        let mut out = vec![V2::zero(); n];
        let mut out_rho = vec![0.0; n];
        bencher
            .counter(divan::counter::ItemsCount::new(n))
            .bench_local(|| {
                s.rates_range(0, &mut out, &mut out_rho).unwrap();
            });
    }

    /// Pressure gradient and Morris viscosity: the benchmark scene's physics.
    #[divan::bench(args = [10_000, 40_000])]
    fn pressure_morris(bencher: Bencher, n: usize) {
        force_pass(bencher, n, (PressureGradient, MorrisViscosity { mu: 1e-3 }));
    }

    /// A scene that needs only pressure pays only for pressure.
    #[divan::bench(args = [40_000])]
    fn pressure_only(bencher: Bencher, n: usize) {
        force_pass(bencher, n, (PressureGradient,));
    }

    /// Adding a body force and continuity costs what they compute.
    #[divan::bench(args = [40_000])]
    fn pressure_morris_body_continuity(bencher: Bencher, n: usize) {
        force_pass(
            bencher,
            n,
            (
                Continuity,
                PressureGradient,
                MorrisViscosity { mu: 1e-3 },
                BodyForce {
                    g: V2::new([0.0, -9.81]),
                },
            ),
        );
    }

    /// The run-time choice of viscous form (one predictable branch per pair).
    #[divan::bench(args = [40_000])]
    fn pressure_any_viscosity(bencher: Bencher, n: usize) {
        force_pass(
            bencher,
            n,
            (
                PressureGradient,
                AnyViscosity::Morris(MorrisViscosity { mu: 1e-3 }),
            ),
        );
    }
}

/// Whole steps of the benchmark box (`sph bench`'s box2d: a jittered
/// lattice in a periodic unit square, random velocities at Mach 0.05, cubic
/// spline `h = 1.3 dx`, pressure and Morris viscosity, Verlet lists with skin
/// 0.1, reordered at every rebuild), after 300 warm-up steps, in the
/// configurations a user chooses between: summation or continuity density,
/// `f64` or `f32`. Items are particle-steps, so divan's rate is particle-steps
/// per second: `cargo bench -p sph-core --bench core -- steps`.
mod steps {
    use super::*;
    use sph_core::math::Math;

    /// Particles, as a 200 x 200 lattice.
    const SIDE: usize = 200;

    /// Host square root (the compiler's intrinsic, correctly rounded as
    /// libm's), libm for the rest: the `f64` half of `sph_std::math::Host`,
    /// written again here because the core's benches cannot depend on the
    /// frontend (it depends on the core).
    #[derive(Clone, Copy, Debug, Default)]
    struct Host;
    impl Math<f64> for Host {
        const NAME: &'static str = "host";
        #[inline(always)]
        fn sqrt(x: f64) -> f64 {
            x.sqrt()
        }
        #[inline(always)]
        fn exp(x: f64) -> f64 {
            <Libm as Math<f64>>::exp(x)
        }
        #[inline(always)]
        fn powf(x: f64, y: f64) -> f64 {
            <Libm as Math<f64>>::powf(x, y)
        }
        #[inline(always)]
        fn floor(x: f64) -> f64 {
            <Libm as Math<f64>>::floor(x)
        }
    }

    fn run<S, D, T>(bencher: Bencher, density: D, forces: T)
    where
        S: Space,
        D: Term<S>,
        T: Term<S>,
        Libm: Math<S::Real>,
    {
        run_with::<S, Libm, D, T>(bencher, density, forces)
    }

    fn run_with<S, M, D, T>(bencher: Bencher, density: D, forces: T)
    where
        S: Space,
        M: Math<S::Real>,
        D: Term<S>,
        T: Term<S>,
    {
        let n = SIDE * SIDE;
        let dx = 1.0 / SIDE as f64;
        let (beta, skin) = (1.3, 0.1);
        let f = S::Real::from_f64;
        let pair = |a: f64, b: f64| {
            let mut v = S::Vector::zero();
            v[0] = f(a);
            v[1] = f(b);
            v
        };
        let domain = Domain::<S>::new(S::Global::zero(), S::Vector::splat(f(1.0)))
            .and_then(|d| d.with_periodic(0))
            .and_then(|d| d.with_periodic(1))
            .unwrap();
        let h = f(beta * dx);
        let cells = Solver::<S, CubicSpline, M, D, T>::cells_needed(&domain, h).unwrap();
        let r = (1.0 + skin) * 2.0 * beta;
        let width = (1.5 * std::f64::consts::PI * r * r).ceil() as usize + 8;
        let mut state = 0x5eed_1234_abcd_0001u64;
        let mut rnd = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        };
        let mut x = vec![S::Vector::zero(); n];
        let mut v = vec![S::Vector::zero(); n];
        for k in 0..n {
            let (i, j) = ((k % SIDE) as f64, (k / SIDE) as f64);
            x[k] = pair((i + 0.5 + 0.05 * rnd()) * dx, (j + 0.5 + 0.05 * rnd()) * dx);
            v[k] = pair(0.5 * rnd(), 0.5 * rnd());
        }
        let mut b =
            common::Buffers::<S>::new(&x, &v, f(dx * dx), f(1.0), 0, cells).with_lists(width);
        let eos = Eos::Linear {
            rho0: f(1.0),
            c0: f(10.0),
            p0: S::Real::ZERO,
        };
        let params = Params::new(h, eos).with_reorder_every(1).with_skin(f(skin));
        let mut solver =
            Solver::<S, CubicSpline, M, D, T>::new(params, domain, b.storage(), n, density, forces)
                .unwrap();
        let dt = 0.5 * solver.limits().min();
        for _ in 0..300 {
            solver.step(dt).unwrap();
        }
        bencher
            .counter(divan::counter::ItemsCount::new(n))
            .bench_local(|| solver.step(dt).unwrap());
    }

    /// `sph bench`'s default: f64, summation density (two passes a step).
    #[divan::bench]
    fn summation_f64(bencher: Bencher) {
        run::<D2<f64>, _, _>(
            bencher,
            SummationDensity,
            (PressureGradient, MorrisViscosity { mu: 1e-3 }),
        );
    }

    /// The default with the host's square root.
    #[divan::bench]
    fn summation_f64_host(bencher: Bencher) {
        run_with::<D2<f64>, Host, _, _>(
            bencher,
            SummationDensity,
            (PressureGradient, MorrisViscosity { mu: 1e-3 }),
        );
    }

    /// Continuity density: one pass a step.
    #[divan::bench]
    fn continuity_f64(bencher: Bencher) {
        run::<D2<f64>, _, _>(
            bencher,
            (),
            (Continuity, PressureGradient, MorrisViscosity { mu: 1e-3 }),
        );
    }

    /// Summation density in `f32`.
    #[divan::bench]
    fn summation_f32(bencher: Bencher) {
        run::<D2<f32>, _, _>(
            bencher,
            SummationDensity,
            (PressureGradient, MorrisViscosity { mu: 1e-3f32 }),
        );
    }

    /// Continuity density in `f32`.
    #[divan::bench]
    fn continuity_f32(bencher: Bencher) {
        run::<D2<f32>, _, _>(
            bencher,
            (),
            (
                Continuity,
                PressureGradient,
                MorrisViscosity { mu: 1e-3f32 },
            ),
        );
    }
}
