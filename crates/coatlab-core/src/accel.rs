//! The acceleration structure for the tracer: a BVH over the scene's triangles.
//!
//! Two layers, as in obvhs, which does the building and the node traversal:
//! - [`Bvh`] knows nothing about geometry. It is built from boxes ([`Bounds`]) and
//!   traversed with a closure that intersects one primitive, so the same structure
//!   serves shading rays, shadow rays and picking. Primitives are addressed by *slot*
//!   (their position in the tree's leaf order); [`Bvh::primitive_order`] maps a slot to
//!   the caller's index, and callers store their primitives in slot order so the
//!   closure reads memory sequentially.
//! - [`Accel`] is the triangle layer the tracer uses: a [`Bvh`] over a
//!   [`TriangleMesh`] plus the triangles copied in slot order, with
//!   [`Accel::closest_hit`] (shading rays, picking) and [`Accel::occluded`] (any hit,
//!   for shadow rays).
//!
//! The default is obvhs's compressed 8-wide BVH (`CwBvh`) built with its `fast_build`
//! preset; `docs/benchmarks.md` ("Acceleration structure") has the measurements
//! behind that choice against its binary `Bvh2` and the other presets.
//!
//! # Rays and the epsilon policy
//!
//! A ray is `origin + t · dir` for `t` in the open interval `(0, t_max)`; `t` is in
//! units of `|dir|` (metres for a unit `dir`). `dir` need not be normalised but must be
//! finite and non-zero; a ray with a non-finite origin or direction, or `t_max` that is
//! not positive (NaN included), hits nothing. The triangle test is Möller–Trumbore in
//! The triangle test is the watertight one of Woop, Benthin and Wald ("Watertight
//! Ray/Triangle Intersection", JCGT 2013) in f32, without backface culling: the
//! vertices are moved into a frame where the ray is the +z axis and the three 2-D
//! edge functions decide inside/outside, recomputed in f64 when one is exactly zero.
//! A ray through an edge or vertex shared by two triangles hits at least one of
//! them. Möller–Trumbore was tried first and is not good enough here: a ray 1.4·10⁻⁶
//! (barycentric) inside a torus's triangle 1.35 m away missed both triangles of the
//! edge, even with edges widened by 10⁻⁶, because `origin − v0` loses the digits that
//! matter (the tests keep that ray).
//!
//! The accel adds **no** self-intersection epsilon: a hit at `t > 0` counts, however
//! small. A secondary ray (bounce or shadow) leaving a surface must start off it:
//! the tracer moves the hit point along the geometric normal with
//! [`offset_ray_origin`] (the integer-ulp offset of Wächter and Binder, "A Fast and
//! Robust Method for Avoiding Self-Intersection", Ray Tracing Gems ch. 6), which is
//! scale-independent and so works for a 4.5 m car and for coordinates of 10⁶ m alike.
//! A shadow ray towards a point on another surface should shorten `t_max` likewise (or
//! offset that end too).
//!
//! # Degenerate input
//!
//! Non-finite positions are refused with the triangle's index ([`AccelError`]).
//! Zero-area triangles (edge cross product exactly zero in f32) can never be hit and
//! are left out of the tree ([`Accel::skipped_degenerate`] counts them): a cluster of
//! them at one point would otherwise make the tree deep. An empty mesh (or one of only
//! degenerate triangles) gives an empty accel whose queries miss.
//!
//! obvhs's 8-wide traversal has a fixed stack of 32 entries and silently loses nodes
//! beyond it, so a `Wide8` tree of depth 32 or more (many coincident triangles) is
//! rebuilt as `Binary`, whose stack grows; [`Bvh::options`] then reports `Binary`.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::time::Duration;

use glam::{Mat3A, Vec3A};
use obvhs::{
    BvhBuildParams,
    aabb::Aabb,
    bvh2::{Bvh2, builder::build_bvh2, reinsertion::ReinsertionOptimizer},
    cwbvh::{CwBvh, bvh2_to_cwbvh::bvh2_to_cwbvh},
    ploc::PlocBuilder,
    ray::RayHit,
};

use crate::scene::TriangleMesh;

pub use obvhs::ray::Ray;

/// An axis-aligned box, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    pub min: [f32; 3],
    pub max: [f32; 3],
}

