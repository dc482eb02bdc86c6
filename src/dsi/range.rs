//! A bone's range of motion in its own parametrisation, so smoothing can be kept inside it and
//! overshoot measured.
//!
//! The parametrisation ([`Chart`]): for most bones, the rotation vector `v = log(m⁻¹ · q)` of
//! each rotation about the track's mean rotation `m` (the normalised sum of its sign-continuous
//! quaternions), in the bone's parent frame. A hinge's vectors lie on its axis, the root's on the
//! vertical: the box `[lo, hi]` of their components moves a rotation only along the axes its
//! class allows. A 2-D bone's swing-only rotations are not flat in that chart (`m⁻¹ · q` has a
//! twist), so a box there cuts across its class and clamping to it leaves the class: for 2-D
//! bones the chart is the swing (its rotation vector, two components across the bone) and the
//! twist angle about the bone's rest direction, in which the class is the plane `twist = 0` and a
//! box clamp never leaves it. A track that reaches further than [`MAX_SPREAD_RAD`] from its mean
//! (a root turning through a full circle) has no range: the chart would wrap.

use nalgebra::{Quaternion, Unit, UnitQuaternion, Vector3};

use crate::skeleton::geom::{
    align_hemisphere, exp_rotation, log_rotation, rotation_distance, swing_twist,
};
use crate::skeleton::rig::{Bone, Dof};

/// Tracks reaching further than this from their mean rotation (or, for a 2-D bone, swinging or
/// twisting further than this) have no range (0.8 π).
pub const MAX_SPREAD_RAD: f64 = 0.8 * std::f64::consts::PI;

/// A rotation this far past the box (per component) counts as inside it, radians.
pub const INSIDE_TOLERANCE_RAD: f64 = 1e-9;

/// Bisection steps of [`SourceRange::pull_inside`]: the way is cut to 2⁻⁴⁰ of its length.
const PULL_ROUNDS: usize = 40;

/// How a range reads a rotation as three numbers (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Chart {
    /// The rotation vector about the track's mean rotation.
    AboutMean,
    /// A 2-D bone's swing and twist about its rest direction `axis`: the swing's rotation
    /// vector on `across` (two unit vectors square to `axis` and to each other), then the
    /// twist angle, radians.
    SwingTwist {
        /// The bone's rest direction in its parent's frame.
        axis: Unit<Vector3<f64>>,
        /// Two directions across the bone.
        across: [Vector3<f64>; 2],
    },
}

impl Chart {
    /// The chart of `bone`'s rotations: [`Chart::SwingTwist`] for a 2-D bone, else
    /// [`Chart::AboutMean`].
    #[must_use]
    pub fn of(bone: &Bone) -> Chart {
        match bone.dof {
            Dof::TwoD => Chart::swing_twist(bone.rest_direction()),
            _ => Chart::AboutMean,
        }
    }

    /// The swing–twist chart about `axis`.
    #[must_use]
    pub fn swing_twist(axis: Unit<Vector3<f64>>) -> Chart {
        let helper = if axis.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let first = axis.cross(&helper).normalize();
        Chart::SwingTwist {
            axis,
            across: [first, axis.cross(&first)],
        }
    }

    /// `q`'s coordinates in this chart about `mean`.
    fn coordinates(&self, mean: &UnitQuaternion<f64>, q: &UnitQuaternion<f64>) -> Vector3<f64> {
        match self {
            Chart::AboutMean => log_rotation(&(mean.inverse() * q)),
            Chart::SwingTwist { axis, across } => {
                let (swing, twist) = swing_twist(q, axis);
                let s = log_rotation(&swing);
                Vector3::new(s.dot(&across[0]), s.dot(&across[1]), twist)
            }
        }
    }

    /// The rotation at coordinates `c` about `mean`, in `like`'s hemisphere.
    fn rotation(
        &self,
        mean: &UnitQuaternion<f64>,
        c: &Vector3<f64>,
        like: &UnitQuaternion<f64>,
    ) -> UnitQuaternion<f64> {
        let q = match self {
            Chart::AboutMean => mean * exp_rotation(c),
            Chart::SwingTwist { axis, across } => {
                exp_rotation(&(across[0] * c.x + across[1] * c.y))
                    * UnitQuaternion::from_axis_angle(axis, c.z)
            }
        };
        align_hemisphere(q, like)
    }
}

/// The box of a track's rotations in its chart ([`Chart`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SourceRange {
    /// How the range reads rotations.
    pub chart: Chart,
    /// The track's mean rotation: the [`Chart::AboutMean`] chart's centre.
    pub mean: UnitQuaternion<f64>,
    /// Smallest coordinates in the chart, radians.
    pub lo: Vector3<f64>,
    /// Largest coordinates in the chart, radians.
    pub hi: Vector3<f64>,
    /// The track's rotations on the box's six faces (smallest, then largest, per component):
    /// rotations known to be inside, for [`SourceRange::pull_inside`].
    pub anchors: [UnitQuaternion<f64>; 6],
}

