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

use std::f64::consts::{FRAC_PI_2, PI};
use std::path::Path;

use palette::LinSrgb;
use thiserror::Error;

use crate::colour::cie::{Colorimeter, Illuminant, Observer, daylight_spd};
use crate::colour::spectrum::{Channels, VISIBLE, WavelengthGrid};
use crate::colour::xyz_from_linear_srgb;

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
/// Sampling weight of the map below the horizon relative to its power: the floor
/// hides it whenever the floor is present, so samples there are mostly wasted; it
/// stays positive so an environment without floor is still sampled everywhere.
const GROUND_SAMPLING_WEIGHT: f64 = 0.1;
/// Each texel's sampling weight is (luminance + this × its largest spectral value)
/// × solid angle: the second term keeps texels whose light lies outside ȳ (deep red
/// or violet) sampled.
const MAX_VALUE_SAMPLING_WEIGHT: f64 = 0.05;

/// What went wrong reading an environment map.
#[derive(Debug, Error)]
pub enum EnvironmentError {
    /// The file could not be read.
    #[error("{path}: cannot read the environment map: {error}")]
    Io { path: String, error: std::io::Error },
    /// The header is not that of a Radiance RGBE (.hdr) picture we can read.
    #[error("{path}: not a readable Radiance .hdr file: {reason}")]
    BadHeader { path: String, reason: String },
    /// The pixel data stop early.
    #[error(
        "{path}: truncated: the pixel data end in scanline {row} of {height} (the header promises {width}×{height} pixels)"
    )]
    Truncated {
        path: String,
        row: usize,
        width: usize,
        height: usize,
    },
    /// Run-length data that do not decode to a scanline.
    #[error("{path}: corrupt run-length data in scanline {row}: {reason}")]
    CorruptScanline {
        path: String,
        row: usize,
        reason: &'static str,
    },
    /// An OpenEXR file the decoder cannot read (or without RGB channels).
    #[error("{path}: not a readable OpenEXR file: {reason}")]
    BadExr { path: String, reason: String },
    /// Neither .hdr nor .exr.
    #[error(
        "{path}: unknown environment map format (expected a Radiance .hdr or OpenEXR .exr file)"
    )]
    UnknownFormat { path: String },
    /// An image whose pixel buffer does not fit its size, or holds NaN or infinity.
    #[error("{name}: {reason}")]
    InvalidImage { name: String, reason: String },
    /// The map sends no light onto the floor, so it cannot be normalised.
    #[error(
        "{name}: the upper half of the map is black, so it lights nothing and cannot be normalised"
    )]
    NoLight { name: String },
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
    floor: Option<Floor>,
    sun_dir: Option<[f32; 3]>,
}

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
                let cos_gamma = dot(dir, sun_axis).clamp(-1.0, 1.0);
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
        env.sun_dir = Some(sun_axis.map(|v| v as f32));
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
        match extension.as_deref() {
            Some("hdr") | Some("pic") | Some("rgbe") => {
                let image = read_hdr(path)?;
                Self::from_rgb_image(&image, &name, &channels)
            }
            Some("exr") => {
                let image = read_exr(path)?;
                Self::from_rgb_image(&image, &name, &channels)
            }
            _ => Err(EnvironmentError::UnknownFormat { path: name }),
        }
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
        let factor = image.width.div_ceil(IMAGE_MAX_WIDTH).max(1);
        let image = if factor > 1 {
            image.box_downsample(factor)
        } else {
            image.clone()
        };
        let upsampler = RgbUpsampler::new(&radiance_channels);
        let channels = upsampler.emission_bases.to_vec();
        let mut b = Builder::new(&radiance_channels, channels, image.width, image.height);
        for (coeffs, rgb) in b.coeffs.chunks_exact_mut(3).zip(&image.pixels) {
            for (c, v) in coeffs.iter_mut().zip(rgb) {
                *c = v.max(0.0);
            }
        }
        b.finish(EnvironmentKind::Image, IMAGE_FLOOR_REFLECTANCE, false)
            .ok_or_else(|| EnvironmentError::NoLight {
                name: name.to_owned(),
            })
    }

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

    /// Spectral radiance arriving from `dir` (a ray travelling along `dir` sees it),
    /// written to `out` (one value per grid sample).
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub fn radiance(&self, dir: [f32; 3], out: &mut [f32]) {
        self.radiance_and_pdf(dir, out);
    }

    /// Density (per unit solid angle) with which [`Self::sample`] returns `dir`.
    pub fn pdf(&self, dir: [f32; 3]) -> f32 {
        self.pdf_for(dir, false)
    }

    /// Density (per unit solid angle) with which a light sample for a surface
    /// facing straight up (`facing_up`, the floor: [`Self::sample_for`]) or for
    /// any other returns `dir`.
    pub fn pdf_for(&self, dir: [f32; 3], facing_up: bool) -> f32 {
        let Some(d) = normalised(dir) else {
            return 0.0;
        };
        let mut q = Query::new(d);
        let texel = self.map.texel(&mut q);
        self.evaluate_texel(texel, &mut q, None, facing_up) as f32
    }

    /// [`Self::radiance`] and [`Self::pdf`] of one direction together: the texel and
    /// the emitters containing `dir` are found once (a path that escapes needs both).
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub fn radiance_and_pdf(&self, dir: [f32; 3], out: &mut [f32]) -> f32 {
        assert_eq!(out.len(), self.channels.len(), "radiance buffer length");
        out.fill(0.0);
        let Some(d) = normalised(dir) else { return 0.0 };
        self.evaluate(&mut Query::new(d), Some(out)) as f32
    }

    /// A direction toward the light for the two uniform numbers `u` in [0, 1)²:
    /// emitters chosen in proportion to their power, then a point uniform in solid
    /// angle on them, or a texel of the background map by luminance × solid angle.
    /// `out` receives the radiance from the direction. `None` if the sample
    /// carries no density (never for the setups here).
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub fn sample(&self, u: [f32; 2], out: &mut [f32]) -> Option<EnvSample> {
        self.finish_sample(&self.begin_sample(u), out)
    }

    /// [`Self::sample`] for a surface facing straight up (`facing_up`: the floor,
    /// normal +Y) or any other. Facing up, emitters and the map's rows are chosen
    /// in proportion to their power times their mean cosine to the vertical
    /// (the texel within a row and the point within an emitter as before), so the
    /// light sample's weight L·cos θ/pdf is nearly constant over the unshadowed
    /// sky: the floor's direct light without the noise of sampling by power
    /// alone, which spends samples on bright light near the horizon that reaches
    /// the floor at a grazing cosine.
    pub fn sample_for(&self, u: [f32; 2], facing_up: bool, out: &mut [f32]) -> Option<EnvSample> {
        self.finish_sample(&self.begin_sample_for(u, facing_up), out)
    }

    /// [`Self::sample`] in two steps, for a batch of paths: this one draws what the
    /// numbers decide without reading the map's tables (the emitter, the map's row
    /// and the column u lands on) and starts reading that column's alias-table
    /// entry into the cache;
    /// [`Self::finish_sample`], called after the batch's other look-ups have been
    /// begun, completes the draw. The result is bit for bit `sample(u, out)`.
    pub(crate) fn begin_sample(&self, u: [f32; 2]) -> SampleLookUp {
        self.begin_sample_for(u, false)
    }

    /// [`Self::begin_sample`] of [`Self::sample_for`].
    pub(crate) fn begin_sample_for(&self, u: [f32; 2], facing_up: bool) -> SampleLookUp {
        let (components, rows, facing_up) = match (&self.facing_up, facing_up) {
            (Some(up), true) => (&up.components, &up.rows, true),
            _ => (&self.components, &self.map.rows, false),
        };
        let (component, u0) = components.sample(f64::from(u[0]));
        let u1 = f64::from(u[1]).clamp(0.0, ONE_BELOW);
        let draw = if component < self.patches.len() {
            None
        } else {
            let draw = self.map.begin_sample(rows, [u0, u1]);
            if let Some(draw) = &draw {
                prefetch(&self.map.columns[draw.row * self.map.width + draw.first]);
            }
            draw
        };
        SampleLookUp {
            component,
            u: [u0, u1],
            draw,
            facing_up,
        }
    }

    /// The second step of [`Self::begin_sample`].
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub(crate) fn finish_sample(&self, begun: &SampleLookUp, out: &mut [f32]) -> Option<EnvSample> {
        self.finish_located_sample(&self.locate_sample(begun)?, out)
    }

    /// [`Self::finish_sample`]'s first half, for a batch: the sample's direction
    /// and the texel it lies in, whose record it starts reading into the cache.
    /// `None` where `finish_sample` returns `None` without writing `out` (a map
    /// without light).
    pub(crate) fn locate_sample(&self, begun: &SampleLookUp) -> Option<LocatedSample> {
        let (d, dir, drawn) = if begun.component < self.patches.len() {
            let d = self.patches[begun.component].shape.sample(begun.u);
            (d, d.map(|v| v as f32), None)
        } else {
            let (d, dir, drawn) = self.map.finish_sample(begun.draw?);
            (d, dir, Some(drawn))
        };
        // Radiance and density of the direction as returned (rounded to f32), the
        // same function of `dir` that `radiance`, `pdf` and a re-shading replay of
        // the recorded `dir` evaluate: the texel is that of the rounded direction.
        // The drawn texel is that texel unless the rounding could have moved the
        // direction across one of its boundaries; only then is it searched for
        // (an `atan2` and a row search saved on all but a few samples in 10⁴).
        // Without emitters the normalised direction is needed for nothing else,
        // so where the drawn direction is safely inside its texel's row it is not
        // normalised at all (a square root and a division saved).
        if self.patches.is_empty()
            && let Some(drawn) = drawn
            && self.map.surely_holds_unrounded(&drawn, d, dir)
        {
            prefetch(&self.map.texels[drawn.texel]);
            let look_up = DirectionLookUp {
                query: LookUpQuery::NoEmitters,
                texel: drawn.texel,
                facing_up: begun.facing_up,
            };
            return Some(LocatedSample { dir, look_up });
        }
        let look_up = self.begin_look_up(dir, drawn, begun.facing_up);
        Some(LocatedSample { dir, look_up })
    }

    /// [`Self::finish_sample`]'s second half: the radiance (to `out`) and density
    /// of a located sample.
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub(crate) fn finish_located_sample(
        &self,
        located: &LocatedSample,
        out: &mut [f32],
    ) -> Option<EnvSample> {
        let pdf = self.finish_radiance_and_pdf(&located.look_up, out);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(EnvSample {
            dir: located.dir,
            pdf,
        })
    }

    /// [`Self::radiance_and_pdf`] in two steps, for a batch of escapes: this one
    /// finds the direction's texel and starts reading its record into the cache;
    /// [`Self::finish_radiance_and_pdf`] returns what `radiance_and_pdf` does, bit
    /// for bit. Begun for a whole batch first, the batch's cache misses overlap.
    ///
    /// With `facing_up` the density is that of [`Self::sample_for`] for a surface
    /// facing up (an escape from the floor), else that of [`Self::sample`].
    pub(crate) fn begin_radiance_and_pdf_for(
        &self,
        dir: [f32; 3],
        facing_up: bool,
    ) -> DirectionLookUp {
        self.begin_look_up(dir, None, facing_up)
    }

    /// The look-up of `dir` begun: its texel found (the `drawn` one where `dir`
    /// surely lies in it) and its record prefetched.
    fn begin_look_up(
        &self,
        dir: [f32; 3],
        drawn: Option<DrawnTexel>,
        facing_up: bool,
    ) -> DirectionLookUp {
        let Some(d) = normalised(dir) else {
            return DirectionLookUp {
                query: LookUpQuery::Degenerate,
                texel: 0,
                facing_up,
            };
        };
        let mut query = Query::new(d);
        let texel = match drawn {
            Some(drawn) if self.map.surely_holds(&drawn, &query) => drawn.texel,
            _ => self.map.texel(&mut query),
        };
        prefetch(&self.map.texels[texel]);
        DirectionLookUp {
            query: LookUpQuery::Direction(query),
            texel,
            facing_up,
        }
    }

    /// The second step of [`Self::begin_radiance_and_pdf_for`].
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub(crate) fn finish_radiance_and_pdf(&self, begun: &DirectionLookUp, out: &mut [f32]) -> f32 {
        assert_eq!(out.len(), self.channels.len(), "radiance buffer length");
        out.fill(0.0);
        match begun.query {
            LookUpQuery::Degenerate => 0.0,
            LookUpQuery::NoEmitters => {
                self.evaluate_map_texel(begun.texel, Some(out), begun.facing_up) as f32
            }
            LookUpQuery::Direction(mut query) => {
                self.evaluate_texel(begun.texel, &mut query, Some(out), begun.facing_up) as f32
            }
        }
    }

    /// The density of `q` (f64), and its radiance added to `out` when given: one
    /// texel look-up and one containment test per emitter.
    fn evaluate(&self, q: &mut Query, out: Option<&mut [f32]>) -> f64 {
        let texel = self.map.texel(q);
        self.evaluate_texel(texel, q, out, false)
    }

    /// The map's share of [`Self::evaluate_texel`] (all of it for an environment
    /// without emitters), the density that of [`Self::sample_for`] with
    /// `facing_up`.
    fn evaluate_map_texel(&self, texel: usize, out: Option<&mut [f32]>, facing_up: bool) -> f64 {
        if let Some(out) = out {
            self.map.add_radiance(texel, out);
        }
        let (components, row_factor) = self.components_for(texel, facing_up);
        components.probability(self.patches.len()) * self.map.pdf(texel) * row_factor
    }

    /// The component distribution of [`Self::sample_for`] with `facing_up`, and the
    /// factor its row distribution gives `texel`'s row against the plain one.
    fn components_for(&self, texel: usize, facing_up: bool) -> (&Distribution1D, f64) {
        match (&self.facing_up, facing_up) {
            (Some(up), true) => (
                &up.components,
                f64::from(up.row_factor[texel / self.map.width]),
            ),
            _ => (&self.components, 1.0),
        }
    }

    /// [`Self::evaluate`] with the map's texel of `q` already found, the density
    /// that of [`Self::sample_for`] with `facing_up`.
    fn evaluate_texel(
        &self,
        texel: usize,
        q: &mut Query,
        mut out: Option<&mut [f32]>,
        facing_up: bool,
    ) -> f64 {
        let mut pdf = self.evaluate_map_texel(texel, out.as_deref_mut(), facing_up);
        let (components, _) = self.components_for(texel, facing_up);
        for (k, patch) in self.patches.iter().enumerate() {
            if patch.shape.contains(q) {
                pdf += components.probability(k) / patch.solid_angle;
                if let Some(out) = out.as_deref_mut() {
                    for (o, r) in out.iter_mut().zip(&patch.radiance) {
                        *o += r;
                    }
                }
            }
        }
        pdf
    }
}

