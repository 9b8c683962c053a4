//! `coatlab measure DESIGN`: what the virtual instruments read on a design — the
//! multi-angle colour table (CIELAB, D65/10°) and the gloss at 20°, 60°, 85° — and,
//! with `--target`, the design against a target design or a measured standard
//! (CGATS or CxF3) as a quality lab reports it: per geometry ΔL*, Δa*, Δb*, ΔC*,
//! ΔH*, the totals, pass or fail against `--tolerance`, and the CIE metamerism
//! index under A and F11.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::colour::tolerance::{METAMERIC_DE00, Tolerance};
use coatlab_core::design::PaintDesign;
use coatlab_core::instruments::{Measurement, measure};
use coatlab_core::measurement::{self, Format};
use coatlab_core::paint::model::PaintModel;
use coatlab_core::target::{Comparison, compare_designs, compare_to_standard};

use super::failure::{Classify, Failure};

#[derive(clap::Args, Debug)]
pub struct MeasureArgs {
    /// Paint design file (TOML).
    pub design: PathBuf,
    /// A target: a design file, or a measurement file (CGATS.17 text or CxF3 XML).
    #[arg(long)]
    pub target: Option<PathBuf>,
    /// The standard in a measurement file with several: its name (or id), or its
    /// number counting from 1.
    #[arg(long, value_name = "NAME|INDEX")]
    pub sample: Option<String>,
    /// Pass/fail limits: `[FORMULA:]LIMIT[,ANGLE=LIMIT…]`, FORMULA de00 (default),
    /// deab or cmc (2:1); e.g. `1`, `cmc:1.5`, `de00:1,15=1.5,110=2`. Default: the
    /// design file's `[tolerance]`, else `de00:1`.
    #[arg(long, value_name = "SPEC")]
    pub tolerance: Option<Tolerance>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

fn load_design(path: &Path) -> anyhow::Result<(PaintDesign, PaintModel, Measurement)> {
    let design = PaintDesign::load(path)?;
    let model = design
        .model(WavelengthGrid::reference())
        .with_context(|| format!("cannot build the paint model of {}", path.display()))
        .or_fail(Failure::Data)?;
    let measurement = measure(&model).or_fail(Failure::Internal)?;
    Ok((design, model, measurement))
}

/// What `--target` named.
enum Target {
    Design {
        name: String,
    },
    Measured {
        name: String,
        format: Format,
        scale: Option<String>,
    },
}

pub fn run(args: &MeasureArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let (design, model, readings) = load_design(&args.design)?;
    let tolerance = args
        .tolerance
        .clone()
        .or_else(|| design.tolerance.clone())
        .unwrap_or_default();
    let tolerance_source = match (&args.tolerance, &design.tolerance) {
        (Some(_), _) => "command line",
        (None, Some(_)) => "design",
        (None, None) => "default",
    };
    let mut target = None;
    if let Some(path) = &args.target {
        let file = path.display().to_string();
        let bytes = std::fs::read(path)
            .with_context(|| format!("cannot read {file}"))
            .or_fail(Failure::NoInput)?;
        if let Some(format) = measurement::sniff(&bytes) {
            let m = measurement::read(&bytes, &file).or_fail(Failure::Data)?;
            let standard = m
                .select(args.sample.as_deref())
                .with_context(|| format!("{file}: --sample"))
                .or_fail(Failure::Usage)?;
            let comparison = compare_to_standard(&model, &readings, &standard, &tolerance)
                .with_context(|| format!("{file}: cannot compare with sample {:?}", standard.name))
                .or_fail(Failure::Data)?;
            target = Some((
                Target::Measured {
                    name: standard.name.to_owned(),
                    format,
                    scale: m.reflectance_scale.as_ref().map(ToString::to_string),
                },
                comparison,
            ));
        } else {
            if args.sample.is_some() {
                return Err(Failure::Usage.error(format!(
                    "--sample chooses a standard in a measurement file; {file} is a design"
                )));
            }
            let (t, _, t_readings) = load_design(path)?;
            let comparison =
                compare_designs(&readings, &t_readings, &tolerance).or_fail(Failure::Internal)?;
            target = Some((Target::Design { name: t.name }, comparison));
        }
    } else if args.sample.is_some() {
        return Err(Failure::Usage.error("--sample needs --target"));
    }

    if args.json {
        let delta_e = target.as_ref().map(|(_, c)| {
            c.angles
                .iter()
                .map(|a| a.difference.de00)
                .collect::<Vec<_>>()
        });
        let (target_name, target_kind, target_format, scale) = match target.as_ref() {
            None => (None, None, None, None),
            Some((Target::Design { name }, _)) => (Some(name.clone()), Some("design"), None, None),
            Some((
                Target::Measured {
                    name,
                    format,
                    scale,
                },
                _,
            )) => (
                Some(name.clone()),
                Some("measurement"),
                Some(format.to_string()),
                scale.clone(),
            ),
        };
        let json = serde_json::json!({
            "design": design.name,
            "file": args.design.display().to_string(),
            "illumination_deg": coatlab_core::instruments::ILLUMINATION_DEG,
            "colour_space": "CIELAB D65/10°",
            "measurement": readings,
            "target": target_name,
            "target_kind": target_kind,
            "target_format": target_format,
            "reflectance_scale": scale,
            "delta_e00": delta_e,
            "comparison": target.as_ref().map(|(_, c)| c),
            "tolerance_source": target.as_ref().map(|_| tolerance_source),
        });
        serde_json::to_writer_pretty(&mut *out, &json).or_fail(Failure::Io)?;
        writeln!(out)?;
        return Ok(());
    }

    writeln!(out, "{} ({})", design.name, args.design.display())?;
    writeln!(out, "Multi-angle colour: illumination 45°, CIELAB D65/10°")?;
    writeln!(out, "aspecular  detector       L*       a*       b*")?;
    for a in &readings.angles {
        writeln!(
            out,
            "{:>8}°  {:>7}°  {:>7.2}  {:>7.2}  {:>7.2}",
            a.aspecular_deg, a.detector_deg, a.lab.l, a.lab.a, a.lab.b
        )?;
    }
    writeln!(
        out,
        "Gloss (ISO 2813 geometry; specular + body, ȳ under D65):"
    )?;
    for g in &readings.gloss {
        writeln!(
            out,
            "{:>8}  {:>7.1} GU  (specular alone {:.1} GU)",
            g.geometry.to_string(),
            g.total_gu,
            g.specular_gu
        )?;
    }
    if let Some((t, comparison)) = &target {
        write_comparison(out, t, comparison, args, tolerance_source)?;
    }
    Ok(())
}

fn write_comparison(
    out: &mut impl Write,
    target: &Target,
    c: &Comparison,
    args: &MeasureArgs,
    tolerance_source: &str,
) -> anyhow::Result<()> {
    let file = args
        .target
        .as_ref()
        .map(|p| p.display().to_string())
        .unwrap_or_default();
    writeln!(out)?;
    match target {
        Target::Design { name } => writeln!(out, "Against design {name} ({file})")?,
        Target::Measured {
            name,
            format,
            scale,
        } => {
            writeln!(out, "Against sample {name:?} of {file} ({format})")?;
            if let Some(scale) = scale {
                writeln!(out, "  {scale}")?;
            }
        }
    }
    write_verdicts(out, c, tolerance_source == "design")
}

/// The tolerance, the differences per geometry with their verdicts, the overall
/// result, the metamerism index, the gloss beside the target's and the notes of a
/// comparison: what `coatlab measure --target` and `coatlab fit` both report.
pub(super) fn write_verdicts(
    out: &mut impl Write,
    c: &Comparison,
    tolerance_from_design: bool,
) -> anyhow::Result<()> {
    let t = &c.tolerance;
    let mut limits = format!("{} ≤ {}", t.formula, t.default_limit);
    for (angle, limit) in &t.per_angle {
        limits.push_str(&format!(", {limit} at as{angle}°"));
    }
    let from = if tolerance_from_design {
        " (from the design file)"
    } else {
        ""
    };
    writeln!(
        out,
        "Tolerance: {limits}{from}; differences are design − target"
    )?;
    writeln!(
        out,
        "{:<12} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} {:>6}  verdict",
        "geometry", "ΔL*", "Δa*", "Δb*", "ΔC*", "ΔH*", "ΔE00", "ΔE*ab", "CMC2:1", "limit"
    )?;
    for a in &c.angles {
        let d = &a.difference;
        writeln!(
            out,
            "{:<12} {:>7.2} {:>7.2} {:>7.2} {:>7.2} {:>7.2} {:>7.2} {:>7.2} {:>7.2} {:>6.2}  {}",
            a.geometry.to_string(),
            d.dl,
            d.da,
            d.db,
            d.dc,
            d.dh,
            d.de00,
            d.de_ab,
            d.de_cmc,
            a.limit,
            if a.pass { "pass" } else { "FAIL" }
        )?;
    }
    for n in &c.not_comparable {
        writeln!(out, "{:<12} {}", n.geometry.to_string(), n.reason)?;
    }
    match c.pass {
        Some(true) => writeln!(out, "Result: PASS at every compared geometry")?,
        Some(false) => {
            let failed = c.angles.iter().filter(|a| !a.pass).count();
            writeln!(
                out,
                "Result: FAIL at {failed} of {} geometries",
                c.angles.len()
            )?;
        }
        None => writeln!(out, "Result: nothing to compare")?,
    }
    if c.angles.iter().any(|a| !a.metamerism.is_empty()) {
        writeln!(
            out,
            "Metamerism index (matched under D65, CIE multiplicative correction): ΔE00 (ΔE*ab)"
        )?;
        for a in c.angles.iter().filter(|a| !a.metamerism.is_empty()) {
            writeln!(
                out,
                "{:<12} {}",
                a.geometry.to_string(),
                a.metamerism_summary()
            )?;
        }
        if c.metameric {
            writeln!(
                out,
                "warning: the pair is metameric: the match changes by more than {METAMERIC_DE00} ΔE00 under another light"
            )?;
        }
    }
    for g in &c.gloss {
        writeln!(
            out,
            "Gloss {}°: design {:.1} GU, target {:.1} GU",
            g.angle_deg, g.design_gu, g.target_gu
        )?;
    }
    for note in &c.notes {
        writeln!(out, "note: {note}")?;
    }
    Ok(())
}
