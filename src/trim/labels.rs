//! Pose and box labels for every clip, from the render bag's per-frame landmarks: the MMAction2 /
//! PYSKL skeleton annotation files (COCO-17 in pixels, NTU-25 in metres) and COCO-format keypoint
//! JSON per split.
//!
//! Each clip's labels are read in the same pass over the render bag as its quality measurements
//! ([`super::qa::measure_clips`]) and kept beside the clip as a sidecar,
//! `labels/<label>/<clip_id>.json` ([`ClipLabels`]); the dataset-wide files are rewritten from
//! every complete clip's sidecar after every run, like the lists, so they stay whole and
//! consistent as captures are trimmed into one folder one after another. They are written as
//! streams, one sidecar held at a time ([`write_label_files`]), so the step's memory does not
//! grow with the clips' frames.
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
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::lists::{ANNOTATIONS_DIR, write_atomic};
use super::pickle::{DictEndingInList, Py};
use super::split::{Assignment, Split};
use super::{ClipRecord, TrimError};
use crate::atomic_file::StreamedFile;
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

/// Collects each clip's labels from the render bag's annotations, frame by frame. A clip whose
/// every frame is in is serialised at once (its sidecar's text) into a [`LabelSpool`], so only
/// the clips the pass is inside of are held in memory, not a whole capture's.
#[derive(Debug)]
pub struct LabelCollector {
    coco: LayoutIndex,
    ntu: LayoutIndex,
    clips: Vec<CollectedClip>,
    spool: LabelSpool,
    /// The first error writing or reading the spool.
    error: Option<TrimError>,
    /// Annotations without the landmarks the layouts need.
    pub without_landmarks: u64,
}

/// Where one clip's labels are during the pass.
#[derive(Debug)]
enum CollectedClip {
    /// No frame of it seen yet.
    Waiting { start: u64, frames: usize },
    /// Being filled; `missing` frames have no labels yet.
    Open {
        start: u64,
        labels: ClipLabels,
        missing: usize,
    },
    /// Every frame in: its sidecar text is in the spool.
    Spooled { start: u64, text: SpoolRange },
}

impl CollectedClip {
    fn start(&self) -> u64 {
        match self {
            CollectedClip::Waiting { start, .. }
            | CollectedClip::Open { start, .. }
            | CollectedClip::Spooled { start, .. } => *start,
        }
    }
}

impl LabelCollector {
    /// A collector for clips of `(start_frame, frame_count)`, spooling finished clips into an
    /// unnamed temporary file in `dir` (the dataset folder: gone when the run ends, however
    /// it ends).
    ///
    /// # Errors
    /// [`TrimError::Io`] when the temporary file cannot be made in `dir`.
    pub fn new(
        ranges: impl IntoIterator<Item = (u64, u64)>,
        dir: &Path,
    ) -> Result<LabelCollector, TrimError> {
        Ok(LabelCollector {
            coco: LayoutIndex::new("coco-17"),
            ntu: LayoutIndex::new("ntu-25"),
            clips: ranges
                .into_iter()
                .map(|(start, frames)| CollectedClip::Waiting {
                    start,
                    frames: usize::try_from(frames).unwrap_or(0),
                })
                .collect(),
            spool: LabelSpool::new(dir)?,
            error: None,
            without_landmarks: 0,
        })
    }

    /// Takes in frame `a` of clip `clip`, from an image of `[width, height]`.
    pub fn push(&mut self, clip: usize, a: &FrameAnnotation, [width, height]: [u32; 2]) {
        if self.error.is_some() {
            return;
        }
        let Some(start) = self.clips.get(clip).map(CollectedClip::start) else {
            return;
        };
        let Some(k) = a
            .frame_index
            .checked_sub(start)
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
        let frames = match &self.clips[clip] {
            CollectedClip::Waiting { frames, .. } => *frames,
            CollectedClip::Open { labels, .. } => labels.frames.len(),
            CollectedClip::Spooled { text, .. } => text.frames,
        };
        if !ok || k >= frames {
            return;
        }
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
        let frame = FrameLabels {
            coco17,
            ntu25,
            bbox: (a.silhouette_pixels > 0).then_some([b.x_offset, b.y_offset, b.width, b.height]),
            area: a.silhouette_pixels,
        };
        if let Err(e) = self.fill(clip, k, frame, [width, height]) {
            self.error = Some(e);
        }
    }

