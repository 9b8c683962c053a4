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
use coatlab_core::render::progressive::{ProgressiveRender, RenderSettings};
use coatlab_core::render::reshade::{ReshadeError, ShadingDifference};
use coatlab_core::scene::Scene;

#[path = "support/image_stats.rs"]
mod image_stats;
use image_stats::{
    Image, Replicas, Weights, assert_agree_with_controls_in, compare, film_image, reshaded_image,
    seed,
};

#[path = "support/car_render.rs"]
mod car_render;
use car_render::{HEIGHT, REPLICAS, WIDTH, paint_region, red};

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

/// Per pixel the samples `r`'s path cache holds.
fn recorded_per_pixel(r: &ProgressiveRender) -> Vec<u32> {
    let film = r.film();
    r.path_cache()
        .recorded_per_pixel(film.width(), film.height())
}

/// The difference Phong makes to `r`'s picture, from all its recorded paths.
fn phong_difference(r: &ProgressiveRender, scene: &Scene) -> ShadingDifference {
    let image = r
        .reshade_recorded(&shading(scene, PHONG))
        .expect("re-shade");
    let recorded = r.path_cache().samples_per_pixel();
    ShadingDifference::of(&image, r.film(), recorded, recorded_per_pixel(r)).expect("same size")
}

fn shading(scene: &Scene, which: ShadingModel) -> Arc<Shading> {
    car_render::shading(scene, &red(), which)
}

