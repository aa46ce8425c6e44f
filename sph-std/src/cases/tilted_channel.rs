//! `tilted-channel`: plane Poiseuille flow between walls at `atan(4/7)`
//! (29.7 degrees) to the box axes, on a lattice aligned with the box: the
//! test that the shaped walls (`sph_core::shape`) do not depend on the
//! lattice.
//!
//! The box is `7a x 4a` with `a = m dx`, periodic both ways. The channel's
//! walls run along `t = (7, 4)/sqrt(65)`; across the box's periods they
//! repeat every `P = 28 a / sqrt(65)` along the normal, so the box holds a
//! family of channels of width `H = 2P/3` separated by solid strips of
//! `P/3` (one [`Shape::Channel`] with that period). `resolution` sets `m`
//! so that about that many particles span `H`. The physics is the
//! `poiseuille` case's: `H = 1 mm` (nominal), `nu = 1e-6 m^2/s`,
//! `u_max = 1.25e-5 m/s`, a body force `F = 8 nu u_max / H^2` along `t`,
//! the consistent operators, and the ghosts continue the parabola with the
//! curvature `-F / nu` (as the aligned case's walls do). Lattice points
//! less than `dx/2` from a wall are left out.

use std::sync::Arc;

use sph_core::analytic::Poiseuille;
use sph_core::prelude::{Shape, ShapedWall};

use super::{Case, Settings};
use crate::error::Result;
use crate::scene::{AxisSpec, Region, RunRecord, Scene};

/// The case's table entry.
pub const CASE: Case = Case {
    name: "tilted-channel",
    about: "plane Poiseuille flow between walls at atan(4/7) to the box axes, lattice aligned with the box, against the exact series (Re 0.0125)",
    defaults,
    build,
    figure,
    reference: super::no_reference,
};

const GAP: f64 = 1e-3;
const U_MAX: f64 = 1.25e-5;
const RHO0: f64 = 1000.0;

fn defaults() -> Settings {
    Settings::base("tilted-channel", 20, 2.0, 0.1, U_MAX * GAP / 1e-6).consistent()
}

/// The geometry for `resolution`: `(m, dx, H, P)`.
pub fn geometry(resolution: usize) -> (usize, f64, f64, f64) {
    let root = 65f64.sqrt();
    // H / dx = 56 m / (3 sqrt 65) ~ 2.315 m.
    let m = ((resolution as f64) * 3.0 * root / 56.0).round().max(4.0) as usize;
    let dx = 3.0 * GAP * root / (56.0 * m as f64);
    let p = 28.0 * m as f64 * dx / root;
    (m, dx, 2.0 * p / 3.0, p)
}

fn build(s: &Settings) -> Result<Scene> {
    super::only_2d(s)?;
    let (m, dx, h, period) = geometry(s.resolution);
    let root = 65f64.sqrt();
    let t = [7.0 / root, 4.0 / root, 0.0];
    let n = [-4.0 / root, 7.0 / root, 0.0];
    let nu = U_MAX * GAP / s.re;
    let force = 8.0 * nu * U_MAX / (h * h);
    let exact = Poiseuille::new(0.0, h, force, nu)?;
    let a = m as f64 * dx;
    let (lx, ly) = (7.0 * a, 4.0 * a);
    // The first wall through a point off the lattice's symmetry lines.
    let point = [0.25 * dx, 0.0, 0.0];
    let wall = ShapedWall::new(Shape::Channel {
        point,
        normal: n,
        width: h,
        period,
    })
    .with_curvature([-force * t[0] / nu, -force * t[1] / nu, 0.0]);
    let velocity = move |x: [f64; 3], time: f64| {
        let mut s = (x[0] - point[0]) * n[0] + (x[1] - point[1]) * n[1];
        s -= period * (s / period).floor();
        if s < h {
            let u = exact.velocity(s, time);
            [u * t[0], u * t[1], 0.0]
        } else {
            [0.0; 3]
        }
    };
    Ok(Scene {
        case: s.case.clone(),
        dim: 2,
        origin: [0.0; 3],
        extent: [lx, ly, 0.0],
        axes: [AxisSpec::Periodic, AxisSpec::Periodic, AxisSpec::Periodic],
        dx,
        regions: vec![Region {
            lo: [0.0; 3],
            hi: [lx, ly, 0.0],
        }],
        shaped_walls: vec![wall],
        initial: None,
        summary: vec![
            (
                "angle_degrees".into(),
                (4f64 / 7.0).atan().to_degrees().into(),
            ),
            ("channel_width".into(), h.into()),
            ("period".into(), period.into()),
            ("particles_across".into(), (h / dx).into()),
        ],
        velocity: None,
        pressure: None,
        body_force: [force * t[0], force * t[1], 0.0],
        rho0: RHO0,
        nu,
        physics: s.physics(U_MAX, RHO0),
        output_times: s.output_times(),
        velocity_scale: U_MAX,
        length_scale: h,
        exact: Some(Arc::new(velocity)),
        error_decay: 0.0,
        monitor: s.monitor(),
        steady_tolerance: None,
        threads: s.threads,
        keep_particles: true,
        allow_long_run: false,
    })
}

/// The particles at the last output, coloured by speed.
fn figure(scene: &Scene, record: &RunRecord) -> Result<Vec<u8>> {
    super::custom::speed_figure(scene, record, "Tilted channel")
}
