//! End-to-end tests of `coatlab measure` on the committed presets.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Output;

mod common;

use common::{exit, failure, json, measured_spectra, preset, run, stdout};

#[path = "../crates/coatlab-core/tests/support/measurement_files.rs"]
mod measurement_files;
use measurement_files::{Spectra, as_cxf};

#[path = "../crates/coatlab-core/tests/support/metameric_black.rs"]
mod metameric_black;
use metameric_black::metameric_black;

#[path = "../crates/coatlab-core/tests/support/instrument_reference.rs"]
mod instrument_reference;

use coatlab_core::design::PaintDesign;
use coatlab_core::paint::gloss::GlossExponent;
use instrument_reference::{DESIGNS, Readings, disagreements, reference, workspace_root};

/// `coatlab measure` with `args`; the outcome is the caller's to judge.
fn measure(args: &[&OsStr]) -> Output {
    run(&[&["measure".as_ref()], args].concat())
}

/// What a successful `coatlab measure` with `args` printed.
fn measure_text(args: &[&OsStr]) -> String {
    stdout(&measure(args))
}

/// `coatlab measure --json` with `args`, which must succeed.
fn measure_json(args: &[&OsStr]) -> serde_json::Value {
    json(&measure(&[&["--json".as_ref()], args].concat()))
}

#[test]
fn measure_prints_five_angles_and_three_gloss_readings() {
    let path = preset("signal-red");
    let text = measure_text(&[path.as_os_str()]);
    // Each table row against the independent reference, to the printed rounding
    // (2 decimals for L*a*b*, 1 for GU): the aspecular angle, the detector's signed
    // polar angle (45° − aspecular), then the readings.
    let rows = reference();
    let value = |quantity: &str, angle: f64| {
        rows.iter()
            .find(|r| r.design == "signal-red" && r.quantity == quantity && r.angle_deg == angle)
            .map(|r| r.value)
            .expect("reference row")
    };
    let numbers = |line: &str| -> Vec<f64> {
        line.split(|c: char| c.is_whitespace() || c == '°' || c == '(' || c == ')')
            .filter_map(|w| w.parse().ok())
            .collect()
    };
    for angle in [15.0, 25.0, 45.0, 75.0, 110.0] {
        let line = text
            .lines()
            .find(|l| !l.contains("GU") && numbers(l).len() == 5 && numbers(l)[0] == angle)
            .unwrap_or_else(|| panic!("{angle}° missing from\n{text}"));
        let n = numbers(line);
        assert_eq!(n[1], 45.0 - angle, "detector angle: {line}");
        for (k, quantity) in ["L", "a", "b"].into_iter().enumerate() {
            let want = value(quantity, angle);
            assert!(
                (n[2 + k] - want).abs() <= 0.005 + 1e-4,
                "{quantity}: {line} vs {want}"
            );
        }
    }
    for geometry in [20.0, 60.0, 85.0] {
        let line = text
            .lines()
            .find(|l| l.contains("GU") && numbers(l).first() == Some(&geometry))
            .unwrap_or_else(|| panic!("{geometry}° gloss missing from\n{text}"));
        let n = numbers(line);
        assert_eq!(n.len(), 3, "{line}");
        // 0.05 of rounding, and the reference's gloss tolerance (0.05 GU of
        // misreading at most through the exponent).
        let (total, specular) = (value("total_gu", geometry), value("specular_gu", geometry));
        assert!((n[1] - total).abs() <= 0.1, "{line} vs {total}");
        assert!((n[2] - specular).abs() <= 0.1, "{line} vs {specular}");
    }
}

#[test]
fn measure_json_reports_a_red_as_red_and_its_designed_gloss() {
    let path = preset("signal-red");
    let json = measure_json(&[path.as_os_str()]);
    let angles = json["measurement"]["angles"].as_array().expect("angles");
    assert_eq!(angles.len(), 5);
    let lab = &angles[2]["lab"];
    let (a, b) = (lab["a"].as_f64().expect("a"), lab["b"].as_f64().expect("b"));
    assert!(
        a > 30.0 && a > b.abs() * 0.5,
        "a red has a large positive a*: {lab}"
    );
    // The design asks for 88 GU at 20° with n at 587.6 nm; the instrument weights
    // the dispersive coat by ȳ under D65, which moves the reading by < 1 GU.
    let gloss = json["measurement"]["gloss"].as_array().expect("gloss");
    let g20 = gloss[0]["specular_gu"].as_f64().expect("gloss at 20°");
    assert!((g20 - 88.0).abs() < 1.0, "specular gloss at 20°: {g20}");
}

