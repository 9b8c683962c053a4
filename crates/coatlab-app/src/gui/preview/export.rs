//! Writing the preview's views: the first view as NAME.EXT and, in a comparison,
//! the second as NAME-b.EXT. PNG as shown (the published images' exposure and
//! tone mapping), EXR as linear sRGB. Runs on the render thread between two
//! passes, with the engine's films.

use std::path::{Path, PathBuf};

use coatlab_core::engine::{EngineEvent, Job, LiveEngine, SecondImage};

use crate::gui::export::preview_record;
use coatlab_core::render::film::{DisplaySettings, ExrOutput, Film, RenderRecord, write_xyz_png};

/// The export of the views to `path` (PNG or EXR by its extension), as a job
/// for the render thread; it reports what it wrote or why it could not.
pub(super) fn job(path: PathBuf) -> Job<coatlab_core::engine::CpuBackend> {
    Box::new(move |engine| Some(export(engine, &path)))
}

fn export(engine: &LiveEngine, path: &Path) -> EngineEvent {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let display = engine.display();
    let first = engine.first();
    if first.samples_per_pixel() == 0 {
        return error("Nothing to export yet: the preview has no samples.".into());
    }
    let mut written = Vec::new();
    let second = engine.second_image();
    let mut targets = vec![(first.film(), path.to_owned())];
    if let SecondImage::Film(film) = &second {
        targets.push((film, second_path(path)));
    }
    let record = record(engine);
    for (film, target) in targets {
        match write_film(film, &target, ext.as_deref(), &display, &record) {
            Ok(()) => written.push(target.display().to_string()),
            Err(e) => return error(format!("Could not export the preview: {e}")),
        }
    }
    let mut note = String::new();
    if let SecondImage::Reshaded(image) = second {
        // The second view has no film of its own: its re-shaded image, as shown.
        let target = second_path(path);
        match (ext.as_deref(), image) {
            (Some("png"), Ok(image)) => {
                match write_xyz_png(&target, image.width, image.height, &image.xyz, &display) {
                    Ok(()) => written.push(target.display().to_string()),
                    Err(e) => return error(format!("Could not export the second view: {e}")),
                }
            }
            (_, Ok(_)) => {
                note = "; the second view is re-shaded from the first view's samples \
                        and is exported as .png only"
                    .to_owned();
            }
            (_, Err(e)) => note = format!("; the second view could not be re-shaded ({e})"),
        }
    }
    EngineEvent::Report {
        text: format!(
            "Exported the preview ({} spp) to {}{note}",
            first.samples_per_pixel(),
            written.join(" and ")
        ),
        is_error: false,
    }
}

fn error(text: String) -> EngineEvent {
    EngineEvent::Report {
        text,
        is_error: true,
    }
}

/// What an exported EXR's header records beyond what the film knows.
fn record(engine: &LiveEngine) -> RenderRecord {
    preview_record(
        engine.design(),
        engine.lighting(),
        engine.first().settings().seed,
    )
}

/// Writes `film` to `path`: PNG as shown with `display`, EXR linear with `record`
/// in its header.
fn write_film(
    film: &Film,
    path: &Path,
    ext: Option<&str>,
    display: &DisplaySettings,
    record: &RenderRecord,
) -> Result<(), String> {
    let output = ExrOutput {
        record: record.clone(),
        ..ExrOutput::default()
    };
    match ext {
        Some("png") => film.write_png(path, display).map_err(|e| e.to_string()),
        Some("exr") => film
            .write_exr_with(path, &output)
            .map_err(|e| e.to_string()),
        _ => Err(format!(
            "{}: export as .png (as shown) or .exr (linear sRGB)",
            path.display()
        )),
    }
}

/// Where the second view of a comparison is exported: NAME-b.EXT beside NAME.EXT.
pub fn second_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = match path.extension() {
        Some(ext) => format!("{stem}-b.{}", ext.to_string_lossy()),
        None => format!("{stem}-b"),
    };
    path.with_file_name(name)
}
