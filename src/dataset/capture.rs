//! Capture sessions: a dataset spec's plan laid on timelines — every source converted (DSI,
//! variants), each scene's character staged (the animation retargeted onto its drawn body), the
//! camera moved along its viewpoints — and written as capture bags ([`crate::bags::capture`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::plan::{Leaf, Plan, SceneNode, Session};
use super::spec::Spec;
use crate::bags;
use crate::bags::animation::{TrackWriter, read_animation_variant_with_losses, scene_frame_prefix};
use crate::bags::capture::CaptureWriter;
use crate::bags::pose::PoseBagError;
use crate::camera::{
    CameraError, CameraPose, Intrinsics, Shot, Subject, Viewpoint, camera_at, framing_band,
};
use crate::dsi::smoothing::Smoothing;
use crate::dsi::{self, DsiError, DsiOptions, Pace, SourceKind};
use crate::formats::import::InputFormat;
use crate::loss::Losses;
use crate::mcap_io::{BagReader, McapIoError, WriteConfig};
use crate::ros::RosMessage;
use crate::ros::autoact_msgs::{BoneFrame, SceneState, Segment};
use crate::ros::builtin_interfaces::Time;
use crate::ros::std_msgs::Header;
use crate::scene::Scene;
use crate::scene::location::Staging;
use crate::skeleton::character::Character;
use crate::skeleton::convert::{AnimationFrame, ConvertError, ConvertOptions, convert_sequence};
use crate::skeleton::fk::BonePose;
use crate::skeleton::frames::WORLD_FRAME;
use crate::skeleton::layout::{Coverage, Layout, LayoutError};
use crate::skeleton::pose::stamp_nanos_at;
use crate::skeleton::rig::Rig;
use rand::SeedableRng;

/// What went wrong while capturing.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    /// A source bag that cannot be turned into an animation.
    #[error("{key} ({path})")]
    Source {
        /// `class[k].sources[i]`.
        key: String,
        /// The bag.
        path: PathBuf,
        /// Why.
        source: Box<SourceError>,
    },
    /// The dataset's camera (resolution, field of view) cannot be made.
    #[error(transparent)]
    Camera(CameraError),
    /// A scene's character, staged, cannot be framed by the camera.
    #[error("{scene_id}")]
    Framing {
        /// The scene.
        scene_id: String,
        /// Why.
        source: CameraError,
    },
    /// Writing failed.
    #[error(transparent)]
    Write(#[from] McapIoError),
}

