//! Resampling an animation to an explicit frame rate from its own stamps, on the rotation group:
//! slerp between the bracketing frames' local rotations (their hemispheres are already
//! continuous), lerp between root translations. Output stamps are `first + k·(1 s / fps)` up to
//! the last input stamp, never extrapolated, and gaps in the input (dropped frames) are bridged by
//! the same interpolation instead of being assumed away. The clip keeps its end: when the next
//! output time falls less than half a frame past the last input, the last input is emitted at its
//! own stamp, so a clip of `N` frames resampled at its own nominal rate has `N` frames even when
//! its stamps drift from the nominal clock (a BVH frame time of `0.008333` s is 120.005 fps: the
//! 140th frame is 46 µs before `139 / 120` s), and the output has `round(duration · fps) + 1`
//! frames, the last one the last input.

use std::cmp::Ordering;

use nalgebra::UnitQuaternion;

use crate::skeleton::convert::AnimationFrame;
use crate::skeleton::fk::BonePose;
use crate::skeleton::pose::stamp_nanos_at;

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
    let b = crate::skeleton::geom::align_hemisphere(*b, a);
    let q = a.try_slerp(&b, s, 1e-12).unwrap_or_else(|| a.nlerp(&b, s));
    // nalgebra's slerp is unit only to ~1e-9 between nearly equal rotations (its angle comes
    // from an acos); every written quaternion is unit to rounding.
    UnitQuaternion::new_normalize(q.into_inner())
}

/// Resamples a stream of frames at a fixed rate as they arrive: push each input frame (strictly
/// increasing stamps); every output frame whose time is reached is handed to the callback, in
/// order. Memory is two poses, whatever the length.
#[derive(Debug, Clone)]
pub struct Resampler {
    fps: f64,
    first: Option<u64>,
    /// Index of the next output frame.
    k: usize,
    previous: Option<(u64, BonePose)>,
    scratch: Option<BonePose>,
    /// Half an output frame, nanoseconds (see the module docs).
    end_tolerance: u64,
}

impl Resampler {
    /// A resampler to `fps` frames per second (positive).
    #[must_use]
    pub fn new(fps: f64) -> Resampler {
        // Stamps written at a nominal rate carry rounding (1/30 s is not a whole number of ns, a
        // BVH frame time has 7 digits): the clip's end is kept to the nearest output frame.
        Resampler {
            fps,
            first: None,
            k: 0,
            previous: None,
            scratch: None,
            end_tolerance: stamp_nanos_at(1, fps * 2.0),
        }
    }

    fn next_time(&self) -> Option<u64> {
        self.first.map(|f| f + stamp_nanos_at(self.k, self.fps))
    }

    /// Takes the next input frame and emits the output frames up to its time.
    pub fn push(&mut self, stamp: u64, pose: &BonePose, emit: &mut impl FnMut(u64, &BonePose)) {
        if self.first.is_none() {
            self.first = Some(stamp);
        }
        while let Some(t) = self.next_time() {
            match t.cmp(&stamp) {
                Ordering::Equal => emit(t, pose),
                Ordering::Less => {
                    let Some((t0, p0)) = &self.previous else {
                        break;
                    };
                    #[expect(
                        clippy::cast_precision_loss,
                        reason = "stamp differences within a clip are far below 2^52 ns"
                    )]
                    let s = (t - t0) as f64 / (stamp - t0) as f64;
                    let scratch = self.scratch.get_or_insert_with(|| pose.clone());
                    interpolate_into(p0, pose, s, scratch);
                    emit(t, scratch);
                }
                Ordering::Greater => break,
            }
            self.k += 1;
        }
        match &mut self.previous {
            Some((t, p)) => {
                *t = stamp;
                p.root_translation_m = pose.root_translation_m;
                p.local_rotations.clone_from(&pose.local_rotations);
            }
            None => self.previous = Some((stamp, pose.clone())),
        }
    }

    /// Ends the stream: when the next output time is less than half a frame past the last
    /// input, the last input is emitted at its own stamp (the clip keeps its last frame).
    pub fn finish(mut self, emit: &mut impl FnMut(u64, &BonePose)) {
        if let (Some(t), Some((last, pose))) = (self.next_time(), self.previous.take())
            && t > last
            && t - last < self.end_tolerance
        {
            emit(last, &pose);
        }
    }
}

