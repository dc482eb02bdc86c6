//! One trim run: a capture bag and its video → clips in the dataset folder, the manifest
//! extended, every list rewritten from it.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use super::lists::{ListSummary, ensure_classes, write_lists};
use super::manifest::Manifest;
use super::plan::{Truncated, VideoTiming, frame_ranges};
use super::split::{SplitConfig, assign, fnv1a};
use super::{ClipRecord, TrimError, label_dirs, sanitize_name};

use crate::bags::capture::Capture;

use crate::video::{
    CutMethod, CutRequest, Ffmpeg, Rational, ReencodeSettings, VideoError, cut, keyframe_frames,
};

/// Folder of the clips inside the dataset folder.
pub const VIDEOS_DIR: &str = "videos";
/// Folder of extracted frames inside the dataset folder.
pub const RAWFRAMES_DIR: &str = "rawframes";

/// Options of a run.
#[derive(Debug, Clone, PartialEq)]
pub struct TrimOptions {
    /// How to split.
    pub split: SplitConfig,
    /// Re-encode every clip, even where stream copy would be exact.
    pub force_reencode: bool,
    /// Encoder settings for re-encoded clips.
    pub reencode: ReencodeSettings,
    /// Also extract every clip's frames as JPEG (`img_00001.jpg` …).
    pub rawframes: bool,
}

/// The capture video and where it sits on the capture's timeline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VideoSource<'a> {
    /// The video.
    pub path: &'a Path,
    /// Timeline stamp of its frame 0, nanoseconds.
    pub frame0_nanos: i128,
    /// Its constant frame rate.
    pub fps: Rational,
}

/// What a run did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TrimSummary {
    /// Clips cut by stream copy in this run.
    pub copied: usize,
    /// Clips re-encoded in this run.
    pub reencoded: usize,
    /// Clips already complete from an earlier run.
    pub skipped: usize,
    /// Segments the video does not fully hold (left out of every list).
    pub truncated: Vec<Truncated>,
    /// Clips in the dataset (all runs), and the list files written.
    pub lists: ListSummary,
    /// Frames cut in this run.
    pub frames_cut: u64,
}

fn character_id(look: &serde_json::Value) -> String {
    format!("{:016x}", fnv1a(&look.to_string()))[..8].to_owned()
}

