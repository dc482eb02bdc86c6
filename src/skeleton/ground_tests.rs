use std::collections::BTreeMap;
use std::f64::consts::PI;

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use proptest::prelude::*;

use super::*;
use crate::skeleton::layout::{JointExpr, Layout};
use crate::skeleton::pose::{PoseFrame, PoseSequence, stamp_nanos_at};

/// The motions of the synthetic body.
#[derive(Debug, Clone, Copy)]
enum Motion {
    /// Walking along +Y at 1.2 m/s, trunk leaning `lean_deg` forward, `side_step_m` sideways
    /// per second.
    Walk { lean_deg: f64, side_step_m: f64 },
    /// Squatting in place, feet planted.
    Squat,
    /// Standing in a staggered stance, swaying a little, on feet built unlike the rig's (ankle
    /// 11 cm up, heel 3 cm, toes 4.5 cm), the back (right) foot on its ball with the heel raised
    /// `heel_raise_m`: the stance of a fighting or throwing clip.
    Stand { heel_raise_m: f64 },
}

/// An upright walk that steps 0.4 m sideways per second: contacts spread across the floor.
const SIDE_STEPS: Motion = Motion::Walk {
    lean_deg: 0.0,
    side_step_m: 0.4,
};

/// Heights above the sole (ankle, heel, toe) of the synthetic feet, metres.
fn foot_heights(motion: Motion) -> (f64, f64, f64) {
    match motion {
        Motion::Stand { .. } => (0.11, 0.03, 0.045),
        _ => (0.08, 0.01, 0.02),
    }
}

/// Rig landmarks of a body at time `t_s` in the world (z up, facing +Y, ground z = 0).
fn body(motion: Motion, t_s: f64) -> BTreeMap<&'static str, Point3<f64>> {
    let mut m = BTreeMap::new();
    let (pelvis, feet, lean) = match motion {
        Motion::Walk {
            lean_deg,
            side_step_m,
        } => {
            let speed = 1.2;
            let step_s = 0.5;
            let x = side_step_m * t_s;
            let pelvis = Point3::new(
                x,
                speed * t_s,
                0.95 + 0.02 * (2.0 * PI * t_s / step_s).cos(),
            );
            // Each foot: planted for half a cycle of 2 steps, swinging the other half.
            let foot = |phase: f64, lateral: f64| {
                let cycle = 2.0 * step_s;
                let k = ((t_s + phase * step_s) / cycle).floor();
                let u = (t_s + phase * step_s) / cycle - k;
                let plant_y = speed * (k * cycle - phase * step_s + step_s);
                let (y, z) = if u < 0.5 {
                    (plant_y, 0.0)
                } else {
                    let w = (u - 0.5) * 2.0;
                    (plant_y + w * speed * cycle, 0.12 * (PI * w).sin())
                };
                Point3::new(x + lateral, y, z)
            };
            (
                pelvis,
                [foot(0.0, -0.1), foot(1.0, 0.1)],
                lean_deg.to_radians(),
            )
        }
        Motion::Squat => {
            let depth = 0.35 * (0.5 - 0.5 * (2.0 * PI * t_s / 2.0).cos());
            let pelvis = Point3::new(0.0, -0.15 * depth / 0.35, 0.95 - depth);
            let feet = [Point3::new(-0.12, 0.0, 0.0), Point3::new(0.12, 0.0, 0.0)];
            (pelvis, feet, (40.0 * depth / 0.35_f64).to_radians())
        }
        Motion::Stand { .. } => {
            let sway = 0.03 * (2.0 * PI * t_s / 1.5).sin();
            let pelvis = Point3::new(sway, -0.12, 0.93);
            let feet = [Point3::new(-0.14, 0.05, 0.0), Point3::new(0.14, -0.3, 0.0)];
            (pelvis, feet, 0.0)
        }
    };
    let (ankle_h, heel_h, toe_h) = foot_heights(motion);
    // The back foot of a stance pivots about its toes: a point at `y` along the foot rises
    // with its distance behind the toes.
    let raised = |side: usize, y: f64| match motion {
        Motion::Stand { heel_raise_m } if side == 1 => heel_raise_m * (0.125 - y).max(0.0) / 0.175,
        _ => 0.0,
    };
    let trunk = Vector3::new(0.0, lean.sin(), lean.cos());
    m.insert("pelvis", pelvis);
    m.insert("spine_mid", pelvis + trunk * 0.25);
    m.insert("chest", pelvis + trunk * 0.45);
    m.insert("neck", pelvis + trunk * 0.55);
    m.insert("head_center", pelvis + trunk * 0.65);
    m.insert("head_top", pelvis + trunk * 0.75);
    for (i, side) in ["l", "r"].into_iter().enumerate() {
        let sign = if i == 0 { -1.0 } else { 1.0 };
        let hip = pelvis + Vector3::x() * (0.1 * sign);
        let sole = feet[i];
        let ankle = sole + Vector3::z() * (ankle_h + raised(i, 0.0));
        let knee = nalgebra::center(&hip, &ankle) + Vector3::y() * 0.08;
        let shoulder = pelvis + trunk * 0.5 + Vector3::x() * (0.18 * sign);
        let leak = |s: &str| -> &'static str { Box::leak(format!("{side}_{s}").into_boxed_str()) };
        m.insert(leak("hip"), hip);
        m.insert(leak("knee"), knee);
        m.insert(leak("ankle"), ankle);
        m.insert(
            leak("heel"),
            sole + Vector3::new(0.0, -0.05, heel_h + raised(i, -0.05)),
        );
        m.insert(leak("toe"), sole + Vector3::new(0.0, 0.125, toe_h));
        m.insert(
            leak("big_toe"),
            sole + Vector3::new(-0.02 * sign, 0.125, toe_h),
        );
        m.insert(
            leak("small_toe"),
            sole + Vector3::new(0.03 * sign, 0.1, toe_h),
        );
        m.insert(leak("shoulder"), shoulder);
        m.insert(leak("elbow"), shoulder - Vector3::z() * 0.28);
        m.insert(leak("wrist"), shoulder - Vector3::z() * 0.53);
    }
    m
}

