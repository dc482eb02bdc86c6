//! `std_msgs`: the header and a colour.

use serde::{Deserialize, Serialize};

use super::RosMessage;
use super::builtin_interfaces::Time;

/// `std_msgs/msg/Header`: stamp and coordinate frame.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Header {
    /// When the data was observed.
    pub stamp: Time,
    /// Coordinate frame of the data.
    pub frame_id: String,
}

impl RosMessage for Header {
    const TYPE_NAME: &'static str = "std_msgs/msg/Header";
}

/// `std_msgs/msg/ColorRGBA`, components in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ColorRGBA {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Alpha.
    pub a: f32,
}

impl RosMessage for ColorRGBA {
    const TYPE_NAME: &'static str = "std_msgs/msg/ColorRGBA";
}
