//! Pearson's χ² test of a BSDF's sampler against a density, shared by
//! `tests/paint_model.rs` and `tests/extremes.rs`.
//!
//! Samples are counted on a grid of (cos θ, φ) bins, which has equal solid angles;
//! samples lost below the surface form a bin of their own. The expected count of a
//! bin is ∫ pdf dω over it (4 × 4 Gauss–Legendre), the lost bin takes the rest.
//! Bins expecting fewer than 5 samples are pooled into one. The p-value is
//! Q((dof − 1)/2, χ²/2).
//!
//! The negative control ([`Perturbation::HalfDomain`]) feeds the same statistic the
//! density of a sampler that is wrong by 10 % on half of the directions: ×1.1 on
//! the half of the azimuths that begins at the mirror direction (so it cuts the
//! lobe and the diffuse part alike), renormalised so that the total is unchanged.
//! The half is a union of whole bins, so its expected counts are exactly ∫ pdf′ dω.

#![allow(dead_code)]

use coatlab_core::paint::model::SpectralBsdf;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

use std::f64::consts::PI;

/// How the density the sampler is compared with is changed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Perturbation {
    /// The density as given.
    None,
    /// ×`factor` on the half of the azimuth bins that starts at the mirror
    /// direction's, renormalised.
    HalfDomain {
        /// E.g. 1.1 for a 10 % error.
        factor: f64,
    },
}

/// The bins: `mu` × `phi` over the hemisphere.
#[derive(Debug, Clone, Copy)]
pub struct Bins {
    /// Bins in cos θ.
    pub mu: usize,
    /// Bins in azimuth.
    pub phi: usize,
}

impl Bins {
    fn count(self) -> usize {
        self.mu * self.phi
    }

    fn phi_index(self, phi: f64) -> usize {
        ((phi.rem_euclid(2.0 * PI) / (2.0 * PI) * self.phi as f64) as usize).min(self.phi - 1)
    }

    fn of(self, w: [f32; 3]) -> usize {
        let mu = f64::from(w[2]).clamp(0.0, 1.0 - 1e-12);
        let phi = f64::from(w[1]).atan2(f64::from(w[0]));
        let i = ((mu * self.mu as f64) as usize).min(self.mu - 1);
        i * self.phi + self.phi_index(phi)
    }
}

/// The result of one test.
#[derive(Debug, Clone, Copy)]
pub struct ChiSquare {
    /// Pearson's statistic.
    pub chi2: f64,
    /// Number of bins after pooling.
    pub bins: i64,
    /// Upper tail probability for bins − 1 degrees of freedom.
    pub p_value: f64,
}

/// Counts of `samples` directions drawn from `bsdf` at `wo` (the last entry: lost or
/// delta samples).
pub fn sample_counts(
    bsdf: &dyn SpectralBsdf,
    wo: [f32; 3],
    bins: Bins,
    samples: usize,
    seed: u64,
) -> Vec<f64> {
    let mut observed = vec![0.0_f64; bins.count() + 1];
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut weight = vec![0.0_f32; bsdf.len()];
    for _ in 0..samples {
        let u = [
            rng.random::<f32>(),
            rng.random::<f32>(),
            rng.random::<f32>(),
        ];
        match bsdf.sample(wo, u, &mut weight) {
            Some(s) if !s.delta => observed[bins.of(s.wi)] += 1.0,
            _ => observed[bins.count()] += 1.0,
        }
    }
    observed
}

/// ∫ pdf dω over each bin (dω = dμ dφ), and the rest of the unit probability as the
/// last entry. Each bin by 4 × 4 Gauss–Legendre, split in four where that and the
/// sum over its quarters differ (the flat lobe, m = 0, is a step across its
/// horizon, which one rule per bin integrates to only a few per cent).
pub fn bin_probabilities(pdf: &dyn Fn([f32; 3]) -> f64, bins: Bins) -> Vec<f64> {
    let (dmu, dphi) = (1.0 / bins.mu as f64, 2.0 * PI / bins.phi as f64);
    let mut out = vec![0.0_f64; bins.count() + 1];
    let mut total = 0.0;
    for i in 0..bins.mu {
        for j in 0..bins.phi {
            let cell = [i as f64 * dmu, (i + 1) as f64 * dmu];
            let azimuths = [j as f64 * dphi, (j + 1) as f64 * dphi];
            let whole = gauss_legendre_cell(pdf, cell, azimuths);
            let p = adaptive_cell(pdf, cell, azimuths, whole, 6);
            out[i * bins.phi + j] = p;
            total += p;
        }
    }
    out[bins.count()] = (1.0 - total).max(0.0);
    out
}

