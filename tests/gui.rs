//! The designer's window driven as a person uses it, headless, with egui_kittest:
//! widgets are found by the names assistive technology sees.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use coatlab_app::gui::dialogs::{
    DialogOutcome, DialogRequest, NativeFileDialog, native_dialog_availability,
};
use coatlab_app::gui::paint_materials::{material_label, visible_label};
use coatlab_app::gui::storage::Storage;
use coatlab_app::gui::{AppOptions, CoatlabApp, app::Tab};
use coatlab_core::render::lighting::Lighting;
use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};

mod common;
use common::{ExrImage, assert_rgb_f32, read_exr};

#[path = "common/harness.rs"]
mod harness;
use harness::{app_harness, options};

#[path = "../crates/coatlab-core/tests/support/hdr_fixture.rs"]
mod hdr_fixture;
use hdr_fixture::write_hdr;

#[path = "../crates/coatlab-core/tests/support/gltf_testdata.rs"]
mod gltf_testdata;

/// The Instruments tab's target from measurement files, and *Fit to target*.
#[path = "gui/target.rs"]
mod target;

fn app() -> CoatlabApp {
    CoatlabApp::new(options(false))
}

fn harness(app: CoatlabApp) -> Harness<'static, CoatlabApp> {
    let mut h = app_harness(egui::vec2(1400.0, 900.0), false, app);
    h.run();
    h
}

/// Opens `target` as the Instruments tab's target; ΔE00 per angle to it.
fn delta_e_to_target(h: &mut Harness<'static, CoatlabApp>, target: &Path) -> Vec<f64> {
    h.state_mut().open_target(target);
    h.run();
    h.state()
        .analysis()
        .and_then(|a| a.delta_e.clone())
        .expect("ΔE00 per angle")
}

/// Ctrl+Z, and the frame that takes it.
fn undo_key(h: &mut Harness<'static, CoatlabApp>) {
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run();
}

