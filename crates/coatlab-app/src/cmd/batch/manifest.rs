//! The batch manifest (`docs/batch.md`): a versioned TOML file of designs ×
//! views × lighting × shading models at one quality and size, expanded in that
//! order (design outermost, model innermost) into numbered tasks, each one image.
//!
//! Every refusal names the manifest, the line and the key: a scheduler's log of
//! a failed array task is all a user may see.

use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

use coatlab_app::gui::quality::QualityPresets;
use coatlab_core::colour::spectrum::{MAX_VISIBLE_SAMPLES, WavelengthGrid};
use coatlab_core::colour::tolerance::Tolerance;
use coatlab_core::design::PaintDesign;
use coatlab_core::render::lighting::Lighting;
use coatlab_core::render::material::ShadingModel;
use serde::{Deserialize, Serialize};
use toml::Spanned;

use coatlab_core::render::view::{NamedView, ViewSpec};

use crate::cmd::render::{DEFAULT_WAVELENGTHS, parse_model, parse_size};

/// The value of the manifest's `format` key.
pub const FORMAT: &str = "coatlab-batch";
/// The manifest version this program reads.
pub const VERSION: i64 = 1;
/// The view of a manifest without a `views` key: the front three-quarter view.
pub const DEFAULT_VIEW: NamedView = NamedView::FrontThreeQuarter;

/// A manifest that cannot be used: the file, the line (where the problem is in
/// the file) and the key.
#[derive(Debug)]
pub struct ManifestError {
    pub path: PathBuf,
    pub line: Option<usize>,
    pub key: Option<String>,
    pub message: String,
}

impl fmt::Display for ManifestError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.path.display())?;
        if let Some(line) = self.line {
            write!(f, ", line {line}")?;
        }
        if let Some(key) = &self.key {
            write!(f, ", key `{key}`")?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for ManifestError {}

/// The manifest as written, every value with its place in the file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawManifest {
    format: Spanned<String>,
    version: Spanned<i64>,
    output: Spanned<String>,
    scene: Option<Spanned<String>>,
    designs: Spanned<Vec<Spanned<String>>>,
    views: Option<Spanned<Vec<Spanned<String>>>>,
    lighting: Spanned<Vec<Spanned<String>>>,
    models: Option<Spanned<Vec<Spanned<String>>>>,
    quality: Option<Spanned<String>>,
    spp: Option<Spanned<i64>>,
    wavelengths: Option<Spanned<i64>>,
    size: Option<Spanned<String>>,
    seed: Option<Spanned<i64>>,
    image: Option<Spanned<String>>,
    target: Option<Spanned<String>>,
    target_sample: Option<Spanned<String>>,
    tolerance: Option<Spanned<String>>,
}

/// One paint design of the manifest.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignEntry {
    /// The file, resolved against the manifest's folder.
    pub path: PathBuf,
    /// The design's own name.
    pub name: String,
    /// Its part of output names (the file's stem).
    pub slug: String,
}

/// One lighting of the manifest.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LightingEntry {
    /// What `coatlab render --environment` takes: a setup's name, or a map's
    /// path resolved against the manifest's folder.
    pub argument: String,
    /// Its part of output names.
    pub slug: String,
}

/// How many samples and wavelengths: a quality preset, or `spp = N`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Quality {
    /// The preset's name, or `spp = N`.
    pub label: String,
    pub samples_per_pixel: u32,
    pub wavelengths: usize,
}

/// The image format of the outputs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ImageFormat {
    Png,
    Exr,
}

impl ImageFormat {
    pub fn extension(self) -> &'static str {
        match self {
            ImageFormat::Png => "png",
            ImageFormat::Exr => "exr",
        }
    }
}

/// A checked manifest.
#[derive(Debug, Clone, PartialEq)]
pub struct Manifest {
    /// The manifest file.
    pub path: PathBuf,
    /// The output folder, resolved against the manifest's folder.
    pub output: PathBuf,
    /// A glTF file (resolved), or `None`: the built-in car.
    pub scene: Option<PathBuf>,
    pub designs: Vec<DesignEntry>,
    /// The `views` entries, canonical (a turntable once, as `turntable:N`);
    /// [`view_frames`] gives the single views, one task each.
    pub views: Vec<String>,
    pub lighting: Vec<LightingEntry>,
    /// The models with the names they were given (paint, phong-naive, phong-fit).
    pub models: Vec<(String, ShadingModel)>,
    pub quality: Quality,
    pub size: (u32, u32),
    pub seed: u64,
    pub image: ImageFormat,
    /// A design or a measurement to compare against (for the review deck).
    pub target: Option<PathBuf>,
    /// The standard of a measurement file with several: its name, id or number
    /// from 1 (`None`: the only one, else the one named like each design).
    pub target_sample: Option<String>,
    /// The review deck's pass/fail limits (default ΔE00 ≤ 1 at every angle).
    pub tolerance: Tolerance,
}

