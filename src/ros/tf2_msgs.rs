//! `tf2_msgs`: the `/tf` and `/tf_static` message.

use serde::{Deserialize, Serialize};

use super::RosMessage;
use super::geometry_msgs::TransformStamped;

/// `tf2_msgs/msg/TFMessage`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TFMessage {
    /// Transforms.
    pub transforms: Vec<TransformStamped>,
}

impl RosMessage for TFMessage {
    const TYPE_NAME: &'static str = "tf2_msgs/msg/TFMessage";
}
