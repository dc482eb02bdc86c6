//! `autoact layouts`: the built-in keypoint layouts, or one layout (built-in or file) in detail.

use anyhow::{Context, Result};

use super::{Format, Outcome, print_stdout};
use crate::skeleton::describe;
use crate::skeleton::layout::Layout;
use crate::skeleton::rig::Rig;

/// Arguments of `autoact layouts`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A built-in layout name or a layout .toml file to show joint by joint; omit to list all.
    #[arg(value_name = "LAYOUT")]
    pub layout: Option<String>,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Table)]
    pub format: Format,
}

/// Runs `autoact layouts`.
///
/// # Errors
/// An unknown or invalid layout, or a write failure.
pub fn run(args: Args) -> Result<Outcome> {
    let Args { layout, format } = args;
    let rig = Rig::standard();
    let text = match layout {
        None => {
            let layouts = describe::builtin_layouts(&rig)?;
            format.pick(
                || {
                    let bvh = crate::formats::bvh_map::mappings_table();
                    format!("{}\n{bvh}", describe::layouts_table(&layouts))
                },
                || {
                    let mut v = describe::layouts_json(&layouts);
                    v["bvh_mappings"] = crate::formats::bvh_map::mappings_json();
                    v
                },
            )
        }
        Some(name) => {
            let layout =
                Layout::load(&name).with_context(|| format!("cannot use layout `{name}`"))?;
            let coverage = layout.bind(&rig)?.coverage(&rig);
            format.pick(
                || describe::layout_table(&layout, &coverage),
                || describe::layout_json(&layout, &coverage),
            )
        }
    };
    print_stdout(&text)?;
    Ok(Outcome::Success)
}
