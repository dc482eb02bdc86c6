//! Tests of the conversion laws: the rig is posed at random, read back through FK as landmark
//! positions, converted, and posed again.

use crate::outcome::LostInput;
use nalgebra::{Point3, Translation3, UnitQuaternion, Vector3};
use proptest::prelude::*;

use super::*;
use crate::skeleton::fk;
use crate::skeleton::geom::rotation_distance;

/// Positions of every rig landmark for `pose` on `character`: a frame in the rig-landmark layout.
fn landmark_frame(
    rig: &Rig,
    character: &Character,
    pose: &BonePose,
    stamp_nanos: u64,
) -> PoseFrame {
    let world = fk::forward(rig, character, pose, 1.0);
    let positions_m = (0..rig.landmarks.len())
        .map(|l| fk::landmark_position(rig, character, &world, l))
        .collect();
    PoseFrame {
        stamp_nanos,
        positions_m,
        confidence: vec![1.0; rig.landmarks.len()],
    }
}

fn arb_rotation(max_angle: f64) -> impl Strategy<Value = UnitQuaternion<f64>> {
    (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, 0.0..max_angle).prop_map(|(x, y, z, a)| {
        let axis = Vector3::new(x, y, z);
        if axis.norm() < 1e-3 {
            UnitQuaternion::identity()
        } else {
            UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), a)
        }
    })
}

/// A random pose that respects the DoF classes, with hinges flexed between 10° and 150° (a limb
/// bent the anatomical way, so its bend plane is observable), and yaw, translation anywhere.
fn arb_pose() -> impl Strategy<Value = BonePose> {
    let rig = Rig::standard();
    let n = rig.bones.len();
    (
        proptest::collection::vec(arb_rotation(1.5), n),
        proptest::collection::vec(0.17..2.6f64, n),
        -3.1..3.1f64,
        (-5.0..5.0f64, -5.0..5.0f64, -0.5..0.5f64),
    )
        .prop_map(move |(rots, hinges, yaw, (x, y, z))| {
            let mut pose = BonePose::rest(&rig);
            for (b, bone) in rig.bones.iter().enumerate() {
                pose.local_rotations[b] = match bone.dof {
                    // spine1 and spine3 share their recipes with spine0 and spine2: the layout's
                    // landmarks cannot tell them apart, so a bend is carried by the lower bone.
                    _ if bone.name == "spine1" || bone.name == "spine3" => {
                        UnitQuaternion::identity()
                    }
                    // The spine's twist is seen on the shoulder line, which a clavicle swing also
                    // moves: the law holds for clavicles at rest (`clavicle_swing_...` covers
                    // them with the spine at rest).
                    _ if bone.name.ends_with("_clavicle") => UnitQuaternion::identity(),
                    Dof::Root => crate::skeleton::geom::yaw_rotation(yaw),
                    Dof::Static => UnitQuaternion::identity(),
                    Dof::ThreeD => rots[b],
                    Dof::TwoD => {
                        let d = bone.rest_direction();
                        let (swing, _) = crate::skeleton::geom::swing_twist(&rots[b], &d);
                        swing
                    }
                    Dof::Hinge { axis } => UnitQuaternion::from_axis_angle(&axis, hinges[b]),
                };
            }
            pose.root_translation_m = Vector3::new(x, y, z);
            pose
        })
}

fn convert_one(rig: &Rig, frame: &PoseFrame) -> (BonePose, ConversionReport) {
    let layout = Layout::rig_landmarks(rig);
    let character = Character::standard(rig);
    let mut c = Converter::new(rig, &layout, &character, ConvertOptions::default()).unwrap();
    let mut out = BonePose::rest(rig);
    c.convert_frame(frame, &mut out).unwrap();
    (out, c.into_report())
}

