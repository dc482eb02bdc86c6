//! Quality checks of a dataset's clips, from the render bag's per-frame annotations: a clip in
//! which the character is hidden, tiny or does not move is flagged, and so is a class whose clips
//! mostly do not move (an animation that lost its action), before anyone trains on them.
//!
//! Per clip, over its frames:
//! - **visible-joint fraction**: the mean share of keypoints marked visible (COCO visibility 2:
//!   in the image and not behind scenery);
//! - **hidden frames**: frames in which no pixel of the character is seen;
//! - **box height**: the median height of the character's box, as a fraction of the image's;
//! - **motion**: the mean speed of the joints relative to the body's own frame (pelvis, hips and
//!   neck), metres per second. The body frame removes the camera's motion and the body's travel
//!   and turning, so a walk on the spot and a walk across the scene measure alike, and a moving
//!   camera does not make a still body look active.
//!
//! The thresholds ([`Thresholds::default`]) are stated in physical terms, not fitted to a file:
//! half the joints hidden on average, more than 5 % of frames with the character out of sight, a
//! person under a tenth of the image's height, joints moving slower than 5 cm/s on average (a
//! held pose measures 0; the demo dataset's rendered walks 0.54–0.94 m/s, its waves 0.43 m/s).

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::lists::{ANNOTATIONS_DIR, write_atomic};
use super::motion::{BODY_FRAME_JOINTS, STILL_M_PER_S, body_frame};
use super::plan::FrameRange;
use super::{ClipRecord, TrimError};
use crate::bags::render::{ANNOTATIONS_TOPIC, RenderBagError, VIDEO_TOPIC, decode_annotation};
use crate::mcap_io::BagReader;
use crate::ros::autoact_msgs::{FrameAnnotation, VideoInfo};
use crate::ros::{RosMessage, cdr};

/// COCO visibility of a keypoint seen in the image.
const VISIBLE: u8 = 2;

/// What a clip is flagged for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ClipFlag {
    /// Fewer joints visible on average than [`Thresholds::min_visible_fraction`].
    Occluded,
    /// More frames without a visible pixel of the character than
    /// [`Thresholds::max_hidden_fraction`].
    Hidden,
    /// The character's median box is shorter than [`Thresholds::min_box_height_fraction`].
    Small,
    /// The joints move slower than [`Thresholds::min_motion_m_per_s`].
    Still,
}

impl ClipFlag {
    /// What the flag means, for warnings.
    #[must_use]
    pub fn describe(self) -> &'static str {
        match self {
            ClipFlag::Occluded => "most joints hidden",
            ClipFlag::Hidden => "character out of sight in many frames",
            ClipFlag::Small => "character very small in the image",
            ClipFlag::Still => "the body barely moves",
        }
    }
}

/// The measurements of one clip.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClipQa {
    /// Frames measured (those of the clip found in the render bag).
    pub frames: u64,
    /// Mean share of keypoints visible, 0–1.
    pub visible_joint_fraction: f64,
    /// Frames without a visible pixel of the character.
    pub hidden_frames: u64,
    /// Median box height / image height, 0–1 (`None` when the image size is unknown).
    pub box_height_fraction: Option<f64>,
    /// Mean joint speed in the body's frame, m/s.
    pub motion_m_per_s: f64,
    /// What it is flagged for (empty: nothing).
    pub flags: Vec<ClipFlag>,
}

/// Where a clip or class is flagged.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Thresholds {
    /// Least mean share of visible joints.
    pub min_visible_fraction: f64,
    /// Largest share of frames without a visible pixel of the character.
    pub max_hidden_fraction: f64,
    /// Least median box height, as a fraction of the image height.
    pub min_box_height_fraction: f64,
    /// Least mean joint speed in the body's frame, m/s; a class whose median clip is slower is
    /// flagged as a whole.
    pub min_motion_m_per_s: f64,
}

impl Default for Thresholds {
    fn default() -> Thresholds {
        Thresholds {
            min_visible_fraction: 0.5,
            max_hidden_fraction: 0.05,
            min_box_height_fraction: 0.1,
            min_motion_m_per_s: STILL_M_PER_S,
        }
    }
}

impl Thresholds {
    /// The flags of a clip's measurements.
    #[must_use]
    #[expect(
        clippy::cast_precision_loss,
        reason = "frame counts are far below 2^52"
    )]
    pub fn flags(&self, qa: &ClipQa) -> Vec<ClipFlag> {
        let mut out = Vec::new();
        if qa.frames == 0 {
            return out;
        }
        if qa.visible_joint_fraction < self.min_visible_fraction {
            out.push(ClipFlag::Occluded);
        }
        if qa.hidden_frames as f64 > self.max_hidden_fraction * qa.frames as f64 {
            out.push(ClipFlag::Hidden);
        }
        if qa
            .box_height_fraction
            .is_some_and(|h| h < self.min_box_height_fraction)
        {
            out.push(ClipFlag::Small);
        }
        if qa.motion_m_per_s < self.min_motion_m_per_s {
            out.push(ClipFlag::Still);
        }
        out
    }
}

