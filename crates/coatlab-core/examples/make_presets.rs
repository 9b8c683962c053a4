//! Writes the preset paint designs to `assets/presets/<slug>.toml`.
//!
//! `cargo run -p coatlab-core --example make_presets [OUTPUT_DIR]`
//!
//! The designs themselves live in `coatlab_core::design::presets` so that the test
//! suite can check the committed files against them; this program only writes them
//! and reports each one's lobe exponent.

use std::path::PathBuf;
use std::process::ExitCode;

use coatlab_core::design::presets;
use coatlab_core::paint::gloss::{GLOSS_WAVELENGTH_NM, GlossExponent};

fn main() -> ExitCode {
    let out_dir = std::env::args_os()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../assets/presets"));
    for preset in presets::all() {
        let design = &preset.design;
        let path = out_dir.join(format!("{}.toml", preset.slug));
        if let Err(error) = design.save(&path) {
            eprintln!("error: {error}");
            return ExitCode::FAILURE;
        }
        let m = match design.exponent() {
            Ok(GlossExponent::Finite(m)) => format!("m = {m:.1}"),
            Ok(GlossExponent::Mirror) => "mirror".to_owned(),
            Err(error) => format!("error: {error}"),
        };
        println!(
            "{:<22} {:>5.1} GU at {:<3} n({GLOSS_WAVELENGTH_NM} nm) = {:.4}  h = {} µm  {m}  ({})",
            path.file_name()
                .map(|n| n.to_string_lossy())
                .unwrap_or_default(),
            design.gloss.gu,
            design.gloss.geometry,
            design.refractive_index_at_nm(GLOSS_WAVELENGTH_NM),
            design.thickness_um,
            design.lobe.name(),
        );
    }
    ExitCode::SUCCESS
}
