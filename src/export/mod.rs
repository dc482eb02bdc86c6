//! Export: animations of an animation bag → files other tools play (`autoact export`).
//!
//! **What is exported.** An *animation* is one `(track_id, variant)` pair of the bag's
//! `/animation` frames ([`AnimationKey`]): a person, and either the animation as converted
//! (variant 0) or one of its DSI variants. [`list`] names them all (`autoact export BAG --list`);
//! [`read_clips`] reads one with the body its `/tf_static` rest offsets describe, at the bag's
//! frame rate ([`frame_rate`]). A capture bag (`autoact convert --spec`) holds every clip of a
//! session on one timeline, and draws a new character (body proportions) for every scene: there a
//! `(track, variant)` is read as one [`Clip`] per scene, each on that scene's body, so that every
//! exported frame puts the joints where the bag does (a warning says when frames are not evenly
//! spaced).
//!
//! **Formats.** Each format is a module that turns a [`Clip`] into the bytes of one file and
//! knows nothing of paths: [`bvh`] (Biovision Hierarchy, for Blender, MotionBuilder, Maya) and
//! [`onim`] (GTA V's text animation, for OpenIV/CodeWalker → `.ycd`) and [`gltf`] (glTF 2.0 /
//! GLB: the skinned body, its animation and a capture's camera, for Blender and other engines).
//! [`ExportFormat`] lists them.
//!
//! **Output files.** [`write_atomically`] writes through a hidden temporary file in the target folder
//! and renames it into place, so an interrupted export never leaves a complete-looking file; an
//! existing file is replaced only when asked. [`output_name`] names one file per animation (and
//! per scene, for a capture bag) when several are exported into a folder.

pub mod bvh;
pub mod gltf;
pub mod job;
pub mod onim;

use std::path::{Path, PathBuf};

use crate::bags::animation::AnimationLosses;
pub use crate::bags::animation::{AnimationKey, AnimationListing};
use crate::mcap_io::BagReader;
use crate::skeleton::character::Character;
use crate::skeleton::fk::BonePose;
use crate::skeleton::pose::{frame_rate, nanos_to_secs};
use crate::skeleton::rig::Rig;

/// Why an export failed. Every variant names the file it is about.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExportError {
    /// The bag holds no readable `/animation` frames.
    #[error(
        "{path}: no /animation frames (autoact_msgs/msg/BoneFrame): not an animation bag; `autoact convert` makes one from a pose bag"
    )]
    NotAnimationBag {
        /// The bag.
        path: PathBuf,
    },
    /// The asked-for animation (track and/or variant) is not in the bag.
    #[error("{path}: no animation with {wanted}; the bag holds: {available}")]
    UnknownAnimation {
        /// The bag.
        path: PathBuf,
        /// What was asked for, e.g. `track 3` or `track 0 variant 2`.
        wanted: String,
        /// What the bag has, e.g. `track 0 variant 0, track 0 variant 1`.
        available: String,
    },
    /// The frames of an animation could not be used.
    #[error("{path}: {key}: {source}")]
    BadAnimation {
        /// The bag.
        path: PathBuf,
        /// Which animation.
        key: AnimationKey,
        /// What was wrong.
        #[source]
        source: Box<crate::bags::animation::ReadAnimationError>,
    },
    /// A capture bag's camera and scenes cannot be read.
    #[error("{path}: {key}: {source}")]
    Capture {
        /// The bag.
        path: PathBuf,
        /// Which animation.
        key: AnimationKey,
        /// Why.
        #[source]
        source: Box<crate::bags::capture::TimelineError>,
    },
    /// A capture bag has no camera pose at one of the animation's frames.
    #[error("{path}: {key}: no camera pose at the frame stamped {stamp_nanos} ns")]
    NoCameraPose {
        /// The bag.
        path: PathBuf,
        /// Which animation.
        key: AnimationKey,
        /// The frame's stamp.
        stamp_nanos: u64,
    },
    /// No frame rate: the bag states none and has too few frames to measure one.
    #[error(
        "{path}: {key}: cannot tell the frame rate (no `fps` in the bag's metadata and fewer than two frames); give `--fps`"
    )]
    NoFrameRate {
        /// The bag.
        path: PathBuf,
        /// Which animation.
        key: AnimationKey,
    },
    /// The output exists and replacing it was not asked for.
    #[error("{0} exists; pass `--force` to replace it")]
    OutputExists(PathBuf),
    /// A file system error.
    #[error("cannot {action} {path}")]
    Io {
        /// What was being done.
        action: &'static str,
        /// The file or folder.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
}

