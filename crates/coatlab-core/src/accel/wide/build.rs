//! The build of the 8-wide tree (see the parent module's documentation, "Build"):
//! the binned-SAH binary tree over the primitives' boxes, below a given top when the
//! spatial-split pass made one, and its collapse into 8-wide nodes by the SAH plan.

use glam::Vec3A;

use super::super::boxes::{Bounds, BoundsA, NodeBoxes, bin_index, bin_indices};
use super::{
    MAX_LEAF, MEDIAN_DEPTH, Node, PACK, TreeTooLarge, WIDTH, WideBvh, leaf_reference,
    node_reference, pack_count,
};

impl WideBvh {
    /// Builds the tree over `boxes` (finite; checked by the caller) with `bins` SAH
    /// bins per axis, on up to `threads` threads (at least one).
    ///
    /// `top`, when not empty, is the top of the binary tree, already partitioned
    /// (the spatial-split pass's, `accel/split.rs`): `boxes` are in its leaves'
    /// order, and the SAH build goes on below each of its leaves.
    pub fn build(
        boxes: &[Bounds],
        top: &[TopNode],
        bins: usize,
        threads: usize,
    ) -> Result<WideBvh, TreeTooLarge> {
        WideBvh::build_collapsed(boxes, top, bins, threads, |wide, bin| {
            let plan = CollapsePlan::new(bin);
            wide.collapse(bin, &plan, 0).map(|_| ())
        })
    }

    /// [`WideBvh::build`], with an inner root collapsed into wide nodes by
    /// `collapse` (the SAH plan's, or, for comparison, another).
    pub(super) fn build_collapsed(
        boxes: &[Bounds],
        top: &[TopNode],
        bins: usize,
        threads: usize,
        collapse: impl FnOnce(&mut WideBvh, &[BinNode]) -> Result<(), TreeTooLarge>,
    ) -> Result<WideBvh, TreeTooLarge> {
        if boxes.is_empty() {
            return Ok(WideBvh {
                nodes: Vec::new(),
                order: Vec::new(),
                pack_slots: Vec::new(),
            });
        }
        let (bin, order) = binary_tree(boxes, top, bins, threads);
        let mut wide = WideBvh {
            nodes: Vec::with_capacity(bin.len() / 4 + 1),
            order: Vec::new(),
            pack_slots: Vec::with_capacity(boxes.len() / 2),
        };
        let root = &bin[0];
        if let BinKind::Leaf { first, count } = root.kind {
            // A single leaf: a root node with one child.
            let mut node = Node::empty();
            node.set_bounds(0, &root.bounds);
            node.child[0] = wide.leaf_child(first, count)?;
            wide.nodes.push(node);
        } else {
            collapse(&mut wide, &bin)?;
        }
        wide.order = order;
        Ok(wide)
    }

    /// Emits the wide node for binary inner node `b` (and, recursively, its subtree)
    /// as `plan` chose it; returns its child reference.
    fn collapse(
        &mut self,
        bin: &[BinNode],
        plan: &CollapsePlan,
        b: usize,
    ) -> Result<u32, TreeTooLarge> {
        let (index, reference) = self.reserve_node()?;
        let mut roots = Vec::with_capacity(WIDTH);
        plan.node_roots(bin, b, &mut roots);
        let mut node = Node::empty();
        for (i, &r) in roots.iter().enumerate() {
            node.set_bounds(i, &bin[r].bounds);
            node.child[i] = if plan.as_leaf[r] {
                let (first, count) = plan.span[r];
                self.leaf_child(first as usize, count as usize)?
            } else {
                self.collapse(bin, plan, r)?
            };
        }
        self.nodes[index] = node;
        Ok(reference)
    }

    /// Appends an empty node for a collapse to fill in once its children have
    /// theirs (a node precedes its subtree); returns its index and child reference.
    pub(super) fn reserve_node(&mut self) -> Result<(usize, u32), TreeTooLarge> {
        let index = self.nodes.len();
        let reference = node_reference(index).ok_or_else(TreeTooLarge::nodes)?;
        self.nodes.push(Node::empty());
        Ok((index, reference))
    }

