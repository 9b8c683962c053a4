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
//! With RUNS > 1 the comparison is run that many times from other seeds, and the
//! map's noise at a pixel is also taken as the root mean square of its error over
//! the runs: one run's |map − reference map| is a single draw of that noise, and
//! the RMS tells a pixel whose map is noisy from one that drew a value far in the
//! tail (with 16 runs, a pixel whose noise is 0.7 of its signal has its RMS reach
//! the signal about once in a hundred); counted, like one run's noise, also where
//! the reference map is decided, with what those pixels show, and each of those
//! listed with the runs' mean offset from the reference map and their spread,
//! the reference map's own noise, and each run's map and panes' CIELAB (noise
//! the guidance has missed shows as spread; a bias of the map, or the
//! reference's own error, as an offset every run shares). The pixels
//! where a single run's noise is not below the signal are listed by what they
//! show, and one by one with the map, the signal, the first view's samples there,
//! and each pane's CIELAB beside its reference's (whether the error is one of
//! lightness or of hue).
//! In `designs` mode the second design is the second preset, or with
//! `COMPARE_SECOND_GU=GU` the first preset at another gloss reading (the same
//! geometry): a variant a designer compares with the original.
//! `COMPARE_FIRST_GU=GU` sets the first design's reading the same way.
//! `COMPARE_GUIDANCE=off` renders both views with even passes (the engine's
//! map guidance off, shared or apart), `alternate` every other run so (the first off), to measure
//! what the guidance buys in one invocation (the RMS over runs is then given for
//! each half); `on`, the default, is the engine as the app runs it.
//! `COMPARE_SHARE_LOBES=alternate` shares the views of every other run (the
//! first) whatever their lobes, where the re-shade allows it (a second lobe
//! no wider than the first), and renders those of the others apart wherever
//! the lobes differ by more than 1 %, to measure where the engine's limit on a
//! sharper second lobe belongs.
//! `COMPARE_ADAPTIVE=1` turns on adaptive sampling (its defaults) in every view;
//! `COMPARE_WATCH=X,Y` lists pixel (X, Y) with those whose RMS reaches the
//! signal, whether it does or not (to see one pixel under two builds or settings).
//! `COMPARE_MISSES=FILE.png` draws the signal in grey and those pixels in red.
//! `COMPARE_PANES=PREFIX` writes the first run's panes as shown (its display
//! settings) to PREFIX-first.png and PREFIX-second.png, to look at;
//! `COMPARE_ERRORS=PREFIX` their ΔE00 to their references (0 black, 2 white) to
//! PREFIX-0.png and PREFIX-1.png. The first run's pane errors are also split by
//! what the pixels show.
//! `COMPARE_EXPLAIN=X,Y` compares nothing: it traces 65 536 samples of pixel
//! (X, Y) in each view's model and prints how that pixel's estimate is made up —
//! the mean, quantiles of the samples and the brightest samples' paths (what each
//! vertex was, its light sample's and continuation's densities, how the path
//! ended) — to tell a firefly from a highlight that few samples reach —, the
//! share of the mean and of the samples' variance from paths that met a lamp
//! or took a glossy bounce after a rough one (a caustic), and the
//! standard deviation of a 64-sample mean over 256 seeds, the error a sampling
//! change is judged by (a second is SECONDS enough: the runs only set up the
//! scene).
//! `COMPARE_REFERENCES=DIR` keeps the references there and reads them back in a
//! later run of exactly the same designs, models, size, samples, scene and camera
//! (a 4 096-spp pair takes a quarter of an hour here); the renderer's code is not
//! part of that match, so empty the folder when it changes.
//!
//! `cargo run -p coatlab-core --example compare_convergence -- [models|designs]
//! [SECONDS] [WIDTHxHEIGHT] [REFERENCE_SPP] [RUNS]` (defaults: models, 30,
//! 316x400 — one pane of the preview's side-by-side layout at its largest — 256
//! and 1).

use std::sync::Arc;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use palette::Srgb;

use coatlab_core::colour::{Lab, Xyz, ciede2000};
use coatlab_core::design::{PaintDesign, presets};
use coatlab_core::engine::{
    Command, CpuBackend, LiveEngine, Output, QualityKnobs, SecondImage, SecondUpdate, Views,
    ViewsUpdate,
};
use coatlab_core::io::atomic::write_bytes_atomically;
use coatlab_core::io::png_write::write_srgb8_png;
use coatlab_core::paint::phong::PhongVariant;
use coatlab_core::render::camera::Camera;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::{DisplaySettings, DisplayTransform, Film, display_xyz_srgba};
use coatlab_core::render::geometry::Surface;
use coatlab_core::render::integrator::{
    IntegratorSettings, NoRecord, PathBuffers, PathRecorder, PathTracer, VertexRecord,
};
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::pick::pick;
use coatlab_core::render::progressive::{ProgressiveRender, RenderScene, RenderSettings};
use coatlab_core::render::sampler::PixelSampler;
use coatlab_core::scene::SceneMaterial;

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
    let transform = DisplayTransform::of(display);
    image
        .iter()
        .map(|v| {
            let [x, y, z] = v.map(f64::from);
            transform.lab_of_xyz(Xyz::new(x, y, z))
        })
        .collect()
}

