//! The film: per-pixel accumulation of spectral radiance samples as CIE XYZ, noise
//! estimates, and PNG and OpenEXR output. The display pipeline of spec section 6
//! (XYZ → linear sRGB → exposure → tone mapping → sRGB encoding) is [`display`],
//! re-exported here.
//!
//! # Tristimulus scale
//! Samples are spectral radiance on the film's [`WavelengthGrid`], read (like every
//! spectrum in Coatlab) as the piecewise-linear function through its samples. X, Y,
//! Z are ∫ L(λ) x̄(λ) dλ (CIE 1931 2°, the display observer) divided by ∫ ȳ(λ) dλ over
//! 380–780 nm, so a constant radiance of 1 has Y = 1 exactly, on any grid: the scale
//! the display pipeline expects (white at Y = 1). The weights are those of
//! [`crate::colour::cie::Colorimeter`] without an illuminant: per grid sample the integral,
//! on the 5 nm CIE table, of the sample's hat (linear-interpolation) basis function
//! times the colour-matching function.
//!
//! # Accumulation and tiles
//! Per pixel the film keeps Σ X, Σ Y, Σ Z twice: exactly, in 128-bit fixed point
//! with [`EXACT_FRACTION_BITS`] bits below the point, and that exact sum rounded
//! to f64, which is what every reader (the mean, the display) uses. A sample's X,
//! Y, Z are f32; every f32 of magnitude ≥ 2⁻⁴¹ (≈ 4.5 · 10⁻¹³, far below anything
//! a display or an EXR of Y = 1 whites resolves) is a whole number of 2⁻⁶⁴ and adds
//! without rounding, smaller ones are cut towards zero, and the sum saturates at
//! ±2⁶³ (≈ 9.2 · 10¹⁸). Integer addition is associative, so the sums, and the
//! image, do not depend on the order the samples were added in: a render split
//! into sample ranges on several machines and merged ([`part`])
//! is bit for bit the render of one process. Beside them the film keeps Σ X², Σ Y²,
//! Σ Z² and the sample count in 64-bit numbers, so the sum-of-squares variance does
//! not cancel catastrophically in low-noise pixels after thousands of samples, and
//! for the noise estimate (below) Σ X, Σ Y, Σ Z of the samples in the two highest
//! power-of-two blocks of sample indices and which blocks those are (these f64
//! sums depend on the order of additions in their last bits; they feed only the
//! noise estimates, never the image): 160 bytes a pixel in all, 147 MB at 1280×720
//! (the blocks are 56 of them, 52 MB; the exact sums 48). [`Film::add_sample`]
//! costs three dot products over the grid (in f32, 8 lanes), three conversions to
//! fixed point and back, and ten additions.
//!
//! # Noise estimate: the two halves of a power-of-two prefix
//! A pixel's samples are Owen-scrambled Sobol points ([`crate::render::sampler`]),
//! negatively correlated, so s²/n (the variance) over-states the error of their
//! mean. With P the largest power of two ≤ n, the pixel's samples 0 .. P/2 and
//! P/2 .. P are each a (0, m − 1, 2)-net of their dimension pairs, as stratified as
//! one another: [`Film::noise_estimate`] takes half the difference of their means
//! as the error of the first P samples' mean (for independent samples
//! E[(m_A − m_B)²] / 4 is its squared error exactly), and scales it by √(P / n) to
//! the n samples (at least the 1/√n rate; none between powers of two is assumed
//! faster). The interleaved halves (even and odd indices) would not do: the index
//! shuffle puts samples 2j and 2j + 1 in opposite halves of every dimension, so
//! either half alone is badly stratified and their difference over-states the
//! error (×2.7 on the car at 16 spp). One pixel's difference is a single degree of
//! freedom (a very noisy number), so it is only used averaged over many pixels.
//!
//! Blocks: sample s is in block `bit_length(s)` (0: sample 0; 1: sample 1; 2:
//! samples 2–3; k: 2^(k−1) .. 2^k). Per pixel the film keeps the sums of the
//! highest block holding a sample and of the one below; everything lower is the
//! total minus those. Samples may arrive in any order and tiles of later passes
//! merge exactly (the block sums of the union are the sums of the parts').
//! Parallel rendering takes [`Film::tiles`], fills each tile on its own thread
//! with image pixel coordinates, and merges them back ([`Film::merge_tiles`], the
//! film's rows in parallel) in a fixed order: a pixel receives its samples in the
//! same order as in a serial render, so the result is bit-for-bit deterministic.
//!
//! # Tone mapping
//! See [`ToneMapping`]: Khronos PBR Neutral by default, which shows every colour
//! that fits the display as it is (less the 4 % of a clear coat's reflection) and
//! compresses only highlights, without changing any hue; extended Reinhard on
//! luminance (the mapping before it, and the one measurements keep:
//! [`DisplaySettings::MEASURED`]); or a plain clip for colorimetric checks. The
//! exposure is the film's automatic one plus the viewer's adjustment, or fixed
//! ([`Exposure`]). Neither touches the film's sums or its EXR, which stay the
//! unbiased linear means.

pub mod display;
pub mod part;

pub use display::{
    BadExposure, DisplayChoice, DisplaySettings, DisplayTransform, Exposure,
    PBR_NEUTRAL_DESATURATION, PBR_NEUTRAL_F90, PBR_NEUTRAL_START_COMPRESSION, ToneMapping,
    UnknownToneMapping, display_lab_of_xyz, display_xyz, display_xyz_srgba,
};
use display::{display_matrix, encode, encode_lut, mul, tone_map};

use std::path::{Path, PathBuf};
use std::sync::Arc;

use thiserror::Error;

use crate::colour::cie::{Observer, hat_weighted_cmfs};
use crate::colour::spectrum::{Channels, WavelengthGrid};
use crate::colour::{Lab, Xyz, ciede2000, xyz_rows_of_linear_srgb};
use crate::io::exr_write::{
    ExrCompression, ExrOptions, ExrPrecision, ExrWriteError, write_linear_srgb_exr,
};
use crate::io::png_write::{PngWriteError, write_srgb8_png};
use palette::{LinSrgb, Srgb, Srgba};

/// [`Film::auto_exposure`]'s key: the log-average luminance is mapped to this
/// (Reinhard et al. 2002, "Photographic tone reproduction", middle grey).
pub const AUTO_EXPOSURE_KEY: f64 = 0.18;

