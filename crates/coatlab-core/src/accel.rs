//! The acceleration structure for the tracer: a BVH over the scene's triangles.
//!
//! Two layers, as in obvhs, which does the building and the node traversal:
//! - [`Bvh`] knows nothing about geometry. It is built from boxes ([`Bounds`]) and
//!   traversed with a closure that intersects one primitive, so the same structure
//!   serves shading rays, shadow rays and picking. Primitives are addressed by *slot*
//!   (their position in the tree's leaf order); [`Bvh::primitive_order`] maps a slot to
//!   the caller's index, and callers store their primitives in slot order so the
//!   closure reads memory sequentially.
//! - [`Accel`] is the triangle layer the tracer uses: a [`Bvh`] over
//!   [`Triangles`] (an indexed triangle list, which the scene hands over; the accel
//!   knows no scene type) plus the triangles copied in slot order (for `Simd8`, lane by
//!   lane in the packs its leaves point to), with
//!   [`Accel::closest_hit`] (shading rays, picking) and [`Accel::occluded`] (any hit,
//!   for shadow rays), and [`Accel::closest_hits`], the same closest-hit queries for a
//!   slice of rays, which the `Simd8` layout traces several at a time on one thread
//!   (bit for bit the single-ray results; about 1.5 times the rays per second on
//!   incoherent rays, see docs/benchmarks.md).
//!
//! Layouts ([`BvhLayout`]): `Simd8`, our own CPU-first 8-wide BVH (binned-SAH
//! build, f32 child boxes tested 8 at a time, leaves of up to 8 triangles tested 8
//! at a time, ordered traversal and a separate any-hit traversal; see
//! `accel/wide.rs`), is the one the library ships. With the feature
//! `bvh-experiments` (which the tests and benches turn on), obvhs's compressed
//! 8-wide `CwBvh` (`Wide8`) and binary `Bvh2` (`Binary`) are there to compare
//! against (`accel/obvhs_layouts.rs`), with the other experiment code (`experiments`).
//! `docs/benchmarks.md` ("Acceleration structure") has the measurements behind the
//! choice.
//!
//! Files, each importing only those below it: this one (the triangle layer);
//! `bvh.rs` (the box layer); `split.rs` (reference splitting before the build);
//! `wide.rs` and `wide/` (the `Simd8` tree: traversal, build, the collapse it
//! replaced); `obvhs_layouts.rs`; `options.rs` (build options); `triangle.rs` (the
//! watertight test on packs of triangles); `boxes.rs` (boxes, scalar and SIMD).
//! The queries dispatch on the process's SIMD path (`crate::simd_path`), chosen at
//! start-up.
//!
//! # Rays and the epsilon policy
//!
//! A ray is `origin + t · dir` for `t` in the open interval `(0, t_max)`; `t` is in
//! units of `|dir|` (metres for a unit `dir`). `dir` need not be normalised but must be
//! finite and non-zero; a ray with a non-finite origin or direction, or `t_max` that is
//! not positive (NaN included), hits nothing. The triangle test is the watertight
//! one of Woop, Benthin and Wald ("Watertight Ray/Triangle Intersection", JCGT 2013)
//! in f32, without backface culling: the
//! vertices are moved into a frame where the ray is the +z axis and the three 2-D
//! edge functions decide inside/outside, recomputed in f64 when one is exactly zero
//! (`accel/triangle.rs`; the `Simd8` leaves run the same operations 8 lanes at a
//! time, bit for bit).
//! A ray through an edge or vertex shared by two triangles hits at least one of
//! them; of hits at the same distance the query reports the triangle with the least
//! index, whichever the traversal reaches first (so that every SIMD path and the
//! batch report the same hit, though their box tests round differently).
//! Möller–Trumbore was tried first and is not good enough here: a ray 1.4·10⁻⁶
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
//! The `Simd8` tree splits at the median where the SAH cannot separate primitives,
//! so its depth stays logarithmic, and its stack spills to the heap if ever needed.

mod boxes;
mod bvh;
#[cfg(feature = "bvh-experiments")]
mod obvhs_layouts;
mod options;
mod split;
#[cfg(test)]
mod test_support;
mod triangle;
mod wide;

use glam::Vec3A;

use bvh::Tree;
use triangle::{ShearedRay, TrianglePack};
use wide::{BoxRay, PACK, Traversal, prefetch};

