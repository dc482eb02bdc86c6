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
use autoact::skeleton::character::Character;
use autoact::skeleton::fk::{self, BonePose};
use autoact::skeleton::layout::Layout;
use autoact::skeleton::pose::{PoseSequence, stamp_nanos_at};
use autoact::skeleton::rig::{Dof, Rig};
use nalgebra::{UnitQuaternion, Vector3};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let frames: usize = args.get(1).context("FRAMES")?.parse()?;
    let out = Path::new(args.get(2).context("OUT.mcap")?);
    let fps: f64 = args.get(3).map_or(Ok(50.0), |s| s.parse())?;
    let rig = Rig::standard();
    let layout = Layout::builtin("h36m-17").context("built-in layout")?;
    let character = Character::standard(&rig);
    let arm = rig.bone_index("r_upper_arm").context("bone")?;
    let seq = PoseSequence {
        source: "synthetic".into(),
        track_id: 0,
        joint_names: layout.joints.clone(),
        frames: Vec::new(),
    };
    let mut writer = BagWriter::create(out, WriteConfig::default())?;
    let mut pose = BonePose::rest(&rig);
    for k in 0..frames {
        #[expect(clippy::cast_precision_loss, reason = "frame counts far below 2^52")]
        let t = k as f64 / fps;
        for (b, bone) in rig.bones.iter().enumerate() {
            if let Dof::Hinge { axis } = bone.dof {
                pose.local_rotations[b] =
                    UnitQuaternion::from_axis_angle(&axis, 0.5 + 0.3 * (2.0 * t).sin());
            }
        }
        pose.local_rotations[arm] =
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -1.0 + 0.5 * (3.0 * t).sin());
        pose.local_rotations[0] = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.1 * t);
        // Walks in a circle of 5 m, so that positions stay small however long the bag.
        pose.root_translation_m = Vector3::new(5.0 * (0.16 * t).cos(), 5.0 * (0.16 * t).sin(), 0.0);
        let world = fk::forward(&rig, &character, &pose, 1.0);
        let frame = layout.keypoints_from_rig(&rig, &character, &world, stamp_nanos_at(k, fps));
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
