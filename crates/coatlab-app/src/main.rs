//! `coatlab`: the designer's GUI when started without a subcommand, else the
//! command line.
//!
//! The CLI's command names and CSV column names are an interface that scripts depend
//! on; keep them exactly as documented in the README.

mod cmd;

use std::io::{self, BufWriter, Write};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use cmd::failure::{BROKEN_PIPE, Classify, Failure, Outcome, classify};
use coatlab_core::simd_path::SimdPath;

/// The `--help` epilogue: the exit statuses of `cmd::failure` (and the README's).
const EXIT_STATUS: &str = "\
Exit status:
  0    success
  1    the designer's window could not start
  2    usage: an unknown flag, a missing or malformed value, a value out of range
  65   bad input data: a stdin row, or a CSV, design, scene or map file's content
  66   an input file does not exist or cannot be read
  70   internal error (a bug: please report the command)
  73   an output file cannot be written
  74   reading stdin or writing stdout failed
  141  stdout was closed by its reader (`coatlab ... | head`); nothing is printed";

/// `--version`: the version and the SIMD path of the hot kernels (ray traversal,
/// paint evaluation) on this CPU (`coatlab_core::simd_path`, chosen at start-up).
fn version_line() -> &'static str {
    static LINE: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    LINE.get_or_init(|| {
        format!(
            "{} (SIMD path: {})",
            env!("CARGO_PKG_VERSION"),
            SimdPath::current().name()
        )
    })
}

#[derive(Parser, Debug)]
#[command(
    name = "coatlab",
    version = version_line(),
    about = "Spectral colour design for gloss solid automotive paints",
    after_help = EXIT_STATUS
)]
struct Cli {
    /// Without a subcommand: open the designer's window (on DESIGN, if given).
    #[command(subcommand)]
    command: Option<Command>,
    /// A design file to open in the window.
    #[arg(value_name = "DESIGN")]
    design: Option<std::path::PathBuf>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Tabulate the body BRDF and directional albedo: CSV on stdin
    /// (`n,rho,kh,theta_i_deg,theta_o_deg,dphi_deg`), CSV on stdout.
    Brdf,
    /// CIE XYZ and CIELAB of spectra in a CSV file (`wavelength_nm` plus one column per sample).
    Color(cmd::color::ColorArgs),
    /// CIEDE2000 of colour pairs: CSV `L1,a1,b1,L2,a2,b2` on stdin, adds `dE00`.
    DeltaE,
    /// Multi-angle colour and gloss readings of a paint design file.
    Measure(cmd::measure::MeasureArgs),
    /// Fit a design's pigment albedo to a measured standard (CGATS or CxF3) and write it.
    Fit(cmd::fit::FitArgs),
    /// Export a design: its virtual readings as CxF3 or CGATS.17, or the car with
    /// the design as a glTF clear-coat material (GLB).
    Export(cmd::export::ExportArgs),
    /// Convert between a glossmeter reading (GU) and the lobe exponent m.
    Gloss(cmd::gloss::GlossArgs),
    /// Render a design on a car (progressive spectral path tracer) to PNG or EXR,
    /// or a range of its samples to a .film part for `coatlab merge`.
    Render(cmd::render::RenderArgs),
    /// Add the .film parts of one render (sample ranges rendered apart) into its
    /// image, exactly as one render of all the samples writes it.
    Merge(cmd::merge::MergeArgs),
    /// Many renders from a manifest, on this machine or as a scheduler's array
    /// tasks (docs/batch.md): `batch plan`, `batch run`, `batch report`.
    Batch(cmd::batch::BatchArgs),
}

fn main() -> ExitCode {
    // A `COATLAB_SIMD` that names no path this CPU has is refused before anything
    // runs (the library would otherwise quietly take the detected path).
    if let Err(err) = SimdPath::from_env() {
        let _ = writeln!(io::stderr(), "coatlab: {err}");
        return ExitCode::from(Failure::Usage.code());
    }
    let cli = Cli::parse();
    let Some(command) = &cli.command else {
        return run_gui(cli.design);
    };
    let stdin = io::stdin().lock();
    let mut stdout = BufWriter::new(io::stdout().lock());
    let result = match command {
        Command::Brdf => cmd::brdf::run(stdin, &mut stdout),
        Command::Color(args) => cmd::color::run(args, &mut stdout),
        Command::DeltaE => cmd::delta_e::run(stdin, &mut stdout),
        Command::Measure(args) => cmd::measure::run(args, &mut stdout),
        Command::Fit(args) => cmd::fit::run(args, &mut stdout),
        Command::Export(args) => cmd::export::run(args, &mut stdout),
        Command::Gloss(args) => cmd::gloss::run(args, &mut stdout),
        Command::Render(args) => cmd::render::run(args, &mut stdout),
        Command::Merge(args) => cmd::merge::run(args, &mut stdout),
        Command::Batch(args) => cmd::batch::run(args, &mut stdout),
    }
    .and_then(|()| stdout.flush().or_fail(Failure::Io));
    let Err(err) = result else {
        return ExitCode::SUCCESS;
    };
    // The rows before a bad one are written out before the message (flushing a
    // closed pipe fails quietly).
    drop(stdout);
    match classify(&err) {
        Outcome::BrokenPipe => ExitCode::from(BROKEN_PIPE),
        Outcome::Failed(failure) => {
            // A closed stderr must not turn a failure into a panic.
            let _ = writeln!(io::stderr(), "coatlab: {err:#}");
            ExitCode::from(failure.code())
        }
    }
}

fn run_gui(design: Option<std::path::PathBuf>) -> ExitCode {
    let options = coatlab_app::gui::AppOptions {
        storage: coatlab_app::gui::storage::Storage::from_environment(),
        open: design,
        preview: true,
    };
    match coatlab_app::gui::run(options) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            let _ = writeln!(io::stderr(), "coatlab: {err:#}");
            ExitCode::FAILURE
        }
    }
}
