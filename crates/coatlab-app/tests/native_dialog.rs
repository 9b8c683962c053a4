//! The system file dialog for real: the `coatlab` binary under a virtual X server
//! (Xvfb) with no desktop portal, so its File → Save and File → Open go to a real
//! `zenity --file-selection`, which `xdotool` drives as a person would (keys to the
//! window, a path typed into the dialog). The end-to-end test checks what a person
//! would see: the dialog appears with the request's title, Save writes the design at
//! the typed path (and nothing else there), Escape cancels without falling back to
//! the in-app browser, and Open loads the typed file into the window (its title) and
//! the recent files. Screenshots with the dialog open go to
//! `target/tmp/native-dialog/` (ImageMagick's `import`, where installed).
//!
//! Needs `Xvfb`, `zenity` and `xdotool` (CI's apt packages, `.ci/run`). Without them
//! the end-to-end test says so and passes on a developer's machine; where `CI` or
//! `COATLAB_REQUIRE_GUI_SMOKE` is set, a missing tool is a failure.
//!
//! The other tests check zenity's command line and how its answers are read, with no
//! tools needed.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{ExitStatus, Output};
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use coatlab_app::gui::dialogs::{
    DialogOutcome, DialogRequest, FileDialogs, NativeFileDialog, zenity_args, zenity_outcome,
};
use coatlab_app::gui::file_browser::FilePurpose;
use coatlab_core::design::{PaintDesign, presets};

#[path = "../../../tests/common/xvfb.rs"]
mod xvfb;
use xvfb::{Reaped, UnderX, app_dirs, coatlab_on, have, start_xvfb, xdotool};

// ---------------------------------------------------------------------------------
// zenity's command line and answers (no tools needed)

fn request(purpose: FilePurpose, directory: &Path, file_name: &str) -> DialogRequest {
    DialogRequest::for_purpose(purpose, directory.to_owned(), file_name.to_owned())
}

fn args(request: &DialogRequest) -> Vec<String> {
    zenity_args(request)
        .into_iter()
        .map(|a: OsString| a.to_string_lossy().into_owned())
        .collect()
}

#[test]
fn zenity_is_asked_with_the_title_the_start_directory_and_the_filter() {
    let dir = std::env::temp_dir();
    let open = args(&request(FilePurpose::OpenDesign, &dir, ""));
    assert!(open.contains(&"--file-selection".to_owned()), "{open:?}");
    assert!(open.contains(&"--title=Open design".to_owned()), "{open:?}");
    // A directory to start in ends in a slash, or zenity takes it as a file name.
    let start = format!("--filename={}/", dir.display()).replace("//", "/");
    assert!(open.contains(&start), "{open:?} lacks {start}");
    assert!(
        open.contains(&"--file-filter=Coatlab design (*.toml) | *.toml".to_owned()),
        "{open:?}"
    );
    assert!(open.contains(&"--file-filter=All files | *".to_owned()));
    assert!(!open.contains(&"--save".to_owned()));

    let save = args(&request(FilePurpose::SaveDesign, &dir, "signal-red.toml"));
    assert!(
        save.contains(&"--title=Save design as".to_owned()),
        "{save:?}"
    );
    let start = format!("--filename={}", dir.join("signal-red.toml").display());
    assert!(save.contains(&start), "{save:?} lacks {start}");
    assert!(save.contains(&"--save".to_owned()));
    assert!(save.contains(&"--confirm-overwrite".to_owned()));

    // Two extensions, and a '|' in the name, which would split zenity's filter.
    let mut export = request(FilePurpose::ExportPreviewImage, &dir, "car.png");
    export.filter_name = "PNG | EXR".into();
    let export = args(&export);
    assert!(
        export.contains(&"--file-filter=PNG / EXR (*.png, *.exr) | *.png *.exr".to_owned()),
        "{export:?}"
    );
}

