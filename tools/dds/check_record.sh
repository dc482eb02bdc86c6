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
#             `autoact convert` takes the bag as it takes an imported one;
#   image   - sensor_msgs/Image (64x48 rgb8, 30 Hz) recorded, every frame equal to what was sent;
#   restart - a publisher runs, exits, and a new one (a new DDS writer, its own sequence numbers)
#             continues during one recording: every message of both runs, 0 dropped, exit 0;
#   malformed - a Cyclone type with Skeleton3D's DDS type name but another layout, on a topic the
#             recorder takes as Skeleton3D, next to a good /skeleton: every bad sample counted
#             `rejected`, the good topic complete, exit 3;
#   diskfull - recording into a 2 MB tmpfs (a private mount namespace) until it fills: exit 1 with
#             an error naming the file; `autoact recover` restores a valid bag of what was flushed;
#   rosbag2 - `-o DIR` with --split-duration: a rosbag2 directory of several files that `rosbags`
#             reads whole (metadata.yaml lists them all);
#   sigstop - the recorder stopped (SIGSTOP, as Ctrl-Z does) for 3 s mid-stream and continued
#             (SIGCONT, as fg does), then SIGINT: every message of both topics, 0 dropped, exit 0
#             (RustDDS's event loop used to end on the EINTR this leaves: issue 20);
#   besteffort - a best-effort publisher (sensor-data QoS) recorded in full with the default
#             (reliable) settings: the reader follows what the publisher offers.
#   tools/dds/check_record.sh [SCENARIO...]   (all by default; N=200 RATE=200; KEEP=dir keeps
#                                             the outputs)
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
N=${N:-200}
RATE=${RATE:-200}
# shellcheck source=setup.sh
. "$HERE/setup.sh"
failed=0
passed=0
ONLY=" $* "
want() { [ "$ONLY" = "  " ] || [[ $ONLY == *" $1 "* ]]; }

scenario() {
  local name=$1 signal=$2 dir="$OUT/$1"
  want "$name" || return 0
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
    echo "ok $name: $(head -1 "$dir/recover.out")"; passed=$((passed + 1))
    return
  fi
  grep -q "record exit 0" "$dir/record.rc" || { echo "FAIL $name: $(cat "$dir/record.rc")"; tail -5 "$dir/record.err"; failed=$((failed + 1)); return; }
  "$AUTOACT" info "$dir/rec.mcap" | grep -q "^verdict: valid" || { echo "FAIL $name: autoact info"; failed=$((failed + 1)); return; }
  tools/interop/run.sh --exec python tools/dds/check_recorded.py "$dir/published.json" "$dir/rec.mcap" \
    || { echo "FAIL $name"; failed=$((failed + 1)); return; }
  echo "ok $name: $(head -1 "$dir/record.out")"; passed=$((passed + 1))
}

scenario sigint INT
scenario sigterm TERM
scenario sigkill KILL
# A real pose stream (the walking sample's skeletons) recorded, then converted like an import.
if want convert; then
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
  echo "ok convert: a recorded pose stream converts like an imported one"; passed=$((passed + 1))
else
  echo "FAIL convert (namespace run $rc)"; tail -5 "$OUT/walk.err"; failed=$((failed + 1))
fi
fi

# Runs the recorder on TOPICS (a space-separated list) in a namespace while the shell snippet
# PUBLISH publishes, then SIGINTs it: $dir/record.out/.err/.rc. PUB is the publisher command.
record_while() {
  local dir=$1 topics=$2 publish=$3
  mkdir -p "$dir"
  DIR=$dir AUTOACT=$AUTOACT TOPICS=$topics PUBLISH=$publish \
    PUB="tools/interop/run.sh --exec python tools/dds/publish_cyclone.py" timeout 120 "$HERE/netns.sh" bash -c '
    # shellcheck disable=SC2086
    "$AUTOACT" -q record $TOPICS -o "$DIR/rec.mcap" --flush-interval 0.2 --max-duration 90 \
      >"$DIR/record.out" 2>"$DIR/record.err" &
    rec=$!
    sleep 0.5
    eval "$PUBLISH" || exit 10
    sleep 0.5
    kill -INT "$rec"
    wait "$rec"; echo "$?" >"$DIR/record.rc"'
}

fail() { echo "FAIL $1"; shift; for f in "$@"; do [ -f "$f" ] && tail -n 5 "$f"; done; failed=$((failed + 1)); }

if want image; then
  dir=$OUT/image
  if ! record_while "$dir" /camera/image_raw \
      '$PUB --topics "" --image 64x48@30 -n 30 --json "$DIR/published.json" 2>"$DIR/publisher.err"'; then
    fail "image: namespace run" "$dir/record.err" "$dir/publisher.err"
  elif [ "$(cat "$dir/record.rc")" != 0 ]; then
    fail "image: record exit $(cat "$dir/record.rc")" "$dir/record.err"
  elif tools/interop/run.sh --exec python tools/dds/check_recorded.py "$dir/published.json" "$dir/rec.mcap"; then
    echo "ok image: $(sed -n 2p "$dir/record.out" | sed 's/^ *//')"; passed=$((passed + 1))
  else
    fail "image: bag differs from what was published"
  fi
