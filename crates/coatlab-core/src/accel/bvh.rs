//! The box layer of the acceleration structure: a [`Bvh`] over primitives' boxes,
//! queried with a [`Ray`] and a closure that intersects one primitive (see the
//! module documentation of [`crate::accel`]).

use super::boxes::Bounds;
#[cfg(feature = "bvh-experiments")]
use super::obvhs_layouts::ObvhsTree;
use super::options::{BuildOptions, BvhLayout};
use super::wide::{BoxRay, TopNode, WideBvh, pack_count};
use crate::simd_path::isa::PORTABLE;
use glam::Vec3A;

/// A ray for the box-level queries ([`Bvh::closest`], [`Bvh::any`]):
/// `origin + t · direction` for `t` in `(tmin, tmax)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    pub origin: Vec3A,
    pub direction: Vec3A,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    /// The ray from `origin` along `direction` over `(tmin, tmax)`.
    pub fn new(origin: Vec3A, direction: Vec3A, tmin: f32, tmax: f32) -> Ray {
        Ray {
            origin,
            direction,
            tmin,
            tmax,
        }
    }
}

/// Why a structure could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AccelError {
    #[error("primitive {index} has a non-finite bounding box {bounds:?}")]
    NonFiniteBox { index: usize, bounds: Bounds },
    #[error("triangle {triangle} has a non-finite vertex {vertex} at {position:?}")]
    NonFiniteVertex {
        triangle: usize,
        vertex: u32,
        position: [f32; 3],
    },
    #[error(
        "triangle {triangle} refers to vertex {vertex}, but the mesh has {vertex_count} vertices"
    )]
    VertexOutOfRange {
        triangle: usize,
        vertex: u32,
        vertex_count: usize,
    },
    #[error("{count} primitives: more than a BVH with u32 indices can hold")]
    TooManyPrimitives { count: usize },
    #[error(
        "{primitives} primitives need more than the {limit} {part} that the tree's child references can address"
    )]
    TreeTooLarge {
        primitives: usize,
        part: &'static str,
        limit: usize,
    },
}

/// The tree of a [`Bvh`], by layout.
#[derive(Clone)]
pub(super) enum Tree {
    Empty,
    Simd8(WideBvh),
    #[cfg(feature = "bvh-experiments")]
    Obvhs(ObvhsTree),
}

/// A bounding volume hierarchy over boxes; see the module documentation of
/// [`crate::accel`].
#[derive(Clone)]
pub struct Bvh {
    pub(super) tree: Tree,
    options: BuildOptions,
    bounds: Option<Bounds>,
}

impl std::fmt::Debug for Bvh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bvh")
            .field("options", &self.options)
            .field("primitives", &self.len())
            .field("nodes", &self.node_count())
            .field("bounds", &self.bounds)
            .finish()
    }
}

impl Bvh {
    /// Builds the tree over `boxes` (one per primitive; empty or flat boxes are fine,
    /// non-finite ones are refused).
    pub fn build(boxes: &[Bounds], options: &BuildOptions) -> Result<Bvh, AccelError> {
        Bvh::build_below(boxes, &[], options)
    }

    /// [`Bvh::build`] below a given top of the tree (`Simd8` only, else ignored; see
    /// [`WideBvh::build`]).
    pub(super) fn build_below(
        boxes: &[Bounds],
        top: &[TopNode],
        options: &BuildOptions,
    ) -> Result<Bvh, AccelError> {
        if u32::try_from(boxes.len()).is_err() {
            return Err(AccelError::TooManyPrimitives { count: boxes.len() });
        }
        if let Some(index) = boxes.iter().position(|b| !b.is_finite()) {
            return Err(AccelError::NonFiniteBox {
                index,
                bounds: boxes[index],
            });
        }
        let mut bounds: Option<Bounds> = None;
        for b in boxes {
            bounds = Some(match bounds {
                None => *b,
                Some(acc) => Bounds::from_points(&[acc.min, acc.max, b.min, b.max]).unwrap_or(acc),
            });
        }
        if boxes.is_empty() {
            return Ok(Bvh {
                tree: Tree::Empty,
                options: *options,
                bounds: None,
            });
        }
        match options.layout {
            BvhLayout::Simd8 => Ok(Bvh {
                tree: Tree::Simd8(
                    WideBvh::build(
                        boxes,
                        top,
                        options.quality.sah_bins(),
                        options.build_threads(),
                    )
                    .map_err(|e| AccelError::TreeTooLarge {
                        primitives: boxes.len(),
                        part: e.part,
                        limit: e.limit,
                    })?,
                ),
                options: *options,
                bounds,
            }),
            #[cfg(feature = "bvh-experiments")]
            BvhLayout::Wide8 | BvhLayout::Binary => {
                let (tree, layout) = ObvhsTree::build(boxes, options);
                Ok(Bvh {
                    tree: Tree::Obvhs(tree),
                    options: BuildOptions { layout, ..*options },
                    bounds,
                })
            }
        }
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.primitive_order().len()
    }

    /// Whether the tree holds no primitive.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of tree nodes (8-wide or binary, per the layout).
    pub fn node_count(&self) -> usize {
        match &self.tree {
            Tree::Empty => 0,
            Tree::Simd8(t) => t.node_count(),
            #[cfg(feature = "bvh-experiments")]
            Tree::Obvhs(t) => t.node_count(),
        }
    }

    /// The options it was built with.
    pub fn options(&self) -> BuildOptions {
        self.options
    }

    /// Bounds of all primitives; `None` when empty.
    pub fn bounds(&self) -> Option<Bounds> {
        self.bounds
    }