/// Ctrl+Shift+Z, and the frame that takes it.
fn redo_key(h: &mut Harness<'static, CoatlabApp>) {
    h.key_press_modifiers(
        egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
        egui::Key::Z,
    );
    h.run();
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("coatlab-gui-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

#[test]
fn moving_the_thickness_slider_changes_the_design_and_undo_restores_it() {
    let mut h = harness(app());
    let before = h.state().design().clone();
    assert_eq!(before.thickness_um, 45.0);
    h.get_by_role_and_label(Role::Slider, "Thickness h (µm)")
        .set_value_accesskit(60.0);
    h.run();
    assert_eq!(h.state().design().thickness_um, 60.0);
    assert!(h.state().is_dirty());

    undo_key(&mut h);
    assert_eq!(h.state().design(), &before, "Ctrl+Z restores the design");

    redo_key(&mut h);
    assert_eq!(h.state().design().thickness_um, 60.0, "Ctrl+Shift+Z redoes");
}

#[test]
fn dragging_a_control_point_of_rho_moves_the_curve_there_and_is_undoable() {
    let mut h = harness(app());
    let before = h.state().design().albedo.value_at_nm(550.0);
    h.get_by_role_and_label(Role::Slider, "ρ at 550 nm")
        .set_value_accesskit(0.5);
    h.run();
    let after = h.state().design().albedo.value_at_nm(550.0);
    assert!((after - 0.5).abs() < 1e-9, "{before} -> {after}");
    // 100 nm away nothing moved.
    assert_eq!(
        h.state().design().albedo.value_at_nm(650.0),
        coatlab_core::design::presets::all()
            .into_iter()
            .find(|p| p.slug == "signal-red")
            .map(|p| p.design.albedo.value_at_nm(650.0))
            .unwrap_or(f64::NAN)
    );
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run();
    assert_eq!(h.state().design().albedo.value_at_nm(550.0), before);
}

#[test]
fn the_gloss_slider_cannot_leave_what_the_coat_can_read() {
    let mut h = harness(app());
    h.get_by_role_and_label(Role::Slider, "Gloss g (GU)")
        .set_value_accesskit(1000.0);
    h.run();
    let gu = h.state().design().gloss.gu;
    assert!(gu < 100.0, "clamped to the mirror's reading, got {gu}");
    assert!(h.state().design().validate().is_ok());
}

#[test]
fn a_bad_design_file_shows_an_error_and_loses_nothing() {
    let dir = temp_dir("bad");
    let bad = dir.join("broken.toml");
    std::fs::write(&bad, "format = \"coatlab-paint-design\"\nversion = 1\nname = \"x\"\n[clear_coat]\nthickness_um = -3\n")
        .expect("write");
    let mut h = harness(app());
    h.get_by_role_and_label(Role::Slider, "Thickness h (µm)")
        .set_value_accesskit(52.0);
    h.run();
    let edited = h.state().design().clone();

    h.state_mut().open_design(&bad);
    h.run();
    assert_eq!(
        h.state().design(),
        &edited,
        "the current design is untouched"
    );
    assert!(h.state().is_dirty(), "and still counts as unsaved");
    h.get_by_label_contains("Could not open the design");
    let _ = std::fs::remove_dir_all(dir);
}

#[derive(Debug)]
struct Dropped(PathBuf);

impl egui::DroppedFile for Dropped {
    fn path(&self) -> &Path {
        &self.0
    }
    fn bytes(&self) -> Result<Vec<u8>, String> {
        std::fs::read(&self.0).map_err(|e| e.to_string())
    }
}

#[test]
fn dropping_a_design_file_opens_it_and_lists_it_as_recent() {
    let dir = temp_dir("drop");
    let file = dir.join("blue.toml");
    let blue = coatlab_core::design::presets::all()
        .into_iter()
        .find(|p| p.slug == "deep-blue")
        .map(|p| p.design)
        .expect("deep blue preset");
    blue.save(&file).expect("save");
    let mut h = harness(CoatlabApp::new(AppOptions {
        storage: Storage::in_dir(dir.join("state")),
        open: None,
        preview: false,
    }));
    h.input_mut()
        .dropped_files
        .push(Arc::new(Dropped(file.clone())));
    h.run();
    assert_eq!(h.state().design(), &blue);
    assert!(!h.state().is_dirty());
    assert_eq!(h.state().recent_files().len(), 1);
    let _ = std::fs::remove_dir_all(dir);
}

/// An unsaved edit left by an exit that did not save is offered and recovered (the
/// exit's own autosave). The periodic autosave and a real crash (SIGKILL) are
/// tests/gui_crash.rs.
#[test]
fn save_then_reopen_round_trips_and_an_unsaved_edit_is_recovered_after_an_unsaved_exit() {
    let dir = temp_dir("save");
    let state = dir.join("state");
    let file = dir.join("mine.toml");
    let mut h = harness(CoatlabApp::new(AppOptions {
        storage: Storage::in_dir(&state),
        open: None,
        preview: false,
    }));
    h.get_by_role_and_label(Role::Slider, "Thickness h (µm)")
        .set_value_accesskit(38.0);
    h.run();
    h.state_mut().save_design_as(&file);
    h.run();
    assert!(!h.state().is_dirty());
    assert_eq!(
        coatlab_core::design::PaintDesign::load(&file)
            .expect("saved")
            .thickness_um,
        38.0
    );

    // An unsaved edit, then the process ends without a clean save.
    h.get_by_role_and_label(Role::Slider, "Thickness h (µm)")
        .set_value_accesskit(70.0);
    h.run();
    h.state_mut().shutdown();
    drop(h);

    let mut h = harness(CoatlabApp::new(AppOptions {
        storage: Storage::in_dir(&state),
        open: None,
        preview: false,
    }));
    assert!(h.state().pending_recovery().is_some());
    h.get_by_label("Recover").click();
    h.run();
    assert_eq!(h.state().design().thickness_um, 70.0);
    assert_eq!(h.state().path(), Some(file.as_path()));
    assert!(h.state().is_dirty(), "recovered changes are not yet saved");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn the_instruments_panel_shows_delta_e_to_a_target_and_exports_it() {
    let dir = temp_dir("instruments");
    let mut app = app();
    app.set_tab(Tab::Instruments);
    let mut h = harness(app);
    h.get_by_role_and_label(Role::ComboBox, "Target");
    h.get_by_label("15°");
    assert!(h.query_by_label("ΔE00").is_some());
    let target_file = dir.join("target.toml");
    let mut target = h.state().design().clone();
    target.thickness_um = 45.0;
    target.albedo = coatlab_core::design::presets::all()[1]
        .design
        .albedo
        .clone();
    target.save(&target_file).expect("save");
    let de = delta_e_to_target(&mut h, &target_file);
    assert_eq!(de.len(), 5);
    // Another pigment: clearly visible at every angle, and each value on screen.
    for d in &de {
        assert!(*d > 1.0, "ΔE00 per angle {de:?}");
        // In the table (and at 45° again beside the D65 swatch).
        assert!(
            h.get_all_by_label(&format!("{d:.2}")).next().is_some(),
            "{d:.2} is not shown"
        );
    }
    let csv = dir.join("readings.csv");
    h.state_mut().export_measurement(&csv);
    let text = std::fs::read_to_string(&csv).expect("exported");
    assert!(text.starts_with("kind,angle_deg,detector_deg,L,a,b,dE00"));
    assert_eq!(text.lines().count(), 9);
    let exported: Vec<f64> = text
        .lines()
        .filter(|l| l.starts_with("colour,"))
        .map(|l| {
            l.split(',')
                .nth(6)
                .expect("dE00")
                .parse()
                .expect("a number")
        })
        .collect();
    assert_eq!(exported, de, "the exported dE00 column");

    // The design itself as the target: no difference at any angle.
    let same = dir.join("same.toml");
    h.state().design().save(&same).expect("save");
    let de = delta_e_to_target(&mut h, &same);
    assert_eq!(de, vec![0.0; 5]);
    assert!(h.get_all_by_label("0.00").count() >= 5);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn an_invalid_cauchy_pair_is_explained_where_it_is_entered() {
    let mut h = harness(app());
    h.get_by_role_and_label(Role::Slider, "Cauchy A")
        .set_value_accesskit(1.0);
    h.get_by_role_and_label(Role::Slider, "Cauchy B (µm²)")
        .set_value_accesskit(-0.02);
    h.run();
    assert!(h.state().design().validate().is_err());
    h.get_by_label_contains("Invalid: clear_coat.refractive_index");
    assert!(h.state().analysis().is_none());
}

/// Rendered snapshots of the whole window on Mesa's software Vulkan (lavapipe).
#[test]
fn snapshot_of_the_designer() {
    let mut h = app_harness(egui::vec2(1400.0, 900.0), true, app());
    h.run();
    h.snapshot("designer_plots");
    h.state_mut().set_tab(Tab::Instruments);
    h.run();
    h.snapshot("designer_instruments");
}

/// The committed quality preset that `rank` puts first.
fn committed_preset<K: Ord>(
    rank: impl Fn(&coatlab_app::gui::quality::QualityPreset) -> K,
) -> &'static coatlab_app::gui::quality::QualityPreset {
    coatlab_app::gui::quality::QualityPresets::embedded()
        .expect("the committed presets parse")
        .presets
        .iter()
        .min_by_key(|p| rank(p))
        .expect("at least one preset")
}

/// The window with the preview image, on lavapipe. A render is deterministic for
/// its seed whatever the thread count, so the preview is stopped at a fixed sample
/// count (the coarsest quality preset's) and is then the same picture on every run;
/// the status line, which holds samples per second and the change latency (times),
/// is painted over before the comparison and checked as text instead.
#[test]
fn snapshot_of_the_preview_at_a_fixed_sample_count() {
    let chosen =
        committed_preset(|p| (p.samples_per_pixel, std::cmp::Reverse(p.resolution_divisor)));
    let mut h = preview_harness(true);
    steps(&mut h, 2);
    choose_quality_preset(&mut h, &chosen.name);
    assert_eq!(preview(h.state()).quality().knobs, chosen.knobs());
    wait_until(&mut h, "the preset's image, converged", |app| {
        app.preview_status()
            .is_some_and(|s| !s.coarse && s.samples_per_pixel >= chosen.samples_per_pixel)
    });
    // Away from every widget (no hover highlight, no tooltip), then let the render
    // thread go idle and every animation end.
    h.hover_at(egui::pos2(1490.0, 930.0));
    steps(&mut h, 5);
    h.run();
    let status = h.state().preview_status().cloned().expect("a frame");
    assert_eq!(status.samples_per_pixel, chosen.samples_per_pixel);
    let line = h.get_by_label_contains("k samples/s");
    let node = line.accesskit_node();
    let text = node.label().or_else(|| node.value()).unwrap_or_default();
    assert!(
        text.starts_with(&format!("{} spp  ·  ", chosen.samples_per_pixel))
            && text.contains(&format!("{}×{}", status.width, status.height)),
        "status line: {text}"
    );
    let line = line.rect();
    let mut image = h.render().expect("render the window");
    // The whole row of the status line, across the central panel.
    let (x0, x1) = (line.left().floor() as u32, image.width());
    let (y0, y1) = (line.top().floor() as u32, line.bottom().ceil() as u32);
    for y in y0..y1.min(image.height()) {
        for x in x0..x1 {
            image.get_pixel_mut(x, y).0 = [255, 0, 255, 255];
        }
    }
    egui_kittest::image_snapshot(&image, "designer_preview");
}

/// The live preview renders off the UI thread and restarts on a design change.
#[test]
fn the_preview_accumulates_and_restarts_when_the_design_changes() {
    let mut h = app_harness(
        egui::vec2(1000.0, 700.0),
        false,
        CoatlabApp::new(options(true)),
    );
    let spp = |h: &Harness<'static, CoatlabApp>| {
        h.state()
            .preview_status()
            .map(|s| (s.samples_per_pixel, s.coarse))
    };
    let wait_for = |h: &mut Harness<'static, CoatlabApp>,
                    done: &dyn Fn(Option<(u32, bool)>) -> bool| {
        let start = std::time::Instant::now();
        while !done(spp(h)) {
            assert!(
                start.elapsed().as_secs() < 120,
                "the preview did not progress: {:?}",
                spp(h)
            );
            h.step();
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    };
    wait_for(&mut h, &|s| s.is_some_and(|(n, coarse)| n >= 3 && !coarse));
    // A gloss edit cannot be re-shaded: accumulation restarts with a coarse pass.
    h.get_by_role_and_label(Role::Slider, "Gloss g (GU)")
        .set_value_accesskit(80.0);
    wait_for(&mut h, &|s| s.is_some_and(|(_, coarse)| coarse));
}

/// A paint edit once the preview has its path cache: the next image is the new
/// design at full resolution at once, re-shaded from the old samples (the status
/// line says so), then fresh samples of the new design take over; a gloss edit
/// is traced fresh (coarse first).
#[test]
fn a_paint_edit_is_shown_re_shaded_at_full_resolution_then_refined() {
    let mut h = preview_harness(false);
    let full = |app: &CoatlabApp| {
        app.preview_status()
            .is_some_and(|s| !s.coarse && s.reshaded.is_none() && s.samples_per_pixel >= 6)
    };
    wait_until(&mut h, "the cache to fill", full);
    let before = h.state().preview_status().cloned().expect("status");
    h.get_by_role_and_label(Role::Slider, "Thickness h (µm)")
        .set_value_accesskit(80.0);
    wait_until(&mut h, "the edit to show", |app| {
        app.preview_status().is_some_and(|s| s.epoch > before.epoch)
    });
    let edited = h.state().preview_status().cloned().expect("status");
    assert_eq!(edited.reshaded, Some(0.0), "{edited:?}");
    assert!(!edited.coarse);
    assert_eq!((edited.width, edited.height), (before.width, before.height));
    assert_eq!(edited.samples_per_pixel, 0);
    h.step();
    assert!(
        h.query_by_label_contains("re-shaded edit").is_some(),
        "the status line does not say the image is re-shaded"
    );
    // Fresh samples of the new design join in.
    wait_until(&mut h, "fresh samples in the blend", |app| {
        app.preview_status()
            .is_some_and(|s| s.samples_per_pixel >= 2 && s.reshaded.is_some_and(|w| w > 0.0))
    });
    // The gloss cannot be re-weighted well: traced fresh, coarse first.
    let epoch = h.state().preview_status().map(|s| s.epoch).unwrap_or(0);
    h.get_by_role_and_label(Role::Slider, "Gloss g (GU)")
        .set_value_accesskit(80.0);
    wait_until(&mut h, "the gloss edit", |app| {
        app.preview_status().is_some_and(|s| s.epoch > epoch)
    });
    let gloss = h.state().preview_status().cloned().expect("status");
    assert!(gloss.coarse && gloss.reshaded.is_none(), "{gloss:?}");
}

// ---------------------------------------------------------------------------
// The preview's comparisons, scenes, lighting maps and export, driven through the
// window with the render thread running.

/// The window at its default size with the live preview on.
fn preview_harness(wgpu: bool) -> Harness<'static, CoatlabApp> {
    app_harness(
        egui::vec2(1500.0, 940.0),
        wgpu,
        CoatlabApp::new(options(true)),
    )
}

/// Steps frames (the render thread keeps asking for repaints, so `run` would not
/// settle) until `done` holds; fails after two minutes with `what`.
fn wait_until(
    h: &mut Harness<'static, CoatlabApp>,
    what: &str,
    done: impl Fn(&CoatlabApp) -> bool,
) {
    let start = std::time::Instant::now();
    while !done(h.state()) {
        assert!(
            start.elapsed().as_secs() < 120,
            "timed out waiting for {what}; notices: {:?}",
            h.state().notices()
        );
        h.step();
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}

/// Types `path` into the open in-app browser's file name field (its last text
/// field, which takes an absolute path) and presses Open.
fn open_in_browser(h: &mut Harness<'static, CoatlabApp>, path: &Path) {
    h.get_all_by_role(Role::TextInput)
        .last()
        .expect("file name field")
        .focus();
    steps(h, 1);
    h.get_all_by_role(Role::TextInput)
        .last()
        .expect("file name field")
        .type_text(&path.display().to_string());
    steps(h, 1);
    h.get_by_label("Open").click();
}

/// Picks the quality preset `name` from the preview's Quality menu.
fn choose_quality_preset(h: &mut Harness<'static, CoatlabApp>, name: &str) {
    h.get_by_role_and_label(Role::ComboBox, "Quality").click();
    steps(h, 2);
    h.get_by_label(name).click();
    steps(h, 2);
}

/// Clicks `label`'s box in the paint list, opening the list first if it is shut.
fn click_in_paint_list(h: &mut Harness<'static, CoatlabApp>, label: &str) {
    if h.query_by_label(label).is_none() {
        h.get_by_label("Paint materials").click();
        steps(h, 2);
    }
    h.get_by_label(label).click();
    steps(h, 2);
}

fn steps(h: &mut Harness<'static, CoatlabApp>, n: usize) {
    for _ in 0..n {
        h.step();
    }
}

fn has_notice(app: &CoatlabApp, is_error: bool, text: &str) -> bool {
    app.notices()
        .iter()
        .any(|n| n.is_error == is_error && n.text.contains(text))
}

/// The scene the preview shows, once loaded.
fn scene_shown(app: &CoatlabApp) -> Option<&coatlab_core::engine::SceneInfo> {
    app.preview().and_then(|p| p.scene())
}

fn preview(app: &CoatlabApp) -> &coatlab_app::gui::preview::Preview {
    app.preview().expect("the preview runs")
}

/// Paint against Phong, laid out as `layout`.
fn compare_models(
    h: &mut Harness<'static, CoatlabApp>,
    layout: coatlab_app::gui::compare::CompareLayout,
) {
    h.state_mut()
        .preview_mut()
        .expect("preview")
        .set_compare(coatlab_app::gui::compare::CompareMode::Models, layout);
}

/// Both views refined past the coarse pass, on the same change, with a ΔE00 map of
/// at least `spp` samples per pixel.
fn compared(app: &CoatlabApp, spp: u32) -> bool {
    let Some(p) = app.preview() else { return false };
    match (p.status(), p.second_status(), p.delta_e_map()) {
        (Some(a), Some(b), Some(map)) => {
            !a.coarse
                && a.epoch == b.epoch
                && (a.width, a.height) == (b.width, b.height)
                && map.samples_per_pixel >= spp
                && (map.width, map.height) == (a.width, a.height)
        }
        _ => false,
    }
}

/// Share of the map's pixels where the two views agree exactly: the backdrop seen
/// directly, which only the same camera and the same random numbers make equal.
fn exact_share(map: &coatlab_app::gui::compare::DeltaEMap) -> f64 {
    map.values.iter().filter(|&&v| v == 0.0).count() as f64 / map.values.len() as f64
}

fn drag(h: &mut Harness<'static, CoatlabApp>, from: egui::Pos2, by: egui::Vec2) {
    h.hover_at(from);
    h.step();
    h.drag_at(from);
    h.step();
    for k in 1..=4 {
        h.hover_at(from + by * (k as f32 / 4.0));
        h.step();
    }
    h.drop_at(from + by);
    h.step();
}

fn save_screenshot(h: &mut Harness<'static, CoatlabApp>, name: &str) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/gui-preview");
    std::fs::create_dir_all(&dir).expect("screenshot dir");
    match h.render() {
        Ok(image) => image.save(dir.join(name)).expect("save screenshot"),
        Err(e) => panic!("render: {e}"),
    }
}

/// Pixels each view of a comparison renders at most: half of the preview's
/// 640×400.
const ONE_VIEWS_SHARE: u32 = 128_000;

/// The size the preview's first view renders at.
fn rendered_size(h: &Harness<'static, CoatlabApp>) -> (u32, u32) {
    let s = preview(h.state()).status().expect("a rendered image");
    (s.width, s.height)
}

#[test]
fn the_comparison_shows_paint_and_phong_with_one_camera_and_a_delta_e_map() {
    let mut h = preview_harness(true);
    wait_until(&mut h, "the first refined image", |app| {
        app.preview_status().is_some_and(|s| !s.coarse)
    });
    let single = rendered_size(&h);
    assert!(
        single.0 * single.1 > ONE_VIEWS_SHARE,
        "one view alone renders more than a comparison's view: {single:?}"
    );
    h.get_by_role_and_label(Role::ComboBox, "Compare").click();
    steps(&mut h, 2);
    h.get_by_label("Paint vs Phong").click();
    steps(&mut h, 2);
    wait_until(&mut h, "both views and their ΔE00 map", |app| {
        compared(app, 2)
    });
    h.get_by_role_and_label(Role::Image, "Preview pane: Paint model");
    let phong_pane = h
        .get_by_role_and_label(Role::Image, "Preview pane: Phong (best fit)")
        .rect();
    let map = preview(h.state()).delta_e_map().expect("map").clone();
    let share = exact_share(&map);
    assert!(share > 0.05, "the backdrop differs: {share}");
    assert!(
        map.p95 > 0.5 && map.mean.is_finite(),
        "the models should differ on the car: mean {} p95 {}",
        map.mean,
        map.p95
    );
    save_screenshot(&mut h, "compare_side_by_side.png");

    // Orbiting in the right pane moves both views.
    let epoch = preview(h.state()).status().map(|s| s.epoch).unwrap_or(0);
    drag(&mut h, phong_pane.center(), egui::vec2(60.0, 0.0));
    wait_until(&mut h, "both views after the orbit", |app| {
        compared(app, 2) && preview(app).status().is_some_and(|s| s.epoch > epoch)
    });
    let moved = preview(h.state()).delta_e_map().expect("map").clone();
    assert!(
        exact_share(&moved) > 0.05,
        "after the orbit the views still share one camera"
    );
    assert_ne!(
        moved.values, map.values,
        "the view moved, so the map changed"
    );

    // The ΔE00 map with its scale and numbers.
    h.get_by_label("ΔE00 map").click();
    steps(&mut h, 3);
    h.get_by_role_and_label(Role::Image, "ΔE00 map");
    h.get_by_role_and_label(Role::ComboBox, "Scale");
    h.get_by_label_contains("difference ΔE00 mean");
    save_screenshot(&mut h, "compare_delta_e_map.png");

    // Split view: dragging the divider moves the divider, not the camera.
    h.get_by_label("Split").click();
    // The split view renders each view with the whole area's aspect (within the
    // views' share of the preview's pixels): wait for that size.
    wait_until(&mut h, "the split view's images", |app| {
        compared(app, 1) && !preview(app).change_pending()
    });
    // The picture is as wide as one view's, but each of the two views renders
    // at most its share of one view's pixels, with the area's aspect.
    let (w, h_px) = rendered_size(&h);
    assert!(
        w * h_px <= ONE_VIEWS_SHARE + w + h_px && w > h_px,
        "the split view renders {w}×{h_px}"
    );
    let epoch = preview(h.state()).status().map(|s| s.epoch).unwrap_or(0);
    let divider = h
        .get_by_role_and_label(Role::Splitter, "Split divider")
        .rect();
    drag(&mut h, divider.center(), egui::vec2(-150.0, 0.0));
    steps(&mut h, 3);
    let p = preview(h.state());
    assert!(p.divider() < 0.4, "divider at {}", p.divider());
    assert!(!p.change_pending(), "the camera did not move");
    assert_eq!(p.status().map(|s| s.epoch), Some(epoch));
    save_screenshot(&mut h, "compare_split.png");
}

#[test]
fn two_designs_side_by_side_from_a_preset_and_from_a_file() {
    let dir = temp_dir("second");
    let mut h = preview_harness(false);
    steps(&mut h, 2);
    h.get_by_role_and_label(Role::ComboBox, "Compare").click();
    steps(&mut h, 2);
    h.get_by_label("Two designs").click();
    steps(&mut h, 2);
    h.get_by_role_and_label(Role::ComboBox, "Second design")
        .click();
    steps(&mut h, 2);
    h.get_by_label("Deep blue").click();
    steps(&mut h, 2);
    assert_eq!(
        preview(h.state()).second_design().map(|(l, _)| l),
        Some("Deep blue")
    );
    h.get_by_role_and_label(Role::Image, "Preview pane: Current design");
    h.get_by_role_and_label(Role::Image, "Preview pane: Deep blue");
    wait_until(&mut h, "both designs and their ΔE00 map", |app| {
        compared(app, 1)
            && preview(app)
                .second_design()
                .is_some_and(|(l, _)| l == "Deep blue")
    });
    let map = preview(h.state()).delta_e_map().expect("map");
    assert!(map.p95 > 20.0, "red against blue: p95 {}", map.p95);

    // A file as the second design: the same design as the current one shows no
    // difference anywhere (same camera, same seed, a zero shading difference).
    let file = dir.join("same.toml");
    h.state().design().save(&file).expect("save");
    // Read before the change: the render thread may publish the change's first
    // image while the steps below run (it did, under load, and the wait for a
    // later epoch then never ended).
    let epoch = preview(h.state()).status().map(|s| s.epoch).unwrap_or(0);
    h.state_mut().open_second_design(&file);
    steps(&mut h, 2);
    assert!(
        preview(h.state())
            .second_design()
            .is_some_and(|(l, _)| l.contains("same.toml"))
    );
    h.get_by_label_contains("Preview pane: Signal red (");
    wait_until(&mut h, "the file's design beside the current one", |app| {
        compared(app, 1) && preview(app).status().is_some_and(|s| s.epoch > epoch)
    });
    // Each pane is its own film blended with the other's plus or minus a
    // difference that is zero here: equal up to rounding.
    let map = preview(h.state()).delta_e_map().expect("map");
    assert!(
        map.max < 1e-3,
        "identical designs render identically: max ΔE00 {}",
        map.max
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn dropped_scenes_and_environment_maps_go_to_the_preview_and_bad_ones_change_nothing() {
    let dir = temp_dir("scene");
    let mut h = preview_harness(false);
    wait_until(&mut h, "the built-in car", |app| {
        scene_shown(app).is_some_and(|s| s.name == "Built-in car")
    });
    let glb = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/default-car.glb");
    h.input_mut().dropped_files.push(Arc::new(Dropped(glb)));
    wait_until(&mut h, "the dropped glTF scene", |app| {
        scene_shown(app).is_some_and(|s| s.name == "default-car.glb")
    });
    assert!(has_notice(h.state(), false, "Opened the scene"));
    let scene = preview(h.state()).scene().cloned().expect("scene");
    assert!(
        !scene.warnings.is_empty(),
        "the loader explains its paint choice"
    );
    steps(&mut h, 2);
    h.get_by_label(&format!("{} warning(s)", scene.warnings.len()));

    // Paint another material too, through the list of the scene's materials with
    // their areas; then take the loader's choice off: only the other is painted.
    let other = (0..scene.materials.len() as u32)
        .find(|i| !scene.automatic_paint().contains(i))
        .expect("a material that is not painted");
    let label = |i: u32| material_label(&scene.materials[i as usize]);
    click_in_paint_list(&mut h, &label(other));
    let mut both = scene.automatic_paint();
    both.push(other);
    both.sort_unstable();
    assert_eq!(preview(h.state()).paint_materials(), both);
    assert!(!preview(h.state()).paint_is_automatic());
    for &automatic in &scene.automatic_paint() {
        click_in_paint_list(&mut h, &label(automatic));
    }
    assert_eq!(preview(h.state()).paint_materials(), vec![other]);
    let epoch = preview(h.state()).status().map(|s| s.epoch).unwrap_or(0);
    wait_until(&mut h, "the repainted scene", |app| {
        app.preview_status()
            .is_some_and(|s| s.epoch >= epoch && !preview(app).change_pending())
    });

    // A broken scene: an error, and the scene stays.
    let broken = dir.join("broken.glb");
    std::fs::write(&broken, b"glTF\x02\0\0\0\x40\0\0\0garbage").expect("write");
    h.input_mut().dropped_files.push(Arc::new(Dropped(broken)));
    wait_until(&mut h, "the scene error", |app| {
        has_notice(app, true, "Could not open the scene")
    });
    assert_eq!(
        preview(h.state()).scene().map(|s| s.name.as_str()),
        Some("default-car.glb")
    );

    // An environment map, then a broken one.
    let hdr = dir.join("sky.hdr");
    write_hdr(&hdr);
    h.input_mut().dropped_files.push(Arc::new(Dropped(hdr)));
    wait_until(&mut h, "the environment map", |app| {
        app.preview()
            .is_some_and(|p| matches!(p.environment(), (Lighting::Map(_), Some("sky.hdr"))))
    });
    assert!(has_notice(h.state(), false, "environment map"));
    let bad = dir.join("bad.hdr");
    std::fs::write(&bad, "not a picture").expect("write");
    h.input_mut().dropped_files.push(Arc::new(Dropped(bad)));
    wait_until(&mut h, "the environment error", |app| {
        has_notice(app, true, "Could not open the environment map")
    });
    assert_eq!(preview(h.state()).environment().1, Some("sky.hdr"));
    // Bad EXR maps too: one the decoder refuses, one whose pixels are not finite.
    let garbage = dir.join("garbage.exr");
    let mut bytes = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    bytes.extend(b"channels\0chlist\0 not the rest of a header");
    std::fs::write(&garbage, bytes).expect("write");
    let not_finite = dir.join("nan.exr");
    exr::prelude::write_rgb_file(&not_finite, 8, 4, |x, _| {
        (if x == 3 { f32::NAN } else { 1.0 }, 1.0f32, 1.0f32)
    })
    .expect("write");
    for (bad, reason) in [
        (garbage, "garbage.exr: not a readable OpenEXR file"),
        (not_finite, "nan.exr"),
    ] {
        let errors_before = h.state().notices().iter().filter(|n| n.is_error).count();
        h.input_mut().dropped_files.push(Arc::new(Dropped(bad)));
        wait_until(&mut h, "the EXR's error", |app| {
            app.notices().iter().filter(|n| n.is_error).count() > errors_before
        });
        let error = h
            .state()
            .notices()
            .iter()
            .rfind(|n| n.is_error)
            .expect("error");
        assert!(
            error.text.contains("Could not open the environment map")
                && error.text.contains(reason),
            "{}",
            error.text
        );
        assert_eq!(preview(h.state()).environment().1, Some("sky.hdr"));
    }
    let _ = std::fs::remove_dir_all(dir);
}

fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).expect("read png");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{}", path.display());
    let be = |o: usize| u32::from_be_bytes([bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]]);
    (be(16), be(20))
}

/// Linear sRGB → XYZ as the film converts (the inverse of its XYZ → linear sRGB
/// with the D65 white at Y = 1, built from the core's own conversion).
fn xyz_of_linear_srgb() -> [[f64; 3]; 3] {
    use coatlab_core::colour::{Xyz, linear_srgb_from_xyz, srgb_white};
    let w = srgb_white();
    let white = Xyz::new(w.x / w.y, 1.0, w.z / w.y);
    let columns = [
        Xyz::new(1.0, 0.0, 0.0),
        Xyz::new(0.0, 1.0, 0.0),
        Xyz::new(0.0, 0.0, 1.0),
    ]
    .map(|e| {
        let rgb = linear_srgb_from_xyz(e, white);
        [rgb.red, rgb.green, rgb.blue]
    });
    let m = [0, 1, 2].map(|r| [0, 1, 2].map(|c| columns[c][r]));
    // The inverse by cofactors.
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    let cofactor = |r: usize, c: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (c1, c2) = ((c + 1) % 3, (c + 2) % 3);
        m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1]
    };
    [0, 1, 2].map(|r| [0, 1, 2].map(|c| cofactor(c, r) / det))
}

