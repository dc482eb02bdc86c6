//! The Human3.6M exponential-map reader on the real S1 clips in `../shared/data/h36m_expmap`.
//!
//! The data is research-only and is not in the repository, so every test is ignored by default;
//! CI runs them with `--ignored` when the data exists. Run with `-- --ignored --nocapture` to see
//! the measured heights and distances.

use std::time::Duration;

use autoact::formats::h36m_expmap::{
    self, ExpmapClip, JOINT_COUNT, JOINT_NAMES, OFFSETS_MM, PARENTS, RootMode, offset_autoact_m,
};
use autoact::skeleton::pose::PoseSequence;
use nalgebra::{Point3, Vector3};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/data");

const WALKING: &str = "S1_walking_1";
const GREETING: &str = "S1_greeting_1";
const SITTING: &str = "S1_sittingdown_2";
const CLIPS: [&str; 3] = [WALKING, GREETING, SITTING];

const HIP: usize = 0;
const HEAD_SITE: usize = 15;
/// Ankles, toes and toe ends of both feet.
const FOOT_JOINTS: [usize; 6] = [3, 4, 5, 8, 9, 10];

fn load(name: &str) -> ExpmapClip {
    let path = format!("{DATA}/h36m_expmap/{name}.txt");
    h36m_expmap::read(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn lowest_foot_z(positions: &[Point3<f64>]) -> f64 {
    FOOT_JOINTS
        .iter()
        .map(|&j| positions[j].z)
        .fold(f64::INFINITY, f64::min)
}

fn horizontal(v: Vector3<f64>) -> f64 {
    v.x.hypot(v.y)
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

fn range(values: impl IntoIterator<Item = f64>) -> (f64, f64) {
    values
        .into_iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
}

/// Head-top height above the lowest foot joint of frame 0 (the floor, up to the foot joints'
/// own height), per frame.
fn head_heights_above_first_floor(seq: &PoseSequence) -> Vec<f64> {
    let floor = lowest_foot_z(&seq.frames[0].positions_m);
    seq.frames
        .iter()
        .map(|f| f.positions_m[HEAD_SITE].z - floor)
        .collect()
}

#[test]
#[ignore = "needs ../shared/data"]
fn frame_counts_names_and_stamps() {
    for (name, expected) in [(WALKING, 3476), (GREETING, 1265), (SITTING, 2742)] {
        let clip = load(name);
        assert_eq!(clip.frame_count(), expected, "{name}");
        assert!(clip.rows().iter().all(|row| row.len() == 99));
        let seq = clip.to_pose_sequence(RootMode::Centred);
        assert_eq!(seq.frames.len(), expected);
        assert_eq!(seq.joint_names, JOINT_NAMES.map(str::to_owned).to_vec());
        assert!(seq.source.ends_with(&format!("{name}.txt")));
        let last = seq.frames.last().expect("frames").stamp_nanos;
        assert_eq!(
            Duration::from_nanos(last),
            Duration::from_millis(20) * u32::try_from(expected - 1).expect("small")
        );
        for frame in &seq.frames {
            assert_eq!(frame.positions_m.len(), JOINT_COUNT);
            assert!(
                frame
                    .confidence
                    .iter()
                    .all(|&c| (c - 1.0).abs() < f32::EPSILON)
            );
            assert!(
                frame
                    .positions_m
                    .iter()
                    .all(|p| p.coords.iter().all(|c| c.is_finite()))
            );
        }
    }
}

#[test]
#[ignore = "needs ../shared/data"]
fn bone_lengths_are_constant_over_frames() {
    for name in CLIPS {
        let clip = load(name);
        for root in [RootMode::Centred, RootMode::Trajectory] {
            for (index, frame) in clip.to_pose_sequence(root).frames.iter().enumerate() {
                let p = &frame.positions_m;
                for (joint, parent) in PARENTS.iter().enumerate() {
                    let Some(parent) = *parent else { continue };
                    let length = (p[joint] - p[parent]).norm();
                    let expected = Vector3::from(OFFSETS_MM[joint]).norm() / 1000.0;
                    assert!(
                        (length - expected).abs() < 1e-9,
                        "{name} {root:?} frame {index} {}: {length} m, expected {expected} m",
                        JOINT_NAMES[joint]
                    );
                }
            }
        }
    }
}

#[test]
#[ignore = "needs ../shared/data"]
#[expect(clippy::print_stderr, reason = "reports the measured heights")]
fn standing_height_is_1_5_to_1_6_m_along_z() {
    for name in CLIPS {
        let clip = load(name);
        let trajectory = clip.to_pose_sequence(RootMode::Trajectory);
        let centred = clip.to_pose_sequence(RootMode::Centred);
        let height = |seq: &PoseSequence, frame: usize| {
            let p = &seq.frames[frame].positions_m;
            p[HEAD_SITE].z - lowest_foot_z(p)
        };
        let levelled = height(&trajectory, 0);
        let leaning = height(&centred, 0);
        eprintln!(
            "{name}: frame-0 height {levelled:.3} m (Trajectory, levelled by {:.1}°), \
             {leaning:.3} m (Centred)",
            clip.levelling_source().angle().to_degrees()
        );
        assert!((1.5..=1.6).contains(&levelled), "{name}: {levelled} m");
        // Head above hip above feet, along autoact +Z.
        let p = &trajectory.frames[0].positions_m;
        assert!(p[HEAD_SITE].z > p[HIP].z + 0.6 && p[HIP].z > lowest_foot_z(p) + 0.8);
        // The Centred figure leans (identity pelvis), so it is shorter along Z.
        assert!(leaning < levelled);
    }
    // Walking stays upright all through.
    let walking = load(WALKING).to_pose_sequence(RootMode::Trajectory);
    let heights: Vec<f64> = walking
        .frames
        .iter()
        .map(|f| f.positions_m[HEAD_SITE].z - lowest_foot_z(&f.positions_m))
        .collect();
    let (lo, hi) = range(heights.iter().copied());
    let typical = median(heights);
    eprintln!("{WALKING}: height while walking {lo:.3}–{hi:.3} m, median {typical:.3} m");
    assert!((1.5..=1.6).contains(&typical), "{typical}");
    assert!(lo > 1.45 && hi < 1.65, "{lo}–{hi}");
}

#[test]
#[ignore = "needs ../shared/data"]
#[expect(clippy::print_stderr, reason = "reports the measured heights")]
fn sitting_down_drops_the_head_in_trajectory_mode() {
    let clip = load(SITTING);
    let seq = clip.to_pose_sequence(RootMode::Trajectory);
    let floor = lowest_foot_z(&seq.frames[0].positions_m);
    let heads = head_heights_above_first_floor(&seq);
    let hips: Vec<f64> = seq
        .frames
        .iter()
        .map(|f| f.positions_m[HIP].z - floor)
        .collect();
    let seated: Vec<usize> = (0..hips.len())
        .filter(|&i| hips[i] < hips[0] - 0.5)
        .collect();
    let seated_heads: Vec<f64> = seated.iter().map(|&i| heads[i]).collect();
    let (head_lo, _) = range(heads.iter().copied());
    let (hip_lo, _) = range(hips.iter().copied());
    let seated_head = median(seated_heads);
    let (feet_lo, feet_hi) = range(
        seq.frames
            .iter()
            .map(|f| lowest_foot_z(&f.positions_m) - floor),
    );
    eprintln!(
        "{SITTING}: head {:.3} m standing, median {seated_head:.3} m over {} seated frames \
         ({:.1} s), lowest {head_lo:.3} m; hip {:.3} m standing, lowest {hip_lo:.3} m; \
         lowest foot joint stays within {feet_lo:+.3}…{feet_hi:+.3} m of the first frame's",
        heads[0],
        seated.len(),
        Duration::from_millis(20 * u64::try_from(seated.len()).expect("small")).as_secs_f64(),
        hips[0],
    );
    assert!(heads[0] > 1.5, "starts standing");
    assert!(seated.len() > 500, "sits for more than 10 s");
    // The subject sits low (the seated hip is about 0.1 m above the foot joints' level), so the
    // head drops to about 0.7 m, below the 1.0 m of chair sitting.
    assert!((0.55..=1.0).contains(&seated_head), "{seated_head}");
    assert!(hip_lo < hips[0] - 0.7, "{hip_lo}");
    // The integrated root translation agrees with the pose: the feet neither sink through the
    // floor nor float while the hip drops.
    assert!(feet_lo > -0.1 && feet_hi < 0.2, "{feet_lo}…{feet_hi}");
    // Centred mode keeps the hip at the origin whatever happens.
    let centred = clip.to_pose_sequence(RootMode::Centred);
    assert!(
        centred
            .frames
            .iter()
            .all(|f| f.positions_m[HIP] == Point3::origin())
    );
}

#[test]
#[ignore = "needs ../shared/data"]
#[expect(clippy::print_stderr, reason = "reports the measured distances")]
fn walking_moves_the_hip_a_plausible_distance() {
    let seq = load(WALKING).to_pose_sequence(RootMode::Trajectory);
    let hips: Vec<Point3<f64>> = seq.frames.iter().map(|f| f.positions_m[HIP]).collect();
    let floor = lowest_foot_z(&seq.frames[0].positions_m);
    // Path length sampled every 0.5 s (25 frames), which ignores the sway within a step.
    let sampled: Vec<&Point3<f64>> = hips.iter().step_by(25).collect();
    let path: f64 = sampled.windows(2).map(|w| horizontal(w[1] - w[0])).sum();
    let duration =
        Duration::from_nanos(seq.frames.last().expect("frames").stamp_nanos).as_secs_f64();
    let speed = path / duration;
    let farthest = hips
        .iter()
        .map(|p| horizontal(p - hips[0]))
        .fold(0.0, f64::max);
    let (x_lo, x_hi) = range(hips.iter().map(|p| p.x));
    let (y_lo, y_hi) = range(hips.iter().map(|p| p.y));
    let (z_lo, z_hi) = range(hips.iter().map(|p| p.z));
    let (feet_lo, feet_hi) = range(
        seq.frames
            .iter()
            .map(|f| lowest_foot_z(&f.positions_m) - floor),
    );
    eprintln!(
        "{WALKING}: hip path {path:.1} m in {duration:.1} s ({speed:.2} m/s), at most \
         {farthest:.2} m from the start, within x {x_lo:+.2}…{x_hi:+.2} m, \
         y {y_lo:+.2}…{y_hi:+.2} m; hip height varies {z_lo:+.3}…{z_hi:+.3} m; lowest foot \
         joint within {feet_lo:+.3}…{feet_hi:+.3} m of the first frame's"
    );
    // A normal walking pace, going round inside the capture area (a few metres across).
    assert!((0.5..=1.5).contains(&speed), "{speed} m/s");
    assert!((1.0..=4.0).contains(&farthest), "{farthest} m");
    // Levelled trajectory: the walk stays on the floor plane.
    assert!(z_hi - z_lo < 0.2, "{z_lo}…{z_hi}");
    assert!(feet_lo > -0.12 && feet_hi < 0.1, "{feet_lo}…{feet_hi}");
}

#[test]
#[ignore = "needs ../shared/data"]
fn world_rotations_are_consistent_with_positions() {
    for name in CLIPS {
        let clip = load(name);
        let offsets: Vec<Vector3<f64>> = (0..JOINT_COUNT).map(offset_autoact_m).collect();
        for root in [RootMode::Centred, RootMode::Trajectory] {
            for frame in 0..clip.frame_count() {
                let p = clip.positions_m(frame, root);
                let q = clip.world_rotations(frame, root);
                for (joint, parent) in PARENTS.iter().enumerate() {
                    let Some(parent) = *parent else { continue };
                    let predicted = p[parent] + q[parent] * offsets[joint];
                    let error = (predicted - p[joint]).norm();
                    assert!(
                        error < 1e-6,
                        "{name} {root:?} frame {frame} {}: {error} m",
                        JOINT_NAMES[joint]
                    );
                }
            }
        }
    }
}

#[test]
#[ignore = "needs ../shared/data"]
fn greeting_stays_in_place() {
    let seq = load(GREETING).to_pose_sequence(RootMode::Trajectory);
    let start = seq.frames[0].positions_m[HIP];
    let farthest = seq
        .frames
        .iter()
        .map(|f| horizontal(f.positions_m[HIP] - start))
        .fold(0.0, f64::max);
    assert!(farthest < 0.5, "{farthest} m");
}
