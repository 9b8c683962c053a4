//! The CPU back-end: the progressive path tracer of [`crate::render::progressive`]
//! behind the engine's [`RenderBackend`] seam. Every method forwards to the
//! render's own; a pass is one call, so the seam costs one call per pass, not
//! per sample.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use crate::render::camera::Camera;
use crate::render::environment::Environment;
use crate::render::film::{DisplaySettings, Film, NoiseEstimate};
use crate::render::material::Shading;
use crate::render::progressive::{
    EditOutcome, PassStats, ProgressiveRender, RenderError, RenderScene, RenderSettings,
};
use crate::render::reshade::{ReshadeError, Reshaded};

use super::backend::{BackendView, RenderBackend, ViewSetup};

/// The CPU's progressive path tracer, on rayon's thread pool.
#[derive(Debug, Clone, Copy, Default)]
pub struct CpuBackend {
    /// Seed, path length, tiles and adaptive sampling of every view.
    pub settings: RenderSettings,
}

impl RenderBackend for CpuBackend {
    type View = ProgressiveRender;

    fn view(&self, setup: ViewSetup) -> Result<ProgressiveRender, RenderError> {
        ProgressiveRender::new(
            setup.scene,
            setup.environment,
            setup.shading,
            setup.camera,
            self.settings,
        )
    }
}

impl BackendView for ProgressiveRender {
    fn set_camera(&mut self, camera: Camera) -> Result<(), RenderError> {
        ProgressiveRender::set_camera(self, camera)
    }

    fn set_shading(&mut self, shading: Arc<Shading>) -> Result<(), RenderError> {
        ProgressiveRender::set_shading(self, shading)
    }

    fn set_environment(&mut self, environment: Arc<Environment>) -> Result<(), RenderError> {
        ProgressiveRender::set_environment(self, environment)
    }

    fn set_scene(
        &mut self,
        scene: Arc<RenderScene>,
        shading: Arc<Shading>,
    ) -> Result<(), RenderError> {
        ProgressiveRender::set_scene(self, scene, shading)
    }

    fn set_path_cache_samples(&mut self, samples: u32) {
        ProgressiveRender::set_path_cache_samples(self, samples);
    }

    fn edit_shading(&mut self, shading: Arc<Shading>) -> Result<EditOutcome, RenderError> {
        ProgressiveRender::edit_shading(self, shading)
    }

    fn refine_edit(&mut self) -> bool {
        ProgressiveRender::refine_edit(self)
    }

    fn is_reshaded(&self) -> bool {
        ProgressiveRender::is_reshaded(self)
    }

    fn edit_estimate(&self) -> Option<(Reshaded, f64)> {
        ProgressiveRender::edit_estimate(self)
    }

    fn render_pass(&mut self, cancel: &AtomicBool) -> Option<PassStats> {
        self.render_pass_cancellable(1, cancel)
    }

    fn reshade_recorded(&self, shading: &Shading) -> Result<Reshaded, ReshadeError> {
        ProgressiveRender::reshade_recorded(self, shading)
    }

    fn recorded_samples(&self) -> u32 {
        self.path_cache().samples_per_pixel()
    }

    fn recorded_per_pixel(&self) -> Vec<u32> {
        let (width, height) = self.resolution();
        self.path_cache().recorded_per_pixel(width, height)
    }

    fn recording_complete(&self) -> bool {
        self.path_cache_complete()
    }

    fn record_next_samples(&mut self) -> bool {
        ProgressiveRender::record_next_samples(self)
    }

    fn set_pass_weights(&mut self, weights: Option<Vec<f32>>) {
        ProgressiveRender::set_pass_weights(self, weights);
    }

    fn film(&self) -> &Film {
        ProgressiveRender::film(self)
    }

    fn samples_per_pixel(&self) -> u32 {
        ProgressiveRender::samples_per_pixel(self)
    }

    fn resolution(&self) -> (u32, u32) {
        (self.camera().width(), self.camera().height())
    }

    fn shading(&self) -> &Arc<Shading> {
        ProgressiveRender::shading(self)
    }

    fn noise_estimate(&self, display: &DisplaySettings) -> Option<NoiseEstimate> {
        ProgressiveRender::noise_estimate(self, display)
    }
}
