//! Accuracy studies over many Couette runs: convergence in N and beta, and the
//! speed/accuracy trade (`sph convergence`, `sph pareto`).
//!
//! What to expect (physics.md section 7): at fixed beta, errors fall at second
//! order in dx only until they reach a floor set by the kernel sums on the
//! particle lattice and the `eta^2 = 0.01 h^2` regulariser; the floor depends
//! on kernel and beta, not on dx. So the order is measured on *differences*
//! of a signed error measure (Richardson), which removes the floor, and the
//! floor itself is extrapolated. The signed measure used here is the
//! effective viscosity fitted to the SPH profile, `nu_eff / nu - 1`: it exists
//! at every resolution (particle rows of different resolutions never
//! coincide), its sign says whether the operator is too weak or too strong,
//! and its floor is the operator's lattice bias.

use std::time::Instant;

use serde::Serialize;

use crate::config::{CouetteConfig, KernelName};
use crate::couette::{self, CouetteRun, Progress};
use crate::error::Result;

/// Output times of the studies: the transient, where the viscous operator is tested.
pub const STUDY_TIMES: [f64; 4] = [0.02, 0.05, 0.1, 0.25];

/// The time at which orders and floors are evaluated (`t* = 0.1`).
pub const ANALYSIS_TIME: f64 = 0.1;

/// Effective kinematic viscosity fitted to a profile: the `nu` for which the
/// exact series best matches the SPH velocities (least squares), by golden
/// section on `ln nu` within a factor 4 of the true value.
pub fn effective_viscosity(run: &CouetteRun, profile: usize) -> f64 {
    let p = &run.profiles[profile];
    let base = run.exact();
    let misfit = |ln_nu: f64| {
        let c = sph_core::analytic::Couette {
            nu: ln_nu.exp(),
            ..base
        };
        p.y.iter()
            .zip(&p.vx)
            .map(|(y, u)| (u - c.velocity(*y, p.t)).powi(2))
            .sum::<f64>()
    };
    let (mut a, mut b) = (base.nu.ln() - 4f64.ln(), base.nu.ln() + 4f64.ln());
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (misfit(c), misfit(d));
    for _ in 0..80 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = misfit(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = misfit(d);
        }
    }
    (0.5 * (a + b)).exp()
}

/// One row of `convergence.csv` (one run at one output time).
#[derive(Clone, Debug, Serialize)]
pub struct ConvergenceRow {
    /// `fixed_beta`, `fixed_n` or `joint`.
    pub sweep: &'static str,
    /// Kernel name.
    pub kernel: KernelName,
    /// Overlap factor.
    pub beta: f64,
    /// Regulariser (fraction of h^2).
    pub eta2: f64,
    /// Particles across the gap.
    pub particles_across: usize,
    /// Particle spacing.
    pub dx: f64,
    /// Smoothing length.
    pub h: f64,
    /// Output time in seconds.
    pub t: f64,
    /// L-infinity error / U.
    pub linf_error: f64,
    /// L2 error / U.
    pub l2_error: f64,
    /// `nu_eff / nu - 1` (see the module docs).
    pub signed_error: f64,
    /// Wall seconds of the run.
    pub wall_seconds: f64,
    /// Steps of the run.
    pub steps: u64,
}

/// Runs one study configuration and turns it into rows.
pub fn study_run(
    sweep: &'static str,
    cfg: &CouetteConfig,
    progress: &dyn Progress,
) -> Result<Vec<ConvergenceRow>> {
    let start = Instant::now();
    let run = couette::run(cfg, progress)?;
    let wall = start.elapsed().as_secs_f64();
    let errors = run.errors();
    Ok(errors
        .iter()
        .enumerate()
        .map(|(k, e)| ConvergenceRow {
            sweep,
            kernel: cfg.kernel,
            beta: cfg.beta,
            eta2: cfg.eta2,
            particles_across: cfg.particles_across,
            dx: run.geometry.dx,
            h: run.geometry.h,
            t: e.t,
            linf_error: e.linf,
            l2_error: e.l2,
            signed_error: effective_viscosity(&run, k) / cfg.nu - 1.0,
            wall_seconds: wall,
            steps: run.steps,
        })
        .collect())
}

