//! Render bags: what `autoact render` writes beside a video (`<video stem>.render.mcap`), and
//! what `autoact trim` reads to place that video on its capture's timeline.
//!
//! - `/render/video` — `autoact_msgs/VideoInfo`, once: the capture session and bag rendered, the
//!   video file, its rate, size, frame count, forced keyframes and encoder settings; its stamp is
//!   the timeline instant of video frame 0 — of timeline frame 0 when the render drew only some
//!   frames (its `settings_json` then has [`TIMELINE_FRAMES_KEY`], see [`DrawnFrames`]);
//! - `/render/annotations` — `autoact_msgs/FrameAnnotation` per video frame, in order: 2D and 3D
//!   joints, visibility, the bounding box and the segment the frame belongs to; its `frame_index`
//!   is the frame's place on the render's timeline (the video's own index when every frame is
//!   drawn);
//! - `/render/camera/h264` — `foxglove_msgs/CompressedVideo` per frame (optional,
//!   `--embed-video`, or `--embed-video=both`): the encoded stream itself, so Foxglove plays it
//!   beside the skeleton;
//! - `/render/camera/image/h264` — `sensor_msgs/CompressedImage` with format `h264` per frame
//!   (optional, `--embed-video=rerun` or `=both`): the same access units, which Rerun plays (it
//!   has no decoder for `foxglove_msgs/CompressedVideo` in ROS 2 bags; Foxglove's image panel
//!   reads `CompressedImage` only as jpeg, png, webp or avif, so it is not the default).
//!
//! The bag is written under a temporary name and renamed when complete.

use std::path::{Path, PathBuf};

use crate::bags::capture::Capture;
use crate::mcap_io::{BagReader, BagWriter, FileSink, McapIoError, WriteConfig};
use crate::ros::autoact_msgs::{FrameAnnotation, VideoInfo};
use crate::ros::foxglove_msgs::CompressedVideo;
use crate::ros::sensor_msgs::CompressedImage;
use crate::ros::std_msgs::Header;
use crate::ros::{RosMessage, cdr};
use crate::video::Rational;

/// Topic of the video description in the render bag.
pub const VIDEO_TOPIC: &str = "/render/video";
/// Topic of the per-frame annotations.
pub const ANNOTATIONS_TOPIC: &str = "/render/annotations";
/// Topic of the embedded H.264 stream (`--embed-video`).
pub const EMBEDDED_VIDEO_TOPIC: &str = "/render/camera/h264";
/// Topic of the embedded H.264 stream as `sensor_msgs/CompressedImage` (`--embed-video=rerun`).
pub const EMBEDDED_IMAGE_TOPIC: &str = "/render/camera/image/h264";

/// Which viewer's message the render bag embeds the encoded video as. Each is the whole stream
/// again, so `Both` nearly doubles the bag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum EmbedVideo {
    /// `foxglove_msgs/CompressedVideo` on `/render/camera/h264`: Foxglove plays it.
    #[default]
    Foxglove,
    /// `sensor_msgs/CompressedImage` (format `h264`) on `/render/camera/image/h264`: Rerun
    /// plays it.
    Rerun,
    /// Both messages: the stream twice, so about twice the bag's bytes.
    Both,
}

impl EmbedVideo {
    /// Whether the bag gets `foxglove_msgs/CompressedVideo`.
    #[must_use]
    pub fn foxglove(self) -> bool {
        matches!(self, EmbedVideo::Foxglove | EmbedVideo::Both)
    }

    /// Whether the bag gets `sensor_msgs/CompressedImage` frames of format `h264`.
    #[must_use]
    pub fn rerun(self) -> bool {
        matches!(self, EmbedVideo::Rerun | EmbedVideo::Both)
    }
}

/// Where `autoact render` puts the render bag of `video` unless told otherwise:
/// `<video stem>.render.mcap` beside it. `autoact trim` looks there.
#[must_use]
pub fn render_bag_beside(video: &Path) -> PathBuf {
    video.with_extension("render.mcap")
}

