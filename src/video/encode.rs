//! Encoding rendered `rgb24` frames to H.264 with `ffmpeg` (libx264), frame-exact; the
//! details are on [`VideoEncoder`]. The frames reach ffmpeg as `yuv420p`, converted on the pipe
//! thread ([`super::yuv`]).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ChildStdin;
use std::sync::mpsc::{Receiver, SyncSender, TryRecvError};
use std::thread::JoinHandle;

use ffmpeg_sidecar::child::FfmpegChild;
use ffmpeg_sidecar::command::FfmpegCommand;

use super::probe::probe_packets;
use super::stderr_tail::StderrTail;
use super::tools::spawn_error;
use super::{Ffmpeg, InvalidSetting, Rational, VideoError};

/// The default libx264 preset, with [`DEFAULT_X264_OPTIONS`] after it: `ultrafast` with CABAC and
/// the deblocking filter put back. Measured on autoact's own renders (the 320×240 captures of
/// `tools/bench_generate.sh`, 1,500 frames each of the wave and the walk as autoact feeds them,
/// `yuv420p`, CRF 23, one thread; ffmpeg 5.1), CPU per frame, size, luma PSNR and SSIM:
///
/// | x264 settings | wave | walk |
/// |---|---|---|
/// | `superfast` (the default before) | 0.95–1.10 ms, 3.31 MB, 43.50 dB, 0.968 | 1.03 ms, 2.44 MB, 42.24 dB, 0.963 |
/// | `ultrafast` + `cabac=1:deblock=0,0` (the default) | 0.61 ms, 2.68 MB, 43.40 dB, 0.965 | 0.53 ms, 2.11 MB, 42.42 dB, 0.959 |
/// | `ultrafast` alone | 0.45 ms, 3.26 MB, 43.16 dB, 0.963 | 0.39 ms, 2.41 MB, 42.20 dB, 0.958 |
///
/// The default encodes in about 55 % of `superfast`'s CPU, into files 13–19 % smaller at the
/// same PSNR; SSIM is 0.003–0.004 lower, because `ultrafast` also leaves out adaptive
/// quantisation, which spends bits on flat areas. `superfast`'s other tools (sub-pixel
/// refinement, the 8×8 transform, partitions, weighted prediction) cost more CPU here than they
/// save in size. `ultrafast` alone is cheaper still but blockier (no deblocking) and 14–22 %
/// larger again (`--x264-options ''`). In `generate` the change took the chain's CPU down
/// 7–12 % (`docs/performance.md`).
pub const DEFAULT_PRESET: &str = "ultrafast";
/// The default x264 options after the preset (ffmpeg's `-x264opts`): CABAC entropy coding
/// and the deblocking filter at its default strength, the two tools only `ultrafast` turns off
/// (so with any other preset they change nothing). See [`DEFAULT_PRESET`].
pub const DEFAULT_X264_OPTIONS: &str = "cabac=1:deblock=0,0";
/// The default number of x264 threads. Always passed (`-threads`): x264's own default is 1.5 ×
/// the machine's cores, and its output depends on its thread count, so a dataset's videos would
/// depend on the machine that encoded them (shards of one dataset on different machines would
/// not give one machine's bytes). One thread also costs the least CPU: on 2 cores, 1,500 frames
/// of a capture at 320×240 took 2.45–2.55 s of ffmpeg CPU with 1 thread, 2.85–2.95 s with 2
/// and 2.94–3.48 s with x264's default, at the same wall time (ffmpeg's input side is the limit
/// there, about 600 frames/s). At 1280×720 one thread encodes about 59 frames/s (x264's
/// default 103 on 2 cores): more threads pay only when the renderer draws faster than that. In
/// `generate` on 2 cores the saving is about 1 % of the chain's CPU (`docs/performance.md`).
pub const DEFAULT_ENCODER_THREADS: u8 = 1;
/// The most x264 threads accepted.
pub const MAX_ENCODER_THREADS: u8 = 64;
/// The default constant rate factor (x264's own default).
pub const DEFAULT_CRF: u8 = 23;
/// The default longest keyframe interval, in seconds of video.
pub const DEFAULT_GOP_SECS: f64 = 2.0;

/// libx264's presets, fastest first.
const PRESETS: [&str; 10] = [
    "ultrafast",
    "superfast",
    "veryfast",
    "faster",
    "fast",
    "medium",
    "slow",
    "slower",
    "veryslow",
    "placebo",
];

/// Frames queued between [`VideoEncoder::write_frame`] and the thread writing to ffmpeg.
const QUEUE_FRAMES: usize = 4;

/// Longest `-force_key_frames` argument we pass. Linux refuses a single argument longer than
/// 128 KiB (`MAX_ARG_STRLEN`); this leaves room. At 30 fps the compact times take ~8 bytes each,
/// so this allows about 15 000 keyframes.
const MAX_KEYFRAME_ARG_BYTES: usize = 120_000;

/// Largest frame side we accept.
const MAX_SIDE_PX: u32 = 16_384;

