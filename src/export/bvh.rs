//! BVH (Biovision Hierarchy) writer: one [`Clip`] → one `.bvh` text, and its inverse through
//! autoact's own BVH reader ([`read_back`]).
//!
//! **Skeleton.** One joint per rig bone, named as the rig names it (`root`, `pelvis`, `l_thigh`,
//! … — `autoact rig` lists them), nested as the rig's parents say, children in rig order. A bone's
//! `OFFSET` is its head's rest offset from its parent's head on the clip's body
//! ([`crate::skeleton::character::Character::head_offset_m`]); bones without children end in an
//! `End Site` at their rest tail (scaled like the bone's own offset). The rest pose — every
//! channel zero — is the rig's T-pose, and every joint frame is aligned with the file's axes at
//! rest.
//!
//! **Axes and units.** The file is **Y-up, centimetres** ([`UNITS_PER_METRE`]), the body facing
//! +Z at rest with its left hand towards +X: autoact's `(x, y, z)` is written as `(−x, z, y)`
//! ([`bvh_from_autoact`], a proper rotation, the inverse of
//! [`crate::skeleton::frames::SourceAxes::YUp`]). Blender's importer wants *Scale* 0.01 for metres.
//!
//! **Channels.** The root has `Xposition Yposition Zposition Zrotation Xrotation Yrotation`
//! (position = the root bone's head in the world, per frame); every other joint
//! `Zrotation Xrotation Yrotation`. The Euler order is **ZXY** ([`EULER_ORDER`]): with angles
//! `(z, x, y)` in degrees the joint's local rotation is `Rz(z) · Rx(x) · Ry(y)` about the parent's
//! axes (column vectors), the standard BVH reading. Rotations are exactly autoact's local
//! rotations re-expressed in the file's axes (`M · q · M⁻¹`), so the file's forward kinematics
//! reproduces autoact's joint positions. Angles are continuous from frame to frame: each frame
//! takes, of the two Euler solutions and their turns by 360°, the one nearest the previous
//! frame's, so curve editors interpolate motion, not a wrap from +180° to −180°.
//!
//! **Motion.** `Frames:` is the clip's frame count and `Frame Time:` is `1 / fps` seconds.
//! Numbers have 6 decimals (1e-8 m, 1e-6°).

use std::fmt::Write as _;

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::Clip;
use crate::formats::bvh::Bvh;
use crate::skeleton::fk::{self, BonePose};
use crate::skeleton::frames::SourceAxes;
use crate::skeleton::rig::{ROOT, Rig};

/// File units per metre: the file is in centimetres.
pub const UNITS_PER_METRE: f64 = 100.0;

/// The Euler order of every rotation channel, outermost first.
pub const EULER_ORDER: &str = "ZXY";

/// `bvh_from_autoact`: autoact's `(x, y, z)` → the file's `(−x, z, y)`.
#[must_use]
pub fn bvh_from_autoact() -> Rotation3<f64> {
    SourceAxes::YUp.autoact_from_source().inverse()
}

/// Bones in the file's joint order: depth first from the root, children in rig order.
#[must_use]
pub fn joint_order(rig: &Rig) -> Vec<usize> {
    fn visit(rig: &Rig, bone: usize, out: &mut Vec<usize>) {
        out.push(bone);
        for child in (0..rig.bones.len()).filter(|&c| rig.bones[c].parent == Some(bone)) {
            visit(rig, child, out);
        }
    }
    let mut out = Vec::with_capacity(rig.bones.len());
    visit(rig, ROOT, &mut out);
    out
}

/// `v` with `decimals` decimals, never `-0.000…`.
pub(crate) fn number(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    match s.strip_prefix('-') {
        Some(rest) if rest.bytes().all(|b| b == b'0' || b == b'.') => rest.to_string(),
        _ => s,
    }
}

fn vector(v: &Vector3<f64>) -> String {
    format!("{} {} {}", number(v.x, 6), number(v.y, 6), number(v.z, 6))
}

