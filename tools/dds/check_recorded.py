#!/usr/bin/env python3
"""Compares what tools/dds/publish_cyclone.py published (--json PUB) with the bag `autoact record`
wrote (or `autoact recover` restored), read with the Python `mcap` reader and the
`mcap-ros2-support` decoder — independent of autoact — message by message: every published
message is there, once, in order, on its topic with its type and content.

Usage: check_recorded.py PUB.json BAG.mcap [--prefix]
  --prefix   the bag may end early (a crash): its messages must be the first ones published,
             in order, with no gap and nothing extra.
Prints `ok ...` lines; exits 1 on any FAIL.
"""

import json
import sys
from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "interop"))
from check_probe import same  # noqa: E402  (field-by-field comparison, float32-aware)
from interop_common import to_plain  # noqa: E402


def main() -> int:
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    prefix = "--prefix" in sys.argv
    if len(args) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    published = json.loads(Path(args[0]).read_text())["messages"]
    got = {}
    with open(args[1], "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            got.setdefault(channel.topic, []).append((schema.name, to_plain(decoded)))
    failures = []
    for topic in sorted({m["topic"] for m in published}):
        pub = [m for m in published if m["topic"] == topic]
        rec = got.get(topic, [])
        if prefix:
            if len(rec) > len(pub):
                failures.append(f"{topic}: {len(rec)} recorded, only {len(pub)} published")
        elif len(rec) != len(pub):
            failures.append(f"{topic}: recorded {len(rec)} of {len(pub)} messages")
        for i, ((type_name, msg), p) in enumerate(zip(rec, pub)):
            if type_name != p["type"]:
                failures.append(f"{topic}[{i}]: type {type_name} != {p['type']}")
                continue
            same(p["content"], msg, f"{topic}[{i}]", failures)
        if not [f for f in failures if f.startswith(topic)]:
            print(f"ok {topic}: {len(rec)}/{len(pub)} messages, in order, equal to what was published")
    extra = sorted(set(got) - {m["topic"] for m in published})
    if extra:
        failures.append(f"unexpected topics {extra}")
    for f in failures[:40]:
        print(f"FAIL {f}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
