//! `cargo xtask bench`: the reference protocol and the speed/accuracy sweep
//! (docs/tradeoff.md).
//!
//! - `cargo xtask bench reference`: renders (or finds in the cache) the converged
//!   reference of one scene and lighting: 81 wavelengths, two halves of different
//!   seeds, stored as mean XYZ per pixel under a key of scene, lighting, design,
//!   size, samples and protocol version.
//! - `cargo xtask bench tradeoff`: for each protocol case, renders every setting of
//!   the sweep, measures its wall time and its error against the reference
//!   ([`coatlab_core::render::image_error`]), and writes the table into
//!   docs/tradeoff.md (between markers), the plot beside it and the quality presets
//!   (assets/quality-presets.toml) from the measured Pareto front ([`report`]).

mod report;
mod rgb;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use anyhow::Context;
use coatlab_core::colour::cie::Illuminant;
use coatlab_core::colour::spectrum::{Channels, WavelengthGrid};
use coatlab_core::design::{PaintDesign, presets};
use coatlab_core::io::rgb_image::ImageReadError;
use coatlab_core::paint::coat::CoatIntegralMethod;
use coatlab_core::paint::lobe::LobeKind;
use coatlab_core::render::camera::Camera;
use coatlab_core::render::environment::EnvironmentError;
use coatlab_core::render::film::DisplaySettings;
use coatlab_core::render::image_error::{ImageError, Region, RegionMasks, XyzImage, image_error};
use coatlab_core::render::lighting::Lighting;
use coatlab_core::render::material::ShadingModel;
use coatlab_core::render::progressive::{ProgressiveRender, RenderScene, RenderSettings};
use coatlab_core::scene::Scene;
use coatlab_core::scene::car::{CarParameters, generate, to_glb};
use coatlab_core::scene::gltf_loader::{LoadOptions, SceneError, load};

use crate::{Failed, OrFail, status};
use report::{
    choose_presets, mark_front, plot_svg, presets_toml, region_cells, table_markdown,
    write_between_markers,
};

/// Bumped whenever the renderer or the protocol changes what a reference holds:
/// part of every cache key, so stale references are never compared against.
pub const PROTOCOL_VERSION: u32 = 2;
/// The protocol's image size: small enough that the sweep runs in minutes on two
/// shared cores, large enough for region means over hundreds of pixels.
pub const PROTOCOL_SIZE: (u32, u32) = (320, 180);
/// Samples per pixel of a reference (two halves of half as many).
pub const REFERENCE_SPP: u32 = 1024;
/// Seeds of the two half references, and of the renders under test.
const HALF_SEEDS: [u64; 2] = [0x5eed_0001, 0x5eed_0002];
const TEST_SEED: u64 = 7;
/// The protocol's glTF car, the Lamborghini, inside the shared test data.
const SHARED_GLTF: &str = "testdata/gltf/LamborghiniHuracanGT3/LamborghiniHuracanGT3.glb";

#[derive(clap::Subcommand, Debug)]
pub enum BenchCommand {
    /// Render (or find in the cache) the reference of one scene and lighting.
    Reference(ReferenceArgs),
    /// Sweep the speed/accuracy knobs against the references; writes the table,
    /// the plot and the quality presets.
    Tradeoff(TradeoffArgs),
}

#[derive(clap::Args, Debug)]
pub struct ReferenceArgs {
    /// glTF scene; the built-in car when left out.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Lighting: studio, booth-d65, booth-a, booth-f11 or outdoor.
    #[arg(long, default_value = "studio")]
    pub environment: String,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "320x180", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Samples per pixel of the whole reference (two halves).
    #[arg(long, default_value_t = REFERENCE_SPP)]
    pub spp: u32,
    /// Where references are cached.
    #[arg(long, default_value = "target/coatlab-references")]
    pub cache: PathBuf,
    /// Render again even when the cache has it.
    #[arg(long)]
    pub force: bool,
}

