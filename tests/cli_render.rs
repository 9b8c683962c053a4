//! End-to-end tests of `coatlab render`: small renders of the built-in car and of
//! the shared glTF models, and the error message of every bad input.

mod common;

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

use coatlab_core::colour::spectrum::{MAX_VISIBLE_SAMPLES, WavelengthGrid};
use coatlab_core::design::presets;
use coatlab_core::render::environment::Environment;
use coatlab_core::render::film::Film;
use coatlab_core::render::image_error::{Region, RegionMasks};
use coatlab_core::render::material::{Shading, ShadingModel};
use coatlab_core::render::progressive::{ProgressiveRender, RenderScene, RenderSettings};
use coatlab_core::scene::car::{CarParameters, generate};
use coatlab_core::simd_path::SimdPath;
use common::{ExrImage, assert_mentions, assert_rgb_f32, exit, failure, read_exr, stdout};

#[path = "../crates/coatlab-core/tests/support/gltf_testdata.rs"]
mod gltf_testdata;
use gltf_testdata::testdata;

#[path = "../crates/coatlab-core/tests/support/exr_text.rs"]
mod exr_text;
use exr_text::{expected_attributes, text_attributes};

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

/// `--version` names the hot kernels' SIMD path; `COATLAB_SIMD` forces one the CPU
/// has, and one it does not know (or the CPU lacks) is refused with status 2.
#[test]
fn version_names_the_simd_path_and_coatlab_simd_forces_it() {
    let version = |simd: Option<&str>| {
        let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_coatlab"));
        command.arg("--version").env_remove("COATLAB_SIMD");
        if let Some(simd) = simd {
            command.env("COATLAB_SIMD", simd);
        }
        command.output().expect("coatlab runs")
    };
    let detected = stdout(&version(None));
    assert!(
        detected.contains(&format!("(SIMD path: {})", SimdPath::best().name())),
        "{detected}"
    );
    for path in SimdPath::ALL {
        let output = version(Some(path.name()));
        if path.is_available() {
            let text = stdout(&output);
            assert!(
                text.contains(&format!("(SIMD path: {})", path.name())),
                "{text}"
            );
        } else {
            assert!(failure(&output, 2).contains("lacks"));
        }
    }
    let message = failure(&version(Some("avx9000")), 2);
    assert_mentions(&message, &["COATLAB_SIMD", "portable"]);
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
    assert_mentions(last, &["M samples/s", "M rays/s", "2 spp", "8 wavelengths"]);
    // The hot kernels' SIMD path, as this process (same CPU, same environment)
    // chooses it.
    assert!(
        last.ends_with(&format!(", SIMD path {}", SimdPath::current().name())),
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

/// `coatlab render --size WxH --spp N` to `out`, then `extra`.
fn render_small(out: &PathBuf, size: &str, spp: u32, extra: &[&str]) -> std::process::Output {
    let spp = spp.to_string();
    let mut args = vec!["--size", size, "--spp", &spp];
    args.extend_from_slice(extra);
    render_to(out, &args)
}

/// `coatlab render` to `out` at the size, sample count, wavelength count and
/// seed that [`film_of_the_default_render`] is given, then `extra`: the command
/// and the film it is compared with cannot drift apart.
fn render_seeded(
    out: &PathBuf,
    ((width, height), spp, wavelengths, seed): ((u32, u32), u32, usize, u64),
    extra: &[&str],
) -> std::process::Output {
    let (wavelengths, seed) = (wavelengths.to_string(), seed.to_string());
    let mut args = vec!["--wavelengths", &wavelengths, "--seed", &seed];
    args.extend_from_slice(extra);
    render_small(out, &format!("{width}x{height}"), spp, &args)
}

/// `--wavelengths` takes exactly the counts a visible grid can have, and its help
/// and its refusal state that range from the grid's limits.
#[test]
fn the_wavelength_count_is_checked_against_the_grid_s_limits() {
    let range = format!("1–{MAX_VISIBLE_SAMPLES}");
    let help = stdout(&common::coatlab(&["render", "--help"], ""));
    assert!(help.contains(&range), "{help}");
    let out = out_path("wavelengths-limit.png");
    let fine = ["--size", "4x3", "--spp", "1", "--wavelengths"];
    for (count, accepted) in [
        (1, true),
        (0, false),
        (MAX_VISIBLE_SAMPLES, true),
        (MAX_VISIBLE_SAMPLES + 1, false),
    ] {
        let count_text = count.to_string();
        let mut args = fine.to_vec();
        args.push(&count_text);
        let output = render_to(&out, &args);
        if accepted {
            stdout(&output);
        } else {
            let message = failure(&output, exit::USAGE);
            assert!(
                message.contains(&format!("--wavelengths {count}"))
                    && message.contains(&format!("1 to {MAX_VISIBLE_SAMPLES}")),
                "{message}"
            );
        }
    }
}

#[test]
fn every_model_environment_and_exr_output_works() {
    let exr = out_path("car.exr");
    let output = render_small(
        &exr,
        "32x18",
        1,
        &["--model", "phong-fit", "--environment", "booth-a"],
    );
    let text = stdout(&output);
    assert!(text.contains("Phong (best fit)"), "{text}");
    let image = read_exr(&exr);
    assert_eq!((image.width, image.height), (32, 18));
    for environment in ["studio", "booth-d65", "booth-f11", "outdoor"] {
        let png = out_path(&format!("car-{environment}.png"));
        let output = render_small(
            &png,
            "24x16",
            1,
            &[
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
    let output = render_small(
        &out_path("adaptive.png"),
        "24x16",
        8,
        &["--wavelengths", "4", "--adaptive", "on"],
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

// ---------------------------------------------------------------------------------
// The EXR output read back

/// The film `coatlab render` makes with its defaults (built-in car, the first
/// preset, studio, paint model) at this size, sample count, wavelength count and
/// seed: the same calls and passes (at most 4 samples each) as the command, so
/// the same numbers (renders are deterministic for a seed, whatever the threads).
fn film_of_the_default_render(
    (width, height): (u32, u32),
    spp: u32,
    wavelengths: usize,
    seed: u64,
    environment: Environment,
) -> (ProgressiveRender, RegionMasks) {
    let grid = WavelengthGrid::visible(wavelengths).expect("grid");
    let design = presets::all().into_iter().next().expect("a preset").design;
    let model = design.model(grid).expect("the preset's model");
    let scene = generate(&CarParameters::default());
    let shading = Shading::for_scene(&model, ShadingModel::Paint, &scene);
    let scene = RenderScene::new(scene).expect("scene");
    let camera = scene.default_camera(width, height);
    let masks = RegionMasks::from_scene(&scene, &camera);
    let mut render = ProgressiveRender::new(
        Arc::new(scene),
        Arc::new(environment),
        Arc::new(shading),
        camera,
        RenderSettings::seeded(seed),
    )
    .expect("render");
    render.render_to(spp, 4);
    (render, masks)
}

/// The EXR's pixel (x, y) against the film's mean linear sRGB: equal to f32
/// rounding (the writer converts the same f64 means with the same f32 matrix).
fn assert_exr_holds_film(image: &ExrImage, film: &Film) {
    assert_exr_holds_film_within(image, film, |want| 1e-6 * want.abs().max(1e-3));
}

/// [`assert_exr_holds_film`] to a tolerance that depends on the film's value.
fn assert_exr_holds_film_within(image: &ExrImage, film: &Film, tolerance: impl Fn(f32) -> f32) {
    assert_eq!(
        (image.width, image.height),
        (film.width() as usize, film.height() as usize)
    );
    let mut lit = 0;
    for y in 0..film.height() {
        for x in 0..film.width() {
            let got = image.rgb[(y * film.width() + x) as usize];
            let want = film.mean_linear_srgb(x, y);
            let want = [want.red, want.green, want.blue];
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() <= tolerance(want[c]),
                    "pixel ({x}, {y}) channel {}: EXR {got:?}, film {want:?}",
                    ["R", "G", "B"][c]
                );
            }
            lit += usize::from(want.iter().any(|&v| v > 1e-3));
        }
    }
    assert!(
        lit > film.width() as usize * film.height() as usize / 2,
        "a lit image"
    );
}

#[test]
fn the_exr_is_the_films_linear_srgb_in_32_bit_floats() {
    let exr = out_path("film.exr");
    let _ = std::fs::remove_file(&exr);
    // Not square, so a transposed image cannot pass; red paint, so swapped
    // channels cannot; three samples, so a film of another sample count cannot.
    let (size, spp, wavelengths, seed) = ((24, 16), 3, 8, 7);
    let output = render_seeded(&exr, (size, spp, wavelengths, seed), &[]);
    stdout(&output);
    let image = read_exr(&exr);
    // What the help text and the docs say: 32-bit float R, G, B, sRGB primaries
    // and D65 white.
    assert_rgb_f32(&image);
    let srgb = [0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290];
    assert_eq!(image.chromaticities, Some(srgb));
    let grid = WavelengthGrid::visible(wavelengths).expect("grid");
    let (render, _) =
        film_of_the_default_render(size, spp, wavelengths, seed, Environment::studio(&grid));
    assert_exr_holds_film(&image, render.film());
    // The same seed gives the same file; another seed another image.
    let same = out_path("film-seed-7.exr");
    let output = render_seeded(&same, (size, spp, wavelengths, seed), &[]);
    stdout(&output);
    assert_eq!(
        std::fs::read(&same).expect("written"),
        std::fs::read(&exr).expect("written"),
        "the same command, another file"
    );
    let again = out_path("film-seed-8.exr");
    let output = render_seeded(&again, (size, spp, wavelengths, seed + 1), &[]);
    stdout(&output);
    let other = read_exr(&again);
    let differing = other
        .rgb
        .iter()
        .zip(&image.rgb)
        .filter(|(a, b)| a != b)
        .count();
    assert!(differing > image.rgb.len() / 4, "{differing} pixels differ");
}

/// The display choice (`--tone-map`, `--exposure`) acts on the PNG only: the
/// EXR of the same render is the same file, byte for byte, whatever is chosen
/// (deterministic output: bit-identity is the claim), while the PNGs differ. A
/// bad name is refused naming it, and automatic exposure cannot go into a .film
/// part.
#[test]
fn the_tone_mapping_and_exposure_leave_the_exr_as_it_is() {
    let job = ((24, 16), 2, 8, 5);
    let choices: [&[&str]; 3] = [
        &[],
        &["--tone-map", "reinhard", "--exposure", "auto+1.5"],
        &["--tone-map", "clip", "--exposure", "-2"],
    ];
    let mut exrs = Vec::new();
    let mut pngs = Vec::new();
    for (i, extra) in choices.iter().enumerate() {
        for (ext, files) in [("exr", &mut exrs), ("png", &mut pngs)] {
            let out = out_path(&format!("tone-map-{i}.{ext}"));
            stdout(&render_seeded(&out, job, extra));
            files.push(std::fs::read(&out).expect("written"));
        }
    }
    assert!(
        exrs.iter().all(|e| *e == exrs[0]),
        "an EXR changed with the display"
    );
    assert!(pngs[0] != pngs[1] && pngs[1] != pngs[2] && pngs[0] != pngs[2]);
    let bad = render_seeded(&out_path("tone-map-bad.png"), job, &["--tone-map", "aces"]);
    let message = failure(&bad, 2);
    assert!(message.contains("\"aces\""), "{message}");
    let part = render_seeded(&out_path("tone-map.film"), job, &["--exposure", "auto"]);
    let message = failure(&part, 2);
    assert!(message.contains("--exposure auto"), "{message}");
}

/// The text attributes of an EXR's header (UTF-8), by name, and its compression.
fn exr_header(path: &std::path::Path) -> (BTreeMap<String, String>, exr::prelude::Compression) {
    use exr::prelude::MetaData;
    let meta = MetaData::read_from_file(path, false).expect("an EXR header");
    let header = &meta.headers[0];
    let texts = text_attributes(
        header
            .own_attributes
            .other
            .iter()
            .chain(&header.shared_attributes.other),
    );
    (texts, header.compression)
}

/// `--exr-precision half --exr-compression piz`: half floats within half
/// precision of the film, PIZ in the file, and the header says what made the
/// image (the lighting by its own name, whatever the case it was typed in). The
/// options are refused for a PNG.
#[test]
fn exr_options_and_the_header_record() {
    use coatlab_core::render::film::{EXR_ADAPTATION, exr_attribute};
    use exr::prelude::Compression;

    let exr = out_path("half-piz.exr");
    let _ = std::fs::remove_file(&exr);
    let (size, spp, wavelengths, seed) = ((24, 16), 3, 8, 5);
    let output = render_seeded(
        &exr,
        (size, spp, wavelengths, seed),
        &[
            "--environment",
            "Booth-A",
            "--exr-precision",
            "half",
            "--exr-compression",
            "piz",
        ],
    );
    stdout(&output);
    let image = read_exr(&exr);
    assert_eq!(
        image.channels,
        [
            ("B".into(), "f16"),
            ("G".into(), "f16"),
            ("R".into(), "f16")
        ]
    );
    let grid = WavelengthGrid::visible(wavelengths).expect("grid");
    let (render, _) = film_of_the_default_render(
        size,
        spp,
        wavelengths,
        seed,
        Environment::booth(coatlab_core::colour::cie::Illuminant::A, &grid),
    );
    // Rounded to the nearest half: half an ulp, a relative 2⁻¹¹ (2⁻²⁵ absolute
    // below the normal halves).
    assert_exr_holds_film_within(&image, render.film(), |want| {
        (want.abs() * 2f32.powi(-11)).max(2f32.powi(-25))
    });
    let (attributes, compression) = exr_header(&exr);
    assert_eq!(compression, Compression::PIZ);
    let design = presets::all().into_iter().next().expect("a preset").design;
    let expected = expected_attributes(&[
        (exr_attribute::DESIGN, design.name.as_str()),
        (exr_attribute::SAMPLES_PER_PIXEL, "3"),
        (exr_attribute::SEED, "5"),
        (exr_attribute::WAVELENGTHS, "8 from 405 to 755 nm"),
        (exr_attribute::LIGHTING, "booth-a"),
        (exr_attribute::ADAPTATION, EXR_ADAPTATION),
    ]);
    assert_eq!(attributes, expected);

    // The defaults: 32-bit floats, ZIP; adaptive sampling says its mean.
    let default = out_path("default-options.exr");
    let output = render_small(
        &default,
        "16x9",
        4,
        &["--wavelengths", "4", "--adaptive", "on"],
    );
    stdout(&output);
    assert!(read_exr(&default).channels.iter().all(|(_, t)| *t == "f32"));
    let (attributes, compression) = exr_header(&default);
    assert_eq!(compression, Compression::ZIP16);
    assert_eq!(
        attributes[exr_attribute::SAMPLES_PER_PIXEL],
        "4 mean, adaptive"
    );
    assert_eq!(attributes[exr_attribute::LIGHTING], "studio");
    assert_eq!(attributes[exr_attribute::SEED], "0");

    for (flag, value, refusal) in [
        ("--exr-compression", "zip", "only for .exr output"),
        ("--exr-precision", "half", "only for .exr output"),
    ] {
        let output = render_small(&out_path("options.png"), "8x8", 1, &[flag, value]);
        let message = failure(&output, exit::USAGE);
        assert_mentions(&message, &[flag, refusal]);
    }
    let output = render_small(
        &out_path("bad-options.exr"),
        "8x8",
        1,
        &["--exr-compression", "dwaa"],
    );
    let message = failure(&output, exit::USAGE);
    assert!(message.contains("none, rle, zips, zip, piz"), "{message}");
}

/// Share of blue in the light of the body side's pixels: B / (R + G + B) of their
/// summed linear sRGB.
fn blue_share(image: &ExrImage, masks: &RegionMasks) -> (f64, usize) {
    let (mut sum, mut count) = ([0.0f64; 3], 0);
    for y in 0..image.height {
        for x in 0..image.width {
            if masks.region_at(x as u32, y as u32) == Some(Region::BodySide) {
                for (s, v) in sum.iter_mut().zip(image.rgb[y * image.width + x]) {
                    *s += f64::from(v);
                }
                count += 1;
            }
        }
    }
    (sum[2] / sum.iter().sum::<f64>(), count)
}

#[test]
fn an_exr_environment_map_lights_the_car_in_its_colour() {
    // A sky of blue light only: whatever the paint reflects of it is blue.
    let map = out_path("blue-sky.exr");
    exr::prelude::write_rgb_file(&map, 64, 32, |_, _| (0.0f32, 0.0f32, 1.0f32)).expect("write");
    let args = |environment: &str| {
        [
            "--size",
            "64x36",
            "--spp",
            "4",
            "--wavelengths",
            "16",
            "--environment",
            environment,
        ]
        .map(str::to_owned)
    };
    let lit = out_path("blue-lit.exr");
    let blue_args = args(map.to_str().expect("utf-8"));
    stdout(&render_to(&lit, &blue_args.each_ref().map(String::as_str)));
    let studio = out_path("studio-lit.exr");
    let studio_args = args("studio");
    stdout(&render_to(
        &studio,
        &studio_args.each_ref().map(String::as_str),
    ));

    let grid = WavelengthGrid::visible(16).expect("grid");
    let (_, masks) = film_of_the_default_render((64, 36), 1, 16, 0, Environment::studio(&grid));
    let (blue_lit, count) = blue_share(&read_exr(&lit), &masks);
    let (studio_lit, _) = blue_share(&read_exr(&studio), &masks);
    assert!(count >= 80, "{count} body-side pixels");
    eprintln!(
        "blue share of {count} body-side pixels: studio {studio_lit:.3}, blue sky {blue_lit:.3}"
    );
    // Red paint in the studio's white light reflects little blue; under a blue sky
    // blue is all there is to reflect (the map's blue primary, upsampled to a
    // spectrum, leaks a little into green).
    assert!(
        studio_lit < 0.2 && blue_lit > 0.8,
        "blue share of the body side: studio {studio_lit:.3}, blue sky {blue_lit:.3}"
    );
}

#[test]
fn bad_inputs_are_refused_with_a_reason_and_no_panic() {
    let png = out_path("never.png");
    let garbage_map = out_path("garbage.exr");
    std::fs::write(&garbage_map, b"v/1\x01 not really an EXR").expect("write");
    let garbage_map = garbage_map.to_str().expect("utf-8").to_owned();
    let (usage, no_input) = (exit::USAGE, exit::NO_INPUT);
    let garbage_arg = format!("--environment {garbage_map}");
    // Refused as a usage error: the arguments (split at spaces), the message.
    let usage_cases: [(&str, &str); 22] = [
        ("--size 48", "WIDTHxHEIGHT"),
        ("--size 0x10", "1 to 16384"),
        ("--size 16384x16384", "160 bytes a pixel"),
        ("--model lambert", "phong-naive"),
        ("--wavelengths 0", "--wavelengths 0"),
        ("--spp 0", "--spp 0"),
        ("--adaptive maybe", "use on or off"),
        (
            "--adaptive on --adaptive-floor 0",
            "--adaptive-floor: floor 0: must be in (0, 1]",
        ),
        ("--seconds -1", "--seconds -1"),
        ("--environment moonlight", "no such file"),
        ("--paint-material Chrome", "body, glass"),
        (
            "--paint-material body,Chrome",
            "--paint-material 'Chrome': the built-in car has no such material (it has body, glass",
        ),
        ("--view diagonal", "'diagonal' for '--view"),
        ("--view turntable:0", "'turntable:0': 0 frames"),
        ("--view turntable:4:4", "frame 4 of 4"),
        ("--camera 1,2,3", "'1,2,3' for '--camera"),
        ("--camera 0,95,5,35", "pitch 95° must be within ±89°"),
        ("--camera 0,10,-2,35", "distance -2 m must be a positive"),
        ("--camera gltf:0", "no camera 0 (it has none of its own)"),
        ("--view side --camera gltf:0", "cannot be used with"),
        ("--front +y", "'+y' for '--front"),
        ("--front -x", "--front -x: only for a glTF --scene"),
    ];
    let no_input_cases = [
        ("--environment /nonexistent/sky.exr", "no such file"),
        ("--scene /nonexistent/car.glb", "/nonexistent/car.glb"),
        (
            "--design /nonexistent/paint.toml",
            "/nonexistent/paint.toml",
        ),
    ];
    let data_case = (&*garbage_arg, exit::DATA, "not a readable OpenEXR file");
    let cases = usage_cases
        .map(|(args, expected)| (args, usage, expected))
        .into_iter()
        .chain(no_input_cases.map(|(args, expected)| (args, no_input, expected)))
        .chain([data_case]);
    for (args, code, expected) in cases {
        let args: Vec<&str> = args.split_whitespace().collect();
        // Small defaults for whatever the case does not set itself.
        let mut full = args.clone();
        for (flag, value) in [("--size", "8x8"), ("--spp", "1")] {
            let timed = flag == "--spp" && args.contains(&"--seconds");
            if !timed && !args.contains(&flag) {
                full.extend([flag, value]);
            }
        }
        let output = render_to(&png, &full);
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
    let output = render_small(&out_path("image.jpg"), "8x8", 1, &[]);
    assert!(failure(&output, exit::USAGE).contains(".png, .exr or .film"));
    // An output that cannot be written.
    let output = render_small(
        &out_path("no-such-folder/image.png"),
        "8x8",
        1,
        &["--wavelengths", "4"],
    );
    assert!(failure(&output, exit::CANT_CREATE).contains("no-such-folder/image.png"));

    // A truncated scene file.
    let bytes = b"glTF\x02\x00\x00\x00\xff\x00\x00\x00";
    let cut = out_path("cut.glb");
    std::fs::write(&cut, bytes).expect("write");
    let output = render_small(&png, "8x8", 1, &["--scene", cut.to_str().expect("utf-8")]);
    let err = failure(&output, exit::DATA);
    assert!(err.contains("cut.glb"), "{err}");
}

/// `--view turntable:4` writes four frames, numbered in the order of the turn
/// after the output's name; each is another side of the car, and
/// `turntable:4:K` alone renders frame K's very image.
#[test]
fn a_turntable_writes_numbered_frames() {
    let dir = out_path("turntable");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("folder");
    let spin = dir.join("spin.png");
    let small = ["--wavelengths", "4", "--view"];
    let said = stdout(&render_small(
        &spin,
        "32x18",
        1,
        &[&small[..], &["turntable:4"]].concat(),
    ));
    let frames: Vec<PathBuf> = (0..4).map(|k| dir.join(format!("spin-0{k}.png"))).collect();
    let lines: Vec<&str> = said.lines().filter(|l| l.starts_with("wrote ")).collect();
    assert_eq!(lines.len(), 4, "{said}");
    let mut images = Vec::new();
    for (frame, line) in frames.iter().zip(&lines) {
        assert!(
            line.starts_with(&format!("wrote {}", frame.display())),
            "{line}"
        );
        let bytes = std::fs::read(frame).expect("the frame is written");
        assert_eq!(png_size(&bytes), (32, 18));
        images.push(bytes);
    }
    assert!(!spin.exists(), "no file under the bare name");
    for i in 0..4 {
        for j in i + 1..4 {
            assert_ne!(
                images[i], images[j],
                "frames {i} and {j} show the same picture"
            );
        }
    }
    let alone = dir.join("frame2.png");
    stdout(&render_small(
        &alone,
        "32x18",
        1,
        &[&small[..], &["turntable:4:2"]].concat(),
    ));
    assert_eq!(
        std::fs::read(&alone).expect("frame 2 alone"),
        images[2],
        "turntable:4:2 is the turn's frame 2"
    );
}

/// `--view side` renders, and not the default view's picture (which view each
/// named view shows is tested on the cameras in crates/coatlab-core/tests/views.rs).
#[test]
fn a_named_view_renders() {
    let (side, default) = (out_path("side.png"), out_path("front-34.png"));
    for (out, extra) in [(&side, &["--view", "side"][..]), (&default, &[][..])] {
        let output = render_small(out, "32x18", 1, &[extra, &["--wavelengths", "4"]].concat());
        stdout(&output);
        assert_eq!(png_size(&std::fs::read(out).expect("png")), (32, 18));
    }
    assert_ne!(
        std::fs::read(&side).expect("png"),
        std::fs::read(&default).expect("png")
    );
}

/// `--camera gltf:N` renders from ToyCar's own cameras, and one it does not have
/// is refused by number.
#[test]
fn a_files_camera_renders_and_a_missing_one_is_refused() {
    let Some(dir) = testdata() else {
        return;
    };
    let toy_car = dir.join("ToyCar/ToyCar.gltf");
    let toy_car = toy_car.to_str().expect("utf-8");
    let png = out_path("toycar-camera.png");
    let output = render_small(
        &png,
        "32x18",
        1,
        &[
            "--scene",
            toy_car,
            "--camera",
            "gltf:1",
            "--wavelengths",
            "4",
        ],
    );
    stdout(&output);
    assert_eq!(png_size(&std::fs::read(&png).expect("png")), (32, 18));
    let output = render_small(&png, "8x8", 1, &["--scene", toy_car, "--camera", "gltf:8"]);
    let err = failure(&output, exit::USAGE);
    assert!(
        err.contains("--camera gltf:8: the scene has no camera 8 (it has 8, gltf:0 to gltf:7)"),
        "{err}"
    );
}

/// `--paint-material` takes several names, comma-separated or repeated, and
/// paints them all: the same image either way, another than the body's alone.
#[test]
fn several_paint_materials_by_name() {
    let image = |name: &str, extra: &[&str]| {
        let out = out_path(name);
        stdout(&render_small(
            &out,
            "32x18",
            1,
            &[&["--wavelengths", "4"], extra].concat(),
        ));
        std::fs::read(&out).expect("the image")
    };
    let listed = image("paint-listed.png", &["--paint-material", "body,glass"]);
    let repeated = image(
        "paint-repeated.png",
        &["--paint-material", "body", "--paint-material", "glass"],
    );
    let body = image("paint-body.png", &["--paint-material", "body"]);
    assert_eq!(
        listed, repeated,
        "a list and a repeated flag are the same choice"
    );
    assert_ne!(listed, body, "the glass carries the paint too");
}

#[test]
fn shared_models_render_or_are_refused_by_name() {
    let Some(dir) = testdata() else {
        return;
    };
    let lambo = dir.join("LamborghiniHuracanGT3/LamborghiniHuracanGT3.glb");
    let png = out_path("lambo.png");
    let output = render_small(
        &png,
        "32x18",
        1,
        &[
            "--scene",
            lambo.to_str().expect("utf-8"),
            "--paint-material",
            "Material.035",
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
        let output = render_small(&png, "8x8", 1, &["--scene", path.to_str().expect("utf-8")]);
        let err = failure(&output, exit::DATA);
        let name = path.file_name().and_then(|n| n.to_str()).expect("name");
        assert!(err.contains(extension) && err.contains(name), "{err}");
    }
}
