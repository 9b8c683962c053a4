//! Exit statuses of `coatlab` that no single command's tests pin: that no input
//! makes it panic (every subcommand driven with a generated set of malformed
//! inputs), and that a stdout closed by its reader ends it quietly with 141.

mod common;

use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use common::exit;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_coatlab"))
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

fn preset(slug: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets/presets")
        .join(format!("{slug}.toml"))
}

// ---------------------------------------------------------------------------------
// Malformed input never panics

/// SplitMix64: the cases are the same on every run, so a failure reproduces.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| self.next() as u8).collect()
    }

    /// `k` distinct items of `items`, in their order.
    fn some<'a>(&mut self, items: &'a [&'a str], k: usize) -> Vec<&'a str> {
        let mut chosen: Vec<usize> = (0..items.len()).collect();
        for i in (1..chosen.len()).rev() {
            chosen.swap(i, (self.next() % (i as u64 + 1)) as usize);
        }
        chosen.truncate(k);
        chosen.sort_unstable();
        chosen.into_iter().map(|i| items[i]).collect()
    }
}

/// Numbers and near-numbers for CSV cells and flag values: not finite, beyond f64,
/// subnormal, signed zero, out of every range, other notations and scripts.
const NUMBERS: &[&str] = &[
    "",
    " ",
    "NaN",
    "-nan",
    "inf",
    "-inf",
    "1e309",
    "-1e309",
    "1e308",
    "-1e308",
    "5e-324",
    "-0",
    "0",
    "-1",
    "0.5",
    "1.5",
    "90.000001",
    "1e6",
    "18446744073709551616",
    "0x1A",
    "1_0",
    "\u{663}",
    "\"1\"",
    "99999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999",
];

/// TOML values for a design's numbers: TOML's own nan and inf, integers beyond
/// 64 bits, other types.
const TOML_VALUES: &[&str] = &[
    "nan",
    "-nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "5e-324",
    "-0.0",
    "0",
    "-1",
    "99999999999999999999",
    "9223372036854775807",
    "\"45\"",
    "[]",
    "{}",
    "true",
];

/// Statuses malformed input may end with: refused as usage, bad data or a missing
/// file, or accepted (a value at the edge of its range). Never 101 (a panic), 70
/// (an unclassed error), I/O failures or a signal.
const REFUSED_OR_DONE: &[i32] = &[0, exit::USAGE, exit::DATA, exit::NO_INPUT];

struct Case {
    what: String,
    args: Vec<String>,
    stdin: Vec<u8>,
}

impl Case {
    fn new(what: impl Into<String>, args: &[&str]) -> Self {
        Self {
            what: what.into(),
            args: args.iter().map(|a| (*a).to_owned()).collect(),
            stdin: Vec::new(),
        }
    }

    fn stdin(mut self, bytes: impl Into<Vec<u8>>) -> Self {
        self.stdin = bytes.into();
        self
    }

    fn run(&self) -> Output {
        common::coatlab_fed(&self.args, self.stdin.clone())
    }
}

