//! Micro-benchmarks of the core's building blocks (divan):
//! `cargo bench -p sph-core --bench core`.
//!
//! - kernel evaluation (`W` and `F` sharing one square root), per kernel;
//! - cell-list build (counting sort) against N;
//! - neighbour search: cell list (build + visit) against brute force, to find
//!   the crossover;
//! - one force pass (pressure + Morris) over a disordered 2D box.

use divan::{black_box, Bencher};
use sph_core::boundary::Ghost;
use sph_core::kernel::SmoothingKernel;
use sph_core::neighbour::{brute_force, CellList, Grid};
use sph_core::prelude::*;

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
        let (mut xs, mut v, mut m, mut rho, mut p, mut ve, mut dv) = (
            x.clone(),
            vec![V2::zero(); n],
            vec![h * h / 1.69; n],
            vec![1.0; n],
            vec![0.0; n],
            vec![V2::zero(); n],
            vec![V2::zero(); n],
        );
        let (mut drho, mut rho_aux, mut ghosts) =
            (vec![0.0; n], vec![0.0; n], vec![Ghost::default(); n]);
        let (mut start, mut sorted, mut cell) = (vec![0u32; cells], vec![0u32; n], vec![0u32; n]);
        let (mut nbr, mut counts) = (vec![0u32; n * 48], vec![0u32; n]);
        let storage = Storage {
            x: &mut xs,
            v: &mut v,
            m: &mut m,
            rho: &mut rho,
            p: &mut p,
            ve: &mut ve,
            dv: &mut dv,
            drho: &mut drho,
            rho_aux: &mut rho_aux,
            ghosts: &mut ghosts,
            cell_start: &mut start,
            cell_sorted: &mut sorted,
            cell_index: &mut cell,
            neighbours: &mut nbr,
            neighbour_counts: &mut counts,
            shift: &mut [],
        };
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
            storage,
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
