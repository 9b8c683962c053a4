//! Wavelength grids, sampled and tabulated spectra, and spectra CSV import.
//!
//! The renderer works on a [`WavelengthGrid`]: the 5 nm reference grid of spec
//! section 6, or fewer, wider bins over the same [`VISIBLE`] range when speed matters
//! more than accuracy. Measured or published data arrive as [`TabulatedSpectrum`]s at
//! their own (possibly irregular) wavelengths and are brought onto a grid with
//! [`TabulatedSpectrum::to_grid`]. What one value of the tracer's per-path arrays
//! stands for — a wavelength of a grid, or a linear-sRGB primary — is a [`Channels`].
//!
//! Resampling rule (both [`SampledSpectrum::resample`] and
//! [`TabulatedSpectrum::to_grid`]): the source is the piecewise-linear function through
//! its samples, constant beyond its ends. Onto a grid coarser than the source each
//! target value is the mean of that function over the target's bin, so a feature
//! narrower than a bin still contributes its area instead of being hit or missed by a
//! point sample (aliasing). Onto an equal or finer grid the function is simply
//! evaluated (linear interpolation), which keeps an equal grid bit-for-bit unchanged.

use std::fmt;
use std::io::Read;

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Shortest wavelength accepted from a spectra file (nm): the UV end of the CIE
/// daylight basis.
pub const CSV_MIN_WAVELENGTH_NM: f64 = 300.0;
/// Longest wavelength accepted from a spectra file (nm): the end of the CIE tables.
pub const CSV_MAX_WAVELENGTH_NM: f64 = 830.0;

/// A closed range of wavelengths.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WavelengthRange {
    /// Shortest wavelength (nm).
    pub start_nm: f64,
    /// Longest wavelength (nm).
    pub end_nm: f64,
}

impl WavelengthRange {
    /// Whether `wavelength_nm` lies in the range, ends included.
    pub fn contains(&self, wavelength_nm: f64) -> bool {
        (self.start_nm..=self.end_nm).contains(&wavelength_nm)
    }

    /// `end_nm − start_nm`.
    pub fn width_nm(&self) -> f64 {
        self.end_nm - self.start_nm
    }
}

impl fmt::Display for WavelengthRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}–{} nm", self.start_nm, self.end_nm)
    }
}

/// The visible range of spec section 6, 380–780 nm: every renderer grid tiles it
/// ([`WavelengthGrid::visible`]), colour is integrated over it, a design's
/// refractive index must be ≥ 1 over it, and the GUI draws spectra over it.
pub const VISIBLE: WavelengthRange = WavelengthRange {
    start_nm: 380.0,
    end_nm: 780.0,
};
/// Spacing of the reference grid (nm): the CIE tables' own.
pub const REFERENCE_STEP_NM: f64 = 5.0;
/// Samples of the reference grid: [`VISIBLE`] every [`REFERENCE_STEP_NM`], ends included.
pub const REFERENCE_LEN: usize = 81;
/// Most samples [`WavelengthGrid::visible`] takes: one per nanometre is the finest
/// grid the renderer has any use for.
pub const MAX_VISIBLE_SAMPLES: usize = 401;

