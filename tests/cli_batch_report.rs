//! End-to-end tests of `coatlab batch report`, the review deck: what the page
//! holds (renders, missing and out-of-date tasks, the verdicts against a target
//! design or a measured standard), and the page in headless Chromium: every image
//! loads, the summary table is there, a screenshot is drawn.

mod common;
#[path = "common/xvfb.rs"]
mod xvfb;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::batch::{coatlab_batch, write_manifest};
use common::{exit, failure, scratch_with_presets, stdout};

const PRESETS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/presets");
const MEASUREMENTS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../coatlab-core/tests/data/measurements"
);

/// A fresh folder with the signal red and deep blue presets, a copy of signal red
/// as `standard.toml`, and the two-standard CxF3 fixture.
fn scratch(name: &str) -> PathBuf {
    let dir = scratch_with_presets("cli_batch_report", name, &["signal-red", "deep-blue"]);
    std::fs::copy(
        format!("{PRESETS}/signal-red.toml"),
        dir.join("standard.toml"),
    )
    .expect("copy the target");
    std::fs::copy(
        format!("{MEASUREMENTS}/multi_angle.cxf"),
        dir.join("standards.cxf"),
    )
    .expect("copy the measurement fixture");
    dir
}

/// 2 designs × 1 view × 2 lighting, 2 spp, 4 λ, 48×27, with `extra` lines.
fn manifest(dir: &Path, extra: &str) -> PathBuf {
    write_manifest(dir, &format!("size = \"48x27\"\n{extra}"))
}

fn coatlab(args: &[&str]) -> Output {
    coatlab_batch(args, &[])
}

fn s(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

fn render(manifest: &Path, indices: &[usize]) {
    for i in indices {
        stdout(&coatlab(&[
            "batch",
            "run",
            s(manifest),
            "--index",
            &i.to_string(),
        ]));
    }
}

/// The output names of the manifest's tasks, in task order (from `batch plan
/// --json`, so that the test does not depend on the default view's name).
fn outputs(manifest: &Path) -> Vec<String> {
    let plan: serde_json::Value =
        serde_json::from_str(&stdout(&coatlab(&["batch", "plan", s(manifest), "--json"])))
            .expect("plan JSON");
    plan["tasks"]
        .as_array()
        .expect("tasks")
        .iter()
        .map(|t| t["output"].as_str().expect("output").to_owned())
        .collect()
}

fn report(manifest: &Path) -> (String, String) {
    let said = stdout(&coatlab(&["batch", "report", s(manifest)]));
    let deck = manifest.parent().expect("folder").join("deck/index.html");
    (
        said,
        std::fs::read_to_string(deck).expect("the deck is written"),
    )
}

/// The summary row of the design whose section is `anchor`.
fn summary_row<'a>(html: &'a str, anchor: &str) -> &'a str {
    let start = html
        .find(&format!("<tr data-section=\"{anchor}\""))
        .unwrap_or_else(|| panic!("no summary row for {anchor}"));
    let row = &html[start..];
    &row[..row.find("</tr>").expect("row ends")]
}

