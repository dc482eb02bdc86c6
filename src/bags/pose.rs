//! Pose bags: skeletons in MCAP. Writing one (`autoact import`) and reading pose topics back
//! (`autoact convert`), whatever publishes them:
//!
//! - `autoact_msgs/msg/Skeleton3D` — one person per message, joints named, layout named;
//! - `visualization_msgs/msg/MarkerArray` — pose-estimator debug output: each marker namespace is
//!   one person, and the joints are either one `SPHERE` marker per joint (joint = marker id) or
//!   the points of one `SPHERE_LIST`/`POINTS` marker (joint = point index). For layouts of at
//!   most 100 joints a sphere's id may also carry the person, `person × 100 + joint` (the Azure
//!   Kinect / Orbbec ROS drivers' body markers, all in one namespace). People keep their track
//!   ids from message to message (first seen, first numbered, per topic), so one who leaves the
//!   view does not hand their track to the next;
//! - `geometry_msgs/msg/PoseArray` — one person per message, joint `k` = pose `k`.
//!
//! Markers and pose arrays carry no joint names: the layout (`--layout`) gives them, in order.
//! A message that cannot be used (undecodable, wrong array lengths, joint count not the
//! layout's) is skipped and reported with its file, channel and index; so is one whose stamp is
//! not after the previous one of the same person. Positions stay in the message's frame.

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::Point3;

use crate::mcap_io::{BagMessage, BagReader, McapIoError, ReadIssue};
use crate::ros::autoact_msgs::Skeleton3D;
use crate::ros::builtin_interfaces::Time;
use crate::ros::geometry_msgs::{Point, PoseArray};
use crate::ros::skeleton_decode::SkeletonReader;
use crate::ros::std_msgs::Header;
use crate::ros::visualization_msgs::{Marker, MarkerArray};
use crate::ros::{self, RosMessage};
use crate::skeleton::frames::WORLD_FRAME;
use crate::skeleton::pose::{PoseFrame, PoseSequence};

mod stream;

pub use stream::{
    Gap, PoseScan, SAMPLE_CAP, StampReport, StreamedFrame, TrackScan, scan_pose_topics,
    stream_pose_frames,
};

/// Topic autoact writes skeletons on.
pub const SKELETON_TOPIC: &str = "/skeleton";
/// Name of the metadata record that carries the dataset label and provenance.
pub const METADATA_NAME: &str = "autoact";

/// The pose message types a pose topic can carry.
pub const POSE_TYPES: [&str; 3] = [
    Skeleton3D::TYPE_NAME,
    MarkerArray::TYPE_NAME,
    PoseArray::TYPE_NAME,
];

/// The `Skeleton3D` message of one frame.
#[must_use]
pub fn skeleton_message(seq: &PoseSequence, frame: &PoseFrame, layout: &str) -> Skeleton3D {
    Skeleton3D {
        header: Header {
            stamp: Time::from_nanos(frame.stamp_nanos),
            frame_id: WORLD_FRAME.to_string(),
        },
        layout: layout.to_string(),
        track_id: seq.track_id,
        joint_names: seq.joint_names.clone(),
        positions: frame.positions_m.iter().map(|p| Point::from(*p)).collect(),
        confidence: frame.confidence.clone(),
    }
}

/// A message that could not be used, and why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{path}: {topic} message {index} ({log_time} ns): {reason}")]
pub struct SkippedMessage {
    /// The file.
    pub path: String,
    /// The channel's topic.
    pub topic: String,
    /// Index of the message on its channel, from 0.
    pub index: u64,
    /// Its log time.
    pub log_time: u64,
    /// What was wrong.
    pub reason: String,
}

/// Errors that stop reading pose topics.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PoseBagError {
    /// The file could not be opened.
    #[error(transparent)]
    Open(#[from] McapIoError),
    /// No channel carries a pose type (or the asked topic does not exist / is not a pose type).
    #[error("{path}: {why}")]
    NoPoseTopic {
        /// The file.
        path: String,
        /// What was found instead.
        why: String,
    },
    /// Markers or pose arrays need a layout to name their joints.
    #[error("{path}: {topic} carries {type_name}, which has no joint names: give --layout")]
    LayoutNeeded {
        /// The file.
        path: String,
        /// The topic.
        topic: String,
        /// The type.
        type_name: String,
    },
}

