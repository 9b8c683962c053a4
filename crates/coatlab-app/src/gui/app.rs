//! The designer's window: the document (design, file, history), the panels, the
//! menus and shortcuts, files in and out, and drag and drop.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use coatlab_core::colour::spectrum::{ValueBounds, read_spectra_csv};
use coatlab_core::design::PaintDesign;
use coatlab_core::design::presets::{self, Preset};
use coatlab_core::export::{ExportFormat, export_to_file};
use coatlab_core::scene::gltf_loader::{LoadOptions, load};
use egui::{Color32, RichText, Ui};

use super::dialogs::{DialogEvent, DialogRequest, FileDialogs, NativeFileDialog};
use super::export;
use super::file_browser::FilePurpose;
use super::fit_job::{FitDone, FitJob};
use super::history::{Edit, History};
use super::instruments_panel::{InstrumentsRequest, InstrumentsView, instruments_ui};
use super::paint_panel::{PanelRequest, paint_controls_ui};
use super::plots::{PlotSettings, plots_ui};
use super::preview::{Preview, PreviewEvent, PreviewRequest};
use super::storage::{Recovery, Storage};
use super::target::{
    MeasuredTarget, Target, TargetView, compare, is_measurement, load_target, tolerance_of,
};
use coatlab_core::analysis::Analysis;
use coatlab_core::fit::{FitRequest, FreeParameters};
use coatlab_core::measurement::Geometry;

/// The File menu's design exports, in menu order.
pub const EXPORT_MENU: [(ExportFormat, &str); 3] = [
    (ExportFormat::Cxf, "Export design as CxF3…"),
    (ExportFormat::Cgats, "Export readings as CGATS.17…"),
    (ExportFormat::Gltf, "Export car as glTF (GLB)…"),
];

/// How often an unsaved design is autosaved.
pub const AUTOSAVE_INTERVAL: Duration = Duration::from_secs(5);
/// The environment variable that overrides [`AUTOSAVE_INTERVAL`], in seconds (the
/// crash-recovery test shortens it; docs/gui.md).
pub const AUTOSAVE_INTERVAL_VAR: &str = "COATLAB_AUTOSAVE_SECONDS";

/// The autosave interval: `COATLAB_AUTOSAVE_SECONDS` if set, else the default; a
/// value that is not a positive number of seconds is reported and ignored.
fn autosave_interval() -> Result<Duration, String> {
    let Some(value) = std::env::var_os(AUTOSAVE_INTERVAL_VAR) else {
        return Ok(AUTOSAVE_INTERVAL);
    };
    value
        .to_str()
        .and_then(|v| v.trim().parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s > 0.0 && *s <= 86_400.0)
        .map(Duration::from_secs_f64)
        .ok_or_else(|| {
            format!(
                "{AUTOSAVE_INTERVAL_VAR}={}: not a number of seconds in (0, 86400]; \
                 autosaving every {} s",
                value.to_string_lossy(),
                AUTOSAVE_INTERVAL.as_secs()
            )
        })
}

/// How the app starts.
#[derive(Debug, Clone, Default)]
pub struct AppOptions {
    /// Where recent files and the autosave live.
    pub storage: Storage,
    /// A design file to open at start.
    pub open: Option<PathBuf>,
    /// Run the live preview (a render thread). Off in headless tests that need the
    /// UI to settle; the window turns it on.
    pub preview: bool,
}

/// The tabs of the central area.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Tab {
    #[default]
    Preview,
    Plots,
    Instruments,
}

/// A message in the notice bar.
#[derive(Debug, Clone, PartialEq)]
pub struct Notice {
    pub is_error: bool,
    pub text: String,
}

/// The key the current analysis was computed for.
#[derive(Debug, Clone, PartialEq)]
struct AnalysisKey {
    design: PaintDesign,
    target: Option<Target>,
    phong: coatlab_core::paint::phong::PhongVariant,
}

/// The whole application state.
pub struct CoatlabApp {
    design: PaintDesign,
    path: Option<PathBuf>,
    /// The design as last saved or opened, to tell unsaved changes.
    saved: PaintDesign,
    history: History<Edit>,
    presets: Vec<Preset>,
    target: Option<Target>,
    /// The design against the target, computed with the analysis.
    target_view: Option<TargetView>,
    /// *Fit to target* while it runs, and its last report.
    fit_job: Option<FitJob>,
    fit_done: Option<FitDone>,
    /// What *Fit to target* may change (`coatlab fit --free`); ρ(λ) alone by default.
    fit_free: FreeParameters,
    analysis: Option<Analysis>,
    analysis_error: Option<String>,
    analysis_key: Option<AnalysisKey>,
    plot_settings: PlotSettings,
    tab: Tab,
    /// Open and save: the system's file dialog, or the in-app browser.
    dialogs: FileDialogs,
    notices: Vec<Notice>,
    storage: Storage,
    recent: Vec<PathBuf>,
    recovery: Option<Recovery>,
    autosave_interval: Duration,
    last_autosave: Instant,
    autosaved: Option<PaintDesign>,
    window_title: String,
    preview_enabled: bool,
    preview: Option<Preview>,
    preview_design: Option<PaintDesign>,
    /// The egui context of the last frame: the preview's render thread needs it to
    /// ask for repaints, and a dropped scene may start the preview.
    ctx: Option<egui::Context>,
}

