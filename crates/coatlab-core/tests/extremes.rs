//! The corners of the parameter domain (issue 5, item 4; report in `docs/extremes.md`).
//!
//! A systematic grid, not random points (those are `tests/paint_model.rs`): n from 1
//! to 4, τ = k·h from 0 to 10⁴, ρ 0, ½ and 1, the gloss exponent at both ends of its
//! range (m = 0, m = `MAX_EXPONENT`, the ideal mirror), both lobes, and directions
//! down to 89.99° and exactly 90°. Checked: every value of the f64 reference and the
//! f32 renderer tables is finite and ≥ 0; f32 agrees with f64 within the tolerances
//! stated on `SpectralPaint`; the directional albedo is at most 1; the sampler never
//! returns a non-finite weight or direction and its densities agree with `pdf`; the
//! derived tables are finite at the ends. The worst cases are printed
//! (`cargo test -p coatlab-core --test extremes -- --nocapture`).
//!
//! Then renders of extreme designs: finite, nothing rejected, and plausible by
//! statistical comparisons (never exact pixel values).

use std::f64::consts::PI;

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::paint::coat::{c_integral, escape_integral_scaled};
use coatlab_core::paint::fresnel::{reflectance, transmittance};
use coatlab_core::paint::gloss::{
    GlossError, GlossExponent, GlossGeometry, MAX_EXPONENT, exponent_from_reading,
    reading_from_exponent,
};
use coatlab_core::paint::lobe::{
    LobeKind, NormalisationTable, phong_lobe_pdf, phong_normalisation,
};
use coatlab_core::paint::model::{GlossSetting, PaintModel, PaintParams, SpectralBsdf};
use coatlab_core::render::camera::Camera;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::Film;
use coatlab_core::render::geometry::Surface;
use coatlab_core::render::material::ShadingModel;
use coatlab_core::render::progressive::{RenderScene, RenderSettings};
use coatlab_core::scene::Scene;
use coatlab_core::scene::car::{BODY, CarParameters, generate};

#[path = "support/sphere.rs"]
mod sphere;

#[path = "support/progressive.rs"]
mod progressive;
use sphere::{sphere, sphere_camera, sphere_hit};

// ---------------------------------------------------------------------------
// The grid.

const INDICES: [f64; 5] = [1.0, 1.0001, 1.5, 2.5, 4.0];
/// The brief's τ values, with 1e-2 and 0.1 added: n = 1 with τ ≈ 0.01 is where the
/// f32 tables' grazing error was largest in `tests/paint_model.rs`.
const DEPTHS: [f64; 8] = [0.0, 1e-6, 1e-3, 1e-2, 0.1, 1.0, 10.0, 1e4];
const ALBEDOS: [f64; 3] = [0.0, 0.5, 1.0];

/// Polar angles, degrees; 90 is the horizon itself (z = 0 exactly).
const THETAS_DEG: [f64; 10] = [0.0, 30.0, 60.0, 80.0, 85.0, 88.0, 89.0, 89.9, 89.99, 90.0];

/// The stated tolerances of the f32 evaluator (see `SpectralPaint`), relative to
/// |f| + 1e-3/sr: up to 85° from the normal, and from 85° to 89.9°.
const F32_TOLERANCE: f64 = 1e-3;
const F32_TOLERANCE_GRAZING: f64 = 5e-2;
const ABSOLUTE_FLOOR_PER_SR: f64 = 1e-3;
/// Below this index the Fresnel table's relative error passes 1e-3 toward 85° (R ∝
/// μ⁻⁴ there), which shows where a very sharp lobe multiplies R; the tolerance up to
/// 85° is then 2e-3 (stated on `SpectralPaint`).
const NEARLY_AIR_INDEX: f64 = 1.003;
const F32_TOLERANCE_NEARLY_AIR: f64 = 2e-3;

/// The lobe settings at both ends of the gloss range.
fn lobe_cases() -> Vec<(GlossExponent, LobeKind)> {
    vec![
        (GlossExponent::Finite(0.0), LobeKind::Normalised),
        (GlossExponent::Finite(0.0), LobeKind::Paper),
        (GlossExponent::Finite(MAX_EXPONENT), LobeKind::Normalised),
        (GlossExponent::Finite(MAX_EXPONENT), LobeKind::Paper),
        (GlossExponent::Mirror, LobeKind::Normalised),
    ]
}

fn lobe_name(m: GlossExponent, lobe: LobeKind) -> String {
    match m {
        GlossExponent::Mirror => "mirror".to_owned(),
        GlossExponent::Finite(m) => format!("m = {m:e} {}", lobe.name()),
    }
}

/// One corner (n, τ, ρ) of the grid.
#[derive(Debug, Clone, Copy)]
struct Corner {
    n: f64,
    tau: f64,
    rho: f64,
}

fn corners() -> Vec<Corner> {
    let mut out = Vec::new();
    for &n in &INDICES {
        for &tau in &DEPTHS {
            for &rho in &ALBEDOS {
                out.push(Corner { n, tau, rho });
            }
        }
    }
    out
}

/// Every corner at once: wavelength i of the grid carries corner i (the f32 and f64
/// evaluations are per wavelength; only the sampler's strategy choice mixes them).
/// h = 1 µm, so k = τ.
fn packed_model(m: GlossExponent, lobe: LobeKind) -> (PaintModel, Vec<Corner>) {
    let corners = corners();
    let grid = WavelengthGrid::visible(corners.len()).expect("grid");
    let params = PaintParams {
        channels: grid.into(),
        albedo: corners.iter().map(|c| c.rho).collect(),
        refractive_index: corners.iter().map(|c| c.n).collect(),
        index_at_gloss_wavelength: 1.5,
        absorption_per_um: corners.iter().map(|c| c.tau).collect(),
        thickness_um: 1.0,
        gloss: GlossSetting::Exponent(m),
        lobe,
    };
    (
        PaintModel::new(params).expect("valid corner parameters"),
        corners,
    )
}

/// A grey model on a one-wavelength grid.
fn grey_model(c: Corner, m: GlossExponent, lobe: LobeKind) -> PaintModel {
    let grid = WavelengthGrid::visible(1).expect("grid");
    let mut params = PaintParams::grey(grid, c.rho, c.n, c.tau, 1.0, GlossSetting::Exponent(m));
    params.lobe = lobe;
    PaintModel::new(params).expect("valid grey parameters")
}

/// Direction with cosine `mu` to the normal and azimuth `phi_deg`.
fn direction_mu(mu: f64, phi_deg: f64) -> [f64; 3] {
    let s = ((1.0 - mu) * (1.0 + mu)).max(0.0).sqrt();
    let p = phi_deg.to_radians();
    [s * p.cos(), s * p.sin(), mu]
}

