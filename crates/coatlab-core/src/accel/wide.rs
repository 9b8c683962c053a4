//! Our own CPU-first 8-wide BVH (the `Simd8` layout).
//!
//! - **Build**: a top-down binned-SAH binary tree over the primitives' boxes (centroid
//!   bins on all three axes in one pass; the cost counts primitives in leaf blocks of
//!   [`PACK`], as the triangle test works on blocks), then collapsed into 8-wide nodes
//!   by the SAH-optimal choice of each node's children (`build::CollapsePlan`:
//!   which binary subtrees become a node's up to 8 children, and which of those are
//!   leaves and which further nodes, for the least expected cost of node and pack
//!   tests; it replaced opening the child with the largest surface area until there
//!   were 8, kept for comparison in `largest_child.rs`). Where the SAH
//!   finds no split (all centroids in one bin) or the tree gets deep, the primitives
//!   are split at the median, so the depth stays logarithmic even for thousands of
//!   coincident triangles.
//! - **Nodes**: the 8 children's boxes as plain f32 planes, structure of arrays
//!   (`bounds[plane][child]`, 224 bytes a node): one ray is tested against all 8 boxes
//!   with the same straight-line code per child, which LLVM vectorises to AVX in the
//!   traversal compiled for AVX2 (and to SSE2 in the portable one) without `unsafe`;
//!   the AVX-512 traversal tests a child's near and far planes of one axis in one
//!   16-lane register instead (`avx512::hit_children`, the same operations). The
//!   const parameter `ISA` of the traversal says which path it is instantiated
//!   for, as in `accel/triangle.rs`.
//! - **Leaves**: up to [`MAX_LEAF`] primitives, stored by the geometry layer as
//!   blocks ("packs") of [`PACK`] lanes; a leaf's child reference holds its first pack
//!   and its primitive count, so a leaf is reached without an indirection.
//!   [`WideBvh::pack_slots`] says which slot (primitive in leaf order) each lane holds.
//! - **Traversal**: closest hit in front-to-back order (hit children sorted by entry
//!   distance, the farther ones pushed with their distance so that they are skipped
//!   once a closer hit is known); any hit without sorting, stopping at the first hit.
//!   The closest-hit traversal is a resumable state ([`Traversal`]) advanced one node
//!   or leaf at a time ([`Nodes::closest_step`]), so that a batch can interleave
//!   the steps of several rays; a single ray ([`Nodes::closest`]) takes the same
//!   steps with its state in locals and its node steps in a loop of their own
//!   (with the fused box test on the AVX2 and AVX-512 paths, so the steps can
//!   differ there where a box is entered within rounding, the hit not).
//!
//! # Robustness
//!
//! The portable slab test computes `(plane − origin) · (1/dir)` (a subtraction, then
//! a product) and widens the exit distance by a few ulps as Ize does ("Robust BVH
//! Ray Traversal", JCGT 2013), so a box is never missed by a ray that hits a
//! primitive inside it. The AVX2 and AVX-512 single-ray traversals compute
//! `plane · (1/dir) − origin · (1/dir)` in one fused multiply-add instead, one
//! rounding and one operation shorter on the chain that a ray's node steps wait on
//! (Embree's form); `origin · (1/dir)` is rounded once per ray, with an error that
//! grows with the origin's distance from the world's origin rather than with the
//! distance to the box, so it is taken as two offsets, one moved up and one down by
//! more than that error ([`BoxRay::single`]): the entry distance is never later, the
//! exit never earlier, than exact arithmetic would put them. The batch keeps the
//! portable form, which needs fewer of a ray's values reloaded at each of its steps
//! (docs/benchmarks.md). The paths therefore visit leaves in different orders at
//! times, which leaves their results unchanged, as the leaf test's ties do not
//! depend on that order (`Nearest` in `accel.rs`). The distances'
//! maxima, minima, widening and compares work on their bits as integers
//! ([`ordered`]), exact for what the test decides. Direction components smaller
//! than ±`f32::MIN_POSITIVE` (or than 2⁻¹⁰⁰ of the origin's coordinate, where that
//! is larger) are replaced by it, so no `0 · ∞` NaN arises and `origin · (1/dir)`
//! stays finite; and
//! child boxes are stored one ulp larger on every side, so that a ray with a zero
//! component (an axis-aligned ray) that hits a primitive has its origin strictly
//! inside that slab and sees the slab as unbounded, rather than leaving it at
//! `t = 0` when the origin lies exactly in a face plane (a vertical ray through a
//! box's edge, found by the tests). Empty child slots have the box `[+∞, −∞]`,
//! which no ray enters.

mod build;
#[cfg(feature = "bvh-experiments")]
pub(super) mod largest_child;
#[cfg(test)]
mod tests;

use std::mem::MaybeUninit;

use super::boxes::Bounds;
use crate::simd_path::isa::{AVX2, AVX512};

pub(super) use super::triangle::PACK;
pub(super) use build::TopNode;

/// Children per node.
pub(super) const WIDTH: usize = 8;
/// Most primitives in one leaf: one pack. The triangle layer (`Accel`) relies on
/// this and tests a leaf's first pack only.
pub(super) const MAX_LEAF: usize = PACK;
const _: () = assert!(MAX_LEAF == PACK, "a leaf must be one pack");

/// Child reference: an inner node's index, or, with [`LEAF_BIT`] set, a leaf's first
/// pack (low [`COUNT_SHIFT`] bits) and primitive count (the bits above, up to
/// [`MAX_LEAF`]). An empty child slot is a leaf of count 0. The build refuses a tree
/// with more nodes or packs than these fields hold ([`TreeTooLarge`]).
const LEAF_BIT: u32 = 1 << 31;
const COUNT_SHIFT: u32 = 27;
const INDEX_MASK: u32 = (1 << COUNT_SHIFT) - 1;
const EMPTY: u32 = LEAF_BIT;

/// Binary-tree depth from which splits are at the median (bounds the final depth by
/// this plus log₂ of the primitive count).
const MEDIAN_DEPTH: usize = 40;

