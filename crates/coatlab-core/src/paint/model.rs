//! The paint model on a wavelength grid (or on linear-sRGB channels): parameters
//! ("set") and the tables derived from them ("derive"), kept apart so an edit
//! recomputes only what it touches.
//!
//! The parameters, with their units, accepted ranges and defaults, are those of
//! the table in [`super::parameters`]; what paints use:
//!
//! | parameter | table entry | typical |
//! | --- | --- | --- |
//! | pigment albedo ρ(λ) | [`ALBEDO`] | 0.03–0.9 |
//! | coat refractive index n(λ) | [`REFRACTIVE_INDEX`] (tested to 4) | 1.48–1.55 |
//! | coat absorption k(λ) | [`ABSORPTION`] | < 0.002 /µm in the visible |
//! | coat thickness h | [`THICKNESS`] | 35–55 µm |
//! | gloss g at 20°/60°/85° | [`super::parameters::GLOSS`], [`super::gloss`] | 80–92 GU at 20° (needs n(587.6 nm) ≳ 1.52 above 82 GU) |
//! | lobe | [`LobeKind`]: normalised / paper | normalised |
//!
//! Derived, and what each depends on:
//!
//! | derived | from |
//! | --- | --- |
//! | τ(λ) = k·h | k, h |
//! | C(λ), E(λ) (coat integrals) | n, τ |
//! | body factor ρ/(n²(π − ρC)) | ρ, n, C |
//! | through-coat and Fresnel tables over μ | n, τ |
//! | m | g, geometry, n(587.6 nm) |
//! | lobe normalisation table N(μ) | m |
//!
//! Each is built in under a millisecond for 81 wavelengths (m once the glossmeter's
//! table nodes it reads exist: they are computed once per process), so any single
//! edit stays within a slider's budget (figures: docs/benchmarks.md, "Paint model").
//!
//! The renderer's evaluation factors the body term as
//! f_body = K(λ)·A(λ, μi)·A(λ, μo), A = T(μ)·exp(−τ/μ′), and the specular term as
//! R(λ, μi)·S(ωi, ωo) with a wavelength-independent lobe S. A and R are tabulated
//! over μ per wavelength (f32, wavelengths contiguous), so an evaluation is a few
//! vector multiply-adds over wavelengths and one scalar lobe.

use std::f64::consts::PI;

use super::coat::{
    CoatIntegralMethod, attenuation, body_brdf, c_integral_with, escape_integral_scaled,
};
use super::fresnel::{cos_refracted, reflectance, reflectance_and_cos_refracted, transmittance};
use super::gloss::{GlossError, GlossExponent, GlossGeometry, exponent_from_reading};
use super::lobe::{
    LobeKind, NormalisationTable, mirror, paper_lobe, phong_lobe, phong_lobe_pdf,
    phong_normalisation, sample_phong_lobe,
};
use super::parameters::{
    ABSORPTION, ALBEDO, Parameter, REFRACTIVE_INDEX, RangeError, THICKNESS, Violation,
};
use crate::colour::spectrum::{Channel, Channels};
use crate::simd_path::{SimdPath, dispatch};

/// Errors setting paint parameters.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    /// A spectral parameter has the wrong number of samples for the channels.
    #[error("{} has {got} samples but there are {want} channels", .parameter.label())]
    Length {
        /// Which parameter.
        parameter: &'static Parameter,
        /// Its length.
        got: usize,
        /// The channels'.
        want: usize,
    },
    /// A value of a spectral parameter outside the parameter's range.
    #[error("{} = {value} {at} {violation}: it must lie in {}", .parameter.label(), .parameter.range_text())]
    OutOfRange {
        /// Which parameter.
        parameter: &'static Parameter,
        /// The value.
        value: f64,
        /// Which channel: a wavelength of the grid, or an sRGB primary.
        at: Channel,
        /// What is wrong with the value.
        violation: Violation,
    },
    /// A scalar parameter (the coat's thickness) outside its range.
    #[error(transparent)]
    Range(#[from] RangeError),
    /// Gloss could not be converted.
    #[error(transparent)]
    Gloss(#[from] GlossError),
}

/// How the lobe exponent is set: from a glossmeter reading (a designer's gloss) or
/// directly (scripts, tests).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GlossSetting {
    /// Gloss in GU at a geometry; m follows n at 587.6 nm.
    Reading {
        /// Gloss units.
        gu: f64,
        /// Geometry of the reading.
        geometry: GlossGeometry,
    },
    /// The exponent itself.
    Exponent(GlossExponent),
}

