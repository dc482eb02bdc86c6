//! `autoact plan`'s outputs: a spec's recording plan as text tables (counts per class, weather,
//! time, location and character, the expected size), as one JSON document, or as CSV.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use super::plan::{Leaf, Plan, SceneNode};
use super::spec::Spec;

/// The whole plan as one pretty JSON document (with a trailing newline); the frame counts are
/// estimates. `expected` holds the clips `trim` will cut: `clips` and `clip_frames` count those
/// known from the plan, without the segments cut into `instances`
/// (`segments_cut_into_instances`).
///
/// # Errors
/// [`serde_json::Error`] if the plan cannot be encoded.
pub fn json(spec: &Spec, plan: &Plan) -> Result<String, serde_json::Error> {
    let expected = Expected::of(plan);
    let mut s = serde_json::to_string_pretty(&serde_json::json!({
        "spec": spec.path,
        "estimated": true,
        "expected": {
            "segments": expected.segments,
            "clips": expected.clips,
            "clip_frames": expected.clip_frames,
            "segments_cut_into_instances": expected.by_motion,
        },
        "plan": plan,
    }))?;
    s.push('\n');
    Ok(s)
}

fn seconds(frames: u64, fps: f64) -> f64 {
    #[expect(clippy::cast_precision_loss, reason = "frame counts far below 2^52")]
    let f = frames as f64;
    f / fps
}

/// What `trim` will cut out of the plan's segments ([`Plan::expected_clips`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Expected {
    segments: usize,
    /// Clips of the segments whose clips are known from the plan.
    clips: u64,
    /// Their frames.
    clip_frames: u64,
    /// Segments cut into `instances`: their clips are found from the motion when trimmed.
    by_motion: usize,
}

impl Expected {
    fn add(&mut self, plan: &Plan, leaf: &Leaf) {
        self.segments += 1;
        match plan.expected_clips(leaf) {
            Some(clips) => {
                self.clips += clips.len() as u64;
                self.clip_frames += clips.iter().map(|c| c.end - c.start).sum::<u64>();
            }
            None => self.by_motion += 1,
        }
    }

    fn of(plan: &Plan) -> Expected {
        let mut e = Expected::default();
        for leaf in &plan.leaves {
            e.add(plan, leaf);
        }
        e
    }

    /// `384 clips, 19200 clip frames at 30 fps, 0.18 h of video (320×240)`, with the segments
    /// cut into instances said apart (their clips are not counted).
    fn size_text(&self, fps: f64, [w, h]: [u32; 2]) -> String {
        let counted = format!(
            "{} clips, {} clip frames at {fps} fps, {:.2} h of video ({w}×{h})",
            self.clips,
            self.clip_frames,
            seconds(self.clip_frames, fps) / 3600.0
        );
        match (self.by_motion, self.segments - self.by_motion) {
            (0, _) => counted,
            (n, 0) => format!(
                "the clips found in {n} segments cut into instances (not known from the plan; {w}×{h} at {fps} fps)"
            ),
            (n, _) => format!(
                "{counted}, plus the clips found in {n} segments cut into instances (not known from the plan)"
            ),
        }
    }
}

