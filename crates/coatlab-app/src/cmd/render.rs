//! `coatlab render`: a headless render of a paint design on a car, to PNG (for
//! viewing) or OpenEXR (linear values, for analysis).

use std::io::{IsTerminal, Write};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context;
use coatlab_core::colour::spectrum::{
    Channels, MAX_VISIBLE_SAMPLES, REFERENCE_LEN, REFERENCE_STEP_NM, WavelengthGrid,
};
use coatlab_core::design::{PaintDesign, presets};
use coatlab_core::io::exr_write::{ExrCompression, ExrPrecision};
use coatlab_core::names::or_list;
use coatlab_core::paint::phong::PhongVariant;
use coatlab_core::render::adaptive::{AdaptiveError, AdaptiveSampling};
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::part::{Identity, PartHeader, write_part};
use coatlab_core::render::film::{
    DisplayChoice, DisplaySettings, Exposure, ExrOutput, Film, RenderRecord, ToneMapping,
};
use coatlab_core::render::lighting::Lighting;
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::{
    PassStats, ProgressiveRender, RenderScene, RenderSettings,
};
use coatlab_core::render::view::{ViewChoice, ViewError, ViewSpec};
use coatlab_core::scene::Scene;
use coatlab_core::scene::car::{CarParameters, generate};
use coatlab_core::scene::gltf_loader::{LoadOptions, load};
use coatlab_core::scene::orientation::Front;
use coatlab_core::simd_path::SimdPath;

use super::failure::{Classify, Failure};

/// Wavelengths per path unless `--wavelengths` says otherwise.
pub const DEFAULT_WAVELENGTHS: usize = 32;
/// Samples per pixel unless `--spp` or `--seconds` says otherwise.
pub const DEFAULT_SPP: u32 = 64;

