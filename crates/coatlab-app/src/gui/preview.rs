//! The live preview: the progressive path tracer of `coatlab-core` on a background
//! thread, its latest images shown as textures.
//!
//! The UI never waits on the renderer. It sends commands (a new design, a camera
//! move, another environment or scene, a new size, an export) over a channel and
//! raises a cancel flag so a pass in flight stops at its next tile; the render
//! thread drains the commands, restarts, renders one coarse pass at a quarter of the
//! resolution so a new image appears at once, then refines at full resolution one
//! sample per pixel per pass. After each pass it publishes the display images (sRGB
//! bytes) in a shared slot and asks egui for a repaint; the UI uploads the newest
//! images when there are some.
//!
//! Comparisons share the work: the first view records its paths
//! ([`COMPARE_CACHE_SAMPLES`] samples per pixel, within the core's path-cache
//! budget) and the second view is those same paths re-shaded with the second
//! model or design (`ProgressiveRender::reshade_recorded`), so the difference
//! between the panes carries only the noise of the difference, not that of two
//! renders. Where re-shading cannot apply (a paint that is an ideal mirror on
//! one side only) the second view is rendered on its own with the same scene,
//! lighting, camera and seed, one pass of each in turn, and the UI says so. Both
//! are shown with the same exposure. Files (glTF scenes, environment maps) are
//! read on the render thread too; what happens is reported back as events the app
//! shows in its notice bar.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, TryRecvError, channel};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use coatlab_core::colour::cie::Illuminant;
use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::design::PaintDesign;
use coatlab_core::design::presets::Preset;
use coatlab_core::paint::model::PaintModel;
use coatlab_core::paint::phong::PhongVariant;
use coatlab_core::render::camera::Camera;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::{DisplaySettings, Film, display_xyz};
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::{
    EditOutcome, PassStats, ProgressiveRender, RenderScene, RenderSettings,
};
use coatlab_core::render::reshade::{ReshadeError, Reshaded};
use coatlab_core::scene::car::{CarParameters, generate};
use coatlab_core::scene::gltf_loader::{LoadOptions, load};
use coatlab_core::scene::{Scene, SceneMaterial};
use egui::{Color32, RichText, Ui};

use super::compare::{CompareLayout, CompareMode, DeltaEMap, SCALES, legend_ui};
use super::quality::{QualityKnobs, QualitySelector};

/// Wavelengths per path: as `coatlab render` by default.
pub(super) const PREVIEW_WAVELENGTHS: usize = 32;
/// The coarse first pass renders at 1/COARSE_FACTOR of the resolution.
const COARSE_FACTOR: u32 = 4;
/// Refinement stops here; the image is then as good as the preview gets.
pub(super) const MAX_SPP: u32 = 1024;
/// Samples per pixel whose paths the first view records for re-shading paint
/// edits (`ProgressiveRender::edit_shading`; memory bounded by the core's
/// default path-cache budget).
const RESHADE_SAMPLES: u32 = 4;
/// Samples per pixel the first view records in a comparison, for the second
/// view to be re-shaded from: the difference between the panes has the noise
/// of this many samples of the difference. The core's memory budget
/// (`DEFAULT_PATH_CACHE_BUDGET_BYTES`) stops the recording earlier if it must.
pub(super) const COMPARE_CACHE_SAMPLES: u32 = 16;
/// The preview's largest size in pixels (it renders at most this, scaled up on screen):
/// the default keeps the first image within reach of a 2-core machine.
const MAX_PREVIEW_PIXELS: (u32, u32) = (640, 400);
/// Gap between side-by-side panes, points.
const PANE_GAP: f32 = 4.0;
/// Width kept for the ΔE00 legend, points.
const LEGEND_WIDTH: f32 = 64.0;

/// The lighting setups offered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EnvironmentChoice {
    Studio,
    BoothD65,
    BoothA,
    BoothF11,
    Outdoor,
    /// The environment map last opened (.hdr or .exr).
    Image,
}

impl EnvironmentChoice {
    /// The built-in setups (an image is offered once one is open).
    pub const ALL: [EnvironmentChoice; 5] = [
        EnvironmentChoice::Studio,
        EnvironmentChoice::BoothD65,
        EnvironmentChoice::BoothA,
        EnvironmentChoice::BoothF11,
        EnvironmentChoice::Outdoor,
    ];

    pub fn label(self) -> &'static str {
        match self {
            EnvironmentChoice::Studio => "Studio",
            EnvironmentChoice::BoothD65 => "Light booth D65",
            EnvironmentChoice::BoothA => "Light booth A",
            EnvironmentChoice::BoothF11 => "Light booth F11",
            EnvironmentChoice::Outdoor => "Outdoor",
            EnvironmentChoice::Image => "Environment map",
        }
    }

    fn build(self, grid: &WavelengthGrid) -> Option<Environment> {
        Some(match self {
            EnvironmentChoice::Studio => Environment::studio(grid),
            EnvironmentChoice::BoothD65 => Environment::booth(Illuminant::D65, grid),
            EnvironmentChoice::BoothA => Environment::booth(Illuminant::A, grid),
            EnvironmentChoice::BoothF11 => Environment::booth(Illuminant::F11, grid),
            EnvironmentChoice::Outdoor => Environment::outdoor(grid),
            EnvironmentChoice::Image => return None,
        })
    }
}

/// What the two views render: the first view's model, and the second view's design
/// (`None`: the same design) and model, if there is a second view.
#[derive(Debug, Clone, PartialEq)]
struct Views {
    model_a: ShadingModel,
    b: Option<(Option<Box<PaintDesign>>, ShadingModel)>,
}

enum Command {
    Design(Box<PaintDesign>),
    Views(Views),
    Environment(EnvironmentChoice),
    EnvironmentFile(PathBuf),
    Scene(Option<PathBuf>),
    PaintMaterial(Option<u32>),
    Resize(u32, u32),
    Orbit(f32, f32),
    Zoom(f32),
    Pan(f32, f32),
    Export(PathBuf),
    Quality(QualityKnobs),
}

impl Command {
    /// Whether the command changes the picture (exports do not).
    fn changes_picture(&self) -> bool {
        !matches!(self, Command::Export(_))
    }
}

/// A command with the number of the last picture-changing command sent with or
/// before it, so a published image says which change it already shows.
struct Envelope {
    epoch: u64,
    command: Command,
}

/// One published image.
#[derive(Debug, Clone)]
pub struct PreviewFrame {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[u8; 4]>,
    pub samples_per_pixel: u32,
    pub samples_per_second: f64,
    /// Mean ΔE00 of the noise left, when the film can estimate it.
    pub noise_delta_e: Option<f64>,
    /// The coarse first pass after a change.
    pub coarse: bool,
    /// A paint edit shown re-shaded from the previous design's samples: the share
    /// (0–1) the fresh samples of the new design already carry in the image.
    /// `None`: the image is the new design's own samples alone.
    pub reshaded: Option<f64>,
    /// The last change this image shows (see [`Preview::last_change_latency`]).
    pub epoch: u64,
    /// The second view of a comparison: how it was made. `None` for the first.
    pub source: Option<SecondSource>,
}

/// How the second view of a comparison is made.
#[derive(Debug, Clone, PartialEq)]
pub enum SecondSource {
    /// Re-shaded from the first view's recorded paths (this many samples per
    /// pixel): both panes show the same samples.
    Shared { recorded_spp: u32 },
    /// Rendered on its own (same camera and seed), for the reason given.
    Independent { reason: String },
}

impl SecondSource {
    /// The line the preview shows under a comparison.
    pub fn label(&self) -> String {
        match self {
            SecondSource::Shared { recorded_spp } => format!(
                "Shared samples: the second view re-shades the first view's paths \
                 ({recorded_spp} spp recorded), so the difference shows the models, not noise"
            ),
            SecondSource::Independent { reason } => {
                format!("Independent renders (same camera and seed): {reason}")
            }
        }
    }
}

/// The scene being rendered, as the UI shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneInfo {
    /// "Built-in car" or the file name.
    pub name: String,
    /// Its file; `None` for the built-in car.
    pub path: Option<PathBuf>,
    /// Material names, by index.
    pub materials: Vec<String>,
    /// Materials that carry the paint as the loader chose them.
    pub automatic_paint: Vec<u32>,
    /// Problems that did not stop the load.
    pub warnings: Vec<String>,
}

/// Something the app should tell the user.
#[derive(Debug, Clone, PartialEq)]
pub enum PreviewEvent {
    Info(String),
    Error(String),
}

#[derive(Default)]
struct Shared {
    frames: [Option<PreviewFrame>; 2],
    delta_e: Option<DeltaEMap>,
    fresh: bool,
    fresh_map: bool,
    scene: Option<SceneInfo>,
    environment_loaded: Option<String>,
    events: Vec<PreviewEvent>,
}

