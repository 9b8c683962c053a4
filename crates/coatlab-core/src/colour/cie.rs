//! CIE standard observers and illuminants, and tristimulus integration (spec
//! section 6).
//!
//! Data: `data/cie_tables.csv` (CIE 1931 2° and CIE 1964 10° colour-matching
//! functions, D65, A, F2, F7, F11 at 5 nm, 360–830 nm, blank where CIE publishes no
//! value) and `data/cie_daylight_basis.csv` (the daylight basis S0, S1, S2 of
//! CIE 15:2004, 300–830 nm), both embedded and parsed once on first use.
//!
//! Tristimulus values follow spec section 6: X = K Σ S R x̄ Δλ with
//! K = 100 / Σ S ȳ Δλ, so the perfect reflecting diffuser has Y = 100. Two ways to
//! evaluate the sum:
//! - [`Colorimeter`] on a renderer's [`WavelengthGrid`], with weights integrated on
//!   the 5 nm tables (exactly 5 nm summation on the reference grid);
//! - [`summation_weights`] at the data's own wavelengths, for measured spectra
//!   (the `color` command).

use std::fmt;
use std::str::FromStr;
use std::sync::OnceLock;

use thiserror::Error;

use crate::colour::spectrum::{SampledSpectrum, TabulatedSpectrum, VISIBLE, WavelengthGrid};
use crate::colour::{Lab, Xyz, lab_from_xyz};
use crate::names::{UnknownName, by_name};

const CIE_TABLES_CSV: &str = include_str!("../../data/cie_tables.csv");
const DAYLIGHT_BASIS_CSV: &str = include_str!("../../data/cie_daylight_basis.csv");
const TABLE_STEP_NM: f64 = 5.0;

/// Errors naming an observer, illuminant or integration the tables cannot serve.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CieError {
    #[error("unknown observer {0:?}: expected 2 (CIE 1931) or 10 (CIE 1964)")]
    UnknownObserver(String),
    #[error(transparent)]
    UnknownIlluminant(#[from] UnknownName),
    #[error(
        "correlated colour temperature {cct_k} K is outside the CIE daylight range 4000–25000 K"
    )]
    DaylightCctOutOfRange { cct_k: f64 },
    #[error(
        "wavelengths {first_nm}–{last_nm} nm see no light: illuminant {illuminant} times the \
         {observer} luminosity function is zero there"
    )]
    NoLuminance {
        first_nm: f64,
        last_nm: f64,
        illuminant: Illuminant,
        observer: Observer,
    },
    #[error("no wavelengths to integrate over")]
    NoWavelengths,
}

/// A CIE standard colorimetric observer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Observer {
    /// CIE 1931 2° (display work, spec section 6).
    Cie1931TwoDegree,
    /// CIE 1964 10° (the paint industry's reporting convention).
    Cie1964TenDegree,
}

impl Observer {
    /// Both observers.
    pub const ALL: [Observer; 2] = [Observer::Cie1931TwoDegree, Observer::Cie1964TenDegree];

    /// x̄, ȳ, z̄ at `wavelength_nm`, linear between the 5 nm table values, zero
    /// outside 360–830 nm.
    pub fn cmf_at_nm(self, wavelength_nm: f64) -> [f64; 3] {
        let t = tables();
        let [x, y, z] = match self {
            Observer::Cie1931TwoDegree => &t.cmf_2,
            Observer::Cie1964TenDegree => &t.cmf_10,
        };
        [
            x.value_at_nm(wavelength_nm),
            y.value_at_nm(wavelength_nm),
            z.value_at_nm(wavelength_nm),
        ]
    }
}

impl fmt::Display for Observer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Observer::Cie1931TwoDegree => "CIE 1931 2°",
            Observer::Cie1964TenDegree => "CIE 1964 10°",
        })
    }
}

impl FromStr for Observer {
    type Err = CieError;

