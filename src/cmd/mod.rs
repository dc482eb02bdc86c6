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

use crate::bags::output::OutputOptions;
use crate::cli::{Command, EXIT_DATA_LOST};
use crate::loss::Losses;
use crate::mcap_io::Compression;

/// How a command ended, when it did not fail.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Everything done.
    Success,
    /// Done, but some input was lost (exit code 3).
    DataLost,
}

impl Outcome {
    /// The one rule for lost input: done, and exit code 3 when any input was lost.
    #[must_use]
    pub fn from_losses(losses: &Losses) -> Outcome {
        if losses.is_empty() {
            Outcome::Success
        } else {
            Outcome::DataLost
        }
    }

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

/// ffmpeg from `AUTOACT_FFMPEG` or PATH; if absent and the user allowed it (`--download-ffmpeg`),
/// a downloaded static build.
///
/// # Errors
/// ffmpeg missing (with the install command) or the download failing.
pub(crate) fn locate_ffmpeg(download: bool) -> anyhow::Result<crate::video::Ffmpeg> {
    match crate::video::Ffmpeg::locate() {
        Ok(found) => Ok(found),
        Err(e) if download => {
            tracing::warn!("{e}; downloading ffmpeg as --download-ffmpeg allows");
            Ok(crate::video::Ffmpeg::download()?)
        }
        Err(e) => Err(e.into()),
    }
}

/// Writes `text` to stdout (results go to stdout, diagnostics to stderr).
pub(crate) fn print_stdout(text: &str) -> std::io::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()
}

/// Formats rows as a left-aligned table with a header and a rule.
pub(crate) fn table(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut widths: Vec<usize> = header.iter().map(|h| h.chars().count()).collect();
    for r in rows {
        for (w, c) in widths.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    let line = |cells: Vec<&str>| {
        let mut s = String::new();
        for (i, (c, w)) in cells.iter().zip(&widths).enumerate() {
            if i + 1 == widths.len() {
                s.push_str(c);
            } else {
                s.push_str(&format!("{c:<w$}  "));
            }
        }
        s.trim_end().to_string() + "\n"
    };
    let mut out = line(header.to_vec());
    out.push_str(&line(
        widths
            .iter()
            .map(|w| "-".repeat(*w))
            .collect::<Vec<_>>()
            .iter()
            .map(String::as_str)
            .collect(),
    ));
    for r in rows {
        out.push_str(&line(r.iter().map(String::as_str).collect()));
    }
    out
}

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

impl OutputArgs {
    /// The library's output options.
    #[must_use]
    pub fn options(&self) -> OutputOptions {
        OutputOptions {
            path: self.output.clone(),
            compression: self.compression,
            rosbag2: self.rosbag2,
            journal: self.write_expected_json,
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
