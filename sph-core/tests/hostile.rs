//! Hostile input at every core entry point: term coefficients, storage
//! sizes, executors that lie about offsets, cell-list queries, ghost
//! generation, far-off periodic coordinates and corrupt resumed states.
//! Each is `Ok` or a typed `Err`, never a panic (the core's contract).

mod common;

use common::*;
use proptest::prelude::*;
use sph_core::boundary;
use sph_core::exec::{Chunk, Reduce};
use sph_core::neighbour::{CellList, Grid};
use sph_core::prelude::*;
use sph_core::solver::{Resume, MAX_VISCOUS_ITERATIONS};

type Forces = (
    PressureGradient,
    AnyViscosity<f64>,
    BodyForce<D2<f64>>,
    DensityDiffusion<D2<f64>>,
);
type Channel<'a> = Solver<'a, D2<f64>, CubicSpline, Libm, (), ((AnyContinuity,), Forces)>;

fn params() -> Params<f64> {
    Params::new(
        0.13,
        Eos::Linear {
            rho0: 1.0,
            c0: 1.0,
            p0: 0.0,
        },
    )
}

fn forces(visc: AnyViscosity<f64>, g: [f64; 2], delta: f64) -> ((AnyContinuity,), Forces) {
    (
        (AnyContinuity::Plain,),
        (
            PressureGradient,
            visc,
            BodyForce { g: V2::new(g) },
            DensityDiffusion::new(delta),
        ),
    )
}

/// A 6 x 10 lattice in a walled channel, with Verlet lists.
fn buffers() -> Buffers<D2<f64>> {
    let x = lattice_2d(6, 10, 0.1);
    let v: Vec<V2> = x.iter().map(|p| V2::new([0.05 * p[1], 0.0])).collect();
    Buffers::new(
        &x,
        &v,
        0.01,
        1.0,
        200,
        cells_for::<CubicSpline>(&channel(0.6, 1.0, 0.0), 0.13 * 1.1),
    )
    .with_lists(64)
}

fn build<'a>(b: &'a mut Buffers<D2<f64>>, f: ((AnyContinuity,), Forces)) -> Result<Channel<'a>> {
    Solver::new(params(), channel(0.6, 1.0, 0.1), b.storage(), 60, (), f)
}

fn morris(mu: f64) -> AnyViscosity<f64> {
    AnyViscosity::Morris(MorrisViscosity { mu })
}

#[test]
fn bad_term_coefficients_are_refused_by_name_before_any_step() {
    let cases: [(((AnyContinuity,), Forces), &str); 7] = [
        (forces(morris(f64::NAN), [0.0, 0.0], 0.0), "mu"),
        (forces(morris(-1.0), [0.0, 0.0], 0.0), "mu"),
        (
            forces(
                AnyViscosity::Pi(PiViscosity { mu: f64::INFINITY }),
                [0.0, 0.0],
                0.0,
            ),
            "mu",
        ),
        (
            forces(
                AnyViscosity::Artificial(ArtificialViscosity {
                    alpha: -0.1,
                    beta: 0.0,
                }),
                [0.0, 0.0],
                0.0,
            ),
            "alpha",
        ),
        (forces(morris(0.01), [f64::NAN, 0.0], 0.0), "g"),
        (forces(morris(0.01), [0.0, f64::NEG_INFINITY], 0.0), "g"),
        (forces(morris(0.01), [0.0, 0.0], f64::NAN), "delta"),
    ];
    for (f, name) in cases {
        let mut b = buffers();
        match build(&mut b, f) {
            Err(Error::InvalidParameter { name: got, .. }) => assert_eq!(got, name),
            other => panic!("{name}: {other:?}"),
        }
    }
    // A coefficient broken after construction is caught at the next step.
    let mut b = buffers();
    let mut s = build(&mut b, forces(morris(0.01), [0.0, 0.0], 0.0)).unwrap();
    s.step(1e-3).unwrap();
    s.forces_mut().1 .1 = morris(f64::NAN);
    assert!(matches!(
        s.step(1e-3),
        Err(Error::InvalidParameter { name: "mu", .. })
    ));
}

#[test]
fn absurd_power_iterations_are_refused_at_once() {
    for iterations in [0, MAX_VISCOUS_ITERATIONS + 1, u32::MAX] {
        let mut b = buffers();
        let mut p = params();
        p.viscous_iterations = iterations;
        let r = Channel::new(
            p,
            channel(0.6, 1.0, 0.1),
            b.storage(),
            60,
            (),
            forces(morris(0.01), [0.0, 0.0], 0.0),
        );
        assert!(matches!(
            r,
            Err(Error::InvalidParameter {
                name: "viscous_iterations",
                ..
            })
        ));
    }
}

/// An executor that hands every pass one piece at a wrong start offset.
struct Liar(usize);

impl Executor for Liar {
    fn run<P: Chunk, R: Reduce>(
        &self,
        parts: P,
        f: &(dyn Fn(usize, P) -> Result<R> + Sync),
    ) -> Result<R> {
        f(self.0, parts)
    }
}