/// The configuration of one study run.
pub fn study_config(
    kernel: KernelName,
    beta: f64,
    n: usize,
    eta2: f64,
    threads: usize,
) -> CouetteConfig {
    CouetteConfig {
        kernel,
        beta,
        particles_across: n,
        eta2,
        threads,
        t_end: *STUDY_TIMES.last().unwrap_or(&0.25),
        output_times: STUDY_TIMES.to_vec(),
        quiet: true,
        ..CouetteConfig::default()
    }
}

/// The kernels and the overlap each is usually run at (their fixed-beta sweeps).
pub const KERNELS: [(KernelName, f64); 5] = [
    (KernelName::Cubic, 1.3),
    (KernelName::Quintic, 1.0),
    (KernelName::WendlandC2, 1.3),
    (KernelName::WendlandC4, 1.3),
    (KernelName::Gaussian, 1.3),
];

/// Which runs a convergence study makes.
#[derive(Clone, Debug)]
pub struct ConvergencePlan {
    /// Resolutions of the fixed-beta sweeps (ratio 2).
    pub fixed_beta_n: Vec<usize>,
    /// Resolution of the beta sweeps.
    pub fixed_n: usize,
    /// Overlaps of the beta sweeps.
    pub betas: Vec<f64>,
    /// Regularisers of the beta sweeps (fractions of h^2).
    pub eta2s: Vec<f64>,
    /// Resolutions of the joint sweep (`beta = sqrt(N / 10)`, `eta = 0.1 dx`).
    pub joint_n: Vec<usize>,
    /// Kernels of the joint sweep (free of pairing at large beta, with a floor that falls as beta grows).
    pub joint_kernels: Vec<KernelName>,
    /// Worker threads per run (0: all cores).
    pub threads: usize,
}

impl ConvergencePlan {
    /// The full study (a few minutes on 2 cores).
    pub fn full() -> Self {
        Self {
            fixed_beta_n: vec![10, 20, 40, 80, 160],
            fixed_n: 40,
            betas: vec![1.0, 1.2, 1.3, 1.5, 1.7, 2.0],
            eta2s: vec![0.01, 1e-4],
            joint_n: vec![10, 20, 40, 80],
            joint_kernels: vec![
                KernelName::WendlandC2,
                KernelName::WendlandC4,
                KernelName::Quintic,
            ],
            threads: 0,
        }
    }

    /// A quick study (well under two minutes on 2 cores).
    pub fn quick() -> Self {
        Self {
            fixed_beta_n: vec![10, 20, 40, 80],
            fixed_n: 20,
            joint_n: vec![10, 20, 40],
            ..Self::full()
        }
    }

    /// Number of runs.
    pub fn runs(&self) -> usize {
        KERNELS.len() * (self.fixed_beta_n.len() + self.betas.len() * self.eta2s.len())
            + self.joint_kernels.len() * self.joint_n.len()
    }
}

/// Orders and floor of one fixed-beta (or joint) sweep, at [`ANALYSIS_TIME`].
#[derive(Clone, Debug, Serialize)]
pub struct OrderRow {
    /// `fixed_beta` or `joint`.
    pub sweep: &'static str,
    /// Kernel.
    pub kernel: KernelName,
    /// Overlap (of the coarsest run for the joint sweep).
    pub beta: f64,
    /// Resolutions.
    pub particles_across: Vec<usize>,
    /// L-infinity errors / U.
    pub linf: Vec<f64>,
    /// Signed errors `nu_eff / nu - 1`.
    pub signed: Vec<f64>,
    /// Local orders of the L-infinity error between successive resolutions.
    pub local_orders: Vec<f64>,
    /// Least-squares slope of ln(Linf) against ln(dx).
    pub fitted_order: f64,
    /// Richardson orders `log2((E_N - E_2N)/(E_2N - E_4N))` of the signed error.
    pub richardson_orders: Vec<f64>,
    /// Extrapolated floor of the signed error (from the finest three runs).
    pub signed_floor: f64,
}

