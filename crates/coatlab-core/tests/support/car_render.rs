//! The default car in the studio at 64×36 with the signal-red preset, rendered
//! with part of its paths recorded, and its fresh renders as replicas for the
//! statistical comparisons of `image_stats.rs`: shared by the re-shading and the
//! shared-comparison tests.
#![allow(dead_code)] // each test crate uses its own subset

use std::sync::{Arc, OnceLock};

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::design::presets;
use coatlab_core::paint::model::PaintModel;
use coatlab_core::render::camera::Camera;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::integrator::IntegratorSettings;
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::pick::pick;
use coatlab_core::render::progressive::{ProgressiveRender, RenderScene, RenderSettings};
use coatlab_core::scene::Scene;
use coatlab_core::scene::car::{CarParameters, generate};

use crate::image_stats::{Image, Replicas, Weights, film_image, seed};

pub const WIDTH: u32 = 64;
pub const HEIGHT: u32 = 36;

/// The default car with its headlamps off. The emitter is found only by paths
/// that hit it (emitters are not light-sampled), so its few pixels and the paint
/// beside it, lit by it, held 45 % of the image's variance at 64 samples: enough
/// to hide a 2 % defect on the paint from these comparisons. Emission is
/// independent of the design and is replayed as recorded.
pub fn car_with_lamps_off() -> Scene {
    let mut scene = generate(&CarParameters::default());
    for material in &mut scene.materials {
        material.emissive = palette::LinSrgb::new(0.0, 0.0, 0.0);
    }
    scene
}

/// [`car_with_lamps_off`] and its render scene (BVH built), made once per test
/// binary and shared by every render and region here: the car is the same each
/// time, and building it took longer than a 64×36 render of it.
fn shared_car() -> &'static (Scene, Arc<RenderScene>) {
    static CAR: OnceLock<(Scene, Arc<RenderScene>)> = OnceLock::new();
    CAR.get_or_init(|| {
        let scene = car_with_lamps_off();
        let render_scene = RenderScene::new(scene.clone()).expect("scene");
        (scene, Arc::new(render_scene))
    })
}

pub fn grid() -> WavelengthGrid {
    WavelengthGrid::visible(16).expect("grid")
}

/// The first preset (signal red) on [`grid`].
pub fn red() -> PaintModel {
    let design = presets::all().into_iter().next().expect("preset").design;
    design.model(grid()).expect("model")
}

pub fn shading(scene: &Scene, model: &PaintModel, which: ShadingModel) -> Arc<Shading> {
    Arc::new(Shading::for_scene(model, which, scene))
}

/// A render of the default car in the studio with `model`, `spp` samples, the
/// first `cached` of them recorded.
pub fn render(
    model: &PaintModel,
    which: ShadingModel,
    seed: u64,
    spp: u32,
    cached: u32,
) -> (ProgressiveRender, Scene) {
    render_with(
        model,
        which,
        seed,
        spp,
        cached,
        IntegratorSettings::default(),
    )
}

/// [`render`] with other integrator settings.
pub fn render_with(
    model: &PaintModel,
    which: ShadingModel,
    seed: u64,
    spp: u32,
    cached: u32,
    integrator: IntegratorSettings,
) -> (ProgressiveRender, Scene) {
    let settings = RenderSettings {
        integrator,
        ..RenderSettings::seeded(seed)
    };
    render_with_settings(model, which, spp, cached, settings)
}

/// [`render`] with the render's settings as given.
pub fn render_with_settings(
    model: &PaintModel,
    which: ShadingModel,
    spp: u32,
    cached: u32,
    settings: RenderSettings,
) -> (ProgressiveRender, Scene) {
    let (scene, render_scene) = shared_car();
    // The scene-box framing these comparisons' statistical controls were sized
    // on: with the car's framing (`default_camera`) the re-shade test's control of
    // a 2 % defect on 5 % of the pixels went undetected. Both images of a
    // comparison share the camera, so which view it is is not what is tested.
    let framed = Framed::new(
        render_scene.clone(),
        Environment::studio(&grid()),
        WIDTH,
        HEIGHT,
    );
    let render = framed.render(shading(scene, model, which), settings, spp, cached);
    (render, scene.clone())
}

/// A scene under an environment, seen by a camera that frames the scene's
/// bounds at `width` × `height`.
pub struct Framed {
    scene: Arc<RenderScene>,
    environment: Environment,
    width: u32,
    height: u32,
}

impl Framed {
    pub fn new(scene: Arc<RenderScene>, environment: Environment, width: u32, height: u32) -> Self {
        Self {
            scene,
            environment,
            width,
            height,
        }
    }

    /// A render with `shading` and `settings`, `spp` samples, the first
    /// `cached` of them recorded.
    pub fn render(
        self,
        shading: Arc<Shading>,
        settings: RenderSettings,
        spp: u32,
        cached: u32,
    ) -> ProgressiveRender {
        let camera = Camera::framing(self.scene.bounds(), self.width, self.height);
        let environment = Arc::new(self.environment);
        let mut render = ProgressiveRender::new(self.scene, environment, shading, camera, settings)
            .expect("render");
        render.set_path_cache_samples(cached);
        render.render_to(spp, 4);
        render
    }
}

