#!/usr/bin/env python3
"""Write the small pose bag (see pose_bag.py) as OUT.mcap with mcap_ros2.writer.Writer, plus
OUT.expected.json. Usage: write_with_mcap_ros2.py OUT.mcap"""

import sys
from pathlib import Path

from mcap_ros2.writer import Writer

import pose_bag

METADATA = [{"name": "autoact_interop", "metadata": {"writer": "mcap_ros2", "layout": "h36m-17"}}]


def main(out: Path) -> None:
    if out.suffix != ".mcap":
        sys.exit("usage: write_with_mcap_ros2.py OUT.mcap")
    expected = []
    with open(out, "wb") as f:
        writer = Writer(f, chunk_size=4096)  # small chunks: several chunks, all indexed
        schema = writer.register_msgdef(pose_bag.TYPE, pose_bag.definition())
        for seq, (t_ns, msg) in enumerate(pose_bag.frames()):
            writer.write_message(pose_bag.TOPIC, schema, msg, log_time=t_ns, publish_time=t_ns, sequence=seq)
            expected.append({"topic": pose_bag.TOPIC, "schema": pose_bag.TYPE, "log_time": t_ns,
                             "publish_time": t_ns, "message": msg})
        for m in METADATA:  # mcap_ros2's Writer has no metadata call: use its mcap writer
            writer._writer.add_metadata(m["name"], m["metadata"])
        writer.finish()
    print(f"wrote {out} ({len(expected)} messages) and {pose_bag.write_expected(out, expected, METADATA)}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: write_with_mcap_ros2.py OUT.mcap")
    main(Path(sys.argv[1]))