fn recipe_direction(frame: &PoseFrame, from: &[usize], to: &[usize]) -> Vector3<f64> {
    let mean = |s: &[usize]| {
        s.iter()
            .map(|&l| frame.positions_m[l].coords)
            .sum::<Vector3<f64>>()
            / s.len() as f64
    };
    (mean(to) - mean(from)).normalize()
}

fn angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b)).to_degrees()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// Law: FK(convert(p)) reproduces the direction of every 3-D and 2-D bone (and of hinge
    /// bones, whose input lies in their hinge plane), to 0.01°.
    #[test]
    fn round_trip_reproduces_bone_directions(pose in arb_pose()) {
        let rig = Rig::standard();
        let character = Character::standard(&rig);
        let input = landmark_frame(&rig, &character, &pose, 0);
        let (solved, _) = convert_one(&rig, &input);
        let output = landmark_frame(&rig, &character, &solved, 0);
        for r in &rig.recipes {
            let d = &r.directions[0];
            let a = recipe_direction(&input, &d.from, &d.to);
            let b = recipe_direction(&output, &d.from, &d.to);
            prop_assert!(angle_deg(&a, &b) < 0.01, "{}: {}°", rig.bones[r.bone].name, angle_deg(&a, &b));
        }
        // Every landmark lands where it was (the pose was expressible), to a micrometre.
        for (l, (p, q)) in input.positions_m.iter().zip(&output.positions_m).enumerate() {
            prop_assert!((p - q).norm() < 1e-6, "landmark {} off by {} m", rig.landmarks[l].name, (p - q).norm());
        }
    }

    /// Law: moving every joint by the same vector changes no rotation (beyond 1e-9) and moves
    /// the root by exactly that vector.
    #[test]
    fn translation_invariance(pose in arb_pose(), t in (-100.0..100.0f64, -100.0..100.0f64, -100.0..100.0f64)) {
        let rig = Rig::standard();
        let character = Character::standard(&rig);
        let input = landmark_frame(&rig, &character, &pose, 0);
        let shift = Vector3::new(t.0, t.1, t.2);
        let mut moved = input.clone();
        for p in &mut moved.positions_m { *p += shift; }
        let (a, _) = convert_one(&rig, &input);
        let (b, _) = convert_one(&rig, &moved);
        for (qa, qb) in a.local_rotations.iter().zip(&b.local_rotations) {
            prop_assert!(rotation_distance(qa, qb) < 1e-9);
        }
        prop_assert!((b.root_translation_m - a.root_translation_m - shift).norm() < 1e-9);
    }

    /// Law: rotating the whole body about the vertical changes only the root's rotation; any
    /// rotation at all changes no local rotation below the bones that hang off the root (spine0
    /// and the pelvis absorb a tilt, since the root only yaws).
    #[test]
    fn rotation_invariance_below_the_root(pose in arb_pose(), tilt in arb_rotation(3.1), yaw in -3.1..3.1f64) {
        let rig = Rig::standard();
        let character = Character::standard(&rig);
        let input = landmark_frame(&rig, &character, &pose, 0);
        let (a, _) = convert_one(&rig, &input);
        for (rotation, exempt) in [(crate::skeleton::geom::yaw_rotation(yaw), vec!["root"]), (tilt, vec!["root", "spine0", "pelvis"])] {
            let mut turned = input.clone();
            let about = Translation3::new(0.3, -0.2, 1.0);
            for p in &mut turned.positions_m { *p = about * (rotation * (about.inverse() * *p)); }
            let (b, _) = convert_one(&rig, &turned);
            for (i, (qa, qb)) in a.local_rotations.iter().zip(&b.local_rotations).enumerate() {
                if exempt.contains(&rig.bones[i].name.as_str()) { continue; }
                prop_assert!(rotation_distance(qa, qb) < 1e-7, "{} changed by {}", rig.bones[i].name, rotation_distance(qa, qb));
            }
        }
    }

    /// Law: every output quaternion is unit-norm and finite, whatever the input — including
    /// NaN, missing and coincident joints.
    #[test]
    fn output_is_always_finite_and_unit(
        pose in arb_pose(),
        damage in proptest::collection::vec((0usize..200, 0u8..4), 0..40),
    ) {
        let rig = Rig::standard();
        let character = Character::standard(&rig);
        let mut frame = landmark_frame(&rig, &character, &pose, 0);
        let n = frame.positions_m.len();
        for (j, kind) in damage {
            let j = j % n;
            match kind {
                0 => frame.positions_m[j] = Point3::new(f64::NAN, 0.0, 0.0),
                1 => frame.confidence[j] = 0.0,
                2 => frame.positions_m[j] = frame.positions_m[(j + 1) % n],
                _ => frame.positions_m[j] = Point3::new(f64::INFINITY, 1.0, 2.0),
            }
        }
        let layout = Layout::rig_landmarks(&rig);
        let mut c = Converter::new(&rig, &layout, &character, ConvertOptions::default()).unwrap();
        let mut out = BonePose::rest(&rig);
        for stamp in 0..3 {
            frame.stamp_nanos = stamp;
            c.convert_frame(&frame, &mut out).unwrap();
            for q in &out.local_rotations {
                prop_assert!(q.coords.iter().all(|v| v.is_finite()));
                prop_assert!((q.norm() - 1.0).abs() < 1e-9);
            }
            prop_assert!(out.root_translation_m.iter().all(|v| v.is_finite()));
        }
    }
}

