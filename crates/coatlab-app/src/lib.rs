//! The designer's GUI as a library, so that the `coatlab` binary starts it and the
//! workspace's GUI tests (`tests/gui*.rs`) drive the very same code headless.
//!
//! Only this crate knows egui; everything it shows is computed by `coatlab-core`.

pub mod gui;

/// An error and its causes as one line for the user: `context: cause: cause`.
///
/// anyhow's `{:#}` appends every cause, but several of the core's errors already
/// name their cause in their own message (`cannot read F: No such file or
/// directory`) while also returning it as their source, which printed the cause
/// twice. A cause whose text the line already ends with is left out.
pub fn error_text(error: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in error.chain() {
        let cause = cause.to_string();
        if text.is_empty() {
            text = cause;
        } else if !text.ends_with(&cause) {
            text.push_str(": ");
            text.push_str(&cause);
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::error_text;

    /// Like the core's `SceneError::Io`: the message names the cause, which is also
    /// the source.
    #[derive(Debug)]
    struct NamesItsCause {
        file: String,
        source: std::io::Error,
    }

    impl std::fmt::Display for NamesItsCause {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "cannot read {}: {}", self.file, self.source)
        }
    }

    impl std::error::Error for NamesItsCause {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            Some(&self.source)
        }
    }

    fn not_found() -> std::io::Error {
        std::io::Error::new(std::io::ErrorKind::NotFound, "No such file or directory")
    }

    #[test]
    fn a_cause_already_in_the_message_is_printed_once() {
        let error = anyhow::Error::new(NamesItsCause {
            file: "car.glb".into(),
            source: not_found(),
        });
        assert_eq!(
            error_text(&error),
            "cannot read car.glb: No such file or directory"
        );
        // What `{:#}` alone printed.
        assert_eq!(
            format!("{error:#}"),
            "cannot read car.glb: No such file or directory: No such file or directory"
        );
    }

    #[test]
    fn every_cause_not_yet_named_is_printed() {
        let error = anyhow::Error::new(not_found())
            .context("loading the scene")
            .context("coatlab render");
        assert_eq!(
            error_text(&error),
            "coatlab render: loading the scene: No such file or directory"
        );
    }
}
