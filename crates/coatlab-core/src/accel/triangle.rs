//! The watertight ray–triangle test of Woop, Benthin and Wald ("Watertight
//! Ray/Triangle Intersection", JCGT 2013), for packs of triangles.
//!
//! One generic routine, [`ShearedRay::intersect_pack`], tests `N` triangles stored
//! lane by lane ([`TrianglePack`]); each lane goes through exactly the same f32
//! operations in the same order, so the pack of 8 that the 8-wide tree's leaves use
//! and the pack of 1 behind [`super::intersect_triangle`] (the brute-force reference
//! of the tests) give bit-identical distances and barycentrics. The per-lane loops are
//! written for LLVM's loop vectoriser (straight-line arithmetic over fixed-size
//! arrays, no early exits), which turns a pack of 8 into AVX instructions without
//! `unsafe` where it is compiled with AVX enabled.
//!
//! The crate is built for baseline x86-64; the traversal runs on the path chosen at
//! start-up (`crate::simd_path`). The const parameter `ISA` of the routines here
//! says which code they are instantiated for (`crate::simd_path::isa`): `AVX2` or
//! `AVX512` only inside the traversal's entry points compiled with those features
//! enabled (`#[target_feature]`), which are called only where the CPU has them;
//! there the reductions use AVX intrinsics, with AVX-512 compares into mask
//! registers. Every instantiation does the same f32 operations, so their results
//! are the same, bit for bit.

use crate::simd_path::isa::{AVX2, AVX512, PORTABLE};

/// Triangles per leaf block of the 8-wide tree: 8, one AVX register per coordinate.
/// (Measured against 4 with leaves of up to 4 or 8: see docs/benchmarks.md.)
pub(super) const PACK: usize = 8;

/// `N` triangles, lane by lane: `v[vertex][axis][lane]`, metres, and the caller's id
/// of each lane. Unused lanes hold NaN vertices, which never hit (every comparison in
/// the test fails on NaN, and the f64 re-evaluation is only taken for exact zeros).
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(16))]
pub(super) struct TrianglePack<const N: usize> {
    pub v: [[[f32; N]; 3]; 3],
    pub id: [u32; N],
}

impl<const N: usize> TrianglePack<N> {
    /// A pack with every lane unused.
    pub fn empty() -> Self {
        TrianglePack {
            v: [[[f32::NAN; N]; 3]; 3],
            id: [u32::MAX; N],
        }
    }

    /// Puts `vertices` with `id` into `lane`.
    pub fn set(&mut self, lane: usize, vertices: [[f32; 3]; 3], id: u32) {
        for (j, vertex) in vertices.iter().enumerate() {
            for (k, &x) in vertex.iter().enumerate() {
                self.v[j][k][lane] = x;
            }
        }
        self.id[lane] = id;
    }

    /// The vertices in `lane`.
    pub fn get(&self, lane: usize) -> [[f32; 3]; 3] {
        std::array::from_fn(|j| std::array::from_fn(|k| self.v[j][k][lane]))
    }
}

/// A lane's hit: its index in the pack, the distance and the weights (u, v) of the
/// second and third vertex.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct LaneHit {
    pub lane: usize,
    pub t: f32,
    pub barycentric: [f32; 2],
}

/// A ray prepared for the watertight test: `v − origin` is mapped to a frame in which
/// the ray runs along +z with `z = t` (axes permuted so that the largest direction
/// component is z, then sheared): `x' = d[kx] − sx·d[kz]`, `y' = d[ky] − sy·d[kz]`,
/// `z' = sz·d[kz]` with `d = v − origin`.
#[derive(Debug, Clone, Copy)]
pub(super) struct ShearedRay {
    origin: [f32; 3],
    k: [usize; 3],
    shear: [f32; 3],
}

