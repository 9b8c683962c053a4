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
//! pass (module `spatial` below): ×1.13–1.30 rays per second on the Lamborghini,
//! none on the default car and the torus, at about 1.7 times the build's time; the
//! default (docs/benchmarks.md, "Acceleration structure").

use super::boxes::Bounds;
use super::options::ReferenceSplits;
use super::wide::TopNode;

/// A triangle is split while its piece's box has more than this many times the
/// average triangle box area (half surface areas).
const SPLIT_AREA_FACTOR: f32 = 8.0;
/// At most 2⁴ = 16 pieces a triangle.
const MAX_SPLIT_DEPTH: u32 = 4;

/// The references for `triangles` (vertices; `boxes` their boxes): for each, its
/// box and the index of its triangle, in triangle order (`Spatial`: in the order
/// of its pass), the same for any number of `threads`; and with `Spatial` the
/// pass's partition of them, as the top of the tree for `WideBvh::build` (else
/// empty).
pub(super) fn split_references(
    triangles: &[[[f32; 3]; 3]],
    boxes: &[Bounds],
    planes: ReferenceSplits,
    threads: usize,
) -> (Vec<Bounds>, Vec<u32>, Vec<TopNode>) {
    let average = boxes.iter().map(Bounds::half_area).sum::<f32>() / boxes.len().max(1) as f32;
    let threshold = SPLIT_AREA_FACTOR * average;
    let mut out_boxes = Vec::with_capacity(boxes.len() + boxes.len() / 16);
    let mut out_triangle = Vec::with_capacity(boxes.len() + boxes.len() / 16);
    for (i, (triangle, b)) in triangles.iter().zip(boxes).enumerate() {
        if b.half_area() <= threshold {
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
        return spatial::presplit(triangles, out_boxes, out_triangle, threads);
    }
    (out_boxes, out_triangle, Vec::new())
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
    if depth >= MAX_SPLIT_DEPTH || b.half_area() <= threshold {
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
/// The references come out in the partition's order, with the partition itself
/// ([`TopNode`]s), which the ordinary builder keeps as the top of its binary tree
/// and builds below (rebuilding the whole tree over the references instead gave the
/// same rays per second within 2 % at about 1.2 times the CPU time on the
/// Lamborghini).
///
/// **Cost.** The pass is built to stay within the build target (docs/benchmarks.md,
/// "Spatial splits"): the chopped binning clips a straddling reference's *box* to
/// each bin it spans (only `cut` clips triangles, in fixed arrays, no allocation),
/// the object bins of all three axes are filled in one pass, a subtree stops as
/// soon as it is too small for any spatial split to be tried in it (a child
/// overlap is never larger than its node), and the two subtrees of a large node
/// run on two threads. The result does not depend on the thread count: each
/// subtree gets a fixed share of the budget of new references (by its number of
/// references), and the subtrees' references are concatenated in tree order.
mod spatial {
    use glam::Vec3A;

    use super::super::boxes::{Bounds, BoundsA, NodeBoxes, bin_index, bin_indices};
    use super::TopNode;

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
    /// Fewest references for which a node's second subtree goes to another thread.
    const PARALLEL_MIN: usize = 4096;
    /// Vertices a clipped polygon can hold: a triangle cut by the six planes of a
    /// box has at most 9; the rest is margin for rounding (a polygon that would
    /// exceed it is replaced by its box, which is conservative).
    const MAX_POINTS: usize = 16;

    #[derive(Clone, Copy)]
    struct Reference {
        bounds: Bounds,
        triangle: u32,
    }

    /// A convex polygon in f64, in fixed storage; `overflow` when a clip produced
    /// more than [`MAX_POINTS`] vertices (then only its box is meaningful).
    #[derive(Clone, Copy)]
    struct Polygon {
        points: [[f64; 3]; MAX_POINTS],
        len: usize,
        overflow: bool,
    }

    impl Polygon {
        fn new() -> Polygon {
            Polygon {
                points: [[0.0; 3]; MAX_POINTS],
                len: 0,
                overflow: false,
            }
        }

        fn push(&mut self, p: [f64; 3]) {
            if self.len < MAX_POINTS {
                self.points[self.len] = p;
                self.len += 1;
            } else {
                self.overflow = true;
            }
        }

        fn points(&self) -> &[[f64; 3]] {
            &self.points[..self.len]
        }

        /// Has area (three or more vertices), or may have (overflowed).
        fn is_piece(&self) -> bool {
            self.overflow || self.len >= 3
        }

        /// The parts on each closed side of the plane `p[axis] = plane`, in one
        /// pass (Sutherland–Hodgman for both sides; a vertex on the plane goes to
        /// both).
        fn split(&self, axis: usize, plane: f64) -> (Polygon, Polygon) {
            let (mut below, mut above) = (Polygon::new(), Polygon::new());
            below.overflow = self.overflow;
            above.overflow = self.overflow;
            let points = self.points();
            for (i, &a) in points.iter().enumerate() {
                let b = points[(i + 1) % points.len()];
                if a[axis] <= plane {
                    below.push(a);
                }
                if a[axis] >= plane {
                    above.push(a);
                }
                if (a[axis] < plane && b[axis] > plane) || (a[axis] > plane && b[axis] < plane) {
                    let t = (plane - a[axis]) / (b[axis] - a[axis]);
                    let mut p: [f64; 3] = std::array::from_fn(|k| a[k] + t * (b[k] - a[k]));
                    p[axis] = plane;
                    below.push(p);
                    above.push(p);
                }
            }
            (below, above)
        }

        /// The part on one closed side of the plane.
        fn clip(&self, axis: usize, plane: f64, below: bool) -> Polygon {
            let (lower, upper) = self.split(axis, plane);
            if below { lower } else { upper }
        }

        /// Bounds rounded outwards to f32 and intersected with `within` (just
        /// `within` for an overflowed polygon, which lies inside it).
        fn outer_bounds(&self, within: &Bounds) -> Bounds {
            if self.overflow {
                return *within;
            }
            super::outer_bounds(self.points(), within)
        }
    }

    fn blocks(n: usize) -> f32 {
        n.div_ceil(PACK) as f32
    }

    /// A reference's box in SIMD form, and its centre.
    #[inline(always)]
    fn boxes(r: &Reference) -> (BoundsA, Vec3A) {
        let b = BoundsA::new(&r.bounds);
        let centre = b.centre2() * 0.5;
        (b, centre)
    }

    /// Adds a reference to a node's boxes.
    #[inline(always)]
    fn add(node: &mut NodeBoxes, r: &Reference) {
        let (b, centre) = boxes(r);
        node.grow(&b, centre);
    }

    /// The best binned object split of a node.
    #[derive(Clone, Copy)]
    struct ObjectSplit {
        cost: f32,
        axis: usize,
        /// The first bin of the right side.
        bin: usize,
        /// Half area of the intersection of the two sides' boxes.
        overlap: f32,
    }

    struct Context<'a> {
        triangles: &'a [[[f32; 3]; 3]],
        root_area: f32,
    }

    impl Context<'_> {
        /// The triangle of `r` clipped to `r`'s box (only on the planes where the
        /// box is tighter than the triangle's own).
        fn polygon(&self, r: &Reference) -> Polygon {
            let t = &self.triangles[r.triangle as usize];
            let mut polygon = Polygon::new();
            for v in t {
                polygon.push(v.map(f64::from));
            }
            for k in 0..3 {
                let lo = t.iter().map(|v| v[k]).fold(f32::INFINITY, f32::min);
                let hi = t.iter().map(|v| v[k]).fold(f32::NEG_INFINITY, f32::max);
                if r.bounds.min[k] > lo && polygon.is_piece() {
                    polygon = polygon.clip(k, f64::from(r.bounds.min[k]), false);
                }
                if r.bounds.max[k] < hi && polygon.is_piece() {
                    polygon = polygon.clip(k, f64::from(r.bounds.max[k]), true);
                }
            }
            polygon
        }

        /// Partitions `refs` (whose boxes are `node`) recursively with at most
        /// `budget` new references, appending the final references to `out` as
        /// chunks in tree order, on up to `threads` threads.
        fn partition(
            &self,
            mut refs: Vec<Reference>,
            node: NodeBoxes,
            budget: usize,
            threads: usize,
            out: &mut Vec<Vec<Reference>>,
            top: &mut Vec<TopNode>,
        ) -> usize {
            let chunk =
                |refs: Vec<Reference>, out: &mut Vec<Vec<Reference>>, top: &mut Vec<TopNode>| {
                    top.push(TopNode::Leaf { refs: refs.len() });
                    out.push(refs);
                    top.len() - 1
                };
            if refs.len() < MIN_NODE {
                return chunk(refs, out, top);
            }
            let NodeBoxes { bounds, centres } = node;
            // Two children overlap by at most their node's area: below this no
            // spatial split can be tried, and the ordinary build does the rest.
            if bounds.half_area() <= OVERLAP * self.root_area {
                return chunk(refs, out, top);
            }
            let object = object_split(&refs, &centres);
            let mut spatial = None;
            if let Some(o) = object
                && o.overlap > OVERLAP * self.root_area
                && budget > 0
            {
                spatial = self.spatial_split(&refs, &bounds);
            }
            // The two sides, their boxes (gathered while partitioning) and the
            // budget left.
            let (left, left_node, right, right_node, budget) = match (object, spatial) {
                (_, Some((cost, axis, plane))) if object.is_none_or(|o| cost < o.cost) => {
                    let (left, left_node, right, right_node, budget) =
                        self.cut(refs, axis, plane, budget);
                    // A cut that leaves one side empty changed nothing: stop
                    // here rather than recurse on the same references.
                    if left.is_empty() || right.is_empty() {
                        top.push(TopNode::Leaf {
                            refs: left.len() + right.len(),
                        });
                        out.push(left);
                        out.push(right);
                        return top.len() - 1;
                    }
                    (left, left_node, right, right_node, budget)
                }
                (Some(o), _) => {
                    let low = centres.min[o.axis];
                    let scale = BINS as f32 * (1.0 - 1e-6) / (centres.max[o.axis] - low);
                    let (mut left_node, mut right_node) = (NodeBoxes::EMPTY, NodeBoxes::EMPTY);
                    // In place, as the ordinary builder partitions; each
                    // reference is classified once.
                    let (mut i, mut j) = (0, refs.len());
                    while i < j {
                        let (b, c) = boxes(&refs[i]);
                        if bin_index((c[o.axis] - low) * scale, BINS - 1) < o.bin {
                            left_node.grow(&b, c);
                            i += 1;
                        } else {
                            right_node.grow(&b, c);
                            j -= 1;
                            refs.swap(i, j);
                        }
                    }
                    let right = refs.split_off(i);
                    (refs, left_node, right, right_node, budget)
                }
                (None, _) => {
                    return chunk(refs, out, top);
                }
            };
            // The budget left is shared by size, so that neither the result nor
            // its order depends on which subtree runs first, or where.
            let left_budget =
                (budget as u64 * left.len() as u64 / (left.len() + right.len()) as u64) as usize;
            let right_budget = budget - left_budget;
            let index = top.len();
            top.push(TopNode::Leaf { refs: 0 });
            let (left, right) = if threads > 1 && left.len() + right.len() >= PARALLEL_MIN {
                let half = threads / 2;
                let mut right_out = Vec::new();
                let mut right_top = Vec::new();
                let (left, right) = std::thread::scope(|scope| {
                    let handle = scope.spawn(|| {
                        self.partition(
                            right,
                            right_node,
                            right_budget,
                            half,
                            &mut right_out,
                            &mut right_top,
                        )
                    });
                    let left =
                        self.partition(left, left_node, left_budget, threads - half, out, top);
                    // A panic in the other half is a bug; re-raise it here.
                    match handle.join() {
                        Ok(right) => (left, right),
                        Err(payload) => std::panic::resume_unwind(payload),
                    }
                });
                out.append(&mut right_out);
                let offset = top.len();
                top.extend(right_top.into_iter().map(|node| node.offset(offset)));
                (left, right + offset)
            } else {
                let left = self.partition(left, left_node, left_budget, threads, out, top);
                (
                    left,
                    self.partition(right, right_node, right_budget, threads, out, top),
                )
            };
            // The children's counts, which include the references their own
            // spatial splits added.
            let refs = top[left].refs() + top[right].refs();
            top[index] = TopNode::Inner { left, right, refs };
            index
        }

        /// The best spatial split: (SAH cost, axis, plane).
        fn spatial_split(&self, refs: &[Reference], bounds: &BoundsA) -> Option<(f32, usize, f32)> {
            let mut bin_bounds = [[BoundsA::EMPTY; BINS]; 3];
            let mut entry = [[0usize; BINS]; 3];
            let mut exit = [[0usize; BINS]; 3];
            let mut planes = [[0.0f32; BINS + 1]; 3];
            let mut inverse_width = [0.0f32; 3];
            // Per axis and bin, the bin's planes as boxes that clip only that axis:
            // the lower plane in the axis's lane of a minimum (−∞ elsewhere), the
            // upper one in a maximum (+∞ elsewhere).
            let mut clip_min = [[Vec3A::NEG_INFINITY; BINS]; 3];
            let mut clip_max = [[Vec3A::INFINITY; BINS]; 3];
            for axis in 0..3 {
                let lo = bounds.min[axis];
                let width = (bounds.max[axis] - lo) / BINS as f32;
                if width > 0.0 && width.is_finite() {
                    inverse_width[axis] = 1.0 / width;
                }
                planes[axis] = std::array::from_fn(|i| {
                    if i == BINS {
                        bounds.max[axis]
                    } else {
                        lo + width * i as f32
                    }
                });
                for i in 0..BINS {
                    clip_min[axis][i][axis] = planes[axis][i];
                    clip_max[axis][i][axis] = planes[axis][i + 1];
                }
            }
            let inverse = Vec3A::from(inverse_width);
            for r in refs {
                let b = BoundsA::new(&r.bounds);
                // Bins by arithmetic: they only place the estimate; which side of
                // a plane a piece ends on is decided by `cut`.
                let first_bin = bin_indices((b.min - bounds.min) * inverse, BINS - 1);
                let last_bin = bin_indices((b.max - bounds.min) * inverse, BINS - 1);
                for axis in 0..3 {
                    if inverse_width[axis] == 0.0 {
                        continue;
                    }
                    let first = first_bin[axis];
                    let last = last_bin[axis].max(first);
                    entry[axis][first] += 1;
                    exit[axis][last] += 1;
                    if first == last {
                        bin_bounds[axis][first].grow(&b);
                        continue;
                    }
                    // Chopped binning with the reference's box clipped to each
                    // bin rather than its triangle (measured: the same rays per
                    // second at under half the cost of clipping the polygon to
                    // every bin; docs/benchmarks.md). `cut` clips exactly.
                    for i in first..=last {
                        let piece = BoundsA {
                            min: b.min.max(clip_min[axis][i]),
                            max: b.max.min(clip_max[axis][i]),
                        };
                        bin_bounds[axis][i].grow(&piece);
                    }
                }
            }
            let mut best: Option<(f32, usize, f32)> = None;
            for axis in 0..3 {
                if inverse_width[axis] == 0.0 {
                    continue;
                }
                let mut right_cost = [0.0f32; BINS];
                let (mut acc, mut n) = (BoundsA::EMPTY, 0);
                for i in (1..BINS).rev() {
                    acc.grow(&bin_bounds[axis][i]);
                    n += exit[axis][i];
                    right_cost[i] = acc.half_area() * blocks(n);
                }
                let (mut acc, mut n) = (BoundsA::EMPTY, 0);
                for i in 0..BINS - 1 {
                    acc.grow(&bin_bounds[axis][i]);
                    n += entry[axis][i];
                    let cost = acc.half_area() * blocks(n) + right_cost[i + 1];
                    if n > 0 && best.is_none_or(|(c, _, _)| cost < c) {
                        best = Some((cost, axis, planes[axis][i + 1]));
                    }
                }
            }
            best
        }

        /// Splits `refs` at `plane` on `axis`, cutting those that straddle it
        /// while `budget` lasts; returns the two sides with their boxes and the
        /// budget left.
        fn cut(
            &self,
            mut refs: Vec<Reference>,
            axis: usize,
            plane: f32,
            mut budget: usize,
        ) -> (Vec<Reference>, NodeBoxes, Vec<Reference>, NodeBoxes, usize) {
            // The left side is written over `refs` as it is read (each reference
            // gives at most one left reference, so it never overtakes the reading).
            let mut right = Vec::with_capacity(refs.len() / 2);
            let (mut left_node, mut right_node) = (NodeBoxes::EMPTY, NodeBoxes::EMPTY);
            let mut left_len = 0;
            for i in 0..refs.len() {
                let r = refs[i];
                let mut to_left = |l: Reference| {
                    add(&mut left_node, &l);
                    refs[left_len] = l;
                    left_len += 1;
                };
                if r.bounds.max[axis] <= plane {
                    to_left(r);
                } else if r.bounds.min[axis] >= plane {
                    add(&mut right_node, &r);
                    right.push(r);
                } else {
                    let (below, above) = self.polygon(&r).split(axis, f64::from(plane));
                    let (mut lower_box, mut upper_box) = (r.bounds, r.bounds);
                    lower_box.max[axis] = plane;
                    upper_box.min[axis] = plane;
                    let lower = below.is_piece().then(|| below.outer_bounds(&lower_box));
                    let upper = above.is_piece().then(|| above.outer_bounds(&upper_box));
                    let triangle = r.triangle;
                    match (lower, upper) {
                        (Some(l), Some(u)) if budget > 0 => {
                            budget -= 1;
                            to_left(Reference {
                                bounds: l,
                                triangle,
                            });
                            let u = Reference {
                                bounds: u,
                                triangle,
                            };
                            add(&mut right_node, &u);
                            right.push(u);
                        }
                        // Only one side holds area: the other touches the plane,
                        // which the kept side's closed box contains.
                        (Some(l), None) => to_left(Reference {
                            bounds: l,
                            triangle,
                        }),
                        (None, Some(u)) => {
                            let u = Reference {
                                bounds: u,
                                triangle,
                            };
                            add(&mut right_node, &u);
                            right.push(u);
                        }
                        // Out of budget (or a degenerate clip): kept whole, on the
                        // side of its centre.
                        _ => {
                            if r.bounds.min[axis] + r.bounds.max[axis] < 2.0 * plane {
                                to_left(r);
                            } else {
                                add(&mut right_node, &r);
                                right.push(r);
                            }
                        }
                    }
                }
            }
            refs.truncate(left_len);
            (refs, left_node, right, right_node, budget)
        }
    }

    /// The best binned object split, all three axes binned in one pass; `None`
    /// when the centroids fall into one bin.
    fn object_split(refs: &[Reference], centres: &BoundsA) -> Option<ObjectSplit> {
        let scale: [f32; 3] = std::array::from_fn(|k| {
            let extent = centres.max[k] - centres.min[k];
            if extent > 0.0 {
                BINS as f32 * (1.0 - 1e-6) / extent
            } else {
                0.0
            }
        });
        let scale_a = Vec3A::from(scale);
        let mut bin_bounds = [[BoundsA::EMPTY; BINS]; 3];
        let mut count = [[0usize; BINS]; 3];
        for r in refs {
            let (b, c) = boxes(r);
            let bin = bin_indices((c - centres.min) * scale_a, BINS - 1);
            for (axis, &i) in bin.iter().enumerate() {
                bin_bounds[axis][i].grow(&b);
                count[axis][i] += 1;
            }
        }
        let mut best: Option<ObjectSplit> = None;
        for axis in 0..3 {
            if scale[axis] == 0.0 {
                continue;
            }
            let mut right = [(BoundsA::EMPTY, 0usize); BINS];
            let (mut acc, mut n) = (BoundsA::EMPTY, 0);
            for i in (1..BINS).rev() {
                acc.grow(&bin_bounds[axis][i]);
                n += count[axis][i];
                right[i] = (acc, n);
            }
            let (mut acc, mut n) = (BoundsA::EMPTY, 0);
            for i in 0..BINS - 1 {
                acc.grow(&bin_bounds[axis][i]);
                n += count[axis][i];
                let (r_box, r_n) = right[i + 1];
                if n == 0 || r_n == 0 {
                    continue;
                }
                let cost = acc.half_area() * blocks(n) + r_box.half_area() * blocks(r_n);
                if best.is_none_or(|o| cost < o.cost) {
                    let overlap = BoundsA {
                        min: acc.min.max(r_box.min),
                        max: acc.max.min(r_box.max),
                    };
                    let overlap = if overlap.min.cmple(overlap.max).all() {
                        overlap.half_area()
                    } else {
                        0.0
                    };
                    best = Some(ObjectSplit {
                        cost,
                        axis,
                        bin: i + 1,
                        overlap,
                    });
                }
            }
        }
        best
    }

    /// Spatially split references for `triangles`: the input references (boxes
    /// and triangle indices) partitioned as described above on up to `threads`
    /// threads, in an order that does not depend on `threads`.
    pub(super) fn presplit(
        triangles: &[[[f32; 3]; 3]],
        boxes: Vec<Bounds>,
        triangle: Vec<u32>,
        threads: usize,
    ) -> (Vec<Bounds>, Vec<u32>, Vec<TopNode>) {
        let budget = (BUDGET * boxes.len() as f32) as usize;
        let refs: Vec<Reference> = boxes
            .into_iter()
            .zip(triangle)
            .map(|(bounds, triangle)| Reference { bounds, triangle })
            .collect();
        let mut root = NodeBoxes::EMPTY;
        refs.iter().for_each(|r| add(&mut root, r));
        let context = Context {
            triangles,
            root_area: root.bounds.half_area(),
        };
        let mut chunks = Vec::new();
        let mut top = Vec::new();
        context.partition(refs, root, budget, threads.max(1), &mut chunks, &mut top);
        let (boxes, triangle) = chunks
            .into_iter()
            .flatten()
            .map(|r| (r.bounds, r.triangle))
            .unzip();
        (boxes, triangle, top)
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::slivers;
    use super::*;

    /// The spatial pass's partition, handed to the builder as the top of the tree,
    /// is a tree over exactly its references: each inner node's count the sum of
    /// its children's, the leaves covering the references in order; and it is the
    /// same for any number of threads.
    #[test]
    fn the_spatial_partition_is_a_tree_over_its_references() {
        let (triangles, boxes) = slivers(6000);
        let (refs, _, top) = split_references(&triangles, &boxes, ReferenceSplits::Spatial, 1);
        assert!(refs.len() > boxes.len(), "no spatial splits to test");
        assert!(top.len() > 1, "no partition to test");
        // Walk from the root: every node reached once, leaves in order.
        let mut seen = vec![false; top.len()];
        let mut leaf_refs = Vec::new();
        let mut pending = vec![0];
        while let Some(t) = pending.pop() {
            assert!(!std::mem::replace(&mut seen[t], true), "node {t} twice");
            match top[t] {
                TopNode::Leaf { refs } => leaf_refs.push(refs),
                TopNode::Inner { left, right, refs } => {
                    assert_eq!(refs, top[left].refs() + top[right].refs(), "node {t}");
                    pending.push(right);
                    pending.push(left);
                }
            }
        }
        assert!(seen.iter().all(|&s| s), "unreachable nodes");
        assert_eq!(top[0].refs(), refs.len());
        assert_eq!(leaf_refs.iter().sum::<usize>(), refs.len());
        for threads in [2, 3] {
            let (_, _, parallel) =
                split_references(&triangles, &boxes, ReferenceSplits::Spatial, threads);
            assert_eq!(parallel, top, "{threads} threads");
        }
        let (_, _, none) = split_references(&triangles, &boxes, ReferenceSplits::LargeTriangles, 1);
        assert!(none.is_empty());
    }
}
