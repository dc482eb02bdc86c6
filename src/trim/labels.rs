//! Pose and box labels for every clip, from the render bag's per-frame landmarks: the MMAction2 /
//! PYSKL skeleton annotation files (COCO-17 in pixels, NTU-25 in metres) and COCO-format keypoint
//! JSON per split.
//!
//! Each clip's labels are read in the same pass over the render bag as its quality measurements
//! ([`super::qa::measure_clips`]) and kept beside the clip as a sidecar,
//! `labels/<label>/<clip_id>.json` ([`ClipLabels`]); the dataset-wide files are rewritten from
//! every complete clip's sidecar after every run, like the lists, so they stay whole and
//! consistent as captures are trimmed into one folder one after another.
//!
//! The keypoints are the rig's landmarks read through the built-in layouts
//! ([`crate::skeleton::layout::Layout::builtin`] `coco-17` and `ntu-25`): each layout joint that
//! a rig landmark names on its own is that landmark (COCO's nose, eyes and ears are the rig's face
//! landmarks, moving with the head), and NTU's hand tips, which the import layout leaves unbound,
//! are the middle fingers' tips ([`EXPORT_EXTRA`]).
//!
//! - 2-D: pixels in the COCO / OpenCV convention (the top-left pixel's centre is (0, 0)), the
//!   visibility `v` as the render bag's: 0 out of the image or behind the camera, 1 in the image
//!   but hidden (behind scenery; the face points also behind the character's own head), 2
//!   visible.
//! - 3-D: NTU RGB+D's (Kinect v2) camera space, metres: x to the camera's left, y up, z away from
//!   the camera — the render camera's optical frame turned half a turn about its axis
//!   ([`kinect_from_optical`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::lists::{ANNOTATIONS_DIR, write_atomic};
use super::pickle::{Py, to_bytes};
use super::split::{Assignment, Split};
use super::{ClipRecord, TrimError};
use crate::ros::autoact_msgs::FrameAnnotation;
use crate::ros::geometry_msgs::Point;
use crate::skeleton::layout::{JointExpr, Layout};

/// Folder of the per-clip label sidecars inside the dataset folder.
pub const LABELS_DIR: &str = "labels";
/// The MMAction2/PYSKL skeleton annotations in COCO-17, pixels.
pub const SKELETON_2D_FILE: &str = "skeleton_2d_coco17.pkl";
/// The MMAction2/PYSKL skeleton annotations in NTU-25, metres.
pub const SKELETON_3D_FILE: &str = "skeleton_3d_ntu25.pkl";

/// COCO keypoint JSON of `split`.
#[must_use]
pub fn coco_file(split: Split) -> String {
    format!("coco_keypoints_{}.json", split.name())
}

/// Layout joints the export binds although the layout (made for import) does not: (layout, joint,
/// rig landmark).
pub const EXPORT_EXTRA: [(&str, &str, &str); 2] = [
    ("ntu-25", "HandTipLeft", "l_middle4"),
    ("ntu-25", "HandTipRight", "r_middle4"),
];

/// COCO's person skeleton: limbs as 1-based keypoint pairs (the `categories[0].skeleton` of
/// `person_keypoints_*.json`).
pub const COCO_SKELETON: [[u8; 2]; 19] = [
    [16, 14],
    [14, 12],
    [17, 15],
    [15, 13],
    [12, 13],
    [6, 12],
    [7, 13],
    [6, 7],
    [6, 8],
    [7, 9],
    [8, 10],
    [9, 11],
    [2, 3],
    [1, 2],
    [1, 3],
    [2, 4],
    [3, 5],
    [4, 6],
    [5, 7],
];

/// A point of the optical frame (x right, y down, z forward) in Kinect v2 camera space (x left,
/// y up, z forward), metres.
#[must_use]
pub fn kinect_from_optical(p: &Point) -> [f64; 3] {
    [-p.x, -p.y, p.z]
}

