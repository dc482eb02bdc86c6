//! Animation bags: what `autoact convert` writes. Per output frame and person:
//!
//! - `/animation` — `autoact_msgs/msg/BoneFrame`: every bone's local rotation and the root
//!   translation (the data later stages consume);
//! - `/tf` — `tf2_msgs/msg/TFMessage`: `world → root`, and `parent → child` for every bone that
//!   moves, with the child's rest offset (on the subject's body) and its local rotation, so RViz,
//!   Foxglove and Rerun show the skeleton with no plugin;
//! - `/skeleton/markers` — `visualization_msgs/msg/MarkerArray`: the skeleton as lines from each
//!   bone's head to its children's heads, for every bone the data drives and the rigid torso
//!   (bones a layout cannot see, such as fingers from a body-only estimator, are not drawn). The
//!   lines are frame-locked `LINE_LIST` markers, one per parent bone, in that bone's own tf
//!   frame, where they never change: RViz and Foxglove move them with `/tf` at every frame. So
//!   they are sent with the first frame and then once a second ([`MARKERS_PERIOD_NANOS`]), for
//!   viewers that join late and bags cut anywhere, not with every frame.
//! - `/skeleton/points/<frame>` — `sensor_msgs/msg/PointCloud2`: the same skeleton for Rerun, which
//!   has no decoder for markers but applies `/tf` to a point cloud's `header.frame_id`: one cloud
//!   per marker, in the same bone frame, of points along that bone's segments
//!   ([`POINT_SPACING_M`] apart). One topic per bone frame (`<frame>` is its tf frame name
//!   without a scene prefix), since a viewer keeps only the latest message of a topic; sent with
//!   the markers, moved by `/tf`.
//!
//! Bones that never move (static bones, and those the layout cannot drive) go once on
//! `/tf_static`. With several people, frame names are prefixed `track<id>/`; with DSI variants,
//! `v<k>/` (after the track's prefix). The markers' namespace is `skeleton` followed by that
//! prefix (`skeleton/track3/v2`), their id the index of the bone whose frame they are in.
//! Variant 0 of a single person, the animation as converted, has no prefix.
//!
//! A capture bag draws a new body at every scene, so its frames carry the scene's index first
//! ([`scene_frame_prefix`], `scene2/pelvis`): every tf frame then has one rest offset for the
//! whole bag, and no viewer that interpolates transforms over time (Foxglove's and Lichtblick's
//! preloading, tf2's buffer) can blend one scene's body into the next. The markers' namespace and
//! the point clouds' topics leave the scene out, so a new scene's skeleton replaces the last one.
//!
//! A [`TrackWriter`] keeps one message of each kind per person and updates it in place, so a
//! frame costs no allocation however long the animation. [`TfTree`] composes the transforms
//! back as a viewer does, to check what a bag shows.

use crate::mcap_io::{BagWriter, McapIoError};
use crate::ros::autoact_msgs::BoneFrame;
use crate::ros::builtin_interfaces::Time;
use crate::ros::geometry_msgs::{
    BadQuaternion, Point, Quaternion, Transform, TransformStamped, Vector3,
};
use crate::ros::sensor_msgs::PointCloud2;
use crate::ros::std_msgs::{ColorRGBA, Header};
use crate::ros::tf2_msgs::TFMessage;
use crate::ros::visualization_msgs::{Marker, MarkerArray};
use crate::skeleton::character::Character;
use crate::skeleton::fk::{self, BonePose};
use crate::skeleton::frames::WORLD_FRAME;
use crate::skeleton::layout::Coverage;
use crate::skeleton::rig::{Dof, ROOT, Rig};

/// Name of the metadata record that says how the bag was made (the conversion's parameters).
pub const METADATA_NAME: &str = "autoact.convert";
/// Topic of the bone frames.
pub const ANIMATION_TOPIC: &str = "/animation";
/// Topic of the per-frame transforms.
pub const TF_TOPIC: &str = "/tf";
/// Topic of the transforms that never change.
pub const TF_STATIC_TOPIC: &str = "/tf_static";
/// Topic of the skeleton markers.
pub const MARKERS_TOPIC: &str = "/skeleton/markers";
/// How often the skeleton markers are sent again: they never change (they move with their tf
/// frames), so this only bounds how long a viewer that joins late, or a bag cut anywhere, waits
/// for them.
pub const MARKERS_PERIOD_NANOS: u64 = 1_000_000_000;
/// Topic prefix of the skeleton's point clouds: `/skeleton/points/` then the bone's tf frame.
pub const POINTS_TOPIC_PREFIX: &str = "/skeleton/points/";
/// Largest gap between the points drawn along a segment of the skeleton's point clouds, metres:
/// close enough that Rerun's default point size reads as a dotted line (a forearm gets 9
/// points), far enough to keep the clouds' bytes small (2 cm cost a third more).
pub const POINT_SPACING_M: f64 = 0.03;

/// Writes one person's frames.
#[derive(Debug)]
pub struct TrackWriter {
    /// Bones with a `/tf` entry each frame (index into the rig), root first.
    moving: Vec<usize>,
    bone_frame: BoneFrame,
    tf: TFMessage,
    /// The skeleton, in the bones' own frames, where it never changes.
    markers: MarkerArray,
    /// The same skeleton as points, one cloud per marker: (topic, cloud).
    points: Vec<(String, PointCloud2)>,
    /// When the markers last went out.
    markers_sent_nanos: Option<u64>,
    statics: Vec<TransformStamped>,
}

/// The tf frame prefix of person `track_id`'s animation `variant`: `track<id>/` when the bag holds
/// several people, then `v<k>/` for a variant other than 0.
#[must_use]
pub fn frame_prefix(track_id: u64, variant: u32, several_people: bool) -> String {
    let mut prefix = String::new();
    if several_people {
        prefix.push_str(&format!("track{track_id}/"));
    }
    if variant > 0 {
        prefix.push_str(&format!("v{variant}/"));
    }
    prefix
}

/// The tf frame prefix of the character of scene `scene_index` (its index on a capture bag's
/// timeline, from 0): `scene<i>/`, before any [`frame_prefix`].
#[must_use]
pub fn scene_frame_prefix(scene_index: usize) -> String {
    format!("scene{scene_index}/")
}

/// `prefix` without its leading [`scene_frame_prefix`], if any.
fn without_scene(prefix: &str) -> &str {
    match prefix.split_once('/') {
        Some((head, tail))
            if head
                .strip_prefix("scene")
                .is_some_and(|i| !i.is_empty() && i.bytes().all(|b| b.is_ascii_digit())) =>
        {
            tail
        }
        _ => prefix,
    }
}

