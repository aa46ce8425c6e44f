//! The chunked update API, every error variant, and no panic on any input.

mod common;

use common::*;
use proptest::prelude::*;
use sph_core::exec::Chunked;
use sph_core::prelude::*;

type Forces = (Continuity, PressureGradient, MorrisViscosity<f64>);

fn disordered_channel(
    buffers: &mut Buffers<D2<f64>>,
    n: usize,
    nx: usize,
) -> Solver<'_, D2<f64>, CubicSpline, Libm, SummationDensity, Forces> {
    let dx = 1.0 / n as f64;
    let domain = channel(nx as f64 * dx, 1.0, 0.01);
    let params = Params::new(
        1.3 * dx,
        Eos::Linear {
            rho0: 1.0,
            c0: 1.0,
            p0: 0.0,
        },
    );
    let forces = (Continuity, PressureGradient, MorrisViscosity { mu: 0.01 });
    Solver::new(
        params,
        domain,
        buffers.storage(),
        n * nx,
        SummationDensity,
        forces,
    )
    .unwrap()
}

fn disordered_buffers(n: usize, nx: usize, seed: u64) -> Buffers<D2<f64>> {
    let dx = 1.0 / n as f64;
    let mut rng = Rng(seed);
    let x: Vec<V2> = lattice_2d(nx, n, dx)
        .into_iter()
        .map(|p| {
            V2::new([
                p[0] + 0.3 * dx * rng.next(),
                (p[1] + 0.3 * dx * rng.next()).clamp(0.0, 1.0),
            ])
        })
        .collect();
    let v: Vec<V2> = x
        .iter()
        .map(|_| V2::new([0.01 * rng.next(), 0.01 * rng.next()]))
        .collect();
    let domain = channel(nx as f64 * dx, 1.0, 0.0);
    Buffers::new(
        &x,
        &v,
        dx * dx,
        1.0,
        4 * n * nx,
        cells_for::<CubicSpline>(&domain, 1.3 * dx),
    )
}

#[test]
fn random_chunks_in_random_order_give_bitwise_the_same_rates() {
    let (n, nx) = (20, 7);
    let mut b = disordered_buffers(n, nx, 3);
    let s = disordered_channel(&mut b, n, nx);
    let total = s.n_fluid();
    let reference: Vec<V2> = s.accelerations().to_vec();
    let reference_drho: Vec<f64> = s.density_rates().to_vec();
    assert!(
        reference_drho.iter().any(|d| *d != 0.0),
        "the continuity term must be exercised"
    );
    let mut rng = Rng(99);
    for _ in 0..20 {
        // A random partition of 0..total.
        let mut cuts: Vec<usize> = (0..rng.below(12)).map(|_| rng.below(total)).collect();
        cuts.extend([0, total]);
        cuts.sort_unstable();
        cuts.dedup();
        let mut ranges: Vec<(usize, usize)> = cuts.windows(2).map(|w| (w[0], w[1])).collect();
        // Random order.
        for k in (1..ranges.len()).rev() {
            ranges.swap(k, rng.below(k + 1));
        }
        let mut dv = vec![V2::zero(); total];
        let mut drho = vec![0.0; total];
        for (a, b) in ranges {
            s.rates_range(a, &mut dv[a..b], &mut drho[a..b]).unwrap();
        }
        for i in 0..total {
            assert_eq!(dv[i][0].to_bits(), reference[i][0].to_bits());
            assert_eq!(dv[i][1].to_bits(), reference[i][1].to_bits());
            assert_eq!(drho[i].to_bits(), reference_drho[i].to_bits());
        }
    }
    let mut rho = vec![0.0; total];
    s.density_range(0, &mut rho).unwrap();
    assert_eq!(rho, s.densities());
}

