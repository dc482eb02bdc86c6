#!/usr/bin/env bash
# The whole chain on the checked-in samples, for a new user: the example dataset spec (waving
# and walking, Bandai-Namco mocap) → capture bags (`convert --spec`) → rendered H.264 captures
# with render bags and contact sheets (`render`) → a trimmed action-recognition dataset with
# Kinetics, MMAction2 and ActivityNet annotations (`trim`). Prints where everything is and what
# the dataset holds. Usage: tools/demo.sh [OUT_DIR] (default: out). Re-running resumes.
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-out}"
cargo build --release --quiet
autoact=target/release/autoact
"$autoact" convert --spec examples/dataset.toml -o "$out/captures" --force
for bag in "$out"/captures/*.capture.mcap; do
    name=$(basename "$bag" .capture.mcap)
    "$autoact" render "$bag" -o "$out/videos/$name.mp4" --resolution 320x240 \
        --preview "$out/videos/$name.png" --force
    "$autoact" trim "$bag" "$out/videos/$name.mp4" -o "$out/dataset"
done
echo
echo "captures: $out/captures   videos and contact sheets: $out/videos   dataset: $out/dataset"
ann="$out/dataset/annotations"
policies=$(grep -o '"policy":"[a-z]*"' "$ann/clips.jsonl" | sort -u | cut -d'"' -f4 | paste -sd, -)
echo "clip policy: $policies (the spec's [clips]; each clip's action span is in clips.jsonl and activitynet.json)"
echo "clips per class and split (MMAction2 lists in $out/dataset/annotations):"
printf '  %-12s %6s %6s %6s\n' class train val test
id=0
while IFS= read -r class; do
    counts=()
    for split in train val test; do
        counts+=("$(awk -v id="$id" '$NF == id' "$ann/${split}_list_videos.txt" | wc -l)")
    done
    printf '  %-12s %6s %6s %6s\n' "$class" "${counts[@]}"
    id=$((id + 1))
done < "$ann/classes.txt"
echo "other clip policies: autoact trim BAG VIDEO -o DIR --clips windows|instances (docs/trim.md)"
