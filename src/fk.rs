//! Forward kinematics: rig + local rotations + root translation + [`Character`] → world bone
//! rotations, joint (bone head) positions and landmark positions. Used by tests, the renderer and
//! the exporters; the one place where a pose becomes positions.

use nalgebra::{Point3, UnitQuaternion, Vector3};

use crate::character::Character;
use crate::rig::{ROOT, Rig};

/// A pose of the rig: what one animation frame stores.
#[derive(Debug, Clone, PartialEq)]
pub struct BonePose {
    /// World position of the root bone's head (on the ground under the hips at rest), metres.
    pub root_translation_m: Vector3<f64>,
    /// Local rotation of every bone (rig order), relative to rest, in the parent's frame.
    pub local_rotations: Vec<UnitQuaternion<f64>>,
}

impl BonePose {
    /// The rest pose: identity rotations, no translation.
    #[must_use]
    pub fn rest(rig: &Rig) -> BonePose {
        BonePose {
            root_translation_m: Vector3::zeros(),
            local_rotations: vec![UnitQuaternion::identity(); rig.bones.len()],
        }
    }
}

/// Per bone: whether its rotation changes anywhere in `poses`.
#[must_use]
pub fn moving_bones(poses: &[BonePose]) -> Vec<bool> {
    let Some(first) = poses.first() else {
        return Vec::new();
    };
    (0..first.local_rotations.len())
        .map(|b| {
            poses
                .iter()
                .any(|p| p.local_rotations[b] != first.local_rotations[b])
        })
        .collect()
}

/// World rotations and head positions of every bone of one posed body.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldPose {
    /// `world_from_bone` rotation relative to rest, per bone.
    pub rotations: Vec<UnitQuaternion<f64>>,
    /// Head (joint) position per bone, metres, autoact frame.
    pub heads_m: Vec<Point3<f64>>,
}

impl WorldPose {
    /// An empty pose sized for `rig`, to be filled by [`forward_into`].
    #[must_use]
    pub fn new(rig: &Rig) -> WorldPose {
        WorldPose {
            rotations: vec![UnitQuaternion::identity(); rig.bones.len()],
            heads_m: vec![Point3::origin(); rig.bones.len()],
        }
    }
}

/// Forward kinematics into a reusable buffer. `translation_scale` multiplies the root translation
/// (1 for the body the animation was solved for; see [`crate::convert::Animation::translation_scale_for`]).
pub fn forward_into(
    rig: &Rig,
    character: &Character,
    pose: &BonePose,
    translation_scale: f64,
    out: &mut WorldPose,
) {
    debug_assert_eq!(
        rig.bones[ROOT].parent, None,
        "internal bug: bone 0 must be the root"
    );
    for b in 0..rig.bones.len() {
        place_bone(rig, character, pose, translation_scale, b, out);
    }
}

/// [`forward_into`] for `bones` only, as [`with_ancestors`] lists them: the other entries of `out`
/// keep what they held. For a caller that needs a few bones of every frame, such as the skeleton
/// markers of a body-only layout, which never draw the fingers.
pub fn forward_bones_into(
    rig: &Rig,
    character: &Character,
    pose: &BonePose,
    translation_scale: f64,
    bones: &[usize],
    out: &mut WorldPose,
) {
    debug_assert!(
        bones.is_sorted(),
        "internal bug: bones must come in rig order"
    );
    for &b in bones {
        place_bone(rig, character, pose, translation_scale, b, out);
    }
}

/// `bones` and all their ancestors, in rig order (parents before children), without repeats: what
/// [`forward_bones_into`] takes.
#[must_use]
pub fn with_ancestors(rig: &Rig, bones: impl IntoIterator<Item = usize>) -> Vec<usize> {
    let mut needed = vec![false; rig.bones.len()];
    for mut b in bones {
        while !needed[b] {
            needed[b] = true;
            match rig.bones[b].parent {
                Some(p) => b = p,
                None => break,
            }
        }
    }
    (0..rig.bones.len()).filter(|&b| needed[b]).collect()
}

/// One step of forward kinematics: bone `b` from its parent, which is already placed (the rig
/// lists parents before children).
#[inline]
fn place_bone(
    rig: &Rig,
    character: &Character,
    pose: &BonePose,
    translation_scale: f64,
    b: usize,
    out: &mut WorldPose,
) {
    let local = pose.local_rotations[b];
    match rig.bones[b].parent {
        None => {
            out.rotations[b] = local;
            out.heads_m[b] = rig.bones[b].head_rest_m + pose.root_translation_m * translation_scale;
        }
        Some(p) => {
            out.heads_m[b] = out.heads_m[p] + out.rotations[p] * character.head_offset_m[b];
            out.rotations[b] = out.rotations[p] * local;
        }
    }
}

/// Forward kinematics, allocating the result.
#[must_use]
pub fn forward(
    rig: &Rig,
    character: &Character,
    pose: &BonePose,
    translation_scale: f64,
) -> WorldPose {
    let mut out = WorldPose::new(rig);
    forward_into(rig, character, pose, translation_scale, &mut out);
    out
}

/// World position of landmark `landmark` in a posed body.
#[must_use]
pub fn landmark_position(
    rig: &Rig,
    character: &Character,
    world: &WorldPose,
    landmark: usize,
) -> Point3<f64> {
    let b = rig.landmarks[landmark].bone;
    world.heads_m[b] + world.rotations[b] * character.landmark_offset_m[landmark]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_subset_of_bones_is_placed_exactly_as_the_whole_body_places_it() {
        let rig = Rig::standard();
        let character = Character::standard(&rig);
        let mut pose = BonePose::rest(&rig);
        for (b, q) in pose.local_rotations.iter_mut().enumerate() {
            #[expect(clippy::cast_precision_loss, reason = "bone indices are small")]
            let angle = 0.1 + 0.05 * b as f64;
            *q = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), angle)
                * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -angle);
        }
        pose.root_translation_m = Vector3::new(0.3, -1.2, 0.05);
        let whole = forward(&rig, &character, &pose, 0.5);

        let hand = rig.bone_index("l_hand").unwrap();
        let foot = rig.bone_index("r_foot").unwrap();
        let bones = with_ancestors(&rig, [hand, foot, hand]);
        // Rig order, no repeats, every parent listed.
        assert!(bones.is_sorted() && bones.windows(2).all(|w| w[0] != w[1]));
        assert!(
            bones
                .iter()
                .all(|&b| rig.bones[b].parent.is_none_or(|p| bones.contains(&p)))
        );
        assert!(bones.contains(&ROOT) && bones.len() < rig.bones.len());

        let mut some = WorldPose::new(&rig);
        forward_bones_into(&rig, &character, &pose, 0.5, &bones, &mut some);
        for &b in &bones {
            assert_eq!(some.heads_m[b], whole.heads_m[b], "bone {b}");
            assert_eq!(some.rotations[b], whole.rotations[b], "bone {b}");
        }
        // The rest is left as it was.
        let unplaced = (0..rig.bones.len()).find(|b| !bones.contains(b)).unwrap();
        assert_eq!(some.heads_m[unplaced], Point3::origin());
    }
}
