#!/usr/bin/env python3
"""Compares what tools/dds/publish_cyclone.py published (--json PUB) with what
`dds_record_probe --hex` received (PROBE.jsonl), message by message:

- every published message arrived, once, in order, on the right topic with the right ROS type;
- per writer the RTPS sequence numbers are contiguous (no drops, no duplicates);
- each sample's bytes start with the CDR little-endian encapsulation header 00 01 00 00 and
  decode (with `rosbags`, from the .msg files in schemas/) to exactly the published content.

Usage: check_probe.py PUB.json PROBE.jsonl   (prints `ok ...` lines, exits 1 on any FAIL)
"""

import json
import math
import struct
import sys
from pathlib import Path

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "interop"))
from interop_common import to_plain  # noqa: E402  (shared decoded-object -> plain converter)

SCHEMAS = HERE.parent.parent / "schemas"


def typestore():
    """A typestore holding exactly the repository's .msg definitions."""
    types = {}
    for path in sorted(SCHEMAS.glob("*/msg/*.msg")):
        name = f"{path.parent.parent.name}/msg/{path.stem}"
        types.update(get_types_from_msg(path.read_text(), name))
    store = get_typestore(Stores.EMPTY)
    store.register(types)
    return store


def same(expected, got, path, failures):
    if isinstance(expected, dict):
        if isinstance(got, dict):  # rosbags adds __msgtype__ and the .msg constants (UPPER_CASE)
            got = {k: v for k, v in got.items() if not k.startswith("__") and not k.isupper()}
        if not isinstance(got, dict) or set(expected) != set(got):
            failures.append(f"{path}: fields {sorted(got) if isinstance(got, dict) else got!r} != {sorted(expected)}")
            return
        for k in expected:
            same(expected[k], got[k], f"{path}.{k}", failures)
    elif isinstance(expected, list):
        if not isinstance(got, list) or len(got) != len(expected):
            failures.append(f"{path}: {got!r} != {expected!r}")
            return
        for i, (e, g) in enumerate(zip(expected, got)):
            same(e, g, f"{path}[{i}]", failures)
    elif isinstance(expected, float):
        f32 = struct.unpack("<f", struct.pack("<f", expected))[0]
        if not (isinstance(got, float) and (got == expected or got == f32 or (math.isnan(got) and math.isnan(expected)))):
            failures.append(f"{path}: {got!r} != {expected!r}")
    elif got != expected or type(got) is not type(expected):
        failures.append(f"{path}: {got!r} != {expected!r}")


def main() -> int:
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    published = json.loads(Path(sys.argv[1]).read_text())["messages"]
    received = [json.loads(line) for line in Path(sys.argv[2]).read_text().splitlines() if line.strip()]
    store = typestore()
    failures = []
    topics = sorted({m["topic"] for m in published})
    for topic in topics:
        pub = [m for m in published if m["topic"] == topic]
        got = [r for r in received if r["topic"] == topic]
        if len(got) != len(pub):
            failures.append(f"{topic}: received {len(got)} of {len(pub)} messages")
        writers = {r["writer"] for r in got}
        for w in sorted(writers):
            seqs = [r["seq"] for r in got if r["writer"] == w]
            if seqs != list(range(seqs[0], seqs[0] + len(seqs))):
                failures.append(f"{topic}: writer {w} sequence numbers not contiguous: {seqs}")
        for i, (p, r) in enumerate(zip(pub, got)):
            where = f"{topic}[{i}]"
            if r["type"] != p["type"]:
                failures.append(f"{where}: type {r['type']} != {p['type']}")
                continue
            raw = bytes.fromhex(r["cdr"])
            if raw[:4] != b"\x00\x01\x00\x00" or r["len"] != len(raw):
                failures.append(f"{where}: header {raw[:4].hex()} / len {r['len']} vs {len(raw)}")
                continue
            try:
                msg = to_plain(store.deserialize_cdr(raw, p["type"]))
            except Exception as e:  # noqa: BLE001  (any decode failure is a FAIL line)
                failures.append(f"{where}: does not decode as {p['type']}: {e}")
                continue
            same(p["content"], msg, where, failures)
        if not [f for f in failures if f.startswith(topic + ":") or f.startswith(topic + "[")]:
            print(f"ok {topic}: {len(got)}/{len(pub)} messages decoded and equal, "
                  f"{len(writers)} writer(s), sequence numbers contiguous")
    unexpected = sorted({r["topic"] for r in received} - set(topics))
    if unexpected:
        failures.append(f"samples on unexpected topics {unexpected}")
    for f in failures[:50]:
        print(f"FAIL {f}")
    if len(failures) > 50:
        print(f"FAIL ... and {len(failures) - 50} more")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