impl Bounds {
    /// The smallest box holding all `points`; `None` for none.
    pub fn from_points(points: &[[f32; 3]]) -> Option<Bounds> {
        let first = *points.first()?;
        let mut bounds = Bounds {
            min: first,
            max: first,
        };
        for p in &points[1..] {
            bounds.min = std::array::from_fn(|k| bounds.min[k].min(p[k]));
            bounds.max = std::array::from_fn(|k| bounds.max[k].max(p[k]));
        }
        Some(bounds)
    }

    /// Whether all six coordinates are finite.
    pub fn is_finite(&self) -> bool {
        self.min.iter().chain(&self.max).all(|x| x.is_finite())
    }

    /// Whether `other` lies inside this box (boundaries included).
    pub fn contains(&self, other: &Bounds) -> bool {
        (0..3).all(|k| self.min[k] <= other.min[k] && other.max[k] <= self.max[k])
    }

    fn to_aabb(self) -> Aabb {
        Aabb::new(self.min.into(), self.max.into())
    }
}

/// Tree layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BvhLayout {
    /// obvhs's compressed wide BVH: 8 children per 80-byte node, child boxes quantised
    /// to 8 bits, traversed 4 boxes at a time with SIMD; up to 3 triangles per leaf.
    Wide8,
    /// obvhs's binary BVH (one box per node, up to 8 triangles per leaf after the
    /// collapse pass). Simpler, and editable in place, but slower to traverse.
    Binary,
}

/// Build quality: obvhs's presets. Slower builds give trees that traverse faster.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BuildQuality {
    /// PLOC with the smallest search radius, no reinsertion, one primitive per leaf.
    Fastest,
    /// PLOC search radius "low", 2 % reinsertion: the interactive default.
    Fast,
    /// PLOC search radius "medium", 5 % reinsertion ("about Embree's build time").
    Medium,
    /// PLOC search radius "high", 20 % reinsertion, 128-bit Morton codes (spatial
    /// pre-splits of the preset are not used: the builder sees boxes, not triangles).
    Slow,
}

impl BuildQuality {
    fn params(self) -> BvhBuildParams {
        match self {
            BuildQuality::Fastest => BvhBuildParams::fastest_build(),
            BuildQuality::Fast => BvhBuildParams::fast_build(),
            BuildQuality::Medium => BvhBuildParams::medium_build(),
            BuildQuality::Slow => BvhBuildParams::slow_build(),
        }
    }
}

/// How to build a [`Bvh`]. The build runs on rayon's current thread pool.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BuildOptions {
    pub layout: BvhLayout,
    pub quality: BuildQuality,
}

