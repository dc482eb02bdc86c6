//! The `convert --spec` stage: a dataset spec → its capture sessions. Every source is converted
//! (DSI, variants), the plan laid out with the exact lengths, one capture bag written per
//! session, and the plan as JSON beside them.

use std::path::{Path, PathBuf};

use super::PipelineError;
use crate::bags::output::{BagOutputError, OutputOptions};
use crate::dataset::capture::{self, Converted, SessionWritten};
use crate::dataset::plan::Plan;
use crate::dataset::spec::Spec;
use crate::file_name;
use crate::loss::{Losses, WARN_LIMIT};
use crate::mcap_io::WriteConfig;
use crate::skeleton::rig::Rig;

/// What dataset to capture and where.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SpecJob {
    /// The dataset spec (`DATASET.toml`).
    pub spec: PathBuf,
    /// `path` is the output folder; `compression` and `journal` apply to every session bag
    /// (`rosbag2` does not apply).
    pub output: OutputOptions,
}

/// What a dataset capture wrote, and what input it lost.
#[derive(Debug, Clone, PartialEq)]
pub struct SpecSummary {
    /// The output folder.
    pub dir: PathBuf,
    /// Every session bag written.
    pub sessions: Vec<SessionWritten>,
    /// Clips in the plan.
    pub clips: usize,
    /// The dataset's frame rate.
    pub fps: f64,
    /// Input that could not be used, over all sources (already logged as warnings).
    pub losses: Losses,
}

impl std::fmt::Display for SpecSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "wrote {} sessions, {} clips into {} (and plan.json)",
            self.sessions.len(),
            self.clips,
            self.dir.display()
        )?;
        for s in &self.sessions {
            #[expect(clippy::cast_precision_loss, reason = "display only")]
            let seconds = s.frames as f64 / self.fps;
            writeln!(
                f,
                "  {}: {} clips, {} frames ({seconds:.1} s)",
                file_name(&s.path),
                s.clips,
                s.frames
            )?;
        }
        Ok(())
    }
}

/// Captures the dataset a spec describes: every source converted (what each lost logged as
/// warnings when met), the plan laid out with the exact lengths, one bag per capture session and
/// `plan.json` in the output folder.
///
/// # Errors
/// [`PipelineError`]: a spec that cannot be loaded or planned, a source that cannot be
/// converted, or an output that cannot be written.
pub fn convert_spec(rig: &Rig, job: &SpecJob) -> Result<SpecSummary, PipelineError> {
    let (spec, mut plan) = estimated_plan(&job.spec)?;
    let dir = &job.output.path;
    if !job.output.force {
        refuse_existing(dir, &plan)?;
    }
    let converted = convert_sources(rig, &spec, &mut plan)?;
    std::fs::create_dir_all(dir).map_err(|source| PipelineError::Io {
        action: "creating",
        path: dir.clone(),
        source,
    })?;
    let config = WriteConfig {
        compression: job.output.compression,
        ..WriteConfig::default()
    };
    let sessions = capture::write_sessions(
        rig,
        &spec,
        &plan,
        &converted,
        dir,
        config,
        job.output.journal,
    )?;
    write_plan(&dir.join("plan.json"), &plan)?;
    for s in &sessions {
        if s.viewpoints_pushed_out > 0 {
            tracing::warn!(
                "{}: {} viewpoints moved out beyond the plan's distance to keep a wide movement in frame",
                file_name(&s.path),
                s.viewpoints_pushed_out
            );
        }
    }
    let mut losses = Losses::new();
    for c in converted {
        losses.append(c.losses);
    }
    Ok(SpecSummary {
        dir: dir.clone(),
        sessions,
        clips: plan.leaves.len(),
        fps: spec.file.dataset.fps,
        losses,
    })
}

/// The spec at `path`, loaded, and its plan with the lengths estimated from the sources'
/// headers (the sessions, clips and draws are those of the exact plan; only frame counts and
/// timeline places change once [`convert_sources`] sets the exact lengths).
///
/// # Errors
/// [`PipelineError`]: a spec that cannot be loaded or planned.
pub fn estimated_plan(path: &Path) -> Result<(Spec, Plan), PipelineError> {
    let spec = Spec::load(path)?;
    let estimated = crate::dataset::estimated_frames(&spec)?;
    let plan = Plan::build(&spec, &|class, source| estimated[class][source])?;
    Ok((spec, plan))
}

/// Converts every animation of the plan from its source, logging what each source lost, and
/// sets each variant's exact length in the plan.
///
/// # Errors
/// [`PipelineError`]: a source that cannot be converted.
pub fn convert_sources(
    rig: &Rig,
    spec: &Spec,
    plan: &mut Plan,
) -> Result<Vec<Converted>, PipelineError> {
    let animations = plan.animations.clone();
    let mut converted = Vec::with_capacity(animations.len());
    for (a, anim) in animations.iter().enumerate() {
        tracing::info!("converting {} ({}/{})", anim.name, a + 1, animations.len());
        let conv = capture::convert_source(rig, spec, anim.class, anim.source, &anim.name)?;
        conv.losses.warn(WARN_LIMIT);
        for (v, frames) in conv.variants.iter().enumerate() {
            plan.set_frames(
                spec,
                a,
                u32::try_from(v).unwrap_or(u32::MAX),
                frames.len() as u64,
            );
        }
        converted.push(conv);
    }
    Ok(converted)
}

/// Refuses, before any work, an output folder that already holds this dataset's `plan.json` or
/// one of its session bags (the caller passes `--force` to replace them).
fn refuse_existing(dir: &Path, plan: &Plan) -> Result<(), PipelineError> {
    let outputs = std::iter::once(dir.join("plan.json")).chain(
        plan.sessions
            .iter()
            .map(|s| crate::bags::capture::session_path(dir, &s.name)),
    );
    for path in outputs {
        if std::fs::symlink_metadata(&path).is_ok() {
            return Err(BagOutputError::Exists { path }.into());
        }
    }
    Ok(())
}

/// Writes the plan, with its exact lengths, as JSON (complete or not at all).
///
/// # Errors
/// [`PipelineError::Io`].
pub fn write_plan(path: &Path, plan: &Plan) -> Result<(), PipelineError> {
    let text =
        serde_json::to_string_pretty(&serde_json::json!({"estimated": false, "plan": plan}))?;
    crate::atomic_file::write(path, text.as_bytes()).map_err(|source| PipelineError::Io {
        action: "writing",
        path: path.to_path_buf(),
        source,
    })
}