#[derive(clap::Args, Debug, Clone)]
pub struct RenderArgs {
    /// Paint design file (TOML); the built-in signal red when left out.
    #[arg(long)]
    pub design: Option<PathBuf>,
    /// glTF scene (.glb or .gltf); the built-in car when left out.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Paint the materials with exactly these names instead of the automatic
    /// choice (a body split across materials): comma-separated, or the flag
    /// repeated.
    #[arg(long, value_delimiter = ',')]
    pub paint_material: Vec<String>,
    /// glTF scene only: the file axis the car's nose points along (+x, -x, +z or
    /// -z) instead of the automatic orientation (docs/scenes.md).
    #[arg(long, allow_hyphen_values = true)]
    pub front: Option<Front>,
    /// Named view: front-34 (the default), rear-34, side, front, rear, top or
    /// closeup (a panel: the left front door and wing); or turntable:N, N frames
    /// (1–360) around the car in equal steps, written as OUT's name with -00, -01…
    /// before the extension; or turntable:N:K, frame K (from 0) alone, to --out.
    #[arg(long, conflicts_with = "camera")]
    pub view: Option<ViewSpec>,
    /// A camera by hand, yaw_deg,pitch_deg,distance_m,fov_deg (yaw from the nose
    /// toward the car's left, pitch up, distance from the car's centre, vertical
    /// field of view), or gltf:N for the scene file's camera N (from 0).
    #[arg(long, allow_hyphen_values = true)]
    pub camera: Option<ViewChoice>,
    /// Lighting: studio, booth-d65, booth-a, booth-f11, outdoor, or the path of an
    /// environment map (Radiance .hdr or OpenEXR .exr, equirectangular).
    #[arg(long, default_value = "studio")]
    pub environment: String,
    /// How the design is rendered: paint, phong-naive or phong-fit.
    #[arg(long, default_value = "paint", value_parser = parse_model)]
    pub model: ShadingModel,
    /// Samples per pixel.
    #[arg(long, conflicts_with = "seconds")]
    pub spp: Option<u32>,
    /// Render for this many seconds instead of a sample count (at least one pass).
    #[arg(long, allow_hyphen_values = true)]
    pub seconds: Option<f64>,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "960x540", value_parser = parse_size)]
    pub size: (u32, u32),
    // The help states the range from the grid's own limits.
    #[arg(long, default_value_t = DEFAULT_WAVELENGTHS, help = wavelengths_help())]
    pub wavelengths: usize,
    /// Seed of the random numbers: the same seed gives the same image.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Exposure of the PNG: stops (the lighting setups are normalised so 0 suits
    /// them all), or auto (the image's log-average luminance to middle grey),
    /// adjusted as auto+STOPS or auto-STOPS. Not applied to an EXR.
    #[arg(long, default_value = "0", value_parser = parse_exposure, allow_hyphen_values = true)]
    pub exposure: Exposure,
    /// Tone mapping of the PNG: neutral (Khronos PBR Neutral: colours that fit the
    /// display stay as they are), reinhard (extended Reinhard on luminance, the
    /// earlier default) or clip. Not applied to an EXR.
    #[arg(long, default_value = "neutral", value_parser = parse_tone_map)]
    pub tone_map: ToneMapping,
    /// Adaptive sampling: after the first uniform samples, each pass spends its
    /// samples on the pixels by their noise (on or off); --spp is then the mean
    /// over the image.
    #[arg(
        long,
        default_value = DEFAULT_ADAPTIVE,
        value_parser = parse_on_off,
        action = clap::ArgAction::Set
    )]
    pub adaptive: bool,
    /// Adaptive sampling: samples per pixel taken uniformly first (at least 2).
    #[arg(long, default_value_t = AdaptiveSampling::default().uniform_samples)]
    pub adaptive_uniform_spp: u32,
    /// Adaptive sampling: the least share of a pixel, relative to the mean, in (0, 1].
    #[arg(long, default_value_t = AdaptiveSampling::default().floor)]
    pub adaptive_floor: f32,
    /// Adaptive sampling: samples follow the per-sample noise to this power (0–4).
    #[arg(long, default_value_t = AdaptiveSampling::default().exponent)]
    pub adaptive_exponent: f32,
    /// Output: .png (8-bit sRGB, exposure and tone mapping applied), .exr (linear
    /// sRGB, D65 white at 1: R, G, B channels, no exposure or tone mapping; the
    /// header says the design, samples, seed, wavelengths and lighting), or .film
    /// (the film's sums of --sample-range, for `coatlab merge`; docs/film-format.md).
    #[arg(long)]
    pub out: PathBuf,
    /// .film output only: render only the sample indices FIRST..END of the --spp
    /// of the whole image [default: 0..spp]; parts covering 0..spp merge
    /// (`coatlab merge`) into exactly the image of one render.
    #[arg(long, value_name = "FIRST..END", value_parser = parse_sample_range)]
    pub sample_range: Option<Range<u32>>,
    /// EXR output only: the channels' sample type, float (32-bit, exact) or half
    /// (16-bit) [default: float].
    #[arg(long, value_parser = parse_exr_precision)]
    pub exr_precision: Option<ExrPrecision>,
    /// EXR output only: the lossless compression, none, rle, zips, zip or piz
    /// [default: zip].
    #[arg(long, value_parser = parse_exr_compression)]
    pub exr_compression: Option<ExrCompression>,
}

fn parse_sample_range(text: &str) -> Result<Range<u32>, String> {
    let message =
        || format!("'{text}' is not a range of sample indices: use FIRST..END, e.g. 0..256");
    let (first, end) = text.split_once("..").ok_or_else(message)?;
    let first: u32 = first.trim().parse().map_err(|_| message())?;
    let end: u32 = end.trim().parse().map_err(|_| message())?;
    if first >= end {
        return Err(format!(
            "'{text}': the range is empty (FIRST must be below END)"
        ));
    }
    Ok(first..end)
}

pub fn parse_exr_precision(text: &str) -> Result<ExrPrecision, String> {
    match text {
        "float" => Ok(ExrPrecision::Float),
        "half" => Ok(ExrPrecision::Half),
        other => Err(format!("'{other}': use float or half")),
    }
}

pub fn parse_exr_compression(text: &str) -> Result<ExrCompression, String> {
    ExrCompression::from_name(text).ok_or_else(|| {
        let names: Vec<&str> = ExrCompression::ALL.iter().map(|c| c.name()).collect();
        format!("'{text}': use {}", names.join(", "))
    })
}

/// `--wavelengths`' help: the range [`WavelengthGrid::visible`] accepts.
fn wavelengths_help() -> String {
    format!(
        "Wavelengths carried by every path (1–{MAX_VISIBLE_SAMPLES}; {REFERENCE_LEN} is the {REFERENCE_STEP_NM} nm reference grid)"
    )
}

