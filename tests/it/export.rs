//! `autoact export` end to end: BVH and `.onim` files from the sample bags and from bags with
//! several people and variants made here, read back with autoact's BVH reader and `.onim`
//! parser, glTF/GLB read back with the `gltf` crate (plain and capture bags), and every kind of
//! bad input.

#![expect(clippy::unwrap_used, reason = "test helpers fail loudly")]

use crate::common::{arg, autoact, stderr, stdout};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use autoact::bags::animation::{TrackWriter, frame_prefix, read_animation, read_animation_variant};
use autoact::export::bvh::read_back;
use autoact::export::onim::{self, OnimMapping, TrackKind};
use autoact::formats::bvh;
use autoact::mcap_io::{BagReader, BagWriter, WriteConfig};
use autoact::ros::tf2_msgs::TFMessage;
use autoact::skeleton::character::Character;
use autoact::skeleton::fk::BonePose;
use autoact::skeleton::geom::rotation_distance;
use autoact::skeleton::layout::Coverage;
use autoact::skeleton::rig::Rig;
use nalgebra::{UnitQuaternion, Vector3};

fn sample(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("bags")
        .join(name)
}

/// Runs `autoact` and requires success.
fn ok(args: &[&str]) -> String {
    let out = autoact(args);
    assert!(out.status.success(), "autoact {args:?}: {}", stderr(&out));
    stdout(&out)
}

/// Runs `autoact` and requires exit code 1; returns stderr.
/// `autoact export BAG --format FORMAT EXTRA... -o OUT`, which must fail with exit 1; its stderr.
fn export_fails(bag: &Path, format: &str, extra: &[&str], out: &Path) -> String {
    let mut args = vec!["export", arg(bag), "--format", format];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["-o", arg(out)]);
    fails(&args)
}

fn fails(args: &[&str]) -> String {
    let out = autoact(args);
    assert_eq!(
        out.status.code(),
        Some(1),
        "autoact {args:?}: {}",
        stderr(&out)
    );
    stderr(&out)
}

/// The pose of track `track`, variant `variant` at frame `k`: everything but fingers moving.
fn pose(rig: &Rig, track: u64, variant: u32, k: usize) -> BonePose {
    #[expect(clippy::cast_precision_loss, reason = "small numbers")]
    let t = k as f64 / 30.0 + track as f64 + 0.1 * f64::from(variant);
    let mut pose = BonePose::rest(rig);
    for (b, bone) in rig.bones.iter().enumerate() {
        #[expect(clippy::cast_precision_loss, reason = "small numbers")]
        let phase = b as f64 * 0.37;
        pose.local_rotations[b] = bone.constrain(&UnitQuaternion::from_euler_angles(
            0.4 * (t + phase).sin(),
            0.3 * (1.3 * t + phase).cos(),
            0.5 * (0.7 * t - phase).sin(),
        ));
    }
    pose.root_translation_m = Vector3::new(0.5 * t, 0.2 * t.sin(), 0.05 * t.cos());
    pose
}

/// An animation bag with `tracks` people × `variants` variants of `frames` frames at 30 fps,
/// each person on their own (scaled) body, as `autoact convert --dsi` lays them out.
fn synthetic_bag(dir: &Path, tracks: u64, variants: u32, frames: usize) -> PathBuf {
    let rig = Rig::standard();
    let path = dir.join("people.anim.mcap");
    let mut w = BagWriter::create(&path, WriteConfig::default()).unwrap();
    let mut meta = BTreeMap::new();
    meta.insert("fps".to_string(), "30".to_string());
    w.write_metadata("autoact.convert", meta).unwrap();
    let coverage = Coverage {
        driven: rig.bones.iter().map(|b| b.name.clone()).collect(),
        twist_unobserved: Vec::new(),
        at_rest: Vec::new(),
    };
    let mut writers = Vec::new();
    for track in 0..tracks {
        #[expect(clippy::cast_precision_loss, reason = "small numbers")]
        let character =
            Character::from_scales(&rig, vec![0.9 + 0.1 * track as f64; rig.bones.len()]);
        for variant in 0..variants {
            let prefix = frame_prefix(track, variant, tracks > 1);
            writers.push((
                track,
                variant,
                TrackWriter::new(&rig, &character, &coverage, track, variant, &prefix),
            ));
        }
    }
    let statics = writers
        .iter()
        .flat_map(|(_, _, tw)| tw.static_transforms(0))
        .collect();
    w.write(
        "/tf_static",
        0,
        &TFMessage {
            transforms: statics,
        },
    )
    .unwrap();
    for k in 0..frames {
        let stamp = autoact::skeleton::pose::stamp_nanos_at(k, 30.0);
        for (track, variant, tw) in &mut writers {
            tw.write_frame(&mut w, stamp, &pose(&rig, *track, *variant, k))
                .unwrap();
        }
    }
    w.finish().unwrap();
    path
}

/// Largest angle between two animations' rotations, degrees, and the bone and frame.
fn worst_angle_deg(rig: &Rig, a: &[BonePose], b: &[BonePose]) -> (f64, String, usize) {
    assert_eq!(a.len(), b.len(), "frame counts");
    let mut worst = (0.0, String::new(), 0);
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        for (i, bone) in rig.bones.iter().enumerate() {
            let d = rotation_distance(&x.local_rotations[i], &y.local_rotations[i]).to_degrees();
            if d > worst.0 {
                worst = (d, bone.name.clone(), k);
            }
        }
    }
    worst
}

fn bag_poses(rig: &Rig, bag: &Path, track: u64, variant: u32) -> (Vec<BonePose>, Character) {
    let readers = BagReader::open_all(bag).unwrap();
    let (frames, character, _) =
        read_animation_variant(rig, &readers, Some(track), variant).unwrap();
    (frames.into_iter().map(|f| f.pose).collect(), character)
}