fn delta_e(a: &[Lab], b: &[Lab]) -> Vec<f64> {
    a.iter().zip(b).map(|(&a, &b)| ciede2000(a, b)).collect()
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// The gloss reading in the environment variable `name`, if it is set.
fn gloss_reading(name: &str) -> Result<Option<f64>, String> {
    std::env::var(name)
        .ok()
        .map(|gu| gu.parse().map_err(|e| format!("{name} {gu:?}: {e}")))
        .transpose()
}

/// `design` read at `gu` gloss units (the same geometry), named so.
fn at_gloss(design: &PaintDesign, gu: f64) -> PaintDesign {
    let mut variant = design.clone();
    variant.name = format!("{} at {gu} GU", design.name);
    variant.gloss.gu = gu;
    variant
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

    let pixel_of = |variable: &str| -> Result<Option<(u32, u32)>, String> {
        match std::env::var(variable) {
            Ok(xy) => {
                let pixel = xy
                    .split_once(',')
                    .and_then(|(x, y)| Some((x.trim().parse().ok()?, y.trim().parse().ok()?)))
                    .filter(|&(x, y): &(u32, u32)| x < width && y < height);
                Ok(Some(pixel.ok_or(format!(
                    "{variable} {xy:?}: a pixel X,Y inside {width}x{height}"
                ))?))
            }
            Err(_) => Ok(None),
        }
    };
    let explain = pixel_of("COMPARE_EXPLAIN")?;
    let watched = pixel_of("COMPARE_WATCH")?.map(|(x, y)| (y * width + x) as usize);
    let all = presets::all();
    let original = &all.first().ok_or("no preset designs")?.design;
    let design = match gloss_reading("COMPARE_FIRST_GU")? {
        Some(gu) => at_gloss(original, gu),
        None => original.clone(),
    };
    let views = match mode {
        "models" => Views::models(PhongVariant::BestFit),
        "designs" => {
            let second = match gloss_reading("COMPARE_SECOND_GU")? {
                Some(gu) => at_gloss(original, gu),
                None => all.get(1).ok_or("a second preset")?.design.clone(),
            };
            Views::designs(ShadingModel::Paint, Some(&second))
        }
        other => return Err(format!("unknown mode {other}: models or designs").into()),
    };
    let runs: usize = args.get(4).map_or(Ok(1), |s| s.parse())?;
    if runs == 0 {
        return Err("RUNS must be at least 1".into());
    }
    let guidance = std::env::var("COMPARE_GUIDANCE").unwrap_or_else(|_| "on".to_string());
    let guided = |run: usize| -> Result<bool, String> {
        match guidance.as_str() {
            "on" => Ok(true),
            "off" => Ok(false),
            "alternate" => Ok(run % 2 == 1),
            other => Err(format!("COMPARE_GUIDANCE {other:?}: on, off or alternate")),
        }
    };
    guided(0)?;
    let sharing = std::env::var("COMPARE_SHARE_LOBES").ok();
    // How much sharper the second lobe may be and be shared, for a run: the
    // engine's own limit, or with COMPARE_SHARE_LOBES=alternate any in the even
    // runs and 1 % in the odd ones.
    let lobe_narrowing = |run: usize| -> Result<Option<f32>, String> {
        match sharing.as_deref() {
            None => Ok(None),
            Some("alternate") => Ok(Some(if run.is_multiple_of(2) {
                f32::INFINITY
            } else {
                0.01
            })),
            Some(other) => Err(format!("COMPARE_SHARE_LOBES {other:?}: alternate")),
        }
    };
    lobe_narrowing(0)?;

    // Each run: a fresh engine of its own seed left alone for `seconds`; the
    // first run's engine gives the camera, scene and display for the rest.
    let mut engine = None;
    let mut panes: Vec<(Image, Image)> = Vec::new();
    // The first run's samples in each pixel of its first view.
    let mut first_counts: Vec<u64> = Vec::new();
    for run in 0..runs {
        let backend = CpuBackend {
            settings: RenderSettings {
                seed: CpuBackend::default()
                    .settings
                    .seed
                    .wrapping_add(run as u64 * 0x9e37_79b9),
                adaptive: std::env::var_os("COMPARE_ADAPTIVE").map(|_| Default::default()),
                ..CpuBackend::default().settings
            },
        };
        let mut live = LiveEngine::new(backend, design.clone(), Arc::new(|| {}))?;
        live.set_map_guidance(guided(run)?);
        if let Some(narrowing) = lobe_narrowing(run)? {
            live.set_shared_lobe_narrowing(narrowing);
        }
        // How the second pane was last made, as the engine publishes it.
        let mut source = None;
        let mut keep = |output: Output| {
            if let Output::Views(ViewsUpdate {
                second: SecondUpdate::Set(frame),
                ..
            }) = output
            {
                source = frame.source;
            }
        };
        live.apply(Command::Size(width, height), &mut keep);
        live.apply(Command::Views(views.clone()), &mut keep);
        live.apply(Command::Quality(QualityKnobs::default()), &mut keep);
        let never = AtomicBool::new(false);
        let start = Instant::now();
        while start.elapsed().as_secs_f64() < seconds {
            live.step(&never, &mut keep);
        }
        let elapsed = start.elapsed().as_secs_f64();
        let totals = live.first().totals();
        let first = live.first_image()?;
        let second = match live.second_image() {
            SecondImage::Film(film) => film_xyz(film),
            SecondImage::Reshaded(Ok(image)) => image.xyz,
            SecondImage::Reshaded(Err(e)) => return Err(e.into()),
            SecondImage::None => return Err("no second view".into()),
        };
        println!(
            "{mode}, {width}x{height}, run {run}, {elapsed:.1} s: first view {} spp ({:.2} rays a \
             sample, {:.2} M rays/s in its passes), pairing {:?}, map guidance {}, second pane \
             {source:?}, display {:?}",
            live.samples_per_pixel(),
            totals.rays as f64 / totals.samples.max(1) as f64,
            totals.rays as f64 / totals.seconds.max(1e-9) / 1e6,
            live.state().pairing,
            if guided(run)? { "on" } else { "off" },
            live.display()
        );
        if run == 0
            && let Some(prefix) = std::env::var_os("COMPARE_PANES")
        {
            for (which, pane) in [("first", &first), ("second", &second)] {
                let path = format!("{}-{which}.png", prefix.to_string_lossy());
                let pixels: Vec<Srgb<u8>> = display_xyz_srgba(pane, &live.display())
                    .into_iter()
                    .map(|p| p.color)
                    .collect();
                write_srgb8_png(std::path::Path::new(&path), width, height, &pixels)?;
                println!("{which} pane written to {path}");
            }
        }
        panes.push((first, second));
        if run == 0 {
            let film = live.first().film();
            first_counts = (0..film.height())
                .flat_map(|y| (0..film.width()).map(move |x| (x, y)))
                .map(|(x, y)| film.sample_count(x, y))
                .collect();
        }
        engine.get_or_insert(live);
    }
    let engine = engine.ok_or("no run")?;
    let display = engine.display();

    // The references: each view's model (and design) on its own, same camera and
    // grid, in two halves of other seeds.
    let camera = engine.first().camera().clone();
    if (camera.width(), camera.height()) != (width, height) {
        return Err(format!(
            "after {seconds} s the engine still shows its coarse start ({}x{}): give it longer",
            camera.width(),
            camera.height()
        )
        .into());
    }
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
    // What a reference is of, in words: a stored one is used only where this
    // matches it exactly.
    let describe = |design: &PaintDesign, which: ShadingModel| {
        // The name is not rendered: a preset and its variant at the preset's own
        // reading are one reference.
        let design = PaintDesign {
            name: String::new(),
            ..design.clone()
        };
        format!(
            "{design:?} | {which:?} | {width}x{height} | {reference_spp} spp | scene bounds \
             {:?}, {} materials | {camera:?}",
            scene.bounds(),
            scene.materials().len()
        )
    };
    let descriptions = [
        describe(&design, views.first),
        describe(second_design, second_view.model),
    ];
    let store = std::env::var_os("COMPARE_REFERENCES").map(std::path::PathBuf::from);
    type Reference = (Image, f64, [Image; 2]);
    let reference = |shading: &Arc<Shading>,
                     description: &str|
     -> Result<Reference, Box<dyn std::error::Error>> {
        let stored = match &store {
            Some(dir) => stored_halves(dir, description, (width * height) as usize)?,
            None => None,
        };
        let halves = match stored {
            Some(halves) => halves,
            None => {
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
                if let Some(dir) = &store {
                    store_halves(dir, description, &halves)?;
                }
                halves
            }
        };
        let noise = mean(&delta_e(
            &labs(&halves[0], &display),
            &labs(&halves[1], &display),
        )) / 2.0;
        let average = halves[0]
            .iter()
            .zip(&halves[1])
            .map(|(a, b)| std::array::from_fn(|c| 0.5 * (a[c] + b[c])))
            .collect();
        let [first_half, second_half]: [Image; 2] = halves.try_into().map_err(|_| "two halves")?;
        Ok((average, noise, [first_half, second_half]))
    };
    if let Some((x, y)) = explain {
        for (view, shading) in shadings.iter().enumerate() {
            explain_pixel(&scene, &environment, shading, &camera, [x, y, width], view);
        }
        return Ok(());
    }
    let reference_start = Instant::now();
    let (ref_a, noise_a, halves_a) = reference(&shadings[0], &descriptions[0])?;
    let (ref_b, noise_b, halves_b) = reference(&shadings[1], &descriptions[1])?;
    println!(
        "references: {reference_spp} spp each in {:.0} s; their noise ΔE00 {noise_a:.3} and {noise_b:.3}",
        reference_start.elapsed().as_secs_f64()
    );
    let (lra, lrb) = (labs(&ref_a, &display), labs(&ref_b, &display));
    let signal = delta_e(&lra, &lrb);
    // The reference map's own noise per pixel: half the difference between the
    // maps of the references' two halves (one draw of the noise of their mean).
    let half_maps =
        [0, 1].map(|h| delta_e(&labs(&halves_a[h], &display), &labs(&halves_b[h], &display)));
    let reference_noise: Vec<f64> = half_maps[0]
        .iter()
        .zip(&half_maps[1])
        .map(|(m1, m2)| 0.5 * (m1 - m2).abs())
        .collect();
    let known = NoiseTally::of(&reference_noise, &signal);
    println!(
        "the reference map's own noise where the models differ by > 1: mean {:.3}, below the \
         signal on {:.1} % of those pixels",
        known.noise_mean,
        known.percent_below()
    );
    // Per pixel, the sums over runs of the map's error and of its square, for each
    // way the runs were made (map guidance on or off, which lobes are shared), with
    // their count.
    let mut run_errors = std::collections::BTreeMap::<String, (Vec<f64>, Vec<f64>, usize)>::new();
    let mut run_panes: Vec<(Vec<f64>, Vec<Lab>, Vec<Lab>)> = Vec::new();
    for (run, (first, second)) in panes.iter().enumerate() {
        let way = format!(
            "map guidance {}, {}",
            if guided(run)? { "on" } else { "off" },
            match lobe_narrowing(run)? {
                None => "the engine's lobe rule",
                Some(n) if n.is_infinite() => "lobes shared where the re-shade allows",
                Some(_) => "lobes that differ by more than 1 % rendered apart",
            }
        );
        let (errors, squared_errors, runs) = run_errors
            .entry(way)
            .or_insert_with(|| (vec![0.0; signal.len()], vec![0.0; signal.len()], 0));
        *runs += 1;
        let (la, lb) = (labs(first, &display), labs(second, &display));
        println!(
            "run {run}: pane to its own reference, mean ΔE00: first {:.3}, second {:.3} (goal ≤ 0.5)",
            mean(&delta_e(&la, &lra)),
            mean(&delta_e(&lb, &lrb))
        );
        if run == 0 {
            for (pane, (lab, reference)) in [(&la, &lra), (&lb, &lrb)].into_iter().enumerate() {
                let error = delta_e(lab, reference);
                pane_error_by_what_it_shows(pane, &error, &scene, &camera, width);
                if let Some(prefix) = std::env::var_os("COMPARE_ERRORS") {
                    // ΔE00 0 black to 2 white, so a pane's noise can be seen where it lies.
                    let pixels: Vec<Srgb<u8>> = error
                        .iter()
                        .map(|e| {
                            let v = (e / 2.0 * 255.0).clamp(0.0, 255.0) as u8;
                            Srgb::new(v, v, v)
                        })
                        .collect();
                    let path = format!("{}-{pane}.png", prefix.to_string_lossy());
                    write_srgb8_png(std::path::Path::new(&path), width, height, &pixels)?;
                    println!("pane {pane}'s error (ΔE00 0 to 2, black to white) written to {path}");
                }
            }
        }
        let map = delta_e(&la, &lb);
        for ((e, e2), (m, s)) in errors
            .iter_mut()
            .zip(squared_errors.iter_mut())
            .zip(map.iter().zip(&signal))
        {
            *e += m - s;
            *e2 += (m - s) * (m - s);
        }
        let noise: Vec<f64> = map
            .iter()
            .zip(&signal)
            .map(|(m, s)| (m - s).abs())
            .collect();
        let tally = NoiseTally::of(&noise, &signal);
        println!(
            "run {run}: map where the models differ by > 1 ({} of {} pixels): mean signal \
             {:.2}, mean noise {:.3}, noise below signal on {:.1} % of them; map mean {:.2}, \
             reference map mean {:.2}",
            tally.count,
            signal.len(),
            tally.signal_mean,
            tally.noise_mean,
            tally.percent_below(),
            mean(&map),
            mean(&signal)
        );
        // The same where the reference map is itself decided, so that what is
        // counted is this run's noise.
        let on_decided = NoiseTally::where_reference_decided(&noise, &reference_noise, &signal);
        println!(
            "run {run}: of those, where the reference map is decided ({} pixels), noise below \
             signal on {:.1} % ({} not)",
            on_decided.count,
            on_decided.percent_below(),
            on_decided.misses.len()
        );
        run_panes.push((map.clone(), la.clone(), lb.clone()));
        if run == 0 {
            describe_misses(&tally.misses, &map, &signal, &scene, &camera, width);
            for &i in &tally.misses {
                let lab = |l: &Lab| format!("({:.1}, {:.1}, {:.1})", l.l, l.a, l.b);
                println!(
                    "  miss ({}, {}): map {:.2}, signal {:.2}, {} samples in the first view; \
                     L*a*b* first {} (reference {}), second {} (reference {})",
                    i % width as usize,
                    i / width as usize,
                    map[i],
                    signal[i],
                    first_counts.get(i).copied().unwrap_or(0),
                    lab(&la[i]),
                    lab(&lra[i]),
                    lab(&lb[i]),
                    lab(&lrb[i]),
                );
            }
        }
    }
    for (way, (errors, squared_errors, runs)) in run_errors {
        if runs < 2 {
            continue;
        }
        // The map's noise at a pixel as the root mean square of its error over the
        // independent runs (one run's |error| is a single draw of it).
        let rms: Vec<f64> = squared_errors
            .iter()
            .map(|e| (e / runs as f64).sqrt())
            .collect();
        let tally = NoiseTally::of(&rms, &signal);
        println!(
            "over {runs} runs, {way}: the map's RMS noise where the models differ by > 1: mean \
             {:.3}, below the signal on {:.2} % of those {} pixels ({} not)",
            tally.noise_mean,
            tally.percent_below(),
            tally.count,
            tally.misses.len()
        );
        // Where the reference map is decided, as for one run: the reference's own
        // noise is then not what makes a pixel's RMS reach its signal.
        let on_decided = NoiseTally::where_reference_decided(&rms, &reference_noise, &signal);
        let shown: Vec<String> =
            misses_by_what_they_show(&on_decided.misses, &scene, &camera, width)
                .into_iter()
                .map(|(name, (pixels, _))| format!("{name} {pixels}"))
                .collect();
        println!(
            "over {runs} runs, {way}: of those, where the reference map is decided ({} pixels), \
             RMS noise below the signal on {:.2} % ({} not: {})",
            on_decided.count,
            on_decided.percent_below(),
            on_decided.misses.len(),
            shown.join(", ")
        );
        // An RMS is the runs' spread about their mean and that mean's offset from
        // the reference map: an offset well beyond the spread over √runs is the
        // reference's own error, or a bias of the map.
        let listed = on_decided
            .misses
            .iter()
            .copied()
            .chain(watched.filter(|i| !on_decided.misses.contains(i)));
        for i in listed {
            let offset = errors[i] / runs as f64;
            let spread = (squared_errors[i] / runs as f64 - offset * offset)
                .max(0.0)
                .sqrt();
            println!(
                "  pixel ({}, {}): signal {:.2}, RMS {:.2}: runs' mean {:+.2} from the \
                 reference map, spread {:.2}; the reference map's own noise {:.2}",
                i % width as usize,
                i / width as usize,
                signal[i],
                rms[i],
                offset,
                spread,
                reference_noise[i]
            );
            for (map, la, lb) in &run_panes {
                println!(
                    "    map {:.2}: first ({:.1}, {:.1}, {:.1}) second ({:.1}, {:.1}, {:.1})",
                    map[i], la[i].l, la[i].a, la[i].b, lb[i].l, lb[i].a, lb[i].b
                );
            }
            println!(
                "    references: first ({:.1}, {:.1}, {:.1}) second ({:.1}, {:.1}, {:.1})",
                lra[i].l, lra[i].a, lra[i].b, lrb[i].l, lrb[i].a, lrb[i].b
            );
        }
    }
    Ok(())
}

/// A stored reference's file in `dir`: named by a hash of its description (the
/// file holds the description itself, which decides).
fn reference_path(dir: &std::path::Path, description: &str) -> std::path::PathBuf {
    use std::hash::{Hash, Hasher};
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    description.hash(&mut hasher);
    dir.join(format!("reference-{:016x}.bin", hasher.finish()))
}

/// The two halves of a reference stored by [`store_halves`] for exactly this
/// description; `None` where there is none.
fn stored_halves(
    dir: &std::path::Path,
    description: &str,
    pixels: usize,
) -> Result<Option<Vec<Image>>, Box<dyn std::error::Error>> {
    let path = reference_path(dir, description);
    let bytes = match std::fs::read(&path) {
        Ok(bytes) => bytes,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("{}: {e}", path.display()).into()),
    };
    let Some(newline) = bytes.iter().position(|&b| b == b'\n') else {
        return Err(format!("{}: no description line", path.display()).into());
    };
    if &bytes[..newline] != description.as_bytes() {
        return Ok(None);
    }
    let values = &bytes[newline + 1..];
    if values.len() != 2 * pixels * 12 {
        return Err(format!(
            "{}: {} bytes of values where two halves of {pixels} pixels take {}",
            path.display(),
            values.len(),
            2 * pixels * 12
        )
        .into());
    }
    let floats: Vec<f32> = values
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let halves = floats
        .chunks_exact(3 * pixels)
        .map(|half| half.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect())
        .collect();
    println!("reference read from {}", path.display());
    Ok(Some(halves))
}

