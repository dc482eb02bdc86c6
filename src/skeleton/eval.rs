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
            let (want, got) = match aimed_target(rig, source.bone, &dir.to) {
                // An aimed bone (the clavicle) points from its solved head at its end point.
                Some(l) => (
                    b - world.heads_m[source.bone],
                    world.rotations[source.bone] * character.landmark_offset_m[l],
                ),
                None => (
                    b - a,
                    world.rotations[source.bone]
                        * (rig.rest_point(&dir.to) - rig.rest_point(&dir.from)),
                ),
            };
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

/// The end landmark of an aimed recipe of `bone` ([`crate::skeleton::rig::Recipe::aim`]) when it
/// is one landmark riding on the bone, as the solver aims at it.
fn aimed_target(rig: &Rig, bone: usize, to: &[usize]) -> Option<usize> {
    let &[l] = to else { return None };
    (rig.recipes.iter().any(|r| r.bone == bone && r.aim) && rig.landmarks[l].bone == bone)
        .then_some(l)
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
    let measures = binding.measures(rig);
    for (k, m) in measures.iter().enumerate() {
        // A segment that is both a bone and a width (the hip line; chest→shoulder where the
        // layout has no clavicle) is reported once.
        if measures[..k]
            .iter()
            .any(|o| o.from == m.from && o.to == m.to)
        {
            continue;
        }
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

/// The landmarks of the root-relative position error: each side's hip, knee, ankle, shoulder,
/// elbow and wrist.
pub const ROOT_RELATIVE_LANDMARKS: [&str; 12] = [
    "l_hip",
    "r_hip",
    "l_knee",
    "r_knee",
    "l_ankle",
    "r_ankle",
    "l_shoulder",
    "r_shoulder",
    "l_elbow",
    "r_elbow",
    "l_wrist",
    "r_wrist",
];

/// Root-relative position error over [`ROOT_RELATIVE_LANDMARKS`]: per frame the pelvis point is
/// subtracted from the input and from the reproduced points, then they are compared.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RootRelativeError {
    /// (frame, landmark) samples.
    pub count: usize,
    /// Mean error, millimetres.
    pub mean_mm: f64,
    /// 95th percentile, millimetres (nearest rank).
    pub p95_mm: f64,
    /// Largest error, millimetres.
    pub max_mm: f64,
    /// Per landmark name: its errors, millimetres.
    pub per_landmark_mm: BTreeMap<String, Stats>,
}

/// The root-relative position error of `animation` (converted from `seq` in `layout`) against
/// `seq` itself: forward kinematics on the animation's fitted body, the pelvis point subtracted
/// per frame on both sides. Frames without a pelvis point and landmarks the layout does not bind
/// are skipped (`count` is 0 when nothing could be compared).
///
/// # Errors
/// [`ConvertError::Layout`] if the layout does not match the data.
pub fn root_relative_error(
    rig: &Rig,
    layout: &Layout,
    seq: &PoseSequence,
    animation: &Animation,
    min_confidence: f32,
) -> Result<RootRelativeError, ConvertError> {
    let err = |source| ConvertError::Layout {
        source_name: seq.source.clone(),
        source,
    };
    let binding = layout.bind(rig).map_err(err)?;
    let order = layout.joint_order(&seq.joint_names).map_err(err)?;
    let landmarks: Vec<usize> = ROOT_RELATIVE_LANDMARKS
        .iter()
        .filter_map(|n| rig.landmark_index(n))
        .filter(|&l| binding.landmark_terms[l].is_some())
        .collect();
    let Some(pelvis) = rig.landmark_index("pelvis") else {
        return Ok(RootRelativeError::default());
    };
    let mut out = RootRelativeError::default();
    let mut samples = Vec::new();
    let mut world = fk::WorldPose::new(rig);
    let character = &animation.character;
    let mut by_stamp = seq.frames.iter();
    for frame in &animation.frames {
        let Some(src) = by_stamp.find(|f| f.stamp_nanos == frame.stamp_nanos) else {
            break;
        };
        let input_frame = Layout::reorder(&order, src);
        let input = |l: usize| binding.landmark_point(l, &input_frame, min_confidence);
        let Some(input_root) = input(pelvis) else {
            continue;
        };
        fk::forward_into(rig, character, &frame.pose, 1.0, &mut world);
        let solved_root = fk::landmark_position(rig, character, &world, pelvis);
        for &l in &landmarks {
            let Some(p) = input(l) else { continue };
            let q = fk::landmark_position(rig, character, &world, l);
            let err_mm = ((p - input_root) - (q - solved_root)).norm() * 1000.0;
            if !err_mm.is_finite() {
                continue;
            }
            samples.push(err_mm);
            out.per_landmark_mm
                .entry(rig.landmarks[l].name.clone())
                .or_default()
                .push(err_mm);
        }
    }
    if samples.is_empty() {
        return Ok(out);
    }
    samples.sort_by(f64::total_cmp);
    out.count = samples.len();
    #[expect(
        clippy::cast_precision_loss,
        reason = "sample counts are far below 2^52"
    )]
    let n = samples.len() as f64;
    out.mean_mm = samples.iter().sum::<f64>() / n;
    out.max_mm = samples[samples.len() - 1];
    out.p95_mm = samples[percentile_rank(samples.len(), 0.95)];
    Ok(out)
}

