//! The paint controls: every parameter of a [`PaintDesign`] with its unit and range.
//!
//! Units, ranges and the spans of the controls are those of the paint model's
//! parameter table ([`coatlab_core::paint::parameters`]); the physics behind the
//! controls (the Cauchy fit of a table, the span of gloss readings, a reading at
//! another geometry) is the core's. Widgets are bounded to each parameter's control
//! span, within its valid range (a slider cannot leave it), so almost nothing
//! invalid can be entered. What bounds cannot express — n(λ) from a Cauchy pair
//! dipping below 1 somewhere in the visible range, say — is reported by the
//! design's own validation, in red, under the control it concerns.

use std::ops::RangeInclusive;

use coatlab_core::colour::spectrum::{TabulatedSpectrum, VISIBLE, WavelengthGrid};
use coatlab_core::design::{Absorption, DesignError, Gloss, PaintDesign, RefractiveIndex};
use coatlab_core::paint::gloss::{
    GLOSS_WAVELENGTH_NM, GlossExponent, GlossGeometry, reading_range,
};
use coatlab_core::paint::lobe::LobeKind;
use coatlab_core::paint::parameters::{
    ABSORPTION, ALBEDO, Bounds, CAUCHY_A, CAUCHY_B, GLOSS, Parameter, REFRACTIVE_INDEX, THICKNESS,
};
use coatlab_core::units::Unit;
use egui::{Color32, RichText, Ui};
use egui_plot::{Line, Plot, PlotPoints};

use super::curve_editor::{CurveEditor, CurveScale};

/// The bottom of the logarithmic k controls, standing for 0 (a log axis has no
/// place for it): through 200 µm, the thickest coat the control offers, k = 1e-5
/// /µm absorbs 0.2 %.
pub const ABSORPTION_LOG_FLOOR_PER_UM: f64 = 1e-5;
const K_CURVE_SCALE: CurveScale = CurveScale::Log10 {
    min: ABSORPTION_LOG_FLOOR_PER_UM,
    max: control_span(&ABSORPTION).max,
};
const RHO_SCALE: CurveScale = CurveScale::Linear {
    min: control_span(&ALBEDO).min,
    max: control_span(&ALBEDO).max,
};

/// The span a control offers for `parameter`: the table's control span, or its
/// range where the table gives none.
pub const fn control_span(parameter: &Parameter) -> Bounds {
    match parameter.control {
        Some(span) => span,
        None => parameter.range,
    }
}

fn slider_range(parameter: &Parameter) -> RangeInclusive<f64> {
    let span = control_span(parameter);
    span.min..=span.max
}

/// A slider's accessible label: "Thickness h (µm)", "Cauchy A".
pub fn slider_label(word: &str, parameter: &Parameter) -> String {
    match parameter.unit {
        Unit::Dimensionless => format!("{word} {}", parameter.symbol),
        unit => format!("{word} {} ({unit})", parameter.symbol),
    }
}

/// What the panel asks the app to do (things that need files or the whole app).
#[derive(Debug, Clone, PartialEq)]
pub enum PanelRequest {
    /// Open the file browser to import ρ(λ) from a spectral CSV.
    ImportAlbedoCsv,
    /// Replace the design by the preset with this index in `presets::all()`.
    LoadPreset(usize),
}

