//! `autoact trim` as one call: find ffmpeg, read the capture, place the video's frame 0 on the
//! capture's timeline (from the render bag beside it, or as given), cut with a progress bar, and
//! say what was done.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use super::TrimError;
use super::planned::PlannedClips;
use super::policy::ClipPolicies;
use super::qa::Thresholds;
use super::run::{RunError, TrimOptions, TrimSummary, VideoSource, trim_capture};
use super::split::{Key, SplitConfig};
use crate::bags::capture::{Capture, TimelineError};
use crate::bags::render::{DrawnFrames, RenderBagError, RenderedVideo, render_bag_beside};
use crate::dataset::clips::ClipsSection;
use crate::progress::Progress;
use crate::skeleton::rig::Rig;
use crate::video::{Ffmpeg, Rational, ReencodeSettings, VideoError};

/// What to trim, and how.
#[derive(Debug, Clone, PartialEq)]
pub struct TrimJob {
    /// The capture bag.
    pub capture: PathBuf,
    /// The capture's video.
    pub video: PathBuf,
    /// The dataset folder.
    pub output: PathBuf,
    /// Timeline time of video frame 0, seconds after the timeline's first frame; `None`: from
    /// the render bag.
    pub video_start_s: Option<f64>,
    /// The video's frame rate; default: the render bag's, else the capture's.
    pub video_fps: Option<f64>,
    /// The video's render bag; default: beside the video.
    pub render_bag: Option<PathBuf>,
    /// What clips of one split share.
    pub split_by: Key,
    /// Train, val and test fractions.
    pub split_ratios: [f64; 3],
    /// Seed of the split; default: the dataset's.
    pub seed: Option<u64>,
    /// Values whose clips all go to test.
    pub hold_out: Vec<(Key, String)>,
    /// The dataset's plan, to decide the splits over; default: `plan.json` beside the capture
    /// bag or one folder up ([`PlannedClips::find`]), when there is one.
    pub plan: Option<PathBuf>,
    /// Re-encode every clip.
    pub force_reencode: bool,
    /// Encoder settings for re-encoded clips.
    pub reencode: ReencodeSettings,
    /// Also extract every clip's frames.
    pub rawframes: bool,
    /// Their JPEG quality range, ffmpeg qscale `[min, max]` (a checked range), drawn per clip;
    /// `None`: the capture bag's recorded `[randomise] jpeg_quality`, else the best (2).
    pub jpeg_quality: Option<[u8; 2]>,
    /// Download ffmpeg when it is not installed.
    pub download_ffmpeg: bool,
    /// Clip policy keys that override the plan's for every class.
    pub clips: ClipsSection,
}

/// What a trim job did, for the summary it prints.
#[derive(Debug, Clone, PartialEq)]
pub struct TrimReport {
    /// What the run did.
    pub summary: TrimSummary,
    /// The video's frame rate.
    pub fps: Rational,
    /// Wall time, seconds.
    pub seconds: f64,
    /// The dataset folder.
    pub output: PathBuf,
    /// How the split was drawn.
    pub split: SplitConfig,
    /// The plan the splits were decided over, and its number of clips; `None`: over the clips
    /// in the dataset folder.
    pub plan: Option<(PathBuf, usize)>,
}

/// Why a trim job failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TrimJobError {
    /// ffmpeg is missing or could not be downloaded.
    #[error(transparent)]
    Ffmpeg(#[from] VideoError),
    /// The capture bag cannot be read.
    #[error(transparent)]
    Capture(#[from] TimelineError),
    /// The video does not exist.
    #[error("`{}`: no such video", .0.display())]
    NoVideo(PathBuf),
    /// `--video-start` is not a number.
    #[error("--video-start {0}: must be a number of seconds")]
    VideoStart(f64),
    /// The frame rate is not a positive number.
    #[error("frame rate {0}: must be a positive number")]
    FrameRate(f64),
    /// The capture bag's recorded `[randomise]`, whose `jpeg_quality` trim uses, is not usable.
    #[error("`{}`: {source} (pass `--jpeg-quality`)", path.display())]
    RecordedRandomise {
        /// The capture bag.
        path: PathBuf,
        /// What is wrong with it.
        #[source]
        source: crate::dataset::randomise::RecordedRandomiseError,
    },
    /// No render bag places the video on the timeline.
    #[error(
        "no render bag `{}` beside the video, so its frame 0 cannot be placed on the capture's timeline: pass `--video-start SECONDS` (and `--video-fps`) for a video autoact did not render, or `--render-bag`",
        .0.display()
    )]
    NoRenderBag(PathBuf),
    /// The render bag cannot be read or is of another capture.
    #[error(transparent)]
    RenderBag(#[from] RenderBagError),
    /// The plan given with `--plan` cannot be read or is of another dataset.
    #[error(transparent)]
    Plan(#[from] TrimError),
    /// Stopped by a signal; the complete clips are listed.
    #[error(transparent)]
    Interrupted(Box<RunError>),
    /// Cutting or listing failed; the complete clips are kept and listed.
    #[error(
        "trimming `{}` into `{}` (complete clips are kept and listed; run again to resume)",
        video.display(),
        output.display()
    )]
    Trim {
        /// The video.
        video: PathBuf,
        /// The dataset folder.
        output: PathBuf,
        /// The cause (boxed: it is large).
        #[source]
        source: Box<RunError>,
    },
}

