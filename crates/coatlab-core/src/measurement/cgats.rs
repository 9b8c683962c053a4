//! CGATS.17 / ASTM E1708 text measurement files.
//!
//! The format: an optional identifier line (`CGATS.17`, `IT8.7/2`, …), header
//! lines `KEYWORD value`, then one or more tables, each `NUMBER_OF_FIELDS n`,
//! `BEGIN_DATA_FORMAT` field names `END_DATA_FORMAT`, `NUMBER_OF_SETS m`,
//! `BEGIN_DATA` one row per line `END_DATA`. Values are separated by white space;
//! text may be quoted; `#` starts a comment. CRLF and LF line ends both work.
//!
//! Fields understood (case-insensitive; others are ignored):
//! - names: `SAMPLE_NAME`, `SAMPLE_ID` (the name is `SAMPLE_NAME` where both are);
//! - spectra: `SPECTRAL_NM_380`, `SPECTRAL_NM380`, `SPECTRAL_380`, `NM380`, `NM_380`,
//!   `R_380`, any wavelengths within 360–830 nm in increasing order;
//! - colour: `LAB_L`, `LAB_A`, `LAB_B`; `XYZ_X`, `XYZ_Y`, `XYZ_Z`;
//! - gloss: `GLOSS_20`, `GLOSS_60`, `GLOSS_85` (any angle after `GLOSS_`);
//! - geometry per row: `GEOMETRY` or `MEASUREMENT_GEOMETRY` (a name such as
//!   `45as15`, `d:8 SCI`, `45:0`), or `ASPECULAR` / `ASPECULAR_ANGLE` (degrees) with
//!   `ILLUMINATION_ANGLE` (a field, a header keyword, or 45°).
//!
//! Header keywords understood: `ILLUMINANT`, `OBSERVER` and `WEIGHTING_FUNCTION`
//! (`"ILLUMINANT, D50"`, `"OBSERVER, 2 degree"`) for stated colours;
//! `MEASUREMENT_GEOMETRY` or `GEOMETRY` for every row without its own;
//! `ILLUMINATION_ANGLE`; `REFLECTANCE_SCALE`, `SPECTRAL_SCALE` or `SPECTRAL_UNITS`
//! (`PERCENT` or `FRACTION`) for the scale of the spectra, which is otherwise judged
//! from the data (any value above [`super::PERCENT_THRESHOLD`] means percent).
//!
//! Multi-angle files carry one row per sample and geometry: the geometry from a
//! field, else from the end of the sample name (`RED_45as15`, `Red 45as-15`,
//! `Red@45as110`), else from the header.

use std::collections::HashMap;

use super::{
    Format, GlossValue, Measurement, MeasurementError, ReflectanceScale, Sample, StatedColour,
    StatedValue, decide_scale, parse_geometry, parse_illuminant, parse_number, parse_observer,
};
use crate::colour::{Lab, Xyz};
use crate::measurement::{Geometry, ReadingProblem, Reflectance};

