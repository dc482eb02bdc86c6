//! Rendering a whole capture: every frame of its timeline (or of a resampled one), rendered in
//! parallel and encoded in order, with the render bag that maps video frames to timeline stamps
//! and carries the per-frame annotations (and, optionally, the encoded video itself).
//!
//! Outputs are written under temporary names and renamed when complete, so an interrupted or
//! failed render never leaves a file that looks finished.

pub mod pieces;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, PoisonError};

use nalgebra::{Isometry3, Translation3};
use rayon::prelude::*;

use super::annotate::{Annotation, SURFACE_LANDMARKS, annotate};
use super::blender::{BlenderError, BlenderFrame, BlenderFrames, BlenderJob, Engine};
use super::cpu::CpuRenderer;
use super::passes::{FramePasses, PassDirs, Wanted};
use super::{Camera, FrameInput, Image, Renderer, Stage};
use crate::bags::capture::{Capture, CaptureFrame, Stamps, TimelineError};
use crate::bags::{self, render::RenderBagError};
use crate::camera::{CAMERA_FRAME, Intrinsics};
use crate::frame_ranges::FrameRanges;
use crate::ros::autoact_msgs::{FrameAnnotation, VideoInfo};
use crate::ros::builtin_interfaces::Time;
use crate::ros::foxglove_msgs::CompressedVideo;
use crate::ros::std_msgs::Header;
use crate::skeleton::character::Character;
use crate::skeleton::fk::{BonePose, WorldPose, forward, landmark_position};
use crate::skeleton::rig::Rig;
use crate::video::{
    AccessUnit, EncodeSettings, EncodedVideo, Ffmpeg, Tile, VideoEncoder, VideoError,
};

/// Why a render failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// Encoding or image output failed.
    #[error(transparent)]
    Video(#[from] VideoError),
    /// Writing the render bag failed.
    #[error(transparent)]
    Bag(#[from] RenderBagError),
    /// A file system error.
    #[error("cannot {action} `{path}`: {source}")]
    Io {
        /// What was being done.
        action: &'static str,
        /// The path.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The output size cannot be encoded.
    #[error(
        "resolution {width}x{height}: width and height must be even and at least {}",
        MIN_SIDE_PX
    )]
    Resolution {
        /// The asked width, pixels.
        width: u32,
        /// The asked height, pixels.
        height: u32,
    },
    /// The capture (or the first `limit` of its frames) gives no frame to render.
    #[error("no frames to render")]
    NoFrames {
        /// The frame limit asked for, if any.
        limit: Option<usize>,
    },
    /// A video was asked for, but no ffmpeg was given to encode it.
    #[error("a video needs ffmpeg (none was found)")]
    NoFfmpeg {
        /// The video asked for.
        video: PathBuf,
    },
    /// The encoded video does not split into one access unit per frame, so it cannot be
    /// embedded into the render bag.
    #[error(
        "{}: {units} H.264 access units for {frames} frames; not embedding a stream that does \
         not match",
        video.display()
    )]
    AccessUnitCount {
        /// The encoded video.
        video: PathBuf,
        /// Access units found in it.
        units: usize,
        /// Frames rendered.
        frames: usize,
    },
    /// The Blender engine failed.
    #[error(transparent)]
    Blender(#[from] BlenderError),
    /// The capture's frames could not be read again.
    #[error(transparent)]
    Capture(#[from] TimelineError),
    /// A finished piece of a render made in pieces ([`pieces`]) cannot be read back.
    #[error("render piece `{}`: {detail}", path.display())]
    Piece {
        /// The piece's file.
        path: PathBuf,
        /// What is wrong.
        detail: String,
    },
    /// Stopped by a signal; nothing complete-looking was left behind.
    #[error("interrupted; partial outputs were removed")]
    Interrupted,
}

/// The smallest output width and height, pixels.
pub const MIN_SIDE_PX: u32 = 16;

/// How to render.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    /// Output width, pixels (even).
    pub width: u32,
    /// Output height, pixels (even).
    pub height: u32,
    /// Output frame rate; `None` renders the capture's own frames.
    pub fps: Option<f64>,
    /// Render only the first this many frames.
    pub limit: Option<usize>,
    /// x264 constant rate factor.
    pub crf: u8,
    /// x264 preset.
    pub preset: String,
    /// x264 options after the preset (empty: none).
    pub x264_options: String,
    /// Largest keyframe interval, frames (`None`: the encoder's default).
    pub gop_frames: Option<u32>,
    /// x264 threads ([`crate::video::DEFAULT_ENCODER_THREADS`]).
    pub encoder_threads: u8,
    /// Put the encoded stream into the render bag, as which viewer's message.
    pub embed_video: Option<crate::bags::render::EmbedVideo>,
    /// Output frames to make keyframes besides the segment boundaries: where planned clips
    /// start (`generate` gives them), so that `trim` copies every clip instead of re-encoding
    /// the ones inside a segment (fixed windows, action instances).
    pub extra_keyframes: Vec<u64>,
    /// Draw only these frames of the render's timeline (sorted, disjoint ranges of output frame
    /// indices): `generate` without `--keep-intermediates` gives the frames its clips use. The
    /// video then holds only those frames, and the render bag says which
    /// ([`crate::bags::render::DrawnFrames`]); `None` draws every frame.
    pub only_frames: Option<Vec<std::ops::Range<u64>>>,
    /// Which engine draws the frames (the labels are the same for every engine).
    pub engine: Engine,
    /// Domain randomisation: colour jitter, sensor noise, motion blur
    /// ([`super::randomise`]; the CRF is `crf`, drawn by the caller).
    pub randomise: crate::dataset::randomise::Randomise,
}

/// Where to write.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Outputs {
    /// The video (`.mp4`); with it, the render bag.
    pub video: Option<PathBuf>,
    /// The render bag (video info, annotations); defaults beside the video.
    pub render_bag: Option<PathBuf>,
    /// A folder for one PNG per frame.
    pub frames_dir: Option<PathBuf>,
    /// A contact sheet of sampled frames.
    pub preview: Option<PathBuf>,
    /// A folder for the depth pass, one 16-bit PNG per frame ([`super::passes`]).
    pub depth_dir: Option<PathBuf>,
    /// A folder for the instance mask pass, one 8-bit PNG per frame ([`super::passes`]).
    pub mask_dir: Option<PathBuf>,
}

