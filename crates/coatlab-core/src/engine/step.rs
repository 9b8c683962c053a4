//! [`LiveEngine::step`]: the actions the commands asked for, then one pass of
//! the views, published. What each outcome does next is [`super::plan::advance`].

use std::ops::ControlFlow;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use crate::render::material::Shading;
use crate::render::progressive::{EditOutcome, PassStats};
use crate::render::reshade::{ReshadeError, ShadingDifference};

use super::backend::{BackendView, RenderBackend, ViewSetup};
use super::events::{EngineError, EngineEvent};
use super::frame::{
    SecondUpdate, ViewsUpdate, display_of, edit_update, film_frame, map_due, pair_update,
    shared_update,
};
use super::guide::{REWEIGH_GROWTH, map_guided_weights, shared_map_guided_weights};
use super::live::{LiveEngine, Output, Progress};
use super::plan::{self, Actions, Outcome, Phase, Restart, Second, Tables};
use super::views::{
    Recordings, SecondSpec, ViewSet, independent_reason, lobes_differ, spawn_second_shading,
};
use super::{COARSE_FACTOR, COMPARE_CACHE_SAMPLES, RESHADE_SAMPLES};

/// Where a step publishes its images and events.
type Out<'a> = &'a mut dyn FnMut(Output);

/// What the first view's pass of a step did and was.
#[derive(Debug, Clone, Copy)]
struct FirstPass {
    stats: PassStats,
    /// A coarse (reduced-resolution) pass.
    coarse: bool,
    /// The view's resolution changed before it.
    resized: bool,
}

impl<B: RenderBackend> LiveEngine<B> {
    /// Does what the commands taken since the last step asked for, then renders
    /// one pass of the views (or re-shades an edit) and publishes the images
    /// through `out`. `cancel` stops a pass between tiles: set it when a command
    /// is waiting.
    pub fn step(&mut self, cancel: &AtomicBool, out: &mut dyn FnMut(Output)) -> Progress {
        let actions = std::mem::take(&mut self.pending);
        if actions.any() && self.execute(actions, out).is_break() {
            return Progress::Stepped;
        }
        // A new display with nothing to render: shown again at once (otherwise
        // the next pass shows it).
        if actions.republish
            && actions.restart == Restart::Keep
            && self.state.phase == Phase::Converged
        {
            self.republish(out);
            return Progress::Stepped;
        }
        if self.state.phase == Phase::Converged {
            return Progress::Idle;
        }
        let coarse = self.state.phase == Phase::Coarse;
        let Some(resized) = self.fit_resolution(coarse) else {
            return Progress::Stepped;
        };
        // With no further edit waiting (the commands were just taken), the
        // re-shade from all recorded samples comes before fresh passes.
        if self.state.phase == Phase::EditShown && self.views.first.refine_edit() {
            self.publish_edit(PassStats::default(), out);
            self.advance(Outcome::EditRefined);
            return Progress::Stepped;
        }
        let Some(stats) = self.views.first.render_pass(cancel) else {
            return Progress::Cancelled;
        };
        self.views.last_stats = [stats, self.views.last_stats[1]];
        self.counters.passes += 1;
        let converged = self.views.first.samples_per_pixel() >= self.inputs.quality.max_spp;
        self.advance(if coarse {
            Outcome::CoarseDone
        } else {
            Outcome::PassDone { converged }
        });
        let first = FirstPass {
            stats,
            coarse,
            resized,
        };
        self.after_first_pass(first, cancel, out)
    }

    /// Moves to the state after `outcome`; returns what it asks for.
    fn advance(&mut self, outcome: Outcome) -> Actions {
        let (state, actions) = plan::advance(self.state, outcome);
        self.state = state;
        actions
    }

