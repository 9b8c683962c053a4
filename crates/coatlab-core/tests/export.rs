//! Exports of a design (`coatlab_core::export`): CGATS.17 and CxF3 files read back
//! by Coatlab's own readers to the same numbers, fitted back to the design's ρ(λ),
//! and the glTF material: its BRDF against closed forms, the roughness mapping,
//! and the GLB loading back through the scene loader with the design's material.

use coatlab_core::colour::spectrum::WavelengthGrid;
use coatlab_core::design::{PaintDesign, presets};
use coatlab_core::export::cxf::{design_from_cxf, to_cxf};
use coatlab_core::export::gltf::{
    RealTimeMaterial, paint_material_name, real_time_material, reflectance_factor,
    roughness_of_exponent, scene_glb,
};
use coatlab_core::export::{ExportFormat, to_cgats, virtual_readings};
use coatlab_core::fit::{Method, fit_albedo};
use coatlab_core::measurement::{self, Format, Geometry, Sample, Standard, StatedValue};
use coatlab_core::paint::gloss::GlossExponent;
use coatlab_core::paint::lobe::LobeKind;

fn design(slug: &str) -> PaintDesign {
    presets::by_slug(slug).expect("preset").design
}

/// The readings as read back, against those written: same geometries in the same
/// order, the same spectra and gloss to the last bit.
fn assert_same_readings(written: &[Sample], back: &[Sample]) {
    assert_eq!(back.len(), written.len());
    for (w, b) in written.iter().zip(back) {
        assert_eq!(b.name, w.name);
        assert_eq!(b.geometry, w.geometry);
        assert_eq!(b.spectrum, w.spectrum, "{}", w.geometry);
    }
}

#[test]
fn cgats_export_reads_back_to_the_same_numbers_one_row_per_geometry() {
    for slug in ["signal-red", "deep-blue"] {
        let d = design(slug);
        let written = virtual_readings(&d).expect("readings");
        assert_eq!(written.len(), 7, "five angles, SCI and SCE");
        let text = to_cgats(&d).expect("CGATS");
        let data_rows = text
            .lines()
            .skip_while(|l| *l != "BEGIN_DATA")
            .skip(1)
            .take_while(|l| *l != "END_DATA")
            .count();
        assert_eq!(data_rows, 7, "{text}");
        let back = measurement::read(text.as_bytes(), "export.txt").expect("readable");
        assert_eq!(back.format, Format::Cgats);
        assert_same_readings(&written, &back.samples);
        for b in &back.samples {
            assert_eq!(b.gloss, written[0].gloss, "every row carries the gloss");
        }
    }
}

#[test]
fn cxf_export_reads_back_to_the_same_numbers_and_carries_the_design() {
    let d = design("signal-red");
    let written = virtual_readings(&d).expect("readings");
    let text = to_cxf(&d, "2026-12-02T18:00:00Z").expect("CxF");
    let back = measurement::read(text.as_bytes(), "export.cxf").expect("readable");
    assert_eq!(back.format, Format::Cxf3);
    assert_same_readings(&written, &back.samples);
    let directional = back
        .samples
        .iter()
        .filter(|s| matches!(s.geometry, Geometry::Directional { .. }))
        .count();
    assert_eq!(directional, 5);
    for (w, b) in written.iter().zip(&back.samples) {
        // The stated CIELAB (D65/10°) comes back exactly, as the instrument gave it.
        let (Some(wc), Some(bc)) = (w.colour, b.colour) else {
            panic!("{} lacks its colour", w.geometry);
        };
        assert_eq!(wc.value, bc.value);
        assert!(matches!(bc.value, StatedValue::Lab(_)));
        assert_eq!(bc.illuminant, wc.illuminant);
        assert_eq!(bc.observer, wc.observer);
    }
    assert_eq!(back.samples[0].gloss, written[0].gloss);
    assert_eq!(back.samples[0].gloss.len(), 3);
    // The custom section gives the design back.
    let again = design_from_cxf(&text, "export.cxf")
        .expect("readable")
        .expect("a design section");
    assert_eq!(again, d);
    // A file without the section has no design, and says so by None.
    let foreign = text.replace("urn:coatlab:cxf:paint-design:1", "urn:someone-else");
    assert!(design_from_cxf(&foreign, "x.cxf").expect("XML").is_none());
}