    /// Puts `frame` at `k` of clip `clip` (opening it, or reading it back from the spool when
    /// a frame comes again after the clip was complete: the last one wins, as for any frame),
    /// and spools the clip when that was its last missing frame.
    fn fill(
        &mut self,
        clip: usize,
        k: usize,
        frame: FrameLabels,
        [width, height]: [u32; 2],
    ) -> Result<(), TrimError> {
        let slot = &mut self.clips[clip];
        let start = slot.start();
        let (mut labels, mut missing) =
            match std::mem::replace(slot, CollectedClip::Waiting { start, frames: 0 }) {
                CollectedClip::Waiting { frames, .. } => {
                    let labels = ClipLabels {
                        width: 0,
                        height: 0,
                        frames: vec![None; frames],
                    };
                    (labels, frames)
                }
                CollectedClip::Open {
                    labels, missing, ..
                } => (labels, missing),
                CollectedClip::Spooled { text, .. } => {
                    let labels = self.spool.read(text)?;
                    let missing = labels.frames.iter().filter(|f| f.is_none()).count();
                    (labels, missing)
                }
            };
        (labels.width, labels.height) = (width, height);
        let slot_frame = &mut labels.frames[k];
        if slot_frame.is_none() {
            missing -= 1;
        }
        *slot_frame = Some(frame);
        self.clips[clip] = if missing == 0 {
            CollectedClip::Spooled {
                start,
                text: self.spool.write(&labels)?,
            }
        } else {
            CollectedClip::Open {
                start,
                labels,
                missing,
            }
        };
        Ok(())
    }

    /// Clips being filled, held in memory.
    #[cfg(test)]
    fn open_clips(&self) -> usize {
        self.clips
            .iter()
            .filter(|c| matches!(c, CollectedClip::Open { .. }))
            .count()
    }

    /// Each clip's labels, spooled: none for a clip without one labelled frame.
    ///
    /// # Errors
    /// [`TrimError::Io`] when the spool could not be written or read back.
    pub fn finish(mut self) -> Result<SpooledLabels, TrimError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        let mut texts = Vec::with_capacity(self.clips.len());
        for clip in std::mem::take(&mut self.clips) {
            texts.push(match clip {
                CollectedClip::Waiting { .. } => None,
                CollectedClip::Open { labels, .. } => labels
                    .frames
                    .iter()
                    .any(Option::is_some)
                    .then(|| self.spool.write(&labels))
                    .transpose()?,
                CollectedClip::Spooled { text, .. } => Some(text),
            });
        }
        Ok(SpooledLabels {
            spool: self.spool,
            texts,
        })
    }
}

/// A clip's sidecar text in the spool.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct SpoolRange {
    offset: u64,
    bytes: usize,
    /// The clip's frame count.
    frames: usize,
}

/// Sidecar texts, one after another, in an unnamed temporary file (deleted by the system when
/// closed, even if the process is killed).
#[derive(Debug)]
struct LabelSpool {
    file: std::fs::File,
    /// The folder the file is in, for errors.
    dir: PathBuf,
    end: u64,
}

impl LabelSpool {
    fn new(dir: &Path) -> Result<LabelSpool, TrimError> {
        let file = tempfile::tempfile_in(dir).map_err(TrimError::io(
            "make the pose labels' temporary file in",
            dir,
        ))?;
        Ok(LabelSpool {
            file,
            dir: dir.to_path_buf(),
            end: 0,
        })
    }

    fn write(&mut self, labels: &ClipLabels) -> Result<SpoolRange, TrimError> {
        use std::io::{Seek, SeekFrom};
        let text = sidecar_text(labels, &self.dir)?;
        let offset = self.end;
        (&self.file)
            .seek(SeekFrom::Start(offset))
            .and_then(|_| (&self.file).write_all(text.as_bytes()))
            .map_err(TrimError::io(
                "write the pose labels' temporary file in",
                &self.dir,
            ))?;
        self.end += text.len() as u64;
        Ok(SpoolRange {
            offset,
            bytes: text.len(),
            frames: labels.frames.len(),
        })
    }

