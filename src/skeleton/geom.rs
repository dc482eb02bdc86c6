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
#[inline]
#[must_use]
pub fn direction(v: Vector3<f64>) -> Option<Unit<Vector3<f64>>> {
    let n = v.norm();
    (n.is_finite() && n > EPS_NORM).then(|| Unit::new_unchecked(v / n))
}

/// The shortest rotation taking direction `from` onto direction `to`.
///
/// Antiparallel input has no unique shortest arc; the half-turn is then taken about an axis
/// perpendicular to `from` (the one nearest to global X, else Y), which is still exact.
#[inline]
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

/// The shortest rotation taking unit `from` onto the direction of `to`, which need not be
/// normalised (one square root fewer than normalising first). `None` when `to` is zero.
#[inline]
#[must_use]
pub fn shortest_arc_to(
    from: &Unit<Vector3<f64>>,
    to: &Vector3<f64>,
) -> Option<UnitQuaternion<f64>> {
    let len = to.norm();
    if !(len.is_finite() && len > EPS_NORM) {
        return None;
    }
    let w = len + from.dot(to);
    if w > len * 1e-12 {
        // (|to| + from·to, from × to) is the half-angle quaternion scaled by |to|.
        let axis = from.cross(to);
        Some(UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            w, axis.x, axis.y, axis.z,
        )))
    } else {
        Some(shortest_arc(from, &Unit::new_unchecked(to / len)))
    }
}

/// The component of `v` perpendicular to `axis`, normalised; `None` when `v` is (nearly)
/// parallel to `axis`, i.e. when the perpendicular part is shorter than `min_angle_rad` (a small
/// angle, taken as its own sine) times the length of `v`.
#[inline]
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
    // sin θ ≈ θ below the angles this is called with (≤ a few degrees); no trig in the hot path.
    (pn > len * min_angle_rad.max(1e-12)).then(|| Unit::new_unchecked(perp / pn))
}

/// The rotation that maps the rest frame (`rest_dir`, reference `rest_ref_perp`) onto the current
/// frame (`cur_dir`, `cur_ref_perp`): `rest_dir` lands exactly on `cur_dir` (swing), and the
/// reference, projected perpendicular to the bone, lands on the current one (twist, a full
/// turn of range, no folding).
///
/// `rest_ref_perp` must be perpendicular to `rest_dir` and `cur_ref_perp` to `cur_dir`
/// (see [`perpendicular_direction`]).
#[inline]
#[must_use]
pub fn frame_rotation(
    rest_dir: &Unit<Vector3<f64>>,
    rest_ref_perp: &Unit<Vector3<f64>>,
    cur_dir: &Unit<Vector3<f64>>,
    cur_ref_perp: &Unit<Vector3<f64>>,
) -> UnitQuaternion<f64> {
    let swing = shortest_arc(rest_dir, cur_dir);
    // The swing carries the rest reference perpendicular to the current direction, so the twist
    // is the rotation about the bone between the two references.
    let swung_ref = Unit::new_normalize(swing * rest_ref_perp.into_inner());
    rotation_about(&swung_ref, cur_ref_perp, cur_dir) * swing
}

/// The rotation about `axis` taking `from` onto `to`, both unit and perpendicular to `axis`:
/// built from the half-angle identity, with no trigonometry. A half turn is taken about `axis`.
#[inline]
#[must_use]
pub fn rotation_about(
    from: &Unit<Vector3<f64>>,
    to: &Unit<Vector3<f64>>,
    axis: &Unit<Vector3<f64>>,
) -> UnitQuaternion<f64> {
    let d = from.dot(to);
    if d > -1.0 + 1e-12 {
        // The cross product is along ±axis; projecting onto it keeps the result exactly about it.
        let s = axis.dot(&from.cross(to));
        let q = nalgebra::Quaternion::from_parts(1.0 + d, axis.into_inner() * s);
        UnitQuaternion::from_quaternion(q)
    } else {
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::from_parts(0.0, axis.into_inner()))
    }
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

/// How much a reference whose defining sine is `sin` (e.g. the sine of a limb's bend) is
/// trusted, in [0, 1]: a C¹ smoothstep of `sin / full_sin`, 0 at 0 and exactly 1 from `full_sin`
/// on. Non-finite input gives 0.
#[inline]
#[must_use]
pub fn reference_weight(sin: f64, full_sin: f64) -> f64 {
    if !(sin.is_finite() && full_sin.is_finite() && full_sin > 0.0) {
        return 0.0;
    }
    let x = (sin.abs() / full_sin).min(1.0);
    x * x * (3.0 - 2.0 * x)
}

/// A twist step (one frame) up to this is followed exactly, radians (10°).
pub const TWIST_FOLLOW_RAD: f64 = 10.0 * std::f64::consts::PI / 180.0;

/// A twist step from this on is taken as the reference's noise, radians (45°): only
/// [`TWIST_RECOVERY`] of it is followed.
pub const TWIST_DOUBT_RAD: f64 = 45.0 * std::f64::consts::PI / 180.0;