#[test]
fn sample_bags_export_to_bvh_that_autoacts_reader_reads_back_within_0_01_degrees() {
    let rig = Rig::standard();
    let dir = tempfile::tempdir().unwrap();
    for name in ["bandai_walk.anim.mcap", "bandai_wave.anim.mcap"] {
        let bag = sample(name);
        let out = dir.path().join(name.replace(".anim.mcap", ".bvh"));
        let text = ok(&["export", arg(&bag), "--format", "bvh", "-o", arg(&out)]);
        assert!(
            text.contains("track 0 variant 0") && text.contains("at 30 fps"),
            "{text}"
        );
        let file = bvh::read(&out).unwrap();
        let (poses, character) = bag_poses(&rig, &bag, 0, 0);
        assert_eq!(file.joints.iter().filter(|j| !j.is_end_site).count(), 53);
        assert_eq!(file.frame_count(), poses.len());
        assert!((file.frame_time_secs - 1.0 / 30.0).abs() < 1e-9);
        // The offsets are the bag's body, in cm.
        let calf = file.joint_index("l_calf").unwrap();
        let want = character.head_offset_m[rig.bone_index("l_calf").unwrap()].norm() * 100.0;
        assert!(
            (file.joints[calf].offset.norm() - want).abs() < 1e-5,
            "{name}"
        );
        let back = read_back(&rig, &file).unwrap();
        let (worst, bone, k) = worst_angle_deg(&rig, &back, &poses);
        assert!(worst < 0.01, "{name}: {bone} frame {k} is {worst}° off");
        for (x, y) in back.iter().zip(&poses) {
            assert!(
                (x.root_translation_m - y.root_translation_m).norm() < 1e-6,
                "{name}"
            );
        }
    }
}

/// The full path the issue names — BVH → `autoact import` (the built-in `autoact53` mapping) →
/// `autoact convert` — does not reach 0.01°: `convert` solves rotations from joint positions,
/// so it re-fits the body, holds the twist of a straight limb (the "degenerate-input path"),
/// splits the spine by its own rule and takes the head's twist from face points placed on the
/// default adult. Since issue 19, a limb bent less than 20° also takes part of its twist from its
/// parent (so that a nearly straight limb never spins), and a second conversion blends again:
/// a nearly straight arm's forearm can come back rolled (up to 33° on the wave's right forearm,
/// where it was 1.6° at most before that rule), so this test holds every joint's position (worst
/// < 15 mm) and the median rotation error over the bones the source moves (< 0.05°); the 0.01°
/// round trip is the reader-level one above.
#[test]
fn bvh_through_import_and_convert_stays_within_the_measured_gap() {
    let rig = Rig::standard();
    let dir = tempfile::tempdir().unwrap();
    for (name, layout) in [
        ("bandai_walk.anim.mcap", "h36m-17"),
        ("bandai_wave.anim.mcap", "coco-wholebody-133"),
    ] {
        let bag = sample(name);
        let bvh_path = dir.path().join("x.bvh");
        let pose_bag = dir.path().join("x.pose.mcap");
        let anim_bag = dir.path().join("x.anim.mcap");
        ok(&[
            "export",
            arg(&bag),
            "--format",
            "bvh",
            "-o",
            arg(&bvh_path),
            "--force",
        ]);
        let text = ok(&[
            "import",
            arg(&bvh_path),
            "--layout",
            layout,
            "-o",
            arg(&pose_bag),
        ]);
        assert!(text.contains(layout), "{text}");
        ok(&["convert", arg(&pose_bag), "-o", arg(&anim_bag)]);
        let (original, character_a) = bag_poses(&rig, &bag, 0, 0);
        let (converted, character_b) = bag_poses(&rig, &anim_bag, 0, 0);
        // Where every joint is: a nearly straight limb's twist is not observable from joint
        // positions, and since issue 19 it is partly carried from the parent, so a second
        // conversion may roll a straight forearm differently; the joints stay put.
        // The joints of the bones the source moves (a bone the layout cannot drive, such as a
        // finger under H3.6M-17, rides on whatever its parent does).
        let moving = autoact::skeleton::fk::moving_bones(&original);
        let mut worst_mm = (0.0f64, String::new(), 0);
        for (k, (x, y)) in converted.iter().zip(&original).enumerate() {
            let a = autoact::skeleton::fk::forward(&rig, &character_b, x, 1.0);
            let b = autoact::skeleton::fk::forward(&rig, &character_a, y, 1.0);
            for (i, bone) in rig.bones.iter().enumerate().filter(|(i, _)| moving[*i]) {
                let d = (a.heads_m[i] - b.heads_m[i]).norm() * 1000.0;
                if d > worst_mm.0 {
                    worst_mm = (d, bone.name.clone(), k);
                }
            }
        }
        let (worst, bone, k) = worst_mm;
        assert!(worst < 15.0, "{name}: {bone} frame {k} is {worst} mm off");
        // Over the bones the source moves: the median is far below the worst.
        let mut errors: Vec<f64> = converted
            .iter()
            .zip(&original)
            .flat_map(|(x, y)| {
                x.local_rotations
                    .iter()
                    .zip(&y.local_rotations)
                    .zip(&moving)
                    .filter(|(_, m)| **m)
                    .map(|((a, b), _)| rotation_distance(a, b).to_degrees())
            })
            .collect();
        errors.sort_by(f64::total_cmp);
        let median = errors[errors.len() / 2];
        let p95 = errors[errors.len() * 95 / 100];
        assert!(
            median < 0.05,
            "{name}: median {median}°, 95th percentile {p95}°, worst {worst}° ({bone})"
        );
        std::fs::remove_file(&bvh_path).unwrap();
        std::fs::remove_file(&pose_bag).unwrap();
        std::fs::remove_file(&anim_bag).unwrap();
    }
}