    /// Accepts "2", "2deg", "2°", "1931" and the 10° equivalents, case-insensitive.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "2" | "2deg" | "2°" | "2 deg" | "1931" | "cie1931" => Ok(Observer::Cie1931TwoDegree),
            "10" | "10deg" | "10°" | "10 deg" | "1964" | "cie1964" => {
                Ok(Observer::Cie1964TenDegree)
            }
            _ => Err(CieError::UnknownObserver(s.to_owned())),
        }
    }
}

/// A CIE standard illuminant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Illuminant {
    /// Average daylight, 6504 K (CIE table).
    D65,
    /// Horizon daylight, 5003 K, derived from the daylight basis (CIE 15:2004).
    D50,
    /// Incandescent (Planckian, 2856 K).
    A,
    /// Cool white fluorescent.
    F2,
    /// Broadband daylight fluorescent.
    F7,
    /// Narrow-band (TL84-type) fluorescent of paint light booths.
    F11,
}

impl Illuminant {
    /// All supported illuminants.
    pub const ALL: [Illuminant; 6] = [
        Illuminant::D65,
        Illuminant::D50,
        Illuminant::A,
        Illuminant::F2,
        Illuminant::F7,
        Illuminant::F11,
    ];

    /// Relative spectral power at `wavelength_nm` (100 at 560 nm), linear between the
    /// 5 nm values, zero where the CIE table has no value (D65 beyond 780 nm, F
    /// series outside 380–780 nm).
    pub fn spd_at_nm(self, wavelength_nm: f64) -> f64 {
        self.series().value_at_nm(wavelength_nm)
    }

    /// The power on `grid` by the resampling rule of [`crate::colour::spectrum`]: the table
    /// values on the reference grid, bin averages on coarser grids, so the narrow
    /// mercury and rare-earth lines of the F series keep their energy instead of
    /// being hit or missed by point samples. Beyond the CIE table the end value is
    /// held, as for any tabulated spectrum.
    pub fn spd(self, grid: &WavelengthGrid) -> SampledSpectrum {
        let series = self.series();
        // A table column is finite, increasing and has many rows, so this cannot fail.
        TabulatedSpectrum::new(series.wavelengths_nm().collect(), series.values.clone())
            .expect("CIE illuminant tables are valid")
            .to_grid(grid)
    }

    fn series(self) -> &'static Series {
        let t = tables();
        match self {
            Illuminant::D65 => &t.d65,
            Illuminant::D50 => &t.d50,
            Illuminant::A => &t.a,
            Illuminant::F2 => &t.f2,
            Illuminant::F7 => &t.f7,
            Illuminant::F11 => &t.f11,
        }
    }
}

impl fmt::Display for Illuminant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Illuminant::D65 => "D65",
            Illuminant::D50 => "D50",
            Illuminant::A => "A",
            Illuminant::F2 => "F2",
            Illuminant::F7 => "F7",
            Illuminant::F11 => "F11",
        })
    }
}

impl FromStr for Illuminant {
    type Err = CieError;

    /// Case-insensitive name: D65, D50, A, F2, F7, F11.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(by_name(s, "an illuminant", &Illuminant::ALL, |i| {
            i.to_string()
        })?)
    }
}

/// The CIE daylight illuminant of correlated colour temperature `cct_k` (CIE 15:2004
/// section 3.1), tabulated at 5 nm over 300–830 nm and 100 at 560 nm.
///
/// S = S0 + M1 S1 + M2 S2, with the chromaticity x_D from the CIE polynomial for the
/// CCT range, y_D = −3 x_D² + 2.870 x_D − 0.275, and M1, M2 rounded to three
/// decimals as CIE does for the published D illuminants (D65 itself is
/// CCT 6500 × 1.4388/1.4380 K, the 1968 change of c₂). Errors outside 4000–25000 K.
pub fn daylight_spd(cct_k: f64) -> Result<TabulatedSpectrum, CieError> {
    let series = daylight_from_basis(&tables().daylight_basis, cct_k)?;
    let wavelengths_nm = series.wavelengths_nm().collect();
    // The basis is finite, strictly increasing and long, so this cannot fail.
    Ok(TabulatedSpectrum::new(wavelengths_nm, series.values)
        .expect("daylight basis table is valid"))
}