#[derive(clap::Args, Debug)]
pub struct TradeoffArgs {
    /// A small, fast sweep (one case, tiny image): a smoke test, not a measurement.
    #[arg(long)]
    pub quick: bool,
    /// The glTF car of the protocol; by default the Lamborghini of the shared test
    /// data (--shared).
    #[arg(long)]
    pub gltf: Option<PathBuf>,
    /// The shared test data (the folder holding testdata/gltf/), where --gltf is not
    /// given; the environment variable COATLAB_SHARED when left out.
    #[arg(long)]
    pub shared: Option<PathBuf>,
    /// Leave the glTF car out.
    #[arg(long)]
    pub no_gltf: bool,
    /// Where references are cached.
    #[arg(long, default_value = "target/coatlab-references")]
    pub cache: PathBuf,
    /// The document whose table (between its markers) is replaced.
    #[arg(long, default_value = "docs/tradeoff.md")]
    pub doc: PathBuf,
    /// The plot (SVG).
    #[arg(long, default_value = "docs/tradeoff.svg")]
    pub plot: PathBuf,
    /// The quality presets file the app embeds.
    #[arg(long, default_value = "assets/quality-presets.toml")]
    pub presets: PathBuf,
}

pub fn run(command: &BenchCommand, out: &mut impl Write) -> Result<(), Failed> {
    match command {
        BenchCommand::Reference(args) => {
            if args.spp < 2 {
                return Err(Failed::new(
                    status::USAGE,
                    format!(
                        "--spp {}: a reference needs at least 2 samples (two halves)",
                        args.spp
                    ),
                ));
            }
            let case = Case {
                scene: args.scene.clone(),
                lighting: lighting(&args.environment)?,
            };
            let protocol = Protocol {
                size: args.size,
                reference_spp: args.spp,
            };
            let prepared = PreparedCase::new(&case)?;
            let reference = reference(&prepared, &protocol, &args.cache, args.force, out)?;
            let noise = reference.noise();
            writeln!(
                out,
                "reference {}: noise ΔE00 ≈ {:.3} mean, {:.3} p95, {:.4} largest region (half the halves' difference)",
                reference.key,
                noise.mean_delta_e,
                noise.p95_delta_e,
                noise.bias()
            )?;
            Ok(())
        }
        BenchCommand::Tradeoff(args) => tradeoff(args, out),
    }
}

/// `WIDTHxHEIGHT`, each side 1 to 16384 pixels, at most 8192² pixels in all.
fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let side = |s: &str| {
        s.trim()
            .parse::<u32>()
            .ok()
            .filter(|v| (1..=16384).contains(v))
    };
    text.split_once(['x', 'X', '×'])
        .and_then(|(w, h)| Some((side(w)?, side(h)?)))
        .filter(|&(w, h)| u64::from(w) * u64::from(h) <= 8192 * 8192)
        .ok_or_else(|| {
            format!("'{text}': use WIDTHxHEIGHT, each 1 to 16384 pixels, 8192x8192 at most")
        })
}

/// The lighting named on the command line: a setup, or a map file that exists.
fn lighting(name: &str) -> Result<Lighting, Failed> {
    let not_found = |status| {
        Failed::new(
            status,
            format!(
                "--environment '{name}': not a lighting setup ({}) and no such file",
                Lighting::SETUP_NAMES.join(", ")
            ),
        )
    };
    let lighting = Lighting::parse(name).map_err(|_| not_found(status::USAGE))?;
    match &lighting {
        Lighting::Map(path) if !path.exists() => Err(not_found(status::NO_INPUT)),
        _ => Ok(lighting),
    }
}

/// A glTF file, or the built-in car; a file that cannot be read is a missing
/// input, one that does not parse bad data.
fn scene(path: Option<&Path>) -> Result<Scene, Failed> {
    let Some(path) = path else {
        return Ok(generate(&CarParameters::default()));
    };
    load(path, &LoadOptions::default()).map_err(|error| {
        let class = match error {
            SceneError::Io { .. } | SceneError::MissingBuffer { .. } => status::NO_INPUT,
            _ => status::DATA,
        };
        Failed {
            status: class,
            error: error.into(),
        }
    })
}

/// One scene under one lighting.
#[derive(Debug, Clone)]
struct Case {
    scene: Option<PathBuf>,
    lighting: Lighting,
}

impl Case {
    fn scene_label(&self) -> String {
        match &self.scene {
            None => "default car".to_owned(),
            Some(p) => p
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("glTF")
                .to_owned(),
        }
    }

    fn label(&self) -> String {
        format!("{}, {}", self.scene_label(), self.lighting)
    }
}

#[derive(Debug, Clone, Copy)]
struct Protocol {
    size: (u32, u32),
    reference_spp: u32,
}