/// Something the preview needs the app for (a file browser).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PreviewRequest {
    OpenScene,
    OpenEnvironment,
    SecondDesignFile,
    Export,
}

/// The preview's UI-side handle.
pub struct Preview {
    commands: Sender<Envelope>,
    shared: Arc<Mutex<Shared>>,
    cancel: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    textures: [Option<egui::TextureHandle>; 2],
    map_texture: Option<egui::TextureHandle>,
    status: [Option<PreviewFrame>; 2],
    delta_e: Option<DeltaEMap>,
    map_scale: f32,
    map_scale_shown: f32,
    environment: EnvironmentChoice,
    environment_name: Option<String>,
    /// The model of the single view and of both in the designs comparison.
    model: ShadingModel,
    /// The Phong variant in the models comparison.
    phong: PhongVariant,
    compare: CompareMode,
    layout: CompareLayout,
    /// The split view's divider, as a fraction of the image's width from the left.
    divider: f32,
    second: Option<(String, PaintDesign)>,
    scene: Option<SceneInfo>,
    paint_override: Option<u32>,
    /// The current design's name (to offer a different one for comparison).
    design_name: String,
    size: (u32, u32),
    epoch: u64,
    change_sent_at: Option<Instant>,
    last_latency: Option<Duration>,
    events: Vec<PreviewEvent>,
    /// The quality preset and the knobs it set (see [`super::quality`]).
    quality: QualitySelector,
    /// Where the last frame drew opaque images (the panels behind need no fill there).
    opaque: Vec<egui::Rect>,
}

impl Preview {
    /// Starts the render thread on `design`.
    pub fn start(ctx: &egui::Context, design: &PaintDesign) -> Self {
        let (tx, rx) = channel();
        let shared = Arc::new(Mutex::new(Shared::default()));
        let cancel = Arc::new(AtomicBool::new(false));
        let worker = Worker {
            commands: rx,
            shared: shared.clone(),
            cancel: cancel.clone(),
            ctx: ctx.clone(),
        };
        let initial = design.clone();
        let thread = std::thread::Builder::new()
            .name("coatlab-preview".into())
            .spawn(move || {
                super::priority::lower_render_thread();
                worker.run(initial)
            })
            .ok();
        Self {
            commands: tx,
            shared,
            cancel,
            thread,
            textures: [None, None],
            map_texture: None,
            status: [None, None],
            delta_e: None,
            map_scale: 5.0,
            map_scale_shown: f32::NAN,
            environment: EnvironmentChoice::Studio,
            environment_name: None,
            model: ShadingModel::Paint,
            phong: PhongVariant::BestFit,
            compare: CompareMode::Off,
            layout: CompareLayout::SideBySide,
            divider: 0.5,
            second: None,
            scene: None,
            paint_override: None,
            design_name: design.name.clone(),
            size: (0, 0),
            epoch: 0,
            change_sent_at: None,
            last_latency: None,
            events: Vec::new(),
            quality: QualitySelector::default(),
            opaque: Vec::new(),
        }
    }

    /// The quality choice and the knobs in force.
    pub fn quality(&self) -> &QualitySelector {
        &self.quality
    }

    fn send(&mut self, command: Command) {
        if command.changes_picture() {
            self.epoch += 1;
            self.change_sent_at = Some(Instant::now());
            // Stop the pass in flight: the thread picks the command up at once. An
            // export waits for the pass to end instead (it keeps the samples).
            self.cancel.store(true, Ordering::Relaxed);
        }
        let _ = self.commands.send(Envelope {
            epoch: self.epoch,
            command,
        });
    }

    /// The design changed.
    pub fn set_design(&mut self, design: &PaintDesign) {
        self.design_name = design.name.clone();
        self.send(Command::Design(Box::new(design.clone())));
    }

    /// Opens a glTF scene (.glb, .gltf) on the render thread; the current scene stays
    /// if it cannot be loaded (an error event says why).
    pub fn open_scene(&mut self, path: &Path) {
        self.paint_override = None;
        self.send(Command::Scene(Some(path.to_owned())));
    }

    /// Goes back to the built-in car.
    pub fn built_in_scene(&mut self) {
        self.paint_override = None;
        self.send(Command::Scene(None));
    }

    /// Opens an environment map (.hdr, .exr) on the render thread; the lighting stays
    /// if it cannot be read.
    pub fn open_environment(&mut self, path: &Path) {
        self.send(Command::EnvironmentFile(path.to_owned()));
    }

    /// Paints the scene material `index` instead of the loader's choice (`None`).
    pub fn set_paint_material(&mut self, index: Option<u32>) {
        if self.paint_override != index {
            self.paint_override = index;
            self.send(Command::PaintMaterial(index));
        }
    }

    /// The scene material painted instead of the loader's choice, if any.
    pub fn paint_material(&self) -> Option<u32> {
        self.paint_override
    }

    /// Writes the first view (and the second, as NAME-b.EXT, in a comparison): PNG
    /// as shown (same exposure and tone mapping), EXR as linear sRGB.
    pub fn export(&mut self, path: &Path) {
        self.send(Command::Export(path.to_owned()));
    }

    /// Sets the comparison.
    pub fn set_compare(&mut self, mode: CompareMode, layout: CompareLayout) {
        let changed = mode != self.compare;
        self.compare = mode;
        self.layout = layout;
        if changed {
            self.send_views();
        }
    }

    /// The second design of the designs comparison.
    pub fn set_second_design(&mut self, label: &str, design: &PaintDesign) {
        self.second = Some((label.to_owned(), design.clone()));
        if self.compare == CompareMode::Designs {
            self.send_views();
        }
    }

    /// The second design and its label.
    pub fn second_design(&self) -> Option<(&str, &PaintDesign)> {
        self.second.as_ref().map(|(l, d)| (l.as_str(), d))
    }

    /// The comparison shown.
    pub fn compare(&self) -> (CompareMode, CompareLayout) {
        (self.compare, self.layout)
    }

    /// The split view's divider (fraction of the width from the left).
    pub fn divider(&self) -> f32 {
        self.divider
    }

    fn views(&self) -> Views {
        match self.compare {
            CompareMode::Off => Views {
                model_a: self.model,
                b: None,
            },
            CompareMode::Models => Views {
                model_a: ShadingModel::Paint,
                b: Some((None, ShadingModel::Phong(self.phong))),
            },
            CompareMode::Designs => Views {
                model_a: self.model,
                b: self
                    .second
                    .as_ref()
                    .map(|(_, d)| (Some(Box::new(d.clone())), self.model)),
            },
        }
    }

    fn send_views(&mut self) {
        let views = self.views();
        self.send(Command::Views(views));
    }

    /// The latest frame's statistics (the first view).
    pub fn status(&self) -> Option<&PreviewFrame> {
        self.status[0].as_ref()
    }

    /// The second view's latest frame statistics, in a comparison.
    pub fn second_status(&self) -> Option<&PreviewFrame> {
        self.status[1].as_ref()
    }

    /// The latest ΔE00 map between the two views, in a comparison.
    pub fn delta_e_map(&self) -> Option<&DeltaEMap> {
        self.delta_e.as_ref()
    }

    /// The scene being rendered.
    pub fn scene(&self) -> Option<&SceneInfo> {
        self.scene.as_ref()
    }

    /// The lighting selected, and the name of the open map.
    pub fn environment(&self) -> (EnvironmentChoice, Option<&str>) {
        (self.environment, self.environment_name.as_deref())
    }

    /// How long the last change took to show: from the command being sent to the
    /// UI taking up the first image rendered after it.
    pub fn last_change_latency(&self) -> Option<Duration> {
        self.last_latency
    }

    /// Whether a change is still waiting for its first image.
    pub fn change_pending(&self) -> bool {
        self.change_sent_at.is_some()
    }

    /// What happened since the last call (loads, exports, errors).
    pub fn take_events(&mut self) -> Vec<PreviewEvent> {
        std::mem::take(&mut self.events)
    }