/// Shows the controls; edits `design` in place and returns requests for the app.
pub fn paint_controls_ui(
    ui: &mut Ui,
    design: &mut PaintDesign,
    presets: &[coatlab_core::design::presets::Preset],
) -> Vec<PanelRequest> {
    let mut requests = Vec::new();
    let error = design.validate().err();
    let error_for = |prefix: &str| -> Option<String> {
        let e: &DesignError = error.as_ref()?;
        let field = e.field()?;
        field.starts_with(prefix).then(|| e.to_string())
    };

    ui.horizontal(|ui| {
        let label = ui.label("Name");
        ui.add(egui::TextEdit::singleline(&mut design.name).desired_width(f32::INFINITY))
            .labelled_by(label.id);
    });
    show_error(ui, error_for("name"));
    ui.horizontal(|ui| {
        egui::ComboBox::from_label("Preset")
            .selected_text("Load…")
            .show_ui(ui, |ui| {
                for (i, p) in presets.iter().enumerate() {
                    if ui.selectable_label(false, &p.design.name).clicked() {
                        requests.push(PanelRequest::LoadPreset(i));
                    }
                }
            });
        if ui
            .button("Import ρ(λ) from CSV…")
            .on_hover_text("A CSV with a wavelength_nm column and one column of reflectance in [0, 1]; it must cover 400–700 nm")
            .clicked()
        {
            requests.push(PanelRequest::ImportAlbedoCsv);
        }
    });

    ui.separator();
    let rho_span = control_span(&ALBEDO);
    section(
        ui,
        "Pigment albedo ρ(λ)",
        &format!(
            "dimensionless, {}–{}; drag the points",
            rho_span.min, rho_span.max
        ),
    );
    if let Some(table) = (CurveEditor {
        label: ALBEDO.symbol,
        unit: "",
        scale: RHO_SCALE,
        control_step_nm: 25.0,
        height: 150.0,
        colour: Color32::from_rgb(220, 90, 60),
    })
    .show(ui, &design.albedo)
    {
        design.albedo = table;
    }
    show_error(ui, error_for("pigment"));

    ui.separator();
    section(
        ui,
        "Clear coat refractive index n(λ)",
        &format!(
            "n = A + B/λ², λ in µm; n ≥ {} over {VISIBLE}",
            REFRACTIVE_INDEX.range.min
        ),
    );
    refractive_index_ui(ui, design);
    show_error(ui, error_for("clear_coat.refractive_index"));

    ui.separator();
    section(
        ui,
        "Clear coat absorption k(λ)",
        &format!("{}, ≥ {}", ABSORPTION.unit, ABSORPTION.range.min),
    );
    absorption_ui(ui, design);
    show_error(ui, error_for("clear_coat.absorption"));

    ui.separator();
    let h_span = control_span(&THICKNESS);
    section(
        ui,
        "Clear coat thickness h",
        &format!("{}, {}–{}", THICKNESS.unit, h_span.min, h_span.max),
    );
    ui.add(
        egui::Slider::new(&mut design.thickness_um, slider_range(&THICKNESS))
            .text(slider_label("Thickness", &THICKNESS))
            .suffix(THICKNESS.unit.suffix())
            .max_decimals(1),
    );
    show_error(ui, error_for("clear_coat.thickness"));

    ui.separator();
    gloss_ui(ui, design);
    show_error(ui, error_for("gloss"));
    if let Some(e) = &error
        && e.field().is_none()
    {
        show_error(ui, Some(e.to_string()));
    }
    requests
}

fn section(ui: &mut Ui, title: &str, range: &str) {
    ui.horizontal(|ui| {
        ui.strong(title);
        ui.label(RichText::new(range).weak());
    });
}

fn show_error(ui: &mut Ui, error: Option<String>) {
    if let Some(e) = error {
        ui.label(RichText::new(format!("Invalid: {e}")).color(ui.visuals().error_fg_color));
    }
}

fn refractive_index_ui(ui: &mut Ui, design: &mut PaintDesign) {
    match &mut design.refractive_index {
        RefractiveIndex::Cauchy { a, b_um2 } => {
            ui.add(
                egui::Slider::new(a, slider_range(&CAUCHY_A))
                    .text(slider_label("Cauchy", &CAUCHY_A))
                    .max_decimals(4),
            );
            ui.add(
                egui::Slider::new(b_um2, slider_range(&CAUCHY_B))
                    .text(slider_label("Cauchy", &CAUCHY_B))
                    .suffix(CAUCHY_B.unit.suffix())
                    .max_decimals(5),
            );
        }
        RefractiveIndex::Table(table) => {
            ui.label(format!(
                "Tabulated from the file ({} samples, {:.0}–{:.0} nm).",
                table.values().len(),
                table.wavelengths_nm().first().copied().unwrap_or(0.0),
                table.wavelengths_nm().last().copied().unwrap_or(0.0)
            ));
            if ui
                .button("Replace by a Cauchy fit")
                .on_hover_text(format!(
                    "Least-squares A + B/λ² through the table's samples in {VISIBLE}"
                ))
                .clicked()
            {
                design.refractive_index = RefractiveIndex::cauchy_fit(table);
            }
        }
    }
    let n_d = design.refractive_index_at_nm(GLOSS_WAVELENGTH_NM);
    ui.label(
        RichText::new(format!(
            "n at {GLOSS_WAVELENGTH_NM} nm = {n_d:.4} (sets the gloss scale)"
        ))
        .weak(),
    );
    let points: PlotPoints = WavelengthGrid::reference()
        .wavelengths_nm()
        .map(|l| [l, design.refractive_index_at_nm(l)])
        .collect::<Vec<_>>()
        .into();
    Plot::new("n_plot")
        .height(90.0)
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .x_axis_label("λ (nm)")
        .show(ui, |p| p.line(Line::new("n(λ)", points)));
}

