//! GGX microfacet BSDFs for the parts that do not carry the design: glTF's
//! metallic-roughness material as a conductor, a rough dielectric over a diffuse
//! base, and `KHR_materials_clearcoat`'s layer on top, all in one [`GltfBsdf`]
//! behind [`SpectralBsdf`]. Transmission (glass) and alpha are not modelled here.
//!
//! # The model
//!
//! With h the half vector of ωo and ωi, D, G2 of [`ggx::Ggx`] (α = r²), Schlick's
//! factor s = (1 − ωo·h)⁵, and the directional albedos E₁, E₅ of [`albedo`]:
//!
//! f = f_coat + (1 − c·E_c(μo)) (1 − c·E_c(μi)) · f_base,
//!
//! f_base = D G2 / (4 μo μi) · (F₀ + (1 − F₀) s)               (single scattering)
//!        + m · F_ms (1 − E₁(μo)) (1 − E₁(μi)) / (π (1 − E₁,avg))  (metal, multiple scattering)
//!        + (1 − m) · o · a · (1 − E_d(μo)) (1 − E_d(μi)) / (π (1 − E_d,avg))  (diffuse)
//!
//! f_coat = c · D_c G2_c / (4 μo μi) · (0.04 + 0.96 s),
//!
//! per wavelength, where
//!
//! - F₀(λ) = (1 − m) F₀,d + m · a(λ): glTF's mix of a dielectric and a conductor,
//!   exact because Schlick's Fresnel is linear in F₀. The **conductor's Fresnel**
//!   is Schlick's with F₀(λ) the upsampled base colour a(λ), as glTF defines it
//!   (an artist-friendly conductor Fresnel — Gulbrandsen's — would add an edge tint
//!   glTF does not carry).
//! - F₀,d = ((η − 1)/(η + 1))², 0.04 for glTF's default η = 1.5 or from
//!   `KHR_materials_ior`; E_d(μ) = F₀,d E₁(μ) + (1 − F₀,d) E₅(μ) is the dielectric
//!   specular lobe's albedo.
//! - **Multiple scattering** (Kulla–Conty 2017): the conductor's single-scattering
//!   lobe loses 1 − E₁(μo) of the light to paths that bounce more than once
//!   between microfacets; the second term gives it back, coloured by
//!   F_ms = F_avg² E₁,avg / (1 − F_avg (1 − E₁,avg)) with F_avg = F₀ + (1 − F₀)/21
//!   (Schlick's hemispherical average). A white conductor (F₀ = 1) reflects all.
//! - **Diffuse under the dielectric**: the light the dielectric lobe does not
//!   reflect, 1 − E_d(μ), enters the diffuse base on the way in and out (the
//!   same compensation form), so a white plastic (a = 1, m = 0) reflects exactly
//!   E_d(μo) + (1 − E_d(μo)) = 1 and a darker one less; the dielectric lobe's own
//!   multiple scattering is left to the diffuse part (it is ≤ 1 % of the light at
//!   F₀ = 0.04).
//! - **Clear coat**: a second GGX lobe of F₀ = 0.04 (glTF fixes the coat's η at
//!   1.5) over the base, which is attenuated on the way in and out by the coat's
//!   directional albedo c·E_c(μ) at each direction (instead of glTF's per-half-vector
//!   1 − c·F, which is not reciprocal and lets a rough coat reflect more than it
//!   receives). The coat carries no colour and no absorption.
//!
//! Every term is symmetric in ωo and ωi, so f is reciprocal; the directional albedo
//! is at most 1 at every μo (the white furnace tests in `tests/microfacet.rs`
//! measure both).
//!
//! # Sampling
//!
//! Three strategies, chosen by one number with probabilities proportional to the
//! lobes' albedos at μo (spectral means): the coat's visible normals, the base's
//! visible normals (Heitz 2018), and the cosine for the diffuse and multiple-
//! scattering lobes; the density reported is the mixture of all three (one-sample
//! MIS), so every strategy covers what another misses. No lobe is a delta: glTF's
//! roughness 0 is a lobe of α = [`ggx::MIN_ALPHA`], which the tracer's light
//! sampling and MIS handle like any sharp lobe, and which re-shading replays.
//!
//! # Parameters
//!
//! | name | symbol | unit | range | default | from glTF |
//! |---|---|---|---|---|---|
//! | base colour | a | linear sRGB, each component | [0, 1] | 1 | `baseColorFactor` × base-colour texture, upsampled to a(λ) |
//! | [`METALLIC`] | m | 1 | [0, 1] | 1 | `metallicFactor` × texture's blue channel |
//! | [`ROUGHNESS`] | r | 1 | [0, 1] (α = r² ≥ 10⁻³) | 1 | `roughnessFactor` × texture's green channel |
//! | [`OCCLUSION`] | o | 1 | [0, 1] | 1 | occlusion texture with its strength; darkens the diffuse term |
//! | [`INDEX_OF_REFRACTION`] | η | 1 | [1, ∞) | 1.5 | `KHR_materials_ior` `ior` (read for F₀,d only; transmission is not modelled here) |
//! | [`CLEAR_COAT`] | c | 1 | [0, 1] | 0 | `KHR_materials_clearcoat` `clearcoatFactor` |
//! | [`CLEAR_COAT_ROUGHNESS`] | r_c | 1 | [0, 1] (α_c = r_c²) | 0 | `clearcoatRoughnessFactor` |
//!
//! Values outside a range are clamped where the BSDF is built (the loader already
//! keeps factors in range); the clear coat's textures and normal map are not read.

