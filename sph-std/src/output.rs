//! Output files, each written atomically: a temporary file in the same
//! directory, then a rename. An interrupted run leaves complete files (old or
//! new), never half-written ones.

use std::fmt::Write as _;
use std::fs;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::couette::{CouetteRun, Snapshot, HEADLINE_T_STAR};
use crate::error::{Error, Result};

/// Writes `bytes` to `path` atomically.
///
/// # Errors
/// [`Error::Io`] naming the path.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("out");
    let tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let result = (|| {
        let mut file = fs::File::create(&tmp)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = fs::remove_file(&tmp);
        Error::io("write", path, e)
    })
}

/// Creates the output directory if needed and checks that it is writable,
/// before any work is done. Returns whether it was created (so a failed run
/// can remove it again and leave nothing behind).
///
/// # Errors
/// [`Error::Io`] if it cannot be created or written to.
pub fn prepare_dir(dir: &Path) -> Result<bool> {
    let existed = dir.is_dir();
    fs::create_dir_all(dir).map_err(|e| Error::io("create output directory", dir, e))?;
    let probe = dir.join(format!(".write-probe-{}", std::process::id()));
    fs::write(&probe, b"").map_err(|e| Error::io("write to output directory", dir, e))?;
    let _ = fs::remove_file(&probe);
    Ok(!existed)
}

/// Removes `dir` if it is empty (used when a run fails after [`prepare_dir`] created it).
pub fn remove_if_empty(dir: &Path) {
    let _ = fs::remove_dir(dir);
}

/// Prepares `dir` (see [`prepare_dir`]), runs `work`, and if `work` fails
/// removes the directory again when this call created it: a failed run
/// leaves nothing behind.
///
/// # Errors
/// Those of [`prepare_dir`] and of `work`.
pub fn in_dir<T>(dir: &Path, work: impl FnOnce() -> Result<T>) -> Result<T> {
    let created = prepare_dir(dir)?;
    work().inspect_err(|_| {
        if created {
            remove_if_empty(dir);
        }
    })
}

#[derive(Serialize)]
struct ErrorEntry {
    t: f64,
    t_star: f64,
    linf: f64,
    l2: f64,
}

#[derive(Serialize)]
struct LimitsEntry {
    cfl: f64,
    viscous: f64,
    force: f64,
}

#[derive(Serialize)]
#[allow(non_snake_case)]
struct Summary<'a> {
    case: &'static str,
    y_lower: f64,
    y_upper: f64,
    U: f64,
    nu: f64,
    rho0: f64,
    c0: f64,
    particles_across: usize,
    particles_along: usize,
    n_fluid: usize,
    dx: f64,
    h: f64,
    beta: f64,
    eta2: f64,
    kernel: &'a str,
    viscosity: &'a str,
    density: &'a str,
    precision: &'a str,
    math: &'a str,
    alpha: f64,
    threads: usize,
    t_end: f64,
    dt_factor: f64,
    dt_max: f64,
    limits: LimitsEntry,
    steps: u64,
    wall_seconds: f64,
    storage_bytes: usize,
    headline_t_star: f64,
    linf_error: f64,
    l2_error: f64,
    errors: Vec<ErrorEntry>,
}

/// `summary.json` of a run.
///
/// # Errors
/// Never for finite numbers; reported rather than assumed.
pub fn summary_json(run: &CouetteRun) -> Result<String> {
    let c = &run.config;
    let g = &run.geometry;
    let (linf, l2) = run.headline();
    let summary = Summary {
        case: "couette",
        y_lower: g.y_lower,
        y_upper: g.y_upper,
        U: c.u_wall,
        nu: c.nu,
        rho0: c.rho0,
        c0: g.c0,
        particles_across: c.particles_across,
        particles_along: g.nx,
        n_fluid: g.n_fluid,
        dx: g.dx,
        h: g.h,
        beta: c.beta,
        eta2: c.eta2,
        kernel: c.kernel.name(),
        viscosity: c.viscosity.name(),
        density: c.density.name(),
        precision: c.precision.name(),
        math: c.math.name(),
        alpha: g.alpha,
        threads: run.threads,
        t_end: c.t_end,
        dt_factor: c.dt_factor,
        dt_max: run.dt_max,
        limits: LimitsEntry {
            cfl: run.limits.cfl,
            viscous: run.limits.viscous,
            force: run.limits.force,
        },
        steps: run.steps,
        wall_seconds: run.wall_seconds,
        storage_bytes: run.storage_bytes,
        headline_t_star: HEADLINE_T_STAR,
        linf_error: linf,
        l2_error: l2,
        errors: run
            .errors()
            .iter()
            .map(|e| ErrorEntry {
                t: e.t,
                t_star: e.t_star,
                linf: e.linf,
                l2: e.l2,
            })
            .collect(),
    };
    serde_json::to_string_pretty(&summary)
        .map_err(|e| Error::config("summary", "json", e.to_string()))
}

/// `profile.csv`: `t,y,vx,vx_exact`, one row per fluid particle per output time.
pub fn profile_csv(run: &CouetteRun) -> String {
    let exact = run.exact();
    let mut s = String::from("t,y,vx,vx_exact\n");
    for p in &run.profiles {
        for (y, vx) in p.y.iter().zip(&p.vx) {
            let _ = writeln!(s, "{},{:e},{:e},{:e}", p.t, y, vx, exact.velocity(*y, p.t));
        }
    }
    s
}