/// One frame's labels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameLabels {
    /// COCO-17 keypoints `x, y, v` interleaved (pixels, OpenCV convention); a point behind the
    /// camera is at (0, 0).
    pub coco17: Vec<f32>,
    /// NTU-25 joints `x, y, z` interleaved, Kinect camera space, metres.
    pub ntu25: Vec<f32>,
    /// The silhouette's box `[x, y, width, height]` in whole pixels, `None` when unseen.
    pub bbox: Option<[u32; 4]>,
    /// Pixels of the silhouette.
    pub area: u32,
}

/// One clip's labels: a sidecar file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClipLabels {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Per frame of the clip, `None` where the render bag has no usable annotation.
    pub frames: Vec<Option<FrameLabels>>,
}

/// Where a layout's joints are in a render bag's landmark list.
#[derive(Debug, Clone)]
struct LayoutIndex {
    /// Per layout joint, the rig landmark it is.
    landmarks: Vec<String>,
    /// The landmark names this was resolved against, and the joints' indices in them.
    resolved: Option<(Vec<String>, Vec<usize>)>,
}

impl LayoutIndex {
    /// The joints of built-in layout `name` as rig landmarks.
    fn new(name: &str) -> LayoutIndex {
        let layout = Layout::builtin(name).unwrap_or_else(|_| Layout {
            name: name.to_owned(),
            description: String::new(),
            joints: Vec::new(),
            landmarks: BTreeMap::new(),
            bones: BTreeMap::new(),
        });
        let landmarks = layout_landmarks(&layout);
        LayoutIndex {
            landmarks,
            resolved: None,
        }
    }

    /// Indices into `names` of every joint, `None` when a landmark is missing (a render bag from
    /// before landmarks were annotated).
    fn indices(&mut self, names: &[String]) -> Option<&[usize]> {
        let stale = self.resolved.as_ref().is_none_or(|(n, _)| n != names);
        if stale {
            let found: Option<Vec<usize>> = self
                .landmarks
                .iter()
                .map(|l| names.iter().position(|n| n == l))
                .collect();
            self.resolved = Some((names.to_vec(), found.unwrap_or_default()));
        }
        let (_, idx) = self.resolved.as_ref()?;
        (idx.len() == self.landmarks.len() && !idx.is_empty()).then_some(idx.as_slice())
    }
}

/// Per joint of `layout`, the rig landmark it is: the landmark that names the joint on its own
/// (or, for a joint no landmark names, [`EXPORT_EXTRA`]'s); empty for a joint neither gives.
#[must_use]
pub fn layout_landmarks(layout: &Layout) -> Vec<String> {
    layout
        .joints
        .iter()
        .map(|j| {
            let named = layout.landmarks.iter().find_map(|(landmark, expr)| {
                matches!(expr, JointExpr::Joint(x) if x == j).then(|| landmark.clone())
            });
            named
                .or_else(|| {
                    EXPORT_EXTRA
                        .iter()
                        .find(|(l, joint, _)| *l == layout.name && joint == j)
                        .map(|(_, _, landmark)| (*landmark).to_owned())
                })
                .unwrap_or_default()
        })
        .collect()
}

/// Collects each clip's labels from the render bag's annotations, frame by frame.
#[derive(Debug)]
pub struct LabelCollector {
    coco: LayoutIndex,
    ntu: LayoutIndex,
    /// Per clip: its first frame and its labels so far.
    clips: Vec<(u64, Option<ClipLabels>)>,
    /// Annotations without the landmarks the layouts need.
    pub without_landmarks: u64,
}

