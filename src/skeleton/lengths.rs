//! Bone lengths of estimator output: how much they vary, and an opt-in solve that fixes them.
//!
//! Estimators fit a skeleton per frame: ZED's thigh measures 0.24–0.43 m within one clip.
//! [`stability`] reports each measured segment's spread (coefficient of variation, median
//! length; the computation is [`crate::skeleton::eval::bone_length_stability`], shared with the
//! round-trip report), and [`report_lines`] words it for stderr and `info`.
//!
//! [`fix_limb_lengths`] (`--lengths fixed`) is a keypoint pre-pass: each limb — hip → knee →
//! ankle, shoulder → elbow → wrist — gets the clip's median segment lengths, and every frame is
//! re-posed by two-bone IK that keeps the root (hip, shoulder) and the end effector (ankle,
//! wrist): the middle joint is placed by the law of cosines in the measured bend plane, on the
//! side the measured knee or elbow bends to (the previous frame's side when the measured limb
//! is straight). A target out of reach straightens the limb towards it and moves the end
//! effector and what hangs from it (foot, hand) by the same amount. A knee bend stays a knee
//! bend, and its angle is no longer inflated or flattened by a thigh that shrinks.

use nalgebra::{Point3, Vector3};

use crate::skeleton::convert::ConvertError;
use crate::skeleton::eval::{LengthStability, bone_length_stability};
use crate::skeleton::layout::{JointExpr, Layout};
use crate::skeleton::pose::{PoseFrame, PoseSequence};
use crate::skeleton::rig::Rig;

/// Coefficient of variation above which a segment is reported as unstable (a warning).
pub const UNSTABLE_CV: f64 = 0.10;

/// How bone lengths are treated at import (`--lengths`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum LengthMode {
    /// As measured, frame by frame (reported when they vary).
    #[default]
    Measured,
    /// Limbs re-posed with the clip's median lengths, end effectors kept (two-bone IK).
    Fixed,
}

/// The spread of every segment `layout` measures in `seq` (see
/// [`crate::skeleton::eval::bone_length_stability`]).
///
/// # Errors
/// [`ConvertError::Layout`] when the layout does not fit the rig or the data's joints.
pub fn stability(
    seq: &PoseSequence,
    layout: &Layout,
) -> Result<Vec<LengthStability>, ConvertError> {
    bone_length_stability(&Rig::standard(), layout, seq, 0.0)
}

/// One line per segment, the most variable first: `l_hip→l_knee: median 0.412 m, CV 12.3 %
/// (126 frames)`; segments at or over [`UNSTABLE_CV`] are marked `unstable`.
#[must_use]
pub fn report_lines(stability: &[LengthStability]) -> Vec<String> {
    let mut rows: Vec<&LengthStability> = stability.iter().collect();
    rows.sort_by(|a, b| b.cv.total_cmp(&a.cv));
    rows.iter()
        .map(|s| {
            format!(
                "{}: median {:.3} m, CV {:.1} % ({} frames){}",
                s.segment,
                s.median_m,
                s.cv * 100.0,
                s.frames,
                if s.cv >= UNSTABLE_CV {
                    ", unstable"
                } else {
                    ""
                }
            )
        })
        .collect()
}

/// What [`fix_limb_lengths`] did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LengthFix {
    /// Limbs solved (of four), with their fitted (upper, lower) lengths, metres.
    pub limbs: Vec<(String, f64, f64)>,
    /// Frames × limbs where the end effector was out of reach and was moved.
    pub out_of_reach: usize,
}

/// A limb: root, middle and end joints (indices into the data) and the joints hanging from the
/// end (moved with it when it is out of reach).
#[derive(Debug, Clone)]
struct Limb {
    name: String,
    joints: [usize; 3],
    hanging: Vec<usize>,
}

/// The data joint bound to landmark `name`, if it is one joint.
fn single_joint(layout: &Layout, joint_names: &[String], name: &str) -> Option<usize> {
    match layout.landmarks.get(name)? {
        JointExpr::Joint(j) => joint_names.iter().position(|n| n == j),
        _ => None,
    }
}

