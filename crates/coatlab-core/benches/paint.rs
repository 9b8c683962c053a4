//! Criterion benchmarks of the paint model against its speed targets (one core):
//!
//! - an 81-wavelength f32 evaluation of body + specular ≤ 100 ns;
//! - a parameter change (the derived tables: C integral, m(g), normalisation) ≤ 1 ms.
//!
//! Run with `cargo bench -p coatlab-core --bench paint -- --warm-up-time 1
//! --measurement-time 3`. Results, the machine and notes on noise are in
//! `docs/benchmarks.md`. `PAINT_ONCE=N` runs N evaluations once, for instruction
//! counts (see `once`).
//!
//! Evaluation benches cycle through a fixed set of 64 direction pairs (half near
//! the mirror direction, half uniform over the hemisphere) so branch prediction and
//! caches see a renderer-like mix; one criterion iteration is one evaluation.
//! Parameter benches alternate between two valid values so every call really
//! recomputes (setting an equal value is a no-op for gloss and lobe).

use std::hint::black_box;
use std::time::Instant;

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::paint::coat::{c_integral, escape_integral_scaled};
use coatlab_core::paint::gloss::{GlossExponent, GlossGeometry, exponent_from_reading};
use coatlab_core::paint::lobe::{
    LobeKind, NormalisationTable, phong_normalisation, sample_phong_lobe,
};
use coatlab_core::paint::model::{
    GlossSetting, PaintModel, PaintParams, SpectralBsdf, cosine_hemisphere,
};
use coatlab_core::paint::phong::PhongParams;
use criterion::{BatchSize, BenchmarkId, Criterion, criterion_group};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// Direction pairs (and random triples) cycled through by the evaluation benches.
const PAIRS: usize = 64;
/// Gloss of the reference paint, GU at 20°: m ≈ 2.5e4 for n(587.6 nm) = 1.505. (An
/// ideal mirror coat of that index reads 83.4 GU at 20°, so 85 GU is the mirror.)
const GLOSS_GU: f64 = 80.0;

/// Cauchy dispersion of the clear coat: n(λ) = a + 0.0045/λ²(µm).
fn cauchy_index(a: f64, wavelength_nm: f64) -> f64 {
    a + 0.0045 / (wavelength_nm / 1000.0).powi(2)
}

/// A red sigmoid albedo.
fn red_albedo(wavelengths_nm: &[f64], edge_nm: f64) -> Vec<f64> {
    wavelengths_nm
        .iter()
        .map(|l| 0.05 + 0.7 / (1.0 + (-(l - edge_nm) / 15.0).exp()))
        .collect()
}

/// A realistic paint: dispersive coat (Cauchy 1.492), red pigment, UV absorber edge
/// at 390 nm, h = 45 µm, 85 GU at 20°, normalised lobe.
fn realistic_params(grid: WavelengthGrid) -> PaintParams {
    let wl: Vec<f64> = grid.wavelengths_nm().collect();
    PaintParams {
        channels: grid.into(),
        albedo: red_albedo(&wl, 600.0),
        refractive_index: wl.iter().map(|&l| cauchy_index(1.492, l)).collect(),
        index_at_gloss_wavelength: cauchy_index(1.492, 587.6),
        absorption_per_um: wl
            .iter()
            .map(|l| 0.0004 + 0.2 / (1.0 + ((l - 390.0) / 6.0).exp()))
            .collect(),
        thickness_um: 45.0,
        gloss: GlossSetting::Reading {
            gu: GLOSS_GU,
            geometry: GlossGeometry::Deg20,
        },
        lobe: LobeKind::Normalised,
    }
}

fn model_with(grid: WavelengthGrid, lobe: LobeKind, gloss: GlossSetting) -> PaintModel {
    let mut params = realistic_params(grid);
    params.lobe = lobe;
    params.gloss = gloss;
    PaintModel::new(params).expect("valid realistic parameters")
}

fn reference_model() -> PaintModel {
    PaintModel::new(realistic_params(WavelengthGrid::reference()))
        .expect("valid realistic parameters")
}

fn random_u(rng: &mut Pcg64) -> [f32; 3] {
    [
        rng.random::<f32>(),
        rng.random::<f32>(),
        rng.random::<f32>(),
    ]
}

