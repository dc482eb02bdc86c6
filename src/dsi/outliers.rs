//! Single-frame outliers, rejected before DSI plans, interpolates and smooths: a Hampel filter on
//! each bone's rotation track.
//!
//! For every key `f` of a moving bone, the *residual* `r_f` is the angle between `q_f` and the
//! geodesic between its neighbours `f − 1` and `f + 1` at its time (at the clip's ends, the two
//! inner neighbours extrapolated on their geodesic). Key `f` is an outlier when all three hold:
//!
//! - its residual is far outside the residuals around it: `r_f > median + 6 · 1.4826 · MAD` of
//!   the residuals of keys `f − 7 … f + 7` (a robust z-score above 6, Hampel's test);
//! - its neighbours agree with each other better than with it: `r_f > ∠(q_(f−1), q_(f+1))`
//!   (so a cut between takes — a step, where the neighbours disagree — is left to DSI's
//!   transitions, and a sudden stop is not mistaken for a spike);
//! - it is off by more than [`MIN_OUTLIER_RAD`], so clean motion capture keeps its own keys.
//!
//! Outliers are replaced by the tangent-space Lagrange polynomial through their neighbours
//! `f − 2, f − 1, f + 1, f + 2` (on their real times; at the ends, the geodesic extrapolation),
//! interior keys first and the largest first, each re-tested against the
//! keys already repaired, so a glitch never drags its neighbours along. Hinges stay hinges and
//! the root stays a yaw: the prediction is a combination of the bone's own rotations about the
//! same axes (and `dsi::run` puts every rotation back in its class at the end anyway).

use nalgebra::{UnitQuaternion, Vector3};

use crate::skeleton::fk::BonePose;
use crate::skeleton::geom::{align_hemisphere, exp_rotation, log_rotation, rotation_distance};
use crate::skeleton::rig::{Dof, Rig};

/// A key off by less than this from its neighbours' prediction is never an outlier, radians (1°).
pub const MIN_OUTLIER_RAD: f64 = 0.017_453_292_519_943_295;

/// Robust z-score above which a residual is an outlier.
const Z_OUTLIER: f64 = 6.0;

/// How many times further from its prediction than its neighbours are from each other.
const NEIGHBOUR_AGREEMENT: f64 = 1.0;

/// Half-width of the window of residuals a key is compared with, keys.
const WINDOW: usize = 7;

/// Replaces single-frame outliers of the bones of `keys` (at `times_s`) that move in the clip
/// (`moving`, per bone) by the prediction from their neighbours; returns how many (bone, key)
/// pairs were replaced.
pub fn reject(rig: &Rig, keys: &mut [BonePose], times_s: &[f64], moving: &[bool]) -> usize {
    if keys.len() < 4 || times_s.len() != keys.len() {
        return 0;
    }
    let mut replaced = 0;
    let mut track: Vec<UnitQuaternion<f64>> = Vec::with_capacity(keys.len());
    for (b, bone) in rig.bones.iter().enumerate() {
        if !moving.get(b).copied().unwrap_or(false) || matches!(bone.dof, Dof::Static) {
            continue;
        }
        track.clear();
        for p in keys.iter() {
            let q = p.local_rotations[b];
            track.push(track.last().map_or(q, |prev| align_hemisphere(q, prev)));
        }
        let fixed = reject_track(&mut track, times_s);
        if fixed > 0 {
            replaced += fixed;
            for (p, q) in keys.iter_mut().zip(&track) {
                p.local_rotations[b] = *q;
            }
        }
    }
    replaced
}

