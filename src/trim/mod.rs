//! Trimming a rendered capture into a clip dataset: clips cut from each leaf segment of the
//! recording hierarchy by the clip policy ([`crate::dataset::clips`]), frame-exact, each with its
//! action span, with the annotation lists action-recognition codebases read.
//!
//! - [`plan`]: segments (timeline stamps) → video frame ranges, given when video frame 0 is on
//!   the timeline; segments the video does not fully cover are reported, never cut.
//! - [`policy`]: a segment's frames → its clips (the animation, windows, or action instances
//!   found by [`motion`], the body-frame joint speeds).
//! - [`split`]: train/val/test by a hierarchy level (default: source animation), seeded,
//!   stratified by class, with whole weathers, locations or characters held out on request;
//!   decided over every clip of the dataset's plan ([`planned`]) when there is one.
//! - [`manifest`]: the journal of complete clips (`manifest.jsonl`); re-runs skip what it
//!   lists, and every list is written from it, so no list names a clip that is not on disk.
//! - [`passes`]: the render's depth and mask frames, linked per clip.
//! - [`qa`]: per-clip quality measurements from the render bag's annotations, and the report.
//! - [`labels`]: per-clip pose and box labels from the render bag's landmarks (a sidecar per
//!   clip), and the dataset's skeleton `.pkl` files (COCO-17 2-D, NTU-25 3-D, written by
//!   [`pickle`]) and COCO keypoint JSON per split.
//! - [`lists`]: `classes.txt`, `label_map.json`, Kinetics CSV, MMAction2 `VideoDataset` and
//!   `RawframeDataset` lists, ActivityNet JSON and the per-clip metadata JSONL.
//!
//! The cut itself is [`crate::video::cut`].
//!
//! # Layout
//! ```text
//! DATASET_DIR/
//!   manifest.jsonl                      journal: one line per complete clip
//!   videos/<label>/<clip_id>.mp4        every clip, whatever its split
//!   labels/<label>/<clip_id>.json       per-clip pose and box labels ([`labels`])
//!   rawframes/<label>/<clip_id>/img_00001.jpg …   with --rawframes
//!   depth/<label>/<clip_id>/img_00001.png …       when the capture was rendered with --depth
//!   masks/<label>/<clip_id>/img_00001.png …       when the capture was rendered with --masks
//!   annotations/
//!     classes.txt  label_map.json       one class list, 0-based, shared by all splits
//!     kinetics_{train,val,test}.csv     label,youtube_id,time_start,time_end,split
//!     {train,val,test}_list_videos.txt  videos/<label>/<clip_id>.mp4 <label_id>
//!     {train,val,test}_list_rawframes.txt  rawframes/<label>/<clip_id> <frames> <label_id>
//!     activitynet.json                  the untrimmed captures with every segment
//!     clips.jsonl                       per-clip metadata
//!     qa.json                           quality report ([`qa`])
//!     skeleton_2d_coco17.pkl            MMAction2/PYSKL PoseDataset, COCO-17, pixels
//!     skeleton_3d_ntu25.pkl             MMAction2/PYSKL PoseDataset, NTU-25, metres
//!     coco_keypoints_{train,val,test}.json  COCO person keypoints and boxes, one image per frame
//! ```
//! The split is not part of a clip's path: splits are drawn over every clip of the plan (else
//! every clip in the manifest), so a dataset can grow capture by capture (or be re-split with
//! other ratios) without moving files.

pub mod job;
pub mod labels;
pub mod lists;
pub mod manifest;
pub mod motion;
pub mod passes;
pub mod pickle;
pub mod plan;
pub mod planned;
pub mod policy;
pub mod qa;
pub mod run;
pub mod sheets;
pub mod split;

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::dataset::clips::{ClipMode, ClipPolicyError};
use crate::video::CutMethod;

