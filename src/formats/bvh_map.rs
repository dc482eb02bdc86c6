//! Keypoints of a layout from a BVH clip: mocap joints (and points fixed in a joint's frame, such
//! as the top of the head or the tip of the big toe) mapped onto a keypoint layout's joints, so
//! that motion capture can stand in for a pose estimator's output with known ground truth.
//!
//! A mapping is a data table per BVH skeleton family (TOML; the built-in ones are in
//! `src/skeleton/layouts/bvh/`):
//!
//! ```toml
//! skeleton = "bandai-namco"
//! required = ["Hips", "Chest"]          # joints that identify the skeleton
//! metres_per_unit = 0.01                # optional; else guessed from the rest skeleton
//! [points]                              # virtual points: joint + offset in its frame (file units)
//! head_top = { joint = "Head", offset = [22.0, 0.0, 0.0] }
//! [layouts.h36m-17]                     # layout joint = BVH joint, virtual point, or expression
//! root = { mean = ["UpperLeg_L", "UpperLeg_R"] }
//! head = "head_top"
//! ```
//!
//! Layout joints a mapping does not give are missing (NaN, confidence 0) in every frame. A
//! point's offset is in its joint's frame as a Y-up file has it (nearly every BVH is Y-up); a
//! file found or told to be in other axes ([`found_axes`], `import --axes`) gets the same body
//! point, the offset turned into its axes. A layout joint may also name alternatives,
//! `{ first = ["LeftToeBase", "LeftFoot_End"] }`: the first the clip has is used, and the joint
//! is missing when it has none (one table then serves a skeleton family whose files differ in
//! their optional joints).
//!
//! Names are matched as written, or else without a namespace prefix: Mixamo's
//! `mixamorig:LeftArm` (or `mixamorig1:LeftArm`) is `LeftArm` to a mapping, when no other joint
//! of the clip has that name.
//!
//! Every built-in mapping has a table for `autoact-landmarks` (the rig's own landmarks, see
//! `autoact rig --landmarks`), the layout a BVH import uses unless told otherwise
//! ([`DEFAULT_LAYOUT`]): it drives every rig bone the source skeleton has a joint for. A BVH
//! skeleton without a built-in mapping needs a mapping file of the same form
//! ([`BvhMapping::from_file`], `autoact import --bvh-map`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use nalgebra::{Point3, Rotation3, UnitQuaternion, Vector3};
use serde::Deserialize;

use super::bvh::Bvh;
use crate::skeleton::frames::SourceAxes;
use crate::skeleton::layout::{JointExpr, Layout, OBSERVED, terms_point};
use crate::skeleton::pose::{PoseFrame, PoseSequence, stamp_nanos_at};

/// The layout a BVH clip is mapped onto unless another is asked for: the rig's own landmarks,
/// so that the spine, neck, head, clavicles, hands and feet follow the source's joints.
pub const DEFAULT_LAYOUT: &str = "autoact-landmarks";

/// Where to read about mapping files, for error messages.
pub const MAPPING_DOCS: &str = "docs/convert.md, section \"BVH mapping files\"";

/// Errors building keypoints from a BVH clip.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BvhMapError {
    /// A mapping file could not be read.
    #[error("cannot read BVH mapping file {}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The mapping table did not parse.
    #[error("invalid BVH mapping {name}: {message}")]
    Parse {
        /// Mapping name or file.
        name: String,
        /// Where (line and column) and what the TOML parser said.
        message: String,
    },
    /// No built-in mapping fits the clip's joints.
    #[error(
        "{source_name}: no built-in BVH mapping fits this skeleton (built in: {known}).\n\
         Its joints are: {joints}.\n\
         Write a mapping file that names them (see {MAPPING_DOCS}; copy a built-in one such as \
         src/skeleton/layouts/bvh/cmu.toml from the autoact sources) and pass it with \
         --bvh-map FILE.toml"
    )]
    NoMapping {
        /// The BVH file.
        source_name: String,
        /// Built-in mapping names, each with the joints it requires.
        known: String,
        /// The clip's joints (End Sites left out).
        joints: String,
    },
    /// A mapping file's `required` joints are not all in the clip.
    #[error(
        "{source_name}: BVH mapping `{mapping}` requires joints the clip does not have: {missing} (the clip's joints: {joints})"
    )]
    MissingJoints {
        /// The BVH file.
        source_name: String,
        /// Mapping name.
        mapping: String,
        /// The required joints not found.
        missing: String,
        /// The clip's joints (End Sites left out).
        joints: String,
    },
    /// A mapping's layout table names a joint the layout does not have.
    #[error(
        "BVH mapping `{mapping}`: [layouts.{layout}] sets `{joint}`, which is not a joint of layout `{layout}`{hint}"
    )]
    UnknownLayoutJoint {
        /// Mapping name.
        mapping: String,
        /// Layout name.
        layout: String,
        /// The key.
        joint: String,
        /// Where to find the layout's joints.
        hint: &'static str,
    },
    /// The mapping has no table for the layout.
    #[error("BVH mapping `{mapping}` has no table for layout `{layout}` (it has: {available})")]
    NoLayoutTable {
        /// Mapping name.
        mapping: String,
        /// Layout asked for.
        layout: String,
        /// Layouts it has.
        available: String,
    },
    /// An expression names something that is neither a BVH joint nor a virtual point.
    #[error(
        "{source_name}: BVH mapping `{mapping}` uses `{name}`, which is neither a joint of the clip nor a virtual point (the clip's joints: {joints})"
    )]
    UnknownName {
        /// The BVH file.
        source_name: String,
        /// Mapping name.
        mapping: String,
        /// The name.
        name: String,
        /// The clip's joints (End Sites included, as `<parent>_End`).
        joints: String,
    },
    /// A channel value that is not physical once the units are known.
    #[error(transparent)]
    Values(#[from] super::bvh::BvhError),
    /// The clip's units cannot be guessed and the mapping does not state them.
    #[error(
        "{source_name}: cannot tell the units of this BVH (rest skeleton {extent:.1} units tall, \
         not the size of a person in cm, m or inches); state them: --metres-per-unit 0.01 for \
         cm (or `metres_per_unit` in a mapping file given with --bvh-map, see {MAPPING_DOCS})"
    )]
    UnknownUnits {
        /// The BVH file.
        source_name: String,
        /// Rest extent.
        extent: f64,
    },
}

