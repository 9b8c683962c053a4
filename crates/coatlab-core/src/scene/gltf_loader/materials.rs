//! The loader's materials: glTF metallic-roughness materials with their extensions,
//! and the images their textures read (buffer views, files, data URIs), each bad
//! image a warning that names it.

use super::*;

pub(super) fn document_materials(
    document: &gltf::Document,
    images: &mut ImageSource<'_>,
    warnings: &mut Vec<String>,
) -> Vec<SceneMaterial> {
    document
        .materials()
        .enumerate()
        .map(|(i, m)| {
            let name = m
                .name()
                .map_or_else(|| format!("material {i}"), str::to_owned);
            let pbr = m.pbr_metallic_roughness();
            let [r, g, b, alpha] = pbr.base_color_factor().map(|c| {
                if c.is_finite() {
                    c.clamp(0.0, 1.0)
                } else {
                    1.0
                }
            });
            let mut texture = |slot: &str, info: Option<TexInfo<'_>>, encoding| {
                let info = info?;
                images.reference(&name, slot, info, encoding, warnings)
            };
            let base_color_texture = texture(
                "base-colour",
                pbr.base_color_texture().map(TexInfo::from_info),
                TexelEncoding::Srgb,
            );
            let metallic_roughness_texture = texture(
                "metallic-roughness",
                pbr.metallic_roughness_texture().map(TexInfo::from_info),
                TexelEncoding::Linear,
            );
            let normal = m.normal_texture().map(|t| {
                let transform = t.extension_value(TRANSFORM);
                TexInfo::scaled(t.texture(), t.tex_coord(), transform, t.scale())
            });
            let occlusion = m.occlusion_texture().map(|t| {
                let transform = t.extension_value(TRANSFORM);
                TexInfo::scaled(t.texture(), t.tex_coord(), transform, t.strength())
            });
            let normal_texture = texture("normal", normal, TexelEncoding::Linear);
            let occlusion_texture = texture("occlusion", occlusion, TexelEncoding::Linear);
            let emissive_texture = texture(
                "emissive",
                m.emissive_texture().map(TexInfo::from_info),
                TexelEncoding::Srgb,
            );
            let strength = m.emissive_strength().unwrap_or(1.0);
            let [er, eg, eb] = m.emissive_factor().map(|c| {
                let e = c * strength;
                if e.is_finite() { e.max(0.0) } else { 0.0 }
            });
            let (clearcoat, clearcoat_roughness) = clear_coat(&m, &name, warnings);
            let transparency = transparency(&m, &name, alpha, warnings);
            SceneMaterial {
                ior: transparency.ior,
                clearcoat,
                clearcoat_roughness,
                name,
                base_color: LinSrgb::new(r, g, b),
                roughness: finite_unit(pbr.roughness_factor()),
                metallic: finite_unit(pbr.metallic_factor()),
                area_m2: 0.0,
                base_color_texture,
                metallic_roughness_texture,
                normal_texture,
                occlusion_texture,
                emissive: LinSrgb::new(er, eg, eb),
                emissive_texture,
                transparency,
            }
        })
        .collect()
}

/// `KHR_materials_clearcoat`'s factor and roughness factor (0 and 0 without the
/// extension), read from its JSON (the `gltf` crate does not type it), each kept
/// in [0, 1]. Its textures are not read (`docs/materials.md`): a warning names
/// each one present, and the factor stands in.
fn clear_coat(material: &gltf::Material<'_>, name: &str, warnings: &mut Vec<String>) -> (f32, f32) {
    let Some(value) = material.extension_value("KHR_materials_clearcoat") else {
        return (0.0, 0.0);
    };
    for slot in [
        "clearcoatTexture",
        "clearcoatRoughnessTexture",
        "clearcoatNormalTexture",
    ] {
        if value.get(slot).is_some() {
            warnings.push(format!(
                "material '{name}': KHR_materials_clearcoat {slot} not read, its factor stands in"
            ));
        }
    }
    let factor = |key: &str| {
        value
            .get(key)
            .and_then(json::Value::as_f64)
            .map_or(0.0, |x| finite_unit(x as f32))
    };
    (
        factor("clearcoatFactor"),
        factor("clearcoatRoughnessFactor"),
    )
}

