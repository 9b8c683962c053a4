//! The design against its target as a quality lab reports it — what `coatlab
//! measure --target` prints, from the same [`Comparison`] — and the report of
//! *Fit to target* (what `coatlab fit` prints).

use coatlab_core::colour::tolerance::METAMERIC_DE00;
use coatlab_core::fit::{FreeParameters, Method};
use coatlab_core::target::Comparison;
use egui::{Color32, RichText, Ui};

use super::fit_job::FitDone;
use super::instruments_panel::{heading_ui, table_ui};

/// How many unreachable wavelengths are listed before the rest are counted.
const UNREACHABLE_LISTED: usize = 8;

fn fail_colour() -> Color32 {
    Color32::from_rgb(230, 90, 60)
}

fn verdict(pass: bool) -> RichText {
    if pass {
        RichText::new("pass").color(Color32::from_rgb(90, 190, 90))
    } else {
        RichText::new("FAIL").color(fail_colour()).strong()
    }
}

/// The tolerance table: per geometry ΔL*, Δa*, Δb*, ΔC*, ΔH*, the three totals,
/// the limit and the verdict; then the result, the metamerism index, the gloss
/// beside the target's and the comparison's notes.
pub fn comparison_ui(ui: &mut Ui, c: &Comparison) {
    let t = &c.tolerance;
    heading_ui(
        ui,
        format!(
            "Against the target: {} ≤ {} (design − target)",
            t.formula, t.default_limit
        ),
    );
    const HEADS: [&str; 11] = [
        "geometry", "ΔL*", "Δa*", "Δb*", "ΔC*", "ΔH*", "ΔE00", "ΔE*ab", "CMC 2:1", "limit",
        "verdict",
    ];
    table_ui(ui, "tolerance", &HEADS, |ui| {
        for a in &c.angles {
            let d = &a.difference;
            ui.label(a.geometry.to_string());
            for v in [
                d.dl, d.da, d.db, d.dc, d.dh, d.de00, d.de_ab, d.de_cmc, a.limit,
            ] {
                ui.label(format!("{v:.2}"));
            }
            ui.label(verdict(a.pass));
            ui.end_row();
        }
    });
    for n in &c.not_comparable {
        ui.label(RichText::new(format!("{}: {}", n.geometry, n.reason)).weak());
    }
    let result = match c.pass {
        Some(true) => verdict(true).text().to_owned() + " at every compared geometry",
        Some(false) => format!(
            "FAIL at {} of {} geometries",
            c.angles.iter().filter(|a| !a.pass).count(),
            c.angles.len()
        ),
        None => "nothing to compare".to_owned(),
    };
    let result = RichText::new(format!("Result: {result}")).strong();
    ui.label(if c.pass == Some(false) {
        result.color(fail_colour())
    } else {
        result
    });
    if c.angles.iter().any(|a| !a.metamerism.is_empty()) {
        ui.label("Metamerism index (matched under D65): ΔE00 (ΔE*ab)");
        for a in c.angles.iter().filter(|a| !a.metamerism.is_empty()) {
            ui.label(format!("{}   {}", a.geometry, a.metamerism_summary()));
        }
        if c.metameric {
            ui.label(
                RichText::new(format!(
                    "Warning: metameric: the match changes by more than {METAMERIC_DE00} ΔE00 under \
                     another light"
                ))
                .color(fail_colour()),
            );
        }
    }
    for g in &c.gloss {
        ui.label(format!(
            "Gloss {}°: design {:.1} GU, target {:.1} GU",
            g.angle_deg, g.design_gu, g.target_gu
        ));
    }
    for note in &c.notes {
        ui.label(RichText::new(format!("Note: {note}")).weak());
    }
}

/// The free parameters as the report's heading names them: "ρ(λ), h".
fn free_names(free: FreeParameters) -> String {
    free.names()
        .into_iter()
        .map(|name| if name == "rho" { "ρ(λ)" } else { name })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The last fit: what was free, how ρ was found, the coat parameters before and
/// after, the residual per geometry, where the target cannot be reached and why,
/// and the fit's notes.
pub fn fit_report_ui(ui: &mut Ui, done: &FitDone) {
    let fit = &done.fit;
    heading_ui(
        ui,
        format!(
            "Fit of {} to sample {:?} of {}",
            free_names(fit.free),
            done.sample,
            done.file
        ),
    );
    let method = match fit.method {
        Method::ClosedForm => "the closed form per wavelength (one geometry)".to_owned(),
        Method::LeastSquares => "bounded least squares over the measured geometries".to_owned(),
        Method::SmoothestMetamer => "the smoothest ρ(λ) with the stated colours".to_owned(),
    };
    let weight = fit
        .smoothness_weight
        .map(|w| format!(", smoothness weight {w}"))
        .unwrap_or_default();
    ui.label(format!(
        "Method: {method}{weight}; the rest kept from {:?}",
        done.start.name
    ));
    for parameter in &fit.coat {
        ui.label(parameter.to_string());
    }
    let rms = |g| {
        done.report
            .spectral_rms
            .iter()
            .find(|(geometry, _)| *geometry == g)
            .map_or("–".to_owned(), |(_, rms)| format!("{rms:.4}"))
    };
    table_ui(
        ui,
        "fit_residual",
        &["geometry", "residual ΔE00", "spectral RMS"],
        |ui| {
            for a in &done.report.comparison.angles {
                ui.label(a.geometry.to_string());
                ui.label(format!("{:.2}", a.difference.de00));
                ui.label(rms(a.geometry));
                ui.end_row();
            }
        },
    );
    if !fit.unreachable.is_empty() {
        ui.label(
            RichText::new(format!(
                "The target cannot be reached at {} wavelength(s) and geometries:",
                fit.unreachable.len()
            ))
            .color(fail_colour()),
        );
        for u in fit.unreachable.iter().take(UNREACHABLE_LISTED) {
            ui.label(format!("  {u}"));
        }
        if fit.unreachable.len() > UNREACHABLE_LISTED {
            ui.label(format!(
                "  … and {} more",
                fit.unreachable.len() - UNREACHABLE_LISTED
            ));
        }
    }
    for note in &fit.notes {
        ui.label(RichText::new(format!("Note: {note}")).weak());
    }
}