/// Per pixel X, Y, Z of `b` − `a`.
fn difference(a: &Image, b: &Image) -> Image {
    a.iter()
        .zip(b)
        .map(|(a, b)| std::array::from_fn(|c| b[c] - a[c]))
        .collect()
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

/// The Phong pane re-shaded from the paint pane's paths is the Phong image:
/// [`REPLICAS`] of it against as many independent Phong renders, X, Y and Z, every
/// control rejected, both while the cache still records every sample and once
/// it stopped growing (control variate); the paint pane itself is rejected.
#[test]
fn the_shared_second_pane_matches_an_independent_render_of_its_model() {
    let weights = car_render::weights();
    let fresh = car_render::fresh(&red(), PHONG, seed(99), 128);
    // Every sample recorded: the paint's paths evaluated with Phong. A recorded
    // path takes one light sample at its first vertex where a fresh render takes
    // two, so sample for sample the re-shade has about 1.75 times a fresh
    // render's variance (measured: as much as a fresh Phong render with one
    // light sample, no more). The re-shades are the noisy side, so they get the
    // samples: at 64 against the fresh 128 they held 5.8 times the comparison's
    // noise and a 2 % bias on 5 % of the pixels went unseen (worst tile ×0.97
    // of its limit); at 128, ×1.7 to ×2.3 at four seed sets, for about a second.
    let all = Replicas::collect(WIDTH, HEIGHT, REPLICAS, |i| {
        let (all, scene) = render(ShadingModel::Paint, seed(7 + i as u64), 128, 256);
        assert_eq!(all.path_cache().samples_per_pixel(), 128);
        assert!(
            all.reshade(&shading(&scene, PHONG)).is_err(),
            "the plain re-shade waits for the cache target"
        );
        reshaded_image(
            &all.reshade_recorded(&shading(&scene, PHONG))
                .expect("re-shade while recording"),
        )
    });
    assert_agree_with_controls_in(&all, &fresh, &weights, "all recorded", paint_region(&all));
    // The cache stopped at 32 of 96 samples: Î_A + mean over 32 of (c_B − c_A).
    // Its noise includes the difference term's over the recorded samples: with
    // 16 recorded the 5 % region control was rejected by ×1.2 to ×1.7 of its
    // limit over three seed sets, with 32 by ×1.4 to ×2.2 over four.
    let mut paint = Vec::new();
    let mut last = None;
    let capped = Replicas::collect(WIDTH, HEIGHT, REPLICAS, |i| {
        let (capped, scene) = render(ShadingModel::Paint, seed(30 + i as u64), 96, 32);
        let shared = capped
            .reshade_recorded(&shading(&scene, PHONG))
            .expect("re-shade");
        paint.push(reshaded_image(
            &capped
                .reshade_recorded(&shading(&scene, ShadingModel::Paint))
                .expect("re-shade"),
        ));
        last = Some((capped, scene));
        reshaded_image(&shared)
    });
    assert_agree_with_controls_in(
        &capped,
        &fresh,
        &weights,
        "32 of 96 recorded",
        paint_region(&capped),
    );
    // Negative control: the paint pane itself does not pass for Phong.
    let paint = Replicas::from_images(WIDTH, HEIGHT, &paint);
    let c = compare(&paint, &fresh, &weights);
    println!("paint for phong: {}", c.summary());
    assert!(c.fails(), "the paint passed for Phong");
    // Half-way through a pass that was not recorded: refused, not wrong.
    let (mut partial, scene) = last.expect("a render");
    partial.set_path_cache_samples(0);
    partial.render_pass(1);
    assert!(matches!(
        partial.reshade_recorded(&shading(&scene, PHONG)),
        Err(ReshadeError::NotReady { .. })
    ));
}

/// The comparison's panes as the engine shows them (`ShadingDifference`):
/// each view's own render (paint and Phong, the same seed, as in the engine)
/// blended with the other's and the paint render's recorded paths re-shaded
/// into Phong, at a fixed sample count (64 spp, 8 recorded), is its own model's
/// image: [`REPLICAS`] of each pane against independent renders of its model,
/// X, Y and Z, every control rejected. With more own samples the second pane
/// leans more on them (it converges to Phong's own render).
#[test]
fn each_combined_pane_is_an_unbiased_image_of_its_own_model() {
    let weights = car_render::weights();
    let panes = |i: u64, spp: u32| {
        let s = seed(500 + i);
        let (a, scene) = render(ShadingModel::Paint, s, spp, 8);
        let (b, _) = render(PHONG, s, spp, 0);
        let difference = phong_difference(&a, &scene);
        [
            difference.combine_first(a.film(), b.film()),
            difference.combine(a.film(), b.film()),
        ]
        .map(|pane| pane.expect("same sizes"))
    };
    let mut own_weights = Vec::new();
    let mut first = Vec::new();
    let second = Replicas::collect(WIDTH, HEIGHT, REPLICAS, |i| {
        let [(a, _), (b, w)] = panes(i as u64, 64);
        own_weights.push(w);
        first.push(reshaded_image(&a));
        reshaded_image(&b)
    });
    let first = Replicas::from_images(WIDTH, HEIGHT, &first);
    let fresh = |which| car_render::fresh(&red(), which, seed(99), 128);
    assert_agree_with_controls_in(
        &second,
        &fresh(PHONG),
        &weights,
        "combined Phong pane",
        paint_region(&second),
    );
    assert_agree_with_controls_in(
        &first,
        &fresh(ShadingModel::Paint),
        &weights,
        "combined paint pane",
        paint_region(&first),
    );
    let early = own_weights.iter().sum::<f64>() / own_weights.len() as f64;
    let [_, (_, late)] = panes(0, 256);
    println!("own weight: {early:.3} at 64 spp, {late:.3} at 256");
    assert!(early > 0.0 && late > early, "{early} then {late}");
}

/// The point of sharing: the difference between the panes has far less noise
/// than the difference between two independent renders with as many samples, in
/// X, Y and Z, and it is the same difference (32 replicas of each, compared like
/// images; a shared Phong pane 1 % brighter, 2 % brighter on 5 %
/// of the pixels, or 2 % off in X or Z alone is rejected).
#[test]
fn shared_samples_leave_only_the_noise_of_the_difference() {
    const SPP: u32 = 16;
    // Replicas of each difference image: the independent one is noisy.
    const K: usize = 16;
    // A design against itself: no difference at all with shared paths; two
    // independent renders differ by their noise.
    let (a, scene) = render(ShadingModel::Paint, seed(1), SPP, SPP);
    let first = a
        .reshade_recorded(&shading(&scene, ShadingModel::Paint))
        .expect("first pane");
    let second = a
        .reshade_recorded(&shading(&scene, ShadingModel::Paint))
        .expect("second pane");
    let shared_same = mean_delta_e(&first.xyz, &second.xyz);
    let (other, _) = render(ShadingModel::Paint, seed(2), SPP, 0);
    let as_f32 = |image: Image| -> Vec<[f32; 3]> {
        image.into_iter().map(|v| v.map(|c| c as f32)).collect()
    };
    let independent_same = mean_delta_e(
        &as_f32(film_image(a.film())),
        &as_f32(film_image(other.film())),
    );
    println!(
        "same design, {SPP} spp: mean ΔE00 shared {shared_same:.2e}, independent {independent_same:.3}"
    );
    assert!(shared_same < 1e-6, "shared: {shared_same}");
    assert!(independent_same > 0.2, "independent: {independent_same}");

    // Paint against Phong: the difference image, shared and independent.
    let mut phong_panes = Vec::new();
    let shared = Replicas::collect(WIDTH, HEIGHT, K, |i| {
        let (r, scene) = render(ShadingModel::Paint, seed(100 + i as u64), SPP, SPP);
        let pa = r
            .reshade_recorded(&shading(&scene, ShadingModel::Paint))
            .expect("paint pane");
        let pb = r
            .reshade_recorded(&shading(&scene, PHONG))
            .expect("phong pane");
        phong_panes.push(reshaded_image(&pb));
        difference(&reshaded_image(&pa), &reshaded_image(&pb))
    });
    // Recorded paths take one light sample at their first vertex, so the
    // independent renders do too: paths of the same estimator, shared or not.
    let one_light = IntegratorSettings {
        first_light_samples: 1,
        ..IntegratorSettings::default()
    };
    let independent_difference = |first_seed: u64, k: usize, spp: u32| {
        let mut phong = Vec::new();
        let d = Replicas::collect(WIDTH, HEIGHT, k, |i| {
            let s = seed(first_seed + 2 * i as u64);
            let (ra, _) = render_with_integrator(ShadingModel::Paint, s, spp, 0, one_light);
            let (rb, _) = render_with_integrator(PHONG, s + 1, spp, 0, one_light);
            phong.push(film_image(rb.film()));
            difference(&film_image(ra.film()), &film_image(rb.film()))
        });
        (d, Replicas::from_images(WIDTH, HEIGHT, &phong))
    };
    let (independent, _) = independent_difference(200, K, SPP);
    let (vs, vi) = (shared.total_variance(), independent.total_variance());
    let mean = |r: &Replicas, c: usize| r.mean.iter().map(|m| m[c]).sum::<f64>();
    for c in 0..3 {
        println!(
            "paint vs phong, {SPP} spp, {}: variance of the difference shared {:.3e}, \
             independent {:.3e}, ratio {:.3}; summed difference {:.3} / {:.3}",
            ["X", "Y", "Z"][c],
            vs[c],
            vi[c],
            vs[c] / vi[c],
            mean(&shared, c),
            mean(&independent, c)
        );
        // Measured ×0.34–0.39 with 8 to 32 replicas (sums of replica variances
        // over the image, with their heavy-tailed pixels): the claim is at most
        // half, what twice the samples would give.
        assert!(
            vs[c] < 0.5 * vi[c],
            "channel {c}: shared {} against independent {}",
            vs[c],
            vi[c]
        );
    }
    // The same difference either way (sharing does not bias the comparison),
    // and a shared Phong pane off like a real defect is caught. The defects are
    // relative to the Phong pane, the noise is the independent difference's:
    // the weights (Phong / variance) from a pilot of both.
    let (pilot_difference, pilot_phong) = independent_difference(90_000, 4, 16);
    let weights = Weights::from_pilot(&Replicas {
        variance: pilot_difference.variance,
        ..pilot_phong
    });
    compare(&shared, &independent, &weights).assert_agree("shared vs independent difference");
    let phong = Replicas::from_images(WIDTH, HEIGHT, &phong_panes);
    for (name, factor) in image_stats::controls(&phong) {
        // The Phong pane times the factor: the difference paint − phong moves by
        // (1 − factor) × phong.
        let moved = shared.shifted(|p, c| (1.0 - factor(p, c)) * phong.mean[p][c]);
        let c = compare(&moved, &independent, &weights);
        println!("  control: phong pane {name}: {}", c.summary());
        assert!(
            c.fails() || name == image_stats::REGION_CONTROL,
            "a phong pane {name} went unnoticed"
        );
    }
}

/// The shared difference keeps refining at the memory of one recording: once a
/// recording is complete the render drops it and records the next samples
/// (`record_next_samples`), and the differences of successive recordings
/// merged (`ShadingDifference::merged`) are the difference of all their
/// samples. Two recordings of 8 samples against one of 16, the same render:
/// the same means (to f32 rounding), variances alike, 16 samples; the second
/// recording's own difference is not the first's (it holds samples 8–15). A
/// recording still in progress is not replaced.
#[test]
fn successive_recordings_merge_into_the_difference_of_all_their_samples() {
    let s = seed(7);
    let (whole, scene) = render(ShadingModel::Paint, s, 16, 16);
    let all = phong_difference(&whole, &scene);

    let (mut rolling, _) = render(ShadingModel::Paint, s, 4, 8);
    assert!(
        !rolling.record_next_samples(),
        "a recording at 4 of its 8 samples was replaced"
    );
    rolling.render_to(8, 4);
    let first = phong_difference(&rolling, &scene);
    assert!(rolling.record_next_samples());
    assert_eq!(rolling.path_cache().samples_per_pixel(), 0);
    assert!(!rolling.path_cache_complete());
    rolling.render_to(16, 4);
    assert_eq!(rolling.path_cache().samples_per_pixel(), 8);
    assert!(rolling.path_cache_complete());
    let second = phong_difference(&rolling, &scene);
    let merged = first.merged(&second).expect("same size");
    assert_eq!(merged.samples(), 16);

    let largest_gap = |a: &ShadingDifference, b: &ShadingDifference| {
        a.mean_xyz()
            .iter()
            .zip(b.mean_xyz())
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs() / (1e-3 + b[c].abs())))
            .fold(0.0f32, f32::max)
    };
    let (merged_gap, halves_gap) = (largest_gap(&merged, &all), largest_gap(&second, &first));
    println!(
        "largest relative gap: merged vs all {merged_gap:.2e}, second vs first {halves_gap:.2e}"
    );
    assert!(
        merged_gap < 1e-4,
        "merged differs from all 16: {merged_gap}"
    );
    assert!(
        halves_gap > 1e-2,
        "the second recording repeats the first's samples"
    );
    let total = |d: &ShadingDifference| {
        d.variance_of_mean_xyz()
            .iter()
            .map(|v| f64::from(v[1]))
            .sum::<f64>()
    };
    let ratio = total(&merged) / total(&all);
    println!("variance of the mean, merged ÷ all: {ratio:.3}");
    assert!(
        (0.7..1.4).contains(&ratio),
        "merged variance ×{ratio} that of all 16"
    );
    let one = total(&first) / total(&all);
    assert!(one > 1.4, "one recording of 8: variance ×{one} that of 16");
}

