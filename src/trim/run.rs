//! One trim run: a capture bag and its video → clips in the dataset folder, the manifest
//! extended, every list rewritten from it.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use super::labels::{
    LabelCollector, LabelSummary, SpooledLabels, sidecar_path, write_label_files,
    write_sidecar_text,
};
use super::lists::{ListSummary, ensure_classes, write_lists};
use super::manifest::Manifest;
use super::motion::video_frame_speeds;
use super::passes::{ClipPasses, PassSources};
use super::plan::{FrameRange, Truncated, VideoTiming, frame_ranges};
use super::planned::scene_values;
use super::policy::{ClipPolicies, clips_of};
use super::qa::{ClipQa, QaSummary, Thresholds, measure_clips, write_qa_report};
use super::sheets::{SheetSummary, write_contact_sheets};
use super::split::{Refined, SplitConfig, SplitItem, assign_clips};
use super::{ActionSpan, ClipRecord, TrimError, label_dirs, part_clip_id};
use crate::dataset::clips::ClipMode;
use crate::skeleton::rig::Rig;

use crate::bags::capture::Capture;
use crate::bags::render::DrawnFrames;
use crate::ros::autoact_msgs::Segment;

use crate::video::{
    CutMethod, CutRequest, Ffmpeg, Mp4Source, Rational, ReencodeSettings, VideoError, cut,
    keyframe_frames,
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
    /// The JPEG quality range of the rawframes, ffmpeg qscale `[min, max]` (2 best … 31): each
    /// clip's is drawn in it from the dataset's seed and the clip's id
    /// ([`crate::video::jpeg_qscale`]).
    pub jpeg_quality: [u8; 2],
    /// Every clip of the dataset's plan, to decide the splits over; `None`: over the clips in
    /// the dataset folder.
    pub planned: Option<Vec<SplitItem>>,
    /// Where a clip is flagged by the quality checks.
    pub qa: Thresholds,
    /// How each class's segments are cut into clips.
    pub clips: ClipPolicies,
    /// Rewrite the dataset-wide files once the clips are cut: the lists and splits, the QA
    /// report, the label files and each class's contact sheet ([`super::sheets`]). They cover
    /// every clip of the folder, so rewriting them after each capture costs time that grows
    /// with the dataset: `generate` leaves them out per capture and writes them once, after its
    /// last ([`relist`]).
    pub lists: bool,
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
    /// The render bag whose per-frame annotations the quality checks read (`None`: no checks).
    pub annotations: Option<&'a Path>,
    /// The timeline frames the video holds, when its render drew only some (`None`: video frame
    /// `k` is timeline frame `k`). Clips are placed on the timeline, then found in the video
    /// through this table; a clip whose frames it lacks is refused, never cut from other frames.
    pub drawn: Option<&'a DrawnFrames>,
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
    /// Segments the clip policy found no clip in (no motion, or shorter than a window).
    pub segments_without_clips: usize,
    /// Clips in the dataset (all runs), and the list files written.
    pub lists: ListSummary,
    /// Frames cut in this run.
    pub frames_cut: u64,
    /// Classes grouped more finely than `--split-by`, having too few groups.
    pub refined: Vec<Refined>,
    /// The quality report over the dataset's clips (`None`: none of them was checked).
    pub qa: Option<QaSummary>,
    /// The pose and box label files (`None`: no clip has labels).
    pub labels: Option<LabelSummary>,
    /// The contact sheet of every class.
    pub sheets: SheetSummary,
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
    // Our own renders are cut in-process; other videos (or ones this reader declines) by ffmpeg.
    let mp4 = Mp4Source::open(source.path)?;
    let (frame_count, keyframes) = match &mp4 {
        Some(m) => (m.frame_count(), m.keyframes()),
        None => keyframe_frames(ffmpeg, source.path)?,
    };
    let timing = timeline(source, frame_count)?;
    std::fs::create_dir_all(dir).map_err(TrimError::io("create", dir))?;
    // Held until this run returns: its manifest and lists then see every clip of any other run.
    let _lock = lock_dataset(dir)?;
    ensure_classes(dir, &capture.labels)?;
    let mut manifest = Manifest::open(dir)?;
    let (segments, truncated) = frame_ranges(&capture.segments, &timing);
    let clips = clip_ranges(capture, &timing, &segments, &options.clips)?;
    let ranges: Vec<FrameRange> = clips.iter().map(|(r, _)| r.clone()).collect();
    let ids: Vec<String> = clips.iter().map(|(_, id)| id.clone()).collect();
    let video_starts = video_starts(source, &timing, &clips)?;
    forget_stale_clips(dir, &mut manifest, capture, &ids)?;
    let mut summary = TrimSummary {
        truncated,
        segments_without_clips: segments.len()
            - ranges
                .iter()
                .map(|r| r.segment)
                .collect::<BTreeSet<_>>()
                .len(),
        ..TrimSummary::default()
    };
    let last_frame = source
        .drawn
        .map_or(frame_count.checked_sub(1), |d| d.frames.last().copied());
    let passes = PassSources::beside(source.path, frame_count, last_frame)?;
    let run = Run {
        ffmpeg,
        capture,
        passes,
        video: source.path,
        mp4,
        fps: source.fps,
        keyframes,
        video_starts,
        dir,
        options,
        label_dirs: label_dirs(&capture.labels),
        capture_video: crate::file_name(source.path),
        capture_bag: crate::file_name(&capture.path),
        duration_s: timing.frame_count as f64 / source.fps.as_f64(),
        resolution: crate::video::probe_size(ffmpeg, source.path)
            .map(|(w, h)| format!("{w}x{h}"))
            .unwrap_or_default(),
    };
    let (qa, labels) = match source.annotations {
        Some(bag) => measure_run(bag, dir, &ids, &ranges, &options.qa)?,
        None => (Vec::new(), None),
    };
    let measured = Measured {
        qa: &qa,
        labels: labels.as_ref(),
    };
    let result = run.cut_all(
        &clips,
        &measured,
        &mut manifest,
        &mut summary,
        progress,
        stop,
    );
    progress(ranges.len(), ranges.len());
    // Lists from what is complete, whatever happened above.
    if !options.lists {
        return result.map(|()| summary);
    }
    let lists = rewrite_lists(ffmpeg, dir, &manifest, options);
    match (result, lists) {
        (
            Ok(()),
            Ok(Rewritten {
                lists,
                refined,
                qa,
                labels,
                sheets,
            }),
        ) => {
            summary.lists = lists;
            summary.refined = refined;
            summary.qa = qa;
            summary.labels = labels;
            summary.sheets = sheets;
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

/// The timing of the render's timeline, which clips are cut on: the video's own frames, or all of
/// the timeline's when the video (of `frame_count` frames) holds only some.
///
/// # Errors
/// [`TrimError::DrawnFrameCount`] when the render bag lists other frames than the video has.
fn timeline(source: &VideoSource<'_>, frame_count: u64) -> Result<VideoTiming, TrimError> {
    if let Some(drawn) = source.drawn
        && drawn.frames.len() as u64 != frame_count
    {
        return Err(TrimError::DrawnFrameCount {
            video: source.path.to_path_buf(),
            video_frames: frame_count,
            listed: drawn.frames.len() as u64,
        });
    }
    Ok(VideoTiming {
        frame0_nanos: source.frame0_nanos,
        fps: source.fps,
        frame_count: source.drawn.map_or(frame_count, |d| d.timeline_frames),
    })
}

/// Every list of the dataset folder `dir` rewritten from its manifest, under the dataset's lock,
/// `labels` being its class list: what `autoact merge` does once the clips and manifest lines of
/// every part are in one folder, and `generate` after its last capture (the lists are those one
/// run over every capture would write).
/// `ffmpeg` draws the classes' contact sheets.
///
/// # Errors
/// [`TrimError`] for the dataset folder, its manifest or its lists.
pub fn relist(
    ffmpeg: &Ffmpeg,
    dir: &Path,
    labels: &[String],
    options: &TrimOptions,
) -> Result<ListSummary, TrimError> {
    std::fs::create_dir_all(dir).map_err(TrimError::io("create", dir))?;
    let _lock = lock_dataset(dir)?;
    ensure_classes(dir, labels)?;
    let manifest = Manifest::open(dir)?;
    Ok(rewrite_lists(ffmpeg, dir, &manifest, options)?.lists)
}

/// The first frame of every clip `policies` cut from a video of `capture` timed as `timing`,
/// sorted: the frames a render makes keyframes so that every clip is a stream copy.
///
/// # Errors
/// As cutting: a segment's label out of range, a label without a policy.
pub fn clip_start_frames(
    capture: &Capture,
    timing: &VideoTiming,
    policies: &ClipPolicies,
) -> Result<Vec<u64>, TrimError> {
    let (segments, _) = frame_ranges(&capture.segments, timing);
    let mut starts: Vec<u64> = clip_ranges(capture, timing, &segments, policies)?
        .iter()
        .map(|(r, _)| r.start_frame)
        .collect();
    starts.sort_unstable();
    starts.dedup();
    Ok(starts)
}

/// The timeline frames some clip `policies` cut from a render of `capture` timed as `timing`
/// uses, as sorted, disjoint ranges: the frames a render for those clips alone has to draw
/// (`generate` without `--keep-intermediates`).
///
/// # Errors
/// As cutting: a segment's label out of range, a label without a policy.
pub fn clip_frames(
    capture: &Capture,
    timing: &VideoTiming,
    policies: &ClipPolicies,
) -> Result<Vec<std::ops::Range<u64>>, TrimError> {
    let (segments, _) = frame_ranges(&capture.segments, timing);
    let mut clips: Vec<std::ops::Range<u64>> = clip_ranges(capture, timing, &segments, policies)?
        .iter()
        .map(|(r, _)| r.start_frame..r.end_frame())
        .filter(|r| !r.is_empty())
        .collect();
    clips.sort_unstable_by_key(|r| (r.start, r.end));
    let mut out: Vec<std::ops::Range<u64>> = Vec::with_capacity(clips.len());
    for r in clips {
        match out.last_mut() {
            Some(last) if r.start <= last.end => last.end = last.end.max(r.end),
            _ => out.push(r),
        }
    }
    Ok(out)
}

/// The video frame each clip (timeline frames) starts at: its own first frame, or, when the
/// video holds only some timeline frames, where the table puts it.
///
/// # Errors
/// [`TrimError::FrameNotInVideo`] naming the video, the clip and the first timeline frame (and
/// its stamp) of the clip that the video does not hold.
fn video_starts(
    source: &VideoSource<'_>,
    timing: &VideoTiming,
    clips: &[(FrameRange, String)],
) -> Result<Vec<u64>, TrimError> {
    clips
        .iter()
        .map(|(range, clip_id)| {
            let Some(drawn) = source.drawn else {
                return Ok(range.start_frame);
            };
            drawn
                .video_start(range.start_frame, range.frame_count)
                .map_err(|frame| TrimError::FrameNotInVideo {
                    video: source.path.to_path_buf(),
                    clip_id: clip_id.clone(),
                    frame,
                    stamp_nanos: timing.frame0_nanos
                        + i128::from(timing.fps.frame_time_nanos(frame)),
                })
        })
        .collect()
}

/// Every clip of the segments the video holds (`segments`, video frames), by each class's clip
/// policy, with its clip id; `instances` reads the motion of the segment's animation from the
/// capture's poses. A segment the policy gives no clip (no motion found, or shorter than a
/// window with `tail = "drop"`) is said on stderr.
///
/// # Errors
/// [`TrimError::ClipPolicy`] for a policy `trim`'s options made unusable;
/// [`TrimError::LabelIdOutOfRange`].
fn clip_ranges(
    capture: &Capture,
    timing: &VideoTiming,
    segments: &[FrameRange],
    policies: &ClipPolicies,
) -> Result<Vec<(FrameRange, String)>, TrimError> {
    let rig = Rig::standard();
    let mut out = Vec::new();
    for range in segments {
        let segment = &capture.segments[range.segment];
        let label = capture
            .labels
            .get(segment.label_id as usize)
            .ok_or_else(|| TrimError::LabelIdOutOfRange {
                bag: capture.path.clone(),
                segment: segment.id.clone(),
                label_id: segment.label_id,
                labels: capture.labels.len(),
            })?;
        let policy = policies.of(label)?;
        let speeds = (policy.policy == ClipMode::Instances)
            .then(|| video_frame_speeds(&rig, capture, timing, range.action.clone()))
            .transpose()
            .map_err(|e| TrimError::CaptureFrames(Box::new(e)))?;
        let clips = clips_of(range, &policy, speeds.as_deref());
        if clips.is_empty() {
            tracing::warn!(
                "segment `{}`: the `{}` clip policy finds no clip in it{}",
                segment.id,
                policy.policy.name(),
                match policy.policy {
                    ClipMode::Instances => " (no burst of motion long enough)",
                    _ => " (shorter than a window)",
                }
            );
        }
        out.extend(clips.into_iter().map(|c| {
            let id = part_clip_id(&segment.id, policy.policy, c.part);
            (c, id)
        }));
    }
    Ok(out)
}

/// Drops from the manifest (and the disk) the clips of this capture's segments that this run
/// does not make — cut by an earlier run under another clip policy — so no list names them.
fn forget_stale_clips(
    dir: &Path,
    manifest: &mut Manifest,
    capture: &Capture,
    ids: &[String],
) -> Result<(), TrimError> {
    let bag = crate::file_name(&capture.path);
    let keep: BTreeSet<&str> = ids.iter().map(String::as_str).collect();
    let segments: BTreeSet<&str> = capture.segments.iter().map(|s| s.id.as_str()).collect();
    let stale: Vec<ClipRecord> = manifest
        .records()
        .values()
        .filter(|r| {
            r.capture_bag == bag
                && r.session == capture.session
                && segments.contains(r.segment_id.as_str())
                && !keep.contains(r.clip_id.as_str())
        })
        .cloned()
        .collect();
    if stale.is_empty() {
        return Ok(());
    }
    tracing::warn!(
        "{} clips of this capture from an earlier run (another clip policy, e.g. `{}`) are removed",
        stale.len(),
        stale[0].clip_id
    );
    manifest.forget(stale.iter().map(|r| r.clip_id.as_str()))?;
    for r in &stale {
        let path = dir.join(&r.video);
        match std::fs::remove_file(&path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(TrimError::io("remove", &path)(e));
            }
            _ => {}
        }
        if let Some(frames) = &r.rawframes {
            let path = dir.join(frames);
            match std::fs::remove_dir_all(&path) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(TrimError::io("remove", &path)(e));
                }
                _ => {}
            }
        }
    }
    Ok(())
}