    /// Rebuilds and restarts as `actions` say. Breaks when the step is over: an
    /// edit was shown re-shaded, or the design cannot be modelled.
    fn execute(&mut self, actions: Actions, out: &mut dyn FnMut(Output)) -> ControlFlow<()> {
        let shading = if actions.shading {
            let Some(shading) = self.first_shading(actions.tables == Tables::Rebuild) else {
                // The last image stays (the paint panel says what is wrong); what
                // was asked for is done with the next command.
                self.deferred = actions;
                let converged = self.views.first.samples_per_pixel() >= self.inputs.quality.max_spp;
                self.advance(Outcome::DesignInvalid { converged });
                return ControlFlow::Break(());
            };
            Some(shading)
        } else {
            None
        };
        if actions.renders
            && let Some(shading) = &shading
        {
            self.new_renders(shading.clone(), out);
        }
        if actions.relight {
            self.relight(out);
        }
        let mut restart = actions.restart;
        if let Some(shading) = shading {
            if restart == Restart::Reshade {
                if self.try_reshade(shading.clone(), out) {
                    return ControlFlow::Break(());
                }
                restart = Restart::Retrace;
            }
            self.retrace_with(shading, actions, out);
        }
        if restart == Restart::Retrace {
            self.counters.retraces += 1;
        }
        ControlFlow::Continue(())
    }

    /// The first view's shading from the paint model brought up to the design
    /// (from scratch if `rebuild`); `None` if the design cannot be modelled.
    fn first_shading(&mut self, rebuild: bool) -> Option<Arc<Shading>> {
        let scene = self.world.scene.clone();
        let paint = self.inputs.paint_materials(scene.paint_materials());
        let model = self
            .world
            .model_for(&self.inputs.design, rebuild, &mut self.counters)?;
        let shading = Shading::new(model, self.inputs.views.first, scene.materials(), &paint);
        self.counters.shading_builds += 1;
        Some(Arc::new(shading))
    }

    /// A new first render on the new grid; the second view's is made again.
    fn new_renders(&mut self, shading: Arc<Shading>, out: &mut dyn FnMut(Output)) {
        let setup = ViewSetup {
            scene: self.world.scene.clone(),
            environment: self.world.environment.clone(),
            shading,
            camera: self.inputs.camera.clone(),
        };
        match self.backend.view(setup) {
            Ok(mut first) => {
                self.counters.render_builds += 1;
                first.set_path_cache_samples(self.views.cache_samples);
                self.views.first = first;
                self.views.second = None;
            }
            Err(e) => failed(out, e.into()),
        }
    }

    /// The views lit by the new lighting.
    fn relight(&mut self, out: &mut dyn FnMut(Output)) {
        let environment = &self.world.environment;
        let views = std::iter::once(&mut self.views.first).chain(self.views.second.as_mut());
        for view in views {
            if let Err(e) = view.set_environment(environment.clone()) {
                failed(out, e.into());
            }
        }
    }

    /// Shows the edit re-shaded from the edit base; false when the back-end
    /// refuses (it is then traced fresh).
    fn try_reshade(&mut self, shading: Arc<Shading>, out: &mut dyn FnMut(Output)) -> bool {
        match self.views.first.edit_shading(shading) {
            Ok(EditOutcome::Reshaded) => {
                self.counters.reshades += 1;
                self.last_refusal = None;
                self.advance(Outcome::EditReshaded);
                self.publish_edit(PassStats::default(), out);
                return true;
            }
            Ok(EditOutcome::Fresh(reason)) => self.last_refusal = Some(reason),
            Err(e) => failed(out, e.into()),
        }
        self.advance(Outcome::EditRefused);
        false
    }

    /// The first view restarted with `shading` (and the new scene), recording as
    /// many samples as the views need; the second view rebuilt or dropped.
    fn retrace_with(
        &mut self,
        shading: Arc<Shading>,
        actions: Actions,
        out: &mut dyn FnMut(Output),
    ) {
        let first = &mut self.views.first;
        let result = if actions.rescene {
            first.set_scene(self.world.scene.clone(), shading)
        } else if actions.renders {
            // The new render has this shading already.
            Ok(())
        } else {
            first.set_shading(shading)
        };
        if let Err(e) = result {
            failed(out, e.into());
        }
        // A comparison records more of the first view's paths, for the second
        // view to be re-shaded from.
        self.views.record(if self.inputs.views.second.is_some() {
            COMPARE_CACHE_SAMPLES
        } else {
            RESHADE_SAMPLES
        });
        match actions.second {
            Second::Rebuild => self.rebuild_second(actions.rescene),
            Second::Drop => self.views.drop_second(),
            Second::Keep => {}
        }
    }

