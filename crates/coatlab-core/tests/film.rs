//! The film: spectral radiance → XYZ, mean and variance estimators, tiles, the
//! display pipeline, and PNG/EXR output.

use coatlab_core::colour::Xyz;
use coatlab_core::colour::cie::{Colorimeter, Illuminant, Observer};
use coatlab_core::colour::spectrum::{Channels, WavelengthGrid};
use coatlab_core::render::film::{DisplaySettings, Film, ToneMapping};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

#[path = "support/exr_text.rs"]
mod exr_text;
use exr_text::{expected_attributes, text_attributes};

fn grids() -> [WavelengthGrid; 3] {
    [
        WavelengthGrid::reference(),
        WavelengthGrid::visible(16).unwrap(),
        WavelengthGrid::visible(5).unwrap(),
    ]
}

fn chromaticity(xyz: Xyz) -> (f64, f64) {
    let sum = xyz.x + xyz.y + xyz.z;
    (xyz.x / sum, xyz.y / sum)
}

fn d65_radiance(grid: &WavelengthGrid, scale: f64) -> Vec<f32> {
    Illuminant::D65
        .spd(grid)
        .values()
        .iter()
        .map(|v| (v * scale) as f32)
        .collect()
}

/// D65 radiance scaled to Y = 1 on the film's scale.
fn unit_d65(film: &Film) -> Vec<f32> {
    let grid = *film.channels().grid().expect("a spectral film");
    let y = film.xyz_of(&d65_radiance(&grid, 1.0)).y;
    d65_radiance(&grid, 1.0 / y)
}

#[test]
fn constant_radiance_one_has_luminance_one_and_equal_energy_chromaticity() {
    for grid in grids() {
        let film = Film::new(1, 1, grid);
        let xyz = film.xyz_of(&vec![1.0; grid.len()]);
        assert!((xyz.y - 1.0).abs() < 1e-6, "{}: Y = {}", grid.len(), xyz.y);
        // Equal energy over 380–780 nm (the tails beyond are cut, as spec section 6
        // integrates): x = y = 1/3 to 1e-3.
        let (x, y) = chromaticity(xyz);
        assert!(
            (x - 1.0 / 3.0).abs() < 1e-3 && (y - 1.0 / 3.0).abs() < 1e-3,
            "{x} {y}"
        );
    }
}

/// A scaled D65 SPD gives XYZ proportional to D65's white point. On the reference
/// grid the film's weights are the 5 nm CMF rows, so the ratios equal the
/// colorimeter's white (K Σ S x̄ Δλ) to f32 rounding: measured Δ(x, y) < 5e-8,
/// bound 1e-6 (components 1e-5 relative). On visible(16) the film integrates the
/// piecewise-linear function through D65's 25 nm bin averages, which smooths D65's
/// 5 nm structure: measured Δ(x, y) = (6.6e-4, 7.5e-4), bound 2e-3 (well below a
/// just-noticeable difference on a white).
#[test]
fn scaled_d65_gives_the_d65_white_point() {
    let reference_white = Colorimeter::new(
        Illuminant::D65,
        Observer::Cie1931TwoDegree,
        &WavelengthGrid::reference(),
    )
    .white();
    let (wx, wy) = chromaticity(reference_white);
    // The CIE's published D65 2° white.
    assert!((wx - 0.31272).abs() < 5e-5 && (wy - 0.32903).abs() < 5e-5);
    for (grid, tolerance) in [
        (WavelengthGrid::reference(), 1e-6),
        (WavelengthGrid::visible(16).unwrap(), 2e-3),
    ] {
        for scale in [1e-3, 1.0, 250.0] {
            let film = Film::new(1, 1, grid);
            let xyz = film.xyz_of(&d65_radiance(&grid, scale));
            let (x, y) = chromaticity(xyz);
            assert!(
                (x - wx).abs() < tolerance && (y - wy).abs() < tolerance,
                "{} samples, scale {scale}: ({x}, {y}) vs ({wx}, {wy})",
                grid.len()
            );
            if grid == WavelengthGrid::reference() {
                // Proportional component by component, not only in chromaticity.
                let k = xyz.y / reference_white.y;
                assert!((xyz.x / (k * reference_white.x) - 1.0).abs() < 1e-5);
                assert!((xyz.z / (k * reference_white.z) - 1.0).abs() < 1e-5);
            }
        }
    }
}