/// The display pixels the preview makes of a film whose means are `exr`: the
/// film's automatic exposure (log-average luminance to the key) and its display
/// pipeline (`display_xyz`), applied to the EXR's values taken back to XYZ.
fn displayed(exr: &ExrImage) -> Vec<[u8; 4]> {
    use coatlab_core::render::film::{AUTO_EXPOSURE_KEY, DisplaySettings, display_xyz};
    let m = xyz_of_linear_srgb();
    let xyz: Vec<[f64; 3]> = exr
        .rgb
        .iter()
        .map(|rgb| m.map(|row| (0..3).map(|c| row[c] * f64::from(rgb[c])).sum()))
        .collect();
    let log_mean = xyz.iter().map(|v| (1e-6 + v[1].max(0.0)).ln()).sum::<f64>() / xyz.len() as f64;
    let settings = DisplaySettings {
        exposure_stops: (AUTO_EXPOSURE_KEY / log_mean.exp()).log2() as f32,
        ..DisplaySettings::default()
    };
    let xyz: Vec<[f32; 3]> = xyz.iter().map(|v| v.map(|c| c as f32)).collect();
    display_xyz(&xyz, &settings)
}

/// An 8-bit RGB PNG's pixels (alpha 255), as the preview's frames hold them.
fn png_pixels(path: &Path) -> (u32, u32, Vec<[u8; 4]>) {
    let file = std::fs::File::open(path).expect("open PNG");
    let mut reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .expect("a PNG");
    let mut buffer = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut buffer).expect("PNG pixels");
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let pixels = buffer[..info.buffer_size()]
        .chunks_exact(3)
        .map(|p| [p[0], p[1], p[2], 255])
        .collect();
    (info.width, info.height, pixels)
}

