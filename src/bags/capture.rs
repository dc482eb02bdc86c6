//! Capture bags (`<session>.capture.mcap`): what `autoact convert --spec` writes — one MCAP per
//! capture session, on one continuous timeline at the output rate, everything a renderer and the
//! trimmer need:
//!
//! - `/animation`, `/tf`, `/tf_static`, `/skeleton/markers`: the character, as
//!   [`crate::bags::animation`] writes them; at each scene start `/tf_static` carries that scene's
//!   character (its drawn body), in tf frames of its own (`scene<i>/pelvis`, see
//!   [`crate::bags::animation::scene_frame_prefix`]) so that no viewer blends two bodies;
//! - `/camera/pose` (`geometry_msgs/PoseStamped`, the optical frame's pose in `world`), a
//!   `world → camera` transform on `/tf` (`camera` is the ROS optical frame: z forward, x right,
//!   y down) and `/camera/camera_info` (`sensor_msgs/CameraInfo`, frame `camera`), every frame;
//! - `/scene` (`autoact_msgs/SceneState`) at each scene's start: every drawn parameter and the
//!   seed and stream it came from;
//! - `/segments` (`autoact_msgs/Segment`) at each clip's start: the full hierarchy path, the
//!   label and its id, and the clip's and the animation's times.
//!
//! The metadata record `autoact.dataset` names the spec, seed, rate, resolution and labels, and
//! holds the spec's `[randomise]` ([`RANDOMISE_KEY`]).
//!
//! [`CaptureWriter`] writes one; [`Capture::read`] reads it back into what the renderer draws
//! and the trimmer cuts: its scenes, its clips, and per timeline frame the character's pose and
//! the camera. Frame `k` of the rendered video is the `k`-th `/animation` frame of the bag, in
//! stamp order; the camera must have a pose at every one of those stamps.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Translation3, UnitQuaternion};

use crate::atomic_file::Part;
use crate::bags;
use crate::bags::animation::{
    ANIMATION_TOPIC, BonePoseError, TF_STATIC_TOPIC, TF_TOPIC, TrackWriter,
};
use crate::camera::Intrinsics;
use crate::camera::{CAMERA_FRAME, CameraPose, DISTORTION_MODEL};
use crate::mcap_io::{BagMessage, BagReader, ReadIssue};
use crate::mcap_io::{BagWriter, FileSink, McapIoError, WriteConfig};
use crate::ros::autoact_msgs::{BoneFrame, SceneState, Segment};
use crate::ros::builtin_interfaces::Time;
use crate::ros::cdr::CdrError;
use crate::ros::geometry_msgs::{BadQuaternion, PoseStamped};
use crate::ros::geometry_msgs::{Pose, Quaternion, Transform, TransformStamped, Vector3};
use crate::ros::sensor_msgs::CameraInfo;
use crate::ros::std_msgs::Header;
use crate::ros::tf2_msgs::TFMessage;
use crate::ros::{RosMessage, cdr};
use crate::scene::Scene;
use crate::skeleton::fk::BonePose;
use crate::skeleton::frames::WORLD_FRAME;
use crate::skeleton::rig::Rig;

mod stamps;

pub use stamps::{Stamps, StampsBuilder};

/// Suffix of a capture bag's file name.
pub const SUFFIX: &str = ".capture.mcap";
/// Topic of the camera's pose.
pub const CAMERA_POSE_TOPIC: &str = "/camera/pose";
/// Topic of the camera's calibration.
pub const CAMERA_INFO_TOPIC: &str = "/camera/camera_info";
/// Topic of the scene states.
pub const SCENE_TOPIC: &str = "/scene";
/// Topic of the clip segments.
pub const SEGMENTS_TOPIC: &str = "/segments";
/// The key of the `autoact.dataset` record that holds the spec's `[randomise]` (JSON).
pub const RANDOMISE_KEY: &str = "randomise";

/// Name of the metadata record that describes the dataset.
pub const METADATA_NAME: &str = "autoact.dataset";

/// The capture bag of session `session` in folder `dir`.
#[must_use]
pub fn session_path(dir: &Path, session: &str) -> PathBuf {
    dir.join(format!("{session}{SUFFIX}"))
}