/// What went wrong building a grid or a spectrum, or reading a spectra file.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SpectrumError {
    /// Grid parameters that do not describe a usable grid.
    #[error("wavelength grid (start {start_nm} nm, step {step_nm} nm, {len} samples): {reason}")]
    InvalidGrid {
        start_nm: f64,
        step_nm: f64,
        len: usize,
        reason: &'static str,
    },
    /// `WavelengthGrid::visible` asked for an unsupported number of samples.
    #[error("a visible wavelength grid needs 1 to {MAX_VISIBLE_SAMPLES} samples, got {count}")]
    VisibleCount { count: usize },
    /// Values and wavelengths of different lengths.
    #[error("spectrum has {found} values but {expected} wavelengths")]
    LengthMismatch { expected: usize, found: usize },
    /// NaN or infinity in a spectrum.
    #[error("spectrum value {index} is {value}, not a finite number")]
    NonFiniteValue { index: usize, value: f64 },
    /// NaN or infinity among the wavelengths of a tabulated spectrum.
    #[error("wavelength {index} is {wavelength_nm}, not a finite number")]
    NonFiniteWavelength { index: usize, wavelength_nm: f64 },
    /// Tabulated wavelengths must strictly increase.
    #[error(
        "wavelength {index} ({wavelength_nm} nm) is not greater than the one before it ({previous_nm} nm)"
    )]
    NotIncreasing {
        index: usize,
        wavelength_nm: f64,
        previous_nm: f64,
    },
    /// A tabulated spectrum needs two samples to define its shape.
    #[error("a tabulated spectrum needs at least 2 samples, got {found}")]
    TooFewSamples { found: usize },
    /// A `ValueBounds` whose limits make no sense.
    #[error("value bounds [{min}, {max}] must satisfy 0 <= min <= max (max may be infinite)")]
    InvalidBounds { min: f64, max: f64 },
    /// A bad field in a spectra CSV file.
    #[error("{file} line {line}, column \"{column}\": {problem}")]
    CsvField {
        file: String,
        line: u64,
        column: String,
        problem: CsvProblem,
    },
    /// A bad row in a spectra CSV file.
    #[error("{file} line {line}: {problem}")]
    CsvRow {
        file: String,
        line: u64,
        problem: CsvProblem,
    },
    /// A spectra CSV file that is unusable as a whole.
    #[error("{file}: {problem}")]
    CsvFile { file: String, problem: CsvProblem },
    /// `SpectraCsv::spectrum` asked for a sample the file does not have.
    #[error("no sample column named \"{name}\"")]
    NoSuchSample { name: String },
}

/// The problem found in a spectra CSV file; [`SpectrumError`] adds where.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CsvProblem {
    #[error("cannot read {text:?} as a number")]
    Unparsable { text: String },
    #[error("value {value} is not a finite number")]
    NonFinite { value: f64 },
    #[error("value {value} is outside {bounds}")]
    OutOfBounds { value: f64, bounds: ValueBounds },
    #[error(
        "wavelength {wavelength_nm} nm is outside {CSV_MIN_WAVELENGTH_NM}–{CSV_MAX_WAVELENGTH_NM} nm"
    )]
    WavelengthOutOfRange { wavelength_nm: f64 },
    #[error(
        "wavelength {wavelength_nm} nm is not greater than the previous row's {previous_nm} nm (wavelengths must strictly increase)"
    )]
    WavelengthNotIncreasing {
        wavelength_nm: f64,
        previous_nm: f64,
    },
    #[error("row has {found} fields but the header has {expected}")]
    RaggedRow { expected: usize, found: usize },
    #[error("no \"wavelength_nm\" column in the header")]
    MissingWavelengthColumn,
    #[error("no sample columns besides \"wavelength_nm\"")]
    NoSampleColumns,
    #[error("column \"{column}\" appears more than once in the header")]
    DuplicateColumn { column: String },
    #[error("needs at least 2 data rows, found {found}")]
    TooFewRows { found: usize },
    #[error("cannot read CSV: {message}")]
    Read { message: String },
}

/// A uniform wavelength grid: sample `i` is at `start_nm + i * step_nm` and stands for
/// a bin of width `step_nm` centred on it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WavelengthGrid {
    start_nm: f64,
    step_nm: f64,
    len: usize,
}

impl WavelengthGrid {
    /// A grid of `len` samples from `start_nm` every `step_nm`.
    ///
    /// Errors unless `len >= 1`, `start_nm > 0` and `step_nm > 0`, all finite.
    pub fn new(start_nm: f64, step_nm: f64, len: usize) -> Result<Self, SpectrumError> {
        let invalid = |reason| SpectrumError::InvalidGrid {
            start_nm,
            step_nm,
            len,
            reason,
        };
        if len == 0 {
            return Err(invalid("needs at least one sample"));
        }
        if !(start_nm.is_finite() && start_nm > 0.0) {
            return Err(invalid("start must be a positive, finite wavelength"));
        }
        if !(step_nm.is_finite() && step_nm > 0.0) {
            return Err(invalid("step must be positive and finite"));
        }
        Ok(Self {
            start_nm,
            step_nm,
            len,
        })
    }

    /// The reference grid of spec section 6: [`VISIBLE`] every 5 nm, 81 samples.
    pub const fn reference() -> Self {
        Self {
            start_nm: VISIBLE.start_nm,
            step_nm: REFERENCE_STEP_NM,
            len: REFERENCE_LEN,
        }
    }

