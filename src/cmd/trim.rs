//! `autoact trim`: a capture bag and its video → one clip per leaf segment, with Kinetics,
//! MMAction2 and ActivityNet annotations.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use anyhow::{Context, Result, bail};

use super::Outcome;
use crate::bags::capture::Capture;
use crate::bags::render::{RenderedVideo, render_bag_beside};
use crate::skeleton::rig::Rig;
use crate::trim::run::{RunError, TrimOptions, VideoSource, trim_capture};
use crate::trim::split::{Key, Split, SplitConfig};
use crate::video::{Rational, ReencodeSettings};

/// Cut a rendered capture into one clip per leaf segment and write the annotation lists.
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
  annotations/classes.txt, label_map.json  one sorted class list, ids 0-based, for every split
  annotations/kinetics_<split>.csv         label,youtube_id,time_start,time_end,split
  annotations/<split>_list_videos.txt      <path> <label_id>          (VideoDataset)
  annotations/<split>_list_rawframes.txt   <dir> <frames> <label_id>  (RawframeDataset)
  annotations/activitynet.json             untrimmed captures with every segment
  annotations/clips.jsonl                  per clip: source animation, variant, weather, time,
                                           location, character, camera, seed, split
  manifest.jsonl                           journal of complete clips
Splits are not in the paths: they are drawn over every clip in the manifest, so several captures
can be trimmed into one folder. Clips are cut frame-exact: by stream copy when the clip starts
on a keyframe (autoact's renders put one on every segment boundary), by re-encoding otherwise.
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
    /// What clips of one split share: no value of it appears in two splits.
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
    /// Re-encode every clip, even where stream copy is exact.
    #[arg(long)]
    pub reencode: bool,
    /// x264 preset for re-encoded clips.
    #[arg(long, default_value = "veryfast")]
    pub preset: String,
    /// x264 constant rate factor for re-encoded clips.
    #[arg(long, default_value_t = 18, value_parser = clap::value_parser!(u8).range(0..=51))]
    pub crf: u8,
    /// Also extract every clip's frames (`img_00001.jpg` …) and write RawframeDataset lists.
    #[arg(long)]
    pub rawframes: bool,
    /// If ffmpeg is not installed, download a static build into the user cache (needs the
    /// `download-ffmpeg` build feature and network access).
    #[arg(long)]
    pub download_ffmpeg: bool,
}

fn parse_ratios(s: &str) -> Result<[f64; 3], String> {
    let parts: Vec<f64> = s
        .split(',')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .map_err(|_| format!("`{p}` is not a number"))
        })
        .collect::<Result<_, _>>()?;
    let [a, b, c] = parts[..] else {
        return Err(format!(
            "`{s}`: give three fractions TRAIN,VAL,TEST, e.g. 0.7,0.15,0.15"
        ));
    };
    if ![a, b, c].iter().all(|r| r.is_finite() && *r >= 0.0) || a + b + c <= 0.0 {
        return Err(format!(
            "`{s}`: fractions must be non-negative and not all zero"
        ));
    }
    Ok([a, b, c])
}

fn parse_hold_out(s: &str) -> Result<(Key, String), String> {
    use clap::ValueEnum;
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| format!("`{s}`: expected KEY=VALUE, e.g. weather=RAIN"))?;
    let key = Key::from_str(k, true).map_err(|_| {
        format!(
            "`{k}`: hold out by weather, location, time, character, animation, variant or scene"
        )
    })?;
    Ok((key, v.to_owned()))
}