    fn read_text(&self, at: SpoolRange) -> Result<Vec<u8>, TrimError> {
        use std::io::{Read, Seek, SeekFrom};
        let mut text = vec![0; at.bytes];
        (&self.file)
            .seek(SeekFrom::Start(at.offset))
            .and_then(|_| (&self.file).read_exact(&mut text))
            .map_err(TrimError::io(
                "read back the pose labels' temporary file in",
                &self.dir,
            ))?;
        Ok(text)
    }

    fn read(&self, at: SpoolRange) -> Result<ClipLabels, TrimError> {
        let text = self.read_text(at)?;
        serde_json::from_slice(&text).map_err(TrimError::json(&self.dir))
    }
}

/// Every clip's labels of one pass over a render bag, as their sidecars' text, read back one
/// clip at a time.
#[derive(Debug)]
pub struct SpooledLabels {
    spool: LabelSpool,
    texts: Vec<Option<SpoolRange>>,
}

impl SpooledLabels {
    /// The sidecar text of clip `clip`, `None` when it has no labelled frame.
    ///
    /// # Errors
    /// [`TrimError::Io`] when the spool cannot be read back.
    pub fn sidecar_text(&self, clip: usize) -> Result<Option<Vec<u8>>, TrimError> {
        self.texts
            .get(clip)
            .copied()
            .flatten()
            .map(|at| self.spool.read_text(at))
            .transpose()
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
    let text = sidecar_text(labels, &dir.join(rel))?;
    write_sidecar_text(dir, rel, text.as_bytes())
}

/// Writes a sidecar's text ([`sidecar_text`]) as the sidecar `rel` (relative to `dir`),
/// atomically.
///
/// # Errors
/// [`TrimError::Io`].
pub fn write_sidecar_text(dir: &Path, rel: &str, text: &[u8]) -> Result<(), TrimError> {
    let path = dir.join(rel);
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(TrimError::io("create", parent))?;
    }
    write_atomic(&path, text)
}

/// A sidecar file's text: `labels` as one line of JSON (`path` names it in an error).
fn sidecar_text(labels: &ClipLabels, path: &Path) -> Result<String, TrimError> {
    let text = serde_json::to_string(labels).map_err(TrimError::json(path))?;
    Ok(format!("{text}\n"))
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
/// Streamed: one clip's sidecar is held at a time, and beyond it only a few numbers per clip,
/// never per frame. A first pass reads every sidecar and writes both pickles; a second writes the COCO
/// files (their images from what the first pass kept of each clip, three numbers, then their
/// annotations from the sidecars read again). Every file is written under its `.part` and put
/// in place only once all five are complete, so a bad sidecar leaves the old files as they were.
///
/// # Errors
/// [`TrimError`] for a sidecar that cannot be read or a file that cannot be written.
pub fn write_label_files(
    dir: &Path,
    clips: &BTreeMap<String, ClipRecord>,
    splits: &Assignment,
) -> Result<Option<LabelSummary>, TrimError> {
    let ann = dir.join(ANNOTATIONS_DIR);
    let labelled = labelled_clips(clips, splits);
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
    let (pickles, sizes) = write_skeleton_pickles(dir, &labelled, [&files[0], &files[1]])?;
    let coco = write_coco_files(dir, &labelled, &sizes, &files[2..])?;
    for file in pickles.into_iter().chain(coco) {
        let path = file.target().to_path_buf();
        file.commit().map_err(TrimError::io("write", &path))?;
    }
    Ok(Some(LabelSummary {
        clips: labelled.len(),
        without: clips.len() - labelled.len(),
        files,
    }))
}

/// A clip with labels: its record, its split and its sidecar (relative to the dataset folder).
#[derive(Debug, Clone, Copy)]
struct Labelled<'a> {
    clip: &'a ClipRecord,
    split: Split,
    sidecar: &'a str,
}