/// The rounded daylight mixing coefficients (M1, M2) of CIE 15:2004 for `cct_k`.
pub fn daylight_coefficients(cct_k: f64) -> Result<(f64, f64), CieError> {
    if !(4000.0..=25000.0).contains(&cct_k) {
        return Err(CieError::DaylightCctOutOfRange { cct_k });
    }
    let t = cct_k;
    let x_d = if t <= 7000.0 {
        -4.6070e9 / t.powi(3) + 2.9678e6 / t.powi(2) + 0.09911e3 / t + 0.244063
    } else {
        -2.0064e9 / t.powi(3) + 1.9018e6 / t.powi(2) + 0.24748e3 / t + 0.237040
    };
    let y_d = -3.000 * x_d * x_d + 2.870 * x_d - 0.275;
    let m = 0.0241 + 0.2562 * x_d - 0.7341 * y_d;
    let m1 = (-1.3515 - 1.7703 * x_d + 5.9114 * y_d) / m;
    let m2 = (0.0300 - 31.4424 * x_d + 30.0717 * y_d) / m;
    let round3 = |v: f64| (v * 1000.0).round() / 1000.0;
    Ok((round3(m1), round3(m2)))
}

/// Per-sample tristimulus weights: X = Σ wₓ,ᵢ Rᵢ etc., with K folded in so the
/// perfect white has Y = 100.
#[derive(Debug, Clone, PartialEq)]
pub struct TristimulusWeights {
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    white: Xyz,
}

impl TristimulusWeights {
    fn from_unscaled(x: Vec<f64>, y: Vec<f64>, z: Vec<f64>) -> Option<Self> {
        let y_sum: f64 = y.iter().sum();
        if y_sum.is_nan() || y_sum <= 0.0 {
            return None;
        }
        let k = 100.0 / y_sum;
        let scale = |w: Vec<f64>| w.into_iter().map(|v| v * k).collect::<Vec<_>>();
        let (x, y, z) = (scale(x), scale(y), scale(z));
        let white = Xyz::new(x.iter().sum(), y.iter().sum(), z.iter().sum());
        Some(Self { x, y, z, white })
    }

    /// Number of samples the weights expect.
    pub fn len(&self) -> usize {
        self.y.len()
    }

    /// Whether there are no samples (never, for weights built here).
    pub fn is_empty(&self) -> bool {
        self.y.is_empty()
    }

    /// Tristimulus values of a reflectance (or transmittance) factor spectrum given at
    /// the weights' samples.
    ///
    /// # Panics
    /// If `values` has a different length from the weights (a programming error).
    pub fn xyz(&self, values: &[f64]) -> Xyz {
        assert_eq!(
            values.len(),
            self.y.len(),
            "spectrum length does not match the tristimulus weights"
        );
        let dot = |w: &[f64]| w.iter().zip(values).map(|(w, v)| w * v).sum::<f64>();
        Xyz::new(dot(&self.x), dot(&self.y), dot(&self.z))
    }

    /// Tristimulus values of the perfect reflecting diffuser (Y = 100).
    pub fn white(&self) -> Xyz {
        self.white
    }

    /// CIELAB relative to [`Self::white`].
    ///
    /// # Panics
    /// As [`Self::xyz`].
    pub fn lab(&self, values: &[f64]) -> Lab {
        lab_from_xyz(self.xyz(values), self.white)
    }

    /// The Y weights (sum 100).
    pub fn luminance_weights(&self) -> &[f64] {
        &self.y
    }
}

