#!/usr/bin/env bash
# Peak memory of a streaming `autoact convert` (docs/performance.md, issue 20 item 5): synthetic
# H36M-17 pose bags of 10,000, 100,000 and 1,000,000 frames at 50 fps (examples/synth_pose_bag.rs,
# deterministic), each converted to 30 fps; prints the peak resident set size of each run (from
# /usr/bin/time -v, which counts the memory-mapped input as it is read) and the ratio 1M / 10k,
# and fails when the 1M-frame run exceeds LIMIT_MB (default 150).
# Usage: tools/bench_memory.sh [WORK_DIR]   (about 30 s after the release build: 7 s writing the
# 1M-frame bag, 10-15 s converting it; SIZES="..." and LIMIT_MB=... override the defaults)
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:-$(mktemp -d)}
limit_mb=${LIMIT_MB:-150}
sizes=${SIZES:-"10000 100000 1000000"}
mkdir -p "$work"
cargo build --release --quiet --bin autoact --example synth_pose_bag
declare -A peak_kb
for n in $sizes; do
    bag="$work/synth_$n.pose.mcap"
    [ -s "$bag" ] || target/release/examples/synth_pose_bag "$n" "$bag" >/dev/null
    rm -f "$work/synth_$n.anim.mcap"
    /usr/bin/time -v -o "$work/time_$n.txt" target/release/autoact -q convert "$bag" \
        -o "$work/synth_$n.anim.mcap" --fps 30 >/dev/null
    peak_kb[$n]=$(awk -F': ' '/Maximum resident set size/ {print $2}' "$work/time_$n.txt")
    wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$work/time_$n.txt")
    printf '%9d frames: input %6.1f MB, peak RSS %6.1f MB, wall %s\n' "$n" \
        "$(echo "$(stat -c %s "$bag") / 1000000" | bc -l)" \
        "$(echo "${peak_kb[$n]} / 1024" | bc -l)" "$wall"
done
first=${sizes%% *}
last=${sizes##* }
printf 'ratio %d / %d frames: %.2f\n' "$last" "$first" \
    "$(echo "${peak_kb[$last]} / ${peak_kb[$first]}" | bc -l)"
if [ "$((peak_kb[$last] / 1024))" -gt "$limit_mb" ]; then
    echo "FAIL: $last frames took $((peak_kb[$last] / 1024)) MB, more than $limit_mb MB" >&2
    exit 1
fi
echo "ok: $last frames within $limit_mb MB"