#[test]
fn the_rates_of_the_parts_add_up_to_the_rates_of_the_whole() {
    let (n, nx) = (20, 7);
    let mut b = disordered_buffers(n, nx, 5);
    let s = disordered_channel(&mut b, n, nx);
    let total = s.n_fluid();
    let mut parts = [
        (vec![V2::zero(); total], vec![0.0; total]),
        (vec![V2::zero(); total], vec![0.0; total]),
        (vec![V2::zero(); total], vec![0.0; total]),
    ];
    s.rates_range_of(&Continuity, 0, &mut parts[0].0, &mut parts[0].1)
        .unwrap();
    s.rates_range_of(&PressureGradient, 0, &mut parts[1].0, &mut parts[1].1)
        .unwrap();
    s.rates_range_of(
        &MorrisViscosity { mu: 0.01 },
        0,
        &mut parts[2].0,
        &mut parts[2].1,
    )
    .unwrap();
    let scale2 = s
        .accelerations()
        .iter()
        .map(|a| a.norm2())
        .fold(0.0, f64::max);
    let mut viscous = 0.0f64;
    for i in 0..total {
        // The continuity term moves no particle, the others change no density.
        assert_eq!(parts[0].0[i], V2::zero());
        assert_eq!((parts[1].1[i], parts[2].1[i]), (0.0, 0.0));
        assert_eq!(parts[0].1[i], s.density_rates()[i]);
        let sum = parts[1].0[i] + parts[2].0[i];
        assert!(
            (sum - s.accelerations()[i]).norm2() <= 1e-24 * scale2,
            "particle {i}"
        );
        viscous = viscous.max(parts[2].0[i].norm2());
    }
    assert!(viscous > 0.0, "the viscous term must be exercised");
    // The same checks as the solver's own group.
    let mut dv = vec![V2::zero(); 2];
    assert!(s
        .rates_range_of(&PressureGradient, total - 1, &mut dv, &mut [0.0; 2])
        .is_err());
}

#[test]
fn chunked_stepping_matches_serial_stepping_bitwise() {
    let (n, nx) = (16, 6);
    let mut b1 = disordered_buffers(n, nx, 8);
    let mut b2 = disordered_buffers(n, nx, 8);
    let mut serial = disordered_channel(&mut b1, n, nx);
    let mut chunked = disordered_channel(&mut b2, n, nx);
    let dt = 0.5 * serial.limits().min();
    for _ in 0..30 {
        serial.step(dt).unwrap();
        chunked.step_with(&Chunked { size: 7 }, dt).unwrap();
    }
    assert_eq!(serial.positions(), chunked.positions());
    assert_eq!(serial.velocities(), chunked.velocities());
    assert_eq!(serial.densities(), chunked.densities());
}

#[test]
fn range_arguments_are_checked() {
    let (n, nx) = (10, 6);
    let mut b = disordered_buffers(n, nx, 1);
    let s = disordered_channel(&mut b, n, nx);
    let mut dv = vec![V2::zero(); 5];
    let mut drho = vec![0.0; 4];
    assert!(matches!(
        s.rates_range(0, &mut dv, &mut drho),
        Err(Error::LengthMismatch { .. })
    ));
    let mut drho = vec![0.0; 5];
    assert!(matches!(
        s.rates_range(58, &mut dv, &mut drho),
        Err(Error::InvalidParameter { name: "range", .. })
    ));
    assert!(matches!(
        s.rates_range(usize::MAX, &mut dv, &mut drho),
        Err(Error::InvalidParameter { .. })
    ));
}

type Scene<'a> = Solver<
    'a,
    D2<f64>,
    CubicSpline,
    Libm,
    SummationDensity,
    (PressureGradient, MorrisViscosity<f64>),
>;

/// Builds a 10 x 6 channel scene from parts that a test may break.
fn build(b: &mut Buffers<D2<f64>>, h: f64, n_fluid: usize) -> Result<Scene<'_>> {
    let domain = channel(0.6, 1.0, 0.0);
    Solver::new(
        Params::new(
            h,
            Eos::Linear {
                rho0: 1.0,
                c0: 1.0,
                p0: 0.0,
            },
        ),
        domain,
        b.storage(),
        n_fluid,
        SummationDensity,
        (PressureGradient, MorrisViscosity { mu: 0.01 }),
    )
}