/// What went wrong writing an image; each names the file.
#[derive(Debug, Error)]
pub enum FilmError {
    /// Writing the PNG failed.
    #[error(transparent)]
    Png(#[from] PngWriteError),
    /// Writing the EXR failed.
    #[error(transparent)]
    Exr(#[from] ExrWriteError),
    /// A film without pixels has no image to write.
    #[error("{}: cannot write a {width}×{height} image (needs at least 1×1)", path.display())]
    EmptyImage {
        path: PathBuf,
        width: u32,
        height: u32,
    },
}

impl FilmError {
    /// Whether the file could not be created or written (rather than encoded).
    pub fn is_write_failure(&self) -> bool {
        matches!(
            self,
            FilmError::Png(PngWriteError::Write(_)) | FilmError::Exr(ExrWriteError::Write(_))
        )
    }
}

/// The names of the text attributes in the header of a film's EXR
/// ([`Film::write_exr_with`]).
pub mod exr_attribute {
    /// The paint design's name.
    pub const DESIGN: &str = "coatlab/design";
    /// Samples per pixel (a number, or e.g. "16 mean, adaptive").
    pub const SAMPLES_PER_PIXEL: &str = "coatlab/samplesPerPixel";
    /// The seed of the random numbers.
    pub const SEED: &str = "coatlab/seed";
    /// The wavelengths each path carried ("32 from 386.25 to 773.75 nm"), or
    /// "linear sRGB" for RGB rendering.
    pub const WAVELENGTHS: &str = "coatlab/wavelengths";
    /// The lighting: a setup's name or an environment map's path.
    pub const LIGHTING: &str = "coatlab/lighting";
    /// How the stored colours are adapted (they are not: see [`super::EXR_ADAPTATION`]).
    pub const ADAPTATION: &str = "coatlab/adaptation";
}

/// The [`exr_attribute::ADAPTATION`] of every film's EXR: the values are the
/// film's mean colours as they are, relative to the sRGB white.
pub const EXR_ADAPTATION: &str =
    "none: linear sRGB relative to the D65 white, not adapted to the lighting";

/// What made a film's image, beyond what the film knows, for the header of its
/// EXR. Each `None` leaves its attribute out (the samples per pixel: the film's
/// own count).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RenderRecord {
    /// The paint design's name.
    pub design: Option<String>,
    /// Samples per pixel, where the film's least count does not say it (adaptive
    /// sampling: "16 mean, adaptive").
    pub samples_per_pixel: Option<String>,
    /// The seed of the random numbers.
    pub seed: Option<u64>,
    /// The lighting: a setup's name or an environment map's path.
    pub lighting: Option<String>,
}

/// How [`Film::write_exr_with`] writes: the sample type and compression, and what
/// goes in the header.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ExrOutput {
    /// 32-bit (the default: the values exactly) or 16-bit floats.
    pub precision: ExrPrecision,
    /// The lossless compression (ZIP unless chosen).
    pub compression: ExrCompression,
    /// What made the image, for the header.
    pub record: RenderRecord,
}

/// Per-channel XYZ weights, shared by a film and its tiles.
#[derive(Debug)]
struct Weights {
    channels: Channels,
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
}

impl Weights {
    /// Emission weights on `grid` (see the module docs), scaled so a constant
    /// radiance of 1 has Y = 1.
    ///
    /// Mirrors the hat-basis integration of [`crate::colour::cie::Colorimeter::new`] with the
    /// illuminant left out: each 5 nm table row's x̄, ȳ, z̄ splits between the two grid
    /// samples around it, the end samples' hats extended as constants.
    fn new(channels: Channels) -> Self {
        let grid = match channels {
            Channels::Spectral(grid) => grid,
            Channels::LinearSrgb => {
                // XYZ by the sRGB matrix.
                let rows = xyz_rows_of_linear_srgb();
                let row = |r: usize| rows[r].iter().map(|&v| v as f32).collect();
                return Self {
                    channels,
                    x: row(0),
                    y: row(1),
                    z: row(2),
                };
            }
        };
        let observer = Observer::Cie1931TwoDegree;
        let [x, y, z] = hat_weighted_cmfs(observer, &grid, |_| 1.0);
        // ∫ȳ over 380–780 nm: every table row's hat shares sum to 1, so the ȳ
        // weights of the reference grid add up to it.
        let y_norm: f64 = hat_weighted_cmfs(observer, &WavelengthGrid::reference(), |_| 1.0)[1]
            .iter()
            .sum();
        let scale = |w: Vec<f64>| w.into_iter().map(|v| (v / y_norm) as f32).collect();
        Self {
            channels,
            x: scale(x),
            y: scale(y),
            z: scale(z),
        }
    }

    /// X, Y, Z of `radiance`: three dot products, 8 lanes wide.
    #[inline]
    fn xyz(&self, radiance: &[f32]) -> [f32; 3] {
        assert_eq!(
            radiance.len(),
            self.x.len(),
            "radiance has {} samples but the film has {} channels",
            radiance.len(),
            self.x.len()
        );
        // One dot product after the other: each then compiles to one 8-wide
        // accumulator (done together, the three were interleaved lane by lane,
        // with shuffles). The arithmetic, and so every bit, is the same.
        [
            dot_8_lanes(radiance, &self.x),
            dot_8_lanes(radiance, &self.y),
            dot_8_lanes(radiance, &self.z),
        ]
    }
}

/// Σ aᵢbᵢ over the shorter length, summed in 8 lanes (lane k takes every 8th
/// product from k), the lanes added in order, then the products past the last
/// whole 8 in order.
#[inline(always)]
fn dot_8_lanes(a: &[f32], b: &[f32]) -> f32 {
    const LANES: usize = 8;
    let len = a.len().min(b.len());
    let (a, b) = (&a[..len], &b[..len]);
    let split = len / LANES * LANES;
    let mut lanes = [0.0f32; LANES];
    for (a, b) in a[..split]
        .chunks_exact(LANES)
        .zip(b[..split].chunks_exact(LANES))
    {
        for k in 0..LANES {
            lanes[k] += b[k] * a[k];
        }
    }
    let mut sum: f32 = lanes.iter().sum();
    for (a, b) in a[split..].iter().zip(&b[split..]) {
        sum += b * a;
    }
    sum
}

/// Bits below the point of the film's exact sums (see the module docs).
pub const EXACT_FRACTION_BITS: i32 = 64;

/// `v` in fixed point with [`EXACT_FRACTION_BITS`] fraction bits: exact for
/// |v| ≥ 2⁻⁴¹ (the scaling by a power of two is exact in f64; the conversion cuts
/// towards zero and saturates).
#[inline]
fn to_exact(v: f32) -> i128 {
    (f64::from(v) * 2f64.powi(EXACT_FRACTION_BITS)) as i128
}

/// An exact sum rounded to the nearest f64.
#[inline]
fn from_exact(sum: i128) -> f64 {
    sum as f64 * 2f64.powi(-EXACT_FRACTION_BITS)
}

/// One pixel's running sums: what the display reads (32 bytes). The sums of
/// squares live in a parallel array, so [`Film::to_display`] streams 32 instead of
/// 56 bytes a pixel (it is memory-bound: 29 MB at 1280×720).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct PixelSums {
    /// The exact sums of `exact` rounded to f64.
    sum: [f64; 3],
    count: u64,
}

/// The sums of a pixel's two highest sample-index blocks (see the module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct BlockSums {
    /// The highest block holding a sample (0 also when there is none: its sums
    /// are then 0).
    top: u32,
    /// Σ X, Σ Y, Σ Z of block `top`.
    top_sum: [f64; 3],
    /// Σ X, Σ Y, Σ Z of block `top − 1` (0 when `top` is 0).
    below_sum: [f64; 3],
}

/// Adds `part` to the exact sums `exact` of `pixel` and rounds them into its
/// f64 sums.
#[inline]
fn add_exact(pixel: &mut PixelSums, exact: &mut [i128; 3], part: &[i128; 3]) {
    for k in 0..3 {
        exact[k] = exact[k].saturating_add(part[k]);
        pixel.sum[k] = from_exact(exact[k]);
    }
}

/// Rows of a film's per-pixel sums (each slice the same pixels, row major from
/// the rows' first pixel): what a merge writes, one film's rows or one row of
/// many tiles at a time.
struct FilmRows<'a> {
    pixels: &'a mut [PixelSums],
    exact: &'a mut [[i128; 3]],
    squares: &'a mut [[f64; 3]],
    blocks: &'a mut [BlockSums],
}

impl FilmRows<'_> {
    /// Adds row `row` of `other` (a film inside these rows' film, checked by
    /// [`Film::check_mergeable`]) to the pixels from index `start` on.
    #[inline]
    fn merge_row(&mut self, other: &Film, row: usize, start: usize) {
        let width = other.width as usize;
        let range = row * width..(row + 1) * width;
        let pixels = self.pixels[start..][..width].iter_mut();
        let exact = self.exact[start..][..width].iter_mut();
        let sources = other.pixels[range.clone()]
            .iter()
            .zip(&other.exact[range.clone()]);
        for ((to, to_exact), (from, from_exact)) in pixels.zip(exact).zip(sources) {
            add_exact(to, to_exact, from_exact);
            to.count += from.count;
        }
        for (to, from) in self.squares[start..][..width]
            .iter_mut()
            .zip(&other.squares[range.clone()])
        {
            for k in 0..3 {
                to[k] += from[k];
            }
        }
        for (to, from) in self.blocks[start..][..width]
            .iter_mut()
            .zip(&other.blocks[range])
        {
            to.merge(from);
        }
    }
}

