//! Live editing (issue 6): what the designer waits for after an edit, at 960×540,
//! the default car, the studio, the signal-red preset, 32 wavelengths, as the app
//! does it (`ProgressiveRender::edit_shading`, 4 samples per pixel recorded).
//!
//!     cargo bench -p coatlab-core --bench edit
//!
//! Environment: `COATLAB_EDIT_BASE_SPP` (samples per pixel of the image being
//! edited, default 16), `COATLAB_EDIT_REFERENCE_SPP` (of each edited design's
//! reference, default 64), `COATLAB_EDIT_SECONDS` (how long the error is followed
//! after an edit, default 3). `COATLAB_EDIT_REFERENCE_SPP=0`: first-image timings
//! only. `COATLAB_EDIT_ERROR_EDITS` (default 4): for how many of the edits the
//! error is followed (each needs its own reference render).
//!
//! For an edit of ρ, k, h and n separately (each from the same base, as steps of
//! one slider drag are): the time to the first full-resolution image (re-shade,
//! blend, conversion to display pixels), split into its parts; then the mean
//! CIEDE2000 of the displayed image against a reference of the edited design
//! after each fresh pass, with the time since the edit. The reference is rendered
//! here (another seed) and its own noise is printed: the error floor it sets.
//! For a gloss edit and a camera change: the time to the first image the app
//! shows (a coarse pass at a quarter of the resolution each way).
//! Also the memory of the path caches, and the machine's load average.

use std::sync::Arc;
use std::time::Instant;

use coatlab_core::colour::ciede2000;
use coatlab_core::colour::spectrum::{TabulatedSpectrum, WavelengthGrid};
use coatlab_core::design::{PaintDesign, RefractiveIndex, presets};
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::{DisplaySettings, DisplayTransform, display_xyz};
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::{
    EditOutcome, ProgressiveRender, RenderScene, RenderSettings,
};
use coatlab_core::render::reshade::{BaseImage, Reshaded, reshade_prepared};
use coatlab_core::scene::Scene;
use coatlab_core::scene::car::{CarParameters, generate};

const WIDTH: u32 = 960;
const HEIGHT: u32 = 540;
/// The app's coarse first pass: a quarter of the resolution each way.
const COARSE_FACTOR: u32 = 4;
/// Every STRIDE-th pixel each way enters the mean ΔE00 (130 k pixels).
const STRIDE: u32 = 2;

fn env_u32(name: &str, default: u32) -> u32 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".into())
}

struct Setup {
    grid: WavelengthGrid,
    scene: Scene,
    render_scene: Arc<RenderScene>,
    environment: Arc<Environment>,
}

impl Setup {
    fn shading(&self, design: &PaintDesign) -> Arc<Shading> {
        let paint = design.model(self.grid).expect("model");
        Arc::new(Shading::for_scene(&paint, ShadingModel::Paint, &self.scene))
    }

    fn render(&self, design: &PaintDesign, seed: u64) -> ProgressiveRender {
        ProgressiveRender::new(
            self.render_scene.clone(),
            self.environment.clone(),
            self.shading(design),
            self.render_scene.default_camera(WIDTH, HEIGHT),
            RenderSettings::seeded(seed),
        )
        .expect("render")
    }
}

/// Mean ΔE00 between `xyz` (row-major means) and the reference film, displayed
/// with `display`.
fn mean_delta_e(xyz: &[[f32; 3]], reference: &ProgressiveRender, display: &DisplaySettings) -> f64 {
    let film = reference.film();
    let transform = DisplayTransform::of(display);
    let (mut sum, mut count) = (0.0, 0usize);
    for y in (0..HEIGHT).step_by(STRIDE as usize) {
        for x in (0..WIDTH).step_by(STRIDE as usize) {
            let v = xyz[(y * WIDTH + x) as usize];
            let lab = transform.lab_of_xyz(coatlab_core::colour::Xyz::new(
                f64::from(v[0]),
                f64::from(v[1]),
                f64::from(v[2]),
            ));
            sum += ciede2000(lab, transform.lab_of_xyz(film.mean_xyz(x, y)));
            count += 1;
        }
    }
    sum / count as f64
}

