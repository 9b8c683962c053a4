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
//!   cos^m α to its specular term R·D/N. The hemisphere integral is a fixed
//!   quadrature: 512 cosine-distributed Hammersley directions plus 512 from the
//!   paint's own lobe, combined with the balance heuristic. For fixed m both fits
//!   are closed form; m is found by golden-section search in ln m within a factor e⁴
//!   of the paint's m, on the specular residual. The specular residual at each
//!   incidence is divided by the square of the paint lobe's peak there, so every
//!   angle counts alike (unweighted, the 80° peaks — R ≈ 0.4 under a lobe
//!   normalised over a clipped hemisphere — decided ks alone: 0.41 for a coat whose
//!   R is 0.04 over most angles). `fit_rms` reports the whole BRDF's residual. Why part by part: a joint fit of kd and ks is ill-conditioned for
//!   glossy paints, whose lobe values (~m/2π per sr) outweigh the body's by orders
//!   of magnitude in the squared error, so kd absorbed the quadrature's error in the
//!   lobe (the signal-red preset, m ≈ 36 000, came out with kd = 19 in the blue and
//!   0 in the red: a blue car). A mirror paint has no lobe to fit: its best-fit
//!   Phong takes the body fit, ks = the mean R over the incidence angles, and
//!   m = 1e9.

use std::f64::consts::PI;

use super::coat::body_brdf;
use super::fresnel::reflectance;
use super::gloss::{GlossExponent, MAX_EXPONENT};
use super::lobe::{
    LobeKind, mirror, paper_lobe, phong_lobe, phong_lobe_pdf, phong_normalisation,
    sample_phong_lobe,
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
    /// For the best fit: the root-mean-square BRDF difference that remains, 1/sr
    /// (cosine-weighted over the hemisphere, averaged over angles and wavelengths).
    pub fit_rms: Option<f64>,
}

/// Incidence angles of the best fit, degrees.
const FIT_INCIDENCE_DEG: [f64; 9] = [0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0];
/// Directions per strategy in the best fit's hemisphere quadrature.
const FIT_DIRECTIONS: usize = 512;

fn finite_exponent(model: &PaintModel) -> f64 {
    match model.exponent() {
        GlossExponent::Finite(m) => m,
        GlossExponent::Mirror => MAX_EXPONENT,
    }
}

impl PhongParams {
    /// The naive translation of a paint design.
    pub fn naive(model: &PaintModel) -> Self {
        let len = model.grid().len();
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
            fit_rms: None,
        }
    }

    /// The least-squares fit to the paint BRDF (see the module documentation).
    pub fn best_fit(model: &PaintModel) -> Self {
        let samples = FitSamples::new(model);
        let len = model.grid().len();
        let paint_m = finite_exponent(model);
        if matches!(model.exponent(), GlossExponent::Mirror) {
            // No lobe to fit: fit kd alone (ks = 0 in the solve), then give the
            // mirror's mean Fresnel reflectance to a needle-sharp lobe.
            let (mut diffuse, _, _, _) = samples.solve(0.0, false);
            diffuse.iter_mut().for_each(|d| *d = d.max(0.0));
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
            return Self {
                variant: PhongVariant::BestFit,
                diffuse,
                specular: vec![mean_r; len],
                exponent: MAX_EXPONENT,
                fit_rms: None,
            };
        }
        // Golden-section search on ln(1 + m).
        let lo0 = (paint_m.ln_1p() - 4.0).max(0.0);
        let hi0 = (paint_m.ln_1p() + 4.0).min(MAX_EXPONENT.ln_1p());
        let cost = |x: f64| samples.solve(x.exp_m1(), true).2;
        let golden = 0.5 * (5.0_f64.sqrt() - 1.0);
        let (mut lo, mut hi) = (lo0, hi0);
        let mut x1 = hi - golden * (hi - lo);
        let mut x2 = lo + golden * (hi - lo);
        let (mut f1, mut f2) = (cost(x1), cost(x2));
        for _ in 0..40 {
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
        let m = (0.5 * (lo + hi)).exp_m1();
        let (diffuse, ks, _, residual) = samples.solve(m, true);
        Self {
            variant: PhongVariant::BestFit,
            diffuse,
            specular: vec![ks; len],
            exponent: m,
            fit_rms: Some((residual / (samples.total_weight * len as f64)).sqrt()),
        }
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
        SpectralPhong {
            diffuse_over_pi: self.diffuse.iter().map(|k| (k / PI) as f32).collect(),
            specular: self.specular.iter().map(|&k| k as f32).collect(),
            exponent: self.exponent as f32,
            specular_probability: p.clamp(0.05, 0.95) as f32,
        }
    }
}

