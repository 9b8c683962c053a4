//! The lighting set-ups: photo studio, light booth, sun and sky, the white
//! furnace, and a user's image map. Each fills a [`Builder`] with its background
//! and emitters; the builder normalises them. The physics and the choices behind
//! every number are in `docs/lighting.md`.

use std::f64::consts::PI;
use std::path::Path;

use super::builder::Builder;
use super::direction::{
    azimuth_of_column, direction_from_azimuth_elevation, direction_from_azimuth_y,
};
use super::emitters::Shape;
use super::{Environment, EnvironmentError, EnvironmentKind};
use crate::colour::cie::{Illuminant, daylight_spd};
use crate::colour::spectrum::{Channels, WavelengthGrid};
use crate::colour::upsampling::RgbUpsampler;
use crate::io::exr_read::read_exr;
use crate::io::hdr::read_hdr;
use crate::io::rgb_image::RgbImage;

/// Correlated colour temperature of the studio softboxes (photographic flash).
pub const STUDIO_CCT_K: f64 = 5500.0;
/// Correlated colour temperature of the direct sun.
pub const SUN_CCT_K: f64 = 5500.0;
/// Correlated colour temperature of the clear blue sky.
pub const SKY_CCT_K: f64 = 10000.0;
/// Angular radius of the sun's disc (degrees).
pub const SUN_HALF_ANGLE_DEG: f64 = 0.265;
/// Elevation of the sun above the horizon (degrees).
pub const SUN_ELEVATION_DEG: f64 = 45.0;
/// Azimuth of the sun, from +Z toward +X (degrees): front-left of the car.
pub const SUN_AZIMUTH_DEG: f64 = 30.0;
/// Fraction of the horizontal illuminance that comes from the sky (clear day, sun
/// at 45°: about 15 klx diffuse against 65 klx direct).
pub const SKY_ILLUMINANCE_FRACTION: f64 = 0.2;
/// Half-angle of the booth's overhead diffuser (degrees).
pub const BOOTH_DIFFUSER_HALF_ANGLE_DEG: f64 = 40.0;
/// Reflectance of the booth's mid-grey walls (Munsell N5 is about 0.2).
pub const BOOTH_WALL_REFLECTANCE: f64 = 0.2;
/// Fraction of the diffuser's radiance a wall receives and re-emits per unit
/// reflectance (its view factor toward the ceiling).
pub const BOOTH_WALL_VIEW_FACTOR: f64 = 0.5;
/// Floor reflectances (flat grey).
pub const STUDIO_FLOOR_REFLECTANCE: f32 = 0.25;
/// Booth floor: the same grey as the walls.
pub const BOOTH_FLOOR_REFLECTANCE: f32 = 0.2;
/// Outdoor ground: concrete and asphalt.
pub const OUTDOOR_FLOOR_REFLECTANCE: f32 = 0.15;
/// Floor under an image map: neutral grey, for the contact shadow.
pub const IMAGE_FLOOR_REFLECTANCE: f32 = 0.25;
/// Image maps wider than this are box-filtered down by an integer factor first.
pub const IMAGE_MAX_WIDTH: usize = 2048;

impl Environment {
    /// The default photo studio: three large softboxes (key overhead-front, fill at
    /// the side, rim behind) of CIE daylight 5500 K on a grey cyclorama, grey floor
    /// ρ = 0.25.
    pub fn studio(channels: &(impl Into<Channels> + Copy)) -> Self {
        let channels: Channels = (*channels).into();
        let spectrum = daylight_on_grid(STUDIO_CCT_K, &channels);
        let (width, height) = (1, 64);
        let mut b = Builder::new(&channels, vec![spectrum], width, height);
        // Cyclorama lit by the softboxes: brighter at the sweep, darker overhead.
        for row in 0..height / 2 {
            let y = 0.5 * (b.row_cos[row] + b.row_cos[row + 1]);
            b.coeffs[row] = (0.06 - 0.04 * y) as f32;
        }
        let deg = f64::to_radians;
        let rect = |az0: f64, az1: f64, el0: f64, el1: f64| Shape::LatLong {
            azimuth: [deg(az0), deg(az1)],
            y: [deg(el0).sin(), deg(el1).sin()],
        };
        b.patches.push((rect(-60.0, 60.0, 50.0, 80.0), 0, 1.0));
        b.patches.push((rect(75.0, 115.0, 5.0, 35.0), 0, 0.4));
        b.patches.push((rect(-165.0, -125.0, 10.0, 40.0), 0, 0.7));
        b.finish(EnvironmentKind::Studio, STUDIO_FLOOR_REFLECTANCE, true)
            .expect("the studio has light")
    }

