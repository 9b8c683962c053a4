//! What the app keeps between sessions: the recent-files list and the autosave of an
//! unsaved design, in one state directory.
//!
//! The directory is `$COATLAB_STATE_DIR` if set (tests and portable installs),
//! else the platform's, through the `directories` crate: on Linux
//! `$XDG_STATE_HOME/coatlab` or `~/.local/state/coatlab` (the home folder from the
//! user database when `HOME` is unset); on macOS `~/Library/Application
//! Support/Coatlab`; on Windows `%LOCALAPPDATA%\Coatlab\data`. When none can be
//! found the app runs without recent files and autosave, and says so
//! ([`Storage::unavailable`]).
//!
//! Crash recovery: while the design has unsaved changes it is written to
//! `autosave.toml` every few seconds (atomically, through [`PaintDesign::save`]),
//! with the path it belongs to in `autosave-path.txt`. A clean exit, or saving the
//! design, removes both. So an `autosave.toml` found at start-up means the last
//! session ended without saving, and the app offers to recover it.

use std::fs;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use anyhow::Context;
use coatlab_core::design::PaintDesign;
use coatlab_core::io::atomic::write_bytes_atomically;
use directories::ProjectDirs;

/// How many recent files are remembered.
pub const MAX_RECENT: usize = 10;
const RECENT_FILE: &str = "recent.txt";
const AUTOSAVE_FILE: &str = "autosave.toml";
const AUTOSAVE_PATH_FILE: &str = "autosave-path.txt";
/// The variable that chooses the state directory over the platform's.
pub const STATE_DIR_VAR: &str = "COATLAB_STATE_DIR";
/// The application's name in the platform's folders.
const APPLICATION: &str = "Coatlab";

/// The state directory, or none (persistence off).
#[derive(Debug, Clone, Default)]
pub struct Storage {
    dir: Option<PathBuf>,
    /// Why there is no directory, when one was looked for and not found.
    unavailable: Option<String>,
}

/// An autosaved design found at start-up.
#[derive(Debug, Clone)]
pub struct Recovery {
    /// The recovered design.
    pub design: PaintDesign,
    /// The file it was being edited as, if it had one.
    pub path: Option<PathBuf>,
    /// When it was autosaved.
    pub saved_at: Option<SystemTime>,
}

impl Storage {
    /// Persistence in `dir` (created when first written).
    pub fn in_dir(dir: impl Into<PathBuf>) -> Self {
        Self {
            dir: Some(dir.into()),
            unavailable: None,
        }
    }

    /// No persistence at all (headless tests).
    pub fn none() -> Self {
        Self::default()
    }

