//! The plots: the paper's figures 3–6 (reflectance distribution of the specular and
//! the body part against the viewing angle, paint model against Phong), the spectra
//! of the design, and the reflectance factor at the instrument's angles.

use coatlab_core::paint::phong::PhongVariant;
use egui::{Color32, Ui};
use egui_plot::{Legend, Line, LineStyle, Plot, PlotPoints, VLine};

use coatlab_core::analysis::Analysis;

/// Which plot the plots tab shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlotKind {
    /// Figures 3–6.
    #[default]
    Distribution,
    /// ρ, n, k.
    Spectra,
    /// π·f at the multi-angle instrument's angles.
    InstrumentReflectance,
}

/// Settings of the plots tab.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlotSettings {
    pub kind: PlotKind,
    /// Plot log10 of the specular part (its peak is orders of magnitude above the rest).
    pub log_specular: bool,
    /// Phong variant of the comparison.
    pub phong: PhongVariant,
}

impl Default for PlotSettings {
    fn default() -> Self {
        Self {
            kind: PlotKind::Distribution,
            log_specular: true,
            phong: PhongVariant::Naive,
        }
    }
}

/// One colour per angle of incidence (and per instrument angle).
const PALETTE: [Color32; 5] = [
    Color32::from_rgb(230, 85, 60),
    Color32::from_rgb(70, 150, 230),
    Color32::from_rgb(90, 190, 90),
    Color32::from_rgb(220, 170, 40),
    Color32::from_rgb(180, 100, 220),
];

/// Shows the plots tab.
pub fn plots_ui(ui: &mut Ui, settings: &mut PlotSettings, analysis: Option<&Analysis>) {
    ui.horizontal(|ui| {
        ui.selectable_value(&mut settings.kind, PlotKind::Distribution, "Figures 3–6");
        ui.selectable_value(&mut settings.kind, PlotKind::Spectra, "Spectra ρ, n, k");
        ui.selectable_value(
            &mut settings.kind,
            PlotKind::InstrumentReflectance,
            "Instrument angles",
        );
    });
    let Some(analysis) = analysis else {
        ui.label("No valid design to plot (see the paint controls).");
        return;
    };
    match settings.kind {
        PlotKind::Distribution => distribution_ui(ui, settings, analysis),
        PlotKind::Spectra => spectra_ui(ui, analysis),
        PlotKind::InstrumentReflectance => instrument_ui(ui, analysis),
    }
}

/// Decades below the peak the log plot shows; the lobe's tails beyond are nothing
/// a viewer sees and would squash the peak into a line.
const LOG_DECADES: f64 = 6.0;

fn transformed(curve: &[[f64; 2]], log: bool, log_floor: f64) -> PlotPoints<'static> {
    curve
        .iter()
        .filter(|p| !log || p[1] > 0.0)
        .map(|p| {
            [
                p[0],
                if log {
                    p[1].log10().max(log_floor)
                } else {
                    p[1]
                },
            ]
        })
        .collect::<Vec<_>>()
        .into()
}

