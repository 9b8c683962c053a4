//! The measurement-file readers on the fixtures of `tests/data/measurements/`
//! (synthetic spectra, made by `tools/make_measurement_fixtures.py`): every
//! variant the readers claim, every malformed case refused with its place named,
//! and round trips of a reading written as CGATS and as CxF3.

use std::path::PathBuf;

use coatlab_core::colour::cie::{Illuminant, Observer};
use coatlab_core::measurement::{
    self, Format, Geometry, LabSource, Measurement, ReflectanceScale, Sample, ScaleEvidence,
    SpecularComponent, StatedValue,
};

fn path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/measurements")
        .join(name)
}

fn read(name: &str) -> Measurement {
    let bytes = std::fs::read(path(name)).expect("fixture");
    measurement::read(&bytes, name).unwrap_or_else(|e| panic!("{e}"))
}

fn refused(name: &str) -> String {
    let bytes = std::fs::read(path(name)).expect("fixture");
    match measurement::read(&bytes, name) {
        Ok(m) => panic!("{name} was read: {m:?}"),
        Err(e) => e.to_string(),
    }
}

/// The fixtures' analytic curves (tools/make_measurement_fixtures.py).
fn red(nm: f64) -> f64 {
    0.05 + 0.75 / (1.0 + (-(nm - 600.0) / 15.0).exp())
}

fn blue(nm: f64) -> f64 {
    0.04 + 0.36 * (-((nm - 450.0) / 40.0).powi(2)).exp()
}

fn assert_curve(m: &Measurement, name: &str, curve: fn(f64) -> f64, factor: f64) {
    let sample = m
        .samples
        .iter()
        .find(|s| s.name == name)
        .unwrap_or_else(|| panic!("{name} missing"));
    let spectrum = sample.spectrum.as_ref().expect("a spectrum");
    for (&nm, &v) in spectrum.wavelengths_nm().iter().zip(spectrum.factors()) {
        let want = (curve(nm) * factor).min(1.0);
        // 4 decimals in the file (of a fraction or of a percentage).
        assert!(
            (v - want).abs() <= 5e-5 + 1e-12,
            "{name} at {nm} nm: {v} vs {want}"
        );
    }
}

fn grid_of(m: &Measurement) -> (f64, f64, usize) {
    let w = m.samples[0]
        .spectrum
        .as_ref()
        .expect("spectrum")
        .wavelengths_nm();
    (w[0], w[1] - w[0], w.len())
}

#[test]
fn cgats_spectral_variants_read_to_fractions_on_their_own_grids() {
    // (file, grid): each file's name says its scale (`percent` or fractions) and
    // whether its header states it (`header`).
    let cases = [
        ("spectral_fraction_10nm.cgats", (380.0, 10.0, 36)),
        ("spectral_percent_5nm_crlf.txt", (400.0, 5.0, 61)),
        ("spectral_r_20nm.cgats", (360.0, 20.0, 20)),
        ("spectral_percent_header.cgats", (400.0, 10.0, 31)),
    ];
    for (file, grid) in cases {
        let (scale, from_header) = if file.contains("percent") {
            (ReflectanceScale::Percent, file.contains("header"))
        } else {
            (ReflectanceScale::Fraction, false)
        };
        let m = read(file);
        assert_eq!(m.format, Format::Cgats, "{file}");
        assert_eq!(grid_of(&m), grid, "{file}");
        let found = m.reflectance_scale.as_ref().expect("a scale");
        assert_eq!(found.scale, scale, "{file}");
        assert_eq!(
            matches!(found.evidence, ScaleEvidence::Header(_)),
            from_header,
            "{file}"
        );
        // The report says what was decided.
        let said = found.to_string();
        assert!(
            said.contains(if scale == ReflectanceScale::Percent {
                "percent"
            } else {
                "fractions"
            }),
            "{said}"
        );
    }
    // Names: SAMPLE_NAME where there is one (quoted, with spaces), else SAMPLE_ID.
    let m = read("spectral_fraction_10nm.cgats");
    let names: Vec<&str> = m.samples.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["Signal red", "Deep blue", "Grey"]);
    assert_eq!(m.samples[0].id.as_deref(), Some("1"));
    // The header's geometry applies to every row.
    assert!(m.samples.iter().all(|s| s.geometry
        == Geometry::Sphere {
            specular: SpecularComponent::Included
        }));
    assert_curve(&m, "Signal red", red, 1.0);
    let crlf = read("spectral_percent_5nm_crlf.txt");
    assert_curve(&crlf, "Signal red", red, 1.0);
    assert_curve(&crlf, "Deep blue", blue, 1.0);
    let ids = read("spectral_r_20nm.cgats");
    assert_eq!(ids.samples[1].name, "2");
    assert_curve(&ids, "1", red, 1.0);
    // A dark sample written in percent: only the header tells, and it is believed.
    let dark = read("spectral_percent_header.cgats");
    let v = dark.samples[0]
        .spectrum
        .as_ref()
        .expect("spectrum")
        .factors()[0];
    assert!((v - 0.012).abs() < 1e-9, "{v}");
}

