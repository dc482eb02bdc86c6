//! Reader tests on real recordings: NTU RGB+D (Kinect v2), ZED 2i BODY_34, UTD-MHAD (Kinect
//! v1) and CMU Panoptic Studio.
//!
//! The data is research-only and is never copied into this repository: the tests read it from
//! `../shared/data` (see `SOURCES.md` there) and are ignored by default. Run them with
//! `cargo test --test it readers_real_data:: -- --ignored` where the data exists.

use std::path::PathBuf;

use autoact::formats::{ntu, panoptic, utd_mat, zed_mat};
use autoact::skeleton::pose::{PoseSequence, stamp_nanos_at};
use nalgebra::{Point3, Vector3};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data");
const NTU_FILE: &str = "ntu/S001C001P001R001A001.skeleton";
const ZED_WALK: &str = "zed_body34/rzy_walk1_HD1080_SN35745898_19-37-53.mat";
const ZED_RUN: &str = "zed_body34/rzy_run1_HD1080_SN35745898_19-44-15.mat";
/// UTD-MHAD action a1, "right arm swipe to the left", subject 1, trial 2.
const UTD_SWIPE: &str = "utd_mhad_kinect1/a1_s1_t2_skeleton.mat";
/// CMU Panoptic: two frames each of two sequences (`160906_band1`, `160906_band2`), renamed into
/// one folder.
const PANOPTIC: &str = "panoptic";

fn data(relative: &str) -> PathBuf {
    PathBuf::from(DATA).join(relative)
}

fn ntu_skeleton() -> ntu::NtuSkeleton {
    match ntu::read(data(NTU_FILE)) {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    }
}

fn zed(relative: &str) -> zed_mat::ZedRecording {
    match zed_mat::read(data(relative)) {
        Ok(r) => r,
        Err(e) => panic!("{e}"),
    }
}

