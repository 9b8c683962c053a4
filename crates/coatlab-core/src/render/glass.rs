//! Surfaces one sees through: glass (glTF transmission, ior, volume) and alpha
//! (`alphaMode` MASK and BLEND), as the tracer renders them.
//!
//! # Where a ray meets such a surface
//! Each hit is first resolved into one of three events, with random numbers where
//! the surface is a mixture (each choice made with the probability of its part,
//! so the estimate is unbiased):
//!
//! 1. **Skip** — the point is not there: alpha below `alphaCutoff` (MASK), or
//!    with probability 1 − α (BLEND). The ray goes on in the same direction, from
//!    just past the hit.
//! 2. **Glass** — with probability `transmissionFactor` where the surface is
//!    there: a smooth dielectric of index n (constant over wavelength: no
//!    dispersion), a delta BSDF:
//!    - *thin-walled* (`thicknessFactor` 0: windows, lamp lenses): a slab whose
//!      internal reflections are summed. With F the Fresnel reflectance of one
//!      face at the angle of incidence and a(λ) the transmittance of one pass
//!      through the pane,
//!
//!      R = F + (1 − F)² F a² / (1 − F² a²),  T = (1 − F)² a / (1 − F² a²),
//!
//!      reflected about the normal or transmitted straight on (no offset: the
//!      pane has no thickness in the scene). a(λ) = c(λ)^(1/cos θt), c the base
//!      colour's reflectance spectrum (glTF: the base colour tints what thin
//!      glass transmits), taken as the pane's transmittance at normal incidence
//!      and raised to the relative path length inside it. R + T = 1 without
//!      tint. Reflection or transmission is chosen by the two's share of the
//!      mean over wavelengths, the path weighed by R/P or T/P per wavelength.
//!    - *volume* (`thicknessFactor` > 0: the mesh is taken as a closed solid):
//!      reflect with probability F, else refract by Snell's law (weight 1 either
//!      way, F being the same at every wavelength). The path remembers the
//!      volume it is in; each segment inside is absorbed by Beer–Lambert,
//!      c_att(λ)^(d / d_att) (`attenuationColor`, `attenuationDistance`). The
//!      1/n² scaling of radiance on entry and n² on exit cancel for a path that
//!      leaves the volume, and are left out. Base colour does not tint volumes.
//! 3. **Opaque** — the rest: the surface's metallic-roughness material.
//!
//! # Shadow rays
//! Next-event estimation must see what the path sees, or multiple importance
//! sampling would weigh light through a window by a strategy that cannot find it.
//! Shadow rays therefore pass every straight-through part, weighted by its
//! transmittance: a skip's probability (1 for alpha below the cutoff, 1 − α for
//! BLEND) plus the covered part's transmission × T of a thin pane. A
//! transmission or skip keeps the MIS state of the vertex before it (its
//! direction is that vertex's, unchanged), so the environment seen through a
//! window is weighed exactly as the light sample that found it through the
//! same window: the car's interior is lit through its glass. Refraction into a
//! volume bends the ray; a shadow ray cannot follow it, and a volume blocks
//! shadow rays (light through solid glass arrives by the path's own
//! refracted bounces, with weight 1 as any delta bounce).
//!
//! # Left out
//! Rough transmission (`roughnessFactor` on glass: every pane is smooth),
//! `transmissionTexture` and `thicknessTexture` (their factors stand in, with a
//! warning), dispersion, nested volumes (a path inside one volume that meets
//! another takes the second as entered from air; one that escapes from inside an
//! open mesh is not absorbed on its last segment), base-colour *textures* as a
//! pane's tint (the factor tints; the texture's alpha is read for alpha modes).
//! A path passes at most [`MAX_CROSSINGS`] skips and thin-pane transmissions;
//! past that it ends (a bias toward dark that needs more panes in a row than any
//! car has).

use crate::colour::spectrum::Channels;
use crate::colour::upsampling::RgbUpsampler;
use crate::render::texturing::{TexturePoint, base_alpha};
use crate::scene::transparency::AlphaMode;
use crate::scene::{SceneMaterial, TriangleMesh};

