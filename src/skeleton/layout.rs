//! Keypoint layouts: which joints a pose estimator outputs, and how they map onto the rig's
//! landmarks. A layout is a data table (TOML), never a code path: the built-in ones are TOML files
//! compiled into the binary (`src/skeleton/layouts/*.toml`), and a user layout file has the same form, so a
//! new pose estimator needs no code.
//!
//! ```toml
//! name = "my-estimator"
//! description = "What produced it"
//! joints = ["hip_l", "hip_r", "knee_l", ...]     # the order of the keypoint arrays
//!
//! [landmarks]                                   # rig landmark = joint expression
//! l_hip = "hip_l"                               # one joint
//! pelvis = { mean = ["hip_l", "hip_r"] }        # the mean of several joints
//! neck = { from = "thorax", to = "head", t = 0.3 }   # a point on the segment from → to
//! ```
//!
//! Which landmarks drive each bone, and which give its twist reference, is the rig's recipe table
//! ([`crate::skeleton::rig::Recipe`], printed by `autoact rig --recipes`); a layout that binds a landmark
//! drives every bone whose recipe can be completed from bound landmarks. Bones no recipe can
//! complete stay at rest, and [`Binding::coverage`] says which.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use nalgebra::{Point3, Unit, Vector3};
use serde::Deserialize;

use crate::skeleton::pose::PoseFrame;
use crate::skeleton::rig::{DirectionSource, Dof, Measure, Reference, Rig};

/// Errors loading or binding a layout.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LayoutError {
    /// The layout file could not be read.
    #[error("cannot read layout file {path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The TOML did not parse or did not have the layout's form.
    #[error("invalid layout in {source_name}: {source}")]
    Parse {
        /// File or built-in name.
        source_name: String,
        /// What the TOML parser said, with the line and column.
        #[source]
        source: Box<toml::de::Error>,
    },
    /// Not a built-in layout name, and no such file.
    #[error(
        "unknown layout `{name}` (built-in layouts: {known}; or give a path to a .toml layout file)"
    )]
    Unknown {
        /// The name asked for.
        name: String,
        /// The built-in names.
        known: String,
    },
    /// A landmark key is not one of the rig's landmarks.
    #[error(
        "layout `{layout}`: `{landmark}` is not a rig landmark (run `autoact rig --landmarks` for the list)"
    )]
    UnknownLandmark {
        /// Layout name.
        layout: String,
        /// The key.
        landmark: String,
    },
    /// A landmark expression names a joint the layout does not list.
    #[error(
        "layout `{layout}`: landmark `{landmark}` uses joint `{joint}`, which is not in `joints`"
    )]
    UnknownJoint {
        /// Layout name.
        layout: String,
        /// The landmark.
        landmark: String,
        /// The joint.
        joint: String,
    },
    /// A joint name appears twice in `joints`.
    #[error("layout `{layout}`: joint `{joint}` is listed twice")]
    DuplicateJoint {
        /// Layout name.
        layout: String,
        /// The joint.
        joint: String,
    },
    /// An expression is empty or has a non-finite parameter.
    #[error("layout `{layout}`: landmark `{landmark}` has an invalid expression ({why})")]
    BadExpression {
        /// Layout name.
        layout: String,
        /// The landmark.
        landmark: String,
        /// What is wrong.
        why: &'static str,
    },
    /// A `[bones.NAME]` entry is wrong.
    #[error("layout `{layout}`: [bones.{bone}] {why}")]
    BadBoneOverride {
        /// Layout name.
        layout: String,
        /// The bone key.
        bone: String,
        /// What is wrong.
        why: String,
    },
    /// The pose data's joints do not match the layout's.
    #[error("the data has joints the layout `{layout}` does not list: {missing}")]
    JointMismatch {
        /// Layout name.
        layout: String,
        /// Up to ten joint names, comma-separated.
        missing: String,
    },
}

