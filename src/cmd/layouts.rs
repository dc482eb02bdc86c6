//! `autoact layouts`: the built-in keypoint layouts, or one layout (built-in or file) in detail.

use anyhow::{Context, Result};
use serde_json::json;

use super::{Outcome, print_stdout, table};
use crate::cli::Format;
use crate::skeleton::layout::{JointExpr, Layout};
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
        None => list(&rig, format)?,
        Some(name) => {
            let layout =
                Layout::load(&name).with_context(|| format!("cannot use layout `{name}`"))?;
            show(&rig, &layout, format)?
        }
    };
    print_stdout(&text)?;
    Ok(Outcome::Success)
}

fn list(rig: &Rig, format: Format) -> Result<String> {
    let mut rows = Vec::new();
    for name in Layout::builtin_names() {
        let layout = Layout::builtin(name)?;
        let cov = layout.bind(rig)?.coverage(rig);
        rows.push((layout, cov));
    }
    Ok(match format {
        Format::Table => {
            let t: Vec<Vec<String>> = rows
                .iter()
                .map(|(l, c)| {
                    vec![
                        l.name.clone(),
                        l.joints.len().to_string(),
                        c.driven.len().to_string(),
                        c.twist_unobserved.len().to_string(),
                        c.at_rest.len().to_string(),
                        l.description.clone(),
                    ]
                })
                .collect();
            format!(
                "Built-in keypoint layouts (a .toml file of the same form works anywhere a name does;\n\
                 `autoact layouts NAME` shows one). Bone counts are of the 48 bones that can move.\n\n{}",
                table(
                    &[
                        "layout",
                        "joints",
                        "driven",
                        "twist unobserved",
                        "at rest",
                        "description"
                    ],
                    &t
                )
            )
        }
        Format::Json => {
            let v: Vec<_> = rows
                .iter()
                .map(|(l, c)| {
                    json!({"name": l.name, "description": l.description, "joints": l.joints.len(),
                           "driven": c.driven, "twist_unobserved": c.twist_unobserved, "at_rest": c.at_rest})
                })
                .collect();
            format!("{:#}\n", json!({ "layouts": v }))
        }
    })
}

fn expr_text(e: &JointExpr) -> String {
    match e {
        JointExpr::Joint(j) => j.clone(),
        JointExpr::Mean { mean } => format!("mean({})", mean.join(", ")),
        JointExpr::Lerp { from, to, t } => format!("{from} + {t}·({to} − {from})"),
    }
}

fn show(rig: &Rig, layout: &Layout, format: Format) -> Result<String> {
    let cov = layout.bind(rig)?.coverage(rig);
    Ok(match format {
        Format::Table => {
            let joints: Vec<Vec<String>> = layout
                .joints
                .iter()
                .enumerate()
                .map(|(i, j)| {
                    let used: Vec<&str> = layout
                        .landmarks
                        .iter()
                        .filter(|(_, e)| match e {
                            JointExpr::Joint(x) => x == j,
                            JointExpr::Mean { mean } => mean.contains(j),
                            JointExpr::Lerp { from, to, .. } => from == j || to == j,
                        })
                        .map(|(k, _)| k.as_str())
                        .collect();
                    vec![
                        i.to_string(),
                        j.clone(),
                        if used.is_empty() {
                            "-".into()
                        } else {
                            used.join(", ")
                        },
                    ]
                })
                .collect();
            let landmarks: Vec<Vec<String>> = layout
                .landmarks
                .iter()
                .map(|(k, e)| vec![k.clone(), expr_text(e)])
                .collect();
            let list = |v: &[String]| {
                if v.is_empty() {
                    "(none)".to_string()
                } else {
                    v.join(", ")
                }
            };
            let overrides: String = layout
                .bones
                .iter()
                .map(|(b, o)| {
                    let reference = o
                        .reference
                        .as_ref()
                        .map_or(String::new(), |[a, c]| format!(", twist from {a}→{c}"));
                    format!(
                        "bone {b}: driven by {}→{}{reference}\n",
                        o.direction[0], o.direction[1]
                    )
                })
                .collect();
            format!(
                "layout {}: {}\n\n{}\n{}\n{overrides}driven: {}\ndriven, twist unobserved: {}\nat rest (not in this layout): {}\n",
                layout.name,
                layout.description,
                table(&["#", "joint", "feeds landmarks"], &joints),
                table(&["landmark", "= joints"], &landmarks),
                list(&cov.driven),
                list(&cov.twist_unobserved),
                list(&cov.at_rest),
            )
        }
        Format::Json => {
            let lm: serde_json::Map<String, serde_json::Value> = layout
                .landmarks
                .iter()
                .map(|(k, e)| (k.clone(), json!(expr_text(e))))
                .collect();
            format!(
                "{:#}\n",
                json!({"name": layout.name, "description": layout.description, "joints": layout.joints, "landmarks": lm,
                       "driven": cov.driven, "twist_unobserved": cov.twist_unobserved, "at_rest": cov.at_rest})
            )
        }
    })
}
