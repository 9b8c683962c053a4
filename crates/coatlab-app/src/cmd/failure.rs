//! How a failed command ends: one exit status per class of failure, so a script
//! can tell a typo on its command line from a bad data file from a full disk.
//!
//! | status | class | when |
//! | --- | --- | --- |
//! | 0 | — | success |
//! | 2 | [`Failure::Usage`] | the command line: an unknown flag, a missing or malformed value (clap's own status), or a value out of its range |
//! | 65 | [`Failure::Data`] | bad input data: a stdin row, a CSV, design, scene or environment file that is not valid |
//! | 66 | [`Failure::NoInput`] | an input file that does not exist or cannot be read |
//! | 70 | [`Failure::Internal`] | a bug (please report it with the command) |
//! | 73 | [`Failure::CantCreate`] | an output file that cannot be written |
//! | 74 | [`Failure::Io`] | reading stdin or writing stdout failed |
//! | 141 | [`BROKEN_PIPE`] | stdout was closed by its reader (`coatlab … \| head`): quiet |
//!
//! 65, 66, 70, 73 and 74 are the BSD `sysexits.h` codes of the same meaning.
//!
//! A command marks the errors whose class only it knows (a flag's range, an input
//! file it opens) with [`Failure::error`] or [`Classify::or_fail`]; errors of
//! `coatlab-core` are classed by their type ([`classify`]). The outermost mark
//! wins; an error that nothing classes is a bug, [`Failure::Internal`].

use std::error::Error as StdError;
use std::fmt;
use std::io;

use coatlab_core::colour::cie::CieError;
use coatlab_core::colour::spectrum::SpectrumError;
use coatlab_core::design::DesignError;
use coatlab_core::io::rgb_image::ImageReadError;
use coatlab_core::paint::gloss::GlossError;
use coatlab_core::render::environment::EnvironmentError;
use coatlab_core::render::film::FilmError;
use coatlab_core::render::film::part::PartError;
use coatlab_core::scene::gltf_loader::SceneError;

/// The exit status when stdout's reader went away before the output was all
/// written: 128 + SIGPIPE, what a shell reports for `cat`, `yes` or any C tool the
/// signal stops. The output was cut short, so it is not a success; but the reader
/// chose it, so nothing is printed. Without `set -o pipefail` a pipeline's status is
/// its last command's, so `coatlab measure x.toml | head` succeeds as usual.
pub const BROKEN_PIPE: u8 = 141;

/// Why a command failed; see the module docs for the exit statuses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failure {
    Usage,
    Data,
    NoInput,
    Internal,
    CantCreate,
    Io,
}

impl Failure {
    /// The process exit status.
    pub const fn code(self) -> u8 {
        match self {
            Failure::Usage => 2,
            Failure::Data => 65,
            Failure::NoInput => 66,
            Failure::Internal => 70,
            Failure::CantCreate => 73,
            Failure::Io => 74,
        }
    }

    /// An error of this class with `message`.
    pub fn error(
        self,
        message: impl fmt::Display + fmt::Debug + Send + Sync + 'static,
    ) -> anyhow::Error {
        anyhow::Error::new(Classified {
            failure: self,
            error: anyhow::Error::msg(message),
        })
    }
}

/// Marks an error with its class, keeping its message and causes as they were.
pub trait Classify<T> {
    fn or_fail(self, failure: Failure) -> anyhow::Result<T>;
}

impl<T, E: Into<anyhow::Error>> Classify<T> for Result<T, E> {
    fn or_fail(self, failure: Failure) -> anyhow::Result<T> {
        self.map_err(|error| {
            anyhow::Error::new(Classified {
                failure,
                error: error.into(),
            })
        })
    }
}

/// An error and its class. Displays as the error and has the error's causes, so
/// `{:#}` prints exactly what the unmarked error would.
struct Classified {
    failure: Failure,
    error: anyhow::Error,
}

impl fmt::Debug for Classified {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?} ({:?})", self.error, self.failure)
    }
}

impl fmt::Display for Classified {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.error, f)
    }
}

impl StdError for Classified {
    fn source(&self) -> Option<&(dyn StdError + 'static)> {
        self.error.chain().nth(1)
    }
}

/// How a failed command ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Stdout's reader closed the pipe: exit [`BROKEN_PIPE`], print nothing.
    BrokenPipe,
    Failed(Failure),
}

/// The outcome of `error`: a closed stdout anywhere in its chain first, then the
/// outermost mark or typed error that says its class.
pub fn classify(error: &anyhow::Error) -> Outcome {
    if is_broken_pipe(error) {
        return Outcome::BrokenPipe;
    }
    Outcome::Failed(
        error
            .chain()
            .find_map(class_of)
            .unwrap_or(Failure::Internal),
    )
}

