#!/usr/bin/env bash
# Regenerates the sample bags in bags/ (or in OUT_DIR) from the Bandai-Namco clips in
# ../shared/data. Usage: tools/make_bags.sh [OUT_DIR]   (needs target/release/autoact)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-bags}
data=../shared/data/bvh/bandai_namco
autoact=target/release/autoact
[ -x "$autoact" ] || { echo "build first: cargo build --release" >&2; exit 1; }
[ -d "$data" ] || { echo "$data is missing: the sample bags are made from the Bandai-Namco clips" >&2; exit 1; }
mkdir -p "$out"
"$autoact" -q import "$data/dataset-2_wave-right-hand_normal_001.bvh" -o "$out/bandai_wave.pose.mcap" --force \
    --layout coco-wholebody-133 --category gesture --action wave
"$autoact" -q convert "$out/bandai_wave.pose.mcap" -o "$out/bandai_wave.anim.mcap" --force
"$autoact" -q import "$data/dataset-1_walk_normal_001.bvh" -o "$out/bandai_walk.pose.mcap" --force \
    --layout h36m-17 --category locomotion --action walk
"$autoact" -q convert "$out/bandai_walk.pose.mcap" -o "$out/bandai_walk.anim.mcap" --force
