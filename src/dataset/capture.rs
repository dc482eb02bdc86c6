//! Capture bags: what `autoact convert --spec` writes — one MCAP per capture session, on one
//! continuous timeline at the output rate, everything a renderer and the trimmer need:
//!
//! - `/animation`, `/tf`, `/tf_static`, `/skeleton/markers`: the character, as
//!   [`crate::animation_bag`] writes them; at each scene start `/tf_static` carries that scene's
//!   character (its drawn body), and the animation is retargeted onto it (root translation scaled
//!   by the ratio of hip heights, starting at the location's origin);
//! - `/camera/pose` (`geometry_msgs/PoseStamped`, the optical frame's pose in `world`), a
//!   `world → camera` transform on `/tf` (`camera` is the ROS optical frame: z forward, x right,
//!   y down) and `/camera/camera_info` (`sensor_msgs/CameraInfo`, frame `camera`), every frame;
//! - `/scene` (`autoact_msgs/SceneState`) at each scene's start: every drawn parameter and the
//!   seed and stream it came from;
//! - `/segments` (`autoact_msgs/Segment`) at each clip's start: the full hierarchy path, the
//!   label and its id, and the clip's and the animation's times.
//!
//! The metadata record `autoact.dataset` names the spec, seed, rate, resolution and labels.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::plan::{Plan, SceneNode};
use super::spec::Spec;
use crate::animation_bag::{TF_STATIC_TOPIC, TF_TOPIC, TrackWriter, read_animation};
use crate::camera::{
    CAMERA_FRAME, CameraPose, DISTORTION_MODEL, Intrinsics, Subject, Viewpoint, camera_at,
    framing_band,
};
use crate::character::Character;
use crate::convert::{AnimationFrame, ConvertOptions, convert_sequence};
use crate::dsi::smoothing::Smoothing;
use crate::dsi::{self, DsiOptions, Pace};
use crate::fk::BonePose;
use crate::frames::WORLD_FRAME;
use crate::layout::{Coverage, Layout};
use crate::mcap_io::{BagReader, BagWriter, McapIoError, WriteConfig};
use crate::pose::stamp_nanos_at;
use crate::pose_bag;
use crate::rig::Rig;
use crate::ros::RosMessage;
use crate::ros::autoact_msgs::{BoneFrame, SceneState, Segment};
use crate::ros::builtin_interfaces::Time;
use crate::ros::geometry_msgs::{
    Pose, PoseStamped, Quaternion, Transform, TransformStamped, Vector3,
};
use crate::ros::sensor_msgs::CameraInfo;
use crate::ros::std_msgs::Header;
use crate::ros::tf2_msgs::TFMessage;

/// Topic of the camera's pose.
pub const CAMERA_POSE_TOPIC: &str = "/camera/pose";
/// Topic of the camera's calibration.
pub const CAMERA_INFO_TOPIC: &str = "/camera/camera_info";
/// Topic of the scene states.
pub const SCENE_TOPIC: &str = "/scene";
/// Topic of the clip segments.
pub const SEGMENTS_TOPIC: &str = "/segments";

