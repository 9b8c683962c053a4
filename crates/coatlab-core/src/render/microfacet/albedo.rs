//! Directional albedos of the GGX reflection lobe, the tables the energy
//! compensation reads (Kulla and Conty, "Revisiting Physically Based Shading at
//! Imageworks", SIGGRAPH 2017 course).
//!
//! For a lobe of width α seen at cos θo = μ, with Schlick's Fresnel
//! F = F₀ + (1 − F₀)(1 − ωo·h)⁵, the directional albedo of the single-scattering
//! lobe is linear in F₀:
//!
//! E(μ; F₀) = F₀ · E₁(μ) + (1 − F₀) · E₅(μ),
//!
//! with E₁ the albedo for F = 1 and E₅ the albedo weighted by (1 − ωo·h)⁵. Both are
//! tabulated once per process on [`NODES`] × [`NODES`] nodes, μ = j/(NODES − 1)
//! and roughness r = k/(NODES − 1) (α = r², so the nodes are even in what a
//! designer sets), each by 32 × 32 stratified samples of the visible normals, whose
//! weight G2/G1 is smooth (about 30 ms at opt-level 3). A material interpolates its
//! roughness once into an [`AlbedoRow`]; a shading point then interpolates linearly
//! in μ. Their hemispherical averages E_avg = 2 ∫ E μ dμ are those of the
//! piecewise-linear rows (exact integrals of the interpolant), so the compensation lobes built from them integrate to what
//! they should up to the interpolation error (measured in `tests/microfacet.rs`).

use std::sync::LazyLock;

use super::ggx::{Ggx, dot, reflect};

/// Nodes per axis of the tables.
pub const NODES: usize = 32;
/// μ at the table's first node (μ = 0 exactly has no direction above the surface).
const MU_FLOOR: f32 = 1e-3;
/// Strata per axis of the visible-normal samples of one node.
const STRATA: usize = 32;

/// E₁ and E₅ per roughness node (rows) and μ node (columns), and each row's
/// hemispherical average (linear in the row, so a row interpolated between
/// nodes has the interpolated average: nothing is integrated per material).
struct Tables {
    e1: Vec<[f32; NODES]>,
    e5: Vec<[f32; NODES]>,
    average1: Vec<f32>,
    average5: Vec<f32>,
}

static TABLES: LazyLock<Tables> = LazyLock::new(|| {
    let mut e1 = vec![[0.0; NODES]; NODES];
    let mut e5 = vec![[0.0; NODES]; NODES];
    for k in 0..NODES {
        let ggx = Ggx::from_roughness(k as f32 / (NODES - 1) as f32);
        for j in 0..NODES {
            let mu = (j as f32 / (NODES - 1) as f32).max(MU_FLOOR);
            let (a, b) = node_albedos(ggx, mu);
            e1[k][j] = a;
            e5[k][j] = b;
        }
    }
    Tables {
        average1: e1.iter().map(hemispherical_average).collect(),
        average5: e5.iter().map(hemispherical_average).collect(),
        e1,
        e5,
    }
});

/// (E₁, E₅) of `ggx` at cos θo = `mu`: the mean of G2/G1 (and of it × (1 − ωo·h)⁵)
/// over stratified visible normals.
fn node_albedos(ggx: Ggx, mu: f32) -> (f32, f32) {
    let wo = [(1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu];
    let g1 = ggx.g1(wo);
    let (mut s1, mut s5) = (0.0f64, 0.0f64);
    for a in 0..STRATA {
        for b in 0..STRATA {
            let u = [
                (a as f32 + 0.5) / STRATA as f32,
                (b as f32 + 0.5) / STRATA as f32,
            ];
            let h = ggx.sample_visible_normal(wo, u);
            let wi = reflect(wo, h);
            if wi[2] <= 0.0 {
                continue;
            }
            let w = f64::from(ggx.g2(wo, wi) / g1);
            let c = f64::from(1.0 - dot(wo, h).clamp(0.0, 1.0));
            s1 += w;
            s5 += w * c.powi(5);
        }
    }
    let n = (STRATA * STRATA) as f64;
    ((s1 / n) as f32, (s5 / n) as f32)
}

/// E₁ and E₅ of one roughness against μ, and their hemispherical averages.
#[derive(Debug, Clone, PartialEq)]
pub struct AlbedoRow {
    e1: [f32; NODES],
    e5: [f32; NODES],
    average1: f32,
    average5: f32,
}

impl AlbedoRow {
    /// The row of `ggx`'s width (interpolated between roughness nodes).
    pub fn new(ggx: Ggx) -> Self {
        let tables = &*TABLES;
        let x = ggx.alpha().sqrt().clamp(0.0, 1.0) * (NODES - 1) as f32;
        let k = (x as usize).min(NODES - 2);
        let t = x - k as f32;
        let lerp = |rows: &[[f32; NODES]]| -> [f32; NODES] {
            std::array::from_fn(|j| rows[k][j] + t * (rows[k + 1][j] - rows[k][j]))
        };
        let average = |a: &[f32]| a[k] + t * (a[k + 1] - a[k]);
        Self {
            e1: lerp(&tables.e1),
            e5: lerp(&tables.e5),
            average1: average(&tables.average1),
            average5: average(&tables.average5),
        }
    }

    /// E(μ; F₀), the single-scattering lobe's directional albedo.
    #[inline]
    pub fn albedo(&self, mu: f32, f0: f32) -> f32 {
        let (a, b) = self.at(mu);
        f0 * a + (1.0 - f0) * b
    }

    /// (E₁(μ), E₅(μ)).
    #[inline]
    pub fn at(&self, mu: f32) -> (f32, f32) {
        let x = mu.clamp(0.0, 1.0) * (NODES - 1) as f32;
        let j = (x as usize).min(NODES - 2);
        let t = x - j as f32;
        (
            self.e1[j] + t * (self.e1[j + 1] - self.e1[j]),
            self.e5[j] + t * (self.e5[j + 1] - self.e5[j]),
        )
    }

    /// E_avg(F₀) = 2 ∫ E(μ; F₀) μ dμ.
    #[inline]
    pub fn average(&self, f0: f32) -> f32 {
        f0 * self.average1 + (1.0 - f0) * self.average5
    }
}

/// 2 ∫ e(μ) μ dμ of the piecewise-linear e over the nodes, exactly (each interval's
/// linear e times μ integrated in closed form).
fn hemispherical_average(e: &[f32; NODES]) -> f32 {
    let h = 1.0 / (NODES - 1) as f64;
    let mut sum = 0.0f64;
    for j in 0..NODES - 1 {
        let (m0, m1) = (j as f64 * h, (j + 1) as f64 * h);
        let (e0, e1) = (f64::from(e[j]), f64::from(e[j + 1]));
        // ∫ over [m0, m1] of (e0 + (e1 − e0)(μ − m0)/h) μ dμ.
        let slope = (e1 - e0) / h;
        let a = e0 - slope * m0;
        sum += a * (m1 * m1 - m0 * m0) / 2.0 + slope * (m1.powi(3) - m0.powi(3)) / 3.0;
    }
    (2.0 * sum) as f32
}