/// A material's alpha mode and glass extensions; each value out of its range a
/// warning naming the material, with the default standing in.
fn transparency(
    m: &gltf::Material<'_>,
    name: &str,
    alpha: f32,
    warnings: &mut Vec<String>,
) -> Transparency {
    let defaults = Transparency::default();
    let checked =
        |what: &str, value: f32, valid: bool, default: f32, warnings: &mut Vec<String>| {
            if valid {
                value
            } else {
                warnings.push(format!(
                    "material '{name}': {what} {value} is out of range, {default} used"
                ));
                default
            }
        };
    let alpha_mode = match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
        gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        gltf::material::AlphaMode::Mask => {
            let cutoff = m.alpha_cutoff().unwrap_or(0.5);
            AlphaMode::Mask {
                cutoff: checked(
                    "alphaCutoff",
                    cutoff,
                    (0.0..=1.0).contains(&cutoff),
                    0.5,
                    warnings,
                ),
            }
        }
    };
    let transmission = m.transmission().map_or(0.0, |t| {
        if t.transmission_texture().is_some() {
            warnings.push(format!(
                "material '{name}': transmission texture not read, its factor stands in"
            ));
        }
        let f = t.transmission_factor();
        checked(
            "transmissionFactor",
            f,
            (0.0..=1.0).contains(&f),
            defaults.transmission,
            warnings,
        )
    });
    let ior = m.ior().map_or(defaults.ior, |ior| {
        checked(
            "KHR_materials_ior ior",
            ior,
            ior >= 1.0 && ior.is_finite(),
            defaults.ior,
            warnings,
        )
    });
    let mut transparency = Transparency {
        alpha,
        alpha_mode,
        transmission,
        ior,
        ..defaults
    };
    if let Some(volume) = m.volume() {
        if volume.thickness_texture().is_some() {
            warnings.push(format!(
                "material '{name}': thickness texture not read, its factor stands in"
            ));
        }
        let thickness = volume.thickness_factor();
        transparency.thickness_m = checked(
            "KHR_materials_volume thicknessFactor",
            thickness,
            thickness >= 0.0 && thickness.is_finite(),
            defaults.thickness_m,
            warnings,
        );
        let distance = volume.attenuation_distance();
        transparency.attenuation_distance_m = checked(
            "KHR_materials_volume attenuationDistance",
            distance,
            distance > 0.0,
            defaults.attenuation_distance_m,
            warnings,
        );
        let colour = volume.attenuation_color();
        let valid = colour.iter().all(|c| (0.0..=1.0).contains(c));
        if valid {
            let [r, g, b] = colour;
            transparency.attenuation_color = LinSrgb::new(r, g, b);
        } else {
            warnings.push(format!(
                "material '{name}': KHR_materials_volume attenuationColor {colour:?} is out of [0, 1], white used"
            ));
        }
    }
    transparency
}

/// A material's texture slot as glTF gives it, before its image is decoded.
struct TexInfo<'a> {
    texture: gltf::Texture<'a>,
    tex_coord: u32,
    /// KHR_texture_transform, with its `texCoord` override.
    transform: Option<(UvTransform, Option<u32>)>,
    scale: f32,
}

impl<'a> TexInfo<'a> {
    fn from_info(info: gltf::texture::Info<'a>) -> Self {
        Self {
            tex_coord: info.tex_coord(),
            transform: info.texture_transform().map(|t| {
                (
                    UvTransform {
                        offset: t.offset(),
                        rotation_rad: t.rotation(),
                        scale: t.scale(),
                    },
                    t.tex_coord(),
                )
            }),
            scale: 1.0,
            texture: info.texture(),
        }
    }
}

impl<'a> TexInfo<'a> {
    /// A normal or occlusion texture slot, with its scale or strength and its
    /// transform's JSON (the `gltf` crate types no transform on these slots).
    fn scaled(
        texture: gltf::Texture<'a>,
        tex_coord: u32,
        transform: Option<&json::Value>,
        scale: f32,
    ) -> Self {
        Self {
            texture,
            tex_coord,
            transform: transform.map(json_transform),
            scale,
        }
    }
}

/// The texture transform extension's name.
const TRANSFORM: &str = "KHR_texture_transform";

/// KHR_texture_transform read from its JSON (the normal and occlusion texture
/// infos, which the `gltf` crate does not type); missing or malformed members
/// keep their defaults.
fn json_transform(value: &json::Value) -> (UvTransform, Option<u32>) {
    let pair = |key: &str, default: [f32; 2]| {
        value
            .get(key)
            .and_then(json::Value::as_array)
            .and_then(|a| match a.as_slice() {
                [x, y] => Some([x.as_f64()? as f32, y.as_f64()? as f32]),
                _ => None,
            })
            .unwrap_or(default)
    };
    let transform = UvTransform {
        offset: pair("offset", [0.0; 2]),
        rotation_rad: value
            .get("rotation")
            .and_then(json::Value::as_f64)
            .unwrap_or(0.0) as f32,
        scale: pair("scale", [1.0; 2]),
    };
    let tex_coord = value
        .get("texCoord")
        .and_then(json::Value::as_u64)
        .map(|t| t.min(u64::from(u32::MAX)) as u32);
    (transform, tex_coord)
}