/// Writes one capture bag: its metadata, then scenes, segments and frames in timeline order.
pub struct CaptureWriter {
    bag: BagWriter<FileSink>,
    camera: CameraTrack,
    /// The bag is written under its temporary sibling and renamed into place when finished.
    part: Part,
}

impl CaptureWriter {
    /// Creates the bag at `path` with the `autoact.dataset` record `metadata`; the camera's
    /// calibration is `intrinsics` throughout. With `journal`, every message is also kept for
    /// [`CaptureWriter::finish`] to write as `<path stem>.expected.json` (for `tools/interop`).
    ///
    /// # Errors
    /// [`McapIoError`] naming the file.
    pub fn create(
        path: &Path,
        config: WriteConfig,
        journal: bool,
        metadata: BTreeMap<String, String>,
        intrinsics: &Intrinsics,
    ) -> Result<CaptureWriter, McapIoError> {
        let part = Part::new(path).ok_or_else(|| McapIoError::Io {
            action: "cannot create",
            path: path.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name"),
        })?;
        let mut bag = BagWriter::create_as(part.temporary(), path, config)?;
        if journal {
            bag.keep_journal();
        }
        bag.write_metadata(METADATA_NAME, metadata)?;
        Ok(CaptureWriter {
            bag,
            camera: CameraTrack::new(intrinsics),
            part,
        })
    }

    /// Starts a scene at `stamp`: its state on `/scene`, its character's rest on `/tf_static`.
    ///
    /// # Errors
    /// [`McapIoError`] naming the file.
    pub fn write_scene(
        &mut self,
        stamp: u64,
        state: &SceneState,
        character: &TrackWriter,
    ) -> Result<(), McapIoError> {
        self.bag.write(SCENE_TOPIC, stamp, state)?;
        self.bag.write(
            TF_STATIC_TOPIC,
            stamp,
            &TFMessage {
                transforms: character.static_transforms(stamp),
            },
        )
    }

    /// Starts a clip: its segment on `/segments`, at the segment's start.
    ///
    /// # Errors
    /// [`McapIoError`] naming the file.
    pub fn write_segment(&mut self, stamp: u64, segment: &Segment) -> Result<(), McapIoError> {
        self.bag.write(SEGMENTS_TOPIC, stamp, segment)
    }

    /// One timeline frame: the camera's three messages, then the character's.
    ///
    /// # Errors
    /// [`McapIoError`] naming the file.
    pub fn write_frame(
        &mut self,
        stamp: u64,
        camera: &CameraPose,
        character: &mut TrackWriter,
        pose: &BonePose,
    ) -> Result<(), McapIoError> {
        self.camera.write(&mut self.bag, stamp, camera)?;
        character.write_frame(&mut self.bag, stamp, pose)
    }

    /// Finishes the bag (summary, index) and, if asked at creation, writes its journal beside it.
    ///
    /// # Errors
    /// [`McapIoError`] naming the file.
    pub fn finish(self, path: &Path, journal: bool) -> Result<(), McapIoError> {
        if journal {
            self.bag
                .finish_with_journal(&path.with_extension("expected.json"))?;
        } else {
            self.bag.finish()?;
        }
        self.part.commit().map_err(|source| McapIoError::Io {
            action: "cannot sync and rename into place",
            path: path.to_path_buf(),
            source,
        })
    }
}

impl std::fmt::Debug for CaptureWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CaptureWriter")
            .field("bag", &self.bag)
            .finish_non_exhaustive()
    }
}

/// The camera's three messages per frame, kept and updated in place (no allocation per frame):
/// its pose in `world`, the `world → camera` transform, and its calibration.
struct CameraTrack {
    pose: PoseStamped,
    tf: TFMessage,
    info: CameraInfo,
}

impl CameraTrack {
    fn new(intrinsics: &Intrinsics) -> CameraTrack {
        let world = Header {
            stamp: Time::default(),
            frame_id: WORLD_FRAME.to_string(),
        };
        CameraTrack {
            pose: PoseStamped {
                header: world.clone(),
                pose: Pose::default(),
            },
            tf: TFMessage {
                transforms: vec![TransformStamped {
                    header: world,
                    child_frame_id: CAMERA_FRAME.to_string(),
                    transform: Transform::default(),
                }],
            },
            info: CameraInfo {
                header: Header {
                    stamp: Time::default(),
                    frame_id: CAMERA_FRAME.to_string(),
                },
                height: intrinsics.height_px,
                width: intrinsics.width_px,
                distortion_model: DISTORTION_MODEL.to_string(),
                d: intrinsics.d().to_vec(),
                k: intrinsics.k(),
                r: intrinsics.r(),
                p: intrinsics.p(),
                ..CameraInfo::default()
            },
        }
    }