/// A case with its scene built once (BVH) and the design it paints.
struct PreparedCase {
    case: Case,
    scene: Arc<RenderScene>,
    design: PaintDesign,
}

impl PreparedCase {
    /// The protocol's camera: the scene-box framing (`Camera::framing`), which the
    /// committed quality presets and docs/tradeoff.md were measured with. It is not
    /// the car's default view (`RenderScene::default_camera`, which frames the car
    /// closer); moving the protocol to that view means measuring the presets again.
    fn camera(&self, width: u32, height: u32) -> Camera {
        Camera::framing(self.scene.bounds(), width, height)
    }

    fn new(case: &Case) -> Result<Self, Failed> {
        let loaded = scene(case.scene.as_deref())?;
        for warning in &loaded.warnings {
            eprintln!("xtask: warning: {warning}");
        }
        let scene = Arc::new(RenderScene::new(loaded).context("cannot prepare the scene")?);
        let design = presets::all()
            .into_iter()
            .next()
            .context("no built-in preset")?
            .design;
        Ok(Self {
            case: case.clone(),
            scene,
            design,
        })
    }
}

/// A knob setting of the sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Setting {
    wavelengths: usize,
    spp: u32,
    coat: CoatIntegralMethod,
    /// `None`: the design's own lobe.
    lobe: Option<LobeKind>,
    /// Render at 1/scale of the protocol size, then upsample.
    scale: u32,
    /// The RGB shortcut (`rgb`) instead of `wavelengths` wavelengths.
    rgb: bool,
}

impl Setting {
    fn spectral(wavelengths: usize, spp: u32) -> Self {
        Self {
            wavelengths,
            spp,
            coat: CoatIntegralMethod::Exact,
            lobe: None,
            scale: 1,
            rgb: false,
        }
    }

    fn rgb(spp: u32) -> Self {
        Self {
            rgb: true,
            ..Self::spectral(3, spp)
        }
    }

    /// Whether the app's quality presets can apply this setting (they change
    /// samples, wavelengths and resolution, never the model).
    fn app_applicable(&self) -> bool {
        self.coat == CoatIntegralMethod::Exact && self.lobe.is_none() && !self.rgb
    }

    fn knob_label(&self) -> String {
        let mut parts = Vec::new();
        if self.rgb {
            parts.push("RGB".to_owned());
        }
        if self.coat != CoatIntegralMethod::Exact {
            parts.push(self.coat.label());
        }
        if let Some(lobe) = self.lobe {
            parts.push(format!("{lobe:?} lobe").to_lowercase());
        }
        if self.scale != 1 {
            parts.push(format!("1/{} res", self.scale));
        }
        if parts.is_empty() {
            "spectral".to_owned()
        } else {
            parts.join(", ")
        }
    }
}

/// The default sweep: samples, wavelengths, the C integral, the lobe, resolution.
fn default_settings() -> Vec<Setting> {
    let mut settings = Vec::new();
    for spp in [1, 4, 16, 64, 256] {
        settings.push(Setting::spectral(32, spp));
    }
    for wavelengths in [3, 8, 16, 81] {
        for spp in [4, 16, 64] {
            settings.push(Setting::spectral(wavelengths, spp));
        }
    }
    for spp in [4, 16, 64] {
        settings.push(Setting::rgb(spp));
    }
    for coat in [
        CoatIntegralMethod::GaussLegendre { order: 2 },
        CoatIntegralMethod::GaussLegendre { order: 8 },
        CoatIntegralMethod::FittedFdr,
    ] {
        settings.push(Setting {
            coat,
            ..Setting::spectral(32, 64)
        });
    }
    settings.push(Setting {
        lobe: Some(LobeKind::Paper),
        ..Setting::spectral(32, 64)
    });
    for scale in [2, 4] {
        for spp in [4, 16, 64, 256] {
            settings.push(Setting {
                scale,
                ..Setting::spectral(32, spp)
            });
        }
    }
    settings
}

fn quick_settings() -> Vec<Setting> {
    vec![
        Setting::spectral(8, 1),
        Setting::spectral(8, 4),
        Setting::spectral(3, 4),
        Setting::rgb(4),
        Setting {
            coat: CoatIntegralMethod::FittedFdr,
            ..Setting::spectral(8, 4)
        },
        Setting {
            scale: 2,
            ..Setting::spectral(8, 4)
        },
    ]
}