/// The export formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, clap::ValueEnum)]
pub enum ExportFormat {
    /// BVH: the rig's hierarchy in cm, Y-up, ZXY Euler rotations (Blender, MotionBuilder, Maya).
    Bvh,
    /// GTA V `.onim` text (Version 8 2), for OpenIV/CodeWalker to make a `.ycd`.
    Onim,
    /// glTF 2.0 JSON (buffer embedded): the skinned body, its animation, the capture's camera.
    Gltf,
    /// glTF 2.0 binary (`.glb`), the same content as `gltf`.
    Glb,
}

impl ExportFormat {
    /// The file extension, without the dot.
    #[must_use]
    pub fn extension(self) -> &'static str {
        match self {
            ExportFormat::Bvh => "bvh",
            ExportFormat::Onim => "onim",
            ExportFormat::Gltf => "gltf",
            ExportFormat::Glb => "glb",
        }
    }
}

/// One animation ready to write: its frames at a fixed rate, on one body.
#[derive(Debug, Clone, PartialEq)]
pub struct Clip {
    /// Which animation of the bag.
    pub key: AnimationKey,
    /// Frames per second; frame `k` plays at `k / fps_hz` seconds.
    pub fps_hz: f64,
    /// The body: rest offsets of every bone (from the bag's `/tf_static`).
    pub character: Character,
    /// The poses, one per frame, in order.
    pub poses: Vec<BonePose>,
    /// The bag's stamp of every frame (same length as `poses`), ns: what ties a frame to the
    /// rest of the bag (camera, scenes, segments).
    pub stamps_nanos: Vec<u64>,
    /// For a capture bag, the one scene the clip's frames belong to (its character is that
    /// scene's); `None` for a plain animation bag.
    pub scene: Option<ClipScene>,
}

impl Clip {
    /// `poses` on the rig's standard character at `fps_hz`, as track 0's original animation,
    /// frame `k` stamped `k / fps_hz` s after 0: a clip to write from poses made in code.
    #[must_use]
    pub fn from_poses(rig: &Rig, fps_hz: f64, poses: Vec<BonePose>) -> Clip {
        Clip {
            key: AnimationKey {
                track_id: 0,
                variant: 0,
            },
            fps_hz,
            character: Character::standard(rig),
            stamps_nanos: (0..poses.len())
                .map(|k| crate::skeleton::pose::stamp_nanos_at(k, fps_hz))
                .collect(),
            poses,
            scene: None,
        }
    }
}

/// The scene of a capture bag a [`Clip`] holds the frames of.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ClipScene {
    /// Its index among the bag's scenes, in time order (0 = the first).
    pub index: usize,
    /// Its id in the recording hierarchy (`SceneState.scene_id`).
    pub scene_id: String,
    /// The clip's first frame on the capture's timeline: frame `k` of the clip is frame
    /// `first_timeline_frame + k` of the capture (the first scene's start is frame 0, and the
    /// timeline runs at the clip's rate), the frame numbers `autoact render` and `trim` use.
    pub first_timeline_frame: u64,
}

/// Every animation of the bag, ordered by track id, then variant, and what could not be read.
///
/// # Errors
/// [`ExportError::NotAnimationBag`] when there is none.
pub fn list(
    path: &Path,
    readers: &[BagReader],
) -> Result<(Vec<AnimationListing>, AnimationLosses), ExportError> {
    let (all, losses) = crate::bags::animation::list_animations_with_losses(readers);
    if all.is_empty() {
        return Err(ExportError::NotAnimationBag {
            path: path.to_path_buf(),
        });
    }
    Ok((all, losses))
}

/// The animations `track` and `variant` select from `available` (`None`: every one), in
/// `available`'s order.
///
/// # Errors
/// [`ExportError::UnknownAnimation`] when nothing matches, naming what the bag holds.
pub fn select(
    path: &Path,
    available: &[AnimationListing],
    track: Option<u64>,
    variant: Option<u32>,
) -> Result<Vec<AnimationKey>, ExportError> {
    let chosen: Vec<AnimationKey> = available
        .iter()
        .map(|a| a.key)
        .filter(|k| track.is_none_or(|t| k.track_id == t) && variant.is_none_or(|v| k.variant == v))
        .collect();
    if chosen.is_empty() {
        let wanted = match (track, variant) {
            (Some(t), Some(v)) => format!("track {t} variant {v}"),
            (Some(t), None) => format!("track {t}"),
            (None, Some(v)) => format!("variant {v}"),
            (None, None) => "any track".to_string(),
        };
        return Err(ExportError::UnknownAnimation {
            path: path.to_path_buf(),
            wanted,
            available: available
                .iter()
                .map(|a| a.key.to_string())
                .collect::<Vec<_>>()
                .join(", "),
        });
    }
    Ok(chosen)
}

