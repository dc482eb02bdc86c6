//! A bone's range of motion in its own parametrisation, so smoothing can be kept inside it and
//! overshoot measured.
//!
//! The parametrisation: the rotation vector `v = log(m⁻¹ · q)` of each rotation about the track's
//! mean rotation `m` (the normalised sum of its sign-continuous quaternions), in the bone's parent
//! frame. A hinge's vectors lie on its axis, the root's on the vertical, a 2-D bone's have no
//! twist: the range is the box `[lo, hi]` of their components, and clamping a rotation to it moves
//! it only along the axes its class allows. A track that reaches further than
//! [`MAX_SPREAD_RAD`] from its mean (a root turning through a full circle) has no range: the
//! chart would wrap.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use crate::skeleton::geom::{align_hemisphere, exp_rotation, log_rotation, rotation_distance};

/// Tracks reaching further than this from their mean rotation have no range (0.8 π).
pub const MAX_SPREAD_RAD: f64 = 0.8 * std::f64::consts::PI;

/// The box of a track's rotations about its mean.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceRange {
    /// The track's mean rotation: the chart's centre.
    pub mean: UnitQuaternion<f64>,
    /// Smallest component of the rotation vectors, radians.
    pub lo: Vector3<f64>,
    /// Largest component of the rotation vectors, radians.
    pub hi: Vector3<f64>,
}

impl SourceRange {
    /// The range of `track`, or `None` when it is empty or spreads past [`MAX_SPREAD_RAD`].
    #[must_use]
    pub fn of<'a>(
        track: impl IntoIterator<Item = &'a UnitQuaternion<f64>> + Clone,
    ) -> Option<Self> {
        let mut sum = Quaternion::from_parts(0.0, Vector3::zeros());
        let mut previous: Option<UnitQuaternion<f64>> = None;
        for q in track.clone() {
            let q = previous.map_or(*q, |p| align_hemisphere(*q, &p));
            sum += q.into_inner();
            previous = Some(q);
        }
        let norm = sum.norm();
        if !(norm > 1e-9 && norm.is_finite()) {
            return None;
        }
        let mean = UnitQuaternion::new_unchecked(sum / norm);
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for q in track {
            if rotation_distance(&mean, q) > MAX_SPREAD_RAD {
                return None;
            }
            let v = log_rotation(&(mean.inverse() * q));
            lo = lo.inf(&v);
            hi = hi.sup(&v);
        }
        Some(SourceRange { mean, lo, hi })
    }

    /// `q` in the range's chart: its rotation vector about the mean.
    #[must_use]
    pub fn coordinates(&self, q: &UnitQuaternion<f64>) -> Vector3<f64> {
        log_rotation(&(self.mean.inverse() * q))
    }

    /// `q` moved into the box (unchanged when inside), in `q`'s hemisphere.
    #[must_use]
    pub fn clamp(&self, q: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
        let v = self.coordinates(q);
        let c = v.sup(&self.lo).inf(&self.hi);
        if c == v {
            return *q;
        }
        align_hemisphere(self.mean * exp_rotation(&c), q)
    }

    /// How far `q` is outside the box, per component (0 inside), radians.
    #[must_use]
    pub fn excess(&self, q: &UnitQuaternion<f64>) -> Vector3<f64> {
        let v = self.coordinates(q);
        (v - self.hi).sup(&Vector3::zeros()) + (self.lo - v).sup(&Vector3::zeros())
    }

    /// The box's extent per component, radians.
    #[must_use]
    pub fn extent(&self) -> Vector3<f64> {
        self.hi - self.lo
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hinge_range_clamps_along_its_axis() {
        let track: Vec<UnitQuaternion<f64>> = (0..=10)
            .map(|k| UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.1 * f64::from(k)))
            .collect();
        let range = SourceRange::of(&track).unwrap();
        assert!((range.extent().x - 1.0).abs() < 1e-9);
        assert!(range.extent().y.abs() < 1e-12);
        let past = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 1.3);
        let clamped = range.clamp(&past);
        assert!(rotation_distance(&clamped, &track[10]) < 1e-9);
        assert!((range.excess(&past).x - 0.3).abs() < 1e-9);
        assert_eq!(range.clamp(&track[4]), track[4]);
        // A full turn has no range.
        let turn: Vec<UnitQuaternion<f64>> = (0..40)
            .map(|k| UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.2 * f64::from(k)))
            .collect();
        assert!(SourceRange::of(&turn).is_none());
    }
}