/// Stores a reference's two halves under its description (atomically, so a run
/// stopped half way leaves no partial reference).
fn store_halves(
    dir: &std::path::Path,
    description: &str,
    halves: &[Image],
) -> Result<(), Box<dyn std::error::Error>> {
    std::fs::create_dir_all(dir)?;
    let mut bytes = description.as_bytes().to_vec();
    bytes.push(b'\n');
    for value in halves.iter().flatten().flatten() {
        bytes.extend_from_slice(&value.to_le_bytes());
    }
    let path = reference_path(dir, description);
    write_bytes_atomically(&path, &bytes)?;
    println!("reference stored in {}", path.display());
    Ok(())
}

/// The map's noise against its signal over the pixels where the models differ by
/// more than 1 ΔE00: how many, how many with the noise below the signal, the
/// means, and the pixels where it is not below.
struct NoiseTally {
    count: usize,
    below: usize,
    noise_mean: f64,
    signal_mean: f64,
    misses: Vec<usize>,
}

impl NoiseTally {
    fn of(noise: &[f64], signal: &[f64]) -> NoiseTally {
        let (mut noise_sum, mut signal_sum) = (0.0, 0.0);
        let (mut count, mut below, mut misses) = (0, 0, Vec::new());
        for (i, (&n, &s)) in noise.iter().zip(signal).enumerate() {
            // NaN noise: a pixel left out of the tally.
            if s > 1.0 && !n.is_nan() {
                noise_sum += n;
                signal_sum += s;
                count += 1;
                if n < s {
                    below += 1;
                } else {
                    misses.push(i);
                }
            }
        }
        let per = count.max(1) as f64;
        NoiseTally {
            count,
            below,
            noise_mean: noise_sum / per,
            signal_mean: signal_sum / per,
            misses,
        }
    }

