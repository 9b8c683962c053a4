//! The designer's window driven as a person uses it, headless, with egui_kittest:
//! widgets are found by the names assistive technology sees.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use coatlab_app::gui::storage::Storage;
use coatlab_app::gui::{AppOptions, CoatlabApp, app::Tab};
use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;

fn app() -> CoatlabApp {
    CoatlabApp::new(AppOptions {
        storage: Storage::none(),
        open: None,
        preview: false,
    })
}

fn harness(app: CoatlabApp) -> Harness<'static, CoatlabApp> {
    let mut h = Harness::builder()
        .with_size(egui::vec2(1400.0, 900.0))
        .build_ui_state(|ui, app: &mut CoatlabApp| app.show(ui), app);
    h.run();
    h
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

    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run();
    assert_eq!(h.state().design(), &before, "Ctrl+Z restores the design");

    h.key_press_modifiers(
        egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
        egui::Key::Z,
    );
    h.run();
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

#[test]
fn save_then_reopen_round_trips_and_an_unsaved_edit_is_recovered_after_a_crash() {
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
    h.state_mut().open_target(&target_file);
    h.run();
    let de = h
        .state()
        .analysis()
        .and_then(|a| a.delta_e.clone())
        .expect("ΔE00 per angle");
    assert_eq!(de.len(), 5);
    let csv = dir.join("readings.csv");
    h.state_mut().export_measurement(&csv);
    let text = std::fs::read_to_string(&csv).expect("exported");
    assert!(text.starts_with("kind,angle_deg,detector_deg,L,a,b,dE00"));
    assert_eq!(text.lines().count(), 9);
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
    let mut h = Harness::builder()
        .with_size(egui::vec2(1400.0, 900.0))
        .wgpu()
        .build_ui_state(|ui, app: &mut CoatlabApp| app.show(ui), app());
    h.run();
    h.snapshot("designer_plots");
    h.state_mut().set_tab(Tab::Instruments);
    h.run();
    h.snapshot("designer_instruments");
}

/// The live preview renders off the UI thread and restarts on a design change.
#[test]
fn the_preview_accumulates_and_restarts_when_the_design_changes() {
    let mut h = Harness::builder()
        .with_size(egui::vec2(1000.0, 700.0))
        .build_ui_state(
            |ui, app: &mut CoatlabApp| app.show(ui),
            CoatlabApp::new(AppOptions {
                storage: Storage::none(),
                open: None,
                preview: true,
            }),
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
    h.get_by_role_and_label(Role::Slider, "Thickness h (µm)")
        .set_value_accesskit(80.0);
    wait_for(&mut h, &|s| s.is_some_and(|(_, coarse)| coarse));
}