/// CSV inputs for a `map_numeric_rows` command: structure broken in every way we
/// know, then each column's cell replaced by each of [`NUMBERS`].
fn table_cases(command: &str, header: &str, good_row: &str, rng: &mut Rng) -> Vec<Case> {
    let columns = header.split(',').count();
    let mut inputs: Vec<(String, Vec<u8>)> = vec![
        ("empty stdin".into(), Vec::new()),
        ("a blank line".into(), b"\n".to_vec()),
        ("CRLF only".into(), b"\r\n".to_vec()),
        ("header only".into(), format!("{header}\n").into_bytes()),
        (
            "a byte order mark".into(),
            format!("\u{feff}{header}\n{good_row}\n").into_bytes(),
        ),
        ("binary garbage".into(), rng.bytes(300)),
        ("a binary row".into(), {
            let mut bytes = format!("{header}\n").into_bytes();
            bytes.extend(rng.bytes(120));
            bytes
        }),
        (
            "NUL bytes in a row".into(),
            format!("{header}\n{}\0\n", good_row.replace(',', ",\0")).into_bytes(),
        ),
        (
            "an unterminated quote".into(),
            format!("{header}\n\"{good_row}\n").into_bytes(),
        ),
        (
            "a quoted newline".into(),
            format!(
                "{header}\n\"1\n2\",{}\n",
                good_row.split_once(',').expect("row").1
            )
            .into_bytes(),
        ),
        (
            "a duplicated header".into(),
            format!("{header},{header}\n{good_row},{good_row}\n").into_bytes(),
        ),
        (
            "an extra field".into(),
            format!("{header}\n{good_row},7\n").into_bytes(),
        ),
        (
            "a field short".into(),
            format!("{header}\n{}\n", good_row.rsplit_once(',').expect("row").0).into_bytes(),
        ),
        (
            "a thousand empty columns".into(),
            format!("{}\n{good_row}\n", ",".repeat(1000)).into_bytes(),
        ),
        (
            "a 100 kB cell".into(),
            format!("{header},x\n{good_row},{}\n", "1".repeat(100_000)).into_bytes(),
        ),
        (
            "a header of spaces".into(),
            format!("{}\n{good_row}\n", header.replace(',', " , ")).into_bytes(),
        ),
    ];
    for column in 0..columns {
        for number in NUMBERS {
            let mut cells: Vec<&str> = good_row.split(',').collect();
            cells[column] = number;
            inputs.push((
                format!("column {column} = {number:?}"),
                format!("{header}\n{good_row}\n{}\n", cells.join(",")).into_bytes(),
            ));
        }
    }
    inputs
        .into_iter()
        .map(|(what, stdin)| Case::new(format!("{command}: {what}"), &[command]).stdin(stdin))
        .collect()
}

fn color_cases(dir: &Path, rng: &mut Rng) -> Vec<Case> {
    let good = "wavelength_nm,red,blue\n400,0.1,0.2\n500,0.3,0.4\n600,0.5,0.6\n";
    let mut files: Vec<(String, Vec<u8>)> = vec![
        ("an empty file".into(), Vec::new()),
        ("header only".into(), b"wavelength_nm,red\n".to_vec()),
        ("one row".into(), b"wavelength_nm,red\n500,0.5\n".to_vec()),
        ("comments only".into(), b"# nothing\n#\n".to_vec()),
        ("binary garbage".into(), rng.bytes(400)),
        (
            "no wavelength column".into(),
            b"nm,red\n400,0.1\n500,0.2\n".to_vec(),
        ),
        (
            "no sample column".into(),
            b"wavelength_nm\n400\n500\n".to_vec(),
        ),
        (
            "a repeated column".into(),
            b"wavelength_nm,red,red\n400,0.1,0.1\n500,0.2,0.2\n".to_vec(),
        ),
        (
            "wavelengths out of the visible".into(),
            b"wavelength_nm,red\n10,0.1\n20,0.2\n".to_vec(),
        ),
        (
            "one wavelength twice".into(),
            b"wavelength_nm,red\n500,0.1\n500,0.2\n".to_vec(),
        ),
        (
            "a thousand samples of one wavelength pair".into(),
            format!(
                "wavelength_nm{}\n500{}\n510{}\n",
                (0..1000).map(|i| format!(",s{i}")).collect::<String>(),
                ",0.5".repeat(1000),
                ",0.5".repeat(1000)
            )
            .into_bytes(),
        ),
    ];
    for column in 0..3 {
        for number in NUMBERS {
            let mut lines: Vec<String> = good.lines().map(str::to_owned).collect();
            let mut cells: Vec<&str> = lines[2].split(',').collect();
            cells[column] = number;
            lines[2] = cells.join(",");
            files.push((
                format!("column {column} = {number:?}"),
                (lines.join("\n") + "\n").into_bytes(),
            ));
        }
    }
    let mut cases = Vec::new();
    for (i, (what, bytes)) in files.into_iter().enumerate() {
        let path = dir.join(format!("spectra-{i}.csv"));
        std::fs::write(&path, bytes).expect("write");
        cases.push(Case::new(
            format!("color: {what}"),
            &["color", path.to_str().expect("UTF-8")],
        ));
    }
    let good_path = dir.join("spectra-good.csv");
    std::fs::write(&good_path, good).expect("write");
    let good_path = good_path.to_str().expect("UTF-8");
    for flag in ["--illuminant", "--observer"] {
        for value in ["", "d65x", "0", "-1", "NaN", "D-65", "10deg2"] {
            cases.push(Case::new(
                format!("color: {flag} {value:?}"),
                &["color", flag, value, good_path],
            ));
        }
    }
    let dir_path = dir.to_str().expect("UTF-8");
    cases.push(Case::new("color: a folder", &["color", dir_path]));
    cases.push(Case::new(
        "color: no such file",
        &["color", "/nonexistent/spectra.csv"],
    ));
    cases.push(Case::new("color: no file", &["color"]));
    cases
}

