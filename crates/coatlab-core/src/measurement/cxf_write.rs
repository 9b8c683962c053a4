//! Writing readings as an X-Rite CxF3 (ISO 17972-1) file, valid against X-Rite's
//! CxF3 core schema 3.0.018 (`vendor/cxf3/CxF3_Core.xsd`; CI validates every
//! preset's export with it) and read back by [`super::cxf`]: `FileInformation`
//! (creator, date), `Resources` with an `ObjectCollection` (one `Object` per sample
//! name: its `CreationDate`, its spectra and CIELAB in `ColorValues`, its gloss in
//! `PhysicalAttributes` as `Gloss` elements whose `Method` names the angle,
//! `specular gloss 60°`) and a `ColorSpecificationCollection` (one
//! `ColorSpecification` per geometry: D65/10°, `Method` `unknown` (the CIELAB is a
//! plain summation of the CIE 5 nm tables, which the schema's list of ASTM E308
//! methods lacks), `Spectrum_Reflectance`, the geometry as a `MultiAngle` of one
//! `BRDFAngle` (`IlluminationAngle`, `Aspecular`) or a `SphereGeometry`
//! (`Specular_Included`, `Specular_Excluded`), and the `WavelengthRange`), then an
//! optional `CustomResources` element for the writer's own namespaced content.
//!
//! The schema's limits are the writer's: spectra start at a whole wavelength in
//! 360–400 nm with a whole step, and L* ≥ 0; reflectance factors lie within its
//! (−0.1, 3) by construction (a [`super::Reflectance`] holds −0.05–1.5).
//! Numbers are written in Rust's shortest form that reads back to the same `f64`,
//! so the file reads back to the same numbers.

use std::fmt::Write;

use super::{Geometry, ReadingsWriteError, Sample, SpecularComponent, StatedValue};
pub use crate::io::markup::escape;

/// The CxF3 core namespace.
pub const CXF3_NAMESPACE: &str = "http://colorexchangeformat.com/CxF3-core";

/// The schema's `StartWLType`: the first wavelength of a spectrum, nm.
const START_WL_NM: std::ops::RangeInclusive<f64> = 360.0..=400.0;

/// The `Method` of a gloss reading at `angle_deg`: the schema's `Gloss` has no
/// angle of its own, so the method names it ([`super::cxf`] reads it back).
pub fn gloss_method(angle_deg: f64) -> String {
    format!("specular gloss {angle_deg}°")
}

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
                "<cc:MultiAngle><cc:BRDFAngle Notation=\"{illumination_deg}as{aspecular_deg}\">\
                 <cc:IlluminationAngle>{illumination_deg}</cc:IlluminationAngle>\
                 <cc:Aspecular>{aspecular_deg}</cc:Aspecular></cc:BRDFAngle></cc:MultiAngle>"
            ),
        )),
        Geometry::Sphere { specular } => {
            let (id, component) = match specular {
                SpecularComponent::Included => ("CS_SCI", "Specular_Included"),
                SpecularComponent::Excluded => ("CS_SCE", "Specular_Excluded"),
            };
            Some((
                id.to_owned(),
                format!("<cc:SphereGeometry>{component}</cc:SphereGeometry>"),
            ))
        }
        Geometry::Unspecified => None,
    }
}