impl ShearedRay {
    /// For a finite, non-zero `dir`.
    #[inline(always)]
    pub fn new(origin: [f32; 3], dir: [f32; 3]) -> ShearedRay {
        let a = dir.map(f32::abs);
        let kz = if a[0] >= a[1] && a[0] >= a[2] {
            0
        } else if a[1] >= a[2] {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Keep the winding (the sign of the edge functions) independent of the axis.
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        ShearedRay {
            origin,
            k: [kx, ky, kz],
            shear: [dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]],
        }
    }

    /// Lane-wise test of a pack; per lane, the hit distance in `(0, t_limit]` with
    /// its barycentrics, or `t = ∞` for a miss (zero-area triangles, NaN and unused
    /// lanes never hit).
    #[inline(always)]
    fn lanes<const ISA: u8, const N: usize>(
        &self,
        pack: &TrianglePack<N>,
        t_limit: f32,
    ) -> ([f32; N], [f32; N], [f32; N]) {
        let [kx, ky, kz] = self.k;
        let [sx, sy, sz] = self.shear;
        let o = self.origin;
        // Vertices in ray space: p[vertex][axis][lane].
        let mut p = [[[0.0f32; N]; 3]; 3];
        for (j, pj) in p.iter_mut().enumerate() {
            let vj = &pack.v[j];
            for i in 0..N {
                let dx = vj[kx][i] - o[kx];
                let dy = vj[ky][i] - o[ky];
                let dz = vj[kz][i] - o[kz];
                pj[0][i] = dx - sx * dz;
                pj[1][i] = dy - sy * dz;
                pj[2][i] = sz * dz;
            }
        }
        let [a, b, c] = p;
        // Edge functions: twice the signed areas seen along the ray.
        let mut u = [0.0f32; N];
        let mut v = [0.0f32; N];
        let mut w = [0.0f32; N];
        for i in 0..N {
            u[i] = c[0][i] * b[1][i] - c[1][i] * b[0][i];
            v[i] = a[0][i] * c[1][i] - a[1][i] * c[0][i];
            w[i] = b[0][i] * a[1][i] - b[1][i] * a[0][i];
        }
        // An exact zero (the ray through an edge or vertex, to f32 precision) is
        // decided in f64, where the products are exact: this is what makes shared
        // edges watertight. Rare, so a scalar loop.
        if any_zero::<ISA, N>(&u, &v, &w) {
            let f = |p: f32, q: f32, r: f32, s: f32| {
                (f64::from(p) * f64::from(q) - f64::from(r) * f64::from(s)) as f32
            };
            for i in 0..N {
                if u[i] == 0.0 || v[i] == 0.0 || w[i] == 0.0 {
                    u[i] = f(c[0][i], b[1][i], c[1][i], b[0][i]);
                    v[i] = f(a[0][i], c[1][i], a[1][i], c[0][i]);
                    w[i] = f(b[0][i], a[1][i], b[1][i], a[0][i]);
                }
            }
        }
        let mut t = [0.0f32; N];
        let mut bu = [0.0f32; N];
        let mut bv = [0.0f32; N];
        for i in 0..N {
            let negative = (u[i] < 0.0) | (v[i] < 0.0) | (w[i] < 0.0);
            let positive = (u[i] > 0.0) | (v[i] > 0.0) | (w[i] > 0.0);
            let det = u[i] + v[i] + w[i];
            let inv_det = 1.0 / det;
            let ti = (u[i] * a[2][i] + v[i] * b[2][i] + w[i] * c[2][i]) * inv_det;
            // Written so that NaN fails.
            let hit = !(negative & positive) & (det != 0.0) & (ti > 0.0) & (ti <= t_limit);
            t[i] = if hit { ti } else { f32::INFINITY };
            bu[i] = v[i] * inv_det;
            bv[i] = w[i] * inv_det;
        }
        (t, bu, bv)
    }

