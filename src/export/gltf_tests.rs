use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::*;
use crate::export::tests::moving_clip;

/// The GLB's JSON chunk, parsed.
fn glb_json(bytes: &[u8]) -> Value {
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    assert_eq!(&bytes[16..20], b"JSON");
    serde_json::from_slice(&bytes[20..20 + len]).unwrap()
}

fn camera_context(frames: usize) -> SceneContext {
    #[expect(clippy::cast_precision_loss, reason = "test")]
    let world_from_optical = (0..frames)
        .map(|k| {
            Isometry3::from_parts(
                Translation3::new(3.0, -2.0 + 0.1 * k as f64, 1.5),
                UnitQuaternion::from_euler_angles(-1.7, 0.1, 0.3 + 0.05 * k as f64),
            )
        })
        .collect();
    let mut extras = BTreeMap::new();
    extras.insert("label".into(), json!("walk"));
    extras.insert("seed".into(), json!(7));
    SceneContext {
        camera: Some(CameraPath {
            yfov_rad: 0.9,
            aspect_ratio: 16.0 / 9.0,
            world_from_optical,
        }),
        look: None,
        extras,
    }
}

#[test]
fn glb_reads_back_with_the_rig_skin_and_one_rotation_per_bone_per_frame() {
    let rig = Rig::standard();
    let clip = moving_clip(&rig, 12);
    let bytes = write(&rig, &clip, &SceneContext::default(), Container::Glb);
    assert_eq!(bytes.len() % 4, 0);
    assert_eq!(
        u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
        bytes.len()
    );
    let doc = ::gltf::Gltf::from_slice(&bytes).unwrap();
    let blob = doc.blob.clone().unwrap();
    let skin = doc.skins().next().unwrap();
    assert_eq!(skin.joints().count(), rig.bones.len());
    let rest = fk::forward(&rig, &clip.character, &BonePose::rest(&rig), 1.0);
    let ibm: Vec<[[f32; 4]; 4]> = skin
        .reader(|_| Some(&blob))
        .read_inverse_bind_matrices()
        .unwrap()
        .collect();
    for (b, m) in ibm.iter().enumerate() {
        let h = rest.heads_m[b];
        assert!((f64::from(m[3][0]) + h.x).abs() < 1e-6, "bone {b}");
        assert!((f64::from(m[3][2]) + h.z).abs() < 1e-6, "bone {b}");
    }
    let animation = doc.animations().next().unwrap();
    assert_eq!(animation.channels().count(), rig.bones.len() + 1);
    for channel in animation.channels() {
        let node = channel.target().node().index();
        let reader = channel.reader(|_| Some(&blob));
        let times: Vec<f32> = reader.read_inputs().unwrap().collect();
        assert_eq!(times.len(), clip.poses.len());
        assert!((f64::from(times[11]) - 11.0 / 30.0).abs() < 1e-6);
        match reader.read_outputs().unwrap() {
            ::gltf::animation::util::ReadOutputs::Rotations(r) => {
                let bone = node - 1;
                for (k, q) in r.into_f32().enumerate() {
                    let want = clip.poses[k].local_rotations[bone].coords;
                    let same = (0..4).all(|i| (f64::from(q[i]) - want[i]).abs() < 1e-6);
                    let opposite = (0..4).all(|i| (f64::from(q[i]) + want[i]).abs() < 1e-6);
                    assert!(same || opposite, "bone {bone} frame {k}: {q:?} vs {want:?}");
                }
            }
            ::gltf::animation::util::ReadOutputs::Translations(t) => {
                assert_eq!(node, joint_node(ROOT));
                for (k, p) in t.enumerate() {
                    let want = rest.heads_m[ROOT].coords + clip.poses[k].root_translation_m;
                    assert!((f64::from(p[1]) - want.y).abs() < 1e-6, "frame {k}");
                }
            }
            _ => panic!("unexpected channel"),
        }
    }
    assert_eq!(doc.cameras().count(), 0);
}

