//! Random variation 𝒱(A, V): seeded variants of an animation, each a smooth perturbation of the
//! bone rotations that respects the rig's degree-of-freedom classes.
//!
//! For variant `v` of seed `S`, every bone that moves in the clip gets its own perturbation
//! rotation vector, in the bone's rest frame (+Y along the bone) and restricted to the axes its
//! class allows — all three for a 3-D bone, the two swing axes for a 2-D bone (no twist), the
//! hinge axis for a hinge, the vertical for the root; static bones are never touched:
//!
//! `θ(t) = A · ((1 − λ)·c + λ·sin(2π·f·t + φ)·w)`,
//!
//! with `c`, `w` uniform in the unit ball of those axes, `λ ~ U(0, ½)`, `f ~ U(0.1, 0.5)` Hz and
//! `φ ~ U(0, 2π)`: a constant offset (the paper's `δ = U(a_q, b_q)`, here with `a_q = −A`,
//! `b_q = A`) plus a slow drift, smooth in time. Its norm never exceeds `A`, the bound of the
//! bone's class, so each bone of a variant stays within `A` of the original (the perturbed
//! rotation is `q · exp(θ)`; a 2-D bone is then projected back onto its swing, and where that
//! would carry it past the bound, θ is shortened). The draws come from ChaCha8 seeded with `S`, on stream `v`:
//! the same seed gives the same variants on every machine.

use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::skeleton::fk::BonePose;
use crate::skeleton::geom::exp_rotation;
use crate::skeleton::rig::{Dof, Rig};

/// Per-class bounds of the perturbation, degrees (`A` in the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VariationBounds {
    /// 3-D bones (thighs, upper arms, spine, neck, head, hands).
    pub three_d_deg: f64,
    /// 2-D bones (feet, finger bases).
    pub two_d_deg: f64,
    /// Hinges (forearms, calves, phalanges).
    pub hinge_deg: f64,
    /// The root's yaw (turns the whole body; off by default since the path does not turn with it).
    pub root_deg: f64,
}

impl Default for VariationBounds {
    fn default() -> VariationBounds {
        VariationBounds {
            three_d_deg: 6.0,
            two_d_deg: 6.0,
            hinge_deg: 8.0,
            root_deg: 0.0,
        }
    }
}

impl VariationBounds {
    /// The bound of `dof`'s class, degrees.
    #[must_use]
    pub fn for_dof(&self, dof: &Dof) -> f64 {
        match dof {
            Dof::Root => self.root_deg,
            Dof::ThreeD => self.three_d_deg,
            Dof::TwoD => self.two_d_deg,
            Dof::Hinge { .. } => self.hinge_deg,
            Dof::Static => 0.0,
        }
    }
}

/// Variation bounds that do not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum VariationBoundsError {
    /// A bound that is not a number of degrees in [0, 90].
    #[error("`{given}`: a bound is a number of degrees in [0, 90]")]
    Bound {
        /// The text given.
        given: String,
    },
    /// A part that is not `CLASS=DEGREES`.
    #[error("`{part}`: expected CLASS=DEGREES")]
    Syntax {
        /// The part given.
        part: String,
    },
    /// A class that is not one of 3d, 2d, hinge and root.
    #[error("`{class}`: the classes are 3d, 2d, hinge and root")]
    Class {
        /// The class given.
        class: String,
    },
}

impl std::str::FromStr for VariationBounds {
    type Err = VariationBoundsError;

    /// `6` (every class but the root), or `3d=6,2d=6,hinge=8,root=0` (any subset).
    fn from_str(s: &str) -> Result<VariationBounds, VariationBoundsError> {
        let number = |v: &str| match v.trim().parse::<f64>() {
            Ok(x) if x.is_finite() && (0.0..=90.0).contains(&x) => Ok(x),
            _ => Err(VariationBoundsError::Bound {
                given: v.to_string(),
            }),
        };
        if !s.contains('=') {
            let a = number(s)?;
            return Ok(VariationBounds {
                three_d_deg: a,
                two_d_deg: a,
                hinge_deg: a,
                root_deg: 0.0,
            });
        }
        let mut out = VariationBounds::default();
        for part in s.split(',') {
            let (class, value) =
                part.split_once('=')
                    .ok_or_else(|| VariationBoundsError::Syntax {
                        part: part.to_string(),
                    })?;
            let slot = match class.trim() {
                "3d" | "3-D" => &mut out.three_d_deg,
                "2d" | "2-D" => &mut out.two_d_deg,
                "hinge" | "1d" | "1-D" => &mut out.hinge_deg,
                "root" => &mut out.root_deg,
                other => {
                    return Err(VariationBoundsError::Class {
                        class: other.to_string(),
                    });
                }
            };
            *slot = number(value)?;
        }
        Ok(out)
    }
}