/// Runs `job`: finds ffmpeg, reads the capture, places the video on its timeline and cuts every
/// segment into the dataset folder, showing a progress bar; `stop` ends the run after the clip
/// being cut, with the lists naming what is complete.
///
/// # Errors
/// [`TrimJobError`].
pub fn trim_job(job: &TrimJob, stop: &AtomicBool) -> Result<TrimReport, TrimJobError> {
    let ffmpeg = Ffmpeg::locate_or_download(job.download_ffmpeg)?;
    let capture = Capture::read(&Rig::standard(), &job.capture)?;
    if !job.video.is_file() {
        return Err(TrimJobError::NoVideo(job.video.clone()));
    }
    let (frame0_nanos, fps, drawn) = place_video(job, &capture)?;
    let plan = planned_clips(job, &capture)?;
    let options = TrimOptions {
        split: SplitConfig {
            by: job.split_by,
            ratios: job.split_ratios,
            seed: job.seed.or(capture.seed).unwrap_or(0),
            hold_out: job.hold_out.clone(),
        },
        force_reencode: job.force_reencode,
        reencode: job.reencode.clone(),
        rawframes: job.rawframes,
        jpeg_quality: match job.jpeg_quality {
            Some(q) => q,
            None => {
                crate::dataset::randomise::Randomise::recorded(capture.randomise.as_deref())
                    .map_err(|source| TrimJobError::RecordedRandomise {
                        path: capture.path.clone(),
                        source,
                    })?
                    .jpeg_quality
            }
        },
        planned: plan.as_ref().map(|p| p.items.clone()),
        qa: Thresholds::default(),
        clips: ClipPolicies {
            by_label: plan.as_ref().map(|p| p.clips.clone()).unwrap_or_default(),
            overrides: job.clips,
        },
        lists: true,
    };
    // The quality checks read the render bag's annotations, when there is one (a video placed
    // by `--video-start` may have none).
    let annotations = Some(
        job.render_bag
            .clone()
            .unwrap_or_else(|| render_bag_beside(&job.video)),
    )
    .filter(|b| b.is_file());
    let bar = Progress::bar("trimming", "clips", false, capture.segments.len() as u64);
    let started = Instant::now();
    let progress = |done: usize, total: usize| bar.update(done as u64, total as u64);
    let source = VideoSource {
        path: &job.video,
        frame0_nanos,
        fps,
        annotations: annotations.as_deref(),
        drawn: drawn.as_ref(),
    };
    let result = trim_capture(
        &ffmpeg,
        &capture,
        &source,
        &job.output,
        &options,
        &progress,
        stop,
    );
    bar.finish();
    let summary = match result {
        Ok(s) => s,
        Err(e @ RunError::Interrupted) => return Err(TrimJobError::Interrupted(Box::new(e))),
        Err(source) => {
            return Err(TrimJobError::Trim {
                video: job.video.clone(),
                output: job.output.clone(),
                source: Box::new(source),
            });
        }
    };
    Ok(TrimReport {
        summary,
        fps,
        seconds: started.elapsed().as_secs_f64(),
        output: job.output.clone(),
        split: options.split,
        plan: plan.map(|p| (p.path, p.items.len())),
    })
}

/// The plan to decide the splits over: `--plan`, which must be this capture's; else
/// `plan.json` beside the capture bag, or one folder up as `generate` keeps it
/// ([`PlannedClips::find`]), when it is this capture's. Without one, says on stderr that the
/// splits are drawn over the clips trimmed so far.
fn planned_clips(job: &TrimJob, capture: &Capture) -> Result<Option<PlannedClips>, TrimJobError> {
    if let Some(path) = &job.plan {
        let plan = PlannedClips::read(path)?;
        plan.check(capture)?;
        return Ok(Some(plan));
    }
    let path = PlannedClips::find(&job.capture);
    let so_far = format!(
        "splits are drawn over the clips in `{}` so far, and a clip's split may change as other captures of the dataset are trimmed into it",
        job.output.display()
    );
    if !path.is_file() {
        tracing::warn!(
            "no `{}` beside the capture bag, nor one folder up: {so_far} (pass the dataset's plan with --plan)",
            path.display()
        );
        return Ok(None);
    }
    match PlannedClips::read(&path).and_then(|plan| plan.check(capture).map(|()| plan)) {
        Ok(plan) => Ok(Some(plan)),
        Err(e) => {
            tracing::warn!("{e}; {so_far} (pass the dataset's plan with --plan)");
            Ok(None)
        }
    }
}

