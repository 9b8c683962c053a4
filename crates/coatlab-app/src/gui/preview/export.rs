//! Writing the preview's views: the first view as NAME.EXT and, in a comparison,
//! the second as NAME-b.EXT, each as its pane shows it. PNG as shown (the
//! published images' exposure and tone mapping), EXR as linear sRGB: a view's
//! film, or in a shared comparison the pane's blend of both views' films (an
//! unbiased estimate of that view's image, `ShadingDifference::combine`).
//! Runs on the render thread between two passes, with the engine's films.

use std::path::{Path, PathBuf};

use coatlab_core::engine::{EngineEvent, Job, LiveEngine, SecondImage};

use crate::gui::export::preview_record;
use coatlab_core::render::film::{
    DisplaySettings, ExrOutput, Film, RenderRecord, write_xyz_exr, write_xyz_png,
};

/// The export of the views to `path` (PNG or EXR by its extension), as a job
/// for the render thread; it reports what it wrote or why it could not.
pub(super) fn job(path: PathBuf) -> Job<coatlab_core::engine::CpuBackend> {
    Box::new(move |engine| Some(export(engine, &path)))
}

/// What one pane shows: a view's film, or mean XYZ blended from both films.
enum Pane<'a> {
    Film(&'a Film),
    Blended(Vec<[f32; 3]>),
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
    let panes = match panes(engine) {
        Ok(panes) => panes,
        Err(e) => return error(format!("Could not export the preview: {e}")),
    };
    let targets = [path.to_owned(), second_path(path)];
    let mut written = Vec::new();
    for (pane, target) in panes.into_iter().zip(targets) {
        let result = match pane {
            Pane::Film(film) => write_film(
                film,
                &target,
                ext.as_deref(),
                &display,
                &record(engine, None),
            ),
            Pane::Blended(xyz) => {
                let film = first.film();
                let record = record(engine, Some(blended_count(engine)));
                write_blended(film, &xyz, &target, ext.as_deref(), &display, &record)
            }
        };
        match result {
            Ok(()) => written.push(target.display().to_string()),
            Err(e) => return error(format!("Could not export the preview: {e}")),
        }
    }
    EngineEvent::Report {
        text: format!(
            "Exported the preview ({} spp) to {}",
            first.samples_per_pixel(),
            written.join(" and ")
        ),
        is_error: false,
    }
}

/// The panes as they are shown: one film; two films rendered apart; or, in a
/// shared comparison, each view's film blended with the other's.
fn panes(engine: &LiveEngine) -> Result<Vec<Pane<'_>>, String> {
    let first = Pane::Film(engine.first().film());
    Ok(match engine.second_image() {
        SecondImage::None => vec![first],
        SecondImage::Film(film) => vec![first, Pane::Film(film)],
        SecondImage::Reshaded(second) => {
            let second = second.map_err(|e| format!("the second view ({e})"))?;
            let first = engine
                .first_image()
                .map_err(|e| format!("the first view ({e})"))?;
            vec![Pane::Blended(first), Pane::Blended(second.xyz)]
        }
    })
}

/// What a blended pane's EXR says of its samples: both views' films go into it.
fn blended_count(engine: &LiveEngine) -> String {
    format!(
        "{} per view, both views' films blended with the paths they share",
        engine.first().samples_per_pixel()
    )
}

fn error(text: String) -> EngineEvent {
    EngineEvent::Report {
        text,
        is_error: true,
    }
}

/// What an exported EXR's header records beyond what the film knows;
/// `samples`, where the film's count does not say it.
fn record(engine: &LiveEngine, samples: Option<String>) -> RenderRecord {
    RenderRecord {
        samples_per_pixel: samples,
        ..preview_record(
            engine.design(),
            engine.lighting(),
            engine.first().settings().seed,
        )
    }
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
    match ext {
        Some("png") => film.write_png(path, display).map_err(|e| e.to_string()),
        Some("exr") => film
            .write_exr_with(path, &exr_output(record))
            .map_err(|e| e.to_string()),
        _ => Err(unsupported(path)),
    }
}

/// Writes a blended pane's mean XYZ (of `film`'s size and wavelengths) as
/// [`write_film`] writes a film.
fn write_blended(
    film: &Film,
    xyz: &[[f32; 3]],
    path: &Path,
    ext: Option<&str>,
    display: &DisplaySettings,
    record: &RenderRecord,
) -> Result<(), String> {
    let (width, height) = (film.width(), film.height());
    match ext {
        Some("png") => write_xyz_png(path, width, height, xyz, display),
        Some("exr") => write_xyz_exr(
            path,
            width,
            height,
            xyz,
            &exr_output(record),
            film.exr_attributes(record),
        ),
        _ => return Err(unsupported(path)),
    }
    .map_err(|e| e.to_string())
}

