//! Re-shading from recorded paths (`render::reshade`): exact when nothing changed,
//! and statistically the same image as a fresh render after an edit.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use coatlab_core::design::presets;
use coatlab_core::paint::gloss::GlossExponent;
use coatlab_core::paint::model::{GlossSetting, PaintModel, PaintParams};
use coatlab_core::paint::phong::PhongVariant;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::{ProgressiveRender, RenderScene, RenderSettings};
use coatlab_core::render::reshade::{ReshadeError, Reshaded};
use coatlab_core::scene::Scene;
use coatlab_core::scene::car::{CarParameters, generate};
use coatlab_core::spectrum::WavelengthGrid;

const WIDTH: u32 = 64;
const HEIGHT: u32 = 36;

fn grid() -> WavelengthGrid {
    WavelengthGrid::visible(16).expect("grid")
}

fn red() -> PaintModel {
    let design = presets::all().into_iter().next().expect("preset").design;
    design.model(grid()).expect("model")
}

fn shading(scene: &Scene, model: &PaintModel, which: ShadingModel) -> Arc<Shading> {
    Arc::new(Shading::new(
        model,
        which,
        &scene.materials,
        &scene.paint_materials,
    ))
}

/// A render of the default car in the studio with `model`, `spp` samples, the
/// first `cached` of them recorded.
fn render(
    model: &PaintModel,
    which: ShadingModel,
    seed: u64,
    spp: u32,
    cached: u32,
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

/// Z-scores of Y between a re-shaded image and a fresh render: (share beyond 4σ,
/// total Z).
fn compare(reshaded: &Reshaded, fresh: &ProgressiveRender) -> (f64, f64) {
    let film = fresh.film();
    let (mut outliers, mut count, mut diff, mut var) = (0usize, 0usize, 0.0, 0.0);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let i = (y * WIDTH + x) as usize;
            let a = f64::from(reshaded.xyz[i][1]);
            let b = film.mean_xyz(x, y).y;
            let v = f64::from(reshaded.variance_y[i]) + film.variance_of_mean_xyz(x, y)[1];
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

#[test]
fn re_shading_with_the_same_paint_gives_the_image_back() {
    let model = red();
    let (render, scene) = render(&model, ShadingModel::Paint, 3, 12, 8);
    let cache = render.path_cache();
    assert_eq!(cache.samples_per_pixel(), 8);
    assert!(cache.path_count() > 1000, "{} paths", cache.path_count());
    println!(
        "cache: {} paths, {} vertices, {:.1} MB for {WIDTH}x{HEIGHT} at 8 spp",
        cache.path_count(),
        cache.vertex_count(),
        cache.memory_bytes() as f64 / 1e6
    );
    let same = render
        .reshade(&shading(&scene, &model, ShadingModel::Paint))
        .expect("reshade");
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let m = render.film().mean_xyz(x, y);
            let r = same.xyz[(y * WIDTH + x) as usize];
            for (a, b) in [m.x, m.y, m.z].iter().zip(r) {
                assert!(
                    (a - f64::from(b)).abs() <= 1e-4 * a.abs().max(0.01),
                    "pixel {x},{y}: {a} vs {b}"
                );
            }
        }
    }
}

/// Edits of ρ, k, h and n, and the switch to Phong: the re-shaded image agrees
/// with a fresh render of the edited design (another seed) within the noise of both.
#[test]
fn re_shaded_edits_match_fresh_renders() {
    let base = red();
    let (render, scene) = render(&base, ShadingModel::Paint, 5, 64, 16);
    let grid = grid();
    let mut edits: Vec<(&str, PaintModel)> = Vec::new();
    let mut m = base.clone();
    m.set_albedo(base.albedo().iter().map(|r| r * 0.5).collect())
        .expect("albedo");
    edits.push(("rho x0.5", m));
    let mut m = base.clone();
    m.set_absorption(vec![0.02; grid.len()])
        .expect("absorption");
    edits.push(("k 0.02/um", m));
    let mut m = base.clone();
    m.set_thickness(80.0).expect("thickness");
    edits.push(("h 80 um", m));
    let mut m = base.clone();
    let n: Vec<f64> = base.refractive_index().iter().map(|n| n + 0.1).collect();
    let n_gloss = base.index_at_gloss_wavelength() + 0.1;
    m.set_refractive_index(n, n_gloss).expect("index");
    edits.push(("n +0.1", m));
    for (name, edited) in &edits {
        let reshaded = render
            .reshade(&shading(&scene, edited, ShadingModel::Paint))
            .expect("reshade");
        let (fresh, _) = self::render(edited, ShadingModel::Paint, 99, 64, 0);
        let (outliers, total_z) = compare(&reshaded, &fresh);
        println!(
            "{name}: beyond 4σ {:.2} %, total Z {total_z:.2}",
            outliers * 100.0
        );
        assert!(
            outliers < 0.01,
            "{name}: {:.2} % beyond 4σ",
            outliers * 100.0
        );
        assert!(total_z.abs() < 4.0, "{name}: total Z {total_z}");
    }
    // Phong from the paint's paths.
    let phong = ShadingModel::Phong(PhongVariant::BestFit);
    let reshaded = render
        .reshade(&shading(&scene, &base, phong))
        .expect("reshade");
    let (fresh, _) = self::render(&base, phong, 99, 64, 0);
    let (outliers, total_z) = compare(&reshaded, &fresh);
    println!(
        "phong fit: beyond 4σ {:.2} %, total Z {total_z:.2}",
        outliers * 100.0
    );
    assert!(outliers < 0.01 && total_z.abs() < 4.0);
    // Negative control: the unedited image is not taken for the ρ × 0.5 one.
    let unedited = render
        .reshade(&shading(&scene, &base, ShadingModel::Paint))
        .expect("reshade");
    let (fresh, _) = self::render(&edits[0].1, ShadingModel::Paint, 99, 64, 0);
    let (_, total_z) = compare(&unedited, &fresh);
    assert!(
        total_z.abs() > 5.0,
        "an unedited image passed for the edit: Z {total_z}"
    );
}

#[test]
fn re_shading_refuses_what_it_cannot_do() {
    let mirror = PaintModel::new(PaintParams::grey(
        grid(),
        0.5,
        1.5,
        0.01,
        40.0,
        GlossSetting::Exponent(GlossExponent::Mirror),
    ))
    .expect("model");
    let (mut render, scene) = render(&mirror, ShadingModel::Paint, 1, 2, 4);
    // Not all 4 samples recorded yet.
    let err = render
        .reshade(&shading(&scene, &mirror, ShadingModel::Paint))
        .unwrap_err();
    assert_eq!(
        err,
        ReshadeError::NotReady {
            recorded: 2,
            wanted: 4
        }
    );
    render.render_pass(2);
    // A recorded mirror bounce cannot be re-weighted for a finite lobe.
    let mut glossy = mirror.clone();
    glossy
        .set_gloss(GlossSetting::Exponent(GlossExponent::Finite(500.0)))
        .expect("gloss");
    let err = render
        .reshade(&shading(&scene, &glossy, ShadingModel::Paint))
        .unwrap_err();
    assert_eq!(err, ReshadeError::DeltaChanged);
    // A cancelled pass leaves the cache as it was.
    render.set_path_cache_samples(4);
    render.render_pass(1);
    let before = render.path_cache().path_count();
    let cancel = AtomicBool::new(true);
    assert!(render.render_pass_cancellable(1, &cancel).is_none());
    assert_eq!(render.path_cache().path_count(), before);
    assert_eq!(render.path_cache().samples_per_pixel(), 1);
}