#[test]
fn colour_only_files_carry_their_conditions() {
    let m = read("lab_only_d50.cgats");
    assert!(m.reflectance_scale.is_none());
    let red = &m.samples[0];
    let stated = red.colour.expect("Lab");
    assert_eq!(stated.illuminant, Some(Illuminant::D50));
    assert_eq!(stated.observer, Some(Observer::Cie1931TwoDegree));
    assert_eq!(
        stated.value,
        StatedValue::Lab(coatlab_core::colour::Lab::new(42.1, 58.3, 38.7))
    );
    let (lab, source) = red
        .lab(Illuminant::D50, Observer::Cie1931TwoDegree)
        .expect("under its own conditions");
    assert_eq!((lab.l, source), (42.1, LabSource::Stated));
    // No spectrum: it cannot be moved to D65.
    let e = red
        .lab(Illuminant::D65, Observer::Cie1964TenDegree)
        .expect_err("other conditions");
    assert!(e.to_string().contains("D50"), "{e}");

    let m = read("xyz_only_d65.cgats");
    let white = &m.samples[0];
    assert_eq!(white.name, "white");
    let (lab, source) = white
        .lab(Illuminant::D65, Observer::Cie1964TenDegree)
        .expect("XYZ to Lab");
    assert_eq!(source, LabSource::Stated);
    // The CIE's D65/10° white point against the tables' own: within rounding.
    assert!(
        (lab.l - 100.0).abs() < 0.01 && lab.a.abs() < 0.1 && lab.b.abs() < 0.1,
        "{lab:?}"
    );
}

fn flop(aspecular: f64) -> f64 {
    match aspecular as i32 {
        -15 => 1.9,
        15 => 1.6,
        25 => 1.25,
        45 => 1.0,
        75 => 0.82,
        110 => 0.74,
        _ => panic!("no flop for {aspecular}"),
    }
}