/// `samples` as a CxF3 document. Every sample needs a stated geometry and a
/// spectrum on evenly spaced wavelengths within the schema's limits (module docs;
/// one `StartWL` and `Increment` per geometry); a stated colour is written only as
/// CIELAB, taken as D65/10°.
pub fn write_cxf(header: &CxfHeader<'_>, samples: &[Sample]) -> Result<String, ReadingsWriteError> {
    if samples.is_empty() {
        return Err(ReadingsWriteError::Empty);
    }
    // Specifications in order of first use: (id, geometry XML, start, step).
    let mut specs: Vec<(String, String, f64, f64)> = Vec::new();
    // Objects in order of first name: (name, ColorValues content, Gloss elements).
    let mut objects: Vec<(String, String, String)> = Vec::new();
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
        if !START_WL_NM.contains(&nm[0]) || nm[0].fract() != 0.0 {
            return Err(unwritable(
                "the spectrum starts elsewhere than at a whole wavelength in 360–400 nm (CxF3's StartWL)",
            ));
        }
        if step.fract() != 0.0 || !(1.0..=f64::from(i16::MAX)).contains(&step) {
            return Err(unwritable(
                "the wavelength step is not a whole number of nm (CxF3's Increment)",
            ));
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
        let i = match objects.iter().position(|(name, ..)| *name == s.name) {
            Some(i) => i,
            None => {
                objects.push((s.name.clone(), String::new(), String::new()));
                objects.len() - 1
            }
        };
        let (_, values, gloss) = &mut objects[i];
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
            if lab.l.is_nan() || lab.l < 0.0 {
                return Err(unwritable(
                    "a CIELAB L* below 0 or not a number, which CxF3 refuses",
                ));
            }
            let _ = write!(
                values,
                "\n          <cc:ColorCIELab ColorSpecification=\"{id}\"><cc:L>{}</cc:L>\
                 <cc:A>{}</cc:A><cc:B>{}</cc:B></cc:ColorCIELab>",
                lab.l, lab.a, lab.b
            );
        }
        for g in &s.gloss {
            let _ = write!(
                gloss,
                "\n          <cc:Gloss Method=\"{}\">{}</cc:Gloss>",
                gloss_method(g.angle_deg),
                g.gu
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
    for (k, (name, values, gloss)) in objects.iter().enumerate() {
        let _ = writeln!(
            xml,
            "      <cc:Object ObjectType=\"Standard\" Name=\"{}\" Id=\"O{}\">",
            escape(name),
            k + 1
        );
        // The schema's order: CreationDate, ColorValues, …, PhysicalAttributes.
        let _ = writeln!(
            xml,
            "        <cc:CreationDate>{}</cc:CreationDate>",
            escape(header.created)
        );
        let _ = writeln!(xml, "        <cc:ColorValues>{values}");
        let _ = writeln!(xml, "        </cc:ColorValues>");
        if !gloss.is_empty() {
            let _ = writeln!(xml, "        <cc:PhysicalAttributes>{gloss}");
            let _ = writeln!(xml, "        </cc:PhysicalAttributes>");
        }
        let _ = writeln!(xml, "      </cc:Object>");
    }
    let _ = writeln!(xml, "    </cc:ObjectCollection>");
    let _ = writeln!(xml, "    <cc:ColorSpecificationCollection>");
    for (id, geometry_xml, start, step) in &specs {
        let _ = writeln!(
            xml,
            "      <cc:ColorSpecification Id=\"{id}\">\n        <cc:TristimulusSpec>\
             <cc:Illuminant>D65</cc:Illuminant><cc:Observer>10_Degree</cc:Observer>\
             <cc:Method>unknown</cc:Method></cc:TristimulusSpec>\n        <cc:MeasurementSpec>\
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::Lab;
    use crate::measurement::{GlossValue, Reflectance, StatedColour};

    fn sample(start_nm: f64, step_nm: f64, l: f64) -> Sample {
        Sample {
            name: "Red".to_owned(),
            id: None,
            geometry: Geometry::directional(45.0, 15.0),
            spectrum: Some(Reflectance::uniform(start_nm, step_nm, vec![0.2, 0.4, 1.5]).unwrap()),
            colour: Some(StatedColour {
                value: StatedValue::Lab(Lab::new(l, 10.0, 5.0)),
                illuminant: None,
                observer: None,
            }),
            gloss: vec![GlossValue {
                angle_deg: 60.0,
                gu: 90.0,
            }],
        }
    }

    const HEADER: CxfHeader<'static> = CxfHeader {
        creator: "test",
        created: "2026-12-02T18:00:00Z",
        description: None,
        custom_resources: None,
    };

    #[test]
    fn what_cxf3_cannot_hold_is_refused_and_named() {
        let why = |s: Sample| match write_cxf(&HEADER, &[s]) {
            Err(ReadingsWriteError::Unwritable { why, .. }) => why,
            other => panic!("{other:?}"),
        };
        assert!(why(sample(410.0, 10.0, 50.0)).contains("StartWL"));
        assert!(why(sample(380.5, 10.0, 50.0)).contains("StartWL"));
        assert!(why(sample(380.0, 2.5, 50.0)).contains("Increment"));
        assert!(why(sample(380.0, 10.0, -1.0)).contains("L* below 0"));
        let text = write_cxf(&HEADER, &[sample(360.0, 10.0, 0.0)]).expect("within the limits");
        // The gloss in PhysicalAttributes after ColorValues, its angle in the Method.
        let values = text.find("</cc:ColorValues>").expect("values");
        let gloss = text
            .find("<cc:PhysicalAttributes>\n          <cc:Gloss Method=\"specular gloss 60°\">90</cc:Gloss>")
            .expect("gloss");
        assert!(values < gloss, "{text}");
    }
}
