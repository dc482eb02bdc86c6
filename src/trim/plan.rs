//! Segments on the capture timeline → frame ranges in the capture video.
//!
//! Video frame `k` shows the timeline at `frame0_nanos + k / fps`. A segment `[start, end)` becomes
//! the frames whose times are nearest its ends: `round((start − frame0) · fps)` up to
//! `round((end − frame0) · fps)` (exclusive). A clip that starts before frame 0 or ends after the
//! video's last frame is *truncated*: reported, never cut, never listed.

use std::ops::Range;

use crate::ros::autoact_msgs::Segment;
use crate::video::Rational;

/// How the capture video lines up with the capture bag's timeline.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoTiming {
    /// Timeline stamp of video frame 0, nanoseconds (may be before the timeline starts).
    pub frame0_nanos: i128,
    /// The video's constant frame rate.
    pub fps: Rational,
    /// Frames in the video.
    pub frame_count: u64,
}

impl VideoTiming {
    /// The video frame nearest timeline stamp `stamp_nanos` (may be negative or past the end).
    #[must_use]
    pub fn frame_at(&self, stamp_nanos: u64) -> i128 {
        let num = i128::from(self.fps.num);
        let den = i128::from(self.fps.den) * 1_000_000_000;
        let x = (i128::from(stamp_nanos) - self.frame0_nanos) * num;
        // round half up, for negative values too
        (2 * x + den).div_euclid(2 * den)
    }
}

/// A clip's frames in the video (or, from [`frame_ranges`], a whole segment's).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FrameRange {
    /// Index into the segment list.
    pub segment: usize,
    /// The clip's index among its segment's clips; `None`: the segment's one clip (`whole`).
    pub part: Option<u32>,
    /// First frame.
    pub start_frame: u64,
    /// Frames.
    pub frame_count: u64,
    /// The action's frames in the video (within the clip): for a segment, its animation.
    pub action: Range<u64>,
    /// The video frame of the animation's first instant (the segment's `content_start`).
    pub animation_start_frame: u64,
}

impl FrameRange {
    /// One past the last frame.
    #[must_use]
    pub fn end_frame(&self) -> u64 {
        self.start_frame + self.frame_count
    }
}

/// A segment the video does not fully hold.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Truncated {
    /// The segment's id.
    pub segment_id: String,
    /// Its first frame in the video (negative: before the video starts).
    pub start_frame: i128,
    /// Its end frame (exclusive).
    pub end_frame: i128,
    /// Frames in the video.
    pub video_frames: u64,
}

impl std::fmt::Display for Truncated {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "segment `{}` needs video frames [{}, {}), but the video holds frames [0, {}): left out",
            self.segment_id, self.start_frame, self.end_frame, self.video_frames
        )
    }
}

/// Frame ranges of every segment the video fully holds, and the others.
#[must_use]
pub fn frame_ranges(
    segments: &[Segment],
    timing: &VideoTiming,
) -> (Vec<FrameRange>, Vec<Truncated>) {
    let mut ranges = Vec::new();
    let mut truncated = Vec::new();
    for (i, s) in segments.iter().enumerate() {
        let start = timing.frame_at(s.start.to_nanos().unwrap_or(0));
        let end = timing.frame_at(s.end.to_nanos().unwrap_or(0));
        match (u64::try_from(start), u64::try_from(end)) {
            (Ok(a), Ok(b)) if a < b && b <= timing.frame_count => {
                let action = content_frames(s, timing, a..b);
                ranges.push(FrameRange {
                    segment: i,
                    part: None,
                    start_frame: a,
                    frame_count: b - a,
                    animation_start_frame: action.start,
                    action,
                });
            }
            _ => truncated.push(Truncated {
                segment_id: s.id.clone(),
                start_frame: start,
                end_frame: end,
                video_frames: timing.frame_count,
            }),
        }
    }
    (ranges, truncated)
}

/// The video frames of segment `s`'s animation (`[content_start, content_end)`), within its
/// frames `within`; the whole segment when it states no animation times.
fn content_frames(s: &Segment, timing: &VideoTiming, within: Range<u64>) -> Range<u64> {
    let (Some(a), Some(b)) = (s.content_start.to_nanos(), s.content_end.to_nanos()) else {
        return within;
    };
    if b <= a {
        return within;
    }
    let clamp = |f: i128| {
        u64::try_from(f.max(0))
            .unwrap_or(u64::MAX)
            .clamp(within.start, within.end)
    };
    let (start, end) = (clamp(timing.frame_at(a)), clamp(timing.frame_at(b)));
    if start < end { start..end } else { within }
}

#[cfg(test)]
mod tests {
    use super::{VideoTiming, frame_ranges};
    use crate::ros::autoact_msgs::Segment;
    use crate::ros::builtin_interfaces::Time;
    use crate::video::Rational;

    fn seg(id: &str, start_nanos: u64, end_nanos: u64) -> Segment {
        Segment {
            id: id.to_owned(),
            start: Time::from_nanos(start_nanos),
            end: Time::from_nanos(end_nanos),
            ..Segment::default()
        }
    }

    #[test]
    fn segments_map_to_nearest_frames_and_overhangs_are_truncated() {
        let fps = Rational::new(30, 1).unwrap();
        let ns = |k: u64| fps.frame_time_nanos(k);
        let timing = VideoTiming {
            frame0_nanos: i128::from(ns(10)),
            fps,
            frame_count: 100,
        };
        let segments = vec![
            seg("before", ns(5), ns(20)),
            seg("a", ns(10), ns(40)),
            seg("b", ns(40) + 1, ns(70) - 1),
            seg("tail", ns(100), ns(110)),
            seg("after", ns(100), ns(111)),
        ];
        let (ranges, truncated) = frame_ranges(&segments, &timing);
        let got: Vec<(usize, u64, u64)> = ranges
            .iter()
            .map(|r| (r.segment, r.start_frame, r.frame_count))
            .collect();
        assert_eq!(got, vec![(1, 0, 30), (2, 30, 30), (3, 90, 10)]);
        let ids: Vec<&str> = truncated.iter().map(|t| t.segment_id.as_str()).collect();
        assert_eq!(ids, vec!["before", "after"]);
        assert_eq!(truncated[0].start_frame, -5);
        assert!(truncated[1].to_string().contains("[90, 101)"));
    }
}
