//! Reading pose topics in two passes, so that `convert` never holds a bag's frames:
//!
//! 1. [`scan_pose_topics`] reads every message once and keeps, per track (a person on a topic),
//!    only counts, the clock its stamps come from, which joints it ever observes, a bounded
//!    sample of its frames ([`SAMPLE_CAP`], evenly spread: what fitting the body and any other
//!    whole-track estimate needs) and a bounded sample of its frame steps (its frame period);
//! 2. [`stream_pose_frames`] reads the file again in file order and hands each track's frames
//!    to a callback with their settled stamps, one at a time: a frame not after the previous one
//!    is dropped and reported (as when reading whole), a gap longer than the track's maximum is
//!    announced with the frame after it, and a lone frame far ahead of its neighbours (a stamp
//!    whose bytes were damaged) is dropped and reported instead of cutting the track.
//!
//! Memory is the sample and a few numbers per track, whatever the length of the bag.

use std::collections::BTreeMap;
use std::path::Path;

use super::{Clock, PoseBagError, PoseDecoder, SkippedMessage, Taken, no_pose_topic, take_message};
use crate::mcap_io::{BagReader, ReadIssue};
use crate::ros::RosMessage;
use crate::ros::autoact_msgs::Skeleton3D;
use crate::skeleton::pose::PoseFrame;

/// Frames kept per track in pass 1: at most this many, evenly spread over the track (every
/// `2^k`-th frame). Below it, every frame is kept.
pub const SAMPLE_CAP: usize = 512;

/// Frame steps kept per track in pass 1 to measure its frame period (median step).
const STEP_SAMPLE_CAP: usize = 1024;

/// What pass 1 learned of one track without keeping its frames.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackScan {
    /// The topic.
    pub topic: String,
    /// The person's tracker id.
    pub track_id: u64,
    /// The file the track starts in.
    pub source: String,
    /// Joint names of its messages, in their order.
    pub joint_names: Vec<String>,
    /// Its layout (from the messages, or the one given).
    pub layout: String,
    /// Frames read (before stamps are checked).
    pub frames: u64,
    /// Whether its stamps are header stamps (some message has one) rather than log times.
    pub stamped: bool,
    /// Stamp of its first frame, nanoseconds.
    pub first_stamp_nanos: u64,
    /// Per joint (message order): whether some frame observes it (finite, confidence above 0).
    pub observed: Vec<bool>,
    /// Whether its messages are marker or pose arrays: estimator output in a camera's frame
    /// (skeleton messages are what `import` and `record` write, already in the world frame).
    pub camera_frame: bool,
    /// At most [`SAMPLE_CAP`] of its frames, evenly spread, in order, with their stamps.
    pub sample: Vec<PoseFrame>,
    /// Its frame period: the median step between consecutive stamps, nanoseconds (`None` with
    /// fewer than two distinct stamps).
    pub median_step_nanos: Option<u64>,
}

/// What pass 1 found in a bag.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseScan {
    /// One entry per (topic, track id), ordered by topic then track id.
    pub tracks: Vec<TrackScan>,
    /// Messages that could not be used (stamps aside: those are checked in pass 2).
    pub skipped: Vec<SkippedMessage>,
    /// Chunks or tails of the file that could not be read.
    pub issues: Vec<ReadIssue>,
    /// Messages whose positions held NaN: (topic, index) of the first few, and the total.
    pub nan_messages: (Vec<(String, u64)>, u64),
    /// Metadata records of the file.
    pub metadata: Vec<(String, BTreeMap<String, String>)>,
}

/// A deterministic, evenly spread sample of a stream of unknown length: item `i` is kept when
/// `i` is a multiple of the stride, and the stride doubles (every other kept item dropped)
/// whenever the cap is reached.
#[derive(Debug, Clone)]
struct StrideSample<T> {
    cap: usize,
    stride: u64,
    seen: u64,
    items: Vec<T>,
}

impl<T> StrideSample<T> {
    fn new(cap: usize) -> Self {
        StrideSample {
            cap,
            stride: 1,
            seen: 0,
            items: Vec::new(),
        }
    }

    /// Whether the next item offered will be kept.
    fn wants_next(&self) -> bool {
        self.seen.is_multiple_of(self.stride)
    }

