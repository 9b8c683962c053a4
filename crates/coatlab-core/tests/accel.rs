//! The acceleration structure against brute force, its validation on real models,
//! and degenerate input.

use std::f32::consts::PI;
use std::path::Path;

use coatlab_core::accel::experiments::compare_collapses;
use coatlab_core::accel::{
    Accel, AccelError, Bounds, BuildOptions, BuildQuality, BvhLayout, Hit, RayQuery,
    ReferenceSplits, intersect_triangle, offset_ray_origin,
};
use coatlab_core::scene::TriangleMesh;
use coatlab_core::scene::car::{CarParameters, generate};
use coatlab_core::scene::gltf_loader::{LoadOptions, load};
use coatlab_core::simd_path::SimdPath;
use glam::Vec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

const LAMBORGHINI: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/testdata/gltf/LamborghiniHuracanGT3/LamborghiniHuracanGT3.glb"
);

const ALL_OPTIONS: [BuildOptions; 7] = [
    BuildOptions {
        layout: BvhLayout::Simd8,
        quality: BuildQuality::Fast,
        reference_splits: ReferenceSplits::LargeTriangles,
        threads: 0,
    },
    BuildOptions {
        layout: BvhLayout::Wide8,
        quality: BuildQuality::Fast,
        reference_splits: ReferenceSplits::LargeTriangles,
        threads: 0,
    },
    BuildOptions {
        layout: BvhLayout::Binary,
        quality: BuildQuality::Medium,
        reference_splits: ReferenceSplits::LargeTriangles,
        threads: 0,
    },
    BuildOptions {
        layout: BvhLayout::Wide8,
        quality: BuildQuality::Fastest,
        reference_splits: ReferenceSplits::LargeTriangles,
        threads: 0,
    },
    BuildOptions {
        layout: BvhLayout::Wide8,
        quality: BuildQuality::Slow,
        reference_splits: ReferenceSplits::LargeTriangles,
        threads: 0,
    },
    BuildOptions {
        layout: BvhLayout::Simd8,
        quality: BuildQuality::Fastest,
        reference_splits: ReferenceSplits::LargeTriangles,
        threads: 0,
    },
    BuildOptions {
        layout: BvhLayout::Simd8,
        quality: BuildQuality::Fast,
        reference_splits: ReferenceSplits::Spatial,
        threads: 0,
    },
];

/// The Lamborghini, or `None` (with a notice) when the shared test data is missing;
/// under CI a missing file fails the test.
fn lamborghini() -> Option<TriangleMesh> {
    if !Path::new(LAMBORGHINI).exists() {
        assert!(
            std::env::var_os("CI").is_none(),
            "{LAMBORGHINI} is missing (required under CI)"
        );
        println!("skipped: {LAMBORGHINI} is missing");
        return None;
    }
    Some(
        load(Path::new(LAMBORGHINI), &LoadOptions::default())
            .expect("the Lamborghini loads")
            .mesh,
    )
}

#[path = "support/area_cdf.rs"]
mod area_cdf;
use area_cdf::area_cdf;

#[path = "support/torus.rs"]
mod support_torus;
use support_torus::torus;

/// The unnormalised geometric normal `(b − a) × (c − a)` of a triangle.
fn normal(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [f32; 3] {
    let [a, b, c] = [a, b, c].map(Vec3::from);
    (b - a).cross(c - a).to_array()
}

/// Closest hit over every triangle, with the accel's own triangle test.
fn brute_force(mesh: &TriangleMesh, origin: [f32; 3], dir: [f32; 3], t_max: f32) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    for (i, tri) in mesh.triangles.iter().enumerate() {
        let vertices = tri.map(|v| mesh.positions[v as usize]);
        let limit = best.map_or(t_max, |h| h.t);
        if let Some((t, barycentric)) = intersect_triangle(origin, dir, vertices, limit) {
            best = Some(Hit {
                t,
                triangle: i as u32,
                barycentric,
            });
        }
    }
    best
}

fn unit(rng: &mut Pcg64) -> [f32; 3] {
    loop {
        let v: [f32; 3] = std::array::from_fn(|_| 2.0 * rng.random::<f32>() - 1.0);
        let l2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        if l2 > 1e-4 && l2 <= 1.0 {
            let l = l2.sqrt();
            return v.map(|x| x / l);
        }
    }
}

/// Random rays for a mesh: half from outside its bounds towards random points in
/// them (camera-like), half from points on its surface (bounce-like), some with a
/// finite `t_max`.
fn random_rays(mesh: &TriangleMesh, count: usize, seed: u64) -> Vec<([f32; 3], [f32; 3], f32)> {
    let (lo, hi) = mesh.bounds().expect("non-empty");
    let centre: [f32; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let radius = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f32>().sqrt();
    let mut rng = Pcg64::seed_from_u64(seed);
    (0..count)
        .map(|i| {
            let t_max = if i % 4 == 3 {
                0.5 * radius * rng.random::<f32>()
            } else {
                f32::INFINITY
            };
            if i % 2 == 0 {
                let d = unit(&mut rng);
                let origin: [f32; 3] = std::array::from_fn(|k| centre[k] + 1.5 * radius * d[k]);
                let target: [f32; 3] =
                    std::array::from_fn(|k| lo[k] + rng.random::<f32>() * (hi[k] - lo[k]));
                let dir: [f32; 3] = std::array::from_fn(|k| target[k] - origin[k]);
                let l = dir.iter().map(|x| x * x).sum::<f32>().sqrt();
                (origin, dir.map(|x| x / l), t_max)
            } else {
                let t = rng.random_range(0..mesh.triangles.len());
                let [a, b, c] = mesh.triangles[t].map(|v| mesh.positions[v as usize]);
                let (u, v) = (rng.random::<f32>() * 0.5, rng.random::<f32>() * 0.5);
                let p: [f32; 3] =
                    std::array::from_fn(|k| a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k]));
                let n = normal(a, b, c);
                let d = unit(&mut rng);
                let side = if d.iter().zip(&n).map(|(x, y)| x * y).sum::<f32>() >= 0.0 {
                    n
                } else {
                    n.map(|x| -x)
                };
                let l = side.iter().map(|x| x * x).sum::<f32>().sqrt();
                let origin = if l > 0.0 {
                    offset_ray_origin(p, side.map(|x| x / l))
                } else {
                    p
                };
                (origin, d, t_max)
            }
        })
        .collect()
}

