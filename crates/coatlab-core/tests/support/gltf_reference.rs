//! The shared glTF test models rendered with their own materials and textures,
//! for `tests/gltf_render.rs`: the default view (framed on the car) in the
//! studio with the signal-red preset on the paint materials, small, from the
//! model read in place.

use std::path::Path;

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::design::presets;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::Film;
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::RenderSettings;
use coatlab_core::render::view::{SceneFraming, ViewChoice};
use coatlab_core::scene::Scene;
use coatlab_core::scene::gltf_loader::{LoadOptions, load};

use crate::image_stats::{Replicas, film_image};
use crate::progressive::film_in_passes;

/// The image: small, so a test render takes a fraction of a second; wide
/// enough that a texture's colours cover whole pixels.
const SIZE: (u32, u32) = (32, 20);
const WAVELENGTHS: usize = 8;

/// The model file loaded as the application loads it; `None` when the loader
/// refuses it (a compression extension).
pub fn load_model(model: &Path) -> Option<Scene> {
    load(model, &LoadOptions::default()).ok()
}

/// `scene` without any texture: every material's factors alone (what a loader
/// that ignored the textures would render), the tests' negative control.
pub fn without_textures(mut scene: Scene) -> Scene {
    for m in &mut scene.materials {
        m.base_color_texture = None;
        m.metallic_roughness_texture = None;
        m.normal_texture = None;
        m.occlusion_texture = None;
        m.emissive_texture = None;
    }
    scene
}

/// Whether a material of `scene` that does not carry the paint has a texture:
/// what the render shows of the file's textures (the designed paint replaces
/// the painted materials' own, textures included, as ClearCoatCarPaint's only
/// material with its normal map).
pub fn has_unpainted_textures(scene: &Scene) -> bool {
    scene
        .materials
        .iter()
        .enumerate()
        .any(|(i, m)| m.has_textures() && !scene.paint_materials.contains(&(i as u32)))
}

/// Renders `scene` from its default view at [`SIZE`] with `seed` and `spp`
/// samples per pixel.
pub fn model_render(scene: &Scene, seed: u64, spp: u32) -> Film {
    let grid = WavelengthGrid::visible(WAVELENGTHS).expect("grid");
    let design = presets::all().into_iter().next().expect("preset").design;
    let model = design.model(grid).expect("model");
    let shading = Shading::for_scene(&model, ShadingModel::Paint, scene);
    let camera = SceneFraming::new(scene)
        .camera(&ViewChoice::default(), SIZE.0, SIZE.1)
        .expect("the default view");
    film_in_passes(
        scene.clone(),
        Environment::studio(&grid),
        shading,
        camera,
        RenderSettings::seeded(seed),
        spp,
        16,
    )
}

/// `k` renders of `scene`, seeds `first_seed` + i, `spp` samples each.
pub fn model_replicas(scene: &Scene, first_seed: u64, k: usize, spp: u32) -> Replicas {
    Replicas::collect(SIZE.0, SIZE.1, k, |i| {
        film_image(&model_render(scene, first_seed + i as u64, spp))
    })
}
