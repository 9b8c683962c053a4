//! Smoke test of the real `coatlab` binary: started without a subcommand under a
//! virtual X server (Xvfb), it must open its window and keep running; a screenshot
//! of the screen goes to `target/gui-smoke/screenshot.png` for a person to look at,
//! and must show the designer (not a blank screen) with the car in its signal red
//! paint in the preview.
//!
//! Needs `Xvfb` and ImageMagick's `import` (the README's and CI's apt packages).
//! Without them the test says so and passes, unless `COATLAB_REQUIRE_GUI_SMOKE=1`
//! (set by CI), where missing tools are a failure.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

#[path = "common/xvfb.rs"]
mod xvfb;
use xvfb::{Reaped, app_dirs, coatlab_on, have, start_xvfb};

fn out_dir() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/gui-smoke");
    std::fs::create_dir_all(&dir).expect("create target/gui-smoke");
    dir
}

/// Counts distinct colours in a PNG read through ImageMagick (no image crate needed).
fn distinct_colours(png: &Path) -> usize {
    let out = Command::new("identify")
        .args(["-format", "%k"])
        .arg(png)
        .output()
        .expect("run identify");
    String::from_utf8_lossy(&out.stdout)
        .trim()
        .parse()
        .unwrap_or(0)
}

/// The screen's pixels as RGB bytes, read through ImageMagick.
fn rgb_pixels(png: &Path) -> Vec<[u8; 3]> {
    let out = Command::new("convert")
        .arg(png)
        .args(["-depth", "8", "rgb:-"])
        .output()
        .expect("run convert");
    out.stdout
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect()
}

/// Share of the pixels in `region` (x0, y0, x1, y1) of a `width`-wide screen that are
/// a saturated red: the default design, signal red, on the car body.
fn red_share(pixels: &[[u8; 3]], width: usize, region: (usize, usize, usize, usize)) -> f64 {
    let (x0, y0, x1, y1) = region;
    let mut red = 0usize;
    let mut total = 0usize;
    for y in y0..y1 {
        for x in x0..x1 {
            let Some(&[r, g, b]) = pixels.get(y * width + x) else {
                continue;
            };
            total += 1;
            if r > 90 && u16::from(r) > 2 * u16::from(g) && u16::from(r) > 2 * u16::from(b) {
                red += 1;
            }
        }
    }
    red as f64 / total.max(1) as f64
}

#[test]
fn the_binary_opens_its_window_under_xvfb() {
    if !(have("Xvfb") && have("import") && have("identify") && have("convert")) {
        assert!(
            std::env::var_os("COATLAB_REQUIRE_GUI_SMOKE").is_none(),
            "COATLAB_REQUIRE_GUI_SMOKE is set but Xvfb or ImageMagick is missing"
        );
        eprintln!("skipped: Xvfb and ImageMagick are not installed (see README)");
        return;
    }
    let dir = out_dir();
    let (runtime, state) = app_dirs(&dir).expect("runtime dir");
    let (xvfb, display) = start_xvfb().unwrap_or_else(|e| panic!("{e}"));

    let mut app = Reaped(
        coatlab_on(&display, &runtime, &dir.join("coatlab.log"))
            .env("COATLAB_STATE_DIR", &state)
            .spawn()
            .expect("start coatlab"),
    );
    // A debug build on the software rasteriser needs a few seconds for the first
    // frames; the preview's first refined images come within a second or two of that.
    std::thread::sleep(Duration::from_secs(12));
    let log_text = || std::fs::read_to_string(dir.join("coatlab.log")).unwrap_or_default();
    assert!(
        app.0.try_wait().expect("poll coatlab").is_none(),
        "coatlab exited early:\n{}",
        log_text()
    );
    let shot = dir.join("screenshot.png");
    let status = Command::new("import")
        .args(["-display", display.as_str(), "-window", "root"])
        .arg(&shot)
        .status()
        .expect("run import");
    assert!(status.success(), "import failed");
    // A blank or single-colour screen means no window was drawn; the designer's plots
    // and text give thousands of colours.
    let colours = distinct_colours(&shot);
    assert!(
        colours > 200,
        "the screen looks blank ({colours} colours): {}",
        shot.display()
    );
    // The preview shows the car: without a window manager the 1500×940 window sits at
    // the top left; the preview fills the central area right of the paint panel
    // (≈ 430 points wide) below the tabs and toolbars. The red body covers a good
    // part of it (≈ 10 %); the studio's grey backdrop and floor have none.
    let pixels = rgb_pixels(&shot);
    assert_eq!(pixels.len(), 1600 * 1000, "screenshot size");
    let share = red_share(&pixels, 1600, (460, 160, 1480, 880));
    assert!(
        share > 0.02,
        "no red car in the preview ({:.2} % red pixels): {}",
        share * 100.0,
        shot.display()
    );
    // And none left of it, in the paint panel (its curves are thin lines).
    assert!(
        red_share(&pixels, 1600, (0, 40, 420, 100)) < share,
        "red is everywhere, not in the preview"
    );
    assert!(
        app.0.try_wait().expect("poll coatlab").is_none(),
        "coatlab exited:\n{}",
        log_text()
    );
    drop(app);
    drop(xvfb);
}
