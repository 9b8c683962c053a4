//! The error of a render against a converged reference, as a viewer sees it
//! (docs/tradeoff.md, "Reference protocol").
//!
//! Images are compared as mean CIE XYZ per pixel (white at Y = 1, what a
//! [`Film`] accumulates), each pixel taken through the display pipeline
//! ([`crate::render::film::display_lab_of_xyz`]: exposure, tone mapping, clipping
//! to the sRGB gamut) to CIELAB, so the error is the CIEDE2000 of the colours on
//! screen:
//!
//! - per pixel: mean and 95th percentile of ΔE00 — noise and bias together;
//! - per region ([`Region`]): ΔE00 between the displayed colours of the region's
//!   mean XYZ in the two images — averaging over hundreds of pixels removes most
//!   of the noise, so what remains is bias (too few wavelengths, an approximate C,
//!   another lobe), which no amount of samples takes away.
//!
//! Regions come from the geometry, not from the picture: a ray through each pixel
//! centre classifies the pixel as painted body side (normal within 30° of
//! horizontal), painted top (bonnet, roof: normal within 45° of up — where the
//! overhead lights' highlight sits), floor, or none of these.

use std::path::Path;

use thiserror::Error;

use crate::colour::{Xyz, ciede2000};
use crate::io::atomic::write_bytes_atomically;
use crate::io::tagged::{TAGGED_HEADER_BYTES, tagged_header};
use crate::render::camera::Camera;
use crate::render::film::{DisplaySettings, DisplayTransform, Film};
use crate::render::geometry::Surface;
use crate::render::progressive::RenderScene;

/// File signature of [`XyzImage::write`] (version 1: little-endian u32 width and
/// height, then width × height × 3 f32).
const MAGIC: &[u8; 8] = b"COATXYZ1";
/// |normal_y| below this: a vertical panel (body side).
const SIDE_MAX_NORMAL_Y: f32 = 0.5;
/// normal_y above this: a top surface (bonnet, roof).
const TOP_MIN_NORMAL_Y: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// What went wrong comparing or storing images; each names what and where.
#[derive(Debug, Error)]
pub enum ImageErrorError {
    /// Two images of different sizes.
    #[error("cannot compare a {a_width}×{a_height} image with a {b_width}×{b_height} one")]
    SizeMismatch {
        a_width: u32,
        a_height: u32,
        b_width: u32,
        b_height: u32,
    },
    /// A pixel buffer that does not fit the size.
    #[error("{len} pixels do not make a {width}×{height} image")]
    BadBuffer { width: u32, height: u32, len: usize },
    /// Reading or writing a file.
    #[error("{path}: {error}")]
    Io { path: String, error: std::io::Error },
    /// A file that is not an XYZ image of this format.
    #[error("{path}: not a Coatlab XYZ image: {reason}")]
    BadFile { path: String, reason: String },
}

/// A picture as mean CIE XYZ per pixel (white at Y = 1), row-major from the top
/// left.
#[derive(Debug, Clone, PartialEq)]
pub struct XyzImage {
    width: u32,
    height: u32,
    pixels: Vec<[f32; 3]>,
}

impl XyzImage {
    /// An image from its pixels.
    pub fn new(width: u32, height: u32, pixels: Vec<[f32; 3]>) -> Result<Self, ImageErrorError> {
        if width == 0 || height == 0 || pixels.len() != width as usize * height as usize {
            return Err(ImageErrorError::BadBuffer {
                width,
                height,
                len: pixels.len(),
            });
        }
        Ok(Self {
            width,
            height,
            pixels,
        })
    }

    /// The means of a film (pixels without samples are black).
    pub fn from_film(film: &Film) -> Self {
        let mut pixels = Vec::with_capacity(film.width() as usize * film.height() as usize);
        let [x0, y0] = film.origin();
        for y in 0..film.height() {
            for x in 0..film.width() {
                let xyz = film.mean_xyz(x0 + x, y0 + y);
                pixels.push([xyz.x as f32, xyz.y as f32, xyz.z as f32]);
            }
        }
        Self {
            width: film.width(),
            height: film.height(),
            pixels,
        }
    }

    /// Width, pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height, pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixels, row-major.
    pub fn pixels(&self) -> &[[f32; 3]] {
        &self.pixels
    }

    /// The pixel-wise mean of two images of one size (two half references make
    /// the reference).
    pub fn average(&self, other: &XyzImage) -> Result<XyzImage, ImageErrorError> {
        self.check_same_size(other)?;
        let pixels = self
            .pixels
            .iter()
            .zip(&other.pixels)
            .map(|(a, b)| std::array::from_fn(|k| 0.5 * (a[k] + b[k])))
            .collect();
        Ok(Self { pixels, ..*self })
    }