/// Running measurements of one clip, frame by frame: what is kept per frame is its box height
/// (for the median); the joints of the last frame and of this one live in two buffers reused
/// from frame to frame.
#[derive(Debug, Clone, Default)]
pub struct ClipMeter {
    frames: u64,
    visible_sum: f64,
    hidden_frames: u64,
    box_heights: Vec<f64>,
    speed_sum_m: f64,
    speed_steps: u64,
    /// Index of the last frame whose body frame was found, and its joints in it.
    last_index: Option<u64>,
    last: Vec<Vector3<f64>>,
    now: Vec<Vector3<f64>>,
}

impl ClipMeter {
    /// Takes in one frame of an image `image_height` pixels high, at `fps`.
    #[expect(
        clippy::cast_precision_loss,
        reason = "keypoint counts and frame indices are far below 2^52"
    )]
    pub fn push(&mut self, frame: &FrameAnnotation, image_height: u32, fps: f64) {
        self.frames += 1;
        let n = frame.visibility.len();
        if n > 0 {
            let seen = frame.visibility.iter().filter(|&&v| v == VISIBLE).count();
            self.visible_sum += seen as f64 / n as f64;
        }
        if frame.silhouette_pixels == 0 {
            self.hidden_frames += 1;
        }
        if image_height > 0 {
            self.box_heights
                .push(f64::from(frame.bbox.height) / f64::from(image_height));
        }
        if !body_frame_joints(frame, &mut self.now) {
            self.last_index = None;
            return;
        }
        if self.last_index == Some(frame.frame_index.wrapping_sub(1))
            && self.last.len() == self.now.len()
        {
            let moved: f64 = (self.now.iter().zip(&self.last))
                .map(|(a, b)| (a - b).norm())
                .sum();
            self.speed_sum_m += moved / self.now.len() as f64 * fps;
            self.speed_steps += 1;
        }
        std::mem::swap(&mut self.last, &mut self.now);
        self.last_index = Some(frame.frame_index);
    }

    /// The clip's measurements and flags.
    #[must_use]
    #[expect(
        clippy::cast_precision_loss,
        reason = "frame counts are far below 2^52"
    )]
    pub fn finish(mut self, thresholds: &Thresholds) -> ClipQa {
        self.box_heights.sort_by(f64::total_cmp);
        let mut qa = ClipQa {
            frames: self.frames,
            visible_joint_fraction: if self.frames > 0 {
                self.visible_sum / self.frames as f64
            } else {
                0.0
            },
            hidden_frames: self.hidden_frames,
            box_height_fraction: self.box_heights.get(self.box_heights.len() / 2).copied(),
            motion_m_per_s: if self.speed_steps > 0 {
                self.speed_sum_m / self.speed_steps as f64
            } else {
                0.0
            },
            flags: Vec::new(),
        };
        qa.flags = thresholds.flags(&qa);
        qa
    }
}

/// The frame's 3D keypoints in the body's own frame (origin at the pelvis, x from the right hip
/// to the left, z towards the neck) into `out`; `false` when the body frame's joints are missing
/// or degenerate.
fn body_frame_joints(frame: &FrameAnnotation, out: &mut Vec<Vector3<f64>>) -> bool {
    body_from_camera(frame).is_some_and(|(body_from_camera, pelvis)| {
        out.clear();
        out.extend(
            (frame.keypoints_3d.iter())
                .map(|p| body_from_camera * (Vector3::new(p.x, p.y, p.z) - pelvis)),
        );
        true
    })
}

/// The rotation from the camera's frame into the body's, and the pelvis in the camera's frame
/// ([`body_frame`]).
fn body_from_camera(frame: &FrameAnnotation) -> Option<(Matrix3<f64>, Vector3<f64>)> {
    let at = |name: &str| {
        let i = frame.keypoint_names.iter().position(|n| n == name)?;
        let p = frame.keypoints_3d.get(i)?;
        let v = Vector3::new(p.x, p.y, p.z);
        v.iter().all(|c| c.is_finite()).then_some(v)
    };
    let [pelvis, left, right, neck] = BODY_FRAME_JOINTS.map(at);
    body_frame(pelvis?, left?, right?, neck?)
}

