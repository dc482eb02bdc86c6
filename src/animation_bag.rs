//! Animation bags: what `autoact convert` writes. Per output frame and person:
//!
//! - `/animation` — `autoact_msgs/msg/BoneFrame`: every bone's local rotation and the root
//!   translation (the data later stages consume);
//! - `/tf` — `tf2_msgs/msg/TFMessage`: `world → root`, and `parent → child` for every bone that
//!   moves, with the child's rest offset (on the subject's body) and its local rotation, so RViz,
//!   Foxglove and Rerun show the skeleton with no plugin;
//! - `/skeleton/markers` — `visualization_msgs/msg/MarkerArray`: the skeleton as a `LINE_LIST`,
//!   drawn from parent to child head for every bone the data drives and the rigid torso (bones a
//!   layout cannot see, such as fingers from a body-only estimator, are not drawn).
//!
//! Bones that never move (static bones, and those the layout cannot drive) go once on
//! `/tf_static`. With several people, frame names are prefixed `track<id>/`; with DSI variants,
//! `v<k>/` (after the track's prefix), and the markers of variant `k` are in namespace
//! `skeleton/v<k>`. Variant 0, the animation as converted, has neither.
//!
//! A [`TrackWriter`] keeps one message of each kind per person and updates it in place, so a
//! frame costs no allocation however long the animation.

use crate::character::Character;
use crate::fk::{self, BonePose};
use crate::frames::WORLD_FRAME;
use crate::layout::Coverage;
use crate::mcap_io::{BagWriter, McapIoError};
use crate::rig::{Dof, ROOT, Rig};
use crate::ros::autoact_msgs::BoneFrame;
use crate::ros::builtin_interfaces::Time;
use crate::ros::geometry_msgs::{Point, Quaternion, Transform, TransformStamped, Vector3};
use crate::ros::std_msgs::{ColorRGBA, Header};
use crate::ros::tf2_msgs::TFMessage;
use crate::ros::visualization_msgs::{Marker, MarkerArray};

/// Topic of the bone frames.
pub const ANIMATION_TOPIC: &str = "/animation";
/// Topic of the per-frame transforms.
pub const TF_TOPIC: &str = "/tf";
/// Topic of the transforms that never change.
pub const TF_STATIC_TOPIC: &str = "/tf_static";
/// Topic of the skeleton markers.
pub const MARKERS_TOPIC: &str = "/skeleton/markers";

/// Writes one person's frames.
#[derive(Debug)]
pub struct TrackWriter<'r> {
    rig: &'r Rig,
    character: Character,
    /// Bones with a `/tf` entry each frame (index into the rig), root first.
    moving: Vec<usize>,
    bone_frame: BoneFrame,
    tf: TFMessage,
    markers: MarkerArray,
    /// (parent, child) bone pairs drawn as marker segments.
    segments: Vec<(usize, usize)>,
    world: fk::WorldPose,
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

fn frame_name(prefix: &str, rig: &Rig, bone: usize) -> String {
    format!("{prefix}{}", rig.bones[bone].name)
}

impl<'r> TrackWriter<'r> {
    /// A writer for person `track_id`'s animation `variant`, with tf frame names prefixed by
    /// `prefix` (see [`frame_prefix`]), animated on `character` with the bones `coverage` says its
    /// data drives.
    #[must_use]
    pub fn new(
        rig: &'r Rig,
        character: Character,
        coverage: &Coverage,
        track_id: u64,
        variant: u32,
        prefix: &str,
    ) -> TrackWriter<'r> {
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
        let segments: Vec<(usize, usize)> = rig
            .bones
            .iter()
            .enumerate()
            .filter_map(|(b, bone)| bone.parent.filter(|&p| p != ROOT).map(|p| (p, b)))
            .filter(|&(p, b)| character.head_offset_m[b].norm() > 1e-6 && !at_rest(p))
            .collect();
        let header = Header {
            stamp: Time::default(),
            frame_id: WORLD_FRAME.to_string(),
        };
        let marker = Marker {
            header: header.clone(),
            ns: if variant > 0 {
                format!("skeleton/v{variant}")
            } else {
                "skeleton".to_string()
            },
            id: i32::try_from(track_id).unwrap_or(i32::MAX),
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
            points: vec![Point::default(); 2 * segments.len()],
            ..Marker::default()
        };
        TrackWriter {
            rig,
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
            markers: MarkerArray {
                markers: vec![marker],
            },
            segments,
            world: fk::WorldPose::new(rig),
            moving,
            statics,
            character,
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

    /// Writes one frame: `/animation`, `/tf` and `/skeleton/markers` at `stamp`.
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

        fk::forward_into(self.rig, &self.character, pose, 1.0, &mut self.world);
        let marker = &mut self.markers.markers[0];
        marker.header.stamp = time;
        for (pair, &(p, b)) in marker.points.chunks_exact_mut(2).zip(&self.segments) {
            pair[0] = Point::from(self.world.heads_m[p]);
            pair[1] = Point::from(self.world.heads_m[b]);
        }
        writer.write(MARKERS_TOPIC, stamp, &self.markers)
    }
}
