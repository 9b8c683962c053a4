//! The RGB shortcut of the speed/accuracy sweep: the same paint model rendered on
//! three linear-sRGB channels instead of wavelengths — what a user of an RGB
//! renderer does — so its error against the spectral reference can be measured
//! (`cargo xtask bench tradeoff`).
//!
//! The channels travel through the tracer as [`Channels::LinearSrgb`]: the paint
//! formulas run per channel exactly as per wavelength; the film turns a channel
//! triple into XYZ by the sRGB→XYZ matrix (white (1, 1, 1) → Y = 1); the lighting's
//! spectra are reduced to their linear sRGB colour
//! ([`coatlab_core::colour::linear_srgb_of_emission`]: same XYZ as the spectrum on the
//! film), its luminance weights are the sRGB luminance row, and scene materials keep
//! their glTF base colour as is.
//!
//! The design's spectra are reduced the way an RGB user would pick values:
//! - ρ: its colour under D65, as linear sRGB
//!   ([`coatlab_core::colour::linear_srgb_of_reflectance`]; a constant ρ stays ρ in all
//!   three);
//! - n and k: the same D65-weighted per-channel average (the sRGB "colour-matching
//!   functions" r̄, ḡ, b̄ times D65, normalised so a constant stays constant),
//!   clamped to n ≥ 1 and k ≥ 0 (the r̄ lobe is negative around 440–540 nm).

use coatlab_core::colour::linear_srgb_of_reflectance;
use coatlab_core::colour::spectrum::{Channels, WavelengthGrid};
use coatlab_core::design::{DesignError, PaintDesign};
use coatlab_core::paint::model::{PaintModel, PaintParams};

/// The design's paint model on [`Channels::LinearSrgb`] (see the module
/// documentation for the reduction).
pub fn paint_model(design: &PaintDesign) -> Result<PaintModel, DesignError> {
    let spectral = design.model(WavelengthGrid::reference())?;
    let reduce = |v: &[f64], min: f64, max: f64| -> Vec<f64> {
        linear_srgb_of_reflectance(v)
            .iter()
            .map(|c| c.clamp(min, max))
            .collect()
    };
    let params = PaintParams {
        channels: Channels::LinearSrgb,
        albedo: reduce(spectral.albedo(), 0.0, 1.0),
        refractive_index: reduce(spectral.refractive_index(), 1.0, f64::INFINITY),
        index_at_gloss_wavelength: spectral.index_at_gloss_wavelength(),
        absorption_per_um: reduce(spectral.absorption_per_um(), 0.0, f64::INFINITY),
        thickness_um: spectral.thickness_um(),
        gloss: spectral.gloss(),
        lobe: spectral.lobe(),
    };
    PaintModel::new(params).map_err(|error| DesignError::Invalid {
        field: "design".to_string(),
        message: format!("{} reduced to RGB: {error}", design.name),
    })
}

#[cfg(test)]
mod tests {
    use palette::LinSrgb;

    use super::*;
    use coatlab_core::colour::upsampling::RgbUpsampler;
    use coatlab_core::colour::{SRGB_LUMINANCE, linear_srgb_of_emission, srgb_white};
    use coatlab_core::render::environment::{Environment, luminance_weights};
    use coatlab_core::render::film::Film;

    #[test]
    fn constant_reflectances_stay_constant_and_the_white_is_white() {
        for c in [0.0, 0.3, 1.0, 1.5] {
            let rgb = linear_srgb_of_reflectance(&vec![c; 81]);
            for v in rgb {
                assert!((v - c).abs() < 1e-3, "{c}: {rgb:?}");
            }
        }
        // The film maps (1, 1, 1) to the sRGB white at Y = 1.
        let film = Film::new(1, 1, Channels::LinearSrgb);
        let xyz = film.xyz_of(&[1.0, 1.0, 1.0]);
        let white = srgb_white();
        assert!((xyz.y - 1.0).abs() < 1e-6, "{xyz:?}");
        assert!((xyz.x - white.x / white.y).abs() < 1e-5, "{xyz:?}");
    }

    #[test]
    fn a_reduced_emission_has_the_spectrum_s_xyz_on_the_film() {
        let spectrum: Vec<f64> = (0..81).map(|i| 0.2 + 0.01 * i as f64).collect();
        let spectral = Film::new(1, 1, WavelengthGrid::reference())
            .xyz_of(&spectrum.iter().map(|&v| v as f32).collect::<Vec<_>>());
        let rgb = linear_srgb_of_emission(&spectrum).map(|v| v as f32);
        let reduced = Film::new(1, 1, Channels::LinearSrgb).xyz_of(&rgb);
        for (a, b) in [
            (spectral.x, reduced.x),
            (spectral.y, reduced.y),
            (spectral.z, reduced.z),
        ] {
            assert!(
                (a - b).abs() < 1e-4 * a.abs().max(1.0),
                "{spectral:?} vs {reduced:?}"
            );
        }
    }

    #[test]
    fn lighting_and_materials_on_the_rgb_grid_use_rgb_values() {
        let rgb = Channels::LinearSrgb;
        assert_eq!(luminance_weights(&rgb), SRGB_LUMINANCE.to_vec());
        let up = RgbUpsampler::new(&rgb);
        let mut out = [0.0f32; 3];
        up.reflectance(LinSrgb::new(0.2, 0.5, 0.7), &mut out);
        assert_eq!(out, [0.2, 0.5, 0.7]);
        // The studio's light on three channels has the luminance of the spectral one.
        let studio = Environment::studio(&rgb);
        let spectral = Environment::studio(&WavelengthGrid::reference());
        let (mut a, mut b) = (vec![0.0f32; 3], vec![0.0f32; 81]);
        let up = [0.0, 1.0, 0.0];
        studio.radiance(up, &mut a);
        spectral.radiance(up, &mut b);
        let (la, lb) = (studio.luminance(&a), spectral.luminance(&b));
        assert!((la / lb - 1.0).abs() < 0.01, "{la} vs {lb}");
    }

    #[test]
    fn the_default_design_reduces_to_a_red_paint_on_three_channels() {
        let design = coatlab_core::design::presets::all().remove(0).design;
        let model = paint_model(&design).unwrap();
        assert_eq!(model.channels(), &Channels::LinearSrgb);
        let rho = model.albedo();
        assert!(rho[0] > 2.0 * rho[1] && rho[0] > 2.0 * rho[2], "{rho:?}");
        assert!(model.refractive_index().iter().all(|&n| n > 1.4 && n < 1.7));
    }
}