/// What reading pose topics produced.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseTopics {
    /// One sequence per (topic, track id), ordered by topic then track id.
    pub sequences: Vec<(String, PoseSequence)>,
    /// Layout name per sequence (from the messages, or the one given).
    pub layouts: Vec<String>,
    /// Messages that could not be used.
    pub skipped: Vec<SkippedMessage>,
    /// Chunks or tails of the file that could not be read.
    pub issues: Vec<ReadIssue>,
    /// Messages whose positions held NaN (joints not seen): (topic, index) of the first few, and the total.
    pub nan_messages: (Vec<(String, u64)>, u64),
    /// Metadata records of the file.
    pub metadata: Vec<(String, BTreeMap<String, String>)>,
}

impl PoseTopics {}

/// Reads the pose topics of a bag. `topic` selects one (else every channel of a pose type);
/// `layout` names the joints of markers and pose arrays (and must match the joint names of
/// skeleton messages when given).
///
/// # Errors
/// [`PoseBagError`] when nothing can be read; per-message problems are in [`PoseTopics::skipped`].
pub fn read_pose_topics(
    path: &Path,
    topic: Option<&str>,
    layout: Option<&crate::skeleton::layout::Layout>,
) -> Result<PoseTopics, PoseBagError> {
    let readers = BagReader::open_all(path)?;
    let mut gathered = Gathered::default();
    let mut decoder = PoseDecoder::default();
    for (reader_index, reader, item) in readers
        .iter()
        .enumerate()
        .flat_map(|(i, r)| r.messages().map(move |m| (i, r, m)))
    {
        match item {
            Ok(msg) => gathered.take(&msg, reader_index, reader, topic, layout, &mut decoder)?,
            Err(issue) => gathered.issues.push(issue),
        }
    }
    let Gathered {
        mut tracks,
        mut skipped,
        issues,
        nan_first,
        nan_total,
        seen_topics,
    } = gathered;
    for (topic, by_track) in &mut tracks {
        for c in by_track.values_mut() {
            c.settle_stamps(topic, &readers, &mut skipped);
        }
    }
    if tracks.is_empty() && skipped.is_empty() && issues.is_empty() {
        return Err(PoseBagError::NoPoseTopic {
            path: path.display().to_string(),
            why: no_pose_topic(topic, &seen_topics),
        });
    }
    let mut sequences = Vec::new();
    let mut layouts = Vec::new();
    for (topic, by_track) in tracks {
        for c in by_track.into_values() {
            sequences.push((topic.clone(), c.seq));
            layouts.push(c.layout);
        }
    }
    Ok(PoseTopics {
        sequences,
        layouts,
        skipped,
        issues,
        nan_messages: (nan_first, nan_total),
        metadata: readers.iter().flat_map(BagReader::metadata).collect(),
    })
}

