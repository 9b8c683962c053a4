//! Benchmarks of the acceleration structure (`coatlab_core::accel`) against the
//! targets on the 2-core machine: BVH build for 150k triangles ≤ 150 ms; ≥ 10 million
//! incoherent rays per second over both cores.
//!
//! Meshes: the Lamborghini Huracán GT3 glTF (145 917 triangles, shared test data), a
//! synthetic torus of 150 000 triangles, and the default car
//! (`scene::car::generate(&CarParameters::default())`).
//! Configurations: our own 8-wide BVH (`Simd8`) with 8, 16 and 32 SAH bins
//! (`Fastest`, `Fast`, `Medium`), and for comparison obvhs's 8-wide compressed BVH
//! (`Wide8`) and its binary BVH (`Binary`) with the `Fast` preset. Ratios are
//! against `Wide8/Fast`, the default before `Simd8`. `ACCEL_FILTER=Simd8` (a
//! substring of the label) runs only the matching configurations.
//!
//! Rays, all closest-hit with `t_max = ∞`:
//! - camera: a 960×540 pinhole camera (45° vertical field of view) looking at the
//!   model's centre from a raised front three-quarter view, one ray per pixel, rows
//!   handed out to rayon in chunks of 8 rows;
//! - incoherent: 2¹⁹ bounce rays, origins at area-weighted random points on the
//!   surface (moved off it with `offset_ray_origin`), cosine-distributed directions
//!   about the geometric normal's front side, in chunks of 4096 rays, each chunk one
//!   call of the batch interface `Accel::closest_hits` (and, for comparison, the same
//!   chunks through `closest_hits_one_by_one`: one ray at a time);
//! - shadow: the same rays as any-hit queries (`occluded`) with `t_max = 1 m`;
//! - image-order bounce: the tracer's first bounce in the order it issues it: camera
//!   rays of a 1920×1080 image in 16×16 tiles, and for each hit a cosine-distributed
//!   bounce about the geometric normal (camera side) from the offset hit point, so
//!   that consecutive rays start close together; chunks of 4096 rays through
//!   `closest_hits`.
//!
//! Ways to run it:
//! - `ACCEL_SUMMARY=1 cargo bench -p coatlab-core --bench accel` prints the whole
//!   comparison as a markdown table in one run (each figure the best of 5 runs) and
//!   skips criterion; this is what docs/benchmarks.md quotes.
//! - `cargo bench -p coatlab-core --bench accel -- --warm-up-time 1
//!   --measurement-time 3` runs the criterion benches (build single- and
//!   two-threaded; ray batches with throughput in rays).
//! - `ACCEL_BATCH=1 cargo bench -p coatlab-core --bench accel` compares, on one
//!   thread and in per-thread CPU time (robust to other processes on the machine),
//!   single-ray queries with batches of 2–32 rays in flight, for trees built with
//!   each `ReferenceSplits` setting (with the build's CPU time); with
//!   `ACCEL_WHICH=bounce` on the image-order bounces instead of the incoherent rays.
//! - `ACCEL_CPU=1 …/accel-<hash>` (the bench binary itself, two builds of it in
//!   turn): the default tree's incoherent and image-order bounce rays through
//!   `closest_hits` on one thread, on each SIMD path the CPU has, interleaved, M
//!   rays per CPU-second and per wall-clock second (best of 15 each) and the
//!   paths' ratios: A/B comparisons of traversal changes and of the SIMD paths on a
//!   noisy machine. `ACCEL_CPU=single`: one ray at a time
//!   (`closest_hits_one_by_one_on`).
//! - `ACCEL_ONCE=1` traces 2¹⁶ rays once, for instruction counts under callgrind
//!   (`ACCEL_ONCE=single`: one by one through `closest_hit`).
//! - `ACCEL_DUMP=DIR` writes each mesh and its rays to `DIR/<mesh>.bin` for other
//!   ray tracers (`benches/embree/`: Intel Embree 4 on the same rays).

use std::f32::consts::PI;
use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

use coatlab_core::accel::{
    Accel, BuildOptions, BuildQuality, BvhLayout, Hit, RayQuery, ReferenceSplits, offset_ray_origin,
};
use coatlab_core::scene::TriangleMesh;
use coatlab_core::scene::car::{CarParameters, generate};
use coatlab_core::scene::gltf_loader::{LoadOptions, load};
use coatlab_core::simd_path::SimdPath;
use criterion::{BenchmarkId, Criterion, Throughput};
use glam::Vec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;

const LAMBORGHINI: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/testdata/gltf/LamborghiniHuracanGT3/LamborghiniHuracanGT3.glb"
);