/// Cosine of a polar angle from the list: exactly 0 at 90°.
fn mu_of(theta_deg: f64) -> f64 {
    if theta_deg >= 90.0 {
        0.0
    } else {
        theta_deg.to_radians().cos()
    }
}

fn to_f32(w: [f64; 3]) -> [f32; 3] {
    w.map(|x| x as f32)
}
fn to_f64(w: [f32; 3]) -> [f64; 3] {
    w.map(f64::from)
}

fn theta_deg_of(w: [f64; 3]) -> f64 {
    w[2].clamp(-1.0, 1.0).acos().to_degrees()
}

/// The worst value seen and where.
#[derive(Debug, Default)]
struct Worst {
    value: f64,
    at: String,
}

impl Worst {
    fn record(&mut self, value: f64, at: impl FnOnce() -> String) {
        if value > self.value || (self.at.is_empty() && value >= self.value) {
            self.value = value;
            self.at = at();
        }
    }
}

/// Direction pairs of the sweep: every (θi, θo) of the list with the view in the
/// plane of incidence on the mirror side, on the light's side and across it; and
/// views just off the mirror direction, on the angular scale of the sharpest lobe
/// (m = 1e9: 1/sqrt(m) ≈ 3e-5 rad) and wider.
fn direction_pairs() -> Vec<([f64; 3], [f64; 3])> {
    let mut pairs = Vec::new();
    for &ti in &THETAS_DEG {
        let wi = direction_mu(mu_of(ti), 0.0);
        for &to in &THETAS_DEG {
            for phi in [180.0, 0.0, 90.0] {
                pairs.push((wi, direction_mu(mu_of(to), phi)));
            }
        }
        let theta_r = ti.to_radians();
        for delta in [0.0, 2e-5, -2e-5, 5e-5, 1e-3, -0.05] {
            let theta = theta_r + delta;
            if !(0.0..=std::f64::consts::FRAC_PI_2).contains(&theta) {
                continue;
            }
            pairs.push((wi, direction_mu(theta.cos(), 180.0)));
        }
    }
    pairs
}

// ---------------------------------------------------------------------------
// f32 against f64, and no NaN, infinity or negative value.

/// For m = 0, whether ωo lies on the edge of the lobe's support (within 1e-6 rad),
/// and if so the lobe's value S just inside it: 1/N(μi, 0) for the normalised lobe
/// (D = max(0, ωo·ωr)⁰), 1 for the paper's (cos((|θo − θr| + |Δφ|)/2)⁰).
fn lobe_step_edge(m: GlossExponent, lobe: LobeKind, wi: [f64; 3], wo: [f64; 3]) -> Option<f64> {
    if m != GlossExponent::Finite(0.0) || wi[2] <= 0.0 || wo[2] <= 0.0 {
        return None;
    }
    let unit = |w: [f64; 3]| {
        let l = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        w.map(|x| x / l)
    };
    let (wi, wo) = (unit(wi), unit(wo));
    let r = [-wi[0], -wi[1], wi[2]];
    match lobe {
        LobeKind::Normalised => {
            let cos = r[0] * wo[0] + r[1] * wo[1] + r[2] * wo[2];
            (cos.abs() < 1e-6).then(|| 1.0 / phong_normalisation(wi[2], 0.0))
        }
        LobeKind::Paper => {
            let theta = |w: [f64; 3]| w[0].hypot(w[1]).atan2(w[2]);
            let on_pole = |w: [f64; 3]| w[0].hypot(w[1]) < 1e-12;
            let mut d_phi = if on_pole(wo) || on_pole(r) {
                0.0
            } else {
                (wo[1].atan2(wo[0]) - r[1].atan2(r[0])).abs()
            };
            if d_phi > PI {
                d_phi = 2.0 * PI - d_phi;
            }
            let angle = 0.5 * ((theta(wo) - theta(r)).abs() + d_phi);
            ((angle - 0.5 * PI).abs() < 1e-6).then_some(1.0)
        }
    }
}

#[test]
fn corner_sweep_single_precision_against_double_precision() {
    let pairs = direction_pairs();
    // Bands by the larger polar angle: ≤ 85°, 85°–89.9°, beyond 89.9°.
    // The fourth: up to 85° for a coat of n < 1.003 (see `NEARLY_AIR_INDEX`).
    let mut worst: [Worst; 4] = Default::default();
    let mut evaluations = 0_usize;
    let mut steps_taken_the_other_way = 0_usize;
    for (m, lobe) in lobe_cases() {
        let (model, corners) = packed_model(m, lobe);
        let len = corners.len();
        let (mut reference, mut single) = (vec![0.0_f64; len], vec![0.0_f32; len]);
        for &(wi, wo) in &pairs {
            // Both evaluate the same (rounded) directions: the f32 pipeline's own
            // error, not the rounding of its inputs.
            let (wi32, wo32) = (to_f32(wi), to_f32(wo));
            model.eval_reference(to_f64(wi32), to_f64(wo32), &mut reference);
            model.spectral().eval(wi32, wo32, &mut single);
            let (ti, to) = (theta_deg_of(wi), theta_deg_of(wo));
            let band = if ti.max(to) <= 85.0 + 1e-9 {
                0
            } else if ti.max(to) <= 89.9 + 1e-9 {
                1
            } else {
                2
            };
            let phi_o = wo[1].atan2(wo[0]).to_degrees();
            // The m = 0 lobes are steps (D = 1 inside, 0 outside); exactly on the
            // step, rounding decides, in either precision. There the f32 value may
            // take the other side's value.
            let on_step = lobe_step_edge(m, lobe, to_f64(wi32), to_f64(wo32));
            let lobe_value = model.lobe_value_reference(to_f64(wi32), to_f64(wo32));
            for (i, c) in corners.iter().enumerate() {
                let (mut r, s) = (reference[i], f64::from(single[i]));
                let (r_own, ti_own, to_own) = (r, ti, to);
                assert!(
                    r.is_finite() && r >= 0.0 && s.is_finite() && s >= 0.0,
                    "n {} τ {:e} ρ {} {}; θi {ti_own}° θo {to_own}°: f64 {r_own:e}, f32 {s:e}",
                    c.n,
                    c.tau,
                    c.rho,
                    lobe_name(m, lobe)
                );
                if let Some(inside) = on_step {
                    let specular = reflectance(wi[2], c.n);
                    let other_side = if lobe_value > 0.0 {
                        (r - specular * lobe_value).max(0.0)
                    } else {
                        r + specular * inside
                    };
                    let error = |r: f64| (s - r).abs() / (r.abs() + ABSOLUTE_FLOOR_PER_SR);
                    if error(other_side) < error(r) {
                        r = other_side;
                        steps_taken_the_other_way += 1;
                    }
                }
                let at = || {
                    format!(
                        "n {} τ {:e} ρ {} {}; θi {ti:.5}° θo {to:.5}° φo {phi_o:.1}°: f64 {r:e}, f32 {s:e}",
                        c.n,
                        c.tau,
                        c.rho,
                        lobe_name(m, lobe)
                    )
                };
                let error = (s - r).abs() / (r.abs() + ABSOLUTE_FLOOR_PER_SR);
                let band = if band == 0 && c.n < NEARLY_AIR_INDEX {
                    3
                } else {
                    band
                };
                worst[band].record(error, at);
                evaluations += 1;
            }
        }
    }
    println!(
        "f32 vs f64 over {evaluations} evaluations (relative to |f| + 1e-3/sr; \
         {steps_taken_the_other_way} on the edge of an m = 0 lobe took the other side of the step):"
    );
    let bands = [
        "θ ≤ 85°, n ≥ 1.003",
        "85° < θ ≤ 89.9°",
        "θ > 89.9° (no stated tolerance)",
        "θ ≤ 85°, n < 1.003",
    ];
    for (name, w) in bands.iter().zip(&worst) {
        println!("  {name}: worst {:.3e} at {}", w.value, w.at);
    }
    for (band, tolerance) in [
        (0, F32_TOLERANCE),
        (1, F32_TOLERANCE_GRAZING),
        (3, F32_TOLERANCE_NEARLY_AIR),
    ] {
        assert!(
            worst[band].value < tolerance,
            "{}: {:e} at {}",
            bands[band],
            worst[band].value,
            worst[band].at
        );
    }
    // Beyond 89.9° nothing is stated; a regression that made it much worse would
    // still show here (measured worst 0.55).
    assert!(
        worst[2].value < 1.0,
        "{}: {:e} at {}",
        bands[2],
        worst[2].value,
        worst[2].at
    );
}