/// The inverse of [`scene_frame_prefix`] + [`frame_prefix`] + bone name: `(track, variant, bone
/// name)` of a tf frame name written by a [`TrackWriter`] (`track` is `None` when the bag held
/// one person); a scene prefix is skipped (the frame's stamps say which scene it belongs to).
#[must_use]
pub fn parse_frame_name(name: &str) -> (Option<u64>, u32, &str) {
    let mut rest = without_scene(name);
    let mut track = None;
    if let Some((head, tail)) = rest.split_once('/')
        && let Some(id) = head.strip_prefix("track").and_then(|t| t.parse().ok())
    {
        track = Some(id);
        rest = tail;
    }
    let mut variant = 0;
    if let Some((head, tail)) = rest.split_once('/')
        && let Some(v) = head.strip_prefix('v').and_then(|v| v.parse().ok())
    {
        variant = v;
        rest = tail;
    }
    (track, variant, rest)
}

/// A `/tf` or `/tf_static` transform whose rotation is not a usable quaternion.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("tf frame `{child_frame_id}`: {source}")]
pub struct TfRotationError {
    /// The transform's child frame.
    pub child_frame_id: String,
    /// Why the rotation is not usable.
    #[source]
    pub source: BadQuaternion,
}

/// The latest transform of every tf frame, composed as tf viewers (RViz, Foxglove) compose
/// them: what a bag shows at an instant, for checking it.
#[derive(Debug, Clone, Default)]
pub struct TfTree {
    /// Child frame → (parent frame, `parent_from_child`).
    parent_from_child: std::collections::HashMap<String, (String, nalgebra::Isometry3<f64>)>,
}

impl TfTree {
    /// Takes in the transforms of a `/tf` or `/tf_static` message.
    ///
    /// # Errors
    /// [`TfRotationError`]: a transform whose rotation is not a usable quaternion, naming its
    /// child frame.
    pub fn update(&mut self, tf: &TFMessage) -> Result<(), TfRotationError> {
        for t in &tf.transforms {
            let rotation =
                nalgebra::UnitQuaternion::try_from(t.transform.rotation).map_err(|source| {
                    TfRotationError {
                        child_frame_id: t.child_frame_id.clone(),
                        source,
                    }
                })?;
            self.parent_from_child.insert(
                t.child_frame_id.clone(),
                (
                    t.header.frame_id.clone(),
                    nalgebra::Isometry3::from_parts(
                        nalgebra::Vector3::from(t.transform.translation).into(),
                        rotation,
                    ),
                ),
            );
        }
        Ok(())
    }

    /// `world_from_frame` of tf frame `frame`, or `None` when its chain of parents does not
    /// reach the world frame.
    #[must_use]
    pub fn world_from(&self, frame: &str) -> Option<nalgebra::Isometry3<f64>> {
        let mut world_from_frame = nalgebra::Isometry3::identity();
        let mut at = frame;
        // A chain longer than the number of frames has a cycle.
        for _ in 0..=self.parent_from_child.len() {
            if at == WORLD_FRAME {
                return Some(world_from_frame);
            }
            let (parent, parent_from_at) = self.parent_from_child.get(at)?;
            world_from_frame = parent_from_at * world_from_frame;
            at = parent;
        }
        None
    }
}

/// Reads one person's animation (variant 0) back from an animation bag: the `/animation`
/// frames of `track` (`None`: the first track seen), the body from the rest offsets its
/// `/tf_static` and `/tf` carry, and as coverage the bones that move.
///
/// # Errors
/// A message when the bag has no such frames, or their bones are not the rig's.
pub fn read_animation(
    rig: &Rig,
    readers: &[crate::mcap_io::BagReader],
    track: Option<u64>,
) -> Result<ReadBack, ReadAnimationError> {
    read_animation_variant(rig, readers, track, 0)
}

/// One animation an animation bag holds: a person (`track_id`) and one of its variants (0 as
/// converted, 1.. the DSI variants).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct AnimationKey {
    /// The person's tracker id (`BoneFrame.track_id`).
    pub track_id: u64,
    /// The variant (`BoneFrame.variant`).
    pub variant: u32,
}

impl std::fmt::Display for AnimationKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "track {} variant {}", self.track_id, self.variant)
    }
}

/// What [`list_animations`] finds of one animation.
#[derive(Debug, Clone, PartialEq)]
pub struct AnimationListing {
    /// Which animation.
    pub key: AnimationKey,
    /// Its rig's name (`BoneFrame.rig`).
    pub rig: String,
    /// Frames, counted as [`read_animation_variant`] reads them (increasing stamps only).
    pub frames: usize,
    /// Stamp of the first frame, nanoseconds.
    pub first_stamp_nanos: u64,
    /// Stamp of the last frame, nanoseconds.
    pub last_stamp_nanos: u64,
    /// The rate its stamps show, as export measures it ([`crate::skeleton::pose::frame_rate`]: one over
    /// the median step); `None` below two frames.
    pub frame_rate_hz: Option<f64>,
}

/// Every animation (person × variant) of an animation bag's `/animation` frames, ordered by
/// track id, then variant; an empty list means the bag holds no readable `BoneFrame`. What could
/// not be read is dropped: [`list_animations_with_losses`] says what it was.
#[must_use]
pub fn list_animations(readers: &[crate::mcap_io::BagReader]) -> Vec<AnimationListing> {
    list_animations_with_losses(readers).0
}

/// What reading an animation bag could not use: unreadable parts of its files, and messages
/// skipped (undecodable frames and transforms, frames whose stamp does not advance), each with
/// its file, topic and index.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AnimationLosses {
    /// Parts of the files that could not be read (chunks, damaged bytes, a missing summary).
    pub unreadable: Vec<crate::mcap_io::ReadIssue>,
    /// Messages read but not used, and why.
    pub skipped: Vec<super::pose::SkippedMessage>,
}

impl AnimationLosses {
    /// Whether nothing was lost.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.unreadable.is_empty() && self.skipped.is_empty()
    }
}

/// A message of the bag at `path` skipped for `reason`.
fn skipped(
    path: &std::path::Path,
    m: &crate::mcap_io::BagMessage,
    reason: String,
) -> super::pose::SkippedMessage {
    super::pose::SkippedMessage {
        path: path.display().to_string(),
        topic: m.channel.topic.clone(),
        index: m.index_on_channel,
        log_time: m.log_time,
        reason,
    }
}

