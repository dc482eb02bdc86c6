//! One dataset file in, its pose sequences out: what `autoact import` writes into a pose bag.
//!
//! [`import`] takes the format from the file's extension (and for `.mat` and `.json` its
//! contents; a folder is CMU Panoptic's) unless told, checks the options against what the format
//! states itself (NTU, Human3.6M, ZED, UTD-MHAD and Panoptic files have their own layout; BVH,
//! Human3.6M, ZED and Panoptic files their own rate; MMPose JSON has none; only BVH and MMPose
//! JSON take axes and units), reads the file and warns when a JSON body's size suggests wrong
//! units.
//!
//! Camera-frame sources — ZED, MMPose JSON, NTU and UTD-MHAD (Kinect camera space) — are then
//! grounded ([`crate::skeleton::ground`]: up from the feet, the body on `z = 0` facing +Y)
//! unless `--ground off`; BVH, Human3.6M exp-map and CMU Panoptic are in a world frame with a
//! floor and are left as they are unless `--ground on`. Every sequence's bone-length spread is reported
//! ([`crate::skeleton::lengths`]), and `--lengths fixed` re-poses the limbs with fixed lengths.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::bags::pose::skeleton_message;
use crate::formats::bvh_map::{self, BvhMapError, BvhMapping};
use crate::formats::{bvh, h36m_expmap, mmpose_json, ntu, panoptic, utd_mat, zed_mat};
use crate::skeleton::eval::LengthStability;
use crate::skeleton::frames::SourceAxes;
use crate::skeleton::ground::{self, GroundMode, SharedGrounding};
use crate::skeleton::layout::{Layout, LayoutError};
use crate::skeleton::lengths::{self, LengthFix, LengthMode, LimbFixer};
use crate::skeleton::pose::{PoseFrame, PoseSequence};

/// Input formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum InputFormat {
    /// From the file extension: .bvh, .skeleton, .txt, .mat (ZED or UTD-MHAD, by its variables),
    /// .json (CMU Panoptic or MMPose, by its first bytes); a folder of CMU Panoptic files.
    #[default]
    Auto,
    /// BVH motion capture.
    Bvh,
    /// NTU RGB+D `.skeleton` (Kinect v2).
    Ntu,
    /// Human3.6M exponential-map text (the motion-prediction release).
    H36mExpmap,
    /// ZED BODY_34 `.mat` (MATLAB v5).
    ZedMat,
    /// UTD-MHAD Kinect v1 skeleton `.mat` (`d_skel`, 20 joints; MATLAB v5).
    UtdMat,
    /// MMPose-style whole-body JSON (a list of frames of keypoint instances).
    MmposeJson,
    /// CMU Panoptic Studio 3D bodies: a `body3DScene_<frame>.json` file, or a folder of them
    /// (`hdPose3d_stage1_coco19`; 19 joints, every person).
    PanopticJson,
}

impl InputFormat {
    /// Whether the format's points are in a camera's frame (estimators, Kinect): what
    /// `--ground auto` grounds. BVH, Human3.6M exp-map and CMU Panoptic are in a world frame
    /// with a floor.
    #[must_use]
    pub fn is_camera_frame(self) -> bool {
        matches!(
            self,
            InputFormat::Ntu | InputFormat::ZedMat | InputFormat::UtdMat | InputFormat::MmposeJson
        )
    }

    /// Whether the format holds a pose estimator's output (every camera-frame format, and CMU
    /// Panoptic's triangulated detections) rather than motion capture: what `convert` smooths
    /// as an estimator's ([`crate::dsi::SourceKind::Estimator`]).
    #[must_use]
    pub fn is_estimator_output(self) -> bool {
        self.is_camera_frame() || self == InputFormat::PanopticJson
    }

    /// Whether a pose bag whose metadata records are `records` was imported from an estimator's
    /// output ([`InputFormat::is_estimator_output`]).
    #[must_use]
    pub fn imported_from_estimator(records: &[(String, BTreeMap<String, String>)]) -> bool {
        records.iter().any(|(name, record)| {
            name == crate::bags::pose::METADATA_NAME
                && record
                    .get("format")
                    .and_then(|f| InputFormat::from_record_name(f))
                    .is_some_and(InputFormat::is_estimator_output)
        })
    }

    /// The name a pose bag's import record gives the format (its `format` key).
    #[must_use]
    pub fn record_name(self) -> String {
        format!("{self:?}")
    }

    /// The format an import record names ([`InputFormat::record_name`]), `None` for another
    /// name.
    #[must_use]
    pub fn from_record_name(name: &str) -> Option<InputFormat> {
        <InputFormat as clap::ValueEnum>::value_variants()
            .iter()
            .copied()
            .find(|f| *f != InputFormat::Auto && f.record_name() == name)
    }
}

/// How to read a dataset file (the `autoact import` options).
#[derive(Debug, Clone)]
pub struct ImportOptions {
    /// Its format, or [`InputFormat::Auto`] for the one its extension names.
    pub format: InputFormat,
    /// The keypoint layout: for BVH the one to map the mocap joints onto (default
    /// `autoact-landmarks`, the rig's own landmarks, [`bvh_map::DEFAULT_LAYOUT`]), for JSON the
    /// one its keypoints are in (default `coco-wholebody-133`); other formats have their own.
    pub layout: Option<String>,
    /// For BVH: a mapping file to use instead of the built-in mapping of the skeleton family
    /// ([`BvhMapping::from_file`]); needed for a skeleton autoact does not know.
    pub bvh_map: Option<PathBuf>,
    /// Frame rate, for formats that have none (MMPose JSON: required; Panoptic files without a
    /// known `fpsType`); overrides NTU's and UTD-MHAD's 30.
    pub fps: Option<f64>,
    /// Axes of the file's coordinates, for BVH and MMPose JSON (other formats state theirs);
    /// `None`: MMPose JSON is Y-down, and a BVH file's are found from its clip
    /// ([`bvh_map::found_axes`]: Z-up or Y-up).
    pub axes: Option<SourceAxes>,
    /// Metres per unit of the file's coordinates, for BVH and MMPose JSON (other formats state
    /// theirs); `None`: MMPose JSON is in metres, and a BVH file's unit is its mapping file's or
    /// else guessed from its rest skeleton.
    pub metres_per_unit: Option<f64>,
    /// Whether to stand the body on the ground (`auto`: camera-frame formats only).
    pub ground: GroundMode,
    /// Bone lengths as measured, or fixed by two-bone IK.
    pub lengths: LengthMode,
}