/// Samples c·1 (a constant spectrum) have XYZ = c·W with W the film's XYZ of 1, so
/// mean and variance are those of the c's times W (W² for the variance).
#[test]
fn mean_and_variance_of_the_mean_on_known_samples() {
    let grid = WavelengthGrid::visible(16).unwrap();
    let mut film = Film::new(3, 2, grid);
    let w = film.xyz_of(&vec![1.0; grid.len()]);
    let w = [w.x, w.y, w.z];
    let c = [0.5f32, 1.5, 2.0, 4.0, 0.25, 3.0];
    for &ci in &c {
        film.add_sample(2, 1, &vec![ci; grid.len()]);
    }
    let n = c.len() as f64;
    let mean_c = c.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    let var_c = c
        .iter()
        .map(|&v| (f64::from(v) - mean_c).powi(2))
        .sum::<f64>()
        / (n - 1.0);
    let mean = film.mean_xyz(2, 1);
    let variance = film.variance_of_mean_xyz(2, 1);
    for (k, m) in [mean.x, mean.y, mean.z].into_iter().enumerate() {
        assert!((m / (mean_c * w[k]) - 1.0).abs() < 1e-6);
        let expected = var_c * w[k] * w[k] / n;
        assert!(
            (variance[k] / expected - 1.0).abs() < 1e-5,
            "{k}: {} vs {expected}",
            variance[k]
        );
    }
    assert_eq!(film.sample_count(2, 1), 6);
    // Other pixels: no samples, zero mean, no variance estimate.
    assert_eq!(film.samples_per_pixel(), 0);
    assert_eq!(film.mean_xyz(0, 0).y, 0.0);
    assert!(film.variance_of_mean_xyz(0, 0)[1].is_infinite());
    film.add_sample(0, 0, &vec![1.0; grid.len()]);
    assert!(film.variance_of_mean_xyz(0, 0)[1].is_infinite());
    film.clear();
    assert_eq!(film.sample_count(2, 1), 0);
}

/// The estimator against the truth: 400 pixels of 16 iid uniform samples each. The
/// estimated variance of the mean, averaged over pixels, matches σ²/n = 1/(12·16)
/// (in units of W²), and so does the spread of the pixel means; both within 10 %
/// (their relative standard errors are about 2 % and 7 %).
#[test]
fn variance_of_the_mean_is_right_for_iid_samples() {
    let grid = WavelengthGrid::visible(8).unwrap();
    let (width, height, n) = (20u32, 20u32, 16);
    let mut film = Film::new(width, height, grid);
    let wy = film.xyz_of(&vec![1.0; grid.len()]).y;
    let mut rng = Pcg64::seed_from_u64(7);
    for y in 0..height {
        for x in 0..width {
            for _ in 0..n {
                let c: f32 = rng.random();
                film.add_sample(x, y, &vec![c; grid.len()]);
            }
        }
    }
    let truth = 1.0 / 12.0 / f64::from(n) * wy * wy;
    let pixels = f64::from(width * height);
    let (mut estimated, mut spread) = (0.0, 0.0);
    for y in 0..height {
        for x in 0..width {
            estimated += film.variance_of_mean_xyz(x, y)[1] / pixels;
            spread += (film.mean_xyz(x, y).y - 0.5 * wy).powi(2) / pixels;
        }
    }
    assert!(
        (estimated / truth - 1.0).abs() < 0.1,
        "{estimated} vs {truth}"
    );
    assert!((spread / truth - 1.0).abs() < 0.1, "{spread} vs {truth}");
    assert_eq!(film.samples_per_pixel(), 16);
}

