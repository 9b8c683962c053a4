//! What the tracer shades with: the designed paint (as the paint model or as one of
//! the two Phong translations the paper compares it with), the glTF materials of the
//! rest of the scene, and the floor.
//!
//! # The other parts
//! Parts that are not painted keep the glTF metallic-roughness description they came
//! with (and `KHR_materials_clearcoat`, `KHR_materials_ior`), rendered by the GGX
//! microfacet BSDF of [`crate::render::microfacet`] (its module documentation has
//! the model and the parameter table): a conductor with Schlick's spectral Fresnel
//! from the base colour and Kulla–Conty multiple scattering, a rough dielectric over
//! an energy-compensated diffuse base, and an optional clear coat. A textured
//! material's parameters are taken at each hit ([`crate::render::texturing`]) and
//! its BSDF built there; [`Shading::extras`] says which materials need that, and
//! which emit. Glass and alpha are [`crate::render::glass`]'s
//! ([`Shading::see_through`]). What is left out (sheen, among others) is listed in
//! `docs/materials.md`.
//!
//! # The floor
//! [`SimpleMaterial`]: the floor's Lambertian reflector (a Phong mixture with the
//! reciprocal normalisation, of which only the diffuse part is used there).

use std::sync::Arc;

use crate::colour::spectrum::Channels;
use crate::colour::upsampling::RgbUpsampler;
use crate::paint::model::{BsdfSample, PaintModel, SpectralBsdf, SpectralPaint};
use crate::paint::phong::{PhongNormalisation, PhongParams, PhongVariant, SpectralPhong};
use crate::render::glass::SeeThroughMaterials;
use crate::render::microfacet::{GltfBsdf, GltfParameters};
use crate::scene::{Scene, SceneMaterial};

/// Sharpest lobe a [`SimpleMaterial`] gets; at 10⁵ the lobe is 0.3° wide.
pub const MAX_SIMPLE_EXPONENT: f32 = 1e5;

/// Which model renders the designed paint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ShadingModel {
    /// The paint model of `docs/model.md`.
    #[default]
    Paint,
    /// Phong with the parameters of [`PhongVariant`].
    Phong(PhongVariant),
}

impl ShadingModel {
    /// The label the UI and the CLI show.
    pub fn label(self) -> &'static str {
        match self {
            ShadingModel::Paint => "Paint model",
            ShadingModel::Phong(variant) => variant.label(),
        }
    }
}

/// The designed paint in the form the tracer evaluates.
#[derive(Debug, Clone)]
pub enum DesignBsdf {
    /// The paint model's single-precision tables.
    Paint(SpectralPaint),
    /// A Phong translation of the design.
    Phong(SpectralPhong),
}

impl DesignBsdf {
    /// The exponent of the design's specular lobe; `None` for an ideal mirror.
    pub fn lobe_exponent(&self) -> Option<f32> {
        match self {
            DesignBsdf::Paint(b) => b.lobe_exponent(),
            DesignBsdf::Phong(b) => Some(b.exponent()),
        }
    }
}

impl SpectralBsdf for DesignBsdf {
    fn len(&self) -> usize {
        match self {
            DesignBsdf::Paint(b) => b.len(),
            DesignBsdf::Phong(b) => b.len(),
        }
    }

    #[inline]
    fn eval(&self, wi: [f32; 3], wo: [f32; 3], out: &mut [f32]) {
        match self {
            DesignBsdf::Paint(b) => b.eval(wi, wo, out),
            DesignBsdf::Phong(b) => b.eval(wi, wo, out),
        }
    }

    #[inline]
    fn pdf(&self, wo: [f32; 3], wi: [f32; 3]) -> f32 {
        match self {
            DesignBsdf::Paint(b) => b.pdf(wo, wi),
            DesignBsdf::Phong(b) => b.pdf(wo, wi),
        }
    }

