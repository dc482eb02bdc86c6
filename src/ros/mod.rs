//! ROS 2 messages as serde types, their `.msg` definitions, and CDR.
//!
//! Every message type autoact writes or reads is a plain serde struct whose fields mirror its
//! `.msg` file under `schemas/` (same names, same order), one module per ROS package. The
//! [`RosMessage`] trait gives each its ROS type name; the `.msg` texts are compiled in from
//! `schemas/`, and [`definition`] concatenates a type's text with its dependencies the way
//! rosbag2 does (root text, then per dependency a line of 80 `=`, `MSG: pkg/Type`, its text), so
//! MCAP schema records are generated from the same files ROS users build with colcon — never
//! written twice. CDR (little-endian, with the 4-byte encapsulation header) is in [`cdr`].

pub mod autoact_msgs;
pub mod builtin_interfaces;
pub mod cdr;
pub mod foxglove_msgs;
pub mod geometry_msgs;
pub mod sensor_msgs;
pub mod skeleton_decode;
pub mod std_msgs;
pub mod tf2_msgs;
pub mod type_hash;
pub mod visualization_msgs;

use serde::{Serialize, de::DeserializeOwned};

/// The ROS 2 distribution whose standard message definitions `schemas/` holds (and whose type
/// support `ros2-client` is built for): named as `ros_distro` in rosbag2 metadata.
pub const ROS_DISTRO: &str = "jazzy";

/// A ROS 2 message type.
pub trait RosMessage: Serialize + DeserializeOwned {
    /// Full type name, e.g. `geometry_msgs/msg/Point`.
    const TYPE_NAME: &'static str;
}

/// The `.msg` texts autoact knows: (full type name, text), compiled in from `schemas/`.
const SCHEMAS: [(&str, &str); 30] = [
    (
        "autoact_msgs/msg/BoneFrame",
        include_str!("../../schemas/autoact_msgs/msg/BoneFrame.msg"),
    ),
    (
        "autoact_msgs/msg/SceneState",
        include_str!("../../schemas/autoact_msgs/msg/SceneState.msg"),
    ),
    (
        "autoact_msgs/msg/Segment",
        include_str!("../../schemas/autoact_msgs/msg/Segment.msg"),
    ),
    (
        "autoact_msgs/msg/VideoInfo",
        include_str!("../../schemas/autoact_msgs/msg/VideoInfo.msg"),
    ),
    (
        "autoact_msgs/msg/FrameAnnotation",
        include_str!("../../schemas/autoact_msgs/msg/FrameAnnotation.msg"),
    ),
    (
        "foxglove_msgs/msg/CompressedVideo",
        include_str!("../../schemas/foxglove_msgs/msg/CompressedVideo.msg"),
    ),
    (
        "autoact_msgs/msg/Skeleton3D",
        include_str!("../../schemas/autoact_msgs/msg/Skeleton3D.msg"),
    ),
    (
        "builtin_interfaces/msg/Duration",
        include_str!("../../schemas/builtin_interfaces/msg/Duration.msg"),
    ),
    (
        "builtin_interfaces/msg/Time",
        include_str!("../../schemas/builtin_interfaces/msg/Time.msg"),
    ),
    (
        "geometry_msgs/msg/Point",
        include_str!("../../schemas/geometry_msgs/msg/Point.msg"),
    ),
    (
        "geometry_msgs/msg/Pose",
        include_str!("../../schemas/geometry_msgs/msg/Pose.msg"),
    ),
    (
        "geometry_msgs/msg/PoseArray",
        include_str!("../../schemas/geometry_msgs/msg/PoseArray.msg"),
    ),
    (
        "geometry_msgs/msg/PoseStamped",
        include_str!("../../schemas/geometry_msgs/msg/PoseStamped.msg"),
    ),
    (
        "geometry_msgs/msg/Quaternion",
        include_str!("../../schemas/geometry_msgs/msg/Quaternion.msg"),
    ),
    (
        "geometry_msgs/msg/Transform",
        include_str!("../../schemas/geometry_msgs/msg/Transform.msg"),
    ),
    (
        "geometry_msgs/msg/TransformStamped",
        include_str!("../../schemas/geometry_msgs/msg/TransformStamped.msg"),
    ),
    (
        "geometry_msgs/msg/Vector3",
        include_str!("../../schemas/geometry_msgs/msg/Vector3.msg"),
    ),
    (
        "sensor_msgs/msg/CameraInfo",
        include_str!("../../schemas/sensor_msgs/msg/CameraInfo.msg"),
    ),
    (
        "sensor_msgs/msg/CompressedImage",
        include_str!("../../schemas/sensor_msgs/msg/CompressedImage.msg"),
    ),
    (
        "sensor_msgs/msg/Image",
        include_str!("../../schemas/sensor_msgs/msg/Image.msg"),
    ),
    (
        "sensor_msgs/msg/PointCloud2",
        include_str!("../../schemas/sensor_msgs/msg/PointCloud2.msg"),
    ),
    (
        "sensor_msgs/msg/PointField",
        include_str!("../../schemas/sensor_msgs/msg/PointField.msg"),
    ),
    (
        "sensor_msgs/msg/RegionOfInterest",
        include_str!("../../schemas/sensor_msgs/msg/RegionOfInterest.msg"),
    ),
    (
        "std_msgs/msg/ColorRGBA",
        include_str!("../../schemas/std_msgs/msg/ColorRGBA.msg"),
    ),
    (
        "std_msgs/msg/Header",
        include_str!("../../schemas/std_msgs/msg/Header.msg"),
    ),
    (
        "tf2_msgs/msg/TFMessage",
        include_str!("../../schemas/tf2_msgs/msg/TFMessage.msg"),
    ),
    (
        "visualization_msgs/msg/Marker",
        include_str!("../../schemas/visualization_msgs/msg/Marker.msg"),
    ),
    (
        "visualization_msgs/msg/MarkerArray",
        include_str!("../../schemas/visualization_msgs/msg/MarkerArray.msg"),
    ),
    (
        "visualization_msgs/msg/MeshFile",
        include_str!("../../schemas/visualization_msgs/msg/MeshFile.msg"),
    ),
    (
        "visualization_msgs/msg/UVCoordinate",
        include_str!("../../schemas/visualization_msgs/msg/UVCoordinate.msg"),
    ),
];

