//! X-Rite CxF3 (ISO 17972-1) XML measurement files.
//!
//! Read: every `Object` (its `Name`, else its `Id`) and in it
//! - `ReflectanceSpectrum` elements: white-space separated values from `StartWL`
//!   (on the element, else the specification's `WavelengthRange`) in steps of
//!   `Increment` (on the element, else the `WavelengthRange`);
//! - `ColorCIELab` (`L`, `A`, `B`) and `ColorCIEXYZ` (`X`, `Y`, `Z`);
//! - `Gloss` elements (the schema puts them in `PhysicalAttributes`), the gloss units
//!   as the text and the angle in the `Method` (`specular gloss 60°`, `60 deg`,
//!   `60`: the number before `°` or `deg`, or the whole text), or in an `Angle` or
//!   `MeasurementAngle` attribute.
//!
//! Each colour names its `ColorSpecification` (by `Id`), which gives the
//! illuminant and observer (`TristimulusSpec`) and the geometry
//! (`MeasurementSpec/GeometryChoice`), in the schema's layout: `SingleAngle`
//! (`IlluminationAngle`, `MeasurementAngle`), `SphereGeometry` (`Specular_Included`,
//! `Specular_Excluded`), `MultiAngle` of `BRDFAngle`s (`IlluminationAngle`,
//! `Aspecular`; where it lists several, a colour picks one by naming its `Notation`
//! in its `Name`). Also read, as Coatlab's exports wrote it before they followed the
//! schema: `SphereGeometry` with a `SpecularComponentIncluded` (true/false) or
//! `SpecularComponent` (Included/Excluded), `MultiAngle` or a bare `BRDFAngle` with
//! the angles directly in it, angles and flags as attributes, `Gloss` with an
//! `Angle` in `ColorValues`. One sample is made per object and geometry.
//!
//! Safety: roxmltree resolves no external entity, and DTDs are refused outright
//! (CxF3 needs none), so no entity can be declared and an entity-expansion bomb
//! cannot start; the number of nodes is capped at [`NODES_LIMIT`].

use roxmltree::{Document, Node, ParsingOptions};

use super::{
    Format, GlossValue, Measurement, MeasurementError, Sample, StatedColour, StatedValue,
    decide_scale, parse_illuminant, parse_number, parse_observer,
};
use crate::colour::cie::{Illuminant, Observer};
use crate::colour::{Lab, Xyz};
use crate::measurement::{
    Geometry, GeometryError, ReadingProblem, Reflectance, ReflectanceScale, SpecularComponent,
};

/// The most XML nodes a file may have: ample for thousands of multi-angle
/// readings, small enough that a hostile file cannot exhaust memory.
pub const NODES_LIMIT: u32 = 2_000_000;

/// What is wrong with an element of a CxF3 file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CxfProblem {
    #[error(
        "a document type declaration (DTD) is refused: CxF3 needs none, and its entities \
         could expand without bound (an XML bomb)"
    )]
    Dtd,
    #[error("the file ends before the element is closed: it is truncated")]
    Truncated,
    #[error("the file has more than {NODES_LIMIT} XML nodes")]
    TooLarge,
    #[error("the root element is <{0}>, not <CxF>")]
    NotCxf(String),
    #[error("the attribute {0} is missing")]
    MissingAttribute(&'static str),
    #[error("the child element <{0}> is missing")]
    MissingChild(&'static str),
    #[error("no ColorSpecification with Id {0:?}")]
    UnknownSpecification(String),
    #[error(
        "unknown geometry element <{0}>: expected SingleAngle, SphereGeometry, MultiAngle or BRDFAngle"
    )]
    UnknownGeometry(String),
    #[error(
        "its ColorSpecification's MultiAngle lists the BRDFAngles {}: the reading's Name must \
         be the Notation of one", .0.join(", ")
    )]
    AmbiguousAngle(Vec<String>),
    #[error(
        "the gloss's angle is not stated: expected an Angle attribute or a Method naming it \
         (\"specular gloss 60°\"), not {0:?}"
    )]
    GlossAngle(String),
    #[error(transparent)]
    Reading(#[from] ReadingProblem),
}

