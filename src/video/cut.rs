//! Cutting a clip of whole frames out of a video, frame-exact: stream copy when the clip starts
//! on a keyframe, re-encoding otherwise, and a check of the result either way.
//!
//! Measured with ffmpeg 5.1 (see `docs` / the reference measurements):
//! - Stream copy with `-ss T` **before** `-i` starts at the keyframe at or before `T`; if `T` is
//!   not on a keyframe, the mp4 silently holds the earlier frames behind an edit list. So copy is
//!   used only when the first frame is a keyframe, `T` is that frame's time rounded *down* to the
//!   microsecond, and the output's packets are counted afterwards: a file holding any other
//!   number of packets than the clip's frames is rejected ([`VideoError::FrameCountMismatch`]).
//! - The end is `-t (N − ½)/fps`: half a frame short of the next frame, so rounding cannot take
//!   one frame more or less. `-frames:v` is never used with copy (it counts packets in decode
//!   order, which breaks with B-frames).
//! - Re-encoding seeks to half a frame before the first frame (`-ss (k − ½)/fps` before `-i`),
//!   decodes from the keyframe before it, and keeps exactly `-frames:v N` frames, restamped from
//!   zero (`setpts=PTS-STARTPTS`).
//!
//! The output goes to a hidden `.<name>.part` sibling, synced and renamed only once checked;
//! every error removes it. Arguments are passed as a vector through `ffmpeg-sidecar`'s command
//! builder, never through a shell.

use std::path::{Path, PathBuf};

use ffmpeg_sidecar::command::FfmpegCommand;

use super::encode::{DEFAULT_ENCODER_THREADS, container_for, remove_part};
use super::probe::probe_packets;
use super::stderr_tail::tail_of_text;
use super::tools::{ffmpeg_path_arg, run};
use super::{Ffmpeg, InvalidSetting, Rational, VideoError};
use crate::atomic_file::temporary_sibling as part_path;

/// How a clip is cut.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CutMethod {
    /// The compressed frames are copied (the first frame must be a keyframe). Fast, lossless.
    StreamCopy,
    /// The frames are decoded and encoded again with libx264.
    Reencode,
}

/// Encoder settings for [`CutMethod::Reencode`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReencodeSettings {
    /// x264 preset.
    pub preset: String,
    /// x264 constant rate factor.
    pub crf: u8,
}

impl Default for ReencodeSettings {
    fn default() -> ReencodeSettings {
        ReencodeSettings {
            preset: "veryfast".to_owned(),
            crf: 18,
        }
    }
}

/// Which frames of which video to cut.
#[derive(Debug, Clone, PartialEq)]
pub struct CutRequest<'a> {
    /// The source video.
    pub input: &'a Path,
    /// The clip to write (`.mp4`, `.mov` or `.mkv`).
    pub output: &'a Path,
    /// Index of the clip's first frame in the source (0-based, presentation order).
    pub start_frame: u64,
    /// Frames in the clip.
    pub frame_count: u64,
    /// The source's constant frame rate: frame k is at k / fps.
    pub fps: Rational,
    /// Copy or re-encode.
    pub method: CutMethod,
}

/// A clip written and checked.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CutClip {
    /// Its final path.
    pub path: PathBuf,
    /// Frames in it (= the request's).
    pub frame_count: u64,
    /// How it was cut.
    pub method: CutMethod,
    /// Its size.
    pub bytes: u64,
}

/// The frame count and the indices (presentation order) of a video's keyframes that a stream
/// copy can start a clip on, from its packets (no decoding). A stream whose decode order is not
/// its presentation order (B-frames) offers none: a copy cut by time there can hold the right
/// number of packets and still the wrong frames, so every clip of it is re-encoded.
///
/// # Errors
/// As [`probe_packets`]; [`VideoError::Probe`] if a packet has no timestamp.
pub fn keyframe_frames(ffmpeg: &Ffmpeg, path: &Path) -> Result<(u64, Vec<u64>), VideoError> {
    let packets = probe_packets(ffmpeg, path)?;
    let mut by_pts = Vec::with_capacity(packets.len());
    for (i, p) in packets.iter().enumerate() {
        let pts = p.pts.ok_or_else(|| VideoError::Probe {
            path: path.to_path_buf(),
            detail: format!("packet {i} has no timestamp"),
        })?;
        by_pts.push((pts, p.key));
    }
    let reordered = by_pts.windows(2).any(|w| w[1].0 < w[0].0);
    by_pts.sort_unstable();
    if reordered {
        return Ok((by_pts.len() as u64, Vec::new()));
    }
    let keys = (0_u64..)
        .zip(&by_pts)
        .filter(|(_, (_, key))| *key)
        .map(|(i, _)| i)
        .collect();
    Ok((by_pts.len() as u64, keys))
}