    fn push(&mut self, item: T) {
        if self.wants_next() {
            self.items.push(item);
            if self.items.len() >= self.cap {
                let mut k = 0;
                self.items.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
                self.stride *= 2;
            }
        }
        self.seen += 1;
    }
}

/// One track during pass 1.
struct Scanning {
    scan: TrackScan,
    first: Clock,
    last: Clock,
    sample: StrideSample<(PoseFrame, Clock)>,
    /// (header step, log-time step) between consecutive messages.
    steps: StrideSample<(u64, u64)>,
}

impl Scanning {
    fn take(&mut self, frame: &PoseFrame, clock: Clock) {
        if self.scan.frames > 0 {
            let header = clock
                .header
                .unwrap_or(0)
                .saturating_sub(self.last.header.unwrap_or(0));
            let log = clock.log_time.saturating_sub(self.last.log_time);
            self.steps.push((header, log));
        } else {
            self.first = clock;
        }
        self.scan.frames += 1;
        self.scan.stamped |= clock.header.is_some();
        self.last = clock;
        for (j, seen) in self.scan.observed.iter_mut().enumerate() {
            if !*seen {
                *seen = frame.confidence.get(j).is_some_and(|&c| c > 0.0)
                    && frame
                        .positions_m
                        .get(j)
                        .is_some_and(|p| p.coords.iter().all(|v| v.is_finite()));
            }
        }
        if self.sample.wants_next() {
            self.sample.push((frame.clone(), clock));
        } else {
            self.sample.seen += 1;
        }
    }

    fn finish(mut self) -> TrackScan {
        let stamped = self.scan.stamped;
        let stamp = |c: &Clock| {
            if stamped {
                c.header.unwrap_or(0)
            } else {
                c.log_time
            }
        };
        self.scan.first_stamp_nanos = stamp(&self.first);
        self.scan.sample = self
            .sample
            .items
            .into_iter()
            .map(|(mut f, c)| {
                f.stamp_nanos = stamp(&c);
                f
            })
            .collect();
        let mut steps: Vec<u64> = self
            .steps
            .items
            .iter()
            .map(|&(h, l)| if stamped { h } else { l })
            .filter(|&s| s > 0)
            .collect();
        steps.sort_unstable();
        self.scan.median_step_nanos = steps.get(steps.len() / 2).copied();
        self.scan
    }
}

/// Pass 1: reads the pose topics of a bag (as [`super::read_pose_topics`] does: `topic` selects
/// one, `layout` names the joints of markers and pose arrays) keeping no frame but each track's
/// sample.
///
/// # Errors
/// [`PoseBagError`] when nothing can be read.
pub fn scan_pose_topics(
    path: &Path,
    topic: Option<&str>,
    layout: Option<&crate::skeleton::layout::Layout>,
) -> Result<PoseScan, PoseBagError> {
    let readers = BagReader::open_all(path)?;
    let mut tracks: BTreeMap<(String, u64), Scanning> = BTreeMap::new();
    let mut skipped = Vec::new();
    let mut issues = Vec::new();
    let (mut nan_first, mut nan_total) = (Vec::new(), 0u64);
    let mut seen_topics = BTreeMap::new();
    let mut decoder = PoseDecoder::default();
    for (reader_index, reader) in readers.iter().enumerate() {
        for item in reader.messages() {
            let msg = match item {
                Ok(msg) => msg,
                Err(issue) => {
                    issues.push(issue);
                    continue;
                }
            };
            let people = match take_message(
                &msg,
                reader,
                topic,
                layout,
                &mut decoder,
                Some(&mut seen_topics),
            )? {
                Taken::NotWanted => continue,
                Taken::Skip(s) => {
                    skipped.push(s);
                    continue;
                }
                Taken::People(people) => people,
            };
            for person in people {
                if person
                    .frame
                    .positions_m
                    .iter()
                    .any(|p| p.coords.iter().any(|v| v.is_nan()))
                {
                    nan_total += 1;
                    if nan_first.len() < 5 {
                        nan_first.push((msg.channel.topic.clone(), msg.index_on_channel));
                    }
                }
                let clock = Clock {
                    header: person.header_stamp,
                    log_time: msg.log_time,
                    index: msg.index_on_channel,
                    reader: reader_index,
                };
                let key = (msg.channel.topic.clone(), person.track_id);
                let track = tracks.entry(key).or_insert_with(|| Scanning {
                    scan: TrackScan {
                        topic: msg.channel.topic.clone(),
                        track_id: person.track_id,
                        source: reader.path().display().to_string(),
                        joint_names: person.joint_names.to_vec(),
                        layout: person.layout.to_string(),
                        frames: 0,
                        stamped: false,
                        first_stamp_nanos: 0,
                        observed: vec![false; person.joint_names.len()],
                        camera_frame: msg.channel.schema_name() != Skeleton3D::TYPE_NAME,
                        sample: Vec::new(),
                        median_step_nanos: None,
                    },
                    first: clock,
                    last: clock,
                    sample: StrideSample::new(SAMPLE_CAP),
                    steps: StrideSample::new(STEP_SAMPLE_CAP),
                });
                if track.scan.joint_names != person.joint_names {
                    skipped.push(super::skipped_message(
                        reader,
                        &msg,
                        joint_names_differ(person.track_id),
                    ));
                    continue;
                }
                track.take(&person.frame, clock);
            }
        }
    }
    if tracks.is_empty() && skipped.is_empty() && issues.is_empty() {
        return Err(PoseBagError::NoPoseTopic {
            path: path.display().to_string(),
            why: no_pose_topic(topic, &seen_topics),
        });
    }
    Ok(PoseScan {
        tracks: tracks.into_values().map(Scanning::finish).collect(),
        skipped,
        issues,
        nan_messages: (nan_first, nan_total),
        metadata: readers.iter().flat_map(metadata_records).collect(),
    })
}