/// Number of intervals of the μ tables. Nodes sit at μ = (j/256)²: dense at grazing
/// angles, where Fresnel (for large n) and the lobe normalisation (for large m)
/// bend sharply. Linear interpolation on them keeps the f32 evaluation within the
/// tolerance stated in [`SpectralPaint`].
pub const MU_INTERVALS: usize = 256;

/// The μ of table node j.
#[inline]
fn mu_node(j: usize) -> f64 {
    let s = j as f64 / MU_INTERVALS as f64;
    s * s
}
/// SIMD width the spectral tables are padded to.
pub const LANES: usize = 8;

/// Counts of derived-table rebuilds, so tests (and the app's diagnostics) can check
/// that an edit recomputes only what it touches.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RecomputeCounts {
    /// C and E integrals.
    pub coat_integrals: u32,
    /// Through-coat and Fresnel tables over μ.
    pub angular_tables: u32,
    /// m from the gloss reading.
    pub exponent: u32,
    /// Lobe normalisation table.
    pub normalisation: u32,
    /// Body factor (cheap, but counted for completeness).
    pub body_factor: u32,
}

/// A paint design's physical parameters on one set of channels (a wavelength grid,
/// or linear sRGB), with all derived tables up to date.
#[derive(Debug, Clone)]
pub struct PaintModel {
    channels: Channels,
    albedo: Vec<f64>,
    index: Vec<f64>,
    index_at_gloss_wavelength: f64,
    absorption_per_um: Vec<f64>,
    thickness_um: f64,
    gloss: GlossSetting,
    lobe: LobeKind,
    /// How C is obtained for the tables (exact unless a benchmark asks otherwise).
    coat_method: CoatIntegralMethod,
    // Derived.
    tau: Vec<f64>,
    c: Vec<f64>,
    escape: Vec<f64>,
    exponent: GlossExponent,
    normalisation: Option<NormalisationTable>,
    spectral: SpectralPaint,
    counts: RecomputeCounts,
}

/// Everything needed to build a [`PaintModel`].
#[derive(Debug, Clone, PartialEq)]
pub struct PaintParams {
    /// What the per-channel values are for: the wavelengths of a grid, or linear sRGB.
    pub channels: Channels,
    /// ρ(λ) in [0, 1].
    pub albedo: Vec<f64>,
    /// n(λ) ≥ 1.
    pub refractive_index: Vec<f64>,
    /// n at 587.6 nm, which sets m from a gloss reading.
    pub index_at_gloss_wavelength: f64,
    /// k(λ) ≥ 0, 1/µm.
    pub absorption_per_um: Vec<f64>,
    /// h ≥ 0, µm.
    pub thickness_um: f64,
    /// Gloss.
    pub gloss: GlossSetting,
    /// Lobe.
    pub lobe: LobeKind,
}

impl PaintParams {
    /// Grey parameters (the same value at every wavelength), for the CLI, tests and
    /// benchmarks.
    pub fn grey(
        channels: impl Into<Channels>,
        rho: f64,
        n: f64,
        absorption_per_um: f64,
        thickness_um: f64,
        gloss: GlossSetting,
    ) -> Self {
        let channels = channels.into();
        let len = channels.len();
        Self {
            channels,
            albedo: vec![rho; len],
            refractive_index: vec![n; len],
            index_at_gloss_wavelength: n,
            absorption_per_um: vec![absorption_per_um; len],
            thickness_um,
            gloss,
            lobe: LobeKind::Normalised,
        }
    }
}

/// Every value of a spectral parameter against the parameter's range.
fn check_spectrum(
    parameter: &'static Parameter,
    values: &[f64],
    channels: &Channels,
) -> Result<(), ParamError> {
    if values.len() != channels.len() {
        return Err(ParamError::Length {
            parameter,
            got: values.len(),
            want: channels.len(),
        });
    }
    for (i, &value) in values.iter().enumerate() {
        if let Some(violation) = parameter.range.violation(value) {
            return Err(ParamError::OutOfRange {
                parameter,
                value,
                at: channels.channel(i),
                violation,
            });
        }
    }
    Ok(())
}

