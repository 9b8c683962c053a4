//! The comparison's work between passes, on two films of 316×400 pixels (one pane
//! of the preview's side-by-side layout) with 16 noisy samples a pixel: the ΔE00
//! map between the films, the map between two panes given as mean XYZ, and the map
//! guidance's weights, apart and shared (`engine/guide.rs`). A guided comparison
//! makes these at each reweigh and map refresh, on the render thread.
//!
//!     cargo bench -p coatlab-core --bench comparison
//!
//! `COMPARISON_REPEAT=N` makes each of them N times and exits, for whole-process
//! timings of two builds in turn (farm-bench).

use coatlab_core::colour::spectrum::Channels;
use coatlab_core::engine::DeltaEMap;
use coatlab_core::engine::guide::{map_guided_weights, shared_map_guided_weights};
use coatlab_core::render::film::{DisplaySettings, Film};
use criterion::{Criterion, criterion_group};
use rand::{RngExt, SeedableRng};

const WIDTH: u32 = 316;
const HEIGHT: u32 = 400;
const SAMPLES: u32 = 16;

/// A film of a smooth image (its colour drifting across the frame, `tint` added
/// to red) whose samples scatter by ±60 % about each pixel's colour.
fn film(seed: u64, tint: f32) -> Film {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let mut film = Film::new(WIDTH, HEIGHT, Channels::LinearSrgb);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let (u, v) = (x as f32 / WIDTH as f32, y as f32 / HEIGHT as f32);
            let colour = [0.05 + 0.4 * u + tint, 0.05 + 0.3 * v, 0.1 + 0.2 * u * v];
            for _ in 0..SAMPLES {
                let s: f32 = rng.random_range(0.4..1.6);
                film.add_sample(x, y, &colour.map(|c| c * s));
            }
        }
    }
    film
}

/// What a shared comparison's guide is given: both films' means as panes and
/// the variances of their difference's X, Y and Z.
struct Panes {
    first: Vec<[f32; 3]>,
    second: Vec<[f32; 3]>,
    variance: Vec<[f32; 3]>,
}

fn panes(a: &Film, b: &Film) -> Panes {
    let means = |film: &Film| -> Vec<[f32; 3]> {
        (0..HEIGHT)
            .flat_map(|y| (0..WIDTH).map(move |x| (x, y)))
            .map(|(x, y)| {
                let m = film.mean_xyz(x, y);
                [m.x as f32, m.y as f32, m.z as f32]
            })
            .collect()
    };
    let variance = (0..HEIGHT)
        .flat_map(|y| (0..WIDTH).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (va, vb) = (a.variance_of_mean_xyz(x, y), b.variance_of_mean_xyz(x, y));
            std::array::from_fn(|c| (va[c] + vb[c]) as f32)
        })
        .collect();
    Panes {
        first: means(a),
        second: means(b),
        variance,
    }
}

/// The four pieces of work, each once; what each returns is kept from the
/// optimiser by the caller.
fn map_between_films(a: &Film, b: &Film, display: &DisplaySettings) -> Option<DeltaEMap> {
    DeltaEMap::between(a, b, display)
}

fn map_between_panes(p: &Panes, display: &DisplaySettings) -> Option<DeltaEMap> {
    DeltaEMap::between_xyz(WIDTH, HEIGHT, &p.first, &p.second, display)
}

fn guide_apart(a: &Film, b: &Film, display: &DisplaySettings) -> Option<Vec<f32>> {
    map_guided_weights(a, b, display)
}

fn guide_shared(p: &Panes, a: &Film, display: &DisplaySettings) -> Option<Vec<f32>> {
    shared_map_guided_weights(&p.first, &p.second, &p.variance, a, display)
}

fn comparison(c: &mut Criterion) {
    let (a, b) = (film(1, 0.0), film(2, 0.03));
    let p = panes(&a, &b);
    let display = DisplaySettings::default();
    let mut group = c.benchmark_group("comparison 316x400");
    group.sample_size(20);
    group.bench_function("map between films", |bench| {
        bench.iter(|| map_between_films(&a, &b, &display))
    });
    group.bench_function("map between panes", |bench| {
        bench.iter(|| map_between_panes(&p, &display))
    });
    group.bench_function("guide, apart", |bench| {
        bench.iter(|| guide_apart(&a, &b, &display))
    });
    group.bench_function("guide, shared", |bench| {
        bench.iter(|| guide_shared(&p, &a, &display))
    });
    group.finish();
}

criterion_group!(benches, comparison);

fn main() {
    if let Some(repeat) = std::env::var("COMPARISON_REPEAT")
        .ok()
        .and_then(|v| v.parse::<u32>().ok())
    {
        let (a, b) = (film(1, 0.0), film(2, 0.03));
        let p = panes(&a, &b);
        let display = DisplaySettings::default();
        for _ in 0..repeat {
            std::hint::black_box(map_between_films(&a, &b, &display));
            std::hint::black_box(map_between_panes(&p, &display));
            std::hint::black_box(guide_apart(&a, &b, &display));
            std::hint::black_box(guide_shared(&p, &a, &display));
        }
        return;
    }
    benches();
    Criterion::default().configure_from_args().final_summary();
}