/// One numbered task: one image.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Task {
    pub index: usize,
    pub design: DesignEntry,
    pub view: String,
    pub lighting: LightingEntry,
    pub model: String,
    #[serde(skip)]
    pub shading_model: ShadingModel,
    /// The image's file name in the output folder; the sidecar is it + `.json`.
    pub output: String,
}

impl Manifest {
    /// Reads and checks the manifest at `path`.
    pub fn load(path: &Path) -> Result<Manifest, ManifestError> {
        let text = std::fs::read_to_string(path).map_err(|e| ManifestError {
            path: path.to_owned(),
            line: None,
            key: None,
            message: format!("cannot read it: {e}"),
        })?;
        Self::parse(path, &text)
    }

    /// Checks the manifest `text` read from `path` (relative paths in it are
    /// resolved against `path`'s folder).
    pub fn parse(path: &Path, text: &str) -> Result<Manifest, ManifestError> {
        let at = |span: Range<usize>, key: &str, message: String| ManifestError {
            path: path.to_owned(),
            line: Some(line_of(text, span.start)),
            key: Some(key.to_owned()),
            message,
        };
        let raw: RawManifest = toml::from_str(text).map_err(|e| ManifestError {
            path: path.to_owned(),
            line: e.span().map(|s| line_of(text, s.start)),
            key: None,
            message: e.message().trim().to_owned(),
        })?;
        let folder = path.parent().unwrap_or(Path::new("."));
        let resolve = |p: &str| folder.join(p);
        // A path in the manifest, resolved, that must name a file: else refused
        // with the key, the line and the file it was taken for.
        let existing = |entry: &Spanned<String>, key: &str, what: &str| {
            let file = resolve(entry.get_ref());
            if file.is_file() {
                Ok(file)
            } else {
                Err(at(
                    entry.span(),
                    key,
                    format!("'{}': no such {what} ({})", entry.get_ref(), file.display()),
                ))
            }
        };

        // The header: what kind of file this is, and which version of it.
        let header = [
            (
                raw.format.get_ref() == FORMAT,
                raw.format.span(),
                "format",
                format!(
                    "'{}': a batch manifest says format = \"{FORMAT}\"",
                    raw.format.get_ref()
                ),
            ),
            (
                *raw.version.get_ref() == VERSION,
                raw.version.span(),
                "version",
                format!(
                    "version {}: this program reads version {VERSION}",
                    raw.version.get_ref()
                ),
            ),
        ];
        if let Some((_, span, key, message)) = header.into_iter().find(|(ok, ..)| !ok) {
            return Err(at(span, key, message));
        }
        if raw.output.get_ref().trim().is_empty() {
            return Err(at(raw.output.span(), "output", "names no folder".into()));
        }
        let output = resolve(raw.output.get_ref());

        let scene = match &raw.scene {
            None => None,
            Some(s) if s.get_ref() == "builtin" => None,
            Some(s) => Some(existing(s, "scene", "glTF file")?),
        };

        let designs = non_empty(&raw.designs, "designs", &at)?;
        let mut design_entries = Vec::new();
        for entry in designs {
            let file = existing(entry, "designs", "design file")?;
            let design = PaintDesign::load(&file)
                .map_err(|e| at(entry.span(), "designs", format!("{e}")))?;
            design_entries.push((
                entry.span(),
                DesignEntry {
                    slug: slug(
                        file.file_stem()
                            .and_then(|s| s.to_str())
                            .unwrap_or("design"),
                    ),
                    path: file,
                    name: design.name,
                },
            ));
        }
        unique(&design_entries, |d| &d.slug, "designs", &at)?;

        let views = match &raw.views {
            None => vec![DEFAULT_VIEW.name().to_owned()],
            Some(views) => {
                let mut names = Vec::new();
                let mut frames = Vec::new();
                for view in non_empty(views, "views", &at)? {
                    let spec = view
                        .get_ref()
                        .parse::<ViewSpec>()
                        .map_err(|e| at(view.span(), "views", e.to_string()))?;
                    names.push(spec.to_string());
                    frames.extend(spec.frames().iter().map(|f| (view.span(), f.to_string())));
                }
                // Two entries that share a frame would write one output twice.
                unique(&frames, |frame| frame, "views", &at)?;
                names
            }
        };

        let mut lighting = Vec::new();
        for entry in non_empty(&raw.lighting, "lighting", &at)? {
            let name = entry.get_ref();
            let unknown = || {
                at(
                    entry.span(),
                    "lighting",
                    format!(
                        "'{name}': not a lighting setup ({}) and no such map file",
                        Lighting::SETUP_NAMES.join(", ")
                    ),
                )
            };
            let parsed = Lighting::parse(name).map_err(|_| unknown())?;
            let lighting_entry = match parsed {
                Lighting::Map(map) => {
                    let file = resolve(&map.to_string_lossy());
                    if !file.is_file() {
                        return Err(unknown());
                    }
                    LightingEntry {
                        slug: slug(file.file_stem().and_then(|s| s.to_str()).unwrap_or("map")),
                        argument: file.to_string_lossy().into_owned(),
                    }
                }
                setup => LightingEntry {
                    argument: setup.name(),
                    slug: slug(&setup.name()),
                },
            };
            lighting.push((entry.span(), lighting_entry));
        }
        unique(&lighting, |l| &l.slug, "lighting", &at)?;

        let models = match &raw.models {
            None => vec![("paint".to_owned(), ShadingModel::Paint)],
            Some(models) => {
                let mut parsed = Vec::new();
                for model in non_empty(models, "models", &at)? {
                    let shading =
                        parse_model(model.get_ref()).map_err(|e| at(model.span(), "models", e))?;
                    parsed.push((model.span(), (model.get_ref().clone(), shading)));
                }
                unique(&parsed, |(name, _)| name, "models", &at)?;
                parsed.into_iter().map(|(_, entry)| entry).collect()
            }
        };

        let quality = quality(path, &raw, &at)?;
        let size = match &raw.size {
            None => (960, 540),
            Some(size) => parse_size(size.get_ref()).map_err(|e| at(size.span(), "size", e))?,
        };
        let seed = match &raw.seed {
            None => 0,
            Some(seed) => u64::try_from(*seed.get_ref()).map_err(|_| {
                at(
                    seed.span(),
                    "seed",
                    format!("{}: must be 0 or more", seed.get_ref()),
                )
            })?,
        };
        let image = match raw.image.as_ref().map(|i| (i.span(), i.get_ref().as_str())) {
            None | Some((_, "png")) => ImageFormat::Png,
            Some((_, "exr")) => ImageFormat::Exr,
            Some((span, other)) => {
                return Err(at(span, "image", format!("'{other}': use png or exr")));
            }
        };
        let target = match &raw.target {
            None => None,
            Some(t) => Some(existing(t, "target", "file")?),
        };
        if let (None, Some(sample)) = (&target, &raw.target_sample) {
            return Err(at(
                sample.span(),
                "target_sample",
                "chooses a standard of the target's measurement file: give target too".into(),
            ));
        }
        let tolerance = match &raw.tolerance {
            None => Tolerance::default(),
            Some(t) => t
                .get_ref()
                .parse()
                .map_err(|e| at(t.span(), "tolerance", format!("'{}': {e}", t.get_ref())))?,
        };
        Ok(Manifest {
            path: path.to_owned(),
            output,
            scene,
            designs: design_entries.into_iter().map(|(_, d)| d).collect(),
            views,
            lighting: lighting.into_iter().map(|(_, l)| l).collect(),
            models,
            quality,
            size,
            seed,
            image,
            target,
            target_sample: raw.target_sample.map(|s| s.into_inner()),
            tolerance,
        })
    }

