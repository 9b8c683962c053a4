//! The clear coat over the pigment: the coat integral C and the body term (spec 4.1).
//!
//! `C(n, τ)` is the fraction (times π) of the pigment's diffuse light that the coat
//! sends back down to the pigment. It is computed in scaled form, C·e^{2τ}, which
//! stays representable for optical depths where C itself underflows (τ up to 10⁴):
//!
//! - the total-internal-reflection part, 2π∫₀^{u_c} u e^{−2τ/u} du with
//!   u_c = sqrt(1 − 1/n²), has a closed form through the exponential integral E₁;
//! - the Fresnel part, 2π∫_{u_c}^1 R_int(u) u e^{−2τ/u} du, is integrated in the
//!   outside cosine μ (u du = μ dμ / n²), where the integrand is analytic on [0, 1]
//!   (in u it has a square-root singularity at the critical angle).
//!
//! Relative accuracy of both is about 1e-13 (checked against an independent
//! high-precision quadrature in `tests/c_integral.rs`).

use std::f64::consts::PI;

use num_traits::Float;

use super::fresnel::{cos_refracted, reflectance, transmittance};
use crate::quadrature::integrate_relative_from;

/// Relative tolerance of the adaptive quadratures; well inside the 1e-9 requirement.
const QUADRATURE_REL_TOL: f64 = 1e-13;
/// Where the scaled exponential factor e^{−w} falls below e^{−50} ≈ 2e-22 the
/// integrand cannot change the result at double precision, so the domain is cut.
const EXPONENT_CUTOFF: f64 = 50.0;

/// C(n, τ) of spec 4.1: 0 ≤ C < π. Underflows to 0 for τ beyond about 370.
pub fn c_integral(n: f64, tau: f64) -> f64 {
    c_integral_scaled(n, tau) * (-2.0 * tau).exp()
}

/// C(n, τ)·e^{2τ}: the coat integral scaled so it stays representable when C
/// underflows.
pub fn c_integral_scaled(n: f64, tau: f64) -> f64 {
    if n <= 1.0 {
        return 0.0;
    }
    let cos_critical = (1.0 - 1.0 / (n * n)).sqrt();
    let tir = total_internal_reflection_part_scaled(cos_critical, tau);
    let fresnel = outside_cosine_integral_scaled(n, 2.0 * tau, |mu| reflectance(mu, n)) / (n * n);
    2.0 * PI * (tir + fresnel)
}

/// E(n, τ)·e^{τ}, where E = 2π∫₀¹ T(μ) e^{−τ/μ′} μ dμ is the factor by which the
/// pigment's diffuse light, after one pass up through the coat, escapes into air
/// (times n², the radiance factor that f_body divides out).
pub fn escape_integral_scaled(n: f64, tau: f64) -> f64 {
    2.0 * PI * outside_cosine_integral_scaled(n, tau, |mu| transmittance(mu, n))
}

/// ∫₀¹ g(μ) μ e^{−d (1/μ′ − 1)} dμ, with μ′ the refracted cosine and d an optical depth.
fn outside_cosine_integral_scaled(n: f64, depth: f64, g: impl Fn(f64) -> f64) -> f64 {
    let n2 = n * n;
    let integrand = |mu: f64| {
        let mu_t = cos_refracted(mu, n);
        // 1/μ′ − 1 without cancellation near normal incidence.
        let one_minus_mu_t = (1.0 - mu) * (1.0 + mu) / (n2 * (1.0 + mu_t));
        let exponent = if depth == 0.0 {
            0.0
        } else {
            depth * one_minus_mu_t / mu_t
        };
        g(mu) * mu * (-exponent).exp()
    };
    let mut lower = 0.0;
    if depth > 0.0 {
        let mu_t_cut = 1.0 / (1.0 + EXPONENT_CUTOFF / depth);
        let sin2_outside = n2 * (1.0 - mu_t_cut * mu_t_cut);
        if sin2_outside < 1.0 {
            lower = (1.0 - sin2_outside).sqrt();
        }
    }
    // Two initial panels: the adaptive pass splits where the integrand needs it.
    integrate_relative_from(integrand, lower, 1.0, QUADRATURE_REL_TOL, 2)
}