/// The fixed quadrature of the best fit, with the paint BRDF evaluated once.
struct FitSamples {
    /// Per sample: incidence, outgoing direction, quadrature weight.
    geometry: Vec<([f64; 3], [f64; 3], f64)>,
    /// f_paint per sample and wavelength, row-major [sample][λ].
    paint: Vec<f64>,
    /// Its body part alone, same layout.
    body: Vec<f64>,
    /// Per sample: 1 / (the peak of the paint's specular part at its incidence)²,
    /// so every incidence angle counts alike in the specular fit.
    specular_scale: Vec<f64>,
    len: usize,
    total_weight: f64,
}

impl FitSamples {
    fn new(model: &PaintModel) -> Self {
        let len = model.grid().len();
        let paint_m = finite_exponent(model);
        let mut geometry = Vec::new();
        let mut paint = Vec::new();
        let mut bodies = Vec::new();
        let mut specular_scale = Vec::new();
        let mut total_weight = 0.0;
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
            let first_sample = geometry.len();
            let mut peak = 0.0f64;
            for wo in directions {
                let w32 = wo.map(|x| x as f32);
                // Balance heuristic over both strategies (N samples each).
                let pdf =
                    0.5 * (wo[2] / PI + f64::from(phong_lobe_pdf(w32, axis32, paint_m as f32)));
                if pdf.is_nan() || pdf <= 0.0 || wo[2] <= 0.0 {
                    continue;
                }
                let weight = wo[2] / (2.0 * FIT_DIRECTIONS as f64 * pdf);
                let lobe = match model.lobe() {
                    LobeKind::Normalised => phong_lobe(wi, wo, paint_m) / normalisation,
                    LobeKind::Paper => paper_lobe(wi, wo, paint_m),
                };
                let lobe = if matches!(model.exponent(), GlossExponent::Mirror) {
                    0.0
                } else {
                    lobe
                };
                for i in 0..len {
                    let n = model.refractive_index()[i];
                    let body = body_brdf(
                        model.albedo()[i],
                        n,
                        model.optical_depth()[i],
                        model.coat_integral()[i],
                        wi[2],
                        wo[2],
                    );
                    paint.push(body + reflectance(wi[2], n) * lobe);
                    bodies.push(body);
                    peak = peak.max(reflectance(wi[2], n) * lobe);
                }
                geometry.push((wi, wo, weight));
                total_weight += weight;
            }
            let scale = if peak > 0.0 { 1.0 / (peak * peak) } else { 1.0 };
            specular_scale.resize(specular_scale.len() + geometry.len() - first_sample, scale);
        }
        Self {
            geometry,
            paint,
            body: bodies,
            specular_scale,
            len,
            total_weight,
        }
    }

    /// For exponent m: the least-squares kd(λ) (to the body part) and grey ks (to
    /// the specular part; fixed at 0 when `with_lobe` is false), the weighted
    /// squared residual of the specular part (what m is chosen by) and that of the
    /// whole BRDF.
    fn solve(&self, m: f64, with_lobe: bool) -> (Vec<f64>, f64, f64, f64) {
        let a = 1.0 / PI;
        let norm = (m + 2.0) / (2.0 * PI);
        let lobes: Vec<f64> = self
            .geometry
            .iter()
            .map(|(wi, wo, _)| norm * phong_lobe(*wi, *wo, m))
            .collect();
        let (mut w_sum, mut b2, mut bs) = (0.0, 0.0, 0.0);
        let mut body_sum = vec![0.0; self.len];
        for (s, ((_, _, w), b)) in self.geometry.iter().zip(&lobes).enumerate() {
            w_sum += w;
            let ws = w * self.specular_scale[s];
            b2 += ws * b * b;
            let range = s * self.len..(s + 1) * self.len;
            for ((sum, body), paint) in body_sum
                .iter_mut()
                .zip(&self.body[range.clone()])
                .zip(&self.paint[range])
            {
                *sum += w * body;
                bs += ws * b * (paint - body);
            }
        }
        let diffuse: Vec<f64> = body_sum
            .iter()
            .map(|sum| (sum / (a * w_sum)).max(0.0))
            .collect();
        let ks = if with_lobe && b2 > 0.0 {
            (bs / (self.len as f64 * b2)).max(0.0)
        } else {
            0.0
        };
        let (mut specular_residual, mut residual) = (0.0, 0.0);
        for (s, ((_, _, w), b)) in self.geometry.iter().zip(&lobes).enumerate() {
            let range = s * self.len..(s + 1) * self.len;
            for (i, (body, paint)) in self.body[range.clone()]
                .iter()
                .zip(&self.paint[range])
                .enumerate()
            {
                let specular = ks * b - (paint - body);
                specular_residual += w * self.specular_scale[s] * specular * specular;
                let r = diffuse[i] * a + ks * b - paint;
                residual += w * r * r;
            }
        }
        (diffuse, ks, specular_residual, residual)
    }
}

