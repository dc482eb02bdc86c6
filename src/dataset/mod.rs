//! Datasets: a spec (what to record), its hierarchical plan (every scene drawn, every viewpoint
//! placed, every clip on a timeline), and the capture bags `convert --spec` writes from it.

pub mod capture;
pub mod clips;
pub mod plan;
pub mod plan_report;
pub mod randomise;
pub mod spec;

use std::path::{Path, PathBuf};

use crate::formats::import::{self, ImportError, ImportOptions, Imported, InputFormat};
use crate::mcap_io::{BagReader, McapIoError};
use crate::skeleton::ground::GroundMode;
use crate::skeleton::lengths::LengthMode;
use crate::skeleton::pose::PoseSequence;
use spec::Spec;

/// A spec source that is a dataset file `autoact import` reads rather than a bag — BVH,
/// NTU `.skeleton`, Human3.6M `.txt`, ZED or UTD-MHAD `.mat`, CMU Panoptic `.json` or a folder
/// of them — read with `import`'s defaults (grounded if it is estimator output in a camera's
/// frame); `None` for anything else (a bag or a rosbag2 folder, or MMPose JSON, which has no
/// frame rate of its own: import it first).
#[must_use]
pub fn import_source(path: &Path) -> Option<Result<Imported, Box<ImportError>>> {
    if !(path.is_dir() && crate::formats::panoptic::folder_holds_scenes(path)) {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        if !matches!(ext.as_str(), "bvh" | "skeleton" | "txt" | "mat" | "json") {
            return None;
        }
        if ext == "json" && import::detect_format(path).ok()? != InputFormat::PanopticJson {
            let path = path.to_path_buf();
            return Some(Err(Box::new(ImportError::JsonInSpec { path })));
        }
    }
    let options = ImportOptions {
        format: InputFormat::Auto,
        layout: None,
        bvh_map: None,
        fps: None,
        axes: None,
        metres_per_unit: None,
        ground: GroundMode::Auto,
        lengths: LengthMode::Measured,
    };
    Some(import::import(path, &options).map_err(Box::new))
}

/// The sequence of person `track` (the first with frames when `None`) of an imported source.
#[must_use]
pub fn imported_track(imported: &Imported, track: Option<u64>) -> Option<&PoseSequence> {
    imported
        .sequences
        .iter()
        .find(|s| track.is_none_or(|t| s.track_id == t) && !s.frames.is_empty())
}

/// Why a source's length cannot be estimated.
#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    /// The source's bag cannot be opened.
    #[error(
        "{key}: {source} (a source is a pose or animation bag, or a file `autoact import` reads: .bvh, .skeleton, .txt, .mat, a CMU Panoptic .json or folder)"
    )]
    Open {
        /// The spec key of the source, e.g. `class[2].sources[0]`.
        key: String,
        /// Why.
        #[source]
        source: McapIoError,
    },
    /// A bag without a readable message (nor summary statistics).
    #[error("{key}: {path} has no readable message to plan with")]
    NoSummary {
        /// The spec key of the source.
        key: String,
        /// The bag file.
        path: PathBuf,
    },
    /// A dataset file that cannot be imported.
    #[error("{key}: {source}")]
    Import {
        /// The spec key of the source.
        key: String,
        /// Why.
        #[source]
        source: Box<ImportError>,
    },
    /// A dataset file without the person the spec names.
    #[error("{key}: {} has no person with frames{}", path.display(), track.map_or_else(String::new, |t| format!(" with track id {t}")))]
    NoTrack {
        /// The spec key of the source.
        key: String,
        /// The file.
        path: PathBuf,
        /// The track id asked for.
        track: Option<u64>,
    },
}

/// Each source's estimated length at the output rate, `[class][source]`: its bag's time range
/// (from the summary, no message read; for an unfinished bag, from its readable messages) at the
/// spec's speed, both ends included.
///
/// # Errors
/// [`EstimateError`]: a bag that cannot be opened or has no summary statistics, named.
pub fn estimated_frames(spec: &Spec) -> Result<Vec<Vec<u64>>, EstimateError> {
    let fps = spec.file.dataset.fps;
    let speed = spec.file.dsi.speed;
    spec.sources
        .iter()
        .enumerate()
        .map(|(k, sources)| {
            sources
                .iter()
                .enumerate()
                .map(|(i, s)| {
                    let key = format!("class[{k}].sources[{i}]");
                    if let Some(imported) = import_source(&s.path) {
                        let imported = imported.map_err(|source| EstimateError::Import {
                            key: key.clone(),
                            source,
                        })?;
                        let seq = imported_track(&imported, s.track).ok_or_else(|| {
                            EstimateError::NoTrack {
                                key: key.clone(),
                                path: s.path.clone(),
                                track: s.track,
                            }
                        })?;
                        let first = seq.frames.first().map_or(0, |f| f.stamp_nanos);
                        let last = seq.frames.last().map_or(0, |f| f.stamp_nanos);
                        return Ok(frames_at(last - first, fps, speed));
                    }
                    let readers =
                        BagReader::open_all(&s.path).map_err(|source| EstimateError::Open {
                            key: key.clone(),
                            source,
                        })?;
                    let mut range: Option<(u64, u64)> = None;
                    for r in &readers {
                        let (a, b) =
                            r.time_range_or_scan()
                                .ok_or_else(|| EstimateError::NoSummary {
                                    key: key.clone(),
                                    path: r.path().to_path_buf(),
                                })?;
                        range = Some(range.map_or((a, b), |(x, y)| (x.min(a), y.max(b))));
                    }
                    let (a, b) = range.unwrap_or((0, 0));
                    Ok(frames_at(b - a, fps, speed))
                })
                .collect()
        })
        .collect()
}

/// Frames at `fps` of a source lasting `nanos` played at `speed`, both ends included.
fn frames_at(nanos: u64, fps: f64, speed: f64) -> u64 {
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "frame counts far inside f64's exact range"
    )]
    let frames = (crate::skeleton::pose::nanos_to_secs(nanos) * fps / speed).round() as u64;
    frames + 1
}
