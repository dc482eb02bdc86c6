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

use super::clips::{ClipPolicy, ClipsSection};
use crate::camera::{CameraError, RcmRanges, Shot};
use crate::dataset::randomise::Randomise;
use crate::dsi::plan::{Threshold, ThresholdError};
use crate::dsi::variants::{VariationBounds, VariationBoundsError};
use crate::scene::{SceneConfig, SceneError};

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
    #[error("{path}: {}", .source.to_string().trim_end())]
    Parse {
        /// The spec file.
        path: PathBuf,
        /// toml's error, with line, column and key.
        #[source]
        source: toml::de::Error,
    },
    /// A name (dataset, category, action) that cannot name files.
    #[error("{path}: {key}: {source}")]
    Name {
        /// The spec file.
        path: PathBuf,
        /// The offending key, e.g. `class[2].action`.
        key: String,
        /// What is wrong with the name.
        #[source]
        source: NameError,
    },
    /// `dataset.start_time` is not an instant a bag can stamp.
    #[error("{path}: dataset.start_time: {source}")]
    StartTime {
        /// The spec file.
        path: PathBuf,
        /// Why.
        #[source]
        source: StartTimeError,
    },
    /// `dsi.threshold` does not parse.
    #[error("{path}: dsi.threshold: {source}")]
    Threshold {
        /// The spec file.
        path: PathBuf,
        /// Why.
        #[source]
        source: ThresholdError,
    },
    /// `dsi.variation_deg` does not parse.
    #[error("{path}: dsi.variation_deg: {source}")]
    Variation {
        /// The spec file.
        path: PathBuf,
        /// Why.
        #[source]
        source: VariationBoundsError,
    },
    /// The `[scene]` section is out of range.
    #[error("{path}: scene: {source}")]
    Scene {
        /// The spec file.
        path: PathBuf,
        /// Why.
        #[source]
        source: SceneError,
    },
    /// The camera's RCM ranges are out of range.
    #[error("{path}: camera: {source}")]
    Camera {
        /// The spec file.
        path: PathBuf,
        /// Why.
        #[source]
        source: CameraError,
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
    /// The instant every capture timeline starts at: ISO 8601 / RFC 3339 with a UTC offset, as a
    /// TOML date-time or a string (default [`DEFAULT_START_TIME`]; fixed, so the same spec gives
    /// byte-identical bags).
    #[serde(default = "default_start_time")]
    pub start_time: StartTime,
    /// Which engine `autoact generate` renders with (`--engine` overrides it).
    #[serde(default, skip_serializing_if = "EngineName::is_embedded")]
    pub engine: EngineName,
}

/// A rendering engine, by name (`[dataset] engine`, `--engine`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum EngineName {
    /// autoact's own CPU renderer: fast, no dependencies.
    #[default]
    Embedded,
    /// Blender Cycles through PyPI `bpy` (`tools/setup-blender.sh`): slow, physically based;
    /// the same labels.
    Blender,
}

impl EngineName {
    /// Whether this is the default engine.
    #[must_use]
    pub fn is_embedded(&self) -> bool {
        *self == EngineName::Embedded
    }
}

pub use crate::instant::{DEFAULT_START_TIME, StartTimeError, iso_8601};

/// `[dataset] start_time` as written: a TOML offset date-time or a string.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum StartTime {
    /// `start_time = 2024-05-01T09:00:00Z`.
    Toml(toml::value::Datetime),
    /// `start_time = "2024-05-01T09:00:00+02:00"`.
    Text(String),
}

impl StartTime {
    /// Nanoseconds since the Unix epoch.
    ///
    /// # Errors
    /// [`StartTimeError`]: no UTC offset, not an instant, before 1970 or after 2554.
    pub fn nanos_since_epoch(&self) -> Result<u64, StartTimeError> {
        match self {
            StartTime::Toml(t) => crate::instant::nanos_since_epoch(&t.to_string()),
            StartTime::Text(s) => crate::instant::nanos_since_epoch(s),
        }
    }
}