/// Cuts every segment of `capture` out of `video` into `dir`, skipping clips the manifest
/// already lists (and whose file exists), then rewrites every list from the manifest.
///
/// Stream copy is used where the clip's first frame is a keyframe of `video` (and
/// `force_reencode` is off); a copy that does not hold exactly the clip's frames is redone by
/// re-encoding. `stop` is polled between clips: when set, the run ends early after writing the
/// lists of what is complete.
///
/// # Errors
/// [`TrimError`] for the dataset folder; [`VideoError`] (wrapped in [`RunError::Video`]) for an
/// unreadable video or a failed cut. On every error the lists are still rewritten from the
/// complete clips when possible, so they never name a missing clip.
pub fn trim_capture(
    ffmpeg: &Ffmpeg,
    capture: &Capture,
    source: &VideoSource<'_>,
    dir: &Path,
    options: &TrimOptions,
    progress: &dyn Fn(usize, usize),
    stop: &AtomicBool,
) -> Result<TrimSummary, RunError> {
    let VideoSource {
        path: video,
        frame0_nanos,
        fps,
    } = *source;
    let (frame_count, keyframes) = keyframe_frames(ffmpeg, video)?;
    let timing = VideoTiming {
        frame0_nanos,
        fps,
        frame_count,
    };
    std::fs::create_dir_all(dir).map_err(TrimError::io("create", dir))?;
    ensure_classes(dir, &capture.labels)?;
    let dirs = label_dirs(&capture.labels);
    let mut manifest = Manifest::open(dir)?;
    let (ranges, truncated) = frame_ranges(&capture.segments, &timing);
    let mut summary = TrimSummary {
        truncated,
        ..TrimSummary::default()
    };
    let capture_video = crate::file_name(video);
    let capture_bag = crate::file_name(&capture.path);
    let duration_s = frame_count as f64 / fps.as_f64();
    let resolution = crate::video::probe_size(ffmpeg, video)
        .map(|(w, h)| format!("{w}x{h}"))
        .unwrap_or_default();
    let fps_f = fps.as_f64();

    let mut seen = std::collections::BTreeSet::new();
    let total = ranges.len();
    let mut result: Result<(), RunError> = Ok(());
    for (done, range) in ranges.iter().enumerate() {
        progress(done, total);
        if stop.load(Ordering::Relaxed) {
            result = Err(RunError::Interrupted);
            break;
        }
        let seg = &capture.segments[range.segment];
        let label_id = seg.label_id as usize;
        let (Some(label), Some(label_dir)) = (capture.labels.get(label_id), dirs.get(label_id))
        else {
            result = Err(TrimError::Invalid(format!(
                "`{}`: segment `{}` has label id {}, but the dataset has {} labels",
                capture.path.display(),
                seg.id,
                seg.label_id,
                capture.labels.len()
            ))
            .into());
            break;
        };
        if label != &seg.action {
            tracing::warn!(
                "segment `{}`: action `{}` but label id {label_id} is `{label}`; using the id",
                seg.id,
                seg.action
            );
        }
        let clip_id = sanitize_name(&seg.id.replace('/', "-"));
        if !seen.insert(clip_id.clone()) {
            result = Err(TrimError::Invalid(format!(
                "`{}`: two segments give the clip id `{clip_id}`",
                capture.path.display()
            ))
            .into());
            break;
        }
        let rel = format!("{VIDEOS_DIR}/{label_dir}/{clip_id}.mp4");
        let out = dir.join(&rel);
        if let Some(r) = manifest.records().get(&clip_id)
            && r.capture_bag != capture_bag
        {
            result = Err(TrimError::Invalid(format!(
                "clip `{clip_id}` in `{}` was cut from capture `{}`, not `{capture_bag}`: trim each dataset of captures into its own folder",
                dir.display(),
                r.capture_bag
            ))
            .into());
            break;
        }
        // Complete from an earlier run: the same clip of the same video, at the same place.
        if let Some(r) = manifest.records().get(&clip_id)
            && r.video == rel
            && r.frame_count == range.frame_count
            && r.start_frame == range.start_frame
            && r.capture_video == capture_video
            && out.is_file()
            && (!options.rawframes || r.rawframes.is_some())
        {
            summary.skipped += 1;
            continue;
        }
        if let Some(parent) = out.parent()
            && let Err(source) = std::fs::create_dir_all(parent)
        {
            result = Err(TrimError::io("create", parent)(source).into());
            break;
        }
        let copy_ok =
            !options.force_reencode && keyframes.binary_search(&range.start_frame).is_ok();
        let request = |method| CutRequest {
            input: video,
            output: &out,
            start_frame: range.start_frame,
            frame_count: range.frame_count,
            fps,
            method,
        };
        let mut clip = if copy_ok {
            cut(ffmpeg, &request(CutMethod::StreamCopy), &options.reencode)
        } else {
            cut(ffmpeg, &request(CutMethod::Reencode), &options.reencode)
        };
        if copy_ok && matches!(clip, Err(VideoError::FrameCountMismatch { .. })) {
            tracing::info!(clip = clip_id, "stream copy was not exact; re-encoding");
            clip = cut(ffmpeg, &request(CutMethod::Reencode), &options.reencode);
        }
        let clip = match clip {
            Ok(c) => c,
            Err(e) => {
                result = Err(e.into());
                break;
            }
        };
        let rawframes = if options.rawframes {
            let rel_frames = format!("{RAWFRAMES_DIR}/{label_dir}/{clip_id}");
            if let Err(e) = crate::video::extract_frames(
                ffmpeg,
                &out,
                &dir.join(&rel_frames),
                range.frame_count,
            ) {
                result = Err(e.into());
                break;
            }
            Some(rel_frames)
        } else {
            None
        };
        match clip.method {
            CutMethod::StreamCopy => summary.copied += 1,
            CutMethod::Reencode => summary.reencoded += 1,
        }
        summary.frames_cut += range.frame_count;
        let scene = capture.scenes.iter().find(|s| s.scene_id == seg.scene_id);
        let look = scene
            .and_then(|s| serde_json::to_value(&s.scene.look).ok())
            .unwrap_or(serde_json::Value::Null);
        let record = ClipRecord {
            clip_id: clip_id.clone(),
            video: rel,
            rawframes,
            label: label.clone(),
            label_id: seg.label_id,
            label_dir: label_dir.clone(),
            frame_count: range.frame_count,
            fps: fps_f,
            start_s: range.start_frame as f64 / fps_f,
            end_s: (range.start_frame + range.frame_count) as f64 / fps_f,
            start_frame: range.start_frame,
            method: clip.method,
            capture_video: capture_video.clone(),
            capture_duration_s: duration_s,
            capture_resolution: resolution.clone(),
            capture_bag: capture_bag.clone(),
            session: capture.session.clone(),
            segment_id: seg.id.clone(),
            category: seg.category.clone(),
            animation: seg.animation.clone(),
            variant: seg.variant,
            scene: seg.scene,
            viewpoint: seg.viewpoint,
            scene_id: seg.scene_id.clone(),
            weather: scene
                .map(|s| s.scene.weather.to_string())
                .unwrap_or_default(),
            time: scene.map(|s| s.scene.clock.to_string()).unwrap_or_default(),
            location: scene
                .map(|s| s.scene.location.name.clone())
                .unwrap_or_default(),
            character: character_id(&look),
            character_look: look,
            camera: format!("{}/c{}", seg.scene_id, seg.viewpoint),
            seed: capture.seed,
        };
        if let Err(e) = manifest.append(record) {
            result = Err(e.into());
            break;
        }
    }
    progress(total, total);
    // Lists from what is complete, whatever happened above.
    let complete: std::collections::BTreeMap<String, ClipRecord> = manifest
        .records()
        .iter()
        .filter(|(_, r)| dir.join(&r.video).is_file())
        .map(|(k, r)| (k.clone(), r.clone()))
        .collect();
    let lists = assign(
        &complete.values().cloned().collect::<Vec<_>>(),
        &options.split,
    )
    .and_then(|splits| write_lists(dir, &complete, &splits));
    match (result, lists) {
        (Ok(()), Ok(lists)) => {
            summary.lists = lists;
            Ok(summary)
        }
        (Ok(()), Err(e)) => Err(e.into()),
        (Err(e), lists) => {
            if let Err(l) = lists {
                tracing::warn!("the lists could not be rewritten either (the old ones stay): {l}");
            }
            Err(e)
        }
    }
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RunError {
    /// The dataset folder or the capture.
    #[error(transparent)]
    Trim(#[from] TrimError),
    /// ffmpeg or the video.
    #[error(transparent)]
    Video(#[from] VideoError),
    /// Stopped by a signal; the complete clips are listed, the rest is left for a re-run.
    #[error(
        "interrupted; the lists name the clips complete so far — run the same command again to finish"
    )]
    Interrupted,
}
