//! `autoact render` as one call: check the outputs, find ffmpeg, read the capture bag, render it
//! with a progress bar, and say what was written.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use super::session::{Outputs, RenderError, RenderSettings, RenderSummary, render_capture};
use crate::bags::capture::{Capture, TimelineError};
use crate::dataset::randomise::{Randomise, RecordedRandomiseError};
use crate::progress::Progress;
use crate::skeleton::rig::Rig;
use crate::video::{Ffmpeg, VideoError};

/// What to render, and where to.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderJob {
    /// The capture bag.
    pub capture: PathBuf,
    /// Where to write (at least one of video, frames and preview).
    pub outputs: Outputs,
    /// Output size, pixels; default: the capture's camera resolution.
    pub resolution: Option<(u32, u32)>,
    /// Output frame rate; default: the capture's.
    pub fps: Option<f64>,
    /// Render only the first this many frames.
    pub limit: Option<usize>,
    /// x264 constant rate factor.
    pub crf: u8,
    /// x264 preset.
    pub preset: String,
    /// x264 options after the preset (empty: none).
    pub x264_options: String,
    /// Longest keyframe interval, frames.
    pub gop_frames: Option<u32>,
    /// x264 threads.
    pub encoder_threads: u8,
    /// Put the encoded stream into the render bag, as which viewer's message.
    pub embed_video: Option<crate::bags::render::EmbedVideo>,
    /// Replace outputs that exist.
    pub force: bool,
    /// Download ffmpeg when it is not installed.
    pub download_ffmpeg: bool,
    /// Which engine draws the frames.
    pub engine: super::blender::Engine,
    /// Draw without any randomisation (`--no-randomise`); otherwise with the `[randomise]` the
    /// capture bag recorded (the defaults for a bag without one), as `generate` does.
    pub no_randomise: bool,
}

/// What a render job did, for the summary it prints.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderReport {
    /// What the renderer wrote.
    pub summary: RenderSummary,
    /// Output size, pixels.
    pub width: u32,
    /// Output size, pixels.
    pub height: u32,
    /// The output frame rate.
    pub fps: f64,
    /// Wall time, seconds.
    pub seconds: f64,
    /// The PNG frame folder, if asked for.
    pub frames_dir: Option<PathBuf>,
    /// The depth pass's folder, if asked for.
    pub depth_dir: Option<PathBuf>,
    /// The mask pass's folder, if asked for.
    pub mask_dir: Option<PathBuf>,
}