    /// The vertices of `lane` in ray space, as [`ShearedRay::lanes`] computes them.
    #[inline(always)]
    fn corners<const N: usize>(&self, pack: &TrianglePack<N>, lane: usize) -> [[f32; 3]; 3] {
        let [kx, ky, kz] = self.k;
        let [sx, sy, sz] = self.shear;
        let o = self.origin;
        pack.v.map(|vj| {
            let dx = vj[kx][lane] - o[kx];
            let dy = vj[ky][lane] - o[ky];
            let dz = vj[kz][lane] - o[kz];
            [dx - sx * dz, dy - sy * dz, sz * dz]
        })
    }

    /// The hit of `lane`, at `t` by [`ShearedRay::lanes`], checked: `t` where its
    /// sign is certain, else the distance recomputed in f64 where that is farther,
    /// `t` where it is nearer, ∞ where it is not in `(0, t_limit]`.
    ///
    /// The distance's rounding error can exceed the distance itself when the
    /// origin lies micrometres from a long sliver's plane (the edge functions
    /// cancel to a small determinant): the f32 distance then has the wrong sign, a
    /// hit on the surface the ray has just left (found on the Lamborghini against
    /// Intel Embree and exact arithmetic, benches/embree/README.md). Only hits are
    /// checked: a hit closer than its own rounding error may still be missed, as
    /// with any f32 test, but none is reported behind the origin. The edge test,
    /// and so watertightness, is unchanged.
    ///
    /// A check never brings a hit nearer than its f32 distance: the packs' tests
    /// drop a lane beyond `t_limit` by that distance before any check, so a check
    /// that could bring it nearer would make the closest hit depend on the order in
    /// which the traversal visits the leaves, and the SIMD paths, whose box tests
    /// round differently, visit them in different orders.
    #[inline(always)]
    fn checked_distance<const N: usize>(
        &self,
        pack: &TrianglePack<N>,
        lane: usize,
        t: f32,
        t_limit: f32,
    ) -> f32 {
        let corners = self.corners(pack, lane);
        let [a, b, c] = corners.map(|p| p[2]);
        // With every corner on one side of the origin along the ray, the distance
        // is a mean of their z with weights of one sign, so its sign is theirs.
        if (a > 0.0) & (b > 0.0) & (c > 0.0) {
            return t;
        }
        certain_distance(corners, t, t_limit)
    }

    /// The nearest hit in the pack with `t` in `(0, t_limit]` (a closed interval, so
    /// that a caller can break ties with hits it already has); on equal distances
    /// the lane with the least id. Each lane's distance depends on the ray and its
    /// triangle only, so the nearest hit over several packs, ties broken by the
    /// least id, does not depend on the order in which they are tested.
    #[inline(always)]
    pub fn intersect_pack<const ISA: u8, const N: usize>(
        &self,
        pack: &TrianglePack<N>,
        t_limit: f32,
    ) -> Option<LaneHit> {
        let (mut t, bu, bv) = self.lanes::<ISA, N>(pack, t_limit);
        loop {
            let best = nearest_lane::<ISA, N>(&t, &pack.id)?;
            let checked = self.checked_distance(pack, best, t[best], t_limit);
            if checked.to_bits() == t[best].to_bits() {
                return Some(LaneHit {
                    lane: best,
                    t: checked,
                    barycentric: [bu[best], bv[best]],
                });
            }
            // Rare: the lane's distance was uncertain. Its checked distance (or a
            // miss) replaces it, and the nearest lane is chosen again; the checked
            // distance is final (checking it again returns it unchanged, as its
            // corners are the same), so this ends.
            t[best] = checked;
            if checked < f32::INFINITY {
                return self.nearest_after_recheck(pack, &mut t, &bu, &bv, t_limit);
            }
        }
    }

    /// The nearest lane of `t` after one lane's distance was recomputed, every
    /// other hit lane checked in turn (a scalar loop: this is the rare path).
    #[cold]
    fn nearest_after_recheck<const N: usize>(
        &self,
        pack: &TrianglePack<N>,
        t: &mut [f32; N],
        bu: &[f32; N],
        bv: &[f32; N],
        t_limit: f32,
    ) -> Option<LaneHit> {
        for (i, ti) in t.iter_mut().enumerate() {
            if *ti < f32::INFINITY {
                *ti = self.checked_distance(pack, i, *ti, t_limit);
            }
        }
        nearest_lane::<PORTABLE, N>(t, &pack.id).map(|best| LaneHit {
            lane: best,
            t: t[best],
            barycentric: [bu[best], bv[best]],
        })
    }