fn gloss_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    for number in NUMBERS {
        for (flag, rest) in [
            ("--n", &["--gu", "50"][..]),
            ("--gu", &["--n", "1.5"][..]),
            ("--m", &["--n", "1.5"][..]),
            ("--geometry", &["--n", "1.5", "--gu", "50"][..]),
        ] {
            let mut args = vec!["gloss", flag, number];
            args.extend_from_slice(rest);
            cases.push(Case::new(format!("gloss {flag} {number:?}"), &args));
        }
    }
    for args in [
        &["gloss"][..],
        &["gloss", "--n", "1.5", "--gu", "50", "--m", "3"],
        &["gloss", "--n", "1.5", "--gu"],
        &["gloss", "--n", "1e300", "--m", "1e300"],
        &["gloss", "--n", "1", "--gu", "1e-300"],
        &[
            "gloss",
            "--n",
            "1.0000001",
            "--geometry",
            "85",
            "--gu",
            "0.0001",
        ],
    ] {
        cases.push(Case::new(format!("{args:?}"), args));
    }
    cases
}

/// A design with each of a few of its numbers replaced by each of [`TOML_VALUES`]
/// (some by all, the others by a sample), cut short at many places, and not text.
fn design_files(dir: &Path, rng: &mut Rng) -> Vec<(String, PathBuf)> {
    let text = std::fs::read_to_string(preset("signal-red")).expect("preset");
    let mut variants: Vec<(String, Vec<u8>)> = Vec::new();
    // Every slot with all values is many seconds of model building; the ones a
    // user types by hand get all, the others a sample.
    let slots: [(&str, usize); 8] = [
        ("thickness_um = 45.0", TOML_VALUES.len()),
        ("gu = 88.0", TOML_VALUES.len()),
        ("a = 1.515", 5),
        ("b_um2 = 0.0045", 4),
        ("geometry_deg = 20", 4),
        ("version = 1", 4),
        ("0.0571, 0.0601", 5),
        ("300, 310", 4),
    ];
    for (slot, k) in slots {
        assert!(text.contains(slot), "{slot} is in the preset");
        let (key, _) = slot.split_once(['=', ',']).expect("slot");
        for value in rng.some(TOML_VALUES, k) {
            let replaced = if slot.contains('=') {
                format!("{key}= {value}")
            } else {
                format!("{value}, {}", slot.split_once(", ").expect("pair").1)
            };
            variants.push((
                format!("{slot} → {value}"),
                text.replacen(slot, &replaced, 1).into_bytes(),
            ));
        }
    }
    for (what, from, to) in [
        ("a short albedo", "0.78, 0.78, 0.78,\n]", "0.78,\n]"),
        ("an empty albedo", "value = [\n    0.0571", "value = [] #"),
        ("lobe", "lobe = \"normalised\"", "lobe = \"matte\""),
        ("no gloss", "[gloss]", "[glosss]"),
        ("a repeated key", "gu = 88.0", "gu = 88.0\ngu = 88.0"),
        ("a Cauchy b below zero", "b_um2 = 0.0045", "b_um2 = -0.5"),
        ("format", "coatlab-paint-design", "coatlab-paint-desing"),
    ] {
        assert!(text.contains(from), "{from} is in the preset");
        variants.push((what.into(), text.replacen(from, to, 1).into_bytes()));
    }
    for cut in (0..text.len()).step_by(211) {
        let end = (0..=cut)
            .rev()
            .find(|&i| text.is_char_boundary(i))
            .unwrap_or(0);
        variants.push((
            format!("cut at byte {end}"),
            text.as_bytes()[..end].to_vec(),
        ));
    }
    variants.push(("binary garbage".into(), rng.bytes(500)));
    variants.push((
        "a NUL in a string".into(),
        text.replacen("Signal", "Sig\0nal", 1).into_bytes(),
    ));
    variants
        .into_iter()
        .enumerate()
        .map(|(i, (what, bytes))| {
            let path = dir.join(format!("design-{i}.toml"));
            std::fs::write(&path, bytes).expect("write");
            (what, path)
        })
        .collect()
}

