//! Running one task of a manifest: skip it when its output is up to date, else
//! render it and write the image and its JSON sidecar, each atomically.
//!
//! Up to date means: the image and its sidecar exist, the sidecar's
//! `inputs_sha256` is the hash of this task's inputs now (the design, the
//! scene, the lighting, the settings and the program version), and its
//! `image_sha256` is the image's. The sidecar is written after the image, so a
//! task killed between the two is rendered again; a seed gives the same image,
//! so the retry writes the same file.

use std::path::{Path, PathBuf};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use anyhow::Context;
use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::design::PaintDesign;
use coatlab_core::instruments::measure;
use coatlab_core::io::atomic::write_bytes_atomically;
use coatlab_core::render::adaptive::AdaptiveSampling;
use coatlab_core::render::film::part::{Identity, sha256_hex};
use coatlab_core::render::film::{Exposure, RenderRecord, ToneMapping};
use serde::Serialize;

use super::manifest::{Manifest, Task};
use crate::cmd::failure::{Classify, Failure};
use crate::cmd::render::{ImageOutput, RenderArgs, render_film, render_inputs};

/// The `format` of every sidecar.
pub const SIDECAR_FORMAT: &str = "coatlab-batch-output";
/// The sidecar version this program writes.
pub const SIDECAR_VERSION: u32 = 1;

/// What running a task did.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// The output was up to date.
    Skipped,
    /// Rendered, in this many seconds (set-up, render and writing).
    Rendered { seconds: f64 },
}

/// The sidecar of an output (`IMAGE.json`): see `docs/batch.md`.
#[derive(Debug, Serialize)]
pub struct Sidecar {
    pub format: &'static str,
    pub version: u32,
    pub manifest: String,
    pub task: usize,
    pub image: String,
    pub image_sha256: String,
    /// SHA-256 of the inputs' hashes, the view and the program: what decides
    /// whether the output is up to date.
    pub inputs_sha256: String,
    pub program: String,
    pub inputs: SidecarInputs,
    pub settings: SidecarSettings,
    pub seed: u64,
    pub samples_per_pixel: u32,
    /// The noise left in the image as displayed (ΔE00 over every fourth pixel).
    pub noise_delta_e00: Option<NoiseFigures>,
    /// Wall time of the task: loading, building, rendering and writing, s.
    pub seconds: f64,
    /// When the task finished, seconds since 1970 (UTC).
    pub finished_unix_s: u64,
    /// The design's instrument readings (what `coatlab measure --json` prints
    /// as `measurement`).
    pub readings: serde_json::Value,
}

#[derive(Debug, Serialize)]
pub struct SidecarInputs {
    pub design: Identity,
    pub design_file: String,
    pub scene: Identity,
    pub lighting: Identity,
    pub settings: Identity,
}

#[derive(Debug, Serialize)]
pub struct SidecarSettings {
    pub view: String,
    pub lighting: String,
    pub model: String,
    pub quality: String,
    pub size: String,
    pub wavelengths: usize,
    pub exposure_stops: f32,
}

#[derive(Debug, Serialize)]
pub struct NoiseFigures {
    pub mean: f64,
    pub p95: f64,
}

/// The image of `task`.
pub fn image_path(manifest: &Manifest, task: &Task) -> PathBuf {
    manifest.output.join(&task.output)
}

/// The sidecar of `image`.
pub fn sidecar_path(image: &Path) -> PathBuf {
    let mut name = image.as_os_str().to_owned();
    name.push(".json");
    PathBuf::from(name)
}

/// What `coatlab render` would be given for `task`.
pub fn render_args(manifest: &Manifest, task: &Task) -> RenderArgs {
    let defaults = AdaptiveSampling::default();
    RenderArgs {
        design: Some(task.design.path.clone()),
        scene: manifest.scene.clone(),
        paint_material: Vec::new(),
        environment: task.lighting.argument.clone(),
        model: task.shading_model,
        spp: Some(manifest.quality.samples_per_pixel),
        seconds: None,
        size: manifest.size,
        wavelengths: manifest.quality.wavelengths,
        seed: manifest.seed,
        exposure: Exposure::Fixed { stops: 0.0 },
        tone_map: ToneMapping::default(),
        adaptive: false,
        adaptive_uniform_spp: defaults.uniform_samples,
        adaptive_floor: defaults.floor,
        adaptive_exponent: defaults.exponent,
        out: image_path(manifest, task),
        exr_precision: None,
        exr_compression: None,
        sample_range: None,
        front: None,
        view: task.view.parse().ok(),
        camera: None,
    }
}

/// The hash that decides whether `task`'s output is up to date, and the inputs
/// it was made from.
fn inputs_of(
    manifest: &Manifest,
    task: &Task,
) -> anyhow::Result<(String, PaintDesign, crate::cmd::render::RenderInputs)> {
    let args = render_args(manifest, task);
    let design = PaintDesign::load(&task.design.path)?;
    let inputs = render_inputs(&args, &design, manifest.quality.samples_per_pixel)?;
    let key = format!(
        "{}\nscene {}\ndesign {}\nlighting {}\nsettings {}\nview {}\nimage {}\n",
        inputs.program,
        inputs.scene.sha256,
        inputs.design.sha256,
        inputs.lighting.sha256,
        inputs.settings.sha256,
        task.view,
        task.output,
    );
    Ok((sha256_hex(key.as_bytes()), design, inputs))
}