/// [`interpolate`] into an existing pose (no allocation).
pub fn interpolate_into(a: &BonePose, b: &BonePose, s: f64, out: &mut BonePose) {
    out.root_translation_m = a.root_translation_m.lerp(&b.root_translation_m, s);
    for ((o, qa), qb) in out
        .local_rotations
        .iter_mut()
        .zip(&a.local_rotations)
        .zip(&b.local_rotations)
    {
        *o = slerp(qa, qb, s);
    }
}

/// Resamples `frames` (strictly increasing stamps) at `fps` (see [`Resampler`]).
#[must_use]
pub fn resample(frames: &[AnimationFrame], fps: f64) -> Vec<AnimationFrame> {
    let mut out = Vec::new();
    let mut r = Resampler::new(fps);
    let mut emit = |stamp_nanos: u64, pose: &BonePose| {
        out.push(AnimationFrame {
            stamp_nanos,
            pose: pose.clone(),
        });
    };
    for f in frames {
        r.push(f.stamp_nanos, &f.pose, &mut emit);
    }
    r.finish(&mut emit);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::geom::rotation_distance;
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
    fn slerp_between_nearly_equal_rotations_is_unit() {
        let a = UnitQuaternion::from_euler_angles(0.3, 0.2, 0.1);
        for angle in [3.7e-4, 1e-5, 1e-7, 1e-9, 1e-11] {
            let b = UnitQuaternion::from_euler_angles(0.3 + angle, 0.2, 0.1);
            for s in [0.1, 0.37, 0.5, 0.83] {
                assert!(
                    (slerp(&a, &b, s).norm() - 1.0).abs() <= 1e-15,
                    "{angle} {s}"
                );
            }
        }
    }

    #[test]
    fn a_bvh_frame_time_that_drifts_keeps_every_frame() {
        // BVH `Frame Time: 0.008333` (120.005 fps): 140 frames in, 140 out at 120 fps, the last
        // one the last input at its own stamp.
        let frames: Vec<_> = (0..140u64)
            .map(|k| frame(k * 8_333_000, f64::from(u32::try_from(k).unwrap()) * 0.01))
            .collect();
        let out = resample(&frames, 120.0);
        assert_eq!(out.len(), 140);
        assert_eq!(out.last().unwrap().stamp_nanos, 139 * 8_333_000);
        assert_eq!(out.last().unwrap().pose, frames[139].pose);
        // Slower than nominal (stamps run late): the grid reaches the last input first.
        let frames: Vec<_> = (0..1901u64).map(|k| frame(k * 33_334_000, 0.0)).collect();
        assert_eq!(resample(&frames, 30.0).len(), 1901);
    }

    proptest! {
        /// Law: N frames at a rate within 0.1 % of the output's come out as N frames, the last
        /// one the last input; at any rate the output has round(duration · fps) + 1 frames.
        #[test]
        fn n_in_n_out_at_the_source_rate(n in 2u64..400, drift in -1e-3..1e-3f64, fps in 10.0..240.0f64) {
            #[expect(clippy::cast_possible_truncation, clippy::cast_sign_loss, reason = "test")]
            let period = (1e9 / fps * (1.0 + drift)).round() as u64;
            let frames: Vec<_> = (0..n).map(|k| frame(k * period, 0.0)).collect();
            let out = resample(&frames, fps);
            #[expect(clippy::cast_precision_loss, reason = "test")]
            let frames_at_rate = ((n - 1) as f64 * period as f64 * 1e-9 * fps).round() as u64 + 1;
            prop_assert_eq!(out.len() as u64, frames_at_rate);
            #[expect(clippy::cast_precision_loss, reason = "test")]
            if drift.abs() * (n as f64) < 0.4 {
                prop_assert_eq!(out.len() as u64, n);
                // Stamps that run early end on the last input itself; stamps that run late end on
                // the output clock, less than half a frame before it.
                let end = out.last().unwrap().stamp_nanos;
                if drift <= 0.0 {
                    prop_assert_eq!(end, (n - 1) * period);
                }
                prop_assert!(end + stamp_nanos_at(1, 2.0 * fps) > (n - 1) * period);
            }
            let other = resample(&frames, fps * 0.73);
            prop_assert!(other.last().unwrap().stamp_nanos <= (n - 1) * period);
        }

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