/// A dataset file read: its pose sequences (one per person) and how they were read.
#[derive(Debug, Clone)]
pub struct Imported {
    /// One sequence per person (track), in the autoact frame and metres.
    pub sequences: Vec<PoseSequence>,
    /// The format it was read as (never [`InputFormat::Auto`]).
    pub format: InputFormat,
    /// The keypoint layout of the sequences.
    pub layout: String,
    /// Where the frame rate came from, for the bag's metadata (e.g. `25 fps`).
    pub rate: String,
    /// How every sequence was grounded, and on which track's feet (`None`: not grounded).
    pub grounding: Option<SharedGrounding>,
    /// Per sequence, the bone-length spread as read (before `--lengths fixed`).
    pub stability: Vec<Vec<LengthStability>>,
    /// Per sequence, what `--lengths fixed` did (`None`: lengths as measured).
    pub length_fixes: Vec<Option<LengthFix>>,
    /// How the file's axes were decided, when not by its format alone (a BVH file found or told
    /// to be other than Y-up).
    pub axes: Option<String>,
    /// For a file read as a stream (MMPose JSON): the second reading still to do. The
    /// sequences then have no frames yet; [`Imported::for_each_frame`] reads them.
    replay: Option<Replay>,
}

/// The second reading of a JSON file, each frame grounded and fixed as its track's sample said.
#[derive(Debug, Clone)]
struct Replay {
    path: PathBuf,
    options: mmpose_json::JsonOptions,
    /// Per track id: its sequence's index.
    index: BTreeMap<u64, usize>,
    /// Per sequence: the limbs' fixer of `--lengths fixed`.
    fixers: Vec<Option<LimbFixer>>,
}

/// A JSON file is read twice: once for each track's frame count and a sample of at most this
/// many of its frames (every `2^k`-th), on which its ground, its bone-length spread and the
/// lengths of `--lengths fixed` are measured; then frame by frame as it is written. A track of
/// up to this many frames (4.5 min at 30 fps) is measured on every frame.
pub const JSON_SAMPLE_FRAMES: usize = 8192;

