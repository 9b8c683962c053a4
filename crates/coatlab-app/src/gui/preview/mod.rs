//! The live preview: a thin widget over the core's live engine
//! ([`coatlab_core::engine`]), which runs on a render thread of its own.
//!
//! The widget sends the engine commands (a new design, a camera move, other
//! lighting or scene, a new size, the comparison, a quality preset) and shows
//! the latest images the engine posts: one view, or two for a comparison (side
//! by side, split, or their ΔE00 map). What to re-shade, re-trace or rebuild
//! after each command is the engine's decision, not the widget's. Files (glTF
//! scenes, environment maps) are read on the render thread too; what happens
//! comes back as events the app shows in its notice bar. An export runs on the
//! render thread between two passes (`export`).
//!
//! | file | what |
//! | --- | --- |
//! | `mod.rs` | the widget's state, its commands, and taking up what the engine posted |
//! | `toolbar.rs` | the controls above the picture: lighting, model, comparison, scene |
//! | `panes.rs` | the picture: one pane, two side by side, split, the ΔE00 map; mouse input |
//! | `export.rs` | writing the views as PNG or EXR |

mod export;
mod panes;
mod toolbar;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use coatlab_core::design::PaintDesign;
use coatlab_core::design::presets::Preset;
use coatlab_core::engine::{
    Command, CpuBackend, EngineEvent, EngineThread, SceneInfo, SceneSource, ThreadHooks, Views,
    file_name,
};
use coatlab_core::paint::phong::PhongVariant;
use coatlab_core::render::film::DisplayChoice;
use coatlab_core::render::lighting::Lighting;
use coatlab_core::render::material::ShadingModel;
use coatlab_core::render::pick::toggled;
use coatlab_core::render::view::ViewChoice;
use egui::{RichText, Ui};

pub use coatlab_core::engine::{Frame as PreviewFrame, SecondSource};
pub use export::second_path;
pub(super) use panes::uncovered;

use super::compare::{CompareLayout, CompareMode, DeltaEMap, map_colours};
use super::history::PaintChoice;
use super::quality::QualitySelector;

/// Something the app should tell the user.
#[derive(Debug, Clone, PartialEq)]
pub enum PreviewEvent {
    Info(String),
    Error(String),
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
    engine: EngineThread,
    textures: [Option<egui::TextureHandle>; 2],
    map_texture: Option<egui::TextureHandle>,
    status: [Option<PreviewFrame>; 2],
    delta_e: Option<DeltaEMap>,
    map_scale: f32,
    map_scale_shown: f32,
    /// The lighting selected.
    lighting: Lighting,
    /// The environment map opened last, and its file name.
    map: Option<(PathBuf, String)>,
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
    paint_override: Option<Vec<u32>>,
    /// Per scene material, the area the view sees of it (m²), and the epoch of
    /// the view it was measured in; asked for while the paint list is open.
    visible: Option<(u64, Vec<f32>)>,
    /// The epoch of the view whose visible areas were last asked for.
    visible_asked: Option<u64>,
    /// The view chosen last (a scene opens at the default one; orbiting, zooming
    /// and panning move on from it).
    view: ViewChoice,
    /// The current design's name (to offer a different one for comparison).
    design_name: String,
    size: (u32, u32),
    change_sent_at: Option<Instant>,
    last_latency: Option<Duration>,
    events: Vec<PreviewEvent>,
    /// The quality preset and the knobs it set (see [`super::quality`]).
    quality: QualitySelector,
    /// How the images are shown: tone mapping, exposure adjustment (a setting
    /// of the session, not of the design).
    display: DisplayChoice,
    /// Where the last frame drew opaque images (the panels behind need no fill there).
    opaque: Vec<egui::Rect>,
}