/// `--adaptive` unless given: see docs/tradeoff.md, "Adaptive sampling".
pub const DEFAULT_ADAPTIVE: &str = "off";

fn parse_exposure(text: &str) -> Result<Exposure, String> {
    Exposure::parse(text).map_err(|e| e.to_string())
}

pub fn parse_tone_map(text: &str) -> Result<ToneMapping, String> {
    ToneMapping::parse(text).map_err(|e| e.to_string())
}

impl RenderArgs {
    /// How the PNG of `film` is shown: `--tone-map` and `--exposure`.
    pub fn display_for(&self, film: &Film) -> DisplaySettings {
        DisplayChoice {
            tone_mapping: self.tone_map,
            exposure: self.exposure,
        }
        .settings_for(film)
    }
}

fn parse_on_off(text: &str) -> Result<bool, String> {
    match text {
        "on" => Ok(true),
        "off" => Ok(false),
        other => Err(format!("'{other}': use on or off")),
    }
}

pub fn parse_model(text: &str) -> Result<ShadingModel, String> {
    match text {
        "paint" => Ok(ShadingModel::Paint),
        "phong-naive" => Ok(ShadingModel::Phong(PhongVariant::Naive)),
        "phong-fit" => Ok(ShadingModel::Phong(PhongVariant::BestFit)),
        other => Err(format!(
            "unknown model '{other}': use paint, phong-naive or phong-fit"
        )),
    }
}

/// The largest image `--size` accepts, in pixels.
pub const MAX_PIXELS: u64 = 8192 * 8192;

pub fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let message = || format!("'{text}' is not a size: use WIDTHxHEIGHT, e.g. 960x540");
    let (w, h) = text.split_once(['x', 'X', '×']).ok_or_else(message)?;
    let w: u32 = w.trim().parse().map_err(|_| message())?;
    let h: u32 = h.trim().parse().map_err(|_| message())?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!(
            "size {w}x{h}: width and height must be 1 to 16384 pixels"
        ));
    }
    // The film keeps 160 bytes a pixel (render::film): 8192×8192 is 10.7 GB, the most
    // a workstation can be asked for without the process being killed for memory
    // instead of told why.
    if u64::from(w) * u64::from(h) > MAX_PIXELS {
        return Err(format!(
            "size {w}x{h}: at most {MAX_PIXELS} pixels (8192x8192): the film needs 160 bytes a pixel"
        ));
    }
    Ok((w, h))
}

/// The lighting setup named on the command line, or an environment map file, on
/// `channels` (a wavelength grid, or linear sRGB).
pub fn environment(
    name: &str,
    channels: &(impl Into<Channels> + Copy),
) -> anyhow::Result<Environment> {
    let not_found = |failure: Failure| {
        failure.error(format!(
            "--environment '{name}': not a lighting setup ({}) and no such file",
            Lighting::SETUP_NAMES.join(", ")
        ))
    };
    // A bare word was meant as a setup's name; anything else as a file.
    let lighting = Lighting::parse(name).map_err(|_| not_found(Failure::Usage))?;
    if let Lighting::Map(path) = &lighting
        && !path.exists()
    {
        return Err(not_found(Failure::NoInput));
    }
    Ok(lighting.build(channels)?)
}

/// The lighting's name for the record of a render: a setup's own name (whatever
/// the case it was typed in), a map's path as given.
fn lighting_name(argument: &str) -> String {
    Lighting::parse(argument)
        .map(|lighting| lighting.name())
        .unwrap_or_else(|_| argument.to_owned())
}

/// The scene: a glTF file, or the built-in car; `paint_materials` (names), when
/// given, carry the design instead of the automatic choice.
pub fn scene(
    path: Option<&Path>,
    paint_materials: &[String],
    front: Option<Front>,
) -> anyhow::Result<Scene> {
    let mut scene = match path {
        // The loader frames and centres the car by its paint: the first name
        // stands in for the body there.
        Some(path) => load(
            path,
            &LoadOptions {
                paint_material: paint_materials.first().cloned(),
                front,
            },
        )?,
        None if front.is_some() => {
            return Err(Failure::Usage.error(format!(
                "--front {}: only for a glTF --scene; the built-in car's nose is +z already",
                front.map(Front::name).unwrap_or_default()
            )));
        }
        None => generate(&CarParameters::default()),
    };
    if !paint_materials.is_empty() {
        scene.paint_materials = materials_named(&scene, paint_materials, path.is_none())?;
    }
    Ok(scene)
}

