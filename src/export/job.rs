//! `autoact export` as one call: list a bag's animations, or export the selected ones, every
//! target checked before anything is written.

use std::path::{Path, PathBuf};

use super::{AnimationListing, Clip, EncodeOptions, ExportError, ExportFormat, bvh, gltf, onim};
use crate::loss::Losses;
use crate::mcap_io::{BagReader, McapIoError};
use crate::skeleton::rig::Rig;

/// What `autoact export` was asked.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ExportRequest {
    /// The animation bag.
    pub input: Option<PathBuf>,
    /// The output format.
    pub format: Option<ExportFormat>,
    /// Output file (one animation) or folder (several).
    pub output: Option<PathBuf>,
    /// Only this track.
    pub animation: Option<u64>,
    /// Only this variant.
    pub variant: Option<u32>,
    /// Only this scene of a capture bag (its index on the timeline).
    pub scene: Option<usize>,
    /// Replace output files that exist.
    pub force: bool,
    /// List the animations instead of exporting them.
    pub list: bool,
    /// Output frame rate; default: the bag's.
    pub fps: Option<f64>,
    /// A `.onim` bone mapping file; default: the built-in one.
    pub onim_template: Option<PathBuf>,
    /// Beside every `X.bvh` also write `X.expected.json`.
    pub write_expected_json: bool,
}

