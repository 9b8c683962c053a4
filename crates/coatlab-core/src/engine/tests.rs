//! Each transition of the live engine, driven without a window: what a command
//! rebuilds is read from [`EngineCounters`], where the state machine goes from
//! [`LiveEngine::state`], and what is shown from the published updates.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use crate::colour::cie::Illuminant;
use crate::colour::spectrum::WavelengthGrid;
use crate::design::{PaintDesign, RefractiveIndex, presets};
use crate::paint::phong::PhongVariant;
use crate::render::camera::Camera;
use crate::render::environment::Environment;
use crate::render::film::Film;
use crate::render::lighting::Lighting;
use crate::render::material::{Shading, ShadingModel};
use crate::render::progressive::{
    EditOutcome, PassStats, ProgressiveRender, RenderError, RenderScene, RenderSettings,
};
use crate::render::reshade::{ReshadeError, Reshaded};
use crate::render::view::{NamedView, ViewChoice, ViewError};

use super::plan::{Actions, Change, Outcome, Restart, Second, Tables, advance, settle, transition};
use super::*;

#[path = "../../tests/support/hdr_fixture.rs"]
mod hdr_fixture;
use hdr_fixture::write_hdr;

/// A small image, so a pass takes milliseconds.
const SIZE: (u32, u32) = (48, 30);
/// Refinement stops here in these tests: past the recording of the path cache.
const TARGET: u32 = 6;

fn design() -> PaintDesign {
    presets::all().swap_remove(0).design
}

fn knobs(wavelengths: usize, max_spp: u32) -> QualityKnobs {
    QualityKnobs {
        wavelengths,
        max_spp,
        resolution_divisor: 1,
    }
}

/// A CPU engine at [`SIZE`] refining to [`TARGET`], its commands' first step done.
fn engine() -> LiveEngine {
    let mut engine = LiveEngine::new(CpuBackend::default(), design(), Arc::new(|| {}))
        .expect("the engine starts");
    apply(&mut engine, Command::Size(SIZE.0, SIZE.1));
    apply(
        &mut engine,
        Command::Quality(knobs(DEFAULT_WAVELENGTHS, TARGET)),
    );
    engine
}

fn apply(engine: &mut LiveEngine, command: Command) -> Vec<Output> {
    let mut outputs = Vec::new();
    engine.apply(command, &mut |o| outputs.push(o));
    outputs
}

fn step(engine: &mut LiveEngine) -> (Progress, Vec<Output>) {
    let never = AtomicBool::new(false);
    let mut outputs = Vec::new();
    let progress = engine.step(&never, &mut |o| outputs.push(o));
    (progress, outputs)
}

/// Steps until the engine waits for a command; the updates published.
/// Converges `engine`, checks it ended in `pairing`, and returns the last
/// published first and second frames.
fn converge_in_pairing(engine: &mut LiveEngine, pairing: Pairing) -> (Frame, Frame) {
    let published = converge(engine);
    assert_eq!(engine.state().pairing, pairing);
    let last = published.last().expect("images");
    let SecondUpdate::Set(second) = &last.second else {
        panic!("no second image: {:?}", last.second);
    };
    (last.first.clone(), second.clone())
}

fn converge(engine: &mut LiveEngine) -> Vec<ViewsUpdate> {
    let mut updates = Vec::new();
    for _ in 0..100 {
        let (progress, outputs) = step(engine);
        updates.extend(outputs.into_iter().map(|o| match o {
            Output::Views(update) => update,
            Output::Event(e) => panic!("unexpected event {e:?}"),
        }));
        if progress == Progress::Idle {
            return updates;
        }
    }
    panic!("the engine did not converge: {:?}", engine.state());
}

/// A converged engine, and its counters.
fn converged() -> (LiveEngine, EngineCounters) {
    let mut engine = engine();
    converge(&mut engine);
    assert_eq!(engine.state().phase, Phase::Converged);
    assert_eq!(engine.samples_per_pixel(), TARGET);
    let counters = engine.counters();
    (engine, counters)
}

/// Converges, applies `command`, which must start a fresh coarse pass, steps once
/// and checks that it showed a coarse image and that just `expected` was rebuilt.
fn restarts_coarse(command: Command, expected: EngineCounters) -> LiveEngine {
    let (mut engine, before) = converged();
    apply(&mut engine, command);
    assert_eq!(engine.state().phase, Phase::Coarse);
    let (_, outputs) = step(&mut engine);
    assert!(updates(outputs)[0].first.coarse);
    assert_built(&engine, &before, expected);
    engine
}

/// Only the named counters moved, by the amounts given.
fn assert_built(engine: &LiveEngine, before: &EngineCounters, expected: EngineCounters) {
    let mut done = engine.counters().since(before);
    // Passes depend on how far the test steps; the builds are what is asserted.
    done.passes = 0;
    done.second_passes = 0;
    done.pane_reshades = 0;
    assert_eq!(done, expected);
}

fn updates(outputs: Vec<Output>) -> Vec<ViewsUpdate> {
    outputs
        .into_iter()
        .filter_map(|o| match o {
            Output::Views(update) => Some(update),
            Output::Event(_) => None,
        })
        .collect()
}

fn events(outputs: &[Output]) -> Vec<&EngineEvent> {
    outputs
        .iter()
        .filter_map(|o| match o {
            Output::Event(event) => Some(event),
            Output::Views(_) => None,
        })
        .collect()
}

const RETRACE_ONLY: EngineCounters = retraced(0, 0, 0);

/// What an edit that starts the first view again builds: these paint tables,
/// first-view shadings and second-view shadings, and one retrace.
const fn retraced(
    table_builds: u64,
    shading_builds: u64,
    second_shading_builds: u64,
) -> EngineCounters {
    EngineCounters {
        table_builds,
        shading_builds,
        second_shading_builds,
        retraces: 1,
        ..ZERO
    }
}

