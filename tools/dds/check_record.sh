#!/usr/bin/env bash
# End-to-end check of `autoact record` against an independent DDS publisher (Cyclone DDS, Python),
# inside throwaway network namespaces (tools/dds/netns.sh; no DDS traffic leaves the machine).
# Scenarios, each bounded by `timeout`:
#   sigint  - record /skeleton and /skeleton/markers; the publisher sends N of each at RATE Hz;
#             SIGINT: the bag is complete and holds every message, in order, equal;
#   sigterm - the same, stopped with SIGTERM;
#   sigkill - SIGKILL mid-stream; `autoact recover` restores a bag whose messages are exactly the
#             first ones published (every flushed chunk), and exits 3;
#   convert - a real pose stream (the walking sample's skeletons, republished) is recorded and
#             `autoact convert` takes the bag as it takes an imported one.
#   tools/dds/check_record.sh        (N=200 RATE=200 by default; KEEP=dir keeps the outputs)
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
N=${N:-200}
RATE=${RATE:-200}
cd "$ROOT"
cargo build --release --quiet
AUTOACT=$ROOT/target/release/autoact
tools/interop/run.sh --exec python -c 'import cyclonedds, mcap_ros2'
OUT=${KEEP:-$(mktemp -d)}
mkdir -p "$OUT"
[ -n "${KEEP:-}" ] || trap 'rm -rf "$OUT"' EXIT
failed=0

scenario() {
  local name=$1 signal=$2 dir="$OUT/$1"
  mkdir -p "$dir"
  set +e
  DIR=$dir SIGNAL=$signal AUTOACT=$AUTOACT N=$N RATE=$RATE timeout 120 "$HERE/netns.sh" bash -c '
    "$AUTOACT" -q record /skeleton /skeleton/markers -o "$DIR/rec.mcap" --flush-interval 0.2 \
      --max-duration 60 >"$DIR/record.out" 2>"$DIR/record.err" &
    rec=$!
    sleep 0.5
    if [ "$SIGNAL" = KILL ]; then
      # Kill mid-stream: half the messages, then SIGKILL while the publisher is still going.
      tools/interop/run.sh --exec python tools/dds/publish_cyclone.py -n "$N" -r "$RATE" \
        --json "$DIR/published.json" 2>"$DIR/publisher.err" &
      pub=$!
      sleep $(python3 -c "print(0.5 + $N / $RATE / 2)")
      kill -KILL "$rec"; wait "$rec" 2>/dev/null
      wait "$pub"
      exit 0
    fi
    tools/interop/run.sh --exec python tools/dds/publish_cyclone.py -n "$N" -r "$RATE" --linger 1 \
      --json "$DIR/published.json" 2>"$DIR/publisher.err" || exit 10
    sleep 0.5
    kill -"$SIGNAL" "$rec"
    wait "$rec"; echo "record exit $?" >"$DIR/record.rc"'
  local rc=$?
  set -e
  if [ $rc -ne 0 ]; then
    echo "FAIL $name: namespace run exited $rc"; tail -5 "$dir"/*.err; failed=$((failed + 1)); return
  fi
  if [ "$signal" = KILL ]; then
    local rrc=0
    "$AUTOACT" -q recover "$dir/rec.mcap" -o "$dir/recovered.mcap" >"$dir/recover.out" || rrc=$?
    [ $rrc -eq 3 ] || { echo "FAIL $name: recover exited $rrc, expected 3"; failed=$((failed + 1)); return; }
    tools/interop/run.sh --exec python tools/dds/check_recorded.py "$dir/published.json" "$dir/recovered.mcap" --prefix \
      || { echo "FAIL $name"; failed=$((failed + 1)); return; }
    echo "ok $name: $(head -1 "$dir/recover.out")"
    return
  fi
  grep -q "record exit 0" "$dir/record.rc" || { echo "FAIL $name: $(cat "$dir/record.rc")"; tail -5 "$dir/record.err"; failed=$((failed + 1)); return; }
  "$AUTOACT" info "$dir/rec.mcap" | grep -q "^verdict: valid" || { echo "FAIL $name: autoact info"; failed=$((failed + 1)); return; }
  tools/interop/run.sh --exec python tools/dds/check_recorded.py "$dir/published.json" "$dir/rec.mcap" \
    || { echo "FAIL $name"; failed=$((failed + 1)); return; }
  echo "ok $name: $(head -1 "$dir/record.out")"
}

scenario sigint INT
scenario sigterm TERM
scenario sigkill KILL
# A real pose stream (the walking sample's skeletons) recorded, then converted like an import.
set +e
DIR=$OUT AUTOACT=$AUTOACT timeout 120 "$HERE/netns.sh" bash -c '
  "$AUTOACT" -q record /skeleton -o "$DIR/walk.mcap" --max-duration 60 >/dev/null 2>"$DIR/walk.err" &
  rec=$!
  sleep 0.5
  tools/interop/run.sh --exec python tools/dds/publish_cyclone.py -n 1000 -r 200 --linger 1     --skeletons-from bags/bandai_walk.pose.mcap 2>/dev/null || exit 10
  sleep 0.5; kill -INT "$rec"; wait "$rec"'
rc=$?
set -e
if [ $rc -eq 0 ] && "$AUTOACT" -q convert "$OUT/walk.mcap" -o "$OUT/walk.anim.mcap" >/dev/null \
   && "$AUTOACT" info "$OUT/walk.anim.mcap" | grep -q "^verdict: valid"; then
  echo "ok convert: a recorded pose stream converts like an imported one"
else
  echo "FAIL convert (namespace run $rc)"; tail -5 "$OUT/walk.err"; failed=$((failed + 1))
fi
echo "record: $((4 - failed)) passed, $failed failed"
[ $failed -eq 0 ]
