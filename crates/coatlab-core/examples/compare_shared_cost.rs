//! What the comparison view's shared samples cost at the preview's largest size
//! (640×400, 32 wavelengths, the default car in the studio): the recording's share
//! of 16 passes, the path cache's memory at 16 recorded samples per pixel, and one
//! refresh of both panes (two replays: paint, and Phong best fit). Figures in
//! `docs/rendering.md`, "Comparison panes from one set of paths".
//!
//! `cargo run --release -p coatlab-core --example compare_shared_cost`

use std::sync::Arc;
use std::time::Instant;

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::design::presets;
use coatlab_core::paint::phong::PhongVariant;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::{ProgressiveRender, RenderScene, RenderSettings};
use coatlab_core::scene::car::{CarParameters, generate};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let grid = WavelengthGrid::visible(32)?;
    let scene = generate(&CarParameters::default());
    let design = presets::all()
        .into_iter()
        .next()
        .ok_or("no preset designs")?
        .design;
    let model = design.model(grid)?;
    let shading = |which| Arc::new(Shading::for_scene(&model, which, &scene));
    let render_scene = Arc::new(RenderScene::new(scene.clone())?);
    let camera = render_scene.default_camera(640, 400);
    let mut render = ProgressiveRender::new(
        render_scene,
        Arc::new(Environment::studio(&grid)),
        shading(ShadingModel::Paint),
        camera,
        RenderSettings::default(),
    )?;
    let phong = shading(ShadingModel::Phong(PhongVariant::BestFit));
    for recorded in [0u32, 16] {
        render.set_path_cache_samples(recorded);
        let start = Instant::now();
        for _ in 0..16 {
            render.render_pass(1);
        }
        println!(
            "16 passes of 1 spp, {recorded} recorded: {:.2} s wall",
            start.elapsed().as_secs_f64()
        );
    }
    let cache = render.path_cache();
    println!(
        "path cache: {} spp recorded, {:.1} MB, {} paths",
        cache.samples_per_pixel(),
        cache.memory_bytes() as f64 / 1e6,
        cache.path_count()
    );
    for _ in 0..3 {
        let start = Instant::now();
        let first = render.reshade_recorded(render.shading())?;
        let second = render.reshade_recorded(&phong)?;
        println!(
            "refresh of both panes ({}×{}, two replays): {:.3} s wall",
            first.width,
            second.height,
            start.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
