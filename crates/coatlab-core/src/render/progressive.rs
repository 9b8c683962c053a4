//! Progressive rendering: passes of a few samples per pixel, accumulated into one
//! [`Film`], restarted whenever anything that changes the picture changes.
//!
//! A pass splits the image into square tiles and renders them on rayon's thread
//! pool; each tile accumulates into its own small film, and the tiles are merged
//! back in a fixed order. Every pixel sample draws its random numbers from a
//! [`PixelSampler`] keyed by (seed, pixel, sample index), so a pixel receives the
//! same samples in the same order whatever the thread count: a render is
//! bit-for-bit the same for a seed (tested).
//!
//! With [`RenderSettings::adaptive`] set, passes after the first few uniform ones
//! spread their samples over the pixels by each pixel's estimated noise
//! ([`crate::render::adaptive`]): a pass of s samples per pixel then takes s ×
//! the pixel count samples in all, some pixels more, some fewer, and
//! [`ProgressiveRender::samples_per_pixel`] is the mean over the image. A pixel's
//! k-th sample is still keyed by (seed, pixel, k), and the allocation is computed
//! in a fixed order from the film, so adaptive renders are deterministic for a
//! seed too.
//!
//! What lives how long, so a change recomputes only what it touches (the live
//! engine, [`crate::engine`], decides which of these a change of the preview
//! rebuilds; the batch renderer builds them once):
//!
//! | value | rebuilt when | cost (default car) |
//! |---|---|---|
//! | [`RenderScene`] (mesh, BVH, materials) | the scene file changes | ~0.1 s |
//! | [`Environment`] | the lighting setup or grid changes | ms |
//! | [`Shading`] | the design, the model or the scene's materials change | ≤ 1 ms (tables come from [`crate::paint::model::PaintModel`]) |
//! | [`Camera`], film | the view or the size changes | – |
//! | edit base (film + [`PathCache`]) | the scene, lighting, view, size or settings change | – |
//!
//! # Editing the paint: re-shade, then refine
//!
//! [`ProgressiveRender::edit_shading`] swaps the shading without restarting from
//! nothing: the last image whose path cache is complete (its film and cache, the
//! *edit base*) is kept for the whole editing session, and every edit re-shades it
//! ([`crate::render::reshade`]) into an unbiased estimate R of the new design at full
//! resolution, with its per-pixel variance. Fresh passes of the new design then
//! accumulate in their own film F as usual. What is shown
//! ([`ProgressiveRender::edit_estimate`]) is (1 − w)·R + w·F with one weight for the
//! whole image, w = V_R / (V_R + V_F), V the mean over the pixels of each
//! estimate's variance of Y: both terms are unbiased and w is (all but) independent
//! of any pixel's value, so the blend is unbiased; w grows towards 1 as F
//! accumulates, and once w > [`FRESH_ONLY_WEIGHT`] R is dropped and the film alone
//! is shown: the picture converges to the fresh render of the new design. Once the
//! fresh film's own cache is complete and it holds at least the base's samples, the
//! next edit makes it the base.
//!
//! Memory: at most two path caches live at once (the base's and the one being
//! recorded), together bounded by [`ProgressiveRender::set_path_cache_budget`]
//! ([`DEFAULT_PATH_CACHE_BUDGET_BYTES`]); a pass that would pass the budget is not
//! recorded (its recordings are rolled back) and the cache stays at the samples
//! per pixel it has.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use rayon::prelude::*;
use thiserror::Error;

use crate::accel::AccelError;
use crate::paint::model::PaintModel;
use crate::render::adaptive::{AdaptiveSampling, RECOMPUTE_GROWTH, allocate};
use crate::render::camera::Camera;
use crate::render::environment::Environment;
use crate::render::film::{DisplaySettings, Film, NoiseEstimate};
use crate::render::geometry::RenderGeometry;
use crate::render::integrator::{
    IntegratorSettings, NoRecord, PathBuffers, PathTracer, WAVE_PATHS,
};
use crate::render::material::{Shading, ShadingModel};
use crate::render::reshade::{
    BaseImage, PathCache, PathLog, ReshadeError, Reshaded, TileCache, TileRecorder,
    paint_is_mirror, reshade, reshade_prepared,
};
use crate::render::sampler::PixelSampler;
use crate::render::view::{NamedView, SceneFraming};
use crate::scene::{Scene, SceneMaterial};

/// Side of the square tiles a pass is split into, pixels: small enough that two
/// cores stay busy to the end of a pass on a preview-sized image, large enough that
/// a tile's film and tracer setup are amortised.
pub const DEFAULT_TILE_SIZE: u32 = 32;

/// Heap memory the path caches of a render may hold together, bytes: the base's
/// and the one being recorded (measured: 89–129 MB for 960×540, 4 samples per
/// pixel, 32 wavelengths, the default car; see `docs/benchmarks.md`).
pub const DEFAULT_PATH_CACHE_BUDGET_BYTES: usize = 320 << 20;

/// The fresh film's weight in the blend above which a re-shaded estimate is
/// dropped (see the module documentation).
pub const FRESH_ONLY_WEIGHT: f64 = 0.98;

/// Recorded samples per pixel an edit's first image is re-shaded from. One of the
/// K recorded samples is already an unbiased estimate of the edit's difference and
/// costs about 1/K of the replay (docs/benchmarks.md, "Re-shading after a paint
/// edit"): while a slider moves, every step gets an image this fast, and the full
/// re-shade follows in [`ProgressiveRender::refine_edit`] once the slider rests.
pub const EDIT_FIRST_IMAGE_SAMPLES: u32 = 1;