/// Why a render job failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderJobError {
    /// No output asked for.
    #[error("nothing to write: give `-o VIDEO`, `--frames-out DIR` or `--preview PNG`")]
    NothingToWrite,
    /// An output exists and replacing it was not asked for.
    #[error("`{}` exists; pass `--force` to replace it", .0.display())]
    OutputExists(PathBuf),
    /// An output's folder could not be made.
    #[error("cannot create the folder `{}`", path.display())]
    CreateDir {
        /// The folder.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// A depth or mask folder of the video replaced could not be removed.
    #[error("cannot remove `{}`, the passes of the video replaced", path.display())]
    RemoveStale {
        /// The folder.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// ffmpeg is missing or could not be downloaded.
    #[error(transparent)]
    Ffmpeg(#[from] VideoError),
    /// The capture bag cannot be read.
    #[error(transparent)]
    Capture(#[from] TimelineError),
    /// The frame rate is not a positive number.
    #[error("--fps {0}: must be a positive number")]
    Fps(f64),
    /// The capture bag's recorded `[randomise]` cannot be used.
    #[error("`{}`", path.display())]
    Randomise {
        /// The capture bag.
        path: PathBuf,
        /// The cause.
        #[source]
        source: RecordedRandomiseError,
    },
    /// The render failed.
    #[error("rendering `{}`", path.display())]
    Render {
        /// The capture bag.
        path: PathBuf,
        /// The cause (boxed: it is large).
        #[source]
        source: Box<RenderError>,
    },
}

/// Runs `job`: checks its outputs (nothing is replaced without `force`), makes their folders,
/// finds ffmpeg when a video is asked for, reads the capture and renders it, showing a
/// progress bar; `stop` abandons the render.
///
/// # Errors
/// [`RenderJobError`]; on a render error no output that looks complete is left.
pub fn render_job(job: &RenderJob, stop: &AtomicBool) -> Result<RenderReport, RenderJobError> {
    let outputs = &job.outputs;
    if outputs.video.is_none() && outputs.frames_dir.is_none() && outputs.preview.is_none() {
        return Err(RenderJobError::NothingToWrite);
    }
    prepare_outputs(outputs, job.force)?;
    let ffmpeg = match outputs.video {
        Some(_) => Some(Ffmpeg::locate_or_download(job.download_ffmpeg)?),
        None => None,
    };
    let rig = Rig::standard();
    let capture = Capture::read(&rig, &job.capture)?;
    let (width, height) = job
        .resolution
        .unwrap_or((capture.intrinsics.width_px, capture.intrinsics.height_px));
    if let Some(fps) = job.fps
        && !(fps.is_finite() && fps > 0.0)
    {
        return Err(RenderJobError::Fps(fps));
    }
    let randomise = if job.no_randomise {
        Randomise::none()
    } else {
        Randomise::recorded(capture.randomise.as_deref()).map_err(|source| {
            RenderJobError::Randomise {
                path: job.capture.clone(),
                source,
            }
        })?
    };
    let settings = RenderSettings {
        width,
        height,
        fps: job.fps,
        limit: job.limit,
        // A recorded `[randomise] crf` draws the CRF as `generate` did.
        crf: randomise.capture_crf(job.crf, capture.seed.unwrap_or(0), &capture.session),
        preset: job.preset.clone(),
        x264_options: job.x264_options.clone(),
        gop_frames: job.gop_frames,
        encoder_threads: job.encoder_threads,
        embed_video: job.embed_video,
        engine: job.engine.clone(),
        extra_keyframes: Vec::new(),
        only_frames: None,
        randomise,
    };
    let total = job
        .limit
        .map_or(capture.frame_count(), |n| n.min(capture.frame_count()));
    let bar = Progress::bar("rendering", "frames", true, total as u64);
    let started = Instant::now();
    let progress = |k: u64| bar.set_done(k);
    let summary = render_capture(
        &rig,
        &capture,
        &settings,
        outputs,
        ffmpeg.as_ref(),
        &progress,
        stop,
    );
    bar.finish();
    let summary = summary.map_err(|source| RenderJobError::Render {
        path: job.capture.clone(),
        source: Box::new(source),
    })?;
    remove_stale_passes(outputs)?;
    if !summary.unknown_prop_kinds.is_empty() {
        tracing::warn!(
            "prop kinds without a shape were drawn as boxes: {}",
            summary.unknown_prop_kinds.join(", ")
        );
    }
    Ok(RenderReport {
        summary,
        width,
        height,
        fps: settings.fps.unwrap_or(capture.fps),
        seconds: started.elapsed().as_secs_f64(),
        frames_dir: outputs.frames_dir.clone(),
        depth_dir: outputs.depth_dir.clone(),
        mask_dir: outputs.mask_dir.clone(),
    })
}

/// Removes the depth or mask folder beside a video just replaced when this render did not write
/// it: it showed the old video's frames.
fn remove_stale_passes(outputs: &Outputs) -> Result<(), RenderJobError> {
    let Some(video) = &outputs.video else {
        return Ok(());
    };
    let beside = [
        (
            crate::bags::render::depth_dir_beside(video),
            &outputs.depth_dir,
        ),
        (
            crate::bags::render::mask_dir_beside(video),
            &outputs.mask_dir,
        ),
    ];
    for (dir, written) in beside {
        if written.is_none() && dir.is_dir() {
            std::fs::remove_dir_all(&dir).map_err(|source| RenderJobError::RemoveStale {
                path: dir.clone(),
                source,
            })?;
            tracing::info!(
                "removed {}: it belonged to the video replaced",
                dir.display()
            );
        }
    }
    Ok(())
}

/// Refuses outputs that exist (unless `force`) and makes the folders outputs go in.
fn prepare_outputs(outputs: &Outputs, force: bool) -> Result<(), RenderJobError> {
    for path in [
        outputs.video.clone(),
        outputs.render_bag_path(),
        outputs.preview.clone(),
        outputs.depth_dir.clone(),
        outputs.mask_dir.clone(),
    ]
    .into_iter()
    .flatten()
    {
        if path.exists() && !force {
            return Err(RenderJobError::OutputExists(path));
        }
    }
    for path in [
        outputs.video.as_ref(),
        outputs.preview.as_ref(),
        outputs.render_bag.as_ref(),
    ]
    .into_iter()
    .flatten()
    {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| RenderJobError::CreateDir {
                path: dir.to_path_buf(),
                source,
            })?;
        }
    }
    Ok(())
}

impl RenderReport {
    /// The summary printed at the end: frames and speed, then every file written.
    #[must_use]
    pub fn report(&self) -> String {
        let summary = &self.summary;
        let (width, height, seconds) = (self.width, self.height, self.seconds);
        #[expect(clippy::cast_precision_loss, reason = "display only")]
        let fps = summary.frames as f64 / seconds.max(1e-9);
        // Blender renders about a frame a second: keep its rate readable.
        let rate = if fps < 10.0 {
            format!("{fps:.2}")
        } else {
            format!("{fps:.0}")
        };
        let mut text = format!(
            "rendered {} frames at {width}x{height} in {seconds:.1} s ({rate} frames/s, {:.1}x real time)\n",
            summary.frames,
            fps / self.fps
        );
        if let Some(v) = &summary.video {
            #[expect(clippy::cast_precision_loss, reason = "display only")]
            let mb = v.bytes as f64 / 1e6;
            text.push_str(&format!(
                "  video: {} ({} frames, {mb:.1} MB, keyframes forced at {} segment boundaries)\n",
                v.path.display(),
                v.frame_count,
                summary.forced_keyframes.len()
            ));
        }
        if let Some(b) = &summary.render_bag {
            text.push_str(&format!("  render bag: {}\n", b.display()));
        }
        if let Some(dir) = &self.frames_dir {
            text.push_str(&format!("  frames: {}\n", dir.display()));
        }
        for (what, dir) in [("depth", &self.depth_dir), ("masks", &self.mask_dir)] {
            if let Some(dir) = dir {
                text.push_str(&format!("  {what}: {}\n", dir.display()));
            }
        }
        if let Some(p) = &summary.preview {
            text.push_str(&format!("  preview: {}\n", p.display()));
        }
        text
    }
}

/// Parses `WIDTHxHEIGHT` (`640x360`).
///
/// # Errors
/// [`ResolutionError`] saying what was expected.
pub fn parse_resolution(s: &str) -> Result<(u32, u32), ResolutionError> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| ResolutionError(format!("`{s}`: expected WIDTHxHEIGHT, e.g. 640x360")))?;
    let n = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| ResolutionError(format!("`{s}`: `{v}` is not a whole number")))
    };
    Ok((n(w)?, n(h)?))
}

/// A `--resolution` value that is not `WIDTHxHEIGHT`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct ResolutionError(String);