/// The unbiased sample variance over n of a pixel's mean XYZ, per component;
/// `None` below two samples.
#[inline]
fn variance_of_mean(pixel: &PixelSums, squares: &[f64; 3]) -> Option<[f64; 3]> {
    if pixel.count < 2 {
        return None;
    }
    let n = pixel.count as f64;
    Some(std::array::from_fn(|k| {
        let variance = (squares[k] - pixel.sum[k] * pixel.sum[k] / n) / (n - 1.0);
        variance.max(0.0) / n
    }))
}

/// The block of sample index `s`: its bit length (0 for sample 0; samples
/// 2^(k−1) .. 2^k are block k).
#[inline]
fn block_of(s: u64) -> u32 {
    u64::BITS - s.leading_zeros()
}

impl BlockSums {
    #[inline]
    fn add(&mut self, block: u32, xyz: [f64; 3]) {
        // Nearly every sample is in the top block (the next block begins only at
        // the next power of two).
        if block == self.top {
            for (sum, v) in self.top_sum.iter_mut().zip(xyz) {
                *sum += v;
            }
            return;
        }
        self.merge(&BlockSums {
            top: block,
            top_sum: xyz,
            below_sum: [0.0; 3],
        });
    }

    /// These sums and `other`'s, of disjoint samples of the same pixel, as one.
    #[inline]
    fn merge(&mut self, other: &BlockSums) {
        let top = self.top.max(other.top);
        // A part's share of block `top` and of block `top − 1`.
        let share = |part: &BlockSums| -> ([f64; 3], [f64; 3]) {
            if part.top == top {
                (part.top_sum, part.below_sum)
            } else if part.top + 1 == top {
                ([0.0; 3], part.top_sum)
            } else {
                ([0.0; 3], [0.0; 3])
            }
        };
        let (a, b) = (share(self), share(other));
        *self = BlockSums {
            top,
            top_sum: std::array::from_fn(|k| a.0[k] + b.0[k]),
            below_sum: std::array::from_fn(|k| a.1[k] + b.1[k]),
        };
    }

    /// The estimated error of the mean XYZ of `pixel` (whose samples are 0 ..
    /// count, these its block sums): half the difference of the means of samples
    /// 0 .. P/2 and P/2 .. P, P the largest power of two ≤ count, times √(P / n).
    /// `None` below two samples.
    fn error_of_mean(&self, pixel: &PixelSums) -> Option<[f64; 3]> {
        if pixel.count < 2 {
            return None;
        }
        let n = pixel.count;
        let p = 1u64 << (u64::BITS - 1 - n.leading_zeros());
        // Samples P/2 .. P are block log2(P); samples P .. n (if any) the block
        // above it, the highest.
        let (second, rest) = if p == n {
            (self.top_sum, [0.0; 3])
        } else {
            (self.below_sum, self.top_sum)
        };
        let half = (p / 2) as f64;
        let scale = 0.5 * (p as f64 / n as f64).sqrt();
        Some(std::array::from_fn(|k| {
            let first = pixel.sum[k] - second[k] - rest[k];
            (first / half - second[k] / half) * scale
        }))
    }
}

/// An accumulation buffer: a whole image, or a tile of one (see the module docs).
///
/// Pixel coordinates are always those of the whole image (x right, y down), also
/// for a tile, which covers `origin .. origin + size`.
#[derive(Debug, Clone)]
pub struct Film {
    weights: Arc<Weights>,
    image_width: u32,
    image_height: u32,
    origin: [u32; 2],
    width: u32,
    height: u32,
    pixels: Vec<PixelSums>,
    /// Σ X, Σ Y, Σ Z per pixel in fixed point (see the module docs), parallel to
    /// `pixels`: the sums the image is made of.
    exact: Vec<[i128; 3]>,
    /// Σ X², Σ Y², Σ Z² per pixel, parallel to `pixels`.
    squares: Vec<[f64; 3]>,
    /// The sums of the two highest sample-index blocks per pixel (see the module
    /// docs), parallel to `pixels`.
    blocks: Vec<BlockSums>,
    rejected: u64,
}

impl Film {
    /// An empty film of `width` × `height` pixels for radiance on `channels` (a
    /// wavelength grid, or linear sRGB).
    pub fn new(width: u32, height: u32, channels: impl Into<Channels>) -> Self {
        Self::empty(
            Arc::new(Weights::new(channels.into())),
            [width, height],
            [0, 0],
            width,
            height,
        )
    }

    /// An empty film of `width` × `height` pixels at `origin` of an image of
    /// `image` = [width, height] pixels: what [`Film::new`] and [`Film::tile`] share.
    fn empty(
        weights: Arc<Weights>,
        image: [u32; 2],
        origin: [u32; 2],
        width: u32,
        height: u32,
    ) -> Self {
        let count = width as usize * height as usize;
        Self {
            weights,
            image_width: image[0],
            image_height: image[1],
            origin,
            width,
            height,
            pixels: vec![PixelSums::default(); count],
            exact: vec![[0; 3]; count],
            squares: vec![[0.0; 3]; count],
            blocks: vec![BlockSums::default(); count],
            rejected: 0,
        }
    }

    /// An empty tile covering `x0 .. x0 + width`, `y0 .. y0 + height` of this film's
    /// image (clipped to it), sharing its grid and weights.
    pub fn tile(&self, x0: u32, y0: u32, width: u32, height: u32) -> Film {
        let x0 = x0.min(self.image_width);
        let y0 = y0.min(self.image_height);
        let width = width.min(self.image_width - x0);
        let height = height.min(self.image_height - y0);
        Film::empty(
            Arc::clone(&self.weights),
            [self.image_width, self.image_height],
            [x0, y0],
            width,
            height,
        )
    }

    /// Empty tiles of `size` × `size` pixels (smaller at the right and bottom edges)
    /// covering this film's region, row by row. A size of 0 is taken as 1.
    pub fn tiles(&self, size: u32) -> Vec<Film> {
        let size = size.max(1);
        let mut tiles = Vec::new();
        for y0 in (self.origin[1]..self.origin[1] + self.height).step_by(size as usize) {
            for x0 in (self.origin[0]..self.origin[0] + self.width).step_by(size as usize) {
                let w = size.min(self.origin[0] + self.width - x0);
                let h = size.min(self.origin[1] + self.height - y0);
                tiles.push(self.tile(x0, y0, w, h));
            }
        }
        tiles
    }

    /// Adds `other`'s sums (a tile of this film, or another pass over the same
    /// region) into this film.
    ///
    /// # Panics
    /// If `other` is for a different grid or image size, or covers pixels outside
    /// this film's region (programming errors).
    pub fn merge(&mut self, other: &Film) {
        self.check_mergeable(other);
        let width = self.width as usize;
        let column = (other.origin[0] - self.origin[0]) as usize;
        let first_row = (other.origin[1] - self.origin[1]) as usize;
        let mut rows = self.rows_mut();
        for row in 0..other.height as usize {
            rows.merge_row(other, row, (first_row + row) * width + column);
        }
        self.rejected += other.rejected;
    }

