//! BVH files whose up is +Z (3ds Max, Blender scenes): `import` finds their axes from the clip,
//! and a clip read from a Z-up file is the clip read from the same motion written Y-up.
//!
//! [`z_up_text`] rewrites any BVH text into the same motion in Z-up axes (a proper rotation, so
//! every test here holds exactly). It is applied to random poses of the rig written by autoact's
//! own BVH export, and to every real BVH file in `../shared/data` (ignored without it).

use std::path::{Path, PathBuf};

use autoact::export::{Clip, bvh as bvh_export};
use autoact::formats::bvh::{self, Bvh};
use autoact::formats::bvh_map::{BvhMapping, DEFAULT_LAYOUT};
use autoact::skeleton::fk::BonePose;
use autoact::skeleton::frames::SourceAxes;
use autoact::skeleton::layout::Layout;
use autoact::skeleton::pose::PoseSequence;
use autoact::skeleton::rig::Rig;
use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;

/// The same motion in Z-up axes: a point (x, y, z) of the Y-up file is (−x, z, y), the rotation
/// [`SourceAxes::YUp`] applies. In the text that is: offsets and position channels permuted and
/// X negated, and each rotation channel turned about its image axis (X about −X, so its angle
/// negated; Y about Z and Z about Y, so the letters swapped).
fn z_up_text(text: &str) -> String {
    // Per channel in file order: whether its value is negated.
    let mut negate: Vec<bool> = Vec::new();
    let mut out = String::with_capacity(text.len());
    let mut in_motion = false;
    let mut frames_started = false;
    for line in text.lines() {
        let trimmed = line.trim_start();
        let pad = &line[..line.len() - trimmed.len()];
        let words: Vec<&str> = trimmed.split_whitespace().collect();
        let rewritten = if in_motion {
            if frames_started && !words.is_empty() {
                words
                    .iter()
                    .enumerate()
                    .map(|(k, w)| {
                        let v: f64 = w.parse().expect("a number");
                        let v = if negate.get(k).copied().unwrap_or(false) {
                            -v
                        } else {
                            v
                        };
                        format!("{v}")
                    })
                    .collect::<Vec<_>>()
                    .join(" ")
            } else {
                if trimmed.starts_with("Frame Time") {
                    frames_started = true;
                }
                trimmed.to_owned()
            }
        } else if words.first() == Some(&"OFFSET") {
            let v: Vec<f64> = words[1..4]
                .iter()
                .map(|w| w.parse().expect("offset"))
                .collect();
            format!("OFFSET {} {} {}", -v[0], v[2], v[1])
        } else if words.first() == Some(&"CHANNELS") {
            let names: Vec<String> = words[2..]
                .iter()
                .map(|n| {
                    negate.push(n.starts_with('X'));
                    let mut c = n.chars();
                    let axis = match c.next() {
                        Some('Y') => 'Z',
                        Some('Z') => 'Y',
                        Some(other) => other,
                        None => ' ',
                    };
                    format!("{axis}{}", c.as_str())
                })
                .collect();
            format!("CHANNELS {} {}", words[1], names.join(" "))
        } else {
            if trimmed == "MOTION" {
                in_motion = true;
            }
            trimmed.to_owned()
        };
        out.push_str(pad);
        out.push_str(&rewritten);
        out.push('\n');
    }
    out
}

