//! Statistical comparison of Monte Carlo images, shared by the render, re-shade,
//! shared-comparison and adaptive-sampling tests.
//!
//! # Why replicas
//! A pixel's samples are Owen-scrambled Sobol points, negatively correlated, so the
//! film's s²/n ([`Film::variance_of_mean_xyz`]) over-states the error of their
//! mean several times over (measured in `tests/render.rs`,
//! `film_variance_overstates_the_replica_spread`) and a Z-test on it is not the
//! test it claims to be. Here an estimate is K independent replicas instead (K
//! seeds, n/K samples each: the same cost as one render of n): per pixel and
//! channel their mean, and the sample variance across them over K, which is an
//! unbiased estimate of the variance of that mean whatever the sampler does
//! inside one replica.
//!
//! # The test
//! Two replica sets `a` and `b` of one image agree when all of these hold, each
//! with a false-alarm probability of [`FALSE_ALARM`] / 3 (so at most
//! [`FALSE_ALARM`] in all, Bonferroni):
//! - **Pixels:** per pixel and channel (X, Y, Z) Welch's t of the two means, with
//!   the Welch–Satterthwaite degrees of freedom. The number of pixels with any
//!   channel beyond |t| > [`PIXEL_T`] is at most the count a Poisson law with
//!   the expected count (the Student t tail of each pixel's three channels,
//!   summed) exceeds with probability [`FALSE_ALARM`] / 3; pixels are
//!   independent (each has its own scrambling seeds), and a Poisson tail is
//!   above the tail of any sum of independent Bernoulli counts with that mean.
//!   Pixels without noise on both sides (the studio's backdrop seen directly)
//!   must agree to float rounding.
//! - **Tiles:** the weighted sum over each tile of several tilings (8 × 8 to
//!   16 × 16 pixels, shifted), per channel, t with Satterthwaite's degrees of
//!   freedom, Bonferroni over tiles and channels: a bias over a region (one
//!   material, one lit area) too weak for any pixel to show.
//! - **Image totals:** the sum over the image per channel: a uniform bias.
//!
//! Every comparison that expects agreement also runs [`assert_controls`]: the
//! same comparison with the first image biased like a real defect (1 % on every
//! pixel; 2 % on a block of 5 % of the pixels; X or Z alone by 2 %) must be
//! rejected.
#![allow(dead_code)] // each test crate uses its own subset

use coatlab_core::render::film::Film;
use coatlab_core::render::reshade::Reshaded;
use statrs::distribution::{ContinuousCDF, DiscreteCDF, Poisson, StudentsT};

/// `n` moved to another set of seeds when `COATLAB_SEED_SET` is set to a number
/// k > 0 (n + k · 10⁶): every test that seeds its renders through this runs on
/// independent samples, to check that its comparisons pass, and its controls
/// fail, for other seeds than the ones committed.
pub fn seed(n: u64) -> u64 {
    let set: u64 = std::env::var("COATLAB_SEED_SET")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    n + set * 1_000_000
}

/// The probability that a comparison of two images of the same scene fails.
pub const FALSE_ALARM: f64 = 1e-4;
/// A pixel channel with |t| beyond this counts as an outlier.
pub const PIXEL_T: f64 = 4.0;
/// Relative difference allowed between noise-free pixels. Such a pixel shows
/// the background, the open floor (one value under the floor's control
/// variate), or an edge between them, where its mean is the share of its
/// sample positions on each side: renders of 64 to 128 samples differ there by
/// about one sample's share of the contrast (7e-4 seen at the horizon).
const EXACT_TOLERANCE: f64 = 2e-2;
/// Relative spread of a pixel's replicas below which it counts as noise-free:
/// what adding the same terms in another order leaves in f32 (the largest seen,
/// on the open floor under the floor's control variate, is about 6e-10).
const ROUNDING_SPREAD: f64 = 1e-7;

/// An image as XYZ per pixel, row-major.
pub type Image = Vec<[f64; 3]>;