#[test]
fn zenity_without_a_start_directory_gets_only_the_name() {
    let missing = Path::new("/nonexistent/coatlab/dir");
    let save = args(&request(FilePurpose::SaveDesign, missing, "a.toml"));
    assert!(save.contains(&"--filename=a.toml".to_owned()), "{save:?}");
    let open = args(&request(FilePurpose::OpenDesign, missing, ""));
    assert!(
        !open.iter().any(|a| a.starts_with("--filename")),
        "{open:?}"
    );
}

#[cfg(unix)]
fn exited(code: i32) -> ExitStatus {
    use std::os::unix::process::ExitStatusExt;
    ExitStatus::from_raw(code << 8)
}

#[cfg(unix)]
#[test]
fn zenity_answers_are_read_as_chosen_cancelled_or_failed() {
    use std::os::unix::ffi::OsStrExt;
    use std::os::unix::process::ExitStatusExt;
    assert_eq!(
        zenity_outcome(exited(0), b"/tmp/a b.toml\n", b""),
        DialogOutcome::Chosen(PathBuf::from("/tmp/a b.toml"))
    );
    // A name may end in a space: only zenity's newline goes.
    assert_eq!(
        zenity_outcome(exited(0), b"/tmp/x \n", b""),
        DialogOutcome::Chosen(PathBuf::from("/tmp/x "))
    );
    // Not UTF-8: still the file the person chose.
    let latin1 = b"/tmp/caf\xe9.toml";
    let mut with_newline = latin1.to_vec();
    with_newline.push(b'\n');
    assert_eq!(
        zenity_outcome(exited(0), &with_newline, b""),
        DialogOutcome::Chosen(PathBuf::from(std::ffi::OsStr::from_bytes(latin1)))
    );
    // Cancel, Escape or closing the window: 1; zenity's timeout: 5.
    assert_eq!(
        zenity_outcome(exited(1), b"", b""),
        DialogOutcome::Cancelled
    );
    assert_eq!(
        zenity_outcome(exited(5), b"", b""),
        DialogOutcome::Cancelled
    );
    // A zenity that could not show anything is not a cancel: the app falls back to
    // its own browser and says why (the last line, after GTK's chatter).
    let failed = zenity_outcome(
        exited(255),
        b"",
        b"(zenity:1): dconf-WARNING **: failed to commit\n\
          (zenity:1): Gtk-WARNING **: cannot open display: :9\n",
    );
    match failed {
        DialogOutcome::Unavailable(why) => {
            assert!(why.contains("cannot open display: :9"), "{why}")
        }
        other => panic!("expected Unavailable, got {other:?}"),
    }
    assert!(matches!(
        zenity_outcome(ExitStatus::from_raw(9), b"", b""),
        DialogOutcome::Unavailable(_)
    ));
}

/// A system dialog that answers at once and counts how often it was asked.
struct AtOnce {
    outcome: DialogOutcome,
    asked: AtomicUsize,
}

impl NativeFileDialog for AtOnce {
    fn ask(&self, _: &DialogRequest) -> DialogOutcome {
        self.asked.fetch_add(1, Ordering::SeqCst);
        self.outcome.clone()
    }
}

/// Escape in the dialog, then Ctrl+O before a frame took up the cancel (one frame
/// can take a second on a slow machine): a new dialog opens, not "a file dialog is
/// already open". The end-to-end test below first found this.
#[test]
fn a_dialog_that_just_closed_does_not_block_the_next_request() {
    for outcome in [
        DialogOutcome::Cancelled,
        DialogOutcome::Chosen(PathBuf::from("/tmp/x.toml")),
    ] {
        let native = Arc::new(AtOnce {
            outcome: outcome.clone(),
            asked: AtomicUsize::new(0),
        });
        let mut dialogs = FileDialogs::new(Some(native.clone()));
        let open = request(FilePurpose::OpenDesign, &std::env::temp_dir(), "");
        assert_eq!(dialogs.request(None, open.clone()), None);
        let start = Instant::now();
        while native.asked.load(Ordering::SeqCst) == 0 && start.elapsed() < Duration::from_secs(10)
        {
            std::thread::sleep(Duration::from_millis(5));
        }
        // The answer is sent right after `ask` returns; give the thread a moment.
        std::thread::sleep(Duration::from_millis(100));
        assert_eq!(
            dialogs.request(None, open),
            None,
            "after {outcome:?}, the next request was refused"
        );
        assert!(dialogs.is_waiting(), "the second dialog is not pending");
        assert!(
            dialogs.use_native(),
            "a {outcome:?} switched to the in-app browser"
        );
    }
}