/// The limbs of `layout` present in `joint_names`.
fn limbs(layout: &Layout, joint_names: &[String]) -> Vec<Limb> {
    let rig = Rig::standard();
    let mut out = Vec::new();
    for side in ["l", "r"] {
        for (upper, middle, end) in [("hip", "knee", "ankle"), ("shoulder", "elbow", "wrist")] {
            let names = [upper, middle, end].map(|n| format!("{side}_{n}"));
            let found: Option<Vec<usize>> = names
                .iter()
                .map(|n| single_joint(layout, joint_names, n))
                .collect();
            let Some(found) = found else { continue };
            let Some(end_bone) = rig.landmark_index(&names[2]).map(|l| rig.landmarks[l].bone)
            else {
                continue;
            };
            let hanging = layout
                .landmarks
                .keys()
                .filter(|l| {
                    rig.landmark_index(l).is_some_and(|i| {
                        let bone = rig.landmarks[i].bone;
                        bone != end_bone && rig.is_ancestor(end_bone, bone)
                    })
                })
                .filter_map(|l| single_joint(layout, joint_names, l))
                .collect();
            out.push(Limb {
                name: format!("{}→{}→{}", names[0], names[1], names[2]),
                joints: [found[0], found[1], found[2]],
                hanging,
            });
        }
    }
    out
}

/// The median of the finite values.
fn median(mut values: Vec<f64>) -> Option<f64> {
    values.retain(|v| v.is_finite() && *v > 0.0);
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied()
}

fn finite(p: &Point3<f64>) -> bool {
    p.coords.iter().all(|v| v.is_finite())
}

/// Re-poses every limb of `seq` with the clip's median segment lengths (see the module
/// documentation). Frames where a limb joint is missing keep that limb as it is.
#[must_use]
pub fn fix_limb_lengths(seq: &mut PoseSequence, layout: &Layout) -> LengthFix {
    let mut fixer = LimbFixer::fit(layout, &seq.joint_names, &seq.frames);
    for f in &mut seq.frames {
        fixer.fix(f);
    }
    fixer.summary()
}

/// [`fix_limb_lengths`] frame by frame, for a clip read as a stream: the limbs' lengths are
/// fitted once (on all of the clip's frames, or a sample of them), then each frame is fixed
/// in order.
#[derive(Debug, Clone)]
pub struct LimbFixer {
    /// Each limb with its fitted (upper, lower) lengths and the side its last frame bent to.
    limbs: Vec<(Limb, f64, f64, Option<Vector3<f64>>)>,
    out_of_reach: usize,
}

impl LimbFixer {
    /// The median segment lengths of every limb of `layout` in `frames` (data whose joints are
    /// `joint_names`); limbs never measured are left out.
    #[must_use]
    pub fn fit(layout: &Layout, joint_names: &[String], frames: &[PoseFrame]) -> LimbFixer {
        let limbs = limbs(layout, joint_names)
            .into_iter()
            .filter_map(|limb| {
                let [a, b, c] = limb.joints;
                let measure = |i: usize, j: usize| -> Vec<f64> {
                    frames
                        .iter()
                        .map(|f| (f.positions_m[j] - f.positions_m[i]).norm())
                        .collect()
                };
                let upper = median(measure(a, b))?;
                let lower = median(measure(b, c))?;
                Some((limb, upper, lower, None))
            })
            .collect();
        LimbFixer {
            limbs,
            out_of_reach: 0,
        }
    }

    /// Re-poses the limbs of the clip's next frame.
    pub fn fix(&mut self, f: &mut PoseFrame) {
        for (limb, upper, lower, side) in &mut self.limbs {
            let [a, b, c] = limb.joints;
            let (pa, pb, pc) = (f.positions_m[a], f.positions_m[b], f.positions_m[c]);
            if !(finite(&pa) && finite(&pb) && finite(&pc)) {
                continue;
            }
            let (middle, end, clamped) = solve_two_bone(pa, pb, pc, *upper, *lower, side);
            self.out_of_reach += usize::from(clamped);
            let shift = end - pc;
            f.positions_m[b] = middle;
            f.positions_m[c] = end;
            for &h in &limb.hanging {
                f.positions_m[h] += shift;
            }
        }
    }