    /// `count` samples over the visible range: 81 gives [`Self::reference`]; any other
    /// count places the samples at the centres of `count` equal bins tiling
    /// [`VISIBLE`] (3 gives 446.67, 580, 713.33 nm).
    ///
    /// Fewer samples is the renderer's speed/accuracy knob. Errors unless
    /// `1 <= count <=` [`MAX_VISIBLE_SAMPLES`].
    pub fn visible(count: usize) -> Result<Self, SpectrumError> {
        if count == REFERENCE_LEN {
            return Ok(Self::reference());
        }
        if !(1..=MAX_VISIBLE_SAMPLES).contains(&count) {
            return Err(SpectrumError::VisibleCount { count });
        }
        let step_nm = VISIBLE.width_nm() / count as f64;
        Ok(Self {
            start_nm: VISIBLE.start_nm + 0.5 * step_nm,
            step_nm,
            len: count,
        })
    }

    /// Number of samples.
    pub const fn len(&self) -> usize {
        self.len
    }

    /// Always false: a grid has at least one sample. Present for API symmetry with
    /// `len`.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// First sample's wavelength (nm).
    pub const fn start_nm(&self) -> f64 {
        self.start_nm
    }

    /// Last sample's wavelength (nm).
    pub fn end_nm(&self) -> f64 {
        self.wavelength_nm(self.len - 1)
    }

    /// Distance between neighbouring samples (nm).
    pub const fn step_nm(&self) -> f64 {
        self.step_nm
    }

    /// Width of the bin each sample stands for (nm); equal to the step, also for a
    /// one-sample grid, whose single bin is `step_nm` wide.
    pub const fn bin_width_nm(&self) -> f64 {
        self.step_nm
    }

    /// Wavelength of sample `index` (nm). Not bounds-checked: indices past the end
    /// extrapolate.
    pub fn wavelength_nm(&self, index: usize) -> f64 {
        self.start_nm + index as f64 * self.step_nm
    }

    /// All sample wavelengths (nm), in increasing order.
    pub fn wavelengths_nm(&self) -> impl ExactSizeIterator<Item = f64> + use<> {
        let grid = *self;
        (0..grid.len).map(move |i| grid.wavelength_nm(i))
    }
}

/// What the values of the tracer's per-path arrays (radiance, BSDF values, path
/// weights, film samples) stand for: one wavelength each of a grid, or the three
/// linear-sRGB primaries of the RGB shortcut (`cargo xtask bench`'s RGB shortcut, xtask/src/bench/rgb.rs).
///
/// The paint formulas run per channel alike; what differs is only how a channel
/// meets colour: a spectral channel has a wavelength (the film weighs it by the
/// colour-matching functions, lights and base colours are spectra on the grid), an
/// RGB channel has none (the film applies the sRGB → XYZ matrix, lights and base
/// colours are their linear-sRGB triples). Code that needs a wavelength asks
/// [`Channels::grid`] and must say what it does without one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Channels {
    /// Spectral radiance at the samples of a wavelength grid.
    Spectral(WavelengthGrid),
    /// Linear sRGB (Rec. 709 primaries, D65 white (1, 1, 1)), in the order R, G, B.
    LinearSrgb,
}

impl Channels {
    /// Number of channels: the grid's samples, or 3.
    pub const fn len(&self) -> usize {
        match self {
            Channels::Spectral(grid) => grid.len(),
            Channels::LinearSrgb => 3,
        }
    }

    /// Always false: there is at least one channel. Present for API symmetry with
    /// `len`.
    pub const fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The wavelength grid of spectral channels; `None` for linear sRGB, whose
    /// channels have no wavelength.
    pub const fn grid(&self) -> Option<&WavelengthGrid> {
        match self {
            Channels::Spectral(grid) => Some(grid),
            Channels::LinearSrgb => None,
        }
    }
}

impl Channels {
    /// Channel `index`, for messages; not bounds-checked (as
    /// [`WavelengthGrid::wavelength_nm`]).
    pub fn channel(&self, index: usize) -> Channel {
        match self {
            Channels::Spectral(grid) => Channel::Wavelength(grid.wavelength_nm(index)),
            Channels::LinearSrgb => match index {
                0 => Channel::Red,
                1 => Channel::Green,
                _ => Channel::Blue,
            },
        }
    }
}

