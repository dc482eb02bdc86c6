//! `autoact::video` against the real ffmpeg/ffprobe: exact frame counts and timestamps, frames
//! decoded back in order, keyframes exactly where asked, Annex B access units, and every way an
//! encode can fail (ffmpeg failing or killed mid-stream, dropped encoders, a full disk, missing
//! ffmpeg) leaving no file that looks complete.
//!
//! Without ffmpeg on the machine the ffmpeg tests print `SKIPPED` and pass; CI installs ffmpeg.

#![expect(clippy::unwrap_used, reason = "tests fail loudly")]
#![expect(
    clippy::print_stderr,
    reason = "skips and measurements are reported on stderr"
)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use autoact::video::{
    self, EncodeSettings, Ffmpeg, Rational, VideoEncoder, VideoError, annexb_access_units, probe,
};

use crate::common::ffmpeg_or_skip;

/// Bits of the frame index painted as a 4×4 grid of black/white blocks (bit 0 top-left), over a
/// colour that changes with the index so consecutive frames differ everywhere.
fn index_frame(width: u32, height: u32, index: u64) -> Vec<u8> {
    let mut frame = Vec::with_capacity((width * height * 3) as usize);
    for y in 0..height {
        for x in 0..width {
            let bit = (y * 4 / height) * 4 + x * 4 / width;
            let on = index >> bit & 1 == 1;
            // Leave a margin inside each block in a tint, to give the encoder some texture.
            let bx = x * 4 % width;
            let by = y * 4 % height;
            let edge = bx < width / 10 || by < height / 10;
            let px = if edge {
                [
                    ((index * 5) % 200) as u8 + 20,
                    (x % 64) as u8 + 60,
                    (y % 64) as u8 + 60,
                ]
            } else if on {
                [250, 250, 250]
            } else {
                [5, 5, 5]
            };
            frame.extend_from_slice(&px);
        }
    }
    frame
}

/// Reads the index back from a decoded frame (block centres, threshold at mid-grey).
fn read_index(width: u32, height: u32, frame: &[u8]) -> u64 {
    let mut index = 0;
    for bit in 0..16_u32 {
        let cx = (bit % 4) * width / 4 + width / 8 + width / 40;
        let cy = (bit / 4) * height / 4 + height / 8 + height / 40;
        let at = ((cy * width + cx) * 3) as usize;
        let luma = (u32::from(frame[at]) + u32::from(frame[at + 1]) + u32::from(frame[at + 2])) / 3;
        if luma > 128 {
            index |= 1 << bit;
        }
    }
    index
}

