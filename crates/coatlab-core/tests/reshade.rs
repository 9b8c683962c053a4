//! Re-shading from recorded paths (`render::reshade`): exact when nothing changed,
//! and statistically the same image as a fresh render after an edit.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use coatlab_core::design::presets;
use coatlab_core::paint::gloss::GlossExponent;
use coatlab_core::paint::model::{GlossSetting, PaintModel, PaintParams};
use coatlab_core::paint::phong::PhongVariant;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::integrator::IntegratorSettings;
use coatlab_core::render::material::ShadingModel;
use coatlab_core::render::progressive::{
    EditOutcome, FRESH_ONLY_WEIGHT, ProgressiveRender, RenderSettings,
};
use coatlab_core::render::reshade::{BaseImage, ReshadeError, Reshaded, reshade_prepared_samples};
use coatlab_core::spectrum::TabulatedSpectrum;

#[path = "support/car_render.rs"]
mod car_render;
use car_render::{HEIGHT, WIDTH, film_estimate, grid, red, render, render_with, shading, z_test};

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
        let (outliers, total_z) = z_test(&reshaded, &fresh);
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
    let (outliers, total_z) = z_test(&reshaded, &fresh);
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
    let (_, total_z) = z_test(&unedited, &fresh);
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

/// An edit session: ρ halved is shown re-shaded at once, then blended with fresh
/// passes, then the fresh film alone; at every stage the picture agrees with an
/// independent fresh render of the new design, and the scene, lighting and BVH
/// are the same objects throughout.
#[test]
fn an_edit_is_reshaded_then_refined_to_the_fresh_render() {
    let base = red();
    let (mut render, scene) = render(&base, ShadingModel::Paint, 5, 32, 8);
    let (scene_before, environment_before) = (render.scene().clone(), render.environment().clone());
    let mut edited = base.clone();
    edited
        .set_albedo(base.albedo().iter().map(|r| r * 0.5).collect())
        .expect("albedo");
    let outcome = render
        .edit_shading(shading(&scene, &edited, ShadingModel::Paint))
        .expect("edit");
    assert_eq!(outcome, EditOutcome::Reshaded);
    assert!(Arc::ptr_eq(render.scene(), &scene_before), "scene rebuilt");
    assert!(Arc::ptr_eq(render.environment(), &environment_before));
    assert_eq!(render.samples_per_pixel(), 0);
    let (fresh, _) = self::render(&edited, ShadingModel::Paint, 99, 256, 0);
    let (first, w) = render.edit_estimate().expect("re-shaded image");
    assert_eq!(w, 0.0);
    let (outliers, z) = z_test(&first, &fresh);
    println!(
        "re-shaded: beyond 4σ {:.2} %, total Z {z:.2}",
        outliers * 100.0
    );
    assert!(outliers < 0.01 && z.abs() < 4.0, "{outliers} {z}");
    // The first image came from one recorded sample per pixel; refining re-shades
    // from all of them, once, and is less noisy (both carry the base image's own
    // noise, so the drop is partial).
    assert!(render.refine_edit(), "nothing to refine after an edit");
    assert!(!render.refine_edit(), "refined twice");
    let (refined, w) = render.edit_estimate().expect("re-shaded image");
    assert_eq!(w, 0.0);
    let mean_variance = |r: &Reshaded| r.variance_y.iter().map(|&v| f64::from(v)).sum::<f64>();
    assert!(
        mean_variance(&refined) < 0.9 * mean_variance(&first),
        "refining did not reduce the noise: {} vs {}",
        mean_variance(&refined),
        mean_variance(&first)
    );
    let (outliers, z) = z_test(&refined, &fresh);
    println!(
        "refined: beyond 4σ {:.2} %, total Z {z:.2}",
        outliers * 100.0
    );
    assert!(outliers < 0.01 && z.abs() < 4.0, "{outliers} {z}");
    // Blended with fresh passes of the new design.
    render.render_pass(16);
    let (blend, w) = render.edit_estimate().expect("still blended");
    assert!(w > 0.2 && w < FRESH_ONLY_WEIGHT, "fresh weight {w}");
    let (outliers, z) = z_test(&blend, &fresh);
    println!(
        "blend (w {w:.2}): beyond 4σ {:.2} %, total Z {z:.2}",
        outliers * 100.0
    );
    assert!(outliers < 0.01 && z.abs() < 4.0, "{outliers} {z}");
    // The re-shaded image is dropped once the film alone is as good: the picture
    // is then the fresh render of the new design.
    while render.is_reshaded() {
        assert!(render.samples_per_pixel() < 4096, "the blend never ended");
        render.render_pass(64);
    }
    println!("film alone from {} spp", render.samples_per_pixel());
    let (outliers, z) = z_test(&film_estimate(&render), &fresh);
    println!("film: beyond 4σ {:.2} %, total Z {z:.2}", outliers * 100.0);
    assert!(outliers < 0.01 && z.abs() < 4.0, "{outliers} {z}");
    assert!(Arc::ptr_eq(render.scene(), &scene_before));
    // Negative control: the old design's image is not taken for the new one.
    let (old, _) = self::render(&base, ShadingModel::Paint, 7, 64, 0);
    let (_, z) = z_test(&film_estimate(&old), &fresh);
    assert!(z.abs() > 5.0, "the unedited image passed: Z {z}");
}