    /// The caller's primitive index for each slot.
    pub fn primitive_order(&self) -> &[u32] {
        match &self.tree {
            Tree::Empty => &[],
            Tree::Simd8(t) => t.order(),
            #[cfg(feature = "bvh-experiments")]
            Tree::Obvhs(t) => t.primitive_order(),
        }
    }

    /// Closest hit: `intersect(ray, slot)` returns the hit distance of that primitive
    /// within `(ray.tmin, ray.tmax)` or `f32::INFINITY`; `ray.tmax` shrinks as hits are
    /// found. Returns the slot and distance of the closest hit.
    #[inline]
    pub fn closest<F: FnMut(&Ray, usize) -> f32>(
        &self,
        ray: Ray,
        intersect: F,
    ) -> Option<(usize, f32)> {
        match &self.tree {
            Tree::Empty => None,
            Tree::Simd8(t) => simd8_closest(t, ray, intersect),
            #[cfg(feature = "bvh-experiments")]
            Tree::Obvhs(t) => t.closest(ray.into(), obvhs_intersect(intersect)),
        }
    }

    /// Any hit: whether some primitive reports a distance below `ray.tmax`; stops at the
    /// first one.
    #[inline]
    pub fn any<F: FnMut(&Ray, usize) -> f32>(&self, ray: Ray, intersect: F) -> bool {
        match &self.tree {
            Tree::Empty => false,
            Tree::Simd8(t) => simd8_any(t, ray, intersect),
            #[cfg(feature = "bvh-experiments")]
            Tree::Obvhs(t) => t.any(ray.into(), obvhs_intersect(intersect)),
        }
    }

    /// Checks the tree against the boxes it was built from: every node reached once,
    /// every child box inside its parent, every primitive's box inside its leaf, the
    /// depth within what the traversal handles (for the obvhs layouts, obvhs's own
    /// validation), plus that the slots are a permutation of the primitives and that
    /// [`Bvh::bounds`] holds every box.
    pub fn validate(&self, boxes: &[Bounds]) -> Result<(), String> {
        let order = self.primitive_order();
        if order.len() != boxes.len() {
            return Err(format!(
                "the tree holds {} primitives, but {} boxes were given",
                order.len(),
                boxes.len()
            ));
        }
        let mut seen = vec![false; boxes.len()];
        for (slot, &index) in order.iter().enumerate() {
            match seen.get_mut(index as usize) {
                None => {
                    return Err(format!(
                        "slot {slot} refers to primitive {index}, out of range"
                    ));
                }
                Some(true) => return Err(format!("primitive {index} appears in two slots")),
                Some(s) => *s = true,
            }
        }
        match (self.bounds, boxes.is_empty()) {
            (None, true) => {}
            (None, false) => return Err("no bounds, but primitives".into()),
            (Some(_), true) => return Err("bounds, but no primitives".into()),
            (Some(bounds), false) => {
                if let Some(i) = boxes.iter().position(|b| !bounds.contains(b)) {
                    return Err(format!("primitive {i}'s box lies outside the bounds"));
                }
            }
        }
        match &self.tree {
            Tree::Empty => Ok(()),
            Tree::Simd8(t) => t.validate(boxes, self.bounds),
            #[cfg(feature = "bvh-experiments")]
            Tree::Obvhs(t) => t.validate(boxes),
        }
    }
}

/// [`Bvh::closest`] on the `Simd8` tree, one slot at a time.
fn simd8_closest<F: FnMut(&Ray, usize) -> f32>(
    tree: &WideBvh,
    mut ray: Ray,
    mut intersect: F,
) -> Option<(usize, f32)> {
    let box_ray = BoxRay::new(ray.origin.into(), ray.direction.into());
    let mut best = None;
    // The box layer's generic queries (tests, picking) run the portable code: the
    // caller's closure is not compiled for a SIMD path.
    tree.nodes().closest::<PORTABLE>(
        &box_ray,
        ray.tmax,
        |first, count, t_max| {
            ray.tmax = t_max;
            for slots in &tree.pack_slots()[first..first + pack_count(count)] {
                for &slot in slots.iter().filter(|&&s| s != u32::MAX) {
                    let t = intersect(&ray, slot as usize);
                    if t < ray.tmax {
                        ray.tmax = t;
                        best = Some((slot as usize, t));
                    }
                }
            }
            ray.tmax
        },
        |_, _| {},
    );
    best
}

/// [`Bvh::any`] on the `Simd8` tree, one slot at a time.
fn simd8_any<F: FnMut(&Ray, usize) -> f32>(tree: &WideBvh, ray: Ray, mut intersect: F) -> bool {
    let box_ray = BoxRay::new(ray.origin.into(), ray.direction.into());
    tree.nodes().any::<PORTABLE>(
        &box_ray,
        ray.tmax,
        |first, count| {
            tree.pack_slots()[first..first + pack_count(count)]
                .iter()
                .flatten()
                .any(|&slot| slot != u32::MAX && intersect(&ray, slot as usize) < ray.tmax)
        },
        |_, _| {},
    )
}

/// obvhs's ray for ours (the obvhs layouts' traversal).
#[cfg(feature = "bvh-experiments")]
impl From<Ray> for obvhs::ray::Ray {
    fn from(ray: Ray) -> obvhs::ray::Ray {
        obvhs::ray::Ray::new(ray.origin, ray.direction, ray.tmin, ray.tmax)
    }
}

/// A primitive test over our ray as one over obvhs's.
#[cfg(feature = "bvh-experiments")]
#[inline(always)]
fn obvhs_intersect<F: FnMut(&Ray, usize) -> f32>(
    mut intersect: F,
) -> impl FnMut(&obvhs::ray::Ray, usize) -> f32 {
    move |ray, slot| {
        let ours = Ray::new(ray.origin, ray.direction, ray.tmin, ray.tmax);
        intersect(&ours, slot)
    }
}
