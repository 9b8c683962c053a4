//! Random numbers for the tracer, as a pure function of (seed, pixel, sample,
//! dimension): a render is the same for a seed whatever the thread count or the
//! order in which tiles run, and progressive passes never repeat a sample.
//!
//! The hash is a PCG-style permutation (O'Neill's `pcg_hash` of a combined key,
//! then a 64→32-bit output function); its output is mapped to [0, 1) with 24 bits.

/// Random numbers for one pixel sample: call [`PixelSampler::next_1d`] and
/// [`PixelSampler::next_2d`] in a fixed order along the path.
#[derive(Debug, Clone)]
pub struct PixelSampler {
    key: u64,
    dimension: u32,
}

impl PixelSampler {
    /// The sampler of sample `sample_index` of pixel `pixel_index` in a render
    /// with `seed`.
    pub fn new(seed: u64, pixel_index: u32, sample_index: u32) -> Self {
        let key = mix64(seed ^ mix64((u64::from(pixel_index) << 32) | u64::from(sample_index)));
        Self { key, dimension: 0 }
    }

    /// The next number in [0, 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let bits = mix64(
            self.key
                .wrapping_add(u64::from(self.dimension).wrapping_mul(0x9E37_79B9_7F4A_7C15)),
        );
        self.dimension += 1;
        // 24 bits: every value is exactly representable and below 1.
        (bits >> 40) as f32 * (1.0 / 16_777_216.0)
    }

    /// The next pair in [0, 1)².
    #[inline]
    pub fn next_2d(&mut self) -> [f32; 2] {
        [self.next_1d(), self.next_1d()]
    }
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
    }

    #[test]
    fn numbers_are_uniform_in_the_unit_interval() {
        // χ² on 64 bins over 2^16 draws from many keys: mean 63, sd ≈ 11.2.
        const BINS: usize = 64;
        let mut counts = [0.0_f64; BINS];
        let n = 1 << 16;
        for i in 0..n {
            let mut s = PixelSampler::new(3, i / 8, i % 8);
            for _ in 0..1 {
                let x = s.next_1d();
                assert!((0.0..1.0).contains(&x));
                counts[(x * BINS as f32) as usize] += 1.0;
            }
        }
        let expected = n as f64 / BINS as f64;
        let chi2: f64 = counts
            .iter()
            .map(|c| (c - expected).powi(2) / expected)
            .sum();
        assert!(chi2 < 63.0 + 5.0 * 11.2, "χ² = {chi2}");
        // And dimensions of one sample are not correlated (lag-1 products).
        let mut s = PixelSampler::new(9, 0, 0);
        let xs: Vec<f64> = (0..20_000).map(|_| f64::from(s.next_1d()) - 0.5).collect();
        let corr: f64 = xs.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / (xs.len() as f64 / 12.0);
        assert!(corr.abs() < 0.05, "lag-1 correlation {corr}");
    }
}
