//! The dataset spec: a TOML file that says what to record — the classes and their source bags,
//! how many variants, scenes and viewpoints per animation, the weather, time, location and
//! character distributions, the camera's ranges, and the output's rate, resolution and seed.
//! `examples/dataset.toml` is a commented example of every key.
//!
//! Parsing rejects unknown keys (with the line and the key); [`Spec::load`] then checks every
//! value and names the offending key (`class[2].sources[0]`, `weather.FOO`, `camera.delta_z_m`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::camera::{RcmRanges, Shot};
use crate::dsi::plan::Threshold;
use crate::dsi::variants::VariationBounds;
use crate::scene::SceneConfig;

/// What is wrong with a spec.
#[derive(Debug, thiserror::Error)]
pub enum SpecError {
    /// The file cannot be read.
    #[error("{path}: {source}")]
    Io {
        /// The spec file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Not TOML, or a key that does not exist / has the wrong type (toml names line and key).
    #[error("{path}: {message}")]
    Parse {
        /// The spec file.
        path: PathBuf,
        /// toml's message, with line, column and key.
        message: String,
    },
    /// A value out of its range, or a reference to something that does not exist.
    #[error("{path}: {key}: {message}")]
    Invalid {
        /// The spec file.
        path: PathBuf,
        /// The offending key, e.g. `class[2].sources[0]`.
        key: String,
        /// What is wrong and what would be right.
        message: String,
    },
}

/// `[dataset]`: the output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatasetSection {
    /// Dataset name (names the session files).
    pub name: String,
    /// Seed of every draw.
    pub seed: u64,
    /// Output frame rate, frames per second.
    #[serde(default = "default_fps")]
    pub fps: f64,
    /// Output resolution, `[width, height]` pixels.
    #[serde(default = "default_resolution")]
    pub resolution: [u32; 2],
    /// Horizontal field of view, degrees.
    #[serde(default = "default_fov")]
    pub fov_deg: f64,
    /// Still lead-in before each clip's animation, seconds.
    #[serde(default = "default_lead")]
    pub lead_in_s: f64,
    /// Still lead-out after it, seconds.
    #[serde(default = "default_lead")]
    pub lead_out_s: f64,
    /// One capture timeline per: the whole dataset, each action, or each source animation.
    #[serde(default)]
    pub session: SessionBy,
}

fn default_fps() -> f64 {
    30.0
}
fn default_resolution() -> [u32; 2] {
    [1280, 720]
}
fn default_fov() -> f64 {
    60.0
}
fn default_lead() -> f64 {
    0.5
}

/// What one capture session (one continuous timeline, one bag) holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SessionBy {
    /// Everything.
    Dataset,
    /// One action (label).
    Action,
    /// One source animation (with all its variants, scenes and viewpoints), as the paper
    /// recorded.
    #[default]
    Animation,
}

/// `[counts]`: the hierarchy below each source animation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Counts {
    /// Animations per source, the original included (variant 0).
    #[serde(default = "one")]
    pub variants: u32,
    /// Scenes (positions) per variant.
    #[serde(default = "four")]
    pub scenes: u32,
    /// Viewpoints (camera moves) per scene.
    #[serde(default = "three")]
    pub viewpoints: u32,
    /// How the camera moves within a clip: `static` holds each viewpoint, `moving` travels
    /// smoothly to the next.
    #[serde(default = "static_shot")]
    pub shot: Shot,
}

fn static_shot() -> Shot {
    Shot::Static
}
fn one() -> u32 {
    1
}
fn four() -> u32 {
    4
}
fn three() -> u32 {
    3
}

impl Default for Counts {
    fn default() -> Counts {
        Counts {
            variants: 1,
            scenes: 4,
            viewpoints: 3,
            shot: Shot::Static,
        }
    }
}

/// `[dsi]`: how pose bags become animations (as `autoact convert --dsi`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DsiSection {
    /// Cut threshold (`3x`, `0.05rad`, `1.5rad/s`, `90deg/s`, `off`).
    #[serde(default = "default_threshold")]
    pub threshold: String,
    /// SuperSmoother on or off.
    #[serde(default = "yes")]
    pub smooth: bool,
    /// Playback speed of the unit motions.
    #[serde(default = "unit_speed")]
    pub speed: f64,
    /// Variant bounds per DoF class (as `--variation-deg`).
    #[serde(default = "default_variation")]
    pub variation_deg: String,
}

fn default_threshold() -> String {
    "3x".to_string()
}
fn yes() -> bool {
    true
}
fn unit_speed() -> f64 {
    1.0
}
fn default_variation() -> String {
    VariationBounds::default().to_string()
}

impl Default for DsiSection {
    fn default() -> DsiSection {
        DsiSection {
            threshold: default_threshold(),
            smooth: true,
            speed: 1.0,
            variation_deg: default_variation(),
        }
    }
}