fn lattice_buffers(spare: usize) -> Buffers<D2<f64>> {
    let x = lattice_2d(6, 10, 0.1);
    let v = vec![V2::zero(); x.len()];
    Buffers::new(
        &x,
        &v,
        0.01,
        1.0,
        spare,
        cells_for::<CubicSpline>(&channel(0.6, 1.0, 0.0), 0.13),
    )
}

#[test]
fn each_error_names_what_and_where() {
    // Ghost capacity: 12 rows near the walls need ghosts, none reserved.
    let mut b = lattice_buffers(0);
    match build(&mut b, 0.13, 60) {
        Err(Error::CapacityExceeded {
            buffer: "ghosts",
            needed,
            available: 0,
        }) => assert!(needed > 0),
        other => panic!("{other:?}"),
    }
    // More fluid than capacity.
    let mut b = lattice_buffers(0);
    assert!(matches!(
        build(&mut b, 0.13, 61),
        Err(Error::CapacityExceeded {
            buffer: "particles",
            ..
        })
    ));
    // A slice of the wrong length.
    let mut b = lattice_buffers(40);
    b.v.pop();
    assert!(matches!(
        build(&mut b, 0.13, 60),
        Err(Error::LengthMismatch { buffer: "v", .. })
    ));
    // Invalid parameter.
    let mut b = lattice_buffers(40);
    assert!(matches!(
        build(&mut b, -0.13, 60),
        Err(Error::InvalidParameter { name: "h", .. })
    ));
    // Non-finite input.
    let mut b = lattice_buffers(40);
    b.v[7] = V2::new([f64::NAN, 0.0]);
    assert_eq!(
        build(&mut b, 0.13, 60).err(),
        Some(Error::NonFinite {
            particle: 7,
            field: "velocity"
        })
    );
    // Outside the domain (through the lower wall).
    let mut b = lattice_buffers(40);
    b.x[3] = V2::new([0.35, -0.01]);
    assert!(matches!(
        build(&mut b, 0.13, 60),
        Err(Error::OutsideDomain {
            particle: 3,
            axis: 1,
            ..
        })
    ));
    // Non-positive mass.
    let mut b = lattice_buffers(40);
    b.m[0] = 0.0;
    assert!(matches!(
        build(&mut b, 0.13, 60),
        Err(Error::InvalidParameter { name: "mass", .. })
    ));
    // Bad time step, then a blow-up reported with step and particle.
    let mut b = lattice_buffers(40);
    b.v[20] = V2::new([0.5, 0.0]);
    let mut s = build(&mut b, 0.13, 60).unwrap();
    assert!(matches!(
        s.step(-1.0),
        Err(Error::InvalidParameter { name: "dt", .. })
    ));
    assert!(matches!(
        s.step(f64::NAN),
        Err(Error::InvalidParameter { name: "dt", .. })
    ));
    let huge = 1e4 * s.limits().min();
    let mut result = Ok(());
    for _ in 0..50 {
        result = s.step(huge);
        if result.is_err() {
            break;
        }
    }
    match result {
        Err(e @ Error::Unstable { step, .. }) => {
            assert!(step >= 1);
            // Later calls keep reporting the same failure.
            assert_eq!(s.step(1e-6), Err(e));
        }
        other => panic!("expected an unstable run, got {other:?}"),
    }
}

