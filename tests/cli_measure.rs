//! End-to-end tests of `coatlab measure` on the committed presets.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;

use common::{exit, failure};

#[path = "../crates/coatlab-core/tests/support/instrument_reference.rs"]
mod instrument_reference;

use coatlab_core::design::PaintDesign;
use coatlab_core::paint::gloss::GlossExponent;
use instrument_reference::{DESIGNS, Readings, disagreements, reference, workspace_root};

fn coatlab() -> Command {
    Command::new(env!("CARGO_BIN_EXE_coatlab"))
}

fn preset(slug: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets/presets")
        .join(format!("{slug}.toml"))
}

fn json_of(args: &[&str]) -> serde_json::Value {
    let output = coatlab().args(args).output().expect("coatlab runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).expect("valid JSON")
}

#[test]
fn measure_prints_five_angles_and_three_gloss_readings() {
    let path = preset("signal-red");
    let output = coatlab()
        .arg("measure")
        .arg(&path)
        .output()
        .expect("coatlab runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let text = String::from_utf8_lossy(&output.stdout);
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
    let json = json_of(&["measure", "--json", path.to_str().expect("utf-8 path")]);
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
        let json = json_of(&["measure", "--json", path.to_str().expect("utf-8 path")]);
        let found = disagreements(&rows, key, &readings_of(&json, &path));
        assert!(found.is_empty(), "{found:#?}");
    }
    // The comparison is sharp enough: the 25° and 45° readings of the red swapped
    // (ΔL* ≈ 8e-3) must fail it.
    let path = preset("signal-red");
    let mut json = json_of(&["measure", "--json", path.to_str().expect("utf-8 path")]);
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
    json_of(&[
        "measure",
        "--json",
        design.to_str().expect("path"),
        "--target",
        target.to_str().expect("path"),
    ])
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
    let output = coatlab()
        .arg("measure")
        .arg(&bad)
        .output()
        .expect("coatlab runs");
    let err = failure(&output, exit::DATA);
    assert!(err.contains("broken.toml") && err.contains("-45"), "{err}");
    let missing = coatlab()
        .arg("measure")
        .arg(dir.join("nope.toml"))
        .output()
        .expect("coatlab runs");
    assert!(failure(&missing, exit::NO_INPUT).contains("nope.toml"));
    // A target that is bad is bad input too; a design that is not text is bad data.
    let target = coatlab()
        .arg("measure")
        .arg(preset("signal-red"))
        .arg("--target")
        .arg(&bad)
        .output()
        .expect("coatlab runs");
    assert!(failure(&target, exit::DATA).contains("broken.toml"));
    let binary = dir.join("binary.toml");
    std::fs::write(&binary, b"\xff\xfe\x00format = 1").expect("write");
    let output = coatlab()
        .arg("measure")
        .arg(&binary)
        .output()
        .expect("coatlab runs");
    assert!(failure(&output, exit::DATA).contains("binary.toml"));
    let output = coatlab()
        .args(["measure", "--colour"])
        .arg(preset("signal-red"))
        .output()
        .expect("coatlab runs");
    failure(&output, exit::USAGE);
    std::fs::remove_dir_all(&dir).ok();
}
