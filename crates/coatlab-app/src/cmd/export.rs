//! `coatlab export DESIGN --format cxf|cgats|gltf [--scene PATH] --out FILE`: the
//! design's virtual readings as a CxF3 or CGATS.17 file, or the car with the design
//! as a glTF clear-coat material (GLB), written atomically. For glTF the ΔE00 the
//! real-time material costs at each multi-angle geometry is printed (and stored in
//! the file). `coatlab_core::export` does the work; docs/export.md is the manual.

use std::io::Write;
use std::path::PathBuf;

use coatlab_core::design::PaintDesign;
use coatlab_core::export::{ExportError, ExportFormat, export_to_file};

use super::failure::{Classify, Failure};

#[derive(clap::Args, Debug)]
pub struct ExportArgs {
    /// The paint design file (TOML).
    pub design: PathBuf,
    /// What to write: cxf (CxF3 readings and the design), cgats (CGATS.17, one
    /// row per geometry) or gltf (the car with the design as a clear-coat
    /// material, binary .glb).
    #[arg(long)]
    pub format: String,
    /// glTF only: the scene (.glb or .gltf) to carry the design; the built-in car
    /// when left out. Its geometry and plain materials are written; textures are not.
    #[arg(long, value_name = "PATH")]
    pub scene: Option<PathBuf>,
    /// The file to write (.cxf; .txt, .cgats, .cgt or .it8; .glb).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

pub fn run(args: &ExportArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let format = ExportFormat::by_name(&args.format)
        .map_err(|e| Failure::Usage.error(format!("--format: {e}")))?;
    if args.scene.is_some() && format != ExportFormat::Gltf {
        return Err(Failure::Usage.error(format!(
            "--scene: only for --format gltf; a {format} export holds readings, not a scene"
        )));
    }
    let design = PaintDesign::load(&args.design)?;
    let scene = match &args.scene {
        Some(path) => Some(super::render::scene(Some(path), &[], None)?),
        None => None,
    };
    let exported =
        export_to_file(&design, format, scene.as_ref(), &args.out).map_err(|e| match e {
            ExportError::Extension { .. } => Failure::Usage.error(e.to_string()),
            ExportError::Write { .. } => Err::<(), _>(e).or_fail(Failure::CantCreate).unwrap_err(),
            _ => Err::<(), _>(e).or_fail(Failure::Data).unwrap_err(),
        })?;
    writeln!(
        out,
        "Wrote {} ({format}, {} bytes) of {:?}",
        args.out.display(),
        exported.bytes,
        design.name
    )?;
    if let Some(material) = &exported.material {
        let c = material.base_color;
        writeln!(
            out,
            "glTF material: base colour (linear sRGB) {:.4} {:.4} {:.4}, roughness {}, \
             clearcoat 1 with roughness {:.4}, ior {:.4}",
            c.red, c.green, c.blue, material.roughness, material.clearcoat_roughness, material.ior
        )?;
        let rows: Vec<String> = material
            .delta_e00
            .iter()
            .map(|c| format!("  {:<10} {:.3}", c.geometry.to_string(), c.delta_e00))
            .collect();
        writeln!(
            out,
            "ΔE00 of the real-time material against the design (D65, 2° observer):\n{}",
            rows.join("\n")
        )?;
    }
    Ok(())
}