#[test]
fn the_camera_node_follows_the_camera_path_looking_down_the_optical_axis() {
    let rig = Rig::standard();
    let clip = moving_clip(&rig, 5);
    let context = camera_context(5);
    let bytes = write(&rig, &clip, &context, Container::Glb);
    let doc = ::gltf::Gltf::from_slice(&bytes).unwrap();
    let blob = doc.blob.clone().unwrap();
    let camera = doc.nodes().find(|n| n.camera().is_some()).unwrap();
    let animation = doc.animations().next().unwrap();
    assert_eq!(animation.channels().count(), rig.bones.len() + 3);
    let rotations: Vec<[f32; 4]> = animation
        .channels()
        .filter(|c| c.target().node().index() == camera.index())
        .find_map(|c| match c.reader(|_| Some(&blob)).read_outputs() {
            Some(::gltf::animation::util::ReadOutputs::Rotations(r)) => {
                Some(r.into_f32().collect())
            }
            _ => None,
        })
        .unwrap();
    let path = context.camera.as_ref().unwrap();
    for (k, q) in rotations.iter().enumerate() {
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            f64::from(q[3]),
            f64::from(q[0]),
            f64::from(q[1]),
            f64::from(q[2]),
        ));
        // glTF's camera looks down its −z: that must be the optical +z.
        let forward = q * -Vector3::z();
        let optical = path.world_from_optical[k].rotation * Vector3::z();
        assert!((forward - optical).norm() < 1e-6, "frame {k}");
        let up = q * Vector3::y();
        let optical_up = path.world_from_optical[k].rotation * -Vector3::y();
        assert!((up - optical_up).norm() < 1e-6, "frame {k}");
    }
    let gltf_camera = camera.camera().unwrap();
    let projection = gltf_camera.projection();
    let ::gltf::camera::Projection::Perspective(p) = projection else {
        panic!("not perspective")
    };
    assert!((p.yfov() - 0.9).abs() < 1e-6);
    let json = glb_json(&bytes);
    assert_eq!(json["scenes"][0]["extras"]["autoact"]["label"], "walk");
    assert_eq!(json["scenes"][0]["extras"]["autoact"]["seed"], 7);
}

#[test]
fn the_world_node_turns_z_up_to_y_up_and_the_mesh_has_a_primitive_per_material() {
    let rig = Rig::standard();
    let clip = moving_clip(&rig, 2);
    let json = glb_json(&write(
        &rig,
        &clip,
        &SceneContext::default(),
        Container::Glb,
    ));
    let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
        f64::from(Y_UP_FROM_Z_UP[3]),
        f64::from(Y_UP_FROM_Z_UP[0]),
        f64::from(Y_UP_FROM_Z_UP[1]),
        f64::from(Y_UP_FROM_Z_UP[2]),
    ));
    assert!((q * Vector3::z() - Vector3::y()).norm() < 1e-6);
    assert_eq!(json["nodes"][0]["name"], "autoact_world");
    assert_eq!(json["scenes"][0]["nodes"], json!([0, rig.bones.len() + 1]));
    let names: Vec<&str> = json["materials"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["skin", "hair", "top", "bottom", "shoes", "eye"]);
    assert_eq!(json["meshes"][0]["primitives"].as_array().unwrap().len(), 6);
}

#[test]
fn gltf_and_glb_hold_the_same_document_and_exports_are_identical() {
    let rig = Rig::standard();
    let clip = moving_clip(&rig, 4);
    let context = camera_context(4);
    let glb = write(&rig, &clip, &context, Container::Glb);
    assert_eq!(glb, write(&rig, &clip, &context, Container::Glb));
    let text = write(&rig, &clip, &context, Container::Gltf);
    assert_eq!(text, write(&rig, &clip, &context, Container::Gltf));
    let mut from_text: Value = serde_json::from_slice(&text).unwrap();
    let uri = from_text["buffers"][0]["uri"].take();
    assert!(
        uri.as_str()
            .unwrap()
            .starts_with("data:application/octet-stream;base64,")
    );
    from_text["buffers"][0]
        .as_object_mut()
        .unwrap()
        .remove("uri");
    assert_eq!(from_text, glb_json(&glb));
}

#[test]
fn base64_matches_rfc_4648_test_vectors() {
    for (input, want) in [
        ("", ""),
        ("f", "Zg=="),
        ("fo", "Zm8="),
        ("foo", "Zm9v"),
        ("foob", "Zm9vYg=="),
        ("fooba", "Zm9vYmE="),
        ("foobar", "Zm9vYmFy"),
    ] {
        assert_eq!(base64(input.as_bytes()), want);
    }
}
