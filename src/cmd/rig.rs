//! `autoact rig`: the rig as a table or JSON, with optional layout coverage, landmarks or recipes.

use anyhow::{Context, Result};
use serde_json::json;

use super::{Outcome, print_stdout, table};
use crate::cli::Format;
use crate::skeleton::layout::Layout;
use crate::skeleton::rig::{Dof, Reference, Rig};

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
            let coverage = layout.bind(&rig)?.coverage(&rig);
            Some(
                rig.bones
                    .iter()
                    .map(|b| {
                        if coverage.driven.contains(&b.name) {
                            "driven"
                        } else if coverage.twist_unobserved.contains(&b.name) {
                            "driven, twist unobserved"
                        } else if coverage.at_rest.contains(&b.name) {
                            "at rest (not in layout)"
                        } else if matches!(b.dof, Dof::Root) {
                            "driven (hips)"
                        } else {
                            "static"
                        }
                    })
                    .collect::<Vec<_>>(),
            )
        }
        None => None,
    };
    let text = if landmarks {
        landmarks_output(&rig, format)
    } else if recipes {
        recipes_output(&rig, format)
    } else {
        bones_output(&rig, format, status.as_deref())
    };
    print_stdout(&text)?;
    Ok(Outcome::Success)
}

fn fmt3(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{:+.3}", x + 0.0))
        .collect::<Vec<_>>()
        .join(" ")
}

fn bones_output(rig: &Rig, format: Format, status: Option<&[&str]>) -> String {
    match format {
        Format::Table => {
            let mut header = vec![
                "#",
                "bone",
                "gta_name",
                "gta_tag",
                "parent",
                "dof",
                "hinge_axis",
                "head_rest_m (x y z)",
                "length_m",
            ];
            if status.is_some() {
                header.push("layout");
            }
            let rows: Vec<Vec<String>> = rig
                .bones
                .iter()
                .enumerate()
                .map(|(i, b)| {
                    let mut r = vec![
                        i.to_string(),
                        b.name.clone(),
                        b.gta_name.to_string(),
                        b.gta_tag.to_string(),
                        b.parent
                            .map_or_else(|| "-".to_string(), |p| rig.bones[p].name.clone()),
                        b.dof.label().to_string(),
                        match b.dof {
                            Dof::Hinge { axis } => fmt3(axis.as_slice()),
                            _ => "-".to_string(),
                        },
                        fmt3(b.head_rest_m.coords.as_slice()),
                        format!("{:.3}", b.rest_length_m()),
                    ];
                    if let Some(s) = status {
                        r.push(s[i].to_string());
                    }
                    r
                })
                .collect();
            format!(
                "rig {}: {} bones. autoact frame: metres, +Z up, rest T-pose facing +Y, +X = the body's right.\n\
                 Local rotations are relative to rest, in the parent's frame (local = parent_world⁻¹ · child_world).\n\n{}",
                rig.name,
                rig.bones.len(),
                table(&header, &rows)
            )
        }
        Format::Json => {
            let bones: Vec<_> = rig
                .bones
                .iter()
                .enumerate()
                .map(|(i, b)| {
                    let q = b.rest_orientation.as_ref();
                    let mut v = json!({
                        "index": i,
                        "name": b.name,
                        "gta_name": b.gta_name,
                        "gta_tag": b.gta_tag,
                        "parent": b.parent.map(|p| rig.bones[p].name.clone()),
                        "dof": b.dof.label(),
                        "hinge_axis": match b.dof { Dof::Hinge { axis } => Some(axis.as_slice().to_vec()), _ => None },
                        "head_rest_m": b.head_rest_m.coords.as_slice(),
                        "tail_rest_m": b.tail_rest_m.coords.as_slice(),
                        "length_m": b.rest_length_m(),
                        "rest_orientation_xyzw": [q.i, q.j, q.k, q.w],
                    });
                    if let Some(s) = status {
                        v["layout"] = json!(s[i]);
                    }
                    v
                })
                .collect();
            let doc = json!({
                "rig": rig.name,
                "frame": "metres; +Z up; rest T-pose on z=0 facing +Y; +X is the body's right",
                "rotations": "local = parent_world^-1 * child_world, relative to rest (rest = identity)",
                "rest_orientation": "character_from_bone: +Y along the bone, +X hinge or lateral axis",
                "bones": bones,
            });
            format!("{doc:#}\n")
        }
    }
}

fn set_name(rig: &Rig, set: &[usize]) -> String {
    let names: Vec<&str> = set
        .iter()
        .map(|&l| rig.landmarks[l].name.as_str())
        .collect();
    if names.len() == 1 {
        names[0].to_string()
    } else {
        format!("mean({})", names.join(","))
    }
}

fn reference_name(rig: &Rig, r: &Reference) -> String {
    match r {
        Reference::Direction { from, to } => {
            format!("{}→{}", set_name(rig, from), set_name(rig, to))
        }
        Reference::Normal {
            points: [a, b, c], ..
        } => {
            format!(
                "normal({},{},{})",
                rig.landmarks[*a].name, rig.landmarks[*b].name, rig.landmarks[*c].name
            )
        }
    }
}

fn recipes_output(rig: &Rig, format: Format) -> String {
    let rows: Vec<(String, String, Vec<String>, Vec<String>)> = rig
        .recipes
        .iter()
        .map(|r| {
            let b = &rig.bones[r.bone];
            (
                b.name.clone(),
                b.dof.label().to_string(),
                r.directions
                    .iter()
                    .map(|d| format!("{}→{}", set_name(rig, &d.from), set_name(rig, &d.to)))
                    .collect(),
                r.references
                    .iter()
                    .map(|x| reference_name(rig, x))
                    .collect(),
            )
        })
        .collect();
    match format {
        Format::Table => {
            let t: Vec<Vec<String>> = rows
                .iter()
                .map(|(b, d, dirs, refs)| {
                    vec![b.clone(), d.clone(), dirs.join(" | "), refs.join(" | ")]
                })
                .collect();
            format!(
                "Which landmarks drive each bone: the first alternative a layout can complete is used.\n\
                 Static bones and the root (yaw from the hip line, translation from the pelvis) have no recipe.\n\n{}",
                table(&["bone", "dof", "direction", "twist reference"], &t)
            )
        }
        Format::Json => {
            let v: Vec<_> = rows.iter().map(|(b, d, dirs, refs)| json!({"bone": b, "dof": d, "directions": dirs, "references": refs})).collect();
            format!("{:#}\n", json!({ "recipes": v }))
        }
    }
}

fn landmarks_output(rig: &Rig, format: Format) -> String {
    match format {
        Format::Table => {
            let t: Vec<Vec<String>> = rig
                .landmarks
                .iter()
                .map(|l| {
                    vec![
                        l.name.clone(),
                        rig.bones[l.bone].name.clone(),
                        fmt3(l.rest_m.coords.as_slice()),
                    ]
                })
                .collect();
            format!(
                "Landmarks: the named body points a layout binds its joints to (see `autoact layouts`).\n\n{}",
                table(&["landmark", "rides on bone", "rest_m (x y z)"], &t)
            )
        }
        Format::Json => {
            let v: Vec<_> = rig
                .landmarks
                .iter()
                .map(|l| json!({"name": l.name, "bone": rig.bones[l.bone].name, "rest_m": l.rest_m.coords.as_slice()}))
                .collect();
            format!("{:#}\n", json!({ "landmarks": v }))
        }
    }
}