/// The Fresnel table alone (the mirror's delta sample returns R(μ) from it): its
/// relative error up to 85° by n. For n → 1, R ∝ μ⁻⁴ at grazing angles, which the
/// tables (linear in sqrt μ, 256 intervals) follow to 1.6e-3 at 85°; R itself is
/// below 1e-4 there, so the error matters only under a very sharp lobe.
#[test]
fn fresnel_table_relative_error_by_index() {
    println!("Fresnel table, worst relative error of R up to 85° (step 0.05°):");
    for n in [1.000_001, 1.0001, 1.001, 1.003, 1.01, 1.1, 1.5, 2.5, 4.0] {
        let model = grey_model(
            Corner {
                n,
                tau: 0.0,
                rho: 0.0,
            },
            GlossExponent::Mirror,
            LobeKind::Normalised,
        );
        let mut weight = [0.0_f32; 1];
        let mut worst = Worst::default();
        for k in 0..=1700 {
            let theta = 0.05 * k as f64;
            let wo = to_f32(direction_mu(theta.to_radians().cos(), 0.0));
            let sample = model
                .spectral()
                .sample(wo, [0.0, 0.5, 0.5], &mut weight)
                .expect("the mirror sample");
            assert!(sample.delta);
            let r32 = f64::from(weight[0]) * f64::from(sample.pdf);
            let r64 = reflectance(f64::from(wo[2]), n);
            worst.record((r32 - r64).abs() / r64, || format!("{theta:.2}°"));
        }
        println!("  n {n}: {:.2e} at {}", worst.value, worst.at);
        let bound = if n < NEARLY_AIR_INDEX {
            F32_TOLERANCE_NEARLY_AIR
        } else {
            F32_TOLERANCE
        };
        assert!(
            worst.value < bound,
            "n {n}: {:e} at {}",
            worst.value,
            worst.at
        );
    }
}

/// Regression: around the peak of the sharpest lobes (m = 1e7 and 1e9, offsets up to
/// 4/sqrt(m) in θ and φ), f32 agrees with f64 for both lobes. The paper's lobe took
/// θ and φ differences of two f32 arctangents (1e-7 rad each) and was off by 2.2e-3
/// at m = 1e7 and 2.2e-2 at m = 1e9; it now works from ωo − ωr.
#[test]
fn the_sharpest_lobes_agree_around_their_peak() {
    for lobe in [LobeKind::Paper, LobeKind::Normalised] {
        for m in [1e7, MAX_EXPONENT] {
            let corner = Corner {
                n: 1.5,
                tau: 0.0,
                rho: 0.0,
            };
            let model = grey_model(corner, GlossExponent::Finite(m), lobe);
            let mut worst = Worst::default();
            let (mut r, mut s) = ([0.0_f64], [0.0_f32]);
            let scale = 1.0 / m.sqrt();
            for k in 1..=17 {
                let ti = 5.0 * k as f64;
                let wi = to_f32(direction_mu(ti.to_radians().cos(), 0.0));
                for a in -10..=10 {
                    for b in -10..=10 {
                        let theta = ti.to_radians() + 0.4 * a as f64 * scale;
                        let phi = 180.0 + (0.4 * b as f64 * scale).to_degrees();
                        let wo = to_f32(direction_mu(theta.cos(), phi));
                        model.eval_reference(to_f64(wi), to_f64(wo), &mut r);
                        model.spectral().eval(wi, wo, &mut s);
                        let error = (f64::from(s[0]) - r[0]).abs() / (r[0] + ABSOLUTE_FLOOR_PER_SR);
                        worst.record(error, || {
                            format!(
                                "θi {ti}°, Δθ {a}·0.4/√m, Δφ {b}·0.4/√m: f64 {:e}, f32 {:e}",
                                r[0], s[0]
                            )
                        });
                    }
                }
            }
            println!(
                "{} m = {m:e} around the peak: worst {:.2e} at {}",
                lobe.name(),
                worst.value,
                worst.at
            );
            assert!(
                worst.value < F32_TOLERANCE,
                "{} m = {m:e}: {:e} at {}",
                lobe.name(),
                worst.value,
                worst.at
            );
        }
    }
}

// ---------------------------------------------------------------------------
// Derived tables at the ends.