/// A joint expression: where a landmark is, in terms of a layout's joints.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged, deny_unknown_fields)]
pub enum JointExpr {
    /// One joint.
    Joint(String),
    /// The mean of several joints.
    Mean {
        /// Joint names.
        mean: Vec<String>,
    },
    /// `from + t · (to − from)`.
    Lerp {
        /// Start joint.
        from: String,
        /// End joint.
        to: String,
        /// Fraction along the segment.
        t: f64,
    },
}

impl JointExpr {
    /// The joints this expression names.
    #[must_use]
    pub fn joints(&self) -> Vec<&String> {
        match self {
            JointExpr::Joint(j) => vec![j],
            JointExpr::Mean { mean } => mean.iter().collect(),
            JointExpr::Lerp { from, to, .. } => vec![from, to],
        }
    }

    /// This expression as `(joint index, weight)` terms over `joint_names` (the order of a
    /// frame's joints): the point is the weighted sum. `None` when it names a joint not among
    /// them. The one place a landmark expression becomes arithmetic: binding a layout to the rig,
    /// grounding and the BVH up check all go through it.
    #[must_use]
    pub fn terms(&self, joint_names: &[String]) -> Option<Vec<(usize, f64)>> {
        let index = |j: &String| joint_names.iter().position(|n| n == j);
        Some(match self {
            JointExpr::Joint(j) => vec![(index(j)?, 1.0)],
            JointExpr::Mean { mean } => {
                #[expect(clippy::cast_precision_loss, reason = "a mean of a handful of joints")]
                let w = 1.0 / mean.len() as f64;
                mean.iter()
                    .map(|j| Some((index(j)?, w)))
                    .collect::<Option<_>>()?
            }
            JointExpr::Lerp { from, to, t } => vec![(index(from)?, 1.0 - t), (index(to)?, *t)],
        })
    }
}

/// The least confidence of an observed joint, for [`terms_point`]: any above 0.
pub const OBSERVED: f32 = f32::MIN_POSITIVE;

/// The point `terms` ([`JointExpr::terms`]) give in `frame`, or `None` when there are none or a
/// joint they need is missing: absent, non-finite, or its confidence NaN or below
/// `min_confidence`.
#[must_use]
pub fn terms_point(
    terms: &[(usize, f64)],
    frame: &PoseFrame,
    min_confidence: f32,
) -> Option<Point3<f64>> {
    if terms.is_empty() {
        return None;
    }
    let mut sum = Vector3::zeros();
    for &(j, w) in terms {
        let p = frame.positions_m.get(j)?;
        let c = frame.confidence.get(j).copied().unwrap_or(1.0);
        if c.is_nan() || c < min_confidence || !p.coords.iter().all(|v| v.is_finite()) {
            return None;
        }
        sum += p.coords * w;
    }
    Some(Point3::from(sum))
}

/// A keypoint layout.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Layout {
    /// Short name, e.g. `h36m-17`.
    pub name: String,
    /// One line on what produces this layout.
    #[serde(default)]
    pub description: String,
    /// Joint names in keypoint-array order.
    pub joints: Vec<String>,
    /// Rig landmark → joint expression.
    #[serde(default)]
    pub landmarks: BTreeMap<String, JointExpr>,
    /// Per bone, landmarks that drive it instead of the rig's recipe (for estimators whose points
    /// sit differently from the rig's usual choice).
    #[serde(default)]
    pub bones: BTreeMap<String, BoneOverride>,
}

/// Which landmarks drive one bone, overriding the rig's recipe for a layout.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoneOverride {
    /// The bone points from the first landmark to the second.
    pub direction: [String; 2],
    /// Twist reference: the direction from the first landmark to the second, projected
    /// perpendicular to the bone (3-D bones only; others have no twist).
    pub reference: Option<[String; 2]>,
}

