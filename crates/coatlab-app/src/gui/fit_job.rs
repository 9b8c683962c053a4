//! *Fit to target* off the UI thread: the core's fit ([`coatlab_core::fit`]) of
//! the design's free parameters (ρ(λ) by default; the coat's gloss, h, k, n as the
//! person frees them) to the target standard, and its report. A fit of several
//! geometries or of the coat is a bounded least-squares problem that may take
//! longer than a frame, so it runs on a thread of its own and the window keeps drawing;
//! the app applies the result as one undoable edit, and only to the design it
//! was started from.

use std::sync::mpsc::{Receiver, TryRecvError, channel};

use coatlab_core::colour::tolerance::Tolerance;
use coatlab_core::design::PaintDesign;
use coatlab_core::fit::{self, Fit, FitReport, FitRequest};

use super::target::MeasuredTarget;

/// A finished fit.
#[derive(Debug, Clone)]
pub struct FitDone {
    /// The design the fit started from (what was not free is kept).
    pub start: PaintDesign,
    /// The standard fitted to, and its file.
    pub sample: String,
    pub file: String,
    pub fit: Fit,
    /// The fitted design against the standard.
    pub report: FitReport,
}

/// A fit running on its thread.
pub struct FitJob {
    start: PaintDesign,
    answer: Receiver<Result<FitDone, String>>,
}

impl FitJob {
    /// Starts fitting `design` to `target`'s chosen standard; `ctx` is asked for a
    /// repaint when the answer is there.
    pub fn start(
        ctx: Option<&egui::Context>,
        design: PaintDesign,
        target: MeasuredTarget,
        tolerance: Tolerance,
        request: FitRequest,
    ) -> Result<Self, String> {
        let (send, answer) = channel();
        let ctx = ctx.cloned();
        let start = design.clone();
        std::thread::Builder::new()
            .name("coatlab-fit".into())
            .spawn(move || {
                // The receiver is gone only if the app closed meanwhile.
                let _ = send.send(run(design, &target, &tolerance, &request));
                if let Some(ctx) = ctx {
                    ctx.request_repaint();
                }
            })
            .map_err(|e| format!("cannot start the fit: {e}"))?;
        Ok(Self { start, answer })
    }

    /// The design the fit started from.
    pub fn start_design(&self) -> &PaintDesign {
        &self.start
    }

    /// The answer once it has come.
    pub fn poll(&self) -> Option<Result<FitDone, String>> {
        match self.answer.try_recv() {
            Ok(answer) => Some(answer),
            Err(TryRecvError::Empty) => None,
            Err(TryRecvError::Disconnected) => {
                Some(Err("the fit's thread ended without an answer".to_owned()))
            }
        }
    }
}

fn run(
    design: PaintDesign,
    target: &MeasuredTarget,
    tolerance: &Tolerance,
    request: &FitRequest,
) -> Result<FitDone, String> {
    let file = target.path.display().to_string();
    let standard = target
        .standard()
        .ok_or_else(|| format!("{file}: no sample to fit"))?;
    let cannot = |e: fit::FitError| format!("{file}: cannot fit sample {:?}: {e}", standard.name);
    let fitted = fit::fit(&design, &standard, request).map_err(cannot)?;
    let report = fit::report(&fitted, &standard, tolerance).map_err(cannot)?;
    Ok(FitDone {
        start: design,
        sample: standard.name.to_owned(),
        file,
        fit: fitted,
        report,
    })
}