/// The mean XYZ image of a film.
pub fn film_image(film: &Film) -> Image {
    let mut out = Vec::with_capacity((film.width() * film.height()) as usize);
    for y in 0..film.height() {
        for x in 0..film.width() {
            let m = film.mean_xyz(x, y);
            out.push([m.x, m.y, m.z]);
        }
    }
    out
}

/// The XYZ image of a re-shade.
pub fn reshaded_image(reshaded: &Reshaded) -> Image {
    reshaded.xyz.iter().map(|v| v.map(f64::from)).collect()
}

/// Independent estimates of one image: per pixel and channel their mean and the
/// estimated variance of that mean.
#[derive(Debug, Clone)]
pub struct Replicas {
    pub width: u32,
    pub height: u32,
    /// How many replicas the variances come from (degrees of freedom + 1);
    /// infinite for a prediction whose variance is known.
    pub count: f64,
    pub mean: Image,
    pub variance: Image,
}

impl Replicas {
    /// Mean and variance of the mean, per pixel and channel, of `images` (at
    /// least two, independent, of `width` × `height`).
    pub fn from_images(width: u32, height: u32, images: &[Image]) -> Self {
        let k = images.len();
        assert!(k >= 2, "{k} replicas: no variance");
        let pixels = (width * height) as usize;
        assert!(images.iter().all(|i| i.len() == pixels), "image sizes");
        let kf = k as f64;
        let mut mean = vec![[0.0; 3]; pixels];
        let mut variance = vec![[0.0; 3]; pixels];
        for p in 0..pixels {
            for c in 0..3 {
                let m = images.iter().map(|i| i[p][c]).sum::<f64>() / kf;
                let ss = images.iter().map(|i| (i[p][c] - m).powi(2)).sum::<f64>();
                mean[p][c] = m;
                variance[p][c] = ss / (kf - 1.0) / kf;
            }
        }
        Self {
            width,
            height,
            count: kf,
            mean,
            variance,
        }
    }

    /// `k` replicas made by `image(i)`, i = 0 .. k.
    pub fn collect(width: u32, height: u32, k: usize, image: impl FnMut(usize) -> Image) -> Self {
        let images: Vec<Image> = (0..k).map(image).collect();
        Self::from_images(width, height, &images)
    }

    /// A prediction: `mean` with a known `variance` (e.g. the tolerance of a
    /// table), as from infinitely many replicas.
    pub fn known(width: u32, height: u32, mean: Image, variance: Image) -> Self {
        Self {
            width,
            height,
            count: f64::INFINITY,
            mean,
            variance,
        }
    }

    /// These replicas with every pixel channel multiplied by `factor(pixel,
    /// channel)`: a defect put in on purpose.
    pub fn biased(&self, factor: impl Fn(usize, usize) -> f64) -> Self {
        let mut out = self.clone();
        for (p, (m, v)) in out.mean.iter_mut().zip(&mut out.variance).enumerate() {
            for c in 0..3 {
                let f = factor(p, c);
                m[c] *= f;
                v[c] *= f * f;
            }
        }
        out
    }

    /// These replicas with `delta(pixel, channel)` added to every mean.
    pub fn shifted(&self, delta: impl Fn(usize, usize) -> f64) -> Self {
        let mut out = self.clone();
        for (p, m) in out.mean.iter_mut().enumerate() {
            for (c, v) in m.iter_mut().enumerate() {
                *v += delta(p, c);
            }
        }
        out
    }

    /// The summed variance of the mean over the image, per channel.
    pub fn total_variance(&self) -> [f64; 3] {
        let mut out = [0.0; 3];
        for v in &self.variance {
            for c in 0..3 {
                out[c] += v[c];
            }
        }
        out
    }
}

/// Student's t with `df` degrees of freedom (at least 1; normal for infinite `df`).
fn students_t(df: f64) -> StudentsT {
    let df = if df.is_finite() {
        df.max(1.0)
    } else {
        f64::INFINITY
    };
    StudentsT::new(0.0, 1.0, df).expect("t distribution")
}