#[test]
fn rest_pose_converts_to_identity() {
    let rig = Rig::standard();
    let character = Character::standard(&rig);
    let frame = landmark_frame(&rig, &character, &BonePose::rest(&rig), 0);
    let (pose, report) = convert_one(&rig, &frame);
    for (b, q) in pose.local_rotations.iter().enumerate() {
        assert!(
            q.angle() < 1e-9,
            "{} is {} rad from rest",
            rig.bones[b].name,
            q.angle()
        );
    }
    assert!(pose.root_translation_m.norm() < 1e-9);
    // Straight arms and legs: the bend planes are undefined, and that is counted.
    assert_eq!(
        report.events[Degeneracy::ParallelReference as usize],
        4,
        "{report:?}"
    );
    assert!(report.coverage.at_rest.is_empty() && report.coverage.twist_unobserved.is_empty());
}

#[test]
fn hemisphere_stays_continuous_through_a_full_turn() {
    // A body turning on the spot through ±180° yaw: the reference code's quaternions flipped sign
    // here; ours keep ⟨q_t, q_t−1⟩ ≥ 0 for every bone.
    let rig = Rig::standard();
    let character = Character::standard(&rig);
    let layout = Layout::rig_landmarks(&rig);
    let mut c = Converter::new(&rig, &layout, &character, ConvertOptions::default()).unwrap();
    let mut out = BonePose::rest(&rig);
    let mut previous: Option<BonePose> = None;
    for k in 0..200u32 {
        let mut pose = BonePose::rest(&rig);
        pose.local_rotations[ROOT] = crate::skeleton::geom::yaw_rotation(f64::from(k) * 0.05);
        let arm = rig.bone_index("l_upper_arm").unwrap();
        pose.local_rotations[arm] =
            UnitQuaternion::from_euler_angles(0.3, f64::from(k) * 0.07, 0.2);
        let frame = landmark_frame(&rig, &character, &pose, u64::from(k));
        c.convert_frame(&frame, &mut out).unwrap();
        if let Some(p) = &previous {
            for (b, (q, r)) in out
                .local_rotations
                .iter()
                .zip(&p.local_rotations)
                .enumerate()
            {
                assert!(
                    q.as_ref().dot(r.as_ref()) >= 0.0,
                    "frame {k}: {} flipped",
                    rig.bones[b].name
                );
            }
        }
        previous = Some(out.clone());
    }
}