    /// The tasks in their fixed order: design, then view, then lighting, then
    /// model (the last varies fastest), numbered from 0.
    pub fn tasks(&self) -> Vec<Task> {
        let mut tasks = Vec::new();
        for design in &self.designs {
            for view in self.views.iter().flat_map(|v| view_frames(v)) {
                for lighting in &self.lighting {
                    for (model, shading_model) in &self.models {
                        tasks.push(Task {
                            index: tasks.len(),
                            design: design.clone(),
                            view: view.clone(),
                            lighting: lighting.clone(),
                            model: model.clone(),
                            shading_model: *shading_model,
                            output: format!(
                                "{}--{}--{}--{}.{}",
                                design.slug,
                                view.replace(':', "-"),
                                lighting.slug,
                                model,
                                self.image.extension()
                            ),
                        });
                    }
                }
            }
        }
        tasks
    }
}

/// The single views of the manifest's `views` entry `view`: a turntable's
/// frames (`turntable:N:K`, one task each), or the view itself.
pub fn view_frames(view: &str) -> Vec<String> {
    match view.parse::<ViewSpec>() {
        Ok(spec) => spec.frames().iter().map(ViewSpec::to_string).collect(),
        Err(_) => vec![view.to_owned()],
    }
}

/// The quality: exactly one of `quality` (a preset's name) and `spp`;
/// `wavelengths` overrides the preset's (or the default with `spp`).
fn quality(
    path: &Path,
    raw: &RawManifest,
    at: &impl Fn(Range<usize>, &str, String) -> ManifestError,
) -> Result<Quality, ManifestError> {
    let wavelengths = match &raw.wavelengths {
        None => None,
        Some(w) => {
            let ok = usize::try_from(*w.get_ref())
                .ok()
                .filter(|&n| WavelengthGrid::visible(n).is_ok());
            Some(ok.ok_or_else(|| {
                at(
                    w.span(),
                    "wavelengths",
                    format!("{}: must be 1 to {MAX_VISIBLE_SAMPLES}", w.get_ref()),
                )
            })?)
        }
    };
    match (&raw.quality, &raw.spp) {
        (Some(q), Some(s)) => Err(at(
            s.span(),
            "spp",
            format!("give either quality = \"{}\" or spp, not both", q.get_ref()),
        )),
        (None, None) => Err(ManifestError {
            path: path.to_owned(),
            line: None,
            key: Some("quality".into()),
            message: "missing: give a quality preset's name or spp = N".into(),
        }),
        (None, Some(spp)) => {
            let n = u32::try_from(*spp.get_ref())
                .ok()
                .filter(|&n| n > 0)
                .ok_or_else(|| {
                    at(
                        spp.span(),
                        "spp",
                        format!("{}: must be 1 or more", spp.get_ref()),
                    )
                })?;
            Ok(Quality {
                label: format!("spp = {n}"),
                samples_per_pixel: n,
                wavelengths: wavelengths.unwrap_or(DEFAULT_WAVELENGTHS),
            })
        }
        (Some(q), None) => {
            let presets = QualityPresets::embedded()
                .map_err(|e| at(q.span(), "quality", format!("the built-in presets: {e}")))?;
            let preset = presets
                .presets
                .iter()
                .find(|p| p.name.eq_ignore_ascii_case(q.get_ref()))
                .ok_or_else(|| {
                    let names: Vec<String> = presets
                        .presets
                        .iter()
                        .map(|p| p.name.to_lowercase())
                        .collect();
                    at(
                        q.span(),
                        "quality",
                        format!(
                            "'{}': not a quality preset ({}); or give spp = N",
                            q.get_ref(),
                            names.join(", ")
                        ),
                    )
                })?;
            Ok(Quality {
                label: preset.name.to_lowercase(),
                samples_per_pixel: preset.samples_per_pixel,
                wavelengths: wavelengths.unwrap_or(preset.wavelengths),
            })
        }
    }
}