pub mod albedo;
pub mod ggx;

use std::f32::consts::FRAC_1_PI;

use palette::LinSrgb;

use crate::colour::spectrum::Channels;
use crate::colour::upsampling::RgbUpsampler;
use crate::paint::model::{BsdfSample, SpectralBsdf, cosine_hemisphere, weigh_sample};
use crate::parameter::{Bounds, Parameter};
use crate::scene::SceneMaterial;
use crate::units::Unit;

use albedo::AlbedoRow;
use ggx::{Ggx, add, dot, normalise, reflect};

/// m: how much of the material is a conductor (glTF's metallic).
pub const METALLIC: Parameter = Parameter {
    name: "metallic",
    symbol: "m",
    unit: Unit::Dimensionless,
    range: Bounds::new(0.0, 1.0),
    control: None,
    default: 1.0,
};

/// r: glTF's perceptual roughness; the GGX width is α = r².
pub const ROUGHNESS: Parameter = Parameter {
    name: "roughness",
    symbol: "r",
    unit: Unit::Dimensionless,
    range: Bounds::new(0.0, 1.0),
    control: None,
    default: 1.0,
};

/// o: ambient occlusion, which darkens the diffuse term only.
pub const OCCLUSION: Parameter = Parameter {
    name: "occlusion",
    symbol: "o",
    unit: Unit::Dimensionless,
    range: Bounds::new(0.0, 1.0),
    control: None,
    default: 1.0,
};

/// η: the dielectric's index of refraction (`KHR_materials_ior`), for its F₀.
pub const INDEX_OF_REFRACTION: Parameter = Parameter {
    name: "index of refraction",
    symbol: "η",
    unit: Unit::Dimensionless,
    range: Bounds::new(1.0, f64::INFINITY),
    control: None,
    default: 1.5,
};

/// c: the clear coat's strength (`KHR_materials_clearcoat`'s `clearcoatFactor`).
pub const CLEAR_COAT: Parameter = Parameter {
    name: "clear coat",
    symbol: "c",
    unit: Unit::Dimensionless,
    range: Bounds::new(0.0, 1.0),
    control: None,
    default: 0.0,
};

/// r_c: the clear coat's roughness (`clearcoatRoughnessFactor`).
pub const CLEAR_COAT_ROUGHNESS: Parameter = Parameter {
    name: "clear coat roughness",
    symbol: "r_c",
    unit: Unit::Dimensionless,
    range: Bounds::new(0.0, 1.0),
    control: None,
    default: 0.0,
};

/// F₀ of the clear coat: glTF fixes its index at 1.5.
const COAT_F0: f32 = 0.04;

/// The parameters of one point of a glTF metallic-roughness material (see the
/// module's table), textures already applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GltfParameters {
    /// a, linear sRGB.
    pub base_color: LinSrgb<f32>,
    /// m.
    pub metallic: f32,
    /// r.
    pub roughness: f32,
    /// o.
    pub occlusion: f32,
    /// η.
    pub ior: f32,
    /// c.
    pub clearcoat: f32,
    /// r_c.
    pub clearcoat_roughness: f32,
}

impl Default for GltfParameters {
    /// glTF's material with no properties: white, metallic, rough, no coat.
    fn default() -> Self {
        Self {
            base_color: LinSrgb::new(1.0, 1.0, 1.0),
            metallic: METALLIC.default as f32,
            roughness: ROUGHNESS.default as f32,
            occlusion: OCCLUSION.default as f32,
            ior: INDEX_OF_REFRACTION.default as f32,
            clearcoat: CLEAR_COAT.default as f32,
            clearcoat_roughness: CLEAR_COAT_ROUGHNESS.default as f32,
        }
    }
}