/// The raw frames ffmpeg writes from `path`, read with `input_format`, in `pix_fmt` (`output`:
/// more output options).
fn raw_frames(
    ffmpeg: &Ffmpeg,
    path: &Path,
    input_format: &[&str],
    output: &[&str],
    pix_fmt: &str,
) -> Vec<u8> {
    let out = Command::new(ffmpeg.ffmpeg_path())
        .args(["-v", "error", "-nostdin"])
        .args(input_format)
        .arg("-i")
        .arg(path)
        .args(output)
        .args(["-f", "rawvideo", "-pix_fmt", pix_fmt, "-"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

/// Decodes `path` with ffmpeg to rgb24 frames.
fn decode(
    ffmpeg: &Ffmpeg,
    path: &Path,
    width: u32,
    height: u32,
    input_format: &[&str],
) -> Vec<Vec<u8>> {
    let bytes = raw_frames(ffmpeg, path, input_format, &[], "rgb24");
    let size = (width * height * 3) as usize;
    assert_eq!(bytes.len() % size, 0);
    bytes.chunks_exact(size).map(<[u8]>::to_vec).collect()
}

fn encode_indexed(
    ffmpeg: &Ffmpeg,
    output: &Path,
    settings: &EncodeSettings,
    frames: u64,
) -> video::EncodedVideo {
    let mut encoder = VideoEncoder::start(ffmpeg, output, settings).unwrap();
    for k in 0..frames {
        encoder
            .write_frame(&index_frame(settings.width, settings.height, k))
            .unwrap();
    }
    encoder.finish().unwrap()
}

fn dir_entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Frame k is at exactly k/fps: pts × time_base = k × den / num, in integers.
fn assert_exact_pts(p: &video::VideoProbe, fps: Rational) {
    for (k, frame) in (0_i64..).zip(&p.frames) {
        assert_eq!(
            i128::from(frame.pts) * i128::from(p.time_base.num) * i128::from(fps.num),
            i128::from(k) * i128::from(p.time_base.den) * i128::from(fps.den),
            "frame {k}: pts {} in {}",
            frame.pts,
            p.time_base
        );
        #[expect(clippy::cast_precision_loss, reason = "small values")]
        let expected_s = k as f64 / fps.as_f64();
        assert!((frame.pts_s - expected_s).abs() < 1e-9, "frame {k}");
    }
}

#[test]
fn encodes_exact_frame_count_and_timestamps_and_decodes_back_in_order() {
    let Some(ffmpeg) = ffmpeg_or_skip("encodes_exact_frame_count…") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("capture.mp4");
    let settings = EncodeSettings::new(320, 240, 30.0);
    let encoded = encode_indexed(&ffmpeg, &output, &settings, 200);
    assert_eq!(encoded.frame_count, 200);
    assert_eq!(encoded.path, output);
    assert_eq!(encoded.fps, Rational::new(30, 1).unwrap());
    assert_eq!(encoded.bytes, std::fs::metadata(&output).unwrap().len());
    assert_eq!(dir_entries(dir.path()), ["capture.mp4"]);

    let p = probe(&ffmpeg, &output).unwrap();
    assert_eq!((p.width, p.height), (320, 240));
    assert_eq!(p.codec, "h264");
    assert_eq!(p.pix_fmt, "yuv420p");
    assert_eq!(p.fps, Rational::new(30, 1).unwrap());
    assert!(!p.has_b_frames);
    assert_eq!(p.frames.len(), 200);
    assert_exact_pts(&p, p.fps);
    assert_eq!(p.keyframe_indices(), encoded.keyframes);

    let decoded = decode(&ffmpeg, &output, 320, 240, &[]);
    let indices: Vec<u64> = decoded.iter().map(|f| read_index(320, 240, f)).collect();
    assert_eq!(indices, (0..200).collect::<Vec<_>>());
}

/// The encoder converts frames to `yuv420p` itself (`video::yuv`): encoded losslessly (CRF 0)
/// and decoded, a smooth picture's planes are ffmpeg's own conversion of it within a code value
/// of luma and two of chroma (its chroma filter is not a 2×2 mean), so the videos' colours are
/// what they were when ffmpeg converted.
#[test]
fn the_encoders_colours_are_ffmpegs_conversion() {
    let Some(ffmpeg) = ffmpeg_or_skip("the_encoders_colours_are_ffmpegs_conversion") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (96_u32, 64_u32);
    let mut rgb = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let (x, y) = (f64::from(x), f64::from(y));
            rgb.extend(
                [
                    128.0 + 120.0 * (x / 23.0).sin(),
                    128.0 + 120.0 * (y / 17.0).cos(),
                    128.0 + 100.0 * ((x + y) / 31.0).sin(),
                ]
                .map(|c| c.round() as u8),
            );
        }
    }
    let raw = dir.path().join("frame.rgb");
    std::fs::write(&raw, &rgb).unwrap();
    let size = format!("{w}x{h}");
    let first = ["-frames:v", "1"];
    let reference = raw_frames(
        &ffmpeg,
        &raw,
        &["-f", "rawvideo", "-pix_fmt", "rgb24", "-video_size", &size],
        &first,
        "yuv420p",
    );

    let output = dir.path().join("lossless.mp4");
    let mut settings = EncodeSettings::new(w, h, 30.0);
    settings.crf = 0;
    let mut encoder = VideoEncoder::start(&ffmpeg, &output, &settings).unwrap();
    encoder.write_frame(&rgb).unwrap();
    encoder.finish().unwrap();
    let ours = raw_frames(&ffmpeg, &output, &[], &first, "yuv420p");

    let luma = (w * h) as usize;
    assert_eq!(ours.len(), luma * 3 / 2);
    assert_eq!(reference.len(), ours.len());
    let worst = |range: std::ops::Range<usize>| {
        range.map(|i| ours[i].abs_diff(reference[i])).max().unwrap()
    };
    assert!(worst(0..luma) <= 1, "luma differs by {}", worst(0..luma));
    let chroma = worst(luma..ours.len());
    assert!(chroma <= 2, "chroma differs by {chroma}");
}

#[test]
fn ntsc_and_decimal_rates_keep_1000_frames_at_exact_times() {
    let Some(ffmpeg) = ffmpeg_or_skip("ntsc_and_decimal_rates…") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    for (fps, rational) in [
        (29.97, Rational::new(2997, 100).unwrap()),
        (30000.0 / 1001.0, Rational::new(30000, 1001).unwrap()),
        (30.0, Rational::new(30, 1).unwrap()),
    ] {
        let output = dir.path().join(format!("r{}.mp4", rational.num));
        let mut settings = EncodeSettings::new(64, 48, fps);
        settings.preset = "ultrafast".into();
        // Keyframes on awkward frames too: times at these rates are not round decimals.
        settings.keyframes = vec![1, 333, 334, 999];
        let encoded = encode_indexed(&ffmpeg, &output, &settings, 1000);
        assert_eq!(encoded.fps, rational);
        let p = probe(&ffmpeg, &output).unwrap();
        assert_eq!(p.frames.len(), 1000, "{rational}");
        assert_eq!(p.fps, rational);
        assert_exact_pts(&p, rational);
        let keys = p.keyframe_indices();
        for k in [0, 1, 333, 334, 999] {
            assert!(
                keys.contains(&k),
                "{rational}: frame {k} not a keyframe in {keys:?}"
            );
        }
        // The container's own count agrees.
        let count = Command::new(ffmpeg.ffprobe_path())
            .args([
                "-v",
                "error",
                "-select_streams",
                "v:0",
                "-show_entries",
                "stream=nb_frames",
                "-of",
                "csv=p=0",
            ])
            .arg(&output)
            .output()
            .unwrap();
        assert_eq!(String::from_utf8_lossy(&count.stdout).trim(), "1000");
    }
}

#[test]
fn keyframes_sit_exactly_on_requested_frames() {
    let Some(ffmpeg) = ffmpeg_or_skip("keyframes_sit_exactly…") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let requested = [0_u64, 37, 38, 90, 151, 199];

    // A GOP longer than the video: the keyframes are exactly the requested ones.
    let output = dir.path().join("exact.mp4");
    let mut settings = EncodeSettings::new(320, 240, 30.0).with_keyframes(requested);
    settings.gop_frames = 1000;
    let encoded = encode_indexed(&ffmpeg, &output, &settings, 200);
    let p = probe(&ffmpeg, &output).unwrap();
    assert_eq!(p.keyframe_indices(), requested);
    assert_eq!(encoded.keyframes, requested);
    assert!(!p.has_b_frames);
    assert!(p.frames.iter().all(|f| f.pict_type != 'B'));
    for k in requested {
        // Forced keyframes are IDR frames.
        assert_eq!(p.frames[k as usize].pict_type, 'I');
    }

    // The default 2 s GOP adds keyframes, but never lets 60 frames pass without one.
    let output = dir.path().join("gop.mp4");
    let settings = EncodeSettings::new(320, 240, 30.0).with_keyframes(requested);
    encode_indexed(&ffmpeg, &output, &settings, 200);
    let keys = probe(&ffmpeg, &output).unwrap().keyframe_indices();
    for k in requested {
        assert!(keys.contains(&k), "{k} missing from {keys:?}");
    }
    assert!(keys.windows(2).all(|w| w[1] - w[0] <= 60), "{keys:?}");
}

#[test]
fn hundreds_of_boundaries_at_ntsc_rate_are_all_keyframes() {
    let Some(ffmpeg) = ffmpeg_or_skip("hundreds_of_boundaries…") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("many.mp4");
    // 400 boundaries, irregular gaps of 1..=7 frames.
    let mut requested = vec![0_u64];
    let mut k = 0;
    while requested.len() < 400 {
        k += 1 + (k * 7 + 3) % 7;
        requested.push(k);
    }
    let frames = k + 5;
    let mut settings =
        EncodeSettings::new(64, 48, 30000.0 / 1001.0).with_keyframes(requested.clone());
    settings.preset = "ultrafast".into();
    settings.gop_frames = 100_000;
    let encoded = encode_indexed(&ffmpeg, &output, &settings, frames);
    assert_eq!(encoded.keyframes, requested);
    assert_eq!(
        probe(&ffmpeg, &output).unwrap().keyframe_indices(),
        requested
    );
}

#[test]
fn annexb_access_units_are_one_per_frame_with_parameter_sets_on_keyframes() {
    let Some(ffmpeg) = ffmpeg_or_skip("annexb_access_units…") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("clip.mp4");
    let settings = EncodeSettings::new(320, 240, 30.0).with_keyframes([45, 46, 100]);
    encode_indexed(&ffmpeg, &output, &settings, 120);
    let p = probe(&ffmpeg, &output).unwrap();

    let units = annexb_access_units(&ffmpeg, &output).unwrap();
    assert_eq!(units.len(), 120);
    let unit_keys: Vec<u64> = (0_u64..)
        .zip(&units)
        .filter(|(_, u)| u.key)
        .map(|(i, _)| i)
        .collect();
    assert_eq!(unit_keys, p.keyframe_indices());
    for (i, unit) in units.iter().enumerate() {
        let types = unit.nal_types();
        assert_eq!(types.first(), Some(&9), "unit {i} starts with a delimiter");
        assert_eq!(
            types.iter().filter(|&&t| t == 9).count(),
            1,
            "unit {i}: {types:?}"
        );
        let slices = types.iter().filter(|&&t| t == 1 || t == 5).count();
        assert!(slices >= 1, "unit {i}: {types:?}");
        if unit.key {
            let first_idr = types.iter().position(|&t| t == 5).unwrap();
            assert!(
                types[..first_idr].contains(&7),
                "unit {i}: no SPS before IDR: {types:?}"
            );
            assert!(
                types[..first_idr].contains(&8),
                "unit {i}: no PPS before IDR: {types:?}"
            );
        } else {
            assert!(!types.contains(&5), "unit {i}: {types:?}");
        }
    }

    // The units, concatenated, are a stream ffmpeg decodes to the same frames.
    let stream: Vec<u8> = units.iter().flat_map(|u| u.data.iter().copied()).collect();
    let raw = dir.path().join("clip.h264");
    std::fs::write(&raw, &stream).unwrap();
    let decoded = decode(&ffmpeg, &raw, 320, 240, &["-f", "h264"]);
    assert_eq!(decoded.len(), 120);
    let indices: Vec<u64> = decoded.iter().map(|f| read_index(320, 240, f)).collect();
    assert_eq!(indices, (0..120).collect::<Vec<_>>());

    // Decoding can start at any keyframe unit on its own.
    let from_45: Vec<u8> = units[45..]
        .iter()
        .flat_map(|u| u.data.iter().copied())
        .collect();
    std::fs::write(&raw, &from_45).unwrap();
    let decoded = decode(&ffmpeg, &raw, 320, 240, &["-f", "h264"]);
    assert_eq!(decoded.len(), 75);
    assert_eq!(read_index(320, 240, &decoded[0]), 45);
}

#[cfg(unix)]
fn script(dir: &Path, name: &str, body: &str) -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let path = dir.join(name);
    std::fs::write(&path, format!("#!/bin/sh\n{body}\n")).unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
    path
}

