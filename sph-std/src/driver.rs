//! Running the core on a workstation: `Vec`-owned storage and a rayon executor.

use sph_core::boundary::Ghost;
use sph_core::error::Result;
use sph_core::exec::{Chunk, Executor, Reduce};
use sph_core::real::Real;
use sph_core::solver::Storage;
use sph_core::space::{Space, VectorOps};

/// Threads to use: `threads`, or every core for 0.
pub fn resolve_threads(threads: usize) -> usize {
    if threads == 0 {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    } else {
        threads
    }
}

/// A rayon pool of `threads` workers.
///
/// # Errors
/// [`crate::error::Error::Config`] naming `threads` if the pool cannot start.
pub fn thread_pool(threads: usize) -> crate::error::Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| {
            crate::error::Error::config(
                "threads",
                threads,
                format!("cannot start the thread pool: {e}"),
            )
        })
}

/// Runs a pass by recursive halving with `rayon::join` down to `min_chunk`
/// particles; inside a `rayon::ThreadPool::install` it uses that pool.
///
/// The core's passes write only their own range, so results are bitwise the
/// same as [`sph_core::exec::Serial`] for every thread count and chunk size.
#[derive(Clone, Copy, Debug)]
pub struct Rayon {
    /// Smallest piece handed to one task.
    pub min_chunk: usize,
}

impl Default for Rayon {
    fn default() -> Self {
        Self { min_chunk: 256 }
    }
}

fn split_run<P: Chunk, R: Reduce>(
    start: usize,
    parts: P,
    min_chunk: usize,
    f: &(dyn Fn(usize, P) -> Result<R> + Sync),
) -> Result<R> {
    let len = parts.len();
    if len <= min_chunk {
        return f(start, parts);
    }
    let mid = len / 2;
    let (left, right) = parts.split_at(mid);
    let (a, b) = rayon::join(
        || split_run(start, left, min_chunk, f),
        || split_run(start + mid, right, min_chunk, f),
    );
    // The leftmost error wins, so the report does not depend on the split.
    Ok(a?.combine(b?))
}

impl Executor for Rayon {
    fn run<P: Chunk, R: Reduce>(
        &self,
        parts: P,
        f: &(dyn Fn(usize, P) -> Result<R> + Sync),
    ) -> Result<R> {
        split_run(0, parts, self.min_chunk.max(1), f)
    }
}

/// Heap-owned buffers for a [`sph_core::solver::Solver`]: `capacity` particle
/// slots (fluid first, then ghosts) and `cells` cell-list starts.
#[derive(Debug)]
pub struct Buffers<S: Space> {
    /// Positions (fill the fluid part before building a solver).
    pub x: Vec<S::Vector>,
    /// Velocities.
    pub v: Vec<S::Vector>,
    /// Masses.
    pub m: Vec<S::Real>,
    /// Densities.
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
    shift: Vec<S::Vector>,
}

impl<S: Space> Buffers<S> {
    /// Zeroed buffers.
    pub fn new(capacity: usize, cells: usize) -> Self {
        let z = S::Vector::zero();
        let f = S::Real::ZERO;
        Self {
            x: vec![z; capacity],
            v: vec![z; capacity],
            m: vec![f; capacity],
            rho: vec![f; capacity],
            p: vec![f; capacity],
            ve: vec![z; capacity],
            dv: vec![z; capacity],
            drho: vec![f; capacity],
            rho_aux: vec![f; capacity],
            ghosts: vec![Ghost::default(); capacity],
            cell_start: vec![0; cells],
            cell_sorted: vec![0; capacity],
            cell_index: vec![0; capacity],
            neighbours: Vec::new(),
            neighbour_counts: Vec::new(),
            shift: Vec::new(),
        }
    }

    /// Adds the buffer particle shifting needs (see `sph_core::terms::Shifting`).
    pub fn with_shifting(mut self) -> Self {
        self.shift = vec![S::Vector::zero(); self.x.len()];
        self
    }

    /// Adds Verlet neighbour lists of `width` entries per particle slot (see
    /// `sph_core::solver::Storage::neighbours`); [`list_width`] suggests one.
    pub fn with_lists(mut self, width: usize) -> Self {
        let capacity = self.x.len();
        self.neighbours = vec![0; capacity * width];
        self.neighbour_counts = vec![0; capacity];
        self
    }

    /// Views for a solver.
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

    /// Bytes held, in total.
    pub fn bytes(&self) -> usize {
        self.x.len() * sph_core::solver::bytes_per_particle::<S>()
            + (self.cell_start.len() + self.neighbours.len() + self.neighbour_counts.len()) * 4
            + self.shift.len() * std::mem::size_of::<S::Vector>()
    }
}

/// A neighbour-list width for a kernel of support `kappa h` with `h = beta dx`
/// on a lattice in `dim` dimensions and a Verlet `skin`: the number of
/// lattice points within `(1 + skin) kappa beta dx`, with 50 % headroom for
/// compression and disorder, plus 8.
pub fn list_width(dim: usize, kappa: f64, beta: f64, skin: f64) -> usize {
    let r = (1.0 + skin) * kappa * beta;
    let ball = match dim {
        1 => 2.0 * r,
        2 => std::f64::consts::PI * r * r,
        _ => 4.0 / 3.0 * std::f64::consts::PI * r * r * r,
    };
    (1.5 * ball).ceil() as usize + 8
}