    /// Writes `/camera/pose`, the camera's `/tf` and `/camera/camera_info` at `stamp`.
    fn write<W: std::io::Write + std::io::Seek>(
        &mut self,
        w: &mut BagWriter<W>,
        stamp: u64,
        camera: &CameraPose,
    ) -> Result<(), McapIoError> {
        let time = Time::from_nanos(stamp);
        let rotation = Quaternion::from(camera.world_from_optical);
        self.pose.header.stamp = time;
        self.pose.pose.position = crate::ros::geometry_msgs::Point::from(camera.position_m);
        self.pose.pose.orientation = rotation;
        let t = &mut self.tf.transforms[0];
        t.header.stamp = time;
        t.transform.translation = Vector3::from(camera.position_m.coords);
        t.transform.rotation = rotation;
        self.info.header.stamp = time;
        w.write(CAMERA_POSE_TOPIC, stamp, &self.pose)?;
        w.write(TF_TOPIC, stamp, &self.tf)?;
        w.write(CAMERA_INFO_TOPIC, stamp, &self.info)
    }
}

/// Why a bag cannot be rendered.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TimelineError {
    /// The file could not be opened.
    #[error("{path}: {source}")]
    Open {
        /// The bag.
        path: PathBuf,
        /// Why.
        #[source]
        source: McapIoError,
    },
    /// The file could not be read to its end.
    #[error("{path}: {source}")]
    Read {
        /// The bag.
        path: PathBuf,
        /// What was lost.
        #[source]
        source: ReadIssue,
    },
    /// The dataset record's `labels` is not a JSON list of strings.
    #[error("{path}: metadata `{name}`: `labels` is not a JSON list of strings: {source}")]
    Labels {
        /// The bag.
        path: PathBuf,
        /// The metadata record.
        name: String,
        /// Why.
        #[source]
        source: serde_json::Error,
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
    #[error("{path}: {topic} at {stamp_nanos} ns: {message}")]
    Bad {
        /// The bag.
        path: PathBuf,
        /// Its topic.
        topic: String,
        /// Its stamp.
        stamp_nanos: u64,
        /// Why.
        message: String,
    },
    /// A message that cannot be decoded.
    #[error("{path}: {topic} at {stamp_nanos} ns: cannot decode: {source}")]
    Decode {
        /// The bag.
        path: PathBuf,
        /// Its topic.
        topic: String,
        /// Its stamp.
        stamp_nanos: u64,
        /// Why.
        #[source]
        source: CdrError,
    },
    /// A scene state whose `parameters_json` is not a scene.
    #[error("{path}: {topic} at {stamp_nanos} ns: parameters_json: {source}")]
    SceneParameters {
        /// The bag.
        path: PathBuf,
        /// Its topic.
        topic: String,
        /// Its stamp.
        stamp_nanos: u64,
        /// Why.
        #[source]
        source: serde_json::Error,
    },
    /// An animation frame that does not fit the rig.
    #[error("{path}: {topic} at {stamp_nanos} ns: {source}")]
    Pose {
        /// The bag.
        path: PathBuf,
        /// Its topic.
        topic: String,
        /// Its stamp.
        stamp_nanos: u64,
        /// Why.
        #[source]
        source: Box<BonePoseError>,
    },
    /// A camera pose whose orientation is not a rotation.
    #[error("{path}: {topic} at {stamp_nanos} ns: {source}")]
    Orientation {
        /// The bag.
        path: PathBuf,
        /// Its topic.
        topic: String,
        /// Its stamp.
        stamp_nanos: u64,
        /// Why.
        #[source]
        source: BadQuaternion,
    },
}

/// Where a scene of a capture bag starts, as its `/scene` message says.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneStart {
    /// The scene's start on the timeline (the message's header stamp), ns.
    pub start_nanos: u64,
    /// Its id in the recording hierarchy.
    pub scene_id: String,
}

