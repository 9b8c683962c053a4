//! Wavelength grids, resampling and spectra CSV import.

use coatlab_core::colour::spectrum::{
    Channel, Channels, MAX_VISIBLE_SAMPLES, REFERENCE_LEN, REFERENCE_STEP_NM, SampledSpectrum,
    SpectrumError, TabulatedSpectrum, VISIBLE, ValueBounds, WavelengthGrid, read_spectra_csv,
};
use proptest::prelude::*;

fn close(a: f64, b: f64, tolerance: f64) -> bool {
    (a - b).abs() <= tolerance
}

// ---------------------------------------------------------------------------------
// Grids

#[test]
fn reference_grid_is_380_to_780_every_5_nm() {
    let grid = WavelengthGrid::reference();
    assert_eq!(grid.len(), 81);
    assert_eq!(grid.wavelength_nm(0), 380.0);
    assert_eq!(grid.wavelength_nm(80), 780.0);
    assert_eq!(grid.step_nm(), 5.0);
    assert_eq!(grid.bin_width_nm(), 5.0);
    assert_eq!(WavelengthGrid::visible(81).unwrap(), grid);
}

#[test]
fn visible_grids_sit_at_bin_centres() {
    let grid = WavelengthGrid::visible(3).unwrap();
    let wavelengths: Vec<f64> = grid.wavelengths_nm().collect();
    assert!(close(wavelengths[0], 446.666_666_666_666_7, 1e-9));
    assert!(close(wavelengths[1], 580.0, 1e-9));
    assert!(close(wavelengths[2], 713.333_333_333_333_3, 1e-9));
    assert!(close(grid.bin_width_nm(), 400.0 / 3.0, 1e-12));
    let one = WavelengthGrid::visible(1).unwrap();
    assert_eq!(one.wavelength_nm(0), 580.0);
    let nm_bins = WavelengthGrid::visible(400).unwrap();
    assert!(close(nm_bins.wavelength_nm(0), 380.5, 1e-12));
    assert!(close(nm_bins.end_nm(), 779.5, 1e-9));
    let finest = WavelengthGrid::visible(401).unwrap();
    assert!(close(
        finest.start_nm() - 0.5 * finest.bin_width_nm(),
        380.0,
        1e-12
    ));
    assert!(close(
        finest.end_nm() + 0.5 * finest.bin_width_nm(),
        780.0,
        1e-9
    ));
}

#[test]
fn bad_grids_are_rejected() {
    assert_eq!(
        WavelengthGrid::visible(0),
        Err(SpectrumError::VisibleCount { count: 0 })
    );
    assert!(WavelengthGrid::visible(402).is_err());
    assert!(WavelengthGrid::new(380.0, 5.0, 0).is_err());
    assert!(WavelengthGrid::new(380.0, 0.0, 10).is_err());
    assert!(WavelengthGrid::new(f64::NAN, 5.0, 10).is_err());
    let message = WavelengthGrid::new(380.0, -1.0, 10)
        .unwrap_err()
        .to_string();
    assert!(message.contains("step"), "{message}");
}

/// The visible range and the grid constants are one definition: the reference
/// grid and every visible grid tile [`VISIBLE`] exactly, up to the finest count.
#[test]
fn every_visible_grid_tiles_the_one_visible_range() {
    assert_eq!((VISIBLE.start_nm, VISIBLE.end_nm), (380.0, 780.0));
    let reference = WavelengthGrid::reference();
    assert_eq!(reference.len(), REFERENCE_LEN);
    assert_eq!(reference.step_nm(), REFERENCE_STEP_NM);
    assert_eq!(reference.start_nm(), VISIBLE.start_nm);
    assert_eq!(reference.end_nm(), VISIBLE.end_nm);
    for count in [1, 2, 3, 16, 32, 80, 82, 400, MAX_VISIBLE_SAMPLES] {
        let grid = WavelengthGrid::visible(count).unwrap();
        let half = 0.5 * grid.bin_width_nm();
        assert!(
            close(grid.start_nm() - half, VISIBLE.start_nm, 1e-9),
            "{count}"
        );
        assert!(close(grid.end_nm() + half, VISIBLE.end_nm, 1e-9), "{count}");
        assert!(grid.wavelengths_nm().all(|nm| VISIBLE.contains(nm)));
    }
    assert!(WavelengthGrid::visible(MAX_VISIBLE_SAMPLES + 1).is_err());
    assert!(VISIBLE.contains(380.0) && VISIBLE.contains(780.0));
    assert!(!VISIBLE.contains(379.999) && !VISIBLE.contains(780.001));
    assert_eq!(VISIBLE.to_string(), "380–780 nm");
}

