//! `autoact_msgs` (`schemas/autoact_msgs/`): skeletons in, bone frames out.

use serde::{Deserialize, Serialize};

use super::RosMessage;
use super::geometry_msgs::{Point, Quaternion, Vector3};
use super::std_msgs::Header;

/// `autoact_msgs/msg/Skeleton3D`: one person's joints at one instant.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Skeleton3D {
    /// Stamp and frame of the positions.
    pub header: Header,
    /// Keypoint layout name.
    pub layout: String,
    /// Tracker id of the person.
    pub track_id: u64,
    /// Joint names.
    pub joint_names: Vec<String>,
    /// Positions, metres; NaN for a joint not seen.
    pub positions: Vec<Point>,
    /// Confidence per joint in [0, 1].
    pub confidence: Vec<f32>,
}

impl RosMessage for Skeleton3D {
    const TYPE_NAME: &'static str = "autoact_msgs/msg/Skeleton3D";
}

/// `autoact_msgs/msg/BoneFrame`: one animation frame on a rig.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct BoneFrame {
    /// Stamp and world frame.
    pub header: Header,
    /// Rig name.
    pub rig: String,
    /// Tracker id of the animated person.
    pub track_id: u64,
    /// Which animation of the person: 0 as converted, 1..V the DSI variants.
    pub variant: u32,
    /// Bone names in rig order.
    pub bone_names: Vec<String>,
    /// Local rotations, relative to rest, in the parent's frame.
    pub local_rotations: Vec<Quaternion>,
    /// World position of the root bone's head, metres.
    pub root_translation: Vector3,
}

impl RosMessage for BoneFrame {
    const TYPE_NAME: &'static str = "autoact_msgs/msg/BoneFrame";
}