    /// A paint light booth: an overhead diffuser emitting `illuminant`, mid-grey
    /// walls (ρ = 0.2) lit by it as a dim uniform background, grey floor ρ = 0.2.
    pub fn booth(illuminant: Illuminant, channels: &(impl Into<Channels> + Copy)) -> Self {
        let channels: Channels = (*channels).into();
        let spectrum: Vec<f32> = match &channels {
            Channels::LinearSrgb => {
                rgb_light(illuminant.spd(&WavelengthGrid::reference()).values())
            }
            Channels::Spectral(grid) => illuminant
                .spd(grid)
                .values()
                .iter()
                .map(|&v| (v / 100.0) as f32)
                .collect(),
        };
        let (width, height) = (1, 64);
        let mut b = Builder::new(&channels, vec![spectrum], width, height);
        for row in 0..height / 2 {
            b.coeffs[row] = (BOOTH_WALL_REFLECTANCE * BOOTH_WALL_VIEW_FACTOR) as f32;
        }
        let cap = Shape::LatLong {
            azimuth: [-PI, PI],
            y: [BOOTH_DIFFUSER_HALF_ANGLE_DEG.to_radians().cos(), 1.0],
        };
        b.patches.push((cap, 0, 1.0));
        b.finish(
            EnvironmentKind::Booth(illuminant),
            BOOTH_FLOOR_REFLECTANCE,
            true,
        )
        .expect("the booth has light")
    }

    /// Sun and clear sky: the sun a 0.53° disc at 45° elevation (CIE daylight
    /// 5500 K), the sky the CIE clear-sky luminance distribution in CIE daylight
    /// 10000 K, the sky giving 20 % of the horizontal illuminance; ground ρ = 0.15.
    pub fn outdoor(channels: &(impl Into<Channels> + Copy)) -> Self {
        let channels: Channels = (*channels).into();
        let sky = daylight_on_grid(SKY_CCT_K, &channels);
        let sun = daylight_on_grid(SUN_CCT_K, &channels);
        let (width, height) = (256, 128);
        let sun_axis = direction_from_azimuth_elevation(
            SUN_AZIMUTH_DEG.to_radians(),
            SUN_ELEVATION_DEG.to_radians(),
        );
        let mut b = Builder::new(&channels, vec![sky, sun], width, height);
        let zenith_sun = (90.0 - SUN_ELEVATION_DEG).to_radians();
        for row in 0..height / 2 {
            let y = 0.5 * (b.row_cos[row] + b.row_cos[row + 1]);
            for col in 0..width {
                let azimuth = azimuth_of_column(col as f64 + 0.5, width);
                let dir = direction_from_azimuth_y(azimuth, y);
                let cos_gamma = dir.dot(sun_axis).clamp(-1.0, 1.0);
                b.coeffs[(row * width + col) * 2] =
                    cie_clear_sky(y.acos(), cos_gamma.acos(), zenith_sun) as f32;
            }
        }
        // The sun's radiance, for its share of the horizontal illuminance.
        let sky_illuminance = b.channel_irradiance()[0] * b.channel_luminance[0];
        let sun_shape = Shape::cap(sun_axis, SUN_HALF_ANGLE_DEG.to_radians());
        let sun_illuminance_per_unit = sun_shape.cosine_integral() * b.channel_luminance[1];
        let sun_coefficient = sky_illuminance * (1.0 - SKY_ILLUMINANCE_FRACTION)
            / SKY_ILLUMINANCE_FRACTION
            / sun_illuminance_per_unit;
        b.patches.push((sun_shape, 1, sun_coefficient));
        let mut env = b
            .finish(EnvironmentKind::Outdoor, OUTDOOR_FLOOR_REFLECTANCE, true)
            .expect("the sky has light");
        env.sun_dir = Some(sun_axis.as_vec3().to_array());
        env
    }

    /// The white furnace: a flat spectrum of radiance 1 arriving from every
    /// direction, and no floor. An object that neither absorbs nor emits is
    /// invisible in it; anything else shows its directional albedo. For tests and
    /// for checking a design's energy balance.
    pub fn uniform(channels: &(impl Into<Channels> + Copy)) -> Self {
        let channels: Channels = (*channels).into();
        let flat = vec![1.0f32; channels.len()];
        let (width, height) = (1, 2);
        let mut b = Builder::new(&channels, vec![flat], width, height);
        b.coeffs.fill(1.0);
        let env = b
            .finish(EnvironmentKind::Uniform, 0.0, false)
            .expect("a uniform sky has light");
        env.with_floor(None)
    }

