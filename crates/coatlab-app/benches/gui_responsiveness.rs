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
//! (c) the real window: the `coatlab` binary started under Xvfb (drawn by Mesa's
//!     software Vulkan, lavapipe, as on these machines) with `COATLAB_FRAME_LOG`,
//!     which makes it redraw continuously and log each frame's start and its UI
//!     pass (`gui/frame_log.rs`), for `--real-window-seconds` while the preview
//!     renders; frames per second, the worst frame, and the CPU time of each of the
//!     process's threads (our UI thread, the render threads, lavapipe's).
//!
//! (d) what the window sends to the GPU each frame (`--only-tessellation`): the app
//!     drawn through a plain egui context while the preview renders, each frame
//!     tessellated as eframe does; meshes, vertices, triangles (and how many are
//!     thinner than a pixel), the pixels they cover per clip rectangle (overdraw
//!     included), texture updates, and how often the app asked for a repaint.
//!
//! (a) and (b) for the single view and for Paint vs Phong side by side, (b) also
//! for a single view set to Phong (best fit). Not a timed test: it prints figures
//! for `docs/benchmarks.md` ("GUI responsiveness").
//!
//!     cargo bench -p coatlab-app --features frame-log --bench gui_responsiveness
//!
//! Options after `--`: `--seconds S` of paced frames per case (default 10),
//! `--changes N` (default 30), `--real-window-seconds S` (default 20; 0 skips it),
//! `--only-real-window` (skips (a) and (b)), `--only-tessellation` (only (d);
//! `--frames N`, default 60).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use coatlab_app::gui::compare::{CompareLayout, CompareMode};
use coatlab_app::gui::storage::Storage;
use coatlab_app::gui::{AppOptions, CoatlabApp};
use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;

#[path = "../../../tests/common/harness.rs"]
mod harness;
use harness::{app_harness, options};

#[path = "../../../tests/common/xvfb.rs"]
mod xvfb;
use xvfb::{Reaped, app_dirs, have, start_xvfb};

fn harness() -> Harness<'static, CoatlabApp> {
    app_harness(
        egui::vec2(1500.0, 940.0),
        false,
        CoatlabApp::new(options(true)),
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

/// CPU seconds (user + system) per thread name of a running process, largest first.
fn thread_cpu_seconds(pid: u32) -> Vec<(String, f64)> {
    // Clock ticks per second: 100 on Linux for /proc's stat fields.
    const TICKS: f64 = 100.0;
    let mut by_name: Vec<(String, f64)> = Vec::new();
    let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return by_name;
    };
    for task in tasks.filter_map(Result::ok) {
        let Ok(stat) = std::fs::read_to_string(task.path().join("stat")) else {
            continue;
        };
        // "tid (comm) state ...": the name may hold spaces; fields follow the last ')'.
        let (Some(open), Some(close)) = (stat.find('('), stat.rfind(')')) else {
            continue;
        };
        // Thread names differ only by a trailing index (llvmpipe-0, -1...): group them.
        let name = stat[open + 1..close].trim_end_matches(|c: char| c.is_ascii_digit());
        let fields: Vec<&str> = stat[close + 1..].split_whitespace().collect();
        let ticks = |i: usize| {
            fields
                .get(i)
                .and_then(|f| f.parse::<f64>().ok())
                .unwrap_or(0.0)
        };
        // utime and stime are fields 14 and 15 of stat, 12 and 13 after the ')'.
        let cpu = (ticks(11) + ticks(12)) / TICKS;
        match by_name.iter_mut().find(|(n, _)| n == name) {
            Some((_, c)) => *c += cpu,
            None => by_name.push((name.to_owned(), cpu)),
        }
    }
    by_name.sort_by(|a, b| b.1.total_cmp(&a.1));
    by_name
}

