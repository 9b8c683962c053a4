//! Frame timing of the real window: with `COATLAB_FRAME_LOG=path` the app appends
//! one line per frame to `path` — the time the frame's UI pass started, in seconds
//! since the window opened, and how long the UI pass itself took, in ms:
//!
//! ```text
//! # coatlab frame log: start_s ui_ms
//! 2.481203 1.204
//! ```
//!
//! The interval between two starts is the whole frame: our UI pass, then eframe's
//! tessellation, the GPU's (on lavapipe: the CPU's) drawing and the present. The
//! difference between the two columns tells our work from the drawing.
//!
//! With the log on, the window also redraws continuously (as it does while a
//! person drags a control), so the log shows the frame rate the window can hold,
//! not only how often a new preview image arrives. The responsiveness bench
//! (`benches/gui_responsiveness.rs`) starts the binary under Xvfb with it.
//!
//! Built only with the `frame-log` feature (the bench requires it); the shipped
//! binary ignores the variable.

use std::fs::File;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context as _;

use super::CoatlabApp;

/// The environment variable that names the log file.
pub const FRAME_LOG_VAR: &str = "COATLAB_FRAME_LOG";

/// An open frame log.
pub struct FrameLog {
    file: File,
    path: PathBuf,
    opened: Instant,
    /// Set after the first failed write, so a full disk is reported once.
    failed: bool,
}

impl FrameLog {
    /// The log named by `COATLAB_FRAME_LOG`, if set (appended to; created if absent).
    pub fn from_environment() -> anyhow::Result<Option<Self>> {
        let Some(path) = std::env::var_os(FRAME_LOG_VAR).map(PathBuf::from) else {
            return Ok(None);
        };
        let mut file = File::options()
            .create(true)
            .append(true)
            .open(&path)
            .with_context(|| format!("{FRAME_LOG_VAR}: cannot open {}", path.display()))?;
        writeln!(file, "# coatlab frame log: start_s ui_ms")
            .with_context(|| format!("{FRAME_LOG_VAR}: cannot write {}", path.display()))?;
        Ok(Some(Self {
            file,
            path,
            opened: Instant::now(),
            failed: false,
        }))
    }

    fn record(&mut self, start: Instant, ui_seconds: f64) {
        if self.failed {
            return;
        }
        let since = start.duration_since(self.opened).as_secs_f64();
        // One write per frame (no buffer to lose when the process is killed).
        let line = format!("{since:.6} {:.3}\n", ui_seconds * 1e3);
        if let Err(e) = self.file.write_all(line.as_bytes()) {
            eprintln!(
                "coatlab: {FRAME_LOG_VAR}: writing {} failed ({e}); no further frames logged",
                self.path.display()
            );
            self.failed = true;
        }
    }
}

/// The app with its frames logged.
pub struct FrameLogged {
    app: CoatlabApp,
    log: FrameLog,
}

impl FrameLogged {
    pub fn new(app: CoatlabApp, log: FrameLog) -> Self {
        Self { app, log }
    }
}

impl eframe::App for FrameLogged {
    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        let start = Instant::now();
        eframe::App::ui(&mut self.app, ui, frame);
        ui.ctx().request_repaint();
        self.log.record(start, start.elapsed().as_secs_f64());
    }

    fn on_exit(&mut self) {
        eframe::App::on_exit(&mut self.app);
    }
}