/// Every message of `readers` in file order, with the file each comes from; what cannot be read
/// goes to `losses`.
fn messages_of<'r>(
    readers: &'r [crate::mcap_io::BagReader],
    losses: &'r mut AnimationLosses,
) -> impl Iterator<Item = (&'r std::path::Path, crate::mcap_io::BagMessage)> + 'r {
    readers
        .iter()
        .flat_map(|r| r.messages().map(move |m| (r.path(), m)))
        .filter_map(move |(path, m)| match m {
            Ok(m) => Some((path, m)),
            Err(issue) => {
                losses.unreadable.push(issue);
                None
            }
        })
}

/// As [`list_animations`], with what could not be read or decoded.
#[must_use]
pub fn list_animations_with_losses(
    readers: &[crate::mcap_io::BagReader],
) -> (Vec<AnimationListing>, AnimationLosses) {
    use crate::ros::{RosMessage, cdr};
    // Per animation: its rig, and its stamps as the reader keeps them (increasing only).
    let mut found: std::collections::BTreeMap<AnimationKey, (String, Vec<u64>)> =
        std::collections::BTreeMap::new();
    let mut f = BoneFrame::default();
    let mut losses = AnimationLosses::default();
    let mut undecodable = Vec::new();
    for (path, m) in messages_of(readers, &mut losses)
        .filter(|(_, m)| m.channel.schema_name() == BoneFrame::TYPE_NAME)
    {
        if let Err(e) = cdr::decode_in_place(&m.data, &mut f) {
            undecodable.push(skipped(
                path,
                &m,
                format!("does not decode as a BoneFrame: {e}"),
            ));
            continue;
        }
        let key = AnimationKey {
            track_id: f.track_id,
            variant: f.variant,
        };
        let stamp = frame_stamp(&f, m.log_time);
        let (_, stamps) = found
            .entry(key)
            .or_insert_with(|| (f.rig.clone(), Vec::new()));
        if stamps.last().is_none_or(|&last| stamp > last) {
            stamps.push(stamp);
        }
    }
    losses.skipped.extend(undecodable);
    let listing = found
        .into_iter()
        .filter_map(|(key, (rig, stamps))| {
            Some(AnimationListing {
                key,
                rig,
                frames: stamps.len(),
                first_stamp_nanos: *stamps.first()?,
                last_stamp_nanos: *stamps.last()?,
                frame_rate_hz: crate::skeleton::pose::frame_rate(None, &stamps),
            })
        })
        .collect();
    (listing, losses)
}

/// Reads one animation back from an animation bag: the `/animation` frames of `track` (`None`:
/// the first track seen) and `variant`, the body from the rest offsets its `/tf_static` and `/tf`
/// carry (the variant's own frames, `v<k>/…`, where the bag has them, else variant 0's), and as
/// coverage the bones that move. What could not be used is dropped:
/// [`read_animation_variant_with_losses`] says what it was.
///
/// # Errors
/// [`ReadAnimationError`]: the bag has no such frames, or their bones are not the rig's.
pub fn read_animation_variant(
    rig: &Rig,
    readers: &[crate::mcap_io::BagReader],
    track: Option<u64>,
    variant: u32,
) -> Result<ReadBack, ReadAnimationError> {
    read_animation_variant_with_losses(rig, readers, track, variant).map(|(back, _)| back)
}

/// As [`read_animation_variant`], with what was lost: unreadable parts of the files, and every
/// message skipped with its file, topic and index — `BoneFrame`s and transforms that do not
/// decode, and the animation's frames whose stamp does not advance past the frame before.
///
/// # Errors
/// [`ReadAnimationError`]: the bag has no such frames, or their bones are not the rig's.
pub fn read_animation_variant_with_losses(
    rig: &Rig,
    readers: &[crate::mcap_io::BagReader],
    track: Option<u64>,
    variant: u32,
) -> Result<(ReadBack, AnimationLosses), ReadAnimationError> {
    let (periods, losses) = read_animation_periods_with_losses(rig, readers, track, variant, &[])?;
    let Some(PeriodAnimation {
        frames, character, ..
    }) = periods.into_iter().next()
    else {
        return Err(ReadAnimationError::NoFrames { track, variant });
    };
    let coverage = coverage_of(rig, &frames);
    Ok(((frames, character, coverage), losses))
}

/// The frames of one animation that fall in one period of the bag's timeline, and the body the
/// rest offsets of that period describe.
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodAnimation {
    /// Index of the period: frames stamped from `starts[period]` (inclusive) to
    /// `starts[period + 1]` (exclusive); period 0 also takes what comes before `starts[0]`.
    pub period: usize,
    /// The animation's frames in the period, in stamp order.
    pub frames: Vec<crate::skeleton::convert::AnimationFrame>,
    /// The body: the rest offsets the `/tf_static` and `/tf` transforms stamped in the period
    /// carry (the standard rig's where they carry none).
    pub character: Character,
}

/// As [`read_animation_variant_with_losses`], with the bag's timeline cut at `starts` (sorted
/// stamps, ns; empty: one period): per period that holds frames of the animation, those frames
/// and the body of that period. A capture bag draws a new character for every scene and
/// publishes its rest on `/tf_static` at the scene's start, so with the scenes' starts each scene
/// gets its own body; with no starts this is [`read_animation_variant_with_losses`]'s one body
/// (the first offset seen of every bone).
///
/// # Errors
/// [`ReadAnimationError`]: the bag has no such frames, or their bones are not the rig's.
pub fn read_animation_periods_with_losses(
    rig: &Rig,
    readers: &[crate::mcap_io::BagReader],
    track: Option<u64>,
    variant: u32,
    starts: &[u64],
) -> Result<(Vec<PeriodAnimation>, AnimationLosses), ReadAnimationError> {
    use crate::ros::{RosMessage, cdr};
    let period_of = |stamp: u64| starts.partition_point(|&s| s <= stamp).saturating_sub(1);
    let mut keys: Vec<crate::skeleton::convert::AnimationFrame> = Vec::new();
    let mut chosen = track;
    let mut offsets: Vec<RestOffsets> = (0..starts.len().max(1))
        .map(|_| RestOffsets::new())
        .collect();
    let mut f = BoneFrame::default();
    let mut losses = AnimationLosses::default();
    let mut skips = Vec::new();
    for (path, m) in messages_of(readers, &mut losses) {
        match m.channel.schema_name() {
            s if s == BoneFrame::TYPE_NAME => {
                if let Err(e) = cdr::decode_in_place(&m.data, &mut f) {
                    skips.push(skipped(
                        path,
                        &m,
                        format!("does not decode as a BoneFrame: {e}"),
                    ));
                    continue;
                }
                if f.variant != variant || *chosen.get_or_insert(f.track_id) != f.track_id {
                    continue;
                }
                let stamp = frame_stamp(&f, m.log_time);
                if let Some(last) = keys.last().map(|k| k.stamp_nanos)
                    && last >= stamp
                {
                    let reason = format!(
                        "track {} variant {variant}: stamp {stamp} ns does not advance past the frame before ({last} ns)",
                        f.track_id
                    );
                    skips.push(skipped(path, &m, reason));
                    continue;
                }
                let pose = bone_pose(rig, &f).map_err(|source| ReadAnimationError::Frame {
                    index: m.index_on_channel,
                    stamp_nanos: stamp,
                    source,
                })?;
                keys.push(crate::skeleton::convert::AnimationFrame {
                    stamp_nanos: stamp,
                    pose,
                });
            }
            s if s == TFMessage::TYPE_NAME
                && (m.channel.topic == TF_STATIC_TOPIC || m.channel.topic == TF_TOPIC) =>
            {
                match cdr::decode::<TFMessage>(&m.data) {
                    Ok(tf) => {
                        let stamp = tf
                            .transforms
                            .first()
                            .and_then(|t| t.header.stamp.to_nanos())
                            .unwrap_or(m.log_time);
                        offsets[period_of(stamp)].add(rig, &tf, variant);
                    }
                    Err(e) => skips.push(skipped(
                        path,
                        &m,
                        format!("does not decode as a TFMessage: {e}"),
                    )),
                }
            }
            _ => {}
        }
    }
    losses.skipped.extend(skips);
    if keys.is_empty() {
        return Err(ReadAnimationError::NoFrames { track, variant });
    }
    let mut periods: Vec<PeriodAnimation> = Vec::new();
    for key in keys {
        let period = period_of(key.stamp_nanos);
        match periods.last_mut() {
            Some(last) if last.period == period => last.frames.push(key),
            _ => periods.push(PeriodAnimation {
                period,
                frames: vec![key],
                character: Character::standard(rig),
            }),
        }
    }
    for (p, o) in offsets.into_iter().enumerate() {
        if let Some(at) = periods.iter_mut().find(|a| a.period == p) {
            at.character = o.character(rig, chosen);
        }
    }
    Ok((periods, losses))
}

/// As coverage, the bones that move in `frames` and those that do not.
fn coverage_of(rig: &Rig, frames: &[crate::skeleton::convert::AnimationFrame]) -> Coverage {
    let poses: Vec<BonePose> = frames.iter().map(|k| k.pose.clone()).collect();
    let moving = fk::moving_bones(&poses);
    let names = |wanted: bool| -> Vec<String> {
        rig.bones
            .iter()
            .zip(&moving)
            .filter(|(_, m)| **m == wanted)
            .map(|(b, _)| b.name.clone())
            .collect()
    };
    Coverage {
        driven: names(true),
        twist_unobserved: Vec::new(),
        at_rest: names(false),
    }
}

/// Rest offsets seen on `/tf_static` and `/tf`, per (track prefix, variant, bone), for variant 0
/// and the variant read; the first one wins.
struct RestOffsets(std::collections::BTreeMap<(Option<u64>, u32, usize), nalgebra::Vector3<f64>>);

impl RestOffsets {
    fn new() -> RestOffsets {
        RestOffsets(std::collections::BTreeMap::new())
    }

    /// Notes the offsets `tf` carries for variant 0 and `variant`.
    fn add(&mut self, rig: &Rig, tf: &TFMessage, variant: u32) {
        for t in &tf.transforms {
            let (frame_track, frame_variant, bone) = parse_frame_name(&t.child_frame_id);
            if let Some(b) = rig.bone_index(bone)
                && b != ROOT
                && (frame_variant == 0 || frame_variant == variant)
            {
                self.0
                    .entry((frame_track, frame_variant, b))
                    .or_insert_with(|| nalgebra::Vector3::from(t.transform.translation));
            }
        }
    }

    /// The body of track `chosen`: variant 0's offsets first, then the variant's own (the map's
    /// order puts them after); prefixed frames belong to their track, unprefixed ones to the
    /// bag's only person.
    fn character(self, rig: &Rig, chosen: Option<u64>) -> Character {
        let mut character = Character::standard(rig);
        for ((frame_track, _, b), offset) in self.0 {
            if frame_track.is_none() || frame_track == chosen {
                character.head_offset_m[b] = offset;
            }
        }
        character
    }
}

/// A bone frame's time: its header stamp, or `log_time_nanos` where the header has none.
#[must_use]
pub fn frame_stamp(frame: &BoneFrame, log_time_nanos: u64) -> u64 {
    frame.header.stamp.to_nanos().unwrap_or(log_time_nanos)
}

/// An animation read back: its frames in stamp order, the body its rest offsets describe, and as
/// coverage the bones that move.
pub type ReadBack = (
    Vec<crate::skeleton::convert::AnimationFrame>,
    Character,
    Coverage,
);

/// Why an animation cannot be read back from an animation bag.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ReadAnimationError {
    /// A frame's bones do not fit the rig.
    #[error("{ANIMATION_TOPIC} message {index} (stamp {stamp_nanos} ns): {source}")]
    Frame {
        /// The message's index on its channel.
        index: u64,
        /// Its stamp.
        stamp_nanos: u64,
        /// What does not fit.
        #[source]
        source: BonePoseError,
    },
    /// The bag holds no frames of the animation asked for.
    #[error("no {ANIMATION_TOPIC} frames{}", animation_named(*track, *variant))]
    NoFrames {
        /// The track asked for (`None`: any).
        track: Option<u64>,
        /// The variant asked for.
        variant: u32,
    },
}

