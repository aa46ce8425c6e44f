//! Checkpoints: a run's whole state at a step boundary, so that
//! `sph resume DIR` continues it bit for bit.
//!
//! What a step reads is more than the particles' positions and velocities:
//! the accelerations and density rates of the last evaluation (the next
//! step starts with a half kick from them), the Verlet lists and the cell
//! list (they fix the order of every neighbour sum, so rebuilding them at
//! another step would change the last bits), the ghost records, and the
//! solver's scalars ([`Resume`]). A checkpoint copies all of it, every real
//! as an `f64` (exact for `f32` runs), together with the diagnostics and
//! particle frames of the output times already reached and where the run
//! stood in its output plan.
//!
//! The file (`checkpoint.bin` in the output directory) is little-endian
//! binary: a magic string with a format version, then the fields in the
//! order of [`Checkpoint::to_bytes`]. Reading checks every length, so a
//! truncated or foreign file is an error naming it, never a panic.

use std::path::Path;

use sph_core::solver::Resume;

use crate::error::{Error, Result};
use crate::scene::{Diagnostics, Energy, Frame};

/// The checkpoint's file name inside an output directory.
pub const FILE: &str = "checkpoint.bin";

/// Magic string and format version.
const MAGIC: &[u8; 8] = b"SPHCKPT\x02";

/// Names of the real-valued buffers, in the order of [`Arrays::reals`].
pub const REAL_NAMES: [&str; 10] = [
    "x", "v", "m", "rho", "p", "ve", "dv", "drho", "rho_aux", "shift",
];

/// Names of the integer buffers, in the order of [`Arrays::words`].
pub const WORD_NAMES: [&str; 7] = [
    "ghost_source",
    "ghost_mirrors",
    "cell_start",
    "cell_sorted",
    "cell_index",
    "neighbours",
    "neighbour_counts",
];

/// Every storage buffer of a solver, whole (see
/// [`crate::driver::save`] and [`crate::driver::Buffers::load`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Arrays {
    /// Real buffers in [`REAL_NAMES`] order; vectors flattened, `dim`
    /// components per slot.
    pub reals: Vec<Vec<f64>>,
    /// Integer buffers in [`WORD_NAMES`] order (a ghost record as its
    /// source and its mirror bits).
    pub words: Vec<Vec<u32>>,
}

/// Options of the command that started the run, which its resumption keeps.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Options {
    /// VTK snapshots were asked for.
    pub vtk: bool,
    /// In ASCII rather than binary.
    pub vtk_ascii: bool,
    /// Simulated seconds between checkpoints (0: none).
    pub checkpoint_every: f64,
    /// The run may exceed the step ceiling.
    pub allow_long_run: bool,
}

/// A run's state at a step boundary.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    /// Case name (checked against the configuration on resumption).
    pub case: String,
    /// Dimension.
    pub dim: usize,
    /// Fluid particles.
    pub n_fluid: usize,
    /// Index of the output interval being stepped through.
    pub interval: usize,
    /// Steps of that interval already taken.
    pub done: u64,
    /// The run's time step (fixed at its start; with an adaptive step, the
    /// estimate made at the start).
    pub dt: f64,
    /// With an adaptive step, the smallest and largest steps so far.
    pub dt_range: Option<[f64; 2]>,
    /// The time-step limits at the run's start: `[cfl, viscous, force]`.
    pub limits: [f64; 3],
    /// Bytes of particle storage.
    pub storage_bytes: usize,
    /// The solver's scalars.
    pub state: Resume,
    /// The storage.
    pub arrays: Arrays,
    /// Diagnostics of the output times reached.
    pub outputs: Vec<Diagnostics>,
    /// Particle frames of the output times reached (where kept).
    pub frames: Vec<Frame>,
    /// The energy budget's running state: the dissipated energy, the
    /// dissipative power at the last step, the periodic body force's
    /// potential and its work rate at the last step (zeros without a budget).
    pub budget: [f64; 4],
    /// The command's options.
    pub options: Options,
}

struct Writer(Vec<u8>);