/// The instrument readings of `json` (the CLI's `measurement`) in the reference's
/// terms, with the exponent the design file gives.
fn readings_of(json: &serde_json::Value, design: &Path) -> Readings {
    let number = |v: &serde_json::Value| v.as_f64().expect("a number");
    let m = &json["measurement"];
    Readings {
        lab: m["angles"]
            .as_array()
            .expect("angles")
            .iter()
            .map(|a| {
                let lab = &a["lab"];
                (
                    number(&a["aspecular_deg"]),
                    [number(&lab["L"]), number(&lab["a"]), number(&lab["b"])],
                )
            })
            .collect(),
        gloss: m["gloss"]
            .as_array()
            .expect("gloss")
            .iter()
            .map(|g| {
                (
                    number(&g["geometry"]),
                    number(&g["specular_gu"]),
                    number(&g["total_gu"]),
                )
            })
            .collect(),
        exponent: match PaintDesign::load(design).expect("design").exponent() {
            Ok(GlossExponent::Finite(m)) => Some(m),
            Ok(GlossExponent::Mirror) => None,
            Err(e) => panic!("{e}"),
        },
    }
}

#[test]
fn measure_json_matches_the_independent_reference() {
    // Every design of the reference, through the binary: multi-angle L*a*b* at all
    // five angles and the gloss at all three geometries (tolerances in
    // crates/coatlab-core/tests/support/instrument_reference.rs).
    let rows = reference();
    for (key, file) in DESIGNS {
        let path = workspace_root().join(file);
        let json = measure_json(&[path.as_os_str()]);
        let found = disagreements(&rows, key, &readings_of(&json, &path));
        assert!(found.is_empty(), "{found:#?}");
    }
    // The comparison is sharp enough: the 25° and 45° readings of the red swapped
    // (ΔL* ≈ 8e-3) must fail it.
    let path = preset("signal-red");
    let mut json = measure_json(&[path.as_os_str()]);
    let angles = json["measurement"]["angles"]
        .as_array_mut()
        .expect("angles");
    let lab_25 = angles[1]["lab"].clone();
    angles[1]["lab"] = angles[2]["lab"].clone();
    angles[2]["lab"] = lab_25;
    let found = disagreements(&rows, "signal-red", &readings_of(&json, &path));
    assert!(
        found.iter().any(|d| d.contains("at 25°")) && found.iter().any(|d| d.contains("at 45°")),
        "{found:#?}"
    );
}

/// `coatlab measure --json` of `design` against `target`.
fn measured_against(design: &Path, target: &Path) -> serde_json::Value {
    measure_json(&[design.as_os_str(), "--target".as_ref(), target.as_os_str()])
}

#[test]
fn measure_against_a_target_reports_delta_e_per_angle() {
    let red = preset("signal-red");
    let json = measured_against(&red, &red);
    let de = json["delta_e00"].as_array().expect("dE00 per angle");
    assert_eq!(de.len(), 5);
    assert!(de.iter().all(|d| d.as_f64() == Some(0.0)));
    let blue = preset("deep-blue");
    let json = measured_against(&red, &blue);
    assert!(json["delta_e00"][0].as_f64().is_some_and(|d| d > 20.0));
}

