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
//!
//! With `ReferenceSplits::Spatial` the references then go through an SBVH-style
//! pass (module `spatial` below): ×1.19–1.21 rays per second on the Lamborghini,
//! ×1.01–1.02 on the default car and the torus, at 4.6–5.3 times the build time
//! (over the 150 ms target), so it is not the default.

use super::{Bounds, ReferenceSplits};

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
    planes: ReferenceSplits,
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
    if planes == ReferenceSplits::Spatial {
        return spatial::presplit(triangles, out_boxes, out_triangle);
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

/// Spatial splits in the spirit of the SBVH (Stich, Friedrich and Dietrich 2009),
/// as a pass before the ordinary build: the top of a tree is partitioned
/// recursively, at each node by whichever is cheaper by the SAH, the best object
/// split (binned centroids) or the best spatial split (chopped binning: a
/// reference crossing a bin boundary is clipped to each bin it spans); a spatial
/// split cuts the references that straddle its plane into a piece on each side.
/// Only the references come out; the ordinary builder then builds the tree over
/// them, where a cut piece no longer straddles the plane.
mod spatial {
    use super::{Bounds, clip, half_area, outer_bounds};

    /// Bins per axis for both kinds of split.
    const BINS: usize = 16;
    /// Spatial splits are tried only where the children of the best object split
    /// overlap by more than this fraction of the root's area (Stich et al.'s α;
    /// their 10⁻⁵ gave the same rays per second on the Lamborghini at twice the
    /// build time, 10⁻² ×1.13 instead of ×1.19–1.21: docs/benchmarks.md).
    const OVERLAP: f32 = 1e-3;
    /// At most this fraction of the input is added as new references.
    const BUDGET: f32 = 0.3;
    /// Nodes with fewer references are left to the ordinary build.
    const MIN_NODE: usize = 64;
    /// Triangles per pack: the SAH counts packs, as the ordinary build does.
    const PACK: usize = 8;

    struct Reference {
        bounds: Bounds,
        triangle: u32,
    }

    fn empty() -> Bounds {
        Bounds {
            min: [f32::INFINITY; 3],
            max: [f32::NEG_INFINITY; 3],
        }
    }

    fn grow(a: &mut Bounds, b: &Bounds) {
        for k in 0..3 {
            a.min[k] = a.min[k].min(b.min[k]);
            a.max[k] = a.max[k].max(b.max[k]);
        }
    }

    fn area(b: &Bounds) -> f32 {
        if b.min[0] > b.max[0] {
            0.0
        } else {
            half_area(b)
        }
    }

    fn blocks(n: usize) -> f32 {
        n.div_ceil(PACK) as f32
    }

    struct Context<'a> {
        triangles: &'a [[[f32; 3]; 3]],
        root_area: f32,
        budget: usize,
    }

    impl Context<'_> {
        /// The triangle of `r` clipped to `r`'s box (f64).
        fn polygon(&self, r: &Reference) -> Vec<[f64; 3]> {
            let t = &self.triangles[r.triangle as usize];
            let mut polygon: Vec<[f64; 3]> = t.iter().map(|v| v.map(f64::from)).collect();
            for k in 0..3 {
                let lo = t.iter().map(|v| v[k]).fold(f32::INFINITY, f32::min);
                let hi = t.iter().map(|v| v[k]).fold(f32::NEG_INFINITY, f32::max);
                if r.bounds.min[k] > lo && polygon.len() >= 3 {
                    polygon = clip(&polygon, k, f64::from(r.bounds.min[k]), false);
                }
                if r.bounds.max[k] < hi && polygon.len() >= 3 {
                    polygon = clip(&polygon, k, f64::from(r.bounds.max[k]), true);
                }
            }
            polygon
        }

        /// The box of the part of `r` between `lo` and `hi` on `axis` (`None`
        /// when that part has no area).
        fn slab(
            &self,
            r: &Reference,
            polygon: &[[f64; 3]],
            axis: usize,
            lo: f32,
            hi: f32,
        ) -> Option<Bounds> {
            let mut piece = clip(polygon, axis, f64::from(lo), false);
            if piece.len() >= 3 {
                piece = clip(&piece, axis, f64::from(hi), true);
            }
            if piece.len() < 3 {
                return None;
            }
            let mut within = r.bounds;
            within.min[axis] = within.min[axis].max(lo);
            within.max[axis] = within.max[axis].min(hi);
            Some(outer_bounds(&piece, &within))
        }

        /// Partitions `refs` recursively, appending the final references to `out`.
        fn partition(&mut self, refs: Vec<Reference>, out: &mut Vec<Reference>) {
            if refs.len() < MIN_NODE {
                out.extend(refs);
                return;
            }
            let mut bounds = empty();
            let mut centres = empty();
            for r in &refs {
                grow(&mut bounds, &r.bounds);
                let c: [f32; 3] =
                    std::array::from_fn(|k| 0.5 * (r.bounds.min[k] + r.bounds.max[k]));
                grow(&mut centres, &Bounds { min: c, max: c });
            }
            let object = object_split(&refs, &centres);
            let mut best_spatial = None;
            if let Some((_, _, _, overlap)) = object
                && overlap > OVERLAP * self.root_area
                && self.budget > 0
            {
                best_spatial = self.spatial_split(&refs, &bounds);
            }
            match (object, best_spatial) {
                (_, Some((cost, axis, plane))) if object.is_none_or(|(c, _, _, _)| cost < c) => {
                    let (left, right) = self.cut(refs, axis, plane);
                    // A cut that leaves one side empty changed nothing: stop
                    // here rather than recurse on the same references.
                    if left.is_empty() || right.is_empty() {
                        out.extend(left);
                        out.extend(right);
                        return;
                    }
                    self.partition(left, out);
                    self.partition(right, out);
                }
                (Some((_, axis, split, _)), _) => {
                    let scale =
                        BINS as f32 * (1.0 - 1e-6) / (centres.max[axis] - centres.min[axis]);
                    let (left, right): (Vec<Reference>, Vec<Reference>) =
                        refs.into_iter().partition(|r| {
                            let c = 0.5 * (r.bounds.min[axis] + r.bounds.max[axis]);
                            ((((c - centres.min[axis]) * scale) as usize).min(BINS - 1)) < split
                        });
                    self.partition(left, out);
                    self.partition(right, out);
                }
                (None, _) => out.extend(refs),
            }
        }

        /// The best spatial split: (SAH cost, axis, plane).
        fn spatial_split(&self, refs: &[Reference], bounds: &Bounds) -> Option<(f32, usize, f32)> {
            let mut best: Option<(f32, usize, f32)> = None;
            for axis in 0..3 {
                let lo = bounds.min[axis];
                let width = (bounds.max[axis] - lo) / BINS as f32;
                if width <= 0.0 || !width.is_finite() {
                    continue;
                }
                let planes: [f32; BINS + 1] = std::array::from_fn(|i| {
                    if i == BINS {
                        bounds.max[axis]
                    } else {
                        lo + width * i as f32
                    }
                });
                let bin_of = |x: f32| planes[1..BINS].partition_point(|&p| p <= x);
                let mut bin_bounds = [empty(); BINS];
                let mut entry = [0usize; BINS];
                let mut exit = [0usize; BINS];
                for r in refs {
                    let first = bin_of(r.bounds.min[axis]);
                    let last = bin_of(r.bounds.max[axis]).max(first);
                    entry[first] += 1;
                    exit[last] += 1;
                    if first == last {
                        grow(&mut bin_bounds[first], &r.bounds);
                        continue;
                    }
                    let polygon = self.polygon(r);
                    for (i, bin) in bin_bounds.iter_mut().enumerate().take(last + 1).skip(first) {
                        if let Some(b) = self.slab(r, &polygon, axis, planes[i], planes[i + 1]) {
                            grow(bin, &b);
                        }
                    }
                }
                let mut right_cost = [0.0f32; BINS];
                let (mut acc, mut n) = (empty(), 0);
                for i in (1..BINS).rev() {
                    grow(&mut acc, &bin_bounds[i]);
                    n += exit[i];
                    right_cost[i] = area(&acc) * blocks(n);
                }
                let (mut acc, mut n) = (empty(), 0);
                for i in 0..BINS - 1 {
                    grow(&mut acc, &bin_bounds[i]);
                    n += entry[i];
                    let cost = area(&acc) * blocks(n) + right_cost[i + 1];
                    if n > 0 && best.is_none_or(|(c, _, _)| cost < c) {
                        best = Some((cost, axis, planes[i + 1]));
                    }
                }
            }
            best
        }

        /// Splits `refs` at `plane` on `axis`, cutting those that straddle it.
        fn cut(
            &mut self,
            refs: Vec<Reference>,
            axis: usize,
            plane: f32,
        ) -> (Vec<Reference>, Vec<Reference>) {
            let (mut left, mut right) = (Vec::new(), Vec::new());
            for r in refs {
                if r.bounds.max[axis] <= plane {
                    left.push(r);
                } else if r.bounds.min[axis] >= plane {
                    right.push(r);
                } else {
                    let polygon = self.polygon(&r);
                    let lower = self.slab(&r, &polygon, axis, f32::NEG_INFINITY, plane);
                    let upper = self.slab(&r, &polygon, axis, plane, f32::INFINITY);
                    match (lower, upper) {
                        (Some(l), Some(u)) if self.budget > 0 => {
                            self.budget -= 1;
                            left.push(Reference {
                                bounds: l,
                                triangle: r.triangle,
                            });
                            right.push(Reference {
                                bounds: u,
                                triangle: r.triangle,
                            });
                        }
                        // Only one side holds area: the other touches the plane,
                        // which the kept side's closed box contains.
                        (Some(l), None) => left.push(Reference {
                            bounds: l,
                            triangle: r.triangle,
                        }),
                        (None, Some(u)) => right.push(Reference {
                            bounds: u,
                            triangle: r.triangle,
                        }),
                        // Out of budget (or a degenerate clip): kept whole, on the
                        // side of its centre.
                        _ => {
                            if r.bounds.min[axis] + r.bounds.max[axis] < 2.0 * plane {
                                left.push(r);
                            } else {
                                right.push(r);
                            }
                        }
                    }
                }
            }
            (left, right)
        }
    }

    /// The best binned object split: (SAH cost, axis, first bin of the right side,
    /// overlap area of the two sides); `None` when the centroids fall into one bin.
    fn object_split(refs: &[Reference], centres: &Bounds) -> Option<(f32, usize, usize, f32)> {
        let mut best: Option<(f32, usize, usize, f32)> = None;
        for axis in 0..3 {
            let extent = centres.max[axis] - centres.min[axis];
            if extent <= 0.0 {
                continue;
            }
            let scale = BINS as f32 * (1.0 - 1e-6) / extent;
            let mut bin_bounds = [empty(); BINS];
            let mut count = [0usize; BINS];
            for r in refs {
                let c = 0.5 * (r.bounds.min[axis] + r.bounds.max[axis]);
                let i = (((c - centres.min[axis]) * scale) as usize).min(BINS - 1);
                grow(&mut bin_bounds[i], &r.bounds);
                count[i] += 1;
            }
            let mut right = [(empty(), 0usize); BINS];
            let (mut acc, mut n) = (empty(), 0);
            for i in (1..BINS).rev() {
                grow(&mut acc, &bin_bounds[i]);
                n += count[i];
                right[i] = (acc, n);
            }
            let (mut acc, mut n) = (empty(), 0);
            for i in 0..BINS - 1 {
                grow(&mut acc, &bin_bounds[i]);
                n += count[i];
                let (r_box, r_n) = right[i + 1];
                if n == 0 || r_n == 0 {
                    continue;
                }
                let cost = area(&acc) * blocks(n) + area(&r_box) * blocks(r_n);
                if best.is_none_or(|(c, _, _, _)| cost < c) {
                    let overlap = Bounds {
                        min: std::array::from_fn(|k| acc.min[k].max(r_box.min[k])),
                        max: std::array::from_fn(|k| acc.max[k].min(r_box.max[k])),
                    };
                    let overlap = if (0..3).all(|k| overlap.min[k] <= overlap.max[k]) {
                        half_area(&overlap)
                    } else {
                        0.0
                    };
                    best = Some((cost, axis, i + 1, overlap));
                }
            }
        }
        best
    }

    /// Spatially split references for `triangles`: the input references (boxes
    /// and triangle indices) partitioned as described above, in a deterministic
    /// order.
    pub(super) fn presplit(
        triangles: &[[[f32; 3]; 3]],
        boxes: Vec<Bounds>,
        triangle: Vec<u32>,
    ) -> (Vec<Bounds>, Vec<u32>) {
        let mut root = empty();
        boxes.iter().for_each(|b| grow(&mut root, b));
        let mut context = Context {
            triangles,
            root_area: area(&root),
            budget: (BUDGET * boxes.len() as f32) as usize,
        };
        let refs: Vec<Reference> = boxes
            .into_iter()
            .zip(triangle)
            .map(|(bounds, triangle)| Reference { bounds, triangle })
            .collect();
        let mut out = Vec::with_capacity(refs.len() + refs.len() / 4);
        context.partition(refs, &mut out);
        out.into_iter().map(|r| (r.bounds, r.triangle)).unzip()
    }
}