    /// [`Self::merge`] of every film of `tiles` (disjoint or not), its rows in
    /// parallel: after each progressive pass the whole image's tiles are merged
    /// while the tracer's threads would otherwise wait. Each pixel takes its
    /// tiles' sums in the order of `tiles`, so the film is bit for bit that of
    /// merging them one by one, whatever the thread count.
    ///
    /// # Panics
    /// As [`Self::merge`], for any of `tiles`.
    pub fn merge_tiles(&mut self, tiles: &[Film]) {
        use rayon::prelude::*;
        for tile in tiles {
            self.check_mergeable(tile);
        }
        // A film of no columns has no pixels, so no chunks either.
        let (width, [origin_x, origin_y]) = (self.width.max(1) as usize, self.origin);
        let rows = (self.pixels.par_chunks_mut(width))
            .zip(self.exact.par_chunks_mut(width))
            .zip(self.squares.par_chunks_mut(width))
            .zip(self.blocks.par_chunks_mut(width));
        rows.enumerate()
            .for_each(|(y, (((pixels, exact), squares), blocks))| {
                let mut row = FilmRows {
                    pixels,
                    exact,
                    squares,
                    blocks,
                };
                let image_y = origin_y + y as u32;
                for tile in tiles {
                    if let Some(tile_row) = image_y.checked_sub(tile.origin[1])
                        && tile_row < tile.height
                    {
                        let column = (tile.origin[0] - origin_x) as usize;
                        row.merge_row(tile, tile_row as usize, column);
                    }
                }
            });
        self.rejected += tiles.iter().map(|t| t.rejected).sum::<u64>();
    }

    /// The checks of [`Self::merge`] (see its panics).
    fn check_mergeable(&self, other: &Film) {
        assert!(
            self.weights.channels == other.weights.channels,
            "merging films on different channels"
        );
        assert!(
            (self.image_width, self.image_height) == (other.image_width, other.image_height),
            "merging films of different image sizes"
        );
        let inside = other.origin[0] >= self.origin[0]
            && other.origin[1] >= self.origin[1]
            && other.origin[0] + other.width <= self.origin[0] + self.width
            && other.origin[1] + other.height <= self.origin[1] + self.height;
        assert!(
            inside,
            "merging a film that is not inside this one's region"
        );
    }