impl GltfParameters {
    /// The factors of `material` (its textures are applied per hit by
    /// [`crate::render::texturing::surface_parameters`]); occlusion 1.
    pub fn factors(material: &SceneMaterial) -> Self {
        Self {
            base_color: material.base_color,
            metallic: material.metallic,
            roughness: material.roughness,
            occlusion: 1.0,
            ior: material.ior,
            clearcoat: material.clearcoat,
            clearcoat_roughness: material.clearcoat_roughness,
        }
    }
}

/// `value` clamped to `parameter`'s range; its default when not finite.
fn clamped(parameter: &Parameter, value: f32) -> f32 {
    if value.is_finite() {
        (f64::from(value).clamp(parameter.range.min, parameter.range.max)) as f32
    } else {
        parameter.default as f32
    }
}

/// The clear-coat layer of a [`GltfBsdf`].
#[derive(Debug, Clone, PartialEq)]
struct Coat {
    factor: f32,
    ggx: Ggx,
    row: AlbedoRow,
}

impl Coat {
    /// c·E_c(μ): what the coat reflects of light arriving at cos θ = μ.
    #[inline]
    fn albedo(&self, mu: f32) -> f32 {
        self.factor * self.row.albedo(mu, COAT_F0)
    }
}

/// glTF's metallic-roughness material with clear coat as GGX lobes (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct GltfBsdf {
    ggx: Ggx,
    row: AlbedoRow,
    /// F₀,d of the dielectric part.
    dielectric_f0: f32,
    /// Per wavelength: F₀(λ) of the single-scattering lobe.
    f0: Vec<f32>,
    /// Per wavelength: m·F_ms(λ) / (π (1 − E₁,avg)).
    multiple: Vec<f32>,
    /// Per wavelength: (1 − m)·o·a(λ) / (π (1 − E_d,avg)).
    diffuse: Vec<f32>,
    /// Spectral means for the choice of strategy: F₀, m·F_ms and (1 − m)·o·a.
    mean_f0: f32,
    mean_multiple_albedo: f32,
    mean_diffuse_albedo: f32,
    coat: Option<Coat>,
}

impl GltfBsdf {
    /// The BSDF of `parameters` on `channels`; out-of-range values are clamped.
    pub fn new(parameters: &GltfParameters, upsampler: &RgbUpsampler, channels: &Channels) -> Self {
        let c = parameters.base_color;
        let unit = |x: f32| {
            if x.is_finite() {
                x.clamp(0.0, 1.0)
            } else {
                1.0
            }
        };
        let mut base = vec![0.0; channels.len()];
        upsampler.reflectance(
            LinSrgb::new(unit(c.red), unit(c.green), unit(c.blue)),
            &mut base,
        );
        let metallic = clamped(&METALLIC, parameters.metallic);
        let occlusion = clamped(&OCCLUSION, parameters.occlusion);
        let eta = clamped(&INDEX_OF_REFRACTION, parameters.ior);
        let dielectric_f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
        let ggx = Ggx::from_roughness(clamped(&ROUGHNESS, parameters.roughness));
        let row = AlbedoRow::new(ggx);
        let average1 = row.average(1.0);
        let multiple_norm = if 1.0 - average1 > 1e-6 {
            FRAC_1_PI / (1.0 - average1)
        } else {
            0.0
        };
        let diffuse_norm = FRAC_1_PI / (1.0 - row.average(dielectric_f0)).max(1e-6);
        let len = base.len();
        let (mut f0, mut multiple, mut diffuse) = (
            Vec::with_capacity(len),
            Vec::with_capacity(len),
            Vec::with_capacity(len),
        );
        let (mut sum_f0, mut sum_multiple, mut sum_diffuse) = (0.0, 0.0, 0.0);
        for &a in &base {
            let a = a.clamp(0.0, 1.0);
            f0.push(dielectric_f0 + metallic * (a - dielectric_f0));
            let f_avg = a + (1.0 - a) / 21.0;
            let f_ms = f_avg * f_avg * average1 / (1.0 - f_avg * (1.0 - average1)).max(1e-6);
            multiple.push(metallic * f_ms * multiple_norm);
            let d = (1.0 - metallic) * occlusion * a;
            diffuse.push(d * diffuse_norm);
            sum_f0 += f0[f0.len() - 1];
            sum_multiple += metallic * f_ms;
            sum_diffuse += d;
        }
        let n = len.max(1) as f32;
        let factor = clamped(&CLEAR_COAT, parameters.clearcoat);
        let coat = (factor > 0.0).then(|| {
            let ggx = Ggx::from_roughness(clamped(
                &CLEAR_COAT_ROUGHNESS,
                parameters.clearcoat_roughness,
            ));
            Coat {
                factor,
                ggx,
                row: AlbedoRow::new(ggx),
            }
        });
        Self {
            ggx,
            row,
            dielectric_f0,
            f0,
            multiple,
            diffuse,
            mean_f0: sum_f0 / n,
            mean_multiple_albedo: sum_multiple / n,
            mean_diffuse_albedo: sum_diffuse / n,
            coat,
        }
    }