/// The nearest-rank index of quantile `q` in `n` sorted samples (`n` > 0).
fn percentile_rank(n: usize, q: f64) -> usize {
    #[expect(
        clippy::cast_precision_loss,
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "a rank among a few million samples, clamped to the range"
    )]
    let rank = ((q * n as f64).ceil() as usize).clamp(1, n);
    rank - 1
}

/// A one-frame spin larger than the source's by more than this counts as a spin (degrees).
pub const TWIST_SPIN_EXCESS_DEG: f64 = 20.0;

/// A source's own joint motion, for [`twist_spin`]: the joints' parents and, per source frame
/// (the [`PoseSequence`]'s frames, same order), every joint's world position (metres, autoact
/// frame) and world rotation (`world_from_joint`, autoact axes).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SourceMotion {
    /// Parent of each source joint.
    pub parents: Vec<Option<usize>>,
    /// Per frame, per joint: (position, `world_from_joint`).
    pub frames: Vec<Vec<(nalgebra::Point3<f64>, nalgebra::UnitQuaternion<f64>)>>,
}

/// Where a bone's source spin comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpinBaseline {
    /// The source joint whose rotation moves the bone's segment: its twist about the segment.
    SourceRotation,
    /// No source rotation: the segment's own one-frame turn (its swing), measured on the input
    /// keypoints.
    SegmentSwing,
}

/// One bone's twist spin over a clip: the largest one-frame rotation about the bone's own axis.
#[derive(Debug, Clone, PartialEq)]
pub struct BoneTwistSpin {
    /// Rig bone name.
    pub bone: String,
    /// What the source column measures.
    pub baseline: SpinBaseline,
    /// Largest one-frame twist of the output bone, degrees.
    pub output_max_deg: f64,
    /// Largest one-frame twist (or swing, see `baseline`) of the source, degrees.
    pub source_max_deg: f64,
    /// Frames where the output's twist exceeds the source's by more than
    /// [`TWIST_SPIN_EXCESS_DEG`].
    pub frames_over: usize,
    /// The frame (animation index) of the largest excess, and that excess in degrees.
    pub worst: Option<(usize, f64)>,
}

/// The twist spin of every driven 3-D and 2-D bone of a converted clip, against its source.
#[derive(Debug, Clone, PartialEq)]
pub struct TwistSpin {
    /// Per bone, in rig order.
    pub bones: Vec<BoneTwistSpin>,
    /// Frames in which at least one bone's twist exceeds its source's by more than
    /// [`TWIST_SPIN_EXCESS_DEG`].
    pub frames_over: usize,
}

impl TwistSpin {
    /// The bone with the largest output spin.
    #[must_use]
    pub fn worst_bone(&self) -> Option<&BoneTwistSpin> {
        self.bones
            .iter()
            .max_by(|a, b| a.output_max_deg.total_cmp(&b.output_max_deg))
    }
}

/// The absolute twist, degrees, of the one-frame change `prev → cur` of a `world_from_x`
/// rotation, about `axis_in_x` (the segment's axis in x's own frame at `prev`).
fn frame_twist_deg(
    prev: &nalgebra::UnitQuaternion<f64>,
    cur: &nalgebra::UnitQuaternion<f64>,
    axis_in_x: &nalgebra::Vector3<f64>,
) -> Option<f64> {
    let axis = crate::skeleton::geom::direction(*axis_in_x)?;
    let (_, twist) = crate::skeleton::geom::swing_twist(&(prev.inverse() * cur), &axis);
    Some(twist.abs().to_degrees())
}

/// The source joint whose rotation moves the segment `a → b`: the parent `j` of the joint `k`
/// at `b` (one with a non-zero offset from its parent), with `j` at `a`. Returns `(j, k)`.
fn source_segment(
    source: &SourceMotion,
    frame: usize,
    a: &nalgebra::Point3<f64>,
    b: &nalgebra::Point3<f64>,
) -> Option<(usize, usize)> {
    const TOLERANCE_M: f64 = 1e-4;
    let joints = source.frames.get(frame)?;
    (0..joints.len()).find_map(|k| {
        let j = (*source.parents.get(k)?)?;
        let (pk, pj) = (joints[k].0, joints.get(j)?.0);
        ((pk - b).norm() < TOLERANCE_M
            && (pj - a).norm() < TOLERANCE_M
            && (pk - pj).norm() > TOLERANCE_M)
            .then_some((j, k))
    })
}

