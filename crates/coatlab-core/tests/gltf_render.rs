//! Each shared glTF test model that loads renders with its own materials and
//! textures: a test render agrees, within the noise of both, with a less noisy
//! reference rendered here from the same model, read in place, with other
//! seeds (`support/gltf_reference.rs`), by the tests of `support/image_stats.rs`
//! (per pixel, over tiles and over the image, never exact pixels). The
//! negative control: a model whose unpainted materials have textures, rendered
//! with its textures left out (the factors alone), is rejected, so the
//! comparison sees the textures. The tracer's colours themselves are held to a
//! stored reference of the built-in car (`tests/render.rs`), not of these
//! third-party models, which stay in `../shared`.

#[path = "support/gltf_testdata.rs"]
mod gltf_testdata;
use gltf_testdata::{model_files, testdata};

#[path = "support/image_stats.rs"]
mod image_stats;
use image_stats::{Weights, compare, seed};

#[path = "support/progressive.rs"]
mod progressive;

#[path = "support/gltf_reference.rs"]
mod gltf_reference;
use gltf_reference::{has_unpainted_textures, load_model, model_replicas, without_textures};

/// A test render: replicas and samples per pixel of each.
const TEST_REPLICAS: (usize, u32) = (4, 16);
/// The reference: eight times the test render's samples, so that the
/// comparison's noise is mostly the test render's.
const REFERENCE_REPLICAS: (usize, u32) = (8, 64);

#[test]
fn each_test_model_renders_as_its_reference_and_its_textures_show() {
    let Some(dir) = testdata() else { return };
    let (k, spp) = TEST_REPLICAS;
    let mut compared = 0;
    for model in model_files(&dir) {
        let Some(scene) = load_model(&model) else {
            // Refused as before (`tests/render.rs` checks the refusals).
            continue;
        };
        let what = model.display().to_string();
        let first = seed(20_000);
        let (reference_k, reference_spp) = REFERENCE_REPLICAS;
        let reference = model_replicas(&scene, first + 300, reference_k, reference_spp);
        let rendered = model_replicas(&scene, first, k, spp);
        let pilot = model_replicas(&scene, first + 100, 2, 8);
        let weights = Weights::from_pilot(&pilot);
        compare(&rendered, &reference, &weights).assert_agree(&what);
        if has_unpainted_textures(&scene) {
            let bare = model_replicas(&without_textures(scene), first + 200, k, spp);
            let control = compare(&bare, &reference, &weights);
            println!("{what} without its textures: {}", control.summary());
            assert!(
                control.fails(),
                "{what}: the render without textures passes for the reference: {}",
                control.summary()
            );
        }
        compared += 1;
    }
    assert!(compared >= 4, "only {compared} models compared");
}