/// What went wrong while capturing.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    /// A source bag that cannot be turned into an animation.
    #[error("{key} ({path}): {message}")]
    Source {
        /// `class[k].sources[i]`.
        key: String,
        /// The bag.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// The plan could not be made.
    #[error("{0}")]
    Plan(String),
    /// Writing failed.
    #[error(transparent)]
    Write(#[from] McapIoError),
}

/// One source animation, converted: its variants at the output rate and the body it was solved
/// on.
#[derive(Debug, Clone)]
pub struct Converted {
    /// Per variant, the frames (stamps are the source's; only their order matters here).
    pub variants: Vec<Vec<BonePose>>,
    /// The body the root translation is measured on.
    pub character: Character,
    /// Which bones the source drives.
    pub coverage: Coverage,
}

/// Reads one source (a pose bag or an animation bag) and runs DSI on it with the spec's
/// options; the variants' seed mixes the dataset seed with the animation's name, so two
/// animations never share perturbations.
///
/// # Errors
/// [`CaptureError::Source`] naming the source.
pub fn convert_source(
    rig: &Rig,
    spec: &Spec,
    class: usize,
    source: usize,
    animation_name: &str,
) -> Result<Converted, CaptureError> {
    let s = &spec.sources[class][source];
    let err = |message: String| CaptureError::Source {
        key: format!("class[{class}].sources[{source}]"),
        path: s.path.clone(),
        message,
    };
    let (keys, character, coverage) = read_source(rig, &s.path, s.track).map_err(err)?;
    let mut options = DsiOptions::new(rig);
    options.out_fps = spec.file.dataset.fps;
    options.pace = Pace::Speed(spec.file.dsi.speed);
    options.threshold = spec.threshold;
    options.smoothing = spec.file.dsi.smooth.then(Smoothing::default);
    options.variants = u64::from(spec.file.counts.variants.saturating_sub(1));
    options.bounds = spec.variation;
    options.seed = spec.file.dataset.seed ^ super::plan::stream_of(animation_name);
    let out = dsi::run(rig, &keys, &options).map_err(|e| err(e.to_string()))?;
    Ok(Converted {
        variants: out
            .animations
            .into_iter()
            .map(|frames| frames.into_iter().map(|f| f.pose).collect())
            .collect(),
        character,
        coverage,
    })
}

/// The key frames, body and coverage of one person of a bag: a pose bag is converted (its own
/// layout); an animation bag is read back ([`crate::animation_bag::read_animation`]).
fn read_source(
    rig: &Rig,
    path: &Path,
    track: Option<u64>,
) -> Result<(Vec<AnimationFrame>, Character, Coverage), String> {
    let readers = BagReader::open_all(path).map_err(|e| e.to_string())?;
    let is_animation = readers.iter().any(|r| {
        r.messages()
            .take(64)
            .filter_map(Result::ok)
            .any(|m| m.channel.schema_name() == BoneFrame::TYPE_NAME)
    });
    if is_animation {
        return read_animation(rig, &readers, track);
    }
    let topics = pose_bag::read_pose_topics(path, None, None).map_err(|e| e.to_string())?;
    if topics.lost_data() {
        tracing::warn!(
            "{}: {} unreadable parts, {} skipped messages; using the rest",
            path.display(),
            topics.issues.len(),
            topics.skipped.len()
        );
    }
    let (index, (_, seq)) = topics
        .sequences
        .iter()
        .enumerate()
        .find(|(_, (_, seq))| track.is_none_or(|t| seq.track_id == t) && !seq.frames.is_empty())
        .ok_or_else(|| match track {
            Some(t) => format!("no person with track id {t}"),
            None => "no pose topic with frames".to_string(),
        })?;
    let layout = Layout::load(&topics.layouts[index]).map_err(|e| e.to_string())?;
    let animation = convert_sequence(rig, &layout, seq, ConvertOptions::default())
        .map_err(|e| e.to_string())?;
    Ok((
        animation.frames,
        animation.character,
        animation.report.coverage,
    ))
}

/// One session bag written.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionWritten {
    /// Where.
    pub path: PathBuf,
    /// Clips in it.
    pub clips: usize,
    /// Frames on its timeline.
    pub frames: u64,
    /// Viewpoints moved farther than planned because the animation needed more room.
    pub viewpoints_pushed_out: usize,
}

/// Nanoseconds of frame `frame` on a session timeline at `fps`.
fn nanos_at(frame: u64, fps: f64) -> u64 {
    stamp_nanos_at(usize::try_from(frame).unwrap_or(usize::MAX), fps)
}

fn time_at(frame: u64, fps: f64) -> Time {
    Time::from_nanos(nanos_at(frame, fps))
}

