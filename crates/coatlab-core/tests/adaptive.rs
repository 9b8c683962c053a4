//! Adaptive sampling (`render::adaptive`) in a whole render: deterministic for a
//! seed on any thread count, samples go to the noisy pixels and every pixel keeps
//! its floor, and the image is the uniform render's within the noise (X, Y and Z
//! of replicas against uniform renders: pixels, tiles and the image total,
//! `support/image_stats.rs`).
//!
//! The scene is the built-in car with a mirror-gloss grey coat in the studio: the
//! coat reflects the softboxes onto the floor, the caustics adaptive sampling is
//! for.
//!
//! The same for the passes a comparison rendered apart spreads by its ΔE00 map
//! (`engine::guide`): two views, the mirror coat and a glossy one, their passes
//! spread by the weights of their map as the live engine does.

use std::sync::Arc;

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::engine::guide::map_guided_weights;
use coatlab_core::paint::gloss::GlossExponent;
use coatlab_core::paint::model::{GlossSetting, PaintModel, PaintParams};
use coatlab_core::render::adaptive::AdaptiveSampling;
use coatlab_core::render::camera::Camera;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::{DisplaySettings, Film};
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::{ProgressiveRender, RenderScene, RenderSettings};
use coatlab_core::scene::car::{CarParameters, generate};

#[path = "support/image_stats.rs"]
mod image_stats;
use image_stats::{Replicas, Weights, assert_agree_with_controls, film_image, seed};

const WIDTH: u32 = 64;
const HEIGHT: u32 = 36;

fn mirror_car(grid: WavelengthGrid) -> (Arc<RenderScene>, Shading, Camera) {
    coated_car(grid, GlossExponent::Mirror)
}

fn coated_car(grid: WavelengthGrid, gloss: GlossExponent) -> (Arc<RenderScene>, Shading, Camera) {
    let model = PaintModel::new(PaintParams::grey(
        grid,
        0.3,
        1.5,
        0.0,
        40.0,
        GlossSetting::Exponent(gloss),
    ))
    .expect("model");
    let scene = generate(&CarParameters::default());
    let camera = Camera::framing(scene.mesh.bounds().expect("bounds"), WIDTH, HEIGHT);
    let shading = Shading::for_scene(&model, ShadingModel::Paint, &scene);
    let scene = RenderScene::new(scene).expect("scene");
    (Arc::new(scene), shading, camera)
}

/// Renders `spp` samples per pixel (on average) in passes of 8.
fn render(seed: u64, adaptive: Option<AdaptiveSampling>, spp: u32, tile_size: u32) -> Film {
    let grid = WavelengthGrid::visible(8).expect("grid");
    let (scene, shading, camera) = mirror_car(grid);
    let mut render = ProgressiveRender::new(
        scene,
        Arc::new(Environment::studio(&grid)),
        Arc::new(shading),
        camera,
        RenderSettings {
            seed,
            tile_size,
            adaptive,
            ..RenderSettings::default()
        },
    )
    .expect("render");
    render.render_to(spp, 8);
    assert_eq!(render.samples_per_pixel(), spp);
    let total: u64 = (0..HEIGHT)
        .flat_map(|y| (0..WIDTH).map(move |x| (x, y)))
        .map(|(x, y)| render.film().sample_count(x, y))
        .sum();
    assert_eq!(
        total,
        u64::from(spp) * u64::from(WIDTH * HEIGHT),
        "a pass takes exactly its samples per pixel over the image"
    );
    render.film().clone()
}

fn adaptive() -> Option<AdaptiveSampling> {
    Some(AdaptiveSampling::default())
}

/// The same seed gives the same adaptive image, sample counts included, on one
/// thread and on three (and with other tiles).
#[test]
fn an_adaptive_render_is_the_same_on_any_number_of_threads() {
    let run = |threads: usize, tile: u32| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| render(5, adaptive(), 24, tile))
    };
    let (one, three) = (run(1, 8), run(3, 13));
    let mut uneven = false;
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            assert_eq!(one.sample_count(x, y), three.sample_count(x, y));
            assert_eq!(one.mean_xyz(x, y), three.mean_xyz(x, y), "pixel {x},{y}");
            assert_eq!(
                one.variance_of_mean_xyz(x, y),
                three.variance_of_mean_xyz(x, y)
            );
            uneven |= one.sample_count(x, y) != 24;
        }
    }
    assert!(
        uneven,
        "the adaptive passes gave every pixel the same samples"
    );
}

/// Samples go where the noise is: ranked by the per-sample noise of an independent
/// uniform render (its 3 × 3 maximum, as the allocation sees it), the noisiest tenth
/// of the pixels gets at least twice the samples of the quieter half; and no pixel
/// gets fewer than its uniform samples plus the floor of every adaptive pass.
#[test]
fn samples_go_to_the_noisy_pixels_and_every_pixel_keeps_its_floor() {
    let settings = AdaptiveSampling::default();
    let film = render(7, Some(settings), 64, 32);
    // Passes of 8: the first is uniform (8 ≥ the uniform samples), then 7 adaptive.
    let uniform = 8u64;
    let adaptive_passes = 7u64;
    let floor_share = (8.0 * settings.floor / (1.0 + settings.floor)).floor() as u64;
    let least = (0..HEIGHT)
        .flat_map(|y| (0..WIDTH).map(move |x| (x, y)))
        .map(|(x, y)| film.sample_count(x, y))
        .min()
        .expect("pixels");
    println!("least samples of a pixel: {least} (floor {floor_share} a pass)");
    assert!(least >= uniform + adaptive_passes * floor_share);

    let reference = render(8, None, 64, 32);
    let noise = reference.sample_delta_e(&DisplaySettings::default());
    let (w, h) = (WIDTH as usize, HEIGHT as usize);
    let mut ranked: Vec<(f32, u64)> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let mut m = 0.0f32;
            for yy in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                for xx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                    m = m.max(noise[yy * w + xx]);
                }
            }
            (m, film.sample_count(x as u32, y as u32))
        })
        .collect();
    ranked.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mean = |s: &[(f32, u64)]| s.iter().map(|&(_, c)| c as f64).sum::<f64>() / s.len() as f64;
    let (noisiest, quietest) = (mean(&ranked[..w * h / 10]), mean(&ranked[w * h / 2..]));
    println!("mean samples: noisiest tenth {noisiest:.1}, quieter half {quietest:.1}");
    assert!(
        noisiest > 2.0 * quietest,
        "noisiest tenth {noisiest:.1} against quieter half {quietest:.1}"
    );
}

