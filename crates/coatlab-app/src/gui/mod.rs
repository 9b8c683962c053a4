//! The designer's GUI (eframe with the wgpu back-end).
//!
//! | module | what |
//! | --- | --- |
//! | [`app`] | the window: menus, panels, shortcuts, files, undo/redo, drag and drop |
//! | [`paint_panel`] | the paint controls |
//! | [`curve_editor`] | ρ(λ) and k(λ) as curves with draggable control points |
//! | [`plots`] | figures 3–6, spectra, instrument reflectance (egui_plot) |
//! | [`instruments_panel`] | multi-angle table, gloss, the target and its tolerances, *Fit to target*, swatches (from [`coatlab_core::analysis`], computed on change) |
//! | [`target`] | the target: a design or a standard of a measurement file (CGATS, CxF3), compared by [`coatlab_core::target`] |
//! | [`tolerance_view`] | the tolerance table and the fit report, as `coatlab measure` and `coatlab fit` print them |
//! | [`fit_job`] | *Fit to target* ([`coatlab_core::fit`]) on a thread of its own |
//! | [`history`] | undo/redo by snapshots of the design and the paint-material choice |
//! | [`storage`] | recent files, autosave and crash recovery |
//! | [`dialogs`] | choosing files: the system file dialog (rfd, XDG portal or zenity) on its own thread, else the in-app browser |
//! | [`file_browser`] | the in-app open/save browser |
//! | `frame_log` | per-frame timestamps of the real window (`COATLAB_FRAME_LOG`; feature `frame-log`) |
//! | [`export`] | readings as CSV and JSON |
//! | [`preview`] | the live preview: a widget over the core's live engine ([`coatlab_core::engine`]); scenes, lighting maps, export |
//! | [`priority`] | the render threads at a lower OS priority than the window |
//! | [`quality`] | quality presets from the measured speed/accuracy front (docs/tradeoff.md) |
//! | [`compare`] | comparison modes and layouts, the ΔE00 map and its legend |

pub mod app;
pub mod compare;
pub mod curve_editor;
pub mod dialogs;
pub mod export;
pub mod file_browser;
pub mod fit_job;
#[cfg(feature = "frame-log")]
pub mod frame_log;
pub mod history;
pub mod instruments_panel;
pub mod paint_materials;
pub mod paint_panel;
pub mod plots;
pub mod preview;
pub mod priority;
pub mod quality;
pub mod storage;
pub mod target;
pub mod tolerance_view;

pub use app::{AppOptions, CoatlabApp};

/// Opens the window and runs the designer until it is closed.
pub fn run(options: AppOptions) -> anyhow::Result<()> {
    let native = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title("Coatlab")
            .with_inner_size([1500.0, 940.0])
            .with_min_inner_size([900.0, 600.0])
            .with_drag_and_drop(true),
        renderer: eframe::Renderer::Wgpu,
        ..Default::default()
    };
    #[cfg(feature = "frame-log")]
    let frame_log = frame_log::FrameLog::from_environment()?;
    // Before anything uses rayon: the render threads yield the CPU to the window.
    if let Err(e) = priority::install_render_pool(priority::RENDER_NICE) {
        eprintln!("coatlab: {e}");
    }
    eframe::run_native(
        "Coatlab",
        native,
        Box::new(move |_cc| {
            let app = CoatlabApp::new(options);
            #[cfg(feature = "frame-log")]
            if let Some(log) = frame_log {
                return Ok(Box::new(frame_log::FrameLogged::new(app, log)) as Box<dyn eframe::App>);
            }
            Ok(Box::new(app) as Box<dyn eframe::App>)
        }),
    )
    .map_err(|e| anyhow::anyhow!("cannot open the Coatlab window: {e}"))
}