/// The scene's state message.
fn scene_state(
    spec: &Spec,
    plan: &Plan,
    node: &SceneNode,
    session: &str,
    stamp: Time,
) -> SceneState {
    let s = &node.drawn;
    let p = &s.weather_params;
    SceneState {
        header: Header {
            stamp,
            frame_id: WORLD_FRAME.to_string(),
        },
        session: session.to_string(),
        scene_id: node.id.clone(),
        seed: plan.seed,
        stream: node.stream,
        weather: s.weather.to_string(),
        visibility_m: p.visibility_m,
        fog_density_per_m: p.fog_density_per_m,
        cloud_cover: p.cloud_cover,
        precipitation: format!("{:?}", p.precipitation).to_lowercase(),
        precipitation_rate_mm_per_h: p.precipitation_rate_mm_per_h,
        wind_speed_m_per_s: p.wind_speed_m_per_s,
        ambient_light_scale: p.ambient_light_scale,
        ground_wetness: p.ground_wetness,
        snow_cover: p.snow_cover,
        lightning: p.lightning,
        clock: s.clock.to_string(),
        latitude_deg: spec.file.scene.latitude_deg,
        day_of_year: spec.file.scene.day_of_year,
        sun_elevation_deg: s.sun.elevation_deg,
        sun_azimuth_deg: s.sun.azimuth_deg,
        location: s.location.name.clone(),
        character_height_m: s.look.height_m,
        parameters_json: serde_json::to_string(&s).unwrap_or_default(),
    }
}

/// The camera's three messages per frame, kept and updated in place (no allocation per frame):
/// its pose in `world`, the `world → camera` transform, and its calibration.
struct CameraTrack {
    pose: PoseStamped,
    tf: TFMessage,
    info: CameraInfo,
}

impl CameraTrack {
    fn new(intrinsics: &Intrinsics) -> CameraTrack {
        let world = Header {
            stamp: Time::default(),
            frame_id: WORLD_FRAME.to_string(),
        };
        CameraTrack {
            pose: PoseStamped {
                header: world.clone(),
                pose: Pose::default(),
            },
            tf: TFMessage {
                transforms: vec![TransformStamped {
                    header: world,
                    child_frame_id: CAMERA_FRAME.to_string(),
                    transform: Transform::default(),
                }],
            },
            info: CameraInfo {
                header: Header {
                    stamp: Time::default(),
                    frame_id: CAMERA_FRAME.to_string(),
                },
                height: intrinsics.height_px,
                width: intrinsics.width_px,
                distortion_model: DISTORTION_MODEL.to_string(),
                d: intrinsics.d().to_vec(),
                k: intrinsics.k(),
                r: intrinsics.r(),
                p: intrinsics.p(),
                ..CameraInfo::default()
            },
        }
    }

    /// Writes `/camera/pose`, the camera's `/tf` and `/camera/camera_info` at `stamp`.
    fn write<W: std::io::Write + std::io::Seek>(
        &mut self,
        w: &mut BagWriter<W>,
        stamp: u64,
        camera: &CameraPose,
    ) -> Result<(), McapIoError> {
        let time = Time::from_nanos(stamp);
        let rotation = Quaternion::from(camera.world_from_optical);
        self.pose.header.stamp = time;
        self.pose.pose.position = crate::ros::geometry_msgs::Point::from(camera.position_m);
        self.pose.pose.orientation = rotation;
        let t = &mut self.tf.transforms[0];
        t.header.stamp = time;
        t.transform.translation = Vector3::from(camera.position_m.coords);
        t.transform.rotation = rotation;
        self.info.header.stamp = time;
        w.write(CAMERA_POSE_TOPIC, stamp, &self.pose)?;
        w.write(TF_TOPIC, stamp, &self.tf)?;
        w.write(CAMERA_INFO_TOPIC, stamp, &self.info)
    }
}

/// What every clip of one scene shares: the character's writer, the animation retargeted onto
/// the scene's body (from the location's origin), how the camera must frame it.
struct Staged {
    writer: TrackWriter,
    content: Vec<BonePose>,
    subject: Subject,
    /// The framing band for this animation on this body.
    band: [f64; 2],
}

