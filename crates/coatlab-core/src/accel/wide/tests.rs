//! Unit tests of the 8-wide tree's private parts: a given top is kept, the AVX
//! hit mask agrees with the portable one, and the AVX-512 slab test with the AVX2
//! one in both forms; no path's slab test, fused or not, misses a box that the ray
//! enters; stored boxes have no subnormal face; the single-ray query's bounded
//! stack hands over to the growing one without changing a result.

use super::super::test_support::{XorShift, on_path, slivers};
use super::*;
use crate::simd_path::SimdPath;

/// A given top of the tree is kept: with the boxes' first and second halves as
/// its two leaves, the root's children hold exactly those halves, and the tree
/// validates.
#[test]
fn a_given_top_is_the_top_of_the_tree() {
    let (_, boxes) = slivers(20_000);
    let half = boxes.len() / 2;
    let top = [
        TopNode::Inner {
            left: 1,
            right: 2,
            refs: boxes.len(),
        },
        TopNode::Leaf { refs: half },
        TopNode::Leaf {
            refs: boxes.len() - half,
        },
    ];
    let mut bounds = Bounds::empty();
    boxes.iter().for_each(|b| bounds.grow(b));
    for threads in [1, 2] {
        let tree = WideBvh::build(&boxes, &top, 16, threads).expect("small tree");
        tree.validate(&boxes, Some(bounds)).expect("valid");
        let mut first: Vec<u32> = tree.order[..half].to_vec();
        first.sort_unstable();
        assert!(
            first.iter().copied().eq(0..half as u32),
            "{threads} threads"
        );
    }
}

/// The AVX2 mask (`movemask`) agrees with the portable one on the [`ordered`]
/// bits of random distances, zeros of both signs, infinities, NaN and raw integers
/// from one end of `i32` to the other (where the CPU has AVX2), and with one compare
/// against the smaller of the two limits.
#[test]
fn hit_mask_agrees_with_the_portable_mask() {
    on_path(SimdPath::Avx2, hit_mask_agrees);
}

#[inline(always)]
fn hit_mask_agrees() {
    let specials = [
        0.0,
        -0.0,
        1.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        f32::MIN_POSITIVE,
        -2.5,
    ]
    .map(ordered);
    let mut rng = XorShift(0x9e37_79b9_7f4a_7c15);
    let mut next = move || rng.next();
    let mut seen = [false; 2];
    for _ in 0..20_000 {
        let mut pick = || {
            let r = next();
            match r % 4 {
                0 => specials[(r >> 8) as usize % specials.len()],
                1 => (r >> 32) as u32 as i32,
                _ => ordered((r >> 40) as f32 / (1u64 << 20) as f32 - 8.0),
            }
        };
        let entry: [i32; WIDTH] = std::array::from_fn(|_| pick());
        let mut beyond: [i32; WIDTH] = std::array::from_fn(|_| pick());
        let picked_t = pick();
        // Exact ties, where `<` must not hold, and neighbours, where it must.
        beyond[(next() % WIDTH as u64) as usize] = entry[0];
        beyond[0] = entry[0];
        beyond[1] = entry[1].wrapping_add(1);
        let t_beyond = match next() % 4 {
            0 => entry[1],
            1 => entry[2].wrapping_add(1),
            _ => picked_t,
        };
        let mask = hit_mask::<AVX2>(&entry, &beyond, t_beyond);
        assert_eq!(
            mask,
            hit_mask_portable(&entry, &beyond, t_beyond),
            "{entry:?} {beyond:?} {t_beyond}"
        );
        let smaller = beyond.map(|l| l.min(t_beyond));
        let one = (0..WIDTH).fold(0, |m, i| m | u32::from(entry[i] < smaller[i]) << i);
        assert_eq!(mask, one, "{entry:?} {beyond:?} {t_beyond}");
        assert_eq!(mask & 1, 0, "a tie is not below");
        seen[usize::from(mask == 0)] = true;
    }
    assert_eq!(seen, [true, true]);
}

