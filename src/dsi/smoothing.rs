//! The SuperSmoother applied to an animation, on the rotation group.
//!
//! Each moving bone's track is smoothed in the tangent space around a running mean rotation:
//! `r_f` is the normalised mean of the sign-continuous quaternions in a woofer-wide window around
//! frame `f`, `v_f = log(r_f⁻¹ · q_f)` its offset from it (a small rotation vector, never past
//! π), and the result is `r_f · exp(S(v)_f)`, `S` being Friedman's SuperSmoother applied to each
//! component of `v`. Raw quaternion components are never smoothed, so nothing shrinks or flips,
//! and every result is unit. A hinge's offsets lie on its axis and the root's on the vertical:
//! only that component is smoothed; a 2-D bone must be projected back onto its swing afterwards
//! ([`crate::skeleton::rig::Bone::constrain`], which `dsi::run` does for every bone). The
//! root translation (Euclidean) is smoothed per coordinate.
//!
//! Friedman's spans are fractions of the series; for animations the three spans (tweeter,
//! midrange, woofer) are given in seconds and turned into fractions of each clip, so a long clip
//! is not smoothed harder than a short one. The residual and span smoothing use the midrange,
//! the final pass the tweeter, as in Friedman's defaults. A clip shorter than the woofer has its
//! spans scaled down together (their ratios kept).

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use super::supersmoother::{SmoothScratch, SuperSmoother};
use crate::skeleton::fk::BonePose;
use crate::skeleton::geom::{align_hemisphere, exp_rotation, log_rotation};
use crate::skeleton::rig::{Dof, Rig};

/// Smoothing parameters for animations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Smoothing {
    /// Tweeter, midrange and woofer spans, seconds, ascending.
    pub spans_s: [f64; 3],
    /// Friedman's bass control α in [0, 10] (higher: smoother), or none.
    pub bass: Option<f64>,
}

impl Default for Smoothing {
    fn default() -> Smoothing {
        Smoothing {
            spans_s: [0.1, 0.2, 0.6],
            bass: None,
        }
    }
}

/// Smoothing parameters out of their range.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum SmoothingError {
    /// Spans that are not positive, finite, strictly ascending seconds.
    #[error(
        "smoothing spans must be positive and strictly ascending seconds (tweeter < midrange < woofer), not {}, {}, {}",
        spans_s[0], spans_s[1], spans_s[2]
    )]
    Spans {
        /// The tweeter, midrange and woofer spans given, seconds.
        spans_s: [f64; 3],
    },
    /// A bass control outside [0, 10].
    #[error("the bass control must be in [0, 10], not {alpha}")]
    Bass {
        /// The bass control given.
        alpha: f64,
    },
}

impl Smoothing {
    /// Checks the spans (positive, finite, strictly ascending) and the bass (in [0, 10]).
    ///
    /// # Errors
    /// [`SmoothingError`] naming the bad value and its range.
    pub fn validate(&self) -> Result<(), SmoothingError> {
        let [a, b, c] = self.spans_s;
        if !(a.is_finite() && c.is_finite() && a > 0.0 && a < b && b < c) {
            return Err(SmoothingError::Spans {
                spans_s: self.spans_s,
            });
        }
        if let Some(alpha) = self.bass
            && !(alpha.is_finite() && (0.0..=10.0).contains(&alpha))
        {
            return Err(SmoothingError::Bass { alpha });
        }
        Ok(())
    }