/// Twist spin of a converted clip: per driven 3-D and 2-D bone, the one-frame change of its
/// world rotation about its own axis (the twist part of the swing–twist decomposition of
/// `world_{t−1}⁻¹ · world_t`), against the source's. With `source` (mocap with rotations), a
/// bone is compared with the source joint whose rotation moves the same segment; bones with no
/// such joint, and every bone without `source`, are compared with the segment's own one-frame
/// turn ([`SpinBaseline::SegmentSwing`]).
///
/// # Errors
/// [`ConvertError::Layout`] if the layout does not match the data.
pub fn twist_spin(
    rig: &Rig,
    layout: &Layout,
    seq: &PoseSequence,
    animation: &Animation,
    min_confidence: f32,
    source: Option<&SourceMotion>,
) -> Result<TwistSpin, ConvertError> {
    let err = |source| ConvertError::Layout {
        source_name: seq.source.clone(),
        source,
    };
    let binding = layout.bind(rig).map_err(err)?;
    let order = layout.joint_order(&seq.joint_names).map_err(err)?;
    // Animation frame k ↔ source frame index (frames dropped for their stamps are skipped).
    let mut src_index = Vec::with_capacity(animation.frames.len());
    let mut next = 0;
    for f in &animation.frames {
        while next < seq.frames.len() && seq.frames[next].stamp_nanos != f.stamp_nanos {
            next += 1;
        }
        src_index.push(next);
        next += 1;
    }
    let bones: Vec<(usize, &crate::skeleton::rig::DirectionSource)> = binding
        .bone_sources
        .iter()
        .filter(|s| {
            matches!(
                rig.bones[s.bone].dof,
                crate::skeleton::rig::Dof::ThreeD | crate::skeleton::rig::Dof::TwoD
            )
        })
        .filter_map(|s| Some((s.bone, s.direction.as_ref()?)))
        .collect();
    let mut out: Vec<BoneTwistSpin> = bones
        .iter()
        .map(|(b, _)| BoneTwistSpin {
            bone: rig.bones[*b].name.clone(),
            baseline: SpinBaseline::SegmentSwing,
            output_max_deg: 0.0,
            source_max_deg: 0.0,
            frames_over: 0,
            worst: None,
        })
        .collect();
    let mut pairs: Vec<Option<(usize, usize)>> = vec![None; bones.len()];
    let mut world = fk::WorldPose::new(rig);
    let mut prev_rotations: Option<Vec<nalgebra::UnitQuaternion<f64>>> = None;
    let mut prev_points: Vec<Option<(nalgebra::Point3<f64>, nalgebra::Point3<f64>)>> =
        vec![None; bones.len()];
    let mut frames_over = 0;
    for (k, frame) in animation.frames.iter().enumerate() {
        let Some(src) = seq.frames.get(src_index[k]) else {
            break;
        };
        let input_frame = Layout::reorder(&order, src);
        fk::forward_into(rig, &animation.character, &frame.pose, 1.0, &mut world);
        let mut over = false;
        for (i, (b, dir)) in bones.iter().enumerate() {
            let pts = binding
                .set_point(&dir.from, &input_frame, min_confidence)
                .zip(binding.set_point(&dir.to, &input_frame, min_confidence));
            // The source joint is found on the first frame that has the segment.
            if let (None, Some(s), Some((a, bp))) = (pairs[i], source, pts) {
                pairs[i] = source_segment(s, src_index[k], &a, &bp);
                if pairs[i].is_some() {
                    out[i].baseline = SpinBaseline::SourceRotation;
                }
            }
            let prev_pts = std::mem::replace(&mut prev_points[i], pts);
            let Some(prev) = &prev_rotations else {
                continue;
            };
            let axis = rig.rest_point(&dir.to) - rig.rest_point(&dir.from);
            let Some(spin) = frame_twist_deg(&prev[*b], &world.rotations[*b], &axis) else {
                continue;
            };
            let reference = match (pairs[i], source) {
                (Some((j, kk)), Some(s)) => {
                    source_twist_deg(s, src_index[k - 1], src_index[k], j, kk)
                }
                _ => prev_pts.zip(pts).and_then(|((a0, b0), (a1, b1))| {
                    let (u, v) = (b0 - a0, b1 - a1);
                    let deg = u.cross(&v).norm().atan2(u.dot(&v)).to_degrees();
                    deg.is_finite().then_some(deg)
                }),
            };
            let entry = &mut out[i];
            entry.output_max_deg = entry.output_max_deg.max(spin);
            let Some(reference) = reference else { continue };
            entry.source_max_deg = entry.source_max_deg.max(reference);
            let excess = spin - reference;
            if excess > TWIST_SPIN_EXCESS_DEG {
                entry.frames_over += 1;
                over = true;
            }
            if entry.worst.is_none_or(|(_, e)| excess > e) {
                entry.worst = Some((k, excess));
            }
        }
        frames_over += usize::from(over);
        prev_rotations = Some(world.rotations.clone());
    }
    Ok(TwistSpin {
        bones: out,
        frames_over,
    })
}

/// The source's twist, degrees, of joint `j` about its segment to `k`, from frame `f0` to `f1`.
fn source_twist_deg(
    source: &SourceMotion,
    f0: usize,
    f1: usize,
    j: usize,
    k: usize,
) -> Option<f64> {
    let (pj, qj) = *source.frames.get(f0)?.get(j)?;
    let pk = source.frames.get(f0)?.get(k)?.0;
    let q1 = source.frames.get(f1)?.get(j)?.1;
    frame_twist_deg(&qj, &q1, &(qj.inverse() * (pk - pj)))
}