const WIDTH: usize = 960;
const HEIGHT: usize = 540;
const INCOHERENT_RAYS: usize = 1 << 19;
const SHADOW_T_MAX: f32 = 1.0;

const ALL_CONFIGS: [(&str, BuildOptions); 6] = [
    (
        "Simd8/Fast/Spatial (default)",
        BuildOptions {
            layout: BvhLayout::Simd8,
            quality: BuildQuality::Fast,
            reference_splits: ReferenceSplits::Spatial,
            threads: 0,
        },
    ),
    (
        "Simd8/Fastest",
        BuildOptions {
            layout: BvhLayout::Simd8,
            quality: BuildQuality::Fastest,
            reference_splits: ReferenceSplits::LargeTriangles,
            threads: 0,
        },
    ),
    (
        "Simd8/Fast",
        BuildOptions {
            layout: BvhLayout::Simd8,
            quality: BuildQuality::Fast,
            reference_splits: ReferenceSplits::LargeTriangles,
            threads: 0,
        },
    ),
    (
        "Simd8/Medium",
        BuildOptions {
            layout: BvhLayout::Simd8,
            quality: BuildQuality::Medium,
            reference_splits: ReferenceSplits::LargeTriangles,
            threads: 0,
        },
    ),
    (
        "Wide8/Fast",
        BuildOptions {
            layout: BvhLayout::Wide8,
            quality: BuildQuality::Fast,
            reference_splits: ReferenceSplits::LargeTriangles,
            threads: 0,
        },
    ),
    (
        "Binary/Fast",
        BuildOptions {
            layout: BvhLayout::Binary,
            quality: BuildQuality::Fast,
            reference_splits: ReferenceSplits::LargeTriangles,
            threads: 0,
        },
    ),
];

/// The configurations whose label contains `ACCEL_FILTER` (all without it).
fn configs() -> Vec<(&'static str, BuildOptions)> {
    let filter = std::env::var("ACCEL_FILTER").unwrap_or_default();
    ALL_CONFIGS
        .into_iter()
        .filter(|(label, _)| label.contains(filter.as_str()))
        .collect()
}

#[path = "../tests/support/area_cdf.rs"]
mod area_cdf;
use area_cdf::area_cdf;

#[path = "../tests/support/torus.rs"]
mod support_torus;
use support_torus::torus;

fn meshes() -> Vec<(String, TriangleMesh)> {
    // `ACCEL_MESH` (a substring of the name) restricts the meshes, like
    // `ACCEL_FILTER`; the others are not generated or loaded (under callgrind the
    // car's generation and the Lamborghini's textures took minutes).
    let filter = std::env::var("ACCEL_MESH").unwrap_or_default();
    let wanted = |name: &str| name.contains(&filter);
    let mut out = Vec::new();
    if wanted("default car") {
        out.push((
            "default car".to_string(),
            generate(&CarParameters::default()).mesh,
        ));
    }
    if wanted("Lamborghini") {
        if Path::new(LAMBORGHINI).exists() {
            match load(Path::new(LAMBORGHINI), &LoadOptions::default()) {
                Ok(scene) => out.push(("Lamborghini".to_string(), scene.mesh)),
                Err(e) => eprintln!("note: Lamborghini not benchmarked: {e}"),
            }
        } else {
            eprintln!("note: Lamborghini not benchmarked: {LAMBORGHINI} is missing");
        }
    }
    if wanted("torus") {
        out.push(("torus".to_string(), torus(500, 150)));
    }
    out
}

/// Pinhole camera: eye and, per pixel, a unit direction.
struct Camera {
    eye: [f32; 3],
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    tan_half: f32,
}

impl Camera {
    /// Raised front three-quarter view of the mesh's bounds.
    fn three_quarter(mesh: &TriangleMesh) -> Camera {
        let (lo, hi) = mesh
            .bounds()
            .map(|(lo, hi)| (Vec3::from(lo), Vec3::from(hi)))
            .expect("non-empty mesh");
        let centre = 0.5 * (lo + hi);
        let radius = 0.5 * (hi - lo).length();
        let tan_half = (22.5f32).to_radians().tan();
        let view = Vec3::new(1.0, 0.55, 1.3).normalize();
        let distance = 1.05 * radius / tan_half;
        let eye = centre + distance * view;
        let forward = (centre - eye).normalize();
        let right = forward.cross(Vec3::Y).normalize();
        let up = right.cross(forward);
        Camera {
            eye: eye.to_array(),
            forward,
            right,
            up,
            tan_half,
        }
    }

    fn dir(&self, x: usize, y: usize) -> [f32; 3] {
        self.dir_in(x, y, WIDTH, HEIGHT)
    }

