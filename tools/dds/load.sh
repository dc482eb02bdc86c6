#!/usr/bin/env bash
# Load check of `autoact record` (inside a throwaway network namespace, tools/dds/netns.sh):
# P Cyclone DDS publisher processes, each R msg/s of 133-joint Skeleton3D (coco-wholebody-133,
# names and positions filled) on its own topic /load/skeleton_<i>, plus one IMAGE topic
# (/camera/image_raw, rgb8) — all reliable, keep-last 100 — for T seconds, recorded by
# `autoact record` under /usr/bin/time -v. Passes when every published message is in the bag
# (tools/dds/check_recorded.py --count-only), the recorder counted 0 dropped / 0 rejected and
# exited 0.
#
#   tools/dds/load.sh                   P=2 R=500 T=5 IMAGE=640x480@30 RUNS=1 (CI size)
#   P=4 R=1000 T=30 RUNS=3 tools/dds/load.sh      the issue's figure, three times
#   KEEP=dir keeps the outputs; IMAGE= (empty) publishes no image.
# Prints one table row per run: published (sum over publishers), recorded (in the bag), dropped
# and rejected (the recorder's stdout summary), the publishers' achieved skeleton rate (msg/s,
# all publishers together), the recorder's CPU seconds (user+sys) and CPU % (over its whole wall
# time, idle start and end included; 100 % = one core), max RSS, wall.
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
P=${P:-2}
R=${R:-500}
T=${T:-5}
IMAGE=${IMAGE-640x480@30}
RUNS=${RUNS:-1}
[[ $P =~ ^[0-9]+$ && $R =~ ^[0-9]+$ && $T =~ ^[0-9]+$ && $RUNS =~ ^[0-9]+$ ]] || { echo "usage: P, R, T, RUNS are integers" >&2; exit 2; }
(( P >= 1 && P <= 8 && R >= 1 && R <= 5000 && T >= 1 && T <= 120 && RUNS >= 1 && RUNS <= 10 )) \
  || { echo "load.sh: bounded load only: 1<=P<=8, 1<=R<=5000, 1<=T<=120, 1<=RUNS<=10" >&2; exit 2; }
# shellcheck source=setup.sh
. "$HERE/setup.sh"
failed=0
printf '%-4s %-3s %-5s %-3s %-9s %-9s %-8s %-8s %-9s %-6s %-5s %-9s %-6s\n' \
  run P R T published recorded dropped rejected pub_rate cpu_s cpu% maxrss_MB wall_s

for run in $(seq 1 "$RUNS"); do
  dir=$OUT/run$run
  mkdir -p "$dir"
  set +e
  DIR=$dir AUTOACT=$AUTOACT P=$P R=$R T=$T IMAGE=$IMAGE timeout $((3 * T + 90)) "$HERE/netns.sh" bash -c '
    /usr/bin/time -v -o "$DIR/time.txt" "$AUTOACT" -q record --include "^/load/" /camera/image_raw \
      -o "$DIR/rec.mcap" --max-duration $((2 * T + 60)) >"$DIR/record.out" 2>"$DIR/record.err" &
    timed=$!
    sleep 0.3
    rec=$(pgrep -P "$timed")   # the recorder itself (time(1) does not pass signals on)
    pids=()
    for i in $(seq 1 "$P"); do
      tools/interop/run.sh --exec python tools/dds/publish_cyclone.py --topics skeleton --wholebody \
        --skeleton-topic "/load/skeleton_$i" -n $((R * T)) -r "$R" --linger 2 --match-timeout 30 \
        --counts "$DIR/pub_$i.json" 2>"$DIR/pub_$i.err" &
      pids+=($!)
    done
    if [ -n "$IMAGE" ]; then
      hz=${IMAGE#*@}
      tools/interop/run.sh --exec python tools/dds/publish_cyclone.py --topics "" --image "$IMAGE" \
        -n $(python3 -c "print(max(1, round($T * $hz)))") --linger 2 --match-timeout 30 \
        --counts "$DIR/pub_image.json" 2>"$DIR/pub_image.err" &
      pids+=($!)
    fi
    bad=0
    for p in "${pids[@]}"; do wait "$p" || bad=1; done
    sleep 1
    kill -INT "$rec"
    wait "$timed"; echo "$?" >"$DIR/record.rc"
    exit $bad'
  rc=$?
  set -e
  if [ $rc -ne 0 ]; then
    echo "FAIL run $run: namespace run exited $rc (a publisher failed, or timeout)"
    tail -n 3 "$dir"/*.err; failed=$((failed + 1)); continue
  fi
  check=$(tools/interop/run.sh --exec python tools/dds/check_recorded.py "$dir"/pub_*.json "$dir/rec.mcap" --count-only) \
    && ok=1 || ok=0
  published=$(sed -n 's/^total: published \([0-9]*\) recorded.*/\1/p' <<<"$check")
  recorded=$(sed -n 's/^total: published [0-9]* recorded \([0-9]*\)/\1/p' <<<"$check")
  dropped=$(awk '/ dropped, /{for(i=1;i<=NF;i++) if($(i)=="dropped,") s+=$(i-1)} END{print s+0}' "$dir/record.out")
  rejected=$(awk '/ rejected$/{s+=$(NF-1)} END{print s+0}' "$dir/record.out")
  pub_rate=$(python3 - "$dir" <<'PY'
import glob, json, sys
docs = [json.load(open(p)) for p in glob.glob(sys.argv[1] + "/pub_[0-9]*.json")]
n = sum(c["published"] for d in docs for c in d["topics"].values())
print(round(n / max(d["publish_s"] for d in docs)) if docs else 0)
PY
)
  read -r cpu_s cpu rss wall < <(python3 - "$dir/time.txt" <<'PY'
import sys
t = {}
for line in open(sys.argv[1]):
    k, _, v = line.strip().rpartition(": ")
    t[k] = v
parts = [float(x) for x in t["Elapsed (wall clock) time (h:mm:ss or m:ss)"].split(":")]
wall = sum(p * 60 ** i for i, p in enumerate(reversed(parts)))
cpu = (float(t["User time (seconds)"]) + float(t["System time (seconds)"])) / wall * 100
print(f"{cpu * wall / 100:.1f} {cpu:.0f} {int(t['Maximum resident set size (kbytes)']) / 1024:.0f} {wall:.1f}")
PY
)
  printf '%-4s %-3s %-5s %-3s %-9s %-9s %-8s %-8s %-9s %-6s %-5s %-9s %-6s\n' \
    "$run" "$P" "$R" "$T" "$published" "$recorded" "$dropped" "$rejected" "$pub_rate" "$cpu_s" "$cpu" "$rss" "$wall"
  rrc=$(cat "$dir/record.rc")
  if [ "$ok" = 1 ] && [ "$dropped" = 0 ] && [ "$rejected" = 0 ] && [ "$rrc" = 0 ]; then
    echo "ok run $run: every published message recorded, 0 dropped, recorder exit 0"
  else
    echo "FAIL run $run: recorder exit $rrc, dropped $dropped, rejected $rejected"
    grep FAIL <<<"$check" | head -5 || true
    failed=$((failed + 1))
  fi
done
echo "load: $((RUNS - failed)) of $RUNS runs passed"
[ $failed -eq 0 ]