/// The clips of `clips` with a sidecar and a split, in the map's order.
fn labelled_clips<'a>(
    clips: &'a BTreeMap<String, ClipRecord>,
    splits: &Assignment,
) -> Vec<Labelled<'a>> {
    clips
        .values()
        .filter_map(|c| {
            Some(Labelled {
                clip: c,
                split: *splits.splits.get(&c.clip_id)?,
                sidecar: c.labels.as_deref()?,
            })
        })
        .collect()
}

/// What the COCO images of a clip need of its sidecar.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct ClipSize {
    frames: usize,
    width: u32,
    height: u32,
}

/// Starts writing `path` through its `.part` ([`StreamedFile`]).
fn create_streamed(path: &Path) -> Result<StreamedFile, TrimError> {
    StreamedFile::create(path).map_err(TrimError::io("write", path))
}

/// Writes both skeleton pickles in one pass over the sidecars of `labelled`, which reads and
/// checks every one of them. The files are complete but not yet in place; with each clip's
/// size.
fn write_skeleton_pickles(
    dir: &Path,
    labelled: &[Labelled<'_>],
    paths: [&Path; 2],
) -> Result<(Vec<StreamedFile>, Vec<ClipSize>), TrimError> {
    let which = [Skeleton::Coco2d, Skeleton::Ntu3d];
    let head = [(Py::str("split"), split_dict(labelled))];
    let mut pickles = Vec::with_capacity(2);
    for path in paths {
        let file = create_streamed(path)?;
        let p = DictEndingInList::open(file, &head, &Py::str("annotations"))
            .map_err(TrimError::io("write", path))?;
        pickles.push(p);
    }
    let mut sizes = Vec::with_capacity(labelled.len());
    for l in labelled {
        let labels = read_sidecar(dir, l.sidecar)?;
        for ((p, which), path) in pickles.iter_mut().zip(which).zip(paths) {
            p.push(&skeleton_annotation(l.clip, &labels, which))
                .map_err(TrimError::io("write", path))?;
        }
        sizes.push(ClipSize {
            frames: labels.frames.len(),
            width: labels.width,
            height: labels.height,
        });
    }
    let files = pickles
        .into_iter()
        .zip(paths)
        .map(|(p, path)| p.finish().map_err(TrimError::io("write", path)))
        .collect::<Result<_, _>>()?;
    Ok((files, sizes))
}

/// Which skeleton file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Skeleton {
    /// COCO-17, pixels, `C = 2`.
    Coco2d,
    /// NTU-25, metres, `C = 3`.
    Ntu3d,
}

