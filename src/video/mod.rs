//! Video output: rendered RGB frames → H.264 through the system `ffmpeg`, checked frame by frame;
//! H.264 Annex B access units for `foxglove_msgs/CompressedVideo`; PNG stills and contact sheets.
//!
//! - [`Ffmpeg`] finds `ffmpeg` and `ffprobe` (`AUTOACT_FFMPEG`, then `PATH`, then the download
//!   cache), or downloads a static build when the user asked for it ([`Ffmpeg::download`]).
//! - [`VideoEncoder`] pipes raw frames into `ffmpeg` (given as `rgb24`, sent as `yuv420p`
//!   converted on its pipe thread; libx264, no B-frames,
//!   constant frame rate with frame k at exactly k/fps, IDR frames at every requested index) and
//!   writes a hidden `.<name>.part` sibling that is renamed only once `ffmpeg` exited 0 and
//!   its sample tables (an MP4's, read in-process; other containers', by `ffprobe`) hold every
//!   frame and every requested keyframe. On any error, on
//!   [`VideoEncoder::abort`] and on drop, `ffmpeg` is killed and the partial file removed.
//! - [`cut`] cuts a clip of whole frames, by stream copy or re-encoding, checked frame-exact.
//! - [`Mp4Source`] cuts stream-copy clips of an H.264 MP4 in-process (no process per clip).
//! - [`probe`] and [`probe_packets`] read what a video file really holds, frame by frame.
//! - [`annexb_access_units`] turns an encoded file into one Annex B access unit per frame.
//! - [`write_png`], [`write_png_as`] (grey 8- and 16-bit too), [`read_png`] and [`contact_sheet`] cover stills;
//!   [`still_frames`] takes one frame from each of many videos in one ffmpeg call.
//!
//! ```no_run
//! use autoact::video::{EncodeSettings, Ffmpeg, VideoEncoder};
//! # fn main() -> Result<(), autoact::video::VideoError> {
//! let ffmpeg = Ffmpeg::locate()?; // or Ffmpeg::download() when the user asked for it
//! // 640x360 at 30 fps; segments start at frames 0, 90 and 151, so cuts there can be exact.
//! let settings = EncodeSettings::new(640, 360, 30.0).with_keyframes([90, 151]);
//! let mut encoder = VideoEncoder::start(&ffmpeg, "capture.mp4".as_ref(), &settings)?;
//! for k in 0..200_u64 {
//!     let frame = vec![(k % 256) as u8; settings.frame_bytes()]; // rendered rgb24 pixels
//!     encoder.write_frame(&frame)?;
//! }
//! let video = encoder.finish()?; // capture.mp4 exists only now, every frame checked
//! let stamp_nanos = video.fps.frame_time_nanos(151); // frame 151's time in the video
//! # let _ = stamp_nanos;
//! # Ok(())
//! # }
//! ```
//!
//! `ffmpeg` 5.1 (Debian 12) is the reference version; nothing here needs a newer one. The
//! `ffmpeg-sidecar` crate builds and spawns the encoder command; `ffprobe` runs through
//! [`std::process::Command`] because `ffmpeg-sidecar` has no `ffprobe` wrapper.

mod annexb;
mod cut;
mod encode;
mod font;
mod image;
mod probe;
mod rational;
mod remux;
mod stderr_tail;
mod stills;
mod tools;
mod yuv;

use std::path::{Path, PathBuf};
use std::process::ExitStatus;