    /// This image resized to `width` × `height` by bilinear interpolation between
    /// pixel centres (edges clamped): how a preview rendered at a lower resolution
    /// is shown at the full one.
    pub fn resized(&self, width: u32, height: u32) -> XyzImage {
        let (width, height) = (width.max(1), height.max(1));
        let sx = self.width as f32 / width as f32;
        let sy = self.height as f32 / height as f32;
        let at = |x: usize, y: usize| self.pixels[y * self.width as usize + x];
        let mut pixels = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            let fy = ((y as f32 + 0.5) * sy - 0.5).clamp(0.0, (self.height - 1) as f32);
            let (y0, ty) = (fy.floor() as usize, fy.fract());
            let y1 = (y0 + 1).min(self.height as usize - 1);
            for x in 0..width {
                let fx = ((x as f32 + 0.5) * sx - 0.5).clamp(0.0, (self.width - 1) as f32);
                let (x0, tx) = (fx.floor() as usize, fx.fract());
                let x1 = (x0 + 1).min(self.width as usize - 1);
                let (a, b, c, d) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
                pixels.push(std::array::from_fn(|k| {
                    let top = a[k] + tx * (b[k] - a[k]);
                    let bottom = c[k] + tx * (d[k] - c[k]);
                    top + ty * (bottom - top)
                }));
            }
        }
        XyzImage {
            width,
            height,
            pixels,
        }
    }

    /// Writes the image (see `MAGIC`); creates the folder.
    pub fn write(&self, path: &Path) -> Result<(), ImageErrorError> {
        let io = io_error(path);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(&io)?;
        }
        let mut bytes = Vec::with_capacity(16 + self.pixels.len() * 12);
        bytes.extend_from_slice(MAGIC);
        bytes.extend_from_slice(&self.width.to_le_bytes());
        bytes.extend_from_slice(&self.height.to_le_bytes());
        for v in self.pixels.iter().flatten() {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        // Atomically: an interrupted run leaves no half file.
        write_bytes_atomically(path, &bytes).map_err(|e| io(e.error))
    }

    /// Reads an image written by [`Self::write`].
    pub fn read(path: &Path) -> Result<XyzImage, ImageErrorError> {
        let bytes = std::fs::read(path).map_err(io_error(path))?;
        let name = path.display().to_string();
        let bad = |reason: String| ImageErrorError::BadFile {
            path: name.clone(),
            reason,
        };
        let Some([width, height]) = tagged_header(&bytes, MAGIC) else {
            return Err(bad("wrong signature".into()));
        };
        let want = TAGGED_HEADER_BYTES + width as usize * height as usize * 12;
        if bytes.len() != want {
            return Err(bad(format!(
                "{width}×{height} needs {want} bytes, the file has {}",
                bytes.len()
            )));
        }
        let pixels = bytes[TAGGED_HEADER_BYTES..]
            .chunks_exact(12)
            .map(|c| {
                std::array::from_fn(|k| {
                    f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]])
                })
            })
            .collect();
        XyzImage::new(width, height, pixels).map_err(|e| bad(e.to_string()))
    }

    fn check_same_size(&self, other: &XyzImage) -> Result<(), ImageErrorError> {
        check_same_size([self.width, self.height], [other.width, other.height])
    }
}

/// The parts of the picture whose mean colour measures bias.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Region {
    /// Painted, normal within 30° of horizontal: doors and wings, the body colour.
    BodySide,
    /// Painted, normal within 45° of up: bonnet and roof, under the overhead light.
    BonnetTop,
    /// The floor: light the paint sends onto it, the contact shadow.
    Floor,
}

impl Region {
    /// Every region, in table order.
    pub const ALL: [Region; 3] = [Region::BodySide, Region::BonnetTop, Region::Floor];

    /// Name for tables.
    pub fn label(self) -> &'static str {
        match self {
            Region::BodySide => "body side",
            Region::BonnetTop => "bonnet/top",
            Region::Floor => "floor",
        }
    }
}

/// Which pixels belong to each [`Region`], for one scene and view.
#[derive(Debug, Clone, PartialEq)]
pub struct RegionMasks {
    width: u32,
    height: u32,
    /// Per pixel: index into [`Region::ALL`], or `None`.
    labels: Vec<Option<u8>>,
}