impl CoatlabApp {
    /// The app on the default design (the signal red preset), or on `options.open`.
    pub fn new(options: AppOptions) -> Self {
        let presets = presets::all();
        let design = presets
            .iter()
            .find(|p| p.slug == "signal-red")
            .or_else(|| presets.first())
            .map(|p| p.design.clone())
            .unwrap_or_else(unreachable_default);
        let mut notices = Vec::new();
        if let Some(why) = options.storage.unavailable() {
            notices.push(Notice {
                is_error: true,
                text: why.to_owned(),
            });
        }
        let recovery = match options.storage.recovery() {
            Ok(r) => r,
            Err(e) => {
                notices.push(Notice {
                    is_error: true,
                    text: format!("{e:#}"),
                });
                None
            }
        };
        let autosave_interval = autosave_interval().unwrap_or_else(|e| {
            notices.push(Notice {
                is_error: true,
                text: e,
            });
            AUTOSAVE_INTERVAL
        });
        let mut app = Self {
            saved: design.clone(),
            history: History::new(Edit {
                design: design.clone(),
                paint: None,
            }),
            design,
            path: None,
            presets,
            target: None,
            target_view: None,
            fit_job: None,
            fit_done: None,
            fit_free: FreeParameters::default(),
            analysis: None,
            analysis_error: None,
            analysis_key: None,
            plot_settings: PlotSettings::default(),
            dialogs: FileDialogs::default(),
            notices,
            recent: options.storage.recent_files(),
            storage: options.storage,
            recovery,
            autosave_interval,
            last_autosave: Instant::now(),
            autosaved: None,
            window_title: String::new(),
            preview_enabled: options.preview,
            preview: None,
            preview_design: None,
            ctx: None,
            tab: if options.preview {
                Tab::Preview
            } else {
                Tab::Plots
            },
        };
        if let Some(path) = options.open {
            app.open_design(&path);
        }
        app
    }

    /// Replaces the system file dialog (the tests stand in for it); `None` leaves
    /// only the in-app browser.
    pub fn set_native_dialog(&mut self, native: Option<Arc<dyn NativeFileDialog>>) {
        self.dialogs = FileDialogs::new(native);
    }

    /// How files are chosen (the system dialog, the in-app browser).
    pub fn file_dialogs(&self) -> &FileDialogs {
        &self.dialogs
    }

    /// The design being edited.
    pub fn design(&self) -> &PaintDesign {
        &self.design
    }

    /// Replaces the design as an undoable edit (what every control ends up doing).
    pub fn set_design(&mut self, design: PaintDesign) {
        self.commit();
        self.design = design;
        self.commit();
    }

    /// The state an undo step restores: the design and the preview's paint
    /// materials.
    fn edit(&self) -> Edit {
        Edit {
            design: self.design.clone(),
            paint: self.preview.as_ref().and_then(Preview::paint_choice),
        }
    }

    /// Records the state as an undo step if it changed. A new scene's paint
    /// choice is not a step: it is taken as the committed one (the steps before
    /// it keep their designs; their choices of the old scene's materials are
    /// not applied to the new scene).
    fn commit(&mut self) {
        let current = self.edit();
        let scene = |e: &Edit| e.paint.as_ref().map(|p| p.scene.clone());
        if scene(&current) != scene(self.history.committed()) {
            let amended = Edit {
                paint: current.paint.clone(),
                ..self.history.committed().clone()
            };
            self.history.amend(amended);
        }
        self.history.commit(&current);
    }

    /// Takes `edit` back: the design, and the paint materials where the
    /// preview still shows the scene they were chosen on.
    fn restore(&mut self, edit: Edit) {
        self.design = edit.design;
        if let (Some(preview), Some(paint)) = (self.preview.as_mut(), edit.paint)
            && preview.scene().is_some_and(|s| s.name == paint.scene)
        {
            preview.set_paint_materials(paint.chosen);
        }
    }

