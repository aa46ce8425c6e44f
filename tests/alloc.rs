//! No allocation during steady stepping, serial and through the rayon driver.
//!
//! One test in its own binary, so nothing else allocates beside it: a
//! counting global allocator records every allocation made while stepping.

// A global allocator cannot be written without `unsafe`; this test file is
// the only place outside the core that needs it, and it only forwards calls.
#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use sph_core::exec::Executor;
use sph_core::prelude::*;
use sph_std::bench::{box_scene, BoxOptions};
use sph_std::driver::Rayon;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);
static BYTES: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        BYTES.fetch_add(layout.size(), Ordering::Relaxed);
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Steps a disordered box (walls across y, so ghosts are rebuilt too) with
/// Verlet lists and reordering through `exec`, and returns (allocations,
/// bytes) during the measured steps.
fn allocations_while_stepping<E: Executor>(exec: &E) -> (usize, usize) {
    let options = BoxOptions {
        beta: 1.3,
        skin: Some(0.1),
        reorder_every: 1,
        walls: true,
        shuffle: true,
    };
    let mut scene = box_scene::<D2<f64>>(2304, options).unwrap();
    let mut s = scene.solver(exec).unwrap();
    let dt = 0.5 * s.limits().min();
    for _ in 0..50 {
        s.step_with(exec, dt).unwrap();
    }
    let (a0, b0) = (
        ALLOCATIONS.load(Ordering::Relaxed),
        BYTES.load(Ordering::Relaxed),
    );
    let builds = s.neighbour_builds();
    for _ in 0..200 {
        s.step_with(exec, dt).unwrap();
    }
    assert!(
        s.neighbour_builds() > builds,
        "the measured steps must include neighbour-list rebuilds"
    );
    (
        ALLOCATIONS.load(Ordering::Relaxed) - a0,
        BYTES.load(Ordering::Relaxed) - b0,
    )
}

#[test]
fn stepping_allocates_nothing_serial_or_parallel() {
    let (count, _) = allocations_while_stepping(&Serial);
    assert_eq!(count, 0, "serial stepping allocated {count} times");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let (count, bytes) = pool.install(|| allocations_while_stepping(&Rayon { min_chunk: 64 }));
    println!("rayon, 2 threads: {count} allocations, {bytes} bytes over 200 steps");
    assert_eq!(
        count, 0,
        "stepping through rayon allocated {count} times ({bytes} bytes)"
    );
}
