//! Crash recovery for real: the `coatlab` binary under a virtual X server (Xvfb),
//! edited through X input events (`xdotool`: a name typed into the Name field, a
//! ρ(λ) control point dragged, a click on the thickness slider), left running past
//! the autosave interval, killed with SIGKILL, and started again: the window must
//! offer the autosave, *Recover* must bring back every edit and the file the design
//! belongs to, and Ctrl+S must then write exactly the autosaved design to that file.
//!
//! Where the widgets are comes from the same `CoatlabApp` laid out headless by
//! egui_kittest at the window's size (the layout is the code's, not guessed pixels).
//! The app runs with its own HOME and XDG directories under the test's temporary
//! directory, and `COATLAB_AUTOSAVE_SECONDS` shortens the interval (docs/gui.md).
//!
//! Needs `Xvfb` and `xdotool` (CI's packages, `.ci/run`); without them the test says
//! so and passes, unless `CI` or `COATLAB_REQUIRE_GUI_SMOKE` is set. Where ImageMagick
//! is installed (CI) the recovery bar is also looked for in a screenshot.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use coatlab_app::gui::app::AUTOSAVE_INTERVAL_VAR;
use coatlab_app::gui::storage::Storage;
use coatlab_app::gui::{AppOptions, CoatlabApp};
use coatlab_core::design::{PaintDesign, presets};
use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;

#[path = "common/harness.rs"]
mod harness;
use harness::app_harness;

#[path = "common/xvfb.rs"]
mod xvfb;
use xvfb::{Reaped, UnderX, coatlab_on, gui_tools_required, have, start_xvfb, xdotool};

/// The window's inner size (gui/mod.rs) and so the headless layout's.
const WINDOW: egui::Vec2 = egui::vec2(1500.0, 940.0);
/// The autosave interval the app runs with here, s: short, so the test is quick,
/// but several frames long, so the autosave is a periodic one and not the edit's.
const INTERVAL_S: f64 = 1.0;
/// How long the window may take to show its first frame: a debug build drawn by
/// lavapipe on a loaded 2-core machine has been seen at about one frame a second.
const START_TIMEOUT: Duration = Duration::from_secs(90);
/// How long one step (an input event to what it changes) may take.
const STEP_TIMEOUT: Duration = Duration::from_secs(30);
const EDITED_NAME: &str = "Recovered after kill";

/// The recovery bar's fill (gui/app.rs, `recovery_ui`).
const BAR_FILL: [u8; 3] = [60, 50, 20];

struct Dirs {
    root: PathBuf,
    home: PathBuf,
    runtime: PathBuf,
    state_home: PathBuf,
}

impl Dirs {
    fn new(root: &Path) -> Dirs {
        let _ = std::fs::remove_dir_all(root);
        let dirs = Dirs {
            root: root.to_owned(),
            home: root.join("home"),
            runtime: root.join("runtime"),
            state_home: root.join("home/.local/state"),
        };
        for d in [&dirs.home, &dirs.runtime, &dirs.state_home] {
            std::fs::create_dir_all(d).expect("test directories");
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&dirs.runtime, std::fs::Permissions::from_mode(0o700))
                .expect("XDG_RUNTIME_DIR mode");
        }
        dirs
    }

    /// Where the app keeps its autosave: `$XDG_STATE_HOME/coatlab` (gui/storage.rs).
    fn state(&self) -> PathBuf {
        self.state_home.join("coatlab")
    }
}

/// The binary running under a display; the test's state is its window's id.
type Running = UnderX<String>;

impl UnderX<String> {
    fn start(dirs: &Dirs, display: &str, name: &str, args: &[&Path]) -> Running {
        let log = dirs.root.join(format!("{name}.log"));
        let app = coatlab_on(display, &dirs.runtime, &log)
            .args(args)
            .current_dir(&dirs.root)
            .env("HOME", &dirs.home)
            .env("XDG_STATE_HOME", &dirs.state_home)
            .env("XDG_CONFIG_HOME", dirs.home.join(".config"))
            .env("XDG_DATA_HOME", dirs.home.join(".local/share"))
            .env("XDG_CACHE_HOME", dirs.home.join(".cache"))
            .env_remove("COATLAB_STATE_DIR")
            .env_remove("COATLAB_FRAME_LOG")
            // One X pixel per egui point, as in the headless layout.
            .env("WINIT_X11_SCALE_FACTOR", "1")
            .env(AUTOSAVE_INTERVAL_VAR, INTERVAL_S.to_string())
            .spawn()
            .map(Reaped)
            .expect("start coatlab");
        let mut running = Running {
            display: display.to_owned(),
            app,
            log,
            shots: Some(dirs.root.clone()),
            state: String::new(),
        };
        running.state = running.wait("the coatlab window", START_TIMEOUT, |r| {
            r.first_window("^Coatlab")
        });
        running
    }

    fn xdotool(&self, args: &[&str]) {
        let out = xdotool(&self.display, args);
        assert!(out.status.success(), "xdotool {args:?}: {out:?}");
    }

    fn title(&self) -> String {
        self.window_name(&self.state)
    }