    #[inline]
    fn sample(&self, wo: [f32; 3], u: [f32; 3], weight: &mut [f32]) -> Option<BsdfSample> {
        match self {
            DesignBsdf::Paint(b) => b.sample(wo, u, weight),
            DesignBsdf::Phong(b) => b.sample(wo, u, weight),
        }
    }

    #[inline]
    fn delta_reflectance(&self, wo: [f32; 3], out: &mut [f32]) -> bool {
        match self {
            DesignBsdf::Paint(b) => b.delta_reflectance(wo, out),
            DesignBsdf::Phong(b) => b.delta_reflectance(wo, out),
        }
    }
}

/// A Lambertian (and optionally glossy) reflector: a Phong mixture with the
/// reciprocal normalisation, its lobe's directional albedo at most F₀ at every
/// angle. The floor uses it.
#[derive(Debug, Clone, PartialEq)]
pub struct SimpleMaterial(SpectralPhong);

impl SimpleMaterial {
    /// A Lambertian reflector with reflectance `albedo` per channel.
    pub fn lambertian(albedo: &[f32]) -> Self {
        Self::new(albedo, &vec![0.0; albedo.len()], 1.0)
    }

    /// From diffuse albedo a(λ), specular colour F₀(λ) and lobe exponent m.
    pub fn new(albedo: &[f32], specular: &[f32], exponent: f32) -> Self {
        let diffuse_over_pi: Vec<f32> = albedo
            .iter()
            .zip(specular)
            .map(|(&a, &f0)| (1.0 - f0) * a * std::f32::consts::FRAC_1_PI)
            .collect();
        let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len().max(1) as f32;
        let diffuse_mean = mean(&diffuse_over_pi) * std::f32::consts::PI;
        let specular_mean = mean(specular);
        // Sample each part by its share of the reflected energy, but never starve a
        // part that is present (its variance would explode).
        let specular_probability = if specular_mean <= 0.0 {
            0.0
        } else if diffuse_mean <= 0.0 {
            1.0
        } else {
            (specular_mean / (specular_mean + diffuse_mean)).clamp(0.1, 0.9)
        };
        Self(SpectralPhong::new(
            diffuse_over_pi,
            specular.to_vec(),
            exponent.clamp(0.0, MAX_SIMPLE_EXPONENT),
            specular_probability,
            PhongNormalisation::Reciprocal,
        ))
    }
}

impl SpectralBsdf for SimpleMaterial {
    fn len(&self) -> usize {
        self.0.len()
    }

    #[inline]
    fn eval(&self, wi: [f32; 3], wo: [f32; 3], out: &mut [f32]) {
        self.0.eval(wi, wo, out);
    }

    #[inline]
    fn pdf(&self, wo: [f32; 3], wi: [f32; 3]) -> f32 {
        self.0.pdf(wo, wi)
    }

    #[inline]
    fn sample(&self, wo: [f32; 3], u: [f32; 3], weight: &mut [f32]) -> Option<BsdfSample> {
        self.0.sample(wo, u, weight)
    }
}

/// Everything the tracer needs to shade one scene with one design: the design's
/// BSDF, a GGX material per scene material, which of them carry the paint, and
/// the floor. Built when the design, the model or the scene changes; the geometry
/// and its BVH are not touched.
#[derive(Debug, Clone)]
pub struct Shading {
    channels: Channels,
    model: ShadingModel,
    design: DesignBsdf,
    simple: Vec<GltfBsdf>,
    painted: Vec<bool>,
    /// Per scene material: what a hit on it needs beyond `simple` (textures,
    /// emission); `None` for most, and for every painted one.
    surfaces: Vec<Option<SurfaceExtras>>,
    /// Per scene material: its glass and alpha ([`crate::render::glass`]).
    see_through: SeeThroughMaterials,
    upsampler: RgbUpsampler,
}

/// What a non-paint material needs per hit besides its BSDF of factors.
#[derive(Debug, Clone)]
pub enum SurfaceExtras {
    /// Its textures are looked up at each hit (and its emission, if any, with them).
    Textured(Box<SceneMaterial>),
    /// Untextured, emitting this spectral radiance.
    Emissive(Vec<f32>),
}

