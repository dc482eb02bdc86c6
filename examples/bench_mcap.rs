//! MCAP throughput of autoact's writer and reader on H36M-17 skeleton messages, for
//! `tools/bench_mcap.py` (which runs the Python `mcap` writer and reader on the same messages in
//! the same run and prints the ratios).
//!
//! Usage:
//!   `bench_mcap write FRAMES OUT.mcap [FPS]` — synthesise FRAMES skeletons at FPS (default 30;
//!                                        a walking, waving body) and write them; prints
//!                                        `write_s BYTES PAYLOAD_BYTES`
//!   `bench_mcap read IN.mcap`           — read and CDR-decode every message; prints `read_s BYTES`
//!   `bench_mcap json FRAMES OUT.json [FPS]` — the same skeletons as JSON lines, for Python
//!   `bench_mcap loop IN.mcap FRAMES OUT.mcap` — a pose bag of FRAMES skeletons from the first
//!                                        track of IN (real motion), played forwards and
//!                                        backwards in turn at IN's own rate, so that a few
//!                                        thousand recorded frames make a long bag with no
//!                                        jumps; an `h36m-32` track (a Human3.6M import) is cut
//!                                        to its usual 17 joints, `h36m-17`
//!   `bench_mcap wholebody IN.mcap FRAMES OUT.mcap` — as `loop`, for a `coco-wholebody-133` track
//!                                        of real mocap with body and feet only (a BVH import):
//!                                        each hand's 21 points come from a moving synthetic hand
//!                                        (every finger curling) held rigidly in the real
//!                                        forearm's frame, the 68 face points likewise in the real
//!                                        head's, so all 133 points are there and the hands move
//!
//! Timing is the median of three runs (the machine is shared); the printed seconds are wall time.

#![expect(
    clippy::print_stdout,
    reason = "a benchmark tool prints its measurements"
)]

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use autoact::bags::pose::skeleton_message;
use autoact::mcap_io::{BagReader, BagWriter, WriteConfig};
use autoact::ros::autoact_msgs::Skeleton3D;
use autoact::ros::cdr;
use autoact::skeleton::layout::Layout;
use autoact::skeleton::pose::{PoseFrame, PoseSequence, stamp_nanos_at};
use nalgebra::{Matrix3, Point3, Vector3};

mod synth;

fn synthesize(frames: usize, fps: f64) -> Result<PoseSequence> {
    let mut motion = synth::Motion::in_layout("h36m-17")?;
    let frames = (0..frames)
        .map(|k| motion.frame(k, fps, |t| Vector3::new(0.0, 0.8 * t, 0.0)))
        .collect();
    Ok(PoseSequence {
        source: "synthetic".into(),
        track_id: 0,
        joint_names: motion.layout.joints.clone(),
        frames,
    })
}

/// The usual 17 joints of an `h36m-32` sequence, named as the `h36m-17` layout names them.
fn h36m_17_of(seq: PoseSequence) -> PoseSequence {
    use autoact::formats::h36m_expmap::H36M_17_JOINTS;
    let pick = |f: &autoact::skeleton::pose::PoseFrame| autoact::skeleton::pose::PoseFrame {
        stamp_nanos: f.stamp_nanos,
        positions_m: H36M_17_JOINTS.iter().map(|&j| f.positions_m[j]).collect(),
        confidence: H36M_17_JOINTS.iter().map(|&j| f.confidence[j]).collect(),
    };
    PoseSequence {
        joint_names: Layout::builtin("h36m-17").expect("built-in layout").joints,
        frames: seq.frames.iter().map(pick).collect(),
        ..seq
    }
}

/// Orthonormal frame at a body part: x along `along`, y across `side` (made perpendicular),
/// z = x × y.
fn part_frame(along: Vector3<f64>, side: Vector3<f64>) -> Matrix3<f64> {
    let x = along.normalize();
    let y = (side - x * side.dot(&x)).normalize();
    Matrix3::from_columns(&[x, y, x.cross(&y)])
}

