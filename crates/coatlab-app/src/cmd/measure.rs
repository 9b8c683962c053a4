//! `coatlab measure DESIGN`: what the virtual instruments read on a design — the
//! multi-angle colour table (CIELAB, D65/10°) and the gloss at 20°, 60°, 85°.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::design::PaintDesign;
use coatlab_core::instruments::{Measurement, delta_e_per_angle, measure};

use super::failure::{Classify, Failure};

#[derive(clap::Args, Debug)]
pub struct MeasureArgs {
    /// Paint design file (TOML).
    pub design: PathBuf,
    /// A target design: adds CIEDE2000 to it at each angle.
    #[arg(long)]
    pub target: Option<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

fn measure_file(path: &PathBuf) -> anyhow::Result<(PaintDesign, Measurement)> {
    let design = PaintDesign::load(path)?;
    let model = design
        .model(WavelengthGrid::reference())
        .with_context(|| format!("cannot build the paint model of {}", path.display()))
        .or_fail(Failure::Data)?;
    let measurement = measure(&model).or_fail(Failure::Internal)?;
    Ok((design, measurement))
}

pub fn run(args: &MeasureArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let (design, measurement) = measure_file(&args.design)?;
    let target = args.target.as_ref().map(measure_file).transpose()?;
    let delta_e = target
        .as_ref()
        .map(|(_, t)| delta_e_per_angle(&measurement, t));

    if args.json {
        let json = serde_json::json!({
            "design": design.name,
            "file": args.design.display().to_string(),
            "illumination_deg": coatlab_core::instruments::ILLUMINATION_DEG,
            "colour_space": "CIELAB D65/10°",
            "measurement": measurement,
            "target": target.as_ref().map(|(t, _)| t.name.clone()),
            "delta_e00": delta_e,
        });
        serde_json::to_writer_pretty(&mut *out, &json).or_fail(Failure::Io)?;
        writeln!(out)?;
        return Ok(());
    }

    writeln!(out, "{} ({})", design.name, args.design.display())?;
    writeln!(out, "Multi-angle colour: illumination 45°, CIELAB D65/10°")?;
    let header_extra = match &target {
        Some((t, _)) => format!("  dE00 to {}", t.name),
        None => String::new(),
    };
    writeln!(
        out,
        "aspecular  detector       L*       a*       b*{header_extra}"
    )?;
    for (i, a) in measurement.angles.iter().enumerate() {
        write!(
            out,
            "{:>8}°  {:>7}°  {:>7.2}  {:>7.2}  {:>7.2}",
            a.aspecular_deg, a.detector_deg, a.lab.l, a.lab.a, a.lab.b
        )?;
        if let Some(de) = &delta_e {
            write!(out, "  {:>6.2}", de[i])?;
        }
        writeln!(out)?;
    }
    writeln!(
        out,
        "Gloss (ISO 2813 geometry; specular + body, ȳ under D65):"
    )?;
    for g in &measurement.gloss {
        writeln!(
            out,
            "{:>8}  {:>7.1} GU  (specular alone {:.1} GU)",
            g.geometry.to_string(),
            g.total_gu,
            g.specular_gu
        )?;
    }
    Ok(())
}
