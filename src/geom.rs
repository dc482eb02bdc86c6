//! Rotation building blocks for the pose → rotation conversion: shortest arcs, frames from a
//! direction and a reference vector, swing–twist decomposition, hinge projection and quaternion
//! hemisphere continuity.
//!
//! Everything works on directions (never points), in radians, with `nalgebra` unit types. No
//! function here can return NaN: degenerate input (zero vectors, parallel vectors) is reported
//! through `Option` so the caller decides what continuity means.

use nalgebra::{Unit, UnitQuaternion, Vector3};

/// Below this norm a vector is treated as zero (metres for offsets, unitless for directions).
pub const EPS_NORM: f64 = 1e-9;

/// Normalises `v`, or `None` when it is zero, tiny or not finite.
#[must_use]
pub fn direction(v: Vector3<f64>) -> Option<Unit<Vector3<f64>>> {
    let n = v.norm();
    (n.is_finite() && n > EPS_NORM).then(|| Unit::new_unchecked(v / n))
}

/// The shortest rotation taking direction `from` onto direction `to`.
///
/// Antiparallel input has no unique shortest arc; the half-turn is then taken about an axis
/// perpendicular to `from` (the one nearest to global X, else Y), which is still exact.
#[must_use]
pub fn shortest_arc(from: &Unit<Vector3<f64>>, to: &Unit<Vector3<f64>>) -> UnitQuaternion<f64> {
    let d = from.dot(to);
    if d > -1.0 + 1e-12 {
        // q = (1 + d, from × to), normalised: exact and stable away from the antipode.
        let axis = from.cross(to);
        let q = nalgebra::Quaternion::new(1.0 + d, axis.x, axis.y, axis.z);
        UnitQuaternion::from_quaternion(q)
    } else {
        let helper = if from.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let axis = Unit::new_normalize(from.cross(&helper));
        UnitQuaternion::from_axis_angle(&axis, std::f64::consts::PI)
    }
}

/// The component of `v` perpendicular to `axis`, normalised; `None` when `v` is (nearly)
/// parallel to `axis`, i.e. when the perpendicular part is shorter than `sin(min_angle_rad)`
/// times the length of `v`.
#[must_use]
pub fn perpendicular_direction(
    v: &Vector3<f64>,
    axis: &Unit<Vector3<f64>>,
    min_angle_rad: f64,
) -> Option<Unit<Vector3<f64>>> {
    let len = v.norm();
    if !len.is_finite() || len <= EPS_NORM {
        return None;
    }
    let perp = v - axis.into_inner() * axis.dot(v);
    let pn = perp.norm();
    (pn > len * min_angle_rad.sin().max(1e-12)).then(|| Unit::new_unchecked(perp / pn))
}

/// The rotation that maps the rest frame (`rest_dir`, reference `rest_ref_perp`) onto the current
/// frame (`cur_dir`, `cur_ref_perp`): `rest_dir` lands exactly on `cur_dir` (swing), and the
/// reference, projected perpendicular to the bone, lands on the current one (twist, a full
/// turn of range, no folding).
///
/// `rest_ref_perp` must be perpendicular to `rest_dir` and `cur_ref_perp` to `cur_dir`
/// (see [`perpendicular_direction`]).
#[must_use]
pub fn frame_rotation(
    rest_dir: &Unit<Vector3<f64>>,
    rest_ref_perp: &Unit<Vector3<f64>>,
    cur_dir: &Unit<Vector3<f64>>,
    cur_ref_perp: &Unit<Vector3<f64>>,
) -> UnitQuaternion<f64> {
    let swing = shortest_arc(rest_dir, cur_dir);
    let swung_ref = swing * rest_ref_perp.into_inner();
    let angle = signed_angle_about(&swung_ref, &cur_ref_perp.into_inner(), cur_dir);
    UnitQuaternion::from_axis_angle(cur_dir, angle) * swing
}

