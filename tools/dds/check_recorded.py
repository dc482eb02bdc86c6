#!/usr/bin/env python3
"""Compares what tools/dds/publish_cyclone.py published (--json PUB) with the bag `autoact record`
wrote (or `autoact recover` restored), read with the Python `mcap` reader and the
`mcap-ros2-support` decoder — independent of autoact — message by message: every published
message is there, once, in order, on its topic with its type and content.

Usage: check_recorded.py PUB.json [PUB.json ...] BAG.mcap [--prefix] [--count-only]
  several PUB.json: publisher runs one after another (their messages concatenated, in order).
  --prefix      the bag may end early (a crash): its messages must be the first ones published,
                in order, with no gap and nothing extra.
  --count-only  only count messages per topic (no decoding; fast, for load runs). PUB.json may
                then also be publish_cyclone.py --counts output; counts of all PUBs are summed.
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


def count_only(pubs, bag) -> int:
    published = {}
    for doc in pubs:
        if "topics" in doc:
            for topic, c in doc["topics"].items():
                published[topic] = published.get(topic, 0) + c["published"]
        else:
            for m in doc["messages"]:
                published[m["topic"]] = published.get(m["topic"], 0) + 1
    got = {}
    with open(bag, "rb") as f:
        for _, channel, _ in make_reader(f).iter_messages(log_time_order=False):
            got[channel.topic] = got.get(channel.topic, 0) + 1
    failures = []
    for topic in sorted(set(published) | set(got)):
        p, r = published.get(topic, 0), got.get(topic, 0)
        if p == r:
            print(f"ok {topic}: {r}/{p} messages")
        else:
            failures.append(f"{topic}: recorded {r} of {p} messages")
    for f in failures:
        print(f"FAIL {f}")
    print(f"total: published {sum(published.values())} recorded {sum(got.values())}")
    return 1 if failures else 0


def main() -> int:
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    prefix = "--prefix" in sys.argv
    if len(args) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    pubs = [json.loads(Path(a).read_text()) for a in args[:-1]]
    if "--count-only" in sys.argv:
        return count_only(pubs, args[-1])
    published = [m for doc in pubs for m in doc["messages"]]
    got = {}
    with open(args[-1], "rb") as f:
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