#[test]
fn every_animation_of_a_bag_goes_to_its_own_file_and_round_trips() {
    let rig = Rig::standard();
    let dir = tempfile::tempdir().unwrap();
    let bag = synthetic_bag(dir.path(), 2, 2, 140);
    let list = ok(&["export", arg(&bag), "--list"]);
    assert_eq!(list.lines().count(), 2 + 4, "{list}");
    assert!(
        list.lines()
            .nth(5)
            .unwrap()
            .starts_with("1      1        140"),
        "{list}"
    );

    let out = dir.path().join("bvh");
    let text = ok(&["export", arg(&bag), "--format", "bvh", "-o", arg(&out)]);
    assert_eq!(text.lines().count(), 4, "{text}");
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "people_track0_v0.bvh",
            "people_track0_v1.bvh",
            "people_track1_v0.bvh",
            "people_track1_v1.bvh"
        ]
    );
    for (track, variant) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
        let file = bvh::read(&out.join(format!("people_track{track}_v{variant}.bvh"))).unwrap();
        let (poses, character) = bag_poses(&rig, &bag, track, variant);
        let (worst, bone, k) = worst_angle_deg(&rig, &read_back(&rig, &file).unwrap(), &poses);
        assert!(
            worst < 0.01,
            "{track}/{variant}: {bone} frame {k}: {worst}°"
        );
        // Each person's own body.
        let b = rig.bone_index("r_forearm").unwrap();
        let j = file.joint_index("r_forearm").unwrap();
        assert!(
            (file.joints[j].offset.norm() / 100.0 - character.head_offset_m[b].norm()).abs() < 1e-7
        );
    }

    // One variant of one person: OUT is the file.
    let one = dir.path().join("one.onim");
    ok(&[
        "export",
        arg(&bag),
        "--format",
        "onim",
        "--animation",
        "1",
        "--variant",
        "1",
        "-o",
        arg(&one),
    ]);
    let file = onim::parse(&std::fs::read_to_string(&one).unwrap(), "one.onim").unwrap();
    assert_eq!(file.frames, 140);
    assert_eq!(file.sequences, vec![128, 13]);
    assert!((file.duration_secs - 140.0 / 30.0).abs() < 1e-6);
    // The quaternions, mapped back onto the rig, are the bag's.
    let mapping = OnimMapping::builtin(&rig).unwrap();
    let (poses, _) = bag_poses(&rig, &bag, 1, 1);
    let heading = rig.bones[0].constrain(&poses[0].local_rotations[0]);
    let per_bone: Vec<Vec<Vec<f64>>> = rig
        .bones
        .iter()
        .map(|b| {
            let t = file
                .tracks
                .iter()
                .find(|t| t.tag == b.gta_tag && t.kind == TrackKind::Rotation)
                .unwrap();
            file.samples(t)
        })
        .collect();
    let back: Vec<BonePose> = (0..file.frames)
        .map(|k| {
            let gta: Vec<UnitQuaternion<f64>> = per_bone
                .iter()
                .map(|v| {
                    let q = &v[k];
                    UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                        q[3], q[0], q[1], q[2],
                    ))
                })
                .collect();
            BonePose {
                root_translation_m: Vector3::zeros(),
                local_rotations: mapping.to_rig(&rig, &gta, &heading),
            }
        })
        .collect();
    let (worst, bone, k) = worst_angle_deg(&rig, &back, &poses);
    assert!(worst < 0.001, "{bone} frame {k}: {worst}°");
}

#[test]
fn sample_bag_exports_to_onim_in_the_native_layout() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("walk.onim");
    ok(&[
        "export",
        arg(&sample("bandai_walk.anim.mcap")),
        "--format",
        "onim",
        "-o",
        arg(&out),
    ]);
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.starts_with("Version 8 2\n{\n\tFlags FLAG_0 FLAG_4 FLAG_5 FLAG_6 FLAG_7 FLAG_8\n\tFrames 195\n\tSequenceFrameLimit 127\n\tDuration 6.500000\n"), "{}", &text[..200]);
    let file = onim::parse(&text, "walk.onim").unwrap();
    assert_eq!(file.sequences, vec![128, 68]);
    // The walk has no finger data: those tracks are Static; the legs move.
    let rig = Rig::standard();
    let tag = |n: &str| rig.bones[rig.bone_index(n).unwrap()].gta_tag;
    let rotation = |t: u16| {
        file.tracks
            .iter()
            .find(|x| x.tag == t && x.kind == TrackKind::Rotation)
            .unwrap()
    };
    assert!(rotation(tag("l_index1")).blocks.iter().all(|b| b.is_static));
    assert!(rotation(tag("l_thigh")).blocks.iter().all(|b| !b.is_static));
    // Deterministic: the same export twice is the same bytes.
    let again = dir.path().join("again.onim");
    ok(&[
        "export",
        arg(&sample("bandai_walk.anim.mcap")),
        "--format",
        "onim",
        "-o",
        arg(&again),
    ]);
    assert_eq!(std::fs::read(&again).unwrap(), text.as_bytes());
}