/// e^{2τ}∫₀^{a} u e^{−2τ/u} du for the critical cosine a, in closed form:
/// (a²/2)·e^{2τ−x}·[1 − x + x² eˣE₁(x)] with x = 2τ/a.
fn total_internal_reflection_part_scaled(cos_critical: f64, tau: f64) -> f64 {
    let a = cos_critical;
    if a <= 0.0 {
        return 0.0;
    }
    if tau == 0.0 {
        return 0.5 * a * a;
    }
    let x = 2.0 * tau / a;
    0.5 * a * a * (2.0 * tau - x).exp() * tir_bracket(x)
}

/// 1 − x + x² eˣ E₁(x) for x > 0, which tends to 1 at 0 and to 2/x at infinity.
/// The three terms cancel for large x, so each range has its own evaluation.
fn tir_bracket(x: f64) -> f64 {
    if x <= 1.0 {
        // Power series of E₁; x² kills the logarithm at 0.
        let euler_gamma = 0.577_215_664_901_532_9;
        let mut sum = 0.0;
        let mut term = 1.0;
        for k in 1..60 {
            term *= -x / k as f64;
            let contribution = term / k as f64;
            sum += contribution;
            if contribution.abs() < 1e-18 * sum.abs().max(1e-300) {
                break;
            }
        }
        let e1 = -euler_gamma - x.ln() - sum;
        1.0 - x + x * x * x.exp() * e1
    } else if x < 60.0 {
        // Continued fraction for eˣE₁(x) (modified Lentz), converging for x > 1;
        // the cancellation costs at most log10(x²/2) ≈ 3.3 digits here.
        let tiny = 1e-300;
        let mut b = x + 1.0;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -((i * i) as f64);
            b += 2.0;
            d = 1.0 / (an * d + b);
            c = b + an / c;
            let delta = c * d;
            h *= delta;
            if (delta - 1.0).abs() < 1e-17 {
                break;
            }
        }
        1.0 - x + x * x * h
    } else {
        // Asymptotic series Σ (−1)^{k+1} (k+1)!/x^k, summed until its terms stop shrinking.
        let mut sum = 0.0;
        let mut term = 1.0;
        for k in 1..200 {
            let next = term * (k + 1) as f64 / x;
            if k > 1 && next > term {
                break;
            }
            term = next;
            let signed = if k % 2 == 1 { term } else { -term };
            sum += signed;
            if term < 1e-18 * sum.abs() {
                break;
            }
        }
        sum
    }
}

/// One-way attenuation exp(−τ/μ′) through the coat; exactly 1 for τ = 0 even at
/// μ′ = 0 (n = 1 at grazing), where τ/μ′ would be 0/0.
#[inline]
pub fn attenuation<F: Float>(tau: F, cos_inside: F) -> F {
    if tau == F::zero() {
        F::one()
    } else {
        (-tau / cos_inside).exp()
    }
}

/// f_body of spec 4.1 in 1/sr (without the cosine factor); `c` is C(n, τ).
///
/// ρ·T(μi)·T(μo)·exp(−τ(1/μi′ + 1/μo′)) / (n²(π − ρC)). Symmetric in μi, μo
/// (reciprocal) by construction.
#[inline]
pub fn body_brdf<F: Float>(rho: F, n: F, tau: F, c: F, cos_i: F, cos_o: F) -> F {
    let pi = F::from(PI).unwrap_or_else(F::one);
    let through_i = transmittance(cos_i, n) * attenuation(tau, cos_refracted(cos_i, n));
    let through_o = transmittance(cos_o, n) * attenuation(tau, cos_refracted(cos_o, n));
    let numerator = rho * through_i * through_o;
    if numerator == F::zero() {
        // Also where π − ρC rounds to 0 (huge n in single precision): no light in.
        return F::zero();
    }
    numerator / (n * n * (pi - rho * c))
}