/// A point fixed in a BVH joint's frame.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VirtualPoint {
    /// The joint it rides on.
    pub joint: String,
    /// Offset in the joint's frame, file units.
    pub offset: [f64; 3],
}

/// Where a layout joint is in a BVH clip: a joint expression over joints and virtual points, or
/// the first of several names the clip has.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum BvhExpr {
    /// The first of these names (joints, End Sites as `<joint>_End`, virtual points) that the
    /// clip has; the layout joint is missing in every frame when it has none of them.
    First(FirstOf),
    /// A joint, virtual point, mean or point along a segment; every name must be in the clip.
    Expr(JointExpr),
}

/// `{ first = [...] }`: see [`BvhExpr::First`].
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FirstOf {
    /// Candidate names, in order of preference.
    pub first: Vec<String>,
}

/// A BVH skeleton family's mapping onto keypoint layouts.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BvhMapping {
    /// Skeleton family name.
    pub skeleton: String,
    /// Where such files come from.
    #[serde(default)]
    pub description: String,
    /// Joints whose presence identifies the skeleton.
    pub required: Vec<String>,
    /// Units, when known.
    pub metres_per_unit: Option<f64>,
    /// Virtual points.
    #[serde(default)]
    pub points: BTreeMap<String, VirtualPoint>,
    /// Per layout name: layout joint → expression over BVH joints and virtual points.
    pub layouts: BTreeMap<String, BTreeMap<String, BvhExpr>>,
}

/// The built-in mappings, tried in this order: the first whose required joints a clip has is
/// used, so a family whose names are a superset of another's (CMU's of the common humanoid
/// names) comes first.
const BUILTIN: [(&str, &str); 5] = [
    (
        "bandai-namco",
        include_str!("../skeleton/layouts/bvh/bandai-namco.toml"),
    ),
    ("cmu", include_str!("../skeleton/layouts/bvh/cmu.toml")),
    (
        "autoact53",
        include_str!("../skeleton/layouts/bvh/autoact53.toml"),
    ),
    (
        "biovision",
        include_str!("../skeleton/layouts/bvh/biovision.toml"),
    ),
    (
        "humanoid",
        include_str!("../skeleton/layouts/bvh/humanoid.toml"),
    ),
];

impl BvhMapping {
    /// Parses a mapping table; `name` names it in errors.
    ///
    /// # Errors
    /// [`BvhMapError::Parse`] with the line and column of the fault.
    pub fn from_toml(text: &str, name: &str) -> Result<BvhMapping, BvhMapError> {
        toml::from_str(text).map_err(|e| BvhMapError::Parse {
            name: name.to_string(),
            message: toml_error_text(text, &e),
        })
    }