fn measure_cases(designs: &[(String, PathBuf)], dir: &Path) -> Vec<Case> {
    let mut cases: Vec<Case> = designs
        .iter()
        .map(|(what, path)| {
            Case::new(
                format!("measure: {what}"),
                &["measure", path.to_str().expect("UTF-8")],
            )
        })
        .collect();
    let good = preset("signal-red");
    let good = good.to_str().expect("UTF-8");
    let bad = designs[0].1.to_str().expect("UTF-8");
    let dir_path = dir.to_str().expect("UTF-8");
    for args in [
        &["measure", good, "--target", bad][..],
        &[
            "measure",
            "--json",
            good,
            "--target",
            "/nonexistent/target.toml",
        ],
        &["measure", dir_path],
        &["measure", "/nonexistent/design.toml"],
        &["measure", ""],
        &["measure"],
    ] {
        cases.push(Case::new(format!("{args:?}"), args));
    }
    cases
}

/// `coatlab fit` with the malformed designs as its start, and malformed arguments
/// (the measurement files themselves are driven by `tests/cli_measure.rs` and the
/// readers' property test).
fn fit_cases(designs: &[(String, PathBuf)], dir: &Path) -> Vec<Case> {
    let target = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../coatlab-core/tests/data/measurements/multi_angle_geometry_field.cgats");
    let target = target.to_str().expect("UTF-8").to_owned();
    let out = dir.join("fitted.toml");
    let out = out.to_str().expect("UTF-8").to_owned();
    let mut cases: Vec<Case> = designs
        .iter()
        .take(40)
        .map(|(what, path)| {
            Case::new(
                format!("fit --start: {what}"),
                &[
                    "fit",
                    "--target",
                    &target,
                    "--sample",
                    "1",
                    "--start",
                    path.to_str().expect("UTF-8"),
                    "--out",
                    &out,
                ],
            )
        })
        .collect();
    let bad = designs[0].1.to_str().expect("UTF-8");
    let dir_path = dir.to_str().expect("UTF-8");
    for args in [
        &["fit", "--target", bad, "--out", &out][..],
        &[
            "fit", "--target", &target, "--sample", "1", "--free", "n,x", "--out", &out,
        ],
        &[
            "fit", "--target", &target, "--sample", "1", "--free", "", "--out", &out,
        ],
        &[
            "fit",
            "--target",
            &target,
            "--sample",
            "1",
            "--tolerance",
            "nan",
            "--out",
            &out,
        ],
        &["fit", "--target", &target, "--sample", "99", "--out", &out],
        &["fit", "--target", "/nonexistent/t.cgats", "--out", &out],
        &["fit", "--target", dir_path, "--out", &out],
        &["fit", "--target", &target],
        &["fit"],
    ] {
        cases.push(Case::new(format!("{args:?}"), args));
    }
    cases
}