/// Closest hit and occlusion agree with brute force on every ray.
fn check_against_brute_force(
    mesh: &TriangleMesh,
    accel: &Accel,
    rays: &[([f32; 3], [f32; 3], f32)],
) {
    let mut hits = 0;
    for (i, &(origin, dir, t_max)) in rays.iter().enumerate() {
        let expected = brute_force(mesh, origin, dir, t_max);
        let got = accel.closest_hit(origin, dir, t_max);
        match (expected, got) {
            (None, None) => {}
            (Some(e), Some(g)) => {
                hits += 1;
                // The same test in the same order of operations: identical distances;
                // on a tie (a shared edge) the least triangle index, which the brute
                // force, going through the triangles in order, keeps. The obvhs
                // layouts keep whichever tie they reach first.
                assert_eq!(e.t, g.t, "ray {i}: {origin:?} {dir:?}: {e:?} vs {g:?}");
                if accel.bvh().options().layout == BvhLayout::Simd8 || e.triangle == g.triangle {
                    assert_eq!(
                        hit_bits(Some(e)),
                        hit_bits(Some(g)),
                        "ray {i}: {origin:?} {dir:?}: {e:?} vs {g:?}"
                    );
                }
            }
            (e, g) => {
                panic!("ray {i}: {origin:?} {dir:?} t_max {t_max}: brute force {e:?}, accel {g:?}")
            }
        }
        assert_eq!(
            accel.occluded(origin, dir, t_max),
            got.is_some(),
            "ray {i}: occluded disagrees with closest_hit"
        );
    }
    assert!(
        hits > rays.len() / 5,
        "only {hits} of {} rays hit",
        rays.len()
    );
    check_batch_against_single_rays(accel, rays);
}

/// A hit's fields as bits, so that equality is bit for bit (-0 ≠ +0).
fn hit_bits(hit: Option<Hit>) -> Option<(u32, u32, [u32; 2])> {
    hit.map(|h| (h.t.to_bits(), h.triangle, h.barycentric.map(f32::to_bits)))
}

/// `closest_hits` (and its variants with other numbers of rays in flight) and
/// `closest_hits_one_by_one` give exactly `closest_hit`'s result for every ray.
fn check_batch_against_single_rays(accel: &Accel, rays: &[([f32; 3], [f32; 3], f32)]) {
    let queries: Vec<RayQuery> = rays
        .iter()
        .map(|&(origin, dir, t_max)| RayQuery { origin, dir, t_max })
        .collect();
    let single: Vec<_> = rays
        .iter()
        .map(|&(origin, dir, t_max)| hit_bits(accel.closest_hit(origin, dir, t_max)))
        .collect();
    let mut batch = vec![None; rays.len()];
    type Trace = fn(&Accel, &[RayQuery], &mut [Option<Hit>]);
    let trace: [Trace; 5] = [
        |a, r, h| a.closest_hits(r, h),
        |a, r, h| a.closest_hits_one_by_one(r, h),
        |a, r, h| a.closest_hits_in_lanes::<1>(r, h),
        |a, r, h| a.closest_hits_in_lanes::<3>(r, h),
        |a, r, h| a.closest_hits_in_lanes::<16>(r, h),
    ];
    for (variant, trace) in trace.iter().enumerate() {
        // Stale hits must be overwritten.
        batch.fill(Some(Hit {
            t: 1.0,
            triangle: u32::MAX,
            barycentric: [0.0; 2],
        }));
        trace(accel, &queries, &mut batch);
        for (i, (s, b)) in single.iter().zip(&batch).enumerate() {
            assert_eq!(
                *s,
                hit_bits(*b),
                "variant {variant}, ray {i}: {:?}",
                rays[i]
            );
        }
    }
}

/// `mesh`'s tree built in each configuration of [`ALL_OPTIONS`].
fn every_configuration(mesh: &TriangleMesh) -> impl Iterator<Item = (BuildOptions, Accel)> + '_ {
    ALL_OPTIONS.into_iter().map(move |options| {
        let accel = Accel::build_with(mesh, &options).expect("build");
        (options, accel)
    })
}

#[test]
fn torus_agrees_with_brute_force_in_every_configuration() {
    let mesh = torus(120, 40);
    let rays = random_rays(&mesh, 2000, 1);
    for (options, accel) in every_configuration(&mesh) {
        accel.validate().expect("valid tree");
        assert_eq!(accel.triangle_count(), mesh.triangle_count());
        assert_eq!(accel.bvh().options(), options);
        check_against_brute_force(&mesh, &accel, &rays);
    }
}