pub use annexb::{AccessUnit, AnnexBError, annexb_access_units, split_access_units};
pub use cut::{
    CutClip, CutMethod, CutRequest, JPEG_QSCALE_BEST, JPEG_QSCALE_WORST, JpegQscaleError,
    ReencodeSettings, check_jpeg_qscale, cut, extract_frames, jpeg_qscale, keyframe_frames,
};
pub use encode::{
    DEFAULT_CRF, DEFAULT_ENCODER_THREADS, DEFAULT_GOP_SECS, DEFAULT_PRESET, DEFAULT_X264_OPTIONS,
    EncodeSettings, EncodedVideo, MAX_ENCODER_THREADS, VideoEncoder, check_x264,
    force_key_frames_arg,
};
pub use image::{PngPixels, Tile, contact_sheet, read_png, write_png, write_png_as};
pub use probe::{ProbedFrame, ProbedPacket, VideoProbe, probe, probe_packets, probe_size};
pub use rational::Rational;
pub use remux::{Mp4Source, concat as concat_mp4};
pub use stills::{StillRequest, still_frames};
pub use tools::{Ffmpeg, INSTALL_HINT, download_cache_dir};

impl VideoError {
    /// A mapper from an I/O error to [`VideoError::Io`] for `action` on `path`
    /// (`file.write_all(..).map_err(VideoError::io("write", &path))`).
    pub fn io(
        action: &'static str,
        path: &Path,
    ) -> impl FnOnce(std::io::Error) -> VideoError + use<> {
        let path = path.to_path_buf();
        move |source| VideoError::Io {
            action,
            path,
            source,
        }
    }
}

/// Number of `ffmpeg` stderr lines kept for error messages.
pub const STDERR_TAIL_LINES: usize = 20;