    /// Whether some triangle of the pack is hit with `t` in `(0, t_max)`.
    #[inline(always)]
    pub fn any_in_pack<const ISA: u8, const N: usize>(
        &self,
        pack: &TrianglePack<N>,
        t_max: f32,
    ) -> bool {
        // The open interval as a closed one: the largest f32 below `t_max`.
        let t_limit = t_max.next_down();
        let (mut t, _, _) = self.lanes::<ISA, N>(pack, t_limit);
        while let Some(best) = nearest_lane::<ISA, N>(&t, &pack.id) {
            if self.checked_distance(pack, best, t[best], t_limit) < f32::INFINITY {
                return true;
            }
            t[best] = f32::INFINITY;
        }
        false
    }
}

/// [`ShearedRay::checked_distance`] for a triangle with corners on both sides of
/// the origin: `t` where its rounding error cannot change the hit decision, else
/// the larger of `t` and the distance recomputed in f64, or ∞ where that is not in
/// `(0, t_limit]`.
/// `corners` are the vertices in ray space.
///
/// The bound: in ray space the distance is `Σ eᵢ·zᵢ / Σ eᵢ` with edge functions
/// eᵢ of one sign on a hit. Each eᵢ is a difference of two products, with an error
/// of at most γ₂ times the sum of their magnitudes (γₙ = n·ε/(1 − n·ε), Higham);
/// the weighted sum adds γ₃·Σ|eᵢ|·max|zᵢ|. If the f32 numerator is larger than that
/// bound (doubled, for the bound's own rounding), its sign, so the hit decision at
/// `t = 0`, is right.
#[inline(never)]
#[cold]
fn certain_distance(corners: [[f32; 3]; 3], t: f32, t_limit: f32) -> f32 {
    let [a, b, c] = corners;
    // The products of each edge function: u = c₀b₁ − c₁b₀, v = a₀c₁ − a₁c₀,
    // w = b₀a₁ − b₁a₀.
    let products = [(c, b), (a, c), (b, a)];
    let eps = f64::from(f32::EPSILON) / 2.0;
    let gamma = |n: f64| n * eps / (1.0 - n * eps);
    let z_max = [a[2], b[2], c[2]]
        .iter()
        .fold(0.0f64, |m, z| m.max(f64::from(z.abs())));
    let edges = products.map(|(p, q)| p[0] * q[1] - p[1] * q[0]);
    let edge_error: f64 = products
        .iter()
        .map(|(p, q)| {
            gamma(2.0) * (f64::from((p[0] * q[1]).abs()) + f64::from((p[1] * q[0]).abs()))
        })
        .sum();
    let edge_sum: f64 = edges.iter().map(|e| f64::from(e.abs())).sum();
    let bound = 2.0 * z_max * (edge_error + gamma(3.0) * edge_sum);
    let numerator = edges[0] * a[2] + edges[1] * b[2] + edges[2] * c[2];
    // (An edge function of exactly zero was recomputed in f64 by the test, so
    // `numerator` may differ from the test's; the f64 path below then decides.)
    if f64::from(numerator.abs()) > bound && edges.iter().all(|&e| e != 0.0) {
        return t;
    }
    // In f64 the products of f32 values are exact and each edge function is
    // rounded once.
    let f =
        |p: f32, q: f32, r: f32, s: f32| f64::from(p) * f64::from(q) - f64::from(r) * f64::from(s);
    let e = products.map(|(p, q)| f(p[0], q[1], p[1], q[0]));
    let det = e[0] + e[1] + e[2];
    let distance = (e[0] * f64::from(a[2]) + e[1] * f64::from(b[2]) + e[2] * f64::from(c[2])) / det;
    let distance = distance as f32;
    // Never nearer than `t` (see `checked_distance`): `t` is in (0, t_limit].
    if distance > 0.0 && distance <= t_limit {
        distance.max(t)
    } else {
        f32::INFINITY
    }
}