/// " of track T variant V", as much of it as names what was asked for.
fn animation_named(track: Option<u64>, variant: u32) -> String {
    match (track, variant) {
        (Some(t), 0) => format!(" of track {t}"),
        (Some(t), v) => format!(" of track {t} variant {v}"),
        (None, 0) => String::new(),
        (None, v) => format!(" of variant {v}"),
    }
}

/// A bone frame that does not fit the rig.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BonePoseError {
    /// Not one rotation per bone of the rig.
    #[error("{rotations} rotations; rig {rig} has {bones} bones")]
    RotationCount {
        /// Rotations in the frame.
        rotations: usize,
        /// The rig's name.
        rig: &'static str,
        /// Bones of the rig.
        bones: usize,
    },
    /// Bone names given, but not one per rotation.
    #[error("{names} bone names for {rotations} rotations")]
    NameCount {
        /// Names in the frame.
        names: usize,
        /// Rotations in the frame.
        rotations: usize,
    },
    /// A bone named otherwise than the rig names it.
    #[error("rig `{frame_rig}` names bone {index} `{theirs}`, where rig {rig} has `{ours}`")]
    BoneName {
        /// The rig the frame names.
        frame_rig: String,
        /// The bone's index.
        index: usize,
        /// The frame's name for it.
        theirs: String,
        /// Our rig's name.
        rig: &'static str,
        /// Our rig's name for it.
        ours: String,
    },
    /// A rotation that is not a usable quaternion.
    #[error("bone `{bone}`: {source}")]
    Rotation {
        /// The bone.
        bone: String,
        /// Why.
        #[source]
        source: BadQuaternion,
    },
}

