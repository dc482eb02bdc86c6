#!/usr/bin/env bash
# Trim speed (README "Performance"): a ~10-minute capture bag from the sample bags, a synthetic
# 640x360 video of its timeline with keyframes on the segment boundaries, cut by stream copy and
# by re-encoding.  Usage: tools/bench_trim.sh [WORK_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:-$(mktemp -d)}
mkdir -p "$work"
cat > "$work/spec.toml" <<SPEC
[dataset]
name = "bench"
seed = 1
fps = 30.0
resolution = [640, 360]
session = "dataset"
[counts]
variants = 2
scenes = 4
viewpoints = 5
[[class]]
category = "gesture"
action = "wave"
sources = ["$PWD/bags/bandai_wave.pose.mcap"]
[[class]]
category = "locomotion"
action = "walk"
sources = ["$PWD/bags/bandai_walk.pose.mcap"]
SPEC
cargo build --release --quiet --bin autoact --example trim_bench
target/release/autoact -q convert --spec "$work/spec.toml" -o "$work/capture" >/dev/null
bag=$(ls "$work"/capture/*.mcap | head -n 1)
target/release/examples/trim_bench "$bag" "$work/bench"