/// How [`ProgressiveRender::edit_shading`] shows the new shading.
#[derive(Debug, Clone, PartialEq)]
pub enum EditOutcome {
    /// Re-shaded from the edit base: [`ProgressiveRender::edit_estimate`] has a
    /// full-resolution image at once.
    Reshaded,
    /// Traced fresh, for the reason given.
    Fresh(ReshadeError),
}

/// The film and path cache an editing session re-shades.
#[derive(Debug)]
struct EditBase {
    film: Film,
    cache: PathCache,
    /// The film's means and variances, prepared once for every edit's re-shade.
    image: BaseImage,
}

/// Why a render could not be set up.
#[derive(Debug, Error)]
pub enum RenderError {
    /// The scene has no triangles.
    #[error("the scene has no geometry to render")]
    EmptyScene,
    /// The acceleration structure could not be built.
    #[error(transparent)]
    Accel(#[from] AccelError),
    /// The lighting and the shading are on different wavelength grids.
    #[error(
        "the lighting has {environment} wavelengths and the paint {shading}: both must use one grid"
    )]
    GridMismatch {
        /// Wavelengths of the environment.
        environment: usize,
        /// Wavelengths of the shading.
        shading: usize,
    },
    /// A range of sample indices asked of an adaptive render.
    #[error(
        "adaptive sampling spreads a pass's samples by the noise of every sample before it, \
         so it cannot render a range of sample indices on its own: render the range uniformly"
    )]
    AdaptiveRange,
    /// A zero-sized image.
    #[error("the image size {width}×{height} has no pixels")]
    EmptyImage {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
    },
}

/// A scene ready to trace: its geometry in a BVH (with the floor plane y = 0; the
/// lighting decides whether it is used), and its materials.
#[derive(Debug, Clone)]
pub struct RenderScene {
    geometry: RenderGeometry,
    materials: Vec<SceneMaterial>,
    paint_materials: Vec<u32>,
    framing: SceneFraming,
}

impl RenderScene {
    /// Builds the BVH of `scene`.
    pub fn new(scene: Scene) -> Result<Self, RenderError> {
        if scene.mesh.positions.is_empty() || scene.mesh.triangle_count() == 0 {
            return Err(RenderError::EmptyScene);
        }
        let framing = SceneFraming::new(&scene);
        let geometry = RenderGeometry::new(scene.mesh, true)?;
        Ok(Self {
            geometry,
            materials: scene.materials,
            paint_materials: scene.paint_materials,
            framing,
        })
    }

    /// The geometry.
    pub fn geometry(&self) -> &RenderGeometry {
        &self.geometry
    }

    /// The scene's materials.
    pub fn materials(&self) -> &[SceneMaterial] {
        &self.materials
    }

    /// Indices of the materials that carry the designed paint.
    pub fn paint_materials(&self) -> &[u32] {
        &self.paint_materials
    }

    /// Axis-aligned bounds of the mesh, metres.
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        // `new` refuses a mesh without vertices, so the geometry has bounds.
        self.geometry.bounds().unwrap_or_default()
    }

    /// The shading of this scene's materials, its painted ones carrying `paint`
    /// under `model`.
    pub fn shading(&self, paint: &PaintModel, model: ShadingModel) -> Shading {
        Shading::new(paint, model, &self.materials, &self.paint_materials)
    }

    /// What the views are fitted to: the car (not the whole scene) and the file's
    /// cameras.
    pub fn framing(&self) -> &SceneFraming {
        &self.framing
    }

    /// The default view of the car at `width` × `height`: the front three-quarter
    /// view of [`crate::render::view`].
    pub fn default_camera(&self, width: u32, height: u32) -> Camera {
        self.framing.named(NamedView::default(), width, height)
    }
}

/// The knobs of a progressive render that are not the scene, lighting, shading or
/// view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// Seed of every random number: the same seed gives the same image.
    pub seed: u64,
    /// Path length and roulette.
    pub integrator: IntegratorSettings,
    /// Tile side, pixels.
    pub tile_size: u32,
    /// Adaptive sampling (see [`crate::render::adaptive`]); `None`: every pass
    /// gives every pixel the same samples (the default).
    pub adaptive: Option<AdaptiveSampling>,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            seed: 0,
            integrator: IntegratorSettings::default(),
            tile_size: DEFAULT_TILE_SIZE,
            adaptive: None,
        }
    }
}

impl RenderSettings {
    /// The default settings with another seed.
    pub fn seeded(seed: u64) -> Self {
        Self {
            seed,
            ..Self::default()
        }
    }
}

/// What one pass (or a whole render) did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PassStats {
    /// Pixel samples taken (paths started).
    pub samples: u64,
    /// Rays traced: camera, bounce and shadow rays.
    pub rays: u64,
    /// Wall time, seconds.
    pub seconds: f64,
}

impl PassStats {
    /// Pixel samples per second.
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.seconds.max(1e-9)
    }

    /// Rays per second.
    pub fn rays_per_second(&self) -> f64 {
        self.rays as f64 / self.seconds.max(1e-9)
    }

    fn add(&mut self, other: PassStats) {
        self.samples += other.samples;
        self.rays += other.rays;
        self.seconds += other.seconds;
    }
}