/// The sample count an "Exported the preview (N spp) to … NAME …" notice gives.
fn exported_spp(app: &CoatlabApp, since: usize, name: &str) -> Option<u32> {
    app.notices()[since..]
        .iter()
        .find(|n| n.text.starts_with("Exported") && n.text.contains(name))
        .map(|n| {
            let (_, rest) = n.text.split_once('(').expect("(N spp)");
            let (count, _) = rest.split_once(" spp").expect("(N spp)");
            count.parse().expect("a sample count")
        })
}

/// Exports the preview to `png` and `exr` one after the other, until both come
/// from one film: the render thread adds a sample per pixel between any two
/// films, so two exports of the same sample count (nothing else changing) are of
/// the same film, and the PNG is what the preview shows of it.
fn export_png_and_exr_of_one_film(
    h: &mut Harness<'static, CoatlabApp>,
    png: &Path,
    exr: &Path,
) -> u32 {
    let name = |p: &Path| {
        p.file_name()
            .and_then(|n| n.to_str())
            .expect("name")
            .to_owned()
    };
    let (png_name, exr_name) = (name(png), name(exr));
    for _ in 0..5 {
        let since = h.state().notices().len();
        h.state_mut().export_preview(png);
        h.state_mut().export_preview(exr);
        wait_until(h, "both exports", |app| {
            exported_spp(app, since, &png_name).is_some()
                && exported_spp(app, since, &exr_name).is_some()
        });
        let spp = exported_spp(h.state(), since, &png_name);
        if spp == exported_spp(h.state(), since, &exr_name) {
            return spp.expect("spp");
        }
    }
    panic!("five pairs of exports fell on either side of a pass");
}