/// The share of a doubted twist step that is taken anyway, so that a reference that stays away
/// (a real turn made while the reference was unreadable) is reached in a few dozen frames.
pub const TWIST_RECOVERY: f64 = 0.05;

/// The twist a bone takes in one frame when its reference asks for `delta_rad` (wrapped into
/// (−π, π]) relative to its previous twist carried along the bone: all of it up to
/// [`TWIST_FOLLOW_RAD`]; then a share falling smoothly (C¹ smoothstep) to [`TWIST_RECOVERY`] at
/// [`TWIST_DOUBT_RAD`] and beyond. A twist reference is a short, noisy segment (a thumb tip
/// seen by a depth camera) whose side of the bone can flip from one frame to the next; a limb
/// cannot spin half a turn in a frame, so such a flip moves the twist by at most
/// `TWIST_RECOVERY · π` (9°), and no step exceeds 16.4°, while any slower turn is followed
/// exactly. Continuous and odd in `delta_rad`.
#[inline]
#[must_use]
pub fn twist_step(delta_rad: f64) -> f64 {
    let x = ((delta_rad.abs() - TWIST_FOLLOW_RAD) / (TWIST_DOUBT_RAD - TWIST_FOLLOW_RAD))
        .clamp(0.0, 1.0);
    let doubt = x * x * (3.0 - 2.0 * x);
    delta_rad * (1.0 - (1.0 - TWIST_RECOVERY) * doubt)
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

/// The rotation about `hinge_axis` that best reproduces a bone whose rest direction is
/// `rest_dir` (perpendicular to the hinge) and whose current direction is `cur_dir`: it takes
/// `rest_dir` onto `cur_dir` projected onto the hinge plane. `None` when `cur_dir` lies along the
/// hinge axis.
#[inline]
#[must_use]
pub fn hinge_rotation(
    rest_dir: &Unit<Vector3<f64>>,
    cur_dir: &Vector3<f64>,
    hinge_axis: &Unit<Vector3<f64>>,
) -> Option<UnitQuaternion<f64>> {
    // Project onto the hinge plane; `cur_dir` need not be normalised.
    let p = cur_dir - hinge_axis.into_inner() * hinge_axis.dot(cur_dir);
    let p_len = p.norm();
    if !(p_len.is_finite() && p_len > 1e-6 * cur_dir.norm().max(EPS_NORM)) {
        return None;
    }
    let w = p_len + rest_dir.dot(&p);
    if w > p_len * 1e-12 {
        // Half-angle quaternion scaled by |p|, its axis projected onto the hinge so the result is
        // exactly a hinge rotation.
        let s = hinge_axis.dot(&rest_dir.cross(&p));
        Some(UnitQuaternion::from_quaternion(
            nalgebra::Quaternion::from_parts(w, hinge_axis.into_inner() * s),
        ))
    } else {
        Some(UnitQuaternion::from_quaternion(
            nalgebra::Quaternion::from_parts(0.0, hinge_axis.into_inner()),
        ))
    }
}

/// Flips `q` to the hemisphere of `previous` (so that ⟨q, previous⟩ ≥ 0). The rotation is
/// unchanged; only its sign is, which keeps sequences continuous for interpolation.
#[inline]
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

/// The rotation vector (axis · angle, radians, angle in [0, π]) of `q`: the logarithm map at the
/// identity, on the shorter side whatever the quaternion's sign. Exact near the identity (the
/// angle comes from `atan2`, not `acos`).
#[inline]
#[must_use]
pub fn log_rotation(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let q = q.as_ref();
    let (w, v) = if q.w < 0.0 {
        (-q.w, -q.vector())
    } else {
        (q.w, q.vector().into_owned())
    };
    let s = v.norm();
    if s < 1e-8 {
        // θ/s → 2/w as s → 0 (first-order exact: θ = 2·atan2(s, w) = 2s/w + O(s³)).
        return v * (2.0 / w);
    }
    v * (2.0 * s.atan2(w) / s)
}

/// The rotation by the rotation vector `r` (axis · angle, radians): the exponential map at the
/// identity, inverse of [`log_rotation`]. Unit to rounding for any finite `r`.
#[inline]
#[must_use]
pub fn exp_rotation(r: &Vector3<f64>) -> UnitQuaternion<f64> {
    let theta = r.norm();
    let half = 0.5 * theta;
    // sin(θ/2)/θ, with its series below 1e-4 rad (error < 1e-17).
    let k = if theta < 1e-4 {
        0.5 - theta * theta / 48.0
    } else {
        half.sin() / theta
    };
    UnitQuaternion::new_unchecked(nalgebra::Quaternion::from_parts(half.cos(), r * k))
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
    fn hinge_rotation_keeps_full_range_and_its_axis() {
        let axis = unit(-1.0, 0.0, 0.0);
        let rest = unit(0.0, 0.0, -1.0);
        for deg in [1.0f64, 45.0, 90.0, 150.0, 179.9, -30.0] {
            let truth = UnitQuaternion::from_axis_angle(&axis, deg.to_radians());
            let q = hinge_rotation(&rest, &(truth * rest.into_inner()), &axis).unwrap();
            assert!(rotation_distance(&q, &truth) < 1e-9, "{deg}°");
        }
        // Straight along the hinge axis: no hinge angle can be read.
        assert!(hinge_rotation(&rest, &axis.into_inner(), &axis).is_none());
        // A half turn is taken about the hinge itself.
        let q = hinge_rotation(&rest, &-rest.into_inner(), &axis).unwrap();
        assert!((q * Vector3::x() - Vector3::x()).norm() < 1e-12);
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
    fn reference_weight_rises_smoothly_from_zero_to_exactly_one() {
        let full = 20f64.to_radians().sin();
        assert_eq!(reference_weight(0.0, full), 0.0);
        assert_eq!(reference_weight(full, full), 1.0);
        assert_eq!(reference_weight(0.9, full), 1.0);
        assert_eq!(reference_weight(f64::NAN, full), 0.0);
        assert_eq!(reference_weight(0.1, 0.0), 0.0);
        let mut last = 0.0;
        for k in 1..=1000 {
            let w = reference_weight(f64::from(k) * full / 1000.0, full);
            // Monotone, and no step larger than the smoothstep's slope (1.5 / 1000) allows.
            assert!(w >= last && w - last <= 1.5e-3 + 1e-12, "{k}: {last} → {w}");
            last = w;
        }
    }

    #[test]
    fn twist_steps_follow_slow_turns_and_never_jump() {
        assert_eq!(twist_step(0.0), 0.0);
        assert_eq!(twist_step(0.1), 0.1);
        assert_eq!(twist_step(-TWIST_FOLLOW_RAD), -TWIST_FOLLOW_RAD);
        let pi = std::f64::consts::PI;
        assert!((twist_step(pi) - TWIST_RECOVERY * pi).abs() < 1e-12);
        let mut last = 0.0;
        for k in 0..=3600 {
            let d = f64::from(k) * pi / 3600.0;
            let s = twist_step(d);
            assert_relative_eq!(twist_step(-d), -s, epsilon = 1e-15);
            // Never more than 16.4°, and continuous (no step between neighbours past the slope's
            // bound).
            assert!(
                s <= 16.4f64.to_radians(),
                "{}° → {}°",
                d.to_degrees(),
                s.to_degrees()
            );
            assert!((s - last).abs() <= 2.0 * pi / 3600.0, "{k}");
            last = s;
        }
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
            prop_assert!(crate::skeleton::geom::rotation_distance(&f, &q) < 1e-9);
        }

        /// Law: swing · twist = q, the swing moves the axis like q, and the twist is about it.
        #[test]
        fn swing_twist_recomposes(q in arb_rotation(), a in arb_dir()) {
            let (swing, twist) = swing_twist(&q, &a);
            let back = swing * UnitQuaternion::from_axis_angle(&a, twist);
            prop_assert!(rotation_distance(&back, &q) < 1e-9);
            prop_assert!((swing * a.into_inner() - q * a.into_inner()).norm() < 1e-9);
        }

        /// Law: the shortest arc to an unnormalised target equals the one to its direction.
        #[test]
        fn shortest_arc_to_ignores_length(a in arb_dir(), b in arb_dir(), len in 1e-3..1e3f64) {
            let q = shortest_arc_to(&a, &(b.into_inner() * len)).unwrap();
            prop_assert!(rotation_distance(&q, &shortest_arc(&a, &b)) < 1e-9);
        }

        /// Law: exp ∘ log is the identity on rotations, log lands in the ball of radius π, and
        /// exp(log q) is unit.
        #[test]
        fn log_exp_round_trip(q in arb_rotation(), tiny in -1e-7..1e-7f64) {
            let r = log_rotation(&q);
            prop_assert!(r.norm() <= std::f64::consts::PI + 1e-12);
            let back = exp_rotation(&r);
            prop_assert!(rotation_distance(&back, &q) < 1e-12);
            prop_assert!((back.norm() - 1.0).abs() < 1e-15);
            let m = UnitQuaternion::new_unchecked(-q.into_inner());
            prop_assert!((log_rotation(&m) - r).norm() < 1e-12);
            let small = Vector3::new(tiny, -0.5 * tiny, 2.0 * tiny);
            prop_assert!((log_rotation(&exp_rotation(&small)) - small).norm() < 1e-20);
        }

        /// Law: q and −q rotate every vector identically.
        #[test]
        fn q_and_minus_q_agree(q in arb_rotation(), v in arb_dir()) {
            let m = UnitQuaternion::new_unchecked(-q.into_inner());
            prop_assert!((q * v.into_inner() - m * v.into_inner()).norm() < 1e-12);
        }
    }
}