/// Environment maps: EXR files of every awkward content, Radiance files that lie
/// about their size or stop early.
fn environment_maps(dir: &Path, rng: &mut Rng) -> Vec<(String, PathBuf)> {
    let mut maps = Vec::new();
    let mut exr = |what: &str, w: usize, h: usize, pixel: fn(usize, usize) -> (f32, f32, f32)| {
        let path = dir.join(format!("map-{}.exr", maps.len()));
        exr::prelude::write_rgb_file(&path, w, h, pixel).expect("write EXR");
        maps.push((what.to_owned(), path));
    };
    exr("NaN pixels", 8, 4, |x, _| {
        if x == 3 {
            (f32::NAN, 1.0, 1.0)
        } else {
            (1.0, 1.0, 1.0)
        }
    });
    exr("infinite pixels", 8, 4, |_, y| {
        if y == 0 {
            (f32::INFINITY, 1.0, 1.0)
        } else {
            (1.0, 1.0, 1.0)
        }
    });
    exr("negative everywhere", 8, 4, |_, _| (-1.0, -1.0, -1.0));
    exr("black", 8, 4, |_, _| (0.0, 0.0, 0.0));
    exr("black above the horizon", 8, 4, |_, y| {
        if y < 2 {
            (0.0, 0.0, 0.0)
        } else {
            (1.0, 1.0, 1.0)
        }
    });
    exr("one pixel", 1, 1, |_, _| (1.0, 0.5, 0.25));
    exr("one row", 7, 1, |_, _| (1.0, 1.0, 1.0));
    exr("the largest float", 4, 2, |_, _| {
        (f32::MAX, f32::MAX, f32::MAX)
    });
    exr("subnormal", 4, 2, |_, _| (1e-40, 1e-40, 1e-40));
    let mut raw = |what: &str, name: &str, bytes: Vec<u8>| {
        let path = dir.join(name);
        std::fs::write(&path, bytes).expect("write");
        maps.push((what.to_owned(), path));
    };
    raw("an empty .exr", "empty.exr", Vec::new());
    raw("garbage .exr", "garbage.exr", {
        let mut bytes = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
        bytes.extend(rng.bytes(300));
        bytes
    });
    raw(
        "a .hdr claiming 10⁸ × 10⁸ pixels",
        "huge.hdr",
        b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000000 +X 100000000\n\x02\x02\x00\x10"
            .to_vec(),
    );
    raw(
        "a .hdr of no pixels",
        "zero.hdr",
        b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 0 +X 0\n".to_vec(),
    );
    raw("a .hdr cut short", "cut.hdr", {
        let mut bytes = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n".to_vec();
        bytes.extend(rng.bytes(40));
        bytes
    });
    raw("garbage run lengths", "rle.hdr", {
        let mut bytes = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 16\n".to_vec();
        for _ in 0..4 {
            bytes.extend([2, 2, 0, 16]);
            bytes.extend(rng.bytes(64));
        }
        bytes
    });
    raw(
        "an unknown extension",
        "map.png",
        b"\x89PNG\r\n\x1a\n".to_vec(),
    );
    maps
}