/// What to encode and how.
#[derive(Debug, Clone, PartialEq)]
pub struct EncodeSettings {
    /// Frame width in pixels (even: `yuv420p` halves it).
    pub width: u32,
    /// Frame height in pixels (even).
    pub height: u32,
    /// Frames per second. Converted to the exact rational it denotes
    /// (`29.97` → `2997/100`; pass `30000.0 / 1001.0` for NTSC).
    pub fps: f64,
    /// libx264 constant rate factor, 0 (lossless) ..= 51; lower is better and larger.
    pub crf: u8,
    /// libx264 preset (`ultrafast` … `placebo`).
    pub preset: String,
    /// libx264 options applied after the preset (ffmpeg's `-x264opts`, `key=value` pairs
    /// joined by `:`); empty: the preset alone ([`DEFAULT_X264_OPTIONS`]).
    pub x264_options: String,
    /// The longest run of frames without a keyframe (`-g`), ≥ 1.
    pub gop_frames: u32,
    /// x264 threads, 1 ..= [`MAX_ENCODER_THREADS`] ([`DEFAULT_ENCODER_THREADS`]): the output's
    /// bytes depend on it.
    pub threads: u8,
    /// Frame indices that must be IDR keyframes (any order; duplicates are fine). Frame 0
    /// always is one.
    pub keyframes: Vec<u64>,
}

impl EncodeSettings {
    /// `width × height` at `fps` with the defaults: [`DEFAULT_CRF`], [`DEFAULT_PRESET`], a
    /// keyframe at least every [`DEFAULT_GOP_SECS`], no extra keyframes.
    #[must_use]
    pub fn new(width: u32, height: u32, fps: f64) -> EncodeSettings {
        EncodeSettings {
            width,
            height,
            fps,
            crf: DEFAULT_CRF,
            preset: DEFAULT_PRESET.to_owned(),
            x264_options: DEFAULT_X264_OPTIONS.to_owned(),
            gop_frames: default_gop_frames(fps),
            threads: DEFAULT_ENCODER_THREADS,
            keyframes: Vec::new(),
        }
    }

    /// These settings with `keyframes` as the frames that must be IDR.
    #[must_use]
    pub fn with_keyframes(mut self, keyframes: impl IntoIterator<Item = u64>) -> EncodeSettings {
        self.keyframes = keyframes.into_iter().collect();
        self
    }

    /// Bytes of one `rgb24` frame: `width × height × 3`.
    #[must_use]
    pub fn frame_bytes(&self) -> usize {
        self.width as usize * self.height as usize * 3
    }
}

fn default_gop_frames(fps: f64) -> u32 {
    let frames = (fps * DEFAULT_GOP_SECS).round();
    if frames.is_finite() && frames >= 1.0 {
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "clamped to 1..=u32::MAX"
        )]
        let frames = frames.min(f64::from(u32::MAX)) as u32;
        frames
    } else {
        1
    }
}

/// The `-force_key_frames` value that makes exactly the frames in `keyframes` (sorted or not,
/// duplicates allowed) keyframes at frame rate `fps`; `None` when only frame 0 (always a
/// keyframe) or nothing is asked for.
///
/// Frame k gets the shortest decimal time t with (k − ½)/fps < t ≤ k/fps. That interval is what
/// both ffmpeg behaviours agree on: ffmpeg ≤ 6.0 rounds t to the *nearest* frame and keys the
/// first frame at or after it, later versions key the first frame whose time is ≥ t. The
/// usual "half a frame before" time would fall on the rounding boundary, and microsecond
/// rounding in ffmpeg's time parser then keys frame k − 1 about half the time (measured with
/// ffmpeg 5.1). Short decimals keep hundreds of boundaries well inside the argument length
/// limit (at 30 fps two decimals always suffice).
#[must_use]
pub fn force_key_frames_arg(keyframes: &[u64], fps: Rational) -> Option<String> {
    let mut frames: Vec<u64> = keyframes.iter().copied().filter(|&k| k > 0).collect();
    frames.sort_unstable();
    frames.dedup();
    if frames.is_empty() {
        return None;
    }
    let mut arg = String::with_capacity(frames.len() * 9);
    for k in frames {
        if !arg.is_empty() {
            arg.push(',');
        }
        arg.push_str(&keyframe_time(k, fps)?);
    }
    Some(arg)
}

/// The shortest decimal t (at most 6 places) with (k − ½)/fps < t ≤ k/fps.
fn keyframe_time(k: u64, fps: Rational) -> Option<String> {
    let num = u128::from(fps.num.unsigned_abs());
    let den = u128::from(fps.den.unsigned_abs());
    let k = u128::from(k);
    let mut scale: u128 = 1;
    for places in 0..=6_usize {
        // Largest m with m/scale ≤ k·den/num.
        let m = k * den * scale / num;
        // m/scale > (k − ½)·den/num  ⇔  2·m·num > (2k − 1)·den·scale.
        if 2 * m * num > (2 * k - 1) * den * scale {
            let whole = m / scale;
            if places == 0 {
                return Some(whole.to_string());
            }
            let frac = m % scale;
            return Some(format!("{whole}.{frac:0places$}"));
        }
        scale *= 10;
    }
    None
}

/// An encoded file, complete and checked.
#[derive(Debug, Clone, PartialEq)]
pub struct EncodedVideo {
    /// The final path.
    pub path: PathBuf,
    /// Frames in the file (= frames written).
    pub frame_count: u64,
    /// File size.
    pub bytes: u64,
    /// The exact frame rate: frame k is at `k / fps`.
    pub fps: Rational,
    /// Indices of all keyframes in the file (the requested ones, frame 0 and GOP keyframes).
    pub keyframes: Vec<u64>,
}