/// Share of blue in the light of the masked pixels (B / (R + G + B) of the sums of
/// their decoded, linear sRGB).
fn blue_share(pixels: &[[u8; 4]], mask: &[bool]) -> f64 {
    let linear = |v: u8| {
        let v = f64::from(v) / 255.0;
        if v <= 0.04045 {
            v / 12.92
        } else {
            ((v + 0.055) / 1.055).powf(2.4)
        }
    };
    let mut sum = [0.0f64; 3];
    for (p, _) in pixels.iter().zip(mask).filter(|(_, m)| **m) {
        for c in 0..3 {
            sum[c] += linear(p[c]);
        }
    }
    sum[2] / sum.iter().sum::<f64>()
}

#[test]
fn the_preview_exports_png_and_exr_and_the_exr_lights_the_car() {
    let dir = temp_dir("export");
    let mut h = preview_harness(false);
    wait_until(&mut h, "a refined image", |app| {
        app.preview_status()
            .is_some_and(|s| !s.coarse && s.samples_per_pixel >= 2)
    });
    let png = dir.join("car.png");
    h.state_mut().export_preview(&png);
    wait_until(&mut h, "the PNG export", |app| {
        has_notice(app, false, "Exported the preview")
    });
    let status = h.state().preview_status().cloned().expect("status");
    assert_eq!(png_size(&png), (status.width, status.height));

    // The EXR holds the film the preview shows: 32-bit float R, G, B of its size,
    // whose display is the PNG exported of the same film up to the 8-bit rounding
    // (a value on a code boundary may round either way after the round trip
    // through XYZ in f32).
    let exr = dir.join("car.exr");
    let shown_png = dir.join("shown.png");
    let spp = export_png_and_exr_of_one_film(&mut h, &shown_png, &exr);
    let (width, height, shown) = png_pixels(&shown_png);
    let image = read_exr(&exr);
    assert_rgb_f32(&image);
    assert_eq!(
        (image.width, image.height),
        (width as usize, height as usize)
    );
    let from_exr = displayed(&image);
    let mut exact = 0;
    for (i, (got, want)) in from_exr.iter().zip(&shown).enumerate() {
        let worst = (0..3).map(|c| got[c].abs_diff(want[c])).max().unwrap_or(0);
        assert!(
            worst <= 1,
            "pixel ({}, {}) at {spp} spp: the EXR shows as {got:?}, the preview as {want:?}",
            i % image.width,
            i / image.width
        );
        exact += usize::from(worst == 0);
    }
    let exact_share = exact as f64 / shown.len() as f64;
    eprintln!(
        "EXR against the shown image at {spp} spp: {exact_share:.4} of the pixels exact, the rest within one code"
    );
    assert!(exact_share > 0.99, "{exact_share}");
    // No temporary files are left beside the exports.
    let names: Vec<String> = std::fs::read_dir(&dir)
        .expect("list")
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 3, "{names:?}");

    h.state_mut().export_preview(&dir.join("car.jpg"));
    h.step();
    assert!(has_notice(
        h.state(),
        true,
        "car.jpg: export the preview as .png"
    ));

    // An EXR map lights the car: a map of white light, then one of blue light
    // only under the same name (so the toolbar, and with it the image's size and
    // framing, stays as it is), dropped on the window. The red paint's pixels
    // under the white map turn blue under the blue one, as nothing else is there
    // to reflect.
    let sky = dir.join("sky.exr");
    let lit_by = |h: &mut Harness<'static, CoatlabApp>, colour: (f32, f32, f32), name: &str| {
        exr::prelude::write_rgb_file(&sky, 64, 32, |_, _| colour).expect("write the map");
        let epoch = h.state().preview_status().expect("status").epoch;
        h.input_mut()
            .dropped_files
            .push(Arc::new(Dropped(sky.clone())));
        wait_until(h, "the car under the map", |app| {
            app.preview_status()
                .is_some_and(|s| s.epoch > epoch && !s.coarse && s.samples_per_pixel >= 2)
        });
        assert!(matches!(
            preview(h.state()).environment(),
            (Lighting::Map(_), Some("sky.exr"))
        ));
        let png = dir.join(name);
        let since = h.state().notices().len();
        h.state_mut().export_preview(&png);
        wait_until(h, "the export", |app| {
            exported_spp(app, since, name).is_some()
        });
        png_pixels(&png)
    };
    let (width, height, white) = lit_by(&mut h, (1.0, 1.0, 1.0), "white-lit.png");
    let red: Vec<bool> = white
        .iter()
        .map(|p| p[0] >= 80 && u16::from(p[0]) >= 2 * u16::from(p[1].max(p[2])))
        .collect();
    let red_count = red.iter().filter(|&&r| r).count();
    assert!(
        red_count * 50 > red.len(),
        "the red car covers {red_count} of {} pixels",
        red.len()
    );
    let (blue_width, blue_height, blue) = lit_by(&mut h, (0.0, 0.0, 1.0), "blue-lit.png");
    assert_eq!((blue_width, blue_height), (width, height));
    let (under_white, under_blue) = (blue_share(&white, &red), blue_share(&blue, &red));
    eprintln!(
        "blue share of {red_count} red-paint pixels: white map {under_white:.3}, blue map {under_blue:.3}"
    );
    // 0.8 held with the Reinhard display and the earlier built-in car; with PBR
    // Neutral (which compresses the brightest reflections toward white) and the
    // new car it measured 0.796. The white map's 0.085 stays far below.
    assert!(
        under_white < 0.2 && under_blue > 0.7,
        "blue share of the paint: white map {under_white:.3}, blue map {under_blue:.3}"
    );

    // In a comparison both views are written.
    compare_models(&mut h, coatlab_app::gui::compare::CompareLayout::Split);
    wait_until(&mut h, "both views", |app| compared(app, 1));
    h.state_mut().export_preview(&dir.join("pair.png"));
    wait_until(&mut h, "the pair's export", |app| {
        app.notices().iter().any(|n| n.text.contains("pair-b.png"))
    });
    assert_eq!(
        png_size(&dir.join("pair.png")),
        png_size(&dir.join("pair-b.png"))
    );

    // The exported EXR reads back as an environment map too.
    h.state_mut().open_environment(&exr);
    wait_until(&mut h, "the EXR as lighting", |app| {
        app.preview()
            .is_some_and(|p| p.environment().1 == Some("car.exr"))
    });
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_scene_opens_through_the_in_app_browser() {
    let mut h = preview_harness(false);
    // The in-app browser whatever this machine has (a system dialog would wait for
    // a person).
    h.state_mut().set_native_dialog(None);
    steps(&mut h, 2);
    h.get_by_label("Open scene…").click();
    steps(&mut h, 2);
    assert!(
        h.query_by_label("Open a glTF scene (.glb or .gltf)")
            .is_some()
    );
    let glb = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets/default-car.glb")
        .canonicalize()
        .expect("the default car");
    open_in_browser(&mut h, &glb);
    wait_until(&mut h, "the scene from the browser", |app| {
        scene_shown(app).is_some_and(|s| s.path.as_deref() == Some(glb.as_path()))
    });
}