    /// Allocates the packs of a leaf over slots `first..first + count`; returns its
    /// child reference.
    pub(super) fn leaf_child(&mut self, first: usize, count: usize) -> Result<u32, TreeTooLarge> {
        let first_pack = self.pack_slots.len();
        let reference = leaf_reference(first_pack, count).ok_or_else(TreeTooLarge::packs)?;
        for start in (first..first + count).step_by(PACK) {
            self.pack_slots.push(std::array::from_fn(|lane| {
                let slot = start + lane;
                if slot < first + count {
                    slot as u32
                } else {
                    u32::MAX
                }
            }));
        }
        Ok(reference)
    }
}

/// Cost of testing one ray against one node's 8 child boxes, per unit of the node's
/// area, in the collapse's SAH (relative to [`PACK_COST`]). A node step and a pack
/// step take about the same time (docs/benchmarks.md, "Where the time goes"). With
/// the leaves fixed by the binary build, the plan only chooses which subtrees to
/// open, and 0.5 and 2 gave the same steps per Lamborghini ray ("SAH collapse").
pub(super) const NODE_COST: f32 = 1.0;
/// Cost of testing one ray against one pack of [`PACK`] primitives, per unit of the
/// leaf's area.
pub(super) const PACK_COST: f32 = 1.0;

/// The optimal collapse of a binary tree into 8-wide nodes under the SAH, after
/// Ylitie, Karras and Laine, "Efficient Incoherent Ray Traversal on GPUs Through
/// Compressed Wide BVHs" (HPG 2017): for each binary node n and each i ≤ 8, the
/// least cost of covering n's primitives by at most i roots, each a leaf (at most
/// [`MAX_LEAF`] primitives, one pack) or a wide node whose own children are such a
/// cover of at most 8 roots. Computed bottom-up in one pass (children have larger
/// indices than their parent), O(8²) per binary node.
pub(super) struct CollapsePlan {
    /// `cost[n][i]`: least cost of n's subtree as at most i + 1 roots.
    cost: Vec<[f32; WIDTH]>,
    /// How `cost[n][i]` is reached: 0 = n itself as one root; otherwise
    /// `roots << 4 | left` = a cover of `roots` roots, `left` of them in the left
    /// child's subtree.
    choice: Vec<[u8; WIDTH]>,
    /// `choice` for n as a wide node: its cover by at most 8 roots.
    node_choice: Vec<u8>,
    /// Whether n as one root is a leaf (else a wide node).
    as_leaf: Vec<bool>,
    /// First slot and number of primitives of n's subtree.
    span: Vec<(u32, u32)>,
}

impl CollapsePlan {
    pub(super) fn new(bin: &[BinNode]) -> CollapsePlan {
        let n = bin.len();
        let mut plan = CollapsePlan {
            cost: vec![[0.0; WIDTH]; n],
            choice: vec![[0; WIDTH]; n],
            node_choice: vec![0; n],
            as_leaf: vec![false; n],
            span: vec![(0, 0); n],
        };
        for b in (0..n).rev() {
            let area = bin[b].bounds.half_area();
            let (left, right) = match bin[b].kind {
                BinKind::Leaf { first, count } => {
                    plan.span[b] = (first as u32, count as u32);
                    plan.as_leaf[b] = true;
                    plan.cost[b] = [PACK_COST * area * pack_count(count) as f32; WIDTH];
                    continue;
                }
                BinKind::Inner { left, right } => (left, right),
            };
            let (first, left_count) = plan.span[left];
            let count = left_count + plan.span[right].1;
            plan.span[b] = (first, count);
            // Best cover by exactly `roots` roots split between the two children.
            let (cl, cr) = (&plan.cost[left], &plan.cost[right]);
            let mut cover = [(f32::INFINITY, 0u8); WIDTH + 1];
            for (roots, best) in cover.iter_mut().enumerate().skip(2) {
                for k in 1..roots {
                    let c = cl[k - 1] + cr[roots - k - 1];
                    if c < best.0 {
                        *best = (c, (roots << 4 | k) as u8);
                    }
                }
            }
            let as_node = NODE_COST * area + cover[WIDTH].0;
            let as_leaf = if count as usize <= MAX_LEAF {
                PACK_COST * area * pack_count(count as usize) as f32
            } else {
                f32::INFINITY
            };
            plan.node_choice[b] = cover[WIDTH].1;
            plan.as_leaf[b] = as_leaf <= as_node;
            let mut cost = [as_leaf.min(as_node); WIDTH];
            let mut choice = [0u8; WIDTH];
            for i in 1..WIDTH {
                let (c, how) = cover[i + 1];
                if c < cost[i - 1] {
                    (cost[i], choice[i]) = (c, how);
                } else {
                    (cost[i], choice[i]) = (cost[i - 1], choice[i - 1]);
                }
            }
            plan.cost[b] = cost;
            plan.choice[b] = choice;
        }
        plan
    }

