//! Drawing indices from discrete distributions with one uniform number, keeping
//! what is left of the number for a continuous draw inside the chosen bin (pbrt's
//! "continuous inversion"): the building blocks of importance sampling.
//!
//! - [`distribution`]: [`Distribution1D`], inversion of a piecewise-constant cdf,
//!   started from a guide table (a step or two per draw);
//! - [`alias`]: Walker's alias tables (one look-up per draw, whatever the weights).
//!
//! Nothing here knows about light or paint; the environment's map sampling
//! ([`crate::render::environment`]) is built from these.

pub mod alias;
pub mod distribution;

pub use alias::{AliasEntry, alias_sample, alias_table};
pub use distribution::Distribution1D;

/// The largest f64 below 1: uniform numbers and fractions within a bin are clamped
/// to it so that they stay in [0, 1).
pub const ONE_BELOW: f64 = 1.0 - f64::EPSILON / 2.0;

/// What the unit tests of sampling code share: a small deterministic generator and
/// Pearson's χ².
#[cfg(test)]
pub(crate) mod test_support {
    /// The next uniform number in [0, 1) (53 bits) from `state` (SplitMix64).
    pub(crate) fn uniform(state: &mut u64) -> f64 {
        *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = *state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Pearson's χ² of observed `counts` against expected counts, over the cells
    /// that expect at least 5, and the bound it must stay under: the mean
    /// (cells − 1) plus five standard deviations √(2(cells − 1)).
    pub(crate) fn chi_square(counts: &[u64], expected: &[f64]) -> (f64, f64) {
        let (mut chi2, mut cells) = (0.0f64, 0.0f64);
        for (&count, &e) in counts.iter().zip(expected) {
            if e >= 5.0 {
                chi2 += (count as f64 - e).powi(2) / e;
                cells += 1.0;
            }
        }
        let dof = (cells - 1.0).max(1.0);
        (chi2, dof + 5.0 * (2.0 * dof).sqrt())
    }

    /// `n` draws of `draw` (an index and the fraction within its bin) follow
    /// `weights`, with the fraction uniform in each bin: Pearson's χ² over (index,
    /// quarter of the bin) cells against wᵢ/4Σw passes. The negative control: the
    /// same draws against the weights ×1.1 where `raised(i)` (renormalised) fail.
    pub(crate) fn assert_draws_follow(
        weights: &[f64],
        n: usize,
        mut draw: impl FnMut() -> (usize, f64),
        raised: impl Fn(usize) -> bool,
    ) {
        let mut counts = vec![0u64; 4 * weights.len()];
        for _ in 0..n {
            let (i, frac) = draw();
            assert!(weights[i] > 0.0, "drew the empty index {i}");
            assert!((0.0..1.0).contains(&frac), "fraction {frac}");
            counts[4 * i + (frac * 4.0) as usize] += 1;
        }
        let expected_for = |factor: &dyn Fn(usize) -> f64| -> Vec<f64> {
            let total: f64 = (0..weights.len()).map(|i| weights[i] * factor(i)).sum();
            (0..counts.len())
                .map(|cell| weights[cell / 4] * factor(cell / 4) / total / 4.0 * n as f64)
                .collect()
        };
        let (chi2, bound) = chi_square(&counts, &expected_for(&|_| 1.0));
        assert!(chi2 < bound, "χ² {chi2:.1}, bound {bound:.1}");
        let (wrong, _) = chi_square(
            &counts,
            &expected_for(&|i| if raised(i) { 1.1 } else { 1.0 }),
        );
        assert!(wrong >= bound, "weights ×1.1 on half passed: χ² {wrong:.1}");
    }
}