/// A progressive render: see the module documentation.
#[derive(Debug)]
pub struct ProgressiveRender {
    scene: Arc<RenderScene>,
    environment: Arc<Environment>,
    shading: Arc<Shading>,
    camera: Camera,
    settings: RenderSettings,
    film: Film,
    tiles: Vec<Film>,
    /// Samples per pixel so far (the next pass's first sample index).
    samples_per_pixel: u32,
    totals: PassStats,
    /// Paths of `cache_window` samples per pixel from sample `cache_first` on,
    /// for re-shading.
    cache: PathCache,
    /// Samples per pixel a recording takes, as asked for.
    cache_target: u32,
    /// Samples per pixel the current recording takes: `cache_target`, or fewer
    /// where the budget stopped the recording before it and it was started again
    /// ([`Self::record_next_samples`]).
    cache_window: u32,
    /// The first sample index the current recording holds (0 but after
    /// [`Self::record_next_samples`]).
    cache_first: u32,
    /// The recording stopped at the budget: the cache is complete at what it has.
    cache_capped: bool,
    cache_budget_bytes: usize,
    base: Option<EditBase>,
    /// The re-shaded image of the current shading, while it still helps.
    reshaded: Option<Reshaded>,
    /// Recorded samples per pixel `reshaded` was made from.
    reshaded_samples: u32,
    /// A cleared film of the current size and grid, made during a pass once the
    /// cache is complete, so that an edit does not allocate (and fault in) the new
    /// film of its editing session on the edit's own time.
    spare_film: Option<Film>,
    /// An edit base replaced by a newer one: freed at the next pass rather than
    /// on the edit's time (its cache is a hundred MB of small vectors).
    retired_base: Option<EditBase>,
    /// The film's prepared means and variances after the last pass (and its
    /// samples per pixel), made while the cache is complete: the next editing
    /// session's base image, ready before the edit (≈ 3 % of a 960×540 pass).
    prepared_base: Option<(u32, BaseImage)>,
    /// Adaptive sampling's per-pixel weights (mean 1, row major) and the samples
    /// per pixel they were computed at; `None` until the first adaptive pass.
    adaptive_weights: Option<(u32, Vec<f32>)>,
    /// Adaptive passes since the last restart (each draws its own rounding offset).
    adaptive_passes: u32,
    /// Per-pixel weights given from outside ([`Self::set_pass_weights`]): they
    /// spread each pass's samples in place of adaptive sampling's own until the
    /// next restart.
    given_weights: Option<Vec<f32>>,
}

impl ProgressiveRender {
    /// A render of `scene` lit by `environment`, shaded by `shading`, seen through
    /// `camera` (whose resolution is the image's).
    pub fn new(
        scene: Arc<RenderScene>,
        environment: Arc<Environment>,
        shading: Arc<Shading>,
        camera: Camera,
        settings: RenderSettings,
    ) -> Result<Self, RenderError> {
        check_grids(&environment, &shading)?;
        let film = new_film(&camera, &environment)?;
        let tiles = film.tiles(settings.tile_size);
        let cache = cache_for(&tiles);
        Ok(Self {
            scene,
            environment,
            shading,
            camera,
            settings,
            film,
            tiles,
            samples_per_pixel: 0,
            totals: PassStats::default(),
            cache,
            cache_target: 0,
            cache_window: 0,
            cache_first: 0,
            cache_capped: false,
            cache_budget_bytes: DEFAULT_PATH_CACHE_BUDGET_BYTES,
            base: None,
            reshaded: None,
            reshaded_samples: 0,
            spare_film: None,
            retired_base: None,
            prepared_base: None,
            adaptive_weights: None,
            adaptive_passes: 0,
            given_weights: None,
        })
    }

    /// Bounds the heap memory of the path caches (the edit base's and the one
    /// being recorded, together) to `bytes`; see the module documentation.
    /// Restarts.
    pub fn set_path_cache_budget(&mut self, bytes: usize) {
        self.cache_budget_bytes = bytes;
        self.restart();
    }

    /// Samples per pixel the cache is complete at: the number asked for, or fewer
    /// where the budget stopped the recording.
    pub fn path_cache_target(&self) -> u32 {
        if self.cache_capped {
            self.cache.samples_per_pixel()
        } else {
            self.cache_window
        }
    }

    /// Whether the path cache holds every sample its recording takes (it can be
    /// re-shaded, and [`Self::record_next_samples`] can start the next one).
    pub fn path_cache_complete(&self) -> bool {
        self.cache_complete()
    }

    /// Drops the complete recording and records the next samples per pixel
    /// instead, as many as it held, from the next pass on; the film keeps every
    /// sample. What a comparison does with its shared paths: the difference it
    /// re-shades from each recording is an unbiased estimate on fresh samples, so
    /// the estimates of successive recordings average down at the memory of one
    /// ([`crate::render::reshade::ShadingDifference::merged`]). Under weights
    /// given ([`Self::set_pass_weights`]) a recording holds every sample of its
    /// passes, as many per pixel as the weights gave it. False, and nothing
    /// changes, while the recording is incomplete, and under adaptive sampling,
    /// whose passes are uniform while a recording takes samples, so that
    /// recording on would keep every pass uniform. The vectors keep their
    /// capacity, which the budget counts.
    pub fn record_next_samples(&mut self) -> bool {
        if !self.cache_complete() || self.settings.adaptive.is_some() {
            return false;
        }
        self.cache_window = self.path_cache_target();
        self.cache_capped = false;
        self.cache_first = self.samples_per_pixel;
        self.cache.tiles.iter_mut().for_each(TileCache::clear);
        self.cache.samples_per_pixel = 0;
        self.prepared_base = None;
        true
    }

    /// Heap memory of every path cache held (the edit base's and the current),
    /// bytes; never above the budget.
    pub fn path_cache_memory_bytes(&self) -> usize {
        self.cache.memory_bytes() + self.base.as_ref().map_or(0, |b| b.cache.memory_bytes())
    }

    /// Whether the current cache is complete (re-shadeable).
    fn cache_complete(&self) -> bool {
        let target = self.path_cache_target();
        target > 0 && self.cache.samples_per_pixel() >= target
    }

