//! The Instruments tab's target from a measurement file (CGATS.17, CxF3): chosen
//! in the file dialog or dropped, a standard chosen from several, the tolerance
//! table as the core computes it, a bad file refused with nothing changed, and
//! *Fit to target* as one undoable edit.

use coatlab_core::colour::tolerance::{Formula, Tolerance};
use coatlab_core::fit::FreeParameters;
use coatlab_core::measurement;
use coatlab_core::target::{Comparison, compare_to_standard};

use super::*;

#[path = "../../crates/coatlab-core/tests/support/metameric_black.rs"]
mod metameric_black;

fn fixture(name: &str) -> PathBuf {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../coatlab-core/tests/data/measurements")
        .join(name);
    // Without the "..": the path is shown in notices and in the fit report.
    std::fs::canonicalize(&path).unwrap_or(path)
}

fn instruments_harness() -> Harness<'static, CoatlabApp> {
    let mut app = app();
    app.set_tab(Tab::Instruments);
    harness(app)
}

fn shown_comparison(app: &CoatlabApp) -> Comparison {
    app.target_view()
        .expect("a target view")
        .comparison
        .clone()
        .expect("a comparison")
}

/// What `coatlab measure --target FILE --sample SAMPLE` computes for the app's
/// current design, from the core directly.
fn expected_comparison(app: &CoatlabApp, file: &Path, sample: &str) -> Comparison {
    let bytes = std::fs::read(file).expect("fixture");
    let m = measurement::read(&bytes, &file.display().to_string()).expect("readable");
    let standard = m.select(Some(sample)).expect("sample");
    let analysis = app.analysis().expect("valid design");
    let tolerance = app.design().tolerance.clone().unwrap_or_default();
    compare_to_standard(
        &analysis.model,
        &analysis.measurement,
        &standard,
        &tolerance,
    )
    .expect("comparable")
}

fn target_label(app: &CoatlabApp) -> String {
    app.target()
        .map(coatlab_app::gui::target::Target::label)
        .unwrap_or_default()
}

#[test]
fn a_measurement_chosen_in_the_file_dialog_is_the_target_with_its_tolerance_table() {
    let file = fixture("multi_angle.cxf");
    let fake = FakeDialog::new(DialogOutcome::Chosen(file.clone()));
    let mut h = instruments_harness();
    h.state_mut().set_native_dialog(Some(fake.clone()));
    h.get_by_label("Target from file…").click();
    wait_until(&mut h, "the measured target", |app| {
        app.target_view().is_some()
    });
    h.run();
    let asked = fake.requests();
    assert_eq!(asked.len(), 1);
    assert!(
        ["toml", "cgats", "cxf"]
            .iter()
            .all(|e| asked[0].extensions.contains(&(*e).to_owned())),
        "{:?}",
        asked[0].extensions
    );

    // The file's first standard of two; the table is the core's comparison.
    assert_eq!(target_label(h.state()), "Signal red (multi_angle.cxf)");
    let shown = shown_comparison(h.state());
    assert_eq!(shown, expected_comparison(h.state(), &file, "Signal red"));
    assert_eq!(shown.angles.len(), 6, "the file's six angles");
    for a in &shown.angles {
        h.get_by_label(&a.geometry.to_string());
        for v in [a.difference.dl, a.difference.dh, a.difference.de00] {
            assert!(
                h.query_all_by_label(&format!("{v:.2}")).next().is_some(),
                "{v:.2} is not shown"
            );
        }
    }
    let verdicts = h.query_all_by_label("pass").count() + h.query_all_by_label("FAIL").count();
    assert_eq!(verdicts, shown.angles.len());
    h.get_by_label_contains("Result:");
    h.get_by_label_contains("Metamerism index");

    // The other standard, from the Sample box.
    h.get_by_role_and_label(Role::ComboBox, "Sample").click();
    h.run();
    h.get_all_by_label("Deep blue")
        .last()
        .expect("Deep blue in the sample list")
        .click();
    h.run();
    assert_eq!(target_label(h.state()), "Deep blue (multi_angle.cxf)");
    assert_eq!(
        shown_comparison(h.state()),
        expected_comparison(h.state(), &file, "Deep blue")
    );

    // ΔE*ab as the formula: an edit of the design's tolerance, undoable.
    h.get_by_role_and_label(Role::ComboBox, "Tolerance").click();
    h.run();
    h.get_by_role_and_label(Role::Button, "ΔE*ab").click();
    h.run();
    assert_eq!(
        h.state().design().tolerance.as_ref().map(|t| t.formula),
        Some(Formula::DeAb)
    );
    let c = shown_comparison(h.state());
    assert_eq!(c.tolerance.formula, Formula::DeAb);
    assert!(c.angles.iter().all(|a| a.value == a.difference.de_ab));
    undo_key(&mut h);
    assert_eq!(h.state().design().tolerance, None);
    assert_eq!(shown_comparison(h.state()).tolerance, Tolerance::default());
}

