//! The hierarchical recording plan: category → action → animation → variant → scene → viewpoint,
//! every scene drawn (weather, time, location, character) and every viewpoint placed (Random
//! Camera Moving) from the spec's seed, every leaf a segment on a capture session's timeline
//! (which `trim` cuts into clips).
//!
//! **Draws.** Each scene has its own ChaCha8 stream, a hash (FNV-1a) of its id
//! `<category>/<action>/<animation>/v<variant>/s<scene>` under the dataset seed: the same spec and
//! seed give the same draws whatever the order of the classes, adding a class changes no other
//! class's scenes, and another seed changes every draw. Within a stream the order is fixed:
//! weather, clock, location, location props, character, then the camera's viewpoints.
//!
//! **Timeline.** A session's leaves follow each other on one clock at the output rate, each a
//! whole number of frames: `lead-in | animation | lead-out`, the pose held still in the leads.
//! Leaves never overlap; segment `[start, end)` is frame-exact. `autoact plan` estimates the
//! animations' lengths from their bags' time ranges (DSI's transition frames are not known
//! before conversion); `convert --spec` fills in the exact ones — the draws are the same.

use std::collections::BTreeMap;
use std::ops::Range;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::clips::ClipPolicy;
use super::spec::{SessionBy, Spec};
use crate::camera::{
    CameraError, Intrinsics, Shot, Subject, Viewpoint, framing_band, random_viewpoints,
};
use crate::scene::{Scene, SceneError};

/// Why a plan cannot be drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// The dataset's resolution and field of view make no camera.
    #[error("dataset: {source}")]
    Intrinsics {
        /// Why.
        #[source]
        source: CameraError,
    },
    /// A scene cannot be drawn.
    #[error("{scene_id}: {source}")]
    Scene {
        /// The scene's id, `<category>/<action>/<animation>/v<variant>/s<scene>`.
        scene_id: String,
        /// Why.
        #[source]
        source: SceneError,
    },
    /// A scene's character cannot be framed or its viewpoints placed.
    #[error("{scene_id}: {source}")]
    Camera {
        /// The scene's id.
        scene_id: String,
        /// Why.
        #[source]
        source: CameraError,
    },
}

/// Radius of the sphere a standing body with raised arms sweeps, as a fraction of its height,
/// used to frame a character before its animation is known (the framing band then never
/// depends on conversion, so `plan` and `convert --spec` place the same viewpoints).
pub const PLANNING_RADIUS_PER_HEIGHT: f64 = 0.75;

/// Horizontal offset of the body's centre from its ground point a planned framing allows for
/// (leaning, bending, a step), as a fraction of the height.
pub const PLANNING_CENTRE_OFFSET_PER_HEIGHT: f64 = 0.25;

/// The subject a character of `height_m` is framed as before its animation is known.
#[must_use]
pub fn planning_subject(height_m: f64) -> Subject {
    Subject {
        centres_m: Vec::new(),
        ground_xy_m: Vec::new(),
        radius_m: PLANNING_RADIUS_PER_HEIGHT * height_m,
        max_centre_offset_m: PLANNING_CENTRE_OFFSET_PER_HEIGHT * height_m,
    }
}

/// One source animation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AnimationNode {
    /// Index of its class in the spec.
    pub class: usize,
    /// Index of its source in the class.
    pub source: usize,
    /// `<bag file name>#<track>` (`#first` when the spec names no track).
    pub name: String,
    /// Frames per variant at the output rate (estimated by `plan`, exact after conversion).
    pub frames: Vec<u64>,
}

/// One drawn scene with its viewpoints.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneNode {
    /// `<category>/<action>/<animation>/v<variant>/s<scene>`.
    pub id: String,
    /// Index of the animation.
    pub animation: usize,
    /// Variant index.
    pub variant: u32,
    /// Scene index within the variant.
    pub scene: u32,
    /// ChaCha8 stream of its draws.
    pub stream: u64,
    /// What was drawn.
    pub drawn: Scene,
    /// Camera waypoints (one more than the viewpoints for moving shots).
    pub viewpoints: Vec<Viewpoint>,
}

