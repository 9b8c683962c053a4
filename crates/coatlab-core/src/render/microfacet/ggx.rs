//! The GGX (Trowbridge–Reitz) distribution of microfacet normals, isotropic, with
//! Smith's height-correlated masking–shadowing and Heitz's sampling of the visible
//! normals ("Sampling the GGX Distribution of Visible Normals", JCGT 7(4), 2018).
//!
//! Directions are in the local frame (z = the macro-surface normal), unit length,
//! `wo` toward the viewer and `wi` toward the light, both above the surface.

use std::f32::consts::PI;

/// The smallest α used: glTF's roughness 0 is an ideal mirror, which a finite
/// lobe of α = 10⁻³ (its half-width about 0.06°) stands in for; D's peak,
/// 1/(πα²) ≈ 3·10⁵ sr⁻¹, stays well inside f32.
pub const MIN_ALPHA: f32 = 1e-3;

/// A GGX distribution of width α (glTF: α = roughness²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ggx {
    alpha: f32,
}

impl Ggx {
    /// Width α, clamped to [[`MIN_ALPHA`], 1] (a non-finite α reads as 1).
    pub fn new(alpha: f32) -> Self {
        let alpha = if alpha.is_finite() { alpha } else { 1.0 };
        Self {
            alpha: alpha.clamp(MIN_ALPHA, 1.0),
        }
    }

    /// glTF's perceptual roughness r in [0, 1]: α = r².
    pub fn from_roughness(roughness: f32) -> Self {
        Self::new(roughness * roughness)
    }

    /// α.
    pub fn alpha(self) -> f32 {
        self.alpha
    }

    /// D(h), the density of microfacet normals per solid angle of h, projected
    /// (∫ D(h) cos θh dωh = 1).
    #[inline]
    pub fn d(self, h: [f32; 3]) -> f32 {
        let a2 = self.alpha * self.alpha;
        let c2 = h[2] * h[2];
        let t = c2 * (a2 - 1.0) + 1.0;
        a2 / (PI * t * t)
    }

    /// Smith's Λ(ω); +∞ at or below the horizon.
    #[inline]
    pub fn lambda(self, w: [f32; 3]) -> f32 {
        let c2 = w[2] * w[2];
        if w[2] <= 0.0 {
            return f32::INFINITY;
        }
        let tan2 = ((1.0 - c2) / c2).max(0.0);
        0.5 * ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0)
    }

    /// G1(ω): the fraction of the microsurface seen from ω.
    #[inline]
    pub fn g1(self, w: [f32; 3]) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// G2(ωo, ωi), height-correlated.
    #[inline]
    pub fn g2(self, wo: [f32; 3], wi: [f32; 3]) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// A microfacet normal seen from `wo` (wo·z > 0), with density
    /// G1(ωo) max(0, ωo·h) D(h) / cos θo (Heitz 2018, listing 1).
    #[inline]
    pub fn sample_visible_normal(self, wo: [f32; 3], u: [f32; 2]) -> [f32; 3] {
        let a = self.alpha;
        // The view direction in the frame where the distribution is a hemisphere.
        let vh = normalise([a * wo[0], a * wo[1], wo[2]]);
        let len2 = vh[0] * vh[0] + vh[1] * vh[1];
        let t1 = if len2 > 0.0 {
            let inv = 1.0 / len2.sqrt();
            [-vh[1] * inv, vh[0] * inv, 0.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let t2 = cross(vh, t1);
        let r = u[0].sqrt();
        let (sin, cos) = (2.0 * PI * u[1]).sin_cos();
        let p1 = r * cos;
        let s = 0.5 * (1.0 + vh[2]);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sin;
        let p3 = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        let nh: [f32; 3] = std::array::from_fn(|c| p1 * t1[c] + p2 * t2[c] + p3 * vh[c]);
        normalise([a * nh[0], a * nh[1], nh[2].max(0.0)])
    }

    /// Density per solid angle of ωi of reflecting `wo` about a visible normal:
    /// G1(ωo) D(h) / (4 cos θo) with h the half vector; 0 below either horizon.
    #[inline]
    pub fn reflection_pdf(self, wo: [f32; 3], wi: [f32; 3]) -> f32 {
        if wo[2] <= 0.0 || wi[2] <= 0.0 {
            return 0.0;
        }
        let h = normalise(add(wo, wi));
        self.g1(wo) * self.d(h) / (4.0 * wo[2])
    }
}

/// `wo` mirrored about the unit normal `h`.
#[inline]
pub fn reflect(wo: [f32; 3], h: [f32; 3]) -> [f32; 3] {
    let k = 2.0 * dot(wo, h);
    std::array::from_fn(|c| k * h[c] - wo[c])
}

#[inline]
pub(super) fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
pub(super) fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline]
fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `a` scaled to unit length; the normal for a zero vector.
#[inline]
pub(super) fn normalise(a: [f32; 3]) -> [f32; 3] {
    let l2 = dot(a, a);
    if l2 > 0.0 {
        let inv = 1.0 / l2.sqrt();
        a.map(|x| x * inv)
    } else {
        [0.0, 0.0, 1.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_projected_normal_density_integrates_to_one() {
        // ∫ D(h) cos θh dωh over the hemisphere, in μ = cos θh (midpoint rule on a
        // grid fine enough for the sharpest width tested).
        for alpha in [0.05f32, 0.3, 1.0] {
            let ggx = Ggx::new(alpha);
            let n = 200_000;
            let mut sum = 0.0f64;
            for i in 0..n {
                let mu = (i as f64 + 0.5) / n as f64;
                let h = [(1.0 - mu * mu).sqrt() as f32, 0.0, mu as f32];
                sum += f64::from(ggx.d(h)) * mu;
            }
            let integral = sum * 2.0 * std::f64::consts::PI / n as f64;
            assert!((integral - 1.0).abs() < 2e-3, "α {alpha}: {integral}");
        }
    }

    #[test]
    fn visible_normals_face_the_viewer() {
        let ggx = Ggx::new(0.5);
        let wo = normalise([0.8, 0.1, 0.3]);
        for i in 0..64 {
            let u = [(i as f32 + 0.5) / 64.0, ((i * 37) % 64) as f32 / 64.0];
            let h = ggx.sample_visible_normal(wo, u);
            assert!(dot(h, wo) >= -1e-6 && h[2] >= 0.0, "{h:?}");
            assert!((dot(h, h) - 1.0).abs() < 1e-5);
        }
    }
}
