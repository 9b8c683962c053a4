//! The comparison's shared difference: what a second shading changes in a
//! render's picture, estimated from its recorded paths
//! ([`crate::render::progressive::ProgressiveRender::reshade_recorded`]),
//! merged over successive recordings, and blended with each pane's own film.

use rayon::prelude::*;

use super::{BaseImage, ReshadeError, Reshaded};
use crate::render::film::Film;

/// The difference a second shading makes to a render's picture, estimated from
/// the render's recorded paths: per pixel the mean over the recorded samples of
/// c_B − c_A (the paths evaluated with the second shading less their own
/// value) and the variances of that mean's X, Y and Z. One recording gives one
/// estimate; the estimates of the render's successive recordings merge into
/// one ([`Self::merged`]) while its own film keeps refining; what a
/// comparison's second pane is made of ([`Self::combine`]).
#[derive(Debug, Clone)]
pub struct ShadingDifference {
    width: u32,
    height: u32,
    xyz: Vec<[f32; 3]>,
    variance_xyz: Vec<[f32; 3]>,
    samples: u32,
    /// Per pixel, the recorded samples its mean is over.
    counts: Vec<u32>,
}

impl ShadingDifference {
    /// The difference in `reshaded` (the recorded paths of the render whose
    /// film is `film` re-shaded with the second shading, from `samples` recorded
    /// samples per pixel, `counts` per pixel: [`super::PathCache::samples_per_pixel`]
    /// and [`super::PathCache::recorded_per_pixel`]) less the film's means and
    /// variances as they were when it was re-shaded.
    pub fn of(
        reshaded: &Reshaded,
        film: &Film,
        samples: u32,
        counts: Vec<u32>,
    ) -> Result<Self, ReshadeError> {
        if (reshaded.width, reshaded.height) != (film.width(), film.height())
            || counts.len() != reshaded.xyz.len()
        {
            return Err(ReshadeError::SizeChanged);
        }
        let base = BaseImage::of(film);
        let xyz = reshaded
            .xyz
            .iter()
            .zip(&base.xyz)
            .map(|(r, b)| std::array::from_fn(|c| r[c] - b[c]))
            .collect();
        let variance_xyz = reshaded
            .variance_xyz
            .iter()
            .zip(&base.variance_xyz)
            .map(|(r, b)| {
                std::array::from_fn(|c| {
                    if b[c].is_finite() {
                        (r[c] - b[c]).max(0.0)
                    } else {
                        r[c]
                    }
                })
            })
            .collect();
        Ok(Self {
            width: reshaded.width,
            height: reshaded.height,
            xyz,
            variance_xyz,
            samples,
            counts,
        })
    }

    /// Recorded samples per pixel the difference was estimated from (the
    /// pixels' mean where the recordings' passes were spread by weights).
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// Per pixel (row major) the recorded samples its difference was estimated
    /// from.
    pub fn counts(&self) -> &[u32] {
        &self.counts
    }

    /// Per pixel (row major) the mean of c_B − c_A, X, Y and Z.
    pub fn mean_xyz(&self) -> &[[f32; 3]] {
        &self.xyz
    }

    /// Per pixel the variances of [`Self::mean_xyz`]'s X, Y and Z.
    pub fn variance_of_mean_xyz(&self) -> &[[f32; 3]] {
        &self.variance_xyz
    }

    /// This difference and `other`, estimated from other samples of the same
    /// pixels (a later recording of the same render), as one: per pixel the mean
    /// over both recordings' samples (each mean weighed by the pixel's samples
    /// in it) and the variance of that mean. Recordings on different samples
    /// are independent, so the variance of the merged mean is
    /// Σ kᵢ² Vᵢ / (Σ kᵢ)².
    pub fn merged(&self, other: &Self) -> Result<Self, ReshadeError> {
        if (self.width, self.height) != (other.width, other.height) {
            return Err(ReshadeError::SizeChanged);
        }
        let pixels = self.xyz.len();
        let (mut xyz, mut variance_xyz) = (Vec::with_capacity(pixels), Vec::with_capacity(pixels));
        for i in 0..pixels {
            let (ka, kb) = (f64::from(self.counts[i]), f64::from(other.counts[i]));
            let k = ka + kb;
            let (wa, wb) = if k == 0.0 {
                (1.0, 0.0)
            } else {
                (ka / k, kb / k)
            };
            let (a, b) = (self.xyz[i], other.xyz[i]);
            xyz.push(std::array::from_fn(|c| {
                (wa * f64::from(a[c]) + wb * f64::from(b[c])) as f32
            }));
            let (va, vb) = (self.variance_xyz[i], other.variance_xyz[i]);
            variance_xyz.push(std::array::from_fn(|c| {
                (wa * wa * f64::from(va[c]) + wb * wb * f64::from(vb[c])) as f32
            }));
        }
        Ok(Self {
            width: self.width,
            height: self.height,
            xyz,
            variance_xyz,
            samples: self.samples + other.samples,
            counts: self
                .counts
                .iter()
                .zip(&other.counts)
                .map(|(a, b)| a + b)
                .collect(),
        })
    }

