//! Whether an untouched comparison converges: the live engine (as the preview
//! drives it, no window) runs a comparison for a number of seconds; then each
//! pane is compared with its own model's converged reference, and the ΔE00 map
//! with the map between the references.
//!
//! Printed: each pane's mean ΔE00 to its reference (as shown: the engine's
//! display, PBR Neutral with the first view's automatic exposure), the
//! references' own noise (half the ΔE00 between their two halves), and, over
//! the pixels where the references differ by more than ΔE00 1 (the signal), the
//! map's noise (|map − reference map|) against that signal: its mean, and the
//! share of those pixels where the noise is below the signal.
//!
//! `cargo run -p coatlab-core --example compare_convergence -- [models|designs]
//! [SECONDS] [WIDTHxHEIGHT] [REFERENCE_SPP]` (defaults: models, 30, 316x400 —
//! one pane of the preview's side-by-side layout at its largest — and 256).

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use coatlab_core::colour::{Lab, Xyz, ciede2000};
use coatlab_core::design::presets;
use coatlab_core::engine::{
    Command, CpuBackend, LiveEngine, Output, QualityKnobs, SecondImage, Views,
};
use coatlab_core::paint::phong::PhongVariant;
use coatlab_core::render::film::{DisplaySettings, Film, display_lab_of_xyz};
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::{ProgressiveRender, RenderSettings};

type Image = Vec<[f32; 3]>;

fn film_xyz(film: &Film) -> Image {
    (0..film.height())
        .flat_map(|y| (0..film.width()).map(move |x| (x, y)))
        .map(|(x, y)| {
            let m = film.mean_xyz(x, y);
            [m.x as f32, m.y as f32, m.z as f32]
        })
        .collect()
}

fn labs(image: &Image, display: &DisplaySettings) -> Vec<Lab> {
    image
        .iter()
        .map(|v| {
            let [x, y, z] = v.map(f64::from);
            display_lab_of_xyz(Xyz::new(x, y, z), display)
        })
        .collect()
}

fn delta_e(a: &[Lab], b: &[Lab]) -> Vec<f64> {
    a.iter().zip(b).map(|(&a, &b)| ciede2000(a, b)).collect()
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mode = args.first().map_or("models", String::as_str);
    let seconds: f64 = args.get(1).map_or(Ok(30.0), |s| s.parse())?;
    let (width, height) = match args.get(2) {
        Some(size) => {
            let (w, h) = size.split_once('x').ok_or("size as WIDTHxHEIGHT")?;
            (w.parse()?, h.parse()?)
        }
        None => (316u32, 400u32),
    };
    let reference_spp: u32 = args.get(3).map_or(Ok(256), |s| s.parse())?;

    let all = presets::all();
    let design = all.first().ok_or("no preset designs")?.design.clone();
    let views = match mode {
        "models" => Views::models(PhongVariant::BestFit),
        "designs" => {
            let second = &all.get(1).ok_or("a second preset")?.design;
            Views::designs(ShadingModel::Paint, Some(second))
        }
        other => return Err(format!("unknown mode {other}: models or designs").into()),
    };
    let mut engine = LiveEngine::new(CpuBackend::default(), design.clone(), Arc::new(|| {}))?;
    let mut ignore = |_: Output| {};
    engine.apply(Command::Size(width, height), &mut ignore);
    engine.apply(Command::Views(views.clone()), &mut ignore);
    engine.apply(Command::Quality(QualityKnobs::default()), &mut ignore);
    let never = AtomicBool::new(false);
    let start = Instant::now();
    while start.elapsed().as_secs_f64() < seconds {
        engine.step(&never, &mut ignore);
    }
    let elapsed = start.elapsed().as_secs_f64();
    let display = engine.display();
    let first = engine.first_image()?;
    let second = match engine.second_image() {
        SecondImage::Film(film) => film_xyz(film),
        SecondImage::Reshaded(Ok(image)) => image.xyz,
        SecondImage::Reshaded(Err(e)) => return Err(e.into()),
        SecondImage::None => return Err("no second view".into()),
    };
    println!(
        "{mode}, {width}x{height}, {elapsed:.1} s: first view {} spp, pairing {:?}, display {:?}",
        engine.samples_per_pixel(),
        engine.state().pairing,
        display
    );

    // The references: each view's model (and design) on its own, same camera and
    // grid, in two halves of other seeds.
    let camera = engine.first().camera().clone();
    let scene = engine.first().scene().clone();
    let environment = engine.first().environment().clone();
    let grid = engine.grid();
    let second_view = views.second.as_ref().ok_or("a second view")?;
    let second_design = second_view.design.as_deref().unwrap_or(&design);
    let paint_materials = scene.paint_materials().to_vec();
    let shadings = [
        (design.model(grid)?, views.first),
        (second_design.model(grid)?, second_view.model),
    ]
    .map(|(model, which)| {
        Arc::new(Shading::new(
            &model,
            which,
            scene.materials(),
            &paint_materials,
        ))
    });
    let reference = |shading: &Arc<Shading>| -> Result<(Image, f64), Box<dyn std::error::Error>> {
        let mut halves = Vec::new();
        for seed in [0x5eed_0101u64, 0x5eed_0202] {
            let mut render = ProgressiveRender::new(
                scene.clone(),
                environment.clone(),
                shading.clone(),
                camera.clone(),
                RenderSettings::seeded(seed),
            )?;
            render.render_to(reference_spp / 2, 4);
            halves.push(film_xyz(render.film()));
        }
        let noise = mean(&delta_e(
            &labs(&halves[0], &display),
            &labs(&halves[1], &display),
        )) / 2.0;
        let average = halves[0]
            .iter()
            .zip(&halves[1])
            .map(|(a, b)| std::array::from_fn(|c| 0.5 * (a[c] + b[c])))
            .collect();
        Ok((average, noise))
    };
    let reference_start = Instant::now();
    let (ref_a, noise_a) = reference(&shadings[0])?;
    let (ref_b, noise_b) = reference(&shadings[1])?;
    println!(
        "references: {reference_spp} spp each in {:.0} s; their noise ΔE00 {noise_a:.3} and {noise_b:.3}",
        reference_start.elapsed().as_secs_f64()
    );
    let (la, lb, lra, lrb) = (
        labs(&first, &display),
        labs(&second, &display),
        labs(&ref_a, &display),
        labs(&ref_b, &display),
    );
    println!(
        "pane to its own reference, mean ΔE00: first {:.3}, second {:.3} (goal ≤ 0.5)",
        mean(&delta_e(&la, &lra)),
        mean(&delta_e(&lb, &lrb))
    );
    let map = delta_e(&la, &lb);
    let signal = delta_e(&lra, &lrb);
    let (mut noise_sum, mut signal_sum, mut below, mut count) = (0.0, 0.0, 0usize, 0usize);
    for (m, s) in map.iter().zip(&signal) {
        if *s > 1.0 {
            let noise = (m - s).abs();
            noise_sum += noise;
            signal_sum += s;
            below += usize::from(noise < *s);
            count += 1;
        }
    }
    println!(
        "map where the models differ by > 1 ({count} of {} pixels): mean signal {:.2}, mean noise \
         {:.3}, noise below signal on {:.1} % of them; map mean {:.2}, reference map mean {:.2}",
        signal.len(),
        signal_sum / count.max(1) as f64,
        noise_sum / count.max(1) as f64,
        100.0 * below as f64 / count.max(1) as f64,
        mean(&map),
        mean(&signal)
    );
    Ok(())
}