    /// Takes up what the render thread published: images, the ΔE00 map, the scene,
    /// events. Called by [`Self::ui`] each frame; tests call it between frames.
    pub fn poll(&mut self, ctx: &egui::Context) {
        let mut shared = self.shared.lock().unwrap_or_else(|p| p.into_inner());
        self.events.append(&mut shared.events);
        if let Some(scene) = shared.scene.take() {
            self.scene = Some(scene);
        }
        if let Some(name) = shared.environment_loaded.take() {
            self.environment = EnvironmentChoice::Image;
            self.environment_name = Some(name);
        }
        if shared.fresh {
            shared.fresh = false;
            for (i, frame) in shared.frames.iter().enumerate() {
                let Some(frame) = frame else {
                    self.status[i] = None;
                    self.textures[i] = None;
                    continue;
                };
                let image = egui::ColorImage::from_rgba_unmultiplied(
                    [frame.width as usize, frame.height as usize],
                    frame.pixels.as_flattened(),
                );
                upload(
                    ctx,
                    &mut self.textures[i],
                    ["preview-a", "preview-b"][i],
                    image,
                );
                self.status[i] = Some(PreviewFrame {
                    pixels: Vec::new(),
                    ..frame.clone()
                });
            }
            if let Some(f) = &self.status[0]
                && f.epoch >= self.epoch
                && let Some(sent) = self.change_sent_at.take()
            {
                self.last_latency = Some(sent.elapsed());
            }
        }
        if shared.fresh_map {
            shared.fresh_map = false;
            self.delta_e = shared.delta_e.take();
            self.map_scale_shown = f32::NAN;
        }
        drop(shared);
        if self.compare == CompareMode::Off {
            self.delta_e = None;
        }
        if let Some(map) = &self.delta_e
            && self.map_scale_shown != self.map_scale
        {
            let image = egui::ColorImage::new(
                [map.width as usize, map.height as usize],
                map.to_colours(self.map_scale),
            );
            upload(ctx, &mut self.map_texture, "preview-delta-e", image);
            self.map_scale_shown = self.map_scale;
        }
    }

    /// The rectangles the last [`Self::ui`] covered with opaque images: what lies
    /// behind them is never seen, so the window does not fill it.
    pub fn opaque_rects(&self) -> &[egui::Rect] {
        &self.opaque
    }

    /// Draws the preview with its controls; mouse drags orbit (left) or pan (right or
    /// middle), the wheel zooms, in either pane of a comparison (both follow).
    pub fn ui(&mut self, ui: &mut Ui, presets: &[Preset]) -> Vec<PreviewRequest> {
        let mut requests = Vec::new();
        self.poll(ui.ctx());
        self.toolbar_ui(ui, presets, &mut requests);
        if let Some(knobs) = ui
            .horizontal(|ui| super::quality::quality_ui(ui, &mut self.quality))
            .inner
        {
            self.send(Command::Quality(knobs));
            self.size = (0, 0);
        }
        self.scene_ui(ui, &mut requests);

        let status_height = 22.0;
        let available = ui.available_size() - egui::vec2(0.0, status_height);
        let (rect, _) = ui.allocate_exact_size(available, egui::Sense::hover());
        let two = self.compare != CompareMode::Off;
        let pane_size = match (two, self.layout) {
            (true, CompareLayout::SideBySide) => {
                egui::vec2((rect.width() - PANE_GAP) / 2.0, rect.height())
            }
            (true, CompareLayout::DeltaE) => egui::vec2(rect.width() - LEGEND_WIDTH, rect.height()),
            _ => rect.size(),
        };
        let ppp = ui.ctx().pixels_per_point();
        let want = self
            .quality
            .knobs
            .divide(fit(pane_size.x * ppp, pane_size.y * ppp));
        if want != self.size && want.0 > 16 && want.1 > 16 {
            self.size = want;
            self.send(Command::Resize(want.0, want.1));
        }
        // The dark background goes only where no opaque image covers it (filled in
        // below, once the images' rectangles are known): a software rasteriser
        // shades every pixel of every shape, hidden or not.
        let background = ui.painter().add(egui::Shape::Noop);
        let mut covered: Vec<egui::Rect> = Vec::new();
        let labels = self.view_labels();
        match (two, self.layout) {
            (false, _) => {
                let r = ui.interact(
                    rect,
                    ui.scope_id().with("pane-a"),
                    egui::Sense::click_and_drag(),
                );
                named(&r, "Preview pane");
                covered.extend(self.image_ui(ui, 0, rect, None));
                self.camera_input(ui, &r);
            }
            (true, CompareLayout::SideBySide) => {
                for (i, label) in labels.iter().enumerate() {
                    let pane = egui::Rect::from_min_size(
                        rect.min + egui::vec2(i as f32 * (pane_size.x + PANE_GAP), 0.0),
                        pane_size,
                    );
                    let r = ui.interact(
                        pane,
                        ui.scope_id().with(("pane", i)),
                        egui::Sense::click_and_drag(),
                    );
                    named(&r, &format!("Preview pane: {label}"));
                    covered.extend(self.image_ui(ui, i, pane, Some(label)));
                    self.camera_input(ui, &r);
                }
            }
            (true, CompareLayout::Split) => covered.extend(self.split_ui(ui, rect, &labels)),
            (true, CompareLayout::DeltaE) => {
                let map_rect = egui::Rect::from_min_size(rect.min, pane_size);
                let r = ui.interact(
                    map_rect,
                    ui.scope_id().with("pane-map"),
                    egui::Sense::click_and_drag(),
                );
                named(&r, "ΔE00 map");
                covered.extend(self.map_ui(ui, map_rect, &r, &labels));
                self.camera_input(ui, &r);
                let legend =
                    egui::Rect::from_min_max(egui::pos2(map_rect.right(), rect.top()), rect.max);
                legend_ui(ui, legend.shrink2(egui::vec2(4.0, 20.0)), self.map_scale);
            }
        }
        let fill = Color32::from_gray(20);
        ui.painter().set(
            background,
            egui::Shape::Vec(
                uncovered(rect, &covered)
                    .into_iter()
                    .map(|r| egui::Shape::rect_filled(r, 0.0, fill))
                    .collect(),
            ),
        );
        self.opaque = covered;
        ui.label(RichText::new(self.status_line()).weak());
        if self.compare != CompareMode::Off
            && let Some(source) = self.status[1].as_ref().and_then(|f| f.source.as_ref())
        {
            ui.label(RichText::new(source.label()).weak());
        }
        requests
    }

    fn view_labels(&self) -> [String; 2] {
        match self.compare {
            CompareMode::Off => [self.model.label().to_owned(), String::new()],
            CompareMode::Models => [
                ShadingModel::Paint.label().to_owned(),
                self.phong.label().to_owned(),
            ],
            CompareMode::Designs => [
                "Current design".to_owned(),
                self.second
                    .as_ref()
                    .map(|(l, _)| l.clone())
                    .unwrap_or_else(|| "(choose a second design)".into()),
            ],
        }
    }

    fn toolbar_ui(&mut self, ui: &mut Ui, presets: &[Preset], requests: &mut Vec<PreviewRequest>) {
        ui.horizontal_wrapped(|ui| {
            let mut env = self.environment;
            let image_label = self
                .environment_name
                .as_ref()
                .map(|n| format!("Map: {n}"))
                .unwrap_or_default();
            let shown = if env == EnvironmentChoice::Image {
                image_label.clone()
            } else {
                env.label().to_owned()
            };
            egui::ComboBox::from_label("Lighting")
                .selected_text(shown)
                .show_ui(ui, |ui| {
                    for e in EnvironmentChoice::ALL {
                        ui.selectable_value(&mut env, e, e.label());
                    }
                    if self.environment_name.is_some() {
                        ui.selectable_value(&mut env, EnvironmentChoice::Image, &image_label);
                    }
                });
            if env != self.environment {
                self.environment = env;
                self.send(Command::Environment(env));
            }
            if ui
                .button("Open map…")
                .on_hover_text("An equirectangular environment map (.hdr or .exr)")
                .clicked()
            {
                requests.push(PreviewRequest::OpenEnvironment);
            }
            ui.separator();
            match self.compare {
                CompareMode::Models => {
                    let mut phong = self.phong;
                    ui.label("against");
                    for v in [PhongVariant::Naive, PhongVariant::BestFit] {
                        ui.selectable_value(&mut phong, v, v.label());
                    }
                    if phong != self.phong {
                        self.phong = phong;
                        self.send_views();
                    }
                }
                _ => {
                    let mut model = self.model;
                    for m in [
                        ShadingModel::Paint,
                        ShadingModel::Phong(PhongVariant::Naive),
                        ShadingModel::Phong(PhongVariant::BestFit),
                    ] {
                        ui.selectable_value(&mut model, m, m.label());
                    }
                    if model != self.model {
                        self.model = model;
                        self.send_views();
                    }
                }
            }
            ui.separator();
            let mut mode = self.compare;
            egui::ComboBox::from_label("Compare")
                .selected_text(mode.label())
                .show_ui(ui, |ui| {
                    for m in CompareMode::ALL {
                        ui.selectable_value(&mut mode, m, m.label());
                    }
                });
            if mode == CompareMode::Designs && self.second.is_none() {
                // Something to compare with at once: the first preset unlike the
                // design; the combo beside it changes it.
                if let Some(p) = presets.iter().find(|p| p.design.name != self.design_name) {
                    self.second = Some((p.design.name.clone(), p.design.clone()));
                }
            }
            if mode != self.compare {
                self.set_compare(mode, self.layout);
            }
            if self.compare != CompareMode::Off {
                let mut layout = self.layout;
                for l in CompareLayout::ALL {
                    ui.selectable_value(&mut layout, l, l.label());
                }
                self.layout = layout;
            }
            if self.compare == CompareMode::Designs {
                let current = self
                    .second
                    .as_ref()
                    .map(|(l, _)| l.clone())
                    .unwrap_or_default();
                let mut chosen = None;
                egui::ComboBox::from_label("Second design")
                    .selected_text(current)
                    .show_ui(ui, |ui| {
                        for (i, p) in presets.iter().enumerate() {
                            if ui.selectable_label(false, &p.design.name).clicked() {
                                chosen = Some(i);
                            }
                        }
                    });
                if let Some(p) = chosen.and_then(|i| presets.get(i)) {
                    let (name, design) = (p.design.name.clone(), p.design.clone());
                    self.set_second_design(&name, &design);
                }
                if ui.button("Second design from file…").clicked() {
                    requests.push(PreviewRequest::SecondDesignFile);
                }
            }
            if self.compare != CompareMode::Off && self.layout == CompareLayout::DeltaE {
                let mut scale = self.map_scale;
                egui::ComboBox::from_label("Scale")
                    .selected_text(format!("0–{scale:.0} ΔE00"))
                    .show_ui(ui, |ui| {
                        for s in SCALES {
                            ui.selectable_value(&mut scale, s, format!("0–{s:.0} ΔE00"));
                        }
                    });
                self.map_scale = scale;
            }
        });
    }