/// A `ColorSpecification`, as far as it concerns us.
#[derive(Debug, Clone)]
struct Specification {
    /// `None` outer: not stated; `Some(None)`: named, but not one we have.
    illuminant: Option<Option<Illuminant>>,
    illuminant_text: String,
    observer: Option<Observer>,
    /// The geometries it applies to, each with its `Notation`: one, or the several
    /// `BRDFAngle`s of a `MultiAngle`, of which a reading names one.
    geometries: Vec<(Option<String>, Geometry)>,
    start_nm: Option<f64>,
    increment_nm: Option<f64>,
}

type Located = (u32, String, CxfProblem);

fn local(node: &Node) -> String {
    node.tag_name().name().to_owned()
}

/// The first descendant of `node` (itself excluded) with local name `name`.
fn find<'a, 'i>(node: Node<'a, 'i>, name: &str) -> Option<Node<'a, 'i>> {
    node.descendants()
        .skip(1)
        .find(|n| n.is_element() && n.tag_name().name() == name)
}

/// The value `name` on `node`: an attribute, else a descendant element's text.
fn value<'a>(node: Node<'a, '_>, name: &str) -> Option<&'a str> {
    node.attribute(name)
        .or_else(|| find(node, name).and_then(|n| n.text()))
        .map(str::trim)
}

/// Reads a CxF3 text; `file` names it in errors.
pub fn read_cxf(text: &str, file: &str) -> Result<Measurement, MeasurementError> {
    let options = ParsingOptions {
        allow_dtd: false,
        nodes_limit: NODES_LIMIT,
        ..ParsingOptions::default()
    };
    let doc = Document::parse_with_options(text, options).map_err(|e| match e {
        roxmltree::Error::DtdDetected => MeasurementError::Cxf {
            file: file.to_owned(),
            line: line_of(text, "<!DOCTYPE"),
            element: "!DOCTYPE".to_owned(),
            problem: CxfProblem::Dtd,
        },
        roxmltree::Error::NodesLimitReached => MeasurementError::Cxf {
            file: file.to_owned(),
            line: 1,
            element: "CxF".to_owned(),
            problem: CxfProblem::TooLarge,
        },
        roxmltree::Error::UnclosedRootNode | roxmltree::Error::UnexpectedEndOfStream => {
            MeasurementError::Cxf {
                file: file.to_owned(),
                line: u32::try_from(text.lines().count().max(1)).unwrap_or(u32::MAX),
                element: "CxF".to_owned(),
                problem: CxfProblem::Truncated,
            }
        }
        other => MeasurementError::Xml {
            file: file.to_owned(),
            message: other.to_string(),
        },
    })?;
    read_document(&doc).map_err(|(line, element, problem)| MeasurementError::Cxf {
        file: file.to_owned(),
        line,
        element,
        problem,
    })
}

fn line_of(text: &str, needle: &str) -> u32 {
    let at = text.find(needle).unwrap_or(0);
    u32::try_from(text[..at].matches('\n').count() + 1).unwrap_or(u32::MAX)
}