/// The exit distance of a slab test is widened by this many ulps, added to its bits
/// (a positive f32's ulp is 2⁻²⁴ to 2⁻²³ of it): at least a factor 1 + 2⁻²⁰, which
/// covers Ize's 1 + 2γ₃ (≈ 1 + 3.6·10⁻⁷). An integer addition where a product would
/// take four cycles on the chain that one ray's node steps wait on.
const EXIT_WIDEN_ULPS: i32 = 16;
/// The current closest distance, compared with a box's entry distance, is widened by
/// this: the triangle test's distance has its own rounding error, and a box whose
/// entry distance lies a few ulps beyond an equally distant hit must still be entered
/// (ties on shared edges).
const TMAX_WIDEN: f32 = 1.0 + 1.0 / 65_536.0;
/// 2⁻¹⁰⁰: a direction component is at least this times the origin's coordinate on
/// its axis ([`BoxRay::new`]).
const DIR_FLOOR_OF_ORIGIN: f32 = f32::from_bits((127 - 100) << 23);

/// An 8-wide node: `bounds[2·axis]` are the children's minima along `axis`,
/// `bounds[2·axis + 1]` their maxima.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(32))]
pub(super) struct Node {
    bounds: [[f32; WIDTH]; 6],
    child: [u32; WIDTH],
}

/// The child reference of the inner node at `index`; `None` where the index would
/// reach [`LEAF_BIT`].
fn node_reference(index: usize) -> Option<u32> {
    u32::try_from(index)
        .ok()
        .filter(|&index| index & LEAF_BIT == 0)
}

/// The child reference of a leaf of `count` primitives from pack `first_pack`;
/// `None` where the pack lies beyond what [`INDEX_MASK`] addresses.
fn leaf_reference(first_pack: usize, count: usize) -> Option<u32> {
    debug_assert!(count <= MAX_LEAF, "a leaf of {count} primitives");
    let first_pack = u32::try_from(first_pack)
        .ok()
        .filter(|&p| p <= INDEX_MASK)?;
    Some(LEAF_BIT | ((count as u32) << COUNT_SHIFT) | first_pack)
}

/// A tree with more nodes or packs than its child references address: 2³¹ nodes or
/// 2²⁷ packs (a pack holds up to 8 triangles, so the packs are the limit: some
/// hundreds of millions of triangles). The build checks, because a pack index past
/// 2²⁷ would run into the count's bits and name another leaf.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct TreeTooLarge {
    /// "nodes" or "packs".
    pub part: &'static str,
    /// The most of them that can be addressed.
    pub limit: usize,
}

impl TreeTooLarge {
    fn nodes() -> TreeTooLarge {
        TreeTooLarge {
            part: "nodes",
            limit: LEAF_BIT as usize,
        }
    }

    fn packs() -> TreeTooLarge {
        TreeTooLarge {
            part: "packs",
            limit: INDEX_MASK as usize + 1,
        }
    }
}

impl Node {
    fn empty() -> Node {
        let mut bounds = [[f32::INFINITY; WIDTH]; 6];
        for axis in 0..3 {
            bounds[2 * axis + 1] = [f32::NEG_INFINITY; WIDTH];
        }
        Node {
            bounds,
            child: [EMPTY; WIDTH],
        }
    }

    /// Stores child `i`'s box one ulp larger on every side (see the module
    /// documentation, "Robustness").
    fn set_bounds(&mut self, i: usize, b: &Bounds) {
        let b = widened(b);
        for axis in 0..3 {
            self.bounds[2 * axis][i] = b.min[axis];
            self.bounds[2 * axis + 1][i] = b.max[axis];
        }
    }

    fn child_bounds(&self, i: usize) -> Bounds {
        Bounds {
            min: std::array::from_fn(|axis| self.bounds[2 * axis][i]),
            max: std::array::from_fn(|axis| self.bounds[2 * axis + 1][i]),
        }
    }
}

/// `b` one ulp larger on every side, with no face at a subnormal coordinate: a face
/// moved by one ulp from 0 (as every mesh centred on or mirrored about a coordinate
/// plane has) would lie at ±1.4·10⁻⁴⁵, and on x86 a fused multiply-add with a
/// subnormal product takes a microcode assist of about a hundred cycles, unless the
/// thread flushes subnormals to zero (Embree asks its callers to; Coatlab does not,
/// as that would change the rest of its arithmetic). Such a face moves further out,
/// to ∓`f32::MIN_POSITIVE` (docs/benchmarks.md).
fn widened(b: &Bounds) -> Bounds {
    let normal = |x: f32, outward: f32| {
        if x.abs() < f32::MIN_POSITIVE {
            outward
        } else {
            x
        }
    };
    Bounds {
        min: b.min.map(|x| normal(x.next_down(), -f32::MIN_POSITIVE)),
        max: b.max.map(|x| normal(x.next_up(), f32::MIN_POSITIVE)),
    }
}

/// A leaf's first pack and primitive count, from a child reference with [`LEAF_BIT`].
#[inline(always)]
fn leaf_parts(child: u32) -> (usize, usize) {
    (
        (child & INDEX_MASK) as usize,
        ((child & !LEAF_BIT) >> COUNT_SHIFT) as usize,
    )
}

/// Number of packs of a leaf of `count` primitives.
#[inline(always)]
pub(super) fn pack_count(count: usize) -> usize {
    count.div_ceil(PACK)
}

/// The 8-wide tree: nodes (the root at 0), slot order, and the pack layout of the
/// leaves. Empty when built from no boxes.
#[derive(Debug, Clone)]
pub(super) struct WideBvh {
    nodes: Vec<Node>,
    /// The caller's primitive index for each slot.
    order: Vec<u32>,
    /// For each pack, the slot in each lane; `u32::MAX` for an unused lane.
    pack_slots: Vec<[u32; PACK]>,
}

/// A tree's nodes as a slice, what the traversals read ([`WideBvh::nodes`]). The
/// batch traversal takes it into a local before its loop, so that the slice's
/// address and length stay in registers: reached through `&WideBvh` instead, they
/// were loaded again at every step wherever LLVM could not prove that the loop's
/// stores leave the tree's `Vec` alone, as inside `dispatch!`'s closure (+2.8 %
/// instructions in `closest_hits` against an entry point compiled with the target
/// features directly; docs/benchmarks.md).
#[derive(Debug, Clone, Copy)]
pub(super) struct Nodes<'a>(&'a [Node]);

