//! The spectral paint model against the spec's checklist (section 9): energy,
//! white furnace, reciprocity, limits, no NaN at the corners, f32 against f64, and
//! χ² tests of the sampler. Statistical tests use fixed seeds and real tests
//! (Z-scores, χ² p-values), each with a negative control showing it can fail.

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::paint::coat::{body_albedo, body_brdf, c_integral};
use coatlab_core::paint::fresnel::reflectance;
use coatlab_core::paint::gloss::{GlossExponent, GlossGeometry};
use coatlab_core::paint::lobe::{LobeKind, phong_lobe};
use coatlab_core::paint::model::{GlossSetting, PaintModel, PaintParams, SpectralBsdf};
use coatlab_core::simd_path::SimdPath;
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

fn direction(theta_deg: f64, phi_deg: f64) -> [f64; 3] {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
}

fn to_f32(w: [f64; 3]) -> [f32; 3] {
    w.map(|x| x as f32)
}

fn grey_model(rho: f64, n: f64, tau: f64, m: GlossExponent, lobe: LobeKind) -> PaintModel {
    let grid = WavelengthGrid::visible(16).expect("16-sample grid");
    let mut params = PaintParams::grey(grid, rho, n, tau, 1.0, GlossSetting::Exponent(m));
    params.lobe = lobe;
    PaintModel::new(params).expect("valid grey parameters")
}

/// A paint with real dispersion and a UV absorber, on the reference grid.
fn realistic_model(gu: f64) -> PaintModel {
    realistic_model_on(WavelengthGrid::reference(), gu)
}

fn realistic_model_on(grid: WavelengthGrid, gu: f64) -> PaintModel {
    let wl: Vec<f64> = grid.wavelengths_nm().collect();
    let albedo = wl
        .iter()
        .map(|l| 0.05 + 0.7 / (1.0 + (-(l - 600.0) / 15.0).exp()))
        .collect();
    let index: Vec<f64> = wl
        .iter()
        .map(|l| 1.492 + 0.0045 / (l / 1000.0).powi(2))
        .collect();
    let absorption = wl
        .iter()
        .map(|l| 0.0004 + 0.2 / (1.0 + ((l - 390.0) / 6.0).exp()))
        .collect();
    let params = PaintParams {
        channels: grid.into(),
        albedo,
        refractive_index: index,
        index_at_gloss_wavelength: 1.492 + 0.0045 / 0.5876_f64.powi(2),
        absorption_per_um: absorption,
        thickness_um: 45.0,
        gloss: GlossSetting::Reading {
            gu,
            geometry: GlossGeometry::Deg20,
        },
        lobe: LobeKind::Normalised,
    };
    PaintModel::new(params).expect("valid realistic parameters")
}

#[test]
fn an_edit_recomputes_only_what_it_touches() {
    let mut model = realistic_model(80.0);
    let before = model.recompute_counts();
    model.set_albedo(vec![0.5; 81]).expect("valid albedo");
    let after = model.recompute_counts();
    assert_eq!(
        after.coat_integrals, before.coat_integrals,
        "ρ must not recompute C"
    );
    assert_eq!(after.angular_tables, before.angular_tables);
    assert_eq!(after.normalisation, before.normalisation);
    assert_eq!(after.body_factor, before.body_factor + 1);

    let before = model.recompute_counts();
    model
        .set_gloss(GlossSetting::Reading {
            gu: 70.0,
            geometry: GlossGeometry::Deg20,
        })
        .expect("valid gloss");
    let after = model.recompute_counts();
    assert_eq!(
        after.coat_integrals, before.coat_integrals,
        "gloss must not recompute C"
    );
    assert_eq!(after.angular_tables, before.angular_tables);
    assert_eq!(after.normalisation, before.normalisation + 1);

    let before = model.recompute_counts();
    model.set_thickness(50.0).expect("valid thickness");
    let after = model.recompute_counts();
    assert_eq!(after.coat_integrals, before.coat_integrals + 1);
    assert_eq!(
        after.normalisation, before.normalisation,
        "h must not touch the lobe"
    );
    assert_eq!(after.exponent, before.exponent);
}

