//! One scene stepped by several ranks, each holding a slab of the box, with
//! the same bits as one solver: the engine under `sph run --mpi`, written
//! against a [`Comm`] so that it runs on MPI ranks (the `sph-mpi` crate) or
//! on threads of one process ([`Threads`], for the tests and for users
//! without MPI).
//!
//! # Decomposition
//! The box is cut into slabs across its longest axis, one per rank, with
//! edges placed by particle count (a histogram of the fluid along the axis,
//! summed over the ranks: integers, so every rank places the same edges).
//! Slabs exchange with at most two neighbours whatever the rank count and
//! keep their interface flat; recursive bisection would cut the halo
//! surface at high rank counts in 3D (see `docs/distributed.md`).
//!
//! Each rank runs an ordinary [`Solver`] on the particles it owns plus a
//! halo: every particle within `levels` neighbour-list radii of its slab
//! (two: a force needs the neighbours' densities, which need theirs; three
//! with wall particles, whose pressure is a sum over the fluid), plus the
//! distance the coming drift may carry a particle. Between list rebuilds
//! the membership is fixed: before each step the owners send their
//! particles' state to every rank that holds a copy, so each rank starts
//! the step with the exact state of all its particles, and its owned
//! particles end it with exactly the single solver's values (the halo's
//! outer layer, whose neighbourhoods are cut, is overwritten before it is
//! read).
//!
//! # Why the bits agree
//! A particle's sums run over its neighbour row in the order the row was
//! built: the cell stencil, then the particle index within a cell. Each
//! rank keeps its particles in global id order, the order a scene's single
//! solver keeps them in (scenes do not reorder), and ghosts in generation
//! order; so every row on a rank is the single solver's row restricted to
//! the same particles, in the same order. The rows must also be built at
//! the same steps: the Verlet travel counts the fastest drift, so every
//! rank steps with the largest drift of all ranks
//! ([`Solver::step_bounded_with`]; a maximum is exact in any order), and
//! particles change rank only at those rebuilds ([`Solver::rebuilds_next`]
//! says which step rebuilds before it is taken).

use crate::driver::Buffers;
use crate::error::{Error, Result};
use crate::exact::ExactSum;
use crate::scene::Stopwatch;
use sph_core::domain::Domain;
use sph_core::exec::Executor;
use sph_core::kernel::Kernel;
use sph_core::math::Math;
use sph_core::real::Real;
use sph_core::solver::{Limits, Params, Resume, Solver};
use sph_core::space::{Space, VectorOps};
use sph_core::terms::Term;
use std::sync::{mpsc, Barrier, Mutex};

/// The collective operations the engine needs; every rank calls them in the
/// same sequence.
pub trait Comm {
    /// This rank, `0..size`.
    fn rank(&self) -> usize;
    /// The number of ranks.
    fn size(&self) -> usize;
    /// Sends `out[r]` to rank `r` (one buffer per rank, this rank's own
    /// included) and returns the buffers every rank sent to this one, in
    /// rank order.
    fn exchange(&self, out: Vec<Vec<f64>>) -> Vec<Vec<f64>>;
    /// The element-wise maximum over the ranks.
    fn max(&self, values: &[f64]) -> Vec<f64> {
        let all = self.exchange(vec![values.to_vec(); self.size()]);
        let mut out = values.to_vec();
        for v in &all {
            for (o, x) in out.iter_mut().zip(v) {
                *o = o.max(*x);
            }
        }
        out
    }
    /// The element-wise sum over the ranks, in rank order (the same bits on
    /// every rank, whatever the transport's own reduction order).
    fn sum(&self, values: &[f64]) -> Vec<f64> {
        let all = self.exchange(vec![values.to_vec(); self.size()]);
        let mut out = vec![0.0; values.len()];
        for v in &all {
            for (o, x) in out.iter_mut().zip(v) {
                *o += *x;
            }
        }
        out
    }
}

/// Ranks as threads of one process, meeting at a barrier.
pub struct Threads<'b> {
    rank: usize,
    board: &'b Board,
}

/// The threads' shared mailboxes: `slots[to][from]`.
struct Board {
    size: usize,
    slots: Mutex<Vec<Vec<Vec<f64>>>>,
    barrier: Barrier,
}

impl Threads<'_> {
    /// Runs `f` on `ranks` threads, one [`Comm`] each, and returns their
    /// results in rank order.
    ///
    /// # Errors
    /// [`Error::Config`] (key `ranks`) for zero ranks.
    pub fn run<R: Send>(ranks: usize, f: impl Fn(&Threads<'_>) -> R + Sync) -> Result<Vec<R>> {
        if ranks == 0 {
            return Err(Error::config("ranks", 0, "at least one rank"));
        }
        let board = Board {
            size: ranks,
            slots: Mutex::new(vec![vec![Vec::new(); ranks]; ranks]),
            barrier: Barrier::new(ranks),
        };
        let results = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..ranks)
                .map(|rank| {
                    let (board, f) = (&board, &f);
                    scope.spawn(move || f(&Threads { rank, board }))
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join())
                .collect::<std::result::Result<Vec<R>, _>>()
        });
        results.map_err(|_| Error::Diverged("a rank's thread panicked".into()))
    }
}

impl Comm for Threads<'_> {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.board.size
    }

    fn exchange(&self, out: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
        {
            let mut slots = self.board.slots.lock().unwrap_or_else(|e| e.into_inner());
            for (to, buf) in out.into_iter().enumerate() {
                slots[to][self.rank] = buf;
            }
        }
        self.board.barrier.wait();
        let got = {
            let mut slots = self.board.slots.lock().unwrap_or_else(|e| e.into_inner());
            std::mem::replace(&mut slots[self.rank], vec![Vec::new(); self.board.size])
        };
        // Nobody writes the next round before everyone has read this one.
        self.board.barrier.wait();
        got
    }
}

/// Runs `f` with this process's MPI world as its [`Comm`] (MPI initialised
/// here and finalised when `f` returns): every process that `mpirun`
/// started calls it, and each gets its rank. `f` runs on a thread of its
/// own; every MPI call is made on the calling thread ([`funnel`]).
///
/// # Errors
/// [`Error::Config`] (key `mpi`) where this build lacks the `mpi` feature
/// or MPI cannot be initialised (already initialised in this process).
pub fn with_mpi<R: Send>(f: impl FnOnce(&(dyn Comm + Sync)) -> R + Send) -> Result<R> {
    #[cfg(feature = "mpi")]
    {
        let universe = ::mpi::initialize().ok_or_else(|| {
            Error::config("mpi", "on", "MPI is already initialised in this process")
        })?;
        let world = mpi_comm::World::new(universe.world());
        funnel(&world, f)
    }
    #[cfg(not(feature = "mpi"))]
    {
        drop(f);
        Err(Error::config(
            "mpi",
            "on",
            "this sph was built without MPI; build it with `cargo build --release --features mpi` (needs an MPI implementation and libclang)",
        ))
    }
}