/// The indices of the materials named `names` (every material of a name: a file
/// may use one name twice), or a usage error naming the first unknown name and
/// listing the scene's materials.
fn materials_named(scene: &Scene, names: &[String], built_in: bool) -> anyhow::Result<Vec<u32>> {
    let mut chosen = Vec::new();
    for name in names {
        let named: Vec<u32> = (0..scene.materials.len() as u32)
            .filter(|&i| scene.materials[i as usize].name == *name)
            .collect();
        if named.is_empty() {
            let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
            return Err(Failure::Usage.error(format!(
                "--paint-material '{name}': {} has no such material (it has {})",
                if built_in {
                    "the built-in car"
                } else {
                    "the scene"
                },
                or_list(&names)
            )));
        }
        chosen.extend(named);
    }
    chosen.sort_unstable();
    chosen.dedup();
    Ok(chosen)
}

pub fn run(args: &RenderArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let extension = out_extension(&args.out, &["png", "exr", "film"], "the output")?;
    let part = extension == "film";
    if extension != "exr" {
        let given = [
            ("--exr-precision", args.exr_precision.is_some()),
            ("--exr-compression", args.exr_compression.is_some()),
        ];
        if let Some((flag, _)) = given.iter().find(|(_, given)| *given) {
            return Err(Failure::Usage.error(format!(
                "{flag}: only for .exr output, and --out {} is not one",
                args.out.display()
            )));
        }
    }
    // What a Duration holds (about 5.8e11 years) is the upper limit.
    let time_limit = match args.seconds {
        None => None,
        Some(seconds) => match Duration::try_from_secs_f64(seconds) {
            Ok(limit) if seconds > 0.0 => Some(limit),
            _ => {
                return Err(Failure::Usage.error(format!(
                    "--seconds {seconds}: must be a positive, finite number of seconds"
                )));
            }
        },
    };
    let spp = args.spp.unwrap_or(DEFAULT_SPP);
    if spp == 0 {
        return Err(Failure::Usage.error("--spp 0: at least one sample per pixel is needed"));
    }
    let samples = sample_range(args, part, spp)?;
    let prepared = prepare(args)?;
    match args.view {
        Some(whole @ ViewSpec::Turntable(turntable)) => {
            for (k, frame) in whole.frames().into_iter().enumerate() {
                let frame_args = RenderArgs {
                    view: Some(frame),
                    out: frame_path(&args.out, k as u32, turntable.frames()),
                    ..args.clone()
                };
                let rendered =
                    render_prepared(&frame_args, &prepared, samples.clone(), time_limit, true)?;
                write_render(&frame_args, rendered, spp, samples.clone(), out)?;
            }
            Ok(())
        }
        _ => {
            let rendered = render_prepared(args, &prepared, samples.clone(), time_limit, true)?;
            write_render(args, rendered, spp, samples, out)
        }
    }
}

/// Frame `k` of an `n`-frame turntable written to `out`: its name with `-KK`
/// before the extension, K zero-padded to the digits of n − 1 (at least two),
/// so the files sort in the order of the turn.
pub fn frame_path(out: &Path, k: u32, n: u32) -> PathBuf {
    let digits = (n.saturating_sub(1).max(1).ilog10() + 1).max(2) as usize;
    let stem = out.file_stem().unwrap_or_default().to_string_lossy();
    let name = match out.extension() {
        Some(extension) => format!("{stem}-{k:0digits$}.{}", extension.to_string_lossy()),
        None => format!("{stem}-{k:0digits$}"),
    };
    out.with_file_name(name)
}

