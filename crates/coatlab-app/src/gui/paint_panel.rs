//! The paint controls: every parameter of a [`PaintDesign`] with its unit and range.
//!
//! Widgets are bounded to each parameter's valid range (a slider cannot leave it), so
//! almost nothing invalid can be entered. What bounds cannot express — n(λ) from a
//! Cauchy pair dipping below 1 somewhere in 380–780 nm, say — is reported by the
//! design's own validation, in red, under the control it concerns.

use coatlab_core::colour::spectrum::TabulatedSpectrum;
use coatlab_core::design::{Absorption, DesignError, Gloss, PaintDesign, RefractiveIndex};
use coatlab_core::paint::gloss::{
    GLOSS_WAVELENGTH_NM, GlossExponent, GlossGeometry, reading_from_exponent,
};
use coatlab_core::paint::lobe::LobeKind;
use egui::{Color32, RichText, Ui};
use egui_plot::{Line, Plot, PlotPoints};

use super::curve_editor::{CurveEditor, CurveScale};

/// Ranges of the controls (the design format allows more; these are the paints the
/// model is meant for, and what a slider can usefully span).
pub const THICKNESS_RANGE_UM: (f64, f64) = (0.0, 200.0);
pub const CAUCHY_A_RANGE: (f64, f64) = (1.0, 2.5);
pub const CAUCHY_B_RANGE_UM2: (f64, f64) = (-0.02, 0.1);
pub const ABSORPTION_RANGE_PER_UM: (f64, f64) = (0.0, 1.0);
const K_CURVE_SCALE: CurveScale = CurveScale::Log10 {
    min: 1e-5,
    max: 1.0,
};
const RHO_SCALE: CurveScale = CurveScale::Linear { min: 0.0, max: 1.0 };

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
    section(
        ui,
        "Pigment albedo ρ(λ)",
        "dimensionless, 0–1; drag the points",
    );
    if let Some(table) = (CurveEditor {
        label: "ρ",
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
        "n = A + B/λ², λ in µm; n ≥ 1 over 380–780 nm",
    );
    refractive_index_ui(ui, design);
    show_error(ui, error_for("clear_coat.refractive_index"));

    ui.separator();
    section(ui, "Clear coat absorption k(λ)", "1/µm, ≥ 0");
    absorption_ui(ui, design);
    show_error(ui, error_for("clear_coat.absorption"));

    ui.separator();
    section(ui, "Clear coat thickness h", "µm, 0–200");
    ui.add(
        egui::Slider::new(
            &mut design.thickness_um,
            THICKNESS_RANGE_UM.0..=THICKNESS_RANGE_UM.1,
        )
        .text("Thickness h (µm)")
        .suffix(" µm")
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
                egui::Slider::new(a, CAUCHY_A_RANGE.0..=CAUCHY_A_RANGE.1)
                    .text("Cauchy A")
                    .max_decimals(4),
            );
            ui.add(
                egui::Slider::new(b_um2, CAUCHY_B_RANGE_UM2.0..=CAUCHY_B_RANGE_UM2.1)
                    .text("Cauchy B (µm²)")
                    .suffix(" µm²")
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
                .on_hover_text("Least-squares A + B/λ² through the table's samples in 380–780 nm")
                .clicked()
            {
                let (a, b_um2) = cauchy_fit(table);
                design.refractive_index = RefractiveIndex::Cauchy { a, b_um2 };
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
    let points: PlotPoints = (380..=780)
        .step_by(5)
        .map(|l| [f64::from(l), design.refractive_index_at_nm(f64::from(l))])
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

/// Least-squares Cauchy coefficients (A, B in µm²) through a table's samples in
/// 380–780 nm: linear regression of n on 1/λ².
pub fn cauchy_fit(table: &TabulatedSpectrum) -> (f64, f64) {
    let samples: Vec<(f64, f64)> = table
        .wavelengths_nm()
        .iter()
        .zip(table.values())
        .filter(|(l, _)| (380.0..=780.0).contains(*l))
        .map(|(&l, &n)| (1.0 / (l * 1e-3).powi(2), n))
        .collect();
    let count = samples.len() as f64;
    if samples.len() < 2 {
        return (table.value_at_nm(GLOSS_WAVELENGTH_NM).max(1.0), 0.0);
    }
    let mean_x = samples.iter().map(|s| s.0).sum::<f64>() / count;
    let mean_y = samples.iter().map(|s| s.1).sum::<f64>() / count;
    let sxx: f64 = samples.iter().map(|s| (s.0 - mean_x).powi(2)).sum();
    let sxy: f64 = samples
        .iter()
        .map(|s| (s.0 - mean_x) * (s.1 - mean_y))
        .sum();
    let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    (mean_y - b * mean_x, b)
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
                egui::Slider::new(k, ABSORPTION_RANGE_PER_UM.0..=ABSORPTION_RANGE_PER_UM.1)
                    .logarithmic(true)
                    .smallest_positive(1e-5)
                    .text("Absorption k (1/µm)")
                    .suffix(" /µm"),
            );
        }
        Absorption::Table(table) => {
            if let Some(t) = (CurveEditor {
                label: "k",
                unit: "1/µm",
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

/// The readings the gloss slider spans at one geometry and index: the broadest lobe
/// (m = 0) and the ideal mirror.
pub fn gloss_range(geometry: GlossGeometry, n: f64) -> Option<(f64, f64)> {
    let lo = reading_from_exponent(geometry, n, GlossExponent::Finite(0.0)).ok()?;
    let hi = reading_from_exponent(geometry, n, GlossExponent::Mirror).ok()?;
    Some((lo, hi))
}

fn gloss_ui(ui: &mut Ui, design: &mut PaintDesign) {
    let n = design.refractive_index_at_nm(GLOSS_WAVELENGTH_NM);
    let Gloss { gu, geometry } = design.gloss;
    let range = gloss_range(geometry, n);
    let range_text = match range {
        Some((lo, hi)) => format!("GU at {geometry}, {lo:.1}–{hi:.1} (top = ideal mirror)"),
        None => "GU".to_owned(),
    };
    section(ui, "Gloss g", &range_text);
    ui.horizontal(|ui| {
        ui.label("Geometry");
        for g in GlossGeometry::ALL {
            if ui.radio(geometry == g, g.to_string()).clicked() && g != geometry {
                design.gloss = convert_gloss(design.gloss, g, n);
            }
        }
    });
    if let Some((lo, hi)) = range {
        let mut value = gu.clamp(lo, hi);
        let response = ui.add(
            egui::Slider::new(&mut value, lo..=hi)
                .text("Gloss g (GU)")
                .suffix(" GU")
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

/// The reading at another geometry that gives the same lobe, so changing the
/// geometry changes the number shown, not the paint.
pub fn convert_gloss(gloss: Gloss, to: GlossGeometry, n: f64) -> Gloss {
    let exponent = coatlab_core::paint::gloss::exponent_from_reading(gloss.geometry, n, gloss.gu);
    let gu = exponent
        .ok()
        .and_then(|m| reading_from_exponent(to, n, m).ok())
        .unwrap_or(gloss.gu);
    Gloss { gu, geometry: to }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cauchy_fit_recovers_a_cauchy_table() {
        let w: Vec<f64> = (0..=40).map(|i| 380.0 + 10.0 * f64::from(i)).collect();
        let v = w
            .iter()
            .map(|l| 1.5 + 0.0042 / (l * 1e-3f64).powi(2))
            .collect();
        let (a, b) = cauchy_fit(&TabulatedSpectrum::new(w, v).expect("valid"));
        assert!(
            (a - 1.5).abs() < 1e-9 && (b - 0.0042).abs() < 1e-9,
            "{a} {b}"
        );
    }

    #[test]
    fn changing_the_geometry_keeps_the_lobe() {
        let g = Gloss {
            gu: 50.0,
            geometry: GlossGeometry::Deg20,
        };
        let g60 = convert_gloss(g, GlossGeometry::Deg60, 1.5);
        assert_eq!(g60.geometry, GlossGeometry::Deg60);
        let back = convert_gloss(g60, GlossGeometry::Deg20, 1.5);
        assert!((back.gu - 50.0).abs() < 1e-6, "{back:?}");
    }
}