/// A request to the thread that owns the transport: the buffers to send
/// and where the received ones go.
type Request = (Vec<Vec<f64>>, mpsc::Sender<Vec<Vec<f64>>>);

/// A [`Comm`] that any thread may hold: it forwards every exchange to the
/// thread running [`funnel`].
struct Relay {
    rank: usize,
    size: usize,
    requests: mpsc::Sender<Request>,
}

impl Comm for Relay {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn exchange(&self, out: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
        let (reply, answer) = mpsc::channel();
        // The serving thread outlives `f`, so neither end is gone here.
        let _ = self.requests.send((out, reply));
        answer.recv().unwrap_or_default()
    }
}

/// Runs `f` on a new thread with a [`Comm`] that forwards every exchange to
/// `inner` on this thread: for a transport that must stay on the thread
/// that created it (MPI without thread support; a communicator handle that
/// is not `Sync`), under code that moves work between threads (a rayon
/// pool).
///
/// # Errors
/// [`Error::Diverged`] if `f` panics.
pub fn funnel<R: Send>(
    inner: &dyn Comm,
    f: impl FnOnce(&(dyn Comm + Sync)) -> R + Send,
) -> Result<R> {
    let (requests, served) = mpsc::channel::<Request>();
    let relay = Relay {
        rank: inner.rank(),
        size: inner.size(),
        requests,
    };
    std::thread::scope(|scope| {
        let worker = scope.spawn(move || f(&relay));
        // Ends when `f` returns and drops the relay.
        for (out, reply) in served {
            let _ = reply.send(inner.exchange(out));
        }
        worker
            .join()
            .map_err(|_| Error::Diverged("the run's thread panicked".into()))
    })
}

/// MPI ranks as a [`Comm`].
#[cfg(feature = "mpi")]
mod mpi_comm {
    use super::Comm;
    use ::mpi::datatype::{Partition, PartitionMut};
    use ::mpi::topology::SimpleCommunicator;
    use ::mpi::traits::{Communicator, CommunicatorCollectives};

    /// A communicator's ranks.
    pub struct World {
        comm: SimpleCommunicator,
    }

    impl World {
        pub fn new(comm: SimpleCommunicator) -> Self {
            Self { comm }
        }
    }

    /// Offsets of buffers of `counts` words laid back to back.
    fn offsets(counts: &[i32]) -> Vec<i32> {
        counts
            .iter()
            .scan(0i32, |at, &c| {
                let here = *at;
                *at += c;
                Some(here)
            })
            .collect()
    }

    impl Comm for World {
        fn rank(&self) -> usize {
            self.comm.rank() as usize
        }

        fn size(&self) -> usize {
            self.comm.size() as usize
        }

        fn exchange(&self, out: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
            let size = self.size();
            // MPI counts are 32-bit: a buffer past 2^31 words (16 GiB) is
            // beyond any halo this engine sends.
            let counts: Vec<i32> = out
                .iter()
                .map(|b| i32::try_from(b.len()).unwrap_or(i32::MAX))
                .collect();
            let mut got = vec![0i32; size];
            self.comm.all_to_all_into(&counts[..], &mut got[..]);
            let (sent_at, got_at) = (offsets(&counts), offsets(&got));
            let send: Vec<f64> = out.concat();
            let mut recv = vec![0.0; got.iter().map(|&c| c as usize).sum()];
            {
                let outgoing = Partition::new(&send[..], &counts[..], &sent_at[..]);
                let mut incoming = PartitionMut::new(&mut recv[..], &got[..], &got_at[..]);
                self.comm.all_to_all_varcount_into(&outgoing, &mut incoming);
            }
            got_at
                .iter()
                .zip(&got)
                .map(|(&at, &c)| recv[at as usize..(at + c) as usize].to_vec())
                .collect()
        }
    }
}

/// Every fluid particle's state, one record of [`Particles::width`] words
/// each: its id, then `x`, `v`, `m`, `rho`, `p`, `ve`, `dv`, `drho`,
/// `rho_aux`, `shift` (vectors as `dim` words; reals as `f64`, exact for
/// `f32`).
#[derive(Clone, Debug, PartialEq)]
pub struct Particles {
    /// Dimensions.
    pub dim: usize,
    /// The records, back to back.
    pub words: Vec<f64>,
}

impl Particles {
    /// Words per record.
    pub fn width(dim: usize) -> usize {
        1 + 5 * dim + 5
    }

    /// The records.
    pub fn len(&self) -> usize {
        self.words.len() / Self::width(self.dim)
    }

    /// No records.
    pub fn is_empty(&self) -> bool {
        self.words.is_empty()
    }

    /// Record `k`.
    pub fn record(&self, k: usize) -> &[f64] {
        let w = Self::width(self.dim);
        &self.words[k * w..(k + 1) * w]
    }