fi

if want restart; then
  dir=$OUT/restart
  if ! record_while "$dir" "/skeleton /skeleton/markers" \
      '$PUB -n 100 -r 200 --json "$DIR/pub1.json" 2>"$DIR/pub1.err" && sleep 0.5 &&
       $PUB -n 100 -r 200 --first 100 --linger 1 --json "$DIR/pub2.json" 2>"$DIR/pub2.err"'; then
    fail "restart: namespace run" "$dir/record.err" "$dir/pub1.err" "$dir/pub2.err"
  elif [ "$(cat "$dir/record.rc")" != 0 ] || grep -q "[1-9][0-9]* dropped" "$dir/record.out"; then
    fail "restart: record exit $(cat "$dir/record.rc")" "$dir/record.out" "$dir/record.err"
  elif tools/interop/run.sh --exec python tools/dds/check_recorded.py "$dir/pub1.json" "$dir/pub2.json" "$dir/rec.mcap"; then
    echo "ok restart: two publisher runs, $(head -1 "$dir/record.out" | cut -d' ' -f1-3), 0 dropped"
    passed=$((passed + 1))
  else
    fail "restart: bag differs from the two runs"
  fi
fi

if want rosbag2; then
  dir=$OUT/rosbag2
  mkdir -p "$dir"
  # -o DIR: a rosbag2 directory, split every 0.3 s; rosbags (independent) reads it whole.
  set +e
  DIR=$dir AUTOACT=$AUTOACT timeout 120 "$HERE/netns.sh" bash -c '
    "$AUTOACT" -q record /skeleton -o "$DIR/take" --split-duration 0.3 --max-duration 60 \
      >"$DIR/record.out" 2>"$DIR/record.err" &
    rec=$!
    sleep 0.5
    tools/interop/run.sh --exec python tools/dds/publish_cyclone.py --topics skeleton -n 200 -r 200 \
      --linger 1 --json "$DIR/published.json" 2>"$DIR/publisher.err" || exit 10
    sleep 0.5; kill -INT "$rec"; wait "$rec"; echo $? >"$DIR/record.rc"'
  rc=$?
  set -e
  files=$(ls "$dir/take"/take_*.mcap 2>/dev/null | wc -l)
  if [ $rc -ne 0 ] || [ "$(cat "$dir/record.rc" 2>/dev/null)" != 0 ]; then
    fail "rosbag2: record" "$dir/record.err" "$dir/publisher.err"
  elif [ "$files" -lt 2 ]; then
    fail "rosbag2: expected several split files, got $files"
  elif tools/interop/run.sh --exec python tools/dds/check_rosbag2.py "$dir/take" "$dir/published.json"; then
    echo "ok rosbag2: $files split files in a rosbag2 directory, read whole by rosbags"; passed=$((passed + 1))
  else
    fail "rosbag2: rosbags could not read it whole"
  fi
fi

if want sigstop; then
  dir=$OUT/sigstop
  # 300 of each at 50 Hz (6 s); the recorder is stopped from 1.5 s to 4.5 s. The 150 samples per
  # topic sent meanwhile fit the publisher's history (--depth 1000: what reliable repair can
  # resend) and the recorder's default reader history (1000 for these types), which the backlog
  # fills at SIGCONT. With the recorder's old default of 100 such a backlog lost its oldest
  # samples (counted as dropped, exit 3).
  if ! record_while "$dir" "/skeleton /skeleton/markers" \
      '$PUB -n 300 -r 50 --depth 1000 --linger 2 --json "$DIR/published.json" 2>"$DIR/publisher.err" & pub=$!
       sleep 1.5; kill -STOP "$rec"; sleep 3; kill -CONT "$rec"
       wait $pub'; then
    fail "sigstop: namespace run" "$dir/record.err" "$dir/publisher.err"
  elif [ "$(cat "$dir/record.rc")" != 0 ] || grep -q "[1-9][0-9]* dropped" "$dir/record.out"; then
    fail "sigstop: record exit $(cat "$dir/record.rc")" "$dir/record.out" "$dir/record.err"
  elif tools/interop/run.sh --exec python tools/dds/check_recorded.py "$dir/published.json" "$dir/rec.mcap"; then
    echo "ok sigstop: stopped 3 s mid-stream and continued: $(head -1 "$dir/record.out" | cut -d' ' -f1-3), 0 dropped, exit 0"
    passed=$((passed + 1))
  else
    fail "sigstop: bag differs from what was published" "$dir/record.out"
  fi
fi