/// What is wrong at a line of a CGATS file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CgatsProblem {
    #[error("a quoted text is not closed")]
    UnclosedQuote,
    #[error("{keyword} needs a whole number, not {text:?}")]
    NotACount { keyword: String, text: String },
    #[error("BEGIN_DATA before any BEGIN_DATA_FORMAT")]
    DataBeforeFormat,
    #[error("no END_DATA_FORMAT after BEGIN_DATA_FORMAT: the file is truncated")]
    MissingEndDataFormat,
    #[error("no END_DATA after BEGIN_DATA: the file is truncated ({rows} rows read)")]
    MissingEndData { rows: usize },
    #[error("no BEGIN_DATA after END_DATA_FORMAT: the file is truncated")]
    MissingData,
    #[error("no BEGIN_DATA_FORMAT: not a CGATS data file")]
    NoDataFormat,
    #[error(
        "NUMBER_OF_FIELDS (line {declared_line}) is {declared}, but the data format lists {listed} fields"
    )]
    FieldCount {
        declared: usize,
        declared_line: usize,
        listed: usize,
    },
    #[error("NUMBER_OF_SETS (line {declared_line}) is {declared}, but the table has {found} rows")]
    SetCount {
        declared: usize,
        declared_line: usize,
        found: usize,
    },
    #[error("a row has {found} values, but the data format lists {expected} fields")]
    RowLength { found: usize, expected: usize },
    #[error("field {field}: the wavelength {wavelength_nm} nm is outside 360–830 nm")]
    WavelengthOutOfRange { field: String, wavelength_nm: f64 },
    #[error("spectral field {field} does not follow the one before it in increasing wavelength")]
    WavelengthOrder { field: String },
    #[error(transparent)]
    Reading(#[from] ReadingProblem),
    #[error("{field} is missing: {needed}")]
    IncompleteColour { field: String, needed: &'static str },
    #[error("{0} appears twice in the data format")]
    DuplicateField(String),
}

/// Splits a line into values: white space separates, double quotes keep spaces,
/// `#` outside quotes starts a comment.
fn tokens(line: &str) -> Result<Vec<String>, CgatsProblem> {
    let mut out = Vec::new();
    let mut chars = line.chars().peekable();
    while let Some(&c) = chars.peek() {
        if c.is_whitespace() {
            chars.next();
        } else if c == '#' {
            break;
        } else if c == '"' {
            chars.next();
            let mut text = String::new();
            loop {
                match chars.next() {
                    Some('"') => break,
                    Some(c) => text.push(c),
                    None => return Err(CgatsProblem::UnclosedQuote),
                }
            }
            out.push(text);
        } else {
            let mut text = String::new();
            while let Some(&c) = chars.peek() {
                if c.is_whitespace() {
                    break;
                }
                text.push(c);
                chars.next();
            }
            out.push(text);
        }
    }
    Ok(out)
}

/// The wavelength of a spectral field name, if it is one.
pub fn spectral_wavelength_nm(field: &str) -> Option<f64> {
    let upper = field.to_ascii_uppercase();
    [
        "SPECTRAL_NM_",
        "SPECTRAL_NM",
        "SPECTRAL_",
        "NM_",
        "NM",
        "R_",
    ]
    .iter()
    .find_map(|prefix| upper.strip_prefix(prefix))
    .and_then(|rest| rest.parse::<f64>().ok())
    .filter(|nm| nm.is_finite())
}

/// What a column holds.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Column {
    Name,
    Id,
    Spectral(f64),
    Lab(usize),
    Xyz(usize),
    Gloss(f64),
    Geometry,
    Aspecular,
    Illumination,
    Other,
}

fn column_of(field: &str) -> Column {
    let upper = field.to_ascii_uppercase();
    match upper.as_str() {
        "SAMPLE_NAME" => Column::Name,
        "SAMPLE_ID" => Column::Id,
        "LAB_L" => Column::Lab(0),
        "LAB_A" => Column::Lab(1),
        "LAB_B" => Column::Lab(2),
        "XYZ_X" => Column::Xyz(0),
        "XYZ_Y" => Column::Xyz(1),
        "XYZ_Z" => Column::Xyz(2),
        "GEOMETRY" | "MEASUREMENT_GEOMETRY" => Column::Geometry,
        "ASPECULAR" | "ASPECULAR_ANGLE" => Column::Aspecular,
        "ILLUMINATION_ANGLE" => Column::Illumination,
        _ => {
            if let Some(angle) = upper
                .strip_prefix("GLOSS_")
                .and_then(|a| a.parse::<f64>().ok())
            {
                Column::Gloss(angle)
            } else if let Some(nm) = spectral_wavelength_nm(&upper) {
                Column::Spectral(nm)
            } else {
                Column::Other
            }
        }
    }
}

/// One data row before the file's scale is known.
struct Row {
    line: usize,
    name: String,
    id: Option<String>,
    geometry: Geometry,
    spectrum: Option<(Vec<f64>, Vec<f64>)>,
    lab: Option<[f64; 3]>,
    xyz: Option<[f64; 3]>,
    gloss: Vec<GlossValue>,
}

/// One table's data format.
struct Table {
    fields: Vec<String>,
    columns: Vec<Column>,
    wavelengths_nm: Vec<f64>,
}

/// The header keywords seen so far: every value of each, with its line.
#[derive(Default)]
struct Header {
    values: HashMap<String, Vec<(usize, String)>>,
}

impl Header {
    fn last(&self, keys: &[&str]) -> Option<&(usize, String)> {
        keys.iter()
            .filter_map(|k| self.values.get(*k).and_then(|v| v.last()))
            .max_by_key(|(line, _)| *line)
    }