#[test]
fn lamborghini_agrees_with_brute_force_and_validates() {
    let Some(mesh) = lamborghini() else { return };
    assert_eq!(mesh.triangle_count(), 145_917);
    let rays = random_rays(&mesh, 3000, 2);
    for options in [ALL_OPTIONS[0], ALL_OPTIONS[1]] {
        let accel = Accel::build_with(&mesh, &options).expect("build");
        accel.validate().expect("valid tree");
        let bounds = accel.bounds().expect("bounds");
        let (lo, hi) = mesh.bounds().expect("bounds");
        assert_eq!((bounds.min, bounds.max), (lo, hi));
        // Only a subset against brute force for the obvhs layout: brute force is slow.
        let n = if options == ALL_OPTIONS[0] { 3000 } else { 500 };
        check_against_brute_force(&mesh, &accel, &rays[..n]);
    }
}

/// `Accel::build` is `build_with` the documented defaults: the `Simd8` layout,
/// the `Fast` quality preset (16 SAH bins) and spatial splits. The tree is
/// compared with trees built with each option changed in turn, so a default that
/// is reported but not applied fails. How fast the default traces is the accel
/// bench's to measure (docs/benchmarks.md), not a unit test's.
#[test]
fn default_build_is_the_simd8_layout_with_the_fast_preset_and_spatial_splits() {
    let documented = BuildOptions {
        layout: BvhLayout::Simd8,
        quality: BuildQuality::Fast,
        reference_splits: ReferenceSplits::Spatial,
        threads: 0,
    };
    assert_eq!(BuildOptions::default(), documented);
    // The default car: its floor and body panels are large triangles that the
    // reference splits cut, and enough triangles for the bin count to matter.
    let mesh = coatlab_core::scene::car::generate(&Default::default()).mesh;
    // Node count, slot count and a hash of the leaf order and slot triangles: equal
    // for the same tree, and short in a failure message.
    let tree = |accel: &Accel| {
        use std::hash::{Hash, Hasher};
        let mut hasher = std::hash::DefaultHasher::new();
        accel.bvh().primitive_order().hash(&mut hasher);
        accel.slot_triangles().hash(&mut hasher);
        (
            accel.bvh().node_count(),
            accel.slot_triangles().len(),
            hasher.finish(),
        )
    };
    let default = Accel::build(&mesh).expect("build");
    assert_eq!(default.bvh().options(), documented);
    let explicit = Accel::build_with(&mesh, &documented).expect("build");
    assert_eq!(
        tree(&default),
        tree(&explicit),
        "the default is not applied"
    );
    let changed = [
        BuildOptions {
            layout: BvhLayout::Wide8,
            ..documented
        },
        BuildOptions {
            layout: BvhLayout::Binary,
            ..documented
        },
        BuildOptions {
            quality: BuildQuality::Fastest,
            ..documented
        },
        BuildOptions {
            quality: BuildQuality::Medium,
            ..documented
        },
        BuildOptions {
            reference_splits: ReferenceSplits::LargeTriangles,
            ..documented
        },
    ];
    for options in changed {
        let other = Accel::build_with(&mesh, &options).expect("build");
        assert_eq!(other.bvh().options(), options);
        assert_ne!(
            tree(&default),
            tree(&other),
            "{options:?} builds the default's tree: the test cannot tell them apart"
        );
    }
    // Eight children a node: far fewer nodes than the binary layout's.
    let binary = Accel::build_with(
        &mesh,
        &BuildOptions {
            layout: BvhLayout::Binary,
            ..documented
        },
    )
    .expect("build");
    assert!(
        4 * default.bvh().node_count() < binary.bvh().node_count(),
        "Simd8 {} nodes against Binary {}",
        default.bvh().node_count(),
        binary.bvh().node_count()
    );
}

/// The traversal's SIMD paths (`src/simd_path.rs`: portable, and AVX2 and AVX-512
/// where the CPU has them) do the same f32 operations, so every query gives the
/// same result on each, bit for bit: closest hits (single and batch), and any
/// hits, on the Lamborghini (its slivers and spatial splits) and the default car,
/// for camera-like and bounce rays, and axis-aligned rays through vertices (zero
/// direction components, which the slab tests replace by ±`f32::MIN_POSITIVE`,
/// and origins in box planes). On a CPU without AVX2 only the portable path exists
/// and the comparison is with itself (it says so).
#[test]
fn every_simd_path_gives_the_same_hits_bit_for_bit() {
    let paths = SimdPath::available();
    println!(
        "SIMD paths this CPU has: {:?}; this process runs {}",
        paths.iter().map(|p| p.name()).collect::<Vec<_>>(),
        SimdPath::current().name()
    );
    let mut meshes = vec![generate(&CarParameters::default()).mesh];
    meshes.extend(lamborghini());
    for mesh in &meshes {
        let accel = Accel::build(mesh).expect("build");
        let mut rays = random_rays(mesh, 3000, 41);
        rays.extend(bounce_rays(mesh, 3000, 43, false));
        rays.extend(axis_rays_through_vertices(mesh, 600));
        let queries: Vec<RayQuery> = rays
            .iter()
            .map(|&(origin, dir, t_max)| RayQuery { origin, dir, t_max })
            .collect();
        let on = |path: SimdPath| {
            let mut batch = vec![None; queries.len()];
            accel.closest_hits_on(path, &queries, &mut batch);
            let single: Vec<_> = rays
                .iter()
                .map(|&(o, d, t)| hit_bits(accel.closest_hit_on(path, o, d, t)))
                .collect();
            let mut one_by_one = vec![None; queries.len()];
            accel.closest_hits_one_by_one_on(path, &queries, &mut one_by_one);
            assert!(
                one_by_one
                    .into_iter()
                    .map(hit_bits)
                    .eq(single.iter().copied()),
                "{}: closest_hits_one_by_one against closest_hit",
                path.name()
            );
            let any: Vec<bool> = rays
                .iter()
                .map(|&(o, d, t)| accel.occluded_on(path, o, d, t.min(1.0)))
                .collect();
            (
                batch.into_iter().map(hit_bits).collect::<Vec<_>>(),
                single,
                any,
            )
        };
        let reference = on(SimdPath::Portable);
        assert_eq!(
            reference.0, reference.1,
            "portable: batch against single rays"
        );
        let hits = reference.0.iter().filter(|h| h.is_some()).count();
        assert!(
            hits > rays.len() / 4,
            "only {hits} of {} rays hit",
            rays.len()
        );
        for &path in &paths {
            let got = on(path);
            for (i, ray) in rays.iter().enumerate() {
                assert_eq!(
                    got.0[i],
                    reference.0[i],
                    "{}: batch, ray {i}: {ray:?}",
                    path.name()
                );
                assert_eq!(
                    got.1[i],
                    reference.1[i],
                    "{}: single, ray {i}: {ray:?}",
                    path.name()
                );
                assert_eq!(
                    got.2[i],
                    reference.2[i],
                    "{}: any hit, ray {i}: {ray:?}",
                    path.name()
                );
            }
        }
    }
}