/// Scene files that are not glTF, half glTF, or glTF describing nothing sane.
fn scene_files(dir: &Path, rng: &mut Rng) -> Vec<(String, PathBuf)> {
    // One triangle, its three positions in a data URI (36 bytes of f32).
    let triangle = |count: &str, offset: &str, min: &str| {
        format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
"buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}}],
"bufferViews":[{{"buffer":0,"byteLength":36}}],
"accessors":[{{"bufferView":0,"byteOffset":{offset},"componentType":5126,"count":{count},"type":"VEC3","min":[{min},0,0],"max":[1,1,0]}}]}}"#
        )
    };
    let files: Vec<(&str, &str, Vec<u8>)> = vec![
        ("an empty .glb", "empty.glb", Vec::new()),
        ("a GLB header alone", "header.glb", b"glTF\x02\x00\x00\x00".to_vec()),
        (
            "a GLB claiming 4 GB",
            "long.glb",
            b"glTF\x02\x00\x00\x00\xff\xff\xff\xff\x10\x00\x00\x00JSON{}".to_vec(),
        ),
        ("garbage .glb", "garbage.glb", rng.bytes(200)),
        ("an empty object", "empty.gltf", b"{}".to_vec()),
        ("no scene", "asset.gltf", br#"{"asset":{"version":"2.0"}}"#.to_vec()),
        ("a triangle", "triangle.gltf", triangle("3", "0", "0").into_bytes()),
        (
            "a billion vertices",
            "many.gltf",
            triangle("1000000000", "0", "0").into_bytes(),
        ),
        (
            "an offset past the end",
            "offset.gltf",
            triangle("3", "4294967292", "0").into_bytes(),
        ),
        (
            "a missing buffer file",
            "buffer.gltf",
            triangle("3", "0", "0")
                .replace(
                    "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA",
                    "no-such.bin",
                )
                .into_bytes(),
        ),
        (
            "base64 garbage",
            "base64.gltf",
            triangle("3", "0", "0")
                .replace("AAAAAAAAAAAAAAAAAACAPw", "!!!!")
                .into_bytes(),
        ),
        ("a cyclic node", "cycle.gltf", br#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"children":[0]}]}"#.to_vec()),
    ];
    files
        .into_iter()
        .map(|(what, name, bytes)| {
            let path = dir.join(name);
            std::fs::write(&path, bytes).expect("write");
            (what.to_owned(), path)
        })
        .collect()
}

fn render_cases(
    dir: &Path,
    designs: &[(String, PathBuf)],
    maps: &[(String, PathBuf)],
    scenes: &[(String, PathBuf)],
) -> Vec<Case> {
    let out = dir.join("out.png");
    let out = out.to_str().expect("UTF-8").to_owned();
    // Every case renders at most a few pixels: the point is the input, not the image.
    let small = ["--size", "3x2", "--spp", "1", "--wavelengths", "4"];
    let mut cases = Vec::new();
    let mut push = |what: String, args: &[&str]| {
        let mut full = vec!["render"];
        full.extend_from_slice(args);
        for pair in small.chunks(2) {
            let timed = pair[0] == "--spp" && args.contains(&"--seconds");
            if !timed && !args.contains(&pair[0]) {
                full.extend_from_slice(pair);
            }
        }
        if !args.contains(&"--out") {
            full.extend(["--out", out.as_str()]);
        }
        cases.push(Case::new(format!("render {what}"), &full));
    };
    let values: [(&str, &[&str]); 10] = [
        (
            "--size",
            &[
                "1x1",
                "0x0",
                "-1x4",
                "4x",
                "x4",
                "NaNx4",
                "4.5x4",
                "16385x1",
                "4x4x4",
                "\u{664}x\u{664}",
                "",
            ],
        ),
        ("--spp", &["-1", "1.5", "", "4294967296"]),
        (
            "--seconds",
            &[
                "0", "-0", "NaN", "inf", "-inf", "1e300", "1e-300", "-1e-300", "",
            ],
        ),
        ("--wavelengths", &["0", "402", "-1", "1", "1e3", ""]),
        (
            "--seed",
            &["-1", "18446744073709551616", "18446744073709551615", "x"],
        ),
        (
            "--exposure",
            &["NaN", "inf", "-inf", "1e30", "-1e30", "1e39"],
        ),
        ("--model", &["", "PAINT", "phong"]),
        ("--environment", &["", ".", "/", "STUDIO", "studio "]),
        ("--adaptive", &["", "ON", "1"]),
        ("--paint-material", &["", "body ", "\u{1f3a8}"]),
    ];
    for (flag, list) in values {
        for value in list {
            push(format!("{flag} {value:?}"), &[flag, value]);
        }
    }
    for (flag, list) in [
        ("--adaptive-uniform-spp", &["0", "1", "-1", ""][..]),
        ("--adaptive-floor", &["NaN", "0", "-0", "1.0000001", "inf"]),
        ("--adaptive-exponent", &["NaN", "-1", "4.0000001", "inf"]),
    ] {
        for value in list {
            push(
                format!("--adaptive on {flag} {value:?}"),
                &["--adaptive", "on", flag, value],
            );
        }
    }
    for (what, path) in maps {
        push(
            format!("--environment ({what})"),
            &["--environment", path.to_str().expect("UTF-8")],
        );
    }
    for (what, path) in scenes {
        push(
            format!("--scene ({what})"),
            &["--scene", path.to_str().expect("UTF-8")],
        );
    }
    // Designs the parser refuses fail before the scene is built; a sample is enough.
    for (what, path) in designs.iter().step_by(9) {
        push(
            format!("--design ({what})"),
            &["--design", path.to_str().expect("UTF-8")],
        );
    }
    let in_dir = |name: &str| dir.join(name).to_str().expect("UTF-8").to_owned();
    for value in [
        "",
        "/",
        &in_dir(".png"),
        &in_dir("upper.PNG"),
        &in_dir("folder/"),
    ] {
        push(format!("--out {value:?}"), &["--out", value]);
    }
    cases
}

fn top_level_cases() -> Vec<Case> {
    [
        &["--frobnicate"][..],
        &["frobnicate", "--json"],
        &["measure", "--json", "--json"],
        &["delta-e", "extra"],
        &["brdf", "--n", "1.5"],
        &["--version", "--help"],
    ]
    .iter()
    .map(|args| Case::new(format!("{args:?}"), args))
    .collect()
}

#[test]
fn no_input_makes_any_command_panic() {
    let start = std::time::Instant::now();
    let dir = temp_dir("malformed");
    let mut rng = Rng(0x00c0_a71a_b000_0016);
    let designs = design_files(&dir, &mut rng);
    let maps = environment_maps(&dir, &mut rng);
    let scenes = scene_files(&dir, &mut rng);
    let mut cases = Vec::new();
    cases.extend(table_cases(
        "brdf",
        "n,rho,kh,theta_i_deg,theta_o_deg,dphi_deg",
        "1.5,0.5,0.01,30,30,180",
        &mut rng,
    ));
    cases.extend(table_cases(
        "delta-e",
        "L1,a1,b1,L2,a2,b2",
        "50,1,2,50,1,2",
        &mut rng,
    ));
    cases.extend(color_cases(&dir, &mut rng));
    cases.extend(gloss_cases());
    cases.extend(measure_cases(&designs, &dir));
    cases.extend(fit_cases(&designs, &dir));
    cases.extend(render_cases(&dir, &designs, &maps, &scenes));
    cases.extend(top_level_cases());

    // A few processes at a time: most of a case is starting the binary.
    let next = AtomicUsize::new(0);
    let problems = Mutex::new(Vec::new());
    let statuses = Mutex::new(std::collections::BTreeMap::<Option<i32>, usize>::new());
    std::thread::scope(|scope| {
        for _ in 0..3 {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(case) = cases.get(i) else { break };
                    let output = case.run();
                    let code = output.status.code();
                    *statuses.lock().unwrap().entry(code).or_default() += 1;
                    let stderr = String::from_utf8_lossy(&output.stderr);
                    let refused = code.is_some_and(|c| c != 0);
                    if !code.is_some_and(|c| REFUSED_OR_DONE.contains(&c))
                        || stderr.contains("panicked")
                        || (refused && stderr.trim().is_empty())
                    {
                        problems.lock().unwrap().push(format!(
                            "{}: {:?} → {:?}\n{}",
                            case.what,
                            case.args,
                            output.status,
                            stderr.chars().take(600).collect::<String>()
                        ));
                    }
                }
            });
        }
    });
    let problems = problems.into_inner().unwrap();
    let statuses = statuses.into_inner().unwrap();
    eprintln!(
        "{} malformed inputs in {:.1} s; exit statuses: {statuses:?}",
        cases.len(),
        start.elapsed().as_secs_f64()
    );
    assert!(
        problems.is_empty(),
        "{} of {} cases ended badly:\n{}",
        problems.len(),
        cases.len(),
        problems.join("\n")
    );
    // The generator reaches each class, so the set is not all refused at the door.
    for code in REFUSED_OR_DONE {
        assert!(
            statuses.get(&Some(*code)).is_some_and(|&n| n >= 5),
            "status {code} is reached by too few cases: {statuses:?}"
        );
    }
    let _ = std::fs::remove_dir_all(dir);
}

