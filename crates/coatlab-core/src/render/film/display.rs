//! The film's display pipeline (spec section 6): XYZ (white at Y = 1) → linear sRGB,
//! adapted to a white → exposure → tone mapping → sRGB encoding. It acts on what is
//! shown only: the film's sums and its EXR stay the unbiased linear means. Kept
//! apart from the accumulation in [`super`] because the viewer's choices
//! ([`DisplaySettings`], [`ToneMapping`], [`Exposure`]) change without the film.

use std::sync::OnceLock;

use palette::{LinSrgb, Srgba};
use thiserror::Error;

use super::Film;

use crate::colour::{
    Lab, SRGB_LUMINANCE, Xyz, ciede2000, lab_from_xyz, linear_srgb_from_xyz, srgb_white,
    xyz_from_linear_srgb,
};

/// Entries of the sRGB encoding table: 2¹⁶ over [0, 1], fine enough that the
/// steepest part of the curve (slope 12.92 near black, 3295 code values per unit)
/// moves by at most 0.03 code values within an entry.
const ENCODE_LUT_LEN: usize = 1 << 16;

/// How linear sRGB is compressed into the displayable [0, 1]. The film and its
/// EXR never see it: it acts on the displayed image only (`docs/display.md`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ToneMapping {
    /// The Khronos PBR Neutral tone mapper (the default), from its specification
    /// (KhronosGroup/ToneMapping, `PBR_Neutral/README.md`): with F90 = 0.04,
    /// K_s = 0.8 − F90 and K_d = 0.15, x = min(R, G, B), the offset
    /// f = x − x²/(4 F90) for x ≤ 2 F90 and F90 above, p = max(c − f);
    /// c_out = c − f while p ≤ K_s; above it the peak is compressed to
    /// p_n = 1 − (1 − K_s)² / (p + 1 − 2 K_s) and the colour blended towards the
    /// grey of p_n by 1 − g, g = 1 / (K_d (p − p_n) + 1).
    ///
    /// Why this one for product colour: every colour whose channels lie in
    /// [0.08, 0.8] is shown as itself less 0.04 — the 4 % a clear coat reflects of
    /// a uniform white surround — so a paint's body colour seen face-on under even
    /// light is shown as designed, not brightened, desaturated or hue-shifted as
    /// filmic curves do; brighter colours (highlights) are compressed towards
    /// white without any change of hue (only within the plane of the colour and
    /// the grey axis). Negative channels (colours outside the sRGB gamut) are
    /// clipped to 0 first: the specification is for non-negative input.
    PbrNeutral,
    /// None: values above 1 (and below 0) are clipped per channel. For colorimetric
    /// checks, where a white of Y = 1 must show as 255.
    Clip,
    /// Extended Reinhard on luminance (Reinhard et al. 2002, eq. 4):
    /// L' = L (1 + L / L_white²) / (1 + L), and the linear RGB scaled by L' / L, so
    /// every pixel keeps its chromaticity; a colour still above 1 in some channel
    /// after that is scaled down until its largest channel is 1 (hue kept, the
    /// colour darkens rather than shifting). The display before PBR Neutral, and
    /// the one the quality presets and adaptive sampling were measured with
    /// ([`DisplaySettings::MEASURED`]).
    ReinhardLuminance { white_luminance: f32 },
}

impl Default for ToneMapping {
    /// Khronos PBR Neutral: the colours that fit the display stay as they are.
    fn default() -> Self {
        ToneMapping::PbrNeutral
    }
}

impl ToneMapping {
    /// Reinhard on luminance with the white at 4 (two stops above a diffuse white
    /// at Y = 1, room for specular highlights): the mapping before PBR Neutral.
    pub const REINHARD: ToneMapping = ToneMapping::ReinhardLuminance {
        white_luminance: 4.0,
    };

    /// The mappings a user chooses from, the default first.
    pub const CHOICES: [ToneMapping; 3] = [
        ToneMapping::PbrNeutral,
        ToneMapping::REINHARD,
        ToneMapping::Clip,
    ];

    /// The name on the command line (`--tone-map`).
    pub fn name(self) -> &'static str {
        match self {
            ToneMapping::PbrNeutral => "neutral",
            ToneMapping::ReinhardLuminance { .. } => "reinhard",
            ToneMapping::Clip => "clip",
        }
    }

    /// The name a user reads.
    pub fn label(self) -> &'static str {
        match self {
            ToneMapping::PbrNeutral => "PBR Neutral",
            ToneMapping::ReinhardLuminance { .. } => "Reinhard",
            ToneMapping::Clip => "Clip",
        }
    }

    /// The mapping named `name` ([`Self::name`]: neutral, reinhard or clip).
    pub fn parse(name: &str) -> Result<ToneMapping, UnknownToneMapping> {
        Self::CHOICES
            .into_iter()
            .find(|t| t.name() == name)
            .ok_or_else(|| UnknownToneMapping(name.to_owned()))
    }
}

