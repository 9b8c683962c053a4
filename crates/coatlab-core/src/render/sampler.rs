//! Random numbers for the tracer, as a pure function of (seed, pixel, sample,
//! dimension): a render is the same for a seed whatever the thread count or the
//! order in which tiles run, and progressive passes never repeat a sample.
//!
//! # Owen-scrambled Sobol points (Burley 2020)
//! The numbers are a low-discrepancy sequence per pixel rather than independent
//! draws: B. Burley, "Practical Hash-based Owen Scrambling", JCGT 9(4), 2020.
//! Each [`PixelSampler::next_2d`] call is one *dimension pair* of the path (the
//! pixel jitter, a light sample, a BSDF direction): its point is the first two
//! Sobol dimensions (van der Corput and the (0, 2)-sequence's second matrix) at a
//! *shuffled* sample index, each coordinate Owen-scrambled with its own seed;
//! [`PixelSampler::next_1d`] is the scrambled van der Corput point alone. The
//! seeds come from a hash of (seed, pixel, dimension), so pixels and dimensions
//! are decorrelated, and each scrambled point is uniform on [0, 1)ᵈ: a pixel's
//! mean stays an unbiased estimate, converging to the same image as independent
//! numbers.
//!
//! Why: the first 2^m samples of a pixel put one point in every elementary
//! interval of area 2^-m of each dimension pair (16 samples: one in each 4 × 4
//! cell, also 16 × 1 and 1 × 16), so the pixel footprint, the light samples and
//! the first BSDF directions are stratified and the error falls faster than
//! 1/√n where the integrand is smooth in those dimensions.
//!
//! The index shuffle is an Owen scramble of the index's bits too: bit k of the
//! result depends only on bits ≥ k, so the first 2^m indices of a pixel map onto
//! one aligned block of 2^m Sobol indices — itself a (0, m, 2)-net — in a
//! scrambled order. A pixel's sample index runs on across progressive passes, so
//! its N samples are always the first N points of its sequence.
//!
//! The scramble is a Laine–Karras-style hash on the bit-reversed value (each
//! output bit a function of the input bits above it); the constants are N.
//! Vegdahl's improved version ("Building a Better LK Hash", 2021) of Burley's.
//!
//! With these numbers a pixel's samples are no longer independent but negatively
//! correlated: the spread of its samples (the film's variance) over-estimates the
//! error of its mean, so noise estimates and Z-tests built on it are conservative.
//! Numbers are 24-bit: every value is exactly representable and below 1.

/// Random numbers for one pixel sample: call [`PixelSampler::next_1d`] and
/// [`PixelSampler::next_2d`] in a fixed order along the path; each call is a
/// dimension of its own (a 2D call is one dimension pair, stratified in 2D).
#[derive(Debug, Clone)]
pub struct PixelSampler {
    /// Hash of (seed, pixel): the key of every dimension's scrambling seeds.
    pixel_key: u64,
    /// The sample's index within its pixel's sequence, bit-reversed (the
    /// scrambles work on reversed bits).
    index_reversed: u32,
    /// The next dimension (1D number or 2D pair) to draw.
    dimension: u32,
}

impl PixelSampler {
    /// The sampler of sample `sample_index` of pixel `pixel_index` in a render
    /// with `seed`.
    pub fn new(seed: u64, pixel_index: u32, sample_index: u32) -> Self {
        let pixel_key = mix64(seed ^ mix64(u64::from(pixel_index) | PIXEL_TAG));
        Self {
            pixel_key,
            index_reversed: sample_index.reverse_bits(),
            dimension: 0,
        }
    }

    /// The scrambling seeds of the next dimension: (index shuffle, first
    /// coordinate, second coordinate).
    #[inline]
    fn next_seeds(&mut self) -> (u32, u32, u32) {
        let h = mix64(
            self.pixel_key
                .wrapping_add(u64::from(self.dimension).wrapping_mul(0x9E37_79B9_7F4A_7C15)),
        );
        self.dimension += 1;
        let h2 = mix64(h ^ 0xD1B5_4A32_D192_ED03);
        (h as u32, (h >> 32) as u32, h2 as u32)
    }