#[test]
fn straight_limb_keeps_the_previous_twist() {
    let rig = Rig::standard();
    let character = Character::standard(&rig);
    let layout = Layout::rig_landmarks(&rig);
    let mut c = Converter::new(&rig, &layout, &character, ConvertOptions::default()).unwrap();
    let arm = rig.bone_index("l_upper_arm").unwrap();
    let forearm = rig.bone_index("l_forearm").unwrap();
    let twist = UnitQuaternion::from_axis_angle(&rig.bones[arm].rest_direction(), 1.2);
    let mut bent = BonePose::rest(&rig);
    bent.local_rotations[arm] = twist;
    bent.local_rotations[forearm] = match rig.bones[forearm].dof {
        Dof::Hinge { axis } => UnitQuaternion::from_axis_angle(&axis, 0.8),
        _ => unreachable!(),
    };
    let mut straight = bent.clone();
    straight.local_rotations[forearm] = UnitQuaternion::identity();
    let mut out = BonePose::rest(&rig);
    c.convert_frame(&landmark_frame(&rig, &character, &bent, 0), &mut out)
        .unwrap();
    assert!(rotation_distance(&out.local_rotations[arm], &twist) < 1e-9);
    c.convert_frame(&landmark_frame(&rig, &character, &straight, 1), &mut out)
        .unwrap();
    assert!(
        rotation_distance(&out.local_rotations[arm], &twist) < 1e-9,
        "twist lost on a straight arm"
    );
    assert_eq!(c.report().bone_degenerate_frames[arm], 1);
}

#[test]
fn missing_joints_hold_the_previous_frame_and_are_counted() {
    let rig = Rig::standard();
    let character = Character::standard(&rig);
    let layout = Layout::rig_landmarks(&rig);
    let mut c = Converter::new(&rig, &layout, &character, ConvertOptions::default()).unwrap();
    let calf = rig.bone_index("l_calf").unwrap();
    let mut pose = BonePose::rest(&rig);
    pose.local_rotations[calf] = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -0.5);
    let good = landmark_frame(&rig, &character, &pose, 0);
    let mut out = BonePose::rest(&rig);
    c.convert_frame(&good, &mut out).unwrap();
    let held = out.local_rotations[calf];
    let mut bad = landmark_frame(&rig, &character, &BonePose::rest(&rig), 1);
    let ankle = rig.landmark_index("l_ankle").unwrap();
    bad.positions_m[ankle] = Point3::new(f64::NAN, f64::NAN, f64::NAN);
    c.convert_frame(&bad, &mut out).unwrap();
    assert!(rotation_distance(&out.local_rotations[calf], &held) < 1e-12);
    let low = {
        let mut f = bad.clone();
        f.positions_m[ankle] = good.positions_m[ankle];
        f.confidence[ankle] = 0.1;
        f
    };
    c.convert_frame(&low, &mut out).unwrap();
    let r = c.report();
    assert!(r.events[Degeneracy::MissingJoint as usize] >= 1);
    assert!(r.events[Degeneracy::LowConfidence as usize] >= 1);
    assert_eq!(
        r.degenerate_frames,
        2 + 1,
        "frame 0 has straight limbs; frames 1 and 2 lost the ankle: {r:?}"
    );
}

#[test]
fn sequences_drop_and_report_non_monotonic_stamps() {
    let rig = Rig::standard();
    let character = Character::standard(&rig);
    let layout = Layout::rig_landmarks(&rig);
    let frames: Vec<PoseFrame> = [0u64, 10, 10, 5, 20]
        .iter()
        .map(|&s| landmark_frame(&rig, &character, &BonePose::rest(&rig), s))
        .collect();
    let seq = PoseSequence {
        source: "synthetic".into(),
        track_id: 0,
        joint_names: layout.joints.clone(),
        frames,
    };
    let anim = convert_sequence(&rig, &layout, &seq, ConvertOptions::default()).unwrap();
    assert_eq!(anim.frames.len(), 3);
    assert_eq!(anim.report.dropped_non_monotonic, vec![(2, 10), (3, 5)]);
    assert!(anim.report.lost_input());
}

