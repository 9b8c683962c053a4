//! Path tracer throughput: one progressive pass (one sample per pixel) of the
//! default car in the studio at 960×540, for the wavelength counts and models a
//! user can choose. Samples per second = 518 400 / the time per pass; the rays per
//! sample are printed once per variant.
//!
//!     cargo bench -p coatlab-core --bench render
//!
//! `RENDER_ONCE=1` renders one pass and exits, for instruction counts (see `once`).

use std::sync::Arc;

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::design::presets;
use coatlab_core::paint::phong::PhongVariant;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::{ProgressiveRender, RenderScene, RenderSettings};
use coatlab_core::scene::car::{CarParameters, generate};
use criterion::{Criterion, Throughput, criterion_group};

const WIDTH: u32 = 960;
const HEIGHT: u32 = 540;

fn render_for(wavelengths: usize, model: ShadingModel) -> ProgressiveRender {
    let grid = WavelengthGrid::visible(wavelengths).expect("grid");
    let design = presets::all().into_iter().next().expect("preset").design;
    let paint = design.model(grid).expect("model");
    let scene = generate(&CarParameters::default());
    let shading = Shading::for_scene(&paint, model, &scene);
    let scene = RenderScene::new(scene).expect("scene");
    let camera = scene.default_camera(WIDTH, HEIGHT);
    ProgressiveRender::new(
        Arc::new(scene),
        Arc::new(Environment::studio(&grid)),
        Arc::new(shading),
        camera,
        RenderSettings::default(),
    )
    .expect("render")
}

fn passes(c: &mut Criterion) {
    let mut group = c.benchmark_group("pass_960x540");
    group.sample_size(10);
    group.throughput(Throughput::Elements(u64::from(WIDTH * HEIGHT)));
    let variants = [
        ("paint/8", 8, ShadingModel::Paint),
        ("paint/16", 16, ShadingModel::Paint),
        ("paint/32", 32, ShadingModel::Paint),
        ("paint/81", 81, ShadingModel::Paint),
        (
            "phong-fit/32",
            32,
            ShadingModel::Phong(PhongVariant::BestFit),
        ),
    ];
    for (name, wavelengths, model) in variants {
        let mut render = render_for(wavelengths, model);
        let first = render.render_pass(1);
        eprintln!(
            "{name}: {:.2} rays per sample, first pass {:.3} M samples/s, {:.2} M rays/s",
            first.rays as f64 / first.samples as f64,
            first.samples_per_second() / 1e6,
            first.rays_per_second() / 1e6
        );
        group.bench_function(name, |b| {
            b.iter(|| {
                // Keep the film from growing without bound: restart now and then.
                if render.samples_per_pixel() > 64 {
                    render.restart();
                }
                render.render_pass(1)
            })
        });
    }
    group.finish();
}

/// Re-shading after a paint edit (ρ × 0.8) from K recorded samples per pixel, and
/// the memory the recording takes.
fn reshading(c: &mut Criterion) {
    let mut group = c.benchmark_group("reshade_960x540");
    group.sample_size(10);
    for (wavelengths, cached) in [(16, 4), (32, 4), (32, 8)] {
        let grid = WavelengthGrid::visible(wavelengths).expect("grid");
        let design = presets::all().into_iter().next().expect("preset").design;
        let paint = design.model(grid).expect("model");
        let scene = generate(&CarParameters::default());
        let mut render = render_for(wavelengths, ShadingModel::Paint);
        render.set_path_cache_samples(cached);
        let record_start = std::time::Instant::now();
        while render.samples_per_pixel() < cached {
            render.render_pass(1);
        }
        let record_seconds = record_start.elapsed().as_secs_f64();
        let cache = render.path_cache();
        eprintln!(
            "{wavelengths} wavelengths, {cached} recorded spp: {} paths, {} vertices, {:.0} MB, recording passes {:.2} s",
            cache.path_count(),
            cache.vertex_count(),
            cache.memory_bytes() as f64 / 1e6,
            record_seconds
        );
        let mut edited = paint.clone();
        edited
            .set_albedo(paint.albedo().iter().map(|r| r * 0.8).collect())
            .expect("albedo");
        let shading = Shading::for_scene(&edited, ShadingModel::Paint, &scene);
        group.bench_function(format!("{wavelengths}wl/{cached}spp"), |b| {
            b.iter(|| render.reshade(&shading).expect("reshade"))
        });
    }
    group.finish();
}

criterion_group!(benches, passes, reshading);

/// `RENDER_ONCE=1`: one pass (one sample per pixel) of the 32-wavelength paint at
/// 960×540 on this thread's pool, then exits: for instruction counts under
/// cachegrind (with `RAYON_NUM_THREADS=1`).
fn once() {
    let mut render = render_for(32, ShadingModel::Paint);
    let pass = render.render_pass(1);
    println!("{} samples, {} rays", pass.samples, pass.rays);
}

fn main() {
    if std::env::var_os("RENDER_ONCE").is_some() {
        once();
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