    fn scene_ui(&mut self, ui: &mut Ui, requests: &mut Vec<PreviewRequest>) {
        ui.horizontal_wrapped(|ui| {
            let name = self
                .scene
                .as_ref()
                .map(|s| s.name.clone())
                .unwrap_or_else(|| "Built-in car".into());
            ui.label(format!("Scene: {name}"));
            if ui
                .button("Open scene…")
                .on_hover_text("A glTF 2.0 scene (.glb or .gltf); or drop one on the window")
                .clicked()
            {
                requests.push(PreviewRequest::OpenScene);
            }
            if self.scene.as_ref().is_some_and(|s| s.path.is_some())
                && ui.button("Built-in car").clicked()
            {
                self.built_in_scene();
            }
            if let Some(scene) = self.scene.clone() {
                let automatic = format!(
                    "automatic ({})",
                    names_of(&scene.materials, &scene.automatic_paint)
                );
                let selected = match self.paint_override {
                    Some(i) => scene.materials.get(i as usize).cloned().unwrap_or_default(),
                    None => automatic.clone(),
                };
                let mut choice = self.paint_override;
                egui::ComboBox::from_label("Paint material")
                    .selected_text(selected)
                    .show_ui(ui, |ui| {
                        ui.selectable_value(&mut choice, None, &automatic);
                        for (i, m) in scene.materials.iter().enumerate() {
                            ui.selectable_value(&mut choice, Some(i as u32), m);
                        }
                    });
                self.set_paint_material(choice);
                if !scene.warnings.is_empty() {
                    ui.label(
                        RichText::new(format!("{} warning(s)", scene.warnings.len()))
                            .color(ui.visuals().warn_fg_color),
                    )
                    .on_hover_text(scene.warnings.join("\n"));
                }
            }
            ui.separator();
            if ui
                .button("Export image…")
                .on_hover_text("The preview as PNG (as shown) or EXR (linear)")
                .clicked()
            {
                requests.push(PreviewRequest::Export);
            }
        });
    }

    /// Draws view `i`'s image letterboxed in `rect`, with a label; returns where the
    /// (opaque) image went.
    fn image_ui(
        &self,
        ui: &Ui,
        i: usize,
        rect: egui::Rect,
        label: Option<&str>,
    ) -> Option<egui::Rect> {
        let mut drawn = None;
        match &self.textures[i] {
            Some(t) => {
                let shown = letterbox(rect, t.size_vec2());
                ui.painter().image(t.id(), shown, full_uv(), Color32::WHITE);
                drawn = Some(shown);
            }
            None => {
                ui.painter().text(
                    rect.center(),
                    egui::Align2::CENTER_CENTER,
                    "Preparing the car…",
                    egui::FontId::proportional(16.0),
                    ui.visuals().weak_text_color(),
                );
            }
        }
        if let Some(label) = label {
            pane_label(
                ui,
                rect.left_top() + egui::vec2(6.0, 6.0),
                egui::Align2::LEFT_TOP,
                label,
            );
        }
        drawn
    }

    /// The split view; returns the part of `rect` its two images cover.
    fn split_ui(
        &mut self,
        ui: &mut Ui,
        rect: egui::Rect,
        labels: &[String; 2],
    ) -> Option<egui::Rect> {
        let r = ui.interact(
            rect,
            ui.scope_id().with("pane-split"),
            egui::Sense::click_and_drag(),
        );
        named(&r, "Preview pane: split");
        let size = self.textures[0]
            .as_ref()
            .map(|t| t.size_vec2())
            .unwrap_or(egui::vec2(16.0, 10.0));
        let shown = letterbox(rect, size);
        let x = shown.left() + self.divider * shown.width();
        let drawn = self.textures.iter().all(Option::is_some).then_some(shown);
        for (i, t) in self.textures.iter().enumerate() {
            let Some(t) = t else { continue };
            let (part, uv) = if i == 0 {
                (
                    egui::Rect::from_min_max(shown.min, egui::pos2(x, shown.bottom())),
                    egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(self.divider, 1.0)),
                )
            } else {
                (
                    egui::Rect::from_min_max(egui::pos2(x, shown.top()), shown.max),
                    egui::Rect::from_min_max(egui::pos2(self.divider, 0.0), egui::pos2(1.0, 1.0)),
                )
            };
            ui.painter().image(t.id(), part, uv, Color32::WHITE);
        }
        if self.textures[0].is_none() {
            self.image_ui(ui, 0, rect, None);
        }
        // The divider: a handle over the line, on top of the picture's own drag area.
        let handle = egui::Rect::from_center_size(
            egui::pos2(x, shown.center().y),
            egui::vec2(12.0, shown.height()),
        );
        let d = ui
            .interact(
                handle,
                ui.scope_id().with("split-divider"),
                egui::Sense::drag(),
            )
            .on_hover_cursor(egui::CursorIcon::ResizeHorizontal);
        named(&d, "Split divider");
        if d.dragged() {
            self.divider =
                (self.divider + d.drag_delta().x / shown.width().max(1.0)).clamp(0.0, 1.0);
        }
        let stroke = if d.hovered() || d.dragged() { 3.0 } else { 1.5 };
        ui.painter().line_segment(
            [egui::pos2(x, shown.top()), egui::pos2(x, shown.bottom())],
            egui::Stroke::new(stroke, Color32::WHITE),
        );
        ui.painter()
            .circle_filled(egui::pos2(x, shown.center().y), 6.0, Color32::WHITE);
        pane_label(
            ui,
            shown.left_top() + egui::vec2(6.0, 6.0),
            egui::Align2::LEFT_TOP,
            &labels[0],
        );
        pane_label(
            ui,
            shown.right_top() + egui::vec2(-6.0, 6.0),
            egui::Align2::RIGHT_TOP,
            &labels[1],
        );
        if !d.dragged() {
            self.camera_input(ui, &r);
        }
        drawn
    }

    /// The ΔE00 map; returns where its (opaque) image went.
    fn map_ui(
        &self,
        ui: &Ui,
        rect: egui::Rect,
        response: &egui::Response,
        labels: &[String; 2],
    ) -> Option<egui::Rect> {
        let (Some(t), Some(map)) = (&self.map_texture, &self.delta_e) else {
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "Computing the ΔE00 map…",
                egui::FontId::proportional(16.0),
                ui.visuals().weak_text_color(),
            );
            return None;
        };
        let shown = letterbox(rect, t.size_vec2());
        ui.painter().image(t.id(), shown, full_uv(), Color32::WHITE);
        pane_label(
            ui,
            shown.left_top() + egui::vec2(6.0, 6.0),
            egui::Align2::LEFT_TOP,
            &format!(
                "ΔE00 {} vs {}: mean {:.2}, 95th percentile {:.2}, max {:.1} ({} spp)",
                labels[0], labels[1], map.mean, map.p95, map.max, map.samples_per_pixel
            ),
        );
        if let Some(pos) = response.hover_pos()
            && shown.contains(pos)
        {
            let u = (pos - shown.min) / shown.size();
            let x = ((u.x * map.width as f32) as u32).min(map.width - 1);
            let y = ((u.y * map.height as f32) as u32).min(map.height - 1);
            if let Some(v) = map.values.get((y * map.width + x) as usize)
                && v.is_finite()
            {
                pane_label(
                    ui,
                    pos + egui::vec2(14.0, 0.0),
                    egui::Align2::LEFT_CENTER,
                    &format!("ΔE00 {v:.2}"),
                );
            }
        }
        Some(shown)
    }

    fn camera_input(&mut self, ui: &Ui, response: &egui::Response) {
        let delta = response.drag_delta();
        if delta != egui::Vec2::ZERO {
            if response.dragged_by(egui::PointerButton::Primary) {
                self.send(Command::Orbit(-delta.x * 0.4, delta.y * 0.4));
            } else {
                let scale = self.size.0 as f32 / response.rect.width().max(1.0);
                self.send(Command::Pan(delta.x * scale, delta.y * scale));
            }
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.send(Command::Zoom((scroll * 0.004).exp()));
            }
        }
    }

    fn status_line(&self) -> String {
        let Some(s) = &self.status[0] else {
            return "starting…".into();
        };
        let mode = match s.reshaded {
            Some(w) => format!(" (re-shaded edit, fresh share {:.0} %)", w * 100.0),
            None if s.coarse => " (coarse)".to_owned(),
            None => String::new(),
        };
        let mut line = format!(
            "{} spp{}  ·  {:.0} k samples/s  ·  noise {}  ·  {}×{}",
            s.samples_per_pixel,
            mode,
            s.samples_per_second / 1e3,
            s.noise_delta_e
                .map(|d| format!("ΔE00 {d:.2}"))
                .unwrap_or_else(|| "–".into()),
            s.width,
            s.height
        );
        if let Some(map) = &self.delta_e {
            line += &format!(
                "  ·  difference ΔE00 mean {:.2}, 95 % {:.2}",
                map.mean, map.p95
            );
        }
        if let Some(left) = self.quality.error_left(s.noise_delta_e) {
            line += &format!("  ·  {left}");
        }
        if let Some(l) = self.last_latency {
            line += &format!("  ·  last change shown after {} ms", l.as_millis());
        }
        line
    }
}