/// Independent replicas an image is estimated from (see `image_stats.rs`).
pub const REPLICAS: usize = 8;

/// [`REPLICAS`] fresh renders of `model`, seeds `first_seed` + i, `spp` samples
/// each.
pub fn fresh(model: &PaintModel, which: ShadingModel, first_seed: u64, spp: u32) -> Replicas {
    fresh_with(model, which, first_seed, spp, IntegratorSettings::default())
}

/// [`fresh`] with other integrator settings.
pub fn fresh_with(
    model: &PaintModel,
    which: ShadingModel,
    first_seed: u64,
    spp: u32,
    integrator: IntegratorSettings,
) -> Replicas {
    fresh_replicas(model, which, first_seed, spp, integrator, REPLICAS)
}

/// `count` fresh renders of `model` with `integrator`, seeds `first_seed` + i,
/// `spp` samples each.
pub fn fresh_replicas(
    model: &PaintModel,
    which: ShadingModel,
    first_seed: u64,
    spp: u32,
    integrator: IntegratorSettings,
    count: usize,
) -> Replicas {
    Replicas::collect(WIDTH, HEIGHT, count, |i| {
        let (render, _) = render_with(model, which, first_seed + i as u64, spp, 0, integrator);
        film_image(render.film())
    })
}

/// A pilot for the weights of the tile and image sums: 4 renders of `model` of 16
/// samples, seeds `first_seed` + i (seeds no compared render uses).
pub fn pilot(model: &PaintModel, which: ShadingModel, first_seed: u64) -> Replicas {
    Replicas::collect(WIDTH, HEIGHT, 8, |i| {
        let (render, _) = render(model, which, first_seed + i as u64, 32, 0);
        film_image(render.film())
    })
}

/// The weights of the tile and image sums: from a [`pilot`] of the signal-red
/// car, independent of every image compared.
pub fn weights() -> Weights {
    Weights::from_pilot(&pilot(&red(), ShadingModel::Paint, seed(90_000)))
}

/// The pixels whose chromaticity differs from the backdrop's (the top-left
/// pixel's) by more than 0.02 in xy: the car, coloured by its paint.
pub fn car_mask(image: &Image) -> Vec<bool> {
    let xy = |m: &[f64; 3]| {
        let s = m[0] + m[1] + m[2];
        [m[0] / s, m[1] / s]
    };
    let backdrop = xy(&image[0]);
    image
        .iter()
        .map(|m| {
            let p = xy(m);
            (p[0] - backdrop[0]).hypot(p[1] - backdrop[1]) > 0.02
        })
        .collect()
}

/// The pixels of a `camera` image of `scene` whose centres see one of the
/// scene's paint materials first (`render::pick`): the paint, wherever it is
/// framed, grey or coloured.
pub fn paint_pixels(scene: &RenderScene, camera: &Camera) -> Vec<bool> {
    pixels_showing(scene, camera, |material| {
        scene.paint_materials().contains(&material)
    })
}

/// The pixels of a `camera` image of `scene` whose centres see first a
/// material (by index) for which `shows` holds; the floor and the background
/// are no material.
pub fn pixels_showing(
    scene: &RenderScene,
    camera: &Camera,
    shows: impl Fn(u32) -> bool,
) -> Vec<bool> {
    let (w, h) = (camera.width(), camera.height());
    (0..w * h)
        .map(|p| {
            let (x, y) = ((p % w) as f32 + 0.5, (p / w) as f32 + 0.5);
            pick(scene, camera, x, y).is_some_and(|hit| shows(hit.material))
        })
        .collect()
}

/// The block of the region control on the default car's paint
/// (`image_stats::defect_region_on`), framed as [`render_with`] frames it (the
/// car's bounds) at the size of `a`.
pub fn paint_region(a: &Replicas) -> Vec<bool> {
    let scene = &shared_car().1;
    let camera = Camera::framing(scene.bounds(), a.width, a.height);
    crate::image_stats::defect_region_on(a, &paint_pixels(scene, &camera))
}

/// The CIELAB hue angle (degrees) and chroma of the mean colour of `image` over
/// `mask`, relative to the backdrop's chromaticity at Y = 1.
pub fn hue(image: &Image, mask: &[bool]) -> (f64, f64) {
    use coatlab_core::colour::{Xyz, lab_from_xyz};
    let (mut sum, mut n) = ([0.0; 3], 0.0);
    for (m, _) in image.iter().zip(mask).filter(|(_, inside)| **inside) {
        for c in 0..3 {
            sum[c] += m[c];
        }
        n += 1.0;
    }
    let w = image[0];
    let lab = lab_from_xyz(
        Xyz::new(sum[0] / n, sum[1] / n, sum[2] / n),
        Xyz::new(w[0] / w[1], 1.0, w[2] / w[1]),
    );
    (lab.b.atan2(lab.a).to_degrees(), lab.a.hypot(lab.b))
}
