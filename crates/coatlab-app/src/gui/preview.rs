//! The live preview: the progressive path tracer of `coatlab-core` on a background
//! thread, its latest image shown as a texture.
//!
//! The UI never waits on the renderer. It sends commands (a new design, a camera
//! move, another environment, a new size) over a channel and raises a cancel flag so
//! a pass in flight stops at its next tile; the render thread drains the commands,
//! restarts, renders one coarse pass at a quarter of the resolution so a new image
//! appears at once, then refines at full resolution one sample per pixel per pass.
//! After each pass it publishes the display image (sRGB bytes) in a shared slot and
//! asks egui for a repaint; the UI uploads the newest image when there is one.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, TryRecvError, channel};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

use coatlab_core::cie::Illuminant;
use coatlab_core::design::PaintDesign;
use coatlab_core::render::camera::Camera;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::DisplaySettings;
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::{ProgressiveRender, RenderScene, RenderSettings};
use coatlab_core::scene::car::{CarParameters, generate};
use coatlab_core::spectrum::WavelengthGrid;
use egui::{RichText, Ui};

/// Wavelengths per path: as `coatlab render` by default.
const PREVIEW_WAVELENGTHS: usize = 32;
/// The coarse first pass renders at 1/COARSE_FACTOR of the resolution.
const COARSE_FACTOR: u32 = 4;
/// Refinement stops here; the image is then as good as the preview gets.
const MAX_SPP: u32 = 1024;
/// The preview's largest size in pixels (it renders at most this, scaled up on screen):
/// the default keeps the first image within reach of a 2-core machine.
const MAX_PREVIEW_PIXELS: (u32, u32) = (640, 400);

/// The lighting setups offered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EnvironmentChoice {
    Studio,
    BoothD65,
    BoothA,
    BoothF11,
    Outdoor,
}

impl EnvironmentChoice {
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
        }
    }

    fn build(self, grid: &WavelengthGrid) -> Environment {
        match self {
            EnvironmentChoice::Studio => Environment::studio(grid),
            EnvironmentChoice::BoothD65 => Environment::booth(Illuminant::D65, grid),
            EnvironmentChoice::BoothA => Environment::booth(Illuminant::A, grid),
            EnvironmentChoice::BoothF11 => Environment::booth(Illuminant::F11, grid),
            EnvironmentChoice::Outdoor => Environment::outdoor(grid),
        }
    }
}

enum Command {
    Design(Box<PaintDesign>),
    Model(ShadingModel),
    Environment(EnvironmentChoice),
    Resize(u32, u32),
    Orbit(f32, f32),
    Zoom(f32),
    Pan(f32, f32),
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
}

#[derive(Default)]
struct Shared {
    frame: Option<PreviewFrame>,
    fresh: bool,
    error: Option<String>,
}