/// Runs `autoact trim`.
///
/// # Errors
/// Unreadable capture bag or video, ffmpeg missing or failing, an unwritable dataset folder, a
/// dataset folder holding another class list.
pub fn run(args: Args) -> Result<Outcome> {
    let ffmpeg = super::locate_ffmpeg(args.download_ffmpeg)?;
    let rig = Rig::standard();
    let capture = Capture::read(&rig, &args.capture)?;
    if !args.video.is_file() {
        bail!("`{}`: no such video", args.video.display());
    }
    let video_fps = |default: f64| -> Result<Rational> {
        let fps = args.video_fps.unwrap_or(default);
        Rational::from_f64(fps)
            .filter(|_| fps.is_finite() && fps > 0.0)
            .with_context(|| format!("frame rate {fps}: must be a positive number"))
    };
    let (frame0_nanos, fps) = if let Some(start_s) = args.video_start {
        if !start_s.is_finite() {
            bail!("--video-start {start_s}: must be a number of seconds");
        }
        let first = capture.frames.first().map_or(0, |f| f.stamp_nanos);
        #[expect(
            clippy::cast_possible_truncation,
            reason = "seconds of video fit in i128 ns"
        )]
        let offset = (start_s * 1e9).round() as i128;
        (i128::from(first) + offset, video_fps(capture.fps)?)
    } else {
        let bag = args
            .render_bag
            .clone()
            .unwrap_or_else(|| render_bag_beside(&args.video));
        if !bag.exists() {
            bail!(
                "no render bag `{}` beside the video, so its frame 0 cannot be placed on the capture's timeline: pass `--video-start SECONDS` (and `--video-fps`) for a video autoact did not render, or `--render-bag`",
                bag.display()
            );
        }
        let rendered = RenderedVideo::read(&bag)?;
        rendered.check_renders(&capture)?;
        let video_name = crate::file_name(&args.video);
        if !rendered.video_file.is_empty() && rendered.video_file != video_name {
            tracing::warn!(
                "render bag `{}` was written for video `{}`; using its timing for `{video_name}`",
                bag.display(),
                rendered.video_file
            );
        }
        let fps = match args.video_fps {
            Some(_) => video_fps(rendered.fps.as_f64())?,
            None => rendered.fps,
        };
        (rendered.frame0_nanos, fps)
    };
    let options = TrimOptions {
        split: SplitConfig {
            by: args.split_by,
            ratios: args.split_ratios,
            seed: args.seed.or(capture.seed).unwrap_or(0),
            hold_out: args.hold_out.clone(),
        },
        force_reencode: args.reencode,
        reencode: ReencodeSettings {
            preset: args.preset.clone(),
            crf: args.crf,
        },
        rawframes: args.rawframes,
    };
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .context("cannot install the signal handler")?;
    }
    let bar = indicatif::ProgressBar::new(capture.segments.len() as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} trimming [{bar:30}] {pos}/{len} clips  ETA {eta}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    if !tracing::enabled!(tracing::Level::WARN) {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let started = std::time::Instant::now();
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    };
    let source = VideoSource {
        path: &args.video,
        frame0_nanos,
        fps,
    };
    let result = trim_capture(
        &ffmpeg,
        &capture,
        &source,
        &args.output,
        &options,
        &progress,
        &stop,
    );
    bar.finish_and_clear();
    let summary = match result {
        Ok(s) => s,
        Err(e @ RunError::Interrupted) => return Err(e.into()),
        Err(e) => {
            return Err(anyhow::Error::new(e).context(format!(
                "trimming `{}` into `{}` (complete clips are kept and listed; run again to resume)",
                args.video.display(),
                args.output.display()
            )));
        }
    };
    let seconds = started.elapsed().as_secs_f64();
    super::warn_list("truncated segments", &summary.truncated, 20);
    let mut text = format!(
        "trimmed {} clips ({} by stream copy, {} re-encoded, {} already complete) in {seconds:.1} s",
        summary.copied + summary.reencoded + summary.skipped,
        summary.copied,
        summary.reencoded,
        summary.skipped
    );
    if summary.frames_cut > 0 {
        let realtime = summary.frames_cut as f64 / fps.as_f64() / seconds.max(1e-9);
        text.push_str(&format!(" ({realtime:.0}x real time)"));
    }
    text.push('\n');
    if !summary.truncated.is_empty() {
        text.push_str(&format!(
            "  {} segments left out: the video does not cover them\n",
            summary.truncated.len()
        ));
    }
    let counts: Vec<String> = Split::ALL
        .iter()
        .map(|s| {
            format!(
                "{} {}",
                s.name(),
                summary.lists.clips.get(s).copied().unwrap_or(0)
            )
        })
        .collect();
    text.push_str(&format!(
        "  dataset {}: {} (split by {}, seed {})\n",
        args.output.display(),
        counts.join(", "),
        clap::ValueEnum::to_possible_value(&options.split.by)
            .map_or_else(String::new, |v| v.get_name().to_owned()),
        options.split.seed
    ));
    super::print_stdout(&text).context("writing to stdout")?;
    Ok(if summary.truncated.is_empty() {
        Outcome::Success
    } else {
        Outcome::DataLost
    })
}

#[cfg(test)]
mod tests {
    use super::{parse_hold_out, parse_ratios};
    use crate::trim::split::Key;

    #[test]
    fn ratios_and_hold_outs_parse_or_say_what_is_expected() {
        assert_eq!(parse_ratios("0.8,0.1,0.1").unwrap(), [0.8, 0.1, 0.1]);
        assert_eq!(parse_ratios("1, 0, 0").unwrap(), [1.0, 0.0, 0.0]);
        assert!(
            parse_ratios("0.8,0.2")
                .unwrap_err()
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
        assert!(parse_hold_out("weather").unwrap_err().contains("KEY=VALUE"));
        assert!(parse_hold_out("colour=red").is_err());
    }
}
