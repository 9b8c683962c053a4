//! [`LiveEngine`]: the views, what they are rendered from, and the state
//! machine's state; commands taken here, render steps in `step.rs` ([`LiveEngine::step`]).

use std::path::PathBuf;
use std::sync::Arc;

use crate::colour::spectrum::WavelengthGrid;
use crate::design::PaintDesign;
use crate::render::environment::Environment;
use crate::render::film::{DisplayChoice, DisplaySettings};
use crate::render::lighting::Lighting;
use crate::render::material::Shading;
use crate::render::pick::{pick, toggled, visible_areas};
use crate::render::reshade::ReshadeError;
use crate::render::view::ViewChoice;

use super::backend::{BackendView, RenderBackend, ViewSetup};
use super::command::{Command, QualityKnobs, SceneSource, Views};
use super::counters::EngineCounters;
use super::cpu::CpuBackend;
use super::events::{EngineError, EngineEvent, SceneInfo};
use super::frame::ViewsUpdate;
use super::inputs::Inputs;
use super::plan::{Actions, Change, State, settle, transition};
use super::views::{SecondImage, ViewSet};
use super::world::{World, load_scene};
use super::{DEFAULT_WAVELENGTHS, INITIAL_SIZE, RESHADE_SAMPLES, ThreadHook};

/// What the engine hands out while it works.
#[derive(Debug)]
pub enum Output {
    /// New images.
    Views(ViewsUpdate),
    /// Something the user should be told.
    Event(EngineEvent),
}

/// What a call of [`LiveEngine::step`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// Work was done (a pass, a re-shade); more is to come.
    Stepped,
    /// A pass was cancelled; the picture is as it was.
    Cancelled,
    /// Nothing to do until the next command (the sample target is reached).
    Idle,
}

/// The live-rendering engine: owns the one or two views, takes [`Command`]s and
/// decides what to re-shade, re-trace or rebuild through the state machine of
/// [`super::plan`]; [`Self::step`] renders and publishes. Driven directly (as
/// its tests do) or on a render thread by [`super::EngineThread`].
pub struct LiveEngine<B: RenderBackend = CpuBackend> {
    pub(super) backend: B,
    pub(super) inputs: Inputs,
    pub(super) world: World,
    pub(super) views: ViewSet<B::View>,
    pub(super) state: State,
    /// The actions the commands taken since the last step asked for.
    pub(super) pending: Actions,
    /// Actions left undone because the design could not be modelled: done with
    /// the next command's.
    pub(super) deferred: Actions,
    pub(super) counters: EngineCounters,
    /// Why the last paint edit could not be shown re-shaded.
    pub(super) last_refusal: Option<ReshadeError>,
    /// Called first on every thread the engine starts.
    pub(super) on_thread_start: ThreadHook,
}

impl<B: RenderBackend> LiveEngine<B> {
    /// An engine rendering `design` on the built-in car in the studio, one view
    /// in the paint model, at [`INITIAL_SIZE`]; its first step is a coarse pass.
    /// `on_thread_start` runs first on every thread the engine starts.
    pub fn new(
        backend: B,
        design: PaintDesign,
        on_thread_start: ThreadHook,
    ) -> Result<Self, EngineError> {
        let mut counters = EngineCounters::default();
        let grid = WavelengthGrid::visible(DEFAULT_WAVELENGTHS).map_err(|_| EngineError::NoGrid)?;
        let mut world = World::new(grid, &mut counters)?;
        let inputs = Inputs {
            camera: world.scene.default_camera(INITIAL_SIZE.0, INITIAL_SIZE.1),
            view: Some(ViewChoice::default()),
            design,
            views: Views::default(),
            lighting: Lighting::Studio,
            paint_override: None,
            quality: QualityKnobs::default(),
            display: DisplayChoice::default(),
            size: INITIAL_SIZE,
        };
        let scene = world.scene.clone();
        let paint = inputs.paint_materials(scene.paint_materials());
        let model = world
            .model_for(&inputs.design, true, &mut counters)
            .ok_or(EngineError::DesignInvalid)?;
        let shading = Arc::new(Shading::new(
            model,
            inputs.views.first,
            scene.materials(),
            &paint,
        ));
        counters.shading_builds += 1;
        let first = backend.view(ViewSetup {
            scene: world.scene.clone(),
            environment: world.environment.clone(),
            shading,
            camera: inputs.camera.clone(),
        })?;
        counters.render_builds += 1;
        Ok(Self {
            backend,
            inputs,
            world,
            views: ViewSet::new(first, RESHADE_SAMPLES),
            state: State::START,
            pending: Actions::NONE,
            deferred: Actions::NONE,
            counters,
            last_refusal: None,
            on_thread_start,
        })
    }

