//! `coatlab fit --target FILE --out DESIGN.toml`: the pigment albedo ρ(λ) — and,
//! with `--free`, the coat's gloss, h, k and n — that reproduce a measured standard
//! (CGATS.17 or CxF3), written as a design file, with the fitted design against the
//! standard as `coatlab measure --target` reports it. The method is
//! `coatlab_core::fit`'s; docs/measurements.md ("Fitting a design") states it.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use coatlab_core::colour::tolerance::Tolerance;
use coatlab_core::design::{PaintDesign, presets};
use coatlab_core::fit::{self, FitError, FitRequest, Method, parse_free};
use coatlab_core::measurement;

use super::failure::{Classify, Failure};

#[derive(clap::Args, Debug)]
pub struct FitArgs {
    /// The measured standard: a CGATS.17 or CxF3 file.
    #[arg(long)]
    pub target: PathBuf,
    /// The standard in a file with several: its name (or id), or its number
    /// counting from 1.
    #[arg(long, value_name = "NAME|INDEX")]
    pub sample: Option<String>,
    /// The design whose clear coat and gloss are kept (default: the first preset,
    /// Signal red).
    #[arg(long, value_name = "DESIGN")]
    pub start: Option<PathBuf>,
    /// What the fit may change, comma-separated: `rho` (the pigment albedo),
    /// `gloss`, `h` (coat thickness), `k` (coat absorption, the start's k(λ)
    /// scaled), `n` (coat index, the start's n(λ) shifted); the rest is the start
    /// design's.
    #[arg(long, value_name = "LIST", default_value = "rho")]
    pub free: String,
    /// Where to write the fitted design (atomically).
    #[arg(long, value_name = "DESIGN.toml")]
    pub out: PathBuf,
    /// Pass/fail limits of the report, as `coatlab measure --tolerance` (default:
    /// the start design's `[tolerance]`, else `de00:1`); the written design keeps
    /// the start design's.
    #[arg(long, value_name = "SPEC")]
    pub tolerance: Option<Tolerance>,
    /// Print JSON instead of a report.
    #[arg(long)]
    pub json: bool,
}

fn usage_or_data(error: FitError) -> anyhow::Error {
    let failure = match error {
        FitError::UnknownParameter { .. } => Failure::Usage,
        FitError::Design(_) => return anyhow::Error::new(error),
        _ => Failure::Data,
    };
    Err::<(), _>(error).or_fail(failure).unwrap_err()
}

fn start_design(path: Option<&Path>) -> anyhow::Result<PaintDesign> {
    match path {
        Some(path) => Ok(PaintDesign::load(path)?),
        None => presets::all()
            .into_iter()
            .next()
            .map(|p| p.design)
            .ok_or_else(|| Failure::Internal.error("no preset designs")),
    }
}

