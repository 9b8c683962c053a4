//! A small Radiance .hdr for the tests that load an environment map (included with
//! `#[path]` by the engine's unit tests and the GUI tests).

use std::path::Path;

/// 16 × 8 pixels, flat (not run-length) scanlines, a bright upper half.
pub fn write_hdr(path: &Path) {
    let (w, h) = (16usize, 8usize);
    let mut bytes = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    for y in 0..h {
        for x in 0..w {
            let level = if y < h / 2 { 200u8 } else { 60 };
            bytes.extend_from_slice(&[level, level, (level as usize * x / w) as u8 + 10, 129]);
        }
    }
    std::fs::write(path, bytes).expect("write .hdr");
}
