//! Everything the designer's plots and instruments panel show about a design,
//! derived in one place from the design (and the target design): the paper's
//! reflectance figures, the multi-angle and gloss readings, ΔE00 per angle to the
//! target, and swatches under three illuminants.
//!
//! The GUI never derives physics itself: it asks for an [`Analysis`] of the current
//! design whenever the design changes and draws what it holds. Building one takes
//! a few tens of milliseconds (the best-fit Phong dominates), which is why the app
//! computes it only on change, not every frame.

use std::f64::consts::PI;

use crate::colour::cie::{Colorimeter, Illuminant, Observer};
use crate::colour::spectrum::WavelengthGrid;
use crate::colour::{Lab, ciede2000, srgb_from_xyz};
use crate::design::PaintDesign;
use crate::instruments::{self, Measurement};
use crate::measurement::{Geometry, Standard, interpolate};
use crate::paint::fresnel::reflectance;
use crate::paint::gloss::GlossExponent;
use crate::paint::model::PaintModel;
use crate::paint::phong::{PhongParams, PhongVariant};

/// Angles of incidence of the paper's figures 3–6, degrees.
pub const FIGURE_INCIDENCE_DEG: [f64; 4] = [0.0, 30.0, 60.0, 75.0];
/// Viewing angles of the figures: the plane of incidence, −89° … 89°, 1° apart.
const FIGURE_VIEW_STEP_DEG: f64 = 1.0;
/// The illuminants of the swatches: daylight, tungsten, the TL84-type booth lamp.
pub const SWATCH_ILLUMINANTS: [Illuminant; 3] = [Illuminant::D65, Illuminant::A, Illuminant::F11];
/// The swatches show the colour at this aspecular angle (the "face" reading).
pub const SWATCH_ASPECULAR_DEG: f64 = 45.0;

/// One curve of the figures: (viewing angle in degrees, luminance-weighted BRDF in 1/sr).
pub type Curve = Vec<[f64; 2]>;

/// The reflectance distribution at one angle of incidence (one family of curves of
/// the paper's figures), luminance-weighted (ȳ under D65) over the wavelengths.
#[derive(Debug, Clone)]
pub struct Distribution {
    /// Angle of incidence, degrees (light arrives from the −x side).
    pub incidence_deg: f64,
    /// The paint model's specular lobe R(θi)·S(ωi, ωo); empty for the ideal mirror.
    pub paint_specular: Curve,
    /// The paint model's body term.
    pub paint_body: Curve,
    /// Phong's specular term ks·(m+2)/2π·cos^m.
    pub phong_specular: Curve,
    /// Phong's diffuse term kd/π (flat in the viewing angle).
    pub phong_diffuse: Curve,
    /// For the ideal mirror: the luminance-weighted Fresnel reflectance R(θi).
    pub mirror_reflectance: Option<f64>,
}

/// A colour swatch of the design (and target) under one illuminant.
#[derive(Debug, Clone, Copy)]
pub struct Swatch {
    /// The illuminant.
    pub illuminant: Illuminant,
    /// Display colour of the design, sRGB bytes, adapted to D65 (Bradford).
    pub design_srgb: [u8; 3],
    /// The target's, if there is one.
    pub target_srgb: Option<[u8; 3]>,
    /// ΔE00 between them under this illuminant (10° observer, CIELAB relative to the
    /// illuminant's white), if there is a target.
    pub delta_e: Option<f64>,
}

/// Derived data of one design.
#[derive(Debug, Clone)]
pub struct Analysis {
    /// The paint model on the reference grid.
    pub model: PaintModel,
    /// What the virtual instruments read.
    pub measurement: Measurement,
    /// The target's reading and its name, if a target is set.
    pub target: Option<(String, Measurement)>,
    /// ΔE00 to the target per aspecular angle.
    pub delta_e: Option<Vec<f64>>,
    /// The Phong parameters the figures compare with.
    pub phong: PhongParams,
    /// The figures' curves, one entry per [`FIGURE_INCIDENCE_DEG`].
    pub distributions: Vec<Distribution>,
    /// Swatches under [`SWATCH_ILLUMINANTS`].
    pub swatches: Vec<Swatch>,
    /// ρ, n and k on the reference grid.
    pub spectra: DesignSpectra,
}

/// A design's spectral inputs on one grid, as the spectra plots draw them.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignSpectra {
    pub wavelength_nm: Vec<f64>,
    pub albedo: Vec<f64>,
    pub refractive_index: Vec<f64>,
    pub absorption_per_um: Vec<f64>,
}