impl SourceRange {
    /// The range of `track` in `chart`, or `None` when it is empty or spreads past
    /// [`MAX_SPREAD_RAD`].
    #[must_use]
    pub fn of<'a>(
        chart: Chart,
        track: impl IntoIterator<Item = &'a UnitQuaternion<f64>> + Clone,
    ) -> Option<Self> {
        let mut mean = MeanRotation::default();
        for q in track.clone() {
            mean.push(q);
        }
        let mut range = RangeBox::new(chart, mean.mean()?);
        for q in track {
            range.push(q);
        }
        range.finish()
    }

    /// `q` in the range's chart.
    #[must_use]
    pub fn coordinates(&self, q: &UnitQuaternion<f64>) -> Vector3<f64> {
        self.chart.coordinates(&self.mean, q)
    }

    /// The rotation at coordinates `c` of the range's chart, in `like`'s hemisphere.
    #[must_use]
    pub fn rotation(&self, c: &Vector3<f64>, like: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
        self.chart.rotation(&self.mean, c, like)
    }

    /// `q` moved into the box (unchanged when inside), in `q`'s hemisphere.
    #[must_use]
    pub fn clamp(&self, q: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
        let v = self.coordinates(q);
        let c = v.sup(&self.lo).inf(&self.hi);
        if c == v {
            return *q;
        }
        self.rotation(&c, q)
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

/// The second pass of [`SourceRange::of`]: the box of the track's coordinates, for a track read
/// in pieces.
#[derive(Debug, Clone)]
pub struct RangeBox {
    range: SourceRange,
    too_wide: bool,
}

impl RangeBox {
    /// An empty box in `chart` about `mean` (from [`MeanRotation`]).
    #[must_use]
    pub fn new(chart: Chart, mean: UnitQuaternion<f64>) -> RangeBox {
        RangeBox {
            range: SourceRange {
                chart,
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
        if self.too_wide {
            return;
        }
        // About the mean, |v| is the angle from it; in the swing–twist chart it bounds the
        // swing's and the twist's angles, where that chart wraps.
        let v = r.coordinates(q);
        if v.norm() > MAX_SPREAD_RAD {
            self.too_wide = true;
            return;
        }
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

    /// The range, or `None` when the track spread past [`MAX_SPREAD_RAD`]. In the swing–twist
    /// chart the twist's interval always holds 0, the bone's class: a solved track need not be
    /// in its bone's class (a foot aimed at a toe landmark turns about the line to the toe, not
    /// about the bone, so it carries a little twist about the bone), but every output is.
    #[must_use]
    pub fn finish(mut self) -> Option<SourceRange> {
        let r = &mut self.range;
        if matches!(r.chart, Chart::SwingTwist { .. }) && r.lo.z <= r.hi.z {
            r.lo.z = r.lo.z.min(0.0);
            r.hi.z = r.hi.z.max(0.0);
        }
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
        let range = SourceRange::of(Chart::AboutMean, &track).unwrap();
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
        assert!(SourceRange::of(Chart::AboutMean, &turn).is_none());
    }

    /// The swing–twist chart reads a rotation back exactly, keeps the swing-only class flat (a
    /// clamp of a swing stays a swing), and its twist interval holds 0 even when the track's
    /// rotations all twist a little.
    #[test]
    fn a_two_d_range_clamps_swings_to_swings() {
        let axis = nalgebra::Unit::new_normalize(Vector3::new(0.9, -0.3, 0.2));
        let chart = Chart::swing_twist(axis);
        let Chart::SwingTwist { across, .. } = chart else {
            unreachable!()
        };
        let swing = |x: f64, y: f64| exp_rotation(&(across[0] * x + across[1] * y));
        let twisted =
            |x: f64, y: f64, t: f64| swing(x, y) * UnitQuaternion::from_axis_angle(&axis, t);
        let q = twisted(0.4, -0.7, 0.3);
        let c = SourceRange::of(chart, &[q]).unwrap().coordinates(&q);
        assert!((c - Vector3::new(0.4, -0.7, 0.3)).norm() < 1e-12, "{c}");
        let track: Vec<UnitQuaternion<f64>> = (0..=10)
            .map(|k| {
                let s = 0.05 * f64::from(k);
                twisted(0.3 + s, 0.2 - s, 0.02 + 0.007 * f64::from(k))
            })
            .collect();
        let range = SourceRange::of(chart, &track).unwrap();
        assert_eq!(range.lo.z, 0.0);
        assert!((range.hi.z - 0.09).abs() < 1e-12);
        // Past the swing's end: clamped onto it, still a swing (no twist about the bone).
        let clamped = range.clamp(&swing(1.2, 0.1));
        let (_, twist) = swing_twist(&clamped, &axis);
        assert!(twist.abs() < 1e-12, "{twist}");
        assert!(rotation_distance(&clamped, &swing(0.8, 0.1)) < 1e-12);
        assert!(range.contains(&clamped, INSIDE_TOLERANCE_RAD));
    }

    #[test]
    fn pull_inside_ends_in_the_box_and_the_class_at_the_edge_of_the_way_in() {
        // The class: rotations about the tilted axis a = (1, 1, 0)/√2; the track turns 0…0.2 rad
        // about it.
        let axis = nalgebra::Unit::new_normalize(Vector3::new(1.0, 1.0, 0.0));
        let about = |angle: f64| UnitQuaternion::from_axis_angle(&axis, angle);
        let track: Vec<UnitQuaternion<f64>> = (0..=4).map(|k| about(0.05 * f64::from(k))).collect();
        let range = SourceRange::of(Chart::AboutMean, &track).unwrap();
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