/// The `.msg` text of a type (`pkg/msg/Type` or `pkg/Type`), if autoact knows it.
#[must_use]
pub fn msg_text(type_name: &str) -> Option<&'static str> {
    let full = full_name(type_name, "");
    SCHEMAS.iter().find(|(n, _)| *n == full).map(|(_, t)| *t)
}

/// `pkg/Type` or `pkg/msg/Type` → `pkg/msg/Type`; a bare `Type` is in `package`. The one place
/// type names are made full, for schema texts and type hashes.
fn full_name(name: &str, package: &str) -> String {
    let parts: Vec<&str> = name.split('/').collect();
    match parts.as_slice() {
        [pkg, "msg", ty] | [pkg, ty] => format!("{pkg}/msg/{ty}"),
        [ty] => format!("{package}/msg/{ty}"),
        _ => name.to_string(),
    }
}

/// The full `ros2msg` definition of a type: its text, then every dependency (depth first, each
/// once) after a line of 80 `=` and `MSG: pkg/Type`, as rosbag2 writes schema records. `None`
/// if the type, or one it depends on, is unknown.
#[must_use]
pub fn definition(type_name: &str) -> Option<String> {
    let root = full_name(type_name, "");
    let mut out = msg_text(&root)?.to_string();
    let mut seen = vec![root.clone()];
    let mut stack: Vec<String> =
        type_hash::nested_types(msg_text(&root)?, root.split('/').next().unwrap_or(""))?;
    stack.reverse();
    while let Some(dep) = stack.pop() {
        if seen.contains(&dep) {
            continue;
        }
        let text = msg_text(&dep)?;
        // rosbag2 (`get_full_text`) always starts a block with a newline, so a text that ends
        // in one is followed by an empty line.
        out.push('\n');
        out.push_str(&"=".repeat(80));
        out.push_str("\nMSG: ");
        out.push_str(&dep.replacen("/msg/", "/", 1));
        out.push('\n');
        out.push_str(text);
        let package = dep.split('/').next().unwrap_or("").to_string();
        let mut inner = type_hash::nested_types(text, &package)?;
        inner.reverse();
        stack.extend(inner);
        seen.push(dep);
    }
    Some(out)
}

/// The full definition of `M` (see [`definition`]).
///
/// # Panics
/// Never for the types in this module: a test checks that every one resolves.
#[must_use]
pub fn definition_of<M: RosMessage>() -> String {
    definition(M::TYPE_NAME)
        .unwrap_or_else(|| panic!("internal bug: no .msg text for {}", M::TYPE_NAME))
}