/// Writes one finished render to `args.out` (a film part, an EXR or a PNG) and
/// prints its line.
fn write_render(
    args: &RenderArgs,
    rendered: Rendered,
    spp: u32,
    samples: Range<u32>,
    out: &mut impl Write,
) -> anyhow::Result<()> {
    let Rendered {
        render,
        design,
        grid,
        totals,
    } = rendered;
    let (width, height) = args.size;
    if is_part(&args.out) {
        let header = part_header(args, &design, grid, spp, samples.clone())?;
        write_part(&args.out, &header, render.film())?;
        writeln!(
            out,
            "wrote {} (samples {}..{} of {spp}, {width}x{height}, {} wavelengths, {}) {}",
            args.out.display(),
            samples.start,
            samples.end,
            grid.len(),
            args.model.label(),
            speed(&totals),
        )?;
        return Ok(());
    }
    let display = args.display_for(render.film());
    let samples_per_pixel = if args.adaptive {
        format!("{} mean, adaptive", render.samples_per_pixel())
    } else {
        render.samples_per_pixel().to_string()
    };
    let record = RenderRecord {
        design: Some(design.name.clone()),
        samples_per_pixel: Some(samples_per_pixel),
        seed: Some(args.seed),
        lighting: Some(lighting_name(&args.environment)),
    };
    let image = ImageOutput {
        path: &args.out,
        exr_precision: args.exr_precision,
        exr_compression: args.exr_compression,
    };
    image.write(render.film(), record, &display)?;
    let rejected = render.film().rejected_samples();
    if rejected > 0 {
        to_stderr(format_args!(
            "coatlab: warning: {rejected} samples were not finite and counted as black\n"
        ));
    }
    let noise = render
        .noise_estimate(&display)
        .map(|n| format!(", noise left ΔE00 {:.2} mean", n.mean_delta_e))
        .unwrap_or_default();
    writeln!(
        out,
        "wrote {} ({width}x{height}, {} spp{}, {} wavelengths, {}{noise}) {}",
        args.out.display(),
        render.samples_per_pixel(),
        if args.adaptive { " mean, adaptive" } else { "" },
        grid.len(),
        args.model.label(),
        speed(&totals),
    )?;
    Ok(())
}

/// `--out path`'s extension, lower-case, if it is one of `accepted`; else a usage
/// error saying that `what` must end in one of them.
pub fn out_extension(path: &Path, accepted: &[&str], what: &str) -> anyhow::Result<String> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .filter(|e| accepted.contains(&e.as_str()));
    extension.ok_or_else(|| {
        let list: Vec<String> = accepted.iter().map(|e| format!(".{e}")).collect();
        Failure::Usage.error(format!(
            "--out {}: {what} must end in {}",
            path.display(),
            or_list(&list)
        ))
    })
}

/// The end of a render's last line: its time, rates and SIMD path.
fn speed(totals: &PassStats) -> String {
    format!(
        "in {:.1} s: {:.3} M samples/s, {:.2} M rays/s, SIMD path {}",
        totals.seconds,
        totals.samples_per_second() / 1e6,
        totals.rays_per_second() / 1e6,
        SimdPath::current().name(),
    )
}

/// A finished render and what it was made of.
pub struct Rendered {
    pub render: ProgressiveRender,
    pub design: PaintDesign,
    pub grid: WavelengthGrid,
    /// Samples and rays of the render and its wall time (the passes, not the set-up).
    pub totals: PassStats,
}

/// Renders the sample indices `samples` of `args`' image (or, with
/// `time_limit`, passes from the first until the time is up), with a progress
/// bar on standard error if `show_progress`.
pub fn render_film(
    args: &RenderArgs,
    samples: Range<u32>,
    time_limit: Option<Duration>,
    show_progress: bool,
) -> anyhow::Result<Rendered> {
    let prepared = prepare(args)?;
    render_prepared(args, &prepared, samples, time_limit, show_progress)
}

/// What every image of one `coatlab render` shares, built once: the design, its
/// grid, the scene with its BVH, the lighting and the shading.
pub struct Prepared {
    design: PaintDesign,
    grid: WavelengthGrid,
    scene: Arc<RenderScene>,
    environment: Arc<Environment>,
    shading: Arc<Shading>,
    adaptive: Option<AdaptiveSampling>,
}

