//! Writing readings as an X-Rite CxF3 (ISO 17972-1) file, the form [`super::cxf`]
//! reads and the CxF3 core schema lays out: `FileInformation` (creator, date),
//! `Resources` with an `ObjectCollection` (one `Object` per sample name, its
//! spectra and CIELAB in `ColorValues`, its gloss as `Gloss` elements with an
//! `Angle`) and a `ColorSpecificationCollection` (one `ColorSpecification` per
//! geometry: D65/10°, `Spectrum_Reflectance`, the geometry as `MultiAngle`
//! (`IlluminationAngle`, `Aspecular`) or `SphereGeometry`
//! (`SpecularComponentIncluded`), and the `WavelengthRange`), then an optional
//! `CustomResources` element for the writer's own namespaced content.
//!
//! Numbers are written in Rust's shortest form that reads back to the same `f64`,
//! so the file reads back to the same numbers.

use std::fmt::Write;

use super::{Geometry, ReadingsWriteError, Sample, SpecularComponent, StatedValue};
pub use crate::io::markup::escape;

/// The CxF3 core namespace.
pub const CXF3_NAMESPACE: &str = "http://colorexchangeformat.com/CxF3-core";

/// What goes into the file besides the readings.
#[derive(Debug, Clone, PartialEq)]
pub struct CxfHeader<'a> {
    /// `FileInformation/Creator`.
    pub creator: &'a str,
    /// `FileInformation/CreationDate`, an `xs:dateTime` (`2026-12-02T18:00:00Z`).
    pub created: &'a str,
    /// `FileInformation/Description`.
    pub description: Option<&'a str>,
    /// Elements of another namespace placed in `CustomResources` as they are (the
    /// caller declares the namespace on them).
    pub custom_resources: Option<&'a str>,
}

/// The `Id` of a geometry's `ColorSpecification` and its `GeometryChoice` content.
fn specification(geometry: Geometry) -> Option<(String, String)> {
    match geometry {
        Geometry::Directional {
            illumination_deg,
            aspecular_deg,
        } => Some((
            format!("CS_{illumination_deg}as{aspecular_deg}"),
            format!(
                "<cc:MultiAngle><cc:IlluminationAngle>{illumination_deg}</cc:IlluminationAngle>\
                 <cc:Aspecular>{aspecular_deg}</cc:Aspecular></cc:MultiAngle>"
            ),
        )),
        Geometry::Sphere { specular } => {
            let (id, included) = match specular {
                SpecularComponent::Included => ("CS_SCI", true),
                SpecularComponent::Excluded => ("CS_SCE", false),
            };
            Some((
                id.to_owned(),
                format!(
                    "<cc:SphereGeometry><cc:SpecularComponentIncluded>{included}\
                     </cc:SpecularComponentIncluded></cc:SphereGeometry>"
                ),
            ))
        }
        Geometry::Unspecified => None,
    }
}