impl Default for BuildOptions {
    /// `Wide8` with `Fast`: see docs/benchmarks.md, "Acceleration structure".
    fn default() -> Self {
        BuildOptions {
            layout: BvhLayout::Wide8,
            quality: BuildQuality::Fast,
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
}

#[derive(Clone)]
enum Tree {
    Empty,
    Wide(CwBvh),
    Binary(Bvh2),
}

/// A bounding volume hierarchy over boxes; see the module documentation.
#[derive(Clone)]
pub struct Bvh {
    tree: Tree,
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
        let aabbs: Vec<Aabb> = boxes.iter().map(|b| b.to_aabb()).collect();
        let params = options.quality.params();
        let mut core_time = Duration::ZERO;
        let wide = match options.layout {
            BvhLayout::Wide8 => build_wide(&aabbs, &params),
            BvhLayout::Binary => None,
        };
        let (tree, layout) = match wide {
            Some(wide) => (Tree::Wide(wide), BvhLayout::Wide8),
            None => (
                Tree::Binary(build_bvh2(&aabbs, params, &mut core_time)),
                BvhLayout::Binary,
            ),
        };
        Ok(Bvh {
            tree,
            options: BuildOptions {
                layout,
                quality: options.quality,
            },
            bounds,
        })
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
            Tree::Wide(t) => t.nodes.len(),
            Tree::Binary(t) => t.nodes.len(),
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
            Tree::Wide(t) => &t.primitive_indices,
            Tree::Binary(t) => &t.primitive_indices,
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
        let mut hit = RayHit::none();
        let found = match &self.tree {
            Tree::Empty => false,
            Tree::Wide(t) => t.ray_traverse(ray, &mut hit, intersect),
            Tree::Binary(t) => t.ray_traverse(ray, &mut hit, intersect),
        };
        found.then_some((hit.primitive_id as usize, hit.t))
    }

    /// Any hit: whether some primitive reports a distance below `ray.tmax`; stops at the
    /// first one.
    #[inline]
    pub fn any<F: FnMut(&Ray, usize) -> f32>(&self, ray: Ray, intersect: F) -> bool {
        match &self.tree {
            Tree::Empty => false,
            Tree::Wide(t) => !t.ray_traverse_miss(ray, intersect),
            Tree::Binary(t) => !t.ray_traverse_miss(ray, intersect),
        }
    }

    /// Checks the tree against the boxes it was built from: obvhs's own validation
    /// (every node reached once, every child box inside its parent, every primitive's
    /// box inside its leaf, depth within the traversal stack), plus that the slots are
    /// a permutation of the primitives and that [`Bvh::bounds`] holds every box.
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
        let aabbs: Vec<Aabb> = boxes.iter().map(|b| b.to_aabb()).collect();
        // obvhs's validation asserts; turn a failed assertion into an error.
        let checked = catch_unwind(AssertUnwindSafe(|| match &self.tree {
            Tree::Empty => {}
            Tree::Wide(t) => {
                t.validate(&aabbs, false);
            }
            Tree::Binary(t) => {
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

/// A ray's hit on a triangle of the mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance along the ray, in units of `|dir|`.
    pub t: f32,
    /// Index into `mesh.triangles`.
    pub triangle: u32,
    /// Weights (u, v) of the triangle's second and third vertex; the first has
    /// 1 − u − v.
    pub barycentric: [f32; 2],
}

/// The triangle mesh's acceleration structure; see the module documentation.
#[derive(Debug, Clone)]
pub struct Accel {
    bvh: Bvh,
    /// Triangle vertices in slot order.
    triangles: Vec<[Vec3A; 3]>,
    /// Index into `mesh.triangles` of each slot.
    mesh_triangle: Vec<u32>,
    /// Zero-area triangles left out.
    skipped_degenerate: usize,
}

/// One triangle's box, for the builder and obvhs's validation.
fn triangle_bounds(t: &[Vec3A; 3]) -> Bounds {
    Bounds {
        min: t[0].min(t[1]).min(t[2]).into(),
        max: t[0].max(t[1]).max(t[2]).into(),
    }
}

impl Accel {
    /// Builds with the default options ([`BuildOptions::default`]).
    pub fn build(mesh: &TriangleMesh) -> Result<Accel, AccelError> {
        Accel::build_with(mesh, &BuildOptions::default())
    }

    /// Builds with the given layout and quality.
    pub fn build_with(mesh: &TriangleMesh, options: &BuildOptions) -> Result<Accel, AccelError> {
        let vertex_count = mesh.positions.len();
        let mut triangles = Vec::with_capacity(mesh.triangles.len());
        let mut kept = Vec::with_capacity(mesh.triangles.len());
        for (triangle, indices) in mesh.triangles.iter().enumerate() {
            let mut vertices = [Vec3A::ZERO; 3];
            for (v, &vertex) in vertices.iter_mut().zip(indices) {
                let Some(&position) = mesh.positions.get(vertex as usize) else {
                    return Err(AccelError::VertexOutOfRange {
                        triangle,
                        vertex,
                        vertex_count,
                    });
                };
                if !position.iter().all(|x| x.is_finite()) {
                    return Err(AccelError::NonFiniteVertex {
                        triangle,
                        vertex,
                        position,
                    });
                }
                *v = Vec3A::from(position);
            }
            let [a, b, c] = vertices;
            if (b - a).cross(c - a) != Vec3A::ZERO {
                triangles.push(vertices);
                kept.push(triangle as u32);
            }
        }
        let boxes: Vec<Bounds> = triangles.iter().map(triangle_bounds).collect();
        let bvh = Bvh::build(&boxes, options)?;
        let order = bvh.primitive_order();
        Ok(Accel {
            triangles: order.iter().map(|&i| triangles[i as usize]).collect(),
            mesh_triangle: order.iter().map(|&i| kept[i as usize]).collect(),
            skipped_degenerate: mesh.triangles.len() - kept.len(),
            bvh,
        })
    }

    /// The underlying tree.
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Number of triangles in the tree.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Number of the mesh's zero-area triangles left out of the tree.
    pub fn skipped_degenerate(&self) -> usize {
        self.skipped_degenerate
    }

    /// Bounds of the mesh's triangles; `None` when empty.
    pub fn bounds(&self) -> Option<Bounds> {
        self.bvh.bounds()
    }

    /// The closest triangle hit by `origin + t · dir` for `t` in `(0, t_max)`; see the
    /// module documentation for the epsilon policy. For shading rays and picking.
    #[inline]
    pub fn closest_hit(&self, origin: [f32; 3], dir: [f32; 3], t_max: f32) -> Option<Hit> {
        let ray = make_ray(origin, dir, t_max)?;
        let sheared = ShearedRay::new(ray.origin, ray.direction);
        let (slot, t) = self.bvh.closest(ray, |ray, slot| {
            sheared.intersect(&self.triangles[slot], ray.tmax).0
        })?;
        // Barycentrics only for the winner.
        let (_, u, v) = sheared.intersect(&self.triangles[slot], ray.tmax);
        Some(Hit {
            t,
            triangle: self.mesh_triangle[slot],
            barycentric: [u, v],
        })
    }

    /// Whether anything lies on `origin + t · dir` for `t` in `(0, t_max)`: the any-hit
    /// query for shadow rays. Agrees with `closest_hit(..).is_some()`.
    #[inline]
    pub fn occluded(&self, origin: [f32; 3], dir: [f32; 3], t_max: f32) -> bool {
        let Some(ray) = make_ray(origin, dir, t_max) else {
            return false;
        };
        let sheared = ShearedRay::new(ray.origin, ray.direction);
        self.bvh.any(ray, |ray, slot| {
            sheared.intersect(&self.triangles[slot], ray.tmax).0
        })
    }

    /// Checks the tree ([`Bvh::validate`]) against the triangles' boxes.
    pub fn validate(&self) -> Result<(), String> {
        // Back from slot order to mesh order, as the tree was built.
        let order = self.bvh.primitive_order();
        if order.len() != self.triangles.len() {
            return Err(format!(
                "{} triangles but {} slots",
                self.triangles.len(),
                order.len()
            ));
        }
        let mut boxes = vec![
            Bounds {
                min: [0.0; 3],
                max: [0.0; 3],
            };
            order.len()
        ];
        for (slot, &index) in order.iter().enumerate() {
            let b = boxes
                .get_mut(index as usize)
                .ok_or_else(|| format!("slot {slot} refers to triangle {index}, out of range"))?;
            *b = triangle_bounds(&self.triangles[slot]);
        }
        self.bvh.validate(&boxes)
    }
}

/// The obvhs ray for a query, or `None` for a ray that can hit nothing.
#[inline]
fn make_ray(origin: [f32; 3], dir: [f32; 3], t_max: f32) -> Option<Ray> {
    let origin = Vec3A::from(origin);
    let dir = Vec3A::from(dir);
    // `t_max > 0` is false for NaN.
    let usable_t_max = t_max > 0.0;
    if !usable_t_max || !origin.is_finite() || !dir.is_finite() || dir == Vec3A::ZERO {
        return None;
    }
    Some(Ray::new(origin, dir, 0.0, t_max))
}

/// A ray prepared for the watertight test: `to_ray_space` maps `v − origin` to a frame
/// in which the ray runs along +z with `z = t` (permuted so the largest direction
/// component is z, then sheared).
struct ShearedRay {
    origin: Vec3A,
    to_ray_space: Mat3A,
}

impl ShearedRay {
    #[inline(always)]
    fn new(origin: Vec3A, dir: Vec3A) -> ShearedRay {
        let kz = dir.abs().max_position();
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Keep the winding (the sign of the edge functions) independent of the axis.
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let (sx, sy, sz) = (dir[kx] / dir[kz], dir[ky] / dir[kz], 1.0 / dir[kz]);
        // Rows: x' = v[kx] − sx·v[kz], y' = v[ky] − sy·v[kz], z' = sz·v[kz]. The zero
        // entries add exact zeros, so each coordinate rounds as the paper's does.
        let mut rows = [[0.0f32; 3]; 3];
        rows[0][kx] = 1.0;
        rows[0][kz] = -sx;
        rows[1][ky] = 1.0;
        rows[1][kz] = -sy;
        rows[2][kz] = sz;
        ShearedRay {
            origin,
            to_ray_space: Mat3A::from_cols_array_2d(&rows).transpose(),
        }
    }

    /// `(t, u, v)` with `t` in `(0, t_max)`, or `t = ∞` for a miss; zero-area
    /// triangles and NaN never hit.
    #[inline(always)]
    fn intersect(&self, tri: &[Vec3A; 3], t_max: f32) -> (f32, f32, f32) {
        const MISS: (f32, f32, f32) = (f32::INFINITY, 0.0, 0.0);
        let a = self.to_ray_space * (tri[0] - self.origin);
        let b = self.to_ray_space * (tri[1] - self.origin);
        let c = self.to_ray_space * (tri[2] - self.origin);
        // Edge functions: twice the signed areas seen along the ray.
        let mut u = c.x * b.y - c.y * b.x;
        let mut v = a.x * c.y - a.y * c.x;
        let mut w = b.x * a.y - b.y * a.x;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            let f = |p: f32, q: f32, r: f32, s: f32| {
                (f64::from(p) * f64::from(q) - f64::from(r) * f64::from(s)) as f32
            };
            u = f(c.x, b.y, c.y, b.x);
            v = f(a.x, c.y, a.y, c.x);
            w = f(b.x, a.y, b.y, a.x);
        }
        let negative = u < 0.0 || v < 0.0 || w < 0.0;
        let positive = u > 0.0 || v > 0.0 || w > 0.0;
        let det = u + v + w;
        if (negative && positive) || det == 0.0 {
            return MISS;
        }
        let inv_det = 1.0 / det;
        let t = (u * a.z + v * b.z + w * c.z) * inv_det;
        // Written so that NaN fails.
        if t > 0.0 && t < t_max {
            (t, v * inv_det, w * inv_det)
        } else {
            MISS
        }
    }
}

/// The ray–triangle test the accel uses, for one triangle: `Some((t, [u, v]))` when
/// `origin + t · dir` hits the triangle `vertices` for `t` in `(0, t_max)`. Brute-force
/// references (tests, debugging) should use it to agree with [`Accel`] bit for bit.
pub fn intersect_triangle(
    origin: [f32; 3],
    dir: [f32; 3],
    vertices: [[f32; 3]; 3],
    t_max: f32,
) -> Option<(f32, [f32; 2])> {
    let tri = vertices.map(Vec3A::from);
    let (t, u, v) = ShearedRay::new(origin.into(), dir.into()).intersect(&tri, t_max);
    (t < f32::INFINITY).then_some((t, [u, v]))
}

/// Moves a surface point `p` off its surface along the geometric normal `n` (either
/// side: pass `-n` to leave through the back) so that a ray starting there does not
/// hit the surface it left. Wächter and Binder's method: an offset of a fixed number
/// of ulps in each coordinate, so it is right at every scale, with a small absolute
/// offset for coordinates near zero where ulps vanish.
pub fn offset_ray_origin(p: [f32; 3], n: [f32; 3]) -> [f32; 3] {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    std::array::from_fn(|k| {
        let of_i = (INT_SCALE * n[k]) as i32;
        let bits = p[k].to_bits() as i32;
        let stepped = f32::from_bits(if p[k] < 0.0 { bits - of_i } else { bits + of_i } as u32);
        if p[k].abs() < ORIGIN {
            p[k] + FLOAT_SCALE * n[k]
        } else {
            stepped
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_moves_along_the_normal_at_every_scale() {
        for scale in [1e-3f32, 1.0, 4.5, 1e6] {
            let p = [scale, -scale, 0.5 * scale];
            let q = offset_ray_origin(p, [0.0, 1.0, 0.0]);
            assert_eq!(q[0], p[0]);
            assert!(q[1] > p[1], "{scale}: {q:?}");
            assert_eq!(q[2], p[2]);
        }
    }
}
