//! `visualization_msgs`: markers, which RViz and Foxglove draw with no plugin. autoact writes a
//! skeleton as a `LINE_LIST` marker, and reads pose-estimator output published as sphere or
//! points markers.

use serde::{Deserialize, Serialize};

use super::RosMessage;
use super::builtin_interfaces::Duration;
use super::geometry_msgs::{Point, Pose, Vector3};
use super::sensor_msgs::CompressedImage;
use super::std_msgs::{ColorRGBA, Header};

/// `visualization_msgs/msg/UVCoordinate`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct UVCoordinate {
    /// u.
    pub u: f32,
    /// v.
    pub v: f32,
}

impl RosMessage for UVCoordinate {
    const TYPE_NAME: &'static str = "visualization_msgs/msg/UVCoordinate";
}

/// `visualization_msgs/msg/MeshFile`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct MeshFile {
    /// File name.
    pub filename: String,
    /// File contents.
    pub data: Vec<u8>,
}

impl RosMessage for MeshFile {
    const TYPE_NAME: &'static str = "visualization_msgs/msg/MeshFile";
}

/// `visualization_msgs/msg/Marker`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Marker {
    /// Header.
    pub header: Header,
    /// Namespace.
    pub ns: String,
    /// Id within the namespace.
    pub id: i32,
    /// Marker type ([`Marker::SPHERE`], [`Marker::LINE_LIST`], ...).
    #[serde(rename = "type")]
    pub type_: i32,
    /// Action ([`Marker::ADD`], ...).
    pub action: i32,
    /// Pose of the marker.
    pub pose: Pose,
    /// Scale.
    pub scale: Vector3,
    /// Colour.
    pub color: ColorRGBA,
    /// How long the marker lives (0 = forever).
    pub lifetime: Duration,
    /// Whether it follows its frame.
    pub frame_locked: bool,
    /// Points (lists, points, sphere lists).
    pub points: Vec<Point>,
    /// Per-point colours.
    pub colors: Vec<ColorRGBA>,
    /// Texture resource.
    pub texture_resource: String,
    /// Texture.
    pub texture: CompressedImage,
    /// Texture coordinates.
    pub uv_coordinates: Vec<UVCoordinate>,
    /// Text (text markers).
    pub text: String,
    /// Mesh resource.
    pub mesh_resource: String,
    /// Mesh file.
    pub mesh_file: MeshFile,
    /// Whether the mesh uses its embedded materials.
    pub mesh_use_embedded_materials: bool,
}

impl Marker {
    /// `ARROW`.
    pub const ARROW: i32 = 0;
    /// `SPHERE`.
    pub const SPHERE: i32 = 2;
    /// `LINE_LIST`.
    pub const LINE_LIST: i32 = 5;
    /// `SPHERE_LIST`.
    pub const SPHERE_LIST: i32 = 7;
    /// `POINTS`.
    pub const POINTS: i32 = 8;
    /// `ADD` (also `MODIFY`).
    pub const ADD: i32 = 0;
    /// `DELETE`.
    pub const DELETE: i32 = 2;
    /// `DELETEALL`.
    pub const DELETEALL: i32 = 3;
}

impl RosMessage for Marker {
    const TYPE_NAME: &'static str = "visualization_msgs/msg/Marker";
}

/// `visualization_msgs/msg/MarkerArray`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MarkerArray {
    /// Markers.
    pub markers: Vec<Marker>,
}

impl RosMessage for MarkerArray {
    const TYPE_NAME: &'static str = "visualization_msgs/msg/MarkerArray";
}