    /// The per-pixel sums of every row of this film's region.
    fn rows_mut(&mut self) -> FilmRows<'_> {
        FilmRows {
            pixels: &mut self.pixels,
            exact: &mut self.exact,
            squares: &mut self.squares,
            blocks: &mut self.blocks,
        }
    }

    /// Accumulates one sample of spectral radiance (on the film's grid) at pixel
    /// (`x`, `y`) of the image, as the pixel's next sample: its index is the
    /// pixel's sample count so far (right for a film filled in sample order; a tile
    /// of a later pass uses [`Self::add_sample_indexed`]). A sample whose XYZ is
    /// not finite counts as a sample of zero and in [`Self::rejected_samples`], so
    /// one NaN cannot blacken a pixel for good.
    ///
    /// # Panics
    /// If `radiance` has the wrong length or the pixel is outside this film's region.
    #[inline]
    pub fn add_sample(&mut self, x: u32, y: u32, radiance: &[f32]) {
        let count = self.pixels[self.index(x, y)].count;
        self.add_sample_indexed(x, y, count, radiance);
    }

    /// [`Self::add_sample`] for the pixel's sample `sample_index` (its index in
    /// the pixel's whole sequence, which runs on across passes): it says which
    /// block of the [noise estimate](Self::noise_estimate) it goes to.
    ///
    /// # Panics
    /// As [`Self::add_sample`].
    #[inline]
    pub fn add_sample_indexed(&mut self, x: u32, y: u32, sample_index: u64, radiance: &[f32]) {
        let mut xyz = self.weights.xyz(radiance);
        if !xyz.iter().all(|v| v.is_finite()) {
            self.rejected += 1;
            xyz = [0.0; 3];
        }
        let index = self.index(x, y);
        let pixel = &mut self.pixels[index];
        add_exact(pixel, &mut self.exact[index], &xyz.map(to_exact));
        let squares = &mut self.squares[index];
        for (k, &v) in xyz.iter().enumerate() {
            let v = f64::from(v);
            squares[k] += v * v;
        }
        pixel.count += 1;
        self.blocks[index].add(block_of(sample_index), xyz.map(f64::from));
    }

    /// The XYZ (white at Y = 1) of `radiance`, as [`Self::add_sample`] would add it.
    pub fn xyz_of(&self, radiance: &[f32]) -> Xyz {
        let [x, y, z] = self.weights.xyz(radiance).map(f64::from);
        Xyz::new(x, y, z)
    }

    /// Mean XYZ of pixel (`x`, `y`); zero before any sample.
    pub fn mean_xyz(&self, x: u32, y: u32) -> Xyz {
        let p = &self.pixels[self.index(x, y)];
        if p.count == 0 {
            return Xyz::new(0.0, 0.0, 0.0);
        }
        let n = p.count as f64;
        Xyz::new(p.sum[0] / n, p.sum[1] / n, p.sum[2] / n)
    }

    /// Estimated variance of [`Self::mean_xyz`] per component: the unbiased sample
    /// variance over n. Infinite below 2 samples (no estimate: sample more).
    ///
    /// s²/n is the variance of the mean of n independent samples; the sampler's
    /// are stratified (Owen-scrambled Sobol points, [`crate::render::sampler`]),
    /// so the mean's actual variance is smaller and s²/n over-states it, the
    /// more the more samples. Measured against the spread of independent renders
    /// (`tests/render.rs`, `film_variance_overstates_the_replica_spread`: the
    /// grey car in the studio, 16 seeds): the median over pixels ×3.2 at 16
    /// samples and ×5.2 at 64 (quartiles ×2.3–4.3 and ×3.5–7.2, the same in X, Y
    /// and Z), ×1.2 at 4 and ×8 at 256; the image sums ×2.5–2.8, because the
    /// noisiest pixels (bright, rare paths) gain least. A Z-test on it is no
    /// honest Z-test: the image tests use replicas (`tests/support/image_stats.rs`).
    /// It is a per-pixel relative measure for adaptive sampling and the re-shade
    /// blend, which is what it is used for; [`Self::noise_estimate`] is the
    /// error estimate shown to a designer.
    pub fn variance_of_mean_xyz(&self, x: u32, y: u32) -> [f64; 3] {
        let index = self.index(x, y);
        variance_of_mean(&self.pixels[index], &self.squares[index]).unwrap_or([f64::INFINITY; 3])
    }

    /// Number of samples at pixel (`x`, `y`).
    pub fn sample_count(&self, x: u32, y: u32) -> u64 {
        self.pixels[self.index(x, y)].count
    }

    /// The smallest per-pixel sample count (the progressive pass count when every
    /// pixel gets one sample a pass); 0 for an empty film.
    pub fn samples_per_pixel(&self) -> u64 {
        self.pixels.iter().map(|p| p.count).min().unwrap_or(0)
    }

    /// Samples that had a non-finite XYZ and were counted as zero.
    pub fn rejected_samples(&self) -> u64 {
        self.rejected
    }

    /// Forgets every sample (a parameter changed: restart accumulation).
    pub fn clear(&mut self) {
        // In parallel: a paint edit clears a whole-image film (tens of MB) on the
        // way to its first image (`ProgressiveRender::edit_shading`).
        use rayon::prelude::*;
        const CHUNK: usize = 1 << 14;
        rayon::join(
            || {
                rayon::join(
                    || {
                        self.pixels
                            .par_chunks_mut(CHUNK)
                            .for_each(|c| c.fill(PixelSums::default()))
                    },
                    || {
                        self.exact
                            .par_chunks_mut(CHUNK)
                            .for_each(|c| c.fill([0; 3]))
                    },
                )
            },
            || {
                rayon::join(
                    || {
                        self.squares
                            .par_chunks_mut(CHUNK)
                            .for_each(|c| c.fill([0.0; 3]))
                    },
                    || {
                        self.blocks
                            .par_chunks_mut(CHUNK)
                            .for_each(|c| c.fill(BlockSums::default()))
                    },
                )
            },
        );
        self.rejected = 0;
    }

    /// The channels radiance samples must be on: a wavelength grid, or linear sRGB.
    pub fn channels(&self) -> &Channels {
        &self.weights.channels
    }

    /// Width of this film's region, pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height of this film's region, pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Top-left pixel of this film's region in the image ((0, 0) unless a tile).
    pub fn origin(&self) -> [u32; 2] {
        self.origin
    }

    /// Mean linear sRGB (D65 white, Y = 1 → (1, 1, 1)) of pixel (`x`, `y`), shown
    /// as it is: no adaptation, exposure or tone mapping, not clamped. What
    /// [`Self::write_exr`] stores.
    pub fn mean_linear_srgb(&self, x: u32, y: u32) -> LinSrgb<f32> {
        let m = display_matrix(None, 0.0);
        let xyz = self.mean_xyz(x, y);
        let [r, g, b] = mul(&m, [xyz.x as f32, xyz.y as f32, xyz.z as f32]);
        LinSrgb::new(r, g, b)
    }

    /// [`Self::mean_linear_srgb`] of every pixel of this film's region, row-major
    /// from the top-left (black where there are no samples).
    pub fn linear_srgb_image(&self) -> Vec<LinSrgb<f32>> {
        let m = display_matrix(None, 0.0);
        self.pixels
            .iter()
            .map(|p| {
                let n = p.count.max(1) as f64;
                let [r, g, b] = mul(&m, p.sum.map(|s| (s / n) as f32));
                LinSrgb::new(r, g, b)
            })
            .collect()
    }

    /// The exposure (stops) that brings the log-average luminance of the sampled
    /// pixels, exp(mean ln(δ + Y)) with δ = 10⁻⁶, to [`AUTO_EXPOSURE_KEY`]
    /// (Reinhard et al. 2002). 0 before any sample.
    pub fn auto_exposure(&self) -> f32 {
        let (mut log_sum, mut count) = (0.0f64, 0usize);
        for p in self.pixels.iter().filter(|p| p.count > 0) {
            let luminance = (p.sum[1] / p.count as f64).max(0.0);
            log_sum += (1e-6 + luminance).ln();
            count += 1;
        }
        if count == 0 {
            return 0.0;
        }
        let log_average = (log_sum / count as f64).exp();
        (AUTO_EXPOSURE_KEY / log_average).log2() as f32
    }

    /// The displayable image of this film's region: 8-bit sRGB, alpha 255,
    /// row-major from the top-left. Pixels without samples are black.
    pub fn to_display_srgba(&self, settings: &DisplaySettings) -> Vec<Srgba<u8>> {
        use rayon::prelude::*;
        let m = display_matrix(settings.adapt_white, settings.exposure_stops);
        let lut = encode_lut();
        // In parallel: the preview converts every pass's film while the tracer's
        // threads wait for the next pass.
        self.pixels
            .par_iter()
            .map(|p| {
                if p.count == 0 {
                    return Srgba::new(0, 0, 0, 255);
                }
                let inv_n = 1.0 / p.count as f64;
                let xyz = p.sum.map(|s| (s * inv_n) as f32);
                let rgb = tone_map(mul(&m, xyz), settings.tone_mapping);
                let [r, g, b] = rgb.map(|v| encode(lut, v));
                Srgba::new(r, g, b, 255)
            })
            .collect()
    }

    /// [`Self::to_display_srgba`] as plain RGBA bytes, the form GPU textures
    /// (egui's `ColorImage`) take; the same memory, not a copy.
    pub fn to_display(&self, settings: &DisplaySettings) -> Vec<[u8; 4]> {
        palette::cast::into_array_vec(self.to_display_srgba(settings))
    }

    /// CIELAB (D65 white, display white L* = 100) of the colour pixel (`x`, `y`) is
    /// shown in by [`Self::to_display`] before 8-bit quantisation: what a viewer
    /// sees, and what the error of a render is measured on.
    pub fn display_lab(&self, x: u32, y: u32, settings: &DisplaySettings) -> Lab {
        DisplayTransform::of(settings).lab_of_xyz(self.mean_xyz(x, y))
    }

    /// How far the displayed picture still is from the converged one: per pixel,
    /// the CIEDE2000 between the displayed colour of the mean and that of the mean
    /// moved by the pixel's error estimate from the two halves of its largest
    /// power-of-two prefix of P samples (see the module docs):
    /// (m_A − m_B) / 2 · √(P / n), which for independent samples has the spread of
    /// the mean's own error and for the sampler's stratified points follows their
    /// faster convergence. Over every `stride`-th pixel in both directions that has at
    /// least two samples; `None` before that. A single pixel's figure is one
    /// degree of freedom: only the mean over many pixels is an estimate; the 95th
    /// percentile mixes the pixels' spread with that per-pixel noise.
    pub fn noise_estimate(&self, settings: &DisplaySettings, stride: u32) -> Option<NoiseEstimate> {
        use rayon::prelude::*;
        let transform = DisplayTransform::of(settings);
        let stride = stride.max(1) as usize;
        // Rows in parallel (the preview asks after every pass), collected in
        // order, so the figures do not depend on the thread count.
        let mut errors: Vec<f64> = (0..self.height as usize)
            .into_par_iter()
            .step_by(stride)
            .flat_map_iter(|y| {
                (0..self.width as usize)
                    .step_by(stride)
                    .filter_map(move |x| {
                        let index = y * self.width as usize + x;
                        let p = &self.pixels[index];
                        let error = self.blocks[index].error_of_mean(p)?;
                        let n = p.count as f64;
                        let mean = p.sum.map(|s| s / n);
                        let a = transform.lab_of_xyz(Xyz::new(mean[0], mean[1], mean[2]));
                        let b = transform.lab_of_xyz(Xyz::new(
                            mean[0] + error[0],
                            mean[1] + error[1],
                            mean[2] + error[2],
                        ));
                        Some(ciede2000(a, b)).filter(|delta| delta.is_finite())
                    })
            })
            .collect();
        if errors.is_empty() {
            return None;
        }
        errors.sort_by(f64::total_cmp);
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        let p95 = errors[((errors.len() - 1) as f64 * 0.95).round() as usize];
        Some(NoiseEstimate {
            mean_delta_e: mean,
            p95_delta_e: p95,
            pixels: errors.len(),
        })
    }

    /// The perceptual noise of one sample, per pixel of this film's region (row
    /// major): √n times the CIEDE2000 between the displayed colour of the pixel's
    /// mean of n samples and that of the mean moved by one standard error in X, Y
    /// and Z, up or down, whichever moves it more (a mean moved up may be clipped
    /// white already; one moved down is held at 0). So the error of the mean after
    /// n samples is about this over √n, the slope of ΔE00 taken at the current
    /// error rather than at a whole sample's deviation, which would saturate for
    /// the rare bright samples of a caustic (a deviation many times the mean).
    /// What adaptive sampling ([`crate::render::adaptive`]) spends samples by.
    /// `f32::INFINITY` where a pixel has fewer than two samples (no estimate yet).
    /// Pixels in parallel; the result does not depend on the thread count.
    pub fn sample_delta_e(&self, settings: &DisplaySettings) -> Vec<f32> {
        use rayon::prelude::*;
        let transform = DisplayTransform::of(settings);
        self.pixels
            .par_iter()
            .zip(self.squares.par_iter())
            .map(|(p, squares)| {
                let Some(variance) = variance_of_mean(p, squares) else {
                    return f32::INFINITY;
                };
                let n = p.count as f64;
                // The mean is never negative (nor are its samples' X, Y, Z).
                transform.sample_noise(p.sum.map(|s| s / n), variance, n)
            })
            .collect()
    }

    /// Writes [`Self::to_display_srgba`] as an 8-bit sRGB PNG (with an sRGB chunk),
    /// atomically ([`crate::io::png_write`]).
    pub fn write_png(&self, path: &Path, settings: &DisplaySettings) -> Result<(), FilmError> {
        self.check_not_empty(path)?;
        let rgb: Vec<Srgb<u8>> = self
            .to_display_srgba(settings)
            .into_iter()
            .map(|p| p.color)
            .collect();
        write_srgb8_png(path, self.width, self.height, &rgb)?;
        Ok(())
    }

    /// [`Self::write_exr_with`] with the default output (32-bit floats, ZIP) and
    /// only what the film itself knows in the header.
    pub fn write_exr(&self, path: &Path) -> Result<(), FilmError> {
        self.write_exr_with(path, &ExrOutput::default())
    }

    /// Writes the mean linear sRGB ([`Self::linear_srgb_image`]: D65 white, Y = 1 →
    /// (1, 1, 1), unadapted, no exposure or tone mapping, unclamped, so
    /// out-of-gamut colours keep their negative components) as a single-part
    /// scanline OpenEXR file with R, G, B channels and the sRGB `chromaticities`,
    /// atomically ([`crate::io::exr_write`]); the header's text attributes say
    /// what made it ([`Self::exr_attributes`]).
    ///
    /// Linear sRGB rather than XYZ: it is the convention EXR viewers assume, and XYZ
    /// is one matrix away for analysis (or [`Self::mean_xyz`] in code).
    pub fn write_exr_with(&self, path: &Path, output: &ExrOutput) -> Result<(), FilmError> {
        self.check_not_empty(path)?;
        write_linear_exr(
            path,
            (self.width, self.height),
            &self.linear_srgb_image(),
            output,
            self.exr_attributes(&output.record),
        )
    }

    /// The header attributes of this film's EXR, (name, text): those of
    /// [`exr_attribute`] that `record` or the film knows, in that module's order.
    /// The samples per pixel are the film's least count unless `record` says
    /// otherwise; the wavelengths and the adaptation are the film's.
    pub fn exr_attributes(&self, record: &RenderRecord) -> Vec<(String, String)> {
        let wavelengths = match self.channels() {
            Channels::LinearSrgb => "linear sRGB".to_owned(),
            Channels::Spectral(grid) => format!(
                "{} from {} to {} nm",
                grid.len(),
                short_nm(grid.start_nm()),
                short_nm(grid.end_nm())
            ),
        };
        let samples = record
            .samples_per_pixel
            .clone()
            .unwrap_or_else(|| self.samples_per_pixel().to_string());
        let attributes = [
            (exr_attribute::DESIGN, record.design.clone()),
            (exr_attribute::SAMPLES_PER_PIXEL, Some(samples)),
            (exr_attribute::SEED, record.seed.map(|s| s.to_string())),
            (exr_attribute::WAVELENGTHS, Some(wavelengths)),
            (exr_attribute::LIGHTING, record.lighting.clone()),
            (exr_attribute::ADAPTATION, Some(EXR_ADAPTATION.to_owned())),
        ];
        attributes
            .into_iter()
            .filter_map(|(name, value)| Some((name.to_owned(), value?)))
            .collect()
    }

    fn check_not_empty(&self, path: &Path) -> Result<(), FilmError> {
        check_not_empty(path, self.width, self.height)
    }

    #[inline]
    fn index(&self, x: u32, y: u32) -> usize {
        let (dx, dy) = (
            x.wrapping_sub(self.origin[0]),
            y.wrapping_sub(self.origin[1]),
        );
        assert!(
            dx < self.width && dy < self.height,
            "pixel ({x}, {y}) is outside the film region {:?} + {}×{}",
            self.origin,
            self.width,
            self.height
        );
        dy as usize * self.width as usize + dx as usize
    }
}