use crate::simd_path::isa::PORTABLE;
use crate::simd_path::{SimdPath, dispatch};
pub use boxes::Bounds;
pub use bvh::{AccelError, Bvh, Ray};
pub use options::{BuildOptions, BuildQuality, BvhLayout, ReferenceSplits};

/// Experiment and comparison code, out of the shipped library (feature
/// `bvh-experiments`; the layouts `Wide8` and `Binary` and
/// [`Accel::closest_hits_in_lanes`] come with it).
#[cfg(feature = "bvh-experiments")]
pub mod experiments {
    pub use super::wide::largest_child::{CollapseCosts, compare_collapses};
}

/// A ray's hit on one of the [`Triangles`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance along the ray, in units of `|dir|`.
    pub t: f32,
    /// Index into [`Triangles::indices`].
    pub triangle: u32,
    /// Weights (u, v) of the triangle's second and third vertex; the first has
    /// 1 − u − v.
    pub barycentric: [f32; 2],
}

/// One closest-hit query of a batch ([`Accel::closest_hits`]): the ray
/// `origin + t · dir` for `t` in `(0, t_max)`, as for [`Accel::closest_hit`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayQuery {
    /// Metres.
    pub origin: [f32; 3],
    /// Finite and non-zero; need not be normalised.
    pub dir: [f32; 3],
    /// In units of `|dir|`.
    pub t_max: f32,
}

/// Rays a [`Accel::closest_hits`] batch keeps in flight on one thread.
pub const BATCH_LANES: usize = 8;

/// The acceleration structure of a set of [`Triangles`]; see the module
/// documentation.
#[derive(Debug, Clone)]
pub struct Accel {
    bvh: Bvh,
    /// Triangle vertices in slot order (the obvhs layouts; empty for `Simd8`).
    #[cfg(feature = "bvh-experiments")]
    triangles: Vec<[Vec3A; 3]>,
    /// The triangles in the packs of the `Simd8` leaves, lane ids being indices into
    /// [`Triangles::indices`] (empty for the obvhs layouts).
    packs: Vec<TrianglePack<PACK>>,
    /// Index into [`Triangles::indices`] of each slot.
    mesh_triangle: Vec<u32>,
    /// Triangles in the tree (each once, however many references it has).
    triangle_count: usize,
    /// Zero-area triangles left out.
    skipped_degenerate: usize,
}

/// One triangle's box, for the builder and the validation.
fn triangle_bounds(t: &[Vec3A; 3]) -> Bounds {
    Bounds {
        min: t[0].min(t[1]).min(t[2]).into(),
        max: t[0].max(t[1]).max(t[2]).into(),
    }
}

/// The triangles an [`Accel`] is built over: vertex positions (metres) and, for
/// each triangle, the indices of its three vertices. Borrowed, so that a scene's
/// mesh hands its own arrays over without a copy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triangles<'a> {
    pub positions: &'a [[f32; 3]],
    pub indices: &'a [[u32; 3]],
}

impl<'a> Triangles<'a> {
    /// The triangles `indices` over the vertices `positions`.
    pub fn new(positions: &'a [[f32; 3]], indices: &'a [[u32; 3]]) -> Triangles<'a> {
        Triangles { positions, indices }
    }
}