if want besteffort; then
  dir=$OUT/besteffort
  # A best-effort publisher (sensor-data QoS) with the recorder's default (reliable) settings:
  # the recorder adapts its reader to what the publisher offers.
  if ! record_while "$dir" /skeleton \
      '$PUB --topics skeleton --best-effort -n 100 -r 100 --linger 1 --json "$DIR/published.json" 2>"$DIR/publisher.err"'; then
    fail "besteffort: namespace run" "$dir/record.err" "$dir/publisher.err"
  elif [ "$(cat "$dir/record.rc")" != 0 ]; then
    fail "besteffort: record exit $(cat "$dir/record.rc")" "$dir/record.out" "$dir/record.err"
  elif tools/interop/run.sh --exec python tools/dds/check_recorded.py "$dir/published.json" "$dir/rec.mcap"; then
    echo "ok besteffort: a best-effort publisher recorded in full with the default settings"; passed=$((passed + 1))
  else
    fail "besteffort: bag differs from what was published"
  fi
fi

if want malformed; then
  dir=$OUT/malformed
  if ! record_while "$dir" "/skeleton /skeleton_bad" \
      '$PUB --topics skeleton -n 100 -r 100 --linger 1 --json "$DIR/good.json" 2>"$DIR/good.err" & good=$!
       $PUB --topics malformed --skeleton-topic /skeleton_bad -n 20 -r 20 2>"$DIR/bad.err" || exit 11
       wait $good'; then
    fail "malformed: namespace run" "$dir/record.err" "$dir/good.err" "$dir/bad.err"
  elif [ "$(cat "$dir/record.rc")" != 3 ]; then
    fail "malformed: record exit $(cat "$dir/record.rc"), expected 3" "$dir/record.out" "$dir/record.err"
  elif ! grep -q "^  /skeleton_bad (autoact_msgs/msg/Skeleton3D): 0 messages, 0 bytes, 0 dropped, 20 rejected" "$dir/record.out" \
       || ! grep -q "^  /skeleton (autoact_msgs/msg/Skeleton3D): 100 messages, .* 0 dropped, 0 rejected" "$dir/record.out"; then
    fail "malformed: summary" "$dir/record.out"
  elif tools/interop/run.sh --exec python tools/dds/check_recorded.py "$dir/good.json" "$dir/rec.mcap"; then
    echo "ok malformed: 20 of 20 bad samples rejected, the good topic complete, exit 3"; passed=$((passed + 1))
  else
    fail "malformed: the good topic is not complete"
  fi
fi

if want diskfull; then
  dir=$OUT/diskfull
  mkdir -p "$dir/tmpfs"
  set +e
  DIR=$dir AUTOACT=$AUTOACT NETNS=$HERE/netns.sh timeout 120 unshare -m bash -c '
    set -e
    mount -t tmpfs -o size=2m tmpfs "$DIR/tmpfs"
    "$NETNS" bash -c "
      \"\$AUTOACT\" -q record /skeleton -o \"\$DIR/tmpfs/rec.mcap\" --compression none --flush-interval 0.2 \
        --max-duration 60 >\"\$DIR/record.out\" 2>\"\$DIR/record.err\" &
      rec=\$!
      sleep 0.5
      tools/interop/run.sh --exec python tools/dds/publish_cyclone.py --topics skeleton --wholebody \
        -n 3000 -r 1000 --linger 0 2>\"\$DIR/publisher.err\" &
      pub=\$!
      wait \$rec; echo \$? >\"\$DIR/record.rc\"
      wait \$pub || true"
    cp "$DIR/tmpfs/rec.mcap" "$DIR/rec.mcap"   # the tmpfs goes away with this namespace
    df -k "$DIR/tmpfs" | tail -1 >"$DIR/df.txt"'
  rc=$?
  set -e
  rrc=0
  if [ $rc -ne 0 ]; then
    fail "diskfull: namespace run exited $rc" "$dir/record.err" "$dir/publisher.err"
  elif [ "$(cat "$dir/record.rc")" != 1 ] || ! grep -q "tmpfs/rec.mcap" "$dir/record.err"; then
    fail "diskfull: record exit $(cat "$dir/record.rc"), expected 1 and an error naming the file" "$dir/record.err"
  elif "$AUTOACT" -q recover "$dir/rec.mcap" -o "$dir/recovered.mcap" >"$dir/recover.out" || rrc=$?; [ $rrc -ne 3 ]; then
    fail "diskfull: recover exited $rrc, expected 3" "$dir/recover.out"
  elif ! "$AUTOACT" info "$dir/recovered.mcap" | grep -q "^verdict: valid"; then
    fail "diskfull: recovered bag not valid"
  else
    echo "ok diskfull: $(grep -m1 -o 'Error.*' "$dir/record.err" | cut -c1-160); recover: $(head -1 "$dir/recover.out")"
    passed=$((passed + 1))
  fi
fi

echo "record: $passed passed, $failed failed"
[ $failed -eq 0 ]