fn resolve_exponent(gloss: GlossSetting, n_gloss: f64) -> Result<GlossExponent, ParamError> {
    match gloss {
        GlossSetting::Reading { gu, geometry } => Ok(exponent_from_reading(geometry, n_gloss, gu)?),
        GlossSetting::Exponent(GlossExponent::Finite(m)) if !(m.is_finite() && m >= 0.0) => {
            Err(GlossError::InvalidExponent(m).into())
        }
        GlossSetting::Exponent(e) => Ok(e),
    }
}

impl PaintModel {
    /// Validates the parameters and derives every table.
    pub fn new(params: PaintParams) -> Result<Self, ParamError> {
        let channels = params.channels;
        check_spectrum(&ALBEDO, &params.albedo, &channels)?;
        check_spectrum(&REFRACTIVE_INDEX, &params.refractive_index, &channels)?;
        check_spectrum(&ABSORPTION, &params.absorption_per_um, &channels)?;
        THICKNESS.check(params.thickness_um)?;
        REFRACTIVE_INDEX.check(params.index_at_gloss_wavelength)?;
        let exponent = resolve_exponent(params.gloss, params.index_at_gloss_wavelength)?;
        let len = channels.len();
        let mut model = Self {
            channels,
            albedo: params.albedo,
            index: params.refractive_index,
            index_at_gloss_wavelength: params.index_at_gloss_wavelength,
            absorption_per_um: params.absorption_per_um,
            thickness_um: params.thickness_um,
            gloss: params.gloss,
            lobe: params.lobe,
            coat_method: CoatIntegralMethod::Exact,
            tau: vec![0.0; len],
            c: vec![0.0; len],
            escape: vec![0.0; len],
            exponent,
            normalisation: None,
            spectral: SpectralPaint::empty(len),
            counts: RecomputeCounts::default(),
        };
        model.derive_optical_depth();
        model.derive_coat_integrals();
        model.derive_angular_tables();
        model.derive_body_factor();
        model.derive_lobe();
        Ok(model)
    }

    /// Sets ρ(λ): only the body factor changes.
    pub fn set_albedo(&mut self, albedo: Vec<f64>) -> Result<(), ParamError> {
        check_spectrum(&ALBEDO, &albedo, &self.channels)?;
        self.albedo = albedo;
        self.derive_body_factor();
        Ok(())
    }

    /// Sets n(λ) and n at 587.6 nm: coat integrals, angular tables, body factor and,
    /// when gloss is a reading, m and its normalisation.
    pub fn set_refractive_index(
        &mut self,
        index: Vec<f64>,
        index_at_gloss_wavelength: f64,
    ) -> Result<(), ParamError> {
        check_spectrum(&REFRACTIVE_INDEX, &index, &self.channels)?;
        let exponent = resolve_exponent(self.gloss, index_at_gloss_wavelength)?;
        self.index = index;
        self.index_at_gloss_wavelength = index_at_gloss_wavelength;
        self.derive_coat_integrals();
        self.derive_angular_tables();
        self.derive_body_factor();
        if matches!(self.gloss, GlossSetting::Reading { .. }) {
            self.counts.exponent += 1;
            if exponent != self.exponent {
                self.exponent = exponent;
                self.derive_lobe();
            }
        }
        Ok(())
    }

    /// Sets k(λ) in 1/µm: τ changes, so coat integrals, angular tables, body factor.
    pub fn set_absorption(&mut self, absorption_per_um: Vec<f64>) -> Result<(), ParamError> {
        check_spectrum(&ABSORPTION, &absorption_per_um, &self.channels)?;
        self.absorption_per_um = absorption_per_um;
        self.derive_optical_depth();
        self.derive_coat_integrals();
        self.derive_angular_tables();
        self.derive_body_factor();
        Ok(())
    }

    /// Sets h in µm: as for k.
    pub fn set_thickness(&mut self, thickness_um: f64) -> Result<(), ParamError> {
        THICKNESS.check(thickness_um)?;
        self.thickness_um = thickness_um;
        self.derive_optical_depth();
        self.derive_coat_integrals();
        self.derive_angular_tables();
        self.derive_body_factor();
        Ok(())
    }