#[test]
fn bad_input_gets_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let walk = sample("bandai_walk.anim.mcap");

    // A bag without /animation frames.
    let e = export_fails(
        &sample("bandai_walk.pose.mcap"),
        "bvh",
        &[],
        &dir.path().join("x.bvh"),
    );
    assert!(
        e.contains("bandai_walk.pose.mcap: no /animation frames") && e.contains("autoact convert"),
        "{e}"
    );

    // Frames that carry no bones.
    let empty = dir.path().join("empty.anim.mcap");
    let mut w = BagWriter::create(&empty, WriteConfig::default()).unwrap();
    let frame = autoact::ros::autoact_msgs::BoneFrame {
        rig: "autoact53".into(),
        ..Default::default()
    };
    w.write("/animation", 0, &frame).unwrap();
    w.write("/animation", 33_333_333, &frame).unwrap();
    w.finish().unwrap();
    let e = export_fails(&empty, "bvh", &[], &dir.path().join("x.bvh"));
    assert!(e.contains("empty.anim.mcap: track 0 variant 0: /animation message 0 (stamp 0 ns): 0 rotations; rig autoact53 has 53 bones"), "{e}");

    // Two such animations into a folder: refused before the folder is made.
    let two = dir.path().join("two_empty.anim.mcap");
    let mut w = BagWriter::create(&two, WriteConfig::default()).unwrap();
    for variant in [0, 1] {
        let frame = autoact::ros::autoact_msgs::BoneFrame {
            variant,
            ..frame.clone()
        };
        w.write("/animation", 0, &frame).unwrap();
        w.write("/animation", 33_333_333, &frame).unwrap();
    }
    w.finish().unwrap();
    let folder = dir.path().join("two_out");
    let e = export_fails(&two, "bvh", &[], &folder);
    assert!(e.contains("0 rotations"), "{e}");
    assert!(
        !folder.exists(),
        "a refused export made {}",
        folder.display()
    );

    // Unknown animation or variant.
    let e = export_fails(
        &walk,
        "bvh",
        &["--animation", "4"],
        &dir.path().join("x.bvh"),
    );
    assert!(
        e.contains("no animation with track 4; the bag holds: track 0 variant 0"),
        "{e}"
    );
    let e = export_fails(
        &walk,
        "onim",
        &["--variant", "2"],
        &dir.path().join("x.onim"),
    );
    assert!(e.contains("no animation with variant 2"), "{e}");

    // An output that exists: refused without --force, left alone; replaced with it.
    let taken = dir.path().join("taken.bvh");
    std::fs::write(&taken, "mine").unwrap();
    let e = export_fails(&walk, "bvh", &[], &taken);
    assert!(e.contains("taken.bvh exists; pass `--force`"), "{e}");
    assert_eq!(std::fs::read_to_string(&taken).unwrap(), "mine");
    ok(&[
        "export",
        arg(&walk),
        "--format",
        "bvh",
        "-o",
        arg(&taken),
        "--force",
    ]);
    assert!(
        std::fs::read_to_string(&taken)
            .unwrap()
            .starts_with("HIERARCHY\n")
    );
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| {
            Path::new(n)
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("part"))
        })
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");

    // An output that cannot be written.
    let e = export_fails(&walk, "bvh", &[], Path::new("/proc/autoact/x.bvh"));
    assert!(e.contains("cannot write /proc/autoact/x.bvh: "), "{e}");

    // Several animations into one file name.
    let bag = synthetic_bag(dir.path(), 1, 2, 3);
    let e = export_fails(&bag, "bvh", &[], &dir.path().join("two.bvh"));
    assert!(
        e.contains("2 animations are selected") && e.contains("--variant"),
        "{e}"
    );

    // A mapping that does not cover the rig.
    let template = dir.path().join("partial.toml");
    let text: String = onim::DEFAULT_MAPPING_TOML
        .lines()
        .filter(|l| !l.starts_with("SKEL_R_Hand ") && !l.starts_with("SKEL_Spine2 "))
        .flat_map(|l| [l, "\n"])
        .collect();
    std::fs::write(&template, text).unwrap();
    let e = export_fails(
        &walk,
        "onim",
        &["--onim-template", arg(&template)],
        &dir.path().join("x.onim"),
    );
    assert!(
        e.contains(
            "partial.toml does not cover 2 of rig autoact53's bones: SKEL_Spine2, SKEL_R_Hand"
        ),
        "{e}"
    );
    assert!(!dir.path().join("x.onim").exists());

    // A bad --fps.
    let e = autoact(&[
        "export",
        arg(&walk),
        "--format",
        "bvh",
        "--fps",
        "0",
        "-o",
        "x.bvh",
    ]);
    assert!(
        !e.status.success() && stderr(&e).contains("--fps"),
        "{}",
        stderr(&e)
    );
}

#[test]
fn the_printed_onim_template_is_the_built_in_mapping() {
    let rig = Rig::standard();
    let text = ok(&["export", "--print-onim-template"]);
    let printed = OnimMapping::from_toml(&rig, &text, "printed").unwrap();
    let builtin = OnimMapping::builtin(&rig).unwrap();
    assert_eq!(printed.frames, builtin.frames);
    assert_eq!(printed.translations, builtin.translations);
    // And as a template file it gives the same .onim as the default.
    let dir = tempfile::tempdir().unwrap();
    let template = dir.path().join("mine.toml");
    std::fs::write(&template, &text).unwrap();
    let a = dir.path().join("a.onim");
    let b = dir.path().join("b.onim");
    let walk = sample("bandai_wave.anim.mcap");
    ok(&["export", arg(&walk), "--format", "onim", "-o", arg(&a)]);
    ok(&[
        "export",
        arg(&walk),
        "--format",
        "onim",
        "--onim-template",
        arg(&template),
        "-o",
        arg(&b),
    ]);
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}

#[test]
fn read_animation_still_reads_variant_0() {
    let rig = Rig::standard();
    let dir = tempfile::tempdir().unwrap();
    let bag = synthetic_bag(dir.path(), 1, 3, 5);
    let readers = BagReader::open_all(&bag).unwrap();
    let (frames, _, _) = read_animation(&rig, &readers, None).unwrap();
    let (v0, _, _) = read_animation_variant(&rig, &readers, None, 0).unwrap();
    let (v2, _, _) = read_animation_variant(&rig, &readers, None, 2).unwrap();
    assert_eq!(frames, v0);
    assert_ne!(frames, v2);
    let (worst, bone, k) = worst_angle_deg(
        &rig,
        &v2.iter().map(|f| f.pose.clone()).collect::<Vec<_>>(),
        &(0..5).map(|k| pose(&rig, 0, 2, k)).collect::<Vec<_>>(),
    );
    assert!(worst < 1e-9, "{bone} frame {k}: {worst}°");
}

/// The GLB's JSON chunk.
fn glb_json(bytes: &[u8]) -> serde_json::Value {
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    assert_eq!(&bytes[16..20], b"JSON");
    serde_json::from_slice(&bytes[20..20 + len]).unwrap()
}

/// Per animated node: its rotations (x y z w) or translations, per frame, and the keyframe times.
struct GlbAnimation {
    times: Vec<f32>,
    rotations: BTreeMap<usize, Vec<[f32; 4]>>,
    translations: BTreeMap<usize, Vec<[f32; 3]>>,
    channels: usize,
}

