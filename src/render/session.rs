//! Rendering a whole capture: every frame of its timeline (or of a resampled one), rendered in
//! parallel and encoded in order, with the render bag that maps video frames to timeline stamps
//! and carries the per-frame annotations (and, optionally, the encoded video itself).
//!
//! Outputs are written under temporary names and renamed when complete, so an interrupted or
//! failed render never leaves a file that looks finished.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use nalgebra::{Isometry3, Translation3};
use rayon::prelude::*;

use super::annotate::{Annotation, annotate};
use super::cpu::CpuRenderer;
use super::{Camera, FrameInput, Image, Renderer, Stage};
use crate::bags::capture::Capture;
use crate::bags::{
    self,
    render::{RenderBagError, RenderedFrame},
};
use crate::camera::CAMERA_FRAME;
use crate::ros::autoact_msgs::{FrameAnnotation, VideoInfo};
use crate::ros::builtin_interfaces::Time;
use crate::ros::foxglove_msgs::CompressedVideo;
use crate::ros::std_msgs::Header;
use crate::skeleton::fk::{BonePose, forward};
use crate::skeleton::rig::Rig;
use crate::video::{EncodeSettings, EncodedVideo, Ffmpeg, Tile, VideoEncoder, VideoError};

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
    /// The settings cannot be used.
    #[error("{0}")]
    Settings(String),
    /// Stopped by a signal; nothing complete-looking was left behind.
    #[error("interrupted; partial outputs were removed")]
    Interrupted,
}

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
    /// Largest keyframe interval, frames (`None`: the encoder's default).
    pub gop_frames: Option<u32>,
    /// Put the encoded stream into the render bag as `foxglove_msgs/CompressedVideo`.
    pub embed_video: bool,
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

/// One output frame: when, which scene, the pose and the camera.
#[derive(Debug, Clone)]
struct Sample {
    stamp_nanos: u64,
    scene: usize,
    pose: BonePose,
    world_from_optical: Isometry3<f64>,
    segment: Option<usize>,
}

