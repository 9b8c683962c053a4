//! Rebuilds `tests/data/gltf_reference/*.csv`, the references each shared glTF
//! test model's render is compared with (`tests/gltf_render.rs`): one per model
//! file the loader accepts. Run it after a change that is meant to change what
//! the models look like (their materials, textures, the studio), never to make
//! a test pass. Needs `../shared/testdata/gltf`.
//!
//!     cargo run -p coatlab-core --example make_gltf_references
//!
//! (The dev profile builds the core at opt-level 3; `--release` is as fast to run.)

#[path = "../tests/support/gltf_reference.rs"]
mod gltf_reference;
#[path = "../tests/support/gltf_testdata.rs"]
mod gltf_testdata;
#[path = "../tests/support/image_stats.rs"]
mod image_stats;
#[path = "../tests/support/progressive.rs"]
mod progressive;
#[path = "../tests/support/render_reference.rs"]
mod render_reference;

use std::time::Instant;

use gltf_reference::{
    REFERENCE_DIR, REFERENCE_REPLICAS, REFERENCE_SEED, load_model, model_replicas, reference_path,
};
use gltf_testdata::model_files;
use render_reference::Reference;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = gltf_testdata::testdata().ok_or("the glTF test models are missing")?;
    std::fs::create_dir_all(REFERENCE_DIR)?;
    let (k, spp) = REFERENCE_REPLICAS;
    for model in model_files(&dir) {
        let Some(scene) = load_model(&model) else {
            println!("{}: refused by the loader, no reference", model.display());
            continue;
        };
        let start = Instant::now();
        let replicas = model_replicas(&scene, REFERENCE_SEED, k, spp);
        let path = reference_path(&model);
        let name = model.file_name().and_then(|n| n.to_str()).unwrap_or("?");
        Reference::from_replicas(&replicas).write_titled(
            &path,
            &format!(
                "{name}, default view, studio, signal-red on its paint materials, \
                 8 wavelengths, {k} replicas of {spp} spp, seeds {REFERENCE_SEED}..{}",
                REFERENCE_SEED + k as u64 - 1
            ),
        )?;
        println!(
            "wrote {} in {:.1} s",
            path.display(),
            start.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