/// Most skips and thin-pane transmissions along one path, and along one shadow
/// ray (a car: a side window in, the one opposite out, a lens and its bowl).
pub const MAX_CROSSINGS: u32 = 16;

/// Fresnel reflectance of unpolarised light at a smooth interface between
/// dielectrics, `cos_i` the cosine of incidence on the side of index nᵢ and
/// `eta` = nₜ / nᵢ; 1 under total internal reflection.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// The cosine of the refracted direction for incidence `cos_i` and `eta` = nₜ / nᵢ;
/// `None` under total internal reflection.
pub fn refracted_cos(cos_i: f32, eta: f32) -> Option<f32> {
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    (sin2_t < 1.0).then(|| (1.0 - sin2_t).sqrt())
}

/// Reflectance and transmittance of a thin pane of index `ior` at incidence
/// `cos_i`, per channel, where one pass through it at normal incidence
/// transmits `tint` (see the module documentation). Writes R to `reflect` and T
/// to `transmit`.
pub fn thin_pane(cos_i: f32, ior: f32, tint: &[f32], reflect: &mut [f32], transmit: &mut [f32]) {
    let f = fresnel_dielectric(cos_i, ior);
    let cos_t = refracted_cos(cos_i.clamp(0.0, 1.0), ior)
        .unwrap_or(1.0)
        .max(1e-3);
    for ((&c, r), t) in tint.iter().zip(reflect.iter_mut()).zip(transmit.iter_mut()) {
        let a = if c >= 1.0 {
            1.0
        } else {
            c.max(0.0).powf(1.0 / cos_t)
        };
        let inter = 1.0 - f * f * a * a;
        if inter <= 0.0 {
            // F = a = 1: a perfect mirror on both faces.
            *r = 1.0;
            *t = 0.0;
            continue;
        }
        *r = f + (1.0 - f) * (1.0 - f) * f * a * a / inter;
        *t = (1.0 - f) * (1.0 - f) * a / inter;
    }
}

/// The probability of choosing reflection at a pane that reflects `reflect` and
/// transmits `transmit` per channel: reflection's share of the mean.
pub fn reflect_probability(reflect: &[f32], transmit: &[f32]) -> f32 {
    let r: f32 = reflect.iter().sum();
    let t: f32 = transmit.iter().sum();
    if r + t > 0.0 { r / (r + t) } else { 1.0 }
}

/// What a ray does at a see-through surface (module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Crossing {
    /// The surface's opaque material shades the hit.
    Opaque,
    /// Not there: the ray goes on.
    Skip,
    /// The glass part: reflection, transmission or refraction.
    Glass,
}

/// A see-through material's derived data: its parameters with the tint and
/// attenuation colours as spectra on the render's channels.
#[derive(Debug, Clone)]
pub struct SeeThrough {
    alpha: f32,
    alpha_mode: AlphaMode,
    /// The material, for its base colour texture's alpha (`None` when alpha is
    /// ignored or untextured).
    alpha_source: Option<Box<SceneMaterial>>,
    transmission: f32,
    ior: f32,
    volume: bool,
    /// A thin pane's transmittance per pass at normal incidence.
    tint: Vec<f32>,
    /// A volume's attenuation colour and distance, m (`None`: it does not absorb).
    attenuation: Option<(Vec<f32>, f32)>,
}