/// `[camera]`: Random Camera Moving and framing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSection {
    /// The RCM ranges.
    #[serde(flatten)]
    pub ranges: RcmRanges,
    /// Farthest horizontal distance from the character, metres.
    #[serde(default = "default_max_distance")]
    pub max_distance_m: f64,
    /// Fraction of the image kept free around the character, on the narrower axis.
    #[serde(default = "default_margin")]
    pub margin: f64,
}

fn default_max_distance() -> f64 {
    9.0
}
fn default_margin() -> f64 {
    0.05
}

impl Default for CameraSection {
    fn default() -> CameraSection {
        CameraSection {
            ranges: RcmRanges::default(),
            max_distance_m: default_max_distance(),
            margin: default_margin(),
        }
    }
}

/// `[[class]]`: one action and where its animations come from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClassSpec {
    /// Category, e.g. `daily`.
    pub category: String,
    /// Action label, e.g. `drink water`.
    pub action: String,
    /// Pose or animation bags (files or rosbag2 directories), relative to the spec;
    /// `BAG#TRACK` picks one person of a bag with several.
    pub sources: Vec<String>,
    /// Location requirements (`water`, `indoor`, `outdoor`, or a location tag).
    #[serde(default)]
    pub requires: Vec<String>,
}

/// A dataset spec as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpecFile {
    /// The output.
    pub dataset: DatasetSection,
    /// The hierarchy's counts.
    #[serde(default)]
    pub counts: Counts,
    /// DSI for pose-bag sources.
    #[serde(default)]
    pub dsi: DsiSection,
    /// Weather, time of day, sun, locations and characters (see [`SceneConfig`]).
    #[serde(default)]
    pub scene: SceneConfig,
    /// Camera.
    #[serde(default)]
    pub camera: CameraSection,
    /// The classes.
    #[serde(rename = "class")]
    pub classes: Vec<ClassSpec>,
}

/// One source animation: a bag (file or rosbag2 directory) and, optionally, a track.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Source {
    /// The path as written in the spec.
    pub written: String,
    /// Resolved against the spec's folder.
    pub path: PathBuf,
    /// The person to use (`None`: the bag's first).
    pub track: Option<u64>,
}

/// A validated spec, ready to plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Spec {
    /// Where it was read from.
    pub path: PathBuf,
    /// The spec as written.
    pub file: SpecFile,
    /// Per class, its resolved sources.
    pub sources: Vec<Vec<Source>>,
    /// DSI threshold.
    pub threshold: Threshold,
    /// Variant bounds.
    pub variation: VariationBounds,
    /// The sorted action labels; a label's id is its index.
    pub labels: Vec<String>,
}