/// Signed angle (radians, in (−π, π]) from `a` to `b` about `axis`, using only their components
/// perpendicular to `axis`.
#[must_use]
pub fn signed_angle_about(a: &Vector3<f64>, b: &Vector3<f64>, axis: &Unit<Vector3<f64>>) -> f64 {
    let y = axis.dot(&a.cross(b));
    let x = a.dot(b) - axis.dot(a) * axis.dot(b);
    y.atan2(x)
}

/// Splits `q` into `swing · twist`, where `twist` is a rotation about `axis` and `swing` moves
/// `axis` exactly as `q` does. Returns `(swing, twist_angle_rad)`.
#[must_use]
pub fn swing_twist(
    q: &UnitQuaternion<f64>,
    axis: &Unit<Vector3<f64>>,
) -> (UnitQuaternion<f64>, f64) {
    let moved = Unit::new_unchecked(q * axis.into_inner());
    let swing = shortest_arc(axis, &moved);
    let twist = swing.inverse() * q;
    // The twist is (numerically) about `axis`; read its signed angle from the vector part.
    let v = twist.as_ref().vector();
    let angle = 2.0 * axis.dot(&v).atan2(twist.as_ref().w);
    (swing, wrap_angle(angle))
}

/// Wraps an angle into (−π, π].
#[must_use]
pub fn wrap_angle(a: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    let mut r = a.rem_euclid(tau);
    if r > std::f64::consts::PI {
        r -= tau;
    }
    r
}

/// The hinge angle about `hinge_axis` that best reproduces a bone whose rest direction is
/// `rest_dir` (perpendicular to the hinge) and whose current direction is `cur_dir`: the angle of
/// `cur_dir` projected onto the hinge plane. `None` when `cur_dir` lies along the hinge axis.
#[must_use]
pub fn hinge_angle(
    rest_dir: &Unit<Vector3<f64>>,
    cur_dir: &Vector3<f64>,
    hinge_axis: &Unit<Vector3<f64>>,
) -> Option<f64> {
    perpendicular_direction(cur_dir, hinge_axis, 1e-6)
        .map(|p| signed_angle_about(&rest_dir.into_inner(), &p.into_inner(), hinge_axis))
}

/// Flips `q` to the hemisphere of `previous` (so that ⟨q, previous⟩ ≥ 0). The rotation is
/// unchanged; only its sign is, which keeps sequences continuous for interpolation.
#[must_use]
pub fn align_hemisphere(
    q: UnitQuaternion<f64>,
    previous: &UnitQuaternion<f64>,
) -> UnitQuaternion<f64> {
    if q.as_ref().dot(previous.as_ref()) < 0.0 {
        UnitQuaternion::new_unchecked(-q.into_inner())
    } else {
        q
    }
}

/// A rotation about +Z (the autoact up axis) by `yaw_rad`.
#[must_use]
pub fn yaw_rotation(yaw_rad: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw_rad)
}