/// 64 (wi, wo) pairs: wo cosine-distributed; wi near the mirror of wo (from the
/// lobe of m = 200, so the specular term is live) for even pairs, cosine-distributed
/// (mostly outside the lobe, as for light samples) for odd ones. All above the surface.
fn direction_pairs() -> Vec<([f32; 3], [f32; 3])> {
    let mut rng = Pcg64::seed_from_u64(0x5eed_c0a7);
    let mut pairs = Vec::with_capacity(PAIRS);
    while pairs.len() < PAIRS {
        let u = random_u(&mut rng);
        let wo = cosine_hemisphere([u[0], u[1]]);
        let wi = if pairs.len() % 2 == 0 {
            match sample_phong_lobe([-wo[0], -wo[1], wo[2]], 200.0, [u[2], rng.random::<f32>()]) {
                Some(wi) => wi,
                None => continue,
            }
        } else {
            cosine_hemisphere([u[2], rng.random::<f32>()])
        };
        if wi[2] > 0.0 && wo[2] > 0.0 {
            pairs.push((wi, wo));
        }
    }
    pairs
}

/// One evaluation per iteration, cycling through the direction pairs.
fn bench_eval(c: &mut Criterion, name: &str, model: &PaintModel) {
    let paint = model.spectral();
    let pairs = direction_pairs();
    let mut out = vec![0.0_f32; paint.len()];
    let mut k = 0_usize;
    c.bench_function(name, |b| {
        b.iter(|| {
            let (wi, wo) = pairs[k % PAIRS];
            k = k.wrapping_add(1);
            paint.eval(black_box(wi), black_box(wo), black_box(&mut out[..]));
        })
    });
}

fn eval_benches(c: &mut Criterion) {
    let reading = GlossSetting::Reading {
        gu: GLOSS_GU,
        geometry: GlossGeometry::Deg20,
    };
    let mirror = GlossSetting::Exponent(GlossExponent::Mirror);
    let reference = WavelengthGrid::reference();
    let sixteen = WavelengthGrid::visible(16).expect("16-sample grid");
    for (name, grid, lobe, gloss) in [
        ("eval/81", reference, LobeKind::Normalised, reading),
        ("eval/16", sixteen, LobeKind::Normalised, reading),
        ("eval/81/paper", reference, LobeKind::Paper, reading),
        ("eval/81/mirror", reference, LobeKind::Normalised, mirror),
    ] {
        bench_eval(c, name, &model_with(grid, lobe, gloss));
    }
}

fn sample_benches(c: &mut Criterion) {
    let model = reference_model();
    let paint = model.spectral();
    let mut rng = Pcg64::seed_from_u64(0x5a3b_1e00);
    let wos: Vec<[f32; 3]> = direction_pairs().into_iter().map(|(_, wo)| wo).collect();
    // 1024 triples against 64 view directions: no (wo, u) combination repeats soon.
    let us: Vec<[f32; 3]> = (0..1024).map(|_| random_u(&mut rng)).collect();
    let mut weight = vec![0.0_f32; paint.len()];
    let mut k = 0_usize;
    c.bench_function("sample/81", |b| {
        b.iter(|| {
            let wo = wos[k % PAIRS];
            let u = us[k % us.len()];
            k = k.wrapping_add(1);
            black_box(paint.sample(black_box(wo), black_box(u), black_box(&mut weight[..])))
        })
    });
}

/// Each iteration sets one of two values in turn, so every call recomputes.
fn bench_alternating<T: Clone>(
    c: &mut Criterion,
    name: &str,
    model: &mut PaintModel,
    values: [T; 2],
    mut set: impl FnMut(&mut PaintModel, T),
) {
    let mut k = 0_usize;
    c.bench_function(name, |b| {
        b.iter(|| {
            set(model, values[k % 2].clone());
            k = k.wrapping_add(1);
        })
    });
    black_box(model.spectral());
}

