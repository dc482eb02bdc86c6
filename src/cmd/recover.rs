//! `autoact recover`: rewrite a bag that was cut off (a crash, `kill -9`, power loss) or damaged
//! into a complete one — every message of every readable chunk, with its schema, channel and
//! times, the metadata records, and a fresh summary and index.

use std::path::PathBuf;

use anyhow::Result;

use super::{Outcome, print_stdout};
use crate::mcap_io::Compression;
use crate::recover::recover;

/// Arguments of `autoact recover`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The damaged or unfinished `.mcap`, or a rosbag2 folder of them.
    pub input: PathBuf,
    /// Where to write the recovered bag: a file for a `.mcap`; for a rosbag2 folder, a folder
    /// that gets each of its `.mcap` files recovered under its own name and a fresh
    /// `metadata.yaml`.
    #[arg(short, long, value_name = "PATH")]
    pub output: PathBuf,
    /// Replace the output if it exists.
    #[arg(long)]
    pub force: bool,
    /// Chunk compression of the output.
    #[arg(long, value_enum, default_value_t = Compression::Zstd)]
    pub compression: Compression,
    /// The format of the fresh `metadata.yaml` of a recovered rosbag2 folder.
    #[command(flatten)]
    pub rosbag2: super::Rosbag2Args,
}

/// Runs `autoact recover`.
///
/// # Errors
/// An unreadable input, an output that exists (without `--force`) or cannot be written.
pub fn run(args: Args) -> Result<Outcome> {
    let Args {
        input,
        output,
        force,
        compression,
        rosbag2,
    } = args;
    let recovery = recover(&input, &output, compression, force, rosbag2.rosbag2_version)?;
    print_stdout(&recovery.report())?;
    for warning in recovery.warnings() {
        tracing::warn!("{warning}");
    }
    Ok(Outcome::from_run(&recovery))
}
