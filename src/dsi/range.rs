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

/// A rotation this far past the box (per component) counts as inside it, radians.
pub const INSIDE_TOLERANCE_RAD: f64 = 1e-9;

/// Bisection steps of [`SourceRange::pull_inside`]: the way is cut to 2⁻⁴⁰ of its length.
const PULL_ROUNDS: usize = 40;

/// The box of a track's rotations about its mean.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceRange {
    /// The track's mean rotation: the chart's centre.
    pub mean: UnitQuaternion<f64>,
    /// Smallest component of the rotation vectors, radians.
    pub lo: Vector3<f64>,
    /// Largest component of the rotation vectors, radians.
    pub hi: Vector3<f64>,
    /// The track's rotations on the box's six faces (smallest, then largest, per component):
    /// rotations known to be inside, for [`SourceRange::pull_inside`].
    pub anchors: [UnitQuaternion<f64>; 6],
}

impl SourceRange {
    /// The range of `track`, or `None` when it is empty or spreads past [`MAX_SPREAD_RAD`].
    #[must_use]
    pub fn of<'a>(
        track: impl IntoIterator<Item = &'a UnitQuaternion<f64>> + Clone,
    ) -> Option<Self> {
        let mut mean = MeanRotation::default();
        for q in track.clone() {
            mean.push(q);
        }
        let mut range = RangeBox::new(mean.mean()?);
        for q in track {
            range.push(q);
        }
        range.finish()
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

    /// Whether `q` is in the box, to `tolerance_rad` on every component.
    #[must_use]
    pub fn contains(&self, q: &UnitQuaternion<f64>, tolerance_rad: f64) -> bool {
        self.excess(q).max() <= tolerance_rad
    }

    /// `q` brought into the box along the way from `inside`, through `project` (a bone's DoF
    /// class): the furthest `project(slerp(inside, q, t))` that is in the box, found by
    /// bisection on `t`. For when [`SourceRange::clamp`] and `project` disagree (a box and a
    /// curved class can meet at an angle where alternating between them stalls). `inside` is
    /// the nearest to `q` of `previous` (when given) and the range's
    /// [`anchors`](SourceRange::anchors) whose projection is in the box; `None` when there is
    /// none (a source that is not in the class itself can leave the box and the class without
    /// a common rotation near its edges).
    #[must_use]
    pub fn pull_inside(
        &self,
        q: &UnitQuaternion<f64>,
        previous: Option<&UnitQuaternion<f64>>,
        project: impl Fn(&UnitQuaternion<f64>) -> UnitQuaternion<f64>,
    ) -> Option<UnitQuaternion<f64>> {
        let inside = previous
            .into_iter()
            .chain(&self.anchors)
            .filter(|c| self.contains(&project(c), INSIDE_TOLERANCE_RAD))
            .min_by(|a, b| rotation_distance(a, q).total_cmp(&rotation_distance(b, q)))?;
        let inside = align_hemisphere(project(inside), q);
        let at = |t: f64| project(&inside.slerp(q, t));
        let (mut feasible, mut infeasible) = (0.0, 1.0);
        for _ in 0..PULL_ROUNDS {
            let t = 0.5 * (feasible + infeasible);
            if self.contains(&at(t), INSIDE_TOLERANCE_RAD) {
                feasible = t;
            } else {
                infeasible = t;
            }
        }
        Some(align_hemisphere(at(feasible), q))
    }

    /// The box's extent per component, radians.
    #[must_use]
    pub fn extent(&self) -> Vector3<f64> {
        self.hi - self.lo
    }
}

/// The first of the two passes over a track that [`SourceRange::of`] makes, for a track read in
/// pieces: the sum of its sign-continuous quaternions.
#[derive(Debug, Clone, Copy)]
pub struct MeanRotation {
    sum: Quaternion<f64>,
    previous: Option<UnitQuaternion<f64>>,
}

impl Default for MeanRotation {
    fn default() -> MeanRotation {
        MeanRotation {
            sum: Quaternion::from_parts(0.0, Vector3::zeros()),
            previous: None,
        }
    }
}