fn read_document(doc: &Document) -> Result<Measurement, Located> {
    let here = |node: &Node, problem: CxfProblem| -> Located {
        (
            doc.text_pos_at(node.range().start).row,
            local(node),
            problem,
        )
    };
    let root = doc.root_element();
    if root.tag_name().name() != "CxF" {
        return Err(here(&root, CxfProblem::NotCxf(local(&root))));
    }
    let number = |node: &Node, what: &str, text: &str| -> Result<f64, Located> {
        parse_number(what, text).map_err(|p| here(node, p.into()))
    };

    // Specifications by Id.
    let mut specs: Vec<(String, Specification)> = Vec::new();
    for spec in root
        .descendants()
        .filter(|n| n.is_element() && n.tag_name().name() == "ColorSpecification")
    {
        // A colour value also carries a ColorSpecification *attribute*; the element
        // with an Id is the definition.
        let Some(id) = spec.attribute("Id") else {
            continue;
        };
        let tristimulus = find(spec, "TristimulusSpec");
        let illuminant_text = tristimulus
            .and_then(|t| value(t, "Illuminant"))
            .unwrap_or_default()
            .to_owned();
        let illuminant = (!illuminant_text.is_empty()).then(|| parse_illuminant(&illuminant_text));
        let observer = tristimulus
            .and_then(|t| value(t, "Observer"))
            .and_then(parse_observer);
        let geometries = match find(spec, "GeometryChoice") {
            Some(choice) => geometries_of(choice, &here, &number)?,
            None => vec![(None, Geometry::Unspecified)],
        };
        let range = find(spec, "WavelengthRange");
        let start_nm = match range.and_then(|r| value(r, "StartWL")) {
            Some(t) => Some(number(&range.unwrap_or(spec), "StartWL", t)?),
            None => None,
        };
        let increment_nm = match range.and_then(|r| value(r, "Increment")) {
            Some(t) => Some(number(&range.unwrap_or(spec), "Increment", t)?),
            None => None,
        };
        specs.push((
            id.to_owned(),
            Specification {
                illuminant,
                illuminant_text,
                observer,
                geometries,
                start_nm,
                increment_nm,
            },
        ));
    }
    let spec_of = |node: &Node| -> Result<Option<&Specification>, Located> {
        match node.attribute("ColorSpecification") {
            None => Ok(None),
            Some(id) => specs
                .iter()
                .find(|(sid, _)| sid == id)
                .map(|(_, s)| Some(s))
                .ok_or_else(|| here(node, CxfProblem::UnknownSpecification(id.to_owned()))),
        }
    };
    // The geometry of a colour element under its specification.
    let geometry_at = |node: &Node, spec: Option<&Specification>| -> Result<Geometry, Located> {
        let Some(spec) = spec else {
            return Ok(Geometry::Unspecified);
        };
        if let [(_, only)] = spec.geometries.as_slice() {
            return Ok(*only);
        }
        let name = node.attribute("Name").map(str::trim);
        spec.geometries
            .iter()
            .find(|(notation, _)| notation.is_some() && notation.as_deref() == name)
            .map(|(_, g)| *g)
            .ok_or_else(|| {
                let notations = spec.geometries.iter();
                here(
                    node,
                    CxfProblem::AmbiguousAngle(
                        notations
                            .map(|(n, g)| n.clone().unwrap_or_else(|| g.to_string()))
                            .collect(),
                    ),
                )
            })
    };

    // Spectra are collected raw first: the scale is decided over the whole file.
    struct RawSpectrum {
        node_line: u32,
        element: String,
        start_nm: f64,
        step_nm: f64,
        values: Vec<f64>,
    }
    struct Reading {
        geometry: Geometry,
        spectrum: Option<RawSpectrum>,
        colour: Option<(StatedValue, Option<Specification>)>,
    }
    /// The reading of `geometry` that still lacks what `lacks` looks for, a new
    /// one if there is none: a spectrum and a colour of one geometry go together.
    fn reading_at(
        readings: &mut Vec<Reading>,
        geometry: Geometry,
        lacks: impl Fn(&Reading) -> bool,
    ) -> &mut Reading {
        let i = readings
            .iter()
            .position(|r| r.geometry == geometry && lacks(r))
            .unwrap_or_else(|| {
                readings.push(Reading {
                    geometry,
                    spectrum: None,
                    colour: None,
                });
                readings.len() - 1
            });
        &mut readings[i]
    }
    /// An object's name, id, readings and gloss.
    type RawObject = (String, Option<String>, Vec<Reading>, Vec<GlossValue>);
    let mut samples_raw: Vec<RawObject> = Vec::new();
    let mut unknown_illuminant: Option<Located> = None;

    for object in root
        .descendants()
        .filter(|n| n.is_element() && n.tag_name().name() == "Object")
    {
        let name = object
            .attribute("Name")
            .or_else(|| object.attribute("Id"))
            .ok_or_else(|| here(&object, CxfProblem::MissingAttribute("Name")))?
            .to_owned();
        let id = object
            .attribute("Id")
            .filter(|_| object.attribute("Name").is_some())
            .map(str::to_owned);
        let mut readings: Vec<Reading> = Vec::new();
        let mut gloss = Vec::new();
        for node in object.descendants().filter(|n| n.is_element()) {
            let tag = node.tag_name().name();
            match tag {
                "ReflectanceSpectrum" => {
                    let spec = spec_of(&node)?;
                    let start_nm = match node.attribute("StartWL") {
                        Some(t) => number(&node, "StartWL", t)?,
                        None => spec
                            .and_then(|s| s.start_nm)
                            .ok_or_else(|| here(&node, CxfProblem::MissingAttribute("StartWL")))?,
                    };
                    let step_nm = match node.attribute("Increment") {
                        Some(t) => number(&node, "Increment", t)?,
                        None => spec.and_then(|s| s.increment_nm).ok_or_else(|| {
                            here(&node, CxfProblem::MissingAttribute("Increment"))
                        })?,
                    };
                    if step_nm <= 0.0 {
                        return Err(here(
                            &node,
                            ReadingProblem::NotANumber {
                                what: "Increment (a positive step)".to_owned(),
                                text: step_nm.to_string(),
                            }
                            .into(),
                        ));
                    }
                    let values = node
                        .text()
                        .unwrap_or_default()
                        .split_whitespace()
                        .enumerate()
                        .map(|(k, t)| number(&node, &format!("value {}", k + 1), t))
                        .collect::<Result<Vec<_>, _>>()?;
                    let geometry = geometry_at(&node, spec)?;
                    let raw = RawSpectrum {
                        node_line: doc.text_pos_at(node.range().start).row,
                        element: local(&node),
                        start_nm,
                        step_nm,
                        values,
                    };
                    reading_at(&mut readings, geometry, |r| r.spectrum.is_none()).spectrum =
                        Some(raw);
                }
                "ColorCIELab" | "ColorCIEXYZ" => {
                    let spec = spec_of(&node)?;
                    let names: [&'static str; 3] = if tag == "ColorCIELab" {
                        ["L", "A", "B"]
                    } else {
                        ["X", "Y", "Z"]
                    };
                    let mut v = [0.0; 3];
                    for (slot, child) in v.iter_mut().zip(names) {
                        let element = find(node, child)
                            .ok_or_else(|| here(&node, CxfProblem::MissingChild(child)))?;
                        *slot = number(&element, child, element.text().unwrap_or_default())?;
                    }
                    let stated = if tag == "ColorCIELab" {
                        StatedValue::Lab(Lab::new(v[0], v[1], v[2]))
                    } else {
                        StatedValue::Xyz(Xyz::new(v[0], v[1], v[2]))
                    };
                    if let Some(s) = spec
                        && matches!(s.illuminant, Some(None))
                    {
                        unknown_illuminant.get_or_insert_with(|| {
                            here(
                                &node,
                                ReadingProblem::UnknownIlluminant(s.illuminant_text.clone()).into(),
                            )
                        });
                    }
                    let geometry = geometry_at(&node, spec)?;
                    let entry = (stated, spec.cloned());
                    reading_at(&mut readings, geometry, |r| r.colour.is_none()).colour =
                        Some(entry);
                }
                "Gloss" => {
                    let method = node.attribute("Method").unwrap_or_default();
                    let angle = node
                        .attribute("Angle")
                        .or_else(|| node.attribute("MeasurementAngle"))
                        .or_else(|| angle_in_method(method))
                        .ok_or_else(|| here(&node, CxfProblem::GlossAngle(method.to_owned())))?;
                    gloss.push(GlossValue {
                        angle_deg: number(&node, "Angle", angle)?,
                        gu: number(&node, "Gloss", node.text().unwrap_or_default())?,
                    });
                }
                _ => {}
            }
        }
        samples_raw.push((name, id, readings, gloss));
    }

    let has_spectra = samples_raw
        .iter()
        .any(|(_, _, r, _)| r.iter().any(|r| r.spectrum.is_some()));
    if let Some(located) = unknown_illuminant
        && !has_spectra
    {
        return Err(located);
    }
    let max = samples_raw
        .iter()
        .flat_map(|(_, _, r, _)| r.iter())
        .filter_map(|r| r.spectrum.as_ref())
        .flat_map(|s| s.values.iter().copied())
        .fold(f64::NEG_INFINITY, f64::max);
    let scale = if has_spectra {
        Some(decide_scale(None, max).map_err(|e| {
            (
                root_line(doc),
                "CxF".to_owned(),
                ReadingProblem::from(e).into(),
            )
        })?)
    } else {
        None
    };
    let divisor = match scale.as_ref().map(|s| s.scale) {
        Some(ReflectanceScale::Percent) => 100.0,
        _ => 1.0,
    };

    let mut samples = Vec::new();
    for (name, id, readings, gloss) in samples_raw {
        let count = readings.len();
        for (k, reading) in readings.into_iter().enumerate() {
            let spectrum = match reading.spectrum {
                Some(raw) => Some(
                    Reflectance::uniform(
                        raw.start_nm,
                        raw.step_nm,
                        raw.values.iter().map(|v| v / divisor).collect(),
                    )
                    .map_err(|e| (raw.node_line, raw.element, ReadingProblem::from(e).into()))?,
                ),
                None => None,
            };
            let colour = reading.colour.and_then(|(value, spec)| {
                let spec = spec.as_ref();
                let illuminant = spec.and_then(|s| s.illuminant);
                // A colour under an illuminant we lack is dropped where a spectrum
                // gives it anyway (refused above where none does).
                if matches!(illuminant, Some(None)) {
                    return None;
                }
                Some(StatedColour {
                    value,
                    illuminant: illuminant.flatten(),
                    observer: spec.and_then(|s| s.observer),
                })
            });
            samples.push(Sample {
                name: name.clone(),
                id: id.clone(),
                geometry: reading.geometry,
                spectrum,
                colour,
                // The object's gloss readings go with its first reading.
                gloss: if k == 0 { gloss.clone() } else { Vec::new() },
            });
        }
        if count == 0 && !gloss.is_empty() {
            samples.push(Sample {
                name,
                id,
                geometry: Geometry::Unspecified,
                spectrum: None,
                colour: None,
                gloss,
            });
        }
    }
    Ok(Measurement {
        format: Format::Cxf3,
        samples,
        reflectance_scale: scale,
    })
}