impl Outputs {
    /// The render bag's path: as given, or `<video stem>.render.mcap` beside the video.
    #[must_use]
    pub fn render_bag_path(&self) -> Option<PathBuf> {
        self.render_bag.clone().or_else(|| {
            self.video
                .as_deref()
                .map(crate::bags::render::render_bag_beside)
        })
    }
}

/// What a render produced.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSummary {
    /// Frames rendered.
    pub frames: u64,
    /// The encoded video.
    pub video: Option<EncodedVideo>,
    /// The render bag.
    pub render_bag: Option<PathBuf>,
    /// The contact sheet.
    pub preview: Option<PathBuf>,
    /// Frame indices forced to be keyframes.
    pub forced_keyframes: Vec<u64>,
    /// Prop kinds drawn as plain boxes.
    pub unknown_prop_kinds: Vec<String>,
}

/// Where one output frame is, without its pose: what the sinks need of it.
#[derive(Debug, Clone, Copy)]
struct Spot {
    /// Its index on the render's timeline (the frame a render of every frame puts it at).
    frame: usize,
    stamp_nanos: u64,
    scene: usize,
    segment: Option<usize>,
}

/// One output frame: where it is, the pose and the camera.
#[derive(Debug, Clone)]
struct Sample {
    spot: Spot,
    pose: BonePose,
    world_from_optical: Isometry3<f64>,
}

/// Output frames read from the capture at a time (their poses and cameras are held only while
/// they are drawn, so memory does not grow with the session).
const SAMPLE_BLOCK: usize = 512;

/// The stamps of the output frames of a render of `capture` at `fps` (`None`: its own rate):
/// the capture's own frames at its own rate, else every 1/`fps` from its first frame to its last.
/// The one place that knows a render's timeline; `generate` counts frames with it too.
#[must_use]
pub fn output_timeline(capture: &Capture, fps: Option<f64>) -> Stamps {
    if same_rate(capture, fps) {
        return capture.stamps.clone();
    }
    let fps = fps.unwrap_or(capture.fps);
    match (capture.stamps.first(), capture.stamps.last()) {
        (Some(first), Some(last)) => Stamps::clock_until(first, fps, last),
        _ => Stamps::new(fps),
    }
}

/// Whether a render at `fps` draws the capture's own frames.
fn same_rate(capture: &Capture, fps: Option<f64>) -> bool {
    fps.is_none_or(|f| (f - capture.fps).abs() < 1e-9)
}

/// The first clip (`/segments`) whose span holds stamp `t`.
fn segment_at(capture: &Capture, t: u64) -> Option<usize> {
    capture.segments.iter().position(|s| {
        let (a, b) = (
            s.start.to_nanos().unwrap_or(0),
            s.end.to_nanos().unwrap_or(0),
        );
        (a..b).contains(&t)
    })
}

/// Output frames where a segment or its animation starts or ends (where `trim`'s `whole` clips
/// start, with or without the leads): the first frame at or after each boundary.
fn keyframes(capture: &Capture, timeline: &Stamps, extra: &[u64]) -> Vec<u64> {
    let len = timeline.len() as u64;
    let mut out = vec![0u64];
    for s in &capture.segments {
        let boundaries = [s.start, s.content_start, s.content_end, s.end];
        for t in boundaries.into_iter().filter_map(Time::to_nanos) {
            let k = timeline.count_before(t) as u64;
            if k < len {
                out.push(k);
            }
        }
    }
    out.extend(extra.iter().filter(|&&k| k < len));
    out.sort_unstable();
    out.dedup();
    out
}

/// Renders `capture` as `settings` say into `outputs`. `progress` is called with the number of
/// frames done; setting `stop` abandons the render (partial outputs are removed).
///
/// The stages: check the settings, [plan](Plan) the output frames (samples, keyframes, preview
/// picks), [prepare](Scenes::prepare) every scene for drawing, then either render only the
/// preview's frames or render every frame in parallel and hand them in order to the
/// [outputs](FrameSinks) (encoder, PNG frames, preview tiles, annotations), and finally write
/// the video, the preview and the render bag.
///
/// # Errors
/// [`RenderError`]; on any error, no output that looks complete is left.
pub fn render_capture(
    rig: &Rig,
    capture: &Capture,
    settings: &RenderSettings,
    outputs: &Outputs,
    ffmpeg: Option<&Ffmpeg>,
    progress: &(dyn Fn(u64) + Sync),
    stop: &AtomicBool,
) -> Result<RenderSummary, RenderError> {
    check_resolution(settings)?;
    let plan = Plan::new(capture, settings)?;
    let scenes = Scenes::prepare(rig, capture, settings);
    let mut summary = RenderSummary {
        frames: 0,
        video: None,
        render_bag: None,
        preview: None,
        forced_keyframes: plan.keyframes.clone(),
        unknown_prop_kinds: scenes.unknown_prop_kinds(),
    };
    if outputs.video.is_none()
        && outputs.frames_dir.is_none()
        && outputs.depth_dir.is_none()
        && outputs.mask_dir.is_none()
    {
        // A preview alone renders only the sampled frames.
        if let Some(path) = &outputs.preview {
            let picks = plan.samples(rig, capture, &plan.preview_picks)?;
            let blender = scenes.blender(settings, &picks, Wanted::default(), progress, stop)?;
            summary.frames =
                render_preview_only(&scenes, &picks, blender.as_ref(), path, settings)?;
            summary.preview = Some(path.clone());
        }
        return Ok(summary);
    }
    let wanted = Wanted {
        depth: outputs.depth_dir.is_some(),
        mask: outputs.mask_dir.is_some(),
    };
    let all = plan.blender_samples(rig, capture, settings)?;
    let blender = scenes.blender(settings, &all, wanted, progress, stop)?;
    drop(all);
    let renderer = blender
        .as_ref()
        .map_or_else(|| "autoact cpu".to_owned(), |b| b.description.clone());
    // The render bag gets each frame's labels as it is rendered (it describes a video only).
    let labels = match (outputs.render_bag_path(), &outputs.video) {
        (Some(bag), Some(video)) => Some(LabelSink::create(
            &bag, video, capture, settings, &plan, rig, &renderer,
        )?),
        _ => None,
    };
    let mut sinks = FrameSinks::open(&plan, outputs, settings, ffmpeg, labels)?;
    let video = draw_all(
        &scenes,
        &plan,
        &mut sinks,
        blender.as_ref(),
        progress,
        &|_, _| {},
        stop,
    )?;
    summary.frames = sinks.taken as u64;
    if let Some(path) = &outputs.preview {
        write_preview(path, &sinks.preview_tiles, settings)?;
        summary.preview = Some(path.clone());
    }
    if let Some(labels) = sinks.labels.take() {
        labels.finish(video.as_ref(), ffmpeg, settings, &plan)?;
        summary.render_bag = outputs.render_bag_path();
    }
    summary.video = video;
    Ok(summary)
}