/// Where the images of a file come from, and those decoded so far (per image and
/// encoding: the same image used as colour and as data is decoded twice; a failure
/// is kept as its message, so each material that uses the image is told).
pub(super) struct ImageSource<'a> {
    pub(super) file: &'a Path,
    pub(super) buffers: &'a [Vec<u8>],
    pub(super) cache: HashMap<(usize, TexelEncoding), Result<Arc<Texture>, String>>,
}

impl ImageSource<'_> {
    /// The texture a material's `slot` uses; `None`, with a warning naming the
    /// material and the image, when it cannot be used (the factor stands in).
    fn reference(
        &mut self,
        material: &str,
        slot: &str,
        info: TexInfo<'_>,
        encoding: TexelEncoding,
        warnings: &mut Vec<String>,
    ) -> Option<TextureRef> {
        let (transform, tex_coord) = match info.transform {
            Some((t, set)) => (t, set.unwrap_or(info.tex_coord)),
            None => (UvTransform::default(), info.tex_coord),
        };
        let finite = transform
            .offset
            .iter()
            .chain(&transform.scale)
            .all(|x| x.is_finite())
            && transform.rotation_rad.is_finite();
        let result = if tex_coord > 1 {
            Err(format!(
                "TEXCOORD_{tex_coord} is not read (only sets 0 and 1)"
            ))
        } else if !finite {
            Err("KHR_texture_transform has non-finite values".into())
        } else {
            // Indices were validated with the document, so `source` finds its image.
            self.decoded(info.texture.source(), encoding)
        };
        match result {
            Ok(texture) => {
                let wrap = |mode| match mode {
                    gltf::texture::WrappingMode::ClampToEdge => WrapMode::ClampToEdge,
                    gltf::texture::WrappingMode::MirroredRepeat => WrapMode::MirroredRepeat,
                    gltf::texture::WrappingMode::Repeat => WrapMode::Repeat,
                };
                let sampler = info.texture.sampler();
                Some(TextureRef {
                    texture,
                    texcoord: tex_coord,
                    transform,
                    wrap: [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())],
                    scale: if info.scale.is_finite() {
                        info.scale
                    } else {
                        1.0
                    },
                })
            }
            Err(why) => {
                warnings.push(format!(
                    "material '{material}': {slot} texture not used, its factor stands in: {why}"
                ));
                None
            }
        }
    }

    fn decoded(
        &mut self,
        image: gltf::Image<'_>,
        encoding: TexelEncoding,
    ) -> Result<Arc<Texture>, String> {
        let key = (image.index(), encoding);
        if let Some(found) = self.cache.get(&key) {
            return found.clone();
        }
        let result = self.decode(&image, encoding);
        self.cache.insert(key, result.clone());
        result
    }

    fn decode(
        &self,
        image: &gltf::Image<'_>,
        encoding: TexelEncoding,
    ) -> Result<Arc<Texture>, String> {
        let label = |what: String| match image.name() {
            Some(name) => format!("{what} ('{name}')"),
            None => what,
        };
        let (name, bytes, mime) = match image.source() {
            gltf::image::Source::View { view, mime_type } => {
                let name = label(format!(
                    "image {} (buffer view {})",
                    image.index(),
                    view.index()
                ));
                let buffer = self.buffers.get(view.buffer().index());
                let start = view.offset();
                let bytes = buffer
                    .and_then(|b| b.get(start..start.checked_add(view.length())?))
                    .ok_or_else(|| {
                        format!("{name}: buffer view {} runs past its buffer", view.index())
                    })?;
                (
                    name,
                    std::borrow::Cow::Borrowed(bytes),
                    Some(mime_type.to_owned()),
                )
            }
            gltf::image::Source::Uri { uri, mime_type } if uri.starts_with("data:") => {
                let name = label(format!("image {} (data URI)", image.index()));
                let bytes = decode_data_uri(uri).map_err(|e| format!("{name}: {e}"))?;
                let mime = mime_type.map(str::to_owned).or_else(|| {
                    uri.strip_prefix("data:")
                        .and_then(|h| h.split([';', ',']).next())
                        .map(str::to_owned)
                });
                (name, std::borrow::Cow::Owned(bytes), mime)
            }
            gltf::image::Source::Uri { uri, mime_type } => {
                let dir = self.file.parent().unwrap_or(Path::new(""));
                let image_path = dir.join(percent_decode(uri));
                let name = image_path.display().to_string();
                let bytes =
                    std::fs::read(&image_path).map_err(|e| format!("cannot read {name}: {e}"))?;
                (
                    name,
                    std::borrow::Cow::Owned(bytes),
                    mime_type.map(str::to_owned),
                )
            }
        };
        Texture::decode(&name, &bytes, mime.as_deref(), encoding)
            .map(Arc::new)
            .map_err(|e| e.to_string())
    }
}

fn finite_unit(x: f32) -> f32 {
    if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        1.0
    }
}