fn glb_animation(bytes: &[u8]) -> GlbAnimation {
    let doc = gltf::Gltf::from_slice(bytes).unwrap();
    let blob = doc.blob.clone().unwrap();
    assert_eq!(doc.animations().count(), 1);
    let animation = doc.animations().next().unwrap();
    let mut out = GlbAnimation {
        times: Vec::new(),
        rotations: BTreeMap::new(),
        translations: BTreeMap::new(),
        channels: animation.channels().count(),
    };
    for channel in animation.channels() {
        assert_eq!(
            channel.sampler().interpolation(),
            gltf::animation::Interpolation::Linear
        );
        let node = channel.target().node().index();
        let reader = channel.reader(|_| Some(&blob));
        out.times = reader.read_inputs().unwrap().collect();
        match reader.read_outputs().unwrap() {
            gltf::animation::util::ReadOutputs::Rotations(r) => {
                assert!(out.rotations.insert(node, r.into_f32().collect()).is_none());
            }
            gltf::animation::util::ReadOutputs::Translations(t) => {
                assert!(out.translations.insert(node, t.collect()).is_none());
            }
            _ => panic!("a channel that is neither rotation nor translation"),
        }
    }
    out
}

/// `q` (x y z w, f32) is `want` or `−want` within `tol` per component.
fn same_rotation(q: [f32; 4], want: &UnitQuaternion<f64>, tol: f64) -> bool {
    let w = want.coords;
    let close = |sign: f64| (0..4).all(|i| (f64::from(q[i]) - sign * w[i]).abs() < tol);
    close(1.0) || close(-1.0)
}

#[test]
fn sample_bags_export_to_glb_with_the_rig_skin_and_the_bags_rotations() {
    let rig = Rig::standard();
    let dir = tempfile::tempdir().unwrap();
    for (name, label) in [
        ("bandai_walk.anim.mcap", "walk"),
        ("bandai_wave.anim.mcap", "wave"),
    ] {
        let bag = sample(name);
        let out = dir.path().join(format!("{label}.glb"));
        ok(&["export", arg(&bag), "--format", "glb", "-o", arg(&out)]);
        let bytes = std::fs::read(&out).unwrap();
        let (poses, character) = bag_poses(&rig, &bag, 0, 0);
        let doc = gltf::Gltf::from_slice(&bytes).unwrap();
        let blob = doc.blob.clone().unwrap();
        let skin = doc.skins().next().unwrap();
        assert_eq!(skin.joints().count(), 53);
        for (b, joint) in skin.joints().enumerate() {
            assert_eq!(joint.name(), Some(rig.bones[b].name.as_str()));
        }
        let rest = autoact::skeleton::fk::forward(&rig, &character, &BonePose::rest(&rig), 1.0);
        let ibm: Vec<[[f32; 4]; 4]> = skin
            .reader(|_| Some(&blob))
            .read_inverse_bind_matrices()
            .unwrap()
            .collect();
        assert_eq!(ibm.len(), 53);
        for (b, m) in ibm.iter().enumerate() {
            // Columns: the identity, then the translation by minus the bone's rest head.
            let h = rest.heads_m[b];
            let want = [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
                [-h.x, -h.y, -h.z, 1.0],
            ];
            let worst = m
                .iter()
                .flatten()
                .zip(want.iter().flatten())
                .map(|(got, want)| (f64::from(*got) - want).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-6, "{name}: bone {b}: {m:?}");
        }
        assert_eq!(
            doc.cameras().count(),
            0,
            "{name}: a plain bag has no camera"
        );

        let a = glb_animation(&bytes);
        assert_eq!(a.channels, 53 + 1, "{name}: a rotation per bone + the root");
        assert_eq!(a.times.len(), poses.len());
        #[expect(clippy::cast_precision_loss, reason = "frame counts")]
        let last = (poses.len() - 1) as f64 / 30.0;
        assert!((f64::from(*a.times.last().unwrap()) - last).abs() < 1e-5);
        for b in 0..53 {
            let rotations = &a.rotations[&(b + 1)];
            assert_eq!(rotations.len(), poses.len());
            for (k, q) in rotations.iter().enumerate() {
                assert!(
                    same_rotation(*q, &poses[k].local_rotations[b], 1e-6),
                    "{name}: bone {b} frame {k}"
                );
            }
        }
        for (k, t) in a.translations[&1].iter().enumerate() {
            let want = rest.heads_m[0].coords + poses[k].root_translation_m;
            for axis in 0..3 {
                assert!(
                    (f64::from(t[axis]) - want[axis]).abs() < 1e-5,
                    "{name}: frame {k}"
                );
            }
        }
        let json = glb_json(&bytes);
        let extras = &json["scenes"][0]["extras"]["autoact"];
        assert_eq!(extras["label"], label, "{name}");
        assert_eq!(extras["frames"], poses.len());
        assert_eq!(extras["fps"], 30.0);

        // Deterministic, and the .gltf holds the same document.
        let again = dir.path().join(format!("{label}_again.glb"));
        ok(&["export", arg(&bag), "--format", "glb", "-o", arg(&again)]);
        assert_eq!(bytes, std::fs::read(&again).unwrap(), "{name}");
        let text_path = dir.path().join(format!("{label}.gltf"));
        ok(&[
            "export",
            arg(&bag),
            "--format",
            "gltf",
            "-o",
            arg(&text_path),
        ]);
        let mut text: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&text_path).unwrap()).unwrap();
        text["buffers"][0].as_object_mut().unwrap().remove("uri");
        assert_eq!(text, json, "{name}");
    }
}

