//! `autoact plan SPEC`: the whole recording plan of a dataset spec, before anything is converted
//! or rendered — counts per class, weather, time, location and character, the expected size, or
//! every segment as JSON or CSV.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};

use super::{Outcome, print_stdout};
use crate::dataset::plan::Plan;
use crate::dataset::spec::Spec;
use crate::dataset::{estimated_frames, plan_report};

/// Output of `autoact plan`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PlanFormat {
    /// Counts and expected size, as text tables.
    Summary,
    /// The whole plan (every scene with its draws, every segment, the clips expected), one JSON
    /// document.
    Json,
    /// One row per segment, with the clips expected of it.
    Csv,
}

/// Arguments of `autoact plan`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The dataset spec (TOML; see `examples/dataset.toml`).
    pub spec: PathBuf,
    /// What to print.
    #[arg(long, value_enum, default_value_t = PlanFormat::Summary)]
    pub format: PlanFormat,
    /// Write to this file instead of stdout.
    #[arg(short, long, value_name = "PATH")]
    pub output: Option<PathBuf>,
    /// Replace the `--output` file if it exists (it is written whole or not at all).
    #[arg(long, requires = "output")]
    pub force: bool,
}

/// Runs `autoact plan`.
///
/// # Errors
/// An invalid spec (naming the key), an unreadable source bag, or a write failure.
pub fn run(args: Args) -> Result<Outcome> {
    if let Some(path) = &args.output
        && !args.force
        && std::fs::symlink_metadata(path).is_ok()
        && !crate::atomic_file::is_special(path)
    {
        bail!("{} exists; pass --force to replace it", path.display());
    }
    let spec = Spec::load(&args.spec)?;
    let frames = estimated_frames(&spec)?;
    let plan = Plan::build(&spec, &|class, source| frames[class][source])
        .with_context(|| format!("planning {}", spec.path.display()))?;
    let text = match args.format {
        PlanFormat::Summary => plan_report::summary(&spec, &plan),
        PlanFormat::Json => plan_report::json(&spec, &plan)?,
        PlanFormat::Csv => plan_report::csv(&spec, &plan),
    };
    match args.output {
        Some(path) => {
            crate::atomic_file::write(&path, text.as_bytes())
                .with_context(|| format!("writing {}", path.display()))?;
            print_stdout(&format!("wrote {}\n", path.display()))?;
        }
        None => print_stdout(&text)?,
    }
    Ok(Outcome::Success)
}