    /// Appends the roots of the cover `how` (a `choice` value) of binary node `b`.
    fn cover(&self, bin: &[BinNode], b: usize, how: u8, roots: &mut Vec<usize>) {
        if how == 0 {
            roots.push(b);
            return;
        }
        let (count, left_count) = ((how >> 4) as usize, (how & 15) as usize);
        let BinKind::Inner { left, right } = bin[b].kind else {
            unreachable!("only inner nodes are covered by several roots");
        };
        self.cover(bin, left, self.choice[left][left_count - 1], roots);
        self.cover(
            bin,
            right,
            self.choice[right][count - left_count - 1],
            roots,
        );
    }

    /// The planned cost of the children of inner node `b` as a wide node (without
    /// the node's own test).
    #[cfg(feature = "bvh-experiments")]
    pub(super) fn cost_as_node(&self, bin: &[BinNode], b: usize) -> f32 {
        let how = self.node_choice[b];
        let (count, left_count) = ((how >> 4) as usize, (how & 15) as usize);
        let BinKind::Inner { left, right } = bin[b].kind else {
            unreachable!("only inner nodes become wide nodes");
        };
        self.cost[left][left_count - 1] + self.cost[right][count - left_count - 1]
    }

    /// The children (binary node indices) of inner node `b` as a wide node.
    fn node_roots(&self, bin: &[BinNode], b: usize, roots: &mut Vec<usize>) {
        self.cover(bin, b, self.node_choice[b], roots);
    }
}

/// The binary SAH tree over `boxes` (nonempty), below `top` when it is given
/// ([`WideBvh::build`]), with `bins` bins per axis on up to `threads` threads; and
/// the slot order its leaves' ranges index (slot → index into `boxes`).
pub(super) fn binary_tree(
    boxes: &[Bounds],
    top: &[TopNode],
    bins: usize,
    threads: usize,
) -> (Vec<BinNode>, Vec<u32>) {
    let boxes: Vec<BoundsA> = boxes.iter().map(BoundsA::new).collect();
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    let mut builder = BinaryBuilder::new(&boxes, &mut order, 0, bins.clamp(2, 256), threads.max(1));
    if top.is_empty() {
        let node = builder.range_bounds(0, boxes.len());
        builder.build(0, boxes.len(), 0, node);
    } else {
        builder.build_top(top, 0, 0, 0);
    }
    let nodes = builder.nodes;
    (nodes, order)
}

#[derive(Debug, Clone, Copy)]
pub(super) enum BinKind {
    Leaf { first: usize, count: usize },
    Inner { left: usize, right: usize },
}

#[derive(Debug, Clone, Copy)]
pub(super) struct BinNode {
    pub(super) bounds: Bounds,
    pub(super) kind: BinKind,
}

/// A node of a given top of the binary tree ([`WideBvh::build`]), the root first:
/// `Leaf`: the next `refs` primitives, to be built below; `Inner`: the indices of its
/// two children in the same list and its number of primitives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(in crate::accel) enum TopNode {
    Leaf {
        refs: usize,
    },
    Inner {
        left: usize,
        right: usize,
        refs: usize,
    },
}

impl TopNode {
    pub(in crate::accel) fn refs(self) -> usize {
        match self {
            TopNode::Leaf { refs } | TopNode::Inner { refs, .. } => refs,
        }
    }

    /// The same node in a list that starts `offset` entries later.
    pub(in crate::accel) fn offset(self, offset: usize) -> TopNode {
        match self {
            TopNode::Inner { left, right, refs } => TopNode::Inner {
                left: left + offset,
                right: right + offset,
                refs,
            },
            leaf => leaf,
        }
    }
}