/// Euler angles `(z, x, y)` in radians with `q = Rz(z) · Rx(x) · Ry(y)`. Without `previous`,
/// the principal solution (`x` in [−90°, 90°], the others in (−180°, 180°]); with it, the
/// equivalent solution nearest to `previous` (of the two solutions, each shifted by whole turns).
#[must_use]
pub fn euler_zxy(q: &UnitQuaternion<f64>, previous: Option<[f64; 3]>) -> [f64; 3] {
    let r: Matrix3<f64> = q.to_rotation_matrix().into_inner();
    let cos_x = r[(0, 1)].hypot(r[(1, 1)]);
    let x = r[(2, 1)].atan2(cos_x);
    let principal = if cos_x > 1e-12 {
        [
            (-r[(0, 1)]).atan2(r[(1, 1)]),
            x,
            (-r[(2, 0)]).atan2(r[(2, 2)]),
        ]
    } else {
        // Gimbal lock: only z + y (x = +90°) or z − y (x = −90°) is defined; keep y as it was.
        let combined = r[(1, 0)].atan2(r[(0, 0)]);
        let y = previous.map_or(0.0, |p| p[2]);
        let z = if x > 0.0 { combined - y } else { combined + y };
        [z, x, y]
    };
    let Some(prev) = previous else {
        return principal;
    };
    let pi = std::f64::consts::PI;
    let other = [principal[0] + pi, pi - principal[1], principal[2] + pi];
    let near =
        |a: f64, p: f64| a + std::f64::consts::TAU * ((p - a) / std::f64::consts::TAU).round();
    let unwrap = |s: [f64; 3]| {
        [
            near(s[0], prev[0]),
            near(s[1], prev[1]),
            near(s[2], prev[2]),
        ]
    };
    let cost = |s: &[f64; 3]| (0..3).map(|i| (s[i] - prev[i]).abs()).sum::<f64>();
    let (a, b) = (unwrap(principal), unwrap(other));
    if cost(&b) < cost(&a) { b } else { a }
}

/// The rotation `Rz(z) · Rx(x) · Ry(y)` of Euler angles in degrees, as a BVH reader builds it.
#[must_use]
pub fn rotation_from_euler_zxy_deg(angles_deg: [f64; 3]) -> UnitQuaternion<f64> {
    let [z, x, y] = angles_deg.map(f64::to_radians);
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), z)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), x)
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), y)
}

/// The rest offset of the `End Site` of leaf bone `b` from its head, metres, autoact frame: its
/// rest tail, scaled like the bone's own offset from its parent.
fn end_site_m(rig: &Rig, clip: &Clip, b: usize) -> Vector3<f64> {
    let bone = &rig.bones[b];
    let scale = bone.parent.map_or(1.0, |p| {
        let rest = (bone.head_rest_m - rig.bones[p].head_rest_m).norm();
        if rest > 1e-9 {
            clip.character.head_offset_m[b].norm() / rest
        } else {
            1.0
        }
    });
    (bone.tail_rest_m - bone.head_rest_m) * scale
}

/// The BVH text of `clip` (see the module docs for every convention).
#[must_use]
pub fn write(rig: &Rig, clip: &Clip) -> String {
    let m = bvh_from_autoact();
    let m_q = UnitQuaternion::from_rotation_matrix(&m);
    let to_file = |v: &Vector3<f64>| m * v * UNITS_PER_METRE;
    let order = joint_order(rig);
    let mut s = String::from("HIERARCHY\n");
    // Open joints as (bone, depth): a joint closes when the next one is not its descendant.
    let mut open: Vec<(usize, usize)> = Vec::new();
    let close = |s: &mut String, open: &mut Vec<(usize, usize)>, until_parent: Option<usize>| {
        while let Some(&(b, depth)) = open.last() {
            if Some(b) == until_parent {
                break;
            }
            let ind = "\t".repeat(depth);
            if !rig.bones.iter().any(|c| c.parent == Some(b)) {
                let end = to_file(&end_site_m(rig, clip, b));
                let _ = write!(
                    s,
                    "{ind}\tEnd Site\n{ind}\t{{\n{ind}\t\tOFFSET {}\n{ind}\t}}\n",
                    vector(&end)
                );
            }
            let _ = writeln!(s, "{ind}}}");
            open.pop();
        }
    };
    for &b in &order {
        let bone = &rig.bones[b];
        close(&mut s, &mut open, bone.parent);
        let depth = open.len();
        let ind = "\t".repeat(depth);
        if bone.parent.is_none() {
            let _ = write!(
                s,
                "ROOT {}\n{{\n\tOFFSET {}\n\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n",
                bone.name,
                vector(&to_file(&bone.head_rest_m.coords))
            );
        } else {
            let _ = write!(
                s,
                "{ind}JOINT {}\n{ind}{{\n{ind}\tOFFSET {}\n{ind}\tCHANNELS 3 Zrotation Xrotation Yrotation\n",
                bone.name,
                vector(&to_file(&clip.character.head_offset_m[b]))
            );
        }
        open.push((b, depth));
    }
    close(&mut s, &mut open, None);

    let _ = write!(
        s,
        "MOTION\nFrames: {}\nFrame Time: {}\n",
        clip.poses.len(),
        number(1.0 / clip.fps_hz, 9)
    );
    let mut previous: Vec<Option<[f64; 3]>> = vec![None; rig.bones.len()];
    let root_head = rig.bones[ROOT].head_rest_m.coords;
    for pose in &clip.poses {
        let mut line = vector(&to_file(&(root_head + pose.root_translation_m)));
        for &b in &order {
            let q = m_q * pose.local_rotations[b] * m_q.inverse();
            let angles = euler_zxy(&q, previous[b]);
            previous[b] = Some(angles);
            for a in angles {
                line.push(' ');
                line.push_str(&number(a.to_degrees(), 6));
            }
        }
        s.push_str(&line);
        s.push('\n');
    }
    s
}