/// A tone mapping name [`ToneMapping::parse`] does not know.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("unknown tone mapping \"{0}\" (expected neutral, reinhard or clip)")]
pub struct UnknownToneMapping(pub String);

/// How [`Film::to_display`] turns XYZ into pixels.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DisplaySettings {
    /// Exposure in stops: XYZ is scaled by 2^stops before tone mapping.
    pub exposure_stops: f32,
    /// `Some(white)`: show the scene as adapted to `white` (its XYZ at any scale,
    /// e.g. [`crate::colour::cie::Colorimeter::white`] of the scene's illuminant), mapping it
    /// to the sRGB white by Bradford; `None`: show the colours as they are, relative
    /// to the sRGB (D65) white.
    pub adapt_white: Option<Xyz>,
    /// The tone mapping after exposure.
    pub tone_mapping: ToneMapping,
}

impl DisplaySettings {
    /// The display the quality presets' errors (`docs/tradeoff.md`), the
    /// reference noise of the bench and adaptive sampling's noise were measured
    /// and tuned with: exposure 0, no adaptation, Reinhard on luminance. Those
    /// measurements keep it whatever a viewer chooses, so their figures stay
    /// comparable with the committed ones.
    pub const MEASURED: DisplaySettings = DisplaySettings {
        exposure_stops: 0.0,
        adapt_white: None,
        tone_mapping: ToneMapping::REINHARD,
    };
}

/// How the exposure of a display is chosen: from the image, or fixed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Exposure {
    /// [`Film::auto_exposure`] (the log-average luminance to middle grey) plus
    /// `adjust_stops`.
    Auto {
        /// The user's adjustment, stops.
        adjust_stops: f32,
    },
    /// This many stops, whatever the image.
    Fixed {
        /// Exposure, stops.
        stops: f32,
    },
}

impl Default for Exposure {
    /// Automatic, unadjusted.
    fn default() -> Self {
        Exposure::Auto { adjust_stops: 0.0 }
    }
}

impl Exposure {
    /// The exposure in stops for `film`'s image.
    pub fn stops(self, film: &Film) -> f32 {
        match self {
            Exposure::Auto { adjust_stops } => film.auto_exposure() + adjust_stops,
            Exposure::Fixed { stops } => stops,
        }
    }

    /// Parses `auto`, `auto+STOPS`, `auto-STOPS` or a number of stops.
    pub fn parse(text: &str) -> Result<Exposure, BadExposure> {
        let bad = || BadExposure(text.to_owned());
        let number = |t: &str| t.parse::<f32>().ok().filter(|v| v.is_finite());
        match text.strip_prefix("auto") {
            Some("") => Ok(Exposure::default()),
            Some(rest) if rest.starts_with(['+', '-']) => number(rest)
                .map(|adjust_stops| Exposure::Auto { adjust_stops })
                .ok_or_else(bad),
            Some(_) => Err(bad()),
            None => number(text)
                .map(|stops| Exposure::Fixed { stops })
                .ok_or_else(bad),
        }
    }
}

impl std::fmt::Display for Exposure {
    /// As [`Exposure::parse`] reads it: "0", "-1.5", "auto", "auto+1".
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Exposure::Fixed { stops } => write!(f, "{stops}"),
            Exposure::Auto { adjust_stops: 0.0 } => f.write_str("auto"),
            Exposure::Auto { adjust_stops } => write!(f, "auto{adjust_stops:+}"),
        }
    }
}

/// An exposure [`Exposure::parse`] cannot read.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error(
    "bad exposure \"{0}\" (expected stops such as 0 or -1.5, auto, or auto+STOPS / auto-STOPS)"
)]
pub struct BadExposure(pub String);

/// What a viewer chooses of a display: the tone mapping and the exposure; the
/// exposure's stops follow the image ([`Self::settings_for`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DisplayChoice {
    /// The tone mapping.
    pub tone_mapping: ToneMapping,
    /// The exposure.
    pub exposure: Exposure,
}

impl DisplayChoice {
    /// The settings that show `film` as chosen (no adaptation).
    pub fn settings_for(&self, film: &Film) -> DisplaySettings {
        DisplaySettings {
            exposure_stops: self.exposure.stops(film),
            adapt_white: None,
            tone_mapping: self.tone_mapping,
        }
    }
}

pub(super) type Mat3f = [[f32; 3]; 3];

#[inline]
pub(super) fn mul(m: &Mat3f, v: [f32; 3]) -> [f32; 3] {
    [0, 1, 2].map(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])
}