/// One segment: a viewpoint of a scene on its session's timeline, which `trim` cuts into clips
/// by its class's clip policy ([`Plan::expected_clips`]).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Leaf {
    /// `<scene id>/c<viewpoint>`.
    pub id: String,
    /// Index of its session.
    pub session: usize,
    /// Index of its scene node.
    pub scene: usize,
    /// Viewpoint index within the scene.
    pub viewpoint: u32,
    /// Label id (index in the sorted labels).
    pub label_id: u32,
    /// First frame of the segment (its lead-in) on the session timeline.
    pub start_frame: u64,
    /// First frame of the animation.
    pub content_start_frame: u64,
    /// One past the animation's last frame.
    pub content_end_frame: u64,
    /// One past the segment's last frame (its lead-out's).
    pub end_frame: u64,
}

/// One capture session: a timeline, a bag.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Session {
    /// File-safe name.
    pub name: String,
    /// Its leaves (indices into [`Plan::leaves`]).
    pub leaves: Range<usize>,
    /// Frames on its timeline.
    pub frames: u64,
}

/// The whole plan.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Plan {
    /// Dataset name.
    pub name: String,
    /// Seed.
    pub seed: u64,
    /// Output rate.
    pub fps: f64,
    /// Sorted action labels.
    pub labels: Vec<String>,
    /// Source animations.
    pub animations: Vec<AnimationNode>,
    /// Scenes.
    pub scenes: Vec<SceneNode>,
    /// Segments, session by session, in timeline order.
    pub leaves: Vec<Leaf>,
    /// Sessions.
    pub sessions: Vec<Session>,
    /// Per label, how `trim` cuts its segments into clips (the spec's `[clips]` and the class's
    /// own keys).
    pub clips: BTreeMap<String, ClipPolicy>,
}

/// FNV-1a, 64 bits: a stable stream number for a scene id.
#[must_use]
pub fn stream_of(id: &str) -> u64 {
    crate::hash::of_str(id)
}

fn frames_for(seconds: f64, fps: f64) -> u64 {
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "a non-negative frame count far below 2^52"
    )]
    let n = (seconds * fps).round().max(0.0) as u64;
    n
}

impl Plan {
    /// Draws every scene and viewpoint of `spec` and lays the segments on their timelines, with
    /// `frames(animation index, class, source)` giving each animation's length per variant at
    /// the output rate.
    ///
    /// # Errors
    /// [`PlanError`], e.g. when the camera cannot frame a character (field of view too narrow
    /// for the farthest distance).
    pub fn build(spec: &Spec, frames: &dyn Fn(usize, usize) -> u64) -> Result<Plan, PlanError> {
        let file = &spec.file;
        let d = &file.dataset;
        let counts = &file.counts;
        let intrinsics =
            Intrinsics::from_horizontal_fov(d.resolution[0], d.resolution[1], d.fov_deg)
                .map_err(|source| PlanError::Intrinsics { source })?;

        let mut animations = Vec::new();
        for (class, sources) in spec.sources.iter().enumerate() {
            for (source, s) in sources.iter().enumerate() {
                let file_name = s
                    .path
                    .file_name()
                    .map_or_else(|| s.written.clone(), |n| n.to_string_lossy().into_owned());
                let name = match s.track {
                    Some(t) => format!("{file_name}#{t}"),
                    None => format!("{file_name}#first"),
                };
                let n = frames(class, source);
                animations.push(AnimationNode {
                    class,
                    source,
                    name,
                    frames: vec![n; counts.variants as usize],
                });
            }
        }

        let viewpoints_per_scene =
            counts.viewpoints as usize + usize::from(counts.shot == Shot::Moving);
        let mut scenes = Vec::new();
        for (a, anim) in animations.iter().enumerate() {
            let class = &file.classes[anim.class];
            for variant in 0..counts.variants {
                for scene in 0..counts.scenes {
                    let id = format!(
                        "{}/{}/{}/v{variant}/s{scene}",
                        class.category, class.action, anim.name
                    );
                    let stream = stream_of(&id);
                    let mut rng = ChaCha8Rng::seed_from_u64(d.seed);
                    rng.set_stream(stream);
                    let drawn = file
                        .scene
                        .draw(&mut rng, &class.requires)
                        .map_err(|source| PlanError::Scene {
                            scene_id: id.clone(),
                            source,
                        })?;
                    let subject = planning_subject(drawn.look.height_m);
                    let band = framing_band(
                        &intrinsics,
                        &subject,
                        file.camera.margin,
                        file.camera.max_distance_m,
                    )
                    .map_err(|source| PlanError::Camera {
                        scene_id: id.clone(),
                        source,
                    })?;
                    let viewpoints = random_viewpoints(
                        &mut rng,
                        &file.camera.ranges,
                        band,
                        viewpoints_per_scene,
                    )
                    .map_err(|source| PlanError::Camera {
                        scene_id: id.clone(),
                        source,
                    })?;
                    scenes.push(SceneNode {
                        id,
                        animation: a,
                        variant,
                        scene,
                        stream,
                        drawn,
                        viewpoints,
                    });
                }
            }
        }

        let mut plan = Plan {
            name: d.name.clone(),
            seed: d.seed,
            fps: d.fps,
            labels: spec.labels.clone(),
            animations,
            scenes,
            leaves: Vec::new(),
            sessions: Vec::new(),
            clips: file
                .classes
                .iter()
                .zip(&spec.clip_policies)
                .map(|(c, p)| (c.action.clone(), *p))
                .collect(),
        };
        plan.lay_out(spec);
        Ok(plan)
    }