    /// Sets the gloss: m and its normalisation only.
    pub fn set_gloss(&mut self, gloss: GlossSetting) -> Result<(), ParamError> {
        let exponent = resolve_exponent(gloss, self.index_at_gloss_wavelength)?;
        self.gloss = gloss;
        if matches!(gloss, GlossSetting::Reading { .. }) {
            self.counts.exponent += 1;
        }
        if exponent != self.exponent {
            self.exponent = exponent;
            self.derive_lobe();
        }
        Ok(())
    }

    /// Sets the lobe kind: only the normalisation (needed by the normalised lobe alone).
    pub fn set_lobe(&mut self, lobe: LobeKind) {
        if lobe != self.lobe {
            self.lobe = lobe;
            self.derive_lobe();
        }
    }

    /// Sets how C is computed (a speed/accuracy knob; see [`CoatIntegralMethod`]):
    /// coat integrals and body factor.
    pub fn set_coat_integral_method(&mut self, method: CoatIntegralMethod) {
        if method != self.coat_method {
            self.coat_method = method;
            self.derive_coat_integrals();
            self.derive_body_factor();
        }
    }

    /// How C is computed.
    pub fn coat_integral_method(&self) -> CoatIntegralMethod {
        self.coat_method
    }

    fn derive_optical_depth(&mut self) {
        for (tau, k) in self.tau.iter_mut().zip(&self.absorption_per_um) {
            *tau = k * self.thickness_um;
        }
    }

    fn derive_coat_integrals(&mut self) {
        self.counts.coat_integrals += 1;
        for i in 0..self.channels.len() {
            let (n, tau) = (self.index[i], self.tau[i]);
            self.c[i] = c_integral_with(self.coat_method, n, tau);
            self.escape[i] = escape_integral_scaled(n, tau) * (-tau).exp();
        }
    }

    fn derive_angular_tables(&mut self) {
        self.counts.angular_tables += 1;
        let stride = self.spectral.stride;
        for j in 0..=MU_INTERVALS {
            let mu = mu_node(j);
            for i in 0..self.channels.len() {
                let n = self.index[i];
                let (r, mu_t) = reflectance_and_cos_refracted(mu, n);
                let through = (1.0 - r) * attenuation(self.tau[i], mu_t);
                self.spectral.through[j * stride + i] = through as f32;
                self.spectral.fresnel[j * stride + i] = r as f32;
            }
        }
    }

    fn derive_body_factor(&mut self) {
        self.counts.body_factor += 1;
        for i in 0..self.channels.len() {
            let k = self.body_factor_f64(i);
            self.spectral.body_factor[i] = k as f32;
            self.spectral.albedo_factor[i] = (k * self.escape[i]) as f32;
        }
        self.derive_sampling_weights();
    }

    fn body_factor_f64(&self, i: usize) -> f64 {
        let n = self.index[i];
        self.albedo[i] / (n * n * (PI - self.albedo[i] * self.c[i]))
    }

    fn derive_lobe(&mut self) {
        self.normalisation = match (self.exponent, self.lobe) {
            (GlossExponent::Finite(m), LobeKind::Normalised) => {
                self.counts.normalisation += 1;
                Some(NormalisationTable::new(m))
            }
            _ => None,
        };
        self.spectral.lobe = match self.exponent {
            GlossExponent::Mirror => SpectralLobe::Mirror,
            GlossExponent::Finite(m) => match self.lobe {
                LobeKind::Normalised => SpectralLobe::Normalised {
                    m: m as f32,
                    normalisation: self
                        .normalisation
                        .as_ref()
                        .map(tabulate_normalisation)
                        .unwrap_or_default(),
                },
                LobeKind::Paper => SpectralLobe::Paper { m: m as f32 },
            },
        };
    }

    /// The probability of sampling the specular part, tabulated over μo: the mean
    /// specular albedo against the mean body albedo (both ≈ what each part returns).
    fn derive_sampling_weights(&mut self) {
        let len = self.channels.len();
        let stride = self.spectral.stride;
        for j in 0..=MU_INTERVALS {
            let (mut spec, mut body) = (0.0_f64, 0.0_f64);
            for i in 0..len {
                spec += f64::from(self.spectral.fresnel[j * stride + i]);
                body += f64::from(self.spectral.albedo_factor[i])
                    * f64::from(self.spectral.through[j * stride + i]);
            }
            let p = if spec + body > 0.0 {
                spec / (spec + body)
            } else {
                0.5
            };
            // Keep both strategies alive so MIS never meets a zero density where f > 0.
            self.spectral.specular_probability[j] = p.clamp(0.05, 0.95) as f32;
        }
    }