/// A ray prepared for the slab tests.
#[derive(Debug, Clone, Copy)]
pub(super) struct BoxRay {
    origin: [f32; 3],
    inv_dir: [f32; 3],
    /// `origin · inv_dir` per axis, rounded and then moved up by more than its
    /// rounding error, and down: what the fused test subtracts from a near plane's
    /// `plane · inv_dir`, and from a far plane's.
    near_offset: [f32; 3],
    far_offset: [f32; 3],
    /// Per axis, the plane row by which the ray enters a box (its minimum where
    /// the direction is positive, its maximum where negative) and the one by which
    /// it leaves.
    near: [PlaneRow; 3],
    far: [PlaneRow; 3],
}

/// Where a row of [`Node::bounds`] starts in the node's planes taken as one array
/// of 48: an enum rather than an integer, so that LLVM knows every start is at most
/// 40 and a row of 8 from it needs no bounds check; a start times 4 is an x86
/// address by itself (a row index would need a shift at every step); and 32 bits
/// wide, so that a batch lane's six starts are six plain loads (as bytes, LLVM
/// merged the loads and unpacked them with shifts). Held as the direction's signs
/// instead, the batch rebuilt six row offsets from them at every step, 15
/// instructions (docs/benchmarks.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
enum PlaneRow {
    MinX = 0,
    MaxX = 8,
    MinY = 16,
    MaxY = 24,
    MinZ = 32,
    MaxZ = 40,
}

impl PlaneRow {
    /// The entry and exit rows of `axis` for a direction whose reciprocal is
    /// `inv_dir`.
    #[inline(always)]
    fn entry_exit(axis: usize, inv_dir: f32) -> (PlaneRow, PlaneRow) {
        let (min, max) = match axis {
            0 => (PlaneRow::MinX, PlaneRow::MaxX),
            1 => (PlaneRow::MinY, PlaneRow::MaxY),
            _ => (PlaneRow::MinZ, PlaneRow::MaxZ),
        };
        if inv_dir < 0.0 {
            (max, min)
        } else {
            (min, max)
        }
    }

    /// The row's 8 planes.
    #[inline(always)]
    fn of(self, node: &Node) -> &[f32; WIDTH] {
        let start = self as usize;
        match node.bounds.as_flattened()[start..].first_chunk() {
            Some(row) => row,
            None => unreachable!("plane row {start} past the node's 48 planes"),
        }
    }
}

impl BoxRay {
    /// For a finite origin and a finite, non-zero direction, for the unfused box
    /// test (the batch's, and every traversal's on the portable path): without the
    /// fused test's offsets, which are NaN here, so that a fused test given this
    /// ray would miss every box rather than pass unnoticed.
    #[inline(always)]
    pub fn new(origin: [f32; 3], dir: [f32; 3]) -> BoxRay {
        BoxRay::prepared(origin, dir, false)
    }

    /// [`BoxRay::new`] for the single-ray traversals ([`Nodes::closest`],
    /// [`Nodes::any`]), which take the fused test where `ISA` is AVX2 or AVX-512:
    /// with its offsets there (the batch does not pay for them).
    #[inline(always)]
    pub fn single<const ISA: u8>(origin: [f32; 3], dir: [f32; 3]) -> BoxRay {
        BoxRay::prepared(origin, dir, ISA >= AVX2)
    }

    /// The ray, with the fused test's offsets where `fused`.
    ///
    /// A direction component below `f32::MIN_POSITIVE`, or below 2⁻¹⁰⁰ of the
    /// origin's coordinate on that axis, is replaced by that bound (its sign kept):
    /// ±0 and subnormals would give ±∞ and then 0 · ∞ = NaN for a plane through the
    /// origin, and the second bound keeps `origin · (1/dir)` below 2¹⁰⁰, so the
    /// fused test's offsets are finite. A larger component shortens the slab's
    /// distances, but by the second bound a box face other than the one the origin
    /// lies on is at least an ulp of the origin's coordinate away, so at least 2⁷⁵
    /// (in units of `|dir|`) along the ray, beyond any scene.
    #[inline(always)]
    fn prepared(origin: [f32; 3], dir: [f32; 3], fused: bool) -> BoxRay {
        let inv_dir: [f32; 3] = std::array::from_fn(|axis| {
            let least = f32::MIN_POSITIVE.max(origin[axis].abs() * DIR_FLOOR_OF_ORIGIN);
            let d = dir[axis];
            let d = if d.abs() < least {
                least.copysign(d)
            } else {
                d
            };
            1.0 / d
        });
        let (near_offset, far_offset) = if fused {
            // The product's rounding error is at most 2⁻²⁴ of it, the offset's own
            // rounding as much again: a margin of 2⁻²² of it covers both, and
            // `MIN_POSITIVE` a product rounded among the subnormals.
            let scaled: [f32; 3] = std::array::from_fn(|axis| origin[axis] * inv_dir[axis]);
            let margin = scaled.map(|c| c.abs() * (1.0 / 4_194_304.0) + f32::MIN_POSITIVE);
            (
                std::array::from_fn(|axis| scaled[axis] + margin[axis]),
                std::array::from_fn(|axis| scaled[axis] - margin[axis]),
            )
        } else {
            ([f32::NAN; 3], [f32::NAN; 3])
        };
        let rows: [(PlaneRow, PlaneRow); 3] =
            std::array::from_fn(|axis| PlaneRow::entry_exit(axis, inv_dir[axis]));
        BoxRay {
            origin,
            inv_dir,
            near_offset,
            far_offset,
            near: rows.map(|r| r.0),
            far: rows.map(|r| r.1),
        }
    }