/// Output frames: the capture's own, or resampled at `fps` (poses slerped between the two
/// neighbouring frames; the camera interpolated only within one clip, so cuts stay cuts).
fn samples(capture: &Capture, fps: Option<f64>, limit: Option<usize>) -> Vec<Sample> {
    let segment_at = |t: u64| {
        capture.segments.iter().position(|s| {
            let (a, b) = (
                s.start.to_nanos().unwrap_or(0),
                s.end.to_nanos().unwrap_or(0),
            );
            (a..b).contains(&t)
        })
    };
    let frames = &capture.frames;
    let max = limit.unwrap_or(usize::MAX);
    let same_rate = fps.is_none_or(|f| (f - capture.fps).abs() < 1e-9);
    if same_rate {
        return frames
            .iter()
            .take(max)
            .map(|f| Sample {
                stamp_nanos: f.stamp_nanos,
                scene: f.scene,
                pose: f.pose.clone(),
                world_from_optical: f.world_from_optical,
                segment: segment_at(f.stamp_nanos),
            })
            .collect();
    }
    let fps = fps.unwrap_or(capture.fps);
    let (Some(first), Some(last)) = (frames.first(), frames.last()) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    let mut i = 0;
    for k in 0.. {
        let t = first.stamp_nanos + crate::skeleton::pose::stamp_nanos_at(k, fps);
        if t > last.stamp_nanos || out.len() >= max {
            break;
        }
        while i + 1 < frames.len() && frames[i + 1].stamp_nanos <= t {
            i += 1;
        }
        let a = &frames[i];
        let b = frames.get(i + 1).unwrap_or(a);
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
        let segment = segment_at(t);
        let camera = if blend && segment == segment_at(b.stamp_nanos) {
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
        out.push(Sample {
            stamp_nanos: t,
            scene: a.scene,
            pose,
            world_from_optical: camera,
            segment,
        });
    }
    out
}

/// Output frames where a clip starts or ends: the first frame at or after each boundary.
fn keyframes(capture: &Capture, samples: &[Sample]) -> Vec<u64> {
    let mut out = vec![0u64];
    for s in &capture.segments {
        for t in [s.start, s.end].into_iter().filter_map(Time::to_nanos) {
            let k = samples.partition_point(|f| f.stamp_nanos < t);
            if k < samples.len() {
                out.push(k as u64);
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// Renders `capture` as `settings` say into `outputs`. `progress` is called with the number of
/// frames done; setting `stop` abandons the render (partial outputs are removed).
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
    if settings.width < 16
        || settings.height < 16
        || settings.width % 2 == 1
        || settings.height % 2 == 1
    {
        return Err(RenderError::Settings(format!(
            "resolution {}x{}: width and height must be even and at least 16",
            settings.width, settings.height
        )));
    }
    let samples = samples(capture, settings.fps, settings.limit);
    if samples.is_empty() {
        return Err(RenderError::Settings("no frames to render".into()));
    }
    let fps = settings.fps.unwrap_or(capture.fps);
    let intrinsics = capture.intrinsics.resized(settings.width, settings.height);
    let stages: Vec<Stage> = capture
        .scenes
        .par_iter()
        .enumerate()
        .map(|(i, s)| Stage::new(rig, &s.scene, s.stream, i as u64))
        .collect();
    let mut unknown: Vec<String> = stages
        .iter()
        .flat_map(|s| s.world.unknown_prop_kinds.clone())
        .collect();
    unknown.sort();
    unknown.dedup();
    let characters: Vec<_> = capture
        .scenes
        .iter()
        .map(|s| s.scene.look.character(rig))
        .collect();
    let render_one = |renderer: &mut CpuRenderer, image: &mut Image, s: &Sample| {
        let posed = forward(rig, &characters[s.scene], &s.pose, 1.0);
        let camera = Camera {
            world_from_optical: s.world_from_optical,
            intrinsics,
        };
        let scene_start = capture.scenes[s.scene].start_nanos;
        let input = FrameInput {
            camera,
            pose: &posed,
            time_s: crate::skeleton::pose::nanos_to_secs(s.stamp_nanos.saturating_sub(scene_start)),
        };
        renderer.render(&stages[s.scene], &input, image);
        annotate(&posed, &camera, image)
    };

    let mut summary = RenderSummary {
        frames: 0,
        video: None,
        render_bag: None,
        preview: None,
        forced_keyframes: keyframes(capture, &samples),
        unknown_prop_kinds: unknown,
    };

    // A preview alone renders only the sampled frames.
    let preview_picks = preview_frames(capture, &samples);
    let full = outputs.video.is_some() || outputs.frames_dir.is_some();
    if !full {
        if let Some(path) = &outputs.preview {
            let tiles: Vec<(Vec<u8>, String)> = preview_picks
                .par_iter()
                .map_init(
                    || (CpuRenderer::new(), Image::default()),
                    |(r, image), &k| {
                        render_one(r, image, &samples[k]);
                        (image.rgb.clone(), preview_label(capture, &samples[k]))
                    },
                )
                .collect();
            write_preview(path, &tiles, settings)?;
            summary.preview = Some(path.clone());
            summary.frames = tiles.len() as u64;
        }
        return Ok(summary);
    }

    if let Some(dir) = &outputs.frames_dir {
        std::fs::create_dir_all(dir).map_err(|source| RenderError::Io {
            action: "create the frames folder",
            path: dir.clone(),
            source,
        })?;
    }
    let mut encoder = match (&outputs.video, ffmpeg) {
        (Some(path), Some(ff)) => {
            let mut enc = EncodeSettings::new(settings.width, settings.height, fps)
                .with_keyframes(summary.forced_keyframes.iter().copied());
            enc.crf = settings.crf;
            enc.preset.clone_from(&settings.preset);
            if let Some(g) = settings.gop_frames {
                enc.gop_frames = g;
            }
            Some(VideoEncoder::start(ff, path, &enc)?)
        }
        (Some(_), None) => {
            return Err(RenderError::Settings(
                "a video needs ffmpeg (none was found)".into(),
            ));
        }
        _ => None,
    };

    // Render in parallel batches, hand frames over in order.
    let threads = rayon::current_num_threads().max(1);
    let batch = 4 * threads;
    let mut annotations: Vec<Annotation> = Vec::with_capacity(samples.len());
    let mut preview_tiles: Vec<(Vec<u8>, String)> = Vec::new();
    let (sender, receiver) = std::sync::mpsc::sync_channel::<Vec<(Vec<u8>, Annotation)>>(2);
    let result: Result<(), RenderError> = std::thread::scope(|scope| {
        let producer = scope.spawn(|| {
            // Owned here, so the channel closes when rendering ends.
            let sender = sender;
            for chunk in samples.chunks(batch) {
                if stop.load(Ordering::Relaxed) {
                    break;
                }
                let frames: Vec<(Vec<u8>, Annotation)> = chunk
                    .par_iter()
                    .map_init(
                        || (CpuRenderer::new(), Image::default()),
                        |(r, image), s| {
                            let a = render_one(r, image, s);
                            (image.rgb.clone(), a)
                        },
                    )
                    .collect();
                if sender.send(frames).is_err() {
                    break;
                }
            }
        });
        let mut k = 0usize;
        let mut consume = || -> Result<(), RenderError> {
            for frames in receiver.iter() {
                for (rgb, annotation) in frames {
                    if stop.load(Ordering::Relaxed) {
                        return Err(RenderError::Interrupted);
                    }
                    if let Some(enc) = encoder.as_mut() {
                        enc.write_frame(&rgb)?;
                    }
                    if let Some(dir) = &outputs.frames_dir {
                        crate::video::write_png(
                            &dir.join(format!("frame_{k:06}.png")),
                            settings.width,
                            settings.height,
                            &rgb,
                        )?;
                    }
                    if preview_picks.contains(&k) {
                        preview_tiles.push((rgb, preview_label(capture, &samples[k])));
                    }
                    annotations.push(annotation);
                    k += 1;
                    progress(k as u64);
                }
            }
            Ok(())
        };
        let outcome = consume();
        drop(receiver);
        let _ = producer.join();
        outcome
    });
    if let Err(e) = result {
        if let Some(enc) = encoder {
            enc.abort();
        }
        return Err(e);
    }
    if stop.load(Ordering::Relaxed) || annotations.len() < samples.len() {
        if let Some(enc) = encoder {
            enc.abort();
        }
        return Err(RenderError::Interrupted);
    }
    summary.frames = annotations.len() as u64;
    let video = match encoder {
        Some(enc) => Some(enc.finish()?),
        None => None,
    };
    if let Some(path) = &outputs.preview {
        write_preview(path, &preview_tiles, settings)?;
        summary.preview = Some(path.clone());
    }
    if let Some(bag) = outputs.render_bag_path().filter(|_| video.is_some()) {
        let units = match (&video, ffmpeg) {
            (Some(v), Some(ff)) if settings.embed_video => {
                let units = crate::video::annexb_access_units(ff, &v.path)?;
                if units.len() != samples.len() {
                    return Err(RenderError::Settings(format!(
                        "{}: {} H.264 access units for {} frames; not embedding a stream that does not match",
                        v.path.display(),
                        units.len(),
                        samples.len()
                    )));
                }
                Some(units)
            }
            _ => None,
        };
        write_render_bag(
            &bag,
            capture,
            settings,
            &samples,
            &annotations,
            video.as_ref(),
            &summary.forced_keyframes,
            units.as_deref(),
            rig,
        )?;
        summary.render_bag = Some(bag);
    }
    summary.video = video;
    Ok(summary)
}

/// Frames for the contact sheet: the middle of each clip's animation, at most 12, evenly chosen.
fn preview_frames(capture: &Capture, samples: &[Sample]) -> Vec<usize> {
    let mut mids: Vec<usize> = capture
        .segments
        .iter()
        .filter_map(|s| {
            let (a, b) = (s.content_start.to_nanos()?, s.content_end.to_nanos()?);
            let k = samples.partition_point(|f| f.stamp_nanos < a / 2 + b / 2);
            (k < samples.len()).then_some(k)
        })
        .collect();
    if mids.is_empty() {
        mids = (0..12).map(|i| i * samples.len() / 12).collect();
    }
    let n = mids.len();
    let mut picks: Vec<usize> = (0..n.min(12)).map(|i| mids[i * n / n.min(12)]).collect();
    picks.dedup();
    picks
}

fn preview_label(capture: &Capture, s: &Sample) -> String {
    let scene = &capture.scenes[s.scene].scene;
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

/// Writes the render bag: the video's description, then each frame's labels (and access unit).
#[allow(clippy::too_many_arguments)]
fn write_render_bag(
    path: &Path,
    capture: &Capture,
    settings: &RenderSettings,
    samples: &[Sample],
    annotations: &[Annotation],
    video: Option<&EncodedVideo>,
    forced_keyframes: &[u64],
    units: Option<&[crate::video::AccessUnit]>,
    rig: &Rig,
) -> Result<(), RenderBagError> {
    let header = |stamp_nanos: u64| Header {
        stamp: Time::from_nanos(stamp_nanos),
        frame_id: CAMERA_FRAME.to_owned(),
    };
    let first = samples.first().map_or(0, |s| s.stamp_nanos);
    let info = VideoInfo {
        header: header(first),
        session: capture.session.clone(),
        capture_bag: crate::file_name(&capture.path),
        video_file: video.map(|v| crate::file_name(&v.path)).unwrap_or_default(),
        container: "mp4".into(),
        codec: "h264".into(),
        fps: settings.fps.unwrap_or(capture.fps),
        frame_count: samples.len() as u64,
        width: settings.width,
        height: settings.height,
        forced_keyframes: forced_keyframes.to_vec(),
        settings_json: serde_json::json!({
            "renderer": "autoact cpu",
            "crf": settings.crf,
            "preset": settings.preset,
            "gop_frames": settings.gop_frames,
        })
        .to_string(),
    };
    let names: Vec<String> = rig.bones.iter().map(|b| b.name.clone()).collect();
    let frames = samples
        .iter()
        .zip(annotations)
        .enumerate()
        .map(|(k, (s, a))| RenderedFrame {
            stamp_nanos: s.stamp_nanos,
            annotation: FrameAnnotation {
                header: header(s.stamp_nanos),
                frame_index: k as u64,
                segment_id: s
                    .segment
                    .map(|i| capture.segments[i].id.clone())
                    .unwrap_or_default(),
                keypoint_names: names.clone(),
                keypoints_3d: a.keypoints_3d.clone(),
                keypoints_2d: a.keypoints_2d_ros(),
                visibility: a.visibility.clone(),
                bbox: a.roi(),
                silhouette_pixels: a.silhouette_pixels,
            },
            video: units.and_then(|u| u.get(k)).map(|unit| CompressedVideo {
                timestamp: Time::from_nanos(s.stamp_nanos),
                frame_id: CAMERA_FRAME.to_owned(),
                data: unit.data.clone(),
                format: "h264".into(),
            }),
        });
    bags::render::write(path, first, &info, frames)
}