fn median(mut values: Vec<f64>) -> f64 {
    values.retain(|v| v.is_finite());
    assert!(!values.is_empty(), "no finite values");
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

/// Per-frame distance between two joints (NaN where either is missing).
fn lengths(seq: &PoseSequence, a: &str, b: &str) -> Vec<f64> {
    let (Some(a), Some(b)) = (seq.joint_index(a), seq.joint_index(b)) else {
        panic!("unknown joint {a} or {b}");
    };
    seq.frames
        .iter()
        .map(|f| (f.positions_m[a] - f.positions_m[b]).norm())
        .collect()
}

#[test]
#[ignore = "needs ../shared/data"]
fn ntu_frames_bodies_joints_and_tracking_states() {
    let skeleton = ntu_skeleton();
    assert_eq!(skeleton.frames.len(), 103);
    assert!(skeleton.frames.iter().all(|f| f.bodies.len() == 1));
    assert_eq!(skeleton.body_ids().len(), 1);

    let joints: Vec<&ntu::NtuJoint> = skeleton
        .frames
        .iter()
        .flat_map(|f| &f.bodies)
        .flat_map(|b| &b.joints)
        .collect();
    assert_eq!(joints.len(), 2575);
    let inferred = joints
        .iter()
        .filter(|j| j.tracking == ntu::TrackingState::Inferred)
        .count();
    assert_eq!(inferred, 367);

    let sequences = skeleton.to_pose_sequences(ntu::FPS);
    assert_eq!(sequences.len(), 1);
    let seq = &sequences[0];
    assert_eq!(seq.track_id, skeleton.body_ids()[0]);
    assert_eq!(seq.frames.len(), 103);
    assert_eq!(seq.joint_names, ntu::JOINT_NAMES);
    assert_eq!(seq.frames[102].stamp_nanos, stamp_nanos_at(102, 30.0));
    let half = seq
        .frames
        .iter()
        .flat_map(|f| &f.confidence)
        .filter(|c| **c == 0.5)
        .count();
    assert_eq!(half, 367);
}

#[test]
#[ignore = "needs ../shared/data"]
fn ntu_is_z_up_in_the_autoact_frame() {
    let seq = &ntu_skeleton().to_pose_sequences(ntu::FPS)[0];
    let index = |name| seq.joint_index(name).expect("joint");
    let (head, left, right) = (index("Head"), index("FootLeft"), index("FootRight"));
    for frame in &seq.frames {
        let z = |j: usize| frame.positions_m[j].z;
        assert!(
            z(head) > z(left) + 1.0 && z(head) > z(right) + 1.0,
            "head not above the feet"
        );
    }
}

/// The long bones of the trunk, legs and upper arms keep their length within ~10 % where Kinect
/// tracked both ends. (Hands, feet, thumbs and the forearms of this drinking clip jitter by
/// 25–60 %, and inferred joints by up to 24 % even on long bones, so they are left out.)
#[test]
#[ignore = "needs ../shared/data"]
fn ntu_bone_lengths_are_stable() {
    let seq = &ntu_skeleton().to_pose_sequences(ntu::FPS)[0];
    let bones = [
        ("SpineBase", "SpineMid"),
        ("SpineMid", "SpineShoulder"),
        ("HipLeft", "KneeLeft"),
        ("KneeLeft", "AnkleLeft"),
        ("HipRight", "KneeRight"),
        ("KneeRight", "AnkleRight"),
        ("ShoulderLeft", "ElbowLeft"),
        ("ShoulderRight", "ElbowRight"),
    ];
    for (parent, joint) in bones {
        let (p, j) = (
            seq.joint_index(parent).expect("joint"),
            seq.joint_index(joint).expect("joint"),
        );
        let tracked: Vec<f64> = seq
            .frames
            .iter()
            .zip(lengths(seq, parent, joint))
            .filter(|(f, _)| f.confidence[p] == 1.0 && f.confidence[j] == 1.0)
            .map(|(_, l)| l)
            .collect();
        assert!(
            tracked.len() >= 30,
            "{parent}→{joint}: only {} tracked frames",
            tracked.len()
        );
        let median = median(tracked.clone());
        assert!(
            (0.15..0.5).contains(&median),
            "{parent}→{joint}: median {median} m"
        );
        let within = tracked
            .iter()
            .filter(|l| (*l / median - 1.0).abs() <= 0.10)
            .count();
        assert!(
            within * 10 >= tracked.len() * 9,
            "{parent}→{joint}: only {within} of {} tracked frames within 10 % of {median} m",
            tracked.len()
        );
    }
}

/// The quaternion's local +Y axis points along parent→joint. Converting the orientation with
/// `orientation_to_autoact` and the positions with `point_to_autoact` must keep that true.
#[test]
#[ignore = "needs ../shared/data"]
fn ntu_orientation_y_axis_follows_the_bone_after_conversion() {
    let skeleton = ntu_skeleton();
    let axes = ntu::AXES;
    let local_y = axes.to_autoact(Vector3::y());
    let (mut converted, mut unconverted, mut count) = (0.0, 0.0, 0_usize);
    for body in skeleton.frames.iter().flat_map(|f| &f.bodies) {
        let position = |j: usize| axes.point_to_autoact(body.joints[j].camera_m);
        for (j, joint) in body.joints.iter().enumerate() {
            let (Some(parent), Some(q)) = (ntu::JOINT_PARENTS[j], joint.orientation) else {
                continue;
            };
            let bone = (position(j) - position(parent)).normalize();
            converted += (axes.orientation_to_autoact(q) * local_y).dot(&bone);
            unconverted += (q * local_y).dot(&bone);
            count += 1;
        }
    }
    // non-leaf joints with a parent: 24 − 7 leaves = 17 per frame
    assert_eq!(count, 103 * 17);
    let mean = converted / count as f64;
    assert!(mean >= 0.99, "mean cos {mean}");
    // the check is sensitive: leaving the orientation in Kinect axes breaks it
    assert!(
        unconverted / (count as f64) < 0.5,
        "unconverted mean cos {}",
        unconverted / count as f64
    );
}

fn check_zed(relative: &str, frames: usize) -> PoseSequence {
    let recording = zed(relative);
    assert_eq!(recording.len(), frames);
    let seq = recording.to_pose_sequence();
    assert_eq!(seq.frames.len(), frames);
    assert_eq!(seq.joint_names.len(), 34);
    assert_eq!(seq.joint_names, zed_mat::JOINT_NAMES);
    assert_eq!(seq.frames[0].stamp_nanos, 0);

    // Stamps strictly increase with the real gaps: mostly 33–34 ms, some ~67 ms drops.
    let steps_ms: Vec<u64> = seq
        .frames
        .windows(2)
        .map(|w| (w[1].stamp_nanos - w[0].stamp_nanos) / 1_000_000)
        .collect();
    assert!(steps_ms.iter().all(|s| *s > 0));
    let regular = steps_ms.iter().filter(|s| (30..=37).contains(*s)).count();
    let dropped = steps_ms.iter().filter(|s| (60..=70).contains(*s)).count();
    assert!(
        regular * 10 >= steps_ms.len() * 8,
        "{regular} of {} steps are ~33 ms",
        steps_ms.len()
    );
    assert!(dropped >= 1, "no ~67 ms gap");
    assert_eq!(
        regular + dropped,
        steps_ms.len(),
        "other steps: {steps_ms:?}"
    );
    let raw = recording.timestamps_ms();
    assert_eq!(
        seq.frames[frames - 1].stamp_nanos,
        (raw[frames - 1] - raw[0]) as u64 * 1_000_000
    );

    // Thighs ≈ 0.41 m on both sides.
    for (hip, knee) in [("L_HIP", "L_KNEE"), ("R_HIP", "R_KNEE")] {
        let thigh = median(lengths(&seq, hip, knee));
        assert!((thigh - 0.41).abs() <= 0.05, "{hip}→{knee}: {thigh} m");
    }

    // Head above pelvis: +Z is up in the autoact frame.
    let (head, pelvis) = (
        seq.joint_index("HEAD").expect("HEAD"),
        seq.joint_index("PELVIS").expect("PELVIS"),
    );
    let mut checked = 0;
    for frame in &seq.frames {
        let (h, p): (Point3<f64>, Point3<f64>) =
            (frame.positions_m[head], frame.positions_m[pelvis]);
        if h.z.is_finite() && p.z.is_finite() {
            assert!(h.z > p.z + 0.3, "head {h} not above pelvis {p}");
            checked += 1;
        }
    }
    assert!(checked * 10 >= frames * 9);
    seq
}

#[test]
#[ignore = "needs ../shared/data"]
fn zed_walk() {
    check_zed(ZED_WALK, 126);
}

#[test]
#[ignore = "needs ../shared/data"]
fn zed_run() {
    check_zed(ZED_RUN, 94);
}

/// UTD-MHAD's Kinect v1 file: every joint in every frame, body proportions, and the names
/// checked against the data itself: the person's left is where their shoulders and their feet
/// both say (facing from the shoulder line and up, against the ankle→foot direction), and in
/// this "right arm swipe" the right wrist is the one that travels.
#[test]
#[ignore = "needs ../shared/data"]
#[expect(clippy::print_stderr, reason = "reports what it measured")]
fn utd_kinect_v1_joints_sides_and_proportions() {
    let clip = utd_mat::read(data(UTD_SWIPE)).unwrap_or_else(|e| panic!("{e}"));
    let seq = clip.to_pose_sequence(utd_mat::FPS);
    assert_eq!(seq.frames.len(), 52);
    assert_eq!(seq.joint_names, utd_mat::JOINT_NAMES);
    assert_eq!(seq.frames[51].stamp_nanos, stamp_nanos_at(51, 30.0));
    assert!(
        seq.frames
            .iter()
            .all(|f| f.confidence.iter().all(|c| *c == 1.0)),
        "a joint is missing"
    );
    let at = |f: usize, n: &str| seq.frames[f].positions_m[seq.joint_index(n).expect(n)];
    // Adult proportions (Kinect v1 joints are noisy: medians, wide bounds).
    for (a, b, lo, hi) in [
        ("HipLeft", "KneeLeft", 0.30, 0.50),
        ("HipRight", "KneeRight", 0.30, 0.50),
        ("KneeLeft", "AnkleLeft", 0.30, 0.50),
        ("ShoulderLeft", "ElbowLeft", 0.20, 0.35),
        ("ElbowRight", "WristRight", 0.18, 0.32),
    ] {
        let m = median(lengths(&seq, a, b));
        assert!((lo..=hi).contains(&m), "{a}→{b}: {m} m");
    }
    let mut agree = 0;
    for f in 0..seq.frames.len() {
        assert!(
            at(f, "Head").z > at(f, "HipCenter").z + 0.4,
            "frame {f}: +Z is up"
        );
        let facing = (at(f, "ShoulderLeft") - at(f, "ShoulderRight")).cross(&Vector3::z());
        let feet =
            (at(f, "FootLeft") - at(f, "AnkleLeft")) + (at(f, "FootRight") - at(f, "AnkleRight"));
        if facing.dot(&feet) > 0.0 {
            agree += 1;
        }
    }
    assert!(
        agree * 10 >= seq.frames.len() * 9,
        "shoulders and feet face the same way in {agree} of {} frames",
        seq.frames.len()
    );
    let travel = |n: &str| {
        (1..seq.frames.len())
            .map(|f| (at(f, n) - at(f - 1, n)).norm())
            .sum::<f64>()
    };
    let (right, left) = (travel("WristRight"), travel("WristLeft"));
    eprintln!(
        "UTD swipe: shoulders and feet agree in {agree} of {} frames; wrist travel right {right:.2} m, left {left:.2} m",
        seq.frames.len()
    );
    assert!(right > 3.0 * left, "right wrist {right} m, left {left} m");
}

/// CMU Panoptic (two sequences of seated musicians, three people each): the shared folder, which
/// holds both sequences, is refused by name; each sequence, in a folder of its own, reads as
/// one track per person, 1/29.97 s apart, in a right-handed frame with the floor at z = 0. The
/// sides are checked against what the data says, not against our reading of Panoptic's axes:
/// the facing from the shoulder line and up agrees with the nose (in front of the ears) and with
/// the thighs (a seated person's knees are in front of the hips) in every body of every frame.
#[test]
#[ignore = "needs ../shared/data"]
#[expect(clippy::print_stderr, reason = "reports what it measured")]
fn panoptic_sequences_people_sides_floor_and_timing() {
    let e = panoptic::read(data(PANOPTIC)).expect_err("two sequences in one folder");
    assert!(
        matches!(e, panoptic::PanopticError::MixedSequences { count: 2, .. }),
        "{e}"
    );
    for sequence in ["160906_band1", "160906_band2"] {
        let dir = tempfile::tempdir().expect("temp dir");
        for entry in std::fs::read_dir(data(PANOPTIC)).expect("panoptic folder") {
            let path = entry.expect("entry").path();
            let name = path
                .file_name()
                .and_then(|n| n.to_str())
                .unwrap_or_default();
            if name.starts_with(sequence) {
                std::fs::copy(&path, dir.path().join(name)).expect("copy");
            }
        }
        let clip = panoptic::read(dir.path()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(clip.fps_type(), Some("hd_29_97"));
        let fps = clip.fps().expect("a known rate");
        let seqs = clip.to_pose_sequences(fps);
        assert_eq!(
            seqs.iter().map(|s| s.track_id).collect::<Vec<_>>(),
            [0, 1, 2]
        );
        let (mut ankles, mut checked) = (Vec::new(), 0);
        for seq in &seqs {
            assert_eq!(seq.frames.len(), 2, "{sequence} track {}", seq.track_id);
            // 33.37 ms: the files' univTime differ by 33.356 ms.
            assert_eq!(seq.frames[1].stamp_nanos, 33_366_667);
            for f in &seq.frames {
                let at = |n: &str| {
                    let j = seq.joint_index(n).expect(n);
                    (f.confidence[j] > 0.0).then(|| f.positions_m[j])
                };
                let (Some(l), Some(r)) = (at("lShoulder"), at("rShoulder")) else {
                    panic!("{sequence} track {}: no shoulders", seq.track_id);
                };
                let facing = Vector3::z().cross(&(r - l));
                if let (Some(nose), Some(le), Some(re)) = (at("Nose"), at("lEar"), at("rEar")) {
                    let ahead = nose - Point3::from((le.coords + re.coords) / 2.0);
                    assert!(
                        facing.dot(&ahead) > 0.0,
                        "{sequence} {}: nose behind",
                        seq.track_id
                    );
                    checked += 1;
                }
                for (hip, knee) in [("lHip", "lKnee"), ("rHip", "rKnee")] {
                    if let (Some(h), Some(k)) = (at(hip), at(knee)) {
                        assert!(
                            facing.dot(&(k - h)) > 0.0,
                            "{sequence} {}: {knee}",
                            seq.track_id
                        );
                        let thigh = (k - h).norm();
                        assert!((0.3..0.55).contains(&thigh), "{hip}→{knee} {thigh} m");
                        checked += 1;
                    }
                }
                ankles.extend(
                    ["lAnkle", "rAnkle"]
                        .iter()
                        .filter_map(|n| at(n))
                        .map(|p| p.z),
                );
                let head = at("Nose").expect("nose").z;
                assert!((0.7..1.5).contains(&head), "a seated head at {head} m");
            }
        }
        // The ankle joint sits about 8 cm above the sole.
        assert!(
            ankles.iter().all(|z| (0.02..0.25).contains(z)),
            "{sequence}: ankle heights {ankles:?}"
        );
        eprintln!(
            "Panoptic {sequence}: sides agree in {checked} of {checked} checks; ankle heights {:.3}–{:.3} m",
            ankles.iter().copied().fold(f64::INFINITY, f64::min),
            ankles.iter().copied().fold(0.0, f64::max)
        );
        // Through `import` as a user runs it: found by its folder, not re-grounded.
        let imported = importer::import(
            dir.path(),
            &options(InputFormat::Auto, None, None, LengthMode::Measured),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(imported.format, InputFormat::PanopticJson);
        assert_eq!(imported.layout, panoptic::LAYOUT);
        assert!(imported.grounding.is_none());
        // The same frames (compared as text: a missing joint's NaN is not equal to itself).
        assert_eq!(format!("{:?}", imported.sequences), format!("{seqs:?}"));
    }
}

/// Cutting the real files short anywhere gives an error, never a panic or a shorter clip.
#[test]
#[ignore = "needs ../shared/data"]
fn truncated_real_files_are_errors() {
    let bytes = std::fs::read(data(ZED_WALK)).expect("zed walk");
    for k in (0..bytes.len()).step_by(37) {
        assert!(
            zed_mat::parse(&bytes[..k], "cut.mat").is_err(),
            "zed cut at {k} parsed"
        );
    }
    let bytes = std::fs::read(data(UTD_SWIPE)).expect("utd swipe");
    for k in (0..bytes.len()).step_by(37) {
        assert!(
            utd_mat::parse(&bytes[..k], "cut.mat").is_err(),
            "utd cut at {k} parsed"
        );
    }
    let file = "panoptic/160906_band1_body3DScene_00000168.json";
    let bytes = std::fs::read(data(file)).expect("panoptic");
    for k in (0..bytes.len()).step_by(37) {
        assert!(
            panoptic::parse(&bytes[..k], "cut.json").is_err(),
            "panoptic cut at {k} parsed"
        );
    }
    let text = std::fs::read_to_string(data(NTU_FILE)).expect("ntu");
    let lines: Vec<&str> = text.lines().collect();
    for n in (0..lines.len()).step_by(7) {
        let cut = lines[..n].join("\n");
        assert!(
            ntu::parse(&cut, "cut.skeleton").is_err(),
            "ntu cut after {n} lines parsed"
        );
    }
}

// Grounding camera-frame sources (issue 19, item 4).
//
// "Up within 3°" has no ground truth in these files (no camera pose, no gravity), so it is
// measured against two things the grounding does not fit directly:
// - the **contact plane**: an ordinary least-squares plane (no prior) through the feet at the
//   contacts this test detects itself (lowest heel/toe or ankle point of a foot moving less than
//   0.3 m/s); its normal must be within 3° of +Z where the contacts spread in two directions;
// - the **body's long-run vertical**: the mean unit direction from the midpoint of the ankles to
//   the neck over the frames where the body is upright (at least 97 % of its longest
//   ankle→neck span); within 3° of +Z across the direction of travel (leaning into a run is
//   real, so only the sideways component is checked on moving clips). The ZED run curves left
//   and right (a runner leans into turns) and has few slow-foot frames: it is held at 4°;
// - **one camera, one up**: both ZED clips come from the same camera (serial 35745898, six
//   minutes apart); their up estimates, in the camera frame, must agree within 3°.
// "Feet within 3 cm of z = 0": at the detected contacts, the lowest foot point minus its height
// above the sole at rest (heel 0.01 m, toe 0.02 m, ankle 0.08 m); the median must be within
// 3 cm. ZED's own feet are noisier than that (a foot standing still drifts 3 cm in height
// within 0.7 s at the start of the walk), so the 90th percentile is only held under 6 cm.
// The mmpose frames are unrelated moments (no motion to detect contacts by): there a foot is at
// contact when it is its frame's lower foot or within 5 cm of it.

use autoact::formats::import::{self as importer, ImportOptions, InputFormat};
use autoact::skeleton::ground::{GroundMode, angle_deg};
use autoact::skeleton::lengths::{LengthMode, flexion_deg};

/// Per frame and foot, the lowest sole point (`None` where unseen).
fn soles(seq: &PoseSequence, feet: &[[(&str, f64); 3]; 2]) -> Vec<[Option<Point3<f64>>; 2]> {
    seq.frames
        .iter()
        .map(|f| {
            let sole = |foot: &[(&str, f64); 3]| {
                foot.iter()
                    .filter_map(|(name, off)| {
                        let p = f.positions_m[seq.joint_index(name)?];
                        p.z.is_finite().then(|| p - Vector3::z() * *off)
                    })
                    .min_by(|a, b| a.z.total_cmp(&b.z))
            };
            [sole(&feet[0]), sole(&feet[1])]
        })
        .collect()
}

/// Contacts: sole points of a foot moving less than 0.3 m/s; for `unrelated` frames, the
/// lower foot of each frame and any within 5 cm of it.
fn contacts(seq: &PoseSequence, feet: &[[(&str, f64); 3]; 2], unrelated: bool) -> Vec<Point3<f64>> {
    let soles = soles(seq, feet);
    let mut out = Vec::new();
    for (i, frame) in soles.iter().enumerate() {
        let lower = frame
            .iter()
            .flatten()
            .map(|p| p.z)
            .fold(f64::INFINITY, f64::min);
        for (side, sole) in frame.iter().enumerate() {
            let Some(p) = *sole else { continue };
            if unrelated {
                if p.z <= lower + 0.05 {
                    out.push(p);
                }
                continue;
            }
            let speed = |j: usize| -> Option<f64> {
                let q = soles.get(j)?[side]?;
                let dt = (seq.frames[i]
                    .stamp_nanos
                    .abs_diff(seq.frames[j].stamp_nanos)) as f64
                    * 1e-9;
                Some((q - p).norm() / dt)
            };
            let slowest = [i.checked_sub(1).and_then(speed), speed(i + 1)]
                .into_iter()
                .flatten()
                .reduce(f64::min);
            if slowest.is_none_or(|v| v < 0.3) {
                out.push(p);
            }
        }
    }
    out
}

/// The least-squares plane normal through `points` (towards +Z) and the smaller in-plane spread.
fn plane_normal(points: &[Point3<f64>]) -> (Vector3<f64>, f64) {
    let n = points.len() as f64;
    let mean = points.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
    let mut scatter = nalgebra::Matrix3::zeros();
    for p in points {
        scatter += (p.coords - mean) * (p.coords - mean).transpose();
    }
    let eigen = (scatter / n).symmetric_eigen();
    let mut order: Vec<usize> = (0..3).collect();
    order.sort_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
    let mut normal = eigen.eigenvectors.column(order[0]).into_owned();
    if normal.z < 0.0 {
        normal = -normal;
    }
    (normal, eigen.eigenvalues[order[1]].sqrt())
}

/// The body's long-run vertical (see above) and the direction of travel (unit, horizontal; zero
/// when the pelvis moves less than 0.5 m).
fn body_vertical(
    seq: &PoseSequence,
    ankles: [&str; 2],
    neck: &str,
    pelvis: &str,
) -> (Vector3<f64>, Vector3<f64>) {
    let (a, b, n, p) = (
        seq.joint_index(ankles[0]).expect("joint"),
        seq.joint_index(ankles[1]).expect("joint"),
        seq.joint_index(neck).expect("joint"),
        seq.joint_index(pelvis).expect("joint"),
    );
    let spans: Vec<Vector3<f64>> = seq
        .frames
        .iter()
        .map(|f| f.positions_m[n] - nalgebra::center(&f.positions_m[a], &f.positions_m[b]))
        .filter(|d| d.norm().is_finite())
        .collect();
    let pelvis: Vec<Point3<f64>> = seq
        .frames
        .iter()
        .map(|f| f.positions_m[p])
        .filter(|q| q.x.is_finite())
        .collect();
    let mut travel = pelvis[pelvis.len() - 1] - pelvis[0];
    travel.z = 0.0;
    let travel = if travel.norm() > 0.5 {
        travel.normalize()
    } else {
        Vector3::zeros()
    };
    let longest = spans.iter().map(Vector3::norm).fold(0.0, f64::max);
    let up: Vector3<f64> = spans
        .iter()
        .filter(|d| d.norm() >= 0.97 * longest)
        .map(Vector3::normalize)
        .sum();
    (up.normalize(), travel)
}

fn import_grounded(path: &std::path::Path, options: &ImportOptions) -> importer::Imported {
    importer::import(path, options).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn options(
    format: InputFormat,
    layout: Option<&str>,
    fps: Option<f64>,
    lengths: LengthMode,
) -> ImportOptions {
    ImportOptions {
        format,
        layout: layout.map(str::to_string),
        fps,
        axes: None,
        metres_per_unit: None,
        bvh_map: None,
        ground: GroundMode::Auto,
        lengths,
    }
}

/// Checks a grounded clip and prints its numbers.
#[expect(clippy::print_stderr, reason = "reports the measured numbers")]
fn check_grounded(
    name: &str,
    seq: &PoseSequence,
    feet: &[[(&str, f64); 3]; 2],
    trunk: ([&str; 2], &str, &str),
    unrelated: bool,
    max_sideways_deg: f64,
) {
    let contacts = contacts(seq, feet, unrelated);
    assert!(contacts.len() >= 2, "{name}: {} contacts", contacts.len());
    let mut heights: Vec<f64> = contacts.iter().map(|p| p.z.abs()).collect();
    heights.sort_by(f64::total_cmp);
    let q = |f: f64| heights[((heights.len() - 1) as f64 * f).round() as usize];
    let (normal, spread) = plane_normal(&contacts);
    let (vertical, travel) = body_vertical(seq, trunk.0, trunk.1, trunk.2);
    let sideways = if travel.norm() > 0.0 {
        let across = Vector3::z().cross(&travel);
        across.dot(&vertical).asin().to_degrees().abs()
    } else {
        angle_deg(&vertical, &Vector3::z())
    };
    eprintln!(
        "{name}: {} contacts, |z| median {:.1} mm, p90 {:.1} mm, max {:.1} mm; contact plane {:.2}° from +Z (spread {:.2} m); body vertical {:.2}° from +Z, {:.2}° sideways",
        contacts.len(),
        q(0.5) * 1e3,
        q(0.9) * 1e3,
        q(1.0) * 1e3,
        angle_deg(&normal, &Vector3::z()),
        spread,
        angle_deg(&vertical, &Vector3::z()),
        sideways,
    );
    assert!(
        q(0.5) <= 0.03,
        "{name}: feet {:.3} m from z = 0 at contact (median)",
        q(0.5)
    );
    assert!(
        q(0.9) <= 0.06,
        "{name}: feet {:.3} m from z = 0 at contact (p90)",
        q(0.9)
    );
    if spread >= 0.1 {
        assert!(
            angle_deg(&normal, &Vector3::z()) <= 3.0,
            "{name}: contact plane tilted"
        );
    }
    assert!(
        sideways <= max_sideways_deg,
        "{name}: body vertical {sideways}° off +Z"
    );
}

const ZED_FEET: [[(&str, f64); 3]; 2] = [
    [("L_HEEL", 0.01), ("L_FOOT", 0.02), ("L_ANKLE", 0.08)],
    [("R_HEEL", 0.01), ("R_FOOT", 0.02), ("R_ANKLE", 0.08)],
];

#[test]
#[ignore = "needs ../shared/data"]
#[expect(clippy::print_stderr, reason = "reports the measured numbers")]
fn zed_clips_are_grounded() {
    let mut ups = Vec::new();
    for (clip, max_sideways_deg) in [(ZED_WALK, 3.0), (ZED_RUN, 4.0)] {
        let imported = import_grounded(
            &data(clip),
            &options(InputFormat::Auto, None, None, LengthMode::Measured),
        );
        let g = &imported.grounding.as_ref().expect("grounded").grounding;
        eprintln!("{clip}: {}", g.summary());
        ups.push(g.up_in_camera);
        check_grounded(
            clip,
            &imported.sequences[0],
            &ZED_FEET,
            (["L_ANKLE", "R_ANKLE"], "NECK", "PELVIS"),
            false,
            max_sideways_deg,
        );
    }
    let apart = angle_deg(&ups[0], &ups[1]);
    eprintln!("one camera: the two clips' up {apart:.2}° apart");
    assert!(apart <= 3.0, "one camera, two ups {apart}° apart");
}

/// Flexion range (degrees) of both knees, and the CV of both thighs.
fn knees_and_thighs(
    seq: &PoseSequence,
    stability: &[autoact::skeleton::eval::LengthStability],
) -> ([(f64, f64); 2], [f64; 2]) {
    let mut ranges = [(f64::INFINITY, f64::NEG_INFINITY); 2];
    for (i, side) in ["L", "R"].iter().enumerate() {
        let j = |n: &str| seq.joint_index(&format!("{side}_{n}")).expect("joint");
        for f in &seq.frames {
            let deg = flexion_deg(
                &f.positions_m[j("HIP")],
                &f.positions_m[j("KNEE")],
                &f.positions_m[j("ANKLE")],
            );
            if deg.is_finite() {
                ranges[i] = (ranges[i].0.min(deg), ranges[i].1.max(deg));
            }
        }
    }
    let cv = |seg: &str| {
        stability
            .iter()
            .find(|s| s.segment == seg)
            .map_or(f64::NAN, |s| s.cv)
    };
    (ranges, [cv("l_hip→l_knee"), cv("r_hip→r_knee")])
}

#[test]
#[ignore = "needs ../shared/data"]
#[expect(clippy::print_stderr, reason = "reports the measured numbers")]
fn zed_fixed_lengths_hold_the_thighs_and_keep_the_knee_bend() {
    for clip in [ZED_WALK, ZED_RUN] {
        let measured = import_grounded(
            &data(clip),
            &options(InputFormat::Auto, None, None, LengthMode::Measured),
        );
        let fixed = import_grounded(
            &data(clip),
            &options(InputFormat::Auto, None, None, LengthMode::Fixed),
        );
        let layout = autoact::skeleton::layout::Layout::load("zed-body-34").unwrap();
        let after = autoact::skeleton::lengths::stability(&fixed.sequences[0], &layout).unwrap();
        let (knees_before, cv_before) =
            knees_and_thighs(&measured.sequences[0], &measured.stability[0]);
        let (knees_after, cv_after) = knees_and_thighs(&fixed.sequences[0], &after);
        eprintln!(
            "{clip}: knee flexion L {:.0}–{:.0}° R {:.0}–{:.0}° → L {:.0}–{:.0}° R {:.0}–{:.0}°; thigh CV L {:.1} % R {:.1} % → {:.2} % {:.2} %",
            knees_before[0].0,
            knees_before[0].1,
            knees_before[1].0,
            knees_before[1].1,
            knees_after[0].0,
            knees_after[0].1,
            knees_after[1].0,
            knees_after[1].1,
            cv_before[0] * 100.0,
            cv_before[1] * 100.0,
            cv_after[0] * 100.0,
            cv_after[1] * 100.0,
        );
        for line in autoact::skeleton::lengths::report_lines(&measured.stability[0])
            .iter()
            .take(4)
        {
            eprintln!("  {line}");
        }
        assert!(cv_after[0] < 0.005 && cv_after[1] < 0.005);
        for side in 0..2 {
            let span = |r: (f64, f64)| r.1 - r.0;
            assert!(
                span(knees_after[side]) >= 0.5 * span(knees_before[side]),
                "the knee bend is kept"
            );
        }
    }
}

/// The `S` array (frames × 17 × 4: x, y, z, visibility; metres, camera frame, y down) of the
/// mmpose test npz (a zip of stored .npy files).
fn npz_h36m_frames() -> Vec<[[f64; 4]; 17]> {
    let bytes = std::fs::read(data("h36m_17j/mmpose_test_h36m_body3d.npz")).expect("npz");
    let name = b"S.npy";
    let at = bytes
        .windows(name.len())
        .position(|w| w == name)
        .expect("S.npy in the npz");
    let npy = &bytes[at + name.len()..];
    let magic = npy
        .windows(6)
        .position(|w| w == b"\x93NUMPY")
        .expect("npy magic");
    let npy = &npy[magic..];
    let header_len = u16::from_le_bytes([npy[8], npy[9]]) as usize;
    let header = String::from_utf8_lossy(&npy[10..10 + header_len]);
    assert!(
        header.contains("'<f8'") && header.contains("(4, 17, 4)"),
        "{header}"
    );
    let values: Vec<f64> = npy[10 + header_len..]
        .chunks_exact(8)
        .take(4 * 17 * 4)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
    (0..4)
        .map(|f| std::array::from_fn(|j| std::array::from_fn(|k| values[(f * 17 + j) * 4 + k])))
        .collect()
}

/// The mmpose H36M frames as MMPose JSON, one clip per camera (frames 0–1: camera 54138969,
/// S1 Directions and S5 SittingDown; frames 2–3: camera 55011271, S7 Greeting and S8 WalkDog):
/// the two frames of a camera share its floor, so they ground together. They are stamped 100 s
/// apart (`--fps 0.01`): unrelated moments, not a motion.
#[test]
#[ignore = "needs ../shared/data"]
#[expect(clippy::print_stderr, reason = "reports the measured numbers")]
fn mmpose_h36m_frames_are_grounded() {
    let frames = npz_h36m_frames();
    let dir = tempfile::tempdir().unwrap();
    let feet = [
        [
            ("left_foot", 0.08),
            ("left_foot", 0.08),
            ("left_foot", 0.08),
        ],
        [
            ("right_foot", 0.08),
            ("right_foot", 0.08),
            ("right_foot", 0.08),
        ],
    ];
    for (camera, pair) in [("54138969", &frames[0..2]), ("55011271", &frames[2..4])] {
        let json: Vec<serde_json::Value> = pair
            .iter()
            .enumerate()
            .map(|(k, f)| {
                let keypoints: Vec<[f64; 3]> = f.iter().map(|p| [p[0], p[1], p[2]]).collect();
                serde_json::json!({"frame_id": k, "instances": [{"keypoints": keypoints}]})
            })
            .collect();
        let path = dir.path().join(format!("{camera}.json"));
        std::fs::write(&path, serde_json::to_string(&json).unwrap()).unwrap();
        let imported = import_grounded(
            &path,
            &options(
                InputFormat::MmposeJson,
                Some("h36m-17"),
                Some(0.01),
                LengthMode::Measured,
            ),
        );
        let g = &imported.grounding.as_ref().expect("grounded").grounding;
        eprintln!("camera {camera}: {}", g.summary());
        for (k, f) in imported.sequences[0].frames.iter().enumerate() {
            let z = |n: &str| f.positions_m[imported.sequences[0].joint_index(n).unwrap()].z;
            eprintln!(
                "  frame {k}: ankles z {:.3} {:.3}, pelvis {:.3}, head {:.3}",
                z("left_foot"),
                z("right_foot"),
                z("root"),
                z("head")
            );
        }
        check_grounded(
            &format!("camera {camera}"),
            &imported.sequences[0],
            &feet,
            (["left_foot", "right_foot"], "neck_base", "root"),
            true,
            3.0,
        );
    }
}
