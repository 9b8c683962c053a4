//! Helpers shared by the end-to-end tests of the `coatlab` binary.
#![allow(dead_code)] // each test crate uses its own subset

pub mod batch;
mod outcome;

use std::ffi::OsStr;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

#[allow(unused_imports)] // each test crate uses its own subset
pub use outcome::{assert_mentions, exit, failure, stdout};

pub fn coatlab(args: &[&str], stdin: &str) -> Output {
    coatlab_fed(args, stdin.as_bytes().to_vec())
}

/// A committed design preset: `signal-red` is `assets/presets/signal-red.toml`.
pub fn preset(slug: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets/presets")
        .join(format!("{slug}.toml"))
}

/// `coatlab` with `args` and no input; the outcome is the caller's to judge.
pub fn run(args: &[impl AsRef<OsStr>]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_coatlab"))
        .args(args)
        .output()
        .expect("coatlab runs")
}

/// The JSON a successful run printed.
pub fn json(output: &Output) -> serde_json::Value {
    serde_json::from_str(&stdout(output)).expect("valid JSON")
}

/// `coatlab` with `args`, fed `stdin` (any bytes, not only text).
pub fn coatlab_fed(args: &[impl AsRef<OsStr>], stdin: Vec<u8>) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_coatlab"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("coatlab starts");
    // Feed stdin from another thread while this one drains stdout, or a large input
    // and output fill both pipes and deadlock. The binary may stop reading at a bad
    // row and close its stdin early; the broken pipe is then expected, and the exit
    // status tells the story.
    let mut child_stdin = child.stdin.take().expect("stdin is piped");
    let feeder = std::thread::spawn(move || {
        let _ = child_stdin.write_all(&stdin);
    });
    let output = child.wait_with_output().expect("coatlab finishes");
    feeder.join().expect("the stdin feeder does not panic");
    output
}

/// A CSV text split into its header and rows (no quoting: the commands write none).
pub fn parse_rows(text: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let mut lines = text.lines();
    let header = lines
        .next()
        .expect("header")
        .split(',')
        .map(str::to_owned)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect();
    (header, rows)
}

/// An OpenEXR file's first layer read back with the `exr` crate.
pub struct ExrImage {
    pub width: usize,
    pub height: usize,
    /// Channel names and their sample types ("f16", "f32", "u32"), in file order.
    pub channels: Vec<(String, &'static str)>,
    /// R, G, B per pixel, row-major from the top-left.
    pub rgb: Vec<[f32; 3]>,
    /// The `chromaticities` attribute: red, green, blue and white x, y.
    pub chromaticities: Option<[f32; 8]>,
}

/// Checks that `image` holds what the help text and the docs say an EXR export
/// holds: 32-bit float R, G, B, sorted by name as the format requires.
pub fn assert_rgb_f32(image: &ExrImage) {
    let names: Vec<(&str, &str)> = image
        .channels
        .iter()
        .map(|(n, t)| (n.as_str(), *t))
        .collect();
    assert_eq!(names, [("B", "f32"), ("G", "f32"), ("R", "f32")]);
}

pub fn read_exr(path: &std::path::Path) -> ExrImage {
    use exr::prelude::{FlatSamples, read_first_flat_layer_from_file};
    let image = read_first_flat_layer_from_file(path)
        .unwrap_or_else(|e| panic!("{} is not a readable EXR: {e}", path.display()));
    let layer = &image.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let mut channels = Vec::new();
    let mut planes = std::collections::HashMap::new();
    for channel in &layer.channel_data.list {
        let name = channel.name.to_string();
        let (kind, values): (&'static str, Vec<f32>) = match &channel.sample_data {
            FlatSamples::F16(v) => ("f16", v.iter().map(|x| x.to_f32()).collect()),
            FlatSamples::F32(v) => ("f32", v.clone()),
            FlatSamples::U32(v) => ("u32", v.iter().map(|&x| x as f32).collect()),
        };
        assert_eq!(values.len(), width * height, "{name}: one sample a pixel");
        channels.push((name.clone(), kind));
        planes.insert(name, values);
    }
    let plane = |name: &str| {
        planes
            .get(name)
            .unwrap_or_else(|| panic!("no {name} channel"))
    };
    let (r, g, b) = (plane("R"), plane("G"), plane("B"));
    let rgb = (0..width * height).map(|i| [r[i], g[i], b[i]]).collect();
    let chromaticities = image.attributes.chromaticities.map(|c| {
        [
            c.red.x(),
            c.red.y(),
            c.green.x(),
            c.green.y(),
            c.blue.x(),
            c.blue.y(),
            c.white.x(),
            c.white.y(),
        ]
    });
    ExrImage {
        width,
        height,
        channels,
        rgb,
        chromaticities,
    }
}

/// The multi-angle reflectance in `coatlab measure --json`'s output on every
/// `step`-th wavelength, as (wavelengths, [(aspecular, values)]).
pub fn measured_spectra(json: &serde_json::Value, step: usize) -> (Vec<f64>, Vec<(f64, Vec<f64>)>) {
    let m = &json["measurement"];
    let number = |v: &serde_json::Value| v.as_f64().expect("a number");
    let w: Vec<f64> = m["wavelength_nm"]
        .as_array()
        .expect("grid")
        .iter()
        .map(number)
        .collect();
    let keep: Vec<usize> = (0..w.len()).step_by(step).collect();
    let angles = m["angles"]
        .as_array()
        .expect("angles")
        .iter()
        .map(|a| {
            let r: Vec<f64> = a["reflectance_factor"]
                .as_array()
                .expect("r")
                .iter()
                .map(number)
                .collect();
            (
                number(&a["aspecular_deg"]),
                keep.iter().map(|&i| r[i]).collect(),
            )
        })
        .collect();
    (keep.iter().map(|&i| w[i]).collect(), angles)
}

/// A fresh folder `<test>/<name>` under Cargo's temporary folder for tests, holding
/// copies of the design presets named by `presets` (`signal-red` → `signal-red.toml`).
pub fn scratch_with_presets(test: &str, name: &str, presets: &[&str]) -> std::path::PathBuf {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(test)
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch folder");
    let assets = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/presets");
    for preset in presets {
        std::fs::copy(
            format!("{assets}/{preset}.toml"),
            dir.join(format!("{preset}.toml")),
        )
        .expect("copy a preset");
    }
    dir
}
