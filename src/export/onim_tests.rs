use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::*;
use crate::export::tests::moving_clip;
use crate::skeleton::rig::Dof;

/// The frame with +X along `x` and +Z as near `z_hint` as the bone allows.
fn frame_x_z(x: Vector3<f64>, z_hint: Vector3<f64>) -> Matrix3<f64> {
    let x = x.normalize();
    let y = z_hint.cross(&x).normalize();
    Matrix3::from_columns(&[x, y, x.cross(&y)])
}

/// The frame with +X along `x` and +Y as near `y_hint` as the bone allows.
fn frame_x_y(x: Vector3<f64>, y_hint: Vector3<f64>) -> Matrix3<f64> {
    let x = x.normalize();
    let z = x.cross(&y_hint).normalize();
    Matrix3::from_columns(&[x, z.cross(&x), z])
}

/// scipy's extrinsic `xyz` Euler angles in degrees: `Rz(c) · Ry(b) · Rx(a)`.
fn extrinsic_xyz_deg(a: f64, b: f64, c: f64) -> Matrix3<f64> {
    let r = |axis: Vector3<f64>, deg: f64| {
        Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), deg.to_radians())
            .into_inner()
    };
    r(Vector3::z(), c) * r(Vector3::y(), b) * r(Vector3::x(), a)
}

/// The rules `gta_ped.toml`'s header states, computed: the data file must agree with them.
fn documented_frames(rig: &Rig) -> Vec<Matrix3<f64>> {
    let right = Vector3::x();
    let forward = Vector3::y();
    let spine = frame_x_z(Vector3::z(), -right);
    rig.bones
        .iter()
        .map(|b| {
            let dir = b.rest_direction().into_inner();
            let n = b.name.as_str();
            if n == "root" {
                Matrix3::identity()
            } else if n == "pelvis" {
                frame_x_z(-Vector3::z(), right)
            } else if ["thigh", "calf", "foot"].iter().any(|s| n.ends_with(s)) {
                frame_x_z(dir, right)
            } else if n.starts_with("spine") || n == "neck" || n == "head" {
                frame_x_z(dir, -right)
            } else if n.ends_with("clavicle") {
                let euler = if n.starts_with("l_") {
                    extrinsic_xyz_deg(128.719, -67.204, -127.179)
                } else {
                    extrinsic_xyz_deg(-128.719, 67.204, -127.18)
                };
                let paper = spine * euler;
                let x = nalgebra::Unit::new_normalize(paper.column(0).into_owned());
                let swing = crate::skeleton::geom::shortest_arc(&x, &b.rest_direction());
                swing.to_rotation_matrix().into_inner() * paper
            } else if ["upper_arm", "forearm", "hand"]
                .iter()
                .any(|s| n.ends_with(s))
            {
                frame_x_y(dir, forward)
            } else {
                // Fingers.
                frame_x_z(dir, dir.cross(&-Vector3::z()))
            }
        })
        .collect()
}

/// Prints the `[frames]` section of `gta_ped.toml` from the documented rules:
/// `cargo test --lib print_documented_frames -- --ignored --nocapture`.
#[test]
#[ignore = "generator for gta_ped.toml, run by hand"]
#[expect(clippy::print_stdout, reason = "the generator's output is the point")]
fn print_documented_frames() {
    let rig = Rig::standard();
    let v = |m: &Matrix3<f64>, c: usize| {
        format!(
            "[{}, {}, {}]",
            number(m[(0, c)], 6),
            number(m[(1, c)], 6),
            number(m[(2, c)], 6)
        )
    };
    for (b, m) in rig.bones.iter().zip(documented_frames(&rig)) {
        println!("{} = {{ x = {}, y = {} }}", b.gta_name, v(&m, 0), v(&m, 1));
    }
}

#[test]
fn builtin_mapping_follows_its_documented_rules() {
    let rig = Rig::standard();
    let mapping = OnimMapping::builtin(&rig).unwrap();
    for ((b, q), m) in rig
        .bones
        .iter()
        .zip(&mapping.frames)
        .zip(documented_frames(&rig))
    {
        let data = q.to_rotation_matrix().into_inner();
        assert!((data - m).norm() < 1e-5, "{}: {data} vs {m}", b.gta_name);
        // GTA conventions: +X along the bone (but for the root), 1-D hinges about ±Z.
        if b.parent.is_some() {
            let x = data.column(0).into_owned();
            assert!(x.dot(&b.rest_direction()) > 0.99, "{}", b.gta_name);
        }
        if let Dof::Hinge { axis } = b.dof {
            let z = data.column(2).into_owned();
            assert!(
                z.dot(&axis).abs() > 0.999,
                "{}: hinge {axis:?} vs +Z {z:?}",
                b.gta_name
            );
        }
    }
}