/// The preview's UI-side handle.
pub struct Preview {
    commands: Sender<Command>,
    shared: Arc<Mutex<Shared>>,
    cancel: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    texture: Option<egui::TextureHandle>,
    status: Option<PreviewFrame>,
    environment: EnvironmentChoice,
    model: ShadingModel,
    size: (u32, u32),
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
        let design = design.clone();
        let thread = std::thread::Builder::new()
            .name("coatlab-preview".into())
            .spawn(move || worker.run(design))
            .ok();
        Self {
            commands: tx,
            shared,
            cancel,
            thread,
            texture: None,
            status: None,
            environment: EnvironmentChoice::Studio,
            model: ShadingModel::Paint,
            size: (0, 0),
        }
    }

    fn send(&self, command: Command) {
        // Stop the pass in flight: the thread picks the command up at once.
        self.cancel.store(true, Ordering::Relaxed);
        let _ = self.commands.send(command);
    }

    /// The design changed.
    pub fn set_design(&self, design: &PaintDesign) {
        self.send(Command::Design(Box::new(design.clone())));
    }

    /// The latest frame's statistics.
    pub fn status(&self) -> Option<&PreviewFrame> {
        self.status.as_ref()
    }

    /// Draws the preview with its controls; mouse drags orbit (left) or pan (right or
    /// middle), the wheel zooms.
    pub fn ui(&mut self, ui: &mut Ui) {
        ui.horizontal(|ui| {
            let mut env = self.environment;
            egui::ComboBox::from_label("Lighting")
                .selected_text(env.label())
                .show_ui(ui, |ui| {
                    for e in EnvironmentChoice::ALL {
                        ui.selectable_value(&mut env, e, e.label());
                    }
                });
            if env != self.environment {
                self.environment = env;
                self.send(Command::Environment(env));
            }
            let mut model = self.model;
            for m in [
                ShadingModel::Paint,
                ShadingModel::Phong(coatlab_core::paint::phong::PhongVariant::Naive),
                ShadingModel::Phong(coatlab_core::paint::phong::PhongVariant::BestFit),
            ] {
                ui.selectable_value(&mut model, m, m.label());
            }
            if model != self.model {
                self.model = model;
                self.send(Command::Model(model));
            }
        });
        {
            let mut shared = self.shared.lock().unwrap_or_else(|p| p.into_inner());
            if let Some(e) = shared.error.take() {
                ui.label(RichText::new(e).color(ui.visuals().error_fg_color));
            }
            if shared.fresh {
                shared.fresh = false;
                if let Some(frame) = &shared.frame {
                    let image = egui::ColorImage::from_rgba_unmultiplied(
                        [frame.width as usize, frame.height as usize],
                        bytemuck_pixels(&frame.pixels),
                    );
                    match &mut self.texture {
                        Some(t) => t.set(image, egui::TextureOptions::LINEAR),
                        None => {
                            self.texture = Some(ui.ctx().load_texture(
                                "preview",
                                image,
                                egui::TextureOptions::LINEAR,
                            ))
                        }
                    }
                    self.status = Some(PreviewFrame {
                        pixels: Vec::new(),
                        ..frame.clone()
                    });
                }
            }
        }
        let status_height = 22.0;
        let available = ui.available_size() - egui::vec2(0.0, status_height);
        let ppp = ui.ctx().pixels_per_point();
        let want = fit(available.x * ppp, available.y * ppp);
        if want != self.size && want.0 > 16 && want.1 > 16 {
            self.size = want;
            self.send(Command::Resize(want.0, want.1));
        }
        let (rect, response) = ui.allocate_exact_size(available, egui::Sense::click_and_drag());
        ui.painter()
            .rect_filled(rect, 0.0, egui::Color32::from_gray(20));
        if let Some(t) = &self.texture {
            // Keep the image's aspect: letterbox inside the area.
            let size = t.size_vec2();
            let scale = (rect.width() / size.x).min(rect.height() / size.y);
            let shown = egui::Rect::from_center_size(rect.center(), size * scale);
            ui.painter().image(
                t.id(),
                shown,
                egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
                egui::Color32::WHITE,
            );
        } else {
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "Preparing the car…",
                egui::FontId::proportional(16.0),
                ui.visuals().weak_text_color(),
            );
        }
        let delta = response.drag_delta();
        if delta != egui::Vec2::ZERO {
            if response.dragged_by(egui::PointerButton::Primary) {
                self.send(Command::Orbit(-delta.x * 0.4, delta.y * 0.4));
            } else {
                let scale = self.size.0 as f32 / rect.width().max(1.0);
                self.send(Command::Pan(delta.x * scale, delta.y * scale));
            }
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.send(Command::Zoom((scroll * 0.004).exp()));
            }
        }
        let status = match &self.status {
            Some(s) => format!(
                "{} spp{}  ·  {:.0} k samples/s  ·  noise {}  ·  {}×{}",
                s.samples_per_pixel,
                if s.coarse { " (coarse)" } else { "" },
                s.samples_per_second / 1e3,
                s.noise_delta_e
                    .map(|d| format!("ΔE00 {d:.2}"))
                    .unwrap_or_else(|| "–".into()),
                s.width,
                s.height
            ),
            None => "starting…".into(),
        };
        ui.label(RichText::new(status).weak());
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

fn bytemuck_pixels(pixels: &[[u8; 4]]) -> &[u8] {
    pixels.as_flattened()
}

/// The render size for an area of `w`×`h` physical pixels, capped at
/// [`MAX_PREVIEW_PIXELS`] with the area's aspect.
fn fit(w: f32, h: f32) -> (u32, u32) {
    let (mw, mh) = (MAX_PREVIEW_PIXELS.0 as f32, MAX_PREVIEW_PIXELS.1 as f32);
    let scale = (mw / w.max(1.0)).min(mh / h.max(1.0)).min(1.0);
    ((w * scale).round() as u32, (h * scale).round() as u32)
}

struct Worker {
    commands: Receiver<Command>,
    shared: Arc<Mutex<Shared>>,
    cancel: Arc<AtomicBool>,
    ctx: egui::Context,
}

