//! Unit tests of the 8-wide tree's private parts: a given top is kept, the AVX
//! hit mask agrees with the portable one, and so does the AVX-512 slab test.

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
        let tree = WideBvh::build(&boxes, &top, 16, threads);
        tree.validate(&boxes, Some(bounds)).expect("valid");
        let mut first: Vec<u32> = tree.order[..half].to_vec();
        first.sort_unstable();
        assert!(
            first.iter().copied().eq(0..half as u32),
            "{threads} threads"
        );
    }
}

/// The AVX mask (`movemask`) agrees with the portable one on random values, equal
/// pairs, infinities and NaN (where the CPU has AVX).
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
    ];
    let mut rng = XorShift(0x9e37_79b9_7f4a_7c15);
    let mut next = move || rng.next();
    let mut seen = [false; 2];
    for _ in 0..20_000 {
        let mut pick = || {
            let r = next();
            if r % 3 == 0 {
                specials[(r >> 8) as usize % specials.len()]
            } else {
                (r >> 40) as f32 / (1u64 << 20) as f32 - 8.0
            }
        };
        let entry: [f32; WIDTH] = std::array::from_fn(|_| pick());
        let mut limit: [f32; WIDTH] = std::array::from_fn(|_| pick());
        // Some exact ties, where `<=` must hold.
        limit[(next() % WIDTH as u64) as usize] = entry[0];
        limit[0] = entry[0];
        let mask = hit_mask::<AVX2>(&entry, &limit);
        assert_eq!(
            mask,
            hit_mask_portable(&entry, &limit),
            "{entry:?} {limit:?}"
        );
        seen[usize::from(mask == 0)] = true;
    }
    assert_eq!(seen, [true, true]);
}

/// The AVX-512 slab test (near and far planes in one register) gives the portable one's mask, and its entry distances bit for bit
/// on the children hit, for rays in all octants, with zero and subnormal
/// direction components, origins on box planes, empty child slots and `t_max`
/// from 0 to ∞ (where the CPU has AVX-512).
#[test]
fn avx512_slab_test_agrees_with_the_portable_one() {
    on_path(SimdPath::Avx512, slab_tests_agree);
}

#[inline(always)]
fn slab_tests_agree() {
    use crate::simd_path::isa::PORTABLE;
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
        let portable = BoxRay::new(origin, dir).hit_children::<PORTABLE>(&node, t_max);
        let wide = BoxRay::new(origin, dir).hit_children::<AVX512>(&node, t_max);
        assert_eq!(wide.0, portable.0, "{origin:?} {dir:?} {t_max}");
        for i in (0..WIDTH).filter(|&i| portable.0 & (1 << i) != 0) {
            assert_eq!(wide.1[i], portable.1[i], "child {i}: {origin:?} {dir:?}");
        }
        if portable.0 == 0 {
            misses += 1;
        } else {
            hits += 1;
        }
    }
    assert!(hits > 1000 && misses > 1000, "{hits} hits, {misses} misses");
}