fn distribution_ui(ui: &mut Ui, settings: &mut PlotSettings, analysis: &Analysis) {
    ui.horizontal(|ui| {
        ui.label("Phong:");
        for v in [PhongVariant::Naive, PhongVariant::BestFit] {
            ui.selectable_value(&mut settings.phong, v, v.label());
        }
        ui.checkbox(&mut settings.log_specular, "log₁₀ specular");
    });
    ui.label(
        egui::RichText::new(
            "Plane of incidence, light from the left; luminance-weighted BRDF (1/sr). Solid: paint model; dashed: Phong.",
        )
        .weak(),
    );
    let height = ((ui.available_height() - 40.0) / 2.0).max(120.0);
    let log = settings.log_specular;
    let peak = analysis
        .distributions
        .iter()
        .flat_map(|d| d.paint_specular.iter().chain(&d.phong_specular))
        .map(|p| p[1])
        .fold(f64::MIN_POSITIVE, f64::max);
    let floor = peak.log10() - LOG_DECADES;
    ui.label("Specular part");
    Plot::new("fig_specular")
        .height(height)
        .legend(Legend::default())
        .x_axis_label("viewing angle θo (°)")
        .y_axis_label(if log {
            "log₁₀ f_spec (1/sr)"
        } else {
            "f_spec (1/sr)"
        })
        .show(ui, |p| {
            for (i, d) in analysis.distributions.iter().enumerate() {
                let colour = PALETTE[i % PALETTE.len()];
                let name = format!("θi = {}°", d.incidence_deg);
                if let Some(r) = d.mirror_reflectance {
                    // A delta cannot be drawn as a curve: mark its direction.
                    p.vline(
                        VLine::new(format!("{name} mirror, R = {r:.4}"), d.incidence_deg)
                            .color(colour),
                    );
                } else {
                    p.line(
                        Line::new(
                            format!("{name} paint"),
                            transformed(&d.paint_specular, log, floor),
                        )
                        .color(colour),
                    );
                }
                p.line(
                    Line::new(
                        format!("{name} Phong"),
                        transformed(&d.phong_specular, log, floor),
                    )
                    .color(colour)
                    .style(LineStyle::dashed_dense()),
                );
            }
        });
    ui.label("Body part");
    Plot::new("fig_body")
        .height(height)
        .legend(Legend::default())
        .x_axis_label("viewing angle θo (°)")
        .y_axis_label("f_body (1/sr)")
        .show(ui, |p| {
            for (i, d) in analysis.distributions.iter().enumerate() {
                let colour = PALETTE[i % PALETTE.len()];
                let name = format!("θi = {}°", d.incidence_deg);
                p.line(
                    Line::new(
                        format!("{name} paint"),
                        transformed(&d.paint_body, false, 0.0),
                    )
                    .color(colour),
                );
                p.line(
                    Line::new(
                        format!("{name} Phong"),
                        transformed(&d.phong_diffuse, false, 0.0),
                    )
                    .color(colour)
                    .style(LineStyle::dashed_dense()),
                );
            }
        });
}

fn spectrum_line(name: &str, x: &[f64], y: &[f64], colour: Color32) -> Line<'static> {
    let points: Vec<[f64; 2]> = x.iter().zip(y).map(|(&a, &b)| [a, b]).collect();
    Line::new(name.to_owned(), PlotPoints::from(points)).color(colour)
}

fn spectra_ui(ui: &mut Ui, analysis: &Analysis) {
    let height = ((ui.available_height() - 60.0) / 3.0).max(90.0);
    let spectra = &analysis.spectra;
    let x = &spectra.wavelength_nm;
    let group = egui::Id::unique("spectra_x");
    for (id, name, y, colour, unit) in [
        ("spec_rho", "ρ(λ)", &spectra.albedo, PALETTE[0], "ρ"),
        ("spec_n", "n(λ)", &spectra.refractive_index, PALETTE[1], "n"),
        (
            "spec_k",
            "k(λ) (1/µm)",
            &spectra.absorption_per_um,
            PALETTE[4],
            "k (1/µm)",
        ),
    ] {
        ui.label(name);
        Plot::new(id)
            .height(height)
            .link_axis(group, [true, false])
            .x_axis_label("λ (nm)")
            .y_axis_label(unit)
            .show(ui, |p| p.line(spectrum_line(name, x, y, colour)));
    }
}

fn instrument_ui(ui: &mut Ui, analysis: &Analysis) {
    ui.label(
        egui::RichText::new(
            "Reflectance factor π·f under 45° illumination, by aspecular angle (dashed: target).",
        )
        .weak(),
    );
    let x = &analysis.measurement.wavelength_nm;
    Plot::new("instrument_reflectance")
        .height((ui.available_height() - 10.0).max(150.0))
        .legend(Legend::default())
        .x_axis_label("λ (nm)")
        .y_axis_label("R = π·f")
        .show(ui, |p| {
            for (i, a) in analysis.measurement.angles.iter().enumerate() {
                let colour = PALETTE[i % PALETTE.len()];
                p.line(spectrum_line(
                    &format!("{}°", a.aspecular_deg),
                    x,
                    &a.reflectance_factor,
                    colour,
                ));
            }
            if let Some((name, target)) = &analysis.target {
                for (i, a) in target.angles.iter().enumerate() {
                    let colour = PALETTE[i % PALETTE.len()];
                    p.line(
                        spectrum_line(
                            &format!("{name} {}°", a.aspecular_deg),
                            x,
                            &a.reflectance_factor,
                            colour,
                        )
                        .style(LineStyle::dashed_dense()),
                    );
                }
            }
        });
}