/// COCO-WholeBody indices: per side elbow, wrist, first hand point; hand points relative to it.
const HANDS: [(usize, usize, usize); 2] = [(7, 9, 91), (8, 10, 112)];
const FOREFINGER1: usize = 5;
const PINKY1: usize = 17;
const NOSE: usize = 0;
const EARS: (usize, usize) = (3, 4);
const FACE: std::ops::Range<usize> = 23..91;

/// The frames (forearm or head) the hands' and the face's points are held in: `(origin, points,
/// frame)`. The palm lies across the finger bases where there are fingers (`hips` is `None`),
/// else across the hips.
fn part_frames(
    p: &[Point3<f64>],
    hips: Option<Vector3<f64>>,
) -> Vec<(usize, std::ops::Range<usize>, Matrix3<f64>)> {
    let mut out: Vec<_> = HANDS
        .iter()
        .map(|&(elbow, wrist, hand)| {
            let side = hips.unwrap_or(p[hand + PINKY1] - p[hand + FOREFINGER1]);
            (
                wrist,
                hand..hand + 21,
                part_frame(p[wrist] - p[elbow], side),
            )
        })
        .collect();
    let ears = p[EARS.1] - p[EARS.0];
    let mid_ears = nalgebra::center(&p[EARS.0], &p[EARS.1]);
    out.push((NOSE, FACE, part_frame(ears, p[NOSE] - mid_ears)));
    out
}

/// `real` (a 133-point frame whose hands and face are missing) with both hands' 21 points and
/// the 68 face points taken from `synthetic` (the same layout), moved rigidly from the synthetic
/// forearm's or head's frame into the real one's.
fn transplant_hands_and_face(real: &mut PoseFrame, synthetic: &PoseFrame) {
    let (r, s) = (&real.positions_m, &synthetic.positions_m);
    let to = part_frames(r, Some(r[12] - r[11]));
    let mut placed = Vec::new();
    for ((origin, points, from), (_, _, to)) in part_frames(s, None).into_iter().zip(to) {
        for j in points {
            placed.push((j, r[origin] + to * (from.transpose() * (s[j] - s[origin]))));
        }
    }
    for (j, p) in placed {
        real.positions_m[j] = p;
        real.confidence[j] = 1.0;
    }
}

/// `seq` with every joint of `layout`, in its order (those `seq` lacks missing: NaN, confidence 0).
fn in_full_layout(seq: PoseSequence, layout: &Layout) -> PoseSequence {
    let index: Vec<Option<usize>> = layout
        .joints
        .iter()
        .map(|j| seq.joint_names.iter().position(|n| n == j))
        .collect();
    let frames = seq
        .frames
        .iter()
        .map(|f| {
            let mut full = PoseFrame::missing(f.stamp_nanos, index.len());
            for (to, from) in index.iter().enumerate() {
                if let Some(from) = *from {
                    full.positions_m[to] = f.positions_m[from];
                    full.confidence[to] = f.confidence[from];
                }
            }
            full
        })
        .collect();
    PoseSequence {
        joint_names: layout.joints.clone(),
        frames,
        ..seq
    }
}

