//! The rig and the keypoint layouts described for people: the listings `autoact rig` and
//! `autoact layouts` print, each as a text table and as a JSON document.

use std::fmt::Write as _;

use serde_json::json;

use crate::skeleton::layout::{Coverage, JointExpr, Layout, LayoutError};
use crate::skeleton::rig::{Dof, Reference, Rig};
use crate::table::table;

/// Per bone of `rig` (in rig order), what `layout` does with it: `driven`, `driven, twist
/// unobserved`, `at rest (not in layout)`, `driven (hips)` (the root) or `static`.
///
/// # Errors
/// A layout that does not bind to the rig.
pub fn layout_status(rig: &Rig, layout: &Layout) -> Result<Vec<&'static str>, LayoutError> {
    let coverage = layout.bind(rig)?.coverage(rig);
    Ok(rig
        .bones
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
        .collect())
}

/// A vector as three signed numbers, millimetre precision (no `-0.000`).
fn fmt3(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{:+.3}", x + 0.0))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The bones table: index, names, parent, degree-of-freedom class, hinge axis, rest head and
/// length, and with `status` (from [`layout_status`]) a column of what a layout does with each.
#[must_use]
pub fn bones_table(rig: &Rig, status: Option<&[&str]>) -> String {
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

/// The bones as JSON: the frame conventions and every bone with its rest geometry (and, with
/// `status`, what a layout does with it).
#[must_use]
pub fn bones_json(rig: &Rig, status: Option<&[&str]>) -> serde_json::Value {
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
    json!({
        "rig": rig.name,
        "frame": "metres; +Z up; rest T-pose on z=0 facing +Y; +X is the body's right",
        "rotations": "local = parent_world^-1 * child_world, relative to rest (rest = identity)",
        "rest_orientation": "character_from_bone: +Y along the bone, +X hinge or lateral axis",
        "bones": bones,
    })
}

/// A landmark set by name: the landmark, or `mean(a,b,…)`.
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

/// A twist reference by landmark names.
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

/// One recipe by names: bone, degree-of-freedom class, direction and reference alternatives.
type RecipeRow = (String, String, Vec<String>, Vec<String>);

/// The rig's recipes by landmark names, in rig order.
fn recipe_rows(rig: &Rig) -> Vec<RecipeRow> {
    rig.recipes
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
        .collect()
}

/// The recipes table: which landmarks drive each bone, alternatives in order of preference.
#[must_use]
pub fn recipes_table(rig: &Rig) -> String {
    let t: Vec<Vec<String>> = recipe_rows(rig)
        .into_iter()
        .map(|(b, d, dirs, refs)| vec![b, d, dirs.join(" | "), refs.join(" | ")])
        .collect();
    format!(
        "Which landmarks drive each bone: the first alternative a layout can complete is used.\n\
         Static bones and the root (yaw from the hip line, translation from the pelvis) have no recipe.\n\n{}",
        table(&["bone", "dof", "direction", "twist reference"], &t)
    )
}

/// The recipes as JSON.
#[must_use]
pub fn recipes_json(rig: &Rig) -> serde_json::Value {
    let v: Vec<_> = recipe_rows(rig)
        .iter()
        .map(|(b, d, dirs, refs)| json!({"bone": b, "dof": d, "directions": dirs, "references": refs}))
        .collect();
    json!({ "recipes": v })
}

/// The landmarks table: each named body point, the bone it rides on and its rest position.
#[must_use]
pub fn landmarks_table(rig: &Rig) -> String {
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

/// The landmarks as JSON.
#[must_use]
pub fn landmarks_json(rig: &Rig) -> serde_json::Value {
    let v: Vec<_> = rig
        .landmarks
        .iter()
        .map(|l| json!({"name": l.name, "bone": rig.bones[l.bone].name, "rest_m": l.rest_m.coords.as_slice()}))
        .collect();
    json!({ "landmarks": v })
}

/// Every built-in layout with its coverage of `rig`, in name order.
///
/// # Errors
/// A built-in layout that does not load or bind (a bug).
pub fn builtin_layouts(rig: &Rig) -> Result<Vec<(Layout, Coverage)>, LayoutError> {
    let mut rows = Vec::new();
    for name in Layout::builtin_names() {
        let layout = Layout::builtin(name)?;
        let cov = layout.bind(rig)?.coverage(rig);
        rows.push((layout, cov));
    }
    Ok(rows)
}

/// The layouts table: per layout (from [`builtin_layouts`]) its joints, how many bones it drives,
/// drives without twist and leaves at rest, and its description.
#[must_use]
pub fn layouts_table(layouts: &[(Layout, Coverage)]) -> String {
    let t: Vec<Vec<String>> = layouts
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

/// The layouts as JSON, with the names of the bones each drives.
#[must_use]
pub fn layouts_json(layouts: &[(Layout, Coverage)]) -> serde_json::Value {
    let v: Vec<_> = layouts
        .iter()
        .map(|(l, c)| {
            json!({"name": l.name, "description": l.description, "joints": l.joints.len(),
                   "driven": c.driven, "twist_unobserved": c.twist_unobserved, "at_rest": c.at_rest})
        })
        .collect();
    json!({ "layouts": v })
}

/// A landmark's joint expression as text: `joint`, `mean(a, b)` or `a + t·(b − a)`.
fn expr_text(e: &JointExpr) -> String {
    match e {
        JointExpr::Joint(j) => j.clone(),
        JointExpr::Mean { mean } => format!("mean({})", mean.join(", ")),
        JointExpr::Lerp { from, to, t } => format!("{from} + {t}·({to} − {from})"),
    }
}

/// One layout joint by joint: its joints and the landmarks each feeds, its landmarks' joint
/// expressions, its bone overrides, and (from `coverage`) the bones it drives and leaves at rest.
#[must_use]
pub fn layout_table(layout: &Layout, coverage: &Coverage) -> String {
    let joints: Vec<Vec<String>> = layout
        .joints
        .iter()
        .enumerate()
        .map(|(i, j)| {
            let used: Vec<&str> = layout
                .landmarks
                .iter()
                .filter(|(_, e)| e.joints().contains(&j))
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
    let overrides = layout.bones.iter().fold(String::new(), |mut out, (b, o)| {
        let reference = o
            .reference
            .as_ref()
            .map_or(String::new(), |[a, c]| format!(", twist from {a}→{c}"));
        let _ = writeln!(
            out,
            "bone {b}: driven by {}→{}{reference}",
            o.direction[0], o.direction[1]
        );
        out
    });
    format!(
        "layout {}: {}\n\n{}\n{}\n{overrides}driven: {}\ndriven, twist unobserved: {}\nat rest (not in this layout): {}\n",
        layout.name,
        layout.description,
        table(&["#", "joint", "feeds landmarks"], &joints),
        table(&["landmark", "= joints"], &landmarks),
        list(&coverage.driven),
        list(&coverage.twist_unobserved),
        list(&coverage.at_rest),
    )
}

/// One layout as JSON: its joints, landmarks' joint expressions and coverage.
#[must_use]
pub fn layout_json(layout: &Layout, coverage: &Coverage) -> serde_json::Value {
    let lm: serde_json::Map<String, serde_json::Value> = layout
        .landmarks
        .iter()
        .map(|(k, e)| (k.clone(), json!(expr_text(e))))
        .collect();
    json!({"name": layout.name, "description": layout.description, "joints": layout.joints, "landmarks": lm,
           "driven": coverage.driven, "twist_unobserved": coverage.twist_unobserved, "at_rest": coverage.at_rest})
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bone_gets_a_layout_status_and_the_root_is_driven() {
        let rig = Rig::standard();
        let status = layout_status(&rig, &Layout::builtin("h36m-17").unwrap()).unwrap();
        assert_eq!(status.len(), rig.bones.len());
        let root = rig
            .bones
            .iter()
            .position(|b| matches!(b.dof, Dof::Root))
            .unwrap();
        assert_eq!(status[root], "driven (hips)");
        assert!(status.contains(&"at rest (not in layout)"));
    }

    #[test]
    fn tables_and_json_list_the_same_items() {
        let rig = Rig::standard();
        let status = vec!["static"; rig.bones.len()];
        let bones = bones_json(&rig, Some(&status));
        assert_eq!(bones["bones"].as_array().unwrap().len(), rig.bones.len());
        assert_eq!(bones["bones"][0]["layout"], "static");
        assert!(bones_json(&rig, None)["bones"][0].get("layout").is_none());
        // Two heading lines, a blank line, the header and the rule, then one row per bone.
        assert_eq!(bones_table(&rig, None).lines().count(), 5 + rig.bones.len());
        assert!(
            bones_table(&rig, Some(&status))
                .lines()
                .nth(3)
                .unwrap()
                .ends_with("layout")
        );
        let landmarks = landmarks_json(&rig);
        assert_eq!(
            landmarks["landmarks"].as_array().unwrap().len(),
            rig.landmarks.len()
        );
        assert_eq!(
            landmarks_table(&rig).lines().count(),
            4 + rig.landmarks.len()
        );
        let recipes = recipes_json(&rig);
        assert_eq!(
            recipes["recipes"].as_array().unwrap().len(),
            rig.recipes.len()
        );
        assert_eq!(recipes_table(&rig).lines().count(), 5 + rig.recipes.len());
    }

    #[test]
    fn the_layout_listing_names_every_builtin_and_one_layout_shows_its_joints() {
        let rig = Rig::standard();
        let layouts = builtin_layouts(&rig).unwrap();
        let text = layouts_table(&layouts);
        for name in Layout::builtin_names() {
            assert!(text.contains(&format!("\n{name} ")), "{name}: {text}");
        }
        assert_eq!(
            layouts_json(&layouts)["layouts"].as_array().unwrap().len(),
            layouts.len()
        );
        let (layout, coverage) = &layouts[0];
        let text = layout_table(layout, coverage);
        assert!(text.starts_with(&format!("layout {}: ", layout.name)));
        assert!(text.contains("\nat rest (not in this layout): "));
        assert_eq!(
            layout_json(layout, coverage)["joints"]
                .as_array()
                .unwrap()
                .len(),
            layout.joints.len()
        );
    }

    #[test]
    fn expressions_read_as_formulas() {
        assert_eq!(expr_text(&JointExpr::Joint("nose".into())), "nose");
        assert_eq!(
            expr_text(&JointExpr::Mean {
                mean: vec!["a".into(), "b".into()]
            }),
            "mean(a, b)"
        );
        assert_eq!(fmt3(&[0.0, -0.0, 1.23456]), "+0.000 +0.000 +1.235");
    }
}