/// Keypoints of the default layout and the axes `import` finds, through the clip's own mapping.
fn keypoints(clip: &Bvh) -> (PoseSequence, SourceAxes) {
    let mapping = BvhMapping::detect(clip).unwrap_or_else(|e| panic!("{e}"));
    let layout = Layout::load(DEFAULT_LAYOUT).expect("layout");
    mapping
        .keypoints_in(clip, &layout, None, None)
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The largest distance between the two sequences' points, metres (both must miss the same).
fn largest_difference_m(a: &PoseSequence, b: &PoseSequence) -> f64 {
    assert_eq!(a.frames.len(), b.frames.len());
    let mut worst: f64 = 0.0;
    for (fa, fb) in a.frames.iter().zip(&b.frames) {
        assert_eq!(fa.confidence, fb.confidence);
        for (pa, pb) in fa.positions_m.iter().zip(&fb.positions_m) {
            if pa.x.is_finite() {
                worst = worst.max((pa - pb).norm());
            }
        }
    }
    worst
}

/// Checks one BVH text and its Z-up rewrite; returns the largest difference (m).
fn check(text: &str, name: &str) -> f64 {
    let y_up = bvh::parse(text, name).unwrap_or_else(|e| panic!("{e}"));
    let z_up = bvh::parse(&z_up_text(text), name).unwrap_or_else(|e| panic!("{e}"));
    let (a, axes_a) = keypoints(&y_up);
    let (b, axes_b) = keypoints(&z_up);
    assert_eq!(axes_a, SourceAxes::YUp, "{name} as written");
    assert_eq!(axes_b, SourceAxes::ZUp, "{name} rewritten Z-up");
    largest_difference_m(&a, &b)
}

/// The angle between +Z and the mean over the frames of the body's up (pelvis to neck, unit),
/// degrees: how far from standing the clip is on the whole.
fn mean_tilt_deg(seq: &PoseSequence) -> f64 {
    let layout = Layout::load(DEFAULT_LAYOUT).expect("layout");
    let index = |name: &str| layout.joints.iter().position(|n| n == name).expect(name);
    let (pelvis, neck) = (index("pelvis"), index("neck"));
    let sum: Vector3<f64> = seq
        .frames
        .iter()
        .map(|f| (f.positions_m[neck] - f.positions_m[pelvis]).normalize())
        .sum();
    sum.normalize().z.clamp(-1.0, 1.0).acos().to_degrees()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Any pose of the rig (±30° per axis at the spine and neck, ±60° at the head, arms and
    /// legs, the root anywhere within 5 m) that stands within 45° of upright on the whole (the
    /// band in which `found_axes` decides), written Y-up by `export` and rewritten Z-up, reads
    /// as the same keypoints, each file's axes found.
    #[test]
    fn a_z_up_file_reads_as_the_same_motion_written_y_up(
        angles in prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0), 3 * 10),
        root in prop::collection::vec((-5.0f64..5.0, -5.0f64..5.0), 3),
    ) {
        let rig = Rig::standard();
        let bones = ["spine1", "spine3", "neck", "head", "l_upper_arm", "r_forearm", "l_thigh",
            "r_calf", "l_hand", "r_foot"];
        let poses: Vec<BonePose> = (0..3)
            .map(|k| {
                let mut pose = BonePose::rest(&rig);
                pose.root_translation_m = Vector3::new(root[k].0, root[k].1, 0.0);
                for (i, b) in bones.iter().enumerate() {
                    let (x, y, z) = angles[k * bones.len() + i];
                    let (x, y, z) = if i < 3 { (x / 2.0, y / 2.0, z / 2.0) } else { (x, y, z) };
                    pose.local_rotations[rig.bone_index(b).expect(b)] =
                        UnitQuaternion::from_euler_angles(x, y, z);
                }
                pose
            })
            .collect();
        let text = bvh_export::write(&rig, &Clip::from_poses(&rig, 30.0, poses));
        let (seq, _) = keypoints(&bvh::parse(&text, "pose.bvh").expect("parse"));
        prop_assume!(mean_tilt_deg(&seq) < 44.0);
        let worst = check(&text, "pose.bvh");
        prop_assert!(worst < 1e-9, "{worst} m apart");
    }
}

#[test]
fn the_rewrite_turns_the_rest_skeleton_onto_z() {
    let text = "HIERARCHY\nROOT Hips\n{\n  OFFSET 1 2 3\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n  End Site\n  {\n    OFFSET 0 10 0\n  }\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n1 2 3 10 20 30\n";
    let z = z_up_text(text);
    assert!(z.contains("  OFFSET -1 3 2\n"), "{z}");
    assert!(z.contains("    OFFSET -0 0 10\n"), "{z}");
    assert!(
        z.contains("CHANNELS 6 Xposition Zposition Yposition Yrotation Xrotation Zrotation\n"),
        "{z}"
    );
    assert!(z.ends_with("-1 2 3 10 -20 30\n"), "{z}");
}

