//! A discrete distribution over indices 0..n, drawn by inverting its cdf:
//! `sample(u)` gives the index and where u fell within that index's share, so one
//! uniform number chooses a bin and then a point inside it.

use super::ONE_BELOW;

/// Guide entries per index of a [`Distribution1D`]: a target's part holds on
/// average 1/this of the cdf's steps whatever the weights (the parts are equal
/// in weight, so they are hit as often as the steps lie in them), so the search
/// from the guide's entry takes a step in 1 of 4 draws instead of 1 of 1.
const GUIDE_PARTS_PER_INDEX: usize = 4;

/// A discrete distribution with continuous inversion: index i has probability
/// wᵢ / Σw (negative weights count as 0), and `sample(u)` gives the index and
/// where u fell within its share, in [0, 1).
#[derive(Debug, Clone)]
pub struct Distribution1D {
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
    /// The distribution of `weights` (at least one; negative ones count as 0).
    /// All-zero weights give a distribution of total 0, whose every probability
    /// is 0 and whose draws still return some index.
    ///
    /// # Panics
    /// If `weights` is empty.
    pub fn new(weights: &[f64]) -> Self {
        assert!(
            !weights.is_empty(),
            "a distribution needs at least one weight"
        );
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        let mut sum = 0.0;
        cdf.push(0.0);
        for &w in weights {
            sum += w.max(0.0);
            cdf.push(sum);
        }
        let parts = weights.len() * GUIDE_PARTS_PER_INDEX;
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

    /// The number of indices.
    pub fn len(&self) -> usize {
        self.cdf.len() - 1
    }

    /// Whether there are no indices (never: [`Self::new`] needs one).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The sum of the (non-negative) weights.
    #[inline]
    pub fn total(&self) -> f64 {
        self.cdf[self.cdf.len() - 1]
    }

    /// The probability of index `i`: wᵢ / Σw, or 0 when the total is 0.
    ///
    /// # Panics
    /// If `i` is not below [`Self::len`].
    #[inline]
    pub fn probability(&self, i: usize) -> f64 {
        self.probabilities[i]
    }

    /// The first index p with cdf[p] > target (`cdf.len()` if none): what
    /// `cdf.partition_point(|&c| c <= target)` returns, started from the guide.
    #[inline]
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

    /// The index that `u` (clamped to [0, 1)) falls on, with probability
    /// [`Self::probability`], and where it fell within that index's share, in
    /// [0, 1): uniform given the index, so it can place a point in the bin. Never
    /// an index of weight 0 while the total is positive.
    #[inline]
    pub fn sample(&self, u: f64) -> (usize, f64) {
        let n = self.cdf.len() - 1;
        let target = u.clamp(0.0, ONE_BELOW) * self.total();
        // One index (an environment that is only a map): no search, the same
        // answer (`upper_bound(target).max(1) - 1` clamped to 0).
        let i = if n == 1 {
            0
        } else {
            (self.upper_bound(target).max(1) - 1).min(n - 1)
        };
        self.landing(i, target)
    }

    /// Index `i` that the search for `target` found, moved off an empty bin, and
    /// where `target` fell within that index's share.
    #[inline]
    fn landing(&self, mut i: usize, target: f64) -> (usize, f64) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::test_support::{assert_draws_follow, uniform};

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

    /// `n` weights from uniform numbers: every `period`-th one 0 (empty bins), the
    /// one after it `spike(u)`, the others `rest(u)`.
    fn lumpy_weights(
        n: usize,
        period: usize,
        state: &mut u64,
        spike: impl Fn(f64) -> f64,
        rest: impl Fn(f64) -> f64,
    ) -> Vec<f64> {
        (0..n)
            .map(|i| match i % period {
                0 => 0.0,
                1 => spike(uniform(state)),
                _ => rest(uniform(state)),
            })
            .collect()
    }

    /// `sample` (guided search, one-index shortcut, probabilities computed once)
    /// gives the index and fraction of the plain inversion by binary search (with
    /// the same landing off empty bins), bit for bit, for random numbers, 0, the
    /// largest below 1 and numbers whose targets fall at and next to every step of
    /// the cdf.
    #[test]
    fn samples_are_the_plain_cdf_inversion() {
        let mut state = 3;
        let weights = lumpy_weights(700, 5, &mut state, |u| 1e3 * u.powi(6), |u| u);
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
            assert_eq!(d.len(), n);
            let plain = |u: f64| -> (usize, f64) {
                let target = u.clamp(0.0, ONE_BELOW) * total;
                let i = (d.cdf.partition_point(|&c| c <= target).max(1) - 1).min(n - 1);
                d.landing(i, target)
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

    /// Draws follow the weights, and the fraction is uniform within each bin:
    /// Pearson's χ² over (index, quarter of the bin) cells against wᵢ/4Σw. The
    /// negative control: the same draws against weights ×1.1 on the first half of
    /// the indices (renormalised) must fail.
    #[test]
    fn draws_follow_the_weights_and_fill_each_bin_uniformly() {
        let mut state = 29;
        let weights = lumpy_weights(60, 6, &mut state, |u| 5.0 * u, |u| u.powi(2));
        let d = Distribution1D::new(&weights);
        let half = weights.len() / 2;
        let draw = || d.sample(uniform(&mut state));
        assert_draws_follow(&weights, 400_000, draw, |i| i < half);
    }

    #[test]
    fn all_zero_weights_have_zero_probabilities_and_still_draw() {
        let d = Distribution1D::new(&[0.0, -1.0, 0.0]);
        assert_eq!(d.total(), 0.0);
        assert!((0..3).all(|i| d.probability(i) == 0.0));
        let (i, frac) = d.sample(0.7);
        assert!(i < 3 && (0.0..1.0).contains(&frac));
    }
}