/// A light sample begun by [`Environment::begin_sample`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct SampleLookUp {
    component: usize,
    /// The numbers left for the component's own draw.
    u: [f64; 2],
    /// The map's part of the draw when the component is the map (`None` also for
    /// a map without light, which draws nothing).
    draw: Option<MapDraw>,
    /// Drawn for a surface facing up ([`Environment::sample_for`]).
    facing_up: bool,
}

/// A light sample located by [`Environment::locate_sample`]: its direction, and
/// the radiance look-up of that direction begun.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LocatedSample {
    dir: [f32; 3],
    look_up: DirectionLookUp,
}

/// An escape's look-up begun by [`Environment::begin_radiance_and_pdf_for`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct DirectionLookUp {
    query: LookUpQuery,
    texel: usize,
    /// The density is that of a light sample for a surface facing up.
    facing_up: bool,
}

/// What a begun look-up still needs of its direction besides the texel.
#[derive(Debug, Clone, Copy)]
enum LookUpQuery {
    /// A direction that cannot be normalised: radiance and density 0.
    Degenerate,
    /// Nothing: the environment has no emitters to test the direction against.
    NoEmitters,
    /// The normalised direction, for the emitters' containment tests.
    Direction(Query),
}

/// What a map sample's numbers decide before its column's alias entry is read.
#[derive(Debug, Clone, Copy)]
struct MapDraw {
    row: usize,
    /// Where the row's number fell within the row, in [0, 1).
    v: f64,
    /// The column u lands on, before its alias table decides.
    first: usize,
    /// Where u fell within that column, in [0, 1).
    frac: f64,
}

/// Starts reading the cache line of `item` (a hint: no effect on any result).
#[inline(always)]
fn prefetch<T>(item: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: a prefetch never faults and reads nothing the program sees; the
        // address is that of a live reference.
        #[allow(unused_unsafe)]
        unsafe {
            _mm_prefetch::<_MM_HINT_T0>((item as *const T).cast::<i8>())
        };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = item;
}

/// A unit direction being looked up, with its azimuth computed at most once (an
/// `atan2`, shared by the map's column and every emitter's azimuth test).
#[derive(Debug, Clone, Copy)]
struct Query {
    d: [f64; 3],
    azimuth: Option<f64>,
}

impl Query {
    fn new(d: [f64; 3]) -> Self {
        Self { d, azimuth: None }
    }

    /// φ = atan2(x, z), in [−π, π].
    fn azimuth(&mut self) -> f64 {
        *self
            .azimuth
            .get_or_insert_with(|| self.d[0].atan2(self.d[2]))
    }
}

/// A linear-sRGB picture, row-major, top row first.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbImage {
    width: usize,
    height: usize,
    pixels: Vec<[f32; 3]>,
}

impl RgbImage {
    /// An image from its pixels; errors unless there are `width × height ≥ 1` of
    /// them, all finite.
    pub fn new(
        width: usize,
        height: usize,
        pixels: Vec<[f32; 3]>,
    ) -> Result<Self, EnvironmentError> {
        let invalid = |reason: String| EnvironmentError::InvalidImage {
            name: "RGB image".to_owned(),
            reason,
        };
        if width == 0 || height == 0 || width.checked_mul(height) != Some(pixels.len()) {
            return Err(invalid(format!(
                "{} pixels do not make a {width}×{height} image",
                pixels.len()
            )));
        }
        if let Some(i) = pixels.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
            return Err(invalid(format!(
                "pixel {i} ({:?}) is not finite",
                pixels[i]
            )));
        }
        Ok(Self {
            width,
            height,
            pixels,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The pixels, row-major, top row first.
    pub fn pixels(&self) -> &[[f32; 3]] {
        &self.pixels
    }

    fn box_downsample(&self, factor: usize) -> Self {
        let width = self.width.div_ceil(factor);
        let height = self.height.div_ceil(factor);
        let mut pixels = vec![[0.0f32; 3]; width * height];
        let mut counts = vec![0u32; width * height];
        for row in 0..self.height {
            for col in 0..self.width {
                let target = (row / factor) * width + col / factor;
                let p = self.pixels[row * self.width + col];
                for c in 0..3 {
                    pixels[target][c] += p[c];
                }
                counts[target] += 1;
            }
        }
        for (p, &n) in pixels.iter_mut().zip(&counts) {
            *p = p.map(|v| v / n as f32);
        }
        Self {
            width,
            height,
            pixels,
        }
    }
}

// ---------------------------------------------------------------------------
// RGB → spectrum

/// Jakob–Hanika sigmoid-polynomial coefficients (c₂, c₁, c₀ of
/// S(c₂t² + c₁t + c₀), t = (λ − 580 nm)/200 nm, S(x) = ½ + x/(2√(1 + x²))) of the
/// three basis reflectances. Fitted jointly offline (Levenberg–Marquardt on the
/// CIE 1931 5 nm tables) so that D65 × basis has the chromaticity of the sRGB red,
/// green and blue primaries (to 5e-6) while the three, scaled to the primaries'
/// luminances, sum to nearly 1 (0.77–1.44, mostly 0.9–1.15): white light stays
/// close to D65. Each grid refits them exactly ([`refit_basis`]).
const RGB_BASIS_COEFFICIENTS: [[f64; 3]; 3] = [
    [15.278_909_716_9, 14.156_045_384_5, -1.396_364_337_8],
    [-28.213_178_528_6, -11.369_104_624_1, 0.601_796_464_1],
    [6.353_649_784_7, -6.196_147_115_2, -4.317_131_247_5],
];

/// Linear sRGB to smooth, non-negative spectra: a fixed linear combination of three
/// smooth basis spectra, one per primary, so the map is linear (an RGB image's
/// spectra are three coefficients per texel) and an RGB triple round-trips.
///
/// Basis i is the sigmoid polynomial of [`RGB_BASIS_COEFFICIENTS`] scaled so that,
/// as a reflectance under D65 (CIE 1931, on this grid's colorimetry), its XYZ is
/// exactly that of sRGB primary i; chromaticity holds to the fit. Negative RGB
/// components are clamped to 0, so the spectra are never negative.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbUpsampler {
    reflectance_bases: [Vec<f32>; 3],
    emission_bases: [Vec<f32>; 3],
}

impl RgbUpsampler {
    /// The bases on `channels`.
    pub fn new(channels: &(impl Into<Channels> + Copy)) -> Self {
        let grid = match (*channels).into() {
            Channels::Spectral(grid) => grid,
            Channels::LinearSrgb => {
                // A colour is its own "spectrum"; (1, 1, 1) has luminance 1 under
                // the sRGB luminance weights.
                let unit = |i: usize| (0..3).map(|k| if k == i { 1.0 } else { 0.0 }).collect();
                return Self {
                    reflectance_bases: std::array::from_fn(unit),
                    emission_bases: std::array::from_fn(unit),
                };
            }
        };
        let grid = &grid;
        let colorimeter = Colorimeter::new(Illuminant::D65, Observer::Cie1931TwoDegree, grid);
        let unit = [
            LinSrgb::new(1.0, 0.0, 0.0),
            LinSrgb::new(0.0, 1.0, 0.0),
            LinSrgb::new(0.0, 0.0, 1.0),
        ];
        let reflectance_bases: [Vec<f64>; 3] = std::array::from_fn(|i| {
            let target = xyz_from_linear_srgb(unit[i]);
            let coefficients = refit_basis(&colorimeter, RGB_BASIS_COEFFICIENTS[i], target);
            let raw = sigmoid_polynomial(grid, coefficients);
            let scale = target.y / colorimeter.xyz(&raw).y;
            raw.into_iter().map(|v| v * scale).collect()
        });
        // Emission: D65 × reflectance, scaled so RGB (1, 1, 1) has luminance 1.
        let d65 = Illuminant::D65.spd(grid);
        let weights = luminance_weights(grid);
        let white: Vec<f64> = (0..grid.len())
            .map(|k| d65.values()[k] * reflectance_bases.iter().map(|b| b[k]).sum::<f64>())
            .collect();
        let white_luminance: f64 = white
            .iter()
            .zip(&weights)
            .map(|(v, &w)| v * f64::from(w))
            .sum();
        let emission_bases = std::array::from_fn(|i| {
            reflectance_bases[i]
                .iter()
                .zip(d65.values())
                .map(|(r, s)| (r * s / white_luminance) as f32)
                .collect()
        });
        Self {
            reflectance_bases: reflectance_bases.map(|b| b.into_iter().map(|v| v as f32).collect()),
            emission_bases,
        }
    }

    /// A reflectance whose colour under D65 is `rgb` (linear sRGB, white (1, 1, 1)).
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub fn reflectance(&self, rgb: LinSrgb<f32>, out: &mut [f32]) {
        combine(&self.reflectance_bases, rgb, out);
    }

