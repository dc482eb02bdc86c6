//! What a video file really holds, read with `ffprobe`: stream facts and, per frame, the exact
//! timestamp and whether it is a keyframe.
//!
//! [`probe`] decodes every frame (`-show_entries frame=…`, as `ffprobe -show_frames`);
//! [`probe_packets`] only demuxes (`packet=pts,flags`), which is much cheaper and what the
//! encoder uses to confirm its output. Timestamps are kept as integers in the stream's time base,
//! so `pts × time_base` is exact.

use std::ffi::OsStr;
use std::path::Path;

use serde::Deserialize;

use super::tools::ffmpeg_path_arg;
use super::{Ffmpeg, Rational, VideoError};

/// Facts about a file's first video stream and all its frames, in presentation order.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoProbe {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The stream's frame rate (`r_frame_rate`), exact; `fps.as_f64()` for the float.
    pub fps: Rational,
    /// The stream's time base: a frame's time is `pts × time_base` seconds.
    pub time_base: Rational,
    /// Codec name, e.g. `h264`.
    pub codec: String,
    /// Pixel format, e.g. `yuv420p`.
    pub pix_fmt: String,
    /// Whether the stream uses B-frames (reordering declared by the stream, or any `B` frame).
    pub has_b_frames: bool,
    /// Every decoded frame.
    pub frames: Vec<ProbedFrame>,
}

impl VideoProbe {
    /// Indices (into [`VideoProbe::frames`]) of the keyframes.
    #[must_use]
    pub fn keyframe_indices(&self) -> Vec<u64> {
        (0_u64..)
            .zip(&self.frames)
            .filter(|(_, f)| f.key)
            .map(|(i, _)| i)
            .collect()
    }
}

/// One decoded frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbedFrame {
    /// Presentation timestamp in the stream's time base.
    pub pts: i64,
    /// `pts × time_base`, in seconds.
    pub pts_s: f64,
    /// Whether it is a keyframe.
    pub key: bool,
    /// Picture type: `I`, `P`, `B` (or `?`).
    pub pict_type: char,
}

/// One packet (compressed frame), in file order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ProbedPacket {
    /// Presentation timestamp in the stream's time base, if the container gives one.
    pub pts: Option<i64>,
    /// Whether the container marks it as a keyframe (sync sample).
    pub key: bool,
}

#[derive(Deserialize)]
struct ProbeJson {
    #[serde(default)]
    streams: Vec<StreamJson>,
    #[serde(default)]
    frames: Vec<FrameJson>,
    #[serde(default)]
    packets: Vec<PacketJson>,
}

#[derive(Deserialize)]
struct StreamJson {
    codec_name: Option<String>,
    width: Option<u32>,
    height: Option<u32>,
    r_frame_rate: Option<String>,
    time_base: Option<String>,
    has_b_frames: Option<i64>,
    pix_fmt: Option<String>,
}

#[derive(Deserialize)]
struct FrameJson {
    pts: Option<i64>,
    best_effort_timestamp: Option<i64>,
    key_frame: Option<i64>,
    pict_type: Option<String>,
}

#[derive(Deserialize)]
struct PacketJson {
    pts: Option<i64>,
    flags: Option<String>,
}