#[test]
fn builtin_mapping_covers_the_rig_and_has_the_templates_translations() {
    let rig = Rig::standard();
    let mapping = OnimMapping::builtin(&rig).unwrap();
    assert_eq!(mapping.frames.len(), rig.bones.len());
    assert_eq!(mapping.translations.len(), 77);
    assert_eq!(
        mapping.translations[&64729],
        Vector3::new(-0.021_830_1, 0.042_174, 0.031_918_8)
    );
    assert!(
        !mapping.translations.contains_key(&4169),
        "not in the template"
    );
}

fn mapping_without(rig: &Rig, dropped: &[&str]) -> String {
    DEFAULT_MAPPING_TOML
        .lines()
        .filter(|l| !dropped.iter().any(|d| l.starts_with(&format!("{d} ="))))
        .flat_map(|l| [l, "\n"])
        .collect::<String>()
        + &format!("# for {}\n", rig.name)
}

#[test]
fn a_mapping_that_leaves_bones_out_names_them() {
    let rig = Rig::standard();
    let text = mapping_without(&rig, &["SKEL_L_Finger42", "SKEL_Head"]);
    let e = OnimMapping::from_toml(&rig, &text, "mine.toml").unwrap_err();
    let msg = e.to_string();
    assert!(
        matches!(e, OnimError::Uncovered { ref bones, .. } if bones.len() == 2),
        "{msg}"
    );
    assert!(
        msg.contains("mine.toml") && msg.contains("SKEL_Head") && msg.contains("SKEL_L_Finger42"),
        "{msg}"
    );
}

#[test]
fn bad_mapping_entries_are_named() {
    type Kind = fn(&OnimError) -> bool;
    let rig = Rig::standard();
    let template: Kind = |e| matches!(e, OnimError::Template { .. });
    let frame: Kind = |e| matches!(e, OnimError::Frame { name, .. } if name == "SKEL_ROOT");
    let toml: Kind = |e| matches!(e, OnimError::Toml { .. });
    let cases: [(&str, &str, Kind); 6] = [
        (
            "[frames]\nSKEL_Tail = { x = [1.0, 0.0, 0.0], y = [0.0, 1.0, 0.0] }\n",
            "SKEL_Tail",
            template,
        ),
        (
            "[frames]\nSKEL_ROOT = { x = [1.0, 0.0, 0.0], y = [0.5, 1.0, 0.0] }\n",
            "perpendicular",
            frame,
        ),
        (
            "[frames]\nSKEL_ROOT = { x = [0.0, 0.0, 0.0], y = [0.0, 1.0, 0.0] }\n",
            "zero",
            frame,
        ),
        (
            "[frames]\nroot = { x = [1.0, 0.0, 0.0], y = [0.0, 1.0, 0.0] }\nSKEL_ROOT = { x = [1.0, 0.0, 0.0], y = [0.0, 1.0, 0.0] }\n",
            "twice",
            template,
        ),
        (
            "[frames]\n[translations]\nhead = [0.0, 0.0, 0.0]\n",
            "not a GTA bone tag",
            template,
        ),
        ("[frame]\n", "unknown field", toml),
    ];
    for (text, needle, kind) in cases {
        let e = OnimMapping::from_toml(&rig, text, "t.toml").unwrap_err();
        assert!(kind(&e), "{text}: {e:?}");
        // What a user reads: the error and its causes.
        let mut shown = e.to_string();
        let mut cause = std::error::Error::source(&e);
        while let Some(c) = cause {
            shown = format!("{shown}: {c}");
            cause = c.source();
        }
        assert!(
            shown.contains(needle) && shown.starts_with("t.toml"),
            "{text}: {shown}"
        );
    }
}

#[test]
fn sequences_hold_128_samples_and_share_boundaries() {
    assert_eq!(sequence_lengths(1), vec![1]);
    assert_eq!(sequence_lengths(128), vec![128]);
    assert_eq!(sequence_lengths(129), vec![128, 2]);
    assert_eq!(sequence_lengths(162), vec![128, 35], "the native sample");
    assert_eq!(sequence_lengths(255), vec![128, 128]);
    assert_eq!(sequence_lengths(256), vec![128, 128, 2]);
    for n in 1..600 {
        let s = sequence_lengths(n);
        assert_eq!(s.iter().sum::<usize>() - (s.len() - 1), n, "{n}");
        assert!(
            s.iter().all(|&k| (1..=SEQUENCE_SAMPLES).contains(&k)),
            "{n}"
        );
    }
}

