//! SuperSmoother throughput: samples per second for one core, with the plan and scratch made
//! once (as when smoothing many channels of one length). Cases: `supersmoother/<variant>/<n>`.
//! Target: ≥ 30 M samples/s.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};

use autoact::dsi::supersmoother::{SmoothScratch, SuperSmoother};

/// A joint-angle-like test curve: two sines plus deterministic pseudo-random noise.
fn curve(n: usize) -> Vec<f64> {
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    (0..n)
        .map(|i| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            #[expect(clippy::cast_precision_loss, reason = "test data")]
            let (t, noise) = (i as f64 / 30.0, (state >> 11) as f64 / (1u64 << 53) as f64);
            40.0 * (1.3 * t).sin() + 10.0 * (4.1 * t).cos() + 3.0 * (noise - 0.5)
        })
        .collect()
}

fn bench_supersmoother(c: &mut Criterion) {
    let mut group = c.benchmark_group("supersmoother");
    for (variant, smoother) in [
        ("default", SuperSmoother::default()),
        (
            "bass5",
            SuperSmoother {
                bass: Some(5.0),
                ..SuperSmoother::default()
            },
        ),
    ] {
        for n in [300usize, 10_000] {
            let y = curve(n);
            let plan = smoother.plan(n);
            let mut scratch = SmoothScratch::default();
            let mut out = vec![0.0; n];
            group.throughput(Throughput::Elements(n as u64));
            group.bench_with_input(BenchmarkId::new(variant, n), &y, |b, y| {
                b.iter(|| plan.smooth_into(black_box(y), &mut out, &mut scratch));
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench_supersmoother);
criterion_main!(benches);