impl RegionMasks {
    /// Classifies every pixel of `camera`'s image by the surface its centre ray
    /// hits first (see the module documentation).
    pub fn from_scene(scene: &RenderScene, camera: &Camera) -> Self {
        let (width, height) = (camera.width(), camera.height());
        let paint = scene.paint_materials();
        let mut labels = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                let (origin, dir) = camera.ray(x as f32 + 0.5, y as f32 + 0.5);
                let hit = scene.geometry().intersect(origin, dir, f32::INFINITY);
                let region = hit.and_then(|hit| match hit.surface {
                    Surface::Floor => Some(Region::Floor),
                    Surface::Mesh { material } if paint.contains(&material) => {
                        let ny = hit.shading_normal[1];
                        if ny.abs() < SIDE_MAX_NORMAL_Y {
                            Some(Region::BodySide)
                        } else if ny > TOP_MIN_NORMAL_Y {
                            Some(Region::BonnetTop)
                        } else {
                            None
                        }
                    }
                    Surface::Mesh { .. } => None,
                });
                labels.push(
                    region.map(|r| Region::ALL.iter().position(|&q| q == r).unwrap_or(0) as u8),
                );
            }
        }
        Self {
            width,
            height,
            labels,
        }
    }

    /// Pixels in `region`.
    pub fn count(&self, region: Region) -> usize {
        let index = Region::ALL.iter().position(|&r| r == region);
        self.labels
            .iter()
            .filter(|&&l| l.map(usize::from) == index)
            .count()
    }

    /// The region of pixel (`x`, `y`), if any.
    pub fn region_at(&self, x: u32, y: u32) -> Option<Region> {
        self.labels[(y * self.width + x) as usize].map(|i| Region::ALL[usize::from(i)])
    }
}

/// The error of an image against a reference (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageError {
    /// Mean per-pixel ΔE00.
    pub mean_delta_e: f64,
    /// 95th percentile of the per-pixel ΔE00.
    pub p95_delta_e: f64,
    /// ΔE00 of each region's mean colour, in [`Region::ALL`] order (`None` for a
    /// region with no pixels in this view).
    pub region_delta_e: [Option<f64>; 3],
}

impl ImageError {
    /// The largest region ΔE00: the bias measure of the tables.
    pub fn bias(&self) -> f64 {
        self.region_delta_e
            .iter()
            .flatten()
            .copied()
            .fold(0.0, f64::max)
    }
}

/// The error of `image` against `reference` as displayed with `display`.
pub fn image_error(
    image: &XyzImage,
    reference: &XyzImage,
    masks: &RegionMasks,
    display: &DisplaySettings,
) -> Result<ImageError, ImageErrorError> {
    image.check_same_size(reference)?;
    check_same_size([image.width, image.height], [masks.width, masks.height])?;
    let transform = DisplayTransform::of(display);
    let lab = |p: &[f32; 3]| {
        transform.lab_of_xyz(Xyz::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
    };
    let mut errors: Vec<f64> = image
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(a, b)| ciede2000(lab(a), lab(b)))
        .map(|e| if e.is_finite() { e } else { f64::INFINITY })
        .collect();
    errors.sort_by(f64::total_cmp);
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    let p95 = errors[((errors.len() - 1) as f64 * 0.95).round() as usize];

    let mut sums = [[[0.0f64; 3]; 2]; 3];
    let mut counts = [0usize; 3];
    for ((label, a), b) in masks
        .labels
        .iter()
        .zip(&image.pixels)
        .zip(&reference.pixels)
    {
        if let Some(i) = label {
            let i = usize::from(*i);
            counts[i] += 1;
            for k in 0..3 {
                sums[i][0][k] += f64::from(a[k]);
                sums[i][1][k] += f64::from(b[k]);
            }
        }
    }
    let region_delta_e = std::array::from_fn(|i| {
        (counts[i] > 0).then(|| {
            let n = counts[i] as f64;
            let mean_of =
                |s: [f64; 3]| transform.lab_of_xyz(Xyz::new(s[0] / n, s[1] / n, s[2] / n));
            ciede2000(mean_of(sums[i][0]), mean_of(sums[i][1]))
        })
    });
    Ok(ImageError {
        mean_delta_e: mean,
        p95_delta_e: p95,
        region_delta_e,
    })
}

/// [`ImageErrorError::SizeMismatch`] unless sizes `a` and `b` ([width, height])
/// are equal: images against each other and against region masks alike.
fn check_same_size(a: [u32; 2], b: [u32; 2]) -> Result<(), ImageErrorError> {
    if a != b {
        return Err(ImageErrorError::SizeMismatch {
            a_width: a[0],
            a_height: a[1],
            b_width: b[0],
            b_height: b[1],
        });
    }
    Ok(())
}

