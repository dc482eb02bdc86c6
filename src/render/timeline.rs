//! Reading a capture bag (what `autoact convert --spec` writes) into what the renderer draws:
//! its scenes (from `/scene`), its clips (`/segments`), and per timeline frame the character's
//! pose (`/animation`) and the camera (`/camera/pose`, `/camera/camera_info`).
//!
//! Frame `k` of the rendered video is the `k`-th `/animation` frame of the bag, in stamp order;
//! the camera must have a pose at every one of those stamps.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Translation3, UnitQuaternion};

use crate::animation_bag;
use crate::camera::Intrinsics;
use crate::dataset::capture::{CAMERA_INFO_TOPIC, CAMERA_POSE_TOPIC, SCENE_TOPIC, SEGMENTS_TOPIC};
use crate::fk::BonePose;
use crate::mcap_io::BagReader;
use crate::rig::Rig;
use crate::ros::autoact_msgs::{BoneFrame, SceneState, Segment};
use crate::ros::geometry_msgs::PoseStamped;
use crate::ros::sensor_msgs::CameraInfo;
use crate::ros::{RosMessage, cdr};
use crate::scene::Scene;

/// Why a bag cannot be rendered.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TimelineError {
    /// The file could not be opened or read.
    #[error("{path}: {message}")]
    Read {
        /// The bag.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// Something the renderer needs is not in the bag.
    #[error(
        "{path}: no {what} — `autoact render` needs a capture bag, as `autoact convert --spec DATASET.toml` writes (animation bags from plain `convert` have no camera or scene)"
    )]
    Missing {
        /// The bag.
        path: PathBuf,
        /// What is missing, with its topic.
        what: String,
    },
    /// A message that cannot be used.
    #[error("{path}: {topic} at {stamp_ns} ns: {message}")]
    Bad {
        /// The bag.
        path: PathBuf,
        /// Its topic.
        topic: String,
        /// Its stamp.
        stamp_ns: u64,
        /// Why.
        message: String,
    },
}

/// One scene of the capture.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureScene {
    /// When it starts on the timeline, ns.
    pub start_ns: u64,
    /// Its id in the recording hierarchy.
    pub scene_id: String,
    /// The ChaCha8 stream it was drawn from (seeds the renderer's procedural detail).
    pub stream: u64,
    /// Everything drawn.
    pub scene: Scene,
}

/// One frame of the timeline.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureFrame {
    /// Its stamp, ns.
    pub stamp_ns: u64,
    /// Index into [`Capture::scenes`].
    pub scene: usize,
    /// The character's pose.
    pub pose: BonePose,
    /// The camera's optical frame in the world.
    pub world_from_optical: Isometry3<f64>,
}

/// A capture bag, read for rendering.
#[derive(Debug, Clone, PartialEq)]
pub struct Capture {
    /// The bag.
    pub path: PathBuf,
    /// Its capture session's name.
    pub session: String,
    /// Frame rate of the timeline, frames per second.
    pub fps: f64,
    /// The dataset's class labels, sorted (a segment's `label_id` indexes them), from the
    /// `autoact.dataset` record; empty if the bag has none.
    pub labels: Vec<String>,
    /// The dataset's seed, from the `autoact.dataset` record.
    pub seed: Option<u64>,
    /// The camera's lens as recorded.
    pub intrinsics: Intrinsics,
    /// Scenes in time order.
    pub scenes: Vec<CaptureScene>,
    /// Clips in time order.
    pub segments: Vec<Segment>,
    /// Every frame, in stamp order.
    pub frames: Vec<CaptureFrame>,
}

