//! The integrating-sphere instrument, d:8° (CIE 15): diffuse illumination from the
//! sphere's wall, detection at 8° from the normal, with the specular component
//! included (di:8°, SCI) or excluded through a specular port (de:8°, SCE).
//!
//! The reading is the reflectance factor
//!
//! ```text
//! R(λ) = ∫_H f(ωi, ωo) μi dωi,   ωo at 8°,
//! ```
//!
//! the radiance toward the detector under a wall of unit radiance, relative to a
//! perfect diffuser's (whose is 1). It is what a flat panel under a uniform white
//! sky shows a camera at 8°, which is how the renderer's picture and this number
//! are tested against each other (`tests/sphere_instrument.rs`). ωi is the light's
//! direction and ωo the detector's, as in the renderer.
//!
//! - Body: f_body is symmetric in μi and μo (spec 4.1), so its integral over ωi is
//!   the body's directional albedo at μo, which the model has in closed form.
//! - Surface reflection: a mirror coat's delta gives R_F(μo). A finite lobe is
//!   integrated numerically about the mirror direction of ωo: Gauss–Legendre panels
//!   in the angle ψ from that direction, graded on the lobe's angular width, and
//!   equally spaced azimuths about it (the integrand is smooth and periodic there,
//!   where the equally weighted rule converges fastest).
//! - SCE: the specular port is a hole in the wall, a cone of half-angle
//!   [`SPECULAR_PORT_HALF_ANGLE_DEG`] about the mirror direction of ωo. No light
//!   comes from there, so what the cone would have sent — surface reflection and
//!   body alike — is taken away.

use std::f64::consts::PI;

use crate::measurement::SpecularComponent;
use crate::paint::coat::body_brdf;
use crate::paint::fresnel::reflectance;
use crate::paint::gloss::GlossExponent;
use crate::paint::lobe::{LobeKind, NormalisationTable, mirror, paper_lobe, phong_lobe};
use crate::paint::model::PaintModel;
use crate::quadrature::GaussLegendre;

/// The detector's angle from the normal, degrees.
pub const DETECTION_DEG: f64 = 8.0;

/// Half-angle of the specular port of the SCE geometry, degrees. CIE 15 leaves
/// the port's size to the instrument; commercial d:8° spheres exclude a cone of a
/// few degrees about the specular direction, and 5° covers the lobe of every
/// glossy automotive finish (m above a few hundred) while leaving the body's
/// reading nearly whole.
pub const SPECULAR_PORT_HALF_ANGLE_DEG: f64 = 5.0;

/// Equally spaced azimuths about the mirror direction.
const AZIMUTHS: usize = 64;

/// The angle ψ from the mirror direction beyond which every direction is below
/// the horizon (the mirror direction is 8° from the normal), and where the horizon
/// starts to cut the cones of constant ψ.
const PSI_BELOW_HORIZON: f64 = (90.0 + DETECTION_DEG) * PI / 180.0;
const PSI_HORIZON_STARTS: f64 = (90.0 - DETECTION_DEG) * PI / 180.0;

/// The specular lobe S(ωi, ωo) at the detector's ωo, as a function of ωi.
type Lobe = Box<dyn Fn([f64; 3]) -> f64>;

/// The reflectance factor of `model` in the sphere, per wavelength of its channels.
pub(super) fn sphere_reflectance(model: &PaintModel, specular: SpecularComponent) -> Vec<f64> {
    let len = model.channels().len();
    let index = &model.refractive_index()[..len];
    let wo = super::in_plane_direction(DETECTION_DEG);
    let axis = mirror(wo);
    let port = SPECULAR_PORT_HALF_ANGLE_DEG.to_radians();
    let mut r = vec![0.0; len];
    model.body_albedo(wo[2], &mut r);

    // The surface reflection from the whole hemisphere: the lobe S(ωi, ωo) with
    // its normalisation from the model's table (within 5·10⁻⁵ of exact, and
    // computed once, where the exact one is an integral per direction).
    let (width, lobe): (Option<f64>, Lobe) = match (model.exponent(), model.lobe()) {
        (GlossExponent::Mirror, _) => (None, Box::new(|_| 0.0)),
        (GlossExponent::Finite(m), LobeKind::Normalised) => {
            let table = NormalisationTable::new(m);
            (
                Some(1.0 / (m + 1.0).sqrt()),
                Box::new(move |wi| phong_lobe(wi, wo, m) / table.eval(wi[2])),
            )
        }
        // The paper's lobe is about twice as wide as a Phong lobe of the same m.
        (GlossExponent::Finite(m), LobeKind::Paper) => (
            Some(2.0 / (m + 1.0).sqrt()),
            Box::new(move |wi| paper_lobe(wi, wo, m)),
        ),
    };
    let breaks = match width {
        None => vec![0.0, port],
        Some(w) => psi_breakpoints(w, port),
    };
    match width {
        None => {
            for (r, &n) in r.iter_mut().zip(index) {
                *r += reflectance(wo[2], n);
            }
        }
        Some(_) => around(axis, &breaks, |wi, weight| {
            let s = lobe(wi) * wi[2] * weight;
            for (r, &n) in r.iter_mut().zip(index) {
                *r += reflectance(wi[2], n) * s;
            }
        }),
    }

    if specular == SpecularComponent::Excluded {
        // The port's cone, on the same panels and with the same lobe as above, so
        // the lobe's part of it is exactly what was added; the body's light from
        // the cone goes too.
        let inside: Vec<f64> = breaks.iter().copied().filter(|&p| p <= port).collect();
        let (albedo, tau, c) = (model.albedo(), model.optical_depth(), model.coat_integral());
        around(axis, &inside, |wi, weight| {
            let s = lobe(wi);
            for (i, (r, &n)) in r.iter_mut().zip(index).enumerate() {
                let body = body_brdf(albedo[i], n, tau[i], c[i], wi[2], wo[2]);
                *r -= (body + reflectance(wi[2], n) * s) * wi[2] * weight;
            }
        });
        if width.is_none() {
            for (r, &n) in r.iter_mut().zip(index) {
                *r -= reflectance(wo[2], n);
            }
        }
    }
    r
}