/// The pose a bone frame carries, on `rig`: one rotation per bone in rig order (names, where the
/// frame has them, must be the rig's), each a usable quaternion (normalised here). The one place
/// a `BoneFrame` becomes a [`BonePose`].
///
/// # Errors
/// [`BonePoseError`]: what does not fit the rig, naming the bone.
pub fn bone_pose(rig: &Rig, frame: &BoneFrame) -> Result<BonePose, BonePoseError> {
    if frame.local_rotations.len() != rig.bones.len() {
        return Err(BonePoseError::RotationCount {
            rotations: frame.local_rotations.len(),
            rig: rig.name,
            bones: rig.bones.len(),
        });
    }
    if !frame.bone_names.is_empty() {
        if frame.bone_names.len() != rig.bones.len() {
            return Err(BonePoseError::NameCount {
                names: frame.bone_names.len(),
                rotations: frame.local_rotations.len(),
            });
        }
        if let Some((k, (theirs, ours))) = frame
            .bone_names
            .iter()
            .zip(&rig.bones)
            .enumerate()
            .find(|(_, (theirs, ours))| **theirs != ours.name)
        {
            return Err(BonePoseError::BoneName {
                frame_rig: frame.rig.clone(),
                index: k,
                theirs: theirs.clone(),
                rig: rig.name,
                ours: ours.name.clone(),
            });
        }
    }
    let local_rotations = frame
        .local_rotations
        .iter()
        .zip(&rig.bones)
        .map(|(&q, bone)| {
            nalgebra::UnitQuaternion::try_from(q).map_err(|source| BonePoseError::Rotation {
                bone: bone.name.clone(),
                source,
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(BonePose {
        root_translation_m: nalgebra::Vector3::from(frame.root_translation),
        local_rotations,
    })
}

fn frame_name(prefix: &str, rig: &Rig, bone: usize) -> String {
    format!("{prefix}{}", rig.bones[bone].name)
}

/// The marker namespace of the animation whose tf frames are prefixed `prefix`: `skeleton`, then
/// the prefix (`skeleton/track3/v2`).
fn marker_namespace(prefix: &str) -> String {
    let prefix = prefix.trim_end_matches('/');
    if prefix.is_empty() {
        "skeleton".to_string()
    } else {
        format!("skeleton/{prefix}")
    }
}

/// The line skeleton of one animation: for every bone `p` with drawn children, one frame-locked
/// `LINE_LIST` marker in `p`'s own tf frame (id `p`), a segment from its head (the frame's origin)
/// to each drawn child's head (the child's rest offset, constant in that frame). RViz and
/// Foxglove move each marker with its frame from `/tf`, so the markers carry no motion and never
/// change. `draws(p, c)` says whether the segment from parent
/// `p` to child `c` is drawn; segments from the root (on the ground) never are.
fn skeleton_markers(
    rig: &Rig,
    character: &Character,
    prefix: &str,
    draws: impl Fn(usize, usize) -> bool,
) -> MarkerArray {
    let mut markers: Vec<Marker> = Vec::new();
    let mut marker_of = vec![None; rig.bones.len()];
    for (c, bone) in rig.bones.iter().enumerate() {
        let Some(p) = bone.parent.filter(|&p| p != ROOT && draws(p, c)) else {
            continue;
        };
        let k = *marker_of[p].get_or_insert_with(|| {
            markers.push(Marker {
                header: Header {
                    stamp: Time::default(),
                    frame_id: frame_name(prefix, rig, p),
                },
                ns: marker_namespace(without_scene(prefix)),
                id: i32::try_from(p).expect("internal bug: a rig has fewer than 2^31 bones"),
                type_: Marker::LINE_LIST,
                action: Marker::ADD,
                scale: Vector3 {
                    x: 0.02,
                    y: 0.0,
                    z: 0.0,
                },
                color: ColorRGBA {
                    r: 0.1,
                    g: 0.7,
                    b: 1.0,
                    a: 1.0,
                },
                frame_locked: true,
                ..Marker::default()
            });
            markers.len() - 1
        });
        markers[k].points.extend([
            Point::default(),
            Point::from(nalgebra::Point3::from(character.head_offset_m[c])),
        ]);
    }
    MarkerArray { markers }
}

/// The skeleton's point clouds, for viewers that draw no markers (Rerun): per marker of
/// [`skeleton_markers`], a cloud in the same frame on `/skeleton/points/<topic prefix><bone>`,
/// holding the frame's origin and points along each of its segments at most [`POINT_SPACING_M`]
/// apart, each segment's far end included.
fn skeleton_points(
    markers: &MarkerArray,
    rig: &Rig,
    topic_prefix: &str,
) -> Vec<(String, PointCloud2)> {
    #[expect(
        clippy::cast_possible_truncation,
        reason = "metres on a body, well within f32"
    )]
    let f32_point = |p: nalgebra::Point3<f64>| [p.x as f32, p.y as f32, p.z as f32];
    markers
        .markers
        .iter()
        .map(|marker| {
            let mut points = vec![[0.0_f32; 3]];
            for pair in marker.points.chunks_exact(2) {
                let [a, b] = [pair[0], pair[1]].map(nalgebra::Point3::from);
                #[expect(
                    clippy::cast_possible_truncation,
                    clippy::cast_sign_loss,
                    reason = "a bone's length over 3 cm: a small positive count"
                )]
                let steps = ((b - a).norm() / POINT_SPACING_M).ceil().max(1.0) as usize;
                #[expect(clippy::cast_precision_loss, reason = "small counts")]
                points.extend(
                    (1..=steps).map(|k| f32_point(a + (b - a) * (k as f64 / steps as f64))),
                );
            }
            let bone =
                usize::try_from(marker.id).expect("internal bug: marker ids are bone indices");
            (
                format!(
                    "{POINTS_TOPIC_PREFIX}{}",
                    frame_name(topic_prefix, rig, bone)
                ),
                PointCloud2::xyz(marker.header.clone(), &points),
            )
        })
        .collect()
}