impl Drop for Preview {
    fn drop(&mut self) {
        // Closing the channel ends the thread; the cancel flag ends its pass.
        self.cancel.store(true, Ordering::Relaxed);
        let (tx, _) = channel();
        drop(std::mem::replace(&mut self.commands, tx));
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn upload(
    ctx: &egui::Context,
    slot: &mut Option<egui::TextureHandle>,
    name: &str,
    image: egui::ColorImage,
) {
    match slot {
        Some(t) => t.set(image, egui::TextureOptions::LINEAR),
        None => *slot = Some(ctx.load_texture(name, image, egui::TextureOptions::LINEAR)),
    }
}

/// Gives an area a name assistive technology (and the tests) can find it by.
fn named(response: &egui::Response, name: &str) {
    let role = if name == "Split divider" {
        egui::Role::Splitter
    } else {
        egui::Role::Image
    };
    response.widget_info(|| egui::WidgetInfo::labeled(role, true, name));
}

fn full_uv() -> egui::Rect {
    egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0))
}

/// The largest rectangle of `size`'s aspect centred in `rect`.
/// The parts of `rect` outside every rectangle of `covered`, as disjoint rectangles
/// (horizontal bands between the covered rectangles' edges, split at their sides).
pub(super) fn uncovered(rect: egui::Rect, covered: &[egui::Rect]) -> Vec<egui::Rect> {
    let covered: Vec<egui::Rect> = covered
        .iter()
        .map(|c| c.intersect(rect))
        .filter(|c| c.is_positive())
        .collect();
    let mut ys: Vec<f32> = vec![rect.top(), rect.bottom()];
    ys.extend(covered.iter().flat_map(|c| [c.top(), c.bottom()]));
    ys.sort_by(f32::total_cmp);
    ys.dedup();
    let mut out = Vec::new();
    for band in ys.windows(2) {
        let (top, bottom) = (band[0], band[1]);
        if bottom <= top {
            continue;
        }
        // The covered x-intervals of this band, left to right.
        let mut spans: Vec<(f32, f32)> = covered
            .iter()
            .filter(|c| c.top() <= top && c.bottom() >= bottom)
            .map(|c| (c.left(), c.right()))
            .collect();
        spans.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut x = rect.left();
        for (left, right) in spans {
            if left > x {
                out.push(egui::Rect::from_min_max(
                    egui::pos2(x, top),
                    egui::pos2(left, bottom),
                ));
            }
            x = x.max(right);
        }
        if x < rect.right() {
            out.push(egui::Rect::from_min_max(
                egui::pos2(x, top),
                egui::pos2(rect.right(), bottom),
            ));
        }
    }
    out
}

fn letterbox(rect: egui::Rect, size: egui::Vec2) -> egui::Rect {
    let scale = (rect.width() / size.x.max(1.0)).min(rect.height() / size.y.max(1.0));
    egui::Rect::from_center_size(rect.center(), size * scale)
}

/// A label on a dark backing, readable over any picture.
fn pane_label(ui: &Ui, pos: egui::Pos2, align: egui::Align2, text: &str) {
    let painter = ui.painter();
    let galley = painter.layout_no_wrap(
        text.to_owned(),
        egui::FontId::proportional(13.0),
        Color32::WHITE,
    );
    let rect = align.anchor_size(pos, galley.size()).expand(3.0);
    painter.rect_filled(rect, 3.0, Color32::from_black_alpha(150));
    painter.galley(rect.min + egui::vec2(3.0, 3.0), galley, Color32::WHITE);
}

fn names_of(materials: &[String], indices: &[u32]) -> String {
    let names: Vec<&str> = indices
        .iter()
        .filter_map(|&i| materials.get(i as usize).map(String::as_str))
        .collect();
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}

/// The render size for an area of `w`×`h` physical pixels, capped at
/// [`MAX_PREVIEW_PIXELS`] with the area's aspect.
fn fit(w: f32, h: f32) -> (u32, u32) {
    let (mw, mh) = (MAX_PREVIEW_PIXELS.0 as f32, MAX_PREVIEW_PIXELS.1 as f32);
    let scale = (mw / w.max(1.0)).min(mh / h.max(1.0)).min(1.0);
    ((w * scale).round() as u32, (h * scale).round() as u32)
}

struct Worker {
    commands: Receiver<Envelope>,
    shared: Arc<Mutex<Shared>>,
    cancel: Arc<AtomicBool>,
    ctx: egui::Context,
}

/// What the render thread renders: everything but the renders themselves.
struct State {
    grid: WavelengthGrid,
    scene: Arc<RenderScene>,
    materials: Vec<SceneMaterial>,
    /// The loader's choice of paint materials, and the override.
    automatic_paint: Vec<u32>,
    paint_override: Option<u32>,
    design: PaintDesign,
    views: Views,
    environment: Arc<Environment>,
    image_environment: Option<Arc<Environment>>,
    camera: Camera,
    size: (u32, u32),
    epoch: u64,
    /// The display settings of the last published images (what an export writes).
    display: DisplaySettings,
    /// The first view's design and its paint model, kept so an edit rebuilds only
    /// the derived tables it touches (`PaintDesign::update_model`).
    paint_a: Option<(PaintDesign, PaintModel)>,
    /// Wavelengths, sample target and resolution of the quality preset.
    quality: QualityKnobs,
}

impl State {
    /// Applies a quality preset's knobs; a new wavelength count rebuilds the
    /// lighting and the paint model on the new grid. Says why when it cannot.
    fn set_quality(&mut self, quality: QualityKnobs) -> Option<String> {
        self.quality = quality;
        if quality.wavelengths == self.grid.len() {
            return None;
        }
        let grid = WavelengthGrid::visible(quality.wavelengths).ok()?;
        match super::quality::environment_on(&self.environment, &grid) {
            Some(environment) => {
                self.grid = grid;
                self.environment = Arc::new(environment);
                self.image_environment = None;
                self.paint_a = None;
                None
            }
            None => Some(format!(
                "quality: an environment map stays at {} wavelengths (choose a built-in lighting to change them)",
                self.grid.len()
            )),
        }
    }

    fn paint_materials(&self) -> Vec<u32> {
        match self.paint_override {
            Some(i) => vec![i],
            None => self.automatic_paint.clone(),
        }
    }