/// The dataset folder, held for one run: a second `trim` into the same folder waits until the
/// first is done (saying so), so that neither reads the manifest while the other appends to it
/// and the lists written last name every clip. The lock is the kernel's (`flock`) on
/// `.autoact-trim.lock`, released when the run ends, however it ends.
fn lock_dataset(dir: &Path) -> Result<std::fs::File, TrimError> {
    let path = dir.join(".autoact-trim.lock");
    let file = std::fs::OpenOptions::new()
        .create(true)
        .write(true)
        .truncate(false)
        .open(&path)
        .map_err(TrimError::io("open", &path))?;
    match file.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => {
            tracing::warn!(
                "another trim is writing into {}: waiting for it to finish",
                dir.display()
            );
            file.lock().map_err(TrimError::io("lock", &path))?;
        }
        Err(std::fs::TryLockError::Error(e)) => return Err(TrimError::io("lock", &path)(e)),
    }
    Ok(file)
}

/// Flagged clips named one by one on stderr; past this many, only their count.
const FLAGGED_CLIPS_NAMED: usize = 10;

/// What the render bag says of each range's clip: its quality measurements and its labels.
struct Measured<'a> {
    qa: &'a [Option<ClipQa>],
    labels: Option<&'a SpooledLabels>,
}

/// Each range's quality measurements and labels from render bag `bag`, the flagged clips said
/// on stderr (none, also said, when the bag cannot be read: the clips are cut all the same).
/// The labels wait for their clips in a temporary file in the dataset folder `dir`.
///
/// # Errors
/// [`TrimError::Io`] when that file cannot be made, written or read.
fn measure_run(
    bag: &Path,
    dir: &Path,
    ids: &[String],
    ranges: &[FrameRange],
    thresholds: &Thresholds,
) -> Result<(Vec<Option<ClipQa>>, Option<SpooledLabels>), TrimError> {
    let mut collector =
        LabelCollector::new(ranges.iter().map(|r| (r.start_frame, r.frame_count)), dir)?;
    let measured = measure_clips(bag, ranges, thresholds, &mut |i, a, size| {
        collector.push(i, a, size);
    });
    if collector.without_landmarks > 0 {
        tracing::warn!(
            "render bag `{}`: {} frame annotations have no COCO-17/NTU-25 landmarks (a render from before they were annotated: render again for pose labels)",
            bag.display(),
            collector.without_landmarks
        );
    }
    let labels = collector.finish()?;
    Ok(match measured {
        Ok((qa, undecodable)) => {
            if undecodable > 0 {
                tracing::warn!(
                    "render bag `{}`: {undecodable} frame annotations do not decode; the quality checks leave them out",
                    bag.display()
                );
            }
            let flagged: Vec<(usize, &ClipQa)> = qa
                .iter()
                .enumerate()
                .filter_map(|(i, q)| q.as_ref().filter(|q| !q.flags.is_empty()).map(|q| (i, q)))
                .collect();
            for (i, q) in flagged.iter().take(FLAGGED_CLIPS_NAMED) {
                let why: Vec<&str> = q.flags.iter().map(|f| f.describe()).collect();
                tracing::warn!(
                    "clip {}: {} (visible joints {:.0} %, out of sight in {} of {} frames, motion {:.3} m/s)",
                    ids[*i],
                    why.join(", "),
                    100.0 * q.visible_joint_fraction,
                    q.hidden_frames,
                    q.frames,
                    q.motion_m_per_s
                );
            }
            if flagged.len() > FLAGGED_CLIPS_NAMED {
                tracing::warn!(
                    "… and {} more flagged clips (all in annotations/qa.json)",
                    flagged.len() - FLAGGED_CLIPS_NAMED
                );
            }
            (qa, Some(labels))
        }
        Err(e) => {
            tracing::warn!("no quality checks or pose labels for this capture's clips: {e}");
            (Vec::new(), None)
        }
    })
}