/// Why trimming failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TrimError {
    /// A file could not be read or written.
    #[error("cannot {action} `{path}`")]
    Io {
        /// What was being done.
        action: &'static str,
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// A contact sheet cannot be written.
    #[error("cannot write the contact sheet `{}`", path.display())]
    Sheet {
        /// The sheet.
        path: PathBuf,
        /// The cause (boxed: it is large).
        #[source]
        source: Box<crate::video::VideoError>,
    },
    /// A line of the manifest autoact wrote earlier is not a clip record.
    #[error("`{path}` line {line}: not a clip record")]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// Why the line does not read as a record.
        #[source]
        source: serde_json::Error,
    },
    /// The dataset folder's class list differs from this capture's.
    #[error(
        "`{path}` lists the classes {existing:?}, but this capture's dataset has {new:?}; class ids must not change between runs, so trim into another folder"
    )]
    ClassesChanged {
        /// `classes.txt`.
        path: PathBuf,
        /// What it lists.
        existing: Vec<String>,
        /// What the capture has.
        new: Vec<String>,
    },
    /// The capture bag's dataset record lists no class labels.
    #[error("the capture bag lists no class labels (its `autoact.dataset` record has no `labels`)")]
    NoLabels,
    /// The capture bag's class labels are not sorted and unique (class ids are their order).
    #[error("the class labels {labels:?} are not sorted and unique")]
    LabelsUnsorted {
        /// The labels as listed.
        labels: Vec<String>,
    },
    /// A class label holds a line break (`classes.txt` has one label per line).
    #[error("the class label {label:?} holds a line break")]
    LabelLineBreak {
        /// The label.
        label: String,
    },
    /// A segment names a class id the capture's label list does not have.
    #[error(
        "`{bag}`: segment `{segment}` has label id {label_id}, but the dataset has {labels} labels"
    )]
    LabelIdOutOfRange {
        /// The capture bag.
        bag: PathBuf,
        /// The segment's id.
        segment: String,
        /// Its class id.
        label_id: u32,
        /// How many labels the capture lists.
        labels: usize,
    },
    /// Two segments of one capture sanitise to the same clip id.
    #[error("`{bag}`: two segments give the clip id `{clip_id}`")]
    DuplicateClipId {
        /// The capture bag.
        bag: PathBuf,
        /// The shared clip id.
        clip_id: String,
    },
    /// The dataset folder already holds this clip id, cut from another capture.
    #[error(
        "clip `{clip_id}` in `{dir}` was cut from capture `{existing_bag}`, not `{bag}`: trim each dataset of captures into its own folder"
    )]
    OtherCapture {
        /// The clip id.
        clip_id: String,
        /// The dataset folder.
        dir: PathBuf,
        /// The capture bag (file name) the manifest records for it.
        existing_bag: String,
        /// The capture bag (file name) of this run.
        bag: String,
    },
    /// The capture's poses could not be read again (to find a clip policy's instances).
    #[error(transparent)]
    CaptureFrames(Box<crate::bags::capture::TimelineError>),
    /// A clip has no split (the split assignment missed it).
    #[error("clip `{clip_id}` was given no split")]
    NoSplit {
        /// The clip id.
        clip_id: String,
    },
    /// The split ratios cannot be used.
    #[error("split ratios {ratios:?}: need three non-negative numbers, not all zero")]
    SplitRatios {
        /// Train, validation and test ratios as given.
        ratios: [f64; 3],
    },
    /// The plan file is not a dataset plan.
    #[error("`{path}` is not a dataset plan (the `plan.json` `autoact convert --spec` writes)")]
    PlanRead {
        /// The file.
        path: PathBuf,
        /// Why it does not read as a plan.
        #[source]
        source: serde_json::Error,
    },
    /// A clip of the plan names a scene, animation or label the plan does not have.
    #[error("`{path}`: clip `{clip}` names {what}, which the plan does not have")]
    PlanIndex {
        /// The plan file.
        path: PathBuf,
        /// The clip's segment id.
        clip: String,
        /// What it names.
        what: String,
    },
    /// The capture bag is not a capture of the plan.
    #[error("`{bag}` is not a capture of the plan `{plan}`: {why}")]
    PlanMismatch {
        /// The plan file.
        plan: PathBuf,
        /// The capture bag.
        bag: PathBuf,
        /// What differs.
        why: String,
    },
    /// A depth or mask folder beside the capture video does not hold one frame per video frame.
    #[error(
        "`{}` holds {frames} frames, the video {video_frames}: it is not this video's pass (render again with --force)",
        dir.display()
    )]
    PassFrames {
        /// The pass folder.
        dir: PathBuf,
        /// Frames in it.
        frames: u64,
        /// Frames of the video.
        video_frames: u64,
    },
    /// A clip's frames are not all in a video that holds only some frames of its timeline (a
    /// render that drew only the frames its clips used, under another clip policy).
    #[error(
        "`{}` holds only some frames of its timeline (the clips' of the render's clip policy), and not timeline frame {frame} (stamp {stamp_nanos} ns) that clip `{clip_id}` needs: render again with every frame (`autoact render`, or `generate --keep-intermediates`)",
        video.display()
    )]
    FrameNotInVideo {
        /// The video.
        video: PathBuf,
        /// The clip.
        clip_id: String,
        /// The timeline frame missing.
        frame: u64,
        /// Its timeline stamp, nanoseconds.
        stamp_nanos: i128,
    },
    /// A video's frames are not those its render bag lists.
    #[error(
        "`{}` has {video_frames} frames, but its render bag lists {listed}: not the video that render made",
        video.display()
    )]
    DrawnFrameCount {
        /// The video.
        video: PathBuf,
        /// Frames in it.
        video_frames: u64,
        /// Frames the render bag lists.
        listed: u64,
    },
    /// A clip's label sidecar is not one.
    #[error("`{path}` is not a clip label file (the `labels/` sidecar `autoact trim` writes)")]
    LabelsRead {
        /// The file.
        path: PathBuf,
        /// Why it does not read.
        #[source]
        source: serde_json::Error,
    },
    /// A clip's label sidecar has frames of the wrong size.
    #[error("`{path}`: a frame does not have 17 COCO and 25 NTU keypoints of 3 values each")]
    LabelsShape {
        /// The file.
        path: PathBuf,
    },
    /// A clip's label sidecar changed while the label files were being written from it.
    #[error(
        "`{path}` changed while the label files were written ({frames} frames, {now} when read again): nothing was replaced; run again"
    )]
    LabelsChanged {
        /// The file.
        path: PathBuf,
        /// Its frames when first read.
        frames: usize,
        /// Its frames when read again.
        now: usize,
    },
    /// The clip policy, with `trim`'s options over the plan's, cannot cut clips.
    #[error("the clip policy of class `{label}`: {source}")]
    ClipPolicy {
        /// The class.
        label: String,
        /// The bad key.
        #[source]
        source: ClipPolicyError,
    },
    /// A record could not be encoded as JSON for a file.
    #[error("cannot encode JSON for `{path}`")]
    Json {
        /// The file it was meant for.
        path: PathBuf,
        /// The cause.
        #[source]
        source: serde_json::Error,
    },
}