/// The built-in layouts: (name, aliases, TOML text).
const BUILTIN: [(&str, &[&str], &str); 12] = [
    (
        "coco-wholebody-133",
        &["h3wb", "coco-wholebody"],
        include_str!("layouts/coco-wholebody-133.toml"),
    ),
    ("coco-17", &["coco"], include_str!("layouts/coco-17.toml")),
    (
        "ntu-25",
        &["ntu", "kinect-v2"],
        include_str!("layouts/ntu-25.toml"),
    ),
    (
        "kinect-v1-20",
        &["kinect-v1"],
        include_str!("layouts/kinect-v1-20.toml"),
    ),
    (
        "panoptic-coco19",
        &["panoptic", "coco19"],
        include_str!("layouts/panoptic-coco19.toml"),
    ),
    ("h36m-17", &["h36m"], include_str!("layouts/h36m-17.toml")),
    ("h36m-32", &[], include_str!("layouts/h36m-32.toml")),
    (
        "zed-body-34",
        &["zed", "body-34"],
        include_str!("layouts/zed-body-34.toml"),
    ),
    (
        "mediapipe-pose-33",
        &["mediapipe", "blazepose"],
        include_str!("layouts/mediapipe-pose-33.toml"),
    ),
    ("smpl-24", &["smpl"], include_str!("layouts/smpl-24.toml")),
    (
        "smplx-55",
        &["smplx", "smpl-x"],
        include_str!("layouts/smplx-55.toml"),
    ),
    (
        "azure-kinect-32",
        &["azure-kinect", "k4abt", "orbbec-femto"],
        include_str!("layouts/azure-kinect-32.toml"),
    ),
];

impl Layout {
    /// Parses a layout from TOML text; `source_name` is used in errors.
    ///
    /// # Errors
    /// [`LayoutError::Parse`] with the TOML parser's position, or a validation error.
    pub fn from_toml(text: &str, source_name: &str) -> Result<Layout, LayoutError> {
        let layout: Layout = toml::from_str(text).map_err(|source| LayoutError::Parse {
            source_name: source_name.to_string(),
            source: Box::new(source),
        })?;
        layout.validate()?;
        Ok(layout)
    }

    /// A layout whose joints are the rig's own landmarks, one to one (`autoact-landmarks`): for
    /// data already in the rig's vocabulary, and for tests that pose the rig and read it back.
    #[must_use]
    pub fn rig_landmarks(rig: &Rig) -> Layout {
        let joints: Vec<String> = rig.landmarks.iter().map(|l| l.name.clone()).collect();
        let landmarks = joints
            .iter()
            .map(|j| (j.clone(), JointExpr::Joint(j.clone())))
            .collect();
        Layout {
            name: "autoact-landmarks".to_string(),
            description: "the rig's own landmarks, one joint each".to_string(),
            joints,
            landmarks,
            bones: BTreeMap::new(),
        }
    }

    /// This layout without the landmarks that use a joint for which `present` is false: for a
    /// source that never has those joints (mocap without fingers), so the bones they would drive
    /// are reported as left at rest instead of as missing in every frame.
    #[must_use]
    pub fn restricted(&self, present: &[bool]) -> Layout {
        let has = |j: &String| {
            self.joints
                .iter()
                .position(|n| n == j)
                .is_some_and(|i| present.get(i).copied().unwrap_or(false))
        };
        let landmarks = self
            .landmarks
            .iter()
            .filter(|(_, e)| match e {
                JointExpr::Joint(j) => has(j),
                JointExpr::Mean { mean } => mean.iter().all(has),
                JointExpr::Lerp { from, to, .. } => has(from) && has(to),
            })
            .map(|(k, e)| (k.clone(), e.clone()))
            .collect();
        Layout {
            landmarks,
            ..self.clone()
        }
    }

    /// This layout's keypoints read off a posed body: each joint that a landmark names on its own
    /// gets that landmark's position; joints only used inside means, or not at all (face points),
    /// are missing (NaN, confidence 0). For synthetic test data and benchmarks.
    #[must_use]
    pub fn keypoints_from_rig(
        &self,
        rig: &Rig,
        character: &crate::skeleton::character::Character,
        world: &crate::skeleton::fk::WorldPose,
        stamp_nanos: u64,
    ) -> crate::skeleton::pose::PoseFrame {
        let mut frame = crate::skeleton::pose::PoseFrame::missing(stamp_nanos, self.joints.len());
        for (landmark, expr) in &self.landmarks {
            let (JointExpr::Joint(j), Some(l)) = (expr, rig.landmark_index(landmark)) else {
                continue;
            };
            if let Some(k) = self.joints.iter().position(|n| n == j) {
                frame.positions_m[k] =
                    crate::skeleton::fk::landmark_position(rig, character, world, l);
                frame.confidence[k] = 1.0;
            }
        }
        frame
    }

