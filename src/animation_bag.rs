//! Animation bags: what `autoact convert` writes. Per output frame and person:
//!
//! - `/animation` — `autoact_msgs/msg/BoneFrame`: every bone's local rotation and the root
//!   translation (the data later stages consume);
//! - `/tf` — `tf2_msgs/msg/TFMessage`: `world → root`, and `parent → child` for every bone that
//!   moves, with the child's rest offset (on the subject's body) and its local rotation, so RViz,
//!   Foxglove and Rerun show the skeleton with no plugin;
//! - `/skeleton/markers` — `visualization_msgs/msg/MarkerArray`: the skeleton as a `LINE_LIST`.
//!
//! Bones that never move (static bones, and those the layout cannot drive) go once on
//! `/tf_static`. With several people, frame names are prefixed `track<id>/`.

use std::collections::BTreeMap;

use crate::convert::{Animation, AnimationFrame};
use crate::fk;
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
/// Topic of the skeleton markers.
pub const MARKERS_TOPIC: &str = "/skeleton/markers";
/// The world frame.
pub const WORLD_FRAME: &str = "world";

/// One person's animation to write: its solved animation and its frames at the output rate.
#[derive(Debug, Clone, Copy)]
pub struct Track<'a> {
    /// The solved animation (rig, body, report).
    pub animation: &'a Animation,
    /// Frames at the output rate.
    pub frames: &'a [AnimationFrame],
    /// Tracker id.
    pub track_id: u64,
}

