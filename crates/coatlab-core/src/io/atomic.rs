//! Writing a file so that a reader finds the old contents or the new, never half
//! of either: every file Coatlab writes (designs, images, the error images of the
//! renders, the app's state) goes through [`write_atomically`].
//!
//! The bytes go to a temporary file beside the target (a rename is only atomic
//! within one file system), which is flushed to disk and then renamed over the
//! target. If anything fails, the temporary file is removed and the previous file
//! at the path is left as it was.

use std::ffi::OsString;
use std::fs::{self, File};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use thiserror::Error;

/// A file could not be written; names the file that was meant.
#[derive(Debug, Error)]
#[error("cannot write {}: {error}", path.display())]
pub struct WriteError {
    /// The file that was to be written (not the temporary one).
    pub path: PathBuf,
    /// What went wrong.
    pub error: io::Error,
}

/// Distinguishes the temporary files of concurrent writes from one process.
static WRITE_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `path` atomically: `write` fills a temporary file in the same folder,
/// which is then synced and renamed over `path` (see the module docs). An
/// existing file's permissions are kept. Large outputs can be streamed: `write`
/// gets the file itself (wrap it in a [`io::BufWriter`] for many small writes).
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut File) -> io::Result<()>,
) -> Result<(), WriteError> {
    let fail = |error| WriteError {
        path: path.to_owned(),
        error,
    };
    let file_name = path.file_name().ok_or_else(|| {
        fail(io::Error::new(
            io::ErrorKind::InvalidInput,
            "the path does not name a file",
        ))
    })?;
    let dir = match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    };
    let mut temp_name = OsString::from(".");
    temp_name.push(file_name);
    temp_name.push(format!(
        ".{}-{}.tmp",
        std::process::id(),
        WRITE_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    let temp_path = dir.join(temp_name);

    let result = (|| {
        // create_new: never clobber a file that happens to have the temporary name.
        let mut file = fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temp_path)?;
        write(&mut file)?;
        file.flush()?;
        // Keep the permissions a user gave the existing file.
        if let Ok(metadata) = fs::metadata(path) {
            file.set_permissions(metadata.permissions())?;
        }
        file.sync_all()?;
        drop(file);
        fs::rename(&temp_path, path)
    })();
    if let Err(error) = result {
        let _ = fs::remove_file(&temp_path);
        return Err(fail(error));
    }
    // Make the rename itself durable. Directories cannot be opened (or synced) on
    // every platform; the file's contents are already safe, so this is best effort.
    #[cfg(unix)]
    if let Ok(dir) = File::open(dir) {
        let _ = dir.sync_all();
    }
    Ok(())
}

/// [`write_atomically`] of bytes already in memory.
pub fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    write_atomically(path, |file| file.write_all(bytes))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    /// A temporary folder holding `out.txt`, which reads "old".
    fn old_file() -> (tempfile::TempDir, PathBuf) {
        let scratch = tempfile::tempdir().unwrap();
        let path = scratch.path().join("out.txt");
        fs::write(&path, "old").unwrap();
        (scratch, path)
    }

    #[test]
    fn replaces_the_file_and_leaves_nothing_beside_it() {
        let (scratch, path) = old_file();
        let dir = scratch.path();
        write_bytes_atomically(&path, b"new").unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), "new");
        assert_eq!(names(dir), ["out.txt"]);
    }

    /// A failing writer, a failing rename and a missing folder: each error names
    /// the path, the old file is kept and no temporary file is left.
    #[test]
    fn failures_name_the_path_and_keep_the_old_file() {
        let (scratch, path) = old_file();
        let dir = scratch.path();
        let error = write_atomically(&path, |file| {
            file.write_all(b"half")?;
            Err(io::Error::other("the encoder gave up"))
        })
        .unwrap_err();
        let message = error.to_string();
        assert!(
            message.contains("out.txt") && message.contains("the encoder gave up"),
            "{message}"
        );
        assert_eq!(fs::read_to_string(&path).unwrap(), "old");

        // The rename fails: the target is a non-empty folder.
        let blocker = dir.join("blocker");
        fs::create_dir(&blocker).unwrap();
        fs::write(blocker.join("keep"), "kept").unwrap();
        let error = write_bytes_atomically(&blocker, b"x").unwrap_err();
        assert_eq!(error.path, blocker);
        assert_eq!(fs::read_to_string(blocker.join("keep")).unwrap(), "kept");

        let missing = dir.join("no-such-folder").join("out.txt");
        let error = write_bytes_atomically(&missing, b"x").unwrap_err();
        assert!(error.to_string().contains("no-such-folder"), "{error}");
        assert_eq!(names(dir), ["blocker", "out.txt"]);
    }

    #[test]
    fn a_path_without_a_file_name_is_refused() {
        let error = write_bytes_atomically(Path::new("/"), b"x").unwrap_err();
        assert!(
            error.to_string().contains("does not name a file"),
            "{error}"
        );
    }
}
