//! A long pose bag for memory benchmarks (`tools/bench_memory.sh`), written as it is made so
//! that its own memory does not depend on its length: FRAMES H36M-17 skeletons of a walking,
//! waving body at FPS (default 50), one `Skeleton3D` per frame on `/skeleton`, deterministic
//! (the same arguments give the same bytes).
//!
//! Usage: `synth_pose_bag FRAMES OUT.mcap [FPS]`

#![expect(clippy::print_stdout, reason = "a benchmark tool prints what it wrote")]

use std::path::Path;

use anyhow::{Context, Result};
use autoact::bags::pose::{SKELETON_TOPIC, skeleton_message};
use autoact::mcap_io::{BagWriter, WriteConfig};
use autoact::skeleton::pose::PoseSequence;
use nalgebra::Vector3;

mod synth;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let frames: usize = args.get(1).context("FRAMES")?.parse()?;
    let out = Path::new(args.get(2).context("OUT.mcap")?);
    let fps: f64 = args.get(3).map_or(Ok(50.0), |s| s.parse())?;
    let mut motion = synth::Motion::in_layout("h36m-17")?;
    let seq = PoseSequence {
        source: "synthetic".into(),
        track_id: 0,
        joint_names: motion.layout.joints.clone(),
        frames: Vec::new(),
    };
    let mut writer = BagWriter::create(out, WriteConfig::default())?;
    for k in 0..frames {
        // Walks in a circle of 5 m, so that positions stay small however long the bag.
        let frame = motion.frame(k, fps, |t| {
            Vector3::new(5.0 * (0.16 * t).cos(), 5.0 * (0.16 * t).sin(), 0.0)
        });
        writer.write(
            SKELETON_TOPIC,
            frame.stamp_nanos,
            &skeleton_message(&seq, &frame, "h36m-17"),
        )?;
    }
    let stats = writer.finish()?;
    println!(
        "wrote {} ({} messages, {} bytes)",
        out.display(),
        stats.message_count(),
        std::fs::metadata(out)?.len()
    );
    Ok(())
}