/// Where `autoact render --depth` puts the depth pass of `video` (one 16-bit PNG per frame,
/// millimetres): the folder `<video stem>.depth` beside it. `autoact trim` looks there.
#[must_use]
pub fn depth_dir_beside(video: &Path) -> PathBuf {
    video.with_extension("depth")
}

/// Where `autoact render --masks` puts the instance mask pass of `video` (one 8-bit PNG per
/// frame): the folder `<video stem>.mask` beside it. `autoact trim` looks there.
#[must_use]
pub fn mask_dir_beside(video: &Path) -> PathBuf {
    video.with_extension("mask")
}

/// The file of video frame `k` in a folder of one image per frame (`--frames-out`, the depth
/// and mask passes): `frame_000000.png`, ….
#[must_use]
pub fn frame_file(dir: &Path, k: u64) -> PathBuf {
    dir.join(format!("frame_{k:06}.png"))
}

/// Why a render bag could not be written or read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderBagError {
    /// Writing or reading the MCAP failed.
    #[error(transparent)]
    Bag(#[from] McapIoError),
    /// Part of the bag could not be read.
    #[error(transparent)]
    Read(#[from] crate::mcap_io::ReadIssue),
    /// The bag's path has no file name to put a temporary sibling beside.
    #[error("render bag `{0}`: not a file name")]
    NotAFile(PathBuf),
    /// The finished bag could not be synced and renamed into place.
    #[error("cannot sync and rename the render bag into `{path}`")]
    Commit {
        /// The render bag.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// A `/render/video` message could not be decoded.
    #[error("render bag `{path}`: {VIDEO_TOPIC} cannot be decoded")]
    Decode {
        /// The render bag.
        path: PathBuf,
        /// The cause.
        #[source]
        source: cdr::CdrError,
    },
    /// The video's frame rate cannot be used.
    #[error("render bag `{path}`: {VIDEO_TOPIC}: frame rate {fps} is not usable")]
    FrameRate {
        /// The render bag.
        path: PathBuf,
        /// The rate it states.
        fps: f64,
    },
    /// The bag holds no video description.
    #[error("render bag `{0}`: no `{VIDEO_TOPIC}` message ({ty})", ty = VideoInfo::TYPE_NAME)]
    NoVideoInfo(PathBuf),
    /// A render that drew only some frames does not say which, one annotation per video frame
    /// ([`DrawnFrames`]).
    #[error("render bag `{path}`: {detail}")]
    DrawnFrames {
        /// The render bag.
        path: PathBuf,
        /// What is wrong.
        detail: String,
    },
    /// The bag is a render of another capture session.
    #[error(
        "render bag `{bag}` is a render of capture session `{rendered}` (capture bag `{rendered_bag}`), but `{capture_bag}` holds session `{session}`: pass the capture bag that was rendered, or the right `--render-bag`"
    )]
    OtherSession {
        /// The render bag.
        bag: PathBuf,
        /// The session it rendered.
        rendered: String,
        /// The capture bag it rendered (file name).
        rendered_bag: String,
        /// The capture bag given.
        capture_bag: PathBuf,
        /// Its session.
        session: String,
    },
}

/// Decodes a `/render/annotations` message into `place`. A message from a render bag written
/// before the landmark fields were added (its payload ends after `silhouette_pixels`) decodes
/// too, with no landmarks: those four sequences are the message's last fields, so the old payload
/// plus four zero lengths is the same message with them empty.
///
/// # Errors
/// [`cdr::CdrError`] when the payload is neither.
pub fn decode_annotation(payload: &[u8], place: &mut FrameAnnotation) -> Result<(), cdr::CdrError> {
    match cdr::decode_in_place(payload, place) {
        Ok(()) => Ok(()),
        Err(e) => {
            let mut padded = Vec::with_capacity(payload.len() + 16);
            padded.extend_from_slice(payload);
            padded.extend_from_slice(&[0; 16]);
            cdr::decode_in_place(&padded, place).map_err(|_| e)
        }
    }
}