impl TrackWriter {
    /// A writer for person `track_id`'s animation `variant`, with tf frame names prefixed by
    /// `prefix` (see [`frame_prefix`]), animated on `character` with the bones `coverage` says its
    /// data drives.
    #[must_use]
    pub fn new(
        rig: &Rig,
        character: &Character,
        coverage: &Coverage,
        track_id: u64,
        variant: u32,
        prefix: &str,
    ) -> TrackWriter {
        let moves = |b: usize| {
            b == ROOT
                || (!matches!(rig.bones[b].dof, Dof::Static)
                    && !coverage.at_rest.contains(&rig.bones[b].name))
        };
        let moving: Vec<usize> = (0..rig.bones.len()).filter(|&b| moves(b)).collect();
        let transform = |b: usize| TransformStamped {
            header: Header {
                stamp: Time::default(),
                frame_id: rig.bones[b]
                    .parent
                    .map_or_else(|| WORLD_FRAME.to_string(), |p| frame_name(prefix, rig, p)),
            },
            child_frame_id: frame_name(prefix, rig, b),
            transform: Transform {
                translation: Vector3::from(character.head_offset_m[b]),
                rotation: Quaternion::default(),
            },
        };
        let statics = (0..rig.bones.len())
            .filter(|&b| !moves(b))
            .map(transform)
            .collect();
        let tf = TFMessage {
            transforms: moving.iter().map(|&b| transform(b)).collect(),
        };
        // Segments of what the data drives, and the rigid torso it hangs on: bones a layout cannot
        // see (fingers from a body-only estimator) would only draw the rest pose.
        let at_rest = |b: usize| coverage.at_rest.contains(&rig.bones[b].name);
        let header = Header {
            stamp: Time::default(),
            frame_id: WORLD_FRAME.to_string(),
        };
        let markers = skeleton_markers(rig, character, prefix, |p, c| {
            character.head_offset_m[c].norm() > 1e-6 && !at_rest(p)
        });
        let points = skeleton_points(&markers, rig, without_scene(prefix));
        TrackWriter {
            bone_frame: BoneFrame {
                header,
                rig: rig.name.to_string(),
                track_id,
                variant,
                bone_names: rig.bones.iter().map(|b| b.name.clone()).collect(),
                local_rotations: vec![Quaternion::default(); rig.bones.len()],
                root_translation: Vector3::default(),
            },
            tf,
            points,
            markers,
            markers_sent_nanos: None,
            moving,
            statics,
        }
    }

    /// Transforms that never change, stamped `stamp`, for `/tf_static`.
    #[must_use]
    pub fn static_transforms(&self, stamp: u64) -> Vec<TransformStamped> {
        let mut out = self.statics.clone();
        for t in &mut out {
            t.header.stamp = Time::from_nanos(stamp);
        }
        out
    }