const ZERO: EngineCounters = EngineCounters {
    bvh_builds: 0,
    lighting_builds: 0,
    table_builds: 0,
    shading_builds: 0,
    second_shading_builds: 0,
    render_builds: 0,
    retraces: 0,
    reshades: 0,
    pane_reshades: 0,
    passes: 0,
    second_passes: 0,
};

#[test]
fn a_new_engine_builds_each_thing_once_and_starts_coarse() {
    let engine = LiveEngine::new(CpuBackend::default(), design(), Arc::new(|| {})).expect("start");
    assert_eq!(engine.state(), State::START);
    assert_eq!(
        engine.counters(),
        EngineCounters {
            bvh_builds: 1,
            lighting_builds: 1,
            table_builds: 1,
            shading_builds: 1,
            render_builds: 1,
            ..ZERO
        }
    );
    assert_eq!(engine.recording_target(), RESHADE_SAMPLES);
    assert_eq!(engine.grid().len(), DEFAULT_WAVELENGTHS);
}

#[test]
fn a_change_shows_coarse_first_then_refines_at_full_size_to_the_target() {
    let mut engine = engine();
    let (_, outputs) = step(&mut engine);
    let first = &updates(outputs)[0].first;
    assert!(first.coarse);
    assert_eq!(
        (first.width, first.height),
        (SIZE.0 / COARSE_FACTOR, SIZE.1 / COARSE_FACTOR)
    );
    assert_eq!(engine.state().phase, Phase::CoarseShown);
    let rest = converge(&mut engine);
    assert!(
        rest.iter()
            .all(|u| !u.first.coarse && u.first.width == SIZE.0)
    );
    assert_eq!(rest.last().map(|u| u.first.samples_per_pixel), Some(TARGET));
    assert_eq!(engine.state().phase, Phase::Converged);
}

#[test]
fn commands_that_change_nothing_rebuild_nothing() {
    let (mut engine, before) = converged();
    let state = engine.state();
    let same = [
        Command::Design(Box::new(design())),
        Command::Views(Views::single(ShadingModel::Paint)),
        Command::Lighting(Lighting::Studio),
        Command::PaintMaterials(None),
        Command::Size(SIZE.0, SIZE.1),
        Command::Size(0, 10),
        Command::Orbit(0.0, 0.0),
        Command::Zoom(1.0),
        Command::Pan(0.0, 0.0),
        Command::Quality(knobs(DEFAULT_WAVELENGTHS, TARGET)),
    ];
    for command in same {
        assert!(apply(&mut engine, command).is_empty());
        assert_eq!(engine.state(), state);
        let (progress, outputs) = step(&mut engine);
        assert_eq!(progress, Progress::Idle);
        assert!(outputs.is_empty());
    }
    assert_built(&engine, &before, ZERO);
    assert_eq!(engine.counters().passes, before.passes);
}

#[test]
fn a_paint_edit_is_shown_re_shaded_then_refined_from_all_recorded_samples() {
    let (mut engine, before) = converged();
    let mut edited = design();
    edited.thickness_um += 20.0;
    apply(&mut engine, Command::Design(Box::new(edited)));
    assert_eq!(engine.state().phase, Phase::EditPending);
    let (_, outputs) = step(&mut engine);
    let shown = &updates(outputs)[0];
    assert_eq!(shown.first.reshaded, Some(0.0));
    assert!(!shown.first.coarse);
    assert_eq!((shown.first.width, shown.first.height), SIZE);
    assert_eq!(engine.state().phase, Phase::EditShown);
    assert_built(
        &engine,
        &before,
        EngineCounters {
            table_builds: 1,
            shading_builds: 1,
            reshades: 1,
            ..ZERO
        },
    );
    // The re-shade from all recorded samples, then fresh passes blend in.
    let (_, outputs) = step(&mut engine);
    assert!(updates(outputs)[0].first.reshaded.is_some());
    assert_eq!(engine.state().phase, Phase::Refining);
    assert_eq!(engine.counters().passes, before.passes);
    converge(&mut engine);
    assert_eq!(engine.counters().retraces, before.retraces);
}

/// n + 0.1 under the design's gloss reading keeps the reading but widens the
/// lobe: the planner asks for a re-shade, the back-end refuses it
/// (`ReshadeError::LobeWidened`) and the edit is traced fresh, coarse first.
#[test]
fn an_edit_that_widens_the_lobe_is_traced_fresh() {
    let (mut engine, before) = converged();
    let mut widened = design();
    match &mut widened.refractive_index {
        RefractiveIndex::Cauchy { a, .. } => *a += 0.1,
        RefractiveIndex::Table(_) => panic!("the preset's index is a Cauchy fit"),
    }
    assert_eq!(widened.gloss, design().gloss);
    apply(&mut engine, Command::Design(Box::new(widened)));
    assert_eq!(engine.state().phase, Phase::EditPending);
    let (_, outputs) = step(&mut engine);
    assert!(matches!(
        engine.last_edit_refusal(),
        Some(ReshadeError::LobeWidened { .. })
    ));
    let first = &updates(outputs)[0].first;
    assert!(first.coarse && first.reshaded.is_none());
    assert_built(&engine, &before, retraced(1, 1, 0));
}

#[test]
fn a_gloss_edit_is_traced_fresh_without_a_re_shade() {
    let mut glossier = design();
    glossier.gloss.gu += 5.0;
    let engine = restarts_coarse(Command::Design(Box::new(glossier)), retraced(1, 1, 0));
    assert!(
        engine.last_edit_refusal().is_none(),
        "no re-shade was tried"
    );
}

#[test]
fn a_model_change_rebuilds_the_shading_but_not_the_tables() {
    restarts_coarse(
        Command::Views(Views::single(ShadingModel::Phong(PhongVariant::Naive))),
        retraced(0, 1, 0),
    );
}

