//! Adaptive sampling: after a few uniform passes, a pass's samples go to the pixels
//! by their estimated perceptual noise instead of evenly, so that the few very
//! noisy pixels (the floor's caustics under a mirror-like coat: light from the
//! softboxes reflected by the body, found by the path tracer only by chance) get
//! more samples for the same total.
//!
//! # The allocation
//! 1. Per pixel, the perceptual noise of one sample, e_i
//!    ([`Film::sample_delta_e`]: the ΔE00 of the displayed colour moved by one
//!    standard deviation of a sample). The error of its mean after n_i samples is
//!    about e_i / √n_i.
//! 2. r_i = the largest e_j of the 3 × 3 neighbourhood: a caustic pixel that has not
//!    yet found its light (its own samples say "quiet") still gets samples when a
//!    neighbour has; and a pixel's share depends mostly on its neighbours' samples,
//!    not only on its own (a share driven by the pixel's own samples alone would
//!    pull a pixel that happened to see a bright sample back down faster than one
//!    that did not: a downward bias).
//! 3. w_i = max(r_i^p / mean(r^p), floor), normalised to a mean of 1; a pass of
//!    `s` samples per pixel gives pixel i about s · w_i samples, rounded by
//!    systematic sampling so that the pass takes exactly s samples per pixel over
//!    the image (the mean samples per pixel stays a whole number) and each pixel's
//!    count is s · w_i rounded down or up. With the floor f every pixel gets at
//!    least s · f / (1 + f) per pass, rounded down (the mean of w before
//!    normalising is at most 1 + f).
//!
//! The exponent p: minimising the mean of e_i / √n_i over the image at a fixed
//! total gives n_i ∝ e_i^(2/3), equalising the pixels' errors (the best for a high
//! percentile) n_i ∝ e_i²; p = 1 (the mean squared error's optimum) lies between.
//! The defaults come from measurements (docs/tradeoff.md, "Adaptive sampling").
//!
//! # Unbiasedness
//! A pixel's value stays the mean of its samples, sum / count. Its samples keep
//! their index order ([`crate::render::sampler::PixelSampler`] keyed by the pixel's
//! own sample count), so no sample is ever repeated or skipped. The count is random
//! and depends on earlier samples, which can bias a plain mean; step 2 keeps that
//! dependence weak, and the tests compare adaptive renders with uniform ones
//! (Z-tests of region and image means).

use thiserror::Error;

use crate::render::film::{DisplaySettings, Film};
use crate::render::sampler::PixelSampler;

/// How adaptive passes spend their samples (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveSampling {
    /// Samples per pixel taken uniformly before the first adaptive pass (at least
    /// 2: a noise estimate needs two samples). Samples recorded for re-shading
    /// are always uniform too.
    pub uniform_samples: u32,
    /// The least weight of a pixel relative to the image's mean weight, before
    /// normalising: no pixel is starved (see the module documentation).
    pub floor: f32,
    /// The exponent p of the per-sample noise the share follows.
    pub exponent: f32,
}

/// An [`AdaptiveSampling`] number out of its range; the message names it.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum AdaptiveError {
    /// Fewer than two uniform samples per pixel.
    #[error("{0} uniform samples per pixel: at least 2 are needed for a noise estimate")]
    UniformSamples(u32),
    /// A floor outside (0, 1].
    #[error("floor {0}: must be in (0, 1]")]
    Floor(f32),
    /// An exponent outside [0, 4].
    #[error("exponent {0}: must be in [0, 4]")]
    Exponent(f32),
}

/// The noise map is recomputed when the samples per pixel have grown by this factor
/// since the last one: it costs about as much as a third of a sample per pixel,
/// and the estimates it comes from change slowly.
pub const RECOMPUTE_GROWTH: f64 = 1.5;

impl Default for AdaptiveSampling {
    fn default() -> Self {
        Self {
            uniform_samples: 4,
            floor: 0.25,
            exponent: 1.0,
        }
    }
}