/// The timeline stamp of video frame 0 and the video's frame rate: from `--video-start` (and
/// `--video-fps`) when given, else from the render bag, with the timeline frames the video holds
/// when the render drew only some.
fn place_video(
    job: &TrimJob,
    capture: &Capture,
) -> Result<(i128, Rational, Option<DrawnFrames>), TrimJobError> {
    let video_fps = |default: f64| {
        let fps = job.video_fps.unwrap_or(default);
        Rational::from_f64(fps)
            .filter(|_| fps.is_finite() && fps > 0.0)
            .ok_or(TrimJobError::FrameRate(fps))
    };
    if let Some(start_s) = job.video_start_s {
        if !start_s.is_finite() {
            return Err(TrimJobError::VideoStart(start_s));
        }
        let first = capture.stamps.first().unwrap_or(0);
        #[expect(
            clippy::cast_possible_truncation,
            reason = "seconds of video fit in i128 ns"
        )]
        let offset = (start_s * 1e9).round() as i128;
        return Ok((i128::from(first) + offset, video_fps(capture.fps)?, None));
    }
    let bag = job
        .render_bag
        .clone()
        .unwrap_or_else(|| render_bag_beside(&job.video));
    if !bag.exists() {
        return Err(TrimJobError::NoRenderBag(bag));
    }
    let rendered = RenderedVideo::read(&bag)?;
    rendered.check_renders(capture)?;
    let video_name = crate::file_name(&job.video);
    if !rendered.video_file.is_empty() && rendered.video_file != video_name {
        tracing::warn!(
            "render bag `{}` was written for video `{}`; using its timing for `{video_name}`",
            bag.display(),
            rendered.video_file
        );
    }
    let fps = match job.video_fps {
        Some(_) => video_fps(rendered.fps.as_f64())?,
        None => rendered.fps,
    };
    Ok((rendered.frame0_nanos, fps, rendered.drawn))
}

impl TrimReport {
    /// The summary printed at the end: clips and speed, segments left out, clips per split.
    #[must_use]
    pub fn report(&self) -> String {
        let (summary, seconds) = (&self.summary, self.seconds);
        let mut text = format!(
            "trimmed {} clips ({} by stream copy, {} re-encoded, {} already complete) in {seconds:.1} s",
            summary.copied + summary.reencoded + summary.skipped,
            summary.copied,
            summary.reencoded,
            summary.skipped
        );
        if summary.frames_cut > 0 {
            #[expect(clippy::cast_precision_loss, reason = "display only")]
            let realtime = summary.frames_cut as f64 / self.fps.as_f64() / seconds.max(1e-9);
            text.push_str(&format!(" ({realtime:.0}x real time)"));
        }
        text.push('\n');
        if summary.segments_without_clips > 0 {
            text.push_str(&format!(
                "  {} segments gave no clip under their clip policy (see the warnings)\n",
                summary.segments_without_clips
            ));
        }
        if !summary.truncated.is_empty() {
            text.push_str(&format!(
                "  {} segments left out: the video does not cover them\n",
                summary.truncated.len()
            ));
        }
        let over = match &self.plan {
            Some((path, clips)) => format!("over the {clips} clips of {}", path.display()),
            None => "over the clips trimmed so far: no plan".to_owned(),
        };
        text.push_str(&format!(
            "  dataset {}: {} (split by {}, seed {}, {over})\n",
            self.output.display(),
            summary.lists.split_counts(),
            self.split.by.name(),
            self.split.seed
        ));
        for r in &summary.refined {
            text.push_str(&format!("  {r}\n"));
        }
        if let Some(qa) = &summary.qa {
            text.push_str(&qa.to_string());
        }
        let sheets = &summary.sheets;
        if sheets.drawn + sheets.unchanged > 0 {
            text.push_str(&format!(
                "  contact sheets: {} classes in {} ({} drawn now){}\n",
                sheets.drawn + sheets.unchanged,
                sheets.dir.display(),
                sheets.drawn,
                if sheets.failed.is_empty() {
                    String::new()
                } else {
                    format!(
                        "; {} could not be drawn (see the warnings)",
                        sheets.failed.len()
                    )
                }
            ));
        }
        if let Some(l) = &summary.labels {
            text.push_str(&format!(
                "  pose labels: {} clips in {} and {} (COCO-17 px, NTU-25 m), coco_keypoints_{{train,val,test}}.json{}\n",
                l.clips,
                super::labels::SKELETON_2D_FILE,
                super::labels::SKELETON_3D_FILE,
                if l.without > 0 {
                    format!("; {} clips without (no render bag annotations)", l.without)
                } else {
                    String::new()
                }
            ));
        }
        text
    }
}

