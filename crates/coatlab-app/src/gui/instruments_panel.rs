//! The instruments panel: the multi-angle table, the gloss readings, ΔE00 to a
//! target design per angle, and swatches under D65, A and F11.

use coatlab_core::instruments::ILLUMINATION_DEG;
use egui::{Color32, RichText, Ui};

use coatlab_core::analysis::{Analysis, SWATCH_ASPECULAR_DEG};

/// What the panel asks the app to do.
#[derive(Debug, Clone, PartialEq)]
pub enum InstrumentsRequest {
    /// Use the preset with this index as the target.
    TargetPreset(usize),
    /// Choose a target design file.
    TargetFile,
    /// No target.
    ClearTarget,
    /// Export the readings (the file browser asks where).
    Export,
}

/// Shows the panel.
pub fn instruments_ui(
    ui: &mut Ui,
    analysis: Option<&Analysis>,
    target_name: Option<&str>,
    presets: &[coatlab_core::design::presets::Preset],
) -> Vec<InstrumentsRequest> {
    let mut requests = Vec::new();
    ui.horizontal(|ui| {
        egui::ComboBox::from_label("Target")
            .selected_text(target_name.unwrap_or("none"))
            .show_ui(ui, |ui| {
                if ui.selectable_label(target_name.is_none(), "none").clicked() {
                    requests.push(InstrumentsRequest::ClearTarget);
                }
                for (i, p) in presets.iter().enumerate() {
                    if ui.selectable_label(false, &p.design.name).clicked() {
                        requests.push(InstrumentsRequest::TargetPreset(i));
                    }
                }
            });
        if ui.button("Target from file…").clicked() {
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
    egui::Grid::new("multi_angle")
        .striped(true)
        .num_columns(6)
        .show(ui, |ui| {
            for h in ["aspecular", "detector", "L*", "a*", "b*", "ΔE00"] {
                ui.label(RichText::new(h).strong());
            }
            ui.end_row();
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
        });
    ui.add_space(6.0);
    ui.label(RichText::new("Gloss (ISO 2813; specular + body, ȳ under D65)").strong());
    egui::Grid::new("gloss")
        .striped(true)
        .num_columns(3)
        .show(ui, |ui| {
            for h in ["geometry", "total GU", "specular GU"] {
                ui.label(RichText::new(h).strong());
            }
            ui.end_row();
            for g in &analysis.measurement.gloss {
                ui.label(g.geometry.to_string());
                ui.label(format!("{:.1}", g.total_gu));
                ui.label(format!("{:.1}", g.specular_gu));
                ui.end_row();
            }
        });
    ui.add_space(6.0);
    ui.label(
        RichText::new(format!(
            "Swatches at aspecular {SWATCH_ASPECULAR_DEG}°, adapted to the display's D65 white"
        ))
        .strong(),
    );
    ui.horizontal(|ui| {
        for s in &analysis.swatches {
            ui.vertical(|ui| {
                ui.label(s.illuminant.to_string());
                swatch_ui(ui, s.design_srgb, s.target_srgb);
                if let Some(de) = s.delta_e {
                    ui.label(delta_e_text(de));
                }
            });
        }
    });
    if analysis.target.is_some() {
        ui.label(
            RichText::new("Left half: design; right half: target. ΔE00 under each light (10°).")
                .weak(),
        );
    }
    requests
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