#[test]
fn a_scene_change_builds_its_bvh_and_a_failed_load_changes_nothing() {
    let (mut engine, before) = converged();
    let outputs = apply(&mut engine, Command::Scene(SceneSource::BuiltInCar));
    assert!(matches!(
        events(&outputs)[..],
        [EngineEvent::SceneLoaded(SceneInfo { path: None, .. })]
    ));
    step(&mut engine);
    // The tables start from scratch with a new scene, as the first design did.
    assert_built(
        &engine,
        &before,
        EngineCounters {
            bvh_builds: 1,
            table_builds: 1,
            shading_builds: 1,
            retraces: 1,
            ..ZERO
        },
    );
    converge(&mut engine);
    let before = engine.counters();
    let state = engine.state();
    let missing = PathBuf::from("/nonexistent/car.glb");
    let outputs = apply(&mut engine, Command::Scene(SceneSource::File(missing)));
    assert!(matches!(
        events(&outputs)[..],
        [EngineEvent::Failed(EngineError::Scene(_))]
    ));
    assert_eq!(engine.state(), state);
    assert_eq!(step(&mut engine).0, Progress::Idle);
    assert_built(&engine, &before, ZERO);
}

#[test]
fn a_lighting_change_builds_the_lighting_only() {
    restarts_coarse(
        Command::Lighting(Lighting::Booth(Illuminant::D65)),
        EngineCounters {
            lighting_builds: 1,
            retraces: 1,
            ..ZERO
        },
    );
}

