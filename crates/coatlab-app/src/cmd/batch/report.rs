//! `coatlab batch report`: the review deck, one HTML page in the output folder
//! (`index.html`) with, per design, its renders by view and lighting, the
//! multi-angle and gloss readings, ΔE00 to the manifest's target per angle with
//! pass or fail, and swatches under D65, A and F11; a summary table sortable by
//! ΔE00. Tasks not rendered yet are shown as missing.
//!
//! The page refers to the renders by their file names, relatively: it lives in
//! the folder beside them, so the folder is the deck (copy or serve it whole),
//! and a deck of hundreds of final renders stays a page of kilobytes instead of
//! hundreds of megabytes of base64. Nothing is loaded from the network: the
//! style and the sorting script are inline, the swatches are CSS colours.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;
use coatlab_core::analysis::{
    SWATCH_ASPECULAR_DEG, Swatch, design_swatch_reflectance, standard_swatch_reflectance,
    swatches as swatches_of,
};
use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::colour::tolerance::{Formula, Tolerance};
use coatlab_core::design::PaintDesign;
use coatlab_core::instruments::{self, Measurement};
use coatlab_core::io::atomic::write_bytes_atomically;
use coatlab_core::measurement::{self, Standard};
use coatlab_core::paint::model::PaintModel;
use coatlab_core::target::{Comparison, compare_designs, compare_to_standard};

use super::manifest::{DesignEntry, ImageFormat, Manifest, Task, view_frames};
use super::task::{State, create_output_folder, state};
use crate::cmd::failure::{Classify, Failure};

/// The deck's file name in the output folder.
pub const DECK_FILE: &str = "index.html";

/// What was written.
#[derive(Debug, Clone, PartialEq)]
pub struct DeckSummary {
    pub path: PathBuf,
    pub tasks: usize,
    pub done: usize,
    pub out_of_date: usize,
    pub missing: usize,
    /// Designs that pass and fail at every compared angle (0, 0 without a target).
    pub pass: usize,
    pub fail: usize,
}

/// The manifest's target, loaded once.
enum Target {
    Design {
        name: String,
        readings: Measurement,
    },
    Measured {
        file: String,
        readings: measurement::Measurement,
    },
}

/// One design's part of the deck.
struct DesignPage<'a> {
    entry: &'a DesignEntry,
    design: PaintDesign,
    readings: Measurement,
    /// Under D65, A and F11, with the target's half when the target has a
    /// spectrum at the swatches' angle.
    swatches: Vec<Swatch>,
    /// The comparison, and the name of what it was compared with.
    comparison: Option<(String, Comparison)>,
}

fn load_design(entry: &DesignEntry) -> anyhow::Result<(PaintDesign, PaintModel, Measurement)> {
    let design = PaintDesign::load(&entry.path)?;
    let model = design
        .model(WavelengthGrid::reference())
        .with_context(|| format!("cannot build the paint model of {}", entry.path.display()))
        .or_fail(Failure::Data)?;
    let readings = instruments::measure(&model).or_fail(Failure::Internal)?;
    Ok((design, model, readings))
}

fn load_target(path: &Path) -> anyhow::Result<Target> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path)
        .with_context(|| format!("target: cannot read {file}"))
        .or_fail(Failure::NoInput)?;
    if measurement::sniff(&bytes).is_some() {
        let readings = measurement::read(&bytes, &file).or_fail(Failure::Data)?;
        return Ok(Target::Measured { file, readings });
    }
    let design = PaintDesign::load(path).with_context(|| {
        format!("target {file}: neither a measurement file (CGATS, CxF3) nor a design")
    })?;
    let model = design
        .model(WavelengthGrid::reference())
        .with_context(|| format!("cannot build the paint model of the target {file}"))
        .or_fail(Failure::Data)?;
    Ok(Target::Design {
        name: design.name,
        readings: instruments::measure(&model).or_fail(Failure::Internal)?,
    })
}

