//! The collapse the SAH plan replaced: each wide node's children found by opening
//! the binary child with the largest surface area until there are 8. Kept (feature
//! `bvh-experiments`) to measure the plan against it: [`compare_collapses`].

use super::super::boxes::Bounds;
use super::build::{BinKind, BinNode, CollapsePlan, NODE_COST, PACK_COST, binary_tree};
use super::{
    EMPTY, LEAF_BIT, MAX_LEAF, Node, TreeTooLarge, WIDTH, WideBvh, leaf_parts, pack_count,
};

impl WideBvh {
    /// The collapse before the SAH plan: opens the largest inner child until there
    /// are 8 children or only leaves.
    fn collapse_largest(&mut self, bin: &[BinNode], b: usize) -> Result<u32, TreeTooLarge> {
        let (index, reference) = self.reserve_node()?;
        // Open the largest inner child until there are 8 children or only leaves.
        let mut kids = [0usize; WIDTH];
        let mut n = 0;
        if let BinKind::Inner { left, right } = bin[b].kind {
            kids[0] = left;
            kids[1] = right;
            n = 2;
        }
        while n < WIDTH {
            let mut largest: Option<(usize, f32)> = None;
            for (i, &k) in kids[..n].iter().enumerate() {
                if let BinKind::Inner { .. } = bin[k].kind {
                    let area = bin[k].bounds.half_area();
                    if largest.is_none_or(|(_, a)| area > a) {
                        largest = Some((i, area));
                    }
                }
            }
            let Some((i, _)) = largest else { break };
            if let BinKind::Inner { left, right } = bin[kids[i]].kind {
                kids[i] = left;
                kids[n] = right;
                n += 1;
            }
        }
        let mut node = Node::empty();
        for (i, &k) in kids[..n].iter().enumerate() {
            node.set_bounds(i, &bin[k].bounds);
            node.child[i] = match bin[k].kind {
                BinKind::Leaf { first, count } => self.leaf_child(first, count)?,
                BinKind::Inner { .. } => self.collapse_largest(bin, k)?,
            };
        }
        self.nodes[index] = node;
        Ok(reference)
    }
}

/// The costs of the two collapses of one binary tree ([`compare_collapses`]): the
/// expected SAH cost of a ray's node and pack tests, relative to a ray through the
/// root's box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CollapseCosts {
    /// The tree collapsed by the SAH plan.
    pub sah: f64,
    /// What the plan computed for that tree, from the binary tree's unwidened boxes.
    pub planned: f64,
    /// The tree collapsed by opening the largest child.
    pub largest_child: f64,
    /// Nodes of the two trees.
    pub sah_nodes: usize,
    pub largest_child_nodes: usize,
}

/// Builds the `Simd8` tree over `boxes` (finite, at least one) from one binary SAH
/// tree (`bins` bins per axis, `threads` threads) collapsed twice, by the SAH plan
/// and by opening the largest child; checks both (they validate, hold the same slot
/// order, and have the shape the collapse promises: every node below the root at
/// least 2 children, every leaf one pack) and returns their costs.
pub fn compare_collapses(
    boxes: &[Bounds],
    bins: usize,
    threads: usize,
) -> Result<CollapseCosts, String> {
    let mut bounds = Bounds::empty();
    boxes.iter().for_each(|b| bounds.grow(b));
    let too_large = |e: TreeTooLarge| format!("more than {} {}", e.limit, e.part);
    let sah = WideBvh::build(boxes, &[], bins, threads).map_err(too_large)?;
    let largest = WideBvh::build_collapsed(boxes, &[], bins, threads, |wide, bin| {
        wide.collapse_largest(bin, 0).map(|_| ())
    })
    .map_err(too_large)?;
    sah.validate(boxes, Some(bounds))
        .map_err(|e| format!("SAH collapse: {e}"))?;
    largest
        .validate(boxes, Some(bounds))
        .map_err(|e| format!("largest-child collapse: {e}"))?;
    if sah.order != largest.order {
        return Err("the two collapses were built from different binary trees".into());
    }
    // The plan's own figure for the root.
    let (bin, _) = binary_tree(boxes, &[], bins, threads);
    let plan = CollapsePlan::new(&bin);
    let root = &bin[0].bounds;
    let planned = (f64::from(NODE_COST * root.half_area()) + f64::from(plan.cost_as_node(&bin, 0)))
        / f64::from(root.half_area());
    Ok(CollapseCosts {
        sah: sah_cost(&sah)?,
        planned,
        largest_child: sah_cost(&largest)?,
        sah_nodes: sah.nodes.len(),
        largest_child_nodes: largest.nodes.len(),
    })
}

/// The collapse's SAH cost of a built tree, from its stored child boxes: node tests
/// weighted by each node's box (the union of its children), pack tests by each
/// leaf's box, relative to the root's box. Checks the shape the collapse promises:
/// every node below the root has at least 2 children (a node of one child would be
/// a wasted step) and every leaf one pack.
fn sah_cost(tree: &WideBvh) -> Result<f64, String> {
    let area = |b: &Bounds| f64::from(b.half_area());
    let mut total = 0.0;
    let mut root_area = 0.0;
    for (index, node) in tree.nodes.iter().enumerate() {
        let mut union = Bounds::empty();
        let mut children = 0;
        for i in 0..WIDTH {
            if node.child[i] == EMPTY {
                continue;
            }
            children += 1;
            let b = node.child_bounds(i);
            union.grow(&b);
            if node.child[i] & LEAF_BIT != 0 {
                let (_, count) = leaf_parts(node.child[i]);
                if !(1..=MAX_LEAF).contains(&count) {
                    return Err(format!("node {index}: leaf of {count}"));
                }
                total += f64::from(PACK_COST) * area(&b) * pack_count(count) as f64;
            }
        }
        if index != 0 && children < 2 {
            return Err(format!("node {index}: {children} children"));
        }
        total += f64::from(NODE_COST) * area(&union);
        if index == 0 {
            root_area = area(&union);
        }
    }
    Ok(total / root_area)
}