    /// The file the design belongs to.
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }

    /// Whether the design differs from its file.
    pub fn is_dirty(&self) -> bool {
        self.design != self.saved
    }

    /// Messages shown in the notice bar, oldest first.
    pub fn notices(&self) -> &[Notice] {
        &self.notices
    }

    /// The current analysis, if the design is valid.
    pub fn analysis(&self) -> Option<&Analysis> {
        self.analysis.as_ref()
    }

    /// The live preview's latest frame statistics, once it has shown one.
    pub fn preview_status(&self) -> Option<&super::preview::PreviewFrame> {
        self.preview.as_ref().and_then(|p| p.status())
    }

    /// The live preview, once started.
    pub fn preview(&self) -> Option<&Preview> {
        self.preview.as_ref()
    }

    /// The live preview, started if it is enabled and not running yet (it needs a
    /// frame's egui context first).
    pub fn preview_mut(&mut self) -> Option<&mut Preview> {
        if self.preview.is_none()
            && self.preview_enabled
            && let Some(ctx) = &self.ctx
        {
            self.preview = Some(Preview::start(ctx, &self.design));
            self.preview_design = Some(self.design.clone());
        }
        self.preview.as_mut()
    }

    fn running_preview(&mut self, what: &str) -> Option<&mut Preview> {
        if self.preview_mut().is_none() {
            self.error(format!(
                "The live preview is off in this session; cannot {what}."
            ));
            return None;
        }
        self.tab = Tab::Preview;
        self.preview.as_mut()
    }

    /// Opens a glTF scene (.glb, .gltf) in the preview. It loads on the render
    /// thread; a file that fails shows an error and the current scene stays.
    pub fn open_scene(&mut self, path: &Path) {
        if let Some(p) = self.running_preview("open a scene") {
            p.open_scene(path);
        }
    }

    /// Opens an environment map (.hdr, .exr) as the preview's lighting.
    pub fn open_environment(&mut self, path: &Path) {
        if let Some(p) = self.running_preview("open an environment map") {
            p.open_environment(path);
        }
    }

    /// Writes the preview as PNG (as shown) or EXR (linear), atomically.
    pub fn export_preview(&mut self, path: &Path) {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        if !matches!(ext.as_deref(), Some("png") | Some("exr")) {
            return self.error(format!(
                "{}: export the preview as .png (as shown) or .exr (linear sRGB)",
                path.display()
            ));
        }
        if let Some(p) = self.running_preview("export the preview") {
            p.export(path);
        }
    }

    /// Uses a design file as the second design of the comparison.
    pub fn open_second_design(&mut self, path: &Path) {
        match PaintDesign::load(path) {
            Ok(d) => {
                let label = format!("{} ({})", d.name, path.display());
                if let Some(p) = self.running_preview("compare designs") {
                    p.set_second_design(&label, &d);
                }
            }
            Err(e) => self.error(format!("Could not open the design to compare with: {e}")),
        }
    }

    /// Selects a tab.
    pub fn set_tab(&mut self, tab: Tab) {
        self.tab = tab;
    }

    /// The target: a design, or a standard of a measurement file.
    pub fn target(&self) -> Option<&Target> {
        self.target.as_ref()
    }

    /// The design against the target (tolerances, swatches), once computed.
    pub fn target_view(&self) -> Option<&TargetView> {
        self.target_view.as_ref()
    }

    /// Whether *Fit to target* is running.
    pub fn is_fitting(&self) -> bool {
        self.fit_job.is_some()
    }

    /// The last fit's report.
    pub fn last_fit(&self) -> Option<&FitDone> {
        self.fit_done.as_ref()
    }

    /// Recent files, newest first.
    pub fn recent_files(&self) -> &[PathBuf] {
        &self.recent
    }

    /// The autosave offered for recovery, if any.
    pub fn pending_recovery(&self) -> Option<&Recovery> {
        self.recovery.as_ref()
    }

    fn error(&mut self, text: impl Into<String>) {
        self.notices.push(Notice {
            is_error: true,
            text: text.into(),
        });
    }

    fn info(&mut self, text: impl Into<String>) {
        self.notices.push(Notice {
            is_error: false,
            text: text.into(),
        });
    }

    /// Opens a design file. On failure the error is shown and the current design is
    /// left exactly as it was.
    pub fn open_design(&mut self, path: &Path) {
        match PaintDesign::load(path) {
            Ok(design) => {
                self.set_design(design.clone());
                self.saved = design;
                self.path = Some(path.to_owned());
                self.remember(path);
                self.info(format!("Opened {}", path.display()));
            }
            Err(e) => self.error(format!("Could not open the design: {e}")),
        }
    }

    /// Saves to `path` (atomically) and makes it the design's file.
    pub fn save_design_as(&mut self, path: &Path) {
        match self.design.save(path) {
            Ok(()) => {
                self.saved = self.design.clone();
                self.path = Some(path.to_owned());
                self.storage.clear_autosave();
                self.autosaved = None;
                self.remember(path);
                self.info(format!("Saved {}", path.display()));
            }
            Err(e) => self.error(format!("Could not save: {e}")),
        }
    }

    fn save(&mut self) {
        match self.path.clone() {
            Some(p) => self.save_design_as(&p),
            None => self.choose_file(FilePurpose::SaveDesign),
        }
    }

    fn remember(&mut self, path: &Path) {
        match self.storage.add_recent(path) {
            Ok(list) => self.recent = list,
            Err(e) => self.error(format!("{e:#}")),
        }
    }

    /// Imports ρ(λ) from a spectral CSV (the first sample column). The design is
    /// changed only if the result is a valid design.
    pub fn import_albedo_csv(&mut self, path: &Path) {
        let result = std::fs::File::open(path)
            .map_err(|e| format!("cannot read {}: {e}", path.display()))
            .and_then(|f| {
                read_spectra_csv(f, &path.display().to_string(), ValueBounds::UNIT)
                    .map_err(|e| e.to_string())
            });
        let csv = match result {
            Ok(csv) => csv,
            Err(e) => return self.error(format!("Could not import ρ(λ): {e}")),
        };
        let Some((column, _)) = csv.samples.first() else {
            return self.error(format!(
                "Could not import ρ(λ): {} has no sample column",
                path.display()
            ));
        };
        let column = column.clone();
        let mut design = self.design.clone();
        design.albedo = csv.tabulated(0);
        match design.validate() {
            Ok(()) => {
                self.set_design(design);
                let others = csv.samples.len() - 1;
                let note = if others > 0 {
                    format!(" ({others} further column(s) ignored)")
                } else {
                    String::new()
                };
                self.info(format!(
                    "Imported ρ(λ) from column \"{column}\" of {}{note}",
                    path.display()
                ));
            }
            Err(e) => self.error(format!(
                "Could not import ρ(λ) from {}: {e}",
                path.display()
            )),
        }
    }

    /// Uses a design or a measurement file (CGATS.17, CxF3) as the target. A file
    /// that cannot be read is reported and the target stays as it was.
    pub fn open_target(&mut self, path: &Path) {
        match load_target(path) {
            Ok(target) => {
                if let Target::Measured(m) = &target {
                    let count = m.standard_names().len();
                    let scale = m
                        .measurement
                        .reflectance_scale
                        .as_ref()
                        .map(|s| format!("; {s}"))
                        .unwrap_or_default();
                    self.info(format!(
                        "Target: {} ({} standard(s), {}{scale})",
                        path.display(),
                        count,
                        m.measurement.format
                    ));
                }
                self.set_target(Some(target));
            }
            Err(e) => self.error(format!("Could not open the target: {e:#}")),
        }
    }

    /// Sets the target; a fit's report belongs to the target it was made for.
    pub fn set_target(&mut self, target: Option<Target>) {
        if self.target != target {
            self.fit_done = None;
        }
        self.target = target;
    }

    /// Chooses the standard of a measurement target by its index in the file.
    pub fn select_target_sample(&mut self, index: usize) {
        self.change_measured_target(|m| m.selected = index);
    }

    /// States the geometry of a CSV target's readings.
    pub fn set_target_geometry(&mut self, geometry: Geometry) {
        self.change_measured_target(|m| m.set_geometry(geometry));
    }

    fn change_measured_target(&mut self, change: impl FnOnce(&mut MeasuredTarget)) {
        let Some(Target::Measured(m)) = &self.target else {
            return;
        };
        let mut m = m.clone();
        change(&mut m);
        self.set_target(Some(Target::Measured(m)));
    }

    /// What *Fit to target* may change.
    pub fn fit_free(&self) -> FreeParameters {
        self.fit_free
    }

    /// Sets what *Fit to target* may change (a setting of the window, not of the
    /// design: it is not undone).
    pub fn set_fit_free(&mut self, free: FreeParameters) {
        self.fit_free = free;
    }

    /// Fits the design's free parameters (see [`Self::set_fit_free`]) to the
    /// measured target on a thread of its own; the
    /// result is applied, as one undoable edit, when it arrives (see
    /// `take_fit`, called each frame).
    pub fn fit_to_target(&mut self) {
        if self.fit_job.is_some() {
            return self.error("A fit is already running.");
        }
        let Some(Target::Measured(m)) = &self.target else {
            return self.error(
                "Fit to target needs a measured target: choose a CGATS or CxF3 file as the target.",
            );
        };
        if !self.fit_free.any() {
            return self.error("Fit to target: nothing is free; tick ρ(λ) or a coat parameter.");
        }
        let tolerance = tolerance_of(&self.design);
        let request = FitRequest {
            free: self.fit_free,
        };
        match FitJob::start(
            self.ctx.as_ref(),
            self.design.clone(),
            m.clone(),
            tolerance,
            request,
        ) {
            Ok(job) => self.fit_job = Some(job),
            Err(e) => self.error(e),
        }
    }

    /// Takes up a finished fit: applied as one undoable edit if the design is still
    /// the one it started from, else reported and dropped.
    fn take_fit(&mut self) {
        let Some(answer) = self.fit_job.as_ref().and_then(FitJob::poll) else {
            return;
        };
        self.fit_job = None;
        match answer {
            Ok(done) if done.start == self.design => {
                self.set_design(done.fit.design.clone());
                self.info(format!(
                    "Fitted {} to sample {:?} of {} (Undo restores the design)",
                    done.fit.free.names().join(", "),
                    done.sample,
                    done.file
                ));
                self.fit_done = Some(done);
            }
            Ok(_) => self
                .error("The design changed while the fit ran; the fit was not applied. Fit again."),
            Err(e) => self.error(format!("Could not fit: {e}")),
        }
    }

    /// Undoes the last edit.
    pub fn undo(&mut self) {
        self.commit();
        if let Some(edit) = self.history.undo(&self.edit()) {
            self.restore(edit);
        }
    }

    /// Redoes the last undone edit.
    pub fn redo(&mut self) {
        if let Some(edit) = self.history.redo(&self.edit()) {
            self.restore(edit);
        }
    }

    /// Asks for a file for `purpose`: the system dialog on its own thread (the UI
    /// keeps drawing), or the in-app browser; the answer arrives in `show`.
    fn choose_file(&mut self, purpose: FilePurpose) {
        let dir = self
            .path
            .as_ref()
            .and_then(|p| p.parent().map(Path::to_owned))
            .or_else(|| std::env::current_dir().ok())
            .unwrap_or_else(|| PathBuf::from("/"));
        let name = match purpose {
            FilePurpose::SaveDesign => self
                .path
                .as_ref()
                .and_then(|p| p.file_name())
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| format!("{}.toml", slug(&self.design.name))),
            FilePurpose::ExportMeasurement => format!("{}-readings.csv", slug(&self.design.name)),
            FilePurpose::ExportPreviewImage => format!("{}.png", slug(&self.design.name)),
            FilePurpose::ExportDesign(format) => {
                format!("{}.{}", slug(&self.design.name), format.extensions()[0])
            }
            _ => String::new(),
        };
        let request = DialogRequest::for_purpose(purpose, dir, name);
        if let Some(text) = self.dialogs.request(self.ctx.as_ref(), request) {
            self.info(text);
        }
    }

    fn file_chosen(&mut self, purpose: FilePurpose, path: PathBuf) {
        match purpose {
            FilePurpose::OpenDesign => self.open_design(&path),
            FilePurpose::SaveDesign => self.save_design_as(&path),
            FilePurpose::ImportAlbedoCsv => self.import_albedo_csv(&path),
            FilePurpose::Target => self.open_target(&path),
            FilePurpose::ExportMeasurement => self.export_measurement(&path),
            FilePurpose::ExportPreviewImage => self.export_preview(&path),
            FilePurpose::ExportDesign(format) => self.export_design(format, &path),
            FilePurpose::OpenScene => self.open_scene(&path),
            FilePurpose::OpenEnvironment => self.open_environment(&path),
            FilePurpose::SecondDesign => self.open_second_design(&path),
        }
    }

    /// Writes the readings as CSV or JSON (by extension).
    pub fn export_measurement(&mut self, path: &Path) {
        let Some(analysis) = &self.analysis else {
            return self.error("The design is invalid; there are no readings to export.");
        };
        match export::write_measurement(path, analysis, &self.design.name, self.path.as_deref()) {
            Ok(()) => self.info(format!("Exported readings to {}", path.display())),
            Err(e) => self.error(format!("{e:#}")),
        }
    }

    /// Writes the design as an exchange file (`coatlab export`'s): CxF3 or CGATS.17
    /// readings, or glTF on the preview's scene (the built-in car until a scene
    /// is opened). The glTF material's ΔE00 per angle goes to the notice bar.
    pub fn export_design(&mut self, format: ExportFormat, path: &Path) {
        let scene = match format {
            ExportFormat::Gltf => match self.preview_scene_path() {
                Some(scene_path) => match load(&scene_path, &LoadOptions::default()) {
                    Ok(scene) => Some(scene),
                    Err(e) => return self.error(format!("{e}")),
                },
                None => None,
            },
            _ => None,
        };
        match export_to_file(&self.design, format, scene.as_ref(), path) {
            Ok(exported) => {
                let cost = exported.material.map(|m| {
                    let cells: Vec<String> = m
                        .delta_e00
                        .iter()
                        .map(|c| format!("{} {:.2}", c.geometry, c.delta_e00))
                        .collect();
                    format!("; the real-time material's ΔE00: {}", cells.join(", "))
                });
                self.info(format!(
                    "Exported {format} to {}{}",
                    path.display(),
                    cost.unwrap_or_default()
                ));
            }
            Err(e) => self.error(format!("{e}")),
        }
    }

    /// The file of the scene the preview shows (`None`: the built-in car).
    fn preview_scene_path(&self) -> Option<PathBuf> {
        self.preview
            .as_ref()
            .and_then(|p| p.scene())
            .and_then(|s| s.path.clone())
    }

    /// A file dropped on the window: a measurement file (CGATS.17, CxF3, told by
    /// its content) becomes the target, a design opens, a CSV becomes ρ(λ), a glTF
    /// scene or an environment map goes to the preview.
    pub fn file_dropped(&mut self, path: &Path) {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let binary = matches!(
            ext.as_deref(),
            Some("glb") | Some("gltf") | Some("hdr") | Some("exr")
        );
        if !binary && std::fs::read(path).is_ok_and(|bytes| is_measurement(&bytes)) {
            self.tab = Tab::Instruments;
            return self.open_target(path);
        }
        match ext.as_deref() {
            Some("toml") => self.open_design(path),
            Some("csv") => self.import_albedo_csv(path),
            Some("glb") | Some("gltf") => self.open_scene(path),
            Some("hdr") | Some("exr") => self.open_environment(path),
            _ => self.error(format!(
                "{}: not a design (.toml), a measurement (CGATS.17 text, CxF3 XML), a spectral \
                 CSV (.csv), a glTF scene (.glb, .gltf) or an environment map (.hdr, .exr)",
                path.display()
            )),
        }
    }

    /// Recomputes the analysis if the design, the target or the Phong variant changed.
    pub fn update_analysis(&mut self) {
        let key = AnalysisKey {
            design: self.design.clone(),
            target: self.target.clone(),
            phong: self.plot_settings.phong,
        };
        if self.analysis_key.as_ref() == Some(&key) {
            return;
        }
        match Analysis::compute(
            &key.design,
            key.target.as_ref().and_then(Target::design),
            key.phong,
        ) {
            Ok(a) => {
                self.target_view = key
                    .target
                    .as_ref()
                    .map(|t| compare(&a, t, &tolerance_of(&key.design)));
                self.analysis = Some(a);
                self.analysis_error = None;
            }
            Err(e) => {
                // Keep showing the last valid analysis is misleading next to an
                // invalid design: show none, and the reason.
                self.analysis = None;
                self.target_view = None;
                self.analysis_error = Some(e);
            }
        }
        self.analysis_key = Some(key);
    }

    fn autosave(&mut self, ctx: &egui::Context) {
        let pending = self.is_dirty() && self.autosaved.as_ref() != Some(&self.design);
        let elapsed = self.last_autosave.elapsed();
        if elapsed < self.autosave_interval {
            // egui draws only on input or when asked: without this, an edit followed
            // by no input and a finished preview would wait for the next event.
            if pending {
                ctx.request_repaint_after(self.autosave_interval - elapsed);
            }
            return;
        }
        self.last_autosave = Instant::now();
        if !self.is_dirty()
            || self.autosaved.as_ref() == Some(&self.design)
            || self.design.validate().is_err()
        {
            return;
        }
        match self.storage.autosave(&self.design, self.path.as_deref()) {
            Ok(()) => self.autosaved = Some(self.design.clone()),
            Err(e) => self.error(format!("Autosave failed: {e:#}")),
        }
    }

    /// Called when the window closes: a clean exit with everything saved leaves no
    /// autosave; unsaved changes are autosaved once more and offered next time.
    pub fn shutdown(&mut self) {
        if self.is_dirty() && self.design.validate().is_ok() {
            if let Err(e) = self.storage.autosave(&self.design, self.path.as_deref()) {
                eprintln!("coatlab: autosave on exit failed: {e:#}");
            }
        } else if !self.is_dirty() {
            self.storage.clear_autosave();
        }
    }

    fn shortcuts(&mut self, ctx: &egui::Context) {
        use egui::{Key, KeyboardShortcut, Modifiers};
        // A focused text field has its own undo; leave the keys to it.
        if ctx.egui_wants_keyboard_input() {
            return;
        }
        let redo_z = KeyboardShortcut::new(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z);
        let redo_y = KeyboardShortcut::new(Modifiers::COMMAND, Key::Y);
        let undo = KeyboardShortcut::new(Modifiers::COMMAND, Key::Z);
        let save = KeyboardShortcut::new(Modifiers::COMMAND, Key::S);
        let open = KeyboardShortcut::new(Modifiers::COMMAND, Key::O);
        // The more specific shortcut first: Ctrl+Shift+Z also matches Ctrl+Z's keys.
        if ctx.input_mut(|i| i.consume_shortcut(&redo_z) || i.consume_shortcut(&redo_y)) {
            self.redo();
        }
        if ctx.input_mut(|i| i.consume_shortcut(&undo)) {
            self.undo();
        }
        if ctx.input_mut(|i| i.consume_shortcut(&save)) {
            self.save();
        }
        if ctx.input_mut(|i| i.consume_shortcut(&open)) {
            self.choose_file(FilePurpose::OpenDesign);
        }
    }

    /// Draws the whole window into `ui` (the eframe entry point and the tests' harness
    /// both call this).
    pub fn show(&mut self, ui: &mut Ui) {
        let ctx = ui.ctx().clone();
        self.ctx = Some(ctx.clone());
        self.shortcuts(&ctx);
        let dropped: Vec<PathBuf> = ctx.input(|i| {
            i.raw
                .dropped_files
                .iter()
                .map(|f| f.path().to_owned())
                .collect()
        });
        for path in dropped {
            self.file_dropped(&path);
        }

        egui::Panel::top("menu").show(ui, |ui| self.menu_ui(ui));
        egui::Panel::bottom("notices").show(ui, |ui| self.notices_ui(ui));
        egui::Panel::left("paint")
            .resizable(true)
            .default_size(400.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| self.paint_panel_ui(ui));
            });
        self.update_analysis();
        self.central_ui(ui);
        self.after_frame(&ctx);
    }

    /// The paint controls, and the presets and imports they ask for.
    fn paint_panel_ui(&mut self, ui: &mut Ui) {
        for request in paint_controls_ui(ui, &mut self.design, &self.presets) {
            match request {
                PanelRequest::ImportAlbedoCsv => self.choose_file(FilePurpose::ImportAlbedoCsv),
                PanelRequest::LoadPreset(i) => {
                    if let Some(p) = self.presets.get(i) {
                        let d = p.design.clone();
                        self.set_design(d);
                    }
                }
            }
        }
    }

    /// The central panel: the recovery offer, the tabs and the chosen tab's content.
    fn central_ui(&mut self, ui: &mut Ui) {
        // The central panel's background is filled by us, around the preview's
        // images rather than under them (see `central_background`).
        let frame = egui::Frame::central_panel(ui.style());
        let panel_fill = frame.fill;
        let margin = frame.inner_margin;
        let frame = frame.fill(Color32::TRANSPARENT);
        egui::CentralPanel::default().frame(frame).show(ui, |ui| {
            let background = ui.painter().add(egui::Shape::Noop);
            let panel_rect = ui.max_rect() + margin;
            self.recovery_ui(ui);
            ui.horizontal(|ui| {
                ui.selectable_value(&mut self.tab, Tab::Preview, "Preview");
                ui.selectable_value(&mut self.tab, Tab::Plots, "Plots");
                ui.selectable_value(&mut self.tab, Tab::Instruments, "Instruments");
            });
            ui.separator();
            if let Some(e) = &self.analysis_error {
                ui.label(
                    RichText::new(format!(
                        "No plots or readings until the design is valid: {e}"
                    ))
                    .color(ui.visuals().error_fg_color),
                );
            }
            match self.tab {
                Tab::Preview => self.preview_ui(ui),
                Tab::Plots => plots_ui(ui, &mut self.plot_settings, self.analysis.as_ref()),
                Tab::Instruments => self.instruments_tab_ui(ui),
            }
            let covered = match (self.tab, &self.preview) {
                (Tab::Preview, Some(p)) => p.opaque_rects(),
                _ => &[],
            };
            ui.painter().set(
                background,
                central_background(panel_rect, covered, panel_fill),
            );
        });
    }

    /// The Instruments tab, and the targets and exports it asks for.
    fn instruments_tab_ui(&mut self, ui: &mut Ui) {
        let tolerance = tolerance_of(&self.design);
        let view = InstrumentsView {
            analysis: self.analysis.as_ref(),
            target: self.target.as_ref(),
            target_view: self.target_view.as_ref(),
            presets: &self.presets,
            tolerance: &tolerance,
            fitting: self.fit_job.is_some(),
            fit: self.fit_done.as_ref(),
            fit_free: self.fit_free,
        };
        let requests = egui::ScrollArea::vertical()
            .show(ui, |ui| instruments_ui(ui, &view))
            .inner;
        for request in requests {
            match request {
                InstrumentsRequest::TargetPreset(i) => {
                    let target = self
                        .presets
                        .get(i)
                        .map(|p| Target::Design(p.design.clone()));
                    self.set_target(target);
                }
                InstrumentsRequest::TargetFile => self.choose_file(FilePurpose::Target),
                InstrumentsRequest::ClearTarget => self.set_target(None),
                InstrumentsRequest::SelectSample(i) => self.select_target_sample(i),
                InstrumentsRequest::SetGeometry(g) => self.set_target_geometry(g),
                // Edited in place, like a slider: committed as one step when the
                // gesture ends.
                InstrumentsRequest::SetTolerance(t) => self.design.tolerance = Some(t),
                InstrumentsRequest::FitToTarget => self.fit_to_target(),
                InstrumentsRequest::SetFitFree(free) => self.fit_free = free,
                InstrumentsRequest::Export => self.choose_file(FilePurpose::ExportMeasurement),
            }
        }
    }

    /// What follows the panels each frame: files chosen in dialogs, the preview's
    /// notices, the drop overlay, the undo step, autosave and the window title.
    fn after_frame(&mut self, ctx: &egui::Context) {
        self.take_fit();
        for event in self.dialogs.show(ctx) {
            match event {
                DialogEvent::Chosen(purpose, path) => self.file_chosen(purpose, path),
                DialogEvent::Info(text) => self.info(text),
            }
        }
        // After the preview took up what its thread published this frame; shown in
        // the notice bar from the next frame on.
        let events = self
            .preview
            .as_mut()
            .map(Preview::take_events)
            .unwrap_or_default();
        if !events.is_empty() {
            ctx.request_repaint();
        }
        for e in events {
            match e {
                PreviewEvent::Info(text) => self.info(text),
                PreviewEvent::Error(text) => self.error(text),
            }
        }
        drop_overlay(ctx);

        // One undo step per gesture: commit once no button is held and no text field
        // is being typed in.
        let gesture_over = !ctx.input(|i| i.pointer.any_down()) && !ctx.egui_wants_keyboard_input();
        if gesture_over {
            self.commit();
        }
        self.autosave(ctx);
        let title = format!(
            "Coatlab — {}{}",
            self.design.name,
            if self.is_dirty() { " •" } else { "" }
        );
        // Only on change: a viewport command requests another frame.
        if title != self.window_title {
            ctx.send_viewport_cmd(egui::ViewportCommand::Title(title.clone()));
            self.window_title = title;
        }
    }

    fn preview_ui(&mut self, ui: &mut Ui) {
        if !self.preview_enabled {
            ui.label("The live preview is off in this session.");
            return;
        }
        let design = self.design.clone();
        let changed = self.preview_design.as_ref() != Some(&design);
        if self.preview_mut().is_none() {
            return;
        }
        let Some(preview) = self.preview.as_mut() else {
            return;
        };
        // Restart the render on any change of a valid design.
        if changed && design.validate().is_ok() {
            preview.set_design(&design);
        }
        let requests = preview.ui(ui, &self.presets);
        self.preview_design = Some(design);
        for r in requests {
            let purpose = match r {
                PreviewRequest::OpenScene => FilePurpose::OpenScene,
                PreviewRequest::OpenEnvironment => FilePurpose::OpenEnvironment,
                PreviewRequest::SecondDesignFile => FilePurpose::SecondDesign,
                PreviewRequest::Export => FilePurpose::ExportPreviewImage,
            };
            self.choose_file(purpose);
        }
    }

    fn menu_ui(&mut self, ui: &mut Ui) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Open design…  (Ctrl+O)").clicked() {
                    self.choose_file(FilePurpose::OpenDesign);
                }
                if ui.button("Save  (Ctrl+S)").clicked() {
                    self.save();
                }
                if ui.button("Save as…").clicked() {
                    self.choose_file(FilePurpose::SaveDesign);
                }
                ui.menu_button("Open recent", |ui| {
                    if self.recent.is_empty() {
                        ui.label("(none)");
                    }
                    for p in self.recent.clone() {
                        if ui.button(p.display().to_string()).clicked() {
                            self.open_design(&p);
                        }
                    }
                });
                ui.separator();
                if ui.button("Import ρ(λ) from CSV…").clicked() {
                    self.choose_file(FilePurpose::ImportAlbedoCsv);
                }
                if ui.button("Export readings (CSV, JSON)…").clicked() {
                    self.choose_file(FilePurpose::ExportMeasurement);
                }
                for (format, label) in EXPORT_MENU {
                    if ui.button(label).clicked() {
                        self.choose_file(FilePurpose::ExportDesign(format));
                    }
                }
                if ui
                    .button("Target from file (design, CGATS, CxF3, CSV)…")
                    .clicked()
                {
                    self.choose_file(FilePurpose::Target);
                }
                ui.separator();
                if ui.button("Open scene (glTF)…").clicked() {
                    self.choose_file(FilePurpose::OpenScene);
                }
                if ui.button("Open environment map (HDR, EXR)…").clicked() {
                    self.choose_file(FilePurpose::OpenEnvironment);
                }
                if ui.button("Export preview image (PNG, EXR)…").clicked() {
                    self.choose_file(FilePurpose::ExportPreviewImage);
                }
                ui.separator();
                if self.dialogs.has_native() {
                    let mut native = self.dialogs.use_native();
                    if ui
                        .checkbox(&mut native, "Use the system file dialog")
                        .on_hover_text("Off: files are chosen in the app's own browser")
                        .changed()
                    {
                        self.dialogs.set_use_native(native);
                    }
                }
                ui.separator();
                if ui.button("Quit").clicked() {
                    ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
                }
            });
            ui.menu_button("Edit", |ui| {
                let edit = self.edit();
                let (can_undo, can_redo) =
                    (self.history.can_undo(&edit), self.history.can_redo(&edit));
                for (enabled, label, action) in [
                    (can_undo, "Undo  (Ctrl+Z)", Self::undo as fn(&mut Self)),
                    (can_redo, "Redo  (Ctrl+Shift+Z)", Self::redo),
                ] {
                    if ui.add_enabled(enabled, egui::Button::new(label)).clicked() {
                        action(self);
                    }
                }
                ui.separator();
                let fittable = matches!(self.target, Some(Target::Measured(_)))
                    && self.fit_job.is_none()
                    && self.fit_free.any();
                if ui
                    .add_enabled(fittable, egui::Button::new("Fit to target"))
                    .on_disabled_hover_text(
                        "Needs a measured target (Instruments tab), something free to fit and no fit running",
                    )
                    .clicked()
                {
                    self.tab = Tab::Instruments;
                    self.fit_to_target();
                }
            });
            if self.dialogs.is_waiting() {
                ui.separator();
                ui.label(RichText::new("Waiting for the file dialog…").weak());
            }
            ui.separator();
            let file = self
                .path
                .as_ref()
                .map(|p| p.display().to_string())
                .unwrap_or_else(|| "not saved yet".into());
            ui.label(
                RichText::new(format!(
                    "{} — {file}{}",
                    self.design.name,
                    if self.is_dirty() { " (modified)" } else { "" }
                ))
                .weak(),
            );
        });
    }

    fn notices_ui(&mut self, ui: &mut Ui) {
        let mut dismiss = None;
        // The last three: older ones are history, the newest matter.
        let start = self.notices.len().saturating_sub(3);
        for (i, n) in self.notices.iter().enumerate().skip(start) {
            ui.horizontal(|ui| {
                if ui.small_button("x").on_hover_text("Dismiss").clicked() {
                    dismiss = Some(i);
                }
                let colour = if n.is_error {
                    ui.visuals().error_fg_color
                } else {
                    ui.visuals().text_color()
                };
                ui.label(RichText::new(&n.text).color(colour));
            });
        }
        if self.notices.is_empty() {
            ui.label(
                RichText::new(
                    "Drop a design (.toml), a measurement (CGATS, CxF3) as the target, a spectral \
                     CSV, a glTF scene (.glb, .gltf) or an environment map (.hdr, .exr) on the \
                     window to open it.",
                )
                .weak(),
            );
        }
        if let Some(i) = dismiss {
            self.notices.remove(i);
        }
    }

    fn recovery_ui(&mut self, ui: &mut Ui) {
        let Some(r) = &self.recovery else { return };
        let when = r
            .saved_at
            .and_then(|t| t.elapsed().ok())
            .map(|d| format!("{} min ago", d.as_secs() / 60))
            .unwrap_or_else(|| "earlier".into());
        let of = r
            .path
            .as_ref()
            .map(|p| format!(" of {}", p.display()))
            .unwrap_or_default();
        let mut choice = None;
        egui::Frame::group(ui.style())
            .fill(Color32::from_rgb(60, 50, 20))
            .show(ui, |ui| {
                ui.horizontal_wrapped(|ui| {
                    ui.label(format!(
                    "Unsaved changes to \"{}\"{of} from the last session were autosaved ({when}).",
                    r.design.name
                ));
                    if ui.button("Recover").clicked() {
                        choice = Some(true);
                    }
                    if ui.button("Discard").clicked() {
                        choice = Some(false);
                    }
                });
            });
        match choice {
            Some(true) => self.recover(),
            Some(false) => {
                self.recovery = None;
                self.storage.clear_autosave();
            }
            None => {}
        }
    }

    /// Takes the autosaved design (undoable), with its file if it had one.
    pub fn recover(&mut self) {
        if let Some(r) = self.recovery.take() {
            self.path = r.path.clone();
            // What is on disk (if anything) is what counts as saved.
            self.saved = r
                .path
                .as_ref()
                .and_then(|p| PaintDesign::load(p).ok())
                .unwrap_or_else(|| self.design.clone());
            self.set_design(r.design);
            self.info("Recovered the autosaved design.");
        }
    }
}

