//! Keeping the whole character in the picture.
//!
//! A [`Subject`] summarises an animation for the camera: per frame, the point to look at and the
//! character's ground point, and one radius that bounds the body about that point in every
//! frame. [`framing_band`] turns it and a lens into the range of horizontal distances at which
//! the body is guaranteed to fit in the image.
//!
//! **The guarantee.** The camera looks at the frame's centre `c`, so a sphere of radius `R`
//! about `c` seen from a distance `d ≥ R / sin α` lies inside the cone of half-angle `α` about the
//! optical axis, and every point of it projects within `f·tan α` pixels of the principal point.
//! With `tan α = (1 − margin)·tan(narrow_half_fov)` that is inside the image shrunk by the margin
//! on the narrower axis, hence on both. The camera's *horizontal* distance `D` is measured from
//! the character's ground point, which can be up to `o` (the largest horizontal offset of `c`
//! from the ground point) away from `c`, so `d ≥ D − o`: the band's minimum is
//! `R / sin α + o`, whatever the camera's height.
//!
//! **A fixed aim.** A static shot's camera holds one place and aim for a whole clip when the
//! same bound, widened by how far the aim is from each frame's centre and ground point, still
//! holds ([`Subject::held_aim`]).

use nalgebra::{Point3, Vector3};

use super::{CameraError, Intrinsics};
use crate::skeleton::character::Character;
use crate::skeleton::fk::{self, BonePose, WorldPose};
use crate::skeleton::rig::{ROOT, Rig};

/// Added to the radius of the joints' sphere to cover what joints do not mark: the body's flesh
/// and clothes around the bones (half a torso's depth, a hand's and a foot's width), metres.
pub const BODY_ALLOWANCE_M: f64 = 0.15;

/// The points of a posed body the camera must keep in view, into `out` (cleared first): every
/// bone's head (the joints) and the tail of every leaf bone — the **top of the head** (the head
/// bone's tail, at the character's full height at rest), the finger tips and the toe tips.
/// A leaf bone's tail is `head + world_rotation · (tail_rest − head_rest) · bone_scale`.
pub fn subject_points_into(
    rig: &Rig,
    character: &Character,
    world: &WorldPose,
    out: &mut Vec<Point3<f64>>,
) {
    out.clear();
    out.extend_from_slice(&world.heads_m);
    let mut has_child = vec![false; rig.bones.len()];
    for p in rig.bones.iter().filter_map(|b| b.parent) {
        has_child[p] = true;
    }
    for (i, bone) in rig.bones.iter().enumerate() {
        if has_child[i] {
            continue;
        }
        let rest = (bone.tail_rest_m - bone.head_rest_m) * character.bone_scale[i];
        out.push(world.heads_m[i] + world.rotations[i] * rest);
    }
}

/// What the camera needs to know about one animation on one body.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Subject {
    /// Per frame: the look-at point, the centre of the axis-aligned box of that frame's
    /// [`subject_points_into`] points, metres, world frame.
    pub centres_m: Vec<Point3<f64>>,
    /// Per frame: the character's ground point, the root bone's head `(x, y)`, metres. The
    /// camera's cylindrical coordinates are about it.
    pub ground_xy_m: Vec<[f64; 2]>,
    /// Radius bounding every point about its own frame's centre, over all frames, plus
    /// [`BODY_ALLOWANCE_M`], metres.
    pub radius_m: f64,
    /// Largest horizontal distance between a frame's centre and its ground point, metres.
    pub max_centre_offset_m: f64,
}

