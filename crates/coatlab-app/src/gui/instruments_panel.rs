//! The instruments panel: the multi-angle table, the gloss readings, the target
//! (a design or a measured standard) with the tolerance table `coatlab measure
//! --target` prints, *Fit to target* and its report, and swatches under D65, A
//! and F11.

use coatlab_core::colour::tolerance::{Formula, Tolerance};
use coatlab_core::instruments::ILLUMINATION_DEG;
use egui::{Color32, RichText, Ui};

use coatlab_core::analysis::{Analysis, SWATCH_ASPECULAR_DEG, Swatch};

use super::fit_job::FitDone;
use super::target::{Target, TargetView, geometry_choices};
use super::tolerance_view::{comparison_ui, fit_report_ui};
use coatlab_core::fit::FreeParameters;

/// What the panel asks the app to do.
#[derive(Debug, Clone, PartialEq)]
pub enum InstrumentsRequest {
    /// Use the preset with this index as the target.
    TargetPreset(usize),
    /// Choose a target file: a design or a measurement.
    TargetFile,
    /// No target.
    ClearTarget,
    /// Use this standard of the target's measurement file.
    SelectSample(usize),
    /// The geometry a CSV target was measured at (a CSV does not say).
    SetGeometry(coatlab_core::measurement::Geometry),
    /// Judge by this tolerance (the design's `[tolerance]`; an edit of the design).
    SetTolerance(Tolerance),
    /// Fit the design's free parameters to the target standard.
    FitToTarget,
    /// What the fit may change.
    SetFitFree(FreeParameters),
    /// Export the readings (the file browser asks where).
    Export,
}

/// What the panel shows besides the analysis.
pub struct InstrumentsView<'a> {
    pub analysis: Option<&'a Analysis>,
    pub target: Option<&'a Target>,
    /// The design against the target, once computed.
    pub target_view: Option<&'a TargetView>,
    pub presets: &'a [coatlab_core::design::presets::Preset],
    /// The tolerance the design is judged by.
    pub tolerance: &'a Tolerance,
    /// A fit is running.
    pub fitting: bool,
    /// The last fit's report.
    pub fit: Option<&'a FitDone>,
    /// What the fit may change.
    pub fit_free: FreeParameters,
}

/// Shows the panel.
pub fn instruments_ui(ui: &mut Ui, view: &InstrumentsView<'_>) -> Vec<InstrumentsRequest> {
    let mut requests = Vec::new();
    target_row_ui(ui, view, &mut requests);
    let analysis = view.analysis;
    let Some(analysis) = analysis else {
        ui.label("No valid design to measure (see the paint controls).");
        return requests;
    };
    ui.label(
        RichText::new(format!(
            "Multi-angle colour: illumination {ILLUMINATION_DEG}°, CIELAB D65/10°"
        ))
        .strong(),
    );
    table_ui(
        ui,
        "multi_angle",
        &["aspecular", "detector", "L*", "a*", "b*", "ΔE00"],
        |ui| {
            for (i, a) in analysis.measurement.angles.iter().enumerate() {
                ui.label(format!("{}°", a.aspecular_deg));
                ui.label(format!("{}°", a.detector_deg));
                ui.label(format!("{:.2}", a.lab.l));
                ui.label(format!("{:.2}", a.lab.a));
                ui.label(format!("{:.2}", a.lab.b));
                match analysis.delta_e.as_ref().and_then(|d| d.get(i)) {
                    Some(de) => ui.label(delta_e_text(*de)),
                    None => ui.label("–"),
                };
                ui.end_row();
            }
        },
    );
    ui.add_space(6.0);
    ui.label(RichText::new("Gloss (ISO 2813; specular + body, ȳ under D65)").strong());
    table_ui(
        ui,
        "gloss",
        &["geometry", "total GU", "specular GU"],
        |ui| {
            for g in &analysis.measurement.gloss {
                ui.label(g.geometry.to_string());
                ui.label(format!("{:.1}", g.total_gu));
                ui.label(format!("{:.1}", g.specular_gu));
                ui.end_row();
            }
        },
    );
    ui.add_space(6.0);
    ui.label(
        RichText::new(format!(
            "Swatches at aspecular {SWATCH_ASPECULAR_DEG}°, adapted to the display's D65 white"
        ))
        .strong(),
    );
    let swatches: &[Swatch] = view
        .target_view
        .map_or(analysis.swatches.as_slice(), |t| t.swatches.as_slice());
    ui.horizontal(|ui| {
        for s in swatches {
            ui.vertical(|ui| {
                ui.label(s.illuminant.to_string());
                swatch_ui(ui, s.design_srgb, s.target_srgb);
                if let Some(de) = s.delta_e {
                    ui.label(delta_e_text(de));
                }
            });
        }
    });
    if swatches.iter().any(|s| s.target_srgb.is_some()) {
        ui.label(
            RichText::new("Left half: design; right half: target. ΔE00 under each light (10°).")
                .weak(),
        );
    }
    if let Some(t) = view.target_view {
        ui.add_space(6.0);
        match &t.comparison {
            Ok(c) => comparison_ui(ui, c),
            Err(e) => {
                ui.label(RichText::new(e).color(ui.visuals().error_fg_color));
            }
        }
    }
    if let Some(fit) = view.fit {
        ui.add_space(6.0);
        fit_report_ui(ui, fit);
    }
    requests
}