#[test]
fn wrong_joint_count_is_an_error_naming_the_frame() {
    let rig = Rig::standard();
    let layout = Layout::rig_landmarks(&rig);
    let mut frames = vec![
        PoseFrame::missing(0, layout.joints.len()),
        PoseFrame::missing(1, 3),
    ];
    frames[0].confidence[0] = 1.0;
    let seq = PoseSequence {
        source: "clip.json".into(),
        track_id: 0,
        joint_names: layout.joints.clone(),
        frames,
    };
    let err = convert_sequence(&rig, &layout, &seq, ConvertOptions::default()).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("clip.json") && msg.contains("frame 1"),
        "{msg}"
    );
}

#[test]
fn retargeting_keeps_directions_and_feet_on_the_ground() {
    use crate::skeleton::character::Proportions;
    let rig = Rig::standard();
    let source = Character::standard(&rig);
    let mut pose = BonePose::rest(&rig);
    let thigh = rig.bone_index("l_thigh").unwrap();
    pose.local_rotations[thigh] = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.6);
    pose.root_translation_m = Vector3::new(0.4, 1.0, 0.0);
    let frame = landmark_frame(&rig, &source, &pose, 0);
    let seq = PoseSequence {
        source: "t".into(),
        track_id: 0,
        joint_names: Layout::rig_landmarks(&rig).joints,
        frames: vec![frame],
    };
    let anim = convert_sequence(
        &rig,
        &Layout::rig_landmarks(&rig),
        &seq,
        ConvertOptions::default(),
    )
    .unwrap();
    let src_world = fk::forward(&rig, &anim.character, &anim.frames[0].pose, 1.0);
    let lowest = |c: &Character, w: &fk::WorldPose| {
        ["r_heel", "r_toe", "r_big_toe", "r_small_toe"]
            .iter()
            .map(|n| fk::landmark_position(&rig, c, w, rig.landmark_index(n).unwrap()).z)
            .fold(f64::INFINITY, f64::min)
    };
    let src_low = lowest(&anim.character, &src_world);
    for target in [
        Character::with_proportions(
            &rig,
            Proportions {
                height_m: 0.8 * 1.75,
                ..Proportions::default()
            },
        ),
        Character::with_proportions(
            &rig,
            Proportions {
                height_m: 1.25 * 1.75,
                ..Proportions::default()
            },
        ),
        Character::with_proportions(
            &rig,
            Proportions {
                arm_scale: 1.2,
                leg_scale: 0.85,
                torso_scale: 1.1,
                ..Proportions::default()
            },
        ),
    ] {
        let scale = anim.translation_scale_for(&rig, &target);
        let w = fk::forward(&rig, &target, &anim.frames[0].pose, scale);
        for (b, bone) in rig.bones.iter().enumerate() {
            let Some(p) = bone.parent else { continue };
            let d_src = src_world.heads_m[b] - src_world.heads_m[p];
            let d_tgt = w.heads_m[b] - w.heads_m[p];
            if d_src.norm() > 1e-6 {
                assert!(
                    angle_deg(&d_src, &d_tgt) < 1e-9,
                    "{} direction changed",
                    bone.name
                );
            }
        }
        // The standing foot is on the ground for every body (soles scale with the foot).
        let low = lowest(&target, &w);
        assert!(
            low.abs() < 0.02
                && (low - src_low * target.bone_scale[rig.bone_index("r_foot").unwrap()]).abs()
                    < 1e-9,
            "lowest foot point at {low} m"
        );
    }
}