/// Orders of a sweep from its rows at [`ANALYSIS_TIME`], ordered by resolution.
pub fn orders(sweep: &'static str, rows: &[ConvergenceRow]) -> OrderRow {
    let mut at: Vec<&ConvergenceRow> = rows
        .iter()
        .filter(|r| (r.t - ANALYSIS_TIME).abs() < 1e-12)
        .collect();
    at.sort_by_key(|r| r.particles_across);
    let linf: Vec<f64> = at.iter().map(|r| r.linf_error).collect();
    let signed: Vec<f64> = at.iter().map(|r| r.signed_error).collect();
    let ratio = |w: &[usize]| (w[1] as f64 / w[0] as f64).ln();
    let ns: Vec<usize> = at.iter().map(|r| r.particles_across).collect();
    let local_orders = linf
        .windows(2)
        .zip(ns.windows(2))
        .map(|(e, n)| (e[0] / e[1]).ln() / ratio(n))
        .collect();
    let fitted_order =
        crate::bench::loglog_slope(&at.iter().map(|r| (r.dx, r.linf_error)).collect::<Vec<_>>());
    let richardson_orders: Vec<f64> = signed
        .windows(3)
        .map(|e| ((e[0] - e[1]) / (e[1] - e[2])).abs().log2())
        .collect();
    let signed_floor = match (signed.len(), richardson_orders.last()) {
        (len, Some(&p)) if len >= 3 => {
            let (e1, e2) = (signed[len - 2], signed[len - 1]);
            e2 - (e1 - e2) / (2f64.powf(p) - 1.0)
        }
        _ => f64::NAN,
    };
    OrderRow {
        sweep,
        kernel: at.first().map_or(KernelName::Cubic, |r| r.kernel),
        beta: at.first().map_or(f64::NAN, |r| r.beta),
        particles_across: ns,
        linf,
        signed,
        local_orders,
        fitted_order,
        richardson_orders,
        signed_floor,
    }
}

/// Everything a convergence study produced.
#[derive(Clone, Debug)]
pub struct ConvergenceReport {
    /// Every run at every output time.
    pub rows: Vec<ConvergenceRow>,
    /// Orders of the fixed-beta and joint sweeps.
    pub orders: Vec<OrderRow>,
}

/// Runs a convergence study.
///
/// # Errors
/// The first failing run's error.
pub fn convergence(plan: &ConvergencePlan, progress: &dyn Progress) -> Result<ConvergenceReport> {
    progress.start(plan.runs() as u64);
    let mut rows = Vec::new();
    let mut order_rows = Vec::new();
    let silent = couette::Silent;
    for (kernel, beta) in KERNELS {
        let mut sweep = Vec::new();
        for &n in &plan.fixed_beta_n {
            sweep.extend(study_run(
                "fixed_beta",
                &study_config(kernel, beta, n, 0.01, plan.threads),
                &silent,
            )?);
            progress.advance(1);
        }
        order_rows.push(orders("fixed_beta", &sweep));
        rows.extend(sweep);
    }
    for (kernel, _) in KERNELS {
        for &eta2 in &plan.eta2s {
            for &beta in &plan.betas {
                rows.extend(study_run(
                    "fixed_n",
                    &study_config(kernel, beta, plan.fixed_n, eta2, plan.threads),
                    &silent,
                )?);
                progress.advance(1);
            }
        }
    }
    for &kernel in &plan.joint_kernels {
        let mut sweep = Vec::new();
        for &n in &plan.joint_n {
            let beta = (n as f64 / 10.0).sqrt();
            // eta = 0.1 dx: a regulariser fixed in units of h would leave a fixed bias.
            sweep.extend(study_run(
                "joint",
                &study_config(kernel, beta, n, 0.01 / (beta * beta), plan.threads),
                &silent,
            )?);
            progress.advance(1);
        }
        order_rows.push(orders("joint", &sweep));
        rows.extend(sweep);
    }
    progress.finish();
    Ok(ConvergenceReport {
        rows,
        orders: order_rows,
    })
}