/// Writes frames until the encoder reports an error (at most `limit`), then finishes; returns
/// the first error.
fn write_until_error(encoder: VideoEncoder, width: u32, height: u32, limit: u64) -> VideoError {
    let mut encoder = encoder;
    for k in 0..limit {
        if let Err(e) = encoder.write_frame(&index_frame(width, height, k)) {
            // Later calls keep failing, without panicking.
            assert!(matches!(
                encoder.write_frame(&index_frame(width, height, k)),
                Err(VideoError::Stopped { .. })
            ));
            return e;
        }
    }
    encoder.finish().unwrap_err()
}

#[cfg(unix)]
#[test]
fn ffmpeg_failing_mid_stream_reports_its_stderr_tail_and_leaves_no_file() {
    let Some(real) = ffmpeg_or_skip("ffmpeg_failing_mid_stream…") else {
        return;
    };
    let tools = tempfile::tempdir().unwrap();
    // Reads ~2 frames, complains on 25 lines, exits 3.
    let fake = script(
        tools.path(),
        "ffmpeg",
        "head -c 400000 >/dev/null\nfor i in $(seq 0 24); do echo \"fake ffmpeg line $i\" >&2; done\nexit 3",
    );
    let ffmpeg = Ffmpeg::from_paths(fake, real.ffprobe_path());
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("out.mp4");
    let encoder =
        VideoEncoder::start(&ffmpeg, &output, &EncodeSettings::new(320, 240, 30.0)).unwrap();
    let err = write_until_error(encoder, 320, 240, 1000);
    let VideoError::Exited {
        status,
        stderr_tail,
        path,
        ..
    } = &err
    else {
        panic!("expected Exited, got {err:?}");
    };
    assert_eq!(status.code(), Some(3));
    assert_eq!(path, &output);
    assert!(stderr_tail.contains("fake ffmpeg line 24"), "{stderr_tail}");
    assert!(stderr_tail.contains("fake ffmpeg line 5"), "{stderr_tail}");
    assert!(
        !stderr_tail.contains("fake ffmpeg line 4\n"),
        "only the last 20 lines: {stderr_tail}"
    );
    assert!(err.to_string().contains("fake ffmpeg line 24"));
    assert_eq!(dir_entries(dir.path()), Vec::<String>::new());
}