/// Top-down binned-SAH builder of the binary tree; `order` is partitioned in place so
/// that each node's primitives are contiguous.
struct BinaryBuilder<'a> {
    /// The primitives' boxes; twice a box's centre is its `centre2` (the factor of
    /// 2 changes no decision).
    boxes: &'a [BoundsA],
    /// The part of the slot order this builder works on: slots `base..`.
    order: &'a mut [u32],
    base: usize,
    nodes: Vec<BinNode>,
    bins: usize,
    /// Threads this builder may use (itself included).
    threads: usize,
    /// Scratch of [`BinaryBuilder::sah_split`], kept between nodes: for each bin,
    /// per axis, the box and the number of its primitives; the right sweep's costs.
    bin_bounds: Vec<[BoundsA; 3]>,
    bin_count: Vec<[usize; 3]>,
    right_cost: Vec<f32>,
}

/// Fewest primitives for which a subtree is handed to another thread.
const PARALLEL_MIN: usize = 4096;

/// Relative cost of one node visit against one pack test, for the SAH.
const TRAVERSAL_COST: f32 = 1.0;

impl<'a> BinaryBuilder<'a> {
    fn new(
        boxes: &'a [BoundsA],
        order: &'a mut [u32],
        base: usize,
        bins: usize,
        threads: usize,
    ) -> BinaryBuilder<'a> {
        let capacity = 2 * order.len() / PACK + 1;
        BinaryBuilder {
            boxes,
            order,
            base,
            nodes: Vec::with_capacity(capacity),
            bins,
            threads,
            bin_bounds: vec![[BoundsA::EMPTY; 3]; bins],
            bin_count: vec![[0; 3]; bins],
            right_cost: vec![0.0; bins],
        }
    }

    /// The box and the centres' box of slots `first..first + count`.
    fn range_bounds(&self, first: usize, count: usize) -> NodeBoxes {
        let mut node = NodeBoxes::EMPTY;
        for &p in &self.order[first - self.base..first - self.base + count] {
            let b = &self.boxes[p as usize];
            node.grow(b, b.centre2());
        }
        node
    }

    /// Builds the subtree over slots `first..first + count`, whose box and centres'
    /// box are `node`; returns its node index.
    fn build(&mut self, first: usize, count: usize, depth: usize, node: NodeBoxes) -> usize {
        let NodeBoxes { bounds, centres } = node;
        let index = self.nodes.len();
        self.nodes.push(BinNode {
            bounds: bounds.bounds(),
            kind: BinKind::Leaf { first, count },
        });
        // A leaf when it fits one pack and its area is finite: then the SAH always
        // prefers it (a split costs the node's area plus its children's, which are
        // finite and not negative, a leaf its area once), so this skips binning
        // that could only confirm it.
        if count <= 1 || (count <= MAX_LEAF && bounds.half_area().is_finite()) {
            return index;
        }
        let split = if depth < MEDIAN_DEPTH {
            self.sah_split(first, count, &bounds, &centres)
        } else {
            None
        };
        let (mid, left_boxes, right_boxes) = match split {
            Some(Some(split)) => split,
            // The SAH prefers a leaf.
            Some(None) => return index,
            None if count <= MAX_LEAF => return index,
            None => self.median_split(first, count, &centres),
        };
        let (left, right) = if self.threads > 1 && count >= PARALLEL_MIN {
            self.build_both_in_parallel(
                first,
                mid,
                first + count,
                depth + 1,
                left_boxes,
                right_boxes,
            )
        } else {
            let left = self.build(first, mid - first, depth + 1, left_boxes);
            (
                left,
                self.build(mid, first + count - mid, depth + 1, right_boxes),
            )
        };
        self.nodes[index].kind = BinKind::Inner { left, right };
        index
    }

    /// Builds the subtree of `top[t]` over slots `first..`: its inner nodes as given,
    /// the SAH build below its leaves; returns its node index. Like
    /// [`BinaryBuilder::build`], it may leave this builder with fewer slots than it
    /// started with: the caller keeps the slots that come after.
    fn build_top(&mut self, top: &[TopNode], t: usize, first: usize, depth: usize) -> usize {
        let (left, right, refs) = match top[t] {
            TopNode::Leaf { refs } => {
                let node = self.range_bounds(first, refs);
                return self.build(first, refs, depth, node);
            }
            TopNode::Inner { left, right, refs } => (left, right, refs),
        };
        let index = self.nodes.len();
        self.nodes.push(BinNode {
            bounds: Bounds::empty(),
            kind: BinKind::Leaf { first, count: refs },
        });
        let mid = first + top[left].refs();
        let order = std::mem::take(&mut self.order);
        let (left_order, right_order) = order.split_at_mut(mid - self.base);
        self.order = left_order;
        let threads = self.threads;
        let (left, right) = if threads > 1 && refs >= PARALLEL_MIN {
            let half = threads / 2;
            self.threads -= half;
            let right_refs = top[right].refs();
            let mut right_builder = BinaryBuilder::new(
                self.boxes,
                &mut right_order[..right_refs],
                mid,
                self.bins,
                half,
            );
            let left = std::thread::scope(|scope| {
                let right = scope.spawn(|| right_builder.build_top(top, right, mid, depth + 1));
                let left = self.build_top(top, left, first, depth + 1);
                // A panic in the right half is a bug; re-raise it here.
                if let Err(payload) = right.join() {
                    std::panic::resume_unwind(payload);
                }
                left
            });
            (left, self.append_nodes(right_builder.nodes))
        } else {
            let left = self.build_top(top, left, first, depth + 1);
            self.order = right_order;
            self.base = mid;
            (left, self.build_top(top, right, mid, depth + 1))
        };
        self.threads = threads;
        let mut bounds = self.nodes[left].bounds;
        bounds.grow(&self.nodes[right].bounds);
        self.nodes[index] = BinNode {
            bounds,
            kind: BinKind::Inner { left, right },
        };
        index
    }

    /// Builds slots `first..mid` here and `mid..end` on a scoped thread with a builder
    /// of its own (half the threads each), then appends that builder's nodes.
    /// Afterwards this builder holds only slots up to `mid`: every caller above has
    /// finished with the slots beyond (they were its right part, or another thread's).
    fn build_both_in_parallel(
        &mut self,
        first: usize,
        mid: usize,
        end: usize,
        depth: usize,
        left_node: NodeBoxes,
        right_node: NodeBoxes,
    ) -> (usize, usize) {
        let order = std::mem::take(&mut self.order);
        let (left_order, right_order) = order.split_at_mut(mid - self.base);
        let right_order = &mut right_order[..end - mid];
        self.order = left_order;
        let half = self.threads / 2;
        self.threads -= half;
        let mut right_builder = BinaryBuilder::new(self.boxes, right_order, mid, self.bins, half);
        let left = std::thread::scope(|scope| {
            let right = scope.spawn(|| right_builder.build(mid, end - mid, depth, right_node));
            let left = self.build(first, mid - first, depth, left_node);
            // A panic in the right half is a bug; re-raise it here.
            if let Err(payload) = right.join() {
                std::panic::resume_unwind(payload);
            }
            left
        });
        (left, self.append_nodes(right_builder.nodes))
    }

    /// Appends the nodes another builder made (its root first) and returns the index
    /// of that root here: its child indices are shifted by where they land.
    fn append_nodes(&mut self, nodes: Vec<BinNode>) -> usize {
        let offset = self.nodes.len();
        self.nodes.extend(nodes.into_iter().map(|mut node| {
            if let BinKind::Inner { left, right } = &mut node.kind {
                *left += offset;
                *right += offset;
            }
            node
        }));
        offset
    }

    /// The best SAH split, partitioning `order` accordingly: `Some(Some((mid, left,
    /// right)))` (the right child starts at `mid`; the children's boxes, gathered
    /// while partitioning), `Some(None)` when a leaf is cheaper (only for at most
    /// [`MAX_LEAF`] primitives), `None` when the centroids fall into one bin.
    #[allow(clippy::type_complexity)]
    fn sah_split(
        &mut self,
        first: usize,
        count: usize,
        bounds: &BoundsA,
        centres: &BoundsA,
    ) -> Option<Option<(usize, NodeBoxes, NodeBoxes)>> {
        let bins = self.bins;
        let range = first - self.base..first - self.base + count;
        let extent = centres.max - centres.min;
        // Bin index of centroid coordinate x on axis k; scale 0 on a flat axis.
        let scale: [f32; 3] = std::array::from_fn(|k| {
            if extent[k] > 0.0 {
                bins as f32 * (1.0 - 1e-6) / extent[k]
            } else {
                0.0
            }
        });
        let scale_a = Vec3A::from(scale);
        let bin_bounds = &mut self.bin_bounds[..bins];
        let bin_count = &mut self.bin_count[..bins];
        bin_bounds.fill([BoundsA::EMPTY; 3]);
        bin_count.fill([0; 3]);
        for &p in &self.order[range.clone()] {
            let b = &self.boxes[p as usize];
            let bin = bin_indices((b.centre2() - centres.min) * scale_a, bins - 1);
            for k in 0..3 {
                bin_bounds[bin[k]][k].grow(b);
                bin_count[bin[k]][k] += 1;
            }
        }
        // Sweep from the right: area × blocks of the right part for each split.
        // An empty bin changes neither side's box nor count, so its costs are
        // those of the bin before it: copied on the right, skipped on the left
        // (an equal cost never replaces the best).
        let blocks = |n: usize| n.div_ceil(PACK) as f32;
        let mut best: Option<(f32, usize, usize)> = None;
        let right_cost = &mut self.right_cost[..bins];
        for k in 0..3 {
            if scale[k] == 0.0 {
                continue;
            }
            let (mut acc, mut n, mut cost) = (BoundsA::EMPTY, 0, 0.0);
            for i in (1..bins).rev() {
                if bin_count[i][k] != 0 {
                    acc.grow(&bin_bounds[i][k]);
                    n += bin_count[i][k];
                    cost = acc.half_area() * blocks(n);
                }
                right_cost[i] = cost;
            }
            let (mut acc, mut n) = (BoundsA::EMPTY, 0);
            for i in 0..bins - 1 {
                if bin_count[i][k] == 0 {
                    continue;
                }
                acc.grow(&bin_bounds[i][k]);
                n += bin_count[i][k];
                if n == 0 || n == count {
                    continue;
                }
                let cost = acc.half_area() * blocks(n) + right_cost[i + 1];
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, k, i + 1));
                }
            }
        }
        let (cost, axis, split_bin) = best?;
        let area = bounds.half_area();
        let split_cost = TRAVERSAL_COST * area + cost;
        let leaf_cost = area * blocks(count);
        if count <= MAX_LEAF && leaf_cost <= split_cost {
            return Some(None);
        }
        // Partition: left the centroids in bins below `split_bin`; each side's
        // boxes on the way (each primitive is classified once).
        let (low, s) = (centres.min[axis], scale[axis]);
        let boxes = self.boxes;
        let slice = &mut self.order[range];
        let (mut left, mut right) = (NodeBoxes::EMPTY, NodeBoxes::EMPTY);
        let (mut i, mut j) = (0, slice.len());
        while i < j {
            let b = &boxes[slice[i] as usize];
            let c = b.centre2();
            if bin_index((c[axis] - low) * s, bins - 1) < split_bin {
                left.grow(b, c);
                i += 1;
            } else {
                right.grow(b, c);
                j -= 1;
                slice.swap(i, j);
            }
        }
        Some(Some((first + i, left, right)))
    }

    /// Splits at the median centroid along the widest centroid axis; returns the start
    /// of the right half and the two halves' boxes.
    fn median_split(
        &mut self,
        first: usize,
        count: usize,
        centres: &BoundsA,
    ) -> (usize, NodeBoxes, NodeBoxes) {
        let extent = (centres.max - centres.min).to_array();
        let axis = (0..3)
            .max_by(|&a, &b| extent[a].total_cmp(&extent[b]))
            .unwrap_or(0);
        let half = count / 2;
        let boxes = self.boxes;
        let start = first - self.base;
        self.order[start..start + count].select_nth_unstable_by(half, |&a, &b| {
            boxes[a as usize].centre2()[axis].total_cmp(&boxes[b as usize].centre2()[axis])
        });
        let left = self.range_bounds(first, half);
        let right = self.range_bounds(first + half, count - half);
        (first + half, left, right)
    }
}