impl Writer {
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.u64(v.to_bits());
    }
    fn opt(&mut self, v: Option<f64>) {
        self.u64(u64::from(v.is_some()));
        self.f64(v.unwrap_or(0.0));
    }
    fn f64s(&mut self, v: &[f64]) {
        self.u64(v.len() as u64);
        for &x in v {
            self.f64(x);
        }
    }
    fn u32s(&mut self, v: &[u32]) {
        self.u64(v.len() as u64);
        for &x in v {
            self.0.extend_from_slice(&x.to_le_bytes());
        }
    }
    fn str(&mut self, s: &str) {
        self.u64(s.len() as u64);
        self.0.extend_from_slice(s.as_bytes());
    }
    fn triples(&mut self, v: &[[f64; 3]]) {
        self.u64(v.len() as u64);
        for x in v {
            for &c in x {
                self.f64(c);
            }
        }
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

/// Why a file is not a checkpoint this version can read.
struct Bad;

impl Reader<'_> {
    fn take(&mut self, n: usize) -> std::result::Result<&[u8], Bad> {
        let end = self.at.checked_add(n).ok_or(Bad)?;
        let s = self.bytes.get(self.at..end).ok_or(Bad)?;
        self.at = end;
        Ok(s)
    }
    fn u64(&mut self) -> std::result::Result<u64, Bad> {
        let b = self.take(8)?;
        Ok(u64::from_le_bytes(b.try_into().map_err(|_| Bad)?))
    }
    fn usize(&mut self) -> std::result::Result<usize, Bad> {
        usize::try_from(self.u64()?).map_err(|_| Bad)
    }
    fn f64(&mut self) -> std::result::Result<f64, Bad> {
        Ok(f64::from_bits(self.u64()?))
    }
    fn bool(&mut self) -> std::result::Result<bool, Bad> {
        match self.u64()? {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(Bad),
        }
    }
    fn opt(&mut self) -> std::result::Result<Option<f64>, Bad> {
        let some = self.bool()?;
        let v = self.f64()?;
        Ok(some.then_some(v))
    }
    /// A length prefix, refused when the rest of the file cannot hold that
    /// many items of `size` bytes (a corrupt length must not allocate).
    fn len(&mut self, size: usize) -> std::result::Result<usize, Bad> {
        let n = self.usize()?;
        if n.checked_mul(size).ok_or(Bad)? > self.bytes.len() - self.at {
            return Err(Bad);
        }
        Ok(n)
    }
    fn f64s(&mut self) -> std::result::Result<Vec<f64>, Bad> {
        let n = self.len(8)?;
        (0..n).map(|_| self.f64()).collect()
    }
    fn u32s(&mut self) -> std::result::Result<Vec<u32>, Bad> {
        let n = self.len(4)?;
        let b = self.take(4 * n)?;
        Ok(b.chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect())
    }
    fn str(&mut self) -> std::result::Result<String, Bad> {
        let n = self.len(1)?;
        String::from_utf8(self.take(n)?.to_vec()).map_err(|_| Bad)
    }
    fn triples(&mut self) -> std::result::Result<Vec<[f64; 3]>, Bad> {
        let n = self.len(24)?;
        (0..n)
            .map(|_| Ok([self.f64()?, self.f64()?, self.f64()?]))
            .collect()
    }
}

