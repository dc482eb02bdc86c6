//! Body-frame motion: how fast the joints move relative to the body's own frame (pelvis, hips,
//! neck), so the camera's motion and the body's travel and turning do not count. The quality
//! checks ([`super::qa`]) measure a clip's mean with it; the `instances` clip policy
//! ([`super::policy`]) finds action instances as bursts of it separated by rests.
//!
//! The speed of frame `k` is the mean over the joints of `|p_k − p_(k−1)| · fps`, each `p` in the
//! body frame of its own instant.

use std::collections::BTreeMap;
use std::ops::Range;

use nalgebra::{Matrix3, Vector3};

use super::plan::VideoTiming;
use crate::bags::capture::{Capture, TimelineError};

use crate::skeleton::character::Character;
use crate::skeleton::fk::{BonePose, WorldPose, forward_into};
use crate::skeleton::rig::Rig;

/// The joints the body frame is built from: the pelvis, the left and right hips and the neck
/// (rig bone names, as the render bag names its keypoints).
pub const BODY_FRAME_JOINTS: [&str; 4] = ["pelvis", "l_thigh", "r_thigh", "neck"];

/// Below this mean joint speed a body is held still, m/s (the quality checks' `still`).
pub const STILL_M_PER_S: f64 = 0.05;

/// The rotation from the frame the points are in into the body's (x from the right hip to the
/// left, z towards the neck), and the pelvis: `None` when the frame is degenerate.
#[must_use]
pub fn body_frame(
    pelvis: Vector3<f64>,
    left_hip: Vector3<f64>,
    right_hip: Vector3<f64>,
    neck: Vector3<f64>,
) -> Option<(Matrix3<f64>, Vector3<f64>)> {
    let x = (left_hip - right_hip).try_normalize(1e-6)?;
    let up = neck - pelvis;
    let z = (up - x * up.dot(&x)).try_normalize(1e-6)?;
    let body_from = Matrix3::from_rows(&[x.transpose(), z.cross(&x).transpose(), z.transpose()]);
    Some((body_from, pelvis))
}

/// Per-frame body-frame joint speeds of posed bodies, frame by frame: two joint buffers reused.
#[derive(Debug, Clone)]
pub struct SpeedMeter {
    /// Bone indices of [`BODY_FRAME_JOINTS`].
    joints: Option<[usize; 4]>,
    world: WorldPose,
    last: Vec<Vector3<f64>>,
    now: Vec<Vector3<f64>>,
    has_last: bool,
}

impl SpeedMeter {
    /// A meter for bodies of `rig`.
    #[must_use]
    pub fn new(rig: &Rig) -> SpeedMeter {
        let joints = BODY_FRAME_JOINTS.map(|n| rig.bone_index(n));
        SpeedMeter {
            joints: joints
                .iter()
                .all(Option::is_some)
                .then(|| joints.map(|j| j.unwrap_or(0))),
            world: WorldPose::new(rig),
            last: Vec::new(),
            now: Vec::new(),
            has_last: false,
        }
    }

    /// Takes in the next frame (`character` posed in `pose`) and returns its speed from the
    /// frame before, m/s at `fps` (`None` for the first frame, or a degenerate body frame).
    #[expect(clippy::cast_precision_loss, reason = "joint counts are small")]
    pub fn push(
        &mut self,
        rig: &Rig,
        character: &Character,
        pose: &BonePose,
        fps: f64,
    ) -> Option<f64> {
        forward_into(rig, character, pose, 1.0, &mut self.world);
        let heads = &self.world.heads_m;
        let frame = self.joints.and_then(|j| {
            body_frame(
                heads[j[0]].coords,
                heads[j[1]].coords,
                heads[j[2]].coords,
                heads[j[3]].coords,
            )
        });
        let Some((body_from, pelvis)) = frame else {
            self.has_last = false;
            return None;
        };
        self.now.clear();
        self.now
            .extend(heads.iter().map(|p| body_from * (p.coords - pelvis)));
        let speed = (self.has_last && self.last.len() == self.now.len()).then(|| {
            let moved: f64 = (self.now.iter().zip(&self.last))
                .map(|(a, b)| (a - b).norm())
                .sum();
            moved / self.now.len() as f64 * fps
        });
        std::mem::swap(&mut self.last, &mut self.now);
        self.has_last = true;
        speed
    }
}