/// `frames` frames of the body at 30 fps in `layout`, each point moved by `camera_from_world`.
fn clip(
    layout: &Layout,
    motion: Motion,
    frames: usize,
    camera_from_world: &Isometry3<f64>,
) -> PoseSequence {
    let frames = (0..frames)
        .map(|i| {
            let stamp = stamp_nanos_at(i, 30.0);
            #[expect(clippy::cast_precision_loss, reason = "small")]
            let world = body(motion, i as f64 / 30.0);
            let mut f = PoseFrame::missing(stamp, layout.joints.len());
            for (landmark, expr) in &layout.landmarks {
                let (JointExpr::Joint(j), Some(p)) = (expr, world.get(landmark.as_str())) else {
                    continue;
                };
                let k = layout.joints.iter().position(|n| n == j).unwrap();
                f.positions_m[k] = camera_from_world * p;
                f.confidence[k] = 1.0;
            }
            f
        })
        .collect();
    PoseSequence {
        source: "synthetic".into(),
        track_id: 0,
        joint_names: layout.joints.clone(),
        frames,
    }
}

fn camera(tilt_deg: f64, tilt_axis_rad: f64, yaw_rad: f64, shift: Vector3<f64>) -> Isometry3<f64> {
    let axis =
        nalgebra::Unit::new_normalize(Vector3::new(tilt_axis_rad.cos(), tilt_axis_rad.sin(), 0.0));
    let r = UnitQuaternion::from_axis_angle(&axis, tilt_deg.to_radians())
        * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw_rad);
    Isometry3::from_parts(Translation3::from(shift), r)
}

