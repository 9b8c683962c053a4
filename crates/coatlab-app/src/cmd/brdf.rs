//! `coatlab brdf`: the body BRDF and the directional albedo of grey parameters, CSV
//! in, CSV out.
//!
//! | column | unit | range | meaning |
//! | --- | --- | --- | --- |
//! | `n` | — | finite, ≥ 1 | refractive index of the clear coat |
//! | `rho` | — | [0, 1] | diffuse albedo ρ of the pigment layer |
//! | `kh` | — | finite, ≥ 0 | optical depth τ = k·h of the coat |
//! | `theta_i_deg` | degrees | [0, 90] | polar angle of incidence (90 = grazing) |
//! | `theta_o_deg` | degrees | [0, 90] | polar angle of the outgoing direction |
//! | `dphi_deg` | degrees | finite | φo − φi (180 = plane of incidence, mirror side) |
//!
//! The columns may come in any order; other columns pass through unchanged, in their
//! input position. Two columns are appended to each row:
//!
//! - `f_body`, 1/sr: the body term of spec 4.1 (without the cosine factor). It does
//!   not depend on `dphi_deg`, which is only validated.
//! - `albedo`: the directional albedo at θi of the whole model with the ideal mirror
//!   as its specular part, R(μi) + ∫ f_body cos θo dωo. It is 1 for ρ = 1, τ = 0
//!   (white furnace) and at grazing incidence for n > 1.
//!
//! The coat integrals C(n, τ) and E(n, τ) cost about 10 µs each, so they are
//! computed once per distinct (n, kh) pair; a sweep over angles costs almost nothing
//! per row.

use std::collections::HashMap;
use std::f64::consts::PI;
use std::io::{Read, Write};

use anyhow::{Context, bail};
use coatlab_core::paint::coat::{attenuation, body_brdf, c_integral, escape_integral_scaled};
use coatlab_core::paint::fresnel::{cos_refracted, reflectance, transmittance};

const INPUT_COLUMNS: [&str; 6] = ["n", "rho", "kh", "theta_i_deg", "theta_o_deg", "dphi_deg"];
const OUTPUT_COLUMNS: [&str; 2] = ["f_body", "albedo"];

/// One row's parameters, validated.
#[derive(Debug, Clone, Copy)]
struct Row {
    n: f64,
    rho: f64,
    kh: f64,
    theta_i_deg: f64,
    theta_o_deg: f64,
}

/// The coat integrals of one (n, τ): C of spec 4.1 and the escape factor
/// E = 2π∫₀¹ T(μ) e^{−τ/μ′} μ dμ that the body albedo needs.
#[derive(Debug, Clone, Copy)]
struct CoatIntegrals {
    c: f64,
    escape: f64,
}

impl CoatIntegrals {
    fn new(n: f64, tau: f64) -> Self {
        Self {
            c: c_integral(n, tau),
            escape: escape_integral_scaled(n, tau) * (-tau).exp(),
        }
    }
}

/// C and E per distinct (n, τ), keyed on their bit patterns.
#[derive(Debug, Default)]
struct CoatCache(HashMap<(u64, u64), CoatIntegrals>);

impl CoatCache {
    fn get(&mut self, n: f64, tau: f64) -> CoatIntegrals {
        // + 0.0 folds −0 into +0, so both share one entry.
        let key = ((n + 0.0).to_bits(), (tau + 0.0).to_bits());
        *self
            .0
            .entry(key)
            .or_insert_with(|| CoatIntegrals::new(n, tau))
    }
}

/// cos θ for θ in degrees, as sin(90° − θ): exactly 0 at grazing and 1 at normal
/// incidence (cos(π/2) in floating point is 6e-17).
fn cos_deg(theta_deg: f64) -> f64 {
    (90.0 - theta_deg).to_radians().sin()
}