#[test]
fn a_dropped_measurement_becomes_the_target_and_a_bad_one_changes_nothing() {
    let mut h = harness(app());
    let good = fixture("multi_angle_in_names.cgats");
    h.input_mut()
        .dropped_files
        .push(Arc::new(Dropped(good.clone())));
    h.run();
    assert_eq!(
        target_label(h.state()),
        "RED (multi_angle_in_names.cgats)",
        "notices: {:?}",
        h.state().notices()
    );
    assert_eq!(
        shown_comparison(h.state()),
        expected_comparison(h.state(), &good, "RED")
    );
    h.get_by_role_and_label(Role::Slider, "Thickness h (µm)")
        .set_value_accesskit(50.0);
    h.run();
    let (design, target) = (h.state().design().clone(), h.state().target().cloned());

    // Dropped, and chosen in the dialog: each refused with the file and the line
    // or element named, and neither the design nor the target changes.
    let bad = fixture("bad_number_of_sets.cgats");
    h.input_mut().dropped_files.push(Arc::new(Dropped(bad)));
    h.run();
    assert!(
        has_notice(h.state(), true, "Could not open the target: ")
            && has_notice(h.state(), true, "bad_number_of_sets.cgats, line 13"),
        "{:?}",
        h.state().notices()
    );
    h.get_by_label_contains("bad_number_of_sets.cgats, line 13");
    let bomb = fixture("bad_xml_bomb.cxf");
    h.state_mut()
        .set_native_dialog(Some(FakeDialog::new(DialogOutcome::Chosen(bomb))));
    h.get_by_label("Target from file…").click();
    wait_until(&mut h, "the refusal", |app| {
        has_notice(app, true, "bad_xml_bomb.cxf")
    });
    h.run();
    assert_eq!(h.state().design(), &design);
    assert_eq!(h.state().target(), target.as_ref());
    assert!(h.state().target_view().is_some());
}

/// The Instruments tab with the "Deep blue" standard of `multi_angle.cxf` as the
/// target.
fn deep_blue_target_harness() -> Harness<'static, CoatlabApp> {
    let mut h = instruments_harness();
    h.state_mut().open_target(&fixture("multi_angle.cxf"));
    h.run();
    h.state_mut().select_target_sample(1);
    h.run();
    h
}