fn absorption_ui(ui: &mut Ui, design: &mut PaintDesign) {
    let is_constant = matches!(design.absorption_per_um, Absorption::Constant(_));
    ui.horizontal(|ui| {
        if ui.radio(is_constant, "constant").clicked() && !is_constant {
            design.absorption_per_um =
                Absorption::Constant(mean_visible(&design.absorption_per_um));
        }
        if ui.radio(!is_constant, "curve").clicked() && is_constant {
            let k = design.absorption_per_um.at_nm(550.0);
            let w: Vec<f64> = (0..=48).map(|i| 300.0 + 10.0 * f64::from(i)).collect();
            let v = vec![k; w.len()];
            if let Ok(table) = TabulatedSpectrum::new(w, v) {
                design.absorption_per_um = Absorption::Table(table);
            }
        }
    });
    match &mut design.absorption_per_um {
        Absorption::Constant(k) => {
            ui.add(
                egui::Slider::new(k, slider_range(&ABSORPTION))
                    .logarithmic(true)
                    .smallest_positive(ABSORPTION_LOG_FLOOR_PER_UM)
                    .text(slider_label("Absorption", &ABSORPTION))
                    .suffix(ABSORPTION.unit.suffix()),
            );
        }
        Absorption::Table(table) => {
            if let Some(t) = (CurveEditor {
                label: ABSORPTION.symbol,
                unit: ABSORPTION.unit.symbol(),
                scale: K_CURVE_SCALE,
                control_step_nm: 20.0,
                height: 120.0,
                colour: Color32::from_rgb(150, 110, 220),
            })
            .show(ui, table)
            {
                *table = t;
            }
        }
    }
    let tau = design.absorption_per_um.at_nm(550.0) * design.thickness_um;
    ui.label(RichText::new(format!("optical depth τ = k·h at 550 nm: {tau:.4}")).weak());
}

fn mean_visible(absorption: &Absorption) -> f64 {
    let samples: Vec<f64> = (400..=700)
        .step_by(10)
        .map(|l| absorption.at_nm(f64::from(l)))
        .collect();
    samples.iter().sum::<f64>() / samples.len() as f64
}