/// How the renderer's tables obtain C(n, τ): the exact integral, or one of the
/// shortcuts other renderers take. A speed/accuracy knob measured by
/// `cargo xtask bench tradeoff` (docs/tradeoff.md); the tables are rebuilt only when a
/// design changes, so the shortcuts save no render time, only table time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CoatIntegralMethod {
    /// [`c_integral`]: closed-form TIR part plus adaptive quadrature, ~1e-13 relative.
    #[default]
    Exact,
    /// A fixed `order`-point Gauss–Legendre rule over the inside cosine u ∈ [0, 1]
    /// of 2π∫ R_int(u) u e^{−2τ/u} du, blind to the kink at the critical angle.
    GaussLegendre {
        /// Number of nodes (≥ 1).
        order: usize,
    },
    /// C = π·F_dr(1/n) with the Egan–Hilgeman (1973) polynomial fit of the
    /// internal diffuse Fresnel reflectance (Mitsuba's `fresnel_diffuse_reflectance`
    /// for η < 1); the coat's absorption is ignored inside C, as Mitsuba's
    /// `plastic` ignores it.
    FittedFdr,
}

impl CoatIntegralMethod {
    /// A short label for tables and the UI.
    pub fn label(self) -> String {
        match self {
            CoatIntegralMethod::Exact => "exact C".to_owned(),
            CoatIntegralMethod::GaussLegendre { order } => format!("C by {order}-point GL"),
            CoatIntegralMethod::FittedFdr => "C = π·F_dr fit".to_owned(),
        }
    }
}

/// C(n, τ) by `method` (see [`CoatIntegralMethod`]).
pub fn c_integral_with(method: CoatIntegralMethod, n: f64, tau: f64) -> f64 {
    match method {
        CoatIntegralMethod::Exact => c_integral(n, tau),
        CoatIntegralMethod::GaussLegendre { order } => c_integral_gauss_legendre(order, n, tau),
        CoatIntegralMethod::FittedFdr => PI * fitted_diffuse_reflectance(1.0 / n),
    }
}

/// 2π∫₀¹ R_int(u) u e^{−2τ/u} du by a plain `order`-point Gauss–Legendre rule in the
/// inside cosine u; R_int is 1 below the critical cosine (total internal
/// reflection) and the Fresnel reflectance of the matching outside angle above it.
pub fn c_integral_gauss_legendre(order: usize, n: f64, tau: f64) -> f64 {
    if n <= 1.0 {
        return 0.0;
    }
    let rule = crate::quadrature::GaussLegendre::new(order);
    let integrand = |u: f64| {
        let sin2_outside = n * n * (1.0 - u * u);
        let r = if sin2_outside >= 1.0 {
            1.0
        } else {
            reflectance((1.0 - sin2_outside).sqrt(), n)
        };
        r * u * attenuation(2.0 * tau, u)
    };
    2.0 * PI * rule.integrate(0.0, 1.0, integrand)
}

/// Hemispherical (cosine-weighted) Fresnel reflectance F_dr for relative index η,
/// fitted: Egan & Hilgeman (1973) for η < 1, d'Eon & Irving (2011) for η ≥ 1 — the
/// polynomials Mitsuba 3 and pbrt use. Quoted accuracy ≲ 0.6 % for 1/η up to 2.
pub fn fitted_diffuse_reflectance(eta: f64) -> f64 {
    if eta < 1.0 {
        -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta
    } else {
        let i = 1.0 / eta;
        0.919317 - 3.4793 * i + 6.75335 * i.powi(2) - 7.80989 * i.powi(3) + 4.98554 * i.powi(4)
            - 1.36881 * i.powi(5)
    }
}

/// The coat integrals of one (n, τ): what f_body and its albedo need besides the
/// angles and ρ. Worth keeping when many evaluations share n and τ (each costs a
/// few microseconds).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoatIntegrals {
    /// C(n, τ).
    pub c: f64,
    /// E(n, τ) = 2π∫₀¹ T(μ) e^{−τ/μ′} μ dμ, the escape factor of the pigment's light.
    pub escape: f64,
}

impl CoatIntegrals {
    /// Computes C and E for a coat.
    pub fn new(n: f64, tau: f64) -> Self {
        Self {
            c: c_integral(n, tau),
            escape: escape_integral_scaled(n, tau) * (-tau).exp(),
        }
    }

