//! The app in egui_kittest's harness, as the GUI tests (tests/gui.rs,
//! tests/gui_crash.rs) and the responsiveness bench lay it out.
#![allow(dead_code)] // each crate uses its own subset

use coatlab_app::gui::storage::Storage;
use coatlab_app::gui::{AppOptions, CoatlabApp};
use egui_kittest::Harness;

/// Nothing stored, no file opened; the live preview on or off.
pub fn options(preview: bool) -> AppOptions {
    AppOptions {
        storage: Storage::none(),
        open: None,
        preview,
    }
}

/// `app` laid out at `size` points, drawn by wgpu (lavapipe in CI) where `wgpu`.
/// No frame is run: with the live preview on, `run` would never settle.
pub fn app_harness(size: egui::Vec2, wgpu: bool, app: CoatlabApp) -> Harness<'static, CoatlabApp> {
    let builder = Harness::builder().with_size(size);
    let builder = if wgpu { builder.wgpu() } else { builder };
    builder.build_ui_state(|ui, app: &mut CoatlabApp| app.show(ui), app)
}