impl SeeThrough {
    /// The see-through part of `material`; `None` for an opaque one.
    pub fn new(
        material: &SceneMaterial,
        upsampler: &RgbUpsampler,
        channels: &Channels,
    ) -> Option<Self> {
        let p = &material.transparency;
        if !p.is_see_through() {
            return None;
        }
        // A transmittance spectrum of a colour, relative to white's: the
        // upsampled white is not 1 at every wavelength (0.77–1.44), and a white
        // pane or attenuation colour must pass everything.
        let mut white = vec![0.0; channels.len()];
        upsampler.reflectance(palette::LinSrgb::new(1.0, 1.0, 1.0), &mut white);
        let spectrum = |rgb: palette::LinSrgb<f32>| {
            let mut out = vec![0.0; channels.len()];
            let clamped = palette::LinSrgb::new(
                rgb.red.clamp(0.0, 1.0),
                rgb.green.clamp(0.0, 1.0),
                rgb.blue.clamp(0.0, 1.0),
            );
            upsampler.reflectance(clamped, &mut out);
            for (v, w) in out.iter_mut().zip(&white) {
                *v = if *w > 0.0 {
                    (*v / w).clamp(0.0, 1.0)
                } else {
                    0.0
                };
            }
            out
        };
        let attenuation = (p.is_volume() && p.attenuation_distance_m.is_finite())
            .then(|| (spectrum(p.attenuation_color), p.attenuation_distance_m));
        let alpha_source = (p.alpha_mode != AlphaMode::Opaque
            && material.base_color_texture.is_some())
        .then(|| Box::new(material.clone()));
        Some(Self {
            alpha: p.alpha.clamp(0.0, 1.0),
            alpha_mode: p.alpha_mode,
            alpha_source,
            transmission: p.transmission.clamp(0.0, 1.0),
            ior: p.ior.max(1.0),
            volume: p.is_volume(),
            tint: spectrum(material.base_color),
            attenuation,
        })
    }

    /// Index of refraction.
    pub fn ior(&self) -> f32 {
        self.ior
    }

    /// Whether the glass is a closed volume (else a thin pane).
    pub fn is_volume(&self) -> bool {
        self.volume
    }

    /// The alpha at a point (factor × texture).
    pub fn alpha(&self, mesh: &TriangleMesh, point: &TexturePoint) -> f32 {
        match &self.alpha_source {
            Some(material) => base_alpha(material, mesh, point).clamp(0.0, 1.0),
            None => self.alpha,
        }
    }

    /// The probability that a ray passes the point untouched, for alpha `alpha`
    /// there.
    pub fn skip_probability(&self, alpha: f32) -> f32 {
        match self.alpha_mode {
            AlphaMode::Opaque => 0.0,
            AlphaMode::Mask { cutoff } => {
                if alpha < cutoff {
                    1.0
                } else {
                    0.0
                }
            }
            AlphaMode::Blend => 1.0 - alpha,
        }
    }

    /// The event at a point of alpha `alpha`; `next` gives a uniform random
    /// number, and is called only where a choice is left to chance (so a
    /// material without mixtures draws none).
    pub fn choose(&self, alpha: f32, mut next: impl FnMut() -> f32) -> Crossing {
        let skip = self.skip_probability(alpha);
        if skip >= 1.0 || (skip > 0.0 && next() < skip) {
            return Crossing::Skip;
        }
        if self.transmission >= 1.0 || (self.transmission > 0.0 && next() < self.transmission) {
            Crossing::Glass
        } else {
            Crossing::Opaque
        }
    }

    /// A thin pane's R and T at incidence `cos_i` (see [`thin_pane`]).
    pub fn pane(&self, cos_i: f32, reflect: &mut [f32], transmit: &mut [f32]) {
        thin_pane(cos_i, self.ior, &self.tint, reflect, transmit);
    }

    /// What passes straight through the point at incidence `cos_i` and alpha
    /// `alpha`, per channel, to `out` (the shadow ray's weight): the skip plus
    /// the covered part's thin-pane transmission. `scratch` is as long as `out`.
    /// Returns whether anything passes.
    pub fn straight_through(
        &self,
        cos_i: f32,
        alpha: f32,
        out: &mut [f32],
        scratch: &mut [f32],
    ) -> bool {
        let skip = self.skip_probability(alpha);
        let glass = if self.volume {
            0.0
        } else {
            (1.0 - skip) * self.transmission
        };
        if glass > 0.0 {
            self.pane(cos_i, scratch, out);
            out.iter_mut().for_each(|t| *t = skip + glass * *t);
        } else {
            out.fill(skip);
        }
        skip > 0.0 || glass > 0.0
    }