/// Two-sided tail probability of Student's t with `df` degrees of freedom
/// (normal for infinite `df`).
pub fn two_sided_p(t: f64, df: f64) -> f64 {
    let dist = students_t(df);
    (2.0 * dist.sf(t.abs())).min(1.0)
}

/// The |t| a two-sided test at level `p` rejects beyond.
pub fn critical_t(p: f64, df: f64) -> f64 {
    let dist = students_t(df);
    -dist.inverse_cdf(p / 2.0)
}

/// A sum of differences with its variance and Satterthwaite's degrees of freedom.
#[derive(Debug, Clone, Copy, Default)]
struct Sum {
    difference: f64,
    variance: f64,
    /// Σ of each term's variance² over its degrees of freedom.
    df_denominator: f64,
}

impl Sum {
    fn add(&mut self, d: f64, va: f64, ka: f64, vb: f64, kb: f64) {
        self.difference += d;
        self.variance += va + vb;
        self.df_denominator += va * va / (ka - 1.0) + vb * vb / (kb - 1.0);
    }

    fn df(&self) -> f64 {
        if self.df_denominator > 0.0 {
            self.variance * self.variance / self.df_denominator
        } else {
            f64::INFINITY
        }
    }

    fn t(&self) -> f64 {
        self.difference / self.variance.sqrt()
    }
}

/// Per pixel and channel, the weight of a pixel's difference in the tile and
/// image sums: about the inverse of its relative variance (so a relative bias
/// is found where the noise is low), from a pilot estimate that is independent
/// of both images compared. Fixed weights keep each sum an unbiased estimate of
/// zero when the images agree, and its variance Σ w² v; weights from the
/// compared images themselves would correlate with their differences.
#[derive(Debug, Clone)]
pub struct Weights {
    pub width: u32,
    pub height: u32,
    weight: Vec<[f64; 3]>,
}

impl Weights {
    /// Weights from `pilot`: w = 1 / (m r²) with m the pilot's mean and r² its
    /// relative variance, each the mean over the pixel's 3 × 3 neighbourhood (one
    /// pixel's replica variance is too noisy to weigh by), r² at least a tenth of
    /// its median over the image (a pixel whose pilot saw no noise is not trusted
    /// with all the weight).
    pub fn from_pilot(pilot: &Replicas) -> Self {
        Self::from_pilots(&[pilot])
    }

    /// [`Self::from_pilot`] for a comparison of two estimators with different
    /// noise: a pilot of each, r² their sum (m from the first).
    pub fn from_pilots(pilots: &[&Replicas]) -> Self {
        let first = pilots[0];
        let (w, h) = (first.width as usize, first.height as usize);
        let box3 = |values: &dyn Fn(usize) -> f64, i: usize| {
            let (x, y) = (i % w, i / w);
            let (mut s, mut n) = (0.0, 0.0);
            for yy in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                for xx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                    s += values(yy * w + xx);
                    n += 1.0;
                }
            }
            s / n
        };
        let channel = |c: usize| -> Vec<f64> {
            let mean: Vec<f64> = (0..w * h).map(|i| box3(&|j| first.mean[j][c], i)).collect();
            let mut r2 = vec![0.0; w * h];
            for pilot in pilots {
                let relative = |i: usize| {
                    let m = pilot.mean[i][c];
                    if m > 0.0 {
                        pilot.variance[i][c] / (m * m)
                    } else {
                        0.0
                    }
                };
                for (i, r) in r2.iter_mut().enumerate() {
                    *r += box3(&relative, i);
                }
            }
            let median = |values: &[f64]| {
                let mut positive: Vec<f64> = values.iter().copied().filter(|&v| v > 0.0).collect();
                positive.sort_by(f64::total_cmp);
                positive.get(positive.len() / 2).copied()
            };
            let floor = median(&r2).map_or(1.0, |m| 0.1 * m);
            let mean_floor = median(&mean).map_or(1.0, |m| 0.01 * m);
            mean.iter()
                .zip(&r2)
                .map(|(m, r)| 1.0 / (m.max(mean_floor) * r.max(floor)))
                .collect()
        };
        let channels = [channel(0), channel(1), channel(2)];
        Self {
            width: first.width,
            height: first.height,
            weight: (0..w * h)
                .map(|i| std::array::from_fn(|c| channels[c][i]))
                .collect(),
        }
    }

    /// Every pixel the same weight (the sums are plain sums of differences).
    pub fn equal(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            weight: vec![[1.0; 3]; (width * height) as usize],
        }
    }
}