#[cfg(unix)]
#[test]
fn ffmpeg_killed_mid_stream_is_an_error_and_leaves_no_file() {
    let Some(real) = ffmpeg_or_skip("ffmpeg_killed_mid_stream…") else {
        return;
    };
    let tools = tempfile::tempdir().unwrap();
    let pid_file = tools.path().join("pid");
    let wrapper = script(
        tools.path(),
        "ffmpeg",
        &format!(
            "echo $$ > '{}'\nexec '{}' \"$@\"",
            pid_file.display(),
            real.ffmpeg_path().display()
        ),
    );
    let ffmpeg = Ffmpeg::from_paths(wrapper, real.ffprobe_path());
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("out.mp4");
    let mut encoder =
        VideoEncoder::start(&ffmpeg, &output, &EncodeSettings::new(320, 240, 30.0)).unwrap();
    for k in 0..30 {
        encoder.write_frame(&index_frame(320, 240, k)).unwrap();
    }
    let pid = std::fs::read_to_string(&pid_file).unwrap();
    let killed = Command::new("kill")
        .args(["-9", pid.trim()])
        .status()
        .unwrap();
    assert!(killed.success());
    let err = write_until_error(encoder, 320, 240, 1000);
    let VideoError::Exited { status, .. } = &err else {
        panic!("expected Exited, got {err:?}");
    };
    assert!(!status.success());
    assert_eq!(dir_entries(dir.path()), Vec::<String>::new());
}

