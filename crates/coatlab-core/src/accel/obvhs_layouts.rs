//! obvhs's layouts, kept to compare ours against (feature `bvh-experiments`): the
//! compressed 8-wide `CwBvh` (`Wide8`) and the binary `Bvh2` (`Binary`), with
//! obvhs's build presets, traversal and validation. (The triangle layer goes
//! through them slot by slot, see `Accel::closest_hit_by_slot`.)

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::time::Duration;

use obvhs::{
    BvhBuildParams,
    aabb::Aabb,
    bvh2::{Bvh2, builder::build_bvh2, reinsertion::ReinsertionOptimizer},
    cwbvh::{CwBvh, bvh2_to_cwbvh::bvh2_to_cwbvh},
    ploc::PlocBuilder,
    ray::{Ray, RayHit},
};

use super::boxes::Bounds;
use super::options::{BuildOptions, BuildQuality, BvhLayout};

/// A tree of one of obvhs's layouts.
#[derive(Clone)]
pub(super) enum ObvhsTree {
    Wide(CwBvh),
    Binary(Bvh2),
}

impl ObvhsTree {
    /// Builds `options.layout` (`Wide8` or `Binary`) over `boxes` (finite, at least
    /// one); returns the tree and its layout, which is `Binary` where a `Wide8` tree
    /// would be too deep for obvhs's 8-wide traversal.
    pub(super) fn build(boxes: &[Bounds], options: &BuildOptions) -> (ObvhsTree, BvhLayout) {
        let aabbs: Vec<Aabb> = boxes.iter().map(aabb).collect();
        let params = params(options.quality);
        let wide = match options.layout {
            BvhLayout::Wide8 => build_wide(&aabbs, &params),
            BvhLayout::Binary | BvhLayout::Simd8 => None,
        };
        match wide {
            Some(wide) => (ObvhsTree::Wide(wide), BvhLayout::Wide8),
            None => {
                let mut core_time = Duration::ZERO;
                (
                    ObvhsTree::Binary(build_bvh2(&aabbs, params, &mut core_time)),
                    BvhLayout::Binary,
                )
            }
        }
    }

    pub(super) fn node_count(&self) -> usize {
        match self {
            ObvhsTree::Wide(t) => t.nodes.len(),
            ObvhsTree::Binary(t) => t.nodes.len(),
        }
    }

    pub(super) fn primitive_order(&self) -> &[u32] {
        match self {
            ObvhsTree::Wide(t) => &t.primitive_indices,
            ObvhsTree::Binary(t) => &t.primitive_indices,
        }
    }

    /// `Bvh::closest` (on obvhs's ray).
    #[inline]
    pub(super) fn closest<F: FnMut(&Ray, usize) -> f32>(
        &self,
        ray: Ray,
        intersect: F,
    ) -> Option<(usize, f32)> {
        let mut hit = RayHit::none();
        let found = match self {
            ObvhsTree::Wide(t) => t.ray_traverse(ray, &mut hit, intersect),
            ObvhsTree::Binary(t) => t.ray_traverse(ray, &mut hit, intersect),
        };
        found.then_some((hit.primitive_id as usize, hit.t))
    }

    /// `Bvh::any` (on obvhs's ray).
    #[inline]
    pub(super) fn any<F: FnMut(&Ray, usize) -> f32>(&self, ray: Ray, intersect: F) -> bool {
        match self {
            ObvhsTree::Wide(t) => !t.ray_traverse_miss(ray, intersect),
            ObvhsTree::Binary(t) => !t.ray_traverse_miss(ray, intersect),
        }
    }

    /// obvhs's own validation (every node reached once, every child box inside its
    /// parent, every primitive's box inside its leaf, depth within the traversal
    /// stack), its failed assertions turned into errors.
    pub(super) fn validate(&self, boxes: &[Bounds]) -> Result<(), String> {
        let aabbs: Vec<Aabb> = boxes.iter().map(aabb).collect();
        let checked = catch_unwind(AssertUnwindSafe(|| match self {
            ObvhsTree::Wide(t) => {
                t.validate(&aabbs, false);
            }
            ObvhsTree::Binary(t) => {
                t.validate(&aabbs, false, false);
            }
        }));
        checked.map_err(|payload| {
            let message = payload
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "unknown failure".into());
            format!("obvhs validation failed: {message}")
        })
    }
}

fn aabb(b: &Bounds) -> Aabb {
    Aabb::new(b.min.into(), b.max.into())
}

/// obvhs's preset for each quality.
fn params(quality: BuildQuality) -> BvhBuildParams {
    match quality {
        BuildQuality::Fastest => BvhBuildParams::fastest_build(),
        BuildQuality::Fast => BvhBuildParams::fast_build(),
        BuildQuality::Medium => BvhBuildParams::medium_build(),
        BuildQuality::Slow => BvhBuildParams::slow_build(),
    }
}

/// Depth limit of obvhs's 8-wide traversal stack (`TRAVERSAL_STACK_SIZE`, private).
const WIDE_STACK: u32 = 32;

/// obvhs's `build_cwbvh` without its debug-build validation (which asserts), and
/// `None` when the tree is too deep for the traversal stack.
fn build_wide(aabbs: &[Aabb], params: &BvhBuildParams) -> Option<CwBvh> {
    let mut bvh2 = PlocBuilder::with_capacity(aabbs.len()).build(
        params.ploc_search_distance,
        aabbs,
        (0..aabbs.len() as u32).collect(),
        params.sort_precision,
        params.search_depth_threshold,
    );
    ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
    let wide = bvh2_to_cwbvh(&bvh2, params.max_prims_per_leaf.clamp(1, 3), true, false);
    (wide_depth(&wide) < WIDE_STACK).then_some(wide)
}

/// Deepest inner node of an 8-wide tree, the root at 0 (as obvhs's validation counts).
fn wide_depth(tree: &CwBvh) -> u32 {
    let mut deepest = 0;
    let mut stack = vec![(0u32, 0u32)];
    while let Some((index, depth)) = stack.pop() {
        deepest = deepest.max(depth);
        let Some(node) = tree.nodes.get(index as usize) else {
            continue;
        };
        for child in 0..8 {
            if !node.is_child_empty(child) && !node.is_leaf(child) {
                stack.push((node.child_node_index(child), depth + 1));
            }
        }
    }
    deepest
}