impl std::fmt::Display for VariationBounds {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "3d={},2d={},hinge={},root={}",
            self.three_d_deg, self.two_d_deg, self.hinge_deg, self.root_deg
        )
    }
}

/// One bone's perturbation curve.
#[derive(Debug, Clone, Copy)]
struct Wobble {
    /// Constant part, rotation vector in the rig frame, radians.
    offset: Vector3<f64>,
    /// Amplitude of the drift, rotation vector in the rig frame, radians.
    drift: Vector3<f64>,
    angular_frequency: f64,
    phase: f64,
    /// The class's bound, radians.
    bound_rad: f64,
}

impl Wobble {
    fn at(&self, t_s: f64) -> Vector3<f64> {
        self.offset + self.drift * (self.angular_frequency * t_s + self.phase).sin()
    }
}

/// A uniform draw in the unit ball of the first `dims` coordinates.
fn in_ball(rng: &mut ChaCha8Rng, dims: usize) -> [f64; 3] {
    loop {
        let mut p = [0.0; 3];
        for x in &mut p[..dims] {
            *x = rng.random_range(-1.0..1.0);
        }
        if p.iter().map(|x| x * x).sum::<f64>() <= 1.0 {
            return p;
        }
    }
}

/// The class's axes in the rig frame: hinge axis; root vertical; 2-D the two axes across the
/// bone; 3-D all three of the bone's rest frame. Static bones have none.
fn class_axes(bone: &crate::skeleton::rig::Bone) -> Vec<Vector3<f64>> {
    let frame = bone.rest_orientation;
    match bone.dof {
        Dof::Static => Vec::new(),
        Dof::Root => vec![Vector3::z()],
        Dof::Hinge { axis } => vec![axis.into_inner()],
        Dof::TwoD => vec![frame * Vector3::x(), frame * Vector3::z()],
        Dof::ThreeD => vec![
            frame * Vector3::x(),
            frame * Vector3::y(),
            frame * Vector3::z(),
        ],
    }
}

/// The perturbation of every bone for variant `index` of `seed` (`None`: not perturbed).
fn wobbles(
    rig: &Rig,
    moving: &[bool],
    bounds: &VariationBounds,
    seed: u64,
    index: u64,
) -> Vec<Option<Wobble>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(index);
    rig.bones
        .iter()
        .zip(moving)
        .map(|(bone, &moves)| {
            let axes = class_axes(bone);
            // Draw for every bone of the rig, perturbed or not, so which bones a layout drives
            // never shifts another bone's draws.
            let c = in_ball(&mut rng, axes.len());
            let w = in_ball(&mut rng, axes.len());
            let lambda = rng.random_range(0.0..0.5);
            let freq_hz: f64 = rng.random_range(0.1..0.5);
            let phase = rng.random_range(0.0..std::f64::consts::TAU);
            let amplitude = bounds.for_dof(&bone.dof).to_radians();
            if !moves || amplitude <= 0.0 || axes.is_empty() {
                return None;
            }
            let combine =
                |p: [f64; 3]| -> Vector3<f64> { axes.iter().zip(p).map(|(a, x)| a * x).sum() };
            Some(Wobble {
                offset: combine(c) * (amplitude * (1.0 - lambda)),
                drift: combine(w) * (amplitude * lambda),
                angular_frequency: std::f64::consts::TAU * freq_hz,
                phase,
                bound_rad: amplitude,
            })
        })
        .collect()
}

/// Variant `index` (≥ 1; 0 is the animation itself) of `poses`, sampled at `fps` from its first
/// frame, for `seed`. Bones that never change in `poses` are left alone.
#[must_use]
pub fn variant(
    rig: &Rig,
    poses: &[BonePose],
    fps: f64,
    bounds: &VariationBounds,
    seed: u64,
    index: u64,
) -> Vec<BonePose> {
    let moving = crate::skeleton::fk::moving_bones(poses);
    Variation {
        rig,
        moving: &moving,
        fps,
        bounds,
        seed,
    }
    .variant(index, poses, 0)
}

/// The variants of one animation, for an animation made piece by piece.
#[derive(Debug, Clone, Copy)]
pub struct Variation<'a> {
    /// The rig.
    pub rig: &'a Rig,
    /// Per bone: it moves in the animation (the others are left alone).
    pub moving: &'a [bool],
    /// The animation's frame rate.
    pub fps: f64,
    /// Bounds of the perturbations.
    pub bounds: &'a VariationBounds,
    /// The variants' seed.
    pub seed: u64,
}