    /// Starts building the second view's shading; how the second view is made is
    /// decided once it is ready. A job still running for an older change
    /// finishes unobserved.
    fn rebuild_second(&mut self, new_scene: bool) {
        self.views.shared = None;
        if new_scene {
            // Made again with the new scene once its shading is ready.
            self.views.second = None;
        }
        let Some(second) = &self.inputs.views.second else {
            self.views.drop_second();
            return;
        };
        let spec = SecondSpec {
            design: second
                .design
                .as_deref()
                .unwrap_or(&self.inputs.design)
                .clone(),
            model: second.model,
            grid: self.world.grid,
            materials: self.world.scene.materials().to_vec(),
            paint_materials: self
                .inputs
                .paint_materials(self.world.scene.paint_materials()),
        };
        self.counters.second_shading_builds += 1;
        self.views.job = spawn_second_shading(spec, self.on_thread_start.clone());
    }

    /// Sets the first view's resolution for the pass: 1/[`COARSE_FACTOR`] of
    /// the size for the coarse pass, the size otherwise. Whether it changed
    /// (restarting the view); `None` if the back-end refused.
    fn fit_resolution(&mut self, coarse: bool) -> Option<bool> {
        let size = self.inputs.size;
        let target = if coarse {
            (
                (size.0 / COARSE_FACTOR).max(1),
                (size.1 / COARSE_FACTOR).max(1),
            )
        } else if self.views.first.resolution() != size {
            size
        } else {
            return Some(false);
        };
        self.inputs.camera.set_resolution(target.0, target.1);
        self.views
            .first
            .set_camera(self.inputs.camera.clone())
            .ok()
            .map(|()| true)
    }

    /// After the first view's pass: the second view decided, rendered or
    /// re-shaded, and the images published.
    fn after_first_pass(&mut self, first: FirstPass, cancel: &AtomicBool, out: Out) -> Progress {
        let FirstPass { stats, coarse, .. } = first;
        if let Some(job) = self.views.job.take() {
            // Show the first view's new image while the second's shading is
            // still being fitted.
            if !job.is_finished() {
                self.publish_first_only(stats, coarse, out);
            }
            let shading = job.join().ok().flatten();
            self.take_second_shading(shading, out);
        }
        if self.views.second.is_some() {
            return self.step_second(first, cancel, out);
        }
        if self.views.first.is_reshaded() {
            self.publish_edit(stats, out);
        } else {
            let display = self.take_display();
            let first = film_frame(&self.views.first, stats, &display, coarse);
            publish(out, first, SecondUpdate::Clear, Some(None));
        }
        Progress::Stepped
    }

    /// The second view's new shading: shared where the first view's paths
    /// re-shade into it, a render of its own where not.
    fn take_second_shading(&mut self, shading: Option<Arc<Shading>>, out: &mut dyn FnMut(Output)) {
        let Some(shading) = shading else {
            failed(out, EngineError::SecondDesignInvalid);
            self.views.second = None;
            self.advance(Outcome::SecondInvalid);
            return;
        };
        let first_lobe = self.views.first.shading().design().lobe_exponent();
        let second_lobe = shading.design().lobe_exponent();
        let shared = if let Some(reason) =
            lobes_differ(first_lobe, second_lobe, self.views.lobe_narrowing)
        {
            self.views.reason = reason;
            false
        } else {
            self.counters.pane_reshades += 1;
            match self.views.first.reshade_recorded(&shading) {
                Ok(_) => true,
                Err(e) => {
                    self.views.reason = independent_reason(&e);
                    false
                }
            }
        };
        // Either way the second view has a render of its own, so its pane
        // converges to its own model's image.
        let existing = self.views.second.take();
        self.views.second = self.second_view(existing, shading.clone(), out);
        self.views.difference = None;
        self.views.shared = shared.then_some(shading);
        self.advance(match (self.views.second.is_some(), shared) {
            (false, _) => Outcome::SecondInvalid,
            (true, true) => Outcome::SecondShared,
            (true, false) => Outcome::SecondIndependent,
        });
    }

