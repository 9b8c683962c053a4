//! The default car in the studio at 64×36 with the signal-red preset, rendered
//! with part of its paths recorded, and the Z-test of an estimate against a
//! film: shared by the re-shading and the shared-comparison tests.
#![allow(dead_code)] // each test crate uses its own subset

use std::sync::Arc;

use coatlab_core::design::presets;
use coatlab_core::paint::model::PaintModel;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::integrator::IntegratorSettings;
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::{ProgressiveRender, RenderScene, RenderSettings};
use coatlab_core::render::reshade::Reshaded;
use coatlab_core::scene::Scene;
use coatlab_core::scene::car::{CarParameters, generate};
use coatlab_core::spectrum::WavelengthGrid;

pub const WIDTH: u32 = 64;
pub const HEIGHT: u32 = 36;

pub fn grid() -> WavelengthGrid {
    WavelengthGrid::visible(16).expect("grid")
}

/// The first preset (signal red) on [`grid`].
pub fn red() -> PaintModel {
    let design = presets::all().into_iter().next().expect("preset").design;
    design.model(grid()).expect("model")
}

pub fn shading(scene: &Scene, model: &PaintModel, which: ShadingModel) -> Arc<Shading> {
    Arc::new(Shading::new(
        model,
        which,
        &scene.materials,
        &scene.paint_materials,
    ))
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
    let scene = generate(&CarParameters::default());
    let render_scene = RenderScene::new(scene.clone()).expect("scene");
    let camera = render_scene.default_camera(WIDTH, HEIGHT);
    let mut render = ProgressiveRender::new(
        Arc::new(render_scene),
        Arc::new(Environment::studio(&grid())),
        shading(&scene, model, which),
        camera,
        RenderSettings {
            seed,
            integrator,
            ..RenderSettings::default()
        },
    )
    .expect("render");
    render.set_path_cache_samples(cached);
    while render.samples_per_pixel() < spp {
        render.render_pass(4.min(spp - render.samples_per_pixel()));
    }
    (render, scene)
}

/// Z-scores of Y between an estimate (mean XYZ and variance of Y per pixel) and an
/// independent render's film: (share of pixels beyond 4σ, total Z over the image).
pub fn z_test(estimate: &Reshaded, fresh: &ProgressiveRender) -> (f64, f64) {
    let film = fresh.film();
    let (mut outliers, mut count, mut diff, mut var) = (0usize, 0usize, 0.0, 0.0);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let i = (y * WIDTH + x) as usize;
            let a = f64::from(estimate.xyz[i][1]);
            let b = film.mean_xyz(x, y).y;
            let v = f64::from(estimate.variance_y[i]) + film.variance_of_mean_xyz(x, y)[1];
            count += 1;
            if v <= 0.0 {
                outliers += usize::from((a - b).abs() > 1e-5 * b.abs().max(1.0));
                continue;
            }
            outliers += usize::from(((a - b) / v.sqrt()).abs() > 4.0);
            diff += a - b;
            var += v;
        }
    }
    (outliers as f64 / count as f64, diff / var.sqrt())
}

/// The current film of a render as an estimate, for [`z_test`].
pub fn film_estimate(render: &ProgressiveRender) -> Reshaded {
    let film = render.film();
    let mut xyz = Vec::new();
    let mut variance_y = Vec::new();
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let m = film.mean_xyz(x, y);
            xyz.push([m.x as f32, m.y as f32, m.z as f32]);
            variance_y.push(film.variance_of_mean_xyz(x, y)[1] as f32);
        }
    }
    Reshaded {
        width: WIDTH,
        height: HEIGHT,
        xyz,
        variance_y,
    }
}