    fn all(&self, key: &str) -> impl Iterator<Item = &(usize, String)> {
        self.values.get(key).into_iter().flatten()
    }
}

const STRUCTURE: [&str; 6] = [
    "NUMBER_OF_FIELDS",
    "BEGIN_DATA_FORMAT",
    "END_DATA_FORMAT",
    "NUMBER_OF_SETS",
    "BEGIN_DATA",
    "END_DATA",
];

/// Reads a CGATS text; `file` names it in errors.
pub fn read_cgats(text: &str, file: &str) -> Result<Measurement, MeasurementError> {
    let at = |line: usize, problem: CgatsProblem| MeasurementError::Cgats {
        file: file.to_owned(),
        line,
        problem,
    };
    let lines: Vec<&str> = text.lines().map(|l| l.trim_end_matches('\r')).collect();
    let last_line = lines.len().max(1);

    let mut header = Header::default();
    let mut rows: Vec<Row> = Vec::new();
    let mut number_of_fields: Option<(usize, usize)> = None;
    let mut number_of_sets: Option<(usize, usize)> = None;
    let mut table: Option<Table> = None;
    let mut seen_content = false;
    let mut tables = 0;

    let count = |tokens: &[String], line: usize| -> Result<(usize, usize), MeasurementError> {
        let text = tokens.get(1).cloned().unwrap_or_default();
        text.parse::<usize>().map(|n| (n, line)).map_err(|_| {
            at(
                line,
                CgatsProblem::NotACount {
                    keyword: tokens[0].clone(),
                    text,
                },
            )
        })
    };

    let mut i = 0;
    while i < lines.len() {
        let line_no = i + 1;
        let toks = tokens(lines[i]).map_err(|p| at(line_no, p))?;
        i += 1;
        let Some(first) = toks.first() else { continue };
        let keyword = first.to_ascii_uppercase();
        if !seen_content {
            seen_content = true;
            // The identifier line (CGATS.17, IT8.7/2, …): one word that is no keyword.
            if toks.len() == 1 && !STRUCTURE.contains(&keyword.as_str()) {
                continue;
            }
        }
        match keyword.as_str() {
            "NUMBER_OF_FIELDS" => number_of_fields = Some(count(&toks, line_no)?),
            "NUMBER_OF_SETS" => number_of_sets = Some(count(&toks, line_no)?),
            "BEGIN_DATA_FORMAT" => {
                let start = line_no;
                let mut fields: Vec<String> = toks[1..].to_vec();
                let mut closed = false;
                if let Some(end) = fields
                    .iter()
                    .position(|f| f.eq_ignore_ascii_case("END_DATA_FORMAT"))
                {
                    fields.truncate(end);
                    closed = true;
                }
                let mut end_line = start;
                while !closed {
                    let Some(line) = lines.get(i) else {
                        return Err(at(start, CgatsProblem::MissingEndDataFormat));
                    };
                    end_line = i + 1;
                    i += 1;
                    let more = tokens(line).map_err(|p| at(end_line, p))?;
                    if more.first().is_some_and(|t| {
                        STRUCTURE.contains(&t.to_ascii_uppercase().as_str())
                            && !t.eq_ignore_ascii_case("END_DATA_FORMAT")
                    }) {
                        return Err(at(start, CgatsProblem::MissingEndDataFormat));
                    }
                    for t in more {
                        if t.eq_ignore_ascii_case("END_DATA_FORMAT") {
                            closed = true;
                            break;
                        }
                        fields.push(t);
                    }
                }
                if let Some((declared, declared_line)) = number_of_fields
                    && declared != fields.len()
                {
                    return Err(at(
                        end_line,
                        CgatsProblem::FieldCount {
                            declared,
                            declared_line,
                            listed: fields.len(),
                        },
                    ));
                }
                table = Some(data_format(fields).map_err(|p| at(start, p))?);
            }
            "BEGIN_DATA" => {
                let start = line_no;
                let Some(format) = table.take() else {
                    return Err(at(start, CgatsProblem::DataBeforeFormat));
                };
                tables += 1;
                let mut found = 0;
                loop {
                    let Some(line) = lines.get(i) else {
                        return Err(at(last_line, CgatsProblem::MissingEndData { rows: found }));
                    };
                    let row_line = i + 1;
                    i += 1;
                    let values = tokens(line).map_err(|p| at(row_line, p))?;
                    let Some(first) = values.first() else {
                        continue;
                    };
                    let upper = first.to_ascii_uppercase();
                    if upper == "END_DATA" {
                        if let Some((declared, declared_line)) = number_of_sets
                            && declared != found
                        {
                            return Err(at(
                                row_line,
                                CgatsProblem::SetCount {
                                    declared,
                                    declared_line,
                                    found,
                                },
                            ));
                        }
                        break;
                    }
                    if STRUCTURE.contains(&upper.as_str()) {
                        // A new table began where this one should have ended.
                        return Err(at(start, CgatsProblem::MissingEndData { rows: found }));
                    }
                    if i >= lines.len() && values.len() != format.fields.len() {
                        // A short last line with nothing after it: the file was cut.
                        return Err(at(row_line, CgatsProblem::MissingEndData { rows: found }));
                    }
                    found += 1;
                    let row = read_row(&format, &values, row_line, &header, rows.len() + 1)
                        .map_err(|p| at(row_line, p))?;
                    rows.push(row);
                }
                number_of_fields = None;
                number_of_sets = None;
            }
            "END_DATA" | "END_DATA_FORMAT" => {
                return Err(at(line_no, CgatsProblem::DataBeforeFormat));
            }
            _ => {
                let value = toks[1..].join(" ");
                header
                    .values
                    .entry(keyword)
                    .or_default()
                    .push((line_no, value));
            }
        }
    }
    if table.is_some() {
        return Err(at(last_line, CgatsProblem::MissingData));
    }
    if tables == 0 {
        return Err(at(last_line, CgatsProblem::NoDataFormat));
    }
    finish(rows, &header).map_err(|(line, p)| at(line, p))
}