    /// [`Self::of`] over the pixels where the reference map is itself decided:
    /// its own noise `reference_noise` below a quarter of the signal.
    fn where_reference_decided(
        noise: &[f64],
        reference_noise: &[f64],
        signal: &[f64],
    ) -> NoiseTally {
        let decided: Vec<f64> = noise
            .iter()
            .zip(reference_noise)
            .zip(signal)
            .map(|((&n, &r), &s)| if r < 0.25 * s { n } else { f64::NAN })
            .collect();
        NoiseTally::of(&decided, signal)
    }

    fn percent_below(&self) -> f64 {
        100.0 * self.below as f64 / self.count.max(1) as f64
    }
}

/// `misses` (pixel indices) by what each shows (the material under its centre, by
/// [`pick`], or the floor or background): per name, the pixels and those of them
/// on an outline (a neighbour shows something else).
fn misses_by_what_they_show(
    misses: &[usize],
    scene: &RenderScene,
    camera: &Camera,
    width: u32,
) -> std::collections::BTreeMap<String, (usize, usize)> {
    let shown =
        |x: i64, y: i64| pick(scene, camera, x as f32 + 0.5, y as f32 + 0.5).map(|p| p.material);
    let mut by_material = std::collections::BTreeMap::<String, (usize, usize)>::new();
    for &i in misses {
        let (x, y) = ((i % width as usize) as i64, (i / width as usize) as i64);
        let here = shown(x, y);
        let outline = [(-1, 0), (1, 0), (0, -1), (0, 1)]
            .iter()
            .any(|(dx, dy)| shown(x + dx, y + dy) != here);
        let name = here.map_or_else(
            || "floor or background".to_string(),
            |m| scene.materials()[m as usize].name.clone(),
        );
        let entry = by_material.entry(name).or_default();
        entry.0 += 1;
        entry.1 += usize::from(outline);
    }
    by_material
}