/// Errors from finding, running or reading the output of `ffmpeg` / `ffprobe`, and from the
/// image helpers.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum VideoError {
    /// `ffmpeg` or `ffprobe` is not installed where we looked.
    #[error("cannot find `{program}`: {detail}\n{INSTALL_HINT}")]
    NotFound {
        /// `ffmpeg` or `ffprobe`.
        program: &'static str,
        /// Where we looked.
        detail: String,
    },
    /// The ffmpeg download was not possible or failed.
    #[error("cannot download ffmpeg into `{dir}`: {detail}")]
    Download {
        /// The cache directory the binaries were meant for.
        dir: PathBuf,
        /// What went wrong, and what to do instead.
        detail: String,
    },
    /// The program exists but could not be started, or a helper thread could not be started.
    #[error("cannot start `{program}`")]
    Spawn {
        /// The program (or thread) that failed to start.
        program: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// `ffmpeg` or `ffprobe` exited with an error (or was killed).
    #[error("`{program}` failed on `{path}` ({status}); its last messages:\n{stderr_tail}")]
    Exited {
        /// `ffmpeg` or `ffprobe`.
        program: &'static str,
        /// How it ended.
        status: ExitStatus,
        /// The file it was writing or reading.
        path: PathBuf,
        /// The last lines of its standard error (at most [`STDERR_TAIL_LINES`]).
        stderr_tail: String,
    },
    /// A file system error.
    #[error("cannot {action} `{path}`")]
    Io {
        /// What was being done.
        action: &'static str,
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// A frame buffer does not hold `width × height × 3` bytes.
    #[error("frame {frame} for `{path}` has {got} bytes; {width}x{height} rgb24 needs {expected}")]
    FrameSize {
        /// The file the frame was meant for.
        path: PathBuf,
        /// The index of the offending frame (or tile).
        frame: u64,
        /// Expected width.
        width: u32,
        /// Expected height.
        height: u32,
        /// `width × height × 3`.
        expected: usize,
        /// The buffer's length.
        got: usize,
    },
    /// The finished file holds a different number of frames than were written.
    #[error("`{path}` holds {found} frames, but {written} were written")]
    FrameCountMismatch {
        /// The (partial) file.
        path: PathBuf,
        /// Frames handed to the encoder.
        written: u64,
        /// Frames the file holds (its sample table's count, or `ffprobe`'s).
        found: u64,
    },
    /// A frame that was asked to be a keyframe is not one in the finished file.
    #[error("frame {frame} of `{path}` was requested as a keyframe but is not one")]
    KeyframeMissing {
        /// The (partial) file.
        path: PathBuf,
        /// The frame index.
        frame: u64,
    },
    /// The encoder settings (or an output path, or a contact sheet's tiles) cannot be used.
    #[error("invalid video settings for `{path}`: {reason}")]
    InvalidSettings {
        /// The output file.
        path: PathBuf,
        /// What is wrong and how to fix it.
        reason: InvalidSetting,
    },
    /// The encoder already failed, was finished or aborted.
    #[error("the encoder for `{path}` has already stopped; start a new one")]
    Stopped {
        /// The output file.
        path: PathBuf,
    },
    /// An encoded stream does not split into Annex B access units.
    #[error("cannot read video `{path}`")]
    AccessUnits {
        /// The file.
        path: PathBuf,
        /// What was wrong.
        #[source]
        source: AnnexBError,
    },
    /// `ffprobe` output (or an encoded stream) could not be understood.
    #[error("cannot read video `{path}`: {detail}")]
    Probe {
        /// The file.
        path: PathBuf,
        /// What was wrong.
        detail: String,
    },
    /// A PNG could not be encoded or decoded.
    #[error("PNG `{path}`: {detail}")]
    Png {
        /// The file.
        path: PathBuf,
        /// What the `png` crate said.
        detail: String,
    },
}

/// Which setting of a video, an output path or a contact sheet cannot be used, with the value
/// asked; its message says why and what would do. The detail of [`VideoError::InvalidSettings`]
/// (not an error of its own: nothing failed below it).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum InvalidSetting {
    /// A side is odd or under 2 pixels.
    FrameSize {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
    },
    /// A side is over the largest the encoder accepts.
    FrameTooLarge {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// The largest side accepted, pixels.
        max_side_px: u32,
    },
    /// The frame rate is not a usable positive fraction.
    Fps {
        /// The asked rate, frames per second.
        fps: f64,
    },
    /// A frame rate that is zero or negative.
    FrameRate {
        /// The asked rate.
        fps: Rational,
    },
    /// The constant rate factor is over 51.
    Crf {
        /// The asked factor.
        crf: u8,
    },
    /// libx264 has no such preset.
    Preset {
        /// The asked preset.
        preset: String,
        /// The presets there are.
        known: &'static [&'static str],
    },
    /// The x264 options are not `key=value` pairs joined by `:` (an empty pair, whitespace or a
    /// control character).
    X264Options {
        /// The asked options.
        options: String,
    },
    /// The longest keyframe interval is 0.
    GopZero,
    /// The x264 thread count is 0 or over [`MAX_ENCODER_THREADS`].
    Threads {
        /// The asked count.
        threads: u8,
    },
    /// The output's extension names no container we write.
    Extension {
        /// The extension (`None`: the path has none).
        extension: Option<String>,
    },
    /// So many keyframes that their times do not fit one command-line argument.
    TooManyKeyframes {
        /// Keyframes asked for.
        keyframes: usize,
        /// The argument's length, bytes.
        arg_bytes: usize,
        /// The longest argument passed, bytes.
        max_bytes: usize,
    },
    /// No decimal time up to microseconds selects the asked keyframes at this rate.
    KeyframeTimes {
        /// The frame rate.
        fps: Rational,
    },
    /// The output path has no file name (its partial sibling cannot be named).
    NoFileName,
    /// The PNG path has no file name.
    NotAFileName,
    /// The frames folder's path has no name.
    NoFolderName,
    /// The encoder was finished before any frame was written.
    NoFramesWritten,
    /// A clip of zero frames was asked for.
    EmptyClip,
    /// A contact sheet with no column or tiles of no width.
    SheetLayout {
        /// Columns asked for.
        columns: u32,
        /// Tile width asked for, pixels.
        tile_width: u32,
    },
    /// A tile's buffer does not hold `width × height × 3` bytes (or a side is 0).
    TileSize {
        /// The tile's index.
        index: usize,
        /// The buffer's length.
        got: usize,
        /// The tile's width, pixels.
        width: u32,
        /// The tile's height, pixels.
        height: u32,
        /// `width × height × 3`.
        expected: usize,
    },
    /// A tile scaled to the sheet's tile width would be over `u32::MAX` pixels tall.
    TileTooTall {
        /// The tile's index.
        index: usize,
        /// The sheet's tile width, pixels.
        tile_width: u32,
    },
    /// More tiles than a `u32` counts.
    TooManyTiles,
    /// The sheet would be over 2³⁰ pixels.
    SheetTooLarge {
        /// The sheet's width, pixels.
        width: u64,
        /// The sheet's height, pixels.
        height: u64,
    },
}

