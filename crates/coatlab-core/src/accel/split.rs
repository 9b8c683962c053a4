//! Reference splitting before the `Simd8` build ("early split clipping", Ernst and
//! Greiner 2007): a triangle whose box is much larger than the average is entered
//! into the tree several times, each *reference* with the box of one piece of the
//! triangle, so that long, thin or diagonal triangles (common in car models) stop
//! inflating the boxes of every node above them. A ray then finds the triangle
//! through whichever piece it crosses; duplicates in the leaves are harmless (the
//! same triangle gives the same distance).
//!
//! Measured on the Lamborghini (docs/benchmarks.md): with the threshold at 8 times
//! the average box area, 2.9 % more references, 41 → 29 triangles and 5.8 → 4.0
//! leaves per incoherent ray, +15–18 % rays per second; the default car and the
//! torus have almost no such triangles and are unchanged.
//!
//! **Conservative boxes.** A piece is the triangle clipped to an axis-aligned half
//! box, computed in f64 and rounded outwards to f32 (then intersected with the half
//! box, whose planes are f32 already), so every point of the triangle lies in the
//! box of at least one of its pieces, as the watertight traversal needs: a point on
//! a split plane belongs to both closed halves.

use super::Bounds;

/// A triangle is split while its piece's box has more than this many times the
/// average triangle box area (half surface areas).
const SPLIT_AREA_FACTOR: f32 = 8.0;
/// At most 2⁴ = 16 pieces a triangle.
const MAX_SPLIT_DEPTH: u32 = 4;

/// Half the surface area of a box (0 for an empty one).
fn half_area(b: &Bounds) -> f32 {
    let d: [f32; 3] = std::array::from_fn(|k| (b.max[k] - b.min[k]).max(0.0));
    d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
}

/// The references for `triangles` (vertices; `boxes` their boxes): for each, its
/// box and the index of its triangle, in triangle order.
pub(super) fn split_references(
    triangles: &[[[f32; 3]; 3]],
    boxes: &[Bounds],
) -> (Vec<Bounds>, Vec<u32>) {
    let average = boxes.iter().map(half_area).sum::<f32>() / boxes.len().max(1) as f32;
    let threshold = SPLIT_AREA_FACTOR * average;
    let mut out_boxes = Vec::with_capacity(boxes.len() + boxes.len() / 16);
    let mut out_triangle = Vec::with_capacity(boxes.len() + boxes.len() / 16);
    for (i, (triangle, b)) in triangles.iter().zip(boxes).enumerate() {
        if half_area(b) <= threshold {
            out_boxes.push(*b);
            out_triangle.push(i as u32);
            continue;
        }
        let polygon: Vec<[f64; 3]> = triangle.iter().map(|v| v.map(f64::from)).collect();
        split(&polygon, b, threshold, 0, &mut |piece| {
            out_boxes.push(piece);
            out_triangle.push(i as u32);
        });
    }
    (out_boxes, out_triangle)
}

/// Bounds of `polygon`, rounded outwards to f32 and intersected with `within`.
fn outer_bounds(polygon: &[[f64; 3]], within: &Bounds) -> Bounds {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in polygon {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    Bounds {
        min: std::array::from_fn(|k| {
            let f = lo[k] as f32;
            let f = if f64::from(f) > lo[k] {
                f.next_down()
            } else {
                f
            };
            f.max(within.min[k])
        }),
        max: std::array::from_fn(|k| {
            let f = hi[k] as f32;
            let f = if f64::from(f) < hi[k] { f.next_up() } else { f };
            f.min(within.max[k])
        }),
    }
}

/// The part of `polygon` on one side (closed) of the plane `p[axis] = plane`
/// (Sutherland–Hodgman for one plane).
fn clip(polygon: &[[f64; 3]], axis: usize, plane: f64, below: bool) -> Vec<[f64; 3]> {
    let inside = |p: &[f64; 3]| {
        if below {
            p[axis] <= plane
        } else {
            p[axis] >= plane
        }
    };
    let mut out = Vec::with_capacity(polygon.len() + 1);
    for (i, &a) in polygon.iter().enumerate() {
        let b = polygon[(i + 1) % polygon.len()];
        if inside(&a) {
            out.push(a);
        }
        if inside(&a) != inside(&b) {
            let t = (plane - a[axis]) / (b[axis] - a[axis]);
            let mut p: [f64; 3] = std::array::from_fn(|k| a[k] + t * (b[k] - a[k]));
            p[axis] = plane;
            out.push(p);
        }
    }
    out
}

/// Emits the boxes of the pieces of `polygon` (inside `within`): halves at the
/// middle of the widest axis until small enough.
fn split(
    polygon: &[[f64; 3]],
    within: &Bounds,
    threshold: f32,
    depth: u32,
    emit: &mut impl FnMut(Bounds),
) {
    let b = outer_bounds(polygon, within);
    if depth >= MAX_SPLIT_DEPTH || half_area(&b) <= threshold {
        emit(b);
        return;
    }
    let extent: [f32; 3] = std::array::from_fn(|k| b.max[k] - b.min[k]);
    let axis = (0..3)
        .max_by(|&x, &y| extent[x].total_cmp(&extent[y]))
        .unwrap_or(0);
    let plane = 0.5 * (b.min[axis] + b.max[axis]);
    let (mut lower, mut upper) = (b, b);
    lower.max[axis] = plane;
    upper.min[axis] = plane;
    for (half, below) in [(lower, true), (upper, false)] {
        let piece = clip(polygon, axis, f64::from(plane), below);
        // A piece of fewer than 3 points has no area; a point of the triangle on it
        // lies on the plane and so in the other piece as well.
        if piece.len() >= 3 {
            split(&piece, &half, threshold, depth + 1, emit);
        }
    }
}