/// A pose whose pelvis rolls, tilts and turns and whose clavicles swing as mirror images (a
/// shrug, a protraction), with the spine at rest: the spine's twist is seen on the shoulder line,
/// which mirrored swings keep parallel to the chest, while one-sided swings turn it too.
fn arb_pelvis_and_clavicle_pose() -> impl Strategy<Value = BonePose> {
    (arb_pose(), arb_rotation(0.8), arb_rotation(0.6)).prop_map(|(mut pose, pelvis, l_clav)| {
        // Mirror x → −x of a rotation: (w, x, y, z) → (w, x, −y, −z).
        let r_clav = UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(
            l_clav.w, l_clav.i, -l_clav.j, -l_clav.k,
        ));
        let rig = Rig::standard();
        let idx = |n: &str| rig.bone_index(n).unwrap();
        for spine in ["spine0", "spine1", "spine2", "spine3"] {
            pose.local_rotations[idx(spine)] = UnitQuaternion::identity();
        }
        pose.local_rotations[idx("pelvis")] = pelvis;
        for (name, q) in [("l_clavicle", l_clav), ("r_clavicle", r_clav)] {
            let b = idx(name);
            let d = rig.bones[b].rest_direction();
            pose.local_rotations[b] = crate::skeleton::geom::swing_twist(&q, &d).0;
        }
        pose
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Law (issue 19): with the default DoF set a rolling pelvis and swinging clavicles put the
    /// hips, the shoulders and everything below them back where they were, to a micrometre;
    /// `DofSet::Paper` holds the pelvis and the clavicles at rest.
    #[test]
    fn pelvis_roll_and_clavicle_swing_are_reproduced(pose in arb_pelvis_and_clavicle_pose()) {
        let rig = Rig::standard();
        let character = Character::standard(&rig);
        let input = landmark_frame(&rig, &character, &pose, 0);
        let (solved, _) = convert_one(&rig, &input);
        let output = landmark_frame(&rig, &character, &solved, 0);
        for (l, (p, q)) in input.positions_m.iter().zip(&output.positions_m).enumerate() {
            prop_assert!((p - q).norm() < 1e-6, "{} off by {} m", rig.landmarks[l].name, (p - q).norm());
        }
        let paper = ConvertOptions { dof: DofSet::Paper, ..ConvertOptions::default() };
        let layout = Layout::rig_landmarks(&rig);
        let mut c = Converter::new(&rig, &layout, &character, paper).unwrap();
        let mut held = BonePose::rest(&rig);
        c.convert_frame(&input, &mut held).unwrap();
        for name in crate::skeleton::rig::PAPER_STATIC_BONES {
            let b = rig.bone_index(name).unwrap();
            prop_assert!(held.local_rotations[b].angle() < 1e-12, "{name} moved with --dof paper");
            prop_assert!(!c.report().coverage.driven.iter().any(|n| n == name));
            prop_assert!(c.report().coverage.at_rest.iter().any(|n| n == name));
        }
    }
}

#[test]
fn a_shrug_lifts_the_shoulder_through_the_clavicle_only() {
    let rig = Rig::standard();
    let character = Character::standard(&rig);
    let clavicle = rig.bone_index("l_clavicle").unwrap();
    let mut pose = BonePose::rest(&rig);
    // 20° about the forward axis: the left shoulder (at −X) rises.
    pose.local_rotations[clavicle] =
        UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 20f64.to_radians());
    let input = landmark_frame(&rig, &character, &pose, 0);
    let shoulder = rig.landmark_index("l_shoulder").unwrap();
    assert!(input.positions_m[shoulder].z > 1.44 + 0.05);
    let (solved, _) = convert_one(&rig, &input);
    assert!(
        rotation_distance(
            &solved.local_rotations[clavicle],
            &pose.local_rotations[clavicle]
        ) < 1e-9
    );
    let upper_arm = rig.bone_index("l_upper_arm").unwrap();
    let spine3 = rig.bone_index("spine3").unwrap();
    // A one-sided shrug leaves the shoulder line's projection across the spine as it was: the
    // spine does not turn, and the upper arm rides on the clavicle.
    for b in [upper_arm, spine3] {
        assert!(
            solved.local_rotations[b].angle() < 1e-9,
            "{}",
            rig.bones[b].name
        );
    }
}
