//! The synthetic motion (H36M-17 keypoints, or any built-in layout's) the benchmarks write and convert: every hinge swings, the right
//! upper arm waves, the root turns slowly; where the root goes is the caller's.

use anyhow::{Context, Result};
use autoact::skeleton::character::Character;
use autoact::skeleton::fk::{self, BonePose};
use autoact::skeleton::layout::Layout;
use autoact::skeleton::pose::{PoseFrame, stamp_nanos_at};
use autoact::skeleton::rig::{Dof, Rig};
use nalgebra::{UnitQuaternion, Vector3};

/// The body and layout the motion is made on, and its current pose.
pub struct Motion {
    rig: Rig,
    /// The layout the keypoints are in.
    pub layout: Layout,
    character: Character,
    pose: BonePose,
    arm: usize,
}

impl Motion {
    /// The standard rig and body, keypoints in the built-in layout `layout`.
    pub fn in_layout(layout: &str) -> Result<Motion> {
        let rig = Rig::standard();
        let layout = Layout::builtin(layout).context("built-in layout")?;
        let character = Character::standard(&rig);
        let pose = BonePose::rest(&rig);
        let arm = rig.bone_index("r_upper_arm").context("bone")?;
        Ok(Motion {
            rig,
            layout,
            character,
            pose,
            arm,
        })
    }

    /// The keypoints of frame `k` at `fps`, the root at `root_m(t)` (`t` in seconds).
    pub fn frame(&mut self, k: usize, fps: f64, root_m: impl Fn(f64) -> Vector3<f64>) -> PoseFrame {
        #[expect(
            clippy::cast_precision_loss,
            reason = "frame counts are far below 2^52"
        )]
        let t = k as f64 / fps;
        for (b, bone) in self.rig.bones.iter().enumerate() {
            if let Dof::Hinge { axis } = bone.dof {
                self.pose.local_rotations[b] =
                    UnitQuaternion::from_axis_angle(&axis, 0.5 + 0.3 * (2.0 * t).sin());
            }
        }
        self.pose.local_rotations[self.arm] =
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -1.0 + 0.5 * (3.0 * t).sin());
        self.pose.local_rotations[0] = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.1 * t);
        self.pose.root_translation_m = root_m(t);
        let world = fk::forward(&self.rig, &self.character, &self.pose, 1.0);
        self.layout
            .keypoints_from_rig(&self.rig, &self.character, &world, stamp_nanos_at(k, fps))
    }
}