/// Recordings of passes spread by per-pixel weights (what a comparison's map
/// guidance gives): each holds every sample of its passes, so a pixel's
/// recorded samples are its film's, and the merged differences of two such
/// recordings are the difference of one recording of both halves' passes, to
/// f32 rounding: each pixel's means weighed by its own samples in each (a
/// pixel's share of a pass is drawn afresh every pass, so its two halves hold
/// different numbers of samples).
#[test]
fn recordings_of_weighted_passes_hold_each_pixels_own_samples_and_merge_by_them() {
    let s = seed(11);
    // Mean 1: the left half of the image at 0.3 of an even share, the right at
    // 1.7 (a pass of 4 gives them 1.2 and 6.8 samples a pixel: whole samples
    // drawn by pixel and pass).
    let weights: Vec<f32> = (0..WIDTH * HEIGHT)
        .map(|i| if i % WIDTH < WIDTH / 2 { 0.3 } else { 1.7 })
        .collect();
    let weighted = |recorded: u32| {
        let (mut r, scene) = render(ShadingModel::Paint, s, 0, recorded);
        r.set_pass_weights(Some(weights.clone()));
        (r, scene)
    };
    let (mut whole, scene) = weighted(16);
    whole.render_to(16, 4);
    assert!(whole.path_cache_complete());
    let film = whole.film();
    let film_counts: Vec<u32> = (0..film.height())
        .flat_map(|y| (0..film.width()).map(move |x| film.sample_count(x, y) as u32))
        .collect();
    assert_eq!(recorded_per_pixel(&whole), film_counts);
    let half_mean = |right: bool| {
        let of: Vec<u32> = film_counts
            .iter()
            .enumerate()
            .filter(|&(i, _)| (i as u32 % WIDTH >= WIDTH / 2) == right)
            .map(|(_, &n)| n)
            .collect();
        f64::from(of.iter().sum::<u32>()) / of.len() as f64
    };
    println!(
        "samples a pixel, left {:.1}, right {:.1}",
        half_mean(false),
        half_mean(true)
    );
    assert!(half_mean(true) > 2.0 * half_mean(false));
    let all = phong_difference(&whole, &scene);

    let (mut rolling, _) = weighted(8);
    rolling.render_to(8, 4);
    assert!(rolling.path_cache_complete());
    let first = phong_difference(&rolling, &scene);
    assert!(rolling.record_next_samples(), "weights refused a recording");
    rolling.render_to(16, 4);
    assert!(rolling.path_cache_complete());
    let second = phong_difference(&rolling, &scene);
    assert_ne!(
        first.counts(),
        second.counts(),
        "the halves hold the same counts"
    );
    let merged = first.merged(&second).expect("same size");
    assert_eq!(merged.counts(), all.counts());
    let largest_gap = merged
        .mean_xyz()
        .iter()
        .zip(all.mean_xyz())
        .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs() / (1e-3 + b[c].abs())))
        .fold(0.0f32, f32::max);
    println!("largest relative gap, merged vs one recording: {largest_gap:.2e}");
    assert!(
        largest_gap < 1e-4,
        "merged differs from one recording: {largest_gap}"
    );
}

