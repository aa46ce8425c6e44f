//! Outputs of any scene's run, from its [`RunRecord`]: `summary.json`,
//! `particles.csv`, `config.toml`, `diagnostics.png` and (optionally) VTK
//! snapshots. A new case gets all of them without code of its own.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::cases::{Reference, Settings};
use crate::couette::Snapshot;
use crate::error::{Error, Result};
use crate::output::{pvd, pvtu, vtu, vtu_with_ids, write_atomic, VtkEncoding};
use crate::plot::{line_plot, Axes, Series};
use crate::scene::{
    energy_drift, Diagnostics, EnergyDrift, Monitor, Physics, RunRecord, VectorField,
};

#[derive(Serialize)]
struct Summary<'a> {
    case: &'a str,
    complete: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    reason: Option<&'a str>,
    steady: bool,
    dim: usize,
    velocity_scale: f64,
    length_scale: f64,
    dx: f64,
    h: f64,
    n_fluid: usize,
    rho0: f64,
    nu: f64,
    reynolds: f64,
    body_force: [f64; 3],
    settings: Option<&'a Settings>,
    physics: &'a Physics,
    monitor: &'a Monitor,
    limits: Limits,
    dt: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    dt_range: Option<[f64; 2]>,
    steps: u64,
    threads: usize,
    ranks: usize,
    #[serde(skip_serializing_if = "<[_]>::is_empty")]
    ranks_detail: &'a [crate::distributed::RankStats],
    wall_seconds: f64,
    storage_bytes: usize,
    outputs: &'a [Diagnostics],
    #[serde(skip_serializing_if = "Option::is_none")]
    energy_drift: Option<EnergyDrift>,
    #[serde(skip_serializing_if = "Option::is_none")]
    reference: Option<&'a Reference>,
    #[serde(flatten)]
    provenance: crate::provenance::Provenance,
}

#[derive(Serialize)]
struct Limits {
    cfl: f64,
    viscous: f64,
    force: f64,
}

/// `summary.json` of a run (with the settings it ran with, where known).
///
/// # Errors
/// Never for finite numbers; reported rather than assumed.
pub fn summary_json(
    record: &RunRecord,
    settings: Option<&Settings>,
    reference: Option<&Reference>,
) -> Result<String> {
    let finite = |x: f64| if x.is_finite() { x } else { f64::MAX };
    let summary = Summary {
        case: &record.case,
        complete: record.complete(),
        reason: record.stop.as_ref().map(|s| s.reason.as_str()),
        steady: record.steady,
        dim: record.dim,
        velocity_scale: record.velocity_scale,
        length_scale: record.length_scale,
        dx: record.dx,
        h: record.h,
        n_fluid: record.n_fluid,
        rho0: record.rho0,
        nu: record.nu,
        reynolds: record.velocity_scale * record.length_scale / record.nu,
        body_force: record.body_force,
        settings,
        physics: &record.physics,
        monitor: &record.monitor,
        limits: Limits {
            cfl: finite(record.limits[0]),
            viscous: finite(record.limits[1]),
            force: finite(record.limits[2]),
        },
        dt: record.dt,
        dt_range: record.dt_range,
        steps: record.steps,
        threads: record.threads,
        ranks: record.ranks,
        ranks_detail: &record.rank_stats,
        wall_seconds: record.wall_seconds,
        storage_bytes: record.storage_bytes,
        outputs: &record.outputs,
        energy_drift: energy_drift(&record.outputs, record.physics.gravity_ramp),
        reference,
        provenance: crate::provenance::now(),
    };
    let mut value = serde_json::to_value(&summary)
        .map_err(|e| Error::config("summary", "json", e.to_string()))?;
    if let Some(map) = value.as_object_mut() {
        for (key, extra) in &record.summary {
            map.insert(key.clone(), extra.clone());
        }
    }
    // JSON has no infinity: a spacing with no pair in reach is written as null.
    if let Some(outputs) = value.get_mut("outputs").and_then(|o| o.as_array_mut()) {
        for (o, d) in outputs.iter_mut().zip(&record.outputs) {
            if !d.min_spacing.is_finite() {
                o["min_spacing"] = serde_json::Value::Null;
            }
        }
    }
    serde_json::to_string_pretty(&value)
        .map_err(|e| Error::config("summary", "json", e.to_string()))
}