impl Shading {
    /// [`Self::new`] with the materials of `scene` and the ones it paints.
    pub fn for_scene(paint: &PaintModel, model: ShadingModel, scene: &Scene) -> Self {
        Self::new(paint, model, &scene.materials, &scene.paint_materials)
    }

    /// The shading of a scene whose materials are `materials`, of which
    /// `paint_materials` (indices) carry the design `paint`, rendered with `model`.
    pub fn new(
        paint: &PaintModel,
        model: ShadingModel,
        materials: &[SceneMaterial],
        paint_materials: &[u32],
    ) -> Self {
        let channels = paint.channels();
        let design = match model {
            ShadingModel::Paint => DesignBsdf::Paint(paint.spectral().clone()),
            ShadingModel::Phong(PhongVariant::Naive) => {
                DesignBsdf::Phong(PhongParams::naive(paint).spectral())
            }
            ShadingModel::Phong(PhongVariant::BestFit) => {
                DesignBsdf::Phong(PhongParams::best_fit(paint).spectral())
            }
        };
        let upsampler = RgbUpsampler::new(channels);
        let simple = materials
            .iter()
            .map(|m| GltfBsdf::new(&GltfParameters::factors(m), &upsampler, channels))
            .collect();
        let mut painted = vec![false; materials.len()];
        for &index in paint_materials {
            if let Some(p) = painted.get_mut(index as usize) {
                *p = true;
            }
        }
        let surfaces = materials
            .iter()
            .zip(&painted)
            .map(|(m, &painted)| {
                if painted {
                    None
                } else if m.has_textures() {
                    Some(SurfaceExtras::Textured(Box::new(m.clone())))
                } else if m.is_emissive() {
                    let mut emission = vec![0.0; channels.len()];
                    upsampler.emission(m.emissive, &mut emission);
                    Some(SurfaceExtras::Emissive(emission))
                } else {
                    None
                }
            })
            .collect();
        let see_through = SeeThroughMaterials::new(materials, &painted, &upsampler, channels);
        Self {
            channels: *channels,
            model,
            design,
            simple,
            painted,
            surfaces,
            see_through,
            upsampler,
        }
    }

    /// The scene's glass and alpha-blended or masked materials.
    #[inline]
    pub fn see_through(&self) -> &SeeThroughMaterials {
        &self.see_through
    }

    /// What a hit on scene material `material` needs beyond [`Self::material`]:
    /// `None` for the paint and plain materials.
    #[inline]
    pub fn extras(&self, material: u32) -> Option<&SurfaceExtras> {
        self.surfaces.get(material as usize)?.as_ref()
    }

    /// Whether a material that does not carry the design is textured (then
    /// recorded paths cannot be re-shaded: the replay does not look textures up
    /// again).
    pub fn has_textures(&self) -> bool {
        self.surfaces
            .iter()
            .any(|s| matches!(s, Some(SurfaceExtras::Textured(_))))
    }

    /// The spectra of RGB colours on these channels.
    pub fn upsampler(&self) -> &RgbUpsampler {
        &self.upsampler
    }

    /// What the per-channel values here are for: a wavelength grid, or linear sRGB.
    pub fn channels(&self) -> &Channels {
        &self.channels
    }

    /// The model the design is rendered with.
    pub fn model(&self) -> ShadingModel {
        self.model
    }

    /// The design's BSDF.
    pub fn design(&self) -> &DesignBsdf {
        &self.design
    }

    /// Number of channels.
    pub fn len(&self) -> usize {
        self.design.len()
    }

    /// Whether there are no channels.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether scene material `material` carries the design (an index the scene
    /// does not have counts as painted, like [`Self::material`]).
    #[inline]
    pub fn is_painted(&self, material: u32) -> bool {
        self.painted.get(material as usize).copied().unwrap_or(true)
    }