/// Each reading of `name` has its angle's flop of `curve`, at the six angles.
fn assert_multi_angle(m: &Measurement, name: &str, curve: fn(f64) -> f64) {
    let standard = m.select(Some(name)).expect("the standard");
    let angles: Vec<f64> = standard
        .readings
        .iter()
        .map(|r| match r.geometry {
            Geometry::Directional {
                illumination_deg: 45.0,
                aspecular_deg,
            } => aspecular_deg,
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(angles, [-15.0, 15.0, 25.0, 45.0, 75.0, 110.0], "{name}");
    for r in &standard.readings {
        let single = Measurement {
            format: m.format,
            samples: vec![(*r).clone()],
            reflectance_scale: None,
        };
        let aspecular = r
            .geometry
            .detector_deg()
            .map(|d| 45.0 - d)
            .expect("directional");
        assert_curve(&single, name, curve, flop(aspecular));
    }
}

#[test]
fn multi_angle_geometry_comes_from_a_field_the_name_or_the_aspecular_column() {
    let fields = read("multi_angle_geometry_field.cgats");
    assert_eq!(fields.standards().len(), 2);
    assert_multi_angle(&fields, "Signal red", red);
    assert_multi_angle(&fields, "Deep blue", blue);
    let names = read("multi_angle_in_names.cgats");
    assert_eq!(names.standards().len(), 1);
    assert_multi_angle(&names, "RED", red);
    let aspecular = read("multi_angle_aspecular_field.cgats");
    assert_multi_angle(&aspecular, "RED", red);
    let gloss: Vec<f64> = aspecular
        .samples
        .iter()
        .flat_map(|s| &s.gloss)
        .map(|g| g.gu)
        .collect();
    assert!(gloss.contains(&92.0));
}

#[test]
fn cxf_multi_angle_sphere_and_45_0_read_like_the_cgats_files() {
    let m = read("multi_angle.cxf");
    assert_eq!(m.format, Format::Cxf3);
    assert_eq!(m.samples.len(), 12);
    assert_multi_angle(&m, "Signal red", red);
    assert_multi_angle(&m, "Deep blue", blue);
    // The same curves as the CGATS file, to the last digit.
    let cgats = read("multi_angle_geometry_field.cgats");
    for (a, b) in m.samples.iter().zip(&cgats.samples) {
        assert_eq!(
            (&a.name, a.geometry, &a.spectrum),
            (&b.name, b.geometry, &b.spectrum)
        );
    }
    // Lab beside the 45° spectrum, under the specification's D65/10°; the gloss.
    let red = m.select(Some("R1")).expect("by id");
    let at_45 = red
        .readings
        .iter()
        .find(|r| r.geometry == Geometry::directional(45.0, 45.0))
        .expect("45as45");
    let stated = at_45.colour.expect("Lab");
    assert_eq!(
        (stated.illuminant, stated.observer),
        (Some(Illuminant::D65), Some(Observer::Cie1964TenDegree))
    );
    let gloss: Vec<(f64, f64)> = red
        .readings
        .iter()
        .flat_map(|r| &r.gloss)
        .map(|g| (g.angle_deg, g.gu))
        .collect();
    assert_eq!(gloss, [(20.0, 88.5), (60.0, 93.0)]);

    let m = read("sphere_and_45_0.cxf");
    let geometries: Vec<String> = m.samples.iter().map(|s| s.geometry.to_string()).collect();
    assert_eq!(geometries, ["d:8° SCI", "d:8° SCE", "45°as45°"]);
    assert_eq!(grid_of(&m), (360.0, 5.0, 85));
}

#[test]
fn cxf_in_coatlabs_earlier_layout_reads_like_the_schema_valid_files() {
    // The same readings as multi_angle.cxf and sphere_and_45_0.cxf, laid out as
    // Coatlab's exports wrote them before they followed the CxF3 schema.
    let earlier = read("earlier_layout.cxf");
    let valid: Vec<Sample> = [read("multi_angle.cxf"), read("sphere_and_45_0.cxf")]
        .into_iter()
        .flat_map(|m| m.samples)
        .collect();
    assert_eq!(earlier.samples.len(), 15);
    assert_eq!(earlier.samples, valid);
}

#[test]
fn samples_are_chosen_by_name_id_or_number() {
    let m = read("multi_angle.cxf");
    assert_eq!(m.select(Some("Deep blue")).expect("name").name, "Deep blue");
    assert_eq!(m.select(Some("B2")).expect("id").name, "Deep blue");
    let red = read("multi_angle_geometry_field.cgats");
    assert_eq!(red.select(Some("2")).expect("number").name, "Deep blue");
    let e = red.select(None).expect_err("two standards");
    assert!(e.to_string().contains("Signal red, Deep blue"), "{e}");
    let e = red.select(Some("Green")).expect_err("no such");
    assert!(e.to_string().contains("\"Green\""), "{e}");
    assert_eq!(
        read("multi_angle_in_names.cgats")
            .select(None)
            .expect("one")
            .name,
        "RED"
    );
}

#[test]
fn every_malformed_file_is_refused_with_its_place_named() {
    // (file, what the message must contain)
    let cases: [(&str, &[&str]); 10] = [
        ("bad_truncated.cgats", &["line 11", "truncated"]),
        ("bad_missing_end_data.cgats", &["no END_DATA", "3 rows"]),
        (
            "bad_number_of_fields.cgats",
            &["line 7", "NUMBER_OF_FIELDS (line 4) is 31", "32 fields"],
        ),
        (
            "bad_number_of_sets.cgats",
            &["line 13", "NUMBER_OF_SETS (line 8) is 4", "3 rows"],
        ),
        (
            "bad_not_a_number.cgats",
            &["line 1", "SPECTRAL_NM_450", "\"0.1O7\", not a number"],
        ),
        (
            "bad_geometry.cgats",
            &["line 11", "unknown geometry \"d:45\""],
        ),
        ("bad_truncated.cxf", &["element <CxF>", "truncated"]),
        (
            "bad_geometry.cxf",
            &["element <ConeGeometry>", "unknown geometry element"],
        ),
        (
            "bad_number.cxf",
            &["element <ReflectanceSpectrum>", "\"0.42.00\", not a number"],
        ),
        (
            "bad_xml_bomb.cxf",
            &["line 2", "<!DOCTYPE>", "DTD", "XML bomb"],
        ),
    ];
    for (file, wanted) in cases {
        let message = refused(file);
        assert!(message.starts_with(file), "{file}: {message}");
        for w in wanted {
            assert!(message.contains(w), "{file}: {message:?} lacks {w:?}");
        }
    }
}

/// Text replacements (from, to) that spoil a file.
type Changes<'a> = &'a [(&'a str, &'a str)];

#[test]
fn inconsistent_or_out_of_range_content_is_refused() {
    let good = std::fs::read_to_string(path("spectral_fraction_10nm.cgats")).expect("fixture");
    let lab = std::fs::read_to_string(path("lab_only_d50.cgats")).expect("fixture");
    let cxf = std::fs::read_to_string(path("multi_angle.cxf")).expect("fixture");
    // (the file, the changes that spoil it, what the refusal says): the header says
    // fractions over percentages; a wavelength outside the CIE tables; wavelength
    // columns out of order; a negative reflectance; LAB_L without LAB_A; colours
    // under an illuminant Coatlab lacks, with no spectrum; a CxF colour naming a
    // specification that is not there, or one of several BRDFAngles without naming
    // which; a CxF gloss whose angle is not stated.
    #[rustfmt::skip]
    let cases: [(&str, Changes, &[&str]); 9] = [
        (&good, &[("CREATED", "REFLECTANCE_SCALE \"FRACTION\"\nCREATED"), ("0.7999", "79.99")], &["the header says fractions"]),
        (&good, &[("SPECTRAL_NM_380", "SPECTRAL_NM_340")], &["SPECTRAL_NM_340", "line 8"]),
        (&good, &[("SPECTRAL_NM_390", "SPECTRAL_NM_370")], &["SPECTRAL_NM_370"]),
        (&good, &[(" 0.0500 ", " -0.5000 ")], &["-0.5"]),
        (&lab, &[(" LAB_A", " LAB_Q")], &["LAB_A is missing"]),
        (&lab, &[("ILLUMINANT, D50", "ILLUMINANT, C")], &["\"ILLUMINANT, C\"", "line 4"]),
        (&cxf, &[("ColorSpecification=\"CS_45as15\"", "ColorSpecification=\"CS_nope\"")], &["CS_nope"]),
        (&cxf, &[(" Name=\"45as75\"", "")], &["line 13", "BRDFAngles 45as75, 45as110", "Notation"]),
        (&cxf, &[("Method=\"60\"", "Method=\"gloss\"")], &["<Gloss>", "\"gloss\""]),
    ];
    for (text, changes, wanted) in cases {
        let mut spoilt = text.to_owned();
        for (from, to) in changes {
            spoilt = spoilt.replacen(from, to, 1);
        }
        let file = if text == cxf { "x.cxf" } else { "x.cgats" };
        let e = measurement::read(spoilt.as_bytes(), file)
            .expect_err(&format!("{changes:?}"))
            .to_string();
        for w in wanted {
            assert!(e.contains(w), "{changes:?}: {e}");
        }
    }
    // Nothing at all, and something that is neither format.
    assert!(measurement::read(b"", "e.cgats").is_err());
    let e = measurement::read(b"wavelength_nm,a\n400,0.1\n", "s.csv").expect_err("csv");
    assert!(e.to_string().contains("neither CGATS"), "{e}");
    // With spectra, colours under an unknown illuminant are dropped instead (the
    // spectra give them).
    let text = cxf.replace(
        "<cc:Illuminant>D65</cc:Illuminant>",
        "<cc:Illuminant>C</cc:Illuminant>",
    );
    let m = measurement::read(text.as_bytes(), "x.cxf").expect("spectra suffice");
    assert!(
        read("multi_angle.cxf")
            .samples
            .iter()
            .any(|s| s.colour.is_some())
    );
    assert!(
        m.samples
            .iter()
            .all(|s| s.colour.is_none() && s.spectrum.is_some())
    );
}

// ---------------------------------------------------------------------------------
// Round trips: a measurement written by the test's own small writers (the formats
// as documented in docs/measurements.md) and read back.

/// The illumination and aspecular angles of a directional reading (the writers
/// below write no other).
fn directional(s: &Sample) -> (f64, f64) {
    match s.geometry {
        Geometry::Directional {
            illumination_deg,
            aspecular_deg,
        } => (illumination_deg, aspecular_deg),
        other => panic!("directional readings only, not {other}"),
    }
}

fn write_cgats(m: &Measurement, percent: bool) -> String {
    let w = m.samples[0]
        .spectrum
        .as_ref()
        .expect("spectrum")
        .wavelengths_nm()
        .to_vec();
    let mut text = String::from("CGATS.17\r\nORIGINATOR \"round trip\"\r\n");
    text += &format!(
        "NUMBER_OF_FIELDS {}\r\nBEGIN_DATA_FORMAT\r\nSAMPLE_NAME GEOMETRY",
        w.len() + 2
    );
    for nm in &w {
        text += &format!(" nm{nm}");
    }
    text += &format!(
        "\r\nEND_DATA_FORMAT\r\nNUMBER_OF_SETS {}\r\nBEGIN_DATA\r\n",
        m.samples.len()
    );
    for s in &m.samples {
        let (illumination_deg, aspecular_deg) = directional(s);
        text += &format!("\"{}\" {illumination_deg}as{aspecular_deg}", s.name);
        for v in s.spectrum.as_ref().expect("spectrum").factors() {
            text += &format!(" {}", if percent { v * 100.0 } else { *v });
        }
        text += "\r\n";
    }
    text + "END_DATA\r\n"
}

fn write_cxf(m: &Measurement) -> String {
    let mut specs = String::new();
    let mut objects = String::new();
    for (k, s) in m.samples.iter().enumerate() {
        let (illumination_deg, aspecular_deg) = directional(s);
        let spectrum = s.spectrum.as_ref().expect("spectrum");
        let w = spectrum.wavelengths_nm();
        specs += &format!(
            "<ColorSpecification Id=\"cs{k}\"><MeasurementSpec><GeometryChoice><MultiAngle \
             IlluminationAngle=\"{illumination_deg}\" Aspecular=\"{aspecular_deg}\"/></GeometryChoice>\
             <WavelengthRange StartWL=\"{}\" Increment=\"{}\"/></MeasurementSpec></ColorSpecification>",
            w[0],
            w[1] - w[0]
        );
        let values: Vec<String> = spectrum.factors().iter().map(f64::to_string).collect();
        objects += &format!(
            "<Object Name=\"{}\" Id=\"o{k}\"><ColorValues><ReflectanceSpectrum ColorSpecification=\"cs{k}\">{}</ReflectanceSpectrum></ColorValues></Object>",
            s.name,
            values.join(" ")
        );
    }
    format!(
        "<?xml version=\"1.0\"?><CxF xmlns=\"http://colorexchangeformat.com/CxF3-core\"><Resources>\
         <ObjectCollection>{objects}</ObjectCollection><ColorSpecificationCollection>{specs}\
         </ColorSpecificationCollection></Resources></CxF>"
    )
}

#[test]
fn a_multi_angle_measurement_round_trips_through_cgats_and_cxf() {
    let original = read("multi_angle_geometry_field.cgats");
    let same = |back: &Measurement, how: &str| {
        assert_eq!(back.samples.len(), original.samples.len(), "{how}");
        for (a, b) in original.samples.iter().zip(&back.samples) {
            assert_eq!((&a.name, a.geometry), (&b.name, b.geometry), "{how}");
            let (sa, sb) = (
                a.spectrum.as_ref().expect("a"),
                b.spectrum.as_ref().expect("b"),
            );
            assert_eq!(sa.wavelengths_nm(), sb.wavelengths_nm(), "{how}");
            for (x, y) in sa.factors().iter().zip(sb.factors()) {
                // Percent and back: one rounding of ×100 and ÷100.
                assert!((x - y).abs() <= 1e-15, "{how}: {x} vs {y}");
            }
        }
    };
    for percent in [false, true] {
        let text = write_cgats(&original, percent);
        let back = measurement::read(text.as_bytes(), "round.cgats").expect("reads back");
        assert_eq!(
            back.reflectance_scale.as_ref().map(|s| s.scale),
            Some(if percent {
                ReflectanceScale::Percent
            } else {
                ReflectanceScale::Fraction
            })
        );
        same(&back, if percent { "CGATS, percent" } else { "CGATS" });
    }
    let back = measurement::read(write_cxf(&original).as_bytes(), "round.cxf").expect("reads back");
    same(&back, "CxF3");
}

// ---------------------------------------------------------------------------------
// Robustness: a file cut anywhere, or with any byte changed, is read or refused,
// never a panic.

const FIXTURES: [&str; 5] = [
    "multi_angle_geometry_field.cgats",
    "spectral_percent_5nm_crlf.txt",
    "multi_angle.cxf",
    "sphere_and_45_0.cxf",
    "earlier_layout.cxf",
];

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(400))]

    #[test]
    fn damaged_files_are_read_or_refused_without_panic(
        which in 0..FIXTURES.len(),
        cut in 0.0f64..1.0,
        at in 0.0f64..1.0,
        byte in proptest::prelude::any::<u8>(),
    ) {
        let mut bytes = std::fs::read(path(FIXTURES[which])).expect("fixture");
        let i = ((bytes.len() as f64) * at) as usize;
        if let Some(b) = bytes.get_mut(i) {
            *b = byte;
        }
        bytes.truncate(((bytes.len() as f64) * cut) as usize);
        if let Err(e) = measurement::read(&bytes, "damaged") {
            proptest::prop_assert!(e.to_string().starts_with("damaged"), "{}", e);
        }
    }
}

