//! `sensor_msgs`: the camera's calibration (`CameraInfo`), raw camera frames (`Image`, which
//! `autoact record` stores and checks), what `visualization_msgs/Marker` embeds, and the two
//! messages Rerun draws that Foxglove and RViz draw too: a skeleton's joints as a `PointCloud2`
//! and an H.264 stream as `CompressedImage` frames with format `h264`.

use serde::{Deserialize, Serialize};

use super::RosMessage;
use super::std_msgs::Header;

/// `sensor_msgs/msg/CompressedImage`: a Marker's texture (autoact leaves it empty), or one
/// H.264 access unit of a render bag's video for Rerun (format `h264`).
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

/// `sensor_msgs/msg/PointField`: one field of a [`PointCloud2`]'s points.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct PointField {
    /// Field name, e.g. `x`.
    pub name: String,
    /// Byte offset from the start of a point.
    pub offset: u32,
    /// Element type ([`PointField::FLOAT32`], ...).
    pub datatype: u8,
    /// Number of elements.
    pub count: u32,
}

impl PointField {
    /// `FLOAT32`.
    pub const FLOAT32: u8 = 7;
}

impl RosMessage for PointField {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/PointField";
}

/// `sensor_msgs/msg/PointCloud2`: points as a binary blob laid out by `fields`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct PointCloud2 {
    /// Stamp and the frame the points are in.
    pub header: Header,
    /// Rows (1: unordered).
    pub height: u32,
    /// Points per row.
    pub width: u32,
    /// Layout of a point.
    pub fields: Vec<PointField>,
    /// Whether the data is big-endian.
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// The points, `row_step * height` bytes.
    pub data: Vec<u8>,
    /// Whether every point is finite.
    pub is_dense: bool,
}

impl RosMessage for PointCloud2 {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/PointCloud2";
}

impl PointCloud2 {
    /// Bytes of an `x, y, z` `float32` point.
    const XYZ_STEP: u32 = 12;

    /// An unordered cloud of `points` (metres, `x, y, z` as little-endian `float32`, the layout
    /// PCL, RViz, Foxglove and Rerun read) in `header`'s frame.
    ///
    /// # Panics
    /// Never for fewer than 2^28 points.
    #[must_use]
    pub fn xyz(header: Header, points: &[[f32; 3]]) -> PointCloud2 {
        let width = u32::try_from(points.len()).expect("internal bug: fewer than 2^28 points");
        let field = |name: &str, offset: u32| PointField {
            name: name.to_string(),
            offset,
            datatype: PointField::FLOAT32,
            count: 1,
        };
        PointCloud2 {
            header,
            height: 1,
            width,
            fields: vec![field("x", 0), field("y", 4), field("z", 8)],
            is_bigendian: false,
            point_step: Self::XYZ_STEP,
            row_step: Self::XYZ_STEP * width,
            data: points
                .iter()
                .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
                .collect(),
            is_dense: points.iter().flatten().all(|c| c.is_finite()),
        }
    }

    /// The points of a cloud laid out as [`PointCloud2::xyz`] lays them out; `None` for any other
    /// layout.
    #[must_use]
    pub fn xyz_points(&self) -> Option<Vec<[f32; 3]>> {
        let layout = PointCloud2::xyz(Header::default(), &[]);
        let expected_len =
            usize::try_from(u64::from(self.row_step) * u64::from(self.height)).ok()?;
        if self.fields != layout.fields
            || self.is_bigendian
            || self.point_step != Self::XYZ_STEP
            || self.row_step != Self::XYZ_STEP * self.width
            || self.data.len() != expected_len
        {
            return None;
        }
        Some(
            self.data
                .chunks_exact(12)
                .map(|p| {
                    let c = |k: usize| f32::from_le_bytes([p[k], p[k + 1], p[k + 2], p[k + 3]]);
                    [c(0), c(4), c(8)]
                })
                .collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_xyz_cloud_decodes_back_with_its_frame_and_points() {
        let header = Header {
            stamp: crate::ros::builtin_interfaces::Time { sec: 3, nanosec: 7 },
            frame_id: "track2/l_forearm".into(),
        };
        let points = [
            [0.0, 0.0, 0.0],
            [0.25, -1.5, 2.0],
            [f32::MIN_POSITIVE, 1e-3, -7.0],
        ];
        let cloud = PointCloud2::xyz(header.clone(), &points);
        assert_eq!((cloud.height, cloud.width, cloud.row_step), (1, 3, 36));
        assert!(cloud.is_dense);
        let back: PointCloud2 =
            crate::ros::cdr::decode(&crate::ros::cdr::encode(&cloud).unwrap()).unwrap();
        assert_eq!(back.header, header);
        assert_eq!(back.xyz_points().unwrap(), points);
        // The bytes a PointCloud2 reader sees: x, y, z as little-endian float32, 12 per point.
        assert_eq!(&back.data[12..16], &0.25_f32.to_le_bytes());
        assert_eq!(&back.data[16..20], &(-1.5_f32).to_le_bytes());
        let names: Vec<&str> = back.fields.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["x", "y", "z"]);
        // Any other layout is not read as x, y, z.
        let mut other = back.clone();
        other.fields[1].offset = 8;
        assert_eq!(other.xyz_points(), None);
        let mut short = back;
        short.data.pop();
        assert_eq!(short.xyz_points(), None);
        assert!(!PointCloud2::xyz(Header::default(), &[[f32::NAN, 0.0, 0.0]]).is_dense);
    }
}