/// Checks a grounded clip: true up recovered within `max_deg`, soles at z ≈ 0 when planted, hip
/// line along +X at the start, pelvis over the origin.
fn check(
    layout: &Layout,
    motion: Motion,
    camera_from_world: &Isometry3<f64>,
    max_deg: f64,
) -> Grounding {
    let mut seq = clip(layout, motion, 90, camera_from_world);
    let g = ground(&mut seq, layout).unwrap();
    let true_up = camera_from_world.rotation * Vector3::z();
    let err = angle_deg(&g.up_in_camera, &true_up);
    assert!(
        err <= max_deg,
        "{motion:?}: up off by {err}° ({})",
        g.summary()
    );
    assert!(g.residual_p95_m <= 0.02, "{}", g.summary());
    let back = clip(layout, motion, 90, &Isometry3::identity());
    let lowest_world = back
        .frames
        .iter()
        .flat_map(|f| f.positions_m.iter())
        .map(|p| p.z)
        .filter(|z| z.is_finite())
        .fold(f64::INFINITY, f64::min);
    let lowest = seq
        .frames
        .iter()
        .flat_map(|f| f.positions_m.iter())
        .map(|p| p.z)
        .filter(|z| z.is_finite())
        .fold(f64::INFINITY, f64::min);
    assert!(
        (lowest - lowest_world).abs() <= 0.015,
        "lowest point {lowest} vs {lowest_world}"
    );
    let f0 = &seq.frames[0];
    let (l, r) = (
        seq.joint_index(&joint(layout, "l_hip")).unwrap(),
        seq.joint_index(&joint(layout, "r_hip")).unwrap(),
    );
    let hip_line = f0.positions_m[r] - f0.positions_m[l];
    assert!(
        hip_line.x > 0.0 && hip_line.y.abs() < 0.01 * hip_line.norm() + 1e-6,
        "{hip_line}"
    );
    let pelvis = match &layout.landmarks["pelvis"] {
        JointExpr::Joint(j) => f0.positions_m[seq.joint_index(j).unwrap()],
        _ => nalgebra::center(&f0.positions_m[l], &f0.positions_m[r]),
    };
    assert!(pelvis.x.hypot(pelvis.y) < 1e-6, "{pelvis}");
    g
}

