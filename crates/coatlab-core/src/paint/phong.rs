//! The comparison model: energy-normalised (Lafortune–Willems) Phong (spec 5).
//!
//!   f_phong = kd(λ)/π + ks(λ)·(m + 2)/(2π)·max(0, ωo·ωr)^m
//!
//! | parameter | unit | range | meaning |
//! | --- | --- | --- | --- |
//! | kd(λ) | — | [0, 1] | diffuse albedo |
//! | ks(λ) | — | [0, 1] | specular albedo at normal incidence |
//! | m | — | [0, 1e9] | lobe exponent |
//!
//! Two ways to set the parameters from a paint design:
//!
//! - **naive**: kd = the body's directional albedo at normal incidence, ks = R(0°)
//!   (per wavelength), m = m(g) — what a renderer that knows only Phong is given;
//! - **best fit**: kd(λ) ≥ 0, one grey ks ≥ 0 and m fitted in the least-squares
//!   sense, ∫∫ (·)² cos θo dωo over incidence angles 0°, 10°, …, 80° and every
//!   wavelength, part by part: kd(λ)/π to the paint's body term, ks·(m + 2)/(2π)·
//!   cos^m α to its specular term R·D/N.
//!
//! The body part has a closed form: setting the derivative of
//! Σᵢ ∫ (kd/π − f_body(θi, ωo))² cos θo dωo to zero gives kd(λ) = the mean over the
//! nine incidence angles of the body's directional albedo, which the model has
//! exactly (`PaintModel::body_albedo`); no quadrature is involved.
//!
//! The specular part depends only on n(λ), the paint's m and its lobe — not on ρ,
//! k or h — so it is kept in a small process-wide cache keyed on those: an edit of
//! the pigment or the coat's absorption refits kd alone (microseconds). The
//! hemisphere integral is a fixed quadrature: 512 cosine-distributed Hammersley
//! directions plus 512 from the paint's own lobe, combined with the balance
//! heuristic. For fixed m the best ks is closed form; m is found by golden-section
//! search in ln m within a factor e⁴ of the paint's m, on the specular residual.
//! Because the paint's specular term is R(θi, n(λ))·D(ωo), the residual summed over
//! wavelengths needs only ΣR and ΣR² per incidence, so one trial m costs one
//! exp per quadrature direction (≈ 9 000), not one per direction and wavelength.
//! The specular residual at each incidence is divided by the square of the paint
//! lobe's peak there, so every angle counts alike (unweighted, the 80° peaks —
//! R ≈ 0.4 under a lobe normalised over a clipped hemisphere — decided ks alone:
//! 0.41 for a coat whose R is 0.04 over most angles). Why part by part: a joint fit
//! of kd and ks is ill-conditioned for glossy paints, whose lobe values (~m/2π per
//! sr) outweigh the body's by orders of magnitude in the squared error, so kd
//! absorbed the quadrature's error in the lobe (the signal-red preset, m ≈ 36 000,
//! came out with kd = 19 in the blue and 0 in the red: a blue car). A mirror paint
//! has no lobe to fit: its best-fit Phong takes the body fit, ks = the mean R over
//! the incidence angles, and m = 1e9.
//!
//! `PhongParams::fit_residual_rms` reports the whole BRDF's remaining residual on
//! the same quadrature (a diagnostic, computed only when asked for: it needs the
//! body term at every direction and wavelength).

use std::collections::VecDeque;
use std::f64::consts::PI;
use std::sync::Mutex;

use super::coat::body_brdf;
use super::fresnel::reflectance;
use super::gloss::{GlossExponent, MAX_EXPONENT};
use super::lobe::{
    LobeKind, mirror, one_minus_cos_to_mirror, paper_lobe, phong_lobe, phong_lobe_pdf,
    phong_normalisation, sample_phong_lobe,
};
use super::model::{BsdfSample, PaintModel, SpectralBsdf, cosine_hemisphere, weigh_sample};

/// Which parameter set a Phong model was made with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PhongVariant {
    /// kd = body albedo at 0°, ks = R(0°), m = m(g).
    Naive,
    /// Least-squares fit to the paint BRDF.
    BestFit,
}

impl PhongVariant {
    /// The label the UI and the CLI show.
    pub fn label(self) -> &'static str {
        match self {
            PhongVariant::Naive => "Phong (naive)",
            PhongVariant::BestFit => "Phong (best fit)",
        }
    }
}