impl Analysis {
    /// Analyses `design` (and `target`), comparing with Phong of the given variant.
    /// Fails with the design's own validation message if it is invalid.
    pub fn compute(
        design: &PaintDesign,
        target: Option<&PaintDesign>,
        variant: PhongVariant,
    ) -> Result<Analysis, String> {
        let grid = WavelengthGrid::reference();
        let model = design.model(grid).map_err(|e| e.to_string())?;
        let measurement = instruments::measure(&model).map_err(|e| e.to_string())?;
        let target_model = match target {
            Some(t) => Some((
                t.name.clone(),
                t.model(grid).map_err(|e| format!("target design: {e}"))?,
            )),
            None => None,
        };
        let target_measurement = match &target_model {
            Some((name, m)) => Some((
                name.clone(),
                instruments::measure(m).map_err(|e| format!("target design: {e}"))?,
            )),
            None => None,
        };
        let delta_e = target_measurement
            .as_ref()
            .map(|(_, t)| instruments::delta_e_per_angle(&measurement, t));
        let phong = match variant {
            PhongVariant::Naive => PhongParams::naive(&model),
            PhongVariant::BestFit => PhongParams::best_fit(&model),
        };
        let weights = instruments::glossmeter_weights(&grid);
        let distributions = FIGURE_INCIDENCE_DEG
            .iter()
            .map(|&deg| distribution(&model, &phong, &weights, deg))
            .collect();
        let swatches = swatches(
            &measurement,
            target_measurement
                .as_ref()
                .and_then(|(_, m)| design_swatch_reflectance(m)),
        );
        Ok(Analysis {
            spectra: DesignSpectra {
                wavelength_nm: grid.wavelengths_nm().collect(),
                albedo: model.albedo().to_vec(),
                refractive_index: model.refractive_index().to_vec(),
                absorption_per_um: model.absorption_per_um().to_vec(),
            },
            model,
            measurement,
            target: target_measurement,
            delta_e,
            phong,
            distributions,
            swatches,
        })
    }
}

fn in_plane(signed_deg: f64) -> [f64; 3] {
    let t = signed_deg.to_radians();
    [t.sin(), 0.0, t.cos()]
}

fn weighted(weights: &[f64], values: impl Iterator<Item = f64>) -> f64 {
    weights.iter().zip(values).map(|(w, v)| w * v).sum()
}

fn distribution(
    model: &PaintModel,
    phong: &PhongParams,
    weights: &[f64],
    incidence_deg: f64,
) -> Distribution {
    // Light from the −x side, as the instruments do: the mirror direction is +θi.
    let wi = in_plane(-incidence_deg);
    let index = model.refractive_index();
    let fresnel = weighted(weights, index.iter().map(|&n| reflectance(wi[2], n)));
    let kd_over_pi = weighted(weights, phong.diffuse.iter().map(|kd| kd / PI));
    let mut total = vec![0.0; weights.len()];
    let mut phong_total = vec![0.0; weights.len()];
    let views = view_angles_deg(incidence_deg, model.exponent());
    let mut d = Distribution {
        incidence_deg,
        paint_specular: Vec::with_capacity(views.len()),
        paint_body: Vec::with_capacity(views.len()),
        phong_specular: Vec::with_capacity(views.len()),
        phong_diffuse: Vec::with_capacity(views.len()),
        mirror_reflectance: None,
    };
    let mirror = model.exponent() == GlossExponent::Mirror;
    if mirror {
        d.mirror_reflectance = Some(fresnel);
    }
    for view_deg in views {
        let wo = in_plane(view_deg);
        model.eval_reference(wi, wo, &mut total);
        let lobe = model.lobe_value_reference(wi, wo);
        // The specular part is R(θi, λ)·S; the body is what remains of f.
        let specular = weighted(weights, index.iter().map(|&n| reflectance(wi[2], n) * lobe));
        let body = weighted(weights, total.iter().copied()) - specular;
        phong.eval(wi, wo, &mut phong_total);
        let phong_specular = weighted(weights, phong_total.iter().copied()) - kd_over_pi;
        if !mirror {
            d.paint_specular.push([view_deg, specular]);
        }
        d.paint_body.push([view_deg, body]);
        d.phong_specular.push([view_deg, phong_specular.max(0.0)]);
        d.phong_diffuse.push([view_deg, kd_over_pi]);
    }
    d
}

/// Viewing angles of one figure: every degree, plus 200 more across ±6 lobe widths
/// around the mirror direction, since a high-gloss lobe (m ~ 10⁴) is a fraction of
/// a degree wide and would fall between whole degrees.
fn view_angles_deg(incidence_deg: f64, exponent: GlossExponent) -> Vec<f64> {
    let steps = (178.0 / FIGURE_VIEW_STEP_DEG) as usize;
    let mut views: Vec<f64> = (0..=steps)
        .map(|s| -89.0 + s as f64 * FIGURE_VIEW_STEP_DEG)
        .collect();
    if let GlossExponent::Finite(m) = exponent {
        let width_deg = (1.0 / (m + 1.0).sqrt()).to_degrees();
        let half = (6.0 * width_deg).min(30.0);
        views.extend((0..=200).map(|i| incidence_deg - half + 2.0 * half * f64::from(i) / 200.0));
    }
    views.retain(|v| v.abs() < 89.5);
    views.sort_by(f64::total_cmp);
    views.dedup();
    views
}