/// Why a bag gave no pose track: the asked topic is not in it, it has no readable message, or
/// none of its topics carries a pose type (`seen_topics`: topic → type).
fn no_pose_topic(topic: Option<&str>, seen_topics: &BTreeMap<String, String>) -> String {
    match topic {
        Some(t) if !seen_topics.contains_key(t) => format!(
            "no topic {t} (topics: {})",
            if seen_topics.is_empty() {
                "none".to_string()
            } else {
                seen_topics.keys().cloned().collect::<Vec<_>>().join(", ")
            }
        ),
        _ if seen_topics.is_empty() => "no readable messages".to_string(),
        _ => format!(
            "no pose topic: autoact reads {}; the file has {}",
            POSE_TYPES.join(", "),
            seen_topics
                .iter()
                .map(|(t, ty)| format!("{t} ({ty})"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// The pose tracks of a bag as its messages are read.
#[derive(Default)]
struct Gathered {
    /// Topic → track id → the track.
    tracks: BTreeMap<String, BTreeMap<u64, Collected>>,
    skipped: Vec<SkippedMessage>,
    issues: Vec<ReadIssue>,
    /// (topic, index) of the first few messages with NaN positions.
    nan_first: Vec<(String, u64)>,
    nan_total: u64,
    /// Every topic seen → its type.
    seen_topics: BTreeMap<String, String>,
}

/// A message of `reader` skipped for `reason`.
fn skipped_message(reader: &BagReader, msg: &BagMessage, reason: String) -> SkippedMessage {
    SkippedMessage {
        path: reader.path().display().to_string(),
        topic: msg.channel.topic.clone(),
        index: msg.index_on_channel,
        log_time: msg.log_time,
        reason,
    }
}

/// What one message gives.
enum Taken<'a> {
    /// Not on a wanted topic.
    NotWanted,
    /// Wanted but unusable.
    Skip(SkippedMessage),
    /// The people in it.
    People(Vec<Person<'a>>),
}

/// Decodes one message of `reader`: a pose message on a wanted topic (`topic`, else any pose
/// type) gives its people, one that cannot be used is skipped. `seen_topics` (topic → type)
/// learns every topic met.
///
/// # Errors
/// A wanted topic that needs a layout or carries no pose type: nothing can be read.
fn take_message<'a>(
    msg: &BagMessage,
    reader: &BagReader,
    topic: Option<&str>,
    layout: Option<&'a crate::skeleton::layout::Layout>,
    decoder: &'a mut PoseDecoder,
    seen_topics: Option<&mut BTreeMap<String, String>>,
) -> Result<Taken<'a>, PoseBagError> {
    let type_name = msg.channel.schema_name();
    if let Some(seen) = seen_topics
        && !seen.contains_key(&msg.channel.topic)
    {
        seen.insert(msg.channel.topic.clone(), type_name.to_string());
    }
    let wanted = match topic {
        Some(t) => msg.channel.topic == t,
        None => POSE_TYPES.contains(&type_name),
    };
    if !wanted {
        return Ok(Taken::NotWanted);
    }
    if msg.channel.message_encoding != "cdr" {
        return Ok(Taken::Skip(skipped_message(
            reader,
            msg,
            format!(
                "message encoding `{}` is not cdr",
                msg.channel.message_encoding
            ),
        )));
    }
    match decode_people(msg, type_name, layout, decoder) {
        Ok(p) => Ok(Taken::People(p)),
        Err(DecodeProblem::Skip(reason)) => Ok(Taken::Skip(skipped_message(reader, msg, reason))),
        Err(DecodeProblem::NeedsLayout) => Err(PoseBagError::LayoutNeeded {
            path: reader.path().display().to_string(),
            topic: msg.channel.topic.clone(),
            type_name: type_name.to_string(),
        }),
        Err(DecodeProblem::NotPose) => Err(PoseBagError::NoPoseTopic {
            path: reader.path().display().to_string(),
            why: format!(
                "{} carries {type_name}, not a pose type ({})",
                msg.channel.topic,
                POSE_TYPES.join(", ")
            ),
        }),
    }
}

impl Gathered {
    /// Takes in one message of reader `reader_index`: a pose message on a wanted topic (`topic`,
    /// else any pose type) adds its people to their tracks, one that cannot be used is skipped.
    ///
    /// # Errors
    /// A wanted topic that needs a layout or carries no pose type: nothing can be read.
    fn take(
        &mut self,
        msg: &BagMessage,
        reader_index: usize,
        reader: &BagReader,
        topic: Option<&str>,
        layout: Option<&crate::skeleton::layout::Layout>,
        decoder: &mut PoseDecoder,
    ) -> Result<(), PoseBagError> {
        match take_message(
            msg,
            reader,
            topic,
            layout,
            decoder,
            Some(&mut self.seen_topics),
        )? {
            Taken::NotWanted => {}
            Taken::Skip(s) => self.skipped.push(s),
            Taken::People(people) => self.add_people(msg, reader_index, reader, people),
        }
        Ok(())
    }

    /// Appends each person of `msg` to its track (created on first sight), counting NaN
    /// positions; a person whose joint names differ from its track's is skipped.
    fn add_people(
        &mut self,
        msg: &BagMessage,
        reader_index: usize,
        reader: &BagReader,
        people: Vec<Person<'_>>,
    ) {
        // Looked up before inserting, so that a message costs no copy of its topic name.
        let topic_tracks = match self.tracks.get_mut(&msg.channel.topic) {
            Some(t) => t,
            None => self.tracks.entry(msg.channel.topic.clone()).or_default(),
        };
        for person in people {
            if person
                .frame
                .positions_m
                .iter()
                .any(|p| p.coords.iter().any(|v| v.is_nan()))
            {
                self.nan_total += 1;
                if self.nan_first.len() < 5 {
                    self.nan_first
                        .push((msg.channel.topic.clone(), msg.index_on_channel));
                }
            }
            let entry = topic_tracks
                .entry(person.track_id)
                .or_insert_with(|| Collected {
                    seq: PoseSequence {
                        source: reader.path().display().to_string(),
                        track_id: person.track_id,
                        joint_names: person.joint_names.to_vec(),
                        frames: Vec::new(),
                    },
                    layout: person.layout.to_string(),
                    clocks: Vec::new(),
                });
            if entry.seq.joint_names != person.joint_names {
                self.skipped.push(skipped_message(
                    reader,
                    msg,
                    stream::joint_names_differ(person.track_id),
                ));
                continue;
            }
            entry.seq.frames.push(person.frame);
            entry.clocks.push(Clock {
                header: person.header_stamp,
                log_time: msg.log_time,
                index: msg.index_on_channel,
                reader: reader_index,
            });
        }
    }
}

/// Where one frame's time can come from.
#[derive(Debug, Clone, Copy)]
struct Clock {
    /// The header stamp (`None`: zero).
    header: Option<u64>,
    log_time: u64,
    index: u64,
    reader: usize,
}

/// One track as read, before its stamps are settled.
struct Collected {
    seq: PoseSequence,
    layout: String,
    clocks: Vec<Clock>,
}

impl Collected {
    /// Gives every frame its time, decided once per track: the header stamps when any frame has
    /// one (a zero there is a real 0 — a stream replayed from 0), else the log times (a
    /// publisher that never stamps). Frames not after their predecessor are dropped and
    /// reported.
    fn settle_stamps(
        &mut self,
        topic: &str,
        readers: &[BagReader],
        skipped: &mut Vec<SkippedMessage>,
    ) {
        let stamped = self.clocks.iter().any(|c| c.header.is_some());
        let frames = std::mem::take(&mut self.seq.frames);
        let mut last: Option<u64> = None;
        for (mut frame, clock) in frames.into_iter().zip(&self.clocks) {
            let stamp = if stamped {
                clock.header.unwrap_or(0)
            } else {
                clock.log_time
            };
            if let Some(previous) = last
                && stamp <= previous
            {
                skipped.push(SkippedMessage {
                    path: readers[clock.reader].path().display().to_string(),
                    topic: topic.to_string(),
                    index: clock.index,
                    log_time: clock.log_time,
                    reason: format!(
                        "track {}: stamp {stamp} ns is not after the previous {previous} ns (non-monotonic)",
                        self.seq.track_id
                    ),
                });
                continue;
            }
            last = Some(stamp);
            frame.stamp_nanos = stamp;
            self.seq.frames.push(frame);
        }
        self.clocks.clear();
    }
}

/// One person of one message. Names are borrowed (from the decoded message or the layout): a
/// track copies them once, when it starts.
struct Person<'a> {
    /// The message's header stamp, `None` when zero (the publisher may not have stamped).
    header_stamp: Option<u64>,
    track_id: u64,
    layout: &'a str,
    joint_names: &'a [String],
    frame: PoseFrame,
}

enum DecodeProblem {
    Skip(String),
    NeedsLayout,
    NotPose,
}

/// A header stamp, `None` when zero or invalid: a publisher that does not stamp leaves it zero.
fn header_stamp(header: &Header) -> Option<u64> {
    header.stamp.to_nanos().filter(|&n| n != 0)
}

/// What decoding pose messages keeps from one message to the next: the skeleton reader (reused
/// so that reading allocates only each frame's own arrays) and the track ids given to the people
/// of marker arrays.
#[derive(Default)]
struct PoseDecoder {
    skeleton: SkeletonReader,
    /// The people of each topic's marker arrays.
    marker_tracks: BTreeMap<String, MarkerTracks>,
}

/// The track ids of one topic's marker people, numbered in order of first sight.
#[derive(Default)]
struct MarkerTracks {
    /// Namespace → person number in the sphere ids → track id.
    ids: BTreeMap<String, BTreeMap<u64, u64>>,
    next: u64,
}

impl MarkerTracks {
    /// The track id of person `person` of namespace `ns`: theirs, or the next number.
    fn id(&mut self, ns: &str, person: u64) -> u64 {
        let next = &mut self.next;
        let by_person = match self.ids.get_mut(ns) {
            Some(m) => m,
            None => self.ids.entry(ns.to_string()).or_default(),
        };
        *by_person.entry(person).or_insert_with(|| {
            *next += 1;
            *next - 1
        })
    }
}

/// Decodes the people of one message with `decoder`'s state.
fn decode_people<'a>(
    msg: &BagMessage,
    type_name: &str,
    layout: Option<&'a crate::skeleton::layout::Layout>,
    decoder: &'a mut PoseDecoder,
) -> Result<Vec<Person<'a>>, DecodeProblem> {
    let PoseDecoder {
        skeleton,
        marker_tracks,
    } = decoder;
    let bad =
        |e: ros::cdr::CdrError| DecodeProblem::Skip(format!("does not decode as {type_name}: {e}"));
    match type_name {
        t if t == Skeleton3D::TYPE_NAME => {
            let s: &'a Skeleton3D = skeleton.decode(&msg.data).map_err(bad)?;
            let n = s.joint_names.len();
            if s.positions.len() != n || s.confidence.len() != n {
                return Err(DecodeProblem::Skip(format!(
                    "{} joint names, {} positions and {} confidences: the arrays must have equal lengths",
                    n,
                    s.positions.len(),
                    s.confidence.len()
                )));
            }
            if let Some(l) = layout
                && let Err(e) = l.joint_order(&s.joint_names)
            {
                return Err(DecodeProblem::Skip(e.to_string()));
            }
            Ok(vec![Person {
                header_stamp: header_stamp(&s.header),
                track_id: s.track_id,
                layout: layout.map_or(s.layout.as_str(), |l| l.name.as_str()),
                frame: PoseFrame {
                    stamp_nanos: 0,
                    positions_m: s.positions.iter().map(|p| Point3::from(*p)).collect(),
                    confidence: s
                        .confidence
                        .iter()
                        .map(|c| {
                            if c.is_finite() {
                                c.clamp(0.0, 1.0)
                            } else {
                                0.0
                            }
                        })
                        .collect(),
                },
                joint_names: &s.joint_names,
            }])
        }
        t if t == MarkerArray::TYPE_NAME => {
            let layout = layout.ok_or(DecodeProblem::NeedsLayout)?;
            let m: MarkerArray = ros::cdr::decode(&msg.data).map_err(bad)?;
            let tracks = match marker_tracks.get_mut(&msg.channel.topic) {
                Some(t) => t,
                None => marker_tracks.entry(msg.channel.topic.clone()).or_default(),
            };
            markers_to_people(&m, layout, tracks)
        }
        t if t == PoseArray::TYPE_NAME => {
            let layout = layout.ok_or(DecodeProblem::NeedsLayout)?;
            let p: PoseArray = ros::cdr::decode(&msg.data).map_err(bad)?;
            if p.poses.len() != layout.joints.len() {
                return Err(DecodeProblem::Skip(format!(
                    "{} poses, the layout `{}` has {} joints",
                    p.poses.len(),
                    layout.name,
                    layout.joints.len()
                )));
            }
            Ok(vec![Person {
                header_stamp: header_stamp(&p.header),
                track_id: 0,
                layout: &layout.name,
                joint_names: &layout.joints,
                frame: PoseFrame {
                    stamp_nanos: 0,
                    positions_m: p
                        .poses
                        .iter()
                        .map(|pose| Point3::from(pose.position))
                        .collect(),
                    confidence: p
                        .poses
                        .iter()
                        .map(|pose| {
                            if pose.position.x.is_finite() {
                                1.0
                            } else {
                                0.0
                            }
                        })
                        .collect(),
                },
            }])
        }
        _ => Err(DecodeProblem::NotPose),
    }
}

