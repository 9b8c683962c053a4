//! Export of the instruments' readings: CSV for spreadsheets, JSON for scripts. The
//! JSON has the shape of `coatlab measure --json`, so one script reads both.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context;
use coatlab_core::instruments::ILLUMINATION_DEG;

use super::analysis::Analysis;

/// The readings as CSV: one row per aspecular angle (`kind = colour`), then one per
/// gloss geometry (`kind = gloss`); a column that does not apply to a row is empty.
pub fn measurement_csv(analysis: &Analysis) -> String {
    let mut out = String::from("kind,angle_deg,detector_deg,L,a,b,dE00,specular_gu,total_gu\n");
    for (i, a) in analysis.measurement.angles.iter().enumerate() {
        let de = analysis
            .delta_e
            .as_ref()
            .and_then(|d| d.get(i))
            .map(|d| d.to_string())
            .unwrap_or_default();
        let _ = writeln!(
            out,
            "colour,{},{},{},{},{},{de},,",
            a.aspecular_deg, a.detector_deg, a.lab.l, a.lab.a, a.lab.b
        );
    }
    for g in &analysis.measurement.gloss {
        let _ = writeln!(
            out,
            "gloss,{},,,,,,{},{}",
            g.geometry.angle_deg(),
            g.specular_gu,
            g.total_gu
        );
    }
    out
}

/// The readings as JSON (the shape of `coatlab measure --json`).
pub fn measurement_json(
    analysis: &Analysis,
    design_name: &str,
    file: Option<&Path>,
) -> anyhow::Result<String> {
    let json = serde_json::json!({
        "design": design_name,
        "file": file.map(|f| f.display().to_string()),
        "illumination_deg": ILLUMINATION_DEG,
        "colour_space": "CIELAB D65/10°",
        "measurement": analysis.measurement,
        "target": analysis.target.as_ref().map(|(name, _)| name.clone()),
        "delta_e00": analysis.delta_e,
    });
    Ok(serde_json::to_string_pretty(&json)?)
}

/// Writes an export; the format follows the extension (`.json`, anything else CSV).
pub fn write_measurement(
    path: &Path,
    analysis: &Analysis,
    design_name: &str,
    design_file: Option<&Path>,
) -> anyhow::Result<()> {
    let is_json = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let text = if is_json {
        measurement_json(analysis, design_name, design_file)?
    } else {
        measurement_csv(analysis)
    };
    std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use coatlab_core::design::presets;
    use coatlab_core::paint::phong::PhongVariant;

    #[test]
    fn csv_has_five_colour_rows_and_three_gloss_rows() {
        let all = presets::all();
        let a = Analysis::compute(&all[0].design, Some(&all[1].design), PhongVariant::Naive)
            .expect("valid");
        let csv = measurement_csv(&a);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 1 + 5 + 3);
        assert!(lines[1].starts_with("colour,15,30,"));
        assert!(lines[6].starts_with("gloss,20,"));
        assert!(lines.iter().all(|l| l.split(',').count() == 9));
        let json: serde_json::Value =
            serde_json::from_str(&measurement_json(&a, "x", None).expect("serialises"))
                .expect("valid JSON");
        assert_eq!(
            json["measurement"]["angles"].as_array().map(Vec::len),
            Some(5)
        );
        assert_eq!(json["delta_e00"].as_array().map(Vec::len), Some(5));
    }
}