impl std::fmt::Display for InvalidSetting {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            InvalidSetting::FrameSize { width, height } => write!(
                f,
                "frame size {width}x{height}: both sides must be even and at least 2 (H.264 yuv420p)"
            ),
            InvalidSetting::FrameTooLarge {
                width,
                height,
                max_side_px,
            } => write!(
                f,
                "frame size {width}x{height}: at most {max_side_px} per side"
            ),
            InvalidSetting::Fps { fps } => write!(
                f,
                "fps {fps}: must be a positive rate up to 10000 that is a fraction with a \
                 denominator up to 1000000 (e.g. 30, 29.97 or 30000/1001)"
            ),
            InvalidSetting::FrameRate { fps } => write!(f, "frame rate {fps} is not positive"),
            InvalidSetting::Crf { crf } => write!(f, "crf {crf}: must be 0..=51"),
            InvalidSetting::Preset { preset, known } => write!(
                f,
                "unknown preset `{preset}`; use one of {}",
                known.join(", ")
            ),
            InvalidSetting::X264Options { options } => write!(
                f,
                "x264 options `{options}`: give `key=value` pairs joined by `:` without spaces \
                 (e.g. `cabac=1:deblock=0,0`), or nothing for the preset alone"
            ),
            InvalidSetting::GopZero => f.write_str("gop_frames is 0; it must be at least 1"),
            InvalidSetting::Threads { threads } => write!(
                f,
                "{threads} encoder threads; use 1 to {MAX_ENCODER_THREADS}"
            ),
            InvalidSetting::Extension { extension } => write!(
                f,
                "unsupported file extension `{}`; use `.mp4`, `.mov` or `.mkv`",
                extension.as_deref().unwrap_or("(none)")
            ),
            InvalidSetting::TooManyKeyframes {
                keyframes,
                arg_bytes,
                max_bytes,
            } => write!(
                f,
                "{keyframes} keyframes need a {arg_bytes}-byte `-force_key_frames` argument, over \
                 the {max_bytes} bytes ffmpeg can be given; split the video into shorter ones"
            ),
            InvalidSetting::KeyframeTimes { fps } => {
                write!(f, "cannot place keyframes at {fps} fps")
            }
            InvalidSetting::NoFileName => f.write_str("the output has no file name"),
            InvalidSetting::NotAFileName => f.write_str("not a file name"),
            InvalidSetting::NoFolderName => f.write_str("the folder has no name"),
            InvalidSetting::NoFramesWritten => f.write_str("no frames were written"),
            InvalidSetting::EmptyClip => f.write_str("a clip needs at least one frame"),
            InvalidSetting::SheetLayout {
                columns,
                tile_width,
            } => write!(
                f,
                "columns {columns} and tile width {tile_width} must be at least 1"
            ),
            InvalidSetting::TileSize {
                index,
                got,
                width,
                height,
                expected,
            } => write!(
                f,
                "tile {index} has {got} bytes; {width}x{height} rgb24 needs {expected}"
            ),
            InvalidSetting::TileTooTall { index, tile_width } => {
                write!(f, "tile {index} would be too tall at width {tile_width}")
            }
            InvalidSetting::TooManyTiles => f.write_str("too many tiles"),
            InvalidSetting::SheetTooLarge { width, height } => write!(
                f,
                "the sheet would be {width}x{height} pixels; use fewer or smaller tiles"
            ),
        }
    }
}