#[test]
fn fit_to_target_applies_the_fit_as_one_edit_and_undo_restores_the_design() {
    let mut h = deep_blue_target_harness();
    assert_eq!(target_label(h.state()), "Deep blue (multi_angle.cxf)");
    let before = h.state().design().clone();
    let failing = shown_comparison(h.state());
    assert_eq!(failing.pass, Some(false), "a red design against a blue");

    h.get_by_label("Fit to target").click();
    h.step();
    wait_until(&mut h, "the fit", |app| !app.is_fitting());
    h.run();
    let fitted = h.state().design().clone();
    assert_ne!(fitted.albedo, before.albedo, "ρ(λ) was fitted");
    assert_eq!(
        (fitted.thickness_um, &fitted.gloss, &fitted.name),
        (before.thickness_um, &before.gloss, &before.name),
        "only ρ is free"
    );
    // The report is the core's: the fitted design against the standard.
    let done = h.state().last_fit().expect("a fit report");
    assert_eq!(done.fit.design, fitted);
    let after = shown_comparison(h.state());
    assert_eq!(after.angles.len(), done.report.comparison.angles.len());
    for (shown, report) in after.angles.iter().zip(&done.report.comparison.angles) {
        assert!((shown.difference.de00 - report.difference.de00).abs() < 1e-9);
    }
    let worst_before = failing
        .angles
        .iter()
        .map(|a| a.difference.de00)
        .fold(0.0, f64::max);
    let worst_after = after
        .angles
        .iter()
        .map(|a| a.difference.de00)
        .fold(0.0, f64::max);
    assert!(
        worst_after < worst_before / 5.0,
        "ΔE00 {worst_before:.2} → {worst_after:.2}"
    );
    h.get_by_label_contains("Fit of ρ(λ) to sample \"Deep blue\"");
    h.get_by_label("residual ΔE00");

    undo_key(&mut h);
    assert_eq!(h.state().design(), &before, "one undo step restores it");
    redo_key(&mut h);
    assert_eq!(h.state().design(), &fitted, "and redo brings the fit back");
}

#[test]
fn fit_to_target_fits_what_is_ticked_and_nothing_ticked_cannot_fit() {
    let mut h = deep_blue_target_harness();
    assert_eq!(
        h.state().fit_free(),
        FreeParameters::RHO,
        "ρ alone by default"
    );
    h.get_by_role_and_label(Role::CheckBox, "h").click();
    h.run();
    assert_eq!(
        h.state().fit_free(),
        FreeParameters::parse("rho,h").expect("names")
    );
    let before = h.state().design().clone();

    h.get_by_label("Fit to target").click();
    h.step();
    wait_until(&mut h, "the fit", |app| !app.is_fitting());
    h.run();
    let fitted = h.state().design().clone();
    let done = h.state().last_fit().expect("a fit report");
    assert_eq!(done.fit.design, fitted);
    let coat: Vec<_> = done.fit.coat.iter().map(|p| p.name).collect();
    assert_eq!(coat, ["h"], "h was free, and only h of the coat");
    assert!((fitted.thickness_um - done.fit.coat[0].fitted).abs() < 1e-9);
    assert_ne!(fitted.albedo, before.albedo, "ρ(λ) was fitted");
    assert_eq!(
        (&fitted.gloss, &fitted.name),
        (&before.gloss, &before.name),
        "the gloss was not free"
    );
    h.get_by_label_contains("Fit of ρ(λ), h to sample \"Deep blue\"");
    h.get_by_label_contains("clear coat thickness h");
    undo_key(&mut h);
    assert_eq!(h.state().design(), &before, "one undo step restores it");

    // Nothing ticked: the button is off, and the action says why.
    h.get_by_role_and_label(Role::CheckBox, "ρ(λ)").click();
    h.run();
    h.get_by_role_and_label(Role::CheckBox, "h").click();
    h.run();
    assert!(!h.state().fit_free().any());
    assert_fit_refused(&mut h, "nothing is free");
}

/// *Fit to target* is off, and asked for anyway it says `why` and leaves the
/// design alone.
fn assert_fit_refused(h: &mut Harness<'_, CoatlabApp>, why: &str) {
    assert!(
        h.get_by_label("Fit to target")
            .accesskit_node()
            .is_disabled()
    );
    let before = h.state().design().clone();
    h.state_mut().fit_to_target();
    h.run();
    assert!(!h.state().is_fitting());
    assert!(has_notice(h.state(), true, why));
    assert_eq!(h.state().design(), &before);
}

#[test]
fn fit_to_target_needs_a_measured_target() {
    let mut h = instruments_harness();
    h.get_by_role_and_label(Role::ComboBox, "Target").click();
    h.run();
    h.get_all_by_label("Deep blue")
        .last()
        .expect("the preset in the list")
        .click();
    h.run();
    assert!(h.state().target_view().is_some());
    assert_fit_refused(&mut h, "needs a measured target");
}