/// A cached or freshly rendered reference.
struct Reference {
    key: String,
    halves: [XyzImage; 2],
    image: XyzImage,
    masks: RegionMasks,
    seconds: Option<f64>,
}

impl Reference {
    /// The reference's own noise: the two halves differ by about √2 × a half's
    /// noise = 2 × the whole reference's, so half their difference.
    fn noise(&self) -> ImageError {
        let e = image_error(
            &self.halves[0],
            &self.halves[1],
            &self.masks,
            &DisplaySettings::MEASURED,
        )
        .unwrap_or(ImageError {
            mean_delta_e: f64::NAN,
            p95_delta_e: f64::NAN,
            region_delta_e: [None; 3],
        });
        ImageError {
            mean_delta_e: e.mean_delta_e / 2.0,
            p95_delta_e: e.p95_delta_e / 2.0,
            region_delta_e: e.region_delta_e.map(|r| r.map(|v| v / 2.0)),
        }
    }
}

/// FNV-1a: a stable hash for cache keys (std's hasher may change between releases).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

fn reference_key(prepared: &PreparedCase, protocol: &Protocol) -> String {
    let scene = match &prepared.case.scene {
        // The car the sweep renders, written as GLB (the bytes of
        // assets/default-car.glb when that is up to date): a reference of an
        // earlier car is not read back.
        None => {
            let bytes = to_glb(&generate(&CarParameters::default())).unwrap_or_default();
            format!("default-car-{:08x}", fnv1a(&bytes) as u32)
        }
        Some(path) => {
            let bytes = std::fs::read(path).unwrap_or_default();
            format!(
                "{}-{:08x}",
                prepared.case.scene_label(),
                fnv1a(&bytes) as u32
            )
        }
    };
    let design = fnv1a(prepared.design.to_toml_string().as_bytes()) as u32;
    let lighting: String = prepared
        .case
        .lighting
        .name()
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect();
    format!(
        "{scene}_{lighting}_design-{design:08x}_{}x{}_{}spp_v{PROTOCOL_VERSION}-{}",
        protocol.size.0,
        protocol.size.1,
        protocol.reference_spp,
        env!("CARGO_PKG_VERSION")
    )
}

fn reference(
    prepared: &PreparedCase,
    protocol: &Protocol,
    cache: &Path,
    force: bool,
    out: &mut impl Write,
) -> Result<Reference, Failed> {
    let key = reference_key(prepared, protocol);
    let paths = [0, 1].map(|i| cache.join(format!("{key}.half{i}.xyz")));
    let camera = prepared.camera(protocol.size.0, protocol.size.1);
    let masks = RegionMasks::from_scene(&prepared.scene, &camera);
    for region in Region::ALL {
        if masks.count(region) == 0 {
            eprintln!(
                "xtask: warning: {}: no {} pixels in the protocol view",
                prepared.case.label(),
                region.label()
            );
        }
    }
    let cached = !force && paths.iter().all(|p| p.exists());
    let (halves, seconds) = if cached {
        let read = |p: &PathBuf| {
            XyzImage::read(p)
                .with_context(|| format!("reading the cached reference {key}"))
                .or_fail(status::DATA)
        };
        ([read(&paths[0])?, read(&paths[1])?], None)
    } else {
        writeln!(
            out,
            "rendering reference {key} ({} spp at 81 wavelengths)",
            protocol.reference_spp
        )?;
        out.flush()?;
        let start = Instant::now();
        let mut halves = Vec::new();
        for (seed, path) in HALF_SEEDS.iter().zip(&paths) {
            let setting = Setting::spectral(81, protocol.reference_spp / 2);
            let (image, _) = render(prepared, protocol, &setting, *seed)?;
            image.write(path).or_fail(status::CANT_CREATE)?;
            halves.push(image);
        }
        let [a, b]: [XyzImage; 2] = halves
            .try_into()
            .map_err(|_| anyhow::anyhow!("two halves expected"))?;
        ([a, b], Some(start.elapsed().as_secs_f64()))
    };
    let image = halves[0]
        .average(&halves[1])
        .context("averaging the halves")?;
    Ok(Reference {
        key,
        halves,
        image,
        masks,
        seconds,
    })
}