/// Whether some lane of `u`, `v` or `w` is exactly zero (either sign).
#[inline(always)]
fn any_zero<const ISA: u8, const N: usize>(u: &[f32; N], v: &[f32; N], w: &[f32; N]) -> bool {
    #[cfg(target_arch = "x86_64")]
    if ISA >= AVX2
        && let (Ok(u), Ok(v), Ok(w)) = (u[..].try_into(), v[..].try_into(), w[..].try_into())
    {
        // SAFETY: `ISA` is AVX2 (AVX512) only where AVX2 (AVX-512) is enabled and
        // the CPU has it (see the module documentation).
        return unsafe {
            if ISA == AVX512 {
                avx512::any_zero(u, v, w)
            } else {
                avx::any_zero(u, v, w)
            }
        };
    }
    any_zero_portable(u, v, w)
}

/// The portable [`any_zero`] (LLVM reduces its booleans through a dozen shuffles;
/// the AVX version is three compares and one `vmovmskps`).
#[inline(always)]
fn any_zero_portable<const N: usize>(u: &[f32; N], v: &[f32; N], w: &[f32; N]) -> bool {
    (0..N).any(|i| (u[i] == 0.0) | (v[i] == 0.0) | (w[i] == 0.0))
}

/// The lane of the smallest `t` below ∞, the one with the least `id` on ties;
/// `None` when every lane is ∞ (no lane holds NaN: the test writes ∞ for every
/// miss).
#[inline(always)]
fn nearest_lane<const ISA: u8, const N: usize>(t: &[f32; N], id: &[u32; N]) -> Option<usize> {
    let at_minimum = lanes_at_minimum::<ISA, N>(t)?;
    Some(if at_minimum.is_power_of_two() {
        at_minimum.trailing_zeros() as usize
    } else {
        least_id_lane(at_minimum, id)
    })
}

/// The lanes holding the smallest `t` below ∞ (bit i for lane i); `None` when every
/// lane is ∞.
#[inline(always)]
fn lanes_at_minimum<const ISA: u8, const N: usize>(t: &[f32; N]) -> Option<u32> {
    #[cfg(target_arch = "x86_64")]
    if ISA >= AVX2
        && let Ok(t) = t[..].try_into()
    {
        // SAFETY: as in `any_zero`.
        return unsafe {
            if ISA == AVX512 {
                avx512::lanes_at_minimum(t)
            } else {
                avx::lanes_at_minimum(t)
            }
        };
    }
    lanes_at_minimum_portable(t)
}

/// The portable [`lanes_at_minimum`]: a running index of the least lane (seven
/// compares and well-predicted branches for a pack of 8; a fold of minima instead,
/// a chain of seven four-cycle operations, traced rays one by one about 5 % slower:
/// docs/benchmarks.md), then a compare a lane (the AVX version: a min tree, one
/// compare, a mask).
#[inline(always)]
fn lanes_at_minimum_portable<const N: usize>(t: &[f32; N]) -> Option<u32> {
    let mut least = 0;
    for i in 1..N {
        if t[i] < t[least] {
            least = i;
        }
    }
    let minimum = t[least];
    (minimum < f32::INFINITY).then(|| {
        t.iter()
            .enumerate()
            .fold(0, |mask, (i, &x)| mask | (u32::from(x == minimum) << i))
    })
}

/// Of the lanes in `mask` (not empty), the one with the least `id`: a tie between
/// triangles at the same distance (a ray through a shared edge or vertex), rare.
#[cold]
fn least_id_lane<const N: usize>(mask: u32, id: &[u32; N]) -> usize {
    (0..N)
        .filter(|&i| mask & (1 << i) != 0)
        .min_by_key(|&i| id[i])
        .unwrap_or(0)
}