/// `particles.csv`: every fluid particle at every output time, global
/// coordinates, `id` the index at creation, rows sorted by t then id.
pub fn particles_csv(record: &RunRecord) -> String {
    let mut s = String::new();
    let three = record.dim == 3;
    s.push_str(if three {
        "t,id,x,y,z,vx,vy,vz,rho,p\n"
    } else {
        "t,id,x,y,vx,vy,rho,p\n"
    });
    for f in &record.frames {
        for (id, ((x, v), (rho, p))) in f.x.iter().zip(&f.v).zip(f.rho.iter().zip(&f.p)).enumerate()
        {
            if three {
                let _ = writeln!(
                    s,
                    "{},{id},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e}",
                    f.t, x[0], x[1], x[2], v[0], v[1], v[2], rho, p
                );
            } else {
                let _ = writeln!(
                    s,
                    "{},{id},{:e},{:e},{:e},{:e},{:e},{:e}",
                    f.t, x[0], x[1], v[0], v[1], rho, p
                );
            }
        }
    }
    s
}

/// `diagnostics.png`: kinetic energy (and its exact value), the error
/// norms where an exact solution exists, and the closest pair, against time.
///
/// # Errors
/// If drawing fails.
pub fn diagnostics_png(record: &RunRecord) -> Result<Vec<u8>> {
    let o = &record.outputs;
    // The first output with motion: a flow started from rest (dam-break,
    // whose first output is t = 0) has none at its first.
    let e0 = o
        .iter()
        .map(|d| d.kinetic_energy_exact.unwrap_or(d.kinetic_energy))
        .find(|&e| e > 0.0 && e.is_finite())
        .unwrap_or(1.0);
    let mut series = vec![Series {
        label: "kinetic energy / E(first output in motion)".into(),
        points: o.iter().map(|d| (d.t, d.kinetic_energy / e0)).collect(),
        color: 0,
        line: true,
        markers: false,
    }];
    if o.iter().any(|d| d.kinetic_energy_exact.is_some()) {
        series.push(Series {
            label: "exact kinetic energy".into(),
            points: o
                .iter()
                .filter_map(|d| d.kinetic_energy_exact.map(|k| (d.t, k / e0)))
                .collect(),
            color: 1,
            line: false,
            markers: true,
        });
    }
    if o.iter().any(|d| d.linf.is_some()) {
        series.push(Series {
            label: "Linf velocity error".into(),
            points: o.iter().filter_map(|d| d.linf.map(|e| (d.t, e))).collect(),
            color: 2,
            line: true,
            markers: true,
        });
    }
    series.push(Series {
        label: "closest pair / dx".into(),
        points: o
            .iter()
            .filter(|d| d.min_spacing.is_finite())
            .map(|d| (d.t, d.min_spacing))
            .collect(),
        color: 3,
        line: true,
        markers: false,
    });
    line_plot(
        &Axes {
            title: format!("{}: diagnostics at the output times", record.case),
            x: "t [s]".into(),
            y: "value".into(),
            log_x: false,
            log_y: true,
        },
        &series,
    )
}

/// `energy.png` (runs with an energy budget): kinetic, internal and
/// dissipated energy, the change of the potential energy and of the sum
/// since the first output, each over the budget's energy scale
/// ([`crate::scene::EnergyDrift::energy_scale`], or the largest term
/// without one), against time, on linear axes; `None` without a budget.
///
/// # Errors
/// If drawing fails.
pub fn energy_png(record: &RunRecord) -> Result<Option<Vec<u8>>> {
    let budget: Vec<(f64, crate::scene::Energy)> = record
        .outputs
        .iter()
        .filter_map(|d| d.energy.map(|e| (d.t, e)))
        .collect();
    let Some(&(_, first)) = budget.first() else {
        return Ok(None);
    };
    let scale = energy_drift(&record.outputs, record.physics.gravity_ramp)
        .map(|d| d.energy_scale)
        .filter(|s| *s > 0.0)
        .unwrap_or_else(|| {
            budget
                .iter()
                .map(|(_, e)| e.potential_energy.abs() + e.kinetic_energy + e.internal_energy.abs())
                .fold(f64::MIN_POSITIVE, f64::max)
        });
    type Pick = fn(&crate::scene::Energy, &crate::scene::Energy) -> f64;
    let parts: [(&str, Pick); 5] = [
        ("kinetic", |e, _| e.kinetic_energy),
        ("potential - potential(first)", |e, f| {
            e.potential_energy - f.potential_energy
        }),
        ("internal", |e, _| e.internal_energy),
        ("dissipated", |e, _| e.dissipated_energy),
        ("sum - sum(first)", |e, f| e.total_energy - f.total_energy),
    ];
    let series: Vec<Series> = parts
        .iter()
        .enumerate()
        .map(|(k, (label, pick))| Series {
            label: (*label).into(),
            points: budget
                .iter()
                .map(|(t, e)| (*t, pick(e, &first) / scale))
                .collect(),
            color: k,
            line: true,
            markers: k == 4,
        })
        .collect();
    line_plot(
        &Axes {
            title: format!("{}: energy budget / {scale:.4e} J", record.case),
            x: "t [s]".into(),
            y: "energy / scale".into(),
            log_x: false,
            log_y: false,
        },
        &series,
    )
    .map(Some)
}

