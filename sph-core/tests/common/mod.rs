//! Shared helpers for the core's integration tests: Vec-owned storage and lattices.
#![allow(dead_code)]

use sph_core::boundary::Ghost;
use sph_core::prelude::*;

/// Owned buffers for a solver, sized for `cap` particle slots and `cells` cell starts.
pub struct Buffers<S: Space> {
    pub x: Vec<S::Vector>,
    pub v: Vec<S::Vector>,
    pub m: Vec<S::Real>,
    pub rho: Vec<S::Real>,
    p: Vec<S::Real>,
    ve: Vec<S::Vector>,
    dv: Vec<S::Vector>,
    drho: Vec<S::Real>,
    rho_aux: Vec<S::Real>,
    ghosts: Vec<Ghost>,
    cell_start: Vec<u32>,
    cell_sorted: Vec<u32>,
    cell_index: Vec<u32>,
    neighbours: Vec<u32>,
    neighbour_counts: Vec<u32>,
    pub shift: Vec<S::Vector>,
    fluid: usize,
}

impl<S: Space> Buffers<S> {
    /// Buffers holding the fluid `x`, `v` with masses `m` and densities `rho`, plus `spare` ghost slots.
    pub fn new(
        x: &[S::Vector],
        v: &[S::Vector],
        m: S::Real,
        rho: S::Real,
        spare: usize,
        cells: usize,
    ) -> Self {
        let cap = x.len() + spare;
        let mut xs = vec![S::Vector::zero(); cap];
        xs[..x.len()].copy_from_slice(x);
        let mut vs = vec![S::Vector::zero(); cap];
        vs[..v.len()].copy_from_slice(v);
        Self {
            x: xs,
            v: vs,
            m: vec![m; cap],
            rho: vec![rho; cap],
            p: vec![S::Real::ZERO; cap],
            ve: vec![S::Vector::zero(); cap],
            dv: vec![S::Vector::zero(); cap],
            drho: vec![S::Real::ZERO; cap],
            rho_aux: vec![S::Real::ZERO; cap],
            ghosts: vec![Ghost::default(); cap],
            cell_start: vec![0; cells],
            cell_sorted: vec![0; cap],
            cell_index: vec![0; cap],
            neighbours: Vec::new(),
            neighbour_counts: Vec::new(),
            shift: Vec::new(),
            fluid: x.len(),
        }
    }

    /// Adds Verlet-list buffers of `width` entries per fluid particle.
    pub fn with_lists(mut self, width: usize) -> Self {
        self.neighbours = vec![0; self.fluid * width];
        self.neighbour_counts = vec![0; self.fluid];
        self
    }

    /// Shortens (or lengthens, with zeros) buffer number `which` of the 16
    /// in [`Storage`] order to `len` entries: a caller's sizing mistake.
    pub fn resize(&mut self, which: usize, len: usize) {
        let (z, f) = (S::Vector::zero(), S::Real::ZERO);
        match which % 16 {
            0 => self.x.resize(len, z),
            1 => self.v.resize(len, z),
            2 => self.m.resize(len, f),
            3 => self.rho.resize(len, f),
            4 => self.p.resize(len, f),
            5 => self.ve.resize(len, z),
            6 => self.dv.resize(len, z),
            7 => self.drho.resize(len, f),
            8 => self.rho_aux.resize(len, f),
            9 => self.ghosts.resize(len, Ghost::default()),
            10 => self.cell_start.resize(len, 0),
            11 => self.cell_sorted.resize(len, 0),
            12 => self.cell_index.resize(len, 0),
            13 => self.neighbours.resize(len, 0),
            14 => self.neighbour_counts.resize(len, 0),
            _ => self.shift.resize(len, z),
        }
    }

    /// Overwrites entry `k` of integer buffer `which` (0 ghosts' sources,
    /// 1 cell starts, 2 sorted, 3 cell indices, 4 neighbours, 5 counts).
    pub fn poke(&mut self, which: usize, k: usize, value: u32) {
        let buf: &mut [u32] = match which % 6 {
            0 => {
                if let Some(g) = self.ghosts.get_mut(k) {
                    g.source = value;
                }
                return;
            }
            1 => &mut self.cell_start,
            2 => &mut self.cell_sorted,
            3 => &mut self.cell_index,
            4 => &mut self.neighbours,
            _ => &mut self.neighbour_counts,
        };
        if let Some(e) = buf.get_mut(k) {
            *e = value;
        }
    }

    pub fn storage(&mut self) -> Storage<'_, S> {
        Storage {
            x: &mut self.x,
            v: &mut self.v,
            m: &mut self.m,
            rho: &mut self.rho,
            p: &mut self.p,
            ve: &mut self.ve,
            dv: &mut self.dv,
            drho: &mut self.drho,
            rho_aux: &mut self.rho_aux,
            ghosts: &mut self.ghosts,
            cell_start: &mut self.cell_start,
            cell_sorted: &mut self.cell_sorted,
            cell_index: &mut self.cell_index,
            neighbours: &mut self.neighbours,
            neighbour_counts: &mut self.neighbour_counts,
            shift: &mut self.shift,
        }
    }
}

pub type V2 = Vector<f64, 2>;

/// Square lattice `nx x ny` with spacing `dx`, first row at `dx/2`.
pub fn lattice_2d(nx: usize, ny: usize, dx: f64) -> Vec<V2> {
    let mut x = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        for i in 0..nx {
            x.push(V2::new([(i as f64 + 0.5) * dx, (j as f64 + 0.5) * dx]));
        }
    }
    x
}

/// A small deterministic generator (xorshift64*), uniform in [-1, 1).
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let r = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        (r >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
    pub fn below(&mut self, n: usize) -> usize {
        (((self.next() + 1.0) * 0.5) * n as f64) as usize % n.max(1)
    }
}

/// Periodic square box of side `l`.
pub fn periodic_box(l: f64) -> Domain<D2<f64>> {
    Domain::new(V2::new([0.0, 0.0]), V2::new([l, l]))
        .unwrap()
        .with_periodic(0)
        .unwrap()
        .with_periodic(1)
        .unwrap()
}

/// Channel periodic in x with no-slip walls at y = 0 and y = ly (upper moving at `u_top`).
pub fn channel(lx: f64, ly: f64, u_top: f64) -> Domain<D2<f64>> {
    Domain::new(V2::new([0.0, 0.0]), V2::new([lx, ly]))
        .unwrap()
        .with_periodic(0)
        .unwrap()
        .with_wall(1, Side::Lower, Wall::no_slip())
        .unwrap()
        .with_wall(1, Side::Upper, Wall::moving(V2::new([u_top, 0.0])))
        .unwrap()
}

pub fn cells_for<K: Kernel>(domain: &Domain<D2<f64>>, h: f64) -> usize {
    Solver::<D2<f64>, K, Libm, (), ()>::cells_needed(domain, h).unwrap()
}