#[test]
fn derived_tables_are_finite_at_the_ends() {
    // C and the escape factor E over the whole (n, τ) grid.
    for &n in &INDICES {
        for &tau in &DEPTHS {
            let c = c_integral(n, tau);
            assert!((0.0..PI).contains(&c), "C({n}, {tau}) = {c}");
            let escape = escape_integral_scaled(n, tau) * (-tau).exp();
            assert!(
                escape.is_finite() && (0.0..=PI * (1.0 + 1e-12)).contains(&escape),
                "E({n}, {tau}) = {escape}"
            );
        }
    }
    // The lobe normalisation N(μ, m) at both ends of m and of μ, exact and tabulated.
    // The table is stated within 5e-5 on a uniform μ grid; near μ = 0 (θ > 89.99°)
    // it reaches 9e-4 (m = 1e9, μ ≈ 1.6e-8), inside the renderer's tolerance there.
    let mut worst_table = Worst::default();
    for m in [0.0, 1e-9, 1.0, 1e4, MAX_EXPONENT] {
        let table = NormalisationTable::new(m);
        let mut mus = vec![0.0, 1e-300, 6.123e-17, 0.5, 1.0];
        mus.extend((0..=90).map(|k| 10f64.powf(-9.0 + 0.1 * k as f64)));
        for mu in mus {
            let exact = phong_normalisation(mu, m);
            let tabulated = table.eval(mu);
            assert!(exact.is_finite() && exact > 0.0, "N({mu}, {m}) = {exact}");
            assert!(tabulated.is_finite(), "table N({mu}, {m}) = {tabulated}");
            worst_table.record((tabulated - exact).abs() / exact, || {
                format!("m {m:e}, μ {mu:.3e}")
            });
        }
    }
    println!(
        "normalisation table: worst relative error {:.2e} at {}",
        worst_table.value, worst_table.at
    );
    assert!(
        worst_table.value < 2e-3,
        "{:e} at {}",
        worst_table.value,
        worst_table.at
    );
    // m(g) at both ends of the gloss range, for every index of the grid.
    for geometry in GlossGeometry::ALL {
        for &n in &INDICES {
            let flat = reading_from_exponent(geometry, n, GlossExponent::Finite(0.0))
                .expect("reading at m = 0");
            let sharpest = reading_from_exponent(geometry, n, GlossExponent::Finite(MAX_EXPONENT))
                .expect("reading at the largest m");
            let mirror =
                reading_from_exponent(geometry, n, GlossExponent::Mirror).expect("mirror reading");
            assert!(
                flat.is_finite() && flat >= 0.0 && flat <= sharpest && sharpest <= mirror,
                "{geometry} n {n}: {flat} ≤ {sharpest} ≤ {mirror}"
            );
            if n == 1.0 {
                // No interface, no specular reading: every gloss is the mirror's 0 GU.
                assert_eq!(mirror, 0.0);
                continue;
            }
            match exponent_from_reading(geometry, n, flat) {
                Ok(GlossExponent::Finite(m)) => assert!(m < 1e-6, "{geometry} n {n}: m = {m}"),
                other => panic!("{geometry} n {n}: lowest reading gives {other:?}"),
            }
            assert_eq!(
                exponent_from_reading(geometry, n, mirror),
                Ok(GlossExponent::Mirror)
            );
            assert!(matches!(
                exponent_from_reading(geometry, n, 0.5 * flat),
                Err(GlossError::BelowRange { .. })
            ));
            // A reading just below the mirror's (by 1e-4 of the range) is a finite,
            // sharp lobe.
            let near_mirror = mirror - 1e-4 * (mirror - flat);
            match exponent_from_reading(geometry, n, near_mirror) {
                Ok(GlossExponent::Finite(m)) => {
                    assert!(m.is_finite() && m > 1e3, "{geometry} n {n}: m = {m}")
                }
                other => panic!("{geometry} n {n}: {other:?}"),
            }
        }
    }
}

// ---------------------------------------------------------------------------
// Energy.

/// The spec's directional albedo (light arriving from ωi) in double precision:
/// R(μi) + body albedo, since the normalised lobe returns exactly R(μi).
#[test]
fn directional_albedo_is_at_most_one_at_every_corner() {
    let (model, corners) = packed_model(GlossExponent::Mirror, LobeKind::Normalised);
    let mut body = vec![0.0; corners.len()];
    let mut worst = Worst::default();
    let mut furnace = 0.0_f64;
    let mut mus: Vec<f64> = THETAS_DEG.iter().map(|&t| mu_of(t)).collect();
    mus.extend([6.123e-17, 1e-300]);
    for &mu in &mus {
        model.body_albedo(mu, &mut body);
        for (c, &b) in corners.iter().zip(&body) {
            let r = reflectance(mu, c.n);
            let albedo = r + b;
            let at = || format!("n {} τ {:e} ρ {} μ {mu:e}", c.n, c.tau, c.rho);
            assert!(b.is_finite() && b >= 0.0, "body albedo {b} at {}", at());
            assert!(albedo <= 1.0 + 1e-12, "albedo {albedo} at {}", at());
            worst.record(albedo, at);
            if c.rho == 1.0 {
                // ρ = 1: the body returns at most what entered, T(μ), and all of
                // it without absorption.
                let t = transmittance(mu, c.n);
                assert!(b <= t * (1.0 + 1e-12), "{b} > T {t} at {}", at());
                if c.tau == 0.0 {
                    furnace = furnace.max((b - t).abs());
                }
            }
        }
    }
    println!(
        "largest directional albedo (f64) {:.15} at {}; white furnace |body − T| ≤ {furnace:.1e}",
        worst.value, worst.at
    );
    assert!(furnace < 1e-11, "white furnace off by {furnace}");
}

/// The probability with which `bsdf` samples its lobe for the view `wo`, read back
/// from its density: pdf = p·lobe + (1 − p)·μi/π at a direction where the two
/// differ most (the lobe's peak or the normal).
fn specular_probability(bsdf: &dyn SpectralBsdf, wo: [f32; 3], m: GlossExponent) -> f64 {
    let mut weight = vec![0.0_f32; bsdf.len()];
    let GlossExponent::Finite(m) = m else {
        // The mirror's delta sample has pdf = p.
        let s = bsdf
            .sample(wo, [0.0, 0.5, 0.5], &mut weight)
            .expect("delta");
        assert!(s.delta);
        return f64::from(s.pdf);
    };
    let candidates = [[-wo[0], -wo[1], wo[2]], [0.0, 0.0, 1.0]];
    let (mut best, mut p) = (0.0, 0.5);
    for wi in candidates {
        let lobe = f64::from(phong_lobe_pdf(wo, wi, m as f32));
        let diffuse = f64::from(wi[2]) / PI;
        if (lobe - diffuse).abs() > best {
            best = (lobe - diffuse).abs();
            p = (f64::from(bsdf.pdf(wo, wi)) - diffuse) / (lobe - diffuse);
        }
    }
    p
}