#[test]
fn an_environment_map_is_read_once_and_keeps_its_grid() {
    let dir = std::env::temp_dir().join(format!("coatlab-engine-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let map = dir.join("sky.hdr");
    write_hdr(&map);
    let (mut engine, before) = converged();
    let outputs = apply(&mut engine, Command::OpenMap(map.clone()));
    assert!(matches!(events(&outputs)[..], [EngineEvent::MapLoaded(_)]));
    apply(&mut engine, Command::Lighting(Lighting::Studio));
    // Back to the map read last: not read again.
    apply(&mut engine, Command::Lighting(Lighting::Map(map.clone())));
    step(&mut engine);
    assert_built(
        &engine,
        &before,
        EngineCounters {
            lighting_builds: 2,
            retraces: 1,
            ..ZERO
        },
    );
    // A new wavelength count cannot rebuild a map without reading it: refused.
    let outputs = apply(&mut engine, Command::Quality(knobs(16, TARGET)));
    assert!(matches!(
        events(&outputs)[..],
        [EngineEvent::Failed(EngineError::MapKeepsGrid(32))]
    ));
    assert_eq!(engine.grid().len(), DEFAULT_WAVELENGTHS);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_camera_move_restarts_from_a_coarse_pass_and_rebuilds_nothing() {
    for command in [
        Command::Orbit(10.0, 0.0),
        Command::Zoom(0.9),
        Command::Pan(3.0, 0.0),
        Command::Size(SIZE.0 + 8, SIZE.1),
    ] {
        restarts_coarse(command, RETRACE_ONLY);
    }
}

/// A view chosen from the toolbar moves the camera as an orbit does: nothing is
/// rebuilt, the picture restarts from a coarse pass, and it is the view's camera.
#[test]
fn a_view_change_restarts_from_a_coarse_pass_and_rebuilds_nothing() {
    for view in [NamedView::Side, NamedView::Top, NamedView::CloseUp] {
        let engine = restarts_coarse(Command::View(ViewChoice::Named(view)), RETRACE_ONLY);
        let (width, height) = engine.inputs.size;
        let mut expected = engine.world.scene.framing().named(view, width, height);
        expected.set_resolution(engine.inputs.camera.width(), engine.inputs.camera.height());
        assert_eq!(engine.inputs.camera, expected, "{view}");
    }
    let free = "120,20,12,30".parse().expect("a free camera");
    restarts_coarse(Command::View(free), RETRACE_ONLY);
    // The built-in car has no cameras of its own: refused, nothing changes.
    let (mut engine, before) = converged();
    let camera = engine.inputs.camera.clone();
    let outputs = apply(&mut engine, Command::View(ViewChoice::SceneCamera(0)));
    assert!(matches!(
        events(&outputs)[..],
        [EngineEvent::Failed(EngineError::View(
            ViewError::NoSuchCamera { index: 0, count: 0 }
        ))]
    ));
    assert_eq!(engine.inputs.camera, camera);
    assert_ne!(engine.state().phase, Phase::Coarse);
    assert_built(&engine, &before, ZERO);
}

/// A new image size fits the chosen view to the new aspect (a view framed wide
/// would crop the car in a tall pane); a camera moved by hand only changes its
/// resolution.
#[test]
fn a_resize_fits_the_view_again_unless_the_camera_was_moved() {
    let tall = (SIZE.0 / 2, SIZE.1 * 2);
    let engine = restarts_coarse(Command::Size(tall.0, tall.1), RETRACE_ONLY);
    let expected = engine.world.scene.default_camera(tall.0, tall.1);
    assert_eq!(engine.inputs.camera.position(), expected.position());
    assert_eq!(engine.inputs.camera.look_at(), expected.look_at());

    let (mut engine, _) = converged();
    apply(&mut engine, Command::Orbit(30.0, 0.0));
    let moved = engine.inputs.camera.position();
    apply(&mut engine, Command::Size(tall.0, tall.1));
    assert_eq!(engine.inputs.camera.position(), moved);
}

#[test]
fn a_quality_preset_with_another_grid_rebuilds_lighting_tables_and_renders_on_it() {
    let (mut engine, before) = converged();
    apply(&mut engine, Command::Quality(knobs(16, TARGET)));
    assert_eq!(engine.grid().len(), 16);
    step(&mut engine);
    assert_built(
        &engine,
        &before,
        EngineCounters {
            lighting_builds: 1,
            table_builds: 1,
            shading_builds: 1,
            render_builds: 1,
            retraces: 1,
            ..ZERO
        },
    );
    assert_eq!(engine.first().film().channels().len(), 16);
    converge(&mut engine);
    // The sample target alone: a restart, nothing rebuilt.
    let before = engine.counters();
    apply(&mut engine, Command::Quality(knobs(16, TARGET + 2)));
    converge(&mut engine);
    assert_built(&engine, &before, RETRACE_ONLY);
    assert_eq!(engine.samples_per_pixel(), TARGET + 2);
}

#[test]
fn a_paint_material_change_rebuilds_the_shading() {
    restarts_coarse(Command::PaintMaterials(Some(vec![0])), retraced(0, 1, 0));
}

/// A click at the image centre of the default view is on the body: the pick takes
/// the body's paint off, a second click puts it back, and each reports the list;
/// a click on the sky changes nothing.
#[test]
fn a_pick_toggles_the_material_under_the_point() {
    let mut engine = engine();
    let painted = |outputs: &[Output]| {
        outputs.iter().find_map(|o| match o {
            Output::Event(EngineEvent::PaintMaterials(list)) => Some(list.clone()),
            _ => None,
        })
    };
    let body = crate::scene::car::BODY;
    assert_eq!(
        painted(&apply(&mut engine, Command::TogglePaintAt(0.5, 0.5))),
        Some(vec![])
    );
    assert_eq!(
        painted(&apply(&mut engine, Command::TogglePaintAt(0.5, 0.5))),
        Some(vec![body])
    );
    assert!(apply(&mut engine, Command::TogglePaintAt(0.01, 0.01)).is_empty());
}

/// The full-size second panes published shared: samples per pixel, the shared
/// difference's samples per pixel, and the weight of the pane's own render.
fn shared_panes(published: &[ViewsUpdate]) -> Vec<(u32, u32, f64)> {
    published
        .iter()
        .filter_map(|u| match &u.second {
            SecondUpdate::Set(Frame {
                source:
                    Some(SecondSource::Shared {
                        recorded_spp,
                        own_weight,
                    }),
                samples_per_pixel,
                coarse: false,
                ..
            }) => Some((*samples_per_pixel, *recorded_spp, *own_weight)),
            _ => None,
        })
        .collect()
}

/// A comparison shares the first view's paths and gives the second view a
/// render of its own (one render built, a pass of it for every pass of the
/// first); its pane says how much its own samples weigh, and that weight grows
/// with them (the pane converges to its own model's image).
#[test]
fn a_comparison_shares_the_first_views_paths_and_switching_it_off_drops_the_second() {
    let (mut engine, before) = converged();
    apply(
        &mut engine,
        Command::Views(Views::models(PhongVariant::BestFit)),
    );
    assert_eq!(
        engine.state(),
        State {
            phase: Phase::Coarse,
            pairing: Pairing::Fitting
        }
    );
    let published = converge(&mut engine);
    assert_eq!(engine.state().pairing, Pairing::Shared);
    assert_eq!(engine.recording_target(), COMPARE_CACHE_SAMPLES);
    let weights: Vec<(u32, f64)> = shared_panes(&published)
        .into_iter()
        .map(|(spp, _, weight)| (spp, weight))
        .collect();
    println!("own weight by spp: {weights:?}");
    let (&(last_spp, last_weight), &(_, first_weight)) = (
        weights.last().expect("shared panes"),
        weights.first().expect("shared panes"),
    );
    assert_eq!(last_spp, TARGET);
    assert!(
        first_weight < 0.5 && last_weight > first_weight,
        "{weights:?}"
    );
    let last = published.last().expect("images");
    assert!(matches!(&last.map, Some(Some(map)) if map.samples_per_pixel == TARGET));
    let done = engine.counters().since(&before);
    assert_eq!(done.second_passes, done.passes);
    assert_built(
        &engine,
        &before,
        EngineCounters {
            render_builds: 1,
            ..retraced(0, 1, 1)
        },
    );
    let before = engine.counters();
    apply(
        &mut engine,
        Command::Views(Views::single(ShadingModel::Paint)),
    );
    assert_eq!(engine.state().pairing, Pairing::Single);
    let published = converge(&mut engine);
    assert_eq!(engine.recording_target(), RESHADE_SAMPLES);
    assert!(
        published
            .iter()
            .all(|u| u.second == SecondUpdate::Clear && u.map == Some(None))
    );
    assert_built(&engine, &before, retraced(0, 1, 0));
}

/// The shared difference keeps refining after its first recording: each
/// complete recording of [`COMPARE_CACHE_SAMPLES`] is merged in and the next
/// one begins, so the panes' shared samples grow with the first view's (here
/// to 2 × 16 at 40 spp, the third recording still running, each merged the
/// pass it completes), at the memory of one recording.
#[test]
fn a_comparison_keeps_merging_new_recordings_into_its_shared_difference() {
    let (mut engine, _) = converged();
    let target = 2 * COMPARE_CACHE_SAMPLES + 8;
    apply(
        &mut engine,
        Command::Quality(knobs(DEFAULT_WAVELENGTHS, target)),
    );
    apply(
        &mut engine,
        Command::Views(Views::models(PhongVariant::BestFit)),
    );
    let published = converge(&mut engine);
    assert_eq!(engine.state().pairing, Pairing::Shared);
    let shared: Vec<(u32, u32)> = shared_panes(&published)
        .into_iter()
        .map(|(spp, recorded, _)| (spp, recorded))
        .collect();
    let at = |spp: u32| shared.iter().find(|(s, _)| *s == spp).map(|(_, r)| *r);
    let c = COMPARE_CACHE_SAMPLES;
    // While the first recording grows it is re-shaded when the map is due (at
    // 1, 2, 4, 8, … spp).
    assert_eq!(at(c - 1), Some(c / 2), "{shared:?}");
    assert_eq!(at(c + 1), Some(c), "{shared:?}");
    assert_eq!(at(2 * c), Some(2 * c), "{shared:?}");
    assert_eq!(at(target), Some(2 * c), "{shared:?}");
    assert!(
        shared.windows(2).all(|w| w[1].1 >= w[0].1),
        "the shared samples fell: {shared:?}"
    );
}

/// A converged engine told to compare the design with one of a thicker coat
/// (its lobe is the first's, so the first view's paths re-shade into it), and
/// that second design.
fn comparing_a_thicker_coat() -> (LiveEngine, PaintDesign) {
    let (mut engine, _) = converged();
    let mut second = design();
    second.thickness_um += 5.0;
    apply(
        &mut engine,
        Command::Views(Views::designs(ShadingModel::Paint, Some(&second))),
    );
    (engine, second)
}

#[test]
fn in_a_comparison_edits_are_traced_fresh_and_the_second_view_follows() {
    let (mut engine, mut second) = comparing_a_thicker_coat();
    converge(&mut engine);
    assert_eq!(engine.state().pairing, Pairing::Shared);
    // The second design edited: the second shading is built again, the first
    // view's tables are kept.
    let before = engine.counters();
    second.thickness_um += 10.0;
    apply(
        &mut engine,
        Command::Views(Views::designs(ShadingModel::Paint, Some(&second))),
    );
    converge(&mut engine);
    assert_built(&engine, &before, retraced(0, 1, 1));
    // A paint edit of the first design: no re-shade with two views.
    let before = engine.counters();
    let mut edited = design();
    edited.thickness_um += 20.0;
    apply(&mut engine, Command::Design(Box::new(edited)));
    assert_eq!(
        engine.state(),
        State {
            phase: Phase::Coarse,
            pairing: Pairing::Fitting
        }
    );
    converge(&mut engine);
    assert_built(&engine, &before, retraced(1, 1, 1));
}

/// The display (tone mapping, exposure adjustment) shows the images again at
/// once, also when converged: nothing rebuilt, no retrace, no pass; the same
/// choice again does nothing; the exposure's adjustment brightens the image.
#[test]
fn a_new_display_shows_the_images_again_without_rendering() {
    use crate::render::film::{DisplayChoice, Exposure, ToneMapping};
    let (mut engine, before) = converged();
    let brighter = DisplayChoice {
        tone_mapping: ToneMapping::REINHARD,
        exposure: Exposure::Auto { adjust_stops: 1.0 },
    };
    let old = engine.display();
    apply(&mut engine, Command::Display(brighter));
    let (progress, outputs) = step(&mut engine);
    assert_eq!(progress, Progress::Stepped);
    let shown = updates(outputs);
    assert_eq!(shown.len(), 1);
    assert_eq!(engine.display().tone_mapping, ToneMapping::REINHARD);
    assert!((engine.display().exposure_stops - old.exposure_stops - 1.0).abs() < 1e-4);
    assert_eq!(shown[0].first.samples_per_pixel, TARGET);
    let done = engine.counters().since(&before);
    assert_eq!(done, ZERO, "a display change rendered or built: {done:?}");
    assert_eq!(step(&mut engine).0, Progress::Idle);
    apply(&mut engine, Command::Display(brighter));
    assert!(engine.is_idle());
}

/// Two designs are compared as paint against Phong is: shared paths and a
/// render of the second design's own, in step.
#[test]
fn two_designs_share_paths_and_render_the_second_on_its_own() {
    let (mut engine, _) = comparing_a_thicker_coat();
    let before = engine.counters();
    let (_, pane) = converge_in_pairing(&mut engine, Pairing::Shared);
    assert!(
        matches!(pane.source, Some(SecondSource::Shared { own_weight, .. }) if own_weight > 0.0)
    );
    assert_eq!(pane.samples_per_pixel, TARGET);
    let done = engine.counters().since(&before);
    assert_eq!(done.second_passes, done.passes);
    assert!(matches!(
        engine.second_image(),
        SecondImage::Reshaded(Ok(_))
    ));
}

/// A mirror paint cannot be re-shaded into Phong: the second view is rendered
/// apart, in step with the first, and says why.
#[test]
fn a_mirror_against_phong_is_rendered_apart_in_step() {
    let (mut engine, _) = converged();
    let mut mirror = design();
    mirror.gloss.gu = 1000.0;
    apply(&mut engine, Command::Design(Box::new(mirror)));
    converge(&mut engine);
    let before = engine.counters();
    apply(
        &mut engine,
        Command::Views(Views::models(PhongVariant::Naive)),
    );
    let (first, second) = converge_in_pairing(&mut engine, Pairing::Independent);
    assert!(
        matches!(&second.source, Some(SecondSource::Independent { reason }) if reason.contains("ideal-mirror"))
    );
    assert_eq!(second.samples_per_pixel, first.samples_per_pixel);
    let done = engine.counters().since(&before);
    assert_eq!(done.second_passes, done.passes);
    assert_eq!(done.render_builds, 1);
}

/// Per-pixel sample counts of a film, row major.
fn sample_counts(film: &Film) -> Vec<u64> {
    (0..film.height())
        .flat_map(|y| (0..film.width()).map(move |x| film.sample_count(x, y)))
        .collect()
}

/// A comparison `views` refined to `samples` samples per pixel in `pairing`,
/// with the map guidance on or off: the engine, and the first view's samples
/// per pixel, which the second view's film holds too and which add up to
/// `samples` a pixel (both checked).
fn compared_counts(
    guided: bool,
    samples: u32,
    views: Views,
    pairing: Pairing,
) -> (LiveEngine, Vec<u64>) {
    let mut engine = engine();
    engine.set_map_guidance(guided);
    apply(
        &mut engine,
        Command::Quality(knobs(DEFAULT_WAVELENGTHS, samples)),
    );
    apply(&mut engine, Command::Views(views));
    converge_in_pairing(&mut engine, pairing);
    let second = engine.views.second.as_ref().expect("a second view");
    let (first, second) = (
        sample_counts(engine.first().film()),
        sample_counts(second.film()),
    );
    let total = u64::from(samples) * first.len() as u64;
    assert_eq!(first.iter().sum::<u64>(), total);
    assert_eq!(first, second, "the views' samples per pixel differ");
    (engine, first)
}

/// The fewest and the most samples of any pixel in `counts`, printed.
fn least_and_most(counts: &[u64]) -> (u64, u64) {
    let most = counts.iter().copied().max().unwrap_or(0);
    let least = counts.iter().copied().min().unwrap_or(0);
    println!("guided: {least} to {most} samples a pixel");
    (least, most)
}

/// The extra goes to every undecided pixel up to a common level, the least short
/// served whole (`guide::nearest_first`): on these small images, where much of
/// the car is undecided, the most a pixel gets is a quarter above an even share
/// of `samples` or more.
fn assert_the_undecided_got_more(most: u64, samples: u32) {
    assert!(
        4 * most >= 5 * u64::from(samples),
        "the undecided pixels got at most {most} samples"
    );
}

/// Rendered apart (a glossier design against a satin one: the second lobe is
/// wider), both views spend more samples where the ΔE00 map is undecided and
/// take the same counts per pixel; with the guidance off, or before the first
/// view's recording is complete, every pixel gets the same samples.
#[test]
fn views_rendered_apart_spend_their_samples_where_the_map_is_undecided() {
    const SAMPLES: u32 = 40;
    let mut satin = design();
    satin.gloss.gu = 60.0;
    let views = Views::designs(ShadingModel::Paint, Some(&satin));
    let counts = |guided| compared_counts(guided, SAMPLES, views.clone(), Pairing::Independent).1;
    let even = counts(false);
    assert!(even.iter().all(|&n| n == u64::from(SAMPLES)));
    let (least, most) = least_and_most(&counts(true));
    assert_the_undecided_got_more(most, SAMPLES);
    assert!(
        least >= u64::from(COMPARE_CACHE_SAMPLES),
        "a pixel got {least} samples: fewer than the uniform recording"
    );
}

/// Shared (paint against Phong), both views' passes and the first view's
/// recordings spend more samples where the ΔE00 map of the panes is undecided:
/// the views take the same counts per pixel, and the shared difference holds
/// more recorded samples of a pixel the more samples its films have; with the
/// guidance off, every pixel gets the same samples and the same recorded ones.
#[test]
fn shared_views_and_their_recordings_spend_their_samples_where_the_map_is_undecided() {
    const SAMPLES: u32 = 64;
    let counts = |guided| {
        let views = Views::models(PhongVariant::Naive);
        let (engine, first) = compared_counts(guided, SAMPLES, views, Pairing::Shared);
        let (difference, _) = engine
            .views
            .difference
            .as_ref()
            .expect("a shared difference");
        let recorded: Vec<u64> = difference.counts().iter().map(|&k| u64::from(k)).collect();
        (first, recorded)
    };
    let (even, even_recorded) = counts(false);
    assert!(even.iter().all(|&n| n == u64::from(SAMPLES)));
    assert!(
        even_recorded.iter().all(|&k| k == even_recorded[0]),
        "even passes recorded unevenly"
    );
    let (guided, recorded) = counts(true);
    let (least, most) = least_and_most(&guided);
    assert_the_undecided_got_more(most, SAMPLES);
    // Recorded samples follow the film's: the pixels with the most samples hold
    // more recorded ones than those with the fewest.
    let recorded_where = |n: u64| {
        let of: Vec<u64> = guided
            .iter()
            .zip(&recorded)
            .filter(|&(&g, _)| g == n)
            .map(|(_, &k)| k)
            .collect();
        of.iter().sum::<u64>() as f64 / of.len() as f64
    };
    let (at_most, at_least) = (recorded_where(most), recorded_where(least));
    println!("recorded: {at_least:.1} where least sampled, {at_most:.1} where most");
    assert!(
        at_most > 1.5 * at_least,
        "recorded {at_most:.1} samples where the films have {most}, {at_least:.1} where {least}"
    );
}

/// Two designs whose gloss lobes differ are rendered apart, a sharper second
/// lobe beyond [`SHARED_LOBE_NARROWING`] and any wider one, and say why; a
/// second lobe a little sharper, and Phong, naive or best fit, whose lobe is
/// the paint's, are shared.
#[test]
fn designs_whose_lobes_differ_are_rendered_apart_and_say_why() {
    let at = |change: f64| {
        let mut d = design();
        d.gloss.gu += change;
        d
    };
    let lobe = |d: &PaintDesign| {
        d.model(WavelengthGrid::visible(8).expect("grid"))
            .expect("model")
            .spectral()
            .lobe_exponent()
            .expect("a lobe")
    };
    // 8 GU less: the preset's lobe more than SHARED_LOBE_NARROWING sharper than
    // this one's; 0.5 GU less: within it.
    assert!(lobe(&design()) / lobe(&at(-8.0)) - 1.0 > SHARED_LOBE_NARROWING);
    assert!(lobe(&design()) / lobe(&at(-0.5)) - 1.0 < SHARED_LOBE_NARROWING);
    let compare = |first: PaintDesign, second: PaintDesign, narrowing: Option<f32>| {
        let (mut engine, _) = converged();
        if let Some(narrowing) = narrowing {
            engine.set_shared_lobe_narrowing(narrowing);
        }
        apply(&mut engine, Command::Design(Box::new(first)));
        apply(
            &mut engine,
            Command::Views(Views::designs(ShadingModel::Paint, Some(&second))),
        );
        engine
    };
    let apart = |mut engine: LiveEngine| {
        let (_, pane) = converge_in_pairing(&mut engine, Pairing::Independent);
        assert!(
            matches!(&pane.source, Some(SecondSource::Independent { reason }) if reason.contains("gloss lobes differ")),
            "{:?}",
            pane.source
        );
    };
    // A much sharper second lobe, and a wider one.
    apart(compare(at(-8.0), design(), None));
    apart(compare(design(), at(-0.5), None));
    // A little sharper: shared; much sharper, with any narrowing allowed (for
    // measuring): shared too.
    converge_in_pairing(&mut compare(at(-0.5), design(), None), Pairing::Shared);
    converge_in_pairing(
        &mut compare(at(-8.0), design(), Some(f32::INFINITY)),
        Pairing::Shared,
    );
    for variant in [PhongVariant::BestFit, PhongVariant::Naive] {
        let (mut engine, _) = converged();
        apply(&mut engine, Command::Views(Views::models(variant)));
        converge_in_pairing(&mut engine, Pairing::Shared);
    }
}

#[test]
fn the_planner_merges_a_batch_into_one_set_of_actions() {
    let refining = State {
        phase: Phase::Refining,
        pairing: Pairing::Single,
    };
    let (state, edit) = transition(refining, Change::Paint);
    assert_eq!(state.phase, Phase::EditPending);
    assert_eq!(edit.restart, Restart::Reshade);
    // A camera move in the same batch turns the re-shade into a retrace.
    let (state, moved) = transition(state, Change::Camera);
    let merged = edit.merge(moved);
    assert_eq!(merged.restart, Restart::Retrace);
    assert_eq!(merged.tables, Tables::Update);
    assert_eq!(settle(state, merged).phase, Phase::Coarse);
    // An edit during the coarse pass is traced fresh.
    let (_, coarse_edit) = transition(State::START, Change::Paint);
    assert_eq!(coarse_edit.restart, Restart::Retrace);
    // Second view on then off in one batch: dropped; off then on: rebuilt.
    let (_, on) = transition(refining, Change::Views { second: true });
    let (_, off) = transition(refining, Change::Views { second: false });
    assert_eq!(on.merge(off).second, Second::Drop);
    assert_eq!(off.merge(on).second, Second::Rebuild);
    assert_eq!(
        transition(refining, Change::Nothing),
        (refining, Actions::NONE)
    );
    // Outcomes.
    let pending = State {
        phase: Phase::EditPending,
        ..refining
    };
    assert_eq!(
        advance(pending, Outcome::EditRefused).0.phase,
        Phase::Coarse
    );
    assert_eq!(
        advance(pending, Outcome::EditReshaded).0.phase,
        Phase::EditShown
    );
}

/// The engine renders the same film as the progressive renderer driven by hand
/// (same scene, lighting, shading, camera and seed): it adds no work per
/// sample. Prints the time of both, per pass.
#[test]
fn the_engine_renders_the_same_bits_as_the_renderer_alone_at_the_same_speed() {
    const PASSES: u32 = 8;
    let mut engine = engine();
    apply(
        &mut engine,
        Command::Quality(knobs(DEFAULT_WAVELENGTHS, PASSES)),
    );
    converge(&mut engine);
    let mut camera = engine.inputs.camera.clone();
    camera.set_resolution(SIZE.0, SIZE.1);
    let mut alone = ProgressiveRender::new(
        engine.world.scene.clone(),
        engine.world.environment.clone(),
        engine.first().shading().clone(),
        camera,
        RenderSettings::default(),
    )
    .expect("a render");
    alone.set_path_cache_samples(RESHADE_SAMPLES);
    for _ in 0..PASSES {
        alone.render_pass(1);
    }
    assert_eq!(
        engine.first().film().to_display(&Default::default()),
        alone.film().to_display(&Default::default())
    );
    assert_films_equal(engine.first().film(), alone.film());
    // Speed per sample: the passes' own rate through the engine (as its frames
    // report it) and alone, interleaved, the coarse passes left out.
    let (mut through, mut direct) = (Vec::new(), Vec::new());
    for round in 0..3 {
        apply(&mut engine, Command::Orbit(1.0 + round as f32, 0.0));
        through.extend(
            converge(&mut engine)
                .iter()
                .filter(|u| !u.first.coarse)
                .map(|u| u.first.samples_per_second),
        );
        alone.restart();
        for _ in 0..PASSES {
            direct.push(alone.render_pass(1).samples_per_second());
        }
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (through, direct) = (median(through), median(direct));
    println!(
        "passes at {}×{}: median {:.0} k samples/s through the engine, {:.0} k alone (ratio {:.3})",
        SIZE.0,
        SIZE.1,
        through / 1e3,
        direct / 1e3,
        through / direct
    );
}

fn assert_films_equal(a: &Film, b: &Film) {
    assert_eq!((a.width(), a.height()), (b.width(), b.height()));
    for y in 0..a.height() {
        for x in 0..a.width() {
            let (ma, mb) = (a.mean_xyz(x, y), b.mean_xyz(x, y));
            assert_eq!(
                [ma.x, ma.y, ma.z].map(f64::to_bits),
                [mb.x, mb.y, mb.z].map(f64::to_bits),
                "pixel ({x}, {y})"
            );
        }
    }
}

/// A back-end that counts what the engine asks of it, around the CPU's.
struct Counting {
    cpu: CpuBackend,
    passes: Arc<AtomicU64>,
    views: Arc<AtomicU64>,
}

struct CountingView {
    render: ProgressiveRender,
    passes: Arc<AtomicU64>,
}

impl RenderBackend for Counting {
    type View = CountingView;

    fn view(&self, setup: ViewSetup) -> Result<CountingView, RenderError> {
        self.views.fetch_add(1, Ordering::Relaxed);
        Ok(CountingView {
            render: self.cpu.view(setup)?,
            passes: self.passes.clone(),
        })
    }
}

impl BackendView for CountingView {
    fn set_camera(&mut self, camera: Camera) -> Result<(), RenderError> {
        BackendView::set_camera(&mut self.render, camera)
    }
    fn set_shading(&mut self, shading: Arc<Shading>) -> Result<(), RenderError> {
        BackendView::set_shading(&mut self.render, shading)
    }
    fn set_environment(&mut self, environment: Arc<Environment>) -> Result<(), RenderError> {
        BackendView::set_environment(&mut self.render, environment)
    }
    fn set_scene(
        &mut self,
        scene: Arc<RenderScene>,
        shading: Arc<Shading>,
    ) -> Result<(), RenderError> {
        BackendView::set_scene(&mut self.render, scene, shading)
    }
    fn set_path_cache_samples(&mut self, samples: u32) {
        BackendView::set_path_cache_samples(&mut self.render, samples);
    }
    fn edit_shading(&mut self, shading: Arc<Shading>) -> Result<EditOutcome, RenderError> {
        BackendView::edit_shading(&mut self.render, shading)
    }
    fn refine_edit(&mut self) -> bool {
        BackendView::refine_edit(&mut self.render)
    }
    fn is_reshaded(&self) -> bool {
        BackendView::is_reshaded(&self.render)
    }
    fn edit_estimate(&self) -> Option<(Reshaded, f64)> {
        BackendView::edit_estimate(&self.render)
    }
    fn render_pass(&mut self, cancel: &AtomicBool) -> Option<PassStats> {
        self.passes.fetch_add(1, Ordering::Relaxed);
        BackendView::render_pass(&mut self.render, cancel)
    }
    fn reshade_recorded(&self, shading: &Shading) -> Result<Reshaded, ReshadeError> {
        BackendView::reshade_recorded(&self.render, shading)
    }
    fn recorded_samples(&self) -> u32 {
        BackendView::recorded_samples(&self.render)
    }
    fn recorded_per_pixel(&self) -> Vec<u32> {
        BackendView::recorded_per_pixel(&self.render)
    }
    fn recording_complete(&self) -> bool {
        BackendView::recording_complete(&self.render)
    }
    fn record_next_samples(&mut self) -> bool {
        BackendView::record_next_samples(&mut self.render)
    }
    fn set_pass_weights(&mut self, weights: Option<Vec<f32>>) {
        BackendView::set_pass_weights(&mut self.render, weights);
    }
    fn film(&self) -> &Film {
        BackendView::film(&self.render)
    }
    fn samples_per_pixel(&self) -> u32 {
        BackendView::samples_per_pixel(&self.render)
    }
    fn resolution(&self) -> (u32, u32) {
        BackendView::resolution(&self.render)
    }
    fn shading(&self) -> &Arc<Shading> {
        BackendView::shading(&self.render)
    }
    fn noise_estimate(
        &self,
        display: &crate::render::film::DisplaySettings,
    ) -> Option<crate::render::film::NoiseEstimate> {
        BackendView::noise_estimate(&self.render, display)
    }
}

#[test]
fn every_render_and_pass_goes_through_the_back_end() {
    let passes = Arc::new(AtomicU64::new(0));
    let views = Arc::new(AtomicU64::new(0));
    let backend = Counting {
        cpu: CpuBackend::default(),
        passes: passes.clone(),
        views: views.clone(),
    };
    let mut engine = LiveEngine::new(backend, design(), Arc::new(|| {})).expect("start");
    let never = AtomicBool::new(false);
    engine.apply(Command::Size(SIZE.0, SIZE.1), &mut |_| {});
    engine.apply(Command::Quality(knobs(24, TARGET)), &mut |_| {});
    while engine.step(&never, &mut |_| {}) != Progress::Idle {}
    let counters = engine.counters();
    assert_eq!(passes.load(Ordering::Relaxed), counters.passes);
    assert_eq!(views.load(Ordering::Relaxed), counters.render_builds);
    assert_eq!(
        counters.render_builds, 2,
        "the first render, then one on 24 λ"
    );
}

/// On its thread: images stamped with the last command they show, and a
/// command that changes nothing shown at once by the images already there.
#[test]
fn the_render_thread_stamps_images_with_the_commands_they_show() {
    let mut thread = EngineThread::spawn(CpuBackend::default(), design(), ThreadHooks::default());
    thread.send(Command::Size(SIZE.0, SIZE.1));
    let epoch = thread.send(Command::Quality(knobs(DEFAULT_WAVELENGTHS, TARGET)));
    let shown = |thread: &EngineThread| {
        let mailbox = thread.mailbox();
        mailbox.frames[0]
            .as_ref()
            .map(|f| (f.epoch, f.samples_per_pixel, f.coarse))
    };
    let wait = |thread: &EngineThread, done: &dyn Fn(Option<(u64, u32, bool)>) -> bool| {
        let start = Instant::now();
        while !done(shown(thread)) {
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "{:?}",
                shown(thread)
            );
            std::thread::sleep(Duration::from_millis(5));
        }
    };
    wait(&thread, &|s| s == Some((epoch, TARGET, false)));
    assert!(thread.mailbox().scene.is_some());
    let epoch = thread.send(Command::Zoom(1.0));
    wait(&thread, &|s| s == Some((epoch, TARGET, false)));
    let epoch = thread.send(Command::Orbit(5.0, 0.0));
    wait(&thread, &|s| {
        s.is_some_and(|(e, spp, _)| e == epoch && spp == TARGET)
    });
}

/// Side by side, each pane of a comparison is tall (half the preview's width):
/// a new size frames the default view again in that aspect, and both views
/// render through that camera, so each pane holds the whole car (the framing
/// of a tall frame is checked on every test car in `tests/views.rs`).
#[test]
fn tall_comparison_panes_are_framed_in_their_own_aspect() {
    let mut engine = engine();
    apply(
        &mut engine,
        Command::Views(Views::models(PhongVariant::Naive)),
    );
    converge(&mut engine);
    for (width, height) in [(32, 40), (20, 40)] {
        apply(&mut engine, Command::Size(width, height));
        converge(&mut engine);
        let framed = engine
            .world
            .scene
            .framing()
            .camera(&ViewChoice::default(), width, height)
            .expect("the default view");
        assert_eq!(engine.inputs.camera, framed, "{width}x{height}");
        let second = engine.views.second.as_ref().expect("a second view");
        for view in [&engine.views.first, second] {
            assert_eq!(view.camera(), &framed, "{width}x{height}");
        }
    }
}