/// The entries of a list key, refused when empty.
fn non_empty<'a>(
    list: &'a Spanned<Vec<Spanned<String>>>,
    key: &str,
    at: &impl Fn(Range<usize>, &str, String) -> ManifestError,
) -> Result<&'a [Spanned<String>], ManifestError> {
    if list.get_ref().is_empty() {
        return Err(at(list.span(), key, "the list is empty".into()));
    }
    Ok(list.get_ref())
}

/// Refuses the second of two entries that give the same part of output names.
fn unique<T>(
    entries: &[(Range<usize>, T)],
    slug: impl Fn(&T) -> &String,
    key: &str,
    at: &impl Fn(Range<usize>, &str, String) -> ManifestError,
) -> Result<(), ManifestError> {
    for (i, (span, entry)) in entries.iter().enumerate() {
        let name = slug(entry);
        if entries[..i].iter().any(|(_, other)| slug(other) == name) {
            return Err(at(
                span.clone(),
                key,
                format!(
                    "'{name}' is there twice: every output needs its own name (rename a file, \
                     or list it once)"
                ),
            ));
        }
    }
    Ok(())
}

/// 1-based line of byte `offset` in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].matches('\n').count() + 1
}

/// `name` as a part of a file name: letters, digits, `-` and `_`; anything
/// else becomes `-`.
fn slug(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c.to_ascii_lowercase()
            } else {
                '-'
            }
        })
        .collect()
}
