//! Output files and output sets. A run writes its whole set into a staging
//! directory and publishes it in one rename ([`in_dir`]): never a mix of two
//! runs' files, never a partial set, never temporary files left behind.
//! Single files are also written atomically ([`write_atomic`]).

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

/// The file sph writes into every output directory it publishes: a
/// directory holding it may be replaced by a new run; any other non-empty
/// directory only with `overwrite`.
pub const MARKER: &str = ".sph-output";

/// Refuses an output directory sph must not replace: the file-system root,
/// the home directory itself, a file, or (without `overwrite`) a non-empty
/// directory that sph did not write.
///
/// # Errors
/// [`Error::Config`] naming `out`, its value and the rule.
pub fn check_out_dir(dir: &Path, overwrite: bool) -> Result<()> {
    let shown = dir.display().to_string();
    if dir.as_os_str().is_empty() {
        return Err(Error::config("out", "\"\"", "must name a directory"));
    }
    let resolved = fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    let home = std::env::var_os("HOME").map(PathBuf::from);
    let home = home.map(|h| fs::canonicalize(&h).unwrap_or(h));
    if resolved.parent().is_none() || home.as_deref() == Some(resolved.as_path()) {
        return Err(Error::config(
            "out",
            shown,
            "must not be the file-system root or the home directory itself (a run replaces its output directory)",
        ));
    }
    if dir.exists() && !dir.is_dir() {
        return Err(Error::config("out", shown, "exists and is not a directory"));
    }
    if dir.is_dir() && !overwrite && !dir.join(MARKER).exists() {
        let empty = fs::read_dir(dir)
            .map_err(|e| Error::io("read output directory", dir, e))?
            .next()
            .is_none();
        if !empty {
            return Err(Error::config(
                "out",
                shown,
                "is a non-empty directory that sph did not write; choose another or pass --overwrite to replace it",
            ));
        }
    }
    Ok(())
}

/// Runs `work` on a staging directory beside `dir` and publishes what it
/// wrote as `dir` in one rename once it succeeds: an output set is a unit.
///
/// - `work` succeeds: the staging directory (plus [`MARKER`]) replaces
///   `dir` as a whole; nothing of a previous set survives beside the new
///   one. A run that stops early (state monitor, SIGINT) succeeds here and
///   publishes what it computed, marked incomplete.
/// - `work` fails (bad input, divergence, an I/O error, a full disk): the
///   staging directory is removed and `dir` is left exactly as it was.
///
/// Staging directories of earlier processes that no longer run (killed
/// mid-write) are removed first.
///
/// # Errors
/// Those of [`check_out_dir`], [`Error::Io`] if the staging directory
/// cannot be created or published, and those of `work`.
pub fn in_dir<T>(dir: &Path, overwrite: bool, work: impl FnOnce(&Path) -> Result<T>) -> Result<T> {
    check_out_dir(dir, overwrite)?;
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".to_string());
    let parent = match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    fs::create_dir_all(&parent).map_err(|e| Error::io("create output directory", &parent, e))?;
    remove_stale(&parent, &name);
    let pid = std::process::id();
    let staging = parent.join(format!(".{name}.staging-{pid}"));
    let _ = fs::remove_dir_all(&staging);
    // The error names the directory the user asked for, not the staging one.
    fs::create_dir(&staging).map_err(|e| Error::io("create output directory", dir, e))?;
    let published = work(&staging).and_then(|value| {
        write_atomic(&staging.join(MARKER), b"written by sph\n")?;
        publish(&staging, dir, &parent.join(format!(".{name}.old-{pid}")))?;
        Ok(value)
    });
    if published.is_err() {
        let _ = fs::remove_dir_all(&staging);
    }
    published
}

/// Moves `staging` to `dir`, replacing a previous `dir` by way of `old`.
fn publish(staging: &Path, dir: &Path, old: &Path) -> Result<()> {
    if !dir.exists() {
        return fs::rename(staging, dir).map_err(|e| Error::io("publish output directory", dir, e));
    }
    let _ = fs::remove_dir_all(old);
    fs::rename(dir, old).map_err(|e| Error::io("replace output directory", dir, e))?;
    if let Err(e) = fs::rename(staging, dir) {
        // Put the previous set back.
        let _ = fs::rename(old, dir);
        return Err(Error::io("publish output directory", dir, e));
    }
    let _ = fs::remove_dir_all(old);
    Ok(())
}

