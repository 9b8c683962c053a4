//! `coatlab merge`: adds the film parts of one render (`coatlab render … --out
//! part.film --sample-range A..B`) into its image, exactly the image one
//! `coatlab render` of all the samples writes (see `render::film::part`).

use std::io::Write;
use std::path::PathBuf;

use coatlab_core::io::exr_write::{ExrCompression, ExrPrecision};
use coatlab_core::render::film::part::merge_parts;
use coatlab_core::render::film::{DisplaySettings, RenderRecord, ToneMapping};

use super::failure::Failure;
use super::render::{
    ImageOutput, out_extension, parse_exr_compression, parse_exr_precision, parse_tone_map, program,
};

#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// The .film parts: together they must hold every sample index of the
    /// render once, and come from the same render (scene, design, lighting,
    /// settings, size, seed, program version).
    #[arg(required = true, value_name = "PART")]
    pub parts: Vec<PathBuf>,
    /// Output: .png or .exr, as `coatlab render` writes them.
    #[arg(long)]
    pub out: PathBuf,
    /// EXR output only: float (32-bit, exact) or half [default: float].
    #[arg(long, value_parser = parse_exr_precision)]
    pub exr_precision: Option<ExrPrecision>,
    /// EXR output only: none, rle, zips, zip or piz [default: zip].
    #[arg(long, value_parser = parse_exr_compression)]
    pub exr_compression: Option<ExrCompression>,
    /// PNG output only: neutral, reinhard or clip, as `coatlab render --tone-map`
    /// (the exposure is the parts' own).
    #[arg(long, default_value = "neutral", value_parser = parse_tone_map)]
    pub tone_map: ToneMapping,
}

pub fn run(args: &MergeArgs, out: &mut impl Write) -> anyhow::Result<()> {
    let extension = out_extension(&args.out, &["png", "exr"], "the merged image")?;
    if extension != "exr" && (args.exr_precision.is_some() || args.exr_compression.is_some()) {
        return Err(Failure::Usage.error(format!(
            "--exr-precision/--exr-compression: only for .exr output, and --out {} is not one",
            args.out.display()
        )));
    }
    let (header, film) = merge_parts(&args.parts)?;
    if header.program != program() {
        return Err(Failure::Data.error(format!(
            "{}: made by {}, and this is {}: parts are merged by the program that made them",
            args.parts[0].display(),
            header.program,
            program()
        )));
    }
    let record = RenderRecord {
        design: Some(header.design.name.clone()),
        samples_per_pixel: Some(header.total_samples.to_string()),
        seed: Some(header.seed),
        lighting: Some(header.lighting.name.clone()),
    };
    let display = DisplaySettings {
        exposure_stops: header.exposure_stops,
        adapt_white: None,
        tone_mapping: args.tone_map,
    };
    ImageOutput {
        path: &args.out,
        exr_precision: args.exr_precision,
        exr_compression: args.exr_compression,
    }
    .write(&film, record, &display)?;
    writeln!(
        out,
        "wrote {} ({}x{}, {} spp from {} parts)",
        args.out.display(),
        header.width,
        header.height,
        header.total_samples,
        args.parts.len()
    )?;
    Ok(())
}