/// The body-frame joint speeds of the video frames `frames` (one a frame), from the poses of
/// `capture` each shows (the capture frame nearest its instant, read from the bag for these
/// frames alone), each on its scene's drawn body. Only the speeds are kept: 8 bytes a frame.
///
/// # Errors
/// [`TimelineError`] when the capture's frames cannot be read again.
pub fn video_frame_speeds(
    rig: &Rig,
    capture: &Capture,
    timing: &VideoTiming,
    frames: Range<u64>,
) -> Result<Vec<f64>, TimelineError> {
    let fps = timing.fps.as_f64();
    let stamps = &capture.stamps;
    let nearest = |k: u64| {
        let stamp = timing.frame0_nanos + i128::from(timing.fps.frame_time_nanos(k));
        let stamp = u64::try_from(stamp.max(0)).unwrap_or(u64::MAX);
        let at = stamps.count_before(stamp);
        [at.saturating_sub(1), at.min(stamps.len().saturating_sub(1))]
            .into_iter()
            .min_by_key(|&i| stamps.get(i).map_or(u64::MAX, |t| t.abs_diff(stamp)))
            .filter(|&i| i < stamps.len())
    };
    let picks: Vec<Option<usize>> = frames.map(nearest).collect();
    let wanted: Vec<usize> = picks.iter().flatten().copied().collect();
    let mut read = capture.frames_at(rig, &wanted)?.into_iter();
    let mut meter = SpeedMeter::new(rig);
    let mut bodies: BTreeMap<usize, Character> = BTreeMap::new();
    let mut out = Vec::with_capacity(picks.len());
    for pick in picks {
        let Some(frame) = pick.and_then(|_| read.next()) else {
            out.push(0.0);
            continue;
        };
        let body = bodies.entry(frame.scene).or_insert_with(|| {
            capture
                .scenes
                .get(frame.scene)
                .map_or_else(|| Character::standard(rig), |s| s.scene.look.character(rig))
        });
        out.push(meter.push(rig, body, &frame.pose, fps).unwrap_or(f64::NAN));
    }
    // The first frame has no speed of its own: its neighbour's.
    if let (Some(first), Some(&second)) = (out.first().copied(), out.get(1))
        && first.is_nan()
    {
        out[0] = second;
    }
    for v in &mut out {
        if v.is_nan() {
            *v = 0.0;
        }
    }
    Ok(out)
}

/// How instances are told from rests in a speed series.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segmentation {
    /// Shorter bursts are left out, frames.
    pub min_frames: u64,
    /// Longer ones are cut into equal parts no longer than this, frames.
    pub max_frames: u64,
    /// A rest shorter than this does not separate two bursts, frames.
    pub min_rest_frames: u64,
}

/// Frames of the centred moving average that smooths the speeds before segmenting.
const SMOOTHING_FRAMES: usize = 5;
/// A burst must reach this share of the series' 95th-percentile speed…
const ENTER_SHARE_OF_PEAK: f64 = 0.3;
/// …and lasts while the speed stays above half of that.
const STAY_SHARE_OF_ENTER: f64 = 0.5;

/// The action instances in `speeds_m_per_s` (one a frame): frame ranges of bursts of motion
/// separated by rests. A burst starts where the smoothed speed rises above a low threshold and
/// ends where it falls below it again, and counts only if it reaches the high threshold
/// ([`ENTER_SHARE_OF_PEAK`] of the 95th-percentile speed, never below [`STILL_M_PER_S`]);
/// bursts closer than `min_rest_frames` are joined, shorter than `min_frames` dropped, longer
/// than `max_frames` cut into equal parts. A series that never moves faster than
/// [`STILL_M_PER_S`] has no instance.
#[must_use]
pub fn instances(speeds_m_per_s: &[f64], seg: &Segmentation) -> Vec<Range<u64>> {
    let smooth = smoothed(speeds_m_per_s);
    let mut sorted: Vec<f64> = smooth.iter().copied().filter(|v| v.is_finite()).collect();
    sorted.sort_by(f64::total_cmp);
    let Some(&peak) = sorted.get(sorted.len().saturating_sub(1) * 95 / 100) else {
        return Vec::new();
    };
    if peak < STILL_M_PER_S {
        return Vec::new();
    }
    let enter = (ENTER_SHARE_OF_PEAK * peak).max(STILL_M_PER_S);
    let stay = STAY_SHARE_OF_ENTER * enter;
    let mut bursts: Vec<Range<u64>> = Vec::new();
    let mut k = 0;
    while k < smooth.len() {
        if smooth[k] <= stay {
            k += 1;
            continue;
        }
        let start = k;
        let mut reached = false;
        while k < smooth.len() && smooth[k] > stay {
            reached |= smooth[k] >= enter;
            k += 1;
        }
        if reached {
            let range = start as u64..k as u64;
            match bursts.last_mut() {
                Some(last) if range.start - last.end < seg.min_rest_frames => last.end = range.end,
                _ => bursts.push(range),
            }
        }
    }
    bursts
        .into_iter()
        .filter(|r| r.end - r.start >= seg.min_frames)
        .flat_map(|r| equal_parts(r, seg.max_frames))
        .collect()
}