/// Phong parameters on the paint's wavelength grid.
#[derive(Debug, Clone, PartialEq)]
pub struct PhongParams {
    /// How they were obtained.
    pub variant: PhongVariant,
    /// kd(λ).
    pub diffuse: Vec<f64>,
    /// ks(λ).
    pub specular: Vec<f64>,
    /// m.
    pub exponent: f64,
}

/// Incidence angles of the best fit, degrees.
const FIT_INCIDENCE_DEG: [f64; 9] = [0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0];
/// Directions per strategy in the best fit's hemisphere quadrature.
const FIT_DIRECTIONS: usize = 512;
/// Golden-section steps of the search for m: the bracket of 8 in ln(1 + m) shrinks
/// to 8·0.618⁴⁰ ≈ 3e-8.
const FIT_GOLDEN_STEPS: usize = 40;
/// Specular fits kept for reuse (a designer alternates between a few coats at most).
const SPECULAR_CACHE_ENTRIES: usize = 8;

fn finite_exponent(model: &PaintModel) -> f64 {
    match model.exponent() {
        GlossExponent::Finite(m) => m,
        GlossExponent::Mirror => MAX_EXPONENT,
    }
}

impl PhongParams {
    /// The naive translation of a paint design.
    pub fn naive(model: &PaintModel) -> Self {
        let len = model.channels().len();
        let mut diffuse = vec![0.0; len];
        model.body_albedo(1.0, &mut diffuse);
        let specular = model
            .refractive_index()
            .iter()
            .map(|&n| reflectance(1.0, n))
            .collect();
        Self {
            variant: PhongVariant::Naive,
            diffuse,
            specular,
            exponent: finite_exponent(model),
        }
    }

    /// The least-squares fit to the paint BRDF (see the module documentation).
    pub fn best_fit(model: &PaintModel) -> Self {
        let len = model.channels().len();
        let SpecularFit { ks, exponent } = specular_fit(model);
        Self {
            variant: PhongVariant::BestFit,
            diffuse: fitted_diffuse(model),
            specular: vec![ks; len],
            exponent,
        }
    }

    /// The root-mean-square difference between this Phong and the paint BRDF, 1/sr:
    /// cosine-weighted over the hemisphere on the best fit's quadrature, averaged
    /// over its incidence angles and the wavelengths. Costs what the body term at
    /// ~9 000 directions × every wavelength costs (tens of milliseconds): a
    /// diagnostic, not part of the fit.
    pub fn fit_residual_rms(&self, model: &PaintModel) -> f64 {
        let quadrature = Quadrature::new(model);
        let len = model.channels().len();
        let mut paint = vec![0.0; len];
        let mut phong = vec![0.0; len];
        let (mut residual, mut weight) = (0.0, 0.0);
        for q in &quadrature.points {
            let wi = quadrature.incidences[q.incidence].wi;
            model_eval_fit(model, wi, q.wo, q.paint_lobe, &mut paint);
            self.eval(wi, q.wo, &mut phong);
            residual += q.weight
                * paint
                    .iter()
                    .zip(&phong)
                    .map(|(p, f)| (f - p) * (f - p))
                    .sum::<f64>();
            weight += q.weight;
        }
        (residual / (weight * len as f64)).sqrt()
    }

    /// f_phong per wavelength in double precision, 1/sr.
    pub fn eval(&self, wi: [f64; 3], wo: [f64; 3], out: &mut [f64]) {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            out.iter_mut().for_each(|o| *o = 0.0);
            return;
        }
        let lobe = (self.exponent + 2.0) / (2.0 * PI) * phong_lobe(wi, wo, self.exponent);
        for ((o, kd), ks) in out.iter_mut().zip(&self.diffuse).zip(&self.specular) {
            *o = kd / PI + ks * lobe;
        }
    }

    /// The renderer's single-precision form.
    pub fn spectral(&self) -> SpectralPhong {
        let mean_kd: f64 = self.diffuse.iter().sum::<f64>() / self.diffuse.len().max(1) as f64;
        let mean_ks: f64 = self.specular.iter().sum::<f64>() / self.specular.len().max(1) as f64;
        let p = if mean_kd + mean_ks > 0.0 {
            mean_ks / (mean_kd + mean_ks)
        } else {
            0.5
        };
        SpectralPhong::new(
            self.diffuse.iter().map(|k| (k / PI) as f32).collect(),
            self.specular.iter().map(|&k| k as f32).collect(),
            self.exponent as f32,
            p.clamp(0.05, 0.95) as f32,
            PhongNormalisation::Energy,
        )
    }
}