fn parameter_benches(c: &mut Criterion) {
    let grid = WavelengthGrid::reference();
    let wl: Vec<f64> = grid.wavelengths_nm().collect();
    let mut model = reference_model();

    let albedos = [red_albedo(&wl, 600.0), red_albedo(&wl, 610.0)];
    bench_alternating(c, "set_albedo", &mut model, albedos, |m, v| {
        m.set_albedo(v).expect("valid albedo")
    });

    bench_alternating(c, "set_thickness", &mut model, [45.0, 46.0], |m, h| {
        m.set_thickness(h).expect("valid thickness")
    });

    let absorptions = [0.0004, 0.0006].map(|k0| -> Vec<f64> {
        wl.iter()
            .map(|l| k0 + 0.2 / (1.0 + ((l - 390.0) / 6.0).exp()))
            .collect()
    });
    bench_alternating(c, "set_absorption", &mut model, absorptions, |m, k| {
        m.set_absorption(k).expect("valid absorption")
    });

    // With gloss given as a reading, n(587.6 nm) moves m, so the lobe table is rebuilt too.
    let indices = [1.492, 1.500].map(|a| {
        (
            wl.iter().map(|&l| cauchy_index(a, l)).collect::<Vec<_>>(),
            a,
        )
    });
    bench_alternating(
        c,
        "set_refractive_index/reading",
        &mut model,
        indices.clone(),
        |m, (n, a)| {
            m.set_refractive_index(n, cauchy_index(a, 587.6))
                .expect("valid index")
        },
    );
    // With the exponent given directly, only the coat integrals and angular tables.
    let mut fixed_m = model_with(
        grid,
        LobeKind::Normalised,
        GlossSetting::Exponent(GlossExponent::Finite(300.0)),
    );
    bench_alternating(
        c,
        "set_refractive_index/exponent",
        &mut fixed_m,
        indices,
        |m, (n, a)| {
            m.set_refractive_index(n, cauchy_index(a, 587.6))
                .expect("valid index")
        },
    );

    // The glossmeter's fraction table was built (once per process) by reference_model().
    let glosses = [80.0, 79.0].map(|gu| GlossSetting::Reading {
        gu,
        geometry: GlossGeometry::Deg20,
    });
    bench_alternating(c, "set_gloss", &mut model, glosses, |m, g| {
        m.set_gloss(g).expect("valid gloss")
    });

    // set_lobe is a no-op for an unchanged kind: time each direction from the other.
    for (to, from) in [
        (LobeKind::Normalised, LobeKind::Paper),
        (LobeKind::Paper, LobeKind::Normalised),
    ] {
        let mut start = reference_model();
        start.set_lobe(from);
        c.bench_function(&format!("set_lobe/{}", to.name()), |b| {
            b.iter_batched(
                || start.clone(),
                |mut m| {
                    m.set_lobe(to);
                    m
                },
                BatchSize::LargeInput,
            )
        });
    }
}

/// One benchmark group, `f` at each pair of `cases`, named by `names` and the pair.
fn bench_pairs(
    c: &mut Criterion,
    group: &str,
    names: (&str, &str),
    cases: &[(f64, f64)],
    f: impl Fn(f64, f64) -> f64,
) {
    let mut group = c.benchmark_group(group);
    for &(x, y) in cases {
        group.bench_with_input(
            BenchmarkId::from_parameter(format!("{}{x}_{}{y}", names.0, names.1)),
            &(x, y),
            |b, &(x, y)| b.iter(|| f(black_box(x), black_box(y))),
        );
    }
    group.finish();
}

fn table_benches(c: &mut Criterion) {
    bench_pairs(
        c,
        "c_integral",
        ("n", "tau"),
        &[
            (1.5, 0.02),
            (1.5, 100.0),
            (1.5, 1e4),
            (1.001, 0.02),
            (3.0, 0.02),
        ],
        c_integral,
    );
    bench_pairs(
        c,
        "phong_normalisation",
        ("m", "mu"),
        &[(100.0, 0.05), (100.0, 0.5), (1e4, 0.005), (1e4, 0.5)],
        |m, mu| phong_normalisation(mu, m),
    );

    let mut group = c.benchmark_group("NormalisationTable::new");
    for m in [100.0, 1e4] {
        group.bench_with_input(BenchmarkId::from_parameter(format!("m{m}")), &m, |b, &m| {
            b.iter(|| NormalisationTable::new(black_box(m)))
        });
    }
    group.finish();

    let n = cauchy_index(1.492, 587.6);
    c.bench_function("exponent_from_reading/20deg", |b| {
        b.iter(|| exponent_from_reading(GlossGeometry::Deg20, black_box(n), black_box(GLOSS_GU)))
    });
}