#[test]
fn the_deck_shows_renders_verdicts_and_missing_tasks() {
    let dir = scratch("design_target");
    let manifest = manifest(&dir, r#"target = "standard.toml""#);
    // Task 3 (deep blue in the booth) is left unrendered.
    render(&manifest, &[0, 1, 2]);
    let (said, html) = report(&manifest);
    assert!(
        said.contains("4 tasks, 3 rendered, 1 missing, 0 out of date; designs: 1 pass, 1 fail"),
        "{said}"
    );
    assert!(html.contains("<table id=\"summary\">"), "the summary table");
    // The renders are referred to relatively, one <img> per rendered task.
    let outputs = outputs(&manifest);
    assert_eq!(html.matches("<img ").count(), 3);
    for output in &outputs[..3] {
        assert!(html.contains(&format!("src=\"{output}\"")), "{output}");
    }
    assert!(outputs[3].starts_with("deep-blue--") && outputs[3].contains("--booth-d65--"));
    assert!(html.contains("missing: task 3 not rendered"));
    assert!(!html.contains(&format!("src=\"{}\"", outputs[3])));
    assert!(
        html.contains(&outputs[3]),
        "the missing task's output is named"
    );
    // Signal red against itself passes at 0.00; deep blue is far from it.
    let red = summary_row(&html, "design-signal-red");
    assert!(
        red.contains("class=\"pass\"") && red.contains(">0.00<"),
        "{red}"
    );
    assert!(red.contains("2 of 2"), "{red}");
    let blue = summary_row(&html, "design-deep-blue");
    assert!(blue.contains("class=\"fail\""), "{blue}");
    assert!(blue.contains("1 of 2"), "{blue}");
    // Five angles with their ΔE00 and verdicts per design, three swatches each.
    assert_eq!(html.matches("<td class=\"de00\"").count(), 10);
    for illuminant in ["D65", "A", "F11"] {
        assert_eq!(
            html.matches(&format!("data-illuminant=\"{illuminant}\""))
                .count(),
            2,
            "{illuminant}"
        );
    }
    assert_eq!(html.matches("<table class=\"gloss\">").count(), 2);
    // Nothing from the network.
    assert!(!html.contains("http://") && !html.contains("https://"));

    // A changed seed changes every task's inputs: the rendered three are out of date.
    let manifest = self::manifest(&dir, "target = \"standard.toml\"\nseed = 5");
    let (said, html) = report(&manifest);
    assert!(
        said.contains("4 tasks, 0 rendered, 1 missing, 3 out of date"),
        "{said}"
    );
    assert_eq!(html.matches("class=\"stale\">out of date").count(), 3);
}

#[test]
fn a_measured_target_compares_each_design_with_its_standard() {
    let dir = scratch("measured_target");
    // The file holds "Signal red" and "Deep blue": each design meets its namesake.
    let manifest = manifest(&dir, r#"target = "standards.cxf""#);
    let (said, html) = report(&manifest);
    assert!(said.contains("4 tasks, 0 rendered, 4 missing"), "{said}");
    assert!(html.contains("Against Signal red."), "red's standard");
    assert!(html.contains("Against Deep blue."), "blue's standard");
    assert_eq!(html.matches("missing: task").count(), 4);
    // The standards' 45°as45° spectra give the swatches their target halves.
    for illuminant in ["D65", "A", "F11"] {
        assert_eq!(
            html.matches(&format!("</div>{illuminant} · ΔE00 ")).count(),
            2,
            "{illuminant}"
        );
    }

    // target_sample chooses one standard for every design.
    let manifest = self::manifest(
        &dir,
        "target = \"standards.cxf\"\ntarget_sample = \"Deep blue\"\ntolerance = \"cmc:2\"",
    );
    let (_, html) = report(&manifest);
    assert_eq!(html.matches("Against Deep blue.").count(), 2);
    assert!(
        html.contains("<th>ΔE CMC(2:1)</th>"),
        "the tolerance's formula"
    );

    // One it does not have is refused, naming the key.
    let manifest = self::manifest(
        &dir,
        "target = \"standards.cxf\"\ntarget_sample = \"Lime green\"",
    );
    let stderr = failure(&coatlab(&["batch", "report", s(&manifest)]), exit::DATA);
    assert!(stderr.contains("target_sample"), "{stderr}");
    assert!(stderr.contains("Lime green"), "{stderr}");
}

#[test]
fn a_bad_tolerance_or_a_sample_without_target_is_refused_by_line_and_key() {
    let dir = scratch("refusals");
    let manifest = manifest(&dir, "tolerance = \"de00:-1\"");
    let stderr = failure(&coatlab(&["batch", "plan", s(&manifest)]), exit::DATA);
    assert!(
        stderr.contains("line 9, key `tolerance`") && stderr.contains("-1"),
        "{stderr}"
    );
    let manifest = self::manifest(&dir, "target_sample = \"Deep blue\"");
    let stderr = failure(&coatlab(&["batch", "plan", s(&manifest)]), exit::DATA);
    assert!(
        stderr.contains("line 9, key `target_sample`") && stderr.contains("give target"),
        "{stderr}"
    );
}

/// Runs Chromium headless on `args`, with no sandbox (tests run as root in CI
/// containers, where Chromium's sandbox refuses to start).
fn chromium(args: &[&str]) -> Output {
    Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
        ])
        .args(args)
        .output()
        .expect("chromium runs")
}