/// A second edit re-shades from the same base (its cache is not complete yet),
/// and a mirror cannot be re-weighted: that edit is traced fresh.
#[test]
fn edits_in_a_row_share_the_base_and_mirrors_trace_fresh() {
    let base = red();
    let (mut render, scene) = render(&base, ShadingModel::Paint, 5, 8, 4);
    let mut edited = base.clone();
    edited.set_thickness(60.0).expect("thickness");
    assert_eq!(
        render
            .edit_shading(shading(&scene, &edited, ShadingModel::Paint))
            .expect("edit"),
        EditOutcome::Reshaded
    );
    render.render_pass(1);
    edited.set_thickness(70.0).expect("thickness");
    assert_eq!(
        render
            .edit_shading(shading(&scene, &edited, ShadingModel::Paint))
            .expect("edit"),
        EditOutcome::Reshaded
    );
    assert_eq!(render.edit_base_samples_per_pixel(), 8);
    let mut mirror = edited.clone();
    mirror
        .set_gloss(GlossSetting::Exponent(GlossExponent::Mirror))
        .expect("gloss");
    assert_eq!(
        render
            .edit_shading(shading(&scene, &mirror, ShadingModel::Paint))
            .expect("edit"),
        EditOutcome::Fresh(ReshadeError::DeltaChanged)
    );
    assert!(!render.is_reshaded());
    assert!(render.edit_estimate().is_none());
}

/// The path caches stay within their budget: a small budget stops the recording
/// early (the cache is complete at fewer samples and still re-shades), and the
/// edit base plus the cache being recorded never pass it together.
#[test]
fn path_caches_stay_within_their_memory_budget() {
    let base = red();
    let (unbounded, scene) = render(&base, ShadingModel::Paint, 5, 4, 4);
    let full = unbounded.path_cache_memory_bytes();
    assert!(full > 0);
    let budget = full / 3;
    let scene_arc = unbounded.scene().clone();
    let mut render = ProgressiveRender::new(
        scene_arc,
        unbounded.environment().clone(),
        shading(&scene, &base, ShadingModel::Paint),
        unbounded.camera().clone(),
        RenderSettings {
            seed: 5,
            ..RenderSettings::default()
        },
    )
    .expect("render");
    render.set_path_cache_samples(4);
    render.set_path_cache_budget(budget);
    for _ in 0..6 {
        render.render_pass(1);
        assert!(
            render.path_cache_memory_bytes() <= budget,
            "{} > {budget}",
            render.path_cache_memory_bytes()
        );
    }
    let capped = render.path_cache_target();
    println!("unbounded {full} B at 4 spp; budget {budget} B: {capped} spp");
    assert!((1..4).contains(&capped), "cache capped at {capped} spp");
    let same = render
        .reshade(&shading(&scene, &base, ShadingModel::Paint))
        .expect("a capped cache re-shades");
    assert_eq!(same.xyz.len(), (WIDTH * HEIGHT) as usize);
    // With a base held, the new cache gets what is left.
    let mut edited = base.clone();
    edited.set_thickness(60.0).expect("thickness");
    assert_eq!(
        render
            .edit_shading(shading(&scene, &edited, ShadingModel::Paint))
            .expect("edit"),
        EditOutcome::Reshaded
    );
    for _ in 0..4 {
        render.render_pass(1);
        assert!(render.path_cache_memory_bytes() <= budget);
    }
    // No budget, no cache: every edit is traced fresh.
    render.set_path_cache_budget(0);
    render.render_pass(2);
    assert_eq!(render.path_cache_memory_bytes(), 0);
    assert!(matches!(
        render.edit_shading(shading(&scene, &base, ShadingModel::Paint)),
        Ok(EditOutcome::Fresh(ReshadeError::NotReady {
            recorded: 0,
            ..
        }))
    ));
}