    /// The fluid of a solver, ids `0..n` in its particle order.
    pub fn of_solver<S, K, M, D, T>(solver: &Solver<'_, S, K, M, D, T>) -> Self
    where
        S: Space,
        K: Kernel,
        M: Math<S::Real>,
        D: Term<S>,
        T: Term<S>,
    {
        let mut words = Vec::with_capacity(solver.n_fluid() * Self::width(S::DIM));
        for i in 0..solver.n_fluid() {
            push_record(&mut words, i as f64, &solver.storage(), i);
        }
        Self { dim: S::DIM, words }
    }

    /// The position of record `k` along `axis`.
    fn coordinate(&self, k: usize, axis: usize) -> f64 {
        self.record(k)[1 + axis]
    }
}

fn push_record<S: Space>(
    out: &mut Vec<f64>,
    id: f64,
    s: &sph_core::solver::StorageRef<'_, S>,
    i: usize,
) {
    let vector = |out: &mut Vec<f64>, v: S::Vector| out.extend((0..S::DIM).map(|a| v[a].to_f64()));
    out.push(id);
    vector(out, s.x[i]);
    vector(out, s.v[i]);
    out.extend([s.m[i].to_f64(), s.rho[i].to_f64(), s.p[i].to_f64()]);
    vector(out, s.ve[i]);
    vector(out, s.dv[i]);
    out.extend([s.drho[i].to_f64(), s.rho_aux[i].to_f64()]);
    vector(out, s.shift.get(i).copied().unwrap_or_else(S::Vector::zero));
}

/// Writes record `r` into fluid slot `i` of a solver.
pub(crate) fn write_record<S: Space>(
    f: &mut sph_core::solver::FluidMut<'_, S>,
    i: usize,
    r: &[f64],
) {
    let d = S::DIM;
    let vector = |at: usize| S::Vector::from_fn(|a| S::Real::from_f64(r[at + a]));
    let real = |at: usize| S::Real::from_f64(r[at]);
    f.x[i] = vector(1);
    f.v[i] = vector(1 + d);
    f.rho[i] = real(2 + 2 * d);
    f.p[i] = real(3 + 2 * d);
    f.ve[i] = vector(4 + 2 * d);
    f.dv[i] = vector(4 + 3 * d);
    f.drho[i] = real(4 + 4 * d);
    f.rho_aux[i] = real(5 + 4 * d);
    if let Some(u) = f.shift.get_mut(i) {
        *u = vector(6 + 4 * d);
    }
}

/// What every rank needs to build its solver.
#[derive(Clone, Copy, Debug)]
pub struct Setup<S: Space, D, T> {
    /// The scene's parameters.
    pub params: Params<S::Real>,
    /// The whole box (every rank's grid covers it).
    pub domain: Domain<S>,
    /// The density group.
    pub density: D,
    /// The force group.
    pub forces: T,
    /// Cell-list starts ([`Solver::cells_needed`]).
    pub cells: usize,
    /// Neighbour-list row width.
    pub list_width: usize,
    /// Ghost slots on top of a rank's particles.
    pub ghost_room: usize,
}

/// A rank's slab edges along the cut axis (local coordinates; `edges[r]..
/// edges[r + 1]` is rank `r`'s).
#[derive(Clone, Debug, PartialEq)]
struct Slabs {
    axis: usize,
    extent: f64,
    periodic: bool,
    edges: Vec<f64>,
}

/// Coordinate `c` wrapped into `0..extent` on a periodic axis.
fn wrap(periodic: bool, extent: f64, c: f64) -> f64 {
    if periodic {
        c.rem_euclid(extent)
    } else {
        c
    }
}

impl Slabs {
    /// The coordinate along the axis, wrapped into the box on a periodic
    /// axis (between rebuilds positions may lie half a skin outside).
    fn coordinate(&self, c: f64) -> f64 {
        wrap(self.periodic, self.extent, c)
    }

    /// The rank whose slab holds coordinate `c`.
    fn owner(&self, c: f64) -> usize {
        let c = self.coordinate(c);
        let ranks = self.edges.len() - 1;
        (1..ranks).take_while(|&r| self.edges[r] <= c).count()
    }

    /// The distance from coordinate `c` to rank `r`'s slab (zero inside).
    fn distance(&self, c: f64, r: usize) -> f64 {
        let c = self.coordinate(c);
        let (lo, hi) = (self.edges[r], self.edges[r + 1]);
        let gap = |c: f64| {
            if c < lo {
                lo - c
            } else if c >= hi {
                c - hi
            } else {
                0.0
            }
        };
        if self.periodic {
            gap(c).min(gap(c + self.extent)).min(gap(c - self.extent))
        } else {
            gap(c)
        }
    }