    /// The new `shading` for a paint edit (see the module documentation): shown at
    /// once re-shaded from the edit base where that is possible, while fresh passes
    /// of it accumulate. Without a complete cache, or across a change to or from
    /// an ideal mirror, it restarts like [`Self::set_shading`] (the outcome says
    /// why). Keeps the scene, lighting, camera and their derived data.
    pub fn edit_shading(&mut self, shading: Arc<Shading>) -> Result<EditOutcome, RenderError> {
        check_grids(&self.environment, &shading)?;
        let base_samples = self
            .base
            .as_ref()
            .map(|b| b.film.samples_per_pixel())
            .unwrap_or(0);
        if self.cache_complete() && u64::from(self.samples_per_pixel) >= base_samples {
            // The current image becomes the base: moved, not copied.
            let film = match self.spare_film.take() {
                Some(spare)
                    if (spare.width(), spare.height())
                        == (self.camera.width(), self.camera.height())
                        && spare.channels() == self.environment.channels() =>
                {
                    spare
                }
                _ => new_film(&self.camera, &self.environment)?,
            };
            let cache = cache_for(&self.tiles);
            let film = std::mem::replace(&mut self.film, film);
            let image = match self.prepared_base.take() {
                Some((spp, image)) if spp == self.samples_per_pixel => image,
                _ => BaseImage::of(&film),
            };
            self.retired_base = self.base.replace(EditBase {
                image,
                film,
                cache: std::mem::replace(&mut self.cache, cache),
            });
        }
        let outcome = match &self.base {
            Some(base) => match reshade_prepared(
                &base.image,
                &base.film,
                &base.cache,
                &self.environment,
                &shading,
                self.scene.geometry().has_floor(),
                EDIT_FIRST_IMAGE_SAMPLES,
            ) {
                Ok(image) => {
                    self.reshaded = Some(image);
                    self.reshaded_samples =
                        EDIT_FIRST_IMAGE_SAMPLES.min(base.cache.samples_per_pixel);
                    EditOutcome::Reshaded
                }
                Err(e) => {
                    self.reshaded = None;
                    EditOutcome::Fresh(e)
                }
            },
            None => {
                self.reshaded = None;
                EditOutcome::Fresh(ReshadeError::NotReady {
                    recorded: self.cache.samples_per_pixel(),
                    wanted: self.path_cache_target(),
                })
            }
        };
        self.shading = shading;
        self.restart_samples();
        Ok(outcome)
    }

    /// Re-shades the last edit from all recorded samples where its image came from
    /// fewer ([`EDIT_FIRST_IMAGE_SAMPLES`]): the step between an edit's first image
    /// and fresh passes, for the render loop to take when no further edit is
    /// waiting. Returns whether it replaced the image (false: nothing to refine, or
    /// the re-shade is no longer possible, in which case the image stays).
    pub fn refine_edit(&mut self) -> bool {
        let (Some(base), Some(_)) = (&self.base, &self.reshaded) else {
            return false;
        };
        if self.reshaded_samples >= base.cache.samples_per_pixel {
            return false;
        }
        match reshade_prepared(
            &base.image,
            &base.film,
            &base.cache,
            &self.environment,
            &self.shading,
            self.scene.geometry().has_floor(),
            base.cache.samples_per_pixel,
        ) {
            Ok(image) => {
                self.reshaded_samples = base.cache.samples_per_pixel;
                self.reshaded = Some(image);
                true
            }
            Err(_) => false,
        }
    }

    /// Whether the picture is still partly the re-shaded estimate of an edit.
    pub fn is_reshaded(&self) -> bool {
        self.reshaded.is_some()
    }

    /// Samples per pixel of the edit base (0 without one).
    pub fn edit_base_samples_per_pixel(&self) -> u64 {
        self.base
            .as_ref()
            .map(|b| b.film.samples_per_pixel())
            .unwrap_or(0)
    }

    /// The best estimate of the current shading's image while an edit's re-shaded
    /// image still helps: the blend of the module documentation, with the fresh
    /// film's weight. `None` once the film alone is better (show [`Self::film`]).
    pub fn edit_estimate(&self) -> Option<(Reshaded, f64)> {
        let reshaded = self.reshaded.as_ref()?;
        let w = self.fresh_weight(reshaded);
        let film = &self.film;
        let width = film.width();
        let mut xyz = reshaded.xyz.clone();
        let mut variance_xyz = reshaded.variance_xyz.clone();
        if w > 0.0 {
            let keep = 1.0 - w;
            for (i, (v, var)) in xyz.iter_mut().zip(variance_xyz.iter_mut()).enumerate() {
                let (x, y) = (i as u32 % width, i as u32 / width);
                let m = film.mean_xyz(x, y);
                let f = [m.x, m.y, m.z];
                let vf = film.variance_of_mean_xyz(x, y);
                for c in 0..3 {
                    v[c] = (keep * f64::from(v[c]) + w * f[c]) as f32;
                    var[c] = (keep * keep * f64::from(var[c]) + w * w * vf[c]) as f32;
                }
            }
        }
        Some((
            Reshaded {
                width: reshaded.width,
                height: reshaded.height,
                xyz,
                variance_xyz,
            },
            w,
        ))
    }

    /// The fresh film's weight against `reshaded` (0 below 2 samples per pixel).
    fn fresh_weight(&self, reshaded: &Reshaded) -> f64 {
        if self.samples_per_pixel < 2 {
            return 0.0;
        }
        let film = &self.film;
        let width = film.width();
        let (mut v_r, mut v_f) = (0.0f64, 0.0f64);
        for (i, vr) in reshaded.variance_xyz.iter().enumerate() {
            let vf = film.variance_of_mean_xyz(i as u32 % width, i as u32 / width)[1];
            if vf.is_finite() {
                v_r += f64::from(vr[1]);
                v_f += vf;
            }
        }
        if v_r + v_f <= 0.0 {
            return 1.0;
        }
        v_r / (v_r + v_f)
    }

