//! The seam between the live engine and whatever renders its views.
//!
//! The engine decides what to rebuild and when to restart; a back-end renders.
//! [`RenderBackend`] makes a view's render from a scene, lighting, shading and
//! camera; [`BackendView`] is that render: progressive passes into a film, the
//! path cache a paint edit or the second view of a comparison is re-shaded from,
//! and the edit base. The CPU's progressive path tracer
//! ([`crate::render::progressive::ProgressiveRender`]) is the back-end today
//! ([`super::cpu`]); a GPU tracer or the batch renderer implements the same
//! two traits to run under the same engine.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use crate::render::camera::Camera;
use crate::render::environment::Environment;
use crate::render::film::{DisplaySettings, Film, NoiseEstimate};
use crate::render::material::Shading;
use crate::render::progressive::{EditOutcome, PassStats, RenderError, RenderScene};
use crate::render::reshade::{ReshadeError, Reshaded};

/// What a view's render is made of.
#[derive(Debug, Clone)]
pub struct ViewSetup {
    /// The scene with its BVH.
    pub scene: Arc<RenderScene>,
    /// The lighting, on the shading's grid.
    pub environment: Arc<Environment>,
    /// The scene's materials with the paint.
    pub shading: Arc<Shading>,
    /// The view; its resolution is the image's.
    pub camera: Camera,
}

/// Makes the renders of the views.
pub trait RenderBackend: Send {
    /// One view's render.
    type View: BackendView;

    /// A new render of `setup`, with no samples.
    fn view(&self, setup: ViewSetup) -> Result<Self::View, RenderError>;
}

/// One view's progressive render. Every setter restarts the accumulation
/// unless it says otherwise.
pub trait BackendView: Send {
    /// A new view (and possibly a new image size).
    fn set_camera(&mut self, camera: Camera) -> Result<(), RenderError>;
    /// New shading.
    fn set_shading(&mut self, shading: Arc<Shading>) -> Result<(), RenderError>;
    /// New lighting, on the shading's grid.
    fn set_environment(&mut self, environment: Arc<Environment>) -> Result<(), RenderError>;
    /// A new scene with its shading.
    fn set_scene(
        &mut self,
        scene: Arc<RenderScene>,
        shading: Arc<Shading>,
    ) -> Result<(), RenderError>;
    /// Records the paths of the first `samples` samples per pixel for re-shading.
    fn set_path_cache_samples(&mut self, samples: u32);

    /// A paint edit: shown at once re-shaded from the edit base where possible
    /// (the outcome says why not), while fresh passes of it accumulate.
    fn edit_shading(&mut self, shading: Arc<Shading>) -> Result<EditOutcome, RenderError>;
    /// Re-shades the last edit from all recorded samples where its first image
    /// came from fewer; whether the image was replaced. Keeps the samples.
    fn refine_edit(&mut self) -> bool;
    /// Whether the picture is still partly an edit's re-shaded estimate.
    fn is_reshaded(&self) -> bool;
    /// The blend of an edit's re-shaded estimate and the fresh samples, with the
    /// fresh samples' weight; `None` once the film alone is better.
    fn edit_estimate(&self) -> Option<(Reshaded, f64)>;

    /// One pass of one sample per pixel; `None` when `cancel` stopped it (the
    /// film is then as it was).
    fn render_pass(&mut self, cancel: &AtomicBool) -> Option<PassStats>;
    /// The recorded paths re-shaded with `shading` (the picture this view would
    /// show with it), without tracing.
    fn reshade_recorded(&self, shading: &Shading) -> Result<Reshaded, ReshadeError>;
    /// Samples per pixel the path cache holds (the pixels' mean where its
    /// passes were spread by weights).
    fn recorded_samples(&self) -> u32;
    /// Per pixel (row major) the samples the path cache holds.
    fn recorded_per_pixel(&self) -> Vec<u32>;
    /// Whether the path cache holds every sample its recording takes.
    fn recording_complete(&self) -> bool;
    /// Drops a complete recording and records as many samples per pixel again
    /// from the next pass on, keeping the film; false (nothing changes) while
    /// it is incomplete or where the back-end cannot.
    fn record_next_samples(&mut self) -> bool;

    /// Spreads every later pass's samples by `weights` (one per pixel, row major,
    /// mean 1) until the next restart, keeping the samples; `None`: evenly. A
    /// back-end that cannot spreads them evenly.
    fn set_pass_weights(&mut self, weights: Option<Vec<f32>>);

    /// The accumulated image.
    fn film(&self) -> &Film;
    /// Samples per pixel accumulated since the last restart.
    fn samples_per_pixel(&self) -> u32;
    /// The image size, pixels.
    fn resolution(&self) -> (u32, u32);
    /// The shading rendered.
    fn shading(&self) -> &Arc<Shading>;
    /// The noise left in the picture as shown with `display`.
    fn noise_estimate(&self, display: &DisplaySettings) -> Option<NoiseEstimate>;
}