    /// What the per-channel values are for: a wavelength grid, or linear sRGB.
    pub fn channels(&self) -> &Channels {
        &self.channels
    }
    /// ρ(λ).
    pub fn albedo(&self) -> &[f64] {
        &self.albedo
    }
    /// n(λ).
    pub fn refractive_index(&self) -> &[f64] {
        &self.index
    }
    /// n at 587.6 nm.
    pub fn index_at_gloss_wavelength(&self) -> f64 {
        self.index_at_gloss_wavelength
    }
    /// k(λ), 1/µm.
    pub fn absorption_per_um(&self) -> &[f64] {
        &self.absorption_per_um
    }
    /// h, µm.
    pub fn thickness_um(&self) -> f64 {
        self.thickness_um
    }
    /// τ(λ) = k·h.
    pub fn optical_depth(&self) -> &[f64] {
        &self.tau
    }
    /// C(λ).
    pub fn coat_integral(&self) -> &[f64] {
        &self.c
    }
    /// The gloss setting.
    pub fn gloss(&self) -> GlossSetting {
        self.gloss
    }
    /// The lobe exponent m (derived from the gloss).
    pub fn exponent(&self) -> GlossExponent {
        self.exponent
    }
    /// The lobe kind.
    pub fn lobe(&self) -> LobeKind {
        self.lobe
    }
    /// How often each derived table was rebuilt.
    pub fn recompute_counts(&self) -> RecomputeCounts {
        self.counts
    }
    /// The renderer's f32 evaluator.
    pub fn spectral(&self) -> &SpectralPaint {
        &self.spectral
    }

    /// Directional albedo of the body term at incidence cosine μ, per wavelength
    /// (double precision).
    pub fn body_albedo(&self, cos_i: f64, out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate().take(self.channels.len()) {
            let n = self.index[i];
            let through =
                transmittance(cos_i, n) * attenuation(self.tau[i], cos_refracted(cos_i, n));
            *o = self.body_factor_f64(i) * through * self.escape[i];
        }
    }

    /// The reference BRDF in double precision, per wavelength, 1/sr: body plus the
    /// non-delta specular lobe (the mirror's delta is not a function value and is
    /// left out), with the exact lobe normalisation.
    pub fn eval_reference(&self, wi: [f64; 3], wo: [f64; 3], out: &mut [f64]) {
        let (mu_i, mu_o) = (wi[2], wo[2]);
        if mu_i <= 0.0 || mu_o <= 0.0 {
            out.iter_mut().for_each(|o| *o = 0.0);
            return;
        }
        let lobe = self.lobe_value_reference(wi, wo);
        for (i, o) in out.iter_mut().enumerate().take(self.channels.len()) {
            let n = self.index[i];
            let body = body_brdf(self.albedo[i], n, self.tau[i], self.c[i], mu_i, mu_o);
            *o = body + reflectance(mu_i, n) * lobe;
        }
    }

    /// The specular lobe S(ωi, ωo) in double precision (exact normalisation).
    pub fn lobe_value_reference(&self, wi: [f64; 3], wo: [f64; 3]) -> f64 {
        match (self.exponent, self.lobe) {
            (GlossExponent::Mirror, _) => 0.0,
            (GlossExponent::Finite(m), LobeKind::Normalised) => {
                phong_lobe(wi, wo, m) / phong_normalisation(wi[2], m)
            }
            (GlossExponent::Finite(m), LobeKind::Paper) => paper_lobe(wi, wo, m),
        }
    }
}

fn tabulate_normalisation(table: &NormalisationTable) -> Vec<f32> {
    (0..=MU_INTERVALS)
        .map(|j| table.eval(mu_node(j)) as f32)
        .collect()
}

/// The specular lobe in the renderer's form.
#[derive(Debug, Clone)]
pub enum SpectralLobe {
    /// Ideal mirror (delta).
    Mirror,
    /// R·D/N with N tabulated over μi.
    Normalised {
        /// Exponent.
        m: f32,
        /// N(μ) at μ = j/MU_INTERVALS.
        normalisation: Vec<f32>,
    },
    /// The paper's lobe, unnormalised.
    Paper {
        /// Exponent.
        m: f32,
    },
}