/// [`ordered`] distances order as their values where that matters to the slab
/// test: among non-negative values (−0 as +0 being the one exception, below it),
/// every negative value below every non-negative one; [`exit_beyond`] of an exit
/// lies above the exit widened by at least 1 + 2⁻²⁰ (so a box is never missed for
/// want of Ize's 1 + 2γ₃), and a negative exit stays below every entry.
#[test]
fn ordered_distances_order_as_the_slab_test_needs() {
    let mut rng = XorShift(0x51f1_5eed_0bad_cafe);
    let mut value = || {
        let r = rng.next();
        let magnitude = f32::from_bits((r >> 33) as u32 % 0x7f80_0001);
        if r & 1 == 0 { magnitude } else { -magnitude }
    };
    for _ in 0..200_000 {
        let (a, b) = (value(), value());
        if a >= 0.0 && b >= 0.0 && !(a == 0.0 && b == 0.0) {
            assert_eq!(ordered(a) < ordered(b), a < b, "{a} {b}");
        }
        if a < 0.0 || a.to_bits() == (-0.0f32).to_bits() {
            assert!(ordered(a) < 0, "{a}");
            assert!(exit_beyond(ordered(a)) < 0, "{a}");
        }
        if a > 0.0 && a < f32::MAX / 2.0 {
            let widened = f64::from(a) * (1.0 + 2f64.powi(-20));
            let beyond = f64::from(f32::from_bits(exit_beyond(ordered(a)) as u32));
            assert!(beyond > widened, "{a}: {beyond} ≤ {widened}");
        }
    }
    assert!(exit_beyond(ordered(f32::INFINITY)) > ordered(f32::INFINITY));
    assert!(ordered(0.0) < exit_beyond(ordered(0.0)));
}

/// The AVX-512 slab test (near and far planes in one register) gives the portable
/// one's mask and entry distances bit for bit on the children hit, and in its fused
/// form the AVX2 fused test's, for rays in all octants, with zero and subnormal
/// direction components, origins on box planes, empty child slots and `t_max`
/// from 0 to ∞ (where the CPU has AVX-512).
#[test]
fn avx512_slab_test_agrees_with_the_portable_and_avx2_ones() {
    on_path(SimdPath::Avx512, slab_tests_agree);
}

#[inline(always)]
fn slab_tests_agree() {
    use crate::simd_path::isa::PORTABLE;
    let agree = |a: (u32, [f32; WIDTH]), b: (u32, [f32; WIDTH]), what: &str| {
        assert_eq!(a.0, b.0, "{what}");
        for i in (0..WIDTH).filter(|&i| a.0 & (1 << i) != 0) {
            assert_eq!(a.1[i].to_bits(), b.1[i].to_bits(), "child {i}: {what}");
        }
    };
    let mut rng = XorShift(0x2545_f491_4f6c_dd1d);
    let mut next = move || rng.next();
    let mut unit = move || (next() >> 40) as f32 / (1u64 << 24) as f32;
    let (mut hits, mut misses) = (0, 0);
    for round in 0..20_000 {
        let mut node = Node::empty();
        let children = 1 + round % WIDTH;
        let corners: Vec<[f32; 3]> = (0..2 * children)
            .map(|_| std::array::from_fn(|_| 4.0 * unit() - 2.0))
            .collect();
        for (i, pair) in corners.chunks(2).enumerate() {
            let b = Bounds {
                min: std::array::from_fn(|k| pair[0][k].min(pair[1][k])),
                max: std::array::from_fn(|k| pair[0][k].max(pair[1][k])),
            };
            node.set_bounds(i, &b);
        }
        // Origins on a child's plane now and then; directions with zero and
        // subnormal components now and then.
        let origin: [f32; 3] = std::array::from_fn(|k| match round % 7 {
            0 => node.bounds[2 * k][0],
            _ => 6.0 * unit() - 3.0,
        });
        let dir: [f32; 3] = std::array::from_fn(|k| match (round / 7 + k) % 9 {
            0 => 0.0,
            1 => -0.0,
            2 => 1e-40,
            _ => 2.0 * unit() - 1.0,
        });
        if dir.iter().all(|&d| d == 0.0) {
            continue;
        }
        let t_max = [f32::INFINITY, 0.0, 0.5, 3.0][round % 4];
        let ray = BoxRay::single::<AVX512>(origin, dir);
        let portable = ray.hit_children::<PORTABLE, false>(&node, t_max);
        let what = format!("{origin:?} {dir:?} {t_max}");
        agree(
            ray.hit_children::<AVX512, false>(&node, t_max),
            portable,
            &what,
        );
        agree(
            ray.hit_children::<AVX512, true>(&node, t_max),
            ray.hit_children::<AVX2, true>(&node, t_max),
            &what,
        );
        if portable.0 == 0 {
            misses += 1;
        } else {
            hits += 1;
        }
    }
    assert!(hits > 1000 && misses > 1000, "{hits} hits, {misses} misses");
}