/// The parameters *Fit to target* may change, one box each, named as `coatlab fit
/// --free` names them.
fn free_parameters_ui(ui: &mut Ui, free: FreeParameters, requests: &mut Vec<InstrumentsRequest>) {
    ui.horizontal(|ui| {
        ui.label("Free in the fit:");
        for (name, description) in FreeParameters::NAMES
            .into_iter()
            .zip(FreeParameters::DESCRIPTIONS)
        {
            let mut changed = free;
            let Some(flag) = changed.flag_mut(name) else {
                continue;
            };
            let text = if name == "rho" { "ρ(λ)" } else { name };
            if ui
                .checkbox(flag, text)
                .on_hover_text(format!("Fit {description}"))
                .changed()
            {
                requests.push(InstrumentsRequest::SetFitFree(changed));
            }
        }
    });
}

/// The target box, the standard of a measurement file, the tolerance and the
/// actions on the target.
fn target_row_ui(ui: &mut Ui, view: &InstrumentsView<'_>, requests: &mut Vec<InstrumentsRequest>) {
    let target_name = view.target.map(Target::label);
    ui.horizontal(|ui| {
        egui::ComboBox::from_label("Target")
            .selected_text(target_name.as_deref().unwrap_or("none"))
            .show_ui(ui, |ui| {
                if ui.selectable_label(target_name.is_none(), "none").clicked() {
                    requests.push(InstrumentsRequest::ClearTarget);
                }
                for (i, p) in view.presets.iter().enumerate() {
                    if ui.selectable_label(false, &p.design.name).clicked() {
                        requests.push(InstrumentsRequest::TargetPreset(i));
                    }
                }
            });
        if ui
            .button("Target from file…")
            .on_hover_text(
                "A design (.toml) or a measurement: CGATS.17 text, CxF3 XML or a CSV of \
                 spectra. A CGATS or CxF3 file can also be dropped on the window.",
            )
            .clicked()
        {
            requests.push(InstrumentsRequest::TargetFile);
        }
        if ui
            .button("Export readings…")
            .on_hover_text("CSV or JSON, by the file name's extension")
            .clicked()
        {
            requests.push(InstrumentsRequest::Export);
        }
    });
    let Some(target) = view.target else {
        return;
    };
    ui.horizontal(|ui| {
        if let Target::Measured(m) = target {
            let names = m.standard_names();
            if names.len() > 1 {
                let selected = names.get(m.selected).map_or("", String::as_str);
                egui::ComboBox::from_label("Sample")
                    .selected_text(selected)
                    .show_ui(ui, |ui| {
                        for (i, name) in names.iter().enumerate() {
                            if ui.selectable_label(i == m.selected, name).clicked() {
                                requests.push(InstrumentsRequest::SelectSample(i));
                            }
                        }
                    });
            }
            if m.geometry_is_chosen() {
                let current = m.chosen_geometry();
                egui::ComboBox::from_label("Measured at")
                    .selected_text(current.to_string())
                    .show_ui(ui, |ui| {
                        for g in geometry_choices() {
                            if ui.selectable_label(g == current, g.to_string()).clicked() {
                                requests.push(InstrumentsRequest::SetGeometry(g));
                            }
                        }
                    })
                    .response
                    .on_hover_text(
                        "A CSV of spectra does not say where it was measured: state the \
                         geometry to compare the design at",
                    );
            }
        }
        tolerance_ui(ui, view.tolerance, requests);
        let fittable = matches!(target, Target::Measured(_)) && view.analysis.is_some();
        free_parameters_ui(ui, view.fit_free, requests);
        let button = ui
            .add_enabled(
                fittable && !view.fitting && view.fit_free.any(),
                egui::Button::new("Fit to target"),
            )
            .on_hover_text(
                "Fit what is ticked to the target standard, keeping the rest of the \
                 design (as coatlab fit --free); one undoable edit",
            )
            .on_disabled_hover_text(if view.fitting {
                "A fit is running"
            } else if !view.fit_free.any() {
                "Tick at least one parameter to fit"
            } else {
                "Fitting needs a measured target (a CGATS or CxF3 file) and a valid design"
            });
        if button.clicked() {
            requests.push(InstrumentsRequest::FitToTarget);
        }
        if view.fitting {
            ui.spinner();
            ui.label("Fitting…");
        }
    });
}