    fn focus(&self) {
        self.xdotool(&["windowfocus", "--sync", &self.state]);
    }

    fn key(&self, key: &str) {
        self.focus();
        self.xdotool(&["key", "--clearmodifiers", key]);
    }

    /// Moves the pointer to `at` (window coordinates, points = pixels here).
    fn pointer(&self, at: egui::Pos2) {
        let (x, y) = (at.x.round().to_string(), at.y.round().to_string());
        self.xdotool(&["mousemove", "--window", &self.state, &x, &y]);
    }

    /// A press and release at `at`, each held over a few frames (egui sees pointer
    /// state per frame).
    fn click(&self, at: egui::Pos2) {
        self.pointer(at);
        pause();
        self.xdotool(&["mousedown", "1"]);
        pause();
        self.xdotool(&["mouseup", "1"]);
        pause();
    }

    /// A left-button drag from `from` by `by`, in steps a frame or more apart.
    fn drag(&self, from: egui::Pos2, by: egui::Vec2) {
        self.pointer(from);
        pause();
        self.xdotool(&["mousedown", "1"]);
        pause();
        for k in 1..=6 {
            self.pointer(from + by * (k as f32 / 6.0));
            pause();
        }
        self.xdotool(&["mouseup", "1"]);
        pause();
    }
}

fn pause() {
    std::thread::sleep(Duration::from_millis(300));
}

/// The same app laid out headless at the window's size: where its widgets are.
fn layout(options: AppOptions) -> Harness<'static, CoatlabApp> {
    let mut h = app_harness(WINDOW, false, CoatlabApp::new(options));
    h.run();
    h
}

fn load(path: &Path) -> Option<PaintDesign> {
    PaintDesign::load(path).ok()
}

/// Share of the pixels of `region` in a screenshot of `display` that have the
/// recovery bar's fill; `None` without ImageMagick.
fn bar_share(display: &str, region: egui::Rect, shot: &Path) -> Option<f64> {
    if !(have("import") && have("convert")) {
        return None;
    }
    let ok = Command::new("import")
        .args(["-display", display, "-window", "root"])
        .arg(shot)
        .status()
        .is_ok_and(|s| s.success());
    assert!(ok, "import failed");
    let crop = format!(
        "{}x{}+{}+{}",
        region.width().round(),
        region.height().round(),
        region.left().round(),
        region.top().round()
    );
    let out = Command::new("convert")
        .arg(shot)
        .args(["-crop", &crop, "-depth", "8", "rgb:-"])
        .output()
        .expect("run convert");
    let pixels: Vec<&[u8]> = out.stdout.chunks_exact(3).collect();
    let fill = pixels
        .iter()
        .filter(|p| p.iter().zip(BAR_FILL).all(|(&a, b)| a.abs_diff(b) <= 2))
        .count();
    Some(fill as f64 / pixels.len().max(1) as f64)
}

