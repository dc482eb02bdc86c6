//! Measures of rotation tracks, for comparing interpolators and smoothers: geodesic error, range
//! of motion, peak angular velocity, jerk, sign flips and norm violations; and what DSI must keep
//! of a clip ([`Fidelity`]: duration, peak angular speed, jerk, overshoot past the source range)
//! and how far a one-frame glitch spreads ([`glitch_frames_affected`]). Tracks are raw
//! quaternions (the reference method's output is not unit); every angle is measured on the
//! normalised rotation, so a sign never counts as an error — only as a flip.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use super::range::{Chart, SourceRange};
use super::{DsiError, DsiOptions};
use crate::skeleton::convert::AnimationFrame;
use crate::skeleton::geom::{log_rotation, rotation_distance};
use crate::skeleton::rig::{Dof, Rig};

/// A norm further than this from 1 is a violation.
pub const NORM_TOLERANCE: f64 = 1e-9;

fn unit(q: &Quaternion<f64>) -> UnitQuaternion<f64> {
    let n = q.norm();
    if n > 0.0 && n.is_finite() {
        UnitQuaternion::new_unchecked(q / n)
    } else {
        UnitQuaternion::identity()
    }
}

/// Angle between a true rotation and an estimate (normalised first), radians.
#[must_use]
pub fn geodesic_error(truth: &UnitQuaternion<f64>, estimate: &Quaternion<f64>) -> f64 {
    rotation_distance(truth, &unit(estimate))
}

/// Range of motion of a track: the 95th percentile of the angle between its rotations and their
/// mean (the normalised sum of the sign-continuous quaternions), radians. A percentile, not the
/// maximum, so that a single jittery frame of estimator output does not count as motion.
#[must_use]
pub fn range_of_motion(track: &[Quaternion<f64>]) -> f64 {
    let mut sum = Quaternion::from_parts(0.0, Vector3::zeros());
    let mut previous: Option<Quaternion<f64>> = None;
    for q in track {
        let u = unit(q).into_inner();
        let u = match previous {
            Some(p) if p.dot(&u) < 0.0 => -u,
            _ => u,
        };
        sum += u;
        previous = Some(u);
    }
    let mean = unit(&sum);
    let mut angles: Vec<f64> = track
        .iter()
        .map(|q| rotation_distance(&mean, &unit(q)))
        .collect();
    percentile(&mut angles, 0.95)
}

/// Angular velocity between consecutive samples (`times_s` per sample), radians per second.
fn velocities(track: &[Quaternion<f64>], times_s: &[f64]) -> Vec<Vector3<f64>> {
    track
        .windows(2)
        .zip(times_s.windows(2))
        .map(|(q, t)| log_rotation(&(unit(&q[0]).inverse() * unit(&q[1]))) / (t[1] - t[0]))
        .collect()
}

/// The peak angular speed of a track: the 95th percentile of its speeds between samples (robust
/// to a single jittery frame), radians per second.
#[must_use]
pub fn peak_angular_speed(track: &[Quaternion<f64>], times_s: &[f64]) -> f64 {
    let mut speeds: Vec<f64> = velocities(track, times_s)
        .iter()
        .map(Vector3::norm)
        .collect();
    if speeds.is_empty() {
        return 0.0;
    }
    percentile(&mut speeds, 0.95)
}

/// Mean magnitude of the angular jerk (the third time derivative of the rotation, by finite
/// differences on the real sample times), radians per second³. `None` below four samples.
#[must_use]
pub fn mean_jerk(track: &[Quaternion<f64>], times_s: &[f64]) -> Option<f64> {
    let v = velocities(track, times_s);
    // Velocity k sits at the middle of samples k and k + 1.
    let mid: Vec<f64> = times_s.windows(2).map(|t| 0.5 * (t[0] + t[1])).collect();
    let acc: Vec<Vector3<f64>> = v
        .windows(2)
        .zip(mid.windows(2))
        .map(|(w, t)| (w[1] - w[0]) / (t[1] - t[0]))
        .collect();
    let mid2: Vec<f64> = mid.windows(2).map(|t| 0.5 * (t[0] + t[1])).collect();
    let jerks: Vec<f64> = acc
        .windows(2)
        .zip(mid2.windows(2))
        .map(|(a, t)| ((a[1] - a[0]) / (t[1] - t[0])).norm())
        .collect();
    #[expect(
        clippy::cast_precision_loss,
        reason = "sample counts are far below 2^52"
    )]
    let n = jerks.len() as f64;
    (!jerks.is_empty()).then(|| jerks.iter().sum::<f64>() / n)
}