#[test]
fn a_designs_readings_written_as_cgats_read_back_to_the_same_numbers() {
    use coatlab_core::design::presets;
    use coatlab_core::measurement::GlossValue;
    use coatlab_core::measurement::Reflectance;
    use coatlab_core::measurement::cgats_write::{CgatsWriteError, write_cgats};
    let design = presets::by_slug("signal-red").expect("preset").design;
    let model = design
        .model(coatlab_core::colour::spectrum::WavelengthGrid::reference())
        .expect("model");
    let m = coatlab_core::instruments::measure(&model).expect("spectral");
    let gloss: Vec<GlossValue> = m
        .gloss
        .iter()
        .map(|g| GlossValue {
            angle_deg: f64::from(u32::from(g.geometry)),
            gu: g.total_gu,
        })
        .collect();
    let reading = |geometry, factors: &[f64]| Sample {
        name: "Signal red".to_owned(),
        id: None,
        geometry,
        spectrum: Some(Reflectance::new(m.wavelength_nm.clone(), factors.to_vec()).expect("valid")),
        colour: None,
        gloss: gloss.clone(),
    };
    let samples: Vec<Sample> = m
        .angles
        .iter()
        .map(|a| {
            reading(
                Geometry::directional(45.0, a.aspecular_deg),
                &a.reflectance_factor,
            )
        })
        .chain(
            m.sphere
                .iter()
                .map(|s| reading(s.geometry, &s.reflectance_factor)),
        )
        .collect();
    let text = write_cgats("coatlab test", &samples).expect("writable");
    let back = measurement::read(text.as_bytes(), "red.cgats").expect("readable");
    assert_eq!(back.format, Format::Cgats);
    assert_eq!(back.samples, samples, "{text}");
    // What cannot be written is refused by name.
    let mut unstated = samples.clone();
    unstated[1].geometry = Geometry::Unspecified;
    let e = write_cgats("t", &unstated).expect_err("no geometry");
    assert!(matches!(e, CgatsWriteError::Unwritable { .. }), "{e}");
    assert!(e.to_string().contains("Signal red"), "{e}");
    assert_eq!(write_cgats("t", &[]), Err(CgatsWriteError::Empty));
}