    /// The clips `trim` will cut out of `leaf` (a segment) by its class's clip policy, as frame
    /// ranges on the session's timeline: exact for `whole` and `windows` at the plan's lengths.
    /// `None` for `instances`, whose clips the motion decides when the segment is trimmed, and
    /// for a policy `trim` would refuse.
    #[must_use]
    pub fn expected_clips(&self, leaf: &Leaf) -> Option<Vec<Range<u64>>> {
        let label = self.labels.get(usize::try_from(leaf.label_id).ok()?)?;
        let policy = self.clips.get(label).copied().unwrap_or_default();
        if policy.validate().is_err() {
            return None;
        }
        let segment = leaf.start_frame..leaf.end_frame.max(leaf.start_frame);
        let action = leaf.content_start_frame..leaf.content_end_frame;
        Some(
            policy
                .fixed_clips(&segment, &action)?
                .into_iter()
                .map(|(frames, _)| frames)
                .collect(),
        )
    }

    /// Sets an animation variant's exact length and lays the timelines out again.
    pub fn set_frames(&mut self, spec: &Spec, animation: usize, variant: u32, frames: u64) {
        self.animations[animation].frames[variant as usize] = frames;
        self.lay_out(spec);
    }

    /// (Re)builds leaves and sessions from the scenes and the animations' lengths.
    fn lay_out(&mut self, spec: &Spec) {
        let file = &spec.file;
        let d = &file.dataset;
        let lead_in = frames_for(d.lead_in_s, d.fps);
        let lead_out = frames_for(d.lead_out_s, d.fps);
        let session_of = |anim: &AnimationNode, a: usize| -> String {
            let class = &file.classes[anim.class];
            let name = match d.session {
                SessionBy::Dataset => d.name.clone(),
                SessionBy::Action => format!("{}_{}_{}", d.name, class.category, class.action),
                SessionBy::Animation => {
                    format!("{}_{}_{}_{a:04}", d.name, class.category, class.action)
                }
            };
            name.replace(' ', "_")
        };
        self.leaves.clear();
        self.sessions.clear();
        for (s, scene) in self.scenes.iter().enumerate() {
            let anim = &self.animations[scene.animation];
            let name = session_of(anim, scene.animation);
            if self.sessions.last().is_none_or(|last| last.name != name) {
                let at = self.leaves.len();
                self.sessions.push(Session {
                    name,
                    leaves: at..at,
                    frames: 0,
                });
            }
            let session_index = self.sessions.len() - 1;
            let label = &file.classes[anim.class].action;
            #[expect(clippy::cast_possible_truncation, reason = "labels are few")]
            let label_id = self.labels.binary_search(label).unwrap_or(0) as u32;
            let content = anim.frames[scene.variant as usize];
            for viewpoint in 0..file.counts.viewpoints {
                let session = &mut self.sessions[session_index];
                let start = session.frames;
                let content_start = start + lead_in;
                let content_end = content_start + content;
                let end = content_end + lead_out;
                session.frames = end;
                session.leaves.end += 1;
                self.leaves.push(Leaf {
                    id: format!("{}/c{viewpoint}", scene.id),
                    session: session_index,
                    scene: s,
                    viewpoint,
                    label_id,
                    start_frame: start,
                    content_start_frame: content_start,
                    content_end_frame: content_end,
                    end_frame: end,
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;
    use std::path::Path;

    fn spec(extra: &str, counts: &str) -> Spec {
        let bag = concat!(env!("CARGO_MANIFEST_DIR"), "/bags/bandai_wave.pose.mcap");
        let text = format!(
            "[dataset]\nname = \"t\"\nseed = 11\n[counts]\n{counts}\n{extra}\n[[class]]\ncategory = \"gesture\"\naction = \"wave\"\nsources = [\"{bag}\"]\n"
        );
        Spec::parse(Path::new("spec.toml"), &text).unwrap()
    }

    /// Pearson's χ² of observed counts against expected probabilities.
    fn chi_square(observed: &[f64], probabilities: &[f64]) -> f64 {
        let n: f64 = observed.iter().sum();
        observed
            .iter()
            .zip(probabilities)
            .map(|(o, p)| (o - n * p).powi(2) / (n * p))
            .sum()
    }

    #[test]
    fn ten_thousand_scenes_follow_the_spec_weights_without_cycling() {
        let s = spec(
            "[scene]\nweather_weights = { CLEAR = 4, RAIN = 2, FOGGY = 1, SNOW = 1, SMOG = 1, THUNDER = 0.5, XMAS = 0.5 }\nclock_weights = { dawn = 1, noon = 3, evening = 2, midnight = 1, \"17:45\" = 1 }",
            "scenes = 10000\nviewpoints = 1",
        );
        let plan = Plan::build(&s, &|_, _| 30).unwrap();
        assert_eq!(plan.scenes.len(), 10_000);
        let weathers = ["CLEAR", "RAIN", "FOGGY", "SNOW", "SMOG", "THUNDER", "XMAS"];
        let w = [4.0, 2.0, 1.0, 1.0, 1.0, 0.5, 0.5];
        let total: f64 = w.iter().sum();
        let probabilities: Vec<f64> = w.iter().map(|x| x / total).collect();
        let index = |n: &SceneNode| {
            weathers
                .iter()
                .position(|&x| x == n.drawn.weather.to_string())
                .unwrap()
        };
        let mut counts = vec![0.0; 7];
        let mut pairs = vec![vec![0.0; 7]; 7];
        for (k, n) in plan.scenes.iter().enumerate() {
            counts[index(n)] += 1.0;
            if k > 0 {
                pairs[index(&plan.scenes[k - 1])][index(n)] += 1.0;
            }
        }
        // p > 0.001 with df = 6: χ² < 22.458.
        let fit = chi_square(&counts, &probabilities);
        assert!(fit < 22.458, "weather χ² {fit}");
        // No cycling: consecutive scenes are independent (contingency χ², df = 36: < 67.985).
        let n: f64 = pairs.iter().flatten().sum();
        let rows: Vec<f64> = pairs.iter().map(|r| r.iter().sum()).collect();
        let cols: Vec<f64> = (0..7).map(|j| pairs.iter().map(|r| r[j]).sum()).collect();
        let mut independence = 0.0;
        for i in 0..7 {
            for j in 0..7 {
                let e = rows[i] * cols[j] / n;
                independence += (pairs[i][j] - e).powi(2) / e;
            }
        }
        assert!(independence < 67.985, "transition χ² {independence}");
        // Clock times: df = 4, χ² < 18.467.
        let mut clocks: BTreeMap<String, f64> = BTreeMap::new();
        for n in &plan.scenes {
            *clocks.entry(n.drawn.clock.to_string()).or_default() += 1.0;
        }
        let expected = [
            ("05:30", 1.0),
            ("12:00", 3.0),
            ("17:45", 1.0),
            ("20:00", 2.0),
            ("23:00", 1.0),
        ];
        let observed: Vec<f64> = expected.iter().map(|(k, _)| clocks[*k]).collect();
        let p: Vec<f64> = expected.iter().map(|(_, w)| w / 8.0).collect();
        let fit = chi_square(&observed, &p);
        assert!(fit < 18.467, "clock χ² {fit}");
        // Characters: the default population's age groups, df = 2, χ² < 13.816.
        let mut ages: BTreeMap<String, f64> = BTreeMap::new();
        for n in &plan.scenes {
            *ages
                .entry(format!("{:?}", n.drawn.look.age_group))
                .or_default() += 1.0;
        }
        let observed: Vec<f64> = ["Child", "Adult", "Older"]
            .iter()
            .map(|k| ages[*k])
            .collect();
        let fit = chi_square(&observed, &[0.15, 0.7, 0.15]);
        assert!(fit < 13.816, "age χ² {fit}: {ages:?}");
    }

    #[test]
    fn the_same_seed_draws_the_same_and_another_seed_redraws_everything() {
        let a = Plan::build(&spec("", "scenes = 50"), &|_, _| 30).unwrap();
        let b = Plan::build(&spec("", "scenes = 50"), &|_, _| 30).unwrap();
        assert_eq!(a, b);
        let mut other = spec("", "scenes = 50");
        other.file.dataset.seed = 12;
        let c = Plan::build(&other, &|_, _| 30).unwrap();
        for (x, y) in a.scenes.iter().zip(&c.scenes) {
            assert_eq!(x.id, y.id);
            assert_ne!(x.drawn.look.height_m, y.drawn.look.height_m, "{}", x.id);
            assert_ne!(
                x.viewpoints[0].azimuth_deg, y.viewpoints[0].azimuth_deg,
                "{}",
                x.id
            );
        }
        let weathers_differ = a
            .scenes
            .iter()
            .zip(&c.scenes)
            .filter(|(x, y)| x.drawn.weather != y.drawn.weather)
            .count();
        assert!(
            weathers_differ > 25,
            "{weathers_differ} of 50 weathers changed"
        );
    }

    /// The clips a segment is expected to give follow its class's policy: one for `whole`,
    /// the windows that fit the animation for `windows` (with each tail rule), none known for
    /// `instances`.
    #[test]
    fn expected_clips_follow_the_policy_over_the_animation() {
        let cases: [(&str, Option<Vec<Range<u64>>>); 5] = [
            ("", Some(std::iter::once(15..115).collect())),
            (
                "[clips]\npolicy = \"windows\"\nlength_frames = 30\nstride_frames = 40\ntail = \"drop\"",
                Some(vec![15..45, 55..85]),
            ),
            (
                "[clips]\npolicy = \"windows\"\nlength_frames = 30\nstride_frames = 40\ntail = \"keep\"",
                Some(vec![15..45, 55..85, 95..115]),
            ),
            (
                "[clips]\npolicy = \"windows\"\nlength_frames = 30\nstride_frames = 40\ninclude_lead = true",
                Some(vec![0..30, 40..70, 80..110, 100..130]),
            ),
            ("[clips]\npolicy = \"instances\"", None),
        ];
        for (clips, expected) in cases {
            let mut s = spec(clips, "variants = 1\nscenes = 1\nviewpoints = 2");
            s.file.dataset.lead_in_s = 0.5;
            s.file.dataset.lead_out_s = 0.5;
            let plan = Plan::build(&s, &|_, _| 100).unwrap();
            assert_eq!(plan.expected_clips(&plan.leaves[0]), expected, "{clips}");
            // The second segment's clips are the first's, moved by its start.
            let shift = plan.leaves[1].start_frame;
            assert_eq!(
                plan.expected_clips(&plan.leaves[1]),
                expected.map(|e| e.iter().map(|r| r.start + shift..r.end + shift).collect()),
                "{clips}"
            );
        }
    }

    #[test]
    fn timelines_are_frame_exact_and_never_overlap() {
        let mut s = spec(
            "",
            "variants = 2\nscenes = 3\nviewpoints = 4\nshot = \"moving\"",
        );
        s.file.dataset.lead_in_s = 0.5;
        let mut plan = Plan::build(&s, &|_, _| 100).unwrap();
        assert_eq!(plan.leaves.len(), 2 * 3 * 4);
        assert!(
            plan.scenes.iter().all(|n| n.viewpoints.len() == 5),
            "moving shots need one more waypoint"
        );
        plan.set_frames(&s, 0, 1, 40);
        let mut ids = std::collections::BTreeSet::new();
        let mut end = 0;
        for leaf in &plan.leaves {
            assert!(ids.insert(leaf.id.clone()));
            assert_eq!(leaf.start_frame, end, "back to back");
            assert_eq!(leaf.content_start_frame - leaf.start_frame, 15);
            assert_eq!(leaf.end_frame - leaf.content_end_frame, 15);
            let variant = plan.scenes[leaf.scene].variant;
            let content = leaf.content_end_frame - leaf.content_start_frame;
            assert_eq!(content, if variant == 1 { 40 } else { 100 });
            end = leaf.end_frame;
        }
        assert_eq!(plan.sessions[0].frames, end);
    }

    #[test]
    fn stream_ids_are_stable() {
        // FNV-1a test vectors.
        assert_eq!(stream_of(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(stream_of("a"), 0xaf63_dc4c_8601_ec8c);
    }
}
