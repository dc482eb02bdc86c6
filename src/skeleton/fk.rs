//! Forward kinematics: rig + local rotations + root translation + [`Character`] → world bone
//! rotations, joint (bone head) positions and landmark positions. Used by tests, the renderer and
//! the exporters; the one place where a pose becomes positions.

use nalgebra::{Point3, UnitQuaternion, Vector3};

use crate::skeleton::character::Character;
use crate::skeleton::rig::{ROOT, Rig};

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
/// (1 for the body the animation was solved for; see [`crate::skeleton::convert::Animation::translation_scale_for`]).
pub fn forward_into(
    rig: &Rig,
    character: &Character,
    pose: &BonePose,
    translation_scale: f64,
    out: &mut WorldPose,
) {
    for (i, bone) in rig.bones.iter().enumerate() {
        let local = pose.local_rotations[i];
        match bone.parent {
            None => {
                out.rotations[i] = local;
                out.heads_m[i] = bone.head_rest_m + pose.root_translation_m * translation_scale;
            }
            Some(p) => {
                out.heads_m[i] = out.heads_m[p] + out.rotations[p] * character.head_offset_m[i];
                out.rotations[i] = out.rotations[p] * local;
            }
        }
    }
    debug_assert_eq!(
        rig.bones[ROOT].parent, None,
        "internal bug: bone 0 must be the root"
    );
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