/// A pane's error split by what its pixels show (as [`misses_by_what_they_show`]):
/// each part's pixels, its mean ΔE00 and its share of the pane's summed error, the
/// largest first: where samples would lower the pane's mean most.
fn pane_error_by_what_it_shows(
    pane: usize,
    error: &[f64],
    scene: &RenderScene,
    camera: &Camera,
    width: u32,
) {
    let mut parts = std::collections::BTreeMap::<String, (usize, f64)>::new();
    for (i, e) in error.iter().enumerate() {
        let (x, y) = ((i % width as usize) as f32, (i / width as usize) as f32);
        let name = pick(scene, camera, x + 0.5, y + 0.5).map_or_else(
            || "floor or background".to_string(),
            |p| scene.materials()[p.material as usize].name.clone(),
        );
        let part = parts.entry(name).or_default();
        part.0 += 1;
        part.1 += e;
    }
    let total: f64 = error.iter().sum();
    let mut parts: Vec<_> = parts.into_iter().collect();
    parts.sort_by(|a, b| b.1.1.total_cmp(&a.1.1));
    let listed: Vec<String> = parts
        .iter()
        .map(|(name, (pixels, sum))| {
            format!(
                "{name} {pixels} px mean {:.2} ({:.0} %)",
                sum / *pixels as f64,
                100.0 * sum / total
            )
        })
        .collect();
    println!(
        "run 0, pane {pane}'s error by what it shows: {}",
        listed.join("; ")
    );
}