fn data_format(fields: Vec<String>) -> Result<Table, CgatsProblem> {
    for (k, f) in fields.iter().enumerate() {
        if fields[..k].iter().any(|g| g.eq_ignore_ascii_case(f)) {
            return Err(CgatsProblem::DuplicateField(f.clone()));
        }
    }
    let columns: Vec<Column> = fields.iter().map(|f| column_of(f)).collect();
    let mut wavelengths_nm = Vec::new();
    for (field, column) in fields.iter().zip(&columns) {
        if let Column::Spectral(nm) = *column {
            let (lo, hi) = super::WAVELENGTH_RANGE_NM;
            if !(lo..=hi).contains(&nm) {
                return Err(CgatsProblem::WavelengthOutOfRange {
                    field: field.clone(),
                    wavelength_nm: nm,
                });
            }
            if wavelengths_nm.last().is_some_and(|&last| nm <= last) {
                return Err(CgatsProblem::WavelengthOrder {
                    field: field.clone(),
                });
            }
            wavelengths_nm.push(nm);
        }
    }
    for (kind, names) in [
        ("LAB", ["LAB_L", "LAB_A", "LAB_B"]),
        ("XYZ", ["XYZ_X", "XYZ_Y", "XYZ_Z"]),
    ] {
        let present: Vec<bool> = names
            .iter()
            .map(|n| fields.iter().any(|f| f.eq_ignore_ascii_case(n)))
            .collect();
        if present.iter().any(|p| *p)
            && let Some(missing) = present.iter().position(|p| !p)
        {
            return Err(CgatsProblem::IncompleteColour {
                field: names[missing].to_owned(),
                needed: if kind == "LAB" {
                    "LAB_L, LAB_A and LAB_B come together"
                } else {
                    "XYZ_X, XYZ_Y and XYZ_Z come together"
                },
            });
        }
    }
    Ok(Table {
        fields,
        columns,
        wavelengths_nm,
    })
}

fn number(field: &str, text: &str) -> Result<f64, CgatsProblem> {
    Ok(parse_number(field, text)?)
}

/// Splits a trailing geometry off a sample name ("RED_45as15" → "RED", 45as15).
fn geometry_suffix(name: &str) -> Option<(String, Geometry)> {
    let cut = name.rfind([' ', '_', '@'])?;
    let geometry = parse_geometry(&name[cut + 1..]).ok()?;
    let head = name[..cut].trim_end_matches([' ', '_', '@']);
    (!head.is_empty()).then(|| (head.to_owned(), geometry))
}

