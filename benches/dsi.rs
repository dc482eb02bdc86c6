//! DSI throughput on one core: output frames per second for a 53-bone animation in which every
//! bone that can move does (within its DoF class), with jitter so the smoother has work.
//!
//! Cases: `dsi/<case>/<frames in>`:
//! - `full_30to30`: segmentation, cubic resampling, transitions, SuperSmoother, at the source's
//!   rate (δ = 1);
//! - `full_30to120`: the same, upsampled 4× (δ = 0.25);
//! - `smooth_only`: the SuperSmoother pass alone.
//!
//! Target (issue "Dynamic Skeletal Interpolation"): DSI + smoothing ≥ 100,000 output frames/s.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::{UnitQuaternion, Vector3};

use autoact::dsi::smoothing::Smoothing;
use autoact::dsi::{self, DsiOptions};
use autoact::skeleton::convert::AnimationFrame;
use autoact::skeleton::fk::BonePose;
use autoact::skeleton::pose::stamp_nanos_at;
use autoact::skeleton::rig::{Dof, Rig};

const FRAMES: usize = 3000;

fn animation(rig: &Rig, frames: usize) -> Vec<AnimationFrame> {
    (0..frames)
        .map(|k| {
            #[expect(clippy::cast_precision_loss, reason = "small frame counts")]
            let t = k as f64 / 30.0;
            // A deterministic jitter of about a degree.
            let jitter = |b: usize, c: usize| {
                #[expect(clippy::cast_precision_loss, reason = "small numbers")]
                let x = (k * 7 + b * 13 + c * 29) as f64 * 0.618_033_988_75;
                0.02 * (x - x.floor() - 0.5)
            };
            let mut pose = BonePose::rest(rig);
            for (b, bone) in rig.bones.iter().enumerate() {
                #[expect(clippy::cast_precision_loss, reason = "bone indices are tiny")]
                let phase = b as f64 * 0.37;
                let q = match bone.dof {
                    Dof::Static => UnitQuaternion::identity(),
                    Dof::Root => {
                        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.5 * t + jitter(b, 0))
                    }
                    Dof::Hinge { axis } => UnitQuaternion::from_axis_angle(
                        &axis,
                        0.6 + 0.4 * (t * 2.0 + phase).sin() + jitter(b, 0),
                    ),
                    Dof::ThreeD | Dof::TwoD => UnitQuaternion::from_scaled_axis(
                        Vector3::new(
                            (t + phase).sin() + jitter(b, 0),
                            (1.3 * t + phase).cos() + jitter(b, 1),
                            0.5 * (0.7 * t).sin() + jitter(b, 2),
                        ) * 0.4,
                    ),
                };
                pose.local_rotations[b] = bone.constrain(&q);
            }
            pose.root_translation_m = Vector3::new(t.sin(), 0.5 * t, 0.0);
            AnimationFrame {
                stamp_nanos: stamp_nanos_at(k, 30.0),
                pose,
            }
        })
        .collect()
}

fn bench_dsi(c: &mut Criterion) {
    let rig = Rig::standard();
    let keys = animation(&rig, FRAMES);
    let mut group = c.benchmark_group("dsi");
    for (case, out_fps) in [("full_30to30", 30.0), ("full_30to120", 120.0)] {
        let mut options = DsiOptions::new(&rig);
        options.out_fps = out_fps;
        let out_frames = dsi::run(&rig, &keys, &options).expect("dsi").animations[0].len();
        group.throughput(Throughput::Elements(out_frames as u64));
        group.bench_with_input(BenchmarkId::new(case, FRAMES), &keys, |b, keys| {
            b.iter(|| dsi::run(&rig, keys, &options).expect("dsi"));
        });
    }
    let poses: Vec<BonePose> = keys.iter().map(|k| k.pose.clone()).collect();
    let moving = autoact::skeleton::fk::moving_bones(&poses);
    group.throughput(Throughput::Elements(FRAMES as u64));
    group.bench_with_input(
        BenchmarkId::new("smooth_only", FRAMES),
        &poses,
        |b, poses| {
            b.iter_batched_ref(
                || poses.clone(),
                |p| Smoothing::default().apply(&rig, p, 30.0, &moving),
                criterion::BatchSize::LargeInput,
            );
        },
    );
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench_dsi
}
criterion_main!(benches);