fn gloss_ui(ui: &mut Ui, design: &mut PaintDesign) {
    let n = design.refractive_index_at_nm(GLOSS_WAVELENGTH_NM);
    let Gloss { gu, geometry } = design.gloss;
    let range = reading_range(geometry, n).ok();
    let range_text = match range {
        Some(Bounds { min, max }) => format!(
            "{} at {geometry}, {min:.1}–{max:.1} (top = ideal mirror)",
            GLOSS.unit
        ),
        None => GLOSS.unit.to_string(),
    };
    section(ui, "Gloss g", &range_text);
    ui.horizontal(|ui| {
        ui.label("Geometry");
        for g in GlossGeometry::ALL {
            if ui.radio(geometry == g, g.to_string()).clicked() && g != geometry {
                design.gloss = design.gloss.at_geometry(g, n);
            }
        }
    });
    if let Some(Bounds { min, max }) = range {
        let mut value = gu.clamp(min, max);
        let response = ui.add(
            egui::Slider::new(&mut value, min..=max)
                .text(slider_label("Gloss", &GLOSS))
                .suffix(GLOSS.unit.suffix())
                .max_decimals(2),
        );
        if response.changed() {
            design.gloss.gu = value;
        }
    }
    match design.exponent() {
        Ok(GlossExponent::Finite(m)) => {
            ui.label(RichText::new(format!("lobe exponent m = {m:.1}")).weak());
        }
        Ok(GlossExponent::Mirror) => {
            ui.label(RichText::new("ideal mirror (m = ∞)").weak());
        }
        Err(_) => {}
    }
    ui.horizontal(|ui| {
        ui.label("Lobe");
        for (kind, text, tip) in [
            (
                LobeKind::Normalised,
                "normalised",
                "Energy-conserving: the specular albedo is exactly R(θi)",
            ),
            (
                LobeKind::Paper,
                "the paper's",
                "Eq. 25′ as printed, not normalised",
            ),
        ] {
            if ui
                .radio(design.lobe == kind, text)
                .on_hover_text(tip)
                .clicked()
            {
                design.lobe = kind;
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use coatlab_core::design::presets;
    use egui::accesskit::Role;
    use egui_kittest::Harness;
    use egui_kittest::kittest::{NodeT, Queryable};

    use super::*;

    /// The span a slider reports to assistive technology (and so to a test), by
    /// its accessible label.
    fn reported_span(harness: &Harness<'_>, label: &str) -> (Option<f64>, Option<f64>) {
        let node = harness.get_by_role_and_label(Role::Slider, label);
        let node = node.accesskit_node();
        (node.min_numeric_value(), node.max_numeric_value())
    }

    #[test]
    fn every_slider_spans_its_parameter_s_control_in_the_table() {
        // A Cauchy index and a constant k: every slider of the panel is shown.
        let mut design = presets::all().remove(0).design;
        design.absorption_per_um = Absorption::Constant(ABSORPTION.default);
        let (geometry, n) = (
            design.gloss.geometry,
            design.refractive_index_at_nm(GLOSS_WAVELENGTH_NM),
        );
        let presets = presets::all();
        let harness = Harness::new_ui(|ui| {
            paint_controls_ui(ui, &mut design, &presets);
        });
        let gloss = reading_range(geometry, n).expect("the preset's gloss");
        for (label, parameter, span) in [
            ("Thickness h (µm)", &THICKNESS, THICKNESS.control),
            ("Cauchy A", &CAUCHY_A, CAUCHY_A.control),
            ("Cauchy B (µm²)", &CAUCHY_B, CAUCHY_B.control),
            ("Absorption k (1/µm)", &ABSORPTION, ABSORPTION.control),
            ("ρ at 550 nm", &ALBEDO, ALBEDO.control),
            ("Gloss g (GU)", &GLOSS, Some(gloss)),
        ] {
            let span = span.expect("a control span");
            assert_eq!(
                reported_span(&harness, label),
                (Some(span.min), Some(span.max)),
                "{label}"
            );
            for end in [span.min, span.max] {
                assert!(parameter.accepts(end), "{label}: {end} outside the range");
            }
        }
    }

    #[test]
    fn the_k_curve_spans_the_table_s_control_down_to_the_log_floor() {
        let mut design = presets::all().remove(0).design;
        assert!(matches!(design.absorption_per_um, Absorption::Table(_)));
        let presets = presets::all();
        let harness = Harness::new_ui(|ui| {
            paint_controls_ui(ui, &mut design, &presets);
        });
        let span = control_span(&ABSORPTION);
        assert_eq!(
            reported_span(&harness, "k at 400 nm"),
            (Some(ABSORPTION_LOG_FLOOR_PER_UM), Some(span.max))
        );
        assert!(span.min < ABSORPTION_LOG_FLOOR_PER_UM);
    }

    #[test]
    fn slider_labels_carry_symbol_and_unit() {
        assert_eq!(slider_label("Thickness", &THICKNESS), "Thickness h (µm)");
        assert_eq!(slider_label("Cauchy", &CAUCHY_A), "Cauchy A");
        assert_eq!(slider_label("Gloss", &GLOSS), "Gloss g (GU)");
    }
}