/// One channel of a [`Channels`], as messages name it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Channel {
    /// A wavelength (nm).
    Wavelength(f64),
    /// The linear-sRGB red primary.
    Red,
    /// The linear-sRGB green primary.
    Green,
    /// The linear-sRGB blue primary.
    Blue,
}

impl fmt::Display for Channel {
    /// "at 550 nm", "in the red channel".
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Channel::Wavelength(nm) => write!(f, "at {nm} nm"),
            Channel::Red => f.write_str("in the red channel"),
            Channel::Green => f.write_str("in the green channel"),
            Channel::Blue => f.write_str("in the blue channel"),
        }
    }
}

impl From<WavelengthGrid> for Channels {
    fn from(grid: WavelengthGrid) -> Self {
        Channels::Spectral(grid)
    }
}

impl fmt::Display for Channels {
    /// "32 wavelengths, 380–780 nm" or "linear sRGB".
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Channels::Spectral(grid) => write!(
                f,
                "{} wavelengths, {}–{} nm",
                grid.len(),
                grid.start_nm(),
                grid.end_nm()
            ),
            Channels::LinearSrgb => f.write_str("linear sRGB"),
        }
    }
}

/// A spectrum sampled on a [`WavelengthGrid`]: reflectances, albedos, absorption
/// coefficients or illuminant powers, one finite value per grid sample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SampledSpectrum {
    grid: WavelengthGrid,
    values: Vec<f64>,
}

impl SampledSpectrum {
    /// A spectrum from its values; errors if the count differs from the grid's or a
    /// value is not finite.
    pub fn new(grid: WavelengthGrid, values: Vec<f64>) -> Result<Self, SpectrumError> {
        if values.len() != grid.len() {
            return Err(SpectrumError::LengthMismatch {
                expected: grid.len(),
                found: values.len(),
            });
        }
        check_finite(&values)?;
        Ok(Self { grid, values })
    }

    /// The same value at every wavelength.
    pub fn constant(grid: WavelengthGrid, value: f64) -> Self {
        Self {
            grid,
            values: vec![value; grid.len()],
        }
    }

    /// Samples `f(wavelength_nm)` at each grid wavelength (a point sample; use
    /// [`TabulatedSpectrum::to_grid`] to average data over bins).
    pub fn from_fn(grid: WavelengthGrid, mut f: impl FnMut(f64) -> f64) -> Self {
        Self {
            grid,
            values: grid.wavelengths_nm().map(&mut f).collect(),
        }
    }

    /// The grid the values live on.
    pub fn grid(&self) -> &WavelengthGrid {
        &self.grid
    }

    /// One value per grid sample.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The values, consuming the spectrum.
    pub fn into_values(self) -> Vec<f64> {
        self.values
    }

    /// This spectrum on another grid, by the module's resampling rule: bin averages
    /// onto a coarser grid, linear interpolation onto an equal or finer one, constant
    /// beyond the ends.
    pub fn resample(&self, target: &WavelengthGrid) -> SampledSpectrum {
        if *target == self.grid {
            return self.clone();
        }
        let wavelengths_nm: Vec<f64> = self.grid.wavelengths_nm().collect();
        let source_step_nm = if self.grid.len() > 1 {
            self.grid.step_nm()
        } else {
            f64::INFINITY
        };
        resample_piecewise_linear(&wavelengths_nm, &self.values, source_step_nm, target)
    }
}

/// A spectrum tabulated at its own, strictly increasing (possibly irregular)
/// wavelengths; between them it is linear, beyond them constant.
///
/// Serialised as `{ wavelength_nm = [...], value = [...] }` in design files.
/// Deserialisation does not validate; call [`TabulatedSpectrum::validate`] after.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TabulatedSpectrum {
    #[serde(rename = "wavelength_nm")]
    wavelengths_nm: Vec<f64>,
    #[serde(rename = "value")]
    values: Vec<f64>,
}