fn read_row(
    table: &Table,
    values: &[String],
    line: usize,
    header: &Header,
    ordinal: usize,
) -> Result<Row, CgatsProblem> {
    if values.len() != table.fields.len() {
        return Err(CgatsProblem::RowLength {
            found: values.len(),
            expected: table.fields.len(),
        });
    }
    let mut name = None;
    let mut id = None;
    let mut spectrum = Vec::with_capacity(table.wavelengths_nm.len());
    let mut lab = [f64::NAN; 3];
    let mut xyz = [f64::NAN; 3];
    let mut gloss = Vec::new();
    let mut geometry_text = None;
    let mut aspecular = None;
    let mut illumination = None;
    for ((field, column), text) in table.fields.iter().zip(&table.columns).zip(values) {
        match *column {
            Column::Name => name = Some(text.clone()),
            Column::Id => id = Some(text.clone()),
            Column::Spectral(_) => spectrum.push(number(field, text)?),
            Column::Lab(k) => lab[k] = number(field, text)?,
            Column::Xyz(k) => xyz[k] = number(field, text)?,
            Column::Gloss(angle_deg) => gloss.push(GlossValue {
                angle_deg,
                gu: number(field, text)?,
            }),
            Column::Geometry => geometry_text = Some(text.clone()),
            Column::Aspecular => aspecular = Some(number(field, text)?),
            Column::Illumination => illumination = Some(number(field, text)?),
            Column::Other => {}
        }
    }
    let (mut name, id) = match (name, id) {
        (Some(name), id) => (name, id),
        (None, Some(id)) => (id, None),
        (None, None) => (format!("row {ordinal}"), None),
    };
    let header_illumination = || -> Result<f64, CgatsProblem> {
        match header.last(&["ILLUMINATION_ANGLE"]) {
            Some((_, text)) => number("ILLUMINATION_ANGLE", text),
            None => Ok(45.0),
        }
    };
    let geometry = if let Some(text) = geometry_text {
        parse_geometry(&text).map_err(ReadingProblem::from)?
    } else if let Some(aspecular_deg) = aspecular {
        let illumination_deg = match illumination {
            Some(v) => v,
            None => header_illumination()?,
        };
        parse_geometry(&format!("{illumination_deg}as{aspecular_deg}"))
            .map_err(ReadingProblem::from)?
    } else if let Some((stripped, geometry)) = geometry_suffix(&name) {
        name = stripped;
        geometry
    } else if let Some((_, text)) = header.last(&["MEASUREMENT_GEOMETRY", "GEOMETRY"]) {
        parse_geometry(text).map_err(ReadingProblem::from)?
    } else {
        Geometry::Unspecified
    };
    let present = |v: [f64; 3]| (!v[0].is_nan()).then_some(v);
    Ok(Row {
        line,
        name,
        id,
        geometry,
        spectrum: (!table.wavelengths_nm.is_empty())
            .then(|| (table.wavelengths_nm.clone(), spectrum)),
        lab: present(lab),
        xyz: present(xyz),
        gloss,
    })
}

/// The scale a header states for the spectra, with the keyword as written.
fn header_scale(header: &Header) -> Option<(usize, ReflectanceScale, String)> {
    let (line, text) = header.last(&["REFLECTANCE_SCALE", "SPECTRAL_SCALE", "SPECTRAL_UNITS"])?;
    let upper = text.to_ascii_uppercase();
    let scale = if upper.contains("PERCENT") || upper.contains('%') || upper.trim() == "100" {
        ReflectanceScale::Percent
    } else if upper.contains("FRACTION") || upper.trim() == "1" || upper.contains("0-1") {
        ReflectanceScale::Fraction
    } else {
        return None;
    };
    Some((*line, scale, text.clone()))
}