    /// Direction through pixel (x, y) of a `width` × `height` image.
    fn dir_in(&self, x: usize, y: usize, width: usize, height: usize) -> [f32; 3] {
        let aspect = width as f32 / height as f32;
        let sx = (2.0 * (x as f32 + 0.5) / width as f32 - 1.0) * self.tan_half * aspect;
        let sy = (1.0 - 2.0 * (y as f32 + 0.5) / height as f32) * self.tan_half;
        (self.forward + sx * self.right + sy * self.up)
            .normalize()
            .to_array()
    }
}

/// Bounce rays: area-weighted surface points, cosine-distributed directions.
fn incoherent_rays(mesh: &TriangleMesh, count: usize, seed: u64) -> Vec<([f32; 3], [f32; 3])> {
    let cdf = area_cdf(mesh);
    let total = cdf.last().copied().unwrap_or(0.0);
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut rays = Vec::with_capacity(count);
    while rays.len() < count {
        let pick = rng.random::<f64>() * total;
        let t = cdf.partition_point(|&c| c < pick).min(cdf.len() - 1);
        let [a, b, c] = mesh.triangles[t].map(|i| Vec3::from(mesh.positions[i as usize]));
        let n = (b - a).cross(c - a);
        if n == Vec3::ZERO {
            continue;
        }
        let n = n.normalize();
        let (mut u, mut v) = (rng.random::<f32>(), rng.random::<f32>());
        if u + v > 1.0 {
            (u, v) = (1.0 - u, 1.0 - v);
        }
        let p = a + u * (b - a) + v * (c - a);
        let dir = cosine_about(n, &mut rng);
        rays.push((offset_ray_origin(p.to_array(), n.to_array()), dir));
    }
    rays
}

/// A cosine-distributed unit direction about the unit normal `n`.
fn cosine_about(n: Vec3, rng: &mut Pcg64) -> [f32; 3] {
    let (r1, r2) = (rng.random::<f32>(), rng.random::<f32>());
    let (r, phi) = (r1.sqrt(), 2.0 * PI * r2);
    let helper = if n.x.abs() > 0.9 { Vec3::Y } else { Vec3::X };
    let tx = helper.cross(n).normalize();
    let ty = n.cross(tx);
    let (lx, ly, lz) = (r * phi.cos(), r * phi.sin(), (1.0 - r1).max(0.0).sqrt());
    (lx * tx + ly * ty + lz * n).normalize().to_array()
}

/// The tracer's first bounce as it issues it: camera rays of a 1920×1080 image in
/// 16×16-pixel tiles (the film's tiles), and for each one that hits, a
/// cosine-distributed bounce about the geometric normal on the camera's side, from
/// the hit point moved off the surface; in that order, so consecutive rays start
/// close together (unlike the area-sampled `incoherent_rays`).
fn image_order_bounces(
    mesh: &TriangleMesh,
    camera: &Camera,
    seed: u64,
) -> Vec<([f32; 3], [f32; 3])> {
    const TILE: usize = 16;
    let (width, height) = (2 * WIDTH, 2 * HEIGHT);
    let accel = Accel::build(mesh).expect("build");
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut rays = Vec::new();
    for ty in (0..height).step_by(TILE) {
        for tx in (0..width).step_by(TILE) {
            for y in ty..(ty + TILE).min(height) {
                for x in tx..(tx + TILE).min(width) {
                    let dir = camera.dir_in(x, y, width, height);
                    let Some(hit) = accel.closest_hit(camera.eye, dir, f32::INFINITY) else {
                        continue;
                    };
                    let [a, b, c] = mesh.triangles[hit.triangle as usize]
                        .map(|i| Vec3::from(mesh.positions[i as usize]));
                    let mut n = (b - a).cross(c - a).normalize();
                    if n.dot(Vec3::from(dir)) > 0.0 {
                        n = -n;
                    }
                    let [u, v] = hit.barycentric;
                    let p = a + u * (b - a) + v * (c - a);
                    let origin = offset_ray_origin(p.to_array(), n.to_array());
                    rays.push((origin, cosine_about(n, &mut rng)));
                }
            }
        }
    }
    rays
}

/// Traces the camera image; returns the number of hits.
fn trace_camera(accel: &Accel, camera: &Camera) -> usize {
    (0..HEIGHT)
        .into_par_iter()
        .with_min_len(8)
        .map(|y| {
            (0..WIDTH)
                .filter(|&x| {
                    accel
                        .closest_hit(camera.eye, camera.dir(x, y), f32::INFINITY)
                        .is_some()
                })
                .count()
        })
        .sum()
}