/// (c): the real binary in a real window under Xvfb, frames logged by the app.
fn real_window(seconds: f64) {
    if !have("Xvfb") {
        println!("[real window] skipped: Xvfb is not installed");
        return;
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/gui-bench");
    let (runtime, state) = match app_dirs(&dir) {
        Ok(dirs) => dirs,
        Err(e) => {
            println!(
                "[real window] skipped: cannot create {}: {e}",
                dir.display()
            );
            return;
        }
    };
    let frames_path: PathBuf = dir.join("frames.log");
    let _ = std::fs::remove_file(&frames_path);
    let (_xvfb, display) = match start_xvfb() {
        Ok(server) => server,
        Err(e) => {
            println!("[real window] skipped: {e}");
            return;
        }
    };
    let Ok(log) = std::fs::File::create(dir.join("coatlab.log")) else {
        println!("[real window] skipped: cannot create the app's log");
        return;
    };
    let Ok(err) = log.try_clone() else { return };
    let load_before = load_average();
    let Ok(child) = Command::new(env!("CARGO_BIN_EXE_coatlab"))
        .env("DISPLAY", &display)
        .env("XDG_RUNTIME_DIR", &runtime)
        .env("COATLAB_STATE_DIR", &state)
        .env("COATLAB_FRAME_LOG", &frames_path)
        .env_remove("WAYLAND_DISPLAY")
        .stdout(log)
        .stderr(err)
        .spawn()
    else {
        println!("[real window] skipped: coatlab did not start");
        return;
    };
    let mut app = Reaped(child);
    // The first frames build pipelines and fonts (seconds on lavapipe): not counted.
    let warm_up = 5.0;
    std::thread::sleep(Duration::from_secs_f64(warm_up));
    let threads_before = thread_cpu_seconds(app.0.id());
    std::thread::sleep(Duration::from_secs_f64(seconds));
    // CPU after the warm-up only: lavapipe compiles its pipelines in the first frames.
    let mut threads = thread_cpu_seconds(app.0.id());
    for (name, cpu) in &mut threads {
        if let Some((_, before)) = threads_before.iter().find(|(n, _)| n == name) {
            *cpu -= before;
        }
    }
    threads.sort_by(|a, b| b.1.total_cmp(&a.1));
    let exited = app.0.try_wait().ok().flatten();
    drop(app);
    let load_after = load_average();
    if let Some(status) = exited {
        println!(
            "[real window] coatlab exited early ({status}); see {}",
            dir.join("coatlab.log").display()
        );
        return;
    }
    let text = std::fs::read_to_string(&frames_path).unwrap_or_default();
    let frames: Vec<(f64, f64)> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .filter_map(|l| {
            let mut f = l.split_whitespace().map(|v| v.parse::<f64>());
            Some((f.next()?.ok()?, f.next()?.ok()?))
        })
        .collect();
    let Some(&(first, _)) = frames.first() else {
        println!("[real window] no frames logged");
        return;
    };
    let counted: Vec<(f64, f64)> = frames
        .iter()
        .copied()
        .filter(|(t, _)| *t >= first + warm_up)
        .collect();
    if counted.len() < 2 {
        println!(
            "[real window] only {} frames after the warm-up",
            counted.len()
        );
        return;
    }
    let span = counted[counted.len() - 1].0 - counted[0].0;
    let intervals: Vec<f64> = counted
        .windows(2)
        .map(|w| (w[1].0 - w[0].0) * 1e3)
        .collect();
    let over = intervals.iter().filter(|&&ms| ms > 1000.0 / 30.0).count();
    println!(
        "[real window] load average before {load_before}, after {load_after}; {} frames in \
         {span:.1} s after a {warm_up} s warm-up: {:.1} frames/s, {over} of {} intervals \
         over 33.3 ms",
        counted.len(),
        (counted.len() - 1) as f64 / span,
        intervals.len()
    );
    summary("[real window] frame interval", intervals);
    summary(
        "[real window] of which our UI pass",
        counted.iter().map(|(_, ui)| *ui).collect(),
    );
    let frames_counted = (counted.len() - 1).max(1) as f64;
    for (name, cpu) in threads.iter().take(8) {
        println!(
            "[real window] thread {name:<20} {cpu:6.2} s CPU in {seconds:.0} s ({:.0} % of a \
             core), {:.1} ms per frame",
            100.0 * cpu / seconds,
            1e3 * cpu / frames_counted
        );
    }
}

/// (d): what the window sends to the GPU per frame: the app drawn through a plain
/// egui context at the window's size (1500×940 points, 1 pixel per point) while the
/// preview renders, each frame tessellated as eframe does. Per clip rectangle (a
/// panel, a plot, the preview): meshes, vertices, triangles, the triangles' summed
/// area (pixels shaded, overdraw included) and how many are thinner than a pixel
/// (lavapipe's cost per triangle is its set-up, not its area); the texture updates;
/// the repaint delay the app asked for.
fn tessellation(frames: usize) {
    let ctx = egui::Context::default();
    let mut app = CoatlabApp::new(options(true));
    let screen = egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(1500.0, 940.0));
    let start = Instant::now();
    let input = |t: f64| egui::RawInput {
        screen_rect: Some(screen),
        time: Some(t),
        ..Default::default()
    };
    // Until the preview shows a refined image (the steady state while it renders).
    while !app.preview().is_some_and(|p| {
        p.status()
            .is_some_and(|s| !s.coarse && s.samples_per_pixel >= 2)
    }) {
        assert!(start.elapsed().as_secs() < 120, "no refined preview image");
        let _ = ctx.run_ui(input(start.elapsed().as_secs_f64()), |ui| app.show(ui));
        std::thread::sleep(Duration::from_millis(20));
    }
    #[derive(Default)]
    struct Region {
        meshes: usize,
        vertices: usize,
        triangles: usize,
        area: f64,
        thin: usize,
    }
    let mut regions: Vec<(egui::Rect, Region)> = Vec::new();
    let (mut uploads, mut upload_texels, mut repaint_now) = (0usize, 0usize, 0usize);
    for _ in 0..frames {
        std::thread::sleep(Duration::from_millis(33));
        let out = ctx.run_ui(input(start.elapsed().as_secs_f64()), |ui| app.show(ui));
        for deltas in out.textures_delta.set.values() {
            for d in deltas {
                uploads += 1;
                upload_texels += d.image.width() * d.image.height();
            }
        }
        if out
            .viewport_output
            .values()
            .any(|v| v.repaint_delay < Duration::from_millis(100))
        {
            repaint_now += 1;
        }
        for prim in ctx.tessellate(out.shapes, out.pixels_per_point) {
            let egui::epaint::Primitive::Mesh(mesh) = prim.primitive else {
                continue;
            };
            let clip = prim.clip_rect.intersect(screen);
            let region = match regions.iter_mut().find(|(r, _)| *r == clip) {
                Some((_, r)) => r,
                None => {
                    regions.push((clip, Region::default()));
                    &mut regions.last_mut().expect("just pushed").1
                }
            };
            region.meshes += 1;
            region.vertices += mesh.vertices.len();
            for tri in mesh.indices.chunks_exact(3) {
                let [a, b, c] = [0, 1, 2].map(|k| mesh.vertices[tri[k] as usize].pos);
                let area = 0.5 * ((b - a).x * (c - a).y - (b - a).y * (c - a).x).abs();
                region.triangles += 1;
                region.area += f64::from(area);
                // Thinner than a pixel: area below half the longest edge.
                let longest = (b - a).length().max((c - b).length()).max((a - c).length());
                if area < 0.5 * longest {
                    region.thin += 1;
                }
            }
        }
    }
    let n = frames as f64;
    regions.sort_by_key(|(_, r)| std::cmp::Reverse(r.triangles));
    let total = |f: &dyn Fn(&Region) -> f64| regions.iter().map(|(_, r)| f(r)).sum::<f64>() / n;
    println!(
        "[tessellation] per frame over {frames} frames: {:.0} meshes, {:.0} vertices, {:.0} \
         triangles ({:.0} thinner than a pixel), {:.2} Mpx of triangle area ({:.2}× the \
         window); {:.2} texture updates ({:.0} texels); {repaint_now} of {frames} frames \
         asked for a repaint within 100 ms",
        total(&|r| r.meshes as f64),
        total(&|r| r.vertices as f64),
        total(&|r| r.triangles as f64),
        total(&|r| r.thin as f64),
        total(&|r| r.area) / 1e6,
        total(&|r| r.area) / f64::from(screen.area()),
        uploads as f64 / n,
        upload_texels as f64 / n,
    );
    for (rect, r) in regions.iter().take(12) {
        println!(
            "[tessellation]   clip ({:4.0},{:4.0})–({:4.0},{:4.0}): {:5.1} meshes {:7.0} vertices \
             {:7.0} triangles ({:6.0} thin), {:6.3} Mpx",
            rect.min.x,
            rect.min.y,
            rect.max.x,
            rect.max.y,
            r.meshes as f64 / n,
            r.vertices as f64 / n,
            r.triangles as f64 / n,
            r.thin as f64 / n,
            r.area / n / 1e6
        );
    }
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
    let window_seconds = option("--real-window-seconds", 20) as f64;
    if args.iter().any(|a| a == "--only-tessellation") {
        tessellation(option("--frames", 60));
        return;
    }
    if args.iter().any(|a| a == "--only-real-window") {
        real_window(window_seconds);
        return;
    }
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

    // The single view set to Phong (best fit): each change refits (ks, m cached).
    select_model(&mut h, "Phong (best fit)");
    change_latency(&mut h, changes, "single view, Phong (best fit)");
    select_model(&mut h, "Paint model");

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
    if window_seconds > 0.0 {
        real_window(window_seconds);
    }
}

/// Picks the single view's model by its selectable label.
fn select_model(h: &mut Harness<'static, CoatlabApp>, label: &str) {
    let node = h.get_all_by_label(label).next();
    match node {
        Some(node) => node.click(),
        None => panic!("no \"{label}\" to click in the preview's toolbar"),
    }
    h.step();
    settle(h);
}