/// Angle in radians between two rotations (the geodesic distance on SO(3)), sign-independent.
#[must_use]
pub fn rotation_distance(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    // atan2 of the relative rotation's parts stays exact near 0 (acos of a dot product does not:
    // a 1e-16 rounding error there reads as 3e-8 rad).
    let rel = a.inverse() * b;
    2.0 * rel.as_ref().vector().norm().atan2(rel.as_ref().w.abs())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    fn unit(x: f64, y: f64, z: f64) -> Unit<Vector3<f64>> {
        Unit::new_normalize(Vector3::new(x, y, z))
    }

    fn arb_dir() -> impl Strategy<Value = Unit<Vector3<f64>>> {
        (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64)
            .prop_filter("non-zero", |(x, y, z)| x * x + y * y + z * z > 1e-3)
            .prop_map(|(x, y, z)| unit(x, y, z))
    }

    fn arb_rotation() -> impl Strategy<Value = UnitQuaternion<f64>> {
        (-4.0..4.0f64, -4.0..4.0f64, -4.0..4.0f64)
            .prop_map(|(x, y, z)| UnitQuaternion::from_scaled_axis(Vector3::new(x, y, z)))
    }

    #[test]
    fn shortest_arc_handles_identical_and_antipodal() {
        let a = unit(0.0, 0.0, 1.0);
        assert_relative_eq!(shortest_arc(&a, &a).angle(), 0.0, epsilon = 1e-12);
        let b = unit(0.0, 0.0, -1.0);
        let q = shortest_arc(&a, &b);
        assert_relative_eq!(q * a.into_inner(), b.into_inner(), epsilon = 1e-12);
        for v in [unit(1.0, 0.0, 0.0), unit(0.3, -0.2, 0.9)] {
            let w = Unit::new_unchecked(-v.into_inner());
            assert_relative_eq!(
                shortest_arc(&v, &w) * v.into_inner(),
                w.into_inner(),
                epsilon = 1e-12
            );
        }
    }

    #[test]
    fn twist_is_not_folded_at_ninety_degrees() {
        // The reference code folded twist into (−90°, 90°]; a 150° twist must survive.
        let axis = unit(0.0, 0.0, 1.0);
        let q = UnitQuaternion::from_axis_angle(&axis, 150f64.to_radians());
        let (swing, twist) = swing_twist(&q, &axis);
        assert_relative_eq!(swing.angle(), 0.0, epsilon = 1e-12);
        assert_relative_eq!(twist, 150f64.to_radians(), epsilon = 1e-12);
    }

    #[test]
    fn hemisphere_alignment_keeps_rotation() {
        let p = yaw_rotation(179f64.to_radians());
        let q = yaw_rotation(-179f64.to_radians());
        assert!(q.as_ref().dot(p.as_ref()) < 0.0);
        let aligned = align_hemisphere(q, &p);
        assert!(aligned.as_ref().dot(p.as_ref()) >= 0.0);
        assert_relative_eq!(rotation_distance(&aligned, &q), 0.0, epsilon = 1e-12);
        assert_relative_eq!(aligned * Vector3::x(), q * Vector3::x(), epsilon = 1e-12);
    }

    proptest! {
        /// Law: the shortest arc maps `from` exactly onto `to`.
        #[test]
        fn shortest_arc_maps_direction(a in arb_dir(), b in arb_dir()) {
            let q = shortest_arc(&a, &b);
            prop_assert!((q * a.into_inner() - b.into_inner()).norm() < 1e-9);
            prop_assert!((q.norm() - 1.0).abs() < 1e-12);
        }

        /// Law: frame_rotation maps the direction exactly and the perpendicular reference exactly.
        #[test]
        fn frame_rotation_maps_both(a in arb_dir(), r in arb_dir(), q in arb_rotation()) {
            let Some(rp) = perpendicular_direction(&r.into_inner(), &a, 1e-3) else { return Ok(()) };
            let b = Unit::new_unchecked(q * a.into_inner());
            let bp = Unit::new_unchecked(q * rp.into_inner());
            let f = frame_rotation(&a, &rp, &b, &bp);
            prop_assert!(crate::geom::rotation_distance(&f, &q) < 1e-9);
        }

        /// Law: swing · twist = q, the swing moves the axis like q, and the twist is about it.
        #[test]
        fn swing_twist_recomposes(q in arb_rotation(), a in arb_dir()) {
            let (swing, twist) = swing_twist(&q, &a);
            let back = swing * UnitQuaternion::from_axis_angle(&a, twist);
            prop_assert!(rotation_distance(&back, &q) < 1e-9);
            prop_assert!((swing * a.into_inner() - q * a.into_inner()).norm() < 1e-9);
        }

        /// Law: q and −q rotate every vector identically.
        #[test]
        fn q_and_minus_q_agree(q in arb_rotation(), v in arb_dir()) {
            let m = UnitQuaternion::new_unchecked(-q.into_inner());
            prop_assert!((q * v.into_inner() - m * v.into_inner()).norm() < 1e-12);
        }
    }
}
