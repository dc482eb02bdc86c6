//! Single frames out of many videos in one ffmpeg call: what contact sheets are made of.

use std::path::Path;

use super::tools::ffmpeg_path_arg;
use super::{Ffmpeg, InvalidSetting, VideoError};

/// One frame to take: frame `frame` (0: the first) of the video `path` at `fps` frames per
/// second.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StillRequest<'a> {
    /// The video.
    pub path: &'a Path,
    /// The frame's index in the video.
    pub frame: u64,
    /// The video's frame rate.
    pub fps: f64,
}

/// Decodes each requested frame, scaled to fit `width × height` (aspect kept, centred on black)
/// as `rgb24`, with one ffmpeg process for all of them. Each video is opened with an exact seek
/// half a frame before the wanted frame, relative to the video's own start, so a clip cut by stream
/// copy (whose timestamps need not start at 0) gives the frame asked for.
///
/// # Errors
/// [`VideoError::InvalidSettings`] for a 0 or odd size; [`VideoError::Exited`] (ffmpeg's words)
/// when a video cannot be read or has no frame there; [`VideoError::NotFound`] without ffmpeg.
pub fn still_frames(
    ffmpeg: &Ffmpeg,
    requests: &[StillRequest<'_>],
    (width, height): (u32, u32),
) -> Result<Vec<Vec<u8>>, VideoError> {
    let Some(first) = requests.first() else {
        return Ok(Vec::new());
    };
    if width == 0 || height == 0 || width % 2 != 0 || height % 2 != 0 {
        return Err(VideoError::InvalidSettings {
            path: first.path.to_path_buf(),
            reason: InvalidSetting::FrameSize { width, height },
        });
    }
    let mut args: Vec<std::ffi::OsString> = ["-nostdin", "-hide_banner", "-v", "error"]
        .iter()
        .map(Into::into)
        .collect();
    let mut graph = String::new();
    for (i, r) in requests.iter().enumerate() {
        #[expect(
            clippy::cast_precision_loss,
            reason = "frame indices are far below 2^52"
        )]
        let seek_s = ((r.frame as f64 - 0.5) / r.fps).max(0.0);
        args.extend(["-ss".into(), format!("{seek_s:.6}").into(), "-i".into()]);
        args.push(ffmpeg_path_arg(r.path));
        graph.push_str(&format!(
            "[{i}:v]trim=end_frame=1,setpts=PTS-STARTPTS,\
             scale={width}:{height}:force_original_aspect_ratio=decrease:flags=area,\
             pad={width}:{height}:(ow-iw)/2:(oh-ih)/2,setsar=1,format=rgb24[s{i}];"
        ));
    }
    for i in 0..requests.len() {
        graph.push_str(&format!("[s{i}]"));
    }
    graph.push_str(&format!("concat=n={}:v=1:a=0[out]", requests.len()));
    args.extend(
        [
            "-filter_complex",
            &graph,
            "-map",
            "[out]",
            // Every still is one frame at the same time: a constant-rate output would drop them.
            "-fps_mode",
            "passthrough",
            "-f",
            "rawvideo",
            "-pix_fmt",
            "rgb24",
            "-",
        ]
        .iter()
        .map(Into::into),
    );
    let bytes = ffmpeg.run_ffmpeg(&args, first.path)?;
    let size = width as usize * height as usize * 3;
    if bytes.len() != size * requests.len() {
        return Err(VideoError::Probe {
            path: first.path.to_path_buf(),
            detail: format!(
                "ffmpeg gave {} bytes for {} stills of {width}x{height}: a video has no frame at its seek point",
                bytes.len(),
                requests.len()
            ),
        });
    }
    Ok(bytes.chunks_exact(size).map(<[u8]>::to_vec).collect())
}