/// The adaptive image estimates the uniform one: 16 adaptive renders of 64
/// samples against 8 uniform renders of 128, X, Y and Z: pixels, tiles and the
/// image total within the noise, every control rejected.
#[test]
fn an_adaptive_render_is_unbiased_against_a_uniform_one() {
    let weights = Weights::from_pilot(&Replicas::collect(WIDTH, HEIGHT, 4, |i| {
        film_image(&render(seed(90_000 + i as u64), None, 16, 32))
    }));
    // Adaptive renders put fewer samples where the noise is low, where the
    // weights look: twice the replicas.
    let a = Replicas::collect(WIDTH, HEIGHT, 16, |i| {
        film_image(&render(seed(21 + i as u64), adaptive(), 64, 32))
    });
    let u = Replicas::collect(WIDTH, HEIGHT, 8, |i| {
        film_image(&render(seed(40 + i as u64), None, 128, 32))
    });
    assert_agree_with_controls(&a, &u, &weights, "adaptive vs uniform");
}

/// Two views rendered apart, the mirror coat and a glossy one (exponent 400), in
/// passes of 8 spread by their map's weights from 8 samples on, made again when
/// the samples have grown by half (as the live engine does); `spp` samples per
/// pixel on average. The first view's film, then the second's.
fn render_guided(seed: u64, spp: u32, tile_size: u32) -> [Film; 2] {
    let grid = WavelengthGrid::visible(8).expect("grid");
    let environment = Arc::new(Environment::studio(&grid));
    let settings = RenderSettings {
        seed,
        tile_size,
        ..RenderSettings::default()
    };
    let mut views = [GlossExponent::Mirror, GlossExponent::Finite(400.0)].map(|gloss| {
        let (scene, shading, camera) = coated_car(grid, gloss);
        ProgressiveRender::new(
            scene,
            environment.clone(),
            Arc::new(shading),
            camera,
            settings,
        )
        .expect("render")
    });
    let mut guided_at = None;
    while views[0].samples_per_pixel() < spp {
        let done = views[0].samples_per_pixel();
        if done >= 8 && guided_at.is_none_or(|at: u32| 2 * done >= 3 * at) {
            let weights =
                map_guided_weights(views[0].film(), views[1].film(), &DisplaySettings::MEASURED)
                    .expect("weights");
            for view in &mut views {
                view.set_pass_weights(Some(weights.clone()));
            }
            guided_at = Some(done);
        }
        for view in &mut views {
            view.render_pass(8);
        }
    }
    views.map(|view| view.film().clone())
}

fn counts(film: &Film) -> Vec<u64> {
    (0..HEIGHT)
        .flat_map(|y| (0..WIDTH).map(move |x| (x, y)))
        .map(|(x, y)| film.sample_count(x, y))
        .collect()
}

/// Guided passes: the same images and counts on one thread and on three, the
/// two views' counts equal and uneven, and each pass exactly its samples.
#[test]
fn map_guided_views_are_the_same_on_any_number_of_threads_and_take_the_same_counts() {
    let run = |threads: usize, tile: u32| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| render_guided(5, 48, tile))
    };
    let (one, three) = (run(1, 8), run(3, 13));
    for (a, b) in one.iter().zip(&three) {
        assert_eq!(counts(a), counts(b));
        for y in 0..HEIGHT {
            for x in 0..WIDTH {
                assert_eq!(a.mean_xyz(x, y), b.mean_xyz(x, y), "pixel {x},{y}");
            }
        }
    }
    let (first, second) = (counts(&one[0]), counts(&one[1]));
    assert_eq!(first, second, "the two views took different counts");
    assert_eq!(first.iter().sum::<u64>(), 48 * u64::from(WIDTH * HEIGHT));
    let most = first.iter().copied().max().unwrap_or(0);
    assert!(most >= 96, "no pixel got twice the mean: at most {most}");
}

/// Each guided view estimates its uniform render: 16 guided renders of 64
/// samples against 8 uniform ones of 128, X, Y and Z: pixels, tiles and the image
/// total within the noise, every control rejected.
#[test]
fn map_guided_views_are_unbiased_against_uniform_ones() {
    let weights = Weights::from_pilot(&Replicas::collect(WIDTH, HEIGHT, 4, |i| {
        film_image(&render(seed(91_000 + i as u64), None, 16, 32))
    }));
    let guided: Vec<[Film; 2]> = (0..16)
        .map(|i| render_guided(seed(61 + i as u64), 64, 32))
        .collect();
    let first = Replicas::collect(WIDTH, HEIGHT, 16, |i| film_image(&guided[i][0]));
    let uniform = Replicas::collect(WIDTH, HEIGHT, 8, |i| {
        film_image(&render(seed(40 + i as u64), None, 128, 32))
    });
    assert_agree_with_controls(&first, &uniform, &weights, "guided mirror vs uniform");
}