    /// The first view's shading, from the kept paint model brought up to the
    /// current design (a full rebuild only for a new grid or a first design).
    fn shading_a(&mut self) -> Option<Arc<Shading>> {
        let model = match self.paint_a.take() {
            Some((previous, mut model)) => match self.design.update_model(&previous, &mut model) {
                Ok(()) => model,
                Err(_) => return None,
            },
            None => self.design.model(self.grid).ok()?,
        };
        let shading = Arc::new(Shading::new(
            &model,
            self.views.model_a,
            &self.materials,
            &self.paint_materials(),
        ));
        self.paint_a = Some((self.design.clone(), model));
        Some(shading)
    }

    /// Starts building the second view's shading on a thread of its own: a best-fit
    /// Phong takes tens of milliseconds to fit, which then overlaps the first view's
    /// coarse pass instead of delaying the first new image.
    fn spawn_second_shading(&self) -> Option<JoinHandle<Option<Arc<Shading>>>> {
        let (design, model) = self.views.b.clone()?;
        let design = design.map(|d| *d).unwrap_or_else(|| self.design.clone());
        let (grid, materials, paint) = (self.grid, self.materials.clone(), self.paint_materials());
        std::thread::Builder::new()
            .name("coatlab-preview-shading".into())
            .spawn(move || {
                super::priority::lower_render_thread();
                shading_of(&design, model, grid, &materials, &paint)
            })
            .ok()
    }
}

fn shading_of(
    design: &PaintDesign,
    model: ShadingModel,
    grid: WavelengthGrid,
    materials: &[SceneMaterial],
    paint_materials: &[u32],
) -> Option<Arc<Shading>> {
    let paint = design.model(grid).ok()?;
    Some(Arc::new(Shading::new(
        &paint,
        model,
        materials,
        paint_materials,
    )))
}

impl Worker {
    fn event(&self, event: PreviewEvent) {
        self.shared
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .events
            .push(event);
        self.ctx.request_repaint();
    }

    fn error(&self, e: String) {
        self.event(PreviewEvent::Error(e));
    }

    fn run(self, design: PaintDesign) {
        let Ok(grid) = WavelengthGrid::visible(PREVIEW_WAVELENGTHS) else {
            return self.error("preview: no wavelength grid".into());
        };
        let scene = generate(&CarParameters::default());
        let info = scene_info(&scene, None);
        let materials = scene.materials.clone();
        let automatic_paint = scene.paint_materials.clone();
        let render_scene = match RenderScene::new(scene) {
            Ok(s) => Arc::new(s),
            Err(e) => return self.error(format!("preview: {e}")),
        };
        self.shared.lock().unwrap_or_else(|p| p.into_inner()).scene = Some(info);
        let size = (320u32, 200u32);
        let Some(environment) = EnvironmentChoice::Studio.build(&grid) else {
            return;
        };
        let mut state = State {
            grid,
            camera: render_scene.default_camera(size.0, size.1),
            scene: render_scene,
            materials,
            automatic_paint,
            paint_override: None,
            design,
            views: Views {
                model_a: ShadingModel::Paint,
                b: None,
            },
            environment: Arc::new(environment),
            image_environment: None,
            size,
            epoch: 0,
            display: DisplaySettings::default(),
            paint_a: None,
            quality: QualityKnobs::default(),
        };
        let Some(shading) = state.shading_a() else {
            return self.error("preview: the design is invalid".into());
        };
        let mut a = match ProgressiveRender::new(
            state.scene.clone(),
            state.environment.clone(),
            shading,
            state.camera.clone(),
            RenderSettings::default(),
        ) {
            Ok(r) => r,
            Err(e) => return self.error(format!("preview: {e}")),
        };
        a.set_path_cache_samples(RESHADE_SAMPLES);
        let mut b: Option<ProgressiveRender> = None;
        // The second view's shading being built, and whether it is for a new scene.
        let mut b_job: Option<JoinHandle<Option<Arc<Shading>>>> = None;
        let mut b_new_scene = false;
        // The second view's shading while it is re-shaded from the first view's
        // paths (`b` is then `None`); and why it is not, when it is rendered apart.
        let mut b_shared: Option<Arc<Shading>> = None;
        let mut b_reason = String::new();
        // The first view's recording target: more samples while comparing.
        let mut cache_samples = RESHADE_SAMPLES;
        let mut restart = true;
        loop {
            // Wait for work when converged; otherwise just look for commands.
            let mut pending = Vec::new();
            if !restart && a.samples_per_pixel() >= state.quality.max_spp {
                match self.commands.recv() {
                    Ok(c) => pending.push(c),
                    Err(_) => return,
                }
            }
            loop {
                match self.commands.try_recv() {
                    Ok(c) => pending.push(c),
                    Err(TryRecvError::Empty) => break,
                    Err(TryRecvError::Disconnected) => return,
                }
            }
            self.cancel.store(false, Ordering::Relaxed);
            let mut new_shading = false;
            let mut new_scene = false;
            let mut new_env = false;
            // A quality preset changed the wavelength count: new renders.
            let mut new_grid = false;
            // Whether every change was a paint edit that samples of the previous
            // design can show at once (re-shading): not the gloss (a new lobe is
            // covered poorly by the old one's samples), the view, the lighting or
            // what is painted.
            let mut reshadeable = true;
            let gloss_before = state.design.gloss;
            for Envelope { epoch, command } in pending {
                // Lighting is built on the current grid (a quality preset may change it).
                let grid = state.grid;
                state.epoch = state.epoch.max(epoch);
                if command.changes_picture() {
                    restart = true;
                    reshadeable &= matches!(command, Command::Design(_));
                }
                match command {
                    Command::Design(d) => {
                        state.design = *d;
                        new_shading = true;
                    }
                    Command::Views(v) => {
                        state.views = v;
                        new_shading = true;
                    }
                    Command::Environment(e) => {
                        let env = match e {
                            EnvironmentChoice::Image => state.image_environment.clone(),
                            other => other.build(&grid).map(Arc::new),
                        };
                        if let Some(env) = env {
                            state.environment = env;
                            new_env = true;
                        }
                    }
                    Command::EnvironmentFile(path) => match Environment::from_image(&path, &grid) {
                        Ok(env) => {
                            let env = Arc::new(env);
                            state.image_environment = Some(env.clone());
                            state.environment = env;
                            new_env = true;
                            let name = file_name(&path);
                            self.shared
                                .lock()
                                .unwrap_or_else(|p| p.into_inner())
                                .environment_loaded = Some(name);
                            self.event(PreviewEvent::Info(format!(
                                "Lighting: environment map {}",
                                path.display()
                            )));
                        }
                        Err(e) => self.error(format!("Could not open the environment map: {e}")),
                    },
                    Command::Scene(path) => {
                        if self.load_scene(&mut state, path.as_deref()) {
                            new_scene = true;
                        }
                    }
                    Command::PaintMaterial(index) => {
                        state.paint_override = index;
                        new_shading = true;
                    }
                    Command::Resize(w, h) => state.size = (w, h),
                    Command::Quality(q) => {
                        if let Some(e) = state.set_quality(q) {
                            self.error(e);
                        }
                        new_grid |= state.grid != grid;
                        new_shading = true;
                    }
                    Command::Orbit(yaw, pitch) => state.camera.orbit(yaw, pitch),
                    Command::Zoom(f) => state.camera.zoom(f),
                    Command::Pan(dx, dy) => state.camera.pan(dx, dy),
                    Command::Export(path) => {
                        self.export(&path, &a, b.as_ref(), b_shared.as_deref(), &state.display)
                    }
                }
            }
            if new_grid && let Some(shading) = state.shading_a() {
                match ProgressiveRender::new(
                    state.scene.clone(),
                    state.environment.clone(),
                    shading,
                    state.camera.clone(),
                    RenderSettings::default(),
                ) {
                    Ok(r) => {
                        a = r;
                        a.set_path_cache_samples(cache_samples);
                    }
                    Err(e) => self.error(format!("preview: {e}")),
                }
                b = None;
            }
            if new_env {
                for r in std::iter::once(&mut a).chain(b.as_mut()) {
                    if let Err(e) = r.set_environment(state.environment.clone()) {
                        self.error(format!("preview: {e}"));
                    }
                }
            }
            reshadeable &= new_shading
                && state.design.gloss == gloss_before
                && state.views.b.is_none()
                && (a.camera().width(), a.camera().height()) == state.size;
            if new_shading || new_scene {
                // An invalid design keeps the last valid image; the paint panel says
                // what is wrong.
                if new_scene {
                    state.paint_a = None;
                }
                let Some(shading_a) = state.shading_a() else {
                    restart = false;
                    continue;
                };
                if reshadeable {
                    match a.edit_shading(shading_a.clone()) {
                        Ok(EditOutcome::Reshaded) => {
                            // The full-resolution re-shaded image now; fresh
                            // passes of the new design refine it below.
                            restart = false;
                            self.publish_edit(&state, &a, PassStats::default());
                            continue;
                        }
                        // No complete cache yet, a mirror or a wider lobe: traced
                        // fresh.
                        Ok(EditOutcome::Fresh(_)) => {}
                        Err(e) => self.error(format!("preview: {e}")),
                    }
                }
                let result = if new_scene {
                    a.set_scene(state.scene.clone(), shading_a)
                } else {
                    a.set_shading(shading_a)
                };
                if let Err(e) = result {
                    self.error(format!("preview: {e}"));
                }
                // A comparison records more of the first view's paths, for the
                // second view to be re-shaded from (restarts the first view, which
                // the new shading did anyway).
                let wanted = if state.views.b.is_some() {
                    COMPARE_CACHE_SAMPLES
                } else {
                    RESHADE_SAMPLES
                };
                if wanted != cache_samples {
                    cache_samples = wanted;
                    a.set_path_cache_samples(wanted);
                }
                // A job still running for an older change finishes unobserved.
                b_job = state.spawn_second_shading();
                b_new_scene |= new_scene;
                b_shared = None;
                if state.views.b.is_none() {
                    b = None;
                    b_new_scene = false;
                }
            }
            let coarse = restart;
            let resolution = if restart {
                restart = false;
                // A coarse pass first, so a change shows within a frame or two.
                Some((
                    (state.size.0 / COARSE_FACTOR).max(1),
                    (state.size.1 / COARSE_FACTOR).max(1),
                ))
            } else if (a.camera().width(), a.camera().height()) != state.size {
                Some(state.size)
            } else {
                None
            };
            if let Some((w, h)) = resolution {
                state.camera.set_resolution(w, h);
                if a.set_camera(state.camera.clone()).is_err() {
                    continue;
                }
            }
            // An edit's first image was re-shaded from one recorded sample per pixel;
            // with no further edit waiting (the commands were just read), the
            // re-shade from all of them comes before fresh passes.
            if a.refine_edit() {
                self.publish_edit(&state, &a, PassStats::default());
                continue;
            }
            let Some(stats_a) = a.render_pass_cancellable(1, &self.cancel) else {
                restart = true;
                continue;
            };
            if let Some(job) = b_job.take() {
                // Show the first view's new image while the second's shading is
                // still being fitted.
                if !job.is_finished() {
                    self.publish(&mut state, &a, None, stats_a, coarse, true);
                }
                match job.join().ok().flatten() {
                    // Shared samples where the first view's paths can be re-shaded
                    // with the second shading; a render of its own where not.
                    Some(shading) => match a.reshade_recorded(&shading) {
                        Ok(_) => {
                            b_shared = Some(shading);
                            b = None;
                            b_new_scene = false;
                        }
                        Err(e) => {
                            b_reason = independent_reason(&e);
                            b = self.second_view(b.take(), &state, shading, b_new_scene);
                            b_new_scene = false;
                        }
                    },
                    None => {
                        self.error("preview: the second design is invalid".into());
                        b = None;
                    }
                }
            }
            if let Some(shading_b) = b_shared.clone() {
                // Both panes from the first view's paths: re-shaded (two replays)
                // when the map is due, the first view alone in between.
                let spp = a.samples_per_pixel();
                if coarse || spp.is_power_of_two() || spp >= state.quality.max_spp {
                    match (
                        a.reshade_recorded(a.shading()),
                        a.reshade_recorded(&shading_b),
                    ) {
                        (Ok(ra), Ok(rb)) => {
                            self.publish_shared(&mut state, &a, &ra, &rb, stats_a, coarse)
                        }
                        (Err(e), _) | (_, Err(e)) => {
                            b_reason = independent_reason(&e);
                            b_shared = None;
                            b = self.second_view(None, &state, shading_b, false);
                            restart = true;
                        }
                    }
                } else {
                    self.publish(&mut state, &a, None, stats_a, coarse, true);
                }
                continue;
            }
            let Some(r) = b.as_mut() else {
                if a.is_reshaded() {
                    self.publish_edit(&state, &a, stats_a);
                } else {
                    self.publish(&mut state, &a, None, stats_a, coarse, false);
                }
                continue;
            };
            // The second view follows the first's camera (and resolution) exactly, and
            // holds the same samples.
            if resolution.is_some() || r.samples_per_pixel() + 1 != a.samples_per_pixel() {
                if r.set_camera(state.camera.clone()).is_err() {
                    b = None;
                    continue;
                }
                if a.samples_per_pixel() != 1 {
                    // Out of step (a pass of the second view was cancelled): both
                    // start again.
                    restart = true;
                    continue;
                }
            }
            let Some(stats_b) = r.render_pass_cancellable(1, &self.cancel) else {
                restart = true;
                continue;
            };
            self.publish(
                &mut state,
                &a,
                Some((&*r, stats_b, &b_reason)),
                stats_a,
                coarse,
                false,
            );
        }
    }

