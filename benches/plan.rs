//! `autoact plan` at the paper's NTU scale: 1,566 source bags × 4 scenes × 3 viewpoints = 18,792
//! clips — reading the spec and every bag's summary, drawing 6,264 scenes and their camera walks,
//! laying out the timelines. Target (issue "Scene customization, Random Camera Moving and the
//! hierarchical recording plan"): under 2 s.

use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};

use autoact::dataset::estimated_frames;
use autoact::dataset::plan::Plan;
use autoact::dataset::spec::Spec;

fn ntu_like_spec(dir: &Path) -> std::path::PathBuf {
    // Every source a copy of the walking sample (its summary is all a plan reads).
    let bag = Path::new(env!("CARGO_MANIFEST_DIR")).join("bags/bandai_walk.pose.mcap");
    let mut classes = String::new();
    for c in 0..54 {
        let sources: Vec<String> = (0..29)
            .map(|i| {
                let name = format!("c{c:02}_{i:02}.mcap");
                std::fs::copy(&bag, dir.join(&name)).expect("copy");
                format!("\"{name}\"")
            })
            .collect();
        classes.push_str(&format!(
            "[[class]]\ncategory = \"daily\"\naction = \"A{c:03}\"\nsources = [{}]\n",
            sources.join(", ")
        ));
    }
    let spec = dir.join("ntu.toml");
    std::fs::write(
        &spec,
        format!(
            "[dataset]\nname = \"ntu\"\nseed = 3\n[counts]\nscenes = 4\nviewpoints = 3\n{classes}"
        ),
    )
    .expect("spec");
    spec
}

fn bench_plan(c: &mut Criterion) {
    let dir = tempfile::tempdir().expect("tempdir");
    let spec_path = ntu_like_spec(dir.path());
    c.bench_function("plan/ntu_18792_clips", |b| {
        b.iter(|| {
            let spec = Spec::load(&spec_path).expect("spec");
            let frames = estimated_frames(&spec).expect("frames");
            let plan = Plan::build(&spec, &|k, i| frames[k][i]).expect("plan");
            assert_eq!(plan.leaves.len(), 18_792);
            plan
        });
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench_plan
}
criterion_main!(benches);