    /// Reads a mapping file (the form of the built-in ones, for a BVH skeleton autoact does
    /// not know).
    ///
    /// # Errors
    /// [`BvhMapError::Io`], or [`BvhMapError::Parse`] naming the file, line and column.
    pub fn from_file(path: &Path) -> Result<BvhMapping, BvhMapError> {
        let bytes = std::fs::read(path).map_err(|source| BvhMapError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let name = path.display().to_string();
        let text = String::from_utf8(bytes).map_err(|e| {
            let at = e.utf8_error().valid_up_to();
            let bytes = e.as_bytes();
            let line = 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count();
            BvhMapError::Parse {
                name: name.clone(),
                message: format!("line {line}: invalid UTF-8 (byte {at})"),
            }
        })?;
        BvhMapping::from_toml(&text, &name)
    }

    /// This mapping if the clip has every joint it requires.
    ///
    /// # Errors
    /// [`BvhMapError::MissingJoints`] naming the joints not found.
    pub fn check_fits(self, bvh: &Bvh) -> Result<BvhMapping, BvhMapError> {
        let missing: Vec<&str> = self
            .required
            .iter()
            .filter(|r| joint_named(bvh, r).is_none())
            .map(String::as_str)
            .collect();
        if missing.is_empty() {
            return Ok(self);
        }
        Err(BvhMapError::MissingJoints {
            source_name: bvh.source.clone(),
            mapping: self.skeleton.clone(),
            missing: missing.join(", "),
            joints: joint_list(bvh),
        })
    }

    /// The built-in mappings.
    ///
    /// # Errors
    /// [`BvhMapError::Parse`] if a built-in table is broken (a test guards against that).
    pub fn builtins() -> Result<Vec<BvhMapping>, BvhMapError> {
        BUILTIN
            .iter()
            .map(|(n, t)| BvhMapping::from_toml(t, n))
            .collect()
    }

    /// The built-in mapping whose required joints the clip has.
    ///
    /// # Errors
    /// [`BvhMapError::NoMapping`].
    pub fn detect(bvh: &Bvh) -> Result<BvhMapping, BvhMapError> {
        let all = BvhMapping::builtins()?;
        let known = all
            .iter()
            .map(|m| format!("{} (needs {})", m.skeleton, m.required.join(", ")))
            .collect::<Vec<_>>()
            .join("; ");
        all.into_iter()
            .find(|m| m.required.iter().all(|r| joint_named(bvh, r).is_some()))
            .ok_or_else(|| BvhMapError::NoMapping {
                source_name: bvh.source.clone(),
                known,
                joints: joint_list(bvh),
            })
    }

    /// Per layout joint, the weighted (BVH joint, offset in its frame) terms that place it, or
    /// `None` where the mapping does not give it.
    ///
    /// # Errors
    /// The mapping has no table for the layout, or names a layout joint or BVH name that is not
    /// there.
    fn terms(&self, bvh: &Bvh, layout: &Layout) -> Result<Vec<Option<Terms>>, BvhMapError> {
        let table = self
            .layouts
            .get(&layout.name)
            .ok_or_else(|| BvhMapError::NoLayoutTable {
                mapping: self.skeleton.clone(),
                layout: layout.name.clone(),
                available: self.layouts.keys().cloned().collect::<Vec<_>>().join(", "),
            })?;
        if let Some(joint) = table.keys().find(|k| !layout.joints.contains(k)) {
            return Err(BvhMapError::UnknownLayoutJoint {
                mapping: self.skeleton.clone(),
                layout: layout.name.clone(),
                joint: joint.clone(),
                hint: if layout.name == DEFAULT_LAYOUT {
                    " (`autoact rig --landmarks` lists them)"
                } else {
                    " (`autoact layouts NAME` lists them)"
                },
            });
        }
        // Every name as (joint index, offset in the joint's frame), if the clip has it.
        let find = |name: &String| -> Option<(usize, Vector3<f64>)> {
            if let Some(j) = joint_named(bvh, name) {
                return Some((j, Vector3::zeros()));
            }
            let p = self.points.get(name)?;
            Some((joint_named(bvh, &p.joint)?, Vector3::from(p.offset)))
        };
        let resolve = |name: &String| {
            find(name).ok_or_else(|| BvhMapError::UnknownName {
                source_name: bvh.source.clone(),
                mapping: self.skeleton.clone(),
                name: name.clone(),
                joints: bvh.joint_names().join(", "),
            })
        };
        let mut terms: Vec<Option<Terms>> = Vec::with_capacity(layout.joints.len());
        for joint in &layout.joints {
            #[expect(clippy::cast_precision_loss, reason = "a mean of a handful of joints")]
            let t = match table.get(joint) {
                None => None,
                Some(BvhExpr::First(FirstOf { first })) => {
                    first.iter().find_map(find).map(|(j, o)| vec![(j, o, 1.0)])
                }
                Some(BvhExpr::Expr(JointExpr::Joint(n))) => {
                    let (j, o) = resolve(n)?;
                    Some(vec![(j, o, 1.0)])
                }
                Some(BvhExpr::Expr(JointExpr::Mean { mean })) => {
                    let w = 1.0 / mean.len().max(1) as f64;
                    Some(
                        mean.iter()
                            .map(|n| resolve(n).map(|(j, o)| (j, o, w)))
                            .collect::<Result<_, _>>()?,
                    )
                }
                Some(BvhExpr::Expr(JointExpr::Lerp { from, to, t })) => {
                    let (a, oa) = resolve(from)?;
                    let (b, ob) = resolve(to)?;
                    Some(vec![(a, oa, 1.0 - t), (b, ob, *t)])
                }
            };
            terms.push(t);
        }
        Ok(terms)
    }

    /// Keypoints of `layout` for every frame of `bvh`, in metres in the autoact frame, the
    /// file's axes found from the clip ([`found_axes`]). Layout joints the mapping does not give
    /// are missing in every frame.
    ///
    /// # Errors
    /// As [`BvhMapping::keypoints_in`].
    pub fn keypoints(&self, bvh: &Bvh, layout: &Layout) -> Result<PoseSequence, BvhMapError> {
        self.keypoints_in(bvh, layout, None, None)
            .map(|(seq, _)| seq)
    }

    /// [`BvhMapping::keypoints`] with the file's axes given (`Some`) or found from the clip
    /// (`None`, [`found_axes`]), and its unit given (`Some`) or else the mapping's or guessed
    /// ([`Bvh::guess_metres_per_unit`]); returns the axes used too.
    ///
    /// # Errors
    /// [`BvhMapError`] when the mapping has no table for the layout, names an unknown joint, or
    /// the units are unknown.
    pub fn keypoints_in(
        &self,
        bvh: &Bvh,
        layout: &Layout,
        axes: Option<SourceAxes>,
        metres_per_unit: Option<f64>,
    ) -> Result<(PoseSequence, SourceAxes), BvhMapError> {
        let terms = self.terms(bvh, layout)?;
        let Some(metres_per_unit) = metres_per_unit
            .or(self.metres_per_unit)
            .or_else(|| bvh.guess_metres_per_unit())
        else {
            return Err(BvhMapError::UnknownUnits {
                source_name: bvh.source.clone(),
                extent: bvh.rest_extent().max(),
            });
        };
        bvh.check_translations(metres_per_unit, super::bvh::MAX_TRANSLATION_M)?;
        // The layout's points in file axes (metres), from joints placed and turned as `world`,
        // the points' offsets turned by `turn` (see below).
        let points = |world: &[(Point3<f64>, UnitQuaternion<f64>)],
                      turn: &Rotation3<f64>,
                      frame: &mut PoseFrame| {
            for (k, t) in terms.iter().enumerate() {
                let Some(t) = t else { continue };
                let mut sum = Vector3::zeros();
                for &(j, offset, w) in t {
                    let (p, q) = world[j];
                    sum += (p.coords + q * (turn * offset)) * w;
                }
                frame.positions_m[k] = Point3::from(sum * metres_per_unit);
                frame.confidence[k] = 1.0;
            }
        };
        let fps = bvh.fps();
        let all_frames = |turn: &Rotation3<f64>| -> Vec<PoseFrame> {
            (0..bvh.frame_count())
                .map(|f| {
                    let mut frame = PoseFrame::missing(stamp_nanos_at(f, fps), layout.joints.len());
                    points(&bvh.world_transforms(f), turn, &mut frame);
                    frame
                })
                .collect()
        };
        let unturned = Rotation3::identity();
        let mut frames = all_frames(&unturned);
        if let Some(given) = axes {
            let motion_up = BodyAxis::of(layout).mean_up(&frames);
            warn_unless_upright(&bvh.source, motion_up, given, "--axes");
        }
        let axes = axes.unwrap_or_else(|| {
            // At rest every joint is unturned.
            let rest: Vec<_> = (bvh.rest_positions().into_iter())
                .map(|p| (p, UnitQuaternion::identity()))
                .collect();
            let mut rest_frame = PoseFrame::missing(0, layout.joints.len());
            points(&rest, &unturned, &mut rest_frame);
            found_axes(&bvh.source, layout, &rest_frame, &frames)
        });
        // A mapping's point offsets are written for Y-up files (as nearly every BVH is): in a
        // file of other axes the same body point is the offset turned into them.
        let has_offsets = terms
            .iter()
            .flatten()
            .flatten()
            .any(|(_, o, _)| *o != Vector3::zeros());
        if axes != SourceAxes::YUp && has_offsets {
            let file_from_y_up =
                axes.autoact_from_source().inverse() * SourceAxes::YUp.autoact_from_source();
            frames = all_frames(&file_from_y_up);
        }
        for p in frames.iter_mut().flat_map(|f| f.positions_m.iter_mut()) {
            *p = axes.point_to_autoact(*p);
        }
        let seq = PoseSequence {
            source: bvh.source.clone(),
            track_id: 0,
            joint_names: layout.joints.clone(),
            frames,
        };
        Ok((seq, axes))
    }
}

/// Weighted (BVH joint, offset in its frame) terms whose sum places one layout joint.
type Terms = Vec<(usize, Vector3<f64>, f64)>;

/// The cosine of the largest angle between a body's up (pelvis to neck) and a file axis at which
/// the body counts as standing along that axis: 45°.
const UPRIGHT_COS: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// The axes of a BVH file, found from its clip: [`SourceAxes::ZUp`] when its motion (the mean
/// of the body's up over the frames) stands along +Z within 45° and its rest pose does not stand
/// along +Y, else [`SourceAxes::YUp`], BVH's usual convention. The motion decides because some
/// rest poses lie down (Bandai-Namco's lies along X and its rotations raise it); a rest pose
/// standing along +Y vetoes Z-up because a clip of a Y-up file may lie along Z throughout
/// (push-ups). A body whose motion does not stand along the chosen axis is warned about, with
/// the way to state the axes. The body's up is from the layout's pelvis to its neck (or chest,
/// head centre, spine midpoint: the first it has), in file axes; `rest` and `frames` hold the
/// layout's points in file axes.
#[must_use]
pub fn found_axes(
    source: &str,
    layout: &Layout,
    rest: &PoseFrame,
    frames: &[PoseFrame],
) -> SourceAxes {
    let body = BodyAxis::of(layout);
    let rest_up = body.up(rest);
    let motion_up = body.mean_up(frames);
    let along = |v: Option<Vector3<f64>>, axis: usize| v.is_some_and(|v| v[axis] > UPRIGHT_COS);
    let axes = if along(motion_up, 2) && !along(rest_up, 1) {
        SourceAxes::ZUp
    } else {
        SourceAxes::YUp
    };
    warn_unless_upright(source, motion_up, axes, "read as");
    axes
}

/// Warns when the body's mean up `motion_up` (in file axes) is more than 45° from the file's up
/// under `axes` (found, or given with `--axes`): the body would come out lying.
fn warn_unless_upright(source: &str, motion_up: Option<Vector3<f64>>, axes: SourceAxes, how: &str) {
    let Some(m) = motion_up else {
        return;
    };
    let file_up = axes.autoact_from_source().inverse() * Vector3::z();
    let cos = m.dot(&file_up);
    if cos <= UPRIGHT_COS {
        tracing::warn!(
            "{source}: the body's mean up (pelvis to neck) is ({:.2}, {:.2}, {:.2}) in the file's axes, {:.0}° from the file's up ({}) under {how} {}: the body will not stand; if the file's up is another axis, give --axes, or --ground on to stand the body on its feet",
            m.x,
            m.y,
            m.z,
            cos.clamp(-1.0, 1.0).acos().to_degrees(),
            axis_name(&file_up),
            axes.name(),
        );
    }
}

/// A unit axis vector as text: `+Y`, `-Z`, ….
fn axis_name(v: &Vector3<f64>) -> String {
    let i = v.iamax();
    format!(
        "{}{}",
        if v[i] < 0.0 { '-' } else { '+' },
        ['X', 'Y', 'Z'][i]
    )
}

/// A layout's pelvis and the points above it (its neck, chest, head centre or spine midpoint,
/// the first a frame has), as joint terms resolved once for a whole clip.
struct BodyAxis {
    pelvis: Option<Vec<(usize, f64)>>,
    tops: Vec<Vec<(usize, f64)>>,
}

impl BodyAxis {
    fn of(layout: &Layout) -> BodyAxis {
        let terms = |l: &str| layout.landmarks.get(l)?.terms(&layout.joints);
        BodyAxis {
            pelvis: terms("pelvis"),
            tops: ["neck", "chest", "head_center", "spine_mid"]
                .into_iter()
                .filter_map(terms)
                .collect(),
        }
    }

