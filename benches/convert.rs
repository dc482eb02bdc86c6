//! Conversion throughput: keypoints → 53 local quaternions, one core, frames per second.
//!
//! Inputs are synthesised in setup: the rig is driven through a smooth whole-body motion (every
//! bone moving within its DoF class, hinges bent), posed with forward kinematics, and read off
//! as a layout's keypoints. Cases: `convert/<layout>/<frames>`.
//! Targets (issue "Core"): H36M-17 ≥ 500,000 frames/s, COCO-WholeBody-133 ≥ 200,000 frames/s.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::{UnitQuaternion, Vector3};

use autoact::skeleton::character::Character;
use autoact::skeleton::convert::{ConvertOptions, Converter};
use autoact::skeleton::fk::{self, BonePose};
use autoact::skeleton::layout::Layout;
use autoact::skeleton::pose::{PoseFrame, stamp_nanos_at};
use autoact::skeleton::rig::{Dof, Rig};

const FRAMES: usize = 2048;

fn synthetic_motion(rig: &Rig, layout: &Layout, frames: usize) -> Vec<PoseFrame> {
    let character = Character::standard(rig);
    (0..frames)
        .map(|k| {
            #[expect(clippy::cast_precision_loss, reason = "small frame counts")]
            let t = k as f64 / 30.0;
            let mut pose = BonePose::rest(rig);
            for (b, bone) in rig.bones.iter().enumerate() {
                #[expect(clippy::cast_precision_loss, reason = "bone indices are tiny")]
                let phase = b as f64 * 0.37;
                pose.local_rotations[b] = match bone.dof {
                    Dof::Root => UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.5 * t),
                    Dof::Static => UnitQuaternion::identity(),
                    Dof::Hinge { axis } => {
                        UnitQuaternion::from_axis_angle(&axis, 0.6 + 0.4 * (t * 2.0 + phase).sin())
                    }
                    Dof::ThreeD | Dof::TwoD => UnitQuaternion::from_scaled_axis(
                        Vector3::new(
                            (t + phase).sin(),
                            (1.3 * t + phase).cos(),
                            0.5 * (0.7 * t).sin(),
                        ) * 0.4,
                    ),
                };
            }
            pose.root_translation_m = Vector3::new(t.sin(), 0.5 * t, 0.0);
            let world = fk::forward(rig, &character, &pose, 1.0);
            layout.keypoints_from_rig(rig, &character, &world, stamp_nanos_at(k, 30.0))
        })
        .collect()
}

fn bench_convert(c: &mut Criterion) {
    let rig = Rig::standard();
    let mut group = c.benchmark_group("convert");
    group.throughput(Throughput::Elements(FRAMES as u64));
    for name in ["h36m-17", "coco-wholebody-133"] {
        let layout = Layout::builtin(name).expect("built-in layout");
        let frames = synthetic_motion(&rig, &layout, FRAMES);
        let character = Character::standard(&rig);
        group.bench_with_input(BenchmarkId::new(name, FRAMES), &frames, |b, frames| {
            b.iter(|| {
                let mut converter =
                    Converter::new(&rig, &layout, &character, ConvertOptions::default())
                        .expect("binds");
                let mut out = BonePose::rest(&rig);
                for f in frames {
                    converter.convert_frame(f, &mut out).expect("converts");
                }
                out.local_rotations[3]
            });
        });
    }
    group.finish();
}

criterion_group!(benches, bench_convert);
criterion_main!(benches);
