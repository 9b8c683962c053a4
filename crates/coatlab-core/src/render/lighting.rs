//! The lighting a user chooses, by name or file, and the one builder from that
//! choice to an [`Environment`] on a wavelength grid. The command line, the
//! designer's window and the benchmarks all go through [`Lighting::build`].

use std::fmt;
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::colour::cie::Illuminant;
use crate::colour::spectrum::Channels;
use crate::render::environment::{Environment, EnvironmentError};

/// A lighting setup or an environment map file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Lighting {
    /// Photo studio: softboxes, cyclorama ([`Environment::studio`]).
    Studio,
    /// Paint light booth under this illuminant ([`Environment::booth`]).
    Booth(Illuminant),
    /// Sun and clear sky ([`Environment::outdoor`]).
    Outdoor,
    /// The same radiance from every direction, no floor: the white furnace.
    Uniform,
    /// An equirectangular map, Radiance `.hdr` or OpenEXR `.exr`
    /// ([`Environment::from_image`]).
    Map(PathBuf),
}

/// A name that is neither a lighting setup nor, by its look, a file.
#[derive(Debug, Error, PartialEq, Eq)]
#[error("'{0}': not a lighting setup ({names})", names = Lighting::SETUP_NAMES.join(", "))]
pub struct UnknownLighting(pub String);

impl Lighting {
    /// The setups a user picks from, in the order menus list them.
    pub const SETUPS: [Lighting; 5] = [
        Lighting::Studio,
        Lighting::Booth(Illuminant::D65),
        Lighting::Booth(Illuminant::A),
        Lighting::Booth(Illuminant::F11),
        Lighting::Outdoor,
    ];

    /// The names of [`Self::SETUPS`] on the command line, in the same order.
    pub const SETUP_NAMES: [&'static str; 5] =
        ["studio", "booth-d65", "booth-a", "booth-f11", "outdoor"];

    /// A setup's command-line name (`studio`, `booth-d65`, …, `uniform`), or a map
    /// file's path.
    pub fn name(&self) -> String {
        match self {
            Lighting::Studio => "studio".to_owned(),
            Lighting::Booth(illuminant) => {
                format!("booth-{}", illuminant.to_string().to_ascii_lowercase())
            }
            Lighting::Outdoor => "outdoor".to_owned(),
            Lighting::Uniform => "uniform".to_owned(),
            Lighting::Map(path) => path.display().to_string(),
        }
    }

    /// What a menu shows: "Studio", "Light booth D65", …, "Environment map".
    pub fn label(&self) -> String {
        match self {
            Lighting::Studio => "Studio".to_owned(),
            Lighting::Booth(illuminant) => format!("Light booth {illuminant}"),
            Lighting::Outdoor => "Outdoor".to_owned(),
            Lighting::Uniform => "Uniform (furnace)".to_owned(),
            Lighting::Map(_) => "Environment map".to_owned(),
        }
    }

    /// A setup by its command-line name (case-insensitive; `uniform` included).
    pub fn setup(name: &str) -> Result<Lighting, UnknownLighting> {
        let wanted = name.trim().to_ascii_lowercase();
        if wanted == "uniform" {
            return Ok(Lighting::Uniform);
        }
        Self::SETUPS
            .into_iter()
            .find(|setup| setup.name() == wanted)
            .ok_or_else(|| UnknownLighting(name.to_owned()))
    }

    /// A setup by name, or else a map file when `name` looks like a path (it has a
    /// dot or a path separator, or names an existing file). A bare word that is no
    /// setup is an [`UnknownLighting`], not a missing file.
    pub fn parse(name: &str) -> Result<Lighting, UnknownLighting> {
        Self::setup(name).or_else(|unknown| {
            let looks_like_path = name.contains(['.', '/', std::path::MAIN_SEPARATOR]);
            if looks_like_path || Path::new(name).exists() {
                Ok(Lighting::Map(PathBuf::from(name)))
            } else {
                Err(unknown)
            }
        })
    }

    /// The environment on `channels` (a wavelength grid, or linear sRGB). Only a
    /// map can fail (its file is read here).
    pub fn build(
        &self,
        channels: &(impl Into<Channels> + Copy),
    ) -> Result<Environment, EnvironmentError> {
        let channels: Channels = (*channels).into();
        Ok(match self {
            Lighting::Studio => Environment::studio(&channels),
            Lighting::Booth(illuminant) => Environment::booth(*illuminant, &channels),
            Lighting::Outdoor => Environment::outdoor(&channels),
            Lighting::Uniform => Environment::uniform(&channels),
            Lighting::Map(path) => Environment::from_image(path, &channels)?,
        })
    }
}

impl fmt::Display for Lighting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::spectrum::WavelengthGrid;
    use crate::render::environment::EnvironmentKind;

    #[test]
    fn every_setup_name_parses_back_to_its_setup() {
        for (setup, name) in Lighting::SETUPS.iter().zip(Lighting::SETUP_NAMES) {
            assert_eq!(setup.name(), name);
            assert_eq!(Lighting::parse(name).as_ref(), Ok(setup));
            assert_eq!(Lighting::parse(&name.to_uppercase()).as_ref(), Ok(setup));
        }
        assert_eq!(Lighting::parse("uniform"), Ok(Lighting::Uniform));
    }

    #[test]
    fn a_bare_unknown_word_is_refused_and_a_path_is_a_map() {
        let unknown = Lighting::parse("studoi").unwrap_err();
        assert!(unknown.to_string().contains("'studoi'"), "{unknown}");
        assert!(unknown.to_string().contains("booth-f11"), "{unknown}");
        assert_eq!(
            Lighting::parse("maps/sky.hdr"),
            Ok(Lighting::Map(PathBuf::from("maps/sky.hdr")))
        );
    }

    #[test]
    fn built_setups_report_their_own_kind() {
        let grid = WavelengthGrid::visible(16).unwrap();
        for setup in Lighting::SETUPS.iter().chain([&Lighting::Uniform]) {
            let environment = setup.build(&grid).unwrap();
            let expected = match setup {
                Lighting::Studio => EnvironmentKind::Studio,
                Lighting::Booth(illuminant) => EnvironmentKind::Booth(*illuminant),
                Lighting::Outdoor => EnvironmentKind::Outdoor,
                Lighting::Uniform => EnvironmentKind::Uniform,
                Lighting::Map(_) => unreachable!("no map among the set-ups"),
            };
            assert_eq!(environment.kind(), expected, "{setup:?}");
        }
    }

    #[test]
    fn a_missing_map_file_is_an_error_naming_it() {
        let grid = WavelengthGrid::visible(16).unwrap();
        let error = Lighting::Map(PathBuf::from("/nonexistent/sky.hdr"))
            .build(&grid)
            .unwrap_err();
        assert!(
            error.to_string().contains("/nonexistent/sky.hdr"),
            "{error}"
        );
    }
}