/// Loads and builds what `args`' images share (see [`Prepared`]).
pub fn prepare(args: &RenderArgs) -> anyhow::Result<Prepared> {
    let adaptive = AdaptiveSampling {
        uniform_samples: args.adaptive_uniform_spp,
        floor: args.adaptive_floor,
        exponent: args.adaptive_exponent,
    };
    if args.adaptive {
        adaptive.validate().map_err(|error| {
            let flag = match error {
                AdaptiveError::UniformSamples(_) => "--adaptive-uniform-spp",
                AdaptiveError::Floor(_) => "--adaptive-floor",
                AdaptiveError::Exponent(_) => "--adaptive-exponent",
            };
            Failure::Usage.error(format!("{flag}: {error}"))
        })?;
    }
    let grid = WavelengthGrid::visible(args.wavelengths)
        .with_context(|| format!("--wavelengths {}", args.wavelengths))
        .or_fail(Failure::Usage)?;

    let design = match &args.design {
        Some(path) => PaintDesign::load(path)?,
        None => {
            presets::all()
                .into_iter()
                .next()
                .context("no built-in preset")
                .or_fail(Failure::Internal)?
                .design
        }
    };
    let model = design
        .model(grid)
        .context("cannot build the paint model")
        .or_fail(Failure::Data)?;
    let environment = environment(&args.environment, &grid)?;
    let scene = scene(args.scene.as_deref(), &args.paint_material, args.front)?;
    for warning in &scene.warnings {
        to_stderr(format_args!("coatlab: warning: {warning}\n"));
    }
    let shading = Shading::for_scene(&model, args.model, &scene);
    let render_scene = RenderScene::new(scene)
        .context("cannot prepare the scene")
        .or_fail(Failure::Data)?;
    Ok(Prepared {
        design,
        grid,
        scene: Arc::new(render_scene),
        environment: Arc::new(environment),
        shading: Arc::new(shading),
        adaptive: args.adaptive.then_some(adaptive),
    })
}

/// Renders `args`' image (its view or camera) from what `prepared` holds; as
/// [`render_film`].
pub fn render_prepared(
    args: &RenderArgs,
    prepared: &Prepared,
    samples: Range<u32>,
    time_limit: Option<Duration>,
    show_progress: bool,
) -> anyhow::Result<Rendered> {
    let (width, height) = args.size;
    let framing = prepared.scene.framing();
    let camera = match (args.view, args.camera) {
        (Some(view), _) => framing.view(view, width, height),
        (None, camera) => framing
            .camera(&camera.unwrap_or_default(), width, height)
            .map_err(|error| {
                let flag = match error {
                    ViewError::NoSuchCamera { index, .. } => format!("--camera gltf:{index}"),
                    _ => "--camera".to_owned(),
                };
                Failure::Usage.error(format!("{flag}: {error}"))
            })?,
    };
    let mut render = ProgressiveRender::new(
        Arc::clone(&prepared.scene),
        Arc::clone(&prepared.environment),
        Arc::clone(&prepared.shading),
        camera,
        RenderSettings {
            seed: args.seed,
            adaptive: prepared.adaptive,
            ..RenderSettings::default()
        },
    )
    .or_fail(Failure::Data)?;

    render
        .restart_at_sample(samples.start)
        .or_fail(Failure::Usage)?;
    let mut progress = show_progress.then(|| Progress::new(time_limit, samples.clone()));
    let start = Instant::now();
    loop {
        let done = render.samples_per_pixel();
        let batch = match time_limit {
            Some(_) => 1,
            None => (samples.end - done).min(4),
        };
        render.render_pass(batch);
        let elapsed = start.elapsed();
        if let Some(progress) = &mut progress {
            progress.update(render.samples_per_pixel(), elapsed);
        }
        let finished = match time_limit {
            Some(limit) => elapsed >= limit,
            None => render.samples_per_pixel() >= samples.end,
        };
        if finished {
            break;
        }
    }
    // The renderer counts samples and rays; the wall time includes the progress bar.
    let totals = PassStats {
        seconds: start.elapsed().as_secs_f64(),
        ..render.totals()
    };
    if let Some(progress) = &progress {
        progress.finish();
    }
    Ok(Rendered {
        render,
        design: prepared.design.clone(),
        grid: prepared.grid,
        totals,
    })
}

/// Where and how a film's image is written: PNG or EXR by the path's extension.
pub struct ImageOutput<'a> {
    pub path: &'a Path,
    pub exr_precision: Option<ExrPrecision>,
    pub exr_compression: Option<ExrCompression>,
}

impl ImageOutput<'_> {
    /// Writes `film`'s image: an EXR with `record` in its header, or a PNG shown
    /// with `display`. What `coatlab render` and `coatlab merge` both write.
    pub fn write(
        &self,
        film: &Film,
        record: RenderRecord,
        display: &DisplaySettings,
    ) -> anyhow::Result<()> {
        if is_exr(self.path) {
            let output = ExrOutput {
                precision: self.exr_precision.unwrap_or_default(),
                compression: self.exr_compression.unwrap_or_default(),
                record,
            };
            film.write_exr_with(self.path, &output)?;
        } else {
            film.write_png(self.path, display)?;
        }
        Ok(())
    }
}