#[test]
fn written_onim_has_the_native_structure() {
    let rig = Rig::standard();
    let clip = moving_clip(&rig, 162);
    let mapping = OnimMapping::builtin(&rig).unwrap();
    let text = write(&rig, &clip, &mapping).unwrap();
    let file = parse(&text, "t.onim").unwrap();
    assert_eq!(file.version, (8, 2));
    assert_eq!(
        file.flags.join(" "),
        "FLAG_0 FLAG_4 FLAG_5 FLAG_6 FLAG_7 FLAG_8"
    );
    assert_eq!(file.frames, 162);
    assert_eq!(file.sequence_frame_limit, 127);
    assert!((file.duration_secs - 5.4).abs() < 1e-9, "162 / 30");
    assert_eq!(file.sequences, vec![128, 35]);
    assert!(text.contains(
        "\t_f10 0\n\tExtraFlags\n\tSequences 128 35\n\tMaterialID -1\n\tAnimation\n\t{\n"
    ));

    // Tracks by tag, position before rotation; one rotation per rig bone; the template's
    // translations; the root both moving.
    let keys: Vec<(u16, TrackKind)> = file.tracks.iter().map(|t| (t.tag, t.kind)).collect();
    let mut sorted = keys.clone();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(keys, sorted, "ordered by tag, no duplicates");
    let rotations: Vec<u16> = file
        .tracks
        .iter()
        .filter(|t| t.kind == TrackKind::Rotation)
        .map(|t| t.tag)
        .collect();
    let mut tags: Vec<u16> = rig.bones.iter().map(|b| b.gta_tag).collect();
    tags.sort_unstable();
    assert_eq!(rotations, tags);
    let positions = file
        .tracks
        .iter()
        .filter(|t| t.kind == TrackKind::Position)
        .count();
    assert_eq!(
        positions,
        1 + 77,
        "the root and the template's translations"
    );
    assert_eq!(file.tracks[0].tag, 0);
    assert_eq!(file.tracks[0].kind, TrackKind::Position);
    assert_eq!(file.tracks[1].tag, 0);
    assert_eq!(file.tracks[1].kind, TrackKind::Rotation);

    // Static blocks exactly for the constant tracks, one per sequence; moving tracks share
    // their boundary frame.
    let moving_tags: Vec<u16> = ["root", "l_forearm", "r_calf", "spine2", "r_upper_arm"]
        .iter()
        .map(|n| rig.bones[rig.bone_index(n).unwrap()].gta_tag)
        .collect();
    for t in &file.tracks {
        assert_eq!(t.blocks.len(), 2);
        let moving = (t.kind == TrackKind::Rotation && moving_tags.contains(&t.tag))
            || (t.kind == TrackKind::Position && t.tag == 0);
        assert!(
            t.blocks.iter().all(|b| b.is_static != moving),
            "{} {:?}",
            t.tag,
            t.kind
        );
        if moving {
            assert_eq!(t.blocks[0].values.len(), 128);
            assert_eq!(t.blocks[1].values.len(), 35);
            assert_eq!(
                t.blocks[0].values[127], t.blocks[1].values[0],
                "shared frame 127"
            );
        }
    }
    // The root starts where the ped stands, facing its heading.
    let root = file.samples(&file.tracks[0]);
    assert_eq!(root.len(), 162);
    assert!(root[0].iter().all(|v| v.abs() < 1e-9), "{:?}", root[0]);
    let yaw = file.samples(&file.tracks[1]);
    assert_eq!(yaw[0], vec![0.0, 0.0, 0.0, 1.0]);
    let template = file
        .tracks
        .iter()
        .find(|t| t.tag == 64729 && t.kind == TrackKind::Position)
        .unwrap();
    assert_eq!(
        template.blocks[1].values[0],
        vec![-0.021_830_1, 0.042_174, 0.031_918_8]
    );
}