    /// The names of the built-in layouts.
    #[must_use]
    pub fn builtin_names() -> Vec<&'static str> {
        let mut names: Vec<&'static str> = BUILTIN.iter().map(|(n, _, _)| *n).collect();
        names.push("autoact-landmarks");
        names
    }

    /// A built-in layout by name or alias.
    ///
    /// # Errors
    /// [`LayoutError::Unknown`] for a name that is not built in.
    pub fn builtin(name: &str) -> Result<Layout, LayoutError> {
        let want = name.to_ascii_lowercase().replace('_', "-");
        let found = BUILTIN
            .iter()
            .find(|(n, aliases, _)| *n == want || aliases.contains(&want.as_str()));
        match found {
            Some((n, _, text)) => Layout::from_toml(text, n),
            None if want == "autoact-landmarks" => Ok(Layout::rig_landmarks(&Rig::standard())),
            None => Err(LayoutError::Unknown {
                name: name.to_string(),
                known: Layout::builtin_names().join(", "),
            }),
        }
    }

    /// A built-in layout name, or a path to a TOML layout file.
    ///
    /// # Errors
    /// As [`Layout::builtin`] and [`Layout::from_toml`], or [`LayoutError::Io`].
    pub fn load(name_or_path: &str) -> Result<Layout, LayoutError> {
        let path = Path::new(name_or_path);
        let looks_like_file =
            path.extension().is_some_and(|e| e == "toml") || name_or_path.contains('/');
        if looks_like_file {
            let text =
                crate::text_file::read_to_string(path).map_err(|source| LayoutError::Io {
                    path: path.to_path_buf(),
                    source,
                })?;
            return Layout::from_toml(&text, name_or_path);
        }
        Layout::builtin(name_or_path)
    }

    fn validate(&self) -> Result<(), LayoutError> {
        let layout = || self.name.clone();
        for (i, j) in self.joints.iter().enumerate() {
            if self.joints[..i].contains(j) {
                return Err(LayoutError::DuplicateJoint {
                    layout: layout(),
                    joint: j.clone(),
                });
            }
        }
        for (landmark, expr) in &self.landmarks {
            let bad = |why| LayoutError::BadExpression {
                layout: layout(),
                landmark: landmark.clone(),
                why,
            };
            match expr {
                JointExpr::Mean { mean } if mean.is_empty() => return Err(bad("empty mean")),
                JointExpr::Lerp { t, .. } if !t.is_finite() => return Err(bad("t is not finite")),
                _ => {}
            }
            for j in expr.joints() {
                if !self.joints.contains(j) {
                    return Err(LayoutError::UnknownJoint {
                        layout: layout(),
                        landmark: landmark.clone(),
                        joint: j.clone(),
                    });
                }
            }
        }
        Ok(())
    }

    /// Binds this layout to a rig.
    ///
    /// # Errors
    /// [`LayoutError::UnknownLandmark`] for a landmark key the rig does not have.
    pub fn bind(&self, rig: &Rig) -> Result<Binding, LayoutError> {
        let mut landmark_terms = vec![None; rig.landmarks.len()];
        for (name, expr) in &self.landmarks {
            let Some(li) = rig.landmark_index(name) else {
                return Err(LayoutError::UnknownLandmark {
                    layout: self.name.clone(),
                    landmark: name.clone(),
                });
            };
            let Some(terms) = expr.terms(&self.joints) else {
                let missing = expr.joints().into_iter().find(|j| !self.joints.contains(j));
                return Err(LayoutError::UnknownJoint {
                    layout: self.name.clone(),
                    landmark: name.clone(),
                    joint: missing.cloned().unwrap_or_default(),
                });
            };
            landmark_terms[li] = Some(terms);
        }
        let bound = |set: &[usize]| set.iter().all(|&l| landmark_terms[l].is_some());
        let mut bone_sources: Vec<BoneSource> = rig
            .recipes
            .iter()
            .map(|r| BoneSource {
                bone: r.bone,
                direction: r
                    .directions
                    .iter()
                    .find(|d| bound(&d.from) && bound(&d.to))
                    .cloned(),
                reference: r
                    .references
                    .iter()
                    .find(|refr| match refr {
                        Reference::Direction { from, to } => bound(from) && bound(to),
                        Reference::Normal { points, .. } => bound(points),
                    })
                    .cloned(),
            })
            .collect();
        for (bone_name, o) in &self.bones {
            let bad = |why: String| LayoutError::BadBoneOverride {
                layout: self.name.clone(),
                bone: bone_name.clone(),
                why,
            };
            let Some(source) = rig
                .bone_index(bone_name)
                .and_then(|b| bone_sources.iter_mut().find(|s| s.bone == b))
            else {
                return Err(bad(
                    "is not a bone that can move (see `autoact rig`)".to_string()
                ));
            };
            let landmark = |name: &String| -> Result<usize, LayoutError> {
                match rig.landmark_index(name) {
                    Some(l) if landmark_terms[l].is_some() => Ok(l),
                    Some(_) => Err(bad(format!(
                        "uses landmark `{name}`, which this layout does not bind"
                    ))),
                    None => Err(bad(format!("uses `{name}`, which is not a rig landmark"))),
                }
            };
            let (from, to) = (landmark(&o.direction[0])?, landmark(&o.direction[1])?);
            let rest_dir = rig.landmarks[to].rest_m - rig.landmarks[from].rest_m;
            if rest_dir.norm() < 1e-3 {
                return Err(bad(
                    "direction: the two landmarks coincide at rest".to_string()
                ));
            }
            source.direction = Some(DirectionSource {
                from: vec![from],
                to: vec![to],
            });
            if let Some([a, b]) = &o.reference {
                let (a, b) = (landmark(a)?, landmark(b)?);
                let rest_ref = rig.landmarks[b].rest_m - rig.landmarks[a].rest_m;
                if rest_ref.cross(&rest_dir).norm() < 0.05 * rest_ref.norm() * rest_dir.norm() {
                    return Err(bad(
                        "reference: parallel to the bone at rest, so it cannot give a twist"
                            .to_string(),
                    ));
                }
                source.reference = Some(Reference::Direction {
                    from: vec![a],
                    to: vec![b],
                });
            }
        }
        Ok(Binding {
            layout_name: self.name.clone(),
            joint_count: self.joints.len(),
            landmark_terms,
            bone_sources,
        })
    }

    /// Maps the joint order of some data onto this layout's order: `result[k]` is the index in
    /// `data_joints` of this layout's joint `k`, or `None` when the data does not have it (a
    /// source may carry only the joints it observes).
    ///
    /// # Errors
    /// [`LayoutError::JointMismatch`] when the data has joints the layout does not list (it is
    /// in another layout), naming them.
    pub fn joint_order(&self, data_joints: &[String]) -> Result<Vec<Option<usize>>, LayoutError> {
        let mut foreign: Vec<&str> = data_joints
            .iter()
            .filter(|d| !self.joints.contains(d))
            .map(String::as_str)
            .collect();
        if !foreign.is_empty() || data_joints.is_empty() {
            let n = foreign.len();
            foreign.truncate(10);
            let more = if n > 10 {
                format!(" and {} more", n - 10)
            } else {
                String::new()
            };
            let listed = if foreign.is_empty() {
                "(no joints at all)".to_string()
            } else {
                format!("{}{more}", foreign.join(", "))
            };
            return Err(LayoutError::JointMismatch {
                layout: self.name.clone(),
                missing: listed,
            });
        }
        Ok(self
            .joints
            .iter()
            .map(|j| data_joints.iter().position(|d| d == j))
            .collect())
    }

    /// Reorders one frame of data (joints `data_joints` order, see [`Layout::joint_order`]) into
    /// this layout's order; joints the data lacks are missing (NaN, confidence 0).
    #[must_use]
    pub fn reorder(
        order: &[Option<usize>],
        frame: &crate::skeleton::pose::PoseFrame,
    ) -> crate::skeleton::pose::PoseFrame {
        let missing = nalgebra::Point3::new(f64::NAN, f64::NAN, f64::NAN);
        crate::skeleton::pose::PoseFrame {
            stamp_nanos: frame.stamp_nanos,
            positions_m: order
                .iter()
                .map(|i| {
                    i.and_then(|i| frame.positions_m.get(i).copied())
                        .unwrap_or(missing)
                })
                .collect(),
            confidence: order
                .iter()
                .map(|i| {
                    i.and_then(|i| frame.confidence.get(i).copied())
                        .unwrap_or(0.0)
                })
                .collect(),
        }
    }
}

