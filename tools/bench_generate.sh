#!/usr/bin/env bash
# Speed of the whole chain (issue 22, README "Performance"): a 1/50-scale NTU-like dataset —
# about 376 clips of 50 frames at 320x240, the NTU-GTAutoAct mean clip — made end to end by
# `autoact generate` from the sample bags (bags/, CC BY-NC 4.0 motion), RUNS times (default 3).
# Prints each run's stage times, then the medians: frames/s per stage and for the chain, and
# the chain's time extrapolated to NTU-GTAutoAct's 953,570 frames (target: <= 45 min, i.e.
# >= 355 frames/s). "frames" are the dataset's clip frames; "rendered" counts the frames drawn
# (without --keep-intermediates only the clips' frames: the two are equal here), and render's own
# rate is given per rendered frame too. CPU time (user + system,
# ffmpeg included) is printed too: on a shared machine it moves less than wall time.
#
# Usage: tools/bench_generate.sh [WORK_DIR] [RUNS]   (AUTOACT=path/to/autoact to skip the build)
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:-$(mktemp -d)}
runs=${2:-3}
mkdir -p "$work"
if [[ -z "${AUTOACT:-}" ]]; then
  cargo build --release --quiet --bin autoact
  AUTOACT=target/release/autoact
fi
# 2 actions x 2 variants x 4 scenes x 8 viewpoints = 128 segments of ~6.3 s; fixed 50-frame
# windows (stride 50, the last partial window dropped) give 3 clips per segment, 384 in all.
cat > "$work/spec.toml" <<SPEC
[dataset]
name = "bench"
seed = 1
fps = 30.0
resolution = [320, 240]
lead_in_s = 0.1
lead_out_s = 0.1
session = "animation"
[counts]
variants = 2
scenes = 4
viewpoints = 8
[clips]
policy = "windows"
length_frames = 50
stride_frames = 50
tail = "drop"
[[class]]
category = "gesture"
action = "wave"
sources = ["$PWD/bags/bandai_wave.pose.mcap"]
[[class]]
category = "locomotion"
action = "walk"
sources = ["$PWD/bags/bandai_walk.pose.mcap"]
SPEC
: > "$work/runs.tsv"
for ((i = 1; i <= runs; i++)); do
  out="$work/run$i"
  rm -rf "$out"
  start=$(date +%s.%N)
  /usr/bin/time -f "%U %S" -o "$work/run$i.cpu" \
    "$AUTOACT" -q generate "$work/spec.toml" -o "$out" --resolution 320x240 > "$work/run$i.txt"
  end=$(date +%s.%N)
  python3 - "$work/run$i.txt" "$out" "$start" "$end" "$work/run$i.cpu" >> "$work/runs.tsv" <<'PY'
import json, pathlib, re, sys
text = open(sys.argv[1]).read()
rendered = int(re.search(r"(\d+) frames rendered", text).group(1))
stages = re.search(r"convert ([\d.]+) s, capture ([\d.]+) s, render ([\d.]+) s, trim ([\d.]+) s", text)
manifest = pathlib.Path(sys.argv[2]) / "dataset/manifest.jsonl"
clips = [json.loads(line) for line in manifest.read_text().splitlines()]
frames = sum(c["frame_count"] for c in clips)
wall = float(sys.argv[4]) - float(sys.argv[3])
cpu = sum(map(float, open(sys.argv[5]).read().split()[-2:]))
print("\t".join(str(x) for x in (len(clips), frames, rendered, *stages.groups(), wall, cpu)))
PY
  tail -n 1 "$work/runs.tsv" | awk -F'\t' -v i="$i" '{printf "run %d: %d clips, %d clip frames, %d rendered; convert %.1f s, capture %.1f s, render %.1f s, trim %.1f s, wall %.1f s, CPU %.1f s\n", i, $1, $2, $3, $4, $5, $6, $7, $8, $9}'
done
python3 - "$work/runs.tsv" <<'PY'
import statistics, sys
rows = [list(map(float, l.split("\t"))) for l in open(sys.argv[1]) if l.strip()]
med = lambda k: statistics.median(r[k] for r in rows)
clips, frames, rendered = rows[0][0], rows[0][1], rows[0][2]
names = ["convert", "capture", "render", "trim"]
print(f"medians of {len(rows)} runs: {int(clips)} clips, {int(frames)} clip frames ({int(rendered)} rendered)")
for k, name in enumerate(names, start=3):
    sec = med(k)
    extra = f", {rendered / sec:.0f} rendered frames/s" if name == "render" and sec > 0 else ""
    # generate prints stage times to 0.1 s: a stage under 0.05 s has no meaningful rate.
    rate_text = f"{frames / sec:8.0f} frames/s" if sec >= 0.05 else "   (under 0.05 s)"
    print(f"  {name:8s} {sec:7.2f} s  {rate_text}{extra}")
wall = med(7)
rate = frames / wall
print(f"  chain    {wall:7.2f} s  {rate:8.0f} frames/s")
cpu = med(8)
print(f"  CPU      {cpu:7.2f} s  (user + system, ffmpeg included): {frames / cpu:.0f} frames per CPU-second, "
      f"{2 * frames / cpu:.0f} frames/s on 2 free cores at best")
minutes = 953570 / rate / 60
print(f"NTU-GTAutoAct (953,570 frames) extrapolated: {minutes:.1f} min wall (target <= 45 min, >= 355 frames/s): {'met' if rate >= 355 else 'NOT met'}")
print(f"  from CPU time on 2 free cores: {953570 / (2 * frames / cpu) / 60:.1f} min at best")
with open("/proc/loadavg") as f:
    print(f"  load average now: {f.read().split()[0]} (the machine may be shared: compare runs by ratios)")
PY