/// XYZ (white at Y = 1) → exposed linear sRGB, the adaptation of
/// [`crate::colour::linear_srgb_from_xyz`] included: that function is linear in the
/// colour, so its images of the unit vectors are the matrix's columns.
pub(super) fn display_matrix(adapt_white: Option<Xyz>, exposure_stops: f32) -> Mat3f {
    let srgb = srgb_white();
    let white = match adapt_white {
        Some(w) if w.y > 0.0 && w.x.is_finite() && w.y.is_finite() && w.z.is_finite() => w,
        _ => srgb,
    };
    // The film's white is at Y = 1.
    let white = Xyz::new(white.x / white.y, 1.0, white.z / white.y);
    let scale = 2f64.powf(f64::from(exposure_stops));
    let columns = [
        Xyz::new(1.0, 0.0, 0.0),
        Xyz::new(0.0, 1.0, 0.0),
        Xyz::new(0.0, 0.0, 1.0),
    ]
    .map(|e| linear_srgb_from_xyz(e, white));
    let column = |c: usize| {
        let rgb = columns[c];
        [rgb.red, rgb.green, rgb.blue]
    };
    [0, 1, 2].map(|r| [0, 1, 2].map(|c| (column(c)[r] * scale) as f32))
}

#[inline]
pub(super) fn tone_map(rgb: [f32; 3], tone_mapping: ToneMapping) -> [f32; 3] {
    match tone_mapping {
        ToneMapping::Clip => rgb,
        ToneMapping::PbrNeutral => pbr_neutral(rgb.map(|v| v.max(0.0))),
        ToneMapping::ReinhardLuminance { white_luminance } => {
            let luminance = SRGB_LUMINANCE[0] * rgb[0]
                + SRGB_LUMINANCE[1] * rgb[1]
                + SRGB_LUMINANCE[2] * rgb[2];
            if luminance.is_nan() || luminance <= 0.0 {
                return [0.0; 3];
            }
            let inv_white_sq = 1.0 / (white_luminance * white_luminance);
            // L' / L = (1 + L / L_white²) / (1 + L).
            let ratio = (1.0 + luminance * inv_white_sq) / (1.0 + luminance);
            let scaled = rgb.map(|v| v * ratio);
            let max = scaled[0].max(scaled[1]).max(scaled[2]);
            if max > 1.0 {
                let inv_max = 1.0 / max;
                scaled.map(|v| v * inv_max)
            } else {
                scaled
            }
        }
    }
}

/// F90 of the PBR Neutral specification: the normal-incidence reflectance of an
/// index-1.5 dielectric, the offset taken off every colour.
pub const PBR_NEUTRAL_F90: f32 = 0.04;
/// K_s: the peak above which PBR Neutral compresses.
pub const PBR_NEUTRAL_START_COMPRESSION: f32 = 0.8 - PBR_NEUTRAL_F90;
/// K_d: how fast PBR Neutral desaturates compressed highlights.
pub const PBR_NEUTRAL_DESATURATION: f32 = 0.15;

/// The Khronos PBR Neutral mapping of a non-negative linear sRGB colour (see
/// [`ToneMapping::PbrNeutral`]; the specification's symbols).
#[inline]
fn pbr_neutral(c: [f32; 3]) -> [f32; 3] {
    const F90: f32 = PBR_NEUTRAL_F90;
    const KS: f32 = PBR_NEUTRAL_START_COMPRESSION;
    const KD: f32 = PBR_NEUTRAL_DESATURATION;
    let x = c[0].min(c[1]).min(c[2]);
    // The offset fades in quadratically below 2 F90, so black stays black.
    let f = if x <= 2.0 * F90 {
        x - x * x / (4.0 * F90)
    } else {
        F90
    };
    let shifted = c.map(|v| v - f);
    let p = shifted[0].max(shifted[1]).max(shifted[2]);
    // NaN fails the comparison too: NaN goes through, and encodes as black.
    if p <= KS || p.is_nan() {
        return shifted;
    }
    let p_n = 1.0 - (1.0 - KS) * (1.0 - KS) / (p + 1.0 - 2.0 * KS);
    let g = 1.0 / (KD * (p - p_n) + 1.0);
    let scale = p_n / p * g;
    let grey = p_n * (1.0 - g);
    shifted.map(|v| v * scale + grey)
}

/// The displayable pixels (RGBA8, sRGB-encoded, as GPU textures take them) of
/// mean XYZ values (white at Y = 1), as [`Film::to_display`] shows a film's
/// means: for images that are estimates but not films (a re-shaded image,
/// `render::reshade`).
pub fn display_xyz(xyz: &[[f32; 3]], settings: &DisplaySettings) -> Vec<[u8; 4]> {
    palette::cast::into_array_vec(display_xyz_srgba(xyz, settings))
}