    /// The second view with new shading: the existing render re-shaded (and given the
    /// new scene), or a new one.
    fn second_view(
        &self,
        existing: Option<ProgressiveRender>,
        state: &State,
        shading: Arc<Shading>,
        new_scene: bool,
    ) -> Option<ProgressiveRender> {
        let result = match existing {
            Some(mut r) => {
                let set = if new_scene {
                    r.set_scene(state.scene.clone(), shading)
                } else {
                    r.set_shading(shading)
                };
                set.map(|()| r)
            }
            None => ProgressiveRender::new(
                state.scene.clone(),
                state.environment.clone(),
                shading,
                state.camera.clone(),
                RenderSettings::default(),
            ),
        };
        match result {
            Ok(r) => Some(r),
            Err(e) => {
                self.error(format!("preview: {e}"));
                None
            }
        }
    }

    /// Loads a glTF scene (or the built-in car for `None`) into `state`; on failure
    /// reports the error and leaves `state` as it was.
    fn load_scene(&self, state: &mut State, path: Option<&Path>) -> bool {
        let loaded: Result<Scene, String> = match path {
            None => Ok(generate(&CarParameters::default())),
            Some(p) => load(p, &LoadOptions::default()).map_err(|e| e.to_string()),
        };
        let scene = match loaded {
            Ok(s) => s,
            Err(e) => {
                self.error(format!("Could not open the scene: {e}"));
                return false;
            }
        };
        let info = scene_info(&scene, path);
        let materials = scene.materials.clone();
        let automatic_paint = scene.paint_materials.clone();
        let render_scene = match RenderScene::new(scene) {
            Ok(s) => Arc::new(s),
            Err(e) => {
                self.error(format!("Could not open the scene: {e}"));
                return false;
            }
        };
        state.camera = render_scene.default_camera(state.size.0, state.size.1);
        state.scene = render_scene;
        state.materials = materials;
        state.automatic_paint = automatic_paint;
        state.paint_override = None;
        let message = match path {
            None => "Scene: the built-in car".to_owned(),
            Some(p) => format!(
                "Opened the scene {} ({} materials; paint on {}){}",
                p.display(),
                info.materials.len(),
                names_of(&info.materials, &info.automatic_paint),
                if info.warnings.is_empty() {
                    String::new()
                } else {
                    format!(
                        "; {} warning(s): {}",
                        info.warnings.len(),
                        info.warnings.join("; ")
                    )
                }
            ),
        };
        self.shared.lock().unwrap_or_else(|p| p.into_inner()).scene = Some(info);
        self.event(PreviewEvent::Info(message));
        true
    }