fn real_bvh_files() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/bvh");
    let mut files = Vec::new();
    for dir in std::fs::read_dir(&root).expect("../shared/data/bvh") {
        let dir = dir.expect("entry").path();
        for f in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
            if f.path().extension().is_some_and(|e| e == "bvh") {
                files.push(f.path());
            }
        }
    }
    files.sort();
    files
}

/// Every real BVH file is found Y-up as written and Z-up once rewritten, and reads as the same
/// keypoints either way — Bandai-Namco's lying rest pose included.
#[test]
#[ignore = "needs ../shared/data"]
#[expect(clippy::print_stderr, reason = "reports what it measured")]
fn every_real_bvh_reads_the_same_from_a_z_up_rewrite() {
    let files = real_bvh_files();
    assert!(files.len() >= 14, "{} BVH files", files.len());
    for path in &files {
        let text = std::fs::read_to_string(path).expect("bvh text");
        let worst = check(&text, &path.display().to_string());
        assert!(worst < 1e-6, "{}: {worst} m apart", path.display());
    }
    eprintln!(
        "{} real BVH files: found y-up as written and z-up rewritten, keypoints within 1 µm",
        files.len()
    );
}

/// A Y-up file whose body lies with its head along +Z all through (push-ups, sleeping) stays
/// Y-up: its rest pose stands along +Y.
#[test]
fn a_y_up_clip_lying_along_z_stays_y_up() {
    let rig = Rig::standard();
    let root = rig.bone_index("root").expect("root bone");
    let poses: Vec<BonePose> = (0..3)
        .map(|k| {
            let mut pose = BonePose::rest(&rig);
            pose.root_translation_m = Vector3::new(0.1 * f64::from(k), 0.0, 0.2);
            // Head from autoact +Z to +Y, which the Y-up file writes as its +Z.
            pose.local_rotations[root] =
                UnitQuaternion::from_euler_angles(-std::f64::consts::FRAC_PI_2, 0.0, 0.0);
            pose
        })
        .collect();
    let text = bvh_export::write(&rig, &Clip::from_poses(&rig, 30.0, poses));
    let (seq, axes) = keypoints(&bvh::parse(&text, "lying.bvh").expect("parse"));
    assert_eq!(axes, SourceAxes::YUp);
    // Read as written: lying, head along +Y in autoact axes.
    let layout = Layout::load(DEFAULT_LAYOUT).expect("layout");
    let at = |name: &str| {
        let j = layout.joints.iter().position(|n| n == name).expect(name);
        seq.frames[0].positions_m[j]
    };
    let up = at("neck") - at("pelvis");
    assert!(up.y > 0.9 * up.norm(), "{up:?}");
}

/// Axes given with `--axes` are checked against how the body stands too: a Y-up file imported
/// as Z-up would lie on its back, and `import` says so (and says nothing for the right axes).
#[test]
fn axes_given_that_lay_the_body_down_are_warned_about() {
    use crate::common::{arg, autoact, stderr};
    let rig = Rig::standard();
    let poses = vec![BonePose::rest(&rig); 3];
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("standing.bvh");
    std::fs::write(
        &path,
        bvh_export::write(&rig, &Clip::from_poses(&rig, 30.0, poses)),
    )
    .expect("write");
    let out = dir.path().join("out.pose.mcap");
    for (axes, warned) in [(Some("z-up"), true), (Some("y-up"), false), (None, false)] {
        let mut args = vec!["import", arg(&path), "-o", arg(&out), "--force"];
        if let Some(a) = axes {
            args.extend(["--axes", a]);
        }
        let o = autoact(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(
            stderr(&o).contains("the body will not stand"),
            warned,
            "--axes {axes:?}: {}",
            stderr(&o)
        );
    }
}
