//! `autoact trim` and the cuts under it: frame exactness (every clip holds exactly its
//! segment's frames, checked by decoding frames whose grey levels code their index), by stream
//! copy and by re-encoding.

#![expect(clippy::unwrap_used, reason = "test helpers fail loudly")]

use std::path::Path;
use std::process::Command;

use autoact::video::{
    CutMethod, CutRequest, EncodeSettings, Ffmpeg, Rational, ReencodeSettings, VideoEncoder, cut,
    keyframe_frames,
};

const W: u32 = 160;
const H: u32 = 96;

fn ffmpeg() -> Option<Ffmpeg> {
    match Ffmpeg::locate() {
        Ok(f) => Some(f),
        Err(e) => {
            eprintln!("SKIPPED: ffmpeg is not installed ({e})");
            None
        }
    }
}

/// Frame `k` as two flat grey halves: low and high nibble of `k`, 16 grey levels apart.
fn coded_frame(k: u64) -> Vec<u8> {
    let level = |n: u64| u8::try_from((n % 16) * 16 + 8).unwrap();
    let (lo, hi) = (level(k), level(k / 16));
    let mut rgb = Vec::with_capacity((W * H * 3) as usize);
    for _y in 0..H {
        for x in 0..W {
            let v = if x < W / 2 { lo } else { hi };
            rgb.extend_from_slice(&[v, v, v]);
        }
    }
    rgb
}

/// Encodes `frames` coded frames at 30 fps with keyframes at `keyframes`.
fn coded_video(ffmpeg: &Ffmpeg, path: &Path, frames: u64, keyframes: &[u64]) {
    let settings = EncodeSettings::new(W, H, 30.0).with_keyframes(keyframes.iter().copied());
    let mut enc = VideoEncoder::start(ffmpeg, path, &settings).unwrap();
    for k in 0..frames {
        enc.write_frame(&coded_frame(k)).unwrap();
    }
    enc.finish().unwrap();
}

/// Decodes a video and reads each frame's index back from its grey levels.
fn decoded_indices(ffmpeg: &Ffmpeg, path: &Path) -> Vec<u64> {
    let out = Command::new(ffmpeg.ffmpeg_path())
        .args(["-v", "error", "-i"])
        .arg(path)
        .args(["-f", "rawvideo", "-pix_fmt", "gray", "-"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let size = (W * H) as usize;
    assert_eq!(out.stdout.len() % size, 0);
    out.stdout
        .chunks(size)
        .map(|f| {
            let at = |x: u32| u64::from(f[(H / 2 * W + x) as usize]) / 16;
            at(W / 4) + 16 * at(3 * W / 4)
        })
        .collect()
}

fn fps30() -> Rational {
    Rational::new(30, 1).unwrap()
}

#[test]
fn coded_frames_decode_back_to_their_index() {
    let Some(ffmpeg) = ffmpeg() else { return };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mp4");
    coded_video(&ffmpeg, &src, 120, &[]);
    assert_eq!(decoded_indices(&ffmpeg, &src), (0..120).collect::<Vec<_>>());
}

#[test]
fn stream_copy_at_keyframes_is_frame_exact() {
    let Some(ffmpeg) = ffmpeg() else { return };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mp4");
    let boundaries = [0, 37, 45, 90, 91, 150, 199];
    coded_video(&ffmpeg, &src, 200, &boundaries);
    let (count, keys) = keyframe_frames(&ffmpeg, &src).unwrap();
    assert_eq!(count, 200);
    for b in boundaries {
        assert!(keys.contains(&b), "{b} is not a keyframe: {keys:?}");
    }
    for w in boundaries.windows(2) {
        let out = dir.path().join(format!("copy_{}.mp4", w[0]));
        let clip = cut(
            &ffmpeg,
            &CutRequest {
                input: &src,
                output: &out,
                start_frame: w[0],
                frame_count: w[1] - w[0],
                fps: fps30(),
                method: CutMethod::StreamCopy,
            },
            &ReencodeSettings::default(),
        )
        .unwrap();
        assert_eq!(clip.frame_count, w[1] - w[0]);
        assert_eq!(
            decoded_indices(&ffmpeg, &out),
            (w[0]..w[1]).collect::<Vec<_>>(),
            "clip [{}, {})",
            w[0],
            w[1]
        );
    }
    // The last segment runs to the end of the video.
    let out = dir.path().join("tail.mp4");
    cut(
        &ffmpeg,
        &CutRequest {
            input: &src,
            output: &out,
            start_frame: 199,
            frame_count: 1,
            fps: fps30(),
            method: CutMethod::StreamCopy,
        },
        &ReencodeSettings::default(),
    )
    .unwrap();
    assert_eq!(decoded_indices(&ffmpeg, &out), vec![199]);
}

#[test]
fn stream_copy_off_a_keyframe_is_rejected_and_leaves_nothing() {
    let Some(ffmpeg) = ffmpeg() else { return };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mp4");
    coded_video(&ffmpeg, &src, 120, &[60]);
    let out = dir.path().join("clip.mp4");
    let err = cut(
        &ffmpeg,
        &CutRequest {
            input: &src,
            output: &out,
            start_frame: 30,
            frame_count: 20,
            fps: fps30(),
            method: CutMethod::StreamCopy,
        },
        &ReencodeSettings::default(),
    )
    .unwrap_err();
    assert!(
        matches!(err, autoact::video::VideoError::FrameCountMismatch { .. }),
        "{err}"
    );
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "only src.mp4 left"
    );
}

#[test]
fn reencode_anywhere_is_frame_exact() {
    let Some(ffmpeg) = ffmpeg() else { return };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mp4");
    // Keyframes only every 250 frames: nothing below lands on one except frame 0.
    coded_video(&ffmpeg, &src, 240, &[]);
    for (start, count) in [(0, 10), (1, 1), (17, 33), (100, 77), (239, 1)] {
        let out = dir.path().join(format!("re_{start}.mp4"));
        cut(
            &ffmpeg,
            &CutRequest {
                input: &src,
                output: &out,
                start_frame: start,
                frame_count: count,
                fps: fps30(),
                method: CutMethod::Reencode,
            },
            &ReencodeSettings::default(),
        )
        .unwrap();
        assert_eq!(
            decoded_indices(&ffmpeg, &out),
            (start..start + count).collect::<Vec<_>>(),
            "clip at {start}"
        );
    }
}

#[test]
fn a_cut_past_the_end_is_an_error_naming_the_clip() {
    let Some(ffmpeg) = ffmpeg() else { return };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mp4");
    coded_video(&ffmpeg, &src, 60, &[]);
    let out = dir.path().join("late.mp4");
    let err = cut(
        &ffmpeg,
        &CutRequest {
            input: &src,
            output: &out,
            start_frame: 50,
            frame_count: 30,
            fps: fps30(),
            method: CutMethod::Reencode,
        },
        &ReencodeSettings::default(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("late.mp4"), "{err}");
    assert!(!out.exists());
}

#[test]
fn a_corrupt_video_is_an_error_with_ffmpegs_words() {
    let Some(ffmpeg) = ffmpeg() else { return };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("broken.mp4");
    std::fs::write(&src, b"not a video at all").unwrap();
    let out = dir.path().join("clip.mp4");
    let err = cut(
        &ffmpeg,
        &CutRequest {
            input: &src,
            output: &out,
            start_frame: 0,
            frame_count: 3,
            fps: fps30(),
            method: CutMethod::StreamCopy,
        },
        &ReencodeSettings::default(),
    )
    .unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("clip.mp4") && text.contains("broken.mp4"),
        "{text}"
    );
    assert!(!out.exists());
}