    /// The difference the second shading makes, from the first view's recorded
    /// paths. While the first recording grows it holds every sample of the film
    /// and is re-shaded when the map is due; each complete recording is re-shaded
    /// once, merged into the difference, and the first view records the next
    /// samples in its place, so the difference keeps refining at the memory of
    /// one recording. A re-shade that cannot be done yet keeps the last
    /// difference; one that cannot be done at all leaves the second view's own
    /// render alone.
    fn update_difference(&mut self, due: bool) {
        let Some(shading) = self.views.shared.clone() else {
            return;
        };
        let size = self.views.first.resolution();
        let kept = match &self.views.difference {
            Some((d, recordings)) if (d.width(), d.height()) == size => Some(*recordings),
            _ => None,
        };
        let complete = self.views.first.recording_complete();
        let wait = match kept {
            Some(Recordings::Final) => true,
            Some(Recordings::Merged) => !complete,
            Some(Recordings::Growing) => !complete && !due,
            None => false,
        };
        if wait {
            return;
        }
        let first = &self.views.first;
        let recorded = first.recorded_samples();
        self.counters.pane_reshades += 1;
        let difference = first
            .reshade_recorded(&shading)
            .and_then(|image| {
                ShadingDifference::of(&image, first.film(), recorded, first.recorded_per_pixel())
            })
            .and_then(|d| match (&self.views.difference, kept, complete) {
                (Some((merged, _)), Some(Recordings::Merged), true) => merged.merged(&d),
                _ => Ok(d),
            });
        match difference {
            Ok(d) if complete => {
                let recordings = if self.views.first.record_next_samples() {
                    Recordings::Merged
                } else {
                    Recordings::Final
                };
                self.views.difference = Some((d, recordings));
            }
            Ok(d) => self.views.difference = Some((d, Recordings::Growing)),
            Err(ReshadeError::NotReady { .. }) => {}
            Err(e) => {
                self.views.reason = independent_reason(&e);
                self.views.shared = None;
                self.views.difference = None;
                self.advance(Outcome::SharedFailed);
            }
        }
    }

    /// The second view's render with new shading: `existing` re-shaded, or a
    /// new one.
    fn second_view(
        &mut self,
        existing: Option<B::View>,
        shading: Arc<Shading>,
        out: &mut dyn FnMut(Output),
    ) -> Option<B::View> {
        let result = match existing {
            Some(mut render) => render.set_shading(shading).map(|()| render),
            None => {
                self.counters.render_builds += 1;
                self.backend.view(ViewSetup {
                    scene: self.world.scene.clone(),
                    environment: self.world.environment.clone(),
                    shading,
                    camera: self.inputs.camera.clone(),
                })
            }
        };
        result.map_err(|e| failed(out, e.into())).ok()
    }

    /// The second view rendered apart: kept on the first view's camera and
    /// samples, one pass, both published.
    fn step_second(&mut self, first: FirstPass, cancel: &AtomicBool, out: Out) -> Progress {
        let FirstPass {
            stats: stats_a,
            coarse,
            resized,
        } = first;
        let spp = self.views.first.samples_per_pixel();
        let Some(second) = self.views.second.as_mut() else {
            return Progress::Stepped;
        };
        if resized || second.samples_per_pixel() + 1 != spp {
            if second.set_camera(self.inputs.camera.clone()).is_err() {
                self.views.second = None;
                return Progress::Stepped;
            }
            if spp != 1 {
                // Out of step (a pass of the second view was cancelled): both
                // start again.
                self.out_of_step();
                return Progress::Stepped;
            }
        }
        let Some(stats_b) = second.render_pass(cancel) else {
            self.out_of_step();
            return Progress::Cancelled;
        };
        self.counters.second_passes += 1;
        self.views.last_stats = [stats_a, stats_b];
        let due = map_due(coarse, spp, self.inputs.quality.max_spp);
        self.update_difference(due);
        self.guide_passes();
        self.publish_pair(coarse, due, out);
        Progress::Stepped
    }

    /// Both views' next passes spread their samples by where the map is
    /// undecided ([`map_weights`]), the weights made again when the samples
    /// have grown by [`REWEIGH_GROWTH`].
    fn guide_passes(&mut self) {
        let views = &mut self.views;
        if views.second.is_none() {
            return;
        }
        if !views.map_guidance {
            if views.guided_at.take().is_some() {
                views.first.set_pass_weights(None);
                if let Some(second) = views.second.as_mut() {
                    second.set_pass_weights(None);
                }
            }
            return;
        }
        let spp = views.first.samples_per_pixel();
        // A restart since has dropped the views' weights.
        if views.guided_at.is_some_and(|at| spp < at) {
            views.guided_at = None;
        }
        let due = views
            .guided_at
            .is_none_or(|at| f64::from(spp) >= f64::from(at) * REWEIGH_GROWTH);
        // From the first complete recording on: shared, the difference exists;
        // apart, each pixel's noise is estimated from that many samples.
        if !due || spp < views.cache_samples.max(2) {
            return;
        }
        if let Some(weights) = map_weights(views)
            && let Some(second) = views.second.as_mut()
        {
            views.first.set_pass_weights(Some(weights.clone()));
            second.set_pass_weights(Some(weights));
            views.guided_at = Some(spp);
        }
    }

