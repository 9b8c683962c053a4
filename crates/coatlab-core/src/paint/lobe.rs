//! The gloss lobe that spreads the mirror term (spec 4.2): its shape, its
//! normalisation and how to sample it.
//!
//! Directions live in the local shading frame (z = surface normal); `wi` points
//! toward the light, `wo` toward the viewer, both in the upper hemisphere. The
//! mirror direction of `wi` is `(−x, −y, z)`.
//!
//! Lobe family (an engineering choice the spec leaves open): the Phong lobe about
//! the mirror direction, D(ωo) = max(0, ωo·ωr)^m. It is symmetric in ωi and ωo
//! (ωo·ωr(ωi) = ωi·ωr(ωo)), rotationally symmetric about ωr, and has an exact
//! sampling routine. Its normalisation
//!
//!   N(μi, m) = ∫_{H+} D μo dωo = 2πμi/(m+2) + Δ(μi, m)
//!
//! is the full-lobe value (the lobe integrated over the whole sphere cap, which is
//! exact when the lobe does not dip below the horizon) plus Δ ≥ 0, which restores
//! the negative contribution of the part below the horizon. Δ reduces to a 1-D
//! integral because the azimuthal integral of max(0, a + b cos β) is closed form.
//!
//! f_spec = R(μi) D / N(μi) is not reciprocal: R(μi)/N(μi) depends on the incidence
//! alone. Only the lobe shape D is reciprocal, which the tests check.

use std::f64::consts::PI;

use num_traits::Float;

use crate::quadrature::integrate_relative_from;

/// Which specular lobe a design uses (spec 4.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LobeKind {
    /// Energy-conserving: R(μi)·D/N, so the specular albedo is exactly R(μi).
    #[default]
    Normalised,
    /// The paper's eq. 25′ as printed: R(μi)·cos((|θo−θr| + |Δφ|)/2)^m, not normalised.
    Paper,
}

impl LobeKind {
    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            LobeKind::Normalised => "normalised",
            LobeKind::Paper => "paper",
        }
    }
}

/// The mirror direction ωr of ωi in the local frame.
#[inline]
pub fn mirror<F: Float>(wi: [F; 3]) -> [F; 3] {
    [-wi[0], -wi[1], wi[2]]
}

/// 1 − ωo·ωr, computed from the chord so it keeps its relative precision for the
/// nearly parallel directions of a sharp lobe (where 1 − cos α would cancel).
#[inline]
pub fn one_minus_cos_to_mirror<F: Float>(wi: [F; 3], wo: [F; 3]) -> F {
    let r = mirror(wi);
    let d = [wo[0] - r[0], wo[1] - r[1], wo[2] - r[2]];
    let half = F::from(0.5).unwrap_or_else(F::one);
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) * half
}

/// The Phong lobe shape D = max(0, ωo·ωr)^m.
#[inline]
pub fn phong_lobe<F: Float>(wi: [F; 3], wo: [F; 3], m: F) -> F {
    let one_minus_cos = one_minus_cos_to_mirror(wi, wo);
    if one_minus_cos >= F::one() {
        return F::zero();
    }
    if m == F::zero() {
        return F::one();
    }
    // cos^m = exp(m·ln(1 − (1 − cos))) keeps precision for m up to 1e8 in f32.
    (m * (-one_minus_cos).ln_1p()).exp()
}