/// The paint BRDF the fit compares with: the body plus R·(the fit quadrature's lobe
/// value), per wavelength, 1/sr.
fn model_eval_fit(model: &PaintModel, wi: [f64; 3], wo: [f64; 3], lobe: f64, out: &mut [f64]) {
    for (i, o) in out.iter_mut().enumerate() {
        let n = model.refractive_index()[i];
        let body = body_brdf(
            model.albedo()[i],
            n,
            model.optical_depth()[i],
            model.coat_integral()[i],
            wi[2],
            wo[2],
        );
        *o = body + reflectance(wi[2], n) * lobe;
    }
}

/// kd(λ) of the best fit: the mean body albedo over the fit's incidence angles
/// (the exact least-squares solution; see the module documentation).
fn fitted_diffuse(model: &PaintModel) -> Vec<f64> {
    let len = model.channels().len();
    let mut sum = vec![0.0; len];
    let mut albedo = vec![0.0; len];
    for theta in FIT_INCIDENCE_DEG {
        model.body_albedo(theta.to_radians().cos(), &mut albedo);
        sum.iter_mut().zip(&albedo).for_each(|(s, a)| *s += a);
    }
    sum.iter()
        .map(|s| (s / FIT_INCIDENCE_DEG.len() as f64).max(0.0))
        .collect()
}

/// The fitted grey ks and exponent m.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SpecularFit {
    ks: f64,
    exponent: f64,
}

/// What the specular fit depends on, bit for bit: n(λ) on the grid, the paint's m
/// (or the mirror) and the lobe.
#[derive(Debug, Clone, PartialEq, Eq)]
struct SpecularKey {
    index_bits: Vec<u64>,
    exponent_bits: Option<u64>,
    lobe: LobeKind,
}

impl SpecularKey {
    fn of(model: &PaintModel) -> Self {
        Self {
            index_bits: model
                .refractive_index()
                .iter()
                .map(|n| n.to_bits())
                .collect(),
            exponent_bits: match model.exponent() {
                GlossExponent::Finite(m) => Some(m.to_bits()),
                GlossExponent::Mirror => None,
            },
            lobe: model.lobe(),
        }
    }
}

/// Recent specular fits, newest last.
static SPECULAR_CACHE: Mutex<VecDeque<(SpecularKey, SpecularFit)>> = Mutex::new(VecDeque::new());

/// ks and m for the model, from the cache or fitted (and then remembered).
fn specular_fit(model: &PaintModel) -> SpecularFit {
    let key = SpecularKey::of(model);
    // A poisoned lock only means another thread panicked mid-update of a list of
    // plain values; the entries are still whole.
    let lookup = |key: &SpecularKey| {
        let cache = SPECULAR_CACHE.lock().unwrap_or_else(|e| e.into_inner());
        cache.iter().find(|(k, _)| k == key).map(|(_, fit)| *fit)
    };
    if let Some(fit) = lookup(&key) {
        return fit;
    }
    // Fitted outside the lock: two threads may both fit the same coat once.
    let fit = fit_specular(model);
    let mut cache = SPECULAR_CACHE.lock().unwrap_or_else(|e| e.into_inner());
    if !cache.iter().any(|(k, _)| *k == key) {
        if cache.len() == SPECULAR_CACHE_ENTRIES {
            cache.pop_front();
        }
        cache.push_back((key, fit));
    }
    fit
}