/// What [`rewrite_lists`] wrote.
struct Rewritten {
    lists: ListSummary,
    refined: Vec<Refined>,
    qa: Option<QaSummary>,
    labels: Option<LabelSummary>,
    sheets: SheetSummary,
}

/// Every list rewritten from the manifest's clips whose file is on disk, split anew (over the
/// plan's clips when there is one), each class grouped more finely than asked said on stderr;
/// then the quality report, the label files and the contact sheets over those clips.
fn rewrite_lists(
    ffmpeg: &Ffmpeg,
    dir: &Path,
    manifest: &Manifest,
    options: &TrimOptions,
) -> Result<Rewritten, TrimError> {
    let complete: BTreeMap<String, ClipRecord> = manifest
        .records()
        .iter()
        .filter(|(_, r)| dir.join(&r.video).is_file())
        .map(|(k, r)| (k.clone(), r.clone()))
        .collect();
    let clips: Vec<ClipRecord> = complete.values().cloned().collect();
    let splits = assign_clips(options.planned.as_deref(), &clips, &options.split)?;
    for r in &splits.refined {
        tracing::warn!("{r}");
    }
    let lists = write_lists(dir, &complete, &splits)?;
    let qa = write_qa_report(dir, &complete, &options.qa)?;
    let labels = write_label_files(dir, &complete, &splits)?;
    let sheets = write_contact_sheets(ffmpeg, dir, &complete, &options.qa)?;
    Ok(Rewritten {
        lists,
        refined: splits.refined,
        qa,
        labels,
        sheets,
    })
}