#[test]
fn a_design_name_with_markup_characters_survives_both_formats() {
    let mut d = design("deep-blue");
    d.name = "Blue <A&B> \"metallic\" 'x'".to_owned();
    let text = to_cxf(&d, "2026-12-02T18:00:00Z").expect("CxF");
    let back = measurement::read(text.as_bytes(), "export.cxf").expect("readable");
    assert_eq!(back.samples[0].name, d.name);
    assert_eq!(
        design_from_cxf(&text, "export.cxf")
            .expect("ok")
            .expect("design")
            .name,
        d.name
    );
}

/// ρ(λ) fitted back from one exported geometry by the existing closed-form fit.
fn fitted_back(text: &str, file: &str, truth: &PaintDesign) {
    let back = measurement::read(text.as_bytes(), file).expect("readable");
    let reading = back
        .samples
        .iter()
        .find(|s| s.geometry == Geometry::directional(45.0, 45.0))
        .expect("45°as45°");
    let standard = Standard {
        name: &reading.name,
        readings: vec![reading],
    };
    // Another pigment, the same coat: the fit must find the design's ρ.
    let mut start = truth.clone();
    start.albedo = design("deep-blue").albedo;
    let fit = fit_albedo(&start, &standard).expect("fits");
    assert_eq!(fit.method, Method::ClosedForm);
    let model = truth.model(WavelengthGrid::reference()).expect("model");
    let worst = fit
        .albedo
        .iter()
        .zip(model.albedo())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-4, "{file}: |Δρ| up to {worst}");
}

#[test]
fn the_exported_readings_fit_back_to_the_designs_albedo() {
    let d = design("signal-red");
    fitted_back(&to_cgats(&d).expect("CGATS"), "export.txt", &d);
    fitted_back(
        &to_cxf(&d, "2026-12-02T18:00:00Z").expect("CxF"),
        "export.cxf",
        &d,
    );
}

#[test]
fn formats_are_chosen_by_name_and_extension() {
    assert_eq!(ExportFormat::by_name(" CxF "), Ok(ExportFormat::Cxf));
    let e = ExportFormat::by_name("png").expect_err("not a format");
    let message = e.to_string();
    for name in ["cxf", "cgats", "gltf", "png"] {
        assert!(message.contains(name), "{message}");
    }
    assert!(ExportFormat::Gltf.accepts_extension("GLB"));
    assert!(!ExportFormat::Gltf.accepts_extension("cxf"));
    assert!(ExportFormat::Cgats.accepts_extension("txt"));
}

fn material(roughness: f64, clearcoat_roughness: f64, ior: f64) -> RealTimeMaterial {
    RealTimeMaterial {
        base_color: palette::LinSrgb::new(0.0, 0.0, 0.0),
        roughness,
        clearcoat_roughness,
        ior,
        delta_e00: Vec::new(),
    }
}

fn direction(deg: f64) -> [f64; 3] {
    let t = deg.to_radians();
    [t.sin(), 0.0, t.cos()]
}

#[test]
fn the_gltf_brdf_matches_its_closed_forms() {
    // A mirror coat over a base of ior 1 (F0 = 0) and roughness 1 (α = 1, where
    // GGX is D = 1/π and the visibility 1/((N·L + 1)(N·V + 1))): off the mirror
    // direction π·f = (1 − F_c)·((1 − F)·c + F·π·V·D), F_c = 0.04 + 0.96 (1 − N·V)^5
    // (the coat's weight at N·V), F = (1 − V·H)^5.
    let m = material(1.0, 0.0, 1.0);
    for view in [0.0f64, 30.0, 60.0] {
        let (wi, wo) = (direction(-45.0), direction(view));
        let f_c = 0.04 + 0.96 * (1.0 - wo[2]).powi(5);
        let v_h = ((45.0 + view) / 2.0).to_radians().cos();
        let f = (1.0 - v_h).powi(5);
        let specular = 1.0 / ((wi[2] + 1.0) * (wo[2] + 1.0));
        let r = reflectance_factor(&m, [0.2, 0.5, 0.8], wi, wo);
        for (got, c) in r.iter().zip([0.2, 0.5, 0.8]) {
            let want = (1.0 - f_c) * ((1.0 - f) * c + f * specular);
            assert!((got - want).abs() < 1e-12, "{view}: {r:?}");
        }
    }
    // The GGX distribution is normalised: ∫ D(h) (n·h) dω = 1. Checked through the
    // coat lobe at the mirror geometry, where V·D and D are related in closed form:
    // here by the Monte Carlo-free route of a midpoint rule over θh.
    let alpha2: f64 = 0.3f64.powi(4);
    let steps = 20_000;
    let integral: f64 = (0..steps)
        .map(|i| {
            let t = (i as f64 + 0.5) / steps as f64 * std::f64::consts::FRAC_PI_2;
            let c = t.cos();
            let d = alpha2 / (std::f64::consts::PI * (c * c * (alpha2 - 1.0) + 1.0).powi(2));
            d * c * t.sin() * 2.0 * std::f64::consts::PI * std::f64::consts::FRAC_PI_2
                / steps as f64
        })
        .sum();
    assert!((integral - 1.0).abs() < 1e-3, "{integral}");
    // A black base shows only the lobes, which fall away from the mirror direction.
    let glossy = material(1.0, 0.2, 1.5);
    let near = reflectance_factor(&glossy, [0.0; 3], direction(-45.0), direction(30.0))[0];
    let far = reflectance_factor(&glossy, [0.0; 3], direction(-45.0), direction(-20.0))[0];
    assert!(near > 5.0 * far, "{near} {far}");
}