#[test]
fn measure_refuses_a_bad_file_with_its_name() {
    let dir = std::env::temp_dir().join(format!("coatlab-measure-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let bad = dir.join("broken.toml");
    let text = std::fs::read_to_string(preset("signal-red"))
        .expect("preset")
        .replace("thickness_um = 45", "thickness_um = -45");
    std::fs::write(&bad, text).expect("write");
    let output = measure(&[bad.as_os_str()]);
    let err = failure(&output, exit::DATA);
    assert!(err.contains("broken.toml") && err.contains("-45"), "{err}");
    let missing = measure(&[dir.join("nope.toml").as_os_str()]);
    assert!(failure(&missing, exit::NO_INPUT).contains("nope.toml"));
    // A target that is bad is bad input too; a design that is not text is bad data.
    let target = measure(&[
        preset("signal-red").as_os_str(),
        "--target".as_ref(),
        bad.as_os_str(),
    ]);
    assert!(failure(&target, exit::DATA).contains("broken.toml"));
    let binary = dir.join("binary.toml");
    std::fs::write(&binary, b"\xff\xfe\x00format = 1").expect("write");
    let output = measure(&[binary.as_os_str()]);
    assert!(failure(&output, exit::DATA).contains("binary.toml"));
    let output = measure(&["--colour".as_ref(), preset("signal-red").as_os_str()]);
    failure(&output, exit::USAGE);
    std::fs::remove_dir_all(&dir).ok();
}

// ---------------------------------------------------------------------------------
// Measurement files as targets (CGATS, CxF3): the design's own virtual measurement
// written out and read back must match it exactly; the fixtures of
// crates/coatlab-core/tests/data/measurements/ exercise the geometries.

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../coatlab-core/tests/data/measurements")
        .join(name)
}

/// A CGATS multi-angle file as [`measurement_files::as_cgats`] writes it but without
/// its scale keyword, so the reader must recognise percent from the data.
fn as_cgats(name: &str, spectra: &Spectra) -> String {
    measurement_files::as_cgats(name, spectra).replace("REFLECTANCE_SCALE PERCENT\n", "")
}

#[test]
fn a_design_against_its_own_measurement_file_passes_with_zero_difference() {
    let dir = tempfile::tempdir().expect("temp dir");
    let red = preset("signal-red");
    let json = measure_json(&[red.as_os_str()]);
    // Every other wavelength (10 nm, 380–780 nm): the comparison happens on the
    // file's own wavelengths, where the design's values are exact.
    let spectra = measured_spectra(&json, 2);
    let cgats = dir.path().join("red.cgats");
    std::fs::write(&cgats, as_cgats("Signal red", &spectra)).expect("write");
    let cxf = dir.path().join("red.cxf");
    std::fs::write(&cxf, as_cxf("Signal red", &spectra)).expect("write");
    for (file, format) in [(&cgats, "CGATS"), (&cxf, "CxF3")] {
        let json = measure_json(&[red.as_os_str(), "--target".as_ref(), file.as_os_str()]);
        assert_eq!(json["target_kind"], "measurement");
        assert_eq!(json["target_format"], format);
        assert_eq!(json["target"], "Signal red");
        let c = &json["comparison"];
        let angles = c["angles"].as_array().expect("angles");
        assert_eq!(angles.len(), 5, "{format}");
        for a in angles {
            let d = &a["difference"];
            for key in ["dL", "da", "db", "dC", "dH", "dE00", "dEab", "dECMC"] {
                assert!(
                    d[key].as_f64().expect(key).abs() < 1e-9,
                    "{format} {key}: {a}"
                );
            }
            assert_eq!(a["pass"], true);
            for m in a["metamerism"].as_array().expect("metamerism") {
                assert!(m["dE00"].as_f64().expect("index") < 1e-9, "{m}");
            }
        }
        assert_eq!(c["pass"], true);
        assert_eq!(c["metameric"], false);
    }
    // Percent was recognised from the data, and said.
    let json = measure_json(&[red.as_os_str(), "--target".as_ref(), cgats.as_os_str()]);
    assert!(
        json["reflectance_scale"]
            .as_str()
            .expect("said")
            .contains("percent")
    );

    // Another design against the red's file fails, at every angle, in text too.
    let blue = preset("deep-blue");
    let text = measure_text(&[blue.as_os_str(), "--target".as_ref(), cgats.as_os_str()]);
    assert!(text.contains("Against sample \"Signal red\""), "{text}");
    assert_eq!(
        text.lines()
            .filter(|l| l.trim_end().ends_with("FAIL"))
            .count(),
        5,
        "{text}"
    );
    assert!(text.contains("Result: FAIL at 5 of 5 geometries"), "{text}");
    assert!(text.contains("Metamerism index"), "{text}");
}

#[test]
fn the_tolerance_sets_the_formula_and_the_limit_per_angle() {
    let red = preset("signal-red");
    let target = fixture("multi_angle.cxf");
    let json = measure_json(&[
        red.as_os_str(),
        "--target".as_ref(),
        target.as_os_str(),
        "--sample".as_ref(),
        "Signal red".as_ref(),
        "--tolerance".as_ref(),
        "cmc:2.5,15=4,as110=6".as_ref(),
    ]);
    let c = &json["comparison"];
    assert_eq!(c["tolerance"]["formula"], "dECMC");
    let angles = c["angles"].as_array().expect("angles");
    // The file's six angles, −15° included: the virtual instrument reads any
    // in-plane geometry.
    let aspecular: Vec<f64> = angles
        .iter()
        .map(|a| a["geometry"]["aspecular_deg"].as_f64().expect("angle"))
        .collect();
    assert_eq!(aspecular, [-15.0, 15.0, 25.0, 45.0, 75.0, 110.0]);
    for a in angles {
        let want = match a["geometry"]["aspecular_deg"].as_f64() {
            Some(15.0) => 4.0,
            Some(110.0) => 6.0,
            _ => 2.5,
        };
        assert_eq!(a["limit"].as_f64(), Some(want), "{a}");
        let value = a["value"].as_f64().expect("value");
        assert_eq!(value, a["difference"]["dECMC"].as_f64().expect("cmc"));
        assert_eq!(a["pass"].as_bool(), Some(value <= want));
    }
    // The file's gloss readings beside the design's.
    let gloss = c["gloss"].as_array().expect("gloss");
    assert_eq!(gloss.len(), 2);
    assert_eq!(gloss[0]["target_gu"].as_f64(), Some(88.5));
    let bad = measure(&[
        red.as_os_str(),
        "--target".as_ref(),
        target.as_os_str(),
        "--tolerance".as_ref(),
        "cmc:-1".as_ref(),
    ]);
    assert!(failure(&bad, exit::USAGE).contains("-1"));
}

#[test]
fn sphere_readings_are_read_by_the_sphere_and_45_0_is_the_45_as_45_reading() {
    let red = preset("signal-red");
    let json = measured_against(&red, &fixture("sphere_and_45_0.cxf"));
    let c = &json["comparison"];
    let angles = c["angles"].as_array().expect("angles");
    let kinds: Vec<String> = angles
        .iter()
        .map(|a| {
            let g = &a["geometry"];
            format!("{} {}", g["kind"], g["specular"])
        })
        .collect();
    assert_eq!(
        kinds,
        [
            "\"sphere\" \"included\"",
            "\"sphere\" \"excluded\"",
            "\"directional\" null"
        ]
    );
    assert!(c["not_comparable"].as_array().expect("listed").is_empty());
    // Each design Lab is the instrument's reading of that geometry under D65/10°:
    // the sphere's SCI and SCE, the 45:0 reading's the 45as45 one (the comparison
    // sums on the file's 5 nm grid from 360 nm, where the design is held flat
    // beyond 380–780 nm: agreement to a few thousandths).
    let m = &json["measurement"];
    for (table, a) in [
        (&m["sphere"][0]["lab"], &angles[0]),
        (&m["sphere"][1]["lab"], &angles[1]),
        (&m["angles"][2]["lab"], &angles[2]),
    ] {
        let design = &a["design_lab"];
        for k in ["L", "a", "b"] {
            let (x, y) = (
                table[k].as_f64().expect("k"),
                design[k].as_f64().expect("k"),
            );
            assert!((x - y).abs() < 0.02, "{k}: {x} vs {y}");
        }
    }
    // With its specular component the sphere reads lighter.
    let l = |i: usize| m["sphere"][i]["lab"]["L"].as_f64().expect("L");
    assert!(l(0) > l(1) + 1.0, "SCI {} vs SCE {}", l(0), l(1));
    assert!(
        c["notes"].to_string().contains("held at its end values"),
        "{c}"
    );
}

#[test]
fn a_lab_only_target_is_compared_under_its_own_conditions() {
    let red = preset("signal-red");
    let text = measure_text(&[
        red.as_os_str(),
        "--target".as_ref(),
        fixture("lab_only_d50.cgats").as_os_str(),
        "--sample".as_ref(),
        "1".as_ref(),
    ]);
    // No geometry in the file: nothing to compare, and it says so.
    assert!(text.contains("not comparable"), "{text}");
    assert!(text.contains("Result: nothing to compare"), "{text}");
    // With the geometry stated in the header, it compares under D50/2°.
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("lab.cgats");
    let with_geometry = std::fs::read_to_string(fixture("lab_only_d50.cgats"))
        .expect("fixture")
        .replace("CREATED", "MEASUREMENT_GEOMETRY \"45as45\"\nCREATED");
    std::fs::write(&path, with_geometry).expect("write");
    let json = measure_json(&[
        red.as_os_str(),
        "--target".as_ref(),
        path.as_os_str(),
        "--sample".as_ref(),
        "Signal red".as_ref(),
    ]);
    let a = &json["comparison"]["angles"][0];
    assert_eq!(a["conditions"], "D50/CIE 1931 2°");
    assert_eq!(a["target_source"], "stated");
    assert_eq!(a["target_lab"]["L"].as_f64(), Some(42.1));
    assert!(a["metamerism"].as_array().expect("list").is_empty());
}

#[test]
fn bad_measurement_targets_and_samples_are_refused() {
    let red = preset("signal-red");
    let run = |target: &Path, extra: &[&str]| {
        let mut args = vec![red.as_os_str(), "--target".as_ref(), target.as_os_str()];
        args.extend(extra.iter().map(OsStr::new));
        measure(&args)
    };
    let e = failure(&run(&fixture("bad_number_of_sets.cgats"), &[]), exit::DATA);
    assert!(e.contains("bad_number_of_sets.cgats, line 13"), "{e}");
    let e = failure(&run(&fixture("bad_xml_bomb.cxf"), &[]), exit::DATA);
    assert!(e.contains("DTD"), "{e}");
    // Two standards and no --sample; a --sample that is not there.
    let e = failure(&run(&fixture("multi_angle.cxf"), &[]), exit::USAGE);
    assert!(e.contains("Signal red, Deep blue"), "{e}");
    let e = failure(
        &run(&fixture("multi_angle.cxf"), &["--sample", "7"]),
        exit::USAGE,
    );
    assert!(e.contains("no sample \"7\""), "{e}");
    // --sample means nothing for a design target, or without a target.
    let e = failure(&run(&preset("deep-blue"), &["--sample", "1"]), exit::USAGE);
    assert!(e.contains("--sample"), "{e}");
    let output = measure(&[red.as_os_str(), "--sample".as_ref(), "1".as_ref()]);
    failure(&output, exit::USAGE);
}

#[test]
fn a_metameric_match_passes_under_d65_and_is_warned_about() {
    let dir = tempfile::tempdir().expect("temp dir");
    let red = preset("signal-red");
    let json = measure_json(&[red.as_os_str()]);
    let (w, angles) = measured_spectra(&json, 2);
    let wiggle: Vec<f64> = w
        .iter()
        .map(|nm| 0.03 * ((nm - 380.0) / 30.0).sin())
        .collect();
    let black = metameric_black(&w, &wiggle);
    let metamer: Vec<(f64, Vec<f64>)> = angles
        .into_iter()
        .map(|(a, r)| (a, r.iter().zip(&black).map(|(x, b)| x + b).collect()))
        .collect();
    let path = dir.path().join("metamer.cgats");
    std::fs::write(&path, as_cgats("Metamer", &(w, metamer))).expect("write");
    let text = measure_text(&[red.as_os_str(), "--target".as_ref(), path.as_os_str()]);
    assert!(text.contains("Result: PASS"), "{text}");
    assert!(text.contains("warning: the pair is metameric"), "{text}");
    let json = measure_json(&[red.as_os_str(), "--target".as_ref(), path.as_os_str()]);
    let c = &json["comparison"];
    assert_eq!(c["metameric"], true);
    for a in c["angles"].as_array().expect("angles") {
        assert!(
            a["difference"]["dE00"].as_f64().expect("dE00") < 1e-6,
            "{a}"
        );
    }
}

#[test]
fn the_design_files_tolerance_is_used_unless_one_is_given() {
    let dir = tempfile::tempdir().expect("temp dir");
    // Deep blue against red fails by tens of ΔE00; a design-file limit of 100 passes.
    let mut blue = PaintDesign::load(preset("deep-blue")).expect("preset");
    blue.tolerance = Some("de00:100".parse().expect("tolerance"));
    let path = dir.path().join("blue.toml");
    blue.save(&path).expect("save");
    let red = preset("signal-red");
    let text = measure_text(&[path.as_os_str(), "--target".as_ref(), red.as_os_str()]);
    assert!(text.contains("ΔE00 ≤ 100 (from the design file)"), "{text}");
    assert!(text.contains("Result: PASS"), "{text}");
    // --tolerance wins.
    let json = measure_json(&[
        path.as_os_str(),
        "--target".as_ref(),
        red.as_os_str(),
        "--tolerance".as_ref(),
        "1".as_ref(),
    ]);
    assert_eq!(json["tolerance_source"], "command line");
    assert_eq!(json["comparison"]["pass"], false);
    let json = measure_json(&[path.as_os_str(), "--target".as_ref(), red.as_os_str()]);
    assert_eq!(json["tolerance_source"], "design");
    assert_eq!(json["comparison"]["pass"], true);
}