/// One video frame's messages.
#[derive(Debug, Clone)]
pub struct RenderedFrame {
    /// Timeline stamp, nanoseconds (the messages' log time).
    pub stamp_nanos: u64,
    /// Its labels.
    pub annotation: FrameAnnotation,
    /// Its encoded access unit, when the video is embedded.
    pub video: Option<CompressedVideo>,
}

/// Writes the render bag `path`: `info` at `info_stamp_nanos`, then every frame, its access unit
/// (where it has one) as `embed` says, under a temporary name renamed into place when complete
/// (removed on failure).
///
/// # Errors
/// [`RenderBagError`] naming the bag.
pub fn write(
    path: &Path,
    info_stamp_nanos: u64,
    info: &VideoInfo,
    frames: impl IntoIterator<Item = RenderedFrame>,
    embed: EmbedVideo,
) -> Result<(), RenderBagError> {
    let mut w = RenderBagWriter::create(path, info_stamp_nanos, info)?;
    for frame in frames {
        w.annotation(frame.stamp_nanos, &frame.annotation)?;
        if let Some(video) = &frame.video {
            w.video(frame.stamp_nanos, video, embed)?;
        }
    }
    w.finish()
}

/// A render bag written message by message while the frames are rendered, so that no frame's
/// labels are held until the end: the video's description first, then each frame's annotation
/// as it comes (and access units, where embedded). The bag is written under a temporary name,
/// renamed into place by [`RenderBagWriter::finish`]; dropped unfinished, it removes that file.
pub struct RenderBagWriter {
    path: PathBuf,
    part: PathBuf,
    writer: Option<BagWriter<FileSink>>,
    image: CompressedImage,
}

impl std::fmt::Debug for RenderBagWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RenderBagWriter")
            .field("path", &self.path)
            .finish_non_exhaustive()
    }
}

impl RenderBagWriter {
    /// Starts the bag at `path` with the video's description `info`.
    ///
    /// # Errors
    /// [`RenderBagError`] naming the bag.
    pub fn create(
        path: &Path,
        info_stamp_nanos: u64,
        info: &VideoInfo,
    ) -> Result<RenderBagWriter, RenderBagError> {
        let part = crate::atomic_file::temporary_sibling(path)
            .ok_or_else(|| RenderBagError::NotAFile(path.to_path_buf()))?;
        let mut bag = RenderBagWriter {
            path: path.to_path_buf(),
            writer: Some(BagWriter::create(&part, WriteConfig::default())?),
            part,
            image: CompressedImage::default(),
        };
        bag.writer_mut()?
            .write(VIDEO_TOPIC, info_stamp_nanos, info)?;
        Ok(bag)
    }

    fn writer_mut(&mut self) -> Result<&mut BagWriter<FileSink>, RenderBagError> {
        self.writer
            .as_mut()
            .ok_or_else(|| RenderBagError::NotAFile(self.path.clone()))
    }

    /// Writes one frame's labels.
    ///
    /// # Errors
    /// [`RenderBagError`] naming the bag.
    pub fn annotation(
        &mut self,
        stamp_nanos: u64,
        annotation: &FrameAnnotation,
    ) -> Result<(), RenderBagError> {
        self.writer_mut()?
            .write(ANNOTATIONS_TOPIC, stamp_nanos, annotation)?;
        Ok(())
    }

    /// Writes one frame's access unit on the topics `embed` asks for.
    ///
    /// # Errors
    /// [`RenderBagError`] naming the bag.
    pub fn video(
        &mut self,
        stamp_nanos: u64,
        video: &CompressedVideo,
        embed: EmbedVideo,
    ) -> Result<(), RenderBagError> {
        let mut image = std::mem::take(&mut self.image);
        let w = self.writer_mut()?;
        if embed.foxglove() {
            w.write(EMBEDDED_VIDEO_TOPIC, stamp_nanos, video)?;
        }
        if embed.rerun() {
            set_image(&mut image, video);
            w.write(EMBEDDED_IMAGE_TOPIC, stamp_nanos, &image)?;
        }
        self.image = image;
        Ok(())
    }