impl LabelCollector {
    /// A collector for clips of `(start_frame, frame_count)`.
    #[must_use]
    pub fn new(ranges: impl IntoIterator<Item = (u64, u64)>) -> LabelCollector {
        LabelCollector {
            coco: LayoutIndex::new("coco-17"),
            ntu: LayoutIndex::new("ntu-25"),
            clips: ranges
                .into_iter()
                .map(|(start, count)| {
                    let frames = usize::try_from(count).unwrap_or(0);
                    let labels = ClipLabels {
                        width: 0,
                        height: 0,
                        frames: vec![None; frames],
                    };
                    (start, Some(labels))
                })
                .collect(),
            without_landmarks: 0,
        }
    }

    /// Takes in frame `a` of clip `clip`, from an image of `[width, height]`.
    pub fn push(&mut self, clip: usize, a: &FrameAnnotation, [width, height]: [u32; 2]) {
        let Some((start, Some(labels))) = self.clips.get_mut(clip) else {
            return;
        };
        let Some(k) = a
            .frame_index
            .checked_sub(*start)
            .and_then(|k| usize::try_from(k).ok())
        else {
            return;
        };
        let (Some(coco), Some(ntu)) = (
            self.coco.indices(&a.landmark_names).map(<[usize]>::to_vec),
            self.ntu.indices(&a.landmark_names),
        ) else {
            self.without_landmarks += 1;
            return;
        };
        let ok = a.landmarks_3d.len() == a.landmark_names.len()
            && a.landmarks_2d.len() == 2 * a.landmark_names.len()
            && a.landmark_visibility.len() == a.landmark_names.len();
        let Some(slot) = labels.frames.get_mut(k).filter(|_| ok) else {
            return;
        };
        (labels.width, labels.height) = (width, height);
        let mut coco17 = Vec::with_capacity(3 * coco.len());
        for &i in &coco {
            let (x, y) = (a.landmarks_2d[2 * i], a.landmarks_2d[2 * i + 1]);
            let (x, y) = if x.is_finite() && y.is_finite() {
                (x, y)
            } else {
                (0.0, 0.0)
            };
            coco17.extend([x, y, f32::from(a.landmark_visibility[i])]);
        }
        let ntu25 = ntu
            .iter()
            .flat_map(|&i| kinect_from_optical(&a.landmarks_3d[i]).map(|v| v as f32))
            .collect();
        let b = &a.bbox;
        *slot = Some(FrameLabels {
            coco17,
            ntu25,
            bbox: (a.silhouette_pixels > 0).then_some([b.x_offset, b.y_offset, b.width, b.height]),
            area: a.silhouette_pixels,
        });
    }

    /// Each clip's labels: `None` for a clip without one labelled frame.
    #[must_use]
    pub fn finish(self) -> Vec<Option<ClipLabels>> {
        self.clips
            .into_iter()
            .map(|(_, l)| l.filter(|l| l.frames.iter().any(Option::is_some)))
            .collect()
    }
}

/// The sidecar path of a clip, relative to the dataset folder.
#[must_use]
pub fn sidecar_path(label_dir: &str, clip_id: &str) -> String {
    format!("{LABELS_DIR}/{label_dir}/{clip_id}.json")
}

/// Writes `labels` as the sidecar `rel` (relative to `dir`), atomically.
///
/// # Errors
/// [`TrimError::Io`] or [`TrimError::Json`].
pub fn write_sidecar(dir: &Path, rel: &str, labels: &ClipLabels) -> Result<(), TrimError> {
    let path = dir.join(rel);
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(TrimError::io("create", parent))?;
    }
    let text = serde_json::to_string(labels).map_err(TrimError::json(&path))?;
    write_atomic(&path, format!("{text}\n").as_bytes())
}

/// Reads the sidecar `rel` of the dataset folder `dir`.
///
/// # Errors
/// [`TrimError::Io`], or [`TrimError::LabelsRead`] when it is not a label sidecar.
pub fn read_sidecar(dir: &Path, rel: &str) -> Result<ClipLabels, TrimError> {
    let path = dir.join(rel);
    let text = std::fs::read_to_string(&path).map_err(TrimError::io("read", &path))?;
    let labels: ClipLabels =
        serde_json::from_str(&text).map_err(|source| TrimError::LabelsRead {
            path: path.clone(),
            source,
        })?;
    let bad = labels
        .frames
        .iter()
        .flatten()
        .any(|f| f.coco17.len() != 3 * COCO17_JOINTS || f.ntu25.len() != 3 * NTU25_JOINTS);
    if bad {
        return Err(TrimError::LabelsShape { path });
    }
    Ok(labels)
}