/// Width and height must be even (for `yuv420p`) and at least [`MIN_SIDE_PX`].
fn check_resolution(settings: &RenderSettings) -> Result<(), RenderError> {
    let (width, height) = (settings.width, settings.height);
    if width < MIN_SIDE_PX || height < MIN_SIDE_PX || width % 2 == 1 || height % 2 == 1 {
        return Err(RenderError::Resolution { width, height });
    }
    Ok(())
}

/// The output frames and what is special about them: the frames drawn as ranges of the
/// render's timeline, whose stamps are runs ([`Stamps`]); nothing is kept per frame.
struct Plan {
    /// The render's timeline: every output frame's stamp, drawn or not.
    timeline: Stamps,
    /// Whether the timeline is the capture's own frames (else it is resampled at `fps`).
    same_rate: bool,
    /// The timeline frames this plan draws, in order.
    drawn: FrameRanges,
    /// Output frames where a clip starts or ends (they become keyframes).
    keyframes: Vec<u64>,
    /// Output frames shown on the contact sheet.
    preview_picks: Vec<usize>,
    /// The output frame rate.
    fps: f64,
    /// The index in the render's video of this plan's frame 0: 0, or where a piece starts
    /// ([`pieces`]).
    first: usize,
    /// The image effects to apply in output order.
    randomise: crate::dataset::randomise::Randomise,
    /// Timeline stamp of the render's timeline frame 0, nanoseconds.
    frame0_nanos: u64,
    /// Frames of the render's timeline when only some are drawn ([`Plan::keep_only`]); `None`:
    /// every frame is drawn.
    timeline_of_some: Option<u64>,
}

impl Plan {
    /// The frames `settings` ask of `capture`.
    fn new(capture: &Capture, settings: &RenderSettings) -> Result<Plan, RenderError> {
        let mut timeline = output_timeline(capture, settings.fps);
        if let Some(limit) = settings.limit {
            timeline.truncate(limit);
        }
        let Some(frame0_nanos) = timeline.first() else {
            return Err(RenderError::NoFrames {
                limit: settings.limit,
            });
        };
        let mut plan = Plan {
            keyframes: keyframes(capture, &timeline, &settings.extra_keyframes),
            preview_picks: preview_frames(capture, &timeline),
            same_rate: same_rate(capture, settings.fps),
            drawn: FrameRanges::all(timeline.len() as u64),
            timeline,
            fps: settings.fps.unwrap_or(capture.fps),
            frame0_nanos,
            first: 0,
            randomise: settings.randomise.clone(),
            timeline_of_some: None,
        };
        if let Some(only) = &settings.only_frames {
            plan.keep_only(only);
            if plan.drawn.is_empty() {
                return Err(RenderError::NoFrames {
                    limit: settings.limit,
                });
            }
        }
        Ok(plan)
    }

    /// How many frames this plan draws.
    fn len(&self) -> usize {
        usize::try_from(self.drawn.len()).unwrap_or(usize::MAX)
    }

    /// The timeline frame this plan draws as its `k`-th.
    fn frame(&self, k: usize) -> usize {
        self.drawn
            .nth(k as u64)
            .and_then(|f| usize::try_from(f).ok())
            .unwrap_or(usize::MAX)
    }

    /// The stamp of this plan's `k`-th frame.
    fn stamp(&self, k: usize) -> u64 {
        self.timeline.get(self.frame(k)).unwrap_or(u64::MAX)
    }

    /// How many of this plan's frames come before stamp `t`.
    fn count_before(&self, t: u64) -> usize {
        let frames = self.drawn.rank(self.timeline.count_before(t) as u64);
        usize::try_from(frames).unwrap_or(usize::MAX)
    }

    /// Keeps only the timeline frames in `only` (sorted, disjoint ranges). The keyframes are the
    /// kept frames that a render of every frame makes keyframes, and the first kept frame after
    /// every gap (a cut in this video: motion blur must not blend frames that are not neighbours
    /// on the timeline). With the clips' starts among the keyframes asked for (as `generate`
    /// asks), every gap ends at a clip start, so the image effects, which start afresh at a
    /// keyframe, draw every kept frame as that render does. A contact sheet's pick not kept moves
    /// to the next kept frame.
    fn keep_only(&mut self, only: &[std::ops::Range<u64>]) {
        let timeline = self.timeline.len() as u64;
        let drawn = FrameRanges::new(
            only.iter()
                .map(|r| r.start.min(timeline)..r.end.min(timeline)),
        );
        let mut keyframes: Vec<u64> = self
            .keyframes
            .iter()
            .filter(|&&k| drawn.contains(k))
            .map(|&k| drawn.rank(k))
            .chain(drawn.range_starts())
            .collect();
        keyframes.sort_unstable();
        keyframes.dedup();
        self.keyframes = keyframes;
        let last = drawn.len().saturating_sub(1);
        let mut picks: Vec<usize> = self
            .preview_picks
            .iter()
            .map(|&k| usize::try_from(drawn.rank(k as u64).min(last)).unwrap_or(usize::MAX))
            .collect();
        picks.dedup();
        self.preview_picks = picks;
        self.drawn = drawn;
        self.timeline_of_some = Some(timeline);
    }

    /// Frames of the render's timeline, drawn or not (of a whole render's plan, not a piece's).
    fn timeline_frames(&self) -> u64 {
        self.timeline_of_some
            .unwrap_or_else(|| (self.first + self.len()) as u64)
    }

