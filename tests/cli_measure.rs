//! End-to-end tests of `coatlab measure` on the committed presets.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;

use common::{exit, failure};

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
    for angle in ["15°", "25°", "45°", "75°", "110°"] {
        assert!(text.contains(angle), "{angle} missing from\n{text}");
    }
    for geometry in ["20°", "60°", "85°"] {
        assert!(
            text.lines()
                .any(|l| l.trim_start().starts_with(geometry) && l.contains("GU")),
            "{text}"
        );
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

#[test]
fn measure_against_a_target_reports_delta_e_per_angle() {
    let red = preset("signal-red");
    let json = json_of(&[
        "measure",
        "--json",
        red.to_str().expect("path"),
        "--target",
        red.to_str().expect("path"),
    ]);
    let de = json["delta_e00"].as_array().expect("dE00 per angle");
    assert_eq!(de.len(), 5);
    assert!(de.iter().all(|d| d.as_f64() == Some(0.0)));
    let blue = preset("deep-blue");
    let json = json_of(&[
        "measure",
        "--json",
        red.to_str().expect("path"),
        "--target",
        blue.to_str().expect("path"),
    ]);
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
