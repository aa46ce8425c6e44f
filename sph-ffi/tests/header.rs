//! `include/sph.h` is what cbindgen generates from `src/lib.rs` now: a
//! stale header fails here.

#[path = "common/header.rs"]
mod common;

#[test]
fn header_is_current() {
    common::check(env!("CARGO_MANIFEST_DIR"), "sph.h", "sph-ffi");
}
