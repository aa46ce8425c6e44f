//! The native run the browser page is checked against:
//! `cargo run -p sph-web --example reference -- ACROSS NU STEPS` prints the
//! error after STEPS steps with 17 digits, as the page does.

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |k: usize, default: &str| args.get(k).cloned().unwrap_or_else(|| default.into());
    let across: usize = get(0, "16").parse().map_err(|e| format!("ACROSS: {e}"))?;
    let nu: f64 = get(1, "1e-6").parse().map_err(|e| format!("NU: {e}"))?;
    let steps: u32 = get(2, "300").parse().map_err(|e| format!("STEPS: {e}"))?;
    let mut run = sph_web::Run::new(across, nu).map_err(|e| e.to_string())?;
    // The page steps in frames of 20; the result does not depend on it.
    let mut left = steps;
    while left > 0 {
        let k = left.min(20);
        run.step(k).map_err(|e| e.to_string())?;
        left -= k;
    }
    println!(
        "across={across} nu={nu:e} steps={} t={:.17e} linf={:.17e}",
        run.steps(),
        run.time(),
        run.linf()
    );
    Ok(())
}