/// A BVH read back lacks a joint for a bone of the rig.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{source_name}: no joint `{joint}` (rig {rig})")]
pub struct MissingJoint {
    /// The BVH (its name as read).
    pub source_name: String,
    /// The rig bone without a joint.
    pub joint: String,
    /// The rig.
    pub rig: String,
}

/// The poses a BVH this module wrote holds, read back through autoact's BVH reader
/// ([`crate::formats::bvh`]): its forward kinematics gives every joint's world orientation in
/// the file's axes, which become autoact's local rotations (`parent_world⁻¹ · world`, axes mapped
/// back) and the root's translation.
///
/// # Errors
/// [`MissingJoint`] naming the first rig bone the file has no joint for.
pub fn read_back(rig: &Rig, bvh: &Bvh) -> Result<Vec<BonePose>, MissingJoint> {
    let joints: Vec<usize> = rig
        .bones
        .iter()
        .map(|b| {
            bvh.joint_index(&b.name).ok_or_else(|| MissingJoint {
                source_name: bvh.source.clone(),
                joint: b.name.clone(),
                rig: rig.name.to_string(),
            })
        })
        .collect::<Result<_, _>>()?;
    Ok((0..bvh.frame_count())
        .map(|f| {
            let world = bvh.world_transforms(f);
            let orientation = |b: usize| SourceAxes::YUp.orientation_to_autoact(world[joints[b]].1);
            let local_rotations = rig
                .bones
                .iter()
                .enumerate()
                .map(|(b, bone)| match bone.parent {
                    None => orientation(b),
                    Some(p) => orientation(p).inverse() * orientation(b),
                })
                .collect();
            let root = SourceAxes::YUp.point_to_autoact(world[joints[ROOT]].0) / UNITS_PER_METRE;
            BonePose {
                root_translation_m: root.coords - rig.bones[ROOT].head_rest_m.coords,
                local_rotations,
            }
        })
        .collect())
}

/// What the interop check (`tools/interop/check_bvh.py`) compares a BVH with: the joint names in
/// file order, frame count and time, units and axes, and per frame every joint's position as
/// autoact's forward kinematics puts it (metres, autoact frame); for a capture scene's clip also
/// its scene id, first capture frame and frame stamps (`tools/interop/check_export_motion.py`
/// compares the file with the bag's transforms at those stamps).
#[must_use]
pub fn expected_json(rig: &Rig, clip: &Clip) -> serde_json::Value {
    let order = joint_order(rig);
    let m = bvh_from_autoact();
    let positions: Vec<Vec<[f64; 3]>> = clip
        .poses
        .iter()
        .map(|pose| {
            let world = fk::forward(rig, &clip.character, pose, 1.0);
            order
                .iter()
                .map(|&b| {
                    let p = world.heads_m[b];
                    [p.x, p.y, p.z]
                })
                .collect()
        })
        .collect();
    let rows: Vec<[f64; 3]> = (0..3).map(|r| [m[(r, 0)], m[(r, 1)], m[(r, 2)]]).collect();
    let mut json = serde_json::json!({
        "joints": order.iter().map(|&b| rig.bones[b].name.as_str()).collect::<Vec<_>>(),
        "frames": clip.poses.len(),
        "frame_time_secs": 1.0 / clip.fps_hz,
        "units_per_metre": UNITS_PER_METRE,
        "euler_order": EULER_ORDER,
        "bvh_from_autoact": rows,
        "positions_m": positions,
    });
    // A capture scene's clip: where its frames sit on the capture's timeline, so that a check can
    // compare them with the bag's own transforms.
    if let Some(scene) = &clip.scene {
        json["scene_id"] = serde_json::json!(scene.scene_id);
        json["timeline_first_frame"] = serde_json::json!(scene.first_timeline_frame);
        json["stamps_ns"] = serde_json::json!(clip.stamps_nanos);
    }
    json
}

#[cfg(test)]
#[path = "bvh_tests.rs"]
mod tests;