/// A direction sampled from a BRDF, with its density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfSample {
    /// The sampled direction toward the light, local frame.
    pub wi: [f32; 3],
    /// Density per solid angle of the non-delta part at `wi`; for a delta sample,
    /// the probability of having chosen the delta.
    pub pdf: f32,
    /// Whether `wi` came from a delta (mirror) component.
    pub delta: bool,
}

/// A spectral BRDF the renderer can use: evaluate, sample, density. Random numbers
/// are passed in; nothing here owns a generator. Directions are in the local frame
/// (z = normal); `wo` toward the viewer, `wi` toward the light.
pub trait SpectralBsdf {
    /// Number of wavelengths.
    fn len(&self) -> usize;
    /// Whether there are no wavelengths.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// f(ωi, ωo) per wavelength, 1/sr, without delta components.
    fn eval(&self, wi: [f32; 3], wo: [f32; 3], out: &mut [f32]);
    /// Density with which [`SpectralBsdf::sample`] picks the non-delta direction `wi`.
    fn pdf(&self, wo: [f32; 3], wi: [f32; 3]) -> f32;
    /// Samples a direction; writes f·cos θi/pdf (the path weight) per wavelength into
    /// `weight`. `None` when the sample is lost (below the surface).
    fn sample(&self, wo: [f32; 3], u: [f32; 3], weight: &mut [f32]) -> Option<BsdfSample>;
    /// For a BSDF with a delta (mirror) component: its reflectance toward the
    /// mirror direction of `wo` per wavelength, written to `out`, and `true`;
    /// `false` (and `out` untouched) without one. Re-shading a recorded delta
    /// sample needs it.
    fn delta_reflectance(&self, wo: [f32; 3], out: &mut [f32]) -> bool {
        let _ = (wo, out);
        false
    }
}

/// The paint model in single precision for the renderer.
///
/// Agreement with [`PaintModel::eval_reference`] (double precision, exact
/// formulas), relative to |f| + 1e-3/sr over the whole parameter domain: within
/// 1e-3 for directions up to 85° from the normal (2e-3 for a coat of n < 1.003
/// under a very sharp lobe: as n → 1, R ∝ μ⁻⁴ toward 85° and its table is 1.6e-3
/// off there, on an R below 1e-4), within 5e-2 from 85° to 89.9°
/// (measured worst 4.3 %, for n = 1 exactly with τ ≈ 0.01: the tables interpolate
/// linearly between nodes at μ = (j/256)², and without refraction exp(−τ/μ) bends
/// without bound as μ → 0). Such directions weigh cos θ < 0.09 in any image.
/// Checked by `tests/paint_model.rs` over random corners of the domain and by
/// `tests/extremes.rs` on a grid of its corners (report: `docs/extremes.md`).
#[derive(Debug, Clone)]
pub struct SpectralPaint {
    len: usize,
    stride: usize,
    through: Vec<f32>,
    fresnel: Vec<f32>,
    body_factor: Vec<f32>,
    albedo_factor: Vec<f32>,
    specular_probability: Vec<f32>,
    lobe: SpectralLobe,
}

impl SpectralPaint {
    /// The specular lobe's exponent; `None` for an ideal mirror.
    pub fn lobe_exponent(&self) -> Option<f32> {
        match self.lobe {
            SpectralLobe::Mirror => None,
            SpectralLobe::Normalised { m, .. } | SpectralLobe::Paper { m } => Some(m),
        }
    }

    fn empty(len: usize) -> Self {
        let stride = len.div_ceil(LANES) * LANES;
        Self {
            len,
            stride,
            through: vec![0.0; stride * (MU_INTERVALS + 1)],
            fresnel: vec![0.0; stride * (MU_INTERVALS + 1)],
            body_factor: vec![0.0; stride],
            albedo_factor: vec![0.0; stride],
            specular_probability: vec![0.5; MU_INTERVALS + 1],
            lobe: SpectralLobe::Mirror,
        }
    }

    /// The specular lobe.
    pub fn lobe(&self) -> &SpectralLobe {
        &self.lobe
    }