/// CPU time of every thread of this process so far, seconds: the sum of the
/// per-thread run times the scheduler reports (/proc/self/task/*/schedstat, ns).
/// Unlike wall time it hardly depends on what else the shared machine runs, so
/// the sweep ranks settings by it. `None` where /proc is missing.
fn process_cpu_seconds() -> Option<f64> {
    let mut total_ns = 0u64;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        total_ns += stat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(total_ns as f64 * 1e-9)
}

/// What a render cost: wall time and CPU time (both cores), seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Cost {
    wall: f64,
    cpu: f64,
}

/// Renders `setting` of a case; returns the image at the protocol size and its
/// cost (tables, environment and shading set-up included: a change of knob pays
/// them).
fn render(
    prepared: &PreparedCase,
    protocol: &Protocol,
    setting: &Setting,
    seed: u64,
) -> Result<(XyzImage, Cost), Failed> {
    let start = Instant::now();
    let cpu_start = process_cpu_seconds();
    let (grid, model) = if setting.rgb {
        let model = rgb::paint_model(&prepared.design).context("cannot reduce the paint to RGB")?;
        (Channels::LinearSrgb, model)
    } else {
        let grid = WavelengthGrid::visible(setting.wavelengths)
            .with_context(|| format!("{} wavelengths", setting.wavelengths))?;
        let model = prepared
            .design
            .model(grid)
            .context("cannot build the paint model")?;
        (Channels::Spectral(grid), model)
    };
    let mut model = model;
    model.set_coat_integral_method(setting.coat);
    if let Some(lobe) = setting.lobe {
        model.set_lobe(lobe);
    }
    let environment = prepared.case.lighting.build(&grid).map_err(|error| {
        let class = match error {
            EnvironmentError::Read(ImageReadError::Io { .. }) => status::NO_INPUT,
            _ => status::DATA,
        };
        Failed {
            status: class,
            error: error.into(),
        }
    })?;
    let shading = prepared.scene.shading(&model, ShadingModel::Paint);
    let (width, height) = (
        (protocol.size.0 / setting.scale).max(1),
        (protocol.size.1 / setting.scale).max(1),
    );
    let camera = prepared.camera(width, height);
    let mut render = ProgressiveRender::new(
        Arc::clone(&prepared.scene),
        Arc::new(environment),
        Arc::new(shading),
        camera,
        RenderSettings::seeded(seed),
    )
    .context("cannot start the render")?;
    render.render_to(setting.spp, 4);
    let image = XyzImage::from_film(render.film());
    let wall = start.elapsed().as_secs_f64();
    // Without /proc, wall time stands in (both cores busy: twice the wall time).
    let cpu = match (cpu_start, process_cpu_seconds()) {
        (Some(a), Some(b)) => b - a,
        _ => wall * rayon::current_num_threads() as f64,
    };
    let image = if setting.scale == 1 {
        image
    } else {
        image.resized(protocol.size.0, protocol.size.1)
    };
    Ok((image, Cost { wall, cpu }))
}

/// One measured row of the table.
#[derive(Debug, Clone)]
struct Row {
    case: String,
    setting: Setting,
    cost: Cost,
    error: ImageError,
    front: bool,
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|s| {
            let v: Vec<&str> = s.split_whitespace().take(3).collect();
            (v.len() == 3).then(|| v.join(" "))
        })
        .unwrap_or_else(|| "unknown".to_owned())
}

/// The protocol's glTF car: `--gltf`, else the Lamborghini under `--shared`.
fn protocol_gltf(args: &TradeoffArgs) -> Result<PathBuf, Failed> {
    let shared = match &args.shared {
        Some(dir) => Some((dir.clone(), "--shared")),
        None => std::env::var_os("COATLAB_SHARED")
            .filter(|dir| !dir.is_empty())
            .map(|dir| (dir.into(), "COATLAB_SHARED")),
    };
    let (path, given) = match (&args.gltf, shared) {
        (Some(path), _) => (path.clone(), "--gltf"),
        (None, Some((shared, given))) => (shared.join(SHARED_GLTF), given),
        (None, None) => {
            return Err(Failed::new(
                status::USAGE,
                "the protocol's glTF car: pass --gltf FILE, or --shared DIR (or set \
                 COATLAB_SHARED) for the shared test data's Lamborghini, or --no-gltf",
            ));
        }
    };
    if !path.exists() {
        return Err(Failed::new(
            status::NO_INPUT,
            format!(
                "{}: no such file (from {given}; or pass --no-gltf)",
                path.display()
            ),
        ));
    }
    Ok(path)
}

