//! `autoact trim`: a capture bag and its video → clips by the clip policy, with Kinetics,
//! MMAction2 and ActivityNet annotations.

use std::path::PathBuf;

use anyhow::{Context, Result};

use super::Outcome;
use crate::dataset::clips::{ClipMode, ClipsSection, Tail};
use crate::trim::job::{TrimJob, parse_hold_out, parse_jpeg_quality, parse_ratios, trim_job};
use crate::trim::split::Key;
use crate::video::ReencodeSettings;

/// Cut a rendered capture into clips (by default one per leaf segment's animation) and write the
/// annotation lists.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Examples:
  autoact convert --spec examples/dataset.toml -o out/
  autoact render out/demo_gesture_wave_0000.capture.mcap -o out/wave.mp4 --resolution 640x360
  autoact trim out/demo_gesture_wave_0000.capture.mcap out/wave.mp4 -o dataset/
  # a video from another engine or a screen recorder, whose frame 0 shows the timeline at 2.5 s:
  autoact trim session.capture.mcap recording.mp4 --video-start 2.5 --video-fps 30 -o dataset/
  # hold out a whole weather for testing:
  autoact trim session.capture.mcap capture.mp4 -o dataset/ --hold-out weather=RAIN

Layout of DATASET_DIR (MMAction2's data_prefix; every path in the lists is relative to it):
  videos/<label>/<clip_id>.mp4            clips (label and id sanitised: letters, digits, - _ .)
  rawframes/<label>/<clip_id>/img_00001.jpg  with --rawframes
  depth/<label>/<clip_id>/img_00001.png      when rendered with --depth (16-bit, mm)
  masks/<label>/<clip_id>/img_00001.png      when rendered with --masks (0 background, 1 person)
  annotations/classes.txt, label_map.json  one sorted class list, ids 0-based, for every split
  annotations/kinetics_<split>.csv         label,youtube_id,time_start,time_end,split
  annotations/<split>_list_videos.txt      <path> <label_id>          (VideoDataset)
  annotations/<split>_list_rawframes.txt   <dir> <frames> <label_id>  (RawframeDataset)
  annotations/activitynet.json             untrimmed captures with every segment
  annotations/clips.jsonl                  per clip: source animation, variant, weather, time,
                                           location, character, camera, seed, split,
                                           split_by (what it shares its split with), qa
  annotations/qa.json                      quality report: clips whose character is hidden,
                                           occluded, tiny or still, and classes that barely
                                           move (from the render bag's annotations)
  annotations/contact_sheets/<label>.png   a tile per clip (up to 24) at its action's middle,
                                           flagged clips first, framed in red; <label>.json
                                           says which clip and frame each tile is
  annotations/skeleton_2d_coco17.pkl       MMAction2/PYSKL PoseDataset: COCO-17 keypoints, px
  annotations/skeleton_3d_ntu25.pkl        the same in NTU-25 joints, metres (Kinect space)
  annotations/coco_keypoints_<split>.json  COCO person keypoints and boxes, an image per frame
  labels/<label>/<clip_id>.json            per-clip labels the three files are rebuilt from
                                           (all four from the render bag's landmarks; COCO
                                           visibility: 0 out of the image, 1 hidden, 2 seen)
  manifest.jsonl                           journal of complete clips
Splits are not in the paths: they are decided over every clip of the dataset's plan (plan.json,
beside the capture bags, or one folder up as `generate` keeps it), so a clip's split does not
depend on which captures are trimmed yet or in what order, and several captures can be trimmed
into one folder (without a plan: over the clips in the folder so far, which may move clips
between splits as captures arrive). A class with fewer groups than splits to fill is grouped
more finely (variant, then scene, then clip), with a warning saying what leaks; clips.jsonl
records each clip's `split_by`.
Clips are cut frame-exact: by stream copy when the clip starts on a keyframe (autoact's renders
put one on every segment boundary), by re-encoding otherwise.
A re-run skips complete clips and rewrites the lists; lists never name a clip that is not
complete on disk. Segments the video does not fully cover are reported, left out, and end the
run with exit code 3.")]
pub struct Args {
    /// Capture bag (`autoact convert --spec` output): MCAP file or rosbag2 folder.
    pub capture: PathBuf,
    /// The capture's video.
    pub video: PathBuf,
    /// Dataset folder (created; re-runs resume in it).
    #[arg(short, long, value_name = "DATASET_DIR")]
    pub output: PathBuf,
    /// Time on the capture's timeline shown by video frame 0, seconds after the timeline's first
    /// frame (negative: the video started earlier). Needed for videos `autoact render` did not
    /// write; without it the render bag beside the video gives it.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub video_start: Option<f64>,
    /// The video's frame rate (default: the render bag's, else the capture's).
    #[arg(long, value_name = "FPS")]
    pub video_fps: Option<f64>,
    /// Render bag of the video (default: `<video stem>.render.mcap` beside it): places its frame
    /// 0 on the capture's timeline. It must be a render of the capture bag's session.
    #[arg(long, value_name = "MCAP")]
    pub render_bag: Option<PathBuf>,
    /// How clips are split.
    #[command(flatten)]
    pub split: SplitArgs,
    /// The dataset's plan, to decide the splits over (default: `plan.json` beside the capture
    /// bag, as `convert --spec` writes it, or one folder up, as `generate` does, when it is this
    /// capture's).
    #[arg(long, value_name = "PLAN_JSON")]
    pub plan: Option<PathBuf>,
    /// How clips are cut.
    #[command(flatten)]
    pub cut: CutArgs,
    /// x264 preset for re-encoded clips.
    #[arg(long, default_value = "veryfast")]
    pub preset: String,
    /// x264 constant rate factor for re-encoded clips.
    #[arg(long, default_value_t = 18, value_parser = clap::value_parser!(u8).range(0..=51))]
    pub crf: u8,
    /// JPEG quality of `--rawframes`: ffmpeg qscale, 2 (best) … 31, or a range `MIN,MAX` each
    /// clip's quality is drawn from (by the dataset's seed and the clip id). Default: the spec's
    /// `[randomise] jpeg_quality` as the capture bag recorded it (what `generate` uses), else 2.
    #[arg(long, value_name = "Q|MIN,MAX", value_parser = parse_jpeg_quality)]
    pub jpeg_quality: Option<[u8; 2]>,
    /// How segments are cut into clips.
    #[command(flatten)]
    pub clips: ClipArgs,
    /// If ffmpeg is not installed, download a static build into the user cache (needs the
    /// `download-ffmpeg` build feature and network access).
    #[arg(long)]
    pub download_ffmpeg: bool,
}

/// How clips are split, shared by `trim` and `generate`.
#[derive(Debug, Clone, clap::Args)]
pub struct SplitArgs {
    /// What clips of one split share: no value of it appears in two splits. A class with too few
    /// groups to fill every split is grouped by the next finer level (variant, scene, clip).
    #[arg(long, value_enum, default_value_t = Key::Animation)]
    pub split_by: Key,
    /// Train, val and test fractions.
    #[arg(long, value_name = "TRAIN,VAL,TEST", default_value = "0.7,0.15,0.15", value_parser = parse_ratios)]
    pub split_ratios: [f64; 3],
    /// Seed of the split (default: the dataset's seed).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Put every clip with this value in test, e.g. `weather=RAIN`, `location=street`,
    /// `time=23:00`, `character=<id from clips.jsonl>` (repeatable).
    #[arg(long, value_name = "KEY=VALUE", value_parser = parse_hold_out)]
    pub hold_out: Vec<(Key, String)>,
}

/// How clips are cut, shared by `trim` and `generate`.
#[derive(Debug, Clone, clap::Args)]
pub struct CutArgs {
    /// Re-encode every clip, even where stream copy is exact.
    #[arg(long)]
    pub reencode: bool,
    /// Also extract every clip's frames (`img_00001.jpg` …) and write RawframeDataset lists.
    #[arg(long)]
    pub rawframes: bool,
}

/// `trim`'s clip policy options: each overrides the plan's value for every class.
#[derive(Debug, clap::Args)]
pub struct ClipArgs {
    /// Clip policy for every class, over the plan's (`[clips]` in the spec; default `whole`):
    /// `whole` (the animation), `windows` (fixed length and stride), `instances` (one clip per
    /// burst of motion).
    #[arg(long, value_enum, value_name = "POLICY")]
    pub clips: Option<ClipMode>,
    /// Include the still lead-in and lead-out in the clips (default: the plan's, else not).
    #[arg(long)]
    pub include_lead: bool,
    /// `windows`: frames per window.
    #[arg(long, value_name = "FRAMES")]
    pub window_frames: Option<u64>,
    /// `windows`: frames from one window's start to the next's.
    #[arg(long, value_name = "FRAMES")]
    pub stride_frames: Option<u64>,
    /// `windows`: the frames after the last full window: `shift` (one more window ending on the
    /// last frame), `drop`, or `keep` (a shorter window).
    #[arg(long, value_enum)]
    pub tail: Option<Tail>,
    /// `instances`: the shortest instance kept, frames.
    #[arg(long, value_name = "FRAMES")]
    pub min_frames: Option<u64>,
    /// `instances`: the longest clip, frames (longer bursts are cut into equal parts).
    #[arg(long, value_name = "FRAMES")]
    pub max_frames: Option<u64>,
    /// `instances`: frames of context before and after each instance.
    #[arg(long, value_name = "FRAMES")]
    pub pad_frames: Option<u64>,
}

impl ClipArgs {
    /// The keys given.
    fn section(&self) -> ClipsSection {
        ClipsSection {
            policy: self.clips,
            include_lead: self.include_lead.then_some(true),
            length_frames: self.window_frames,
            stride_frames: self.stride_frames,
            tail: self.tail,
            min_frames: self.min_frames,
            max_frames: self.max_frames,
            pad_frames: self.pad_frames,
            min_rest_frames: None,
        }
    }
}

/// Runs `autoact trim`.
///
/// # Errors
/// Unreadable capture bag or video, ffmpeg missing or failing, an unwritable dataset folder, a
/// dataset folder holding another class list.
pub fn run(args: Args) -> Result<Outcome> {
    let job = TrimJob {
        capture: args.capture,
        video: args.video,
        output: args.output,
        video_start_s: args.video_start,
        video_fps: args.video_fps,
        render_bag: args.render_bag,
        split_by: args.split.split_by,
        split_ratios: args.split.split_ratios,
        seed: args.split.seed,
        hold_out: args.split.hold_out,
        plan: args.plan,
        force_reencode: args.cut.reencode,
        reencode: ReencodeSettings {
            preset: args.preset,
            crf: args.crf,
        },
        rawframes: args.cut.rawframes,
        jpeg_quality: args.jpeg_quality,
        download_ffmpeg: args.download_ffmpeg,
        clips: args.clips.section(),
    };
    let report = trim_job(&job, crate::interrupt::Interrupt::install()?.flag())?;
    super::warn_list("truncated segments", &report.summary.truncated, 20);
    super::print_stdout(&report.report()).context("writing to stdout")?;
    Ok(Outcome::from_run(&report))
}