#[test]
fn degenerate_scenes_run_without_nan() {
    // An empty domain.
    let mut b = Buffers::<D2<f64>>::new(
        &[],
        &[],
        1.0,
        1.0,
        4,
        cells_for::<CubicSpline>(&channel(0.6, 1.0, 0.0), 0.13),
    );
    let mut s = build(&mut b, 0.13, 0).unwrap();
    s.step(1e-3).unwrap();
    assert_eq!(s.n_fluid(), 0);
    // One particle, exactly on the lower wall, and two coincident particles on a cell edge.
    let x = [
        V2::new([0.3, 0.0]),
        V2::new([0.26, 0.52]),
        V2::new([0.26, 0.52]),
    ];
    let v = [V2::zero(); 3];
    let mut b = Buffers::<D2<f64>>::new(
        &x,
        &v,
        0.01,
        1.0,
        8,
        cells_for::<CubicSpline>(&channel(0.6, 1.0, 0.0), 0.13),
    );
    let mut s = build(&mut b, 0.13, 3).unwrap();
    for _ in 0..10 {
        s.step(1e-3).unwrap();
    }
    assert!(s.velocities().iter().all(|v| v.is_finite()));
    assert!(s.densities().iter().all(|r| r.is_finite() && *r > 0.0));
    // Capacity exactly full: 6 x 10 lattice, ghosts for 2 rows x 6 per wall x 2 walls (h = 0.13, 2h < 0.3).
    let mut b = lattice_buffers(0);
    let needed = match build(&mut b, 0.13, 60) {
        Err(Error::CapacityExceeded { needed, .. }) => needed,
        other => panic!("{other:?}"),
    };
    let mut b = lattice_buffers(needed);
    let mut s = build(&mut b, 0.13, 60).unwrap();
    assert_eq!(s.n_ghost(), needed);
    s.step(1e-3).unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Arbitrary (often invalid) input never panics: it is `Ok` or a clear `Err`.
    #[test]
    fn no_panic_on_arbitrary_input(
        h in prop_oneof![Just(f64::NAN), Just(-1.0), Just(0.0), 1e-3f64..0.4, Just(1e30)],
        eta2 in prop_oneof![Just(0.0), Just(-1.0), 0.0f64..0.1],
        c0 in prop_oneof![Just(0.0), Just(f64::INFINITY), 0.1f64..10.0],
        pts in proptest::collection::vec(
            (prop_oneof![-0.1f64..0.7, Just(0.0), Just(0.6), Just(f64::NAN)], prop_oneof![-0.1f64..1.1, Just(0.0), Just(1.0)]),
            0..40),
        spare in 0usize..60,
        cells in 0usize..400,
        dt in prop_oneof![Just(0.0), Just(f64::NAN), 1e-6f64..1e2],
    ) {
        let x: Vec<V2> = pts.iter().map(|&(a, b)| V2::new([a, b])).collect();
        let v = vec![V2::new([0.01, 0.0]); x.len()];
        let mut b = Buffers::<D2<f64>>::new(&x, &v, 0.01, 1.0, spare, cells);
        let domain = channel(0.6, 1.0, 0.1);
        let params = Params::new(h, Eos::Linear { rho0: 1.0, c0, p0: 0.0 }).with_eta2(eta2);
        let built = Solver::<D2<f64>, CubicSpline, Libm, _, _>::new(
            params, domain, b.storage(), x.len(), SummationDensity, (PressureGradient, MorrisViscosity { mu: 0.01 }),
        );
        if let Ok(mut s) = built {
            for _ in 0..5 {
                if s.step(dt).is_err() {
                    break;
                }
            }
            prop_assert!(s.velocities().iter().all(|v| v.is_finite()) || s.step(dt).is_err());
        }
    }
}

/// A disordered channel run for `steps` steps, with Verlet lists of `width`
/// (0: cell scan); returns the final velocities.
fn channel_run(width: usize, skin: f64, steps: usize) -> Result<Vec<V2>> {
    let (n, nx) = (16, 6);
    let mut b = disordered_buffers(n, nx, 21);
    if width > 0 {
        b = b.with_lists(width);
    }
    let dx = 1.0 / n as f64;
    let domain = channel(nx as f64 * dx, 1.0, 0.01);
    let params = Params::new(
        1.3 * dx,
        Eos::Linear {
            rho0: 1.0,
            c0: 1.0,
            p0: 0.5,
        },
    )
    .with_skin(skin);
    let forces = (Continuity, PressureGradient, MorrisViscosity { mu: 0.01 });
    let mut s = Solver::<D2<f64>, CubicSpline, Libm, _, _>::new(
        params,
        domain,
        b.storage(),
        n * nx,
        SummationDensity,
        forces,
    )?;
    let dt = 0.5 * s.limits().min();
    for _ in 0..steps {
        s.step(dt)?;
    }
    assert!(
        width == 0 || s.neighbour_builds() > 1,
        "lists must have been rebuilt"
    );
    Ok(s.velocities().to_vec())
}