impl TabulatedSpectrum {
    /// Errors unless there are at least 2 samples, as many values as wavelengths, the
    /// wavelengths strictly increase and everything is finite.
    pub fn new(wavelengths_nm: Vec<f64>, values: Vec<f64>) -> Result<Self, SpectrumError> {
        let spectrum = Self {
            wavelengths_nm,
            values,
        };
        spectrum.validate()?;
        Ok(spectrum)
    }

    /// Checks the invariants of [`TabulatedSpectrum::new`] (for deserialised data).
    pub fn validate(&self) -> Result<(), SpectrumError> {
        if self.values.len() != self.wavelengths_nm.len() {
            return Err(SpectrumError::LengthMismatch {
                expected: self.wavelengths_nm.len(),
                found: self.values.len(),
            });
        }
        if self.wavelengths_nm.len() < 2 {
            return Err(SpectrumError::TooFewSamples {
                found: self.wavelengths_nm.len(),
            });
        }
        for (index, &wavelength_nm) in self.wavelengths_nm.iter().enumerate() {
            if !wavelength_nm.is_finite() {
                return Err(SpectrumError::NonFiniteWavelength {
                    index,
                    wavelength_nm,
                });
            }
            if index > 0 && wavelength_nm <= self.wavelengths_nm[index - 1] {
                return Err(SpectrumError::NotIncreasing {
                    index,
                    wavelength_nm,
                    previous_nm: self.wavelengths_nm[index - 1],
                });
            }
        }
        check_finite(&self.values)
    }

    /// The tabulated wavelengths (nm).
    pub fn wavelengths_nm(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// The tabulated values.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Linear interpolation at `wavelength_nm`; the end values beyond the ends.
    pub fn value_at_nm(&self, wavelength_nm: f64) -> f64 {
        interpolate_clamped(&self.wavelengths_nm, &self.values, wavelength_nm)
    }

    /// This spectrum on a grid, by the module's resampling rule. "Coarser" means the
    /// grid step exceeds the smallest spacing of the table, so no feature of the table
    /// is narrower than a bin without being averaged.
    pub fn to_grid(&self, grid: &WavelengthGrid) -> SampledSpectrum {
        let min_spacing_nm = self
            .wavelengths_nm
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min);
        resample_piecewise_linear(&self.wavelengths_nm, &self.values, min_spacing_nm, grid)
    }
}

/// The closed range of values a spectra file may hold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValueBounds {
    min: f64,
    max: f64,
}

impl ValueBounds {
    /// [0, 1]: reflectances, albedos.
    pub const UNIT: Self = Self { min: 0.0, max: 1.0 };
    /// [0, ∞): absorption and scattering coefficients, illuminant powers.
    pub const NON_NEGATIVE: Self = Self {
        min: 0.0,
        max: f64::INFINITY,
    };

    /// `[min, max]`; errors unless `0 <= min <= max` (`max` may be infinite), since
    /// no spectral quantity read from a file here can be negative.
    pub fn new(min: f64, max: f64) -> Result<Self, SpectrumError> {
        if min.is_finite() && min >= 0.0 && max >= min {
            Ok(Self { min, max })
        } else {
            Err(SpectrumError::InvalidBounds { min, max })
        }
    }

    /// Smallest allowed value.
    pub const fn min(&self) -> f64 {
        self.min
    }

    /// Largest allowed value (may be infinite).
    pub const fn max(&self) -> f64 {
        self.max
    }

    /// Whether `value` is inside the bounds.
    pub fn contains(&self, value: f64) -> bool {
        value >= self.min && value <= self.max
    }
}

impl fmt::Display for ValueBounds {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.max.is_infinite() {
            write!(f, "[{}, inf)", self.min)
        } else {
            write!(f, "[{}, {}]", self.min, self.max)
        }
    }
}

/// The content of a spectra CSV file: shared wavelengths and one named column of
/// values per sample, in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectraCsv {
    /// Strictly increasing, within 300–830 nm.
    pub wavelengths_nm: Vec<f64>,
    /// `(column name, values)`, one value per wavelength.
    pub samples: Vec<(String, Vec<f64>)>,
}

impl SpectraCsv {
    /// Sample `index` (file order) as a tabulated spectrum.
    ///
    /// # Panics
    /// If `index` is out of range.
    pub fn tabulated(&self, index: usize) -> TabulatedSpectrum {
        // Already validated by `read_spectra_csv`.
        TabulatedSpectrum {
            wavelengths_nm: self.wavelengths_nm.clone(),
            values: self.samples[index].1.clone(),
        }
    }