    /// The children hit within `[0, t_max]` (bit i for child i) and each one's
    /// entry distance; with `FUSED` (taken only with AVX2 or AVX-512, where the
    /// multiply-add is one instruction), by the fused form of the module
    /// documentation.
    #[inline(always)]
    fn hit_children<const ISA: u8, const FUSED: bool>(
        &self,
        node: &Node,
        t_max: f32,
    ) -> (u32, [f32; WIDTH]) {
        #[cfg(target_arch = "x86_64")]
        if ISA == AVX512 {
            // SAFETY: `ISA` is AVX512 only where AVX-512 is enabled and the CPU has
            // it (see the module documentation).
            return unsafe { avx512::hit_children::<FUSED>(self, node, t_max) };
        }
        let [bnx, bny, bnz] = self.near.map(|row| row.of(node));
        let [bfx, bfy, bfz] = self.far.map(|row| row.of(node));
        let [ox, oy, oz] = self.origin;
        let [rx, ry, rz] = self.inv_dir;
        let [nx, ny, nz] = self.near_offset;
        let [fx, fy, fz] = self.far_offset;
        // A plane's distance, fused (`offset`: the ray's offset for that plane's
        // side) or not; the choice is a constant, so each form compiles alone.
        let distance = |plane: f32, origin: f32, inv_dir: f32, offset: f32| {
            ordered(if FUSED && ISA >= AVX2 {
                plane.mul_add(inv_dir, -offset)
            } else {
                (plane - origin) * inv_dir
            })
        };
        let mut entry = [0i32; WIDTH];
        let mut beyond = [0i32; WIDTH];
        for i in 0..WIDTH {
            let tnx = distance(bnx[i], ox, rx, nx);
            let tny = distance(bny[i], oy, ry, ny);
            let tnz = distance(bnz[i], oz, rz, nz);
            let tfx = distance(bfx[i], ox, rx, fx);
            let tfy = distance(bfy[i], oy, ry, fy);
            let tfz = distance(bfz[i], oz, rz, fz);
            entry[i] = tnx.max(tny).max(tnz.max(0));
            beyond[i] = exit_beyond(tfx.min(tfy).min(tfz));
        }
        let mask = hit_mask::<ISA>(&entry, &beyond, exit_beyond(ordered(t_max)));
        (mask, entry.map(|e| f32::from_bits(e as u32)))
    }
}

/// A distance as the integer of its bits, which orders non-negative distances as
/// their values do, and every negative one (−0 included) below every non-negative
/// one. The slab test takes its maxima and minima and compares on these (Embree
/// does the same): one cycle each where the f32 forms take four, on the chain that
/// one ray's node steps wait on (docs/benchmarks.md). Exact for what the traversal
/// needs: an entry distance is the maximum with +0, so non-negative, and its value is
/// the f32 maximum's; an exit distance that is negative, as an integer or as a value,
/// misses the box either way — apart from an exit of exactly −0, the f32 form's hit at
/// `t = 0` and a miss here, which only a ray whose origin lies exactly on a child
/// box's far face has: that box is stored one ulp larger than its content, which
/// then lies wholly behind the ray, and a triangle hit needs `t > 0` anyway.
#[inline(always)]
fn ordered(distance: f32) -> i32 {
    distance.to_bits() as i32
}

/// The least [`ordered`] distance beyond `exit`, widened by [`EXIT_WIDEN_ULPS`]: a
/// box is hit where its entry lies below this (so `<`, which x86 compares in one
/// instruction, in place of `≤`, which needs two). Wrapping, so that no input
/// panics; an exit as large as +∞ stays far below `i32::MAX`, and a negative one stays
/// negative.
#[inline(always)]
fn exit_beyond(exit: i32) -> i32 {
    exit.wrapping_add(EXIT_WIDEN_ULPS + 1)
}

/// Bit i set where `entry[i] < beyond[i]` and `entry[i] < t_beyond` ([`ordered`]
/// distances), the same bits as `entry[i] < min(beyond[i], t_beyond)`. With `AVX2`,
/// integer compares and one `vmovmskps` (LLVM builds the mask of the portable loop
/// with four pack and logic instructions instead); LLVM folds the two compares
/// into a minimum and one compare, which on integers is as short a chain.
#[inline(always)]
fn hit_mask<const ISA: u8>(entry: &[i32; WIDTH], beyond: &[i32; WIDTH], t_beyond: i32) -> u32 {
    #[cfg(target_arch = "x86_64")]
    if ISA >= AVX2 {
        use std::arch::x86_64::{
            _mm256_and_si256, _mm256_castsi256_ps, _mm256_cmpgt_epi32, _mm256_movemask_ps,
            _mm256_set1_epi32, _mm256_setr_epi32,
        };
        // SAFETY: `ISA` is AVX2 or above only where AVX2 is enabled and the CPU has
        // it (see the module documentation); these intrinsics take and return values
        // only (no memory access).
        return unsafe {
            let vector = |a: &[i32; WIDTH]| {
                _mm256_setr_epi32(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7])
            };
            let entry = vector(entry);
            let within_exit = _mm256_cmpgt_epi32(vector(beyond), entry);
            let within_t_max = _mm256_cmpgt_epi32(_mm256_set1_epi32(t_beyond), entry);
            let both = _mm256_and_si256(within_exit, within_t_max);
            _mm256_movemask_ps(_mm256_castsi256_ps(both)) as u32
        };
    }
    hit_mask_portable(entry, beyond, t_beyond)
}

/// The portable [`hit_mask`].
#[inline(always)]
fn hit_mask_portable(entry: &[i32; WIDTH], beyond: &[i32; WIDTH], t_beyond: i32) -> u32 {
    let mut mask = 0;
    for i in 0..WIDTH {
        mask |= u32::from(entry[i] < beyond[i] && entry[i] < t_beyond) << i;
    }
    mask
}

/// The slab test of [`BoxRay::hit_children`] with AVX-512: per axis, the near
/// and far planes of the 8 children in one 16-lane register, `(plane − origin) ·
/// (1/dir)` (or its fused form) for both at once; then over the axes the maximum in
/// the near lanes and the minimum in the far lanes of their [`ordered`] bits (a
/// maximum, then a masked minimum), and the compare into a mask register. Lane by
/// lane the operations of the AVX2 code, so the same bits.
#[cfg(target_arch = "x86_64")]
mod avx512 {
    use std::arch::x86_64::{
        __m512i, _mm256_add_epi32, _mm256_castsi256_ps, _mm256_cmplt_epi32_mask, _mm256_loadu_ps,
        _mm256_min_epi32, _mm256_set1_epi32, _mm256_storeu_ps, _mm512_castps_si512,
        _mm512_castps256_ps512, _mm512_castsi512_si256, _mm512_extracti32x8_epi32, _mm512_fmsub_ps,
        _mm512_insertf32x8, _mm512_load_si512, _mm512_mask_blend_ps, _mm512_mask_min_epi32,
        _mm512_max_epi32, _mm512_mul_ps, _mm512_set1_ps, _mm512_sub_ps,
    };

    use super::{BoxRay, Node, WIDTH, exit_beyond, ordered};

    /// The far lanes, 8–15.
    const FAR: u16 = 0xff00;