/// Closest hits through the batch interface (`Accel::closest_hits`), a chunk of
/// 4096 rays a call; returns the number of hits.
fn trace_incoherent(accel: &Accel, rays: &[([f32; 3], [f32; 3])]) -> usize {
    rays.par_chunks(4096)
        .map(|chunk| {
            let mut hits = vec![None; chunk.len()];
            accel.closest_hits(&chunk_queries(chunk), &mut hits);
            hits.iter().filter(|h| h.is_some()).count()
        })
        .sum()
}

/// Closest-hit queries with `t_max = ∞` for a chunk of rays.
fn chunk_queries(chunk: &[([f32; 3], [f32; 3])]) -> Vec<RayQuery> {
    chunk
        .iter()
        .map(|&(origin, dir)| RayQuery {
            origin,
            dir,
            t_max: f32::INFINITY,
        })
        .collect()
}

/// Each ray's closest hit through `closest_hits`, in the order of `rays`.
fn incoherent_hits(accel: &Accel, rays: &[([f32; 3], [f32; 3])]) -> Vec<Option<Hit>> {
    let mut hits = vec![None; rays.len()];
    rays.par_chunks(4096)
        .zip(hits.par_chunks_mut(4096))
        .for_each(|(chunk, out)| accel.closest_hits(&chunk_queries(chunk), out));
    hits
}

/// The same rays one at a time (`Accel::closest_hits_one_by_one`, which is
/// `closest_hit` for each ray with the SIMD path entered once a chunk).
fn trace_one_by_one(accel: &Accel, rays: &[([f32; 3], [f32; 3])]) -> usize {
    rays.par_chunks(4096)
        .map(|chunk| {
            let mut hits = vec![None; chunk.len()];
            accel.closest_hits_one_by_one(&chunk_queries(chunk), &mut hits);
            hits.iter().filter(|h| h.is_some()).count()
        })
        .sum()
}

fn trace_shadow(accel: &Accel, rays: &[([f32; 3], [f32; 3])]) -> usize {
    rays.par_chunks(4096)
        .map(|chunk| {
            chunk
                .iter()
                .filter(|(o, d)| accel.occluded(*o, *d, SHADOW_T_MAX))
                .count()
        })
        .sum()
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool")
}

/// Best of `runs` wall-clock times of `f`.
fn best_of<T>(runs: usize, mut f: impl FnMut() -> T) -> (Duration, T) {
    let mut best = Duration::MAX;
    let mut out = None;
    for _ in 0..runs {
        let start = Instant::now();
        let r = black_box(f());
        best = best.min(start.elapsed());
        out = Some(r);
    }
    (best, out.expect("runs > 0"))
}

/// The load average (1, 5, 15 minutes), for the record: other processes on the
/// machine skew every figure, the 2-thread ones most.
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