/// The error for a failed read or write of the image file at `path`.
fn io_error(path: &Path) -> impl Fn(std::io::Error) -> ImageErrorError + '_ {
    move |error| ImageErrorError::Io {
        path: path.display().to_string(),
        error,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::film::display_lab_of_xyz;

    fn uniform(width: u32, height: u32, xyz: [f32; 3]) -> XyzImage {
        XyzImage::new(width, height, vec![xyz; (width * height) as usize]).unwrap()
    }

    fn masks_all(width: u32, height: u32, region: u8) -> RegionMasks {
        RegionMasks {
            width,
            height,
            labels: vec![Some(region); (width * height) as usize],
        }
    }

    #[test]
    fn identical_images_have_no_error() {
        let mut pixels = Vec::new();
        for i in 0..64 {
            pixels.push([0.01 * i as f32, 0.012 * i as f32, 0.009 * i as f32]);
        }
        let image = XyzImage::new(8, 8, pixels).unwrap();
        let e = image_error(
            &image,
            &image,
            &masks_all(8, 8, 0),
            &DisplaySettings::default(),
        )
        .unwrap();
        assert_eq!(e.mean_delta_e, 0.0);
        assert_eq!(e.p95_delta_e, 0.0);
        assert_eq!(e.region_delta_e, [Some(0.0), None, None]);
    }

    #[test]
    fn a_uniform_shift_gives_the_delta_e_of_the_two_colours() {
        let display = DisplaySettings::default();
        let (a, b) = ([0.2f32, 0.1, 0.05], [0.22f32, 0.1, 0.05]);
        let want = ciede2000(
            display_lab_of_xyz(Xyz::new(0.2, 0.1, 0.05), &display),
            display_lab_of_xyz(Xyz::new(f64::from(0.22f32), 0.1, 0.05), &display),
        );
        assert!(want > 1.0, "the shift must be visible: {want}");
        let e = image_error(
            &uniform(4, 3, a),
            &uniform(4, 3, b),
            &masks_all(4, 3, 2),
            &display,
        )
        .unwrap();
        for got in [e.mean_delta_e, e.p95_delta_e, e.bias()] {
            assert!((got - want).abs() < 1e-6 * want, "{got} vs {want}");
        }
    }

    #[test]
    fn noise_raises_pixel_error_but_hardly_region_error() {
        // ±10 % luminance noise of alternating sign: large per pixel, cancels in means.
        let display = DisplaySettings::default();
        let base = [0.2f32, 0.2, 0.2];
        let noisy: Vec<[f32; 3]> = (0..400)
            .map(|i| {
                let s = if i % 2 == 0 { 1.1 } else { 0.9 };
                base.map(|v| v * s)
            })
            .collect();
        let e = image_error(
            &XyzImage::new(20, 20, noisy).unwrap(),
            &uniform(20, 20, base),
            &masks_all(20, 20, 0),
            &display,
        )
        .unwrap();
        assert!(e.mean_delta_e > 1.0, "{e:?}");
        assert!(e.bias() < 0.05 * e.mean_delta_e, "{e:?}");
    }

    #[test]
    fn region_masks_of_the_default_car_cover_each_region() {
        use crate::scene::car::{CarParameters, generate};
        let scene = RenderScene::new(generate(&CarParameters::default())).unwrap();
        let camera = scene.default_camera(160, 90);
        let masks = RegionMasks::from_scene(&scene, &camera);
        for region in Region::ALL {
            let count = masks.count(region);
            assert!(count > 100, "{}: {count} pixels", region.label());
        }
        // The bottom centre row of the default view is floor, in front of the car.
        assert_eq!(masks.region_at(80, 89), Some(Region::Floor));
    }

    #[test]
    fn mismatched_sizes_are_refused_by_name() {
        let e = image_error(
            &uniform(4, 3, [0.1; 3]),
            &uniform(3, 4, [0.1; 3]),
            &masks_all(4, 3, 0),
            &DisplaySettings::default(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("4×3"), "{e}");
        assert!(XyzImage::new(2, 2, vec![[0.0; 3]; 3]).is_err());
    }

    #[test]
    fn resizing_keeps_a_uniform_image_and_interpolates_a_ramp() {
        let image = uniform(4, 2, [0.3, 0.4, 0.5]);
        let big = image.resized(8, 4);
        assert!(big.pixels().iter().all(|p| *p == [0.3, 0.4, 0.5]));
        let ramp = XyzImage::new(2, 1, vec![[0.0; 3], [1.0; 3]]).unwrap();
        let r = ramp.resized(4, 1);
        let xs: Vec<f32> = r.pixels().iter().map(|p| p[0]).collect();
        assert_eq!(xs, vec![0.0, 0.25, 0.75, 1.0]);
    }

    #[test]
    fn images_round_trip_through_files_and_bad_files_are_named() {
        let dir = std::env::temp_dir().join(format!("coatlab-xyz-{}", std::process::id()));
        let path = dir.join("a.xyz");
        let image = XyzImage::new(3, 2, (0..6).map(|i| [i as f32, 0.5, -1.0]).collect()).unwrap();
        image.write(&path).unwrap();
        assert_eq!(XyzImage::read(&path).unwrap(), image);
        std::fs::write(&path, b"COATXYZ1\x03\0\0\0\x02\0\0\0short").unwrap();
        let err = XyzImage::read(&path).unwrap_err().to_string();
        assert!(err.contains("a.xyz") && err.contains("bytes"), "{err}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