impl TrimError {
    /// A mapper from an I/O error to [`TrimError::Io`] for `action` on `path`.
    pub fn io(
        action: &'static str,
        path: &std::path::Path,
    ) -> impl FnOnce(std::io::Error) -> TrimError + use<> {
        let path = path.to_path_buf();
        move |source| TrimError::Io {
            action,
            path,
            source,
        }
    }

    /// A mapper from a JSON encoding error to [`TrimError::Json`] for the file `path`.
    pub fn json(path: &std::path::Path) -> impl FnOnce(serde_json::Error) -> TrimError + use<> {
        let path = path.to_path_buf();
        move |source| TrimError::Json { path, source }
    }
}

/// One complete clip: everything every list needs (a line of `manifest.jsonl` and of
/// `annotations/clips.jsonl`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClipRecord {
    /// Unique clip id (file stem; the Kinetics `youtube_id` column): the sanitised segment id,
    /// with `-w<k>` or `-i<k>` for a segment's windows or instances ([`part_clip_id`]).
    pub clip_id: String,
    /// The clip, relative to the dataset folder (`videos/<label_dir>/<clip_id>.mp4`).
    pub video: String,
    /// Its frames, relative to the dataset folder, with `--rawframes`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rawframes: Option<String>,
    /// The JPEG quality its rawframes were written at: ffmpeg's mjpeg qscale, 2 (best) … 31,
    /// drawn per clip from `[randomise] jpeg_quality` (`trim --jpeg-quality`); absent without
    /// rawframes (and in manifests written before it was drawn, whose frames are at 2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jpeg_quality: Option<u8>,
    /// Its depth frames (16-bit PNG, millimetres), relative to the dataset folder, when the
    /// capture was rendered with `--depth` ([`passes`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth: Option<String>,
    /// Its instance mask frames (8-bit PNG, 0 background, 1 the person), relative to the dataset
    /// folder, when the capture was rendered with `--masks` ([`passes`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub masks: Option<String>,
    /// The class label as in the dataset spec (unsanitised).
    pub label: String,
    /// The class id: line index in `classes.txt`.
    pub label_id: u32,
    /// The label's folder name (sanitised).
    pub label_dir: String,
    /// Frames in the clip.
    pub frame_count: u64,
    /// Frames per second.
    pub fps: f64,
    /// Start of the clip in the capture video, seconds (frame `start_frame` / fps).
    pub start_s: f64,
    /// End (exclusive) of the clip in the capture video, seconds.
    pub end_s: f64,
    /// First frame in the capture video.
    pub start_frame: u64,
    /// How it was cut.
    pub method: CutMethod,
    /// The capture video's file name.
    pub capture_video: String,
    /// The capture video's length, seconds.
    pub capture_duration_s: f64,
    /// The capture video's size, `WxH` (empty if unknown).
    pub capture_resolution: String,
    /// The capture bag's file name.
    pub capture_bag: String,
    /// The capture session.
    pub session: String,
    /// The segment's id in the hierarchy `<category>/<action>/<animation>/v<variant>/s<scene>/c<viewpoint>`.
    pub segment_id: String,
    /// Category.
    pub category: String,
    /// Source animation (`<bag>#<track>`).
    pub animation: String,
    /// Variant index.
    pub variant: u32,
    /// Scene index within the variant.
    pub scene: u32,
    /// Viewpoint index within the scene.
    pub viewpoint: u32,
    /// Scene id.
    pub scene_id: String,
    /// Weather name.
    pub weather: String,
    /// Clock time, `HH:MM`.
    pub time: String,
    /// Location name.
    pub location: String,
    /// Character id: a hash of the drawn look (see `character_look`).
    pub character: String,
    /// The drawn look.
    pub character_look: serde_json::Value,
    /// The camera path of this viewpoint, as recorded in the capture bag (`/camera/pose`),
    /// identified by the segment's viewpoint index.
    pub camera: String,
    /// The dataset seed.
    pub seed: Option<u64>,
    /// The clip policy it was cut by.
    #[serde(default)]
    pub policy: ClipMode,
    /// Its index among its segment's clips (`windows`, `instances`); absent for `whole`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub part: Option<u32>,
    /// Where the action is in the clip, in the source animation and in the capture video
    /// (absent only in records of autoact versions before clip policies).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub action_span: Option<ActionSpan>,
    /// Quality measurements and flags ([`qa`]), when the render bag's annotations were read.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub qa: Option<qa::ClipQa>,
    /// Its pose and box labels ([`labels`]), relative to the dataset folder, when the render
    /// bag's annotations were read.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub labels: Option<String>,
}