#[test]
fn capture_bag_exports_its_camera_path_and_its_labels_seed_and_scenes() {
    use autoact::ros::geometry_msgs::PoseStamped;
    use autoact::ros::{RosMessage, cdr};

    let rig = Rig::standard();
    let dir = tempfile::tempdir().unwrap();
    let bag = capture_bag(dir.path(), 1, 2);
    // One file per scene: the first scene's.
    let out = dir.path().join("capture");
    ok(&["export", arg(&bag), "--format", "glb", "-o", arg(&out)]);
    let bytes = std::fs::read(out.join("t_gesture_wave_0000_track0_v0_scene0.glb")).unwrap();

    let readers = BagReader::open_all(&bag).unwrap();
    let (frames, _, _) = read_animation_variant(&rig, &readers, Some(0), 0).unwrap();
    let mut cameras = BTreeMap::new();
    for m in readers.iter().flat_map(BagReader::messages) {
        let m = m.unwrap();
        if m.channel.topic == "/camera/pose" && m.channel.schema_name() == PoseStamped::TYPE_NAME {
            let p: PoseStamped = cdr::decode(&m.data).unwrap();
            cameras.insert(p.header.stamp.to_nanos().unwrap(), p.pose);
        }
    }

    let doc = gltf::Gltf::from_slice(&bytes).unwrap();
    let camera = doc.nodes().find(|n| n.camera().is_some()).unwrap();
    let a = glb_animation(&bytes);
    assert_eq!(
        a.channels,
        53 + 1 + 2,
        "bones, root, camera translation and rotation"
    );
    // The first scene's frames.
    let frames = &frames[..a.times.len()];
    assert!(a.times.len() > 100, "{}", a.times.len());
    let positions = &a.translations[&camera.index()];
    let rotations = &a.rotations[&camera.index()];
    for (k, f) in frames.iter().enumerate() {
        let pose = &cameras[&f.stamp_nanos];
        let p = pose.position;
        let t = positions[k];
        assert!(
            (f64::from(t[0]) - p.x).abs() < 1e-5
                && (f64::from(t[1]) - p.y).abs() < 1e-5
                && (f64::from(t[2]) - p.z).abs() < 1e-5,
            "frame {k}"
        );
        // glTF's camera looks down its −z, the optical frame down its +z.
        let optical = UnitQuaternion::try_from(pose.orientation).unwrap();
        let q = rotations[k];
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            f64::from(q[3]),
            f64::from(q[0]),
            f64::from(q[1]),
            f64::from(q[2]),
        ));
        assert!(
            (q * -Vector3::z() - optical * Vector3::z()).norm() < 1e-5,
            "frame {k}"
        );
        assert!(
            (q * Vector3::y() - optical * -Vector3::y()).norm() < 1e-5,
            "frame {k}"
        );
        assert!(same_rotation(
            a.rotations[&1][k],
            &f.pose.local_rotations[0],
            1e-6
        ));
    }
    let extras = &glb_json(&bytes)["scenes"][0]["extras"]["autoact"];
    assert_eq!(extras["label"], "wave");
    assert_eq!(extras["seed"], 11);
    assert_eq!(extras["scenes"].as_array().unwrap().len(), 1);
    assert_eq!(extras["scene_index"], 0);
    assert_eq!(extras["timeline_first_frame"], 0);
    assert_eq!(extras["scenes"][0]["scene_id"], extras["scene_id"]);
    assert!(extras["scenes"][0]["lighting"]["key_dir_world"].is_array());
    let segments = extras["segments"].as_array().unwrap();
    assert_eq!(segments.len(), 1);
    assert_eq!(segments[0]["start_frame"], 0);
    assert_eq!(segments[0]["action"], "wave");
}

/// Start offsets of the top-level chunk records of an MCAP file.
fn chunk_starts(bytes: &[u8]) -> Vec<usize> {
    let mut out = Vec::new();
    let mut at = 8;
    while at + 9 <= bytes.len() && bytes[at] != 0x0F {
        let len = usize::try_from(u64::from_le_bytes(
            bytes[at + 1..at + 9].try_into().unwrap(),
        ))
        .unwrap();
        if bytes[at] == 0x06 {
            out.push(at);
        }
        at += 9 + len;
    }
    out
}

