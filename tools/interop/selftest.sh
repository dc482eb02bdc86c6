#!/usr/bin/env bash
# Self-test of the interop checks without autoact: write the pose bag with both reference writers,
# check that run.sh passes on them with all three readers, and that it fails (with a FAIL line)
# on a corrupted expected value, on a file that is not chunked, on a wrong profile, on a missing
# .expected.json and on an empty directory. Usage: tools/interop/selftest.sh
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
RUN=$HERE/run.sh
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
problems=0 passes=0

# expect_fail NAME DIR PATTERN: run.sh DIR must exit non-zero and print a FAIL line matching PATTERN.
expect_fail() {
  local out rc=0
  out=$("$RUN" "$2" 2>/dev/null) || rc=$?
  if [ "$rc" -ne 0 ] && grep -q "^FAIL .*$3" <<<"$out" && tail -n 1 <<<"$out" | grep -Eq '^interop: [0-9]+ passed, [1-9][0-9]* failed$'; then
    echo "selftest ok: $1 is caught: $(grep -m1 "^FAIL .*$3" <<<"$out")"; passes=$((passes + 1))
  else
    echo "selftest FAILED: $1 was not caught (exit $rc):"; echo "$out"; problems=$((problems + 1))
  fi
}

good=$work/good
mkdir "$good"
"$RUN" --exec python "$HERE/write_with_mcap_ros2.py" "$good/mcap_ros2_pose.mcap"
"$RUN" --exec python "$HERE/write_with_rosbags.py" "$good/rosbags_pose"
if out=$("$RUN" "$good") && [ "$(tail -n 1 <<<"$out")" = "interop: 6 passed, 0 failed" ]; then
  echo "$out"; echo "selftest ok: both reference files pass with all three readers"; passes=$((passes + 1))
else
  echo "$out"; echo "selftest FAILED: the reference files do not pass"; problems=$((problems + 1))
fi

# One expected value off by 1 cm: /skeleton[12].positions[3].x
cp -r "$good" "$work/corrupt"
python3 - "$work/corrupt/rosbags_pose.expected.json" <<'EOF'
import json, sys
doc = json.load(open(sys.argv[1]))
doc["messages"][12]["message"]["positions"][3]["x"] += 0.01
json.dump(doc, open(sys.argv[1], "w"))
EOF
expect_fail "a corrupted expected value" "$work/corrupt" 'rosbags_pose: /skeleton\[12\]\.positions\[3\]\.x: expected'

# Unchunked MCAP and a wrong profile (otherwise the same content, written with the mcap library).
for variant in unchunked noprofile; do
  mkdir "$work/$variant"
  cp "$good/mcap_ros2_pose.expected.json" "$work/$variant/pose.expected.json"
  "$RUN" --exec python - "$good/mcap_ros2_pose.mcap" "$work/$variant/pose.mcap" "$variant" <<'EOF'
import sys
from mcap.reader import make_reader
from mcap.writer import Writer
src, dst, variant = sys.argv[1:]
reader = make_reader(open(src, "rb"))
writer = Writer(open(dst, "wb"), use_chunking=variant != "unchunked")
writer.start(profile="" if variant == "noprofile" else "ros2", library="selftest")
ids = {}
for schema, channel, message in reader.iter_messages(log_time_order=False):
    if channel.id not in ids:
        sid = writer.register_schema(schema.name, schema.encoding, schema.data)
        ids[channel.id] = writer.register_channel(channel.topic, channel.message_encoding, sid, channel.metadata)
    writer.add_message(ids[channel.id], message.log_time, message.data, message.publish_time, message.sequence)
for m in reader.iter_metadata():
    writer.add_metadata(m.name, m.metadata)
writer.finish()
EOF
done
expect_fail "an unchunked file" "$work/unchunked" 'no chunk indexes'
expect_fail "an empty header profile" "$work/noprofile" "profile is \"\", not \"ros2\""

mkdir "$work/missing"
cp "$good/mcap_ros2_pose.mcap" "$work/missing/"
expect_fail "a missing .expected.json" "$work/missing" 'no mcap_ros2_pose.expected.json beside it'

mkdir "$work/empty"
expect_fail "an empty directory" "$work/empty" 'a check that checks nothing fails'

echo "selftest: $passes passed, $problems failed"
[ "$problems" -eq 0 ]