    /// Width, pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height, pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The second shading's picture from two unbiased estimates of it: the
    /// shared one, `first`'s film (the recording render, which keeps refining)
    /// plus this difference, and `own`, a film of the second shading rendered
    /// on its own. Per pixel they are blended as (1 − w)·shared + w·own with
    /// w = V_S / (V_S + V_O), V the sums of each estimate's variance of Y over
    /// the pixel's block of [`COMBINE_BLOCK`]² pixels *leaving the pixel itself
    /// out*: a pixel's samples are independent of its neighbours', so its
    /// weight is independent of both its estimates and the blend is exactly
    /// unbiased, while the weight still follows where the difference is noisy
    /// (a highlight one model samples poorly with the other's paths: own
    /// samples) and where it is clean (the shared samples, which keep the
    /// panes' difference free of noise). While either film has fewer than two
    /// samples (no variance), both panes come from the other film. Both
    /// estimates are unbiased and both refine (the difference with each
    /// recording merged into it, `own` with each pass), so the picture converges
    /// to the second shading's image. Returns the picture with the mean of w.
    pub fn combine(&self, first: &Film, own: &Film) -> Result<(Reshaded, f64), ReshadeError> {
        self.blend(first, 1.0, own)
    }

    /// The first shading's picture the same way: its own film `first` blended
    /// with `second` (a film of the second shading) less this difference, an
    /// unbiased estimate of the first shading's image too. Where the weights of
    /// both panes are alike, the panes' difference is this difference alone,
    /// free of either film's noise.
    pub fn combine_first(
        &self,
        first: &Film,
        second: &Film,
    ) -> Result<(Reshaded, f64), ReshadeError> {
        self.blend(second, -1.0, first)
    }

    /// Per pixel of `first`'s and `second`'s panes ([`Self::combine_first`],
    /// [`Self::combine`]), the variances of the second pane's X, Y and Z less
    /// the first pane's: what the noise of the panes' ΔE00 map is made of (in
    /// a dark pixel of a saturated colour mostly its chroma, which Y alone does
    /// not show). With the panes' weights w₁ and w₂ of their own films, the
    /// difference is (1 − w₁ − w₂)(A − B) + (2 − w₁ − w₂)·D, A and B the films
    /// and D this difference; taken as independent (D shares some of A's
    /// samples, a covariance the sum leaves out), its variance is, channel by
    /// channel, (1 − w₁ − w₂)²(V_A + V_B) + (2 − w₁ − w₂)² V_D.
    pub fn panes_difference_variance_xyz(
        &self,
        first: &Film,
        second: &Film,
    ) -> Result<Vec<[f32; 3]>, ReshadeError> {
        let first_pane = self.pixel_estimates(second, -1.0, first)?;
        let second_pane = self.pixel_estimates(first, 1.0, second)?;
        let (w1, w2) = (
            self.own_weights(&first_pane, second, -1.0, first),
            self.own_weights(&second_pane, first, 1.0, second),
        );
        Ok(first_pane
            .iter()
            .zip(&second_pane)
            .zip(w1.iter().zip(&w2))
            .zip(&self.variance_xyz)
            .map(|(((p1, p2), (w1, w2)), v_d)| {
                // Each pane's own variance is its own film's: A's for the first,
                // B's for the second.
                let (v_a, v_b) = (p1.own_variance, p2.own_variance);
                let films = 1.0 - w1 - w2;
                let shared = 2.0 - w1 - w2;
                std::array::from_fn(|c| {
                    (films * films * (v_a[c] + v_b[c]) + shared * shared * f64::from(v_d[c])) as f32
                })
            })
            .collect())
    }

