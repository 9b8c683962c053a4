//! Numeric helpers and mesh assembly shared by the parts of the car.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use glam::DVec3;

use super::super::TriangleMesh;

pub(super) fn smoothstep(edge0: f64, edge1: f64, x: f64) -> f64 {
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

pub(super) fn lerp(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// Smooth minimum of `a` and `b` with blend width `k`.
pub(super) fn smooth_min(a: f64, b: f64, k: f64) -> f64 {
    let h = (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0);
    lerp(b, a, h) - k * h * (1.0 - h)
}

/// Point of the unit superellipse |x|^n + |y|^n = 1 at polar angle `psi`.
pub(super) fn superellipse(psi: f64, n: f64) -> (f64, f64) {
    let (s, c) = psi.sin_cos();
    let r = (c.abs().powf(n) + s.abs().powf(n)).powf(-1.0 / n);
    (r * c, r * s)
}

/// Quarter-superellipse end cap: 0 at the tip (`d = 0`), rising to 1 at `d = radius`
/// with zero slope there.
pub(super) fn end_cap(d: f64, radius: f64, n: f64) -> f64 {
    if d >= radius {
        1.0
    } else {
        let t = 1.0 - (d / radius).max(0.0);
        (1.0 - t.powf(n)).max(0.0).powf(1.0 / n)
    }
}

/// Monotone piecewise-cubic Hermite interpolation (PCHIP, Fritsch–Butland slopes):
/// C¹, no overshoot between control points.
#[derive(Debug, Clone)]
pub(super) struct Profile {
    xs: Vec<f64>,
    ys: Vec<f64>,
    slopes: Vec<f64>,
}

impl Profile {
    pub(super) fn new(points: &[(f64, f64)]) -> Self {
        let xs: Vec<f64> = points.iter().map(|p| p.0).collect();
        let ys: Vec<f64> = points.iter().map(|p| p.1).collect();
        let n = xs.len();
        let h: Vec<f64> = (0..n - 1).map(|k| xs[k + 1] - xs[k]).collect();
        let delta: Vec<f64> = (0..n - 1).map(|k| (ys[k + 1] - ys[k]) / h[k]).collect();
        let mut slopes = vec![0.0; n];
        slopes[0] = delta[0];
        slopes[n - 1] = delta[n - 2];
        for k in 1..n - 1 {
            let (d0, d1) = (delta[k - 1], delta[k]);
            if d0 * d1 > 0.0 {
                let (h0, h1) = (h[k - 1], h[k]);
                slopes[k] = 3.0 * (h0 + h1) / ((2.0 * h1 + h0) / d0 + (h1 + 2.0 * h0) / d1);
            }
        }
        Self { xs, ys, slopes }
    }

    pub(super) fn eval(&self, x: f64) -> f64 {
        let n = self.xs.len();
        let x = x.clamp(self.xs[0], self.xs[n - 1]);
        let k = self.xs[1..n - 1].partition_point(|&xk| xk <= x);
        let h = self.xs[k + 1] - self.xs[k];
        let t = (x - self.xs[k]) / h;
        let (t2, t3) = (t * t, t * t * t);
        (2.0 * t3 - 3.0 * t2 + 1.0) * self.ys[k]
            + (t3 - 2.0 * t2 + t) * h * self.slopes[k]
            + (-2.0 * t3 + 3.0 * t2) * self.ys[k + 1]
            + (t3 - t2) * h * self.slopes[k + 1]
    }
}

// ---------------------------------------------------------------------------------
// Mesh assembly

/// Appends a surface made of rings of equal vertex count, closed around each ring.
/// With `poles`, the first and last rings are joined to a pole vertex each (a closed
/// surface like a sphere); with `wrap`, the last ring is joined to the first (a
/// torus). `material(i, j)` is the material of the quad from ring `i`, vertex `j`
/// (ring −1 and `rings.len()` stand for the poles). The part is oriented outward by
/// its signed volume; normals are area-weighted face normals.
pub(super) fn add_ring_surface(
    mesh: &mut TriangleMesh,
    rings: &[Vec<[f64; 3]>],
    poles: Option<([f64; 3], [f64; 3])>,
    wrap: bool,
    material: impl Fn(isize, usize) -> u32,
) {
    let m = rings[0].len();
    let mut positions: Vec<[f64; 3]> = Vec::with_capacity(rings.len() * m + 2);
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut materials: Vec<u32> = Vec::new();
    let ring_start = usize::from(poles.is_some());
    if let Some((first, _)) = poles {
        positions.push(first);
    }
    for ring in rings {
        positions.extend_from_slice(ring);
    }
    let vertex = |i: usize, j: usize| (ring_start + i * m + j % m) as u32;
    // Each ring joins the next; a wrapped surface also joins the last ring to the first.
    let last = rings.len() - 1;
    let ring_pairs = (0..last)
        .map(|i| (i, i + 1))
        .chain(wrap.then_some((last, 0)));
    for (i, next) in ring_pairs {
        for j in 0..m {
            let [a, b, c, d] =
                [(i, j), (next, j), (next, j + 1), (i, j + 1)].map(|(i, j)| vertex(i, j));
            let mat = material(i as isize, j);
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
            materials.extend([mat, mat]);
        }
    }
    if let Some((_, last)) = poles {
        let last_index = positions.len() as u32;
        positions.push(last);
        let i = rings.len() - 1;
        for j in 0..m {
            triangles.push([0, vertex(0, j), vertex(0, j + 1)]);
            materials.push(material(-1, j));
            triangles.push([vertex(i, j), last_index, vertex(i, j + 1)]);
            materials.push(material(i as isize, j));
        }
    }

    // Orient outward: a closed surface has positive signed volume.
    orient_by(&mut triangles, &positions, |[a, b, c]| a.dot(b.cross(c)));
    push_part(mesh, &positions, &triangles, materials);
}

/// Appends an open grid of points (rows of equal length), oriented so that its
/// summed face normal points along `outward`. `material(i, j)` is the material of
/// the quad from row `i`, column `j`.
pub(super) fn add_grid_patch(
    mesh: &mut TriangleMesh,
    grid: &[Vec<DVec3>],
    outward: DVec3,
    material: impl Fn(usize, usize) -> u32,
) {
    let m = grid[0].len();
    let positions: Vec<[f64; 3]> = grid.iter().flatten().map(|p| p.to_array()).collect();
    let vertex = |i: usize, j: usize| (i * m + j) as u32;
    let mut triangles = Vec::new();
    let mut materials = Vec::new();
    for i in 0..grid.len() - 1 {
        for j in 0..m - 1 {
            let (a, b, c, d) = (
                vertex(i, j),
                vertex(i + 1, j),
                vertex(i + 1, j + 1),
                vertex(i, j + 1),
            );
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
            let mat = material(i, j);
            materials.extend([mat, mat]);
        }
    }
    orient_by(&mut triangles, &positions, |[a, b, c]| {
        (b - a).cross(c - a).dot(outward)
    });
    push_part(mesh, &positions, &triangles, materials);
}

/// A closed superellipsoid: `centre` plus the half-axis vectors `axes` (the poles lie
/// along the second), with squareness `exponents` across and around; `(rings,
/// segments)` its resolution.
pub(super) fn add_superellipsoid(
    mesh: &mut TriangleMesh,
    centre: DVec3,
    axes: [DVec3; 3],
    exponents: (f64, f64),
    (rings, segments): (usize, usize),
    material: u32,
) {
    let [u, v, w] = axes;
    let ring_points: Vec<Vec<[f64; 3]>> = (1..rings)
        .map(|k| {
            let theta = -FRAC_PI_2 + PI * k as f64 / rings as f64;
            let (ct, st) = superellipse(theta, exponents.0);
            (0..segments)
                .map(|s| {
                    let (cp, sp) = superellipse(TAU * s as f64 / segments as f64, exponents.1);
                    (centre + u * (ct * cp) + w * (ct * sp) + v * st).to_array()
                })
                .collect()
        })
        .collect();
    let poles = ((centre - v).to_array(), (centre + v).to_array());
    add_ring_surface(mesh, &ring_points, Some(poles), false, |_, _| material);
}

/// Appends the quads of a ring grid (rows closed around, as in
/// [`add_ring_surface`]) whose `material(i, j)` is `Some`, as one open surface: the
/// quad from ring `i`, row `j`, to ring `i + 1`, row `j + 1`. Every quad is wound
/// alike, and the whole turned so that its faces point along `facing(i, j)` summed
/// over the quads. Only the points the kept quads use are stored.
pub(super) fn add_ring_quads(
    mesh: &mut TriangleMesh,
    rings: &[Vec<DVec3>],
    material: impl Fn(usize, usize) -> Option<u32>,
    facing: impl Fn(usize, usize) -> DVec3,
) {
    let m = rings[0].len();
    let mut index_of = vec![u32::MAX; rings.len() * m];
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut vertex = |i: usize, j: usize| {
        let k = i * m + j % m;
        if index_of[k] == u32::MAX {
            index_of[k] = positions.len() as u32;
            positions.push(rings[i][j % m].to_array());
        }
        index_of[k]
    };
    let mut triangles = Vec::new();
    let mut materials = Vec::new();
    let mut alignment = 0.0;
    for i in 0..rings.len().saturating_sub(1) {
        for j in 0..m {
            let Some(mat) = material(i, j) else {
                continue;
            };
            let [a, b, c, d] =
                [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)].map(|(i, j)| vertex(i, j));
            let (pa, pc) = (rings[i][j], rings[i + 1][(j + 1) % m]);
            alignment += (rings[i + 1][j] - pa).cross(pc - pa).dot(facing(i, j));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
            materials.extend([mat, mat]);
        }
    }
    if triangles.is_empty() {
        return;
    }
    if alignment < 0.0 {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    push_part(mesh, &positions, &triangles, materials);
}

/// Appends loose triangles of one material, each flat (no vertex shared, so each
/// face's normal is its own), facing as wound.
pub(super) fn add_triangles(mesh: &mut TriangleMesh, triangles: &[[DVec3; 3]], material: u32) {
    let positions: Vec<[f64; 3]> = triangles.iter().flatten().map(|p| p.to_array()).collect();
    let faces: Vec<[u32; 3]> = (0..triangles.len() as u32)
        .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
        .collect();
    push_part(mesh, &positions, &faces, vec![material; triangles.len()]);
}

/// Flips every triangle's winding when the sum of `measure` over the triangles
/// (their corners' positions) is negative: the part's whole orientation is chosen
/// by one signed total (a volume, or a facing along a direction).
fn orient_by(
    triangles: &mut [[u32; 3]],
    positions: &[[f64; 3]],
    measure: impl Fn([DVec3; 3]) -> f64,
) {
    let total: f64 = triangles
        .iter()
        .map(|t| measure(t.map(|k| DVec3::from(positions[k as usize]))))
        .sum();
    if total < 0.0 {
        for t in triangles {
            t.swap(1, 2);
        }
    }
}

/// Appends one part with area-weighted vertex normals.
fn push_part(
    mesh: &mut TriangleMesh,
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    materials: Vec<u32>,
) {
    let base = mesh.positions.len() as u32;
    let mut normals = vec![DVec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|k| DVec3::from(positions[k as usize]));
        let n = (b - a).cross(c - a);
        for k in t {
            normals[*k as usize] += n;
        }
    }
    for (p, n) in positions.iter().zip(&normals) {
        let length = n.length();
        // Divided by the length, not `normalize()` (times its reciprocal): the
        // mesh, and so every render, stays the same to the bit.
        let unit = if length > 0.0 { *n / length } else { DVec3::Y };
        mesh.positions.push(p.map(|v| v as f32));
        mesh.normals.push(unit.as_vec3().to_array());
    }
    mesh.triangles
        .extend(triangles.iter().map(|t| t.map(|k| k + base)));
    mesh.triangle_material.extend(materials);
}