/// `seconds` with six decimals, rounded down to the microsecond (ffmpeg's time unit).
fn seconds_floor_us(nanos: u128) -> String {
    let micros = nanos / 1000;
    format!("{}.{:06}", micros / 1_000_000, micros % 1_000_000)
}

/// Time of `frames` frames at `fps`, in nanoseconds (exact rational arithmetic, rounded down).
fn frames_nanos(frames: u128, fps: Rational) -> u128 {
    // fps = num/den → t = frames·den/num seconds.
    let num = u128::try_from(fps.num).unwrap_or(1).max(1);
    let den = u128::try_from(fps.den).unwrap_or(1).max(1);
    frames * den * 1_000_000_000 / num
}

/// Cuts `request.frame_count` frames starting at `request.start_frame` into `request.output`,
/// through a hidden `.part` file renamed once ffmpeg succeeded and `ffprobe` counted exactly
/// that many packets (an existing output is replaced only then).
///
/// # Errors
/// [`VideoError::FrameCountMismatch`] when the cut holds another number of frames (for stream
/// copy: the start was not a keyframe, or the source is shorter), [`VideoError::Exited`] with
/// ffmpeg's last messages (corrupt input, full disk), [`VideoError::NotFound`] without ffmpeg,
/// [`VideoError::Io`], [`VideoError::InvalidSettings`] for a zero-length clip or an unknown
/// extension. On every error no output and no `.part` file is left.
pub fn cut(
    ffmpeg: &Ffmpeg,
    request: &CutRequest<'_>,
    reencode: &ReencodeSettings,
) -> Result<CutClip, VideoError> {
    let output = request.output;
    let invalid = |reason: InvalidSetting| VideoError::InvalidSettings {
        path: output.to_path_buf(),
        reason,
    };
    if request.frame_count == 0 {
        return Err(invalid(InvalidSetting::EmptyClip));
    }
    if request.fps.num <= 0 || request.fps.den <= 0 {
        return Err(invalid(InvalidSetting::FrameRate { fps: request.fps }));
    }
    let container = container_for(output).map_err(invalid)?;
    let part = part_path(output).ok_or_else(|| invalid(InvalidSetting::NoFileName))?;
    let start = u128::from(request.start_frame);
    let count = u128::from(request.frame_count);
    let mut command = FfmpegCommand::new_with_path(ffmpeg.ffmpeg_path());
    command
        .hide_banner()
        .args(["-nostdin", "-nostats", "-loglevel", "level+warning"]);
    match request.method {
        CutMethod::StreamCopy => {
            let ss = seconds_floor_us(frames_nanos(start, request.fps));
            // Half a frame short of the frame after the last.
            let t = seconds_floor_us(frames_nanos(2 * count - 1, request.fps) / 2);
            command
                .args(["-ss", &ss])
                .input(ffmpeg_path_arg(request.input))
                .args(["-map", "0:v:0", "-an", "-sn", "-dn", "-c", "copy", "-t", &t]);
        }
        CutMethod::Reencode => {
            let ss = if start == 0 {
                "0".to_owned()
            } else {
                seconds_floor_us(frames_nanos(2 * start - 1, request.fps) / 2)
            };
            command
                .args(["-ss", &ss])
                .input(ffmpeg_path_arg(request.input))
                .args(["-map", "0:v:0", "-an", "-sn", "-dn"])
                .args(["-frames:v".to_owned(), request.frame_count.to_string()])
                .args(["-vf", "setpts=PTS-STARTPTS", "-fps_mode", "passthrough"])
                .codec_video("libx264")
                .preset(&reencode.preset)
                .crf(u32::from(reencode.crf))
                .pix_fmt("yuv420p")
                // A fixed count, so the clip's bytes do not depend on the machine.
                .args(["-threads".to_owned(), DEFAULT_ENCODER_THREADS.to_string()])
                .args(["-bf", "0"]);
        }
    }
    command
        .format(container)
        .overwrite()
        .output(part.as_os_str());
    let inner = command.as_inner_mut();
    tracing::debug!(
        command = %std::iter::once(inner.get_program())
            .chain(inner.get_args())
            .map(|a| a.to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join(" "),
        "cutting"
    );
    let result = run_and_check(ffmpeg, inner, request, &part);
    if result.is_err() {
        remove_part(&part);
    }
    result
}

fn run_and_check(
    ffmpeg: &Ffmpeg,
    command: &mut std::process::Command,
    request: &CutRequest<'_>,
    part: &Path,
) -> Result<CutClip, VideoError> {
    let output = request.output;
    let out = run("ffmpeg", command, output)?;
    // ffmpeg can exit 0 after a failed write (a full disk): then its words are the useful ones.
    let packets = probe_packets(ffmpeg, part).map_err(|e| {
        let said = tail_of_text(&out.stderr);
        if said.trim().is_empty() {
            e
        } else {
            VideoError::Probe {
                path: output.to_path_buf(),
                detail: format!("ffmpeg wrote an unreadable file ({e}); ffmpeg said:\n{said}"),
            }
        }
    })?;
    let found = packets.len() as u64;
    if found != request.frame_count {
        return Err(VideoError::FrameCountMismatch {
            path: output.to_path_buf(),
            written: request.frame_count,
            found,
        });
    }
    if !packets.first().is_some_and(|p| p.key) {
        return Err(VideoError::Probe {
            path: output.to_path_buf(),
            detail: "the clip does not start with a keyframe".into(),
        });
    }
    let io = VideoError::io;
    crate::atomic_file::commit(part, output).map_err(io("sync and rename into place", output))?;
    let bytes = std::fs::metadata(output)
        .map_err(io("read the size of", output))?
        .len();
    Ok(CutClip {
        path: output.to_path_buf(),
        frame_count: found,
        method: request.method,
        bytes,
    })
}

/// ffmpeg's best mjpeg `qscale` (`-q:v`): what rawframes are written with unless
/// `[randomise] jpeg_quality` (or `trim --jpeg-quality`) draws another.
pub const JPEG_QSCALE_BEST: u8 = 2;
/// ffmpeg's worst mjpeg `qscale`.
pub const JPEG_QSCALE_WORST: u8 = 31;

/// A JPEG quality range that is not `[min, max]` with `2 ≤ min ≤ max ≤ 31`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error(
    "[{min}, {max}] is not an ffmpeg JPEG qscale range [min, max] with {JPEG_QSCALE_BEST} (best) ≤ min ≤ max ≤ {JPEG_QSCALE_WORST} (worst)"
)]
pub struct JpegQscaleError {
    /// The range's first value.
    pub min: u8,
    /// Its second.
    pub max: u8,
}