#[test]
fn verlet_lists_reproduce_the_cell_scan_to_round_off() {
    // The lists hold every pair within (1 + skin) R and are rebuilt before any
    // pair can cross the skin, so the physics is the cell scan's; only the
    // order of summation differs.
    let scan = channel_run(0, 0.1, 300).unwrap();
    for skin in [0.02, 0.1] {
        let lists = channel_run(48, skin, 300).unwrap();
        let scale = scan.iter().fold(0.0f64, |m, v| m.max(v.norm2().sqrt()));
        let diff = scan
            .iter()
            .zip(&lists)
            .fold(0.0f64, |m, (a, b)| m.max((*a - *b).norm2().sqrt()));
        assert!(
            diff <= 1e-10 * scale,
            "skin {skin}: lists differ from the scan by {diff:e} (scale {scale:e})"
        );
    }
}

#[test]
fn a_full_neighbour_row_is_an_error_naming_the_count() {
    match channel_run(8, 0.1, 1) {
        Err(Error::CapacityExceeded {
            buffer: "neighbours",
            needed,
            available: 8,
        }) => assert!(needed > 8),
        other => panic!("expected a neighbour capacity error, got {other:?}"),
    }
}

#[test]
fn a_step_bounded_by_its_own_drift_is_the_plain_step_and_rebuilds_are_predicted() {
    // Two solvers on the same disordered channel: one steps plainly, the
    // other with the bound a distributed run would pass (its own fastest
    // drift here, the largest of the parts there). The drift bound is the
    // drift's own figure, so the travel, the rebuilds and every bit agree,
    // and `rebuilds_next` says beforehand which steps rebuild.
    let (n, nx) = (16, 6);
    let mut a = disordered_buffers(n, nx, 5).with_lists(48);
    let mut b = disordered_buffers(n, nx, 5).with_lists(48);
    let mut plain = disordered_channel(&mut a, n, nx);
    let mut bounded = disordered_channel(&mut b, n, nx);
    let dt = 0.5 * plain.limits().min();
    let mut predicted = 0;
    for _ in 0..200 {
        let drift2 = bounded.drift_speed2(dt);
        let rebuild = bounded.rebuilds_next(dt, drift2);
        let before = bounded.neighbour_builds();
        plain.step(dt).unwrap();
        bounded.step_bounded_with(&Serial, dt, drift2).unwrap();
        assert_eq!(bounded.neighbour_builds() != before, rebuild);
        predicted += rebuild as u32;
    }
    assert!(predicted > 1, "the run must rebuild its lists");
    for (p, q) in plain.positions().iter().zip(bounded.positions()) {
        assert_eq!(p.0.map(f64::to_bits), q.0.map(f64::to_bits));
    }
    // A larger bound spends the skin sooner: more rebuilds, the same
    // physics to round-off (the lists stay exact).
    let mut c = disordered_buffers(n, nx, 5).with_lists(48);
    let mut eager = disordered_channel(&mut c, n, nx);
    for _ in 0..200 {
        let drift2 = 4.0 * eager.drift_speed2(dt);
        eager.step_bounded_with(&Serial, dt, drift2).unwrap();
    }
    assert!(eager.neighbour_builds() > bounded.neighbour_builds());
    for (p, q) in plain.velocities().iter().zip(eager.velocities()) {
        assert!(
            (*p - *q).norm2().sqrt() <= 1e-10 * 0.01,
            "{p:?} against {q:?}"
        );
    }
    // A bound that is not a speed is refused by name.
    assert!(matches!(
        eager.step_bounded_with(&Serial, dt, f64::NAN),
        Err(Error::InvalidParameter { name: "drift2", .. })
    ));
}
