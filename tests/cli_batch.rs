//! End-to-end tests of `coatlab batch`: the task order of a manifest, the
//! scheduler's index variables, skipping outputs that are up to date and
//! rendering those whose inputs changed, and the refusal of bad manifests.

mod common;

use std::path::{Path, PathBuf};

use common::batch::{self, coatlab_batch as coatlab};
use common::{assert_mentions, exit, failure, scratch_with_presets, stdout};

/// A fresh folder with the signal red and deep blue presets in it.
fn scratch(name: &str) -> PathBuf {
    scratch_with_presets("cli_batch", name, &["signal-red", "deep-blue"])
}

/// A tiny manifest: 2 designs × 1 view × 2 lighting × `models`, 2 spp, 4 λ, 16×9.
fn manifest(dir: &Path, models: &str) -> PathBuf {
    batch::write_manifest(
        dir,
        &format!("scene = \"builtin\"\nviews = [\"front-34\"]\nmodels = {models}\nsize = \"16x9\""),
    )
}

fn s(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

/// The task lines of `batch run`'s output (printed as tasks finish), by index:
/// (index, output, rendered?).
fn outcomes(text: &str) -> Vec<(usize, String, bool)> {
    let mut lines: Vec<(usize, String, bool)> = text
        .lines()
        .filter_map(|line| {
            let rest = line.strip_prefix("task ")?;
            let (index, rest) = rest.split_once('/')?;
            let (_, rest) = rest.split_once(' ')?;
            let (output, outcome) = rest.split_once(": ")?;
            Some((
                index.parse().ok()?,
                output.to_owned(),
                outcome.starts_with("rendered"),
            ))
        })
        .collect();
    lines.sort();
    lines
}

#[test]
fn plan_lists_the_tasks_design_first_model_last() {
    let dir = scratch("plan");
    let path = manifest(&dir, r#"["paint", "phong-naive"]"#);
    let two_views = std::fs::read_to_string(&path)
        .expect("manifest")
        .replace(r#"views = ["front-34"]"#, r#"views = ["front-34", "side"]"#);
    std::fs::write(&path, two_views).expect("manifest");
    let text = stdout(&coatlab(&["batch", "plan", s(&path)], &[]));
    let outputs: Vec<&str> = text
        .lines()
        .skip(2)
        .map(|l| l.split_whitespace().nth(1).expect("an output"))
        .collect();
    let expected: Vec<String> = ["signal-red", "deep-blue"]
        .iter()
        .flat_map(|d| {
            ["front-34", "side"].iter().flat_map(move |v| {
                ["studio", "booth-d65"].iter().flat_map(move |l| {
                    ["paint", "phong-naive"]
                        .iter()
                        .map(move |m| format!("{d}--{v}--{l}--{m}.png"))
                })
            })
        })
        .collect();
    assert_eq!(outputs, expected, "{text}");
    assert!(
        text.lines().next().expect("a summary").contains("16 tasks"),
        "{text}"
    );
    // The view is applied: the first design's studio paint task from the front
    // three-quarter view and from the side are different images.
    for index in ["0", "4"] {
        stdout(&coatlab(&["batch", "run", s(&path), "--index", index], &[]));
    }
    let deck = dir.join("deck");
    let front = std::fs::read(deck.join("signal-red--front-34--studio--paint.png")).expect("png");
    let side = std::fs::read(deck.join("signal-red--side--studio--paint.png")).expect("png");
    assert_ne!(front, side, "the two views rendered the same image");
    let json: serde_json::Value = serde_json::from_str(&stdout(&coatlab(
        &["batch", "plan", s(&path), "--json"],
        &[],
    )))
    .expect("JSON");
    let tasks = json["tasks"].as_array().expect("tasks");
    for (i, task) in tasks.iter().enumerate() {
        assert_eq!(task["index"], i);
        assert_eq!(task["output"], expected[i].as_str());
    }
    assert_eq!(json["quality"]["samples_per_pixel"], 2);

    // A preset's name sets the samples and wavelengths.
    let text = std::fs::read_to_string(&path)
        .expect("read")
        .replace("spp = 2\nwavelengths = 4\n", "quality = \"draft\"\n");
    std::fs::write(&path, text).expect("write");
    let json: serde_json::Value = serde_json::from_str(&stdout(&coatlab(
        &["batch", "plan", s(&path), "--json"],
        &[],
    )))
    .expect("JSON");
    assert_eq!(json["quality"]["label"], "draft");
    assert_eq!(json["quality"]["samples_per_pixel"], 4);
    assert_eq!(json["quality"]["wavelengths"], 32);
}

#[test]
fn a_second_run_skips_and_a_changed_design_renders_again() {
    let dir = scratch("idempotent");
    let path = manifest(&dir, r#"["paint"]"#);
    let first = stdout(&coatlab(&["batch", "run", s(&path)], &[]));
    let rendered = outcomes(&first);
    assert_eq!(rendered.len(), 4, "{first}");
    assert!(rendered.iter().all(|(_, _, r)| *r), "{first}");
    let deck = dir.join("deck");
    let image = deck.join("deep-blue--front-34--studio--paint.png");
    let sidecar_path = deck.join("deep-blue--front-34--studio--paint.png.json");
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&sidecar_path).expect("a sidecar"))
            .expect("JSON");
    assert_eq!(sidecar["task"], 2);
    assert_eq!(sidecar["samples_per_pixel"], 2);
    assert_eq!(sidecar["inputs"]["design"]["name"], "Deep blue");
    assert!(sidecar["noise_delta_e00"]["mean"].as_f64().is_some());
    assert!(
        sidecar["readings"]["angles"]
            .as_array()
            .is_some_and(|a| !a.is_empty())
    );
    assert!(
        sidecar["readings"]["gloss"]
            .as_array()
            .is_some_and(|a| !a.is_empty())
    );
    let image_bytes = std::fs::read(&image).expect("an image");

    let second = stdout(&coatlab(&["batch", "run", s(&path)], &[]));
    assert!(outcomes(&second).iter().all(|(_, _, r)| !r), "{second}");

    // A comment is not a change; a changed value is.
    let design = dir.join("deep-blue.toml");
    let text = std::fs::read_to_string(&design).expect("read");
    std::fs::write(&design, format!("# reviewed\n{text}")).expect("write");
    let third = stdout(&coatlab(&["batch", "run", s(&path)], &[]));
    assert!(outcomes(&third).iter().all(|(_, _, r)| !r), "{third}");
    let edited = text.replacen("name = \"Deep blue\"", "name = \"Deep blue 2\"", 1);
    assert_ne!(edited, text, "the preset has a name line");
    std::fs::write(&design, edited).expect("write");
    let fourth = outcomes(&stdout(&coatlab(&["batch", "run", s(&path)], &[])));
    let again: Vec<usize> = fourth.iter().filter(|o| o.2).map(|o| o.0).collect();
    assert_eq!(again, [2, 3], "{fourth:?}");

    // A lost sidecar (a task killed after its image) renders again, the same image.
    std::fs::write(&design, &text).expect("write");
    stdout(&coatlab(&["batch", "run", s(&path)], &[]));
    std::fs::remove_file(&sidecar_path).expect("remove");
    let fifth = outcomes(&stdout(&coatlab(&["batch", "run", s(&path)], &[])));
    let again: Vec<usize> = fifth.iter().filter(|o| o.2).map(|o| o.0).collect();
    assert_eq!(again, [2], "{fifth:?}");
    assert!(
        std::fs::read(&image).expect("an image") == image_bytes,
        "same seed, same file"
    );
    // A damaged image renders again.
    std::fs::write(&image, b"not a png").expect("write");
    let sixth = outcomes(&stdout(&coatlab(&["batch", "run", s(&path)], &[])));
    assert_eq!(sixth.iter().filter(|o| o.2).count(), 1, "{sixth:?}");
    let leftovers: Vec<_> = std::fs::read_dir(&deck)
        .expect("deck")
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
}

#[test]
fn the_schedulers_index_variables_pick_one_task() {
    let dir = scratch("index");
    let path = manifest(&dir, r#"["paint"]"#);
    // (flags, environment, the task that must run)
    type Case<'a> = (&'a [&'a str], &'a [(&'a str, &'a str)], usize);
    let cases: [Case; 4] = [
        (&[], &[("SLURM_ARRAY_TASK_ID", "1")], 1),
        (&[], &[("JOB_COMPLETION_INDEX", "2")], 2),
        (&[], &[("AWS_BATCH_JOB_ARRAY_INDEX", "3")], 3),
        // --index wins over the environment.
        (&["--index", "0"], &[("SLURM_ARRAY_TASK_ID", "3")], 0),
    ];
    for (flags, env, index) in cases {
        let mut args = vec!["batch", "run", s(&path)];
        args.extend(flags);
        let text = stdout(&coatlab(&args, env));
        let done = outcomes(&text);
        assert_eq!(done.len(), 1, "{env:?}: {text}");
        assert_eq!(done[0].0, index, "{env:?}: {text}");
    }
    let images = std::fs::read_dir(dir.join("deck"))
        .expect("deck")
        .filter(|e| {
            e.as_ref()
                .is_ok_and(|e| e.file_name().to_string_lossy().ends_with(".png"))
        })
        .count();
    assert_eq!(images, 4);
    let err = failure(
        &coatlab(&["batch", "run", s(&path)], &[("SLURM_ARRAY_TASK_ID", "x")]),
        exit::USAGE,
    );
    assert!(err.contains("SLURM_ARRAY_TASK_ID='x'"), "{err}");
    let err = failure(
        &coatlab(
            &["batch", "run", s(&path)],
            &[("JOB_COMPLETION_INDEX", "4")],
        ),
        exit::USAGE,
    );
    assert_mentions(&err, &["JOB_COMPLETION_INDEX 4: out of range", "4 tasks"]);
}

#[test]
fn bad_manifests_are_refused_with_the_line_and_key() {
    let dir = scratch("refusals");
    let good = std::fs::read_to_string(manifest(&dir, r#"["paint"]"#)).expect("read");
    std::fs::create_dir_all(dir.join("other")).expect("folder");
    std::fs::copy(
        dir.join("signal-red.toml"),
        dir.join("other/signal-red.toml"),
    )
    .expect("copy");
    let cases: [(&str, &str, &str, i32); 10] = [
        (
            "size = \"16x9\"",
            "size = \"16x9\"\ncolour = \"red\"",
            "line 12: unknown field `colour`",
            exit::DATA,
        ),
        (
            "\"deep-blue.toml\"",
            "\"deep-blue.toml\", \"nowhere.toml\"",
            "line 4, key `designs`: 'nowhere.toml': no such design file",
            exit::DATA,
        ),
        (
            "\"deep-blue.toml\"",
            "\"deep-blue.toml\", \"other/signal-red.toml\"",
            "line 4, key `designs`: 'signal-red' is there twice",
            exit::DATA,
        ),
        (
            "[\"studio\", \"booth-d65\"]",
            "[\"studio\", \"booth-d65\", \"studio\"]",
            "line 5, key `lighting`: 'studio' is there twice",
            exit::DATA,
        ),
        (
            "[\"front-34\"]",
            "[\"front-43\"]",
            "line 9, key `views`: 'front-43' is not a view: use front-34, rear-34, side, front, rear, top, closeup or turntable:N",
            exit::DATA,
        ),
        (
            "spp = 2",
            "quality = \"ultra\"",
            "line 6, key `quality`: 'ultra': not a quality preset",
            exit::DATA,
        ),
        (
            "spp = 2",
            "spp = 2\nquality = \"final\"",
            "key `spp`: give either",
            exit::DATA,
        ),
        (
            "version = 1",
            "version = 2",
            "line 2, key `version`: version 2",
            exit::DATA,
        ),
        (
            "[\"paint\"]",
            "[\"lambert\"]",
            "line 10, key `models`: unknown model 'lambert'",
            exit::DATA,
        ),
        ("\"16x9\"", "\"16\"", "line 11, key `size`", exit::DATA),
    ];
    for (from, to, expected, code) in cases {
        let text = good.replacen(from, to, 1);
        assert_ne!(text, good, "{from}");
        let path = dir.join("bad.toml");
        std::fs::write(&path, text).expect("write");
        let err = failure(&coatlab(&["batch", "plan", s(&path)], &[]), code);
        assert!(
            err.contains(expected) && err.contains("bad.toml"),
            "{to}: {err}"
        );
    }
    let err = failure(
        &coatlab(&["batch", "plan", s(&dir.join("none.toml"))], &[]),
        exit::NO_INPUT,
    );
    assert!(err.contains("none.toml"), "{err}");
}

#[test]
fn a_failed_task_does_not_stop_the_others() {
    let dir = scratch("failure");
    let path = manifest(&dir, r#"["paint"]"#);
    // A folder where task 1's image should go: it cannot be written.
    std::fs::create_dir_all(dir.join("deck/signal-red--front-34--booth-d65--paint.png"))
        .expect("folder");
    let output = coatlab(&["batch", "run", s(&path)], &[]);
    let err = failure(&output, exit::CANT_CREATE);
    assert!(
        err.contains("task 1 (signal-red--front-34--booth-d65--paint.png) failed"),
        "{err}"
    );
    let text = String::from_utf8(output.stdout).expect("UTF-8");
    let done = outcomes(&text);
    let rendered: Vec<usize> = done.iter().filter(|o| o.2).map(|o| o.0).collect();
    assert_eq!(rendered, [0, 2, 3], "{text}");
    assert!(
        text.contains("task 1/4 signal-red--front-34--booth-d65--paint.png: failed"),
        "{text}"
    );
}