/// The 8-lane reductions of the pack test with AVX intrinsics (the loop vectoriser
/// does not find them). Each is `unsafe`: to be called only where the CPU has AVX,
/// and inlined only into code compiled with it (the const `AVX` of the callers).
#[cfg(target_arch = "x86_64")]
mod avx {
    use std::arch::x86_64::{
        __m256, _CMP_EQ_OQ, _mm256_cmp_ps, _mm256_cvtss_f32, _mm256_min_ps, _mm256_movemask_ps,
        _mm256_or_ps, _mm256_permute_ps, _mm256_permute2f128_ps, _mm256_setr_ps, _mm256_setzero_ps,
    };

    // SAFETY (every `unsafe` block below): these intrinsics need AVX, which the
    // callers of these `unsafe` functions guarantee; they take and return values
    // only (no memory access).

    #[inline(always)]
    pub(super) unsafe fn vector(a: &[f32; 8]) -> __m256 {
        // SAFETY: see above.
        unsafe { _mm256_setr_ps(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]) }
    }

    #[inline(always)]
    pub(super) unsafe fn any_zero(u: &[f32; 8], v: &[f32; 8], w: &[f32; 8]) -> bool {
        // SAFETY: see above.
        unsafe {
            let zero = _mm256_setzero_ps();
            let eq = |a: &[f32; 8]| _mm256_cmp_ps::<_CMP_EQ_OQ>(vector(a), zero);
            _mm256_movemask_ps(_mm256_or_ps(_mm256_or_ps(eq(u), eq(v)), eq(w))) != 0
        }
    }

    /// The minimum of the 8 lanes, in every lane: pairs, then quads, then the two
    /// halves.
    #[inline(always)]
    pub(super) unsafe fn minimum(t: __m256) -> __m256 {
        // SAFETY: see above.
        unsafe {
            let pairs = _mm256_min_ps(t, _mm256_permute_ps::<0b10_11_00_01>(t));
            let quads = _mm256_min_ps(pairs, _mm256_permute_ps::<0b01_00_11_10>(pairs));
            _mm256_min_ps(quads, _mm256_permute2f128_ps::<1>(quads, quads))
        }
    }

    #[inline(always)]
    pub(super) unsafe fn lanes_at_minimum(t: &[f32; 8]) -> Option<u32> {
        // SAFETY: see above.
        unsafe {
            let t = vector(t);
            let min = minimum(t);
            let at_min = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(t, min)) as u32;
            (_mm256_cvtss_f32(min) < f32::INFINITY).then_some(at_min)
        }
    }
}

/// The reductions of [`avx`] with AVX-512 compares straight into mask registers
/// (no `vmovmskps`, and the three compares of `any_zero` or-ed as masks). To be
/// called only where the CPU has AVX-512 F and VL, inlined into code compiled with
/// them.
#[cfg(target_arch = "x86_64")]
mod avx512 {
    use std::arch::x86_64::{_CMP_EQ_OQ, _mm256_cmp_ps_mask, _mm256_cvtss_f32, _mm256_setzero_ps};

    use super::avx::{minimum, vector};

    // SAFETY (every `unsafe` block below): as in `avx`, with AVX-512 F and VL.

    #[inline(always)]
    pub(super) unsafe fn any_zero(u: &[f32; 8], v: &[f32; 8], w: &[f32; 8]) -> bool {
        // SAFETY: see above.
        unsafe {
            let zero = _mm256_setzero_ps();
            let eq = |a: &[f32; 8]| _mm256_cmp_ps_mask::<_CMP_EQ_OQ>(vector(a), zero);
            (eq(u) | eq(v) | eq(w)) != 0
        }
    }

