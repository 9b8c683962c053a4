//! Export of the instruments' readings (CSV for spreadsheets, JSON for scripts;
//! the JSON has the shape of `coatlab measure --json`, so one script reads both),
//! and what an exported preview image records about itself.

use std::path::Path;

use anyhow::Context;
use coatlab_core::design::PaintDesign;
use coatlab_core::instruments::ILLUMINATION_DEG;
use coatlab_core::io::atomic::write_bytes_atomically;
use coatlab_core::render::film::RenderRecord;
use coatlab_core::render::lighting::Lighting;

use coatlab_core::analysis::Analysis;

/// The readings as CSV: one row per aspecular angle (`kind = colour`), then one per
/// gloss geometry (`kind = gloss`); a column that does not apply to a row is empty.
pub fn measurement_csv(analysis: &Analysis) -> anyhow::Result<String> {
    let mut csv = csv::Writer::from_writer(Vec::new());
    csv.write_record([
        "kind",
        "angle_deg",
        "detector_deg",
        "L",
        "a",
        "b",
        "dE00",
        "specular_gu",
        "total_gu",
    ])?;
    for (i, a) in analysis.measurement.angles.iter().enumerate() {
        let de = analysis
            .delta_e
            .as_ref()
            .and_then(|d| d.get(i))
            .map(|d| d.to_string())
            .unwrap_or_default();
        csv.write_record([
            "colour".to_owned(),
            a.aspecular_deg.to_string(),
            a.detector_deg.to_string(),
            a.lab.l.to_string(),
            a.lab.a.to_string(),
            a.lab.b.to_string(),
            de,
            String::new(),
            String::new(),
        ])?;
    }
    for g in &analysis.measurement.gloss {
        csv.write_record([
            "gloss".to_owned(),
            g.geometry.angle_deg().to_string(),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
            g.specular_gu.to_string(),
            g.total_gu.to_string(),
        ])?;
    }
    let bytes = csv.into_inner().context("finishing the CSV")?;
    Ok(String::from_utf8(bytes)?)
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
        measurement_csv(analysis)?
    };
    Ok(write_bytes_atomically(path, text.as_bytes())?)
}

/// What an exported preview's EXR records in its header beyond what the film
/// knows: the design's name, the lighting (a setup's name or a map's path) and
/// the seed ([`coatlab_core::render::film::Film::write_exr_with`]).
pub fn preview_record(design: &PaintDesign, lighting: &Lighting, seed: u64) -> RenderRecord {
    RenderRecord {
        design: Some(design.name.clone()),
        samples_per_pixel: None,
        seed: Some(seed),
        lighting: Some(lighting.name()),
    }
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
        let csv = measurement_csv(&a).expect("CSV");
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

    /// The bytes the CSV had when it was written line by line: numbers in Rust's
    /// shortest round-trip form, nothing quoted, empty fields for what a row does
    /// not have, `\n` line ends.
    #[test]
    fn csv_is_the_numbers_display_form_without_quotes() {
        let all = presets::all();
        let a = Analysis::compute(&all[0].design, Some(&all[1].design), PhongVariant::Naive)
            .expect("valid");
        let mut expected =
            String::from("kind,angle_deg,detector_deg,L,a,b,dE00,specular_gu,total_gu\n");
        let delta_e = a.delta_e.as_ref().expect("a target");
        for (angle, de) in a.measurement.angles.iter().zip(delta_e) {
            expected += &format!(
                "colour,{},{},{},{},{},{de},,\n",
                angle.aspecular_deg, angle.detector_deg, angle.lab.l, angle.lab.a, angle.lab.b
            );
        }
        for g in &a.measurement.gloss {
            expected += &format!(
                "gloss,{},,,,,,{},{}\n",
                g.geometry.angle_deg(),
                g.specular_gu,
                g.total_gu
            );
        }
        assert_eq!(measurement_csv(&a).expect("CSV"), expected);
        // Without a target the dE00 column is empty.
        let alone = Analysis::compute(&all[0].design, None, PhongVariant::Naive).expect("valid");
        let csv = measurement_csv(&alone).expect("CSV");
        let first_row: Vec<&str> = csv.lines().nth(1).expect("a row").split(',').collect();
        assert_eq!(first_row[6], "");
    }

    #[test]
    fn a_preview_record_names_the_design_lighting_and_seed() {
        use coatlab_core::colour::cie::Illuminant;
        let design = presets::all()[0].design.clone();
        let record = preview_record(&design, &Lighting::Booth(Illuminant::F11), 9);
        assert_eq!(record.design.as_deref(), Some(design.name.as_str()));
        assert_eq!(record.lighting.as_deref(), Some("booth-f11"));
        assert_eq!(record.seed, Some(9));
        assert_eq!(record.samples_per_pixel, None, "the film's own count");
    }
}