impl Worker {
    fn publish_error(&self, e: String) {
        self.shared.lock().unwrap_or_else(|p| p.into_inner()).error = Some(e);
        self.ctx.request_repaint();
    }

    fn run(self, mut design: PaintDesign) {
        let Ok(grid) = WavelengthGrid::visible(PREVIEW_WAVELENGTHS) else {
            return self.publish_error("preview: no wavelength grid".into());
        };
        let scene = generate(&CarParameters::default());
        let materials = scene.materials.clone();
        let paint_materials = scene.paint_materials.clone();
        let render_scene = match RenderScene::new(scene) {
            Ok(s) => Arc::new(s),
            Err(e) => return self.publish_error(format!("preview: {e}")),
        };
        let mut env_choice = EnvironmentChoice::Studio;
        let mut model_choice = ShadingModel::Paint;
        let mut size = (320u32, 200u32);
        let mut camera: Camera = render_scene.default_camera(size.0, size.1);
        let shading_of = |design: &PaintDesign, which: ShadingModel| {
            design
                .model(grid)
                .map(|m| Arc::new(Shading::new(&m, which, &materials, &paint_materials)))
        };
        let Ok(shading) = shading_of(&design, model_choice) else {
            return self.publish_error("preview: the design is invalid".into());
        };
        let mut render = match ProgressiveRender::new(
            render_scene.clone(),
            Arc::new(env_choice.build(&grid)),
            shading,
            camera.clone(),
            RenderSettings::default(),
        ) {
            Ok(r) => r,
            Err(e) => return self.publish_error(format!("preview: {e}")),
        };
        let mut restart = true;
        loop {
            // Wait for work when converged; otherwise just look for commands.
            let mut pending = Vec::new();
            if !restart && render.samples_per_pixel() >= MAX_SPP {
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
            let mut new_env = false;
            for c in pending {
                restart = true;
                match c {
                    Command::Design(d) => {
                        design = *d;
                        new_shading = true;
                    }
                    Command::Model(m) => {
                        model_choice = m;
                        new_shading = true;
                    }
                    Command::Environment(e) => {
                        env_choice = e;
                        new_env = true;
                    }
                    Command::Resize(w, h) => size = (w, h),
                    Command::Orbit(yaw, pitch) => camera.orbit(yaw, pitch),
                    Command::Zoom(f) => camera.zoom(f),
                    Command::Pan(dx, dy) => camera.pan(dx, dy),
                }
            }
            if new_env && let Err(e) = render.set_environment(Arc::new(env_choice.build(&grid))) {
                self.publish_error(format!("preview: {e}"));
            }
            if new_shading {
                match shading_of(&design, model_choice) {
                    Ok(s) => {
                        if let Err(e) = render.set_shading(s) {
                            self.publish_error(format!("preview: {e}"));
                        }
                    }
                    // An invalid design keeps the last valid image; the paint panel
                    // says what is wrong.
                    Err(_) => {
                        restart = false;
                        continue;
                    }
                }
            }
            let coarse = restart;
            if restart {
                restart = false;
                // A coarse pass first, so a change shows within a frame or two.
                camera.set_resolution(
                    (size.0 / COARSE_FACTOR).max(1),
                    (size.1 / COARSE_FACTOR).max(1),
                );
                if render.set_camera(camera.clone()).is_err() {
                    continue;
                }
            } else if (render.camera().width(), render.camera().height()) != size {
                camera.set_resolution(size.0, size.1);
                if render.set_camera(camera.clone()).is_err() {
                    continue;
                }
            }
            let start = Instant::now();
            let Some(stats) = render.render_pass_cancellable(1, &self.cancel) else {
                continue;
            };
            let _ = start;
            let film = render.film();
            let display = DisplaySettings {
                exposure_stops: film.auto_exposure(),
                ..DisplaySettings::default()
            };
            let frame = PreviewFrame {
                width: film.width(),
                height: film.height(),
                pixels: film.to_display(&display),
                samples_per_pixel: render.samples_per_pixel(),
                samples_per_second: stats.samples_per_second(),
                noise_delta_e: if coarse {
                    None
                } else {
                    render.noise_estimate(&display).map(|n| n.mean_delta_e)
                },
                coarse,
            };
            {
                let mut shared = self.shared.lock().unwrap_or_else(|p| p.into_inner());
                shared.frame = Some(frame);
                shared.fresh = true;
            }
            self.ctx.request_repaint();
        }
    }
}