/// Runs `ffprobe` on `path` and reads its first video stream and every frame (decoding them
/// all: about as slow as decoding the video).
///
/// # Errors
/// [`VideoError::Exited`] if ffprobe fails (e.g. not a video), [`VideoError::Probe`] if the
/// file has no video stream or ffprobe's answer lacks a field, [`VideoError::NotFound`] /
/// [`VideoError::Spawn`] if ffprobe cannot run.
pub fn probe(ffmpeg: &Ffmpeg, path: &Path) -> Result<VideoProbe, VideoError> {
    let json = run_json(
        ffmpeg,
        path,
        "stream=codec_name,width,height,r_frame_rate,time_base,has_b_frames,pix_fmt\
         :frame=pts,best_effort_timestamp,key_frame,pict_type",
    )?;
    let bad = |detail: String| VideoError::Probe {
        path: path.to_path_buf(),
        detail,
    };
    let stream = json
        .streams
        .into_iter()
        .next()
        .ok_or_else(|| bad("no video stream".into()))?;
    let field = |name: &str| bad(format!("ffprobe gave no `{name}` for the video stream"));
    let rational = |name: &str, value: Option<String>| {
        let text = value.ok_or_else(|| field(name))?;
        Rational::parse(&text).ok_or_else(|| bad(format!("`{name}` is `{text}`")))
    };
    let fps = rational("r_frame_rate", stream.r_frame_rate)?;
    let time_base = rational("time_base", stream.time_base)?;
    if time_base.num == 0 {
        return Err(bad("the time base is 0".into()));
    }
    let mut frames = Vec::with_capacity(json.frames.len());
    for (index, frame) in json.frames.into_iter().enumerate() {
        let pts = frame
            .pts
            .or(frame.best_effort_timestamp)
            .ok_or_else(|| bad(format!("frame {index} has no timestamp")))?;
        #[expect(clippy::cast_precision_loss, reason = "exact for any real video")]
        let pts_s = pts as f64 * time_base.num as f64 / time_base.den as f64;
        frames.push(ProbedFrame {
            pts,
            pts_s,
            key: frame.key_frame == Some(1),
            pict_type: frame
                .pict_type
                .as_deref()
                .and_then(|t| t.chars().next())
                .unwrap_or('?'),
        });
    }
    let any_b = frames.iter().any(|f| f.pict_type == 'B');
    Ok(VideoProbe {
        width: stream.width.ok_or_else(|| field("width"))?,
        height: stream.height.ok_or_else(|| field("height"))?,
        fps,
        time_base,
        codec: stream.codec_name.ok_or_else(|| field("codec_name"))?,
        pix_fmt: stream.pix_fmt.unwrap_or_default(),
        has_b_frames: any_b || stream.has_b_frames.unwrap_or(0) > 0,
        frames,
    })
}

/// Runs `ffprobe` on `path` and lists the first video stream's packets (no decoding).
///
/// # Errors
/// As [`probe`].
pub fn probe_packets(ffmpeg: &Ffmpeg, path: &Path) -> Result<Vec<ProbedPacket>, VideoError> {
    let json = run_json(ffmpeg, path, "stream=codec_name:packet=pts,flags")?;
    if json.streams.is_empty() {
        return Err(VideoError::Probe {
            path: path.to_path_buf(),
            detail: "no video stream".into(),
        });
    }
    Ok(json
        .packets
        .into_iter()
        .map(|p| ProbedPacket {
            pts: p.pts,
            key: p.flags.is_some_and(|f| f.starts_with('K')),
        })
        .collect())
}

/// The first video stream's width and height (no decoding).
///
/// # Errors
/// As [`probe_packets`].
pub fn probe_size(ffmpeg: &Ffmpeg, path: &Path) -> Result<(u32, u32), VideoError> {
    let json = run_json(ffmpeg, path, "stream=codec_name,width,height")?;
    json.streams
        .first()
        .and_then(|s| Some((s.width?, s.height?)))
        .ok_or_else(|| VideoError::Probe {
            path: path.to_path_buf(),
            detail: "no video stream with a size".into(),
        })
}

fn run_json(ffmpeg: &Ffmpeg, path: &Path, entries: &str) -> Result<ProbeJson, VideoError> {
    let input = ffmpeg_path_arg(path);
    let args: [&OsStr; 9] = [
        OsStr::new("-v"),
        OsStr::new("error"),
        OsStr::new("-select_streams"),
        OsStr::new("v:0"),
        OsStr::new("-show_entries"),
        OsStr::new(entries),
        OsStr::new("-of"),
        OsStr::new("json"),
        &input,
    ];
    let stdout = ffmpeg.run_ffprobe(args, path)?;
    serde_json::from_slice(&stdout).map_err(|e| VideoError::Probe {
        path: path.to_path_buf(),
        detail: format!("cannot parse ffprobe's JSON: {e}"),
    })
}