// ---------------------------------------------------------------------------------
// The real binary, the real zenity

/// Whether the end-to-end test can run; a missing tool fails it on CI.
fn tools_present() -> bool {
    let missing: Vec<&str> = ["Xvfb", "zenity", "xdotool"]
        .into_iter()
        .filter(|t| !have(t))
        .collect();
    if missing.is_empty() {
        return true;
    }
    let on_ci = ["CI", "COATLAB_REQUIRE_GUI_SMOKE"]
        .iter()
        .any(|v| std::env::var_os(v).is_some_and(|x| !x.is_empty()));
    assert!(
        !on_ci,
        "CI is set but {} missing (install them: see .ci/run)",
        missing.join(", ")
    );
    eprintln!(
        "skipped: {} not installed (apt-get install xvfb zenity xdotool)",
        missing.join(", ")
    );
    false
}

/// How long the window may take: a debug build drawn by lavapipe on a loaded
/// 2-core machine has been seen at about one frame per second.
const START_TIMEOUT: Duration = Duration::from_secs(180);
/// How long one step (a key to a frame to a dialog, a dialog to a loaded file) may take.
const STEP_TIMEOUT: Duration = Duration::from_secs(60);

/// The app under the X server; no state of the test's own.
type Session = UnderX<()>;

impl UnderX<()> {
    /// Runs `xdotool args` on our display; killed after 20 s (a `--sync` that never
    /// sees its event would otherwise hang the test).
    fn xdotool(&self, args: &[&str]) -> Output {
        xdotool(&self.display, args)
    }

    /// Gives `window` the keyboard (there is no window manager) and presses `keys`.
    fn keys(&self, window: &str, keys: &[&str]) {
        let out = self.xdotool(&["windowfocus", "--sync", window]);
        assert!(
            out.status.success(),
            "xdotool windowfocus {window}: {out:?}"
        );
        for k in keys {
            let out = self.xdotool(&["key", "--clearmodifiers", k]);
            assert!(out.status.success(), "xdotool key {k}: {out:?}");
        }
    }

    fn type_text(&self, text: &str) {
        let out = self.xdotool(&["type", "--delay", "10", text]);
        assert!(out.status.success(), "xdotool type: {out:?}");
    }
}

fn first_recent(state: &Path) -> Option<PathBuf> {
    std::fs::read_to_string(state.join("recent.txt"))
        .ok()?
        .lines()
        .next()
        .map(PathBuf::from)
}