/// What drives one bone for a layout: the recipe alternative (or the layout's override) it uses.
#[derive(Debug, Clone, PartialEq)]
pub struct BoneSource {
    /// Bone index.
    pub bone: usize,
    /// The direction's landmarks, or `None`: the bone stays at rest.
    pub direction: Option<DirectionSource>,
    /// The twist reference, or `None`: the twist is not observed.
    pub reference: Option<Reference>,
}

/// A layout bound to a rig: precomputed landmark expressions and recipe choices.
#[derive(Debug, Clone, PartialEq)]
pub struct Binding {
    /// Name of the layout.
    pub layout_name: String,
    /// Number of joints the layout lists.
    pub joint_count: usize,
    /// Per rig landmark: `(joint index, weight)` terms, or `None` when the layout lacks it.
    pub landmark_terms: Vec<Option<Vec<(usize, f64)>>>,
    /// Per recipe (in rig recipe order): the alternatives this layout uses.
    pub bone_sources: Vec<BoneSource>,
}

/// What a layout drives, for reports and `autoact rig --layout`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Coverage {
    /// Bones whose direction (and, for 3-D bones, twist) the layout observes.
    pub driven: Vec<String>,
    /// 3-D bones whose direction is observed but whose twist is not (it is carried over from the
    /// parent frame with the smallest rotation, and held while the pose allows).
    pub twist_unobserved: Vec<String>,
    /// Bones the layout cannot drive: they stay at rest ("major-part motion").
    pub at_rest: Vec<String>,
}