// ---------------------------------------------------------------------------------
// A closed stdout or stderr

/// How a run with a closed stdout ended, and the lines read before closing it.
struct Closed {
    status: std::process::ExitStatus,
    stderr: String,
    lines: Vec<String>,
}

/// Runs coatlab with stdout a pipe whose reader closes it after `lines` lines; with
/// 0 it is closed before the command starts, so its first write fails whatever
/// the size of its output (a short output would otherwise fit the pipe's buffer
/// and never meet the closed end).
fn with_stdout_closed_after(args: &[&str], stdin: Vec<u8>, lines: usize) -> Closed {
    let mut command = bin();
    command
        .args(args)
        .stdin(Stdio::piped())
        .stderr(Stdio::piped());
    if lines == 0 {
        let (reader, writer) = std::io::pipe().expect("pipe");
        drop(reader);
        command.stdout(writer);
    } else {
        command.stdout(Stdio::piped());
    }
    let mut child = command.spawn().expect("coatlab starts");
    drop(command);
    let mut child_stdin = child.stdin.take().expect("piped");
    let feeder = std::thread::spawn(move || {
        let _ = child_stdin.write_all(&stdin);
    });
    let mut child_stderr = child.stderr.take().expect("piped");
    let stderr_reader = std::thread::spawn(move || {
        let mut text = String::new();
        child_stderr
            .read_to_string(&mut text)
            .expect("UTF-8 stderr");
        text
    });
    let mut read = Vec::new();
    if let Some(stdout) = child.stdout.take() {
        let mut stdout = BufReader::new(stdout);
        for _ in 0..lines {
            let mut line = String::new();
            stdout.read_line(&mut line).expect("read a line");
            read.push(line);
        }
        // Dropped here: the pipe has no reader any more.
    }
    let status = child.wait().expect("coatlab finishes");
    feeder.join().expect("the feeder does not panic");
    Closed {
        status,
        stderr: stderr_reader.join().expect("stderr reader"),
        lines: read,
    }
}

