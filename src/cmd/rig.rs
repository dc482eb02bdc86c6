//! `autoact rig`: the rig as a table or JSON, with optional layout coverage, landmarks or recipes.

use anyhow::{Context, Result};

use super::{Format, Outcome, print_stdout};
use crate::skeleton::describe;
use crate::skeleton::layout::Layout;
use crate::skeleton::rig::Rig;

/// Arguments of `autoact rig`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Table)]
    pub format: Format,
    /// Also show, per bone, whether this layout (built-in name or .toml file) drives it.
    #[arg(long, value_name = "LAYOUT")]
    pub layout: Option<String>,
    /// List the landmarks (named body points layouts bind to) instead of the bones.
    #[arg(long, conflicts_with = "recipes")]
    pub landmarks: bool,
    /// List which landmarks drive each bone (direction and twist reference, in order of
    /// preference) instead of the bones.
    #[arg(long)]
    pub recipes: bool,
}

/// Runs `autoact rig`.
///
/// # Errors
/// An unknown layout, or a write failure.
pub fn run(args: Args) -> Result<Outcome> {
    let Args {
        format,
        layout,
        landmarks,
        recipes,
    } = args;
    let rig = Rig::standard();
    let status = match &layout {
        Some(name) => {
            let layout =
                Layout::load(name).with_context(|| format!("cannot use layout `{name}`"))?;
            Some(describe::layout_status(&rig, &layout)?)
        }
        None => None,
    };
    let text = if landmarks {
        format.pick(
            || describe::landmarks_table(&rig),
            || describe::landmarks_json(&rig),
        )
    } else if recipes {
        format.pick(
            || describe::recipes_table(&rig),
            || describe::recipes_json(&rig),
        )
    } else {
        let status = status.as_deref();
        format.pick(
            || describe::bones_table(&rig, status),
            || describe::bones_json(&rig, status),
        )
    };
    print_stdout(&text)?;
    Ok(Outcome::Success)
}