/// Writes the animation bag's messages (after any metadata the caller wrote). Returns the number
/// of frames written.
///
/// # Errors
/// [`McapIoError`] from the writer.
pub fn write_animation<W: std::io::Write + std::io::Seek>(
    writer: &mut BagWriter<W>,
    rig: &Rig,
    tracks: &[Track<'_>],
) -> Result<u64, McapIoError> {
    let prefixes: Vec<String> = tracks
        .iter()
        .map(|t| {
            if tracks.len() > 1 {
                format!("track{}/", t.track_id)
            } else {
                String::new()
            }
        })
        .collect();
    let bone_names: Vec<String> = rig.bones.iter().map(|b| b.name.clone()).collect();
    let moving: Vec<Vec<bool>> = tracks
        .iter()
        .map(|t| moving_bones(rig, t.animation))
        .collect();

    // Static transforms once, at the first output stamp.
    let Some(first) = tracks
        .iter()
        .filter_map(|t| t.frames.first())
        .map(|f| f.stamp_nanos)
        .min()
    else {
        return Ok(0);
    };
    let mut statics = Vec::new();
    for (k, t) in tracks.iter().enumerate() {
        for (b, bone) in rig.bones.iter().enumerate() {
            if b != ROOT && !moving[k][b] {
                statics.push(bone_transform(
                    rig,
                    t.animation,
                    &prefixes[k],
                    b,
                    &bone.name,
                    &nalgebra::UnitQuaternion::identity(),
                    first,
                ));
            }
        }
    }
    writer.write(
        "/tf_static",
        first,
        &TFMessage {
            transforms: statics,
        },
    )?;

    // Frames in time order, people in track order.
    let mut order: Vec<(u64, usize, usize)> = Vec::new();
    for (k, t) in tracks.iter().enumerate() {
        for (i, f) in t.frames.iter().enumerate() {
            order.push((f.stamp_nanos, k, i));
        }
    }
    order.sort_unstable();
    let mut world = fk::WorldPose::new(rig);
    for &(stamp, k, i) in &order {
        let track = &tracks[k];
        let pose = &track.frames[i].pose;
        let header = Header {
            stamp: Time::from_nanos(stamp),
            frame_id: WORLD_FRAME.to_string(),
        };
        writer.write(
            ANIMATION_TOPIC,
            stamp,
            &BoneFrame {
                header: header.clone(),
                rig: rig.name.to_string(),
                track_id: track.track_id,
                bone_names: bone_names.clone(),
                local_rotations: pose
                    .local_rotations
                    .iter()
                    .map(|q| Quaternion::from(*q))
                    .collect(),
                root_translation: Vector3::from(pose.root_translation_m),
            },
        )?;
        let mut transforms = Vec::with_capacity(rig.bones.len());
        transforms.push(TransformStamped {
            header: header.clone(),
            child_frame_id: format!("{}root", prefixes[k]),
            transform: Transform {
                translation: Vector3::from(pose.root_translation_m),
                rotation: Quaternion::from(pose.local_rotations[ROOT]),
            },
        });
        for (b, bone) in rig.bones.iter().enumerate() {
            if b != ROOT && moving[k][b] {
                transforms.push(bone_transform(
                    rig,
                    track.animation,
                    &prefixes[k],
                    b,
                    &bone.name,
                    &pose.local_rotations[b],
                    stamp,
                ));
            }
        }
        writer.write("/tf", stamp, &TFMessage { transforms })?;
        fk::forward_into(rig, &track.animation.character, pose, 1.0, &mut world);
        writer.write(
            MARKERS_TOPIC,
            stamp,
            &MarkerArray {
                markers: vec![skeleton_marker(rig, &world, header, track.track_id)],
            },
        )?;
    }
    Ok(order.len() as u64)
}

/// Which bones of an animation ever move: not static, and driven by its layout.
fn moving_bones(rig: &Rig, animation: &Animation) -> Vec<bool> {
    let at_rest = &animation.report.coverage.at_rest;
    rig.bones
        .iter()
        .map(|b| !matches!(b.dof, Dof::Static) && !at_rest.contains(&b.name))
        .collect()
}

fn bone_transform(
    rig: &Rig,
    animation: &Animation,
    prefix: &str,
    b: usize,
    name: &str,
    local: &nalgebra::UnitQuaternion<f64>,
    stamp: u64,
) -> TransformStamped {
    let parent = rig.bones[b]
        .parent
        .map_or("root", |p| rig.bones[p].name.as_str());
    TransformStamped {
        header: Header {
            stamp: Time::from_nanos(stamp),
            frame_id: format!("{prefix}{parent}"),
        },
        child_frame_id: format!("{prefix}{name}"),
        transform: Transform {
            translation: Vector3::from(animation.character.head_offset_m[b]),
            rotation: Quaternion::from(*local),
        },
    }
}

/// The skeleton as line segments, parent head → child head, in the world frame.
fn skeleton_marker(rig: &Rig, world: &fk::WorldPose, header: Header, track_id: u64) -> Marker {
    let mut points = Vec::with_capacity(2 * rig.bones.len());
    for (b, bone) in rig.bones.iter().enumerate() {
        let Some(p) = bone.parent.filter(|&p| p != ROOT) else {
            continue;
        };
        if (world.heads_m[b] - world.heads_m[p]).norm() < 1e-6 {
            continue;
        }
        points.push(Point::from(world.heads_m[p]));
        points.push(Point::from(world.heads_m[b]));
    }
    Marker {
        header,
        ns: "skeleton".to_string(),
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
        points,
        ..Marker::default()
    }
}

/// Metadata describing a conversion, for the output bag's `autoact.convert` record.
#[must_use]
pub fn convert_metadata(
    rig: &Rig,
    tracks: &[Track<'_>],
    fps: f64,
    source: &str,
) -> BTreeMap<String, String> {
    let mut m = BTreeMap::new();
    m.insert("rig".into(), rig.name.to_string());
    m.insert("source".into(), source.to_string());
    m.insert("fps".into(), format!("{fps}"));
    m.insert(
        "tracks".into(),
        tracks
            .iter()
            .map(|t| t.track_id.to_string())
            .collect::<Vec<_>>()
            .join(","),
    );
    m.insert(
        "layouts".into(),
        tracks
            .iter()
            .map(|t| t.animation.layout_name.clone())
            .collect::<Vec<_>>()
            .join(","),
    );
    m.insert(
        "degenerate_frames".into(),
        tracks
            .iter()
            .map(|t| t.animation.report.degenerate_frames.to_string())
            .collect::<Vec<_>>()
            .join(","),
    );
    m
}
