//! Measurement files written from spectra, for the tests that read a design's
//! virtual measurement back: a multi-angle CGATS.17 table (one row per angle, the
//! geometry in a field, percent, said in the header) and the same as CxF3 (one
//! MultiAngle/BRDFAngle specification per angle, fractions; valid against the CxF3
//! core schema). Spectra are `(wavelengths, [(aspecular, values)])`, illumination 45°.

#![allow(dead_code, reason = "each test file uses some of the helpers")]

pub type Spectra = (Vec<f64>, Vec<(f64, Vec<f64>)>);

pub fn as_cgats(name: &str, (w, angles): &Spectra) -> String {
    let mut text = format!(
        "CGATS.17\nREFLECTANCE_SCALE PERCENT\nNUMBER_OF_FIELDS {}\nBEGIN_DATA_FORMAT\nSAMPLE_NAME GEOMETRY",
        w.len() + 2
    );
    for nm in w {
        text += &format!(" SPECTRAL_NM_{nm}");
    }
    text += &format!(
        "\nEND_DATA_FORMAT\nNUMBER_OF_SETS {}\nBEGIN_DATA\n",
        angles.len()
    );
    for (aspecular, r) in angles {
        text += &format!("\"{name}\" 45as{aspecular}");
        for v in r {
            text += &format!(" {}", v * 100.0);
        }
        text += "\n";
    }
    text + "END_DATA\n"
}

pub fn as_cxf(name: &str, (w, angles): &Spectra) -> String {
    let step = w[1] - w[0];
    let mut specs = String::new();
    let mut values = String::new();
    for (aspecular, r) in angles {
        specs += &format!(
            "<cc:ColorSpecification Id=\"ma{aspecular}\"><cc:MeasurementSpec>\
             <cc:MeasurementType>Spectrum_Reflectance</cc:MeasurementType><cc:GeometryChoice><cc:MultiAngle>\
             <cc:BRDFAngle Notation=\"45as{aspecular}\"><cc:IlluminationAngle>45</cc:IlluminationAngle>\
             <cc:Aspecular>{aspecular}</cc:Aspecular></cc:BRDFAngle></cc:MultiAngle></cc:GeometryChoice>\
             <cc:WavelengthRange StartWL=\"{}\" Increment=\"{step}\"/></cc:MeasurementSpec></cc:ColorSpecification>\n",
            w[0]
        );
        let r: Vec<String> = r.iter().map(f64::to_string).collect();
        values += &format!(
            "<cc:ReflectanceSpectrum ColorSpecification=\"ma{aspecular}\">{}</cc:ReflectanceSpectrum>\n",
            r.join(" ")
        );
    }
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<cc:CxF xmlns:cc=\"http://colorexchangeformat.com/CxF3-core\">\
         <cc:Resources><cc:ObjectCollection><cc:Object ObjectType=\"Standard\" Name=\"{name}\" Id=\"O1\">\
         <cc:CreationDate>2026-01-01T12:00:00Z</cc:CreationDate><cc:ColorValues>\n{values}\
         </cc:ColorValues></cc:Object></cc:ObjectCollection><cc:ColorSpecificationCollection>\n{specs}\
         </cc:ColorSpecificationCollection></cc:Resources></cc:CxF>\n"
    )
}

/// A CGATS file stating one CIELAB at 45°as45° under the given conditions
/// (`"D50"`, `"2 degree"`).
pub fn lab_only_cgats(name: &str, lab: [f64; 3], illuminant: &str, observer: &str) -> String {
    format!(
        "CGATS.17\nWEIGHTING_FUNCTION \"ILLUMINANT, {illuminant}\"\nWEIGHTING_FUNCTION \"OBSERVER, {observer}\"\nMEASUREMENT_GEOMETRY \"45as45\"\n\
         NUMBER_OF_FIELDS 4\nBEGIN_DATA_FORMAT\nSAMPLE_NAME LAB_L LAB_A LAB_B\nEND_DATA_FORMAT\n\
         NUMBER_OF_SETS 1\nBEGIN_DATA\n\"{name}\" {} {} {}\nEND_DATA\n",
        lab[0], lab[1], lab[2]
    )
}