    /// Takes `command`: what it changes goes through [`transition`], and the
    /// actions it asks for wait for the next [`Self::step`]. Scenes and lighting
    /// are loaded here; a load that fails is reported and changes nothing.
    pub fn apply(&mut self, command: Command, out: &mut dyn FnMut(Output)) {
        if command.is_null_step() {
            return;
        }
        let change = match command {
            Command::Scene(source) => self.take_scene(&source, out),
            Command::Lighting(lighting) => self.take_lighting(lighting, out),
            Command::OpenMap(path) => self.take_map(path, out),
            Command::Quality(knobs) => self.take_quality(knobs, out),
            Command::View(choice) => self.take_view(&choice, out),
            Command::TogglePaintAt(x, y) => self.take_paint_pick(x, y, out),
            other => self.inputs.take(other),
        };
        if change == Change::Size {
            self.refit_view();
        }
        let (state, actions) = transition(self.state, change);
        let deferred = std::mem::take(&mut self.deferred);
        self.pending = self.pending.merge(deferred).merge(actions);
        self.state = settle(state, self.pending);
    }

    fn take_scene(&mut self, source: &SceneSource, out: &mut dyn FnMut(Output)) -> Change {
        let (scene, info) = match load_scene(source, &mut self.counters) {
            Ok(loaded) => loaded,
            Err(e) => return failed(e, out),
        };
        let (width, height) = self.inputs.size;
        self.inputs.camera = scene.default_camera(width, height);
        self.inputs.view = Some(ViewChoice::default());
        self.inputs.paint_override = None;
        self.world.scene = scene;
        self.world.info = info.clone();
        out(Output::Event(EngineEvent::SceneLoaded(info)));
        Change::Scene
    }

    fn take_paint_pick(&mut self, x: f32, y: f32, out: &mut dyn FnMut(Output)) -> Change {
        let camera = &self.inputs.camera;
        let (px, py) = (x * camera.width() as f32, y * camera.height() as f32);
        let Some(hit) = pick(&self.world.scene, camera, px, py) else {
            return Change::Nothing;
        };
        let painted = self
            .inputs
            .paint_materials(self.world.scene.paint_materials());
        let chosen = toggled(&painted, hit.material);
        out(Output::Event(EngineEvent::PaintMaterials(chosen.clone())));
        self.inputs.take(Command::PaintMaterials(Some(chosen)))
    }

    fn take_view(&mut self, choice: &ViewChoice, out: &mut dyn FnMut(Output)) -> Change {
        let (width, height) = self.inputs.size;
        match self.world.scene.framing().camera(choice, width, height) {
            Ok(camera) => {
                self.inputs.camera = camera;
                self.inputs.view = Some(*choice);
                Change::Camera
            }
            Err(e) => failed(e.into(), out),
        }
    }

    /// Fits the view the camera is at (if not moved by hand) to a new image size:
    /// a view framed for one aspect crops the car in a narrower one.
    fn refit_view(&mut self) {
        let (width, height) = self.inputs.size;
        if let Some(choice) = self.inputs.view
            && let Ok(camera) = self.world.scene.framing().camera(&choice, width, height)
        {
            self.inputs.camera = camera;
        }
    }

    fn take_lighting(&mut self, lighting: Lighting, out: &mut dyn FnMut(Output)) -> Change {
        if lighting == self.inputs.lighting {
            return Change::Nothing;
        }
        let built = self.world.lighting(&lighting, &mut self.counters);
        self.install_lighting(built, lighting, out)
    }

    fn take_map(&mut self, path: PathBuf, out: &mut dyn FnMut(Output)) -> Change {
        // Read again even if read before: the file may have changed.
        let read = self.world.read_map(&path, &mut self.counters);
        let change = self.install_lighting(read, Lighting::Map(path.clone()), out);
        if change == Change::Lighting {
            out(Output::Event(EngineEvent::MapLoaded(path)));
        }
        change
    }

    /// Makes `built` the environment for `lighting`, or reports why it could
    /// not be built and changes nothing: what a new lighting and a map read share.
    fn install_lighting(
        &mut self,
        built: Result<Arc<Environment>, EngineError>,
        lighting: Lighting,
        out: &mut dyn FnMut(Output),
    ) -> Change {
        let environment = match built {
            Ok(environment) => environment,
            Err(e) => return failed(e, out),
        };
        self.world.environment = environment;
        self.inputs.lighting = lighting;
        Change::Lighting
    }