fn exr_output(record: &RenderRecord) -> ExrOutput {
    ExrOutput {
        record: record.clone(),
        ..ExrOutput::default()
    }
}

fn unsupported(path: &Path) -> String {
    format!(
        "{}: export as .png (as shown) or .exr (linear sRGB)",
        path.display()
    )
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

#[cfg(test)]
mod tests {
    use std::sync::Arc;
    use std::sync::atomic::AtomicBool;

    use coatlab_core::colour::{Xyz, linear_srgb_from_xyz, srgb_white};
    use coatlab_core::design::presets;
    use coatlab_core::engine::{Command, CpuBackend, Output, QualityKnobs, Views};
    use coatlab_core::io::exr_read::read_exr;
    use coatlab_core::paint::phong::PhongVariant;

    use super::*;

    /// Linear sRGB of a mean XYZ as a film's EXR holds it (D65 white at Y = 1).
    fn linear(v: [f32; 3]) -> [f64; 3] {
        let w = srgb_white();
        let white = Xyz::new(w.x / w.y, 1.0, w.z / w.y);
        let [x, y, z] = v.map(f64::from);
        let rgb = linear_srgb_from_xyz(Xyz::new(x, y, z), white);
        [rgb.red, rgb.green, rgb.blue]
    }

    /// The EXR at `path` holds `xyz` in linear sRGB, to f32 rounding.
    fn assert_holds(path: &Path, xyz: &[[f32; 3]]) {
        let image = read_exr(path).expect("the export reads back");
        assert_eq!(image.pixels().len(), xyz.len());
        for (i, (got, want)) in image.pixels().iter().zip(xyz).enumerate() {
            let want = linear(*want);
            for c in 0..3 {
                let tolerance = 1e-5 * (1.0 + want[c].abs());
                assert!(
                    (f64::from(got[c]) - want[c]).abs() <= tolerance,
                    "{}: pixel {i} channel {c}: {} in the file, {} shown",
                    path.display(),
                    got[c],
                    want[c]
                );
            }
        }
    }

    /// In a shared comparison each exported EXR is its pane as shown: the
    /// blend of both views' films, not the first view's film alone (which the
    /// first pane's export used to be).
    #[test]
    fn a_shared_comparisons_panes_export_as_they_are_shown() {
        let design = presets::all().swap_remove(0).design;
        let mut engine =
            LiveEngine::new(CpuBackend::default(), design, Arc::new(|| {})).expect("engine");
        let commands = [
            Command::Size(40, 28),
            Command::Quality(QualityKnobs {
                wavelengths: 8,
                max_spp: 4,
                resolution_divisor: 1,
            }),
            Command::Views(Views::models(PhongVariant::Naive)),
        ];
        let mut ignore = |_: Output| {};
        for command in commands {
            engine.apply(command, &mut ignore);
        }
        let never = AtomicBool::new(false);
        for _ in 0..200 {
            if engine.is_idle() {
                break;
            }
            engine.step(&never, &mut ignore);
        }
        assert!(engine.is_idle(), "the comparison converges to 4 spp");
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("pair.exr");
        let report = export(&engine, &path);
        assert!(
            matches!(
                &report,
                EngineEvent::Report {
                    is_error: false,
                    ..
                }
            ),
            "{report:?}"
        );
        let shown_first = engine.first_image().expect("the first pane");
        let SecondImage::Reshaded(Ok(shown_second)) = engine.second_image() else {
            panic!("the comparison is shared");
        };
        assert_holds(&path, &shown_first);
        assert_holds(&second_path(&path), &shown_second.xyz);
        // The first pane is not its film alone.
        let film = engine.first().film();
        let own: Vec<[f32; 3]> = (0..film.height())
            .flat_map(|y| (0..film.width()).map(move |x| (x, y)))
            .map(|(x, y)| {
                let m = film.mean_xyz(x, y);
                [m.x as f32, m.y as f32, m.z as f32]
            })
            .collect();
        let differing = own
            .iter()
            .zip(&shown_first)
            .filter(|(a, b)| (a[1] - b[1]).abs() > 1e-4 * (1.0 + a[1].abs()))
            .count();
        assert!(
            differing * 10 > own.len(),
            "only {differing} of {} pixels blended",
            own.len()
        );
    }
}