#[test]
fn an_executor_with_a_wrong_offset_gets_an_error_not_a_panic() {
    for offset in [1, 59, 60, usize::MAX] {
        let mut b = buffers();
        let r = Channel::new_with(
            &Liar(offset),
            params(),
            channel(0.6, 1.0, 0.1),
            b.storage(),
            60,
            (),
            forces(morris(0.01), [0.0, 0.0], 0.0),
        );
        assert!(
            matches!(r, Err(Error::InvalidParameter { name: "start", .. })),
            "{offset}: {r:?}"
        );
        let mut b = buffers();
        let mut s = build(&mut b, forces(morris(0.01), [0.0, 0.0], 0.0)).unwrap();
        assert!(s.step_with(&Liar(offset), 1e-3).is_err());
    }
}

#[test]
fn cell_list_queries_check_the_index_the_positions_and_the_grid() {
    let x = lattice_2d(6, 10, 0.1);
    let domain = channel(0.6, 1.0, 0.0);
    let grid = Grid::new(&domain, 0.26).unwrap();
    let mut start = vec![0; grid.cell_count() + 1];
    let (mut sorted, mut cell) = (vec![0; 60], vec![0; 60]);
    let mut list = CellList::new(&mut start, &mut sorted, &mut cell);
    list.build(&grid, &x).unwrap();
    let view = list.view();
    let mut count = 0;
    view.for_each_neighbour(&grid, &x, 0, |_, _, _| count += 1)
        .unwrap();
    assert!(count > 1);
    assert!(view
        .for_each_neighbour(&grid, &x, 60, |_, _, _| {})
        .is_err());
    assert!(view
        .for_each_neighbour(&grid, &x[..30], 0, |_, _, _| {})
        .is_err());
    let coarse = Grid::new(&domain, 0.29).unwrap();
    let fine = Grid::new(&domain, 0.05).unwrap();
    for g in [coarse, fine] {
        // Another grid: an error or a visit, never an out-of-bounds access.
        let _ = view.for_each_neighbour(&g, &x, 59, |_, _, _| {});
    }
    assert!(view
        .for_each_neighbour(&fine, &x, 59, |_, _, _| {})
        .is_err());
}

#[test]
fn ghost_generation_checks_the_fluid_count() {
    let domain = channel(0.6, 1.0, 0.0);
    let mut x = lattice_2d(6, 10, 0.1);
    let mut ghosts = vec![Default::default(); 100];
    assert!(matches!(
        boundary::generate(&domain, 0.26, &mut x, 61, &mut ghosts),
        Err(Error::LengthMismatch { buffer: "x", .. })
    ));
}

#[test]
fn a_periodic_coordinate_far_beyond_the_box_is_refused_not_wrapped() {
    for far in [1e300, -1e300, 1e6] {
        let mut b = buffers();
        b.x[3] = V2::new([far, 0.5]);
        match build(&mut b, forces(morris(0.01), [0.0, 0.0], 0.0)) {
            Err(Error::OutsideDomain {
                particle: 3,
                axis: 0,
                ..
            }) => {}
            other => panic!("{far}: {other:?}"),
        }
    }
    // A few periods out is a position like any other.
    let mut b = buffers();
    b.x[3][0] += 3.0 * 0.6;
    assert!(build(&mut b, forces(morris(0.01), [0.0, 0.0], 0.0)).is_ok());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// Any buffer of the storage at any length: `Ok` or a typed error.
    #[test]
    fn no_panic_on_any_buffer_length(which in 0usize..16, len in 0usize..400, n in 0usize..80) {
        let mut b = buffers();
        b.resize(which, len);
        let r = Channel::new(
            params(), channel(0.6, 1.0, 0.1), b.storage(), n, (),
            forces(morris(0.01), [0.0, -1.0], 0.1),
        );
        if let Ok(mut s) = r {
            for _ in 0..3 {
                if s.step(1e-3).is_err() { break; }
            }
        }
    }

    /// A resumed state with corrupt buffers (ghost sources, cell list,
    /// neighbour rows and counts): `Ok` (and steps that are `Ok` or `Err`)
    /// or a typed error, never a panic.
    #[test]
    fn no_panic_on_corrupt_resumed_buffers(
        pokes in proptest::collection::vec((0usize..6, 0usize..120, any::<u32>()), 1..5),
        fresh in any::<bool>(),
    ) {
        resume_and_step(&pokes, |s| Resume { lists_fresh: fresh, ..s });
    }

    /// The same with corrupt scalars.
    #[test]
    fn no_panic_on_corrupt_resumed_scalars(
        n_ghost in prop_oneof![Just(None), (0usize..300).prop_map(Some)],
        cell_len in prop_oneof![Just(None), (0usize..300).prop_map(Some)],
        time in prop_oneof![Just(None), Just(Some(f64::NAN)), Just(Some(-1.0))],
        travel in prop_oneof![Just(None), Just(Some(f64::INFINITY)), Just(Some(1e3))],
        builds in any::<u32>(),
        fresh in any::<bool>(),
    ) {
        resume_and_step(&[], |s| Resume {
            n_ghost: n_ghost.unwrap_or(s.n_ghost),
            cell_len: cell_len.unwrap_or(s.cell_len),
            time: time.unwrap_or(s.time),
            travel: travel.unwrap_or(s.travel),
            builds,
            lists_fresh: fresh,
            ..s
        });
    }
}