fn is_exr(path: &Path) -> bool {
    has_extension(path, "exr")
}

fn is_part(path: &Path) -> bool {
    has_extension(path, "film")
}

fn has_extension(path: &Path, extension: &str) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(extension))
}

/// The sample indices to render: `--sample-range` (a .film part only, within
/// `--spp`), or all of them.
fn sample_range(args: &RenderArgs, part: bool, spp: u32) -> anyhow::Result<Range<u32>> {
    if !part {
        if args.sample_range.is_some() {
            return Err(Failure::Usage.error(format!(
                "--sample-range: only for a .film part (for `coatlab merge`), and --out {} is not one",
                args.out.display()
            )));
        }
        return Ok(0..spp);
    }
    if args.seconds.is_some() {
        return Err(Failure::Usage.error(
            "--seconds: a .film part holds a fixed range of samples; give --spp (and --sample-range)",
        ));
    }
    if args.adaptive {
        return Err(Failure::Usage.error(format!(
            "--adaptive on: a .film part cannot be adaptive: {}",
            coatlab_core::render::progressive::RenderError::AdaptiveRange
        )));
    }
    let range = args.sample_range.clone().unwrap_or(0..spp);
    if range.end > spp {
        return Err(Failure::Usage.error(format!(
            "--sample-range {}..{}: the image has {spp} samples per pixel (--spp), indices 0..{spp}",
            range.start, range.end
        )));
    }
    Ok(range)
}

/// The identities of a render's inputs: what a film part's header and a batch
/// output's sidecar record, and what decides whether two renders are the same.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderInputs {
    pub program: String,
    pub scene: Identity,
    pub design: Identity,
    pub lighting: Identity,
    pub settings: Identity,
}

/// This program and its version, as parts and sidecars record it.
pub fn program() -> String {
    format!("coatlab {}", env!("CARGO_PKG_VERSION"))
}

/// The identities of `args`' inputs, `design` as loaded. The design is hashed in
/// its canonical TOML (comments and layout do not count); a glTF scene and an
/// environment map by their file's bytes (a .gltf's external buffers are not
/// read: edit the .gltf too, or use .glb); the built-in car and the lighting
/// setups by their names and this program's version (which make them).
pub fn render_inputs(
    args: &RenderArgs,
    design: &PaintDesign,
    spp: u32,
) -> anyhow::Result<RenderInputs> {
    let read = |path: &Path| {
        std::fs::read(path)
            .with_context(|| format!("cannot read {}", path.display()))
            .or_fail(Failure::NoInput)
    };
    let scene = match &args.scene {
        Some(path) => Identity::of_bytes(path.display().to_string(), &read(path)?),
        None => Identity::of_bytes(
            "built-in car",
            format!("{:?}", CarParameters::default()).as_bytes(),
        ),
    };
    let design_identity =
        Identity::of_bytes(design.name.clone(), design.to_toml_string().as_bytes());
    let lighting = match Lighting::parse(&args.environment) {
        Ok(Lighting::Map(path)) => Identity::of_bytes(path.display().to_string(), &read(&path)?),
        _ => Identity::of_bytes(
            lighting_name(&args.environment),
            lighting_name(&args.environment).as_bytes(),
        ),
    };
    let (width, height) = args.size;
    let settings = format!(
        "model={}; size={width}x{height}; wavelengths={}; spp={spp}; seed={}; exposure={}; \
         paint-material={:?}; integrator={:?}; adaptive={}; view={}",
        args.model.label(),
        args.wavelengths,
        args.seed,
        args.exposure,
        args.paint_material,
        RenderSettings::default().integrator,
        args.adaptive,
        match (args.view, args.camera) {
            (Some(view), _) => view.to_string(),
            (None, Some(camera)) => format!("{camera:?}"),
            (None, None) => "default".to_owned(),
        },
    );
    Ok(RenderInputs {
        program: program(),
        scene,
        design: design_identity,
        lighting,
        settings: Identity::of_bytes(
            format!("{}, exposure {}", args.model.label(), args.exposure),
            settings.as_bytes(),
        ),
    })
}