    /// Index and weight of μ in the angular tables (nodes at μ = (j/256)²).
    #[inline]
    fn mu_position(mu: f32) -> (usize, f32) {
        let x = mu.clamp(0.0, 1.0).sqrt() * MU_INTERVALS as f32;
        let j = (x as usize).min(MU_INTERVALS - 1);
        (j, x - j as f32)
    }

    #[inline]
    fn rows<'a>(&self, table: &'a [f32], j: usize) -> (&'a [f32], &'a [f32]) {
        let a = &table[j * self.stride..(j + 1) * self.stride];
        let b = &table[(j + 1) * self.stride..(j + 2) * self.stride];
        (a, b)
    }

    /// Probability of sampling the specular part for the view cosine μo.
    #[inline]
    fn specular_probability(&self, mu_o: f32) -> f32 {
        let (j, t) = Self::mu_position(mu_o);
        let p = &self.specular_probability;
        p[j] + t * (p[j + 1] - p[j])
    }

    /// The wavelength-independent lobe value S(ωi, ωo) (not for the mirror).
    #[inline]
    fn lobe_value(&self, wi: [f32; 3], wo: [f32; 3]) -> f32 {
        match &self.lobe {
            SpectralLobe::Mirror => 0.0,
            SpectralLobe::Normalised { m, normalisation } => {
                let d = phong_lobe(wi, wo, *m);
                if d == 0.0 {
                    return 0.0;
                }
                let (j, t) = Self::mu_position(wi[2]);
                let n = normalisation[j] + t * (normalisation[j + 1] - normalisation[j]);
                d / n
            }
            SpectralLobe::Paper { m } => paper_lobe(wi, wo, *m),
        }
    }

    /// Exponent of the sampling proposal around the mirror direction. The paper's
    /// lobe cos((|Δθ| + |Δφ|)/2)^m is about as wide as a Phong lobe of m/4.
    #[inline]
    fn proposal_exponent(&self) -> Option<f32> {
        match &self.lobe {
            SpectralLobe::Mirror => None,
            SpectralLobe::Normalised { m, .. } => Some(*m),
            SpectralLobe::Paper { m } => Some(*m * 0.25),
        }
    }

    /// Body and specular reflectance for the mirror direction: R(λ, μo), used for
    /// the delta sample.
    fn mirror_reflectance(&self, mu: f32, out: &mut [f32]) {
        let (j, t) = Self::mu_position(mu);
        let (r0, r1) = self.rows(&self.fresnel, j);
        for ((o, a), b) in out.iter_mut().zip(r0).zip(r1) {
            *o = a + t * (b - a);
        }
    }
}

/// [`SpectralBsdf::eval`] on each SIMD path (`crate::simd_path`): the wavelength
/// loop is vectorised 8 wide with AVX2 where the CPU has it (the AVX-512 path runs
/// the same code compiled with AVX-512 enabled), 4 wide (SSE2) otherwise, with
/// the same operations per wavelength, so the same results.
impl SpectralPaint {
    /// [`SpectralBsdf::eval`] on `path` rather than the process's; a path this CPU
    /// lacks runs the portable code.
    pub fn eval_on(&self, path: SimdPath, wi: [f32; 3], wo: [f32; 3], out: &mut [f32]) {
        dispatch!(path.or_portable(), _ => self.eval_with(wi, wo, out));
    }

    #[inline(always)]
    fn eval_with(&self, wi: [f32; 3], wo: [f32; 3], out: &mut [f32]) {
        let out = &mut out[..self.len];
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            out.fill(0.0);
            return;
        }
        let lobe = self.lobe_value(wi, wo);
        let (ji, ti) = Self::mu_position(wi[2]);
        let (jo, to) = Self::mu_position(wo[2]);
        // Rows as [f32; LANES] chunks whose count is fixed once here, and no closure:
        // the loop then has no bounds checks and vectorises in every build (a per-
        // element closure was left out of line in some builds: 3.5x slower).
        let n = self.stride / LANES;
        let (through, _) = self.through.as_chunks::<LANES>();
        let (fresnel, _) = self.fresnel.as_chunks::<LANES>();
        let (ai0, ai1) = (&through[ji * n..][..n], &through[(ji + 1) * n..][..n]);
        let (ao0, ao1) = (&through[jo * n..][..n], &through[(jo + 1) * n..][..n]);
        let (ri0, ri1) = (&fresnel[ji * n..][..n], &fresnel[(ji + 1) * n..][..n]);
        let k = &self.body_factor.as_chunks::<LANES>().0[..n];
        let (whole, tail) = out.as_chunks_mut::<LANES>();
        for c in 0..n {
            let mut row = [0.0_f32; LANES];
            for l in 0..LANES {
                let a_i = ai0[c][l] + ti * (ai1[c][l] - ai0[c][l]);
                let a_o = ao0[c][l] + to * (ao1[c][l] - ao0[c][l]);
                let r_i = ri0[c][l] + ti * (ri1[c][l] - ri0[c][l]);
                row[l] = k[c][l] * a_i * a_o + r_i * lobe;
            }
            match whole.get_mut(c) {
                Some(o) => *o = row,
                None => tail.copy_from_slice(&row[..tail.len()]),
            }
        }
    }
}