/// Directional albedo of the renderer's f32 BSDF at `w` by a deterministic
/// quadrature built on its own sampler: each strategy on a `grid` × `grid` lattice
/// of (u1, u2), combined with the probability p it is picked with, i.e.
/// p·mean_lobe[g/pdf] + (1 − p)·mean_cosine[g/pdf] with the mixture pdf. Returns
/// (light side, view side): ∫ f(w, ω) cos θ dω (the spec's albedo) and
/// ∫ f(ω, w) cos θ dω (what a camera ray at w integrates).
fn sampled_albedo(bsdf: &dyn SpectralBsdf, w: [f32; 3], m: GlossExponent, grid: u32) -> (f64, f64) {
    let p = specular_probability(bsdf, w, m);
    let mut weight = vec![0.0_f32; bsdf.len()];
    let mut value = vec![0.0_f32; bsdf.len()];
    let (mut light, mut view) = (0.0, 0.0);
    for (u0, share) in [(0.0_f32, p), (1.0 - f32::EPSILON, 1.0 - p)] {
        let (mut l, mut v) = (0.0, 0.0);
        for a in 0..grid {
            for b in 0..grid {
                let u = [
                    u0,
                    (a as f32 + 0.5) / grid as f32,
                    (b as f32 + 0.5) / grid as f32,
                ];
                let Some(s) = bsdf.sample(w, u, &mut weight) else {
                    continue;
                };
                v += f64::from(weight[0]);
                if s.delta {
                    l += f64::from(weight[0]);
                } else {
                    bsdf.eval(w, s.wi, &mut value);
                    l += f64::from(value[0]) * f64::from(s.wi[2]) / f64::from(s.pdf);
                }
            }
        }
        let count = f64::from(grid * grid);
        light += share * l / count;
        view += share * v / count;
    }
    (light, view)
}

/// The renderer's tables and sampler at the corners: the light-side albedo agrees
/// with the f64 R + body albedo and stays ≤ 1 (+ the quadrature's own error); the
/// view side exceeds 1 only where the normalised lobe is not reciprocal (it is
/// measured and bounded, see the report).
#[test]
fn sampled_albedo_of_the_renderer_at_the_corners() {
    const GRID: u32 = 64;
    let mut worst_light_error = [Worst::default(), Worst::default()];
    let mut worst_light = [Worst::default(), Worst::default()];
    // Largest view-side albedo per lobe and n (ρ = 1, τ = 0, the white furnace).
    let mut view_excess = Vec::new();
    for (m, lobe) in [
        (GlossExponent::Finite(0.0), LobeKind::Normalised),
        (GlossExponent::Finite(MAX_EXPONENT), LobeKind::Normalised),
        (GlossExponent::Mirror, LobeKind::Normalised),
    ] {
        for &n in &INDICES {
            let mut furnace_view = Worst::default();
            for tau in [0.0, 1e-3, 1.0, 1e4] {
                for rho in [0.0, 1.0] {
                    let c = Corner { n, tau, rho };
                    let model = grey_model(c, m, lobe);
                    let mut body = [0.0];
                    for theta in [0.0, 30.0, 60.0, 85.0, 89.9] {
                        let w = to_f32(direction_mu(mu_of(theta), 0.0));
                        let mu = f64::from(w[2]);
                        model.body_albedo(mu, &mut body);
                        let exact = reflectance(mu, n) + body[0];
                        let (light, view) = sampled_albedo(model.spectral(), w, m, GRID);
                        let at = || {
                            format!(
                                "n {n} τ {tau:e} ρ {rho} {} θ {theta}°: f64 {exact:.6}, f32 {light:.6}",
                                lobe_name(m, lobe)
                            )
                        };
                        assert!(light.is_finite() && view.is_finite(), "{}", at());
                        let band = usize::from(theta > 85.0);
                        worst_light_error[band].record((light - exact).abs(), at);
                        worst_light[band].record(light, at);
                        if rho == 1.0 && tau == 0.0 {
                            furnace_view.record(view, || format!("{theta}°"));
                        }
                    }
                }
            }
            view_excess.push((lobe_name(m, lobe), n, furnace_view));
        }
    }
    println!("renderer's light-side albedo by sampler quadrature ({GRID}² per strategy):");
    for (band, name) in ["θ ≤ 85°", "θ = 89.9°"].iter().enumerate() {
        println!(
            "  {name}: worst |f32 − f64| {:.2e} at {}; largest {:.6} at {}",
            worst_light_error[band].value,
            worst_light_error[band].at,
            worst_light[band].value,
            worst_light[band].at
        );
    }
    println!("view-side albedo, white furnace (ρ = 1, τ = 0), largest over θ:");
    for (name, n, w) in &view_excess {
        println!("  {name}, n {n}: {:.4} at {}", w.value, w.at);
    }
    // Light side: the f32 tables' error (N and R interpolated in sqrt μ: 1.9e-3 at
    // 89.9°) plus the lattice's own error at the lobe's horizon cut.
    for (band, tolerance) in [(0, 1e-3), (1, 3e-3)] {
        assert!(
            worst_light_error[band].value < tolerance,
            "{}",
            worst_light_error[band].at
        );
        assert!(
            worst_light[band].value <= 1.0 + tolerance,
            "{}",
            worst_light[band].at
        );
    }
    // View side: exact for the mirror, nearly so for the sharpest lobe; up to 10 %
    // over for the flat lobe (m = 0), where R(μi)/N(μi) varies most with μi.
    for (name, n, w) in &view_excess {
        let bound = if name.starts_with("m = 0") {
            0.11
        } else {
            3e-3
        };
        assert!(
            w.value <= 1.0 + bound,
            "{name}, n {n}: view side {} at {}",
            w.value,
            w.at
        );
    }
}

// ---------------------------------------------------------------------------
// Renders of extreme designs.

const RENDER_WAVELENGTHS: usize = 8;

/// The paint render of `scene` with `seed` and `spp` samples per pixel.
fn render_film(
    scene: Scene,
    environment: &Environment,
    model: &PaintModel,
    camera: Camera,
    seed: u64,
    spp: u32,
) -> Film {
    let settings = RenderSettings::seeded(seed);
    progressive::render_film(
        scene,
        environment.clone(),
        model,
        ShadingModel::Paint,
        camera,
        settings,
        spp,
    )
}

/// Every pixel finite and ≥ 0 in X, Y and Z, and no sample rejected as non-finite.
fn assert_finite(film: &Film, what: &str) {
    assert_eq!(film.rejected_samples(), 0, "{what}: non-finite samples");
    for y in 0..film.height() {
        for x in 0..film.width() {
            let m = film.mean_xyz(x, y);
            for v in [m.x, m.y, m.z] {
                assert!(v.is_finite() && v >= 0.0, "{what}: pixel {x},{y} = {m:?}");
            }
        }
    }
}