/// The paper's lobe cos((|θo − θr| + |Δφ|)/2)^m clamped at 0 (eq. 25′ as printed).
///
/// Azimuth is undefined at the pole; there Δφ is taken as 0, the limit along any
/// path that keeps the azimuth fixed.
///
/// Both differences are computed from d = ωo − ωr (exact for nearby directions),
/// not as differences of two arctangents, which lose ~1e-7 rad in f32: a lobe of
/// m = 1e9 is ~1e-4 rad wide, and the f32 value was then 2 % off the f64 one
/// (`tests/extremes.rs`).
pub fn paper_lobe<F: Float>(wi: [F; 3], wo: [F; 3], m: F) -> F {
    let r = mirror(wi);
    let d = [wo[0] - r[0], wo[1] - r[1], wo[2] - r[2]];
    let sin_theta = |w: [F; 3]| (w[0] * w[0] + w[1] * w[1]).sqrt();
    let (sin_o, sin_r) = (sin_theta(wo), sin_theta(r));
    // θo − θr = atan2(sin θo cos θr − cos θo sin θr, cos θo cos θr + sin θo sin θr),
    // with sin θo − sin θr = (d·(ωo + ωr) in x, y)/(sin θo + sin θr).
    let sin_sum = sin_o + sin_r;
    let sin_difference = if sin_sum > F::zero() {
        (d[0] * (wo[0] + r[0]) + d[1] * (wo[1] + r[1])) / sin_sum
    } else {
        F::zero()
    };
    let d_theta = (sin_difference * r[2] - d[2] * sin_r)
        .atan2(wo[2] * r[2] + sin_o * sin_r)
        .abs();
    let on_pole = |w: [F; 3]| w[0] == F::zero() && w[1] == F::zero();
    // |Δφ| in [0, π]: the angle between the horizontal projections, its sine
    // xo·yr − yo·xr = yo·dx − xo·dy.
    let d_phi = if on_pole(wo) || on_pole(r) {
        F::zero()
    } else {
        (wo[1] * d[0] - wo[0] * d[1])
            .abs()
            .atan2(wo[0] * r[0] + wo[1] * r[1])
    };
    let half = F::from(0.5).unwrap_or_else(F::one);
    let angle = (d_theta + d_phi) * half;
    if angle.cos() <= F::zero() {
        F::zero()
    } else if m == F::zero() {
        F::one()
    } else {
        // cos^m = exp(m·ln(1 − 2 sin²(angle/2))): cos itself loses the small
        // deviations from 1 that a sharp lobe depends on (in f32 above all).
        let s = (angle * half).sin();
        let two = F::one() + F::one();
        (m * (-(two * s * s)).ln_1p()).exp()
    }
}

/// N(μi, m) = ∫_{H+} max(0, ωo·ωr)^m μo dωo for finite m ≥ 0.
pub fn phong_normalisation(cos_i: f64, m: f64) -> f64 {
    let mu = cos_i.clamp(0.0, 1.0);
    2.0 * PI * mu / (m + 2.0) + below_horizon_correction(mu, m)
}

/// Δ(μr, m) = ∫₀^{t_k} t^m · 2b(t)·h(a/b) dt, with t = cos α the cosine to the
/// lobe axis, a = tμr, b = sqrt(1−t²)·sin θr, h(c) = sqrt(1−c²) − c·acos(c), and
/// t_k = sin θr the last t at which the lobe's ring reaches below the horizon.
pub fn below_horizon_correction(cos_r: f64, m: f64) -> f64 {
    let mu = cos_r.clamp(0.0, 1.0);
    let sin_r = ((1.0 - mu) * (1.0 + mu)).sqrt();
    if sin_r == 0.0 {
        return 0.0;
    }
    // Integrate in v = t_k − t so the small differences near the lobe's edge are
    // exact. t^m falls below e^{-50} (relative to t_k^m) beyond v = t_k(1 − e^{−50/m}).
    let v_max = if m > 0.0 {
        -sin_r * (-50.0 / m).exp_m1()
    } else {
        sin_r
    };
    let integrand_in_v = |v: f64| {
        let t = sin_r - v;
        if t <= 0.0 && m > 0.0 {
            return 0.0;
        }
        let b = ((1.0 - t) * (1.0 + t)).max(0.0).sqrt() * sin_r;
        if b <= 0.0 {
            return 0.0;
        }
        // 1 − c = (t_k − t)(t_k + t)/(b(b + tμ)) since b² − (tμ)² = t_k² − t².
        let one_minus_c = (v * (sin_r + t) / (b * (b + t * mu))).clamp(0.0, 1.0);
        let h = ring_below_horizon(one_minus_c);
        // (t/t_k)^m: t_k^m is factored out so the tolerance is relative to the
        // integral itself, not to an underflowing scale.
        let power = if m == 0.0 {
            1.0
        } else {
            (m * (-v / sin_r).ln_1p()).exp()
        };
        power * 2.0 * b * h
    };
    // h ∝ v^{3/2} at the lobe's edge (v = 0), which Gauss–Legendre resolves only by
    // refining; in w = sqrt(v) the integrand 2w·g(w²) is smooth. 1e-8 is far inside
    // the table's 3e-6 interpolation error (the table build is on the slider path).
    let integrand = |w: f64| 2.0 * w * integrand_in_v(w * w);
    let scaled = integrate_relative_from(integrand, 0.0, v_max.sqrt(), 1e-8, 2);
    let scale = if m == 0.0 {
        1.0
    } else {
        (m * sin_r.ln()).exp()
    };
    scaled * scale
}

/// h(c) = sqrt(1 − c²) − c·acos(c) from 1 − c: with c = cos ψ, h = sin ψ − ψ cos ψ,
/// which is ψ³/3 − ψ⁵/30 + … for small ψ (where the direct form cancels).
fn ring_below_horizon(one_minus_c: f64) -> f64 {
    let psi = 2.0 * (0.5 * one_minus_c).sqrt().asin();
    if psi < 0.1 {
        let p2 = psi * psi;
        psi * p2 * (1.0 / 3.0 - p2 * (1.0 / 30.0 - p2 * (1.0 / 840.0 - p2 / 45360.0)))
    } else {
        psi.sin() - psi * psi.cos()
    }
}