    /// 16 i32 lanes, aligned for one AVX-512 load.
    #[repr(C, align(64))]
    struct Lanes16([i32; 16]);

    /// Lanes 0–7 zero (the entry distance is at least +0), lanes 8–15 `i32::MAX`
    /// (no bound on the exit distance): the portable code's `max(tnz, 0)`, and a
    /// no-op minimum that keeps the two halves' operations together.
    static FLOOR: Lanes16 = Lanes16([
        0,
        0,
        0,
        0,
        0,
        0,
        0,
        0,
        i32::MAX,
        i32::MAX,
        i32::MAX,
        i32::MAX,
        i32::MAX,
        i32::MAX,
        i32::MAX,
        i32::MAX,
    ]);

    /// The maximum of `a` and `b` in the near lanes, their minimum in the far ones.
    #[inline(always)]
    unsafe fn near_max_far_min(a: __m512i, b: __m512i) -> __m512i {
        // SAFETY: as in `hit_children`.
        unsafe { _mm512_mask_min_epi32(_mm512_max_epi32(a, b), FAR, a, b) }
    }

    /// To be called only where the CPU has AVX-512 F, VL and DQ, and inlined only
    /// into code compiled with them (`ISA` = AVX512).
    #[inline(always)]
    pub(super) unsafe fn hit_children<const FUSED: bool>(
        ray: &BoxRay,
        node: &Node,
        t_max: f32,
    ) -> (u32, [f32; WIDTH]) {
        // SAFETY: the intrinsics need the features the caller guarantees; the loads
        // read `node.bounds` rows (8 f32 each) and `FLOOR` (16 i32, 64-byte
        // aligned), all in bounds.
        unsafe {
            // Axis `axis`: [near planes, far planes] − origin, times 1/dir, as
            // ordered bits.
            let axis = |axis: usize| {
                // The near row in lanes 0–7, the far one in 8–15, chosen by
                // index as in the portable code (no branch on the ray's signs).
                let near = _mm256_loadu_ps(ray.near[axis].of(node).as_ptr());
                let far = _mm256_loadu_ps(ray.far[axis].of(node).as_ptr());
                let planes = _mm512_insertf32x8::<1>(_mm512_castps256_ps512(near), far);
                let inv_dir = _mm512_set1_ps(ray.inv_dir[axis]);
                _mm512_castps_si512(if FUSED {
                    let offsets = _mm512_mask_blend_ps(
                        FAR,
                        _mm512_set1_ps(ray.near_offset[axis]),
                        _mm512_set1_ps(ray.far_offset[axis]),
                    );
                    _mm512_fmsub_ps(planes, inv_dir, offsets)
                } else {
                    _mm512_mul_ps(
                        _mm512_sub_ps(planes, _mm512_set1_ps(ray.origin[axis])),
                        inv_dir,
                    )
                })
            };
            let (x, y, z) = (axis(0), axis(1), axis(2));
            let floor = _mm512_load_si512(FLOOR.0.as_ptr().cast());
            let both = near_max_far_min(near_max_far_min(x, y), near_max_far_min(z, floor));
            let entry = _mm512_castsi512_si256(both);
            // `exit_beyond` of each exit: `exit_beyond(0)` is what it adds.
            let beyond = _mm256_add_epi32(
                _mm512_extracti32x8_epi32::<1>(both),
                _mm256_set1_epi32(exit_beyond(0)),
            );
            let t_beyond = _mm256_set1_epi32(exit_beyond(ordered(t_max)));
            let limit = _mm256_min_epi32(beyond, t_beyond);
            let mask = _mm256_cmplt_epi32_mask(entry, limit);
            let mut out = [0.0f32; WIDTH];
            _mm256_storeu_ps(out.as_mut_ptr(), _mm256_castsi256_ps(entry));
            (u32::from(mask), out)
        }
    }
}

/// Asks the cache for the memory of `value` (a hint: no fault, no effect on results).
/// Incoherent rays are bound by memory latency, one dependent miss per level; fetching
/// every child that a ray will visit as soon as it is known to be hit overlaps those
/// misses.
#[inline(always)]
pub(super) fn prefetch<T>(value: &T) {
    #[cfg(all(target_arch = "x86_64", target_feature = "sse"))]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let start = (value as *const T).cast::<i8>();
        for offset in (0..std::mem::size_of::<T>()).step_by(64) {
            // SAFETY: `_mm_prefetch` needs SSE, which the cfg guarantees at compile
            // time; a prefetch never faults and `start + offset` stays inside `value`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start.wrapping_add(offset)) };
        }
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "sse")))]
    let _ = value;
}

/// Where a node step leaves the hit children it does not visit next.
trait PushStack {
    fn push(&mut self, child: u32, entry: f32);
}

/// Entries of the single-ray query's stack ([`BoundedStack`]): a ray holds at most
/// 7 entries for each node above its current one, so this is room for 18 levels of
/// nodes with every child hit; the Lamborghini's tree is 10 nodes deep, and the
/// default car's rays in `tests/accel.rs` used at most 16 entries.
const SINGLE_RAY_STACK: usize = 128;

/// The single-ray query's stack: a fixed array, left uninitialised until pushed
/// (zeroing even 64 entries cost ~49 instructions a ray, more than a node step),
/// and no heap to spill into, so that a push is never a call, which would take the
/// node loop's values out of registers. When full it drops the entry and says so
/// ([`BoundedStack::overflowed`]); the query is then run again with [`Stack`].
struct BoundedStack<const CAPACITY: usize> {
    items: [MaybeUninit<(u32, f32)>; CAPACITY],
    /// `items[..len]` have been written.
    len: usize,
    overflowed: bool,
}

impl<const CAPACITY: usize> BoundedStack<CAPACITY> {
    #[inline(always)]
    fn new() -> Self {
        BoundedStack {
            items: [const { MaybeUninit::uninit() }; CAPACITY],
            len: 0,
            overflowed: false,
        }
    }

