//! OpenEXR input through the `exr` crate: the first layer with R, G and B channels
//! as a linear-RGB image.

use std::path::Path;

use crate::io::rgb_image::{ImageReadError, RgbImage};

/// Reads the first RGB(A) layer of an OpenEXR file as linear RGB (alpha ignored;
/// any compression the `exr` crate decodes).
pub fn read_exr(path: &Path) -> Result<RgbImage, ImageReadError> {
    use exr::prelude::{Vec2, read_first_rgba_layer_from_file};
    let name = path.display().to_string();
    if let Err(error) = std::fs::metadata(path) {
        return Err(ImageReadError::Io { path: name, error });
    }
    type Pixels = (usize, Vec<[f32; 3]>);
    let image = read_first_rgba_layer_from_file(
        path,
        |size: Vec2<usize>, _| -> Pixels { (size.width(), vec![[0.0; 3]; size.area()]) },
        |(width, pixels): &mut Pixels, at: Vec2<usize>, (r, g, b, _): (f32, f32, f32, f32)| {
            pixels[at.y() * *width + at.x()] = [r, g, b];
        },
    )
    .map_err(|e| ImageReadError::BadExr {
        path: name.clone(),
        reason: e.to_string(),
    })?;
    let size = image.layer_data.size;
    let (_, pixels) = image.layer_data.channel_data.pixels;
    RgbImage::new(size.width(), size.height(), pixels).map_err(|e| match e {
        ImageReadError::InvalidImage { reason, .. } => {
            ImageReadError::InvalidImage { name, reason }
        }
        other => other,
    })
}