/// COCO-17's keypoint count.
pub const COCO17_JOINTS: usize = 17;
/// NTU-25's joint count.
pub const NTU25_JOINTS: usize = 25;

/// What the label export wrote.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LabelSummary {
    /// Clips with labels.
    pub clips: usize,
    /// Clips without (cut without a render bag, or from one without landmarks).
    pub without: usize,
    /// The files written.
    pub files: Vec<PathBuf>,
}

/// Rewrites the skeleton `.pkl` files and the COCO keypoint JSON of every split from the
/// sidecars of `clips` (the dataset's complete clips), split as `splits` says. `None` (and the
/// files removed) when no clip has labels.
///
/// # Errors
/// [`TrimError`] for a sidecar that cannot be read or a file that cannot be written.
pub fn write_label_files(
    dir: &Path,
    clips: &BTreeMap<String, ClipRecord>,
    splits: &Assignment,
) -> Result<Option<LabelSummary>, TrimError> {
    let ann = dir.join(ANNOTATIONS_DIR);
    let mut labelled: Vec<(&ClipRecord, Split, ClipLabels)> = Vec::new();
    for c in clips.values() {
        let (Some(rel), Some(split)) = (&c.labels, splits.splits.get(&c.clip_id)) else {
            continue;
        };
        labelled.push((c, *split, read_sidecar(dir, rel)?));
    }
    let files: Vec<PathBuf> = [SKELETON_2D_FILE, SKELETON_3D_FILE]
        .into_iter()
        .map(str::to_owned)
        .chain(Split::ALL.into_iter().map(coco_file))
        .map(|f| ann.join(f))
        .collect();
    if labelled.is_empty() {
        for f in &files {
            match std::fs::remove_file(f) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(TrimError::io("remove", f)(e));
                }
                _ => {}
            }
        }
        return Ok(None);
    }
    std::fs::create_dir_all(&ann).map_err(TrimError::io("create", &ann))?;
    write_atomic(
        &files[0],
        &to_bytes(&skeleton_pickle(&labelled, Skeleton::Coco2d)),
    )?;
    write_atomic(
        &files[1],
        &to_bytes(&skeleton_pickle(&labelled, Skeleton::Ntu3d)),
    )?;
    for (split, path) in Split::ALL.into_iter().zip(&files[2..]) {
        let json = coco_json(labelled.iter().filter(|(_, s, _)| *s == split));
        let text = serde_json::to_string(&json).map_err(TrimError::json(path))?;
        write_atomic(path, format!("{text}\n").as_bytes())?;
    }
    Ok(Some(LabelSummary {
        clips: labelled.len(),
        without: clips.len() - labelled.len(),
        files,
    }))
}

/// Which skeleton file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Skeleton {
    /// COCO-17, pixels, `C = 2`.
    Coco2d,
    /// NTU-25, metres, `C = 3`.
    Ntu3d,
}

/// The MMAction2/PYSKL annotation dict: `split` (every split, possibly empty, clip ids) and
/// `annotations` (one dict per clip, `keypoint` `1 × T × V × C`, and in 2-D `keypoint_score`
/// `1 × T × V`, both `float32`).
fn skeleton_pickle(labelled: &[(&ClipRecord, Split, ClipLabels)], which: Skeleton) -> Py {
    let split = Split::ALL
        .into_iter()
        .map(|s| {
            let ids = labelled
                .iter()
                .filter(|(_, t, _)| *t == s)
                .map(|(c, _, _)| Py::str(&c.clip_id))
                .collect();
            (Py::str(s.name()), Py::List(ids))
        })
        .collect();
    let annotations = labelled
        .iter()
        .map(|(c, _, l)| skeleton_annotation(c, l, which))
        .collect();
    Py::Dict(vec![
        (Py::str("split"), Py::Dict(split)),
        (Py::str("annotations"), Py::List(annotations)),
    ])
}