/// The scenes of a capture bag in time order, from its `/scene` messages alone (no camera or
/// animation is read); empty for a bag without `/scene` (a plain animation bag). Messages that
/// cannot be read are skipped: [`Capture::read`] and `autoact info` report them.
#[must_use]
pub fn scene_starts(readers: &[BagReader]) -> Vec<SceneStart> {
    let mut out: Vec<SceneStart> = readers
        .iter()
        .flat_map(BagReader::messages)
        .filter_map(Result::ok)
        .filter(|m| {
            m.channel.topic == SCENE_TOPIC && m.channel.schema_name() == SceneState::TYPE_NAME
        })
        .filter_map(|m| {
            let s: SceneState = cdr::decode(&m.data).ok()?;
            Some(SceneStart {
                start_nanos: s.header.stamp.to_nanos().unwrap_or(m.log_time),
                scene_id: s.scene_id,
            })
        })
        .collect();
    out.sort_by_key(|s| s.start_nanos);
    out
}

/// One scene of the capture.
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureScene {
    /// When it starts on the timeline, ns.
    pub start_nanos: u64,
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
    pub stamp_nanos: u64,
    /// Index into [`Capture::scenes`].
    pub scene: usize,
    /// The character's pose.
    pub pose: BonePose,
    /// The camera's optical frame in the world.
    pub world_from_optical: Isometry3<f64>,
}

/// A capture bag, read for rendering: what is said once (scenes, clips, the lens) and the
/// timeline's stamps as runs ([`Stamps`]); the frames themselves (pose, camera) are read from
/// the bag a stretch at a time ([`Capture::frames`]), so memory does not grow with the session.
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
    /// The spec's `[randomise]` as JSON, from the `autoact.dataset` record's
    /// [`RANDOMISE_KEY`] (read by `crate::dataset::randomise::Randomise::recorded`); `None` for
    /// bags written before it was recorded.
    pub randomise: Option<String>,
    /// The camera's lens as recorded.
    pub intrinsics: Intrinsics,
    /// Scenes in time order.
    pub scenes: Vec<CaptureScene>,
    /// Clips in time order.
    pub segments: Vec<Segment>,
    /// Every frame's stamp (the `/animation` frames'), in order.
    pub stamps: Stamps,
    /// Where the frames' messages are in log time, when not at their stamps (a bag recorded
    /// live); `None` when every one is logged at its stamp (autoact's own). Either way a
    /// stretch of frames is read by log time ([`BagReader::messages_where`]).
    log_times: Option<LogTimes>,
}

impl Capture {
    /// Reads the capture bag at `path` (an MCAP file or a rosbag2 folder) in one pass: every
    /// message is checked (the frames [`Capture::frames`] reads later were all read once), and
    /// what is kept does not grow with the frames.
    ///
    /// # Errors
    /// [`TimelineError`] naming the file and, for a bad message, its topic and stamp.
    pub fn read(rig: &Rig, path: &Path) -> Result<Capture, TimelineError> {
        let readers = BagReader::open_all(path).map_err(|source| TimelineError::Open {
            path: path.to_path_buf(),
            source,
        })?;
        let record = DatasetRecord::read(&readers, path)?;
        let fps = record.fps.filter(|f| f.is_finite() && *f > 0.0);
        let mut found = Found::new(fps);
        for m in readers.iter().flat_map(|r| r.messages()) {
            let m = m.map_err(|source| TimelineError::Read {
                path: path.to_path_buf(),
                source,
            })?;
            found.take(rig, &m, path)?;
        }
        drop(readers);
        found.finish(path, fps, record)
    }

    /// How many frames the timeline has.
    #[must_use]
    pub fn frame_count(&self) -> usize {
        self.stamps.len()
    }

    /// The scene that stamp `t` falls in (the last to start at or before it; the first for a
    /// stamp before every scene).
    #[must_use]
    pub fn scene_at(&self, t: u64) -> usize {
        self.scenes
            .partition_point(|s| s.start_nanos <= t)
            .saturating_sub(1)
    }