/// Rays along ±x, ±y and ±z through every `mesh.positions.len() / count`-th
/// vertex, starting a metre before it, `t_max` ∞.
fn axis_rays_through_vertices(mesh: &TriangleMesh, count: usize) -> Vec<([f32; 3], [f32; 3], f32)> {
    let step = (mesh.positions.len() / count).max(1);
    mesh.positions
        .iter()
        .step_by(step)
        .enumerate()
        .map(|(i, p)| {
            let axis = i % 3;
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            let mut dir = [0.0; 3];
            dir[axis] = sign;
            let mut origin = *p;
            origin[axis] -= sign;
            (origin, dir, f32::INFINITY)
        })
        .collect()
}

/// CI names the path it means each test run to take in `COATLAB_EXPECT_SIMD_PATH`
/// (`portable`, `avx2` or `avx512`, forced with `COATLAB_SIMD` or detected), so that a forcing
/// that does not take effect fails here instead of testing the other path.
#[test]
fn the_simd_path_running_is_the_one_asked_for() {
    let current = SimdPath::current();
    println!("traversal SIMD path: {}", current.name());
    assert!(current.is_available());
    if let Some(expected) = std::env::var_os("COATLAB_EXPECT_SIMD_PATH") {
        assert_eq!(
            std::ffi::OsStr::new(current.name()),
            expected,
            "COATLAB_EXPECT_SIMD_PATH names another path than the one running"
        );
    }
}

/// Triangle boxes of the default car, and of long thin random slivers in all
/// directions overlapping in a unit cube (Lamborghini-like).
fn collapse_box_sets() -> Vec<(&'static str, Vec<Bounds>)> {
    let car = generate(&CarParameters::default()).mesh;
    let car_boxes = car
        .triangles
        .iter()
        .filter_map(|t| Bounds::from_points(&t.map(|v| car.positions[v as usize])))
        .collect();
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let slivers = (0..20_000)
        .map(|_| {
            let a: [f32; 3] = std::array::from_fn(|_| uniform());
            let long = (uniform() * 3.0) as usize % 3;
            let size: [f32; 3] =
                std::array::from_fn(|k| if k == long { 0.3 * uniform() } else { 0.002 });
            Bounds {
                min: a,
                max: std::array::from_fn(|k| a[k] + size[k]),
            }
        })
        .collect();
    vec![("default car", car_boxes), ("slivers", slivers)]
}

/// The `Simd8` collapse's SAH plan is the optimum over the binary tree, so its cost
/// is at most that of the collapse it replaced (opening the largest child); both
/// trees validate (`compare_collapses` checks them); and the tree it builds costs
/// what its plan computed (the extraction follows the plan).
#[test]
fn sah_collapse_costs_no_more_than_opening_the_largest_child() {
    for (name, boxes) in collapse_box_sets() {
        let costs = compare_collapses(&boxes, 16, 1).expect(name);
        let (cost, old_cost) = (costs.sah, costs.largest_child);
        assert!(
            cost <= old_cost * (1.0 + 1e-6),
            "{name}: {cost} > {old_cost}"
        );
        // Strictly better on both sets (by 5–6 % when written); a plan that fell
        // back to the old choices would not be.
        assert!(cost < 0.99 * old_cost, "{name}: {cost} vs {old_cost}");
        assert!(
            (costs.planned - cost).abs() <= 1e-3 * cost,
            "{name}: planned {}, built {cost}",
            costs.planned
        );
        eprintln!(
            "{name}: SAH cost {cost:.3} (largest child: {old_cost:.3}), {} nodes (was {})",
            costs.sah_nodes, costs.largest_child_nodes
        );
    }
}