    /// Multiplies `throughput` by the volume's Beer–Lambert transmittance over
    /// `distance_m` inside it.
    pub fn absorb(&self, distance_m: f32, throughput: &mut [f32]) {
        if let Some((colour, attenuation_m)) = &self.attenuation {
            let ratio = distance_m.max(0.0) / attenuation_m;
            for (t, &c) in throughput.iter_mut().zip(colour) {
                *t *= if c >= 1.0 { 1.0 } else { c.powf(ratio) };
            }
        }
    }
}

/// The see-through materials of a scene, by scene material index (painted ones
/// are never see-through: the design covers them).
#[derive(Debug, Clone, Default)]
pub struct SeeThroughMaterials(Vec<Option<SeeThrough>>);

impl SeeThroughMaterials {
    /// From the scene's materials and which of them carry the design.
    pub fn new(
        materials: &[SceneMaterial],
        painted: &[bool],
        upsampler: &RgbUpsampler,
        channels: &Channels,
    ) -> Self {
        Self(
            materials
                .iter()
                .zip(painted)
                .map(|(m, &painted)| {
                    if painted {
                        None
                    } else {
                        SeeThrough::new(m, upsampler, channels)
                    }
                })
                .collect(),
        )
    }

    /// Scene material `material`'s see-through part, if it has one.
    #[inline]
    pub fn get(&self, material: u32) -> Option<&SeeThrough> {
        self.0.get(material as usize)?.as_ref()
    }