    /// Ends the bag, syncs it and renames it into place.
    ///
    /// # Errors
    /// [`RenderBagError`] naming the bag; the temporary file is removed.
    pub fn finish(mut self) -> Result<(), RenderBagError> {
        let writer = self
            .writer
            .take()
            .ok_or_else(|| RenderBagError::NotAFile(self.path.clone()))?;
        let result = writer
            .finish()
            .map(|_| ())
            .map_err(RenderBagError::from)
            .and_then(|()| {
                crate::atomic_file::commit(&self.part, &self.path).map_err(|source| {
                    RenderBagError::Commit {
                        path: self.path.clone(),
                        source,
                    }
                })
            });
        if result.is_err() {
            let _ = std::fs::remove_file(&self.part);
        }
        result
    }
}

impl Drop for RenderBagWriter {
    fn drop(&mut self) {
        if self.writer.take().is_some() {
            let _ = std::fs::remove_file(&self.part);
        }
    }
}

/// Makes `image` the `sensor_msgs/CompressedImage` of `video`'s access unit: the same stamp,
/// frame and bytes, format `h264` (what Rerun reads as a video stream).
fn set_image(image: &mut CompressedImage, video: &CompressedVideo) {
    image.header = Header {
        stamp: video.timestamp,
        frame_id: video.frame_id.clone(),
    };
    image.format.clone_from(&video.format);
    image.data.clear();
    image.data.extend_from_slice(&video.data);
}

/// What the render bag says of the video it describes.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedVideo {
    /// The render bag read.
    pub bag: PathBuf,
    /// Timeline stamp of the video's frame 0, nanoseconds.
    pub frame0_nanos: i128,
    /// Its frame rate.
    pub fps: Rational,
    /// The capture session rendered.
    pub session: String,
    /// The capture bag rendered (its file name).
    pub capture_bag: String,
    /// The video's file name.
    pub video_file: String,
    /// The timeline frames the video holds, when the render drew only some (`None`: every
    /// frame, video frame `k` is timeline frame `k`).
    pub drawn: Option<DrawnFrames>,
}

/// `settings_json` key of a render that drew only some frames of its timeline (`generate`
/// without `--keep-intermediates` draws only the frames some clip uses): the frames of the whole
/// timeline.
pub const TIMELINE_FRAMES_KEY: &str = "timeline_frames";

/// Which frames of its timeline a render's video holds, when the render drew only some: video
/// frame `k` shows timeline frame `frames[k]` (frame `j` of the timeline being at `VideoInfo`'s
/// stamp + `j / fps`, the frame a render of every frame has at `k = j`). The table is the render
/// bag's own: the `frame_index` of its `k`-th `/render/annotations` message, one per video frame,
/// with `VideoInfo`'s `settings_json` giving the timeline's length ([`TIMELINE_FRAMES_KEY`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DrawnFrames {
    /// Frames of the whole timeline.
    pub timeline_frames: u64,
    /// The timeline frame of each video frame, strictly increasing.
    pub frames: Vec<u64>,
}

impl DrawnFrames {
    /// The video frame of timeline frames `start .. start + count`, when the video holds them
    /// all, one after the other; else the first of them it does not hold.
    ///
    /// # Errors
    /// The first timeline frame of the range that the video does not hold.
    pub fn video_start(&self, start: u64, count: u64) -> Result<u64, u64> {
        let Ok(first) = self.frames.binary_search(&start) else {
            return Err(start);
        };
        for i in 1..count {
            // Strictly increasing: frame `start + i` is held iff it is right after `start + i - 1`.
            if self.frames.get(first + i as usize) != Some(&(start + i)) {
                return Err(start + i);
            }
        }
        Ok(first as u64)
    }