    /// An emission (radiance) spectrum whose colour is `rgb`: D65 × the
    /// reflectance, scaled so (1, 1, 1) has [`Environment::luminance`] 1.
    ///
    /// # Panics
    /// If `out.len()` differs from the grid's length.
    pub fn emission(&self, rgb: LinSrgb<f32>, out: &mut [f32]) {
        combine(&self.emission_bases, rgb, out);
    }
}

fn combine(bases: &[Vec<f32>; 3], rgb: LinSrgb<f32>, out: &mut [f32]) {
    assert_eq!(out.len(), bases[0].len(), "spectrum buffer length");
    let c = [rgb.red, rgb.green, rgb.blue].map(|v| v.max(0.0));
    for (k, o) in out.iter_mut().enumerate() {
        *o = c[0] * bases[0][k] + c[1] * bases[1][k] + c[2] * bases[2][k];
    }
}

fn sigmoid_polynomial(grid: &WavelengthGrid, [c2, c1, c0]: [f64; 3]) -> Vec<f64> {
    grid.wavelengths_nm()
        .map(|l| {
            let t = (l - 580.0) / 200.0;
            sigmoid(c2 * t * t + c1 * t + c0)
        })
        .collect()
}

/// The sigmoid-polynomial coefficients nearest `start` whose spectrum has the
/// chromaticity of `target` under this grid's colorimetry: minimum-norm
/// Gauss–Newton steps on the two chromaticity equations, halved until they help.
/// On the 5 nm grid `start` already fits; coarse grids, which read a spectrum as
/// piecewise linear between fewer samples, move it a little. Where a grid is too
/// coarse to reach the target the best coefficients found are kept.
fn refit_basis(colorimeter: &Colorimeter, start: [f64; 3], target: crate::colour::Xyz) -> [f64; 3] {
    let grid = *colorimeter.grid();
    let chromaticity = |xyz: crate::colour::Xyz| {
        let sum = xyz.x + xyz.y + xyz.z;
        [xyz.x / sum, xyz.y / sum]
    };
    let goal = chromaticity(target);
    let residual = |c: [f64; 3]| {
        let xy = chromaticity(colorimeter.xyz(&sigmoid_polynomial(&grid, c)));
        [xy[0] - goal[0], xy[1] - goal[1]]
    };
    let norm = |r: [f64; 2]| r[0].hypot(r[1]);
    let mut c = start;
    let mut r = residual(c);
    for _ in 0..30 {
        if norm(r) < 1e-10 {
            break;
        }
        // Jacobian (2×3) by forward differences.
        let jacobian: [[f64; 2]; 3] = std::array::from_fn(|k| {
            let mut shifted = c;
            let h = 1e-6 * c[k].abs().max(1.0);
            shifted[k] += h;
            let rs = residual(shifted);
            [(rs[0] - r[0]) / h, (rs[1] - r[1]) / h]
        });
        // Δc = −Jᵀ (J Jᵀ)⁻¹ r.
        let mut jjt = [[0.0; 2]; 2];
        for col in &jacobian {
            for a in 0..2 {
                for b in 0..2 {
                    jjt[a][b] += col[a] * col[b];
                }
            }
        }
        let det = jjt[0][0] * jjt[1][1] - jjt[0][1] * jjt[1][0];
        if det.abs() < 1e-300 {
            break;
        }
        let lambda = [
            (jjt[1][1] * r[0] - jjt[0][1] * r[1]) / det,
            (jjt[0][0] * r[1] - jjt[1][0] * r[0]) / det,
        ];
        let step: [f64; 3] =
            std::array::from_fn(|k| -(jacobian[k][0] * lambda[0] + jacobian[k][1] * lambda[1]));
        let mut scale = 1.0;
        let mut improved = false;
        for _ in 0..20 {
            let trial = std::array::from_fn(|k| c[k] + scale * step[k]);
            let rt = residual(trial);
            if norm(rt) < norm(r) {
                c = trial;
                r = rt;
                improved = true;
                break;
            }
            scale *= 0.5;
        }
        if !improved {
            break;
        }
    }
    c
}

fn sigmoid(x: f64) -> f64 {
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

// ---------------------------------------------------------------------------
// Radiance .hdr (RGBE)

/// Reads the first RGB(A) layer of an OpenEXR file as linear RGB.
pub fn read_exr(path: &Path) -> Result<RgbImage, EnvironmentError> {
    use exr::prelude::{Vec2, read_first_rgba_layer_from_file};
    let name = path.display().to_string();
    if let Err(error) = std::fs::metadata(path) {
        return Err(EnvironmentError::Io { path: name, error });
    }
    type Pixels = (usize, Vec<[f32; 3]>);
    let image = read_first_rgba_layer_from_file(
        path,
        |size: Vec2<usize>, _| -> Pixels { (size.width(), vec![[0.0; 3]; size.area()]) },
        |(width, pixels): &mut Pixels, at: Vec2<usize>, (r, g, b, _): (f32, f32, f32, f32)| {
            pixels[at.y() * *width + at.x()] = [r, g, b];
        },
    )
    .map_err(|e| EnvironmentError::BadExr {
        path: name.clone(),
        reason: e.to_string(),
    })?;
    let size = image.layer_data.size;
    let (_, pixels) = image.layer_data.channel_data.pixels;
    RgbImage::new(size.width(), size.height(), pixels).map_err(|e| match e {
        EnvironmentError::InvalidImage { reason, .. } => {
            EnvironmentError::InvalidImage { name, reason }
        }
        other => other,
    })
}

/// Reads a Radiance RGBE picture (`#?RADIANCE` header, `FORMAT=32-bit_rle_rgbe`,
/// resolution `-Y h +X w` or `+Y h +X w`, flat, old-style or new-style run-length
/// encoded scanlines). Pixel value = (mantissa + ½)·2^(exponent − 136), as Radiance
/// decodes it; EXPOSURE lines are ignored (environments are normalised anyway).
pub fn read_hdr(path: &Path) -> Result<RgbImage, EnvironmentError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|error| EnvironmentError::Io {
        path: name.clone(),
        error,
    })?;
    decode_hdr(&bytes, &name)
}

/// [`read_hdr`] on bytes in memory; `name` is used in errors.
pub fn decode_hdr(bytes: &[u8], name: &str) -> Result<RgbImage, EnvironmentError> {
    let bad = |reason: &str| EnvironmentError::BadHeader {
        path: name.to_owned(),
        reason: reason.to_owned(),
    };
    let mut pos = 0;
    let next_line = |pos: &mut usize| -> Option<&[u8]> {
        let rest = bytes.get(*pos..)?;
        let end = rest.iter().position(|&b| b == b'\n')?;
        *pos += end + 1;
        Some(&rest[..end])
    };
    let first = next_line(&mut pos).ok_or_else(|| bad("no header line"))?;
    if !first.starts_with(b"#?") {
        return Err(bad(
            "the first line does not start with \"#?\" (e.g. #?RADIANCE)",
        ));
    }
    loop {
        let line = next_line(&mut pos).ok_or_else(|| bad("the header never ends"))?;
        if line.is_empty() {
            break;
        }
        if let Some(format) = line.strip_prefix(b"FORMAT=") {
            let format = String::from_utf8_lossy(format);
            if format.trim() != "32-bit_rle_rgbe" {
                return Err(bad(&format!(
                    "pixel format {} (only 32-bit_rle_rgbe is supported)",
                    format.trim()
                )));
            }
        }
    }
    let resolution = next_line(&mut pos).ok_or_else(|| bad("no resolution line"))?;
    let resolution = String::from_utf8_lossy(resolution);
    let fields: Vec<&str> = resolution.split_whitespace().collect();
    let (flip, height, width) = match fields.as_slice() {
        [y, h, "+X", w] if *y == "-Y" || *y == "+Y" => {
            let parse = |s: &str| s.parse::<usize>().ok().filter(|&n| n > 0);
            match (parse(h), parse(w)) {
                (Some(h), Some(w)) => (*y == "+Y", h, w),
                _ => return Err(bad(&format!("bad resolution line {resolution:?}"))),
            }
        }
        _ => {
            return Err(bad(&format!(
                "resolution line {resolution:?} (only \"-Y h +X w\" and \"+Y h +X w\" are supported)"
            )));
        }
    };
    if width.checked_mul(height).is_none_or(|n| n > 1 << 28) {
        return Err(bad(&format!(
            "image of {width}×{height} pixels is too large"
        )));
    }
    let mut data = ScanlineReader {
        bytes,
        pos,
        name,
        width,
        height,
    };
    let mut pixels = vec![[0.0f32; 3]; width * height];
    let mut scanline = vec![[0u8; 4]; width];
    for row in 0..height {
        data.read_scanline(row, &mut scanline)?;
        let target = if flip { height - 1 - row } else { row };
        for (p, rgbe) in pixels[target * width..(target + 1) * width]
            .iter_mut()
            .zip(&scanline)
        {
            *p = rgbe_to_float(*rgbe);
        }
    }
    Ok(RgbImage {
        width,
        height,
        pixels,
    })
}

fn rgbe_to_float([r, g, b, e]: [u8; 4]) -> [f32; 3] {
    if e == 0 {
        return [0.0; 3];
    }
    let f = 2f32.powi(i32::from(e) - 136);
    [r, g, b].map(|m| (f32::from(m) + 0.5) * f)
}

struct ScanlineReader<'a> {
    bytes: &'a [u8],
    pos: usize,
    name: &'a str,
    width: usize,
    height: usize,
}

impl ScanlineReader<'_> {
    fn byte(&mut self, row: usize) -> Result<u8, EnvironmentError> {
        let b = self
            .bytes
            .get(self.pos)
            .copied()
            .ok_or_else(|| EnvironmentError::Truncated {
                path: self.name.to_owned(),
                row,
                width: self.width,
                height: self.height,
            })?;
        self.pos += 1;
        Ok(b)
    }

    fn corrupt(&self, row: usize, reason: &'static str) -> EnvironmentError {
        EnvironmentError::CorruptScanline {
            path: self.name.to_owned(),
            row,
            reason,
        }
    }

    fn read_scanline(&mut self, row: usize, out: &mut [[u8; 4]]) -> Result<(), EnvironmentError> {
        let width = out.len();
        let first = [
            self.byte(row)?,
            self.byte(row)?,
            self.byte(row)?,
            self.byte(row)?,
        ];
        let new_rle =
            (8..=0x7fff).contains(&width) && first[0] == 2 && first[1] == 2 && first[2] & 0x80 == 0;
        if new_rle {
            if (usize::from(first[2]) << 8 | usize::from(first[3])) != width {
                return Err(self.corrupt(row, "the scanline length differs from the image width"));
            }
            // Four channel runs: count > 128 repeats one byte, else literal bytes.
            for channel in 0..4 {
                let mut x = 0;
                while x < width {
                    let count = usize::from(self.byte(row)?);
                    if count > 128 {
                        let run = count - 128;
                        if x + run > width {
                            return Err(self.corrupt(row, "a run overflows the scanline"));
                        }
                        let value = self.byte(row)?;
                        for p in &mut out[x..x + run] {
                            p[channel] = value;
                        }
                        x += run;
                    } else {
                        if count == 0 || x + count > width {
                            return Err(self.corrupt(row, "a literal span is empty or too long"));
                        }
                        for p in &mut out[x..x + count] {
                            p[channel] = self.byte(row)?;
                        }
                        x += count;
                    }
                }
            }
            return Ok(());
        }
        // Flat pixels, with old-style runs: (1, 1, 1, n) repeats the previous pixel
        // n << shift times, shift growing by 8 for consecutive run markers.
        let mut x = 0;
        let mut shift = 0u32;
        let mut pixel = first;
        loop {
            if pixel[0] == 1 && pixel[1] == 1 && pixel[2] == 1 {
                if x == 0 {
                    return Err(self.corrupt(row, "a run marker with no pixel before it"));
                }
                let run = usize::from(pixel[3])
                    .checked_shl(shift)
                    .filter(|&r| shift < 24 && x + r <= width)
                    .ok_or_else(|| self.corrupt(row, "an old-style run overflows the scanline"))?;
                let previous = out[x - 1];
                out[x..x + run].fill(previous);
                x += run;
                shift += 8;
            } else {
                out[x] = pixel;
                x += 1;
                shift = 0;
            }
            if x == width {
                return Ok(());
            }
            pixel = [
                self.byte(row)?,
                self.byte(row)?,
                self.byte(row)?,
                self.byte(row)?,
            ];
        }
    }
}

// ---------------------------------------------------------------------------
// Building blocks

/// Largest f64 below 1.
const ONE_BELOW: f64 = 1.0 - f64::EPSILON / 2.0;

/// A region of the sphere with constant radiance.
#[derive(Debug, Clone)]
enum Shape {
    /// Azimuth in [a₀, a₁] (radians, from +Z toward +X, within [−π, π]) and
    /// y = sin(elevation) in [y₀, y₁]: uniform in (azimuth, y) is uniform in solid
    /// angle, so sampling is exact. A full azimuth range makes a cap about +Y.
    LatLong { azimuth: [f64; 2], y: [f64; 2] },
    /// A cone of directions about `axis`; `one_minus_cos` = 1 − cos(half-angle)
    /// (kept apart for precision with the sun's tiny disc).
    Cap {
        axis: [f64; 3],
        tangent: [f64; 3],
        bitangent: [f64; 3],
        one_minus_cos: f64,
    },
}

