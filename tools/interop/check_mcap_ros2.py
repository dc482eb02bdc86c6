#!/usr/bin/env python3
"""Check MCAP files / rosbag2 directories against their .expected.json with the Python `mcap`
reader + `mcap-ros2-support` decoder. Usage: check_mcap_ros2.py FILE.mcap|ROSBAG2_DIR ..."""

from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from interop_common import Mismatch, bag_files, parse_msgdef, run, to_plain


def read_mcap(path: Path):
    messages, metadata, defs = [], [], {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        profile = reader.get_header().profile
        if profile != "ros2":
            raise Mismatch(f"{path.name}: header profile is {profile!r}, not 'ros2'")
        summary = reader.get_summary()
        if summary is None:
            raise Mismatch(f"{path.name}: no summary section (files must be chunked and indexed)")
        if not summary.chunk_indexes:
            raise Mismatch(f"{path.name}: summary has no chunk indexes (files must be chunked and indexed)")
        for schema in summary.schemas.values():
            if schema.encoding != "ros2msg":
                raise Mismatch(f"{path.name}: schema {schema.name} has encoding {schema.encoding!r}, not 'ros2msg'")
            defs[schema.id] = parse_msgdef(schema.name, schema.data.decode())
        for channel in summary.channels.values():
            if channel.message_encoding != "cdr":
                raise Mismatch(f"{path.name}: channel {channel.topic} has message encoding "
                               f"{channel.message_encoding!r}, not 'cdr'")
            if channel.schema_id not in defs:
                raise Mismatch(f"{path.name}: channel {channel.topic} has no schema")
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            messages.append({"topic": channel.topic, "schema": schema.name, "log_time": message.log_time,
                             "publish_time": message.publish_time, "message": to_plain(decoded),
                             "defs": defs[schema.id]})
        stats = summary.statistics
        if stats is not None and stats.message_count != len(messages):
            raise Mismatch(f"{path.name}: statistics say {stats.message_count} messages, read {len(messages)}")
        metadata = [(m.name, dict(m.metadata)) for m in reader.iter_metadata()]
    return messages, metadata


def read(target: Path):
    messages, metadata = [], []
    for path in bag_files(target) if target.is_dir() else [target]:
        m, md = read_mcap(path)
        messages += m
        metadata += md
    return messages, metadata


if __name__ == "__main__":
    run("mcap_ros2", read, log_time_order=False)