    /// Writes one frame at `stamp`: `/animation` and `/tf`, and `/skeleton/markers` and the
    /// `/skeleton/points/…` clouds with the first frame and then once a second
    /// ([`MARKERS_PERIOD_NANOS`]).
    ///
    /// # Errors
    /// [`McapIoError`] from the writer.
    pub fn write_frame<W: std::io::Write + std::io::Seek>(
        &mut self,
        writer: &mut BagWriter<W>,
        stamp: u64,
        pose: &BonePose,
    ) -> Result<(), McapIoError> {
        let time = Time::from_nanos(stamp);
        self.bone_frame.header.stamp = time;
        for (q, p) in self
            .bone_frame
            .local_rotations
            .iter_mut()
            .zip(&pose.local_rotations)
        {
            *q = Quaternion::from(*p);
        }
        self.bone_frame.root_translation = Vector3::from(pose.root_translation_m);
        writer.write(ANIMATION_TOPIC, stamp, &self.bone_frame)?;

        for (t, &b) in self.tf.transforms.iter_mut().zip(&self.moving) {
            t.header.stamp = time;
            t.transform.rotation = Quaternion::from(pose.local_rotations[b]);
            if b == ROOT {
                t.transform.translation = Vector3::from(pose.root_translation_m);
            }
        }
        writer.write(TF_TOPIC, stamp, &self.tf)?;

        if self
            .markers_sent_nanos
            .is_none_or(|sent| stamp.saturating_sub(sent) >= MARKERS_PERIOD_NANOS)
        {
            for marker in &mut self.markers.markers {
                marker.header.stamp = time;
            }
            writer.write(MARKERS_TOPIC, stamp, &self.markers)?;
            for (topic, cloud) in &mut self.points {
                cloud.header.stamp = time;
                writer.write(topic, stamp, cloud)?;
            }
            self.markers_sent_nanos = Some(stamp);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_names_parse_back_to_what_the_prefix_wrote() {
        for (track, variant, several) in [(0, 0, false), (3, 0, true), (0, 2, false), (12, 7, true)]
        {
            let name = format!("{}l_forearm", frame_prefix(track, variant, several));
            let (t, v, bone) = parse_frame_name(&name);
            assert_eq!(
                (t, v, bone),
                (several.then_some(track), variant, "l_forearm"),
                "{name}"
            );
        }
        assert_eq!(parse_frame_name("root"), (None, 0, "root"));
        let scened = format!(
            "{}{}l_hand",
            scene_frame_prefix(12),
            frame_prefix(4, 2, true)
        );
        assert_eq!(parse_frame_name(&scened), (Some(4), 2, "l_hand"));
        assert_eq!(without_scene("scene3/v1/"), "v1/");
        // Only `scene<digits>/` is a scene prefix.
        assert_eq!(without_scene("scenery/"), "scenery/");
        assert_eq!(without_scene("scene/"), "scene/");
    }

    /// A bag of person `track`'s animation `variant` (tf frames prefixed as with several
    /// people) on a body of `scale`: `frames` frames at `fps` in which every bone `layout` drives
    /// turns and the root travels; with the rig, the body, the coverage and the poses written.
    struct MovingTrack {
        rig: Rig,
        character: Character,
        coverage: Coverage,
        poses: Vec<BonePose>,
        stamps: Vec<u64>,
        path: std::path::PathBuf,
        _dir: tempfile::TempDir,
    }

    fn moving_track(
        layout: &str,
        scale: f64,
        (track_id, variant): (u64, u32),
        fps: f64,
        frames: usize,
    ) -> MovingTrack {
        let rig = Rig::standard();
        let coverage = crate::skeleton::layout::Layout::builtin(layout)
            .unwrap()
            .bind(&rig)
            .unwrap()
            .coverage(&rig);
        let character = Character::from_scales(&rig, vec![scale; rig.bones.len()]);
        let prefix = frame_prefix(track_id, variant, true);
        let mut track = TrackWriter::new(&rig, &character, &coverage, track_id, variant, &prefix);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.mcap");
        let mut w =
            crate::mcap_io::BagWriter::create(&path, crate::mcap_io::WriteConfig::default())
                .unwrap();
        let statics = TFMessage {
            transforms: track.static_transforms(0),
        };
        w.write(TF_STATIC_TOPIC, 0, &statics).unwrap();
        let pose_at = |k: usize| {
            let mut pose = BonePose::rest(&rig);
            #[expect(clippy::cast_precision_loss, reason = "small numbers")]
            for (b, q) in pose.local_rotations.iter_mut().enumerate() {
                // What convert gives: static bones and bones the layout cannot see stay at rest.
                if matches!(rig.bones[b].dof, Dof::Static)
                    || coverage.at_rest.contains(&rig.bones[b].name)
                {
                    continue;
                }
                let angle = 0.02 * (k + b) as f64;
                *q = nalgebra::UnitQuaternion::from_axis_angle(&nalgebra::Vector3::x_axis(), angle)
                    * nalgebra::UnitQuaternion::from_axis_angle(
                        &nalgebra::Vector3::z_axis(),
                        -angle,
                    );
            }
            #[expect(clippy::cast_precision_loss, reason = "small numbers")]
            let x = 0.01 * k as f64;
            pose.root_translation_m = nalgebra::Vector3::new(x, -0.5, 0.02);
            pose
        };
        let poses: Vec<BonePose> = (0..frames).map(pose_at).collect();
        let stamps: Vec<u64> = (0..frames)
            .map(|k| crate::skeleton::pose::stamp_nanos_at(k, fps))
            .collect();
        for (pose, &t) in poses.iter().zip(&stamps) {
            track.write_frame(&mut w, t, pose).unwrap();
        }
        w.finish().unwrap();
        MovingTrack {
            rig,
            character,
            coverage,
            poses,
            stamps,
            path,
            _dir: dir,
        }
    }

    #[test]
    fn markers_in_the_bone_frames_draw_the_skeleton_where_forward_kinematics_puts_it() {
        // 2.5 s at 30 fps.
        let MovingTrack {
            rig,
            character,
            coverage,
            poses,
            stamps,
            path,
            _dir,
        } = moving_track("h36m-17", 1.1, (3, 2), 30.0, 75);
        // Replay the bag as a viewer does: tf as it arrives, the markers that were last sent.
        let mut tf_tree = TfTree::default();
        let mut markers: Option<MarkerArray> = None;
        let mut marker_stamps = Vec::new();
        let (mut frame, mut placed) = (0, 0);
        let reader = crate::mcap_io::BagReader::open(&path).unwrap();
        for m in reader.messages().map(Result::unwrap) {
            match m.channel.topic.as_str() {
                TF_STATIC_TOPIC | TF_TOPIC => {
                    let tf: TFMessage = crate::ros::cdr::decode(&m.data).unwrap();
                    tf_tree.update(&tf).unwrap();
                }
                MARKERS_TOPIC => {
                    markers = Some(crate::ros::cdr::decode(&m.data).unwrap());
                    marker_stamps.push(m.log_time);
                }
                _ => {}
            }
            if m.channel.topic != TF_TOPIC {
                continue;
            }
            let world = fk::forward(&rig, &character, &poses[frame], 1.0);
            frame += 1;
            // The markers last sent (they never change); the first come after the first /tf.
            let Some(markers) = &markers else { continue };
            placed += 1;
            let mut segments = 0;
            for marker in &markers.markers {
                assert!(marker.frame_locked && marker.type_ == Marker::LINE_LIST);
                assert_eq!(marker.ns, "skeleton/track3/v2");
                let (track, variant, bone) = parse_frame_name(&marker.header.frame_id);
                assert_eq!((track, variant), (Some(3), 2));
                let p = rig.bone_index(bone).unwrap();
                assert!(
                    !coverage.at_rest.contains(&rig.bones[p].name),
                    "{bone} is at rest"
                );
                let world_from_p = tf_tree.world_from(&marker.header.frame_id).unwrap();
                for pair in marker.points.chunks_exact(2) {
                    let [a, b] =
                        [pair[0], pair[1]].map(|q| world_from_p * nalgebra::Point3::from(q));
                    assert!(
                        (a - world.heads_m[p]).norm() < 1e-9,
                        "{bone}: {a} {}",
                        world.heads_m[p]
                    );
                    let child = (0..rig.bones.len())
                        .filter(|&c| rig.bones[c].parent == Some(p))
                        .min_by(|&c, &d| {
                            (b - world.heads_m[c])
                                .norm()
                                .total_cmp(&(b - world.heads_m[d]).norm())
                        })
                        .unwrap();
                    assert!(
                        (b - world.heads_m[child]).norm() < 1e-9,
                        "{bone} → {}",
                        rig.bones[child].name
                    );
                    segments += 1;
                }
            }
            // Hips to thighs, thighs to calves to feet, the spine to the neck and head, the
            // clavicles, arms and forearms to the hands: 19. Nothing from a hand or a foot, whose
            // fingers and toes an H36M-17 layout cannot see.
            assert_eq!(segments, 19);
        }
        assert_eq!((frame, placed), (stamps.len(), stamps.len() - 1));
        // The markers never change: sent with the first frame, then once a second.
        assert_eq!(marker_stamps, [stamps[0], stamps[30], stamps[60]]);
    }

    #[test]
    fn point_clouds_in_the_bone_frames_draw_the_segments_where_forward_kinematics_puts_them() {
        use crate::ros::RosMessage;
        // 1.5 s at 20 fps: the clouds go with the first frame and at 1 s.
        let MovingTrack {
            rig,
            character,
            coverage: _,
            poses,
            stamps,
            path,
            _dir,
        } = moving_track("coco-17", 0.9, (5, 0), 20.0, 30);
        // Replay as Rerun does: tf as it arrives, the latest cloud of each topic.
        let mut tf_tree = TfTree::default();
        let mut clouds = std::collections::BTreeMap::<String, PointCloud2>::new();
        let mut markers: Option<MarkerArray> = None;
        let mut cloud_stamps = Vec::new();
        let (mut frame, mut placed) = (0, 0);
        let reader = crate::mcap_io::BagReader::open(&path).unwrap();
        for m in reader.messages().map(Result::unwrap) {
            let topic = m.channel.topic.as_str();
            if topic == TF_TOPIC || topic == TF_STATIC_TOPIC {
                tf_tree
                    .update(&crate::ros::cdr::decode(&m.data).unwrap())
                    .unwrap();
            } else if topic == MARKERS_TOPIC {
                markers = Some(crate::ros::cdr::decode(&m.data).unwrap());
            } else if let Some(bone_frame) = topic.strip_prefix(POINTS_TOPIC_PREFIX) {
                assert_eq!(m.channel.schema_name(), PointCloud2::TYPE_NAME);
                let cloud: PointCloud2 = crate::ros::cdr::decode(&m.data).unwrap();
                // Frame ids: the topic names the cloud's own frame, a bone of this person.
                assert_eq!(cloud.header.frame_id, bone_frame);
                assert_eq!(cloud.header.stamp.to_nanos(), Some(m.log_time));
                assert_eq!(parse_frame_name(bone_frame).0, Some(5));
                cloud_stamps.push(m.log_time);
                clouds.insert(topic.to_string(), cloud);
            }
            if topic != TF_TOPIC {
                continue;
            }
            let world = fk::forward(&rig, &character, &poses[frame], 1.0);
            frame += 1;
            // One cloud per marker, in the marker's frame; the first come after the first /tf.
            let Some(markers) = &markers else { continue };
            placed += 1;
            assert_eq!(clouds.len(), markers.markers.len());
            let mut segments = 0;
            for marker in &markers.markers {
                let id = &marker.header.frame_id;
                let cloud = &clouds[&format!("{POINTS_TOPIC_PREFIX}{id}")];
                let p = rig.bone_index(parse_frame_name(id).2).unwrap();
                let world_from_p = tf_tree.world_from(id).unwrap();
                let points: Vec<nalgebra::Point3<f64>> = cloud
                    .xyz_points()
                    .unwrap()
                    .iter()
                    .map(|q| world_from_p * nalgebra::Point3::from(q.map(f64::from)))
                    .collect();
                // The bone's head, then each segment's points up to the child's head.
                assert!((points[0] - world.heads_m[p]).norm() < 1e-5, "{id}");
                let mut from = world.heads_m[p];
                let mut rest = &points[1..];
                for pair in marker.points.chunks_exact(2) {
                    let child = world_from_p * nalgebra::Point3::from(pair[1]);
                    let c = (0..rig.bones.len())
                        .find(|&c| {
                            rig.bones[c].parent == Some(p)
                                && (world.heads_m[c] - child).norm() < 1e-9
                        })
                        .unwrap();
                    let end = rest
                        .iter()
                        .position(|q| (q - world.heads_m[c]).norm() < 1e-5)
                        .unwrap_or_else(|| panic!("{id}: no point at {}", rig.bones[c].name));
                    let mut at = from;
                    for q in &rest[..=end] {
                        let along = (q - from).dot(&(child - from).normalize());
                        let off = ((q - from) - (child - from).normalize() * along).norm();
                        assert!(off < 1e-5, "{id}: {q} is off the segment by {off}");
                        assert!(
                            (q - at).norm() <= POINT_SPACING_M + 1e-5,
                            "{id}: gap at {q}"
                        );
                        at = *q;
                    }
                    from = world.heads_m[p];
                    rest = &rest[end + 1..];
                    segments += 1;
                }
                assert!(
                    rest.is_empty(),
                    "{id}: {} points past the segments",
                    rest.len()
                );
            }
            // COCO-17 sees no spine bends, clavicles, hands or feet: hips to thighs, knees and
            // ankles; the torso to the neck and head; shoulders, elbows and wrists.
            assert!(segments >= 10, "{segments}");
        }
        assert_eq!((frame, placed), (stamps.len(), stamps.len() - 1));
        let sends = cloud_stamps.len() / clouds.len();
        assert_eq!(cloud_stamps.len(), sends * clouds.len());
        cloud_stamps.dedup();
        assert_eq!(cloud_stamps, [stamps[0], stamps[20]]);
        assert_eq!(sends, 2);
    }

    /// A frame as `TrackWriter` writes it for `pose`.
    fn frame_of(rig: &Rig, pose: &BonePose) -> BoneFrame {
        BoneFrame {
            rig: rig.name.to_string(),
            bone_names: rig.bones.iter().map(|b| b.name.clone()).collect(),
            local_rotations: pose
                .local_rotations
                .iter()
                .map(|&q| Quaternion::from(q))
                .collect(),
            root_translation: Vector3::from(pose.root_translation_m),
            ..BoneFrame::default()
        }
    }

    #[test]
    fn a_listing_measures_the_rate_as_export_does_and_counts_what_export_reads() {
        let rig = Rig::standard();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.mcap");
        let mut w =
            crate::mcap_io::BagWriter::create(&path, crate::mcap_io::WriteConfig::default())
                .unwrap();
        let mut frame = frame_of(&rig, &BonePose::rest(&rig));
        // 30 fps with a 2 s hole (a mean over first and last stamps would say about 9 fps),
        // and one repeated stamp, which the reader skips.
        let mut stamps: Vec<u64> = (0..10)
            .map(|k| crate::skeleton::pose::stamp_nanos_at(k, 30.0))
            .collect();
        stamps.push(stamps[9]);
        stamps.extend((70..80).map(|k| crate::skeleton::pose::stamp_nanos_at(k, 30.0)));
        for &t in &stamps {
            frame.header.stamp = Time::from_nanos(t);
            w.write(ANIMATION_TOPIC, t, &frame).unwrap();
        }
        w.finish().unwrap();
        let readers = [crate::mcap_io::BagReader::open(&path).unwrap()];
        let [listing] = list_animations(&readers).try_into().unwrap();
        assert_eq!(listing.frames, 20);
        assert_eq!(listing.last_stamp_nanos, stamps[20]);
        assert!(
            (listing.frame_rate_hz.unwrap() - 30.0).abs() < 1e-6,
            "{listing:?}"
        );
        let (read, _, _) = read_animation(&rig, &readers, None).unwrap();
        assert_eq!(read.len(), listing.frames);
    }

    #[test]
    fn bone_pose_reads_back_what_was_written_and_names_what_does_not_fit() {
        let rig = Rig::standard();
        let mut pose = BonePose::rest(&rig);
        let elbow = rig.bone_index("l_forearm").unwrap();
        pose.local_rotations[elbow] =
            nalgebra::UnitQuaternion::from_axis_angle(&nalgebra::Vector3::x_axis(), 0.7);
        pose.root_translation_m = nalgebra::Vector3::new(0.5, -1.0, 0.02);
        let frame = frame_of(&rig, &pose);
        assert_eq!(bone_pose(&rig, &frame).unwrap(), pose);
        // Names may be left out (rig order), but not half given.
        let unnamed = BoneFrame {
            bone_names: Vec::new(),
            ..frame.clone()
        };
        assert_eq!(bone_pose(&rig, &unnamed).unwrap(), pose);
        let short = BoneFrame {
            bone_names: frame.bone_names[..3].to_vec(),
            ..frame.clone()
        };
        assert_eq!(
            bone_pose(&rig, &short).unwrap_err(),
            BonePoseError::NameCount {
                names: 3,
                rotations: 53
            }
        );
        assert_eq!(
            bone_pose(&rig, &short).unwrap_err().to_string(),
            "3 bone names for 53 rotations"
        );

        let mut renamed = frame.clone();
        renamed.bone_names[elbow] = "forearm_L".into();
        let e = bone_pose(&rig, &renamed).unwrap_err().to_string();
        assert!(
            e.contains(&format!(
                "names bone {elbow} `forearm_L`, where rig autoact53 has `l_forearm`"
            )),
            "{e}"
        );

        // A zero or NaN quaternion is an error naming the bone, never a silent rest pose.
        for bad in [
            Quaternion {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                w: 0.0,
            },
            Quaternion {
                x: f64::NAN,
                ..Quaternion::default()
            },
        ] {
            let mut broken = frame.clone();
            broken.local_rotations[elbow] = bad;
            let e = bone_pose(&rig, &broken).unwrap_err();
            assert!(
                matches!(&e, BonePoseError::Rotation { bone, .. } if bone == "l_forearm"),
                "{e}"
            );
            assert!(e.to_string().starts_with("bone `l_forearm`: "), "{e}");
        }
        let e = bone_pose(
            &rig,
            &BoneFrame {
                local_rotations: vec![Quaternion::default(); 2],
                ..frame
            },
        )
        .unwrap_err()
        .to_string();
        assert_eq!(e, "2 rotations; rig autoact53 has 53 bones");
    }
}