/// Removes `.NAME.staging-PID` and `.NAME.old-PID` directories in `parent`
/// whose process no longer runs (where `/proc` tells).
fn remove_stale(parent: &Path, name: &str) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = fs::read_dir(parent) else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name().to_string_lossy().into_owned();
        let pid = [".staging-", ".old-"].iter().find_map(|tag| {
            file.strip_prefix(&format!(".{name}{tag}"))
                .and_then(|p| p.parse::<u32>().ok())
        });
        if let Some(pid) = pid {
            if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
                let _ = fs::remove_dir_all(entry.path());
            }
        }
    }
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
    complete: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    reason: Option<&'a str>,
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
    /// `null` when no output time has `t* >= headline_t_star`.
    linf_error: Option<f64>,
    l2_error: Option<f64>,
    errors: Vec<ErrorEntry>,
    #[serde(flatten)]
    provenance: crate::provenance::Provenance,
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
        complete: run.stop.is_none(),
        reason: run.stop.as_ref().map(|s| s.reason.as_str()),
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
        linf_error: run.has_headline().then_some(linf),
        l2_error: run.has_headline().then_some(l2),
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
        provenance: crate::provenance::now(),
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

/// How `.vtu` arrays are stored.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum VtkEncoding {
    /// Inline binary: each array base64-encoded with a `UInt64` byte-count
    /// header (VTK's `format="binary"`); about 4x smaller than ASCII and
    /// exact to the last bit.
    #[default]
    Binary,
    /// Human-readable text (shortest round-trip decimal).
    Ascii,
}

/// One array's values.
enum Values<'a> {
    F64(&'a [f64]),
    I64(&'a [i64]),
    U8(&'a [u8]),
}

impl Values<'_> {
    fn vtk_type(&self) -> &'static str {
        match self {
            Values::F64(_) => "Float64",
            Values::I64(_) => "Int64",
            Values::U8(_) => "UInt8",
        }
    }

    fn bytes(&self) -> Vec<u8> {
        match self {
            Values::F64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::I64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::U8(v) => v.to_vec(),
        }
    }

    fn ascii(&self, s: &mut String) {
        match self {
            Values::F64(v) => v.iter().for_each(|x| {
                let _ = write!(s, "{x:?} ");
            }),
            Values::I64(v) => v.iter().for_each(|x| {
                let _ = write!(s, "{x} ");
            }),
            Values::U8(v) => v.iter().for_each(|x| {
                let _ = write!(s, "{x} ");
            }),
        }
    }
}

/// Writes one `<DataArray>`.
fn data_array(
    s: &mut String,
    name: &str,
    components: usize,
    values: Values<'_>,
    encoding: VtkEncoding,
) {
    use base64::Engine as _;
    let format = match encoding {
        VtkEncoding::Binary => "binary",
        VtkEncoding::Ascii => "ascii",
    };
    let _ = write!(
        s,
        "<DataArray type=\"{}\" Name=\"{name}\" NumberOfComponents=\"{components}\" format=\"{format}\">",
        values.vtk_type()
    );
    match encoding {
        VtkEncoding::Binary => {
            let data = values.bytes();
            let mut block = (data.len() as u64).to_le_bytes().to_vec();
            block.extend_from_slice(&data);
            s.push_str(&base64::engine::general_purpose::STANDARD.encode(block));
        }
        VtkEncoding::Ascii => values.ascii(s),
    }
    s.push_str("</DataArray>\n");
}

/// A `.vtu` (VTK XML UnstructuredGrid, one vertex cell per particle) file
/// with the particles of `snap`: `id`, `velocity`, `density`, `pressure`,
/// and where an exact solution exists `velocity_exact` and `error`
/// (`|v - v_exact|` relative to the snapshot's error scale). ParaView,
/// VisIt and meshio read it.
pub fn vtu(snap: &Snapshot, encoding: VtkEncoding) -> String {
    let ids: Vec<i64> = (0..snap.x.len() as i64).collect();
    vtu_with_ids(snap, &ids, encoding)
}