    /// Edges that give each rank an equal share of the particles at
    /// coordinates `coords` (this rank's; the histogram is summed over all).
    fn balanced<C: Comm + ?Sized>(
        comm: &C,
        axis: usize,
        extent: f64,
        periodic: bool,
        coords: &[f64],
    ) -> Self {
        let ranks = comm.size();
        let bins = 256 * ranks;
        let mut counts = vec![0.0; bins];
        let scale = bins as f64 / extent;
        for &c in coords {
            let c = wrap(periodic, extent, c);
            let b = ((c * scale).floor().max(0.0) as usize).min(bins - 1);
            counts[b] += 1.0;
        }
        let counts = comm.sum(&counts);
        let total: f64 = counts.iter().sum();
        let mut edges = vec![0.0; ranks + 1];
        let (mut cum, mut r) = (0.0, 1);
        for (b, c) in counts.iter().enumerate() {
            while r < ranks && cum >= total * r as f64 / ranks as f64 {
                edges[r] = b as f64 / scale;
                r += 1;
            }
            cum += c;
        }
        while r < ranks {
            edges[r] = extent;
            r += 1;
        }
        edges[ranks] = extent;
        if !periodic {
            // Walled: positions stay inside, but keep the ends open.
            edges[0] = f64::NEG_INFINITY;
            edges[ranks] = f64::INFINITY;
        }
        Self {
            axis,
            extent,
            periodic,
            edges,
        }
    }
}

/// One rank's particles between two rebuilds: owned and halo records in id
/// order, which local slots are owned, and the refresh plan.
struct Part {
    /// Records in id order (this rank's local particle order).
    local: Particles,
    /// Local slot of each owned particle, in id order.
    owned: Vec<usize>,
    /// Per rank: the local slots of this rank's owned particles it holds
    /// as copies, in id order.
    send: Vec<Vec<usize>>,
    /// Per rank: the local slots of the copies it sends, in its order.
    recv: Vec<Vec<usize>>,
}

impl Part {
    /// The records of the local particles at `slots`, from `solver`'s
    /// current state.
    fn pack<S, K, M, D, T>(&self, solver: &Solver<'_, S, K, M, D, T>, slots: &[usize]) -> Vec<f64>
    where
        S: Space,
        K: Kernel,
        M: Math<S::Real>,
        D: Term<S>,
        T: Term<S>,
    {
        let st = solver.storage();
        let mut words = Vec::with_capacity(slots.len() * Particles::width(S::DIM));
        for &i in slots {
            push_record(&mut words, self.local.record(i)[0], &st, i);
        }
        words
    }
}

/// Splits `words` into records and sorts them by id.
fn sorted(dim: usize, words: Vec<f64>) -> Particles {
    let w = Particles::width(dim);
    let mut recs: Vec<&[f64]> = words.chunks_exact(w).collect();
    recs.sort_by(|a, b| a[0].total_cmp(&b[0]));
    Particles {
        dim,
        words: recs.concat(),
    }
}

/// Moves the owned records to their owners under `slabs`, then sends every
/// rank copies of the particles within `depth` of its slab.
fn distribute<C: Comm + ?Sized>(
    comm: &C,
    slabs: &Slabs,
    owned: &Particles,
    depth: f64,
) -> (Part, f64) {
    let (rank, size, dim) = (comm.rank(), comm.size(), owned.dim);
    let w = Particles::width(dim);
    let mut out = vec![Vec::new(); size];
    for k in 0..owned.len() {
        let to = slabs.owner(owned.coordinate(k, slabs.axis));
        out[to].extend_from_slice(owned.record(k));
    }
    let mut sent = bytes_to_others(&out, rank);
    let mine = sorted(dim, comm.exchange(out).concat());
    // Copies: to every other rank whose slab lies within the depth.
    let mut out = vec![Vec::new(); size];
    let mut sent_ids = vec![Vec::new(); size];
    for k in 0..mine.len() {
        let c = mine.coordinate(k, slabs.axis);
        for (r, buf) in out.iter_mut().enumerate() {
            if r != rank && slabs.distance(c, r) < depth {
                buf.extend_from_slice(mine.record(k));
                sent_ids[r].push(mine.record(k)[0]);
            }
        }
    }
    sent += bytes_to_others(&out, rank);
    let got = comm.exchange(out);
    let mut words = mine.words.clone();
    for g in &got {
        words.extend_from_slice(g);
    }
    let local = sorted(dim, words);
    let ids: Vec<f64> = (0..local.len()).map(|k| local.record(k)[0]).collect();
    let slot = |id: f64| ids.partition_point(|&x| x < id);
    let owned = (0..mine.len()).map(|k| slot(mine.record(k)[0])).collect();
    let send = sent_ids
        .iter()
        .map(|ids| ids.iter().map(|&id| slot(id)).collect())
        .collect();
    let recv = got
        .iter()
        .map(|g| g.chunks_exact(w).map(|r| slot(r[0])).collect())
        .collect();
    let part = Part {
        local,
        owned,
        send,
        recv,
    };
    (part, sent)
}

/// The axis to cut: the longest.
fn cut_axis<S: Space>(domain: &Domain<S>) -> usize {
    let e = domain.extent();
    (0..S::DIM).fold(0, |best, a| {
        if e[a].to_f64() > e[best].to_f64() {
            a
        } else {
            best
        }
    })
}

/// The gathered state at an output time (on rank 0).
#[derive(Clone, Debug)]
pub struct Output {
    /// The index of the output in the plan.
    pub index: usize,
    /// Every fluid particle, in id order.
    pub particles: Particles,
    /// The simulated time the solvers reached.
    pub time: f64,
    /// The steps taken since the start.
    pub steps: u64,
    /// Every rank's figures, in rank order.
    pub ranks: Vec<RankStats>,
    /// The rank that owns each particle, in id order.
    pub owners: Vec<u32>,
}

/// What one rank held, sent and spent, from the start to an output.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct RankStats {
    /// The rank.
    pub rank: usize,
    /// Particles it owned at the output.
    pub owned: usize,
    /// Copies of other ranks' particles it held at the output.
    pub halo: usize,
    /// Steps taken.
    pub steps: u64,
    /// Migrations (one at each list rebuild).
    pub migrations: u64,
    /// Bytes it sent: halo refreshes, migrations, collectives and gathers.
    pub bytes_sent: f64,
    /// Seconds in its solver's steps.
    pub step_seconds: f64,
    /// Seconds refreshing the halo (packing, exchange, unpacking).
    pub halo_seconds: f64,
    /// Seconds in the per-step collective (the drift, the speed, failures):
    /// mostly waiting for the slowest rank.
    pub reduce_seconds: f64,
    /// Seconds migrating and building the next part's solver.
    pub migrate_seconds: f64,
}

impl RankStats {
    fn words(&self) -> [f64; 10] {
        [
            self.rank as f64,
            self.owned as f64,
            self.halo as f64,
            self.steps as f64,
            self.migrations as f64,
            self.bytes_sent,
            self.step_seconds,
            self.halo_seconds,
            self.reduce_seconds,
            self.migrate_seconds,
        ]
    }