fn summary() {
    let (one, two) = (pool(1), pool(2));
    println!(
        "| mesh | triangles | BVH | build 1 thread (ms) | build 2 threads (ms) | nodes | \
         camera Mrays/s 1 core | camera Mrays/s 2 cores | incoherent Mrays/s 1 core | \
         incoherent Mrays/s 2 cores | incoherent one by one Mrays/s 1 core | \
         shadow Mrays/s 2 cores | image-order bounce Mrays/s 2 cores | \
         image-order bounce one by one Mrays/s 2 cores |"
    );
    println!(
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
    );
    for (name, mesh) in meshes() {
        let camera = Camera::three_quarter(&mesh);
        let rays = incoherent_rays(&mesh, INCOHERENT_RAYS, 7);
        let bounces = image_order_bounces(&mesh, &camera, 8);
        eprintln!("{name}: load average before: {}", load_average());
        let mut reference: Option<(f64, f64, f64)> = None;
        let mut notes = Vec::new();
        for (label, options) in configs() {
            // `Simd8` builds on threads of its own: as many as the pool has.
            let (options1, options2) = (
                BuildOptions {
                    threads: 1,
                    ..options
                },
                BuildOptions {
                    threads: 2,
                    ..options
                },
            );
            let (build1, _) = best_of(5, || one.install(|| Accel::build_with(&mesh, &options1)));
            let (build2, accel) =
                best_of(5, || two.install(|| Accel::build_with(&mesh, &options2)));
            let accel = accel.expect("build");
            let rate = |pool: &rayon::ThreadPool, n: usize, f: &(dyn Fn() -> usize + Sync)| {
                let (t, hits) = best_of(5, || pool.install(f));
                (n as f64 / t.as_secs_f64() / 1e6, hits)
            };
            let camera_n = WIDTH * HEIGHT;
            let (cam1, _) = rate(&one, camera_n, &|| trace_camera(&accel, &camera));
            let (cam2, cam_hits) = rate(&two, camera_n, &|| trace_camera(&accel, &camera));
            let (inc1, _) = rate(&one, rays.len(), &|| trace_incoherent(&accel, &rays));
            let (inc2, inc_hits) = rate(&two, rays.len(), &|| trace_incoherent(&accel, &rays));
            let (single1, _) = rate(&one, rays.len(), &|| trace_one_by_one(&accel, &rays));
            let (sh2, sh_hits) = rate(&two, rays.len(), &|| trace_shadow(&accel, &rays));
            let (bo2, bo_hits) = rate(&two, bounces.len(), &|| trace_incoherent(&accel, &bounces));
            let (bo_single2, _) = rate(&two, bounces.len(), &|| trace_one_by_one(&accel, &bounces));
            println!(
                "| {name} | {} | {label} | {:.1} | {:.1} | {} | {cam1:.2} | {cam2:.2} | {inc1:.2} | \
                 {inc2:.2} | {single1:.2} | {sh2:.2} | {bo2:.2} | {bo_single2:.2} |",
                mesh.triangle_count(),
                build1.as_secs_f64() * 1e3,
                build2.as_secs_f64() * 1e3,
                accel.bvh().node_count(),
            );
            if label == "Wide8/Fast" {
                reference = Some((cam2, inc2, bo2));
            }
            notes.push((label, cam2, inc2, bo2));
            if label == "Simd8/Fast" {
                eprintln!(
                    "{name}: camera rays hitting {:.1} %, incoherent rays hitting {:.1} %, \
                     shadow rays (t_max {SHADOW_T_MAX} m) occluded {:.1} %, {} image-order \
                     bounce rays hitting {:.1} %",
                    100.0 * cam_hits as f64 / camera_n as f64,
                    100.0 * inc_hits as f64 / rays.len() as f64,
                    100.0 * sh_hits as f64 / rays.len() as f64,
                    bounces.len(),
                    100.0 * bo_hits as f64 / bounces.len() as f64,
                );
            }
        }
        eprintln!("{name}: load average after: {}", load_average());
        if let Some((cam_ref, inc_ref, bo_ref)) = reference {
            for (label, cam, inc, bo) in notes {
                eprintln!(
                    "{name}: {label} vs Wide8/Fast (2 cores): camera ×{:.2}, incoherent ×{:.2}, \
                     image-order bounce ×{:.2}",
                    cam / cam_ref,
                    inc / inc_ref,
                    bo / bo_ref
                );
            }
        }
    }
}

fn criterion_benches(c: &mut Criterion) {
    let (one, two) = (pool(1), pool(2));
    for (name, mesh) in meshes() {
        let camera = Camera::three_quarter(&mesh);
        let rays = incoherent_rays(&mesh, INCOHERENT_RAYS, 7);
        let mut build = c.benchmark_group(format!("accel_build/{name}"));
        build.sample_size(10);
        for (label, options) in configs() {
            for (threads, pool) in [(1, &one), (2, &two)] {
                let options = BuildOptions { threads, ..options };
                build.bench_function(BenchmarkId::new(label, format!("{threads}T")), |b| {
                    b.iter(|| pool.install(|| Accel::build_with(black_box(&mesh), &options)))
                });
            }
        }
        build.finish();

        let mut trace = c.benchmark_group(format!("accel_rays/{name}"));
        trace.sample_size(10);
        for (label, options) in configs() {
            let accel = Accel::build_with(&mesh, &options).expect("build");
            trace.throughput(Throughput::Elements((WIDTH * HEIGHT) as u64));
            trace.bench_function(BenchmarkId::new("camera_2T", label), |b| {
                b.iter(|| two.install(|| trace_camera(&accel, &camera)))
            });
            trace.throughput(Throughput::Elements(rays.len() as u64));
            trace.bench_function(BenchmarkId::new("incoherent_2T", label), |b| {
                b.iter(|| two.install(|| trace_incoherent(&accel, &rays)))
            });
            trace.bench_function(BenchmarkId::new("incoherent_1T", label), |b| {
                b.iter(|| one.install(|| trace_incoherent(&accel, &rays)))
            });
            trace.bench_function(BenchmarkId::new("incoherent_one_by_one_1T", label), |b| {
                b.iter(|| one.install(|| trace_one_by_one(&accel, &rays)))
            });
            trace.bench_function(BenchmarkId::new("shadow_2T", label), |b| {
                b.iter(|| two.install(|| trace_shadow(&accel, &rays)))
            });
        }
        trace.finish();
    }
}

/// CPU time this thread has run (`/proc/thread-self/schedstat`, first field, ns):
/// unlike the wall clock, it does not count the time other processes held the core.
fn thread_cpu_time() -> Duration {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse().ok())
        .map(Duration::from_nanos)
        .expect("/proc/thread-self/schedstat (Linux) for ACCEL_BATCH")
}