/// Where the map's noise is not below its signal: what each such pixel shows
/// (the material under its centre, by [`pick`]), whether it lies on an outline
/// (a neighbour shows something else), and the map against the signal there.
fn describe_misses(
    misses: &[usize],
    map: &[f64],
    signal: &[f64],
    scene: &RenderScene,
    camera: &Camera,
    width: u32,
) {
    if misses.is_empty() {
        return;
    }
    let by_material = misses_by_what_they_show(misses, scene, camera, width);
    let sorted = |mut values: Vec<f64>| {
        values.sort_by(f64::total_cmp);
        values
    };
    let ratios = sorted(misses.iter().map(|&i| map[i] / signal[i]).collect());
    let signals = sorted(misses.iter().map(|&i| signal[i]).collect());
    let quartiles = |v: &[f64]| [v[v.len() / 4], v[v.len() / 2], v[3 * v.len() / 4]];
    println!(
        "the {} pixels where it is not: signal quartiles {:.2?}, map ÷ signal median {:.2}, max \
         {:.1}; by what they show (pixels, of them on an outline):",
        misses.len(),
        quartiles(&signals),
        ratios[ratios.len() / 2],
        ratios[ratios.len() - 1]
    );
    for (name, (pixels, outline)) in by_material {
        println!("  {name}: {pixels}, {outline}");
    }
    if let Some(path) = std::env::var_os("COMPARE_MISSES") {
        // The signal as grey (ΔE00 0 black to 10 white), the misses red.
        let mut pixels: Vec<Srgb<u8>> = signal
            .iter()
            .map(|s| {
                let v = (25.5 * s.min(10.0)) as u8;
                Srgb::new(v, v, v)
            })
            .collect();
        for &i in misses {
            pixels[i] = Srgb::new(255, 0, 0);
        }
        let height = (signal.len() / width as usize) as u32;
        match write_srgb8_png(std::path::Path::new(&path), width, height, &pixels) {
            Ok(()) => println!("misses drawn in {}", path.to_string_lossy()),
            Err(e) => eprintln!("could not draw the misses: {e}"),
        }
    }
}