    fn from_words(w: &[f64]) -> Self {
        Self {
            rank: w[0] as usize,
            owned: w[1] as usize,
            halo: w[2] as usize,
            steps: w[3] as u64,
            migrations: w[4] as u64,
            bytes_sent: w[5],
            step_seconds: w[6],
            halo_seconds: w[7],
            reduce_seconds: w[8],
            migrate_seconds: w[9],
        }
    }
}

/// What a distributed run does to every rank's solver before each step,
/// given the largest fluid speed of all ranks.
pub type BeforeStep<'f, S, K, M, D, T> =
    dyn Fn(&mut Solver<'_, S, K, M, D, T>, f64) -> Result<()> + 'f;

/// What a distributed run does on every rank after each step, once every
/// particle's state is exact (the halo refreshed): it sees the rank's
/// solver and [`StepDone`], and returns whether the run stops there. It may
/// call collectives of its own, in the same sequence on every rank, and
/// must decide on figures every rank shares (a collective's result), so
/// that all ranks stop together.
pub type AfterStep<'f, S, K, M, D, T> =
    dyn FnMut(&Solver<'_, S, K, M, D, T>, &StepDone<'_>) -> Result<bool> + 'f;

/// The step a distributed run just took, as [`AfterStep`] sees it.
#[derive(Clone, Copy, Debug)]
pub struct StepDone<'a> {
    /// Its length (s).
    pub dt: f64,
    /// Its index within the current output interval, from 0.
    pub in_interval: u64,
    /// This rank's own particles: `(slot in the solver, id)`, in id order.
    pub owned: &'a [(usize, usize)],
}

/// How a distributed run chooses its steps.
pub enum Stepping<'f> {
    /// Per output time, that many steps of that length (s).
    Fixed(&'f [(u64, f64)]),
    /// Per output time, steps chosen from the state: before each step
    /// `choose(output index, time, limits)` is given the time-step limits
    /// at the largest speed and acceleration of all ranks
    /// ([`Solver::limits_at`] of a rank's solver) and returns the step, or
    /// `None` once the output is reached.
    Adaptive {
        /// The number of output times.
        outputs: usize,
        /// The step for `(output index, time, limits)`.
        choose: &'f mut dyn FnMut(usize, f64, Limits) -> Option<f64>,
    },
}

/// Every rank's `words`, in rank order, on every rank.
pub fn all_gather<C: Comm + ?Sized>(comm: &C, words: &[f64]) -> Vec<Vec<f64>> {
    comm.exchange(vec![words.to_vec(); comm.size()])
}

/// The correctly rounded total over the ranks of each of `sums`: the same
/// bits on every rank, and for any split of the summands over the ranks
/// (each rank sends its sums' exact [`ExactSum::terms`]).
pub fn sum_exact<C: Comm + ?Sized>(comm: &C, sums: Vec<ExactSum>) -> Vec<f64> {
    let count = sums.len();
    let mut words = Vec::new();
    for s in sums {
        let t = s.terms();
        words.push(t.len() as f64);
        words.extend(t);
    }
    let all = all_gather(comm, &words);
    let mut lists: Vec<Vec<&[f64]>> = vec![Vec::new(); count];
    for w in &all {
        let mut at = 0;
        for list in lists.iter_mut() {
            let n = w[at] as usize;
            list.push(&w[at + 1..at + 1 + n]);
            at += 1 + n;
        }
    }
    lists.into_iter().map(crate::exact::merge).collect()
}

/// Every rank's `verdict` (go on, stop, or an error) made one, in one max
/// collective: this rank's own error; else [`Error::Diverged`] saying
/// `failed` if another rank's failed; else whether any rank asked to stop.
fn agree<C: Comm + ?Sized>(comm: &C, verdict: Result<bool>, failed: &str) -> Result<bool> {
    let code = match &verdict {
        Ok(false) => 0.0,
        Ok(true) => 1.0,
        Err(_) => 2.0,
    };
    let code = comm.max(&[code])[0];
    let stop = verdict?;
    if code == 2.0 {
        return Err(Error::Diverged(format!("{failed}; the run stops with it")));
    }
    Ok(stop || code == 1.0)
}

/// Bytes in buffers of `f64` words bound for ranks other than `rank` (a
/// rank's buffer to itself is a copy, not traffic).
fn bytes_to_others(out: &[Vec<f64>], rank: usize) -> f64 {
    out.iter()
        .enumerate()
        .filter(|(r, _)| *r != rank)
        .map(|(_, b)| 8.0 * b.len() as f64)
        .sum()
}

/// Steps a scene's fluid `initial` (every particle, ids `0..n` in the single
/// solver's order, as [`Particles::of_solver`] gives after set-up) on the
/// ranks of `comm`, each rank's passes through `exec`: for each output of
/// `stepping`, its steps, then the particles gathered on rank 0 and handed
/// to `on_output` there, which returns whether the run stops. Before each
/// step `before_step` sees every rank's solver with the largest fluid speed
/// of all ranks (the single solver's [`Solver::max_speed`]), to retune its
/// forces; after it, `after_step` sees the exact state (energy sums, cheap
/// checks) and may stop the run.
///
/// # Errors
/// [`Error::Core`] if a rank's solver refuses its part or diverges, or the
/// error of `before_step`, `after_step` or `on_output` (on the rank where
/// it arose; the others report [`Error::Diverged`] naming it).
#[allow(clippy::too_many_arguments)]
pub fn run<S, K, M, D, T, C, E>(
    comm: &C,
    exec: &E,
    setup: &Setup<S, D, T>,
    initial: &Particles,
    mut stepping: Stepping<'_>,
    before_step: &BeforeStep<'_, S, K, M, D, T>,
    after_step: &mut AfterStep<'_, S, K, M, D, T>,
    on_output: &mut dyn FnMut(Output) -> Result<bool>,
) -> Result<()>
where
    S: Space,
    K: Kernel,
    M: Math<S::Real>,
    D: Term<S>,
    T: Term<S>,
    C: Comm + ?Sized,
    E: Executor,
{
    let dim = S::DIM;
    let w = Particles::width(dim);
    let axis = cut_axis(&setup.domain);
    let extent = setup.domain.extent()[axis].to_f64();
    let periodic = setup.domain.is_periodic(axis);
    let radius = (S::Real::ONE + setup.params.skin).to_f64() * K::SUPPORT * setup.params.h.to_f64();
    let levels = if setup.domain.wall_particles().is_some() {
        3.0
    } else {
        2.0
    };
    // Every rank holds the initial state; each starts from an equal share
    // of it (ids `rank, rank + size, ...`), then the particles go to the
    // ranks whose slabs hold them. The first part's lists are built at the
    // initial positions, so its halo needs no drift allowance.
    let share: Vec<usize> = (comm.rank()..initial.len()).step_by(comm.size()).collect();
    let mut owned = Particles {
        dim,
        words: share
            .iter()
            .flat_map(|&k| initial.record(k).iter().copied())
            .collect(),
    };
    let coords: Vec<f64> = (0..owned.len())
        .map(|k| owned.coordinate(k, axis))
        .collect();
    let slabs = Slabs::balanced(comm, axis, extent, periodic, &coords);
    let mut stats = RankStats {
        rank: comm.rank(),
        ..RankStats::default()
    };
    let (mut part, sent) = distribute(comm, &slabs, &owned, levels * radius);
    stats.bytes_sent += sent;
    // Steps done, the output next due and the steps it falls after.
    let outputs = match &stepping {
        Stepping::Fixed(plan) => plan.len(),
        Stepping::Adaptive { outputs, .. } => *outputs,
    };
    let mut done = 0u64;
    let mut index = 0usize;
    let mut due = match &stepping {
        Stepping::Fixed(plan) => plan.first().map_or(0, |p| p.0),
        Stepping::Adaptive { .. } => 0,
    };
    // Steps in the current interval, and the step that awaits `after_step`.
    let mut in_interval = 0u64;
    let mut pending: Option<f64> = None;
    let mut state: Option<Resume> = None;
    let mut migrating: Option<Stopwatch> = None;
    loop {
        let n = part.local.len();
        let mut buffers =
            Buffers::<S>::new(n + setup.ghost_room, setup.cells).with_lists(n, setup.list_width);
        if T::SHIFTS {
            buffers = buffers.with_shifting();
        }
        for k in 0..n {
            let r = part.local.record(k);
            buffers.x[k] = S::Vector::from_fn(|a| S::Real::from_f64(r[1 + a]));
            buffers.v[k] = S::Vector::from_fn(|a| S::Real::from_f64(r[1 + dim + a]));
            buffers.m[k] = S::Real::from_f64(r[1 + 2 * dim]);
            buffers.rho[k] = S::Real::from_f64(r[2 + 2 * dim]);
        }
        let built = match state {
            // The first part: lists built at the initial positions, as
            // the single solver's set-up built them.
            None => Solver::<S, K, M, D, T>::new_with(
                exec,
                setup.params,
                setup.domain,
                buffers.storage(),
                n,
                setup.density,
                setup.forces,
            ),
            // After a migration: the coming step rebuilds the lists.
            Some(resume) => Solver::<S, K, M, D, T>::resume_with(
                setup.params,
                setup.domain,
                buffers.storage(),
                n,
                setup.density,
                setup.forces,
                resume,
            ),
        };
        let (mut solver, mut failure) = match built {
            Ok(s) => (Some(s), None),
            Err(e) => (None, Some(Error::Core(e))),
        };
        if let Some(solver) = solver.as_mut() {
            let mut f = solver.fluid_mut();
            for k in 0..n {
                write_record::<S>(&mut f, k, part.local.record(k));
            }
        }
        if let Some(clock) = migrating.take() {
            stats.migrate_seconds += clock.seconds();
        }
        let own: Vec<(usize, usize)> = part
            .owned
            .iter()
            .map(|&k| (k, part.local.record(k)[0] as usize))
            .collect();
        // The records were just written: every particle's state is exact.
        let mut fresh = true;
        loop {
            // Every copy takes its owner's state, so each rank measures
            // the drift on exact particles (the halo's outer layer drifts
            // on cut neighbourhoods within a step).
            if !fresh {
                let clock = Stopwatch::start();
                stats.bytes_sent += match solver.as_mut() {
                    Some(s) => refresh(comm, s, &part),
                    None => {
                        comm.exchange(vec![Vec::new(); comm.size()]);
                        0.0
                    }
                };
                stats.halo_seconds += clock.seconds();
            }
            // A fixed step is known before the collective; an adaptive one
            // needs the maxima first.
            let planned = match &stepping {
                Stepping::Fixed(plan) => Some(plan.get(index).map_or(0.0, |p| p.1)),
                Stepping::Adaptive { .. } => None,
            };
            // One collective per step: the largest drift (of a fixed step),
            // speed and acceleration, and whether any rank failed.
            let local = match (&solver, &failure) {
                (Some(s), None) => {
                    let (v, a) = (s.velocities(), s.accelerations());
                    let (v2, a2) = own
                        .iter()
                        .fold((S::Real::ZERO, S::Real::ZERO), |m, &(k, _)| {
                            (m.0.max(v[k].norm2()), m.1.max(a[k].norm2()))
                        });
                    let drift2 = planned.map_or(0.0, |dt| s.drift_speed2(dt).to_f64());
                    [drift2, v2.to_f64(), a2.to_f64(), -1.0]
                }
                _ => [0.0, 0.0, 0.0, comm.rank() as f64],
            };
            let clock = Stopwatch::start();
            let agreed = comm.max(&local);
            stats.reduce_seconds += clock.seconds();
            stats.bytes_sent += 8.0 * (local.len() * (comm.size() - 1)) as f64;
            let (vmax2, amax2, failed) = (agreed[1], agreed[2], agreed[3]);
            let s = match solver.as_mut() {
                Some(s) if failed < 0.0 => s,
                _ => {
                    return Err(failure.unwrap_or_else(|| {
                        Error::Diverged(format!("rank {failed} failed; the run stops with it"))
                    }))
                }
            };
            // The step just taken, now that every particle is exact; every
            // rank learns whether any hook failed or asked to stop.
            if let Some(dt) = pending.take() {
                let step = StepDone {
                    dt,
                    in_interval: in_interval - 1,
                    owned: &own,
                };
                let verdict = after_step(s, &step);
                let clock = Stopwatch::start();
                let stop = agree(comm, verdict, "a rank failed after a step")?;
                stats.reduce_seconds += clock.seconds();
                if stop {
                    return Ok(());
                }
            }
            let dt = match &mut stepping {
                Stepping::Fixed(_) => planned.filter(|_| done != due),
                Stepping::Adaptive { choose, .. } if index < outputs => {
                    let limits = s.limits_at(S::Real::from_f64(vmax2), S::Real::from_f64(amax2));
                    choose(index, s.time(), limits)
                }
                Stepping::Adaptive { .. } => None,
            };
            if dt.is_none() && index < outputs {
                let words = part.pack(s, &part.owned);
                if comm.rank() != 0 {
                    stats.bytes_sent += 8.0 * words.len() as f64;
                }
                let all = comm.exchange(
                    (0..comm.size())
                        .map(|r| if r == 0 { words.clone() } else { Vec::new() })
                        .collect(),
                );
                stats.owned = part.owned.len();
                stats.halo = part.local.len() - part.owned.len();
                stats.steps = done;
                let figures = comm.exchange(
                    (0..comm.size())
                        .map(|r| {
                            if r == 0 {
                                stats.words().to_vec()
                            } else {
                                Vec::new()
                            }
                        })
                        .collect(),
                );
                // Rank 0 decides whether the run goes on; an error there
                // stops every rank.
                let verdict = if comm.rank() == 0 {
                    let mut owners = vec![0u32; initial.len()];
                    for (r, words) in all.iter().enumerate() {
                        for rec in words.chunks_exact(w) {
                            if let Some(o) = owners.get_mut(rec[0] as usize) {
                                *o = r as u32;
                            }
                        }
                    }
                    on_output(Output {
                        index,
                        owners,
                        particles: sorted(dim, all.concat()),
                        time: s.time(),
                        steps: s.steps(),
                        ranks: figures.iter().map(|w| RankStats::from_words(w)).collect(),
                    })
                } else {
                    Ok(false)
                };
                let stop = agree(comm, verdict, "rank 0 failed at an output")?;
                index += 1;
                in_interval = 0;
                if stop || index == outputs {
                    return Ok(());
                }
                if let Stepping::Fixed(plan) = &stepping {
                    due += plan[index].0;
                }
                // The step's length changed: measure the drift again.
                fresh = false;
                continue;
            }
            let Some(dt) = dt else {
                // Every output was made.
                return Ok(());
            };
            let drift2 = match planned {
                Some(_) => agreed[0],
                None => {
                    let clock = Stopwatch::start();
                    let d = comm.max(&[s.drift_speed2(dt).to_f64()])[0];
                    stats.reduce_seconds += clock.seconds();
                    d
                }
            };
            let drift2 = S::Real::from_f64(drift2);
            // A part after a migration rebuilds in its first step; it
            // migrates again only at the next rebuild. A single rank owns
            // everything: its solver rebuilds its own lists, as one
            // process does.
            if comm.size() > 1 && !(fresh && state.is_some()) && s.rebuilds_next(dt, drift2) {
                let clock = Stopwatch::start();
                stats.migrations += 1;
                let words = part.pack(s, &part.owned);
                owned = Particles { dim, words };
                let mut resume = s.resume_state();
                resume.lists_fresh = false;
                resume.n_ghost = 0;
                resume.cell_len = 0;
                resume.partitioned = false;
                state = Some(resume);
                // The drift may carry a particle this far before the lists
                // are built.
                let reach = 2.0 * drift2.to_f64().sqrt() * dt;
                let coords: Vec<f64> = (0..owned.len())
                    .map(|k| owned.coordinate(k, axis))
                    .collect();
                let slabs = Slabs::balanced(comm, axis, extent, periodic, &coords);
                let sent;
                (part, sent) = distribute(comm, &slabs, &owned, levels * radius + reach);
                stats.bytes_sent += sent;
                // The next part's solver is built at the loop's top.
                migrating = Some(clock);
                break;
            }
            fresh = false;
            let vmax = M::sqrt(S::Real::from_f64(vmax2)).to_f64();
            let clock = Stopwatch::start();
            let stepped = before_step(s, vmax)
                .and_then(|()| s.step_bounded_with(exec, dt, drift2).map_err(Error::Core));
            stats.step_seconds += clock.seconds();
            if let Err(e) = stepped {
                failure = Some(e);
                solver = None;
                continue;
            }
            done += 1;
            in_interval += 1;
            pending = Some(dt);
        }
    }
}

/// Sends the owners' current state to every copy; returns the bytes sent.
fn refresh<S, K, M, D, T, C>(comm: &C, s: &mut Solver<'_, S, K, M, D, T>, part: &Part) -> f64
where
    S: Space,
    K: Kernel,
    M: Math<S::Real>,
    D: Term<S>,
    T: Term<S>,
    C: Comm + ?Sized,
{
    let out: Vec<Vec<f64>> = part.send.iter().map(|slots| part.pack(s, slots)).collect();
    let sent = bytes_to_others(&out, comm.rank());
    let got = comm.exchange(out);
    let w = Particles::width(S::DIM);
    let mut f = s.fluid_mut();
    for (slots, words) in part.recv.iter().zip(&got) {
        for (&i, r) in slots.iter().zip(words.chunks_exact(w)) {
            write_record::<S>(&mut f, i, r);
        }
    }
    sent
}

#[cfg(test)]
mod tests {
    use super::*;
    use sph_core::prelude::*;
    use std::f64::consts::PI;

    type V2 = Vector<f64, 2>;

    /// A 2D scene: the box, the lattice spacing and the initial velocity.
    struct Case {
        domain: Domain<D2<f64>>,
        nx: usize,
        ny: usize,
        dx: f64,
        velocity: fn(f64, f64) -> [f64; 2],
    }

    /// Runs `case` for `steps` steps as one solver and on 1 to 4 ranks,
    /// and asserts every rank count gives every particle's every field
    /// bit for bit.
    fn same_bits<D: Term<D2<f64>>, T: Term<D2<f64>>>(
        case: &Case,
        density: D,
        forces: T,
        steps: u64,
    ) {
        let n = case.nx * case.ny;
        let h = 1.3 * case.dx;
        let params = Params::new(
            h,
            Eos::Linear {
                rho0: 1.0,
                c0: 10.0,
                p0: 1.0,
            },
        );
        let cells =
            Solver::<D2<f64>, CubicSpline, Libm, D, T>::cells_needed(&case.domain, h).unwrap();
        let width = crate::driver::list_width(2, 2.0, 1.3, 0.1) + 16;
        let setup = Setup {
            params,
            domain: case.domain,
            density,
            forces,
            cells,
            list_width: width,
            ghost_room: 4 * n,
        };
        let mut buffers = Buffers::<D2<f64>>::new(n + setup.ghost_room, cells).with_lists(n, width);
        for j in 0..case.ny {
            for i in 0..case.nx {
                let (x, y) = ((i as f64 + 0.5) * case.dx, (j as f64 + 0.5) * case.dx);
                let k = j * case.nx + i;
                buffers.x[k] = V2::new([x, y]);
                buffers.v[k] = V2::new((case.velocity)(x, y));
                buffers.m[k] = case.dx * case.dx;
                buffers.rho[k] = 1.0;
            }
        }
        let mut single = Solver::<D2<f64>, CubicSpline, Libm, D, T>::new_with(
            &Serial,
            params,
            case.domain,
            buffers.storage(),
            n,
            density,
            forces,
        )
        .unwrap();
        let initial = Particles::of_solver(&single);
        let dt = 0.5 * single.limits().min();
        for _ in 0..steps {
            single.step(dt).unwrap();
        }
        assert!(
            single.neighbour_builds() >= 4,
            "the lists must be rebuilt, and particles migrate"
        );
        let want = Particles::of_solver(&single);
        for ranks in 1..=4 {
            let got = Threads::run(ranks, |comm| {
                let mut got = None;
                run::<D2<f64>, CubicSpline, Libm, D, T, _, _>(
                    comm,
                    &Serial,
                    &setup,
                    &initial,
                    Stepping::Fixed(&[(steps, dt)]),
                    &|_, _| Ok(()),
                    &mut |_, _| Ok(false),
                    &mut |out| {
                        assert_eq!((out.index, out.steps), (0, steps));
                        got = Some(out.particles);
                        Ok(false)
                    },
                )
                .map(|()| got)
            })
            .unwrap();
            let got = got.into_iter().next().unwrap().unwrap().unwrap();
            assert_eq!(got.len(), n, "{ranks} ranks");
            for k in 0..n {
                let (a, b) = (want.record(k), got.record(k));
                let same = a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
                assert!(same, "{ranks} ranks, particle {k}:\n{a:?}\n{b:?}");
            }
        }
    }

    #[test]
    fn a_funnelled_comm_exchanges_as_its_transport() {
        let got = Threads::run(3, |comm| {
            funnel(comm, |relay| {
                let r = relay.rank() as f64;
                let out = (0..3).map(|to| vec![10.0 * r + to as f64]).collect();
                (relay.exchange(out), relay.sum(&[r]), relay.max(&[r]))
            })
            .unwrap()
        })
        .unwrap();
        for (r, (got, sum, max)) in got.into_iter().enumerate() {
            let want: Vec<Vec<f64>> = (0..3)
                .map(|from| vec![10.0 * from as f64 + r as f64])
                .collect();
            assert_eq!(got, want);
            assert_eq!((sum, max), (vec![3.0], vec![2.0]));
        }
    }

    /// Runs a built-in case as one process and on `ranks` (threads as
    /// ranks, through `scene::run_with`), `fraction` of its default
    /// duration at `resolution`, and asserts the same frames and
    /// diagnostics, bit for bit (as their shortest round-trip text).
    fn same_record(name: &str, resolution: usize, fraction: f64, ranks: &[usize]) {
        let want = same_record_with(name, resolution, fraction, ranks, |_| {});
        assert!(
            want.complete() && want.frames.len() == 2,
            "{name}: {:?}",
            want.stop
        );
        assert!(want.steps >= 20, "{name}: only {} steps", want.steps);
    }

    /// As [`same_record`], with `tweak` applied to the scene; the stop, the
    /// adaptive step's range and the energy budget (in the outputs) must
    /// agree too. Returns the single run's record.
    fn same_record_with(
        name: &str,
        resolution: usize,
        fraction: f64,
        ranks: &[usize],
        tweak: fn(&mut crate::scene::Scene),
    ) -> crate::scene::RunRecord {
        use crate::scene::{run, run_with, RunControl};
        let mut settings = (crate::cases::find(name).unwrap().defaults)();
        settings.resolution = resolution;
        settings.t_end *= fraction;
        settings.output_interval = settings.t_end / 2.0;
        settings.threads = 1;
        let mut scene = crate::cases::scene(&settings).unwrap();
        scene.keep_particles = true;
        tweak(&mut scene);
        let silent = crate::couette::Silent;
        let want = run(&scene, &silent).unwrap();
        assert!(
            want.stop.is_some() || want.frames.len() >= 2,
            "{name}: {:?}, {} frames",
            want.stop,
            want.frames.len()
        );
        let text = |r: &crate::scene::RunRecord| {
            format!(
                "{:?} {:?} {} {:?} {:?}",
                r.frames, r.outputs, r.steps, r.stop, r.dt_range
            )
        };
        for &n in ranks {
            let got = Threads::run(n, |comm| {
                let mut none =
                    |_: &crate::scene::RunRecord, _: &crate::checkpoint::Checkpoint| Ok(());
                let mut ctl = RunControl::new(&silent, &mut none);
                ctl.ranks = Some(comm);
                run_with(&scene, &mut ctl).map(|r| text(&r))
            })
            .unwrap();
            assert_eq!(
                got[0].as_ref().unwrap(),
                &text(&want),
                "{name} on {n} ranks"
            );
        }
        want
    }

    #[test]
    fn an_adaptive_step_and_the_energy_budget_on_ranks_are_the_single_run_bitwise() {
        // The dam break's defaults: adaptive step, energy budget, wall
        // particles and a free surface.
        let want = same_record_with("dam-break", 10, 0.05, &[2, 3], |_| {});
        assert!(want.complete() && want.steps >= 20, "{want:?}");
        let [lo, hi] = want.dt_range.unwrap();
        assert!(lo > 0.0 && hi >= lo);
        assert!(want.outputs.iter().all(|d| d.energy.is_some()));
        // Taylor-Green with both switched on: periodic in both axes.
        let want = same_record_with("taylor-green", 16, 0.05, &[2, 4], |s| {
            s.physics.adaptive_dt = true;
            s.physics.energy_budget = true;
        });
        assert!(want.complete() && want.steps >= 20, "{want:?}");
        let e = want.outputs.last().unwrap().energy.unwrap();
        // The budget closes: the viscous dissipation is what the kinetic
        // energy lost (to the time integration's error).
        assert!(e.dissipated_energy > 0.0, "{e:?}");
    }

    #[test]
    fn a_monitor_stop_between_outputs_on_ranks_is_the_single_runs() {
        // A Mach limit below the vortex's speed: the cheap check between
        // outputs stops the run at its first check, naming the fastest
        // particle (by id).
        let want = same_record_with("taylor-green", 16, 0.05, &[2, 3], |s| {
            s.monitor.max_mach = 1e-3;
            s.monitor.every = 7;
        });
        let stop = want.stop.expect("the monitor stops the run");
        assert!(stop.particle.is_some(), "{stop:?}");
        assert_eq!(want.steps, 7, "{stop:?}");
    }

    #[test]
    fn the_couette_taylor_green_and_cavity_scenes_on_2_and_3_ranks_are_the_single_run_bitwise() {
        same_record("couette", 12, 0.05, &[2, 3]);
        same_record("taylor-green", 16, 0.05, &[2, 3]);
        same_record("lid-driven-cavity", 12, 0.01, &[2, 3]);
    }

    #[test]
    fn taylor_green_with_continuity_density_on_1_to_4_ranks_is_the_single_solver_bitwise() {
        let domain = Domain::<D2<f64>>::new(V2::new([0.0, 0.0]), V2::new([1.0, 1.0]))
            .unwrap()
            .with_periodic(0)
            .unwrap()
            .with_periodic(1)
            .unwrap();
        let case = Case {
            domain,
            nx: 24,
            ny: 24,
            dx: 1.0 / 24.0,
            velocity: |x, y| {
                let (k, u) = (2.0 * PI, 1.0);
                [
                    u * (k * x).sin() * (k * y).cos(),
                    -u * (k * x).cos() * (k * y).sin(),
                ]
            },
        };
        let forces = (Continuity, PressureGradient, MorrisViscosity { mu: 0.01 });
        same_bits(&case, (), forces, 60);
    }

    #[test]
    fn couette_with_a_perturbation_on_1_to_4_ranks_is_the_single_solver_bitwise() {
        let domain = Domain::<D2<f64>>::new(V2::new([0.0, 0.0]), V2::new([2.0, 1.0]))
            .unwrap()
            .with_periodic(0)
            .unwrap()
            .with_wall(1, Side::Lower, Wall::no_slip())
            .unwrap()
            .with_wall(1, Side::Upper, Wall::moving(V2::new([1.0, 0.0])))
            .unwrap();
        let case = Case {
            domain,
            nx: 32,
            ny: 16,
            dx: 1.0 / 16.0,
            velocity: |x, y| [y, 0.3 * (PI * x).sin() * (PI * y).sin()],
        };
        let forces = (PressureGradient, MorrisViscosity { mu: 0.02 });
        same_bits(&case, SummationDensity, forces, 60);
    }

    #[test]
    fn a_lid_driven_cavity_with_wall_particles_cut_across_walls_is_the_single_solver_bitwise() {
        let dx = 1.0 / 16.0;
        let domain = Domain::<D2<f64>>::new(V2::new([0.0, 0.0]), V2::new([1.5, 1.0]))
            .unwrap()
            .with_wall(0, Side::Lower, Wall::no_slip())
            .unwrap()
            .with_wall(0, Side::Upper, Wall::no_slip())
            .unwrap()
            .with_wall(1, Side::Lower, Wall::no_slip())
            .unwrap()
            .with_wall(1, Side::Upper, Wall::moving(V2::new([1.0, 0.0])))
            .unwrap()
            .with_wall_particles(dx)
            .unwrap();
        let case = Case {
            domain,
            nx: 24,
            ny: 16,
            dx,
            velocity: |x, y| [0.5 * (PI * x / 1.5).sin() * y, 0.0],
        };
        let forces = (PressureGradient, MorrisViscosity { mu: 0.02 });
        same_bits(&case, SummationDensity, forces, 60);
    }
}
