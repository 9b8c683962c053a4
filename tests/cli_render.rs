//! End-to-end tests of `coatlab render`: small renders of the built-in car and of
//! the shared glTF models, and the error message of every bad input.

mod common;

use std::path::PathBuf;

use common::{exit, failure, stdout};

const TESTDATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/testdata/gltf");

fn out_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name)
}

/// Width and height from a PNG's IHDR chunk.
fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
    assert_eq!(&bytes[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    (be(16), be(20))
}

#[test]
fn renders_the_built_in_car_to_png_with_a_speed_line() {
    let out = out_path("car.png");
    let _ = std::fs::remove_file(&out);
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_coatlab"))
        .args([
            "render",
            "--size",
            "48x27",
            "--spp",
            "2",
            "--wavelengths",
            "8",
            "--out",
        ])
        .arg(&out)
        .output()
        .expect("coatlab runs");
    let text = stdout(&output);
    let last = text.lines().last().expect("a last line");
    assert!(
        last.contains("M samples/s") && last.contains("M rays/s"),
        "{last}"
    );
    assert!(
        last.contains("2 spp") && last.contains("8 wavelengths"),
        "{last}"
    );
    let bytes = std::fs::read(&out).expect("the PNG was written");
    assert_eq!(png_size(&bytes), (48, 27));
    // The progress bar went to standard error.
    let err = String::from_utf8_lossy(&output.stderr);
    assert!(err.contains("100%"), "{err}");
}

fn render_to(out: &PathBuf, extra: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_coatlab"))
        .arg("render")
        .args(extra)
        .arg("--out")
        .arg(out)
        .output()
        .expect("coatlab runs")
}

#[test]
fn every_model_environment_and_exr_output_works() {
    let exr = out_path("car.exr");
    let output = render_to(
        &exr,
        &[
            "--size",
            "32x18",
            "--spp",
            "1",
            "--model",
            "phong-fit",
            "--environment",
            "booth-a",
        ],
    );
    let text = stdout(&output);
    assert!(text.contains("Phong (best fit)"), "{text}");
    let bytes = std::fs::read(&exr).expect("the EXR was written");
    assert_eq!(
        &bytes[..4],
        &[0x76, 0x2f, 0x31, 0x01],
        "OpenEXR magic number"
    );
    for environment in ["studio", "booth-d65", "booth-f11", "outdoor"] {
        let png = out_path(&format!("car-{environment}.png"));
        let output = render_to(
            &png,
            &[
                "--size",
                "24x16",
                "--spp",
                "1",
                "--wavelengths",
                "4",
                "--environment",
                environment,
                "--model",
                "phong-naive",
            ],
        );
        stdout(&output);
        assert_eq!(png_size(&std::fs::read(&png).expect("png")), (24, 16));
    }
    // Adaptive sampling: --spp is the mean over the image.
    let output = render_to(
        &out_path("adaptive.png"),
        &[
            "--size",
            "24x16",
            "--spp",
            "8",
            "--wavelengths",
            "4",
            "--adaptive",
            "on",
        ],
    );
    let text = stdout(&output);
    assert!(text.contains("8 spp mean, adaptive"), "{text}");
    // A time budget instead of a sample count.
    let output = render_to(
        &out_path("timed.png"),
        &["--size", "24x16", "--seconds", "0.3", "--wavelengths", "4"],
    );
    stdout(&output);
}

#[test]
fn bad_inputs_are_refused_with_a_reason_and_no_panic() {
    let png = out_path("never.png");
    let garbage_map = out_path("garbage.exr");
    std::fs::write(&garbage_map, b"v/1\x01 not really an EXR").expect("write");
    let garbage_map = garbage_map.to_str().expect("utf-8").to_owned();
    let usage = exit::USAGE;
    let cases: Vec<(Vec<String>, i32, &str)> = vec![
        (vec!["--size".into(), "48".into()], usage, "WIDTHxHEIGHT"),
        (vec!["--size".into(), "0x10".into()], usage, "1 to 16384"),
        (
            vec!["--model".into(), "lambert".into()],
            usage,
            "phong-naive",
        ),
        (
            vec!["--wavelengths".into(), "0".into()],
            usage,
            "--wavelengths 0",
        ),
        (vec!["--spp".into(), "0".into()], usage, "--spp 0"),
        (
            vec!["--adaptive".into(), "maybe".into()],
            usage,
            "use on or off",
        ),
        (
            vec![
                "--adaptive".into(),
                "on".into(),
                "--adaptive-floor".into(),
                "0".into(),
            ],
            usage,
            "--adaptive-floor: floor 0: must be in (0, 1]",
        ),
        (vec!["--seconds".into(), "-1".into()], usage, "--seconds -1"),
        (
            vec!["--environment".into(), "moonlight".into()],
            usage,
            "no such file",
        ),
        (
            vec!["--environment".into(), "/nonexistent/sky.exr".into()],
            exit::NO_INPUT,
            "no such file",
        ),
        (
            vec!["--environment".into(), garbage_map],
            exit::DATA,
            "not a readable OpenEXR file",
        ),
        (
            vec!["--paint-material".into(), "Chrome".into()],
            usage,
            "body, glass",
        ),
        (
            vec!["--scene".into(), "/nonexistent/car.glb".into()],
            exit::NO_INPUT,
            "/nonexistent/car.glb",
        ),
        (
            vec!["--design".into(), "/nonexistent/paint.toml".into()],
            exit::NO_INPUT,
            "/nonexistent/paint.toml",
        ),
    ];
    for (args, code, expected) in cases {
        // Small defaults for whatever the case does not set itself.
        let mut full = args.clone();
        for (flag, value) in [("--size", "8x8"), ("--spp", "1")] {
            let timed = flag == "--spp" && args.iter().any(|a| a == "--seconds");
            if !timed && !args.iter().any(|a| a == flag) {
                full.extend([flag.to_owned(), value.to_owned()]);
            }
        }
        let refs: Vec<&str> = full.iter().map(String::as_str).collect();
        let output = render_to(&png, &refs);
        let err = failure(&output, code);
        assert!(err.contains(expected), "{args:?}: {err}");
        // Each cause once: a message that names its cause must not get it appended
        // again (`cannot read F: No such file or directory: No such file or directory`).
        let parts: Vec<&str> = err.trim().split(": ").collect();
        assert!(
            parts.windows(2).all(|pair| pair[0] != pair[1]),
            "{args:?}: a cause is repeated in {err}"
        );
    }
    let output = render_to(&out_path("image.jpg"), &["--size", "8x8", "--spp", "1"]);
    assert!(failure(&output, exit::USAGE).contains(".png or .exr"));
    // An output that cannot be written.
    let output = render_to(
        &out_path("no-such-folder/image.png"),
        &["--size", "8x8", "--spp", "1", "--wavelengths", "4"],
    );
    assert!(failure(&output, exit::CANT_CREATE).contains("no-such-folder/image.png"));

    // A truncated scene file.
    let bytes = b"glTF\x02\x00\x00\x00\xff\x00\x00\x00";
    let cut = out_path("cut.glb");
    std::fs::write(&cut, bytes).expect("write");
    let output = render_to(
        &png,
        &[
            "--scene",
            cut.to_str().expect("utf-8"),
            "--size",
            "8x8",
            "--spp",
            "1",
        ],
    );
    let err = failure(&output, exit::DATA);
    assert!(err.contains("cut.glb"), "{err}");
}

#[test]
fn shared_models_render_or_are_refused_by_name() {
    let dir = PathBuf::from(TESTDATA);
    if !dir.is_dir() {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set but the glTF test models are missing at {}",
            dir.display()
        );
        eprintln!(
            "NOTICE: glTF test models not found at {}; test skipped",
            dir.display()
        );
        return;
    }
    let lambo = dir.join("LamborghiniHuracanGT3/LamborghiniHuracanGT3.glb");
    let png = out_path("lambo.png");
    let output = render_to(
        &png,
        &[
            "--scene",
            lambo.to_str().expect("utf-8"),
            "--paint-material",
            "Material.035",
            "--size",
            "32x18",
            "--spp",
            "1",
            "--wavelengths",
            "4",
        ],
    );
    stdout(&output);
    assert_eq!(png_size(&std::fs::read(&png).expect("png")), (32, 18));

    for (file, extension) in [
        (
            "LamborghiniHuracanGT3/LamborghiniHuracanGT3.meshopt.glb",
            "EXT_meshopt_compression",
        ),
        (
            "CesiumMilkTruck/glTF-Draco/CesiumMilkTruck.gltf",
            "KHR_draco_mesh_compression",
        ),
    ] {
        let path = dir.join(file);
        let output = render_to(
            &png,
            &[
                "--scene",
                path.to_str().expect("utf-8"),
                "--size",
                "8x8",
                "--spp",
                "1",
            ],
        );
        let err = failure(&output, exit::DATA);
        let name = path.file_name().and_then(|n| n.to_str()).expect("name");
        assert!(err.contains(extension) && err.contains(name), "{err}");
    }
}
