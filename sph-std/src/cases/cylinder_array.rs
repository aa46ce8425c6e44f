//! `cylinder-array`: Stokes flow through a square periodic array of
//! cylinders driven by a body force (Morris, Fox & Zhu 1997), against the
//! drag Sangani & Acrivos (1982) computed for that array.
//!
//! A unit cell `L = 1`, periodic both ways, one cylinder of radius
//! `a = L sqrt(phi / pi)` at its centre (a [`Shape::Ball`] wall, fluid
//! outside), `nu = 1`, `rho0 = 1`, a body force `g` along x chosen so that
//! the superficial velocity from the reference drag is `U = Re nu / L`
//! (Re 0.1 by default: the Stokes regime), the consistent operators. The
//! sound speed follows Morris, Fox & Zhu (1997): `c0` is
//! `sound_speed_factor` times the largest of `U`, `sqrt(nu U / L)` and
//! `sqrt(g L)`, so that the pressure the body force builds around the
//! cylinder (of order `rho g L`, far above `rho U^2` in Stokes flow) stays a
//! small fraction of `rho c0^2`. Particle shifting keeps the arrangement
//! regular as particles pass the cylinder. Particles on the cell's
//! lattice, those closer than `dx/2` to the cylinder left out;
//! `resolution` counts particles across `L`.
//!
//! The reference: Sangani & Acrivos (1982), "Slow flow past periodic
//! arrays of cylinders with application to heat transfer", Int. J.
//! Multiphase Flow 8: 193-206, Table 1 (square array): the drag per unit
//! length over `mu U`, `K = F / (mu U)`, for solid fractions 0.05 to 0.75.
//! Here `F = rho g L^2`, the force per cell (with a mean pressure gradient
//! `G = rho g` driving the flow instead, `G L^2` is the whole force on the
//! cylinder), and `U` the superficial velocity, the volume flux per unit
//! cell area: the fluid area `(1 - phi) L^2` times the particles' mean
//! `u_x` (every particle carries the same volume). Basilisk's test of the same table
//! (`src/test/cylinders.c`) uses the same definitions. Fractions between
//! the tabulated ones are interpolated linearly in `ln K`.

use sph_core::prelude::{Shape, ShapedWall};

use super::{Case, Reference, ReferencePoint, Settings};
use crate::config::check;
use crate::error::Result;
use crate::scene::{AxisSpec, Region, RunRecord, Scene};

/// The case's table entry.
pub const CASE: Case = Case {
    name: "cylinder-array",
    about: "Stokes flow through a square periodic array of cylinders (solid fraction 0.1 by default), drag against Sangani & Acrivos (1982)",
    defaults,
    build,
    figure,
    reference,
};

/// Sangani & Acrivos (1982), Table 1, square array: `(phi, F / (mu U))`.
pub const SANGANI_ACRIVOS: [(f64, f64); 9] = [
    (0.05, 15.56),
    (0.10, 24.83),
    (0.20, 51.53),
    (0.30, 102.90),
    (0.40, 217.89),
    (0.50, 532.55),
    (0.60, 1.763e3),
    (0.70, 1.352e4),
    (0.75, 1.263e5),
];

/// The reference drag `K = F / (mu U)` at solid fraction `phi` (in the
/// table's range; linear in `ln K` between its rows).
pub fn drag(phi: f64) -> Option<f64> {
    let t = &SANGANI_ACRIVOS;
    if !(phi >= t[0].0 && phi <= t[t.len() - 1].0) {
        return None;
    }
    for w in t.windows(2) {
        let ((p0, k0), (p1, k1)) = (w[0], w[1]);
        if phi == p0 {
            return Some(k0);
        }
        if phi == p1 {
            return Some(k1);
        }
        if phi < p1 {
            let s = (phi - p0) / (p1 - p0);
            return Some(libm::exp(libm::log(k0) * (1.0 - s) + libm::log(k1) * s));
        }
    }
    None
}

fn defaults() -> Settings {
    // Without shifting the flow around the cylinder disorders the lattice
    // (closest pair 0.58 dx at t = 1, 40 across) and runs at 60 and 80
    // across stop on the density monitor near t = 0.27.
    let mut s = Settings::base("cylinder-array", 40, 1.0, 0.1, 0.1).consistent();
    s.regularise = crate::scene::Regularise::Shifting;
    s.solid_fraction = Some(0.1);
    s
}

