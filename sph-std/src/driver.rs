//! Running the core on a workstation: `Vec`-owned storage and a rayon executor.

use sph_core::boundary::Ghost;
use sph_core::error::Result;
use sph_core::exec::{Chunk, Executor, Reduce};
use sph_core::real::Real;
use sph_core::solver::{Storage, StorageRef};

use crate::checkpoint::{Arrays, REAL_NAMES, WORD_NAMES};
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

    /// Adds Verlet neighbour lists: a row of `width` entries for each of the
    /// `fluid` particles (see `sph_core::solver::Storage::neighbours`; ghosts
    /// need none); [`list_width`] suggests a width.
    pub fn with_lists(mut self, fluid: usize, width: usize) -> Self {
        self.neighbours = vec![0; fluid * width];
        self.neighbour_counts = vec![0; fluid];
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

    /// Copies a checkpoint's buffers in ([`save`] wrote them).
    ///
    /// # Errors
    /// [`crate::error::Error::Config`] (key `checkpoint`) naming the first buffer whose
    /// length does not match these buffers (a checkpoint of another scene
    /// or resolution).
    pub fn load(&mut self, arrays: &Arrays) -> crate::error::Result<()> {
        let dim = S::DIM;
        let mismatch = |name: &str, got: usize, want: usize| {
            crate::error::Error::config(
                "checkpoint",
                format!("{name}: {got} values"),
                format!("does not fit the scene ({want} expected): the checkpoint belongs to another run"),
            )
        };
        if arrays.reals.len() != REAL_NAMES.len() || arrays.words.len() != WORD_NAMES.len() {
            return Err(mismatch(
                "buffers",
                arrays.reals.len() + arrays.words.len(),
                REAL_NAMES.len() + WORD_NAMES.len(),
            ));
        }
        fn vectors<S: Space>(dst: &mut [S::Vector], src: &[f64]) {
            for (k, v) in dst.iter_mut().enumerate() {
                *v = S::Vector::from_fn(|a| S::Real::from_f64(src[k * S::DIM + a]));
            }
        }
        fn reals<F: Real>(dst: &mut [F], src: &[f64]) {
            for (d, s) in dst.iter_mut().zip(src) {
                *d = F::from_f64(*s);
            }
        }
        let r = &arrays.reals;
        let vec_bufs = [
            (0, self.x.len()),
            (1, self.v.len()),
            (5, self.ve.len()),
            (6, self.dv.len()),
            (9, self.shift.len()),
        ];
        for (i, len) in vec_bufs {
            if r[i].len() != len * dim {
                return Err(mismatch(REAL_NAMES[i], r[i].len(), len * dim));
            }
        }
        let real_bufs = [
            (2, self.m.len()),
            (3, self.rho.len()),
            (4, self.p.len()),
            (7, self.drho.len()),
            (8, self.rho_aux.len()),
        ];
        for (i, len) in real_bufs {
            if r[i].len() != len {
                return Err(mismatch(REAL_NAMES[i], r[i].len(), len));
            }
        }
        let w = &arrays.words;
        let word_bufs = [
            self.ghosts.len(),
            self.ghosts.len(),
            self.cell_start.len(),
            self.cell_sorted.len(),
            self.cell_index.len(),
            self.neighbours.len(),
            self.neighbour_counts.len(),
        ];
        for (i, len) in word_bufs.into_iter().enumerate() {
            if w[i].len() != len {
                return Err(mismatch(WORD_NAMES[i], w[i].len(), len));
            }
        }
        if w[1].iter().any(|&m| m > u32::from(u8::MAX)) {
            return Err(mismatch("ghost_mirrors", w[1].len(), w[1].len()));
        }
        vectors::<S>(&mut self.x, &r[0]);
        vectors::<S>(&mut self.v, &r[1]);
        reals(&mut self.m, &r[2]);
        reals(&mut self.rho, &r[3]);
        reals(&mut self.p, &r[4]);
        vectors::<S>(&mut self.ve, &r[5]);
        vectors::<S>(&mut self.dv, &r[6]);
        reals(&mut self.drho, &r[7]);
        reals(&mut self.rho_aux, &r[8]);
        vectors::<S>(&mut self.shift, &r[9]);
        for (k, g) in self.ghosts.iter_mut().enumerate() {
            g.source = w[0][k];
            g.mirrors = w[1][k] as u8;
        }
        self.cell_start.copy_from_slice(&w[2]);
        self.cell_sorted.copy_from_slice(&w[3]);
        self.cell_index.copy_from_slice(&w[4]);
        self.neighbours.copy_from_slice(&w[5]);
        self.neighbour_counts.copy_from_slice(&w[6]);
        Ok(())
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

/// Copies every buffer of a solver's storage, reals as `f64` (exact for
/// `f32`), for a checkpoint ([`Buffers::load`] reads it back).
pub fn save<S: Space>(s: &StorageRef<'_, S>) -> Arrays {
    fn vectors<S: Space>(v: &[S::Vector]) -> Vec<f64> {
        v.iter()
            .flat_map(|x| (0..S::DIM).map(move |a| x[a].to_f64()))
            .collect()
    }
    fn reals<F: Real>(v: &[F]) -> Vec<f64> {
        v.iter().map(|x| x.to_f64()).collect()
    }
    Arrays {
        reals: vec![
            vectors::<S>(s.x),
            vectors::<S>(s.v),
            reals(s.m),
            reals(s.rho),
            reals(s.p),
            vectors::<S>(s.ve),
            vectors::<S>(s.dv),
            reals(s.drho),
            reals(s.rho_aux),
            vectors::<S>(s.shift),
        ],
        words: vec![
            s.ghosts.iter().map(|g| g.source).collect(),
            s.ghosts.iter().map(|g| u32::from(g.mirrors)).collect(),
            s.cell_start.to_vec(),
            s.cell_sorted.to_vec(),
            s.cell_index.to_vec(),
            s.neighbours.to_vec(),
            s.neighbour_counts.to_vec(),
        ],
    }
}
