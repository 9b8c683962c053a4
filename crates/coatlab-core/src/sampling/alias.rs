//! Walker's alias method: a discrete distribution drawn with one look-up whatever
//! its weights. The uniform number picks an index uniformly; that index is kept
//! with its entry's probability, else its alias is taken.

use super::ONE_BELOW;

/// One index's entry in an alias table (8 bytes): the probability that a draw
/// landing on this index keeps it, else it takes `alias`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AliasEntry {
    /// Probability of keeping the index the draw landed on, in [0, 1].
    pub keep: f32,
    /// The index taken otherwise.
    pub alias: u32,
}

impl AliasEntry {
    /// The draw that landed on `index` (whose entry this is), `frac` in [0, 1)
    /// where within its 1/n share: the index it takes, and `frac` rescaled to
    /// [0, 1) within the part of the share that chose it (uniform given the
    /// index, so it can place a point inside the bin).
    #[inline]
    pub fn pick(self, index: usize, frac: f64) -> (usize, f64) {
        let keep = f64::from(self.keep);
        let (i, w) = if frac < keep {
            (index, frac / keep)
        } else {
            (self.alias as usize, (frac - keep) / (1.0 - keep))
        };
        (i, w.clamp(0.0, ONE_BELOW))
    }
}

/// Walker's alias table of `weights` (Vose's construction, in f64): per index, the
/// probability of keeping it and the index that takes the rest. Index i is drawn
/// with probability (keep_i + Σ_{j: alias_j = i} (1 − keep_j)) / n = w_i / Σw.
/// Negative weights count as 0; all-zero weights give the uniform table.
pub fn alias_table(weights: &[f64]) -> Vec<AliasEntry> {
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
    let mut table: Vec<AliasEntry> = (0..n as u32)
        .map(|i| AliasEntry {
            keep: 1.0,
            alias: i,
        })
        .collect();
    let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
    while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
        small.pop();
        table[s] = AliasEntry {
            keep: scaled[s] as f32,
            alias: l as u32,
        };
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // What is left holds 1 up to rounding: kept always.
    table
}

/// A draw from `table` with the uniform number `u` (clamped to [0, 1)): the
/// index, and where u fell within the part of its share that chose it, in [0, 1).
///
/// # Panics
/// If `table` is empty.
pub fn alias_sample(table: &[AliasEntry], u: f64) -> (usize, f64) {
    let n = table.len();
    let x = u.clamp(0.0, ONE_BELOW) * n as f64;
    let first = (x as usize).min(n - 1);
    let frac = (x - first as f64).clamp(0.0, ONE_BELOW);
    table[first].pick(first, frac)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::test_support::{assert_draws_follow, uniform};

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
            for (i, entry) in table.iter().enumerate() {
                implied[i] += f64::from(entry.keep) / n;
                implied[entry.alias as usize] += (1.0 - f64::from(entry.keep)) / n;
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

    /// Draws through the table follow the weights, with the fraction uniform
    /// within each index: Pearson's χ² over (index, quarter) cells against
    /// wᵢ/4Σw. The negative control: weights ×1.1 on every other index
    /// (renormalised) must fail.
    #[test]
    fn alias_draws_follow_the_weights_and_fill_each_bin_uniformly() {
        let mut state = 31;
        let weights: Vec<f64> = (0..50)
            .map(|i| {
                if i % 7 == 3 {
                    0.0
                } else {
                    uniform(&mut state).powi(3) + 0.01
                }
            })
            .collect();
        let table = alias_table(&weights);
        let draw = || alias_sample(&table, uniform(&mut state));
        assert_draws_follow(&weights, 400_000, draw, |i| i % 2 == 0);
    }
}