/// One clip's annotation dict. A frame without labels has zeros (and score 0). 2-D scores: 1 for a
/// point in the image (its position is exact, seen or hidden), 0 out of it. 3-D annotations have
/// no scores, as NTU RGB+D's 3-D annotations for MMAction2/PYSKL have none: MMAction2's 3-D
/// skeleton pipeline (`GenSkeFeat` with `dataset='nturgb+d'`) refuses a 3-D annotation with
/// `keypoint_score`.
fn skeleton_annotation(c: &ClipRecord, l: &ClipLabels, which: Skeleton) -> Py {
    let (v, ch) = match which {
        Skeleton::Coco2d => (COCO17_JOINTS, 2),
        Skeleton::Ntu3d => (NTU25_JOINTS, 3),
    };
    let t = l.frames.len();
    let mut keypoint = Vec::with_capacity(t * v * ch);
    let mut score = Vec::with_capacity(t * v);
    for f in &l.frames {
        match (f, which) {
            (None, _) => {
                keypoint.extend(std::iter::repeat_n(0.0, v * ch));
                score.extend(std::iter::repeat_n(0.0, v));
            }
            (Some(f), Skeleton::Coco2d) => {
                for p in f.coco17.chunks_exact(3) {
                    keypoint.extend_from_slice(&p[..2]);
                    score.push(if p[2] > 0.0 { 1.0 } else { 0.0 });
                }
            }
            (Some(f), Skeleton::Ntu3d) => keypoint.extend_from_slice(&f.ntu25),
        }
    }
    let shape = Py::Tuple(vec![
        Py::Int(i64::from(l.height)),
        Py::Int(i64::from(l.width)),
    ]);
    let frames = i64::try_from(t).unwrap_or(i64::MAX);
    let dims = |d: &[usize]| [&[1, t][..], d].concat();
    // Where the action is in the clip, frames `[start, end)` (the whole clip when unknown);
    // PoseDataset and PYSKL pass keys they do not use through untouched.
    let span = c.action_span.as_ref().map_or((0, frames), |a| {
        let at = |f: u64| i64::try_from(f).unwrap_or(i64::MAX);
        (at(a.start_frame), at(a.end_frame))
    });
    let mut dict = vec![
        (Py::str("frame_dir"), Py::str(&c.clip_id)),
        (Py::str("label"), Py::Int(i64::from(c.label_id))),
        (Py::str("img_shape"), shape.clone()),
        (Py::str("original_shape"), shape),
        (Py::str("total_frames"), Py::Int(frames)),
        (
            Py::str("action_span"),
            Py::Tuple(vec![Py::Int(span.0), Py::Int(span.1)]),
        ),
        (
            Py::str("keypoint"),
            Py::F32Array {
                shape: dims(&[v, ch]),
                data: keypoint,
            },
        ),
    ];
    if which == Skeleton::Coco2d {
        dict.push((
            Py::str("keypoint_score"),
            Py::F32Array {
                shape: dims(&[v]),
                data: score,
            },
        ));
    }
    Py::Dict(dict)
}