/// ffmpeg encoding `rgb24` frames into a hidden `.part` file, renamed when complete and checked.
///
/// The command (`ffmpeg-sidecar` builds and spawns it), fed `yuv420p` made from each frame by
/// the pipe thread ([`super::yuv`]: BT.601 limited range, ffmpeg's own default, at a tenth of
/// its conversion's CPU):
///
/// ```text
/// ffmpeg -hide_banner -nostats -loglevel level+warning
///        -f rawvideo -pix_fmt yuv420p -video_size WxH -framerate NUM/DEN -i -
///        -map 0:v:0 -an -sn -dn
///        -c:v libx264 -preset P [-x264opts K=V:…] -crf C -pix_fmt yuv420p -threads T
///        -bf 0 -g GOP -sc_threshold 0 -forced-idr 1 [-force_key_frames T1,T2,…]
///        -f mp4 -y DIR/.NAME.part
/// ```
///
/// - **Timing.** The frame rate is passed as an exact rational ([`Rational::from_f64`]), and the
///   raw demuxer stamps frame k with pts k in a 1/fps time base, so frame k is at exactly k/fps in
///   the output (mp4 track timescale = a multiple of the rate's numerator).
/// - **x264 options** go through `-x264opts`, not `-x264-params`: with `-x264opts` an option
///   x264 does not know, or a bad value, stops ffmpeg with x264's message (which the error
///   carries); `-x264-params` only warns and encodes without it.
/// - **No B-frames** (`-bf 0`): decode order = presentation order, so the same stream can go into
///   `foxglove_msgs/CompressedVideo` and a cut needs no reordering.
/// - **Keyframes.** `-g` bounds the distance between keyframes; `-sc_threshold 0` stops x264
///   adding its own at scene cuts (so keyframes sit only where asked, and at most every `-g`);
///   `-force_key_frames` lists a time for each requested frame index and `-forced-idr 1` makes
///   each an IDR frame. See [`force_key_frames_arg`] for how the times are chosen.
/// - **Never a file that looks complete unless it is.** ffmpeg writes a hidden `.NAME.part`
///   sibling. [`VideoEncoder::finish`] renames it to `NAME` only after ffmpeg exited 0, the file
///   was found to hold exactly the frames written and a keyframe at every requested index (an
///   MP4's sample tables read in-process, other containers probed by `ffprobe`), and the file was
///   synced to disk. Every error, [`VideoEncoder::abort`] and dropping an unfinished
///   encoder kill ffmpeg and delete the `.part` file.
/// - **Interruption.** ffmpeg runs in its own process group, so a terminal's Ctrl-C reaches only
///   autoact, which should stop rendering and drop (or abort) the encoder. If autoact dies
///   without unwinding, ffmpeg sees the end of its input and closes the `.part` file, which keeps
///   its `.part` name.
/// - **No deadlock.** Frames go through a small queue to a writer thread that owns ffmpeg's
///   stdin, and ffmpeg's stderr is drained by another thread, so neither pipe can block the
///   other; rendering continues while ffmpeg catches up. A write that fails because ffmpeg died
///   is reported as [`VideoError::Exited`] with ffmpeg's last stderr lines.
#[derive(Debug)]
pub struct VideoEncoder {
    ffmpeg: Ffmpeg,
    output: PathBuf,
    part: PathBuf,
    width: u32,
    height: u32,
    frame_bytes: usize,
    fps: Rational,
    keyframes: Vec<u64>,
    frames_written: u64,
    running: Option<Running>,
}

/// The live parts of an encoder.
struct Running {
    child: FfmpegChild,
    frames: SyncSender<Vec<u8>>,
    spare: Receiver<Vec<u8>>,
    writer: JoinHandle<std::io::Result<()>>,
    stderr: StderrTail,
}

impl std::fmt::Debug for Running {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // `FfmpegChild` has no `Debug`.
        f.debug_struct("Running")
            .field("writer_finished", &self.writer.is_finished())
            .finish_non_exhaustive()
    }
}

/// Whether x264 takes `preset` and `x264_options`: a two-frame 64×48 encode into `dir` (the
/// file removed after). Only x264 knows its options, and a job that records its settings before
/// its first long encode (`generate`'s journal) must not commit to ones that will fail.
///
/// # Errors
/// As [`VideoEncoder::start`] and [`VideoEncoder::finish`]: [`VideoError::InvalidSettings`]
/// for an unknown preset or options not shaped `key=value:…`, [`VideoError::Exited`] with
/// x264's message for an option or value it does not know.
pub fn check_x264(
    ffmpeg: &Ffmpeg,
    dir: &Path,
    preset: &str,
    x264_options: &str,
) -> Result<(), VideoError> {
    let settings = EncodeSettings {
        preset: preset.to_owned(),
        x264_options: x264_options.to_owned(),
        ..EncodeSettings::new(64, 48, 30.0)
    };
    let path = dir.join(".x264-check.mp4");
    let mut encoder = VideoEncoder::start(ffmpeg, &path, &settings)?;
    let frame = vec![0; settings.frame_bytes()];
    for _ in 0..2 {
        encoder.write_frame(&frame)?;
    }
    encoder.finish()?;
    std::fs::remove_file(&path).map_err(VideoError::io("remove", &path))
}

