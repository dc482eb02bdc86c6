#!/usr/bin/env bash
# Peak memory of a streaming `autoact convert`, plain and with `--dsi` (docs/performance.md, issue
# 20 item 5): synthetic H36M-17 pose bags of 10,000, 100,000 and 1,000,000 frames at 50 fps
# (examples/synth_pose_bag.rs, deterministic), each converted to 30 fps, then again with DSI
# (whose keys go to a temporary file in WORK_DIR); prints the peak resident set size of each run
# (from /usr/bin/time -v, which counts the memory-mapped input as it is read) and the ratios
# 1M / 10k, and fails when a 1M-frame run exceeds LIMIT_MB (default 150). Then `autoact import`
# of MMPose JSON (issue 25 item 1): synthetic 133-keypoint files (examples/synth_pose_json.rs,
# 3.6 KB per frame) of JSON_SIZES frames (default 10,000 and 100,000; 1,000,000 is a 3.6 GB
# file and 5 minutes), failing above JSON_LIMIT_MB (default 200) for the largest.
# Usage: tools/bench_memory.sh [WORK_DIR]   (about 2 minutes after the release build: 7 s writing
# the 1M-frame bag, 10-15 s converting it, 30-40 s with DSI, which needs 1.7 GB of disk for the
# keys, 35 s for the JSON files; SIZES, LIMIT_MB, JSON_SIZES and JSON_LIMIT_MB override the
# defaults)
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:-$(mktemp -d)}
limit_mb=${LIMIT_MB:-150}
sizes=${SIZES:-"10000 100000 1000000"}
mkdir -p "$work"
json_sizes=${JSON_SIZES:-"10000 100000"}
json_limit_mb=${JSON_LIMIT_MB:-200}
cargo build --release --quiet --bin autoact --example synth_pose_bag --example synth_pose_json
declare -A peak_kb
status=0

# measure MODE N INPUT OUT COMMAND...: runs COMMAND (writing OUT) under /usr/bin/time, prints a
# line with INPUT's size and the peak RSS, keeps the peak in peak_kb[N] and removes OUT.
measure() {
    local mode=$1 n=$2 input=$3 out=$4
    shift 4
    rm -f "$out"
    /usr/bin/time -v -o "$work/time_${n}_$mode.txt" "$@" >/dev/null
    rm -f "$out"
    peak_kb[$n]=$(awk -F': ' '/Maximum resident set size/ {print $2}' "$work/time_${n}_$mode.txt")
    local wall
    wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$work/time_${n}_$mode.txt")
    printf '%-5s %9d frames: input %6.1f MB, peak RSS %6.1f MB, wall %s\n' "$mode" "$n" \
        "$(echo "$(stat -c %s "$input") / 1000000" | bc -l)" \
        "$(echo "${peak_kb[$n]} / 1024" | bc -l)" "$wall"
}

# within MODE N LIMIT_MB: fails the run (status 1) when N frames took more than LIMIT_MB.
within() {
    if [ "$((peak_kb[$2] / 1024))" -gt "$3" ]; then
        echo "FAIL: $1: $2 frames took $((peak_kb[$2] / 1024)) MB, more than $3 MB" >&2
        status=1
    fi
}

first=${sizes%% *}
last=${sizes##* }
for mode in plain dsi; do
    flags=()
    [ "$mode" = dsi ] && flags=(--dsi)
    for n in $sizes; do
        bag="$work/synth_$n.pose.mcap"
        [ -s "$bag" ] || target/release/examples/synth_pose_bag "$n" "$bag" >/dev/null
        out="$work/synth_${n}_$mode.anim.mcap"
        measure "$mode" "$n" "$bag" "$out" \
            target/release/autoact -q convert "$bag" -o "$out" --fps 30 "${flags[@]}"
    done
    printf '%-5s ratio %d / %d frames: %.2f\n' "$mode" "$last" "$first" \
        "$(echo "${peak_kb[$last]} / ${peak_kb[$first]}" | bc -l)"
    within "$mode" "$last" "$limit_mb"
done
for n in $json_sizes; do
    json="$work/synth_$n.json"
    [ -s "$json" ] || target/release/examples/synth_pose_json "$n" "$json" >/dev/null
    out="$work/synth_${n}_json.pose.mcap"
    measure json "$n" "$json" "$out" \
        target/release/autoact -q import "$json" -o "$out" --fps 30 --axes z-up
done
json_last=${json_sizes##* }
within "json import" "$json_last" "$json_limit_mb"
[ "$status" = 0 ] && echo "ok: $last frames within $limit_mb MB, plain and with --dsi; JSON import of $json_last frames within $json_limit_mb MB"
exit "$status"