#[test]
fn roughness_follows_the_gloss_lobe() {
    let r = |m| roughness_of_exponent(GlossExponent::Finite(m), LobeKind::Normalised);
    assert_eq!(
        roughness_of_exponent(GlossExponent::Mirror, LobeKind::Normalised),
        0.0
    );
    // α = √(2/(4m+2)), roughness = √α: m = 0 is α = 1.
    assert!((r(0.0) - 1.0).abs() < 1e-12);
    assert!((r(1000.0) - (2.0f64 / 4002.0).sqrt().sqrt()).abs() < 1e-12);
    assert!(r(100.0) > r(1000.0));
    // The paper's lobe of m is as wide as a normalised one of m/4.
    assert_eq!(
        roughness_of_exponent(GlossExponent::Finite(400.0), LobeKind::Paper),
        r(100.0)
    );
}

fn lab_of_rgb(rgb: [f64; 3]) -> coatlab_core::colour::Lab {
    use coatlab_core::colour::{lab_from_xyz, srgb_white, xyz_from_linear_srgb};
    lab_from_xyz(
        xyz_from_linear_srgb(palette::LinSrgb::new(rgb[0], rgb[1], rgb[2])),
        srgb_white(),
    )
}

#[test]
fn the_real_time_material_is_fitted_and_states_its_cost() {
    use coatlab_core::colour::{ciede2000, linear_srgb_of_reflectance};
    let d = design("signal-red");
    let m = real_time_material(&d).expect("material");
    assert_eq!(m.delta_e00.len(), 5);
    let fitted = [m.base_color.red, m.base_color.green, m.base_color.blue];
    assert!(
        fitted[0] > 2.0 * fitted[1] && fitted[0] > 2.0 * fitted[2],
        "a red: {fitted:?}"
    );
    // The design's colours at the five geometries (D65/2°), recomputed here.
    let model = d.model(WavelengthGrid::reference()).expect("model");
    let readings = coatlab_core::instruments::measure(&model).expect("spectral");
    let per_angle = |rgb: [f64; 3]| -> Vec<f64> {
        readings
            .angles
            .iter()
            .map(|a| {
                let want = lab_of_rgb(linear_srgb_of_reflectance(&a.reflectance_factor));
                let (wi, wo) = (direction(-45.0), direction(45.0 - a.aspecular_deg));
                ciede2000(lab_of_rgb(reflectance_factor(&m, rgb, wi, wo)), want)
            })
            .collect()
    };
    let stated: Vec<f64> = m.delta_e00.iter().map(|c| c.delta_e00).collect();
    assert_eq!(per_angle(fitted), stated);
    let cost = |rgb| per_angle(rgb).iter().map(|d| d * d).sum::<f64>();
    // No better than the colour of ρ under D65 it starts from, nor than any
    // neighbour inside the unit cube: a (local) minimum of Σ ΔE00².
    let plain = linear_srgb_of_reflectance(model.albedo());
    assert!(
        cost(fitted) <= cost(plain),
        "{} vs {}",
        cost(fitted),
        cost(plain)
    );
    for axis in 0..3 {
        for step in [-0.002, 0.002] {
            let mut near = fitted;
            near[axis] = (near[axis] + step).clamp(0.0, 1.0);
            assert!(cost(fitted) <= cost(near) + 1e-12, "{axis} {step}");
        }
    }
}