impl Capture {
    /// Reads the capture bag at `path` (an MCAP file or a rosbag2 folder).
    ///
    /// # Errors
    /// [`TimelineError`] naming the file and, for a bad message, its topic and stamp.
    pub fn read(rig: &Rig, path: &Path) -> Result<Capture, TimelineError> {
        let readers = BagReader::open_all(path).map_err(|e| TimelineError::Read {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        let bad = |topic: &str, stamp_ns: u64, message: String| TimelineError::Bad {
            path: path.to_path_buf(),
            topic: topic.to_owned(),
            stamp_ns,
            message,
        };
        let missing = |what: &str| TimelineError::Missing {
            path: path.to_path_buf(),
            what: what.to_owned(),
        };
        let mut fps = None;
        let mut labels = Vec::new();
        let mut seed = None;
        for r in &readers {
            for (name, meta) in r.metadata() {
                if !name.ends_with(".dataset") {
                    continue;
                }
                if let Some(v) = meta.get("fps").and_then(|v| v.parse::<f64>().ok()) {
                    fps = Some(v);
                }
                if let Some(v) = meta.get("seed").and_then(|v| v.parse::<u64>().ok()) {
                    seed = Some(v);
                }
                if let Some(text) = meta.get("labels") {
                    labels = serde_json::from_str::<Vec<String>>(text).map_err(|e| {
                        TimelineError::Read {
                            path: path.to_path_buf(),
                            message: format!(
                                "metadata `{name}`: `labels` is not a JSON list of strings: {e}"
                            ),
                        }
                    })?;
                }
            }
        }
        let mut scenes = Vec::new();
        let mut segments = Vec::new();
        let mut poses: BTreeMap<u64, BonePose> = BTreeMap::new();
        let mut cameras: BTreeMap<u64, Isometry3<f64>> = BTreeMap::new();
        let mut intrinsics = None;
        let mut session = String::new();
        for m in readers.iter().flat_map(|r| r.messages()) {
            let m = m.map_err(|e| TimelineError::Read {
                path: path.to_path_buf(),
                message: e.to_string(),
            })?;
            let topic = m.channel.topic.as_str();
            let schema = m.channel.schema_name();
            let stamp = m.log_time;
            let decode_error =
                |e: &dyn std::fmt::Display| bad(topic, stamp, format!("cannot decode: {e}"));
            match (topic, schema) {
                (SCENE_TOPIC, SceneState::TYPE_NAME) => {
                    let s: SceneState = cdr::decode(&m.data).map_err(|e| decode_error(&e))?;
                    let scene: Scene = serde_json::from_str(&s.parameters_json)
                        .map_err(|e| bad(topic, stamp, format!("parameters_json: {e}")))?;
                    session.clone_from(&s.session);
                    scenes.push(CaptureScene {
                        start_ns: s.header.stamp.to_nanos().unwrap_or(stamp),
                        scene_id: s.scene_id,
                        stream: s.stream,
                        scene,
                    });
                }
                (SEGMENTS_TOPIC, Segment::TYPE_NAME) => {
                    segments.push(cdr::decode::<Segment>(&m.data).map_err(|e| decode_error(&e))?);
                }
                (_, BoneFrame::TYPE_NAME) => {
                    let f: BoneFrame = cdr::decode(&m.data).map_err(|e| decode_error(&e))?;
                    let pose =
                        animation_bag::bone_pose(rig, &f).map_err(|e| bad(topic, stamp, e))?;
                    let at = animation_bag::frame_stamp(&f, stamp);
                    if poses.insert(at, pose).is_some() {
                        return Err(bad(topic, at, "two animation frames at one stamp (several tracks or variants: a capture bag has one)".into()));
                    }
                }
                (CAMERA_POSE_TOPIC, PoseStamped::TYPE_NAME) => {
                    let p: PoseStamped = cdr::decode(&m.data).map_err(|e| decode_error(&e))?;
                    let q = UnitQuaternion::try_from(p.pose.orientation)
                        .map_err(|e| bad(topic, stamp, e.to_string()))?;
                    let o = p.pose.position;
                    if ![o.x, o.y, o.z].iter().all(|v| v.is_finite()) {
                        return Err(bad(topic, stamp, "camera position is not finite".into()));
                    }
                    let at = p.header.stamp.to_nanos().unwrap_or(stamp);
                    cameras.insert(
                        at,
                        Isometry3::from_parts(Translation3::new(o.x, o.y, o.z), q),
                    );
                }
                (CAMERA_INFO_TOPIC, CameraInfo::TYPE_NAME) if intrinsics.is_none() => {
                    let c: CameraInfo = cdr::decode(&m.data).map_err(|e| decode_error(&e))?;
                    intrinsics = Some(Intrinsics::from_ros(c.width, c.height, &c.k).ok_or_else(
                        || bad(topic, stamp, format!("unusable camera matrix {:?}", c.k)),
                    )?);
                }
                _ => {}
            }
        }
        if poses.is_empty() {
            return Err(missing("animation (autoact_msgs/BoneFrame on /animation)"));
        }
        if cameras.is_empty() {
            return Err(missing(&format!("camera path ({CAMERA_POSE_TOPIC})")));
        }
        let intrinsics = intrinsics
            .ok_or_else(|| missing(&format!("camera calibration ({CAMERA_INFO_TOPIC})")))?;
        if scenes.is_empty() {
            return Err(missing(&format!("scene ({SCENE_TOPIC})")));
        }
        scenes.sort_by_key(|s| s.start_ns);
        segments.sort_by_key(|s| s.start.to_nanos().unwrap_or(0));
        // Without the dataset record, the median spacing of the frames.
        let stamps: Vec<u64> = poses.keys().copied().collect();
        let fps = crate::pose::frame_rate(fps.filter(|f| f.is_finite() && *f > 0.0), &stamps)
            .ok_or_else(|| {
                missing("frame rate (the autoact.dataset record's fps, or two frames)")
            })?;
        let mut frames = Vec::with_capacity(poses.len());
        for (stamp_ns, pose) in poses {
            let world_from_optical = *cameras.get(&stamp_ns).ok_or_else(|| {
                bad(
                    CAMERA_POSE_TOPIC,
                    stamp_ns,
                    "no camera pose at this animation frame's stamp".into(),
                )
            })?;
            let scene = scenes.partition_point(|s| s.start_ns <= stamp_ns);
            if scene == 0 {
                return Err(bad(
                    SCENE_TOPIC,
                    stamp_ns,
                    "an animation frame comes before the first scene starts".into(),
                ));
            }
            frames.push(CaptureFrame {
                stamp_ns,
                scene: scene - 1,
                pose,
                world_from_optical,
            });
        }
        Ok(Capture {
            path: path.to_path_buf(),
            session,
            fps,
            labels,
            seed,
            intrinsics,
            scenes,
            segments,
            frames,
        })
    }

    /// Indices of the frames where a clip starts or ends (the keyframes cuts need), sorted,
    /// without duplicates, within the timeline.
    #[must_use]
    pub fn boundary_frames(&self) -> Vec<u64> {
        let mut out: Vec<u64> = self
            .segments
            .iter()
            .flat_map(|s| [s.start, s.end])
            .filter_map(|t| t.to_nanos())
            .filter_map(|t| self.frames.binary_search_by_key(&t, |f| f.stamp_ns).ok())
            .map(|i| i as u64)
            .collect();
        out.push(0);
        out.sort_unstable();
        out.dedup();
        out
    }
}