#[test]
fn invalid_parameters_are_refused_with_their_value() {
    let mut model = realistic_model(80.0);
    let mut bad = vec![0.5; 81];
    bad[10] = 1.2;
    let err = model
        .set_albedo(bad)
        .expect_err("ρ > 1 must be refused")
        .to_string();
    assert!(err.contains("1.2") && err.contains("430 nm"), "{err}");
    let err = model.set_thickness(-1.0).expect_err("h < 0").to_string();
    assert!(err.contains("-1"), "{err}");
    let err = model
        .set_refractive_index(vec![0.9; 81], 0.9)
        .expect_err("n < 1")
        .to_string();
    assert!(err.contains("0.9"), "{err}");
    let err = model
        .set_absorption(vec![f64::NAN; 81])
        .expect_err("NaN k")
        .to_string();
    assert!(err.contains("NaN"), "{err}");
    // The model is unchanged by refused edits.
    assert_eq!(model.thickness_um(), 45.0);
}

/// Worst relative disagreement of the f32 evaluator with the f64 reference
/// (relative to the value plus 1e-3/sr), over directions up to 85° from the normal
/// and over grazing ones (85°–89.9°), separately.
fn worst_f32_error(model: &PaintModel) -> (f64, f64) {
    let len = model.channels().len();
    let (mut reference, mut single) = (vec![0.0; len], vec![0.0_f32; len]);
    let (mut worst, mut worst_grazing) = (0.0_f64, 0.0_f64);
    for &ti in &[0.0, 10.0, 33.0, 60.0, 80.0, 85.0, 88.0, 89.9] {
        for &to in &[0.0, 15.0, 45.0, 70.0, 85.0, 89.5] {
            for &dphi in &[180.0, 150.0, 90.0, 0.0] {
                let wi = direction(ti, 0.0);
                let wo = direction(to, dphi);
                model.eval_reference(wi, wo, &mut reference);
                model.spectral().eval(to_f32(wi), to_f32(wo), &mut single);
                for (r, s) in reference.iter().zip(&single) {
                    let error = (f64::from(*s) - r).abs() / (r.abs() + 1e-3);
                    if ti > 85.0 || to > 85.0 {
                        worst_grazing = worst_grazing.max(error);
                    } else {
                        worst = worst.max(error);
                    }
                }
            }
        }
    }
    (worst, worst_grazing)
}

/// The evaluation's SIMD paths (`coatlab_core::simd_path`: portable, and AVX2
/// where the CPU has it) give the same values bit for bit, on 81 and 16 wavelengths
/// (a tail shorter than a vector), sharp and broad lobes, random directions.
#[test]
fn every_simd_path_evaluates_the_same_bits() {
    let paths = SimdPath::available();
    println!(
        "SIMD paths: {:?}",
        paths.iter().map(|p| p.name()).collect::<Vec<_>>()
    );
    let mut rng = Pcg64::seed_from_u64(0x51d0);
    let sixteen = WavelengthGrid::visible(16).expect("16-sample grid");
    let models = [
        realistic_model(80.0),
        realistic_model(20.0),
        realistic_model_on(sixteen, 80.0),
    ];
    for model in &models {
        let paint = model.spectral();
        let mut reference = vec![0.0_f32; paint.len()];
        let mut got = vec![0.0_f32; paint.len()];
        let mut nonzero = 0;
        for _ in 0..2000 {
            let mut unit = || {
                let (ct, phi) = (
                    rng.random::<f64>(),
                    2.0 * std::f64::consts::PI * rng.random::<f64>(),
                );
                let st = (1.0 - ct * ct).sqrt();
                to_f32([st * phi.cos(), st * phi.sin(), ct])
            };
            let (wi, wo) = (unit(), unit());
            paint.eval_on(SimdPath::Portable, wi, wo, &mut reference);
            nonzero += usize::from(reference.iter().any(|&f| f > 0.0));
            for &path in &paths {
                paint.eval_on(path, wi, wo, &mut got);
                let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                assert_eq!(
                    bits(&got),
                    bits(&reference),
                    "{}: {wi:?} {wo:?}",
                    path.name()
                );
            }
        }
        assert!(nonzero > 1000, "{nonzero}");
    }
}