/// The variances of the panes' difference in X, Y and Z that the map guidance
/// reads (`ShadingDifference::panes_difference_variance_xyz`), each summed over
/// the image, against the spread of that difference over independent
/// replicas: above it, as every variance estimated from a pixel's stratified
/// samples is (tests/render.rs, `film_variance_overstates_the_replica_spread`),
/// and less than three times it. Measured in Y ×2.2; the panes' own variances
/// summed, which leave out that the panes share the difference, give ×6.2,
/// and the shared difference's variance alone ×3.4. Each replica: a paint
/// render recording every sample and a Phong render of its own with the same
/// seed, as the engine's two views are.
#[test]
fn the_panes_difference_variance_follows_the_spread_over_replicas() {
    const SPP: u32 = 16;
    const K: usize = 16;
    let pixels = (WIDTH * HEIGHT) as usize;
    let mut predicted = [0.0; 3];
    let mut differences: Vec<Vec<[f64; 3]>> = Vec::with_capacity(K);
    for i in 0..K {
        let s = seed(300 + i as u64);
        let (a, scene) = render(ShadingModel::Paint, s, SPP, SPP);
        let (b, _) = render(PHONG, s, SPP, 0);
        let d = phong_difference(&a, &scene);
        let (first, _) = d.combine_first(a.film(), b.film()).expect("first pane");
        let (second, _) = d.combine(a.film(), b.film()).expect("second pane");
        let variance = d
            .panes_difference_variance_xyz(a.film(), b.film())
            .expect("same size");
        for (c, sum) in predicted.iter_mut().enumerate() {
            *sum += variance.iter().map(|v| f64::from(v[c])).sum::<f64>() / K as f64;
        }
        differences.push(
            first
                .xyz
                .iter()
                .zip(&second.xyz)
                .map(|(p, q)| std::array::from_fn(|c| f64::from(q[c]) - f64::from(p[c])))
                .collect(),
        );
    }
    for (c, channel) in ["X", "Y", "Z"].into_iter().enumerate() {
        let measured: f64 = (0..pixels)
            .map(|p| {
                let mean = differences.iter().map(|d| d[p][c]).sum::<f64>() / K as f64;
                differences
                    .iter()
                    .map(|d| (d[p][c] - mean).powi(2))
                    .sum::<f64>()
                    / (K - 1) as f64
            })
            .sum();
        let ratio = predicted[c] / measured;
        println!(
            "panes' difference, variance of {channel} summed: predicted {:.3e}, over replicas \
             {measured:.3e}, ratio {ratio:.2}",
            predicted[c]
        );
        assert!(
            (1.0..3.0).contains(&ratio),
            "{channel}: predicted ×{ratio:.2} the replicas' spread"
        );
    }
}

/// A pass cancelled before any tile ran leaves the recorded counts as they
/// were, whether the recording is complete or still taking samples. Tiles of
/// 4 × 4 pixels, so that some see only the backdrop and store no path: their
/// counts must not roll back to before the last recorded pass.
#[test]
fn a_cancelled_pass_leaves_the_recorded_counts_as_they_were() {
    let cancelled = std::sync::atomic::AtomicBool::new(true);
    for (spp, recorded) in [(8, 8), (8, 16)] {
        let settings = RenderSettings {
            tile_size: 4,
            ..RenderSettings::seeded(seed(13))
        };
        let (mut r, _) =
            car_render::render_with_settings(&red(), ShadingModel::Paint, spp, recorded, settings);
        let before = recorded_per_pixel(&r);
        assert!(
            before.iter().all(|&k| k == spp),
            "{spp} spp recorded unevenly"
        );
        assert!(r.render_pass_cancellable(1, &cancelled).is_none());
        assert_eq!(
            recorded_per_pixel(&r),
            before,
            "a cancelled pass changed the counts ({spp} of {recorded} recorded)"
        );
    }
}
