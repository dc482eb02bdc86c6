//! Resampling an animation to an explicit frame rate from its own stamps, on the rotation group:
//! slerp between the bracketing frames' local rotations (their hemispheres are already
//! continuous), lerp between root translations. Output stamps are `first + k·(1 s / fps)` up to
//! the last input stamp: never extrapolated (an output time within a thousandth of a frame past
//! the last input — stamp rounding — is that input), and gaps in the input (dropped frames) are
//! bridged by the same interpolation instead of being assumed away.

use nalgebra::UnitQuaternion;

use crate::convert::AnimationFrame;
use crate::fk::BonePose;
use crate::pose::stamp_nanos_at;

/// Where a time falls in a sorted list of frames.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sample {
    /// Exactly on frame `i`.
    Exact(usize),
    /// Before the first frame.
    Before,
    /// After the last frame.
    After,
    /// Between frames `i` and `i + 1`, a fraction `s` in (0, 1) of the way.
    Between(usize, f64),
}

/// Locates `t` among frames with strictly increasing stamps, starting the search at `hint`
/// (monotone queries walk forward in O(1) amortised).
#[must_use]
pub fn locate(frames: &[AnimationFrame], t: u64, hint: usize) -> Sample {
    let (Some(first), Some(last)) = (frames.first(), frames.last()) else {
        return Sample::After;
    };
    if t < first.stamp_nanos {
        return Sample::Before;
    }
    if t > last.stamp_nanos {
        return Sample::After;
    }
    let mut i = hint.min(frames.len() - 1);
    if frames[i].stamp_nanos > t {
        i = 0;
    }
    while i + 1 < frames.len() && frames[i + 1].stamp_nanos <= t {
        i += 1;
    }
    if frames[i].stamp_nanos == t {
        return Sample::Exact(i);
    }
    let (a, b) = (frames[i].stamp_nanos, frames[i + 1].stamp_nanos);
    #[expect(
        clippy::cast_precision_loss,
        reason = "stamp differences within a clip are far below 2^52 ns"
    )]
    let s = (t - a) as f64 / (b - a) as f64;
    Sample::Between(i, s)
}

/// Interpolates two poses: slerp per bone, lerp for the root translation.
#[must_use]
pub fn interpolate(a: &BonePose, b: &BonePose, s: f64) -> BonePose {
    BonePose {
        root_translation_m: a.root_translation_m.lerp(&b.root_translation_m, s),
        local_rotations: a
            .local_rotations
            .iter()
            .zip(&b.local_rotations)
            .map(|(qa, qb)| slerp(qa, qb, s))
            .collect(),
    }
}

/// Shortest-path slerp that never panics (nalgebra's `slerp` does on antipodal input).
#[must_use]
pub fn slerp(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>, s: f64) -> UnitQuaternion<f64> {
    let b = crate::geom::align_hemisphere(*b, a);
    a.try_slerp(&b, s, 1e-12).unwrap_or_else(|| a.nlerp(&b, s))
}