/// Whether `cdr` (with its encapsulation header) decodes as `type_name`, for every message type
/// autoact has a Rust type of; `None` for other types. The one place that maps a type name to
/// its decoder, for `info` and `record`.
#[must_use]
pub fn check_decodes(type_name: &str, cdr: &[u8]) -> Option<Result<(), cdr::CdrError>> {
    fn check<M: RosMessage>(cdr: &[u8]) -> Result<(), cdr::CdrError> {
        cdr::decode::<M>(cdr).map(drop)
    }
    let check: fn(&[u8]) -> Result<(), cdr::CdrError> = match type_name {
        autoact_msgs::Skeleton3D::TYPE_NAME => check::<autoact_msgs::Skeleton3D>,
        autoact_msgs::BoneFrame::TYPE_NAME => check::<autoact_msgs::BoneFrame>,
        autoact_msgs::SceneState::TYPE_NAME => check::<autoact_msgs::SceneState>,
        autoact_msgs::Segment::TYPE_NAME => check::<autoact_msgs::Segment>,
        autoact_msgs::VideoInfo::TYPE_NAME => check::<autoact_msgs::VideoInfo>,
        autoact_msgs::FrameAnnotation::TYPE_NAME => check::<autoact_msgs::FrameAnnotation>,
        foxglove_msgs::CompressedVideo::TYPE_NAME => check::<foxglove_msgs::CompressedVideo>,
        geometry_msgs::PoseArray::TYPE_NAME => check::<geometry_msgs::PoseArray>,
        geometry_msgs::PoseStamped::TYPE_NAME => check::<geometry_msgs::PoseStamped>,
        geometry_msgs::TransformStamped::TYPE_NAME => check::<geometry_msgs::TransformStamped>,
        sensor_msgs::CameraInfo::TYPE_NAME => check::<sensor_msgs::CameraInfo>,
        sensor_msgs::CompressedImage::TYPE_NAME => check::<sensor_msgs::CompressedImage>,
        sensor_msgs::Image::TYPE_NAME => check::<sensor_msgs::Image>,
        sensor_msgs::PointCloud2::TYPE_NAME => check::<sensor_msgs::PointCloud2>,
        tf2_msgs::TFMessage::TYPE_NAME => check::<tf2_msgs::TFMessage>,
        visualization_msgs::Marker::TYPE_NAME => check::<visualization_msgs::Marker>,
        visualization_msgs::MarkerArray::TYPE_NAME => check::<visualization_msgs::MarkerArray>,
        _ => return None,
    };
    Some(check(cdr))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_vendored_type_resolves_with_its_dependencies() {
        for (name, _) in SCHEMAS {
            let def = definition(name).unwrap_or_else(|| panic!("{name} does not resolve"));
            assert!(def.starts_with(msg_text(name).unwrap()));
        }
    }

    #[test]
    fn definitions_concatenate_dependencies_once_in_rosbag2_form() {
        let def = definition("autoact_msgs/msg/Skeleton3D").unwrap();
        let sep = format!("\n\n{}\n", "=".repeat(80));
        let blocks: Vec<&str> = def.split(&sep).collect();
        let names: Vec<&str> = blocks[1..]
            .iter()
            .map(|b| b.lines().next().unwrap())
            .collect();
        assert_eq!(
            names,
            [
                "MSG: std_msgs/Header",
                "MSG: builtin_interfaces/Time",
                "MSG: geometry_msgs/Point"
            ]
        );
        let tf = definition("tf2_msgs/msg/TFMessage").unwrap();
        assert_eq!(tf.matches("MSG: geometry_msgs/Vector3").count(), 1);
    }

    /// Field names of a `.msg` text, in order (constants and comments skipped).
    fn msg_fields(text: &str) -> Vec<String> {
        text.lines()
            .map(|l| l.split('#').next().unwrap_or("").trim())
            .filter(|l| !l.is_empty() && !l.contains('='))
            .filter_map(|l| l.split_whitespace().nth(1).map(str::to_string))
            .collect()
    }

    fn serde_fields<M: RosMessage + Default>() -> Vec<String> {
        match serde_json::to_value(M::default()).unwrap() {
            serde_json::Value::Object(map) => map.keys().cloned().collect(),
            other => panic!("{} is not a struct: {other}", M::TYPE_NAME),
        }
    }

    /// Law: every Rust message type has exactly its `.msg` fields, in `.msg` order (CDR is
    /// positional, so order is the wire format).
    #[test]
    fn rust_types_mirror_their_msg_files() {
        fn check<M: RosMessage + Default>() {
            let text =
                msg_text(M::TYPE_NAME).unwrap_or_else(|| panic!("no .msg for {}", M::TYPE_NAME));
            assert_eq!(serde_fields::<M>(), msg_fields(text), "{}", M::TYPE_NAME);
        }
        check::<autoact_msgs::Skeleton3D>();
        check::<autoact_msgs::BoneFrame>();
        check::<autoact_msgs::SceneState>();
        check::<autoact_msgs::Segment>();
        check::<autoact_msgs::VideoInfo>();
        check::<autoact_msgs::FrameAnnotation>();
        check::<foxglove_msgs::CompressedVideo>();
        check::<geometry_msgs::PoseStamped>();
        check::<sensor_msgs::CameraInfo>();
        check::<sensor_msgs::Image>();
        check::<sensor_msgs::RegionOfInterest>();
        check::<sensor_msgs::PointField>();
        check::<sensor_msgs::PointCloud2>();
        check::<builtin_interfaces::Time>();
        check::<builtin_interfaces::Duration>();
        check::<std_msgs::Header>();
        check::<std_msgs::ColorRGBA>();
        check::<geometry_msgs::Point>();
        check::<geometry_msgs::Vector3>();
        check::<geometry_msgs::Quaternion>();
        check::<geometry_msgs::Pose>();
        check::<geometry_msgs::PoseArray>();
        check::<geometry_msgs::Transform>();
        check::<geometry_msgs::TransformStamped>();
        check::<tf2_msgs::TFMessage>();
        check::<sensor_msgs::CompressedImage>();
        check::<visualization_msgs::UVCoordinate>();
        check::<visualization_msgs::MeshFile>();
        check::<visualization_msgs::Marker>();
        check::<visualization_msgs::MarkerArray>();
    }

    #[test]
    fn cdr_round_trips_and_matches_the_measured_layout() {
        // Measured with rosbags/mcap_ros2 (reference notes): a string is a u32 length counting
        // the NUL, the bytes, the NUL; the header comes first and is not an alignment origin.
        let h = std_msgs::Header {
            stamp: builtin_interfaces::Time { sec: 1, nanosec: 2 },
            frame_id: "hi".into(),
        };
        let bytes = cdr::encode(&h).unwrap();
        assert_eq!(
            bytes,
            [
                0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, b'h', b'i', 0
            ]
        );
        let s = autoact_msgs::Skeleton3D {
            header: h,
            layout: "h36m-17".into(),
            track_id: 7,
            joint_names: vec!["a".into(), "bc".into()],
            positions: vec![
                geometry_msgs::Point {
                    x: 1.0,
                    y: f64::NAN,
                    z: -3.5,
                },
                geometry_msgs::Point::default(),
            ],
            confidence: vec![0.5, 1.0],
        };
        let back: autoact_msgs::Skeleton3D = cdr::decode(&cdr::encode(&s).unwrap()).unwrap();
        assert_eq!(back.joint_names, s.joint_names);
        assert!(back.positions[0].y.is_nan() && back.positions[0].z == -3.5);
        assert_eq!(back.track_id, 7);
        assert!(
            cdr::decode::<autoact_msgs::Skeleton3D>(&bytes).is_err(),
            "a header is not a skeleton"
        );
        assert!(matches!(
            cdr::decode::<std_msgs::Header>(&[0, 1]),
            Err(cdr::CdrError::TooShort(2))
        ));
        assert!(matches!(
            cdr::decode::<std_msgs::Header>(&[0, 3, 0, 0]),
            Err(cdr::CdrError::Encapsulation(0, 3))
        ));
    }

    fn arb_bone_frame() -> impl proptest::strategy::Strategy<Value = autoact_msgs::BoneFrame> {
        use proptest::prelude::*;
        let name = prop::sample::select(vec!["", "hips", "spine_01", "neck"]);
        let quaternion =
            (any::<f64>(), -1.0..1.0f64).prop_map(|(x, w)| geometry_msgs::Quaternion {
                x,
                y: -x,
                z: 0.5,
                w,
            });
        (
            (any::<i32>(), any::<u32>(), name.clone()),
            (any::<u64>(), any::<u32>()),
            prop::collection::vec(name.prop_map(String::from), 0..4),
            prop::collection::vec(quaternion, 0..4),
            any::<f64>(),
        )
            .prop_map(
                |((sec, nanosec, rig), (track_id, variant), bone_names, rotations, x)| {
                    autoact_msgs::BoneFrame {
                        header: std_msgs::Header {
                            stamp: builtin_interfaces::Time { sec, nanosec },
                            frame_id: "world".into(),
                        },
                        rig: rig.into(),
                        track_id,
                        variant,
                        bone_names,
                        local_rotations: rotations,
                        root_translation: geometry_msgs::Vector3 { x, y: 1.0, z: -x },
                    }
                },
            )
    }

    fn arb_markers() -> impl proptest::strategy::Strategy<Value = visualization_msgs::MarkerArray> {
        use proptest::prelude::*;
        let point = (-5.0..5.0f64).prop_map(|x| geometry_msgs::Point {
            x,
            y: 2.0 * x,
            z: 1.0,
        });
        let marker = (
            prop::sample::select(vec!["skeleton", "skeleton/v1"]),
            any::<i32>(),
            any::<bool>(),
            any::<f32>(),
            prop::collection::vec(point, 0..5),
            prop::collection::vec(any::<u8>(), 0..3),
        )
            .prop_map(|(ns, id, frame_locked, a, points, mesh)| {
                visualization_msgs::Marker {
                    ns: ns.into(),
                    id,
                    type_: visualization_msgs::Marker::LINE_LIST,
                    frame_locked,
                    color: std_msgs::ColorRGBA {
                        r: 1.0,
                        g: 0.5,
                        b: 0.0,
                        a,
                    },
                    points,
                    mesh_file: visualization_msgs::MeshFile {
                        filename: String::new(),
                        data: mesh,
                    },
                    ..visualization_msgs::Marker::default()
                }
            });
        prop::collection::vec(marker, 0..3)
            .prop_map(|markers| visualization_msgs::MarkerArray { markers })
    }

    proptest::proptest! {
        /// Law: `encode_over` gives a fresh encoding's bytes, whatever message of its type its
        /// buffer held before (of the same shape or not).
        #[test]
        fn encoding_over_the_previous_message_gives_a_fresh_encoding(
            frames in proptest::collection::vec(arb_bone_frame(), 1..6),
            markers in proptest::collection::vec(arb_markers(), 1..6),
        ) {
            let mut buf = Vec::new();
            for f in &frames {
                cdr::encode_over(f, &mut buf).unwrap();
                proptest::prop_assert_eq!(&buf, &cdr::encode(f).unwrap());
            }
            // Same shape, new numbers: the fast path.
            let mut moved = frames[0].clone();
            cdr::encode_over(&moved, &mut buf).unwrap();
            moved.header.stamp.sec = moved.header.stamp.sec.wrapping_add(1);
            moved.root_translation.x = 0.25;
            cdr::encode_over(&moved, &mut buf).unwrap();
            proptest::prop_assert_eq!(&buf, &cdr::encode(&moved).unwrap());
            let mut buf = Vec::new();
            for m in &markers {
                cdr::encode_over(m, &mut buf).unwrap();
                proptest::prop_assert_eq!(&buf, &cdr::encode(m).unwrap());
            }
        }

        /// Law: decoding into a value that held another message gives what `decode` gives.
        #[test]
        fn decoding_in_place_gives_what_decoding_gives(
            frames in proptest::collection::vec(arb_bone_frame(), 1..6),
        ) {
            let mut place = autoact_msgs::BoneFrame::default();
            for f in &frames {
                let bytes = cdr::encode(f).unwrap();
                cdr::decode_in_place(&bytes, &mut place).unwrap();
                let fresh: autoact_msgs::BoneFrame = cdr::decode(&bytes).unwrap();
                // Compared as bytes: NaN is not equal to itself.
                proptest::prop_assert_eq!(cdr::encode(&place).unwrap(), cdr::encode(&fresh).unwrap());
                // A cut message (its last float short) is an error, not a partial success.
                proptest::prop_assert!(cdr::decode_in_place(&bytes[..bytes.len() - 1], &mut place).is_err());
                cdr::decode_in_place(&bytes, &mut place).unwrap();
            }
        }
    }

    #[test]
    fn check_decodes_knows_the_message_types_and_rejects_damage() {
        let ok = cdr::encode(&sensor_msgs::CameraInfo::default()).unwrap();
        assert!(matches!(
            check_decodes(sensor_msgs::CameraInfo::TYPE_NAME, &ok),
            Some(Ok(()))
        ));
        assert!(matches!(
            check_decodes(sensor_msgs::CameraInfo::TYPE_NAME, &ok[..ok.len() - 3]),
            Some(Err(_))
        ));
        assert!(check_decodes("std_msgs/msg/String", &ok).is_none());
    }

    #[test]
    fn constants_are_not_dependencies() {
        let deps = type_hash::nested_types(
            "int32 ARROW=0\nuint8 X = 3\nstring<=5 s\nfloat64[3] v\nfoo/Bar b\nBaz c\n",
            "p",
        )
        .unwrap();
        assert_eq!(deps, ["foo/msg/Bar", "p/msg/Baz"]);
    }
}