/// Consecutive quaternions with a negative dot product: places where a component-wise method
/// passes through the wrong hemisphere (and, smoothed or not, shrinks towards zero).
#[must_use]
pub fn sign_flips(track: &[Quaternion<f64>]) -> usize {
    track.windows(2).filter(|w| w[0].dot(&w[1]) < 0.0).count()
}

/// Quaternions whose norm is further than [`NORM_TOLERANCE`] from 1.
#[must_use]
pub fn norm_violations(track: &[Quaternion<f64>]) -> usize {
    track
        .iter()
        .filter(|q| (q.norm() - 1.0).abs() > NORM_TOLERANCE || !q.norm().is_finite())
        .count()
}

/// The value below which `p` (in [0, 1]) of `samples` fall (nearest rank; `samples` is sorted).
#[must_use]
pub fn percentile(samples: &mut [f64], p: f64) -> f64 {
    if samples.is_empty() {
        return f64::NAN;
    }
    samples.sort_by(f64::total_cmp);
    #[expect(
        clippy::cast_precision_loss,
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "an index within a short vector"
    )]
    let rank = ((p * samples.len() as f64).ceil() as usize).clamp(1, samples.len());
    samples[rank - 1]
}

/// A frame differing from the reference by more than this is affected by a glitch, radians (1°).
pub const AFFECTED_TOLERANCE_RAD: f64 = 0.017_453_292_519_943_295;

/// Source components narrower than this are left out of the overshoot, radians (2°).
pub const MIN_RANGE_RAD: f64 = 0.034_906_585_039_886_59;

/// What "DSI keeps the motion" measures on one clip: the output against its input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fidelity {
    /// Output duration ÷ input duration − 1, percent.
    pub duration_change_pct: f64,
    /// Peak angular speed ([`peak_angular_speed`]) kept, output ÷ input, mean over bones whose
    /// input peak is above 0.5 rad/s, percent.
    pub peak_speed_kept_pct: f64,
    /// Mean jerk cut, 1 − output ÷ input (each a mean over bones of [`mean_jerk`]), percent.
    pub jerk_cut_pct: f64,
    /// The largest [`range_overshoot`] over bones, percent of the source range.
    pub max_overshoot_pct: f64,
    /// The bone it is on.
    pub overshoot_bone: Option<usize>,
}

/// How far `output` goes past the range of `source` ([`SourceRange`] in `chart`: the bone's
/// [`Chart::of`]), as a fraction of the source's extent: the largest over components wider than
/// [`MIN_RANGE_RAD`]. `None` when the source has no range (see [`SourceRange::of`]) or no
/// component that wide.
#[must_use]
pub fn range_overshoot(
    chart: Chart,
    source: &[UnitQuaternion<f64>],
    output: &[UnitQuaternion<f64>],
) -> Option<f64> {
    let range = SourceRange::of(chart, source)?;
    let extent = range.extent();
    let excess = output
        .iter()
        .map(|q| range.excess(q))
        .fold(Vector3::zeros(), |a: Vector3<f64>, e| a.sup(&e));
    (0..3)
        .filter(|&c| extent[c] > MIN_RANGE_RAD)
        .map(|c| excess[c] / extent[c])
        .reduce(f64::max)
}