/// Tristimulus integration on a [`WavelengthGrid`] for one illuminant and observer;
/// build once, then each evaluation is three dot products.
///
/// The weights are integrals over the 5 nm tables of S·x̄ (etc.) times each grid
/// sample's linear-interpolation ("hat") basis function, the end samples' functions
/// extended as constants. A spectrum is thus read as the piecewise-linear function
/// through its samples, and a constant spectrum gives exactly the white point. On the
/// reference grid every hat is one table row, so this is plain 5 nm summation.
///
/// The integration runs over the table rows in [`VISIBLE`] (spec section 6), whatever
/// the renderer's grid, widened to the grid's own span if that reaches further.
#[derive(Debug, Clone, PartialEq)]
pub struct Colorimeter {
    grid: WavelengthGrid,
    illuminant: Illuminant,
    observer: Observer,
    weights: TristimulusWeights,
}

impl Colorimeter {
    /// Precomputes the weights for `grid`.
    pub fn new(illuminant: Illuminant, observer: Observer, grid: &WavelengthGrid) -> Self {
        let [x, y, z] = hat_weighted_cmfs(observer, grid, |wavelength_nm| {
            illuminant.spd_at_nm(wavelength_nm)
        });
        let weights = TristimulusWeights::from_unscaled(x, y, z)
            .expect("every CIE illuminant has luminance in 380–780 nm");
        Self {
            grid: *grid,
            illuminant,
            observer,
            weights,
        }
    }

    /// Tristimulus values (white Y = 100) of reflectance factors on [`Self::grid`].
    ///
    /// # Panics
    /// If `values.len()` differs from the grid's length.
    pub fn xyz(&self, values: &[f64]) -> Xyz {
        self.weights.xyz(values)
    }

    /// The perfect white's tristimulus values: the sums of the weights.
    pub fn white(&self) -> Xyz {
        self.weights.white()
    }

    /// CIELAB relative to [`Self::white`].
    ///
    /// # Panics
    /// As [`Self::xyz`].
    pub fn lab(&self, values: &[f64]) -> Lab {
        self.weights.lab(values)
    }

    /// The grid the weights are for.
    pub fn grid(&self) -> &WavelengthGrid {
        &self.grid
    }

    /// The illuminant.
    pub fn illuminant(&self) -> Illuminant {
        self.illuminant
    }

    /// The observer.
    pub fn observer(&self) -> Observer {
        self.observer
    }

    /// The Y weights, one per grid sample, summing to 100 (the glossmeter's
    /// luminance weighting).
    pub fn luminance_weights(&self) -> &[f64] {
        self.weights.luminance_weights()
    }
}

/// Tristimulus weights for plain summation at measured wavelengths (spec section 6):
/// S and the CMFs interpolated from the 5 nm tables at `wavelengths_nm`, Δλᵢ half the
/// distance between the neighbours (the full spacing at the two ends). For uniform
/// data Δλ is constant and cancels with K.
///
/// Errors if there are no wavelengths or none where the illuminant and ȳ overlap.
/// `wavelengths_nm` must increase (as [`crate::colour::spectrum::read_spectra_csv`] ensures).
pub fn summation_weights(
    illuminant: Illuminant,
    observer: Observer,
    wavelengths_nm: &[f64],
) -> Result<TristimulusWeights, CieError> {
    let n = wavelengths_nm.len();
    if n == 0 {
        return Err(CieError::NoWavelengths);
    }
    let delta_nm = |i: usize| -> f64 {
        if n == 1 {
            1.0
        } else if i == 0 {
            wavelengths_nm[1] - wavelengths_nm[0]
        } else if i == n - 1 {
            wavelengths_nm[n - 1] - wavelengths_nm[n - 2]
        } else {
            0.5 * (wavelengths_nm[i + 1] - wavelengths_nm[i - 1])
        }
    };
    let (mut x, mut y, mut z) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    for (i, &wavelength_nm) in wavelengths_nm.iter().enumerate() {
        let s = illuminant.spd_at_nm(wavelength_nm) * delta_nm(i);
        let [xb, yb, zb] = observer.cmf_at_nm(wavelength_nm);
        x[i] = s * xb;
        y[i] = s * yb;
        z[i] = s * zb;
    }
    TristimulusWeights::from_unscaled(x, y, z).ok_or(CieError::NoLuminance {
        first_nm: wavelengths_nm[0],
        last_nm: wavelengths_nm[n - 1],
        illuminant,
        observer,
    })
}