/// [`reject`] on one sign-continuous track; returns the number of keys replaced.
pub fn reject_track(track: &mut [UnitQuaternion<f64>], times_s: &[f64]) -> usize {
    let n = track.len();
    if n < 4 {
        return 0;
    }
    let residuals: Vec<f64> = (0..n)
        .map(|f| rotation_distance(&track[f], &expect(track, times_s, f, side_of(f, n))))
        .collect();
    // Each key's bound, from the residuals before any replacement: computed only for the keys
    // that pass the cheaper tests (most keys of clean motion do not), the ends' up front since
    // theirs are measured on the track, which the replacements change.
    let bound = |track: &[UnitQuaternion<f64>], f: usize| {
        // Compared with residuals of the same kind: the ends are extrapolated, so their
        // neighbours' residuals are taken as if each were an end too.
        let side = side_of(f, n);
        let lo = f.saturating_sub(if side == Side::FromLeft {
            2 * WINDOW
        } else {
            WINDOW
        });
        let hi = (f
            + 1
            + if side == Side::FromRight {
                2 * WINDOW
            } else {
                WINDOW
            })
        .min(n);
        let mut window: Vec<f64> = (lo..hi)
            .filter(|&j| j != f)
            .filter_map(|j| match side {
                Side::Both => Some(residuals[j]),
                Side::FromRight => (j + 2 < n)
                    .then(|| rotation_distance(&track[j], &expect(track, times_s, j, side))),
                Side::FromLeft => {
                    (j >= 2).then(|| rotation_distance(&track[j], &expect(track, times_s, j, side)))
                }
            })
            .collect();
        let median = median_of(&mut window);
        let mut deviations: Vec<f64> = window.iter().map(|r| (r - median).abs()).collect();
        let mad = median_of(&mut deviations);
        median + Z_OUTLIER * 1.4826 * mad
    };
    let end_bounds = [bound(track, 0), bound(track, n - 1)];
    // Interior keys first, the largest first; then the ends, which are extrapolated from keys
    // that must be repaired before.
    let mut order: Vec<usize> = (1..n - 1)
        .filter(|&f| residuals[f] > MIN_OUTLIER_RAD)
        .collect();
    order.sort_by(|&a, &b| residuals[b].total_cmp(&residuals[a]));
    order.extend([0, n - 1]);
    let mut replaced = 0;
    for f in order {
        let side = side_of(f, n);
        let r = rotation_distance(&track[f], &expect(track, times_s, f, side));
        let spread = match (f.checked_sub(1), track.get(f + 1)) {
            (Some(p), Some(next)) => rotation_distance(&track[p], next),
            // At an end: the step between the two inner neighbours.
            (None, _) => rotation_distance(&track[1], &track[2]),
            (Some(_), None) => rotation_distance(&track[n - 3], &track[n - 2]),
        };
        if r > MIN_OUTLIER_RAD && r > NEIGHBOUR_AGREEMENT * spread && {
            let b = match f {
                0 => end_bounds[0],
                f if f + 1 == n => end_bounds[1],
                f => bound(track, f),
            };
            r > b
        } {
            let prediction = predict(track, times_s, f, side);
            track[f] = align_hemisphere(prediction, &track[f]);
            replaced += 1;
        }
    }
    // Keep the track sign-continuous after the replacements.
    for f in 1..n {
        track[f] = align_hemisphere(track[f], &track[f - 1]);
    }
    replaced
}

/// How much of the tracks' frame-to-frame variation is noise: per bone, the median angle
/// between each interior key and the Lagrange polynomial through its neighbours `f ± 1, f ± 2`
/// ([`predict`], which follows smooth motion of any speed to fourth order), divided by
/// `√1.944` (that polynomial's noise gain), radians; 0 for bones that do not move or tracks of
/// fewer than five keys. Clean motion capture has almost none; estimator output degrees.
///
/// The clip is read in pieces ([`NoiseLevels::push`]), and of a clip longer than
/// [`MAX_NOISE_SAMPLES`] interior keys only every `k`-th key counts (`k` the smallest stride that
/// keeps within it), so the memory does not grow with the clip.
#[derive(Debug, Clone)]
pub struct NoiseLevels {
    keys: usize,
    stride: usize,
    residuals_rad: Vec<Vec<f64>>,
}