    /// The next number in [0, 1): scrambled van der Corput at the shuffled index.
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let (shuffle, seed_x, _) = self.next_seeds();
        // The shuffled index, bit-reversed: van der Corput's fraction itself.
        let fraction = laine_karras(self.index_reversed, shuffle);
        to_unit(owen_scramble(fraction, seed_x))
    }

    /// The next pair in [0, 1)²: Sobol dimensions 0 and 1 at the shuffled index,
    /// each Owen-scrambled.
    #[inline]
    pub fn next_2d(&mut self) -> [f32; 2] {
        let (shuffle, seed_x, seed_y) = self.next_seeds();
        Self::point_2d(self.index_reversed, shuffle, seed_x, seed_y)
    }

    /// `out.len()` pairs of one dimension pair, for a split of the sample into
    /// K = `out.len()` parts (a power of two): part j is the point of index
    /// K·s + j of the pixel's sequence (s this sample's index), so the parts of
    /// the first N samples are the first K·N points — stratified together as a
    /// (0, m, 2)-net, not K independent draws. With K = 1 this is
    /// [`Self::next_2d`].
    ///
    /// # Panics
    /// If `out.len()` is not a power of two.
    #[inline]
    pub fn next_2d_split(&mut self, out: &mut [[f32; 2]]) {
        assert!(out.len().is_power_of_two(), "a split into 2^b parts");
        let bits = out.len().trailing_zeros();
        let (shuffle, seed_x, seed_y) = self.next_seeds();
        for (j, o) in out.iter_mut().enumerate() {
            // reverse(K·s + j) = reverse(s) >> b | reverse(j).
            let index_reversed =
                self.index_reversed.checked_shr(bits).unwrap_or(0) | (j as u32).reverse_bits();
            *o = Self::point_2d(index_reversed, shuffle, seed_x, seed_y);
        }
    }

    /// The scrambled 2D point of a bit-reversed index.
    #[inline]
    fn point_2d(index_reversed: u32, shuffle: u32, seed_x: u32, seed_y: u32) -> [f32; 2] {
        let fraction = laine_karras(index_reversed, shuffle);
        [
            to_unit(owen_scramble(fraction, seed_x)),
            to_unit(owen_scramble(sobol_1(fraction.reverse_bits()), seed_y)),
        ]
    }
}

/// Set above a pixel index's 32 bits, so a pixel's key never equals a plain
/// small number's hash.
const PIXEL_TAG: u64 = 0x5A17_0000_0000_0000;

/// The top 24 bits of `x` as a number in [0, 1).
#[inline]
fn to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Direction numbers of Sobol's second dimension (primitive polynomial x + 1,
/// m = 1): v₀ = 2³¹, v_k = v_{k−1} ⊕ (v_{k−1} ≫ 1) — the Pascal matrix mod 2.
const SOBOL_1: [u32; 32] = {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut k = 1;
    while k < 32 {
        v[k] = v[k - 1] ^ (v[k - 1] >> 1);
        k += 1;
    }
    v
};

/// [`SOBOL_1`] by bytes: the matrix is linear over GF(2), so the point of an
/// index is the XOR of its four bytes' points, read from 4 × 256 entries.
const SOBOL_1_BY_BYTE: [[u32; 256]; 4] = {
    let mut table = [[0u32; 256]; 4];
    let mut byte = 0;
    while byte < 4 {
        let mut value = 0;
        while value < 256 {
            let mut x = 0;
            let mut bit = 0;
            while bit < 8 {
                if value & (1 << bit) != 0 {
                    x ^= SOBOL_1[byte * 8 + bit];
                }
                bit += 1;
            }
            table[byte][value] = x;
            value += 1;
        }
        byte += 1;
    }
    table
};

/// Sobol's second dimension at `index`, as a 32-bit fraction.
#[inline]
fn sobol_1(index: u32) -> u32 {
    let [b0, b1, b2, b3] = index.to_le_bytes();
    SOBOL_1_BY_BYTE[0][usize::from(b0)]
        ^ SOBOL_1_BY_BYTE[1][usize::from(b1)]
        ^ SOBOL_1_BY_BYTE[2][usize::from(b2)]
        ^ SOBOL_1_BY_BYTE[3][usize::from(b3)]
}

/// Nested uniform (Owen) scrambling of a 32-bit fraction with `seed`: a hash of
/// the bit-reversed value in which each bit depends only on the bits below it,
/// so in the fraction each bit is flipped by a function of the bits above it.
#[inline]
fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// The hash behind [`owen_scramble`], on the bit-reversed value: each output bit
/// a function of the input bits at and below it (multiplications by even
/// numbers, an addition, a multiplication by an odd number), bijective.
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3D20_ADEA);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6C56);
    x ^= x.wrapping_mul(0x53A2_2864);
    x
}