/// `convergence.csv`.
pub fn convergence_csv(report: &ConvergenceReport) -> String {
    let mut s = String::from("sweep,kernel,beta,particles_across,dx,h,t,linf_error,l2_error,signed_error,wall_seconds,steps,eta2\n");
    for r in &report.rows {
        s.push_str(&format!(
            "{},{},{},{},{:e},{:e},{},{:e},{:e},{:e},{:.4},{},{}\n",
            r.sweep,
            r.kernel,
            r.beta,
            r.particles_across,
            r.dx,
            r.h,
            r.t,
            r.linf_error,
            r.l2_error,
            r.signed_error,
            r.wall_seconds,
            r.steps,
            r.eta2
        ));
    }
    s
}

/// The orders table (printed, and written as `orders.txt`).
pub fn orders_table(report: &ConvergenceReport) -> String {
    let mut s = format!(
        "Orders at t* = {ANALYSIS_TIME} (signed error: nu_eff/nu - 1; Richardson orders from its successive differences)\n"
    );
    s.push_str(&format!(
        "{:<10} {:<12} {:>5} {:>20} {:>24} {:>7} {:>20} {:>12}\n",
        "sweep", "kernel", "beta", "N", "local orders (Linf)", "fitted", "Richardson", "floor"
    ));
    for o in &report.orders {
        let join = |v: &[f64]| {
            v.iter()
                .map(|x| format!("{x:.2}"))
                .collect::<Vec<_>>()
                .join(" ")
        };
        let ns = o
            .particles_across
            .iter()
            .map(|n| n.to_string())
            .collect::<Vec<_>>()
            .join(",");
        // With beta changing along the joint sweep there is no fixed floor to
        // extrapolate: what matters there is that the error keeps falling.
        let (richardson, floor) = if o.sweep == "joint" {
            ("-".to_string(), "-".to_string())
        } else {
            (
                join(&o.richardson_orders),
                format!("{:+.3e}", o.signed_floor),
            )
        };
        s.push_str(&format!(
            "{:<10} {:<12} {:>5} {:>20} {:>24} {:>7.2} {:>20} {:>12}\n",
            o.sweep,
            o.kernel.name(),
            if o.sweep == "joint" {
                "sqrtN".to_string()
            } else {
                format!("{}", o.beta)
            },
            ns,
            join(&o.local_orders),
            o.fitted_order,
            richardson,
            floor
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::couette::Silent;

    #[test]
    fn effective_viscosity_recovers_the_viscosity_of_an_exact_profile() {
        // A synthetic "run" whose velocities are the exact series for 1.07 nu.
        let mut run = couette::run(
            &CouetteConfig {
                particles_across: 8,
                t_end: 0.05,
                output_times: vec![0.05],
                threads: 1,
                ..CouetteConfig::default()
            },
            &Silent,
        )
        .unwrap();
        let exact = sph_core::analytic::Couette {
            nu: 1.07 * run.config.nu,
            ..run.exact()
        };
        let p = &mut run.profiles[0];
        p.vx = p.y.iter().map(|y| exact.velocity(*y, p.t)).collect();
        let nu_eff = effective_viscosity(&run, 0);
        assert!(
            (nu_eff / run.config.nu - 1.07).abs() < 1e-6,
            "{}",
            nu_eff / run.config.nu
        );
    }
}

use crate::plot::{line_plot, Axes, Series};

/// The convergence plots: Linf against N, the Richardson view (signed error
/// minus its extrapolated floor), and the signed error against beta.
///
/// # Errors
/// If drawing fails.
pub fn convergence_plots(report: &ConvergenceReport) -> Result<Vec<(&'static str, Vec<u8>)>> {
    let at = |r: &&ConvergenceRow| (r.t - ANALYSIS_TIME).abs() < 1e-12;
    let mut linf = Vec::new();
    let mut diff = Vec::new();
    for (k, o) in report.orders.iter().enumerate() {
        let label = if o.sweep == "joint" {
            format!("{} joint (beta = sqrt(N/10), eta = 0.1 dx)", o.kernel)
        } else {
            format!("{} beta {}", o.kernel, o.beta)
        };
        let points: Vec<(f64, f64)> = o
            .particles_across
            .iter()
            .zip(&o.linf)
            .map(|(n, e)| (*n as f64, *e))
            .collect();
        linf.push(Series {
            label: label.clone(),
            points,
            color: k,
            line: true,
            markers: true,
        });
        if o.sweep == "fixed_beta" {
            let points = o
                .particles_across
                .iter()
                .zip(&o.signed)
                .map(|(n, e)| (*n as f64, (e - o.signed_floor).abs()))
                .collect();
            diff.push(Series {
                label,
                points,
                color: k,
                line: true,
                markers: true,
            });
        }
    }
    let n_max = report
        .orders
        .iter()
        .flat_map(|o| o.particles_across.iter())
        .copied()
        .max()
        .unwrap_or(160) as f64;
    let reference = |y10: f64| Series {
        label: "slope -2".into(),
        points: vec![(10.0, y10), (n_max, y10 * (10.0 / n_max).powi(2))],
        color: crate::plot::REFERENCE,
        line: true,
        markers: false,
    };
    linf.push(reference(2e-2));
    diff.push(reference(2e-2));
    let mut beta_series = Vec::new();
    for (k, (kernel, _)) in KERNELS.iter().enumerate() {
        for (eta2, line) in [(0.01, true), (1e-4, false)] {
            let mut points: Vec<(f64, f64)> = report
                .rows
                .iter()
                .filter(at)
                .filter(|r| r.sweep == "fixed_n" && r.kernel == *kernel && r.eta2 == eta2)
                .map(|r| (r.beta, r.signed_error))
                .collect();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            if !points.is_empty() {
                beta_series.push(Series {
                    label: format!("{kernel}, eta2 {eta2}"),
                    points,
                    color: k,
                    line,
                    markers: true,
                });
            }
        }
    }
    let fixed_n = report
        .rows
        .iter()
        .find(|r| r.sweep == "fixed_n")
        .map_or(0, |r| r.particles_across);
    Ok(vec![
        (
            "convergence.png",
            line_plot(
                &Axes {
                    title: format!("Couette, Linf error at t* = {ANALYSIS_TIME} against resolution"),
                    x: "particles across the gap".into(),
                    y: "Linf error / U".into(),
                    log_x: true,
                    log_y: true,
                },
                &linf,
            )?,
        ),
        (
            "richardson.png",
            line_plot(
                &Axes {
                    title: "Signed error minus its extrapolated floor (fixed beta)".into(),
                    x: "particles across the gap".into(),
                    y: "|nu_eff/nu - 1 - floor|".into(),
                    log_x: true,
                    log_y: true,
                },
                &diff,
            )?,
        ),
        (
            "beta.png",
            line_plot(
                &Axes {
                    title: format!("Signed error against beta at {fixed_n} particles across (lines eta2 = 0.01, dots 1e-4)"),
                    x: "beta = h / dx".into(),
                    y: "nu_eff / nu - 1".into(),
                    log_x: false,
                    log_y: false,
                },
                &beta_series,
            )?,
        ),
    ])
}

/// Writes `convergence.csv`, `orders.txt` and the plots into `dir`.
///
/// # Errors
/// [`crate::error::Error::Io`] naming the file.
pub fn write_convergence(
    report: &ConvergenceReport,
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>> {
    let mut files = vec![
        ("convergence.csv", convergence_csv(report).into_bytes()),
        ("orders.txt", orders_table(report).into_bytes()),
    ];
    for (name, png) in convergence_plots(report)? {
        files.push((name, png));
    }
    let mut written = Vec::new();
    for (name, bytes) in files {
        let path = dir.join(name);
        crate::output::write_atomic(&path, &bytes)?;
        written.push(path);
    }
    Ok(written)
}

/// One configuration of the speed/accuracy study.
#[derive(Clone, Debug, Serialize)]
pub struct ParetoRow {
    /// Kernel.
    pub kernel: KernelName,
    /// Precision.
    pub precision: crate::config::Precision,
    /// Math backend.
    pub math: crate::config::MathBackend,
    /// Overlap.
    pub beta: f64,
    /// Time step as a fraction of the stability limit.
    pub dt_factor: f64,
    /// Particles across.
    pub particles_across: usize,
    /// Largest Linf / U over output times with t* >= 0.02.
    pub linf_error: f64,
    /// Wall seconds (one thread).
    pub wall_seconds: f64,
    /// Fluid particle-steps per second.
    pub particle_steps_per_s: f64,
    /// On the Pareto frontier (no other run both cheaper and more accurate).
    pub pareto: bool,
}

/// The designed subset of the study: one-factor variations around the
/// default (cubic, f64, libm, beta 1.3, dt factor 0.7) at each resolution.
pub fn pareto_configs(resolutions: &[usize]) -> Vec<CouetteConfig> {
    use crate::config::{MathBackend, Precision};
    let mut out = Vec::new();
    for &n in resolutions {
        let base = CouetteConfig {
            particles_across: n,
            t_end: 0.225,
            output_times: vec![0.0225, 0.045, 0.1125, 0.225],
            threads: 1,
            quiet: true,
            ..CouetteConfig::default()
        };
        for (kernel, beta) in KERNELS {
            out.push(CouetteConfig {
                kernel,
                beta,
                ..base.clone()
            });
        }
        out.push(CouetteConfig {
            precision: Precision::F32,
            ..base.clone()
        });
        out.push(CouetteConfig {
            precision: Precision::F32,
            math: MathBackend::Micromath,
            ..base.clone()
        });
        for beta in [1.0, 1.5, 2.0] {
            out.push(CouetteConfig {
                beta,
                ..base.clone()
            });
        }
        for dt_factor in [0.3, 0.9] {
            out.push(CouetteConfig {
                dt_factor,
                ..base.clone()
            });
        }
    }
    out
}

/// Runs the speed/accuracy study over `configs` and marks the frontier.
///
/// # Errors
/// The first failing run's error.
pub fn pareto(configs: &[CouetteConfig], progress: &dyn Progress) -> Result<Vec<ParetoRow>> {
    progress.start(configs.len() as u64);
    let mut rows = Vec::with_capacity(configs.len());
    for cfg in configs {
        let run = couette::run(cfg, &couette::Silent)?;
        let (linf, _) = run.headline();
        rows.push(ParetoRow {
            kernel: cfg.kernel,
            precision: cfg.precision,
            math: cfg.math,
            beta: cfg.beta,
            dt_factor: cfg.dt_factor,
            particles_across: cfg.particles_across,
            linf_error: linf,
            wall_seconds: run.wall_seconds,
            particle_steps_per_s: (run.geometry.n_fluid as f64 * run.steps as f64)
                / run.wall_seconds,
            pareto: false,
        });
        progress.advance(1);
    }
    progress.finish();
    let snapshot = rows.clone();
    for r in &mut rows {
        r.pareto = !snapshot.iter().any(|o| {
            o.wall_seconds <= r.wall_seconds
                && o.linf_error <= r.linf_error
                && (o.wall_seconds < r.wall_seconds || o.linf_error < r.linf_error)
        });
    }
    Ok(rows)
}

/// `pareto.csv`.
pub fn pareto_csv(rows: &[ParetoRow]) -> String {
    let mut s = String::from("kernel,precision,math,beta,dt_factor,particles_across,linf_error,wall_seconds,particle_steps_per_s,pareto\n");
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{},{},{:e},{:.4},{:.4e},{}\n",
            r.kernel,
            r.precision,
            r.math,
            r.beta,
            r.dt_factor,
            r.particles_across,
            r.linf_error,
            r.wall_seconds,
            r.particle_steps_per_s,
            r.pareto
        ));
    }
    s
}

/// For each target error (fraction of U), the cheapest run that meets it.
pub fn cheapest_for(rows: &[ParetoRow], targets: &[f64]) -> String {
    let mut s = String::from(
        "Cheapest configuration for a target error (largest Linf / U over t* >= 0.02):\n",
    );
    for &target in targets {
        let best = rows
            .iter()
            .filter(|r| r.linf_error <= target)
            .min_by(|a, b| a.wall_seconds.total_cmp(&b.wall_seconds));
        match best {
            Some(r) => s.push_str(&format!(
                "  <= {:>5} % of U: {} kernel, beta {}, {} across, {}/{}, dt factor {}: error {:.2e}, {:.3} s on one thread\n",
                target * 100.0,
                r.kernel,
                r.beta,
                r.particles_across,
                r.precision,
                r.math,
                r.dt_factor,
                r.linf_error,
                r.wall_seconds
            )),
            None => s.push_str(&format!("  <= {:>5} % of U: no run of this study reaches it\n", target * 100.0)),
        }
    }
    s
}

/// Error against cost, each run a point, the frontier a line.
///
/// # Errors
/// If drawing fails.
pub fn pareto_png(rows: &[ParetoRow]) -> Result<Vec<u8>> {
    let mut series = Vec::new();
    let mut labels: Vec<String> = Vec::new();
    for r in rows {
        let label = format!(
            "{} b{} {}/{} dt{}",
            r.kernel, r.beta, r.precision, r.math, r.dt_factor
        );
        let k = match labels.iter().position(|l| *l == label) {
            Some(k) => k,
            None => {
                labels.push(label.clone());
                series.push(Series {
                    label,
                    points: Vec::new(),
                    color: labels.len() - 1,
                    line: false,
                    markers: true,
                });
                labels.len() - 1
            }
        };
        series[k].points.push((r.wall_seconds, r.linf_error));
    }
    let mut frontier: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.pareto)
        .map(|r| (r.wall_seconds, r.linf_error))
        .collect();
    frontier.sort_by(|a, b| a.0.total_cmp(&b.0));
    series.push(Series {
        label: "Pareto frontier".into(),
        points: frontier,
        color: crate::plot::REFERENCE,
        line: true,
        markers: false,
    });
    line_plot(
        &Axes {
            title: "Couette: error against cost (each point a run; one thread)".into(),
            x: "wall seconds".into(),
            y: "largest Linf error / U (t* >= 0.02)".into(),
            log_x: true,
            log_y: true,
        },
        &series,
    )
}

/// Writes `pareto.csv`, `cheapest.txt` and `pareto.png` into `dir`.
///
/// # Errors
/// [`crate::error::Error::Io`] naming the file.
pub fn write_pareto(rows: &[ParetoRow], dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>> {
    let files = [
        ("pareto.csv", pareto_csv(rows).into_bytes()),
        (
            "cheapest.txt",
            cheapest_for(rows, &[0.1, 0.01, 0.001]).into_bytes(),
        ),
        ("pareto.png", pareto_png(rows)?),
    ];
    let mut written = Vec::new();
    for (name, bytes) in files {
        let path = dir.join(name);
        crate::output::write_atomic(&path, &bytes)?;
        written.push(path);
    }
    Ok(written)
}