impl MeanRotation {
    /// Adds the track's next rotation.
    pub fn push(&mut self, q: &UnitQuaternion<f64>) {
        let q = self.previous.map_or(*q, |p| align_hemisphere(*q, &p));
        self.sum += q.into_inner();
        self.previous = Some(q);
    }

    /// The normalised sum, or `None` for an empty track or one whose signs cancel.
    #[must_use]
    pub fn mean(&self) -> Option<UnitQuaternion<f64>> {
        let norm = self.sum.norm();
        (norm > 1e-9 && norm.is_finite()).then(|| UnitQuaternion::new_unchecked(self.sum / norm))
    }
}

/// The second pass of [`SourceRange::of`]: the box of the track's rotation vectors about its
/// mean, for a track read in pieces.
#[derive(Debug, Clone)]
pub struct RangeBox {
    range: SourceRange,
    too_wide: bool,
}

impl RangeBox {
    /// An empty box about `mean` (from [`MeanRotation`]).
    #[must_use]
    pub fn new(mean: UnitQuaternion<f64>) -> RangeBox {
        RangeBox {
            range: SourceRange {
                mean,
                lo: Vector3::repeat(f64::INFINITY),
                hi: Vector3::repeat(f64::NEG_INFINITY),
                anchors: [mean; 6],
            },
            too_wide: false,
        }
    }

    /// Adds the track's next rotation.
    pub fn push(&mut self, q: &UnitQuaternion<f64>) {
        let r = &mut self.range;
        if self.too_wide || rotation_distance(&r.mean, q) > MAX_SPREAD_RAD {
            self.too_wide = true;
            return;
        }
        let v = log_rotation(&(r.mean.inverse() * q));
        for c in 0..3 {
            if v[c] < r.lo[c] {
                r.lo[c] = v[c];
                r.anchors[c] = *q;
            }
            if v[c] > r.hi[c] {
                r.hi[c] = v[c];
                r.anchors[3 + c] = *q;
            }
        }
    }

    /// The range, or `None` when the track spread past [`MAX_SPREAD_RAD`].
    #[must_use]
    pub fn finish(self) -> Option<SourceRange> {
        (!self.too_wide).then_some(self.range)
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

    #[test]
    fn pull_inside_ends_in_the_box_and_the_class_at_the_edge_of_the_way_in() {
        // The class: rotations about the tilted axis a = (1, 1, 0)/√2; the track turns 0…0.2 rad
        // about it.
        let axis = nalgebra::Unit::new_normalize(Vector3::new(1.0, 1.0, 0.0));
        let about = |angle: f64| UnitQuaternion::from_axis_angle(&axis, angle);
        let track: Vec<UnitQuaternion<f64>> = (0..=4).map(|k| about(0.05 * f64::from(k))).collect();
        let range = SourceRange::of(&track).unwrap();
        let project = |q: &UnitQuaternion<f64>| {
            let v = q.as_ref().vector();
            UnitQuaternion::new_normalize(Quaternion::from_parts(
                q.w,
                axis.into_inner() * axis.dot(&v),
            ))
        };
        // Past the end, in the class: pulled back to the end, from an anchor or the previous
        // frame alike.
        let past = about(0.6);
        assert!(!range.contains(&past, INSIDE_TOLERANCE_RAD));
        for previous in [None, Some(about(0.1))] {
            let pulled = range
                .pull_inside(&past, previous.as_ref(), project)
                .unwrap();
            assert!(range.contains(&pulled, INSIDE_TOLERANCE_RAD));
            let angle = rotation_distance(&pulled, &about(0.2));
            assert!(angle < 1e-8, "{previous:?}: {angle}");
        }
        // Off the class, in the middle: pulled in from the previous frame (nearer than any
        // anchor), ending in both.
        let off = about(0.12) * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.3);
        let pulled = range
            .pull_inside(&off, Some(&about(0.11)), project)
            .unwrap();
        assert!(range.contains(&pulled, INSIDE_TOLERANCE_RAD));
        assert!(rotation_distance(&pulled, &project(&pulled)) < 1e-12);
        assert!(rotation_distance(&pulled, &about(0.11)) < 0.02);
    }
}
