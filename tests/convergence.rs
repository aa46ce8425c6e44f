//! The convergence claims, from theory (physics.md section 7): at fixed beta
//! the error approaches a kernel- and beta-dependent floor at second order,
//! which Richardson's differences expose; with beta growing as sqrt(N) (and
//! the regulariser tied to dx) the error keeps falling toward zero.

use sph_std::config::KernelName;
use sph_std::couette::Silent;
use sph_std::studies::{orders, study_config, study_run, ConvergenceRow};

fn sweep(
    kernel: KernelName,
    ns: &[usize],
    beta_of: impl Fn(usize) -> f64,
    eta2_of: impl Fn(f64) -> f64,
) -> Vec<ConvergenceRow> {
    ns.iter()
        .flat_map(|&n| {
            let beta = beta_of(n);
            study_run(
                "test",
                &study_config(kernel, beta, n, eta2_of(beta), 1),
                &Silent,
            )
            .unwrap()
        })
        .collect()
}

#[test]
fn fixed_beta_richardson_order_is_second_order_for_two_kernels() {
    for (kernel, beta) in [
        (KernelName::Cubic, 1.3),
        (KernelName::Quintic, 1.0),
        (KernelName::WendlandC2, 1.3),
    ] {
        let rows = sweep(kernel, &[10, 20, 40], |_| beta, |_| 0.01);
        let o = orders("fixed_beta", &rows);
        assert_eq!(o.richardson_orders.len(), 1);
        let p = o.richardson_orders[0];
        assert!(
            p >= 1.8,
            "{kernel} beta {beta}: Richardson order {p:.2} (signed errors {:?})",
            o.signed
        );
    }
}

#[test]
fn joint_sweep_error_falls_at_every_refinement() {
    for kernel in [KernelName::WendlandC2, KernelName::Quintic] {
        let rows = sweep(
            kernel,
            &[10, 20, 40],
            |n| (n as f64 / 10.0).sqrt(),
            |beta| 0.01 / (beta * beta),
        );
        let o = orders("joint", &rows);
        for w in o.linf.windows(2) {
            assert!(
                w[1] < w[0],
                "{kernel}: joint sweep error did not fall: {:?}",
                o.linf
            );
        }
        for w in o.signed.windows(2) {
            assert!(
                w[1].abs() < w[0].abs(),
                "{kernel}: joint sweep viscosity error did not fall: {:?}",
                o.signed
            );
        }
    }
}
