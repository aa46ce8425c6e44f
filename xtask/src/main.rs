//! `cargo xtask`: project automation that plain `cargo build`/`cargo test`
//! cannot do (see matklad/cargo-xtask). Std only, no dependencies.
//!
//! Commands:
//! - `cross`: build sph-core for bare-metal and wasm targets, with default
//!   features and with `fast-math` (installs missing targets with rustup).
//! - `deps`: check that sph-core's normal dependencies are only libm,
//!   heapless and micromath (and what those pull in).

use std::env;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

/// Bare-metal and wasm targets the core must build for.
const TARGETS: &[(&str, &str)] = &[
    ("thumbv6m-none-eabi", "Cortex-M0: no FPU, no atomics"),
    ("thumbv7em-none-eabihf", "Cortex-M4F"),
    ("riscv32imac-unknown-none-elf", "RISC-V 32"),
    ("wasm32-unknown-unknown", "wasm"),
];

/// Crates allowed in `cargo tree -p sph-core -e normal`.
const ALLOWED_CORE_DEPS: &[&str] = &[
    "sph-core",
    "libm",
    "heapless",
    "micromath",
    "hash32",
    "byteorder",
    "stable_deref_trait",
];

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

fn cargo() -> Command {
    let mut c = Command::new(env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.current_dir(root());
    c
}

fn fail(msg: String) -> Result<(), String> {
    Err(msg)
}

fn installed_targets() -> Result<String, String> {
    let out = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .map_err(|e| format!("cannot run rustup (needed to install targets): {e}"))?;
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

fn ensure_target(target: &str) -> Result<(), String> {
    if installed_targets()?.lines().any(|l| l.trim() == target) {
        return Ok(());
    }
    eprintln!("xtask: installing target {target} (rustup target add {target})");
    let status = Command::new("rustup")
        .args(["target", "add", target])
        .status()
        .map_err(|e| format!("cannot run rustup: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        fail(format!(
            "target {target}: `rustup target add {target}` failed"
        ))
    }
}

fn cross() -> Result<(), String> {
    for (target, what) in TARGETS {
        ensure_target(target)?;
        for features in [None, Some("fast-math")] {
            let mut cmd = cargo();
            cmd.args([
                "build",
                "--quiet",
                "--release",
                "-p",
                "sph-core",
                "--target",
                target,
            ]);
            if let Some(f) = features {
                cmd.args(["--features", f]);
            }
            let label = format!(
                "{target} ({what}), features: {}",
                features.unwrap_or("default")
            );
            let out = cmd
                .output()
                .map_err(|e| format!("{label}: cannot run cargo: {e}"))?;
            if !out.status.success() {
                let stderr = String::from_utf8_lossy(&out.stderr);
                let first = stderr
                    .lines()
                    .find(|l| l.starts_with("error"))
                    .unwrap_or("build failed");
                return fail(format!("{label}: {first}\n{stderr}"));
            }
            println!("ok  sph-core for {label}");
        }
    }
    Ok(())
}

fn deps() -> Result<(), String> {
    let out = cargo()
        .args([
            "tree",
            "-p",
            "sph-core",
            "-e",
            "normal",
            "--prefix",
            "none",
            "--all-features",
        ])
        .output()
        .map_err(|e| format!("cannot run cargo tree: {e}"))?;
    if !out.status.success() {
        return fail(format!(
            "cargo tree failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let tree = String::from_utf8_lossy(&out.stdout);
    let mut bad = Vec::new();
    for line in tree.lines() {
        let name = line.split_whitespace().next().unwrap_or("");
        if !name.is_empty() && !ALLOWED_CORE_DEPS.contains(&name) {
            bad.push(name.to_string());
        }
    }
    if bad.is_empty() {
        println!(
            "ok  sph-core depends only on: {}",
            ALLOWED_CORE_DEPS[1..].join(", ")
        );
        Ok(())
    } else {
        fail(format!(
            "sph-core has dependencies outside libm, heapless, micromath: {}",
            bad.join(", ")
        ))
    }
}

fn main() -> ExitCode {
    let task = env::args().nth(1).unwrap_or_default();
    let result = match task.as_str() {
        "cross" => cross(),
        "deps" => deps(),
        _ => {
            eprintln!("usage: cargo xtask <cross|deps>");
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask {task}: error: {e}");
            ExitCode::FAILURE
        }
    }
}
