use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;

use super::*;
use crate::export::tests::moving_clip;
use crate::formats::bvh::{Channel, parse};

fn quaternion(a: f64, b: f64, c: f64, d: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(a, b, c, d))
}

proptest! {
    #[test]
    fn euler_zxy_recomposes_exactly(
        a in -1.0..1.0f64, b in -1.0..1.0f64, c in -1.0..1.0f64, d in -1.0..1.0f64,
        p in prop::array::uniform3(-7.0..7.0f64),
    ) {
        prop_assume!(a * a + b * b + c * c + d * d > 1e-3);
        let q = quaternion(a, b, c, d);
        for previous in [None, Some(p)] {
            let angles = euler_zxy(&q, previous);
            let back = rotation_from_euler_zxy_deg(angles.map(f64::to_degrees));
            prop_assert!(crate::skeleton::geom::rotation_distance(&q, &back) < 1e-9, "{angles:?}");
        }
        let principal = euler_zxy(&q, None);
        prop_assert!(principal[1].abs() <= std::f64::consts::FRAC_PI_2 + 1e-12);
    }
}

#[test]
fn euler_zxy_handles_gimbal_lock() {
    for x_deg in [90.0, -90.0] {
        let q = rotation_from_euler_zxy_deg([30.0, x_deg, 20.0]);
        for previous in [None, Some([0.5, 1.5, 0.3])] {
            let back = rotation_from_euler_zxy_deg(euler_zxy(&q, previous).map(f64::to_degrees));
            assert!(crate::skeleton::geom::rotation_distance(&q, &back) < 1e-9);
        }
    }
}

#[test]
fn euler_angles_stay_continuous_through_a_full_turn() {
    // Yaw about the file's Y (the vertical) from 0° to 720°, with a tilt: no jumps.
    let mut previous = None;
    let mut last = 0.0;
    for k in 0..=720 {
        let q = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), f64::from(k).to_radians())
            * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.3);
        let angles = euler_zxy(&q, previous);
        if let Some(before) = previous {
            for (a, p) in angles.iter().zip(before) {
                assert!(
                    (a - p).abs() < 2f64.to_radians(),
                    "frame {k}: {angles:?} after {p}"
                );
            }
        }
        previous = Some(angles);
        last = angles[2].to_degrees();
    }
    assert!((last - 720.0).abs() < 1e-6, "unwrapped to {last}");
}

#[test]
fn numbers_never_read_minus_zero() {
    assert_eq!(number(-0.0, 6), "0.000000");
    assert_eq!(number(-1e-9, 6), "0.000000");
    assert_eq!(number(-1.5e-6, 6), "-0.000002");
    assert_eq!(number(12.25, 2), "12.25");
}

#[test]
fn written_bvh_has_the_rig_hierarchy_in_centimetres_y_up() {
    let rig = Rig::standard();
    let clip = moving_clip(&rig, 12);
    let text = write(&rig, &clip);
    let bvh = parse(&text, "t.bvh").unwrap();
    let joints: Vec<_> = bvh.joints.iter().filter(|j| !j.is_end_site).collect();
    assert_eq!(joints.len(), rig.bones.len());
    for (j, &b) in joints.iter().zip(&joint_order(&rig)) {
        assert_eq!(j.name, rig.bones[b].name);
        let parent = j.parent.map(|p| bvh.joints[p].name.as_str());
        assert_eq!(
            parent,
            rig.bones[b].parent.map(|p| rig.bones[p].name.as_str())
        );
        let expected: &[Channel] = if b == ROOT {
            &[
                Channel::Xposition,
                Channel::Yposition,
                Channel::Zposition,
                Channel::Zrotation,
                Channel::Xrotation,
                Channel::Yrotation,
            ]
        } else {
            &[Channel::Zrotation, Channel::Xrotation, Channel::Yrotation]
        };
        assert_eq!(j.channels, expected, "{}", j.name);
    }
    assert_eq!(bvh.frame_count(), 12);
    assert!((bvh.frame_time_secs - 1.0 / 30.0).abs() < 1e-9);
    // Zero channels = the T-pose, standing on y = 0, 175 cm tall, facing +Z, left hand at +X.
    let rest = bvh.rest_positions();
    let head = bvh.joint_index("head").unwrap();
    let l_hand = bvh.joint_index("l_hand").unwrap();
    assert!((rest[head] - nalgebra::Point3::new(0.0, 154.0, 0.0)).norm() < 1e-6);
    assert!((rest[l_hand] - nalgebra::Point3::new(71.0, 144.0, 0.0)).norm() < 1e-6);
    let head_end = bvh.joint_index("head_End").unwrap();
    assert!((rest[head_end].y - 175.0).abs() < 1e-6);
    assert_eq!(
        bvh.guess_metres_per_unit(),
        Some(0.01),
        "autoact's reader reads it as cm"
    );
}

#[test]
fn bvh_round_trip_gives_back_the_rotations_and_the_root() {
    let rig = Rig::standard();
    let clip = moving_clip(&rig, 90);
    let bvh = parse(&write(&rig, &clip), "t.bvh").unwrap();
    let back = read_back(&rig, &bvh).unwrap();
    assert_eq!(back.len(), clip.poses.len());
    let mut worst: f64 = 0.0;
    for (a, b) in back.iter().zip(&clip.poses) {
        for (qa, qb) in a.local_rotations.iter().zip(&b.local_rotations) {
            worst = worst.max(crate::skeleton::geom::rotation_distance(qa, qb));
        }
        assert!((a.root_translation_m - b.root_translation_m).norm() < 1e-7);
    }
    assert!(worst.to_degrees() < 1e-4, "worst {}°", worst.to_degrees());
}

#[test]
fn bvh_forward_kinematics_reproduces_autoacts_joints() {
    let rig = Rig::standard();
    let clip = moving_clip(&rig, 40);
    let bvh = parse(&write(&rig, &clip), "t.bvh").unwrap();
    let seq = bvh.to_pose_sequence(1.0 / UNITS_PER_METRE, SourceAxes::YUp);
    for (frame, pose) in seq.frames.iter().zip(&clip.poses) {
        let world = fk::forward(&rig, &clip.character, pose, 1.0);
        for (b, bone) in rig.bones.iter().enumerate() {
            let j = bvh.joint_index(&bone.name).unwrap();
            let d = (frame.positions_m[j] - world.heads_m[b]).norm();
            assert!(d < 1e-6, "{}: {d} m", bone.name);
        }
    }
}

#[test]
fn read_back_names_a_missing_joint() {
    let rig = Rig::standard();
    let text = "HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 3 Zrotation Xrotation Yrotation\n\tEnd Site\n\t{\n\t\tOFFSET 0 1 0\n\t}\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n0 0 0\n";
    let bvh = parse(text, "other.bvh").unwrap();
    let e = read_back(&rig, &bvh).unwrap_err().to_string();
    assert!(e.contains("other.bvh") && e.contains("`root`"), "{e}");
}

#[test]
fn expected_json_lists_joints_and_positions_in_file_order() {
    let rig = Rig::standard();
    let clip = moving_clip(&rig, 3);
    let json = expected_json(&rig, &clip);
    assert_eq!(json["joints"].as_array().unwrap().len(), 53);
    assert_eq!(json["joints"][0], "root");
    assert_eq!(json["frames"], 3);
    assert_eq!(json["euler_order"], "ZXY");
    assert_eq!(json["positions_m"][2].as_array().unwrap().len(), 53);
}
