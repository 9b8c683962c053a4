//! End-to-end tests of `coatlab fit`: a preset's own virtual measurement, written as
//! CGATS and CxF3, fitted back; unreachable and colour-only standards; refusals.

use std::ffi::OsStr;
use std::path::Path;
use std::process::Output;

mod common;

use common::{exit, failure, json, measured_spectra, preset, run, stdout};

#[path = "../crates/coatlab-core/tests/support/measurement_files.rs"]
mod measurement_files;

use coatlab_core::design::PaintDesign;
use measurement_files::{Spectra, as_cgats, as_cxf, lab_only_cgats};

/// `coatlab fit --target TARGET --out OUT` and `extra`; the outcome is the
/// caller's to judge.
fn fit(target: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "fit".as_ref(),
        "--target".as_ref(),
        target.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ];
    args.extend(extra.iter().map(OsStr::new));
    run(&args)
}

fn number(v: &serde_json::Value) -> f64 {
    v.as_f64().expect("a number")
}

/// A preset's multi-angle reflectance from `coatlab measure --json`, every
/// `step`-th wavelength.
fn spectra_of(design: &Path, step: usize) -> Spectra {
    let j = json(&run(&[
        "measure".as_ref(),
        "--json".as_ref(),
        design.as_os_str(),
    ]));
    measured_spectra(&j, step)
}

#[test]
fn a_presets_measurement_is_fitted_back_and_the_fit_passes_measure() {
    let dir = tempfile::tempdir().expect("temp dir");
    let blue = preset("deep-blue");
    let spectra = spectra_of(&blue, 2);
    for (name, text) in [
        ("blue.cgats", as_cgats("Deep blue", &spectra)),
        ("blue.cxf", as_cxf("Deep blue", &spectra)),
    ] {
        let target = dir.path().join(name);
        std::fs::write(&target, text).expect("write");
        let out = dir.path().join(format!("{name}.toml"));
        let start = blue.to_str().expect("UTF-8 path");
        let j = json(&fit(&target, &out, &["--start", start, "--json"]));
        assert_eq!(j["method"], "least_squares");
        assert_eq!(j["smoothness_weight"].as_f64(), Some(1e-3));
        assert_eq!(j["free"], serde_json::json!(["rho"]));
        let angles = j["comparison"]["angles"].as_array().expect("angles");
        assert_eq!(angles.len(), 5);
        for a in angles {
            assert!(number(&a["difference"]["dE00"]) <= 0.05, "{name}: {a}");
        }
        assert_eq!(j["spectral_rms"].as_array().map(Vec::len), Some(5));
        assert!(j["unreachable"].as_array().expect("list").is_empty());
        // The written design is a valid design with the start's coat, named after
        // the standard, and passes against the standard.
        let fitted = PaintDesign::load(&out).expect("a valid design");
        let start = PaintDesign::load(&blue).expect("preset");
        assert_eq!(fitted.name, "Deep blue");
        assert_eq!(fitted.refractive_index, start.refractive_index);
        assert_eq!(fitted.thickness_um, start.thickness_um);
        let text = stdout(&run(&[
            "measure".as_ref(),
            out.as_os_str(),
            "--target".as_ref(),
            target.as_os_str(),
        ]));
        assert!(text.contains("Result: PASS"), "{text}");
    }
}

#[test]
fn the_coat_is_fitted_from_a_perturbed_start() {
    let dir = tempfile::tempdir().expect("temp dir");
    let red = preset("signal-red");
    let spectra = spectra_of(&red, 2);
    let target = dir.path().join("red.cgats");
    std::fs::write(&target, as_cgats("Signal red", &spectra)).expect("write");
    // The preset with a thicker, more absorbing coat.
    let mut start = PaintDesign::load(&red).expect("preset");
    start.thickness_um *= 1.3;
    start.absorption_per_um = coatlab_core::design::Absorption::Constant(1e-3);
    let start_path = dir.path().join("start.toml");
    start.save(&start_path).expect("save");
    let start_arg = start_path.to_str().expect("UTF-8 path");
    let out = dir.path().join("fitted.toml");
    let j = json(&fit(
        &target,
        &out,
        &["--start", start_arg, "--free", "rho,gloss,h,k,n", "--json"],
    ));
    assert_eq!(
        j["free"],
        serde_json::json!(["rho", "gloss", "h", "k", "n"])
    );
    let coat = j["coat"].as_array().expect("coat parameters");
    let names: Vec<&str> = coat.iter().filter_map(|p| p["name"].as_str()).collect();
    assert_eq!(names, ["n", "gloss", "h", "k"]);
    assert_eq!(number(&coat[2]["start"]), start.thickness_um);
    for a in j["comparison"]["angles"].as_array().expect("angles") {
        assert!(number(&a["difference"]["dE00"]) <= 0.05, "{a}");
    }
    // The written design carries the fitted coat.
    let fitted = PaintDesign::load(&out).expect("a valid design");
    assert_eq!(fitted.thickness_um, number(&coat[2]["fitted"]));
    // The text report names the free parameters and their values.
    let text = stdout(&fit(
        &target,
        &out,
        &["--start", start_arg, "--free", "k,rho"],
    ));
    assert!(text.contains("free: rho, k; kept: gloss, h, n"), "{text}");
    assert!(text.contains("clear coat absorption k"), "{text}");
    assert!(text.contains(" fitted to "), "{text}");
}

