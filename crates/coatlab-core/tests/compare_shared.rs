//! The comparison view's shared samples (`ProgressiveRender::reshade_recorded`):
//! the second pane re-shaded from the first pane's recorded paths is the second
//! model's image (statistically), and the difference between the panes carries
//! far less noise than the difference of two independent renders.

use std::sync::Arc;

use coatlab_core::colour::{Xyz, ciede2000};
use coatlab_core::paint::phong::PhongVariant;
use coatlab_core::render::film::{DisplaySettings, display_lab_of_xyz};
use coatlab_core::render::integrator::IntegratorSettings;
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::ProgressiveRender;
use coatlab_core::render::reshade::ReshadeError;
use coatlab_core::scene::Scene;

#[path = "support/car_render.rs"]
mod car_render;
use car_render::{film_estimate, red, z_test};

const PHONG: ShadingModel = ShadingModel::Phong(PhongVariant::BestFit);

/// The default car in the studio, signal red, shaded by `which`.
fn render(which: ShadingModel, seed: u64, spp: u32, recorded: u32) -> (ProgressiveRender, Scene) {
    car_render::render(&red(), which, seed, spp, recorded)
}

fn render_with_integrator(
    which: ShadingModel,
    seed: u64,
    spp: u32,
    recorded: u32,
    integrator: IntegratorSettings,
) -> (ProgressiveRender, Scene) {
    car_render::render_with(&red(), which, seed, spp, recorded, integrator)
}

fn shading(scene: &Scene, which: ShadingModel) -> Arc<Shading> {
    car_render::shading(scene, &red(), which)
}

/// Per-pixel Y of `b` − `a`.
fn difference_y(a: &[[f32; 3]], b: &[[f32; 3]]) -> Vec<f64> {
    a.iter()
        .zip(b)
        .map(|(a, b)| f64::from(b[1]) - f64::from(a[1]))
        .collect()
}

/// The noise of a difference image, from two replicas with other seeds: the mean
/// over pixels of (D₁ − D₂)² / 2, the variance of one replica's difference.
fn replica_variance(d1: &[f64], d2: &[f64]) -> f64 {
    d1.iter()
        .zip(d2)
        .map(|(a, b)| (a - b).powi(2) / 2.0)
        .sum::<f64>()
        / d1.len() as f64
}

fn mean_delta_e(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let display = DisplaySettings::default();
    let lab = |v: [f32; 3]| {
        display_lab_of_xyz(
            Xyz::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2])),
            &display,
        )
    };
    a.iter()
        .zip(b)
        .map(|(&a, &b)| ciede2000(lab(a), lab(b)))
        .sum::<f64>()
        / a.len() as f64
}

/// The Phong pane re-shaded from the paint pane's paths is the Phong image: a
/// Z-test against an independent converged Phong render, both while the cache
/// still records every sample and once it stopped growing (control variate).
#[test]
fn the_shared_second_pane_matches_an_independent_render_of_its_model() {
    let (fresh, _) = render(PHONG, 99, 128, 0);
    // Every sample recorded: the paint's paths evaluated with Phong.
    let (all, scene) = render(ShadingModel::Paint, 7, 32, 64);
    assert_eq!(all.path_cache().samples_per_pixel(), 32);
    assert!(
        all.reshade(&shading(&scene, PHONG)).is_err(),
        "the plain re-shade waits for the cache target"
    );
    let shared = all
        .reshade_recorded(&shading(&scene, PHONG))
        .expect("re-shade while recording");
    let (outliers, total_z) = z_test(&shared, &fresh);
    println!(
        "all recorded: beyond 4σ {:.2} %, total Z {total_z:.2}",
        outliers * 100.0
    );
    assert!(outliers < 0.01 && total_z.abs() < 4.0);
    // The cache stopped at 8 of 48 samples: Î_A + mean over 8 of (c_B − c_A).
    let (capped, scene) = render(ShadingModel::Paint, 11, 48, 8);
    let shared = capped
        .reshade_recorded(&shading(&scene, PHONG))
        .expect("re-shade");
    let (outliers, total_z) = z_test(&shared, &fresh);
    println!(
        "8 of 48 recorded: beyond 4σ {:.2} %, total Z {total_z:.2}",
        outliers * 100.0
    );
    assert!(outliers < 0.01 && total_z.abs() < 4.0);
    // Negative control: the paint pane itself does not pass for Phong.
    let paint = capped
        .reshade_recorded(&shading(&scene, ShadingModel::Paint))
        .expect("re-shade");
    let (_, total_z) = z_test(&paint, &fresh);
    assert!(
        total_z.abs() > 5.0,
        "the paint passed for Phong: Z {total_z}"
    );
    // Half-way through a pass that was not recorded: refused, not wrong.
    let mut partial = capped;
    partial.set_path_cache_samples(0);
    partial.render_pass(1);
    assert!(matches!(
        partial.reshade_recorded(&shading(&scene, PHONG)),
        Err(ReshadeError::NotReady { .. })
    ));
}