/// Checks a JPEG qscale range `[min, max]`.
///
/// # Errors
/// [`JpegQscaleError`] when it is not `2 ≤ min ≤ max ≤ 31`.
pub fn check_jpeg_qscale([lo, hi]: [u8; 2]) -> Result<(), JpegQscaleError> {
    if JPEG_QSCALE_BEST <= lo && lo <= hi && hi <= JPEG_QSCALE_WORST {
        Ok(())
    } else {
        Err(JpegQscaleError { min: lo, max: hi })
    }
}

/// The JPEG qscale of the clip keyed by `key` (the dataset's seed hashed with the clip's id):
/// drawn uniformly in `[min, max]` (a checked range), the same for the same key on every run.
#[must_use]
pub fn jpeg_qscale([lo, hi]: [u8; 2], key: u64) -> u8 {
    if hi <= lo {
        return lo;
    }
    let span = u64::from(hi - lo) + 1;
    // `span` ≤ 30, so the remainder fits a u8.
    lo + (crate::hash::hash2(key, 0x0004_a9e6) % span) as u8
}

/// Decodes every frame of `video` into `dir` as `img_00001.jpg` … (MMAction2's rawframe
/// naming, 1-based) at JPEG quality `qscale` (ffmpeg's `-q:v`, [`JPEG_QSCALE_BEST`] …
/// [`JPEG_QSCALE_WORST`]), through a hidden `.<dir>.part` sibling folder renamed once it holds exactly
/// `frame_count` images (an existing `dir` is replaced only then).
///
/// # Errors
/// [`VideoError::Exited`], [`VideoError::FrameCountMismatch`], [`VideoError::Io`]; the partial
/// folder is removed on every error.
pub fn extract_frames(
    ffmpeg: &Ffmpeg,
    video: &Path,
    dir: &Path,
    frame_count: u64,
    qscale: u8,
) -> Result<(), VideoError> {
    let invalid = |reason: InvalidSetting| VideoError::InvalidSettings {
        path: dir.to_path_buf(),
        reason,
    };
    let part = part_path(dir).ok_or_else(|| invalid(InvalidSetting::NoFolderName))?;
    let io = VideoError::io;
    let _ = std::fs::remove_dir_all(&part);
    std::fs::create_dir_all(&part).map_err(io("create", &part))?;
    let result = (|| {
        let mut command = FfmpegCommand::new_with_path(ffmpeg.ffmpeg_path());
        command
            .hide_banner()
            .args(["-nostdin", "-nostats", "-loglevel", "level+warning"])
            .input(ffmpeg_path_arg(video))
            .args(["-map", "0:v:0", "-fps_mode", "passthrough", "-q:v"])
            .arg(qscale.to_string())
            .args(["-start_number", "1", "-f", "image2"])
            .overwrite()
            .output(part.join("img_%05d.jpg").as_os_str());
        run("ffmpeg", command.as_inner_mut(), dir)?;
        let found =
            crate::atomic_file::sync_folder(&part).map_err(io("sync the frames in", &part))?;
        if found != frame_count {
            return Err(VideoError::FrameCountMismatch {
                path: dir.to_path_buf(),
                written: frame_count,
                found,
            });
        }
        crate::atomic_file::commit_folder(&part, dir).map_err(io("put in place", dir))
    })();
    if result.is_err() {
        let _ = std::fs::remove_dir_all(&part);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::{Rational, check_jpeg_qscale, frames_nanos, jpeg_qscale, seconds_floor_us};

    #[test]
    fn jpeg_qscales_are_drawn_in_their_range_reproducibly() {
        assert_eq!(jpeg_qscale([2, 2], 9), 2);
        let drawn: Vec<u8> = (0..200).map(|k| jpeg_qscale([3, 12], k)).collect();
        assert!(drawn.iter().all(|q| (3..=12).contains(q)), "{drawn:?}");
        assert!(drawn.contains(&3) && drawn.contains(&12), "{drawn:?}");
        assert_eq!(
            drawn,
            (0..200)
                .map(|k| jpeg_qscale([3, 12], k))
                .collect::<Vec<_>>()
        );
        assert!(check_jpeg_qscale([2, 31]).is_ok());
        for bad in [[1, 5], [6, 5], [2, 32]] {
            let e = check_jpeg_qscale(bad).unwrap_err().to_string();
            assert!(e.contains("qscale"), "{e}");
        }
    }

    #[test]
    fn times_round_down_to_the_microsecond() {
        let fps = Rational::new(30, 1).unwrap();
        assert_eq!(seconds_floor_us(frames_nanos(45, fps)), "1.500000");
        assert_eq!(seconds_floor_us(frames_nanos(1, fps)), "0.033333");
        let ntsc = Rational::new(30000, 1001).unwrap();
        assert_eq!(seconds_floor_us(frames_nanos(30, ntsc)), "1.001000");
        assert_eq!(seconds_floor_us(frames_nanos(89, fps) / 2), "1.483333");
    }
}