#[test]
fn choosing_a_quality_preset_sets_the_render_knobs_and_shows_its_measured_figures() {
    // The preset with the coarsest resolution shows the knobs most plainly.
    let chosen =
        committed_preset(|p| (std::cmp::Reverse(p.resolution_divisor), p.samples_per_pixel));
    let mut h = preview_harness(false);
    wait_until(&mut h, "the first refined image", |app| {
        app.preview_status().is_some_and(|s| !s.coarse)
    });
    let full = {
        let s = h.state().preview_status().expect("a frame");
        (s.width, s.height)
    };
    choose_quality_preset(&mut h, &chosen.name);
    let quality = preview(h.state()).quality();
    assert_eq!(quality.knobs, chosen.knobs());
    assert_eq!(
        quality.preset().map(|p| p.name.as_str()),
        Some(chosen.name.as_str())
    );
    // Its measured error and cost are on screen.
    h.get_by_label_contains(&format!(
        "measured ΔE00 mean {:.2}, p95 {:.2}, bias {:.2} · {:.2} s CPU",
        chosen.mean_delta_e, chosen.p95_delta_e, chosen.bias_delta_e, chosen.cpu_seconds
    ));
    // The preview renders at the preset's resolution and stops at its samples.
    let divided = chosen.knobs().divide(full);
    wait_until(&mut h, "the preset's image, converged", |app| {
        app.preview_status().is_some_and(|s| {
            !s.coarse
                && (s.width, s.height) == divided
                && s.samples_per_pixel >= chosen.samples_per_pixel
        })
    });
    steps(&mut h, 20);
    let s = h.state().preview_status().expect("a frame");
    assert_eq!(
        s.samples_per_pixel, chosen.samples_per_pixel,
        "stops at the preset's spp"
    );
    // The status line states the error left: noise plus the measured bias floor.
    h.get_by_label_contains(&format!("bias floor {:.2}", chosen.bias_delta_e));
}

/// Stands in for the system's file dialog: answers every request with `outcome`,
/// after `gate` lets it (a person taking their time), and records the requests.
struct FakeDialog {
    outcome: DialogOutcome,
    gate: std::sync::Mutex<Option<std::sync::mpsc::Receiver<()>>>,
    asked: std::sync::Mutex<Vec<DialogRequest>>,
}

impl FakeDialog {
    fn new(outcome: DialogOutcome) -> Arc<Self> {
        Arc::new(Self {
            outcome,
            gate: std::sync::Mutex::new(None),
            asked: std::sync::Mutex::new(Vec::new()),
        })
    }

    fn requests(&self) -> Vec<DialogRequest> {
        self.asked.lock().expect("requests").clone()
    }
}

impl NativeFileDialog for FakeDialog {
    fn ask(&self, request: &DialogRequest) -> DialogOutcome {
        self.asked.lock().expect("requests").push(request.clone());
        if let Some(gate) = self.gate.lock().expect("gate").take() {
            let _ = gate.recv();
        }
        self.outcome.clone()
    }
}

fn deep_blue() -> coatlab_core::design::PaintDesign {
    coatlab_core::design::presets::all()
        .into_iter()
        .find(|p| p.slug == "deep-blue")
        .map(|p| p.design)
        .expect("deep blue preset")
}

fn press_ctrl(h: &mut Harness<'static, CoatlabApp>, key: egui::Key) {
    h.key_press_modifiers(egui::Modifiers::COMMAND, key);
    h.step();
}