    /// Both views of a comparison: the second view's pane shared (combined
    /// with the first view's paths) where it can be, else its own film.
    fn publish_pair(&mut self, coarse: bool, due: bool, out: Out) {
        let display = self.take_display();
        let Some(second) = &self.views.second else {
            return;
        };
        let stats = self.views.last_stats;
        let shared_spp = self
            .views
            .difference
            .as_ref()
            .map_or(0, |(d, _)| d.samples());
        let update = match self.views.shared_panes() {
            Some(Ok(panes)) => shared_update(
                [&self.views.first, second],
                &panes,
                shared_spp,
                stats,
                &display,
                (coarse, due),
            ),
            // Not re-shaded yet at this size, or not shared: its own film.
            _ => pair_update(
                [&self.views.first, second],
                stats,
                &self.views.reason,
                &display,
                (coarse, due),
            ),
        };
        out(Output::Views(update));
    }

    /// The images shown again (the display changed) without a pass: what the
    /// last pass published, in the new display.
    pub(super) fn republish(&mut self, out: Out) {
        if self.views.second.is_some() {
            self.publish_pair(false, true, out);
        } else if self.views.first.is_reshaded() {
            self.take_display();
            self.publish_edit(self.views.last_stats[0], out);
        } else {
            let display = self.take_display();
            let first = film_frame(&self.views.first, self.views.last_stats[0], &display, false);
            publish(out, first, SecondUpdate::Clear, Some(None));
        }
    }

    fn out_of_step(&mut self) {
        let retrace = self.advance(Outcome::OutOfStep);
        self.pending = self.pending.merge(retrace);
    }

    /// The display settings for the images about to be published, kept for an
    /// export: one for both views, from the first view's film.
    fn take_display(&mut self) -> crate::render::film::DisplaySettings {
        self.views.display = display_of(&self.views.first, &self.inputs.display);
        self.views.display
    }

    /// The first view alone; the second keeps its last image (its new one is on
    /// the way) and the map stays.
    fn publish_first_only(&mut self, stats: PassStats, coarse: bool, out: &mut dyn FnMut(Output)) {
        let display = self.take_display();
        let first = film_frame(&self.views.first, stats, &display, coarse);
        publish(out, first, SecondUpdate::Keep, None);
    }

    /// The first view while an edit is shown re-shaded, in the last image's
    /// display settings.
    fn publish_edit(&self, stats: PassStats, out: &mut dyn FnMut(Output)) {
        if let Some(update) = edit_update(&self.views.first, stats, &self.views.display) {
            out(Output::Views(update));
        }
    }
}

/// The weights for both views' next passes from where their map is undecided:
/// rendered apart, the films' map ([`map_guided_weights`]); shared, the panes'
/// ([`shared_map_guided_weights`], whose recordings then take the same share).
/// `None` where there is no map to read yet.
fn map_weights<V: BackendView>(views: &ViewSet<V>) -> Option<Vec<f32>> {
    let second = views.second.as_ref()?;
    let (first_film, second_film) = (views.first.film(), second.film());
    if views.shared.is_none() {
        return map_guided_weights(first_film, second_film, &views.display);
    }
    let [(first_pane, _), (second_pane, _)] = views.shared_panes()?.ok()?;
    let (difference, _) = views.difference.as_ref()?;
    let variance = difference
        .panes_difference_variance_xyz(first_film, second_film)
        .ok()?;
    shared_map_guided_weights(
        &first_pane.xyz,
        &second_pane.xyz,
        &variance,
        first_film,
        &views.display,
    )
}

fn publish(
    out: &mut dyn FnMut(Output),
    first: super::frame::Frame,
    second: SecondUpdate,
    map: Option<Option<super::delta_e::DeltaEMap>>,
) {
    out(Output::Views(ViewsUpdate { first, second, map }));
}

fn failed(out: &mut dyn FnMut(Output), error: EngineError) {
    out(Output::Event(EngineEvent::Failed(error)));
}
