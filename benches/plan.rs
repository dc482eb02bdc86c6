//! `autoact plan` at the paper's NTU scale: 1,566 source bags × 4 scenes × 3 viewpoints = 18,792
//! clips — reading the spec and every bag's summary, drawing 6,264 scenes and their camera walks,
//! laying out the timelines. Target (issue "Scene customization, Random Camera Moving and the
//! hierarchical recording plan"): under 2 s.

use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};

use autoact::dataset::estimated_frames;
use autoact::dataset::plan::Plan;
use autoact::dataset::spec::Spec;
use autoact::mcap_io::{BagWriter, WriteConfig};
use autoact::ros::autoact_msgs::Skeleton3D;
use autoact::ros::builtin_interfaces::Time;
use autoact::ros::std_msgs::Header;

fn ntu_like_spec(dir: &Path) -> std::path::PathBuf {
    let bag = dir.join("a.mcap");
    let mut w = BagWriter::create(&bag, WriteConfig::default()).expect("bag");
    for k in 0..2u64 {
        let s = Skeleton3D {
            header: Header {
                stamp: Time::from_nanos(k * 33_333_333),
                frame_id: "world".into(),
            },
            layout: "ntu-25".into(),
            ..Skeleton3D::default()
        };
        w.write("/skeleton", k * 33_333_333, &s).expect("write");
    }
    w.finish().expect("finish");
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