    /// The tweeter span in frames at `fps`, at least one.
    #[must_use]
    pub fn tweeter_frames(&self, fps: f64) -> usize {
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "a validated positive span times a positive rate: a small count"
        )]
        let frames = (self.spans_s[0] * fps).round().max(1.0) as usize;
        frames
    }

    /// The SuperSmoother for `n` frames of a clip of `clip_frames` frames (≥ `n`) at `fps`: the
    /// spans in seconds turned into fractions of the `n` frames, scaled down together when the
    /// clip is shorter than the woofer.
    #[must_use]
    pub fn smoother_for(&self, n: usize, clip_frames: usize, fps: f64) -> SuperSmoother {
        #[expect(
            clippy::cast_precision_loss,
            reason = "frame counts are far below 2^52"
        )]
        let (frames, clip_frames) = (n.max(1) as f64, clip_frames.max(n).max(1) as f64);
        let scale = (clip_frames / fps / self.spans_s[2]).min(1.0);
        // A span's window is `⌊fraction · n⌋` frames: a hair more than the span's frames, so
        // that a whole number of frames (0.6 s at 30 fps) is not rounded down to one less for
        // some lengths, and a clip smoothed in pieces gets the same windows in every piece.
        let fraction = |s: f64| s * scale * fps * (1.0 + 1e-12) / frames;
        let spans = self.spans_s.map(fraction);
        SuperSmoother {
            primary_spans: spans,
            middle_span: spans[1],
            final_span: spans[0],
            bass: self.bass,
        }
    }

    /// Smooths `poses` (one clip, `fps` frames per second) in place. Only the bones that move
    /// in the clip (`moving`, per bone) are smoothed.
    pub fn apply(&self, rig: &Rig, poses: &mut [BonePose], fps: f64, moving: &[bool]) {
        self.apply_as_part(rig, poses, fps, moving, poses.len());
    }

    /// [`Smoothing::apply`] to a piece of a clip of `clip_frames` frames: the same spans, in
    /// frames, as the whole clip's.
    pub fn apply_as_part(
        &self,
        rig: &Rig,
        poses: &mut [BonePose],
        fps: f64,
        moving: &[bool],
        clip_frames: usize,
    ) {
        let n = poses.len();
        if n < 3 {
            return;
        }
        let smoother = self.smoother_for(n, clip_frames, fps);
        let plan = smoother.plan(n);
        let mut scratch = SmoothScratch::default();
        let mut y = vec![0.0; n];
        let mut smoothed = vec![0.0; n];

        for axis in 0..3 {
            for (v, p) in y.iter_mut().zip(poses.iter()) {
                *v = p.root_translation_m[axis];
            }
            plan.smooth_into(&y, &mut smoothed, &mut scratch);
            for (p, v) in poses.iter_mut().zip(&smoothed) {
                p.root_translation_m[axis] = *v;
            }
        }

        // The running mean's window: the woofer, in frames, by the smoother's own rule.
        #[expect(
            clippy::cast_precision_loss,
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "window sizes are small positive counts"
        )]
        let window = (smoother.primary_spans[2] * n as f64).max(3.0).floor() as usize;
        let mut track: Vec<UnitQuaternion<f64>> = Vec::with_capacity(n);
        let mut prefix: Vec<Quaternion<f64>> = Vec::with_capacity(n + 1);
        let mut means: Vec<UnitQuaternion<f64>> = Vec::with_capacity(n);
        let mut offsets: Vec<Vector3<f64>> = Vec::with_capacity(n);
        let mut smoothed_offsets: Vec<Vector3<f64>> = Vec::with_capacity(n);
        for (b, bone) in rig.bones.iter().enumerate() {
            if !moving[b] || matches!(bone.dof, Dof::Static) {
                continue;
            }
            // The sign-continuous track and its running sums.
            track.clear();
            prefix.clear();
            let mut sum = Quaternion::from_parts(0.0, Vector3::zeros());
            prefix.push(sum);
            for p in poses.iter() {
                let q = p.local_rotations[b];
                let q = track.last().map_or(q, |prev| align_hemisphere(q, prev));
                track.push(q);
                sum += q.into_inner();
                prefix.push(sum);
            }
            means.clear();
            offsets.clear();
            for (f, q) in track.iter().enumerate() {
                let lo = f.saturating_sub(window / 2);
                let hi = (f + window - window / 2).min(n);
                let sum = prefix[hi] - prefix[lo];
                let norm = sum.norm();
                #[expect(clippy::cast_precision_loss, reason = "window sizes are small")]
                let mean = if norm > 1e-6 * (hi - lo) as f64 {
                    UnitQuaternion::new_unchecked(sum / norm)
                } else {
                    *q
                };
                means.push(mean);
                offsets.push(log_rotation(&(mean.inverse() * q)));
            }
            let components: &[Vector3<f64>] = match &bone.dof {
                Dof::Hinge { axis } => &[axis.into_inner()],
                Dof::Root => &[Vector3::z()],
                _ => &[Vector3::x(), Vector3::y(), Vector3::z()],
            };
            smoothed_offsets.clear();
            smoothed_offsets.resize(n, Vector3::zeros());
            for direction in components {
                for (v, o) in y.iter_mut().zip(&offsets) {
                    *v = direction.dot(o);
                }
                plan.smooth_into(&y, &mut smoothed, &mut scratch);
                for (s, v) in smoothed_offsets.iter_mut().zip(&smoothed) {
                    *s += direction * *v;
                }
            }
            // Back on the group; the caller puts the result in the bone's class and aligns signs
            // (see `dsi::run`).
            for ((p, mean), v) in poses.iter_mut().zip(&means).zip(&smoothed_offsets) {
                p.local_rotations[b] = mean * exp_rotation(v);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::geom::rotation_distance;

    fn clip(rig: &Rig, n: u32, noise: f64) -> (Vec<BonePose>, Vec<BonePose>) {
        (
            crate::dsi::fixture::whole_body(rig, n, 0.0, |_| 0.0),
            crate::dsi::fixture::whole_body(rig, n, noise, |_| 0.0),
        )
    }

    fn mean_error(rig: &Rig, a: &[BonePose], b: &[BonePose]) -> f64 {
        let mut sum = 0.0;
        let mut count = 0.0;
        for (p, q) in a.iter().zip(b) {
            for (bone, (x, y)) in rig
                .bones
                .iter()
                .zip(p.local_rotations.iter().zip(&q.local_rotations))
            {
                if !matches!(bone.dof, Dof::Static) {
                    sum += rotation_distance(x, y);
                    count += 1.0;
                }
            }
        }
        sum / count
    }

    #[test]
    fn smoothing_removes_noise_and_keeps_units() {
        let rig = Rig::standard();
        let (clean, noisy) = clip(&rig, 240, 0.05);
        let mut smoothed = noisy.clone();
        let moving = crate::skeleton::fk::moving_bones(&smoothed);
        Smoothing::default().apply(&rig, &mut smoothed, 30.0, &moving);
        let before = mean_error(&rig, &noisy, &clean);
        let after = mean_error(&rig, &smoothed, &clean);
        assert!(after < 0.5 * before, "noise {before} rad → {after} rad");
        for p in &smoothed {
            for q in &p.local_rotations {
                assert!((q.norm() - 1.0).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn clean_motion_is_kept() {
        let rig = Rig::standard();
        let (clean, _) = clip(&rig, 240, 0.0);
        let mut smoothed = clean.clone();
        let moving = crate::skeleton::fk::moving_bones(&smoothed);
        Smoothing::default().apply(&rig, &mut smoothed, 30.0, &moving);
        let err = mean_error(&rig, &smoothed, &clean);
        assert!(err < 0.3f64.to_radians(), "{}°", err.to_degrees());
    }

    #[test]
    fn short_clips_and_bad_parameters() {
        let rig = Rig::standard();
        for n in [0, 1, 2, 3, 5, 17] {
            let (_, mut noisy) = clip(&rig, n, 0.05);
            let moving = crate::skeleton::fk::moving_bones(&noisy);
            Smoothing::default().apply(&rig, &mut noisy, 30.0, &moving);
            assert!(
                noisy
                    .iter()
                    .all(|p| p.local_rotations.iter().all(|q| q.norm().is_finite()))
            );
        }
        for bad in [
            [0.0, 0.3, 1.0],
            [0.3, 0.3, 1.0],
            [0.1, 2.0, 1.0],
            [0.1, 0.3, f64::INFINITY],
        ] {
            assert!(
                Smoothing {
                    spans_s: bad,
                    bass: None
                }
                .validate()
                .is_err()
            );
        }
        assert!(
            Smoothing {
                spans_s: [0.1, 0.2, 0.6],
                bass: Some(11.0)
            }
            .validate()
            .is_err()
        );
        assert!(Smoothing::default().validate().is_ok());
    }
}