fn default_start_time() -> StartTime {
    StartTime::Text(DEFAULT_START_TIME.to_string())
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
    /// How the camera moves within a clip: `static` holds each viewpoint (and stands still
    /// unless the body travels too far to stay in frame), `moving` travels smoothly to the
    /// next.
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
    /// This class's clip policy: keys that override the dataset's `[clips]`.
    #[serde(default, skip_serializing_if = "ClipsSection::is_empty")]
    pub clips: ClipsSection,
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
    /// How `trim` cuts segments into clips (see [`crate::dataset::clips`]).
    #[serde(default)]
    pub clips: ClipsSection,
    /// Domain randomisation of the rendered pictures (see [`crate::render::randomise`]).
    #[serde(default, skip_serializing_if = "Randomise::is_default")]
    pub randomise: Randomise,
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
    /// When every capture timeline starts (`[dataset] start_time`), nanoseconds since the epoch.
    pub start_nanos: u64,
    /// Per class (spec order), its clip policy: `[clips]` with the class's own keys over it.
    pub clip_policies: Vec<ClipPolicy>,
}

impl Spec {
    /// Reads and validates a spec file.
    ///
    /// # Errors
    /// [`SpecError`] naming the file and the offending key.
    pub fn load(path: &Path) -> Result<Spec, SpecError> {
        let text = crate::text_file::read_to_string(path).map_err(|source| SpecError::Io {
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
        let file: SpecFile = toml::from_str(text).map_err(|source| SpecError::Parse {
            path: path.to_path_buf(),
            source,
        })?;
        let check = Checker { path };
        check.dataset(&file.dataset)?;
        let start_nanos = file
            .dataset
            .start_time
            .nanos_since_epoch()
            .map_err(|source| SpecError::StartTime {
                path: path.to_path_buf(),
                source,
            })?;
        check.counts(&file.counts)?;
        let (threshold, variation) = check.dsi(&file.dsi)?;
        check.scene_and_camera(&file.scene, &file.camera)?;
        file.randomise
            .validate()
            .map_err(|e| check.invalid(&format!("randomise.{}", e.key), e.message))?;
        let sources = check.classes(&file)?;
        let mut labels: Vec<String> = file.classes.iter().map(|c| c.action.clone()).collect();
        labels.sort();
        labels.dedup();
        check.class_identities(&file.classes)?;
        let clip_policies = check.clip_policies(&file)?;
        Ok(Spec {
            path: path.to_path_buf(),
            file,
            sources,
            threshold,
            variation,
            labels,
            start_nanos,
            clip_policies,
        })
    }
}

/// The checks of [`Spec::parse`], one per section of the spec, each naming `path` and the key.
struct Checker<'a> {
    path: &'a Path,
}

impl Checker<'_> {
    fn invalid(&self, key: &str, message: String) -> SpecError {
        SpecError::Invalid {
            path: self.path.to_path_buf(),
            key: key.to_string(),
            message,
        }
    }

    fn name(&self, key: &str, name: &str) -> Result<(), SpecError> {
        check_name(name).map_err(|source| SpecError::Name {
            path: self.path.to_path_buf(),
            key: key.to_string(),
            source,
        })
    }