/// Why an export failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExportJobError {
    /// No bag given.
    #[error("give the animation bag to export")]
    NoInput,
    /// No format or output given.
    #[error("give `--format` and `-o OUT`")]
    NoFormatOrOutput,
    /// The frame rate is not a positive number.
    #[error("--fps must be a positive number of frames per second, not {0}")]
    Fps(f64),
    /// `--write-expected-json` with another format than BVH.
    #[error("--write-expected-json is for --format bvh only")]
    ExpectedJsonNotBvh,
    /// Several files to write (animations, or scenes of a capture bag) but one file named.
    #[error(
        "{count} animations are selected (an animation of a capture bag is one per scene), and `{}` names one .{extension} file: give a folder for them, or pick one with `--animation`, `--variant` and, for a capture bag, `--scene` (`--list` shows them)",
        output.display()
    )]
    OneFileForMany {
        /// Files to write: animations selected, times their scenes in a capture bag.
        count: usize,
        /// The output named.
        output: PathBuf,
        /// The format's extension.
        extension: &'static str,
    },
    /// `--scene` names no scene of the bag that holds frames of the selected animations.
    #[error("{}: no scene {scene} among the selected animations' scenes: {available}", path.display())]
    UnknownScene {
        /// The bag.
        path: PathBuf,
        /// The scene asked for.
        scene: usize,
        /// The scenes there are (`<index> <scene id>`), or why there are none.
        available: String,
    },
    /// The bag cannot be opened.
    #[error(transparent)]
    Bag(#[from] McapIoError),
    /// Reading, selecting or writing animations failed.
    #[error(transparent)]
    Export(#[from] ExportError),
    /// The `.onim` mapping is invalid or does not cover the rig.
    #[error(transparent)]
    Onim(#[from] onim::OnimError),
    /// The output folder could not be made.
    #[error("cannot create the output folder {}", path.display())]
    CreateDir {
        /// The folder.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The expected JSON could not be encoded.
    #[error("cannot encode the expected JSON")]
    ExpectedJson(#[source] serde_json::Error),
}

/// What an export did: the text to print, and what of the bag could not be used.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ExportReport {
    /// The `--list` table, or one line per file written.
    pub text: String,
    /// What of the bag could not be read or used (each once, however many animations were
    /// read): the run exits 3 when there is any.
    pub losses: Losses,
}

impl crate::outcome::LostInput for ExportReport {
    fn lost_input(&self) -> bool {
        !self.losses.is_empty()
    }
}

/// Does what `request` asks: the `--list` table, or the files written, and what of the bag was
/// lost (unreadable chunks, a missing summary, frames that do not decode or do not advance).
///
/// # Errors
/// [`ExportJobError`]: an unreadable bag or one without animation frames, an unknown animation
/// or variant, an output that exists (without `force`) or cannot be written, a `.onim` mapping
/// that is invalid or does not cover the rig. A refused export writes nothing.
pub fn export(request: &ExportRequest) -> Result<ExportReport, ExportJobError> {
    let Some(input) = request.input.as_deref() else {
        return Err(ExportJobError::NoInput);
    };
    if let Some(f) = request.fps
        && !(f.is_finite() && f > 0.0)
    {
        return Err(ExportJobError::Fps(f));
    }
    let readers = BagReader::open_all(input)?;
    let (available, listed_losses) = super::list(input, &readers)?;
    if request.list {
        let fps = request.fps.or_else(|| super::stated_frame_rate(&readers));
        let scenes = crate::bags::capture::scene_starts(&readers);
        let mut losses = Losses::from_animation(&listed_losses);
        let text = if scenes.is_empty() {
            listing(&available, fps)
        } else {
            // A capture bag: one row per animation and scene, as the export writes them.
            let rig = Rig::standard();
            let mut clips = Vec::new();
            for a in &available {
                let (read, lost) =
                    super::read_clips(&rig, input, &readers, a.key, request.fps, &scenes)?;
                clips.extend(read);
                losses.merge(Losses::from_animation(&lost));
            }
            scene_listing(&clips)
        };
        return Ok(ExportReport { text, losses });
    }
    let (Some(format), Some(output)) = (request.format, request.output.as_deref()) else {
        return Err(ExportJobError::NoFormatOrOutput);
    };
    if request.write_expected_json && format != ExportFormat::Bvh {
        return Err(ExportJobError::ExpectedJsonNotBvh);
    }
    let rig = Rig::standard();
    let options = EncodeOptions {
        onim_mapping: match (format, &request.onim_template) {
            (ExportFormat::Onim, Some(path)) => Some(onim::OnimMapping::load(&rig, path)?),
            (ExportFormat::Onim, None) => Some(onim::OnimMapping::builtin(&rig)?),
            (_, _) => None,
        },
        gltf_scene: None,
    };
    if request.onim_template.is_some() && format != ExportFormat::Onim {
        tracing::warn!("--onim-template is only used with --format onim");
    }
    let keys = super::select(input, &available, request.animation, request.variant)?;
    // A capture bag's scenes each have their own character: one clip per animation and scene.
    let scenes = crate::bags::capture::scene_starts(&readers);
    let mut clips = Vec::new();
    let mut report = ExportReport::default();
    for key in keys {
        let (read, losses) = super::read_clips(&rig, input, &readers, key, request.fps, &scenes)?;
        clips.extend(read);
        report.losses.merge(Losses::from_animation(&losses));
    }
    if let Some(scene) = request.scene {
        clips = only_scene(input, clips, scene)?;
    }
    let (targets, folder) = targets(input, output, &clips, format)?;
    // Every target is checked before anything is written, and the folder is made only when the
    // first file is ready, so a refused export writes nothing.
    for path in &targets {
        super::check_writable(path, request.force)?;
        if request.write_expected_json {
            super::check_writable(&expected_path(path), request.force)?;
        }
    }
    let job = Job {
        rig: &rig,
        input,
        readers: &readers,
        format,
        options: &options,
        request,
    };
    let mut folder = folder;
    for (clip, path) in clips.iter().zip(&targets) {
        report.text.push_str(&job.write(clip, path, folder.take())?);
    }
    Ok(report)
}

/// What every animation of one export shares.
struct Job<'a> {
    rig: &'a Rig,
    input: &'a Path,
    readers: &'a [BagReader],
    format: ExportFormat,
    options: &'a EncodeOptions,
    request: &'a ExportRequest,
}

impl Job<'_> {
    /// Encodes and writes one clip to `path` (making `folder` first, if given); returns the line
    /// saying so.
    fn write(
        &self,
        clip: &Clip,
        path: &Path,
        folder: Option<&Path>,
    ) -> Result<String, ExportJobError> {
        let (rig, input, force) = (self.rig, self.input, self.request.force);
        let bytes = if matches!(self.format, ExportFormat::Gltf | ExportFormat::Glb) {
            let scene = gltf::SceneContext::read(rig, input, self.readers, clip)?;
            let options = EncodeOptions {
                gltf_scene: Some(scene),
                ..self.options.clone()
            };
            super::encode(rig, clip, self.format, &options)?
        } else {
            super::encode(rig, clip, self.format, self.options)?
        };
        if let Some(folder) = folder {
            std::fs::create_dir_all(folder).map_err(|source| ExportJobError::CreateDir {
                path: folder.to_path_buf(),
                source,
            })?;
        }
        super::write_atomically(path, &bytes, force)?;
        if self.request.write_expected_json {
            let json = serde_json::to_vec(&bvh::expected_json(rig, clip))
                .map_err(ExportJobError::ExpectedJson)?;
            super::write_atomically(&expected_path(path), &json, force)?;
        }
        let scene = clip.scene.as_ref().map_or_else(String::new, |s| {
            format!(
                ", scene {} (capture frames {}..{})",
                s.scene_id,
                s.first_timeline_frame,
                s.first_timeline_frame
                    .saturating_add(u64::try_from(clip.poses.len()).unwrap_or(u64::MAX))
            )
        });
        Ok(format!(
            "wrote {}: {}{scene}, {} frames at {} fps\n",
            path.display(),
            clip.key,
            clip.poses.len(),
            clip.fps_hz
        ))
    }
}

/// The file each clip goes to (see "Output naming" in `autoact export --help`), and the folder
/// they go in when `output` names one (created only once every target is known to be writable).
fn targets<'o>(
    input: &Path,
    output: &'o Path,
    clips: &[Clip],
    format: ExportFormat,
) -> Result<(Vec<PathBuf>, Option<&'o Path>), ExportJobError> {
    if clips.len() == 1 && !output.is_dir() {
        return Ok((vec![output.to_path_buf()], None));
    }
    if clips.len() > 1
        && output
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case(format.extension()))
    {
        return Err(ExportJobError::OneFileForMany {
            count: clips.len(),
            output: output.to_path_buf(),
            extension: format.extension(),
        });
    }
    let paths = clips
        .iter()
        .map(|c| output.join(super::output_name(input, c.key, c.scene.as_ref(), format)))
        .collect();
    Ok((paths, Some(output)))
}

