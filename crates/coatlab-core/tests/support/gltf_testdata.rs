//! The shared glTF test models (`shared/testdata/gltf`, read in place).
#![allow(dead_code)] // each test crate uses its own subset

use std::path::PathBuf;

pub const TESTDATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/testdata/gltf");

/// The test-model folder, or `None` (with a notice) when it is absent outside CI.
pub fn testdata() -> Option<PathBuf> {
    let dir = PathBuf::from(TESTDATA);
    if dir.is_dir() {
        return Some(dir);
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "CI is set but the glTF test models are missing at {}",
        dir.display()
    );
    eprintln!(
        "NOTICE: glTF test models not found at {}; test skipped",
        dir.display()
    );
    None
}
