//! Unit tests of the 8-wide tree's private parts: a given top is kept, and the AVX
//! hit mask agrees with the portable one.

use super::super::test_support::{XorShift, slivers};
use super::*;

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
    if !crate::simd_path::SimdPath::Avx2.is_available() {
        println!("no AVX2 on this CPU: only the portable mask exists");
        return;
    }
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
        let mask = hit_mask::<true>(&entry, &limit);
        assert_eq!(
            mask,
            hit_mask_portable(&entry, &limit),
            "{entry:?} {limit:?}"
        );
        seen[usize::from(mask == 0)] = true;
    }
    assert_eq!(seen, [true, true]);
}