/// Measures the clip of each of `ranges` (video frames) from the per-frame annotations of render
/// bag `bag`, read once: `None` for a clip none of whose frames the bag annotates. An annotation
/// that does not decode is left out (and counted in the second value). Each annotation of a clip
/// is also handed to `on_frame` (the clip's index in `ranges`, the annotation, the image's
/// `[width, height]`), so other per-clip labels come from the same pass.
///
/// # Errors
/// [`RenderBagError`] when the bag cannot be opened or read.
pub fn measure_clips(
    bag: &Path,
    ranges: &[FrameRange],
    thresholds: &Thresholds,
    on_frame: &mut dyn FnMut(usize, &FrameAnnotation, [u32; 2]),
) -> Result<(Vec<Option<ClipQa>>, u64), RenderBagError> {
    // Clips by first frame, to find the clips of a frame by bisection; clips may overlap
    // (windows), so `reach[j]` is the furthest end of the first `j + 1` clips in that order.
    let mut order: Vec<usize> = (0..ranges.len()).collect();
    order.sort_by_key(|&i| ranges[i].start_frame);
    let reach: Vec<u64> = order
        .iter()
        .scan(0, |far, &i| {
            *far = (*far).max(ranges[i].start_frame + ranges[i].frame_count);
            Some(*far)
        })
        .collect();
    let mut meters = vec![ClipMeter::default(); ranges.len()];
    let (mut width, mut height, mut fps, mut undecodable) = (0, 0, 0.0, 0u64);
    let mut annotation = FrameAnnotation::default();
    for m in BagReader::open_all(bag)?
        .iter()
        .flat_map(BagReader::messages)
    {
        let m = m?;
        if m.channel.topic == VIDEO_TOPIC && m.channel.schema_name() == VideoInfo::TYPE_NAME {
            if let Ok(info) = cdr::decode::<VideoInfo>(&m.data) {
                (width, height, fps) = (info.width, info.height, info.fps);
            }
            continue;
        }
        if m.channel.topic != ANNOTATIONS_TOPIC
            || m.channel.schema_name() != FrameAnnotation::TYPE_NAME
        {
            continue;
        }
        if decode_annotation(&m.data, &mut annotation).is_err() {
            undecodable += 1;
            continue;
        }
        let k = annotation.frame_index;
        let at = order.partition_point(|&i| ranges[i].start_frame <= k);
        for j in (0..at).rev().take_while(|&j| reach[j] > k) {
            let i = order[j];
            if k < ranges[i].start_frame + ranges[i].frame_count {
                meters[i].push(&annotation, height, fps);
                on_frame(i, &annotation, [width, height]);
            }
        }
    }
    let qas = meters
        .into_iter()
        .map(|m| (m.frames > 0).then(|| m.finish(thresholds)))
        .collect();
    Ok((qas, undecodable))
}

/// One class's summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClassQa {
    /// Clips measured.
    pub clips: usize,
    /// Clips flagged for anything.
    pub flagged: usize,
    /// Median of its clips' motion, m/s.
    pub median_motion_m_per_s: f64,
    /// Whether the class as a whole barely moves (its median clip is [`ClipFlag::Still`]).
    pub still: bool,
}

/// Per-class summaries of `clips` (label, measurements).
#[must_use]
pub fn classes<'a>(
    clips: impl IntoIterator<Item = (&'a str, &'a ClipQa)>,
    thresholds: &Thresholds,
) -> BTreeMap<String, ClassQa> {
    let mut by_class: BTreeMap<String, Vec<&ClipQa>> = BTreeMap::new();
    for (label, qa) in clips {
        by_class.entry(label.to_owned()).or_default().push(qa);
    }
    by_class
        .into_iter()
        .map(|(label, qas)| {
            let mut motion: Vec<f64> = qas.iter().map(|q| q.motion_m_per_s).collect();
            motion.sort_by(f64::total_cmp);
            let median = motion[motion.len() / 2];
            let summary = ClassQa {
                clips: qas.len(),
                flagged: qas.iter().filter(|q| !q.flags.is_empty()).count(),
                median_motion_m_per_s: median,
                still: median < thresholds.min_motion_m_per_s,
            };
            (label, summary)
        })
        .collect()
}

/// The file the quality report is written to, in the annotations folder.
pub const REPORT_FILE: &str = "qa.json";

/// What the quality report found, for the run's summary.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct QaSummary {
    /// Clips checked (those cut with their render bag's annotations at hand).
    pub checked: usize,
    /// Clips not checked.
    pub unchecked: usize,
    /// Clips flagged, per flag.
    pub flagged: BTreeMap<ClipFlag, usize>,
    /// Clips flagged for anything.
    pub flagged_clips: usize,
    /// Classes whose median clip barely moves, with that median (m/s).
    pub still_classes: Vec<(String, f64)>,
    /// The report written.
    pub path: std::path::PathBuf,
}