/// COCO keypoint JSON over the clips of one split: an image per frame (`file_name` as
/// `--rawframes` names it), an annotation per frame that shows the character.
fn coco_json<'a>(
    clips: impl Iterator<Item = &'a (&'a ClipRecord, Split, ClipLabels)>,
) -> serde_json::Value {
    let (mut images, mut annotations) = (Vec::new(), Vec::new());
    let mut image_id = 0u64;
    for (c, _, l) in clips {
        for (k, f) in l.frames.iter().enumerate() {
            image_id += 1;
            images.push(serde_json::json!({
                "id": image_id,
                "file_name": format!("{}/{}/{}/img_{:05}.jpg", super::run::RAWFRAMES_DIR, c.label_dir, c.clip_id, k + 1),
                "width": l.width,
                "height": l.height,
                "clip_id": c.clip_id,
                "frame_index": k,
                "video": c.video,
                "label_id": c.label_id,
            }));
            let Some(f) = f else { continue };
            let Some([x, y, w, h]) = f.bbox else { continue };
            let mut keypoints = Vec::with_capacity(3 * COCO17_JOINTS);
            let mut shown = 0u32;
            for p in f.coco17.chunks_exact(3) {
                if p[2] > 0.0 {
                    shown += 1;
                    keypoints.extend([f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]);
                } else {
                    keypoints.extend([0.0, 0.0, 0.0]);
                }
            }
            annotations.push(serde_json::json!({
                "id": image_id,
                "image_id": image_id,
                "category_id": 1,
                "iscrowd": 0,
                "keypoints": keypoints,
                "num_keypoints": shown,
                "bbox": [x, y, w, h],
                "area": f.area,
            }));
        }
    }
    let names = Layout::builtin("coco-17")
        .map(|l| l.joints)
        .unwrap_or_default();
    serde_json::json!({
        "info": {"description": "autoact: rendered frames with their rendering's exact labels"},
        "images": images,
        "annotations": annotations,
        "categories": [{
            "id": 1,
            "name": "person",
            "supercategory": "person",
            "keypoints": names,
            "skeleton": COCO_SKELETON,
        }],
    })
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::{
        ClipLabels, FrameLabels, LabelCollector, coco_file, layout_landmarks, sidecar_path,
        write_label_files, write_sidecar,
    };
    use crate::ros::autoact_msgs::FrameAnnotation;
    use crate::ros::geometry_msgs::Point;
    use crate::skeleton::layout::Layout;
    use crate::skeleton::rig::Rig;
    use crate::trim::split::tests::record;
    use crate::trim::split::{Assignment, Split};

    #[test]
    fn both_layouts_are_rig_landmarks_one_to_one_face_included() {
        let rig = Rig::standard();
        for (name, n) in [("coco-17", 17), ("ntu-25", 25)] {
            let l = layout_landmarks(&Layout::builtin(name).unwrap());
            assert_eq!(l.len(), n, "{name}");
            let mut distinct = l.clone();
            distinct.sort();
            distinct.dedup();
            assert_eq!(distinct.len(), n, "{name}: {l:?}");
            assert!(
                l.iter().all(|m| rig.landmark_index(m).is_some()),
                "{name}: {l:?}"
            );
        }
        let coco = layout_landmarks(&Layout::builtin("coco-17").unwrap());
        assert_eq!(coco[..5], ["nose", "l_eye", "r_eye", "l_ear", "r_ear"]);
        let ntu = layout_landmarks(&Layout::builtin("ntu-25").unwrap());
        assert_eq!(
            (ntu[21].as_str(), ntu[23].as_str()),
            ("l_middle4", "r_middle4")
        );
    }

    /// A frame whose landmark `i` (rig order) is at pixel `(i, 2i)` (OpenCV) and optical
    /// `(i, 2i, 5)` metres, visible unless `i` is odd.
    fn frame(k: u64) -> FrameAnnotation {
        let rig = Rig::standard();
        let n = rig.landmarks.len();
        FrameAnnotation {
            frame_index: k,
            landmark_names: rig.landmarks.iter().map(|l| l.name.clone()).collect(),
            landmarks_3d: (0..n)
                .map(|i| Point {
                    x: i as f64,
                    y: 2.0 * i as f64,
                    z: 5.0,
                })
                .collect(),
            landmarks_2d: (0..n).flat_map(|i| [i as f32, 2.0 * i as f32]).collect(),
            landmark_visibility: (0..n)
                .map(|i| if i.is_multiple_of(2) { 2 } else { 1 })
                .collect(),
            silhouette_pixels: 10,
            ..FrameAnnotation::default()
        }
    }

    #[test]
    fn collected_labels_are_the_layouts_landmarks_in_kinect_space() {
        let rig = Rig::standard();
        let mut c = LabelCollector::new([(10, 3), (20, 2)]);
        c.push(0, &frame(11), [320, 240]);
        c.push(1, &frame(25), [320, 240]); // past the clip: left out
        let mut old = frame(12);
        old.landmark_names.clear();
        c.push(0, &old, [320, 240]);
        assert_eq!(c.without_landmarks, 1);
        let out = c.finish();
        assert!(out[1].is_none(), "no frame of clip 1 was labelled");
        let l = out[0].as_ref().unwrap();
        assert_eq!((l.width, l.height, l.frames.len()), (320, 240, 3));
        assert!(l.frames[0].is_none() && l.frames[2].is_none());
        let f = l.frames[1].as_ref().unwrap();
        let nose_index = rig.landmark_index("nose").unwrap();
        let nose = nose_index as f32;
        let v = if nose_index.is_multiple_of(2) {
            2.0
        } else {
            1.0
        };
        assert_eq!(f.coco17[..3], [nose, 2.0 * nose, v]);
        let base = rig.landmark_index("pelvis").unwrap() as f32;
        assert_eq!(f.ntu25[..3], [-base, -2.0 * base, 5.0]);
    }

    #[test]
    fn the_files_hold_every_labelled_clip_as_the_dataset_grows() {
        let dir = tempfile::tempdir().unwrap();
        let labels = |t: usize| ClipLabels {
            width: 320,
            height: 240,
            frames: vec![
                Some(FrameLabels {
                    coco17: vec![1.0; 51],
                    ntu25: vec![0.5; 75],
                    bbox: Some([1, 2, 30, 40]),
                    area: 900,
                });
                t
            ],
        };
        let mut clips = BTreeMap::new();
        let mut splits = Assignment::default();
        let ann = dir.path().join("annotations");
        for (round, (id, split)) in [("a", Split::Train), ("b", Split::Val), ("c", Split::Test)]
            .into_iter()
            .enumerate()
        {
            let mut r = record(id, "wave", id, "CLEAR");
            let rel = sidecar_path("wave", id);
            write_sidecar(dir.path(), &rel, &labels(3 + round)).unwrap();
            r.labels = Some(rel);
            clips.insert(id.to_owned(), r);
            splits.splits.insert(id.to_owned(), split);
            let s = write_label_files(dir.path(), &clips, &splits)
                .unwrap()
                .unwrap();
            assert_eq!((s.clips, s.without), (round + 1, 0));
            let pkl = std::fs::read(ann.join(super::SKELETON_2D_FILE)).unwrap();
            for seen in clips.keys() {
                // The clip id as a pickled str (BINUNICODE), in the split list and as frame_dir.
                let needle = [&[b'X', 1, 0, 0, 0][..], seen.as_bytes()].concat();
                let n = pkl.windows(needle.len()).filter(|w| *w == needle).count();
                assert_eq!(n, 2, "clip {seen} in round {round}");
            }
            let coco: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(ann.join(coco_file(split))).unwrap())
                    .unwrap();
            assert_eq!(coco["images"].as_array().unwrap().len(), 3 + round);
            assert_eq!(coco["annotations"][0]["num_keypoints"], 17);
            assert_eq!(coco["annotations"][0]["area"], 900);
        }
        // Without labelled clips the files go.
        for c in clips.values_mut() {
            c.labels = None;
        }
        assert!(
            write_label_files(dir.path(), &clips, &splits)
                .unwrap()
                .is_none()
        );
        assert!(!ann.join(super::SKELETON_3D_FILE).exists());
    }
}