/// Retargets a scene's animation variant onto its drawn body (root translation scaled by the
/// ratio of hip heights, starting at the location's origin) and measures it for the camera.
fn stage_scene(
    rig: &Rig,
    spec: &Spec,
    intrinsics: &Intrinsics,
    node: &SceneNode,
    conv: &Converted,
) -> Result<Staged, CaptureError> {
    let character = node.drawn.look.character(rig);
    let scale = character.hip_height_m(rig) / conv.character.hip_height_m(rig);
    let frames = &conv.variants[node.variant as usize];
    let origin = frames
        .first()
        .map_or_else(nalgebra::Vector3::zeros, |f| f.root_translation_m);
    let content: Vec<BonePose> = frames
        .iter()
        .map(|f| BonePose {
            root_translation_m: (f.root_translation_m
                - nalgebra::Vector3::new(origin.x, origin.y, 0.0))
                * scale,
            local_rotations: f.local_rotations.clone(),
        })
        .collect();
    let subject = Subject::from_poses(rig, &character, &content, 1.0)
        .map_err(|e| CaptureError::Plan(format!("{}: {e}", node.id)))?;
    let band = framing_band(
        intrinsics,
        &subject,
        spec.file.camera.margin,
        spec.file.camera.max_distance_m,
    )
    .map_err(|e| CaptureError::Plan(format!("{}: {e}", node.id)))?;
    Ok(Staged {
        writer: TrackWriter::new(rig, &character, &conv.coverage, 0, node.variant, ""),
        content,
        subject,
        band,
    })
}