/// Why a dataset file could not be imported.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ImportError {
    /// `--fps` is zero, negative or not a number.
    #[error("--fps must be a positive number of frames per second, not {0}")]
    BadFps(f64),
    /// `--metres-per-unit` is zero, negative or not a number.
    #[error("--metres-per-unit must be positive, not {0}")]
    BadMetresPerUnit(f64),
    /// No format given and the extension names none.
    #[error("cannot tell the format of {} from its extension `{extension}`: give --format", path.display())]
    UnknownExtension {
        /// The file.
        path: PathBuf,
        /// Its extension, lowercase.
        extension: String,
    },
    /// A layout asked for a format that has its own.
    #[error("{format} files are in the `{own}` layout; drop --layout {asked}")]
    FixedLayout {
        /// The format's name.
        format: &'static str,
        /// Its layout.
        own: &'static str,
        /// The layout asked for.
        asked: String,
    },
    /// A BVH mapping file given for another format.
    #[error("--bvh-map is for BVH input only; drop it")]
    BvhMapNotBvh,
    /// Axes or units given for a format that states its own.
    #[error(
        "--axes and --metres-per-unit are for BVH and MMPose JSON input only (other formats state their axes and units); drop them"
    )]
    FrameNotHere,
    /// A frame rate given for a format that states its own.
    #[error("{why}; drop --fps")]
    FixedRate {
        /// Where the format's rate comes from.
        why: &'static str,
    },
    /// No frame rate for a format without one.
    #[error("{}: {why}: give --fps", path.display())]
    NoRate {
        /// The file.
        path: PathBuf,
        /// Why there is none.
        why: String,
    },
    /// MMPose JSON named as a dataset spec's source, where no frame rate can be given.
    #[error(
        "{}: MMPose JSON has no frame rate of its own: import it first (`autoact import {} --fps N -o FILE.pose.mcap`) and name the pose bag in the spec",
        path.display(),
        path.display()
    )]
    JsonInSpec {
        /// The file.
        path: PathBuf,
    },
    /// The file was read but holds no frame.
    #[error("{} holds no frames", path.display())]
    NoFrames {
        /// The file.
        path: PathBuf,
    },
    /// Writing the pose bag failed.
    #[error(transparent)]
    Write(#[from] crate::mcap_io::McapIoError),
    /// A layout that does not load.
    #[error(transparent)]
    Layout(#[from] LayoutError),
    /// A BVH file that does not read.
    #[error(transparent)]
    Bvh(#[from] bvh::BvhError),
    /// A BVH skeleton that does not map onto the layout.
    #[error(transparent)]
    BvhMap(#[from] BvhMapError),
    /// An NTU file that does not read.
    #[error(transparent)]
    Ntu(#[from] ntu::NtuError),
    /// A Human3.6M file that does not read.
    #[error(transparent)]
    H36m(#[from] h36m_expmap::H36mError),
    /// A ZED file that does not read.
    #[error(transparent)]
    Zed(#[from] zed_mat::ZedError),
    /// A UTD-MHAD file that does not read.
    #[error(transparent)]
    Utd(#[from] utd_mat::UtdError),
    /// A CMU Panoptic file or folder that does not read.
    #[error(transparent)]
    Panoptic(#[from] panoptic::PanopticError),
    /// An MMPose JSON file that does not read in the layout.
    #[error("reading {} as {layout}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// The layout its keypoints were read in.
        layout: String,
        /// The cause (boxed: it is large).
        #[source]
        source: Box<mmpose_json::JsonError>,
    },
}

/// Reads the dataset file at `input` as `options` say.
///
/// # Errors
/// An option that does not fit the format, an unreadable file (the message names the file and
/// the place), or a file without frames.
pub fn import(input: &Path, options: &ImportOptions) -> Result<Imported, ImportError> {
    let mut imported = measure(input, options)?;
    if imported.replay.is_some() {
        let mut frames: Vec<Vec<PoseFrame>> = vec![Vec::new(); imported.sequences.len()];
        imported.for_each_frame(|s, frame| {
            frames[s].push(frame.clone());
            Ok(())
        })?;
        for (seq, frames) in imported.sequences.iter_mut().zip(frames) {
            seq.frames = frames;
        }
    }
    Ok(imported)
}

/// [`import`] without holding the frames of a file that can be read as a stream (MMPose
/// JSON: every track measured on its sample, see [`JSON_SAMPLE_FRAMES`]); its frames are then
/// read by [`Imported::for_each_frame`] or [`Imported::write`].
///
/// # Errors
/// As [`import`].
pub fn measure(input: &Path, options: &ImportOptions) -> Result<Imported, ImportError> {
    if let Some(f) = options.fps
        && !(f.is_finite() && f > 0.0)
    {
        return Err(ImportError::BadFps(f));
    }
    if let Some(m) = options.metres_per_unit
        && !(m.is_finite() && m > 0.0)
    {
        return Err(ImportError::BadMetresPerUnit(m));
    }
    let format = resolve_format(options.format, input)?;
    let Input {
        sequences,
        layout,
        rate,
        replay,
        axes,
    } = read_input(input, format, options)?;
    if sequences.iter().all(|s| s.frames.is_empty()) {
        return Err(ImportError::NoFrames {
            path: input.to_path_buf(),
        });
    }
    // A layout asked for by path loads from it again (fixed-layout formats checked it equal).
    let loaded = Layout::load(options.layout.as_deref().unwrap_or(&layout))?;
    let mut imported = Imported {
        sequences: Vec::new(),
        format,
        layout,
        rate,
        grounding: None,
        stability: Vec::new(),
        length_fixes: Vec::new(),
        axes,
        replay: None,
    };
    if options.ground.applies(format.is_camera_frame()) {
        imported.grounding = shared_grounding(&sequences, &loaded);
    }
    let mut fixers = Vec::new();
    for mut seq in sequences {
        if let Some(shared) = &imported.grounding {
            shared.grounding.apply(&mut seq);
        }
        let stability = lengths::stability(&seq, &loaded).unwrap_or_default();
        warn_unstable(&seq.source, seq.track_id, &stability);
        let mut fixer = (options.lengths == LengthMode::Fixed)
            .then(|| LimbFixer::fit(&loaded, &seq.joint_names, &seq.frames));
        if replay.is_some() {
            // A sample: the frames come in the second reading.
            seq.frames = Vec::new();
        } else if let Some(fixer) = &mut fixer {
            for f in &mut seq.frames {
                fixer.fix(f);
            }
        }
        imported
            .length_fixes
            .push(fixer.as_ref().map(LimbFixer::summary));
        fixers.push(fixer);
        imported.sequences.push(seq);
        imported.stability.push(stability);
    }
    imported.replay = replay.map(|(path, options)| Replay {
        path,
        options,
        index: (imported.sequences.iter().enumerate())
            .map(|(i, s)| (s.track_id, i))
            .collect(),
        fixers,
    });
    Ok(imported)
}

impl Imported {
    /// Every frame of every sequence in stamp order (ties: track id), with its sequence's
    /// index: the sequences' own frames, or those of the file's second reading, grounded and
    /// fixed as the first one decided.
    ///
    /// # Errors
    /// The file's second reading failing, or `f`'s error.
    pub fn for_each_frame(
        &mut self,
        mut f: impl FnMut(usize, &PoseFrame) -> Result<(), ImportError>,
    ) -> Result<(), ImportError> {
        let Some(mut replay) = self.replay.take() else {
            let mut order: Vec<(u64, u64, usize, usize)> = Vec::new();
            for (s, seq) in self.sequences.iter().enumerate() {
                for (k, frame) in seq.frames.iter().enumerate() {
                    order.push((frame.stamp_nanos, seq.track_id, s, k));
                }
            }
            order.sort_unstable();
            for (_, _, s, k) in order {
                f(s, &self.sequences[s].frames[k])?;
            }
            return Ok(());
        };
        let grounding = self.grounding.as_ref().map(|s| &s.grounding);
        let Replay {
            path,
            options,
            index,
            fixers,
        } = &mut replay;
        let result = mmpose_json::for_each_frame(path, options, |mut people| {
            people.sort_by_key(|(track_id, _)| *track_id);
            for (track_id, mut frame) in people {
                // The first reading saw every track the second one does.
                let Some(&s) = index.get(&track_id) else {
                    continue;
                };
                if let Some(g) = grounding {
                    for p in &mut frame.positions_m {
                        *p = g.world_from_camera * *p;
                    }
                }
                if let Some(Some(fixer)) = fixers.get_mut(s) {
                    fixer.fix(&mut frame);
                }
                f(s, &frame).map_err(ReplayError::Caller)?;
            }
            Ok(())
        });
        for (fix, fixer) in self.length_fixes.iter_mut().zip(fixers.iter()) {
            *fix = fixer.as_ref().map(LimbFixer::summary);
        }
        match result {
            Ok(()) => Ok(()),
            Err(ReplayError::Json(e)) => Err(ImportError::Json {
                path: path.clone(),
                layout: self.layout.clone(),
                source: Box::new(e),
            }),
            Err(ReplayError::Caller(e)) => Err(e),
        }
    }

    /// Writes the pose bag's `autoact` metadata record and every frame ([`skeleton_message`]s in
    /// stamp order, each stamped `start_nanos` after the epoch plus its own time in the file);
    /// returns the number of skeletons written.
    ///
    /// # Errors
    /// The bag cannot be written, or the file's second reading fails.
    pub fn write<W: std::io::Write + std::io::Seek>(
        &mut self,
        writer: &mut crate::mcap_io::BagWriter<W>,
        metadata: BTreeMap<String, String>,
        start_nanos: u64,
    ) -> Result<u64, ImportError> {
        writer.write_metadata(crate::bags::pose::METADATA_NAME, metadata)?;
        // Each sequence's name and joints, for the messages (not its frames).
        let heads: Vec<PoseSequence> = self
            .sequences
            .iter()
            .map(|s| PoseSequence {
                source: s.source.clone(),
                track_id: s.track_id,
                joint_names: s.joint_names.clone(),
                frames: Vec::new(),
            })
            .collect();
        let layout = self.layout.clone();
        let mut written = 0;
        // One frame reused for every message: `Vec::clone_from` keeps its allocations.
        let mut stamped = PoseFrame::missing(0, 0);
        self.for_each_frame(|s, frame| {
            stamped.positions_m.clone_from(&frame.positions_m);
            stamped.confidence.clone_from(&frame.confidence);
            stamped.stamp_nanos = start_nanos.saturating_add(frame.stamp_nanos);
            writer.write(
                crate::bags::pose::SKELETON_TOPIC,
                stamped.stamp_nanos,
                &skeleton_message(&heads[s], &stamped, &layout),
            )?;
            written += 1;
            Ok(())
        })?;
        Ok(written)
    }
}

/// Why the second reading of a JSON file stopped.
enum ReplayError {
    Json(mmpose_json::JsonError),
    Caller(ImportError),
}

impl From<mmpose_json::JsonError> for ReplayError {
    fn from(e: mmpose_json::JsonError) -> ReplayError {
        ReplayError::Json(e)
    }
}

/// The grounding of a file's tracks, all seen by one camera ([`ground::shared`]), with a
/// warning when its feet do not settle on one plane. `None`, with a warning, when no track can
/// be grounded: the tracks then stay in their source frame.
fn shared_grounding(seqs: &[PoseSequence], layout: &Layout) -> Option<SharedGrounding> {
    let found = ground::shared(
        seqs,
        |s| (s.track_id, s.frames.len()),
        |s| ground::estimate(s, layout, 1),
    )?;
    match found {
        Ok(shared) => {
            if let Some(w) = shared.grounding.loose_fit_warning() {
                let source = seqs.iter().find(|s| s.track_id == shared.track_id);
                let source = source.map_or("", |s| s.source.as_str());
                tracing::warn!("{source} track {}: {w}", shared.track_id);
            }
            Some(shared)
        }
        Err(e) => {
            tracing::warn!("{e}: left in the source frame");
            None
        }
    }
}

/// Warns once per segment whose length varies by [`lengths::UNSTABLE_CV`] or more.
fn warn_unstable(source: &str, track: u64, stability: &[LengthStability]) {
    let unstable: Vec<LengthStability> = stability
        .iter()
        .filter(|s| s.cv >= lengths::UNSTABLE_CV)
        .cloned()
        .collect();
    for line in lengths::report_lines(&unstable) {
        tracing::warn!(
            "{source} track {track}: bone length varies: {line} (--lengths fixed holds limbs at their median)"
        );
    }
}

impl Imported {
    /// The pose bag's `autoact` metadata record: source file name, format, layout, rate and
    /// the label (empty where not given).
    #[must_use]
    pub fn metadata(
        &self,
        input: &Path,
        category: Option<String>,
        action: Option<String>,
    ) -> BTreeMap<String, String> {
        let mut metadata = BTreeMap::new();
        metadata.insert("source".to_string(), crate::file_name(input));
        metadata.insert("format".to_string(), self.format.record_name());
        metadata.insert("layout".to_string(), self.layout.clone());
        metadata.insert("rate".to_string(), self.rate.clone());
        metadata.insert("category".to_string(), category.unwrap_or_default());
        metadata.insert("action".to_string(), action.unwrap_or_default());
        metadata
    }
}

impl Imported {
    /// What was done to the file (axes found or given) and to each track (grounding, fixed
    /// lengths), one line each, for people.
    #[must_use]
    pub fn notes(&self) -> String {
        let mut out = self
            .axes
            .as_ref()
            .map_or(String::new(), |a| format!("{a}\n"));
        for (i, seq) in self.sequences.iter().enumerate() {
            if let Some(shared) = &self.grounding {
                out += &format!("track {}: {}\n", seq.track_id, shared.note(seq.track_id));
            }
            if let Some(Some(fix)) = self.length_fixes.get(i) {
                for (limb, upper, lower) in &fix.limbs {
                    out += &format!(
                        "track {}: {limb} held at {upper:.3} m + {lower:.3} m\n",
                        seq.track_id
                    );
                }
                if fix.out_of_reach > 0 {
                    out += &format!(
                        "track {}: {} limb poses out of reach, end effector moved\n",
                        seq.track_id, fix.out_of_reach
                    );
                }
            }
        }
        out
    }
}

/// The format `import` reads `input` as when not told ([`InputFormat::Auto`]): from its
/// extension, and for `.mat` and `.json` its contents; a folder is CMU Panoptic's.
///
/// # Errors
/// [`ImportError::UnknownExtension`].
pub fn detect_format(input: &Path) -> Result<InputFormat, ImportError> {
    resolve_format(InputFormat::Auto, input)
}

/// The format to read `input` as: `format`, or for [`InputFormat::Auto`] the one its extension
/// names.
fn resolve_format(format: InputFormat, input: &Path) -> Result<InputFormat, ImportError> {
    if format != InputFormat::Auto {
        return Ok(format);
    }
    if input.is_dir() {
        // The reader names a folder without Panoptic scene files.
        return Ok(InputFormat::PanopticJson);
    }
    let ext = input
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    Ok(match ext.as_str() {
        "bvh" => InputFormat::Bvh,
        "skeleton" => InputFormat::Ntu,
        "txt" => InputFormat::H36mExpmap,
        // Both MAT formats: UTD-MHAD's files hold `d_skel`, ZED's `keypoints` (a file that
        // cannot be read is left to the ZED reader, which names the problem).
        "mat" if std::fs::read(input).is_ok_and(|b| utd_mat::holds_skeleton(&b)) => {
            InputFormat::UtdMat
        }
        "mat" => InputFormat::ZedMat,
        // Both JSON formats: a Panoptic scene is an object with `bodies` (a file that cannot be
        // read is left to the MMPose reader, which names the problem).
        "json" if file_head(input).is_some_and(|h| panoptic::looks_like_scene(&h)) => {
            InputFormat::PanopticJson
        }
        "json" => InputFormat::MmposeJson,
        _ => {
            return Err(ImportError::UnknownExtension {
                path: input.to_path_buf(),
                extension: ext,
            });
        }
    })
}

/// The first 64 KiB of a file, `None` if it cannot be read.
fn file_head(path: &Path) -> Option<Vec<u8>> {
    use std::io::Read;
    let mut head = Vec::new();
    std::fs::File::open(path)
        .ok()?
        .take(64 * 1024)
        .read_to_end(&mut head)
        .ok()?;
    Some(head)
}

/// The layout of a format that has its own (`own`): an error if another one was asked for.
fn fixed_layout(
    format: &'static str,
    own: &'static str,
    asked: Option<&str>,
) -> Result<String, ImportError> {
    match asked {
        Some(l) if Layout::load(l)?.name != own => Err(ImportError::FixedLayout {
            format,
            own,
            asked: l.to_string(),
        }),
        _ => Ok(own.to_string()),
    }
}

/// An error if a frame rate was given for a format that states its own (`why`).
fn no_fps(fps: Option<f64>, why: &'static str) -> Result<(), ImportError> {
    match fps {
        Some(_) => Err(ImportError::FixedRate { why }),
        None => Ok(()),
    }
}

/// What [`read_input`] read: the pose sequences (for a file read as a stream, each track's
/// sample), their layout name, a description of the rate, and the file to read again.
struct Input {
    sequences: Vec<PoseSequence>,
    layout: String,
    rate: String,
    replay: Option<(PathBuf, mmpose_json::JsonOptions)>,
    /// How the axes were decided, when that is worth a line (not a format's fixed axes).
    axes: Option<String>,
}

impl Input {
    fn read(sequences: Vec<PoseSequence>, layout: String, rate: String) -> Input {
        Input {
            sequences,
            layout,
            rate,
            replay: None,
            axes: None,
        }
    }
}

/// Reads the input: its pose sequences, their layout name, and a description of its rate.
fn read_input(
    input: &Path,
    format: InputFormat,
    options: &ImportOptions,
) -> Result<Input, ImportError> {
    let (layout, fps) = (options.layout.as_deref(), options.fps);
    if format != InputFormat::Bvh && options.bvh_map.is_some() {
        return Err(ImportError::BvhMapNotBvh);
    }
    if !matches!(
        format,
        InputFormat::Auto | InputFormat::Bvh | InputFormat::MmposeJson
    ) && (options.axes.is_some() || options.metres_per_unit.is_some())
    {
        return Err(ImportError::FrameNotHere);
    }
    Ok(match format {
        // `resolve_format` never returns `Auto`; read it as the extension says all the same.
        InputFormat::Auto => read_input(input, resolve_format(format, input)?, options)?,
        InputFormat::Bvh => {
            no_fps(fps, "BVH files state their own frame time")?;
            let layout = Layout::load(layout.unwrap_or(bvh_map::DEFAULT_LAYOUT))?;
            let user_mapping = match &options.bvh_map {
                Some(path) => Some(BvhMapping::from_file(path)?),
                None => None,
            };
            let clip = bvh::read(input)?;
            let mapping = match user_mapping {
                Some(m) => m.check_fits(&clip)?,
                None => BvhMapping::detect(&clip)?,
            };
            let (seq, axes) =
                mapping.keypoints_in(&clip, &layout, options.axes, options.metres_per_unit)?;
            let rate = format!("{:.3} fps (BVH frame time)", clip.fps());
            let mut input = Input::read(vec![seq.without_unobserved_joints()], layout.name, rate);
            input.axes = match (options.axes, axes) {
                (Some(given), _) => Some(format!("axes: {} (--axes)", given.name())),
                (None, SourceAxes::YUp) => None,
                (None, found) => Some(format!(
                    "axes: {} (found: the body stands along its up through the clip)",
                    found.name()
                )),
            };
            input
        }
        InputFormat::Ntu => {
            let layout = fixed_layout("NTU", "ntu-25", layout)?;
            let rate = fps.unwrap_or(ntu::FPS);
            let seqs = ntu::read(input)?.to_pose_sequences(rate);
            Input::read(seqs, layout, format!("{rate} fps"))
        }
        InputFormat::H36mExpmap => {
            let layout = fixed_layout("Human3.6M exp-map", "h36m-32", layout)?;
            no_fps(fps, "Human3.6M exp-map files are 50 fps")?;
            let clip = h36m_expmap::read(input)?;
            let seq = clip.to_pose_sequence(h36m_expmap::RootMode::Trajectory);
            Input::read(vec![seq], layout, format!("{} fps", h36m_expmap::FPS))
        }
        InputFormat::ZedMat => {
            let layout = fixed_layout("ZED", "zed-body-34", layout)?;
            no_fps(fps, "ZED recordings carry their own timestamps")?;
            let seq = zed_mat::read(input)?.to_pose_sequence();
            Input::read(vec![seq], layout, "recorded timestamps".to_string())
        }
        InputFormat::UtdMat => {
            let layout = fixed_layout("UTD-MHAD", "kinect-v1-20", layout)?;
            let rate = fps.unwrap_or(utd_mat::FPS);
            let seq = utd_mat::read(input)?.to_pose_sequence(rate);
            Input::read(vec![seq], layout, format!("{rate} fps"))
        }
        InputFormat::MmposeJson => read_json(input, options)?,
        InputFormat::PanopticJson => {
            let layout = fixed_layout("CMU Panoptic", panoptic::LAYOUT, layout)?;
            let clip = panoptic::read(input)?;
            let (rate, how) = match (clip.fps(), fps) {
                (Some(_), Some(_)) => {
                    return Err(ImportError::FixedRate {
                        why: "CMU Panoptic files state their own rate (fpsType)",
                    });
                }
                (Some(rate), None) => {
                    let named = clip.fps_type().unwrap_or_default();
                    (rate, format!("{rate:.3} fps (fpsType {named})"))
                }
                (None, Some(rate)) => (rate, format!("{rate} fps")),
                (None, None) => {
                    let why = match clip.fps_type() {
                        Some(t) => format!("CMU Panoptic fpsType `{t}` is not one autoact knows"),
                        None => "these CMU Panoptic files state no fpsType".to_owned(),
                    };
                    return Err(ImportError::NoRate {
                        path: input.to_path_buf(),
                        why,
                    });
                }
            };
            Input::read(clip.to_pose_sequences(rate), layout, how)
        }
    })
}

/// Reads an MMPose-style JSON file (which needs a frame rate and has no layout of its own) for
/// the first time: each track's sample (see [`JSON_SAMPLE_FRAMES`]).
fn read_json(input: &Path, options: &ImportOptions) -> Result<Input, ImportError> {
    let layout = Layout::load(options.layout.as_deref().unwrap_or("coco-wholebody-133"))?;
    let Some(fps) = options.fps else {
        return Err(ImportError::NoRate {
            path: input.to_path_buf(),
            why: "MMPose JSON has no frame rate".to_owned(),
        });
    };
    let metres_per_unit = options.metres_per_unit.unwrap_or(1.0);
    let json_options = mmpose_json::JsonOptions {
        fps,
        metres_per_unit,
        axes: options.axes.unwrap_or(SourceAxes::YDown),
        joint_names: layout.joints.clone(),
    };
    let source = input.display().to_string();
    // Per track: its sample, frames seen, and the sample's stride.
    let mut tracks: BTreeMap<u64, (PoseSequence, usize, usize)> = BTreeMap::new();
    mmpose_json::for_each_frame(input, &json_options, |people| {
        for (track_id, frame) in people {
            let (sample, seen, stride) = tracks.entry(track_id).or_insert_with(|| {
                let seq = PoseSequence {
                    source: source.clone(),
                    track_id,
                    joint_names: json_options.joint_names.clone(),
                    frames: Vec::new(),
                };
                (seq, 0, 1)
            });
            if *seen % *stride == 0 {
                sample.frames.push(frame);
                if sample.frames.len() > JSON_SAMPLE_FRAMES {
                    sample.frames = std::mem::take(&mut sample.frames)
                        .into_iter()
                        .step_by(2)
                        .collect();
                    *stride *= 2;
                }
            }
            *seen += 1;
        }
        Ok(())
    })
    .map_err(|source| ImportError::Json {
        path: input.to_path_buf(),
        layout: layout.name.clone(),
        source: Box::new(source),
    })?;
    let seqs: Vec<PoseSequence> = tracks.into_values().map(|(s, _, _)| s).collect();
    warn_if_implausible_size(&seqs, metres_per_unit);
    Ok(Input {
        sequences: seqs,
        layout: layout.name,
        rate: format!("{fps} fps"),
        replay: Some((input.to_path_buf(), json_options)),
        axes: None,
    })
}

/// A body that spans more than 3 m or less than 0.3 m is almost always a unit mistake.
fn warn_if_implausible_size(seqs: &[PoseSequence], metres_per_unit: f64) {
    let mut extent: f64 = 0.0;
    for f in seqs.iter().flat_map(|s| s.frames.iter()).take(200) {
        let zs: Vec<f64> = f
            .positions_m
            .iter()
            .map(|p| p.z)
            .filter(|z| z.is_finite())
            .collect();
        if let (Some(lo), Some(hi)) = (
            zs.iter().copied().reduce(f64::min),
            zs.iter().copied().reduce(f64::max),
        ) {
            extent = extent.max(hi - lo);
        }
    }
    if extent > 3.0 || (extent > 0.0 && extent < 0.3) {
        tracing::warn!(
            "the skeleton is {extent:.2} m tall with --metres-per-unit {metres_per_unit}: check the units (0.001 for millimetres) and --axes"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn options(format: InputFormat, layout: Option<&str>, fps: Option<f64>) -> ImportOptions {
        ImportOptions {
            format,
            layout: layout.map(str::to_string),
            bvh_map: None,
            fps,
            axes: None,
            metres_per_unit: None,
            ground: GroundMode::Off,
            lengths: LengthMode::Measured,
        }
    }

    fn error(path: &str, options: &ImportOptions) -> String {
        import(Path::new(path), options).unwrap_err().to_string()
    }

    #[test]
    fn a_mat_file_is_read_as_utd_mhad_when_it_holds_d_skel_and_imports_grounded() {
        use crate::formats::matlab::test_files::Mat;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a1_s1_t1_skeleton.mat");
        // Two frames of a person standing 3 m in front of a Kinect 0.8 m above the floor:
        // the rows in UTD's order (head first), x y z in camera space (+Y up).
        let rows: [[f64; 3]; 20] = [
            [0.0, 0.8, 3.0],    // head
            [0.0, 0.55, 3.0],   // shoulder centre
            [0.0, 0.25, 3.0],   // spine
            [0.0, 0.15, 3.0],   // hip centre
            [-0.18, 0.5, 3.0],  // left shoulder (the person faces the sensor: their left at −x)
            [-0.2, 0.22, 3.0],  // left elbow
            [-0.2, -0.02, 3.0], // left wrist
            [-0.2, -0.1, 3.0],  // left hand
            [0.18, 0.5, 3.0],
            [0.2, 0.22, 3.0],
            [0.2, -0.02, 3.0],
            [0.2, -0.1, 3.0],
            [-0.1, 0.1, 3.0],    // left hip
            [-0.1, -0.32, 3.0],  // left knee
            [-0.1, -0.72, 3.0],  // left ankle
            [-0.1, -0.78, 2.88], // left foot, towards the sensor
            [0.1, 0.1, 3.0],
            [0.1, -0.32, 3.0],
            [0.1, -0.72, 3.0],
            [0.1, -0.78, 2.88],
        ];
        // Column-major (row, coordinate, frame).
        let frame: Vec<f64> = (0..3)
            .flat_map(|c| rows.iter().map(move |r| r[c]))
            .collect();
        let data = [frame.clone(), frame].concat();
        let m = Mat::new(false);
        let bytes = Mat::new(false)
            .push(m.matrix(6, &[20, 3, 2], "d_skel", 9, &m.f64s(&data)))
            .bytes;
        std::fs::write(&path, bytes).unwrap();
        assert_eq!(
            resolve_format(InputFormat::Auto, &path).unwrap(),
            InputFormat::UtdMat
        );
        let imported = import(
            &path,
            &ImportOptions {
                ground: GroundMode::Auto,
                ..options(InputFormat::Auto, None, None)
            },
        )
        .unwrap();
        assert_eq!(imported.layout, "kinect-v1-20");
        let seq = &imported.sequences[0];
        assert_eq!(seq.frames[1].stamp_nanos, 33_333_333);
        let z = |n: &str| seq.frames[0].positions_m[seq.joint_index(n).unwrap()].z;
        // Grounded: the feet on the floor, the head 1.5 m above them.
        assert!(z("FootLeft").abs() < 0.05, "{}", z("FootLeft"));
        assert!((z("Head") - 1.55).abs() < 0.1, "{}", z("Head"));
        // Any other .mat (or one that cannot be read) is left to the ZED reader.
        let other = dir.path().join("other.mat");
        std::fs::write(&other, Mat::new(false).bytes).unwrap();
        assert_eq!(
            resolve_format(InputFormat::Auto, &other).unwrap(),
            InputFormat::ZedMat
        );
    }

    #[test]
    fn the_extension_names_the_format_unless_one_is_given() {
        let resolve = |f, p: &str| resolve_format(f, Path::new(p)).unwrap();
        assert_eq!(resolve(InputFormat::Auto, "a/walk.BVH"), InputFormat::Bvh);
        assert_eq!(
            resolve(InputFormat::Auto, "S001.skeleton"),
            InputFormat::Ntu
        );
        assert_eq!(
            resolve(InputFormat::Auto, "walking_1.txt"),
            InputFormat::H36mExpmap
        );
        assert_eq!(resolve(InputFormat::Auto, "zed.mat"), InputFormat::ZedMat);
        assert_eq!(
            resolve(InputFormat::Auto, "out.json"),
            InputFormat::MmposeJson
        );
        assert_eq!(resolve(InputFormat::Ntu, "out.json"), InputFormat::Ntu);
        assert_eq!(
            error("notes.md", &options(InputFormat::Auto, None, None)),
            "cannot tell the format of notes.md from its extension `md`: give --format"
        );
    }

    #[test]
    fn json_is_told_by_its_first_bytes_and_a_folder_is_panoptics() {
        let dir = tempfile::tempdir().expect("temp dir");
        let file = |name: &str, text: &str| {
            let path = dir.path().join(name);
            std::fs::write(&path, text).expect("write");
            detect_format(&path).expect("a format")
        };
        assert_eq!(
            file("a.json", "  {\"version\": 0.7, \"bodies\": []}"),
            InputFormat::PanopticJson
        );
        assert_eq!(
            file("b.json", "[{\"frame_id\": 0, \"instances\": []}]"),
            InputFormat::MmposeJson
        );
        assert_eq!(
            file("c.json", "{\"instance_info\": []}"),
            InputFormat::MmposeJson
        );
        assert_eq!(
            detect_format(dir.path()).expect("a format"),
            InputFormat::PanopticJson
        );
        // A folder without scene files says what it reads, and that a rosbag2 folder is a bag.
        let e = error(
            &dir.path().display().to_string(),
            &options(InputFormat::Auto, None, None),
        );
        assert!(
            e.contains("holds no CMU Panoptic scene files") && e.contains("rosbag2"),
            "{e}"
        );
        // Panoptic files without a known rate need --fps, and say so.
        std::fs::write(
            dir.path().join("body3DScene_00000001.json"),
            "{\"fpsType\": \"hd_60\", \"bodies\": []}",
        )
        .expect("write");
        let e = error(
            &dir.path().display().to_string(),
            &options(InputFormat::Auto, None, None),
        );
        assert!(
            e.ends_with("CMU Panoptic fpsType `hd_60` is not one autoact knows: give --fps"),
            "{e}"
        );
        let e = error(
            &dir.path().display().to_string(),
            &options(InputFormat::Auto, Some("coco-17"), None),
        );
        assert_eq!(
            e,
            "CMU Panoptic files are in the `panoptic-coco19` layout; drop --layout coco-17"
        );
    }

    #[test]
    fn options_that_contradict_the_format_are_named_before_reading() {
        let auto = InputFormat::Auto;
        assert_eq!(
            error("x.json", &options(auto, None, Some(0.0))),
            "--fps must be a positive number of frames per second, not 0"
        );
        assert_eq!(
            error("x.skeleton", &options(auto, Some("h36m-17"), None)),
            "NTU files are in the `ntu-25` layout; drop --layout h36m-17"
        );
        assert_eq!(
            error("x.txt", &options(auto, None, Some(25.0))),
            "Human3.6M exp-map files are 50 fps; drop --fps"
        );
        assert_eq!(
            error("x.mat", &options(auto, Some("zed-body-34"), Some(25.0))),
            "ZED recordings carry their own timestamps; drop --fps"
        );
        assert_eq!(
            error("x.json", &options(auto, Some("h36m-17"), None)),
            "x.json: MMPose JSON has no frame rate: give --fps"
        );
        let mut bad_units = options(auto, Some("h36m-17"), Some(25.0));
        bad_units.metres_per_unit = Some(0.0);
        assert_eq!(
            error("x.json", &bad_units),
            "--metres-per-unit must be positive, not 0"
        );
        for path in ["x.skeleton", "x.mat", "x.txt"] {
            let mut axes = options(auto, None, None);
            axes.axes = Some(SourceAxes::ZUp);
            let mut units = options(auto, None, None);
            units.metres_per_unit = Some(0.01);
            for o in [axes, units] {
                assert!(
                    error(path, &o).starts_with(
                        "--axes and --metres-per-unit are for BVH and MMPose JSON input only"
                    ),
                    "{path}"
                );
            }
        }
    }

    #[test]
    fn the_people_of_one_camera_share_its_floor_and_keep_their_places() {
        // Two people 1.2 m apart across the image, 4 m from a camera 1.2 m above the floor (y
        // down), one facing it and one turned away: grounding each on its own would stand both
        // on the origin facing +Y.
        let joints: [(f64, f64, f64); 17] = [
            (0.0, -1.55, -0.1),
            (0.03, -1.6, -0.08),
            (-0.03, -1.6, -0.08),
            (0.07, -1.58, 0.0),
            (-0.07, -1.58, 0.0),
            (0.18, -1.4, 0.0),
            (-0.18, -1.4, 0.0),
            (0.2, -1.1, 0.0),
            (-0.2, -1.1, 0.0),
            (0.2, -0.85, 0.0),
            (-0.2, -0.85, 0.0),
            (0.1, -0.9, 0.0),
            (-0.1, -0.9, 0.0),
            (0.1, -0.5, 0.0),
            (-0.1, -0.5, 0.0),
            (0.1, -0.08, 0.0),
            (-0.1, -0.08, 0.0),
        ];
        let person = |x_m: f64, turned: f64| {
            let points: Vec<String> = joints
                .iter()
                .map(|(x, y, z)| {
                    format!("[{}, {}, {}]", x_m + turned * x, y + 1.2, 4.0 + turned * z)
                })
                .collect();
            format!("[{}]", points.join(", "))
        };
        let frames: Vec<String> = (0..20)
            .map(|f| {
                format!(
                    "{{\"frame_id\": {f}, \"instances\": [{{\"keypoints\": {}, \"track_id\": 0}}, {{\"keypoints\": {}, \"track_id\": 1}}]}}",
                    person(-0.6, 1.0),
                    person(0.6, -1.0)
                )
            })
            .collect();
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("two.json");
        std::fs::write(&path, format!("[{}]", frames.join(",\n"))).expect("write");
        let mut o = options(InputFormat::Auto, Some("coco-17"), Some(30.0));
        o.ground = GroundMode::Auto;
        let imported = import(&path, &o).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(imported.grounding.as_ref().map(|g| g.track_id), Some(0));
        let hips = |s: usize| {
            let f = &imported.sequences[s].frames[0];
            (f.positions_m[11], f.positions_m[12])
        };
        let ((l0, r0), (l1, r1)) = (hips(0), hips(1));
        let (mid0, mid1) = (nalgebra::center(&l0, &r0), nalgebra::center(&l1, &r1));
        assert!(((mid1 - mid0).norm() - 1.2).abs() < 1e-6, "{mid0} {mid1}");
        // Turned away from each other: their hip lines point opposite ways.
        assert!(((r0 - l0).normalize().dot(&(r1 - l1).normalize()) + 1.0).abs() < 1e-6);
        assert!(imported.notes().contains("track 1: grounded with track 0"));
    }

    #[test]
    fn a_bvh_unit_given_on_the_command_line_overrides_the_guess() {
        // 11 units tall: no person's size in cm, m or inches, so the unit cannot be guessed.
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("tiny.bvh");
        let text = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Xposition Yposition Zposition\n  JOINT Head\n  {\n    OFFSET 0 11 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      OFFSET 0 1 0\n    }\n  }\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n0 6 0 0 0 0\n";
        std::fs::write(&path, text).expect("write");
        let map = dir.path().join("map.toml");
        std::fs::write(
            &map,
            "skeleton = \"tiny\"\nrequired = [\"Hips\", \"Head\"]\n[layouts.autoact-landmarks]\npelvis = \"Hips\"\nhead_center = \"Head\"\n",
        )
        .expect("write");
        let mut o = options(InputFormat::Auto, None, None);
        o.bvh_map = Some(map);
        let e = error(&path.display().to_string(), &o);
        assert!(
            e.contains("cannot tell the units") && e.contains("--metres-per-unit 0.01"),
            "{e}"
        );
        o.metres_per_unit = Some(0.15);
        let imported = import(&path, &o).unwrap_or_else(|e| panic!("{e}"));
        let head = imported.sequences[0].frames[0].positions_m[1];
        // Head 11 units above the hips, 6 above the origin: 17 × 0.15 m, +Y up.
        assert!((head.z - 2.55).abs() < 1e-9, "{head}");
    }

    #[test]
    fn a_json_file_reads_in_its_layout_and_keeps_the_reader_error_as_source() {
        let dir = tempfile::tempdir().unwrap();
        let empty = dir.path().join("empty.json");
        std::fs::write(&empty, "[]").unwrap();
        let json = options(InputFormat::Auto, Some("h36m-17"), Some(25.0));
        let err = import(&empty, &json).unwrap_err();
        assert!(matches!(err, ImportError::NoFrames { .. }), "{err}");
        let broken = dir.path().join("broken.json");
        std::fs::write(&broken, "[{").unwrap();
        let err = import(&broken, &json).unwrap_err();
        assert!(
            err.to_string().starts_with("reading ") && err.to_string().ends_with(" as h36m-17")
        );
        assert!(std::error::Error::source(&err).is_some());
        let clip = dir.path().join("clip.json");
        let frame: Vec<[f64; 3]> = (0..17).map(|j| [0.0, -0.1 * f64::from(j), 0.0]).collect();
        let frames: Vec<_> = (0..3)
            .map(|k| serde_json::json!({"frame_id": k, "instances": [{"keypoints": frame}]}))
            .collect();
        std::fs::write(&clip, serde_json::to_string(&frames).unwrap()).unwrap();
        let imported = import(&clip, &json).unwrap();
        assert_eq!(imported.format, InputFormat::MmposeJson);
        assert_eq!(imported.layout, "h36m-17");
        assert_eq!(imported.rate, "25 fps");
        assert_eq!(imported.sequences[0].frames.len(), 3);
        let metadata = imported.metadata(&clip, None, Some("walk".into()));
        let pairs: Vec<(&str, &str)> = metadata
            .iter()
            .map(|(k, v)| (k.as_str(), v.as_str()))
            .collect();
        assert_eq!(
            pairs,
            [
                ("action", "walk"),
                ("category", ""),
                ("format", "MmposeJson"),
                ("layout", "h36m-17"),
                ("rate", "25 fps"),
                ("source", "clip.json"),
            ]
        );
    }

    #[test]
    fn a_record_names_its_format() {
        for f in [
            InputFormat::Bvh,
            InputFormat::Ntu,
            InputFormat::H36mExpmap,
            InputFormat::ZedMat,
            InputFormat::MmposeJson,
        ] {
            assert_eq!(InputFormat::from_record_name(&f.record_name()), Some(f));
        }
        assert_eq!(InputFormat::from_record_name("Auto"), None);
        assert!(InputFormat::from_record_name("ZedMat").is_some_and(InputFormat::is_camera_frame));
        let record = |format: &str| {
            vec![(
                crate::bags::pose::METADATA_NAME.to_string(),
                BTreeMap::from([("format".to_string(), format.to_string())]),
            )]
        };
        assert!(InputFormat::imported_from_estimator(&record("Ntu")));
        assert!(!InputFormat::imported_from_estimator(&record("Bvh")));
        assert!(InputFormat::imported_from_estimator(&record(
            "PanopticJson"
        )));
        assert!(!InputFormat::imported_from_estimator(&[]));
    }
}