/// Sphere ids carry the person as `person × 100 + joint` in layouts of at most this many joints.
const IDS_PER_PERSON: i32 = 100;

/// (person, joint) of sphere id `id`: `person × 100 + joint` when `per_person` (the layout has at
/// most [`IDS_PER_PERSON`] joints) and the id is not negative, else person 0 and joint `id`.
fn sphere_person_joint(id: i32, per_person: bool) -> (u64, i32) {
    match u64::try_from(id / IDS_PER_PERSON) {
        Ok(person) if per_person => (person, id % IDS_PER_PERSON),
        _ => (0, id),
    }
}

/// Markers → people: one person per namespace and, for layouts of at most [`IDS_PER_PERSON`]
/// joints, per hundred of sphere ids; in (namespace, person) order. `tracks` gives each person
/// its track id, a new one (the next number) on first sight.
fn markers_to_people<'a>(
    m: &MarkerArray,
    layout: &'a crate::skeleton::layout::Layout,
    tracks: &mut MarkerTracks,
) -> Result<Vec<Person<'a>>, DecodeProblem> {
    let n = layout.joints.len();
    let per_person = i32::try_from(n).is_ok_and(|n| n <= IDS_PER_PERSON);
    let mut by_person: BTreeMap<(&str, u64), Vec<&Marker>> = BTreeMap::new();
    for marker in m.markers.iter().filter(|mk| mk.action == Marker::ADD) {
        let person = if marker.type_ == Marker::SPHERE {
            sphere_person_joint(marker.id, per_person).0
        } else {
            0
        };
        by_person
            .entry((marker.ns.as_str(), person))
            .or_default()
            .push(marker);
    }
    let mut people = Vec::new();
    for ((ns, person), markers) in by_person {
        let mut positions = vec![Point3::new(f64::NAN, f64::NAN, f64::NAN); n];
        let mut confidence = vec![0.0f32; n];
        let lists: Vec<&&Marker> = markers
            .iter()
            .filter(|mk| mk.type_ == Marker::SPHERE_LIST || mk.type_ == Marker::POINTS)
            .collect();
        if let [list] = lists.as_slice() {
            if list.points.len() != n {
                return Err(DecodeProblem::Skip(format!(
                    "namespace `{ns}`: {} points, the layout `{}` has {n} joints",
                    list.points.len(),
                    layout.name
                )));
            }
            // The points are in the marker's own frame: header frame ← marker pose ← point.
            let rotation =
                nalgebra::UnitQuaternion::try_from(list.pose.orientation).map_err(|e| {
                    DecodeProblem::Skip(format!("namespace `{ns}`: marker orientation: {e}"))
                })?;
            let origin = Point3::from(list.pose.position);
            for (k, p) in list.points.iter().enumerate() {
                positions[k] = origin + rotation * Point3::from(*p).coords;
                confidence[k] = 1.0;
            }
        } else {
            for mk in markers.iter().filter(|mk| mk.type_ == Marker::SPHERE) {
                let (_, joint) = sphere_person_joint(mk.id, per_person);
                let Some(k) = usize::try_from(joint).ok().filter(|&k| k < n) else {
                    return Err(DecodeProblem::Skip(format!(
                        "namespace `{ns}`: sphere id {} is not a joint index of the layout `{}` (0..{n}{})",
                        mk.id,
                        layout.name,
                        if per_person {
                            ", or person × 100 + joint"
                        } else {
                            ""
                        }
                    )));
                };
                positions[k] = Point3::from(mk.pose.position);
                confidence[k] = 1.0;
            }
        }
        people.push(Person {
            header_stamp: markers.first().and_then(|mk| header_stamp(&mk.header)),
            track_id: tracks.id(ns, person),
            layout: &layout.name,
            joint_names: &layout.joints,
            frame: PoseFrame {
                stamp_nanos: 0,
                positions_m: positions,
                confidence,
            },
        });
    }
    Ok(people)
}

impl crate::outcome::LostInput for PoseTopics {
    /// Whether any input was lost.
    fn lost_input(&self) -> bool {
        !self.skipped.is_empty() || !self.issues.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_ids_carry_the_person_only_in_small_layouts_and_never_when_negative() {
        assert_eq!(sphere_person_joint(7, true), (0, 7));
        assert_eq!(sphere_person_joint(231, true), (2, 31));
        assert_eq!(sphere_person_joint(131, false), (0, 131));
        // Negative ids are no joint of anyone: the joint stays negative, an error downstream.
        assert_eq!(sphere_person_joint(-5, true), (0, -5));
        assert_eq!(sphere_person_joint(-150, true), (0, -150));
    }

    #[test]
    fn marker_people_are_numbered_in_order_of_first_sight() {
        let mut tracks = MarkerTracks::default();
        assert_eq!(tracks.id("b", 0), 0);
        assert_eq!(tracks.id("", 2), 1);
        assert_eq!(tracks.id("a", 0), 2);
        assert_eq!(tracks.id("b", 0), 0);
        assert_eq!(tracks.id("", 1), 3);
        assert_eq!(tracks.id("", 2), 1);
    }
}