/// The tilings whose tile sums are tested: (tile width, height), offset in x and
/// y. Tiles of 8 × 8, 16 × 8 (the aspect of the images here, and of
/// [`defect_region`]) and 16 × 16 pixels, each tiling shifted by a quarter or a
/// half of a tile so that a compact region falls mostly inside one tile of some
/// tiling. More tilings cost little: the Bonferroni limit grows with the log of
/// their number.
fn tilings() -> Vec<([u32; 2], [u32; 2])> {
    let mut out = Vec::new();
    for (size, steps) in [([8, 8], [2, 2]), ([16, 8], [4, 2]), ([16, 16], [2, 2])] {
        for sy in 0..steps[1] {
            for sx in 0..steps[0] {
                out.push((size, [sx * size[0] / steps[0], sy * size[1] / steps[1]]));
            }
        }
    }
    out
}

/// The result of [`compare`].
#[derive(Debug, Clone)]
pub struct Comparison {
    /// Pixels with noise in some channel.
    pub noisy_pixels: usize,
    /// Noise-free pixel channels that differ beyond float rounding.
    pub exact_mismatches: usize,
    /// Pixels with some channel beyond |t| > [`PIXEL_T`].
    pub outliers: u64,
    /// Their expected number when the images agree.
    pub expected_outliers: f64,
    /// The most that passes.
    pub outlier_bound: u64,
    /// The largest |t| of a tile sum over its critical value (> 1 fails), with
    /// the tile's size, top-left pixel and channel.
    pub worst_tile: (f64, [u32; 2], i64, i64, usize),
    /// t of the weighted image total per channel.
    pub total_t: [f64; 3],
    /// The critical |t| of the totals.
    pub total_limit: [f64; 3],
    /// The weighted variance of the first image's total over the second's: which
    /// side's noise limits the comparison.
    pub noise_ratio: f64,
}

impl Comparison {
    pub fn pixels_fail(&self) -> bool {
        self.exact_mismatches > 0 || self.outliers > self.outlier_bound
    }

    pub fn tiles_fail(&self) -> bool {
        self.worst_tile.0 > 1.0
    }

    pub fn totals_fail(&self) -> bool {
        (0..3).any(|c| self.total_t[c].abs() > self.total_limit[c])
    }

    pub fn fails(&self) -> bool {
        self.pixels_fail() || self.tiles_fail() || self.totals_fail()
    }

    /// One line: every criterion with its limit.
    pub fn summary(&self) -> String {
        let (tile, size, tx, ty, tc) = self.worst_tile;
        format!(
            "{} noisy pixels, {} noise-free mismatched; |t| > {PIXEL_T}: {} pixels \
             (expected {:.1}, at most {}); worst tile ×{:.2} of its limit ({}×{} at \
             {tx},{ty} {}); total t X {:+.2} Y {:+.2} Z {:+.2} (limit {:.2}); noise a/b \
             {:.2}",
            self.noisy_pixels,
            self.exact_mismatches,
            self.outliers,
            self.expected_outliers,
            self.outlier_bound,
            tile,
            size[0],
            size[1],
            ["X", "Y", "Z"][tc],
            self.total_t[0],
            self.total_t[1],
            self.total_t[2],
            self.total_limit[1],
            self.noise_ratio,
        )
    }

    /// Prints the comparison and asserts that the two images agree.
    pub fn assert_agree(&self, what: &str) {
        println!("{what}: {}", self.summary());
        assert!(
            !self.fails(),
            "{what}: the images differ: {}",
            self.summary()
        );
    }
}

