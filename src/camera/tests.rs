//! The framing test: a seeded plan of 1,000 viewpoints (250 random scenes × 4 viewpoints, half
//! static, half moving) filming a moving, randomly proportioned character. Every joint and the
//! head top of every frame must project inside the image with the margin, and the camera must
//! stay above the ground and inside its distance and height bands.

use nalgebra::{Point3, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::skeleton::character::{Character, Proportions};
use crate::skeleton::fk::{self, BonePose, WorldPose};
use crate::skeleton::rig::Rig;

const SCENES: usize = 250;
const VIEWPOINTS: usize = 4;
const FRAMES: usize = 48;
const MARGIN: f64 = 0.05;
const MAX_DISTANCE_M: f64 = 15.0;

/// Indices of the bones the synthetic motion drives.
struct Bones {
    upper_arm: [usize; 2],
    forearm: [usize; 2],
    thigh: [usize; 2],
    calf: [usize; 2],
    spine0: usize,
    neck: usize,
    head: usize,
}

impl Bones {
    fn of(rig: &Rig) -> Bones {
        let b = |n: &str| rig.bone_index(n).unwrap();
        Bones {
            upper_arm: [b("l_upper_arm"), b("r_upper_arm")],
            forearm: [b("l_forearm"), b("r_forearm")],
            thigh: [b("l_thigh"), b("r_thigh")],
            calf: [b("l_calf"), b("r_calf")],
            spine0: b("spine0"),
            neck: b("neck"),
            head: b("head"),
        }
    }
}

fn about(axis: Vector3<f64>, angle_deg: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle_deg.to_radians())
}

/// A random clip: arms waving from down by the sides to overhead with bending elbows, legs
/// stepping, the spine bowing, the head nodding, and the root turning, walking a few metres in a
/// random direction and hopping.
fn synthesise(rig: &Rig, bones: &Bones, rng: &mut ChaCha8Rng) -> Vec<BonePose> {
    let cycles = rng.random_range(1.0..3.0);
    let phase = rng.random_range(0.0..std::f64::consts::TAU);
    let walk_dir = rng.random_range(0.0..std::f64::consts::TAU);
    let walk_m = rng.random_range(1.0..4.0);
    let start = Vector3::new(
        rng.random_range(-5.0..5.0),
        rng.random_range(-5.0..5.0),
        0.0,
    );
    let yaw0 = rng.random_range(0.0..360.0);
    let turn = rng.random_range(-180.0..180.0);
    let hop_m = rng.random_range(0.0..0.4);
    (0..FRAMES)
        .map(|f| {
            let t = f as f64 / (FRAMES - 1) as f64;
            let w = std::f64::consts::TAU * cycles * t + phase;
            let mut pose = BonePose::rest(rig);
            // Arms: −70° (down) … +110° (past vertical) about the forward axis.
            let raise = -70.0 + 180.0 * (0.5 + 0.5 * w.sin());
            let swing = 40.0 * (0.7 * w).cos();
            for (side, sign) in [(0, 1.0), (1, -1.0)] {
                pose.local_rotations[bones.upper_arm[side]] =
                    about(Vector3::z(), sign * swing) * about(Vector3::y(), sign * raise);
                pose.local_rotations[bones.forearm[side]] =
                    about(Vector3::z(), -sign * 60.0 * (0.5 + 0.5 * (1.3 * w).sin()));
                let step = if side == 0 { w.sin() } else { -w.sin() };
                pose.local_rotations[bones.thigh[side]] = about(Vector3::x(), 35.0 * step);
                pose.local_rotations[bones.calf[side]] =
                    about(Vector3::x(), -35.0 * (1.0 + step.max(0.0)));
            }
            pose.local_rotations[bones.spine0] = about(Vector3::x(), 25.0 * (0.5 * w).sin());
            pose.local_rotations[bones.neck] = about(Vector3::y(), 15.0 * (0.9 * w).sin());
            pose.local_rotations[bones.head] = about(Vector3::x(), 20.0 * (1.1 * w).cos());
            pose.local_rotations[crate::skeleton::rig::ROOT] = about(Vector3::z(), yaw0 + turn * t);
            pose.root_translation_m = start
                + Vector3::new(walk_dir.cos(), walk_dir.sin(), 0.0) * walk_m * t
                + Vector3::z() * hop_m * (std::f64::consts::PI * 2.0 * t).sin().max(0.0);
            pose
        })
        .collect()
}

