//! Textures of glTF materials: images decoded with the `image` crate (PNG and JPEG),
//! kept as 8-bit RGBA mip-map chains, and looked up with trilinear filtering.
//!
//! | step | what happens |
//! |---|---|
//! | header | the image's size is read from its header first; more than [`MAX_TEXTURE_PIXELS`] pixels is refused before anything is decoded |
//! | decode | PNG or JPEG (by MIME type, else by the first bytes) to 8-bit RGBA; 16-bit PNGs are rounded to 8 bits |
//! | mip-maps | 2 × 2 box filter down to 1 × 1; colour textures ([`TexelEncoding::Srgb`]) are averaged in linear light and re-encoded, data textures (roughness, normals) as stored |
//! | look-up | trilinear: bilinear in the two levels around the level of detail, blended; the wrap modes of the glTF sampler per axis |
//!
//! The level of detail comes from the caller's footprint (how many texels a ray's
//! cone covers at the hit, see `render::texturing`), so distant textures are
//! averaged rather than point-sampled and do not alias. glTF's magnification and
//! minification filters are not followed: every look-up is filtered this way.
//!
//! An image that cannot be used (too large, truncated, a format other than PNG or
//! JPEG) is a [`TextureError`]; the loader turns it into a warning and
//! the material's factor stands in.

use std::io::Cursor;
use std::sync::{Arc, OnceLock};

/// Most pixels a texture's header may claim: 8192 × 8192. A larger image would take
/// more than 350 MB with its mip-maps; a car model's textures are 4096² at most.
pub const MAX_TEXTURE_PIXELS: u64 = 8192 * 8192;

/// How a texture's bytes encode its values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TexelEncoding {
    /// sRGB-encoded colour (base colour, emission): decoded to linear on look-up.
    Srgb,
    /// Linear data (metallic-roughness, normals, occlusion): the byte / 255.
    Linear,
}

/// The wrap mode of one texture axis (glTF sampler `wrapS`, `wrapT`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WrapMode {
    /// The texture repeats (glTF's default).
    #[default]
    Repeat,
    /// The texture repeats, every other copy mirrored.
    MirroredRepeat,
    /// Coordinates outside [0, 1] take the edge texel.
    ClampToEdge,
}

impl WrapMode {
    /// Texel index `i` of an axis `size` texels long, wrapped into [0, size).
    #[inline]
    fn wrap(self, i: i64, size: u32) -> usize {
        let n = i64::from(size.max(1));
        let wrapped = match self {
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::ClampToEdge => i.clamp(0, n - 1),
            WrapMode::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m >= n { 2 * n - 1 - m } else { m }
            }
        };
        wrapped as usize
    }
}

/// Why an image cannot be used as a texture, naming the image.
#[derive(Debug, thiserror::Error)]
#[error("image '{image}': {problem}")]
pub struct TextureError {
    /// The image's name (its file, or its index and buffer view).
    pub image: String,
    /// What is wrong with it.
    pub problem: TextureProblem,
}

/// What is wrong with an image.
#[derive(Debug, thiserror::Error)]
pub enum TextureProblem {
    /// The header claims more pixels than [`MAX_TEXTURE_PIXELS`].
    #[error("its header claims {width} × {height} pixels, more than the limit of {limit}")]
    TooLarge { width: u32, height: u32, limit: u64 },
    /// Not PNG or JPEG.
    #[error("unsupported format ({0}); PNG and JPEG are supported")]
    Unsupported(String),
    /// Truncated or corrupt data.
    #[error("cannot be decoded: {0}")]
    Corrupt(String),
}

/// One level of a mip-map chain.
#[derive(Debug, Clone, PartialEq)]
struct MipLevel {
    width: u32,
    height: u32,
    texels: Vec<[u8; 4]>,
}

impl MipLevel {
    #[inline]
    fn texel(&self, x: usize, y: usize) -> [u8; 4] {
        self.texels[y * self.width as usize + x]
    }
}

/// An image as a texture: RGBA, 8 bits per channel, with its mip-maps.
#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    name: String,
    encoding: TexelEncoding,
    levels: Vec<MipLevel>,
}

impl Texture {
    /// Decodes a PNG or JPEG image (`mime`, when given, says which; otherwise the
    /// first bytes do), checking its header against [`MAX_TEXTURE_PIXELS`] before
    /// decoding. `name` names the image in errors.
    pub fn decode(
        name: &str,
        bytes: &[u8],
        mime: Option<&str>,
        encoding: TexelEncoding,
    ) -> Result<Self, TextureError> {
        Self::decode_with_limit(name, bytes, mime, encoding, MAX_TEXTURE_PIXELS)
    }

