//! One module per command; the only layer that prints. Each has its `Args` next to its `run`,
//! which calls the library and maps the outcome to an exit code ([`Outcome`]). [`crate::cli`]
//! names the commands and dispatches to them; nothing here depends on it.

pub mod convert;
pub mod export;
pub mod generate;
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

use crate::bags::output::OutputOptions;
use crate::mcap_io::{Compression, Rosbag2Version};

pub use crate::outcome::{EXIT_DATA_LOST, EXIT_FAILURE, EXIT_USAGE, Outcome};

/// Output format of listing commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Format {
    /// An aligned text table.
    #[default]
    Table,
    /// JSON, one document.
    Json,
}

impl Format {
    /// A listing in this format: the table as it is, or the JSON document pretty-printed with a
    /// final newline (only the one asked for is built).
    pub(crate) fn pick(
        self,
        table: impl FnOnce() -> String,
        json: impl FnOnce() -> serde_json::Value,
    ) -> String {
        match self {
            Format::Table => table(),
            Format::Json => format!("{:#}\n", json()),
        }
    }
}

/// Writes `text` to stdout (results go to stdout, diagnostics to stderr).
pub(crate) fn print_stdout(text: &str) -> std::io::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()
}

/// The `metadata.yaml` format of a rosbag2 directory: one option shared by every command that
/// writes one (`convert`, `import`, `record`, `recover`).
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct Rosbag2Args {
    /// rosbag2 `metadata.yaml` format version: 9 for Jazzy and later (type description hashes,
    /// `ros_distro`), 5 for Humble, which refuses version 9 (Iron and later read both).
    #[arg(long, value_enum, value_name = "VERSION", default_value_t = Rosbag2Version::V9)]
    pub rosbag2_version: Rosbag2Version,
}

/// Where and how a command writes its bag.
#[derive(Debug, Clone, clap::Args)]
// The format version means something only for a directory.
#[command(mut_arg("rosbag2_version", |a| a.requires("rosbag2")))]
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
    /// The format of the rosbag2 directory's `metadata.yaml`.
    #[command(flatten)]
    pub rosbag2_format: Rosbag2Args,
    /// Test hook: also write `<output>.expected.json`, every message as autoact meant it, for the
    /// interoperability checks in `tools/interop`.
    #[arg(long, hide = true)]
    pub write_expected_json: bool,
    /// Replace the output if it exists. Without it an existing output is refused before
    /// anything is read; with it the old output stays untouched until the new one is complete.
    #[arg(long)]
    pub force: bool,
}

impl OutputArgs {
    /// The library's output options.
    #[must_use]
    pub fn options(&self) -> OutputOptions {
        OutputOptions {
            path: self.output.clone(),
            compression: self.compression,
            rosbag2: self.rosbag2.then_some(self.rosbag2_format.rosbag2_version),
            journal: self.write_expected_json,
            force: self.force,
        }
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
