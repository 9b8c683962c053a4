//! What lights the scene: a distant environment of spectral radiance over the sphere
//! of directions, with importance sampling, plus the floor plane y = 0 of the
//! lighting setup. The physics and the choices behind every number are in
//! `docs/lighting.md`.
//!
//! | Setup | Emitters (sampled by power) | Background map | Floor ρ |
//! |---|---|---|---|
//! | [`Environment::studio`] (default) | key (overhead-front), fill, rim softboxes, CIE daylight 5500 K | grey cyclorama, brighter toward the horizon | 0.25 |
//! | [`Environment::booth`] | overhead diffuser, 40° half-angle, the chosen illuminant | grey walls (ρ 0.2, view factor 0.5) | 0.20 |
//! | [`Environment::outdoor`] | sun: 0.53° disc at 45° elevation, CIE daylight 5500 K | CIE clear sky, CIE daylight 10000 K | 0.15 |
//! | [`Environment::from_image`] | — | the user's equirectangular map, RGB upsampled | 0.25 |
//!
//! Conventions: `radiance(dir)` is the radiance *arriving from* `dir`, i.e. seen by a
//! ray travelling along `dir` (a ray going up, +Y, sees the overhead light). Azimuth
//! is φ = atan2(x, z), from +Z (the car's front) toward +X; elevation is above the
//! floor. An equirectangular image has its top row at the zenith and its centre
//! column toward +Z; seen from inside it is not mirrored: a viewer facing +Z with Y
//! up has −X on their right, and so the image's right half (column u = 0.5 − φ/2π).
//!
//! The distant-light approximation: softboxes, cyclorama, booth walls and diffuser
//! are regions of the sphere at infinity rather than geometry. A studio is large
//! against a car and the paint's look comes from what its reflection sees, which the
//! direction alone decides at that distance; in return sampling is exact and cheap
//! (no visibility of emitters among themselves, a closed-form pdf). The floor is
//! real geometry (the tracer intersects y = 0) so the car casts a contact shadow.
//!
//! Normalisation: every environment is scaled so a white Lambertian facing up, lit
//! by the upper hemisphere, has luminance 1 ([`Environment::luminance`] of its
//! exitant radiance), i.e. horizontal illuminance E = π. The floor therefore has
//! luminance ρ in the open, and one film exposure suits every setup.
//!
//! The modules here, by concept:
//! - `setups`: the lighting set-ups above and their constants;
//! - `builder`: normalisation, and the sampling tables built from a set-up;
//! - `emitters`: the regions of constant radiance (softboxes, diffuser, sun);
//! - `map`: the background map, its texel look-up and importance sampling;
//! - `facing_up`: light sampling reweighted for the floor;
//! - `lookup`: radiance, density and light samples of the whole environment,
//!   in one step or two (for a batch of paths);
//! - `direction`, `fast_math`: the sphere's coordinates, and the polynomial
//!   approximations that keep libm calls out of the look-ups.
//!
//! The building blocks come from below: [`crate::sampling`] (distributions and
//! alias tables), [`crate::colour::upsampling`] (RGB texels to spectra) and
//! [`crate::io`] (reading .hdr and .exr files).

use thiserror::Error;

use crate::colour::cie::Illuminant;
use crate::colour::spectrum::Channels;
use crate::colour::upsampling::spectral_luminance_weights;
use crate::io::rgb_image::ImageReadError;
use crate::sampling::Distribution1D;

mod builder;
mod direction;
mod emitters;
mod facing_up;
mod fast_math;
mod lookup;
mod map;
mod setups;
#[cfg(test)]
mod tests;

pub(crate) use lookup::{DirectionLookUp, LocatedSample, SampleLookUp};
pub use setups::{
    BOOTH_DIFFUSER_HALF_ANGLE_DEG, BOOTH_FLOOR_REFLECTANCE, BOOTH_WALL_REFLECTANCE,
    BOOTH_WALL_VIEW_FACTOR, IMAGE_FLOOR_REFLECTANCE, IMAGE_MAX_WIDTH, OUTDOOR_FLOOR_REFLECTANCE,
    SKY_CCT_K, SKY_ILLUMINANCE_FRACTION, STUDIO_CCT_K, STUDIO_FLOOR_REFLECTANCE, SUN_AZIMUTH_DEG,
    SUN_CCT_K, SUN_ELEVATION_DEG, SUN_HALF_ANGLE_DEG,
};

use emitters::Patch;
use facing_up::FacingUpSampling;
use map::RadianceMap;

