//! What the app keeps between sessions: the recent-files list and the autosave of an
//! unsaved design, in one state directory.
//!
//! The directory is `$COATLAB_STATE_DIR` if set (tests and portable installs), else
//! `$XDG_STATE_HOME/coatlab`, else `~/.local/state/coatlab`. Without any of these the
//! app runs with no recent files and no autosave rather than failing.
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

/// How many recent files are remembered.
pub const MAX_RECENT: usize = 10;
const RECENT_FILE: &str = "recent.txt";
const AUTOSAVE_FILE: &str = "autosave.toml";
const AUTOSAVE_PATH_FILE: &str = "autosave-path.txt";

/// The state directory, or none (persistence off).
#[derive(Debug, Clone, Default)]
pub struct Storage {
    dir: Option<PathBuf>,
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
        }
    }

    /// No persistence at all (headless tests).
    pub fn none() -> Self {
        Self { dir: None }
    }

    /// The platform's state directory (see the module documentation).
    pub fn from_environment() -> Self {
        let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
        let dir = var("COATLAB_STATE_DIR")
            .map(PathBuf::from)
            .or_else(|| var("XDG_STATE_HOME").map(|d| PathBuf::from(d).join("coatlab")))
            .or_else(|| var("HOME").map(|d| PathBuf::from(d).join(".local/state/coatlab")));
        Self { dir }
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
            fs::write(&file, text).with_context(|| format!("cannot write {}", file.display()))?;
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
        fs::write(&path_file, text)
            .with_context(|| format!("cannot write {}", path_file.display()))?;
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

    fn temp_dir(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("coatlab-storage-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn recent_files_are_newest_first_without_duplicates() {
        let dir = temp_dir("recent");
        let s = Storage::in_dir(&dir);
        assert!(s.recent_files().is_empty());
        s.add_recent(Path::new("/a.toml")).expect("writable");
        s.add_recent(Path::new("/b.toml")).expect("writable");
        let list = s.add_recent(Path::new("/a.toml")).expect("writable");
        assert_eq!(
            list,
            vec![PathBuf::from("/a.toml"), PathBuf::from("/b.toml")]
        );
        assert_eq!(s.recent_files(), list);
        let _ = fs::remove_dir_all(dir);
    }

    #[test]
    fn an_autosave_is_offered_until_cleared() {
        let dir = temp_dir("autosave");
        let s = Storage::in_dir(&dir);
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
        let _ = fs::remove_dir_all(dir);
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