    #[inline(always)]
    pub(super) unsafe fn lanes_at_minimum(t: &[f32; 8]) -> Option<u32> {
        // SAFETY: see above.
        unsafe {
            let t = vector(t);
            let min = minimum(t);
            let at_min = u32::from(_mm256_cmp_ps_mask::<_CMP_EQ_OQ>(t, min));
            (_mm256_cvtss_f32(min) < f32::INFINITY).then_some(at_min)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd_path::SimdPath;

    /// A full pack agrees lane by lane, bit for bit, with packs of 1, on random
    /// triangles and rays (including rays through shared vertices).
    #[test]
    fn pack_lanes_agree_with_single_triangles() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let mut hits = 0;
        for _ in 0..20_000 {
            let origin = [next(), next(), next()];
            let dir = [next(), next(), next()];
            if dir == [0.0; 3] {
                continue;
            }
            let ray = ShearedRay::new(origin, dir);
            let mut pack = TrianglePack::<PACK>::empty();
            let mut singles = Vec::new();
            for lane in 0..PACK {
                let tri: [[f32; 3]; 3] = std::array::from_fn(|_| [next(), next(), next()]);
                pack.set(lane, tri, lane as u32);
                let mut single = TrianglePack::<1>::empty();
                single.set(0, tri, lane as u32);
                singles.push(single);
            }
            let (t, bu, bv) = ray.lanes::<PORTABLE, PACK>(&pack, 10.0);
            for (lane, single) in singles.iter().enumerate() {
                let (t1, bu1, bv1) = ray.lanes::<PORTABLE, 1>(single, 10.0);
                assert_eq!(t[lane].to_bits(), t1[0].to_bits());
                if t1[0] < f32::INFINITY {
                    hits += 1;
                    assert_eq!((bu[lane], bv[lane]), (bu1[0], bv1[0]));
                }
            }
        }
        assert!(hits > 1000, "{hits}");
    }

    /// The AVX2 and AVX-512 reductions against the portable ones, on lanes drawn
    /// from a few values so that ties, zeros of either sign and all-∞ packs are
    /// common (on the paths the CPU has).
    #[test]
    fn reductions_agree_with_the_portable_ones() {
        if SimdPath::Avx2.is_available() {
            // SAFETY: the CPU has AVX2.
            unsafe { crate::simd_path::on_avx2(reductions_agree::<AVX2>) };
        } else {
            println!("no AVX2 on this CPU: only the portable reductions exist");
        }
        if SimdPath::Avx512.is_available() {
            // SAFETY: the CPU has AVX-512.
            unsafe { crate::simd_path::on_avx512(reductions_agree::<AVX512>) };
        } else {
            println!("no AVX-512 on this CPU");
        }
    }

    #[inline(always)]
    fn reductions_agree<const ISA: u8>() {
        let values = [0.0, -0.0, 1.0, 2.5, 1e-30, -3.0, f32::INFINITY];
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut pick = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            values[(state % values.len() as u64) as usize]
        };
        let (mut none, mut ties) = (0, 0);
        for _ in 0..100_000 {
            let lanes =
                |pick: &mut dyn FnMut() -> f32| -> [f32; PACK] { std::array::from_fn(|_| pick()) };
            let (u, v, w) = (lanes(&mut pick), lanes(&mut pick), lanes(&mut pick));
            assert_eq!(
                any_zero::<ISA, PACK>(&u, &v, &w),
                any_zero_portable(&u, &v, &w),
                "{u:?} {v:?} {w:?}"
            );
            // Distances are positive or ∞ (misses); ids in any order.
            let t = u.map(|x| if x > 0.0 { x } else { f32::INFINITY });
            let id: [u32; PACK] = std::array::from_fn(|i| (pick().to_bits() ^ i as u32) % 5);
            let best = nearest_lane::<ISA, PACK>(&t, &id);
            assert_eq!(
                best,
                nearest_lane::<PORTABLE, PACK>(&t, &id),
                "{t:?} {id:?}"
            );
            let expected = (0..PACK)
                .filter(|&i| t[i] < f32::INFINITY)
                .min_by(|&i, &j| t[i].total_cmp(&t[j]).then(id[i].cmp(&id[j])));
            if let (Some(b), Some(e)) = (best, expected) {
                assert_eq!((t[b], id[b]), (t[e], id[e]), "{t:?} {id:?}");
            } else {
                assert_eq!(best, expected, "{t:?}");
            }
            match best {
                None => none += 1,
                Some(b) if t.iter().filter(|&&x| x == t[b]).count() > 1 => ties += 1,
                Some(_) => {}
            }
        }
        assert!(none > 100 && ties > 1000, "{none} {ties}");
    }