    /// The table of render bag `bag`, whose `VideoInfo` says `video_frames` frames of a
    /// `timeline_frames`-frame timeline.
    fn read(bag: &Path, timeline_frames: u64, video_frames: u64) -> Result<Self, RenderBagError> {
        let bad = |detail: String| RenderBagError::DrawnFrames {
            path: bag.to_path_buf(),
            detail,
        };
        let mut frames = Vec::new();
        let mut annotation = FrameAnnotation::default();
        for m in BagReader::open_all(bag)?
            .iter()
            .flat_map(BagReader::messages)
        {
            let m = m?;
            if m.channel.topic != ANNOTATIONS_TOPIC {
                continue;
            }
            decode_annotation(&m.data, &mut annotation)
                .map_err(|e| bad(format!("{ANNOTATIONS_TOPIC} message {}: {e}", frames.len())))?;
            let k = annotation.frame_index;
            if frames.last().is_some_and(|&last| k <= last) || k >= timeline_frames {
                return Err(bad(format!(
                    "{ANNOTATIONS_TOPIC} message {} is of timeline frame {k}: not after the one \
                     before, or past the timeline's {timeline_frames} frames",
                    frames.len()
                )));
            }
            frames.push(k);
        }
        if frames.len() as u64 != video_frames {
            return Err(bad(format!(
                "{} {ANNOTATIONS_TOPIC} messages for a video of {video_frames} frames: which \
                 timeline frames the video holds cannot be told",
                frames.len()
            )));
        }
        Ok(DrawnFrames {
            timeline_frames,
            frames,
        })
    }
}

impl RenderedVideo {
    /// Reads the `VideoInfo` of render bag `bag`.
    ///
    /// # Errors
    /// [`RenderBagError`] naming the bag when it cannot be read or has no `VideoInfo`.
    pub fn read(bag: &Path) -> Result<RenderedVideo, RenderBagError> {
        let readers = BagReader::open_all(bag)?;
        for m in readers.iter().flat_map(|r| r.messages()) {
            let m = m?;
            if m.channel.topic == VIDEO_TOPIC && m.channel.schema_name() == VideoInfo::TYPE_NAME {
                let info: VideoInfo =
                    cdr::decode(&m.data).map_err(|source| RenderBagError::Decode {
                        path: bag.to_path_buf(),
                        source,
                    })?;
                let fps = Rational::from_f64(info.fps).ok_or(RenderBagError::FrameRate {
                    path: bag.to_path_buf(),
                    fps: info.fps,
                })?;
                let stamp = info.header.stamp.to_nanos().unwrap_or(m.log_time);
                let timeline = serde_json::from_str::<serde_json::Value>(&info.settings_json)
                    .ok()
                    .and_then(|v| {
                        v.get(TIMELINE_FRAMES_KEY)
                            .and_then(serde_json::Value::as_u64)
                    });
                let drawn = timeline
                    .map(|t| DrawnFrames::read(bag, t, info.frame_count))
                    .transpose()?;
                return Ok(RenderedVideo {
                    drawn,
                    bag: bag.to_path_buf(),
                    frame0_nanos: i128::from(stamp),
                    fps,
                    session: info.session,
                    capture_bag: info.capture_bag,
                    video_file: info.video_file,
                });
            }
        }
        Err(RenderBagError::NoVideoInfo(bag.to_path_buf()))
    }

