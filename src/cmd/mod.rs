//! One module per command; the only layer that prints. Each has its `Args` next to its `run`.

pub mod convert;
pub mod export;
pub mod import;
pub mod info;
pub mod layouts;
pub mod plan;
pub mod record;
pub mod recover;
pub mod render;
pub mod rig;
pub mod trim;

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

use crate::cli::{Command, EXIT_DATA_LOST};
use crate::mcap_io::{BagStats, BagWriter, Compression, FileSink, WriteConfig};

/// How a command ended, when it did not fail.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Everything done.
    Success,
    /// Done, but some input was lost (exit code 3).
    DataLost,
}

impl Outcome {
    /// The process exit code for this outcome.
    #[must_use]
    pub fn exit_code(self) -> ExitCode {
        match self {
            Outcome::Success => ExitCode::SUCCESS,
            Outcome::DataLost => ExitCode::from(EXIT_DATA_LOST),
        }
    }
}

/// Runs a command.
///
/// # Errors
/// Whatever the command reports; the caller prints it and exits with code 1.
pub fn dispatch(command: Command) -> anyhow::Result<Outcome> {
    match command {
        Command::Rig(args) => rig::run(args),
        Command::Layouts(args) => layouts::run(args),
        Command::Import(args) => import::run(args),
        Command::Convert(args) => convert::run(args),
        Command::Info(args) => info::run(args),
        Command::Plan(args) => plan::run(args),
        Command::Recover(args) => recover::run(args),
        Command::Record(args) => record::run(args),
        Command::Export(args) => export::run(args),
        Command::Render(args) => render::run(args),
        Command::Trim(args) => trim::run(args),
    }
}

/// Writes `text` to stdout (results go to stdout, diagnostics to stderr).
pub(crate) fn print_stdout(text: &str) -> std::io::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()
}

pub(crate) use crate::table::table;

/// Where and how a command writes its bag.
#[derive(Debug, Clone, clap::Args)]
pub struct OutputArgs {
    /// Output file (`.mcap`), or directory with `--rosbag2`.
    #[arg(short, long, value_name = "PATH")]
    pub output: PathBuf,
    /// Chunk compression.
    #[arg(long, value_enum, default_value_t = Compression::Zstd)]
    pub compression: Compression,
    /// Write a rosbag2 directory (`metadata.yaml` + one `.mcap`) instead of a bare `.mcap`,
    /// for ROS distributions whose `ros2 bag play` wants one.
    #[arg(long)]
    pub rosbag2: bool,
    /// Test hook: also write `<output>.expected.json`, every message as autoact meant it, for the
    /// interoperability checks in `tools/interop`.
    #[arg(long, hide = true)]
    pub write_expected_json: bool,
}

/// An open output bag and how to finish it.
pub(crate) struct BagOutput {
    pub writer: BagWriter<FileSink>,
    mcap_path: PathBuf,
    args: OutputArgs,
}

impl BagOutput {
    /// Creates the output (and the rosbag2 directory if asked).
    pub fn create(args: &OutputArgs) -> anyhow::Result<BagOutput> {
        let mcap_path = if args.rosbag2 {
            std::fs::create_dir_all(&args.output).with_context(|| {
                format!(
                    "cannot create the rosbag2 directory {}",
                    args.output.display()
                )
            })?;
            let name = args
                .output
                .file_name()
                .map_or_else(|| "bag".to_string(), |n| n.to_string_lossy().into_owned());
            args.output.join(format!("{name}_0.mcap"))
        } else {
            args.output.clone()
        };
        let mut writer = BagWriter::create(
            &mcap_path,
            WriteConfig {
                compression: args.compression,
                ..WriteConfig::default()
            },
        )?;
        if args.write_expected_json {
            writer.keep_journal();
        }
        Ok(BagOutput {
            writer,
            mcap_path,
            args: args.clone(),
        })
    }

    /// Finishes the file (and `metadata.yaml`, and the journal); returns what was written.
    pub fn finish(self) -> anyhow::Result<BagStats> {
        let BagOutput {
            writer,
            mcap_path,
            args,
        } = self;
        let stats = if args.write_expected_json {
            // The interop contract: `X.mcap` ↔ `X.expected.json`, directory `D` ↔ `D.expected.json`.
            let journal = if args.rosbag2 {
                let mut p = args.output.clone().into_os_string();
                p.push(".expected.json");
                PathBuf::from(p)
            } else {
                args.output.with_extension("expected.json")
            };
            writer.finish_with_journal(&journal)?
        } else {
            writer.finish()?
        };
        if args.rosbag2 {
            let name = mcap_path
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            crate::mcap_io::write_rosbag2_metadata(&args.output, &[(name, stats.clone())])?;
        }
        Ok(stats)
    }
}

/// Prints warnings, at most `limit` in full, then a count of the rest.
pub(crate) fn warn_list<T: std::fmt::Display>(what: &str, items: &[T], limit: usize) {
    for item in items.iter().take(limit) {
        tracing::warn!("{item}");
    }
    if items.len() > limit {
        tracing::warn!("... and {} more {what}", items.len() - limit);
    }
}
