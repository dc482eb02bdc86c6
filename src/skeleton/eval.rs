//! How faithfully a conversion reproduces its input: convert a keypoint sequence, pose the fitted
//! body with the result (forward kinematics with the same bone lengths), and compare.
//!
//! - **Bone-direction error** (degrees): per driven bone, the angle between the input's direction
//!   (its recipe landmarks) and the solved bone's axis, grouped by degree-of-freedom class. 3-D
//!   and 2-D bones reproduce it exactly by construction; hinges lose what is out of their plane.
//! - **Position error** (millimetres): per landmark the layout binds, the distance between the
//!   input point and the reproduced one, unaligned (global, root included); grouped by the class
//!   of the bone the landmark rides on, and overall (the mean per-joint position error).
//! - **Bone-length stability**: for sources with no ground-truth rotations (Kinect, ZED), the
//!   spread of each measured segment's length over time, which bounds how well any rigid body
//!   can follow them.

use std::collections::BTreeMap;

use crate::skeleton::convert::{Animation, ConvertError, ConvertOptions, convert_sequence};
use crate::skeleton::fk;
use crate::skeleton::layout::Layout;
use crate::skeleton::pose::PoseSequence;
use crate::skeleton::rig::Rig;

/// Mean, max and count of a set of non-negative samples.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Stats {
    /// Number of samples.
    pub count: usize,
    /// Sum of samples.
    pub sum: f64,
    /// Largest sample.
    pub max: f64,
}

impl Stats {
    /// Adds a sample.
    pub fn push(&mut self, v: f64) {
        self.count += 1;
        self.sum += v;
        self.max = self.max.max(v);
    }

    /// Mean (0 when empty).
    #[must_use]
    pub fn mean(&self) -> f64 {
        #[expect(
            clippy::cast_precision_loss,
            reason = "sample counts are far below 2^52"
        )]
        let n = self.count.max(1) as f64;
        self.sum / n
    }
}

/// Errors per degree-of-freedom class.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ClassErrors {
    /// Bone-direction error, degrees.
    pub direction_deg: Stats,
    /// Position error of the landmarks riding on bones of this class, millimetres.
    pub position_mm: Stats,
}

/// The result of a round trip.
#[derive(Debug, Clone, PartialEq)]
pub struct RoundTrip {
    /// The converted animation (with its conversion report).
    pub animation: Animation,
    /// Per DoF class label (`root`, `3-D`, `2-D`, `1-D`, `static`).
    pub per_class: BTreeMap<&'static str, ClassErrors>,
    /// Per landmark name: position error, millimetres.
    pub per_landmark_mm: BTreeMap<String, Stats>,
    /// Per bone name: direction error, degrees.
    pub per_bone_deg: BTreeMap<String, Stats>,
    /// All landmarks: the mean per-joint position error, millimetres.
    pub overall_mm: Stats,
}