    /// Checks that this is a render of `capture`: the same capture session. Its timing placed on
    /// another capture's timeline would cut every clip at the wrong frames.
    ///
    /// # Errors
    /// [`RenderBagError::OtherSession`] naming the render bag, the session it rendered and the
    /// capture's.
    pub fn check_renders(&self, capture: &Capture) -> Result<(), RenderBagError> {
        if self.session == capture.session {
            return Ok(());
        }
        Err(RenderBagError::OtherSession {
            bag: self.bag.clone(),
            rendered: self.session.clone(),
            rendered_bag: self.capture_bag.clone(),
            capture_bag: capture.path.clone(),
            session: capture.session.clone(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros::builtin_interfaces::Time;
    use crate::ros::geometry_msgs::Point;

    #[test]
    fn a_clip_is_found_in_a_video_of_some_frames_only_when_it_holds_them_all() {
        // Timeline frames 2..6 and 9..12 of 20 drawn.
        let drawn = DrawnFrames {
            timeline_frames: 20,
            frames: vec![2, 3, 4, 5, 9, 10, 11],
        };
        assert_eq!(drawn.video_start(2, 4), Ok(0));
        assert_eq!(drawn.video_start(3, 2), Ok(1));
        assert_eq!(drawn.video_start(9, 3), Ok(4));
        assert_eq!(drawn.video_start(10, 1), Ok(5));
        // Starts at a frame not drawn; runs past a gap; runs past the end.
        assert_eq!(drawn.video_start(1, 2), Err(1));
        assert_eq!(drawn.video_start(4, 4), Err(6));
        assert_eq!(drawn.video_start(10, 3), Err(12));
    }

    #[test]
    fn an_annotation_from_before_the_landmarks_decodes_without_them() {
        let a = FrameAnnotation {
            frame_index: 7,
            keypoint_names: vec!["pelvis".into()],
            keypoints_3d: vec![Point {
                x: 1.0,
                y: 2.0,
                z: 3.0,
            }],
            keypoints_2d: vec![4.0, 5.0],
            visibility: vec![2],
            silhouette_pixels: 99,
            ..FrameAnnotation::default()
        };
        let bytes = cdr::encode(&a).unwrap();
        // The old layout: the same bytes without the four empty landmark sequences.
        let old = &bytes[..bytes.len() - 16];
        let mut place = FrameAnnotation::default();
        assert!(cdr::decode_in_place(old, &mut place).is_err());
        decode_annotation(old, &mut place).unwrap();
        assert_eq!(place, a);
        let mut with = a.clone();
        with.landmark_names = vec!["nose".into()];
        with.landmarks_3d = a.keypoints_3d.clone();
        with.landmarks_2d = vec![1.0, 2.0];
        with.landmark_visibility = vec![1];
        decode_annotation(&cdr::encode(&with).unwrap(), &mut place).unwrap();
        assert_eq!(place, with);
        assert!(decode_annotation(&bytes[..bytes.len() - 20], &mut place).is_err());
    }

    #[test]
    fn the_video_goes_in_as_the_chosen_viewers_message() {
        let dir = tempfile::tempdir().unwrap();
        let frames = || {
            (0..3_u8).map(|k| RenderedFrame {
                stamp_nanos: 100 + u64::from(k),
                annotation: FrameAnnotation::default(),
                video: Some(CompressedVideo {
                    timestamp: Time::from_nanos(100 + u64::from(k)),
                    frame_id: "camera".into(),
                    data: vec![0, 0, 0, 1, 0x65, k],
                    format: "h264".into(),
                }),
            })
        };
        for (embed, videos, images) in [
            (EmbedVideo::Foxglove, 3, 0),
            (EmbedVideo::Rerun, 0, 3),
            (EmbedVideo::Both, 3, 3),
        ] {
            let path = dir.path().join(format!("{embed:?}.render.mcap"));
            write(&path, 100, &VideoInfo::default(), frames(), embed).unwrap();
            let (mut v, mut i) = (0, Vec::new());
            for m in BagReader::open(&path)
                .unwrap()
                .messages()
                .map(Result::unwrap)
            {
                match m.channel.topic.as_str() {
                    EMBEDDED_VIDEO_TOPIC => {
                        assert_eq!(m.channel.schema_name(), CompressedVideo::TYPE_NAME);
                        v += 1;
                    }
                    EMBEDDED_IMAGE_TOPIC => {
                        assert_eq!(m.channel.schema_name(), CompressedImage::TYPE_NAME);
                        let image: CompressedImage = cdr::decode(&m.data).unwrap();
                        assert_eq!(image.header.stamp.to_nanos(), Some(m.log_time));
                        i.push(image);
                    }
                    _ => {}
                }
            }
            assert_eq!((v, i.len()), (videos, images), "{embed:?}");
            for (k, image) in (0_u8..).zip(&i) {
                assert_eq!(image.data, [0, 0, 0, 1, 0x65, k]);
                assert_eq!(
                    (image.format.as_str(), image.header.frame_id.as_str()),
                    ("h264", "camera")
                );
            }
        }
    }
}