/// A `--split-ratios`, `--hold-out` or `--jpeg-quality` value that cannot be used, saying what
/// is expected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct SplitArgError(String);

/// Parses `TRAIN,VAL,TEST` fractions (non-negative, not all zero).
///
/// # Errors
/// [`SplitArgError`] saying what is expected.
pub fn parse_ratios(s: &str) -> Result<[f64; 3], SplitArgError> {
    let parts: Vec<f64> = s
        .split(',')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .map_err(|_| SplitArgError(format!("`{p}` is not a number")))
        })
        .collect::<Result<_, _>>()?;
    let [a, b, c] = parts[..] else {
        return Err(SplitArgError(format!(
            "`{s}`: give three fractions TRAIN,VAL,TEST, e.g. 0.7,0.15,0.15"
        )));
    };
    if ![a, b, c].iter().all(|r| r.is_finite() && *r >= 0.0) || a + b + c <= 0.0 {
        return Err(SplitArgError(format!(
            "`{s}`: fractions must be non-negative and not all zero"
        )));
    }
    Ok([a, b, c])
}

/// Parses a `--jpeg-quality`: one ffmpeg qscale `Q` or a range `MIN,MAX` (2 best … 31).
///
/// # Errors
/// [`SplitArgError`] saying what is expected.
pub fn parse_jpeg_quality(s: &str) -> Result<[u8; 2], SplitArgError> {
    let parts: Vec<u8> = s
        .split(',')
        .map(|p| {
            p.trim()
                .parse::<u8>()
                .map_err(|_| SplitArgError(format!("`{p}` is not a whole number")))
        })
        .collect::<Result<_, _>>()?;
    let range = match parts[..] {
        [q] => [q, q],
        [lo, hi] => [lo, hi],
        _ => {
            return Err(SplitArgError(format!(
                "`{s}`: give one qscale Q or a range MIN,MAX, e.g. 2,8"
            )));
        }
    };
    crate::video::check_jpeg_qscale(range).map_err(|e| SplitArgError(format!("`{s}`: {e}")))?;
    Ok(range)
}

/// Parses a `KEY=VALUE` hold-out (`weather=RAIN`).
///
/// # Errors
/// [`SplitArgError`] saying what is expected.
pub fn parse_hold_out(s: &str) -> Result<(Key, String), SplitArgError> {
    use clap::ValueEnum;
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| SplitArgError(format!("`{s}`: expected KEY=VALUE, e.g. weather=RAIN")))?;
    let key = Key::from_str(k, true).map_err(|_| {
        SplitArgError(format!(
            "`{k}`: hold out by weather, location, time, character, animation, variant or scene"
        ))
    })?;
    Ok((key, v.to_owned()))
}

impl crate::outcome::LostInput for TrimReport {
    /// Whether segments were left out (the video does not cover them): exit code 3.
    fn lost_input(&self) -> bool {
        !self.summary.truncated.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::{parse_hold_out, parse_jpeg_quality, parse_ratios};
    use crate::trim::split::Key;

    #[test]
    fn jpeg_qualities_parse_or_say_what_is_expected() {
        assert_eq!(parse_jpeg_quality("2").unwrap(), [2, 2]);
        assert_eq!(parse_jpeg_quality("4, 12").unwrap(), [4, 12]);
        for (bad, says) in [
            ("1", "qscale"),
            ("12,4", "qscale"),
            ("2,40", "qscale"),
            ("x", "whole number"),
            ("2,3,4", "MIN,MAX"),
        ] {
            let e = parse_jpeg_quality(bad).unwrap_err().to_string();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn ratios_and_hold_outs_parse_or_say_what_is_expected() {
        assert_eq!(parse_ratios("0.8,0.1,0.1").unwrap(), [0.8, 0.1, 0.1]);
        assert_eq!(parse_ratios("1, 0, 0").unwrap(), [1.0, 0.0, 0.0]);
        assert!(
            parse_ratios("0.8,0.2")
                .unwrap_err()
                .to_string()
                .contains("TRAIN,VAL,TEST")
        );
        assert!(parse_ratios("0,0,0").is_err());
        assert!(parse_ratios("-1,1,1").is_err());
        assert_eq!(
            parse_hold_out("weather=RAIN").unwrap(),
            (Key::Weather, "RAIN".to_owned())
        );
        assert_eq!(
            parse_hold_out("time=23:00").unwrap(),
            (Key::Time, "23:00".to_owned())
        );
        assert!(
            parse_hold_out("weather")
                .unwrap_err()
                .to_string()
                .contains("KEY=VALUE")
        );
        assert!(parse_hold_out("colour=red").is_err());
    }
}
