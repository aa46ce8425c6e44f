//! The header check shared by sph-ffi and sph-ffi-bare: cbindgen run on
//! `src/lib.rs` with `cbindgen.toml` must give the committed header;
//! `SPH_UPDATE_HEADER=1` rewrites it.

use std::path::Path;

/// Compares (or with `SPH_UPDATE_HEADER`, rewrites) `include/<header>` of
/// the crate in `dir`, named `package` in the message.
pub fn check(dir: &str, header: &str, package: &str) {
    let dir = Path::new(dir);
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).unwrap();
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(dir.join("src/lib.rs"))
        .generate()
        .expect("cbindgen reads src/lib.rs");
    let mut generated = Vec::new();
    bindings.write(&mut generated);
    let generated = String::from_utf8(generated).unwrap();
    let path = dir.join("include").join(header);
    if std::env::var_os("SPH_UPDATE_HEADER").is_some() {
        std::fs::write(&path, &generated).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "include/{header} is stale: run SPH_UPDATE_HEADER=1 cargo test -p {package} --test header"
    );
}