    /// Frames `range` of this plan as a plan of their own (keyframes and preview picks counted
    /// from the range's start, [`Plan::first`] its start).
    fn piece(&self, range: std::ops::Range<usize>) -> Plan {
        let within = |k: u64| (range.start as u64..range.end as u64).contains(&k);
        Plan {
            timeline: self.timeline.clone(),
            same_rate: self.same_rate,
            drawn: self.drawn.slice(range.start as u64..range.end as u64),
            keyframes: self
                .keyframes
                .iter()
                .filter(|&&k| within(k))
                .map(|&k| k - range.start as u64)
                .collect(),
            preview_picks: self
                .preview_picks
                .iter()
                .filter(|&&k| within(k as u64))
                .map(|&k| k - range.start)
                .collect(),
            fps: self.fps,
            first: self.first + range.start,
            randomise: self.randomise.clone(),
            frame0_nanos: self.frame0_nanos,
            timeline_of_some: self.timeline_of_some,
        }
    }

    /// The capture frame timeline frame `frame` shows (at or before its stamp; with the next one,
    /// the two a resampled frame blends).
    fn capture_frame(&self, capture: &Capture, frame: usize) -> usize {
        if self.same_rate {
            return frame;
        }
        let t = self.timeline.get(frame).unwrap_or(u64::MAX);
        capture
            .stamps
            .count_before(t.saturating_add(1))
            .saturating_sub(1)
    }

    /// The scene this plan's `k`-th frame is drawn in.
    fn scene(&self, capture: &Capture, k: usize) -> usize {
        let i = self.capture_frame(capture, self.frame(k));
        capture.scene_at(capture.stamps.get(i).unwrap_or(0))
    }

    /// The samples of this plan's frames `ks` (ascending), their poses and cameras read from the
    /// capture a stretch of neighbouring frames at a time.
    fn samples(
        &self,
        rig: &Rig,
        capture: &Capture,
        ks: &[usize],
    ) -> Result<Vec<Sample>, TimelineError> {
        let frames = capture.frame_count();
        // The capture frames timeline frame `f` needs.
        let span = |f: usize| {
            let i = self.capture_frame(capture, f);
            i..(i + if self.same_rate { 1 } else { 2 }).min(frames)
        };
        let mut out = Vec::with_capacity(ks.len());
        let mut group: Vec<usize> = Vec::new();
        let mut read = 0..0;
        for f in ks.iter().map(|&k| self.frame(k)) {
            let need = span(f);
            let near = (read.start..=read.end + SAMPLE_BLOCK / 2).contains(&need.start)
                && need.end.max(read.end) - read.start <= 2 * SAMPLE_BLOCK;
            if group.is_empty() || !near {
                self.sample_group(rig, capture, &group, read.clone(), &mut out)?;
                group.clear();
                read = need.clone();
            }
            read.end = read.end.max(need.end);
            group.push(f);
        }
        self.sample_group(rig, capture, &group, read, &mut out)?;
        Ok(out)
    }

    /// The samples of timeline frames `group`, whose capture frames are all in `read`.
    fn sample_group(
        &self,
        rig: &Rig,
        capture: &Capture,
        group: &[usize],
        read: std::ops::Range<usize>,
        out: &mut Vec<Sample>,
    ) -> Result<(), TimelineError> {
        if group.is_empty() {
            return Ok(());
        }
        let frames = capture.frames(rig, read.clone())?;
        for &f in group {
            let i = self.capture_frame(capture, f) - read.start;
            let (Some(a), Some(t)) = (frames.get(i), self.timeline.get(f)) else {
                continue;
            };
            out.push(self.sample(capture, f, t, a, frames.get(i + 1).unwrap_or(a)));
        }
        Ok(())
    }

    /// Timeline frame `f` at stamp `t`: capture frame `a` as it is (at the capture's own rate),
    /// else resampled between `a` and the next frame `b` (poses slerped within a scene; the
    /// camera interpolated only within one clip, so cuts stay cuts).
    fn sample(
        &self,
        capture: &Capture,
        f: usize,
        t: u64,
        a: &CaptureFrame,
        b: &CaptureFrame,
    ) -> Sample {
        let segment = segment_at(capture, t);
        let spot = Spot {
            frame: f,
            stamp_nanos: t,
            scene: a.scene,
            segment,
        };
        if self.same_rate {
            return Sample {
                spot,
                pose: a.pose.clone(),
                world_from_optical: a.world_from_optical,
            };
        }
        let span = b.stamp_nanos.saturating_sub(a.stamp_nanos);
        let alpha = if span == 0 {
            0.0
        } else {
            (t - a.stamp_nanos) as f64 / span as f64
        };
        let blend = a.scene == b.scene;
        let pose = if blend {
            BonePose {
                root_translation_m: a
                    .pose
                    .root_translation_m
                    .lerp(&b.pose.root_translation_m, alpha),
                local_rotations: a
                    .pose
                    .local_rotations
                    .iter()
                    .zip(&b.pose.local_rotations)
                    .map(|(p, q)| p.slerp(q, alpha))
                    .collect(),
            }
        } else {
            a.pose.clone()
        };
        let camera = if blend && segment == segment_at(capture, b.stamp_nanos) {
            let ta = a.world_from_optical.translation.vector;
            let tb = b.world_from_optical.translation.vector;
            Isometry3::from_parts(
                Translation3::from(ta.lerp(&tb, alpha)),
                a.world_from_optical
                    .rotation
                    .slerp(&b.world_from_optical.rotation, alpha),
            )
        } else {
            a.world_from_optical
        };
        Sample {
            spot,
            pose,
            world_from_optical: camera,
        }
    }

    /// Every sample, when the Blender engine draws them (it is handed them all at once);
    /// nothing for the embedded engine, which reads them a block at a time.
    fn blender_samples(
        &self,
        rig: &Rig,
        capture: &Capture,
        settings: &RenderSettings,
    ) -> Result<Vec<Sample>, TimelineError> {
        if !matches!(settings.engine, Engine::Blender(_)) {
            return Ok(Vec::new());
        }
        self.samples(rig, capture, &(0..self.len()).collect::<Vec<_>>())
    }
}

