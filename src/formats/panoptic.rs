//! Reader for the 3D bodies of the CMU Panoptic Studio dataset (Joo et al.): the
//! `body3DScene_<frame>.json` files of a sequence's `hdPose3d_stage1_coco19/` folder, one file
//! per frame, every person in the dome in each.
//!
//! # Format
//!
//! ```json
//! { "version": 0.7, "univTime": 47896.621, "fpsType": "hd_29_97",
//!   "bodies": [ { "id": 0, "joints19": [x, y, z, score, x, y, z, score, ...] } ] }
//! ```
//!
//! * `bodies`: the people reconstructed in this frame (`[]` for none). `id` is the person's
//!   identity through the sequence (a non-negative integer): each id is one track.
//! * `joints19`: 19 × (x, y, z, score), in the order of layout `panoptic-coco19`
//!   ([`JOINT_NAMES`]). A joint that was not reconstructed has score −1 (and coordinates 0).
//!   Bodies of the older MPI-15 reconstruction (`joints15` only) are refused by name.
//! * `fpsType`: `hd_29_97` (the HD cameras, 30000/1001 fps), `vga_25` or `kinect_30`. A file
//!   without it, or with another, needs `--fps`.
//! * Other keys (`version`, `univTime`) are read past.
//!
//! # Units, axes, time
//!
//! Centimetres in the dome's world frame: +Y **down**, the floor at about y = 0 ([`AXES`] =
//! [`SourceAxes::YDown`], [`METRES_PER_UNIT`]). It is a world frame with a real floor, like
//! motion capture, so import does not re-ground it and keeps the people where they stood
//! relative to each other. A frame is stamped by the number in its file name, so missing files
//! are gaps in time: `(frame − first frame) / fps`.
//!
//! # Scores
//!
//! Panoptic's score is the reconstruction's, not a detector's: its own tools (and MMPose's and
//! VoxelPose's loaders) count a joint as reconstructed when it exceeds [`VALID_SCORE`] (0.1).
//! The score is mapped to autoact's confidence piecewise linearly and in order, so that 0.1
//! lands on `convert`'s default `--min-confidence` (0.3) and 1 on 1: `convert` keeps exactly the
//! joints Panoptic's tools keep, and a higher `--min-confidence` keeps the better-reconstructed
//! ones. Score −1 (or any negative score, or a coordinate that is not finite) is a missing joint.
//!
//! # Input
//!
//! A single file, or a folder: every `<prefix>body3DScene_<frame>.json` in it (not in its
//! sub-folders), in frame order. A folder holding files of two sequences (two prefixes, as when
//! several sequences' files are renamed into one place) is refused: their frame numbers and body
//! ids would collide.
//!
//! # Errors
//!
//! [`read`] and [`parse`] never panic; every problem is a [`PanopticError`] naming the file and
//! the place: the JSON parser's line and column, or the body (its index and id) and what is
//! wrong with it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use thiserror::Error;

use crate::skeleton::frames::SourceAxes;
use crate::skeleton::pose::{PoseFrame, PoseSequence, stamp_nanos_at};

/// The layout of the files' joints.
pub const LAYOUT: &str = "panoptic-coco19";

/// Number of joints per body.
pub const JOINT_COUNT: usize = 19;

/// The joints of layout `panoptic-coco19`, in the files' order (Panoptic's toolbox names).
pub const JOINT_NAMES: [&str; JOINT_COUNT] = [
    "Neck",
    "Nose",
    "BodyCenter",
    "lShoulder",
    "lElbow",
    "lWrist",
    "lHip",
    "lKnee",
    "lAnkle",
    "rShoulder",
    "rElbow",
    "rWrist",
    "rHip",
    "rKnee",
    "rAnkle",
    "lEye",
    "lEar",
    "rEye",
    "rEar",
];

/// Axis convention of the dome's world frame.
pub const AXES: SourceAxes = SourceAxes::YDown;

/// The files are in centimetres.
pub const METRES_PER_UNIT: f64 = 0.01;

/// The score above which Panoptic's own tools count a joint as reconstructed.
pub const VALID_SCORE: f32 = 0.1;

/// What a scene file's name holds between its prefix and its frame number.
const SCENE_STEM: &str = "body3DScene_";