    /// `[dataset]`: the name, rate, resolution and leads.
    fn dataset(&self, d: &DatasetSection) -> Result<(), SpecError> {
        self.name("dataset.name", &d.name)?;
        if !(d.fps.is_finite() && d.fps > 0.0 && d.fps <= 1000.0) {
            return Err(self.invalid(
                "dataset.fps",
                format!("{} is not a frame rate in (0, 1000]", d.fps),
            ));
        }
        if d.resolution.contains(&0) || d.resolution.iter().any(|&r| r > 16384) {
            return Err(self.invalid(
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
                return Err(self.invalid(key, format!("{v} is not a duration in [0, 60] s")));
            }
        }
        Ok(())
    }

    /// `[counts]`: each 1–10000.
    fn counts(&self, c: &Counts) -> Result<(), SpecError> {
        for (key, v) in [
            ("counts.variants", c.variants),
            ("counts.scenes", c.scenes),
            ("counts.viewpoints", c.viewpoints),
        ] {
            if v == 0 || v > 10_000 {
                return Err(self.invalid(key, format!("{v}: must be 1–10000")));
            }
        }
        Ok(())
    }

    /// `[dsi]`: the threshold and the variant bounds parsed, the speed positive.
    fn dsi(&self, dsi: &DsiSection) -> Result<(Threshold, VariationBounds), SpecError> {
        let threshold: Threshold =
            dsi.threshold
                .parse()
                .map_err(|source| SpecError::Threshold {
                    path: self.path.to_path_buf(),
                    source,
                })?;
        let variation: VariationBounds =
            dsi.variation_deg
                .parse()
                .map_err(|source| SpecError::Variation {
                    path: self.path.to_path_buf(),
                    source,
                })?;
        if !(dsi.speed.is_finite() && dsi.speed > 0.0) {
            return Err(self.invalid(
                "dsi.speed",
                format!("{} is not a positive speed", dsi.speed),
            ));
        }
        Ok((threshold, variation))
    }

    /// `[scene]` and `[camera]`: their own checks, then the camera's distance and margin.
    fn scene_and_camera(
        &self,
        scene: &SceneConfig,
        camera: &CameraSection,
    ) -> Result<(), SpecError> {
        scene.validate().map_err(|source| SpecError::Scene {
            path: self.path.to_path_buf(),
            source,
        })?;
        camera
            .ranges
            .validate()
            .map_err(|source| SpecError::Camera {
                path: self.path.to_path_buf(),
                source,
            })?;
        if !(camera.max_distance_m.is_finite() && camera.max_distance_m > 0.0) {
            return Err(self.invalid(
                "camera.max_distance_m",
                format!("{} is not a positive distance", camera.max_distance_m),
            ));
        }
        if !(camera.margin.is_finite() && (0.0..0.5).contains(&camera.margin)) {
            return Err(self.invalid(
                "camera.margin",
                format!("{} is not a fraction in [0, 0.5)", camera.margin),
            ));
        }
        Ok(())
    }

    /// `[[class]]`: at least one; each named, with sources, a location that suits it, and its
    /// sources resolved against the spec's folder.
    fn classes(&self, file: &SpecFile) -> Result<Vec<Vec<Source>>, SpecError> {
        if file.classes.is_empty() {
            return Err(self.invalid("class", "no [[class]]: nothing to record".to_string()));
        }
        let mut sources = Vec::new();
        for (k, class) in file.classes.iter().enumerate() {
            let key = format!("class[{k}]");
            self.name(&format!("{key}.category"), &class.category)?;
            self.name(&format!("{key}.action"), &class.action)?;
            if class.sources.is_empty() {
                return Err(self.invalid(
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
                return Err(self.invalid(
                    &format!("{key}.requires"),
                    format!("no location in the pool meets {:?}", class.requires),
                ));
            }
            sources.push(self.class_sources(&key, class)?);
        }
        Ok(sources)
    }

    /// One class's sources (`BAG` or `BAG#TRACK`), resolved; each must exist.
    fn class_sources(&self, key: &str, class: &ClassSpec) -> Result<Vec<Source>, SpecError> {
        let base = self.path.parent().unwrap_or_else(|| Path::new("."));
        let mut list = Vec::new();
        for (i, written) in class.sources.iter().enumerate() {
            let skey = format!("{key}.sources[{i}]");
            let (file_part, track) = match written.rsplit_once('#') {
                Some((f, t)) => (
                    f,
                    Some(t.parse::<u64>().map_err(|_| {
                        self.invalid(
                            &skey,
                            format!("`{written}`: the part after # must be a track id"),
                        )
                    })?),
                ),
                None => (written.as_str(), None),
            };
            let resolved = base.join(file_part);
            if !resolved.exists() {
                return Err(self.invalid(
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
        Ok(list)
    }

    /// `[clips]` over the defaults, then each class's `clips` over that, each checked.
    fn clip_policies(&self, file: &SpecFile) -> Result<Vec<ClipPolicy>, SpecError> {
        let base = file.clips.over(&ClipPolicy::default());
        base.validate()
            .map_err(|e| self.invalid(&format!("clips.{}", e.key), e.message))?;
        file.classes
            .iter()
            .enumerate()
            .map(|(k, class)| {
                let policy = class.clips.over(&base);
                policy
                    .validate()
                    .map_err(|e| self.invalid(&format!("class[{k}].clips.{}", e.key), e.message))?;
                Ok(policy)
            })
            .collect()
    }

    /// Each category/action once, and each action in one category.
    fn class_identities(&self, classes: &[ClassSpec]) -> Result<(), SpecError> {
        let mut seen = BTreeMap::new();
        for (k, class) in classes.iter().enumerate() {
            if let Some(j) = classes[..k]
                .iter()
                .position(|c| c.category == class.category && c.action == class.action)
            {
                return Err(self.invalid(
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
                return Err(self.invalid(
                    &format!("class[{k}].action"),
                    format!(
                        "`{}` is also in category `{}` (class[{}]): an action belongs to one category",
                        class.action, other.1, other.0
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// A name (dataset, category, action) that cannot name a folder or file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NameError {
    /// Empty or blank.
    #[error("must not be empty")]
    Empty,
    /// A path separator or a leading `.`.
    #[error("`{name}` would escape the output folder (no `/`, `\\` or leading `.`)")]
    Escapes {
        /// The name.
        name: String,
    },
    /// A character outside letters, digits, space, `_`, `-` and `.`.
    #[error("`{name}`: `{character}` is not allowed (letters, digits, space, _ - .)")]
    Character {
        /// The name.
        name: String,
        /// The first character not allowed.
        character: char,
    },
    /// Over 100 bytes.
    #[error("`{name}` is longer than 100 bytes")]
    TooLong {
        /// The name.
        name: String,
    },
}

/// Names become folder and file names downstream: letters, digits, spaces, `_`, `-`, `.`; not
/// empty, not starting with `.`, no path separators — so a label can never escape the output.
fn check_name(name: &str) -> Result<(), NameError> {
    if name.trim().is_empty() {
        return Err(NameError::Empty);
    }
    if name.starts_with('.') || name.contains('/') || name.contains('\\') {
        return Err(NameError::Escapes {
            name: name.to_string(),
        });
    }
    if let Some(c) = name
        .chars()
        .find(|c| !(c.is_alphanumeric() || matches!(c, ' ' | '_' | '-' | '.')))
    {
        return Err(NameError::Character {
            name: name.to_string(),
            character: c,
        });
    }
    if name.len() > 100 {
        return Err(NameError::TooLong {
            name: name.to_string(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(dataset_extra: &str) -> Result<Spec, SpecError> {
        let bag = concat!(env!("CARGO_MANIFEST_DIR"), "/bags/bandai_wave.pose.mcap");
        let text = format!(
            "[dataset]\nname = \"t\"\nseed = 1\n{dataset_extra}\n[counts]\n[[class]]\ncategory = \"gesture\"\naction = \"wave\"\nsources = [\"{bag}\"]\n"
        );
        Spec::parse(Path::new("spec.toml"), &text)
    }

    #[test]
    fn capture_timelines_start_at_the_spec_start_time_or_the_fixed_default() {
        assert_eq!(parse("").unwrap().start_nanos, 946_684_800_000_000_000);
        assert_eq!(iso_8601(946_684_800_000_000_000), DEFAULT_START_TIME);
        // A TOML date-time and a string, any UTC offset.
        let toml = parse("start_time = 2024-05-01T09:00:00.25Z").unwrap();
        assert_eq!(toml.start_nanos, 1_714_554_000_250_000_000);
        assert_eq!(iso_8601(toml.start_nanos), "2024-05-01T09:00:00.250Z");
        let text = parse("start_time = \"2024-05-01T11:00:00.25+02:00\"").unwrap();
        assert_eq!(text.start_nanos, toml.start_nanos);
    }

    #[test]
    fn randomise_has_defaults_and_bad_ranges_name_the_file_and_key() {
        let spec = parse("").unwrap();
        assert_eq!(spec.file.randomise, Randomise::default());
        let text = "[dataset]\nname = \"t\"\nseed = 1\n[randomise]\nsensor_noise = [0.05, 0.01]\n[[class]]\ncategory = \"g\"\naction = \"wave\"\nsources = []\n";
        let err = Spec::parse(Path::new("/x/spec.toml"), text)
            .unwrap_err()
            .to_string();
        assert!(err.contains("/x/spec.toml"), "{err}");
        assert!(err.contains("randomise.sensor_noise"), "{err}");
        let typo = text.replace("sensor_noise", "sensor_nois");
        let err = Spec::parse(Path::new("/x/spec.toml"), &typo)
            .unwrap_err()
            .to_string();
        assert!(err.contains("sensor_nois"), "{err}");
    }

    #[test]
    fn the_engine_is_embedded_unless_the_spec_names_blender() {
        assert_eq!(parse("").unwrap().file.dataset.engine, EngineName::Embedded);
        assert_eq!(
            parse("engine = \"blender\"").unwrap().file.dataset.engine,
            EngineName::Blender
        );
        let err = parse("engine = \"unreal\"").unwrap_err().to_string();
        assert!(err.contains("unreal") && err.contains("blender"), "{err}");
        // The default is not written out, so specs without the key serialise as before.
        let spec = parse("").unwrap();
        let json = serde_json::to_string(&spec.file.dataset).unwrap();
        assert!(!json.contains("engine"), "{json}");
    }

    #[test]
    fn clip_policies_take_the_class_keys_over_the_dataset_table_and_bad_ones_name_their_key() {
        use crate::dataset::clips::{ClipMode, Tail};
        let bag = concat!(env!("CARGO_MANIFEST_DIR"), "/bags/bandai_wave.pose.mcap");
        let text = |class_clips: &str| {
            format!(
                "[dataset]\nname = \"t\"\nseed = 1\n[clips]\npolicy = \"windows\"\nlength_frames = 20\n[[class]]\ncategory = \"g\"\naction = \"wave\"\nsources = [\"{bag}\"]\n{class_clips}\n[[class]]\ncategory = \"g\"\naction = \"bow\"\nsources = [\"{bag}\"]\n"
            )
        };
        let spec =
            Spec::parse(Path::new("spec.toml"), &text("clips = { tail = \"drop\" }")).unwrap();
        let [wave, bow] = [&spec.clip_policies[0], &spec.clip_policies[1]];
        assert_eq!(
            (wave.policy, wave.length_frames, wave.tail),
            (ClipMode::Windows, 20, Tail::Drop)
        );
        assert_eq!(
            (bow.policy, bow.length_frames, bow.tail),
            (ClipMode::Windows, 20, Tail::Shift)
        );
        let err = Spec::parse(
            Path::new("spec.toml"),
            &text("clips = { stride_frames = 0 }"),
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("class[0].clips.stride_frames"), "{err}");
        let err = Spec::parse(
            Path::new("spec.toml"),
            &text("clips = { polcy = \"whole\" }"),
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("polcy"), "{err}");
    }

    #[test]
    fn a_start_time_that_is_no_instant_is_refused_by_key() {
        for bad in [
            "start_time = 2024-05-01T09:00:00",
            "start_time = 2024-05-01",
            "start_time = \"yesterday\"",
            "start_time = 1969-12-31T23:59:59Z",
            "start_time = 2600-01-01T00:00:00Z",
        ] {
            let err = parse(bad).unwrap_err().to_string();
            assert!(err.contains("dataset.start_time"), "{bad}: {err}");
        }
    }
}
