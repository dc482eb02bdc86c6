//! Body proportions: a [`Character`] scales bone lengths without touching rotations, so one
//! animation plays on a child, an adult or a long-armed avatar with the same bone directions.
//!
//! A bone's scale multiplies every offset measured from its head: its children's heads and the
//! landmarks that ride on it. The root's scale is derived from the legs so that, at rest, the
//! soles touch the ground plane `z = 0` whatever the proportions.
//!
//! The offsets themselves are stored (`head_offset_m`, `landmark_offset_m`), so that a fitted
//! subject can also carry its own fixed geometry where the rig is rigid: where its shoulders sit
//! on its clavicles, where its hip joints sit on its pelvis (see
//! [`crate::skeleton::convert::fit_character`]). Offsets of moving bones always stay along the rig's rest
//! directions, so rotations keep their meaning on every body.

use nalgebra::{Point3, Vector3};

use crate::skeleton::rig::{Measure, ROOT, Rig};

/// Proportions relative to the rig's default adult (1.0 = unchanged).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Proportions {
    /// Overall height, metres (the default adult is [`Character::STANDARD_HEIGHT_M`]).
    pub height_m: f64,
    /// Extra factor on upper arms, forearms and hands (on top of the height).
    pub arm_scale: f64,
    /// Extra factor on thighs, calves and feet.
    pub leg_scale: f64,
    /// Extra factor on the spine, neck and clavicles.
    pub torso_scale: f64,
}

impl Default for Proportions {
    fn default() -> Self {
        Proportions {
            height_m: Character::STANDARD_HEIGHT_M,
            arm_scale: 1.0,
            leg_scale: 1.0,
            torso_scale: 1.0,
        }
    }
}

/// One body: per-bone length scales and the rest offsets they give.
#[derive(Debug, Clone, PartialEq)]
pub struct Character {
    /// Scale of each bone of the rig, in rig order (root first).
    pub bone_scale: Vec<f64>,
    /// Per bone: its head's rest offset from its parent's head, metres (zero for the root).
    pub head_offset_m: Vec<Vector3<f64>>,
    /// Per landmark: its rest offset from the head of the bone it rides on, metres.
    pub landmark_offset_m: Vec<Vector3<f64>>,
}

impl Character {
    /// Height of the rig's default adult, metres (ground to the top of the head).
    pub const STANDARD_HEIGHT_M: f64 = 1.75;

    /// The rig's default adult.
    #[must_use]
    pub fn standard(rig: &Rig) -> Character {
        Character::from_scales(rig, vec![1.0; rig.bones.len()])
    }

    /// A character from per-bone scales (the root's is derived from the legs).
    #[must_use]
    pub fn from_scales(rig: &Rig, bone_scale: Vec<f64>) -> Character {
        let mut c = Character {
            bone_scale,
            head_offset_m: Vec::new(),
            landmark_offset_m: Vec::new(),
        };
        c.derive_root_scale(rig);
        c.head_offset_m = rig
            .bones
            .iter()
            .map(|b| {
                b.parent.map_or_else(Vector3::zeros, |p| {
                    (b.head_rest_m - rig.bones[p].head_rest_m) * c.bone_scale[p]
                })
            })
            .collect();
        c.landmark_offset_m = rig
            .landmarks
            .iter()
            .map(|l| (l.rest_m - rig.bones[l.bone].head_rest_m) * c.bone_scale[l.bone])
            .collect();
        c
    }

    /// A character with the given proportions.
    #[must_use]
    pub fn with_proportions(rig: &Rig, p: Proportions) -> Character {
        let base = p.height_m / Self::STANDARD_HEIGHT_M;
        let bone_scale = rig
            .bones
            .iter()
            .map(|b| {
                let n = b.name.as_str();
                let part = if ["thigh", "calf", "foot"].iter().any(|s| n.ends_with(s)) {
                    p.leg_scale
                } else if n.contains("arm") || n.contains("hand") {
                    p.arm_scale
                } else if n.starts_with("spine") || n == "neck" || n.ends_with("clavicle") {
                    p.torso_scale
                } else {
                    1.0
                };
                base * part
            })
            .collect();
        Character::from_scales(rig, bone_scale)
    }