/// RGB rendering is a kind of channels with no wavelengths, not a grid: it cannot
/// be asked for one, and its channels are named as primaries.
#[test]
fn linear_srgb_channels_have_no_wavelengths() {
    let rgb = Channels::LinearSrgb;
    assert_eq!(rgb.len(), 3);
    assert_eq!(rgb.grid(), None);
    assert_eq!(
        [0, 1, 2].map(|i| rgb.channel(i)),
        [Channel::Red, Channel::Green, Channel::Blue]
    );
    assert_eq!(rgb.channel(0).to_string(), "in the red channel");
    assert_eq!(rgb.to_string(), "linear sRGB");

    let grid = WavelengthGrid::visible(4).unwrap();
    let spectral = Channels::from(grid);
    assert_eq!(spectral, Channels::Spectral(grid));
    assert_eq!(spectral.len(), 4);
    assert_eq!(spectral.grid(), Some(&grid));
    assert_eq!(
        spectral.channel(1),
        Channel::Wavelength(grid.wavelength_nm(1))
    );
    assert_eq!(spectral.channel(1).to_string(), "at 530 nm");
    assert_ne!(spectral, rgb);
    // No three-sample grid stands for RGB any more: a 3-sample grid is spectral.
    let three = Channels::from(WavelengthGrid::visible(3).unwrap());
    assert_ne!(three, rgb);
    assert!(three.grid().is_some());
}

// ---------------------------------------------------------------------------------
// Spectra

#[test]
fn sampled_spectrum_validates() {
    let grid = WavelengthGrid::visible(3).unwrap();
    assert_eq!(
        SampledSpectrum::new(grid, vec![0.0; 2]),
        Err(SpectrumError::LengthMismatch {
            expected: 3,
            found: 2
        })
    );
    let message = SampledSpectrum::new(grid, vec![0.0, f64::NAN, 0.0])
        .unwrap_err()
        .to_string();
    assert!(message.contains("value 1"), "{message}");
    let spectrum = SampledSpectrum::from_fn(grid, |wavelength_nm| wavelength_nm / 1000.0);
    assert!(close(spectrum.values()[1], 0.58, 1e-12));
}

#[test]
fn tabulated_spectrum_validates_and_interpolates() {
    assert!(TabulatedSpectrum::new(vec![400.0], vec![1.0]).is_err());
    assert!(TabulatedSpectrum::new(vec![400.0, 500.0], vec![1.0]).is_err());
    assert!(matches!(
        TabulatedSpectrum::new(vec![400.0, 500.0, 500.0], vec![1.0; 3]),
        Err(SpectrumError::NotIncreasing { index: 2, .. })
    ));
    assert!(TabulatedSpectrum::new(vec![400.0, 500.0], vec![1.0, f64::INFINITY]).is_err());
    let spectrum = TabulatedSpectrum::new(vec![400.0, 500.0, 700.0], vec![0.0, 1.0, 0.0]).unwrap();
    assert_eq!(spectrum.value_at_nm(300.0), 0.0);
    assert!(close(spectrum.value_at_nm(450.0), 0.5, 1e-12));
    assert!(close(spectrum.value_at_nm(650.0), 0.25, 1e-12));
    assert_eq!(spectrum.value_at_nm(800.0), 0.0);
}

#[test]
fn tabulated_spectrum_round_trips_through_toml() {
    let spectrum = TabulatedSpectrum::new(vec![400.0, 700.0], vec![0.25, 0.75]).unwrap();
    let text = toml::to_string(&spectrum).unwrap();
    assert!(
        text.contains("wavelength_nm = [") && text.contains("value = ["),
        "{text}"
    );
    let back: TabulatedSpectrum = toml::from_str(&text).unwrap();
    back.validate().unwrap();
    assert_eq!(back, spectrum);
}

