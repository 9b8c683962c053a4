//! End-to-end tests of `coatlab export`: each format written and read back by
//! Coatlab's own readers (the measurement readers, `coatlab fit`, the scene
//! loader), and every bad input refused with a message naming it, leaving the
//! output file as it was.

use std::path::Path;
use std::process::Output;

mod common;

use common::{json, preset, run};

#[path = "../crates/coatlab-core/tests/support/gltf_testdata.rs"]
mod gltf_testdata;

use coatlab_core::design::PaintDesign;
use coatlab_core::export::virtual_readings;
use coatlab_core::measurement;

fn export(design: &Path, format: &str, out: &Path, extra: &[&str]) -> Output {
    let mut args: Vec<&std::ffi::OsStr> = vec![
        "export".as_ref(),
        design.as_os_str(),
        "--format".as_ref(),
        format.as_ref(),
        "--out".as_ref(),
        out.as_os_str(),
    ];
    args.extend(extra.iter().map(std::ffi::OsStr::new));
    run(&args)
}

fn succeeded(output: &Output) -> String {
    let text = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(
        output.status.success(),
        "{}\n{text}",
        String::from_utf8_lossy(&output.stderr)
    );
    text
}

fn refused(output: &Output, code: i32) -> String {
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(code), "{stderr}");
    stderr
}

#[test]
fn cgats_and_cxf_exports_read_back_and_fit_back_through_the_cli() {
    let dir = tempfile::tempdir().expect("temp dir");
    let red = preset("signal-red");
    let design = PaintDesign::load(&red).expect("preset");
    let written = virtual_readings(&design).expect("readings");
    for (format, name) in [("cgats", "red.txt"), ("cxf", "red.cxf")] {
        let out = dir.path().join(name);
        let said = succeeded(&export(&red, format, &out, &[]));
        assert!(said.contains(&out.display().to_string()), "{said}");
        let bytes = std::fs::read(&out).expect("written");
        let back = measurement::read(&bytes, name).expect("readable");
        assert_eq!(back.samples.len(), written.len());
        for (w, b) in written.iter().zip(&back.samples) {
            assert_eq!((b.geometry, &b.spectrum), (w.geometry, &w.spectrum));
        }
        // `coatlab fit` on all seven geometries (least squares with its smoothness
        // term, the multi-angle readings only), from another pigment under the
        // same coat: the design's colour comes back at every angle.
        let start = dir.path().join("start.toml");
        let mut other = design.clone();
        other.albedo = PaintDesign::load(preset("deep-blue"))
            .expect("preset")
            .albedo;
        other.save(&start).expect("saved");
        let fitted = dir.path().join(format!("{name}.toml"));
        let j = json(&run(&[
            "fit".as_ref(),
            "--target".as_ref(),
            out.as_os_str(),
            "--start".as_ref(),
            start.as_os_str(),
            "--out".as_ref(),
            fitted.as_os_str(),
            "--json".as_ref(),
        ]));
        let angles = j["comparison"]["angles"].as_array().expect("angles");
        assert_eq!(angles.len(), 7, "every geometry compared: {j}");
        for a in angles {
            let de = a["difference"]["dE00"].as_f64().expect("ΔE00");
            assert!(de < 0.05, "{name}: {a}");
        }
    }
}

#[test]
fn gltf_export_prints_its_cost_and_loads_back_with_the_design_on_the_paint() {
    use coatlab_core::scene::gltf_loader::{LoadOptions, load};
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("car.glb");
    let said = succeeded(&export(&preset("deep-blue"), "gltf", &out, &[]));
    // One line per multi-angle geometry, with its ΔE00.
    for geometry in ["45°as15°", "45°as25°", "45°as45°", "45°as75°", "45°as110°"] {
        let line = said
            .lines()
            .find(|l| l.trim_start().starts_with(geometry))
            .unwrap_or_else(|| panic!("{geometry} missing in {said}"));
        let de: f64 = line
            .split_whitespace()
            .last()
            .and_then(|v| v.parse().ok())
            .expect("a ΔE00");
        assert!(de.is_finite() && de >= 0.0, "{line}");
    }
    let scene = load(&out, &LoadOptions::default()).expect("loads");
    let paint = &scene.materials[scene.paint_materials[0] as usize];
    assert_eq!(paint.name, "Coatlab paint: Deep blue");
    assert!(paint.base_color.blue > paint.base_color.red, "{paint:?}");

    // A scene of one's own: its geometry carries the design.
    let Some(models) = gltf_testdata::testdata() else {
        return;
    };
    let toy = models.join("ToyCar/ToyCar.gltf");
    let out = dir.path().join("toy.glb");
    let scene_arg = toy.to_str().expect("UTF-8 path");
    succeeded(&export(
        &preset("deep-blue"),
        "gltf",
        &out,
        &["--scene", scene_arg],
    ));
    let original = load(&toy, &LoadOptions::default()).expect("ToyCar loads");
    let exported = load(&out, &LoadOptions::default()).expect("the export loads");
    assert_eq!(
        exported.mesh.triangle_count(),
        original.mesh.triangle_count()
    );
    let painted = &exported.materials[exported.paint_materials[0] as usize];
    assert_eq!(painted.name, "Coatlab paint: Deep blue");
}

#[test]
fn bad_inputs_are_refused_by_name_and_the_output_is_untouched() {
    let dir = tempfile::tempdir().expect("temp dir");
    let red = preset("signal-red");
    let out = dir.path().join("out.cxf");
    std::fs::write(&out, "old").expect("old file");
    let untouched = || assert_eq!(std::fs::read_to_string(&out).expect("there"), "old");

    let e = refused(&export(&red, "pdf", &out, &[]), 2);
    assert!(
        e.contains("'pdf' is not an export format: use cxf, cgats or gltf"),
        "{e}"
    );
    untouched();

    let e = refused(&export(&red, "gltf", &out, &[]), 2);
    assert!(e.contains("out.cxf: a gltf export is a .glb file"), "{e}");
    untouched();

    let missing = dir.path().join("no-such-design.toml");
    let e = refused(&export(&missing, "cxf", &out, &[]), 66);
    assert!(e.contains("no-such-design.toml"), "{e}");
    untouched();

    let broken = dir.path().join("broken.toml");
    std::fs::write(
        &broken,
        "format = \"coatlab-paint-design\"\nversion = 1\nname = 3\n",
    )
    .expect("written");
    let e = refused(&export(&broken, "cxf", &out, &[]), 65);
    assert!(e.contains("broken.toml"), "{e}");
    untouched();

    let e = refused(&export(&red, "cxf", &out, &["--scene", "car.glb"]), 2);
    assert!(e.contains("--scene: only for --format gltf"), "{e}");
    untouched();

    let bad_scene = dir.path().join("bad.glb");
    std::fs::write(&bad_scene, "not glTF").expect("written");
    let glb = dir.path().join("car.glb");
    let scene_arg = bad_scene.to_str().expect("UTF-8 path");
    let e = refused(&export(&red, "gltf", &glb, &["--scene", scene_arg]), 65);
    assert!(e.contains("bad.glb"), "{e}");
    assert!(!glb.exists());

    let nowhere = dir.path().join("no-such-dir/out.txt");
    let e = refused(&export(&red, "cgats", &nowhere, &[]), 73);
    assert!(e.contains("no-such-dir"), "{e}");
}