/// `COMPARE_EXPLAIN`: traces [`EXPLAINED_SAMPLES`] samples of one pixel one by one
/// (`pixel`: x, y and the image's width) in `shading`'s model, with the
/// integrator's default settings as the preview has them, and prints their mean,
/// quantiles of the samples' brightness (the mean over wavelengths of the spectral
/// radiance) and the brightest samples with their paths; then the spread of the
/// pixel's mean over seeds. Recorded paths take one light sample at their first
/// vertex, not the preview's two, so the listed samples spread a little wider than
/// the preview's (the mean is the same); the spread over seeds is the preview's.
fn explain_pixel(
    scene: &RenderScene,
    environment: &Environment,
    shading: &Shading,
    camera: &Camera,
    [x, y, width]: [u32; 3],
    view: usize,
) {
    let tracer = PathTracer::new(
        scene.geometry(),
        environment,
        shading,
        IntegratorSettings::default(),
    );
    let len = shading.len();
    let mut buffers = PathBuffers::new(len);
    let mut radiance = vec![0.0f32; len];
    let mut samples: Vec<(f32, String, PathKind)> = Vec::with_capacity(EXPLAINED_SAMPLES as usize);
    let mut one = OneSample {
        tracer: &tracer,
        camera,
        buffers: &mut buffers,
        radiance: &mut radiance,
        pixel: [x, y, width],
    };
    for sample in 0..EXPLAINED_SAMPLES {
        let mut path = PathWords {
            materials: scene.materials(),
            words: String::new(),
            kind: PathKind::default(),
            rough_before: false,
        };
        let value = one.brightness(0x5eed_0303, sample, &mut path);
        samples.push((value, path.words, path.kind));
    }
    let mean = samples.iter().map(|s| f64::from(s.0)).sum::<f64>() / samples.len() as f64;
    // Where a pixel's noise is a few rare bright paths, which kind they are:
    // lamps, found only by a path's own BSDF samples (no light sample aims at
    // them), or caustics, a light seen in a glossy reflection from a rough
    // surface, which a path tracer finds only when the rough bounce happens to
    // aim at the glossy reflection.
    let variance_sum: f64 = samples
        .iter()
        .map(|s| (f64::from(s.0) - mean).powi(2))
        .sum();
    let share = |of: fn(&PathKind) -> bool| {
        let (mut count, mut sum, mut square) = (0usize, 0.0, 0.0);
        for (value, _, _) in samples.iter().filter(|s| of(&s.2)) {
            count += 1;
            sum += f64::from(*value);
            square += (f64::from(*value) - mean).powi(2);
        }
        (
            count,
            100.0 * sum / (mean * samples.len() as f64),
            100.0 * square / variance_sum,
        )
    };
    let shares = [
        (
            "shaded an emissive surface".to_string(),
            share(|k| k.emitter),
        ),
        (
            format!("took a glossy bounce (density ≥ {GLOSSY_DENSITY} /sr) after a rough one"),
            share(|k| k.caustic),
        ),
    ];
    samples.sort_by(|a, b| b.0.total_cmp(&a.0));
    let above = |share: f64| samples[(share * samples.len() as f64) as usize].0;
    println!(
        "view {view}, pixel ({x}, {y}), {EXPLAINED_SAMPLES} samples: mean {mean:.4}; median \
         {:.4}, brightest 10 % from {:.4}, 1 % from {:.4}, 0.1 % from {:.4}; the brightest:",
        above(0.5),
        above(0.1),
        above(0.01),
        above(0.001)
    );
    for (value, words, _) in samples.iter().take(8) {
        println!(
            "  {value:.3} ({:.1e} of the sum):{words}",
            f64::from(*value) / (mean * samples.len() as f64)
        );
    }
    for (what, (count, of_mean, of_variance)) in shares {
        println!(
            "  paths that {what}: {count} of {EXPLAINED_SAMPLES}, {of_mean:.1} % of the mean, \
             {of_variance:.1} % of the samples' variance"
        );
    }
    // How far a pixel's mean of N samples strays, from the spread of such means
    // over other seeds: the error the sampler leaves, stratification included
    // (the samples of one seed are not independent, so the spread of single
    // samples above does not give it).
    let means: Vec<f64> = (0..SPREAD_SEEDS)
        .map(|seed| {
            let sum: f64 = (0..SPREAD_SAMPLES)
                .map(|sample| f64::from(one.brightness(0x5eed_0404 + seed, sample, &mut NoRecord)))
                .sum();
            sum / f64::from(SPREAD_SAMPLES)
        })
        .collect();
    let centre = means.iter().sum::<f64>() / means.len() as f64;
    let spread =
        (means.iter().map(|m| (m - centre).powi(2)).sum::<f64>() / (means.len() - 1) as f64).sqrt();
    println!(
        "  the mean of {SPREAD_SAMPLES} samples over {SPREAD_SEEDS} seeds: {centre:.4}, standard \
         deviation {spread:.5} ({:.2} % of the mean)",
        100.0 * spread / centre
    );
}