/// The table printed at the end of a run.
pub fn error_table(run: &CouetteRun) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:>10}  {:>8}  {:>12}  {:>12}",
        "t [s]", "t*", "Linf / U", "L2 / U"
    );
    for e in run.errors() {
        let mark = if e.t_star >= HEADLINE_T_STAR {
            ""
        } else {
            "  (start-up)"
        };
        let _ = writeln!(
            s,
            "{:>10.4}  {:>8.4}  {:>12.3e}  {:>12.3e}{mark}",
            e.t, e.t_star, e.linf, e.l2
        );
    }
    s
}

/// A `.vtu` (VTK XML UnstructuredGrid, ASCII, one vertex cell per particle)
/// file with the particles of `snap`; ParaView, VisIt and meshio read it.
pub fn vtu(snap: &Snapshot) -> String {
    let n = snap.x.len();
    let mut s = String::new();
    let _ = writeln!(s, "<?xml version=\"1.0\"?>");
    let _ = writeln!(
        s,
        "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">"
    );
    let _ = writeln!(s, "<UnstructuredGrid>");
    let _ = writeln!(s, "<Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\">");
    let _ = writeln!(s, "<PointData Vectors=\"velocity\" Scalars=\"density\">");
    let _ = writeln!(
        s,
        "<DataArray type=\"Float64\" Name=\"velocity\" NumberOfComponents=\"3\" format=\"ascii\">"
    );
    for v in &snap.v {
        let _ = writeln!(s, "{:e} {:e} 0", v[0], v[1]);
    }
    let _ = writeln!(s, "</DataArray>");
    for (name, values) in [("density", &snap.rho), ("pressure", &snap.p)] {
        let _ = writeln!(
            s,
            "<DataArray type=\"Float64\" Name=\"{name}\" format=\"ascii\">"
        );
        for x in values {
            let _ = writeln!(s, "{x:e}");
        }
        let _ = writeln!(s, "</DataArray>");
    }
    let _ = writeln!(s, "</PointData>");
    let _ = writeln!(s, "<Points>");
    let _ = writeln!(
        s,
        "<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">"
    );
    for x in &snap.x {
        let _ = writeln!(s, "{:e} {:e} 0", x[0], x[1]);
    }
    let _ = writeln!(s, "</DataArray>");
    let _ = writeln!(s, "</Points>");
    let _ = writeln!(s, "<Cells>");
    let _ = writeln!(
        s,
        "<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">"
    );
    for i in 0..n {
        let _ = writeln!(s, "{i}");
    }
    let _ = writeln!(s, "</DataArray>");
    let _ = writeln!(
        s,
        "<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">"
    );
    for i in 1..=n {
        let _ = writeln!(s, "{i}");
    }
    let _ = writeln!(s, "</DataArray>");
    let _ = writeln!(
        s,
        "<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">"
    );
    for _ in 0..n {
        let _ = writeln!(s, "1");
    }
    let _ = writeln!(s, "</DataArray>");
    let _ = writeln!(s, "</Cells>");
    let _ = writeln!(s, "</Piece>");
    let _ = writeln!(s, "</UnstructuredGrid>");
    let _ = writeln!(s, "</VTKFile>");
    s
}

/// A `.pvd` collection listing `(time, file)` pairs, so ParaView plays them in order.
pub fn pvd(entries: &[(f64, String)]) -> String {
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n<Collection>\n",
    );
    for (t, file) in entries {
        let _ = writeln!(
            s,
            "<DataSet timestep=\"{t}\" group=\"\" part=\"0\" file=\"{file}\"/>"
        );
    }
    s.push_str("</Collection>\n</VTKFile>\n");
    s
}

/// Writes every output of a Couette run into `dir`; returns the paths written.
///
/// # Errors
/// [`Error::Io`] naming the file that could not be written.
pub fn write_couette(run: &CouetteRun, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    let mut put = |name: &str, bytes: &[u8]| -> Result<()> {
        let path = dir.join(name);
        write_atomic(&path, bytes)?;
        written.push(path);
        Ok(())
    };
    put("profile.csv", profile_csv(run).as_bytes())?;
    put("summary.json", summary_json(run)?.as_bytes())?;
    put("config.toml", run.config.to_toml()?.as_bytes())?;
    put("profiles.png", &crate::plot::profiles_png(run)?)?;
    if run.config.vtk {
        let mut entries = Vec::new();
        for (k, snap) in run.snapshots.iter().enumerate() {
            let name = format!("particles_{k:04}.vtu");
            put(&name, vtu(snap).as_bytes())?;
            entries.push((snap.t, name));
        }
        put("particles.pvd", pvd(&entries).as_bytes())?;
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_whole_files_and_leaves_no_temporaries() {
        let dir = std::env::temp_dir().join(format!("sph-atomic-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.txt");
        write_atomic(&path, b"first").unwrap();
        write_atomic(&path, b"second").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second");
        let names: Vec<_> = fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
        // A path in a missing directory is an error naming it, and leaves nothing.
        let bad = dir.join("missing").join("b.txt");
        let e = write_atomic(&bad, b"x").unwrap_err().to_string();
        assert!(e.contains("missing"), "{e}");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn vtu_is_well_formed_and_carries_every_particle() {
        let snap = Snapshot {
            t: 0.5,
            x: vec![[0.0, 1.0], [2.0, 3.0]],
            v: vec![[1.0, 0.0], [0.5, 0.0]],
            rho: vec![1.0, 1.0],
            p: vec![0.0, 0.1],
        };
        let s = vtu(&snap);
        assert!(s.contains("NumberOfPoints=\"2\""));
        assert_eq!(
            s.matches("<DataArray").count(),
            s.matches("</DataArray>").count()
        );
        assert_eq!(s.matches("<DataArray").count(), 7);
        assert!(s.contains("2e0 3e0 0"));
        assert!(pvd(&[(0.5, "p.vtu".into())]).contains("timestep=\"0.5\""));
    }
}