fn film_xyz(render: &ProgressiveRender) -> Vec<[f32; 3]> {
    let film = render.film();
    let mut out = Vec::with_capacity((WIDTH * HEIGHT) as usize);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let m = film.mean_xyz(x, y);
            out.push([m.x as f32, m.y as f32, m.z as f32]);
        }
    }
    out
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// CPU time of every thread of this process so far, ms (from
/// `/proc/self/task/*/schedstat`): unlike wall time, it does not grow with the
/// other engineers' load; on two idle cores a well-parallel step takes about half
/// of it in wall time.
fn cpu_ms() -> f64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return f64::NAN;
    };
    let mut ns = 0u64;
    for task in tasks.flatten() {
        if let Ok(text) = std::fs::read_to_string(task.path().join("schedstat"))
            && let Some(first) = text.split_whitespace().next()
        {
            ns += first.parse::<u64>().unwrap_or(0);
        }
    }
    ns as f64 / 1e6
}

fn main() {
    // `cargo bench` passes `--bench`; nothing else is taken.
    let base_spp = env_u32("COATLAB_EDIT_BASE_SPP", 16);
    let reference_spp = env_u32("COATLAB_EDIT_REFERENCE_SPP", 64);
    let follow_s = f64::from(env_u32("COATLAB_EDIT_SECONDS", 3));
    let error_edits = env_u32("COATLAB_EDIT_ERROR_EDITS", 4);
    let mut followed = 0;
    let grid = WavelengthGrid::visible(32).expect("grid");
    let design = presets::all().into_iter().next().expect("preset").design;
    let scene = generate(&CarParameters::default());
    let setup = Setup {
        grid,
        render_scene: Arc::new(RenderScene::new(scene.clone()).expect("scene")),
        scene,
        environment: Arc::new(Environment::studio(&grid)),
    };
    println!(
        "edit bench: {WIDTH}x{HEIGHT}, 32 wavelengths, {}, base {base_spp} spp, references {reference_spp} spp; load {}",
        design.name,
        load()
    );
    let mut render = setup.render(&design, 1);
    render.set_path_cache_samples(4);
    let t = Instant::now();
    for _ in 0..base_spp {
        render.render_pass(1);
    }
    println!(
        "base: {base_spp} spp in {:.1} s; path cache {:.1} MB ({} paths, {} compact)",
        t.elapsed().as_secs_f64(),
        render.path_cache_memory_bytes() as f64 / 1e6,
        render.path_cache().path_count(),
        render.path_cache().compact_path_count()
    );
    // The preview's automatic exposure with the mapping the committed edit
    // figures were measured with.
    let display = DisplaySettings {
        exposure_stops: render.film().auto_exposure(),
        ..DisplaySettings::MEASURED
    };

    let scaled = |spectrum: &TabulatedSpectrum, f: &dyn Fn(f64) -> f64| {
        TabulatedSpectrum::new(
            spectrum.wavelengths_nm().to_vec(),
            spectrum.values().iter().map(|&v| f(v)).collect(),
        )
        .expect("spectrum")
    };
    let mut edits: Vec<(&str, PaintDesign)> = Vec::new();
    let mut d = design.clone();
    d.albedo = scaled(&d.albedo, &|v| (v * 0.8).min(1.0));
    edits.push(("rho x0.8", d));
    let mut d = design.clone();
    d.absorption_per_um = match &d.absorption_per_um {
        coatlab_core::design::Absorption::Constant(k) => {
            coatlab_core::design::Absorption::Constant(k + 0.01)
        }
        coatlab_core::design::Absorption::Table(t) => {
            coatlab_core::design::Absorption::Table(scaled(t, &|v| v + 0.01))
        }
    };
    edits.push(("k +0.01/um", d));
    let mut d = design.clone();
    d.thickness_um += 10.0;
    edits.push(("h +10 um", d));
    let mut d = design.clone();
    d.refractive_index = match &d.refractive_index {
        RefractiveIndex::Cauchy { a, b_um2 } => RefractiveIndex::Cauchy {
            a: a + 0.05,
            b_um2: *b_um2,
        },
        RefractiveIndex::Table(t) => RefractiveIndex::Table(scaled(t, &|v| v + 0.05)),
    };
    edits.push(("n +0.05", d));

    // The parts, once, on the base (its cache is complete here).
    {
        let t = Instant::now();
        let c = cpu_ms();
        let base_image = BaseImage::of(render.film());
        println!(
            "parts: prepare the base image {:.1} ms wall, {:.1} ms CPU (once per editing session)",
            ms(t),
            cpu_ms() - c
        );
        let reshade = |shading: &Shading, samples: u32| {
            reshade_prepared(
                &base_image,
                render.film(),
                render.path_cache(),
                &setup.environment,
                shading,
                true,
                samples,
            )
            .expect("reshade")
        };
        let shading = setup.shading(&edits[0].1);
        for _ in 0..3 {
            let t = Instant::now();
            let c = cpu_ms();
            let image = reshade(&shading, render.path_cache().samples_per_pixel());
            std::hint::black_box(image);
            println!(
                "parts: re-shade alone (rho edit) {:.1} ms wall, {:.1} ms CPU",
                ms(t),
                cpu_ms() - c
            );
        }
        // A first image from only the first m of the K = 4 recorded samples per
        // pixel, against all of them, interleaved in one run so that the load
        // varies alike for both: re-shade, the copy `edit_estimate` makes, the
        // conversion to display pixels.
        let shadings: Vec<_> = edits.iter().map(|(_, d)| setup.shading(d)).collect();
        let mut totals = [[0.0f64; 2]; 3];
        let rounds = 3;
        for round in 0..rounds {
            for (name, shading) in edits.iter().map(|(n, _)| n).zip(&shadings) {
                for (slot, m) in [1u32, 2, 4].into_iter().enumerate() {
                    let t = Instant::now();
                    let c = cpu_ms();
                    let image = reshade(shading, m);
                    let reshade_cpu = cpu_ms() - c;
                    let shown = image.xyz.clone();
                    let pixels = display_xyz(&shown, &display);
                    std::hint::black_box((image, pixels));
                    let (wall, cpu) = (ms(t), cpu_ms() - c);
                    totals[slot][0] += wall;
                    totals[slot][1] += cpu;
                    if round == 0 {
                        println!(
                            "parts: {name}: first image from {m} of 4 recorded samples {wall:.1} ms wall, {cpu:.1} ms CPU (re-shade {reshade_cpu:.1} ms CPU); load {}",
                            load()
                        );
                    }
                }
            }
        }
        let runs = (rounds * edits.len()) as f64;
        for (slot, m) in [1u32, 2, 4].into_iter().enumerate() {
            println!(
                "parts: first image from {m} of 4 samples, mean of {runs} (rho, k, h, n x {rounds}): {:.1} ms wall, {:.1} ms CPU, CPU ratio to all 4: {:.2}",
                totals[slot][0] / runs,
                totals[slot][1] / runs,
                totals[slot][1] / totals[2][1]
            );
        }
        println!("parts: load {}", load());
        let mut film = render.film().clone();
        let t = Instant::now();
        let c = cpu_ms();
        film.clear();
        println!(
            "parts: clear a 960x540 film {:.1} ms wall, {:.1} ms CPU",
            ms(t),
            cpu_ms() - c
        );
    }
    for (name, edited) in &edits {
        let shading = setup.shading(edited);
        let c = cpu_ms();
        let t = Instant::now();
        let outcome = render.edit_shading(shading).expect("edit");
        let reshade_ms = ms(t);
        assert_eq!(outcome, EditOutcome::Reshaded, "{name}");
        let t_blend = Instant::now();
        let (image, _): (Reshaded, f64) = render.edit_estimate().expect("re-shaded");
        let blend_ms = ms(t_blend);
        let t_display = Instant::now();
        let pixels = display_xyz(&image.xyz, &display);
        let display_ms = ms(t_display);
        std::hint::black_box(pixels);
        let first_ms = ms(t);
        let first_cpu = cpu_ms() - c;
        println!(
            "{name}: first full-resolution image {first_ms:.1} ms wall, {first_cpu:.1} ms CPU (edit_shading incl. re-shade {reshade_ms:.1}, blend {blend_ms:.1}, display {display_ms:.1}); load {}",
            load()
        );
        if reference_spp == 0 || followed >= error_edits {
            // Timings only.
            continue;
        }
        // The error against the edited design's reference while refining.
        followed += 1;
        let mut reference = setup.render(edited, 1000);
        for _ in 0..reference_spp {
            reference.render_pass(1);
        }
        let floor = reference
            .noise_estimate(&display)
            .map(|n| n.mean_delta_e)
            .unwrap_or(f64::NAN);
        let mut points = vec![(
            first_ms / 1e3,
            mean_delta_e(&image.xyz, &reference, &display),
        )];
        // Re-edit to start the clock again (the reference took a while).
        render
            .edit_shading(setup.shading(edited))
            .expect("edit again");
        let t = Instant::now();
        while t.elapsed().as_secs_f64() < follow_s {
            // As the preview does: the full re-shade first, then fresh passes.
            if !render.refine_edit() {
                render.render_pass(1);
            }
            let xyz = match render.edit_estimate() {
                Some((image, _)) => image.xyz,
                None => film_xyz(&render),
            };
            let at = t.elapsed().as_secs_f64();
            points.push((at, mean_delta_e(&xyz, &reference, &display)));
        }
        let curve: Vec<String> = points
            .iter()
            .map(|(t, e)| format!("{t:.2} s: {e:.2}"))
            .collect();
        println!(
            "{name}: mean ΔE00 vs reference ({reference_spp} spp, its own noise ΔE00 {floor:.2}) — {}",
            curve.join(", ")
        );
        // Back to editing from the base.
        render.edit_shading(setup.shading(&design)).expect("back");
    }
    println!(
        "path caches held now: {:.1} MB (base {} spp)",
        render.path_cache_memory_bytes() as f64 / 1e6,
        render.edit_base_samples_per_pixel()
    );

    // A gloss edit: traced fresh, the coarse pass first, as the app does.
    let mut gloss = design.clone();
    gloss.gloss.gu *= 0.9;
    let mut coarse_camera = render.camera().clone();
    coarse_camera.set_resolution(WIDTH / COARSE_FACTOR, HEIGHT / COARSE_FACTOR);
    let shading = setup.shading(&gloss);
    let t = Instant::now();
    let c = cpu_ms();
    render.set_shading(shading).expect("gloss");
    render.set_camera(coarse_camera.clone()).expect("camera");
    render.render_pass(1);
    let pixels = render.film().to_display(&display);
    std::hint::black_box(pixels);
    println!(
        "gloss x0.9: first image (coarse {}x{}) {:.1} ms wall, {:.1} ms CPU; load {}",
        WIDTH / COARSE_FACTOR,
        HEIGHT / COARSE_FACTOR,
        ms(t),
        cpu_ms() - c,
        load()
    );
    // A camera change (orbit by 5°).
    coarse_camera.orbit(5.0, 0.0);
    let t = Instant::now();
    let c = cpu_ms();
    render.set_camera(coarse_camera).expect("camera");
    render.render_pass(1);
    let pixels = render.film().to_display(&display);
    std::hint::black_box(pixels);
    println!(
        "camera orbit 5°: first image (coarse) {:.1} ms wall, {:.1} ms CPU; load {}",
        ms(t),
        cpu_ms() - c,
        load()
    );
}