/// `COMPARE_EXPLAIN`'s spread of a pixel's mean: seeds, and samples a seed.
const SPREAD_SEEDS: u64 = 256;
const SPREAD_SAMPLES: u32 = 64;

/// Samples `COMPARE_EXPLAIN` traces of its pixel.
const EXPLAINED_SAMPLES: u32 = 1 << 16;

/// One pixel's samples, traced one at a time.
struct OneSample<'a> {
    tracer: &'a PathTracer<'a>,
    camera: &'a Camera,
    buffers: &'a mut PathBuffers,
    radiance: &'a mut [f32],
    /// x, y and the image's width.
    pixel: [u32; 3],
}

impl OneSample<'_> {
    /// Sample `sample` of the pixel in a render with `seed`: its brightness (the
    /// mean over wavelengths of the spectral radiance), its path told to
    /// `recorder`.
    fn brightness(&mut self, seed: u64, sample: u32, recorder: &mut impl PathRecorder) -> f32 {
        let [x, y, width] = self.pixel;
        let mut sampler = PixelSampler::new(seed, y * width + x, sample);
        let [jx, jy] = sampler.next_2d();
        let (origin, dir) = self.camera.ray(x as f32 + jx, y as f32 + jy);
        self.tracer.radiance(
            origin,
            dir,
            &mut sampler,
            self.buffers,
            self.radiance,
            recorder,
        );
        // A recorded path's radiance leaves the floor's control term to the film.
        for (r, c) in self.radiance.iter_mut().zip(self.buffers.floor_control(0)) {
            *r += c;
        }
        self.radiance.iter().sum::<f32>() / self.radiance.len() as f32
    }
}

/// A path in words, as the tracer reports its decisions.
struct PathWords<'a> {
    materials: &'a [SceneMaterial],
    words: String,
    kind: PathKind,
    /// Whether the last vertex's continuation was a rough one.
    rough_before: bool,
}

/// What a path met, for `COMPARE_EXPLAIN`'s shares.
#[derive(Default)]
struct PathKind {
    /// A vertex on an emissive material.
    emitter: bool,
    /// A glossy continuation (a density of at least [`GLOSSY_DENSITY`]) right
    /// after a rough one.
    caustic: bool,
}

/// The continuation density (per steradian) from which `COMPARE_EXPLAIN` counts
/// a bounce as glossy: a Lambertian surface's is at most 1/π, the paint's clear
/// coat's in the tens to thousands.
const GLOSSY_DENSITY: f32 = 10.0;

impl PathRecorder for PathWords<'_> {
    fn vertex(&mut self, vertex: &VertexRecord, light_transmittance: Option<&[f32]>) {
        let name = match vertex.surface {
            Surface::Mesh { material } => {
                let material = &self.materials[material as usize];
                self.kind.emitter |= material.is_emissive();
                material.name.as_str()
            }
            Surface::Floor => "floor",
        };
        let glossy = vertex
            .next
            .as_ref()
            .is_some_and(|next| next.delta || next.pdf >= GLOSSY_DENSITY);
        self.kind.caustic |= glossy && self.rough_before;
        self.rough_before = vertex.next.is_some() && !glossy;
        self.words += &format!(" {name} (cos to viewer {:.2}", vertex.wo[2]);
        if let Some(light) = &vertex.light {
            let through = if light_transmittance.is_some() {
                " through see-through surfaces"
            } else {
                ""
            };
            self.words += &format!(
                "; lit{through}, densities light {:.2e} BSDF {:.2e}",
                light.light_pdf, light.bsdf_pdf
            );
        }
        if let Some(next) = &vertex.next {
            let delta = if next.delta { " delta" } else { "" };
            self.words += &format!("; on{delta}, density {:.2e}", next.pdf);
        }
        self.words += ")";
    }

    fn crossed(&mut self, factor: Option<&[f32]>) {
        let mean = factor.map_or(1.0, |f| f.iter().sum::<f32>() / f.len() as f32);
        self.words += &format!(" crossed ×{mean:.2}");
    }

    fn escape(&mut self, dir: [f32; 3], mis: f32) {
        self.words += &format!(
            " out along ({:.2}, {:.2}, {:.2}), MIS weight {mis:.3}",
            dir[0], dir[1], dir[2]
        );
    }
}