/// The frame rate the bag states: the `fps` of its `autoact.convert` or `autoact.dataset`
/// metadata record (what `autoact convert` resampled to), if any.
#[must_use]
pub fn stated_frame_rate(readers: &[BagReader]) -> Option<f64> {
    readers
        .iter()
        .flat_map(BagReader::metadata)
        .filter(|(name, _)| {
            name == crate::bags::animation::METADATA_NAME
                || name == crate::bags::capture::METADATA_NAME
        })
        .find_map(|(_, record)| record.get("fps").and_then(|v| v.parse::<f64>().ok()))
        .filter(|f| f.is_finite() && *f > 0.0)
}

/// The first frame whose stamp is more than half a frame away from `first + k / fps_hz`, as
/// `(k, seconds off)`: frames a fixed-rate file would play at the wrong time. `stamps_nanos` is
/// in increasing order.
#[must_use]
pub fn first_uneven_frame(stamps_nanos: &[u64], fps_hz: f64) -> Option<(usize, f64)> {
    let first = *stamps_nanos.first()?;
    stamps_nanos.iter().enumerate().find_map(|(k, &s)| {
        #[expect(clippy::cast_precision_loss, reason = "frame counts far below 2^52")]
        let expected = k as f64 / fps_hz;
        let off = nanos_to_secs(s.saturating_sub(first)) - expected;
        (off.abs() > 0.5 / fps_hz).then_some((k, off))
    })
}

/// Reads animation `key` of the bag as [`Clip`]s at `fps_hz` (`None`: [`stated_frame_rate`],
/// else measured from the stamps), warning when a clip's frames are not evenly spaced at that
/// rate; with what of the bag could not be used. `scenes` are the scenes of a capture bag
/// ([`crate::bags::capture::scene_starts`]): then there is one clip per scene that holds frames
/// of the animation, each on the body that scene's `/tf_static` and `/tf` carry. Without scenes
/// (a plain animation bag) there is one clip, on the bag's body.
///
/// # Errors
/// [`ExportError::BadAnimation`] for frames that do not fit the rig, [`ExportError::NoFrameRate`].
pub fn read_clips(
    rig: &Rig,
    path: &Path,
    readers: &[BagReader],
    key: AnimationKey,
    fps_hz: Option<f64>,
    scenes: &[crate::bags::capture::SceneStart],
) -> Result<(Vec<Clip>, AnimationLosses), ExportError> {
    let starts: Vec<u64> = scenes.iter().map(|s| s.start_nanos).collect();
    let (periods, losses) = crate::bags::animation::read_animation_periods_with_losses(
        rig,
        readers,
        Some(key.track_id),
        key.variant,
        &starts,
    )
    .map_err(|source| ExportError::BadAnimation {
        path: path.to_path_buf(),
        key,
        source: Box::new(source),
    })?;
    let all_stamps: Vec<u64> = periods
        .iter()
        .flat_map(|p| p.frames.iter().map(|f| f.stamp_nanos))
        .collect();
    let fps_hz = frame_rate(fps_hz.or_else(|| stated_frame_rate(readers)), &all_stamps)
        .ok_or_else(|| ExportError::NoFrameRate {
            path: path.to_path_buf(),
            key,
        })?;
    let mut clips = Vec::with_capacity(periods.len());
    for period in periods {
        let stamps: Vec<u64> = period.frames.iter().map(|f| f.stamp_nanos).collect();
        let scene = scenes.get(period.period).map(|s| ClipScene {
            index: period.period,
            scene_id: s.scene_id.clone(),
            first_timeline_frame: timeline_frame(&starts, stamps[0], fps_hz),
        });
        if let Some((k, off)) = first_uneven_frame(&stamps, fps_hz) {
            let within = scene
                .as_ref()
                .map_or_else(String::new, |s| format!(" in scene {}", s.scene_id));
            tracing::warn!(
                "{}: {key}{within}: frames are not evenly spaced at {fps_hz} fps (frame {k} is {off:+.3} s off); the export plays them back to back",
                path.display()
            );
        }
        clips.push(Clip {
            key,
            fps_hz,
            character: period.character,
            poses: period.frames.into_iter().map(|f| f.pose).collect(),
            stamps_nanos: stamps,
            scene,
        });
    }
    Ok((clips, losses))
}