/// Accumulating through tiles (filled in any order, merged in any order) gives
/// bit-for-bit the sums of accumulating directly: each pixel sees its samples in the
/// same order.
#[test]
fn merged_tiles_equal_direct_accumulation() {
    let grid = WavelengthGrid::visible(16).unwrap();
    let (width, height) = (23u32, 17u32);
    let mut direct = Film::new(width, height, grid);
    let mut tiled = Film::new(width, height, grid);
    let mut tiles = tiled.tiles(7);
    assert_eq!(tiles.len(), 4 * 3);
    let covered: u32 = tiles.iter().map(|t| t.width() * t.height()).sum();
    assert_eq!(covered, width * height);
    let mut rng = Pcg64::seed_from_u64(11);
    let samples: Vec<(u32, u32, Vec<f32>)> = (0..4000)
        .map(|_| {
            let x = rng.random_range(0..width);
            let y = rng.random_range(0..height);
            let radiance = (0..grid.len()).map(|_| 3.0 * rng.random::<f32>()).collect();
            (x, y, radiance)
        })
        .collect();
    for (x, y, radiance) in &samples {
        direct.add_sample(*x, *y, radiance);
    }
    // Tiles filled in reverse order, each from the samples in its region.
    for tile in tiles.iter_mut().rev() {
        let [x0, y0] = tile.origin();
        for (x, y, radiance) in &samples {
            if (x0..x0 + tile.width()).contains(x) && (y0..y0 + tile.height()).contains(y) {
                tile.add_sample(*x, *y, radiance);
            }
        }
    }
    for tile in tiles.iter().rev() {
        tiled.merge(tile);
    }
    for y in 0..height {
        for x in 0..width {
            assert_eq!(direct.mean_xyz(x, y), tiled.mean_xyz(x, y));
            assert_eq!(
                direct.variance_of_mean_xyz(x, y).map(f64::to_bits),
                tiled.variance_of_mean_xyz(x, y).map(f64::to_bits)
            );
            assert_eq!(direct.sample_count(x, y), tiled.sample_count(x, y));
        }
    }
    // Two passes over the whole image merge like one longer pass (to rounding).
    let mut second = Film::new(width, height, grid);
    for (x, y, radiance) in &samples {
        second.add_sample(*x, *y, radiance);
    }
    tiled.merge(&second);
    for (x, y, radiance) in &samples {
        direct.add_sample(*x, *y, radiance);
    }
    let (a, b) = (direct.mean_xyz(5, 5), tiled.mean_xyz(5, 5));
    assert!((a.y - b.y).abs() <= 1e-12 * a.y.abs());
    assert_eq!(direct.sample_count(5, 5), tiled.sample_count(5, 5));
}

const CLIP: DisplaySettings = DisplaySettings {
    exposure_stops: 0.0,
    adapt_white: None,
    tone_mapping: ToneMapping::Clip,
};

/// An opaque grey of `level` (±1 for rounding) in every channel.
fn assert_grey(pixel: [u8; 4], level: i32) {
    assert!(
        pixel[..3]
            .iter()
            .all(|&c| (i32::from(c) - level).abs() <= 1)
            && pixel[3] == 255,
        "{pixel:?} is not grey {level}"
    );
}

/// An equal-energy grey, adapted to E, is neutral: R = G = B within 1 code value, on
/// every grid, with and without tone mapping. Unadapted, the same grey is visibly
/// pink-ish relative to D65 (R > B by several codes): adaptation does something.
#[test]
fn equal_energy_grey_is_neutral_when_adapted_to_e() {
    for grid in grids() {
        let mut film = Film::new(1, 1, grid);
        film.add_sample(0, 0, &vec![0.18; grid.len()]);
        for tone_mapping in [ToneMapping::Clip, ToneMapping::default()] {
            let settings = DisplaySettings {
                adapt_white: Some(Xyz::new(100.0, 100.0, 100.0)),
                tone_mapping,
                ..CLIP
            };
            let [r, g, b, a] = film.to_display(&settings)[0];
            assert_eq!(a, 255);
            let (lo, hi) = (r.min(g).min(b), r.max(g).max(b));
            assert!(
                hi - lo <= 1,
                "{} samples, {tone_mapping:?}: {r} {g} {b}",
                grid.len()
            );
            assert!(lo > 100, "0.18 grey encodes near 118: {r} {g} {b}");
        }
        let [r, _, b, _] = film.to_display(&CLIP)[0];
        assert!(
            r > b + 3,
            "unadapted E grey should be warmer than D65: {r} vs {b}"
        );
    }
}