impl Subject {
    /// Runs forward kinematics on every frame (with `translation_scale` on the root translation,
    /// as the renderer will) and measures the subject.
    ///
    /// # Errors
    /// [`CameraError::NoFrames`] for an empty animation, [`CameraError::PoseSize`] for a frame
    /// whose rotation count differs from the rig's bone count, [`CameraError::NonFinitePose`]
    /// for a frame whose joints are not finite.
    pub fn from_poses(
        rig: &Rig,
        character: &Character,
        poses: &[BonePose],
        translation_scale: f64,
    ) -> Result<Subject, CameraError> {
        if poses.is_empty() {
            return Err(CameraError::NoFrames);
        }
        let mut world = WorldPose::new(rig);
        let mut points = Vec::new();
        let mut subject = Subject {
            centres_m: Vec::with_capacity(poses.len()),
            ground_xy_m: Vec::with_capacity(poses.len()),
            radius_m: 0.0,
            max_centre_offset_m: 0.0,
        };
        let mut joint_radius_m: f64 = 0.0;
        for (frame, pose) in poses.iter().enumerate() {
            if pose.local_rotations.len() != rig.bones.len() {
                return Err(CameraError::PoseSize {
                    frame,
                    got: pose.local_rotations.len(),
                    expected: rig.bones.len(),
                });
            }
            fk::forward_into(rig, character, pose, translation_scale, &mut world);
            subject_points_into(rig, character, &world, &mut points);
            if !points
                .iter()
                .all(|p| p.coords.iter().all(|v| v.is_finite()))
            {
                return Err(CameraError::NonFinitePose { frame });
            }
            let mut lo = points[0];
            let mut hi = points[0];
            for p in &points {
                lo = lo.inf(p);
                hi = hi.sup(p);
            }
            let centre = nalgebra::center(&lo, &hi);
            for p in &points {
                joint_radius_m = joint_radius_m.max((p - centre).norm());
            }
            let root = world.heads_m[ROOT];
            let offset = (centre.xy() - root.xy()).norm();
            subject.max_centre_offset_m = subject.max_centre_offset_m.max(offset);
            subject.centres_m.push(centre);
            subject.ground_xy_m.push([root.x, root.y]);
        }
        subject.radius_m = joint_radius_m + BODY_ALLOWANCE_M;
        Ok(subject)
    }

    /// Where a static shot's camera stands and looks for the whole clip showing frames
    /// `shows` from `distance_m`, when one place keeps every one of them in frame: about the
    /// frames' mean ground point, looking at the middle of their centres' box. A tripod does not
    /// follow an arm's swing: a camera that did would move the background with the action.
    /// `None` when the body moves too far for that (a walk, unless seen from far enough): the
    /// camera then tracks it frame by frame.
    ///
    /// `band` is [`framing_band`]'s for this subject; its bound is `band[0] = R / sin α + c`,
    /// with `R` the subject's radius about each frame's centre and `c` the largest centre–ground
    /// offset. For a fixed aim every point is within `R + δ` of it (`δ` the farthest centre's
    /// distance from the aim) and the camera is at least `distance − |ground − aim|` from it, so
    /// the body stays in frame when `distance ≥ |ground − aim| + R / sin α + δ / sin α`.
    #[must_use]
    pub fn held_aim(
        &self,
        shows: &[usize],
        distance_m: f64,
        band: [f64; 2],
    ) -> Option<([f64; 2], Point3<f64>)> {
        #[expect(clippy::cast_precision_loss, reason = "frame counts far below 2^52")]
        let n = shows.len().max(1) as f64;
        let mut ground = [0.0; 2];
        let (mut lo, mut hi) = (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        );
        for &k in shows {
            ground[0] += self.ground_xy_m[k][0] / n;
            ground[1] += self.ground_xy_m[k][1] / n;
            lo = lo.inf(&self.centres_m[k].coords);
            hi = hi.sup(&self.centres_m[k].coords);
        }
        let centre = Point3::from((lo + hi) / 2.0);
        let farthest_m = shows
            .iter()
            .map(|&k| (self.centres_m[k] - centre).norm())
            .fold(0.0, f64::max);
        let offset_m = (ground[0] - centre.x).hypot(ground[1] - centre.y);
        let reach_m = band[0] - self.max_centre_offset_m;
        let inv_sin_alpha = reach_m / self.radius_m;
        (inv_sin_alpha.is_finite() && distance_m >= offset_m + reach_m + farthest_m * inv_sin_alpha)
            .then_some((ground, centre))
    }
}