impl Variation<'_> {
    /// Variant `index` (≥ 1) of the animation's frames `first_frame..first_frame + poses.len()`.
    #[must_use]
    pub fn variant(&self, index: u64, poses: &[BonePose], first_frame: usize) -> Vec<BonePose> {
        let rig = self.rig;
        let wobbles = wobbles(rig, self.moving, self.bounds, self.seed, index);
        poses
            .iter()
            .enumerate()
            .map(|(k, pose)| {
                #[expect(
                    clippy::cast_precision_loss,
                    reason = "frame counts are far below 2^52"
                )]
                let t_s = (first_frame + k) as f64 / self.fps;
                let mut out = pose.clone();
                for ((q, wobble), bone) in
                    out.local_rotations.iter_mut().zip(&wobbles).zip(&rig.bones)
                {
                    if let Some(w) = wobble {
                        *q = perturb(bone, q, w.at(t_s), w.bound_rad);
                    }
                }
                out
            })
            .collect()
    }
}

/// `q · exp(θ)` projected onto the bone's class. The projection (a 2-D bone's swing) can carry
/// the result a little past `|θ|`; then θ is shortened until the result is within `bound_rad`.
fn perturb(
    bone: &crate::skeleton::rig::Bone,
    q: &nalgebra::UnitQuaternion<f64>,
    mut theta: Vector3<f64>,
    bound_rad: f64,
) -> nalgebra::UnitQuaternion<f64> {
    for _ in 0..8 {
        let out = bone.constrain(&(q * exp_rotation(&theta)));
        let d = crate::skeleton::geom::rotation_distance(&out, q);
        if d <= bound_rad {
            return out;
        }
        theta *= 0.999 * bound_rad / d;
    }
    *q
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::geom::rotation_distance;

    /// Every bone of the rig moving in its own class, smoothly, for 3 s at 30 fps.
    fn moving_animation(rig: &Rig) -> Vec<BonePose> {
        crate::dsi::fixture::whole_body(rig, 90, 0.0, |_| 0.0)
    }

    #[test]
    fn variants_are_deterministic_bounded_distinct_and_keep_their_classes() {
        let rig = Rig::standard();
        let poses = moving_animation(&rig);
        let bounds = VariationBounds::default();
        let vs: Vec<Vec<BonePose>> = (1..=10)
            .map(|v| variant(&rig, &poses, 30.0, &bounds, 7, v))
            .collect();
        assert_eq!(
            vs[0],
            variant(&rig, &poses, 30.0, &bounds, 7, 1),
            "same seed, same variant"
        );
        assert_ne!(
            vs[0],
            variant(&rig, &poses, 30.0, &bounds, 8, 1),
            "another seed differs"
        );
        let moving = crate::skeleton::fk::moving_bones(&poses);
        for v in &vs {
            for (p, o) in v.iter().zip(&poses) {
                for (b, bone) in rig.bones.iter().enumerate() {
                    let (q, q0) = (&p.local_rotations[b], &o.local_rotations[b]);
                    assert!((q.norm() - 1.0).abs() < 1e-12);
                    let d = rotation_distance(q, q0).to_degrees();
                    let bound = bounds.for_dof(&bone.dof);
                    assert!(d <= bound + 1e-9, "{}: {d}° > {bound}°", bone.name);
                    assert!(
                        rotation_distance(&bone.constrain(q), q) < 1e-12,
                        "{} left its class",
                        bone.name
                    );
                    if !moving[b] || matches!(bone.dof, Dof::Root | Dof::Static) {
                        assert_eq!(q, q0, "{} must not move", bone.name);
                    }
                }
                assert_eq!(p.root_translation_m, o.root_translation_m);
            }
        }
        // Pairwise different: the mean distance between two variants, over the perturbed bones
        // and all frames, is a good part of the bound.
        let perturbed: Vec<usize> = (0..rig.bones.len())
            .filter(|&b| moving[b] && bounds.for_dof(&rig.bones[b].dof) > 0.0)
            .collect();
        for i in 0..vs.len() {
            for j in i + 1..vs.len() {
                let mut sum = 0.0;
                let mut n = 0.0;
                for (a, b) in vs[i].iter().zip(&vs[j]) {
                    for &bone in &perturbed {
                        sum +=
                            rotation_distance(&a.local_rotations[bone], &b.local_rotations[bone]);
                        n += 1.0;
                    }
                }
                let mean_deg = (sum / n).to_degrees();
                assert!(
                    mean_deg > 2.0,
                    "variants {i} and {j} differ by only {mean_deg}°"
                );
            }
        }
    }

    #[test]
    fn bounds_parse() {
        let b: VariationBounds = "4".parse().unwrap();
        assert_eq!((b.three_d_deg, b.hinge_deg, b.root_deg), (4.0, 4.0, 0.0));
        let b: VariationBounds = "hinge=10,root=2".parse().unwrap();
        assert_eq!((b.three_d_deg, b.hinge_deg, b.root_deg), (6.0, 10.0, 2.0));
        assert_eq!(b.to_string().parse::<VariationBounds>().unwrap(), b);
        for bad in ["-1", "100", "knee=3", "3d=x", "3d"] {
            assert!(bad.parse::<VariationBounds>().is_err(), "{bad}");
        }
    }
}
