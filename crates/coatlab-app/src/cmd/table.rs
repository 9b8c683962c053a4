//! Numeric CSV in, CSV out: the shape shared by `brdf` and `delta-e`.
//!
//! Named input columns may come in any order; other columns pass through in place;
//! computed columns are appended. Errors name the stdin row, its line and the column.

use std::io::{Read, Write};

use anyhow::Context;

use super::failure::{Classify, Failure};

/// Reads CSV from `input` whose header must contain each of `inputs` exactly once,
/// checks each value with `check(column, value)` (values are already finite), and
/// writes every record followed by the values `compute` returns for `outputs`.
pub fn map_numeric_rows<const N: usize>(
    input: impl Read,
    out: &mut impl Write,
    inputs: [&str; N],
    outputs: &[&str],
    check: impl Fn(&str, f64) -> Result<(), String>,
    mut compute: impl FnMut([f64; N]) -> Vec<f64>,
) -> anyhow::Result<()> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(input);
    let header = reader
        .headers()
        .context("cannot read the CSV header on stdin")?
        .clone();
    let names: Vec<&str> = header.iter().map(str::trim).collect();
    for column in outputs {
        if names.contains(column) {
            return Err(Failure::Data.error(format!(
                "stdin already has a \"{column}\" column; rename or remove it"
            )));
        }
    }
    let mut index = [0; N];
    let mut missing = Vec::new();
    for (slot, column) in index.iter_mut().zip(inputs) {
        let mut positions = names
            .iter()
            .enumerate()
            .filter(|(_, name)| **name == column)
            .map(|(p, _)| p);
        match (positions.next(), positions.next()) {
            (Some(position), None) => *slot = position,
            (Some(_), Some(_)) => {
                return Err(Failure::Data.error(format!(
                    "stdin header has column \"{column}\" more than once"
                )));
            }
            (None, _) => missing.push(column),
        }
    }
    if !missing.is_empty() {
        return Err(Failure::Data.error(format!(
            "stdin header lacks column(s) {}; expected {}",
            missing.join(", "),
            inputs.join(",")
        )));
    }

    let mut writer = csv::Writer::from_writer(out);
    writer
        .write_record(header.iter().chain(outputs.iter().copied()))
        .or_fail(Failure::Io)?;
    for (row_index, record) in reader.records().enumerate() {
        let row = row_index + 1;
        let record = record.with_context(|| format!("stdin row {row}: cannot read CSV"))?;
        let line = record.position().map_or(0, csv::Position::line);
        if record.len() != header.len() {
            return Err(Failure::Data.error(format!(
                "stdin row {row} (line {line}): {} fields, but the header has {}",
                record.len(),
                header.len()
            )));
        }
        let mut values = [0.0; N];
        for ((value, &column_index), column) in values.iter_mut().zip(&index).zip(inputs) {
            let text = record[column_index].trim();
            *value = match text.parse::<f64>() {
                Ok(v) if v.is_finite() => v,
                _ => {
                    return Err(Failure::Data.error(format!(
                        "stdin row {row} (line {line}), column \"{column}\": cannot read {text:?} as a finite number"
                    )));
                }
            };
            if let Err(constraint) = check(column, *value) {
                return Err(Failure::Data.error(format!(
                    "stdin row {row} (line {line}), column \"{column}\": {constraint}"
                )));
            }
        }
        let results = compute(values);
        if let Some(bad) = results.iter().position(|v| !v.is_finite()) {
            return Err(Failure::Internal.error(format!(
                "stdin row {row} (line {line}): the model gave {} = {} (a bug: please report these parameters)",
                outputs.get(bad).copied().unwrap_or("a value"),
                results[bad]
            )));
        }
        let formatted: Vec<String> = results.iter().map(f64::to_string).collect();
        writer
            .write_record(record.iter().chain(formatted.iter().map(String::as_str)))
            .or_fail(Failure::Io)?;
    }
    writer.flush().or_fail(Failure::Io)?;
    Ok(())
}