#[test]
fn a_csv_of_spectra_is_compared_at_the_geometry_the_person_states() {
    let dir = temp_dir("csv-target");
    let mut h = instruments_harness();
    // The design's own 45°as45° reading as a CSV, as `coatlab color` reads one.
    let analysis = h.state().analysis().expect("valid design");
    let m = &analysis.measurement;
    let at_45 = m
        .angles
        .iter()
        .find(|a| a.aspecular_deg == 45.0)
        .expect("the 45° reading");
    // And a metamer of it under D65: the same reading plus a metameric black.
    // (in proportion to the reflectance, so that it stays positive).
    let wiggle: Vec<f64> = m
        .wavelength_nm
        .iter()
        .zip(&at_45.reflectance_factor)
        .map(|(nm, r)| 0.4 * r * ((nm - 380.0) / 20.0).sin())
        .collect();
    let black = metameric_black::metameric_black(&m.wavelength_nm, &wiggle);
    let mut csv = String::from("wavelength_nm,own,metamer\n");
    for ((nm, r), b) in m
        .wavelength_nm
        .iter()
        .zip(&at_45.reflectance_factor)
        .zip(&black)
    {
        csv.push_str(&format!("{nm},{r},{}\n", r + b));
    }
    let file = dir.join("own.csv");
    std::fs::write(&file, csv).expect("write");
    h.state_mut()
        .set_native_dialog(Some(FakeDialog::new(DialogOutcome::Chosen(file))));
    h.get_by_label("Target from file…").click();
    wait_until(&mut h, "the CSV target", |app| app.target_view().is_some());
    h.run();

    // No geometry in a CSV: nothing compared until one is stated.
    let c = shown_comparison(h.state());
    assert!(c.angles.is_empty() && c.not_comparable.len() == 1, "{c:?}");
    h.get_by_role_and_label(Role::ComboBox, "Measured at")
        .click();
    h.run();
    h.get_by_role_and_label(Role::Button, "45°as45°").click();
    h.run();
    let c = shown_comparison(h.state());
    assert_eq!(c.angles.len(), 1);
    assert!(c.angles[0].difference.de00 < 1e-6, "{:?}", c.angles[0]);
    assert_eq!(c.pass, Some(true));
    assert!(h.query_all_by_label("pass").next().is_some());
    assert!(h.query_by_label_contains("metameric").is_none());

    // The metamer passes under D65 and is warned about.
    h.get_by_role_and_label(Role::ComboBox, "Sample").click();
    h.run();
    h.get_by_role_and_label(Role::Button, "metamer").click();
    h.run();
    let c = shown_comparison(h.state());
    assert_eq!(c.pass, Some(true), "{c:?}");
    assert!(c.metameric, "{c:?}");
    h.get_by_label_contains("Warning: metameric");
    let _ = std::fs::remove_dir_all(dir);
}

/// The two states docs/workflow.md shows: the Instruments tab with a measured
/// standard as the target, then after *Fit to target*, drawn by wgpu and written to
/// `target/gui-preview/workflow-*.png` to look at. The swatches put the target's
/// colour beside the design's.
#[test]
fn the_workflow_pictures_show_the_target_and_the_fit() {
    let mut app = app();
    app.set_tab(Tab::Instruments);
    let mut h = app_harness(egui::vec2(1500.0, 1350.0), true, app);
    h.run();
    h.state_mut().open_target(&fixture("multi_angle.cxf"));
    h.run();
    h.state_mut().select_target_sample(1);
    h.run();
    let blue = |rgb: [u8; 3]| rgb[2] > rgb[0];
    let swatches = &h.state().target_view().expect("target").swatches;
    assert!(swatches.iter().all(|s| s.target_srgb.is_some_and(blue)));
    assert!(
        swatches.iter().all(|s| !blue(s.design_srgb)),
        "a red design"
    );
    save_screenshot(&mut h, "workflow-target.png");

    h.get_by_label("Fit to target").click();
    h.step();
    wait_until(&mut h, "the fit", |app| !app.is_fitting());
    h.run();
    let swatches = &h.state().target_view().expect("target").swatches;
    assert!(
        swatches.iter().all(|s| blue(s.design_srgb)),
        "fitted to blue"
    );
    save_screenshot(&mut h, "workflow-fit.png");
}