impl Checkpoint {
    /// The binary encoding.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Writer(MAGIC.to_vec());
        w.str(&self.case);
        w.u64(self.dim as u64);
        w.u64(self.n_fluid as u64);
        w.u64(self.interval as u64);
        w.u64(self.done);
        w.u64(self.storage_bytes as u64);
        w.f64(self.dt);
        for l in self.limits {
            w.f64(l);
        }
        let s = &self.state;
        w.f64(s.time);
        w.u64(s.steps);
        w.u64(s.n_ghost as u64);
        w.u64(s.cell_len as u64);
        w.u64(u64::from(s.builds));
        for v in [s.vmax2, s.amax2, s.viscous_rate, s.travel] {
            w.f64(v);
        }
        w.u64(u64::from(s.lists_fresh));
        w.u64(u64::from(s.partitioned));
        w.u64(self.arrays.reals.len() as u64);
        for r in &self.arrays.reals {
            w.f64s(r);
        }
        w.u64(self.arrays.words.len() as u64);
        for r in &self.arrays.words {
            w.u32s(r);
        }
        w.u64(self.outputs.len() as u64);
        for d in &self.outputs {
            w.f64(d.t);
            w.f64(d.kinetic_energy);
            w.opt(d.kinetic_energy_exact);
            w.f64(d.min_spacing);
            w.f64(d.max_density_deviation);
            w.f64(d.max_mach);
            w.opt(d.linf);
            w.opt(d.l2);
            w.u64(u64::from(d.energy.is_some()));
            if let Some(e) = d.energy {
                for x in [
                    e.kinetic_energy,
                    e.potential_energy,
                    e.internal_energy,
                    e.dissipated_energy,
                    e.total_energy,
                ] {
                    w.f64(x);
                }
            }
        }
        w.u64(self.frames.len() as u64);
        for f in &self.frames {
            w.f64(f.t);
            w.triples(&f.x);
            w.triples(&f.v);
            w.f64s(&f.rho);
            w.f64s(&f.p);
        }
        for b in self.budget {
            w.f64(b);
        }
        w.u64(u64::from(self.dt_range.is_some()));
        for x in self.dt_range.unwrap_or_default() {
            w.f64(x);
        }
        w.u64(u64::from(self.options.vtk));
        w.u64(u64::from(self.options.vtk_ascii));
        w.f64(self.options.checkpoint_every);
        w.u64(u64::from(self.options.allow_long_run));
        w.0
    }

    /// Decodes [`Self::to_bytes`]; `path` only names the file in errors.
    ///
    /// # Errors
    /// [`Error::Config`] (key `checkpoint`) if the bytes are not a
    /// checkpoint of this format version (truncated, foreign, corrupt).
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        if bytes.get(..MAGIC.len()) != Some(&MAGIC[..]) {
            return Err(Error::config(
                "checkpoint",
                path.display(),
                "is not a checkpoint written by this version of sph",
            ));
        }
        let mut r = Reader {
            bytes,
            at: MAGIC.len(),
        };
        let decoded =
            Self::decode(&mut r).and_then(|c| if r.at == bytes.len() { Ok(c) } else { Err(Bad) });
        decoded.map_err(|Bad| {
            Error::config(
                "checkpoint",
                path.display(),
                "is truncated or corrupt (its lengths do not add up)",
            )
        })
    }

    fn decode(r: &mut Reader<'_>) -> std::result::Result<Self, Bad> {
        let case = r.str()?;
        let dim = r.usize()?;
        let n_fluid = r.usize()?;
        let interval = r.usize()?;
        let done = r.u64()?;
        let storage_bytes = r.usize()?;
        let dt = r.f64()?;
        let limits = [r.f64()?, r.f64()?, r.f64()?];
        let time = r.f64()?;
        let steps = r.u64()?;
        let n_ghost = r.usize()?;
        let cell_len = r.usize()?;
        let builds = u32::try_from(r.u64()?).map_err(|_| Bad)?;
        let (vmax2, amax2, viscous_rate, travel) = (r.f64()?, r.f64()?, r.f64()?, r.f64()?);
        let lists_fresh = r.bool()?;
        let partitioned = r.bool()?;
        let state = Resume {
            time,
            steps,
            n_ghost,
            cell_len,
            builds,
            vmax2,
            amax2,
            viscous_rate,
            travel,
            lists_fresh,
            partitioned,
        };
        let n = r.len(8)?;
        let reals = (0..n)
            .map(|_| r.f64s())
            .collect::<std::result::Result<_, _>>()?;
        let n = r.len(8)?;
        let words = (0..n)
            .map(|_| r.u32s())
            .collect::<std::result::Result<_, _>>()?;
        let n = r.len(8 * 12)?;
        let mut outputs = Vec::with_capacity(n);
        for _ in 0..n {
            outputs.push(Diagnostics {
                t: r.f64()?,
                kinetic_energy: r.f64()?,
                kinetic_energy_exact: r.opt()?,
                min_spacing: r.f64()?,
                max_density_deviation: r.f64()?,
                max_mach: r.f64()?,
                linf: r.opt()?,
                l2: r.opt()?,
                energy: if r.bool()? {
                    Some(Energy {
                        kinetic_energy: r.f64()?,
                        potential_energy: r.f64()?,
                        internal_energy: r.f64()?,
                        dissipated_energy: r.f64()?,
                        total_energy: r.f64()?,
                    })
                } else {
                    None
                },
            });
        }
        let n = r.len(8 * 5)?;
        let mut frames = Vec::with_capacity(n);
        for _ in 0..n {
            frames.push(Frame {
                t: r.f64()?,
                x: r.triples()?,
                v: r.triples()?,
                rho: r.f64s()?,
                p: r.f64s()?,
            });
        }
        let budget = [r.f64()?, r.f64()?, r.f64()?, r.f64()?];
        let ranged = r.bool()?;
        let range = [r.f64()?, r.f64()?];
        let dt_range = ranged.then_some(range);
        let options = Options {
            vtk: r.bool()?,
            vtk_ascii: r.bool()?,
            checkpoint_every: r.f64()?,
            allow_long_run: r.bool()?,
        };
        Ok(Self {
            case,
            dim,
            n_fluid,
            interval,
            done,
            dt,
            limits,
            storage_bytes,
            state,
            arrays: Arrays { reals, words },
            outputs,
            frames,
            budget,
            dt_range,
            options,
        })
    }

    /// Reads `dir/checkpoint.bin`.
    ///
    /// # Errors
    /// [`Error::Io`] if it cannot be read (a missing one is named as such);
    /// as [`Self::from_bytes`].
    pub fn read(dir: &Path) -> Result<Self> {
        let path = dir.join(FILE);
        if !path.exists() {
            return Err(Error::config(
                "dir",
                dir.display(),
                "holds no checkpoint.bin: only a run that was interrupted or checkpointed (--checkpoint-every) can be resumed",
            ));
        }
        let bytes = std::fs::read(&path).map_err(|e| Error::io("read checkpoint", &path, e))?;
        Self::from_bytes(&bytes, &path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Checkpoint {
        Checkpoint {
            case: "couette".into(),
            dim: 2,
            n_fluid: 3,
            interval: 1,
            done: 17,
            dt: 1.25e-4,
            limits: [1e-3, 2e-4, f64::INFINITY],
            storage_bytes: 999,
            state: Resume {
                time: 0.1 + 0.2,
                steps: 2400,
                n_ghost: 2,
                cell_len: 5,
                builds: 7,
                vmax2: 1.0 / 3.0,
                amax2: 2.5,
                viscous_rate: 40.0,
                travel: 1e-9,
                lists_fresh: true,
                partitioned: false,
            },
            arrays: Arrays {
                reals: vec![vec![1.0, -0.0, f64::MIN_POSITIVE], vec![]],
                words: vec![vec![1, u32::MAX], vec![0]],
            },
            outputs: vec![Diagnostics {
                t: 0.05,
                kinetic_energy: 1.0e-3,
                kinetic_energy_exact: None,
                min_spacing: 0.99,
                max_density_deviation: 1e-4,
                max_mach: 0.1,
                linf: Some(2e-3),
                l2: Some(1e-3),
                energy: Some(Energy {
                    kinetic_energy: 1.0e-3,
                    potential_energy: -2.5,
                    internal_energy: 1e-5,
                    dissipated_energy: 0.125,
                    total_energy: -2.37599,
                }),
            }],
            frames: vec![Frame {
                t: 0.05,
                x: vec![[0.1, 0.2, 0.0]],
                v: vec![[1.0, 0.0, -1.0]],
                rho: vec![1000.0],
                p: vec![-3.5],
            }],
            budget: [0.125, -1e-3, 4.0, 0.5],
            dt_range: Some([1e-4, 3e-4]),
            options: Options {
                vtk: true,
                vtk_ascii: false,
                checkpoint_every: 0.5,
                allow_long_run: false,
            },
        }
    }

    #[test]
    fn a_checkpoint_survives_its_encoding_bit_for_bit() {
        let c = sample();
        let back = Checkpoint::from_bytes(&c.to_bytes(), Path::new("c")).unwrap();
        assert_eq!(back, c);
        // -0.0 == 0.0 for PartialEq: compare the bits too.
        assert_eq!(back.arrays.reals[0][1].to_bits(), (-0.0f64).to_bits());
    }

    #[test]
    fn every_truncation_and_a_foreign_file_are_errors_not_panics() {
        let bytes = sample().to_bytes();
        for cut in 0..bytes.len() {
            assert!(Checkpoint::from_bytes(&bytes[..cut], Path::new("c")).is_err());
        }
        let mut long = bytes.clone();
        long.push(0);
        assert!(Checkpoint::from_bytes(&long, Path::new("c")).is_err());
        assert!(Checkpoint::from_bytes(b"not a checkpoint", Path::new("c")).is_err());
        // A huge length prefix must not allocate.
        let mut huge = MAGIC.to_vec();
        huge.extend_from_slice(&u64::MAX.to_le_bytes());
        assert!(Checkpoint::from_bytes(&huge, Path::new("c")).is_err());
    }
}