impl Binding {
    /// Position of landmark `l` from one frame's joint positions, or `None` when the layout lacks
    /// it or a joint it needs is missing (non-finite or below `min_confidence`).
    #[must_use]
    pub fn landmark_point(
        &self,
        l: usize,
        frame: &PoseFrame,
        min_confidence: f32,
    ) -> Option<Point3<f64>> {
        terms_point(self.landmark_terms[l].as_ref()?, frame, min_confidence)
    }

    /// The mean of a landmark set in one frame (see [`Binding::landmark_point`]), or `None` if
    /// any of them is missing.
    #[must_use]
    pub fn set_point(
        &self,
        set: &[usize],
        frame: &PoseFrame,
        min_confidence: f32,
    ) -> Option<Point3<f64>> {
        let mut sum = Vector3::zeros();
        for &l in set {
            sum += self.landmark_point(l, frame, min_confidence)?.coords;
        }
        #[expect(
            clippy::cast_precision_loss,
            reason = "landmark sets hold a handful of points"
        )]
        let n = set.len().max(1) as f64;
        Some(Point3::from(sum / n))
    }

    /// The segments to measure when fitting a body to data in this layout: every direction this
    /// layout drives a bone along (once each), and the rig's static widths.
    #[must_use]
    pub fn measures(&self, rig: &Rig) -> Vec<Measure> {
        let mut out: Vec<Measure> = Vec::new();
        for d in self
            .bone_sources
            .iter()
            .filter_map(|s| s.direction.as_ref())
        {
            if !out.iter().any(|m| m.from == d.from && m.to == d.to) {
                out.extend(rig.measure(&d.from, &d.to));
            }
        }
        let bound = |set: &[usize]| set.iter().all(|&l| self.landmark_terms[l].is_some());
        out.extend(
            rig.width_measures
                .iter()
                .filter(|m| bound(&m.from) && bound(&m.to))
                .cloned(),
        );
        out
    }

    /// Which bones this layout drives.
    #[must_use]
    pub fn coverage(&self, rig: &Rig) -> Coverage {
        let mut c = Coverage {
            driven: Vec::new(),
            twist_unobserved: Vec::new(),
            at_rest: Vec::new(),
        };
        for s in &self.bone_sources {
            let name = rig.bones[s.bone].name.clone();
            match (&s.direction, &s.reference, rig.bones[s.bone].dof) {
                (None, _, _) => c.at_rest.push(name),
                (Some(_), None, Dof::ThreeD) => c.twist_unobserved.push(name),
                _ => c.driven.push(name),
            }
        }
        c
    }
}