/// The standard of a measurement file a design is compared with: `target_sample`
/// if the manifest gives one; else the file's only standard; else the one named
/// like the design (a lab file often holds the standards of a whole review).
fn standard_for<'a>(
    readings: &'a measurement::Measurement,
    file: &str,
    sample: Option<&str>,
    design_name: &str,
) -> anyhow::Result<Standard<'a>> {
    if let Some(key) = sample {
        return readings
            .select(Some(key))
            .with_context(|| format!("target {file}: target_sample"))
            .or_fail(Failure::Data);
    }
    let standards = readings.standards();
    if standards.len() == 1 {
        return Ok(standards[0].clone());
    }
    let names: Vec<&str> = standards.iter().map(|s| s.name).collect();
    standards
        .into_iter()
        .find(|s| s.name.eq_ignore_ascii_case(design_name))
        .ok_or_else(|| {
            Failure::Data.error(format!(
                "target {file} has {} standards ({}) and none is named {design_name:?}: choose \
                 one with target_sample in the manifest",
                names.len(),
                names.join(", ")
            ))
        })
}

fn design_page<'a>(
    manifest: &Manifest,
    entry: &'a DesignEntry,
    target: Option<&Target>,
) -> anyhow::Result<DesignPage<'a>> {
    let (design, model, readings) = load_design(entry)?;
    let tolerance = &manifest.tolerance;
    let mut target_factor: Option<Vec<f64>> = None;
    let comparison = match target {
        None => None,
        Some(Target::Design {
            name,
            readings: target,
        }) => {
            target_factor = design_swatch_reflectance(target).map(<[f64]>::to_vec);
            Some((
                name.clone(),
                compare_designs(&readings, target, tolerance).or_fail(Failure::Internal)?,
            ))
        }
        Some(Target::Measured { file, readings: m }) => {
            let standard = standard_for(m, file, manifest.target_sample.as_deref(), &design.name)?;
            target_factor = standard_swatch_reflectance(&standard, &readings.wavelength_nm);
            let c = compare_to_standard(&model, &readings, &standard, tolerance)
                .with_context(|| format!("{file}: cannot compare with {:?}", standard.name))
                .or_fail(Failure::Data)?;
            Some((standard.name.to_owned(), c))
        }
    };
    let swatches = swatches_of(&readings, target_factor.as_deref());
    Ok(DesignPage {
        entry,
        design,
        readings,
        swatches,
        comparison,
    })
}

/// Writes the deck of `manifest` into its output folder.
pub fn write_deck(manifest: &Manifest) -> anyhow::Result<DeckSummary> {
    let target = manifest.target.as_deref().map(load_target).transpose()?;
    let tasks = manifest.tasks();
    let mut states = Vec::with_capacity(tasks.len());
    for task in &tasks {
        states.push(
            state(manifest, task)
                .with_context(|| format!("task {} ({})", task.index, task.output))?,
        );
    }
    let pages = manifest
        .designs
        .iter()
        .map(|entry| design_page(manifest, entry, target.as_ref()))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let html = deck_html(manifest, target.as_ref(), &tasks, &states, &pages);
    create_output_folder(manifest)?;
    let path = manifest.output.join(DECK_FILE);
    write_bytes_atomically(&path, html.as_bytes()).or_fail(Failure::CantCreate)?;
    let count = |f: fn(&State) -> bool| states.iter().filter(|s| f(s)).count();
    let verdicts: Vec<Option<bool>> = pages
        .iter()
        .map(|p| p.comparison.as_ref().and_then(|(_, c)| c.pass))
        .collect();
    Ok(DeckSummary {
        path,
        tasks: tasks.len(),
        done: count(|s| matches!(s, State::Done(_))),
        out_of_date: count(|s| matches!(s, State::OutOfDate(_))),
        missing: count(|s| matches!(s, State::Missing)),
        pass: verdicts.iter().filter(|v| **v == Some(true)).count(),
        fail: verdicts.iter().filter(|v| **v == Some(false)).count(),
    })
}

/// `text` safe inside HTML text and double-quoted attributes.
fn esc(text: &str) -> String {
    coatlab_core::io::markup::escape(text)
}

fn anchor(entry: &DesignEntry) -> String {
    format!("design-{}", entry.slug)
}

fn verdict(pass: Option<bool>) -> &'static str {
    match pass {
        Some(true) => r#"<span class="pass">pass</span>"#,
        Some(false) => r#"<span class="fail">fail</span>"#,
        None => r#"<span class="none">not compared</span>"#,
    }
}