/// What went wrong making an environment from a map file.
#[derive(Debug, Error)]
pub enum EnvironmentError {
    /// The file could not be read or decoded (the reader's message, unchanged).
    #[error(transparent)]
    Read(#[from] ImageReadError),
    /// Neither .hdr nor .exr.
    #[error(
        "{path}: unknown environment map format (expected a Radiance .hdr or OpenEXR .exr file)"
    )]
    UnknownFormat {
        /// The file, as given.
        path: String,
    },
    /// The map sends no light onto the floor, so it cannot be normalised.
    #[error(
        "{name}: the upper half of the map is black, so it lights nothing and cannot be normalised"
    )]
    NoLight {
        /// The map's name (its file).
        name: String,
    },
}

/// A direction sampled from an environment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnvSample {
    /// Unit direction toward the light (a ray travelling along it sees the light).
    pub dir: [f32; 3],
    /// Probability density of `dir` per unit solid angle (sr⁻¹), > 0.
    pub pdf: f32,
}

/// The floor plane y = 0 that belongs to a lighting setup: Lambertian, with this
/// reflectance on the environment's wavelength grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Floor {
    /// Diffuse reflectance per wavelength sample, in [0, 1].
    pub reflectance: Vec<f32>,
}

/// Which setup an [`Environment`] models.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EnvironmentKind {
    /// Photo studio: softboxes, cyclorama.
    Studio,
    /// Paint light booth under this illuminant.
    Booth(Illuminant),
    /// Sun and clear sky.
    Outdoor,
    /// A user's equirectangular image.
    Image,
    /// The same radiance from every direction, no floor: the white furnace.
    Uniform,
}

/// Spectral radiance over the sphere of directions, with importance sampling, and
/// the floor of the setup. See the module documentation.
#[derive(Debug, Clone)]
pub struct Environment {
    kind: EnvironmentKind,
    channels: Channels,
    luminance_weights: Vec<f32>,
    patches: Vec<Patch>,
    map: RadianceMap,
    /// Selection of a component: the patches in order, then the map.
    components: Distribution1D,
    /// Light sampling for a surface facing straight up (the floor); `None` when
    /// nothing above the horizon gives light.
    facing_up: Option<FacingUpSampling>,
    /// What the facing-up light samples estimate, per channel
    /// ([`Environment::horizontal_irradiance`]).
    horizontal_irradiance: Option<Vec<f32>>,
    floor: Option<Floor>,
    sun_dir: Option<[f32; 3]>,
}

impl Environment {
    /// Which setup this is.
    pub fn kind(&self) -> EnvironmentKind {
        self.kind
    }

    /// What the radiance values here are for: a wavelength grid, or linear sRGB.
    pub fn channels(&self) -> &Channels {
        &self.channels
    }

    /// The floor plane y = 0 of the setup, if any.
    pub fn floor(&self) -> Option<&Floor> {
        self.floor.as_ref()
    }

    /// The same lighting with another floor, or none.
    pub fn with_floor(mut self, floor: Option<Floor>) -> Self {
        self.floor = floor;
        self
    }

    /// The irradiance of a surface facing straight up with nothing above it, per
    /// channel: exactly the expectation of a facing-up light sample's
    /// L · cos θ / pdf ([`Self::sample_for`]), so the floor can take its direct
    /// light as this less what its shadow rays find blocked (a control variate).
    /// `None` where no closed form is exact (an emitter reaching below the
    /// horizon) or nothing lights a surface facing up.
    pub fn horizontal_irradiance(&self) -> Option<&[f32]> {
        self.horizontal_irradiance.as_deref()
    }

    /// The unit direction toward the sun's centre, outdoors.
    pub fn sun_direction(&self) -> Option<[f32; 3]> {
        self.sun_dir
    }

    /// The luminance of a spectral radiance on the grid: Σ wᵢ Lᵢ with wᵢ the CIE 1931
    /// ȳ integrated against sample i's linear-interpolation hat, normalised so
    /// Σ wᵢ = 1 (a flat spectrum of 1 has luminance 1).
    pub fn luminance(&self, values: &[f32]) -> f32 {
        dot_f32(&self.luminance_weights, values)
    }
}

/// Luminance weights on `channels` (Σ wᵢ Lᵢ is the luminance of L, a flat spectrum of 1
/// has luminance 1): [`spectral_luminance_weights`] on a spectral grid, the sRGB
/// luminance coefficients on linear-sRGB channels.
pub fn luminance_weights(channels: &(impl Into<Channels> + Copy)) -> Vec<f32> {
    match (*channels).into() {
        Channels::Spectral(grid) => spectral_luminance_weights(&grid),
        Channels::LinearSrgb => crate::colour::SRGB_LUMINANCE.to_vec(),
    }
}

/// Σ aᵢbᵢ in f32, summed in order: the luminance of a spectrum against its weights.
fn dot_f32(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