/// A design edit rebuilds only the derived tables the changed field touches, and
/// gives the same model as building it anew.
#[test]
fn design_edits_recompute_only_what_they_touch() {
    let design = presets::all().into_iter().next().expect("preset").design;
    let grid = grid();
    let mut model = design.model(grid).expect("model");
    let mut previous = design.clone();
    let mut step = |edit: &dyn Fn(&mut coatlab_core::design::PaintDesign)| {
        let mut next = previous.clone();
        edit(&mut next);
        let before = model.recompute_counts();
        next.update_model(&previous, &mut model).expect("update");
        let after = model.recompute_counts();
        let fresh = next.model(grid).expect("model");
        let mut a = vec![0.0f64; grid.len()];
        let mut b = vec![0.0f64; grid.len()];
        for (wi, wo) in [
            ([0.3, 0.1, 0.95], [-0.2, 0.0, 0.98]),
            ([0.0, 0.6, 0.8], [0.1, -0.5, 0.86]),
        ] {
            model.eval_reference(wi, wo, &mut a);
            fresh.eval_reference(wi, wo, &mut b);
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).abs() <= 1e-9 * y.abs().max(1e-3), "{x} vs {y}");
            }
        }
        previous = next;
        (before, after)
    };
    // ρ: the body factor only.
    let (b, a) = step(&|d| {
        d.albedo = TabulatedSpectrum::new(
            d.albedo.wavelengths_nm().to_vec(),
            d.albedo.values().iter().map(|r| r * 0.5).collect(),
        )
        .expect("albedo");
    });
    assert_eq!(a.coat_integrals, b.coat_integrals, "ρ recomputed C");
    assert_eq!(a.angular_tables, b.angular_tables);
    assert_eq!(a.normalisation, b.normalisation);
    assert_eq!(a.body_factor, b.body_factor + 1);
    // h: τ changes, so C and the angular tables, but not the lobe.
    let (b, a) = step(&|d| d.thickness_um += 10.0);
    assert_eq!(a.coat_integrals, b.coat_integrals + 1);
    assert_eq!(a.exponent, b.exponent);
    assert_eq!(a.normalisation, b.normalisation);
    // Gloss: m and its normalisation, not C.
    let (b, a) = step(&|d| d.gloss.gu *= 0.9);
    assert_eq!(a.coat_integrals, b.coat_integrals, "gloss recomputed C");
    assert_eq!(a.angular_tables, b.angular_tables);
    assert_eq!(a.exponent, b.exponent + 1);
}

