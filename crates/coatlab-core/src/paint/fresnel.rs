//! Fresnel reflection at the air/clear-coat surface (spec section 3).
//!
//! Cosine form only: the paper's sine/tangent form is 0/0 at normal incidence.
//! Generic over the float type so the f64 reference and the f32 renderer share one
//! formula.

use num_traits::Float;

/// cos θ′ inside the coat for an outside cosine μ: sqrt(1 − (1 − μ²)/n²).
///
/// Never below sqrt(1 − 1/n²); exactly μ for n = 1. Inputs outside [0, 1] are
/// clamped so rounding at grazing angles cannot produce a NaN.
#[inline]
pub fn cos_refracted<F: Float>(cos_outside: F, n: F) -> F {
    let mu = clamp_unit(cos_outside);
    let sin2_inside = (F::one() - mu * mu) / (n * n);
    (F::one() - sin2_inside).max(F::zero()).sqrt()
}

/// Unpolarised Fresnel reflectance R(μ) for light arriving from air at outside
/// cosine μ onto a coat of index n ≥ 1.
///
/// n = 1 is no interface at all, so R = 0 even at grazing incidence (where the
/// formula itself would be 0/0).
#[inline]
pub fn reflectance<F: Float>(cos_outside: F, n: F) -> F {
    if n <= F::one() {
        return F::zero();
    }
    let mu = clamp_unit(cos_outside);
    let mu_t = cos_refracted(mu, n);
    let rs = (mu - n * mu_t) / (mu + n * mu_t);
    let rp = (n * mu - mu_t) / (n * mu + mu_t);
    let half = F::from(0.5).unwrap_or_else(F::one);
    (rs * rs + rp * rp) * half
}

/// R(μ) together with the refracted cosine μ′ it needs: callers that also need μ′
/// (the attenuation through the coat) get both from one square root.
#[inline]
pub fn reflectance_and_cos_refracted<F: Float>(cos_outside: F, n: F) -> (F, F) {
    let mu = clamp_unit(cos_outside);
    let mu_t = cos_refracted(mu, n);
    if n <= F::one() {
        return (F::zero(), mu_t);
    }
    let rs = (mu - n * mu_t) / (mu + n * mu_t);
    let rp = (n * mu - mu_t) / (n * mu + mu_t);
    let half = F::from(0.5).unwrap_or_else(F::one);
    ((rs * rs + rp * rp) * half, mu_t)
}

/// T(μ) = 1 − R(μ).
#[inline]
pub fn transmittance<F: Float>(cos_outside: F, n: F) -> F {
    F::one() - reflectance(cos_outside, n)
}

/// Reflectance seen from inside the coat by a ray at internal cosine `cos_inside`:
/// Fresnel is reciprocal, so it is R of the outside angle that refracts to θ′, and 1
/// beyond the critical angle (total internal reflection).
#[inline]
pub fn reflectance_inside<F: Float>(cos_inside: F, n: F) -> F {
    let u = clamp_unit(cos_inside);
    let sin2_outside = n * n * (F::one() - u * u);
    if sin2_outside >= F::one() {
        return F::one();
    }
    reflectance((F::one() - sin2_outside).sqrt(), n)
}

#[inline]
fn clamp_unit<F: Float>(x: F) -> F {
    x.max(F::zero()).min(F::one())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_matches_the_textbook_value() {
        let n = 1.5_f64;
        let want = ((n - 1.0) / (n + 1.0)).powi(2);
        assert!((reflectance(1.0, n) - want).abs() < 1e-15);
    }

    #[test]
    fn grazing_incidence_reflects_everything_and_n_one_nothing() {
        assert_eq!(reflectance(0.0, 1.5_f64), 1.0);
        assert_eq!(reflectance(0.0, 1.0_f64), 0.0);
        assert_eq!(reflectance(0.3, 1.0_f64), 0.0);
        assert!(reflectance(0.7, 1e9_f64) > 0.999_999);
    }

    #[test]
    fn brewster_angle_zeroes_p_polarisation() {
        // At Brewster's angle R = rs²/2; check against the s-only value.
        let n = 1.5_f64;
        let theta_b = n.atan();
        let mu = theta_b.cos();
        let mu_t = cos_refracted(mu, n);
        let rs = (mu - n * mu_t) / (mu + n * mu_t);
        assert!((reflectance(mu, n) - rs * rs / 2.0).abs() < 1e-15);
    }

    #[test]
    fn inside_reflectance_is_total_beyond_the_critical_angle() {
        let n = 1.5_f64;
        let cos_critical = (1.0 - 1.0 / (n * n)).sqrt();
        assert_eq!(reflectance_inside(cos_critical * 0.999, n), 1.0);
        let mu_out = 0.6;
        let mu_in = cos_refracted(mu_out, n);
        assert!((reflectance_inside(mu_in, n) - reflectance(mu_out, n)).abs() < 1e-12);
    }
}
#[cfg(test)]
mod combined_tests {
    use super::*;

    #[test]
    fn combined_form_matches_the_separate_functions() {
        for n in [1.0_f64, 1.0001, 1.5, 4.0] {
            for k in 0..=100 {
                let mu = k as f64 / 100.0;
                let (r, mu_t) = reflectance_and_cos_refracted(mu, n);
                assert_eq!(r, reflectance(mu, n));
                assert_eq!(mu_t, cos_refracted(mu, n));
            }
        }
    }
}