impl AdaptiveSampling {
    /// Checks the numbers: `uniform_samples` ≥ 2, `floor` in (0, 1], `exponent` in
    /// [0, 4].
    pub fn validate(&self) -> Result<(), AdaptiveError> {
        if self.uniform_samples < 2 {
            return Err(AdaptiveError::UniformSamples(self.uniform_samples));
        }
        if !(self.floor > 0.0 && self.floor <= 1.0) {
            return Err(AdaptiveError::Floor(self.floor));
        }
        if !(0.0..=4.0).contains(&self.exponent) {
            return Err(AdaptiveError::Exponent(self.exponent));
        }
        Ok(())
    }

    /// Per-pixel weights (mean 1) of `film`'s region, row major: steps 1–3 of the
    /// module documentation, with the noise seen as `display` shows it.
    pub fn weights(&self, film: &Film, display: &DisplaySettings) -> Vec<f32> {
        let noise = film.sample_delta_e(display);
        neighbourhood_weights(
            &noise,
            film.width() as usize,
            film.height() as usize,
            self.floor,
            self.exponent,
        )
    }
}

/// Steps 2 and 3 of the module documentation on a `width` × `height` noise map
/// (row major). Non-finite noise (a pixel without an estimate) counts as the
/// largest finite value. Sums in a fixed order: the same weights on any thread
/// count.
pub fn neighbourhood_weights(
    noise: &[f32],
    width: usize,
    height: usize,
    floor: f32,
    exponent: f32,
) -> Vec<f32> {
    assert_eq!(noise.len(), width * height, "noise map of the wrong size");
    let largest = noise
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0f32, f32::max);
    let clean: Vec<f32> = noise
        .iter()
        .map(|&v| if v.is_finite() { v.max(0.0) } else { largest })
        .collect();
    let raised: Vec<f32> = neighbourhood_max(&clean, width, height)
        .into_iter()
        .map(|m| m.powf(exponent))
        .collect();
    let mean = raised.iter().map(|&v| f64::from(v)).sum::<f64>() / raised.len().max(1) as f64;
    if !(mean > 0.0 && mean.is_finite()) {
        // No noise anywhere (or no estimate): spend evenly.
        return vec![1.0; raised.len()];
    }
    let floor = f64::from(floor);
    let weights: Vec<f64> = raised
        .iter()
        .map(|&v| (f64::from(v) / mean).max(floor))
        .collect();
    let mean = weights.iter().sum::<f64>() / weights.len() as f64;
    weights.iter().map(|&w| (w / mean) as f32).collect()
}

/// Each pixel's largest value of its 3 × 3 neighbourhood (clipped at the edges)
/// in a `width` × `height` map of non-negative values, row major.
pub fn neighbourhood_max(values: &[f32], width: usize, height: usize) -> Vec<f32> {
    neighbourhood_fold(values, width, height, 0.0f32, |m, &v| m.max(v))
}

/// Each pixel's 3 × 3 neighbourhood (clipped at the edges) of a `width` ×
/// `height` map, row major, folded from `init` by `fold` row by row, left to
/// right.
pub fn neighbourhood_fold<T, A: Copy>(
    values: &[T],
    width: usize,
    height: usize,
    init: A,
    fold: impl Fn(A, &T) -> A,
) -> Vec<A> {
    assert_eq!(values.len(), width * height, "map of the wrong size");
    let mut folded = Vec::with_capacity(values.len());
    for y in 0..height {
        let (y0, y1) = (y.saturating_sub(1), (y + 1).min(height - 1));
        for x in 0..width {
            let (x0, x1) = (x.saturating_sub(1), (x + 1).min(width - 1));
            let mut acc = init;
            for row in values[y0 * width..(y1 + 1) * width].chunks_exact(width) {
                for v in &row[x0..=x1] {
                    acc = fold(acc, v);
                }
            }
            folded.push(acc);
        }
    }
    folded
}