#[test]
fn resampling_to_an_equal_or_finer_grid_interpolates() {
    let source = SampledSpectrum::from_fn(WavelengthGrid::visible(8).unwrap(), |w| w * w);
    let same = source.resample(source.grid());
    assert_eq!(same, source);
    let fine = source.resample(&WavelengthGrid::reference());
    let tab = TabulatedSpectrum::new(
        source.grid().wavelengths_nm().collect(),
        source.values().to_vec(),
    )
    .unwrap();
    for (wavelength_nm, value) in WavelengthGrid::reference()
        .wavelengths_nm()
        .zip(fine.values())
    {
        assert!(close(*value, tab.value_at_nm(wavelength_nm), 1e-9));
    }
    // Ends are clamped.
    assert_eq!(fine.values()[0], source.values()[0]);
}

/// A 10 nm wide line between coarse samples must survive as its area: point sampling
/// would give all zeros on the 3-sample grid.
#[test]
fn resampling_to_a_coarser_grid_keeps_narrow_features() {
    let line = TabulatedSpectrum::new(
        vec![380.0, 500.0, 505.0, 510.0, 780.0],
        vec![0.0, 0.0, 1.0, 0.0, 0.0],
    )
    .unwrap();
    let coarse_grid = WavelengthGrid::visible(3).unwrap();
    let coarse = line.to_grid(&coarse_grid);
    // The line (area 5 nm) lies in the first bin, [380, 513.3] nm.
    assert!(close(
        coarse.values()[0],
        5.0 / coarse_grid.bin_width_nm(),
        1e-12
    ));
    assert_eq!(&coarse.values()[1..], &[0.0, 0.0]);

    // Same for a sampled source on the reference grid.
    let sampled = line.to_grid(&WavelengthGrid::reference());
    let coarse = sampled.resample(&coarse_grid);
    assert!(close(
        coarse.values()[0],
        5.0 / coarse_grid.bin_width_nm(),
        1e-12
    ));
}

/// Averaging preserves the integral over the visible range for data inside it.
#[test]
fn bin_averages_preserve_area() {
    let tab = TabulatedSpectrum::new(
        (0..=40).map(|i| 380.0 + 10.0 * f64::from(i)).collect(),
        (0..=40).map(|i| f64::from((i * 7) % 5) / 4.0).collect(),
    )
    .unwrap();
    let fine = tab.to_grid(&WavelengthGrid::visible(400).unwrap());
    let coarse = tab.to_grid(&WavelengthGrid::visible(16).unwrap());
    let area = |s: &SampledSpectrum| s.values().iter().sum::<f64>() * s.grid().bin_width_nm();
    assert!(close(area(&fine), area(&coarse), 1e-9));
}

proptest! {
    #[test]
    fn resampling_a_constant_is_constant(
        value in 0.0..10.0f64,
        from in 1usize..=401,
        to in 1usize..=401,
    ) {
        let source = SampledSpectrum::constant(WavelengthGrid::visible(from).unwrap(), value);
        let target = WavelengthGrid::visible(to).unwrap();
        for v in source.resample(&target).values() {
            prop_assert!(close(*v, value, 1e-12 * (1.0 + value)), "{} {}", v, value);
        }
    }

    #[test]
    fn resampling_stays_within_the_source_range(
        values in proptest::collection::vec(0.0..1.0f64, 81),
        to in 1usize..=401,
    ) {
        let source = SampledSpectrum::new(WavelengthGrid::reference(), values.clone()).unwrap();
        let min = values.iter().copied().fold(f64::INFINITY, f64::min);
        let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        for v in source.resample(&WavelengthGrid::visible(to).unwrap()).values() {
            prop_assert!(*v >= min - 1e-12 && *v <= max + 1e-12);
        }
    }
}

// ---------------------------------------------------------------------------------
// CSV import

fn read(
    text: &str,
    bounds: ValueBounds,
) -> Result<coatlab_core::colour::spectrum::SpectraCsv, String> {
    read_spectra_csv(text.as_bytes(), "spectra.csv", bounds).map_err(|e| e.to_string())
}

#[test]
fn reads_a_spectra_file() {
    let csv = read(
        "# measured 2024\nred, wavelength_nm ,blue\n0.5,400,0.1\n0.6,500,0.2\n0.7,600,0.3\n",
        ValueBounds::UNIT,
    )
    .unwrap();
    assert_eq!(csv.wavelengths_nm, vec![400.0, 500.0, 600.0]);
    assert_eq!(csv.samples.len(), 2);
    assert_eq!(csv.samples[0], ("red".to_string(), vec![0.5, 0.6, 0.7]));
    assert_eq!(csv.samples[1].0, "blue");
    let blue = csv.spectrum("blue").unwrap();
    assert!(close(blue.value_at_nm(450.0), 0.15, 1e-12));
    assert!(csv.spectrum("green").is_err());
}