/// `range` cut into the fewest equal parts (lengths differing by at most one) no longer than
/// `max`.
fn equal_parts(range: Range<u64>, max: u64) -> Vec<Range<u64>> {
    let n = range.end - range.start;
    let parts = n.div_ceil(max.max(1)).max(1);
    (0..parts)
        .map(|i| range.start + n * i / parts..range.start + n * (i + 1) / parts)
        .collect()
}

/// The centred moving average of `speeds` over [`SMOOTHING_FRAMES`] (fewer at the ends).
#[expect(clippy::cast_precision_loss, reason = "window lengths are small")]
fn smoothed(speeds: &[f64]) -> Vec<f64> {
    let half = SMOOTHING_FRAMES / 2;
    (0..speeds.len())
        .map(|k| {
            let window = &speeds[k.saturating_sub(half)..(k + half + 1).min(speeds.len())];
            window.iter().sum::<f64>() / window.len() as f64
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::{Segmentation, SpeedMeter, equal_parts, instances};
    use crate::skeleton::character::Character;
    use crate::skeleton::fk::BonePose;
    use crate::skeleton::rig::Rig;
    use nalgebra::{UnitQuaternion, Vector3};

    /// 300 frames at 30 fps: rests, then three raises of the right arm (up and down over 24
    /// frames each) at frames 40, 120 and 200, while the whole body walks and turns.
    fn three_arm_raises(rig: &Rig) -> (Vec<BonePose>, Vec<(u64, u64)>) {
        let arm = rig
            .bone_index("r_upper_arm")
            .expect("the rig has a right upper arm");
        let raises = vec![(40, 64), (120, 144), (200, 224)];
        let poses = (0..300u64)
            .map(|k| {
                let mut p = BonePose::rest(rig);
                #[expect(clippy::cast_precision_loss, reason = "small frame numbers")]
                let t = k as f64 / 30.0;
                p.root_translation_m = Vector3::new(0.4 * t, 0.1 * t, 0.0);
                p.local_rotations[0] = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.3 * t);
                for &(a, b) in &raises {
                    if (a..b).contains(&k) {
                        #[expect(clippy::cast_precision_loss, reason = "small frame numbers")]
                        let phase = (k - a) as f64 / (b - a) as f64;
                        let angle = 1.4 * (std::f64::consts::PI * phase).sin();
                        p.local_rotations[arm] =
                            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), angle);
                    }
                }
                p
            })
            .collect();
        (poses, raises)
    }

    #[test]
    fn three_arm_raises_separated_by_rests_are_three_instances() {
        let rig = Rig::standard();
        let character = Character::standard(&rig);
        let (poses, raises) = three_arm_raises(&rig);
        let mut meter = SpeedMeter::new(&rig);
        let mut speeds: Vec<f64> = poses
            .iter()
            .map(|p| meter.push(&rig, &character, p, 30.0).unwrap_or(0.0))
            .collect();
        speeds[0] = speeds[1];
        // The travel and turning do not count: the rests measure (almost) nothing.
        assert!(speeds[10] < 1e-9 && speeds[100] < 1e-9, "{}", speeds[10]);
        let seg = Segmentation {
            min_frames: 10,
            max_frames: 300,
            min_rest_frames: 8,
        };
        let found = instances(&speeds, &seg);
        assert_eq!(found.len(), 3, "{found:?}");
        for (r, (a, b)) in found.iter().zip(raises) {
            assert!(r.start <= a + 3 && r.end + 3 >= b, "{r:?} vs {a}..{b}");
            assert!(r.start + 6 >= a && r.end <= b + 6, "{r:?} hugs {a}..{b}");
        }
        // A rest shorter than min_rest_frames joins them; max_frames cuts the join in parts.
        let joined = instances(
            &speeds,
            &Segmentation {
                min_rest_frames: 100,
                max_frames: 100,
                ..seg
            },
        );
        assert_eq!(joined.len(), 2, "{joined:?}");
        assert!(joined.iter().all(|r| r.end - r.start <= 100));
        assert_eq!(joined[0].start, found[0].start);
        assert_eq!(joined[1].end, found[2].end);
        // Too short to count: none.
        let none = instances(
            &speeds,
            &Segmentation {
                min_frames: 60,
                ..seg
            },
        );
        assert!(none.is_empty(), "{none:?}");
        // A body held still has no instance.
        assert!(instances(&[0.0; 100], &seg).is_empty());
        assert!(instances(&[], &seg).is_empty());
    }

    #[test]
    fn long_bursts_are_cut_in_equal_parts() {
        assert_eq!(equal_parts(0..10, 4), vec![0..3, 3..6, 6..10]);
        assert_eq!(equal_parts(5..9, 4), vec![5..9]);
        assert_eq!(equal_parts(0..9, 3), vec![0..3, 3..6, 6..9]);
    }
}