/// The point of sharing: the difference between the panes has far less noise
/// than the difference between two independent renders with as many samples.
#[test]
fn shared_samples_leave_only_the_noise_of_the_difference() {
    const SPP: u32 = 16;
    // A design against itself: no difference at all with shared paths; two
    // independent renders differ by their noise.
    let (a, scene) = render(ShadingModel::Paint, 1, SPP, SPP);
    let first = a
        .reshade_recorded(&shading(&scene, ShadingModel::Paint))
        .expect("first pane");
    let second = a
        .reshade_recorded(&shading(&scene, ShadingModel::Paint))
        .expect("second pane");
    let shared_same = mean_delta_e(&first.xyz, &second.xyz);
    let (other, _) = render(ShadingModel::Paint, 2, SPP, 0);
    let independent_same = mean_delta_e(&film_estimate(&a).xyz, &film_estimate(&other).xyz);
    println!(
        "same design, {SPP} spp: mean ΔE00 shared {shared_same:.2e}, independent {independent_same:.3}"
    );
    assert!(shared_same < 1e-6, "shared: {shared_same}");
    assert!(independent_same > 0.2, "independent: {independent_same}");

    // Paint against Phong: the noise of the difference image, each way, from
    // two replicas (seeds 1, 2 shared; 3–6 independent).
    let shared_difference = |seed: u64| {
        let (r, scene) = render(ShadingModel::Paint, seed, SPP, SPP);
        let pa = r
            .reshade_recorded(&shading(&scene, ShadingModel::Paint))
            .expect("paint pane");
        let pb = r
            .reshade_recorded(&shading(&scene, PHONG))
            .expect("phong pane");
        difference_y(&pa.xyz, &pb.xyz)
    };
    // Recorded paths take one light sample at their first vertex, so the
    // independent renders do too: paths of the same estimator, shared or not.
    let one_light = IntegratorSettings {
        first_light_samples: 1,
        ..IntegratorSettings::default()
    };
    let independent_difference = |seed: u64| {
        let (ra, _) = render_with_integrator(ShadingModel::Paint, seed, SPP, 0, one_light);
        let (rb, _) = render_with_integrator(PHONG, seed + 1, SPP, 0, one_light);
        difference_y(&film_estimate(&ra).xyz, &film_estimate(&rb).xyz)
    };
    let (s1, s2) = (shared_difference(1), shared_difference(2));
    let (i1, i2) = (independent_difference(3), independent_difference(5));
    let shared = replica_variance(&s1, &s2);
    let independent = replica_variance(&i1, &i2);
    // The models do differ: the mean difference is far from zero in both.
    let mean = |d: &[f64]| d.iter().sum::<f64>() / d.len() as f64;
    println!(
        "paint vs phong, {SPP} spp: variance of the Y difference shared {shared:.3e}, \
         independent {independent:.3e}, ratio {:.3}; mean difference {:.4} / {:.4}",
        shared / independent,
        mean(&s1),
        mean(&i1)
    );
    assert!(
        shared < 0.35 * independent,
        "shared {shared} against independent {independent}"
    );
    // Same mean difference either way (sharing does not bias the comparison).
    let (ms, mi) = (mean(&s1) + mean(&s2), mean(&i1) + mean(&i2));
    let se = ((shared + independent) / s1.len() as f64).sqrt();
    assert!(
        ((ms - mi) / 2.0).abs() < 5.0 * se + 1e-3 * mi.abs(),
        "{ms} vs {mi}"
    );
}