/// Where a clip's action is: frames (end exclusive) and seconds, relative to the clip, to the
/// source animation (its first frame at the output rate is 0) and to the capture video.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ActionSpan {
    /// First frame of the action in the clip (0: the clip's first frame).
    pub start_frame: u64,
    /// One past its last frame in the clip.
    pub end_frame: u64,
    /// Its start in the clip, seconds.
    pub start_s: f64,
    /// Its end in the clip, seconds.
    pub end_s: f64,
    /// First frame of the action in the source animation (0: the animation's first frame).
    pub animation_start_frame: u64,
    /// One past its last frame in the source animation.
    pub animation_end_frame: u64,
    /// Its start in the source animation, seconds.
    pub animation_start_s: f64,
    /// Its end in the source animation, seconds.
    pub animation_end_s: f64,
    /// Its start in the capture video, seconds.
    pub video_start_s: f64,
    /// Its end in the capture video, seconds.
    pub video_end_s: f64,
}

impl ActionSpan {
    /// The span of clip `range` (video frames) at `fps`.
    #[must_use]
    #[expect(
        clippy::cast_precision_loss,
        reason = "frame counts are far below 2^52"
    )]
    pub fn of(range: &plan::FrameRange, fps: f64) -> ActionSpan {
        let s = |frames: u64| frames as f64 / fps;
        let a = &range.action;
        let in_clip = (a.start - range.start_frame)..(a.end - range.start_frame);
        let in_animation = a.start.saturating_sub(range.animation_start_frame)
            ..a.end.saturating_sub(range.animation_start_frame);
        ActionSpan {
            start_frame: in_clip.start,
            end_frame: in_clip.end,
            start_s: s(in_clip.start),
            end_s: s(in_clip.end),
            animation_start_frame: in_animation.start,
            animation_end_frame: in_animation.end,
            animation_start_s: s(in_animation.start),
            animation_end_s: s(in_animation.end),
            video_start_s: s(a.start),
            video_end_s: s(a.end),
        }
    }
}