#[test]
fn the_gltf_export_loads_back_with_the_designs_material() {
    use coatlab_core::scene::car::{CarParameters, generate};
    use coatlab_core::scene::gltf_loader::{LoadOptions, load};
    let d = design("signal-red");
    let m = real_time_material(&d).expect("material");
    let car = generate(&CarParameters::default());
    let glb = scene_glb(&car, &d, &m).expect("GLB");
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("car.glb");
    std::fs::write(&path, &glb).expect("written");

    let scene = load(&path, &LoadOptions::default()).expect("loads");
    assert_eq!(scene.mesh.triangle_count(), car.mesh.triangle_count());
    let painted: Vec<&str> = scene
        .paint_materials
        .iter()
        .map(|&i| scene.materials[i as usize].name.as_str())
        .collect();
    assert!(!painted.is_empty());
    assert!(
        painted.iter().all(|n| *n == paint_material_name(&d)),
        "{painted:?}"
    );
    let paint = &scene.materials[scene.paint_materials[0] as usize];
    assert_eq!(paint.base_color.red, m.base_color.red as f32);
    assert_eq!(paint.base_color.green, m.base_color.green as f32);
    assert_eq!(paint.base_color.blue, m.base_color.blue as f32);
    assert_eq!(paint.metallic, 0.0);

    // The extensions and the extras, as any glTF reader sees the JSON.
    let gltf = gltf::Gltf::from_slice(&glb).expect("valid glTF");
    let used: Vec<&str> = gltf.extensions_used().collect();
    assert!(used.contains(&"KHR_materials_clearcoat") && used.contains(&"KHR_materials_ior"));
    let material = gltf
        .materials()
        .find(|x| x.name() == Some(paint_material_name(&d).as_str()))
        .expect("the paint material");
    assert_eq!(material.ior(), Some(m.ior as f32));
    let clearcoat = material
        .extension_value("KHR_materials_clearcoat")
        .expect("clearcoat");
    assert_eq!(clearcoat["clearcoatFactor"], 1.0);
    let close = |a: Option<f64>, b: f64| a.is_some_and(|a| (a - b).abs() <= 1e-15 * b.abs());
    // (serde_json parses the last digit of a float approximately.)
    assert!(close(
        clearcoat["clearcoatRoughnessFactor"].as_f64(),
        m.clearcoat_roughness
    ));
    let extras: gltf::json::Value =
        gltf::json::deserialize::from_str(material.extras().as_ref().expect("extras").get())
            .expect("JSON");
    let costs = extras["coatlab"]["delta_e00"].as_array().expect("costs");
    assert_eq!(costs.len(), 5);
    for (c, want) in costs.iter().zip(&m.delta_e00) {
        assert!(close(c["delta_e00"].as_f64(), want.delta_e00), "{c}");
    }
}

// ---------------------------------------------------------------------------------
// The CxF3 export against X-Rite's CxF3 core schema (vendor/cxf3/CxF3_Core.xsd),
// read here so that a drift of the writer fails without CI's Python validation
// (.ci/check-cxf): for every core element the schema declares globally, the order
// and presence of its children (sequences, choices, nested choices), its
// attributes (declared, required ones present) and enumerated values.

mod schema {
    use roxmltree::{Document, Node};

    const XS: &str = "http://www.w3.org/2001/XMLSchema";
    const CC: &str = "http://colorexchangeformat.com/CxF3-core";

