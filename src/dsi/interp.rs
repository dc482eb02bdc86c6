//! The interpolator DSI uses inside its unit motions: a local cubic on the rotation group.
//!
//! For the interval between keys `i` and `i + 1`, every bone's keys `i − 1 … i + 2` are carried
//! into the tangent space at key `i` (`v_j = log(q_i⁻¹ · q_j)`, so key `i` sits at the origin), the
//! Lagrange polynomial through them (the paper's `p(x)`, of order 3 and on the real key times, so
//! dropped frames are handled) is evaluated there, and mapped back (`q = q_i · exp(v)`). The
//! result is a unit quaternion by construction, passes through every key exactly, never depends on
//! the keys' signs, and a hinge's keys (coaxial rotations) stay coaxial. The root translation uses
//! the same Lagrange weights.
//!
//! The stencil never reaches across a DSI transition, nor past the clip's ends: there it falls
//! to the points available (three points: a quadratic; two: the geodesic, which is exactly
//! slerp). A transition interval is always interpolated on the geodesic between its two keys —
//! the paper's two-point polynomial `p_[f−1, f]`.

use nalgebra::Vector3;

use crate::skeleton::fk::BonePose;
use crate::skeleton::geom::{exp_rotation, log_rotation};

/// Where an output sample falls: between keys `interval` and `interval + 1`, a fraction `s` ∈
/// [0, 1] of the way in time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Index of the key the interval starts at.
    pub interval: usize,
    /// Fraction of the interval's duration, in [0, 1].
    pub s: f64,
}

/// How the intervals between keys are interpolated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// The local tangent-space cubic described in the module docs (autoact's interpolator).
    Cubic,
    /// The geodesic between the two bracketing keys (slerp; lerp for the translation).
    Slerp,
}

/// Lagrange basis weights of `nodes` at `x` (nodes distinct).
fn lagrange_weights(nodes: &[f64], x: f64, out: &mut [f64]) {
    for (j, &xj) in nodes.iter().enumerate() {
        let mut w = 1.0;
        for (m, &xm) in nodes.iter().enumerate() {
            if m != j {
                w *= (x - xm) / (xj - xm);
            }
        }
        out[j] = w;
    }
}