#[test]
fn onim_quaternions_round_trip_through_the_mapping() {
    let rig = Rig::standard();
    let clip = moving_clip(&rig, 300);
    let mapping = OnimMapping::builtin(&rig).unwrap();
    let text = write(&rig, &clip, &mapping).unwrap();
    let file = parse(&text, "t.onim").unwrap();
    assert_eq!(file.sequences, vec![128, 128, 46]);
    // Per rig bone, its track's samples as quaternions.
    let per_bone: Vec<Vec<UnitQuaternion<f64>>> = rig
        .bones
        .iter()
        .map(|b| {
            let track = file
                .tracks
                .iter()
                .find(|t| t.tag == b.gta_tag && t.kind == TrackKind::Rotation)
                .unwrap();
            file.samples(track)
                .iter()
                .map(|v| {
                    let q = nalgebra::Quaternion::new(v[3], v[0], v[1], v[2]);
                    assert!((q.norm() - 1.0).abs() < 5e-6, "unit: {v:?}");
                    UnitQuaternion::from_quaternion(q)
                })
                .collect()
        })
        .collect();
    let heading = heading(&rig, &clip);
    let mut worst: f64 = 0.0;
    for (k, pose) in clip.poses.iter().enumerate() {
        let gta: Vec<UnitQuaternion<f64>> = per_bone.iter().map(|v| v[k]).collect();
        let back = mapping.to_rig(&rig, &gta, &heading);
        for (a, b) in back.iter().zip(&pose.local_rotations) {
            worst = worst.max(crate::skeleton::geom::rotation_distance(a, b));
        }
        // Sign continuity in the file.
        if k > 0 {
            for v in &per_bone {
                assert!(v[k].as_ref().dot(v[k - 1].as_ref()) >= 0.0);
            }
        }
    }
    assert!(worst.to_degrees() < 1e-3, "worst {}°", worst.to_degrees());
    // The root's position comes back too: turned back by the heading, from the first ground point.
    let root = file.samples(&file.tracks[0]);
    let origin = clip.poses[0].root_translation_m;
    for (k, pose) in clip.poses.iter().enumerate() {
        let v = Vector3::new(root[k][0], root[k][1], root[k][2]);
        let back = heading * v + Vector3::new(origin.x, origin.y, 0.0);
        assert!((back - pose.root_translation_m).norm() < 2e-6, "frame {k}");
    }
}

#[test]
fn gta_bone_frames_follow_the_animation() {
    // World frame of a GTA bone from the written local rotations = the animation's bone frame
    // times the mapping's rest frame: the GTA +X stays along the bone.
    let rig = Rig::standard();
    let clip = moving_clip(&rig, 20);
    let mapping = OnimMapping::builtin(&rig).unwrap();
    let heading = heading(&rig, &clip);
    for pose in &clip.poses {
        let gta = mapping.to_gta(&rig, &pose.local_rotations, &heading);
        let world = crate::skeleton::fk::forward(&rig, &clip.character, pose, 1.0);
        let mut gta_world: Vec<UnitQuaternion<f64>> = Vec::new();
        for (b, bone) in rig.bones.iter().enumerate() {
            let parent = bone.parent.map_or(heading, |p| gta_world[p]);
            gta_world.push(parent * gta[b]);
            let bone_dir = world.rotations[b] * bone.rest_direction();
            let x = gta_world[b] * Vector3::x();
            if bone.parent.is_some() {
                assert!((x - bone_dir.into_inner()).norm() < 1e-5, "{}", bone.name);
            }
        }
    }
}

#[test]
fn parse_names_the_line_at_fault() {
    let rig = Rig::standard();
    let clip = moving_clip(&rig, 5);
    let text = write(&rig, &clip, &OnimMapping::builtin(&rig).unwrap()).unwrap();
    let broken = text.replacen("Sequences 5", "Sequences 4", 1);
    let e = parse(&broken, "b.onim").unwrap_err();
    assert_eq!(e.line, 9, "{e}");
    let line_of = |needle: &str| text.lines().position(|l| l.contains(needle)).unwrap() + 1;
    let row = line_of("0.000000 0.000000 0.000000 1.000000");
    let mut lines: Vec<&str> = text.lines().collect();
    lines[row - 1] = "\t\t\t\t0.0 0.0 1.0";
    let e = parse(&lines.join("\n"), "b.onim").unwrap_err();
    assert_eq!(e.line, row, "{e}");
    assert!(e.to_string().contains("expected 4 numbers"), "{e}");
    let half: String = text.lines().take(400).flat_map(|l| [l, "\n"]).collect();
    let e = parse(&half, "b.onim").unwrap_err();
    assert_eq!(e.line, 400, "{e}");
    assert!(e.to_string().contains("file ends early"), "{e}");
}