impl VideoEncoder {
    /// Checks `settings`, then starts ffmpeg writing `output` through the hidden sibling
    /// `.<name>.part` (renamed by [`VideoEncoder::finish`]). The container follows `output`'s
    /// extension: `.mp4`/`.m4v`, `.mov` or `.mkv`. An existing `output` stays untouched until
    /// the new file is complete, then is replaced.
    ///
    /// # Errors
    /// [`VideoError::InvalidSettings`] (odd or zero size, bad fps, crf > 51, unknown preset,
    /// gop 0, unknown extension, too many keyframes), [`VideoError::Io`] if `output`'s
    /// directory does not exist, [`VideoError::NotFound`] / [`VideoError::Spawn`] if ffmpeg
    /// cannot be started.
    pub fn start(
        ffmpeg: &Ffmpeg,
        output: &Path,
        settings: &EncodeSettings,
    ) -> Result<VideoEncoder, VideoError> {
        let plan = EncodePlan::check(output, settings)?;
        let mut command = encode_command(ffmpeg, settings, &plan);
        tracing::debug!(command = %command_line(&mut command), "starting ffmpeg");
        let mut child = command
            .spawn()
            .map_err(|source| spawn_error("ffmpeg", ffmpeg.ffmpeg_path(), source))?;
        let mut encoder = VideoEncoder {
            ffmpeg: ffmpeg.clone(),
            output: output.to_path_buf(),
            part: plan.part,
            width: settings.width,
            height: settings.height,
            frame_bytes: settings.frame_bytes(),
            fps: plan.fps,
            keyframes: sorted_keyframes(&settings.keyframes),
            frames_written: 0,
            running: None,
        };
        match start_threads(
            &mut child,
            settings.width as usize,
            settings.height as usize,
        ) {
            Ok((frames, spare, writer, stderr)) => {
                encoder.running = Some(Running {
                    child,
                    frames,
                    spare,
                    writer,
                    stderr,
                });
                Ok(encoder)
            }
            Err(source) => {
                // Dropping the pipes ends ffmpeg; kill it in case it is still starting.
                let _ = child.kill();
                let _ = child.wait();
                remove_part(&encoder.part);
                Err(VideoError::Spawn {
                    program: PathBuf::from("ffmpeg pipe thread"),
                    source,
                })
            }
        }
    }

    /// Queues one frame (`width × height × 3` bytes, rows top to bottom, `rgb24`). Returns as soon
    /// as the frame is queued; ffmpeg encodes it in the background.
    ///
    /// # Errors
    /// [`VideoError::FrameSize`] for a buffer of the wrong size, [`VideoError::Exited`] if ffmpeg
    /// died (possibly reported one call late), [`VideoError::Stopped`] after an earlier error.
    /// Every error stops the encoder: ffmpeg is ended and the `.part` file removed.
    pub fn write_frame(&mut self, rgb24: &[u8]) -> Result<(), VideoError> {
        let Some(running) = &self.running else {
            return Err(self.stopped());
        };
        if rgb24.len() != self.frame_bytes {
            return Err(self.frame_size_error(rgb24.len()));
        }
        let mut buffer = match running.spare.try_recv() {
            Ok(buffer) => buffer,
            Err(TryRecvError::Empty | TryRecvError::Disconnected) => {
                Vec::with_capacity(self.frame_bytes)
            }
        };
        buffer.clear();
        buffer.extend_from_slice(rgb24);
        self.send(buffer)
    }

    /// [`VideoEncoder::write_frame`] taking ownership of the buffer, saving a copy.
    ///
    /// # Errors
    /// As [`VideoEncoder::write_frame`].
    pub fn write_frame_owned(&mut self, rgb24: Vec<u8>) -> Result<(), VideoError> {
        if self.running.is_none() {
            return Err(self.stopped());
        }
        if rgb24.len() != self.frame_bytes {
            return Err(self.frame_size_error(rgb24.len()));
        }
        self.send(rgb24)
    }

    fn send(&mut self, buffer: Vec<u8>) -> Result<(), VideoError> {
        let Some(running) = &self.running else {
            return Err(self.stopped());
        };
        if running.frames.send(buffer).is_err() {
            // The writer thread ended: writing to ffmpeg failed.
            return Err(self.fail());
        }
        self.frames_written += 1;
        Ok(())
    }

    /// Frames queued so far.
    #[must_use]
    pub fn frames_written(&self) -> u64 {
        self.frames_written
    }

    /// The final path (the `.part` file becomes this on [`VideoEncoder::finish`]).
    #[must_use]
    pub fn output(&self) -> &Path {
        &self.output
    }

    /// The exact frame rate the video is encoded at.
    #[must_use]
    pub fn fps(&self) -> Rational {
        self.fps
    }

    /// Ends the input, waits for ffmpeg, checks the result and renames `.part` to the output.
    ///
    /// # Errors
    /// [`VideoError::Exited`] (ffmpeg failed; includes its stderr tail),
    /// [`VideoError::FrameCountMismatch`], [`VideoError::KeyframeMissing`],
    /// [`VideoError::Probe`], [`VideoError::Io`] (e.g. a full disk while syncing or renaming),
    /// [`VideoError::InvalidSettings`] if no frame was written, [`VideoError::Stopped`] after an
    /// earlier error. On every error the `.part` file is removed and no output is left.
    pub fn finish(mut self) -> Result<EncodedVideo, VideoError> {
        let Some(running) = self.running.take() else {
            return Err(self.stopped());
        };
        if self.frames_written == 0 {
            let _ = stop(running, true);
            remove_part(&self.part);
            return Err(VideoError::InvalidSettings {
                path: self.output.clone(),
                reason: InvalidSetting::NoFramesWritten,
            });
        }
        let result = self.complete(running);
        if result.is_err() {
            remove_part(&self.part);
        }
        result
    }