/// The formula and the limit at every angle (per-angle limits are kept as set in
/// the design file or by `coatlab measure --tolerance`).
fn tolerance_ui(ui: &mut Ui, tolerance: &Tolerance, requests: &mut Vec<InstrumentsRequest>) {
    let mut t = tolerance.clone();
    egui::ComboBox::from_label("Tolerance")
        .selected_text(t.formula.to_string())
        .show_ui(ui, |ui| {
            for f in [Formula::De00, Formula::DeAb, Formula::Cmc] {
                ui.selectable_value(&mut t.formula, f, f.to_string());
            }
        });
    ui.add(
        egui::DragValue::new(&mut t.default_limit)
            .range(0.01..=50.0)
            .speed(0.01)
            .prefix("≤ "),
    )
    .on_hover_text("The limit at every angle without one of its own; stored in the design file");
    let per_angle = t
        .per_angle
        .iter()
        .map(|(angle, limit)| format!("{limit} at as{angle}°"));
    let per_angle = per_angle.collect::<Vec<_>>().join(", ");
    if !per_angle.is_empty() {
        ui.label(RichText::new(per_angle).weak());
    }
    if t != *tolerance {
        requests.push(InstrumentsRequest::SetTolerance(t));
    }
}

/// A bold line above a table.
pub(super) fn heading_ui(ui: &mut Ui, text: String) {
    ui.label(RichText::new(text).strong());
}

/// A striped table with a bold header row; `rows` adds the rows.
pub(super) fn table_ui(ui: &mut Ui, id: &str, heads: &[&str], rows: impl FnOnce(&mut Ui)) {
    egui::Grid::new(id)
        .striped(true)
        .num_columns(heads.len())
        .show(ui, |ui| {
            for h in heads {
                ui.label(RichText::new(*h).strong());
            }
            ui.end_row();
            rows(ui);
        });
}

fn delta_e_text(de: f64) -> RichText {
    // ΔE00 ≈ 1 is a just-noticeable difference side by side.
    let text = RichText::new(format!("{de:.2}"));
    if de > 1.0 {
        text.color(Color32::from_rgb(230, 120, 40))
    } else {
        text
    }
}

fn swatch_ui(ui: &mut Ui, design: [u8; 3], target: Option<[u8; 3]>) {
    let (rect, _) = ui.allocate_exact_size(egui::vec2(96.0, 56.0), egui::Sense::hover());
    let c = |b: [u8; 3]| Color32::from_rgb(b[0], b[1], b[2]);
    match target {
        Some(t) => {
            let (left, right) = rect.split_left_right_at_fraction(0.5);
            ui.painter().rect_filled(left, 0.0, c(design));
            ui.painter().rect_filled(right, 0.0, c(t));
        }
        None => {
            ui.painter().rect_filled(rect, 0.0, c(design));
        }
    }
}