fn srgb_bytes(xyz: crate::colour::Xyz, white: crate::colour::Xyz) -> [u8; 3] {
    let c = srgb_from_xyz(xyz, white);
    let byte = |v: f64| (v * 255.0).round().clamp(0.0, 255.0) as u8;
    [byte(c.red), byte(c.green), byte(c.blue)]
}

/// The index of [`SWATCH_ASPECULAR_DEG`] in the instrument's angles.
fn swatch_angle() -> usize {
    instruments::ASPECULAR_DEG
        .iter()
        .position(|&a| a == SWATCH_ASPECULAR_DEG)
        .unwrap_or(0)
}

/// Swatches of a design's readings under [`SWATCH_ILLUMINANTS`], beside a
/// target's reflectance factor at [`SWATCH_ASPECULAR_DEG`] on the reference grid
/// (a target design's reading there, or a measured standard's spectrum
/// interpolated onto the grid), if there is one.
pub fn swatches(design: &Measurement, target: Option<&[f64]>) -> Vec<Swatch> {
    let grid = &WavelengthGrid::reference();
    let angle = swatch_angle();
    SWATCH_ILLUMINANTS
        .iter()
        .map(|&illuminant| {
            // Display: 2° observer, adapted from the illuminant's white to D65 so a
            // white stays white; a pair that matches under D65 and not under A shows
            // metamerism as a visible difference between its two halves.
            let display = Colorimeter::new(illuminant, Observer::Cie1931TwoDegree, grid);
            let colour = Colorimeter::new(illuminant, Observer::Cie1964TenDegree, grid);
            let show = |r: &[f64]| srgb_bytes(display.xyz(r), display.white());
            let lab = |r: &[f64]| -> Lab { colour.lab(r) };
            let own = design.angles[angle].reflectance_factor.as_slice();
            Swatch {
                illuminant,
                design_srgb: show(own),
                target_srgb: target.map(show),
                delta_e: target.map(|t| ciede2000(lab(own), lab(t))),
            }
        })
        .collect()
}

/// A target design's reflectance factor at [`SWATCH_ASPECULAR_DEG`], for [`swatches`].
pub fn design_swatch_reflectance(target: &Measurement) -> Option<&[f64]> {
    target
        .angles
        .iter()
        .find(|a| a.aspecular_deg == SWATCH_ASPECULAR_DEG)
        .map(|a| a.reflectance_factor.as_slice())
}

/// A measured standard's spectrum at [`SWATCH_ASPECULAR_DEG`] (any illumination
/// angle), on `wavelength_nm` and held at its end values beyond its range as the
/// comparison does, for [`swatches`]; `None` when the standard has no spectrum
/// at that geometry (a sphere reading alone, stated colours).
pub fn standard_swatch_reflectance(
    standard: &Standard<'_>,
    wavelength_nm: &[f64],
) -> Option<Vec<f64>> {
    standard
        .readings
        .iter()
        .filter(|r| {
            matches!(r.geometry, Geometry::Directional { aspecular_deg, .. }
                if aspecular_deg == SWATCH_ASPECULAR_DEG)
        })
        .find_map(|r| r.spectrum.as_ref())
        .map(|spectrum| {
            wavelength_nm
                .iter()
                .map(|&nm| interpolate(spectrum.wavelengths_nm(), spectrum.factors(), nm))
                .collect()
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::presets;

    #[test]
    fn the_figures_show_what_the_paper_shows() {
        let design = presets::by_slug("satin-grey")
            .map(|p| p.design)
            .unwrap_or_else(|| presets::all()[0].design.clone());
        let a = Analysis::compute(&design, None, PhongVariant::Naive).expect("valid preset");
        assert_eq!(a.distributions.len(), FIGURE_INCIDENCE_DEG.len());
        // Phong's diffuse term does not depend on the viewing angle; the paint's body does.
        let d = &a.distributions[1];
        let body: Vec<f64> = d.paint_body.iter().map(|p| p[1]).collect();
        let (lo, hi) = body.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
        assert!(hi > 1.2 * lo, "body varies with the view: {lo}..{hi}");
        assert!(d.phong_diffuse.windows(2).all(|w| w[0][1] == w[1][1]));
    }

    #[test]
    fn a_target_gives_delta_e_and_swatch_pairs() {
        let all = presets::all();
        let a = Analysis::compute(&all[0].design, Some(&all[1].design), PhongVariant::Naive)
            .expect("valid presets");
        let de = a.delta_e.expect("target set");
        assert_eq!(de.len(), 5);
        assert!(de.iter().all(|d| *d > 1.0));
        assert_eq!(a.swatches.len(), 3);
        assert!(a.swatches.iter().all(|s| s.target_srgb.is_some()));
        let same = Analysis::compute(&all[0].design, Some(&all[0].design), PhongVariant::Naive)
            .expect("valid");
        assert!(same.swatches.iter().all(|s| s.delta_e == Some(0.0)));
    }
}