    /// Records the paths of the first `samples` samples of every pixel that touch
    /// the paint, for [`Self::reshade`] (0: record nothing, the default). Restarts.
    /// Costs memory ([`PathCache::memory_bytes`]) and a little time while recording
    /// (recorded samples are traced in waves like the rest, their paths logged).
    pub fn set_path_cache_samples(&mut self, samples: u32) {
        self.cache_target = samples;
        self.restart();
    }

    /// The recorded paths (complete once [`Self::samples_per_pixel`] reaches the
    /// number asked for).
    pub fn path_cache(&self) -> &PathCache {
        &self.cache
    }

    /// This render's image as it would look with `shading` instead of its own,
    /// from the recorded paths, without tracing (see [`crate::render::reshade`]).
    pub fn reshade(&self, shading: &Shading) -> Result<Reshaded, ReshadeError> {
        if !self.cache_complete() {
            return Err(ReshadeError::NotReady {
                recorded: self.cache.samples_per_pixel(),
                wanted: self.path_cache_target(),
            });
        }
        self.reshade_cached(shading)
    }

    /// The re-shade of the film from the cache, whatever the cache holds.
    fn reshade_cached(&self, shading: &Shading) -> Result<Reshaded, ReshadeError> {
        reshade(
            &self.film,
            &self.cache,
            &self.environment,
            shading,
            self.scene.geometry().has_floor(),
        )
    }

    /// [`Self::reshade`] that also works while the cache is still recording, as long
    /// as it holds every sample the film does: then the control variate's base and
    /// its recorded paths are the same samples, and the result is simply those
    /// paths evaluated with `shading` (exact re-weighting). Once the cache stops
    /// growing (its target or the memory budget reached) it is [`Self::reshade`].
    /// What the comparison view's second pane is made of (`docs/rendering.md`,
    /// "Comparison panes from one set of paths").
    pub fn reshade_recorded(&self, shading: &Shading) -> Result<Reshaded, ReshadeError> {
        let recorded = self.cache.samples_per_pixel();
        if self.cache_complete() || (recorded > 0 && recorded == self.samples_per_pixel) {
            self.reshade_cached(shading)
        } else {
            Err(ReshadeError::NotReady {
                recorded,
                wanted: self.path_cache_target(),
            })
        }
    }

    /// Adds `samples` samples to every pixel (with adaptive sampling, `samples` ×
    /// the pixel count samples spread by the pixels' noise). Returns what the pass
    /// did.
    pub fn render_pass(&mut self, samples: u32) -> PassStats {
        let never = AtomicBool::new(false);
        self.render_pass_cancellable(samples, &never)
            .unwrap_or_default()
    }

    /// Renders passes of at most `pass` samples per pixel until the film holds
    /// `spp`; the same passes, so the same image, wherever it is called.
    pub fn render_to(&mut self, spp: u32, pass: u32) {
        while self.samples_per_pixel() < spp {
            self.render_pass(pass.min(spp - self.samples_per_pixel()));
        }
    }