/// Every scene of a capture made ready to draw, and how one output frame is drawn.
struct Scenes<'a> {
    rig: &'a Rig,
    capture: &'a Capture,
    /// One per capture scene.
    stages: Vec<Stage>,
    /// Each scene's character on the rig.
    characters: Vec<Character>,
    /// The capture's camera at the output resolution.
    intrinsics: Intrinsics,
    /// Per rig landmark, whether it is on the body's surface (the face).
    surface_landmarks: Vec<bool>,
    /// Renderers and images kept from frame to frame: a renderer caches a stage's prop shadow
    /// map (1024² texels) and its buffers, which a fresh one per frame redrew and reallocated.
    renderers: Mutex<Vec<(CpuRenderer, Image)>>,
}

impl<'a> Scenes<'a> {
    /// Builds every scene's stage (in parallel) and character.
    fn prepare(rig: &'a Rig, capture: &'a Capture, settings: &RenderSettings) -> Scenes<'a> {
        let stages: Vec<Stage> = capture
            .scenes
            .par_iter()
            .enumerate()
            .map(|(i, s)| {
                let mut stage = Stage::new(rig, &s.scene, s.stream, i as u64);
                settings.randomise.jitter_stage(&mut stage);
                stage
            })
            .collect();
        let characters = capture
            .scenes
            .iter()
            .map(|s| s.scene.look.character(rig))
            .collect();
        Scenes {
            rig,
            capture,
            stages,
            characters,
            intrinsics: capture.intrinsics.resized(settings.width, settings.height),
            surface_landmarks: rig
                .landmarks
                .iter()
                .map(|l| SURFACE_LANDMARKS.contains(&l.name.as_str()))
                .collect(),
            renderers: Mutex::new(Vec::new()),
        }
    }

    /// Prop kinds some scene draws as plain boxes, sorted, once each.
    fn unknown_prop_kinds(&self) -> Vec<String> {
        let mut unknown: Vec<String> = self
            .stages
            .iter()
            .flat_map(|s| s.world.unknown_prop_kinds.clone())
            .collect();
        unknown.sort();
        unknown.dedup();
        unknown
    }

    /// Sample `s`'s posed skeleton, camera and seconds since its scene started.
    fn frame_of(&self, s: &Sample) -> (WorldPose, Camera, f64) {
        let posed = forward(self.rig, &self.characters[s.spot.scene], &s.pose, 1.0);
        let camera = Camera {
            world_from_optical: s.world_from_optical,
            intrinsics: self.intrinsics,
        };
        let scene_start = self.capture.scenes[s.spot.scene].start_nanos;
        let time_s =
            crate::skeleton::pose::nanos_to_secs(s.spot.stamp_nanos.saturating_sub(scene_start));
        (posed, camera, time_s)
    }

    /// With the Blender engine, renders `picks` with Blender (their annotations still come from
    /// [`Scenes::render`]); `None` for the embedded engine.
    fn blender(
        &self,
        settings: &RenderSettings,
        picks: &[Sample],
        wanted: Wanted,
        progress: &(dyn Fn(u64) + Sync),
        stop: &AtomicBool,
    ) -> Result<Option<BlenderFrames>, RenderError> {
        let Engine::Blender(blender) = &settings.engine else {
            return Ok(None);
        };
        let job = BlenderJob {
            settings: blender,
            stages: &self.stages,
            width: settings.width,
            height: settings.height,
            wanted,
        };
        let frame = |k: usize| {
            let s = &picks[k];
            let (posed, camera, time_s) = self.frame_of(s);
            let stage = &self.stages[s.spot.scene];
            let skinning = crate::scene::body_mesh::Skinning::new(&stage.rest_pose, &posed);
            let (mut body_m, mut normals) = (Vec::new(), Vec::new());
            stage.body.skin_into(&skinning, &mut body_m, &mut normals);
            BlenderFrame {
                scene: s.spot.scene,
                time_s,
                camera,
                body_m,
            }
        };
        match super::blender::render(&job, picks.len(), &frame, progress, stop) {
            Ok(frames) => Ok(Some(frames)),
            Err(BlenderError::Interrupted) => Err(RenderError::Interrupted),
            Err(e) => Err(e.into()),
        }
    }

    /// Renders sample `s` into `image` and returns its labels.
    fn render(&self, renderer: &mut CpuRenderer, image: &mut Image, s: &Sample) -> Annotation {
        let (posed, camera, time_s) = self.frame_of(s);
        let input = FrameInput {
            camera,
            pose: &posed,
            time_s,
        };
        renderer.render(&self.stages[s.spot.scene], &input, image);
        let character = &self.characters[s.spot.scene];
        let landmarks: Vec<_> = (0..self.rig.landmarks.len())
            .map(|l| landmark_position(self.rig, character, &posed, l))
            .collect();
        annotate(&posed, &landmarks, &self.surface_landmarks, &camera, image)
    }

    /// Renders samples `picks` in parallel; the value `keep` makes of each frame (its colour,
    /// depth and surfaces) and its labels, in order.
    fn render_each<T: Send>(
        &self,
        picks: &[Sample],
        keep: impl Fn(&Image, Annotation, &Sample) -> T + Sync,
    ) -> Vec<T> {
        let pool = || {
            self.renderers
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
        };
        picks
            .par_iter()
            .map(|s| {
                let (mut r, mut image) = pool()
                    .pop()
                    .unwrap_or_else(|| (CpuRenderer::new(), Image::default()));
                let a = self.render(&mut r, &mut image, s);
                let kept = keep(&image, a, s);
                pool().push((r, image));
                kept
            })
            .collect()
    }
}

/// Renders only the contact sheet's frames and writes the sheet to `path`; returns how many
/// frames were rendered.
fn render_preview_only(
    scenes: &Scenes<'_>,
    picks: &[Sample],
    blender: Option<&BlenderFrames>,
    path: &Path,
    settings: &RenderSettings,
) -> Result<u64, RenderError> {
    let mut tiles = scenes.render_each(picks, |image, _, s| {
        (
            image.rgb.clone(),
            preview_label(scenes.capture, s.spot.scene),
        )
    });
    if let Some(b) = blender {
        for (k, tile) in tiles.iter_mut().enumerate() {
            tile.0 = b.frame(k)?.0;
        }
    }
    write_preview(path, &tiles, settings)?;
    Ok(tiles.len() as u64)
}

/// Where each rendered frame goes, in order: the encoder, the PNG frames folder, the depth and
/// mask passes, the preview's tiles and the annotations for the render bag.
struct FrameSinks<'a> {
    encoder: Option<VideoEncoder>,
    frames_dir: Option<&'a Path>,
    passes: PassDirs,
    width: u32,
    height: u32,
    preview_tiles: Vec<(Vec<u8>, String)>,
    /// The render bag, written frame by frame.
    labels: Option<LabelSink>,
    /// Frames taken so far.
    taken: usize,
}