fn tradeoff(args: &TradeoffArgs, out: &mut impl Write) -> Result<(), Failed> {
    let (protocol, cases, settings) = if args.quick {
        (
            Protocol {
                size: (64, 36),
                reference_spp: 16,
            },
            vec![Case {
                scene: None,
                lighting: Lighting::Studio,
            }],
            quick_settings(),
        )
    } else {
        let mut cases = Vec::new();
        let mut scenes = vec![None];
        if !args.no_gltf {
            scenes.push(Some(protocol_gltf(args)?));
        }
        for scene in scenes {
            for lighting in [Lighting::Studio, Lighting::Booth(Illuminant::F11)] {
                cases.push(Case {
                    scene: scene.clone(),
                    lighting,
                });
            }
        }
        (
            Protocol {
                size: PROTOCOL_SIZE,
                reference_spp: REFERENCE_SPP,
            },
            cases,
            default_settings(),
        )
    };
    let threads = rayon::current_num_threads();
    let load_before = load_average();
    let started = Instant::now();
    let mut rows = Vec::new();
    let mut notes = Vec::new();
    for case in &cases {
        let prepared = PreparedCase::new(case)?;
        let reference = reference(&prepared, &protocol, &args.cache, false, out)?;
        let noise = reference.noise();
        notes.push(format!(
            "| {} | `{}` | {} | {:.3} | {:.3} | {} |",
            case.label(),
            reference.key,
            reference
                .seconds
                .map(|s| format!("{s:.0} s"))
                .unwrap_or_else(|| "cached".to_owned()),
            noise.mean_delta_e,
            noise.p95_delta_e,
            region_cells(&noise)
        ));
        // One discarded render first: the first render of a case also pays for
        // starting rayon's threads and faulting in the scene, which would make the
        // cheapest setting look dearer than it is.
        render(&prepared, &protocol, &Setting::spectral(8, 1), TEST_SEED)?;
        let first = rows.len();
        for setting in &settings {
            let (image, cost) = render(&prepared, &protocol, setting, TEST_SEED)?;
            let error = image_error(
                &image,
                &reference.image,
                &reference.masks,
                &DisplaySettings::MEASURED,
            )
            .context("comparing with the reference")?;
            writeln!(
                out,
                "{}: {} λ, {} spp, {}: {:.2} s CPU, {:.2} s wall, ΔE00 mean {:.2} p95 {:.2} bias {:.2}",
                case.label(),
                setting.wavelengths,
                setting.spp,
                setting.knob_label(),
                cost.cpu,
                cost.wall,
                error.mean_delta_e,
                error.p95_delta_e,
                error.bias()
            )?;
            out.flush()?;
            rows.push(Row {
                case: case.label(),
                setting: *setting,
                cost,
                error,
                front: false,
            });
        }
        mark_front(&mut rows[first..]);
    }
    let load_after = load_average();
    let total = started.elapsed().as_secs_f64();

    let table = table_markdown(
        &rows,
        &notes,
        &protocol,
        threads,
        &load_before,
        &load_after,
        total,
        args.quick,
    );
    write_between_markers(&args.doc, &table)?;
    let primary = cases.first().map(Case::label).unwrap_or_default();
    std::fs::write(&args.plot, plot_svg(&rows, &primary))
        .with_context(|| format!("writing {}", args.plot.display()))
        .or_fail(status::CANT_CREATE)?;
    let presets = choose_presets(&rows, &primary);
    if let Some(parent) = args.presets.parent() {
        std::fs::create_dir_all(parent).ok();
    }
    std::fs::write(&args.presets, presets_toml(&presets, &protocol, &primary))
        .with_context(|| format!("writing {}", args.presets.display()))
        .or_fail(status::CANT_CREATE)?;
    writeln!(
        out,
        "wrote {}, {} and {} ({} rows in {:.0} s, load {} → {})",
        args.doc.display(),
        args.plot.display(),
        args.presets.display(),
        rows.len(),
        total,
        load_before,
        load_after
    )?;
    Ok(())
}