/// The band `[min, max]` of horizontal camera distances (from the character's ground point,
/// metres) that keeps `subject` inside the image of `intrinsics`, shrunk by `margin_fraction` of
/// its half-size, in every frame; `max` is `max_distance_m`. See the module docs for the bound:
/// `min = R / sin(atan((1 − margin)·tan(narrow_half_fov))) + max_centre_offset`.
///
/// # Errors
/// [`CameraError::Value`] naming `margin_fraction` (must be in [0, 1)) or `max_distance_m`
/// (must be finite and > 0); [`CameraError::DoesNotFit`] when the character needs more than
/// `max_distance_m`, with the shortfall and what to change.
pub fn framing_band(
    intrinsics: &Intrinsics,
    subject: &Subject,
    margin_fraction: f64,
    max_distance_m: f64,
) -> Result<[f64; 2], CameraError> {
    if !(0.0..1.0).contains(&margin_fraction) {
        return Err(CameraError::Value {
            field: "margin_fraction",
            value: margin_fraction,
            expected: "in [0, 1)",
        });
    }
    if !(max_distance_m.is_finite() && max_distance_m > 0.0) {
        return Err(CameraError::Value {
            field: "max_distance_m",
            value: max_distance_m,
            expected: "finite and > 0",
        });
    }
    let narrow_half = intrinsics.narrow_half_fov_rad();
    let alpha = ((1.0 - margin_fraction) * narrow_half.tan()).atan();
    let min_distance_m = subject.radius_m / alpha.sin() + subject.max_centre_offset_m;
    if min_distance_m > max_distance_m {
        return Err(CameraError::DoesNotFit {
            radius_m: subject.radius_m,
            centre_offset_m: subject.max_centre_offset_m,
            min_distance_m,
            max_distance_m,
            shortfall_m: min_distance_m - max_distance_m,
            margin_fraction,
            narrow_fov_deg: (2.0 * narrow_half).to_degrees(),
        });
    }
    Ok([min_distance_m, max_distance_m])
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn a_static_shot_holds_still_over_an_arm_swing_and_tracks_a_walk() {
        // 60 frames: the centre sways 3 cm with the arm, or walks 2 m.
        let subject = |walk_m: f64| Subject {
            centres_m: (0..60)
                .map(|f| {
                    let s = f64::from(f) / 59.0;
                    Point3::new(walk_m * s + 0.03 * (7.0 * s).sin(), 0.0, 0.9)
                })
                .collect(),
            ground_xy_m: (0..60)
                .map(|f| [walk_m * f64::from(f) / 59.0, 0.0])
                .collect(),
            radius_m: 1.0,
            max_centre_offset_m: 0.03,
        };
        let shows: Vec<usize> = (0..60).collect();
        let band = [2.0, 12.0];
        let (ground, centre) = subject(0.0)
            .held_aim(&shows, 2.5, band)
            .expect("an arm swing is held");
        // The sway's box is ±3 cm about 0 (its middle, up to the sine's sampling).
        assert!(centre.x.abs() < 1e-3 && ground == [0.0, 0.0]);
        // At the band's edge there is no room for the sway: the camera tracks.
        assert!(subject(0.0).held_aim(&shows, 2.0, band).is_none());
        assert!(subject(2.0).held_aim(&shows, 2.5, band).is_none());
        // From far enough away even the walk stays in frame.
        assert!(subject(2.0).held_aim(&shows, 12.0, band).is_some());
    }

    #[test]
    fn rest_pose_subject_matches_the_rig() {
        let rig = Rig::standard();
        let ch = Character::standard(&rig);
        let s = Subject::from_poses(&rig, &ch, &[BonePose::rest(&rig)], 1.0).unwrap();
        // T-pose: the box spans the middle finger tips (x ±0.909), the toes and heels (y) and
        // the root's head on the ground to the head top (z 0 … 1.75).
        let c = s.centres_m[0];
        assert_relative_eq!(c.x, 0.0, epsilon = 1e-9);
        assert_relative_eq!(c.z, 0.5 * 1.75, epsilon = 1e-9);
        assert!(
            s.radius_m > 0.909 + BODY_ALLOWANCE_M && s.radius_m < 1.3,
            "{}",
            s.radius_m
        );
        assert_eq!(s.ground_xy_m, vec![[0.0, 0.0]]);
        let mut pts = Vec::new();
        let world = fk::forward(&rig, &ch, &BonePose::rest(&rig), 1.0);
        subject_points_into(&rig, &ch, &world, &mut pts);
        let top = pts.iter().map(|p| p.z).fold(f64::MIN, f64::max);
        assert_relative_eq!(top, Character::STANDARD_HEIGHT_M, epsilon = 1e-9);
    }

    #[test]
    fn centres_follow_root_motion_and_radius_does_not_grow_with_it() {
        let rig = Rig::standard();
        let ch = Character::standard(&rig);
        let mut walked = BonePose::rest(&rig);
        walked.root_translation_m = Vector3::new(3.0, -1.0, 0.0);
        let clip = [BonePose::rest(&rig), walked];
        let still = Subject::from_poses(&rig, &ch, &clip[..1], 1.0).unwrap();
        let s = Subject::from_poses(&rig, &ch, &clip, 1.0).unwrap();
        assert_relative_eq!(s.radius_m, still.radius_m, epsilon = 1e-12);
        assert_relative_eq!(s.centres_m[1].x - s.centres_m[0].x, 3.0, epsilon = 1e-12);
        assert_eq!(s.ground_xy_m[1], [3.0, -1.0]);
        // A half translation scale halves the walk.
        let half = Subject::from_poses(&rig, &ch, &clip, 0.5).unwrap();
        assert_eq!(half.ground_xy_m[1], [1.5, -0.5]);
    }

    #[test]
    fn bad_animations_are_rejected_with_the_frame() {
        let rig = Rig::standard();
        let ch = Character::standard(&rig);
        assert_eq!(
            Subject::from_poses(&rig, &ch, &[], 1.0),
            Err(CameraError::NoFrames)
        );
        let mut short = BonePose::rest(&rig);
        short.local_rotations.pop();
        let e = Subject::from_poses(&rig, &ch, &[BonePose::rest(&rig), short], 1.0).unwrap_err();
        assert!(
            e.to_string().starts_with("frame 1 has 52 bone rotations"),
            "{e}"
        );
        let mut nan = BonePose::rest(&rig);
        nan.root_translation_m.x = f64::NAN;
        let e = Subject::from_poses(&rig, &ch, &[nan], 1.0).unwrap_err();
        assert_eq!(e, CameraError::NonFinitePose { frame: 0 });
    }

    #[test]
    fn framing_band_matches_the_sphere_bound() {
        let c = Intrinsics::from_horizontal_fov(1280, 720, 60.0).unwrap();
        let s = Subject {
            centres_m: vec![Point3::new(0.0, 0.0, 1.0)],
            ground_xy_m: vec![[0.0, 0.0]],
            radius_m: 1.0,
            max_centre_offset_m: 0.25,
        };
        let [lo, hi] = framing_band(&c, &s, 0.1, 20.0).unwrap();
        assert_eq!(hi, 20.0);
        // At distance lo − offset the sphere's angular radius equals the allowed angle.
        let alpha = (1.0 / (lo - 0.25)).asin();
        let allowed = (0.9 * (0.5 * c.vertical_fov_rad()).tan()).atan();
        assert_relative_eq!(alpha, allowed, epsilon = 1e-12);
        // Seen from there, the sphere's silhouette edge straight above the axis lands on the
        // shrunk image's top edge: f·tan α = 0.9·h/2.
        assert_relative_eq!(c.fy_px * alpha.tan(), 0.9 * 360.0, epsilon = 1e-9);
    }

    #[test]
    fn impossible_band_says_by_how_much_and_what_to_change() {
        let c = Intrinsics::from_horizontal_fov(640, 480, 20.0).unwrap();
        let s = Subject {
            centres_m: vec![Point3::new(0.0, 0.0, 1.0)],
            ground_xy_m: vec![[0.0, 0.0]],
            radius_m: 1.2,
            max_centre_offset_m: 0.1,
        };
        let e = framing_band(&c, &s, 0.05, 4.0).unwrap_err();
        let CameraError::DoesNotFit {
            min_distance_m,
            shortfall_m,
            ..
        } = e
        else {
            panic!("{e}")
        };
        assert_relative_eq!(shortfall_m, min_distance_m - 4.0, epsilon = 1e-12);
        let msg = e.to_string();
        assert!(msg.contains("does not fit"), "{msg}");
        assert!(msg.contains("maximum distance is 4.000 m"), "{msg}");
        assert!(msg.contains(&format!("{shortfall_m:.3} m short")), "{msg}");
        assert!(msg.contains("raise the maximum distance"), "{msg}");
        for (m, d, field) in [
            (1.0, 4.0, "margin_fraction"),
            (-0.1, 4.0, "margin_fraction"),
            (0.1, 0.0, "max_distance_m"),
            (0.1, f64::INFINITY, "max_distance_m"),
        ] {
            let e = framing_band(&c, &s, m, d).unwrap_err();
            assert!(e.to_string().starts_with(field), "{e}");
        }
    }
}