    /// A ray of the accel bench leaving a Lamborghini surface 1.9 µm off the plane
    /// of a 2 m sliver, away from it: exact (rational) arithmetic puts the line's
    /// crossing of the plane at t = −2.808·10⁻⁶, inside the triangle, but the f32
    /// distance came out as +8.47·10⁻⁶, a hit on the surface just left, where Intel
    /// Embree (robust) reports none (benches/embree/README.md). Started 10⁻⁴ further
    /// back, the same line must hit, at 10⁻⁴ − 2.808·10⁻⁶, within the f32
    /// distance's error for this sliver (about 10⁻⁵, as above).
    #[test]
    fn distances_near_zero_have_the_right_sign() {
        let sliver = [
            [-0.780_187_37, 0.100_365_12, 0.729_199_9],
            [0.680_211_1, 0.100_398_15, -0.815_169_04],
            [0.686_082_6, 0.100_364_4, -0.817_328_6],
        ];
        let origin = [-0.350_136_73, 0.100_363_046, 0.275_604_7];
        let dir = [0.169_235_17, -0.685_412_6, 0.708_215_5];
        let mut pack = TrianglePack::<PACK>::empty();
        pack.set(3, sliver, 7);
        let ray = ShearedRay::new(origin, dir);
        assert_eq!(
            ray.intersect_pack::<PORTABLE, PACK>(&pack, f32::INFINITY),
            None
        );
        assert!(!ray.any_in_pack::<PORTABLE, PACK>(&pack, f32::INFINITY));
        if SimdPath::Avx2.is_available() {
            // SAFETY: the CPU has AVX2.
            unsafe {
                crate::simd_path::on_avx2(|| {
                    assert_eq!(ray.intersect_pack::<AVX2, PACK>(&pack, f32::INFINITY), None);
                    assert!(!ray.any_in_pack::<AVX2, PACK>(&pack, f32::INFINITY));
                })
            };
        }
        if SimdPath::Avx512.is_available() {
            // SAFETY: the CPU has AVX-512.
            unsafe {
                crate::simd_path::on_avx512(|| {
                    assert_eq!(
                        ray.intersect_pack::<AVX512, PACK>(&pack, f32::INFINITY),
                        None
                    );
                    assert!(!ray.any_in_pack::<AVX512, PACK>(&pack, f32::INFINITY));
                })
            };
        }
        let back = 1e-4f32;
        let behind = std::array::from_fn(|k| origin[k] - back * dir[k]);
        let hit = ShearedRay::new(behind, dir)
            .intersect_pack::<PORTABLE, PACK>(&pack, f32::INFINITY)
            .expect("the line crosses the sliver ahead of this origin");
        assert_eq!(hit.lane, 3);
        let expected = back - 2.808e-6;
        assert!((hit.t - expected).abs() < 2e-5, "{} vs {expected}", hit.t);
    }

    #[test]
    fn unused_lanes_never_hit() {
        let pack = TrianglePack::<PACK>::empty();
        let ray = ShearedRay::new([0.0; 3], [0.0, 0.0, 1.0]);
        assert_eq!(
            ray.intersect_pack::<PORTABLE, PACK>(&pack, f32::INFINITY),
            None
        );
        assert!(!ray.any_in_pack::<PORTABLE, PACK>(&pack, f32::INFINITY));
    }
}