/// The Phong normalisation tabulated over the incidence cosine for one exponent,
/// for the renderer: N(μ) = 2πμ/(m+2) + Δ(μ), with Δ sampled where it matters.
///
/// Δ lives on the scale μ ~ 1/sqrt(m) (it is ≈ e^{−mμ²/2} relative to N), so the
/// table spans μ ∈ [0, μ_max = min(1, 8/sqrt(m+2))] — beyond that Δ/N < 1e-13.
/// Nodes are uniform in v with μ = μ_max·sin²(πv/2): dense at grazing incidence,
/// where Δ varies fastest, and, when the table reaches μ = 1, dense there too, where
/// Δ ∝ (1 − μ)^{3/2}. Catmull–Rom cubics with linearly extrapolated end points.
#[derive(Debug, Clone)]
pub struct NormalisationTable {
    exponent: f64,
    mu_max: f64,
    correction: Vec<f64>,
}

impl NormalisationTable {
    /// Table resolution: 64 intervals keep the interpolation error below 5e-5 of N
    /// (measured worst 4.1e-5 for m from 0 to 1e7; 128 gave 3e-6 at twice the
    /// cost of a gloss edit, and the renderer's own tolerance is 1e-3).
    const INTERVALS: usize = 64;

    /// Builds the table for exponent m ≥ 0 (a gloss edit pays this; its cost is in
    /// docs/benchmarks.md, "Paint model").
    pub fn new(m: f64) -> Self {
        let mu_max = (8.0 / (m + 2.0).sqrt()).min(1.0);
        let correction = (0..=Self::INTERVALS)
            .map(|j| {
                let v = j as f64 / Self::INTERVALS as f64;
                let s = (0.5 * PI * v).sin();
                below_horizon_correction(mu_max * s * s, m)
            })
            .collect();
        Self {
            exponent: m,
            mu_max,
            correction,
        }
    }

    /// The exponent the table was built for.
    pub fn exponent(&self) -> f64 {
        self.exponent
    }

    /// N(μ) interpolated.
    pub fn eval(&self, cos_i: f64) -> f64 {
        let mu = cos_i.clamp(0.0, 1.0);
        let full = 2.0 * PI * mu / (self.exponent + 2.0);
        if mu >= self.mu_max {
            // Beyond the table Δ/N < 1e-13, except when the table ends at μ = 1 itself.
            let last = self.correction[Self::INTERVALS];
            return full + if self.mu_max >= 1.0 { last } else { 0.0 };
        }
        let last = Self::INTERVALS as isize;
        let v = (mu / self.mu_max).sqrt().asin() * (2.0 / PI);
        let x = v * Self::INTERVALS as f64;
        let j = (x as isize).min(last - 1);
        let frac = x - j as f64;
        let at = |k: isize| {
            if k < 0 {
                2.0 * self.correction[0] - self.correction[1]
            } else if k > last {
                2.0 * self.correction[last as usize] - self.correction[last as usize - 1]
            } else {
                self.correction[k as usize]
            }
        };
        let (p0, p1, p2, p3) = (at(j - 1), at(j), at(j + 1), at(j + 2));
        let interpolated = p1
            + 0.5
                * frac
                * (p2 - p0
                    + frac
                        * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3
                            + frac * (3.0 * (p1 - p2) + p3 - p0)));
        full + interpolated.max(0.0)
    }
}

/// Samples a direction from the Phong lobe about `axis` (unit vector) with exponent
/// `m`: cos α = u₀^{1/(m+1)}, density (m+1)/(2π)·cos^m α per solid angle over the
/// cap α < π/2. Returns `None` when the direction falls below the surface; the
/// density [`phong_lobe_pdf`] counts those as part of its mass (a failed sample).
#[inline]
pub fn sample_phong_lobe(axis: [f32; 3], m: f32, u: [f32; 2]) -> Option<[f32; 3]> {
    // 1 − cos α = −expm1(ln u / (m+1)) stays precise for sharp lobes.
    let one_minus_cos = -((u[0].max(f32::MIN_POSITIVE)).ln() / (m + 1.0)).exp_m1();
    let cos_alpha = 1.0 - one_minus_cos;
    let sin_alpha = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
    let beta = 2.0 * std::f32::consts::PI * u[1];
    let (t, b) = orthonormal_basis(axis);
    let (sb, cb) = beta.sin_cos();
    let w = [
        axis[0] * cos_alpha + (t[0] * cb + b[0] * sb) * sin_alpha,
        axis[1] * cos_alpha + (t[1] * cb + b[1] * sb) * sin_alpha,
        axis[2] * cos_alpha + (t[2] * cb + b[2] * sb) * sin_alpha,
    ];
    if w[2] <= 0.0 { None } else { Some(w) }
}

