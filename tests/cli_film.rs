//! End-to-end tests of a render split into sample ranges: `coatlab render
//! --sample-range … --out part.film` and `coatlab merge`. The claim is bit
//! identity of deterministic output, so the images are compared exactly.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::{exit, failure, read_exr, stdout};

/// A small render everyone here shares: 40×24, 8 wavelengths, seed 3.
const SMALL: [&str; 6] = ["--size", "40x24", "--wavelengths", "8", "--seed", "3"];
const SPP: u32 = 12;

fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("cli_film")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch folder");
    dir
}

fn coatlab(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_coatlab"))
        .args(args)
        .output()
        .expect("coatlab runs")
}

fn path_str(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

/// Renders samples `range` of the small render (plus `extra` flags) to `out`.
fn render_part(out: &Path, range: (u32, u32), extra: &[&str]) -> Output {
    let spp = SPP.to_string();
    let range = format!("{}..{}", range.0, range.1);
    let mut args = vec!["render", "--spp", &spp, "--sample-range", &range];
    // `extra` overrides the small render's own flags.
    for pair in SMALL.chunks_exact(2) {
        if !extra.contains(&pair[0]) {
            args.extend(pair);
        }
    }
    args.extend(extra);
    args.extend(["--out", path_str(out)]);
    coatlab(&args)
}

#[test]
fn merged_parts_are_bit_identical_to_one_render() {
    let dir = scratch("identity");
    let spp = SPP.to_string();
    let whole = |name: &str| {
        let out = dir.join(name);
        let mut args = vec!["render", "--spp", &spp];
        args.extend(SMALL);
        args.extend(["--out", path_str(&out)]);
        stdout(&coatlab(&args));
        out
    };
    let (whole_exr, whole_png) = (whole("whole.exr"), whole("whole.png"));
    let whole_pixels = read_exr(&whole_exr).rgb;
    let whole_png = std::fs::read(&whole_png).expect("read");
    let splits: [&[(u32, u32)]; 3] = [
        &[(0, 6), (6, 12)],
        &[(0, 4), (4, 8), (8, 12)],
        &[(0, 1), (1, 11), (11, 12)],
    ];
    for (i, split) in splits.into_iter().enumerate() {
        let mut parts: Vec<String> = split
            .iter()
            .enumerate()
            .map(|(k, &range)| {
                let part = dir.join(format!("split{i}-part{k}.film"));
                let text = stdout(&render_part(&part, range, &[]));
                assert!(
                    text.contains(&format!("samples {}..{} of {SPP}", range.0, range.1)),
                    "{text}"
                );
                path_str(&part).to_owned()
            })
            .collect();
        // The order the parts are named in does not matter.
        parts.reverse();
        for extension in ["exr", "png"] {
            let out = dir.join(format!("merged{i}.{extension}"));
            let mut args = vec!["merge"];
            args.extend(parts.iter().map(String::as_str));
            args.extend(["--out", path_str(&out)]);
            let text = stdout(&coatlab(&args));
            assert!(
                text.contains(&format!("{SPP} spp from {} parts", split.len())),
                "{text}"
            );
            if extension == "exr" {
                let merged = read_exr(&out).rgb;
                assert!(
                    merged
                        .iter()
                        .zip(&whole_pixels)
                        .all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits)),
                    "split {split:?}: the merged EXR differs from the single render"
                );
            } else {
                assert!(
                    std::fs::read(&out).expect("read") == whole_png,
                    "split {split:?}: the merged PNG differs from the single render"
                );
            }
        }
    }
}

