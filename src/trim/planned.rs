//! The whole dataset's clips, from its plan (`plan.json`, which `convert --spec` writes beside
//! the capture bags): what splits are decided over, so that a clip's split does not depend on
//! which captures of the dataset are trimmed yet, nor in what order
//! ([`super::split::assign_clips`]).
//!
//! A planned clip is described as the trimmed one will be: its clip id from its segment id
//! ([`super::clip_id`]), its weather, time, location and character from its drawn scene
//! ([`scene_values`], the function the trimmer describes cut clips with).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::split::{SplitItem, fnv1a};
use super::{TrimError, clip_id};
use crate::bags::capture::Capture;
use crate::dataset::clips::ClipPolicy;
use crate::scene::Scene;

/// The file name `convert --spec` gives the plan, beside the capture bags.
pub const PLAN_FILE: &str = "plan.json";

/// What a clip is described and grouped by that comes from its drawn scene.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneValues {
    /// Weather name.
    pub weather: String,
    /// Clock time, `HH:MM`.
    pub time: String,
    /// Location name.
    pub location: String,
    /// Character id: a hash of the drawn look.
    pub character: String,
    /// The drawn look.
    pub look: serde_json::Value,
}

/// The values of `scene` (empty ones without a scene).
#[must_use]
pub fn scene_values(scene: Option<&Scene>) -> SceneValues {
    let look = scene
        .and_then(|s| serde_json::to_value(&s.look).ok())
        .unwrap_or(serde_json::Value::Null);
    SceneValues {
        weather: scene.map(|s| s.weather.to_string()).unwrap_or_default(),
        time: scene.map(|s| s.clock.to_string()).unwrap_or_default(),
        location: scene.map(|s| s.location.name.clone()).unwrap_or_default(),
        character: format!("{:016x}", fnv1a(&look.to_string()))[..8].to_owned(),
        look,
    }
}

/// `plan.json` as far as splitting needs it.
#[derive(Deserialize)]
struct PlanFile {
    plan: PlanView,
}

#[derive(Deserialize)]
struct PlanView {
    seed: u64,
    labels: Vec<String>,
    animations: Vec<AnimationView>,
    scenes: Vec<SceneView>,
    leaves: Vec<LeafView>,
    /// Absent in plans written before clip policies: every class `whole`.
    #[serde(default)]
    clips: BTreeMap<String, ClipPolicy>,
}

#[derive(Deserialize)]
struct AnimationView {
    name: String,
}

#[derive(Deserialize)]
struct SceneView {
    animation: usize,
    variant: u32,
    scene: u32,
    drawn: Scene,
}

#[derive(Deserialize)]
struct LeafView {
    id: String,
    scene: usize,
    label_id: u32,
}

/// Every clip of a dataset's plan.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedClips {
    /// The plan file.
    pub path: PathBuf,
    /// The dataset's seed.
    pub seed: u64,
    /// The sorted class labels.
    pub labels: Vec<String>,
    /// Every clip of the dataset, as splitting sees it.
    pub items: Vec<SplitItem>,
    /// Per label, how its segments are cut into clips.
    pub clips: BTreeMap<String, ClipPolicy>,
    /// Every clip's segment id and label id.
    segments: BTreeMap<String, u32>,
}

impl PlannedClips {
    /// Where `convert --spec` put the plan of the capture bag `bag`: `plan.json` beside it.
    #[must_use]
    pub fn beside(bag: &Path) -> PathBuf {
        bag.parent().unwrap_or(Path::new("")).join(PLAN_FILE)
    }

    /// Where the plan of the capture bag `bag` is: `plan.json` beside it (`convert --spec`'s
    /// layout), else one folder up (`generate`'s: `DIR/plan.json` over `DIR/captures/`); the
    /// path beside it when neither is there.
    #[must_use]
    pub fn find(bag: &Path) -> PathBuf {
        let beside = PlannedClips::beside(bag);
        if beside.is_file() {
            return beside;
        }
        let above = bag
            .parent()
            .and_then(Path::parent)
            .map(|d| d.join(PLAN_FILE))
            .filter(|p| p.is_file());
        above.unwrap_or(beside)
    }