/// The metadata records of a file ([`BagReader::metadata`]: its own record walk, which checks
/// every length and touches only record headers), with the pages read released after.
fn metadata_records(reader: &BagReader) -> Vec<(String, BTreeMap<String, String>)> {
    let out = reader.metadata();
    reader.release_pages();
    out
}

/// Why a person's message is skipped when its joints are not its track's.
pub(super) fn joint_names_differ(track_id: u64) -> String {
    format!("track {track_id}: joint names differ from the track's earlier messages")
}

/// A gap in a track longer than its maximum: nothing is interpolated across it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Gap {
    /// The file.
    pub path: String,
    /// The topic.
    pub topic: String,
    /// The person's tracker id.
    pub track_id: u64,
    /// Index (on its channel) of the message after the gap.
    pub index: u64,
    /// Stamp of the frame before the gap, nanoseconds.
    pub from_nanos: u64,
    /// Stamp of the frame after it, nanoseconds.
    pub to_nanos: u64,
    /// The track's maximum gap, nanoseconds.
    pub max_gap_nanos: u64,
}

impl std::fmt::Display for Gap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        use crate::skeleton::pose::nanos_to_secs;
        write!(
            f,
            "{}: {} track {}: message {} at {} ns comes {:.3} s after the previous frame ({} ns), more than the maximum gap of {:.3} s: nothing is interpolated across it, the animation resumes there",
            self.path,
            self.topic,
            self.track_id,
            self.index,
            self.to_nanos,
            nanos_to_secs(self.to_nanos - self.from_nanos),
            self.from_nanos,
            nanos_to_secs(self.max_gap_nanos),
        )
    }
}

/// One frame handed out by [`stream_pose_frames`].
#[derive(Debug)]
pub struct StreamedFrame<'f> {
    /// Index of its track in [`PoseScan::tracks`].
    pub track: usize,
    /// The frame, its stamp settled (joints in its messages' order).
    pub frame: &'f PoseFrame,
    /// The gap before it, when it starts a new stretch of its track.
    pub gap: Option<&'f Gap>,
}

/// What pass 2 found in the stamps.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StampReport {
    /// Frames dropped for their stamps (not after the previous one, or a lone frame far ahead),
    /// track by track.
    pub skipped: Vec<SkippedMessage>,
    /// Gaps longer than their track's maximum, track by track.
    pub gaps: Vec<Gap>,
    /// Frames handed out per track.
    pub frames: Vec<u64>,
}