impl<'a> FrameSinks<'a> {
    /// Creates the frames folder and starts the encoder, as `outputs` ask.
    fn open(
        plan: &Plan,
        outputs: &'a Outputs,
        settings: &RenderSettings,
        ffmpeg: Option<&Ffmpeg>,
        labels: Option<LabelSink>,
    ) -> Result<FrameSinks<'a>, RenderError> {
        if let Some(dir) = &outputs.frames_dir {
            std::fs::create_dir_all(dir).map_err(|source| RenderError::Io {
                action: "create the frames folder",
                path: dir.clone(),
                source,
            })?;
        }
        let encoder = match (&outputs.video, ffmpeg) {
            (Some(path), Some(ff)) => Some(start_encoder(ff, path, plan, settings)?),
            (Some(path), None) => {
                return Err(RenderError::NoFfmpeg {
                    video: path.clone(),
                });
            }
            _ => None,
        };
        let passes = PassDirs::open(outputs.depth_dir.as_deref(), outputs.mask_dir.as_deref())?;
        Ok(FrameSinks {
            encoder,
            frames_dir: outputs.frames_dir.as_deref(),
            passes,
            width: settings.width,
            height: settings.height,
            preview_tiles: Vec::new(),
            labels,
            taken: 0,
        })
    }

    /// Takes output frame `k`.
    fn take(
        &mut self,
        k: usize,
        frame: RenderedImage,
        plan: &Plan,
        capture: &Capture,
    ) -> Result<(), RenderError> {
        let RenderedImage {
            rgb,
            passes,
            annotation,
            spot,
        } = frame;
        if let Some(enc) = self.encoder.as_mut() {
            enc.write_frame(&rgb)?;
        }
        // `k` counts this plan's frames; files and labels are numbered by the render's timeline
        // (as a render of every frame numbers them, whatever frames are drawn).
        let frame = spot.frame;
        self.passes.write(frame, self.width, self.height, &passes)?;
        if let Some(dir) = self.frames_dir {
            let path = crate::bags::render::frame_file(dir, frame as u64);
            crate::video::write_png(&path, self.width, self.height, &rgb)?;
        }
        if plan.preview_picks.contains(&k) {
            let label = preview_label(capture, spot.scene);
            self.preview_tiles.push((rgb, label));
        }
        if let Some(labels) = self.labels.as_mut() {
            let message = labels.message(&spot, &annotation, capture);
            labels.writer.annotation(spot.stamp_nanos, &message)?;
        }
        self.taken += 1;
        Ok(())
    }
}

/// Starts encoding `path` at the plan's rate, its keyframes forced, as `settings` say.
fn start_encoder(
    ffmpeg: &Ffmpeg,
    path: &Path,
    plan: &Plan,
    settings: &RenderSettings,
) -> Result<VideoEncoder, RenderError> {
    let mut enc = EncodeSettings::new(settings.width, settings.height, plan.fps)
        .with_keyframes(plan.keyframes.iter().copied());
    enc.crf = settings.crf;
    enc.preset.clone_from(&settings.preset);
    enc.x264_options.clone_from(&settings.x264_options);
    enc.threads = settings.encoder_threads;
    if let Some(g) = settings.gop_frames {
        enc.gop_frames = g;
    }
    Ok(VideoEncoder::start(ffmpeg, path, &enc)?)
}

/// One rendered frame on its way from the renderers to the sinks.
struct RenderedImage {
    rgb: Vec<u8>,
    passes: FramePasses,
    annotation: Annotation,
    spot: Spot,
}

/// Draws every frame of `plan` into `sinks` ([`render_in_order`]), then commits the passes and
/// finishes the video; on failure the encoder is stopped and nothing is committed.
fn draw_all(
    scenes: &Scenes<'_>,
    plan: &Plan,
    sinks: &mut FrameSinks<'_>,
    blender: Option<&BlenderFrames>,
    progress: &(dyn Fn(u64) + Sync),
    drawing: &(dyn Fn(u64, u64) + Sync),
    stop: &AtomicBool,
) -> Result<Option<EncodedVideo>, RenderError> {
    let outcome = render_in_order(scenes, plan, sinks, blender, progress, drawing, stop);
    let encoder = sinks.encoder.take();
    let passes = std::mem::take(&mut sinks.passes);
    if let Err(e) = outcome {
        if let Some(enc) = encoder {
            enc.abort();
        }
        return Err(e);
    }
    passes.commit()?;
    Ok(encoder.map(VideoEncoder::finish).transpose()?)
}

/// Renders every sample in parallel batches on a producer thread and hands the frames to
/// `sinks` in order. Stops with [`RenderError::Interrupted`] when `stop` is set or fewer frames
/// than planned came through.
fn render_in_order(
    scenes: &Scenes<'_>,
    plan: &Plan,
    sinks: &mut FrameSinks<'_>,
    blender: Option<&BlenderFrames>,
    progress: &(dyn Fn(u64) + Sync),
    drawing: &(dyn Fn(u64, u64) + Sync),
    stop: &AtomicBool,
) -> Result<(), RenderError> {
    let wanted = sinks.passes.wanted();
    let (sender, receiver) =
        std::sync::mpsc::sync_channel::<Result<Vec<RenderedImage>, RenderError>>(2);
    std::thread::scope(|scope| {
        let producer = scope.spawn(|| {
            // Owned here, so the channel closes when rendering ends.
            let sender = sender;
            let draw = |first: usize, chunk: &[Sample]| {
                drawing((plan.first + first) as u64, chunk.len() as u64);
                scenes.render_each(chunk, |image, annotation, s| RenderedImage {
                    rgb: image.rgb.clone(),
                    passes: FramePasses::of(image, wanted),
                    annotation,
                    spot: s.spot,
                })
            };
            produce(scenes, plan, stop, &draw, &sender);
        });
        let mut consume = || -> Result<(), RenderError> {
            let mut k = 0usize;
            let mut effects = super::randomise::ImageEffects::new(&plan.randomise);
            for frames in &receiver {
                for frame in frames? {
                    if stop.load(Ordering::Relaxed) {
                        return Err(RenderError::Interrupted);
                    }
                    let mut frame = match blender {
                        // Blender's picture and passes, the embedded geometry's labels.
                        Some(b) => {
                            let (rgb, passes) = b.frame(k)?;
                            RenderedImage {
                                rgb,
                                passes,
                                ..frame
                            }
                        }
                        None => frame,
                    };
                    let cut = plan.keyframes.binary_search(&(k as u64)).is_ok();
                    let seed = scenes.stages[frame.spot.scene].seed;
                    // The frame's index on the render's timeline, not the piece's or the
                    // video's: a render made in pieces, or of only some frames, draws the same
                    // noise as one made whole.
                    let frame_index = frame.spot.frame as u64;
                    effects.apply(frame_index, seed, cut, &mut frame.rgb);
                    sinks.take(k, frame, plan, scenes.capture)?;
                    k += 1;
                    // Timeline frames done, the ones not drawn included.
                    progress(frame_index + 1);
                }
            }
            Ok(())
        };
        let outcome = consume();
        drop(receiver);
        let _ = producer.join();
        outcome
    })?;
    if stop.load(Ordering::Relaxed) || sinks.taken < plan.len() {
        return Err(RenderError::Interrupted);
    }
    Ok(())
}

