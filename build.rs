//! Records the commit HEAD points at when the `sph` binary is built
//! (`SPH_GIT_COMMIT`), for the `git_commit` key of its summaries (local
//! changes not committed are not marked); nothing outside a git checkout.

use std::path::Path;
use std::process::Command;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let git = Path::new(".git");
    if !git.exists() {
        return;
    }
    // Rebuild when HEAD moves (a commit, a checkout).
    for path in [".git/HEAD", ".git/refs/heads", ".git/packed-refs"] {
        if Path::new(path).exists() {
            println!("cargo:rerun-if-changed={path}");
        }
    }
    let out = Command::new("git").args(["rev-parse", "HEAD"]).output();
    if let Ok(out) = out {
        if out.status.success() {
            let commit = String::from_utf8_lossy(&out.stdout).trim().to_string();
            println!("cargo:rustc-env=SPH_GIT_COMMIT={commit}");
        }
    }
}
