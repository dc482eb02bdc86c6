use nalgebra::{UnitQuaternion, Vector3};

use super::*;
use crate::skeleton::rig::ROOT;

/// A clip that turns, walks and bends: root yaw from 150°, moving root, a bending elbow and
/// knee, a twisting spine, everything else still.
pub(crate) fn moving_clip(rig: &Rig, frames: usize) -> Clip {
    let bone = |n: &str| rig.bone_index(n).unwrap();
    let poses: Vec<BonePose> = (0..frames)
        .map(|k| {
            #[expect(clippy::cast_precision_loss, reason = "test")]
            let t = k as f64 / 30.0;
            let mut pose = BonePose::rest(rig);
            pose.root_translation_m = Vector3::new(0.3 + 0.5 * t, -1.0 + 0.2 * t, 0.02 * t.sin());
            pose.local_rotations[ROOT] =
                crate::skeleton::geom::yaw_rotation((150.0 + 40.0 * t).to_radians());
            pose.local_rotations[bone("l_forearm")] =
                UnitQuaternion::from_axis_angle(&-Vector3::z_axis(), 0.2 + t.sin().abs());
            pose.local_rotations[bone("r_calf")] =
                UnitQuaternion::from_axis_angle(&-Vector3::x_axis(), 0.8 * t.sin().abs());
            pose.local_rotations[bone("spine2")] =
                UnitQuaternion::from_euler_angles(0.1 * t, -0.2 * t.cos(), 0.3 * t.sin());
            pose.local_rotations[bone("r_upper_arm")] =
                UnitQuaternion::from_euler_angles(1.0 + t, 0.5, -2.0 * t);
            pose
        })
        .collect();
    Clip {
        key: AnimationKey {
            track_id: 4,
            variant: 1,
        },
        fps_hz: 30.0,
        character: Character::standard(rig),
        stamps_nanos: (0..poses.len() as u64)
            .map(|k| 1_000 + k * 33_333_333)
            .collect(),
        poses,
        scene: None,
    }
}

fn listing(track_id: u64, variant: u32) -> AnimationListing {
    AnimationListing {
        key: AnimationKey { track_id, variant },
        rig: "autoact53".to_string(),
        frames: 10,
        first_stamp_nanos: 0,
        last_stamp_nanos: 300_000_000,
        frame_rate_hz: Some(30.0),
    }
}

#[test]
fn select_picks_by_track_and_variant_and_names_what_exists() {
    let all = [listing(0, 0), listing(0, 1), listing(2, 0)];
    let bag = Path::new("x.anim.mcap");
    let keys = |t, v| select(bag, &all, t, v).unwrap();
    assert_eq!(keys(None, None).len(), 3);
    assert_eq!(keys(Some(0), None).len(), 2);
    assert_eq!(keys(None, Some(0)).len(), 2);
    assert_eq!(
        keys(Some(0), Some(1)),
        vec![AnimationKey {
            track_id: 0,
            variant: 1
        }]
    );
    let e = select(bag, &all, Some(7), None).unwrap_err().to_string();
    assert_eq!(
        e,
        "x.anim.mcap: no animation with track 7; the bag holds: track 0 variant 0, track 0 variant 1, track 2 variant 0"
    );
    let e = select(bag, &all, Some(2), Some(1)).unwrap_err().to_string();
    assert!(e.contains("track 2 variant 1"), "{e}");
}

#[test]
fn output_names_are_safe_and_unique_per_animation() {
    let key = AnimationKey {
        track_id: 3,
        variant: 2,
    };
    let name = |bag: &str, f| output_name(Path::new(bag), key, None, f);
    assert_eq!(
        name("bags/bandai_wave.anim.mcap", ExportFormat::Bvh),
        "bandai_wave_track3_v2.bvh"
    );
    assert_eq!(
        name("/x/session 1;rm.mcap", ExportFormat::Onim),
        "session_1_rm_track3_v2.onim"
    );
    assert_eq!(
        name("run_anim", ExportFormat::Bvh),
        "run_anim_track3_v2.bvh"
    );
    assert_eq!(name("/", ExportFormat::Bvh), "animation_track3_v2.bvh");
    // One file per scene of a capture bag, named by the scene's index on the timeline.
    let scene = super::ClipScene {
        index: 1,
        scene_id: "gesture/wave/bandai_wave/v2/s1".into(),
        first_timeline_frame: 651,
    };
    assert_eq!(
        output_name(
            Path::new("out/demo_gesture_wave_0000.capture.mcap"),
            key,
            Some(&scene),
            ExportFormat::Glb
        ),
        "demo_gesture_wave_0000_track3_v2_scene1.glb"
    );
}

#[test]
fn frame_rate_is_stated_or_measured() {
    assert_eq!(frame_rate(Some(25.0), &[]), Some(25.0));
    let stamps: Vec<u64> = (0..10).map(|k| k * 33_333_333).collect();
    let fps = frame_rate(None, &stamps).unwrap();
    assert!((fps - 30.0).abs() < 1e-3, "{fps}");
    assert_eq!(frame_rate(None, &[5]), None);
    assert_eq!(first_uneven_frame(&stamps, 30.0), None);
    let gap = [0, 33_333_333, 66_666_667, 1_000_000_000];
    let (k, off) = first_uneven_frame(&gap, 30.0).unwrap();
    assert_eq!(k, 3);
    assert!((off - 0.9).abs() < 1e-6, "{off}");
}

#[test]
fn atomic_writes_refuse_to_replace_unless_forced() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.bvh");
    write_atomically(&path, b"one", false).unwrap();
    let e = write_atomically(&path, b"two", false).unwrap_err();
    assert!(matches!(e, ExportError::OutputExists(_)));
    assert!(e.to_string().contains("--force"), "{e}");
    assert_eq!(std::fs::read(&path).unwrap(), b"one");
    write_atomically(&path, b"two", true).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"two");
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "no partial file left: {names:?}");
    let e = write_atomically(&dir.path().join("no/such/dir/a.bvh"), b"x", false).unwrap_err();
    assert!(matches!(e, ExportError::Io { .. }));
    assert!(e.to_string().contains("no/such/dir"), "{e}");
}