    fn take_quality(&mut self, knobs: QualityKnobs, out: &mut dyn FnMut(Output)) -> Change {
        if knobs == self.inputs.quality {
            return Change::Nothing;
        }
        self.inputs.quality = knobs;
        // A count no grid can have keeps the grid (the presets are validated).
        let grid = WavelengthGrid::visible(knobs.wavelengths).ok();
        let Some(grid) = grid.filter(|g| *g != self.world.grid) else {
            return Change::Target;
        };
        match self
            .world
            .regrid(grid, &self.inputs.lighting, &mut self.counters)
        {
            Ok(()) => Change::Grid,
            Err(e) => {
                out(Output::Event(EngineEvent::Failed(e)));
                Change::Target
            }
        }
    }

    /// The state machine's state.
    pub fn state(&self) -> State {
        self.state
    }

    /// Whether a comparison rendered apart spends more of both views' samples
    /// where its ΔE00 map is undecided ([`super::guide`]; on from the start).
    /// Off, every pass is even: what measuring the guidance compares with. Takes
    /// effect at the next pass; the samples are kept.
    pub fn set_map_guidance(&mut self, on: bool) {
        self.views.map_guidance = on;
    }

    /// How much sharper, relative, the second design's lobe may be and still be
    /// shared ([`super::SHARED_LOBE_NARROWING`] from the start, which is what
    /// the app runs); for measuring where that limit belongs. Takes effect when
    /// the second view's shading is next built.
    pub fn set_shared_lobe_narrowing(&mut self, narrowing: f32) {
        self.views.lobe_narrowing = narrowing;
    }

    /// What the engine has built and rendered so far.
    pub fn counters(&self) -> EngineCounters {
        self.counters
    }

    /// Whether the engine waits for a command (nothing to render).
    pub fn is_idle(&self) -> bool {
        self.state.phase == super::plan::Phase::Converged && !self.pending.any()
    }

    /// The scene being rendered.
    pub fn scene_info(&self) -> &SceneInfo {
        &self.world.info
    }

    /// The wavelength grid of every path.
    pub fn grid(&self) -> WavelengthGrid {
        self.world.grid
    }

    /// Why the last paint edit was traced fresh instead of re-shaded, if it was.
    pub fn last_edit_refusal(&self) -> Option<&ReshadeError> {
        self.last_refusal.as_ref()
    }

    /// The first view's render.
    pub fn first(&self) -> &B::View {
        &self.views.first
    }

    /// The second view's image, for an export (a re-shaded one is made now).
    pub fn second_image(&self) -> SecondImage<'_> {
        self.views.second_image()
    }

    /// The first view's picture as its pane shows it (mean XYZ, row major): in
    /// a shared comparison its film combined with the second view's, else its
    /// film's means.
    pub fn first_image(&self) -> Result<Vec<[f32; 3]>, ReshadeError> {
        match self.views.shared_panes() {
            Some(panes) => panes.map(|[(image, _), _]| image.xyz),
            None => {
                let film = self.views.first.film();
                Ok((0..film.height())
                    .flat_map(|y| (0..film.width()).map(move |x| (x, y)))
                    .map(|(x, y)| {
                        let m = film.mean_xyz(x, y);
                        [m.x as f32, m.y as f32, m.z as f32]
                    })
                    .collect())
            }
        }
    }

    /// Per scene material, the area the current view sees of it, m²
    /// ([`visible_areas`] on a grid of [`VISIBLE_AREA_COLUMNS`] across, in the
    /// image's aspect): a few thousand rays, milliseconds, for the paint list.
    pub fn visible_areas(&self) -> Vec<f32> {
        let camera = &self.inputs.camera;
        let rows = (VISIBLE_AREA_COLUMNS as f32 * camera.height() as f32 / camera.width() as f32)
            .round()
            .max(1.0) as u32;
        visible_areas(&self.world.scene, camera, VISIBLE_AREA_COLUMNS, rows)
    }

    /// The display settings of the last published images: what they were shown in.
    pub fn display(&self) -> DisplaySettings {
        self.views.display
    }

    /// Samples per pixel the first view records for re-shading.
    pub fn recording_target(&self) -> u32 {
        self.views.cache_samples
    }

    /// The first view's design.
    pub fn design(&self) -> &PaintDesign {
        &self.inputs.design
    }

    /// The lighting in use.
    pub fn lighting(&self) -> &Lighting {
        &self.inputs.lighting
    }

    /// The first view's samples per pixel.
    pub fn samples_per_pixel(&self) -> u32 {
        self.views.first.samples_per_pixel()
    }
}

/// Columns of the grid of rays [`LiveEngine::visible_areas`] casts: fine enough
/// that a door handle or a mirror is hit, coarse enough to take milliseconds.
pub const VISIBLE_AREA_COLUMNS: u32 = 96;

/// A command that could not be carried out: reported, and nothing changed.
fn failed(error: EngineError, out: &mut dyn FnMut(Output)) -> Change {
    out(Output::Event(EngineEvent::Failed(error)));
    Change::Nothing
}