/// What every clip of one run shares: the capture, its video and the dataset folder.
struct Run<'a> {
    ffmpeg: &'a Ffmpeg,
    capture: &'a Capture,
    /// The render's depth and mask frames beside the video.
    passes: PassSources,
    video: &'a Path,
    /// The video's samples when stream copies are cut in-process (an MP4 that can be).
    mp4: Option<Mp4Source>,
    fps: Rational,
    /// The video's keyframes (frame indices, sorted): where a stream copy can start.
    keyframes: Vec<u64>,
    /// The video frame each clip of the run starts at ([`video_starts`]).
    video_starts: Vec<u64>,
    dir: &'a Path,
    options: &'a TrimOptions,
    /// The folder name of each class.
    label_dirs: Vec<String>,
    /// The capture video's file name.
    capture_video: String,
    /// The capture bag's file name.
    capture_bag: String,
    /// The capture video's length, seconds.
    duration_s: f64,
    /// The capture video's size, `WxH` (empty if unknown).
    resolution: String,
}

/// Where one segment's clip goes.
struct ClipTarget<'a> {
    segment: &'a Segment,
    /// The clip policy it is cut by.
    policy: ClipMode,
    label: &'a String,
    label_dir: &'a String,
    clip_id: String,
    /// The clip, relative to the dataset folder.
    video: String,
    /// The clip's path.
    out: PathBuf,
}