/// Why one source cannot be turned into an animation.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The bag cannot be opened.
    #[error(transparent)]
    Open(McapIoError),
    /// An animation bag whose frames cannot be read back.
    #[error(transparent)]
    Animation(#[from] crate::bags::animation::ReadAnimationError),
    /// A pose bag whose pose topics cannot be read.
    #[error(transparent)]
    PoseTopics(#[from] PoseBagError),
    /// No person with the spec's track id has frames.
    #[error("no person with track id {0}")]
    NoTrack(u64),
    /// No pose topic has frames.
    #[error("no pose topic with frames")]
    NoFrames,
    /// The layout the messages name cannot be loaded.
    #[error(transparent)]
    Layout(#[from] LayoutError),
    /// The poses cannot be solved.
    #[error(transparent)]
    Convert(#[from] ConvertError),
    /// DSI failed on the animation.
    #[error(transparent)]
    Dsi(#[from] DsiError),
    /// A dataset file (BVH, NTU, Human3.6M, ZED) that cannot be imported.
    #[error(transparent)]
    Import(Box<crate::formats::import::ImportError>),
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
    /// What of the source could not be used (a pose bag's unreadable parts, skipped messages
    /// and dropped frames).
    pub losses: Losses,
}

/// One source read: its key frames, body, coverage and what of it was lost.
struct Source {
    keys: Vec<AnimationFrame>,
    character: Character,
    coverage: Coverage,
    losses: Losses,
    /// Whether it is an estimator's output (imported from, or a pose bag imported from, a
    /// camera-frame format): DSI smooths it as [`SourceKind::Estimator`].
    estimator: bool,
}

/// Reads one source (a pose bag or an animation bag) and runs DSI on it with the spec's
/// options; the variants' seed mixes the dataset seed with the animation's name, so two
/// animations never share perturbations. What of the source was lost is returned, not logged.
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
    let err = |why: SourceError| CaptureError::Source {
        key: format!("class[{class}].sources[{source}]"),
        path: s.path.clone(),
        source: Box::new(why),
    };
    let read = read_source(rig, &s.path, s.track).map_err(err)?;
    let mut options =
        DsiOptions::new(rig).for_source(SourceKind::from_camera_frame(read.estimator));
    options.out_fps = spec.file.dataset.fps;
    options.pace = Pace::Speed(spec.file.dsi.speed);
    options.threshold = spec.threshold;
    options.smoothing = spec.file.dsi.smooth.then(Smoothing::default);
    options.variants = u64::from(spec.file.counts.variants.saturating_sub(1));
    options.bounds = spec.variation;
    options.seed = spec.file.dataset.seed ^ super::plan::stream_of(animation_name);
    let out = dsi::run(rig, &read.keys, &options).map_err(|e| err(e.into()))?;
    Ok(Converted {
        variants: out
            .animations
            .into_iter()
            .map(|frames| frames.into_iter().map(|f| f.pose).collect())
            .collect(),
        character: read.character,
        coverage: read.coverage,
        losses: read.losses,
    })
}

/// The key frames, body and coverage of one person of a source: a dataset file `import` reads
/// is imported and converted ([`super::import_source`]), a pose bag is converted (its own
/// layout); an animation bag is read back ([`crate::bags::animation::read_animation_variant_with_losses`]). Either
/// way, what of the bag could not be used is listed (of an animation bag: its unreadable parts).
fn read_source(rig: &Rig, path: &Path, track: Option<u64>) -> Result<Source, SourceError> {
    if let Some(imported) = super::import_source(path) {
        let imported = imported.map_err(SourceError::Import)?;
        let seq = super::imported_track(&imported, track).ok_or(match track {
            Some(t) => SourceError::NoTrack(t),
            None => SourceError::NoFrames,
        })?;
        let layout = Layout::load(&imported.layout)?;
        let animation = convert_sequence(rig, &layout, seq, ConvertOptions::default())?;
        let losses = Losses::non_monotonic(
            &seq.source,
            "(imported)",
            seq.track_id,
            &animation.report.dropped_non_monotonic,
        );
        return Ok(Source {
            keys: animation.frames,
            character: animation.character,
            coverage: animation.report.coverage,
            losses,
            estimator: imported.format.is_estimator_output(),
        });
    }
    let readers = BagReader::open_all(path).map_err(SourceError::Open)?;
    let is_animation = readers.iter().any(|r| {
        r.messages()
            .take(64)
            .filter_map(Result::ok)
            .any(|m| m.channel.schema_name() == BoneFrame::TYPE_NAME)
    });
    if is_animation {
        let ((keys, character, coverage), lost) =
            read_animation_variant_with_losses(rig, &readers, track, 0)
                .map_err(SourceError::Animation)?;
        return Ok(Source {
            keys,
            character,
            coverage,
            losses: Losses::from_animation(&lost),
            // Already an animation: smoothed, if at all, when it was made.
            estimator: false,
        });
    }
    let estimator = readers
        .iter()
        .any(|r| InputFormat::imported_from_estimator(&r.metadata()));
    let topics = bags::pose::read_pose_topics(path, None, None)?;
    let mut losses = Losses::from_pose_topics(&topics);
    let (index, (topic, seq)) = topics
        .sequences
        .iter()
        .enumerate()
        .find(|(_, (_, seq))| track.is_none_or(|t| seq.track_id == t) && !seq.frames.is_empty())
        .ok_or(match track {
            Some(t) => SourceError::NoTrack(t),
            None => SourceError::NoFrames,
        })?;
    let layout = Layout::load(&topics.layouts[index])?;
    let animation = convert_sequence(rig, &layout, seq, ConvertOptions::default())?;
    losses.append(Losses::non_monotonic(
        &seq.source,
        topic,
        seq.track_id,
        &animation.report.dropped_non_monotonic,
    ));
    Ok(Source {
        keys: animation.frames,
        character: animation.character,
        coverage: animation.report.coverage,
        losses,
        estimator,
    })
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

/// The scene's state message.
fn scene_state(
    spec: &Spec,
    plan: &Plan,
    node: &SceneNode,
    staged: &Scene,
    session: &str,
    stamp: Time,
) -> SceneState {
    let s = staged;
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

/// What every clip of one scene shares: the character's writer, the animation retargeted onto
/// the scene's body (from the location's origin), how the camera must frame it, and the scene
/// as staged around them (what the capture bag records and the renderer draws).
struct Staged {
    writer: TrackWriter,
    content: Vec<BonePose>,
    subject: Subject,
    /// The framing band for this animation on this body.
    band: [f64; 2],
    /// The drawn scene, its location staged ([`crate::scene::location::LocationInstance::stage`]).
    scene: Scene,
}

/// Retargets a scene's animation variant onto its drawn body (root translation scaled by the
/// ratio of hip heights, starting at the location's origin), measures it for the camera, and
/// stages the location around the character's path and the lines of sight of every camera of
/// the scene's clips (`leaves`): no water under the path, no prop on it or between a camera and
/// the character. The body's tf frames carry `scene_index` (the scene's index on the session's
/// timeline): each scene's body gets frames of its own.
fn stage_scene(
    rig: &Rig,
    spec: &Spec,
    intrinsics: &Intrinsics,
    node: &SceneNode,
    leaves: &[&Leaf],
    conv: &Converted,
    scene_index: usize,
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
    let framing = |source| CaptureError::Framing {
        scene_id: node.id.clone(),
        source,
    };
    let subject = Subject::from_poses(rig, &character, &content, 1.0).map_err(framing)?;
    let band = framing_band(
        intrinsics,
        &subject,
        spec.file.camera.margin,
        spec.file.camera.max_distance_m,
    )
    .map_err(framing)?;
    let mut sight_lines_m = Vec::new();
    for leaf in leaves {
        let (cameras, _) = clip_cameras(spec, node, leaf, &subject, band);
        sight_lines_m.extend(cameras.iter().map(|(k, cam)| {
            let p = cam.position_m;
            [[p.x, p.y], subject.ground_xy_m[*k]]
        }));
    }
    let mut scene = node.drawn.clone();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(crate::hash::hash2(
        spec.file.dataset.seed,
        node.stream ^ STAGING_STREAM,
    ));
    scene.location.stage(
        &Staging {
            path_xy_m: &subject.ground_xy_m,
            sight_lines_m: &sight_lines_m,
        },
        &mut rng,
    );
    Ok(Staged {
        writer: TrackWriter::new(
            rig,
            &character,
            &conv.coverage,
            0,
            node.variant,
            &scene_frame_prefix(scene_index),
        ),
        content,
        subject,
        band,
        scene,
    })
}

/// Mixed into a scene's stream for its staging draws, so they never repeat the scene's own.
const STAGING_STREAM: u64 = 0x57a6_e000_0000_0000;

/// The camera of every frame of one clip, with the content frame it shows (the staged pose is
/// held before and after the content), moving from the clip's viewpoint towards the next; and
/// how many of the two viewpoints had to be pushed out to keep the animation in frame.
fn clip_cameras(
    spec: &Spec,
    node: &SceneNode,
    leaf: &Leaf,
    subject: &Subject,
    band: [f64; 2],
) -> (Vec<(usize, CameraPose)>, usize) {
    // The plan framed a standing body of the drawn height; an animation that reaches farther
    // (a wide jump) pushes the camera out along its ray, never closer.
    let mut pushed_out = 0;
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
    let last = subject.centres_m.len() - 1;
    let shows: Vec<usize> = (leaf.start_frame..leaf.end_frame)
        .map(|f| {
            usize::try_from(
                f.saturating_sub(leaf.content_start_frame)
                    .min(leaf.content_end_frame - leaf.content_start_frame - 1),
            )
            .unwrap_or(0)
            .min(last)
        })
        .collect();
    let held = match spec.file.counts.shot {
        Shot::Static => subject.held_aim(&shows, from.distance_m, band),
        Shot::Moving => None,
    };
    let cameras = (leaf.start_frame..leaf.end_frame)
        .zip(shows)
        .map(|(f, k)| {
            #[expect(clippy::cast_precision_loss, reason = "frame counts far below 2^52")]
            let s = (f - leaf.start_frame) as f64 / (clip_frames.max(2) - 1) as f64;
            let (ground, centre) = held.unwrap_or((subject.ground_xy_m[k], subject.centres_m[k]));
            let cam = camera_at(&from, to.as_ref(), spec.file.counts.shot, s, ground, centre);
            (k, cam)
        })
        .collect();
    (cameras, pushed_out)
}

/// Writes every session of `plan` into `out_dir` as `<session>.capture.mcap`, with the sources
/// already converted (`converted[animation]`, lengths set in the plan). With `journal`, each
/// bag also gets `<session>.capture.expected.json` (every message as meant, for `tools/interop`).
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
    let dataset = Dataset::new(rig, spec, plan, converted)?;
    plan.sessions
        .iter()
        .map(|session| dataset.write_session(session, out_dir, config, journal))
        .collect()
}

/// Writes session `index` of `plan` alone into `out_dir`, as [`write_sessions`] writes each (the
/// same bytes): what `autoact generate` captures one unit of work at a time with.
///
/// # Errors
/// [`CaptureError`] for a write failure or a character the camera cannot frame.
///
/// # Panics
/// If `index` is not a session of `plan`.
pub fn write_session(
    rig: &Rig,
    spec: &Spec,
    plan: &Plan,
    converted: &[Converted],
    index: usize,
    out_dir: &Path,
    config: WriteConfig,
) -> Result<SessionWritten, CaptureError> {
    let dataset = Dataset::new(rig, spec, plan, converted)?;
    dataset.write_session(&plan.sessions[index], out_dir, config, false)
}

/// What every session of one dataset is written from.
struct Dataset<'a> {
    rig: &'a Rig,
    spec: &'a Spec,
    plan: &'a Plan,
    converted: &'a [Converted],
    intrinsics: Intrinsics,
    fps: f64,
}

impl<'a> Dataset<'a> {
    /// The dataset of `plan`, its camera's lens from the spec.
    fn new(
        rig: &'a Rig,
        spec: &'a Spec,
        plan: &'a Plan,
        converted: &'a [Converted],
    ) -> Result<Dataset<'a>, CaptureError> {
        let d = &spec.file.dataset;
        let intrinsics =
            Intrinsics::from_horizontal_fov(d.resolution[0], d.resolution[1], d.fov_deg)
                .map_err(CaptureError::Camera)?;
        Ok(Dataset {
            rig,
            spec,
            plan,
            converted,
            intrinsics,
            fps: d.fps,
        })
    }

    /// Nanoseconds of frame `frame` on a session timeline (`[dataset] start_time` + frame time).
    fn nanos_at(&self, frame: u64) -> u64 {
        let k = usize::try_from(frame).unwrap_or(usize::MAX);
        self.spec.start_nanos + stamp_nanos_at(k, self.fps)
    }

    fn time_at(&self, frame: u64) -> Time {
        Time::from_nanos(self.nanos_at(frame))
    }

    /// Writes one session's bag: its metadata, then clip by clip the scene (when it changes), the
    /// segment and the frames.
    fn write_session(
        &self,
        session: &Session,
        out_dir: &Path,
        config: WriteConfig,
        journal: bool,
    ) -> Result<SessionWritten, CaptureError> {
        let path = bags::capture::session_path(out_dir, &session.name);
        let meta = self.session_metadata(session);
        let mut w = CaptureWriter::create(&path, config, journal, meta, &self.intrinsics)?;
        // The scene staged last, by its index in the plan.
        let mut staged: Option<(usize, Staged)> = None;
        let mut scenes_written = 0;
        let mut pushed_out = 0;
        for leaf in &self.plan.leaves[session.leaves.clone()] {
            let node = &self.plan.scenes[leaf.scene];
            let start_nanos = self.nanos_at(leaf.start_frame);
            let scene = match staged.take() {
                Some((index, s)) if index == leaf.scene => s,
                _ => {
                    let leaves: Vec<&Leaf> = self.plan.leaves[session.leaves.clone()]
                        .iter()
                        .filter(|l| l.scene == leaf.scene)
                        .collect();
                    let s = stage_scene(
                        self.rig,
                        self.spec,
                        &self.intrinsics,
                        node,
                        &leaves,
                        &self.converted[node.animation],
                        scenes_written,
                    )?;
                    scenes_written += 1;
                    let state = scene_state(
                        self.spec,
                        self.plan,
                        node,
                        &s.scene,
                        &session.name,
                        Time::from_nanos(start_nanos),
                    );
                    w.write_scene(start_nanos, &state, &s.writer)?;
                    s
                }
            };
            let scene = &mut staged.insert((leaf.scene, scene)).1;
            w.write_segment(start_nanos, &self.segment(&session.name, leaf))?;
            pushed_out += self.write_clip_frames(&mut w, leaf, scene)?;
        }
        w.finish(&path, journal)?;
        Ok(SessionWritten {
            path,
            clips: session.leaves.len(),
            frames: session.frames,
            viewpoints_pushed_out: pushed_out,
        })
    }

    /// The session's metadata record: the dataset, the session, the spec, the seed, the camera,
    /// the labels and the spec's `[randomise]` (so `autoact render` draws what `generate` does).
    fn session_metadata(&self, session: &Session) -> BTreeMap<String, String> {
        let d = &self.spec.file.dataset;
        let mut meta = BTreeMap::new();
        meta.insert("dataset".to_string(), self.plan.name.clone());
        meta.insert("session".to_string(), session.name.clone());
        meta.insert("spec".to_string(), crate::file_name(&self.spec.path));
        meta.insert("seed".to_string(), self.plan.seed.to_string());
        meta.insert("fps".to_string(), d.fps.to_string());
        meta.insert(
            "resolution".to_string(),
            format!("{}x{}", d.resolution[0], d.resolution[1]),
        );
        meta.insert("fov_deg".to_string(), d.fov_deg.to_string());
        meta.insert(
            "start_time".to_string(),
            crate::dataset::spec::iso_8601(self.spec.start_nanos),
        );
        meta.insert(
            "labels".to_string(),
            serde_json::to_string(&self.plan.labels).unwrap_or_default(),
        );
        meta.insert("clips".to_string(), session.leaves.len().to_string());
        meta.insert(
            crate::bags::capture::RANDOMISE_KEY.to_string(),
            self.spec.file.randomise.to_record(),
        );
        meta
    }

    /// One clip's segment: its label, animation, scene and viewpoint, and its times.
    fn segment(&self, session_name: &str, leaf: &Leaf) -> Segment {
        let node = &self.plan.scenes[leaf.scene];
        let anim = &self.plan.animations[node.animation];
        let class = &self.spec.file.classes[anim.class];
        let start = self.time_at(leaf.start_frame);
        Segment {
            header: Header {
                stamp: start,
                frame_id: WORLD_FRAME.to_string(),
            },
            session: session_name.to_string(),
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
            end: self.time_at(leaf.end_frame),
            content_start: self.time_at(leaf.content_start_frame),
            content_end: self.time_at(leaf.content_end_frame),
        }
    }

    /// Writes one clip's frames: the staged pose held before and after the content, the camera
    /// moving from the clip's viewpoint towards the next. Returns how many viewpoints had to be
    /// pushed out to keep the animation in frame.
    fn write_clip_frames(
        &self,
        w: &mut CaptureWriter,
        leaf: &Leaf,
        scene: &mut Staged,
    ) -> Result<usize, CaptureError> {
        let node = &self.plan.scenes[leaf.scene];
        let (cameras, pushed_out) = clip_cameras(self.spec, node, leaf, &scene.subject, scene.band);
        for (f, (k, cam)) in (leaf.start_frame..leaf.end_frame).zip(cameras) {
            w.write_frame(self.nanos_at(f), &cam, &mut scene.writer, &scene.content[k])?;
        }
        Ok(pushed_out)
    }
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
        let pose = read_source(&rig, &bag("bandai_wave.pose.mcap"), None).unwrap();
        let anim = read_source(&rig, &bag("bandai_wave.anim.mcap"), None).unwrap();
        assert!(pose.losses.is_empty() && anim.losses.is_empty());
        let (pose_keys, pose_body, pose_cov) = (pose.keys, pose.character, pose.coverage);
        let (anim_keys, anim_body, anim_cov) = (anim.keys, anim.character, anim.coverage);
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
                let d = crate::skeleton::geom::rotation_distance(p, q);
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

    #[test]
    fn an_animation_bag_source_with_an_unreadable_chunk_reports_it_as_lost() {
        use crate::mcap_io::{BagWriter, Compression};
        let rig = Rig::standard();
        let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("bags/bandai_wave.anim.mcap");
        // The sample re-chunked small, so that damage can hit one chunk.
        let dir = tempfile::tempdir().unwrap();
        let copy = dir.path().join("damaged.anim.mcap");
        let config = WriteConfig {
            compression: Compression::Zstd,
            chunk_size_bytes: 4096,
            writer_thread: false,
        };
        let mut w = BagWriter::create(&copy, config).unwrap();
        for m in BagReader::open(&sample).unwrap().messages() {
            let m = m.unwrap();
            let schema = m.channel.schema.clone().unwrap();
            w.write_raw(
                &m.channel.topic,
                &schema.name,
                || String::from_utf8_lossy(&schema.data).into_owned(),
                m.log_time,
                m.publish_time,
                &m.data,
            )
            .unwrap();
        }
        w.finish().unwrap();
        let clean = read_source(&rig, &copy, None).unwrap();
        assert!(clean.losses.is_empty());

        let mut bytes = std::fs::read(&copy).unwrap();
        let chunk = |at: usize| u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap());
        // The second chunk record: magic (8 bytes), then records of op (1) + length (8) + body.
        let (mut at, mut chunks) = (8, 0);
        while chunks < 2 {
            if bytes[at] == 0x06 {
                chunks += 1;
            }
            if chunks < 2 {
                at += 9 + usize::try_from(chunk(at)).unwrap();
            }
        }
        let end = at + 9 + usize::try_from(chunk(at)).unwrap();
        bytes[end - 30] ^= 0xff;
        std::fs::write(&copy, &bytes).unwrap();
        let damaged = read_source(&rig, &copy, None).unwrap();
        assert!(damaged.keys.len() < clean.keys.len());
        let lost: Vec<String> = damaged.losses.iter().map(ToString::to_string).collect();
        // The chunk itself, then (where it held a channel's definition) each message on that
        // channel.
        assert!(lost[0].contains("damaged.anim.mcap: chunk 2"), "{lost:?}");
        assert!(lost.iter().all(|l| l.contains("damaged.anim.mcap")));
    }
}