/// Resamples `frames` (strictly increasing stamps) at `fps`.
#[must_use]
pub fn resample(frames: &[AnimationFrame], fps: f64) -> Vec<AnimationFrame> {
    let (Some(first), Some(last)) = (frames.first(), frames.last()) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    let mut hint = 0;
    // Stamps written at a nominal rate carry rounding (1/30 s is not a whole number of ns, a BVH
    // frame time has 7 digits): an output time this close past the last input is that input.
    let tolerance = stamp_nanos_at(1, fps * 1000.0);
    for k in 0.. {
        let mut t = first.stamp_nanos + stamp_nanos_at(k, fps);
        if t > last.stamp_nanos && t - last.stamp_nanos <= tolerance {
            t = last.stamp_nanos;
        }
        if t > last.stamp_nanos
            || out
                .last()
                .is_some_and(|f: &AnimationFrame| f.stamp_nanos >= t)
        {
            break;
        }
        let pose = match locate(frames, t, hint) {
            Sample::Exact(i) => {
                hint = i;
                frames[i].pose.clone()
            }
            Sample::Between(i, s) => {
                hint = i;
                interpolate(&frames[i].pose, &frames[i + 1].pose, s)
            }
            Sample::Before | Sample::After => break,
        };
        out.push(AnimationFrame {
            stamp_nanos: t,
            pose,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::rotation_distance;
    use nalgebra::Vector3;
    use proptest::prelude::*;

    fn frame(t: u64, angle: f64) -> AnimationFrame {
        AnimationFrame {
            stamp_nanos: t,
            pose: BonePose {
                root_translation_m: Vector3::new(angle, 0.0, 0.0),
                local_rotations: vec![UnitQuaternion::from_axis_angle(&Vector3::z_axis(), angle)],
            },
        }
    }

    #[test]
    fn keyframes_are_hit_exactly_and_nothing_is_extrapolated() {
        let frames = vec![
            frame(0, 0.0),
            frame(100_000_000, 1.0),
            frame(200_000_000, 3.0),
        ];
        let out = resample(&frames, 10.0);
        assert_eq!(out.len(), 3);
        for (o, f) in out.iter().zip(&frames) {
            assert_eq!(o.pose, f.pose);
        }
        let out = resample(&frames, 30.0);
        assert_eq!(out.len(), 7, "0..=200 ms at 30 fps");
        assert!(out.last().unwrap().stamp_nanos <= 200_000_000);
    }

    #[test]
    fn interpolation_is_geodesic_and_crosses_a_gap() {
        // 0 → 90° over a 200 ms gap (a dropped frame): the midpoint is 45°, constant speed.
        let frames = vec![
            frame(0, 0.0),
            frame(200_000_000, std::f64::consts::FRAC_PI_2),
        ];
        let out = resample(&frames, 20.0);
        assert_eq!(out.len(), 5);
        let mid = &out[2].pose.local_rotations[0];
        assert!((mid.angle() - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
        assert!((out[2].pose.root_translation_m.x - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
    }

    #[test]
    fn a_nominal_rate_with_rounded_stamps_keeps_its_last_frame() {
        // 60 frames stamped at round(k · 1e9 / 30) − a little: 60 out at 30 fps, not 59.
        let frames: Vec<_> = (0..60u64).map(|k| frame(k * 33_333_333, 0.0)).collect();
        let out = resample(&frames, 30.0);
        assert_eq!(out.len(), 60);
        assert_eq!(out.last().unwrap().stamp_nanos, 59 * 33_333_333);
    }

    #[test]
    fn locate_reports_every_case() {
        let frames = vec![frame(10, 0.0), frame(20, 0.0)];
        assert_eq!(locate(&frames, 5, 0), Sample::Before);
        assert_eq!(locate(&frames, 25, 0), Sample::After);
        assert_eq!(locate(&frames, 20, 0), Sample::Exact(1));
        assert_eq!(locate(&frames, 15, 1), Sample::Between(0, 0.5));
        assert_eq!(locate(&[], 15, 0), Sample::After);
    }

    proptest! {
        /// Law: slerp hits both ends, stays unit and finite, and takes the shorter way.
        #[test]
        fn slerp_laws(a in (-3.0..3.0f64, -3.0..3.0f64, -3.0..3.0f64), b in (-3.0..3.0f64, -3.0..3.0f64, -3.0..3.0f64), s in 0.0..1.0f64) {
            let qa = UnitQuaternion::from_scaled_axis(Vector3::new(a.0, a.1, a.2));
            let qb = UnitQuaternion::from_scaled_axis(Vector3::new(b.0, b.1, b.2));
            prop_assert!(rotation_distance(&slerp(&qa, &qb, 0.0), &qa) < 1e-9);
            prop_assert!(rotation_distance(&slerp(&qa, &qb, 1.0), &qb) < 1e-9);
            let q = slerp(&qa, &qb, s);
            prop_assert!((q.norm() - 1.0).abs() < 1e-12);
            let total = rotation_distance(&qa, &qb);
            prop_assert!((rotation_distance(&qa, &q) - s * total).abs() < 1e-7);
        }
    }
}