/// A re-shade from only the first m recorded samples per pixel
/// (`reshade_prepared_samples`) is unbiased: after an edit it agrees with a fresh
/// render of the edited design within the noise of both, and its reported
/// variance covers its extra noise.
///
/// Both renders use the plain estimator (one light sample a vertex, MIS on the
/// floor): for m = 1 the reported variance of the difference is one squared
/// difference, a proxy that is right on average but noisy pixel by pixel, and the
/// 1 % bound on |Z| > 4 was set with the plain estimator's base and fresh noise
/// beside it (0.87 %). The default estimator's lower base and fresh noise leave
/// that proxy more of the total: 1.00 % with the floor change alone, 1.61 % with
/// two first light samples too, at total Z −0.50 (no bias). See
/// docs/tradeoff.md, "Estimator efficiency (session 6)".
#[test]
fn partial_reshades_agree_with_fresh_renders() {
    let base = red();
    let plain = IntegratorSettings {
        first_light_samples: 1,
        floor_light_only: false,
        ..IntegratorSettings::default()
    };
    let (render, scene) = render_with(&base, ShadingModel::Paint, 5, 64, 4, plain);
    let mut edited = base.clone();
    edited
        .set_albedo(base.albedo().iter().map(|r| r * 0.5).collect())
        .expect("albedo");
    let edited_shading = shading(&scene, &edited, ShadingModel::Paint);
    let image = BaseImage::of(render.film());
    let environment = Environment::studio(&grid());
    let (fresh, _) = render_with(&edited, ShadingModel::Paint, 99, 64, 0, plain);
    let full = render.reshade(&edited_shading).expect("reshade");
    let mean_variance =
        |r: &Reshaded| r.variance_y.iter().map(|&v| f64::from(v)).sum::<f64>() / r.xyz.len() as f64;
    for m in [1, 2] {
        let partial = reshade_prepared_samples(
            &image,
            render.film(),
            render.path_cache(),
            &environment,
            &edited_shading,
            true,
            m,
        )
        .expect("reshade");
        let (outliers, total_z) = z_test(&partial, &fresh);
        println!(
            "first {m} of 4: beyond 4σ {:.2} %, total Z {total_z:.2}, mean variance {:.3e} (all 4: {:.3e})",
            outliers * 100.0,
            mean_variance(&partial),
            mean_variance(&full)
        );
        assert!(
            outliers < 0.01,
            "m = {m}: {:.2} % beyond 4σ",
            outliers * 100.0
        );
        assert!(total_z.abs() < 4.0, "m = {m}: total Z {total_z}");
        assert!(
            mean_variance(&partial) > mean_variance(&full),
            "m = {m}: fewer samples must report more noise"
        );
        // Not the full re-shade under another name.
        assert_ne!(partial.xyz, full.xyz, "m = {m}");
    }
    // m at or beyond K is the full re-shade, exactly.
    let all = reshade_prepared_samples(
        &image,
        render.film(),
        render.path_cache(),
        &environment,
        &edited_shading,
        true,
        9,
    )
    .expect("reshade");
    assert_eq!(all.xyz, full.xyz);
    assert_eq!(all.variance_y, full.variance_y);
}

/// Which recorded sample a path belongs to does not depend on how the samples were
/// split into passes: recorded in passes of 1 or of 3 + 1, the re-shades from the
/// first m samples are identical (the sampler is deterministic per pixel sample).
#[test]
fn partial_reshades_do_not_depend_on_the_pass_sizes() {
    let base = red();
    let mut edited = base.clone();
    edited.set_thickness(80.0).expect("thickness");
    let environment = Environment::studio(&grid());
    let reshaded = |passes: &[u32]| {
        let (mut render, scene) = render(&base, ShadingModel::Paint, 7, 0, 4);
        for &samples in passes {
            render.render_pass(samples);
        }
        assert_eq!(render.path_cache().samples_per_pixel(), 4);
        let image = BaseImage::of(render.film());
        let shading = shading(&scene, &edited, ShadingModel::Paint);
        (1..=4)
            .map(|m| {
                reshade_prepared_samples(
                    &image,
                    render.film(),
                    render.path_cache(),
                    &environment,
                    &shading,
                    true,
                    m,
                )
                .expect("reshade")
            })
            .collect::<Vec<_>>()
    };
    let ones = reshaded(&[1, 1, 1, 1, 1, 1]);
    let threes = reshaded(&[3, 1, 2]);
    for (m, (a, b)) in ones.iter().zip(&threes).enumerate() {
        assert_eq!(a.xyz, b.xyz, "first {} samples", m + 1);
        assert_eq!(a.variance_y, b.variance_y, "first {} samples", m + 1);
    }
    assert_ne!(ones[0].xyz, ones[3].xyz);
}