    /// The frames and the keyframes (as frame indices) the finished `.part` file holds: read
    /// from its sample tables when it is an MP4 that [`super::Mp4Source`] reads (no process;
    /// an `ffprobe` start costs about 0.12 s of CPU, paid per piece of a render), else counted by
    /// `ffprobe`.
    fn frames_and_keyframes(&self) -> Result<(u64, Vec<u64>), VideoError> {
        if super::Mp4Source::writes(&self.output)
            && let Some(mp4) = super::Mp4Source::open(&self.part)?
        {
            return Ok((mp4.frame_count(), mp4.keyframes()));
        }
        let packets = probe_packets(&self.ffmpeg, &self.part)?;
        let keyframes = (0_u64..)
            .zip(&packets)
            .filter(|(_, p)| p.key)
            .map(|(i, _)| i)
            .collect();
        Ok((packets.len() as u64, keyframes))
    }

    fn complete(&self, running: Running) -> Result<EncodedVideo, VideoError> {
        let (status, written, stderr_tail) = stop(running, false);
        let status = status.map_err(|source| VideoError::Io {
            action: "wait for ffmpeg writing",
            path: self.part.clone(),
            source,
        })?;
        if !status.success() {
            return Err(VideoError::Exited {
                program: "ffmpeg",
                status,
                path: self.output.clone(),
                stderr_tail,
            });
        }
        written.map_err(|source| VideoError::Io {
            action: "pipe frames to ffmpeg for",
            path: self.output.clone(),
            source,
        })?;

        let (found, keyframes) = self.frames_and_keyframes()?;
        if found != self.frames_written {
            return Err(VideoError::FrameCountMismatch {
                path: self.output.clone(),
                written: self.frames_written,
                found,
            });
        }
        if let Some(&frame) = self
            .keyframes
            .iter()
            .filter(|&&k| k < found)
            .find(|k| keyframes.binary_search(k).is_err())
        {
            return Err(VideoError::KeyframeMissing {
                path: self.output.clone(),
                frame,
            });
        }

        let io = VideoError::io;
        crate::atomic_file::commit(&self.part, &self.output)
            .map_err(io("sync and rename into place", &self.output))?;
        let bytes = std::fs::metadata(&self.output)
            .map_err(io("read the size of", &self.output))?
            .len();
        tracing::debug!(
            path = %self.output.display(),
            frames = found,
            bytes,
            "video written"
        );
        Ok(EncodedVideo {
            path: self.output.clone(),
            frame_count: found,
            bytes,
            fps: self.fps,
            keyframes,
        })
    }

    /// Kills ffmpeg and removes the partial file. Dropping an unfinished encoder does the same.
    pub fn abort(mut self) {
        self.teardown();
    }

    fn teardown(&mut self) {
        if let Some(running) = self.running.take() {
            let _ = stop(running, true);
            remove_part(&self.part);
            tracing::debug!(path = %self.output.display(), "video encoding aborted");
        }
    }

    /// Stops after a failed write: collects ffmpeg's status and stderr, removes the `.part` file.
    fn fail(&mut self) -> VideoError {
        let Some(running) = self.running.take() else {
            return self.stopped();
        };
        let (status, written, stderr_tail) = stop(running, false);
        remove_part(&self.part);
        match (status, written) {
            (Ok(status), _) if !status.success() => VideoError::Exited {
                program: "ffmpeg",
                status,
                path: self.output.clone(),
                stderr_tail,
            },
            (_, Err(source)) | (Err(source), Ok(())) => VideoError::Io {
                action: "pipe frames to ffmpeg for",
                path: self.output.clone(),
                source,
            },
            (Ok(_), Ok(())) => VideoError::Io {
                action: "pipe frames to ffmpeg for",
                path: self.output.clone(),
                source: std::io::Error::other("ffmpeg stopped reading frames"),
            },
        }
    }

    fn frame_size_error(&mut self, got: usize) -> VideoError {
        self.teardown();
        VideoError::FrameSize {
            path: self.output.clone(),
            frame: self.frames_written,
            width: self.width,
            height: self.height,
            expected: self.frame_bytes,
            got,
        }
    }

    fn stopped(&self) -> VideoError {
        VideoError::Stopped {
            path: self.output.clone(),
        }
    }
}

impl Drop for VideoEncoder {
    fn drop(&mut self) {
        self.teardown();
    }
}

/// What [`VideoEncoder::start`] derives from its settings before starting ffmpeg.
struct EncodePlan {
    /// The exact frame rate.
    fps: Rational,
    /// ffmpeg's name of the container.
    container: &'static str,
    /// The `-force_key_frames` value, if frames other than 0 must be keyframes.
    keyframe_arg: Option<String>,
    /// The hidden sibling ffmpeg writes.
    part: PathBuf,
}