/// D65 radiance scaled to Y = 1, shown unadapted with exposure 0 and no tone mapping,
/// is (255, 255, 255): the table's D65 chromaticity (0.31272, 0.32903) differs from
/// sRGB's (0.3127, 0.3290) by < 1e-4, under half a code value. Half the luminance
/// with one stop more is the same white; D65 at Y = 0.5 without it encodes to 188
/// (sRGB of 0.5 = 0.7354 → 187.5), ±1. With Reinhard (white 4), Y = 4 maps to 255
/// and Y = 1 to L' = (1 + 1/16)/2 = 0.53125 → 192 ± 1. With the default PBR
/// Neutral, Y = 1 is compressed to 0.869 09 (→ 240 ± 1) and the half white, in
/// the range it keeps, shows as 0.5 − 0.04 = 0.46 (→ 181 ± 1).
#[test]
fn d65_white_maps_to_full_white_without_tone_mapping() {
    let grid = WavelengthGrid::reference();
    let mut film = Film::new(2, 1, grid);
    let white = unit_d65(&film);
    film.add_sample(0, 0, &white);
    let half: Vec<f32> = white.iter().map(|v| 0.5 * v).collect();
    film.add_sample(1, 0, &half);
    let pixels = film.to_display(&CLIP);
    assert_eq!(pixels[0], [255, 255, 255, 255]);
    assert_grey(pixels[1], 188);
    let brighter = film.to_display(&DisplaySettings {
        exposure_stops: 1.0,
        ..CLIP
    });
    assert_eq!(brighter[1], [255, 255, 255, 255]);
    // Adapting to D65 itself changes nothing visible.
    let adapted = film.to_display(&DisplaySettings {
        adapt_white: Some(
            Colorimeter::new(Illuminant::D65, Observer::Cie1931TwoDegree, &grid).white(),
        ),
        ..CLIP
    });
    assert_eq!(adapted[0], [255, 255, 255, 255]);

    let neutral = film.to_display(&DisplaySettings {
        tone_mapping: ToneMapping::default(),
        ..CLIP
    });
    assert_grey(neutral[0], 240);
    assert_grey(neutral[1], 181);
    let reinhard = DisplaySettings {
        tone_mapping: ToneMapping::REINHARD,
        ..CLIP
    };
    let tone_mapped = film.to_display(&reinhard);
    assert_grey(tone_mapped[0], 192);
    let two_stops_up = film.to_display(&DisplaySettings {
        exposure_stops: 2.0,
        ..reinhard
    });
    assert_eq!(two_stops_up[0], [255, 255, 255, 255]);
    // No sample: black.
    let empty = Film::new(1, 1, grid).to_display(&CLIP);
    assert_eq!(empty[0], [0, 0, 0, 255]);
}

/// A scene under illuminant A, shown adapted to A, puts a white under A at the sRGB
/// white; shown as it is, it is orange (R > G > B).
#[test]
fn illuminant_a_scene_adapts_to_white() {
    let grid = WavelengthGrid::visible(16).unwrap();
    let mut film = Film::new(1, 1, grid);
    let spd = Illuminant::A.spd(&grid);
    let y = film
        .xyz_of(&spd.values().iter().map(|&v| v as f32).collect::<Vec<_>>())
        .y;
    let radiance: Vec<f32> = spd.values().iter().map(|&v| (0.9 * v / y) as f32).collect();
    film.add_sample(0, 0, &radiance);
    let adapt = DisplaySettings {
        adapt_white: Some(film.xyz_of(&radiance)),
        ..CLIP
    };
    let [r, g, b, _] = film.to_display(&adapt)[0];
    assert!(r.max(g).max(b) - r.min(g).min(b) <= 1, "{r} {g} {b}");
    let [r, g, b, _] = film.to_display(&CLIP)[0];
    assert!(r > g && g > b, "{r} {g} {b}");
}

#[test]
fn auto_exposure_brings_the_log_average_to_middle_grey() {
    let grid = WavelengthGrid::visible(8).unwrap();
    let mut film = Film::new(2, 1, grid);
    assert_eq!(film.auto_exposure(), 0.0);
    // Luminances 0.5 and 2: log-average 1, so the exposure is log2(0.18).
    film.add_sample(0, 0, &vec![0.5; grid.len()]);
    film.add_sample(1, 0, &vec![2.0; grid.len()]);
    let stops = film.auto_exposure();
    assert!((stops - 0.18f32.log2()).abs() < 1e-3, "{stops}");
}

