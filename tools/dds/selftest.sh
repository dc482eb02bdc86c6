#!/usr/bin/env bash
# End-to-end check of autoact's DDS recording layer (src/record/dds.rs) against an independent
# DDS implementation, entirely inside a throwaway network namespace (tools/dds/netns.sh):
#
#   1. dds_record_probe (our Recorder) subscribes to /skeleton and /skeleton/markers;
#   2. publish_cyclone.py (Cyclone DDS, Python) publishes N Skeleton3D + N MarkerArray at R Hz;
#   3. check_probe.py (outside the namespace, no DDS) asserts every message arrived once, in order,
#      with contiguous RTPS sequence numbers, and decodes (rosbags, schemas/*.msg) to exactly
#      what was published.
#
#   tools/dds/selftest.sh            N=50 R=100 by default; env N, RATE, KEEP=dir to keep outputs
# Exit status 0 only if all of that holds. Needs root for unshare, and the interop venv
# (installed from PyPI by tools/interop/run.sh on first use, outside the namespace).
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
N=${N:-50}
RATE=${RATE:-100}
case "$N$RATE" in *[!0-9]*) echo "selftest: N and RATE must be integers" >&2; exit 2 ;; esac
[ "$N" -ge 1 ] && [ "$N" -le 10000 ] && [ "$RATE" -ge 1 ] && [ "$RATE" -le 1000 ] \
  || { echo "selftest: need 1 <= N <= 10000 and 1 <= RATE <= 1000" >&2; exit 2; }

cd "$ROOT"
cargo build --quiet --example dds_record_probe
PROBE=${CARGO_TARGET_DIR:-$ROOT/target}/debug/examples/dds_record_probe
# Install / verify the pinned venv now, while PyPI is reachable (the namespace has no network).
tools/interop/run.sh --exec python -c 'import cyclonedds, rosbags'

OUT=${KEEP:-$(mktemp -d)}
mkdir -p "$OUT"
[ -n "${KEEP:-}" ] || trap 'rm -rf "$OUT"' EXIT

# Bounded: the probe stops after 2N samples or 60 s, the publisher after N messages (or 10 s
# without a reader), and the whole namespace run after 120 s.
export PROBE OUT N RATE
set +e
timeout 120 "$HERE/netns.sh" bash -c '
  "$PROBE" --seconds 60 --until $((2 * N)) --hex \
    /skeleton=autoact_msgs/msg/Skeleton3D \
    /skeleton/markers=visualization_msgs/msg/MarkerArray \
    >"$OUT/probe.jsonl" 2>"$OUT/probe.err" &
  probe=$!
  tools/interop/run.sh --exec python tools/dds/publish_cyclone.py -n "$N" -r "$RATE" \
    --json "$OUT/published.json" 2>"$OUT/publisher.err"
  pub=$?
  wait "$probe"
  probe_rc=$?
  echo "publisher exit $pub, probe exit $probe_rc" >"$OUT/status"
  [ "$pub" -eq 0 ] && [ "$probe_rc" -eq 0 ]'
rc=$?
set -e
cat "$OUT/status" 2>/dev/null || true
if [ "$rc" -ne 0 ]; then
  echo "FAIL selftest: namespace run exited $rc; logs:" >&2
  tail -n 5 "$OUT/publisher.err" "$OUT/probe.err" >&2 || true
  exit 1
fi
summary=$(grep '^{' "$OUT/probe.err" | tail -n 1)
echo "probe: $summary"
echo "publisher: $(grep '^{' "$OUT/publisher.err" | tail -n 1)"
case "$summary" in *'"rejected":0,'*) ;; *) echo "FAIL selftest: the probe rejected samples" >&2; exit 1 ;; esac

tools/interop/run.sh --exec python "$HERE/check_probe.py" "$OUT/published.json" "$OUT/probe.jsonl"
echo "selftest: ok ($N + $N messages at $RATE Hz)"
