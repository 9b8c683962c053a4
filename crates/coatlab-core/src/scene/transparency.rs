//! What a material lets through: glTF's `alphaMode` with the base colour's alpha,
//! and glass (`KHR_materials_transmission`, `KHR_materials_ior`,
//! `KHR_materials_volume`), as the file gives them. `render::glass` says how the
//! tracer renders them; `docs/materials.md` has the table.

use palette::LinSrgb;

/// glTF's `alphaMode`: how the base colour's alpha (factor × texture) is read.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum AlphaMode {
    /// Alpha is ignored: the surface is solid.
    #[default]
    Opaque,
    /// The surface is absent where alpha is below `cutoff` and solid elsewhere.
    Mask {
        /// glTF `alphaCutoff`, in [0, 1] (0.5 when the file gives none).
        cutoff: f32,
    },
    /// The surface covers the fraction alpha of each point (a veil, tinted
    /// windows without transmission).
    Blend,
}

/// The alpha and glass parameters of one material.
///
/// | field | glTF | unit | range | default |
/// |---|---|---|---|---|
/// | `alpha` | `baseColorFactor[3]` | 1 | [0, 1] | 1 |
/// | `alpha_mode` | `alphaMode`, `alphaCutoff` | — | OPAQUE, MASK, BLEND | OPAQUE |
/// | `transmission` | `transmissionFactor` | 1 | [0, 1] | 0 |
/// | `ior` | `KHR_materials_ior.ior` | 1 | ≥ 1 | 1.5 |
/// | `thickness_m` | `thicknessFactor` | m (scene units) | ≥ 0; 0 = thin-walled | 0 |
/// | `attenuation_color` | `attenuationColor` | linear sRGB | [0, 1] | white |
/// | `attenuation_distance_m` | `attenuationDistance` | m | > 0 | ∞ |
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transparency {
    /// Base colour alpha factor (the base colour texture's alpha multiplies it).
    pub alpha: f32,
    /// How alpha is read.
    pub alpha_mode: AlphaMode,
    /// Fraction of the surface that is glass rather than the opaque
    /// metallic-roughness material (`transmissionTexture` is not read).
    pub transmission: f32,
    /// Index of refraction of the glass, the same at every wavelength (no
    /// dispersion).
    pub ior: f32,
    /// `thicknessFactor`: 0 makes the surface a thin-walled pane, more a closed
    /// volume that refracts (the value itself is a rasteriser's hint; the tracer
    /// measures the path inside the mesh).
    pub thickness_m: f32,
    /// The colour white light takes after `attenuation_distance_m` inside the volume.
    pub attenuation_color: LinSrgb<f32>,
    /// Distance over which light inside the volume takes `attenuation_color`.
    pub attenuation_distance_m: f32,
}

impl Default for Transparency {
    fn default() -> Self {
        Self {
            alpha: 1.0,
            alpha_mode: AlphaMode::Opaque,
            transmission: 0.0,
            ior: 1.5,
            thickness_m: 0.0,
            attenuation_color: LinSrgb::new(1.0, 1.0, 1.0),
            attenuation_distance_m: f32::INFINITY,
        }
    }
}

impl Transparency {
    /// A thin-walled pane (a car window): glass throughout, index `ior`, its
    /// transmission tinted by the material's base colour.
    pub fn thin_glass(ior: f32) -> Self {
        Self {
            transmission: 1.0,
            ior,
            ..Self::default()
        }
    }

    /// Whether anything can be seen through the material.
    pub fn is_see_through(&self) -> bool {
        self.transmission > 0.0 || self.alpha_mode != AlphaMode::Opaque
    }

    /// Whether the glass part is a closed volume that refracts.
    pub fn is_volume(&self) -> bool {
        self.thickness_m > 0.0
    }
}