/// The glossmeter's lobe-fraction table is built once per geometry per process, on
/// first use; criterion cannot repeat it, so it is timed once here, before anything
/// else touches the glossmeter.
fn report_one_time_costs() {
    let n = cauchy_index(1.492, 587.6);
    for geometry in GlossGeometry::ALL {
        let start = Instant::now();
        let first = exponent_from_reading(geometry, n, 50.0);
        let first_s = start.elapsed().as_secs_f64();
        let start = Instant::now();
        let again = exponent_from_reading(geometry, n, 50.0);
        let again_s = start.elapsed().as_secs_f64();
        assert_eq!(first, again);
        println!(
            "one-time glossmeter table, {geometry}: first m(g) call {:.1} ms, second {:.1} µs",
            first_s * 1e3,
            again_s * 1e6
        );
    }
}

/// What a thickness (or absorption) change spends its time on: the coat's C and E
/// integrals at 81 wavelengths, and C alone.
fn derive_breakdown(c: &mut Criterion) {
    let model = reference_model();
    let (n, tau) = (
        model.refractive_index().to_vec(),
        model.optical_depth().to_vec(),
    );
    c.bench_function("derive/coat_integrals_81", |b| {
        b.iter(|| {
            n.iter()
                .zip(&tau)
                .map(|(&n, &tau)| {
                    c_integral(black_box(n), tau) + escape_integral_scaled(n, tau) * (-tau).exp()
                })
                .sum::<f64>()
        })
    });
    c.bench_function("derive/c_integral_81", |b| {
        b.iter(|| {
            n.iter()
                .zip(&tau)
                .map(|(&n, &tau)| c_integral(black_box(n), tau))
                .sum::<f64>()
        })
    });
}

/// The best-fit Phong of the signal-red preset on the preview's 32 wavelengths:
/// "cold" cycles through 16 glosses (m from 30 000 up in 1 % steps, so no fit is
/// ever reused), "rho_edit" alternates two albedos of one coat (only kd depends on
/// ρ). One iteration is one `PhongParams::best_fit`.
fn phong_benches(c: &mut Criterion) {
    let grid = WavelengthGrid::visible(32).expect("32-sample grid");
    let preset =
        coatlab_core::design::presets::by_slug("signal-red").expect("the signal-red preset");
    let base = preset.design.model(grid).expect("valid preset");
    let with = |albedo: &[f64], m: f64| {
        let mut model = base.clone();
        model.set_albedo(albedo.to_vec()).expect("valid albedo");
        model
            .set_gloss(GlossSetting::Exponent(GlossExponent::Finite(m)))
            .expect("valid gloss");
        model
    };
    let albedo = base.albedo().to_vec();
    let cold: Vec<PaintModel> = (0..16)
        .map(|k| with(&albedo, 30_000.0 * 1.01_f64.powi(k)))
        .collect();
    let paler: Vec<f64> = albedo.iter().map(|r| 0.9 * r + 0.05).collect();
    let rho_edit = [with(&albedo, 30_000.0), with(&paler, 30_000.0)];
    let mut k = 0_usize;
    c.bench_function("phong_best_fit/32/cold", |b| {
        b.iter(|| {
            k = k.wrapping_add(1);
            black_box(PhongParams::best_fit(black_box(&cold[k % cold.len()])))
        })
    });
    c.bench_function("phong_best_fit/32/rho_edit", |b| {
        b.iter(|| {
            k = k.wrapping_add(1);
            black_box(PhongParams::best_fit(black_box(&rho_edit[k % 2])))
        })
    });
}

criterion_group!(
    benches,
    phong_benches,
    eval_benches,
    sample_benches,
    parameter_benches,
    table_benches,
    derive_breakdown
);

/// `PAINT_ONCE=N`: N evaluations of the reference paint (81 wavelengths) over the
/// bench's direction pairs, then exits: for instruction counts under cachegrind
/// (`valgrind --tool=cachegrind --cache-sim=no`), e.g. of two builds' code paths.
fn once(evaluations: usize) {
    let model = reference_model();
    let paint = model.spectral();
    let pairs = direction_pairs();
    let mut out = vec![0.0_f32; paint.len()];
    let mut sum = 0.0_f32;
    for k in 0..evaluations {
        let (wi, wo) = pairs[k % PAIRS];
        paint.eval(black_box(wi), black_box(wo), black_box(&mut out[..]));
        sum += out[k % out.len()];
    }
    println!("{evaluations} evaluations, checksum {sum}");
}

fn main() {
    if let Some(n) = std::env::var("PAINT_ONCE")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        once(n);
        return;
    }
    report_one_time_costs();
    benches();
    Criterion::default().configure_from_args().final_summary();
}