/// Where a task's output stands.
#[derive(Debug, Clone, PartialEq)]
pub enum State {
    /// No image, or no readable sidecar: not rendered (or killed before its
    /// sidecar was written).
    Missing,
    /// The image and its sidecar, made from the task's inputs as they are now.
    Done(serde_json::Value),
    /// An image and sidecar that do not match the inputs now (changed since),
    /// or whose image is not the one the sidecar names.
    OutOfDate(serde_json::Value),
}

/// The sidecar of `image`, if there is a readable one.
fn read_sidecar(image: &Path) -> Option<serde_json::Value> {
    let text = std::fs::read_to_string(sidecar_path(image)).ok()?;
    serde_json::from_str(&text).ok()
}

fn state_of(image: &Path, inputs_sha256: &str) -> State {
    let Some(sidecar) = read_sidecar(image) else {
        return State::Missing;
    };
    let Ok(bytes) = std::fs::read(image) else {
        return State::Missing;
    };
    let field = |name: &str| sidecar.get(name).and_then(|v| v.as_str());
    if field("inputs_sha256") == Some(inputs_sha256)
        && field("image_sha256") == Some(&sha256_hex(&bytes))
    {
        State::Done(sidecar)
    } else {
        State::OutOfDate(sidecar)
    }
}

/// Where `task`'s output stands now.
pub fn state(manifest: &Manifest, task: &Task) -> anyhow::Result<State> {
    let (inputs_sha256, _, _) = inputs_of(manifest, task)?;
    Ok(state_of(&image_path(manifest, task), &inputs_sha256))
}

/// Creates the manifest's output folder (and its parents) if it is missing.
pub fn create_output_folder(manifest: &Manifest) -> anyhow::Result<()> {
    std::fs::create_dir_all(&manifest.output)
        .with_context(|| {
            format!(
                "cannot create the output folder {}",
                manifest.output.display()
            )
        })
        .or_fail(Failure::CantCreate)
}

/// Runs `task`: skips it if its output is up to date, else renders it.
pub fn run_task(manifest: &Manifest, task: &Task) -> anyhow::Result<Outcome> {
    let start = Instant::now();
    let (inputs_sha256, design, inputs) = inputs_of(manifest, task)?;
    let image = image_path(manifest, task);
    if matches!(state_of(&image, &inputs_sha256), State::Done(_)) {
        return Ok(Outcome::Skipped);
    }
    create_output_folder(manifest)?;
    let args = render_args(manifest, task);
    let spp = manifest.quality.samples_per_pixel;
    let rendered = render_film(&args, 0..spp, None, false)?;
    let display = args.display_for(rendered.render.film());
    let record = RenderRecord {
        design: Some(design.name.clone()),
        samples_per_pixel: Some(spp.to_string()),
        seed: Some(manifest.seed),
        lighting: Some(inputs.lighting.name.clone()),
    };
    ImageOutput {
        path: &image,
        exr_precision: None,
        exr_compression: None,
    }
    .write(rendered.render.film(), record, &display)?;
    let image_bytes = std::fs::read(&image)
        .with_context(|| format!("cannot read back {}", image.display()))
        .or_fail(Failure::CantCreate)?;
    let model = design
        .model(WavelengthGrid::reference())
        .with_context(|| {
            format!(
                "cannot build the paint model of {}",
                task.design.path.display()
            )
        })
        .or_fail(Failure::Data)?;
    let readings = measure(&model).or_fail(Failure::Internal)?;
    let noise = rendered
        .render
        .noise_estimate(&display)
        .map(|n| NoiseFigures {
            mean: n.mean_delta_e,
            p95: n.p95_delta_e,
        });
    let seconds = start.elapsed().as_secs_f64();
    let sidecar = Sidecar {
        format: SIDECAR_FORMAT,
        version: SIDECAR_VERSION,
        manifest: manifest.path.display().to_string(),
        task: task.index,
        image: task.output.clone(),
        image_sha256: sha256_hex(&image_bytes),
        inputs_sha256,
        program: inputs.program,
        inputs: SidecarInputs {
            design: inputs.design,
            design_file: task.design.path.display().to_string(),
            scene: inputs.scene,
            lighting: inputs.lighting,
            settings: inputs.settings,
        },
        settings: SidecarSettings {
            view: task.view.clone(),
            lighting: task.lighting.argument.clone(),
            model: task.model.clone(),
            quality: manifest.quality.label.clone(),
            size: format!("{}x{}", manifest.size.0, manifest.size.1),
            wavelengths: manifest.quality.wavelengths,
            exposure_stops: display.exposure_stops,
        },
        seed: manifest.seed,
        samples_per_pixel: spp,
        noise_delta_e00: noise,
        seconds,
        finished_unix_s: SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map(|d| d.as_secs())
            .unwrap_or(0),
        readings: serde_json::to_value(&readings).or_fail(Failure::Internal)?,
    };
    let mut json = serde_json::to_vec_pretty(&sidecar).or_fail(Failure::Internal)?;
    json.push(b'\n');
    write_bytes_atomically(&sidecar_path(&image), &json).or_fail(Failure::CantCreate)?;
    Ok(Outcome::Rendered { seconds })
}