#[test]
fn png_round_trip() {
    let (width, height) = (37u32, 11u32);
    let film = random_film((width, height), 3, |_, _, radiance| {
        radiance.iter_mut().for_each(|v| *v *= 2.0);
    });
    let settings = DisplaySettings {
        exposure_stops: film.auto_exposure(),
        ..DisplaySettings::default()
    };
    let dir = std::env::temp_dir().join(format!("coatlab-film-png-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("film.png");
    film.write_png(&path, &settings).unwrap();
    // Only the PNG is left: the temporary file was renamed.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);

    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buffer = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buffer).unwrap();
    assert_eq!((info.width, info.height), (width, height));
    assert_eq!(info.color_type, png::ColorType::Rgb);
    assert_eq!(info.bit_depth, png::BitDepth::Eight);
    let expected: Vec<u8> = film
        .to_display(&settings)
        .into_iter()
        .flat_map(|[r, g, b, _]| [r, g, b])
        .collect();
    assert_eq!(&buffer[..info.buffer_size()], &expected[..]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A film of 9×5 pixels of random spectra with a narrow-band spike now and
/// then: some pixels out of the sRGB gamut (negative components).
fn out_of_gamut_film() -> Film {
    random_film((9, 5), 5, |x, y, radiance| {
        if (x + y) % 3 == 0 {
            radiance.iter_mut().for_each(|v| *v *= 0.01);
            radiance[12] = 20.0;
        }
    })
}

/// A film on a 16-wavelength grid with one sample a pixel: uniform random
/// radiance in [0, 1) from `seed`, then changed by `shape(x, y, radiance)`.
fn random_film(
    (width, height): (u32, u32),
    seed: u64,
    mut shape: impl FnMut(u32, u32, &mut [f32]),
) -> Film {
    let grid = WavelengthGrid::visible(16).unwrap();
    let mut film = Film::new(width, height, grid);
    let mut rng = Pcg64::seed_from_u64(seed);
    for y in 0..height {
        for x in 0..width {
            let mut radiance: Vec<f32> = (0..grid.len()).map(|_| rng.random::<f32>()).collect();
            shape(x, y, &mut radiance);
            film.add_sample(x, y, &radiance);
        }
    }
    film
}

fn scratch_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("coatlab-film-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The EXR of [`Film::write_exr`], read back by the `exr` crate: size, and every
/// channel bit-for-bit equal to `mean_linear_srgb` (negative, out-of-gamut values
/// included).
#[test]
fn exr_is_readable_by_the_exr_crate() {
    use exr::prelude::read_first_rgba_layer_from_file;

    let film = out_of_gamut_film();
    let (width, height) = (film.width(), film.height());
    let dir = scratch_dir("exr");
    let path = dir.join("film.exr");
    film.write_exr(&path).unwrap();

    let image = read_first_rgba_layer_from_file(
        &path,
        |resolution, _| (resolution.width(), vec![[0f32; 4]; resolution.area()]),
        |(w, pixels): &mut (usize, Vec<[f32; 4]>), position, (r, g, b, a): (f32, f32, f32, f32)| {
            pixels[position.y() * *w + position.x()] = [r, g, b, a];
        },
    )
    .unwrap();
    let size = image.layer_data.size;
    assert_eq!(
        (size.width(), size.height()),
        (width as usize, height as usize)
    );
    let (_, pixels) = &image.layer_data.channel_data.pixels;
    let mut negative = false;
    for y in 0..height {
        for x in 0..width {
            let [r, g, b, a] = pixels[(y * width + x) as usize];
            let expected = film.mean_linear_srgb(x, y);
            let expected = [expected.red, expected.green, expected.blue];
            assert_eq!(
                [r, g, b].map(f32::to_bits),
                expected.map(f32::to_bits),
                "({x}, {y})"
            );
            assert_eq!(a, 1.0, "no alpha channel reads as opaque");
            negative |= expected.iter().any(|&v| v < 0.0);
        }
    }
    assert!(negative, "the test should include out-of-gamut colours");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An EXR read back with every channel as stored: the R, G, B samples, the
/// compression and the header's text attributes (UTF-8).
struct StoredExr {
    channels: Vec<(String, exr::prelude::FlatSamples)>,
    compression: exr::prelude::Compression,
    attributes: std::collections::BTreeMap<String, String>,
    has_srgb_chromaticities: bool,
}

fn read_stored_exr(path: &std::path::Path) -> StoredExr {
    use exr::prelude::read_first_flat_layer_from_file;
    let image = read_first_flat_layer_from_file(path).unwrap();
    let layer = image.layer_data;
    let channels = layer
        .channel_data
        .list
        .into_iter()
        .map(|c| (c.name.to_string(), c.sample_data))
        .collect();
    let attributes = text_attributes(layer.attributes.other.iter().chain(&image.attributes.other));
    let has_srgb_chromaticities = image
        .attributes
        .chromaticities
        .is_some_and(|c| c.red.0 == 0.64 && c.white.1 == 0.3290);
    StoredExr {
        channels,
        compression: layer.encoding.compression,
        attributes,
        has_srgb_chromaticities,
    }
}

/// The film's linear sRGB as three planes R, G, B.
fn planes(film: &Film) -> [Vec<f32>; 3] {
    let image = film.linear_srgb_image();
    [
        image.iter().map(|p| p.red).collect(),
        image.iter().map(|p| p.green).collect(),
        image.iter().map(|p| p.blue).collect(),
    ]
}

/// Every compression writes 32-bit floats bit-equal to the film's values, says
/// its compression and channel type in the file, and carries every header
/// attribute (a design name with non-ASCII letters and a quote included); the same
/// image written twice is the same bytes.
#[test]
fn exr_options_and_header_attributes_read_back() {
    use coatlab_core::io::exr_write::{ExrCompression, ExrPrecision};
    use coatlab_core::render::film::{EXR_ADAPTATION, ExrOutput, RenderRecord, exr_attribute};
    use exr::prelude::{Compression, FlatSamples};

    let film = out_of_gamut_film();
    let expected = planes(&film);
    let dir = scratch_dir("exr-options");
    let record = RenderRecord {
        design: Some("Rouge \"Évora\" 赤".to_owned()),
        samples_per_pixel: Some("16 mean, adaptive".to_owned()),
        seed: Some(42),
        lighting: Some("booth-a".to_owned()),
    };
    for (compression, stored) in [
        (ExrCompression::None, Compression::Uncompressed),
        (ExrCompression::Rle, Compression::RLE),
        (ExrCompression::Zips, Compression::ZIP1),
        (ExrCompression::Zip, Compression::ZIP16),
        (ExrCompression::Piz, Compression::PIZ),
    ] {
        let path = dir.join(format!("{}.exr", compression.name()));
        let output = ExrOutput {
            precision: ExrPrecision::Float,
            compression,
            record: record.clone(),
        };
        film.write_exr_with(&path, &output).unwrap();
        let exr = read_stored_exr(&path);
        assert_eq!(exr.compression, stored);
        assert!(exr.has_srgb_chromaticities);
        let names: Vec<&str> = exr.channels.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["B", "G", "R"]);
        for (name, samples) in &exr.channels {
            let FlatSamples::F32(values) = samples else {
                panic!("{name}: not 32-bit floats");
            };
            let want = &expected[["R", "G", "B"].iter().position(|n| n == name).unwrap()];
            assert_eq!(
                values.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                want.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "{name}, {compression:?}"
            );
        }
        let expected_attributes = expected_attributes(&[
            (exr_attribute::DESIGN, "Rouge \"Évora\" 赤"),
            (exr_attribute::SAMPLES_PER_PIXEL, "16 mean, adaptive"),
            (exr_attribute::SEED, "42"),
            (exr_attribute::WAVELENGTHS, "16 from 392.5 to 767.5 nm"),
            (exr_attribute::LIGHTING, "booth-a"),
            (exr_attribute::ADAPTATION, EXR_ADAPTATION),
        ]);
        assert_eq!(exr.attributes, expected_attributes, "{compression:?}");
        // Reproducible: the header's attributes come in one order.
        let again = dir.join("again.exr");
        film.write_exr_with(&again, &output).unwrap();
        assert_eq!(
            std::fs::read(&path).unwrap(),
            std::fs::read(&again).unwrap(),
            "{compression:?}"
        );
    }
    // Without a record: the film's own count, wavelengths and adaptation only; an
    // RGB film says so.
    let mut rgb = Film::new(2, 1, Channels::LinearSrgb);
    rgb.add_sample(0, 0, &[1.0, 0.5, 0.25]);
    rgb.add_sample(1, 0, &[1.0, 0.5, 0.25]);
    rgb.add_sample(1, 0, &[1.0, 0.5, 0.25]);
    let path = dir.join("rgb.exr");
    rgb.write_exr(&path).unwrap();
    let exr = read_stored_exr(&path);
    assert_eq!(exr.compression, Compression::ZIP16, "the default");
    let attributes: Vec<(&str, &str)> = exr
        .attributes
        .iter()
        .map(|(k, v)| (k.as_str(), v.as_str()))
        .collect();
    assert_eq!(
        attributes,
        [
            (exr_attribute::ADAPTATION, EXR_ADAPTATION),
            (exr_attribute::SAMPLES_PER_PIXEL, "1"),
            (exr_attribute::WAVELENGTHS, "linear sRGB"),
        ]
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Half floats: each stored value is the film's rounded to the nearest half, so
/// within half a unit in the last place: a relative 2⁻¹¹ for normal halves, an
/// absolute 2⁻²⁵ below them.
#[test]
fn half_exr_is_within_half_precision() {
    use coatlab_core::io::exr_write::{ExrCompression, ExrPrecision};
    use coatlab_core::render::film::ExrOutput;
    use exr::prelude::{FlatSamples, f16};

    let film = out_of_gamut_film();
    let expected = planes(&film);
    let dir = scratch_dir("exr-half");
    for compression in [ExrCompression::None, ExrCompression::Piz] {
        let path = dir.join("half.exr");
        let output = ExrOutput {
            precision: ExrPrecision::Half,
            compression,
            ..ExrOutput::default()
        };
        film.write_exr_with(&path, &output).unwrap();
        let exr = read_stored_exr(&path);
        let mut checked = 0;
        for (name, samples) in &exr.channels {
            let FlatSamples::F16(values) = samples else {
                panic!("{name}: not half floats");
            };
            let want = &expected[["R", "G", "B"].iter().position(|n| n == name).unwrap()];
            assert_eq!(values.len(), want.len());
            for (&half, &value) in values.iter().zip(want) {
                assert_eq!(half, f16::from_f32(value), "{name}: rounded to nearest");
                let error = (half.to_f32() - value).abs();
                let bound = (value.abs() * 2f32.powi(-11)).max(2f32.powi(-25));
                assert!(error <= bound, "{name}: {value} stored as {half}");
                checked += 1;
            }
        }
        assert_eq!(checked, 3 * 9 * 5);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A re-shaded image (mean XYZ, no film) exported as shown: the PNG holds
/// `display_xyz` of the values.
#[test]
fn xyz_png_holds_the_displayed_colours() {
    use coatlab_core::render::film::{display_xyz, write_xyz_png};
    let (width, height) = (7u32, 3u32);
    let xyz: Vec<[f32; 3]> = (0..width * height)
        .map(|i| {
            let v = i as f32 / 10.0;
            [0.9 * v, v, 1.1 * v]
        })
        .collect();
    let settings = DisplaySettings::default();
    let dir = scratch_dir("xyz-png");
    let path = dir.join("second.png");
    write_xyz_png(&path, width, height, &xyz, &settings).unwrap();
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buffer = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buffer).unwrap();
    assert_eq!((info.width, info.height), (width, height));
    let expected: Vec<u8> = display_xyz(&xyz, &settings)
        .into_iter()
        .flat_map(|[r, g, b, _]| [r, g, b])
        .collect();
    assert_eq!(&buffer[..info.buffer_size()], &expected[..]);
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        1,
        "no temporary left"
    );
    let short = write_xyz_png(&path, width, height + 1, &xyz, &settings).unwrap_err();
    assert!(short.to_string().contains("second.png"), "{short}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn writing_to_a_missing_folder_names_the_file() {
    let film = Film::new(2, 2, WavelengthGrid::visible(4).unwrap());
    let path = std::path::Path::new("/nonexistent-coatlab-folder/out.png");
    let message = film
        .write_png(path, &DisplaySettings::default())
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("/nonexistent-coatlab-folder/out.png"),
        "{message}"
    );
    let message = film
        .write_exr(&path.with_extension("exr"))
        .unwrap_err()
        .to_string();
    assert!(message.contains("out.exr"), "{message}");
}