pub fn run(args: &FitArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let free = parse_free(&args.free).map_err(usage_or_data)?;
    let start = start_design(args.start.as_deref())?;
    let file = args.target.display().to_string();
    let bytes = std::fs::read(&args.target)
        .with_context(|| format!("cannot read {file}"))
        .or_fail(Failure::NoInput)?;
    let Some(format) = measurement::sniff(&bytes) else {
        return Err(Failure::Data.error(format!(
            "{file}: not a CGATS.17 or CxF3 measurement file; coatlab fit fits a design to a measured standard"
        )));
    };
    let m = measurement::read(&bytes, &file).or_fail(Failure::Data)?;
    let standard = m
        .select(args.sample.as_deref())
        .with_context(|| format!("{file}: --sample"))
        .or_fail(Failure::Usage)?;
    let mut fitted = fit::fit(&start, &standard, &FitRequest { free })
        .map_err(usage_or_data)
        .with_context(|| format!("{file}: cannot fit sample {:?}", standard.name))?;
    fitted.design.name = standard.name.to_owned();
    let names = free.names();
    let kept: Vec<&str> = [
        ("pigment albedo", free.rho),
        ("gloss", free.gloss),
        ("h", free.thickness),
        ("k", free.absorption),
        ("n", free.index),
    ]
    .iter()
    .filter(|(_, on)| !on)
    .map(|(name, _)| *name)
    .collect();
    let kept_text = if kept.is_empty() {
        "nothing".to_owned()
    } else {
        kept.join(", ")
    };
    fitted.design.description = Some(format!(
        "Fitted by coatlab fit to sample {:?} of {} ({format}), free: {}; kept from {:?}: {kept_text}.",
        standard.name,
        args.target
            .file_name()
            .map_or(file.clone(), |n| n.to_string_lossy().into_owned()),
        names.join(", "),
        start.name
    ));
    let tolerance = args
        .tolerance
        .clone()
        .or_else(|| start.tolerance.clone())
        .unwrap_or_default();
    let report = fit::report(&fitted, &standard, &tolerance)
        .map_err(usage_or_data)
        .with_context(|| format!("{file}: cannot compare the fitted design"))?;
    fitted.design.save(&args.out)?;

    let method = match fitted.method {
        Method::ClosedForm => "the closed form, per wavelength (one geometry)".to_owned(),
        Method::LeastSquares => {
            let gloss = if free.coat() && !report.comparison.gloss.is_empty() {
                " and the gloss readings"
            } else {
                ""
            };
            let weight = fitted
                .smoothness_weight
                .map_or("ρ held".to_owned(), |w| format!("smoothness weight {w}"));
            format!(
                "bounded least squares over {} geometries{gloss}, {weight}",
                report.spectral_rms.len()
            )
        }
        Method::SmoothestMetamer => format!(
            "the smoothest ρ(λ) with the stated colours, smoothness weight {}",
            fit::SMOOTHNESS_WEIGHT
        ),
    };
    if args.json {
        let json = serde_json::json!({
            "target": file,
            "target_format": format.to_string(),
            "sample": standard.name,
            "start": start.name,
            "free": free,
            "coat": fitted.coat,
            "method": fitted.method,
            "smoothness_weight": fitted.smoothness_weight,
            "wavelength_nm": fitted.wavelength_nm,
            "albedo": fitted.albedo,
            "unreachable": fitted.unreachable,
            "notes": fitted.notes,
            "comparison": report.comparison,
            "spectral_rms": report.spectral_rms.iter().map(|(g, rms)| serde_json::json!({
                "geometry": g.to_string(),
                "rms": rms,
            })).collect::<Vec<_>>(),
            "out": args.out.display().to_string(),
        });
        serde_json::to_writer_pretty(&mut *out, &json).or_fail(Failure::Io)?;
        writeln!(out)?;
        return Ok(());
    }

    writeln!(
        out,
        "Fitted sample {:?} of {file} ({format})",
        standard.name
    )?;
    writeln!(
        out,
        "Start: {} (free: {}; kept: {kept_text})",
        start.name,
        names.join(", ")
    )?;
    writeln!(out, "Method: {method}")?;
    let (lo, hi) = (
        fitted.wavelength_nm.first().copied().unwrap_or(f64::NAN),
        fitted.wavelength_nm.last().copied().unwrap_or(f64::NAN),
    );
    writeln!(
        out,
        "ρ(λ): {} values, {lo}–{hi} nm, from {:.4} to {:.4}",
        fitted.albedo.len(),
        fitted.albedo.iter().copied().fold(f64::INFINITY, f64::min),
        fitted
            .albedo
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max),
    )?;
    for p in &fitted.coat {
        writeln!(out, "{p}")?;
    }
    let from_design = args.tolerance.is_none() && start.tolerance.is_some();
    super::measure::write_verdicts(out, &report.comparison, from_design)?;
    if !report.spectral_rms.is_empty() {
        let cells: Vec<String> = report
            .spectral_rms
            .iter()
            .map(|(g, rms)| format!("{g} {rms:.6}"))
            .collect();
        writeln!(out, "Spectral RMS: {}", cells.join(", "))?;
    }
    if !fitted.unreachable.is_empty() {
        writeln!(
            out,
            "The target cannot be reached at {} wavelength(s) and geometries:",
            fitted.unreachable.len()
        )?;
        for u in &fitted.unreachable {
            writeln!(out, "  {u}")?;
        }
    }
    for note in &fitted.notes {
        writeln!(out, "note: {note}")?;
    }
    writeln!(out, "Wrote {}", args.out.display())?;
    Ok(())
}