#[test]
fn save_and_open_through_the_real_zenity_dialog() {
    if !tools_present() {
        return;
    }
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("native-dialog");
    let _ = std::fs::remove_dir_all(&dir);
    let work = dir.join("work");
    let designs = dir.join("designs");
    let saved_dir = dir.join("saved");
    for d in [&work, &designs, &saved_dir] {
        std::fs::create_dir_all(d).expect("test directories");
    }
    let (runtime, state) = app_dirs(&dir).expect("runtime and state directories");

    // The design to open: a preset under a name no other design has, so the window
    // title shows that this file, and no other, was loaded.
    let blue_path = designs.join("blue.toml");
    let mut blue = presets::by_slug("deep-blue")
        .expect("the deep-blue preset")
        .design;
    blue.name = "Native dialog blue".into();
    blue.save(&blue_path).expect("write the design to open");
    let start_design = presets::all().swap_remove(0).design;

    let (xvfb, display) = start_xvfb().unwrap_or_else(|e| panic!("{e}"));
    let log = dir.join("coatlab.log");
    // A runtime directory without a bus socket and no bus address: no portal can
    // answer (nor pop up on the developer's own desktop), so zenity serves.
    let app = coatlab_on(&display, &runtime, &log)
        .current_dir(&work)
        .env("COATLAB_STATE_DIR", &state)
        // zenity's GTK: keep settings in memory (no dconf daemon here) and do not look
        // for the accessibility bus, which only slows its start.
        .env("GSETTINGS_BACKEND", "memory")
        .env("NO_AT_BRIDGE", "1")
        .spawn()
        .map(Reaped)
        .expect("start coatlab");
    let mut s = Session {
        display,
        app,
        log,
        shots: Some(dir.clone()),
        state: (),
    };

    // The window, once it has drawn a frame (the title then names the design).
    let window = s.wait("coatlab window", START_TIMEOUT, |s| {
        s.first_window("^Coatlab")
    });
    let start_title = format!("Coatlab — {}", start_design.name);
    s.wait("first frame (window title)", START_TIMEOUT, |s| {
        (s.window_name(&window) == start_title).then_some(())
    });

    // Save: the design has no file yet, so Ctrl+S asks where. The name field holds
    // the suggested name, selected; a typed path replaces it.
    s.keys(&window, &["ctrl+s"]);
    let dialog = s.wait("save dialog titled \"Save design as\"", STEP_TIMEOUT, |s| {
        s.first_window("^Save design as$")
    });
    s.screenshot("save-dialog");
    let saved_path = saved_dir.join("from-the-dialog.toml");
    s.keys(&dialog, &["ctrl+a"]);
    s.type_text(&saved_path.display().to_string());
    s.keys(&dialog, &["Return"]);
    s.wait("saved file in recent files", STEP_TIMEOUT, |_| {
        (first_recent(&state).as_deref() == Some(saved_path.as_path())).then_some(())
    });
    let text = std::fs::read_to_string(&saved_path).expect("the saved design");
    assert!(
        text.parse::<toml::Table>().is_ok(),
        "not TOML: {}",
        saved_path.display()
    );
    let saved = PaintDesign::load(&saved_path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        saved, start_design,
        "the saved file is not the window's design"
    );
    // Written atomically: the temporary file was renamed, none is left beside it.
    let left: Vec<_> = std::fs::read_dir(&saved_dir)
        .expect("list saved/")
        .filter_map(Result::ok)
        .map(|e| e.file_name())
        .collect();
    assert_eq!(left, vec![OsString::from("from-the-dialog.toml")]);

    // Cancel: Escape closes the dialog and changes nothing; the system dialog stays
    // in use (a cancel is not "no dialog here", which would open the in-app browser).
    s.keys(&window, &["ctrl+o"]);
    let dialog = s.wait("open dialog titled \"Open design\"", STEP_TIMEOUT, |s| {
        s.first_window("^Open design$")
    });
    s.keys(&dialog, &["Escape"]);
    s.wait("the cancelled dialog to close", STEP_TIMEOUT, |s| {
        s.first_window("^Open design$").is_none().then_some(())
    });

    // Open: the dialog again, the path typed into its location field.
    s.keys(&window, &["ctrl+o"]);
    let dialog = s.wait("open dialog after a cancel", STEP_TIMEOUT, |s| {
        s.first_window("^Open design$")
    });
    s.keys(&dialog, &["ctrl+l"]);
    s.type_text(&blue_path.display().to_string());
    s.screenshot("open-dialog");
    s.keys(&dialog, &["Return"]);
    let blue_title = "Coatlab — Native dialog blue";
    s.wait("the opened design in the window title", STEP_TIMEOUT, |s| {
        (s.window_name(&window) == blue_title).then_some(())
    });
    assert_eq!(first_recent(&state), Some(blue_path.clone()));
    assert!(
        s.app.0.try_wait().expect("poll coatlab").is_none(),
        "coatlab exited:\n{}",
        s.log_text()
    );
    drop(s);
    drop(xvfb);
}