fn median_of_three(mut f: impl FnMut() -> Result<()>) -> Result<f64> {
    let mut seconds = [0.0; 3];
    for s in &mut seconds {
        let t = Instant::now();
        f()?;
        *s = t.elapsed().as_secs_f64();
    }
    seconds.sort_by(f64::total_cmp);
    Ok(seconds[1])
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    match args.get(1).map(String::as_str) {
        Some("write") => {
            let n: usize = args.get(2).context("FRAMES")?.parse()?;
            let out = Path::new(args.get(3).context("OUT")?);
            let fps: f64 = args.get(4).map_or(Ok(30.0), |f| f.parse())?;
            let seq = synthesize(n, fps)?;
            let messages: Vec<Skeleton3D> = seq
                .frames
                .iter()
                .map(|f| skeleton_message(&seq, f, "h36m-17"))
                .collect();
            let payload: usize = messages
                .iter()
                .map(|m| cdr::encode(m).map_or(0, |b| b.len()))
                .sum();
            let seconds = median_of_three(|| {
                let mut w = BagWriter::create(out, WriteConfig::default())?;
                for (m, f) in messages.iter().zip(&seq.frames) {
                    w.write("/skeleton", f.stamp_nanos, m)?;
                }
                w.finish()?;
                Ok(())
            })?;
            let bytes = std::fs::metadata(out)?.len();
            println!("write_s {seconds:.6} {bytes} {payload}");
        }
        Some("read") => {
            let input = Path::new(args.get(2).context("IN")?);
            let mut count = 0usize;
            let seconds = median_of_three(|| {
                count = 0;
                let reader = BagReader::open(input)?;
                for m in reader.messages() {
                    let m = m?;
                    let s: Skeleton3D = cdr::decode(&m.data)?;
                    count += s.positions.len();
                }
                Ok(())
            })?;
            let bytes = std::fs::metadata(input)?.len();
            println!("read_s {seconds:.6} {bytes} {count}");
        }
        Some("json") => {
            let n: usize = args.get(2).context("FRAMES")?.parse()?;
            let out = args.get(3).context("OUT")?;
            let fps: f64 = args.get(4).map_or(Ok(30.0), |f| f.parse())?;
            let seq = synthesize(n, fps)?;
            let mut w = std::io::BufWriter::new(std::fs::File::create(out)?);
            for f in &seq.frames {
                let p: Vec<[f64; 3]> = f.positions_m.iter().map(|p| [p.x, p.y, p.z]).collect();
                writeln!(
                    w,
                    "{}",
                    serde_json::json!({"stamp": f.stamp_nanos, "positions": p, "confidence": f.confidence})
                )?;
            }
        }
        Some(command @ ("loop" | "wholebody")) => {
            let input = Path::new(args.get(2).context("IN")?);
            let n: usize = args.get(3).context("FRAMES")?.parse()?;
            let out = Path::new(args.get(4).context("OUT")?);
            let topics = autoact::bags::pose::read_pose_topics(input, None, None)?;
            let (Some((_, seq)), Some(layout)) =
                (topics.sequences.into_iter().next(), topics.layouts.first())
            else {
                bail!("{}: no skeletons", input.display());
            };
            let (seq, layout) = if layout == "h36m-32" {
                (h36m_17_of(seq), "h36m-17")
            } else {
                (seq, layout.as_str())
            };
            let (seq, mut hands) = if command == "wholebody" {
                if layout != "coco-wholebody-133" {
                    bail!(
                        "{}: wholebody needs a coco-wholebody-133 track, not {layout}",
                        input.display()
                    );
                }
                let motion = synth::Motion::in_layout(layout)?;
                (in_full_layout(seq, &motion.layout), Some(motion))
            } else {
                (seq, None)
            };
            let seq = &seq;
            let stamps: Vec<u64> = seq.frames.iter().map(|f| f.stamp_nanos).collect();
            let fps = autoact::skeleton::pose::frame_rate(None, &stamps)
                .context("fewer than two frames")?;
            let len = seq.frames.len();
            let mut w = BagWriter::create(out, WriteConfig::default())?;
            for k in 0..n {
                // 0, 1, .., len-1, len-2, .., 1, 0, 1, ..
                let phase = k % (2 * len - 2).max(1);
                let mut frame = seq.frames[phase.min(2 * len - 2 - phase)].clone();
                frame.stamp_nanos = stamp_nanos_at(k, fps);
                if let Some(motion) = &mut hands {
                    transplant_hands_and_face(
                        &mut frame,
                        &motion.frame(k, fps, |_| Vector3::zeros()),
                    );
                }
                w.write(
                    "/skeleton",
                    frame.stamp_nanos,
                    &skeleton_message(seq, &frame, layout),
                )?;
            }
            w.finish()?;
            println!("{command} {n} frames of {len} at {fps:.3} fps, layout {layout}");
        }
        _ => bail!(
            "usage: bench_mcap write FRAMES OUT.mcap | read IN.mcap | json FRAMES OUT.json | loop|wholebody IN.mcap FRAMES OUT.mcap"
        ),
    }
    Ok(())
}
