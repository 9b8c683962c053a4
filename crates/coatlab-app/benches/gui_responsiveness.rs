//! Responsiveness of the designer's window while the preview renders (issue 4):
//!
//! (a) the UI's own work per frame while the render thread is busy: the whole
//!     window (`CoatlabApp::show`) driven frame by frame through egui_kittest, the
//!     render thread refining the preview on the same cores; each frame's wall time
//!     is what the UI thread needs for it, preemption by the renderer included
//!     (painting the tessellated frame on the GPU is not: that is the GPU's, and on a
//!     software rasteriser it would measure the rasteriser);
//! (b) the time from a parameter change (the thickness slider, set as assistive
//!     technology sets it) to the UI taking up the first image rendered with it, at
//!     the default window size (1500×940, preview 640×400, coarse pass 160×100).
//!
//! Both for the single view and for Paint vs Phong side by side. Not a timed test:
//! it prints figures for `docs/benchmarks.md` ("GUI responsiveness").
//!
//!     cargo bench -p coatlab-app --bench gui_responsiveness
//!
//! Options after `--`: `--seconds S` of paced frames per case (default 10),
//! `--changes N` (default 30).

use std::time::{Duration, Instant};

use coatlab_app::gui::compare::{CompareLayout, CompareMode};
use coatlab_app::gui::storage::Storage;
use coatlab_app::gui::{AppOptions, CoatlabApp};
use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;

fn harness() -> Harness<'static, CoatlabApp> {
    Harness::builder()
        .with_size(egui::vec2(1500.0, 940.0))
        .build_ui_state(
            |ui, app: &mut CoatlabApp| app.show(ui),
            CoatlabApp::new(AppOptions {
                storage: Storage::none(),
                open: None,
                preview: true,
            }),
        )
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".into())
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn summary(name: &str, mut ms: Vec<f64>) {
    ms.sort_by(f64::total_cmp);
    let mean = ms.iter().sum::<f64>() / ms.len().max(1) as f64;
    println!(
        "{name}: n={} mean {mean:.2} ms, median {:.2}, p95 {:.2}, max {:.2} ms",
        ms.len(),
        percentile(&ms, 0.5),
        percentile(&ms, 0.95),
        ms.last().copied().unwrap_or(f64::NAN)
    );
}

fn wait_for(h: &mut Harness<'static, CoatlabApp>, what: &str, done: impl Fn(&CoatlabApp) -> bool) {
    let start = Instant::now();
    while !done(h.state()) {
        assert!(
            start.elapsed().as_secs() < 120,
            "timed out waiting for {what}"
        );
        h.step();
        std::thread::sleep(Duration::from_millis(1));
    }
}

fn settle(h: &mut Harness<'static, CoatlabApp>) {
    wait_for(h, "a refined image", |app| {
        app.preview().is_some_and(|p| {
            !p.change_pending()
                && p.status()
                    .is_some_and(|s| !s.coarse && s.samples_per_pixel >= 2)
        })
    });
}

/// (a): frame times while the render thread refines, frames paced at 60 Hz as a
/// display would (a frame as soon as the last one is done would mostly measure
/// frames with nothing new; paced, the frames that take up new images are in the
/// sample in their real share).
fn frame_times(h: &mut Harness<'static, CoatlabApp>, seconds: f64, label: &str) {
    settle(h);
    let period = Duration::from_secs_f64(1.0 / 60.0);
    let mut all = Vec::new();
    let mut with_image = Vec::new();
    let mut last_spp = h.state().preview_status().map(|s| s.samples_per_pixel);
    let first_spp = last_spp.unwrap_or(0);
    let start = Instant::now();
    let mut next = start;
    while start.elapsed().as_secs_f64() < seconds {
        let t = Instant::now();
        h.step();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let spp = h.state().preview_status().map(|s| s.samples_per_pixel);
        if spp != last_spp {
            with_image.push(ms);
            last_spp = spp;
        }
        all.push(ms);
        next += period;
        if let Some(wait) = next.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        } else {
            next = Instant::now();
        }
    }
    let elapsed = start.elapsed().as_secs_f64();
    let over_budget = all.iter().filter(|&&ms| ms > 1e3 / 30.0).count();
    println!(
        "[{label}] {} frames in {elapsed:.1} s = {:.1} frames/s (paced at 60); {over_budget} over 33.3 ms; \
         renderer went from {first_spp} to {} spp",
        all.len(),
        all.len() as f64 / elapsed,
        last_spp.unwrap_or(0)
    );
    summary(&format!("[{label}] UI frame, every frame"), all);
    summary(
        &format!("[{label}] UI frame, frames taking up a new image"),
        with_image,
    );
}

/// (b): from a thickness change to the first image with it.
fn change_latency(h: &mut Harness<'static, CoatlabApp>, changes: usize, label: &str) {
    let mut latencies = Vec::new();
    let mut coarse_pass = Vec::new();
    for k in 0..changes {
        settle(h);
        // A person does not change a value every frame: let a refinement pass run.
        let until = Instant::now() + Duration::from_millis(150);
        while Instant::now() < until {
            h.step();
            std::thread::sleep(Duration::from_millis(5));
        }
        let thickness = if k % 2 == 0 { 60.0 } else { 45.0 };
        h.get_by_role_and_label(Role::Slider, "Thickness h (µm)")
            .set_value_accesskit(thickness);
        h.step();
        wait_for(h, "the changed image", |app| {
            app.preview().is_some_and(|p| !p.change_pending())
        });
        let p = h.state().preview().expect("preview");
        if let (Some(l), Some(s)) = (p.last_change_latency(), p.status()) {
            latencies.push(l.as_secs_f64() * 1e3);
            if s.coarse {
                let pixels = f64::from(s.width * s.height);
                coarse_pass.push(pixels / s.samples_per_second * 1e3);
            }
        }
    }
    summary(&format!("[{label}] change -> first new image"), latencies);
    summary(
        &format!("[{label}] of which the coarse pass itself"),
        coarse_pass,
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let option = |name: &str, default: usize| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .and_then(|v| v.parse().ok())
            .unwrap_or(default)
    };
    let seconds = option("--seconds", 10) as f64;
    let changes = option("--changes", 30);
    println!(
        "cores: {}, load average before: {}",
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(0),
        load_average()
    );
    let mut h = harness();
    h.step();
    let size = h.state().preview_status().map(|s| (s.width, s.height));
    settle(&mut h);
    println!(
        "preview size: {:?} (first status {:?})",
        h.state().preview_status().map(|s| (s.width, s.height)),
        size
    );
    frame_times(&mut h, seconds, "single view");
    change_latency(&mut h, changes, "single view");

    if let Some(p) = h.state_mut().preview_mut() {
        p.set_compare(CompareMode::Models, CompareLayout::SideBySide);
    }
    settle(&mut h);
    println!(
        "comparison pane size: {:?}",
        h.state().preview_status().map(|s| (s.width, s.height))
    );
    frame_times(&mut h, seconds, "paint vs Phong, side by side");
    change_latency(&mut h, changes, "paint vs Phong, side by side");
    println!("load average after: {}", load_average());
}
