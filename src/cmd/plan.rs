//! `autoact plan SPEC`: the whole recording plan of a dataset spec, before anything is converted
//! or rendered — counts per class, weather, time, location and character, the expected size, or
//! every clip as JSON or CSV.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use serde_json::json;

use super::{Outcome, print_stdout, table};
use crate::dataset::estimated_frames;
use crate::dataset::plan::Plan;
use crate::dataset::spec::Spec;

/// Output of `autoact plan`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PlanFormat {
    /// Counts and expected size, as text tables.
    Summary,
    /// The whole plan (every scene with its draws, every clip), one JSON document.
    Json,
    /// One row per clip.
    Csv,
}

/// Arguments of `autoact plan`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The dataset spec (TOML; see `examples/dataset.toml`).
    pub spec: PathBuf,
    /// What to print.
    #[arg(long, value_enum, default_value_t = PlanFormat::Summary)]
    pub format: PlanFormat,
    /// Write to this file instead of stdout.
    #[arg(short, long, value_name = "PATH")]
    pub output: Option<PathBuf>,
}

/// Runs `autoact plan`.
///
/// # Errors
/// An invalid spec (naming the key), an unreadable source bag, or a write failure.
pub fn run(args: Args) -> Result<Outcome> {
    let Args {
        spec,
        format,
        output,
    } = args;
    let spec = Spec::load(&spec)?;
    let frames = estimated_frames(&spec).map_err(anyhow::Error::msg)?;
    let plan = Plan::build(&spec, &|class, source| frames[class][source])
        .map_err(anyhow::Error::msg)
        .with_context(|| format!("planning {}", spec.path.display()))?;
    let text = match format {
        PlanFormat::Summary => summary(&spec, &plan),
        PlanFormat::Json => {
            let mut s = serde_json::to_string_pretty(&json!({
                "spec": spec.path,
                "estimated": true,
                "plan": plan,
            }))?;
            s.push('\n');
            s
        }
        PlanFormat::Csv => csv(&spec, &plan),
    };
    match output {
        Some(path) => {
            std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))?;
            print_stdout(&format!("wrote {}\n", path.display()))?;
        }
        None => print_stdout(&text)?,
    }
    Ok(Outcome::Success)
}

fn seconds(frames: u64, fps: f64) -> f64 {
    #[expect(clippy::cast_precision_loss, reason = "frame counts far below 2^52")]
    let f = frames as f64;
    f / fps
}

fn summary(spec: &Spec, plan: &Plan) -> String {
    let fps = plan.fps;
    let total_frames: u64 = plan.sessions.iter().map(|s| s.frames).sum();
    let clip_frames: u64 = plan
        .leaves
        .iter()
        .map(|l| l.end_frame - l.start_frame)
        .sum();
    let c = &spec.file.counts;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "dataset {} (seed {}): {} classes, {} labels, {} animations × {} variants × {} scenes × {} viewpoints = {} clips in {} sessions",
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
    let [w, h] = spec.file.dataset.resolution;
    let _ = writeln!(
        out,
        "expected size: {} clips, {} frames at {fps} fps, {:.2} h of video ({w}×{h}); timelines {:.2} h (lengths estimated from the source bags; DSI transitions may add frames)\n",
        plan.leaves.len(),
        clip_frames,
        seconds(clip_frames, fps) / 3600.0,
        seconds(total_frames, fps) / 3600.0,
    );

    let mut per_class: BTreeMap<(String, String), (u32, usize, usize, u64)> = BTreeMap::new();
    for leaf in &plan.leaves {
        let scene = &plan.scenes[leaf.scene];
        let class = &spec.file.classes[plan.animations[scene.animation].class];
        let e = per_class
            .entry((class.category.clone(), class.action.clone()))
            .or_insert((leaf.label_id, 0, 0, 0));
        e.2 += 1;
        e.3 += leaf.end_frame - leaf.start_frame;
    }
    for anim in &plan.animations {
        let class = &spec.file.classes[anim.class];
        if let Some(e) = per_class.get_mut(&(class.category.clone(), class.action.clone())) {
            e.1 += 1;
        }
    }
    let rows: Vec<Vec<String>> = per_class
        .iter()
        .map(|((cat, act), (label, anims, clips, frames))| {
            vec![
                cat.clone(),
                act.clone(),
                label.to_string(),
                anims.to_string(),
                clips.to_string(),
                format!("{:.1}", seconds(*frames, fps) / 60.0),
            ]
        })
        .collect();
    out.push_str(&table(
        &[
            "category",
            "action",
            "label_id",
            "animations",
            "clips",
            "minutes",
        ],
        &rows,
    ));
    let count_by = |f: &dyn Fn(&crate::dataset::plan::SceneNode) -> String| {
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
        out.push_str(&table(&[name, "clips", "%"], &rows));
    }
    out
}

fn csv(spec: &Spec, plan: &Plan) -> String {
    let mut out = String::from(
        "id,session,category,action,label_id,animation,variant,scene,viewpoint,weather,clock,location,character_height_m,camera_distance_m,camera_azimuth_deg,camera_height_m,start_s,end_s,content_start_s,content_end_s\n",
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
            "{},{},{},{},{},{},{},{},{},{},{},{},{:.3},{:.3},{:.1},{:.3},{:.4},{:.4},{:.4},{:.4}",
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
        );
    }
    out
}