    pub fn text() -> String {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../vendor/cxf3/CxF3_Core.xsd"
        );
        std::fs::read_to_string(path).expect("vendor/cxf3/CxF3_Core.xsd")
    }

    fn xs<'a, 'i>(node: Node<'a, 'i>, tag: &'a str) -> impl Iterator<Item = Node<'a, 'i>> {
        node.children()
            .filter(move |n| n.tag_name().namespace() == Some(XS) && n.tag_name().name() == tag)
    }

    /// The local part of a `cc:Name` reference.
    fn local(name: &str) -> &str {
        name.rsplit(':').next().unwrap_or(name)
    }

    fn global<'a, 'i>(xsd: &'a Document<'i>, tag: &'a str, name: &str) -> Option<Node<'a, 'i>> {
        xs(xsd.root_element(), tag).find(|n| n.attribute("name") == Some(name))
    }

    /// The complexType of a global element, inline or named, with the base of a
    /// complexContent extension followed.
    fn complex<'a, 'i>(xsd: &'a Document<'i>, element: Node<'a, 'i>) -> Option<Node<'a, 'i>> {
        let t = match element.attribute("type") {
            Some(t) => global(xsd, "complexType", local(t))?,
            None => xs(element, "complexType").next()?,
        };
        match xs(t, "complexContent").next() {
            Some(c) => {
                let base = xs(c, "extension").next()?.attribute("base")?;
                global(xsd, "complexType", local(base))
            }
            None => Some(t),
        }
    }

    /// One place of a sequence: the names that may fill it, whether it must be
    /// filled, whether it repeats.
    struct Slot {
        names: Vec<String>,
        required: bool,
        repeats: bool,
    }

    fn slot(particle: Node) -> Slot {
        let names = if particle.tag_name().name() == "choice" {
            xs(particle, "element")
                .map(|e| name_of(e).to_owned())
                .collect()
        } else {
            vec![name_of(particle).to_owned()]
        };
        Slot {
            names,
            required: particle.attribute("minOccurs") != Some("0"),
            repeats: particle.attribute("maxOccurs") == Some("unbounded"),
        }
    }

    fn name_of<'a>(e: Node<'a, '_>) -> &'a str {
        e.attribute("name")
            .or_else(|| e.attribute("ref").map(local))
            .unwrap_or_default()
    }

    /// The names of `children` against a model group: problems, empty when valid.
    fn check_group(group: Node, children: &[String], at: &str) -> Vec<String> {
        let repeats = group.attribute("maxOccurs") == Some("unbounded");
        if group.tag_name().name() == "choice" {
            let allowed: Vec<&str> = xs(group, "element").map(name_of).collect();
            let mut problems: Vec<String> = children
                .iter()
                .filter(|c| !allowed.contains(&c.as_str()))
                .map(|c| format!("{at}: <{c}> is not one of {allowed:?}"))
                .collect();
            if children.is_empty() && group.attribute("minOccurs") != Some("0") {
                problems.push(format!("{at}: none of {allowed:?}"));
            }
            if children.len() > 1 && !repeats {
                problems.push(format!("{at}: {children:?}, where one of {allowed:?} goes"));
            }
            return problems;
        }
        let slots: Vec<Slot> = group
            .children()
            .filter(|n| matches!(n.tag_name().name(), "element" | "choice"))
            .map(slot)
            .collect();
        let mut problems = Vec::new();
        let mut i = 0;
        // A repeating sequence (MultiAngle's) is matched again while it takes more.
        for pass in 0.. {
            let start = i;
            for s in &slots {
                let mut filled = 0;
                while i < children.len()
                    && s.names.contains(&children[i])
                    && (s.repeats || filled == 0)
                {
                    i += 1;
                    filled += 1;
                }
                if filled == 0 && s.required && pass == 0 {
                    problems.push(format!(
                        "{at}: <{}> missing before child {}",
                        s.names.join("|"),
                        i + 1
                    ));
                }
            }
            if !(repeats && i > start && i < children.len()) {
                break;
            }
        }
        if let Some(extra) = children.get(i) {
            problems.push(format!(
                "{at}: child {} <{extra}> out of the schema's order",
                i + 1
            ));
        }
        problems
    }

    /// The declaration of a core element: a local one in its parent's type (where
    /// GeometryChoice's MultiAngle, SphereGeometry, SingleAngle are), else the
    /// global one.
    fn declaration<'a, 'i>(xsd: &'a Document<'i>, node: Node) -> Option<Node<'a, 'i>> {
        let name = node.tag_name().name();
        let local = node
            .parent_element()
            .filter(|p| p.tag_name().namespace() == Some(CC))
            .and_then(|p| declaration(xsd, p))
            .and_then(|p| complex(xsd, p))
            .and_then(|t| {
                t.descendants().find(|n| {
                    n.tag_name().namespace() == Some(XS)
                        && n.tag_name().name() == "element"
                        && n.attribute("name") == Some(name)
                })
            });
        local.or_else(|| global(xsd, "element", name))
    }

    /// Every way `document` departs from the schema (as far as this reads it).
    pub fn problems(xsd: &Document, document: &str) -> Vec<String> {
        let doc = Document::parse(document).expect("XML");
        let mut problems = Vec::new();
        for node in doc.descendants().filter(|n| n.is_element()) {
            if node.tag_name().namespace() != Some(CC) {
                continue;
            }
            let name = node.tag_name().name();
            let at = format!("line {} <{name}>", doc.text_pos_at(node.range().start).row);
            let Some(decl) = declaration(xsd, node) else {
                continue;
            };
            let children: Vec<String> = node
                .children()
                .filter(|n| n.is_element())
                .map(|n| n.tag_name().name().to_owned())
                .collect();
            // The enumerated simple type of the element's value, where it has one.
            let simple = decl.attribute("type").map(local).or_else(|| {
                let ext = decl
                    .descendants()
                    .find(|n| n.tag_name().name() == "extension")?;
                ext.attribute("base").map(local)
            });
            if let Some(t) = simple.and_then(|t| global(xsd, "simpleType", t)) {
                let allowed: Vec<&str> = t
                    .descendants()
                    .filter(|n| n.tag_name().name() == "enumeration")
                    .filter_map(|n| n.attribute("value"))
                    .collect();
                let value = node.text().unwrap_or_default().trim();
                if !allowed.is_empty() && !allowed.contains(&value) {
                    problems.push(format!("{at}: {value:?} is not one of {allowed:?}"));
                }
            }
            let Some(complex) = complex(xsd, decl) else {
                if !children.is_empty() {
                    problems.push(format!("{at}: a simple value cannot hold {children:?}"));
                }
                continue;
            };
            if complex
                .descendants()
                .all(|n| n.tag_name().name() != "anyAttribute")
            {
                let declared: Vec<Node> = complex
                    .descendants()
                    .filter(|n| n.tag_name().name() == "attribute")
                    .collect();
                for a in node.attributes().filter(|a| a.namespace().is_none()) {
                    if !declared
                        .iter()
                        .any(|d| d.attribute("name") == Some(a.name()))
                    {
                        problems.push(format!("{at}: attribute {} is not declared", a.name()));
                    }
                }
                for d in declared
                    .iter()
                    .filter(|d| d.attribute("use") == Some("required"))
                {
                    let wanted = d.attribute("name").unwrap_or_default();
                    if node.attribute(wanted).is_none() {
                        problems.push(format!("{at}: required attribute {wanted} missing"));
                    }
                }
            }
            // CustomResources: any elements, of other namespaces only.
            if complex.descendants().any(|n| n.tag_name().name() == "any") {
                for c in node.children().filter(|n| n.is_element()) {
                    if c.tag_name().namespace() == Some(CC) {
                        problems.push(format!(
                            "{at}: holds the core element <{}>",
                            c.tag_name().name()
                        ));
                    }
                }
                continue;
            }
            match xs(complex, "sequence").chain(xs(complex, "choice")).next() {
                Some(group) => problems.extend(check_group(group, &children, &at)),
                None if !children.is_empty() && xs(complex, "simpleContent").next().is_some() => {
                    problems.push(format!("{at}: a simple value cannot hold {children:?}"));
                }
                None => {}
            }
        }
        problems
    }
}