fn is_broken_pipe(error: &anyhow::Error) -> bool {
    error.chain().any(|cause| {
        io_kind(cause) == Some(io::ErrorKind::BrokenPipe)
            || cause
                .downcast_ref::<Classified>()
                .is_some_and(|c| is_broken_pipe(&c.error))
    })
}

/// The kind of the I/O error `cause` is or wraps directly (csv and serde_json keep
/// theirs inside, not as a `source`).
fn io_kind(cause: &(dyn StdError + 'static)) -> Option<io::ErrorKind> {
    if let Some(e) = cause.downcast_ref::<io::Error>() {
        return Some(e.kind());
    }
    if let Some(e) = cause.downcast_ref::<csv::Error>()
        && let csv::ErrorKind::Io(e) = e.kind()
    {
        return Some(e.kind());
    }
    cause
        .downcast_ref::<serde_json::Error>()
        .and_then(serde_json::Error::io_error_kind)
}

/// The class one link of an error chain says, if it says one.
fn class_of(cause: &(dyn StdError + 'static)) -> Option<Failure> {
    if let Some(c) = cause.downcast_ref::<Classified>() {
        return Some(c.failure);
    }
    if io_kind(cause).is_some() {
        return Some(Failure::Io);
    }
    if cause.downcast_ref::<csv::Error>().is_some()
        || cause.downcast_ref::<SpectrumError>().is_some()
        || cause.downcast_ref::<CieError>().is_some()
    {
        return Some(Failure::Data);
    }
    if let Some(e) = cause.downcast_ref::<DesignError>() {
        return Some(match e.without_file() {
            // Bytes that are not UTF-8 text were read: the file is there but bad.
            DesignError::Read { error, .. } if error.kind() == io::ErrorKind::InvalidData => {
                Failure::Data
            }
            DesignError::Read { .. } => Failure::NoInput,
            DesignError::Write { .. } => Failure::CantCreate,
            _ => Failure::Data,
        });
    }
    if let Some(e) = cause.downcast_ref::<SceneError>() {
        return Some(match e {
            SceneError::Io { .. } | SceneError::MissingBuffer { .. } => Failure::NoInput,
            // `--paint-material` names a material the file does not have.
            SceneError::UnknownMaterial { .. } => Failure::Usage,
            _ => Failure::Data,
        });
    }
    if let Some(e) = cause.downcast_ref::<EnvironmentError>() {
        return Some(match e {
            EnvironmentError::Read(ImageReadError::Io { .. }) => Failure::NoInput,
            _ => Failure::Data,
        });
    }
    if let Some(e) = cause.downcast_ref::<FilmError>() {
        return Some(if e.is_write_failure() {
            Failure::CantCreate
        } else {
            Failure::Internal
        });
    }
    if let Some(e) = cause.downcast_ref::<PartError>() {
        return Some(match e {
            PartError::Read { .. } => Failure::NoInput,
            PartError::Write(_) => Failure::CantCreate,
            PartError::NoParts => Failure::Usage,
            PartError::Mismatch { .. } => Failure::Internal,
            _ => Failure::Data,
        });
    }
    // Gloss numbers come from the command line (a design's gloss is a DesignError).
    if cause.downcast_ref::<GlossError>().is_some() {
        return Some(Failure::Usage);
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mark_keeps_the_message_and_the_outermost_mark_wins() {
        let inner: anyhow::Result<()> = Err(io::Error::other("disk on fire")).or_fail(Failure::Io);
        let error = inner
            .map_err(|e| e.context("writing out.csv"))
            .or_fail(Failure::CantCreate)
            .unwrap_err();
        assert_eq!(format!("{error:#}"), "writing out.csv: disk on fire");
        assert_eq!(classify(&error), Outcome::Failed(Failure::CantCreate));
        let usage = Failure::Usage.error("--spp 0: no");
        assert_eq!(format!("{usage:#}"), "--spp 0: no");
        assert_eq!(classify(&usage), Outcome::Failed(Failure::Usage));
    }

    #[test]
    fn a_broken_pipe_is_found_under_marks_and_inside_csv_errors() {
        let pipe = || io::Error::from(io::ErrorKind::BrokenPipe);
        let marked: anyhow::Result<()> = Err(pipe()).or_fail(Failure::Io);
        assert_eq!(classify(&marked.unwrap_err()), Outcome::BrokenPipe);
        let csv_error = anyhow::Error::from(csv::Error::from(pipe())).context("stdout");
        assert_eq!(classify(&csv_error), Outcome::BrokenPipe);
        let other = anyhow::Error::from(csv::Error::from(io::Error::other("x")));
        assert_eq!(classify(&other), Outcome::Failed(Failure::Io));
    }

    #[test]
    fn unclassed_errors_are_internal() {
        assert_eq!(
            classify(&anyhow::anyhow!("something")),
            Outcome::Failed(Failure::Internal)
        );
    }
}