    /// Fits per-bone scales to a subject from measured segments: `(measure, length in metres)`
    /// pairs. Bones no measure covers take the median ratio of all measured ones.
    #[must_use]
    pub fn fitted(rig: &Rig, observed: &[(&Measure, f64)]) -> Character {
        let mut per_bone: Vec<Vec<f64>> = vec![Vec::new(); rig.bones.len()];
        let mut all = Vec::new();
        for &(m, obs) in observed {
            if !(obs.is_finite() && obs > 0.0) {
                continue;
            }
            let rest = (rig.rest_point(&m.to) - rig.rest_point(&m.from)).norm();
            if rest <= 1e-6 {
                continue;
            }
            let ratio = obs / rest;
            all.push(ratio);
            for &b in &m.bones {
                per_bone[b].push(ratio);
            }
        }
        let global = median(&mut all).unwrap_or(1.0);
        let bone_scale = per_bone
            .iter_mut()
            .map(|v| median(v).unwrap_or(global))
            .collect();
        Character::from_scales(rig, bone_scale)
    }

    /// Sets the position of landmark `landmark` on the bone it rides on, and of every child bone
    /// whose head sits at that landmark, to `offset_m` from the bone's head.
    pub fn set_landmark_offset(&mut self, rig: &Rig, landmark: usize, offset_m: Vector3<f64>) {
        let l = &rig.landmarks[landmark];
        for (i, b) in rig.bones.iter().enumerate() {
            if b.parent == Some(l.bone) && (b.head_rest_m - l.rest_m).norm() < 1e-9 {
                self.head_offset_m[i] = offset_m;
            }
        }
        self.landmark_offset_m[landmark] = offset_m;
    }

    /// Sets the root's scale so that the hips stand at the height the legs reach: at rest the
    /// soles touch the ground for any proportions.
    fn derive_root_scale(&mut self, rig: &Rig) {
        let mut sum = 0.0;
        let mut n = 0.0;
        for side in ["l", "r"] {
            let idx = |s: &str| rig.bone_index(&format!("{side}_{s}"));
            let (Some(thigh), Some(calf), Some(foot)) = (idx("thigh"), idx("calf"), idx("foot"))
            else {
                continue;
            };
            let drop = |b: usize| {
                let bone = &rig.bones[b];
                bone.head_rest_m.z
                    - rig
                        .bones
                        .iter()
                        .find(|c| c.parent == Some(b))
                        .map_or(0.0, |c| c.head_rest_m.z)
            };
            let ankle_height = rig.bones[foot].head_rest_m.z;
            let rest = drop(thigh) + drop(calf) + ankle_height;
            let scaled = drop(thigh) * self.bone_scale[thigh]
                + drop(calf) * self.bone_scale[calf]
                + ankle_height * self.bone_scale[foot];
            sum += scaled / rest;
            n += 1.0;
        }
        if n > 0.0 {
            self.bone_scale[ROOT] = sum / n;
        }
    }

    /// Height of the hips above the ground at rest, metres: the reference for scaling root
    /// translation when an animation moves to another body.
    #[must_use]
    pub fn hip_height_m(&self, rig: &Rig) -> f64 {
        let pelvis = rig
            .landmark_index("pelvis")
            .map_or(Point3::origin(), |l| rig.landmarks[l].rest_m);
        pelvis.z * self.bone_scale[ROOT]
    }

    /// Offset of landmark `landmark` from the root's head at rest (the chain of head offsets).
    #[must_use]
    pub fn landmark_from_root_m(&self, rig: &Rig, landmark: usize) -> Vector3<f64> {
        let l = &rig.landmarks[landmark];
        let mut v = self.landmark_offset_m[landmark];
        let mut b = l.bone;
        while b != ROOT {
            v += self.head_offset_m[b];
            match rig.bones[b].parent {
                Some(p) => b = p,
                None => break,
            }
        }
        v
    }
}

/// The median of `v` (the mean of the two middle values for an even count), `None` when empty.
pub(crate) fn median(v: &mut [f64]) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}