#[test]
fn parallel_and_serial_simd8_builds_are_identical() {
    // The subtrees built on other threads are appended in the serial order, so the
    // tree does not depend on the thread count.
    let mesh = torus(200, 60);
    let build = |threads| {
        Accel::build_with(
            &mesh,
            &BuildOptions {
                threads,
                ..BuildOptions::default()
            },
        )
        .expect("build")
    };
    let serial = build(1);
    for threads in [2, 3, 8] {
        let parallel = build(threads);
        parallel.validate().expect("valid tree");
        assert_eq!(parallel.bvh().node_count(), serial.bvh().node_count());
        assert_eq!(
            parallel.bvh().primitive_order(),
            serial.bvh().primitive_order()
        );
    }
    let rays = random_rays(&mesh, 300, 15);
    let parallel = build(2);
    for &(origin, dir, t_max) in &rays {
        assert_eq!(
            parallel.closest_hit(origin, dir, t_max),
            serial.closest_hit(origin, dir, t_max)
        );
    }
}

#[test]
fn spatial_splits_do_not_depend_on_the_thread_count() {
    // The spatial pass runs its subtrees on other threads and shares the budget of
    // new references by size, not by which thread gets there first: the same
    // references in the same order, so the same tree, for any thread count. The
    // Lamborghini has splits the SAH takes (the torus has none).
    let Some(mesh) = lamborghini() else { return };
    let build = |reference_splits, threads| {
        Accel::build_with(
            &mesh,
            &BuildOptions {
                reference_splits,
                threads,
                ..BuildOptions::default()
            },
        )
        .expect("build")
    };
    let large = build(ReferenceSplits::LargeTriangles, 1);
    let serial = build(ReferenceSplits::Spatial, 1);
    assert!(
        serial.bvh().len() > large.bvh().len() + large.bvh().len() / 20,
        "expected spatial splits: {} references against {}",
        serial.bvh().len(),
        large.bvh().len()
    );
    for threads in [2, 3, 8] {
        let parallel = build(ReferenceSplits::Spatial, threads);
        parallel.validate().expect("valid tree");
        assert_eq!(parallel.bvh().node_count(), serial.bvh().node_count());
        assert_eq!(
            parallel.bvh().primitive_order(),
            serial.bvh().primitive_order()
        );
    }
}

/// Any hit over every triangle, with the accel's own triangle test.
fn brute_force_any(mesh: &TriangleMesh, origin: [f32; 3], dir: [f32; 3], t_max: f32) -> bool {
    mesh.triangles.iter().any(|tri| {
        let vertices = tri.map(|v| mesh.positions[v as usize]);
        intersect_triangle(origin, dir, vertices, t_max).is_some()
    })
}

/// The tracer's bounce rays: area-weighted points on the surface, moved off it with
/// `offset_ray_origin`, cosine-distributed about the front side of the geometric
/// normal (as the benchmark's incoherent rays), a quarter with a finite `t_max`; with
/// `both_sides`, every other ray leaves through the back (into a closed surface, so
/// that it hits).
fn bounce_rays(
    mesh: &TriangleMesh,
    count: usize,
    seed: u64,
    both_sides: bool,
) -> Vec<([f32; 3], [f32; 3], f32)> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let cdf = area_cdf(mesh);
    let total = cdf.last().copied().unwrap_or(0.0);
    let mut rays = Vec::with_capacity(count);
    while rays.len() < count {
        let t = cdf
            .partition_point(|&c| c < rng.random::<f64>() * total)
            .min(cdf.len() - 1);
        let [a, b, c] = mesh.triangles[t].map(|v| mesh.positions[v as usize]);
        let e1: [f32; 3] = std::array::from_fn(|k| b[k] - a[k]);
        let e2: [f32; 3] = std::array::from_fn(|k| c[k] - a[k]);
        let n = normal(a, b, c);
        let l = n.iter().map(|x| x * x).sum::<f32>().sqrt();
        if l == 0.0 || !l.is_finite() {
            continue;
        }
        let side = if both_sides && rays.len() % 2 == 1 {
            -1.0
        } else {
            1.0
        };
        let n = n.map(|x| side * x / l);
        let (mut u, mut v) = (rng.random::<f32>(), rng.random::<f32>());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let p: [f32; 3] = std::array::from_fn(|k| a[k] + u * e1[k] + v * e2[k]);
        // Cosine-distributed: a uniform unit vector added to the normal.
        let s = unit(&mut rng);
        let d: [f32; 3] = std::array::from_fn(|k| n[k] + s[k]);
        let dl = d.iter().map(|x| x * x).sum::<f32>().sqrt();
        if dl <= 1e-6 || dl.is_nan() {
            continue;
        }
        let t_max = if rays.len() % 4 == 3 {
            0.5 * rng.random::<f32>()
        } else {
            f32::INFINITY
        };
        rays.push((offset_ray_origin(p, n), d.map(|x| x / dl), t_max));
    }
    rays
}

/// `occluded` agrees with brute force on each ray `(origin, dir, t_max)`.
fn check_occluded_against_brute_force(
    mesh: &TriangleMesh,
    accel: &Accel,
    rays: impl Iterator<Item = ([f32; 3], [f32; 3], f32)>,
) {
    for (origin, dir, t_max) in rays {
        assert_eq!(
            accel.occluded(origin, dir, t_max),
            brute_force_any(mesh, origin, dir, t_max),
            "{origin:?} {dir:?} {t_max}"
        );
    }
}

#[test]
fn default_car_agrees_with_brute_force_on_camera_and_bounce_rays() {
    let mesh = coatlab_core::scene::car::generate(&Default::default()).mesh;
    let accel = Accel::build(&mesh).expect("build");
    accel.validate().expect("valid tree");
    let mut rays = random_rays(&mesh, 600, 11);
    rays.extend(bounce_rays(&mesh, 1200, 12, false));
    check_against_brute_force(&mesh, &accel, &rays);
    // Any hit against brute force directly (not only against closest_hit).
    check_occluded_against_brute_force(&mesh, &accel, rays.iter().copied());
}