    /// Probabilities of the coat, base-lobe and cosine strategies at cos θo = `mu`;
    /// `None` for a black material.
    #[inline]
    fn strategy_probabilities(&self, mu: f32) -> Option<[f32; 3]> {
        let coat = self.coat.as_ref().map_or(0.0, |c| c.albedo(mu));
        let (e1, e5) = self.row.at(mu);
        let through = 1.0 - coat;
        let specular = through * (self.mean_f0 * e1 + (1.0 - self.mean_f0) * e5);
        let ed = self.dielectric_f0 * e1 + (1.0 - self.dielectric_f0) * e5;
        let cosine = through
            * (self.mean_multiple_albedo * (1.0 - e1).max(0.0)
                + self.mean_diffuse_albedo * (1.0 - ed).max(0.0));
        let total = coat + specular + cosine;
        (total > 0.0 && total.is_finite()).then(|| [coat / total, specular / total, cosine / total])
    }

    /// f for ωi and ωo both above the surface.
    #[inline]
    fn eval_above(&self, wi: [f32; 3], wo: [f32; 3], out: &mut [f32]) {
        let h = normalise(add(wo, wi));
        let s = (1.0 - dot(wo, h).clamp(0.0, 1.0)).powi(5);
        let inv_denominator = 1.0 / (4.0 * wo[2] * wi[2]);
        let specular = self.ggx.d(h) * self.ggx.g2(wo, wi) * inv_denominator;
        let (e1o, e5o) = self.row.at(wo[2]);
        let (e1i, e5i) = self.row.at(wi[2]);
        let multiple = (1.0 - e1o).max(0.0) * (1.0 - e1i).max(0.0);
        let fd = self.dielectric_f0;
        let diffuse = (1.0 - (fd * e1o + (1.0 - fd) * e5o)).max(0.0)
            * (1.0 - (fd * e1i + (1.0 - fd) * e5i)).max(0.0);
        let (coat, through) = match &self.coat {
            Some(c) => (
                c.factor
                    * c.ggx.d(h)
                    * c.ggx.g2(wo, wi)
                    * inv_denominator
                    * (COAT_F0 + (1.0 - COAT_F0) * s),
                (1.0 - c.albedo(wo[2])) * (1.0 - c.albedo(wi[2])),
            ),
            None => (0.0, 1.0),
        };
        for (((o, &f0), &m), &d) in out
            .iter_mut()
            .zip(&self.f0)
            .zip(&self.multiple)
            .zip(&self.diffuse)
        {
            *o = coat + through * (specular * (f0 + (1.0 - f0) * s) + multiple * m + diffuse * d);
        }
    }

    fn mixture_pdf(&self, p: [f32; 3], wo: [f32; 3], wi: [f32; 3]) -> f32 {
        let coat = match &self.coat {
            Some(c) if p[0] > 0.0 => p[0] * c.ggx.reflection_pdf(wo, wi),
            _ => 0.0,
        };
        coat + p[1] * self.ggx.reflection_pdf(wo, wi) + p[2] * wi[2] * FRAC_1_PI
    }
}

impl SpectralBsdf for GltfBsdf {
    fn len(&self) -> usize {
        self.f0.len()
    }

    #[inline]
    fn eval(&self, wi: [f32; 3], wo: [f32; 3], out: &mut [f32]) {
        if wi[2] > 0.0 && wo[2] > 0.0 {
            self.eval_above(wi, wo, out);
        } else {
            out.fill(0.0);
        }
    }

    #[inline]
    fn pdf(&self, wo: [f32; 3], wi: [f32; 3]) -> f32 {
        if wo[2] <= 0.0 || wi[2] <= 0.0 {
            return 0.0;
        }
        self.strategy_probabilities(wo[2])
            .map_or(0.0, |p| self.mixture_pdf(p, wo, wi))
    }

    #[inline]
    fn sample(&self, wo: [f32; 3], u: [f32; 3], weight: &mut [f32]) -> Option<BsdfSample> {
        if wo[2] <= 0.0 {
            return None;
        }
        let p = self.strategy_probabilities(wo[2])?;
        let direction = [u[1], u[2]];
        let wi = match &self.coat {
            Some(c) if u[0] < p[0] => reflect(wo, c.ggx.sample_visible_normal(wo, direction)),
            _ if u[0] < p[0] + p[1] => reflect(wo, self.ggx.sample_visible_normal(wo, direction)),
            _ => cosine_hemisphere(direction),
        };
        if wi[2] <= 0.0 {
            return None;
        }
        weigh_sample(self, wo, wi, weight)
    }
}