/// Writes `annotations/qa.json` over `clips` (the dataset's complete clips): the thresholds,
/// every class's summary, and every flagged clip with its measurements. Flags are decided anew
/// with `thresholds`, so the report is consistent whatever earlier runs used. `None` (and no
/// file; an old report is removed) when no clip was checked.
///
/// # Errors
/// [`TrimError::Io`] or [`TrimError::Json`] for the report.
pub fn write_qa_report(
    dir: &Path,
    clips: &BTreeMap<String, ClipRecord>,
    thresholds: &Thresholds,
) -> Result<Option<QaSummary>, TrimError> {
    let path = dir.join(ANNOTATIONS_DIR).join(REPORT_FILE);
    let checked: Vec<(&ClipRecord, ClipQa)> = clips
        .values()
        .filter_map(|c| {
            let mut qa = c.qa.clone()?;
            qa.flags = thresholds.flags(&qa);
            Some((c, qa))
        })
        .collect();
    if checked.is_empty() {
        match std::fs::remove_file(&path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(TrimError::io("remove", &path)(e));
            }
            _ => return Ok(None),
        }
    }
    let class_summary = classes(
        checked.iter().map(|(c, q)| (c.label.as_str(), q)),
        thresholds,
    );
    let mut summary = QaSummary {
        checked: checked.len(),
        unchecked: clips.len() - checked.len(),
        path: path.clone(),
        ..QaSummary::default()
    };
    let mut flagged = Vec::new();
    for (clip, qa) in &checked {
        for f in &qa.flags {
            *summary.flagged.entry(*f).or_default() += 1;
        }
        if !qa.flags.is_empty() {
            summary.flagged_clips += 1;
            flagged.push(serde_json::json!({
                "clip_id": clip.clip_id,
                "label": clip.label,
                "video": clip.video,
                "qa": qa,
            }));
        }
    }
    summary.still_classes = class_summary
        .iter()
        .filter(|(_, c)| c.still)
        .map(|(label, c)| (label.clone(), c.median_motion_m_per_s))
        .collect();
    let report = serde_json::json!({
        "thresholds": thresholds,
        "clips_checked": summary.checked,
        "clips_not_checked": summary.unchecked,
        "clips_flagged": summary.flagged_clips,
        "classes": class_summary,
        "flagged": flagged,
    });
    let text = serde_json::to_string_pretty(&report).map_err(|source| TrimError::Json {
        path: path.clone(),
        source,
    })?;
    write_atomic(&path, format!("{text}\n").as_bytes())?;
    Ok(Some(summary))
}