/// The frame of the capture timeline stamped `stamp`: whole frames at `fps_hz` since the first
/// scene's start (`starts[0]`).
fn timeline_frame(starts: &[u64], stamp: u64, fps_hz: f64) -> u64 {
    let since = nanos_to_secs(stamp.saturating_sub(starts.first().copied().unwrap_or(stamp)));
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "a non-negative frame count far below 2^52"
    )]
    let frame = (since * fps_hz).round() as u64;
    frame
}

/// The file name of animation `key` of bag `bag` when several are exported into one folder:
/// `<bag stem>_track<T>_v<V>.<ext>`, and for the clip of one scene of a capture bag
/// `<bag stem>_track<T>_v<V>_scene<I>.<ext>` (`I`: the scene's index on the capture's timeline,
/// [`ClipScene::index`]; scene ids are long paths, the file's glTF extras and the export's report
/// name them), where the stem is the bag's file name without `.mcap` and `.anim` or `.capture`,
/// with every character other than ASCII letters, digits, `-` and `_` replaced by `_`.
#[must_use]
pub fn output_name(
    bag: &Path,
    key: AnimationKey,
    scene: Option<&ClipScene>,
    format: ExportFormat,
) -> String {
    let name = bag
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let stem = name.strip_suffix(".mcap").unwrap_or(&name);
    let stem = stem
        .strip_suffix(".anim")
        .or_else(|| stem.strip_suffix(".capture"))
        .unwrap_or(stem);
    let mut name: String = stem
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if name.is_empty() {
        name.push_str("animation");
    }
    let scene = scene.map_or_else(String::new, |s| format!("_scene{}", s.index));
    format!(
        "{name}_track{}_v{}{scene}.{}",
        key.track_id,
        key.variant,
        format.extension()
    )
}

/// Fails with [`ExportError::OutputExists`] when `path` exists and `force` is not set.
///
/// # Errors
/// As said.
pub fn check_writable(path: &Path, force: bool) -> Result<(), ExportError> {
    if !force && path.symlink_metadata().is_ok() {
        return Err(ExportError::OutputExists(path.to_path_buf()));
    }
    Ok(())
}

/// Writes `bytes` to `path` so that it appears only complete ([`crate::atomic_file::write`]):
/// an interrupted export leaves no file that looks finished. An existing `path` is replaced only
/// with `force`.
///
/// # Errors
/// [`ExportError::OutputExists`], or [`ExportError::Io`] naming the file.
pub fn write_atomically(path: &Path, bytes: &[u8], force: bool) -> Result<(), ExportError> {
    check_writable(path, force)?;
    let written = if force {
        crate::atomic_file::write(path, bytes)
    } else {
        crate::atomic_file::write_new(path, bytes)
    };
    match written {
        // Made by someone else while this export was writing: still not replaced.
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => check_writable(path, false),
        Err(source) => Err(ExportError::Io {
            action: "write",
            path: path.to_path_buf(),
            source,
        }),
        Ok(()) => Ok(()),
    }
}

/// What [`encode`] needs besides the clip, per format.
#[derive(Debug, Clone, Default)]
pub struct EncodeOptions {
    /// The `.onim` bone mapping (the built-in default when `None`).
    pub onim_mapping: Option<onim::OnimMapping>,
    /// The glTF camera, look and extras of the clip ([`gltf::SceneContext::read`]); none: the
    /// body and animation only.
    pub gltf_scene: Option<gltf::SceneContext>,
}

/// The bytes of `clip` in `format`.
///
/// # Errors
/// [`onim::OnimError`] when the `.onim` mapping does not cover the rig.
pub fn encode(
    rig: &Rig,
    clip: &Clip,
    format: ExportFormat,
    options: &EncodeOptions,
) -> Result<Vec<u8>, onim::OnimError> {
    Ok(match format {
        ExportFormat::Bvh => bvh::write(rig, clip).into_bytes(),
        ExportFormat::Onim => {
            let default;
            let mapping = if let Some(m) = &options.onim_mapping {
                m
            } else {
                default = onim::OnimMapping::builtin(rig)?;
                &default
            };
            onim::write(rig, clip, mapping)?.into_bytes()
        }
        ExportFormat::Gltf | ExportFormat::Glb => {
            let container = if format == ExportFormat::Glb {
                gltf::Container::Glb
            } else {
                gltf::Container::Gltf
            };
            let plain = gltf::SceneContext::default();
            gltf::write(
                rig,
                clip,
                options.gltf_scene.as_ref().unwrap_or(&plain),
                container,
            )
        }
    })
}

#[cfg(test)]
mod tests;