/// Everything that can go wrong reading Panoptic bodies.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum PanopticError {
    /// A file or the folder could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// A file is not JSON of the scene's form (the message has the line and column).
    #[error("{file}: {source}")]
    Json {
        /// The file.
        file: String,
        /// What the JSON parser said.
        #[source]
        source: serde_json::Error,
    },
    /// A body that cannot be read.
    #[error("{file}: bodies[{index}] (id {id}): {problem}")]
    Body {
        /// The file.
        file: String,
        /// The body's index in `bodies`.
        index: usize,
        /// Its `id` as written.
        id: String,
        /// What is wrong.
        problem: String,
    },
    /// A folder without scene files.
    #[error(
        "{}: holds no CMU Panoptic scene files (<prefix>body3DScene_<frame>.json), the only folders `import` reads (a rosbag2 folder is a bag already: give it to `convert`)",
        folder.display()
    )]
    NoSceneFiles {
        /// The folder.
        folder: PathBuf,
    },
    /// A folder holding the files of more than one sequence.
    #[error(
        "{}: holds the files of {count} sequences ({examples}); put each in a folder of its own",
        folder.display()
    )]
    MixedSequences {
        /// The folder.
        folder: PathBuf,
        /// How many prefixes.
        count: usize,
        /// Up to three of them, quoted.
        examples: String,
    },
    /// Two files of one sequence state different rates.
    #[error("{file}: fpsType `{found}`, but {first_file} says `{first}`")]
    MixedRates {
        /// The file.
        file: String,
        /// Its `fpsType`.
        found: String,
        /// The first file with an `fpsType`.
        first_file: String,
        /// Its `fpsType`.
        first: String,
    },
}

/// One frame of a sequence: its number and its bodies as stored (per body: its id, and per joint
/// x, y, z in centimetres in the dome's frame and the score).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneFrame {
    /// The frame number (from the file name; 0 for a single file named otherwise).
    pub frame: u64,
    /// Per body: its id and its joints.
    pub bodies: Vec<(u64, [[f64; 4]; JOINT_COUNT])>,
}

/// A Panoptic sequence (or a single frame of one).
#[derive(Debug, Clone, PartialEq)]
pub struct PanopticClip {
    source: String,
    /// The `fpsType` the files state, if any.
    fps_type: Option<String>,
    /// In frame order.
    frames: Vec<SceneFrame>,
}

impl PanopticClip {
    /// The frames, in frame order, as stored.
    #[must_use]
    pub fn frames(&self) -> &[SceneFrame] {
        &self.frames
    }

    /// The `fpsType` the files state, if any.
    #[must_use]
    pub fn fps_type(&self) -> Option<&str> {
        self.fps_type.as_deref()
    }

    /// The frame rate the files state (`fpsType`), if it is one this reader knows.
    #[must_use]
    pub fn fps(&self) -> Option<f64> {
        match self.fps_type.as_deref()? {
            "hd_29_97" => Some(30_000.0 / 1001.0),
            "vga_25" => Some(25.0),
            "kinect_30" => Some(30.0),
            _ => None,
        }
    }

    /// One [`PoseSequence`] per body id (ascending) in the autoact frame, metres, layout
    /// `panoptic-coco19`, stamped `(frame − first frame) / fps`; a track has frames only where
    /// its body was reconstructed.
    #[must_use]
    pub fn to_pose_sequences(&self, fps: f64) -> Vec<PoseSequence> {
        let first = self.frames.first().map_or(0, |f| f.frame);
        let mut tracks: BTreeMap<u64, PoseSequence> = BTreeMap::new();
        for scene in &self.frames {
            let offset = usize::try_from(scene.frame - first).unwrap_or(usize::MAX);
            let stamp = stamp_nanos_at(offset, fps);
            for (id, joints) in &scene.bodies {
                let seq = tracks.entry(*id).or_insert_with(|| PoseSequence {
                    source: self.source.clone(),
                    track_id: *id,
                    joint_names: JOINT_NAMES.iter().map(|n| (*n).to_owned()).collect(),
                    frames: Vec::new(),
                });
                seq.frames.push(pose_frame(stamp, joints));
            }
        }
        tracks.into_values().collect()
    }
}