/// The producer of [`render_in_order`]: reads the plan's samples a block at a time and sends
/// them, drawn by `draw` a batch at a time, until done, stopped or no longer received; a read
/// that fails is sent as the error.
fn produce(
    scenes: &Scenes<'_>,
    plan: &Plan,
    stop: &AtomicBool,
    draw: &(dyn Fn(usize, &[Sample]) -> Vec<RenderedImage> + Sync),
    sender: &std::sync::mpsc::SyncSender<Result<Vec<RenderedImage>, RenderError>>,
) {
    let batch = batch_frames(
        rayon::current_num_threads().max(1),
        scenes.intrinsics.width_px as usize * scenes.intrinsics.height_px as usize * 3,
    );
    // Whole batches, so that they are the same as without blocks.
    let block_len = SAMPLE_BLOCK.div_ceil(batch) * batch;
    for block in (0..plan.len()).step_by(block_len) {
        let ks: Vec<usize> = (block..(block + block_len).min(plan.len())).collect();
        let samples = match plan.samples(scenes.rig, scenes.capture, &ks) {
            Ok(samples) => samples,
            Err(e) => {
                let _ = sender.send(Err(e.into()));
                return;
            }
        };
        for (i, chunk) in samples.chunks(batch).enumerate() {
            if stop.load(Ordering::Relaxed) {
                return;
            }
            if sender.send(Ok(draw(block + i * batch, chunk))).is_err() {
                return;
            }
        }
    }
}

/// Frames drawn in parallel per batch on `threads` threads, for frames of `frame_bytes` bytes
/// of RGB: 16 per thread while a batch holds at most [`BATCH_BYTES`], never fewer than 4 per
/// thread. A batch ends with one thread drawing its last frame while the others wait, so longer
/// batches keep the cores busier: on 2 cores at 320×240, 8 frames a batch kept them 92 % busy
/// while rendering and 32 kept them 94.5 % busy (`docs/performance.md`). The byte bound keeps
/// what the batches in flight hold (this one and the two queued for the encoder) small at large
/// sizes.
fn batch_frames(threads: usize, frame_bytes: usize) -> usize {
    let fit = BATCH_BYTES / frame_bytes.max(1);
    (16 * threads).min(fit).max(4 * threads)
}

/// Most bytes of RGB in one batch of [`batch_frames`] beyond 4 frames per thread.
const BATCH_BYTES: usize = 8 << 20;

/// The encoded video's access units, one per frame, when `settings` embed the video into the
/// render bag (and it has one per frame).
fn embedded_units(
    video: Option<&EncodedVideo>,
    ffmpeg: Option<&Ffmpeg>,
    settings: &RenderSettings,
    frames: usize,
) -> Result<Option<Vec<AccessUnit>>, RenderError> {
    let (Some(v), Some(ff)) = (video, ffmpeg) else {
        return Ok(None);
    };
    if settings.embed_video.is_none() {
        return Ok(None);
    }
    let units = crate::video::annexb_access_units(ff, &v.path)?;
    if units.len() != frames {
        return Err(RenderError::AccessUnitCount {
            video: v.path.clone(),
            units: units.len(),
            frames,
        });
    }
    Ok(Some(units))
}

/// Frames for the contact sheet: the middle of each clip's animation, at most 12, evenly chosen.
fn preview_frames(capture: &Capture, timeline: &Stamps) -> Vec<usize> {
    let len = timeline.len();
    let mut mids: Vec<usize> = capture
        .segments
        .iter()
        .filter_map(|s| {
            let (a, b) = (s.content_start.to_nanos()?, s.content_end.to_nanos()?);
            let k = timeline.count_before(a / 2 + b / 2);
            (k < len).then_some(k)
        })
        .collect();
    if mids.is_empty() {
        mids = (0..12).map(|i| i * len / 12).collect();
    }
    let n = mids.len();
    let mut picks: Vec<usize> = (0..n.min(12)).map(|i| mids[i * n / n.min(12)]).collect();
    picks.dedup();
    picks
}

fn preview_label(capture: &Capture, scene: usize) -> String {
    let scene = &capture.scenes[scene].scene;
    format!(
        "{} {} {}",
        scene.weather.name(),
        scene.clock,
        scene.location.name
    )
}

fn write_preview(
    path: &Path,
    tiles: &[(Vec<u8>, String)],
    settings: &RenderSettings,
) -> Result<(), RenderError> {
    let tiles: Vec<Tile<'_>> = tiles
        .iter()
        .map(|(rgb, label)| Tile {
            rgb24: rgb,
            width: settings.width,
            height: settings.height,
            label,
        })
        .collect();
    let columns = if tiles.len() > 4 {
        4
    } else {
        tiles.len().max(1) as u32
    };
    let (w, h, rgb) = crate::video::contact_sheet(&tiles, columns, settings.width.min(320))?;
    crate::video::write_png(path, w, h, &rgb)?;
    Ok(())
}

/// The render bag being written while the frames are rendered, and the names every frame's
/// message repeats. Nothing of a frame is kept once its message is written, so memory does not
/// grow with the session's length.
struct LabelSink {
    writer: bags::render::RenderBagWriter,
    names: Vec<String>,
    landmark_names: Vec<String>,
}

