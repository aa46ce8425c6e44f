//! The firmware's Couette case (`examples/firmware/src/scene.rs`) run on the
//! host, for comparison with the emulated Cortex-M bit for bit:
//! `cargo run -p sph-core --release --example firmware_host -- [libm|micromath]`
//! (an example of sph-core, so that it builds without the std frontend).

#[path = "../../examples/firmware/src/scene.rs"]
#[allow(dead_code)]
mod scene;

use sph_core::math::{Libm, Micromath};

fn main() -> std::process::ExitCode {
    let backend = std::env::args().nth(1).unwrap_or_else(|| "libm".into());
    let mut store = scene::SceneStore::new();
    let print = |line: scene::Line| println!("{line}");
    let result = match backend.as_str() {
        "libm" => scene::run::<Libm>(&mut store, true, print),
        "micromath" => scene::run::<Micromath>(&mut store, true, print),
        other => {
            eprintln!("unknown backend `{other}`: expected libm or micromath");
            return std::process::ExitCode::from(2);
        }
    };
    match result {
        Ok(worst) => {
            println!("worst_ppm={worst}");
            std::process::ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