/// One body's joints as a frame: metres, autoact axes (through
/// [`PoseFrame::from_source_points`]), scores as confidences; a negative score is missing.
fn pose_frame(stamp_nanos: u64, joints: &[[f64; 4]; JOINT_COUNT]) -> PoseFrame {
    let points_m = joints.map(|[x, y, z, score]| {
        if score >= 0.0 {
            [x, y, z].map(|c| c * METRES_PER_UNIT)
        } else {
            [f64::NAN; 3]
        }
    });
    let mut frame = PoseFrame::from_source_points(stamp_nanos, &points_m, AXES);
    for (c, [.., score]) in frame.confidence.iter_mut().zip(joints) {
        if *c > 0.0 {
            #[expect(
                clippy::cast_possible_truncation,
                reason = "a score in f32 is as fine as it is used"
            )]
            let score = *score as f32;
            *c = confidence(score);
        }
    }
    frame
}

/// autoact's confidence for a Panoptic score ≥ 0: piecewise linear and increasing, [0,
/// [`VALID_SCORE`]] onto [0, m] and [[`VALID_SCORE`], 1] onto [m, 1], where m is `convert`'s
/// default minimum confidence; clamped to [0, 1].
#[must_use]
pub fn confidence(score: f32) -> f32 {
    let m = crate::skeleton::convert::ConvertOptions::default().min_confidence;
    let c = if score < VALID_SCORE {
        m * score / VALID_SCORE
    } else {
        m + (1.0 - m) * (score - VALID_SCORE) / (1.0 - VALID_SCORE)
    };
    c.clamp(0.0, 1.0)
}

/// Whether the start of a JSON file looks like a Panoptic scene (an object with `"bodies"`
/// early in it) rather than MMPose's list of frames: how `import` tells the two apart.
#[must_use]
pub fn looks_like_scene(head: &[u8]) -> bool {
    let starts_object = head
        .iter()
        .find(|b| !b.is_ascii_whitespace())
        .is_some_and(|b| *b == b'{');
    starts_object && head.windows(8).any(|w| w == b"\"bodies\"")
}

/// Whether `folder` holds any scene file (how `import` tells a Panoptic folder).
#[must_use]
pub fn folder_holds_scenes(folder: &Path) -> bool {
    scene_files(folder).is_ok_and(|files| !files.is_empty())
}

/// `(prefix, frame)` of a scene file name, `<prefix>body3DScene_<digits>.json`.
fn scene_name(name: &str) -> Option<(&str, u64)> {
    let stem = name.strip_suffix(".json")?;
    let at = stem.rfind(SCENE_STEM)?;
    let digits = &stem[at + SCENE_STEM.len()..];
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some((&stem[..at], digits.parse().ok()?))
}

/// The scene files directly in `folder`: (prefix, frame, path).
fn scene_files(folder: &Path) -> Result<Vec<(String, u64, PathBuf)>, PanopticError> {
    let io = |source| PanopticError::Io {
        path: folder.to_path_buf(),
        source,
    };
    let mut files = Vec::new();
    for entry in std::fs::read_dir(folder).map_err(io)? {
        let entry = entry.map_err(io)?;
        let name = entry.file_name();
        let Some((prefix, frame)) = name.to_str().and_then(scene_name) else {
            continue;
        };
        if entry.path().is_file() {
            files.push((prefix.to_owned(), frame, entry.path()));
        }
    }
    Ok(files)
}