/// Mean luminance over `pixels` and its standard error.
fn region_mean(film: &Film, pixels: &[(u32, u32)]) -> (f64, f64) {
    let (mut sum, mut var) = (0.0, 0.0);
    for &(x, y) in pixels {
        sum += film.mean_xyz(x, y).y;
        var += film.variance_of_mean_xyz(x, y)[1];
    }
    let n = pixels.len() as f64;
    (sum / n, var.sqrt() / n)
}

fn design(rho: f64, n: f64, tau: f64, m: GlossExponent) -> PaintModel {
    let grid = WavelengthGrid::visible(RENDER_WAVELENGTHS).expect("grid");
    // h = 40 µm, k = τ/h: the user's two knobs, at their extremes.
    PaintModel::new(PaintParams::grey(
        grid,
        rho,
        n,
        tau / 40.0,
        40.0,
        GlossSetting::Exponent(m),
    ))
    .expect("extreme design")
}

/// The default car in the studio, one design after another: finite, nothing
/// rejected, and the body's mean luminance ordered as the physics says.
#[test]
fn extreme_designs_render_the_car_finite_and_plausible() {
    let (w, h, spp) = (48, 27, 16);
    let scene = generate(&CarParameters::default());
    let camera = Camera::framing(scene.mesh.bounds().expect("bounds"), w, h);
    let grid = WavelengthGrid::visible(RENDER_WAVELENGTHS).expect("grid");
    let environment = Environment::studio(&grid);
    // Pixels whose whole footprint (4 × 4 rays) sees the painted body first.
    let body_pixels: Vec<(u32, u32)> = {
        let traced = RenderScene::new(scene.clone()).expect("scene");
        let mut out = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let all_body = (0..16).all(|k| {
                    let (px, py) = (
                        x as f32 + (k % 4) as f32 / 4.0 + 0.125,
                        y as f32 + (k / 4) as f32 / 4.0 + 0.125,
                    );
                    let (o, d) = camera.ray(px, py);
                    matches!(
                        traced.geometry().intersect(o, d, f32::INFINITY).map(|hit| hit.surface),
                        Some(Surface::Mesh { material }) if material == BODY
                    )
                });
                if all_body {
                    out.push((x, y));
                }
            }
        }
        out
    };
    assert!(
        body_pixels.len() > 60,
        "only {} body pixels",
        body_pixels.len()
    );
    let gloss = GlossExponent::Finite(1000.0);
    let designs = [
        ("ρ = 1, n = 3, k = 0", design(1.0, 3.0, 0.0, gloss), 1),
        ("ρ = 0", design(0.0, 1.5, 0.02, gloss), 2),
        ("ρ = 1, τ = 1e4", design(1.0, 1.5, 1e4, gloss), 3),
        ("mirror", design(0.5, 1.5, 0.02, GlossExponent::Mirror), 4),
        (
            "matte (m = 0)",
            design(0.5, 1.5, 0.02, GlossExponent::Finite(0.0)),
            5,
        ),
        ("ρ = 0.5, m = 1000", design(0.5, 1.5, 0.02, gloss), 6),
    ];
    let mut body = Vec::new();
    for (name, model, seed) in &designs {
        let film = render_film(
            scene.clone(),
            &environment,
            model,
            camera.clone(),
            *seed,
            spp,
        );
        assert_finite(&film, name);
        let (mean, se) = region_mean(&film, &body_pixels);
        let mut luminances: Vec<f64> = body_pixels
            .iter()
            .map(|&(x, y)| film.mean_xyz(x, y).y)
            .collect();
        luminances.sort_by(f64::total_cmp);
        let p99 = luminances[luminances.len() * 99 / 100];
        let median = luminances[luminances.len() / 2];
        println!(
            "car, {name}: body Y {mean:.5} ± {se:.5} over {} pixels; 99th percentile / median {:.2}",
            body_pixels.len(),
            p99 / median.max(1e-12)
        );
        if std::env::var_os("COATLAB_EXTREMES_PNG").is_some() {
            let path = std::env::temp_dir().join(format!("extremes-car-{seed}.png"));
            film.write_png(&path, &Default::default()).expect("png");
        }
        body.push((mean, se, p99 / median.max(1e-12)));
    }
    let z =
        |a: (f64, f64, f64), b: (f64, f64, f64)| (a.0 - b.0) / (a.1.powi(2) + b.1.powi(2)).sqrt();
    let [white, black, opaque, mirror, matte, mid] = body[..] else {
        unreachable!()
    };
    // ρ = 0 is darker than ρ = 1.
    assert!(z(white, black) > 10.0, "ρ = 1 {white:?} vs ρ = 0 {black:?}");
    // An opaque coat hides the pigment: the body reads like the black one (another
    // seed), and its specular reflection is still there.
    assert!(
        z(opaque, black).abs() < 4.0,
        "τ = 1e4 {opaque:?} vs ρ = 0 {black:?}"
    );
    assert!(
        opaque.0 > 10.0 * opaque.1,
        "τ = 1e4: no specular left {opaque:?}"
    );
    assert!(
        z(mid, opaque) > 10.0,
        "ρ = 0.5 {mid:?} vs τ = 1e4 {opaque:?}"
    );
    // The mirror concentrates its reflection into sharp images of the softboxes;
    // the matte coat (m = 0) spreads it: its brightest body pixels stand out less.
    assert!(
        mirror.2 > 2.0 * matte.2,
        "highlight contrast: mirror {mirror:?}, matte {matte:?}"
    );
}

const SPHERE_SIZE: u32 = 32;

/// Sphere pixels whose 4 × 4 footprint rays all hit it with a view cosine ≥ `min_mu`,
/// with the view cosines and the mirror-reflected directions of those rays.
/// A sphere pixel and its footprint rays: (view cosine, reflected direction).
type SpherePixel = ((u32, u32), Vec<(f64, [f64; 3])>);

fn sphere_pixels(camera: &Camera, min_mu: f64) -> Vec<SpherePixel> {
    let mut out = Vec::new();
    for y in 0..SPHERE_SIZE {
        for x in 0..SPHERE_SIZE {
            let rays: Option<Vec<(f64, [f64; 3])>> = (0..16)
                .map(|k| {
                    let (px, py) = (
                        x as f32 + (k % 4) as f32 / 4.0 + 0.125,
                        y as f32 + (k / 4) as f32 / 4.0 + 0.125,
                    );
                    let (n, d) = sphere_hit(camera, px, py)?;
                    let mu = -(n[0] * d[0] + n[1] * d[1] + n[2] * d[2]);
                    let r = [
                        d[0] + 2.0 * mu * n[0],
                        d[1] + 2.0 * mu * n[1],
                        d[2] + 2.0 * mu * n[2],
                    ];
                    (mu >= min_mu).then_some((mu, r))
                })
                .collect();
            if let Some(rays) = rays {
                out.push(((x, y), rays));
            }
        }
    }
    out
}