/// SplitMix64's finaliser: a bijective 64-bit mix with full avalanche.
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first `count` 2D points of dimension pair `dimension` of a pixel.
    fn points_2d(seed: u64, pixel: u32, dimension: u32, count: u32) -> Vec<[f32; 2]> {
        (0..count)
            .map(|s| {
                let mut sampler = PixelSampler::new(seed, pixel, s);
                for _ in 0..dimension {
                    sampler.next_2d();
                }
                sampler.next_2d()
            })
            .collect()
    }

    /// The inverse cdf of the density ×1.1 on [0, ½) and ×1 on [½, 1), renormalised
    /// (1.1/1.05 and 1/1.05): maps uniform numbers to numbers whose density is
    /// 10 % off on half of the interval, `high_below` saying which half is high.
    /// The negative controls feed the tests' statistics with such numbers.
    fn ten_percent_off(u: f32, high_below: bool) -> f32 {
        let (low, high) = (1.0 / 1.05, 1.1 / 1.05);
        let (first, second) = if high_below { (high, low) } else { (low, high) };
        let u = f64::from(u);
        let split = 0.5 * first;
        let x = if u < split {
            u / first
        } else {
            0.5 + (u - split) / second
        };
        (x as f32).min(1.0 - f32::EPSILON / 2.0)
    }

    /// χ² of `counts` against equal expected counts.
    fn chi2(counts: &[f64]) -> f64 {
        let expected = counts.iter().sum::<f64>() / counts.len() as f64;
        counts
            .iter()
            .map(|c| (c - expected).powi(2) / expected)
            .sum()
    }

    #[test]
    fn the_same_key_gives_the_same_numbers_and_others_differ() {
        let a: Vec<f32> = {
            let mut s = PixelSampler::new(7, 1234, 5);
            (0..16).map(|_| s.next_1d()).collect()
        };
        let b: Vec<f32> = {
            let mut s = PixelSampler::new(7, 1234, 5);
            (0..16).map(|_| s.next_1d()).collect()
        };
        assert_eq!(a, b);
        let mut c = PixelSampler::new(7, 1234, 6);
        assert_ne!(a[0], c.next_1d());
        let mut d = PixelSampler::new(8, 1234, 5);
        assert_ne!(a[0], d.next_1d());
        let mut e = PixelSampler::new(7, 1235, 5);
        assert_ne!(a[0], e.next_1d());
    }

    #[test]
    fn sobol_second_dimension_has_the_published_direction_numbers() {
        // m = 1, 3, 5, 15, 17, 51 (Joe and Kuo's second dimension), v_k = m_k·2^(32−k).
        for (k, m) in [1u32, 3, 5, 15, 17, 51].into_iter().enumerate() {
            assert_eq!(SOBOL_1[k], m << (31 - k), "v_{k}");
        }
        assert_eq!(sobol_1(0), 0);
        // The byte tables against the bit-by-bit product with the matrix.
        let mut state = 0x2545_F491_u32;
        for _ in 0..10_000 {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            let by_bits = (0..32)
                .filter(|k| state & (1 << k) != 0)
                .fold(0, |x, k| x ^ SOBOL_1[k]);
            assert_eq!(sobol_1(state), by_bits, "index {state:#x}");
        }
    }

    #[test]
    fn owen_scrambling_is_a_bijection_that_keeps_the_bits_above_in_charge() {
        // Bit k of the result depends only on bits ≥ k: values sharing their top
        // j bits still share them after scrambling, and no two values collide.
        let seed = 0x1234_5678;
        let mut seen = std::collections::HashSet::new();
        for x in 0..1u32 << 16 {
            let v = x << 16;
            assert!(seen.insert(owen_scramble(v, seed)), "collision at {x}");
            let top = owen_scramble(v, seed) >> 24;
            assert_eq!(top, owen_scramble(v | 0xFFFF, seed) >> 24);
        }
    }

    #[test]
    fn the_first_power_of_two_points_of_a_pair_are_stratified() {
        // A (0, m, 2)-net: for every split 2^a × 2^(m−a) of the square, one point
        // in each cell; and the 1D numbers one in each interval of 2^−m. Checked
        // for several pixels, seeds and dimensions, up to 1024 points.
        for (seed, pixel) in [(1u64, 0u32), (2, 77), (99, 123_456)] {
            for dimension in [0u32, 1, 5] {
                for m in 0..=10u32 {
                    let n = 1u32 << m;
                    let points = points_2d(seed, pixel, dimension, n);
                    for a in 0..=m {
                        let (nx, ny) = (1u32 << a, 1u32 << (m - a));
                        let mut cells = vec![0u8; n as usize];
                        for &[x, y] in &points {
                            assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
                            let cx = (x * nx as f32) as u32;
                            let cy = (y * ny as f32) as u32;
                            cells[(cy * nx + cx) as usize] += 1;
                        }
                        assert!(
                            cells.iter().all(|&c| c == 1),
                            "seed {seed} pixel {pixel} dim {dimension}: {n} points, {nx}×{ny} cells"
                        );
                    }
                }
                let mut cells = vec![0u8; 256];
                for s in 0..256 {
                    let mut sampler = PixelSampler::new(seed, pixel, s);
                    for _ in 0..dimension {
                        sampler.next_1d();
                    }
                    cells[(sampler.next_1d() * 256.0) as usize] += 1;
                }
                assert!(cells.iter().all(|&c| c == 1), "1D, dim {dimension}");
            }
        }
    }

    #[test]
    fn pixels_and_dimensions_are_decorrelated() {
        // Two coordinates drawn with the same index and no shuffle would be tied
        // (the top bits of one fix the top bits of the other: 8 of 64 cells
        // filled). Joint 8 × 8 histograms over 2^17 samples of: the first
        // coordinates of two dimension pairs of one pixel, of one pair in two
        // neighbouring pixels, and a 1D number against the next pair. χ² with
        // 63 degrees of freedom: mean 63, sd ≈ 11.2; stratification only lowers it.
        //
        // Negative control: the same pairs with the second coordinate moved so the
        // joint density is 10 % higher on the two diagonal quadrants (uniform
        // marginals, a correlation). Its χ² excess is n·(0.1/2.1)² ≈ 0.0023 n, so
        // the 4096 samples this test once used could not see it (≈ 9); 2^17 give
        // ≈ 300 over a bound of 119.
        let n = 1 << 17;
        let mut cases: Vec<(&str, Vec<[f32; 2]>)> = Vec::new();
        let d0 = points_2d(4, 10, 0, n);
        let d1 = points_2d(4, 10, 1, n);
        let p1 = points_2d(4, 11, 0, n);
        cases.push((
            "pairs 0 and 1",
            d0.iter().zip(&d1).map(|(a, b)| [a[0], b[0]]).collect(),
        ));
        cases.push((
            "pixels 10 and 11",
            d0.iter().zip(&p1).map(|(a, b)| [a[1], b[1]]).collect(),
        ));
        cases.push((
            "1D then 2D",
            (0..n)
                .map(|s| {
                    let mut sampler = PixelSampler::new(4, 10, s);
                    let u = sampler.next_1d();
                    [u, sampler.next_2d()[0]]
                })
                .collect(),
        ));
        let joint_chi2 = |pairs: &[[f32; 2]]| {
            let mut counts = [0.0f64; 64];
            for &[x, y] in pairs {
                counts[(y * 8.0) as usize * 8 + (x * 8.0) as usize] += 1.0;
            }
            chi2(&counts)
        };
        let bound = 63.0 + 5.0 * 11.2;
        for (name, pairs) in cases {
            let c = joint_chi2(&pairs);
            assert!(c < bound, "{name}: χ² = {c}");
            let correlated: Vec<[f32; 2]> = pairs
                .iter()
                .map(|&[x, y]| [x, ten_percent_off(y, x < 0.5)])
                .collect();
            let control = joint_chi2(&correlated);
            println!("{name}: χ² {c:.1}; density 10 % higher on the diagonal: {control:.1}");
            assert!(
                control >= bound,
                "{name}: a 10 % correlation passed, χ² {control}"
            );
        }
    }

    #[test]
    fn numbers_are_uniform_over_many_pixels() {
        // χ² on 64 bins (1D) and 16 × 16 cells (2D) over 2^18 draws: sample 0..8 of
        // 32768 pixels, in a later dimension. Each pixel's 8 points are stratified,
        // so only the upper tail is tested. 1D: mean 63, sd ≈ 11.2; 2D: 255, ≈ 22.6.
        //
        // Negative control: the same numbers moved to a density 10 % higher on half
        // of the interval (of v in 2D), renormalised. The χ² excess is ≈ 0.0023 n:
        // at the 2^16 draws this test once used, ≈ 150, under the 2D bound of 368;
        // at 2^18, ≈ 600.
        let n = 1u32 << 18;
        let mut counts_1d = [0.0f64; 64];
        let mut counts_2d = [0.0f64; 256];
        let mut wrong_1d = [0.0f64; 64];
        let mut wrong_2d = [0.0f64; 256];
        for i in 0..n {
            let mut s = PixelSampler::new(3, i / 8, i % 8);
            s.next_2d();
            let x = s.next_1d();
            assert!((0.0..1.0).contains(&x));
            counts_1d[(x * 64.0) as usize] += 1.0;
            wrong_1d[(ten_percent_off(x, true) * 64.0) as usize] += 1.0;
            let [u, v] = s.next_2d();
            counts_2d[(v * 16.0) as usize * 16 + (u * 16.0) as usize] += 1.0;
            wrong_2d[(ten_percent_off(v, true) * 16.0) as usize * 16 + (u * 16.0) as usize] += 1.0;
        }
        let (bound_1d, bound_2d) = (63.0 + 5.0 * 11.2, 255.0 + 5.0 * 22.6);
        let c1 = chi2(&counts_1d);
        assert!(c1 < bound_1d, "1D χ² = {c1}");
        let c2 = chi2(&counts_2d);
        assert!(c2 < bound_2d, "2D χ² = {c2}");
        let (w1, w2) = (chi2(&wrong_1d), chi2(&wrong_2d));
        println!("χ² 1D {c1:.1}, 2D {c2:.1}; density 10 % off on half: 1D {w1:.1}, 2D {w2:.1}");
        assert!(w1 >= bound_1d, "1D: a 10 % density error passed, χ² {w1}");
        assert!(w2 >= bound_2d, "2D: a 10 % density error passed, χ² {w2}");
        // And successive dimensions of one sample are not correlated (lag-1
        // products over 20 000 dimensions).
        let mut s = PixelSampler::new(9, 0, 0);
        let xs: Vec<f64> = (0..20_000).map(|_| f64::from(s.next_1d()) - 0.5).collect();
        let corr: f64 = xs.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / (xs.len() as f64 / 12.0);
        assert!(corr.abs() < 0.05, "lag-1 correlation {corr}");
    }

    #[test]
    fn the_spread_of_a_pixels_samples_over_states_its_error() {
        // What the film's noise estimate meets (docs/rendering.md, "Sampler"): for an
        // integrand with an edge (a silhouette), the variance of the mean estimated
        // from the samples' spread, s²/n, exceeds the true squared error of the mean
        // over many pixels. With independent numbers the two would agree.
        let f = |[x, y]: [f32; 2]| f64::from(x * y) + if x + 0.5 * y > 0.6 { 1.0 } else { 0.0 };
        // ∫∫ x·y = 1/4; the area of x + y/2 > 0.6 in the unit square is 1 − (0.6 − 1/4).
        let exact = 0.25 + 0.65;
        let (pixels, n) = (400u32, 64u32);
        let (mut squared_error, mut estimated) = (0.0f64, 0.0f64);
        for pixel in 0..pixels {
            let values: Vec<f64> = points_2d(6, pixel, 3, n).into_iter().map(f).collect();
            let mean = values.iter().sum::<f64>() / f64::from(n);
            let spread = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / f64::from(n - 1);
            squared_error += (mean - exact).powi(2);
            estimated += spread / f64::from(n);
        }
        let ratio = estimated / squared_error;
        println!("s²/n over the squared error of the mean: {ratio:.1}");
        assert!(
            ratio > 4.0,
            "estimated / true variance of the mean: {ratio}"
        );
    }

    #[test]
    fn a_stratified_estimate_beats_independent_numbers() {
        // The point of the sampler: the mean of a smooth integrand over a pixel's
        // first 64 points errs far less than 1/√n. ∫∫ x·y = 1/4; independent
        // numbers would give an RMS error of sd(xy)/8 ≈ 0.028 over the pixels.
        let pixels = 200;
        let mut squared = 0.0f64;
        for pixel in 0..pixels {
            let points = points_2d(5, pixel, 2, 64);
            let mean = points.iter().map(|&[x, y]| f64::from(x * y)).sum::<f64>() / 64.0;
            squared += (mean - 0.25).powi(2);
        }
        let rms = (squared / f64::from(pixels)).sqrt();
        assert!(rms < 0.028 / 4.0, "RMS error {rms}");
    }
}