/// No path's slab test misses a box that the ray enters within `[0, t_max]`, nor
/// reports an entry distance beyond the exact one by more than the traversal's
/// `TMAX_WIDEN` allows for, judged against the same test in f64 (the direction's
/// reciprocal and the distances to the planes ten orders of magnitude closer than
/// f32's): random boxes of 1 mm to 4 m, origins up to 2 km from the world's, rays
/// aimed at a point inside a box or on its face, and directions with
/// zero and subnormal components, axis-aligned ones among them. Nor does it hit a
/// box that the ray misses by more than 10⁻⁵ of the box's size, or an empty slot.
#[test]
fn no_slab_test_misses_a_box_the_ray_enters() {
    use crate::simd_path::isa::PORTABLE;
    no_box_missed::<PORTABLE, false>();
    on_path(SimdPath::Avx2, no_box_missed::<AVX2, false>);
    on_path(SimdPath::Avx2, no_box_missed::<AVX2, true>);
    on_path(SimdPath::Avx512, no_box_missed::<AVX512, false>);
    on_path(SimdPath::Avx512, no_box_missed::<AVX512, true>);
}

/// A ray prepared without the fused test's offsets (`BoxRay::new`, for the unfused
/// test) misses every box in the fused test, rather than taking wrong offsets
/// unnoticed; prepared with them, it hits the boxes it is aimed at.
#[test]
fn a_fused_test_without_the_offsets_misses_every_box() {
    on_path(SimdPath::Avx2, fused_without_offsets::<AVX2>);
    on_path(SimdPath::Avx512, fused_without_offsets::<AVX512>);
}

#[inline(always)]
fn fused_without_offsets<const ISA: u8>() {
    let mut node = Node::empty();
    for i in 0..WIDTH {
        let x = i as f32 - 4.0;
        node.set_bounds(
            i,
            &Bounds {
                min: [x, -1.0, -1.0],
                max: [x + 0.5, 1.0, 1.0],
            },
        );
    }
    let (origin, dir) = ([-10.0, 0.1, -0.2], [1.0, 0.01, 0.02]);
    let with = BoxRay::single::<ISA>(origin, dir).hit_children::<ISA, true>(&node, f32::INFINITY);
    assert_eq!(with.0, 0xff, "every box is on the ray");
    let without = BoxRay::new(origin, dir).hit_children::<ISA, true>(&node, f32::INFINITY);
    assert_eq!(without.0, 0);
}