/// The header of the film part of `samples` of `args`' render.
fn part_header(
    args: &RenderArgs,
    design: &PaintDesign,
    grid: WavelengthGrid,
    spp: u32,
    samples: Range<u32>,
) -> anyhow::Result<PartHeader> {
    let inputs = render_inputs(args, design, spp)?;
    Ok(PartHeader {
        program: inputs.program,
        width: args.size.0,
        height: args.size.1,
        grid: Some(grid),
        seed: args.seed,
        total_samples: spp,
        sample_start: samples.start,
        sample_end: samples.end,
        scene: inputs.scene,
        design: inputs.design,
        lighting: inputs.lighting,
        settings: inputs.settings,
        exposure_stops: match args.exposure {
            Exposure::Fixed { stops } => stops,
            Exposure::Auto { .. } => {
                return Err(Failure::Usage.error(
                    "--exposure auto: a .film part holds only some of the samples, so the \
                     image's exposure is not known yet; give stops (the merged PNG is shown at them)",
                ));
            }
        },
    })
}

/// Writes to standard error, ignoring failure: `eprintln!` panics when stderr is
/// a closed pipe (`coatlab render … 2>&1 | head -1`), and progress and warnings
/// are not worth failing a render for.
fn to_stderr(text: std::fmt::Arguments) {
    let _ = std::io::stderr().write_fmt(text);
}

/// A progress bar on standard error: redrawn in place on a terminal, a line per
/// tenth otherwise (logs stay readable).
struct Progress {
    limit: Option<Duration>,
    samples: Range<u32>,
    terminal: bool,
    last_tenth: u32,
}

impl Progress {
    fn new(limit: Option<Duration>, samples: Range<u32>) -> Self {
        Self {
            limit,
            samples,
            terminal: std::io::stderr().is_terminal(),
            last_tenth: 0,
        }
    }

    fn update(&mut self, done: u32, elapsed: Duration) {
        let fraction = match self.limit {
            Some(limit) => elapsed.as_secs_f64() / limit.as_secs_f64(),
            None => {
                f64::from(done.saturating_sub(self.samples.start))
                    / f64::from(self.samples.len() as u32)
            }
        }
        .clamp(0.0, 1.0);
        let width = 30;
        let filled = (fraction * width as f64).round() as usize;
        let bar = format!(
            "[{}{}] {:3.0}%  {done} spp  {:.1} s",
            "#".repeat(filled),
            " ".repeat(width - filled),
            fraction * 100.0,
            elapsed.as_secs_f64()
        );
        if self.terminal {
            to_stderr(format_args!("\r{bar}"));
        } else {
            let tenth = (fraction * 10.0).floor() as u32;
            if tenth > self.last_tenth {
                self.last_tenth = tenth;
                to_stderr(format_args!("{bar}\n"));
            }
        }
    }

    fn finish(&self) {
        if self.terminal {
            to_stderr(format_args!("\n"));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_and_bad_ones_say_why() {
        assert_eq!(parse_size("960x540"), Ok((960, 540)));
        assert_eq!(parse_size("64X32"), Ok((64, 32)));
        assert!(parse_size("960").unwrap_err().contains("WIDTHxHEIGHT"));
        assert!(parse_size("0x10").unwrap_err().contains("1 to 16384"));
        assert!(parse_size("ax10").is_err());
        assert_eq!(parse_size("8192x8192"), Ok((8192, 8192)));
        assert!(
            parse_size("16384x16384")
                .unwrap_err()
                .contains("160 bytes a pixel")
        );
        assert!(parse_size("16384x4097").is_err());
    }

    #[test]
    fn turntable_frames_are_numbered_to_sort_in_order() {
        let out = Path::new("deck/spin.png");
        assert_eq!(frame_path(out, 3, 8), Path::new("deck/spin-03.png"));
        assert_eq!(frame_path(out, 0, 1), Path::new("deck/spin-00.png"));
        assert_eq!(frame_path(out, 99, 100), Path::new("deck/spin-99.png"));
        assert_eq!(frame_path(out, 5, 360), Path::new("deck/spin-005.png"));
        assert_eq!(frame_path(Path::new("spin"), 1, 2), Path::new("spin-01"));
    }

    #[test]
    fn models_parse() {
        assert_eq!(parse_model("paint"), Ok(ShadingModel::Paint));
        assert_eq!(
            parse_model("phong-fit"),
            Ok(ShadingModel::Phong(PhongVariant::BestFit))
        );
        assert!(parse_model("lambert").unwrap_err().contains("phong-naive"));
    }
}