    /// [`Self::decode`] with another pixel limit.
    pub fn decode_with_limit(
        name: &str,
        bytes: &[u8],
        mime: Option<&str>,
        encoding: TexelEncoding,
        limit: u64,
    ) -> Result<Self, TextureError> {
        let fail = |problem| TextureError {
            image: name.to_owned(),
            problem,
        };
        let format = match mime {
            Some("image/png") => image::ImageFormat::Png,
            Some("image/jpeg") => image::ImageFormat::Jpeg,
            _ => image::guess_format(bytes)
                .map_err(|e| fail(TextureProblem::Unsupported(e.to_string())))?,
        };
        if !matches!(format, image::ImageFormat::Png | image::ImageFormat::Jpeg) {
            return Err(fail(TextureProblem::Unsupported(format!("{format:?}"))));
        }
        let corrupt = |e: image::ImageError| fail(TextureProblem::Corrupt(e.to_string()));
        let reader = || image::ImageReader::with_format(Cursor::new(bytes), format);
        let (width, height) = reader().into_dimensions().map_err(corrupt)?;
        if u64::from(width) * u64::from(height) > limit {
            return Err(fail(TextureProblem::TooLarge {
                width,
                height,
                limit,
            }));
        }
        if width == 0 || height == 0 {
            return Err(fail(TextureProblem::Corrupt(
                "the image has no pixels".into(),
            )));
        }
        let mut reader = reader();
        // The decoder's own allocation guard, set to what the header allowed
        // (16-bit RGBA at most), against a header that lies about the data.
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(width);
        limits.max_image_height = Some(height);
        limits.max_alloc = Some(u64::from(width) * u64::from(height) * 8 + (1 << 20));
        reader.limits(limits);
        let decoded = reader.decode().map_err(corrupt)?.into_rgba8();
        let texels = decoded.pixels().map(|p| p.0).collect();
        Ok(Self::from_rgba8(name, width, height, texels, encoding))
    }

    /// A texture from RGBA texels in rows from the top (the image's first row is
    /// at v = 0, as in glTF), with its mip-maps built.
    ///
    /// # Panics
    /// If `texels` does not hold `width × height` texels or either size is 0.
    pub fn from_rgba8(
        name: &str,
        width: u32,
        height: u32,
        texels: Vec<[u8; 4]>,
        encoding: TexelEncoding,
    ) -> Self {
        assert!(width > 0 && height > 0, "texture without texels");
        assert_eq!(
            texels.len(),
            width as usize * height as usize,
            "texel count"
        );
        let mut levels = vec![MipLevel {
            width,
            height,
            texels,
        }];
        while let Some(last) = levels.last()
            && (last.width > 1 || last.height > 1)
        {
            let next = downsample(last, encoding);
            levels.push(next);
        }
        Self {
            name: name.to_owned(),
            encoding,
            levels,
        }
    }

    /// The name it was loaded under (file name or image index).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Width and height of the full-resolution level, texels.
    pub fn size(&self) -> (u32, u32) {
        (self.levels[0].width, self.levels[0].height)
    }

    /// Number of mip-map levels (1 × 1 included).
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Bytes the texels of every level take.
    pub fn memory_bytes(&self) -> usize {
        self.levels.iter().map(|l| l.texels.len() * 4).sum()
    }

    /// The filtered value at texture coordinates `uv` (after any transform), linear
    /// (sRGB-decoded for [`TexelEncoding::Srgb`]), RGBA in [0, 1]. `lod` is the
    /// level of detail: log2 of the footprint's width in texels of level 0 (0 or
    /// less: full resolution; non-finite counts as 0).
    pub fn sample(&self, uv: [f32; 2], lod: f32, wrap: [WrapMode; 2]) -> [f32; 4] {
        let top = (self.levels.len() - 1) as f32;
        let lod = if lod.is_finite() {
            lod.clamp(0.0, top)
        } else {
            0.0
        };
        let base = lod.floor();
        let blend = lod - base;
        let fine = self.bilinear(base as usize, uv, wrap);
        if blend <= 0.0 {
            return fine;
        }
        let coarse = self.bilinear(base as usize + 1, uv, wrap);
        std::array::from_fn(|k| fine[k] + blend * (coarse[k] - fine[k]))
    }