impl Spec {
    /// Reads and validates a spec file.
    ///
    /// # Errors
    /// [`SpecError`] naming the file and the offending key.
    pub fn load(path: &Path) -> Result<Spec, SpecError> {
        let text = std::fs::read_to_string(path).map_err(|source| SpecError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Spec::parse(path, &text)
    }

    /// Parses and validates spec `text` (read from `path`, against whose folder sources resolve).
    ///
    /// # Errors
    /// [`SpecError`] naming the file and the offending key.
    pub fn parse(path: &Path, text: &str) -> Result<Spec, SpecError> {
        let file: SpecFile = toml::from_str(text).map_err(|e| SpecError::Parse {
            path: path.to_path_buf(),
            message: e.to_string().trim_end().to_string(),
        })?;
        let invalid = |key: &str, message: String| SpecError::Invalid {
            path: path.to_path_buf(),
            key: key.to_string(),
            message,
        };
        let d = &file.dataset;
        check_name("dataset.name", &d.name).map_err(|m| invalid("dataset.name", m))?;
        if !(d.fps.is_finite() && d.fps > 0.0 && d.fps <= 1000.0) {
            return Err(invalid(
                "dataset.fps",
                format!("{} is not a frame rate in (0, 1000]", d.fps),
            ));
        }
        if d.resolution.contains(&0) || d.resolution.iter().any(|&r| r > 16384) {
            return Err(invalid(
                "dataset.resolution",
                format!(
                    "{:?}: width and height must be 1–16384 pixels",
                    d.resolution
                ),
            ));
        }
        for (key, v) in [
            ("dataset.lead_in_s", d.lead_in_s),
            ("dataset.lead_out_s", d.lead_out_s),
        ] {
            if !(v.is_finite() && (0.0..=60.0).contains(&v)) {
                return Err(invalid(key, format!("{v} is not a duration in [0, 60] s")));
            }
        }
        let c = &file.counts;
        for (key, v) in [
            ("counts.variants", c.variants),
            ("counts.scenes", c.scenes),
            ("counts.viewpoints", c.viewpoints),
        ] {
            if v == 0 || v > 10_000 {
                return Err(invalid(key, format!("{v}: must be 1–10000")));
            }
        }
        let threshold: Threshold = file
            .dsi
            .threshold
            .parse()
            .map_err(|m: String| invalid("dsi.threshold", m))?;
        let variation: VariationBounds = file
            .dsi
            .variation_deg
            .parse()
            .map_err(|m: String| invalid("dsi.variation_deg", m))?;
        if !(file.dsi.speed.is_finite() && file.dsi.speed > 0.0) {
            return Err(invalid(
                "dsi.speed",
                format!("{} is not a positive speed", file.dsi.speed),
            ));
        }

        file.scene
            .validate()
            .map_err(|e| invalid("scene", e.to_string()))?;
        file.camera
            .ranges
            .validate()
            .map_err(|e| invalid("camera", e.to_string()))?;
        if !(file.camera.max_distance_m.is_finite() && file.camera.max_distance_m > 0.0) {
            return Err(invalid(
                "camera.max_distance_m",
                format!("{} is not a positive distance", file.camera.max_distance_m),
            ));
        }
        if !(file.camera.margin.is_finite() && (0.0..0.5).contains(&file.camera.margin)) {
            return Err(invalid(
                "camera.margin",
                format!("{} is not a fraction in [0, 0.5)", file.camera.margin),
            ));
        }

        if file.classes.is_empty() {
            return Err(invalid(
                "class",
                "no [[class]]: nothing to record".to_string(),
            ));
        }
        let base = path.parent().unwrap_or_else(|| Path::new("."));
        let mut sources = Vec::new();
        for (k, class) in file.classes.iter().enumerate() {
            let key = format!("class[{k}]");
            check_name(&format!("{key}.category"), &class.category)
                .map_err(|m| invalid(&format!("{key}.category"), m))?;
            check_name(&format!("{key}.action"), &class.action)
                .map_err(|m| invalid(&format!("{key}.action"), m))?;
            if class.sources.is_empty() {
                return Err(invalid(
                    &format!("{key}.sources"),
                    format!("{}/{} has no sources", class.category, class.action),
                ));
            }
            if !file
                .scene
                .locations
                .iter()
                .any(|l| l.suits(&class.requires))
            {
                return Err(invalid(
                    &format!("{key}.requires"),
                    format!("no location in the pool meets {:?}", class.requires),
                ));
            }
            let mut list = Vec::new();
            for (i, written) in class.sources.iter().enumerate() {
                let skey = format!("{key}.sources[{i}]");
                let (file_part, track) = match written.rsplit_once('#') {
                    Some((f, t)) => (
                        f,
                        Some(t.parse::<u64>().map_err(|_| {
                            invalid(
                                &skey,
                                format!("`{written}`: the part after # must be a track id"),
                            )
                        })?),
                    ),
                    None => (written.as_str(), None),
                };
                let resolved = base.join(file_part);
                if !resolved.exists() {
                    return Err(invalid(
                        &skey,
                        format!("{}: no such file or directory", resolved.display()),
                    ));
                }
                list.push(Source {
                    written: written.clone(),
                    path: resolved,
                    track,
                });
            }
            sources.push(list);
        }
        let mut labels: Vec<String> = file.classes.iter().map(|c| c.action.clone()).collect();
        labels.sort();
        labels.dedup();
        let mut seen = BTreeMap::new();
        for (k, class) in file.classes.iter().enumerate() {
            if let Some(j) = file.classes[..k]
                .iter()
                .position(|c| c.category == class.category && c.action == class.action)
            {
                return Err(invalid(
                    &format!("class[{k}]"),
                    format!(
                        "{}/{} is defined again (first in class[{j}]): put all its sources in one [[class]]",
                        class.category, class.action
                    ),
                ));
            }
            if let Some(other) = seen.insert(class.action.clone(), (k, class.category.clone()))
                && other.1 != class.category
            {
                return Err(invalid(
                    &format!("class[{k}].action"),
                    format!(
                        "`{}` is also in category `{}` (class[{}]): an action belongs to one category",
                        class.action, other.1, other.0
                    ),
                ));
            }
        }
        Ok(Spec {
            path: path.to_path_buf(),
            file,
            sources,
            threshold,
            variation,
            labels,
        })
    }
}

/// Names become folder and file names downstream: letters, digits, spaces, `_`, `-`, `.`; not
/// empty, not starting with `.`, no path separators — so a label can never escape the output.
fn check_name(_key: &str, name: &str) -> Result<(), String> {
    if name.trim().is_empty() {
        return Err("must not be empty".to_string());
    }
    if name.starts_with('.') || name.contains('/') || name.contains('\\') {
        return Err(format!(
            "`{name}` would escape the output folder (no `/`, `\\` or leading `.`)"
        ));
    }
    if let Some(c) = name
        .chars()
        .find(|c| !(c.is_alphanumeric() || matches!(c, ' ' | '_' | '-' | '.')))
    {
        return Err(format!(
            "`{name}`: `{c}` is not allowed (letters, digits, space, _ - .)"
        ));
    }
    if name.len() > 100 {
        return Err(format!("`{name}` is longer than 100 bytes"));
    }
    Ok(())
}
