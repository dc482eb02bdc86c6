//! `sensor_msgs`: only what `visualization_msgs/Marker` embeds.

use serde::{Deserialize, Serialize};

use super::RosMessage;
use super::std_msgs::Header;

/// `sensor_msgs/msg/CompressedImage` (a Marker's texture; autoact leaves it empty).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Header.
    pub header: Header,
    /// Image format, e.g. `jpeg`.
    pub format: String,
    /// The compressed bytes.
    pub data: Vec<u8>,
}

impl RosMessage for CompressedImage {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/CompressedImage";
}