    /// Frames `range` of the timeline (clamped to it), read from the bag: only the chunks that
    /// hold them when the bag has a summary.
    ///
    /// # Errors
    /// [`TimelineError`] when the bag cannot be read again as it was by [`Capture::read`].
    pub fn frames(
        &self,
        rig: &Rig,
        range: std::ops::Range<usize>,
    ) -> Result<Vec<CaptureFrame>, TimelineError> {
        let range = range.start..range.end.min(self.frame_count());
        let (Some(first), Some(last)) = (
            self.stamps.get(range.start),
            range.end.checked_sub(1).and_then(|k| self.stamps.get(k)),
        ) else {
            return Ok(Vec::new());
        };
        let path = &self.path;
        let readers = BagReader::open_all(path).map_err(|source| TimelineError::Open {
            path: path.clone(),
            source,
        })?;
        let mut poses: BTreeMap<u64, BonePose> = BTreeMap::new();
        let mut cameras: BTreeMap<u64, Isometry3<f64>> = BTreeMap::new();
        // No window: no frame message is stamped there, and every frame below is missing.
        let window = self
            .log_times
            .as_ref()
            .map_or(Some(first..=last), |l| l.window(first..=last));
        for (reader, window) in readers
            .iter()
            .filter_map(|r| window.clone().map(|w| (r, w)))
        {
            for m in reader.messages_where(window) {
                let m = m.map_err(|source| TimelineError::Read {
                    path: path.clone(),
                    source,
                })?;
                match frame_message(rig, &m, path)? {
                    Some(FrameMessage::Pose(t, pose)) if (first..=last).contains(&t) => {
                        poses.insert(t, pose);
                    }
                    Some(FrameMessage::Camera(t, camera)) if (first..=last).contains(&t) => {
                        cameras.insert(t, camera);
                    }
                    _ => {}
                }
            }
        }
        range
            .map(|k| {
                let stamp_nanos = self.stamps.get(k).unwrap_or(last);
                let changed = || TimelineError::Bad {
                    path: path.clone(),
                    topic: ANIMATION_TOPIC.to_owned(),
                    stamp_nanos,
                    message: "frame not found when read again: the bag changed while in use".into(),
                };
                Ok(CaptureFrame {
                    stamp_nanos,
                    scene: self.scene_at(stamp_nanos),
                    pose: poses.remove(&stamp_nanos).ok_or_else(changed)?,
                    world_from_optical: *cameras.get(&stamp_nanos).ok_or_else(changed)?,
                })
            })
            .collect()
    }

    /// The timeline frames `picks` (indices, any order, repeats allowed), in that order: read
    /// as one stretch from the first to the last of them.
    ///
    /// # Errors
    /// As [`Capture::frames`]; a pick beyond the timeline is a frame not found.
    pub fn frames_at(
        &self,
        rig: &Rig,
        picks: &[usize],
    ) -> Result<Vec<CaptureFrame>, TimelineError> {
        let (Some(&first), Some(&last)) = (picks.iter().min(), picks.iter().max()) else {
            return Ok(Vec::new());
        };
        let read = self.frames(rig, first..last + 1)?;
        picks
            .iter()
            .map(|&k| {
                read.get(k - first)
                    .cloned()
                    .ok_or_else(|| TimelineError::Bad {
                        path: self.path.clone(),
                        topic: ANIMATION_TOPIC.to_owned(),
                        stamp_nanos: self.stamps.last().unwrap_or(0),
                        message: format!(
                            "frame {k} is beyond the timeline's {}",
                            self.frame_count()
                        ),
                    })
            })
            .collect()
    }

    /// Indices of the frames where a segment or its animation starts or ends (the keyframes
    /// cuts need: `trim`'s clips start on one or the other unless their policy cuts windows or
    /// instances), sorted, without duplicates, within the timeline.
    #[must_use]
    pub fn boundary_frames(&self) -> Vec<u64> {
        let mut out: Vec<u64> = self
            .segments
            .iter()
            .flat_map(|s| [s.start, s.content_start, s.content_end, s.end])
            .filter_map(crate::ros::builtin_interfaces::Time::to_nanos)
            .filter_map(|t| self.stamps.position(t))
            .map(|i| i as u64)
            .collect();
        out.push(0);
        out.sort_unstable();
        out.dedup();
        out
    }
}

/// Stamps are grouped in stretches of this long for [`LogTimes`]: a stretch of frames is read
/// from at most one such stretch of log time more than its own.
const LOG_TIME_BUCKET_NANOS: u64 = 4_000_000_000;