    /// Whether any material is see-through.
    pub fn any(&self) -> bool {
        self.0.iter().any(Option::is_some)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::transparency::Transparency;

    /// A small LCG: the tests' random numbers, reproducible.
    fn uniform(seed: u64) -> impl FnMut() -> f32 {
        let mut state = seed;
        move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 40) as f32) / 16_777_216.0
        }
    }

    const IORS: [f32; 4] = [1.0, 1.33, 1.5, 2.4];
    const COSINES: [f32; 6] = [1.0, 0.9, 0.6, 0.3, 0.1, 0.01];

    #[test]
    fn fresnel_matches_published_values() {
        // Normal incidence: ((n − 1)/(n + 1))²; glass of 1.5 reflects 4 %.
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        // Brewster's angle: the p part vanishes, R = Rs/2 (tan θB = n).
        let theta_b = 1.5f32.atan();
        let (ci, st) = (theta_b.cos(), theta_b.sin() / 1.5);
        let ct = (1.0 - st * st).sqrt();
        let rs = ((ci - 1.5 * ct) / (ci + 1.5 * ct)).powi(2);
        assert!((fresnel_dielectric(ci, 1.5) - 0.5 * rs).abs() < 1e-6);
        // Grazing: everything reflects; inside past the critical angle too.
        assert!(fresnel_dielectric(0.0, 1.5) > 0.999);
        assert_eq!(fresnel_dielectric(0.5, 1.0 / 1.5), 1.0);
        assert_eq!(fresnel_dielectric(0.7, 1.0), 0.0);
    }

    #[test]
    fn fresnel_is_reciprocal_across_the_interface() {
        // Light from outside at θi and from inside at θt reflect the same.
        for ior in IORS {
            for cos_i in COSINES {
                let cos_t = refracted_cos(cos_i, ior).expect("air to glass always refracts");
                let outside = fresnel_dielectric(cos_i, ior);
                let inside = fresnel_dielectric(cos_t, 1.0 / ior);
                assert!(
                    (outside - inside).abs() < 2e-4,
                    "n {ior}, cos {cos_i}: {outside} against {inside}"
                );
            }
        }
    }

    #[test]
    fn a_clear_pane_conserves_energy_and_a_tinted_one_absorbs() {
        let mut r = [0.0; 3];
        let mut t = [0.0; 3];
        for ior in IORS {
            for cos_i in COSINES {
                thin_pane(cos_i, ior, &[1.0, 0.6, 0.0], &mut r, &mut t);
                assert!(
                    (r[0] + t[0] - 1.0).abs() < 1e-5,
                    "clear pane, n {ior}, cos {cos_i}: R {} T {}",
                    r[0],
                    t[0]
                );
                for k in 1..3 {
                    assert!(r[k] + t[k] <= 1.0 + 1e-6 && r[k] >= 0.0 && t[k] >= 0.0);
                }
                // Absorption takes from what gets through, and more at grazing.
                assert!(t[1] <= 0.6 * t[0] + 1e-6, "n {ior}, cos {cos_i}: {t:?}");
                assert_eq!(t[2], 0.0);
                // A black pane reflects its front face alone.
                assert!((r[2] - fresnel_dielectric(cos_i, ior)).abs() < 1e-6);
            }
        }
        // A clear pane of 1.5 at normal incidence: 2F/(1 + F) = 7.7 % reflected.
        thin_pane(1.0, 1.5, &[1.0], &mut r[..1], &mut t[..1]);
        assert!((r[0] - 0.08 / 1.04).abs() < 1e-6, "{}", r[0]);
    }

    #[test]
    fn a_thin_pane_is_the_same_from_both_sides() {
        // Reciprocity of the delta lobes: T(ωo → −ωo) = T(−ωo → ωo) and R from
        // either face: the pane's response depends on |cos θ| alone, so walking
        // the same direction back gives the same weights.
        let tint = [0.9, 0.4];
        for ior in IORS {
            for cos_i in COSINES {
                let (mut r1, mut t1, mut r2, mut t2) = ([0.0; 2], [0.0; 2], [0.0; 2], [0.0; 2]);
                thin_pane(cos_i, ior, &tint, &mut r1, &mut t1);
                thin_pane((-cos_i).abs(), ior, &tint, &mut r2, &mut t2);
                assert_eq!((r1, t1), (r2, t2));
            }
        }
    }

    #[test]
    fn the_sampler_chooses_reflection_with_the_fresnel_probability() {
        // Binomial Z-test of the choice between reflection and transmission
        // against R / (R + T) of a clear pane, at several angles and indices.
        let material = SceneMaterial {
            base_color: palette::LinSrgb::new(1.0, 1.0, 1.0),
            transparency: Transparency::thin_glass(1.5),
            ..SceneMaterial::default()
        };
        let channels = Channels::LinearSrgb;
        let upsampler = RgbUpsampler::new(&channels);
        let glass = SeeThrough::new(&material, &upsampler, &channels).expect("see-through");
        let mut next = uniform(7);
        let n = 200_000;
        for cos_i in [1.0, 0.5, 0.2, 0.05] {
            let (mut r, mut t) = ([0.0; 3], [0.0; 3]);
            glass.pane(cos_i, &mut r, &mut t);
            let p = reflect_probability(&r, &t);
            assert!((p - r[0]).abs() < 1e-5, "clear: P = R");
            let reflected = (0..n).filter(|_| next() < p).count();
            let expected = p as f64 * n as f64;
            let z = (reflected as f64 - expected) / (expected * (1.0 - p as f64)).sqrt();
            assert!(z.abs() < 4.0, "cos {cos_i}: {reflected} of {n}, Z = {z:.2}");
        }
    }

    fn blend(alpha: f32, mode: AlphaMode, transmission: f32) -> SeeThrough {
        let material = SceneMaterial {
            transparency: Transparency {
                alpha,
                alpha_mode: mode,
                transmission,
                ..Transparency::default()
            },
            ..SceneMaterial::default()
        };
        let channels = Channels::LinearSrgb;
        SeeThrough::new(&material, &RgbUpsampler::new(&channels), &channels).expect("see-through")
    }

    #[test]
    fn mask_skips_exactly_below_the_cutoff() {
        let mask = blend(1.0, AlphaMode::Mask { cutoff: 0.5 }, 0.0);
        let mut draws = 0;
        let mut next = || {
            draws += 1;
            0.5
        };
        assert_eq!(mask.choose(0.4999, &mut next), Crossing::Skip);
        assert_eq!(mask.choose(0.5, &mut next), Crossing::Opaque);
        assert_eq!(mask.choose(0.9, &mut next), Crossing::Opaque);
        assert_eq!(mask.choose(0.0, &mut next), Crossing::Skip);
        assert_eq!(draws, 0, "a mask is no lottery");
        let (mut out, mut scratch) = ([0.0; 3], [0.0; 3]);
        assert!(mask.straight_through(0.7, 0.3, &mut out, &mut scratch));
        assert_eq!(out, [1.0; 3]);
        assert!(!mask.straight_through(0.7, 0.6, &mut out, &mut scratch));
        assert_eq!(out, [0.0; 3]);
    }

    #[test]
    fn blend_passes_at_one_minus_alpha() {
        let mut next = uniform(11);
        let n = 100_000;
        for alpha in [0.1f32, 0.31, 0.5, 0.9] {
            let veil = blend(alpha, AlphaMode::Blend, 0.0);
            let skips = (0..n)
                .filter(|_| veil.choose(alpha, &mut next) == Crossing::Skip)
                .count();
            let p = f64::from(1.0 - alpha);
            let expected = p * n as f64;
            let z = (skips as f64 - expected) / (expected * (1.0 - p)).sqrt();
            assert!(z.abs() < 4.0, "alpha {alpha}: {skips} of {n}, Z = {z:.2}");
            // The shadow ray's weight is the same probability.
            let (mut out, mut scratch) = ([0.0; 3], [0.0; 3]);
            veil.straight_through(1.0, alpha, &mut out, &mut scratch);
            assert!((out[0] - (1.0 - alpha)).abs() < 1e-6);
        }
        // Part glass: the covered share is glass with the transmission's
        // probability, and the shadow weight adds its pane transmittance.
        let mixed = blend(0.5, AlphaMode::Blend, 0.5);
        let counts = (0..n).fold([0usize; 3], |mut c, _| {
            c[mixed.choose(0.5, &mut next) as usize] += 1;
            c
        });
        for (count, p) in counts.iter().zip([0.25, 0.5, 0.25]) {
            let z = (*count as f64 - p * n as f64) / (p * (1.0 - p) * n as f64).sqrt();
            assert!(z.abs() < 4.0, "{counts:?}");
        }
        let (mut out, mut scratch) = ([0.0; 3], [0.0; 3]);
        mixed.straight_through(1.0, 0.5, &mut out, &mut scratch);
        let pane = 1.0 - 0.08 / 1.04;
        assert!((out[0] - (0.5 + 0.25 * pane)).abs() < 1e-4, "{out:?}");
    }

    #[test]
    fn beer_lambert_gives_the_attenuation_colour_at_its_distance() {
        let material = SceneMaterial {
            transparency: Transparency {
                transmission: 1.0,
                thickness_m: 0.01,
                attenuation_color: palette::LinSrgb::new(0.5, 0.5, 0.5),
                attenuation_distance_m: 0.2,
                ..Transparency::default()
            },
            ..SceneMaterial::default()
        };
        let channels = Channels::LinearSrgb;
        let glass = SeeThrough::new(&material, &RgbUpsampler::new(&channels), &channels)
            .expect("see-through");
        assert!(glass.is_volume());
        let mut t = [1.0; 3];
        glass.absorb(0.2, &mut t);
        assert!(t.iter().all(|v| (v - 0.5).abs() < 0.02), "{t:?}");
        glass.absorb(0.4, &mut t);
        assert!(t.iter().all(|v| (v - 0.125).abs() < 0.01), "{t:?}");
        // A volume passes no shadow ray.
        let (mut out, mut scratch) = ([0.0; 3], [0.0; 3]);
        assert!(!glass.straight_through(1.0, 1.0, &mut out, &mut scratch));
    }
}
