//! `autoact render`: a capture bag → H.264 video, a render bag (frame ↔ stamp, annotations),
//! PNG frames and a contact sheet.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::{Context, Result, bail};

use super::Outcome;
use crate::bags::capture::Capture;
use crate::render::session::{Outputs, RenderSettings, render_capture};
use crate::skeleton::rig::Rig;

/// Render a capture bag's timeline with the embedded CPU renderer and encode it to H.264.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Examples:
  autoact convert --spec examples/dataset.toml -o out/
  autoact render out/demo_gesture_wave_0000.capture.mcap -o out/wave.mp4 --resolution 640x360
  autoact render out/demo_gesture_wave_0000.capture.mcap --preview sheet.png   # 12 frames only

Outputs: the video; beside it `<video>.render.mcap` with /render/video (autoact_msgs/VideoInfo:
frame k shows the timeline at its k-th frame stamp) and /render/annotations
(autoact_msgs/FrameAnnotation: 2D/3D joints, visibility and the silhouette's box per frame);
with --embed-video also /render/camera/h264 (foxglove_msgs/CompressedVideo). Every segment
boundary is a keyframe, so `autoact trim` cuts clips by stream copy. Files appear only when
complete; Ctrl-C or an error removes partial ones.")]
pub struct Args {
    /// Capture bag (`autoact convert --spec` output): MCAP file or rosbag2 folder.
    pub capture: PathBuf,
    /// Output video (.mp4, .mov or .mkv).
    #[arg(short, long, value_name = "VIDEO")]
    pub output: Option<PathBuf>,
    /// Output size WIDTHxHEIGHT (even numbers); default: the capture's camera resolution. The
    /// horizontal field of view is kept.
    #[arg(long, value_name = "WxH", value_parser = parse_resolution)]
    pub resolution: Option<(u32, u32)>,
    /// Output frame rate; default: the capture's. Other rates interpolate poses and cameras.
    #[arg(long)]
    pub fps: Option<f64>,
    /// x264 constant rate factor: 0 lossless … 51 worst.
    #[arg(long, default_value_t = crate::video::DEFAULT_CRF, value_parser = clap::value_parser!(u8).range(0..=51))]
    pub crf: u8,
    /// x264 preset (ultrafast … veryslow): speed against file size.
    #[arg(long, default_value = crate::video::DEFAULT_PRESET)]
    pub preset: String,
    /// Longest keyframe interval, frames (segment boundaries are always keyframes).
    #[arg(long, value_name = "FRAMES")]
    pub gop: Option<u32>,
    /// Also write every frame as PNG into this folder (frame_000000.png, …).
    #[arg(long, value_name = "DIR")]
    pub frames_out: Option<PathBuf>,
    /// Write a contact sheet of up to 12 sampled frames (one per clip) to this PNG. Without
    /// `-o` and `--frames-out`, only those frames are rendered.
    #[arg(long, value_name = "PNG")]
    pub preview: Option<PathBuf>,
    /// Render bag path (default: beside the video, `<video stem>.render.mcap`).
    #[arg(long, value_name = "MCAP")]
    pub render_bag: Option<PathBuf>,
    /// Put the encoded H.264 (Annex B) into the render bag as foxglove_msgs/CompressedVideo.
    #[arg(long)]
    pub embed_video: bool,
    /// Render only the first N frames (a quick look; the video then covers only those).
    #[arg(long, value_name = "N")]
    pub limit: Option<usize>,
    /// Rendering threads (default: all cores).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Replace outputs that exist.
    #[arg(long)]
    pub force: bool,
    /// If ffmpeg is not installed, download a static build into the user cache (needs the
    /// `download-ffmpeg` build feature and network access).
    #[arg(long)]
    pub download_ffmpeg: bool,
}

fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{s}`: expected WIDTHxHEIGHT, e.g. 640x360"))?;
    let n = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("`{s}`: `{v}` is not a whole number"))
    };
    Ok((n(w)?, n(h)?))
}

/// Runs `autoact render`.
///
/// # Errors
/// Unreadable or incomplete capture bags, ffmpeg missing or failing, unwritable outputs.
pub fn run(args: Args) -> Result<Outcome> {
    if args.output.is_none() && args.frames_out.is_none() && args.preview.is_none() {
        bail!("nothing to write: give `-o VIDEO`, `--frames-out DIR` or `--preview PNG`");
    }
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()
            .context("cannot set the number of threads")?;
    }
    let outputs = Outputs {
        video: args.output.clone(),
        render_bag: args.render_bag.clone(),
        frames_dir: args.frames_out.clone(),
        preview: args.preview.clone(),
    };
    for path in [
        outputs.video.clone(),
        outputs.render_bag_path(),
        outputs.preview.clone(),
    ]
    .into_iter()
    .flatten()
    {
        if path.exists() && !args.force {
            bail!("`{}` exists; pass `--force` to replace it", path.display());
        }
    }
    for path in [
        outputs.video.as_ref(),
        outputs.preview.as_ref(),
        args.render_bag.as_ref(),
    ]
    .into_iter()
    .flatten()
    {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("cannot create the folder `{}`", dir.display()))?;
        }
    }
    let ffmpeg = if args.output.is_some() {
        Some(super::locate_ffmpeg(args.download_ffmpeg)?)
    } else {
        None
    };
    let rig = Rig::standard();
    let capture = Capture::read(&rig, &args.capture)?;
    let (width, height) = args
        .resolution
        .unwrap_or((capture.intrinsics.width_px, capture.intrinsics.height_px));
    if let Some(fps) = args.fps
        && !(fps.is_finite() && fps > 0.0)
    {
        bail!("--fps {fps}: must be a positive number");
    }
    let settings = RenderSettings {
        width,
        height,
        fps: args.fps,
        limit: args.limit,
        crf: args.crf,
        preset: args.preset.clone(),
        gop_frames: args.gop,
        embed_video: args.embed_video,
    };
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .context("cannot install the signal handler")?;
    }
    let total = args
        .limit
        .map_or(capture.frames.len(), |n| n.min(capture.frames.len()));
    let bar = indicatif::ProgressBar::new(total as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} rendering [{bar:30}] {pos}/{len} frames  {per_sec}  ETA {eta}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    if tracing::enabled!(tracing::Level::ERROR) && !tracing::enabled!(tracing::Level::WARN) {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let started = std::time::Instant::now();
    let progress = |k: u64| bar.set_position(k);
    let summary = render_capture(
        &rig,
        &capture,
        &settings,
        &outputs,
        ffmpeg.as_ref(),
        &progress,
        &stop,
    )
    .with_context(|| format!("rendering `{}`", args.capture.display()));
    bar.finish_and_clear();
    let summary = summary?;
    let seconds = started.elapsed().as_secs_f64();
    let mut text = String::new();
    let fps = summary.frames as f64 / seconds.max(1e-9);
    text.push_str(&format!(
        "rendered {} frames at {width}x{height} in {seconds:.1} s ({fps:.0} frames/s, {:.1}x real time)\n",
        summary.frames,
        fps / settings.fps.unwrap_or(capture.fps)
    ));
    if let Some(v) = &summary.video {
        text.push_str(&format!(
            "  video: {} ({} frames, {:.1} MB, keyframes forced at {} segment boundaries)\n",
            v.path.display(),
            v.frame_count,
            v.bytes as f64 / 1e6,
            summary.forced_keyframes.len()
        ));
    }
    if let Some(b) = &summary.render_bag {
        text.push_str(&format!("  render bag: {}\n", b.display()));
    }
    if let Some(dir) = &args.frames_out {
        text.push_str(&format!("  frames: {}\n", dir.display()));
    }
    if let Some(p) = &summary.preview {
        text.push_str(&format!("  preview: {}\n", p.display()));
    }
    if !summary.unknown_prop_kinds.is_empty() {
        tracing::warn!(
            "prop kinds without a shape were drawn as boxes: {}",
            summary.unknown_prop_kinds.join(", ")
        );
    }
    super::print_stdout(&text).context("writing to stdout")?;
    Ok(Outcome::Success)
}