/// The white furnace with ρ = 1, n = 3, k = 0: with the mirror lobe the sphere
/// returns exactly what it receives and vanishes (every pixel 1 within its noise);
/// with a finite lobe (m = 1000) it reads at most 1 + the view-side excess of the
/// normalised lobe, measured by the sampler quadrature for the same design.
#[test]
fn white_furnace_with_a_high_index_white_design() {
    let grid = WavelengthGrid::visible(RENDER_WAVELENGTHS).expect("grid");
    let camera = sphere_camera(SPHERE_SIZE);
    let pixels = sphere_pixels(&camera, 0.1);
    assert!(pixels.len() > 300, "{} pixels", pixels.len());
    for (m, spp) in [
        (GlossExponent::Mirror, 64),
        (GlossExponent::Finite(1000.0), 64),
    ] {
        let model = design(1.0, 3.0, 0.0, m);
        let film = render_film(
            sphere(48),
            &Environment::uniform(&grid),
            &model,
            camera.clone(),
            7,
            spp,
        );
        assert_finite(&film, "furnace");
        // The largest view-side albedo of this design over view angles, f32.
        let excess = (0..=18)
            .map(|k| {
                let mu = 0.1 + 0.05 * k as f64;
                let w = to_f32(direction_mu(mu, 0.0));
                sampled_albedo(model.spectral(), w, m, 64).1
            })
            .fold(0.0_f64, f64::max);
        let (mut worst_z, mut above) = (0.0_f64, 0.0_f64);
        let (mut sum, mut var) = (0.0, 0.0);
        for ((x, y), _) in &pixels {
            let (mean, v) = (
                film.mean_xyz(*x, *y).y,
                film.variance_of_mean_xyz(*x, *y)[1],
            );
            sum += mean;
            var += v;
            worst_z = worst_z.max((mean - 1.0) / v.sqrt().max(1e-9));
            above = above.max(mean);
        }
        let n = pixels.len() as f64;
        let (mean, se) = (sum / n, var.sqrt() / n);
        println!(
            "furnace, ρ = 1, n = 3, k = 0, {}: sphere mean {mean:.5} ± {se:.5}, largest pixel {above:.4}, \
             worst Z above 1 {worst_z:.2}; the sampler's largest view-side albedo {excess:.5}",
            lobe_name(m, LobeKind::Normalised)
        );
        match m {
            GlossExponent::Mirror => {
                assert!((mean - 1.0).abs() < 4.0 * se + 1e-3, "{mean} ± {se}");
                assert!(worst_z < 5.0, "a pixel {worst_z}σ above 1");
            }
            GlossExponent::Finite(_) => {
                assert!(excess < 1.02, "view-side albedo {excess}");
                assert!(mean < excess + 4.0 * se + 1e-3, "{mean} ± {se} vs {excess}");
            }
        }
    }
}

/// A perfect mirror coat (ρ = 0, so the body adds nothing) shows the studio: each
/// sphere pixel whose reflections go up into the sky (not the floor) has the
/// luminance of R(μ)·L(reflected direction), averaged over its footprint.
#[test]
fn a_perfect_mirror_shows_the_environment() {
    let grid = WavelengthGrid::visible(RENDER_WAVELENGTHS).expect("grid");
    let camera = sphere_camera(SPHERE_SIZE);
    let environment = Environment::studio(&grid);
    let model = design(0.0, 1.5, 0.0, GlossExponent::Mirror);
    let film = render_film(sphere(48), &environment, &model, camera.clone(), 3, 32);
    assert_finite(&film, "mirror sphere");
    let mut radiance = vec![0.0_f32; grid.len()];
    let (mut predicted, mut rendered, mut variance) = (Vec::new(), Vec::new(), 0.0);
    for ((x, y), rays) in sphere_pixels(&camera, 0.05) {
        if rays.iter().any(|(_, r)| r[1] < 0.02) {
            continue;
        }
        let mut sum = 0.0;
        for (mu, r) in &rays {
            environment.radiance(to_f32(*r), &mut radiance);
            let reflectance = reflectance(*mu, 1.5) as f32;
            radiance.iter_mut().for_each(|v| *v *= reflectance);
            sum += film.xyz_of(&radiance).y;
        }
        predicted.push(sum / rays.len() as f64);
        rendered.push(film.mean_xyz(x, y).y);
        variance += film.variance_of_mean_xyz(x, y)[1];
    }
    let count = predicted.len() as f64;
    assert!(count > 100.0, "{count} pixels");
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (mp, mr) = (mean(&predicted), mean(&rendered));
    let covariance: f64 = predicted
        .iter()
        .zip(&rendered)
        .map(|(p, r)| (p - mp) * (r - mr))
        .sum();
    let spread = |v: &[f64], m: f64| v.iter().map(|x| (x - m).powi(2)).sum::<f64>().sqrt();
    let correlation = covariance / (spread(&predicted, mp) * spread(&rendered, mr));
    println!(
        "mirror sphere in the studio: {count} pixels, rendered mean Y {mr:.5} ± {:.5}, predicted {mp:.5}, \
         correlation {correlation:.4}",
        variance.sqrt() / count
    );
    assert!(correlation > 0.95, "correlation {correlation}");
    // Pixel-footprint averaging with 16 rays is the prediction's own error.
    assert!(
        (mr / mp - 1.0).abs() < 0.05,
        "rendered {mr} vs predicted {mp}"
    );
}

