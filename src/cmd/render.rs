//! `autoact render`: a capture bag → H.264 video, a render bag (frame ↔ stamp, annotations),
//! PNG frames and a contact sheet.

use std::path::PathBuf;

use anyhow::{Context, Result};

use super::Outcome;
use crate::dataset::spec::EngineName;
use crate::render::blender::{BlenderSettings, Engine};
use crate::render::job::{RenderJob, parse_resolution, render_job};
use crate::render::session::Outputs;

/// Render a capture bag's timeline (with the embedded CPU renderer, or Blender Cycles) and encode
/// it to H.264, with the domain randomisation (`[randomise]`) the bag recorded.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Examples:
  autoact convert --spec examples/dataset.toml -o out/
  autoact render out/demo_gesture_wave_0000.capture.mcap -o out/wave.mp4 --resolution 640x360
  autoact render out/demo_gesture_wave_0000.capture.mcap --preview sheet.png   # 12 frames only
  tools/setup-blender.sh     # once: the venv with Blender's bpy
  autoact render out/demo_gesture_wave_0000.capture.mcap -o out/b.mp4 --engine blender --limit 10

Outputs: the video; beside it `<video>.render.mcap` with /render/video (autoact_msgs/VideoInfo:
frame k shows the timeline at its k-th frame stamp) and /render/annotations
(autoact_msgs/FrameAnnotation: 2D/3D joints and landmarks, visibility and the silhouette's box
per frame);
with --embed-video also /render/camera/h264 (foxglove_msgs/CompressedVideo, which Foxglove plays),
with --embed-video=rerun /render/camera/image/h264 instead (sensor_msgs/CompressedImage, format
h264, which Rerun plays), with --embed-video=both the two. Every segment
boundary is a keyframe, so `autoact trim` cuts clips by stream copy. Files appear only when
complete; Ctrl-C or an error removes partial ones.")]
pub struct Args {
    /// Capture bag (`autoact convert --spec` output): MCAP file or rosbag2 folder.
    pub capture: PathBuf,
    /// Output video (.mp4, .mov or .mkv).
    #[arg(short, long, value_name = "VIDEO")]
    pub output: Option<PathBuf>,
    /// How frames are rendered and encoded.
    #[command(flatten)]
    pub engine: EngineArgs,
    /// Also write every frame as PNG into this folder (frame_000000.png, …).
    #[arg(long, value_name = "DIR")]
    pub frames_out: Option<PathBuf>,
    /// Write a contact sheet of up to 12 sampled frames (one per clip) to this PNG. Without
    /// `-o` and `--frames-out`, only those frames are rendered.
    #[arg(long, value_name = "PNG")]
    pub preview: Option<PathBuf>,
    #[command(flatten)]
    pub passes: PassArgs,
    /// Render bag path (default: beside the video, `<video stem>.render.mcap`).
    #[arg(long, value_name = "MCAP")]
    pub render_bag: Option<PathBuf>,
    /// Put the encoded H.264 (Annex B) into the render bag: as foxglove_msgs/CompressedVideo for
    /// Foxglove (`--embed-video`), as sensor_msgs/CompressedImage frames of format h264 for
    /// Rerun (`--embed-video=rerun`), or both (`=both`, the stream twice).
    #[arg(
        long,
        value_enum,
        value_name = "VIEWER",
        num_args = 0..=1,
        require_equals = true,
        default_missing_value = "foxglove"
    )]
    pub embed_video: Option<crate::bags::render::EmbedVideo>,
    /// Render only the first N frames (a quick look; the video then covers only those).
    #[arg(long, value_name = "N")]
    pub limit: Option<usize>,
    /// Draw clean pictures: no colour jitter, sensor noise, motion blur or drawn CRF. Without
    /// it, the capture bag's recorded `[randomise]` applies, so the frames are `generate`'s
    /// (bags written before autoact recorded it get the defaults).
    #[arg(long)]
    pub no_randomise: bool,
    /// Replace outputs that exist.
    #[arg(long)]
    pub force: bool,
}