/// Interpolates `keys` (at `times_s`, strictly increasing) at every sample, in order.
/// `transition[i]` marks interval `i` (keys `i → i + 1`) as a DSI transition; it may be empty
/// when there are none. Samples must be sorted by `(interval, s)`.
///
/// Bones that never change over the keys are copied, not interpolated.
///
/// # Panics
/// When `times_s` and `keys` differ in length or a sample's interval is not followed by a key —
/// programming errors of the caller, never data-dependent.
#[must_use]
pub fn interpolate(
    keys: &[BonePose],
    times_s: &[f64],
    transition: &[bool],
    samples: &[Sample],
    method: Method,
) -> Vec<BonePose> {
    assert_eq!(keys.len(), times_s.len(), "one time per key");
    // Keys whose signs jump (as a `w ≥ 0` convention makes them) are aligned first, so the output
    // is sign-continuous too.
    let aligned;
    let keys = if keys.iter().zip(keys.iter().skip(1)).any(|(a, b)| {
        a.local_rotations
            .iter()
            .zip(&b.local_rotations)
            .any(|(p, q)| p.as_ref().dot(q.as_ref()) < 0.0)
    }) {
        let mut k = keys.to_vec();
        for b in 0..k.first().map_or(0, |p| p.local_rotations.len()) {
            for i in 1..k.len() {
                let previous = k[i - 1].local_rotations[b];
                k[i].local_rotations[b] =
                    crate::skeleton::geom::align_hemisphere(k[i].local_rotations[b], &previous);
            }
        }
        aligned = k;
        &aligned[..]
    } else {
        keys
    };
    let Some(first) = keys.first() else {
        return Vec::new();
    };
    let bones = first.local_rotations.len();
    let varies = crate::skeleton::fk::moving_bones(keys);
    let is_transition = |i: usize| transition.get(i).copied().unwrap_or(false);

    let mut out = Vec::with_capacity(samples.len());
    // Per-interval state: the stencil's key indices, its node times, and every varying bone's
    // tangent vectors at the interval's first key.
    let mut current: Option<usize> = None;
    let mut stencil: Vec<usize> = Vec::with_capacity(4);
    let mut nodes: Vec<f64> = Vec::with_capacity(4);
    let mut tangents: Vec<[Vector3<f64>; 4]> = vec![[Vector3::zeros(); 4]; bones];
    let mut weights = [0.0; 4];
    for sample in samples {
        let i = sample.interval;
        if sample.s <= 0.0 || i + 1 >= keys.len() {
            out.push(keys[i.min(keys.len() - 1)].clone());
            continue;
        }
        if sample.s >= 1.0 {
            out.push(keys[i + 1].clone());
            continue;
        }
        if current != Some(i) {
            current = Some(i);
            stencil.clear();
            let wide = method == Method::Cubic && !is_transition(i);
            if wide && i >= 1 && !is_transition(i - 1) {
                stencil.push(i - 1);
            }
            stencil.push(i);
            stencil.push(i + 1);
            if wide && i + 2 < keys.len() && !is_transition(i + 1) {
                stencil.push(i + 2);
            }
            nodes.clear();
            nodes.extend(stencil.iter().map(|&k| times_s[k]));
            for (b, t) in tangents.iter_mut().enumerate() {
                if !varies[b] {
                    continue;
                }
                let chart_inverse = keys[i].local_rotations[b].inverse();
                for (slot, &k) in t.iter_mut().zip(&stencil) {
                    *slot = if k == i {
                        Vector3::zeros()
                    } else {
                        log_rotation(&(chart_inverse * keys[k].local_rotations[b]))
                    };
                }
            }
        }
        let time = times_s[i] + sample.s * (times_s[i + 1] - times_s[i]);
        let w = &mut weights[..stencil.len()];
        lagrange_weights(&nodes, time, w);
        let mut pose = keys[i].clone();
        pose.root_translation_m = stencil
            .iter()
            .zip(w.iter())
            .map(|(&k, &wk)| keys[k].root_translation_m * wk)
            .sum();
        for (b, q) in pose.local_rotations.iter_mut().enumerate() {
            if !varies[b] {
                continue;
            }
            let v: Vector3<f64> = tangents[b][..w.len()]
                .iter()
                .zip(w.iter())
                .map(|(t, &wk)| t * wk)
                .sum();
            *q *= exp_rotation(&v);
        }
        out.push(pose);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::geom::rotation_distance;
    use nalgebra::UnitQuaternion;
    use proptest::prelude::*;

    fn pose(q: UnitQuaternion<f64>, x: f64) -> BonePose {
        BonePose {
            root_translation_m: Vector3::new(x, 0.0, 0.0),
            local_rotations: vec![q, UnitQuaternion::identity()],
        }
    }

    fn every(n_keys: usize, per_interval: usize) -> Vec<Sample> {
        let mut out = Vec::new();
        for i in 0..n_keys - 1 {
            for k in 0..per_interval {
                #[expect(clippy::cast_precision_loss, reason = "tiny test counts")]
                out.push(Sample {
                    interval: i,
                    s: k as f64 / per_interval as f64,
                });
            }
        }
        out.push(Sample {
            interval: n_keys - 1,
            s: 0.0,
        });
        out
    }

    /// A smooth rotation curve: yaw and pitch as polynomials of time.
    fn curve(t: f64) -> UnitQuaternion<f64> {
        UnitQuaternion::from_euler_angles(0.3 * t * t - 0.2 * t, 0.8 * t, 0.1 + 0.05 * t * t * t)
    }

    #[test]
    fn keys_are_hit_and_signs_do_not_matter() {
        let times: Vec<f64> = (0..6).map(|k| f64::from(k) * 0.2).collect();
        let keys: Vec<BonePose> = times
            .iter()
            .enumerate()
            .map(|(k, &t)| {
                // Every other key with the opposite sign: the same rotations.
                let q = curve(t);
                let q = if k % 2 == 1 {
                    UnitQuaternion::new_unchecked(-q.into_inner())
                } else {
                    q
                };
                pose(q, t)
            })
            .collect();
        let out = interpolate(&keys, &times, &[], &every(6, 4), Method::Cubic);
        assert_eq!(out.len(), 5 * 4 + 1);
        for (k, key) in keys.iter().enumerate() {
            let o = &out[k * 4];
            assert!(rotation_distance(&o.local_rotations[0], &key.local_rotations[0]) < 1e-12);
        }
        // Between keys, close to the true curve, with no detour through a flipped sign.
        for (n, o) in out.iter().enumerate() {
            let t = f64::from(u32::try_from(n).unwrap()) * 0.05;
            let err = rotation_distance(&o.local_rotations[0], &curve(t));
            assert!(err < 2e-3, "sample {n}: {err} rad");
            assert!((o.local_rotations[0].norm() - 1.0).abs() < 1e-12);
            assert!(
                (o.root_translation_m.x - t).abs() < 1e-12,
                "cubic reproduces a line"
            );
        }
    }

    #[test]
    fn cubic_beats_slerp_on_a_smooth_curve() {
        let times: Vec<f64> = (0..8).map(|k| f64::from(k) * 0.25).collect();
        let keys: Vec<BonePose> = times.iter().map(|&t| pose(curve(t), t)).collect();
        let samples = every(8, 5);
        let err = |m: Method| -> f64 {
            interpolate(&keys, &times, &[], &samples, m)
                .iter()
                .enumerate()
                .map(|(n, o)| {
                    let t = f64::from(u32::try_from(n).unwrap()) * 0.05;
                    rotation_distance(&o.local_rotations[0], &curve(t))
                })
                .fold(0.0, f64::max)
        };
        let (cubic, slerp) = (err(Method::Cubic), err(Method::Slerp));
        // The end intervals fall back to quadratics, which bound the worst case.
        assert!(cubic < slerp / 4.0, "cubic {cubic} vs slerp {slerp}");
    }

    #[test]
    fn a_transition_is_geodesic_and_is_not_reached_across() {
        // Keys 0..=3 then a jump; the interval 3 → 4 is a transition.
        let times: Vec<f64> = (0..7).map(f64::from).collect();
        let angles = [0.0, 0.1, 0.2, 0.3, 1.5, 1.6, 1.7];
        let keys: Vec<BonePose> = angles
            .iter()
            .map(|&a| pose(UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a), a))
            .collect();
        let mut transition = vec![false; 6];
        transition[3] = true;
        let out = interpolate(&keys, &times, &transition, &every(7, 4), Method::Cubic);
        // Inside the quiet segments the motion is linear, so no overshoot from the jump.
        for (n, o) in out.iter().enumerate() {
            let a = o.local_rotations[0].angle();
            let i = n / 4;
            let s = f64::from(u32::try_from(n % 4).unwrap()) / 4.0;
            let expected = if i < 6 {
                angles[i] + s * (angles[i + 1] - angles[i])
            } else {
                angles[6]
            };
            assert!(
                (a - expected).abs() < 1e-12,
                "sample {n}: {a} vs {expected}"
            );
        }
    }

    #[test]
    fn a_hinge_stays_a_hinge_and_a_still_bone_is_copied() {
        let axis = Vector3::x_axis();
        let times: Vec<f64> = (0..5).map(f64::from).collect();
        let keys: Vec<BonePose> = [0.1, 0.9, 1.7, 2.6, 3.0]
            .iter()
            .map(|&a| pose(UnitQuaternion::from_axis_angle(&axis, a), 0.0))
            .collect();
        for o in interpolate(&keys, &times, &[], &every(5, 7), Method::Cubic) {
            let v = o.local_rotations[0].as_ref().vector();
            assert!(v.y.abs() < 1e-15 && v.z.abs() < 1e-15);
            assert_eq!(o.local_rotations[1], UnitQuaternion::identity());
        }
    }

    proptest! {
        /// Law: output is unit and finite for any rotations, and interpolating at the keys
        /// returns them.
        #[test]
        fn unit_and_exact_at_keys(
            raw in proptest::collection::vec((-3.0..3.0f64, -3.0..3.0f64, -3.0..3.0f64), 2..9),
            gaps in proptest::collection::vec(0.01..1.0f64, 9),
        ) {
            let mut t = 0.0;
            let mut times = Vec::new();
            let keys: Vec<BonePose> = raw.iter().enumerate().map(|(k, (a, b, c))| {
                t += gaps[k];
                times.push(t);
                pose(UnitQuaternion::from_scaled_axis(Vector3::new(*a, *b, *c)), t)
            }).collect();
            let out = interpolate(&keys, &times, &[], &every(keys.len(), 3), Method::Cubic);
            for o in &out {
                prop_assert!((o.local_rotations[0].norm() - 1.0).abs() < 1e-12);
                prop_assert!(o.root_translation_m.iter().all(|x| x.is_finite()));
            }
            for (k, key) in keys.iter().enumerate() {
                prop_assert!(rotation_distance(&out[k * 3].local_rotations[0], &key.local_rotations[0]) < 1e-12);
            }
        }
    }
}