/// Reads a scene file, or every scene file of a folder (see the module docs).
///
/// # Errors
/// A [`PanopticError`] naming the file (or folder) and the place.
pub fn read(path: impl AsRef<Path>) -> Result<PanopticClip, PanopticError> {
    let path = path.as_ref();
    let source = path.display().to_string();
    let files = if path.is_dir() {
        let mut files = scene_files(path)?;
        let prefixes: std::collections::BTreeSet<&str> =
            files.iter().map(|(p, _, _)| p.as_str()).collect();
        if prefixes.len() > 1 {
            return Err(PanopticError::MixedSequences {
                folder: path.to_path_buf(),
                count: prefixes.len(),
                examples: prefixes
                    .iter()
                    .take(3)
                    .map(|p| format!("`{p}body3DScene_*`"))
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        if files.is_empty() {
            return Err(PanopticError::NoSceneFiles {
                folder: path.to_path_buf(),
            });
        }
        files.sort_by_key(|(_, frame, _)| *frame);
        files.into_iter().map(|(_, f, p)| (f, p)).collect()
    } else {
        let frame = path
            .file_name()
            .and_then(|n| n.to_str())
            .and_then(scene_name)
            .map_or(0, |(_, f)| f);
        vec![(frame, path.to_path_buf())]
    };
    let mut frames = Vec::with_capacity(files.len());
    // The rate the first file that states one states, and that file, for the error when
    // another differs.
    let mut rate: Option<(String, String)> = None;
    for (frame, file) in files {
        let text = std::fs::read(&file).map_err(|source| PanopticError::Io {
            path: file.clone(),
            source,
        })?;
        let name = file.display().to_string();
        let (bodies, fps_type) = parse(&text, &name)?;
        match (fps_type, &rate) {
            (Some(found), Some((first, first_file))) if found != *first => {
                return Err(PanopticError::MixedRates {
                    file: name,
                    found,
                    first_file: first_file.clone(),
                    first: first.clone(),
                });
            }
            (Some(found), None) => rate = Some((found, name)),
            _ => {}
        }
        frames.push(SceneFrame { frame, bodies });
    }
    Ok(PanopticClip {
        source,
        fps_type: rate.map(|(fps_type, _)| fps_type),
        frames,
    })
}

/// One scene file as written.
#[derive(Deserialize)]
struct SceneJson {
    #[serde(rename = "fpsType", default)]
    fps_type: Option<String>,
    bodies: Vec<BodyJson>,
}

/// One body as written.
#[derive(Deserialize)]
struct BodyJson {
    id: serde_json::Value,
    #[serde(default)]
    joints19: Option<Vec<f64>>,
    #[serde(default)]
    joints15: Option<serde::de::IgnoredAny>,
}

/// Parses one scene file's bytes; `file` names it in errors. Returns its bodies (id and joints
/// as stored) and its `fpsType`.
///
/// # Errors
/// [`PanopticError::Json`] for bytes that are not a scene object, [`PanopticError::Body`] for a
/// body without a non-negative integer id or without 19 joints of 4 numbers, or an id twice.
#[allow(clippy::type_complexity)]
pub fn parse(
    bytes: &[u8],
    file: &str,
) -> Result<(Vec<(u64, [[f64; 4]; JOINT_COUNT])>, Option<String>), PanopticError> {
    let scene: SceneJson = serde_json::from_slice(bytes).map_err(|source| PanopticError::Json {
        file: file.to_owned(),
        source,
    })?;
    let mut bodies: Vec<(u64, [[f64; 4]; JOINT_COUNT])> = Vec::with_capacity(scene.bodies.len());
    for (index, body) in scene.bodies.into_iter().enumerate() {
        let bad = |problem: String| PanopticError::Body {
            file: file.to_owned(),
            index,
            id: body.id.to_string(),
            problem,
        };
        let Some(id) = body.id.as_u64() else {
            return Err(bad("the id is not a non-negative integer".to_owned()));
        };
        if bodies.iter().any(|(seen, _)| *seen == id) {
            return Err(bad("a second body with this id".to_owned()));
        }
        let values = match (&body.joints19, &body.joints15) {
            (Some(values), _) => values,
            (None, Some(_)) => {
                return Err(bad(
                    "only `joints15` (the older MPI-15 reconstruction): autoact reads `joints19` (hdPose3d_stage1_coco19)"
                        .to_owned(),
                ));
            }
            (None, None) => return Err(bad("no `joints19`".to_owned())),
        };
        if values.len() != 4 * JOINT_COUNT {
            return Err(bad(format!(
                "`joints19` has {} numbers, expected {} (19 × x, y, z, score)",
                values.len(),
                4 * JOINT_COUNT
            )));
        }
        let joints = std::array::from_fn(|j| std::array::from_fn(|k| values[4 * j + k]));
        bodies.push((id, joints));
    }
    Ok((bodies, scene.fps_type))
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;
    use proptest::prelude::*;

    use super::*;

    /// A scene file's text: `bodies` as (id, 19 × [x, y, z, score]).
    fn scene_text(fps_type: Option<&str>, bodies: &[(u64, [[f64; 4]; 19])]) -> String {
        let bodies: Vec<String> = bodies
            .iter()
            .map(|(id, joints)| {
                let values: Vec<String> = joints.iter().flatten().map(|v| format!("{v}")).collect();
                format!("{{ \"id\": {id}, \"joints19\": [{}] }}", values.join(", "))
            })
            .collect();
        let rate = fps_type.map_or(String::new(), |r| format!("\"fpsType\": \"{r}\",\n"));
        format!(
            "{{ \"version\": 0.7,\n\"univTime\": 1000.5,\n{rate}\"bodies\": [\n{}\n] }}",
            bodies.join(",\n")
        )
    }

    fn joints(offset_cm: f64) -> [[f64; 4]; 19] {
        std::array::from_fn(|j| [j as f64 + offset_cm, -100.0 + j as f64, 5.0 * j as f64, 0.5])
    }

    fn folder(files: &[(&str, String)]) -> tempfile::TempDir {
        let dir = tempfile::tempdir().expect("temp dir");
        for (name, text) in files {
            std::fs::write(dir.path().join(name), text).expect("write");
        }
        dir
    }

    #[test]
    fn scene_names_give_prefix_and_frame() {
        assert_eq!(scene_name("body3DScene_00000168.json"), Some(("", 168)));
        assert_eq!(
            scene_name("160906_band1_body3DScene_00000168.json"),
            Some(("160906_band1_", 168))
        );
        for other in [
            "body3DScene_.json",
            "body3DScene_12a.json",
            "body3DScene_12.json.bak",
            "poses.json",
        ] {
            assert_eq!(scene_name(other), None, "{other}");
        }
    }

    #[test]
    fn a_folder_is_one_track_per_body_id_stamped_by_frame_number_with_gaps() {
        let dir = folder(&[
            (
                "body3DScene_00000010.json",
                scene_text(Some("hd_29_97"), &[(0, joints(0.0)), (3, joints(50.0))]),
            ),
            (
                "body3DScene_00000011.json",
                scene_text(Some("hd_29_97"), &[(3, joints(51.0))]),
            ),
            // Frame 12 missing: a gap in time.
            (
                "body3DScene_00000013.json",
                scene_text(Some("hd_29_97"), &[(0, joints(2.0))]),
            ),
            ("calibration.json", "{}".to_owned()),
        ]);
        let clip = read(dir.path()).unwrap_or_else(|e| panic!("{e}"));
        let fps = clip.fps().expect("hd rate");
        assert!((fps - 29.97).abs() < 1e-3);
        let seqs = clip.to_pose_sequences(fps);
        assert_eq!(seqs.len(), 2);
        assert_eq!((seqs[0].track_id, seqs[1].track_id), (0, 3));
        let stamps = |s: &PoseSequence| s.frames.iter().map(|f| f.stamp_nanos).collect::<Vec<_>>();
        assert_eq!(
            stamps(&seqs[0]),
            [0, stamp_nanos_at(3, fps)],
            "frames 10 and 13"
        );
        assert_eq!(stamps(&seqs[1]), [0, stamp_nanos_at(1, fps)]);
        assert_eq!(seqs[0].joint_names, JOINT_NAMES);
    }

    #[test]
    fn scores_map_in_order_with_panoptics_threshold_on_converts_default() {
        let m = crate::skeleton::convert::ConvertOptions::default().min_confidence;
        assert_eq!(confidence(0.0), 0.0);
        assert!((confidence(VALID_SCORE) - m).abs() < 1e-6);
        assert!((confidence(1.0) - 1.0).abs() < 1e-6);
        assert_eq!(confidence(7.0), 1.0);
        let mut last = -1.0;
        for k in 0..=100 {
            let c = confidence(k as f32 / 100.0);
            assert!(c >= last, "not increasing at {k}");
            last = c;
        }
        // A joint just under Panoptic's threshold is dropped by `convert`, just over kept.
        assert!(confidence(0.099) < m && confidence(0.101) >= m);
    }

    #[test]
    fn negative_scores_and_missing_joints_are_missing() {
        let mut j = joints(0.0);
        j[8] = [0.0, 0.0, 0.0, -1.0];
        let text = scene_text(None, &[(1, j)]);
        let (bodies, rate) = parse(text.as_bytes(), "f.json").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(rate, None);
        let frame = pose_frame(0, &bodies[0].1);
        assert!(frame.positions_m[8].x.is_nan());
        assert_eq!(frame.confidence[8], 0.0);
        assert!(frame.positions_m[7].x.is_finite());
    }

    #[test]
    fn folders_without_scenes_or_with_two_sequences_are_refused_by_name() {
        let empty = folder(&[("notes.json", "{}".to_owned())]);
        let e = read(empty.path()).expect_err("no scenes").to_string();
        assert!(e.contains("holds no CMU Panoptic scene files"), "{e}");
        let two = folder(&[
            ("a_body3DScene_00000001.json", scene_text(None, &[])),
            ("b_body3DScene_00000001.json", scene_text(None, &[])),
        ]);
        let e = read(two.path()).expect_err("two sequences").to_string();
        assert!(
            e.contains("2 sequences") && e.contains("`a_body3DScene_*`"),
            "{e}"
        );
    }

    #[test]
    fn mixed_rates_and_bad_bodies_name_the_file_and_the_body() {
        let dir = folder(&[
            (
                "body3DScene_00000001.json",
                scene_text(Some("hd_29_97"), &[]),
            ),
            ("body3DScene_00000002.json", scene_text(Some("vga_25"), &[])),
        ]);
        let e = read(dir.path()).expect_err("mixed").to_string();
        assert!(
            e.contains("body3DScene_00000002.json: fpsType `vga_25`")
                && e.contains("body3DScene_00000001.json says `hd_29_97`"),
            "{e}"
        );
        for (text, says) in [
            (
                r#"{"bodies": [{"id": 4, "joints15": [1, 2]}]}"#,
                "f.json: bodies[0] (id 4): only `joints15`",
            ),
            (
                r#"{"bodies": [{"id": -1, "joints19": []}]}"#,
                "not a non-negative integer",
            ),
            (
                r#"{"bodies": [{"id": 2, "joints19": [1, 2, 3]}]}"#,
                "has 3 numbers, expected 76",
            ),
            (r#"{"bodies": [{"id": 2}]}"#, "no `joints19`"),
            (r#"{"fpsType": "hd_29_97"}"#, "missing field `bodies`"),
            (r#"{"bodies": [{"id": 1, "joints19": [1"#, "line 1 column"),
        ] {
            let e = parse(text.as_bytes(), "f.json")
                .expect_err(text)
                .to_string();
            assert!(e.contains(says), "{text}: {e}");
        }
        let twice = scene_text(None, &[(5, joints(0.0)), (5, joints(1.0))]);
        let e = parse(twice.as_bytes(), "f.json")
            .expect_err("twice")
            .to_string();
        assert!(e.contains("bodies[1] (id 5): a second body"), "{e}");
    }

    #[test]
    fn scene_heads_are_told_from_mmpose_lists() {
        assert!(looks_like_scene(scene_text(None, &[]).as_bytes()));
        assert!(!looks_like_scene(b"[{\"frame_id\": 0, \"instances\": []}]"));
        assert!(!looks_like_scene(b"{\"instance_info\": []}"));
    }

    proptest! {
        /// Any body, written as Panoptic writes it (centimetres, +Y down), reads back as the
        /// same points in metres in the autoact frame (a proper rotation: left stays left), its
        /// scores as [`confidence`] says, its id as the track and its frame from the name.
        #[test]
        fn points_read_back_in_metres_and_autoact_axes(
            points in prop::collection::vec(
                (-300.0f64..300.0, -200.0f64..0.0, -300.0f64..300.0, 0.0f64..1.0), 19),
            id in 0u64..1000,
        ) {
            let joints: [[f64; 4]; 19] =
                std::array::from_fn(|j| [points[j].0, points[j].1, points[j].2, points[j].3]);
            let text = scene_text(Some("hd_29_97"), &[(id, joints)]);
            let dir = folder(&[("s_body3DScene_00000042.json", text)]);
            let clip = read(dir.path().join("s_body3DScene_00000042.json"))
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert_eq!(clip.frames()[0].frame, 42);
            let seqs = clip.to_pose_sequences(30.0);
            prop_assert_eq!(seqs.len(), 1);
            prop_assert_eq!(seqs[0].track_id, id);
            let frame = &seqs[0].frames[0];
            for (j, [x, y, z, s]) in joints.iter().enumerate() {
                let p = frame.positions_m[j];
                // (x, y, z) cm, +Y down → (x, z, −y) m, +Z up.
                prop_assert!((p.coords - Vector3::new(*x, *z, -*y) * 0.01).norm() < 1e-12);
                #[expect(clippy::cast_possible_truncation, reason = "test")]
                let c = confidence(*s as f32);
                prop_assert_eq!(frame.confidence[j], c);
            }
        }
    }
}