/// Per bone, the track of the non-static bones that move in `frames` (`None` for the others).
fn unit_tracks(rig: &Rig, frames: &[AnimationFrame]) -> Vec<Option<Vec<UnitQuaternion<f64>>>> {
    rig.bones
        .iter()
        .enumerate()
        .map(|(b, bone)| {
            let track: Vec<UnitQuaternion<f64>> =
                frames.iter().map(|f| f.pose.local_rotations[b]).collect();
            let moves = track.iter().any(|q| *q != track[0]);
            (moves && !matches!(bone.dof, Dof::Static)).then_some(track)
        })
        .collect()
}

fn stamps_s(frames: &[AnimationFrame]) -> Vec<f64> {
    let first = frames.first().map_or(0, |f| f.stamp_nanos);
    frames
        .iter()
        .map(|f| crate::skeleton::pose::nanos_to_secs(f.stamp_nanos - first))
        .collect()
}

/// Measures `output` (DSI's animation) against `input` (its keys): see [`Fidelity`].
#[must_use]
pub fn fidelity(rig: &Rig, input: &[AnimationFrame], output: &[AnimationFrame]) -> Fidelity {
    let (t_in, t_out) = (stamps_s(input), stamps_s(output));
    let duration = |t: &[f64]| t.last().copied().unwrap_or(0.0);
    let tracks_in = unit_tracks(rig, input);
    let quaternions = |t: &[UnitQuaternion<f64>]| -> Vec<Quaternion<f64>> {
        t.iter().map(|q| q.into_inner()).collect()
    };
    let (mut peaks, mut jerk_in, mut jerk_out) = (Vec::new(), Vec::new(), Vec::new());
    let (mut max_overshoot, mut overshoot_bone) = (0.0, None);
    for (b, track) in tracks_in.iter().enumerate() {
        let Some(track) = track else { continue };
        let out: Vec<UnitQuaternion<f64>> =
            output.iter().map(|f| f.pose.local_rotations[b]).collect();
        let (q_in, q_out) = (quaternions(track), quaternions(&out));
        let peak = peak_angular_speed(&q_in, &t_in);
        if peak > 0.5 {
            peaks.push(peak_angular_speed(&q_out, &t_out) / peak);
        }
        if let (Some(a), Some(b)) = (mean_jerk(&q_in, &t_in), mean_jerk(&q_out, &t_out)) {
            jerk_in.push(a);
            jerk_out.push(b);
        }
        if let Some(o) = range_overshoot(Chart::of(&rig.bones[b]), track, &out)
            && (overshoot_bone.is_none() || o > max_overshoot)
        {
            max_overshoot = o;
            overshoot_bone = Some(b);
        }
    }
    let mean = |v: &[f64]| {
        #[expect(clippy::cast_precision_loss, reason = "bone counts")]
        let n = v.len().max(1) as f64;
        v.iter().sum::<f64>() / n
    };
    let d_in = duration(&t_in);
    Fidelity {
        duration_change_pct: if d_in > 0.0 {
            100.0 * (duration(&t_out) / d_in - 1.0)
        } else {
            0.0
        },
        peak_speed_kept_pct: 100.0 * mean(&peaks),
        jerk_cut_pct: 100.0 * (1.0 - mean(&jerk_out) / mean(&jerk_in)),
        max_overshoot_pct: 100.0 * max_overshoot,
        overshoot_bone,
    }
}

/// Output frames of `a` and `b` that differ: a rotation further apart than
/// [`AFFECTED_TOLERANCE_RAD`] on any bone, plus every frame one has and the other has not.
#[must_use]
pub fn frames_affected(a: &[AnimationFrame], b: &[AnimationFrame]) -> usize {
    let differ = a
        .iter()
        .zip(b)
        .filter(|(x, y)| {
            x.pose
                .local_rotations
                .iter()
                .zip(&y.pose.local_rotations)
                .any(|(p, q)| rotation_distance(p, q) > AFFECTED_TOLERANCE_RAD)
        })
        .count();
    differ + a.len().abs_diff(b.len())
}

