//! A design as CxF3: its virtual readings ([`super::virtual_readings`]) in the
//! core namespace, and the design itself in `CustomResources`, in Coatlab's own
//! namespace [`DESIGN_NAMESPACE`] (schema in `docs/export.md`):
//!
//! ```xml
//! <cl:PaintDesign xmlns:cl="urn:coatlab:cxf:paint-design:1" Name="Signal red"
//!                 Format="coatlab-paint-design" Version="1">
//!   <cl:Albedo StartWL="380" Increment="5">0.05 0.05 …</cl:Albedo>
//!   <cl:RefractiveIndex StartWL="380" Increment="5">1.53 …</cl:RefractiveIndex>
//!   <cl:AbsorptionPerUm StartWL="380" Increment="5">0.0004 …</cl:AbsorptionPerUm>
//!   <cl:ThicknessUm>45</cl:ThicknessUm>
//!   <cl:Gloss Angle="20" Lobe="normalised">88</cl:Gloss>
//!   <cl:DesignFile MediaType="application/toml">format = "coatlab-paint-design" …</cl:DesignFile>
//! </cl:PaintDesign>
//! ```
//!
//! The sampled tables are for other programs (ρ, n and k on the reference grid);
//! `DesignFile` is the design file itself, which [`design_from_cxf`] reads back.

use std::fmt::Write;

use roxmltree::{Document, ParsingOptions};

use super::{CREATOR, ExportError, virtual_readings};
use crate::colour::spectrum::WavelengthGrid;
use crate::design::{DesignError, FORMAT_NAME, FORMAT_VERSION, PaintDesign};
use crate::measurement::cxf::NODES_LIMIT;
use crate::measurement::cxf_write::{CxfHeader, escape, write_cxf};

/// The namespace of Coatlab's custom CxF3 section, versioned by its last part.
pub const DESIGN_NAMESPACE: &str = "urn:coatlab:cxf:paint-design:1";

/// The design's `cl:PaintDesign` element (see the module docs).
pub fn design_section(design: &PaintDesign) -> String {
    let grid = WavelengthGrid::reference();
    let (start, step) = (grid.start_nm(), grid.step_nm());
    let mut xml = String::new();
    let _ = writeln!(
        xml,
        "    <cl:PaintDesign xmlns:cl=\"{DESIGN_NAMESPACE}\" Name=\"{}\" Format=\"{FORMAT_NAME}\" Version=\"{FORMAT_VERSION}\">",
        escape(&design.name)
    );
    for (element, values) in [
        ("Albedo", design.albedo_on(&grid)),
        ("RefractiveIndex", design.refractive_index_on(&grid)),
        ("AbsorptionPerUm", design.absorption_on(&grid)),
    ] {
        let text: Vec<String> = values.values().iter().map(f64::to_string).collect();
        let _ = writeln!(
            xml,
            "      <cl:{element} StartWL=\"{start}\" Increment=\"{step}\">{}</cl:{element}>",
            text.join(" ")
        );
    }
    let _ = writeln!(
        xml,
        "      <cl:ThicknessUm>{}</cl:ThicknessUm>",
        design.thickness_um
    );
    let _ = writeln!(
        xml,
        "      <cl:Gloss Angle=\"{}\" Lobe=\"{}\">{}</cl:Gloss>",
        design.gloss.geometry.angle_deg(),
        design.lobe.name(),
        design.gloss.gu
    );
    let _ = writeln!(
        xml,
        "      <cl:DesignFile MediaType=\"application/toml\">{}</cl:DesignFile>",
        escape(&design.to_toml_string())
    );
    xml.push_str("    </cl:PaintDesign>");
    xml
}

/// The design's readings and the design itself as a CxF3 document; `created` is
/// the `CreationDate` (an `xs:dateTime`).
pub fn to_cxf(design: &PaintDesign, created: &str) -> Result<String, ExportError> {
    let samples = virtual_readings(design)?;
    let section = design_section(design);
    let description = format!(
        "The virtual instruments' readings of the paint design {:?}: multi-angle 45° at \
         aspecular 15°, 25°, 45°, 75°, 110°; sphere d:8° SCI and SCE; gloss at 20°, 60°, 85°. \
         The design itself is in CustomResources ({DESIGN_NAMESPACE}).",
        design.name
    );
    let header = CxfHeader {
        creator: CREATOR,
        created,
        description: Some(&description),
        custom_resources: Some(&section),
    };
    Ok(write_cxf(&header, &samples)?)
}

/// Why a CxF3 file's Coatlab section could not be read.
#[derive(Debug, thiserror::Error)]
pub enum DesignSectionError {
    #[error("{file}: not XML: {message}")]
    Xml { file: String, message: String },
    #[error("{file}, line {line}: {error}")]
    Design {
        file: String,
        line: u32,
        error: DesignError,
    },
}

/// The design a CxF3 file carries in Coatlab's section (`None` where it has
/// none); `file` names it in errors.
pub fn design_from_cxf(text: &str, file: &str) -> Result<Option<PaintDesign>, DesignSectionError> {
    let options = ParsingOptions {
        allow_dtd: false,
        nodes_limit: NODES_LIMIT,
        ..ParsingOptions::default()
    };
    let doc = Document::parse_with_options(text, options).map_err(|e| DesignSectionError::Xml {
        file: file.to_owned(),
        message: e.to_string(),
    })?;
    let Some(node) = doc.descendants().find(|n| {
        n.is_element()
            && n.tag_name().name() == "DesignFile"
            && n.tag_name().namespace() == Some(DESIGN_NAMESPACE)
    }) else {
        return Ok(None);
    };
    let source = format!("{file} (CustomResources)");
    PaintDesign::from_toml_str(node.text().unwrap_or_default(), &source)
        .map(Some)
        .map_err(|error| DesignSectionError::Design {
            file: file.to_owned(),
            line: doc.text_pos_at(node.range().start).row,
            error,
        })
}