#[test]
fn torus_bounce_and_shadow_rays_agree_with_brute_force() {
    let mesh = torus(150, 50);
    let accel = Accel::build(&mesh).expect("build");
    accel.validate().expect("valid tree");
    let rays = bounce_rays(&mesh, 3000, 13, true);
    check_against_brute_force(&mesh, &accel, &rays);
    let shadow_rays = rays
        .iter()
        .flat_map(|&(origin, dir, _)| [0.05, 0.5, 3.0].map(|t_max| (origin, dir, t_max)));
    check_occluded_against_brute_force(&mesh, &accel, shadow_rays);
}

#[test]
fn the_box_level_queries_agree_with_the_triangle_layer_in_every_layout() {
    // `Bvh::closest`/`Bvh::any` with a per-primitive closure (as picking would use
    // them) find the same hits as `Accel`'s own, packed path.
    let mesh = torus(60, 20);
    let rays = random_rays(&mesh, 800, 14);
    for (options, accel) in every_configuration(&mesh) {
        let slot_triangles = accel.slot_triangles();
        let intersect = |ray: &coatlab_core::accel::Ray, slot: usize| {
            let tri =
                mesh.triangles[slot_triangles[slot] as usize].map(|v| mesh.positions[v as usize]);
            intersect_triangle(ray.origin.into(), ray.direction.into(), tri, ray.tmax)
                .map_or(f32::INFINITY, |(t, _)| t)
        };
        for &(origin, dir, t_max) in &rays {
            let ray = coatlab_core::accel::Ray::new(origin.into(), dir.into(), 0.0, t_max);
            let got = accel.bvh().closest(ray, intersect).map(|(_, t)| t);
            let expected = accel.closest_hit(origin, dir, t_max).map(|h| h.t);
            assert_eq!(got, expected, "{options:?}: {origin:?} {dir:?}");
            assert_eq!(accel.bvh().any(ray, intersect), expected.is_some());
        }
    }
}

#[test]
fn a_ray_leaving_a_surface_through_the_offset_origin_does_not_hit_it() {
    let mesh = torus(200, 60);
    let accel = Accel::build(&mesh).expect("build");
    let mut rng = Pcg64::seed_from_u64(3);
    // Bounce rays on the torus's outer equator point outwards and must escape.
    for _ in 0..2000 {
        let origin_dir = accel.closest_hit(
            [0.0, 0.6, 0.0],
            {
                let a = 2.0 * PI * rng.random::<f32>();
                [a.cos(), 0.0, a.sin()]
            },
            f32::INFINITY,
        );
        let hit = origin_dir.expect("from the hole, a horizontal ray hits the inner wall");
        let tri = mesh.triangles[hit.triangle as usize].map(|v| mesh.positions[v as usize]);
        let [u, v] = hit.barycentric;
        let p: [f32; 3] = std::array::from_fn(|k| {
            tri[0][k] + u * (tri[1][k] - tri[0][k]) + v * (tri[2][k] - tri[0][k])
        });
        // The inner wall faces the hole: its normal points towards the axis.
        let n_len = (p[0] * p[0] + p[2] * p[2]).sqrt();
        let n = [-p[0] / n_len, 0.0, -p[2] / n_len];
        let back = accel.closest_hit(offset_ray_origin(p, n), n, f32::INFINITY);
        let hit_back = back.expect("across the hole, the opposite wall");
        assert!(
            hit_back.t > 1.0,
            "self-intersection or a leak: first {hit:?}, then {hit_back:?}"
        );
    }
}

#[test]
fn empty_mesh_gives_an_empty_accel_whose_queries_miss() {
    let accel = Accel::build(&TriangleMesh::default()).expect("empty is fine");
    accel.validate().expect("valid");
    assert_eq!(accel.triangle_count(), 0);
    assert_eq!(accel.bounds(), None);
    assert_eq!(
        accel.closest_hit([0.0; 3], [0.0, 0.0, 1.0], f32::INFINITY),
        None
    );
    assert!(!accel.occluded([0.0; 3], [0.0, 0.0, 1.0], f32::INFINITY));
}

#[test]
fn single_triangle() {
    let mesh = TriangleMesh {
        positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        triangles: vec![[0, 1, 2]],
        ..Default::default()
    };
    for (_, accel) in every_configuration(&mesh) {
        accel.validate().expect("valid");
        let hit = accel
            .closest_hit([0.25, 0.25, 1.0], [0.0, 0.0, -1.0], f32::INFINITY)
            .expect("hit");
        assert_eq!(hit.triangle, 0);
        assert!((hit.t - 1.0).abs() < 1e-6);
        assert!((hit.barycentric[0] - 0.25).abs() < 1e-6);
        assert!((hit.barycentric[1] - 0.25).abs() < 1e-6);
        // t_max is exclusive, and so is t = 0.
        assert!(!accel.occluded([0.25, 0.25, 1.0], [0.0, 0.0, -1.0], 1.0));
        assert!(accel.occluded([0.25, 0.25, 1.0], [0.0, 0.0, -1.0], 1.0001));
        assert!(!accel.occluded([0.25, 0.25, 0.0], [0.0, 0.0, -1.0], 1.0));
        // Both sides hit (no culling); a miss beside it.
        assert!(accel.occluded([0.25, 0.25, -1.0], [0.0, 0.0, 1.0], 2.0));
        assert!(!accel.occluded([0.75, 0.75, 1.0], [0.0, 0.0, -1.0], 2.0));
        // Unusable rays hit nothing rather than panic.
        for (o, d, t) in [
            ([f32::NAN, 0.0, 1.0], [0.0, 0.0, -1.0], 2.0),
            ([0.25, 0.25, 1.0], [0.0, 0.0, 0.0], 2.0),
            ([0.25, 0.25, 1.0], [0.0, f32::INFINITY, -1.0], 2.0),
            ([0.25, 0.25, 1.0], [0.0, 0.0, -1.0], f32::NAN),
            ([0.25, 0.25, 1.0], [0.0, 0.0, -1.0], -1.0),
        ] {
            assert_eq!(accel.closest_hit(o, d, t), None);
            assert!(!accel.occluded(o, d, t));
        }
    }
}