/// One track's stamps during pass 2.
struct Stamps {
    stamped: bool,
    max_gap_nanos: u64,
    /// Stamp of the last frame handed out.
    last: Option<u64>,
    /// A frame more than the maximum gap after the last one, held until the next frame tells a
    /// gap (the next one is later still) from a lone damaged stamp (the next one is earlier).
    held: Option<(PoseFrame, Clock)>,
    skipped: Vec<SkippedMessage>,
    gaps: Vec<Gap>,
    handed: u64,
}

/// Where a frame goes after its stamp is checked.
enum Verdict {
    /// Hand it out (after the gap, if any).
    Hand(Option<Gap>),
    /// Hold it: it is far after the last frame.
    Hold,
    /// Drop it: its stamp is not after the last frame's.
    Drop,
}

impl Stamps {
    fn stamp(&self, clock: &Clock) -> u64 {
        if self.stamped {
            clock.header.unwrap_or(0)
        } else {
            clock.log_time
        }
    }

    fn skip(&mut self, scan: &TrackScan, readers: &[BagReader], clock: &Clock, reason: String) {
        self.skipped.push(SkippedMessage {
            path: readers
                .get(clock.reader)
                .map_or_else(String::new, |r| r.path().display().to_string()),
            topic: scan.topic.clone(),
            index: clock.index,
            log_time: clock.log_time,
            reason,
        });
    }

    /// Checks the stamp of the next frame; a held frame is released (a gap) or dropped (a lone
    /// stamp far ahead) on the way, and handed to `hand`.
    fn check<E>(
        &mut self,
        scan: &TrackScan,
        readers: &[BagReader],
        clock: &Clock,
        hand: &mut impl FnMut(&PoseFrame, Option<&Gap>) -> Result<(), E>,
    ) -> Result<Verdict, E> {
        let stamp = self.stamp(clock);
        if let Some(last) = self.last
            && stamp <= last
        {
            let reason = format!(
                "track {}: stamp {stamp} ns is not after the previous {last} ns (non-monotonic)",
                scan.track_id
            );
            self.skip(scan, readers, clock, reason);
            return Ok(Verdict::Drop);
        }
        if let Some((frame, held)) = self.held.take() {
            let held_stamp = frame.stamp_nanos;
            if stamp <= held_stamp {
                let reason = format!(
                    "track {}: stamp {held_stamp} ns jumps {:.3} s past the previous frame and the next message (index {}) is back at {stamp} ns: a damaged stamp, dropped",
                    scan.track_id,
                    crate::skeleton::pose::nanos_to_secs(
                        held_stamp - self.last.unwrap_or(held_stamp)
                    ),
                    clock.index
                );
                self.skip(scan, readers, &held, reason);
            } else {
                self.release(scan, readers, &frame, &held, hand)?;
            }
        }
        Ok(match self.last {
            Some(last) if stamp - last > self.max_gap_nanos => Verdict::Hold,
            _ => Verdict::Hand(None),
        })
    }

    /// Hands out a held frame after its gap.
    fn release<E>(
        &mut self,
        scan: &TrackScan,
        readers: &[BagReader],
        frame: &PoseFrame,
        clock: &Clock,
        hand: &mut impl FnMut(&PoseFrame, Option<&Gap>) -> Result<(), E>,
    ) -> Result<(), E> {
        let gap = Gap {
            path: readers
                .get(clock.reader)
                .map_or_else(String::new, |r| r.path().display().to_string()),
            topic: scan.topic.clone(),
            track_id: scan.track_id,
            index: clock.index,
            from_nanos: self.last.unwrap_or(0),
            to_nanos: frame.stamp_nanos,
            max_gap_nanos: self.max_gap_nanos,
        };
        hand(frame, Some(&gap))?;
        self.gaps.push(gap);
        self.last = Some(frame.stamp_nanos);
        self.handed += 1;
        Ok(())
    }
}