/// A stored box contains the given one, with every face moved out by at least an
/// ulp, and none at a subnormal coordinate (which would slow the fused slab test by
/// microcode assists; `widened`).
#[test]
fn stored_boxes_are_larger_and_have_no_subnormal_face() {
    let values: [f32; 10] = [
        0.0, -0.0, 1e-45, -1e-45, 1e-39, -1e-39, 1.0, -2.5, 1e30, -1e30,
    ];
    for &a in &values {
        for &b in &values {
            let (lo, hi) = (a.min(b), a.max(b));
            let w = widened(&Bounds {
                min: [lo; 3],
                max: [hi; 3],
            });
            for k in 0..3 {
                assert!(w.min[k] < lo && w.max[k] > hi, "{lo} {hi}: {w:?}");
                for face in [w.min[k], w.max[k]] {
                    assert!(face.is_normal(), "{lo} {hi}: face {face}");
                }
            }
        }
    }
}

/// The exact (f64) entry and exit distances of the ray from `origin` along `dir`
/// through child `i`'s box grown by `grow` of its extent (or of its coordinates,
/// where larger) on every side, or `None` where it does not enter it.
fn exact_slab(
    node: &Node,
    i: usize,
    origin: [f32; 3],
    dir: [f32; 3],
    grow: f64,
) -> Option<(f64, f64)> {
    let (mut near, mut far) = (0.0f64, f64::INFINITY);
    for axis in 0..3 {
        let (lo, hi) = (
            f64::from(node.bounds[2 * axis][i]),
            f64::from(node.bounds[2 * axis + 1][i]),
        );
        let margin = grow * (hi - lo).max(lo.abs()).max(hi.abs());
        let (lo, hi) = (lo - margin, hi + margin);
        let (o, d) = (f64::from(origin[axis]), f64::from(dir[axis]));
        if d == 0.0 || d.abs() < f64::from(f32::MIN_POSITIVE) {
            if o < lo || o > hi {
                return None;
            }
            continue;
        }
        let (a, b) = ((lo - o) / d, (hi - o) / d);
        near = near.max(a.min(b));
        far = far.min(a.max(b));
    }
    (near <= far).then_some((near, far))
}

#[inline(always)]
fn no_box_missed<const ISA: u8, const FUSED: bool>() {
    let mut rng = XorShift(0x6a09_e667_f3bc_c908);
    let (mut checked, mut missed) = (0, 0);
    for round in 0..40_000u32 {
        let mut unit = || rng.uniform();
        let mut node = Node::empty();
        let children = 1 + round as usize % WIDTH;
        let centre: [f32; 3] = std::array::from_fn(|_| 4.0 * unit() - 2.0);
        for i in 0..children {
            let size = 0.001 * 4000f32.powf(unit());
            let c: [f32; 3] = std::array::from_fn(|k| centre[k] + 2.0 * unit() - 1.0);
            node.set_bounds(
                i,
                &Bounds {
                    min: std::array::from_fn(|k| c[k] - size * unit()),
                    max: std::array::from_fn(|k| c[k] + size * unit()),
                },
            );
        }
        // Aimed at a point of child 0: inside it, or on one of its faces.
        let target: [f32; 3] = std::array::from_fn(|k| {
            let (lo, hi) = (node.bounds[2 * k][0], node.bounds[2 * k + 1][0]);
            lo + (hi - lo) * unit()
        });
        let face = round as usize % 6;
        let mut target = target;
        if round % 3 == 0 {
            target[face / 2] = node.bounds[face][0];
        }
        let distance = [1.0, 30.0, 2000.0][round as usize % 3] * unit();
        let mut origin: [f32; 3] =
            std::array::from_fn(|k| target[k] + distance * (2.0 * unit() - 1.0));
        let mut dir: [f32; 3] = std::array::from_fn(|k| target[k] - origin[k]);
        // Zero components, the origin moved into the target's plane on their axes so
        // that the ray still passes through the target (and lies in a face plane
        // when the target does).
        let axis = round as usize % 3;
        let flat: &[usize] = match round % 11 {
            0 | 1 => &[axis],
            // Axis-aligned: two zero components.
            2 => &[axis, (axis + 1) % 3],
            _ => &[],
        };
        for (j, &k) in flat.iter().enumerate() {
            origin[k] = target[k];
            dir[k] = [0.0, -0.0, 1e-40][(round as usize + j) % 3];
        }
        if dir.iter().all(|&d| d == 0.0) {
            continue;
        }
        let t_max = [f32::INFINITY, 1.0, 0.5][round as usize % 3];
        let (mask, entry) =
            BoxRay::single::<ISA>(origin, dir).hit_children::<ISA, FUSED>(&node, t_max);
        assert_eq!(
            mask >> children,
            0,
            "an empty slot hit: origin {origin:?}, dir {dir:?}"
        );
        for (i, &entry) in entry.iter().enumerate().take(children) {
            // A box missed by a clear margin is missed: the test is not merely
            // conservative but tight (within 10⁻⁵ of the box's size).
            let entered = exact_slab(&node, i, origin, dir, 1e-5)
                .is_some_and(|(near, _)| near <= f64::from(t_max) * (1.0 + 1e-5));
            if !entered {
                missed += 1;
                assert!(
                    mask & (1 << i) == 0,
                    "child {i} hit, clearly missed: origin {origin:?}, dir {dir:?}, t_max {t_max}"
                );
            }
            let Some((near, far)) = exact_slab(&node, i, origin, dir, 0.0) else {
                continue;
            };
            // Entered within [0, t_max], by more than f64's own rounding.
            let slack = 1e-9 * far.abs().max(1.0);
            if near + slack > far || near > f64::from(t_max) - slack {
                continue;
            }
            checked += 1;
            assert!(
                mask & (1 << i) != 0,
                "child {i} missed: origin {origin:?}, dir {dir:?}, exact entry {near}, exit {far}"
            );
            assert!(
                f64::from(entry) <= near * f64::from(TMAX_WIDEN) + 1e-30,
                "child {i}: entry {entry} beyond the exact {near}: origin {origin:?}, dir {dir:?}"
            );
        }
    }
    assert!(
        checked > 20_000 && missed > 20_000,
        "{checked} boxes entered, {missed} missed"
    );
}