#[cfg(unix)]
#[test]
fn ffmpeg_exiting_0_with_a_wrong_file_is_caught_and_leaves_no_file() {
    let Some(real) = ffmpeg_or_skip("ffmpeg_exiting_0_with_a_wrong_file…") else {
        return;
    };
    // An MP4 is checked from its sample tables in-process, a Matroska file by ffprobe.
    for extension in ["mp4", "mkv"] {
        let tools = tempfile::tempdir().unwrap();
        // A genuine 5-frame video whose only keyframe is frame 0.
        let five = tools.path().join(format!("five.{extension}"));
        let mut settings = EncodeSettings::new(64, 48, 30.0);
        settings.gop_frames = 1000;
        encode_indexed(&real, &five, &settings, 5);
        // An "ffmpeg" that swallows its input, copies that file to its output and exits 0.
        let fake = script(
            tools.path(),
            "ffmpeg",
            &format!(
                "for a; do last=$a; done\ncat >/dev/null\ncp '{}' \"$last\"",
                five.display()
            ),
        );
        let ffmpeg = Ffmpeg::from_paths(fake, real.ffprobe_path());
        let dir = tempfile::tempdir().unwrap();
        let output = dir.path().join(format!("out.{extension}"));

        let mut encoder = VideoEncoder::start(&ffmpeg, &output, &settings).unwrap();
        for k in 0..7 {
            encoder.write_frame(&index_frame(64, 48, k)).unwrap();
        }
        let err = encoder.finish().unwrap_err();
        assert!(
            matches!(
                err,
                VideoError::FrameCountMismatch {
                    written: 7,
                    found: 5,
                    ..
                }
            ),
            "{extension}: {err:?}"
        );
        assert_eq!(dir_entries(dir.path()), Vec::<String>::new());

        let with_key = settings.clone().with_keyframes([3]);
        let mut encoder = VideoEncoder::start(&ffmpeg, &output, &with_key).unwrap();
        for k in 0..5 {
            encoder.write_frame(&index_frame(64, 48, k)).unwrap();
        }
        let err = encoder.finish().unwrap_err();
        assert!(
            matches!(err, VideoError::KeyframeMissing { frame: 3, .. }),
            "{extension}: {err:?}"
        );
        assert_eq!(dir_entries(dir.path()), Vec::<String>::new());
    }
}