/// Whether Chromium is here; where it is not, CI fails (it must run the browser
/// checks) and elsewhere the caller skips them, saying so.
fn have_chromium() -> bool {
    if xvfb::have("chromium") {
        return true;
    }
    assert!(
        !xvfb::gui_tools_required(),
        "chromium is not installed, and CI needs this test (apt-get install chromium)"
    );
    eprintln!("skipped the browser check: chromium not installed (apt-get install chromium)");
    false
}

#[test]
fn the_deck_loads_in_headless_chromium() {
    if !have_chromium() {
        return;
    }
    let dir = scratch("chromium");
    let manifest = manifest(&dir, r#"target = "standard.toml""#);
    render(&manifest, &[0, 1, 2, 3]);
    let (said, _) = report(&manifest);
    assert!(said.contains("4 rendered, 0 missing"), "{said}");
    let url = format!("file://{}", s(&dir.join("deck/index.html")));

    // The page's own script records every image's naturalWidth once it has loaded.
    let dom = chromium(&["--virtual-time-budget=5000", "--dump-dom", &url]);
    let dom = String::from_utf8_lossy(&dom.stdout);
    assert!(
        dom.contains(r#"id="image-check" data-loaded="4" data-total="4""#),
        "every image loads: {}",
        dom.lines()
            .find(|l| l.contains("image-check"))
            .unwrap_or("no image check in the DOM")
    );
    assert_eq!(dom.matches("data-natural-width=\"48\"").count(), 4);
    assert!(dom.contains("<table id=\"summary\">"));
    assert!(dom.contains("Signal red") && dom.contains("Deep blue"));

    // Sorted by the largest ΔE00, descending (what a click on the column does
    // twice; ?sort= does it on opening): deep blue first, in the table and below.
    let dom = chromium(&[
        "--virtual-time-budget=5000",
        "--dump-dom",
        &format!("{url}?sort=-max"),
    ]);
    let dom = String::from_utf8_lossy(&dom.stdout);
    assert!(dom.contains(r#"data-sorted-by="max descending""#), "sorted");
    let at = |needle: &str| {
        dom.find(needle)
            .unwrap_or_else(|| panic!("{needle} in the DOM"))
    };
    assert!(
        at(r#"<tr data-section="design-deep-blue""#)
            < at(r#"<tr data-section="design-signal-red""#),
        "the summary's rows sorted by ΔE00, largest first"
    );
    assert!(
        at(r#"<section class="design" id="design-deep-blue""#)
            < at(r#"<section class="design" id="design-signal-red""#),
        "the sections follow the table"
    );
    let dom = chromium(&[
        "--virtual-time-budget=5000",
        "--dump-dom",
        &format!("{url}?sort=max"),
    ]);
    let dom = String::from_utf8_lossy(&dom.stdout);
    assert!(
        dom.find(r#"<tr data-section="design-signal-red""#)
            < dom.find(r#"<tr data-section="design-deep-blue""#),
        "ascending: signal red (0.00) first"
    );

    let shot = dir.join("deck.png");
    let _ = std::fs::remove_file(&shot);
    let out = chromium(&[
        "--window-size=1200,1600",
        &format!("--screenshot={}", s(&shot)),
        &url,
    ]);
    assert!(
        shot.is_file(),
        "a screenshot: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The page drew more than a blank: the pass and fail badges' colours are there.
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(&shot).expect("the screenshot"),
    ));
    let mut reader = decoder.read_info().expect("a PNG");
    let mut pixels = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut pixels).expect("decodes");
    let channels = info.color_type.samples();
    let has = |rgb: [u8; 3]| {
        pixels[..info.buffer_size()]
            .chunks(channels)
            .any(|p| p[..3] == rgb)
    };
    assert!(has([0x2a, 0x7d, 0x2e]), "the pass badge's green is drawn");
    assert!(has([0xb3, 0x26, 0x1e]), "the fail badge's red is drawn");
}

/// `views = ["turntable:3"]` is three tasks a design and lighting, one a frame,
/// named in the order of the turn; the deck shows each turn as a strip of its
/// frames, in one row in Chromium.
#[test]
fn a_turntable_is_a_task_a_frame_and_a_strip_in_the_deck() {
    let dir = scratch("turntable");
    let manifest = manifest(&dir, r#"views = ["side", "turntable:3"]"#);
    let outputs = outputs(&manifest);
    // 2 designs × (side + 3 frames) × 2 lighting.
    assert_eq!(outputs.len(), 16);
    let red_studio: Vec<&str> = outputs[..8]
        .iter()
        .map(String::as_str)
        .filter(|o| o.contains("--studio--"))
        .collect();
    assert_eq!(
        red_studio,
        [
            "signal-red--side--studio--paint.png",
            "signal-red--turntable-3-0--studio--paint.png",
            "signal-red--turntable-3-1--studio--paint.png",
            "signal-red--turntable-3-2--studio--paint.png",
        ]
    );
    stdout(&coatlab(&["batch", "run", s(&manifest)]));
    let (said, html) = report(&manifest);
    assert!(said.contains("16 tasks, 16 rendered"), "{said}");
    assert_eq!(
        html.matches("<div class=\"strip\" data-view=\"turntable:3\">")
            .count(),
        4
    );
    let strip = &html[html.find("<div class=\"strip\"").expect("a strip")..];
    let strip = &strip[..strip.find("</div></td>").expect("the strip ends")];
    let frames: Vec<usize> = (0..3)
        .map(|k| {
            strip
                .find(&format!(
                    "src=\"signal-red--turntable-3-{k}--studio--paint.png\""
                ))
                .unwrap_or_else(|| panic!("frame {k} in the first strip: {strip}"))
        })
        .collect();
    assert!(frames.is_sorted(), "the frames in the order of the turn");
    // Bad turntables are refused by line and key, naming the value.
    for (view, expected) in [
        (
            "turntable:0",
            "'turntable:0': 0 frames: a turntable takes 1 to 360",
        ),
        ("turntable:three", "N 'three' is not a whole number"),
    ] {
        let bad = self::manifest(&dir, &format!("views = [\"{view}\"]"));
        let stderr = failure(&coatlab(&["batch", "plan", s(&bad)]), exit::DATA);
        assert!(
            stderr.contains("key `views`") && stderr.contains(expected),
            "{stderr}"
        );
    }
    let twice = self::manifest(&dir, r#"views = ["turntable:3", "turntable:3:1"]"#);
    let stderr = failure(&coatlab(&["batch", "plan", s(&twice)]), exit::DATA);
    assert!(
        stderr.contains("'turntable:3:1' is there twice"),
        "{stderr}"
    );

    if !have_chromium() {
        return;
    }
    let url = format!("file://{}", s(&dir.join("deck/index.html")));
    let dom = chromium(&["--virtual-time-budget=5000", "--dump-dom", &url]);
    let dom = String::from_utf8_lossy(&dom.stdout);
    assert!(
        dom.contains(r#"id="image-check" data-loaded="16" data-total="16""#),
        "every image loads"
    );
    assert_eq!(
        dom.matches(r#"data-frames="3" data-in-row="true""#).count(),
        4,
        "each strip's three frames stand in one row"
    );
    let shot = dir.join("deck.png");
    let _ = std::fs::remove_file(&shot);
    chromium(&[
        "--window-size=1200,1600",
        &format!("--screenshot={}", s(&shot)),
        &url,
    ]);
    assert!(shot.is_file(), "a screenshot of the deck");
}