/// Puts a one-frame glitch of `angle_rad` into `keys` at their middle, on the moving bone of the
/// largest weight in `options` (about an axis its DoF class allows), runs DSI on the clean and
/// the glitched keys, and counts the output frames of the animation that differ
/// ([`frames_affected`]). `None` when no bone moves.
///
/// # Errors
/// [`DsiError`] from [`crate::dsi::run`].
pub fn glitch_frames_affected(
    rig: &Rig,
    keys: &[AnimationFrame],
    options: &DsiOptions,
    angle_rad: f64,
) -> Result<Option<usize>, DsiError> {
    let tracks = unit_tracks(rig, keys);
    let Some(bone) = (0..rig.bones.len())
        .filter(|&b| tracks[b].is_some() && !matches!(rig.bones[b].dof, Dof::Root))
        .max_by(|&a, &b| {
            options.weights[a]
                .total_cmp(&options.weights[b])
                .then(b.cmp(&a))
        })
    else {
        return Ok(None);
    };
    let axis = match &rig.bones[bone].dof {
        Dof::Hinge { axis } => *axis,
        Dof::Root => Vector3::z_axis(),
        // Across the bone: a swing, allowed to 2-D and 3-D bones.
        _ => nalgebra::Unit::new_normalize(rig.bones[bone].rest_orientation * Vector3::x()),
    };
    let mut glitched = keys.to_vec();
    let f = keys.len() / 2;
    let q = &mut glitched[f].pose.local_rotations[bone];
    *q = rig.bones[bone].constrain(&(*q * UnitQuaternion::from_axis_angle(&axis, angle_rad)));
    let clean = crate::dsi::run(rig, keys, options)?;
    let glitch = crate::dsi::run(rig, &glitched, options)?;
    Ok(Some(frames_affected(
        &clean.animations[0],
        &glitch.animations[0],
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn yaw(a: f64) -> Quaternion<f64> {
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a).into_inner()
    }

    #[test]
    fn measures_on_known_tracks() {
        let times: Vec<f64> = (0..50).map(|k| f64::from(k) * 0.1).collect();
        // Constant angular speed 0.5 rad/s about z: no jerk, peak 0.5 rad/s; the deviations from
        // the mean are spread evenly up to half the sweep, their 95th percentile just below it.
        let track: Vec<Quaternion<f64>> = times.iter().map(|t| yaw(0.5 * t)).collect();
        assert!((peak_angular_speed(&track, &times) - 0.5).abs() < 1e-9);
        assert!(mean_jerk(&track, &times).unwrap() < 1e-9);
        assert!(
            (range_of_motion(&track) - 0.5 * 2.35).abs() < 1e-9,
            "{}",
            range_of_motion(&track)
        );
        assert_eq!(sign_flips(&track), 0);
        assert_eq!(norm_violations(&track), 0);
        // The same rotations with alternating signs: flips, but the same measures.
        let flipped: Vec<Quaternion<f64>> = track
            .iter()
            .enumerate()
            .map(|(k, q)| if k % 2 == 1 { -q } else { *q })
            .collect();
        assert_eq!(sign_flips(&flipped), 49);
        assert!((range_of_motion(&flipped) - range_of_motion(&track)).abs() < 1e-9);
        assert!(geodesic_error(&UnitQuaternion::new_unchecked(track[3]), &flipped[3]) < 1e-12);
        // A shrunken quaternion is a norm violation, but the same rotation.
        assert_eq!(norm_violations(&[track[0] * 0.9]), 1);
        // Jerk: a cubic angle a(t) = t³ has constant third derivative 6.
        let cubic: Vec<Quaternion<f64>> = times.iter().map(|t| yaw(t * t * t / 10.0)).collect();
        let j = mean_jerk(&cubic, &times).unwrap();
        assert!((j - 0.6).abs() < 1e-6, "{j}");
        assert!(mean_jerk(&cubic[..3], &times[..3]).is_none());
    }

    #[test]
    fn percentiles() {
        let mut v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&mut v, 0.95), 95.0);
        assert_eq!(percentile(&mut v, 1.0), 100.0);
        assert!(percentile(&mut [], 0.5).is_nan());
    }
}