#[cfg(unix)]
#[test]
fn interrupted_process_leaves_no_file_under_the_final_name() {
    if let Some(dir) = std::env::var_os("AUTOACT_VIDEO_INTERRUPT_DIR") {
        // Child: encode until killed.
        let dir = PathBuf::from(dir);
        let ffmpeg = Ffmpeg::locate().unwrap();
        let settings = EncodeSettings::new(320, 240, 30.0);
        let mut encoder =
            VideoEncoder::start(&ffmpeg, &dir.join("capture.mp4"), &settings).unwrap();
        for k in 0..1_000_000 {
            encoder
                .write_frame(&index_frame(320, 240, k % 60_000))
                .unwrap();
            if k == 30 {
                std::fs::write(dir.join("ready"), b"").unwrap();
            }
        }
        return;
    }
    if ffmpeg_or_skip("interrupted_process…").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let exe = std::env::current_exe().unwrap();
    let mut child = Command::new(exe)
        .args([
            &harness_name("interrupted_process_leaves_no_file_under_the_final_name"),
            "--exact",
            "--test-threads=1",
        ])
        .env("AUTOACT_VIDEO_INTERRUPT_DIR", dir.path())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while !dir.path().join("ready").exists() {
        assert!(t0.elapsed().as_secs() < 60, "the child never got going");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    // SIGKILL, not SIGINT: a process started in the background of a shell without job control
    // (`nohup …&`, some CI runners) inherits SIGINT ignored, and the child then encoded on for
    // minutes. SIGKILL runs no cleanup either, as Ctrl-C's default action does not.
    child.kill().unwrap();
    let status = child.wait().unwrap();
    assert!(!status.success(), "the child should have died from SIGKILL");
    // ffmpeg, in its own process group, sees the end of its input and closes its file; give it
    // a moment, then check that only the hidden `.part` name was ever used.
    std::thread::sleep(std::time::Duration::from_millis(500));
    let names = dir_entries(dir.path());
    assert!(!names.iter().any(|n| n == "capture.mp4"), "{names:?}");
    assert!(
        names
            .iter()
            .all(|n| n == "ready" || n == ".capture.mp4.part"),
        "{names:?}"
    );
}

#[test]
fn dropped_or_aborted_encoders_leave_no_file_and_keep_an_old_output() {
    let Some(ffmpeg) = ffmpeg_or_skip("dropped_or_aborted…") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("out.mp4");
    let settings = EncodeSettings::new(320, 240, 30.0);

    let mut encoder = VideoEncoder::start(&ffmpeg, &output, &settings).unwrap();
    for k in 0..20 {
        encoder.write_frame(&index_frame(320, 240, k)).unwrap();
    }
    drop(encoder);
    assert_eq!(dir_entries(dir.path()), Vec::<String>::new());

    std::fs::write(&output, b"old").unwrap();
    let mut encoder = VideoEncoder::start(&ffmpeg, &output, &settings).unwrap();
    for k in 0..20 {
        encoder.write_frame(&index_frame(320, 240, k)).unwrap();
    }
    encoder.abort();
    assert_eq!(dir_entries(dir.path()), ["out.mp4"]);
    assert_eq!(std::fs::read(&output).unwrap(), b"old");

    // Finishing replaces it.
    encode_indexed(&ffmpeg, &output, &settings, 5);
    assert_eq!(probe(&ffmpeg, &output).unwrap().frames.len(), 5);
}

#[test]
fn bad_input_is_reported_and_stops_the_encoder() {
    let Some(ffmpeg) = ffmpeg_or_skip("bad_input…") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("out.mp4");
    let settings = EncodeSettings::new(320, 240, 30.0);

    let mut encoder = VideoEncoder::start(&ffmpeg, &output, &settings).unwrap();
    encoder.write_frame(&index_frame(320, 240, 0)).unwrap();
    let err = encoder.write_frame(&[0; 100]).unwrap_err();
    assert!(
        matches!(
            err,
            VideoError::FrameSize {
                frame: 1,
                got: 100,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("out.mp4"), "{err}");
    assert!(matches!(encoder.finish(), Err(VideoError::Stopped { .. })));
    assert_eq!(dir_entries(dir.path()), Vec::<String>::new());

    // No frames at all.
    let encoder = VideoEncoder::start(&ffmpeg, &output, &settings).unwrap();
    assert!(encoder.finish().is_err());
    assert_eq!(dir_entries(dir.path()), Vec::<String>::new());

    // A missing directory, odd sizes, unknown containers and presets are refused up front.
    let err =
        VideoEncoder::start(&ffmpeg, &dir.path().join("no/such/out.mp4"), &settings).unwrap_err();
    assert!(err.to_string().contains("no/such"), "{err}");
    let odd = EncodeSettings::new(321, 240, 30.0);
    assert!(matches!(
        VideoEncoder::start(&ffmpeg, &output, &odd),
        Err(VideoError::InvalidSettings { .. })
    ));
    let err = VideoEncoder::start(&ffmpeg, &dir.path().join("out.avi"), &settings).unwrap_err();
    assert!(err.to_string().contains(".mp4"), "{err}");
    let slow = EncodeSettings {
        preset: "ludicrous".into(),
        ..settings.clone()
    };
    let err = VideoEncoder::start(&ffmpeg, &output, &slow).unwrap_err();
    assert!(err.to_string().contains("superfast"), "{err}");
    for options in [
        "cabac=1 :deblock=0,0",
        "cabac=1::deblock=0,0",
        ":cabac=1",
        "cabac=1\n",
    ] {
        let bad = EncodeSettings {
            x264_options: options.into(),
            ..settings.clone()
        };
        let err = VideoEncoder::start(&ffmpeg, &output, &bad).unwrap_err();
        assert!(
            matches!(err, VideoError::InvalidSettings { .. })
                && err.to_string().contains(options)
                && err.to_string().contains("key=value"),
            "{options:?}: {err}"
        );
    }
    assert_eq!(dir_entries(dir.path()), Vec::<String>::new());
}

/// The x264 options follow the preset into the stream: x264 writes the settings it encoded
/// with into the stream (a user-data SEI), so the file says whether CABAC and the deblocking
/// filter were on. An option x264 does not know fails the encode and names the option, and
/// leaves no file.
#[test]
fn the_x264_options_follow_the_preset_into_the_stream() {
    let Some(ffmpeg) = ffmpeg_or_skip("the_x264_options_follow_the_preset…") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let settings_text = |options: &str| {
        let output = dir.path().join(format!("p{}.mp4", options.len()));
        let mut settings = EncodeSettings::new(64, 48, 30.0);
        settings.x264_options = options.into();
        encode_indexed(&ffmpeg, &output, &settings, 10);
        let bytes = std::fs::read(&output).unwrap();
        let at = bytes
            .windows(11)
            .position(|w| w == b"x264 - core")
            .expect("x264's settings SEI");
        let end = bytes[at..]
            .iter()
            .position(|&b| b == 0)
            .map_or(bytes.len(), |n| at + n);
        // Space-separated `name=value` items, as a set of words.
        String::from_utf8_lossy(&bytes[at..end])
            .split(' ')
            .map(str::to_owned)
            .collect::<Vec<_>>()
    };
    // The default: `ultrafast`'s motion search and partitions, with CABAC and deblocking.
    let default = settings_text(autoact::video::DEFAULT_X264_OPTIONS);
    for on in ["cabac=1", "deblock=1:0:0", "subme=0", "aq=0"] {
        assert!(default.iter().any(|w| w == on), "{on:?} not in {default:?}");
    }
    // `ultrafast` alone turns both off.
    let alone = settings_text("");
    for off in ["cabac=0", "deblock=0:0:0", "subme=0"] {
        assert!(alone.iter().any(|w| w == off), "{off:?} not in {alone:?}");
    }

    let output = dir.path().join("unknown.mp4");
    let mut settings = EncodeSettings::new(64, 48, 30.0);
    settings.x264_options = "cabac=1:no-such-option=3".into();
    let err = match VideoEncoder::start(&ffmpeg, &output, &settings) {
        Err(err) => err,
        Ok(mut encoder) => {
            let frame = vec![0u8; settings.frame_bytes()];
            let written = (0..10).try_for_each(|_| encoder.write_frame(&frame));
            written
                .and_then(|()| encoder.finish().map(|_| ()))
                .unwrap_err()
        }
    };
    assert!(err.to_string().contains("no-such-option"), "{err}");
    assert_eq!(
        dir_entries(dir.path())
            .iter()
            .filter(|n| n.starts_with("unknown") || n.starts_with(".unknown"))
            .count(),
        0
    );
}

#[test]
fn version_and_mkv_output_work() {
    let Some(ffmpeg) = ffmpeg_or_skip("version_and_mkv…") else {
        return;
    };
    let version = ffmpeg.version().unwrap();
    assert!(
        version.chars().next().unwrap().is_ascii_digit(),
        "{version}"
    );
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("out.mkv");
    let settings = EncodeSettings::new(64, 48, 25.0).with_keyframes([10]);
    let encoded = encode_indexed(&ffmpeg, &output, &settings, 30);
    assert_eq!(encoded.frame_count, 30);
    assert!(encoded.keyframes.contains(&10));
}

/// The name the test harness gives this module's test `test` (`video::test`: the module path
/// without the crate), for running just that test in a child with `--exact`.
fn harness_name(test: &str) -> String {
    let module = module_path!()
        .split_once("::")
        .map_or(module_path!(), |(_, module)| module);
    format!("{module}::{test}")
}

/// Runs this test binary again, as `test`, with `env` set; returns whether it passed.
fn rerun_self(test: &str, env: &[(&str, &str)], wrapper: Option<&[&str]>) -> std::process::Output {
    let exe = std::env::current_exe().unwrap();
    let mut command = match wrapper {
        Some(args) => {
            let mut c = Command::new(args[0]);
            c.args(&args[1..]).arg(&exe);
            c
        }
        None => Command::new(&exe),
    };
    command.args([
        &harness_name(test),
        "--exact",
        "--nocapture",
        "--test-threads=1",
    ]);
    for (k, v) in env {
        command.env(k, v);
    }
    command.output().unwrap()
}

#[test]
fn missing_ffmpeg_gives_the_install_hint() {
    if std::env::var_os("AUTOACT_VIDEO_TEST_CHILD").is_some() {
        let err = Ffmpeg::locate().unwrap_err();
        assert!(matches!(err, VideoError::NotFound { .. }), "{err:?}");
        let text = err.to_string();
        assert!(text.contains("sudo apt-get install ffmpeg"), "{text}");
        assert!(text.contains("/nonexistent"), "{text}");
        return;
    }
    let run = rerun_self(
        "missing_ffmpeg_gives_the_install_hint",
        &[
            ("AUTOACT_VIDEO_TEST_CHILD", "1"),
            ("AUTOACT_FFMPEG", "/nonexistent"),
        ],
        None,
    );
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{stdout}");
    // The child ran this very test (a filter naming no test would pass too).
    assert!(stdout.contains("1 passed"), "{stdout}");
}

/// Noise: incompressible, so a few frames fill a small disk.
fn noise_frame(width: u32, height: u32, seed: u64) -> Vec<u8> {
    let mut state = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    (0..width * height * 3)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 24) as u8
        })
        .collect()
}

