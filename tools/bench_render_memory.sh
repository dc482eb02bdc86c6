#!/usr/bin/env bash
# Peak memory of `autoact render` and `autoact generate --keep-intermediates` against the length
# of one capture session (issue 22, docs/performance.md): one-session specs from the sample bags
# (bags/, CC BY-NC 4.0 motion; wave and walk, one scene, VIEWPOINTS viewpoints each, so about 442
# frames per viewpoint) at 160x120, from about 2,200 to 19,900 frames. Each autoact process's own
# peak (VmHWM, polled from /proc/<pid>/status every 50 ms: ffmpeg is another process and is not
# counted) is printed with the session's frames, then the ratio longest / shortest; the target is
# <= 1.15 for both commands. Too slow for CI (about 10 minutes on 2 cores).
#
# Usage: tools/bench_render_memory.sh [WORK_DIR]
#   AUTOACT=path/to/autoact skips the build (e.g. an older build, for a before/after);
#   VIEWPOINTS="5 15 45" sets the session lengths; MAX_RATIO (default 1.15) the limit.
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:-$(mktemp -d)}
viewpoints=${VIEWPOINTS:-"5 15 45"}
max_ratio=${MAX_RATIO:-1.15}
mkdir -p "$work"
if [[ -z "${AUTOACT:-}" ]]; then
  cargo build --release --quiet --bin autoact
  AUTOACT=target/release/autoact
fi

# spec V: a one-session spec of V viewpoints per animation.
spec() {
  cat <<SPEC
[dataset]
name = "mem"
seed = 1
fps = 30.0
resolution = [160, 120]
session = "dataset"
[counts]
variants = 1
scenes = 1
viewpoints = $1
[[class]]
category = "gesture"
action = "wave"
sources = ["$PWD/bags/bandai_wave.pose.mcap"]
[[class]]
category = "locomotion"
action = "walk"
sources = ["$PWD/bags/bandai_walk.pose.mcap"]
SPEC
}

# peak_kb COMMAND...: runs COMMAND, polling its VmHWM; prints the last value read (kB).
peak_kb() {
  "$@" >/dev/null &
  local pid=$! peak=0 hwm
  while kill -0 "$pid" 2>/dev/null; do
    hwm=$(awk '/^VmHWM:/ {print $2}' "/proc/$pid/status" 2>/dev/null || true)
    [[ -n "$hwm" ]] && peak=$hwm
    sleep 0.05
  done
  wait "$pid"
  echo "$peak"
}

declare -A render_kb generate_kb frames
for v in $viewpoints; do
  dir="$work/v$v"
  rm -rf "$dir"
  mkdir -p "$dir"
  spec "$v" > "$dir/spec.toml"
  "$AUTOACT" -q convert --spec "$dir/spec.toml" -o "$dir/capture" >/dev/null
  bag=$(ls "$dir"/capture/*.capture.mcap)
  frames[$v]=$(python3 -c 'import json,sys; print(sum(s["frames"] for s in json.load(open(sys.argv[1]))["plan"]["sessions"]))' "$dir/capture/plan.json")
  render_kb[$v]=$(peak_kb "$AUTOACT" -q render "$bag" -o "$dir/render.mp4" --resolution 160x120)
  generate_kb[$v]=$(peak_kb "$AUTOACT" -q generate "$dir/spec.toml" -o "$dir/generated" \
    --resolution 160x120 --keep-intermediates)
  printf '%6d frames (%s): render %6.1f MB, generate --keep-intermediates %6.1f MB\n' \
    "${frames[$v]}" "$(du -h "$bag" | cut -f1)" \
    "$(echo "${render_kb[$v]} / 1024" | bc -l)" "$(echo "${generate_kb[$v]} / 1024" | bc -l)"
  rm -rf "$dir/generated" "$dir/render.mp4" "$dir/render.render.mcap"
done
first=${viewpoints%% *}
last=${viewpoints##* }
status=0
for what in render generate; do
  declare -n kb="${what}_kb"
  ratio=$(echo "${kb[$last]} / ${kb[$first]}" | bc -l)
  printf '%s: %d / %d frames: peak ratio %.2f\n' "$what" "${frames[$last]}" "${frames[$first]}" "$ratio"
  if (($(echo "$ratio > $max_ratio" | bc -l))); then
    echo "FAIL: $what peak grows $(printf '%.2f' "$ratio")x with the session (limit $max_ratio)" >&2
    status=1
  fi
done
exit "$status"
