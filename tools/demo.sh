#!/usr/bin/env bash
# The whole chain on the checked-in samples, for a new user, as one `autoact generate`: the
# example dataset spec (waving and walking, Bandai-Namco mocap) → capture bags → rendered H.264
# captures with render bags and contact sheets → a trimmed action-recognition dataset with
# Kinetics, MMAction2 and ActivityNet annotations, skeleton .pkl and COCO keypoint labels, and
# each clip's depth and mask frames. Prints where everything is and what the
# dataset holds. Usage: tools/demo.sh [OUT_DIR] (default: out). Re-running resumes (and does
# nothing once the dataset is complete).
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-out}"
cargo build --release --quiet
autoact=target/release/autoact
"$autoact" generate examples/dataset.toml -o "$out" --resolution 320x240 --previews --keep-intermediates \
    --depth --masks
echo
echo "captures: $out/captures   videos: $out/renders   contact sheets: $out/previews   dataset: $out/dataset"
echo "each class's clips at a glance (flagged ones first, framed in red): $out/dataset/annotations/contact_sheets/"
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