/// The joints (bone heads) and the head top, computed here independently of
/// [`subject_points_into`]: the head top is the head bone's head plus its rest length along its
/// rest direction (+Z), rotated.
fn joints_and_head_top(
    rig: &Rig,
    ch: &Character,
    bones: &Bones,
    world: &WorldPose,
) -> Vec<Point3<f64>> {
    let head = bones.head;
    let len = rig.bones[head].rest_length_m() * ch.bone_scale[head];
    let mut pts = world.heads_m.clone();
    pts.push(
        world.heads_m[head]
            + world.rotations[head] * (rig.bones[head].rest_direction().into_inner() * len),
    );
    pts
}

fn lenses() -> [Intrinsics; 3] {
    [
        Intrinsics::from_horizontal_fov(1280, 720, 60.0).unwrap(),
        Intrinsics::from_horizontal_fov(640, 480, 75.0).unwrap(),
        Intrinsics::from_horizontal_fov(720, 1280, 45.0).unwrap(),
    ]
}

/// One scene: a character, its clip, the lens, the walk.
struct Scene {
    /// Per frame: the joints and the head top.
    points: Vec<Vec<Point3<f64>>>,
    subject: Subject,
    lens: Intrinsics,
    ranges: RcmRanges,
    band: [f64; 2],
    walk: Vec<Viewpoint>,
}

fn scene(rig: &Rig, bones: &Bones, index: usize, rng: &mut ChaCha8Rng) -> Scene {
    let character = Character::with_proportions(
        rig,
        Proportions {
            height_m: rng.random_range(0.9..=2.0),
            arm_scale: rng.random_range(0.85..1.15),
            leg_scale: rng.random_range(0.85..1.15),
            torso_scale: rng.random_range(0.9..1.1),
        },
    );
    let clip = synthesise(rig, bones, rng);
    let points = clip
        .iter()
        .map(|p| {
            joints_and_head_top(
                rig,
                &character,
                bones,
                &fk::forward(rig, &character, p, 1.0),
            )
        })
        .collect();
    let subject = Subject::from_poses(rig, &character, &clip, 1.0).unwrap();
    let lens = lenses()[index % 3];
    let ranges = RcmRanges {
        distance_m: index.is_multiple_of(4).then_some([2.0, 9.0]),
        ..RcmRanges::default()
    };
    let framing = framing_band(&lens, &subject, MARGIN, MAX_DISTANCE_M).unwrap();
    let band = ranges.distance_band(framing).unwrap();
    // One viewpoint more than filmed: the last moving segment glides to it.
    let walk = random_viewpoints(rng, &ranges, framing, VIEWPOINTS + 1).unwrap();
    Scene {
        points,
        subject,
        lens,
        ranges,
        band,
        walk,
    }
}

fn shot(scene: usize, viewpoint: usize) -> Shot {
    if (scene + viewpoint).is_multiple_of(2) {
        Shot::Moving
    } else {
        Shot::Static
    }
}