/// Compares two estimates of one image (see the module docs), the tile and image
/// sums weighted by `weights`.
pub fn compare(a: &Replicas, b: &Replicas, weights: &Weights) -> Comparison {
    assert_eq!((a.width, a.height), (b.width, b.height), "image sizes");
    assert_eq!(
        (a.width, a.height),
        (weights.width, weights.height),
        "weights"
    );
    let (w, h) = (a.width, a.height);
    let (ka, kb) = (a.count, b.count);
    let alpha = FALSE_ALARM / 3.0;
    let (mut noisy_pixels, mut exact_mismatches, mut outliers) = (0, 0, 0u64);
    let mut expected_outliers = 0.0;
    let mut total = [Sum::default(); 3];
    let (mut noise_a, mut noise_b) = (0.0, 0.0);
    let tilings = tilings();
    let columns = |size: [u32; 2], offset: [u32; 2]| (w + offset[0]).div_ceil(size[0]);
    let mut tiles: Vec<Vec<[Sum; 3]>> = tilings
        .iter()
        .map(|&(size, offset)| {
            let rows = (h + offset[1]).div_ceil(size[1]);
            vec![[Sum::default(); 3]; (columns(size, offset) * rows) as usize]
        })
        .collect();
    for y in 0..h {
        for x in 0..w {
            let p = (y * w + x) as usize;
            let (ma, va, mb, vb) = (a.mean[p], a.variance[p], b.mean[p], b.variance[p]);
            let (mut noisy, mut beyond, mut tail) = (false, false, 0.0);
            for c in 0..3 {
                let d = ma[c] - mb[c];
                // Noise-free: no spread beyond f32 rounding (the open floor under
                // the floor's control variate is one value in every replica, up to
                // the order its terms were added in).
                let scale = ma[c].abs().max(mb[c].abs()).max(1e-3);
                if (va[c] + vb[c]).sqrt() <= ROUNDING_SPREAD * scale {
                    exact_mismatches += usize::from(d.abs() > EXACT_TOLERANCE * scale);
                    continue;
                }
                noisy = true;
                let mut s = Sum::default();
                s.add(d, va[c], ka, vb[c], kb);
                beyond |= s.t().abs() > PIXEL_T;
                tail += two_sided_p(PIXEL_T, s.df());
                let wt = weights.weight[p][c];
                let (dw, vaw, vbw) = (d * wt, va[c] * wt * wt, vb[c] * wt * wt);
                total[c].add(dw, vaw, ka, vbw, kb);
                noise_a += vaw;
                noise_b += vbw;
                for (tiling, &(size, offset)) in tiles.iter_mut().zip(&tilings) {
                    let (tx, ty) = ((x + offset[0]) / size[0], (y + offset[1]) / size[1]);
                    let i = (ty * columns(size, offset) + tx) as usize;
                    tiling[i][c].add(dw, vaw, ka, vbw, kb);
                }
            }
            if noisy {
                noisy_pixels += 1;
                outliers += u64::from(beyond);
                expected_outliers += tail.min(1.0);
            }
        }
    }
    let outlier_bound = if expected_outliers > 0.0 {
        let poisson = Poisson::new(expected_outliers).expect("poisson");
        // The least c with P(N > c) ≤ α.
        (0u64..)
            .find(|&c| poisson.sf(c) <= alpha)
            .expect("a Poisson tail ends")
    } else {
        0
    };
    let tile_tests = 3 * tiles.iter().map(Vec::len).sum::<usize>();
    let mut worst_tile = (0.0, [0, 0], 0, 0, 0);
    for (tiling, &(size, offset)) in tiles.iter().zip(&tilings) {
        for (i, sums) in tiling.iter().enumerate() {
            for (c, s) in sums.iter().enumerate() {
                if s.variance <= 0.0 {
                    continue;
                }
                let ratio = s.t().abs() / critical_t(alpha / tile_tests as f64, s.df());
                if ratio > worst_tile.0 {
                    let cols = columns(size, offset) as usize;
                    let (tx, ty) = ((i % cols) as i64, (i / cols) as i64);
                    worst_tile = (
                        ratio,
                        size,
                        tx * i64::from(size[0]) - i64::from(offset[0]),
                        ty * i64::from(size[1]) - i64::from(offset[1]),
                        c,
                    );
                }
            }
        }
    }
    let total_t = total.map(|s| if s.variance > 0.0 { s.t() } else { 0.0 });
    let total_limit = total.map(|s| critical_t(alpha / 3.0, s.df()));
    Comparison {
        noisy_pixels,
        exact_mismatches,
        outliers,
        expected_outliers,
        outlier_bound,
        worst_tile,
        total_t,
        total_limit,
        noise_ratio: noise_a / noise_b,
    }
}