/// Writes mean XYZ values (`width` × `height`, row-major from the top-left) as
/// [`display_xyz`] shows them, as an 8-bit sRGB PNG, atomically: the export of
/// an image that is not a film (a re-shaded view), as [`Film::write_png`] writes
/// a film's.
pub fn write_xyz_png(
    path: &Path,
    width: u32,
    height: u32,
    xyz: &[[f32; 3]],
    settings: &DisplaySettings,
) -> Result<(), FilmError> {
    check_not_empty(path, width, height)?;
    let rgb: Vec<Srgb<u8>> = display_xyz_srgba(xyz, settings)
        .into_iter()
        .map(|p| p.color)
        .collect();
    write_srgb8_png(path, width, height, &rgb)?;
    Ok(())
}

/// Writes mean XYZ values (`width` × `height`, row-major from the top-left) as
/// [`Film::write_exr_with`] writes a film's means: linear sRGB relative to the
/// D65 white, unexposed, untone-mapped and unclamped, with `attributes` in the
/// header. The export of an image that is not one film's means (a comparison
/// pane blended from two films), linear as a film's EXR is.
pub fn write_xyz_exr(
    path: &Path,
    width: u32,
    height: u32,
    xyz: &[[f32; 3]],
    output: &ExrOutput,
    attributes: Vec<(String, String)>,
) -> Result<(), FilmError> {
    check_not_empty(path, width, height)?;
    let m = display_matrix(None, 0.0);
    let rgb: Vec<LinSrgb<f32>> = xyz
        .iter()
        .map(|&v| {
            let [r, g, b] = mul(&m, v);
            LinSrgb::new(r, g, b)
        })
        .collect();
    write_linear_exr(path, (width, height), &rgb, output, attributes)
}

/// An image of no pixels cannot be written: the error naming `path`.
fn check_not_empty(path: &Path, width: u32, height: u32) -> Result<(), FilmError> {
    if width == 0 || height == 0 {
        return Err(FilmError::EmptyImage {
            path: path.to_owned(),
            width,
            height,
        });
    }
    Ok(())
}

/// Writes linear sRGB pixels of a `size` image as `output` says, with
/// `attributes` in the header: what a film's EXR and a blended image's share.
fn write_linear_exr(
    path: &Path,
    (width, height): (u32, u32),
    rgb: &[LinSrgb<f32>],
    output: &ExrOutput,
    attributes: Vec<(String, String)>,
) -> Result<(), FilmError> {
    let options = ExrOptions {
        precision: output.precision,
        compression: output.compression,
        attributes,
    };
    write_linear_srgb_exr(path, width as usize, height as usize, rgb, &options)?;
    Ok(())
}

/// The noise left in a progressive render, as CIEDE2000 of the displayed colours.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseEstimate {
    /// Mean over the pixels looked at.
    pub mean_delta_e: f64,
    /// 95th percentile over them.
    pub p95_delta_e: f64,
    /// How many pixels were looked at.
    pub pixels: usize,
}