/// A 5 nm table column: values from `start_nm` on, linear between, zero outside.
#[derive(Debug)]
struct Series {
    start_nm: f64,
    values: Vec<f64>,
}

impl Series {
    fn wavelengths_nm(&self) -> impl Iterator<Item = f64> + '_ {
        (0..self.values.len()).map(|i| self.start_nm + i as f64 * TABLE_STEP_NM)
    }

    fn value_at_nm(&self, wavelength_nm: f64) -> f64 {
        let position = (wavelength_nm - self.start_nm) / TABLE_STEP_NM;
        let last = (self.values.len() - 1) as f64;
        // Also rejects NaN.
        if !(position >= 0.0 && position <= last) {
            return 0.0;
        }
        let i = position.floor() as usize;
        let t = position - i as f64;
        if t == 0.0 {
            self.values[i]
        } else {
            self.values[i] + t * (self.values[i + 1] - self.values[i])
        }
    }
}

#[derive(Debug)]
struct Tables {
    cmf_2: [Series; 3],
    cmf_10: [Series; 3],
    d65: Series,
    d50: Series,
    a: Series,
    f2: Series,
    f7: Series,
    f11: Series,
    daylight_basis: [Series; 3],
    first_nm: f64,
    row_count: usize,
}

/// For each sample of `grid`, the integrals over the 5 nm table of
/// weighting(λ)·x̄(λ), ·ȳ(λ), ·z̄(λ) times the sample's linear-interpolation (hat)
/// basis function, the end samples' hats extended as constants; over [`VISIBLE`],
/// widened to the grid's span if it reaches further. A spectrum reconstructed by
/// linear interpolation between the grid's samples therefore integrates exactly
/// against the tables, on any grid. Unscaled: Δλ = 5 nm is included.
pub fn hat_weighted_cmfs(
    observer: Observer,
    grid: &WavelengthGrid,
    weighting: impl Fn(f64) -> f64,
) -> [Vec<f64>; 3] {
    let n = grid.len();
    let (mut x, mut y, mut z) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let first_nm = VISIBLE.start_nm.min(grid.start_nm());
    let last_nm = VISIBLE.end_nm.max(grid.end_nm());
    for wavelength_nm in table_wavelengths_nm() {
        if wavelength_nm < first_nm || wavelength_nm > last_nm {
            continue;
        }
        let s = weighting(wavelength_nm) * TABLE_STEP_NM;
        let [xb, yb, zb] = observer.cmf_at_nm(wavelength_nm);
        // The row's weight splits between the two grid samples around it.
        let position = (wavelength_nm - grid.start_nm()) / grid.step_nm();
        let (i, t) = if position <= 0.0 {
            (0, 0.0)
        } else if position >= (n - 1) as f64 {
            (n - 1, 0.0)
        } else {
            let i = position.floor() as usize;
            (i, position - i as f64)
        };
        for (index, share) in [(i, 1.0 - t), (i + 1, t)] {
            if share != 0.0 {
                x[index] += s * xb * share;
                y[index] += s * yb * share;
                z[index] += s * zb * share;
            }
        }
    }
    [x, y, z]
}

fn table_wavelengths_nm() -> impl Iterator<Item = f64> {
    let t = tables();
    let (first_nm, rows) = (t.first_nm, t.row_count);
    (0..rows).map(move |i| first_nm + i as f64 * TABLE_STEP_NM)
}

fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(|| {
        let main = parse_table(CIE_TABLES_CSV, "cie_tables.csv");
        let basis = parse_table(DAYLIGHT_BASIS_CSV, "cie_daylight_basis.csv");
        let column = |name: &str| main.series(name);
        let cmf_2 = [column("x2"), column("y2"), column("z2")];
        let cmf_10 = [column("x10"), column("y10"), column("z10")];
        let daylight_basis = [basis.series("S0"), basis.series("S1"), basis.series("S2")];
        let d50 = daylight_from_basis(&daylight_basis, 5000.0 * 1.4388 / 1.4380)
            .expect("D50's CCT is in the daylight range");
        Tables {
            cmf_2,
            cmf_10,
            d65: column("D65"),
            d50,
            a: column("A"),
            f2: column("F2"),
            f7: column("F7"),
            f11: column("F11"),
            daylight_basis,
            first_nm: main.first_nm,
            row_count: main.rows,
        }
    })
}

fn daylight_from_basis(basis: &[Series; 3], cct_k: f64) -> Result<Series, CieError> {
    let (m1, m2) = daylight_coefficients(cct_k)?;
    let [s0, s1, s2] = basis;
    Ok(Series {
        start_nm: s0.start_nm,
        values: (0..s0.values.len())
            .map(|i| s0.values[i] + m1 * s1.values[i] + m2 * s2.values[i])
            .collect(),
    })
}

/// A parsed embedded table: uniform 5 nm rows, named columns with optional cells.
struct RawTable {
    first_nm: f64,
    rows: usize,
    columns: Vec<(String, Vec<Option<f64>>)>,
}

impl RawTable {
    /// The column's contiguous run of values as a series. The embedded data are
    /// checked by the tests, so malformed data is a build defect and panics.
    fn series(&self, name: &str) -> Series {
        let (_, cells) = self
            .columns
            .iter()
            .find(|(n, _)| n == name)
            .unwrap_or_else(|| panic!("embedded CIE table lacks column {name}"));
        let first = cells
            .iter()
            .position(Option::is_some)
            .expect("column has values");
        let last = cells
            .iter()
            .rposition(Option::is_some)
            .expect("column has values");
        let values = cells[first..=last]
            .iter()
            .map(|c| c.unwrap_or_else(|| panic!("gap inside column {name}")))
            .collect();
        Series {
            start_nm: self.first_nm + first as f64 * TABLE_STEP_NM,
            values,
        }
    }
}

fn parse_table(text: &str, file: &str) -> RawTable {
    let mut lines = text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'));
    let header: Vec<&str> = lines
        .next()
        .unwrap_or_else(|| panic!("{file}: empty"))
        .split(',')
        .collect();
    assert_eq!(header[0], "wavelength_nm", "{file}: first column");
    let mut columns: Vec<(String, Vec<Option<f64>>)> = header[1..]
        .iter()
        .map(|h| (h.to_string(), Vec::new()))
        .collect();
    let mut first_nm = None;
    let mut rows = 0;
    for line in lines {
        let fields: Vec<&str> = line.split(',').collect();
        assert_eq!(fields.len(), header.len(), "{file}: ragged row {line}");
        let wavelength_nm: f64 = fields[0].parse().expect("wavelength is a number");
        let first = *first_nm.get_or_insert(wavelength_nm);
        assert_eq!(
            wavelength_nm,
            first + rows as f64 * TABLE_STEP_NM,
            "{file}: rows must be every 5 nm"
        );
        for (cell, (_, column)) in fields[1..].iter().zip(&mut columns) {
            column.push(if cell.is_empty() {
                None
            } else {
                Some(
                    cell.parse()
                        .unwrap_or_else(|_| panic!("{file}: bad cell {cell}")),
                )
            });
        }
        rows += 1;
    }
    RawTable {
        first_nm: first_nm.unwrap_or_else(|| panic!("{file}: no rows")),
        rows,
        columns,
    }
}