fn build(s: &Settings) -> Result<Scene> {
    super::only_2d(s)?;
    let phi = s.solid_fraction.unwrap_or(0.1);
    check(
        (0.05..=0.5).contains(&phi),
        "solid_fraction",
        phi,
        "must be between 0.05 and 0.5 (the reference table's range where the gap holds a few particles)",
    )?;
    let k = drag(phi).unwrap_or(f64::NAN);
    let l = 1.0;
    let nu = 1.0;
    let rho0 = 1.0;
    let u = s.re * nu / l;
    let g = k * nu * u / (l * l);
    let dx = l / s.resolution as f64;
    let radius = l * (phi / std::f64::consts::PI).sqrt();
    let center = [0.5 * l, 0.5 * l, 0.0];
    let cylinder = ShapedWall::new(Shape::Ball {
        center,
        radius,
        fluid_inside: false,
    });
    Ok(Scene {
        case: s.case.clone(),
        dim: 2,
        origin: [0.0; 3],
        extent: [l, l, 0.0],
        axes: [AxisSpec::Periodic, AxisSpec::Periodic, AxisSpec::Periodic],
        dx,
        regions: vec![Region {
            lo: [0.0; 3],
            hi: [l, l, 0.0],
        }],
        shaped_walls: vec![cylinder],
        initial: None,
        summary: vec![
            ("solid_fraction".into(), phi.into()),
            ("radius".into(), radius.into()),
            ("center".into(), serde_json::json!([center[0], center[1]])),
            ("cell".into(), l.into()),
        ],
        velocity: None,
        pressure: None,
        body_force: [g, 0.0, 0.0],
        rho0,
        nu,
        // Morris, Fox & Zhu (1997), eq. 27: the sound speed from the
        // largest of the flow's three velocity scales.
        physics: s.physics(u.max((nu * u / l).sqrt()).max((g * l).sqrt()), rho0),
        output_times: s.output_times(),
        velocity_scale: u,
        length_scale: l,
        exact: None,
        error_decay: 0.0,
        monitor: s.monitor(),
        steady_tolerance: None,
        threads: s.threads,
        keep_particles: true,
        allow_long_run: false,
    })
}

/// The drag `F / (mu U)` of a run's last output: `F = rho g L^2` and the
/// superficial velocity `U = (1 - phi) mean_i(u_x)`.
pub fn measured_drag(record: &RunRecord) -> Option<f64> {
    let phi = solid_fraction(record)?;
    let frame = record.frames.last()?;
    let l = record.length_scale;
    let mean = frame.v.iter().map(|v| v[0]).sum::<f64>() / frame.v.len() as f64;
    let u = (1.0 - phi) * mean;
    let f = record.rho0 * record.body_force[0] * l * l;
    (u > 0.0).then(|| f / (record.rho0 * record.nu * u))
}

/// The solid fraction a run recorded in its summary.
fn solid_fraction(record: &RunRecord) -> Option<f64> {
    record
        .summary
        .iter()
        .find(|(k, _)| k == "solid_fraction")
        .and_then(|(_, v)| v.as_f64())
}

fn reference(record: &RunRecord) -> Option<Reference> {
    let phi = solid_fraction(record)?;
    let k = drag(phi)?;
    let sph = measured_drag(record)?;
    Some(Reference {
        source:
            "Sangani & Acrivos 1982, Int. J. Multiphase Flow 8: 193-206, Table 1 (square array)"
                .into(),
        t: record.frames.last()?.t,
        max_deviation: (sph - k).abs() / k,
        points: vec![ReferencePoint {
            quantity: "F/(mu U)",
            at: phi,
            reference: k,
            sph,
        }],
    })
}

/// The particles at the last output, coloured by speed.
fn figure(scene: &Scene, record: &RunRecord) -> Result<Vec<u8>> {
    super::custom::speed_figure(scene, record, "Cylinder array")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_is_interpolated_in_log_k_and_exact_at_its_rows() {
        assert_eq!(drag(0.1), Some(24.83));
        assert_eq!(drag(0.2), Some(51.53));
        let mid = drag(0.15).unwrap();
        assert!((mid - (24.83f64 * 51.53).sqrt()).abs() < 1e-9);
        assert_eq!(drag(0.01), None);
        // The dilute limit of the square array (Sangani & Acrivos eq. for
        // small phi): 4 pi / (-ln(phi)/2 - 0.738 + phi - 0.887 phi^2).
        let p: f64 = 0.05;
        let dilute = 4.0 * std::f64::consts::PI / (-0.5 * libm::log(p) - 0.738 + p - 0.887 * p * p);
        assert!((dilute - drag(0.05).unwrap()).abs() < 0.02 * dilute);
    }
}