    /// The sample whose column is named `name`, as a tabulated spectrum.
    pub fn spectrum(&self, name: &str) -> Result<TabulatedSpectrum, SpectrumError> {
        self.samples
            .iter()
            .position(|(n, _)| n == name)
            .map(|index| self.tabulated(index))
            .ok_or_else(|| SpectrumError::NoSuchSample {
                name: name.to_owned(),
            })
    }
}

/// Name of the wavelength column in spectra files.
pub const WAVELENGTH_COLUMN: &str = "wavelength_nm";

/// Reads a spectra CSV: a `wavelength_nm` column (any position) and one value column
/// per sample, named by its header. Fields are trimmed; lines starting with `#` are
/// comments (for provenance notes).
///
/// `file` names the source in error messages, which also give the line and, for a
/// bad field, the column: `spectra.csv line 7, column "red": value -0.2 is outside
/// [0, 1]`. Rejected: a missing wavelength column, no sample columns, duplicate
/// column names, ragged rows, fewer than 2 data rows, unparsable or non-finite
/// numbers, wavelengths outside 300–830 nm or not strictly increasing, and values
/// outside `bounds`.
pub fn read_spectra_csv(
    reader: impl Read,
    file: &str,
    bounds: ValueBounds,
) -> Result<SpectraCsv, SpectrumError> {
    let file_error = |problem| SpectrumError::CsvFile {
        file: file.to_owned(),
        problem,
    };
    let mut csv_reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_reader(reader);
    let header = csv_reader
        .headers()
        .map_err(|e| csv_error(file, &e))?
        .clone();
    let columns: Vec<String> = header.iter().map(str::to_owned).collect();
    for (i, column) in columns.iter().enumerate() {
        if columns[..i].contains(column) {
            return Err(file_error(CsvProblem::DuplicateColumn {
                column: column.clone(),
            }));
        }
    }
    let wavelength_column = columns
        .iter()
        .position(|c| c == WAVELENGTH_COLUMN)
        .ok_or_else(|| file_error(CsvProblem::MissingWavelengthColumn))?;
    if columns.len() < 2 {
        return Err(file_error(CsvProblem::NoSampleColumns));
    }

    let mut wavelengths_nm = Vec::new();
    let mut sample_values: Vec<Vec<f64>> = vec![Vec::new(); columns.len()];
    for record in csv_reader.records() {
        let record = record.map_err(|e| csv_error(file, &e))?;
        let line = record.position().map_or(0, csv::Position::line);
        if record.len() != columns.len() {
            return Err(SpectrumError::CsvRow {
                file: file.to_owned(),
                line,
                problem: CsvProblem::RaggedRow {
                    expected: columns.len(),
                    found: record.len(),
                },
            });
        }
        for (column_index, text) in record.iter().enumerate() {
            let field_error = |problem| SpectrumError::CsvField {
                file: file.to_owned(),
                line,
                column: columns[column_index].clone(),
                problem,
            };
            let value: f64 = text.parse().map_err(|_| {
                field_error(CsvProblem::Unparsable {
                    text: text.to_owned(),
                })
            })?;
            if !value.is_finite() {
                return Err(field_error(CsvProblem::NonFinite { value }));
            }
            if column_index == wavelength_column {
                if !(CSV_MIN_WAVELENGTH_NM..=CSV_MAX_WAVELENGTH_NM).contains(&value) {
                    return Err(field_error(CsvProblem::WavelengthOutOfRange {
                        wavelength_nm: value,
                    }));
                }
                if let Some(&previous_nm) = wavelengths_nm.last()
                    && value <= previous_nm
                {
                    return Err(field_error(CsvProblem::WavelengthNotIncreasing {
                        wavelength_nm: value,
                        previous_nm,
                    }));
                }
                wavelengths_nm.push(value);
            } else {
                if !bounds.contains(value) {
                    return Err(field_error(CsvProblem::OutOfBounds { value, bounds }));
                }
                sample_values[column_index].push(value);
            }
        }
    }
    if wavelengths_nm.len() < 2 {
        return Err(file_error(CsvProblem::TooFewRows {
            found: wavelengths_nm.len(),
        }));
    }
    let samples = columns
        .into_iter()
        .zip(sample_values)
        .enumerate()
        .filter(|&(i, _)| i != wavelength_column)
        .map(|(_, sample)| sample)
        .collect();
    Ok(SpectraCsv {
        wavelengths_nm,
        samples,
    })
}