#[test]
fn a_file_chosen_in_the_system_dialog_opens_while_the_ui_keeps_drawing() {
    let dir = temp_dir("native-open");
    let file = dir.join("blue.toml");
    deep_blue().save(&file).expect("save");
    let fake = FakeDialog::new(DialogOutcome::Chosen(file.clone()));
    let (release, gate) = std::sync::mpsc::channel();
    *fake.gate.lock().expect("gate") = Some(gate);
    let mut h = harness(app());
    h.state_mut().set_native_dialog(Some(fake.clone()));
    press_ctrl(&mut h, egui::Key::O);

    // The dialog is up on its own thread: frames go on, the menu bar says so.
    steps(&mut h, 5);
    assert!(h.state().file_dialogs().is_waiting());
    assert!(h.query_by_label("Waiting for the file dialog…").is_some());
    assert_ne!(h.state().design(), &deep_blue());
    // The dialog's thread asks when the scheduler runs it, which five frames do
    // not promise.
    wait_until(&mut h, "the system dialog to be asked", |_| {
        !fake.requests().is_empty()
    });
    assert!(h.state().file_dialogs().is_waiting());
    let asked = fake.requests();
    assert_eq!(asked.len(), 1);
    assert!(!asked[0].save && asked[0].extensions == ["toml"]);

    release.send(()).expect("release the dialog");
    wait_until(&mut h, "the design from the system dialog", |app| {
        app.design() == &deep_blue()
    });
    assert_eq!(h.state().path(), Some(file.as_path()));
    assert!(!h.state().file_dialogs().is_waiting());
    assert!(!h.state().file_dialogs().browser_is_open());
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn saving_through_the_system_dialog_writes_the_chosen_file() {
    let dir = temp_dir("native-save");
    let file = dir.join("chosen.toml");
    let fake = FakeDialog::new(DialogOutcome::Chosen(file.clone()));
    let mut h = harness(app());
    h.state_mut().set_native_dialog(Some(fake.clone()));
    h.get_by_role_and_label(Role::Slider, "Thickness h (µm)")
        .set_value_accesskit(52.0);
    h.run();
    // Never saved: Ctrl+S asks where.
    press_ctrl(&mut h, egui::Key::S);
    wait_until(&mut h, "the save", |app| app.path() == Some(file.as_path()));
    let asked = fake.requests();
    assert!(asked[0].save && asked[0].file_name.ends_with(".toml"));
    assert_eq!(
        coatlab_core::design::PaintDesign::load(&file)
            .expect("saved")
            .thickness_um,
        52.0
    );
    assert!(!h.state().is_dirty());
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn cancelling_the_system_dialog_changes_nothing() {
    let fake = FakeDialog::new(DialogOutcome::Cancelled);
    let mut h = harness(app());
    h.state_mut().set_native_dialog(Some(fake.clone()));
    let before = h.state().design().clone();
    press_ctrl(&mut h, egui::Key::O);
    wait_until(&mut h, "the dialog to close", |app| {
        !app.file_dialogs().is_waiting()
    });
    steps(&mut h, 2);
    assert_eq!(fake.requests().len(), 1);
    assert_eq!(h.state().design(), &before);
    assert_eq!(h.state().path(), None);
    assert!(h.state().notices().is_empty(), "{:?}", h.state().notices());
    assert!(!h.state().file_dialogs().browser_is_open());
    assert!(h.state().file_dialogs().use_native());
}

#[test]
fn without_a_system_dialog_the_in_app_browser_opens_and_says_why_once() {
    let fake = FakeDialog::new(DialogOutcome::Unavailable(
        "no desktop portal answers on the session bus, and zenity is not installed".into(),
    ));
    let mut h = harness(app());
    h.state_mut().set_native_dialog(Some(fake.clone()));
    press_ctrl(&mut h, egui::Key::O);
    wait_until(&mut h, "the in-app browser", |app| {
        app.file_dialogs().browser_is_open()
    });
    steps(&mut h, 2);
    assert!(
        h.query_by_label("Open design").is_some(),
        "the browser's window"
    );
    let why = |app: &CoatlabApp| {
        app.notices()
            .iter()
            .filter(|n| n.text.contains("No system file dialog (no desktop portal"))
            .count()
    };
    assert_eq!(why(h.state()), 1);
    assert!(!h.state().file_dialogs().use_native());

    // The browser works: a design typed into it opens.
    let dir = temp_dir("fallback");
    let file = dir.join("blue.toml");
    deep_blue().save(&file).expect("save");
    open_in_browser(&mut h, &file);
    wait_until(&mut h, "the design from the browser", |app| {
        app.design() == &deep_blue()
    });

    // Later requests go straight to the browser: the system is not asked again and
    // the reason is not repeated.
    press_ctrl(&mut h, egui::Key::O);
    steps(&mut h, 2);
    assert!(h.state().file_dialogs().browser_is_open());
    assert_eq!(fake.requests().len(), 1);
    assert_eq!(why(h.state()), 1);
    let _ = std::fs::remove_dir_all(dir);
}

/// The real system dialog where this machine has none (CI: Xvfb, no portal, no
/// zenity): the request ends in the in-app browser with the reason shown.
#[test]
fn the_real_system_dialog_falls_back_where_the_machine_has_none() {
    if let Ok(()) = native_dialog_availability() {
        eprintln!("skipped: this machine has a system file dialog, which would wait for a person");
        return;
    }
    let mut h = harness(app());
    press_ctrl(&mut h, egui::Key::O);
    wait_until(&mut h, "the in-app browser", |app| {
        app.file_dialogs().browser_is_open()
    });
    assert!(has_notice(h.state(), false, "No system file dialog ("));
}

/// The comparison shares the work: the second view is the first view's paths
/// re-shaded, the window says so, and a design compared with itself shows no
/// difference at all (not noise), while paint against Phong still differs.
#[test]
fn the_comparison_re_shades_the_first_views_paths() {
    use coatlab_app::gui::compare::{CompareLayout, CompareMode};
    use coatlab_app::gui::preview::SecondSource;
    let mut h = preview_harness(false);
    steps(&mut h, 2);
    compare_models(&mut h, CompareLayout::DeltaE);
    wait_until(&mut h, "paint and Phong from shared samples", |app| {
        compared(app, 4)
    });
    steps(&mut h, 2);
    let p = preview(h.state());
    assert!(
        matches!(
            p.second_status().and_then(|s| s.source.clone()),
            Some(SecondSource::Shared { recorded_spp, .. }) if recorded_spp >= 1
        ),
        "{:?}",
        p.second_status()
    );
    h.get_by_label_contains("spp of the first view's paths re-shaded into the second");
    let map = preview(h.state()).delta_e_map().expect("map").clone();
    assert!(map.p95 > 0.5, "paint and Phong differ: p95 {}", map.p95);

    // The current design as the second design: the same paths with the same
    // shading, so the map is zero everywhere, from the first pass on.
    let design = h.state().design().clone();
    let epoch = preview(h.state()).status().map(|s| s.epoch).unwrap_or(0);
    {
        let p = h.state_mut().preview_mut().expect("preview");
        p.set_second_design("Itself", &design);
        p.set_compare(CompareMode::Designs, CompareLayout::DeltaE);
    }
    wait_until(&mut h, "the design against itself", |app| {
        compared(app, 2)
            && preview(app).status().is_some_and(|s| s.epoch > epoch)
            && preview(app)
                .second_design()
                .is_some_and(|(l, _)| l == "Itself")
    });
    // Each pane blends its own film with the other's plus or minus the (zero)
    // difference, with weights w and 1 − w computed from the same variances: the
    // panes agree up to the rounding of those weights.
    let map = preview(h.state()).delta_e_map().expect("map");
    assert!(
        map.mean < 1e-4 && map.max < 1e-3,
        "a design against itself from shared samples: mean {}, max {}",
        map.mean,
        map.max
    );
    h.get_by_label_contains("difference ΔE00 mean 0.00, 95 % 0.00");
}

/// A click at `at`: press and release without moving, one frame apart (a
/// press held over several of the harness's quarter-second frames would be a
/// long press, not a click).
fn click(h: &mut Harness<'static, CoatlabApp>, at: egui::Pos2) {
    h.hover_at(at);
    h.step();
    h.drag_at(at);
    h.step();
    h.drop_at(at);
    h.step();
}

/// In a comparison a click on the car toggles its material's paint as in the
/// single view — in a side-by-side pane and on the ΔE00 map — and undo takes
/// each choice back, to the loader's at the end.
#[test]
fn a_click_on_the_car_in_a_comparison_toggles_its_paint_and_undo_takes_it_back() {
    use coatlab_app::gui::compare::CompareLayout;
    let mut h = preview_harness(true);
    compare_models(&mut h, CompareLayout::SideBySide);
    wait_until(&mut h, "both views", |app| compared(app, 1));
    let automatic = preview(h.state()).paint_materials();
    assert!(preview(h.state()).paint_is_automatic());
    // The framed car's middle is its painted body (the loader's choice).
    let pane = h
        .get_by_role_and_label(Role::Image, "Preview pane: Phong (best fit)")
        .rect();
    let changed = |h: &mut Harness<'static, CoatlabApp>, at: egui::Pos2, what: &str| {
        let before = preview(h.state()).paint_materials();
        click(h, at);
        wait_until(h, what, |app| {
            preview(app).paint_materials() != before && !preview(app).change_pending()
        });
        // The gesture is over: committed as an undo step.
        steps(h, 2);
        preview(h.state()).paint_materials()
    };
    let unpainted = changed(&mut h, pane.center(), "the click in the Phong pane");
    assert!(
        unpainted.len() < automatic.len(),
        "the body's material came off: {automatic:?} → {unpainted:?}"
    );
    save_screenshot(&mut h, "compare_side_by_side_unpainted.png");
    h.get_by_label("ΔE00 map").click();
    steps(&mut h, 3);
    let map = h.get_by_role_and_label(Role::Image, "ΔE00 map").rect();
    wait_until(&mut h, "the map", |app| compared(app, 1));
    let repainted = changed(&mut h, map.center(), "the click on the map");
    let mut expected = automatic.clone();
    expected.sort_unstable();
    let mut got = repainted.clone();
    got.sort_unstable();
    assert_eq!(got, expected, "the same click put the body's paint back");
    assert!(!preview(h.state()).paint_is_automatic());

    h.state_mut().undo();
    steps(&mut h, 2);
    assert_eq!(preview(h.state()).paint_materials(), unpainted);
    h.state_mut().undo();
    steps(&mut h, 2);
    assert!(preview(h.state()).paint_is_automatic());
    assert_eq!(preview(h.state()).paint_materials(), automatic);
    h.state_mut().redo();
    steps(&mut h, 2);
    assert_eq!(preview(h.state()).paint_materials(), unpainted);

    // The paint list shows the area the view sees of each material, measured
    // on the render thread once the list is open: of the body, a part (its far
    // side is hidden, and what is seen is seen in projection).
    h.get_by_label("Paint materials").click();
    steps(&mut h, 2);
    wait_until(&mut h, "the visible areas", |app| {
        preview(app).visible_areas().is_some()
    });
    steps(&mut h, 2);
    let scene = preview(h.state()).scene().cloned().expect("scene");
    let visible = preview(h.state())
        .visible_areas()
        .expect("measured")
        .to_vec();
    assert_eq!(visible.len(), scene.materials.len());
    for &body in &automatic {
        let total = scene.materials[body as usize].area_m2;
        let seen = visible[body as usize];
        // The built-in saloon's body, 16.7 m² of panels (inner faces included),
        // shows 2.0 m² from the front three-quarter view.
        assert!(
            seen > 1.0 && seen < 0.5 * total,
            "{}: {seen} m² seen of {total} m²",
            scene.materials[body as usize].name
        );
    }
    h.get_by_label(&visible_label(Some(visible[automatic[0] as usize])));
    save_screenshot(&mut h, "compare_paint_list_visible.png");
}

/// An ideal-mirror paint cannot be re-shaded into Phong (a delta bounce has no
/// lobe to re-weight): the comparison falls back to two renders and says why.
#[test]
fn a_mirror_paint_is_compared_through_independent_renders() {
    use coatlab_app::gui::compare::CompareLayout;
    use coatlab_app::gui::preview::SecondSource;
    use coatlab_core::paint::gloss::GlossExponent;
    let mut h = preview_harness(false);
    steps(&mut h, 2);
    let mut mirror = h.state().design().clone();
    mirror.gloss.gu = 1000.0;
    assert!(matches!(mirror.exponent(), Ok(GlossExponent::Mirror)));
    h.state_mut().set_design(mirror);
    steps(&mut h, 2);
    compare_models(&mut h, CompareLayout::SideBySide);
    wait_until(&mut h, "the mirror against Phong, rendered apart", |app| {
        compared(app, 2)
            && preview(app).second_status().is_some_and(|s| {
                matches!(&s.source, Some(SecondSource::Independent { reason })
                    if reason.contains("ideal-mirror"))
            })
    });
    steps(&mut h, 2);
    h.get_by_label_contains("Independent renders (same camera and seed): an ideal-mirror");
    let map = preview(h.state()).delta_e_map().expect("map");
    assert!(map.p95 > 0.5, "a mirror is not Phong: p95 {}", map.p95);
}

/// The preview's View list: the named views, and the scene file's own cameras
/// once a file with cameras (ToyCar) is open. (What the engine does with the
/// choice is tested without a window: `a_view_change_restarts_from_a_coarse_pass_and_rebuilds_nothing`.)
#[test]
fn the_view_list_offers_named_views_and_the_files_cameras() {
    use coatlab_core::render::view::{NamedView, ViewChoice};
    let Some(dir) = gltf_testdata::testdata() else {
        return;
    };
    let mut h = preview_harness(false);
    wait_until(&mut h, "the built-in car", |app| {
        scene_shown(app).is_some_and(|s| s.name == "Built-in car")
    });
    let choose = |h: &mut Harness<'static, CoatlabApp>, label: &str| {
        h.get_by_role_and_label(Role::ComboBox, "View").click();
        steps(h, 2);
        h.get_by_label(label).click();
        steps(h, 2);
    };
    choose(&mut h, NamedView::Side.label());
    assert_eq!(
        preview(h.state()).view(),
        ViewChoice::Named(NamedView::Side)
    );

    let toy_car = dir.join("ToyCar/ToyCar.gltf");
    h.input_mut().dropped_files.push(Arc::new(Dropped(toy_car)));
    wait_until(&mut h, "ToyCar", |app| {
        scene_shown(app).is_some_and(|s| s.name == "ToyCar.gltf")
    });
    // A new scene opens at the default view.
    assert_eq!(preview(h.state()).view(), ViewChoice::default());
    assert_eq!(scene_shown(h.state()).expect("scene").cameras.len(), 8);
    choose(&mut h, "Camera: Camera002");
    assert_eq!(preview(h.state()).view(), ViewChoice::SceneCamera(1));
    assert!(
        !h.state().notices().iter().any(|n| n.is_error),
        "{:?}",
        h.state().notices()
    );
}