fn tolerance_text(t: &Tolerance) -> String {
    let mut text = format!("{} ≤ {}", t.formula, t.default_limit);
    for (angle, limit) in &t.per_angle {
        let _ = write!(text, ", {limit} at {angle}°");
    }
    text
}

/// The geometries compared, in the order they first appear over the designs
/// (the summary's columns).
fn geometry_columns(pages: &[DesignPage<'_>]) -> Vec<String> {
    let mut columns: Vec<String> = Vec::new();
    for page in pages {
        if let Some((_, c)) = &page.comparison {
            for a in &c.angles {
                let name = a.geometry.to_string();
                if !columns.contains(&name) {
                    columns.push(name);
                }
            }
        }
    }
    columns
}

const STYLE: &str = r#"
body { font-family: system-ui, sans-serif; margin: 1.5em; color: #222; background: #fafafa; }
h1 { margin-bottom: 0.2em; }
table { border-collapse: collapse; margin: 0.5em 0 1em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th { background: #eee; }
td.name, th.name { text-align: left; }
th[data-sort] { cursor: pointer; }
th[data-sort]::after { content: " ⇅"; color: #999; }
.pass { color: #fff; background: #2a7d2e; padding: 0 0.4em; border-radius: 3px; }
.fail { color: #fff; background: #b3261e; padding: 0 0.4em; border-radius: 3px; }
.none, .stale { color: #fff; background: #777; padding: 0 0.4em; border-radius: 3px; }
section.design { border-top: 2px solid #bbb; margin-top: 1.5em; }
table.renders td { vertical-align: top; text-align: center; }
figure { margin: 0; }
figure img { max-width: 320px; display: block; background: #000; }
.strip { display: flex; gap: 2px; overflow-x: auto; max-width: 60vw; }
.strip figure img { max-width: 160px; }
.strip figcaption { font-size: 70%; }
figcaption { font-size: 0.8em; color: #555; }
.missing { width: 320px; height: 120px; display: flex; align-items: center;
  justify-content: center; background: repeating-linear-gradient(45deg, #eee, #eee 8px, #ddd 8px, #ddd 16px);
  color: #900; font-weight: bold; }
.swatches { display: flex; gap: 1em; }
.swatch { width: 9em; text-align: center; font-size: 0.85em; }
.chip { display: flex; height: 5em; border: 1px solid #888; }
.chip div { flex: 1; }
.notes { color: #555; font-size: 0.9em; }
"#;

/// Sorting (click a column of the summary; the design sections follow the
/// table's order) and the image check the deck's test reads: every image's
/// naturalWidth, recorded into the page once it has loaded.
const SCRIPT: &str = r#"
(function () {
  var table = document.getElementById("summary");
  var designs = document.getElementById("designs");
  table.querySelectorAll("th[data-sort]").forEach(function (th, column) {
    var index = Array.prototype.indexOf.call(th.parentNode.children, th);
    th.addEventListener("click", function () {
      var ascending = th.dataset.order !== "ascending";
      th.dataset.order = ascending ? "ascending" : "descending";
      var body = table.tBodies[0];
      var rows = Array.prototype.slice.call(body.rows);
      var key = function (row) {
        var cell = row.cells[index];
        if (th.dataset.sort === "text") { return cell.textContent; }
        var v = parseFloat(cell.dataset.value);
        return isNaN(v) ? Infinity : v;
      };
      rows.sort(function (a, b) {
        var x = key(a), y = key(b);
        var c = x < y ? -1 : x > y ? 1 : 0;
        if (x === Infinity || y === Infinity) { return c; }
        return ascending ? c : -c;
      });
      rows.forEach(function (row) {
        body.appendChild(row);
        var section = document.getElementById(row.dataset.section);
        if (section) { designs.appendChild(section); }
      });
      table.dataset.sortedBy = th.dataset.key + (ascending ? "" : " descending");
    });
  });
  // index.html?sort=KEY sorts by a column on opening (?sort=-KEY: descending),
  // so a link can hand a reviewer the deck sorted by ΔE00.
  var wanted = new URLSearchParams(window.location.search).get("sort");
  if (wanted) {
    var descending = wanted.charAt(0) === "-";
    var th = table.querySelector('th[data-key="' + wanted.replace(/^-/, "") + '"]');
    if (th) {
      th.click();
      if (descending) { th.click(); }
    }
  }
  window.addEventListener("load", function () {
    var images = Array.prototype.slice.call(document.images);
    var loaded = 0;
    images.forEach(function (img) {
      img.dataset.naturalWidth = String(img.naturalWidth);
      if (img.complete && img.naturalWidth > 0) { loaded += 1; }
    });
    var check = document.getElementById("image-check");
    check.textContent = "images loaded: " + loaded + " of " + images.length;
    check.dataset.loaded = String(loaded);
    check.dataset.total = String(images.length);
    // A turntable's frames stand in one row, left to right in the order of the turn.
    document.querySelectorAll(".strip").forEach(function (strip) {
      var boxes = Array.prototype.map.call(strip.querySelectorAll("figure"), function (f) {
        return f.getBoundingClientRect();
      });
      var inRow = boxes.every(function (b, i) {
        return i === 0 || (b.top === boxes[0].top && b.left > boxes[i - 1].left);
      });
      strip.dataset.frames = String(boxes.length);
      strip.dataset.inRow = String(inRow);
    });
  });
})();
"#;

fn deck_html(
    manifest: &Manifest,
    target: Option<&Target>,
    tasks: &[Task],
    states: &[State],
    pages: &[DesignPage<'_>],
) -> String {
    let mut h = String::new();
    let manifest_name = manifest
        .path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let done = states
        .iter()
        .filter(|s| matches!(s, State::Done(_)))
        .count();
    let stale = states
        .iter()
        .filter(|s| matches!(s, State::OutOfDate(_)))
        .count();
    let missing = states.len() - done - stale;
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <title>Review deck: {}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n\
         <h1>Review deck: {}</h1>\n",
        esc(&manifest_name),
        esc(&manifest_name),
    );
    let _ = writeln!(
        h,
        "<p>{} designs × {} views × {} lighting × {} models; quality {} ({} spp, {} \
         wavelengths), {}×{}, seed {}; {}.</p>",
        manifest.designs.len(),
        manifest.views.len(),
        manifest.lighting.len(),
        manifest.models.len(),
        esc(&manifest.quality.label),
        manifest.quality.samples_per_pixel,
        manifest.quality.wavelengths,
        manifest.size.0,
        manifest.size.1,
        manifest.seed,
        esc(&crate::cmd::render::program()),
    );
    let _ = writeln!(
        h,
        "<p id=\"tasks\" data-done=\"{done}\" data-missing=\"{missing}\" data-out-of-date=\"{stale}\">\
         {} tasks: {done} rendered, {missing} missing, {stale} out of date.</p>",
        tasks.len()
    );
    match target {
        None => {
            let _ = writeln!(
                h,
                "<p>No target in the manifest: readings only, nothing compared.</p>"
            );
        }
        Some(t) => {
            let (kind, name) = match t {
                Target::Design { name, .. } => ("design", name.clone()),
                Target::Measured { file, .. } => ("measurement file", file.clone()),
            };
            let file = manifest
                .target
                .as_ref()
                .map(|p| p.display().to_string())
                .unwrap_or_default();
            let _ = writeln!(
                h,
                "<p>Target: {kind} {} ({}). Tolerance: {}; differences are design − target, \
                 CIELAB D65/10° unless a reading says otherwise.</p>",
                esc(&name),
                esc(&file),
                esc(&tolerance_text(&manifest.tolerance)),
            );
        }
    }
    summary_table(&mut h, manifest, tasks, states, pages);
    h.push_str("<div id=\"designs\">\n");
    for page in pages {
        design_section(&mut h, manifest, tasks, states, page);
    }
    h.push_str("</div>\n<p id=\"image-check\">images: not checked (scripts are off)</p>\n");
    let _ = write!(h, "<script>{SCRIPT}</script>\n</body>\n</html>\n");
    h
}

fn summary_table(
    h: &mut String,
    manifest: &Manifest,
    tasks: &[Task],
    states: &[State],
    pages: &[DesignPage<'_>],
) {
    let columns = geometry_columns(pages);
    h.push_str("<h2>Summary</h2>\n<table id=\"summary\">\n<thead><tr>");
    h.push_str("<th class=\"name\" data-sort=\"text\" data-key=\"design\">Design</th>");
    h.push_str("<th data-sort=\"number\" data-key=\"max\">max ΔE00</th>");
    for c in &columns {
        // The key: the geometry's digits and signs, e.g. 45as-15 for 45°as-15°.
        let key: String = c
            .chars()
            .filter(|ch| ch.is_ascii_alphanumeric() || *ch == '-')
            .collect();
        let _ = write!(
            h,
            "<th data-sort=\"number\" data-key=\"{}\">ΔE00 {}</th>",
            esc(&key),
            esc(c)
        );
    }
    let _ = write!(
        h,
        "<th>Result ({})</th><th>Renders</th></tr></thead>\n<tbody>\n",
        esc(&manifest.tolerance.formula.to_string())
    );
    for page in pages {
        let _ = write!(
            h,
            "<tr data-section=\"{}\"><td class=\"name\"><a href=\"#{}\">{}</a></td>",
            anchor(page.entry),
            anchor(page.entry),
            esc(&page.design.name)
        );
        let comparison = page.comparison.as_ref().map(|(_, c)| c);
        let max = comparison.and_then(|c| {
            c.angles
                .iter()
                .map(|a| a.difference.de00)
                .max_by(f64::total_cmp)
        });
        number_cell(h, max);
        for column in &columns {
            let de = comparison.and_then(|c| {
                c.angles
                    .iter()
                    .find(|a| &a.geometry.to_string() == column)
                    .map(|a| a.difference.de00)
            });
            number_cell(h, de);
        }
        let mine: Vec<&State> = tasks
            .iter()
            .zip(states)
            .filter(|(t, _)| t.design.slug == page.entry.slug)
            .map(|(_, s)| s)
            .collect();
        let done = mine.iter().filter(|s| matches!(s, State::Done(_))).count();
        let _ = writeln!(
            h,
            "<td class=\"name\">{}</td><td>{done} of {}</td></tr>",
            verdict(comparison.and_then(|c| c.pass)),
            mine.len()
        );
    }
    h.push_str("</tbody>\n</table>\n");
}

fn number_cell(h: &mut String, value: Option<f64>) {
    match value {
        Some(v) => {
            let _ = write!(h, "<td data-value=\"{v}\">{v:.2}</td>");
        }
        None => h.push_str("<td data-value=\"\">—</td>"),
    }
}

fn design_section(
    h: &mut String,
    manifest: &Manifest,
    tasks: &[Task],
    states: &[State],
    page: &DesignPage<'_>,
) {
    let comparison = page.comparison.as_ref();
    let _ = writeln!(
        h,
        "<section class=\"design\" id=\"{}\">\n<h2>{} {}</h2>\n<p class=\"notes\">{}</p>",
        anchor(page.entry),
        esc(&page.design.name),
        verdict(comparison.and_then(|(_, c)| c.pass)),
        esc(&page.entry.path.display().to_string()),
    );
    renders(h, manifest, tasks, states, page);
    swatches(h, page);
    angle_table(h, manifest, page);
    gloss_table(h, page);
    h.push_str("</section>\n");
}

fn renders(
    h: &mut String,
    manifest: &Manifest,
    tasks: &[Task],
    states: &[State],
    page: &DesignPage<'_>,
) {
    h.push_str("<h3>Renders</h3>\n");
    for (model, _) in &manifest.models {
        if manifest.models.len() > 1 {
            let _ = writeln!(h, "<h4>Model: {}</h4>", esc(model));
        }
        h.push_str("<table class=\"renders\"><thead><tr><th>view</th>");
        for lighting in &manifest.lighting {
            let _ = write!(h, "<th>{}</th>", esc(&lighting.slug));
        }
        h.push_str("</tr></thead><tbody>\n");
        for view in &manifest.views {
            let _ = write!(h, "<tr><th>{}</th>", esc(view));
            let frames = view_frames(view);
            for lighting in &manifest.lighting {
                let found = |frame: &String| {
                    tasks.iter().zip(states).find(|(t, _)| {
                        t.design.slug == page.entry.slug
                            && &t.view == frame
                            && t.lighting.slug == lighting.slug
                            && &t.model == model
                    })
                };
                h.push_str("<td>");
                if let [single] = &frames[..] {
                    if let Some((task, state)) = found(single) {
                        render_cell(h, manifest, task, state, SINGLE_WIDTH);
                    }
                } else {
                    // A turntable: its frames side by side in the order of the turn.
                    let _ = write!(h, "<div class=\"strip\" data-view=\"{}\">", esc(view));
                    for (task, state) in frames.iter().filter_map(found) {
                        render_cell(h, manifest, task, state, STRIP_WIDTH);
                    }
                    h.push_str("</div>");
                }
                h.push_str("</td>");
            }
            h.push_str("</tr>\n");
        }
        h.push_str("</tbody></table>\n");
    }
}

/// The widest a render is shown in the deck, CSS pixels: alone, and as one frame
/// of a turntable's strip.
const SINGLE_WIDTH: u32 = 320;
const STRIP_WIDTH: u32 = 160;

fn render_cell(h: &mut String, manifest: &Manifest, task: &Task, state: &State, widest: u32) {
    let sidecar = match state {
        State::Missing => {
            let _ = write!(
                h,
                "<div class=\"missing\" data-task=\"{}\">missing: task {} not rendered</div>\
                 <div class=\"notes\">{}</div>",
                task.index,
                task.index,
                esc(&task.output)
            );
            return;
        }
        State::Done(s) | State::OutOfDate(s) => s,
    };
    let file = esc(&task.output);
    h.push_str("<figure>");
    match manifest.image {
        // Output names are letters, digits, '-', '_' and '.', safe in a URL.
        ImageFormat::Png => {
            let _ = write!(
                h,
                "<a href=\"{file}\"><img src=\"{file}\" alt=\"{file}\" width=\"{}\" height=\"{}\"></a>",
                manifest.size.0.min(widest),
                (u64::from(manifest.size.1) * u64::from(manifest.size.0.min(widest))
                    / u64::from(manifest.size.0.max(1))),
            );
        }
        // Browsers do not show OpenEXR: the deck links it.
        ImageFormat::Exr => {
            let _ = write!(
                h,
                "<div class=\"missing\"><a href=\"{file}\">{file}</a> (EXR: open it in an EXR \
                 viewer)</div>"
            );
        }
    }
    let number = |key: &str| sidecar.get(key).and_then(|v| v.as_f64());
    let mut caption = format!("task {}", task.index);
    if let Some(spp) = number("samples_per_pixel") {
        let _ = write!(caption, " · {spp} spp");
    }
    if let Some(noise) = sidecar
        .get("noise_delta_e00")
        .and_then(|n| n.get("mean"))
        .and_then(|v| v.as_f64())
    {
        let _ = write!(caption, " · noise ΔE00 {noise:.2}");
    }
    if let Some(seconds) = number("seconds") {
        let _ = write!(caption, " · {seconds:.1} s");
    }
    let _ = write!(h, "<figcaption>{}", esc(&caption));
    if matches!(state, State::OutOfDate(_)) {
        h.push_str(
            " <span class=\"stale\">out of date: its inputs changed since; run the task again</span>",
        );
    }
    h.push_str("</figcaption></figure>");
}

fn rgb(c: [u8; 3]) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

fn swatches(h: &mut String, page: &DesignPage<'_>) {
    let _ = writeln!(
        h,
        "<h3>Swatches</h3>\n<p class=\"notes\">At {}° aspecular, shown adapted to D65{}.</p>\n\
         <div class=\"swatches\">",
        SWATCH_ASPECULAR_DEG,
        if page.swatches.iter().any(|s| s.target_srgb.is_some()) {
            "; left the design, right the target"
        } else {
            ""
        }
    );
    for s in &page.swatches {
        let _ = write!(
            h,
            "<div class=\"swatch\" data-illuminant=\"{}\"><div class=\"chip\"><div style=\"background:{}\"></div>",
            s.illuminant,
            rgb(s.design_srgb)
        );
        if let Some(t) = s.target_srgb {
            let _ = write!(h, "<div style=\"background:{}\"></div>", rgb(t));
        }
        let _ = write!(h, "</div>{}", s.illuminant);
        if let Some(de) = s.delta_e {
            let _ = write!(h, " · ΔE00 {de:.2}");
        }
        h.push_str("</div>\n");
    }
    h.push_str("</div>\n");
}

fn lab_cells(h: &mut String, l: f64, a: f64, b: f64) {
    let _ = write!(h, "<td>{l:.2}</td><td>{a:.2}</td><td>{b:.2}</td>");
}

fn angle_table(h: &mut String, manifest: &Manifest, page: &DesignPage<'_>) {
    h.push_str("<h3>Multi-angle colour</h3>\n");
    let Some((target_name, c)) = &page.comparison else {
        h.push_str(
            "<p class=\"notes\">Illumination 45°, CIELAB D65/10°.</p>\n<table class=\"angles\">\
             <thead><tr><th>aspecular</th><th>L*</th><th>a*</th><th>b*</th></tr></thead><tbody>\n",
        );
        for a in &page.readings.angles {
            let _ = write!(h, "<tr><td>{}°</td>", a.aspecular_deg);
            lab_cells(h, a.lab.l, a.lab.a, a.lab.b);
            h.push_str("</tr>\n");
        }
        h.push_str("</tbody></table>\n");
        return;
    };
    let formula = manifest.tolerance.formula;
    let other = formula != Formula::De00;
    let _ = write!(
        h,
        "<p class=\"notes\">Against {}.</p>\n<table class=\"angles\"><thead><tr>\
         <th>geometry</th><th>L*</th><th>a*</th><th>b*</th><th>target L*</th><th>target a*</th>\
         <th>target b*</th><th>ΔL*</th><th>Δa*</th><th>Δb*</th><th>ΔE00</th>",
        esc(target_name)
    );
    if other {
        let _ = write!(h, "<th>{}</th>", esc(&formula.to_string()));
    }
    h.push_str("<th>limit</th><th>result</th></tr></thead><tbody>\n");
    for a in &c.angles {
        let _ = write!(h, "<tr><td>{}</td>", esc(&a.geometry.to_string()));
        lab_cells(h, a.design_lab.l, a.design_lab.a, a.design_lab.b);
        lab_cells(h, a.target_lab.l, a.target_lab.a, a.target_lab.b);
        lab_cells(h, a.difference.dl, a.difference.da, a.difference.db);
        let _ = write!(
            h,
            "<td class=\"de00\" data-value=\"{}\">{:.2}</td>",
            a.difference.de00, a.difference.de00
        );
        if other {
            let _ = write!(h, "<td>{:.2}</td>", a.value);
        }
        let _ = writeln!(
            h,
            "<td>{}</td><td class=\"name\">{}</td></tr>",
            a.limit,
            verdict(Some(a.pass))
        );
    }
    h.push_str("</tbody></table>\n");
    let mut notes: Vec<String> = c
        .not_comparable
        .iter()
        .map(|n| format!("{}: {}", n.geometry, n.reason))
        .collect();
    notes.extend(c.notes.iter().cloned());
    if c.metameric {
        notes.push(
            "metameric: the pair passes under D65 but a metamerism index under A or F11 is above \
             0.5"
            .to_owned(),
        );
    }
    for note in notes {
        let _ = writeln!(h, "<p class=\"notes\">{}</p>", esc(&note));
    }
}

fn gloss_table(h: &mut String, page: &DesignPage<'_>) {
    h.push_str(
        "<h3>Gloss</h3>\n<table class=\"gloss\"><thead><tr><th>geometry</th>\
         <th>design GU</th><th>specular alone GU</th><th>target GU</th></tr></thead><tbody>\n",
    );
    let targets = page.comparison.as_ref().map(|(_, c)| &c.gloss);
    for g in &page.readings.gloss {
        let angle = f64::from(u32::from(g.geometry));
        let target = targets
            .and_then(|t| t.iter().find(|t| t.angle_deg == angle))
            .map(|t| format!("{:.1}", t.target_gu))
            .unwrap_or_else(|| "—".to_owned());
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{:.1}</td><td>{:.1}</td><td>{target}</td></tr>",
            esc(&g.geometry.to_string()),
            g.total_gu,
            g.specular_gu
        );
    }
    h.push_str("</tbody></table>\n");
}