fn finish(rows: Vec<Row>, header: &Header) -> Result<Measurement, (usize, CgatsProblem)> {
    // The conditions of stated colours: ILLUMINANT/OBSERVER, or WEIGHTING_FUNCTION.
    let weighting: Vec<&(usize, String)> = header.all("WEIGHTING_FUNCTION").collect();
    let illuminant_text = header.last(&["ILLUMINANT"]).cloned().or_else(|| {
        weighting
            .iter()
            .find(|(_, v)| v.to_ascii_uppercase().contains("ILLUMINANT"))
            .map(|v| (*v).clone())
    });
    let observer_text = header.last(&["OBSERVER"]).cloned().or_else(|| {
        weighting
            .iter()
            .find(|(_, v)| v.to_ascii_uppercase().contains("OBSERVER"))
            .map(|v| (*v).clone())
    });
    let illuminant = illuminant_text.as_ref().map(|(_, t)| parse_illuminant(t));
    let observer = observer_text.as_ref().and_then(|(_, t)| parse_observer(t));
    let has_spectra = rows.iter().any(|r| r.spectrum.is_some());
    let has_stated = rows.iter().any(|r| r.lab.is_some() || r.xyz.is_some());
    if let (Some(None), Some((line, text))) = (illuminant, &illuminant_text)
        && has_stated
        && !has_spectra
    {
        return Err((
            *line,
            ReadingProblem::UnknownIlluminant(text.clone()).into(),
        ));
    }
    // An illuminant Coatlab lacks, with spectra present: the stated colours are dropped
    // (the spectra give every colour), rather than labelled wrongly.
    let keep_stated = !matches!(illuminant, Some(None));
    let illuminant = illuminant.flatten();

    let max = rows
        .iter()
        .filter_map(|r| r.spectrum.as_ref())
        .flat_map(|(_, v)| v.iter().copied())
        .fold(f64::NEG_INFINITY, f64::max);
    let stated_scale = header_scale(header);
    let scale = if has_spectra {
        let line = stated_scale.as_ref().map_or(1, |(l, _, _)| *l);
        Some(
            decide_scale(stated_scale.map(|(_, s, t)| (s, t)), max)
                .map_err(|e| (line, ReadingProblem::from(e).into()))?,
        )
    } else {
        None
    };
    let divisor = match scale.as_ref().map(|s| s.scale) {
        Some(ReflectanceScale::Percent) => 100.0,
        _ => 1.0,
    };

    let samples = rows
        .into_iter()
        .map(|row| {
            let spectrum = row
                .spectrum
                .map(|(wavelengths_nm, values)| {
                    Reflectance::new(
                        wavelengths_nm,
                        values.into_iter().map(|v| v / divisor).collect(),
                    )
                })
                .transpose()
                .map_err(|e| (row.line, ReadingProblem::from(e).into()))?;
            let value = match (row.lab, row.xyz) {
                (Some([l, a, b]), _) => Some(StatedValue::Lab(Lab::new(l, a, b))),
                (None, Some([x, y, z])) => Some(StatedValue::Xyz(Xyz::new(x, y, z))),
                (None, None) => None,
            };
            Ok(Sample {
                name: row.name,
                id: row.id,
                geometry: row.geometry,
                spectrum,
                colour: value.filter(|_| keep_stated).map(|value| StatedColour {
                    value,
                    illuminant,
                    observer,
                }),
                gloss: row.gloss,
            })
        })
        .collect::<Result<Vec<_>, (usize, CgatsProblem)>>()?;
    Ok(Measurement {
        format: Format::Cgats,
        samples,
        reflectance_scale: scale,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_spectral_column_spelling_gives_its_wavelength() {
        for field in [
            "SPECTRAL_NM_380",
            "SPECTRAL_NM380",
            "nm380",
            "R_380",
            "NM_380",
        ] {
            assert_eq!(spectral_wavelength_nm(field), Some(380.0), "{field}");
        }
        for field in ["LAB_L", "SAMPLE_ID", "RGB_R", "R_X"] {
            assert_eq!(spectral_wavelength_nm(field), None, "{field}");
        }
    }

    #[test]
    fn quoted_values_keep_their_spaces_and_comments_end_a_line() {
        assert_eq!(
            tokens(r#"1 "Red metallic" 0.5 # note"#).expect("tokens"),
            ["1", "Red metallic", "0.5"]
        );
        assert_eq!(tokens(r#"1 "open"#), Err(CgatsProblem::UnclosedQuote));
    }

    #[test]
    fn a_geometry_suffix_is_split_off_the_name() {
        assert_eq!(
            geometry_suffix("RED_45as15"),
            Some(("RED".to_owned(), Geometry::directional(45.0, 15.0)))
        );
        assert_eq!(
            geometry_suffix("Deep blue 45as-15"),
            Some(("Deep blue".to_owned(), Geometry::directional(45.0, -15.0)))
        );
        assert_eq!(geometry_suffix("Panel_7"), None);
    }
}
