//! `foxglove_msgs`: Foxglove's ROS 2 schemas that autoact writes.

use serde::{Deserialize, Serialize};

use super::RosMessage;
use super::builtin_interfaces::Time;

/// `foxglove_msgs/msg/CompressedVideo`: one frame of a compressed video stream.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CompressedVideo {
    /// When the frame was taken.
    pub timestamp: Time,
    /// The camera's frame.
    pub frame_id: String,
    /// One access unit (H.264 Annex B).
    pub data: Vec<u8>,
    /// `h264`, `h265`, `vp9` or `av1`.
    pub format: String,
}

impl RosMessage for CompressedVideo {
    const TYPE_NAME: &'static str = "foxglove_msgs/msg/CompressedVideo";
}