    /// [`Self::render_pass`] that gives up as soon as `cancel` is set (checked
    /// between tiles), returning `None` and leaving the film as it was: the caller
    /// is about to change something and restart.
    pub fn render_pass_cancellable(
        &mut self,
        samples: u32,
        cancel: &AtomicBool,
    ) -> Option<PassStats> {
        let start = Instant::now();
        let first_sample = self.samples_per_pixel;
        // Samples before `record_below` from `cache_first` on are recorded (a pass
        // never starts before `cache_first`: a recording starts at the next pass).
        let record_below = self.cache_first + self.path_cache_target();
        let recording = first_sample < record_below;
        // The noise map and the allocation count as the pass's time.
        let counts = self.adaptive_counts(samples, record_below);
        let tracer = PathTracer::new(
            self.scene.geometry(),
            &self.environment,
            &self.shading,
            self.settings.integrator,
        );
        let camera = &self.camera;
        let seed = self.settings.seed;
        let width = self.film.width();
        let len = self.shading.len();
        let lengths: Vec<[usize; 5]> = self.cache.tiles.iter().map(TileCache::lengths).collect();
        let plan = match &counts {
            Some(counts) => Plan::Adaptive {
                film: &self.film,
                counts,
            },
            None => Plan::Uniform {
                first: first_sample,
                samples,
            },
        };
        if recording {
            self.cache.paint_is_mirror = paint_is_mirror(&self.shading);
            self.cache.lobe_exponent = self.shading.design().lobe_exponent();
            // What the budget leaves beside the caches held, shared by the tiles.
            let room = self
                .cache_budget_bytes
                .saturating_sub(self.path_cache_memory_bytes());
            let pool = Arc::new(std::sync::atomic::AtomicUsize::new(room));
            for cache in &mut self.cache.tiles {
                cache.set_pool(pool.clone());
                cache.begin_pass();
            }
        }
        let rays: u64 = self
            .tiles
            .par_iter_mut()
            .zip(self.cache.tiles.par_iter_mut())
            .map(|(tile, cache)| {
                if cancel.load(Ordering::Relaxed) {
                    return 0;
                }
                tile.clear();
                let job = TileJob {
                    tracer: &tracer,
                    camera,
                    seed,
                    image_width: width,
                    plan,
                    len,
                };
                if recording {
                    // A pass spread by weights is recorded whole: its samples of
                    // a pixel start at the pixel's own count, not at one index.
                    let below = if counts.is_some() {
                        u32::MAX
                    } else {
                        record_below
                    };
                    let mut recorder = TileRecorder::new(cache, &tracer);
                    job.render(tile, Some((&mut recorder, below)))
                } else {
                    job.render(tile, None)
                }
            })
            .sum();
        if cancel.load(Ordering::Relaxed) {
            for (cache, &length) in self.cache.tiles.iter_mut().zip(&lengths) {
                cache.truncate(length);
            }
            return None;
        }
        if self.cache.tiles.iter().any(TileCache::overflowed) {
            // Over the budget: this pass is not recorded, and the cache is complete
            // at what it had.
            for (cache, &length) in self.cache.tiles.iter_mut().zip(&lengths) {
                cache.roll_back(length);
            }
            self.cache_capped = true;
            self.cache.samples_per_pixel = first_sample
                .min(record_below)
                .saturating_sub(self.cache_first);
        } else if recording {
            let end = if counts.is_some() {
                first_sample + samples
            } else {
                (first_sample + samples).min(record_below)
            };
            self.cache.samples_per_pixel = end.saturating_sub(self.cache_first);
            self.cache.tiles.iter_mut().for_each(TileCache::end_pass);
        }
        self.film.merge_tiles(&self.tiles);
        if counts.is_some() {
            self.adaptive_passes += 1;
        }
        self.samples_per_pixel += samples;
        self.retired_base = None;
        self.prepared_base = self
            .cache_complete()
            .then(|| (self.samples_per_pixel, BaseImage::of(&self.film)));
        let spare_fits = self.spare_film.as_ref().is_some_and(|f| {
            (f.width(), f.height()) == (self.film.width(), self.film.height())
                && f.channels() == self.film.channels()
        });
        if !spare_fits
            && self.cache_complete()
            && let Ok(mut spare) = new_film(&self.camera, &self.environment)
        {
            // Written once, so its pages are in memory before an edit needs them.
            spare.clear();
            self.spare_film = Some(spare);
        }
        if let Some(reshaded) = &self.reshaded
            && self.fresh_weight(reshaded) > FRESH_ONLY_WEIGHT
        {
            self.reshaded = None;
        }
        let stats = PassStats {
            samples: u64::from(samples) * u64::from(width) * u64::from(self.film.height()),
            rays,
            seconds: start.elapsed().as_secs_f64(),
        };
        self.totals.add(stats);
        Some(stats)
    }

    /// The per-pixel sample counts of the next pass when it is uneven: by the
    /// weights given ([`Self::set_pass_weights`]), else with adaptive sampling
    /// on, once the path cache (which then records uniform samples) is complete
    /// and every pixel has its uniform samples, by its noise map, recomputed
    /// when the samples per pixel have grown by [`RECOMPUTE_GROWTH`].
    fn adaptive_counts(&mut self, samples: u32, record_below: u32) -> Option<Vec<u32>> {
        let spp = self.samples_per_pixel;
        if samples == 0 {
            return None;
        }
        let weights = match &self.given_weights {
            Some(weights) => weights,
            None if spp < record_below => return None,
            None => {
                let adaptive = self.settings.adaptive?;
                if spp < adaptive.uniform_samples.max(2) {
                    return None;
                }
                let stale = match &self.adaptive_weights {
                    Some((at, _)) => f64::from(spp) >= f64::from(*at) * RECOMPUTE_GROWTH,
                    None => true,
                };
                if stale {
                    // The noise as the display adaptive sampling was tuned with
                    // shows it (exposure 0, Reinhard): the render does not know the
                    // viewer's exposure, exposure 0 suits every lighting setup, and
                    // the tuning's figures (docs/rendering.md) stay valid.
                    let weights = adaptive.weights(&self.film, &DisplaySettings::MEASURED);
                    self.adaptive_weights = Some((spp, weights));
                }
                &self.adaptive_weights.as_ref()?.1
            }
        };
        Some(allocate(
            weights,
            samples,
            self.settings.seed,
            self.adaptive_passes,
        ))
    }

    /// Spreads the samples of every later pass by `weights` (one per pixel, row
    /// major, mean 1) instead of evenly or by adaptive sampling's own noise map,
    /// until the next restart; keeps the samples. A recording of paths then
    /// holds every sample of its passes, more of some pixels than of others
    /// ([`PathCache::recorded_per_pixel`]). What a comparison does to spend
    /// more of both views' samples where its ΔE00 map is undecided
    /// ([`crate::engine`]'s guide). `None`, or weights of another size (a view
    /// resized since), spread them as before. A pixel's value is still the mean
    /// of its samples and its k-th sample still `PixelSampler(seed, p, k)`, so
    /// the render stays deterministic for a seed; two views with the same seed
    /// and weights from the same restart on take the same counts.
    pub fn set_pass_weights(&mut self, weights: Option<Vec<f32>>) {
        let pixels = self.film.width() as usize * self.film.height() as usize;
        self.given_weights = weights.filter(|w| w.len() == pixels);
    }

    /// The accumulated image.
    pub fn film(&self) -> &Film {
        &self.film
    }

    /// Samples per pixel accumulated since the last restart.
    pub fn samples_per_pixel(&self) -> u32 {
        self.samples_per_pixel
    }

    /// Everything rendered since the last restart.
    pub fn totals(&self) -> PassStats {
        self.totals
    }

    /// The noise left in the picture as displayed with `display` (see
    /// [`Film::noise_estimate`]), over every fourth pixel each way.
    pub fn noise_estimate(&self, display: &DisplaySettings) -> Option<NoiseEstimate> {
        self.film.noise_estimate(display, 4)
    }