#[test]
fn zero_area_triangles_are_skipped_and_never_hit() {
    // A real triangle, a collapsed one (all three vertices equal), a sliver (collinear),
    // and many duplicates of the collapsed one in one spot.
    let mut mesh = TriangleMesh {
        positions: vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.5, 0.5],
            [0.0, 0.0, 0.5],
            [1.0, 1.0, 0.5],
        ],
        triangles: vec![[0, 1, 2], [3, 3, 3], [4, 3, 5]],
        ..Default::default()
    };
    mesh.triangles.extend(std::iter::repeat_n([3, 3, 3], 500));
    for (_, accel) in every_configuration(&mesh) {
        accel.validate().expect("valid");
        assert_eq!(accel.triangle_count(), 1);
        assert_eq!(accel.skipped_degenerate(), 502);
        // Straight through the degenerate ones onto the real triangle.
        let hit = accel
            .closest_hit([0.5, 0.5, 1.0], [0.0, 0.0, -1.0], f32::INFINITY)
            .expect("hit");
        assert_eq!(hit.triangle, 0);
        assert_eq!(hit.t, 1.0);
        let hit = accel
            .closest_hit([0.25, 0.25, 1.0], [0.0, 0.0, -1.0], f32::INFINITY)
            .expect("hit");
        assert_eq!(hit.triangle, 0);
    }
    // All degenerate.
    let only = TriangleMesh {
        positions: vec![[1.0, 2.0, 3.0]],
        triangles: vec![[0, 0, 0]; 64],
        ..Default::default()
    };
    let accel = Accel::build(&only).expect("build");
    accel.validate().expect("valid");
    assert_eq!(accel.triangle_count(), 0);
    assert!(!accel.occluded([1.0, 2.0, 0.0], [0.0, 0.0, 1.0], f32::INFINITY));
}

#[test]
fn many_coincident_triangles_still_trace_correctly() {
    // 2000 copies of one real triangle at one place (duplicated CAD geometry) plus a
    // torus: PLOC cannot separate the copies, so the tree is deep there; a `Wide8`
    // request may come back `Binary` (see the module documentation), never wrong.
    let mut mesh = torus(40, 12);
    let base = mesh.positions.len() as u32;
    mesh.positions
        .extend([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0], [0.0, 0.3, 0.0]]);
    mesh.triangles
        .extend(std::iter::repeat_n([base, base + 1, base + 2], 2000));
    let rays = random_rays(&mesh, 600, 5);
    for (_, accel) in every_configuration(&mesh) {
        accel.validate().expect("valid");
        assert_eq!(accel.triangle_count(), mesh.triangle_count());
        check_against_brute_force(&mesh, &accel, &rays);
        let hit = accel
            .closest_hit([0.1, 0.1, 1.0], [0.0, 0.0, -1.0], f32::INFINITY)
            .expect("hit");
        assert!(hit.triangle >= 960, "{hit:?}");
        assert_eq!(hit.t, 1.0);
    }
}

#[test]
fn non_finite_vertices_are_refused_naming_the_triangle() {
    let mut mesh = torus(10, 8);
    let bad_vertex = mesh.triangles[37][1];
    mesh.positions[bad_vertex as usize][2] = f32::NAN;
    let err = Accel::build(&mesh).expect_err("NaN refused");
    let first_user = mesh
        .triangles
        .iter()
        .position(|t| t.contains(&bad_vertex))
        .expect("used");
    match &err {
        AccelError::NonFiniteVertex {
            triangle, vertex, ..
        } => {
            assert_eq!(*triangle, first_user);
            assert_eq!(*vertex, bad_vertex);
        }
        other => panic!("unexpected error {other:?}"),
    }
    let message = err.to_string();
    assert!(
        message.contains(&format!("triangle {first_user} ")) && message.contains("non-finite"),
        "{message}"
    );

    mesh.positions[bad_vertex as usize][2] = f32::INFINITY;
    assert!(matches!(
        Accel::build(&mesh),
        Err(AccelError::NonFiniteVertex { .. })
    ));

    let out_of_range = TriangleMesh {
        positions: vec![[0.0; 3]; 3],
        triangles: vec![[0, 1, 2], [0, 1, 3]],
        ..Default::default()
    };
    let err = Accel::build(&out_of_range).expect_err("index refused");
    assert!(
        err.to_string().contains("triangle 1 refers to vertex 3"),
        "{err}"
    );
}