    /// The unit direction from the pelvis to the first top point `frame` observes, if any.
    fn up(&self, frame: &PoseFrame) -> Option<Vector3<f64>> {
        let observed = |t: &[(usize, f64)]| terms_point(t, frame, OBSERVED);
        let pelvis = observed(self.pelvis.as_deref()?)?;
        let top = self.tops.iter().find_map(|t| observed(t))?;
        (top - pelvis).try_normalize(1e-9)
    }

    /// The mean over `frames` of [`BodyAxis::up`], in the frames' axes, if any frame has one.
    fn mean_up(&self, frames: &[PoseFrame]) -> Option<Vector3<f64>> {
        frames
            .iter()
            .filter_map(|f| self.up(f))
            .sum::<Vector3<f64>>()
            .try_normalize(1e-9)
    }
}

/// The built-in mappings as a table for `autoact layouts`: name, the joints that identify it,
/// its layouts and description.
#[must_use]
pub fn mappings_table() -> String {
    let rows: Vec<Vec<String>> = BvhMapping::builtins()
        .unwrap_or_default()
        .iter()
        .map(|m| {
            vec![
                m.skeleton.clone(),
                m.required.join(", "),
                m.layouts.keys().cloned().collect::<Vec<_>>().join(", "),
                m.description.clone(),
            ]
        })
        .collect();
    format!(
        "Built-in BVH skeleton mappings (`autoact import` picks the one whose joints a clip has and\n\
         maps it onto {DEFAULT_LAYOUT} unless --layout says otherwise; --bvh-map FILE.toml for\n\
         other skeletons, see docs/convert.md):\n\n{}",
        crate::table::table(
            &["mapping", "identified by", "layouts", "description"],
            &rows
        )
    )
}

/// The built-in mappings as JSON (see [`mappings_table`]).
#[must_use]
pub fn mappings_json() -> serde_json::Value {
    let v: Vec<_> = BvhMapping::builtins()
        .unwrap_or_default()
        .iter()
        .map(|m| {
            serde_json::json!({"name": m.skeleton, "description": m.description,
                "required": m.required, "layouts": m.layouts.keys().collect::<Vec<_>>()})
        })
        .collect();
    serde_json::Value::Array(v)
}

/// The joint of `bvh` called `name`: the one with exactly that name, else the only one whose
/// name without its namespace prefix (up to the last `:`, as Mixamo's `mixamorig:`) is `name`.
fn joint_named(bvh: &Bvh, name: &str) -> Option<usize> {
    if let Some(j) = bvh.joint_index(name) {
        return Some(j);
    }
    let mut found = bvh
        .joints
        .iter()
        .enumerate()
        .filter(|(_, joint)| {
            joint
                .name
                .rsplit_once(':')
                .is_some_and(|(_, local)| local == name)
        })
        .map(|(j, _)| j);
    let first = found.next()?;
    found.next().is_none().then_some(first)
}

/// The clip's joints, End Sites left out, comma-separated (for error messages).
fn joint_list(bvh: &Bvh) -> String {
    bvh.joints
        .iter()
        .filter(|j| !j.is_end_site)
        .map(|j| j.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// A TOML error as `line L, column C: message`, quoting at most 80 characters of the line (a
/// huge line must not flood the terminal).
fn toml_error_text(text: &str, e: &toml::de::Error) -> String {
    let Some(span) = e.span() else {
        return e.message().to_string();
    };
    let start = span.start.min(text.len());
    let before = text.get(..start).unwrap_or("");
    let line = 1 + before.matches('\n').count();
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = 1 + before[line_start..].chars().count();
    let line_text: String = text[line_start..]
        .lines()
        .next()
        .unwrap_or("")
        .chars()
        .take(80)
        .collect();
    format!(
        "line {line}, column {column}: {} (at `{}`)",
        e.message().trim_end(),
        line_text.trim()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_mappings_parse_and_name_real_layout_joints() {
        for m in BvhMapping::builtins().unwrap() {
            for (layout_name, table) in &m.layouts {
                let layout = Layout::builtin(layout_name).unwrap();
                for joint in table.keys() {
                    assert!(
                        layout.joints.contains(joint),
                        "{}: {layout_name} has no joint {joint}",
                        m.skeleton
                    );
                }
            }
        }
    }

    #[test]
    fn virtual_points_ride_on_their_joint() {
        let text = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n  JOINT Head\n  {\n    OFFSET 0 100 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      OFFSET 0 10 0\n    }\n  }\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n0 0 0 0 0 0 90 0 0\n";
        let bvh = super::super::bvh::parse(text, "t.bvh").unwrap();
        let mapping = BvhMapping::from_toml(
            "skeleton = \"t\"\nrequired = [\"Hips\"]\nmetres_per_unit = 0.01\n[points]\ntop = { joint = \"Head\", offset = [0.0, 20.0, 0.0] }\n[layouts.h36m-17]\nhead = \"top\"\nroot = \"Hips\"\n",
            "t",
        )
        .unwrap();
        let layout = Layout::builtin("h36m-17").unwrap();
        let seq = mapping.keypoints(&bvh, &layout).unwrap();
        let f = &seq.frames[0];
        let head = layout.joints.iter().position(|j| j == "head").unwrap();
        // Head at (0, 100, 0) cm, turned 90° about Z: its +Y offset of 20 points along file −X,
        // which is autoact +X; up is autoact +Z.
        let expected = SourceAxes::YUp.point_to_autoact(Point3::new(-0.2, 1.0, 0.0));
        assert!(
            (f.positions_m[head] - expected).norm() < 1e-9,
            "{:?}",
            f.positions_m[head]
        );
        assert_eq!(f.confidence[1], 0.0, "right_hip is not mapped: missing");
        assert!(f.positions_m[1].x.is_nan());
    }

    /// A two-joint clip (`Hips` → `Head`, cm) with one frame.
    fn two_joint_clip() -> Bvh {
        let text = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n  JOINT Head\n  {\n    OFFSET 0 100 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      OFFSET 0 10 0\n    }\n  }\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n0 90 0 0 0 0 0 0 0\n";
        super::super::bvh::parse(text, "t.bvh").unwrap()
    }

    const GOOD_MAP: &str = "skeleton = \"two\"\nrequired = [\"Hips\", \"Head\"]\nmetres_per_unit = 0.01\n[points]\ntop = { joint = \"Head\", offset = [0.0, 20.0, 0.0] }\n[layouts.autoact-landmarks]\npelvis = \"Hips\"\nneck = \"Head\"\nhead_top = \"top\"\n";

    #[test]
    fn a_mapping_file_reads_and_maps_the_clip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("two.toml");
        std::fs::write(&path, GOOD_MAP).unwrap();
        let bvh = two_joint_clip();
        let mapping = BvhMapping::from_file(&path)
            .unwrap()
            .check_fits(&bvh)
            .unwrap();
        let layout = Layout::load(DEFAULT_LAYOUT).unwrap();
        let seq = mapping
            .keypoints(&bvh, &layout)
            .unwrap()
            .without_unobserved_joints();
        assert_eq!(seq.joint_names, ["pelvis", "neck", "head_top"]);
        // Hips at 0.9 m up (file Y), the head 1 m above it, its top 0.2 m further.
        let z: Vec<f64> = seq.frames[0].positions_m.iter().map(|p| p.z).collect();
        for (got, want) in z.iter().zip([0.9, 1.9, 2.1]) {
            assert!((got - want).abs() < 1e-9, "{z:?}");
        }
    }

    #[test]
    fn a_broken_mapping_file_is_refused_with_its_line() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.toml");
        let bad = GOOD_MAP.replace("metres_per_unit = 0.01", "metres_per_unit = \"cm\"");
        std::fs::write(&path, bad).unwrap();
        let e = BvhMapping::from_file(&path).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!(
                "invalid BVH mapping {}: line 3, column 19:",
                path.display()
            )),
            "{e}"
        );
        assert!(e.contains("metres_per_unit = \"cm\""), "{e}");
        // An unknown key names itself and its line too.
        std::fs::write(&path, format!("{GOOD_MAP}colour = 1\n")).unwrap();
        let e = BvhMapping::from_file(&path).unwrap_err().to_string();
        assert!(e.contains("line 10") && e.contains("colour"), "{e}");
        // A huge line is not quoted whole.
        std::fs::write(&path, format!("skeleton = [{}", "1,".repeat(100_000))).unwrap();
        let e = BvhMapping::from_file(&path).unwrap_err().to_string();
        assert!(e.len() < 1_000, "{} bytes", e.len());
        std::fs::write(&path, b"skeleton = \"\xff\"\n").unwrap();
        let e = BvhMapping::from_file(&path).unwrap_err().to_string();
        assert!(e.ends_with("line 1: invalid UTF-8 (byte 12)"), "{e}");
        let e = BvhMapping::from_file(&dir.path().join("none.toml")).unwrap_err();
        assert!(
            e.to_string().starts_with("cannot read BVH mapping file "),
            "{e}"
        );
    }

    #[test]
    fn unknown_names_in_a_mapping_are_named() {
        let bvh = two_joint_clip();
        let layout = Layout::load(DEFAULT_LAYOUT).unwrap();
        let map = |text: &str| BvhMapping::from_toml(text, "m").unwrap();
        let e = map(&GOOD_MAP.replace("neck = \"Head\"", "neck = \"Neck1\""))
            .keypoints(&bvh, &layout)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "t.bvh: BVH mapping `two` uses `Neck1`, which is neither a joint of the clip nor a virtual point (the clip's joints: Hips, Head, Head_End)"
        );
        let e = map(&GOOD_MAP.replace(
            "required = [\"Hips\", \"Head\"]",
            "required = [\"Hips\", \"Chest\", \"Neck\"]",
        ))
        .check_fits(&bvh)
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            "t.bvh: BVH mapping `two` requires joints the clip does not have: Chest, Neck (the clip's joints: Hips, Head)"
        );
        let e = map(&GOOD_MAP.replace("neck = ", "neck_top = "))
            .keypoints(&bvh, &layout)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "BVH mapping `two`: [layouts.autoact-landmarks] sets `neck_top`, which is not a joint of layout `autoact-landmarks` (`autoact rig --landmarks` lists them)"
        );
        let e = map(GOOD_MAP)
            .keypoints(&bvh, &Layout::load("h36m-17").unwrap())
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "BVH mapping `two` has no table for layout `h36m-17` (it has: autoact-landmarks)"
        );
    }

    #[test]
    fn a_skeleton_without_a_mapping_is_refused_with_how_to_write_one() {
        let e = BvhMapping::detect(&two_joint_clip())
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("t.bvh: no built-in BVH mapping fits this skeleton (built in: bandai-namco (needs Hips, Chest, "), "{e}");
        assert!(e.contains("Its joints are: Hips, Head.\n"), "{e}");
        assert!(
            e.contains("docs/convert.md")
                && e.contains("bvh/cmu.toml")
                && e.contains("--bvh-map FILE.toml"),
            "{e}"
        );
    }

    /// A humanoid-named skeleton (cm, Y up, T-pose): `(name, parent, offset)`, parents first,
    /// and whether the joint (with everything below it) may be left out of a file.
    const HUMANOID: [(&str, &str, [f64; 3], bool); 30] = [
        ("Hips", "", [0.0, 95.0, 0.0], false),
        ("Spine", "Hips", [0.0, 10.0, 0.0], false),
        ("Spine1", "Spine", [0.0, 15.0, 0.0], true),
        ("Spine2", "Spine1", [0.0, 15.0, 0.0], true),
        ("Neck", "Spine2", [0.0, 15.0, 0.0], true),
        ("Head", "Neck", [0.0, 10.0, 2.0], false),
        ("HeadTop_End", "Head", [0.0, 18.0, 3.0], true),
        ("LeftEye", "Head", [3.0, 7.0, 8.0], true),
        ("RightEye", "Head", [-3.0, 7.0, 8.0], true),
        ("LeftShoulder", "Spine2", [6.0, 12.0, 0.0], true),
        ("LeftArm", "LeftShoulder", [12.0, 0.0, 0.0], false),
        ("LeftForeArm", "LeftArm", [27.0, 0.0, 0.0], false),
        ("LeftHand", "LeftForeArm", [26.0, 0.0, 0.0], false),
        ("LeftHandIndex1", "LeftHand", [10.0, 0.0, 3.0], true),
        ("LeftHandIndex2", "LeftHandIndex1", [4.0, 0.0, 0.0], true),
        ("LeftHandPinky1", "LeftHand", [9.0, 0.0, -3.0], true),
        ("RightShoulder", "Spine2", [-6.0, 12.0, 0.0], true),
        ("RightArm", "RightShoulder", [-12.0, 0.0, 0.0], false),
        ("RightForeArm", "RightArm", [-27.0, 0.0, 0.0], false),
        ("RightHand", "RightForeArm", [-26.0, 0.0, 0.0], false),
        ("RightHandIndex1", "RightHand", [-10.0, 0.0, 3.0], true),
        ("RightHandPinky1", "RightHand", [-9.0, 0.0, -3.0], true),
        ("LeftUpLeg", "Hips", [9.0, -5.0, 0.0], false),
        ("LeftLeg", "LeftUpLeg", [0.0, -42.0, 0.0], false),
        ("LeftFoot", "LeftLeg", [0.0, -42.0, 0.0], false),
        ("LeftToeBase", "LeftFoot", [0.0, -6.0, 12.0], true),
        ("RightUpLeg", "Hips", [-9.0, -5.0, 0.0], false),
        ("RightLeg", "RightUpLeg", [0.0, -42.0, 0.0], false),
        ("RightFoot", "RightLeg", [0.0, -42.0, 0.0], false),
        ("RightToeBase", "RightFoot", [0.0, -6.0, 12.0], true),
    ];

    /// A one-frame BVH of the [`HUMANOID`] joints that `keep` keeps (the required ones are
    /// always kept; a joint left out hands its children to its own parent, where they stay at
    /// rest), each named `prefix` + its name; a joint without children gets an End Site. The
    /// frame turns every joint a little.
    fn humanoid_clip(prefix: &str, keep: impl Fn(usize) -> bool) -> Bvh {
        /// Writes joint `i` at `depth` and, below it, the joints whose nearest kept ancestor
        /// it is; `placed[j]` is that ancestor and `j`'s offset from it.
        fn write(
            text: &mut String,
            i: usize,
            depth: usize,
            prefix: &str,
            placed: &[Option<(Option<usize>, Vector3<f64>)>],
        ) {
            use std::fmt::Write;
            let pad = "  ".repeat(depth);
            let (kind, channels) = if depth == 0 {
                (
                    "ROOT",
                    "6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
                )
            } else {
                ("JOINT", "3 Zrotation Xrotation Yrotation")
            };
            let o = placed[i].map_or_else(Vector3::zeros, |(_, o)| o);
            let _ = writeln!(
                text,
                "{pad}{kind} {prefix}{}\n{pad}{{\n{pad}  OFFSET {} {} {}\n{pad}  CHANNELS {channels}",
                HUMANOID[i].0, o.x, o.y, o.z
            );
            let children: Vec<usize> = (0..placed.len())
                .filter(|&c| placed[c].is_some_and(|(p, _)| p == Some(i)))
                .collect();
            if children.is_empty() {
                let _ = writeln!(
                    text,
                    "{pad}  End Site\n{pad}  {{\n{pad}    OFFSET 0 5 0\n{pad}  }}"
                );
            }
            for c in children {
                write(text, c, depth + 1, prefix, placed);
            }
            let _ = writeln!(text, "{pad}}}");
        }
        let parent = |i: usize| HUMANOID.iter().position(|h| h.0 == HUMANOID[i].1);
        let kept = |i: usize| keep(i) || !HUMANOID[i].3;
        // A kept joint hangs from its nearest kept ancestor, the offsets of the joints left out
        // between them added to its own (so every kept joint stays where it was at rest).
        let placed: Vec<Option<(Option<usize>, Vector3<f64>)>> = (0..HUMANOID.len())
            .map(|i| {
                let mut offset = Vector3::from(HUMANOID[i].2);
                let mut j = parent(i);
                while let Some(q) = j.filter(|&q| !kept(q)) {
                    offset += Vector3::from(HUMANOID[q].2);
                    j = parent(q);
                }
                kept(i).then_some((j, offset))
            })
            .collect();
        let mut text = String::from("HIERARCHY\n");
        write(&mut text, 0, 0, prefix, &placed);
        let joints = placed.iter().flatten().count();
        let values: Vec<String> = (0..3 + 3 * joints)
            .map(|k| format!("{}", (k % 7) as f64 * 2.5))
            .collect();
        text += &format!(
            "MOTION\nFrames: 1\nFrame Time: 0.0333333\n{}\n",
            values.join(" ")
        );
        super::super::bvh::parse(&text, "h.bvh").unwrap()
    }

    #[test]
    fn a_namespace_prefix_is_ignored_unless_two_joints_share_the_name() {
        let clip = humanoid_clip("mixamorig:", |_| true);
        assert_eq!(
            joint_named(&clip, "LeftArm"),
            clip.joint_index("mixamorig:LeftArm")
        );
        assert_eq!(joint_named(&clip, "Left"), None);
        assert_eq!(BvhMapping::detect(&clip).unwrap().skeleton, "humanoid");
        // Two namespaces holding the same name: neither is `Head`.
        let text = "HIERARCHY\nROOT a:Head\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Xposition Yposition Zposition\n  JOINT b:Head\n  {\n    OFFSET 0 10 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      OFFSET 0 1 0\n    }\n  }\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n0 0 0 0 0 0\n";
        let two = super::super::bvh::parse(text, "two.bvh").unwrap();
        assert_eq!(joint_named(&two, "Head"), None);
        assert_eq!(joint_named(&two, "b:Head"), Some(1));
    }

    #[test]
    fn the_first_alternative_the_clip_has_is_used_and_none_leaves_the_joint_missing() {
        let clip = two_joint_clip();
        let layout = Layout::load(DEFAULT_LAYOUT).unwrap();
        let map = GOOD_MAP.to_string()
            + "head_center = { first = [\"Eye\", \"top\", \"Head\"] }\nnose = { first = [\"Nose\", \"Nose_End\"] }\nl_eye = { first = [\"Head_End\"] }\n";
        let seq = BvhMapping::from_toml(&map, "m")
            .unwrap()
            .keypoints(&clip, &layout)
            .unwrap();
        let at = |n: &str| seq.frames[0].positions_m[seq.joint_index(n).unwrap()];
        // `Eye` is not in the clip; `top` (a virtual point) is.
        assert_eq!(at("head_center"), at("head_top"));
        assert!(at("nose").x.is_nan(), "no alternative: missing");
        assert!(
            at("l_eye").z > at("neck").z,
            "an End Site by its `_End` name"
        );
        // A `first` with anything but its list is refused.
        let bad = GOOD_MAP.to_string() + "nose = { first = [\"Head\"], t = 1.0 }\n";
        assert!(BvhMapping::from_toml(&bad, "m").is_err());
    }

    #[test]
    fn cmu_clips_keep_their_own_mapping_ahead_of_the_humanoid_names() {
        // The CMU skeleton's names include every humanoid required name.
        let cmu = BvhMapping::builtins()
            .unwrap()
            .into_iter()
            .find(|m| m.skeleton == "cmu")
            .unwrap();
        let humanoid = BvhMapping::builtins()
            .unwrap()
            .into_iter()
            .find(|m| m.skeleton == "humanoid")
            .unwrap();
        let mut text = String::from(
            "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Xposition Yposition Zposition\n",
        );
        let mut names: Vec<&String> = cmu.required.iter().chain(&humanoid.required).collect();
        names.sort();
        names.dedup();
        names.retain(|n| *n != "Hips");
        for n in &names {
            text += &format!(
                "  JOINT {n}\n  {{\n    OFFSET 0 10 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {{\n      OFFSET 0 1 0\n    }}\n  }}\n"
            );
        }
        text += &format!(
            "}}\nMOTION\nFrames: 1\nFrame Time: 0.04\n{}\n",
            vec!["0"; 3 + 3 * names.len()].join(" ")
        );
        let clip = super::super::bvh::parse(&text, "cmu.bvh").unwrap();
        assert_eq!(BvhMapping::detect(&clip).unwrap().skeleton, "cmu");
    }

    proptest::proptest! {
        /// Any humanoid-named file, whatever optional joints it lacks and whatever namespace
        /// its names carry, is read by the built-in `humanoid` mapping: every landmark is there
        /// exactly when one of its alternatives is, at that joint.
        #[test]
        fn any_humanoid_file_maps_each_landmark_it_has_the_joints_for(
            keep in proptest::collection::vec(proptest::bool::ANY, HUMANOID.len()),
            prefix in proptest::sample::select(vec!["", "mixamorig:", "mixamorig1:", "Char:"]),
        ) {
            let clip = humanoid_clip(prefix, |i| keep[i]);
            let mapping = BvhMapping::detect(&clip).unwrap();
            proptest::prop_assert_eq!(&mapping.skeleton, "humanoid");
            let layout = Layout::load(DEFAULT_LAYOUT).unwrap();
            let seq = mapping.keypoints(&clip, &layout).unwrap();
            let world = clip.world_transforms(0);
            let metres = clip.guess_metres_per_unit().unwrap();
            for (landmark, expr) in &mapping.layouts[DEFAULT_LAYOUT] {
                let got = seq.frames[0].positions_m[seq.joint_index(landmark).unwrap()];
                let BvhExpr::First(FirstOf { first }) = expr else {
                    proptest::prop_assert!(got.iter().all(|c| c.is_finite()), "{}", landmark);
                    continue;
                };
                match first.iter().find_map(|n| joint_named(&clip, n)) {
                    Some(j) => {
                        let want = SourceAxes::YUp
                            .point_to_autoact(Point3::from(world[j].0.coords * metres));
                        proptest::prop_assert!((got - want).norm() < 1e-9, "{}", landmark);
                    }
                    None => proptest::prop_assert!(got.x.is_nan(), "{}", landmark),
                }
            }
        }
    }

    /// The error of mapping BVH `text` (named `name`, with a `Hips` joint) onto the rig's
    /// landmarks through a table that maps only the pelvis; `units` is the table's
    /// `metres_per_unit` line, or nothing.
    fn pelvis_only_error(text: &str, name: &str, units: &str) -> String {
        let bvh = super::super::bvh::parse(text, name).unwrap();
        let table = format!(
            "skeleton = \"one\"\nrequired = [\"Hips\"]\n{units}[layouts.autoact-landmarks]\npelvis = \"Hips\"\n"
        );
        BvhMapping::from_toml(&table, "one")
            .unwrap()
            .keypoints(&bvh, &Layout::load(DEFAULT_LAYOUT).unwrap())
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn units_that_cannot_be_guessed_are_refused_with_how_to_state_them() {
        // 11 units tall: the size of no person in cm, m or inches.
        let text = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Xposition Yposition Zposition\n  End Site\n  {\n    OFFSET 0 11 0\n  }\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n0 0 0\n";
        let e = pelvis_only_error(text, "tiny.bvh", "");
        assert!(
            e.starts_with(
                "tiny.bvh: cannot tell the units of this BVH (rest skeleton 11.0 units tall"
            ) && e.contains("--metres-per-unit 0.01")
                && e.contains("`metres_per_unit` in a mapping file given with --bvh-map"),
            "{e}"
        );
    }

    #[test]
    fn absurd_translations_are_refused_once_the_units_are_known() {
        // 2e6 cm is within the parser's bound but 20 km from the origin.
        let text = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Xposition Yposition Zposition\n  End Site\n  {\n    OFFSET 0 10 0\n  }\n}\nMOTION\nFrames: 2\nFrame Time: 0.04\n0 90 0\n\n0 90 -2e6\n";
        let e = pelvis_only_error(text, "far.bvh", "metres_per_unit = 0.01\n");
        assert_eq!(
            e,
            "far.bvh:16: frame 1, column 2 (Hips Zposition): value -2e6 is not physical (2.000e4 m at 0.01 m per unit; translations are at most 1e4 m)"
        );
    }

    #[test]
    fn autoacts_own_bvh_maps_onto_every_rig_landmark_where_the_rig_puts_it() {
        use crate::export::Clip;
        use crate::skeleton::fk::{self, BonePose};
        use crate::skeleton::rig::Rig;
        use nalgebra::UnitQuaternion;
        let rig = Rig::standard();
        let bone = |n: &str| rig.bone_index(n).unwrap();
        let poses: Vec<BonePose> = (0..3)
            .map(|k| {
                let t = f64::from(k);
                let mut pose = BonePose::rest(&rig);
                pose.root_translation_m = Vector3::new(0.3 * t, -1.0, 0.0);
                for (b, angles) in [
                    ("spine2", (0.1, -0.2, 0.3)),
                    ("head", (0.3, 0.1, -0.2)),
                    ("l_foot", (0.2, 0.0, 0.1)),
                    ("r_hand", (0.4, 0.2, -0.3)),
                    ("l_upper_arm", (1.0, 0.5, -0.7)),
                ] {
                    pose.local_rotations[bone(b)] =
                        UnitQuaternion::from_euler_angles(angles.0 * t, angles.1 * t, angles.2);
                }
                pose
            })
            .collect();
        let clip = Clip::from_poses(&rig, 30.0, poses);
        let bvh =
            super::super::bvh::parse(&crate::export::bvh::write(&rig, &clip), "own.bvh").unwrap();
        let mapping = BvhMapping::detect(&bvh).unwrap();
        assert_eq!(mapping.skeleton, "autoact53");
        let layout = Layout::load(DEFAULT_LAYOUT).unwrap();
        let seq = mapping.keypoints(&bvh, &layout).unwrap();
        for (k, pose) in clip.poses.iter().enumerate() {
            let world = fk::forward(&rig, &clip.character, pose, 1.0);
            for (l, landmark) in rig.landmarks.iter().enumerate() {
                let want = fk::landmark_position(&rig, &clip.character, &world, l);
                let got = seq.frames[k].positions_m[l];
                // Points written with 6 decimals of a centimetre; face and foot points from the
                // default adult's landmarks, rounded to a millimetre.
                assert!(
                    (got - want).norm() < 1.5e-3,
                    "frame {k} {}: {got} vs {want}",
                    landmark.name
                );
            }
        }
    }
}