impl Run<'_> {
    /// Cuts the clip of each range in turn, appending each to the manifest as it completes;
    /// stops at the first error, or when `stop` is set.
    fn cut_all(
        &self,
        ranges: &[(FrameRange, String)],
        measured: &Measured<'_>,
        manifest: &mut Manifest,
        summary: &mut TrimSummary,
        progress: &dyn Fn(usize, usize),
        stop: &AtomicBool,
    ) -> Result<(), RunError> {
        let mut seen = BTreeSet::new();
        for (done, (range, clip_id)) in ranges.iter().enumerate() {
            progress(done, ranges.len());
            if stop.load(Ordering::Relaxed) {
                return Err(RunError::Interrupted);
            }
            let target = self.target(range, clip_id, &mut seen)?;
            if self.is_complete(manifest, &target, range)? {
                summary.skipped += 1;
                continue;
            }
            let at = self
                .video_starts
                .get(done)
                .copied()
                .unwrap_or(range.start_frame);
            let (method, rawframes) = self.cut_clip(&target, range, at)?;
            let passes = self.passes.link_clip(
                self.dir,
                target.label_dir,
                &target.clip_id,
                range.start_frame,
                range.frame_count,
            )?;
            match method {
                CutMethod::StreamCopy => summary.copied += 1,
                CutMethod::Reencode => summary.reencoded += 1,
            }
            summary.frames_cut += range.frame_count;
            let mut record = self.record(target, range, method, rawframes);
            record.depth = passes.depth;
            record.masks = passes.masks;
            record.qa = measured.qa.get(done).cloned().flatten();
            if let Some(text) = measured
                .labels
                .map(|l| l.sidecar_text(done))
                .transpose()?
                .flatten()
            {
                let rel = sidecar_path(&record.label_dir, &record.clip_id);
                write_sidecar_text(self.dir, &rel, &text)?;
                record.labels = Some(rel);
            }
            manifest.append(record)?;
        }
        Ok(())
    }

    /// The segment of `range`, its class and its clip's id and path; `seen` collects the clip
    /// ids so far.
    fn target(
        &self,
        range: &FrameRange,
        clip_id: &str,
        seen: &mut BTreeSet<String>,
    ) -> Result<ClipTarget<'_>, TrimError> {
        let capture = self.capture;
        let segment = &capture.segments[range.segment];
        let label_id = segment.label_id as usize;
        let (Some(label), Some(label_dir)) =
            (capture.labels.get(label_id), self.label_dirs.get(label_id))
        else {
            return Err(TrimError::LabelIdOutOfRange {
                bag: capture.path.clone(),
                segment: segment.id.clone(),
                label_id: segment.label_id,
                labels: capture.labels.len(),
            });
        };
        if label != &segment.action {
            tracing::warn!(
                "segment `{}`: action `{}` but label id {label_id} is `{label}`; using the id",
                segment.id,
                segment.action
            );
        }
        let clip_id = clip_id.to_owned();
        if !seen.insert(clip_id.clone()) {
            return Err(TrimError::DuplicateClipId {
                bag: capture.path.clone(),
                clip_id,
            });
        }
        let video = format!("{VIDEOS_DIR}/{label_dir}/{clip_id}.mp4");
        let policy = self.options.clips.of(label)?.policy;
        Ok(ClipTarget {
            segment,
            policy,
            label,
            label_dir,
            out: self.dir.join(&video),
            clip_id,
            video,
        })
    }

    /// The JPEG qscale of clip `clip_id`'s rawframes: drawn in the options' range, keyed by the
    /// dataset's seed and the clip's id (the same on every run and in every shard).
    fn rawframe_qscale(&self, clip_id: &str) -> u8 {
        crate::video::jpeg_qscale(
            self.options.jpeg_quality,
            crate::hash::hash2(self.capture.seed.unwrap_or(0), crate::hash::of_str(clip_id)),
        )
    }

    /// Whether the manifest holds `target` complete from an earlier run: the same clip of the
    /// same video, at the same place, with its frames if they are asked for (at its drawn JPEG
    /// quality).
    ///
    /// # Errors
    /// [`TrimError::OtherCapture`] if the manifest's clip of that id is from another capture.
    fn is_complete(
        &self,
        manifest: &Manifest,
        target: &ClipTarget<'_>,
        range: &FrameRange,
    ) -> Result<bool, TrimError> {
        let Some(r) = manifest.records().get(&target.clip_id) else {
            return Ok(false);
        };
        if r.capture_bag != self.capture_bag {
            return Err(TrimError::OtherCapture {
                clip_id: target.clip_id.clone(),
                dir: self.dir.to_path_buf(),
                existing_bag: r.capture_bag.clone(),
                bag: self.capture_bag.clone(),
            });
        }
        Ok(r.video == target.video
            && r.policy == target.policy
            && r.action_span.as_ref() == Some(&ActionSpan::of(range, self.fps.as_f64()))
            && r.frame_count == range.frame_count
            && r.start_frame == range.start_frame
            && r.capture_video == self.capture_video
            && target.out.is_file()
            && (!self.options.rawframes
                || (r.rawframes.is_some()
                    && r.jpeg_quality.unwrap_or(crate::video::JPEG_QSCALE_BEST)
                        == self.rawframe_qscale(&target.clip_id)))
            && self.passes.covered_by(&ClipPasses {
                depth: r.depth.clone(),
                masks: r.masks.clone(),
            }))
    }

    /// One segment → one clip, starting at frame `at` of the video (the clip's first timeline
    /// frame there): by stream copy where that frame is a keyframe (and re-encoding is not
    /// forced), re-encoded otherwise or when the copy does not hold exactly its frames ([`cut`]
    /// verifies the count); then its frames, with `--rawframes`. Returns how it was cut and its
    /// frames' folder, relative to the dataset folder.
    fn cut_clip(
        &self,
        target: &ClipTarget<'_>,
        range: &FrameRange,
        at: u64,
    ) -> Result<(CutMethod, Option<String>), RunError> {
        let out = &target.out;
        if let Some(parent) = out.parent() {
            std::fs::create_dir_all(parent).map_err(TrimError::io("create", parent))?;
        }
        let copy_ok = !self.options.force_reencode && self.keyframes.binary_search(&at).is_ok();
        let request = |method| CutRequest {
            input: self.video,
            output: out,
            start_frame: at,
            frame_count: range.frame_count,
            fps: self.fps,
            method,
        };
        let reencode = &self.options.reencode;
        let method = if copy_ok {
            CutMethod::StreamCopy
        } else {
            CutMethod::Reencode
        };
        let mut clip = match (&self.mp4, method) {
            (Some(mp4), CutMethod::StreamCopy) if Mp4Source::writes(out) => {
                mp4.cut(out, at, range.frame_count)
            }
            _ => cut(self.ffmpeg, &request(method), reencode),
        };
        if copy_ok && matches!(clip, Err(VideoError::FrameCountMismatch { .. })) {
            tracing::info!(
                clip = target.clip_id,
                "stream copy was not exact; re-encoding"
            );
            clip = cut(self.ffmpeg, &request(CutMethod::Reencode), reencode);
        }
        let clip = clip?;
        if !self.options.rawframes {
            return Ok((clip.method, None));
        }
        let rel_frames = format!("{RAWFRAMES_DIR}/{}/{}", target.label_dir, target.clip_id);
        crate::video::extract_frames(
            self.ffmpeg,
            out,
            &self.dir.join(&rel_frames),
            range.frame_count,
            self.rawframe_qscale(&target.clip_id),
        )?;
        Ok((clip.method, Some(rel_frames)))
    }

    /// The manifest record of a clip cut by `method`.
    fn record(
        &self,
        target: ClipTarget<'_>,
        range: &FrameRange,
        method: CutMethod,
        rawframes: Option<String>,
    ) -> ClipRecord {
        let capture = self.capture;
        let seg = target.segment;
        let fps_f = self.fps.as_f64();
        let scene = capture
            .scenes
            .iter()
            .find(|s| s.scene_id == seg.scene_id)
            .map(|s| &s.scene);
        let values = scene_values(scene);
        let jpeg_quality = rawframes
            .as_ref()
            .map(|_| self.rawframe_qscale(&target.clip_id));
        ClipRecord {
            clip_id: target.clip_id,
            video: target.video,
            rawframes,
            jpeg_quality,
            depth: None,
            masks: None,
            label: target.label.clone(),
            label_id: seg.label_id,
            label_dir: target.label_dir.clone(),
            frame_count: range.frame_count,
            fps: fps_f,
            start_s: range.start_frame as f64 / fps_f,
            end_s: (range.start_frame + range.frame_count) as f64 / fps_f,
            start_frame: range.start_frame,
            method,
            capture_video: self.capture_video.clone(),
            capture_duration_s: self.duration_s,
            capture_resolution: self.resolution.clone(),
            capture_bag: self.capture_bag.clone(),
            session: capture.session.clone(),
            segment_id: seg.id.clone(),
            category: seg.category.clone(),
            animation: seg.animation.clone(),
            variant: seg.variant,
            scene: seg.scene,
            viewpoint: seg.viewpoint,
            scene_id: seg.scene_id.clone(),
            weather: values.weather,
            time: values.time,
            location: values.location,
            character: values.character,
            character_look: values.look,
            camera: format!("{}/c{}", seg.scene_id, seg.viewpoint),
            seed: capture.seed,
            policy: target.policy,
            part: range.part,
            action_span: Some(ActionSpan::of(range, fps_f)),
            qa: None,
            labels: None,
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