/// Samples per pixel for one pass of `samples` per pixel on average, by `weights`
/// (mean 1): pixel i gets ⌊C_i + u⌋ − ⌊C_{i−1} + u⌋ with C the running sum of
/// `samples` · w and u one uniform number for the pass (systematic sampling), so
/// the counts add up to exactly `samples` × the pixel count and each is
/// `samples` · w_i rounded down or up. `u` comes from (`seed`, `pass`).
pub fn allocate(weights: &[f32], samples: u32, seed: u64, pass: u32) -> Vec<u32> {
    let total = f64::from(samples) * weights.len() as f64;
    let sum: f64 = weights.iter().map(|&w| f64::from(w)).sum();
    if !(sum > 0.0 && sum.is_finite()) {
        return vec![samples; weights.len()];
    }
    let scale = total / sum;
    // Pixel index u32::MAX is never an image pixel (sizes stop at 16384²): the
    // pass's offset draws from a key of its own.
    let u = f64::from(PixelSampler::new(seed, u32::MAX, pass).next_1d());
    let mut counts = Vec::with_capacity(weights.len());
    let (mut running, mut taken) = (0.0f64, 0.0f64);
    let last = weights.len().saturating_sub(1);
    for (i, &w) in weights.iter().enumerate() {
        running += f64::from(w) * scale;
        // The last pixel closes the sum exactly, whatever the rounding on the way.
        let end = if i == last { total } else { running.min(total) };
        let upto = (end + u).floor();
        counts.push((upto - taken).max(0.0) as u32);
        taken = taken.max(upto);
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn allocation_takes_exactly_the_pass_and_follows_the_weights() {
        let weights: Vec<f32> = (0..1000).map(|i| 0.2 + (i % 7) as f32 * 0.3).collect();
        let mean = weights.iter().sum::<f32>() / weights.len() as f32;
        let weights: Vec<f32> = weights.iter().map(|w| w / mean).collect();
        for pass in 0..20 {
            let counts = allocate(&weights, 4, 3, pass);
            assert_eq!(counts.iter().map(|&c| u64::from(c)).sum::<u64>(), 4000);
            for (&c, &w) in counts.iter().zip(&weights) {
                let share = 4.0 * f64::from(w);
                assert!(
                    f64::from(c) >= share.floor() - 1e-9 && f64::from(c) <= share.ceil() + 1e-9,
                    "{c} samples for a share of {share}"
                );
            }
        }
        // Uniform weights: every pixel gets the pass, whatever the offset.
        assert!(allocate(&[1.0; 64], 3, 1, 0).iter().all(|&c| c == 3));
    }

    #[test]
    fn weights_follow_the_noisiest_neighbour_and_keep_the_floor() {
        let (w, h) = (9, 7);
        let mut noise = vec![1.0f32; w * h];
        noise[3 * w + 4] = 20.0;
        noise[0] = f32::INFINITY;
        let weights = neighbourhood_weights(&noise, w, h, 0.25, 1.0);
        let mean = weights.iter().sum::<f32>() / weights.len() as f32;
        assert!((mean - 1.0).abs() < 1e-5);
        // The 3 × 3 block round the noisy pixel shares its weight, the rest the floor.
        let high = weights[3 * w + 4];
        for y in 0..h {
            for x in 0..w {
                let near = x.abs_diff(4) <= 1 && y.abs_diff(3) <= 1;
                let corner = x <= 1 && y <= 1;
                let v = weights[y * w + x];
                if near || corner {
                    assert!((v - high).abs() < 1e-5, "({x}, {y}): {v} against {high}");
                } else {
                    assert!(v < high / 4.0 && v > 0.0, "({x}, {y}): {v}");
                }
            }
        }
        // No noise at all: even weights.
        assert!(
            neighbourhood_weights(&[0.0; 12], 4, 3, 0.25, 1.0)
                .iter()
                .all(|&v| v == 1.0)
        );
    }

    #[test]
    fn settings_out_of_range_are_refused_by_name() {
        assert!(AdaptiveSampling::default().validate().is_ok());
        let bad = |s: AdaptiveSampling| s.validate().unwrap_err().to_string();
        assert!(
            bad(AdaptiveSampling {
                uniform_samples: 1,
                ..Default::default()
            })
            .contains("at least 2")
        );
        assert!(
            bad(AdaptiveSampling {
                floor: 0.0,
                ..Default::default()
            })
            .contains("floor 0")
        );
        assert!(
            bad(AdaptiveSampling {
                exponent: f32::NAN,
                ..Default::default()
            })
            .contains("exponent NaN")
        );
    }
}