    /// Reads the plan at `path`.
    ///
    /// # Errors
    /// [`TrimError::Io`] if it cannot be read, [`TrimError::PlanRead`] if it is not a plan,
    /// [`TrimError::PlanIndex`] if a clip names a scene, animation or label it does not have.
    pub fn read(path: &Path) -> Result<PlannedClips, TrimError> {
        let bytes = std::fs::read(path).map_err(TrimError::io("read", path))?;
        let file: PlanFile =
            serde_json::from_slice(&bytes).map_err(|source| TrimError::PlanRead {
                path: path.to_path_buf(),
                source,
            })?;
        let plan = file.plan;
        let mut items = Vec::with_capacity(plan.leaves.len());
        let mut segments = BTreeMap::new();
        for leaf in &plan.leaves {
            let missing = |what: String| TrimError::PlanIndex {
                path: path.to_path_buf(),
                clip: leaf.id.clone(),
                what,
            };
            let scene = plan
                .scenes
                .get(leaf.scene)
                .ok_or_else(|| missing(format!("scene {}", leaf.scene)))?;
            let animation = plan
                .animations
                .get(scene.animation)
                .ok_or_else(|| missing(format!("animation {}", scene.animation)))?;
            let label = plan
                .labels
                .get(leaf.label_id as usize)
                .ok_or_else(|| missing(format!("label {}", leaf.label_id)))?;
            let values = scene_values(Some(&scene.drawn));
            items.push(SplitItem {
                clip_id: clip_id(&leaf.id),
                label: label.clone(),
                animation: animation.name.clone(),
                variant: scene.variant,
                scene: scene.scene,
                weather: values.weather,
                time: values.time,
                location: values.location,
                character: values.character,
            });
            segments.insert(leaf.id.clone(), leaf.label_id);
        }
        Ok(PlannedClips {
            path: path.to_path_buf(),
            seed: plan.seed,
            labels: plan.labels,
            items,
            clips: plan.clips,
            segments,
        })
    }

    /// Whether `capture` is a capture of this plan: the same labels and seed, and every segment
    /// a clip of the plan with the same label.
    ///
    /// # Errors
    /// [`TrimError::PlanMismatch`] saying what differs.
    pub fn check(&self, capture: &Capture) -> Result<(), TrimError> {
        let mismatch = |why: String| TrimError::PlanMismatch {
            plan: self.path.clone(),
            bag: capture.path.clone(),
            why,
        };
        if capture.labels != self.labels {
            return Err(mismatch(format!(
                "the plan's labels are {:?}, the capture's {:?}",
                self.labels, capture.labels
            )));
        }
        if let Some(seed) = capture.seed.filter(|s| *s != self.seed) {
            return Err(mismatch(format!(
                "the plan's seed is {}, the capture's {seed}",
                self.seed
            )));
        }
        for s in &capture.segments {
            match self.segments.get(&s.id) {
                Some(label_id) if *label_id == s.label_id => {}
                Some(label_id) => {
                    return Err(mismatch(format!(
                        "segment `{}` has label id {} in the capture, {label_id} in the plan",
                        s.id, s.label_id
                    )));
                }
                None => {
                    return Err(mismatch(format!("the plan has no clip `{}`", s.id)));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{PLAN_FILE, PlannedClips};

    #[test]
    fn the_plan_is_found_beside_the_bag_else_one_folder_up() {
        let dir = tempfile::tempdir().unwrap();
        let captures = dir.path().join("captures");
        std::fs::create_dir(&captures).unwrap();
        let bag = captures.join("s.capture.mcap");
        let beside = captures.join(PLAN_FILE);
        // Neither: the path beside the bag, which the warning names.
        assert_eq!(PlannedClips::find(&bag), beside);
        // `generate`'s layout: DIR/plan.json over DIR/captures/.
        std::fs::write(dir.path().join(PLAN_FILE), "{}").unwrap();
        assert_eq!(PlannedClips::find(&bag), dir.path().join(PLAN_FILE));
        // `convert --spec`'s: beside the bag, which wins.
        std::fs::write(&beside, "{}").unwrap();
        assert_eq!(PlannedClips::find(&bag), beside);
    }
}