#[test]
fn a_cut_or_damaged_animation_bag_exports_what_it_has_and_exits_3() {
    let dir = tempfile::tempdir().unwrap();
    let bag = synthetic_bag(dir.path(), 1, 1, 300);
    let bytes = std::fs::read(&bag).unwrap();
    let chunks = chunk_starts(&bytes);
    assert!(chunks.len() >= 3, "{chunks:?}");
    let cut = dir.path().join("cut.anim.mcap");
    std::fs::write(&cut, &bytes[..chunks[2]]).unwrap();
    let mut flipped = bytes.clone();
    flipped[chunks[1] + 200] ^= 0xff;
    let damaged = dir.path().join("damaged.anim.mcap");
    std::fs::write(&damaged, &flipped).unwrap();
    for (bag, said) in [
        (&cut, "cut.anim.mcap: file ends without a summary"),
        (&damaged, "damaged.anim.mcap: chunk 2 "),
    ] {
        let out = dir.path().join("out.bvh");
        let o = autoact(&[
            "export",
            arg(bag),
            "--format",
            "bvh",
            "-o",
            arg(&out),
            "--force",
        ]);
        assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
        assert!(stderr(&o).contains(said), "{}", stderr(&o));
        assert!(stderr(&o).contains("1 unreadable parts"), "{}", stderr(&o));
        assert!(out.exists(), "what was read is exported");
        let o = autoact(&["export", arg(bag), "--list"]);
        assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    }
    // The whole bag exports with exit 0.
    let out = dir.path().join("whole.bvh");
    let o = autoact(&["export", arg(&bag), "--format", "bvh", "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn frames_that_do_not_decode_or_do_not_advance_are_lost_with_their_topic_and_index() {
    let rig = Rig::standard();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("odd.anim.mcap");
    let mut w = BagWriter::create(&path, WriteConfig::default()).unwrap();
    let coverage = Coverage {
        driven: rig.bones.iter().map(|b| b.name.clone()).collect(),
        twist_unobserved: Vec::new(),
        at_rest: Vec::new(),
    };
    let character = Character::standard(&rig);
    let mut tw = TrackWriter::new(&rig, &character, &coverage, 0, 0, "");
    for k in 0..60 {
        // Frame 20 is written twice at the same stamp.
        let stamp = autoact::skeleton::pose::stamp_nanos_at(if k == 21 { 20 } else { k }, 30.0);
        tw.write_frame(&mut w, stamp, &pose(&rig, 0, 0, k)).unwrap();
        if k == 40 {
            w.write_raw(
                "/animation",
                "autoact_msgs/msg/BoneFrame",
                String::new,
                stamp + 1,
                stamp + 1,
                &[0, 1, 0, 0, 9],
            )
            .unwrap();
        }
    }
    w.finish().unwrap();
    let (_, lost) = autoact::bags::animation::read_animation_variant_with_losses(
        &rig,
        &[BagReader::open(&path).unwrap()],
        None,
        0,
    )
    .unwrap();
    assert!(lost.unreadable.is_empty(), "{lost:?}");
    let skipped: Vec<(String, u64)> = lost
        .skipped
        .iter()
        .map(|s| (s.topic.clone(), s.index))
        .collect();
    assert_eq!(
        skipped,
        [
            ("/animation".to_string(), 21),
            ("/animation".to_string(), 41)
        ],
        "{lost:?}"
    );
    let out = dir.path().join("odd.bvh");
    let o = autoact(&["export", arg(&path), "--format", "bvh", "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("odd.anim.mcap: /animation message 21")
            && err.contains("does not advance past the frame before")
            && err.contains("odd.anim.mcap: /animation message 41")
            && err.contains("does not decode as a BoneFrame"),
        "{err}"
    );
}

/// A capture bag of `bandai_wave` with `variants` × `scenes` scenes (each scene a new character)
/// made by `autoact convert --spec` in `dir`.
fn capture_bag(dir: &Path, variants: u32, scenes: u32) -> PathBuf {
    let repo = |p: &str| format!("{}/{p}", env!("CARGO_MANIFEST_DIR"));
    let spec = dir.join("s.toml");
    std::fs::write(
        &spec,
        format!(
            "[dataset]\nname = \"t\"\nseed = 11\nfps = 30.0\nresolution = [640, 360]\n\
             [counts]\nvariants = {variants}\nscenes = {scenes}\nviewpoints = 1\nshot = \"moving\"\n\
             [[class]]\ncategory = \"gesture\"\naction = \"wave\"\nsources = [\"{}\"]\n",
            repo("bags/bandai_wave.pose.mcap")
        ),
    )
    .unwrap();
    let capture = dir.join("capture");
    ok(&["convert", "--spec", arg(&spec), "-o", arg(&capture)]);
    std::fs::read_dir(&capture)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "mcap"))
        .unwrap()
}

/// Every bone head in the world at every `/animation` frame of a bag, as a tf viewer shows it:
/// `/tf_static` and `/tf` replayed in order and composed ([`TfTree`]), by frame stamp; and the
/// scene starts (`/scene`) in order.
fn bag_joint_positions(
    rig: &Rig,
    bag: &Path,
) -> (BTreeMap<u64, Vec<nalgebra::Point3<f64>>>, Vec<u64>) {
    use autoact::bags::animation::TfTree;
    use autoact::ros::autoact_msgs::SceneState;
    use autoact::ros::{RosMessage, cdr};
    let mut tree = TfTree::default();
    let mut out = BTreeMap::new();
    let mut scenes = Vec::new();
    for m in BagReader::open_all(bag)
        .unwrap()
        .iter()
        .flat_map(BagReader::messages)
    {
        let m = m.unwrap();
        match (m.channel.topic.as_str(), m.channel.schema_name()) {
            ("/tf" | "/tf_static", TFMessage::TYPE_NAME) => {
                let tf: TFMessage = cdr::decode(&m.data).unwrap();
                tree.update(&tf).unwrap();
                // The character's /tf (not the camera's) is written after its /tf_static; its
                // frames carry the scene's prefix (`scene1/root`).
                let root = tf
                    .transforms
                    .iter()
                    .find_map(|t| t.child_frame_id.strip_suffix("root"));
                if let Some(prefix) = root.filter(|_| m.channel.topic == "/tf") {
                    let stamp = tf.transforms[0].header.stamp.to_nanos().unwrap();
                    let heads = rig
                        .bones
                        .iter()
                        .map(|b| {
                            tree.world_from(&format!("{prefix}{}", b.name)).unwrap()
                                * nalgebra::Point3::origin()
                        })
                        .collect();
                    out.insert(stamp, heads);
                }
            }
            ("/scene", SceneState::TYPE_NAME) => {
                let s: SceneState = cdr::decode(&m.data).unwrap();
                scenes.push(s.header.stamp.to_nanos().unwrap());
            }
            _ => {}
        }
    }
    scenes.sort_unstable();
    (out, scenes)
}

/// Every joint's world position (autoact frame, metres) at every frame of an exported GLB: the
/// joint nodes' rest translations, the animation's rotations and root translation, composed.
fn glb_joint_positions(rig: &Rig, bytes: &[u8]) -> Vec<Vec<nalgebra::Point3<f64>>> {
    use nalgebra::{Isometry3, Translation3};
    let doc = gltf::Gltf::from_slice(bytes).unwrap();
    let a = glb_animation(bytes);
    let nodes: Vec<gltf::Node<'_>> = doc.nodes().collect();
    let quat = |q: [f32; 4]| {
        UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            f64::from(q[3]),
            f64::from(q[0]),
            f64::from(q[1]),
            f64::from(q[2]),
        ))
    };
    let v3 = |t: [f32; 3]| Vector3::new(f64::from(t[0]), f64::from(t[1]), f64::from(t[2]));
    (0..a.times.len())
        .map(|k| {
            let mut world: Vec<Isometry3<f64>> = Vec::with_capacity(rig.bones.len());
            for (b, bone) in rig.bones.iter().enumerate() {
                let node = 1 + b;
                let (rest, _, _) = nodes[node].transform().decomposed();
                let t = a.translations.get(&node).map_or(v3(rest), |t| v3(t[k]));
                let local =
                    Isometry3::from_parts(Translation3::from(t), quat(a.rotations[&node][k]));
                world.push(bone.parent.map_or(local, |p| world[p] * local));
            }
            world
                .iter()
                .map(|w| w * nalgebra::Point3::origin())
                .collect()
        })
        .collect()
}

/// Largest distance between two sets of joint positions, metres.
fn worst_m(a: &[nalgebra::Point3<f64>], b: &[nalgebra::Point3<f64>]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).norm())
        .fold(0.0, f64::max)
}