    /// Bilinear look-up in level `level`.
    fn bilinear(&self, level: usize, uv: [f32; 2], wrap: [WrapMode; 2]) -> [f32; 4] {
        let l = &self.levels[level];
        // Texel centres at half-integers; non-finite coordinates read texel 0.
        let finite = |x: f32| if x.is_finite() { x } else { 0.0 };
        let x = finite(uv[0]) * l.width as f32 - 0.5;
        let y = finite(uv[1]) * l.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        // Far outside [0, 1] the f32 → i64 cast saturates; wrapping stays in range.
        let (x0, y0) = (x0 as i64, y0 as i64);
        let xs = [
            wrap[0].wrap(x0, l.width),
            wrap[0].wrap(x0.saturating_add(1), l.width),
        ];
        let ys = [
            wrap[1].wrap(y0, l.height),
            wrap[1].wrap(y0.saturating_add(1), l.height),
        ];
        let decode = decode_table(self.encoding);
        let mut out = [0.0f32; 4];
        for (j, &yy) in ys.iter().enumerate() {
            let wy = if j == 0 { 1.0 - fy } else { fy };
            for (i, &xx) in xs.iter().enumerate() {
                let w = wy * if i == 0 { 1.0 - fx } else { fx };
                let t = l.texel(xx, yy);
                for k in 0..3 {
                    out[k] += w * decode[usize::from(t[k])];
                }
                out[3] += w * f32::from(t[3]) / 255.0;
            }
        }
        out
    }
}

/// Byte → value per encoding (alpha is always linear).
fn decode_table(encoding: TexelEncoding) -> &'static [f32; 256] {
    static SRGB: OnceLock<[f32; 256]> = OnceLock::new();
    static LINEAR: OnceLock<[f32; 256]> = OnceLock::new();
    match encoding {
        TexelEncoding::Srgb => {
            SRGB.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)))
        }
        TexelEncoding::Linear => LINEAR.get_or_init(|| std::array::from_fn(|i| i as f32 / 255.0)),
    }
}

/// The sRGB transfer function's inverse (IEC 61966-2-1).
fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// The sRGB transfer function (IEC 61966-2-1), for re-encoding averaged texels.
fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// The next coarser level: each texel the mean of (up to) 2 × 2 of `level`'s,
/// colour averaged in linear light.
fn downsample(level: &MipLevel, encoding: TexelEncoding) -> MipLevel {
    let width = level.width.div_ceil(2).max(1);
    let height = level.height.div_ceil(2).max(1);
    let decode = decode_table(encoding);
    let mut texels = Vec::with_capacity(width as usize * height as usize);
    for y in 0..height as usize {
        for x in 0..width as usize {
            let mut sum = [0.0f32; 4];
            let mut n = 0.0f32;
            for yy in (2 * y)..(2 * y + 2).min(level.height as usize) {
                for xx in (2 * x)..(2 * x + 2).min(level.width as usize) {
                    let t = level.texel(xx, yy);
                    for k in 0..3 {
                        sum[k] += decode[usize::from(t[k])];
                    }
                    sum[3] += f32::from(t[3]) / 255.0;
                    n += 1.0;
                }
            }
            let encode = |v: f32, colour: bool| {
                let v = (v / n).clamp(0.0, 1.0);
                let v = if colour && encoding == TexelEncoding::Srgb {
                    linear_to_srgb(v)
                } else {
                    v
                };
                (v * 255.0 + 0.5) as u8
            };
            texels.push([
                encode(sum[0], true),
                encode(sum[1], true),
                encode(sum[2], true),
                encode(sum[3], false),
            ]);
        }
    }
    MipLevel {
        width,
        height,
        texels,
    }
}

/// KHR_texture_transform: uv' = T · R · S · uv (offset, rotation counter-clockwise
/// in radians, scale), as the extension's reference GLSL applies it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UvTransform {
    /// Offset, in units of the texture (added last).
    pub offset: [f32; 2],
    /// Rotation, radians.
    pub rotation_rad: f32,
    /// Scale per axis (applied first).
    pub scale: [f32; 2],
}

impl Default for UvTransform {
    fn default() -> Self {
        Self {
            offset: [0.0; 2],
            rotation_rad: 0.0,
            scale: [1.0; 2],
        }
    }
}

impl UvTransform {
    /// The transformed coordinates.
    #[inline]
    pub fn apply(&self, uv: [f32; 2]) -> [f32; 2] {
        let (s, c) = self.rotation_rad.sin_cos();
        let [x, y] = [uv[0] * self.scale[0], uv[1] * self.scale[1]];
        // The reference's column-major rotation mat3(c, s, 0, −s, c, 0, 0, 0, 1).
        [
            c * x - s * y + self.offset[0],
            s * x + c * y + self.offset[1],
        ]
    }

    /// How much the transform stretches lengths (the larger scale), for the
    /// footprint of a look-up.
    pub fn stretch(&self) -> f32 {
        self.scale[0].abs().max(self.scale[1].abs())
    }
}