impl EncodePlan {
    /// Checks `settings` and `output` (an existing folder, a known extension).
    fn check(output: &Path, settings: &EncodeSettings) -> Result<EncodePlan, VideoError> {
        let invalid = |reason: InvalidSetting| VideoError::InvalidSettings {
            path: output.to_path_buf(),
            reason,
        };
        let fps = validate(settings).map_err(invalid)?;
        let container = container_for(output).map_err(invalid)?;
        let keyframe_arg = match force_key_frames_arg(&settings.keyframes, fps) {
            Some(arg) if arg.len() > MAX_KEYFRAME_ARG_BYTES => {
                return Err(invalid(InvalidSetting::TooManyKeyframes {
                    keyframes: settings.keyframes.len(),
                    arg_bytes: arg.len(),
                    max_bytes: MAX_KEYFRAME_ARG_BYTES,
                }));
            }
            Some(arg) => Some(arg),
            None if settings.keyframes.iter().any(|&k| k > 0) => {
                return Err(invalid(InvalidSetting::KeyframeTimes { fps }));
            }
            None => None,
        };
        let part = crate::atomic_file::temporary_sibling(output)
            .ok_or_else(|| invalid(InvalidSetting::NoFileName))?;
        let dir = part.parent().unwrap_or(Path::new("."));
        if !dir.as_os_str().is_empty() && !dir.is_dir() {
            return Err(VideoError::Io {
                action: "write a video into",
                path: dir.to_path_buf(),
                source: std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    "the directory does not exist",
                ),
            });
        }
        Ok(EncodePlan {
            fps,
            container,
            keyframe_arg,
            part,
        })
    }
}

/// The ffmpeg command encoding raw frames as `settings` and `plan` say (in its own process
/// group, so a terminal's Ctrl-C reaches only autoact).
fn encode_command(ffmpeg: &Ffmpeg, settings: &EncodeSettings, plan: &EncodePlan) -> FfmpegCommand {
    let mut command = FfmpegCommand::new_with_path(ffmpeg.ffmpeg_path());
    command
        .hide_banner()
        // ffmpeg-sidecar put `-loglevel level+info` first; the last `-loglevel` wins.
        .args(["-nostats", "-loglevel", "level+warning"])
        .format("rawvideo")
        .pix_fmt("yuv420p")
        .args([
            "-video_size".to_owned(),
            format!("{}x{}", settings.width, settings.height),
            "-framerate".to_owned(),
            plan.fps.to_string(),
        ])
        .input("-")
        .args(["-map", "0:v:0", "-an", "-sn", "-dn"])
        .codec_video("libx264")
        .preset(&settings.preset);
    if !settings.x264_options.is_empty() {
        command.args(["-x264opts", &settings.x264_options]);
    }
    command
        .crf(u32::from(settings.crf))
        .pix_fmt("yuv420p")
        .args([
            "-threads".to_owned(),
            settings.threads.to_string(),
            "-bf".to_owned(),
            "0".to_owned(),
            "-g".to_owned(),
            settings.gop_frames.to_string(),
            "-sc_threshold".to_owned(),
            "0".to_owned(),
            "-forced-idr".to_owned(),
            "1".to_owned(),
        ]);
    if let Some(arg) = &plan.keyframe_arg {
        command.args(["-force_key_frames", arg]);
    }
    command
        .format(plan.container)
        .overwrite()
        .output(plan.part.as_os_str());
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        command.as_inner_mut().process_group(0);
    }
    command
}

type Threads = (
    SyncSender<Vec<u8>>,
    Receiver<Vec<u8>>,
    JoinHandle<std::io::Result<()>>,
    StderrTail,
);

fn start_threads(child: &mut FfmpegChild, width: usize, height: usize) -> std::io::Result<Threads> {
    let missing = |what| std::io::Error::other(format!("ffmpeg's {what} was not piped"));
    let stdin = child.take_stdin().ok_or_else(|| missing("stdin"))?;
    let stderr = child.take_stderr().ok_or_else(|| missing("stderr"))?;
    // ffmpeg writes nothing to stdout when writing a file; close our end.
    drop(child.take_stdout());
    let stderr = StderrTail::spawn("ffmpeg-stderr", stderr)?;
    let (frames_tx, frames_rx) = std::sync::mpsc::sync_channel::<Vec<u8>>(QUEUE_FRAMES);
    let (spare_tx, spare_rx) = std::sync::mpsc::sync_channel::<Vec<u8>>(QUEUE_FRAMES + 1);
    let writer = std::thread::Builder::new()
        .name("ffmpeg-stdin".into())
        .spawn(move || write_frames(stdin, width, height, &frames_rx, &spare_tx))?;
    Ok((frames_tx, spare_rx, writer, stderr))
}

/// The writer thread: `rgb24` frames from the queue to ffmpeg's stdin as `yuv420p`, buffers
/// back for reuse. Ends (closing stdin, which tells ffmpeg the input is over) when the queue is
/// closed or a write fails.
fn write_frames(
    mut stdin: ChildStdin,
    width: usize,
    height: usize,
    frames: &Receiver<Vec<u8>>,
    spare: &SyncSender<Vec<u8>>,
) -> std::io::Result<()> {
    let mut yuv = Vec::with_capacity(super::yuv::yuv420p_bytes(width, height));
    for frame in frames {
        super::yuv::yuv420p_from_rgb24(width, height, &frame, &mut yuv);
        stdin.write_all(&yuv)?;
        // A full spare queue just drops the buffer.
        let _ = spare.try_send(frame);
    }
    stdin.flush()
}