/// Incoherent rays (with `ACCEL_WHICH=bounce` the image-order bounces) through
/// `closest_hit` one by one and through `closest_hits` with
/// 2, 4, 8, 12, 16 and 32 rays in flight, on this thread, `Simd8/Fast` built with
/// each `ReferenceSplits` setting: M rays per CPU-second (best of 5 interleaved
/// rounds), the ratio to one by one and to the default setting, and the build's
/// CPU time (best of 3); every result is checked against the default tree's
/// single-ray ones bit for bit.
fn batch_comparison() {
    let options = BuildOptions {
        threads: 1,
        ..BuildOptions::default()
    };
    type Trace = fn(&Accel, &[RayQuery], &mut [Option<Hit>]);
    let variants: [(&str, Trace); 8] = [
        ("one by one", Accel::closest_hits_one_by_one),
        ("batch, 2 lanes", Accel::closest_hits_in_lanes::<2>),
        ("batch, 4 lanes", Accel::closest_hits_in_lanes::<4>),
        ("batch, 8 lanes", Accel::closest_hits_in_lanes::<8>),
        ("batch, 12 lanes", Accel::closest_hits_in_lanes::<12>),
        ("batch, 16 lanes", Accel::closest_hits_in_lanes::<16>),
        ("batch, 32 lanes", Accel::closest_hits_in_lanes::<32>),
        ("closest_hits", Accel::closest_hits),
    ];
    let splits = [
        ("large triangles", ReferenceSplits::LargeTriangles),
        ("spatial", ReferenceSplits::Spatial),
    ];
    let which = std::env::var("ACCEL_WHICH").unwrap_or_default();
    for (name, mesh) in meshes() {
        // The image-order bounces are fewer (about 2·10⁵); repeated up to the
        // incoherent rays' count, so that a run spans many scheduler ticks (the
        // CPU-time clock's resolution).
        let rays: Vec<RayQuery> = {
            let rays = queries(&mesh, &which);
            let count = rays.len().max(INCOHERENT_RAYS);
            rays.iter().cycle().take(count).copied().collect()
        };
        eprintln!("{name}: load average before: {}", load_average());
        // Builds on this thread, best of 3 CPU times, for each split placement;
        // and on all cores (`threads: 0`), best of 3 wall-clock times.
        let mut build = [Duration::MAX; 2];
        let mut build_all_cores = [Duration::MAX; 2];
        let mut accels = Vec::new();
        for (s, &(_, reference_splits)) in splits.iter().enumerate() {
            let options = BuildOptions {
                reference_splits,
                ..options
            };
            for _ in 0..3 {
                let all_cores = BuildOptions {
                    threads: 0,
                    ..options
                };
                let start = Instant::now();
                black_box(Accel::build_with(&mesh, &all_cores).expect("build"));
                build_all_cores[s] = build_all_cores[s].min(start.elapsed());
            }
            for _ in 0..3 {
                let start = thread_cpu_time();
                let accel = Accel::build_with(&mesh, &options).expect("build");
                build[s] = build[s].min(thread_cpu_time() - start);
                if accels.len() == s {
                    accels.push(accel);
                }
            }
        }
        let mut reference = vec![None; rays.len()];
        variants[0].1(&accels[0], &rays, &mut reference);
        let mut best = [[Duration::MAX; 8]; 2];
        let mut hits = vec![None; rays.len()];
        for _ in 0..5 {
            for (s, accel) in accels.iter().enumerate() {
                for (i, (label, trace)) in variants.iter().enumerate() {
                    let start = thread_cpu_time();
                    trace(accel, &rays, &mut hits);
                    best[s][i] = best[s][i].min(thread_cpu_time() - start);
                    // Splits change which references a ray meets, never the
                    // closest triangle or its distance.
                    assert!(hits == reference, "{name}: {label} differs from one by one");
                }
            }
        }
        eprintln!("{name}: load average after: {}", load_average());
        let rate = |t: Duration| rays.len() as f64 / t.as_secs_f64() / 1e6;
        for (s, (split, _)) in splits.iter().enumerate() {
            println!(
                "| {name} | {split} | build {:.1} ms CPU (1 thread), {:.1} ms wall (all cores), {} references, {} nodes | |",
                build[s].as_secs_f64() * 1e3,
                build_all_cores[s].as_secs_f64() * 1e3,
                accels[s].bvh().len(),
                accels[s].bvh().node_count()
            );
            for (i, (label, _)) in variants.iter().enumerate() {
                println!(
                    "| {name} | {split} | {label} | {:.2} | ×{:.2} | ×{:.2} vs large triangles only |",
                    rate(best[s][i]),
                    best[s][0].as_secs_f64() / best[s][i].as_secs_f64(),
                    best[0][i].as_secs_f64() / best[s][i].as_secs_f64()
                );
            }
        }
    }
}