    /// The state directory of this user on this platform (see the module
    /// documentation).
    pub fn from_environment() -> Self {
        let chosen = std::env::var_os(STATE_DIR_VAR)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from);
        let platform = ProjectDirs::from("", "", APPLICATION);
        Self::choose(chosen, platform.as_ref())
    }

    /// The directory `chosen` by [`STATE_DIR_VAR`], else the platform's state
    /// folder (Linux), else its local data folder (macOS, Windows); none, with the
    /// reason, when neither is there.
    fn choose(chosen: Option<PathBuf>, platform: Option<&ProjectDirs>) -> Self {
        let dir = chosen
            .or_else(|| platform.map(|p| p.state_dir().unwrap_or(p.data_local_dir()).to_owned()));
        match dir {
            Some(dir) => Self::in_dir(dir),
            None => Self {
                dir: None,
                unavailable: Some(format!(
                    "No folder for the app's state was found (no home folder is known; \
                     set {STATE_DIR_VAR} to choose one): recent files and the autosave \
                     of unsaved changes are off."
                )),
            },
        }
    }

    /// Why persistence is off although it was asked for ([`Self::from_environment`]
    /// found no folder), for the user to read; `None` when it is on, or off by
    /// choice ([`Self::none`]).
    pub fn unavailable(&self) -> Option<&str> {
        self.unavailable.as_deref()
    }

    /// The directory, if persistence is on.
    pub fn dir(&self) -> Option<&Path> {
        self.dir.as_deref()
    }

    fn file(&self, name: &str) -> Option<PathBuf> {
        self.dir.as_ref().map(|d| d.join(name))
    }

    /// The remembered recent files, newest first (missing list: none).
    pub fn recent_files(&self) -> Vec<PathBuf> {
        let Some(path) = self.file(RECENT_FILE) else {
            return Vec::new();
        };
        fs::read_to_string(path)
            .map(|text| {
                text.lines()
                    .filter(|l| !l.trim().is_empty())
                    .map(PathBuf::from)
                    .take(MAX_RECENT)
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Puts `path` first in the recent list and writes the list.
    pub fn add_recent(&self, path: &Path) -> anyhow::Result<Vec<PathBuf>> {
        let path = path.canonicalize().unwrap_or_else(|_| path.to_owned());
        let mut list = self.recent_files();
        list.retain(|p| *p != path);
        list.insert(0, path);
        list.truncate(MAX_RECENT);
        if let Some(file) = self.file(RECENT_FILE) {
            let text: String = list.iter().map(|p| format!("{}\n", p.display())).collect();
            self.ensure_dir()?;
            write_bytes_atomically(&file, text.as_bytes())?;
        }
        Ok(list)
    }

    fn ensure_dir(&self) -> anyhow::Result<()> {
        if let Some(dir) = &self.dir {
            fs::create_dir_all(dir)
                .with_context(|| format!("cannot create the state directory {}", dir.display()))?;
        }
        Ok(())
    }

    /// Writes the autosave of an unsaved design (atomic; an invalid design is not
    /// written, the previous autosave stays).
    pub fn autosave(&self, design: &PaintDesign, path: Option<&Path>) -> anyhow::Result<()> {
        let (Some(file), Some(path_file)) =
            (self.file(AUTOSAVE_FILE), self.file(AUTOSAVE_PATH_FILE))
        else {
            return Ok(());
        };
        self.ensure_dir()?;
        design.save(&file)?;
        let text = path.map(|p| p.display().to_string()).unwrap_or_default();
        write_bytes_atomically(&path_file, text.as_bytes())?;
        Ok(())
    }

    /// Removes the autosave (the design was saved, or the app closed cleanly).
    pub fn clear_autosave(&self) {
        for name in [AUTOSAVE_FILE, AUTOSAVE_PATH_FILE] {
            if let Some(file) = self.file(name) {
                // Absent is the usual case; any other failure only means an offer to
                // recover next time, which the user can decline.
                let _ = fs::remove_file(file);
            }
        }
    }

    /// The autosave left by a session that did not end cleanly, if any. An autosave
    /// that no longer loads is reported as an error (and kept for inspection).
    pub fn recovery(&self) -> anyhow::Result<Option<Recovery>> {
        let Some(file) = self.file(AUTOSAVE_FILE) else {
            return Ok(None);
        };
        if !file.exists() {
            return Ok(None);
        }
        let design =
            PaintDesign::load(&file).context("the autosaved design cannot be recovered")?;
        let path = self
            .file(AUTOSAVE_PATH_FILE)
            .and_then(|f| fs::read_to_string(f).ok())
            .map(|t| t.trim().to_owned())
            .filter(|t| !t.is_empty())
            .map(PathBuf::from);
        let saved_at = fs::metadata(&file).and_then(|m| m.modified()).ok();
        Ok(Some(Recovery {
            design,
            path,
            saved_at,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use coatlab_core::design::presets;

    #[test]
    fn recent_files_are_newest_first_without_duplicates() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let s = Storage::in_dir(dir.path().join("state"));
        assert!(s.recent_files().is_empty());
        s.add_recent(Path::new("/a.toml")).expect("writable");
        s.add_recent(Path::new("/b.toml")).expect("writable");
        let list = s.add_recent(Path::new("/a.toml")).expect("writable");
        assert_eq!(
            list,
            vec![PathBuf::from("/a.toml"), PathBuf::from("/b.toml")]
        );
        assert_eq!(s.recent_files(), list);
    }

    #[test]
    fn an_autosave_is_offered_until_cleared() {
        let dir = tempfile::tempdir().expect("a temporary folder");
        let s = Storage::in_dir(dir.path().join("state"));
        assert!(s.recovery().expect("nothing there").is_none());
        let mut design = presets::all()[0].design.clone();
        design.thickness_um = 51.5;
        s.autosave(&design, Some(Path::new("/designs/red.toml")))
            .expect("writable");
        let r = s.recovery().expect("readable").expect("autosave present");
        assert_eq!(r.design, design);
        assert_eq!(r.path, Some(PathBuf::from("/designs/red.toml")));
        s.clear_autosave();
        assert!(s.recovery().expect("nothing there").is_none());
    }

    /// The variable wins; then the platform's state folder (Linux), else its local
    /// data folder (macOS, Windows); with neither, persistence is off and says why.
    #[test]
    fn the_state_directory_is_chosen_in_order_and_its_absence_is_said() {
        let platform = ProjectDirs::from_path(PathBuf::from("coatlab"));
        let chosen = Storage::choose(Some(PathBuf::from("/portable/state")), platform.as_ref());
        assert_eq!(chosen.dir(), Some(Path::new("/portable/state")));
        assert_eq!(chosen.unavailable(), None);
        if let Some(platform) = &platform {
            let expected = platform.state_dir().unwrap_or(platform.data_local_dir());
            let found = Storage::choose(None, Some(platform));
            assert_eq!(found.dir(), Some(expected));
            assert!(expected.ends_with("coatlab"), "{}", expected.display());
            #[cfg(target_os = "linux")]
            assert!(
                expected.ends_with(".local/state/coatlab")
                    || std::env::var_os("XDG_STATE_HOME").is_some(),
                "{}",
                expected.display()
            );
        }
        let nowhere = Storage::choose(None, None);
        assert_eq!(nowhere.dir(), None);
        let why = nowhere.unavailable().expect("a reason");
        assert!(
            why.contains(STATE_DIR_VAR) && why.contains("autosave"),
            "{why}"
        );
        assert!(nowhere.add_recent(Path::new("/x.toml")).is_ok());
        assert!(Storage::none().unavailable().is_none(), "off by choice");
    }

    /// The designer's window says that autosave is off, rather than dropping it
    /// silently.
    #[test]
    fn the_app_says_when_there_is_no_state_directory() {
        use crate::gui::app::{AppOptions, CoatlabApp};
        let options = |storage| AppOptions {
            storage,
            open: None,
            preview: false,
        };
        let app = CoatlabApp::new(options(Storage::choose(None, None)));
        assert!(
            app.notices()
                .iter()
                .any(|n| n.is_error && n.text.contains("autosave")),
            "{:?}",
            app.notices()
        );
        let app = CoatlabApp::new(options(Storage::none()));
        assert!(app.notices().is_empty(), "{:?}", app.notices());
    }

    /// On Linux, [`Storage::from_environment`] in a process of its own (this test
    /// run again, with the variables staged): `$COATLAB_STATE_DIR`, else
    /// `$XDG_STATE_HOME/coatlab` (what tests/gui_crash.rs gives the app), else
    /// `~/.local/state/coatlab` with the home folder from the user database when
    /// `HOME` is unset, where the old lookup turned persistence off.
    #[cfg(target_os = "linux")]
    #[test]
    fn on_linux_the_folder_follows_xdg_and_is_found_without_home() {
        const PROBE: &str = "COATLAB_STORAGE_PROBE";
        const NAME: &str = "on_linux_the_folder_follows_xdg_and_is_found_without_home";
        if std::env::var_os(PROBE).is_some() {
            let storage = Storage::from_environment();
            let dir = storage.dir().map(|d| d.display().to_string());
            println!("state dir: {}", dir.unwrap_or_default());
            return;
        }
        let test = module_path!()
            .split_once("::")
            .map_or(String::new(), |(_, path)| format!("{path}::{NAME}"));
        let probe = |vars: &[(&str, &str)]| -> String {
            let mut command = std::process::Command::new(std::env::current_exe().expect("exe"));
            command
                .args(["--exact", &test, "--nocapture", "--test-threads=1"])
                .env(PROBE, "1")
                .env_remove("HOME")
                .env_remove("XDG_STATE_HOME")
                .env_remove(STATE_DIR_VAR);
            for (name, value) in vars {
                command.env(name, value);
            }
            let output = command.output().expect("the test binary runs");
            let text = String::from_utf8_lossy(&output.stdout).into_owned();
            text.lines()
                .find_map(|l| l.split_once("state dir: ").map(|(_, dir)| dir))
                .unwrap_or_else(|| panic!("no probe output: {text}"))
                .to_owned()
        };
        assert_eq!(probe(&[(STATE_DIR_VAR, "/chosen")]), "/chosen");
        assert_eq!(
            probe(&[("XDG_STATE_HOME", "/xdg/state"), ("HOME", "/home/x")]),
            "/xdg/state/coatlab"
        );
        assert_eq!(
            probe(&[("HOME", "/home/x")]),
            "/home/x/.local/state/coatlab"
        );
        let without_home = probe(&[]);
        assert!(
            without_home.ends_with(".local/state/coatlab") && without_home.len() > 21,
            "{without_home:?}"
        );
    }

    #[test]
    fn no_storage_persists_nothing_and_fails_nowhere() {
        let s = Storage::none();
        assert!(s.add_recent(Path::new("/x.toml")).is_ok());
        assert!(s.recent_files().is_empty());
        assert!(s.autosave(&presets::all()[0].design, None).is_ok());
        assert!(s.recovery().expect("none").is_none());
    }
}