/// The specular fit itself (no cache).
fn fit_specular(model: &PaintModel) -> SpecularFit {
    let len = model.channels().len();
    if matches!(model.exponent(), GlossExponent::Mirror) {
        // No lobe to fit: the mirror's mean Fresnel reflectance on a needle-sharp
        // lobe.
        let mean_r: f64 = FIT_INCIDENCE_DEG
            .iter()
            .map(|t| {
                let mu = t.to_radians().cos();
                model
                    .refractive_index()
                    .iter()
                    .map(|&n| reflectance(mu, n))
                    .sum::<f64>()
                    / len as f64
            })
            .sum::<f64>()
            / FIT_INCIDENCE_DEG.len() as f64;
        return SpecularFit {
            ks: mean_r,
            exponent: MAX_EXPONENT,
        };
    }
    let sums = SpecularSums::new(&Quadrature::new(model));
    let paint_m = finite_exponent(model);
    // Golden-section search on ln(1 + m).
    let lo0 = (paint_m.ln_1p() - 4.0).max(0.0);
    let hi0 = (paint_m.ln_1p() + 4.0).min(MAX_EXPONENT.ln_1p());
    let cost = |x: f64| sums.solve(x.exp_m1()).1;
    let golden = 0.5 * (5.0_f64.sqrt() - 1.0);
    let (mut lo, mut hi) = (lo0, hi0);
    let mut x1 = hi - golden * (hi - lo);
    let mut x2 = lo + golden * (hi - lo);
    let (mut f1, mut f2) = (cost(x1), cost(x2));
    for _ in 0..FIT_GOLDEN_STEPS {
        if f1 <= f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - golden * (hi - lo);
            f1 = cost(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + golden * (hi - lo);
            f2 = cost(x2);
        }
    }
    let exponent = (0.5 * (lo + hi)).exp_m1();
    SpecularFit {
        ks: sums.solve(exponent).0,
        exponent,
    }
}

/// One incidence angle of the fit.
struct Incidence {
    wi: [f64; 3],
    /// ΣR(θi, n(λ)) and ΣR² over the wavelengths.
    r_sum: f64,
    r2_sum: f64,
    /// 1 / (the peak of the paint's specular part at this incidence)², so every
    /// incidence angle counts alike in the specular fit.
    specular_scale: f64,
}

/// One direction of the hemisphere quadrature.
struct QuadraturePoint {
    incidence: usize,
    wo: [f64; 3],
    /// Quadrature weight (cos θo included), sr.
    weight: f64,
    /// The paint's lobe value D/N (or the paper's lobe) there, 1/sr.
    paint_lobe: f64,
}

/// The best fit's fixed quadrature over the fit's incidence angles.
struct Quadrature {
    incidences: Vec<Incidence>,
    points: Vec<QuadraturePoint>,
    /// Wavelengths of the model's grid.
    wavelengths: usize,
}

impl Quadrature {
    fn new(model: &PaintModel) -> Self {
        let len = model.channels().len();
        let paint_m = finite_exponent(model);
        let is_mirror = matches!(model.exponent(), GlossExponent::Mirror);
        let mut incidences = Vec::with_capacity(FIT_INCIDENCE_DEG.len());
        let mut points = Vec::with_capacity(FIT_INCIDENCE_DEG.len() * 2 * FIT_DIRECTIONS);
        for theta in FIT_INCIDENCE_DEG {
            let t = theta.to_radians();
            let wi = [-t.sin(), 0.0, t.cos()];
            let axis = mirror(wi);
            let axis32 = axis.map(|x| x as f32);
            let normalisation = phong_normalisation(wi[2], paint_m);
            let mut directions = Vec::with_capacity(2 * FIT_DIRECTIONS);
            for k in 0..FIT_DIRECTIONS {
                let u = [
                    (k as f64 + 0.5) / FIT_DIRECTIONS as f64,
                    radical_inverse(k as u32),
                ];
                directions.push(cosine_hemisphere([u[0] as f32, u[1] as f32]).map(f64::from));
                if let Some(w) =
                    sample_phong_lobe(axis32, paint_m as f32, [u[0] as f32, u[1] as f32])
                {
                    directions.push(w.map(f64::from));
                }
            }
            let incidence = incidences.len();
            let mut lobe_peak = 0.0f64;
            for wo in directions {
                let w32 = wo.map(|x| x as f32);
                // Balance heuristic over both strategies (N samples each).
                let pdf =
                    0.5 * (wo[2] / PI + f64::from(phong_lobe_pdf(w32, axis32, paint_m as f32)));
                if pdf.is_nan() || pdf <= 0.0 || wo[2] <= 0.0 {
                    continue;
                }
                let paint_lobe = if is_mirror {
                    0.0
                } else {
                    match model.lobe() {
                        LobeKind::Normalised => phong_lobe(wi, wo, paint_m) / normalisation,
                        LobeKind::Paper => paper_lobe(wi, wo, paint_m),
                    }
                };
                lobe_peak = lobe_peak.max(paint_lobe);
                points.push(QuadraturePoint {
                    incidence,
                    wo,
                    weight: wo[2] / (2.0 * FIT_DIRECTIONS as f64 * pdf),
                    paint_lobe,
                });
            }
            let (mut r_sum, mut r2_sum, mut r_max) = (0.0, 0.0, 0.0f64);
            for &n in &model.refractive_index()[..len] {
                let r = reflectance(wi[2], n);
                r_sum += r;
                r2_sum += r * r;
                r_max = r_max.max(r);
            }
            let peak = r_max * lobe_peak;
            incidences.push(Incidence {
                wi,
                r_sum,
                r2_sum,
                specular_scale: if peak > 0.0 { 1.0 / (peak * peak) } else { 1.0 },
            });
        }
        Self {
            incidences,
            points,
            wavelengths: len,
        }
    }
}