/// The plan as text tables: totals and expected size, then segments and clips per class, and
/// segments per weather, time, location and character.
#[must_use]
pub fn summary(spec: &Spec, plan: &Plan) -> String {
    let fps = plan.fps;
    let total_frames: u64 = plan.sessions.iter().map(|s| s.frames).sum();
    let expected = Expected::of(plan);
    let c = &spec.file.counts;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "dataset {} (seed {}): {} classes, {} labels, {} animations × {} variants × {} scenes × {} viewpoints = {} segments in {} sessions",
        plan.name,
        plan.seed,
        spec.file.classes.len(),
        plan.labels.len(),
        plan.animations.len(),
        c.variants,
        c.scenes,
        c.viewpoints,
        plan.leaves.len(),
        plan.sessions.len(),
    );
    let _ = writeln!(
        out,
        "expected size: {}; timelines {} frames, {:.2} h (lengths estimated from the source bags; DSI transitions may add frames)\n",
        expected.size_text(fps, spec.file.dataset.resolution),
        total_frames,
        seconds(total_frames, fps) / 3600.0,
    );

    let mut per_class: BTreeMap<(String, String), (u32, usize, Expected)> = BTreeMap::new();
    for leaf in &plan.leaves {
        let scene = &plan.scenes[leaf.scene];
        let class = &spec.file.classes[plan.animations[scene.animation].class];
        per_class
            .entry((class.category.clone(), class.action.clone()))
            .or_insert((leaf.label_id, 0, Expected::default()))
            .2
            .add(plan, leaf);
    }
    for anim in &plan.animations {
        let class = &spec.file.classes[anim.class];
        if let Some(e) = per_class.get_mut(&(class.category.clone(), class.action.clone())) {
            e.1 += 1;
        }
    }
    let rows: Vec<Vec<String>> = per_class
        .iter()
        .map(|((cat, act), (label, anims, e))| {
            let (clips, minutes) = if e.by_motion == 0 {
                (
                    e.clips.to_string(),
                    format!("{:.1}", seconds(e.clip_frames, fps) / 60.0),
                )
            } else {
                ("instances".to_string(), "–".to_string())
            };
            vec![
                cat.clone(),
                act.clone(),
                label.to_string(),
                anims.to_string(),
                e.segments.to_string(),
                clips,
                minutes,
            ]
        })
        .collect();
    out.push_str(&crate::table::table(
        &[
            "category",
            "action",
            "label_id",
            "animations",
            "segments",
            "clips",
            "clip minutes",
        ],
        &rows,
    ));
    if expected.by_motion > 0 {
        out.push_str(
            "(instances: found from the motion when the segments are trimmed; not known from the plan)\n",
        );
    }
    let count_by = |f: &dyn Fn(&SceneNode) -> String| {
        let mut m: BTreeMap<String, usize> = BTreeMap::new();
        for leaf in &plan.leaves {
            *m.entry(f(&plan.scenes[leaf.scene])).or_default() += 1;
        }
        m
    };
    let sections: [(&str, BTreeMap<String, usize>); 4] = [
        ("weather", count_by(&|s| s.drawn.weather.to_string())),
        ("time", count_by(&|s| s.drawn.clock.to_string())),
        ("location", count_by(&|s| s.drawn.location.name.clone())),
        (
            "character",
            count_by(&|s| format!("{:?}", s.drawn.look.age_group).to_lowercase()),
        ),
    ];
    for (name, counts) in sections {
        let total: usize = counts.values().sum();
        let rows: Vec<Vec<String>> = counts
            .iter()
            .map(|(k, n)| {
                #[expect(clippy::cast_precision_loss, reason = "display only")]
                let pct = 100.0 * *n as f64 / total.max(1) as f64;
                vec![k.clone(), n.to_string(), format!("{pct:.1}")]
            })
            .collect();
        out.push('\n');
        out.push_str(&crate::table::table(&[name, "segments", "%"], &rows));
    }
    out
}

/// The plan as CSV, one row per segment; `expected_clips` is how many clips `trim` will cut out
/// of it (empty for a segment cut into `instances`: its motion decides).
#[must_use]
pub fn csv(spec: &Spec, plan: &Plan) -> String {
    let mut out = String::from(
        "id,session,category,action,label_id,animation,variant,scene,viewpoint,weather,clock,location,character_height_m,camera_distance_m,camera_azimuth_deg,camera_height_m,start_s,end_s,content_start_s,content_end_s,expected_clips\n",
    );
    let quote = |s: &str| {
        if s.contains([',', '"', '\n']) {
            format!("\"{}\"", s.replace('"', "\"\""))
        } else {
            s.to_string()
        }
    };
    for leaf in &plan.leaves {
        let scene = &plan.scenes[leaf.scene];
        let anim = &plan.animations[scene.animation];
        let class = &spec.file.classes[anim.class];
        let vp = &scene.viewpoints[leaf.viewpoint as usize];
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{},{},{:.3},{:.3},{:.1},{:.3},{:.4},{:.4},{:.4},{:.4},{}",
            quote(&leaf.id),
            quote(&plan.sessions[leaf.session].name),
            quote(&class.category),
            quote(&class.action),
            leaf.label_id,
            quote(&anim.name),
            scene.variant,
            scene.scene,
            leaf.viewpoint,
            scene.drawn.weather,
            scene.drawn.clock,
            quote(&scene.drawn.location.name),
            scene.drawn.look.height_m,
            vp.distance_m,
            vp.azimuth_deg,
            vp.height_m,
            seconds(leaf.start_frame, plan.fps),
            seconds(leaf.end_frame, plan.fps),
            seconds(leaf.content_start_frame, plan.fps),
            seconds(leaf.content_end_frame, plan.fps),
            plan.expected_clips(leaf)
                .map_or_else(String::new, |clips| clips.len().to_string()),
        );
    }
    out
}