#[test]
fn parts_of_other_renders_and_broken_parts_are_refused_by_name() {
    let dir = scratch("refusals");
    let part = |name: &str, range: (u32, u32), extra: &[&str]| {
        let path = dir.join(name);
        stdout(&render_part(&path, range, extra));
        path_str(&path).to_owned()
    };
    let first = part("first.film", (0, 6), &[]);
    let second = part("second.film", (6, 12), &[]);
    let overlapping = part("overlap.film", (5, 12), &[]);
    let short = part("short.film", (7, 12), &[]);
    let other_seed = part("seed.film", (6, 12), &["--seed", "4"]);
    let other_lighting = part("booth.film", (6, 12), &["--environment", "booth-d65"]);
    let other_model = part("phong.film", (6, 12), &["--model", "phong-naive"]);
    let other_size = part("size.film", (6, 12), &["--size", "20x12"]);
    let design = dir.join("blue.toml");
    let blue = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../assets/presets/deep-blue.toml"
    ))
    .expect("preset");
    std::fs::write(&design, blue).expect("write");
    let other_design = part("blue.film", (6, 12), &["--design", path_str(&design)]);
    let truncated = dir.join("truncated.film");
    let bytes = std::fs::read(&second).expect("read");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).expect("write");
    let damaged = dir.join("damaged.film");
    let mut flipped = bytes.clone();
    let middle = flipped.len() / 2;
    flipped[middle] ^= 0x10;
    std::fs::write(&damaged, flipped).expect("write");
    let out = dir.join("never.exr");
    let cases: Vec<(&str, &str, i32, Vec<&str>)> = vec![
        (
            overlapping.as_str(),
            "overlap",
            exit::DATA,
            vec!["samples 5..12"],
        ),
        (
            short.as_str(),
            "samples 6..7 of 12 are in none",
            exit::DATA,
            vec![],
        ),
        (other_seed.as_str(), "seed 3 vs 4", exit::DATA, vec![]),
        (
            other_lighting.as_str(),
            "lighting studio",
            exit::DATA,
            vec![],
        ),
        (other_model.as_str(), "settings", exit::DATA, vec![]),
        (
            other_size.as_str(),
            "size 40x24 vs 20x12",
            exit::DATA,
            vec![],
        ),
        (
            other_design.as_str(),
            "design Signal red",
            exit::DATA,
            vec![],
        ),
        (path_str(&truncated), "truncated", exit::DATA, vec![]),
        (path_str(&damaged), "checksum", exit::DATA, vec![]),
    ];
    for (other, expected, code, more) in cases {
        let output = coatlab(&["merge", &first, other, "--out", path_str(&out)]);
        let err = failure(&output, code);
        let file = Path::new(other)
            .file_name()
            .and_then(|f| f.to_str())
            .expect("name");
        assert!(
            err.contains(expected) && err.contains(file),
            "{other}: {err}"
        );
        for m in more {
            assert!(err.contains(m), "{other}: {err}");
        }
    }
    assert!(!out.exists(), "a refused merge writes nothing");
    // The parts alone are fine.
    stdout(&coatlab(&[
        "merge",
        &first,
        &second,
        "--out",
        path_str(&out),
    ]));

    // Flags that cannot make a part.
    let film = dir.join("never.film");
    let png = dir.join("never.png");
    let usage: [(&Path, &[&str], &str); 5] = [
        (&film, &["--sample-range", "0..13"], "indices 0..12"),
        (&film, &["--sample-range", "4..4"], "empty"),
        (
            &film,
            &["--adaptive", "on", "--sample-range", "0..4"],
            "cannot be adaptive",
        ),
        (&film, &["--seconds", "1"], "fixed range"),
        (&png, &["--sample-range", "0..4"], "only for a .film part"),
    ];
    for (out, flags, expected) in usage {
        let spp = SPP.to_string();
        let mut args = vec![
            "render",
            "--spp",
            &spp,
            "--size",
            "8x8",
            "--wavelengths",
            "4",
        ];
        if flags.contains(&"--seconds") {
            args.drain(1..3);
        }
        args.extend(flags);
        args.extend(["--out", path_str(out)]);
        let err = failure(&coatlab(&args), exit::USAGE);
        assert!(err.contains(expected), "{flags:?}: {err}");
    }
    let err = failure(
        &coatlab(&["merge", &first, "--out", path_str(&dir.join("x.jpg"))]),
        exit::USAGE,
    );
    assert!(err.contains(".png or .exr"), "{err}");
    let missing = dir.join("missing.film");
    let err = failure(
        &coatlab(&["merge", &first, path_str(&missing), "--out", path_str(&out)]),
        exit::NO_INPUT,
    );
    assert!(err.contains("missing.film"), "{err}");
}