#[test]
fn edits_survive_sigkill_through_the_periodic_autosave_and_are_recovered() {
    let missing: Vec<&str> = ["Xvfb", "xdotool"]
        .into_iter()
        .filter(|t| !have(t))
        .collect();
    if !missing.is_empty() {
        assert!(
            !gui_tools_required(),
            "CI or COATLAB_REQUIRE_GUI_SMOKE is set but {} missing (see .ci/run)",
            missing.join(", ")
        );
        eprintln!(
            "skipped: {} not installed (apt-get install xvfb xdotool)",
            missing.join(", ")
        );
        return;
    }
    let started = Instant::now();
    let dirs = Dirs::new(&Path::new(env!("CARGO_TARGET_TMPDIR")).join("gui-crash"));
    let state = dirs.state();
    let autosave = state.join("autosave.toml");

    // The design file being edited: a preset under a name of its own.
    let file = dirs.root.join("mine.toml");
    let mut original = presets::by_slug("signal-red")
        .expect("the signal-red preset")
        .design;
    original.name = "Crash test".into();
    original.save(&file).expect("write the design");
    let file_bytes = std::fs::read(&file).expect("read the design back");

    // Where the widgets are, from the same code at the same size.
    let (name_field, rho_550, thickness) = {
        let h = layout(AppOptions {
            storage: Storage::none(),
            open: Some(file.clone()),
            preview: false,
        });
        let rect = |role, label: &str| h.get_by_role_and_label(role, label).rect();
        (
            rect(Role::TextInput, "Name"),
            rect(Role::Slider, "ρ at 550 nm"),
            rect(Role::Slider, "Thickness h (µm)"),
        )
    };

    let (xvfb, display) = start_xvfb().unwrap_or_else(|e| panic!("{e}"));

    // First session: open the file, edit it three ways, never save.
    let mut s = Running::start(&dirs, &display, "first", &[file.as_path()]);
    s.wait("the design's title", START_TIMEOUT, |s| {
        (s.title() == "Coatlab — Crash test").then_some(())
    });
    s.focus();
    s.click(name_field.center());
    s.key("ctrl+a");
    s.xdotool(&["type", "--delay", "20", EDITED_NAME]);
    let edited_title = format!("Coatlab — {EDITED_NAME} •");
    s.wait("the typed name in the title", STEP_TIMEOUT, |s| {
        (s.title() == edited_title).then_some(())
    });
    // Leave the field, so the keys below are not typed into it.
    s.key("Escape");
    // ρ at 550 nm up by about 0.4 (the curve spans 0–1 over 150 points).
    s.drag(rho_550.center(), egui::vec2(0.0, -60.0));
    // Three quarters along the thickness slider's rail (0–200 µm).
    s.click(egui::pos2(
        thickness.left() + 0.75 * thickness.width(),
        thickness.center().y,
    ));

    // The periodic autosave: all three edits on disk, the file untouched. Waiting
    // for the content (not the file) is waiting past the interval after the last edit.
    let edits_in = |d: &PaintDesign| {
        d.name == EDITED_NAME
            && d.thickness_um > 100.0
            && d.albedo.value_at_nm(550.0) > original.albedo.value_at_nm(550.0) + 0.2
    };
    let saved = s.wait("an autosave with all three edits", STEP_TIMEOUT, |_| {
        load(&autosave).filter(edits_in)
    });
    assert_eq!(
        std::fs::read_to_string(state.join("autosave-path.txt"))
            .expect("autosave-path.txt")
            .trim(),
        file.display().to_string(),
        "the autosave names the file it belongs to"
    );
    // No further edit is coming: the autosave stays as it is.
    std::thread::sleep(Duration::from_secs_f64(2.0 * INTERVAL_S) + Duration::from_millis(500));
    let saved_again = load(&autosave).expect("the autosave, again");
    assert_eq!(saved_again, saved, "the autosave changed without an edit");
    let edited = saved;
    assert_eq!(
        std::fs::read(&file).expect("the design file"),
        file_bytes,
        "the edits were saved to the file; the test needs them unsaved"
    );

    // The crash: SIGKILL, no exit handler runs.
    assert!(
        s.app.0.try_wait().expect("poll").is_none(),
        "coatlab exited early:\n{}",
        s.log_text()
    );
    s.app.0.kill().expect("SIGKILL coatlab");
    let status = s.app.0.wait().expect("reap coatlab");
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        assert_eq!(status.signal(), Some(9), "{status}");
    }
    drop(s);
    assert_eq!(load(&autosave).as_ref(), Some(&edited));

    // Where the recovery bar and its button are, from a copy of the state (the
    // headless app must not touch the real one).
    let scratch = dirs.root.join("state-copy");
    std::fs::create_dir_all(&scratch).expect("scratch state");
    for name in ["autosave.toml", "autosave-path.txt"] {
        std::fs::copy(state.join(name), scratch.join(name)).expect("copy the autosave");
    }
    let (recover, bar) = {
        let h = layout(AppOptions {
            storage: Storage::in_dir(&scratch),
            open: None,
            preview: false,
        });
        assert!(h.state().pending_recovery().is_some());
        let recover = h.get_by_label("Recover").rect();
        let text = h
            .get_by_label_contains("from the last session were autosaved")
            .rect();
        (recover, text.union(recover))
    };

    // Second session: the default design, the autosave offered.
    let mut s = Running::start(&dirs, &display, "second", &[]);
    s.wait("the default design's title", START_TIMEOUT, |s| {
        (s.title() == "Coatlab — Signal red").then_some(())
    });
    let shot = dirs.root.join("recovery-offered.png");
    if bar_share(&display, bar, &shot).is_some() {
        // Polled: the title is set while the first frame is laid out, before it is
        // on screen.
        s.wait("the recovery bar on screen", STEP_TIMEOUT, |s| {
            bar_share(&s.display, bar.expand(2.0), &shot).filter(|&share| share > 0.3)
        });
    } else {
        assert!(
            !gui_tools_required(),
            "ImageMagick is missing; CI installs it (see .ci/run)"
        );
    }
    s.focus();
    s.click(recover.center());
    s.wait("the recovered design's title", STEP_TIMEOUT, |s| {
        (s.title() == edited_title).then_some(())
    });
    // The recovered design still belongs to its file: Ctrl+S writes it there
    // without asking, and the autosave goes.
    s.key("ctrl+s");
    let written = s.wait(
        "the recovered design saved to its file",
        STEP_TIMEOUT,
        |_| load(&file).filter(|d| d.name == EDITED_NAME),
    );
    assert_eq!(
        (written.name.as_str(), written.thickness_um),
        (edited.name.as_str(), edited.thickness_um),
        "name and thickness of the saved design"
    );
    assert_eq!(written.albedo, edited.albedo, "ρ(λ) of the saved design");
    assert_eq!(written, edited, "the saved design is not the autosaved one");
    s.wait("the autosave removed after the save", STEP_TIMEOUT, |_| {
        (!autosave.exists()).then_some(())
    });
    s.wait("the saved title", STEP_TIMEOUT, |s| {
        (s.title() == format!("Coatlab — {EDITED_NAME}")).then_some(())
    });
    drop(s);
    drop(xvfb);
    eprintln!(
        "crash recovery checked in {:.1} s",
        started.elapsed().as_secs_f64()
    );
}