    /// What was done so far.
    #[must_use]
    pub fn summary(&self) -> LengthFix {
        LengthFix {
            limbs: self
                .limbs
                .iter()
                .map(|(limb, upper, lower, _)| (limb.name.clone(), *upper, *lower))
                .collect(),
            out_of_reach: self.out_of_reach,
        }
    }
}

/// Two-bone IK: the middle joint for root `a`, measured middle `b` and end `c`, with segment
/// lengths `upper` and `lower`, in the plane of the measured bend (its side from `b`, else
/// `side`, the previous frame's). Returns (middle, end, whether the end was out of reach and
/// moved).
fn solve_two_bone(
    a: Point3<f64>,
    b: Point3<f64>,
    c: Point3<f64>,
    upper: f64,
    lower: f64,
    side: &mut Option<Vector3<f64>>,
) -> (Point3<f64>, Point3<f64>, bool) {
    let to_end = c - a;
    let Some(axis) = to_end.try_normalize(1e-9) else {
        // The end sits on the root: nothing to orient the limb by; leave it.
        return (b, c, false);
    };
    let reach_max = upper + lower;
    let reach_min = (upper - lower).abs();
    let d = to_end.norm();
    let (d, end, clamped) = if d > reach_max {
        (reach_max, a + axis * reach_max, true)
    } else if d < reach_min {
        (reach_min, a + axis * reach_min, true)
    } else {
        (d, c, false)
    };
    // The bend's side: the measured middle joint's offset from the root → end line.
    let offset = (b - a) - axis * (b - a).dot(&axis);
    let previous = side.map(|s| s - axis * s.dot(&axis));
    let w = offset
        .try_normalize(1e-6)
        .or_else(|| previous.and_then(|p| p.try_normalize(1e-6)))
        .unwrap_or_else(|| any_perpendicular(&axis));
    *side = Some(w);
    let along = (upper * upper - lower * lower + d * d) / (2.0 * d);
    let across = (upper * upper - along * along).max(0.0).sqrt();
    (a + axis * along + w * across, end, clamped)
}

/// A unit vector perpendicular to unit `v`.
fn any_perpendicular(v: &Vector3<f64>) -> Vector3<f64> {
    let helper = if v.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    v.cross(&helper).normalize()
}