/// Converts `seq` and measures how well FK of the result reproduces it.
///
/// # Errors
/// [`ConvertError`] from the conversion.
pub fn round_trip(
    rig: &Rig,
    layout: &Layout,
    seq: &PoseSequence,
    options: ConvertOptions,
) -> Result<RoundTrip, ConvertError> {
    let animation = convert_sequence(rig, layout, seq, options)?;
    let binding = layout.bind(rig).map_err(|source| ConvertError::Layout {
        source_name: seq.source.clone(),
        source,
    })?;
    let order = layout
        .joint_order(&seq.joint_names)
        .map_err(|source| ConvertError::Layout {
            source_name: seq.source.clone(),
            source,
        })?;
    let mut per_class: BTreeMap<&'static str, ClassErrors> = BTreeMap::new();
    let mut per_landmark_mm: BTreeMap<String, Stats> = BTreeMap::new();
    let mut per_bone_deg: BTreeMap<String, Stats> = BTreeMap::new();
    let mut overall_mm = Stats::default();
    let mut world = fk::WorldPose::new(rig);
    let character = &animation.character;
    let mut by_stamp = seq.frames.iter();
    for frame in &animation.frames {
        // Frames dropped for their stamps are absent from the animation: find the source frame.
        let Some(src) = by_stamp.find(|f| f.stamp_nanos == frame.stamp_nanos) else {
            break;
        };
        let input_frame = Layout::reorder(&order, src);
        let input = |l: usize| binding.landmark_point(l, &input_frame, options.min_confidence);
        let input_set =
            |set: &[usize]| binding.set_point(set, &input_frame, options.min_confidence);
        fk::forward_into(rig, character, &frame.pose, 1.0, &mut world);
        for l in 0..rig.landmarks.len() {
            let Some(p) = input(l) else { continue };
            let q = fk::landmark_position(rig, character, &world, l);
            let err_mm = (p - q).norm() * 1000.0;
            overall_mm.push(err_mm);
            per_landmark_mm
                .entry(rig.landmarks[l].name.clone())
                .or_default()
                .push(err_mm);
            let class = rig.bones[rig.landmarks[l].bone].dof.label();
            per_class.entry(class).or_default().position_mm.push(err_mm);
        }
        for source in &binding.bone_sources {
            let Some(dir) = &source.direction else {
                continue;
            };
            let (Some(a), Some(b)) = (input_set(&dir.from), input_set(&dir.to)) else {
                continue;
            };
            // The solved bone's axis (its recipe's rest direction, carried by the bone's world
            // rotation) against the input direction: the solver's own error, independent of
            // where composite landmarks such as a head centre happen to ride.
            let want = b - a;
            let got = world.rotations[source.bone]
                * (rig.rest_point(&dir.to) - rig.rest_point(&dir.from));
            let deg = want.cross(&got).norm().atan2(want.dot(&got)).to_degrees();
            if !deg.is_finite() {
                continue;
            }
            let bone = &rig.bones[source.bone];
            per_bone_deg.entry(bone.name.clone()).or_default().push(deg);
            per_class
                .entry(bone.dof.label())
                .or_default()
                .direction_deg
                .push(deg);
        }
    }
    Ok(RoundTrip {
        animation,
        per_class,
        per_landmark_mm,
        per_bone_deg,
        overall_mm,
    })
}

/// Spread of one measured segment over time.
#[derive(Debug, Clone, PartialEq)]
pub struct LengthStability {
    /// Segment name, `from→to`.
    pub segment: String,
    /// Median length, metres.
    pub median_m: f64,
    /// Coefficient of variation (standard deviation / mean).
    pub cv: f64,
    /// Frames in which it was measured.
    pub frames: usize,
}

/// Bone-length stability of every rig segment the layout sees.
///
/// # Errors
/// [`ConvertError::Layout`] if the layout does not match the data.
pub fn bone_length_stability(
    rig: &Rig,
    layout: &Layout,
    seq: &PoseSequence,
    min_confidence: f32,
) -> Result<Vec<LengthStability>, ConvertError> {
    let err = |source| ConvertError::Layout {
        source_name: seq.source.clone(),
        source,
    };
    let binding = layout.bind(rig).map_err(err)?;
    let order = layout.joint_order(&seq.joint_names).map_err(err)?;
    let mut out = Vec::new();
    for m in &binding.measures(rig) {
        let mut lengths = Vec::new();
        for f in &seq.frames {
            let frame = Layout::reorder(&order, f);
            let pt = |set: &[usize]| binding.set_point(set, &frame, min_confidence);
            if let (Some(a), Some(b)) = (pt(&m.from), pt(&m.to)) {
                lengths.push((b - a).norm());
            }
        }
        if lengths.len() < 2 {
            continue;
        }
        #[expect(
            clippy::cast_precision_loss,
            reason = "frame counts are far below 2^52"
        )]
        let n = lengths.len() as f64;
        let mean = lengths.iter().sum::<f64>() / n;
        let var = lengths.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / n;
        lengths.sort_by(f64::total_cmp);
        let name = |set: &[usize]| {
            set.iter()
                .map(|&l| rig.landmarks[l].name.as_str())
                .collect::<Vec<_>>()
                .join("+")
        };
        out.push(LengthStability {
            segment: format!("{}→{}", name(&m.from), name(&m.to)),
            median_m: lengths[lengths.len() / 2],
            cv: if mean > 0.0 { var.sqrt() / mean } else { 0.0 },
            frames: lengths.len(),
        });
    }
    Ok(out)
}