/// At most this many residuals per bone make a noise level (an hour of 30 fps is 108,000 keys):
/// the median of 65,536 evenly spread samples is within a percent of the whole clip's.
pub const MAX_NOISE_SAMPLES: usize = 1 << 16;

impl NoiseLevels {
    /// Ready for a clip of `keys` keys of a rig of `bones` bones.
    #[must_use]
    pub fn new(bones: usize, keys: usize) -> NoiseLevels {
        NoiseLevels {
            keys,
            stride: keys.saturating_sub(4).div_ceil(MAX_NOISE_SAMPLES).max(1),
            residuals_rad: vec![Vec::new(); bones],
        }
    }

    /// Takes the residuals of the clip's keys `core` (indices in the clip) from `keys`, the
    /// clip's keys `offset..offset + keys.len()`, which must hold two keys on each side of
    /// `core` wherever the clip has them.
    pub fn push(
        &mut self,
        rig: &Rig,
        moving: &[bool],
        keys: &[BonePose],
        times_s: &[f64],
        offset: usize,
        core: std::ops::Range<usize>,
    ) {
        let n = self.keys;
        let wanted: Vec<usize> = core
            .filter(|&f| f >= 2 && f + 2 < n && (f - 2) % self.stride == 0)
            .collect();
        if wanted.is_empty() {
            return;
        }
        let mut track: Vec<UnitQuaternion<f64>> = Vec::with_capacity(keys.len());
        for (b, bone) in rig.bones.iter().enumerate() {
            if !moving.get(b).copied().unwrap_or(false) || matches!(bone.dof, Dof::Static) {
                continue;
            }
            track.clear();
            for p in keys {
                let q = p.local_rotations[b];
                track.push(track.last().map_or(q, |prev| align_hemisphere(q, prev)));
            }
            self.residuals_rad[b].extend(wanted.iter().map(|&f| {
                let local = f - offset;
                rotation_distance(&track[local], &predict(&track, times_s, local, Side::Both))
            }));
        }
    }

    /// The noise level of every bone, radians.
    #[must_use]
    pub fn levels(self) -> Vec<f64> {
        self.residuals_rad
            .into_iter()
            .map(|mut r| median_of(&mut r) / 1.944_f64.sqrt())
            .collect()
    }
}

/// Which neighbours predict a key.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    /// Two on each side where there are (an interior key).
    Both,
    /// The two after it, extrapolated (the first key).
    FromRight,
    /// The two before it, extrapolated (the last key).
    FromLeft,
}

fn side_of(f: usize, n: usize) -> Side {
    if f == 0 {
        Side::FromRight
    } else if f + 1 == n {
        Side::FromLeft
    } else {
        Side::Both
    }
}

/// What key `f` is tested against: the geodesic between its two neighbours at its time (at an
/// end, the two inner neighbours extrapolated). Only the nearest keys, so a step two keys away
/// never makes a key look like an outlier.
fn expect(
    track: &[UnitQuaternion<f64>],
    times_s: &[f64],
    f: usize,
    side: Side,
) -> UnitQuaternion<f64> {
    if side != Side::Both {
        return predict(track, times_s, f, side);
    }
    let (a, b) = (f - 1, f + 1);
    let s = (times_s[f] - times_s[a]) / (times_s[b] - times_s[a]);
    track[a] * exp_rotation(&(log_rotation(&(track[a].inverse() * track[b])) * s))
}