/// Panel ends in ψ for a lobe of angular width `width`: fine near the peak,
/// doubling outward, one end at the port's edge, and several panels where the
/// horizon cuts the cones (the integrand has a kink there).
fn psi_breakpoints(width: f64, port: f64) -> Vec<f64> {
    let mut breaks = vec![0.0, port, PSI_HORIZON_STARTS, PSI_BELOW_HORIZON];
    let mut psi = width / 8.0;
    while psi < PSI_HORIZON_STARTS {
        breaks.push(psi);
        psi *= 2.0;
    }
    let kink_panels = 8;
    for k in 1..kink_panels {
        breaks.push(
            PSI_HORIZON_STARTS
                + (PSI_BELOW_HORIZON - PSI_HORIZON_STARTS) * k as f64 / kink_panels as f64,
        );
    }
    breaks.sort_by(f64::total_cmp);
    breaks.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    breaks
}

/// Visits directions about `axis` with their solid-angle weights: ψ (the angle
/// from `axis`) on the panels between consecutive `breaks`, and equally spaced
/// azimuths. Directions below the horizon are skipped (the BRDF is zero there).
fn around(axis: [f64; 3], breaks: &[f64], mut visit: impl FnMut([f64; 3], f64)) {
    // A frame with `axis` as its z: axis lies in the xz-plane.
    let t1 = [axis[2], 0.0, -axis[0]];
    let t2 = [0.0, 1.0, 0.0];
    let rule = GaussLegendre::order10();
    let dphi = 2.0 * PI / AZIMUTHS as f64;
    for panel in breaks.windows(2) {
        rule.for_each_node(panel[0], panel[1], |psi, w_psi| {
            let (sin_psi, cos_psi) = psi.sin_cos();
            for k in 0..AZIMUTHS {
                let (sin_phi, cos_phi) = ((k as f64 + 0.5) * dphi).sin_cos();
                let wi: [f64; 3] = std::array::from_fn(|j| {
                    axis[j] * cos_psi + (t1[j] * cos_phi + t2[j] * sin_phi) * sin_psi
                });
                if wi[2] > 0.0 {
                    visit(wi, w_psi * sin_psi * dphi);
                }
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::instruments::tests::grey;
    use crate::paint::model::GlossSetting;

    #[test]
    fn the_panels_integrate_the_solid_angle_of_the_hemisphere_and_of_the_port() {
        let axis = mirror(super::super::in_plane_direction(DETECTION_DEG));
        let breaks = psi_breakpoints(0.05, 5f64.to_radians());
        let mut hemisphere = 0.0;
        around(axis, &breaks, |wi, w| hemisphere += wi[2] * w);
        // ∫ μ dω over the upper hemisphere is π; the horizon's kink costs a little.
        assert!((hemisphere - PI).abs() < 1e-4, "{hemisphere}");
        let mut cone = 0.0;
        around(axis, &[0.0, 5f64.to_radians()], |_, w| cone += w);
        let exact = 2.0 * PI * (1.0 - 5f64.to_radians().cos());
        assert!(
            (cone - exact).abs() < 1e-12 * exact.max(1.0),
            "{cone} vs {exact}"
        );
    }

    #[test]
    fn a_mirror_coat_adds_its_fresnel_reflectance_and_the_port_takes_it_away() {
        let model = grey(0.4, GlossSetting::Exponent(GlossExponent::Mirror));
        let sci = sphere_reflectance(&model, SpecularComponent::Included);
        let sce = sphere_reflectance(&model, SpecularComponent::Excluded);
        let mu = DETECTION_DEG.to_radians().cos();
        let mut body = vec![0.0; sci.len()];
        model.body_albedo(mu, &mut body);
        for i in 0..sci.len() {
            let rf = reflectance(mu, model.refractive_index()[i]);
            assert!((sci[i] - body[i] - rf).abs() < 1e-12);
            // The port also hides the body's light from its cone: about its solid
            // angle times μ times the body's BRDF, a fraction of a percent.
            let hidden = sci[i] - rf - sce[i];
            assert!(hidden > 0.0 && hidden < 0.01 * body[i], "{hidden}");
        }
    }

    #[test]
    fn a_sharp_lobe_reads_like_the_mirror_and_its_port_hides_it_all() {
        let mirror_model = grey(0.4, GlossSetting::Exponent(GlossExponent::Mirror));
        let sharp = grey(0.4, GlossSetting::Exponent(GlossExponent::Finite(20_000.0)));
        for specular in [SpecularComponent::Included, SpecularComponent::Excluded] {
            let a = sphere_reflectance(&mirror_model, specular);
            let b = sphere_reflectance(&sharp, specular);
            for (a, b) in a.iter().zip(&b) {
                assert!((a - b).abs() < 2e-4, "{specular:?}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn a_broad_lobe_loses_more_than_the_port_can_hide() {
        // m = 20: the lobe is wider than the port, so SCE keeps most of it.
        let model = grey(0.0, GlossSetting::Exponent(GlossExponent::Finite(20.0)));
        let sci = sphere_reflectance(&model, SpecularComponent::Included);
        let sce = sphere_reflectance(&model, SpecularComponent::Excluded);
        assert!(
            sce[10] > 0.5 * sci[10] && sce[10] < sci[10],
            "{sce:?} {sci:?}"
        );
    }
}