fn adaptive_cell(
    pdf: &dyn Fn([f32; 3]) -> f64,
    mu: [f64; 2],
    phi: [f64; 2],
    whole: f64,
    depth: u32,
) -> f64 {
    let (mm, pm) = (0.5 * (mu[0] + mu[1]), 0.5 * (phi[0] + phi[1]));
    let quarters = [
        ([mu[0], mm], [phi[0], pm]),
        ([mu[0], mm], [pm, phi[1]]),
        ([mm, mu[1]], [phi[0], pm]),
        ([mm, mu[1]], [pm, phi[1]]),
    ];
    let parts = quarters.map(|(m, p)| gauss_legendre_cell(pdf, m, p));
    let sum: f64 = parts.iter().sum();
    // 1e-7 of the cell's probability is far below what 10⁶ samples resolve.
    if depth == 0 || (sum - whole).abs() <= 1e-7 * (mu[1] - mu[0]) * (phi[1] - phi[0]) + 1e-12 * sum
    {
        return sum;
    }
    quarters
        .iter()
        .zip(parts)
        .map(|(&(m, p), part)| adaptive_cell(pdf, m, p, part, depth - 1))
        .sum()
}

fn gauss_legendre_cell(pdf: &dyn Fn([f32; 3]) -> f64, mu: [f64; 2], phi: [f64; 2]) -> f64 {
    const NODES: [f64; 4] = [
        -0.861_136_311_594_052_6,
        -0.339_981_043_584_856_3,
        0.339_981_043_584_856_3,
        0.861_136_311_594_052_6,
    ];
    const WEIGHTS: [f64; 4] = [
        0.347_854_845_137_453_9,
        0.652_145_154_862_546_1,
        0.652_145_154_862_546_1,
        0.347_854_845_137_453_9,
    ];
    let (cm, hm) = (0.5 * (mu[0] + mu[1]), 0.5 * (mu[1] - mu[0]));
    let (cp, hp) = (0.5 * (phi[0] + phi[1]), 0.5 * (phi[1] - phi[0]));
    let mut integral = 0.0;
    for (a, wa) in NODES.iter().zip(&WEIGHTS) {
        for (b, wb) in NODES.iter().zip(&WEIGHTS) {
            let mu = cm + hm * a;
            let phi = cp + hp * b;
            let s = (1.0 - mu * mu).sqrt();
            let w = [(s * phi.cos()) as f32, (s * phi.sin()) as f32, mu as f32];
            integral += wa * wb * pdf(w);
        }
    }
    integral * hm * hp
}

/// Applies `perturbation` to bin probabilities of a view `wo`.
pub fn perturb(probabilities: &mut [f64], bins: Bins, wo: [f32; 3], perturbation: Perturbation) {
    let Perturbation::HalfDomain { factor } = perturbation else {
        return;
    };
    let first = bins.phi_index(f64::from(wo[1]).atan2(f64::from(wo[0])) + PI);
    let in_half = |j: usize| (j + bins.phi - first) % bins.phi < bins.phi / 2;
    let directions = &mut probabilities[..bins.count()];
    let before: f64 = directions.iter().sum();
    for (k, p) in directions.iter_mut().enumerate() {
        if in_half(k % bins.phi) {
            *p *= factor;
        }
    }
    let after: f64 = directions.iter().sum();
    if after > 0.0 {
        directions.iter_mut().for_each(|p| *p *= before / after);
    }
}

/// Pearson's χ² of `observed` counts against `probabilities` (same layout).
pub fn pearson(observed: &[f64], probabilities: &[f64]) -> ChiSquare {
    let samples: f64 = observed.iter().sum();
    let (mut chi2, mut bins) = (0.0, 0_i64);
    let (mut pooled_e, mut pooled_o) = (0.0, 0.0);
    for (p, o) in probabilities.iter().zip(observed) {
        let e = p * samples;
        if e < 5.0 {
            pooled_e += e;
            pooled_o += o;
        } else {
            chi2 += (o - e).powi(2) / e;
            bins += 1;
        }
    }
    if pooled_e > 0.0 {
        chi2 += (pooled_o - pooled_e).powi(2) / pooled_e;
        bins += 1;
    }
    ChiSquare {
        chi2,
        bins,
        p_value: gamma_q((bins - 1) as f64 / 2.0, chi2 / 2.0),
    }
}

/// The whole test: samples of `bsdf` at `wo` against `pdf` (perturbed as asked).
pub fn chi_square_test(
    bsdf: &dyn SpectralBsdf,
    wo: [f32; 3],
    pdf: &dyn Fn([f32; 3]) -> f64,
    bins: Bins,
    samples: usize,
    seed: u64,
    perturbation: Perturbation,
) -> ChiSquare {
    let observed = sample_counts(bsdf, wo, bins, samples, seed);
    let mut probabilities = bin_probabilities(pdf, bins);
    perturb(&mut probabilities, bins, wo, perturbation);
    pearson(&observed, &probabilities)
}

/// ln Γ(x), Lanczos approximation (g = 7, n = 9), accurate to ~1e-15.
pub fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Upper regularised incomplete gamma Q(a, x): the χ² p-value is Q(dof/2, χ²/2).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x < a + 1.0 {
        let mut sum = 1.0 / a;
        let mut term = sum;
        for k in 1..10_000 {
            term *= x / (a + k as f64);
            sum += term;
            if term < sum * 1e-16 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - ln_gamma(a)).exp()
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (-x + a * x.ln() - ln_gamma(a)).exp() * h
    }
}