/// The sampler at every corner, lobe and view (down to the horizon), with random
/// numbers at their ends: a sample is either lost (`None`) or has a finite unit
/// direction above the surface, a finite positive density that `pdf` reproduces,
/// and finite non-negative weights equal to f·cos θi/pdf; wherever f > 0 the density
/// is > 0 (MIS never meets a zero density where there is light).
#[test]
fn sampler_at_the_corners() {
    let ends = [0.0_f32, 1e-7, 0.5, 1.0 - 1e-7, 1.0 - f32::EPSILON / 2.0];
    let (mut samples, mut lost, mut deltas) = (0_usize, 0_usize, 0_usize);
    let mut value = [0.0_f32];
    let mut weight = [0.0_f32];
    for (m, lobe) in lobe_cases() {
        for c in corners() {
            let model = grey_model(c, m, lobe);
            let bsdf = model.spectral();
            for &theta in &THETAS_DEG {
                let wo = to_f32(direction_mu(mu_of(theta), 30.0));
                for &u0 in &ends {
                    for &u1 in &ends {
                        for &u2 in &ends {
                            let at = || {
                                format!(
                                    "n {} τ {:e} ρ {} {}; θo {theta}°, u {u0} {u1} {u2}",
                                    c.n,
                                    c.tau,
                                    c.rho,
                                    lobe_name(m, lobe)
                                )
                            };
                            samples += 1;
                            let Some(s) = bsdf.sample(wo, [u0, u1, u2], &mut weight) else {
                                lost += 1;
                                continue;
                            };
                            let length = s.wi.iter().map(|x| x * x).sum::<f32>().sqrt();
                            assert!(
                                s.wi.iter().all(|x| x.is_finite())
                                    && (length - 1.0).abs() < 1e-5
                                    && s.wi[2] > 0.0,
                                "direction {:?}: {}",
                                s.wi,
                                at()
                            );
                            assert!(s.pdf.is_finite() && s.pdf > 0.0, "pdf {}: {}", s.pdf, at());
                            assert!(
                                weight[0].is_finite() && weight[0] >= 0.0,
                                "weight {}: {}",
                                weight[0],
                                at()
                            );
                            if s.delta {
                                assert_eq!(m, GlossExponent::Mirror, "{}", at());
                                deltas += 1;
                                continue;
                            }
                            let pdf = bsdf.pdf(wo, s.wi);
                            assert!(
                                (pdf - s.pdf).abs() <= 1e-6 * s.pdf,
                                "pdf {pdf} vs {}: {}",
                                s.pdf,
                                at()
                            );
                            bsdf.eval(s.wi, wo, &mut value);
                            let expected = value[0] * s.wi[2] / s.pdf;
                            assert!(
                                (weight[0] - expected).abs() <= 1e-5 * expected.max(1e-30),
                                "weight {} vs {expected}: {}",
                                weight[0],
                                at()
                            );
                        }
                    }
                }
                // Density wherever there is light, on a few fixed directions.
                for wi in [
                    [0.0_f32, 0.0, 1.0],
                    [-wo[0], -wo[1], wo[2]],
                    [0.6, 0.0, 0.8],
                ] {
                    if wo[2] <= 0.0 {
                        break;
                    }
                    bsdf.eval(wi, wo, &mut value);
                    if value[0] > 0.0 {
                        assert!(
                            bsdf.pdf(wo, wi) > 0.0,
                            "f > 0, pdf 0 at n {} τ {} ρ {}",
                            c.n,
                            c.tau,
                            c.rho
                        );
                    }
                }
            }
        }
    }
    println!(
        "sampler: {samples} samples, {lost} lost (below the surface or view at the horizon), {deltas} mirror"
    );
    // A view exactly at the horizon has nothing to sample.
    assert!(lost > 0 && samples > 500_000);
}

#[path = "support/bsdf_chi_square.rs"]
mod bsdf_chi_square;

/// `sampler_at_the_corners` checks that the sampler's densities are consistent with
/// `pdf`, which a density wrong in both (`sample` weighs its samples with `pdf`)
/// passes. This checks the distribution of the samples itself at corners of the
/// domain: the specular probability at both clamps (0.05 with no Fresnel
/// reflection, 0.95 with no body), the flattest lobes (m = 0, both kinds), the
/// mirror's diffuse part, views from the normal to 89°, where half of the flat
/// lobe falls below the horizon. (The sharpest lobe, m = 10⁹, is narrower than any
/// bin the quadrature of the expected counts could resolve; its density is checked
/// pointwise in `the_sharpest_lobes_agree_around_their_peak`.)
///
/// The family of 36 tests uses p > 1e-4 (a 0.4 % chance that a correct sampler
/// fails one, with fixed seeds a fixed outcome); the negative control, the density
/// ×1.1 on half of the azimuths (renormalised), must reach p < 1e-9 in every case
/// where directions (not the mirror's delta) take most of the samples.
#[test]
fn sampler_density_at_the_corners() {
    use bsdf_chi_square::{Bins, Perturbation, bin_probabilities, pearson, perturb, sample_counts};
    const BINS: Bins = Bins { mu: 32, phi: 64 };
    // At 2·10⁵ samples the control reached only p = 1.4e-7 (measured).
    const SAMPLES: usize = 500_000;
    let corners = [
        Corner {
            n: 1.0,
            tau: 0.0,
            rho: 1.0,
        },
        Corner {
            n: 4.0,
            tau: 0.0,
            rho: 0.0,
        },
        Corner {
            n: 1.0001,
            tau: 1e4,
            rho: 1.0,
        },
        Corner {
            n: 4.0,
            tau: 1e-3,
            rho: 1.0,
        },
    ];
    let (mut worst_null, mut worst_control, mut controls) = (1.0_f64, 0.0_f64, 0);
    for (m, lobe) in [
        (GlossExponent::Finite(0.0), LobeKind::Normalised),
        (GlossExponent::Finite(0.0), LobeKind::Paper),
        (GlossExponent::Mirror, LobeKind::Normalised),
    ] {
        for c in corners {
            let model = grey_model(c, m, lobe);
            let bsdf = model.spectral();
            for theta in [0.0, 60.0, 89.0] {
                let wo = to_f32(direction_mu(mu_of(theta), 30.0));
                let pdf = |wi| f64::from(bsdf.pdf(wo, wi));
                let at = format!(
                    "n {} τ {:e} ρ {} {} θo {theta}°",
                    c.n,
                    c.tau,
                    c.rho,
                    lobe_name(m, lobe)
                );
                let observed = sample_counts(bsdf, wo, BINS, SAMPLES, 5);
                let mut expected = bin_probabilities(&pdf, BINS);
                let null = pearson(&observed, &expected);
                assert!(null.p_value > 1e-4, "{at}: {null:?}");
                worst_null = worst_null.min(null.p_value);
                if expected[expected.len() - 1] > 0.5 {
                    // The mirror's delta takes 95 % of the samples: a 10 % error in
                    // the other 5 % is not what this control is about.
                    continue;
                }
                let wrong = Perturbation::HalfDomain { factor: 1.1 };
                perturb(&mut expected, BINS, wo, wrong);
                let control = pearson(&observed, &expected);
                assert!(
                    control.p_value < 1e-9,
                    "{at}: a 10 % density error passed: {control:?}"
                );
                worst_control = worst_control.max(control.p_value);
                controls += 1;
            }
        }
    }
    println!(
        "sampler χ² at the corners: smallest p {worst_null:.2e}; 10 % error on half the azimuths: largest p {worst_control:.2e} ({controls} cases)"
    );
    // Every case but the 7 where the mirror's delta takes most samples.
    assert_eq!(controls, 29, "cases with a negative control");
}
