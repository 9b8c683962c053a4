//! The text attributes of an EXR header, shared by the film's EXR tests and the
//! `coatlab render` end-to-end tests.

use std::collections::BTreeMap;

use exr::prelude::{AttributeValue, Text};

/// The text attributes among `attributes` (a header's own and shared lists,
/// chained), by name, their UTF-8 values; other attribute kinds are left out.
pub fn text_attributes<'a>(
    attributes: impl IntoIterator<Item = (&'a Text, &'a AttributeValue)>,
) -> BTreeMap<String, String> {
    attributes
        .into_iter()
        .filter_map(|(name, value)| match value {
            AttributeValue::Text(text) => Some((
                name.to_string(),
                String::from_utf8(text.bytes().to_vec()).expect("UTF-8"),
            )),
            _ => None,
        })
        .collect()
}

/// `pairs` of attribute name and value as [`text_attributes`] gives them, to compare
/// with.
pub fn expected_attributes(pairs: &[(&str, &str)]) -> BTreeMap<String, String> {
    pairs
        .iter()
        .map(|&(k, v)| (k.to_owned(), v.to_owned()))
        .collect()
}