/// f_body and the albedo of one row.
fn evaluate(row: &Row, coat: CoatIntegrals) -> (f64, f64) {
    let Row {
        n, rho, kh: tau, ..
    } = *row;
    let cos_i = cos_deg(row.theta_i_deg);
    let cos_o = cos_deg(row.theta_o_deg);
    let f_body = body_brdf::<f64>(rho, n, tau, coat.c, cos_i, cos_o);
    // coat::body_albedo with the cached C and E (it recomputes both on every call).
    let through_i = transmittance(cos_i, n) * attenuation(tau, cos_refracted(cos_i, n));
    let body_numerator = rho * through_i * coat.escape;
    let body_albedo = if body_numerator == 0.0 {
        0.0
    } else {
        body_numerator / (n * n * (PI - rho * coat.c))
    };
    (f_body, reflectance(cos_i, n) + body_albedo)
}

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
    for column in OUTPUT_COLUMNS {
        if names.contains(&column) {
            bail!("stdin already has a \"{column}\" column; rename or remove it");
        }
    }
    let mut index = [0; 6];
    let mut missing = Vec::new();
    for (slot, column) in index.iter_mut().zip(INPUT_COLUMNS) {
        let mut positions = names
            .iter()
            .enumerate()
            .filter(|(_, name)| **name == column)
            .map(|(position, _)| position);
        match (positions.next(), positions.next()) {
            (Some(position), None) => *slot = position,
            (Some(_), Some(_)) => bail!("stdin header has column \"{column}\" more than once"),
            (None, _) => missing.push(column),
        }
    }
    if !missing.is_empty() {
        bail!(
            "stdin header lacks column(s) {}; expected {}",
            missing.join(", "),
            INPUT_COLUMNS.join(",")
        );
    }

    let mut cache = CoatCache::default();
    let mut writer = csv::Writer::from_writer(out);
    writer.write_record(header.iter().chain(OUTPUT_COLUMNS))?;
    for (row_index, record) in reader.records().enumerate() {
        let row_number = row_index + 1;
        let record = record.with_context(|| format!("stdin row {row_number}: cannot read CSV"))?;
        let line = record.position().map_or(0, csv::Position::line);
        if record.len() != header.len() {
            bail!(
                "stdin row {row_number} (line {line}): {} fields, but the header has {}",
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
                    "stdin row {row_number} (line {line}), column \"{column}\": cannot read {text:?} as a finite number"
                ),
            };
            if let Err(constraint) = check(column, *value) {
                bail!("stdin row {row_number} (line {line}), column \"{column}\": {constraint}");
            }
        }
        let [n, rho, kh, theta_i_deg, theta_o_deg, _dphi_deg] = values;
        let row = Row {
            n,
            rho,
            kh,
            theta_i_deg,
            theta_o_deg,
        };
        let (f_body, albedo) = evaluate(&row, cache.get(n, kh));
        if !(f_body.is_finite() && albedo.is_finite()) {
            bail!(
                "stdin row {row_number} (line {line}): the model gave f_body = {f_body}, albedo = {albedo} (a bug: please report these parameters)"
            );
        }
        writer.write_record(
            record
                .iter()
                .chain([f_body.to_string().as_str(), albedo.to_string().as_str()]),
        )?;
    }
    writer.flush()?;
    Ok(())
}

/// The range each input column must lie in; `value` is already finite.
fn check(column: &str, value: f64) -> Result<(), String> {
    match column {
        "n" if value < 1.0 => Err(format!(
            "{value} is below 1; a refractive index must be ≥ 1"
        )),
        "rho" if !(0.0..=1.0).contains(&value) => Err(format!("{value} is outside [0, 1]")),
        "kh" if value < 0.0 => Err(format!(
            "{value} is negative; the optical depth k·h must be ≥ 0"
        )),
        "theta_i_deg" | "theta_o_deg" if !(0.0..=90.0).contains(&value) => {
            Err(format!("{value} is outside [0, 90] degrees"))
        }
        _ => Ok(()),
    }
}