    /// Pushes the entry unless the stack is full; whether it did.
    #[inline(always)]
    fn try_push(&mut self, child: u32, entry: f32) -> bool {
        match self.items.get_mut(self.len) {
            Some(slot) => {
                slot.write((child, entry));
                self.len += 1;
                true
            }
            None => false,
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        let len = self.len.checked_sub(1)?;
        self.len = len;
        // SAFETY: `items[..len + 1]` have been written (`try_push` writes an item
        // before it counts it), and `len < CAPACITY`, as `len + 1` items fit.
        Some(unsafe { self.items.get_unchecked(len).assume_init() })
    }

    /// Pops entries until one whose entry distance is within `t_box`, and returns
    /// its child; `None` when the stack runs out first.
    #[inline(always)]
    fn pop_within(&mut self, t_box: f32) -> Option<u32> {
        pop_within(|| self.pop(), t_box)
    }
}

/// Pops entries with `pop` until one whose entry distance is within `t_box`, and
/// returns its child; `None` when they run out first.
#[inline(always)]
fn pop_within(mut pop: impl FnMut() -> Option<(u32, f32)>, t_box: f32) -> Option<u32> {
    loop {
        let (child, entry) = pop()?;
        if entry <= t_box {
            return Some(child);
        }
    }
}

impl<const CAPACITY: usize> PushStack for BoundedStack<CAPACITY> {
    #[inline(always)]
    fn push(&mut self, child: u32, entry: f32) {
        if !self.try_push(child, entry) {
            self.overflowed = true;
        }
    }
}

/// Traversal stack that grows: a [`BoundedStack`] with a heap overflow that a tree
/// of ordinary depth never touches (the fixed part needs neither an allocation nor
/// zeroing per ray; the overflow keeps pathological trees correct).
struct Stack {
    fixed: BoundedStack<64>,
    /// Entries pushed while `fixed` was full: all newer than its own.
    overflow: Vec<(u32, f32)>,
}

impl PushStack for Stack {
    #[inline(always)]
    fn push(&mut self, child: u32, entry: f32) {
        if !self.fixed.try_push(child, entry) {
            self.overflow.push((child, entry));
        }
    }
}

impl Stack {
    #[inline(always)]
    fn new() -> Stack {
        Stack {
            fixed: BoundedStack::new(),
            overflow: Vec::new(),
        }
    }

    #[inline(always)]
    fn clear(&mut self) {
        self.fixed.len = 0;
        self.overflow.clear();
    }

    /// Pops entries until one whose entry distance is within `t_box`, and returns
    /// its child; `None` when the stack runs out first.
    #[inline(always)]
    fn pop_within(&mut self, t_box: f32) -> Option<u32> {
        pop_within(|| self.pop(), t_box)
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        self.overflow.pop().or_else(|| self.fixed.pop())
    }
}

/// The state of one ray's closest-hit traversal, resumable step by step
/// ([`Nodes::closest_step`]); reusable for the next ray ([`Traversal::start`]), so a
/// batch sets up its stacks once.
pub(super) struct Traversal {
    stack: Stack,
    /// The node or leaf to visit next.
    current: u32,
    /// The closest hit so far (the query's `t_max` before any).
    t_max: f32,
    /// `t_max · TMAX_WIDEN`, what the node steps compare entry distances with:
    /// updated at the leaves, which change `t_max`, rather than at every node.
    t_box: f32,
}

impl Traversal {
    #[inline(always)]
    pub fn new() -> Traversal {
        Traversal {
            stack: Stack::new(),
            current: 0,
            t_max: 0.0,
            t_box: 0.0,
        }
    }

    /// Starts a new ray at the root with `t_max`.
    #[inline(always)]
    pub fn start(&mut self, t_max: f32) {
        self.stack.clear();
        self.current = 0;
        self.t_max = t_max;
        self.t_box = t_max * TMAX_WIDEN;
    }
}

impl Nodes<'_> {
    /// Starts fetching a hit child: an inner node here, a leaf's packs through
    /// `fetch_leaf(first_pack, primitive_count)`.
    #[inline(always)]
    fn fetch(&self, child: u32, fetch_leaf: &impl Fn(usize, usize)) {
        if child & LEAF_BIT != 0 {
            let (first, count) = leaf_parts(child);
            fetch_leaf(first, count);
        } else if let Some(node) = self.0.get(child as usize) {
            prefetch(node);
        }
    }

    /// Closest hit: `leaf(first_pack, primitive_count, t_max)` intersects a leaf's
    /// packs and returns the new `t_max` (smaller when it found a closer hit);
    /// `fetch_leaf(first_pack, primitive_count)` may prefetch them.
    ///
    /// One ray on its own, with its state in locals and a stack that never
    /// allocates ([`BoundedStack`]); in the rare tree deep enough to fill that
    /// stack, the ray is traced again with the stack that grows, through the steps
    /// of [`Nodes::closest_step`] (the same hit, bit for bit: no hit depends on the
    /// order in which leaves are visited).
    #[inline(always)]
    pub fn closest<const ISA: u8>(
        &self,
        ray: &BoxRay,
        t_max: f32,
        mut leaf: impl FnMut(usize, usize, f32) -> f32,
        fetch_leaf: impl Fn(usize, usize),
    ) {
        self.closest_within::<ISA, SINGLE_RAY_STACK>(ray, t_max, &mut leaf, &fetch_leaf);
    }

    /// [`Nodes::closest`] with a bounded stack of `CAPACITY` entries; `true` where
    /// it filled up and the stack that grows took over.
    #[inline(always)]
    pub(super) fn closest_within<const ISA: u8, const CAPACITY: usize>(
        &self,
        ray: &BoxRay,
        t_max: f32,
        leaf: &mut impl FnMut(usize, usize, f32) -> f32,
        fetch_leaf: &impl Fn(usize, usize),
    ) -> bool {
        if self.closest_bounded::<ISA, CAPACITY>(ray, t_max, leaf, fetch_leaf) {
            return false;
        }
        self.closest_growing::<ISA>(ray, t_max, leaf, fetch_leaf);
        true
    }