/// Steps a channel 3 times, corrupts its buffers with `pokes` and its
/// state with `edit`, resumes and steps again: must not panic.
fn resume_and_step(pokes: &[(usize, usize, u32)], edit: impl Fn(Resume) -> Resume) {
    let mut b = buffers();
    let state = {
        let mut s = build(&mut b, forces(morris(0.01), [0.0, -1.0], 0.1)).unwrap();
        for _ in 0..3 {
            s.step(1e-3).unwrap();
        }
        s.resume_state()
    };
    for &(which, k, value) in pokes {
        b.poke(which, k, value);
    }
    let r = Channel::resume_with(
        params(),
        channel(0.6, 1.0, 0.1),
        b.storage(),
        60,
        (),
        forces(morris(0.01), [0.0, -1.0], 0.1),
        edit(state),
    );
    if let Ok(mut s) = r {
        for _ in 0..3 {
            if s.step(1e-3).is_err() {
                break;
            }
        }
    }
}

#[test]
fn an_untouched_resumed_state_continues_bit_for_bit() {
    let f = forces(morris(0.01), [0.0, -1.0], 0.1);
    let mut whole = buffers();
    let expected: Vec<V2> = {
        let mut s = build(&mut whole, f).unwrap();
        for _ in 0..40 {
            s.step(1e-3).unwrap();
        }
        s.velocities().to_vec()
    };
    let mut b = buffers();
    let state = {
        let mut s = build(&mut b, f).unwrap();
        for _ in 0..17 {
            s.step(1e-3).unwrap();
        }
        s.resume_state()
    };
    let mut s = Channel::resume_with(
        params(),
        channel(0.6, 1.0, 0.1),
        b.storage(),
        60,
        (),
        f,
        state,
    )
    .unwrap();
    for _ in 17..40 {
        s.step(1e-3).unwrap();
    }
    assert_eq!(s.steps(), 40);
    let bits = |v: &[V2]| {
        v.iter()
            .map(|x| [x[0].to_bits(), x[1].to_bits()])
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(s.velocities()), bits(&expected));
}

#[test]
#[cfg(feature = "shaped-walls")]
fn shaped_walls_check_their_description_and_the_particles_behind_them() {
    let ball = |r: f64| {
        ShapedWall::new(Shape::Ball {
            center: [0.3, 0.5, 0.0],
            radius: r,
            fluid_inside: false,
        })
    };
    for bad in [f64::NAN, -0.1, 0.0, f64::INFINITY] {
        assert!(
            matches!(
                channel(0.6, 1.0, 0.0).with_shaped_wall(ball(bad)),
                Err(Error::InvalidParameter {
                    name: "wall.radius",
                    ..
                })
            ),
            "radius {bad}"
        );
    }
    let tilted = |n: [f64; 3]| {
        ShapedWall::new(Shape::Plane {
            point: [0.0; 3],
            normal: n,
        })
    };
    assert!(channel(0.6, 1.0, 0.0)
        .with_shaped_wall(tilted([1.0, 1.0, 0.0]))
        .is_err());
    assert!(channel(0.6, 1.0, 0.0)
        .with_shaped_wall(tilted([f64::NAN, 0.0, 0.0]))
        .is_err());
    // A plane may slide along itself, not through itself.
    assert!(channel(0.6, 1.0, 0.0)
        .with_shaped_wall(tilted([0.0, 1.0, 0.0]).sliding([0.0, 1.0, 0.0]))
        .is_err());
    // Capacity: a ninth wall is an error, not a panic.
    let mut d = channel(0.6, 1.0, 0.0);
    for _ in 0..8 {
        d = d.with_shaped_wall(ball(0.01)).unwrap();
    }
    assert!(matches!(
        d.with_shaped_wall(ball(0.01)),
        Err(Error::CapacityExceeded { .. })
    ));
    // Four lattice particles lie inside a disc of radius 0.12 at (0.3, 0.5).
    let domain = channel(0.6, 1.0, 0.1).with_shaped_wall(ball(0.12)).unwrap();
    let mut b = buffers();
    match Solver::<D2<f64>, CubicSpline, Libm, _, _>::new(
        params(),
        domain,
        b.storage(),
        60,
        (),
        forces(morris(0.01), [0.0, 0.0], 0.0),
    ) {
        Err(Error::BehindWall {
            wall: 0, distance, ..
        }) => assert!(distance < 0.0),
        other => panic!("{:?}", other.err()),
    }
}