/// The specular residual as sums over the quadrature, per trial exponent m:
/// Σ_s w_s·scale·Σ_λ (ks·b_s − R_λ·D_s)² = len·ks²·B2 − 2·ks·BS + C with
/// B2 = Σ w·scale·b², BS = Σ w·scale·b·D·ΣR and C = Σ w·scale·D²·ΣR², where
/// b = (m + 2)/(2π)·cos^m α. Only B2 and BS depend on m.
struct SpecularSums {
    /// Per direction that can see the lobe (cos α > 0): w·scale.
    weight: Vec<f64>,
    /// w·scale·D·ΣR.
    weighted_target: Vec<f64>,
    /// ln cos α.
    ln_cos: Vec<f64>,
    /// C.
    constant: f64,
    len: usize,
}

impl SpecularSums {
    fn new(quadrature: &Quadrature) -> Self {
        let len_points = quadrature.points.len();
        let mut sums = Self {
            weight: Vec::with_capacity(len_points),
            weighted_target: Vec::with_capacity(len_points),
            ln_cos: Vec::with_capacity(len_points),
            constant: 0.0,
            len: 0,
        };
        for q in &quadrature.points {
            let inc = &quadrature.incidences[q.incidence];
            let ws = q.weight * inc.specular_scale;
            sums.constant += ws * q.paint_lobe * q.paint_lobe * inc.r2_sum;
            // phong_lobe's own arithmetic, so b matches it bit for bit; directions
            // beyond 90° from the axis have b = 0 at every m.
            let one_minus_cos = one_minus_cos_to_mirror(inc.wi, q.wo);
            if one_minus_cos >= 1.0 {
                continue;
            }
            sums.weight.push(ws);
            sums.weighted_target.push(ws * q.paint_lobe * inc.r_sum);
            sums.ln_cos.push((-one_minus_cos).ln_1p());
        }
        sums.len = quadrature.wavelengths;
        sums
    }

    /// For exponent m: the least-squares grey ks ≥ 0 and the specular residual.
    fn solve(&self, m: f64) -> (f64, f64) {
        let norm = (m + 2.0) / (2.0 * PI);
        let (mut b2, mut bs) = (0.0, 0.0);
        for ((w, t), l) in self
            .weight
            .iter()
            .zip(&self.weighted_target)
            .zip(&self.ln_cos)
        {
            let lobe = if m == 0.0 { 1.0 } else { (m * l).exp() };
            b2 += w * lobe * lobe;
            bs += t * lobe;
        }
        let (b2, bs) = (b2 * norm * norm, bs * norm);
        let wavelengths = self.len as f64;
        let ks = if b2 > 0.0 {
            (bs / (wavelengths * b2)).max(0.0)
        } else {
            0.0
        };
        (
            ks,
            wavelengths * ks * ks * b2 - 2.0 * ks * bs + self.constant,
        )
    }
}

/// Van der Corput radical inverse in base 2: the second Hammersley coordinate.
fn radical_inverse(mut bits: u32) -> f64 {
    bits = bits.reverse_bits();
    f64::from(bits) / 4_294_967_296.0
}

/// How the lobe of a [`SpectralPhong`] is normalised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PhongNormalisation {
    /// (m + 2)/(2π)·cos^m α: the energy-normalised Phong of spec 5, what the
    /// design's Phong translations use.
    Energy,
    /// (m + 1)/(2π)·cos^m α / max(cos θi, cos θo): reciprocal, and a sharp lobe
    /// reflects ks at every angle as a mirror does; the scene's simple materials
    /// ([`crate::render::material::SimpleMaterial`]) use it.
    Reciprocal,
}