/// The rotation key `f` is replaced by: the Lagrange polynomial through its neighbours (see the
/// module docs).
fn predict(
    track: &[UnitQuaternion<f64>],
    times_s: &[f64],
    f: usize,
    side: Side,
) -> UnitQuaternion<f64> {
    let n = track.len();
    if side != Side::Both {
        let (a, b) = if side == Side::FromRight {
            (f + 2, f + 1)
        } else {
            (f - 2, f - 1)
        };
        let step = log_rotation(&(track[a].inverse() * track[b]));
        let ratio = (times_s[f] - times_s[b]) / (times_s[b] - times_s[a]);
        return track[b] * exp_rotation(&(step * ratio));
    }
    let mut stencil = [0; 4];
    let mut count = 0;
    for j in [f.checked_sub(2), f.checked_sub(1), Some(f + 1), Some(f + 2)]
        .into_iter()
        .flatten()
        .filter(|&j| j < n)
    {
        stencil[count] = j;
        count += 1;
    }
    let neighbours = &stencil[..count];
    // The chart at the nearest earlier neighbour.
    let chart = track[f - 1];
    let inverse = chart.inverse();
    let mut v = Vector3::zeros();
    for &j in neighbours {
        let mut w = 1.0;
        for &m in neighbours {
            if m != j {
                w *= (times_s[f] - times_s[m]) / (times_s[j] - times_s[m]);
            }
        }
        v += log_rotation(&(inverse * track[j])) * w;
    }
    chart * exp_rotation(&v)
}

fn median_of(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn yaw(a: f64) -> UnitQuaternion<f64> {
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a)
    }

    fn times(n: usize) -> Vec<f64> {
        (0..n)
            .map(|k| f64::from(u32::try_from(k).unwrap()) / 30.0)
            .collect()
    }

    #[test]
    fn a_spike_is_replaced_and_nothing_else_moves() {
        let t = times(60);
        let clean: Vec<UnitQuaternion<f64>> =
            t.iter().map(|t| yaw(1.2 * (3.0 * t).sin())).collect();
        for f in [0, 1, 30, 58, 59] {
            let mut track = clean.clone();
            track[f] *= UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.5);
            assert_eq!(reject_track(&mut track, &t), 1, "spike at {f}");
            for (k, (a, b)) in track.iter().zip(&clean).enumerate() {
                let tolerance = if k == f { 0.01 } else { 1e-12 };
                assert!(rotation_distance(a, b) < tolerance, "{f}: key {k} moved");
            }
        }
    }

    #[test]
    fn a_cut_and_fast_smooth_motion_are_left_alone() {
        let t = times(60);
        // A step of 40° between takes.
        let mut track: Vec<UnitQuaternion<f64>> = (0..60)
            .map(|k| yaw(if k < 30 { 0.0 } else { 0.7 }))
            .collect();
        let before = track.clone();
        assert_eq!(reject_track(&mut track, &t), 0);
        assert_eq!(track, before);
        // A fast swing: 10 rad/s peaks.
        let mut track: Vec<UnitQuaternion<f64>> =
            t.iter().map(|t| yaw(1.0 * (10.0 * t).sin())).collect();
        assert_eq!(reject_track(&mut track, &t), 0);
    }

    proptest! {
        /// Law: on a smooth motion of any speed and phase, one spike of any size above the
        /// threshold at any key is the only key replaced.
        #[test]
        fn one_spike_one_key(f in 0usize..80, spike in 0.2..2.5f64, w in 0.5..8.0f64, phase in 0.0..6.3f64) {
            // Larger than two steps of the motion: then the neighbours agree better than it.
            let size = spike + 2.0 * 0.9 * w / 30.0;
            let t = times(80);
            let clean: Vec<UnitQuaternion<f64>> = t
                .iter()
                .map(|t| UnitQuaternion::from_euler_angles(0.8 * (w * t + phase).sin(), 0.3 * (0.7 * w * t).cos(), 0.2))
                .collect();
            let mut track = clean.clone();
            track[f] *= UnitQuaternion::from_axis_angle(&Vector3::y_axis(), size);
            prop_assert!(reject_track(&mut track, &t) >= 1);
            for (k, (a, b)) in track.iter().zip(&clean).enumerate() {
                if k != f {
                    prop_assert!(rotation_distance(a, b) < 1e-12, "key {} moved", k);
                }
            }
            prop_assert!(rotation_distance(&track[f], &clean[f]) < size / 4.0);
        }
    }
}