/// The stated tolerances of the f32 evaluator (see `SpectralPaint`).
const F32_TOLERANCE: f64 = 1e-3;
const F32_TOLERANCE_GRAZING: f64 = 5e-2;
/// The stated tolerance for a coat of n < [`NEAR_UNIT_INDEX`] (as n → 1 the
/// Fresnel table's error grows toward 85°, on a reflectance below 1e-4).
const F32_TOLERANCE_NEAR_UNIT_INDEX: f64 = 2e-3;
const NEAR_UNIT_INDEX: f64 = 1.003;

#[test]
fn single_precision_agrees_with_double_precision_on_a_real_paint() {
    // n(587.6 nm) = 1.505 reads 83.4 GU as a mirror: 80 GU is a sharp finite lobe.
    for gu in [30.0, 80.0] {
        let model = realistic_model(gu);
        let (worst, grazing) = worst_f32_error(&model);
        assert!(
            worst < F32_TOLERANCE,
            "{gu} GU: worst relative f32 error {worst:e}"
        );
        assert!(
            grazing < F32_TOLERANCE_GRAZING,
            "{gu} GU: worst grazing f32 error {grazing:e}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn single_precision_agrees_with_double_precision_over_the_domain(
        rho in prop_oneof![Just(0.0), Just(1.0), 0.0..=1.0f64],
        n in prop_oneof![Just(1.0), Just(4.0), 1.0..=4.0f64],
        log_tau in -6.0..4.0f64,
        zero_tau in any::<bool>(),
        log_m in 0.0..7.0f64,
        paper in any::<bool>(),
    ) {
        let tau = if zero_tau { 0.0 } else { 10f64.powf(log_tau) };
        let lobe = if paper { LobeKind::Paper } else { LobeKind::Normalised };
        let model = grey_model(rho, n, tau, GlossExponent::Finite(10f64.powf(log_m)), lobe);
        let (worst, grazing) = worst_f32_error(&model);
        let tolerance = if n < NEAR_UNIT_INDEX { F32_TOLERANCE_NEAR_UNIT_INDEX } else { F32_TOLERANCE };
        prop_assert!(worst < tolerance, "worst relative f32 error {:e}", worst);
        prop_assert!(grazing < F32_TOLERANCE_GRAZING, "worst grazing f32 error {:e}", grazing);
    }

    #[test]
    fn the_formulas_in_f32_agree_with_f64(
        rho in 0.0..=1.0f64,
        n in 1.0..=4.0f64,
        tau in prop_oneof![Just(0.0), 0.0..5.0f64],
        mu_i in 0.0..=1.0f64,
        mu_o in 0.0..=1.0f64,
    ) {
        let c = c_integral(n, tau);
        let f64_value = body_brdf(rho, n, tau, c, mu_i, mu_o);
        let f32_value = body_brdf(rho as f32, n as f32, tau as f32, c as f32, mu_i as f32, mu_o as f32);
        prop_assert!(f32_value.is_finite());
        // Beyond 85° the transmission's 1 − μ² cancels and amplifies the rounding of
        // μ in f32 (measured 7.8e-5 relative at μi = 1.8e-4): there the renderer's
        // stated f32 bound, F32_TOLERANCE, applies.
        let relative = if mu_i.min(mu_o) < 85f64.to_radians().cos() { F32_TOLERANCE } else { 1e-5 };
        prop_assert!((f64::from(f32_value) - f64_value).abs() <= relative * (f64_value + 1e-3),
            "{} vs {}", f32_value, f64_value);
        let r64 = reflectance(mu_i, n);
        let r32 = reflectance(mu_i as f32, n as f32);
        prop_assert!((f64::from(r32) - r64).abs() <= 2e-6, "{} vs {}", r32, r64);
    }

    #[test]
    fn no_nan_or_infinity_and_albedo_at_most_one(
        rho in prop_oneof![Just(0.0), Just(1.0), 0.0..=1.0f64],
        n in prop_oneof![Just(1.0), Just(4.0), Just(1e6), 1.0..=4.0f64],
        tau in prop_oneof![Just(0.0), Just(1e4), Just(800.0), 0.0..20.0f64],
        mu_i in prop_oneof![Just(0.0), Just(1.0), Just(1e-12), 0.0..=1.0f64],
        mu_o in prop_oneof![Just(0.0), Just(1.0), 0.0..=1.0f64],
    ) {
        let c = c_integral(n, tau);
        prop_assert!((0.0..std::f64::consts::PI).contains(&c), "C = {}", c);
        let f = body_brdf(rho, n, tau, c, mu_i, mu_o);
        prop_assert!(f.is_finite() && f >= 0.0, "f_body = {}", f);
        let albedo = reflectance(mu_i, n) + body_albedo(rho, n, tau, mu_i);
        prop_assert!(albedo.is_finite() && albedo <= 1.0 + 1e-12, "albedo = {}", albedo);
        if n <= 4.0 {
            // The renderer's single precision is stated for n in [1, 4].
            let f32_value = body_brdf(rho as f32, n as f32, tau as f32, c as f32, mu_i as f32, mu_o as f32);
            prop_assert!(f32_value.is_finite() && f32_value >= 0.0);
        }
    }

    #[test]
    fn body_and_lobe_shape_are_reciprocal(
        rho in 0.0..=1.0f64, n in 1.0..=4.0f64, tau in 0.0..3.0f64,
        ti in 0.0..89.0f64, to in 0.0..89.0f64, pi in 0.0..360.0f64, po in 0.0..360.0f64,
        m in 0.0..500.0f64,
    ) {
        let c = c_integral(n, tau);
        let (wi, wo) = (direction(ti, pi), direction(to, po));
        let a = body_brdf(rho, n, tau, c, wi[2], wo[2]);
        let b = body_brdf(rho, n, tau, c, wo[2], wi[2]);
        prop_assert!((a - b).abs() <= 1e-14 * a.max(1e-300));
        let da = phong_lobe(wi, wo, m);
        let db = phong_lobe(wo, wi, m);
        prop_assert!((da - db).abs() <= 1e-12 * da.max(1e-300));
    }
}

#[test]
fn stated_limits_hold() {
    // n = 1: no reflection, C = 0, f_body = ρ/π·exp(−τ(1/μi + 1/μo)).
    for &(rho, tau, mi, mo) in &[
        (0.7, 0.3, 0.5, 0.8),
        (1.0, 0.0, 0.1, 1.0),
        (0.2, 2.0, 0.9, 0.3),
    ] {
        assert_eq!(reflectance(mi, 1.0), 0.0);
        assert_eq!(c_integral(1.0, tau), 0.0);
        let f = body_brdf(rho, 1.0, tau, 0.0, mi, mo);
        let want = rho / std::f64::consts::PI * (-tau * (1.0 / mi + 1.0 / mo)).exp();
        assert!((f - want).abs() < 1e-15, "{f} vs {want}");
    }
    // ρ = 0: no body.
    assert_eq!(
        body_brdf(0.0, 1.5, 0.1, c_integral(1.5, 0.1), 0.5, 0.5),
        0.0
    );
    // τ → ∞: body → 0 (and no NaN on the way).
    assert_eq!(
        body_brdf(1.0, 1.5, 1e4, c_integral(1.5, 1e4), 0.5, 0.5),
        0.0
    );
    assert!(body_brdf(1.0, 1.5, 50.0, c_integral(1.5, 50.0), 1.0, 1.0) < 1e-40);
    // n → ∞: R → 1.
    assert!(reflectance(0.5, 1e8) > 1.0 - 1e-7);
    // τ = 0 with μ′ = 0 (n = 1, grazing) is finite.
    assert!(body_brdf(1.0_f64, 1.0, 0.0, 0.0, 0.0, 0.0).is_finite());
}

/// Mean and standard error of a Monte Carlo estimate of the directional albedo at
/// `w`, by importance sampling with the model's own sampler.
///
/// `light_side` estimates the spec's albedo ∫ f(ωi = w, ωo) cos θo dωo (light
/// arriving from `w`). Otherwise it estimates ∫ f(ωi, ωo = w) cos θi dωi, what a
/// path traced from a camera at `w` integrates. The two differ because the
/// normalised lobe is not reciprocal.
fn sampled_albedo(
    model: &PaintModel,
    w: [f32; 3],
    light_side: bool,
    samples: usize,
    seed: u64,
) -> (f64, f64) {
    let bsdf = model.spectral();
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut weight = vec![0.0_f32; bsdf.len()];
    let mut value = vec![0.0_f32; bsdf.len()];
    let (mut sum, mut sum2) = (0.0_f64, 0.0_f64);
    for _ in 0..samples {
        let u = [
            rng.random::<f32>(),
            rng.random::<f32>(),
            rng.random::<f32>(),
        ];
        let estimate = match bsdf.sample(w, u, &mut weight) {
            Some(s) if light_side && !s.delta => {
                // The lobe proposal is symmetric, so directions about the mirror of
                // `w` serve both sides; weigh them with f(w, ωo) instead.
                bsdf.eval(w, s.wi, &mut value);
                f64::from(value[0]) * f64::from(s.wi[2]) / f64::from(s.pdf)
            }
            Some(_) => f64::from(weight[0]),
            None => 0.0,
        };
        sum += estimate;
        sum2 += estimate * estimate;
    }
    let mean = sum / samples as f64;
    let variance = (sum2 / samples as f64 - mean * mean).max(0.0);
    (mean, (variance / samples as f64).sqrt())
}

#[test]
fn white_furnace_by_importance_sampling() {
    // ρ = 1, τ = 0, normalised lobe: the directional albedo is exactly 1. The
    // estimate is judged by its Z-score (its standard error plus the f32 tables'
    // tolerance), and a 1 % error must be detectable.
    for m in [
        GlossExponent::Finite(30.0),
        GlossExponent::Finite(3000.0),
        GlossExponent::Mirror,
    ] {
        let model = grey_model(1.0, 1.5, 0.0, m, LobeKind::Normalised);
        for theta in [0.0, 40.0, 75.0, 85.0] {
            let w = to_f32(direction(theta, 30.0));
            let (mean, se) = sampled_albedo(&model, w, true, 400_000, 7);
            let tolerance = se + 5e-4;
            let z = (mean - 1.0) / tolerance;
            assert!(
                z.abs() < 4.0,
                "{m:?} θ {theta}: albedo {mean} ± {se} (z {z})"
            );
            let z_wrong = (mean - 1.01) / tolerance;
            assert!(
                z_wrong.abs() > 4.0,
                "the furnace test cannot see a 1% error ({m:?}, θ {theta})"
            );
        }
    }
}

#[test]
fn view_side_albedo_exceeds_one_only_by_the_measured_amount() {
    // Seen from the camera, the white furnace integrates R(μi)/N(μi) over ωi, which
    // the normalisation does not make exactly 1 (the lobe is normalised over ωo).
    // Measured (400 000 samples, n = 1.5), recorded in docs/model.md, section 9:
    // the largest excess is 4.0 % (m = 5 at 40°), 3.2 % (m = 30 at 60°), 1.3 %
    // (m = 300 at 75°), 0.36 % (m = 3000 at 85°); at grazing views it falls below 1
    // as the lobe about the mirror of ωo dips under the horizon.
    for (m, bound) in [(5.0, 0.045), (30.0, 0.035), (300.0, 0.015), (3000.0, 0.005)] {
        let model = grey_model(
            1.0,
            1.5,
            0.0,
            GlossExponent::Finite(m),
            LobeKind::Normalised,
        );
        for theta in [0.0, 40.0, 60.0, 75.0, 85.0] {
            let (mean, se) =
                sampled_albedo(&model, to_f32(direction(theta, 0.0)), false, 400_000, 8);
            assert!(
                mean - 1.0 < bound + 4.0 * se,
                "m {m} θ {theta}: view-side albedo {mean} ± {se}"
            );
        }
    }
}

#[test]
fn albedo_is_at_most_one_for_every_lobe_but_the_papers() {
    for (rho, n, tau) in [
        (0.9, 1.5, 0.01),
        (1.0, 3.0, 0.0),
        (1.0, 1.0, 0.0),
        (0.5, 4.0, 2.0),
    ] {
        let model = grey_model(
            rho,
            n,
            tau,
            GlossExponent::Finite(100.0),
            LobeKind::Normalised,
        );
        for theta in [0.0, 60.0, 85.0] {
            let (mean, se) =
                sampled_albedo(&model, to_f32(direction(theta, 0.0)), true, 100_000, 11);
            assert!(
                mean - 4.0 * se <= 1.0 + 2e-4,
                "ρ {rho} n {n} τ {tau} θ {theta}: {mean} ± {se}"
            );
        }
    }
    // The paper's lobe as printed is not normalised: at low m it reflects more
    // energy than it receives, which is why it is not the default.
    let paper = grey_model(1.0, 1.5, 0.0, GlossExponent::Finite(2.0), LobeKind::Paper);
    let (mean, se) = sampled_albedo(&paper, to_f32(direction(60.0, 0.0)), true, 100_000, 12);
    assert!(mean - 4.0 * se > 1.0, "paper lobe albedo {mean} ± {se}");
}

// ---------------------------------------------------------------------------
// χ² test of the sampler against its own density.

#[path = "support/bsdf_chi_square.rs"]
mod bsdf_chi_square;
use bsdf_chi_square::{Bins, ChiSquare, Perturbation, chi_square_test};

/// 64 × 128 bins of equal solid angle; 10⁶ samples put ≥ 5 expected in every bin a
/// broad lobe or the diffuse part reaches, so the test sees 10 % density errors
/// over half the hemisphere (see the control below).
const BINS: Bins = Bins { mu: 64, phi: 128 };
const SAMPLES: usize = 1_000_000;

/// χ² test of `model`'s sampler, seen from `wo`, against the density of `density`
/// (the model itself, or another one for a negative control) with `perturbation`.
fn chi_square(
    model: &PaintModel,
    density: &PaintModel,
    wo: [f32; 3],
    perturbation: Perturbation,
) -> ChiSquare {
    let pdf = |wi| f64::from(density.spectral().pdf(wo, wi));
    chi_square_test(model.spectral(), wo, &pdf, BINS, SAMPLES, 3, perturbation)
}

/// The sampler settings the χ² test covers (ρ, m, lobe, θo): broad to sharp
/// normalised lobes, the paper's lobe (sampled with a Phong proposal) and the
/// mirror's diffuse part, with ρ = 0.6 (mostly cosine samples); and each lobe again
/// over a black pigment, where the lobe takes 95 % of the samples, so that an error
/// in the lobe's own sampling is not diluted by the diffuse part.
fn sampler_cases() -> Vec<(f64, GlossExponent, LobeKind, f64)> {
    let mut cases = vec![(0.6, GlossExponent::Mirror, LobeKind::Normalised, 50.0)];
    for (m, lobe, theta) in [
        (5.0, LobeKind::Normalised, 30.0),
        (60.0, LobeKind::Normalised, 70.0),
        (400.0, LobeKind::Normalised, 10.0),
        (40.0, LobeKind::Paper, 45.0),
    ] {
        for rho in [0.6, 0.0] {
            cases.push((rho, GlossExponent::Finite(m), lobe, theta));
        }
    }
    cases
}

#[test]
fn sampler_matches_its_density() {
    for (rho, m, lobe, theta) in sampler_cases() {
        let model = grey_model(rho, 1.5, 0.05, m, lobe);
        let wo = to_f32(direction(theta, 20.0));
        let test = chi_square(&model, &model, wo, Perturbation::None);
        println!("ρ {rho} {m:?} {lobe:?} θ {theta}: {test:?}");
        assert!(
            test.p_value > 1e-3,
            "ρ {rho} {m:?} {lobe:?} θ {theta}: χ² p-value {:e}",
            test.p_value
        );
    }
}

#[test]
fn chi_square_test_rejects_a_wrong_density() {
    // Negative control: the density of a 25 % different exponent must be rejected.
    let with_exponent = |m| {
        grey_model(
            0.6,
            1.5,
            0.05,
            GlossExponent::Finite(m),
            LobeKind::Normalised,
        )
    };
    let (model, wrong) = (with_exponent(60.0), with_exponent(75.0));
    let wo = to_f32(direction(40.0, 0.0));
    let test = chi_square(&model, &wrong, wo, Perturbation::None);
    assert!(
        test.p_value < 1e-6,
        "χ² accepted a 25% wrong exponent: {test:?}"
    );
}

/// A negative control's test, printed, must reject far beyond chance (p < 1e-9).
fn assert_far_rejected(test: &ChiSquare, case: &str, error: &str) {
    println!("{case}, {error}: {test:?}");
    assert!(test.p_value < 1e-9, "{case}: χ² accepted {error}: {test:?}");
}

#[test]
fn chi_square_test_rejects_a_ten_percent_density_error_in_every_case() {
    // Negative control at the size of a real defect: for every case of
    // `sampler_matches_its_density`, the same samples against the density ×1.1 on
    // half of the azimuths (renormalised) must fail the same test, by far.
    for (rho, m, lobe, theta) in sampler_cases() {
        let model = grey_model(rho, 1.5, 0.05, m, lobe);
        let wo = to_f32(direction(theta, 20.0));
        let wrong = Perturbation::HalfDomain { factor: 1.1 };
        let test = chi_square(&model, &model, wo, wrong);
        let case = format!("ρ {rho} {m:?} {lobe:?} θ {theta}");
        assert_far_rejected(&test, &case, "a 10 % density error on half the azimuths");
    }
}

#[test]
fn chi_square_test_rejects_a_ten_percent_error_in_the_lobe_exponent() {
    // Negative control for the lobe's own sampler: where the lobe takes most samples
    // (ρ = 0), the density of an exponent 10 % off must be rejected. (Over ρ = 0.6
    // the same error is diluted by the cosine samples: p = 0.02 for m = 5, measured,
    // which is why the black-pigment cases are in `sampler_cases`.)
    for (rho, m, lobe, theta) in sampler_cases() {
        let GlossExponent::Finite(exponent) = m else {
            continue;
        };
        if rho != 0.0 {
            continue;
        }
        let model = grey_model(rho, 1.5, 0.05, m, lobe);
        let wrong = grey_model(rho, 1.5, 0.05, GlossExponent::Finite(1.1 * exponent), lobe);
        let wo = to_f32(direction(theta, 20.0));
        let test = chi_square(&model, &wrong, wo, Perturbation::None);
        let case = format!("m {exponent} {lobe:?} θ {theta}");
        assert_far_rejected(&test, &case, "the density of m × 1.1");
    }
}

/// The model refuses a parameter exactly outside the parameter table's range, at
/// any channel, naming the parameter, the channel and the range.
#[test]
fn the_model_refuses_exactly_outside_the_parameter_table() {
    use coatlab_core::colour::spectrum::Channels;
    use coatlab_core::paint::parameters::{
        ABSORPTION, ALBEDO, Parameter, REFRACTIVE_INDEX, THICKNESS,
    };

    let grid = WavelengthGrid::visible(4).expect("grid");
    let gloss = GlossSetting::Exponent(GlossExponent::Finite(100.0));
    type Setter = fn(&mut PaintParams, f64);
    let cases: [(&Parameter, Setter); 4] = [
        (&ALBEDO, |p, v| p.albedo[2] = v),
        (&REFRACTIVE_INDEX, |p, v| p.refractive_index[2] = v),
        (&ABSORPTION, |p, v| p.absorption_per_um[2] = v),
        (&THICKNESS, |p, v| p.thickness_um = v),
    ];
    for channels in [Channels::Spectral(grid), Channels::LinearSrgb] {
        for (parameter, set) in cases {
            let range = parameter.range;
            let mut values = vec![(f64::NAN, false), (f64::INFINITY, false)];
            values.extend([(range.min, true), (range.min.next_down(), false)]);
            if range.max.is_finite() {
                values.extend([(range.max, true), (range.max.next_up(), false)]);
            }
            for (value, inside) in values {
                let mut params = PaintParams::grey(channels, 0.5, 1.5, 0.001, 40.0, gloss);
                set(&mut params, value);
                match PaintModel::new(params) {
                    Ok(_) => assert!(inside, "{} = {value} accepted", parameter.label()),
                    Err(error) => {
                        assert!(!inside, "{} = {value}: {error}", parameter.label());
                        let message = error.to_string();
                        assert!(
                            message.contains(&parameter.label())
                                && message.contains(&parameter.range_text()),
                            "{message}"
                        );
                        if parameter.symbol != "h" {
                            let at = channels.channel(2).to_string();
                            assert!(message.contains(&at), "{message} lacks {at}");
                        }
                    }
                }
            }
        }
    }
}