/// A Lambertian term under a Phong lobe in single precision for the renderer:
///
///   f = kd(λ)/π + ks(λ)·S(ωi, ωo), S the lobe normalised by [`PhongNormalisation`],
///
/// sampled as a mixture: the lobe around the mirror direction with the specular
/// probability, the cosine hemisphere otherwise. The design's Phong translations
/// and the scene's simple materials are both this; they differ in how their
/// parameters and the lobe's normalisation are chosen.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralPhong {
    diffuse_over_pi: Vec<f32>,
    specular: Vec<f32>,
    exponent: f32,
    specular_probability: f32,
    normalisation: PhongNormalisation,
}

impl SpectralPhong {
    /// From kd/π and ks per channel (equal lengths), the lobe exponent m, the
    /// probability of sampling the lobe (0: never, and the lobe is then left out
    /// of f, since ks must be 0) and the lobe's normalisation.
    pub fn new(
        diffuse_over_pi: Vec<f32>,
        specular: Vec<f32>,
        exponent: f32,
        specular_probability: f32,
        normalisation: PhongNormalisation,
    ) -> Self {
        debug_assert_eq!(diffuse_over_pi.len(), specular.len());
        Self {
            diffuse_over_pi,
            specular,
            exponent,
            specular_probability,
            normalisation,
        }
    }

    /// The specular lobe's exponent.
    pub fn exponent(&self) -> f32 {
        self.exponent
    }

    /// S(ωi, ωo), both above the surface.
    #[inline]
    fn lobe_value(&self, wi: [f32; 3], wo: [f32; 3]) -> f32 {
        if self.specular_probability > 0.0 {
            let m = self.exponent;
            match self.normalisation {
                PhongNormalisation::Energy => {
                    (m + 2.0) / (2.0 * std::f32::consts::PI) * phong_lobe(wi, wo, m)
                }
                PhongNormalisation::Reciprocal => {
                    (m + 1.0) / (2.0 * std::f32::consts::PI) * phong_lobe(wi, wo, m)
                        / wi[2].max(wo[2])
                }
            }
        } else {
            0.0
        }
    }
}

impl SpectralBsdf for SpectralPhong {
    fn len(&self) -> usize {
        self.diffuse_over_pi.len()
    }