impl LabelSink {
    /// Ends the render bag: when the settings embed the video, each frame's access unit of
    /// `video` goes in beside its labels first.
    fn finish(
        mut self,
        video: Option<&EncodedVideo>,
        ffmpeg: Option<&Ffmpeg>,
        settings: &RenderSettings,
        plan: &Plan,
    ) -> Result<(), RenderError> {
        let units = embedded_units(video, ffmpeg, settings, plan.len())?;
        let embed = settings.embed_video.unwrap_or_default();
        for (k, unit) in units.iter().flatten().enumerate() {
            let stamp = plan.stamp(k);
            let message = CompressedVideo {
                timestamp: Time::from_nanos(stamp),
                frame_id: CAMERA_FRAME.to_owned(),
                data: unit.data.clone(),
                format: "h264".into(),
            };
            self.writer.video(stamp, &message, embed)?;
        }
        self.writer.finish()?;
        Ok(())
    }

    /// Starts the render bag at `path` describing `video` (written by this render).
    fn create(
        path: &Path,
        video: &Path,
        capture: &Capture,
        settings: &RenderSettings,
        plan: &Plan,
        rig: &Rig,
        renderer: &str,
    ) -> Result<LabelSink, RenderError> {
        let first = plan.frame0_nanos;
        let mut settings_json = serde_json::json!({
            "renderer": renderer,
            "crf": settings.crf,
            "preset": settings.preset,
            "x264_options": settings.x264_options,
            "gop_frames": settings.gop_frames,
        });
        if let Some(timeline) = plan.timeline_of_some {
            settings_json[crate::bags::render::TIMELINE_FRAMES_KEY] = timeline.into();
        }
        let info = VideoInfo {
            header: Header {
                stamp: Time::from_nanos(first),
                frame_id: CAMERA_FRAME.to_owned(),
            },
            session: capture.session.clone(),
            capture_bag: crate::file_name(&capture.path),
            video_file: crate::file_name(video),
            container: "mp4".into(),
            codec: "h264".into(),
            fps: plan.fps,
            frame_count: plan.len() as u64,
            width: settings.width,
            height: settings.height,
            forced_keyframes: plan.keyframes.clone(),
            settings_json: settings_json.to_string(),
        };
        Ok(LabelSink {
            writer: bags::render::RenderBagWriter::create(path, first, &info)?,
            names: rig.bones.iter().map(|b| b.name.clone()).collect(),
            landmark_names: rig.landmarks.iter().map(|l| l.name.clone()).collect(),
        })
    }

    /// The labels of the output frame at `spot` as a render-bag message (numbered by the
    /// render's timeline).
    fn message(&self, spot: &Spot, a: &Annotation, capture: &Capture) -> FrameAnnotation {
        FrameAnnotation {
            header: Header {
                stamp: Time::from_nanos(spot.stamp_nanos),
                frame_id: CAMERA_FRAME.to_owned(),
            },
            frame_index: spot.frame as u64,
            segment_id: spot
                .segment
                .map(|i| capture.segments[i].id.clone())
                .unwrap_or_default(),
            keypoint_names: self.names.clone(),
            keypoints_3d: a.keypoints_3d.clone(),
            keypoints_2d: a.keypoints_2d_ros(),
            visibility: a.visibility.clone(),
            bbox: a.roi(),
            silhouette_pixels: a.silhouette_pixels,
            landmark_names: self.landmark_names.clone(),
            landmarks_3d: a.landmarks_3d.clone(),
            landmarks_2d: a.landmarks_2d_ros(),
            landmark_visibility: a.landmark_visibility.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batches_hold_16_frames_per_thread_up_to_8_mib_and_never_fewer_than_4() {
        let rgb = |w: usize, h: usize| w * h * 3;
        assert_eq!(batch_frames(2, rgb(320, 240)), 32);
        assert_eq!(batch_frames(1, rgb(64, 48)), 16);
        // 8 MiB holds 12 frames of 640×360: fewer than 16 per thread on 2, 4 per thread on 8.
        assert_eq!(batch_frames(2, rgb(640, 360)), 12);
        assert_eq!(batch_frames(8, rgb(640, 360)), 32);
        assert_eq!(batch_frames(2, rgb(1920, 1080)), 8);
        assert_eq!(batch_frames(2, 0), 32);
    }

    fn settings(width: u32, height: u32) -> RenderSettings {
        RenderSettings {
            width,
            height,
            fps: None,
            limit: None,
            crf: 23,
            preset: crate::video::DEFAULT_PRESET.into(),
            x264_options: crate::video::DEFAULT_X264_OPTIONS.into(),
            gop_frames: None,
            encoder_threads: crate::video::DEFAULT_ENCODER_THREADS,
            embed_video: None,
            extra_keyframes: Vec::new(),
            only_frames: None,
            engine: Engine::Embedded,
            randomise: crate::dataset::randomise::Randomise::default(),
        }
    }

    #[test]
    fn resolutions_must_be_even_and_at_least_the_minimum() {
        assert!(check_resolution(&settings(16, 16)).is_ok());
        assert!(check_resolution(&settings(320, 240)).is_ok());
        for (w, h) in [(14, 240), (320, 14), (321, 240), (320, 241), (0, 0)] {
            let err = check_resolution(&settings(w, h)).unwrap_err();
            assert!(
                matches!(err, RenderError::Resolution { width, height } if (width, height) == (w, h)),
                "{err:?}"
            );
        }
        assert_eq!(
            RenderError::Resolution {
                width: 321,
                height: 240
            }
            .to_string(),
            "resolution 321x240: width and height must be even and at least 16"
        );
    }

    #[test]
    fn setting_errors_name_the_value() {
        let err = RenderError::AccessUnitCount {
            video: PathBuf::from("out/v.mp4"),
            units: 9,
            frames: 10,
        };
        assert_eq!(
            err.to_string(),
            "out/v.mp4: 9 H.264 access units for 10 frames; not embedding a stream that does not \
             match"
        );
        let err = RenderError::NoFfmpeg {
            video: PathBuf::from("v.mp4"),
        };
        assert_eq!(err.to_string(), "a video needs ffmpeg (none was found)");
    }
}