/// The `split` entry of the MMAction2/PYSKL annotation dict: every split, possibly empty, with
/// its clip ids. The dict's other entry, `annotations`, is one dict per clip
/// ([`skeleton_annotation`]).
fn split_dict(labelled: &[Labelled<'_>]) -> Py {
    let split = Split::ALL
        .into_iter()
        .map(|s| {
            let ids = labelled
                .iter()
                .filter(|l| l.split == s)
                .map(|l| Py::str(&l.clip.clip_id))
                .collect();
            (Py::str(s.name()), Py::List(ids))
        })
        .collect();
    Py::Dict(split)
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

/// The COCO document's description.
const COCO_DESCRIPTION: &str = "autoact: rendered frames with their rendering's exact labels";

/// One COCO image: a frame of a clip (`file_name` as `--rawframes` names it). Its fields are in
/// the order the files have always had them.
#[derive(Debug, Serialize)]
struct CocoImage<'a> {
    id: u64,
    file_name: String,
    width: u32,
    height: u32,
    clip_id: &'a str,
    frame_index: usize,
    video: &'a str,
    label_id: u32,
}

/// One COCO annotation: a frame that shows the character.
#[derive(Debug, Serialize)]
struct CocoAnnotation {
    id: u64,
    image_id: u64,
    category_id: u32,
    iscrowd: u32,
    keypoints: Vec<f64>,
    num_keypoints: u32,
    bbox: [u32; 4],
    area: u32,
}

impl CocoAnnotation {
    /// Frame `f`'s annotation as image `image_id`; `None` when the character is unseen. Hidden
    /// and out-of-image points are `0, 0, 0`, as COCO has unlabelled ones.
    fn new(image_id: u64, f: &FrameLabels) -> Option<CocoAnnotation> {
        let [x, y, w, h] = f.bbox?;
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
        Some(CocoAnnotation {
            id: image_id,
            image_id,
            category_id: 1,
            iscrowd: 0,
            keypoints,
            num_keypoints: shown,
            bbox: [x, y, w, h],
            area: f.area,
        })
    }
}

/// One split's COCO file being written: an image per frame, an annotation per frame that shows
/// the character, as one JSON line.
struct CocoWriter {
    file: StreamedFile,
    /// The last image id given (ids count the split's frames from 1).
    image_id: u64,
    /// Whether the array being written has an element yet.
    any: bool,
}

impl CocoWriter {
    /// Starts the document: its description, then the images array.
    fn open(path: &Path) -> Result<CocoWriter, TrimError> {
        let mut w = CocoWriter {
            file: create_streamed(path)?,
            image_id: 0,
            any: false,
        };
        w.raw(b"{\"info\":")?;
        w.json(&serde_json::json!({ "description": COCO_DESCRIPTION }))?;
        w.raw(b",\"images\":[")?;
        Ok(w)
    }

    fn raw(&mut self, bytes: &[u8]) -> Result<(), TrimError> {
        self.file
            .write_all(bytes)
            .map_err(TrimError::io("write", self.file.target()))
    }

    fn json(&mut self, value: &impl Serialize) -> Result<(), TrimError> {
        serde_json::to_writer(&mut self.file, value).map_err(TrimError::json(self.file.target()))
    }

    /// One element of the array being written.
    fn element(&mut self, value: &impl Serialize) -> Result<(), TrimError> {
        if std::mem::replace(&mut self.any, true) {
            self.raw(b",")?;
        }
        self.json(value)
    }

    /// Ends the images array and starts the annotations; image ids count again from 1.
    fn start_annotations(&mut self) -> Result<(), TrimError> {
        (self.image_id, self.any) = (0, false);
        self.raw(b"],\"annotations\":[")
    }

    /// Ends the annotations array with the person category; the file, complete, to commit.
    fn finish(mut self) -> Result<StreamedFile, TrimError> {
        self.raw(b"],\"categories\":")?;
        let names = Layout::builtin("coco-17")
            .map(|l| l.joints)
            .unwrap_or_default();
        self.json(&serde_json::json!([{
            "id": 1,
            "name": "person",
            "supercategory": "person",
            "keypoints": names,
            "skeleton": COCO_SKELETON,
        }]))?;
        self.raw(b"}\n")?;
        Ok(self.file)
    }
}

/// Writes the COCO keypoint file of every split (`paths`, in [`Split::ALL`]'s order): the
/// images of every file from `sizes`, then the annotations in one more pass over the sidecars.
/// The files are complete but not yet in place.
fn write_coco_files(
    dir: &Path,
    labelled: &[Labelled<'_>],
    sizes: &[ClipSize],
    paths: &[PathBuf],
) -> Result<Vec<StreamedFile>, TrimError> {
    let mut writers = paths
        .iter()
        .map(|p| CocoWriter::open(p))
        .collect::<Result<Vec<_>, _>>()?;
    let writer_of = |split: Split| Split::ALL.iter().position(|s| *s == split).unwrap_or(0);
    for (l, size) in labelled.iter().zip(sizes) {
        let w = &mut writers[writer_of(l.split)];
        for k in 0..size.frames {
            w.image_id += 1;
            let c = l.clip;
            w.element(&CocoImage {
                id: w.image_id,
                file_name: format!(
                    "{}/{}/{}/img_{:05}.jpg",
                    super::run::RAWFRAMES_DIR,
                    c.label_dir,
                    c.clip_id,
                    k + 1
                ),
                width: size.width,
                height: size.height,
                clip_id: &c.clip_id,
                frame_index: k,
                video: &c.video,
                label_id: c.label_id,
            })?;
        }
    }
    for w in &mut writers {
        w.start_annotations()?;
    }
    for (l, size) in labelled.iter().zip(sizes) {
        let labels = read_sidecar(dir, l.sidecar)?;
        // The images were numbered from the first reading: a sidecar rewritten since would
        // give annotations that point at the wrong images.
        if labels.frames.len() != size.frames {
            return Err(TrimError::LabelsChanged {
                path: dir.join(l.sidecar),
                frames: size.frames,
                now: labels.frames.len(),
            });
        }
        let w = &mut writers[writer_of(l.split)];
        for f in &labels.frames {
            w.image_id += 1;
            if let Some(a) = f.as_ref().and_then(|f| CocoAnnotation::new(w.image_id, f)) {
                w.element(&a)?;
            }
        }
    }
    writers.into_iter().map(CocoWriter::finish).collect()
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::{
        ClipLabels, ClipSize, FrameLabels, LabelCollector, Skeleton, SpooledLabels, TrimError,
        coco_file, labelled_clips, layout_landmarks, read_sidecar, sidecar_path,
        skeleton_annotation, split_dict, write_coco_files, write_label_files, write_sidecar,
    };
    use crate::ros::autoact_msgs::FrameAnnotation;
    use crate::ros::geometry_msgs::Point;
    use crate::skeleton::layout::Layout;
    use crate::skeleton::rig::Rig;
    use crate::trim::ClipRecord;
    use crate::trim::pickle::{Py, to_bytes};
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

    /// Clip `clip`'s labels as `finish` hands them on: the sidecar text, parsed.
    fn spooled(out: &SpooledLabels, clip: usize) -> Option<ClipLabels> {
        out.sidecar_text(clip)
            .unwrap()
            .map(|t| serde_json::from_slice(&t).unwrap())
    }

    #[test]
    fn collected_labels_are_the_layouts_landmarks_in_kinect_space() {
        let rig = Rig::standard();
        let dir = tempfile::tempdir().unwrap();
        let mut c = LabelCollector::new([(10, 3), (20, 2)], dir.path()).unwrap();
        c.push(0, &frame(11), [320, 240]);
        c.push(1, &frame(25), [320, 240]); // past the clip: left out
        let mut old = frame(12);
        old.landmark_names.clear();
        c.push(0, &old, [320, 240]);
        assert_eq!(c.without_landmarks, 1);
        let out = c.finish().unwrap();
        assert!(
            spooled(&out, 1).is_none(),
            "no frame of clip 1 was labelled"
        );
        let l = spooled(&out, 0).unwrap();
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
        // What the cut writes is the sidecar `write_sidecar` makes of the same labels.
        write_sidecar(dir.path(), "a.json", &l).unwrap();
        assert_eq!(
            std::fs::read(dir.path().join("a.json")).unwrap(),
            out.sidecar_text(0).unwrap().unwrap()
        );
        // The spool is an unnamed file: nothing is left in the dataset folder.
        drop(out);
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "only a.json"
        );
    }

    #[test]
    fn a_clip_leaves_memory_when_its_last_frame_is_in_and_a_frame_given_again_still_wins() {
        let dir = tempfile::tempdir().unwrap();
        // Overlapping windows, as `windows` with a stride shorter than the window cuts them.
        let mut c = LabelCollector::new([(0, 4), (2, 4), (4, 4)], dir.path()).unwrap();
        for k in 0..4 {
            c.push(0, &frame(k), [320, 240]);
            if k >= 2 {
                c.push(1, &frame(k), [320, 240]);
            }
        }
        assert_eq!(
            c.open_clips(),
            1,
            "clip 0 is complete and spooled; clip 1 is open"
        );
        for k in 4..8 {
            if k < 6 {
                c.push(1, &frame(k), [320, 240]);
            }
            c.push(2, &frame(k), [320, 240]);
        }
        assert_eq!(
            c.open_clips(),
            0,
            "every clip complete: none held in memory"
        );
        // Frame 1 of clip 0 again, from another image size and with another box: read back,
        // replaced, spooled again (the last annotation of a frame wins, as before spooling).
        let mut again = frame(1);
        again.silhouette_pixels = 77;
        c.push(0, &again, [640, 480]);
        assert_eq!(c.open_clips(), 0);
        let out = c.finish().unwrap();
        let first = spooled(&out, 0).unwrap();
        assert_eq!((first.width, first.height), (640, 480));
        assert_eq!(first.frames[1].as_ref().unwrap().area, 77);
        assert_eq!(first.frames[0].as_ref().unwrap().area, 10);
        for clip in 1..3 {
            let l = spooled(&out, clip).unwrap();
            assert!(l.frames.iter().all(Option::is_some), "clip {clip}");
            assert_eq!((l.width, l.height), (320, 240));
        }
    }

    #[test]
    fn a_dataset_folder_the_spool_cannot_be_made_in_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("not-there");
        let e = LabelCollector::new([(0, 1)], &missing).unwrap_err();
        assert!(
            matches!(&e, TrimError::Io { path, .. } if *path == missing),
            "{e}"
        );
        assert!(e.to_string().contains("not-there"), "{e}");
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

    /// Three clips, one per split: `a` (train) of two frames, the first seen with its odd
    /// points hidden and the second unlabelled; `b` (val) of one frame with the character unseen;
    /// `c` (test) of one seen frame. Written as sidecars into `dir`.
    fn three_clips(dir: &std::path::Path) -> (BTreeMap<String, ClipRecord>, Assignment) {
        let seen = FrameLabels {
            coco17: (0..17)
                .flat_map(|i| {
                    [
                        i as f32 + 0.25,
                        2.0 * i as f32,
                        if i % 2 == 0 { 2.0 } else { 0.0 },
                    ]
                })
                .collect(),
            ntu25: (0..75).map(|i| i as f32 * 0.01).collect(),
            bbox: Some([1, 2, 30, 40]),
            area: 900,
        };
        let unseen = FrameLabels {
            bbox: None,
            area: 0,
            ..seen.clone()
        };
        let sidecars = [
            ("a", Split::Train, vec![Some(seen.clone()), None]),
            ("b", Split::Val, vec![Some(unseen)]),
            ("c", Split::Test, vec![Some(seen)]),
        ];
        let (mut clips, mut splits) = (BTreeMap::new(), Assignment::default());
        for (id, split, frames) in sidecars {
            let mut r = record(id, "wave", id, "CLEAR");
            let rel = sidecar_path("wave", id);
            let labels = ClipLabels {
                width: 320,
                height: 240,
                frames,
            };
            write_sidecar(dir, &rel, &labels).unwrap();
            r.labels = Some(rel);
            clips.insert(id.to_owned(), r);
            splits.splits.insert(id.to_owned(), split);
        }
        (clips, splits)
    }

    #[test]
    fn the_streamed_pickles_are_the_whole_dicts_pickled() {
        let dir = tempfile::tempdir().unwrap();
        let (clips, splits) = three_clips(dir.path());
        write_label_files(dir.path(), &clips, &splits).unwrap();
        let labelled = labelled_clips(&clips, &splits);
        assert_eq!(labelled.len(), clips.len(), "every clip is labelled");
        for (file, which) in [
            (super::SKELETON_2D_FILE, Skeleton::Coco2d),
            (super::SKELETON_3D_FILE, Skeleton::Ntu3d),
        ] {
            let annotations = labelled
                .iter()
                .map(|l| {
                    let labels = read_sidecar(dir.path(), l.sidecar).unwrap();
                    skeleton_annotation(l.clip, &labels, which)
                })
                .collect();
            let whole = Py::Dict(vec![
                (Py::str("split"), split_dict(&labelled)),
                (Py::str("annotations"), Py::List(annotations)),
            ]);
            let written = std::fs::read(dir.path().join("annotations").join(file)).unwrap();
            assert_eq!(written, to_bytes(&whole), "{file}");
        }
    }

    #[test]
    fn the_streamed_coco_file_is_serde_jsons_document_key_for_key() {
        let dir = tempfile::tempdir().unwrap();
        let (clips, splits) = three_clips(dir.path());
        write_label_files(dir.path(), &clips, &splits).unwrap();
        let read = |split| {
            let path = dir.path().join("annotations").join(coco_file(split));
            std::fs::read_to_string(path).unwrap()
        };
        let image = |id: u64, clip: &str, k: usize| {
            serde_json::json!({
                "id": id,
                "file_name": format!("rawframes/wave/{clip}/img_{:05}.jpg", k + 1),
                "width": 320, "height": 240, "clip_id": clip, "frame_index": k,
                "video": format!("videos/wave/{clip}.mp4"), "label_id": 0,
            })
        };
        // Even points shown (v = 2), odd ones hidden: written as 0, 0, 0.
        let keypoints: Vec<f64> = (0..17)
            .flat_map(|i| {
                if i % 2 == 0 {
                    [f64::from(i as f32 + 0.25), 2.0 * f64::from(i), 2.0]
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        let annotation = serde_json::json!({
            "id": 1, "image_id": 1, "category_id": 1, "iscrowd": 0, "keypoints": keypoints,
            "num_keypoints": 9, "bbox": [1, 2, 30, 40], "area": 900,
        });
        let document = |images: Vec<serde_json::Value>, annotations: Vec<serde_json::Value>| {
            let names = Layout::builtin("coco-17").unwrap().joints;
            let doc = serde_json::json!({
                "info": {"description": "autoact: rendered frames with their rendering's exact labels"},
                "images": images,
                "annotations": annotations,
                "categories": [{"id": 1, "name": "person", "supercategory": "person",
                    "keypoints": names, "skeleton": super::COCO_SKELETON}],
            });
            format!("{}\n", serde_json::to_string(&doc).unwrap())
        };
        let train = document(
            vec![image(1, "a", 0), image(2, "a", 1)],
            vec![annotation.clone()],
        );
        assert_eq!(read(Split::Train), train);
        assert_eq!(read(Split::Val), document(vec![image(1, "b", 0)], vec![]));
        assert_eq!(
            read(Split::Test),
            document(vec![image(1, "c", 0)], vec![annotation])
        );
    }

    #[test]
    fn a_bad_sidecar_stops_the_export_and_leaves_every_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let (clips, splits) = three_clips(dir.path());
        write_label_files(dir.path(), &clips, &splits).unwrap();
        let ann = dir.path().join("annotations");
        let before = |dir: &std::path::Path| {
            let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
                .unwrap()
                .map(|e| {
                    let e = e.unwrap();
                    let name = e.file_name().to_string_lossy().into_owned();
                    (name, std::fs::read(e.path()).unwrap())
                })
                .collect();
            files.sort();
            files
        };
        let old = before(&ann);
        assert_eq!(
            old.len(),
            5,
            "{:?}",
            old.iter().map(|f| &f.0).collect::<Vec<_>>()
        );
        // The last clip's sidecar goes bad: both pickles are half written when it is read.
        let last = dir.path().join(clips["c"].labels.as_deref().unwrap());
        std::fs::write(&last, b"{\"width\": 1").unwrap();
        let e = write_label_files(dir.path(), &clips, &splits).unwrap_err();
        assert!(e.to_string().contains("c.json"), "{e}");
        assert_eq!(before(&ann), old, "the old files, and no .part beside them");
    }

    /// The COCO images are numbered from the first reading of the sidecars: one that has other
    /// frames when read again for the annotations is refused, naming it, with no file left.
    #[test]
    fn a_sidecar_changed_between_the_passes_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let (clips, splits) = three_clips(dir.path());
        let labelled = labelled_clips(&clips, &splits);
        assert_eq!(labelled.len(), clips.len(), "every clip is labelled");
        // As the first pass saw them, but clip `a` had 3 frames then (it has 2 on disk).
        let sizes: Vec<ClipSize> = [3, 1, 1]
            .into_iter()
            .map(|frames| ClipSize {
                frames,
                width: 320,
                height: 240,
            })
            .collect();
        let ann = dir.path().join("annotations");
        std::fs::create_dir_all(&ann).unwrap();
        let paths: Vec<std::path::PathBuf> = crate::trim::split::Split::ALL
            .into_iter()
            .map(|s| ann.join(coco_file(s)))
            .collect();
        let Err(e) = write_coco_files(dir.path(), &labelled, &sizes, &paths) else {
            panic!("a changed sidecar was not noticed");
        };
        assert!(e.to_string().contains("a.json"), "{e}");
        assert!(e.to_string().contains("3 frames, 2 when read again"), "{e}");
        assert_eq!(std::fs::read_dir(&ann).unwrap().count(), 0, "no .part left");
    }
}