/// Compares `a` with `b`, asserts that they agree, and asserts that each of the
/// negative controls of [`assert_controls`] is rejected.
pub fn assert_agree_with_controls(
    a: &Replicas,
    b: &Replicas,
    weights: &Weights,
    what: &str,
) -> Comparison {
    assert_agree_with_controls_in(a, b, weights, what, defect_region(a))
}

/// [`assert_agree_with_controls`] with the region control's block `region`
/// (see [`defect_region`], [`defect_region_on`]).
pub fn assert_agree_with_controls_in(
    a: &Replicas,
    b: &Replicas,
    weights: &Weights,
    what: &str,
    region: Vec<bool>,
) -> Comparison {
    let comparison = compare(a, b, weights);
    comparison.assert_agree(what);
    assert_controls_in(a, b, weights, what, region);
    comparison
}

/// The pixels of a block of about 5 % of the image around the centre of the
/// noisy pixels (the object in view): where a defect of one material or one
/// lit region would show.
pub fn defect_region(a: &Replicas) -> Vec<bool> {
    let (w, h) = (a.width as usize, a.height as usize);
    let noisy = |p: usize| a.variance[p].iter().any(|&v| v > 0.0);
    let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
    for p in (0..w * h).filter(|&p| noisy(p)) {
        sx += (p % w) as f64;
        sy += (p / w) as f64;
        n += 1.0;
    }
    let (cx, cy) = if n > 0.0 {
        (sx / n, sy / n)
    } else {
        (w as f64 / 2.0, h as f64 / 2.0)
    };
    // A block of the image's aspect ratio.
    let area = 0.05 * (w * h) as f64;
    let bw = (area * w as f64 / h as f64).sqrt().round().max(1.0) as usize;
    let bh = (area / bw as f64).ceil() as usize;
    let x0 = (cx - bw as f64 / 2.0).round().clamp(0.0, (w - bw) as f64) as usize;
    let y0 = (cy - bh as f64 / 2.0).round().clamp(0.0, (h - bh) as f64) as usize;
    (0..w * h)
        .map(|p| (x0..x0 + bw).contains(&(p % w)) && (y0..y0 + bh).contains(&(p / w)))
        .collect()
}

/// A region control's block on one material: of the noisy pixels that `on`
/// marks (the pixels where the camera sees that material), the ones nearest to
/// their centroid, as many as 5 % of the image (all of them where there are
/// fewer). A defect of re-shading or rendering the paint shows on the paint;
/// a block of the image around the car's middle is mostly glass, and the
/// interior's noise behind it hides a 2 % defect.
pub fn defect_region_on(a: &Replicas, on: &[bool]) -> Vec<bool> {
    let w = a.width as usize;
    let candidates: Vec<usize> = (0..a.mean.len())
        .filter(|&p| on[p] && a.variance[p].iter().any(|&v| v > 0.0))
        .collect();
    let n = candidates.len().max(1) as f64;
    let cx = candidates.iter().map(|&p| (p % w) as f64).sum::<f64>() / n;
    let cy = candidates.iter().map(|&p| (p / w) as f64).sum::<f64>() / n;
    let distance = |p: usize| ((p % w) as f64 - cx).hypot((p / w) as f64 - cy);
    let mut nearest = candidates;
    nearest.sort_by(|&p, &q| distance(p).total_cmp(&distance(q)));
    nearest.truncate((0.05 * a.mean.len() as f64).round() as usize);
    let mut region = vec![false; a.mean.len()];
    for p in nearest {
        region[p] = true;
    }
    region
}