impl Preview {
    /// Starts the render thread on `design`.
    pub fn start(ctx: &egui::Context, design: &PaintDesign) -> Self {
        let repaint = ctx.clone();
        let hooks = ThreadHooks {
            on_start: Arc::new(super::priority::lower_render_thread),
            on_post: Arc::new(move || repaint.request_repaint()),
        };
        Self {
            engine: EngineThread::spawn(CpuBackend::default(), design.clone(), hooks),
            textures: [None, None],
            map_texture: None,
            status: [None, None],
            delta_e: None,
            map_scale: 5.0,
            map_scale_shown: f32::NAN,
            lighting: Lighting::Studio,
            map: None,
            model: ShadingModel::Paint,
            phong: PhongVariant::BestFit,
            compare: CompareMode::Off,
            layout: CompareLayout::SideBySide,
            divider: 0.5,
            second: None,
            scene: None,
            paint_override: None,
            visible: None,
            visible_asked: None,
            view: ViewChoice::default(),
            design_name: design.name.clone(),
            size: (0, 0),
            change_sent_at: None,
            last_latency: None,
            events: Vec::new(),
            quality: QualitySelector::default(),
            display: DisplayChoice::default(),
            opaque: Vec::new(),
        }
    }

    /// The quality choice and the knobs in force.
    pub fn quality(&self) -> &QualitySelector {
        &self.quality
    }

    /// Sends a command that changes the picture; the latency to its first image
    /// is measured from now.
    fn send(&mut self, command: Command) {
        self.engine.send(command);
        self.change_sent_at = Some(Instant::now());
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
        self.send(Command::Scene(SceneSource::File(path.to_owned())));
    }

    /// Goes back to the built-in car.
    pub fn built_in_scene(&mut self) {
        self.paint_override = None;
        self.send(Command::Scene(SceneSource::BuiltInCar));
    }

    /// Opens an environment map (.hdr, .exr) on the render thread; the lighting stays
    /// if it cannot be read.
    pub fn open_environment(&mut self, path: &Path) {
        self.send(Command::OpenMap(path.to_owned()));
    }

    /// Lights the scene with `lighting`.
    fn set_lighting(&mut self, lighting: Lighting) {
        if lighting != self.lighting {
            self.lighting = lighting.clone();
            self.send(Command::Lighting(lighting));
        }
    }

    /// Paints the scene materials `chosen` instead of the loader's choice (`None`).
    pub fn set_paint_materials(&mut self, chosen: Option<Vec<u32>>) {
        if self.paint_override != chosen {
            self.paint_override = chosen.clone();
            self.send(Command::PaintMaterials(chosen));
        }
    }

    /// Paints material `index` too, or no longer (a click on the car, a box in
    /// the paint list).
    pub fn toggle_paint_material(&mut self, index: u32) {
        let chosen = toggled(&self.paint_materials(), index);
        self.set_paint_materials(Some(chosen));
    }

    /// Puts the camera at `view`: sent even when it is the view chosen last, which
    /// brings the camera back after an orbit.
    pub fn set_view(&mut self, view: ViewChoice) {
        self.view = view;
        self.send(Command::View(view));
    }

    /// The view chosen last.
    pub fn view(&self) -> ViewChoice {
        self.view
    }

    /// Shows the images with `display` (tone mapping, exposure); nothing is
    /// rendered again.
    pub fn set_display(&mut self, display: DisplayChoice) {
        if display != self.display {
            self.display = display;
            self.send(Command::Display(display));
        }
    }

    /// How the images are shown.
    pub fn display(&self) -> DisplayChoice {
        self.display
    }

    /// The scene materials that carry the paint: the user's choice, else the
    /// loader's.
    pub fn paint_materials(&self) -> Vec<u32> {
        match (&self.paint_override, &self.scene) {
            (Some(chosen), _) => chosen.clone(),
            (None, Some(scene)) => scene.automatic_paint(),
            (None, None) => Vec::new(),
        }
    }

    /// Whether the loader's choice is painted (no user choice).
    pub fn paint_is_automatic(&self) -> bool {
        self.paint_override.is_none()
    }

    /// Per scene material, the area the current view sees of it (m²), once
    /// measured ([`Self::ask_visible_areas`]); the last view's while the new
    /// one's is measured.
    pub fn visible_areas(&self) -> Option<&[f32]> {
        self.visible.as_ref().map(|(_, areas)| areas.as_slice())
    }

