//! A film from a progressive render run to a number of samples per pixel: the
//! set-up the render tests, the extreme-design renders and the stored render
//! reference share.
#![allow(dead_code)] // each test crate uses its own subset

use std::sync::Arc;

use coatlab_core::paint::model::PaintModel;
use coatlab_core::render::camera::Camera;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::Film;
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::{ProgressiveRender, RenderScene, RenderSettings};
use coatlab_core::scene::Scene;

/// `model` under shading model `which` on every paint material of `scene`.
pub fn shading_for(scene: &Scene, model: &PaintModel, which: ShadingModel) -> Shading {
    Shading::for_scene(model, which, scene)
}

/// The film of `scene` rendered with `shading` to `spp` samples per pixel, in
/// passes of at most `pass` samples.
pub fn film_in_passes(
    scene: Scene,
    environment: Environment,
    shading: Shading,
    camera: Camera,
    settings: RenderSettings,
    spp: u32,
    pass: u32,
) -> Film {
    let mut render = ProgressiveRender::new(
        Arc::new(RenderScene::new(scene).expect("scene")),
        Arc::new(environment),
        Arc::new(shading),
        camera,
        settings,
    )
    .expect("render");
    render.render_to(spp, pass);
    render.film().clone()
}

/// The film of `scene` with `model` under shading model `which`, `spp` samples per
/// pixel in passes of 8.
pub fn render_film(
    scene: Scene,
    environment: Environment,
    model: &PaintModel,
    which: ShadingModel,
    camera: Camera,
    settings: RenderSettings,
    spp: u32,
) -> Film {
    let shading = shading_for(&scene, model, which);
    film_in_passes(scene, environment, shading, camera, settings, spp, 8)
}