fn csv_error(file: &str, error: &csv::Error) -> SpectrumError {
    let problem = CsvProblem::Read {
        message: error.to_string(),
    };
    match error.position() {
        Some(position) => SpectrumError::CsvRow {
            file: file.to_owned(),
            line: position.line(),
            problem,
        },
        None => SpectrumError::CsvFile {
            file: file.to_owned(),
            problem,
        },
    }
}

fn check_finite(values: &[f64]) -> Result<(), SpectrumError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(SpectrumError::NonFiniteValue {
            index,
            value: values[index],
        }),
        None => Ok(()),
    }
}

/// Linear interpolation through `(xs, ys)` (`xs` strictly increasing, non-empty),
/// constant beyond the ends.
pub(crate) fn interpolate_clamped(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let last = xs.len() - 1;
    if x <= xs[0] {
        return ys[0];
    }
    if x >= xs[last] {
        return ys[last];
    }
    // First knot strictly greater than x; 1..=last because of the checks above.
    let upper = xs.partition_point(|&k| k <= x);
    let (x0, x1) = (xs[upper - 1], xs[upper]);
    let t = (x - x0) / (x1 - x0);
    ys[upper - 1] + t * (ys[upper] - ys[upper - 1])
}

/// ∫ₐᵇ of the piecewise-linear function through `(xs, ys)`, constant beyond the ends;
/// exact (trapezoids on the clipped segments). Requires `a <= b`.
fn integrate_clamped(xs: &[f64], ys: &[f64], a: f64, b: f64) -> f64 {
    let first = xs[0];
    let last = xs[xs.len() - 1];
    let mut total = 0.0;
    // Constant extensions beyond the table.
    if a < first {
        total += ys[0] * (b.min(first) - a);
    }
    if b > last {
        total += ys[ys.len() - 1] * (b - a.max(last));
    }
    let lo = a.max(first);
    let hi = b.min(last);
    if lo < hi {
        // Segments [xs[k], xs[k+1]] overlapping (lo, hi).
        let mut k = xs.partition_point(|&x| x <= lo).saturating_sub(1);
        while k + 1 < xs.len() && xs[k] < hi {
            let s0 = xs[k].max(lo);
            let s1 = xs[k + 1].min(hi);
            if s1 > s0 {
                let f0 = interpolate_clamped(xs, ys, s0);
                let f1 = interpolate_clamped(xs, ys, s1);
                total += 0.5 * (f0 + f1) * (s1 - s0);
            }
            k += 1;
        }
    }
    total
}

fn resample_piecewise_linear(
    xs: &[f64],
    ys: &[f64],
    source_spacing_nm: f64,
    target: &WavelengthGrid,
) -> SampledSpectrum {
    let values = if target.step_nm() > source_spacing_nm {
        let half_nm = 0.5 * target.bin_width_nm();
        target
            .wavelengths_nm()
            .map(|c| integrate_clamped(xs, ys, c - half_nm, c + half_nm) / (2.0 * half_nm))
            .collect()
    } else {
        target
            .wavelengths_nm()
            .map(|x| interpolate_clamped(xs, ys, x))
            .collect()
    };
    SampledSpectrum {
        grid: *target,
        values,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integral_of_linear_segment_is_exact() {
        let xs = [400.0, 500.0];
        let ys = [0.0, 1.0];
        // Inside: ∫ from 450 to 500 of (x-400)/100 = 0.375 * 50.
        assert!((integrate_clamped(&xs, &ys, 450.0, 500.0) - 0.75 * 50.0).abs() < 1e-12);
        // Clamped ends.
        assert!((integrate_clamped(&xs, &ys, 300.0, 400.0)).abs() < 1e-12);
        assert!((integrate_clamped(&xs, &ys, 500.0, 600.0) - 100.0).abs() < 1e-12);
        assert!((integrate_clamped(&xs, &ys, 350.0, 550.0) - (50.0 + 50.0)).abs() < 1e-12);
    }
}