/// A material's use of a texture: which image, which texture-coordinate set,
/// the transform and the sampler's wrap modes.
#[derive(Debug, Clone, PartialEq)]
pub struct TextureRef {
    /// The decoded image (shared by every material that uses it the same way).
    pub texture: Arc<Texture>,
    /// `TEXCOORD_n` set: 0 or 1.
    pub texcoord: u32,
    /// KHR_texture_transform (identity without it).
    pub transform: UvTransform,
    /// Wrap modes of the u and v axes.
    pub wrap: [WrapMode; 2],
    /// The normal map's `scale` or the occlusion map's `strength`; 1 for the others.
    pub scale: f32,
}

impl TextureRef {
    /// A use of `texture` with set 0, no transform, repeat on both axes, scale 1.
    pub fn new(texture: Arc<Texture>) -> Self {
        Self {
            texture,
            texcoord: 0,
            transform: UvTransform::default(),
            wrap: [WrapMode::Repeat; 2],
            scale: 1.0,
        }
    }

    /// The filtered value at `uv` (before the transform), `lod` as for
    /// [`Texture::sample`] at the untransformed scale.
    #[inline]
    pub fn sample(&self, uv: [f32; 2], lod: f32) -> [f32; 4] {
        let lod = lod + self.transform.stretch().max(1e-6).log2();
        self.texture
            .sample(self.transform.apply(uv), lod, self.wrap)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(size: u32) -> Texture {
        let texels = (0..size * size)
            .map(|i| {
                let (x, y) = (i % size, i / size);
                if (x + y) % 2 == 0 {
                    [255, 255, 255, 255]
                } else {
                    [0, 0, 0, 255]
                }
            })
            .collect();
        Texture::from_rgba8("checker", size, size, texels, TexelEncoding::Srgb)
    }

    #[test]
    fn mip_chain_reaches_one_texel_and_averages_in_linear_light() {
        let t = checker(8);
        assert_eq!(t.level_count(), 4);
        // A black and white checker averages to linear 0.5 (sRGB byte 188).
        let far = t.sample([0.3, 0.7], 10.0, [WrapMode::Repeat; 2]);
        assert!((far[0] - 0.5).abs() < 0.01, "{far:?}");
        // At full resolution a texel centre reads its own value.
        let near = t.sample([0.5 / 8.0, 0.5 / 8.0], 0.0, [WrapMode::Repeat; 2]);
        assert!((near[0] - 1.0).abs() < 1e-6, "{near:?}");
        let memory = t.memory_bytes();
        assert_eq!(memory, 4 * (64 + 16 + 4 + 1));
    }

    #[test]
    fn wrap_modes_fold_indices_into_the_texture() {
        assert_eq!(WrapMode::Repeat.wrap(-1, 4), 3);
        assert_eq!(WrapMode::Repeat.wrap(9, 4), 1);
        assert_eq!(WrapMode::ClampToEdge.wrap(-7, 4), 0);
        assert_eq!(WrapMode::ClampToEdge.wrap(70, 4), 3);
        assert_eq!(WrapMode::MirroredRepeat.wrap(4, 4), 3);
        assert_eq!(WrapMode::MirroredRepeat.wrap(-1, 4), 0);
        assert_eq!(WrapMode::MirroredRepeat.wrap(8, 4), 0);
        assert_eq!(WrapMode::Repeat.wrap(i64::MAX, 4), 3);
    }

    #[test]
    fn transform_follows_the_extension_reference() {
        let t = UvTransform {
            offset: [0.5, 0.25],
            rotation_rad: std::f32::consts::FRAC_PI_2,
            scale: [2.0, 1.0],
        };
        // (1, 0) scaled to (2, 0), turned a quarter counter-clockwise to (0, 2),
        // then offset.
        let [u, v] = t.apply([1.0, 0.0]);
        assert!((u - 0.5).abs() < 1e-6 && (v - 2.25).abs() < 1e-6, "{u} {v}");
    }

    #[test]
    fn bad_images_are_errors_naming_them() {
        let e = Texture::decode("x.png", b"not an image", None, TexelEncoding::Linear)
            .expect_err("not an image");
        assert!(matches!(e.problem, TextureProblem::Unsupported(_)));
        assert!(e.to_string().contains("x.png"));
        let gif = b"GIF89a\x01\x00\x01\x00\x00\x00\x00;";
        let e = Texture::decode("y.gif", gif, None, TexelEncoding::Linear).expect_err("a GIF");
        assert!(matches!(e.problem, TextureProblem::Unsupported(_)), "{e:?}");
    }
}