impl std::fmt::Display for QaSummary {
    /// One line per finding: clips flagged per flag, classes that barely move, where the report is.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let flags: Vec<String> = self
            .flagged
            .iter()
            .map(|(flag, n)| format!("{n} {}", flag.describe()))
            .collect();
        write!(
            f,
            "  quality: {} of {} clips flagged{}",
            self.flagged_clips,
            self.checked,
            if flags.is_empty() {
                String::new()
            } else {
                format!(" ({})", flags.join(", "))
            }
        )?;
        if self.unchecked > 0 {
            write!(f, "; {} not checked (no render bag)", self.unchecked)?;
        }
        writeln!(f, ": {}", self.path.display())?;
        for (label, motion) in &self.still_classes {
            writeln!(
                f,
                "  quality: class `{label}` barely moves (median clip {motion:.3} m/s): check its source animations"
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{ClipFlag, ClipMeter, Thresholds, classes};
    use crate::ros::autoact_msgs::FrameAnnotation;
    use crate::ros::geometry_msgs::Point;
    use crate::ros::sensor_msgs::RegionOfInterest;
    use nalgebra::{Rotation3, Vector3};

    const NAMES: [&str; 6] = ["pelvis", "l_thigh", "r_thigh", "neck", "l_hand", "r_hand"];

    /// A body 3 m in front of a camera (optical frame: z forward, y down), rotated by `yaw` about
    /// the camera's y axis and shifted by `shift`, the hands at `hand_offset` from rest.
    fn frame(index: u64, yaw: f64, shift: Vector3<f64>, hand: f64) -> FrameAnnotation {
        let rest = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(0.1, 0.0, 0.0),
            Vector3::new(-0.1, 0.0, 0.0),
            Vector3::new(0.0, -0.5, 0.0),
            Vector3::new(0.3, -0.2 - hand, 0.0),
            Vector3::new(-0.3, -0.2 + hand, 0.0),
        ];
        let r = Rotation3::from_axis_angle(&Vector3::y_axis(), yaw);
        let origin = Vector3::new(0.0, 0.0, 3.0) + shift;
        FrameAnnotation {
            frame_index: index,
            keypoint_names: NAMES.iter().map(|s| (*s).to_owned()).collect(),
            keypoints_3d: rest
                .iter()
                .map(|p| {
                    let q = r * p + origin;
                    Point {
                        x: q.x,
                        y: q.y,
                        z: q.z,
                    }
                })
                .collect(),
            visibility: vec![2; NAMES.len()],
            bbox: RegionOfInterest {
                height: 120,
                width: 40,
                ..RegionOfInterest::default()
            },
            silhouette_pixels: 500,
            ..FrameAnnotation::default()
        }
    }

    fn measure(frames: &[FrameAnnotation]) -> super::ClipQa {
        let mut m = ClipMeter::default();
        for f in frames {
            m.push(f, 360, 30.0);
        }
        m.finish(&Thresholds::default())
    }

    #[test]
    fn a_still_body_is_still_whatever_the_camera_or_body_travel_does() {
        // Turning and travelling 1 m/s, the joints fixed on the body: no motion measured.
        let frames: Vec<_> = (0..60u32)
            .map(|k| {
                let t = f64::from(k) / 30.0;
                frame(u64::from(k), 0.8 * t, Vector3::new(t, 0.0, 0.0), 0.0)
            })
            .collect();
        let qa = measure(&frames);
        assert!(qa.motion_m_per_s < 1e-9, "{qa:?}");
        assert_eq!(qa.flags, vec![ClipFlag::Still]);
    }

    #[test]
    fn waving_hands_move_and_are_not_flagged() {
        let frames: Vec<_> = (0..60u32)
            .map(|k| {
                let t = f64::from(k) / 30.0;
                frame(u64::from(k), 0.0, Vector3::zeros(), 0.2 * (6.0 * t).sin())
            })
            .collect();
        let qa = measure(&frames);
        // Two of six joints move 0.2 m with angular rate 6 rad/s: mean |v| = 2/6 · 0.2 · 6 · 2/π.
        let expected = 2.0 / 6.0 * 0.2 * 6.0 * 2.0 / std::f64::consts::PI;
        assert!(
            (qa.motion_m_per_s - expected).abs() < 0.05 * expected,
            "{} vs {expected}",
            qa.motion_m_per_s
        );
        assert!(qa.flags.is_empty(), "{qa:?}");
        assert_eq!(qa.box_height_fraction, Some(120.0 / 360.0));
    }

    #[test]
    fn hidden_occluded_and_small_clips_are_flagged_and_a_still_class_too() {
        let moving = |k: u32| frame(u64::from(k), 0.0, Vector3::zeros(), 0.1 * f64::from(k % 7));
        let mut frames: Vec<_> = (0..100).map(moving).collect();
        for f in &mut frames[..20] {
            f.silhouette_pixels = 0;
            f.visibility = vec![1; NAMES.len()];
        }
        for f in &mut frames[20..] {
            f.visibility = vec![2, 2, 0, 1, 1, 0];
            f.bbox.height = 20;
        }
        let qa = measure(&frames);
        assert_eq!(
            qa.flags,
            vec![ClipFlag::Occluded, ClipFlag::Hidden, ClipFlag::Small]
        );
        assert_eq!(qa.hidden_frames, 20);
        assert!((qa.visible_joint_fraction - 0.8 * 2.0 / 6.0).abs() < 1e-12);

        let still = measure(
            &(0..30)
                .map(|k| frame(k, 0.0, Vector3::zeros(), 0.0))
                .collect::<Vec<_>>(),
        );
        let ok = measure(&(0..30u32).map(moving).collect::<Vec<_>>());
        let summary = classes(
            [
                ("squat", &still),
                ("squat", &still),
                ("squat", &ok),
                ("wave", &ok),
            ],
            &Thresholds::default(),
        );
        assert!(summary["squat"].still);
        assert_eq!(summary["squat"].flagged, 2);
        assert!(!summary["wave"].still);
    }

    #[test]
    fn a_gap_in_frame_indices_does_not_count_as_motion() {
        let mut frames: Vec<_> = (0..10)
            .map(|k| frame(k, 0.0, Vector3::zeros(), 0.0))
            .collect();
        frames.extend((20..30).map(|k| frame(k, 0.0, Vector3::zeros(), 0.3)));
        assert!(measure(&frames).motion_m_per_s < 1e-9);
    }
}