/// Writes, for each mesh, `<dir>/<mesh>.bin`: the mesh and the bench's own rays, for
/// other ray tracers to trace the same work (benches/embree/). Little-endian: five
/// u32 (vertex, triangle, incoherent-ray and image-order-bounce counts, and how many
/// of the incoherent rays our `closest_hits` finds a hit for), then the vertices
/// (3 f32 each), the triangles (3 u32), the incoherent rays and the bounces (origin
/// and direction, 6 f32 each). Beside it, `<dir>/<mesh>.hits`: for each incoherent
/// ray, our closest hit's triangle index (`u32::MAX` for a miss) and distance (f32),
/// so that the other tracer's hits can be compared ray by ray.
fn dump(dir: &Path) {
    std::fs::create_dir_all(dir).expect("dump folder");
    for (name, mesh) in meshes() {
        let camera = Camera::three_quarter(&mesh);
        let rays = incoherent_rays(&mesh, INCOHERENT_RAYS, 7);
        let bounces = image_order_bounces(&mesh, &camera, 8);
        let ray_hits = incoherent_hits(&Accel::build(&mesh).expect("build"), &rays);
        let hits = ray_hits.iter().filter(|h| h.is_some()).count();
        let mut out = Vec::new();
        let mut put = |x: u32| out.extend_from_slice(&x.to_le_bytes());
        for count in [
            mesh.positions.len(),
            mesh.triangles.len(),
            rays.len(),
            bounces.len(),
            hits,
        ] {
            put(count as u32);
        }
        mesh.positions
            .iter()
            .flatten()
            .for_each(|x| put(x.to_bits()));
        mesh.triangles.iter().flatten().for_each(|&i| put(i));
        for (origin, dir) in rays.iter().chain(&bounces) {
            origin.iter().chain(dir).for_each(|x| put(x.to_bits()));
        }
        let path = dir.join(format!("{}.bin", name.replace(' ', "-")));
        std::fs::write(&path, out).expect("dump file");
        let per_ray: Vec<u8> = ray_hits
            .iter()
            .flat_map(|hit| {
                let (triangle, t) = hit.map_or((u32::MAX, f32::INFINITY), |h| (h.triangle, h.t));
                [triangle.to_le_bytes(), t.to_bits().to_le_bytes()]
            })
            .flatten()
            .collect();
        std::fs::write(path.with_extension("hits"), per_ray).expect("dump hits file");
        eprintln!("{}: {} rays, {hits} hit", path.display(), rays.len());
    }
}

/// The incoherent rays, or with `which == "bounce"` the image-order bounces, as
/// batch queries.
fn queries(mesh: &TriangleMesh, which: &str) -> Vec<RayQuery> {
    let rays = if which == "bounce" {
        image_order_bounces(mesh, &Camera::three_quarter(mesh), 8)
    } else {
        incoherent_rays(mesh, INCOHERENT_RAYS, 7)
    };
    rays.into_iter()
        .map(|(origin, dir)| RayQuery {
            origin,
            dir,
            t_max: f32::INFINITY,
        })
        .collect()
}

