//! `autoact_msgs` (`schemas/autoact_msgs/`): skeletons in, bone frames out, and a dataset's
//! scenes and recording hierarchy.

use serde::{Deserialize, Serialize};

use super::RosMessage;
use super::builtin_interfaces::Time;
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

/// `autoact_msgs/msg/SceneState`: the drawn scene an animation is shown in.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct SceneState {
    /// Stamp (the scene's start) and world frame.
    pub header: Header,
    /// Capture session.
    pub session: String,
    /// Scene id in the hierarchy.
    pub scene_id: String,
    /// Dataset seed.
    pub seed: u64,
    /// ChaCha8 stream of the scene's draws.
    pub stream: u64,
    /// Weather name.
    pub weather: String,
    /// Meteorological visibility, metres.
    pub visibility_m: f64,
    /// Fog extinction coefficient, per metre.
    pub fog_density_per_m: f64,
    /// Cloud cover in [0, 1].
    pub cloud_cover: f64,
    /// `none`, `rain` or `snow`.
    pub precipitation: String,
    /// Precipitation rate, mm/h.
    pub precipitation_rate_mm_per_h: f64,
    /// Wind speed, m/s.
    pub wind_speed_m_per_s: f64,
    /// Multiplier on clear-sky ambient light, [0, 1].
    pub ambient_light_scale: f64,
    /// Ground wetness in [0, 1].
    pub ground_wetness: f64,
    /// Snow cover in [0, 1].
    pub snow_cover: f64,
    /// Lightning flashes.
    pub lightning: bool,
    /// Local solar clock, `HH:MM`.
    pub clock: String,
    /// Latitude of the sun computation, degrees.
    pub latitude_deg: f64,
    /// Day of year of the sun computation.
    pub day_of_year: u16,
    /// Sun elevation, degrees.
    pub sun_elevation_deg: f64,
    /// Sun azimuth, degrees clockwise from north.
    pub sun_azimuth_deg: f64,
    /// Location name.
    pub location: String,
    /// Height of the drawn character, metres.
    pub character_height_m: f64,
    /// Every drawn parameter, JSON.
    pub parameters_json: String,
}

impl RosMessage for SceneState {
    const TYPE_NAME: &'static str = "autoact_msgs/msg/SceneState";
}

/// `autoact_msgs/msg/Segment`: one leaf of the recording hierarchy on a capture timeline.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Segment {
    /// Stamp (the segment's start) and world frame.
    pub header: Header,
    /// Capture session.
    pub session: String,
    /// Unique leaf id.
    pub id: String,
    /// Category.
    pub category: String,
    /// Action label.
    pub action: String,
    /// Index of the label in the dataset's sorted labels.
    pub label_id: u32,
    /// Source animation, `<bag>#<track>`.
    pub animation: String,
    /// Variant index.
    pub variant: u32,
    /// Scene index within the variant.
    pub scene: u32,
    /// Viewpoint index within the scene.
    pub viewpoint: u32,
    /// Scene id.
    pub scene_id: String,
    /// Clip start.
    pub start: Time,
    /// Clip end (exclusive).
    pub end: Time,
    /// Animation start.
    pub content_start: Time,
    /// Animation end.
    pub content_end: Time,
}

impl RosMessage for Segment {
    const TYPE_NAME: &'static str = "autoact_msgs/msg/Segment";
}

/// `autoact_msgs/msg/VideoInfo`: a rendered video and how its frames map to timeline stamps.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct VideoInfo {
    /// Stamp of video frame 0, and the camera's optical frame.
    pub header: Header,
    /// Capture session.
    pub session: String,
    /// The capture bag rendered.
    pub capture_bag: String,
    /// The video, relative to the bag's folder.
    pub video_file: String,
    /// Container, e.g. `mp4`.
    pub container: String,
    /// Codec, e.g. `h264`.
    pub codec: String,
    /// Frames per second.
    pub fps: f64,
    /// Frames in the video.
    pub frame_count: u64,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Frames made keyframes on purpose (segment boundaries and frame 0).
    pub forced_keyframes: Vec<u64>,
    /// Renderer and encoder settings, JSON.
    pub settings_json: String,
}

impl RosMessage for VideoInfo {
    const TYPE_NAME: &'static str = "autoact_msgs/msg/VideoInfo";
}

/// `autoact_msgs/msg/FrameAnnotation`: the character's keypoints and box in one rendered frame.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct FrameAnnotation {
    /// Stamp of the timeline frame, and the camera's optical frame.
    pub header: Header,
    /// Index of the frame in the video.
    pub frame_index: u64,
    /// The clip the frame belongs to, or `""`.
    pub segment_id: String,
    /// Keypoint names (the rig's bones, whose heads are the joints).
    pub keypoint_names: Vec<String>,
    /// Keypoints in the optical frame, metres.
    pub keypoints_3d: Vec<Point>,
    /// Pixel coordinates, interleaved x, y (OpenCV convention).
    pub keypoints_2d: Vec<f32>,
    /// COCO visibility per keypoint: 0 out of view, 1 hidden by scenery, 2 visible.
    pub visibility: Vec<u8>,
    /// Bounding box of the rendered silhouette.
    pub bbox: crate::ros::sensor_msgs::RegionOfInterest,
    /// Pixels of the silhouette.
    pub silhouette_pixels: u32,
    /// The rig's landmark names (face, feet, fingers, …), in the rig's order.
    pub landmark_names: Vec<String>,
    /// Landmarks in the optical frame, metres.
    pub landmarks_3d: Vec<Point>,
    /// Landmark pixel coordinates, interleaved x, y (OpenCV convention).
    pub landmarks_2d: Vec<f32>,
    /// COCO visibility per landmark (surface landmarks can be hidden by the body itself).
    pub landmark_visibility: Vec<u8>,
}

impl RosMessage for FrameAnnotation {
    const TYPE_NAME: &'static str = "autoact_msgs/msg/FrameAnnotation";
}