impl Accel {
    /// Builds with the default options ([`BuildOptions::default`]).
    pub fn build<'a>(triangles: impl Into<Triangles<'a>>) -> Result<Accel, AccelError> {
        Accel::build_with(triangles, &BuildOptions::default())
    }

    /// Builds with the given layout and quality.
    pub fn build_with<'a>(
        triangles: impl Into<Triangles<'a>>,
        options: &BuildOptions,
    ) -> Result<Accel, AccelError> {
        Accel::build_from(triangles.into(), options)
    }

    fn build_from(input: Triangles<'_>, options: &BuildOptions) -> Result<Accel, AccelError> {
        let vertex_count = input.positions.len();
        let mut triangles = Vec::with_capacity(input.indices.len());
        let mut kept = Vec::with_capacity(input.indices.len());
        for (triangle, indices) in input.indices.iter().enumerate() {
            let mut vertices = [Vec3A::ZERO; 3];
            for (v, &vertex) in vertices.iter_mut().zip(indices) {
                let Some(&position) = input.positions.get(vertex as usize) else {
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
        let mut boxes: Vec<Bounds> = triangles.iter().map(triangle_bounds).collect();
        // The tree's primitives: references to triangles (one a triangle, except
        // that `Simd8` splits large ones; see `accel/split.rs`).
        let mut reference_triangle: Vec<u32> = (0..triangles.len() as u32).collect();
        // The spatial pass's partition, kept as the top of the `Simd8` tree.
        let mut top_tree = Vec::new();
        if options.layout == BvhLayout::Simd8 {
            let vertices: Vec<[[f32; 3]; 3]> =
                triangles.iter().map(|t| t.map(Into::into)).collect();
            let top;
            (boxes, reference_triangle, top) = split::split_references(
                &vertices,
                &boxes,
                options.reference_splits,
                options.build_threads(),
            );
            top_tree = top;
        }
        let bvh = Bvh::build_below(&boxes, &top_tree, options)?;
        // Slot → index into `triangles`.
        let order: Vec<u32> = bvh
            .primitive_order()
            .iter()
            .map(|&r| reference_triangle[r as usize])
            .collect();
        let mesh_triangle: Vec<u32> = order.iter().map(|&i| kept[i as usize]).collect();
        let packs = match &bvh.tree {
            Tree::Simd8(tree) => tree
                .pack_slots()
                .iter()
                .map(|slots| {
                    let mut pack = TrianglePack::empty();
                    for (lane, &slot) in slots.iter().enumerate() {
                        if slot != u32::MAX {
                            let i = order[slot as usize] as usize;
                            pack.set(lane, triangles[i].map(Into::into), kept[i]);
                        }
                    }
                    pack
                })
                .collect(),
            _ => Vec::new(),
        };
        Ok(Accel {
            #[cfg(feature = "bvh-experiments")]
            triangles: match &bvh.tree {
                Tree::Obvhs(_) => order.iter().map(|&i| triangles[i as usize]).collect(),
                _ => Vec::new(),
            },
            packs,
            mesh_triangle,
            triangle_count: kept.len(),
            skipped_degenerate: input.indices.len() - kept.len(),
            bvh,
        })
    }

    /// The underlying tree.
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Number of triangles in the tree.
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    /// For each slot of [`Accel::bvh`], the index into [`Triangles::indices`] of its
    /// triangle. (With `Simd8` a large triangle may fill several slots: the tree's
    /// primitives are then references, see `accel/split.rs`.)
    pub fn slot_triangles(&self) -> &[u32] {
        &self.mesh_triangle
    }

    /// Number of zero-area triangles left out of the tree.
    pub fn skipped_degenerate(&self) -> usize {
        self.skipped_degenerate
    }

    /// Bounds of the triangles in the tree; `None` when empty.
    pub fn bounds(&self) -> Option<Bounds> {
        self.bvh.bounds()
    }

    /// The closest triangle hit by `origin + t · dir` for `t` in `(0, t_max)`; see the
    /// module documentation for the epsilon policy. For shading rays and picking.
    #[inline]
    pub fn closest_hit(&self, origin: [f32; 3], dir: [f32; 3], t_max: f32) -> Option<Hit> {
        let path = SimdPath::current();
        dispatch!(path, ISA => self.closest_hit_with::<ISA>(origin, dir, t_max))
    }

    /// [`Accel::closest_hit`] on `path` rather than the process's
    /// ([`SimdPath::current`]), for comparing the paths; a path this CPU lacks runs
    /// the portable code.
    pub fn closest_hit_on(
        &self,
        path: SimdPath,
        origin: [f32; 3],
        dir: [f32; 3],
        t_max: f32,
    ) -> Option<Hit> {
        let path = path.or_portable();
        dispatch!(path, ISA => self.closest_hit_with::<ISA>(origin, dir, t_max))
    }

    /// [`Accel::closest_hit`] instantiated for one path (`ISA`: see
    /// `accel/triangle.rs`).
    #[inline(always)]
    fn closest_hit_with<const ISA: u8>(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        t_max: f32,
    ) -> Option<Hit> {
        if !usable_ray(origin, dir, t_max) {
            return None;
        }
        let sheared = ShearedRay::new(origin, dir);
        if let Tree::Simd8(tree) = &self.bvh.tree {
            let box_ray = BoxRay::single::<ISA>(origin, dir);
            let mut nearest = Nearest::default();
            tree.nodes().closest::<ISA>(
                &box_ray,
                Nearest::closed_bound(t_max),
                #[inline(always)]
                |pack, _, t_max| nearest.test::<ISA>(&sheared, &self.packs, pack, t_max),
                #[inline(always)]
                |pack, _| fetch_pack(&self.packs, pack),
            );
            return nearest.hit(&self.packs);
        }
        self.closest_hit_by_slot(&sheared, RayQuery { origin, dir, t_max })
    }

    /// [`Accel::closest_hit`] where the tree is not `Simd8`: without the obvhs
    /// layouts (feature `bvh-experiments`), only the empty tree, which nothing hits.
    #[cfg(not(feature = "bvh-experiments"))]
    #[inline(always)]
    fn closest_hit_by_slot(&self, _: &ShearedRay, _: RayQuery) -> Option<Hit> {
        None
    }

    /// [`Accel::occluded`] where the tree is not `Simd8` (see
    /// [`Accel::closest_hit_by_slot`]).
    #[cfg(not(feature = "bvh-experiments"))]
    #[inline(always)]
    fn occluded_by_slot(&self, _: &ShearedRay, _: RayQuery) -> bool {
        false
    }

    /// [`Accel::closest_hit`] for each query of `rays`, written to the same index of
    /// `hits`, with the same results bit for bit. With the `Simd8` layout the rays
    /// are traced [`BATCH_LANES`] at a time, one node or leaf of each in turn: while
    /// one ray waits for the node it has asked the cache for, the others work, which
    /// a single-ray query cannot do (see docs/benchmarks.md, "Acceleration
    /// structure"). Other layouts trace the rays one by one.
    ///
    /// # Panics
    ///
    /// If `hits` is not as long as `rays`.
    pub fn closest_hits(&self, rays: &[RayQuery], hits: &mut [Option<Hit>]) {
        self.closest_hits_checked(SimdPath::current(), rays, hits);
    }

    /// [`Accel::closest_hits`] on `path` (see [`Accel::closest_hit_on`]).
    ///
    /// # Panics
    ///
    /// If `hits` is not as long as `rays`.
    pub fn closest_hits_on(&self, path: SimdPath, rays: &[RayQuery], hits: &mut [Option<Hit>]) {
        let path = path.or_portable();
        self.closest_hits_checked(path, rays, hits);
    }

    /// [`Accel::closest_hits`] on `path`, which this CPU has.
    fn closest_hits_checked(&self, path: SimdPath, rays: &[RayQuery], hits: &mut [Option<Hit>]) {
        dispatch!(path, ISA => self.closest_hits_with_lanes::<ISA, BATCH_LANES>(rays, hits));
    }

    /// [`Accel::closest_hits`] with `LANES` rays in flight instead of
    /// [`BATCH_LANES`]: for measuring and testing other counts (feature
    /// `bvh-experiments`).
    #[cfg(feature = "bvh-experiments")]
    pub fn closest_hits_in_lanes<const LANES: usize>(
        &self,
        rays: &[RayQuery],
        hits: &mut [Option<Hit>],
    ) {
        dispatch!(SimdPath::current(), ISA => self.closest_hits_with_lanes::<ISA, LANES>(rays, hits));
    }

    /// [`Accel::closest_hit`] for each of `rays` in turn, inside one call: the same
    /// results bit for bit, with one ray traversed at a time rather than the eight
    /// in flight of [`Accel::closest_hits`]. For coherent rays whose nodes stay in
    /// cache, such as bounces in image order, where the eight in flight cost more
    /// than they hide; on incoherent rays [`Accel::closest_hits`] leads
    /// (docs/benchmarks.md, "Against Intel Embree 4"). Unlike calling
    /// [`Accel::closest_hit`] in a loop, the SIMD path is chosen and entered once
    /// for all the rays (about a tenth of a bounce ray's time on the EPYC VM).
    ///
    /// # Panics
    ///
    /// If `hits` is not as long as `rays`.
    pub fn closest_hits_one_by_one(&self, rays: &[RayQuery], hits: &mut [Option<Hit>]) {
        self.closest_hits_one_by_one_on(SimdPath::current(), rays, hits);
    }

    /// [`Accel::closest_hits_one_by_one`] on `path` (see [`Accel::closest_hit_on`]).
    ///
    /// # Panics
    ///
    /// If `hits` is not as long as `rays`.
    pub fn closest_hits_one_by_one_on(
        &self,
        path: SimdPath,
        rays: &[RayQuery],
        hits: &mut [Option<Hit>],
    ) {
        assert_eq!(
            rays.len(),
            hits.len(),
            "closest_hits_one_by_one: {} rays but {} hit slots",
            rays.len(),
            hits.len()
        );
        let path = path.or_portable();
        dispatch!(path, ISA => {
            for (query, hit) in rays.iter().zip(hits.iter_mut()) {
                *hit = self.closest_hit_with::<ISA>(query.origin, query.dir, query.t_max);
            }
        });
    }

    /// The batch traversal, instantiated for one path (`ISA`: see
    /// `accel/triangle.rs`).
    #[inline(always)]
    fn closest_hits_with_lanes<const ISA: u8, const LANES: usize>(
        &self,
        rays: &[RayQuery],
        hits: &mut [Option<Hit>],
    ) {
        assert_eq!(
            rays.len(),
            hits.len(),
            "closest_hits: {} rays but {} hit slots",
            rays.len(),
            hits.len()
        );
        let Tree::Simd8(tree) = &self.bvh.tree else {
            for (query, hit) in rays.iter().zip(hits.iter_mut()) {
                *hit = self.closest_hit(query.origin, query.dir, query.t_max);
            }
            return;
        };
        // A ray in flight: its index into `rays`, its two prepared forms, its closest
        // hit so far and its traversal, together, so that a step reads one lane.
        struct Lane {
            index: usize,
            box_ray: BoxRay,
            sheared: ShearedRay,
            nearest: Nearest,
            traversal: Traversal,
        }
        // Unusable rays are skipped below and miss.
        hits.fill(None);
        // Placeholder rays for the lanes until `take` starts theirs, prepared once.
        let (idle_box, idle_sheared) = (
            BoxRay::new([0.0; 3], [1.0; 3]),
            ShearedRay::new([0.0; 3], [1.0; 3]),
        );
        let mut lanes: [Lane; LANES] = std::array::from_fn(|_| Lane {
            index: 0,
            box_ray: idle_box,
            sheared: idle_sheared,
            nearest: Nearest::default(),
            traversal: Traversal::new(),
        });
        let mut next = 0;
        // Starts the next usable ray from `next` on in `lane` (unusable ones miss at
        // once); false when none is left.
        let mut take = |lane: &mut Lane| -> bool {
            while let Some(query) = rays.get(next) {
                let index = next;
                next += 1;
                if usable_ray(query.origin, query.dir, query.t_max) {
                    lane.index = index;
                    lane.box_ray = BoxRay::new(query.origin, query.dir);
                    lane.sheared = ShearedRay::new(query.origin, query.dir);
                    lane.nearest = Nearest::default();
                    lane.traversal.start(Nearest::closed_bound(query.t_max));
                    return true;
                }
            }
            false
        };
        // The lanes in flight are `lanes[order[..active]]`: a lane with no ray left
        // to take swaps its place in `order` with the last one in flight, so a step
        // never tests whether its lane is in use, and no lane (about 600 bytes,
        // most of them its stack) is copied. Which lane a ray runs in does not
        // change its steps, so neither does this its results.
        let mut order: [usize; LANES] = std::array::from_fn(|i| i);
        let mut active = 0;
        while active < LANES && take(&mut lanes[active]) {
            active += 1;
        }
        // Slices in locals, not reached through `self` at every step (see
        // `wide::Nodes`).
        let tree = tree.nodes();
        let packs: &[TrianglePack<PACK>] = &self.packs;
        let fetch_leaf = |pack: usize, _| fetch_pack(packs, pack);
        while active > 0 {
            let mut i = 0;
            while let Some(&slot) = order[..active].get(i) {
                let lane = &mut lanes[slot];
                let Lane {
                    box_ray,
                    sheared,
                    nearest,
                    traversal,
                    ..
                } = lane;
                let mut leaf =
                    |pack: usize, _, t_max: f32| nearest.test::<ISA>(sheared, packs, pack, t_max);
                if tree.closest_step::<ISA>(box_ray, traversal, &mut leaf, &fetch_leaf) {
                    i += 1;
                    continue;
                }
                // This ray is done: its result, then the next ray in its place.
                hits[lane.index] = lane.nearest.hit(packs);
                if take(lane) {
                    i += 1;
                } else {
                    // The last lane in flight takes this one's place and steps next.
                    active -= 1;
                    order.swap(i, active);
                }
            }
        }
    }

    /// Whether anything lies on `origin + t · dir` for `t` in `(0, t_max)`: the any-hit
    /// query for shadow rays. Agrees with `closest_hit(..).is_some()`.
    #[inline]
    pub fn occluded(&self, origin: [f32; 3], dir: [f32; 3], t_max: f32) -> bool {
        let path = SimdPath::current();
        dispatch!(path, ISA => self.occluded_with::<ISA>(origin, dir, t_max))
    }

    /// [`Accel::occluded`] on `path` (see [`Accel::closest_hit_on`]).
    pub fn occluded_on(&self, path: SimdPath, origin: [f32; 3], dir: [f32; 3], t_max: f32) -> bool {
        let path = path.or_portable();
        dispatch!(path, ISA => self.occluded_with::<ISA>(origin, dir, t_max))
    }

    /// [`Accel::occluded`] instantiated for one path.
    #[inline(always)]
    fn occluded_with<const ISA: u8>(&self, origin: [f32; 3], dir: [f32; 3], t_max: f32) -> bool {
        if !usable_ray(origin, dir, t_max) {
            return false;
        }
        let sheared = ShearedRay::new(origin, dir);
        if let Tree::Simd8(tree) = &self.bvh.tree {
            let box_ray = BoxRay::single::<ISA>(origin, dir);
            return tree.nodes().any::<ISA>(
                &box_ray,
                t_max,
                #[inline(always)]
                |pack, _| sheared.any_in_pack::<ISA, PACK>(&self.packs[pack], t_max),
                #[inline(always)]
                |pack, _| fetch_pack(&self.packs, pack),
            );
        }
        self.occluded_by_slot(&sheared, RayQuery { origin, dir, t_max })
    }

    /// The `Simd8` part of [`Accel::validate`]: the references are recomputed from the
    /// triangles (the split is deterministic) and the tree is checked against their
    /// boxes; each slot must hold its reference's triangle.
    fn validate_references(&self, slot_triangles: &[Option<[Vec3A; 3]>]) -> Result<(), String> {
        // Each triangle once, in input order (the order the tree was built from).
        let mut by_mesh: Vec<(u32, [Vec3A; 3])> = Vec::with_capacity(self.triangle_count);
        for (slot, t) in slot_triangles.iter().enumerate() {
            let t = t.ok_or_else(|| format!("slot {slot} is in no pack"))?;
            by_mesh.push((self.mesh_triangle[slot], t));
        }
        by_mesh.sort_by_key(|&(id, _)| id);
        let mut unique: Vec<(u32, [Vec3A; 3])> = Vec::with_capacity(self.triangle_count);
        for (id, t) in by_mesh {
            match unique.last() {
                Some(&(last, u)) if last == id => {
                    if u != t {
                        return Err(format!("two slots of triangle {id} differ"));
                    }
                }
                _ => unique.push((id, t)),
            }
        }
        if unique.len() != self.triangle_count {
            return Err(format!(
                "{} triangles in the slots, {} built",
                unique.len(),
                self.triangle_count
            ));
        }
        let vertices: Vec<[[f32; 3]; 3]> = unique.iter().map(|(_, t)| t.map(Into::into)).collect();
        let boxes: Vec<Bounds> = unique.iter().map(|(_, t)| triangle_bounds(t)).collect();
        let (reference_boxes, reference_triangle, _) = split::split_references(
            &vertices,
            &boxes,
            self.bvh.options().reference_splits,
            self.bvh.options().build_threads(),
        );
        let order = self.bvh.primitive_order();
        if reference_boxes.len() != order.len() {
            return Err(format!(
                "{} references, but the tree holds {}",
                reference_boxes.len(),
                order.len()
            ));
        }
        for (slot, &r) in order.iter().enumerate() {
            let t = reference_triangle
                .get(r as usize)
                .ok_or_else(|| format!("slot {slot}: reference {r} out of range"))?;
            if unique[*t as usize].0 != self.mesh_triangle[slot] {
                return Err(format!(
                    "slot {slot} holds triangle {}, its reference is to {}",
                    self.mesh_triangle[slot], unique[*t as usize].0
                ));
            }
        }
        self.bvh.validate(&reference_boxes)
    }

    /// Checks the tree ([`Bvh::validate`]) against the triangles' boxes, and, for
    /// `Simd8`, that the packs hold the slots' triangles.
    pub fn validate(&self) -> Result<(), String> {
        let order = self.bvh.primitive_order();
        if order.len() != self.mesh_triangle.len() {
            return Err(format!(
                "{} triangles but {} slots",
                self.mesh_triangle.len(),
                order.len()
            ));
        }
        // Each slot's triangle, from the packs or the slot-order copy.
        let mut slot_triangles: Vec<Option<[Vec3A; 3]>> = vec![None; order.len()];
        match &self.bvh.tree {
            Tree::Simd8(tree) => {
                if tree.pack_slots().len() != self.packs.len() {
                    return Err(format!(
                        "{} packs but the tree lays out {}",
                        self.packs.len(),
                        tree.pack_slots().len()
                    ));
                }
                for (p, (pack, slots)) in self.packs.iter().zip(tree.pack_slots()).enumerate() {
                    for (lane, &slot) in slots.iter().enumerate() {
                        if slot == u32::MAX {
                            continue;
                        }
                        let Some(entry) = slot_triangles.get_mut(slot as usize) else {
                            return Err(format!("pack {p} lane {lane}: slot {slot} out of range"));
                        };
                        if pack.id[lane] != self.mesh_triangle[slot as usize] {
                            return Err(format!(
                                "pack {p} lane {lane} holds triangle {}, slot {slot} is {}",
                                pack.id[lane], self.mesh_triangle[slot as usize]
                            ));
                        }
                        *entry = Some(pack.get(lane).map(Vec3A::from));
                    }
                }
            }
            Tree::Empty => {}
            #[cfg(feature = "bvh-experiments")]
            Tree::Obvhs(_) => self.slot_triangles_by_slot(&mut slot_triangles)?,
        }
        if let Tree::Simd8(_) = &self.bvh.tree {
            return self.validate_references(&slot_triangles);
        }
        // Back from slot order to input order, as the tree was built.
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
            let t = slot_triangles[slot].ok_or_else(|| format!("slot {slot} is in no pack"))?;
            *b = triangle_bounds(&t);
        }
        self.bvh.validate(&boxes)
    }
}

/// The triangle layer on the obvhs layouts: a slot-order copy of the triangles,
/// tested one at a time through the box layer.
#[cfg(feature = "bvh-experiments")]
impl Accel {
    /// [`Accel::closest_hit`] through an obvhs tree (or the empty one): one triangle a
    /// slot, from the slot-order copy.
    fn closest_hit_by_slot(&self, sheared: &ShearedRay, query: RayQuery) -> Option<Hit> {
        let RayQuery { origin, dir, t_max } = query;
        let ray = Ray::new(origin.into(), dir.into(), 0.0, t_max);
        let (slot, _) = self
            .bvh
            .closest(ray, |ray, slot| self.slot_distance(sheared, ray, slot))?;
        // Barycentrics only for the winner.
        let hit = sheared
            .intersect_pack::<PORTABLE, 1>(&single(&self.triangles[slot]), t_max.next_down())?;
        Some(Hit {
            t: hit.t,
            triangle: self.mesh_triangle[slot],
            barycentric: hit.barycentric,
        })
    }

    /// [`Accel::occluded`] through an obvhs tree (or the empty one).
    fn occluded_by_slot(&self, sheared: &ShearedRay, query: RayQuery) -> bool {
        let ray = Ray::new(query.origin.into(), query.dir.into(), 0.0, query.t_max);
        self.bvh
            .any(ray, |ray, slot| self.slot_distance(sheared, ray, slot))
    }

    /// The distance at which `sheared` hits the triangle of `slot` within `ray`'s
    /// `tmax`; infinity for a miss.
    #[inline(always)]
    fn slot_distance(&self, sheared: &ShearedRay, ray: &Ray, slot: usize) -> f32 {
        sheared
            .intersect_pack::<PORTABLE, 1>(&single(&self.triangles[slot]), ray.tmax.next_down())
            .map_or(f32::INFINITY, |hit| hit.t)
    }

    /// For [`Accel::validate`]: each slot's triangle, from the slot-order copy.
    fn slot_triangles_by_slot(
        &self,
        slot_triangles: &mut [Option<[Vec3A; 3]>],
    ) -> Result<(), String> {
        if self.triangles.len() != slot_triangles.len() {
            return Err(format!(
                "{} triangles but {} slots",
                self.triangles.len(),
                slot_triangles.len()
            ));
        }
        for (entry, t) in slot_triangles.iter_mut().zip(&self.triangles) {
            *entry = Some(*t);
        }
        Ok(())
    }
}

/// The nearest hit of one closest-hit query so far, and the leaf test that
/// improves on it. Of hits at the same distance (a ray through an edge or vertex
/// that triangles share) the one with the least triangle index wins, whichever the
/// traversal reaches first: the SIMD paths' box tests round differently, so they
/// visit leaves in different orders, and their results are the same bit for bit
/// only because no result depends on that order.
#[derive(Debug, Clone, Copy, Default)]
struct Nearest {
    /// The pack and the lane's hit.
    best: Option<(usize, triangle::LaneHit)>,
}

impl Nearest {
    /// The traversal's first `t_max` for a query's: the largest distance below it,
    /// as the traversal's bound is a closed one (a later hit may equal the nearest
    /// so far and win on its index).
    #[inline(always)]
    fn closed_bound(query_t_max: f32) -> f32 {
        query_t_max.next_down()
    }

    /// Tests `packs[pack]` for hits within the traversal's `t_max` (a closed bound:
    /// [`Nearest::closed_bound`] of the query's, then the nearest hit's distance)
    /// and returns the new `t_max`.
    #[inline(always)]
    fn test<const ISA: u8>(
        &mut self,
        sheared: &ShearedRay,
        packs: &[TrianglePack<PACK>],
        pack: usize,
        t_max: f32,
    ) -> f32 {
        let Some(hit) = sheared.intersect_pack::<ISA, PACK>(&packs[pack], t_max) else {
            return t_max;
        };
        // A tie that does not win (a triangle split into several leaves ties with
        // itself).
        if hit.t == t_max
            && let Some((p, best)) = self.best
            && packs[pack].id[hit.lane] >= packs[p].id[best.lane]
        {
            return t_max;
        }
        self.best = Some((pack, hit));
        hit.t
    }

    /// The query's result.
    #[inline(always)]
    fn hit(&self, packs: &[TrianglePack<PACK>]) -> Option<Hit> {
        self.best.map(|(p, hit)| Hit {
            t: hit.t,
            triangle: packs[p].id[hit.lane],
            barycentric: hit.barycentric,
        })
    }
}

/// Starts fetching a leaf's pack (see `wide::prefetch`). A `Simd8` leaf is one
/// pack (`wide::MAX_LEAF` is `PACK`), so the triangle traversals test the leaf's
/// first pack only.
#[inline(always)]
fn fetch_pack(packs: &[TrianglePack<PACK>], pack: usize) {
    if let Some(pack) = packs.get(pack) {
        prefetch(pack);
    }
}

/// A pack of one triangle.
#[cfg(feature = "bvh-experiments")]
#[inline(always)]
fn single(t: &[Vec3A; 3]) -> TrianglePack<1> {
    TrianglePack {
        v: std::array::from_fn(|j| std::array::from_fn(|k| [t[j][k]])),
        id: [0],
    }
}

/// Whether a query can hit anything: finite origin and direction, a non-zero
/// direction and a positive `t_max` (`t_max > 0` is false for NaN).
#[inline(always)]
fn usable_ray(origin: [f32; 3], dir: [f32; 3], t_max: f32) -> bool {
    t_max > 0.0 && origin.iter().chain(&dir).all(|x| x.is_finite()) && dir.iter().any(|&x| x != 0.0)
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
    if !usable_ray(origin, dir, t_max) {
        return None;
    }
    let mut pack = TrianglePack::<1>::empty();
    pack.set(0, vertices, 0);
    ShearedRay::new(origin, dir)
        .intersect_pack::<PORTABLE, 1>(&pack, t_max.next_down())
        .map(|hit| (hit.t, hit.barycentric))
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