    /// [`Nodes::closest`] with a stack of `CAPACITY` entries; `false`, with the
    /// query unfinished, where that stack filled up (the caller then runs it again
    /// from the start: `leaf` only ever reports real hits, and the second run
    /// reports the closest last).
    ///
    /// The nodes are visited in a loop of their own until a leaf is reached, which
    /// keeps the ray's values in registers over the node steps (in one loop over
    /// nodes and leaves alike, LLVM kept them on the stack, as the leaf test needs
    /// most vector registers; docs/benchmarks.md).
    #[inline(always)]
    fn closest_bounded<const ISA: u8, const CAPACITY: usize>(
        &self,
        ray: &BoxRay,
        mut t_max: f32,
        leaf: &mut impl FnMut(usize, usize, f32) -> f32,
        fetch_leaf: &impl Fn(usize, usize),
    ) -> bool {
        if self.0.is_empty() {
            return true;
        }
        let mut stack = BoundedStack::<CAPACITY>::new();
        let mut t_box = t_max * TMAX_WIDEN;
        let mut current = 0u32;
        loop {
            // A fresh copy of the ray for each run of node steps: its values then
            // live only across that run, and LLVM keeps them in registers there.
            // Given the ray itself, LLVM hoisted them out of the outer loop, where
            // they compete with the leaf test for the vector registers, and it
            // reloaded each from the stack at every node step (−10 % instructions
            // a ray with the copy; docs/benchmarks.md). `black_box` stops the copy
            // from being folded back into the ray.
            let ray = &{ *std::hint::black_box(ray) };
            while current & LEAF_BIT == 0 {
                let node = &self.0[current as usize];
                current = match self
                    .enter::<ISA, false, true>(node, ray, t_box, &mut stack, fetch_leaf)
                {
                    Some(next) => next,
                    None => match stack.pop_within(t_box) {
                        Some(next) => next,
                        None => return !stack.overflowed,
                    },
                };
            }
            let (first, count) = leaf_parts(current);
            t_max = leaf(first, count, t_max);
            t_box = t_max * TMAX_WIDEN;
            current = match stack.pop_within(t_box) {
                Some(next) => next,
                None => return !stack.overflowed,
            };
        }
    }

    /// [`Nodes::closest`] with the stack that grows: the steps of
    /// [`Nodes::closest_step`] back to back.
    #[inline(always)]
    fn closest_growing<const ISA: u8>(
        &self,
        ray: &BoxRay,
        t_max: f32,
        leaf: &mut impl FnMut(usize, usize, f32) -> f32,
        fetch_leaf: &impl Fn(usize, usize),
    ) {
        let mut traversal = Traversal::new();
        traversal.start(t_max);
        while self.closest_step::<ISA>(ray, &mut traversal, leaf, fetch_leaf) {}
    }

    /// Tests an inner node's children: pushes the farther hit ones with their entry
    /// distances (nearest on top), having asked the cache for them, and returns the
    /// nearest; `None` when no child is hit within `t_box`. With `FETCH_NEXT` it
    /// asks the cache for the nearest too: a batch's other rays work before it is
    /// read, whereas one ray on its own reads it at once, and the request would only
    /// cost instructions (the node's address and bounds check, four prefetches).
    /// `FUSED` as for [`BoxRay::hit_children`].
    #[inline(always)]
    fn enter<const ISA: u8, const FETCH_NEXT: bool, const FUSED: bool>(
        &self,
        node: &Node,
        ray: &BoxRay,
        t_box: f32,
        stack: &mut impl PushStack,
        fetch_leaf: &impl Fn(usize, usize),
    ) -> Option<u32> {
        let (mut mask, entry) = ray.hit_children::<ISA, FUSED>(node, t_box);
        // One or two children hit (most steps): the order the sort below would
        // give, without it.
        if mask.is_power_of_two() {
            let child = node.child[mask.trailing_zeros() as usize];
            if FETCH_NEXT {
                self.fetch(child, fetch_leaf);
            }
            return Some(child);
        }
        let rest = mask & mask.wrapping_sub(1);
        if rest.is_power_of_two() {
            let (a, b) = (
                mask.trailing_zeros() as usize,
                rest.trailing_zeros() as usize,
            );
            let (child_a, child_b) = (node.child[a], node.child[b]);
            // Nearer first; on equal entries the later child, as the sort's.
            let ((next, _), (pushed, t)) = if entry[a] < entry[b] {
                ((child_a, entry[a]), (child_b, entry[b]))
            } else {
                ((child_b, entry[b]), (child_a, entry[a]))
            };
            if FETCH_NEXT {
                self.fetch(next, fetch_leaf);
            }
            self.fetch(pushed, fetch_leaf);
            stack.push(pushed, t);
            return Some(next);
        }
        if mask == 0 {
            return None;
        }
        // Hit children, sorted by decreasing entry distance (insertion sort:
        // rarely more than three).
        let mut hits = [(0u32, 0.0f32); WIDTH];
        let mut n = 0;
        while mask != 0 {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            let item = (node.child[i], entry[i]);
            let mut j = n;
            while j > 0 && hits[j - 1].1 < item.1 {
                hits[j] = hits[j - 1];
                j -= 1;
            }
            hits[j] = item;
            n += 1;
        }
        for &(child, t) in &hits[..n - 1] {
            self.fetch(child, fetch_leaf);
            stack.push(child, t);
        }
        let next = hits[n - 1].0;
        if FETCH_NEXT {
            self.fetch(next, fetch_leaf);
        }
        Some(next)
    }

    /// One step of a closest-hit traversal: visits the traversal's current node or
    /// leaf and moves on to the next one, which it has asked the cache for. Returns
    /// `false` when the traversal is over. [`Nodes::closest`] runs the steps of one
    /// ray back to back; a batch interleaves the steps of several rays, so that the
    /// memory each ray waits for arrives while the others work. The results are the
    /// same either way, bit for bit.
    #[inline(always)]
    pub fn closest_step<const ISA: u8>(
        &self,
        ray: &BoxRay,
        traversal: &mut Traversal,
        leaf: &mut impl FnMut(usize, usize, f32) -> f32,
        fetch_leaf: &impl Fn(usize, usize),
    ) -> bool {
        if self.0.is_empty() {
            return false;
        }
        let current = traversal.current;
        if current & LEAF_BIT != 0 {
            let (first, count) = leaf_parts(current);
            traversal.t_max = leaf(first, count, traversal.t_max);
            traversal.t_box = traversal.t_max * TMAX_WIDEN;
        } else if let Some(next) = self.enter::<ISA, true, false>(
            &self.0[current as usize],
            ray,
            traversal.t_box,
            &mut traversal.stack,
            fetch_leaf,
        ) {
            traversal.current = next;
            return true;
        }
        // Next: the nearest pending child not already beyond the closest hit.
        match traversal.stack.pop_within(traversal.t_box) {
            Some(next) => {
                traversal.current = next;
                true
            }
            None => false,
        }
    }