/// `ACCEL_CPU`: for comparing two builds of this bench run in turn, and the SIMD
/// paths of one build: each mesh's default tree (built on one thread), then its
/// incoherent rays and its image-order bounces (repeated to as many rays) through
/// `closest_hits_on` in chunks of 4096 on this thread, on each SIMD path the CPU has
/// (or only `COATLAB_SIMD`'s where it is set), 15 rounds of every set on every path in turn; M rays per
/// second of this thread's CPU time and of wall-clock time, each the best of the
/// 15, and each path's CPU rate as a ratio to the first path's. (The thread's CPU
/// time, read from `/proc`, advances by scheduler ticks, so runs of well over
/// 100 ms are needed; other processes on a shared machine slow single runs by tens
/// of per cent, which the best of many and the interleaving filter out.)
/// `ACCEL_CPU=single`: the rays one at a time through `closest_hits_one_by_one_on`
/// instead.
fn cpu_rates() {
    let one_by_one = std::env::var("ACCEL_CPU").is_ok_and(|v| v == "single");
    let paths: Vec<SimdPath> = match SimdPath::from_env() {
        Ok(Some(path)) => vec![path],
        _ => SimdPath::ALL
            .into_iter()
            .filter(|p| p.is_available())
            .collect(),
    };
    for (name, mesh) in meshes() {
        let accel = Accel::build_with(
            &mesh,
            &BuildOptions {
                threads: 1,
                ..BuildOptions::default()
            },
        )
        .expect("build");
        // The image-order bounces repeated up to the incoherent rays' count, as in
        // `batch_comparison`: a set of a few tens of milliseconds spans only a few
        // of the CPU-time clock's steps.
        let bounces = queries(&mesh, "bounce");
        let bounces = bounces
            .iter()
            .cycle()
            .take(bounces.len().max(INCOHERENT_RAYS));
        let sets = [queries(&mesh, "incoherent"), bounces.copied().collect()];
        let mut hits: Vec<Vec<Option<Hit>>> = sets.iter().map(|s| vec![None; s.len()]).collect();
        // Best CPU and wall time for each path and set.
        let mut best = vec![[[Duration::MAX; 2]; 2]; paths.len()];
        for _ in 0..15 {
            for (p, &path) in paths.iter().enumerate() {
                for (k, rays) in sets.iter().enumerate() {
                    let (cpu, wall) = (thread_cpu_time(), Instant::now());
                    if one_by_one {
                        for (q, h) in rays.chunks(4096).zip(hits[k].chunks_mut(4096)) {
                            accel.closest_hits_one_by_one_on(path, q, h);
                        }
                    } else {
                        for (q, h) in rays.chunks(4096).zip(hits[k].chunks_mut(4096)) {
                            accel.closest_hits_on(path, q, h);
                        }
                    }
                    best[p][k][0] = best[p][k][0].min(thread_cpu_time() - cpu);
                    best[p][k][1] = best[p][k][1].min(wall.elapsed());
                    black_box(&hits[k]);
                }
            }
        }
        let rate =
            |p: usize, k: usize, i: usize| sets[k].len() as f64 / best[p][k][i].as_secs_f64() / 1e6;
        for (p, path) in paths.iter().enumerate() {
            println!(
                "{name} [{}]: M rays/s of CPU, wall: incoherent {:.3}, {:.3} (×{:.3}); \
                 image-order bounce {:.3}, {:.3} (×{:.3}) (load {})",
                path.name(),
                rate(p, 0, 0),
                rate(p, 0, 1),
                rate(p, 0, 0) / rate(0, 0, 0),
                rate(p, 1, 0),
                rate(p, 1, 1),
                rate(p, 1, 0) / rate(0, 1, 0),
                load_average()
            );
        }
    }
}

/// `ACCEL_ONCE`: the first `ACCEL_RAYS` (default 2¹⁶) incoherent rays (with
/// `ACCEL_WHICH=bounce` the image-order bounces) through `closest_hits` once on one
/// thread, for counting instructions a ray with `valgrind --tool=callgrind
/// --toggle-collect='*simd_path::on_avx2*'`, the AVX2 kernels (docs/benchmarks.md).
/// `ACCEL_ONCE=single`: through `closest_hit` one by one instead.
fn once() {
    let single = std::env::var("ACCEL_ONCE").is_ok_and(|v| v == "single");
    let count: usize = std::env::var("ACCEL_RAYS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1 << 16);
    let which = std::env::var("ACCEL_WHICH").unwrap_or_default();
    for (name, mesh) in meshes() {
        let accel = Accel::build(&mesh).expect("build");
        let rays = queries(&mesh, &which);
        let rays = &rays[..count.min(rays.len())];
        let mut hits = vec![None; rays.len()];
        if single {
            for (q, h) in rays.iter().zip(hits.iter_mut()) {
                *h = accel.closest_hit(q.origin, q.dir, q.t_max);
            }
        } else {
            for (q, h) in rays.chunks(4096).zip(hits.chunks_mut(4096)) {
                accel.closest_hits(q, h);
            }
        }
        let hit = hits.iter().filter(|h| h.is_some()).count();
        println!("{name}: {} rays, {hit} hit", rays.len());
    }
}

fn main() {
    if std::env::var_os("ACCEL_CPU").is_some() {
        cpu_rates();
        return;
    }
    if std::env::var_os("ACCEL_ONCE").is_some() {
        once();
        return;
    }
    if let Some(dir) = std::env::var_os("ACCEL_DUMP") {
        dump(Path::new(&dir));
        return;
    }
    if std::env::var_os("ACCEL_BATCH").is_some() {
        println!("| mesh | incoherent rays | M rays per CPU-second, 1 thread | vs one by one |");
        println!("| --- | --- | --- | --- |");
        batch_comparison();
        return;
    }
    if std::env::var_os("ACCEL_SUMMARY").is_some() {
        summary();
        return;
    }
    let mut c = Criterion::default().configure_from_args();
    criterion_benches(&mut c);
    c.final_summary();
}