/// Issue 23: every scene of a capture bag draws a new character, and the export of a capture bag
/// is one file per scene on that scene's body, so every frame of every scene, re-read from the
/// BVH (autoact's BVH reader) and from the GLB (the `gltf` crate, composed here), puts every joint
/// where the bag's `/tf` and `/tf_static` put it, within 0.1 mm. The same frames on the first
/// scene's body (what the export wrote before) are centimetres off.
#[test]
#[expect(clippy::print_stderr, reason = "the measured errors, for the record")]
fn capture_exports_match_the_bag_on_every_frame_of_every_scene() {
    let rig = Rig::standard();
    let dir = tempfile::tempdir().unwrap();
    let bag = capture_bag(dir.path(), 2, 2);
    let (truth, scene_starts) = bag_joint_positions(&rig, &bag);
    assert_eq!(scene_starts.len(), 4);
    let stamps: Vec<u64> = truth.keys().copied().collect();
    let mut covered = vec![false; stamps.len()];
    let mut old_worst = [0.0_f64; 4];
    for format in ["bvh", "glb"] {
        let out = dir.path().join(format);
        let text = ok(&["export", arg(&bag), "--format", format, "-o", arg(&out)]);
        assert_eq!(text.lines().count(), 4, "one file per scene: {text}");
        for scene in 0..4 {
            let v = scene / 2;
            let file = out.join(format!(
                "t_gesture_wave_0000_track0_v{v}_scene{scene}.{format}"
            ));
            assert!(text.contains(arg(&file)), "{text}");
            // The scene's frames on the capture's timeline.
            let first = stamps.partition_point(|&s| s < scene_starts[scene]);
            let end = scene_starts
                .get(scene + 1)
                .map_or(stamps.len(), |&s| stamps.partition_point(|&t| t < s));
            assert!(
                text.contains(&format!("(capture frames {first}..{end})")),
                "{text}"
            );
            let positions: Vec<Vec<nalgebra::Point3<f64>>> = if format == "bvh" {
                let f = bvh::read(&file).unwrap();
                (0..f.frame_count())
                    .map(|k| {
                        let world = f.world_transforms(k);
                        rig.bones
                            .iter()
                            .map(|b| {
                                let p = world[f.joint_index(&b.name).unwrap()].0;
                                autoact::skeleton::frames::SourceAxes::YUp.point_to_autoact(p)
                                    / 100.0
                            })
                            .collect()
                    })
                    .collect()
            } else {
                let bytes = std::fs::read(&file).unwrap();
                let extras = &glb_json(&bytes)["scenes"][0]["extras"]["autoact"];
                assert_eq!(extras["scene_index"], scene);
                assert_eq!(extras["timeline_first_frame"], first);
                assert_eq!(extras["scenes"].as_array().unwrap().len(), 1);
                glb_joint_positions(&rig, &bytes)
            };
            assert_eq!(positions.len(), end - first, "{format} scene {scene}");
            let mut worst = 0.0_f64;
            for (k, p) in positions.iter().enumerate() {
                worst = worst.max(worst_m(p, &truth[&stamps[first + k]]));
                covered[first + k] = true;
            }
            eprintln!("{format} scene {scene}: worst {:.2} µm", worst * 1e6);
            assert!(worst < 1e-4, "{format} scene {scene}: {} mm", worst * 1e3);
        }
    }
    assert!(
        covered.iter().all(|&c| c),
        "every frame of the bag is exported"
    );

    // --list shows what the export writes: a row per animation and scene.
    let list = ok(&["export", arg(&bag), "--list"]);
    assert!(list.contains("scene  capture frames"), "{list}");
    for (scene, &start) in scene_starts.iter().enumerate() {
        let first = stamps.partition_point(|&s| s < start);
        let row = format!("0      {}        {scene}      {first}..", scene / 2);
        assert!(list.contains(&row), "{row:?} in {list}");
    }

    // One scene to one file; a scene the bag does not have is an error naming those it has.
    let one = dir.path().join("one.bvh");
    let text = ok(&[
        "export",
        arg(&bag),
        "--format",
        "bvh",
        "--scene",
        "3",
        "-o",
        arg(&one),
    ]);
    assert!(
        text.contains("variant 1, scene ") && text.contains("/v1/s1"),
        "{text}"
    );
    assert_eq!(
        std::fs::read(&one).unwrap(),
        std::fs::read(
            dir.path()
                .join("bvh/t_gesture_wave_0000_track0_v1_scene3.bvh")
        )
        .unwrap()
    );
    let e = export_fails(&bag, "bvh", &["--scene", "3", "--variant", "0"], &one);
    assert!(
        e.contains("no scene 3") && e.contains("0 (") && e.contains("/v0/s1)"),
        "{e}"
    );
    let e = export_fails(
        &sample("bandai_wave.anim.mcap"),
        "bvh",
        &["--scene", "0"],
        &one,
    );
    assert!(e.contains("not a capture bag"), "{e}");

    // The bodies differ: the first scene's body on a later scene's frames (what one animation per
    // variant on the first scene's body gave) is far off.
    let (_, first_body) = bag_poses(&rig, &bag, 0, 0);
    let readers = BagReader::open_all(&bag).unwrap();
    for v in 0..2 {
        let (frames, _, _) = read_animation_variant(&rig, &readers, Some(0), v).unwrap();
        for f in &frames {
            let scene = scene_starts.partition_point(|&s| s <= f.stamp_nanos) - 1;
            let world = autoact::skeleton::fk::forward(&rig, &first_body, &f.pose, 1.0);
            let worst = worst_m(&world.heads_m, &truth[&f.stamp_nanos]);
            if scene == 0 {
                assert!(worst < 1e-6, "scene 0 is on the first scene's body");
            } else {
                old_worst[scene] = old_worst[scene].max(worst);
            }
        }
    }
    eprintln!("on the first scene's body: worst per scene {old_worst:?} m");
    assert!(old_worst[1..].iter().all(|&w| w > 5e-3), "{old_worst:?}");
}