/// `rows` input rows of `row`, after `header`: far more output than a pipe buffers.
fn many_rows(header: &str, row: &str, rows: usize) -> Vec<u8> {
    let mut text = format!("{header}\n");
    for _ in 0..rows {
        text.push_str(row);
        text.push('\n');
    }
    text.into_bytes()
}

#[test]
fn a_stdout_closed_by_its_reader_ends_every_command_quietly_with_141() {
    let dir = temp_dir("closed-stdout");
    let spectra = dir.join("spectra.csv");
    std::fs::write(&spectra, "wavelength_nm,red\n400,0.1\n700,0.8\n").expect("write");
    let image = dir.join("car.png");
    let design = preset("signal-red");
    let design = design.to_str().expect("UTF-8");
    // 20 000 rows of ~60 bytes: over a megabyte, many times a pipe's buffer.
    let brdf_input = many_rows(
        "n,rho,kh,theta_i_deg,theta_o_deg,dphi_deg",
        "1.5,0.5,0.01,30,30,180",
        20_000,
    );
    let delta_e_input = many_rows(
        "L1,a1,b1,L2,a2,b2",
        "50,2.6772,-79.7751,50,0,-82.7485",
        20_000,
    );
    let cases: Vec<(Vec<&str>, Vec<u8>, usize, &str)> = vec![
        (
            vec!["brdf"],
            brdf_input,
            1,
            "n,rho,kh,theta_i_deg,theta_o_deg,dphi_deg,f_body,albedo\n",
        ),
        (
            vec!["delta-e"],
            delta_e_input,
            1,
            "L1,a1,b1,L2,a2,b2,dE00\n",
        ),
        (vec!["measure", design], Vec::new(), 0, ""),
        (vec!["measure", "--json", design], Vec::new(), 0, ""),
        (
            vec!["color", spectra.to_str().expect("UTF-8")],
            Vec::new(),
            0,
            "",
        ),
        (vec!["gloss", "--n", "1.5", "--gu", "80"], Vec::new(), 0, ""),
        (
            vec![
                "render",
                "--size",
                "4x3",
                "--spp",
                "1",
                "--wavelengths",
                "4",
                "--out",
                image.to_str().expect("UTF-8"),
            ],
            Vec::new(),
            0,
            "",
        ),
    ];
    for (args, stdin, lines, first) in cases {
        let closed = with_stdout_closed_after(&args, stdin, lines);
        assert_eq!(
            closed.status.code(),
            Some(exit::BROKEN_PIPE),
            "{args:?}: {}",
            closed.stderr
        );
        if lines > 0 {
            assert_eq!(closed.lines[0], first, "{args:?}");
        }
        // Quiet: no message, no panic; a render's progress bar is all it prints.
        let unexpected: Vec<&str> = closed
            .stderr
            .lines()
            .filter(|l| !(args[0] == "render" && l.contains("100%")))
            .collect();
        assert!(unexpected.is_empty(), "{args:?}: {}", closed.stderr);
    }
    // The render's image was written before the summary line met the closed pipe.
    assert!(std::fs::metadata(&image).is_ok_and(|m| m.len() > 0));
    let _ = std::fs::remove_dir_all(dir);
}

/// Runs coatlab with stderr a pipe that was closed before it started.
fn with_stderr_closed(args: &[&str]) -> Output {
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    bin()
        .args(args)
        .stdin(Stdio::null())
        .stderr(writer)
        .output()
        .expect("coatlab runs")
}

#[test]
fn a_closed_stderr_neither_stops_a_render_nor_turns_a_failure_into_a_panic() {
    let dir = temp_dir("closed-stderr");
    let image = dir.join("car.png");
    // The progress bar and the warnings go to stderr; they are not worth the render.
    let output = with_stderr_closed(&[
        "render",
        "--size",
        "4x3",
        "--spp",
        "2",
        "--wavelengths",
        "4",
        "--out",
        image.to_str().expect("UTF-8"),
    ]);
    assert_eq!(output.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&output.stdout).starts_with("wrote "));
    assert!(std::fs::metadata(&image).is_ok_and(|m| m.len() > 0));
    // The message is lost, the status is not.
    let output = with_stderr_closed(&["measure", "/nonexistent/design.toml"]);
    assert_eq!(output.status.code(), Some(exit::NO_INPUT));
    let _ = std::fs::remove_dir_all(dir);
}