/// The single-ray query with a stack too small for most rays (one entry) takes
/// the same steps, once the stack that grows has taken over, as the resumable
/// traversal: every leaf report and the final closest distance the same, bit for
/// bit; with the default capacity no ray here needs the hand-over.
#[test]
fn a_full_bounded_stack_hands_over_without_changing_a_result() {
    use crate::simd_path::isa::PORTABLE;
    let (_, boxes) = slivers(5_000);
    let tree = WideBvh::build(&boxes, &[], 16, 1).expect("small tree");
    let nodes = tree.nodes();
    let mut rng = XorShift(0x2545_f491_4f6c_dd1d);
    let (mut handed_over, mut hits) = (0, 0);
    for _ in 0..2_000 {
        let origin: [f32; 3] = std::array::from_fn(|_| 2.0 * rng.uniform() - 0.5);
        let dir: [f32; 3] = std::array::from_fn(|_| rng.uniform() - 0.5);
        let ray = BoxRay::new(origin, dir);
        // Each leaf's boxes stand in for its primitives: the distance to a
        // primitive is its box's entry distance, so the closest "hit" is decided
        // by the traversal's order and pruning alone.
        let trace = |run: &dyn Fn(&mut LeafTest) -> bool| {
            let mut reports = Vec::new();
            let handed_over = run(&mut |first, count, t_max| {
                let mut t_max = t_max;
                for slots in &tree.pack_slots()[first..first + pack_count(count)] {
                    for &slot in slots.iter().filter(|&&s| s != u32::MAX) {
                        let prim = tree.order()[slot as usize] as usize;
                        let t = exact_entry(&ray, &boxes[prim]).unwrap_or(f32::INFINITY);
                        if t < t_max {
                            t_max = t;
                        }
                    }
                }
                reports.push((first, t_max.to_bits()));
                t_max
            });
            (handed_over, reports)
        };
        let (over_default, default) = trace(&|leaf| {
            nodes.closest_within::<PORTABLE, SINGLE_RAY_STACK>(
                &ray,
                f32::INFINITY,
                &mut |a, b, t| leaf(a, b, t),
                &|_, _| {},
            )
        });
        let (over_one, one) = trace(&|leaf| {
            nodes.closest_within::<PORTABLE, 1>(
                &ray,
                f32::INFINITY,
                &mut |a, b, t| leaf(a, b, t),
                &|_, _| {},
            )
        });
        let (_, growing) = trace(&|leaf| {
            nodes.closest_growing::<PORTABLE>(
                &ray,
                f32::INFINITY,
                &mut |a, b, t| leaf(a, b, t),
                &|_, _| {},
            );
            false
        });
        assert!(!over_default, "the default capacity overflowed");
        assert_eq!(default, growing, "bounded stack against the growing one");
        // After a hand-over, the reports of the second run are the growing
        // stack's, and the last one (the result) is the same.
        if over_one {
            handed_over += 1;
            assert!(
                one.ends_with(&growing),
                "hand-over against the growing stack"
            );
        } else {
            assert_eq!(one, growing);
        }
        hits += usize::from(
            growing
                .last()
                .is_some_and(|r| f32::from_bits(r.1).is_finite()),
        );
    }
    assert!(
        handed_over > 100,
        "only {handed_over} rays filled a one-entry stack"
    );
    assert!(hits > 100, "only {hits} rays hit a box");
}