/// A wavelength with at most two decimals and no trailing zeros ("380",
/// "386.25", "446.67").
fn short_nm(nm: f64) -> String {
    let text = format!("{nm:.2}");
    text.trim_end_matches('0').trim_end_matches('.').to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::srgb_from_linear;
    use palette::LinSrgb;

    #[test]
    fn encode_lut_matches_the_srgb_curve() {
        let lut = encode_lut();
        for i in 0..=20_000 {
            let v = i as f32 / 20_000.0;
            let exact = srgb_from_linear(LinSrgb::new(f64::from(v), 0.0, 0.0)).red * 255.0;
            let code = f64::from(encode(lut, v));
            assert!((code - exact).abs() <= 0.53, "{v}: {code} vs {exact}");
        }
        assert_eq!(encode(lut, f32::NAN), 0);
        assert_eq!(encode(lut, -1.0), 0);
        assert_eq!(encode(lut, 7.0), 255);
    }

    /// The block sums: samples go to block bit_length(index) (by the pixel's own
    /// count in [`Film::add_sample`], by the given index in
    /// [`Film::add_sample_indexed`], as a tile of a later pass needs, its own count
    /// starting at 0); the two highest blocks are kept, carried bit for bit
    /// through tiles and merges in any order, and gone after a clear.
    #[test]
    fn block_sums_follow_the_sample_index_through_tiles_and_merges() {
        assert_eq!([0, 1, 2, 3, 4, 7, 8].map(block_of), [0, 1, 2, 2, 3, 3, 4]);
        let grid = WavelengthGrid::visible(4).unwrap();
        let (width, height) = (5u32, 3u32);
        let value = |x: u32, y: u32, s: u64| vec![0.1 + (x + 7 * y) as f32 * 0.03 + s as f32; 4];
        // Serially, five samples a pixel (blocks 0, 1, 2, 2, 3).
        let mut serial = Film::new(width, height, grid);
        for s in 0..5 {
            for y in 0..height {
                for x in 0..width {
                    serial.add_sample(x, y, &value(x, y, s));
                }
            }
        }
        for y in 0..height {
            for x in 0..width {
                let xyz = |s| serial.xyz_of(&value(x, y, s)).y;
                let blocks = serial.blocks[serial.index(x, y)];
                assert_eq!(blocks.top, 3);
                assert!((blocks.top_sum[1] - xyz(4)).abs() < 1e-9 * xyz(4));
                let below = xyz(2) + xyz(3);
                assert!((blocks.below_sum[1] - below).abs() < 1e-9 * below);
            }
        }
        // Two passes (samples 0–1, then 2–4) through 2×2 tiles, merged; and the
        // same samples added to one film in reverse order.
        let mut tiled = Film::new(width, height, grid);
        for pass in [0..2u64, 2..5] {
            let mut tiles = tiled.tiles(2);
            for tile in &mut tiles {
                let [x0, y0] = tile.origin();
                for y in y0..y0 + tile.height() {
                    for x in x0..x0 + tile.width() {
                        for s in pass.clone() {
                            tile.add_sample_indexed(x, y, s, &value(x, y, s));
                        }
                    }
                }
            }
            for tile in tiles.iter().rev() {
                tiled.merge(tile);
            }
        }
        let mut reversed = Film::new(width, height, grid);
        for s in (0..5).rev() {
            for y in 0..height {
                for x in 0..width {
                    reversed.add_sample_indexed(x, y, s, &value(x, y, s));
                }
            }
        }
        for y in 0..height {
            for x in 0..width {
                let i = serial.index(x, y);
                assert_eq!(serial.blocks[i], tiled.blocks[i]);
                let (a, b) = (serial.blocks[i], reversed.blocks[i]);
                assert_eq!(a.top, b.top);
                for k in 0..3 {
                    assert!((a.top_sum[k] - b.top_sum[k]).abs() <= 1e-12 * a.top_sum[k].abs());
                    assert!(
                        (a.below_sum[k] - b.below_sum[k]).abs() <= 1e-12 * a.below_sum[k].abs()
                    );
                }
            }
        }
        let display = DisplaySettings::default();
        let (a, b) = (
            serial.noise_estimate(&display, 1).unwrap(),
            tiled.noise_estimate(&display, 1).unwrap(),
        );
        assert!(a.mean_delta_e > 0.0);
        assert!((a.mean_delta_e - b.mean_delta_e).abs() < 1e-9 * a.mean_delta_e);
        tiled.clear();
        assert!(tiled.blocks.iter().all(|b| *b == BlockSums::default()));
        assert_eq!(tiled.noise_estimate(&display, 1), None);
    }

    /// The estimate of one pixel by hand: samples 0 .. 4 and a fifth, P = 4, the
    /// error of the first four samples' mean taken as half the difference of
    /// samples 0–1's and 2–3's means, scaled by √(4/5).
    /// Merging a pass's tiles in parallel gives the film of merging them one
    /// by one, bit for bit: on a sub-region of an image (tiles of uneven sizes
    /// at its edges), with a second pass over the region among the "tiles" (so
    /// pixels take two parts, in the list's order), and rejected samples.
    #[test]
    fn merging_tiles_in_parallel_is_merging_them_one_by_one() {
        let grid = WavelengthGrid::visible(4).unwrap();
        let image = Film::new(23, 17, grid);
        let region = image.tile(3, 2, 19, 13);
        let fill = |film: &mut Film, salt: u32| {
            let [x0, y0] = film.origin();
            for y in y0..y0 + film.height() {
                for x in x0..x0 + film.width() {
                    for s in 0..3 {
                        let v = 0.1 + ((x * 31 + y * 7 + s * 3 + salt) % 17) as f32 * 0.37;
                        film.add_sample(x, y, &[v, 2.0 * v, 0.5 * v, v * v]);
                    }
                }
            }
        };
        let mut parts = region.tiles(5);
        for (k, tile) in parts.iter_mut().enumerate() {
            fill(tile, k as u32);
        }
        let mut whole_pass = region.tile(3, 2, 19, 13);
        fill(&mut whole_pass, 99);
        whole_pass.add_sample(4, 3, &[f32::NAN; 4]);
        parts.insert(3, whole_pass);
        let mut one_by_one = region.tile(3, 2, 19, 13);
        for part in &parts {
            one_by_one.merge(part);
        }
        let mut parallel = region.tile(3, 2, 19, 13);
        parallel.merge_tiles(&parts);
        assert_eq!(parallel.pixels, one_by_one.pixels);
        assert_eq!(parallel.exact, one_by_one.exact);
        assert_eq!(parallel.blocks, one_by_one.blocks);
        let bits = |film: &Film| -> Vec<u64> {
            film.squares.iter().flatten().map(|v| v.to_bits()).collect()
        };
        assert_eq!(bits(&parallel), bits(&one_by_one));
        assert_eq!(parallel.rejected_samples(), 1);
        assert_eq!(one_by_one.rejected_samples(), 1);
    }

    #[test]
    fn error_of_mean_is_the_half_difference_of_the_prefix_halves() {
        let grid = Channels::LinearSrgb;
        let mut film = Film::new(1, 1, grid);
        let ys = [1.0f32, 3.0, 2.0, 6.0, 100.0];
        for y in ys {
            film.add_sample(0, 0, &[y, y, y]);
        }
        let y_of = |v: f32| film.xyz_of(&[v, v, v]).y;
        let error = film.blocks[0].error_of_mean(&film.pixels[0]).unwrap();
        let expected = ((y_of(1.0) + y_of(3.0)) / 2.0 - (y_of(2.0) + y_of(6.0)) / 2.0) / 2.0
            * (4.0f64 / 5.0).sqrt();
        assert!(
            (error[1] - expected).abs() < 1e-9,
            "{} vs {expected}",
            error[1]
        );
        let mut one = Film::new(1, 1, grid);
        one.add_sample(0, 0, &[1.0; 3]);
        assert_eq!(one.blocks[0].error_of_mean(&one.pixels[0]), None);
    }

    /// For independent samples the half-difference estimate agrees with the error
    /// actually left, as the variance-based one does: 2500 grey pixels of n iid
    /// uniform samples (n a power of two and not), mean ΔE00 of the displayed colour to the
    /// true mean's against the estimate, within 10 % (each mean has a relative
    /// standard error of about 1.5 %). Equal samples in both halves give 0.
    #[test]
    fn half_difference_estimate_matches_the_error_of_iid_samples() {
        use rand::{RngExt, SeedableRng};
        let grid = WavelengthGrid::visible(8).unwrap();
        let display = DisplaySettings {
            tone_mapping: ToneMapping::Clip,
            ..DisplaySettings::default()
        };
        let (width, height) = (50u32, 50u32);
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        for n in [16, 7] {
            let mut film = Film::new(width, height, grid);
            for y in 0..height {
                for x in 0..width {
                    for _ in 0..n {
                        let c: f32 = 0.2 + 0.4 * rng.random::<f32>();
                        film.add_sample(x, y, &vec![c; grid.len()]);
                    }
                }
            }
            let truth = display_lab_of_xyz(film.xyz_of(&vec![0.4; grid.len()]), &display);
            let mut actual = 0.0;
            for y in 0..height {
                for x in 0..width {
                    actual += ciede2000(film.display_lab(x, y, &display), truth);
                }
            }
            actual /= f64::from(width * height);
            let estimate = film.noise_estimate(&display, 1).unwrap();
            assert_eq!(estimate.pixels, (width * height) as usize);
            let ratio = estimate.mean_delta_e / actual;
            println!("iid, n {n}: estimate / actual {ratio:.3}");
            assert!(
                (ratio - 1.0).abs() < 0.1,
                "n {n}: estimate {} vs actual {actual}",
                estimate.mean_delta_e
            );
        }
        let mut flat = Film::new(1, 1, grid);
        for _ in 0..4 {
            flat.add_sample(0, 0, &vec![0.3; grid.len()]);
        }
        assert_eq!(flat.noise_estimate(&display, 1).unwrap().mean_delta_e, 0.0);
    }

    /// Input/output pairs of the Khronos PBR Neutral specification's equations,
    /// evaluated apart in f64: the range where only the offset acts (a colour in
    /// [0.08, 0.8] less F90), the quadratic offset below 2 F90, the compressed
    /// white (1 → 0.869 09, 10 → 0.993 90) and saturated highlights.
    #[test]
    fn pbr_neutral_matches_the_specification_at_reference_points() {
        let pairs: [([f32; 3], [f32; 3]); 8] = [
            ([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
            ([0.5, 0.3, 0.2], [0.46, 0.26, 0.16]),
            ([0.8, 0.8, 0.8], [0.76, 0.76, 0.76]),
            ([0.02, 0.5, 0.5], [0.0025, 0.4825, 0.4825]),
            ([1.0, 1.0, 1.0], [0.869_090_9; 3]),
            ([10.0, 10.0, 10.0], [0.993_898_3; 3]),
            ([2.0, 1.0, 0.5], [0.96, 0.534_090_5, 0.321_135_8]),
            ([4.0, 0.2, 0.1], [0.983_255_8, 0.330_977_4, 0.313_812_2]),
        ];
        for (input, expected) in pairs {
            let out = tone_map(input, ToneMapping::PbrNeutral);
            for c in 0..3 {
                assert!(
                    (out[c] - expected[c]).abs() < 2e-6,
                    "{input:?} → {out:?}, the specification gives {expected:?}"
                );
            }
        }
        // Out-of-gamut (negative) channels are clipped first, as for black.
        assert_eq!(
            tone_map([-0.5, 0.0, -1.0], ToneMapping::PbrNeutral),
            [0.0; 3]
        );
    }

    /// The specification's guarantee: every colour with all channels in
    /// [0.08, 0.8] (below the compression start once offset) is shown as itself
    /// less F90 = 0.04, exactly up to f32 rounding; the compression start is
    /// where the peak passes K_s. And for every colour the hue is kept: the output
    /// lies in the plane of the input and the grey axis, on the input's side.
    #[test]
    fn pbr_neutral_keeps_colours_below_the_compression_start_and_every_hue() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(18);
        for _ in 0..10_000 {
            let c: [f32; 3] = std::array::from_fn(|_| rng.random_range(0.08f32..=0.8));
            let out = tone_map(c, ToneMapping::PbrNeutral);
            for k in 0..3 {
                assert!(
                    (out[k] - (c[k] - PBR_NEUTRAL_F90)).abs() < 1e-6,
                    "{c:?} → {out:?}"
                );
            }
        }
        // Just above the start the peak is compressed (less than c − F90).
        let above = tone_map([0.81, 0.5, 0.3], ToneMapping::PbrNeutral);
        assert!(
            above[0] < 0.81 - PBR_NEUTRAL_F90 && above[0] > 0.76,
            "{above:?}"
        );
        for _ in 0..10_000 {
            let scale = 10f32.powf(rng.random_range(-2.0f32..2.0));
            let c: [f32; 3] = std::array::from_fn(|_| scale * rng.random::<f32>());
            let out = tone_map(c, ToneMapping::PbrNeutral);
            assert!(
                out.iter().all(|v| (0.0..=1.0).contains(v)),
                "{c:?} → {out:?}"
            );
            // Chroma vectors (off the grey axis) are parallel and alike in sign.
            let chroma = |v: [f32; 3]| {
                let m = (v[0] + v[1] + v[2]) / 3.0;
                v.map(|x| f64::from(x - m))
            };
            let (a, b) = (chroma(c), chroma(out));
            let dot: f64 = (0..3).map(|k| a[k] * b[k]).sum();
            let norms = (0..3).map(|k| a[k] * a[k]).sum::<f64>().sqrt()
                * (0..3).map(|k| b[k] * b[k]).sum::<f64>().sqrt();
            if norms > 1e-9 {
                assert!(dot / norms > 1.0 - 1e-4, "{c:?} → {out:?}: hue moved");
            }
        }
    }

    #[test]
    fn exposure_and_tone_mapping_names_round_trip_and_bad_ones_are_named() {
        for text in ["0", "-1.5", "auto", "auto+1", "auto-0.5"] {
            let exposure = Exposure::parse(text).unwrap();
            assert_eq!(exposure.to_string(), text);
        }
        assert_eq!(
            Exposure::parse("auto+2"),
            Ok(Exposure::Auto { adjust_stops: 2.0 })
        );
        for bad in ["", "auto2", "autox", "NaN", "inf", "auto+inf", "1e39"] {
            let e = Exposure::parse(bad).unwrap_err();
            assert!(e.to_string().contains(&format!("\"{bad}\"")), "{e}");
        }
        for t in ToneMapping::CHOICES {
            assert_eq!(ToneMapping::parse(t.name()), Ok(t));
        }
        assert_eq!(ToneMapping::CHOICES[0], ToneMapping::default());
        let e = ToneMapping::parse("aces").unwrap_err();
        assert!(e.to_string().contains("\"aces\""), "{e}");
        // Automatic exposure follows the film; the adjustment adds to it.
        let mut film = Film::new(1, 1, Channels::LinearSrgb);
        film.add_sample(0, 0, &[2.0; 3]);
        let auto = Exposure::Auto { adjust_stops: 1.0 }.stops(&film);
        assert!((auto - film.auto_exposure() - 1.0).abs() < 1e-6);
        assert_eq!(Exposure::Fixed { stops: -2.0 }.stops(&film), -2.0);
    }

    #[test]
    fn reinhard_keeps_chromaticity_and_maps_white_to_one() {
        let tm = ToneMapping::ReinhardLuminance {
            white_luminance: 4.0,
        };
        let out = tone_map([4.0; 3], tm);
        assert!(out.iter().all(|v| (v - 1.0).abs() < 1e-6));
        let rgb = [0.5, 0.2, 0.1];
        let out = tone_map(rgb, tm);
        assert!((out[0] / out[1] - 2.5).abs() < 1e-5 && (out[1] / out[2] - 2.0).abs() < 1e-5);
        // A bright saturated colour is scaled down to a largest channel of 1.
        let out = tone_map([30.0, 1.0, 0.5], tm);
        assert!((out[0] - 1.0).abs() < 1e-6 && (out[0] / out[1] - 30.0).abs() < 1e-3);
    }
}