#[test]
fn huge_coordinates_build_validate_and_trace() {
    // The torus moved 10⁶ m away (f32 spacing there is 0.0625 m): scaled to stay
    // resolvable, 2 km across.
    let mut mesh = torus(60, 20);
    for p in &mut mesh.positions {
        *p = [p[0] * 500.0 + 1e6, p[1] * 500.0 - 1e6, p[2] * 500.0 + 1e6];
    }
    let rays = random_rays(&mesh, 1000, 4);
    for (_, accel) in every_configuration(&mesh) {
        accel.validate().expect("valid");
        check_against_brute_force(&mesh, &accel, &rays);
    }
    // And a mesh spanning ±10⁶ m with a 1 m triangle at the origin.
    let spread = TriangleMesh {
        positions: vec![
            [-1e6, 0.0, -1e6],
            [1e6, 0.0, -1e6],
            [0.0, 0.0, 1e6],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 1.0],
        ],
        triangles: vec![[0, 2, 1], [3, 5, 4]],
        ..Default::default()
    };
    for options in ALL_OPTIONS {
        let accel = Accel::build_with(&spread, &options).expect("build");
        accel.validate().expect("valid");
        let hit = accel
            .closest_hit([0.2, 5.0, 0.2], [0.0, -1.0, 0.0], f32::INFINITY)
            .expect("hit");
        assert_eq!((hit.triangle, hit.t), (1, 4.0));
        let hit = accel
            .closest_hit([5e5, 5.0, 0.0], [0.0, -1.0, 0.0], f32::INFINITY)
            .expect("hit");
        assert_eq!((hit.triangle, hit.t), (0, 5.0));
    }
}

#[test]
fn large_triangles_split_into_references_are_still_found_everywhere() {
    // A 100 m ground quad (two triangles, far above the average box area) under a
    // torus, and a long diagonal sliver through it: `Simd8` enters them as several
    // references each. Rays straight down exactly on the split planes (x and z at
    // multiples of 100 m / 2⁴, the middles of the halved boxes) and random rays
    // must agree with brute force.
    let mut mesh = torus(60, 20);
    let base = mesh.positions.len() as u32;
    mesh.positions.extend([
        [-50.0, 0.0, -50.0],
        [50.0, 0.0, -50.0],
        [50.0, 0.0, 50.0],
        [-50.0, 0.0, 50.0],
        [-3.0, 0.1, -3.0],
        [3.0, 1.1, 3.0],
        [3.0, 1.1, 3.01],
    ]);
    mesh.triangles
        .extend([[base, base + 2, base + 1], [base, base + 3, base + 2]]);
    mesh.triangles.push([base + 4, base + 5, base + 6]);
    let accel = Accel::build(&mesh).expect("build");
    accel.validate().expect("valid tree");
    assert_eq!(accel.triangle_count(), mesh.triangle_count());
    assert!(
        accel.bvh().len() > accel.triangle_count(),
        "expected split references: {} slots for {} triangles",
        accel.bvh().len(),
        accel.triangle_count()
    );
    let mut rays = random_rays(&mesh, 1500, 16);
    for i in 0..=16 {
        for j in 0..=16 {
            let (x, z) = (-50.0 + 6.25 * i as f32, -50.0 + 6.25 * j as f32);
            rays.push(([x, 10.0, z], [0.0, -1.0, 0.0], f32::INFINITY));
            rays.push(([x, -10.0, z], [0.0, 1.0, 0.0], 20.0));
        }
    }
    check_against_brute_force(&mesh, &accel, &rays);
    for &(origin, dir, t_max) in &rays {
        assert_eq!(
            accel.occluded(origin, dir, t_max),
            brute_force_any(&mesh, origin, dir, t_max)
        );
    }
}

#[test]
fn batches_with_unusable_rays_and_every_length_agree_with_single_rays() {
    let mesh = torus(60, 20);
    let mut rays = random_rays(&mesh, 200, 5);
    // Unusable queries between usable ones: they miss, as in `closest_hit`.
    for (k, bad) in [
        ([f32::NAN, 0.0, 0.0], [0.0, 0.0, 1.0], f32::INFINITY),
        ([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], f32::INFINITY),
        ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], 0.0),
        ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], f32::NAN),
        ([0.0, 0.0, 0.0], [f32::INFINITY, 1.0, 0.0], 1.0),
    ]
    .into_iter()
    .enumerate()
    {
        rays.insert(7 * k + 3, bad);
    }
    for (_, accel) in every_configuration(&mesh) {
        for len in [0, 1, 2, 5, 9, 17, rays.len()] {
            check_batch_against_single_rays(&accel, &rays[..len]);
        }
    }
    let empty = Accel::build(&TriangleMesh::default()).expect("empty accel");
    check_batch_against_single_rays(&empty, &rays);
}

/// A small tree and one ray, for the calls given the wrong number of hit slots.
fn a_tree_and_a_ray() -> (Accel, RayQuery) {
    let accel = Accel::build(&torus(8, 4)).expect("build");
    let ray = RayQuery {
        origin: [0.0; 3],
        dir: [0.0, 0.0, 1.0],
        t_max: 1.0,
    };
    (accel, ray)
}

#[test]
#[should_panic(expected = "closest_hits_one_by_one: 1 rays but 2 hit slots")]
fn rays_one_by_one_with_the_wrong_number_of_hit_slots_is_a_bug() {
    let (accel, ray) = a_tree_and_a_ray();
    accel.closest_hits_one_by_one(&[ray], &mut [None, None]);
}

#[test]
#[should_panic(expected = "closest_hits: 1 rays but 2 hit slots")]
fn a_batch_with_the_wrong_number_of_hit_slots_is_a_bug() {
    let (accel, ray) = a_tree_and_a_ray();
    accel.closest_hits(&[ray], &mut [None, None]);
}