/// Compares a re-shade from one recorded path a pixel with `b` by its tile and
/// image sums only, and asserts that those reject every control but the 2 %
/// bias on 5 % of the pixels (printed, not asserted).
///
/// Such an image is a mean of single-sample estimates of the edit's
/// difference, too skewed for Student's t per pixel (more pixels beyond |t| > 4
/// than the t law predicts, with no bias in any sum); sums over tiles and the
/// image average enough pixels to be normal. Its noise is several times a fresh
/// render's, so a 2 % bias on 5 % of the pixels would take several times the
/// sessions to see; the re-shade computes its mean as the full re-shade does
/// (with one sample instead of all), and the full re-shade is held to that
/// control.
pub fn assert_first_image_agrees(a: &Replicas, b: &Replicas, weights: &Weights, what: &str) {
    let c = compare(a, b, weights);
    println!("{what}: {} (tiles and totals tested)", c.summary());
    assert!(
        !c.tiles_fail() && !c.totals_fail() && c.exact_mismatches == 0,
        "{what}: the images differ: {}",
        c.summary()
    );
    for (name, factor) in controls(a) {
        let c = compare(&a.biased(factor), b, weights);
        println!("  control {name}: {}", c.summary());
        assert!(
            name == REGION_CONTROL || c.tiles_fail() || c.totals_fail(),
            "{what}: the control \"{name}\" passed: {}",
            c.summary()
        );
    }
}

/// A defect: the factor of each (pixel, channel).
pub type Factor = Box<dyn Fn(usize, usize) -> f64>;

/// The name of the control that biases a block of 5 % of the pixels.
pub const REGION_CONTROL: &str = "5 % of the pixels +2 %";

/// The defects every image comparison must catch, as (name, factor(pixel,
/// channel)), applied to the pixels with noise (a noise-free pixel would be
/// caught by its exact comparison, which says nothing of the statistics).
pub fn controls(a: &Replicas) -> Vec<(&'static str, Factor)> {
    controls_in(a, defect_region(a))
}

/// [`controls`] with the region control's block `region`.
pub fn controls_in(a: &Replicas, region: Vec<bool>) -> Vec<(&'static str, Factor)> {
    let noisy: Vec<bool> = a
        .variance
        .iter()
        .map(|v| v.iter().any(|&v| v > 0.0))
        .collect();
    let region: Vec<bool> = region
        .into_iter()
        .zip(&noisy)
        .map(|(r, &n)| r && n)
        .collect();
    let on = move |mask: Vec<bool>,
                   channels: [bool; 3],
                   factor: f64|
          -> Box<dyn Fn(usize, usize) -> f64> {
        Box::new(move |p, c| if mask[p] && channels[c] { factor } else { 1.0 })
    };
    vec![
        ("uniform +1 %", on(noisy.clone(), [true; 3], 1.01)),
        (REGION_CONTROL, on(region, [true; 3], 1.02)),
        (
            "X alone +2 %",
            on(noisy.clone(), [true, false, false], 1.02),
        ),
        ("Z alone −2 %", on(noisy, [false, false, true], 0.98)),
    ]
}

/// Asserts that the comparison of `a` with `b` rejects each control defect
/// put into `a`, and prints by which criterion and how far.
pub fn assert_controls(a: &Replicas, b: &Replicas, weights: &Weights, what: &str) {
    assert_controls_in(a, b, weights, what, defect_region(a));
}

/// [`assert_controls`] with the region control's block `region`.
pub fn assert_controls_in(
    a: &Replicas,
    b: &Replicas,
    weights: &Weights,
    what: &str,
    region: Vec<bool>,
) {
    for (name, factor) in controls_in(a, region) {
        let c = compare(&a.biased(factor), b, weights);
        println!("  control {name}: {}", c.summary());
        assert!(
            c.fails(),
            "{what}: the control \"{name}\" passed: {}",
            c.summary()
        );
    }
}
