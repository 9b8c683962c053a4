//! Writing the preview's views: the first view as NAME.EXT and, in a comparison,
//! the second as NAME-b.EXT. PNG as shown (the published images' exposure and
//! tone mapping), EXR as linear sRGB. Runs on the render thread between two
//! passes, with the engine's films.

use std::path::{Path, PathBuf};

use coatlab_core::engine::{EngineEvent, Job, LiveEngine, SecondImage};
use coatlab_core::render::film::{DisplaySettings, Film, display_xyz};

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
    for (film, target) in targets {
        match write_film(film, &target, ext.as_deref(), &display) {
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
                let pixels = display_xyz(&image.xyz, &display);
                match write_png_rgb(&target, image.width, image.height, &pixels) {
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

/// Writes `film` to `path`: PNG as shown with `display`, EXR linear.
fn write_film(
    film: &Film,
    path: &Path,
    ext: Option<&str>,
    display: &DisplaySettings,
) -> Result<(), String> {
    match ext {
        Some("png") => film.write_png(path, display).map_err(|e| e.to_string()),
        Some("exr") => film.write_exr(path).map_err(|e| e.to_string()),
        _ => Err(format!(
            "{}: export as .png (as shown) or .exr (linear sRGB)",
            path.display()
        )),
    }
}

/// Writes 8-bit sRGB `pixels` (RGBA, alpha ignored) as a PNG at `path`, through a
/// temporary file beside it so a failure leaves no half-written file.
fn write_png_rgb(path: &Path, width: u32, height: u32, pixels: &[[u8; 4]]) -> Result<(), String> {
    let rgb: Vec<u8> = pixels.iter().flat_map(|&[r, g, b, _]| [r, g, b]).collect();
    let mut encoded = Vec::new();
    let mut encoder = png::Encoder::new(&mut encoded, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder
        .write_header()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    writer
        .write_image_data(&rgb)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    writer
        .finish()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let temporary = path.with_extension("png.partial");
    std::fs::write(&temporary, &encoded)
        .and_then(|()| std::fs::rename(&temporary, path))
        .map_err(|e| {
            let _ = std::fs::remove_file(&temporary);
            format!("{}: {e}", path.display())
        })
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