/// Writes every session of `plan` into `out_dir` as `<session>.anim.mcap`, with the sources
/// already converted (`converted[animation]`, lengths set in the plan). With `journal`, each
/// bag also gets `<session>.anim.expected.json` (every message as meant, for `tools/interop`).
///
/// # Errors
/// [`CaptureError`] for a write failure or a character the camera cannot frame.
pub fn write_sessions(
    rig: &Rig,
    spec: &Spec,
    plan: &Plan,
    converted: &[Converted],
    out_dir: &Path,
    config: WriteConfig,
    journal: bool,
) -> Result<Vec<SessionWritten>, CaptureError> {
    let d = &spec.file.dataset;
    let intrinsics = Intrinsics::from_horizontal_fov(d.resolution[0], d.resolution[1], d.fov_deg)
        .map_err(|e| CaptureError::Plan(e.to_string()))?;
    let shot = spec.file.counts.shot;
    let mut written = Vec::new();
    for session in &plan.sessions {
        let path = out_dir.join(format!("{}.anim.mcap", session.name));
        let mut w = BagWriter::create(&path, config)?;
        if journal {
            w.keep_journal();
        }
        let mut meta = BTreeMap::new();
        meta.insert("dataset".to_string(), plan.name.clone());
        meta.insert("session".to_string(), session.name.clone());
        meta.insert("spec".to_string(), crate::file_name(&spec.path));
        meta.insert("seed".to_string(), plan.seed.to_string());
        meta.insert("fps".to_string(), d.fps.to_string());
        meta.insert(
            "resolution".to_string(),
            format!("{}x{}", d.resolution[0], d.resolution[1]),
        );
        meta.insert("fov_deg".to_string(), d.fov_deg.to_string());
        meta.insert(
            "labels".to_string(),
            serde_json::to_string(&plan.labels).unwrap_or_default(),
        );
        meta.insert("clips".to_string(), session.leaves.len().to_string());
        w.write_metadata(&format!("{}.dataset", crate::pose_bag::METADATA_NAME), meta)?;

        let mut camera_track = CameraTrack::new(&intrinsics);
        let mut current_scene: Option<usize> = None;
        let mut staged: Option<Staged> = None;
        let mut pushed_out = 0;
        for leaf in &plan.leaves[session.leaves.clone()] {
            let node = &plan.scenes[leaf.scene];
            let anim = &plan.animations[node.animation];
            let class = &spec.file.classes[anim.class];
            let start_ns = nanos_at(leaf.start_frame, d.fps);
            let start = Time::from_nanos(start_ns);
            if current_scene != Some(leaf.scene) {
                current_scene = Some(leaf.scene);
                w.write(
                    SCENE_TOPIC,
                    start_ns,
                    &scene_state(spec, plan, node, &session.name, start),
                )?;
                let s = stage_scene(rig, spec, &intrinsics, node, &converted[node.animation])?;
                w.write(
                    TF_STATIC_TOPIC,
                    start_ns,
                    &TFMessage {
                        transforms: s.writer.static_transforms(start_ns),
                    },
                )?;
                staged = Some(s);
            }
            let Some(Staged {
                writer: tw,
                content,
                subject,
                band,
            }) = staged.as_mut()
            else {
                continue;
            };
            let segment = Segment {
                header: Header {
                    stamp: start,
                    frame_id: WORLD_FRAME.to_string(),
                },
                session: session.name.clone(),
                id: leaf.id.clone(),
                category: class.category.clone(),
                action: class.action.clone(),
                label_id: leaf.label_id,
                animation: anim.name.clone(),
                variant: node.variant,
                scene: node.scene,
                viewpoint: leaf.viewpoint,
                scene_id: node.id.clone(),
                start,
                end: time_at(leaf.end_frame, d.fps),
                content_start: time_at(leaf.content_start_frame, d.fps),
                content_end: time_at(leaf.content_end_frame, d.fps),
            };
            w.write(SEGMENTS_TOPIC, start_ns, &segment)?;

            // The plan framed a standing body of the drawn height; an animation that reaches
            // farther (a wide jump) pushes the camera out along its ray, never closer.
            let mut fit = |v: &Viewpoint| {
                let mut v = *v;
                if v.distance_m < band[0] {
                    v.distance_m = band[0];
                    pushed_out += 1;
                }
                v
            };
            let from = fit(&node.viewpoints[leaf.viewpoint as usize]);
            let to = node
                .viewpoints
                .get(leaf.viewpoint as usize + 1)
                .map(&mut fit);
            let clip_frames = leaf.end_frame - leaf.start_frame;
            for f in leaf.start_frame..leaf.end_frame {
                let k = usize::try_from(
                    f.saturating_sub(leaf.content_start_frame)
                        .min(leaf.content_end_frame - leaf.content_start_frame - 1),
                )
                .unwrap_or(0)
                .min(content.len() - 1);
                let pose = &content[k];
                let stamp = nanos_at(f, d.fps);
                #[expect(clippy::cast_precision_loss, reason = "frame counts far below 2^52")]
                let s = (f - leaf.start_frame) as f64 / (clip_frames.max(2) - 1) as f64;
                let cam = camera_at(
                    &from,
                    to.as_ref(),
                    shot,
                    s,
                    subject.ground_xy_m[k],
                    subject.centres_m[k],
                );
                camera_track.write(&mut w, stamp, &cam)?;
                tw.write_frame(&mut w, stamp, pose)?;
            }
        }
        if journal {
            w.finish_with_journal(&path.with_extension("expected.json"))?;
        } else {
            w.finish()?;
        }
        written.push(SessionWritten {
            path,
            clips: session.leaves.len(),
            frames: session.frames,
            viewpoints_pushed_out: pushed_out,
        });
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_animation_bag_source_reads_back_what_its_pose_bag_converts_to() {
        let rig = Rig::standard();
        let bag = |name: &str| {
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("bags")
                .join(name)
        };
        let (pose_keys, pose_body, pose_cov) =
            read_source(&rig, &bag("bandai_wave.pose.mcap"), None).unwrap();
        let (anim_keys, anim_body, anim_cov) =
            read_source(&rig, &bag("bandai_wave.anim.mcap"), None).unwrap();
        assert_eq!(pose_keys.len(), anim_keys.len());
        // The animation bag was resampled on the 30 fps output clock, whose stamps drift up to
        // 33 ns a frame from the BVH's 0.0333333 s frames: rotations agree to the motion in that
        // instant, under 10 rad/s × 10 µs.
        for (a, b) in pose_keys.iter().zip(&anim_keys) {
            assert!(a.stamp_nanos.abs_diff(b.stamp_nanos) < 10_000);
            for (k, (p, q)) in a
                .pose
                .local_rotations
                .iter()
                .zip(&b.pose.local_rotations)
                .enumerate()
            {
                let d = crate::geom::rotation_distance(p, q);
                assert!(
                    d < 1e-4,
                    "frame {} bone {}: {d}",
                    a.stamp_nanos,
                    rig.bones[k].name
                );
            }
        }
        for (b, (p, q)) in pose_body
            .head_offset_m
            .iter()
            .zip(&anim_body.head_offset_m)
            .enumerate()
            .skip(1)
        {
            assert!((p - q).norm() < 1e-12, "{}", rig.bones[b].name);
        }
        // Bones the pose layout does not drive never move in the animation either.
        for name in &pose_cov.at_rest {
            assert!(anim_cov.at_rest.contains(name), "{name}");
        }
    }
}