/// `samples` as a CxF3 document. Every sample needs a stated geometry and a
/// spectrum on evenly spaced wavelengths (one `StartWL` and `Increment` per
/// geometry); a stated colour is written only as CIELAB, taken as D65/10°.
pub fn write_cxf(header: &CxfHeader<'_>, samples: &[Sample]) -> Result<String, ReadingsWriteError> {
    if samples.is_empty() {
        return Err(ReadingsWriteError::Empty);
    }
    // Specifications in order of first use: (id, geometry XML, start, step).
    let mut specs: Vec<(String, String, f64, f64)> = Vec::new();
    // Objects in order of first name: (name, ColorValues content).
    let mut objects: Vec<(String, String)> = Vec::new();
    for s in samples {
        let unwritable = |why| ReadingsWriteError::Unwritable {
            name: s.name.clone(),
            geometry: s.geometry,
            why,
        };
        let (id, geometry_xml) =
            specification(s.geometry).ok_or_else(|| unwritable("no geometry"))?;
        let spectrum = s
            .spectrum
            .as_ref()
            .ok_or_else(|| unwritable("no spectrum"))?;
        let nm = spectrum.wavelengths_nm();
        let step = if nm.len() > 1 { nm[1] - nm[0] } else { 1.0 };
        let even = nm
            .iter()
            .enumerate()
            .all(|(i, w)| (w - (nm[0] + step * i as f64)).abs() <= 1e-9 * w.abs());
        if !even {
            return Err(unwritable("wavelengths not evenly spaced"));
        }
        match specs.iter().find(|(sid, ..)| *sid == id) {
            Some((_, _, start, increment)) if (*start, *increment) != (nm[0], step) => {
                return Err(unwritable(
                    "other wavelengths than another reading of this geometry",
                ));
            }
            Some(_) => {}
            None => specs.push((id.clone(), geometry_xml, nm[0], step)),
        }
        let i = match objects.iter().position(|(name, _)| *name == s.name) {
            Some(i) => i,
            None => {
                objects.push((s.name.clone(), String::new()));
                objects.len() - 1
            }
        };
        let values = &mut objects[i].1;
        let _ = write!(
            values,
            "\n          <cc:ReflectanceSpectrum ColorSpecification=\"{id}\" StartWL=\"{}\">",
            nm[0]
        );
        for (k, v) in spectrum.factors().iter().enumerate() {
            let _ = write!(values, "{}{v}", if k == 0 { "" } else { " " });
        }
        values.push_str("</cc:ReflectanceSpectrum>");
        if let Some(colour) = s.colour
            && let StatedValue::Lab(lab) = colour.value
        {
            let _ = write!(
                values,
                "\n          <cc:ColorCIELab ColorSpecification=\"{id}\"><cc:L>{}</cc:L>\
                 <cc:A>{}</cc:A><cc:B>{}</cc:B></cc:ColorCIELab>",
                lab.l, lab.a, lab.b
            );
        }
        for g in &s.gloss {
            let _ = write!(
                values,
                "\n          <cc:Gloss Angle=\"{}\">{}</cc:Gloss>",
                g.angle_deg, g.gu
            );
        }
    }

    let mut xml = String::new();
    let _ = writeln!(xml, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>");
    let _ = writeln!(xml, "<cc:CxF xmlns:cc=\"{CXF3_NAMESPACE}\">");
    let _ = writeln!(xml, "  <cc:FileInformation>");
    let _ = writeln!(
        xml,
        "    <cc:Creator>{}</cc:Creator>",
        escape(header.creator)
    );
    let _ = writeln!(
        xml,
        "    <cc:CreationDate>{}</cc:CreationDate>",
        escape(header.created)
    );
    if let Some(d) = header.description {
        let _ = writeln!(xml, "    <cc:Description>{}</cc:Description>", escape(d));
    }
    let _ = writeln!(xml, "  </cc:FileInformation>");
    let _ = writeln!(xml, "  <cc:Resources>");
    let _ = writeln!(xml, "    <cc:ObjectCollection>");
    for (k, (name, values)) in objects.iter().enumerate() {
        let _ = writeln!(
            xml,
            "      <cc:Object ObjectType=\"Standard\" Name=\"{}\" Id=\"O{}\">",
            escape(name),
            k + 1
        );
        let _ = writeln!(xml, "        <cc:ColorValues>{values}");
        let _ = writeln!(xml, "        </cc:ColorValues>");
        let _ = writeln!(xml, "      </cc:Object>");
    }
    let _ = writeln!(xml, "    </cc:ObjectCollection>");
    let _ = writeln!(xml, "    <cc:ColorSpecificationCollection>");
    for (id, geometry_xml, start, step) in &specs {
        let _ = writeln!(
            xml,
            "      <cc:ColorSpecification Id=\"{id}\">\n        <cc:TristimulusSpec>\
             <cc:Illuminant>D65</cc:Illuminant><cc:Observer>10_Degree</cc:Observer>\
             <cc:Method>E308</cc:Method></cc:TristimulusSpec>\n        <cc:MeasurementSpec>\
             <cc:MeasurementType>Spectrum_Reflectance</cc:MeasurementType>\
             <cc:GeometryChoice>{geometry_xml}</cc:GeometryChoice>\
             <cc:WavelengthRange StartWL=\"{start}\" Increment=\"{step}\"/></cc:MeasurementSpec>\n      \
             </cc:ColorSpecification>"
        );
    }
    let _ = writeln!(xml, "    </cc:ColorSpecificationCollection>");
    let _ = writeln!(xml, "  </cc:Resources>");
    if let Some(custom) = header.custom_resources {
        let _ = writeln!(
            xml,
            "  <cc:CustomResources>\n{custom}\n  </cc:CustomResources>"
        );
    }
    xml.push_str("</cc:CxF>\n");
    Ok(xml)
}
