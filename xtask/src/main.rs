//! Coatlab's developer tasks, run as `cargo xtask TASK …` (the alias in
//! .cargo/config.toml): measurements that write the repository's documents and
//! assets, kept out of the shipped `coatlab` binary.
//!
//! - `cargo xtask bench reference|tradeoff`: the reference protocol and the
//!   speed/accuracy sweep (docs/tradeoff.md; [`bench`](mod@bench)).
//!
//! Exit statuses are those of `coatlab` (README, "Exit status") for the classes a
//! task can meet: 2 usage, 65 bad data, 66 a missing input, 70 a bug, 73 an output
//! that cannot be written, 74 writing stdout failed.

mod bench;

use std::io::{self, BufWriter, Write};
use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(
    name = "cargo xtask",
    bin_name = "cargo xtask",
    about = "Coatlab's developer tasks"
)]
struct Cli {
    #[command(subcommand)]
    task: Task,
}

#[derive(Subcommand, Debug)]
enum Task {
    /// Reference renders and the speed/accuracy sweep (docs/tradeoff.md).
    #[command(subcommand)]
    Bench(bench::BenchCommand),
}

/// A failed task: the error and the exit status of its class.
#[derive(Debug)]
pub struct Failed {
    pub status: u8,
    pub error: anyhow::Error,
}

/// Exit statuses (the BSD `sysexits.h` codes `coatlab` uses, and clap's 2).
pub mod status {
    pub const USAGE: u8 = 2;
    pub const DATA: u8 = 65;
    pub const NO_INPUT: u8 = 66;
    pub const INTERNAL: u8 = 70;
    pub const CANT_CREATE: u8 = 73;
    pub const IO: u8 = 74;
}

impl Failed {
    /// A failure of class `status` with `message`.
    pub fn new(status: u8, message: impl std::fmt::Display) -> Failed {
        Failed {
            status,
            error: anyhow::anyhow!("{message}"),
        }
    }
}

/// An error nothing classed is a bug.
impl From<anyhow::Error> for Failed {
    fn from(error: anyhow::Error) -> Failed {
        Failed {
            status: status::INTERNAL,
            error,
        }
    }
}

/// Progress and results go to stdout; failing to write them is an I/O failure.
impl From<io::Error> for Failed {
    fn from(error: io::Error) -> Failed {
        Failed {
            status: status::IO,
            error: error.into(),
        }
    }
}

/// Marks an error with the class of failure it is.
pub trait OrFail<T> {
    fn or_fail(self, status: u8) -> Result<T, Failed>;
}

impl<T, E: Into<anyhow::Error>> OrFail<T> for Result<T, E> {
    fn or_fail(self, status: u8) -> Result<T, Failed> {
        self.map_err(|error| Failed {
            status,
            error: error.into(),
        })
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let mut stdout = BufWriter::new(io::stdout().lock());
    let result = match &cli.task {
        Task::Bench(command) => bench::run(command, &mut stdout),
    }
    .and_then(|()| stdout.flush().map_err(Failed::from));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(failed) => {
            drop(stdout);
            let _ = writeln!(io::stderr(), "xtask: {:#}", failed.error);
            ExitCode::from(failed.status)
        }
    }
}
