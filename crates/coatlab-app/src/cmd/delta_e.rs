//! `coatlab delta-e`: CIEDE2000 of colour pairs, CSV in, CSV out.
//!
//! Input columns `L1,a1,b1,L2,a2,b2` may come in any order; other columns pass
//! through unchanged, and `dE00` is appended to each row.

use std::io::{Read, Write};

use anyhow::{Context, bail};
use coatlab_core::colour::{Lab, ciede2000};

const INPUT_COLUMNS: [&str; 6] = ["L1", "a1", "b1", "L2", "a2", "b2"];
const OUTPUT_COLUMN: &str = "dE00";

pub fn run(input: impl Read, out: &mut impl Write) -> anyhow::Result<()> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(input);
    let header = reader
        .headers()
        .context("cannot read the CSV header on stdin")?
        .clone();
    let names: Vec<&str> = header.iter().map(str::trim).collect();
    if names.contains(&OUTPUT_COLUMN) {
        bail!("stdin already has a \"{OUTPUT_COLUMN}\" column; rename or remove it");
    }
    let mut index = [0; 6];
    let mut missing = Vec::new();
    for (slot, column) in index.iter_mut().zip(INPUT_COLUMNS) {
        match names.iter().position(|name| *name == column) {
            Some(position) => *slot = position,
            None => missing.push(column),
        }
    }
    if !missing.is_empty() {
        bail!(
            "stdin header lacks column(s) {}; expected {}",
            missing.join(", "),
            INPUT_COLUMNS.join(",")
        );
    }

    let mut writer = csv::Writer::from_writer(out);
    writer.write_record(header.iter().chain([OUTPUT_COLUMN]))?;
    for (row_index, record) in reader.records().enumerate() {
        let row = row_index + 1;
        let record = record.with_context(|| format!("stdin row {row}: cannot read CSV"))?;
        let line = record.position().map_or(0, csv::Position::line);
        if record.len() != header.len() {
            bail!(
                "stdin row {row} (line {line}): {} fields, but the header has {}",
                record.len(),
                header.len()
            );
        }
        let mut values = [0.0; 6];
        for ((value, &column_index), column) in values.iter_mut().zip(&index).zip(INPUT_COLUMNS) {
            let text = record[column_index].trim();
            *value = match text.parse::<f64>() {
                Ok(v) if v.is_finite() => v,
                _ => bail!(
                    "stdin row {row} (line {line}), column \"{column}\": cannot read {text:?} as a finite number"
                ),
            };
        }
        let [l1, a1, b1, l2, a2, b2] = values;
        let de = ciede2000(Lab::new(l1, a1, b1), Lab::new(l2, a2, b2));
        writer.write_record(record.iter().chain([de.to_string().as_str()]))?;
    }
    writer.flush()?;
    Ok(())
}