    /// Asks the render thread for the visible areas of the view the last
    /// command shows, unless they are measured or asked for already: a job
    /// between two passes, off the UI thread.
    pub fn ask_visible_areas(&mut self) {
        let epoch = self.engine.epoch();
        let measured = self.visible.as_ref().is_some_and(|(e, _)| *e >= epoch);
        if measured || self.visible_asked.is_some_and(|e| e >= epoch) {
            return;
        }
        self.visible_asked = Some(epoch);
        self.engine.run_job(Box::new(|engine| {
            Some(EngineEvent::VisibleAreas(engine.visible_areas()))
        }));
    }

    /// The paint-material choice with the scene it was made on, for the undo
    /// history; `None` before a scene is shown.
    pub fn paint_choice(&self) -> Option<PaintChoice> {
        let scene = self.scene.as_ref()?;
        Some(PaintChoice {
            scene: scene.name.clone(),
            chosen: self.paint_override.clone(),
        })
    }

    /// Writes the first view (and the second, as NAME-b.EXT, in a comparison): PNG
    /// as shown (same exposure and tone mapping), EXR as linear sRGB. Runs on the
    /// render thread after the pass in flight, which it keeps.
    pub fn export(&mut self, path: &Path) {
        self.engine.run_job(export::job(path.to_owned()));
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

    /// What the engine's views render for the comparison chosen.
    fn views(&self) -> Views {
        match self.compare {
            CompareMode::Off => Views::single(self.model),
            CompareMode::Models => Views::models(self.phong),
            CompareMode::Designs => {
                Views::designs(self.model, self.second.as_ref().map(|(_, d)| d))
            }
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

    /// The lighting selected, and the file name of the map opened last.
    pub fn environment(&self) -> (&Lighting, Option<&str>) {
        (&self.lighting, self.map.as_ref().map(|(_, n)| n.as_str()))
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

    /// Takes up what the render thread posted: images, the ΔE00 map, the scene,
    /// events. Called by [`Self::ui`] each frame; tests call it between frames.
    pub fn poll(&mut self, ctx: &egui::Context) {
        let mut mailbox = self.engine.mailbox();
        let events = std::mem::take(&mut mailbox.events);
        if let Some(scene) = mailbox.scene.take() {
            // The engine frames a new scene at the default view.
            self.view = ViewChoice::default();
            self.scene = Some(scene);
            // Another scene's materials.
            self.visible = None;
        }
        if std::mem::take(&mut mailbox.fresh) {
            // Uploaded from the mailbox, not copied out of it.
            upload_frames(ctx, &mailbox.frames, &mut self.textures, &mut self.status);
            if let Some(f) = &self.status[0]
                && f.epoch >= self.engine.epoch()
                && let Some(sent) = self.change_sent_at.take()
            {
                self.last_latency = Some(sent.elapsed());
            }
        }
        if std::mem::take(&mut mailbox.fresh_map) {
            self.delta_e = mailbox.delta_e.take();
            self.map_scale_shown = f32::NAN;
        }
        drop(mailbox);
        for event in events {
            self.take_event(event);
        }
        if self.compare == CompareMode::Off {
            self.delta_e = None;
        }
        if let Some(map) = &self.delta_e
            && self.map_scale_shown != self.map_scale
        {
            let image = egui::ColorImage::new(
                [map.width as usize, map.height as usize],
                map_colours(map, self.map_scale),
            );
            panes::upload(ctx, &mut self.map_texture, "preview-delta-e", image);
            self.map_scale_shown = self.map_scale;
        }
    }

    /// An event of the engine as the app's notice.
    fn take_event(&mut self, event: EngineEvent) {
        let notice = match event {
            EngineEvent::SceneLoaded(info) => PreviewEvent::Info(scene_message(&info)),
            EngineEvent::MapLoaded(path) => {
                self.lighting = Lighting::Map(path.clone());
                self.map = Some((path.clone(), file_name(&path)));
                PreviewEvent::Info(format!("Lighting: environment map {}", path.display()))
            }
            EngineEvent::PaintMaterials(chosen) => {
                let names = self
                    .scene
                    .as_ref()
                    .map(|s| panes::names_of(&s.materials, &chosen))
                    .unwrap_or_default();
                self.paint_override = Some(chosen);
                PreviewEvent::Info(format!("Paint on: {names}"))
            }
            EngineEvent::VisibleAreas(areas) => {
                // Measured for the view asked for: no notice.
                self.visible = Some((self.visible_asked.unwrap_or(0), areas));
                return;
            }
            EngineEvent::Failed(e) => PreviewEvent::Error(e.to_string()),
            EngineEvent::Report { text, is_error } if is_error => PreviewEvent::Error(text),
            EngineEvent::Report { text, .. } => PreviewEvent::Info(text),
        };
        self.events.push(notice);
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
        self.picture_ui(ui);
        // One line each, as `picture_ui` leaves room for: in a narrow window
        // the rest is elided and shown on hover.
        ui.add(egui::Label::new(RichText::new(self.status_line()).weak()).truncate());
        if self.compare != CompareMode::Off
            && let Some(source) = self.status[1].as_ref().and_then(|f| f.source.as_ref())
        {
            ui.add(egui::Label::new(RichText::new(second_source_label(source)).weak()).truncate());
        }
        requests
    }

    /// Asks for the render size that fits `pane` (points) at this display's
    /// pixel density, the views' share of the preview's pixels and the quality's
    /// resolution divisor.
    fn fit_to(&mut self, ui: &Ui, pane: egui::Vec2) {
        let ppp = ui.ctx().pixels_per_point();
        let views = if self.compare == CompareMode::Off {
            1
        } else {
            2
        };
        let want = self
            .quality
            .knobs
            .divide(panes::fit(pane.x * ppp, pane.y * ppp, views));
        if want != self.size && want.0 > 16 && want.1 > 16 {
            self.size = want;
            self.send(Command::Size(want.0, want.1));
        }
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

/// The views' new images as textures, with their statistics (without pixels).
fn upload_frames(
    ctx: &egui::Context,
    frames: &[Option<PreviewFrame>; 2],
    textures: &mut [Option<egui::TextureHandle>; 2],
    status: &mut [Option<PreviewFrame>; 2],
) {
    for (i, frame) in frames.iter().enumerate() {
        let Some(frame) = frame else {
            status[i] = None;
            textures[i] = None;
            continue;
        };
        let image = egui::ColorImage::from_rgba_unmultiplied(
            [frame.width as usize, frame.height as usize],
            frame.pixels.as_flattened(),
        );
        panes::upload(ctx, &mut textures[i], ["preview-a", "preview-b"][i], image);
        status[i] = Some(PreviewFrame {
            pixels: Vec::new(),
            ..frame.clone()
        });
    }
}

/// The line the preview shows under a comparison: how its second view is made.
pub fn second_source_label(source: &SecondSource) -> String {
    match source {
        SecondSource::Shared {
            recorded_spp,
            own_weight,
        } => format!(
            "Shared samples: {recorded_spp} spp of the first view's paths re-shaded into the \
             second (more where the map is undecided), so the difference shows the models; its \
             own samples weigh {:.0} %",
            own_weight * 100.0
        ),
        SecondSource::Independent { reason } => {
            format!("Independent renders (same camera and seed): {reason}")
        }
    }
}

/// The notice for a scene now rendered.
fn scene_message(info: &SceneInfo) -> String {
    let Some(path) = &info.path else {
        return "Scene: the built-in car".to_owned();
    };
    let warnings = if info.warnings.is_empty() {
        String::new()
    } else {
        format!(
            "; {} warning(s): {}",
            info.warnings.len(),
            info.warnings.join("; ")
        )
    };
    format!(
        "Opened the scene {} ({} materials; paint on {}){warnings}",
        path.display(),
        info.materials.len(),
        panes::names_of(&info.materials, &info.automatic_paint()),
    )
}