/// The rest-frame direction of a recipe reference, perpendicular to `rest_dir`.
#[must_use]
pub fn rest_reference(rig: &Rig, reference: &Reference) -> Vector3<f64> {
    match reference {
        Reference::Direction { from, to } => rig.rest_point(to) - rig.rest_point(from),
        Reference::Normal { rest, .. } => Unit::into_inner(*rest),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_layout_parses_and_binds() {
        let rig = Rig::standard();
        for name in Layout::builtin_names() {
            let layout = Layout::builtin(name).unwrap();
            assert_eq!(layout.name, name);
            let binding = layout.bind(&rig).unwrap();
            let cov = binding.coverage(&rig);
            assert!(
                cov.driven.len() >= 10,
                "{name} drives only {:?}",
                cov.driven
            );
        }
    }

    /// SMPL-X's body is SMPL's first 22 joints, so its table maps them as `smpl-24` does: the
    /// two TOML files cannot share the lines, this keeps them from drifting apart.
    #[test]
    fn smplx_maps_its_body_as_smpl_does() {
        let smpl = Layout::builtin("smpl-24").unwrap();
        let smplx = Layout::builtin("smplx-55").unwrap();
        assert_eq!(smplx.joints[..22], smpl.joints[..22]);
        let body = |layout: &Layout| {
            layout
                .landmarks
                .iter()
                .filter(|(landmark, _)| !landmark.ends_with(char::is_numeric))
                .map(|(landmark, expr)| (landmark.clone(), expr.clone()))
                .collect::<Vec<_>>()
        };
        assert_eq!(body(&smplx), body(&smpl));
    }

    #[test]
    fn coco_wholebody_drives_fingers_and_h36m_leaves_them_at_rest() {
        let rig = Rig::standard();
        let coco = Layout::builtin("h3wb")
            .unwrap()
            .bind(&rig)
            .unwrap()
            .coverage(&rig);
        assert!(
            coco.at_rest.is_empty(),
            "COCO-WholeBody leaves {:?} at rest",
            coco.at_rest
        );
        assert!(coco.driven.iter().any(|b| b == "l_index2"));
        let h36m = Layout::builtin("h36m-17")
            .unwrap()
            .bind(&rig)
            .unwrap()
            .coverage(&rig);
        assert!(h36m.at_rest.iter().any(|b| b == "l_index2"));
        assert!(h36m.at_rest.iter().any(|b| b == "l_hand"));
        assert!(h36m.driven.iter().any(|b| b == "l_forearm"));
    }

    #[test]
    fn user_layout_errors_name_the_problem() {
        let rig = Rig::standard();
        let err = Layout::from_toml(
            "name = \"x\"\njoints = [\"a\"]\n[landmarks]\nl_hip = \"b\"\n",
            "x.toml",
        )
        .unwrap_err();
        assert!(err.to_string().contains("`b`"), "{err}");
        let err = Layout::from_toml(
            "name = \"x\"\njoints = [\"a\"]\n[landmarks]\nelbow = \"a\"\n",
            "x.toml",
        )
        .unwrap()
        .bind(&rig)
        .unwrap_err();
        assert!(
            err.to_string().contains("`elbow` is not a rig landmark"),
            "{err}"
        );
        let err =
            Layout::from_toml("name = \"x\"\njoints = [\"a\", \"a\"]\n", "x.toml").unwrap_err();
        assert!(err.to_string().contains("listed twice"), "{err}");
        let err = Layout::from_toml("name = \"x\"\njoints = [\"a\"\n", "x.toml").unwrap_err();
        assert!(err.to_string().contains("x.toml"), "{err}");
        let err = Layout::load("no-such-layout").unwrap_err();
        assert!(err.to_string().contains("h36m-17"), "{err}");
    }

    #[test]
    fn bone_overrides_drive_a_bone_from_other_landmarks() {
        let rig = Rig::standard();
        let text = "name = \"feet\"\njoints = [\"a\", \"h\", \"t\"]\n[landmarks]\nl_ankle = \"a\"\nl_heel = \"h\"\nl_big_toe = \"t\"\n\
                    [bones.l_foot]\ndirection = [\"l_heel\", \"l_big_toe\"]\n";
        let layout = Layout::from_toml(text, "feet.toml").unwrap();
        let binding = layout.bind(&rig).unwrap();
        let foot = rig.bone_index("l_foot").unwrap();
        let src = binding
            .bone_sources
            .iter()
            .find(|s| s.bone == foot)
            .unwrap();
        let heel = rig.landmark_index("l_heel").unwrap();
        assert_eq!(src.direction.as_ref().unwrap().from, vec![heel]);
        assert!(
            binding
                .coverage(&rig)
                .driven
                .contains(&"l_foot".to_string())
        );
        // Errors name the bone and the problem.
        let bad = |extra: &str| {
            Layout::from_toml(
                &format!("name = \"x\"\njoints = [\"a\"]\n[landmarks]\nl_ankle = \"a\"\n{extra}"),
                "x",
            )
            .unwrap()
            .bind(&rig)
            .unwrap_err()
            .to_string()
        };
        assert!(
            bad("[bones.spine_root]\ndirection = [\"l_ankle\", \"l_ankle\"]\n")
                .contains("[bones.spine_root] is not a bone that can move")
        );
        assert!(
            bad("[bones.l_foot]\ndirection = [\"l_ankle\", \"l_toe\"]\n").contains("does not bind")
        );
        assert!(
            bad("[bones.l_foot]\ndirection = [\"l_ankle\", \"toe\"]\n")
                .contains("not a rig landmark")
        );
        assert!(
            bad("[bones.l_foot]\ndirection = [\"l_ankle\", \"l_ankle\"]\n").contains("coincide")
        );
    }

    #[test]
    fn lerp_and_mean_expressions_evaluate() {
        let rig = Rig::standard();
        let layout = Layout::from_toml(
            "name = \"t\"\njoints = [\"a\", \"b\"]\n[landmarks]\npelvis = { mean = [\"a\", \"b\"] }\nchest = { from = \"a\", to = \"b\", t = 0.25 }\n",
            "t",
        )
        .unwrap();
        let b = layout.bind(&rig).unwrap();
        let frame = |c: [f32; 2]| PoseFrame {
            stamp_nanos: 0,
            positions_m: vec![Point3::new(0.0, 0.0, 0.0), Point3::new(4.0, 0.0, 0.0)],
            confidence: c.to_vec(),
        };
        let pelvis = rig.landmark_index("pelvis").unwrap();
        let chest = rig.landmark_index("chest").unwrap();
        assert_eq!(
            b.landmark_point(pelvis, &frame([1.0, 1.0]), 0.5),
            Some(Point3::new(2.0, 0.0, 0.0))
        );
        assert_eq!(
            b.landmark_point(chest, &frame([1.0, 1.0]), 0.5),
            Some(Point3::new(1.0, 0.0, 0.0))
        );
        assert_eq!(
            b.landmark_point(chest, &frame([1.0, 0.1]), 0.5),
            None,
            "low confidence is missing"
        );
    }
}
