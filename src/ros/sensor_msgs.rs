//! `sensor_msgs`: the camera's calibration (`CameraInfo`), raw camera frames (`Image`, which
//! `autoact record` stores and checks), and what `visualization_msgs/Marker` embeds.

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

/// `sensor_msgs/msg/RegionOfInterest` (autoact leaves it zero: the full image).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RegionOfInterest {
    /// Leftmost pixel.
    pub x_offset: u32,
    /// Topmost pixel.
    pub y_offset: u32,
    /// Height, pixels.
    pub height: u32,
    /// Width, pixels.
    pub width: u32,
    /// Whether a rectified ROI should be computed.
    pub do_rectify: bool,
}

impl RosMessage for RegionOfInterest {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/RegionOfInterest";
}

/// `sensor_msgs/msg/CameraInfo`: image size, distortion model and the K, R, P matrices (row
/// major), in the optical frame named by the header.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CameraInfo {
    /// Stamp and the camera's optical frame.
    pub header: Header,
    /// Image height, pixels.
    pub height: u32,
    /// Image width, pixels.
    pub width: u32,
    /// Distortion model, e.g. `plumb_bob`.
    pub distortion_model: String,
    /// Distortion coefficients.
    pub d: Vec<f64>,
    /// Intrinsic matrix, 3×3 row major.
    pub k: [f64; 9],
    /// Rectification matrix, 3×3 row major.
    pub r: [f64; 9],
    /// Projection matrix, 3×4 row major.
    pub p: [f64; 12],
    /// Horizontal binning.
    pub binning_x: u32,
    /// Vertical binning.
    pub binning_y: u32,
    /// Region of interest.
    pub roi: RegionOfInterest,
}

impl RosMessage for CameraInfo {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/CameraInfo";
}

/// `sensor_msgs/msg/Image`: an uncompressed image, row by row from the top-left pixel.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Image {
    /// Acquisition time and the camera's optical frame.
    pub header: Header,
    /// Number of rows.
    pub height: u32,
    /// Number of columns.
    pub width: u32,
    /// Pixel encoding, e.g. `rgb8` (see ROS `sensor_msgs/image_encodings.hpp`).
    pub encoding: String,
    /// Whether multi-byte pixel data is big-endian (0 or 1).
    pub is_bigendian: u8,
    /// Full row length, bytes.
    pub step: u32,
    /// The pixels, `step * height` bytes.
    pub data: Vec<u8>,
}

impl RosMessage for Image {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/Image";
}
