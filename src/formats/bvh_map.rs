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
//! Layout joints a mapping does not give are missing (NaN, confidence 0) in every frame.

use std::collections::BTreeMap;

use nalgebra::{Point3, Vector3};
use serde::Deserialize;

use super::bvh::Bvh;
use crate::skeleton::frames::SourceAxes;
use crate::skeleton::layout::{JointExpr, Layout};
use crate::skeleton::pose::{PoseFrame, PoseSequence, stamp_nanos_at};

/// Errors building keypoints from a BVH clip.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BvhMapError {
    /// The mapping table did not parse.
    #[error("invalid BVH mapping {name}: {message}")]
    Parse {
        /// Mapping name.
        name: String,
        /// What the TOML parser said.
        message: String,
    },
    /// No built-in mapping fits the clip's joints.
    #[error(
        "{source_name}: no built-in BVH mapping fits this skeleton (known: {known}); its joints are: {joints}"
    )]
    NoMapping {
        /// The BVH file.
        source_name: String,
        /// Built-in mapping names.
        known: String,
        /// The clip's first joints.
        joints: String,
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
        "{source_name}: BVH mapping `{mapping}` uses `{name}`, which is neither a joint of the clip nor a virtual point"
    )]
    UnknownName {
        /// The BVH file.
        source_name: String,
        /// Mapping name.
        mapping: String,
        /// The name.
        name: String,
    },
    /// The clip's units cannot be guessed and the mapping does not state them.
    #[error(
        "{source_name}: cannot tell the units of this BVH (rest skeleton {extent:.1} units tall); give metres per unit"
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
    pub layouts: BTreeMap<String, BTreeMap<String, JointExpr>>,
}

const BUILTIN: [(&str, &str); 3] = [
    (
        "bandai-namco",
        include_str!("../skeleton/layouts/bvh/bandai-namco.toml"),
    ),
    ("cmu", include_str!("../skeleton/layouts/bvh/cmu.toml")),
    (
        "autoact53",
        include_str!("../skeleton/layouts/bvh/autoact53.toml"),
    ),
];

impl BvhMapping {
    /// Parses a mapping table.
    ///
    /// # Errors
    /// [`BvhMapError::Parse`].
    pub fn from_toml(text: &str, name: &str) -> Result<BvhMapping, BvhMapError> {
        toml::from_str(text).map_err(|e| BvhMapError::Parse {
            name: name.to_string(),
            message: e.to_string(),
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
        let names = bvh.joint_names();
        let known = all
            .iter()
            .map(|m| m.skeleton.clone())
            .collect::<Vec<_>>()
            .join(", ");
        all.into_iter()
            .find(|m| m.required.iter().all(|r| names.contains(r)))
            .ok_or_else(|| BvhMapError::NoMapping {
                source_name: bvh.source.clone(),
                known,
                joints: names
                    .iter()
                    .take(12)
                    .cloned()
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// Keypoints of `layout` for every frame of `bvh`, in metres in the autoact frame (BVH is
    /// Y-up). Layout joints the mapping does not give are missing in every frame.
    ///
    /// # Errors
    /// [`BvhMapError`] when the mapping has no table for the layout, names an unknown joint, or
    /// the units are unknown.
    pub fn keypoints(&self, bvh: &Bvh, layout: &Layout) -> Result<PoseSequence, BvhMapError> {
        // Per layout joint: (BVH joint, offset in its frame, weight) terms, or None if unmapped.
        type Terms = Vec<(usize, Vector3<f64>, f64)>;
        let table = self
            .layouts
            .get(&layout.name)
            .ok_or_else(|| BvhMapError::NoLayoutTable {
                mapping: self.skeleton.clone(),
                layout: layout.name.clone(),
                available: self.layouts.keys().cloned().collect::<Vec<_>>().join(", "),
            })?;
        let Some(metres_per_unit) = self.metres_per_unit.or_else(|| bvh.guess_metres_per_unit())
        else {
            return Err(BvhMapError::UnknownUnits {
                source_name: bvh.source.clone(),
                extent: bvh.rest_extent().max(),
            });
        };
        // Resolve every name to (joint index, offset in the joint's frame).
        let resolve = |name: &String| -> Result<(usize, Vector3<f64>), BvhMapError> {
            if let Some(j) = bvh.joint_index(name) {
                return Ok((j, Vector3::zeros()));
            }
            self.points
                .get(name)
                .and_then(|p| Some((bvh.joint_index(&p.joint)?, Vector3::from(p.offset))))
                .ok_or_else(|| BvhMapError::UnknownName {
                    source_name: bvh.source.clone(),
                    mapping: self.skeleton.clone(),
                    name: name.clone(),
                })
        };
        let mut terms: Vec<Option<Terms>> = Vec::with_capacity(layout.joints.len());
        for joint in &layout.joints {
            let Some(expr) = table.get(joint) else {
                terms.push(None);
                continue;
            };
            #[expect(clippy::cast_precision_loss, reason = "a mean of a handful of joints")]
            let t = match expr {
                JointExpr::Joint(n) => {
                    let (j, o) = resolve(n)?;
                    vec![(j, o, 1.0)]
                }
                JointExpr::Mean { mean } => {
                    let w = 1.0 / mean.len().max(1) as f64;
                    mean.iter()
                        .map(|n| resolve(n).map(|(j, o)| (j, o, w)))
                        .collect::<Result<_, _>>()?
                }
                JointExpr::Lerp { from, to, t } => {
                    let (a, oa) = resolve(from)?;
                    let (b, ob) = resolve(to)?;
                    vec![(a, oa, 1.0 - t), (b, ob, *t)]
                }
            };
            terms.push(Some(t));
        }
        let fps = bvh.fps();
        let frames = (0..bvh.frame_count())
            .map(|f| {
                let world = bvh.world_transforms(f);
                let mut frame = PoseFrame::missing(stamp_nanos_at(f, fps), layout.joints.len());
                for (k, t) in terms.iter().enumerate() {
                    let Some(t) = t else { continue };
                    let mut sum = Vector3::zeros();
                    for &(j, offset, w) in t {
                        let (p, q) = world[j];
                        sum += (p.coords + q * offset) * w;
                    }
                    frame.positions_m[k] =
                        SourceAxes::YUp.point_to_autoact(Point3::from(sum * metres_per_unit));
                    frame.confidence[k] = 1.0;
                }
                frame
            })
            .collect();
        Ok(PoseSequence {
            source: bvh.source.clone(),
            track_id: 0,
            joint_names: layout.joints.clone(),
            frames,
        })
    }
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
}