#[cfg(target_os = "linux")]
#[test]
fn full_disk_is_an_error_and_leaves_no_file() {
    if let Some(dir) = std::env::var_os("AUTOACT_VIDEO_DISK_FULL_DIR") {
        // Child: `dir` is a fresh 1 MiB tmpfs.
        let dir = PathBuf::from(dir);
        let ffmpeg = Ffmpeg::locate().unwrap();
        let output = dir.join("full.mp4");
        let mut settings = EncodeSettings::new(320, 240, 30.0);
        settings.crf = 0;
        settings.preset = "ultrafast".into();
        let mut encoder = VideoEncoder::start(&ffmpeg, &output, &settings).unwrap();
        let mut failed = None;
        for k in 0..300 {
            if let Err(e) = encoder.write_frame(&noise_frame(320, 240, k)) {
                failed = Some(e);
                break;
            }
        }
        let err = match failed {
            Some(e) => e,
            None => encoder.finish().unwrap_err(),
        };
        eprintln!("disk full reported as: {err}");
        assert!(err.to_string().contains("No space left on device"), "{err}");
        assert_eq!(dir_entries(&dir), Vec::<String>::new());
        return;
    }
    if ffmpeg_or_skip("full_disk_is_an_error…").is_none() {
        return;
    }
    let mount = tempfile::tempdir().unwrap();
    let mount_arg = mount.path().to_str().unwrap().to_owned();
    // A private mount namespace with a 1 MiB tmpfs over `mount`; exit 77 if that is not allowed.
    let shell =
        format!("mount -t tmpfs -o size=1m autoact-test '{mount_arg}' || exit 77; exec \"$@\"");
    let run = rerun_self(
        "full_disk_is_an_error_and_leaves_no_file",
        &[("AUTOACT_VIDEO_DISK_FULL_DIR", &mount_arg)],
        Some(&[
            "unshare",
            "-m",
            "--propagation",
            "private",
            "sh",
            "-c",
            &shell,
            "sh",
        ]),
    );
    let stderr = String::from_utf8_lossy(&run.stderr);
    if run.status.code() == Some(77)
        || stderr.contains("unshare failed")
        || stderr.contains("Operation not permitted")
    {
        eprintln!(
            "SKIPPED full_disk_is_an_error_and_leaves_no_file: cannot mount a tmpfs in a private \
             mount namespace here (needs root or user namespaces): {stderr}"
        );
        return;
    }
    assert!(
        run.status.success(),
        "child failed:\n{}\n{stderr}",
        String::from_utf8_lossy(&run.stdout)
    );
    assert!(stderr.contains("disk full reported as"), "{stderr}");
}

