//! Results do not depend on the thread count or the chunk size: the core's
//! passes are gather-only, so serial and rayon runs agree bit for bit.

use sph_core::exec::{Chunked, Executor};
use sph_core::prelude::*;
use sph_std::bench::{box_scene, BoxOptions};
use sph_std::driver::Rayon;

type V2 = Vector<f64, 2>;

/// Positions and velocities after 150 steps of the wall-bounded box (Verlet
/// lists, reordering, ghost rebuilds) run through `exec`.
fn run<E: Executor>(exec: &E, lists: bool) -> (Vec<V2>, Vec<V2>, u32) {
    let options = BoxOptions {
        beta: 1.3,
        skin: lists.then_some(0.1),
        reorder_every: 1,
        walls: true,
        shuffle: true,
    };
    let mut scene = box_scene::<D2<f64>>(1600, options).unwrap();
    let mut s = scene.solver(exec).unwrap();
    let dt = 0.5 * s.limits().min();
    for _ in 0..150 {
        s.step_with(exec, dt).unwrap();
    }
    (
        s.positions().to_vec(),
        s.velocities().to_vec(),
        s.neighbour_builds(),
    )
}

fn bits(v: &[V2]) -> Vec<[u64; 2]> {
    v.iter().map(|p| [p[0].to_bits(), p[1].to_bits()]).collect()
}

#[test]
fn every_thread_count_and_chunk_size_gives_the_same_bits() {
    for lists in [true, false] {
        let (x0, v0, builds) = run(&Serial, lists);
        assert!(builds > 2, "the run must rebuild its neighbours");
        let chunked = run(&Chunked { size: 37 }, lists);
        assert_eq!(bits(&chunked.0), bits(&x0));
        assert_eq!(bits(&chunked.1), bits(&v0));
        for (threads, min_chunk) in [(1, 13), (2, 13), (2, 101)] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let (x, v, _) = pool.install(|| run(&Rayon { min_chunk }, lists));
            assert_eq!(
                bits(&x),
                bits(&x0),
                "positions differ: {threads} threads, chunks of {min_chunk}, lists {lists}"
            );
            assert_eq!(
                bits(&v),
                bits(&v0),
                "velocities differ: {threads} threads, chunks of {min_chunk}, lists {lists}"
            );
        }
    }
}