#[test]
fn the_file_menu_exports_the_design_as_cxf_cgats_and_gltf() {
    use coatlab_app::gui::app::EXPORT_MENU;
    let dir = temp_dir("export-design");
    let mut h = harness(app());
    for (format, label) in EXPORT_MENU {
        let file = dir.join(format!("export.{}", format.extensions()[0]));
        let fake = FakeDialog::new(DialogOutcome::Chosen(file.clone()));
        h.state_mut().set_native_dialog(Some(fake.clone()));
        h.get_by_label("File").click();
        h.run();
        h.get_by_label(label).click();
        wait_until(&mut h, label, |_| file.exists());
        // The dialog was asked for a file to save, of the format's extension.
        let asked = fake.requests();
        assert!(asked[0].save, "{label}");
        assert_eq!(asked[0].extensions, format.extensions(), "{label}");
        let bytes = std::fs::read(&file).expect("written");
        match format.extensions()[0] {
            "glb" => assert_eq!(&bytes[..4], b"glTF"),
            name => {
                let back = coatlab_core::measurement::read(&bytes, name).expect("readable");
                assert_eq!(back.samples[0].name, h.state().design().name);
            }
        }
        assert!(has_notice(h.state(), false, "Exported"), "{label}");
    }
    // The glTF notice states what the real-time material costs per angle.
    assert!(has_notice(h.state(), false, "45°as110°"));
    let _ = std::fs::remove_dir_all(dir);
}