/// A leaf test as the traversals call it: (first pack, primitive count, t_max) → new t_max.
type LeafTest<'a> = dyn FnMut(usize, usize, f32) -> f32 + 'a;

/// The entry distance of `ray` into `b` (0 from inside), `None` where it misses.
fn exact_entry(ray: &BoxRay, b: &Bounds) -> Option<f32> {
    let (mut near, mut far) = (0.0f32, f32::INFINITY);
    for axis in 0..3 {
        let t0 = (b.min[axis] - ray.origin[axis]) * ray.inv_dir[axis];
        let t1 = (b.max[axis] - ray.origin[axis]) * ray.inv_dir[axis];
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
    }
    (near <= far).then_some(near)
}

/// The last node and the last pack that a child reference can address are
/// addressed, the next ones are refused (the build then fails with
/// [`TreeTooLarge`] rather than make a reference that runs into the leaf bit or the
/// count), every reference reads back as the node or leaf it names, and `validate`
/// reports a reference past the nodes.
#[test]
fn child_references_address_exactly_the_nodes_and_packs_that_fit() {
    let last_node = LEAF_BIT as usize - 1;
    assert_eq!(node_reference(last_node), Some(LEAF_BIT - 1));
    assert_eq!(node_reference(last_node + 1), None);
    assert_eq!(TreeTooLarge::nodes().limit, last_node + 1);
    for index in [0, 1, 2, 1_000, 123_456] {
        assert_eq!(node_reference(index), Some(index as u32));
    }

    let last_pack = INDEX_MASK as usize;
    let leaf = leaf_reference(last_pack, MAX_LEAF).expect("the last pack that fits");
    assert_eq!(leaf_parts(leaf), (last_pack, MAX_LEAF));
    assert_eq!(leaf_reference(last_pack + 1, 1), None);
    assert_eq!(TreeTooLarge::packs().limit, last_pack + 1);

    let (_, boxes) = slivers(2_000);
    let mut bounds = Bounds::empty();
    boxes.iter().for_each(|b| bounds.grow(b));
    let mut tree = WideBvh::build(&boxes, &[], 16, 1).expect("small tree");
    tree.validate(&boxes, Some(bounds)).expect("valid");
    let inner = (0..WIDTH)
        .find(|&i| tree.nodes[0].child[i] & LEAF_BIT == 0)
        .expect("an inner child of the root");
    let past = tree.nodes.len() as u32;
    tree.nodes[0].child[inner] = past;
    let error = tree
        .validate(&boxes, Some(bounds))
        .expect_err("a bad reference");
    assert!(
        error.contains(&format!("node {past} out of range")),
        "{error}"
    );
}