/// The renderer's and encoder's options, shared by `render` and `generate`.
#[derive(Debug, Clone, clap::Args)]
pub struct EngineArgs {
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
    /// x264 options after the preset, `key=value` pairs joined by `:` (ffmpeg's
    /// `-x264opts`). The default puts CABAC and the deblocking filter back into `ultrafast`
    /// (smaller files at the same PSNR, about half `superfast`'s encoding CPU); it changes
    /// nothing with the other presets. `''` for the preset alone.
    #[arg(long, value_name = "K=V:…", default_value = crate::video::DEFAULT_X264_OPTIONS)]
    pub x264_options: String,
    /// Longest keyframe interval, frames (segment boundaries are always keyframes).
    #[arg(long, value_name = "FRAMES")]
    pub gop: Option<u32>,
    /// x264 threads. Fixed rather than the machine's, because x264's output depends on it: the
    /// same count gives the same videos on any machine. More pays only when the renderer draws
    /// faster than one thread encodes (about 600 frames/s at 320x240, 59 at 1280x720 on the
    /// reference machine).
    #[arg(long, value_name = "N", default_value_t = crate::video::DEFAULT_ENCODER_THREADS,
          value_parser = clap::value_parser!(u8).range(1..=i64::from(crate::video::MAX_ENCODER_THREADS)))]
    pub encoder_threads: u8,
    /// Rendering threads (default: all cores).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// If ffmpeg is not installed, download a static build into the user cache (needs the
    /// `download-ffmpeg` build feature and network access).
    #[arg(long)]
    pub download_ffmpeg: bool,
    /// What draws the frames: `embedded` (autoact's CPU renderer) or `blender` (Blender Cycles
    /// through PyPI `bpy`: run tools/setup-blender.sh first; a GPU is used when Cycles finds
    /// one). The labels are the same. Default: `embedded` (`generate`: the spec's
    /// `[dataset] engine`).
    #[arg(long, value_enum, value_name = "ENGINE")]
    pub engine: Option<EngineName>,
    /// The Python with `bpy` for `--engine blender` (default: $AUTOACT_BLENDER_PYTHON, else the
    /// venv tools/setup-blender.sh makes).
    #[arg(long, value_name = "PATH")]
    pub blender_python: Option<PathBuf>,
    /// Cycles samples per pixel for `--engine blender` (then denoised).
    #[arg(long, value_name = "N", default_value_t = crate::render::blender::DEFAULT_SAMPLES)]
    pub blender_samples: u32,
}

impl EngineArgs {
    /// The engine asked for, `default` when none was.
    #[must_use]
    pub fn engine(&self, default: EngineName) -> Engine {
        match self.engine.unwrap_or(default) {
            EngineName::Embedded => Engine::Embedded,
            EngineName::Blender => Engine::Blender(BlenderSettings {
                python: self.blender_python.clone(),
                samples: self.blender_samples,
                threads: self.threads,
                ..BlenderSettings::default()
            }),
        }
    }

    /// Sets the number of rendering threads, if asked.
    ///
    /// # Errors
    /// When the thread pool cannot be built.
    pub fn set_threads(&self) -> Result<()> {
        if let Some(n) = self.threads {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n.max(1))
                .build_global()
                .context("cannot set the number of threads")?;
        }
        Ok(())
    }
}

/// The per-pixel label passes written beside the video (`autoact trim` gives every clip its
/// frames of them).
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct PassArgs {
    /// Also write the depth pass beside the video: `<video stem>.depth/frame_000000.png`, …,
    /// 16-bit grey, millimetres along the optical axis, 0 for the sky. Needs `-o`.
    #[arg(long, requires = "output")]
    pub depth: bool,
    /// Also write the instance mask pass beside the video: `<video stem>.mask/frame_000000.png`,
    /// …, 8-bit grey, 0 background, 1 the person. Needs `-o`.
    #[arg(long, requires = "output")]
    pub masks: bool,
}

impl PassArgs {
    /// The passes asked for.
    #[must_use]
    pub fn wanted(self) -> crate::render::passes::Wanted {
        crate::render::passes::Wanted {
            depth: self.depth,
            mask: self.masks,
        }
    }
}

/// Runs `autoact render`.
///
/// # Errors
/// Unreadable or incomplete capture bags, ffmpeg missing or failing, unwritable outputs.
pub fn run(args: Args) -> Result<Outcome> {
    args.engine.set_threads()?;
    let renderer = args.engine.engine(EngineName::Embedded);
    let engine = args.engine;
    let video = args.output.as_deref();
    let depth_dir = video
        .filter(|_| args.passes.depth)
        .map(crate::bags::render::depth_dir_beside);
    let mask_dir = video
        .filter(|_| args.passes.masks)
        .map(crate::bags::render::mask_dir_beside);
    let job = RenderJob {
        capture: args.capture,
        outputs: Outputs {
            video: args.output,
            render_bag: args.render_bag,
            frames_dir: args.frames_out,
            preview: args.preview,
            depth_dir,
            mask_dir,
        },
        resolution: engine.resolution,
        fps: engine.fps,
        limit: args.limit,
        crf: engine.crf,
        preset: engine.preset,
        x264_options: engine.x264_options,
        gop_frames: engine.gop,
        encoder_threads: engine.encoder_threads,
        embed_video: args.embed_video,
        force: args.force,
        download_ffmpeg: engine.download_ffmpeg,
        engine: renderer,
        no_randomise: args.no_randomise,
    };
    let report = render_job(&job, crate::interrupt::Interrupt::install()?.flag())?;
    super::print_stdout(&report.report()).context("writing to stdout")?;
    Ok(Outcome::Success)
}