fn joint(layout: &Layout, landmark: &str) -> String {
    match &layout.landmarks[landmark] {
        JointExpr::Joint(j) => j.clone(),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_tilted_walk_and_squat_are_grounded_in_both_layouts() {
    for name in ["zed-body-34", "h36m-17", "coco-wholebody-133"] {
        let layout = Layout::load(name).unwrap();
        let cam = camera(22.0, 0.7, 2.0, Vector3::new(0.3, -1.05, 4.5));
        check(
            &layout,
            Motion::Walk {
                lean_deg: 6.0,
                side_step_m: 0.0,
            },
            &cam,
            3.0,
        );
        check(&layout, SIDE_STEPS, &cam, 3.0);
        check(&layout, Motion::Squat, &cam, 3.0);
    }
}

/// Two planted feet fix only the tilt along the line between them: the estimate says the trunk
/// set the rest. Steps that wander sideways spread the contacts across the floor, and it does
/// not.
#[test]
fn the_estimate_says_when_the_trunk_set_the_tilt() {
    let layout = Layout::load("h36m-17").unwrap();
    let cam = camera(15.0, 0.3, 1.0, Vector3::new(0.2, -1.0, 4.0));
    let squat = check(&layout, Motion::Squat, &cam, 3.0);
    assert!(
        squat.across_spread_m < TRUNK_DECIDES_SPREAD_M,
        "{}",
        squat.summary()
    );
    assert!(squat.summary().contains("the trunk set the tilt"));
    let wander = check(&layout, SIDE_STEPS, &cam, 3.0);
    assert!(
        wander.across_spread_m >= TRUNK_DECIDES_SPREAD_M,
        "{}",
        wander.summary()
    );
    assert!(wander.trunk_note().is_empty());
}

/// The tracks of one camera share the grounding of the one with the most frames, or of the
/// next that can be grounded; when none can, the error is the first tried track's.
#[test]
fn a_shared_grounding_comes_from_the_longest_track_that_can_be_grounded() {
    let layout = Layout::load("h36m-17").unwrap();
    let seq = clip(&layout, Motion::Squat, 30, &Isometry3::identity());
    // (track id, frames, whether it has feet)
    let tracks = [
        (1_u64, 10_usize, true),
        (2, 30, false),
        (3, 20, true),
        (4, 20, true),
    ];
    let estimate = |&(id, _, feet): &(u64, usize, bool)| {
        if feet {
            estimate(&seq, &layout, 1)
        } else {
            Err(GroundError::NoFootObserved {
                source_name: format!("track {id}"),
                samples: 0,
            })
        }
    };
    let key = |&(id, n, _): &(u64, usize, bool)| (id, n);
    let found = shared(&tracks, key, estimate).unwrap().unwrap();
    assert_eq!(found.track_id, 3, "longest with feet, first of equals");
    assert!(found.note(3).starts_with("grounded: up"));
    assert!(found.note(1).contains("grounded with track 3"));
    let footless = [(7_u64, 5_usize, false), (8, 9, false)];
    let err = shared(&footless, key, estimate).unwrap().unwrap_err();
    assert!(err.to_string().contains("track 8"), "{err}");
    assert!(shared(&[], key, estimate).is_none());
}

/// A standing clip decides the floor from two planted feet whose joints sit at heights above
/// the sole unlike the rig's, one of them on its ball: neither the heights nor the raised heel
/// may tilt the floor (they did by 4.9° before each landmark kind was fitted about its own mean
/// and only a foot's lowest points counted as contacts). What is left is the trunk prior's own
/// lean: the feet's points average 6 cm ahead of the ankles, so feet → neck leans back about 2°,
/// and the two planted feet fix only the tilt along the line between them.
#[test]
fn a_stance_on_feet_unlike_the_rig_and_a_raised_heel_is_not_tilted() {
    for name in ["zed-body-34", "coco-wholebody-133"] {
        let layout = Layout::load(name).unwrap();
        for heel_raise_m in [0.0, 0.07] {
            let cam = camera(18.0, 2.4, 0.6, Vector3::new(0.2, -1.0, 3.5));
            let mut seq = clip(&layout, Motion::Stand { heel_raise_m }, 90, &cam);
            let g = ground(&mut seq, &layout).unwrap();
            let err = angle_deg(&g.up_in_camera, &(cam.rotation * Vector3::z()));
            assert!(
                err < 1.5,
                "{name}, heel raised {heel_raise_m} m: up off by {err}° ({})",
                g.summary()
            );
        }
    }
}

#[test]
fn an_already_grounded_clip_is_left_in_place() {
    let layout = Layout::load("zed-body-34").unwrap();
    let walk = Motion::Walk {
        lean_deg: 3.0,
        side_step_m: 0.0,
    };
    let g = check(&layout, walk, &Isometry3::identity(), 0.5);
    assert!(g.tilt_deg < 0.5, "{}", g.summary());
}

#[test]
fn a_sampled_clip_gives_the_same_ground_as_the_whole() {
    let layout = Layout::load("zed-body-34").unwrap();
    let cam = camera(15.0, 2.0, -1.0, Vector3::new(-1.0, 2.0, 3.0));
    let seq = clip(
        &layout,
        Motion::Walk {
            lean_deg: 4.0,
            side_step_m: 0.1,
        },
        150,
        &cam,
    );
    let whole = estimate(&seq, &layout, 1).unwrap();
    let sampled = estimate(&seq, &layout, 4).unwrap();
    assert!(angle_deg(&whole.up_in_camera, &sampled.up_in_camera) < 1.0);
    assert_eq!(sampled.samples, 38);
}

#[test]
fn degenerate_clips_are_errors_or_estimates_never_panics() {
    let layout = Layout::load("h36m-17").unwrap();
    let cam = camera(10.0, 0.0, 0.0, Vector3::zeros());
    // One frame: the plane goes through its lowest foot, square to the trunk.
    let mut one = clip(&layout, Motion::Squat, 1, &cam);
    let g = ground(&mut one, &layout).unwrap();
    assert!(angle_deg(&g.up_in_camera, &(cam.rotation * Vector3::z())) < 3.0);
    // No frame.
    let mut none = clip(&layout, Motion::Squat, 0, &cam);
    let err = ground(&mut none, &layout).unwrap_err();
    assert_eq!(
        err.to_string(),
        "synthetic: no frame observes a foot (0 frames sampled)"
    );
    // Every joint NaN: an error, the clip unchanged.
    let mut nan = clip(&layout, Motion::Squat, 5, &cam);
    for f in &mut nan.frames {
        *f = PoseFrame::missing(f.stamp_nanos, f.positions_m.len());
    }
    let before = nan.clone();
    assert!(ground(&mut nan, &layout).is_err());
    assert_eq!(format!("{before:?}"), format!("{nan:?}"));
    // A layout without feet.
    let no_feet = Layout::from_toml(
        "name = \"trunk\"\njoints = [\"a\", \"b\"]\n[landmarks]\npelvis = \"a\"\nneck = \"b\"\n",
        "trunk",
    )
    .unwrap();
    let seq = PoseSequence {
        source: "x.json".into(),
        track_id: 0,
        joint_names: vec!["a".into(), "b".into()],
        frames: vec![],
    };
    assert_eq!(
        estimate(&seq, &no_feet, 1).unwrap_err().to_string(),
        "x.json: the layout `trunk` has no ankle, heel or toe joint to find the ground with"
    );
    // Some NaN joints in every frame: still grounded.
    let mut holes = clip(&layout, Motion::Squat, 30, &cam);
    for (i, f) in holes.frames.iter_mut().enumerate() {
        f.positions_m[i % 17] = Point3::new(f64::NAN, 0.0, 0.0);
    }
    let g = ground(&mut holes, &layout).unwrap();
    assert!(angle_deg(&g.up_in_camera, &(cam.rotation * Vector3::z())) < 3.0);
}

#[test]
fn ground_mode_applies_to_camera_frame_sources_by_default() {
    assert!(GroundMode::Auto.applies(true));
    assert!(!GroundMode::Auto.applies(false));
    assert!(GroundMode::On.applies(false));
    assert!(!GroundMode::Off.applies(true));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Any camera tilted up to 30° with any yaw and position: the body comes back on z = 0 with
    /// up within 3°; and the result does not depend on the camera (translation and rotation
    /// invariance of the grounded clip).
    #[test]
    fn any_camera_is_undone(
        tilt_deg in 0.0..30.0_f64,
        tilt_axis in 0.0..(2.0 * PI),
        yaw in -PI..PI,
        shift in prop::array::uniform3(-6.0..6.0_f64),
        lean_deg in -8.0..8.0_f64,
        side_step_m in -0.5..0.5_f64,
        squat in any::<bool>(),
    ) {
        let layout = Layout::load("zed-body-34").unwrap();
        let motion = if squat { Motion::Squat } else { Motion::Walk { lean_deg, side_step_m } };
        let cam = camera(tilt_deg, tilt_axis, yaw, Vector3::from(shift));
        check(&layout, motion, &cam, 3.0);
        let mut a = clip(&layout, motion, 60, &cam);
        let mut b = clip(&layout, motion, 60, &Isometry3::identity());
        ground(&mut a, &layout).unwrap();
        ground(&mut b, &layout).unwrap();
        for (fa, fb) in a.frames.iter().zip(&b.frames) {
            for (pa, pb) in fa.positions_m.iter().zip(&fb.positions_m) {
                if pa.x.is_finite() {
                    prop_assert!((pa - pb).norm() < 0.03, "{pa} vs {pb}");
                }
            }
        }
    }
}