/// Pass 2: reads the bag again and hands every frame of every track of `scan` to `on_frame`, in
/// file order, with its stamp settled (header stamps or log times, as pass 1 decided per track).
/// Track `k`'s gaps longer than `max_gap_nanos[k]` are announced with the frame after them;
/// frames whose stamps are not after their predecessor, and lone frames more than the maximum
/// gap ahead of both neighbours, are dropped and reported in the [`StampReport`]. Messages pass 1
/// skipped are skipped again, silently (pass 1 reported them).
///
/// # Errors
/// The bag cannot be opened again ([`PoseBagError`]), or `on_frame` fails.
pub fn stream_pose_frames<E: From<PoseBagError>>(
    path: &Path,
    topic: Option<&str>,
    layout: Option<&crate::skeleton::layout::Layout>,
    scan: &PoseScan,
    max_gap_nanos: &[u64],
    mut on_frame: impl FnMut(StreamedFrame<'_>) -> Result<(), E>,
) -> Result<StampReport, E> {
    let readers = BagReader::open_all(path).map_err(|e| E::from(PoseBagError::Open(e)))?;
    let index: BTreeMap<(&str, u64), usize> = scan
        .tracks
        .iter()
        .enumerate()
        .map(|(k, t)| ((t.topic.as_str(), t.track_id), k))
        .collect();
    let mut stamps: Vec<Stamps> = scan
        .tracks
        .iter()
        .enumerate()
        .map(|(k, t)| Stamps {
            stamped: t.stamped,
            max_gap_nanos: max_gap_nanos.get(k).copied().unwrap_or(u64::MAX),
            last: None,
            held: None,
            skipped: Vec::new(),
            gaps: Vec::new(),
            handed: 0,
        })
        .collect();
    let mut decoder = PoseDecoder::default();
    for (reader_index, reader) in readers.iter().enumerate() {
        for item in reader.messages() {
            let Ok(msg) = item else {
                continue;
            };
            let Ok(Taken::People(people)) =
                take_message(&msg, reader, topic, layout, &mut decoder, None)
            else {
                continue;
            };
            for mut person in people {
                let Some(&k) = index.get(&(msg.channel.topic.as_str(), person.track_id)) else {
                    continue;
                };
                let track = &scan.tracks[k];
                if track.joint_names != person.joint_names {
                    continue;
                }
                let clock = Clock {
                    header: person.header_stamp,
                    log_time: msg.log_time,
                    index: msg.index_on_channel,
                    reader: reader_index,
                };
                let state = &mut stamps[k];
                person.frame.stamp_nanos = state.stamp(&clock);
                let mut hand = |frame: &PoseFrame, gap: Option<&Gap>| {
                    on_frame(StreamedFrame {
                        track: k,
                        frame,
                        gap,
                    })
                };
                match state.check(track, &readers, &clock, &mut hand)? {
                    Verdict::Drop => {}
                    Verdict::Hold => state.held = Some((person.frame, clock)),
                    Verdict::Hand(gap) => {
                        hand(&person.frame, gap.as_ref())?;
                        state.last = Some(person.frame.stamp_nanos);
                        state.handed += 1;
                    }
                }
            }
        }
    }
    let mut report = StampReport::default();
    for (k, mut state) in stamps.into_iter().enumerate() {
        if let Some((frame, clock)) = state.held.take() {
            let mut hand = |frame: &PoseFrame, gap: Option<&Gap>| {
                on_frame(StreamedFrame {
                    track: k,
                    frame,
                    gap,
                })
            };
            state.release(&scan.tracks[k], &readers, &frame, &clock, &mut hand)?;
        }
        report.skipped.append(&mut state.skipped);
        report.gaps.append(&mut state.gaps);
        report.frames.push(state.handed);
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mcap_io::{BagWriter, WriteConfig};
    use crate::skeleton::pose::PoseSequence;

    /// A one-person pose bag of `stamps`, three joints, the last never seen.
    fn bag(dir: &Path, stamps: &[u64]) -> std::path::PathBuf {
        let path = dir.join("in.mcap");
        let seq = PoseSequence {
            source: "test".into(),
            track_id: 0,
            joint_names: vec!["a".into(), "b".into(), "c".into()],
            frames: Vec::new(),
        };
        let mut w = BagWriter::create(&path, WriteConfig::default()).unwrap();
        for &t in stamps {
            let mut f = PoseFrame::missing(t, 3);
            for j in 0..2 {
                f.positions_m[j] = nalgebra::Point3::new(0.0, 0.0, 1.0);
                f.confidence[j] = 1.0;
            }
            w.write(
                "/skeleton",
                t,
                &super::super::skeleton_message(&seq, &f, "x"),
            )
            .unwrap();
        }
        w.finish().unwrap();
        path
    }

    /// Frames handed out by pass 2 (their stamps, and whether a gap came before), and the report.
    fn pass_two(path: &Path, scan: &PoseScan, max_gap: u64) -> (Vec<(u64, bool)>, StampReport) {
        let mut seen = Vec::new();
        let report = stream_pose_frames::<PoseBagError>(path, None, None, scan, &[max_gap], |f| {
            seen.push((f.frame.stamp_nanos, f.gap.is_some()));
            Ok(())
        })
        .unwrap();
        (seen, report)
    }

    #[test]
    fn pass_one_keeps_a_bounded_evenly_spread_sample_and_the_frame_period() {
        let dir = tempfile::tempdir().unwrap();
        let stamps: Vec<u64> = (1..=3000).map(|k| k * 20_000_000).collect();
        let path = bag(dir.path(), &stamps);
        let scan = scan_pose_topics(&path, None, None).unwrap();
        let [track] = scan.tracks.as_slice() else {
            panic!("one track")
        };
        assert_eq!(track.frames, 3000);
        assert!(track.sample.len() >= SAMPLE_CAP / 2 && track.sample.len() < SAMPLE_CAP);
        assert_eq!(track.sample[0].stamp_nanos, 20_000_000);
        assert_eq!(track.median_step_nanos, Some(20_000_000));
        assert_eq!(track.first_stamp_nanos, 20_000_000);
        assert_eq!(track.observed, vec![true, true, false]);
        assert!(track.stamped);
        let (seen, report) = pass_two(&path, &scan, 100_000_000);
        assert_eq!(seen.len(), 3000);
        assert!(report.skipped.is_empty() && report.gaps.is_empty());
    }

    #[test]
    fn pass_two_drops_backward_stamps_and_lone_stamps_far_ahead_and_announces_gaps() {
        let dir = tempfile::tempdir().unwrap();
        let ms = 1_000_000;
        // 10, 20, [5: backwards], 30, [10^12: alone far ahead], 40, 50, [gap] 5000, 5010.
        let stamps = [10, 20, 5, 30, 1_000_000_000, 40, 50, 5000, 5010].map(|t| t * ms);
        let path = bag(dir.path(), &stamps);
        let scan = scan_pose_topics(&path, None, None).unwrap();
        let (seen, report) = pass_two(&path, &scan, 100 * ms);
        let expected = [10, 20, 30, 40, 50, 5000, 5010].map(|t| t * ms);
        assert_eq!(seen.iter().map(|s| s.0).collect::<Vec<_>>(), expected);
        assert_eq!(seen.iter().filter(|s| s.1).count(), 1);
        assert!(seen[5].1, "the gap comes before 5000 ms");
        let dropped: Vec<u64> = report.skipped.iter().map(|s| s.index).collect();
        assert_eq!(dropped, vec![2, 4]);
        assert!(report.skipped[1].reason.contains("damaged stamp"));
        assert_eq!(report.gaps.len(), 1);
        assert_eq!(report.gaps[0].index, 7);
        // A frame far ahead at the very end is a gap too: nothing comes back.
        let path = bag(dir.path(), &[10 * ms, 20 * ms, 9_000 * ms]);
        let scan = scan_pose_topics(&path, None, None).unwrap();
        let (seen, report) = pass_two(&path, &scan, 100 * ms);
        assert_eq!(
            seen,
            vec![(10 * ms, false), (20 * ms, false), (9_000 * ms, true)]
        );
        assert!(report.skipped.is_empty());
    }

    #[test]
    fn a_stride_sample_is_every_frame_below_its_cap_and_evenly_spread_above() {
        let mut s = StrideSample::new(8);
        (0..7u64).for_each(|i| s.push(i));
        assert_eq!(s.items, (0..7).collect::<Vec<_>>());
        let mut s = StrideSample::new(8);
        (0..100u64).for_each(|i| s.push(i));
        assert!(s.items.len() >= 4 && s.items.len() < 8);
        let step = s.items[1] - s.items[0];
        assert!(s.items.windows(2).all(|w| w[1] - w[0] == step));
        assert_eq!(s.items[0], 0);
    }
}