/// A synthetic "render": sky gradient, a scrolling checkered ground (the camera moves), and a
/// shaded figure walking across.
fn synthetic_render(width: u32, height: u32, k: u32) -> Vec<u8> {
    let mut frame = Vec::with_capacity((width * height * 3) as usize);
    let horizon = height * 2 / 5;
    let (cx, cy) = ((k * 3) % width, height / 2);
    let r = height / 6;
    for y in 0..height {
        for x in 0..width {
            let dx = x.abs_diff(cx);
            let dy = y.abs_diff(cy);
            let px = if dx * dx + dy * dy < r * r || (dx < r / 3 && y > cy && y < cy + 2 * r) {
                let shade = 255 - (dx * 120 / r.max(1)).min(200);
                [shade as u8, (shade / 2) as u8, 40]
            } else if y < horizon {
                [
                    90 + (y * 100 / horizon) as u8,
                    140 + (y * 60 / horizon) as u8,
                    230,
                ]
            } else {
                let depth = y - horizon + 1;
                let u = (x + k * 2) * 16 / depth;
                let v = 4000 / depth + k;
                if (u / 8 + v / 8).is_multiple_of(2) {
                    [110, 120, 100]
                } else {
                    [70, 80, 60]
                }
            };
            frame.extend_from_slice(&px);
        }
    }
    frame
}

/// ffmpeg's CPU time so far (children's user + system time, in seconds), from `/proc/self/stat`.
fn children_cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .map_or("", |(_, r)| r)
        .split_whitespace()
        .collect();
    // After the command name: field 3 is index 0, so cutime (16) and cstime (17) are 13 and 14.
    let ticks: f64 = [13, 14]
        .iter()
        .filter_map(|&i| fields.get(i)?.parse::<f64>().ok())
        .sum();
    ticks / 100.0
}

/// Encode speed per preset and size. Run with
/// `cargo test --test it video::encode_speed_report -- --ignored --nocapture`.
#[test]
#[ignore = "a measurement, not a check; prints a table"]
fn encode_speed_report() {
    let Some(ffmpeg) = ffmpeg_or_skip("encode_speed_report") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let frames = 600_u32;
    eprintln!(
        "size     preset (x264 options)            median fps  ffmpeg CPU ms/frame  bytes/frame"
    );
    for (width, height) in [(320, 240), (640, 360)] {
        let rendered: Vec<Vec<u8>> = (0..150)
            .map(|k| synthetic_render(width, height, k))
            .collect();
        for (preset, options) in [
            ("ultrafast", ""),
            ("ultrafast", autoact::video::DEFAULT_X264_OPTIONS),
            ("superfast", ""),
            ("veryfast", ""),
        ] {
            let mut runs = Vec::new();
            for run in 0..3 {
                let output = dir
                    .path()
                    .join(format!("{preset}{}{run}.mp4", options.len()));
                let mut settings = EncodeSettings::new(width, height, 30.0);
                settings.preset = preset.into();
                settings.x264_options = options.into();
                let cpu0 = children_cpu_s();
                let t0 = Instant::now();
                let mut encoder = VideoEncoder::start(&ffmpeg, &output, &settings).unwrap();
                for k in 0..frames {
                    // 60 distinct frames, but each shown once in a sweep: motion every frame.
                    encoder.write_frame(&rendered[(k % 150) as usize]).unwrap();
                }
                let encoded = encoder.finish().unwrap();
                let wall = t0.elapsed().as_secs_f64();
                let cpu = children_cpu_s() - cpu0;
                runs.push((
                    f64::from(frames) / wall,
                    cpu * 1000.0 / f64::from(frames),
                    encoded.bytes / u64::from(frames),
                ));
            }
            runs.sort_by(|a, b| a.0.total_cmp(&b.0));
            let (fps, cpu_ms, bytes) = runs[1];
            let name = format!("{preset} ({options})");
            eprintln!("{width}x{height}  {name:<32} {fps:>10.0}  {cpu_ms:>19.2}  {bytes:>11}");
        }
    }
}
