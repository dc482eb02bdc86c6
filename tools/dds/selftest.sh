#!/usr/bin/env bash
# End-to-end check of autoact's DDS recording layer (src/record/dds.rs) against an independent
# DDS implementation, entirely inside a throwaway network namespace (tools/dds/netns.sh):
#
#   1. dds_record_probe (our Recorder) subscribes to /skeleton and /skeleton/markers;
#   2. publish_cyclone.py (Cyclone DDS, Python) publishes N Skeleton3D + N MarkerArray at R Hz;
#      (second scenario: the publisher runs first and the probe joins later with --all,
#      subscribing to what discovery reports);
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

# One scenario: the probe and the publisher in a fresh namespace, then the checks.
#   scenario NAME first   - the probe subscribes to both topics, then the publisher starts;
#   scenario NAME late    - the publisher starts first; 1 s later the probe joins with --all and
#                           subscribes to whatever discovery shows (discover-then-subscribe).
# Bounded: the probe stops after 2N samples or 60 s, the publisher after N messages (or 10 s
# without a reader), and each namespace run after 120 s.
scenario() {
  local name=$1 order=$2 dir="$OUT/$1" rc summary
  mkdir -p "$dir"
  set +e
  DIR=$dir ORDER=$order PROBE=$PROBE N=$N RATE=$RATE timeout 120 "$HERE/netns.sh" bash -c '
    probe() {
      "$PROBE" --seconds 60 --until $((2 * N)) --hex "$@" >"$DIR/probe.jsonl" 2>"$DIR/probe.err"
    }
    publish() {
      tools/interop/run.sh --exec python tools/dds/publish_cyclone.py -n "$N" -r "$RATE" \
        --json "$DIR/published.json" 2>"$DIR/publisher.err"
    }
    if [ "$ORDER" = first ]; then
      probe /skeleton=autoact_msgs/msg/Skeleton3D \
        /skeleton/markers=visualization_msgs/msg/MarkerArray &
      probe_pid=$!
      publish; pub=$?
      wait "$probe_pid"; probe_rc=$?
    else
      publish & pub_pid=$!
      sleep 1
      probe --all; probe_rc=$?
      wait "$pub_pid"; pub=$?
    fi
    echo "publisher exit $pub, probe exit $probe_rc" >"$DIR/status"
    [ "$pub" -eq 0 ] && [ "$probe_rc" -eq 0 ]'
  rc=$?
  set -e
  echo "== $name: $(cat "$dir/status" 2>/dev/null || echo 'no status')"
  if [ "$rc" -ne 0 ]; then
    echo "FAIL selftest $name: namespace run exited $rc; logs:" >&2
    tail -n 5 "$dir/publisher.err" "$dir/probe.err" >&2 || true
    return 1
  fi
  summary=$(grep '^{' "$dir/probe.err" | tail -n 1)
  echo "probe: $summary"
  echo "publisher: $(grep '^{' "$dir/publisher.err" | tail -n 1)"
  grep "\"subscribed\"" "$dir/probe.err" || true
  case "$summary" in
    *'"rejected":0,'*) ;;
    *) echo "FAIL selftest $name: the probe rejected samples" >&2; return 1 ;;
  esac
  tools/interop/run.sh --exec python "$HERE/check_probe.py" "$dir/published.json" "$dir/probe.jsonl"
}

scenario recorder-first first
scenario recorder-joins-late late
echo "selftest: ok ($N + $N messages at $RATE Hz, two scenarios)"