/// The central panel's fill: `panel` less the preview's opaque images. A software
/// rasteriser (lavapipe) shades every pixel of every shape, hidden or not, so a
/// fill under a picture that covers it costs as much as the picture; with the
/// preview shown, this halves the pixels drawn in the central panel.
fn central_background(panel: egui::Rect, covered: &[egui::Rect], fill: Color32) -> egui::Shape {
    egui::Shape::Vec(
        super::preview::uncovered(panel, covered)
            .into_iter()
            .map(|r| egui::Shape::rect_filled(r, 0.0, fill))
            .collect(),
    )
}

fn drop_overlay(ctx: &egui::Context) {
    if ctx.input(|i| i.raw.hovered_files.is_empty()) {
        return;
    }
    let screen = ctx.content_rect();
    let painter = ctx.layer_painter(egui::LayerId::new(
        egui::Order::Foreground,
        egui::Id::unique("drop"),
    ));
    painter.rect_filled(screen, 0.0, Color32::from_black_alpha(160));
    painter.text(
        screen.center(),
        egui::Align2::CENTER_CENTER,
        "Drop a design, a measurement, a spectral CSV, a glTF scene or an environment map",
        egui::FontId::proportional(24.0),
        Color32::WHITE,
    );
}

fn slug(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| {
            if c.is_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '-'
            }
        })
        .collect();
    let s = s.trim_matches('-').to_owned();
    if s.is_empty() { "design".into() } else { s }
}

fn unreachable_default() -> PaintDesign {
    // presets::all() is never empty; this keeps the app free of a panic path anyway.
    presets::all().swap_remove(0).design
}

impl eframe::App for CoatlabApp {
    fn ui(&mut self, ui: &mut Ui, _frame: &mut eframe::Frame) {
        self.show(ui);
    }

    fn on_exit(&mut self) {
        self.shutdown();
    }
}