    #[inline]
    fn eval(&self, wi: [f32; 3], wo: [f32; 3], out: &mut [f32]) {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            out.fill(0.0);
            return;
        }
        let lobe = self.lobe_value(wi, wo);
        for ((o, kd), ks) in out
            .iter_mut()
            .zip(&self.diffuse_over_pi)
            .zip(&self.specular)
        {
            *o = kd + ks * lobe;
        }
    }

    fn pdf(&self, wo: [f32; 3], wi: [f32; 3]) -> f32 {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return 0.0;
        }
        let p = self.specular_probability;
        let lobe = if p > 0.0 {
            p * phong_lobe_pdf(wo, wi, self.exponent)
        } else {
            0.0
        };
        lobe + (1.0 - p) * wi[2] * std::f32::consts::FRAC_1_PI
    }

    fn sample(&self, wo: [f32; 3], u: [f32; 3], weight: &mut [f32]) -> Option<BsdfSample> {
        if wo[2] <= 0.0 {
            return None;
        }
        let wi = if u[0] < self.specular_probability {
            sample_phong_lobe(mirror(wo), self.exponent, [u[1], u[2]])?
        } else {
            cosine_hemisphere([u[1], u[2]])
        };
        weigh_sample(self, wo, wi, weight)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::spectrum::WavelengthGrid;
    use crate::paint::model::{GlossSetting, PaintParams};

    fn model(m: GlossExponent) -> PaintModel {
        let grid = WavelengthGrid::visible(8).expect("grid");
        PaintModel::new(PaintParams::grey(
            grid,
            0.6,
            1.5,
            0.001,
            40.0,
            GlossSetting::Exponent(m),
        ))
        .expect("model")
    }

    #[test]
    fn naive_phong_takes_the_papers_numbers() {
        let paint = model(GlossExponent::Finite(500.0));
        let phong = PhongParams::naive(&paint);
        let r0 = reflectance(1.0, 1.5);
        assert!((phong.specular[0] - r0).abs() < 1e-15);
        let mut albedo = vec![0.0; 8];
        paint.body_albedo(1.0, &mut albedo);
        assert_eq!(phong.diffuse, albedo);
        assert_eq!(phong.exponent, 500.0);
    }

    #[test]
    fn best_fit_is_closer_to_the_paint_than_naive() {
        let paint = model(GlossExponent::Finite(300.0));
        let fit = PhongParams::best_fit(&paint);
        let naive = PhongParams::naive(&paint);
        let (fit_rms, naive_rms) = (fit.fit_residual_rms(&paint), naive.fit_residual_rms(&paint));
        assert!(fit_rms < naive_rms, "fit {fit_rms} vs naive {naive_rms}");
        assert!(fit_rms.is_finite() && fit_rms > 0.0);
        // The fitted exponent stays near the paint's (same lobe shape).
        let m = fit.exponent;
        assert!(m > 100.0 && m < 1000.0, "m = {m}");
    }

    /// The specular residual from the per-incidence sums ΣR, ΣR² equals the sum
    /// over every direction and wavelength it replaces.
    #[test]
    fn specular_sums_equal_the_sum_over_wavelengths() {
        for lobe in [LobeKind::Normalised, LobeKind::Paper] {
            let mut paint = model(GlossExponent::Finite(300.0));
            paint.set_lobe(lobe);
            let quadrature = Quadrature::new(&paint);
            let sums = SpecularSums::new(&quadrature);
            for m in [0.0, 1.0, 120.0, 300.0, 2000.0] {
                let (ks, cost) = sums.solve(m);
                let norm = (m + 2.0) / (2.0 * PI);
                let mut direct = 0.0;
                for q in &quadrature.points {
                    let inc = &quadrature.incidences[q.incidence];
                    let b = norm * phong_lobe(inc.wi, q.wo, m);
                    for &n in paint.refractive_index() {
                        let e = ks * b - reflectance(inc.wi[2], n) * q.paint_lobe;
                        direct += q.weight * inc.specular_scale * e * e;
                    }
                }
                assert!(
                    (cost - direct).abs() <= 1e-9 * direct.abs().max(1e-300),
                    "{lobe:?} m {m}: sums {cost} vs direct {direct}"
                );
            }
        }
    }

    /// kd's closed form (the mean body albedo) agrees with the cosine-weighted mean
    /// of the body term over the quadrature that the fit used to solve for it.
    #[test]
    fn fitted_kd_is_the_quadratures_body_mean() {
        let paint = model(GlossExponent::Finite(300.0));
        let quadrature = Quadrature::new(&paint);
        let len = paint.channels().len();
        let (mut sum, mut weight) = (vec![0.0; len], 0.0);
        let mut out = vec![0.0; len];
        for q in &quadrature.points {
            let wi = quadrature.incidences[q.incidence].wi;
            model_eval_fit(&paint, wi, q.wo, 0.0, &mut out);
            sum.iter_mut()
                .zip(&out)
                .for_each(|(s, b)| *s += q.weight * b);
            weight += q.weight;
        }
        let kd = fitted_diffuse(&paint);
        for (k, s) in kd.iter().zip(&sum) {
            let quadrature_kd = s * PI / weight;
            assert!(
                (k - quadrature_kd).abs() < 0.01 * quadrature_kd,
                "closed form {k} vs quadrature {quadrature_kd}"
            );
        }
    }

    /// ks and m depend only on n(λ), m and the lobe: a ρ or k edit keeps them and
    /// changes kd.
    #[test]
    fn pigment_edits_keep_the_specular_fit() {
        let paint = model(GlossExponent::Finite(700.0));
        let before = PhongParams::best_fit(&paint);
        let mut edited = paint.clone();
        edited.set_albedo(vec![0.3; 8]).expect("albedo");
        edited.set_absorption(vec![0.01; 8]).expect("absorption");
        let after = PhongParams::best_fit(&edited);
        assert_eq!(before.specular, after.specular);
        assert_eq!(before.exponent, after.exponent);
        assert_eq!(after.specular, fit_uncached(&edited).specular);
        assert!(after.diffuse[0] < 0.7 * before.diffuse[0]);
    }

    fn fit_uncached(model: &PaintModel) -> PhongParams {
        let SpecularFit { ks, exponent } = fit_specular(model);
        PhongParams {
            variant: PhongVariant::BestFit,
            diffuse: fitted_diffuse(model),
            specular: vec![ks; model.channels().len()],
            exponent,
        }
    }

    /// Regression: the joint fit gave the glossy signal-red preset (m ≈ 36 000)
    /// kd = 19 in the blue and 0 in the red, a blue car.
    #[test]
    fn best_fit_of_a_glossy_red_is_red_with_a_plausible_ks() {
        let grid = WavelengthGrid::visible(16).expect("grid");
        let design = crate::design::presets::all()
            .into_iter()
            .next()
            .expect("preset")
            .design;
        let paint = design.model(grid).expect("model");
        let fit = PhongParams::best_fit(&paint);
        let naive = PhongParams::naive(&paint);
        let (blue, red) = (fit.diffuse[2], fit.diffuse[13]);
        assert!(red > 10.0 * blue, "kd blue {blue}, red {red}");
        for (f, n) in fit.diffuse.iter().zip(&naive.diffuse) {
            assert!(*f <= 1.0 && (f - n).abs() < 0.1, "kd {f} vs naive {n}");
        }
        // Between R at normal incidence and the mean R over 0–80°.
        let ks = fit.specular[0];
        assert!(ks > 0.04 && ks < 0.12, "ks {ks}");
    }

    #[test]
    fn phong_sampler_weights_are_consistent_with_eval_and_pdf() {
        let phong = PhongParams::naive(&model(GlossExponent::Finite(50.0))).spectral();
        let wo = [0.3_f32, 0.1, (1.0_f32 - 0.1).sqrt()];
        let mut weight = vec![0.0_f32; 8];
        let mut value = vec![0.0_f32; 8];
        for k in 0..200 {
            let u = [(k as f32 + 0.5) / 200.0, radical_inverse(k) as f32, 0.37];
            if let Some(s) = phong.sample(wo, u, &mut weight) {
                phong.eval(s.wi, wo, &mut value);
                let want = value[0] * s.wi[2] / phong.pdf(wo, s.wi);
                assert!((weight[0] - want).abs() <= 1e-5 * want.max(1e-6));
            }
        }
    }

    /// One mixture, two normalisations: each evaluates to its formula with the
    /// same arithmetic, so the design's Phong and the scene's simple materials
    /// shade exactly as when each had its own code.
    #[test]
    fn each_normalisation_evaluates_its_formula() {
        let (kd, ks, m) = (vec![0.1_f32, 0.2], vec![0.04_f32, 0.5], 40.0_f32);
        let wi = [0.3_f32, 0.0, (1.0_f32 - 0.09).sqrt()];
        let wo = [-0.28_f32, 0.05, (1.0_f32 - 0.0809).sqrt()];
        let lobe = phong_lobe(wi, wo, m);
        let two_pi = 2.0 * std::f32::consts::PI;
        for (normalisation, s) in [
            (PhongNormalisation::Energy, (m + 2.0) / two_pi * lobe),
            (
                PhongNormalisation::Reciprocal,
                (m + 1.0) / two_pi * lobe / wi[2].max(wo[2]),
            ),
        ] {
            let phong = SpectralPhong::new(kd.clone(), ks.clone(), m, 0.5, normalisation);
            let mut out = [0.0_f32; 2];
            phong.eval(wi, wo, &mut out);
            for c in 0..2 {
                assert_eq!(out[c], kd[c] + ks[c] * s, "{normalisation:?} channel {c}");
            }
            // Below the surface: nothing.
            phong.eval([wi[0], wi[1], -wi[2]], wo, &mut out);
            assert_eq!(out, [0.0; 2]);
        }
        // A lobe never sampled has no weight in f either (its ks is 0).
        let lambertian = SpectralPhong::new(
            kd.clone(),
            vec![0.0; 2],
            m,
            0.0,
            PhongNormalisation::Reciprocal,
        );
        let mut out = [0.0_f32; 2];
        lambertian.eval(wi, wo, &mut out);
        assert_eq!(out, [kd[0], kd[1]]);
        assert_eq!(lambertian.pdf(wo, wi), wi[2] * std::f32::consts::FRAC_1_PI);
    }
}