    /// The camera.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The scene.
    pub fn scene(&self) -> &Arc<RenderScene> {
        &self.scene
    }

    /// The lighting.
    pub fn environment(&self) -> &Arc<Environment> {
        &self.environment
    }

    /// The shading.
    pub fn shading(&self) -> &Arc<Shading> {
        &self.shading
    }

    /// The settings.
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// Forgets every sample, the edit base's too.
    pub fn restart(&mut self) {
        self.base = None;
        self.spare_film = None;
        self.reshaded = None;
        self.restart_samples();
    }

    /// Forgets the samples of the current shading (and its re-shaded image unless
    /// set anew): what an edit does; the edit base stays.
    fn restart_samples(&mut self) {
        self.prepared_base = None;
        self.film.clear();
        self.samples_per_pixel = 0;
        self.totals = PassStats::default();
        self.cache.tiles.iter_mut().for_each(TileCache::clear);
        self.cache.samples_per_pixel = 0;
        self.cache_capped = false;
        self.cache_window = self.cache_target;
        self.cache_first = 0;
        self.adaptive_weights = None;
        self.adaptive_passes = 0;
        self.given_weights = None;
    }

    /// Restarts with the next pass beginning at sample index `first` of every
    /// pixel, to render one range of the sample indices of a render split across
    /// processes ([`crate::render::film::part`]): each sample is keyed by (seed,
    /// pixel, index), so the range gets the samples a whole render gives it.
    /// [`Self::samples_per_pixel`] then counts on from `first`, while the film
    /// holds only the range's samples. Refused past 0 with adaptive sampling,
    /// whose allocation depends on the samples before the range.
    pub fn restart_at_sample(&mut self, first: u32) -> Result<(), RenderError> {
        if first > 0 && self.settings.adaptive.is_some() {
            return Err(RenderError::AdaptiveRange);
        }
        self.restart();
        self.samples_per_pixel = first;
        Ok(())
    }

    /// A new view (and possibly a new image size); restarts.
    pub fn set_camera(&mut self, camera: Camera) -> Result<(), RenderError> {
        if (camera.width(), camera.height()) != (self.film.width(), self.film.height()) {
            self.film = new_film(&camera, &self.environment)?;
            self.tiles = self.film.tiles(self.settings.tile_size);
            self.cache = cache_for(&self.tiles);
        }
        self.camera = camera;
        self.restart();
        Ok(())
    }

    /// New shading (design or model edited); restarts.
    pub fn set_shading(&mut self, shading: Arc<Shading>) -> Result<(), RenderError> {
        check_grids(&self.environment, &shading)?;
        self.shading = shading;
        self.restart();
        Ok(())
    }

    /// New lighting; restarts. The shading must be on the same grid.
    pub fn set_environment(&mut self, environment: Arc<Environment>) -> Result<(), RenderError> {
        check_grids(&environment, &self.shading)?;
        if environment.channels() != self.film.channels() {
            self.film = new_film(&self.camera, &environment)?;
            self.tiles = self.film.tiles(self.settings.tile_size);
            self.cache = cache_for(&self.tiles);
        }
        self.environment = environment;
        self.restart();
        Ok(())
    }

    /// A new scene with its shading (built for its materials); restarts.
    pub fn set_scene(
        &mut self,
        scene: Arc<RenderScene>,
        shading: Arc<Shading>,
    ) -> Result<(), RenderError> {
        check_grids(&self.environment, &shading)?;
        self.scene = scene;
        self.shading = shading;
        self.restart();
        Ok(())
    }

    /// New settings (seed, path length, tiles); restarts.
    pub fn set_settings(&mut self, settings: RenderSettings) {
        if settings.tile_size != self.settings.tile_size {
            self.tiles = self.film.tiles(settings.tile_size);
            self.cache = cache_for(&self.tiles);
        }
        self.settings = settings;
        self.restart();
    }
}

/// Which samples a pass takes of each pixel.
#[derive(Clone, Copy)]
enum Plan<'a> {
    /// Samples `first .. first + samples` of every pixel.
    Uniform { first: u32, samples: u32 },
    /// `counts[i]` samples of image pixel i (row major), from the next of its own
    /// (the count `film` holds).
    Adaptive { film: &'a Film, counts: &'a [u32] },
}

impl Plan<'_> {
    /// The first sample index and the number of samples of pixel (`x`, `y`).
    #[inline]
    fn samples_of(&self, x: u32, y: u32, pixel_index: u32) -> (u32, u32) {
        match *self {
            Plan::Uniform { first, samples } => (first, samples),
            Plan::Adaptive { film, counts } => {
                let done = u32::try_from(film.sample_count(x, y)).unwrap_or(u32::MAX);
                (done, counts[pixel_index as usize])
            }
        }
    }
}

/// What a tile needs to render its share of a pass.
struct TileJob<'a> {
    tracer: &'a PathTracer<'a>,
    camera: &'a Camera,
    seed: u64,
    image_width: u32,
    plan: Plan<'a>,
    len: usize,
}

