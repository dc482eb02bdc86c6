#!/usr/bin/env python3
"""Check MCAP files / rosbag2 directories against their .expected.json with `rosbags` AnyReader
(it builds the message types from each file's ros2msg schema text itself).
Usage: check_rosbags.py FILE.mcap|ROSBAG2_DIR ...

rosbags rejects a header profile other than 'ros2' on its own. It exposes neither publish_time
nor MCAP metadata records, so those two are checked by the other readers only."""

from pathlib import Path

from rosbags.highlevel import AnyReader
from rosbags.interfaces import MessageDefinitionFormat

from interop_common import Mismatch, parse_msgdef, run, to_plain


def read(target: Path):
    messages = []
    with AnyReader([target]) as reader:
        defs = {}
        for c in reader.connections:
            if c.msgdef.format != MessageDefinitionFormat.MSG:
                raise Mismatch(f"topic {c.topic}: schema encoding is {c.msgdef.format.name}, not ros2msg")
            if c.ext.serialization_format != "cdr":
                raise Mismatch(f"topic {c.topic}: message encoding is {c.ext.serialization_format!r}, not 'cdr'")
            defs[c.id] = parse_msgdef(c.msgtype, c.msgdef.data)
        for c, log_time, raw in reader.messages():
            messages.append({"topic": c.topic, "schema": c.msgtype, "log_time": log_time,
                             "publish_time": None, "message": to_plain(reader.deserialize(raw, c.msgtype)),
                             "defs": defs[c.id]})
        if reader.message_count != len(messages):
            where = "metadata.yaml" if target.is_dir() else "the summary"
            raise Mismatch(f"{where} says {reader.message_count} messages, read {len(messages)}")
    return messages, None


if __name__ == "__main__":
    run("rosbags", read, log_time_order=True)