/// Density of [`sample_phong_lobe`] per unit solid angle at `w`.
#[inline]
pub fn phong_lobe_pdf(wi: [f32; 3], wo: [f32; 3], m: f32) -> f32 {
    (m + 1.0) / (2.0 * std::f32::consts::PI) * phong_lobe(wi, wo, m)
}

/// An orthonormal pair perpendicular to the unit vector `n` (Duff et al. 2017).
#[inline]
pub fn orthonormal_basis(n: [f32; 3]) -> ([f32; 3], [f32; 3]) {
    let sign = 1.0_f32.copysign(n[2]);
    let a = -1.0 / (sign + n[2]);
    let b = n[0] * n[1] * a;
    (
        [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]],
        [b, sign + n[1] * n[1] * a, -n[1]],
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quadrature::integrate_relative;

    fn direction(theta_deg: f64, phi_deg: f64) -> [f64; 3] {
        let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
        [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
    }

    /// Brute-force N by a product rule over the hemisphere in the lobe's own frame.
    fn brute_force_normalisation(cos_i: f64, m: f64) -> f64 {
        let wi = [-(1.0 - cos_i * cos_i).sqrt(), 0.0, cos_i];
        let r = mirror(wi);
        let (t, b) = {
            let (t, b) = orthonormal_basis([r[0] as f32, r[1] as f32, r[2] as f32]);
            (t.map(f64::from), b.map(f64::from))
        };
        let alpha_max = std::f64::consts::FRAC_PI_2;
        integrate_relative(
            |alpha: f64| {
                let (sa, ca) = alpha.sin_cos();
                let ring = integrate_relative(
                    |beta: f64| {
                        let (sb, cb) = beta.sin_cos();
                        let z = r[2] * ca + (t[2] * cb + b[2] * sb) * sa;
                        z.max(0.0)
                    },
                    0.0,
                    2.0 * PI,
                    1e-10,
                );
                ca.powf(m) * sa * ring
            },
            0.0,
            alpha_max,
            1e-9,
        )
    }

    #[test]
    fn normalisation_of_the_flat_lobe_is_the_cosine_integral_of_its_cap() {
        // m = 0: D = 1 on the hemisphere about ωr. At normal incidence that is the
        // whole upper hemisphere (∫ μo dω = π); at grazing it is half of it (π/2).
        let normal = phong_normalisation(1.0, 0.0);
        let grazing = phong_normalisation(0.0, 0.0);
        assert!((normal - PI).abs() < 1e-12, "{normal}");
        assert!((grazing - PI / 2.0).abs() < 1e-7, "{grazing}");
    }

    #[test]
    fn normalisation_matches_brute_force() {
        for &m in &[1.0, 10.0, 100.0, 2000.0] {
            for &mu in &[0.02, 0.1, 0.5, 0.9] {
                let got = phong_normalisation(mu, m);
                let want = brute_force_normalisation(mu, m);
                assert!(
                    (got - want).abs() < 1e-5 * want,
                    "m {m} μ {mu}: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn table_interpolates_the_normalisation() {
        for &m in &[0.0, 3.0, 50.0, 1e4, 1e7] {
            let table = NormalisationTable::new(m);
            for k in 0..=200 {
                let mu = k as f64 / 200.0;
                let exact = phong_normalisation(mu, m);
                let got = table.eval(mu);
                assert!(
                    (got - exact).abs() <= 5e-5 * exact,
                    "m {m} μ {mu}: {got} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn phong_lobe_is_reciprocal() {
        let wi = direction(35.0, 10.0);
        let wo = direction(50.0, 200.0);
        let a = phong_lobe(wi, wo, 40.0);
        let b = phong_lobe(wo, wi, 40.0);
        assert!((a - b).abs() < 1e-14 * a.max(1e-300));
        let c = paper_lobe(wi, wo, 40.0);
        let d = paper_lobe(wo, wi, 40.0);
        assert!((c - d).abs() < 1e-12, "{c} vs {d}");
    }

    #[test]
    fn paper_lobe_peaks_at_the_mirror_and_vanishes_far_from_it() {
        let wi = direction(30.0, 180.0);
        assert!((paper_lobe(wi, direction(30.0, 0.0), 100.0) - 1.0).abs() < 1e-12);
        assert_eq!(paper_lobe(wi, direction(80.0, 180.0), 100.0), 0.0);
    }
}