/// A `.vtu` like [`vtu`] whose `id` array holds `ids` (a piece of a
/// parallel collection: the particles' ids in the whole run).
pub fn vtu_with_ids(snap: &Snapshot, ids: &[i64], encoding: VtkEncoding) -> String {
    let n = snap.x.len();
    let flat = |v: &[[f64; 3]]| v.iter().flatten().copied().collect::<Vec<f64>>();
    let mut s = String::new();
    s.push_str("<?xml version=\"1.0\"?>\n");
    s.push_str("<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n");
    s.push_str("<UnstructuredGrid>\n");
    let _ = writeln!(s, "<Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\">");
    s.push_str("<PointData Vectors=\"velocity\" Scalars=\"density\">\n");
    data_array(&mut s, "id", 1, Values::I64(ids), encoding);
    data_array(&mut s, "velocity", 3, Values::F64(&flat(&snap.v)), encoding);
    data_array(&mut s, "density", 1, Values::F64(&snap.rho), encoding);
    data_array(&mut s, "pressure", 1, Values::F64(&snap.p), encoding);
    if let Some(exact) = &snap.v_exact {
        data_array(
            &mut s,
            "velocity_exact",
            3,
            Values::F64(&flat(exact)),
            encoding,
        );
        let error: Vec<f64> = snap
            .v
            .iter()
            .zip(exact)
            .map(|(v, e)| {
                let d = [v[0] - e[0], v[1] - e[1], v[2] - e[2]];
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() / snap.error_scale
            })
            .collect();
        data_array(&mut s, "error", 1, Values::F64(&error), encoding);
    }
    s.push_str("</PointData>\n<Points>\n");
    data_array(&mut s, "position", 3, Values::F64(&flat(&snap.x)), encoding);
    s.push_str("</Points>\n<Cells>\n");
    let offsets: Vec<i64> = (1..=n as i64).collect();
    let connectivity: Vec<i64> = (0..n as i64).collect();
    data_array(
        &mut s,
        "connectivity",
        1,
        Values::I64(&connectivity),
        encoding,
    );
    data_array(&mut s, "offsets", 1, Values::I64(&offsets), encoding);
    data_array(&mut s, "types", 1, Values::U8(&vec![1u8; n]), encoding);
    s.push_str("</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
    s
}

/// A `.pvtu` (VTK XML parallel UnstructuredGrid) that joins the `.vtu`
/// pieces `pieces` (one per rank, written by [`vtu_with_ids`]) into one
/// data set; `exact` says whether they hold `velocity_exact` and `error`.
pub fn pvtu(pieces: &[String], exact: bool) -> String {
    let mut s = String::from("<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n<PUnstructuredGrid GhostLevel=\"0\">\n<PPointData Vectors=\"velocity\" Scalars=\"density\">\n");
    let mut array = |kind: &str, name: &str, components: usize| {
        let _ = writeln!(
            s,
            "<PDataArray type=\"{kind}\" Name=\"{name}\" NumberOfComponents=\"{components}\"/>"
        );
    };
    array("Int64", "id", 1);
    array("Float64", "velocity", 3);
    array("Float64", "density", 1);
    array("Float64", "pressure", 1);
    if exact {
        array("Float64", "velocity_exact", 3);
        array("Float64", "error", 1);
    }
    s.push_str("</PPointData>\n<PPoints>\n<PDataArray type=\"Float64\" Name=\"position\" NumberOfComponents=\"3\"/>\n</PPoints>\n");
    for piece in pieces {
        let _ = writeln!(s, "<Piece Source=\"{piece}\"/>");
    }
    s.push_str("</PUnstructuredGrid>\n</VTKFile>\n");
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
            put(&name, vtu(snap, run.config.vtk_encoding()).as_bytes())?;
            entries.push((snap.t, name));
        }
        put("particles.pvd", pvd(&entries).as_bytes())?;
    }
    if let Some(ck) = &run.checkpoint {
        put(crate::checkpoint::FILE, &ck.to_bytes())?;
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
    fn vtu_is_well_formed_and_binary_arrays_decode_to_the_same_bits() {
        use base64::Engine as _;
        let snap = Snapshot {
            t: 0.5,
            x: vec![[0.0, 1.0, 0.0], [2.0, 3.0, 0.0]],
            v: vec![[1.0, 0.0, 0.0], [0.1 + 0.2, 0.0, 0.0]],
            rho: vec![1.0, 1.0],
            p: vec![0.0, 0.1],
            v_exact: Some(vec![[1.0, 0.0, 0.0], [0.25, 0.0, 0.0]]),
            error_scale: 0.5,
        };
        for encoding in [VtkEncoding::Binary, VtkEncoding::Ascii] {
            let s = vtu(&snap, encoding);
            assert!(s.contains("NumberOfPoints=\"2\""));
            assert_eq!(
                s.matches("<DataArray").count(),
                s.matches("</DataArray>").count()
            );
            // id, velocity, density, pressure, velocity_exact, error,
            // positions, connectivity, offsets, types.
            assert_eq!(s.matches("<DataArray").count(), 10);
        }
        // ASCII writes round-trip decimals.
        assert!(vtu(&snap, VtkEncoding::Ascii).contains("0.30000000000000004 0.0 0.0"));
        // Binary: a UInt64 byte count, then the little-endian values.
        let s = vtu(&snap, VtkEncoding::Binary);
        let start = s.find("Name=\"error\"").unwrap();
        let body = &s[s[start..].find('>').unwrap() + start + 1..];
        let body = &body[..body.find('<').unwrap()];
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(body)
            .unwrap();
        assert_eq!(u64::from_le_bytes(bytes[..8].try_into().unwrap()), 16);
        let second = f64::from_le_bytes(bytes[16..24].try_into().unwrap());
        // |0.30000000000000004 - 0.25| / 0.5, to the bit.
        assert_eq!(second, ((0.1f64 + 0.2) - 0.25) / 0.5);
        assert!(pvd(&[(0.5, "p.vtu".into())]).contains("timestep=\"0.5\""));
    }
}