    /// Per pixel: `base` + `sign` × this difference (the shared estimate) and
    /// its variances of X, Y and Z, and `own`'s mean and variances (0 where not
    /// finite, so they drop out of the sums).
    fn pixel_estimates(
        &self,
        base: &Film,
        sign: f64,
        own: &Film,
    ) -> Result<Vec<PaneEstimates>, ReshadeError> {
        let size = (self.width, self.height);
        if (base.width(), base.height()) != size || (own.width(), own.height()) != size {
            return Err(ReshadeError::SizeChanged);
        }
        let width = self.width as usize;
        Ok((0..self.xyz.len())
            .into_par_iter()
            .map(|i| {
                let (x, y) = ((i % width) as u32, (i / width) as u32);
                let m = base.mean_xyz(x, y);
                let d = self.xyz[i].map(|v| sign * f64::from(v));
                let finite = |v: f64| if v.is_finite() { v } else { 0.0 };
                let o = own.mean_xyz(x, y);
                let (base_variance, own_variance) = (
                    base.variance_of_mean_xyz(x, y),
                    own.variance_of_mean_xyz(x, y),
                );
                let difference_variance = self.variance_xyz[i];
                PaneEstimates {
                    shared: [m.x + d[0], m.y + d[1], m.z + d[2]],
                    shared_variance: std::array::from_fn(|c| {
                        finite(base_variance[c]) + f64::from(difference_variance[c])
                    }),
                    own: [o.x, o.y, o.z],
                    own_variance: own_variance.map(finite),
                }
            })
            .collect())
    }

    /// Per pixel the weight of the pane's own film in its blend (see
    /// [`Self::combine`]).
    fn own_weights(
        &self,
        pixels: &[PaneEstimates],
        base: &Film,
        sign: f64,
        own: &Film,
    ) -> Vec<f64> {
        let (width, height) = (self.width as usize, self.height as usize);
        let blocks_x = width.div_ceil(COMBINE_BLOCK);
        let block_of =
            |i: usize| (i / width / COMBINE_BLOCK) * blocks_x + (i % width) / COMBINE_BLOCK;
        let mut sums = vec![[0.0f64; 2]; blocks_x * height.div_ceil(COMBINE_BLOCK)];
        for (i, p) in pixels.iter().enumerate() {
            let b = &mut sums[block_of(i)];
            b[0] += p.shared_variance[1];
            b[1] += p.own_variance[1];
        }
        // A film of fewer than two samples has no variance (it reads as 0, as if
        // certain), so it cannot take part in the weighing. While the second
        // view's film is one (it has just started), both panes come from the
        // first's film: the first pane as it is, the second as the first plus
        // the difference; while the first's is one, both from the second's.
        let own_is_first = sign < 0.0;
        let (first_film, second_film) = if own_is_first {
            (own, base)
        } else {
            (base, own)
        };
        let fixed_weight = if second_film.samples_per_pixel() < 2 {
            Some(if own_is_first { 1.0 } else { 0.0 })
        } else if first_film.samples_per_pixel() < 2 {
            Some(if own_is_first { 0.0 } else { 1.0 })
        } else {
            None
        };
        pixels
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let b = sums[block_of(i)];
                let rest_s = (b[0] - p.shared_variance[1]).max(0.0);
                let rest_o = (b[1] - p.own_variance[1]).max(0.0);
                if let Some(w) = fixed_weight {
                    w
                } else if rest_s + rest_o > 0.0 {
                    rest_s / (rest_s + rest_o)
                } else {
                    // No neighbour has any noise (the sky): its own samples, as
                    // the pixel's own variances must not choose.
                    1.0
                }
            })
            .collect()
    }

    /// `own` blended with `base` + `sign` × this difference, as [`Self::combine`]
    /// describes.
    fn blend(&self, base: &Film, sign: f64, own: &Film) -> Result<(Reshaded, f64), ReshadeError> {
        let pixels = self.pixel_estimates(base, sign, own)?;
        let weights = self.own_weights(&pixels, base, sign, own);
        let mean_weight = weights.iter().sum::<f64>() / weights.len().max(1) as f64;
        let (xyz, variance_xyz) = pixels
            .iter()
            .zip(&weights)
            .map(|(p, &w)| {
                let keep = 1.0 - w;
                let xyz: [f32; 3] =
                    std::array::from_fn(|c| (keep * p.shared[c] + w * p.own[c]) as f32);
                let variance: [f32; 3] = std::array::from_fn(|c| {
                    (keep * keep * p.shared_variance[c] + w * w * p.own_variance[c]) as f32
                });
                (xyz, variance)
            })
            .unzip();
        Ok((
            Reshaded {
                width: self.width,
                height: self.height,
                xyz,
                variance_xyz,
            },
            mean_weight,
        ))
    }
}

/// One pixel of a pane before its blend: the shared estimate and the pane's
/// own film's, each with its variances of X, Y and Z (the blend's weights
/// follow Y's).
struct PaneEstimates {
    shared: [f64; 3],
    shared_variance: [f64; 3],
    own: [f64; 3],
    own_variance: [f64; 3],
}

/// Side of the blocks of pixels whose variances set the weights of
/// [`ShadingDifference::combine`]: small enough to follow a highlight, large
/// enough (64 pixels) that the sum of a block's other pixels is a steady
/// estimate.
pub const COMBINE_BLOCK: usize = 8;