/// Where a capture's frame messages sit in log time: for each [`LOG_TIME_BUCKET_NANOS`] of
/// stamps, the earliest and the latest log time of a pose or camera message stamped in it. A
/// bag recorded live logs each frame when it arrived, in any relation to its stamp; with this,
/// a stretch of its frames is still read from the chunks that hold them, not by a pass over the
/// whole bag per stretch. It keeps 16 bytes per 4 s of the session.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
struct LogTimes {
    /// Bucket (stamp / [`LOG_TIME_BUCKET_NANOS`]) → (earliest, latest) log time.
    buckets: BTreeMap<u64, (u64, u64)>,
}

impl LogTimes {
    fn push(&mut self, stamp: u64, log_time: u64) {
        let e = self
            .buckets
            .entry(stamp / LOG_TIME_BUCKET_NANOS)
            .or_insert((log_time, log_time));
        *e = (e.0.min(log_time), e.1.max(log_time));
    }

    /// The log times within which every frame message stamped in `stamps` is (`None`: none is).
    fn window(
        &self,
        stamps: std::ops::RangeInclusive<u64>,
    ) -> Option<std::ops::RangeInclusive<u64>> {
        let buckets = stamps.start() / LOG_TIME_BUCKET_NANOS..=stamps.end() / LOG_TIME_BUCKET_NANOS;
        self.buckets
            .range(buckets)
            .map(|(_, &bounds)| bounds)
            .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
            .map(|(lo, hi)| lo..=hi)
    }
}

/// What the `autoact.dataset` metadata record says (the last record's values win).
#[derive(Debug, Default)]
struct DatasetRecord {
    fps: Option<f64>,
    labels: Vec<String>,
    seed: Option<u64>,
    randomise: Option<String>,
}

impl DatasetRecord {
    fn read(readers: &[BagReader], path: &Path) -> Result<DatasetRecord, TimelineError> {
        let mut record = DatasetRecord::default();
        for r in readers {
            for (name, meta) in r.metadata() {
                if name != METADATA_NAME {
                    continue;
                }
                if let Some(v) = meta.get("fps").and_then(|v| v.parse::<f64>().ok()) {
                    record.fps = Some(v);
                }
                if let Some(v) = meta.get("seed").and_then(|v| v.parse::<u64>().ok()) {
                    record.seed = Some(v);
                }
                if let Some(v) = meta.get(RANDOMISE_KEY) {
                    record.randomise = Some(v.clone());
                }
                if let Some(text) = meta.get("labels") {
                    record.labels =
                        serde_json::from_str::<Vec<String>>(text).map_err(|source| {
                            TimelineError::Labels {
                                path: path.to_path_buf(),
                                name: name.clone(),
                                source,
                            }
                        })?;
                }
            }
        }
        Ok(record)
    }
}

/// A frame's message of a capture bag, decoded and checked.
enum FrameMessage {
    /// An animation frame at its stamp.
    Pose(u64, BonePose),
    /// A camera pose at its stamp.
    Camera(u64, Isometry3<f64>),
}

/// The error of message `m` (of the bag at `path`) that does not decode (nothing is copied
/// unless it is called: it is made for every message read).
fn decode_error<'a>(
    path: &'a Path,
    m: &'a BagMessage,
) -> impl FnOnce(CdrError) -> TimelineError + 'a {
    move |source| TimelineError::Decode {
        path: path.to_path_buf(),
        topic: m.channel.topic.clone(),
        stamp_nanos: m.log_time,
        source,
    }
}