#[test]
fn one_geometry_is_inverted_to_the_designs_albedo() {
    let dir = tempfile::tempdir().expect("temp dir");
    let red = preset("signal-red");
    let (w, angles) = spectra_of(&red, 1);
    let single: Spectra = (w, angles.into_iter().filter(|(a, _)| *a == 45.0).collect());
    let target = dir.path().join("red.cgats");
    std::fs::write(&target, as_cgats("Signal red", &single)).expect("write");
    let out = dir.path().join("fitted.toml");
    let text = stdout(&fit(&target, &out, &[]));
    assert!(text.contains("closed form"), "{text}");
    assert!(text.contains("Wrote"), "{text}");
    let fitted = PaintDesign::load(&out).expect("design");
    let original = PaintDesign::load(&red).expect("preset");
    for (nm, rho) in fitted
        .albedo
        .wavelengths_nm()
        .iter()
        .zip(fitted.albedo.values())
    {
        let expected = original.albedo.value_at_nm(*nm);
        assert!(
            (rho - expected).abs() < 1e-4,
            "{nm} nm: {rho} vs {expected}"
        );
    }
}

#[test]
fn an_unreachable_target_is_named_by_wavelength_and_geometry() {
    let dir = tempfile::tempdir().expect("temp dir");
    let white = preset("pure-white");
    let (w, angles) = spectra_of(&white, 2);
    let mut single: Spectra = (w, angles.into_iter().filter(|(a, _)| *a == 45.0).collect());
    let at = single.0.iter().position(|nm| *nm == 600.0).expect("600 nm");
    single.1[0].1[at] = 1.3;
    let target = dir.path().join("too_bright.cgats");
    std::fs::write(&target, as_cgats("White", &single)).expect("write");
    let out = dir.path().join("fitted.toml");
    let start = white.to_str().expect("UTF-8 path");
    let text = stdout(&fit(&target, &out, &["--start", start]));
    assert!(text.contains("cannot be reached at 1 wavelength"), "{text}");
    assert!(
        text.contains("45°as45° at 600 nm: the target reads 1.3000, brighter than ρ = 1"),
        "{text}"
    );
}

#[test]
fn a_lab_only_standard_gets_the_smoothest_metamer() {
    let dir = tempfile::tempdir().expect("temp dir");
    let target = dir.path().join("lab.cgats");
    std::fs::write(
        &target,
        lab_only_cgats("Teal", [45.0, -30.0, -8.0], "D50", "2 degree"),
    )
    .expect("write");
    let out = dir.path().join("teal.toml");
    let j = json(&fit(&target, &out, &["--json"]));
    assert_eq!(j["method"], "smoothest_metamer");
    let a = &j["comparison"]["angles"][0];
    assert_eq!(a["conditions"], "D50/CIE 1931 2°");
    assert!(number(&a["difference"]["dE00"]) < 0.01, "{a}");
    let notes = j["notes"].to_string();
    assert!(notes.contains("metamer"), "{notes}");
    let comparison_notes = j["comparison"]["notes"].to_string();
    assert!(
        comparison_notes.contains("no metamerism index"),
        "{comparison_notes}"
    );
    PaintDesign::load(&out).expect("a valid design");
}

#[test]
fn bad_arguments_and_files_are_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().expect("temp dir");
    let red = preset("signal-red");
    let (w, angles) = spectra_of(&red, 2);
    let target = dir.path().join("red.cgats");
    std::fs::write(&target, as_cgats("Signal red", &(w, angles))).expect("write");
    let out = dir.path().join("out.toml");
    let e = failure(&fit(&target, &out, &["--free", "rho,colour"]), exit::USAGE);
    assert!(e.contains("--free \"colour\": unknown parameter"), "{e}");
    let e = failure(&fit(&target, &out, &["--free", ""]), exit::USAGE);
    assert!(e.contains("--free \"\": unknown parameter"), "{e}");
    // Colours alone cannot fix a coat.
    let lab = dir.path().join("lab.cgats");
    std::fs::write(
        &lab,
        lab_only_cgats("Teal", [45.0, -30.0, -8.0], "D50", "2 degree"),
    )
    .expect("write");
    let e = failure(&fit(&lab, &out, &["--free", "rho,h"]), exit::DATA);
    assert!(e.contains("cannot be fitted to colours"), "{e}");
    let e = failure(&fit(&red, &out, &[]), exit::DATA);
    assert!(e.contains("not a CGATS.17 or CxF3"), "{e}");
    let e = failure(
        &fit(&dir.path().join("missing.cgats"), &out, &[]),
        exit::NO_INPUT,
    );
    assert!(e.contains("missing.cgats"), "{e}");
    let e = failure(&fit(&target, &out, &["--sample", "Blue"]), exit::USAGE);
    assert!(e.contains("--sample"), "{e}");
    assert!(!out.exists());
    // An output that cannot be created; an existing one is replaced whole.
    let e = failure(
        &fit(&target, &dir.path().join("no/such/dir/out.toml"), &[]),
        exit::CANT_CREATE,
    );
    assert!(e.contains("out.toml"), "{e}");
    std::fs::write(&out, "old").expect("write");
    let output = fit(&target, &out, &[]);
    assert!(output.status.success());
    PaintDesign::load(&out).expect("replaced by a valid design");
}