/// The flexion angle at the middle joint of limb (`a`, `b`, `c`), degrees: 0 when straight.
#[must_use]
pub fn flexion_deg(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> f64 {
    crate::skeleton::ground::angle_deg(&(b - a), &(c - b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::pose::PoseFrame;
    use proptest::prelude::*;

    /// A leg in h36m-17 whose thigh length wobbles while the knee bends through `bend_deg`.
    fn wobbly_leg(frames: usize, wobble: f64) -> (PoseSequence, Layout, Vec<f64>) {
        let layout = Layout::load("h36m-17").unwrap();
        let idx = |n: &str| layout.joints.iter().position(|j| j == n).unwrap();
        let (hip, knee, foot) = (idx("left_hip"), idx("left_knee"), idx("left_foot"));
        let mut bends = Vec::new();
        let frames = (0..frames)
            .map(|i| {
                #[expect(clippy::cast_precision_loss, reason = "small")]
                let t = i as f64 / 10.0;
                let bend = (60.0 * (0.5 - 0.5 * t.cos())).to_radians();
                bends.push(bend.to_degrees());
                let thigh = 0.42 * (1.0 + wobble * (3.0 * t).sin());
                let shin = 0.40;
                let h = Point3::new(0.1, 0.0, 1.0);
                let k = h + Vector3::new(0.0, 0.2_f64.sin(), -0.2_f64.cos()) * thigh;
                let dir = Vector3::new(0.0, (0.2 - bend).sin(), -(0.2 - bend).cos());
                let mut f = PoseFrame::missing(0, layout.joints.len());
                for (j, p) in [(hip, h), (knee, k), (foot, k + dir * shin)] {
                    f.positions_m[j] = p;
                    f.confidence[j] = 1.0;
                }
                f
            })
            .collect();
        let seq = PoseSequence {
            source: "leg".into(),
            track_id: 0,
            joint_names: layout.joints.clone(),
            frames,
        };
        (seq, layout, bends)
    }

    #[test]
    fn fixed_lengths_keep_the_feet_and_the_bend() {
        let (mut seq, layout, _) = wobbly_leg(60, 0.2);
        let before = stability(&seq, &layout).unwrap();
        let thigh =
            |s: &[LengthStability]| s.iter().find(|l| l.segment == "l_hip→l_knee").unwrap().cv;
        assert!(thigh(&before) > 0.1);
        let original = seq.clone();
        let fix = fix_limb_lengths(&mut seq, &layout);
        assert_eq!(fix.limbs.len(), 1, "{fix:?}");
        let after = stability(&seq, &layout).unwrap();
        assert!(thigh(&after) < 1e-9, "{}", thigh(&after));
        let foot = layout.joints.iter().position(|j| j == "left_foot").unwrap();
        let moved = original
            .frames
            .iter()
            .zip(&seq.frames)
            .filter(|(a, b)| (a.positions_m[foot] - b.positions_m[foot]).norm() > 1e-9)
            .count();
        assert_eq!(moved, fix.out_of_reach);
        let lines = report_lines(&before);
        assert!(
            lines[0].starts_with("l_hip→l_knee: median 0.4"),
            "{lines:?}"
        );
        assert!(lines[0].ends_with(", unstable"), "{lines:?}");
    }

    #[test]
    fn a_missing_joint_leaves_its_frame_and_a_layout_without_limbs_is_a_no_op() {
        let (mut seq, layout, _) = wobbly_leg(5, 0.1);
        seq.frames[2].positions_m[5] = Point3::new(f64::NAN, f64::NAN, f64::NAN);
        let kept = seq.frames[2].clone();
        let _ = fix_limb_lengths(&mut seq, &layout);
        assert_eq!(format!("{kept:?}"), format!("{:?}", seq.frames[2]));
        let trunk = Layout::from_toml(
            "name = \"t\"\njoints = [\"a\"]\n[landmarks]\npelvis = \"a\"\n",
            "t",
        )
        .unwrap();
        let mut one = PoseSequence {
            source: "t".into(),
            track_id: 0,
            joint_names: vec!["a".into()],
            frames: vec![PoseFrame::missing(0, 1)],
        };
        assert_eq!(fix_limb_lengths(&mut one, &trunk), LengthFix::default());
    }

    proptest! {
        /// Within reach, the end effector stays, the lengths are the fitted ones, and the bend
        /// keeps its side.
        #[test]
        fn two_bone_ik_keeps_the_end_and_the_side(
            b in prop::array::uniform3(-0.5..0.5_f64),
            c in prop::array::uniform3(-0.6..0.6_f64),
            upper in 0.2..0.5_f64,
            lower in 0.2..0.5_f64,
        ) {
            let (a, b, c) = (Point3::origin(), Point3::from(Vector3::from(b)), Point3::from(Vector3::from(c)));
            let mut side = None;
            let (m, end, clamped) = solve_two_bone(a, b, c, upper, lower, &mut side);
            prop_assert!(((m - a).norm() - upper).abs() < 1e-9 || c.coords.norm() < 1e-9);
            if !clamped && c.coords.norm() > 1e-9 {
                prop_assert!((end - c).norm() < 1e-12);
                prop_assert!(((end - m).norm() - lower).abs() < 1e-9);
                let axis = c.coords.normalize();
                let off_b = b.coords - axis * b.coords.dot(&axis);
                let off_m = m.coords - axis * m.coords.dot(&axis);
                if off_b.norm() > 1e-3 && off_m.norm() > 1e-3 {
                    prop_assert!(off_b.dot(&off_m) > 0.0);
                }
            }
        }
    }
}
