//! Trim speed on a long capture: a capture bag (`autoact convert --spec`) and a synthetic
//! 640×360 video of its whole timeline with a keyframe on every segment boundary (as `autoact
//! render` writes), cut into clips by stream copy, then a sample of clips re-encoded.
//!
//! Usage: `cargo run --release --example trim_bench -- CAPTURE_BAG WORK_DIR`
//! (`tools/bench_trim.sh` makes a 10-minute capture bag and runs this).

#![expect(clippy::print_stdout, reason = "a benchmark prints its results")]

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use anyhow::{Context, Result};
use autoact::bags::capture::Capture;
use autoact::skeleton::rig::Rig;
use autoact::trim::run::{TrimOptions, VideoSource, trim_capture};
use autoact::trim::split::SplitConfig;
use autoact::video::{EncodeSettings, Ffmpeg, Rational, ReencodeSettings, VideoEncoder};

fn main() -> Result<()> {
    let mut args = std::env::args_os().skip(1);
    let (Some(bag), Some(work)) = (args.next(), args.next()) else {
        anyhow::bail!("usage: trim_bench CAPTURE_BAG WORK_DIR");
    };
    let (bag, work) = (PathBuf::from(bag), PathBuf::from(work));
    std::fs::create_dir_all(&work)?;
    let ffmpeg = Ffmpeg::locate()?;
    let capture = Capture::read(&Rig::standard(), &bag)?;
    let n = capture.frame_count() as u64;
    let (w, h) = (640_u32, 360_u32);
    let video = work.join("capture.mp4");
    let started = Instant::now();
    let settings = EncodeSettings::new(w, h, capture.fps).with_keyframes(capture.boundary_frames());
    let mut enc = VideoEncoder::start(&ffmpeg, &video, &settings)?;
    let mut frame = vec![0_u8; settings.frame_bytes()];
    for k in 0..n {
        // A moving gradient: cheap to make, not free to encode.
        for (i, px) in frame.chunks_mut(3).enumerate() {
            let (x, y) = (i as u64 % u64::from(w), i as u64 / u64::from(w));
            px.copy_from_slice(&[(x + k) as u8, (y + 2 * k) as u8, (x ^ y) as u8]);
        }
        enc.write_frame(&frame)?;
    }
    let v = enc.finish()?;
    let video_s = n as f64 / capture.fps;
    println!(
        "capture: {} frames ({:.1} min) at {w}x{h}, {} segments, {:.1} MB, encoded in {:.1} s",
        n,
        video_s / 60.0,
        capture.segments.len(),
        v.bytes as f64 / 1e6,
        started.elapsed().as_secs_f64()
    );
    let fps = Rational::from_f64(capture.fps).context("fps")?;
    let first = capture.stamps.first().unwrap_or(0);
    let source = VideoSource {
        path: &video,
        frame0_nanos: i128::from(first),
        fps,
        annotations: None,
        drawn: None,
    };
    let stop = AtomicBool::new(false);
    let options = TrimOptions {
        split: SplitConfig::default(),
        force_reencode: false,
        reencode: ReencodeSettings::default(),
        rawframes: false,
        jpeg_quality: [autoact::video::JPEG_QSCALE_BEST; 2],
        planned: None,
        qa: autoact::trim::qa::Thresholds::default(),
        clips: autoact::trim::policy::ClipPolicies::default(),
        // The cut alone is measured.
        lists: false,
    };
    let reencode_all = TrimOptions {
        force_reencode: true,
        ..options.clone()
    };
    for (name, folder, opts) in [
        ("stream copy (target >= 50x)", "copy", &options),
        (
            "re-encode (libx264 veryfast crf 18)",
            "reencode",
            &reencode_all,
        ),
    ] {
        let t = Instant::now();
        let s = trim_capture(
            &ffmpeg,
            &capture,
            &source,
            &work.join(folder),
            opts,
            &|_, _| {},
            &stop,
        )?;
        let secs = t.elapsed().as_secs_f64();
        let cut_s = s.frames_cut as f64 / capture.fps;
        println!(
            "{name}: {} clips ({} copied, {} re-encoded), {cut_s:.1} s of video in {secs:.2} s = {:.1}x real time",
            s.copied + s.reencoded,
            s.copied,
            s.reencoded,
            cut_s / secs
        );
    }
    Ok(())
}