    /// Any hit: `leaf(first_pack, primitive_count)` says whether a leaf holds a hit;
    /// stops at the first. `fetch_leaf` as for [`Nodes::closest`].
    #[inline(always)]
    pub fn any<const ISA: u8>(
        &self,
        ray: &BoxRay,
        t_max: f32,
        mut leaf: impl FnMut(usize, usize) -> bool,
        fetch_leaf: impl Fn(usize, usize),
    ) -> bool {
        if self.0.is_empty() {
            return false;
        }
        let t_box = t_max * TMAX_WIDEN;
        let mut stack = Stack::new();
        let mut current = 0u32;
        loop {
            if current & LEAF_BIT != 0 {
                let (first, count) = leaf_parts(current);
                if leaf(first, count) {
                    return true;
                }
            } else {
                let node = &self.0[current as usize];
                let (mut mask, _) = ray.hit_children::<ISA, true>(node, t_box);
                if mask != 0 {
                    // No ordering: any hit ends the query.
                    let i = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    current = node.child[i];
                    while mask != 0 {
                        let i = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        self.fetch(node.child[i], &fetch_leaf);
                        stack.push(node.child[i], 0.0);
                    }
                    continue;
                }
            }
            match stack.pop() {
                Some((child, _)) => current = child,
                None => return false,
            }
        }
    }
}

impl WideBvh {
    /// The nodes, for a traversal.
    #[inline(always)]
    pub fn nodes(&self) -> Nodes<'_> {
        Nodes(&self.nodes)
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The caller's primitive index for each slot.
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// The slot in each lane of each pack (`u32::MAX`: unused lane).
    pub fn pack_slots(&self) -> &[[u32; PACK]] {
        &self.pack_slots
    }

    /// Checks the structure against the boxes it was built from: every node reached
    /// once, every child box inside its parent's, every primitive's box inside its
    /// leaf's, the slots a permutation, the packs covering each slot once with unused
    /// lanes only at the end of a leaf, and empty child slots unreachable.
    pub fn validate(&self, boxes: &[Bounds], bounds: Option<Bounds>) -> Result<(), String> {
        if self.nodes.is_empty() {
            return match (boxes.is_empty(), self.pack_slots.is_empty()) {
                (true, true) => Ok(()),
                _ => Err("no nodes, but primitives or packs".into()),
            };
        }
        let Some(bounds) = bounds else {
            return Err("nodes, but no bounds".into());
        };
        // The root's children are stored widened like all others.
        let bounds = widened(&bounds);
        if self.pack_slots.len() > INDEX_MASK as usize {
            return Err(format!(
                "{} packs: too many to address",
                self.pack_slots.len()
            ));
        }
        let mut node_seen = vec![false; self.nodes.len()];
        let mut slot_seen = vec![false; self.order.len()];
        let mut pack_seen = vec![false; self.pack_slots.len()];
        let mut pending = vec![(0usize, bounds, 0usize)];
        let mut deepest = 0;
        while let Some((index, parent, depth)) = pending.pop() {
            deepest = deepest.max(depth);
            match node_seen.get_mut(index) {
                None => return Err(format!("node {index} out of range")),
                Some(true) => return Err(format!("node {index} reached twice")),
                Some(seen) => *seen = true,
            }
            let node = &self.nodes[index];
            for i in 0..WIDTH {
                let child = node.child[i];
                let b = node.child_bounds(i);
                if child == EMPTY {
                    if b.min.iter().any(|&x| x != f32::INFINITY)
                        || b.max.iter().any(|&x| x != f32::NEG_INFINITY)
                    {
                        return Err(format!("node {index}: empty child {i} has box {b:?}"));
                    }
                    continue;
                }
                if !b.is_finite() || !parent.contains(&b) {
                    return Err(format!(
                        "node {index}: child {i}'s box {b:?} is not inside {parent:?}"
                    ));
                }
                if child & LEAF_BIT == 0 {
                    pending.push((child as usize, b, depth + 1));
                    continue;
                }
                let (first, count) = leaf_parts(child);
                if count == 0 || count > MAX_LEAF {
                    return Err(format!("node {index}: leaf of {count} primitives"));
                }
                let packs = pack_count(count);
                let Some(lanes) = self.pack_slots.get(first..first + packs) else {
                    return Err(format!("node {index}: packs {first}+{packs} out of range"));
                };
                for (p, lane_slots) in lanes.iter().enumerate() {
                    if std::mem::replace(&mut pack_seen[first + p], true) {
                        return Err(format!("pack {} in two leaves", first + p));
                    }
                    for (lane, &slot) in lane_slots.iter().enumerate() {
                        let used = p * PACK + lane < count;
                        if !used {
                            if slot != u32::MAX {
                                return Err(format!(
                                    "pack {}: lane {lane} past the leaf",
                                    first + p
                                ));
                            }
                            continue;
                        }
                        let Some(seen) = slot_seen.get_mut(slot as usize) else {
                            return Err(format!("pack {}: slot {slot} out of range", first + p));
                        };
                        if std::mem::replace(seen, true) {
                            return Err(format!("slot {slot} in two leaves"));
                        }
                        let prim = self.order[slot as usize] as usize;
                        match boxes.get(prim) {
                            Some(pb) if b.contains(pb) => {}
                            Some(pb) => {
                                return Err(format!(
                                    "primitive {prim}'s box {pb:?} is outside its leaf's {b:?}"
                                ));
                            }
                            None => {
                                return Err(format!("slot {slot}: primitive {prim} out of range"));
                            }
                        }
                    }
                }
            }
        }
        if let Some(i) = node_seen.iter().position(|s| !s) {
            return Err(format!("node {i} is unreachable"));
        }
        if let Some(i) = slot_seen.iter().position(|s| !s) {
            return Err(format!("slot {i} is in no leaf"));
        }
        if let Some(i) = pack_seen.iter().position(|s| !s) {
            return Err(format!("pack {i} is in no leaf"));
        }
        // Not a correctness limit (the traversal stack spills to the heap), but a
        // deep tree means the median fallback failed to bound it.
        let limit = MEDIAN_DEPTH + 2 + usize::BITS as usize;
        if deepest > limit {
            return Err(format!("depth {deepest} exceeds {limit}"));
        }
        Ok(())
    }
}