/// [`display_xyz`] as `Srgba<u8>`.
pub fn display_xyz_srgba(xyz: &[[f32; 3]], settings: &DisplaySettings) -> Vec<Srgba<u8>> {
    use rayon::prelude::*;
    let m = display_matrix(settings.adapt_white, settings.exposure_stops);
    let lut = encode_lut();
    xyz.par_iter()
        .map(|&v| {
            let rgb = tone_map(mul(&m, v), settings.tone_mapping);
            let [r, g, b] = rgb.map(|c| encode(lut, c));
            Srgba::new(r, g, b, 255)
        })
        .collect()
}

/// CIELAB of the colour a mean XYZ is displayed in with `settings`, as
/// [`Film::display_lab`] gives it for a film's pixel. For many colours, prepare
/// the settings once ([`DisplayTransform`]): their matrix costs about as much as
/// the colour's own conversion.
pub fn display_lab_of_xyz(xyz: Xyz, settings: &DisplaySettings) -> Lab {
    DisplayTransform::of(settings).lab_of_xyz(xyz)
}

/// [`DisplaySettings`] prepared for converting many colours: the matrix of their
/// white adaptation and exposure, made once, and their tone mapping.
#[derive(Debug, Clone, Copy)]
pub struct DisplayTransform {
    matrix: Mat3f,
    tone_mapping: ToneMapping,
}

impl DisplayTransform {
    /// The transform of `settings`.
    pub fn of(settings: &DisplaySettings) -> Self {
        Self {
            matrix: display_matrix(settings.adapt_white, settings.exposure_stops),
            tone_mapping: settings.tone_mapping,
        }
    }

    /// [`display_lab_of_xyz`] with these settings.
    #[inline]
    pub fn lab_of_xyz(&self, xyz: Xyz) -> Lab {
        display_lab_of(&self.matrix, self.tone_mapping, xyz)
    }

    /// The CIEDE2000 by which moving the colour `xyz` by `offset`, up or down,
    /// moves what is displayed, whichever moves it more (a colour moved up may be
    /// clipped white already; one moved down is held at 0 in each component):
    /// how far one standard error `offset` of a mean moves its displayed colour.
    pub fn delta_e_of_offset(&self, xyz: [f64; 3], offset: [f64; 3]) -> f64 {
        let lab = |v: [f64; 3]| self.lab_of_xyz(Xyz::new(v[0], v[1], v[2]));
        let moved = |sign: f64| {
            lab(std::array::from_fn(|k| {
                (xyz[k] + sign * offset[k]).max(0.0)
            }))
        };
        let centre = lab(xyz);
        ciede2000(centre, moved(1.0)).max(ciede2000(centre, moved(-1.0)))
    }

    /// The perceptual noise of one sample behind a mean `xyz` of `samples`
    /// samples whose variance in X, Y and Z is `variance_of_mean`: √n times
    /// [`Self::delta_e_of_offset`] by one standard error, so the mean's error
    /// after n samples is about this over √n; 0 where that is not finite.
    pub fn sample_noise(&self, xyz: [f64; 3], variance_of_mean: [f64; 3], samples: f64) -> f32 {
        let delta = self.delta_e_of_offset(xyz, variance_of_mean.map(|v| v.max(0.0).sqrt()));
        if delta.is_finite() {
            (delta * samples.sqrt()) as f32
        } else {
            0.0
        }
    }
}

fn display_lab_of(m: &Mat3f, tone_mapping: ToneMapping, xyz: Xyz) -> Lab {
    let rgb = tone_map(
        mul(m, [xyz.x as f32, xyz.y as f32, xyz.z as f32]),
        tone_mapping,
    )
    .map(|v| f64::from(v.clamp(0.0, 1.0)));
    let shown = xyz_from_linear_srgb(LinSrgb::new(rgb[0], rgb[1], rgb[2]));
    lab_from_xyz(shown, srgb_white())
}

/// The sRGB encoding table: entry i holds the 8-bit code of linear i / (len − 1).
pub(super) fn encode_lut() -> &'static [u8] {
    static LUT: OnceLock<Vec<u8>> = OnceLock::new();
    LUT.get_or_init(|| {
        (0..ENCODE_LUT_LEN)
            .map(|i| {
                let v = i as f64 / (ENCODE_LUT_LEN - 1) as f64;
                let encoded = if v <= 0.003_130_8 {
                    12.92 * v
                } else {
                    1.055 * v.powf(1.0 / 2.4) - 0.055
                };
                (encoded * 255.0).round().clamp(0.0, 255.0) as u8
            })
            .collect()
    })
}

/// The 8-bit sRGB code of a linear value, clamped to [0, 1] (NaN → 0).
#[inline]
pub(super) fn encode(lut: &[u8], linear: f32) -> u8 {
    // Round half up by truncation (cheaper than `round`, a libm call); `as` maps NaN
    // to 0.
    let position = linear.clamp(0.0, 1.0) * (ENCODE_LUT_LEN - 1) as f32 + 0.5;
    lut[position as usize]
}