/// Decodes `m` when it is an animation frame or a camera pose (`None` for other topics).
fn frame_message(
    rig: &Rig,
    m: &BagMessage,
    path: &Path,
) -> Result<Option<FrameMessage>, TimelineError> {
    let topic = m.channel.topic.as_str();
    let stamp = m.log_time;
    let decode_error = decode_error(path, m);
    match (topic, m.channel.schema_name()) {
        (_, BoneFrame::TYPE_NAME) => {
            let f: BoneFrame = cdr::decode(&m.data).map_err(decode_error)?;
            let pose =
                bags::animation::bone_pose(rig, &f).map_err(|source| TimelineError::Pose {
                    path: path.to_path_buf(),
                    topic: topic.to_owned(),
                    stamp_nanos: stamp,
                    source: Box::new(source),
                })?;
            Ok(Some(FrameMessage::Pose(
                bags::animation::frame_stamp(&f, stamp),
                pose,
            )))
        }
        (CAMERA_POSE_TOPIC, PoseStamped::TYPE_NAME) => {
            let p: PoseStamped = cdr::decode(&m.data).map_err(decode_error)?;
            let q = UnitQuaternion::try_from(p.pose.orientation).map_err(|source| {
                TimelineError::Orientation {
                    path: path.to_path_buf(),
                    topic: topic.to_owned(),
                    stamp_nanos: stamp,
                    source,
                }
            })?;
            let o = p.pose.position;
            if ![o.x, o.y, o.z].iter().all(|v| v.is_finite()) {
                return Err(TimelineError::Bad {
                    path: path.to_path_buf(),
                    topic: topic.to_owned(),
                    stamp_nanos: stamp,
                    message: "camera position is not finite".into(),
                });
            }
            Ok(Some(FrameMessage::Camera(
                p.header.stamp.to_nanos().unwrap_or(stamp),
                Isometry3::from_parts(Translation3::new(o.x, o.y, o.z), q),
            )))
        }
        _ => Ok(None),
    }
}

/// What the messages of a capture bag carry, as read: scenes and segments (unsorted), the stamps
/// of the animation frames and of the camera poses, the first calibration.
#[derive(Debug)]
struct Found {
    scenes: Vec<CaptureScene>,
    segments: Vec<Segment>,
    poses: StampsBuilder,
    cameras: StampsBuilder,
    logged_at_stamps: bool,
    log_times: LogTimes,
    intrinsics: Option<Intrinsics>,
    session: String,
}

impl Found {
    /// Ready to read a bag whose frames are `fps` apart, if it says.
    fn new(fps: Option<f64>) -> Found {
        let clock = fps.unwrap_or(30.0);
        Found {
            scenes: Vec::new(),
            segments: Vec::new(),
            poses: StampsBuilder::new(clock),
            cameras: StampsBuilder::new(clock),
            logged_at_stamps: true,
            log_times: LogTimes::default(),
            intrinsics: None,
            session: String::new(),
        }
    }

    /// Takes in one message: a scene, a segment, an animation frame, a camera pose or the first
    /// camera calibration; other topics are ignored.
    fn take(&mut self, rig: &Rig, m: &BagMessage, path: &Path) -> Result<(), TimelineError> {
        let topic = m.channel.topic.as_str();
        let stamp = m.log_time;
        let decode_error = decode_error(path, m);
        match frame_message(rig, m, path)? {
            Some(FrameMessage::Pose(at, _)) => {
                self.logged_at_stamps &= at == stamp;
                self.log_times.push(at, stamp);
                self.poses.push(at);
                return Ok(());
            }
            Some(FrameMessage::Camera(at, _)) => {
                self.logged_at_stamps &= at == stamp;
                self.log_times.push(at, stamp);
                self.cameras.push(at);
                return Ok(());
            }
            None => {}
        }
        match (topic, m.channel.schema_name()) {
            (SCENE_TOPIC, SceneState::TYPE_NAME) => {
                let s: SceneState = cdr::decode(&m.data).map_err(decode_error)?;
                let scene: Scene = serde_json::from_str(&s.parameters_json).map_err(|source| {
                    TimelineError::SceneParameters {
                        path: path.to_path_buf(),
                        topic: topic.to_owned(),
                        stamp_nanos: stamp,
                        source,
                    }
                })?;
                self.session.clone_from(&s.session);
                self.scenes.push(CaptureScene {
                    start_nanos: s.header.stamp.to_nanos().unwrap_or(stamp),
                    scene_id: s.scene_id,
                    stream: s.stream,
                    scene,
                });
            }
            (SEGMENTS_TOPIC, Segment::TYPE_NAME) => {
                self.segments
                    .push(cdr::decode::<Segment>(&m.data).map_err(decode_error)?);
            }
            (CAMERA_INFO_TOPIC, CameraInfo::TYPE_NAME) if self.intrinsics.is_none() => {
                let c: CameraInfo = cdr::decode(&m.data).map_err(decode_error)?;
                self.intrinsics = Some(Intrinsics::from_ros(c.width, c.height, &c.k).ok_or_else(
                    || TimelineError::Bad {
                        path: path.to_path_buf(),
                        topic: topic.to_owned(),
                        stamp_nanos: stamp,
                        message: format!("unusable camera matrix {:?}", c.k),
                    },
                )?);
            }
            _ => {}
        }
        Ok(())
    }