#[test]
fn the_cxf_export_follows_the_cxf3_core_schema() {
    let text = schema::text();
    let xsd = roxmltree::Document::parse(&text).expect("the schema parses");
    for slug in ["signal-red", "satin-grey"] {
        let cxf = to_cxf(&design(slug), "2026-12-02T18:00:00Z").expect("CxF");
        assert_eq!(schema::problems(&xsd, &cxf), Vec::<String>::new(), "{slug}");
    }
    // The instrument-like fixtures follow it too; Coatlab's earlier layout does not,
    // and the check says where (so it can fail).
    let fixture = |name: &str| {
        std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/data/measurements")
                .join(name),
        )
        .expect("fixture")
    };
    for name in ["multi_angle.cxf", "sphere_and_45_0.cxf"] {
        assert_eq!(
            schema::problems(&xsd, &fixture(name)),
            Vec::<String>::new(),
            "{name}"
        );
    }
    let earlier = schema::problems(&xsd, &fixture("earlier_layout.cxf")).join("\n");
    for wanted in [
        "<Object>: <CreationDate> missing",
        "<Method>: \"E308\" is not one of",
        "<MultiAngle>: child 1 <IlluminationAngle> out of the schema's order",
        "<GeometryChoice>: <BRDFAngle> is not one of",
        "<SphereGeometry>: a simple value cannot hold",
        "<SingleAngle>: <SingleAngleConfiguration> missing",
        "<ColorValues>: <Gloss> is not one of",
        "<Gloss>: attribute Angle is not declared",
    ] {
        assert!(earlier.contains(wanted), "{wanted:?} not in\n{earlier}");
    }
}