    /// An equirectangular environment map from a file: Radiance `.hdr` (RGBE, flat
    /// or run-length encoded scanlines) or OpenEXR `.exr` (the first layer with R,
    /// G and B channels, any compression the `exr` crate reads; alpha ignored).
    /// Linear sRGB (Rec. 709) primaries are assumed; see
    /// [`Environment::from_rgb_image`].
    pub fn from_image(
        path: &Path,
        channels: &(impl Into<Channels> + Copy),
    ) -> Result<Self, EnvironmentError> {
        let channels: Channels = (*channels).into();
        let name = path.display().to_string();
        let extension = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let image = match extension.as_deref() {
            Some("hdr") | Some("pic") | Some("rgbe") => read_hdr(path)?,
            Some("exr") => read_exr(path)?,
            _ => return Err(EnvironmentError::UnknownFormat { path: name }),
        };
        Self::from_rgb_image(&image, &name, &channels)
    }

    /// An environment from an equirectangular linear-sRGB image (top row at the
    /// zenith, centre column toward +Z). Each texel's RGB (negatives clamped to 0)
    /// becomes a spectrum by [`RgbUpsampler::emission`]; radiance is constant over
    /// a texel, which is sampled in proportion to luminance × solid angle. Maps wider
    /// than [`IMAGE_MAX_WIDTH`] are box-filtered down. `name` is used in errors.
    pub fn from_rgb_image(
        image: &RgbImage,
        name: &str,
        channels: &(impl Into<Channels> + Copy),
    ) -> Result<Self, EnvironmentError> {
        let radiance_channels: Channels = (*channels).into();
        let factor = image.width().div_ceil(IMAGE_MAX_WIDTH).max(1);
        let image = if factor > 1 {
            image.box_downsample(factor)
        } else {
            image.clone()
        };
        let upsampler = RgbUpsampler::new(&radiance_channels);
        let channels = upsampler.emission_bases().to_vec();
        let mut b = Builder::new(&radiance_channels, channels, image.width(), image.height());
        for (coeffs, rgb) in b.coeffs.chunks_exact_mut(3).zip(image.pixels()) {
            for (c, v) in coeffs.iter_mut().zip(rgb) {
                *c = v.max(0.0);
            }
        }
        b.finish(EnvironmentKind::Image, IMAGE_FLOOR_REFLECTANCE, false)
            .ok_or_else(|| EnvironmentError::NoLight {
                name: name.to_owned(),
            })
    }
}

/// The CIE (1973) clear-sky relative luminance of a sky element at zenith angle
/// `zenith` and angle `gamma` from the sun, the sun at zenith angle `zenith_sun`:
/// (0.91 + 10e^(−3γ) + 0.45cos²γ)(1 − e^(−0.32/cos Z)), relative to the zenith's.
fn cie_clear_sky(zenith: f64, gamma: f64, zenith_sun: f64) -> f64 {
    let indicatrix = |g: f64| 0.91 + 10.0 * (-3.0 * g).exp() + 0.45 * g.cos().powi(2);
    let gradation = |z: f64| 1.0 - (-0.32 / z.cos().max(1e-6)).exp();
    indicatrix(gamma) * gradation(zenith) / (indicatrix(zenith_sun) * gradation(0.0))
}

fn daylight_on_grid(cct_k: f64, channels: &Channels) -> Vec<f32> {
    let spd = daylight_spd(cct_k).expect("the CCT constants are in the CIE daylight range");
    let grid = match channels {
        Channels::Spectral(grid) => grid,
        Channels::LinearSrgb => {
            return rgb_light(spd.to_grid(&WavelengthGrid::reference()).values());
        }
    };
    spd.to_grid(grid)
        .values()
        .iter()
        .map(|&v| (v / 100.0) as f32)
        .collect()
}

/// A light's relative spectrum on the reference grid (100 at 560 nm) as the linear
/// sRGB triple of the RGB shortcut, scaled like the spectra (1 at 560 nm).
fn rgb_light(reference_values: &[f64]) -> Vec<f32> {
    crate::colour::linear_srgb_of_emission(reference_values)
        .iter()
        .map(|&v| (v / 100.0) as f32)
        .collect()
}