/// Van der Corput radical inverse in base 2: the second Hammersley coordinate.
fn radical_inverse(mut bits: u32) -> f64 {
    bits = bits.reverse_bits();
    f64::from(bits) / 4_294_967_296.0
}

/// Phong in single precision for the renderer.
#[derive(Debug, Clone)]
pub struct SpectralPhong {
    diffuse_over_pi: Vec<f32>,
    specular: Vec<f32>,
    exponent: f32,
    specular_probability: f32,
}

impl SpectralBsdf for SpectralPhong {
    fn len(&self) -> usize {
        self.diffuse_over_pi.len()
    }

    fn eval(&self, wi: [f32; 3], wo: [f32; 3], out: &mut [f32]) {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            out.iter_mut().for_each(|o| *o = 0.0);
            return;
        }
        let m = self.exponent;
        let lobe = (m + 2.0) / (2.0 * std::f32::consts::PI) * phong_lobe(wi, wo, m);
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
        p * phong_lobe_pdf(wo, wi, self.exponent) + (1.0 - p) * wi[2] * std::f32::consts::FRAC_1_PI
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
    use crate::paint::model::{GlossSetting, PaintParams};
    use crate::spectrum::WavelengthGrid;

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
        let naive = PhongParams {
            variant: PhongVariant::Naive,
            ..PhongParams::naive(&paint)
        };
        let samples = FitSamples::new(&paint);
        let cost = |p: &PhongParams| {
            let a = 1.0 / PI;
            let norm = (p.exponent + 2.0) / (2.0 * PI);
            let mut total = 0.0;
            for (s, (wi, wo, w)) in samples.geometry.iter().enumerate() {
                let b = norm * phong_lobe(*wi, *wo, p.exponent);
                for i in 0..samples.len {
                    let r =
                        p.diffuse[i] * a + p.specular[i] * b - samples.paint[s * samples.len + i];
                    total += w * r * r;
                }
            }
            total
        };
        assert!(
            cost(&fit) < cost(&naive),
            "fit {} vs naive {}",
            cost(&fit),
            cost(&naive)
        );
        // The fitted exponent stays near the paint's (same lobe shape).
        assert!(
            fit.exponent > 100.0 && fit.exponent < 1000.0,
            "m = {}",
            fit.exponent
        );
        assert!(fit.fit_rms.is_some_and(|r| r.is_finite() && r > 0.0));
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
}