impl Shape {
    fn cap(axis: [f64; 3], half_angle: f64) -> Self {
        let helper = if axis[1].abs() < 0.9 {
            [0.0, 1.0, 0.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let tangent = normalise(cross(helper, axis));
        let bitangent = cross(axis, tangent);
        Shape::Cap {
            axis,
            tangent,
            bitangent,
            one_minus_cos: 2.0 * (0.5 * half_angle).sin().powi(2),
        }
    }

    fn solid_angle(&self) -> f64 {
        match self {
            Shape::LatLong { azimuth, y } => (azimuth[1] - azimuth[0]) * (y[1] - y[0]),
            Shape::Cap { one_minus_cos, .. } => 2.0 * PI * one_minus_cos,
        }
    }

    /// ∫ max(y, 0) dω over the region: horizontal irradiance per unit radiance
    /// (exact for a cap entirely above the horizon).
    fn cosine_integral(&self) -> f64 {
        match self {
            Shape::LatLong { azimuth, y } => {
                let (y0, y1) = (y[0].max(0.0), y[1].max(0.0));
                (azimuth[1] - azimuth[0]) * 0.5 * (y1 * y1 - y0 * y0)
            }
            Shape::Cap {
                axis,
                one_minus_cos,
                ..
            } => {
                // π sin²α times the axis's cosine.
                let sin2 = one_minus_cos * (2.0 - one_minus_cos);
                PI * sin2 * axis[1].max(0.0)
            }
        }
    }

    fn contains(&self, q: &mut Query) -> bool {
        match self {
            Shape::LatLong { azimuth, y } => {
                (y[0]..=y[1]).contains(&q.d[1]) && (azimuth[0]..=azimuth[1]).contains(&q.azimuth())
            }
            Shape::Cap {
                axis,
                one_minus_cos,
                ..
            } => 1.0 - dot(q.d, *axis) <= *one_minus_cos,
        }
    }

    fn sample(&self, u: [f64; 2]) -> [f64; 3] {
        match self {
            Shape::LatLong { azimuth, y } => {
                let a = azimuth[0] + u[0] * (azimuth[1] - azimuth[0]);
                let y = y[0] + u[1] * (y[1] - y[0]);
                direction_from_azimuth_y(a, y)
            }
            Shape::Cap {
                axis,
                tangent,
                bitangent,
                one_minus_cos,
            } => {
                let one_minus = u[0] * one_minus_cos;
                let cos_t = 1.0 - one_minus;
                let sin_t = (one_minus * (2.0 - one_minus)).max(0.0).sqrt();
                let phi = 2.0 * PI * u[1];
                let (s, c) = phi.sin_cos();
                std::array::from_fn(|k| {
                    sin_t * (c * tangent[k] + s * bitangent[k]) + cos_t * axis[k]
                })
            }
        }
    }
}

/// An emitter: a region with its radiance.
#[derive(Debug, Clone)]
struct Patch {
    shape: Shape,
    solid_angle: f64,
    radiance: Vec<f32>,
}

/// Piecewise-constant spectral radiance over an equirectangular grid of texels
/// (rows equal in polar angle θ, columns in azimuth), each texel a combination of a
/// few channel spectra. Sampled by texel (weight ∝ luminance × solid angle), then
/// uniformly in (azimuth, cos θ) inside it, so the pdf is constant per texel.
#[derive(Debug, Clone)]
struct RadianceMap {
    width: usize,
    height: usize,
    /// cos θ at the row boundaries, from 1 (zenith) to −1.
    row_cos: Vec<f64>,
    channels: Vec<Vec<f32>>,
    /// Per texel, its coefficients and density together (16 bytes, aligned: a
    /// look-up of a map far larger than the caches, an image map of 1024 × 512
    /// texels, reads one cache line).
    texels: Vec<Texel>,
    /// Per texel, its entry of its row's alias table (8 bytes), apart from
    /// `texels`: a light sample reads the entry of the column it lands on, and
    /// the record of the texel it takes; in an array of a third of the size,
    /// the rows the samples favour stay in the caches.
    columns: Vec<ColumnAlias>,
    rows: Distribution1D,
    /// Sum of all texel weights.
    total_weight: f64,
}

/// One texel of a [`RadianceMap`].
#[derive(Debug, Clone, Copy, Default)]
#[repr(align(16))]
struct Texel {
    /// One coefficient per channel (at most [`MAX_MAP_CHANNELS`]; unused ones 0).
    coeffs: [f32; MAX_MAP_CHANNELS],
    /// The map's sampling density in the texel, per unit solid angle:
    /// P(row) × P(column | row) / the texel's solid angle.
    pdf: f32,
}

// One record per cache-line quarter: a look-up never straddles two lines.
const _: () = assert!(std::mem::size_of::<Texel>() == 16);

/// A column's entry in its row's alias table: the probability that a draw
/// landing on this column keeps it, else it takes `alias` (a column of the same
/// row).
#[derive(Debug, Clone, Copy, Default)]
struct ColumnAlias {
    keep: f32,
    alias: u32,
}

/// Channels (basis spectra) a map's texels combine: 3 for an RGB image.
const MAX_MAP_CHANNELS: usize = 3;

impl RadianceMap {
    /// The texel (row-major index) holding `q`: row r holds cos θ in
    /// (row_cos[r + 1], row_cos[r]] (the same rows as ⌊θ/π · height⌋, found by
    /// comparing cos θ with the row boundaries instead of an `acos`), the column
    /// from the azimuth (no `atan2` for a map one texel wide).
    fn texel(&self, q: &mut Query) -> usize {
        let y = q.d[1].clamp(-1.0, 1.0);
        // A first guess from a cheap arccosine (error below 1e-4 rad, a row is
        // π/height wide), then the exact boundaries decide.
        let guess = (acos_approx(y) * (self.height as f64 / PI)) as usize;
        let mut row = guess.min(self.height - 1);
        while row > 0 && y > self.row_cos[row] {
            row -= 1;
        }
        while row + 1 < self.height && y <= self.row_cos[row + 1] {
            row += 1;
        }
        let col = if self.width == 1 {
            0
        } else {
            self.column_without_atan2(q).unwrap_or_else(|| {
                let u = 0.5 - q.azimuth() / (2.0 * PI);
                ((u * self.width as f64) as usize).min(self.width - 1)
            })
        };
        row * self.width + col
    }

    /// The column of `q` as [`Self::texel`] finds it from the exact azimuth, found
    /// from a polynomial arctangent (error below 2e-8 rad) where the azimuth is
    /// more than [`AZIMUTH_SLACK`] inside a column; `None` near a column edge (and
    /// at the poles), where only the exact `atan2` decides. An escape's look-up
    /// then costs no `atan2` but in a few cases in 10⁴.
    fn column_without_atan2(&self, q: &Query) -> Option<usize> {
        if q.azimuth.is_some() {
            return None;
        }
        let azimuth = atan2_approx(q.d[0], q.d[2])?;
        let scale = self.width as f64 / (2.0 * PI);
        let x = (0.5 - azimuth / (2.0 * PI)) * self.width as f64;
        let col = x.floor();
        let slack = AZIMUTH_SLACK * scale;
        let inside = x - col > slack && col + 1.0 - x > slack;
        (inside && col >= 0.0 && col < self.width as f64).then_some(col as usize)
    }

    fn add_radiance(&self, texel: usize, out: &mut [f32]) {
        let coeffs = self.texels[texel].coeffs;
        match &self.channels[..] {
            // Image maps: three bases, one pass over the spectrum.
            [a, b, c] => {
                let [ca, cb, cc] = coeffs;
                for (((o, a), b), c) in out.iter_mut().zip(a).zip(b).zip(c) {
                    *o += ca * a + cb * b + cc * c;
                }
            }
            channels => {
                for (channel, &c) in channels.iter().zip(&coeffs) {
                    if c != 0.0 {
                        for (o, s) in out.iter_mut().zip(channel) {
                            *o += c * s;
                        }
                    }
                }
            }
        }
    }

    /// Density of the map's own sampling at a direction in `texel`, per unit solid
    /// angle.
    fn pdf(&self, texel: usize) -> f64 {
        f64::from(self.texels[texel].pdf)
    }

    /// The part of a sample the numbers decide alone (the row by its cdf, the
    /// column u lands on); `None` if the map has no light.
    fn begin_sample(&self, rows: &Distribution1D, u: [f64; 2]) -> Option<MapDraw> {
        if self.total_weight <= 0.0 || rows.total() <= 0.0 {
            return None;
        }
        let (row, v) = rows.sample(u[0]);
        let x = u[1] * self.width as f64;
        let first = (x as usize).min(self.width - 1);
        let frac = (x - first as f64).clamp(0.0, ONE_BELOW);
        Some(MapDraw {
            row,
            v,
            first,
            frac,
        })
    }

    /// Whether a direction `q` (the f32 rounding of the one drawn as `drawn`) is
    /// certainly in the drawn texel, so that [`Self::texel`] would return it. The
    /// row is checked exactly, against the same boundaries `texel` compares with.
    /// The column is not looked up: rounding each coordinate of a direction to f32
    /// turns its azimuth by at most √2·2⁻²⁴ rad (≈ 8.4e-8, whatever the distance
    /// from the pole, since x and z round relative to themselves), and the f64
    /// `sin_cos`, normalisation and `atan2` add errors near 1e-15; a drawn azimuth
    /// [`AZIMUTH_SLACK`] or more inside its column stays there. Rows of texels
    /// that close to a column edge (a few in 10⁴ draws) answer `false`.
    fn surely_holds(&self, drawn: &DrawnTexel, q: &Query) -> bool {
        let row = drawn.texel / self.width;
        let y = q.d[1].clamp(-1.0, 1.0);
        let in_row = (row == 0 || y <= self.row_cos[row])
            && (row + 1 == self.height || y > self.row_cos[row + 1]);
        // At a pole (x = z = 0) the azimuth is atan2's convention, not the drawn one.
        let off_pole = q.d[0] != 0.0 || q.d[2] != 0.0;
        let in_column = self.width == 1
            || drawn.within_column.min(1.0 - drawn.within_column) * (2.0 * PI / self.width as f64)
                > AZIMUTH_SLACK;
        in_row && off_pole && in_column
    }

    /// [`Self::surely_holds`] before the direction is normalised: `d` is the
    /// drawn direction (unit, f64) and `dir` its f32 rounding. Rounding each
    /// coordinate to f32 and normalising again moves y by at most
    /// |y|·(2·2⁻²⁴ + 1e-15) < 1.3e-7 (each coordinate gains a factor 1 ± 2⁻²⁴, the
    /// length as well), so a y [`ROW_SLACK`] or more inside the drawn row stays in
    /// it. `false` where only the exact test can tell (y near a row boundary, and
    /// everywhere [`Self::surely_holds`] answers `false` for the column or pole).
    fn surely_holds_unrounded(&self, drawn: &DrawnTexel, d: [f64; 3], dir: [f32; 3]) -> bool {
        let row = drawn.texel / self.width;
        let y = d[1];
        let in_row = (row == 0 || y <= self.row_cos[row] - ROW_SLACK)
            && (row + 1 == self.height || y > self.row_cos[row + 1] + ROW_SLACK);
        // Zero stays zero and non-zero non-zero under normalisation.
        let off_pole = dir[0] != 0.0 || dir[2] != 0.0;
        let in_column = self.width == 1
            || drawn.within_column.min(1.0 - drawn.within_column) * (2.0 * PI / self.width as f64)
                > AZIMUTH_SLACK;
        in_row && off_pole && in_column
    }

    /// The direction of a sample begun by [`Self::begin_sample`] (f64, and
    /// rounded to f32 as [`direction_from_azimuth_y`] would give it), and the
    /// texel it was drawn in.
    fn finish_sample(&self, draw: MapDraw) -> ([f64; 3], [f32; 3], DrawnTexel) {
        let MapDraw {
            row,
            v,
            first,
            frac,
        } = draw;
        // The column by the row's alias table (Walker; Vose's construction): u's
        // column, kept with its texel's probability, else its alias; what is left
        // of u places the direction inside the texel.
        let column = &self.columns[row * self.width + first];
        let keep = f64::from(column.keep);
        let (col, w) = if frac < keep {
            (first, frac / keep)
        } else {
            (column.alias as usize, (frac - keep) / (1.0 - keep))
        };
        let w = w.clamp(0.0, ONE_BELOW);
        let y = self.row_cos[row] + v * (self.row_cos[row + 1] - self.row_cos[row]);
        let azimuth = azimuth_of_column(col as f64 + w, self.width);
        let drawn = DrawnTexel {
            texel: row * self.width + col,
            within_column: w,
        };
        let (d, dir) = direction_from_azimuth_y_f32(azimuth, y);
        (d, dir, drawn)
    }
}

/// The least mean cosine an emitter is given in [`FacingUpSampling`].
const MIN_PATCH_MEAN_UP: f64 = 1e-3;

/// Light sampling for a surface facing straight up ([`Environment::sample_for`]):
/// the same emitters and texels, each emitter's and each map row's weight times
/// its mean max(y, 0) (cos θ to the vertical, 0 below the horizon).
#[derive(Debug, Clone)]
struct FacingUpSampling {
    /// Selection of a component: the patches in order, then the map.
    components: Distribution1D,
    /// Selection of the map's row.
    rows: Distribution1D,
    /// Per map row: its probability here over its probability in the map's own
    /// sampling (the texel densities scale by it; 0 below the horizon).
    row_factor: Vec<f32>,
}

impl FacingUpSampling {
    /// From the map's row weights and boundaries and the components' weights
    /// (patches, then the map); `None` when nothing above the horizon has weight.
    fn new(
        row_weights: &[f64],
        row_cos: &[f64],
        rows: &Distribution1D,
        patches: &[Patch],
        component_weights: &[f64],
    ) -> Option<Self> {
        // Mean of max(y, 0) over a row, y uniform between its boundaries.
        let mean_up = |top: f64, bottom: f64| {
            if bottom >= 0.0 {
                0.5 * (top + bottom)
            } else if top <= 0.0 {
                0.0
            } else {
                0.5 * top * top / (top - bottom)
            }
        };
        let up_row_weights: Vec<f64> = row_weights
            .iter()
            .enumerate()
            .map(|(r, w)| w.max(0.0) * mean_up(row_cos[r], row_cos[r + 1]))
            .collect();
        let up_rows = Distribution1D::new(&up_row_weights);
        let row_factor = (0..row_weights.len())
            .map(|r| {
                let p = rows.probability(r);
                if p > 0.0 {
                    (up_rows.probability(r) / p) as f32
                } else {
                    0.0
                }
            })
            .collect();
        let map_total = rows.total();
        let mut up_components: Vec<f64> = patches
            .iter()
            .zip(component_weights)
            // The mean cosine, at least 1e-3: the cap's formula is exact only for
            // a cap wholly above the horizon, and a density of 0 over any part of
            // an emitter that lights the floor would lose that light (the floor's
            // escapes count nothing).
            .map(|(patch, w)| {
                w * (patch.shape.cosine_integral() / patch.solid_angle).max(MIN_PATCH_MEAN_UP)
            })
            .collect();
        up_components.push(if map_total > 0.0 {
            component_weights[patches.len()] * up_rows.total() / map_total
        } else {
            0.0
        });
        let components = Distribution1D::new(&up_components);
        (components.total() > 0.0).then_some(Self {
            components,
            rows: up_rows,
            row_factor,
        })
    }
}

/// The texel a map sample was drawn in, and where within its column (in [0, 1)).
#[derive(Debug, Clone, Copy)]
struct DrawnTexel {
    texel: usize,
    within_column: f64,
}

/// How far inside its column (radians of azimuth) a drawn direction must be for
/// its texel to be taken without a look-up: 12× the most that rounding the
/// direction to f32 can turn it ([`RadianceMap::surely_holds`]).
const AZIMUTH_SLACK: f64 = 1e-6;

/// How far inside its row (in cos θ) a drawn direction must be for its row to be
/// taken before the direction is rounded and normalised: 8× the most that can
/// move it ([`RadianceMap::surely_holds_unrounded`]).
const ROW_SLACK: f64 = 1e-6;

/// Guide entries per index of a [`Distribution1D`]: a target's part holds on
/// average 1/this of the cdf's steps whatever the weights (the parts are equal
/// in weight, so they are hit as often as the steps lie in them), so the search
/// from the guide's entry takes a step in 1 of 4 draws instead of 1 of 1.
const GUIDE_PARTS_PER_INDEX: usize = 4;

/// A discrete distribution with continuous inversion: `sample(u)` gives the index
/// and where u fell within its share, in [0, 1).
#[derive(Debug, Clone)]
struct Distribution1D {
    /// cdf[i] = sum of the first i weights; cdf[n] = total.
    cdf: Vec<f64>,
    /// Guide table (Chen & Asau's cut-point method): entry j is the index where
    /// the search for a target in the j-th of `guide.len()` equal parts of
    /// [0, total) starts, so a sample costs a step or two instead of a binary
    /// search through a cdf that is not in cache. The search from there gives
    /// exactly the binary search's answer.
    guide: Vec<u32>,
    /// `guide.len() / total` (0 for an empty distribution): a target's part by a
    /// multiplication instead of a division on the way to the guide's entry. It
    /// only chooses where the search starts, so its rounding never changes the
    /// answer.
    parts_per_weight: f64,
    /// `probability(i)` for every index, computed once with the same expression.
    probabilities: Vec<f64>,
}

impl Distribution1D {
    fn new(weights: &[f64]) -> Self {
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        let mut sum = 0.0;
        cdf.push(0.0);
        for &w in weights {
            sum += w.max(0.0);
            cdf.push(sum);
        }
        let parts = weights.len().max(1) * GUIDE_PARTS_PER_INDEX;
        let guide = (0..parts)
            .map(|j| {
                let target = j as f64 / parts as f64 * sum;
                cdf.partition_point(|&c| c <= target) as u32
            })
            .collect();
        let parts_per_weight = if sum > 0.0 { parts as f64 / sum } else { 0.0 };
        let probabilities = cdf
            .windows(2)
            .map(|c| if sum > 0.0 { (c[1] - c[0]) / sum } else { 0.0 })
            .collect();
        Self {
            cdf,
            guide,
            parts_per_weight,
            probabilities,
        }
    }

    fn total(&self) -> f64 {
        self.cdf[self.cdf.len() - 1]
    }

    fn probability(&self, i: usize) -> f64 {
        self.probabilities[i]
    }

    /// The first index p with cdf[p] > target (`cdf.len()` if none): what
    /// `cdf.partition_point(|&c| c <= target)` returns, started from the guide.
    fn upper_bound(&self, target: f64) -> usize {
        // A negative or NaN product converts to 0; any part is a valid start.
        let part = ((target * self.parts_per_weight) as usize).min(self.guide.len() - 1);
        let mut p = self.guide[part] as usize;
        // The cdf is non-decreasing, so walking to the boundary from any start
        // ends where the binary search does.
        while p > 0 && self.cdf[p - 1] > target {
            p -= 1;
        }
        while p < self.cdf.len() && self.cdf[p] <= target {
            p += 1;
        }
        p
    }

    fn sample(&self, u: f64) -> (usize, f64) {
        let n = self.cdf.len() - 1;
        let target = u.clamp(0.0, ONE_BELOW) * self.total();
        // One index (an environment that is only a map): no search, the same
        // answer (`upper_bound(target).max(1) - 1` clamped to 0).
        let mut i = if n == 1 {
            0
        } else {
            (self.upper_bound(target).max(1) - 1).min(n - 1)
        };
        // Never land on an empty bin (possible only at the very top).
        while i > 0 && self.cdf[i + 1] <= self.cdf[i] {
            i -= 1;
        }
        let width = self.cdf[i + 1] - self.cdf[i];
        let frac = if width > 0.0 {
            ((target - self.cdf[i]) / width).clamp(0.0, ONE_BELOW)
        } else {
            0.5
        };
        (i, frac)
    }
}

/// Walker's alias table of `weights` (Vose's construction, in f64): per index, the
/// probability of keeping it and the index that takes the rest. Index i is drawn
/// with probability (keep_i + Σ_{j: alias_j = i} (1 − keep_j)) / n = w_i / Σw.
/// Negative weights count as 0; all-zero weights give the uniform table.
fn alias_table(weights: &[f64]) -> Vec<(f32, u32)> {
    let n = weights.len();
    let total: f64 = weights.iter().map(|w| w.max(0.0)).sum();
    let mut scaled: Vec<f64> = if total > 0.0 {
        weights
            .iter()
            .map(|w| w.max(0.0) * n as f64 / total)
            .collect()
    } else {
        vec![1.0; n]
    };
    let mut table: Vec<(f32, u32)> = (0..n as u32).map(|i| (1.0, i)).collect();
    let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
    while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
        small.pop();
        table[s] = (scaled[s] as f32, l as u32);
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // What is left holds 1 up to rounding: kept always.
    table
}

/// Assembles an environment in arbitrary units, then normalises it.
struct Builder {
    radiance_channels: Channels,
    channels: Vec<Vec<f32>>,
    channel_luminance: Vec<f64>,
    luminance_weights: Vec<f32>,
    width: usize,
    height: usize,
    row_cos: Vec<f64>,
    coeffs: Vec<f32>,
    /// (shape, channel, coefficient).
    patches: Vec<(Shape, usize, f64)>,
}

impl Builder {
    fn new(
        radiance_channels: &Channels,
        channels: Vec<Vec<f32>>,
        width: usize,
        height: usize,
    ) -> Self {
        assert!(
            (1..=MAX_MAP_CHANNELS).contains(&channels.len()),
            "a map combines 1 to {MAX_MAP_CHANNELS} channel spectra"
        );
        let luminance_weights = luminance_weights(radiance_channels);
        let channel_luminance = channels
            .iter()
            .map(|c| f64::from(dot_f32(&luminance_weights, c)))
            .collect();
        // The horizon exactly 0 (cos(π/2) rounds to 6e-17), so no row sits above it
        // by rounding.
        let row_cos = (0..=height)
            .map(|r| {
                if 2 * r == height {
                    0.0
                } else {
                    (PI * r as f64 / height as f64).cos()
                }
            })
            .collect();
        let coeffs = vec![0.0; width * height * channels.len()];
        Self {
            radiance_channels: *radiance_channels,
            channels,
            channel_luminance,
            luminance_weights,
            width,
            height,
            row_cos,
            coeffs,
            patches: Vec::new(),
        }
    }

    /// Horizontal irradiance from the upper hemisphere, per channel (coefficient
    /// units).
    fn channel_irradiance(&self) -> Vec<f64> {
        let n = self.channels.len();
        let mut e = vec![0.0; n];
        for row in 0..self.height {
            let (y0, y1) = (self.row_cos[row + 1].max(0.0), self.row_cos[row].max(0.0));
            let cos_integral = 2.0 * PI / self.width as f64 * 0.5 * (y1 * y1 - y0 * y0);
            if cos_integral <= 0.0 {
                continue;
            }
            for col in 0..self.width {
                let texel = row * self.width + col;
                for (c, e) in e.iter_mut().enumerate() {
                    *e += f64::from(self.coeffs[texel * n + c]) * cos_integral;
                }
            }
        }
        for (shape, channel, coefficient) in &self.patches {
            e[*channel] += coefficient * shape.cosine_integral();
        }
        e
    }

    /// Normalises to horizontal illuminance π, fills the rows wholly below the
    /// horizon with the floor's radiance when `fill_ground`, and builds the
    /// sampling tables. `None` if the upper hemisphere is black.
    fn finish(
        mut self,
        kind: EnvironmentKind,
        floor_reflectance: f32,
        fill_ground: bool,
    ) -> Option<Environment> {
        let n = self.channels.len();
        let irradiance = self.channel_irradiance();
        let illuminance: f64 = irradiance
            .iter()
            .zip(&self.channel_luminance)
            .map(|(e, l)| e * l)
            .sum();
        if !(illuminance > 0.0 && illuminance.is_finite()) {
            return None;
        }
        let scale = PI / illuminance;
        for c in &mut self.coeffs {
            *c = (f64::from(*c) * scale) as f32;
        }
        if fill_ground {
            // A Lambertian floor of reflectance ρ under irradiance E has radiance ρE/π.
            let ground: Vec<f32> = irradiance
                .iter()
                .map(|e| (f64::from(floor_reflectance) * e * scale / PI) as f32)
                .collect();
            for row in (0..self.height).filter(|&r| self.row_cos[r] <= 0.0) {
                for col in 0..self.width {
                    let texel = row * self.width + col;
                    self.coeffs[texel * n..(texel + 1) * n].copy_from_slice(&ground);
                }
            }
        }
        // Texel weights: (luminance + a little of the peak) × solid angle.
        let mut row_weights = vec![0.0; self.height];
        let mut column_weights = Vec::with_capacity(self.height);
        let mut texel_spectrum = vec![0.0f32; self.radiance_channels.len()];
        for (row, row_weight) in row_weights.iter_mut().enumerate() {
            let solid_angle =
                2.0 * PI / self.width as f64 * (self.row_cos[row] - self.row_cos[row + 1]);
            let ground = if self.row_cos[row] <= 0.0 {
                GROUND_SAMPLING_WEIGHT
            } else {
                1.0
            };
            let weights: Vec<f64> = (0..self.width)
                .map(|col| {
                    let texel = row * self.width + col;
                    texel_spectrum.fill(0.0);
                    for (channel, &c) in self.channels.iter().zip(&self.coeffs[texel * n..]) {
                        for (o, s) in texel_spectrum.iter_mut().zip(channel) {
                            *o += c * s;
                        }
                    }
                    let luminance = f64::from(dot_f32(&self.luminance_weights, &texel_spectrum));
                    let peak = texel_spectrum.iter().fold(0.0f32, |a, &b| a.max(b));
                    (luminance.max(0.0) + MAX_VALUE_SAMPLING_WEIGHT * f64::from(peak))
                        * solid_angle
                        * ground
                })
                .collect();
            *row_weight = weights.iter().map(|w| w.max(0.0)).sum();
            column_weights.push(weights);
        }
        let rows = Distribution1D::new(&row_weights);
        let total_weight = rows.total();
        let row_cos_for_up = self.row_cos.clone();
        let mut texels = vec![Texel::default(); self.width * self.height];
        let mut columns = vec![ColumnAlias::default(); self.width * self.height];
        for (row, weights) in column_weights.iter().enumerate() {
            let texels = &mut texels[row * self.width..(row + 1) * self.width];
            let solid_angle =
                2.0 * PI / self.width as f64 * (self.row_cos[row] - self.row_cos[row + 1]);
            let row_probability = if total_weight > 0.0 {
                rows.probability(row)
            } else {
                0.0
            };
            let row_weight = row_weights[row];
            for (col, (texel, &weight)) in texels.iter_mut().zip(weights).enumerate() {
                let texel_index = row * self.width + col;
                texel.coeffs[..n]
                    .copy_from_slice(&self.coeffs[texel_index * n..(texel_index + 1) * n]);
                if row_weight > 0.0 {
                    texel.pdf =
                        (row_probability * weight.max(0.0) / row_weight / solid_angle) as f32;
                }
            }
            let columns = &mut columns[row * self.width..(row + 1) * self.width];
            for (column, (keep, alias)) in columns.iter_mut().zip(alias_table(weights)) {
                column.keep = keep;
                column.alias = alias;
            }
        }
        let map = RadianceMap {
            width: self.width,
            height: self.height,
            row_cos: self.row_cos,
            channels: self.channels,
            texels,
            columns,
            rows,
            total_weight,
        };
        // Emitters by power: luminance (plus a little of the peak) × solid angle.
        let mut component_weights = Vec::with_capacity(self.patches.len() + 1);
        let mut patches = Vec::with_capacity(self.patches.len());
        for (shape, channel, coefficient) in self.patches {
            let radiance: Vec<f32> = map.channels[channel]
                .iter()
                .map(|&s| (f64::from(s) * coefficient * scale) as f32)
                .collect();
            let luminance = f64::from(dot_f32(&self.luminance_weights, &radiance));
            let peak = radiance.iter().fold(0.0f32, |a, &b| a.max(b));
            let solid_angle = shape.solid_angle();
            component_weights
                .push((luminance + MAX_VALUE_SAMPLING_WEIGHT * f64::from(peak)) * solid_angle);
            patches.push(Patch {
                shape,
                solid_angle,
                radiance,
            });
        }
        component_weights.push(total_weight);
        let facing_up = FacingUpSampling::new(
            &row_weights,
            &row_cos_for_up,
            &map.rows,
            &patches,
            &component_weights,
        );
        Some(Environment {
            kind,
            channels: self.radiance_channels,
            luminance_weights: self.luminance_weights,
            patches,
            map,
            components: Distribution1D::new(&component_weights),
            facing_up,
            floor: Some(Floor {
                reflectance: vec![floor_reflectance; self.radiance_channels.len()],
            }),
            sun_dir: None,
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

/// Luminance weights on `channels`. On a grid: CIE 1931 ȳ at 1 nm over [`VISIBLE`]
/// (or the grid's span if wider), split between the two grid samples around each
/// wavelength (linear-interpolation hats, the end hats extended), normalised to sum
/// 1. On linear sRGB: the sRGB luminance row.
pub fn luminance_weights(channels: &(impl Into<Channels> + Copy)) -> Vec<f32> {
    let grid = match (*channels).into() {
        Channels::Spectral(grid) => grid,
        Channels::LinearSrgb => return crate::colour::SRGB_LUMINANCE.to_vec(),
    };
    let n = grid.len();
    let mut w = vec![0.0f64; n];
    let first = VISIBLE.start_nm.min(grid.start_nm()).floor() as i32;
    let last = VISIBLE.end_nm.max(grid.end_nm()).ceil() as i32;
    for nm in first..=last {
        let l = f64::from(nm);
        let y = Observer::Cie1931TwoDegree.cmf_at_nm(l)[1];
        let position = (l - grid.start_nm()) / grid.step_nm();
        if n == 1 || position <= 0.0 {
            w[0] += y;
        } else if position >= (n - 1) as f64 {
            w[n - 1] += y;
        } else {
            let i = position.floor() as usize;
            let t = position - i as f64;
            w[i] += y * (1.0 - t);
            w[i + 1] += y * t;
        }
    }
    let sum: f64 = w.iter().sum();
    w.into_iter().map(|v| (v / sum) as f32).collect()
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

/// arccos(x) for x in [−1, 1] within 7e-5 rad (Abramowitz & Stegun 4.4.45): only a
/// first guess of a map row, which the row boundaries then correct.
fn acos_approx(x: f64) -> f64 {
    let a = x.abs();
    let r = (1.0 - a).max(0.0).sqrt()
        * (1.570_728_8 + a * (-0.212_114_4 + a * (0.074_261_0 - a * 0.018_729_3)));
    if x < 0.0 { PI - r } else { r }
}

/// atan2(y, x) in [−π, π] within 2e-8 rad plus rounding (the arctangent on
/// [0, 1] by Abramowitz & Stegun 4.4.49, |ε| ≤ 2e-8, then the octant); `None`
/// for (0, 0), whose angle depends on the zeros' signs. Near ±π it may answer
/// the other end of the range, which is a column edge for every map width.
fn atan2_approx(y: f64, x: f64) -> Option<f64> {
    const A: [f64; 8] = [
        -0.333_331_452_8,
        0.199_935_508_5,
        -0.142_088_994_4,
        0.106_562_639_3,
        -0.075_289_640_0,
        0.042_909_613_8,
        -0.016_165_736_7,
        0.002_866_225_7,
    ];
    let (ay, ax) = (y.abs(), x.abs());
    let (num, den) = if ay > ax { (ax, ay) } else { (ay, ax) };
    if den == 0.0 {
        return None;
    }
    let t = num / den;
    let t2 = t * t;
    let poly = A.iter().rev().fold(0.0, |acc, &a| acc * t2 + a);
    let mut angle = t + t * t2 * poly;
    if ay > ax {
        angle = FRAC_PI_2 - angle;
    }
    if x < 0.0 {
        angle = PI - angle;
    }
    Some(if y < 0.0 { -angle } else { angle })
}

fn azimuth_of_column(column: f64, width: usize) -> f64 {
    (0.5 - column / width as f64) * 2.0 * PI
}

fn direction_from_azimuth_y(azimuth: f64, y: f64) -> [f64; 3] {
    let y = y.clamp(-1.0, 1.0);
    let r = (1.0 - y * y).max(0.0).sqrt();
    let (s, c) = azimuth.sin_cos();
    [r * s, y, r * c]
}

/// [`direction_from_azimuth_y`] and its rounding to f32, that rounding always
/// the exact one's: the sine and cosine by [`sin_cos_fast`] (no libm call),
/// within [`SIN_COS_MARGIN`] of libm's after the product with r, taken where
/// every number within that margin rounds to the same f32; else (about one
/// coordinate in 10⁷, and more where x or z is tiny) libm's `sin_cos`. The f64
/// direction returned is then off the exact one's by at most the margin.
fn direction_from_azimuth_y_f32(azimuth: f64, y: f64) -> ([f64; 3], [f32; 3]) {
    let y = y.clamp(-1.0, 1.0);
    let r = (1.0 - y * y).max(0.0).sqrt();
    let (s, c) = sin_cos_fast(azimuth);
    let (x, z) = (r * s, r * c);
    let rounds_alike = |v: f64| (v - SIN_COS_MARGIN) as f32 == (v + SIN_COS_MARGIN) as f32;
    if rounds_alike(x) && rounds_alike(z) {
        ([x, y, z], [x as f32, y as f32, z as f32])
    } else {
        let d = direction_from_azimuth_y(azimuth, y);
        (d, d.map(|v| v as f32))
    }
}

/// A bound on |r·s − r·s_libm| (and for c) in [`direction_from_azimuth_y_f32`],
/// with a factor 4 to spare: [`sin_cos_fast`] is within 1e-15 of libm's (the
/// test's largest difference over 10⁶ azimuths and the quadrant edges is one
/// ulp, 2.2e-16), and each product adds half an ulp (1.1e-16).
const SIN_COS_MARGIN: f64 = 4e-15;

/// sin and cos of `a` for |a| ≤ 4 (an azimuth in [−π, π]) by a quadrant
/// reduction (π/2 in two parts, Cody & Waite: the first has 33 bits, so k·it and
/// the subtraction are exact) and fdlibm's minimax polynomials on [−π/4, π/4]
/// (`__kernel_sin`, `__kernel_cos`: |ε| < 2⁻⁵⁸ before rounding).
fn sin_cos_fast(a: f64) -> (f64, f64) {
    const PIO2_HI: f64 = 1.570_796_326_734_125_6;
    const PIO2_LO: f64 = 6.077_100_506_506_192e-11;
    const S: [f64; 6] = [
        -0.166_666_666_666_666_32,
        0.008_333_333_333_322_49,
        -0.000_198_412_698_298_579_5,
        2.755_731_370_707_006_8e-6,
        -2.505_076_025_340_686_3e-8,
        1.589_690_995_211_55e-10,
    ];
    const C: [f64; 6] = [
        0.041_666_666_666_666_6,
        -0.001_388_888_888_887_411,
        2.480_158_728_947_673e-5,
        -2.755_731_435_139_066_3e-7,
        2.087_572_321_298_175e-9,
        -1.135_964_755_778_819_5e-11,
    ];
    let k = (a * std::f64::consts::FRAC_2_PI).round_ties_even();
    let r = (a - k * PIO2_HI) - k * PIO2_LO;
    let z = r * r;
    let ps = S.iter().rev().fold(0.0, |acc, &c| acc * z + c);
    let pc = C.iter().rev().fold(0.0, |acc, &c| acc * z + c);
    let sin_r = r + r * z * ps;
    let cos_r = 1.0 - 0.5 * z + z * z * pc;
    match (k as i64).rem_euclid(4) {
        0 => (sin_r, cos_r),
        1 => (cos_r, -sin_r),
        2 => (-sin_r, -cos_r),
        _ => (-cos_r, sin_r),
    }
}

fn direction_from_azimuth_elevation(azimuth: f64, elevation: f64) -> [f64; 3] {
    direction_from_azimuth_y(azimuth, elevation.sin())
}

fn normalised(d: [f32; 3]) -> Option<[f64; 3]> {
    let d = d.map(f64::from);
    let len = dot(d, d).sqrt();
    (len > 0.0 && len.is_finite()).then(|| d.map(|v| v / len))
}

fn normalise(d: [f64; 3]) -> [f64; 3] {
    let len = dot(d, d).sqrt();
    d.map(|v| v / len)
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot_f32(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator for the tests (SplitMix64).
    fn uniform(state: &mut u64) -> f64 {
        *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = *state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn the_guided_search_answers_as_the_binary_search_does() {
        let mut state = 1;
        // Uneven weights with empty bins, runs of them and a single heavy bin.
        let weights: Vec<f64> = (0..1000)
            .map(|i| match i % 7 {
                0 | 1 => 0.0,
                2 => 50.0 * uniform(&mut state),
                _ => uniform(&mut state),
            })
            .collect();
        for w in [
            &weights[..],
            &[0.0, 0.0, 3.0][..],
            &[1.0][..],
            &[0.0, 1.0, 0.0][..],
        ] {
            let d = Distribution1D::new(w);
            let total = d.total();
            let mut targets: Vec<f64> = (0..20_000).map(|_| uniform(&mut state) * total).collect();
            // Exactly on the cdf's steps, and the ends.
            targets.extend(d.cdf.iter().copied());
            targets.extend([0.0, total, total * ONE_BELOW]);
            for t in targets {
                assert_eq!(
                    d.upper_bound(t),
                    d.cdf.partition_point(|&c| c <= t),
                    "target {t} of total {total}"
                );
            }
        }
    }

    /// `sample` (guided search, one-index shortcut, probabilities computed once)
    /// gives the index and fraction of the plain inversion by binary search, bit
    /// for bit, for random numbers, 0, the largest below 1 and numbers whose
    /// targets fall at and next to every step of the cdf.
    #[test]
    fn samples_are_the_plain_cdf_inversion() {
        let mut state = 3;
        let weights: Vec<f64> = (0..700)
            .map(|i| match i % 5 {
                0 => 0.0,
                1 => 1e3 * uniform(&mut state).powi(6),
                _ => uniform(&mut state),
            })
            .collect();
        for w in [
            &weights[..],
            &[2.5][..],
            &[0.0][..],
            &[0.0, 0.0, 3.0][..],
            &[1.0, 0.0][..],
            &[1e-300, 1.0, 1e300][..],
        ] {
            let d = Distribution1D::new(w);
            let total = d.total();
            let n = w.len();
            let plain = |u: f64| -> (usize, f64) {
                let target = u.clamp(0.0, ONE_BELOW) * total;
                let mut i = (d.cdf.partition_point(|&c| c <= target).max(1) - 1).min(n - 1);
                while i > 0 && d.cdf[i + 1] <= d.cdf[i] {
                    i -= 1;
                }
                let width = d.cdf[i + 1] - d.cdf[i];
                let frac = if width > 0.0 {
                    ((target - d.cdf[i]) / width).clamp(0.0, ONE_BELOW)
                } else {
                    0.5
                };
                (i, frac)
            };
            let mut us: Vec<f64> = (0..20_000).map(|_| uniform(&mut state)).collect();
            us.extend([0.0, ONE_BELOW, 1.0, -0.5, 2.0]);
            if total > 0.0 {
                for &c in &d.cdf {
                    let u = c / total;
                    us.extend([u, u.next_up(), u.next_down(), u + 1e-12, u - 1e-12]);
                }
            }
            for u in us {
                let (i, frac) = d.sample(u);
                let (j, want) = plain(u);
                assert_eq!((i, frac.to_bits()), (j, want.to_bits()), "u {u} of {n}");
            }
            for i in 0..n {
                let want = if total > 0.0 {
                    (d.cdf[i + 1] - d.cdf[i]) / total
                } else {
                    0.0
                };
                assert_eq!(d.probability(i).to_bits(), want.to_bits());
            }
        }
    }

    #[test]
    fn texels_found_without_acos_are_those_of_the_polar_angle() {
        let map = Environment::outdoor(&WavelengthGrid::new(380.0, 50.0, 9).unwrap()).map;
        let mut state = 7;
        let mut agree = 0;
        let n = 200_000;
        for _ in 0..n {
            let y = 2.0 * uniform(&mut state) - 1.0;
            let a = (2.0 * uniform(&mut state) - 1.0) * PI;
            let d = direction_from_azimuth_y(a, y);
            let theta = d[1].clamp(-1.0, 1.0).acos();
            let row = ((theta / PI * map.height as f64) as usize).min(map.height - 1);
            let u = 0.5 - d[0].atan2(d[2]) / (2.0 * PI);
            let col = ((u * map.width as f64) as usize).min(map.width - 1);
            let texel = map.texel(&mut Query::new(d));
            // Only a direction within rounding of a row boundary may differ.
            if texel == row * map.width + col {
                agree += 1;
            } else {
                let found = texel / map.width;
                assert!(found.abs_diff(row) == 1, "row {found} for {row}");
                let boundary = map.row_cos[found.max(row)];
                assert!(
                    (d[1] - boundary).abs() < 1e-12,
                    "y {} boundary {boundary}",
                    d[1]
                );
            }
        }
        assert!(agree >= n - 2, "{agree} of {n}");
        // Poles, horizon, row boundaries themselves.
        for (r, &c) in map.row_cos.iter().enumerate() {
            let t = map.texel(&mut Query::new(direction_from_azimuth_y(0.3, c)));
            assert_eq!(t / map.width, r.min(map.height - 1), "boundary {r}");
        }
    }
    /// The polynomial arctangent stays within its stated error in every octant.
    #[test]
    fn approximate_atan2_is_within_2e_8_rad() {
        let mut state = 3;
        let mut worst = 0.0f64;
        for _ in 0..200_000 {
            let a = (2.0 * uniform(&mut state) - 1.0) * PI;
            let r = 10f64.powf(6.0 * uniform(&mut state) - 3.0);
            let (y, x) = (r * a.sin(), r * a.cos());
            let exact = y.atan2(x);
            let approx = atan2_approx(y, x).unwrap();
            // Near ±π the two may name the two ends of the range.
            let diff = (approx - exact).abs();
            worst = worst.max(diff.min((diff - 2.0 * PI).abs()));
        }
        assert!(worst < 2e-8, "worst error {worst:e} rad");
        assert_eq!(atan2_approx(0.0, -0.0), None);
        assert_eq!(atan2_approx(1.0, 0.0), Some(FRAC_PI_2));
    }

    /// Columns found without `atan2` are the ones `atan2` gives, on a map as wide
    /// as the side-by-side's, for random directions and for directions at and
    /// near every kind of column edge (including ±π and the poles).
    #[test]
    fn columns_found_without_atan2_are_those_of_atan2() {
        let mut map = Environment::outdoor(&WavelengthGrid::new(380.0, 50.0, 9).unwrap()).map;
        map.width = 1024;
        let exact_column = |d: [f64; 3]| {
            let u = 0.5 - d[0].atan2(d[2]) / (2.0 * PI);
            ((u * map.width as f64) as usize).min(map.width - 1)
        };
        let mut state = 9;
        let mut directions = Vec::new();
        for _ in 0..100_000 {
            let y = 2.0 * uniform(&mut state) - 1.0;
            let a = (2.0 * uniform(&mut state) - 1.0) * PI;
            directions.push(direction_from_azimuth_y(a, y));
        }
        for k in 0..=map.width {
            for offset in [0.0, 1e-12, 1e-9, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3] {
                for column in [k as f64 + offset, k as f64 - offset] {
                    let y = 2.0 * uniform(&mut state) - 1.0;
                    directions.push(direction_from_azimuth_y(
                        azimuth_of_column(column, map.width),
                        y,
                    ));
                }
            }
        }
        directions.extend([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [-0.0, 1.0, -0.0]]);
        directions.extend([[0.0, 0.0, -1.0], [-0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]);
        let mut fast = 0;
        for d in directions.iter().map(|&d| normalise(d)) {
            let texel = map.texel(&mut Query::new(d));
            assert_eq!(texel % map.width, exact_column(d), "direction {d:?}");
            fast += usize::from(map.column_without_atan2(&Query::new(d)).is_some());
        }
        // The shortcut answers nearly every random direction.
        assert!(fast > 100_000 * 99 / 100, "{fast}");
    }

    #[test]
    fn alias_tables_draw_each_index_with_its_weights_share() {
        let mut state = 3;
        let mut weights: Vec<f64> = (0..777).map(|_| uniform(&mut state).powi(4)).collect();
        weights[5] = 0.0;
        weights[100] = 300.0;
        weights[101] = -1.0;
        for w in [
            &weights[..],
            &[0.0, 0.0][..],
            &[2.0][..],
            &[1.0, 0.0, 3.0][..],
        ] {
            let table = alias_table(w);
            let n = w.len() as f64;
            let mut implied = vec![0.0; w.len()];
            for (i, &(keep, alias)) in table.iter().enumerate() {
                implied[i] += f64::from(keep) / n;
                implied[alias as usize] += (1.0 - f64::from(keep)) / n;
            }
            let total: f64 = w.iter().map(|v| v.max(0.0)).sum();
            for (i, (p, v)) in implied.iter().zip(w).enumerate() {
                let want = if total > 0.0 {
                    v.max(0.0) / total
                } else {
                    1.0 / n
                };
                assert!(
                    (p - want).abs() < 1e-6 * want.max(1.0 / n),
                    "{i}: {p} vs {want}"
                );
            }
        }
    }

    /// The look-ups in two steps (begun for a batch, then finished) return what the
    /// one-step calls do, bit for bit: light samples (map texels and emitters) and
    /// escapes (including a direction that cannot be normalised).
    #[test]
    fn look_ups_in_two_steps_are_those_in_one() {
        let mut state = 17;
        let grid = WavelengthGrid::new(380.0, 10.0, 33).unwrap();
        let image_env = random_map(64, 32, 6, 50.0, &mut state, &grid);
        let mut a = vec![0.0f32; grid.len()];
        let mut b = vec![0.0f32; grid.len()];
        for env in [
            image_env,
            Environment::studio(&grid),
            Environment::outdoor(&grid),
        ] {
            for _ in 0..20_000 {
                let u = [uniform(&mut state) as f32, uniform(&mut state) as f32];
                let one = env.sample(u, &mut a);
                let two = env.finish_sample(&env.begin_sample(u), &mut b);
                assert_eq!(
                    one.map(|s| (s.dir.map(f32::to_bits), s.pdf.to_bits())),
                    two.map(|s| (s.dir.map(f32::to_bits), s.pdf.to_bits())),
                    "sample {u:?}"
                );
                assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
                sample_is_its_directions_look_up(&env, u, &mut a, &mut b);
                let d = [0, 1, 2].map(|_| (2.0 * uniform(&mut state) - 1.0) as f32 * 3.0);
                for dir in [d, [0.0; 3]] {
                    let one = env.radiance_and_pdf(dir, &mut a);
                    let two = env.finish_radiance_and_pdf(
                        &env.begin_radiance_and_pdf_for(dir, false),
                        &mut b,
                    );
                    assert_eq!(one.to_bits(), two.to_bits(), "direction {dir:?}");
                    assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
                }
            }
        }
    }

    /// Light samples for a surface facing up ([`Environment::sample_for`]): each
    /// reports the density `pdf_for` gives its direction (bit for bit, in one step
    /// or two), lies above the horizon, and as an estimator of the horizontal
    /// illuminance ∫ L cos θ dω (π by the normalisation) is unbiased — and, its
    /// purpose, far less noisy than the sphere's samples, at least ×3 lower in
    /// variance. What noise is left per sample: cos θ varies within a row (32
    /// rows here) and within an emitter (sampled uniformly), and a texel's weight
    /// is its luminance plus a share of its peak (random colours on the test map).
    ///
    /// Negative control: the same samples weighed with a density 10 % high over
    /// half of the sphere (x ≥ 0), as a `pdf_for` wrong there alone would report
    /// it, must fail the same Z-test. (A density 10 % off over half and
    /// renormalised moves this estimate only by 0.1·(P − F), P and F the half's
    /// shares of the density and of L cos θ, nearly 0 for a density that follows
    /// the light: the histograms of `tests/environment.rs` are the test for that.)
    #[test]
    fn samples_facing_up_estimate_the_floors_irradiance_with_less_noise() {
        let mut state = 23;
        let grid = WavelengthGrid::new(380.0, 10.0, 33).unwrap();
        let image_env = random_map(64, 32, 6, 50.0, &mut state, &grid);
        let mut a = vec![0.0f32; grid.len()];
        let mut b = vec![0.0f32; grid.len()];
        for (name, env, most) in [
            ("image", image_env, 0.2),
            ("studio", Environment::studio(&grid), 0.5),
            ("outdoor", Environment::outdoor(&grid), 0.5),
        ] {
            let n = 200_000;
            let mut moments = [[0.0f64; 2]; 2];
            // Facing up, with the density 10 % high for x ≥ 0.
            let mut wrong = [0.0f64; 2];
            for _ in 0..n {
                let u = [uniform(&mut state) as f32, uniform(&mut state) as f32];
                for (facing_up, m) in [(true, 0), (false, 1)] {
                    let Some(sample) = env.sample_for(u, facing_up, &mut a) else {
                        continue;
                    };
                    let two = env.finish_sample(&env.begin_sample_for(u, facing_up), &mut b);
                    assert_eq!(
                        two.map(|s| (s.dir.map(f32::to_bits), s.pdf.to_bits())),
                        Some((sample.dir.map(f32::to_bits), sample.pdf.to_bits())),
                        "{name}: sample {u:?} in two steps"
                    );
                    let pdf = env.pdf_for(sample.dir, facing_up);
                    assert_eq!(pdf.to_bits(), sample.pdf.to_bits(), "{name}: {u:?}");
                    let y = f64::from(sample.dir[1]);
                    if facing_up {
                        assert!(y >= 0.0, "{name}: below the horizon");
                    }
                    let x = f64::from(env.luminance(&a)) * y.max(0.0) / f64::from(sample.pdf);
                    moments[m][0] += x;
                    moments[m][1] += x * x;
                    if facing_up {
                        let x = if sample.dir[0] >= 0.0 { x / 1.1 } else { x };
                        wrong[0] += x;
                        wrong[1] += x * x;
                    }
                }
            }
            let nf = n as f64;
            let [up, sphere] = moments.map(|[s, s2]| {
                let mean = s / nf;
                (mean, (s2 / nf - mean * mean).max(0.0))
            });
            for (label, (mean, var)) in [("facing up", up), ("sphere", sphere)] {
                let z = (mean - PI) / (var / nf).sqrt().max(1e-12);
                println!(
                    "{name} {label}: E {mean:.5}, relative std {:.4}, Z {z:.2}",
                    var.sqrt() / mean
                );
                assert!(
                    z.abs() < 5.0 || (mean - PI).abs() < 1e-4,
                    "{name} {label}: E = {mean} for π (Z {z:.1})"
                );
            }
            let (mean, var) = (
                wrong[0] / nf,
                (wrong[1] / nf - (wrong[0] / nf).powi(2)).max(0.0),
            );
            let z = (mean - PI) / (var / nf).sqrt().max(1e-12);
            println!("{name} facing up, density 10 % high for x ≥ 0: E {mean:.5}, Z {z:.1}");
            assert!(
                z.abs() >= 5.0,
                "{name}: a 10 % density error passed (Z {z:.1})"
            );
            let relative = up.1.sqrt() / up.0;
            assert!(relative < most, "{name}: relative std {relative:.4}");
            assert!(
                up.1 < sphere.1 / 3.0,
                "{name}: {} against {}",
                up.1,
                sphere.1
            );
        }
    }

    /// A map of random texels, each channel `scale` × a uniform number to the
    /// `power` (high powers: a few bright texels, as in a studio map).
    fn random_map(
        width: usize,
        height: usize,
        power: i32,
        scale: f32,
        state: &mut u64,
        grid: &WavelengthGrid,
    ) -> Environment {
        let pixels: Vec<[f32; 3]> = (0..width * height)
            .map(|_| [0, 1, 2].map(|_| uniform(state).powi(power) as f32 * scale))
            .collect();
        let image = RgbImage::new(width, height, pixels).unwrap();
        Environment::from_rgb_image(&image, "test", grid).unwrap()
    }

    /// A light sample's radiance and density are, bit for bit, those that
    /// `radiance_and_pdf` finds for its direction (the sample's texel is taken
    /// from the draw, without a look-up, when the direction is surely in it).
    fn sample_is_its_directions_look_up(
        env: &Environment,
        u: [f32; 2],
        a: &mut [f32],
        b: &mut [f32],
    ) {
        let Some(sample) = env.sample(u, a) else {
            return;
        };
        let pdf = env.radiance_and_pdf(sample.dir, b);
        assert_eq!(sample.pdf.to_bits(), pdf.to_bits(), "sample {u:?}");
        assert!(
            a.iter()
                .zip(b.iter())
                .all(|(x, y)| x.to_bits() == y.to_bits())
        );
    }

    /// Map samples drawn at and near column edges (where the drawn texel is not
    /// trusted) and a little further in (where it is) still find their
    /// direction's texel, on a map as large as the side-by-side's.
    #[test]
    fn map_samples_near_column_edges_find_their_directions_texel() {
        let (width, height) = (1024, 512);
        let mut state = 5;
        let grid = WavelengthGrid::new(380.0, 10.0, 33).unwrap();
        let env = random_map(width, height, 4, 20.0, &mut state, &grid);
        let mut a = vec![0.0f32; grid.len()];
        let mut b = vec![0.0f32; grid.len()];
        let offsets = [0.0, 1e-9, 1e-7, 1e-6, 5e-6, 1e-5, 2e-5, 1e-4, 0.5];
        for _ in 0..2_000 {
            let u0 = uniform(&mut state) as f32;
            let column = (uniform(&mut state) * width as f64) as usize;
            for offset in offsets {
                for edge in [column as f64 + offset, (column + 1) as f64 - offset] {
                    let u1 = (edge / width as f64).min(ONE_BELOW) as f32;
                    sample_is_its_directions_look_up(&env, [u0, u1], &mut a, &mut b);
                }
            }
            let u = [uniform(&mut state) as f32, uniform(&mut state) as f32];
            sample_is_its_directions_look_up(&env, u, &mut a, &mut b);
        }
    }

    /// The polynomial sine and cosine stay within 1e-15 (a quarter of
    /// [`SIN_COS_MARGIN`]) of libm's over the azimuths' range, quadrant edges,
    /// zeros and ±π included.
    #[test]
    fn fast_sin_cos_is_within_1e_15_of_libm() {
        let mut state = 21;
        let mut angles: Vec<f64> = (0..1_000_000)
            .map(|_| (2.0 * uniform(&mut state) - 1.0) * PI)
            .collect();
        for k in -4..=4 {
            let edge = f64::from(k) * PI / 4.0;
            for e in [0.0, 1e-15, 1e-12, 1e-9, 1e-6, 1e-3] {
                angles.extend([edge + e, edge - e]);
            }
        }
        angles.extend([0.0, -0.0, PI, -PI, PI.next_down(), (-PI).next_up()]);
        let mut worst = 0.0f64;
        for a in angles {
            let (s, c) = sin_cos_fast(a);
            let (ws, wc) = a.sin_cos();
            worst = worst.max((s - ws).abs()).max((c - wc).abs());
        }
        assert!(worst < 1e-15, "largest difference {worst:e}");
    }

    /// Directions built with the fast sine and cosine round to the f32 numbers
    /// of the libm ones, bit for bit: random (azimuth, y), quadrant edges, the
    /// poles, and small x or z (where the guard falls back to libm).
    #[test]
    fn fast_directions_round_as_the_libm_ones_do() {
        let mut state = 23;
        let check = |a: f64, y: f64| {
            let (d, dir) = direction_from_azimuth_y_f32(a, y);
            let want = direction_from_azimuth_y(a, y).map(|v| v as f32);
            assert_eq!(
                dir.map(f32::to_bits),
                want.map(f32::to_bits),
                "azimuth {a} y {y}"
            );
            assert_eq!(
                d.map(|v| v as f32).map(f32::to_bits),
                want.map(f32::to_bits)
            );
        };
        for _ in 0..2_000_000 {
            let a = (2.0 * uniform(&mut state) - 1.0) * PI;
            let y = 2.0 * uniform(&mut state) - 1.0;
            check(a, y);
        }
        for k in -4..=4 {
            for e in [0.0, 1e-300, 1e-15, 1e-10, 1e-7, 1e-4] {
                for y in [0.0, 0.5, -0.99, 1.0, -1.0, 1.0 - 1e-12] {
                    check(f64::from(k) * PI / 4.0 + e, y);
                    check(f64::from(k) * PI / 4.0 - e, y);
                }
            }
        }
    }

    /// Map samples drawn at and near row boundaries (where the drawn row is
    /// checked on the normalised f32 direction) and further inside (where it is
    /// taken from the unrounded one) have, bit for bit, the radiance and density
    /// of their direction's look-up; rows at the poles and the horizon included.
    #[test]
    fn map_samples_near_row_edges_find_their_directions_texel() {
        let (width, height) = (1024, 512);
        let mut state = 9;
        let grid = WavelengthGrid::new(380.0, 10.0, 33).unwrap();
        let env = random_map(width, height, 4, 20.0, &mut state, &grid);
        assert!(
            env.patches.is_empty(),
            "a map without emitters takes the shortcut"
        );
        let mut a = vec![0.0f32; grid.len()];
        let mut b = vec![0.0f32; grid.len()];
        let offsets = [0.0, 1e-12, 1e-9, 1e-7, 1e-6, 2e-6, 1e-5, 1e-3, 0.01, 0.5];
        let mut rows: Vec<usize> = (0..300)
            .map(|_| (uniform(&mut state) * height as f64) as usize)
            .collect();
        rows.extend([0, 1, height / 2 - 1, height / 2, height - 2, height - 1]);
        for row in rows {
            let row_width = env.map.row_cos[row] - env.map.row_cos[row + 1];
            for offset in offsets {
                // v is the fraction of the row's cos range; offsets are in cos θ.
                let dv = (offset / row_width).min(0.5);
                for v in [dv, 1.0 - dv] {
                    let v = v.clamp(0.0, ONE_BELOW);
                    let frac = uniform(&mut state).clamp(0.0, ONE_BELOW);
                    let first = (uniform(&mut state) * width as f64) as usize;
                    let begun = SampleLookUp {
                        component: 0,
                        u: [0.0, 0.0],
                        draw: Some(MapDraw {
                            row,
                            v,
                            first,
                            frac,
                        }),
                        facing_up: false,
                    };
                    let located = env.locate_sample(&begun).expect("a lit map");
                    let sample = env
                        .finish_located_sample(&located, &mut a)
                        .expect("density");
                    let pdf = env.radiance_and_pdf(sample.dir, &mut b);
                    assert_eq!(sample.pdf.to_bits(), pdf.to_bits(), "row {row} v {v}");
                    assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
                }
            }
        }
    }

    /// The map's sampling, with its alias tables, against its own density: texel
    /// counts agree with P(texel) (per-texel Z, and Pearson's χ² over all texels,
    /// which sees an error spread over many texels that no single texel's Z
    /// shows), and the estimate of ∫ g dω with g(d) = 1 + d_x + d_y² (4π + 4π/3)
    /// agrees within its standard error. The negative control: the same samples
    /// against the density ×1.1 on the map's left half (renormalised) must fail.
    #[test]
    fn map_samples_follow_the_density_the_map_reports() {
        let (width, height) = (16, 8);
        let mut state = 11;
        let pixels: Vec<[f32; 3]> = (0..width * height)
            .map(|i| {
                let v = if i % 5 == 0 {
                    0.0
                } else {
                    uniform(&mut state).powi(3) as f32
                };
                [v, 0.5 * v, uniform(&mut state) as f32]
            })
            .collect();
        let image = RgbImage::new(width, height, pixels).unwrap();
        let grid = WavelengthGrid::new(380.0, 50.0, 9).unwrap();
        let env = Environment::from_rgb_image(&image, "test", &grid).unwrap();
        let n = 400_000;
        let mut texels = Vec::with_capacity(n);
        let mut out = vec![0.0; grid.len()];
        for _ in 0..n {
            let u = [uniform(&mut state) as f32, uniform(&mut state) as f32];
            let sample = env.sample(u, &mut out).expect("a sample");
            let d = sample.dir.map(f64::from);
            texels.push((env.map.texel(&mut Query::new(d)), d, sample.pdf));
        }
        let solid_angle = |texel: usize| {
            let row = texel / width;
            2.0 * PI / width as f64 * (env.map.row_cos[row] - env.map.row_cos[row + 1])
        };
        // The statistics for a density given as a factor on the map's own.
        let failures = |factor: &dyn Fn(usize) -> f64| -> Vec<String> {
            let mut failed = Vec::new();
            let mut counts = vec![0u64; width * height];
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for &(texel, d, pdf) in &texels {
                counts[texel] += 1;
                let g = 1.0 + d[0] + d[1] * d[1];
                let x = g / (f64::from(pdf) * factor(texel));
                sum += x;
                sum2 += x * x;
            }
            let nf = n as f64;
            let (mut chi2, mut dof) = (0.0_f64, 0.0_f64);
            for (texel, &count) in counts.iter().enumerate() {
                let p = env.map.pdf(texel) * factor(texel) * solid_angle(texel);
                let expected = p * nf;
                let z = (count as f64 - expected) / expected.max(1e-9).sqrt();
                if z.abs() >= 5.0 {
                    failed.push(format!("texel {texel}: {count} for {expected:.1}"));
                }
                if expected >= 5.0 {
                    chi2 += z * z;
                    dof += 1.0;
                }
            }
            // χ² with dof − 1 degrees of freedom: mean dof − 1, sd √(2(dof − 1)).
            let bound = dof - 1.0 + 5.0 * (2.0 * (dof - 1.0)).sqrt();
            if chi2 >= bound {
                failed.push(format!("χ² {chi2:.0} over {dof} texels (bound {bound:.0})"));
            }
            let mean = sum / nf;
            let error = ((sum2 / nf - mean * mean) / nf).sqrt();
            let want = 4.0 * PI + 4.0 * PI / 3.0;
            if (mean - want).abs() >= 5.0 * error {
                failed.push(format!("∫ g: {mean} ± {error} vs {want}"));
            }
            failed
        };
        let own = failures(&|_| 1.0);
        assert!(own.is_empty(), "{own:#?}");
        let left = |texel: usize| texel % width < width / 2;
        let share: f64 = (0..width * height)
            .filter(|&t| left(t))
            .map(|t| env.map.pdf(t) * solid_angle(t))
            .sum();
        let renormalised = 1.0 / (1.0 + 0.1 * share);
        let wrong = failures(&|t| if left(t) { 1.1 } else { 1.0 } * renormalised);
        println!("density ×1.1 on the left half ({share:.3} of it): {wrong:#?}");
        assert!(
            wrong.iter().any(|f| f.starts_with("χ²")),
            "a 10 % density error passed: {wrong:#?}"
        );
    }
}