    fn export(
        &self,
        path: &Path,
        a: &ProgressiveRender,
        b: Option<&ProgressiveRender>,
        b_shared: Option<&Shading>,
        display: &DisplaySettings,
    ) {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let write = |film: &Film, path: &Path| match ext.as_deref() {
            Some("png") => film.write_png(path, display).map_err(|e| e.to_string()),
            Some("exr") => film.write_exr(path).map_err(|e| e.to_string()),
            _ => Err(format!(
                "{}: export as .png (as shown) or .exr (linear sRGB)",
                path.display()
            )),
        };
        if a.samples_per_pixel() == 0 {
            return self.error("Nothing to export yet: the preview has no samples.".into());
        }
        let mut written = Vec::new();
        let mut targets = vec![(a.film(), path.to_owned())];
        if let Some(b) = b {
            targets.push((b.film(), second_path(path)));
        }
        for (film, target) in targets {
            match write(film, &target) {
                Ok(()) => written.push(target.display().to_string()),
                Err(e) => return self.error(format!("Could not export the preview: {e}")),
            }
        }
        let mut note = String::new();
        if let Some(shading) = b_shared {
            // The second view has no film of its own: its re-shaded image, as shown.
            let target = second_path(path);
            match (ext.as_deref(), a.reshade_recorded(shading)) {
                (Some("png"), Ok(image)) => {
                    let pixels = display_xyz(&image.xyz, display);
                    match write_png_rgb(&target, image.width, image.height, &pixels) {
                        Ok(()) => written.push(target.display().to_string()),
                        Err(e) => {
                            return self.error(format!("Could not export the second view: {e}"));
                        }
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
        self.event(PreviewEvent::Info(format!(
            "Exported the preview ({} spp) to {}{note}",
            a.samples_per_pixel(),
            written.join(" and ")
        )));
    }

    /// Publishes the first view's image while a paint edit is shown re-shaded:
    /// the blend of the re-shaded and the fresh image, in the exposure of the last
    /// image (the fresh film is too young to set one, and a steady exposure lets
    /// the edit show).
    fn publish_edit(&self, state: &State, a: &ProgressiveRender, stats: PassStats) {
        let Some((image, fresh_weight)) = a.edit_estimate() else {
            return;
        };
        let frame = PreviewFrame {
            width: image.width,
            height: image.height,
            pixels: display_xyz(&image.xyz, &state.display),
            samples_per_pixel: a.samples_per_pixel(),
            samples_per_second: stats.samples_per_second(),
            noise_delta_e: None,
            coarse: false,
            reshaded: Some(fresh_weight),
            epoch: state.epoch,
            source: None,
        };
        {
            let mut shared = self.shared.lock().unwrap_or_else(|p| p.into_inner());
            shared.frames = [Some(frame), None];
            shared.fresh = true;
            shared.delta_e = None;
            shared.fresh_map = true;
        }
        self.ctx.request_repaint();
    }

    /// Publishes both views of a comparison made from the first view's paths: `ra`
    /// and `rb` are those paths re-shaded with each view's shading (the first is
    /// the film itself up to rounding), so where the two shadings agree the panes
    /// are equal, and the ΔE00 map shows the models, not noise.
    fn publish_shared(
        &self,
        state: &mut State,
        a: &ProgressiveRender,
        ra: &Reshaded,
        rb: &Reshaded,
        stats_a: PassStats,
        coarse: bool,
    ) {
        let display = DisplaySettings {
            exposure_stops: a.film().auto_exposure(),
            ..DisplaySettings::default()
        };
        state.display = display;
        let spp = a.samples_per_pixel();
        let recorded_spp = a.path_cache().samples_per_pixel();
        let frame = |image: &Reshaded, source: Option<SecondSource>| PreviewFrame {
            width: image.width,
            height: image.height,
            pixels: display_xyz(&image.xyz, &display),
            samples_per_pixel: spp,
            samples_per_second: stats_a.samples_per_second(),
            noise_delta_e: if coarse {
                None
            } else {
                a.noise_estimate(&display).map(|n| n.mean_delta_e)
            },
            coarse,
            reshaded: None,
            epoch: state.epoch,
            source,
        };
        let frames = [
            Some(frame(ra, None)),
            Some(frame(rb, Some(SecondSource::Shared { recorded_spp }))),
        ];
        let map =
            DeltaEMap::between_xyz(ra.width, ra.height, &ra.xyz, &rb.xyz, &display).map(|mut m| {
                m.samples_per_pixel = spp;
                m
            });
        {
            let mut shared = self.shared.lock().unwrap_or_else(|p| p.into_inner());
            shared.frames = frames;
            shared.fresh = true;
            shared.delta_e = map;
            shared.fresh_map = true;
        }
        self.ctx.request_repaint();
    }

    fn publish(
        &self,
        state: &mut State,
        a: &ProgressiveRender,
        b: Option<(&ProgressiveRender, PassStats, &str)>,
        stats_a: PassStats,
        coarse: bool,
        b_pending: bool,
    ) {
        // One exposure for both views, so neither hides nor invents a difference.
        let display = DisplaySettings {
            exposure_stops: a.film().auto_exposure(),
            ..DisplaySettings::default()
        };
        state.display = display;
        let frame = |r: &ProgressiveRender, stats: PassStats| PreviewFrame {
            width: r.film().width(),
            height: r.film().height(),
            pixels: r.film().to_display(&display),
            samples_per_pixel: r.samples_per_pixel(),
            samples_per_second: stats.samples_per_second(),
            noise_delta_e: if coarse {
                None
            } else {
                r.noise_estimate(&display).map(|n| n.mean_delta_e)
            },
            coarse,
            reshaded: None,
            epoch: state.epoch,
            source: None,
        };
        let frames = [
            Some(frame(a, stats_a)),
            b.map(|(r, s, reason)| PreviewFrame {
                source: Some(SecondSource::Independent {
                    reason: reason.to_owned(),
                }),
                ..frame(r, s)
            }),
        ];
        // The map costs about as much as a pass at 640×400: made at 1, 2, 4, 8, …
        // samples per pixel, which keeps its share of the time small.
        let spp = a.samples_per_pixel();
        let map = match b {
            Some((b, _, _)) if coarse || spp.is_power_of_two() || spp >= state.quality.max_spp => {
                DeltaEMap::between(a.film(), b.film(), &display).map(|mut m| {
                    m.samples_per_pixel = spp;
                    m
                })
            }
            _ => None,
        };
        {
            let mut shared = self.shared.lock().unwrap_or_else(|p| p.into_inner());
            if b_pending {
                // Keep the second view's last image until its new one is rendered.
                let [first, _] = frames;
                shared.frames[0] = first;
            } else {
                shared.frames = frames;
            }
            shared.fresh = true;
            if map.is_some() || (b.is_none() && !b_pending) {
                shared.delta_e = map;
                shared.fresh_map = true;
            }
        }
        self.ctx.request_repaint();
    }
}

/// Why the second view cannot be re-shaded from the first view's paths, as the
/// user reads it.
fn independent_reason(e: &ReshadeError) -> String {
    match e {
        ReshadeError::DeltaChanged => "an ideal-mirror paint cannot be re-shaded into the other \
             view (a mirror bounce has no lobe to re-weight)"
            .to_owned(),
        other => format!("the first view's paths cannot be re-shaded ({other})"),
    }
}

fn scene_info(scene: &Scene, path: Option<&Path>) -> SceneInfo {
    SceneInfo {
        name: path.map(file_name).unwrap_or_else(|| "Built-in car".into()),
        path: path.map(Path::to_owned),
        materials: scene.materials.iter().map(|m| m.name.clone()).collect(),
        automatic_paint: scene.paint_materials.clone(),
        warnings: scene.warnings.clone(),
    }
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
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

#[cfg(test)]
mod tests {
    use super::*;

    fn r(x0: f32, y0: f32, x1: f32, y1: f32) -> egui::Rect {
        egui::Rect::from_min_max(egui::pos2(x0, y0), egui::pos2(x1, y1))
    }

    fn area(rects: &[egui::Rect]) -> f32 {
        rects.iter().map(|r| r.area()).sum()
    }

    fn overlap(a: egui::Rect, b: egui::Rect) -> bool {
        let i = a.intersect(b);
        i.width() > 1e-3 && i.height() > 1e-3
    }

    /// The background fill and the images tile the preview area exactly: every
    /// point is painted once, by the fill or by an image.
    #[test]
    fn the_background_covers_exactly_what_the_images_leave() {
        let rect = r(0.0, 0.0, 1000.0, 800.0);
        let cases: Vec<Vec<egui::Rect>> = vec![
            vec![],
            vec![letterbox(rect, egui::vec2(532.0, 400.0))],
            vec![letterbox(rect, egui::vec2(200.0, 400.0))],
            // Side by side, with a gap between the panes.
            vec![r(0.0, 200.0, 495.0, 600.0), r(505.0, 190.0, 1000.0, 610.0)],
            // Reaching outside the area (clipped) and touching its corner.
            vec![
                r(-50.0, -50.0, 100.0, 100.0),
                r(900.0, 700.0, 1100.0, 900.0),
            ],
        ];
        for covered in cases {
            let fill = uncovered(rect, &covered);
            let inside: Vec<egui::Rect> = covered.iter().map(|c| c.intersect(rect)).collect();
            let total = area(&fill) + area(&inside);
            assert!(
                (total - rect.area()).abs() < 1e-3 * rect.area(),
                "{covered:?}: fill {} + images {} != {}",
                area(&fill),
                area(&inside),
                rect.area()
            );
            for (i, a) in fill.iter().enumerate() {
                assert!(a.is_positive() && rect.contains_rect(*a), "{a:?}");
                for c in &inside {
                    assert!(!overlap(*a, *c), "{a:?} overlaps {c:?}");
                }
                for b in &fill[i + 1..] {
                    assert!(!overlap(*a, *b), "{a:?} overlaps {b:?}");
                }
            }
        }
    }
}