/// The VTK snapshots a run writes: their encoding and, where the scene has
/// an exact solution, what the `velocity_exact` and `error` arrays need.
#[derive(Clone, Copy)]
pub struct Vtk<'a> {
    /// Binary (default) or ASCII.
    pub encoding: VtkEncoding,
    /// The scene's exact velocity field, if any.
    pub exact: Option<&'a VectorField>,
    /// Errors are relative to `velocity_scale * exp(error_decay * t)`.
    pub error_decay: f64,
}

/// Writes every output of a run into `dir` (`case.png` when the case has a
/// figure, the comparison with reference data in summary.json when it has
/// one; VTK snapshots with `vtk`, in 2D and 3D); returns the paths written.
///
/// # Errors
/// [`Error::Io`] naming the file that could not be written.
pub fn write_record(
    record: &RunRecord,
    settings: Option<&Settings>,
    figure: Option<Vec<u8>>,
    reference: Option<&Reference>,
    dir: &Path,
    vtk: Option<Vtk<'_>>,
) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    let mut put = |name: &str, bytes: &[u8]| -> Result<()> {
        let path = dir.join(name);
        write_atomic(&path, bytes)?;
        written.push(path);
        Ok(())
    };
    put(
        "summary.json",
        summary_json(record, settings, reference)?.as_bytes(),
    )?;
    put("particles.csv", particles_csv(record).as_bytes())?;
    if let Some(s) = settings {
        put("config.toml", s.to_toml()?.as_bytes())?;
    }
    put("diagnostics.png", &diagnostics_png(record)?)?;
    if let Some(png) = energy_png(record)? {
        put("energy.png", &png)?;
    }
    if let Some(png) = figure {
        put("case.png", &png)?;
    }
    if let Some(vtk) = vtk {
        let mut entries = Vec::new();
        for (k, f) in record.frames.iter().enumerate() {
            let snap = Snapshot {
                t: f.t,
                x: f.x.clone(),
                v: f.v.clone(),
                rho: f.rho.clone(),
                p: f.p.clone(),
                v_exact: vtk
                    .exact
                    .map(|field| f.x.iter().map(|x| field(*x, f.t)).collect()),
                error_scale: record.velocity_scale * (vtk.error_decay * f.t).exp(),
            };
            match record.frame_owners.get(k).filter(|o| !o.is_empty()) {
                // On several ranks: one piece per rank, joined by a .pvtu.
                Some(owners) => {
                    let ranks = owners.iter().map(|&r| r as usize + 1).max().unwrap_or(0);
                    let mut pieces = Vec::new();
                    for r in 0..ranks {
                        let mine: Vec<usize> = (0..owners.len())
                            .filter(|&i| owners[i] as usize == r)
                            .collect();
                        let pick = |v: &[[f64; 3]]| mine.iter().map(|&i| v[i]).collect::<Vec<_>>();
                        let piece = Snapshot {
                            t: snap.t,
                            x: pick(&snap.x),
                            v: pick(&snap.v),
                            rho: mine.iter().map(|&i| snap.rho[i]).collect(),
                            p: mine.iter().map(|&i| snap.p[i]).collect(),
                            v_exact: snap.v_exact.as_deref().map(pick),
                            error_scale: snap.error_scale,
                        };
                        let ids: Vec<i64> = mine.iter().map(|&i| i as i64).collect();
                        let name = format!("particles_{k:04}_{r}.vtu");
                        put(&name, vtu_with_ids(&piece, &ids, vtk.encoding).as_bytes())?;
                        pieces.push(name);
                    }
                    let name = format!("particles_{k:04}.pvtu");
                    put(&name, pvtu(&pieces, snap.v_exact.is_some()).as_bytes())?;
                    entries.push((f.t, name));
                }
                None => {
                    let name = format!("particles_{k:04}.vtu");
                    put(&name, vtu(&snap, vtk.encoding).as_bytes())?;
                    entries.push((f.t, name));
                }
            }
        }
        put("particles.pvd", pvd(&entries).as_bytes())?;
    }
    Ok(written)
}