fn root_line(doc: &Document) -> u32 {
    doc.text_pos_at(doc.root_element().range().start).row
}

/// The angle a gloss `Method` names: the number before `°` or `deg`, or the
/// whole text where it is a number.
fn angle_in_method(method: &str) -> Option<&str> {
    let method = method.trim();
    if method.parse::<f64>().is_ok() {
        return Some(method);
    }
    // ASCII lowering keeps every byte offset.
    let end = method
        .find('°')
        .or_else(|| method.to_ascii_lowercase().find("deg"))?;
    let head = method[..end].trim_end();
    let start = head
        .char_indices()
        .rev()
        .take_while(|(_, c)| c.is_ascii_digit() || *c == '.')
        .last()?
        .0;
    Some(&head[start..])
}

/// The geometries a `GeometryChoice` states, each with its `Notation` where it has
/// one (see [`Specification::geometries`]).
fn geometries_of<H, N>(
    choice: Node,
    here: &H,
    number: &N,
) -> Result<Vec<(Option<String>, Geometry)>, Located>
where
    H: Fn(&Node, CxfProblem) -> Located,
    N: Fn(&Node, &str, &str) -> Result<f64, Located>,
{
    let Some(kind) = choice.children().find(|n| n.is_element()) else {
        return Ok(vec![(None, Geometry::Unspecified)]);
    };
    let angle = |node: Node, name: &'static str| -> Result<f64, Located> {
        let text = value(node, name).ok_or_else(|| here(&node, CxfProblem::MissingChild(name)))?;
        number(&node, name, text)
    };
    let hemisphere = |node: Node, name: &str, deg: f64| -> Result<f64, Located> {
        if deg.abs() < 90.0 {
            Ok(deg)
        } else {
            Err(here(
                &node,
                ReadingProblem::Geometry(GeometryError::OutOfRange {
                    name: name.to_owned(),
                    angle_deg: deg,
                })
                .into(),
            ))
        }
    };
    let directional = |node: Node| -> Result<Geometry, Located> {
        let illumination =
            hemisphere(node, "IlluminationAngle", angle(node, "IlluminationAngle")?)?;
        let aspecular = angle(node, "Aspecular")?;
        hemisphere(node, "Aspecular", illumination - aspecular)?;
        Ok(Geometry::directional(illumination, aspecular))
    };
    let one = |geometry| Ok(vec![(None, geometry)]);
    match kind.tag_name().name() {
        "SingleAngle" => {
            let illumination =
                hemisphere(kind, "IlluminationAngle", angle(kind, "IlluminationAngle")?)?;
            let measurement =
                hemisphere(kind, "MeasurementAngle", angle(kind, "MeasurementAngle")?)?;
            one(Geometry::directional(
                illumination,
                illumination - measurement,
            ))
        }
        "MultiAngle" => {
            let angles: Vec<Node> = kind
                .children()
                .filter(|n| n.is_element() && n.tag_name().name() == "BRDFAngle")
                .collect();
            if angles.is_empty() {
                // Coatlab's earlier layout: the angles directly in MultiAngle.
                return one(directional(kind)?);
            }
            angles
                .into_iter()
                .map(|a| Ok((a.attribute("Notation").map(str::to_owned), directional(a)?)))
                .collect()
        }
        "BRDFAngle" => one(directional(kind)?),
        "SphereGeometry" => {
            let included = value(kind, "SpecularComponentIncluded")
                .map(|t| t.eq_ignore_ascii_case("true") || t == "1")
                .or_else(|| {
                    // The schema's Specular_Included as the element's text, or an
                    // earlier export's SpecularComponent="Included".
                    let text = value(kind, "SpecularComponent")
                        .or_else(|| kind.text().map(str::trim))?
                        .to_ascii_lowercase();
                    let text = text.strip_prefix("specular_").unwrap_or(&text);
                    if text.starts_with("incl") {
                        Some(true)
                    } else if text.starts_with("excl") {
                        Some(false)
                    } else {
                        None
                    }
                })
                .ok_or_else(|| {
                    here(
                        &kind,
                        ReadingProblem::Geometry(GeometryError::SpecularUnstated(
                            "SphereGeometry".to_owned(),
                        ))
                        .into(),
                    )
                })?;
            one(Geometry::Sphere {
                specular: if included {
                    SpecularComponent::Included
                } else {
                    SpecularComponent::Excluded
                },
            })
        }
        other => Err(here(&kind, CxfProblem::UnknownGeometry(other.to_owned()))),
    }
}

#[cfg(test)]
mod tests {
    use super::angle_in_method;

    #[test]
    fn a_gloss_method_names_its_angle_before_the_degree_sign_or_alone() {
        for (method, angle) in [
            ("specular gloss 60°", Some("60")),
            ("ISO 2813, 20°", Some("20")),
            ("85.5 °", Some("85.5")),
            ("GU at 60 deg", Some("60")),
            ("60", Some("60")),
            (" 20 ", Some("20")),
            ("gloss", None),
            ("°", None),
            ("ISO 2813", None),
        ] {
            assert_eq!(angle_in_method(method), angle, "{method:?}");
        }
    }
}