#[test]
fn rejects_bad_files_with_file_line_and_column() {
    let cases = [
        (
            "wavelength_nm,red\n400,0.1\n410,0.2\n420,0.3\n430,0.4\n440,0.5\n450,-0.2\n",
            ValueBounds::UNIT,
            r#"spectra.csv line 7, column "red": value -0.2 is outside [0, 1]"#,
        ),
        (
            "wavelength_nm,red\n400,0.1\n410,1.2\n",
            ValueBounds::UNIT,
            r#"spectra.csv line 3, column "red": value 1.2 is outside [0, 1]"#,
        ),
        (
            "wavelength_nm,red\n400,0.1\n410,-1\n",
            ValueBounds::NON_NEGATIVE,
            r#"spectra.csv line 3, column "red": value -1 is outside [0, inf)"#,
        ),
        (
            "wavelength_nm,red\n400,0.1\n400,0.2\n",
            ValueBounds::UNIT,
            r#"spectra.csv line 3, column "wavelength_nm": wavelength 400 nm is not greater than the previous row's 400 nm"#,
        ),
        (
            "wavelength_nm,red\n400,0.1\n390,0.2\n",
            ValueBounds::UNIT,
            r#"line 3, column "wavelength_nm": wavelength 390 nm is not greater"#,
        ),
        (
            "wavelength_nm,red\n290,0.1\n400,0.2\n",
            ValueBounds::UNIT,
            r#"line 2, column "wavelength_nm": wavelength 290 nm is outside 300–830 nm"#,
        ),
        (
            "wavelength_nm,red\n400,0.1\n900,0.2\n",
            ValueBounds::UNIT,
            "wavelength 900 nm is outside",
        ),
        (
            "wavelength_nm,red\n400,0.1\n410,NaN\n",
            ValueBounds::UNIT,
            r#"line 3, column "red": value NaN is not a finite number"#,
        ),
        (
            "wavelength_nm,red\n400,inf\n410,0.1\n",
            ValueBounds::NON_NEGATIVE,
            r#"line 2, column "red": value inf is not a finite number"#,
        ),
        (
            "wavelength_nm,red\n400,0.1\n410,0,2\n",
            ValueBounds::UNIT,
            "spectra.csv line 3: row has 3 fields but the header has 2",
        ),
        (
            "wavelength_nm,red\n400,0.1\n410\n",
            ValueBounds::UNIT,
            "spectra.csv line 3: row has 1 fields but the header has 2",
        ),
        (
            "wavelength_nm,red\n400,0.1\n410,abc\n",
            ValueBounds::UNIT,
            r#"spectra.csv line 3, column "red": cannot read "abc" as a number"#,
        ),
        (
            "lambda,red\n400,0.1\n410,0.2\n",
            ValueBounds::UNIT,
            r#"spectra.csv: no "wavelength_nm" column in the header"#,
        ),
        (
            "wavelength_nm\n400\n410\n",
            ValueBounds::UNIT,
            "spectra.csv: no sample columns",
        ),
        (
            "wavelength_nm,red\n400,0.1\n",
            ValueBounds::UNIT,
            "spectra.csv: needs at least 2 data rows, found 1",
        ),
        (
            "wavelength_nm,red,red\n400,0.1,0.1\n410,0.1,0.1\n",
            ValueBounds::UNIT,
            r#"column "red" appears more than once"#,
        ),
        (
            "",
            ValueBounds::UNIT,
            "spectra.csv: no \"wavelength_nm\" column",
        ),
    ];
    for (text, bounds, expected) in cases {
        let message = read(text, bounds).unwrap_err();
        assert!(
            message.contains(expected),
            "for {text:?}\n got: {message}\nwant: {expected}"
        );
    }
}

#[test]
fn explicit_bounds() {
    let bounds = ValueBounds::new(0.0, 1.5).unwrap();
    assert!(read("wavelength_nm,a\n400,1.4\n410,1.5\n", bounds).is_ok());
    assert!(
        read("wavelength_nm,a\n400,1.4\n410,1.6\n", bounds)
            .unwrap_err()
            .contains("outside [0, 1.5]")
    );
    assert!(ValueBounds::new(-1.0, 1.0).is_err());
    assert!(ValueBounds::new(1.0, 0.5).is_err());
    assert!(ValueBounds::new(f64::NAN, 1.0).is_err());
}