impl TileJob<'_> {
    /// Renders the tile; with a recorder, samples below its limit are recorded.
    /// Returns the rays traced. Samples are traced [`WAVE_PATHS`] at a time
    /// ([`PathTracer::radiance_wave`], bit for bit the same radiance as one by
    /// one) and added to the tile in the same order; a wave holds recorded or
    /// unrecorded samples, not both, and a recorded wave's paths are logged and
    /// handed to the recorder one after another once it is traced.
    fn render(&self, tile: &mut Film, mut recorder: Option<(&mut TileRecorder<'_>, u32)>) -> u64 {
        let mut wave = Wave::new(self.len, recorder.is_some());
        let [x0, y0] = tile.origin();
        let mut rays = 0u64;
        for y in y0..y0 + tile.height() {
            for x in x0..x0 + tile.width() {
                let pixel_index = y * self.image_width + x;
                let (first, count) = self.plan.samples_of(x, y, pixel_index);
                for sample in first..first.saturating_add(count) {
                    let mut sampler = PixelSampler::new(self.seed, pixel_index, sample);
                    let [jx, jy] = sampler.next_2d();
                    let ray = self.camera.ray(x as f32 + jx, y as f32 + jy);
                    let recorded = matches!(&recorder, Some((_, below)) if sample < *below);
                    if recorded != wave.recorded {
                        rays += self.trace_wave(&mut wave, tile, &mut recorder);
                        wave.recorded = recorded;
                    }
                    wave.pixels.push([x, y, sample]);
                    wave.rays.push(ray);
                    wave.samplers.push(sampler);
                    if wave.rays.len() == WAVE_PATHS {
                        rays += self.trace_wave(&mut wave, tile, &mut recorder);
                    }
                }
            }
        }
        rays + self.trace_wave(&mut wave, tile, &mut recorder)
    }

    /// Traces the paths waiting in `wave`, adds them to the tile in order and
    /// empties it; a recorded wave's paths go to the recorder in the same order
    /// (logged, one log per path, while the wave is traced). Returns the rays
    /// traced.
    fn trace_wave(
        &self,
        wave: &mut Wave,
        tile: &mut Film,
        recorder: &mut Option<(&mut TileRecorder<'_>, u32)>,
    ) -> u64 {
        let paths = wave.rays.len();
        if paths == 0 {
            return 0;
        }
        let radiance = &mut wave.radiance[..paths * self.len];
        let (rays, samplers, buffers) = (&wave.rays, &mut wave.samplers, &mut wave.buffers);
        let stats = match recorder.as_mut().filter(|_| wave.recorded) {
            Some((recorder, _)) => {
                let logs = &mut wave.logs[..paths];
                logs.iter_mut().for_each(PathLog::clear);
                let stats = self
                    .tracer
                    .radiance_wave(rays, samplers, buffers, radiance, logs);
                for ((&[x, y, _], spectrum), log) in wave
                    .pixels
                    .iter()
                    .zip(radiance.chunks_exact(self.len))
                    .zip(logs.iter())
                {
                    recorder.begin();
                    log.replay_into(*recorder);
                    recorder.finish(x, y, tile.xyz_of(spectrum));
                }
                // The recorder holds each path's plain contribution, which its
                // replay reproduces; the film also takes the floor's control term.
                for (path, spectrum) in radiance.chunks_exact_mut(self.len).enumerate() {
                    for (s, c) in spectrum.iter_mut().zip(buffers.floor_control(path)) {
                        *s += c;
                    }
                }
                stats
            }
            None => self.tracer.radiance_wave(
                rays,
                samplers,
                buffers,
                radiance,
                &mut [NoRecord; WAVE_PATHS][..paths],
            ),
        };
        for (&[x, y, sample], spectrum) in wave.pixels.iter().zip(radiance.chunks_exact(self.len)) {
            tile.add_sample_indexed(x, y, u64::from(sample), spectrum);
        }
        wave.pixels.clear();
        wave.rays.clear();
        wave.samplers.clear();
        u64::from(stats.rays)
    }
}

/// Pixel samples waiting to be traced together, and what tracing them needs.
struct Wave {
    /// Whether its samples are recorded.
    recorded: bool,
    /// Pixel x, y and the sample's index in the pixel's sequence.
    pixels: Vec<[u32; 3]>,
    rays: Vec<([f32; 3], [f32; 3])>,
    samplers: Vec<PixelSampler>,
    buffers: PathBuffers,
    /// The paths' radiance, one spectrum after another.
    radiance: Vec<f32>,
    /// One per path while a recorded wave is traced (none when nothing records).
    logs: Vec<PathLog>,
}

impl Wave {
    /// An empty wave for spectra of `len` wavelengths; `recording`: it may hold
    /// recorded samples.
    fn new(len: usize, recording: bool) -> Self {
        let mut logs = Vec::new();
        if recording {
            logs.resize_with(WAVE_PATHS, PathLog::default);
        }
        Self {
            recorded: false,
            pixels: Vec::with_capacity(WAVE_PATHS),
            rays: Vec::with_capacity(WAVE_PATHS),
            samplers: Vec::with_capacity(WAVE_PATHS),
            buffers: PathBuffers::new(len),
            radiance: vec![0.0; len * WAVE_PATHS],
            logs,
        }
    }
}

/// Empty path caches aligned with `tiles`.
fn cache_for(tiles: &[Film]) -> PathCache {
    PathCache {
        tiles: tiles
            .iter()
            .map(|t| TileCache::new(t.origin(), t.width(), t.height()))
            .collect(),
        samples_per_pixel: 0,
        paint_is_mirror: false,
        lobe_exponent: None,
    }
}

fn check_grids(environment: &Environment, shading: &Shading) -> Result<(), RenderError> {
    if environment.channels() != shading.channels() {
        return Err(RenderError::GridMismatch {
            environment: environment.channels().len(),
            shading: shading.len(),
        });
    }
    Ok(())
}

fn new_film(camera: &Camera, environment: &Environment) -> Result<Film, RenderError> {
    let (width, height) = (camera.width(), camera.height());
    if width == 0 || height == 0 {
        return Err(RenderError::EmptyImage { width, height });
    }
    Ok(Film::new(width, height, *environment.channels()))
}