/// Closes the input (and kills ffmpeg if `kill`), then waits for everything. Returns ffmpeg's
/// exit status, the writer thread's result and the stderr tail.
fn stop(
    running: Running,
    kill: bool,
) -> (
    std::io::Result<std::process::ExitStatus>,
    std::io::Result<()>,
    String,
) {
    let Running {
        mut child,
        frames,
        spare,
        writer,
        stderr,
    } = running;
    drop(frames);
    drop(spare);
    if kill {
        // A writer blocked on a full pipe gets EPIPE once ffmpeg is gone.
        let _ = child.kill();
    }
    let written = writer
        .join()
        .unwrap_or_else(|_| Err(std::io::Error::other("the frame writer thread failed")));
    let status = child.wait();
    let tail = stderr.join();
    (status, written, tail)
}

pub(super) fn remove_part(part: &Path) {
    match std::fs::remove_file(part) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => tracing::warn!(
            path = %part.display(),
            error = %e,
            "cannot remove the partial video; delete it by hand"
        ),
    }
}

/// The exact frame rate of `settings`, or which setting cannot be used.
fn validate(settings: &EncodeSettings) -> Result<Rational, InvalidSetting> {
    let EncodeSettings {
        width,
        height,
        fps,
        crf,
        preset,
        x264_options,
        gop_frames,
        threads,
        ..
    } = settings;
    let (width, height) = (*width, *height);
    if width < 2 || height < 2 || width % 2 != 0 || height % 2 != 0 {
        return Err(InvalidSetting::FrameSize { width, height });
    }
    if width > MAX_SIDE_PX || height > MAX_SIDE_PX {
        return Err(InvalidSetting::FrameTooLarge {
            width,
            height,
            max_side_px: MAX_SIDE_PX,
        });
    }
    let rate = Rational::from_f64(*fps)
        .filter(|r| r.as_f64() <= 10_000.0)
        .ok_or(InvalidSetting::Fps { fps: *fps })?;
    if *crf > 51 {
        return Err(InvalidSetting::Crf { crf: *crf });
    }
    if !PRESETS.contains(&preset.as_str()) {
        return Err(InvalidSetting::Preset {
            preset: preset.clone(),
            known: &PRESETS,
        });
    }
    if !x264_options.is_empty()
        && x264_options.split(':').any(|pair| {
            pair.is_empty() || pair.contains(|c: char| c.is_whitespace() || c.is_control())
        })
    {
        return Err(InvalidSetting::X264Options {
            options: x264_options.clone(),
        });
    }
    if *gop_frames == 0 {
        return Err(InvalidSetting::GopZero);
    }
    if !(1..=MAX_ENCODER_THREADS).contains(threads) {
        return Err(InvalidSetting::Threads { threads: *threads });
    }
    Ok(rate)
}

/// ffmpeg's name of the container `output`'s extension asks for.
pub(super) fn container_for(output: &Path) -> Result<&'static str, InvalidSetting> {
    let ext = output
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("mp4" | "m4v") => Ok("mp4"),
        Some("mov") => Ok("mov"),
        Some("mkv") => Ok("matroska"),
        _ => Err(InvalidSetting::Extension {
            extension: output.extension().map(|e| e.to_string_lossy().into_owned()),
        }),
    }
}

fn sorted_keyframes(keyframes: &[u64]) -> Vec<u64> {
    let mut frames = keyframes.to_vec();
    frames.sort_unstable();
    frames.dedup();
    frames
}