    /// Directional albedo of the body term at incidence cosine μi for these integrals.
    pub fn body_albedo(&self, rho: f64, n: f64, tau: f64, cos_i: f64) -> f64 {
        let through_i = transmittance(cos_i, n) * attenuation(tau, cos_refracted(cos_i, n));
        let numerator = rho * through_i * self.escape;
        if numerator == 0.0 {
            // Also where π − ρC would round to 0 (huge n): no light enters.
            return 0.0;
        }
        numerator / (n * n * (PI - rho * self.c))
    }
}

/// Directional albedo of the body term at incidence cosine μi: ∫ f_body cos θo dωo.
pub fn body_albedo(rho: f64, n: f64, tau: f64, cos_i: f64) -> f64 {
    CoatIntegrals::new(n, tau).body_albedo(rho, n, tau, cos_i)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn c_at_zero_depth_for_index_one_is_zero_and_grows_with_n() {
        assert_eq!(c_integral(1.0, 0.0), 0.0);
        let mut previous = 0.0;
        for n in [1.01, 1.2, 1.5, 2.0, 3.0, 4.0] {
            let c = c_integral(n, 0.0);
            assert!(c > previous && c < PI, "C({n}, 0) = {c}");
            previous = c;
        }
    }

    #[test]
    fn shortcut_c_methods_have_their_stated_accuracy() {
        // F_dr fit: within 1 % of the exact C at τ = 0 over paint indices; and it
        // ignores absorption, so at τ = 0.5 it is far off (the knob's bias).
        for n in [1.3, 1.45, 1.5, 1.6, 1.8, 2.0] {
            let exact = c_integral(n, 0.0);
            let fit = c_integral_with(CoatIntegralMethod::FittedFdr, n, 0.0);
            assert!(
                (fit / exact - 1.0).abs() < 0.01,
                "n {n}: fit {fit} exact {exact}"
            );
        }
        let fit = c_integral_with(CoatIntegralMethod::FittedFdr, 1.5, 0.5);
        assert!(fit > 2.0 * c_integral(1.5, 0.5));
        // Gauss–Legendre: converges to the exact C as the order grows, but slowly —
        // R_int has a square-root kink at the critical angle that no fixed rule
        // resolves (order 64 is still about 1 % off at n = 1.5).
        for (n, tau) in [(1.5, 0.0), (1.5, 0.05), (1.3, 0.2)] {
            let exact = c_integral(n, tau);
            let error = |order| {
                (c_integral_with(CoatIntegralMethod::GaussLegendre { order }, n, tau) / exact - 1.0)
                    .abs()
            };
            let (e2, e8, e64) = (error(2), error(8), error(64));
            assert!(e64 < 0.02, "n {n} τ {tau}: order 64 off by {e64}");
            assert!(e64 < e8 && e8 < e2, "n {n} τ {tau}: {e2} {e8} {e64}");
            assert!(
                e2 > 0.02,
                "n {n} τ {tau}: order 2 is a visible shortcut ({e2})"
            );
        }
        assert_eq!(
            c_integral_with(CoatIntegralMethod::Exact, 1.5, 0.1),
            c_integral(1.5, 0.1)
        );
    }

    #[test]
    fn tir_bracket_is_continuous_across_its_three_ranges() {
        for x in [1.0_f64, 60.0] {
            let below = tir_bracket(x * (1.0 - 1e-12));
            let above = tir_bracket(x * (1.0 + 1e-12));
            assert!(
                (below - above).abs() < 1e-11 * below,
                "x = {x}: {below} vs {above}"
            );
        }
        // Large-x limit 2/x.
        let x = 1e6;
        assert!((tir_bracket(x) * x / 2.0 - 1.0).abs() < 1e-5);
    }

    #[test]
    fn white_furnace_body_albedo_is_the_transmitted_fraction() {
        // ρ = 1, τ = 0: everything that enters the coat comes back out.
        for n in [1.0, 1.3, 1.5, 2.5, 4.0] {
            for mu in [0.05, 0.5, 1.0] {
                let albedo = body_albedo(1.0, n, 0.0, mu);
                let want = transmittance(mu, n);
                assert!(
                    (albedo - want).abs() < 1e-11,
                    "n {n} μ {mu}: {albedo} vs {want}"
                );
            }
        }
    }
}
