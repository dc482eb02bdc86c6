//! `autoact info`: what an MCAP file holds, and whether all of it can be read.

use std::path::PathBuf;

use anyhow::Result;

use super::{Format, Outcome, print_stdout};
use crate::inspect;

/// Arguments of `autoact info`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The MCAP file.
    pub input: PathBuf,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Table)]
    pub format: Format,
}

/// Runs `autoact info`: prints the report; exit code 3 when parts of the file could not be read.
///
/// # Errors
/// A file that cannot be opened or is not MCAP.
pub fn run(args: Args) -> Result<Outcome> {
    let Args { input, format } = args;
    let report = inspect::inspect(&input)?;
    print_stdout(&format.pick(|| report.table(), || report.json()))?;
    Ok(Outcome::from_run(&report))
}