/// The clip id of part `part` of the segment `segment_id` cut by `policy`: the segment's clip id
/// ([`clip_id`]) for its one clip, else with `-w<k>` (windows) or `-i<k>` (instances) added,
/// `k` 0-based, three digits at least.
#[must_use]
pub fn part_clip_id(segment_id: &str, policy: ClipMode, part: Option<u32>) -> String {
    let base = clip_id(segment_id);
    let suffix = match (part, policy) {
        (None, _) | (_, ClipMode::Whole) => return base,
        (Some(k), ClipMode::Windows) => format!("-w{k:03}"),
        (Some(k), ClipMode::Instances) => format!("-i{k:03}"),
    };
    // The suffix survives sanitize_name's length limit.
    let kept: String = base.chars().take(120 - suffix.len()).collect();
    kept + &suffix
}

/// The clip id of the segment `segment_id` (the file stem of its clip): the id with `/` as `-`,
/// sanitised ([`sanitize_name`]).
#[must_use]
pub fn clip_id(segment_id: &str) -> String {
    sanitize_name(&segment_id.replace('/', "-"))
}

/// `text` as a file or folder name: letters and digits of any script, `-`, `_` and `.` are
/// kept; everything else (spaces, `/`, `\`, `:`, quotes, control characters, …) becomes `_`;
/// a leading `.` becomes `_` (no hidden files, no `..`); empty → `_`. At most 120 characters.
///
/// The only way a label or id becomes a path.
#[must_use]
pub fn sanitize_name(text: &str) -> String {
    let mut out: String = text
        .chars()
        .map(|c| {
            if c.is_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .take(120)
        .collect();
    if out.starts_with('.') {
        out.replace_range(0..1, "_");
    }
    if out.is_empty() {
        out.push('_');
    }
    out
}

/// Folder names for `labels` (sorted classes): [`sanitize_name`], with `_<id>` added to labels
/// whose sanitised names would collide.
#[must_use]
pub fn label_dirs(labels: &[String]) -> Vec<String> {
    let names: Vec<String> = labels.iter().map(|l| sanitize_name(l)).collect();
    names
        .iter()
        .enumerate()
        .map(|(i, n)| {
            if names.iter().filter(|m| *m == n).count() > 1 {
                format!("{n}_{i}")
            } else {
                n.clone()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::{label_dirs, sanitize_name};

    #[test]
    fn sanitised_names_cannot_leave_the_folder_or_hide() {
        assert_eq!(sanitize_name("air drumming"), "air_drumming");
        assert_eq!(sanitize_name("../../etc/passwd"), "_._.._etc_passwd");
        assert_eq!(sanitize_name(".."), "_.");
        assert_eq!(sanitize_name(".hidden"), "_hidden");
        assert_eq!(sanitize_name(""), "_");
        assert_eq!(sanitize_name("größe/ñandú"), "größe_ñandú");
        assert_eq!(sanitize_name("a,b\"c\nd"), "a_b_c_d");
        assert_eq!(sanitize_name(&"x".repeat(500)).len(), 120);
        for s in ["..", ".", "a/../b", "/abs", "c:\\x"] {
            let n = sanitize_name(s);
            assert!(
                !n.contains('/') && !n.contains('\\') && !n.starts_with('.'),
                "{n}"
            );
        }
    }

    #[test]
    fn colliding_labels_get_distinct_folders() {
        let labels = vec!["a b".to_owned(), "a/b".to_owned(), "c".to_owned()];
        assert_eq!(label_dirs(&labels), vec!["a_b_0", "a_b_1", "c"]);
    }
}