    /// The capture: what was found, checked (every frame has its camera pose and a scene).
    fn finish(
        self,
        path: &Path,
        fps: Option<f64>,
        record: DatasetRecord,
    ) -> Result<Capture, TimelineError> {
        let missing = |what: &str| TimelineError::Missing {
            path: path.to_path_buf(),
            what: what.to_owned(),
        };
        let bad = |topic: &str, stamp_nanos: u64, message: &str| TimelineError::Bad {
            path: path.to_path_buf(),
            topic: topic.to_owned(),
            stamp_nanos,
            message: message.to_owned(),
        };
        let (stamps, twice) = self.poses.finish();
        if let Some(t) = twice {
            return Err(bad(
                ANIMATION_TOPIC,
                t,
                "two animation frames at one stamp (several tracks or variants: a capture bag has one)",
            ));
        }
        let (cameras, _) = self.cameras.finish();
        if stamps.is_empty() {
            return Err(missing("animation (autoact_msgs/BoneFrame on /animation)"));
        }
        if cameras.is_empty() {
            return Err(missing(&format!("camera path ({CAMERA_POSE_TOPIC})")));
        }
        let intrinsics = self
            .intrinsics
            .ok_or_else(|| missing(&format!("camera calibration ({CAMERA_INFO_TOPIC})")))?;
        let mut scenes = self.scenes;
        if scenes.is_empty() {
            return Err(missing(&format!("scene ({SCENE_TOPIC})")));
        }
        scenes.sort_by_key(|s| s.start_nanos);
        let mut segments = self.segments;
        segments.sort_by_key(|s| s.start.to_nanos().unwrap_or(0));
        // Without the dataset record, the median spacing of the frames.
        let fps = fps
            .or_else(|| crate::skeleton::pose::frame_rate(None, &stamps.iter().collect::<Vec<_>>()))
            .ok_or_else(|| {
                missing("frame rate (the autoact.dataset record's fps, or two frames)")
            })?;
        let first_scene = scenes[0].start_nanos;
        for t in stamps.iter() {
            if cameras.position(t).is_none() {
                return Err(bad(
                    CAMERA_POSE_TOPIC,
                    t,
                    "no camera pose at this animation frame's stamp",
                ));
            }
            if t < first_scene {
                return Err(bad(
                    SCENE_TOPIC,
                    t,
                    "an animation frame comes before the first scene starts",
                ));
            }
        }
        Ok(Capture {
            path: path.to_path_buf(),
            session: self.session,
            fps,
            labels: record.labels,
            seed: record.seed,
            randomise: record.randomise,
            intrinsics,
            scenes,
            segments,
            stamps,
            log_times: (!self.logged_at_stamps).then_some(self.log_times),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::{LOG_TIME_BUCKET_NANOS, LogTimes};

    #[test]
    fn a_stretch_of_stamps_is_read_from_the_log_times_of_its_buckets_only() {
        // 30 fps for 60 s, each frame logged an hour and 0-90 ms after its stamp.
        let hour = 3_600_000_000_000u64;
        let mut l = LogTimes::default();
        let frame = |k: u64| k * 1_000_000_000 / 30;
        let logged = |k: u64| hour + frame(k) + (k * 13 % 10) * 10_000_000;
        for k in 0..1800 {
            l.push(frame(k), logged(k));
        }
        for (first, last) in [(0, 0), (100, 611), (1700, 1799), (0, 1799)] {
            let w = l.window(frame(first)..=frame(last)).unwrap();
            assert!(
                (first..=last).all(|k| w.contains(&logged(k))),
                "{first}..={last}: {w:?}"
            );
            // No more than one bucket of stamps (and the lateness) on either side.
            let slack = LOG_TIME_BUCKET_NANOS + 100_000_000;
            assert!(*w.start() + slack >= logged(first), "{first}: {w:?}");
            assert!(*w.end() <= logged(last) + slack, "{last}: {w:?}");
        }
        assert_eq!(l.window(hour..=hour + 1), None, "no frame stamped there");
    }
}