#[test]
fn a_thousand_viewpoints_keep_every_joint_in_frame() {
    let rig = Rig::standard();
    let bones = Bones::of(&rig);
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let (mut filmed, mut moving, mut checked) = (0usize, 0usize, 0usize);
    let mut worst_fill: f64 = 0.0;
    for index in 0..SCENES {
        let sc = scene(&rig, &bones, index, &mut rng);
        let [h_lo, h_hi] = sc.ranges.height_m;
        for k in 0..VIEWPOINTS {
            let shot = shot(index, k);
            filmed += 1;
            moving += usize::from(shot == Shot::Moving);
            for (f, points) in sc.points.iter().enumerate() {
                let s = f as f64 / (FRAMES - 1) as f64;
                let ground = sc.subject.ground_xy_m[f];
                let cam = camera_at(
                    &sc.walk[k],
                    Some(&sc.walk[k + 1]),
                    shot,
                    s,
                    ground,
                    sc.subject.centres_m[f],
                );
                let p = cam.position_m;
                let horizontal = (p.xy() - nalgebra::Point2::from(ground)).norm();
                assert!(
                    p.z >= 0.0,
                    "scene {index} viewpoint {k} frame {f}: below ground {p}"
                );
                assert!(
                    (h_lo - 1e-9..=h_hi + 1e-9).contains(&p.z),
                    "scene {index} viewpoint {k} frame {f}: height {} outside {:?}",
                    p.z,
                    sc.ranges.height_m
                );
                assert!(
                    (sc.band[0] - 1e-9..=sc.band[1] + 1e-9).contains(&horizontal),
                    "scene {index} viewpoint {k} frame {f}: distance {horizontal} outside {:?}",
                    sc.band
                );
                // `cam.project(&sc.lens, q)`, with the rotation taken apart once per pose:
                // nalgebra's generic products dominate a debug build's time otherwise.
                let m = cam.world_from_optical.to_rotation_matrix().into_inner();
                let col = |j: usize| [m[(0, j)], m[(1, j)], m[(2, j)]];
                let (ax, ay, az) = (col(0), col(1), col(2));
                let dot = |a: [f64; 3], v: [f64; 3]| a[0] * v[0] + a[1] * v[1] + a[2] * v[2];
                for q in points {
                    let v = [q.x - p.x, q.y - p.y, q.z - p.z];
                    let px = sc
                        .lens
                        .project(Vector3::new(dot(ax, v), dot(ay, v), dot(az, v)))
                        .unwrap_or_else(|| {
                            panic!("scene {index} viewpoint {k} frame {f}: {q} behind the camera")
                        });
                    let fill = ((px[0] - sc.lens.cx_px).abs()
                        / (0.5 * f64::from(sc.lens.width_px)))
                    .max((px[1] - sc.lens.cy_px).abs() / (0.5 * f64::from(sc.lens.height_px)));
                    worst_fill = worst_fill.max(fill);
                    assert!(
                        sc.lens.contains(px, MARGIN),
                        "scene {index} viewpoint {k} ({shot:?}) frame {f}: {q} projects to {px:?}, \
                         outside the {MARGIN} margin of {}×{}",
                        sc.lens.width_px,
                        sc.lens.height_px
                    );
                    checked += 1;
                }
            }
        }
    }
    assert_eq!(filmed, 1_000);
    assert_eq!(moving, 500);
    assert_eq!(checked, 1_000 * FRAMES * 54);
    // The band is not trivially loose: somewhere the body reaches well out into the picture.
    assert!(
        (0.6..=1.0 - MARGIN).contains(&worst_fill),
        "largest extent {worst_fill:.3} of the half-image"
    );
}

/// The same check fails when the camera is brought closer than the band allows: the test can
/// see a character leave the frame.
#[test]
fn closer_than_the_band_loses_the_character() {
    let rig = Rig::standard();
    let bones = Bones::of(&rig);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut lost = 0;
    for index in 0..20 {
        let sc = scene(&rig, &bones, index, &mut rng);
        let mut too_close = sc.walk[0];
        too_close.distance_m = 0.5 * sc.band[0];
        let any_out = sc.points.iter().enumerate().any(|(f, points)| {
            let cam = camera_at(
                &too_close,
                None,
                Shot::Static,
                0.0,
                sc.subject.ground_xy_m[f],
                sc.subject.centres_m[f],
            );
            points.iter().any(|q| {
                cam.project(&sc.lens, q)
                    .is_none_or(|px| !sc.lens.contains(px, MARGIN))
            })
        });
        lost += usize::from(any_out);
    }
    assert!(
        lost >= 15,
        "only {lost} of 20 scenes lost the character at 0.6× the band"
    );
}

#[test]
fn a_character_too_big_for_the_lens_is_reported() {
    let rig = Rig::standard();
    let bones = Bones::of(&rig);
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let giant = Character::with_proportions(
        &rig,
        Proportions {
            height_m: 2.0,
            ..Proportions::default()
        },
    );
    let clip = synthesise(&rig, &bones, &mut rng);
    let subject = Subject::from_poses(&rig, &giant, &clip, 1.0).unwrap();
    let tele = Intrinsics::from_horizontal_fov(1280, 720, 10.0).unwrap();
    let e = framing_band(&tele, &subject, MARGIN, 8.0).unwrap_err();
    assert!(matches!(e, CameraError::DoesNotFit { .. }));
    assert!(e.to_string().contains("does not fit"), "{e}");
    assert!(framing_band(&tele, &subject, MARGIN, 60.0).is_ok());
}