fn command_line(command: &mut FfmpegCommand) -> String {
    let inner = command.as_inner();
    std::iter::once(inner.get_program())
        .chain(inner.get_args())
        .map(|a| a.to_string_lossy().into_owned())
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::{
        DEFAULT_ENCODER_THREADS, EncodePlan, EncodeSettings, MAX_ENCODER_THREADS, container_for,
        encode_command, force_key_frames_arg, keyframe_time, validate,
    };
    use crate::video::InvalidSetting;
    use crate::video::Rational;

    fn rate(num: i64, den: i64) -> Rational {
        Rational::new(num, den).unwrap()
    }

    /// The time must key frame k under both ffmpeg rules: rounds to k, and lies in
    /// ((k-1)/fps, k/fps].
    fn check_window(k: u64, fps: Rational, t: &str) {
        let t: f64 = t.parse().unwrap();
        let frames = t * fps.as_f64();
        #[expect(clippy::cast_precision_loss, reason = "test values are small")]
        let k_f = k as f64;
        assert!(
            frames > k_f - 0.5 && frames <= k_f + 1e-9,
            "k={k} t={t} → {frames}"
        );
    }

    #[test]
    fn keyframe_times_fall_in_the_exact_window() {
        for fps in [
            rate(30, 1),
            rate(2997, 100),
            rate(30000, 1001),
            rate(25, 1),
            rate(60, 1),
        ] {
            for k in (1..5000)
                .step_by(7)
                .chain([1, 2, 37, 38, 90, 151, 199, 999_999])
            {
                let t = keyframe_time(k, fps).unwrap();
                check_window(k, fps, &t);
            }
        }
        assert_eq!(keyframe_time(30, rate(30, 1)).unwrap(), "1");
        assert_eq!(keyframe_time(37, rate(30, 1)).unwrap(), "1.23");
        assert_eq!(keyframe_time(1, rate(30, 1)).unwrap(), "0.03");
    }

    #[test]
    fn keyframe_list_is_sorted_deduplicated_and_skips_frame_zero() {
        let arg = force_key_frames_arg(&[90, 0, 37, 38, 37], rate(30, 1)).unwrap();
        assert_eq!(arg, "1.23,1.26,3");
        assert_eq!(force_key_frames_arg(&[0], rate(30, 1)), None);
        assert_eq!(force_key_frames_arg(&[], rate(30, 1)), None);
    }

    #[test]
    fn thousands_of_keyframes_stay_compact() {
        let frames: Vec<u64> = (1..=10_000).map(|i| i * 30).collect();
        let arg = force_key_frames_arg(&frames, rate(30000, 1001)).unwrap();
        assert!(arg.len() < 100_000, "{}", arg.len());
    }

    #[test]
    fn too_many_keyframes_are_refused_before_starting_ffmpeg() {
        let dir = tempfile::tempdir().unwrap();
        let ffmpeg =
            crate::video::Ffmpeg::from_paths("/nonexistent/ffmpeg", "/nonexistent/ffprobe");
        let settings = EncodeSettings::new(64, 48, 30000.0 / 1001.0).with_keyframes(1..40_000);
        let err =
            super::VideoEncoder::start(&ffmpeg, &dir.path().join("a.mp4"), &settings).unwrap_err();
        assert!(
            matches!(err, crate::video::VideoError::InvalidSettings { .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains("split the video"), "{err}");
    }

    #[test]
    fn invalid_settings_name_the_setting_and_say_what_would_do() {
        let slow = EncodeSettings {
            preset: "ludicrous".into(),
            ..EncodeSettings::new(320, 240, 30.0)
        };
        assert_eq!(
            validate(&slow).unwrap_err().to_string(),
            "unknown preset `ludicrous`; use one of ultrafast, superfast, veryfast, faster, fast, \
             medium, slow, slower, veryslow, placebo"
        );
        assert_eq!(
            validate(&EncodeSettings::new(321, 240, 30.0)),
            Err(InvalidSetting::FrameSize {
                width: 321,
                height: 240
            })
        );
        assert_eq!(
            validate(&EncodeSettings::new(320, 240, -1.0)),
            Err(InvalidSetting::Fps { fps: -1.0 })
        );
        assert_eq!(
            container_for(std::path::Path::new("out"))
                .unwrap_err()
                .to_string(),
            "unsupported file extension `(none)`; use `.mp4`, `.mov` or `.mkv`"
        );
        assert_eq!(
            container_for(std::path::Path::new("out.AVI")),
            Err(InvalidSetting::Extension {
                extension: Some("AVI".into())
            })
        );
        assert_eq!(
            container_for(std::path::Path::new("out.MKV")),
            Ok("matroska")
        );
    }

    #[test]
    fn settings_are_checked() {
        let ok = EncodeSettings::new(320, 240, 30.0);
        assert_eq!(validate(&ok).unwrap(), rate(30, 1));
        assert_eq!(ok.gop_frames, 60);
        for bad in [
            EncodeSettings::new(321, 240, 30.0),
            EncodeSettings::new(0, 240, 30.0),
            EncodeSettings::new(320, 240, 0.0),
            EncodeSettings::new(320, 240, f64::NAN),
            EncodeSettings {
                crf: 52,
                ..ok.clone()
            },
            EncodeSettings {
                preset: "ludicrous".into(),
                ..ok.clone()
            },
            EncodeSettings {
                gop_frames: 0,
                ..ok.clone()
            },
            EncodeSettings {
                threads: 0,
                ..ok.clone()
            },
            EncodeSettings {
                threads: MAX_ENCODER_THREADS + 1,
                ..ok.clone()
            },
        ] {
            assert!(validate(&bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn x264_gets_the_thread_count_asked_not_the_machines() {
        // x264's output depends on its thread count, and left alone it takes 1.5 × the cores.
        let dir = tempfile::tempdir().unwrap();
        let ffmpeg = crate::video::Ffmpeg::from_paths("ffmpeg", "ffprobe");
        let output = dir.path().join("a.mp4");
        for threads in [DEFAULT_ENCODER_THREADS, 3] {
            let settings = EncodeSettings {
                threads,
                ..EncodeSettings::new(64, 48, 30.0)
            };
            let plan = EncodePlan::check(&output, &settings).unwrap();
            let mut command = encode_command(&ffmpeg, &settings, &plan);
            let args: Vec<String> = command
                .as_inner_mut()
                .get_args()
                .map(|a| a.to_string_lossy().into_owned())
                .collect();
            let at = args.iter().position(|a| a == "-threads").expect("-threads");
            assert_eq!(args[at + 1], threads.to_string(), "{args:?}");
            assert!(
                at > args.iter().position(|a| a == "-i").unwrap(),
                "an output option: {args:?}"
            );
        }
        assert_eq!(
            validate(&EncodeSettings {
                threads: 0,
                ..EncodeSettings::new(64, 48, 30.0)
            })
            .unwrap_err()
            .to_string(),
            "0 encoder threads; use 1 to 64"
        );
    }
}