    /// The BSDF of scene material `material`; an index the scene does not have
    /// (which the loader never produces) shades as the paint.
    #[inline]
    pub fn material(&self, material: u32) -> &dyn SpectralBsdf {
        let index = material as usize;
        match self.painted.get(index) {
            Some(false) => &self.simple[index],
            _ => &self.design,
        }
    }
}

/// Shared handle, as the progressive renderer keeps it.
pub type SharedShading = Arc<Shading>;

#[cfg(test)]
mod tests {
    use super::*;
    fn directional_albedo(material: &SimpleMaterial, wo: [f32; 3]) -> f32 {
        // Importance-sampled estimate of ∫ f cos θi dωi at the first wavelength.
        let mut weight = vec![0.0; material.len()];
        let n = 200_000;
        let mut sum = 0.0f64;
        for i in 0..n {
            let u = [
                (i as f32 + 0.5) / n as f32,
                ((i as u64 * 7919) % n as u64) as f32 / n as f32,
                ((i as u64 * 104_729) % n as u64) as f32 / n as f32,
            ];
            if material.sample(wo, u, &mut weight).is_some() {
                sum += f64::from(weight[0]);
            }
        }
        (sum / f64::from(n)) as f32
    }

    #[test]
    fn a_lambertian_reflects_its_albedo_and_samples_by_cosine() {
        let m = SimpleMaterial::lambertian(&[0.5; 4]);
        let mut out = [0.0; 4];
        m.eval([0.0, 0.6, 0.8], [0.0, 0.0, 1.0], &mut out);
        assert!((out[0] - 0.5 / std::f32::consts::PI).abs() < 1e-7);
        assert!(
            (m.pdf([0.0, 0.0, 1.0], [0.0, 0.6, 0.8]) - 0.8 / std::f32::consts::PI).abs() < 1e-6
        );
        let albedo = directional_albedo(&m, [0.0, 0.0, 1.0]);
        assert!((albedo - 0.5).abs() < 1e-3, "{albedo}");
    }

    #[test]
    fn sampled_directions_have_the_density_pdf_reports() {
        // Histogram test over cos θ bins: the sampler and pdf() agree.
        let m = SimpleMaterial::new(&[0.4; 2], &[0.3; 2], 40.0);
        let wo = [0.6, 0.0, 0.8];
        let bins = 32;
        let n = 400_000u32;
        let mut counts = vec![0u32; bins];
        let mut weight = [0.0; 2];
        let mut state = 0x1234_5678_u64;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 40) as f32) / 16_777_216.0
        };
        for _ in 0..n {
            let u = [next(), next(), next()];
            if let Some(s) = m.sample(wo, u, &mut weight) {
                let bin = ((s.wi[2] * bins as f32) as usize).min(bins - 1);
                counts[bin] += 1;
            }
        }
        // Expected mass per bin by quadrature of pdf over (cos θ, φ).
        for (bin, &count) in counts.iter().enumerate() {
            let (mut mass, steps_mu, steps_phi) = (0.0f64, 64, 512);
            for i in 0..steps_mu {
                let mu = (bin as f64 + (i as f64 + 0.5) / steps_mu as f64) / bins as f64;
                let s = (1.0 - mu * mu).sqrt();
                for j in 0..steps_phi {
                    let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / steps_phi as f64;
                    let wi = [(s * phi.cos()) as f32, (s * phi.sin()) as f32, mu as f32];
                    mass += f64::from(m.pdf(wo, wi));
                }
            }
            mass *= 2.0 * std::f64::consts::PI / (steps_phi as f64 * steps_mu as f64 * bins as f64);
            let expected = mass * f64::from(n);
            let z = (f64::from(count) - expected) / expected.max(1.0).sqrt();
            assert!(
                z.abs() < 5.0,
                "bin {bin}: {count} against {expected:.1} (Z = {z:.1})"
            );
        }
    }
}