/// The clips of scene `scene` (its index on the capture's timeline).
///
/// # Errors
/// [`ExportJobError::UnknownScene`] when none is, naming the scenes there are.
fn only_scene(input: &Path, clips: Vec<Clip>, scene: usize) -> Result<Vec<Clip>, ExportJobError> {
    let mut available: Vec<String> = clips
        .iter()
        .filter_map(|c| c.scene.as_ref())
        .map(|s| format!("{} ({})", s.index, s.scene_id))
        .collect();
    available.dedup();
    let chosen: Vec<Clip> = clips
        .into_iter()
        .filter(|c| c.scene.as_ref().is_some_and(|s| s.index == scene))
        .collect();
    if chosen.is_empty() {
        return Err(ExportJobError::UnknownScene {
            path: input.to_path_buf(),
            scene,
            available: if available.is_empty() {
                "the bag has no /scene (not a capture bag)".to_string()
            } else {
                available.join(", ")
            },
        });
    }
    Ok(chosen)
}

/// `X.bvh` → `X.expected.json`.
fn expected_path(path: &Path) -> PathBuf {
    path.with_extension("expected.json")
}

/// The `--list` table of a capture bag: a row per animation and scene (what a file holds).
fn scene_listing(clips: &[Clip]) -> String {
    let rows: Vec<Vec<String>> = clips
        .iter()
        .map(|c| {
            let (index, id, first) = c.scene.as_ref().map_or_else(
                || ("-".to_string(), "-".to_string(), 0),
                |s| {
                    (
                        s.index.to_string(),
                        s.scene_id.clone(),
                        s.first_timeline_frame,
                    )
                },
            );
            let frames = u64::try_from(c.poses.len()).unwrap_or(u64::MAX);
            vec![
                c.key.track_id.to_string(),
                c.key.variant.to_string(),
                index,
                format!("{first}..{}", first.saturating_add(frames)),
                c.poses.len().to_string(),
                format!("{:.2}", c.fps_hz),
                id,
            ]
        })
        .collect();
    crate::table::table(
        &[
            "track",
            "variant",
            "scene",
            "capture frames",
            "frames",
            "fps",
            "scene id",
        ],
        &rows,
    )
}

/// The `--list` table.
fn listing(available: &[AnimationListing], fps: Option<f64>) -> String {
    let rows: Vec<Vec<String>> = available
        .iter()
        .map(|a| {
            let seconds = crate::skeleton::pose::nanos_to_secs(
                a.last_stamp_nanos.saturating_sub(a.first_stamp_nanos),
            );
            vec![
                a.key.track_id.to_string(),
                a.key.variant.to_string(),
                a.frames.to_string(),
                format!("{seconds:.3}"),
                fps.or(a.frame_rate_hz)
                    .map_or_else(|| "-".to_string(), |f| format!("{f:.2}")),
                a.rig.clone(),
            ]
        })
        .collect();
    crate::table::table(
        &["track", "variant", "frames", "seconds", "fps", "rig"],
        &rows,
    )
}
