//! A long MMPose-style JSON file for memory benchmarks (`tools/bench_memory.sh`), written as it
//! is made so that its own memory does not depend on its length: FRAMES frames of the walking,
//! waving body of `synth_pose_bag`, as 133 COCO-WholeBody keypoints (metres, z up: import with
//! `--axes z-up`) with scores, one instance per frame, deterministic.
//!
//! Usage: `synth_pose_json FRAMES OUT.json [FPS]`

#![expect(clippy::print_stdout, reason = "a benchmark tool prints what it wrote")]

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result};
use nalgebra::Vector3;

mod synth;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let frames: usize = args.get(1).context("FRAMES")?.parse()?;
    let out = Path::new(args.get(2).context("OUT.json")?);
    let fps: f64 = args.get(3).map_or(Ok(30.0), |s| s.parse())?;
    let mut motion = synth::Motion::in_layout("coco-wholebody-133")?;
    let mut w = std::io::BufWriter::new(std::fs::File::create(out)?);
    w.write_all(b"[")?;
    for k in 0..frames {
        let frame = motion.frame(k, fps, |t| {
            Vector3::new(5.0 * (0.16 * t).cos(), 5.0 * (0.16 * t).sin(), 0.0)
        });
        if k > 0 {
            w.write_all(b",\n")?;
        }
        write!(w, "{{\"frame_id\": {k}, \"instances\": [{{\"keypoints\": [")?;
        for (j, p) in frame.positions_m.iter().enumerate() {
            let sep = if j > 0 { "," } else { "" };
            write!(w, "{sep}[{:.5},{:.5},{:.5}]", p.x, p.y, p.z)?;
        }
        w.write_all(b"], \"keypoint_scores\": [")?;
        for (j, c) in frame.confidence.iter().enumerate() {
            let sep = if j > 0 { "," } else { "" };
            write!(w, "{sep}{c:.3}")?;
        }
        w.write_all(b"]}]}")?;
    }
    w.write_all(b"]\n")?;
    w.flush()?;
    println!(
        "wrote {} ({frames} frames, {} bytes)",
        out.display(),
        std::fs::metadata(out)?.len()
    );
    Ok(())
}