impl SpectralBsdf for SpectralPaint {
    fn len(&self) -> usize {
        self.len
    }

    #[inline]
    fn eval(&self, wi: [f32; 3], wo: [f32; 3], out: &mut [f32]) {
        // The current path is one the CPU has: no check per call.
        dispatch!(SimdPath::current(), _ => self.eval_with(wi, wo, out));
    }

    fn pdf(&self, wo: [f32; 3], wi: [f32; 3]) -> f32 {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return 0.0;
        }
        let p_spec = self.specular_probability(wo[2]);
        let diffuse = (1.0 - p_spec) * wi[2] * std::f32::consts::FRAC_1_PI;
        match self.proposal_exponent() {
            None => diffuse,
            // The lobe is sampled about the mirror of ωo: D is symmetric in ωi, ωo.
            Some(m) => p_spec * phong_lobe_pdf(wo, wi, m) + diffuse,
        }
    }

    fn sample(&self, wo: [f32; 3], u: [f32; 3], weight: &mut [f32]) -> Option<BsdfSample> {
        if wo[2] <= 0.0 {
            return None;
        }
        let p_spec = self.specular_probability(wo[2]);
        let weight = &mut weight[..self.len];
        let wi = if u[0] < p_spec {
            match self.proposal_exponent() {
                None => {
                    let wi = mirror(wo);
                    self.mirror_reflectance(wo[2], weight);
                    weight.iter_mut().for_each(|w| *w /= p_spec);
                    return Some(BsdfSample {
                        wi,
                        pdf: p_spec,
                        delta: true,
                    });
                }
                Some(m) => sample_phong_lobe(mirror(wo), m, [u[1], u[2]])?,
            }
        } else {
            cosine_hemisphere([u[1], u[2]])
        };
        weigh_sample(self, wo, wi, weight)
    }

    fn delta_reflectance(&self, wo: [f32; 3], out: &mut [f32]) -> bool {
        if !matches!(self.lobe, SpectralLobe::Mirror) || wo[2] <= 0.0 {
            return false;
        }
        self.mirror_reflectance(wo[2], &mut out[..self.len]);
        true
    }
}

/// Completes a non-delta sample of a mixture BSDF: its density, and the path weight
/// f·cos θi/pdf per wavelength written into `weight`. `None` where the density
/// vanishes (a direction no strategy can produce).
#[inline]
pub fn weigh_sample(
    bsdf: &(impl SpectralBsdf + ?Sized),
    wo: [f32; 3],
    wi: [f32; 3],
    weight: &mut [f32],
) -> Option<BsdfSample> {
    let pdf = bsdf.pdf(wo, wi);
    if pdf.is_nan() || pdf <= 0.0 {
        return None;
    }
    bsdf.eval(wi, wo, weight);
    let scale = wi[2] / pdf;
    weight.iter_mut().for_each(|w| *w *= scale);
    Some(BsdfSample {
        wi,
        pdf,
        delta: false,
    })
}

/// Cosine-weighted direction on the upper hemisphere: density μ/π.
#[inline]
pub fn cosine_hemisphere(u: [f32; 2]) -> [f32; 3] {
    let r = u[0].sqrt();
    let phi = 2.0 * std::f32::consts::PI * u[1];
    let (s, c) = phi.sin_cos();
    [r * c, r * s, (1.0 - u[0]).max(0.0).sqrt()]
}
